//! The panels rendered through wgpu (Mesa's software Vulkan in CI) and compared with the
//! snapshots in `tests/snapshots/` (`UPDATE_SNAPSHOTS=1 cargo test -p viewer --test snapshots`
//! rewrites them), each after a scripted interaction through the app's state.
#![cfg(feature = "gui")]

mod common;

use common::{
    MIDDLE, below_the_string, harness, harness_3d, harness_3d_from, move_hand, outward, press,
    press_and_slide, press_apex, push_the_string, stepped, stepped_3d, stepped_deformable,
};
use viewer::gui::{ViewerUi, view};

#[test]
fn snapshot_2d_view_pressed_into_the_curve() {
    let mut state = stepped();
    press(&mut state);
    let mut h = harness([800.0, 600.0], ViewerUi::new(state), |ui, v| {
        view::view_2d_ui(ui, &mut v.state, &mut v.view);
    });
    h.run_steps(2);
    h.snapshot("view_2d_thesis_2d_pressed");
}

#[test]
fn snapshot_telemetry_after_a_scripted_run() {
    let mut state = stepped();
    press_and_slide(&mut state);
    let mut h = harness([440.0, 820.0], ViewerUi::new(state), |ui, v| {
        v.telemetry_ui(ui);
    });
    h.run_steps(2);
    h.snapshot("telemetry_after_scripted_run");
}

#[test]
fn snapshot_invalid_material_error() {
    let mut state = stepped();
    state.materials.edited.mu_dynamic = 0.9;
    state.apply_material();
    let mut h = harness([300.0, 420.0], ViewerUi::new(state), |ui, v| {
        v.materials_ui(ui);
    });
    h.run_steps(2);
    h.snapshot("material_invalid_mu_dynamic");
}

/// An invalid scene file: the message names the file, the object, the patch and the field,
/// and says the running scene is unchanged (which still renders: thesis-2d's label stays).
#[test]
fn snapshot_invalid_scene_error() {
    let mut state = stepped();
    let mut scene: serde_json::Value =
        serde_json::from_str(include_str!("../../../scenes/thesis-2d.json")).expect("JSON");
    scene["objects"][0]["patches"][1]["weights"][1] = serde_json::json!(-0.5);
    state.open_text("bent.json", &scene.to_string());
    let e = state.files.error.clone().expect("refused");
    assert!(
        e.contains("bent.json") && e.contains("patch 1") && e.contains("weights"),
        "{e}"
    );
    assert_eq!(state.scene.label, "thesis-2d");
    let mut h = harness([1000.0, 80.0], ViewerUi::new(state), |ui, v| {
        v.scenes_ui(ui);
    });
    h.run_steps(2);
    h.snapshot("scene_invalid_weight");
}

#[test]
fn snapshot_whole_window_while_sliding() {
    let mut state = stepped();
    press_and_slide(&mut state);
    let mut h = harness([1400.0, 860.0], ViewerUi::new(state), |ui, v| v.ui(ui));
    h.run_steps(2);
    h.snapshot("viewer_window");
}

#[test]
fn snapshot_2d_view_editing_a_dragged_control_point() {
    let mut state = stepped();
    state.edit.enabled = true;
    state.edit.show_regions = true;
    let (p1, _) = viewer::gui::editing::control_point(&state.scene.model, MIDDLE).expect("P_1");
    assert!(state.move_point(MIDDLE, p1 + outward() * 0.006));
    assert_eq!(state.edit.selected, Some(MIDDLE));
    state.step(50);
    let mut h = harness([800.0, 600.0], ViewerUi::new(state), |ui, v| {
        view::view_2d_ui(ui, &mut v.state, &mut v.view);
    });
    h.run_steps(2);
    h.snapshot("view_2d_thesis_2d_edit_dragged");
}

/// Halfway through a drag of P_1 with the pointer: the edited arc (orange) drawn over the
/// running one, nothing applied yet.
#[test]
fn snapshot_2d_view_while_dragging_a_control_point() {
    let mut state = stepped();
    state.edit.enabled = true;
    state.edit.show_regions = true;
    let (p1, _) = viewer::gui::editing::control_point(&state.scene.model, MIDDLE).expect("P_1");
    let mut h = harness([800.0, 600.0], ViewerUi::new(state), |ui, v| {
        view::view_2d_ui(ui, &mut v.state, &mut v.view);
    });
    h.run_steps(2);
    let view = h.state().view;
    let rect = view.last_rect.expect("drawn");
    let at = view.screen_of(rect, p1);
    h.hover_at(at);
    h.run_steps(1);
    h.drag_at(at);
    h.run_steps(1);
    let to = view.screen_of(rect, p1 + outward() * 0.008);
    h.hover_at(to);
    h.run_steps(2);
    assert!(h.state().state.edit.drag.is_some());
    h.snapshot("view_2d_thesis_2d_edit_dragging");
}

#[test]
fn snapshot_3d_view_pressed_into_the_bump() {
    let mut state = stepped_3d();
    press_apex(&mut state, 0.002);
    harness_3d(state).snapshot("view_3d_thesis_3d_pressed");
}

/// The same press felt through the bump's tessellation at 2 mm: the facets the hand feels,
/// flat shaded, and the normal of the facet under the HIP.
#[test]
fn snapshot_3d_view_of_the_bump_felt_as_a_mesh() {
    let mut state = stepped_3d();
    {
        let spatial = state.spatial.as_mut().expect("3-D");
        spatial.set_tolerance(2e-3);
        spatial.set_render_mesh(true);
    }
    press_apex(&mut state, 0.002);
    harness_3d(state).snapshot("view_3d_thesis_3d_mesh");
}

/// The bundled string with deform on, its middle pushed from below by the hand's target 10 mm
/// past the rest line and held: the rest shape faint, the moving string (the loop's newest
/// shape) and its control polygon over it, the HIP in the dent.
#[test]
fn snapshot_2d_view_of_the_pushed_deforming_string() {
    let mut state = stepped_deformable();
    below_the_string(&mut state);
    state.set_deform(true);
    push_the_string(&mut state, 0.01);
    assert!(state.deform.deforming && state.deform.moving_view.is_some());
    let mut ui = ViewerUi::new(state);
    // Closer than the scene's fit (which takes in the drum's outline too): the string's 80 mm
    // across 640 points.
    ui.view = view::View2d {
        centre: nurbs::Vec2::new(0.0, common::STRING_Y),
        scale: 8000.0,
        fit_pending: false,
        last_rect: None,
    };
    let mut h = harness([800.0, 600.0], ui, |ui, v| {
        view::view_2d_ui(ui, &mut v.state, &mut v.view);
    });
    h.run_steps(2);
    h.snapshot("view_2d_deformable_string_pushed");
}

/// The drum skin (the deformable scene's object 1) with deform on, pressed 8 mm into its
/// centre by the spatial hand: the dented skin shaded, its control net moving with it, the
/// rest shape's faint grid over it, seen from 4° above the skin's plane.
#[test]
fn snapshot_3d_view_of_the_pressed_deforming_drum() {
    let mut state = stepped_deformable();
    state.render_object(1);
    state.set_deform(true);
    move_hand(&mut state, nurbs::Vec3::new(0.0, 0.09, -0.008), 100);
    state.step(600);
    assert!(state.deform.moving.is_some());
    let camera = viewer::gui::view3d::Camera3d {
        pitch_rad: 4f32.to_radians(),
        ..viewer::gui::view3d::Camera3d::default()
    };
    harness_3d_from(state, camera).snapshot("view_3d_deformable_drum_pressed");
}
