//! Editing thesis-2d through the app: control points dragged (through the state and with
//! the pointer), weights, knots and splits, refusals, undo and redo, and the force that
//! follows an edit.
#![cfg(feature = "gui")]

mod common;

use common::{MIDDLE, drag, on_arc, outward, stepped, view_2d_harness};
use eframe::egui;
use egui_kittest::Harness;
use friction::Mode;
use nurbs::Vec2;
use viewer::gui::ViewerUi;

/// Press the hand into the right arc at 30°, where P_1 pulls hardest, move P_1 outward by δ
/// and see the force follow.
///
/// Moving P_1 by δ·d̂ moves every C(u) by R_1(u)·δ·d̂, with R_1 the rational basis function:
/// for the quadratic Bézier arc with weights (1, w, 1), R_1(u) = 2u(1−u)w /
/// ((1−u)² + 2u(1−u)w + u²), so at u = 1/2, R_1 = w / (1 + w) = 0.866 / 1.866 = 0.464. The
/// arc and the hand's target are symmetric about the 30° line through P_1 (d̂), and the move
/// keeps that symmetry, so the closest point stays at u = 1/2 with the normal n = d̂: the
/// surface moves outward there by s = R_1(1/2)·δ·(d̂·n) = 0.464 δ, exactly (C is linear in
/// P_1 at fixed u).
///
/// At rest, the handle sits where the material's spring (K = 1000 N/m, F_N = K·depth) and
/// the hand's (k_h = 300 N/m, towards its target, d_t inside the surface) balance:
/// K·depth = k_h (d_t − depth), so F_N = K k_h / (K + k_h) · d_t. Moving the surface outward
/// by s with the target fixed makes d_t grow by s: ΔF_N = K k_h / (K + k_h) · s = 230.8 N/m
/// · 0.464 δ (a handle held rigidly would see K·s; the relaxed hand yields).
///
/// Tolerance: the encoders, through which the controller sees the handle: 4096 counts/rev
/// behind 10:1 capstans are 2π/40960 = 153 µrad per count at a joint, about 12 µm at the
/// handle through the 80 mm proximal links, so a measured depth is within half of that,
/// ±6 µm, and its penalty force within ±6 mN (K = 1000 N/m); and the mechanism's dry
/// friction, which holds the handle at rest wherever the net of the two springs along the
/// normal is below what the joints' Coulomb torques τ_c hold, F_fr = τ_c / max_i |(Jᵀ n)_i|:
/// the depth is then off by up to F_fr / (K + k_h), the normal force by K / (K + k_h) · F_fr
/// (about 0.04 N here). Each measurement is within that plus 8 mN of its prediction, their
/// difference within twice that (a rigidly held handle would see K·s = 1.86 N more, an
/// unchanged scene nothing).
/// The largest force along the tick's normal that the joints' dry friction holds at rest:
/// `τ_c / max_i |(Jᵀ n)_i|` at the tick's joint angles.
fn friction_hold_n(tick: &host::tick::Tick) -> f32 {
    let spec = device::spec::DeviceSpec::default();
    let arm = spec.validate().expect("default spec");
    let theta = tick.device.expect("device sample").theta_rad;
    let n = Vec2::new(tick.normal.x, tick.normal.y);
    let tau = arm.joint_torques(theta, n).expect("pose");
    spec.joint_coulomb_nm[0] / tau[0].abs().max(tau[1].abs())
}

#[test]
fn dragging_a_control_point_changes_the_scene_and_the_force_follows() {
    let mut state = stepped();
    // Approach from outside at 30°, the target 6 mm inside the arc (radius 40 mm).
    drag(&mut state, on_arc(0.05, 30.0), 300);
    state.step(200);
    drag(&mut state, on_arc(0.034, 30.0), 200);
    state.step(1500);
    let before = state.latest().expect("ticks").tick;
    assert_ne!(before.mode, Mode::Free, "{before:?}");
    let series = 1000.0 * 300.0 / 1300.0;
    let tolerance = friction_hold_n(&before) * 1000.0 / 1300.0 + 0.008;
    assert!(
        (before.normal_force_n - series * 0.006).abs() < tolerance,
        "{before:?}"
    );

    let (p1, w) = viewer::gui::editing::control_point(&state.scene.model, MIDDLE).expect("P_1");
    assert!((w - 0.866_025_4).abs() < 1e-6);
    let delta = 0.004;
    let curve_before = state.scene.objects[0].curves[0].clone();
    // The drag as the view does it: press on the handle, move, release.
    state.edit.enabled = true;
    state.begin_point_drag(MIDDLE);
    state.drag_point_to(p1 + outward() * (delta * 0.5));
    state.drag_point_to(p1 + outward() * delta);
    // Nothing applied while dragging.
    assert_eq!(state.scene.objects[0].curves[0], curve_before);
    assert!(state.end_point_drag(), "{:?}", state.edit.error);
    assert_eq!(state.edit.error, None);
    let (moved, _) = viewer::gui::editing::control_point(&state.scene.model, MIDDLE).expect("P_1");
    // Stored as (w·P, w): the round trip costs an ulp or two of the 0.09 m coordinates.
    assert!(
        (moved - (p1 + outward() * delta)).length() < 2e-8,
        "{moved}"
    );
    // The drawn curve moved at its middle by R_1(1/2) δ outward (f32: 1e-6 m is ~100 ulps of
    // the 0.1 m coordinates, the sampling's own rounding).
    let r1 = w / (1.0 + w);
    let mid = |c: &[Vec2]| c[c.len() / 2];
    let shift = mid(&state.scene.objects[0].curves[0]) - mid(&curve_before);
    assert!(
        (shift - outward() * (r1 * delta)).length() < 1e-6,
        "{shift} vs {}",
        outward() * (r1 * delta)
    );

    state.step(1500);
    let after = state.latest().expect("ticks").tick;
    assert_ne!(after.mode, Mode::Free, "{after:?}");
    let expected = series * r1 * delta;
    let grew = after.normal_force_n - before.normal_force_n;
    assert!(
        (grew - expected).abs() < 2.0 * tolerance,
        "F_N grew by {grew} N, expected {expected} N ({before:?} → {after:?})"
    );
    // Still the penalty of the new surface: K times the depth below it, to within the
    // encoders' and the stick spring's share (the god-object sits a few tens of µm from the
    // closest point while stuck: tens of mN), against K·s = 1.86 N had the force stayed with
    // the old surface.
    assert!(
        (after.normal_force_n - 1000.0 * after.depth_m).abs() < 0.05 * 1000.0 * delta,
        "{after:?}"
    );
    assert!(state.faults().is_empty(), "{:?}", state.faults());
}

/// An invalid edit leaves the running scene and says why, naming the field; undo and redo
/// walk the history; a material changed in the editor survives an edit.
#[test]
fn invalid_edits_leave_the_scene_and_undo_redo_round_trip() {
    let mut state = stepped();
    let original = state.scene.model.clone();
    state.edit.enabled = true;
    state.select_point(Some(MIDDLE));
    assert!(!state.set_point_weight(MIDDLE, -1.0));
    let e = state.edit.error.clone().expect("refused");
    assert!(
        e.starts_with("set weight: object 0 (") && e.contains("patch 0: weights[1]: -1 must be"),
        "{e}"
    );
    assert!(e.ends_with("the running scene is unchanged"), "{e}");
    assert_eq!(state.scene.model, original);
    assert_eq!(state.edit.history.depth(), (0, 0));

    // A material changed in the editor, then three edits.
    state.materials.edited.mu_dynamic = 0.4;
    state.apply_material();
    assert_eq!(state.materials.error, None);
    assert!(state.set_point_weight(MIDDLE, 2.0));
    let weighted = state.scene.model.clone();
    assert!(state.insert_knot_at_selected());
    let refined = state.scene.model.clone();
    assert!(state.split_at_selected(), "{:?}", state.edit.error);
    assert_eq!(state.scene.model.objects()[0].patches().len(), 3);
    assert_eq!(state.edit.history.depth(), (3, 0));
    assert_eq!(state.running_material.map(|m| m.mu_dynamic), Some(0.4));
    assert_eq!(
        state.scene.model.objects()[0]
            .material()
            .friction_material()
            .mu_dynamic,
        0.4
    );
    state.step(10);

    assert!(state.undo());
    assert!(state.undo());
    // The geometry of each step (the material is the editor's throughout).
    let patches = |s: &scene::Scene| s.objects()[0].patches().to_vec();
    assert_eq!(patches(&state.scene.model), patches(&weighted));
    assert!(state.redo());
    assert_eq!(patches(&state.scene.model), patches(&refined));
    assert!(state.undo());
    assert!(state.undo());
    assert_eq!(patches(&state.scene.model), patches(&original));
    assert!(!state.undo());
    assert_eq!(state.edit.history.depth(), (0, 3));
    // The loop renders every one of them: the hand still moves, no fault.
    state.step(10);
    assert!(state.faults().is_empty());
    // A new scene forgets the history.
    state.open_bundled("examples");
    assert_eq!(state.edit.history.depth(), (0, 0));
    assert_eq!(state.edit.selected, None);
}

/// The view's wiring, with a simulated pointer: pressing on a handle and dragging it moves
/// the control point to where it is released (and not the hand), nothing is applied before
/// the release; Ctrl+Z undoes the move and Ctrl+Shift+Z redoes it.
#[test]
fn dragging_a_handle_with_the_pointer_and_undoing_with_the_keyboard() {
    let mut state = stepped();
    state.edit.enabled = true;
    let original = state.scene.model.clone();
    let (p1, _) = viewer::gui::editing::control_point(&state.scene.model, MIDDLE).expect("P_1");
    let mut h = view_2d_harness(state);
    h.run_steps(2);
    let view = h.state().view;
    let rect = view.last_rect.expect("drawn");
    let at = view.screen_of(rect, p1);
    let to = at + egui::Vec2::new(24.0, -16.0);
    h.hover_at(at);
    h.run_steps(1);
    h.drag_at(at);
    h.run_steps(1);
    for i in 1..=4 {
        h.hover_at(at + (to - at) * (i as f32 / 4.0));
        h.run_steps(1);
    }
    let s = &h.state().state;
    assert!(s.edit.drag.is_some());
    assert_eq!(s.scene.model, original, "applied only when released");
    h.drop_at(to);
    h.run_steps(1);
    let s = &h.state().state;
    assert_eq!(s.edit.error, None);
    assert_eq!(s.edit.selected, Some(MIDDLE));
    assert_eq!(s.hand_target, host::planar::START_HIP, "the hand stayed");
    let expected = view.device_of(rect, to);
    let (moved, _) = viewer::gui::editing::control_point(&s.scene.model, MIDDLE).expect("P_1");
    // Stored as (w·P, w): an ulp or two of the 0.09 m coordinates.
    assert!((moved - expected).length() < 2e-8, "{moved} vs {expected}");

    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(1);
    assert_eq!(h.state().state.scene.model, original);
    h.key_press_modifiers(
        egui::Modifiers::COMMAND | egui::Modifiers::SHIFT,
        egui::Key::Z,
    );
    h.run_steps(1);
    let (redone, _) =
        viewer::gui::editing::control_point(&h.state().state.scene.model, MIDDLE).expect("P_1");
    assert_eq!(redone, moved);
}

/// The edit panel's weight field sets the selected point's weight; a weight the scene refuses
/// is shown, naming the field, and the running one stays; the undo button steps back.
#[test]
fn the_weight_field_sets_the_weight_and_shows_a_refusal() {
    use egui_kittest::kittest::Queryable;
    let mut state = stepped();
    state.edit.enabled = true;
    state.select_point(Some(MIDDLE));
    let mut h = view_2d_harness(state);
    h.run_steps(2);
    let weight = |h: &Harness<'_, ViewerUi>| {
        viewer::gui::editing::control_point(&h.state().state.scene.model, MIDDLE)
            .expect("P_1")
            .1
    };
    h.get_by_label("weight").set_value_accesskit(2.0);
    h.run_steps(2);
    assert_eq!(weight(&h), 2.0, "{:?}", h.state().state.edit.error);
    h.get_by_label("weight").set_value_accesskit(-1.0);
    h.run_steps(2);
    let e = h.state().state.edit.error.clone().expect("refused");
    assert!(e.contains("patch 0: weights[1]: -1 must be"), "{e}");
    assert_eq!(weight(&h), 2.0);
    h.get_by_label("undo (1)").click();
    h.run_steps(2);
    assert_eq!(weight(&h), 0.866_025_4);
}
