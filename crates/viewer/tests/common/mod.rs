//! What the GUI's test files share: the bundled scenes stepped in place, the scripted hand
//! movements on thesis-2d's right arc and on thesis-3d's bump, the closed forms they are
//! checked against, and the kittest harnesses.
// Each test file is its own crate and uses a part of this module.
#![allow(dead_code)]

use eframe::egui;
use egui_kittest::Harness;
use friction::Mode;
use nurbs::{Vec2, Vec3};
use viewer::gui::state::AppState;
use viewer::gui::view3d::{self, Camera3d};
use viewer::gui::{ViewerUi, view};

// ----- thesis-2d through the planar device -----

/// The bundled scene `name`, stepped in place (no thread, no clock).
pub fn stepped_scene(name: &str) -> AppState {
    AppState::stepped(name).unwrap_or_else(|e| panic!("{e:#}"))
}

/// thesis-2d, stepped in place.
pub fn stepped() -> AppState {
    stepped_scene("thesis-2d")
}

/// The right arc of thesis-2d: centre (−0.02, 0.06), radius 0.04, from 0° (at (0.02, 0.06))
/// to 60° (the apex (0, 0.0946)); the object lies inside the circle.
pub fn on_arc(radius_m: f32, degrees: f32) -> Vec2 {
    let a = degrees.to_radians();
    Vec2::new(-0.02, 0.06) + Vec2::new(a.cos(), a.sin()) * radius_m
}

/// Moves the hand's target from where it is to `to` in a straight line over `ms` ticks (one
/// target per tick, as a mouse drag sends them), then steps.
pub fn drag(state: &mut AppState, to: Vec2, ms: usize) {
    let from = state.hand_target;
    for i in 1..=ms {
        let target = from + (to - from) * (i as f32 / ms as f32);
        assert!(state.set_hand_target(target), "{target} out of reach");
        state.step(1);
    }
}

/// Along the arc of `radius_m` from `from_deg` to `to_deg` over `ms` ticks.
pub fn slide(state: &mut AppState, radius_m: f32, from_deg: f32, to_deg: f32, ms: usize) {
    for i in 1..=ms {
        let d = from_deg + (to_deg - from_deg) * (i as f32 / ms as f32);
        assert!(state.set_hand_target(on_arc(radius_m, d)));
        state.step(1);
    }
}

/// Approach the right arc from outside at 30°, press the hand's target 10 mm into it (the
/// relaxed 300 N/m hand against K = 1000 N/m settles the handle about 2.3 mm deep), hold.
pub fn press(state: &mut AppState) {
    drag(state, on_arc(0.05, 30.0), 300);
    state.step(200);
    drag(state, on_arc(0.03, 30.0), 200);
    state.step(300);
}

/// The whole scripted interaction: press, then drag along the arc from 30° to 55°.
pub fn press_and_slide(state: &mut AppState) {
    press(state);
    slide(state, 0.03, 30.0, 55.0, 1000);
}

/// Whether a tick's normal force is K · depth with K = 1000 N/m to within what the GO's offset
/// from the CP on thesis-2d's 40 mm arcs allows, `K |GO − CP|² / 2R`, and f32 rounding.
pub fn penalty_within_curvature(t: &host::tick::Tick) -> bool {
    let s = (t.go - t.cp).length();
    (t.normal_force_n - 1000.0 * t.depth_m).abs() <= 1000.0 * s * s / (2.0 * 0.04) + 1e-5
}

/// The modes the telemetry went through, consecutive repeats collapsed.
pub fn mode_sequence(state: &AppState) -> Vec<Mode> {
    let mut seq: Vec<Mode> = Vec::new();
    for s in &state.telemetry.history {
        if seq.last() != Some(&s.tick.mode) {
            seq.push(s.tick.mode);
        }
    }
    seq
}

// ----- editing thesis-2d -----

/// The middle control point of thesis-2d's right arc, P_1 = (0.02, 0.0831), weight
/// cos 30° = 0.866: the arc's centre (−0.02, 0.06) sees it at 30°, halfway along the arc.
pub const MIDDLE: scene::edit::PointRef = scene::edit::PointRef {
    object: 0,
    patch: 0,
    index: 1,
};

/// The unit vector from the right arc's centre towards P_1 (outward, at 30°).
pub fn outward() -> Vec2 {
    let a = 30f32.to_radians();
    Vec2::new(a.cos(), a.sin())
}

// ----- thesis-3d through the spatial hand -----

/// The apex of thesis-3d's bicubic bump. Its control net is linear in x and y (x from −0.04
/// to 0.04, y from 0.06 to 0.12, evenly spaced) with the four inner points raised 12 mm, so
/// the surface is z = 0.012 · 9 u(1 − u) v(1 − v), u = (x + 0.04)/0.08, v = (y − 0.06)/0.06
/// (the cubic Bernstein weights of the inner points sum to 3u(1 − u)): the apex is at
/// (0, 0.09, 0.00675), its normal +z, its radii of curvature 0.118 m (x) and 0.067 m (y).
pub const APEX: Vec3 = Vec3::new(0.0, 0.09, 0.00675);

/// The height of thesis-3d's bump over (x, y), from the closed form above.
pub fn bump_z(x: f32, y: f32) -> f32 {
    let u = (x + 0.04) / 0.08;
    let v = (y - 0.06) / 0.06;
    0.012 * 9.0 * u * (1.0 - u) * v * (1.0 - v)
}

/// Moves the spatial hand's target from where it is to `to` in `ms` ticks, then steps.
pub fn move_hand(state: &mut AppState, to: Vec3, ms: usize) {
    let from = state.spatial.as_ref().expect("3-D scene").target;
    for i in 1..=ms {
        let t = from + (to - from) * (i as f32 / ms as f32);
        state.spatial.as_mut().expect("3-D scene").set_target(t);
        state.step(1);
    }
}

/// The hand pressed `depth_m` straight down into the bump's apex and held.
pub fn press_apex(state: &mut AppState, depth_m: f32) {
    move_hand(state, APEX + Vec3::new(0.0, 0.0, 0.005), 300);
    move_hand(state, APEX - Vec3::new(0.0, 0.0, depth_m), 300);
    state.step(200);
}

/// thesis-3d, stepped in place, with its spatial loop.
pub fn stepped_3d() -> AppState {
    let state = stepped_scene("thesis-3d");
    assert!(state.spatial.as_ref().is_some_and(|s| s.has_loop()));
    state
}

// ----- the bundled deformable scene -----

/// The rest line of the bundled string (y, m): x from −40 to 40 mm, its outside below.
pub const STRING_Y: f32 = 0.115;

/// The bundled deformable scene (the string on the device, the drum skin object 1), stepped.
pub fn stepped_deformable() -> AppState {
    stepped_scene("deformable")
}

/// From the app's start, 5 mm below the string (its outside), the hand goes to 15 mm below its
/// middle and rests.
pub fn below_the_string(state: &mut AppState) {
    drag(state, Vec2::new(0.0, STRING_Y - 0.015), 300);
    state.step(200);
}

/// The hand's target pushed `depth_m` past the string's middle from below, and held 0.7 s.
pub fn push_the_string(state: &mut AppState, depth_m: f32) {
    drag(state, Vec2::new(0.0, STRING_Y + depth_m), 300);
    state.step(700);
}

// ----- harnesses -----

/// A light-themed harness of `size` drawing `show`, rendered through wgpu.
pub fn harness<'a>(
    size: [f32; 2],
    ui: ViewerUi,
    show: fn(&mut egui::Ui, &mut ViewerUi),
) -> Harness<'a, ViewerUi> {
    Harness::builder()
        .with_size(egui::Vec2::new(size[0], size[1]))
        .with_theme(egui::Theme::Light)
        .wgpu()
        .build_ui_state(show, ui)
}

/// A harness on the 2-D view alone, not rendered (pointer and keyboard input only).
pub fn view_2d_harness<'a>(state: AppState) -> Harness<'a, ViewerUi> {
    Harness::builder()
        .with_size(egui::Vec2::new(800.0, 600.0))
        .build_ui_state(
            |ui, v: &mut ViewerUi| view::view_2d_ui(ui, &mut v.state, &mut v.view),
            ViewerUi::new(state),
        )
}

/// A harness on the 3-D view with its wgpu pipelines installed.
pub fn harness_3d<'a>(state: AppState) -> Harness<'a, ViewerUi> {
    harness_3d_from(state, Camera3d::default())
}

/// [`harness_3d`] looking from `camera`'s direction (fitted to the scene).
pub fn harness_3d_from<'a>(state: AppState, camera: Camera3d) -> Harness<'a, ViewerUi> {
    use eframe::egui_wgpu;
    let render_state = egui_kittest::wgpu::create_render_state(
        egui_kittest::wgpu::default_wgpu_setup(),
        egui_wgpu::RendererOptions::PREDICTABLE,
    );
    view3d::install(&render_state);
    let mut ui = ViewerUi::new(state);
    ui.wgpu_installed = true;
    ui.camera3d = camera;
    let mut h = Harness::builder()
        .with_size(egui::Vec2::new(800.0, 600.0))
        .with_theme(egui::Theme::Light)
        .renderer(egui_kittest::wgpu::WgpuTestRenderer::from_render_state(
            render_state,
        ))
        .build_ui_state(
            |ui, v: &mut ViewerUi| {
                let installed = v.wgpu_installed;
                view3d::view_3d_ui(ui, &mut v.state, &mut v.camera3d, installed);
            },
            ui,
        );
    h.run_steps(2);
    h
}
