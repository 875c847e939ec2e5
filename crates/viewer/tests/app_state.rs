//! The app's scene tree and material editor, through its state (no window).
#![cfg(feature = "gui")]

use friction::{ModelKind, Stribeck};
use viewer::gui::state::AppState;

/// The first planar object is rendered on open; asking for another planar one renders it
/// (its material becomes the running one). Asking for the surface object (the bump) feels it
/// in the 3-D view with its own material while the planar device idles, and asking for a
/// planar one again goes back to 2-D.
///
/// The bump is pressed d = 2 mm straight down at its apex: the force is K·d = 1 N (the bump's
/// K = 500 N/m) along +z. The reference is the Bézier patch worked by hand: its x and y are
/// linear in u and v (evenly spaced control columns), its inner control points are 20 mm high,
/// so the apex is at u = v = ½, z = 0.02·(¾)² = 11.25 mm, with the normal +z by symmetry, and
/// z(x) = 0.045·u(1 − u) with x = 0.06·u − 0.03 gives a radius of curvature of 40 mm, twenty
/// times d. What is left is f32 rounding and the tracker's second-order residual; 1e-3 N (as
/// for the torus) bounds them. Pressing along the normal at rest gives no friction and no
/// damping force.
#[test]
fn another_object_of_the_scene_can_be_rendered() {
    use nurbs::Vec3;
    let mut state = AppState::stepped("examples").unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!(state.scene.rendered, Some(0));
    let material = |state: &AppState, i: usize| {
        state.scene.model.objects()[i]
            .material()
            .friction_material()
    };
    state.render_object(1);
    state.step(1);
    assert_eq!(state.scene.rendered, Some(1));
    assert_eq!(state.felt_object(), Some(1));
    assert_eq!(state.running_material, Some(material(&state, 1)));
    assert_eq!(state.files.error, None);

    state.render_object(2);
    state.step(1);
    assert_eq!(state.files.error, None);
    assert_eq!(state.scene.rendered, None, "the planar device idles");
    assert_eq!(state.felt_object(), Some(2));
    assert!(state.spatial.as_ref().is_some_and(|s| s.has_loop()));
    assert_eq!(state.running_material, Some(material(&state, 2)));
    let apex = Vec3::new(0.0, 0.09, 0.01125);
    go(&mut state, apex + Vec3::Z * 0.005);
    go(&mut state, apex - Vec3::Z * 0.002);
    state.step(200);
    let k = state.latest().expect("ticks").tick;
    assert!((k.normal_force_n - 1.0).abs() < 1e-3, "{k:?}");
    assert!((k.normal - Vec3::Z).length() < 1e-3, "{:?}", k.normal);
    assert!((k.depth_m - 0.002).abs() < 1e-6, "{}", k.depth_m);

    state.render_object(0);
    state.step(1);
    assert!(state.spatial.is_none(), "back in 2-D");
    assert_eq!(state.scene.rendered, Some(0));
    assert_eq!(state.running_material, Some(material(&state, 0)));
}

/// Moves the spatial hand's target in a straight line to `to` at 0.1 m/s (0.1 mm a tick),
/// stepping the loop a tick per step.
fn go(state: &mut AppState, to: nurbs::Vec3) {
    let from = state.spatial.as_ref().expect("3-D").target;
    let ms = ((to - from).length() / 1e-4).ceil().max(1.0) as usize;
    for i in 1..=ms {
        let t = from + (to - from) * (i as f32 / ms as f32);
        state.spatial.as_mut().expect("3-D").set_target(t);
        state.step(1);
    }
}

/// The friction model and the Stribeck shape are edited like the numbers: a valid choice
/// reaches the loop (the running material reports it), an invalid one (a zero exponent)
/// is named and the running material stays.
#[test]
fn the_model_and_the_stribeck_shape_are_editable() {
    let mut state = AppState::stepped("thesis-2d").unwrap_or_else(|e| panic!("{e:#}"));
    state.materials.edited.model = ModelKind::Karnopp;
    state.materials.edited.viscous_ns_per_m = 0.5;
    state.materials.edited.stribeck = Stribeck::Power { exponent: 3 };
    state.apply_material();
    state.step(1);
    let running = state.running_material.expect("running");
    assert_eq!(running.model, ModelKind::Karnopp);
    assert_eq!(running.stribeck, Stribeck::Power { exponent: 3 });
    assert_eq!(running.viscous_ns_per_m, 0.5);
    state.materials.edited.stribeck = Stribeck::Power { exponent: 0 };
    state.apply_material();
    let e = state.materials.error.clone().expect("refused");
    assert!(e.contains("exponent") || e.contains("stribeck"), "{e}");
    assert_eq!(
        state.running_material.map(|m| m.stribeck),
        Some(Stribeck::Power { exponent: 3 })
    );
}

/// Dragging a control point reaches the loop as the device's upload: the scene the device
/// received (its receiver's CRC) is the edited scene's wire form, not the old one's; an
/// undo uploads the old one again.
#[test]
fn an_edit_is_uploaded_to_the_device() {
    use host::upload::wire_scene;
    use scene::edit::PointRef;
    let mut state = AppState::stepped("thesis-2d").unwrap_or_else(|e| panic!("{e:#}"));
    let crc = |s: &scene::Scene| protocol::crc32(&wire_scene(s, 0).expect("planar"));
    let before = state.scene.model.clone();
    assert_eq!(state.device_scene_crc32(), Some(crc(&before)));
    let at = PointRef {
        object: 0,
        patch: 0,
        index: 1,
    };
    let from = viewer::gui::editing::control_point(&before, at)
        .expect("a point")
        .0;
    assert!(state.move_point(at, from + nurbs::Vec2::new(0.0, 0.004)));
    state.step(1);
    let after = state.scene.model.clone();
    assert_ne!(after, before);
    assert_eq!(state.device_scene_crc32(), Some(crc(&after)));
    assert_ne!(crc(&after), crc(&before));
    state.undo();
    state.step(1);
    assert_eq!(state.device_scene_crc32(), Some(crc(&before)));
}

/// The bundled torus opens in the 3-D view and is felt: pressed d = 2 mm into its outer
/// equator along the radius, the normal force is K·d = 2 N (K = 1000 N/m) pointing radially
/// out. The reference is the exact torus (R = 30 mm, r = 10 mm about (0, 0.09, 0)): the
/// closest point of a point on the equator's plane, on the radius, is the equator point, its
/// normal the radius, its depth r − (distance to the tube's axis circle). The tube's radius
/// of curvature (10 mm) is five times d, and the rational patch is exact, so what is left is
/// f32 rounding (about 1e-9 m of depth near 0.04 m, 1e-6 N) and the tracker's second-order
/// residual: 1e-3 N bounds them.
#[test]
fn the_bundled_torus_is_felt_in_the_3d_view() {
    use nurbs::Vec3;
    let mut state = AppState::stepped("torus").unwrap_or_else(|e| panic!("{e:#}"));
    assert!(!state.scene.is_planar());
    assert!(state.spatial.as_ref().is_some_and(|s| s.has_loop()));
    let centre = Vec3::new(0.0, 0.09, 0.0);
    let radial = Vec3::new(1.0, 0.0, 0.0);
    // From outside the tube (5 mm off the equator) onto it and 2 mm in, slowly (0.1 m/s).
    go(&mut state, centre + radial * 0.045);
    go(&mut state, centre + radial * 0.038);
    state.step(200);
    let k = state.latest().expect("ticks").tick;
    assert!((k.normal_force_n - 2.0).abs() < 1e-3, "{k:?}");
    assert!((k.normal - radial).length() < 1e-3, "{:?}", k.normal);
    assert!((k.depth_m - 0.002).abs() < 1e-6, "{}", k.depth_m);
}

/// The Objects panel's wiring: opening the examples' bump and clicking *Render this one*
/// feels it in 3-D (the planar device idle); the circle's button brings the 2-D view back.
/// The force that follows is checked in `another_object_of_the_scene_can_be_rendered`.
#[test]
fn the_objects_panel_renders_the_bump_in_3d_and_a_curve_in_2d() {
    use eframe::egui;
    use egui_kittest::Harness;
    use egui_kittest::kittest::Queryable;
    use viewer::gui::ViewerUi;
    let state = AppState::stepped("examples").unwrap_or_else(|e| panic!("{e:#}"));
    let mut h = Harness::builder()
        .with_size(egui::Vec2::new(300.0, 600.0))
        .build_ui_state(
            |ui, v: &mut ViewerUi| v.objects_ui(ui),
            ViewerUi::new(state),
        );
    // Opens the object's header (and closes `close`'s), clicks its button, lets the loop
    // take the swap.
    let render = |h: &mut Harness<'_, ViewerUi>, open: &str, close: Option<&str>| {
        if let Some(close) = close {
            h.get_by_label(close).click();
        }
        h.get_by_label(open).click();
        h.run_steps(2);
        h.get_by_label("Render this one").click();
        h.run_steps(2);
        h.state_mut().state.step(1);
        h.run_steps(1);
    };
    h.run_steps(2);
    render(&mut h, "2: bump", None);
    let s = &h.state().state;
    assert_eq!(s.files.error, None);
    assert!(s.spatial.is_some(), "the 3-D view");
    assert_eq!((s.felt_object(), s.scene.rendered), (Some(2), None));
    render(&mut h, "1: circle", Some("(rendered) 2: bump"));
    let s = &h.state().state;
    assert!(s.spatial.is_none(), "back in 2-D");
    assert_eq!((s.felt_object(), s.scene.rendered), (Some(1), Some(1)));
}

/// Issue 31, item 3: a stiffness typed into the material panel applies on Enter, not per
/// keystroke. Typing 2000 over thesis-2d's K = 1000 used to run K = 2, 20 and 200 on the way
/// (then 2000 was refused, and 200 kept running while the panel said "unchanged"). Now the
/// running material stays at 1000 while the digits go in; on Enter 2000 is refused (past the
/// device's passivity bound) and 1000 still runs; 800 typed and entered runs.
#[test]
fn a_typed_stiffness_applies_on_enter_not_per_keystroke() {
    use eframe::egui;
    use egui_kittest::Harness;
    use egui_kittest::kittest::Queryable;
    use viewer::gui::ViewerUi;
    let state = AppState::stepped("thesis-2d").unwrap_or_else(|e| panic!("{e:#}"));
    let before = state.running_material.expect("a material");
    assert_eq!(before.stiffness_n_per_m, 1000.0);
    let mut h = Harness::builder()
        .with_size(egui::Vec2::new(360.0, 700.0))
        .build_ui_state(
            |ui, v: &mut ViewerUi| v.materials_ui(ui),
            ViewerUi::new(state),
        );
    h.run_steps(2);
    let running = |h: &Harness<'_, ViewerUi>| {
        h.state()
            .state
            .running_material
            .expect("a material")
            .stiffness_n_per_m
    };
    // Type `text` into the stiffness field digit by digit (the field selects its text when
    // it opens, so the first digit replaces it), the loop stepping between keystrokes, then
    // Enter.
    let type_k = |h: &mut Harness<'_, ViewerUi>, text: &str| {
        h.get_by_label("stiffness K").click();
        h.run_steps(2);
        for c in text.chars() {
            h.event(egui::Event::Text(c.to_string()));
            h.run_steps(1);
            h.state_mut().state.step(5);
            h.run_steps(1);
            assert_eq!(running(h), 1000.0, "after typing {c:?} of {text}");
        }
        h.key_press(egui::Key::Enter);
        h.run_steps(2);
        h.state_mut().state.step(5);
        h.run_steps(2);
    };
    type_k(&mut h, "2000");
    assert_eq!(running(&h), 1000.0, "2000 is past the passivity bound");
    let e = h.state().state.materials.error.clone().expect("refused");
    assert!(e.contains("stiffness"), "{e}");
    type_k(&mut h, "800");
    assert_eq!(running(&h), 800.0, "{:?}", h.state().state.materials.error);
    assert_eq!(h.state().state.materials.error, None);
}

/// Issue 31, item 4: the app redraws at full pace only while something moves. At rest (the
/// simulated handle still, nothing pressed) it asks for 2 frames a second, not 60; a drag, a
/// moving handle or a change of the forces brings the full pace back.
#[test]
fn an_idle_app_redraws_a_few_times_a_second_and_a_moving_one_at_full_pace() {
    use viewer::gui::repaint::{ACTIVE_FRAME, IDLE_FRAME, Repaint};
    let mut state = AppState::stepped("thesis-2d").unwrap_or_else(|e| panic!("{e:#}"));
    let mut repaint = Repaint::default();
    state.step(1);
    assert_eq!(
        repaint.after_frame(&state, false),
        ACTIVE_FRAME,
        "first tick"
    );
    // The handle at rest at its start, free: nothing changes from frame to frame.
    state.step(300);
    repaint.after_frame(&state, false);
    for _ in 0..5 {
        state.step(20);
        assert_eq!(repaint.after_frame(&state, false), IDLE_FRAME);
    }
    // A demo plays, or the hand is dragged: full pace.
    assert_eq!(repaint.after_frame(&state, true), ACTIVE_FRAME);
    state.dragging = true;
    assert_eq!(repaint.after_frame(&state, false), ACTIVE_FRAME);
    state.dragging = false;
    // The hand sent 5 mm away (released, it glides there): the handle moves, full pace,
    // until it is at rest again.
    let start = state.hand_target;
    assert!(state.set_hand_target(start + nurbs::Vec2::new(0.005, 0.0)));
    state.step(20);
    assert_eq!(repaint.after_frame(&state, false), ACTIVE_FRAME, "moving");
    state.step(1000);
    repaint.after_frame(&state, false);
    state.step(20);
    assert_eq!(
        repaint.after_frame(&state, false),
        IDLE_FRAME,
        "at rest again"
    );
    // The forces switched off: drawn at once.
    state.set_forces(false);
    state.step(2);
    assert_eq!(
        repaint.after_frame(&state, false),
        ACTIVE_FRAME,
        "forces off"
    );
}

/// Issue 31, item 6: thesis-3d, then thesis-2d, then thesis-3d again: the plots' history
/// holds only the newest loop's ticks, on one time axis (before, the spatial hand's clock
/// started again under the old ticks, and the plots spanned −3…21 s).
#[test]
fn the_history_is_one_loop_after_switching_between_2d_and_3d() {
    let mut state = AppState::stepped("thesis-3d").unwrap_or_else(|e| panic!("{e:#}"));
    let history_ok = |state: &AppState, what: &str| {
        let h = &state.telemetry.history;
        let newest = h.back().expect("ticks").tick.t_s;
        assert!(
            h.iter()
                .zip(h.iter().skip(1))
                .all(|(a, b)| a.tick.t_s <= b.tick.t_s),
            "{what}: the history's time runs forward"
        );
        assert!(
            h.iter().all(|s| s.tick.t_s <= newest),
            "{what}: nothing after the newest tick"
        );
        h.len()
    };
    state.step(400);
    state.poll();
    assert_eq!(history_ok(&state, "3-D"), 400);
    state.open_bundled("thesis-2d");
    assert!(state.spatial.is_none());
    state.step(900);
    state.poll();
    assert!(history_ok(&state, "2-D") <= 900);
    state.open_bundled("thesis-3d");
    assert!(state.spatial.is_some());
    state.step(100);
    state.poll();
    assert_eq!(
        history_ok(&state, "3-D again"),
        100,
        "only the new loop's ticks"
    );
}

/// Issue 31, item 8: the telemetry panel keeps its width while it waits for a loop's first
/// tick (after a failed link, or back from a replay it shrank to ~230 px); a command to a
/// loop that is gone says so, not "its queue is full"; and a device switch clears the old
/// loop's messages.
#[test]
fn the_telemetry_panel_keeps_its_width_and_old_messages_go() {
    use eframe::egui;
    use egui_kittest::Harness;
    use egui_kittest::kittest::Queryable;
    use viewer::gui::{TELEMETRY_MIN_PX, ViewerUi};
    let state = AppState::stepped("thesis-2d").unwrap_or_else(|e| panic!("{e:#}"));
    let width = 1400.0;
    let mut h = Harness::builder()
        .with_size(egui::Vec2::new(width, 860.0))
        .build_ui_state(|ui, v: &mut ViewerUi| v.ui(ui), ViewerUi::new(state));
    h.run_steps(2);
    // No tick yet: the panel holds one line.
    h.get_by_label("waiting for the loop…");
    let heading = h.get_by_label("Telemetry").rect();
    // The heading starts inside the panel's inner margin (8 px at most).
    assert!(
        width - heading.min.x + 8.0 >= TELEMETRY_MIN_PX,
        "the panel's content starts {} px from the right",
        width - heading.min.x
    );
    // A loop that is gone (stopped, as a lost link leaves it): the material is refused
    // naming that, and a device switch clears the message.
    let s = &mut h.state_mut().state;
    s.shutdown();
    s.materials.edited.stiffness_n_per_m = 800.0;
    s.apply_material();
    let e = s.materials.error.clone().expect("refused");
    assert!(e.contains("not running"), "{e}");
    assert!(!e.contains("queue is full"), "{e}");
    s.use_simulated();
    assert_eq!(s.materials.error, None);
}
