//! The *deform* switch through the app's state and the objects panel: the bundled string pushed
//! on the planar device and the drum skin pressed by the spatial hand move, the views get their
//! moving shape from what the loop publishes, and the rest shape comes back when the switch is
//! off; a scene swap asks the new loop again (from rest); a rigid object has no switch to turn.
#![cfg(feature = "gui")]

mod common;

use common::{STRING_Y, below_the_string, move_hand, push_the_string, stepped_deformable};
use nurbs::{Vec2, Vec3};
use viewer::gui::state::AppState;

/// The middle of the moving string as the 2-D view draws it (its curve's middle sample).
fn drawn_middle(state: &AppState) -> Vec2 {
    let view = state
        .deform
        .moving_view
        .as_ref()
        .expect("the moving string");
    let curve = &view.curves[0];
    curve[curve.len() / 2]
}

/// Deform on, the string pushed 10 mm past its middle from below: the loop says it deforms,
/// every tick records the displacement at the CP, and the string the 2-D view draws is the
/// loop's: its middle is moved by what the newest tick says (the publication is at most 17 ms
/// old: after 0.7 s of hold the string is still to 1 µm). Off: the rigid rest shape again.
#[test]
fn the_pushed_string_is_drawn_where_the_loop_has_it() {
    let mut state = stepped_deformable();
    assert_eq!(state.scene.rendered, Some(0));
    let info = state.deform.info.clone().expect("the string is deformable");
    assert!(!info.surface);
    // The string's first mode, (1/2L)√(T/ρ) = 44.2 Hz, stiffened a little by its 9 spans.
    let f1 = info.lowest_mode_hz.clone().expect("a mode");
    assert!((44.0..46.0).contains(&f1), "{f1} Hz");
    below_the_string(&mut state);
    state.set_deform(true);
    assert!(state.deform.deforming && state.deform.error.is_none());
    // At rest: the moving string is the rest one.
    assert!((drawn_middle(&state).y - STRING_Y).abs() < 1e-6);
    push_the_string(&mut state, 0.01);
    let k = state.latest().expect("ticks").tick;
    assert_eq!(k.patch, Some(0));
    let w = k.deform.expect("a deforming tick");
    assert!(w.y > 0.004, "{w}");
    let middle = drawn_middle(&state);
    assert!(
        (middle.y - (STRING_Y + w.y)).abs() < 1e-5,
        "drawn at {middle}, the tick says {w} (the CP at {})",
        k.cp
    );

    state.set_deform(false);
    assert!(!state.deform.deforming && state.deform.moving_view.is_none());
    state.step(300);
    let k = state.latest().expect("ticks").tick;
    assert!(k.deform.is_none());
    assert!((k.cp.y - STRING_Y).abs() < 1e-6, "{}", k.cp);
}

/// Another scene while deforming: the new loop renders it rigid, at rest, and the app asks it
/// to deform again when its object is deformable (the switch stays on); a rigid one turns the
/// switch off.
#[test]
fn a_scene_swap_keeps_the_switch_when_it_can() {
    let mut state = stepped_deformable();
    below_the_string(&mut state);
    state.set_deform(true);
    push_the_string(&mut state, 0.01);
    state.open_bundled("deformable");
    assert!(state.deform.requested && state.deform.deforming);
    let view = state
        .deform
        .moving_view
        .as_ref()
        .expect("the moving string");
    let rest = &state.scene.objects[0].curves[0];
    let off = view.curves[0]
        .iter()
        .zip(rest)
        .map(|(a, b)| (*a - *b).length())
        .fold(0.0, f32::max);
    assert!(off < 1e-6, "the new loop starts from rest: {off} m off");
    state.open_bundled("thesis-2d");
    assert!(!state.deform.requested && !state.deform.deforming);
    assert!(state.deform.info.is_none());
    state.set_deform(true);
    assert!(
        state
            .deform
            .error
            .as_deref()
            .is_some_and(|e| e.contains("rigid"))
    );
}

/// The drum skin felt in the 3-D view, deform on, pressed 3 mm into its centre: the skin under
/// the hand moves by the part of the press the contact spring does not take (the series share:
/// the force over its point stiffness), the 3-D view shows the moving shape, and off takes it
/// away.
#[test]
fn the_pressed_drum_moves_in_the_3d_view() {
    let mut state = stepped_deformable();
    state.render_object(1);
    let spatial = state.spatial.as_ref().expect("the 3-D view");
    assert_eq!(spatial.object(), Some(1));
    assert!(state.deform.info.as_ref().is_some_and(|i| i.surface));
    state.set_deform(true);
    assert!(state.deform.deforming, "{:?}", state.deform.error);
    move_hand(&mut state, Vec3::new(0.0, 0.09, -0.003), 100);
    state.step(600);
    let k = state.latest().expect("ticks").tick;
    let w = -k.deform.expect("deforming").z;
    // F = K (d − w) with K = 1000 N/m: the contact takes the rest of the 3 mm.
    assert!(
        (k.normal_force_n - 1000.0 * (0.003 - w)).abs() < 1e-3,
        "F {} N, the skin moved {w} m",
        k.normal_force_n
    );
    let spatial = state.spatial.as_ref().expect("the 3-D view");
    assert!(spatial.view.is_moving());
    let moving = state.deform.moving.as_ref().expect("the moving skin");
    let surfaces = moving.surface_views().expect("surfaces");
    let centre = surfaces[0].point(0.5, 0.5);
    assert!(
        (centre.z + w).abs() < 1e-5,
        "drawn at {centre}, moved {w} m"
    );

    state.set_deform(false);
    assert!(!state.deform.deforming);
    assert!(!state.spatial.as_ref().expect("3-D").view.is_moving());
}

/// The objects panel has the switch in a scene with a deformable object (on the string: on;
/// its hover names the parameters), and none in a scene without.
#[test]
fn the_objects_panel_has_the_switch_where_it_means_something() {
    use eframe::egui;
    use egui_kittest::Harness;
    use egui_kittest::kittest::Queryable;
    use viewer::gui::ViewerUi;
    let panel = |state: AppState| {
        Harness::builder()
            .with_size(egui::Vec2::new(300.0, 400.0))
            .build_ui_state(
                |ui, v: &mut ViewerUi| v.objects_ui(ui),
                ViewerUi::new(state),
            )
    };
    let mut h = panel(stepped_deformable());
    h.run_steps(2);
    h.get_by_label("deform").click();
    h.run_steps(2);
    assert!(h.state().state.deform.deforming);
    let hover = h
        .state()
        .state
        .deform
        .info
        .as_ref()
        .map(viewer::gui::moving_shape::DeformInfo::describe)
        .expect("the string's parameters");
    assert!(hover.contains("tension 5 N") && hover.contains("first natural frequency 44"));
    h.get_by_label("deform").click();
    h.run_steps(2);
    assert!(!h.state().state.deform.deforming);

    let mut h = panel(common::stepped());
    h.run_steps(2);
    assert!(h.query_by_label("deform").is_none());
}

/// On the loop's own thread (as the app runs it): the switch's answer comes back through the
/// reply channel and the moving shape through the shared one, and both are taken in by
/// `poll` without waiting. Polled for up to 10 s of wall time (nothing here is timed).
#[test]
fn the_threaded_loop_answers_and_publishes() {
    use std::time::{Duration, Instant};
    let scene = scene::Bundled::find("deformable")
        .and_then(|b| b.scene().ok())
        .expect("the bundled deformable scene");
    let mut state = AppState::new("deformable", scene, true, None).expect("app");
    assert!(state.is_threaded());
    state.set_deform(true);
    let waited = Instant::now();
    while !(state.deform.deforming && state.deform.moving_view.is_some())
        && waited.elapsed() < Duration::from_secs(10)
    {
        std::thread::sleep(Duration::from_millis(5));
        state.poll();
    }
    assert!(state.deform.deforming, "{:?}", state.deform.error);
    let view = state
        .deform
        .moving_view
        .as_ref()
        .expect("the published shape");
    assert_eq!(view.curves.len(), 1);
    state.set_deform(false);
    let waited = Instant::now();
    while state.deform.deforming && waited.elapsed() < Duration::from_secs(10) {
        std::thread::sleep(Duration::from_millis(5));
        state.poll();
    }
    assert!(!state.deform.deforming && state.deform.moving_view.is_none());
    state.shutdown();
}
