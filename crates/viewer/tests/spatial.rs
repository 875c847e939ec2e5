//! The 3-D view and the spatial hand through the app's state: K·d at thesis-3d's apex, the
//! NURBS normal against a tessellation's on a cylinder, OBJ meshes opened, exported and
//! refused, and the mouse in the 3-D view.
#![cfg(feature = "gui")]

mod common;

use common::{APEX, bump_z, move_hand, press_apex, stepped_3d};
use eframe::egui;
use egui_kittest::Harness;
use friction::Mode;
use nurbs::Vec3;
use scene::{Material, Object, Patch, Scene};
use viewer::gui::ViewerUi;
use viewer::gui::state::AppState;
use viewer::gui::view3d;

/// Pressing the spatial hand d = 2 mm into the apex gives F_N = K·d = 2 N (K = 1000 N/m)
/// along +z. Where it comes from: the HIP is at rest (v = 0: no damping term, and the
/// material has none), straight below the apex, and the radii of curvature (67 mm and more)
/// are far larger than d, so the closest point is the apex and the depth is d exactly. What is
/// left is f32 rounding of heights near 7 mm (ulp 4.7e-10 m, 5e-7 N) and the tracker's
/// residual, whose effect on the depth is second order in its parameter error: 1e-4 N (0.1 µm
/// of depth) bounds both. Pressed straight along the normal the GO stays at the CP: no
/// friction.
#[test]
fn the_spatial_hand_pressed_d_into_the_bump_feels_k_d() {
    let mut state = stepped_3d();
    let start = state.spatial.as_ref().expect("3-D").start;
    // Above the middle of the control net, 10 mm above its top (12 mm).
    assert!(
        (start - Vec3::new(0.0, 0.09, 0.022)).length() < 1e-7,
        "{start}"
    );
    press_apex(&mut state, 0.002);
    let k = state.latest().expect("ticks").tick;
    assert!(
        (k.hip - (APEX - Vec3::new(0.0, 0.0, 0.002))).length() < 1e-7,
        "{k:?}"
    );
    assert_eq!(k.mode, Mode::Stuck, "{k:?}");
    assert!((k.depth_m - 0.002).abs() < 1e-7, "{k:?}");
    assert!((k.normal_force_n - 2.0).abs() < 1e-4, "{k:?}");
    assert!(
        (k.force - Vec3::new(0.0, 0.0, 2.0)).length() < 1e-4,
        "{k:?}"
    );
    assert!((k.cp - APEX).length() < 1e-6, "{k:?}");
    // Before the hand reached the surface nothing was felt.
    assert_eq!(state.telemetry.history[0].tick.mode, Mode::Free);

    // Sliding 10 mm along y stays on the bump (its height there from the closed form) and
    // keeps the force within the friction cone.
    let to = Vec3::new(0.0, 0.1, bump_z(0.0, 0.1) - 0.002);
    move_hand(&mut state, to, 1000);
    let k = state.latest().expect("ticks").tick;
    assert_ne!(k.mode, Mode::Free, "{k:?}");
    assert!(
        k.friction.length() <= 0.7 * k.normal_force_n * (1.0 + 1e-5),
        "{k:?}"
    );
}

/// A cylinder of radius 20 mm lying along x, its top at z = 0.02, frictionless (μ = 0: the
/// normal is all there is to feel).
fn cylinder_scene() -> Scene {
    let s = nurbs::construct::cylinder(Vec3::new(0.03, 0.09, 0.0), -Vec3::X, 0.02, 0.06)
        .expect("cylinder");
    let material = Material::new(1000.0, 0.0, 0.0, 0.0).expect("material");
    let o = Object::new("cylinder", material, vec![Patch::Surface(s)]).expect("object");
    Scene::new(vec![o]).expect("scene")
}

/// On the cylinder (axis along x through (y, z) = (0.09, 0)), the point at angle `a` from the
/// top towards +y, `r` from the axis.
fn around(a: f32, r: f32) -> Vec3 {
    Vec3::new(0.0, 0.09 + r * a.sin(), r * a.cos())
}

/// How far the slide over the cylinder goes around (rad), in 1000 ticks.
const SLIDE_RAD: f32 = 0.9;

/// The normals the hand felt while sliding 1 mm deep over the cylinder from the top to
/// [`SLIDE_RAD`] around (17 mm of arc in 1 s, 0.9 mrad per tick).
fn slide_over_cylinder(state: &mut AppState) -> Vec<Vec3> {
    move_hand(state, around(0.0, 0.019), 400);
    state.step(100);
    let first = state.telemetry.history.len();
    for i in 1..=1000 {
        let a = SLIDE_RAD * i as f32 / 1000.0;
        state
            .spatial
            .as_mut()
            .expect("3-D")
            .set_target(around(a, 0.019));
        state.step(1);
    }
    state
        .telemetry
        .history
        .iter()
        .skip(first)
        .map(|s| {
            assert_ne!(s.tick.mode, Mode::Free, "{:?}", s.tick);
            s.tick.normal
        })
        .collect()
}

/// The thesis's point (Fig. 2.1.2): the polygonal baseline's normal jumps across every edge
/// of the tessellation by the angle between the facets, the NURBS normal turns continuously.
/// References from the exact construction: the NURBS normal at the hand is the radial
/// direction (the cylinder's normal), turning 0.5 mrad per tick; a chord facet between the
/// vertices at angles a and b has the radial normal at (a + b)/2, so crossing the edge at b to
/// the facet [b, c] turns the normal by (c − a)/2, and a facet whose chord height is within
/// the tolerance h spans at most 2·acos(1 − h/r).
#[test]
fn the_mesh_normal_jumps_across_edges_and_the_nurbs_normal_does_not() {
    let mut state = stepped_3d();
    state.open_scene("cylinder", cylinder_scene());
    assert_eq!(state.files.error, None);
    // atan2 of sine and cosine: acos near 1 in f32 cannot resolve less than 0.35 mrad.
    let angle = |a: Vec3, b: Vec3| a.cross(b).length().atan2(a.dot(b));

    let nurbs = slide_over_cylinder(&mut state);
    let nurbs_step = nurbs
        .windows(2)
        .map(|w| angle(w[0], w[1]))
        .fold(0.0, f32::max);
    // 0.9 mrad per tick, and the tracker follows within a few ticks: 3 mrad at most.
    assert!(
        nurbs_step < 3e-3,
        "largest NURBS normal step {nurbs_step} rad"
    );
    let last = state.latest().expect("ticks").tick;
    let radial = (around(SLIDE_RAD, 1.0) - around(SLIDE_RAD, 0.0)).normalize();
    assert!(angle(last.normal, radial) < 3e-3, "{last:?}");

    // The same slide on the tessellation at h = 0.5 mm.
    let tol = 5e-4;
    move_hand(&mut state, around(0.0, 0.03), 300);
    {
        let spatial = state.spatial.as_mut().expect("3-D");
        spatial.set_tolerance(tol);
        spatial.set_render_mesh(true);
        assert_eq!(spatial.message, None);
        assert!(spatial.stepped().is_some_and(|s| s.renders_mesh()));
    }
    let mesh = state
        .spatial
        .as_ref()
        .and_then(|s| s.tessellation())
        .expect("mesh");
    let facets = slide_over_cylinder(&mut state);
    let steps: Vec<f32> = facets.windows(2).map(|w| angle(w[0], w[1])).collect();
    let jumps: Vec<(usize, f32)> = steps
        .iter()
        .copied()
        .enumerate()
        .filter(|&(_, s)| s > 1e-5)
        .collect();
    // At 0.5 mm the facets span π/8 or less: at least two edges crossed in 0.9 rad.
    assert!(jumps.len() >= 2, "{jumps:?}");
    eprintln!("mesh normal jumps (tick, rad): {jumps:?}; largest NURBS step {nurbs_step} rad");
    // Between the edges the face normal does not move at all (one flat facet).
    assert!(
        steps.iter().all(|&s| !(1e-5..=0.05).contains(&s)),
        "{steps:?}"
    );
    // The vertices' angles around the axis, from their positions.
    let mut angles: Vec<f32> = mesh
        .vertices()
        .iter()
        .map(|p| (p.y - 0.09).atan2(p.z))
        .collect();
    angles.sort_by(f32::total_cmp);
    angles.dedup_by(|a, b| (*a - *b).abs() < 1e-5);
    let bound = 2.0 * (1.0 - tol / 0.02f32).acos();
    for (tick, jump) in jumps {
        // The edge crossed: the vertex angle nearest the hand's angle at that tick.
        let a_hand = SLIDE_RAD * (tick + 1) as f32 / 1000.0;
        let k = angles
            .iter()
            .enumerate()
            .min_by(|x, y| (x.1 - a_hand).abs().total_cmp(&(y.1 - a_hand).abs()))
            .map(|(k, _)| k)
            .expect("angles");
        let expected = 0.5 * (angles[k + 1] - angles[k - 1]);
        assert!(
            (jump - expected).abs() < 2e-3,
            "jump {jump} rad at tick {tick}, facets say {expected} rad"
        );
        assert!(
            jump <= bound * 1.001,
            "jump {jump} beyond the tolerance's {bound}"
        );
        assert!(
            jump > 50.0 * nurbs_step,
            "jump {jump} vs NURBS step {nurbs_step}"
        );
    }
}

/// The app's OBJ export of thesis-3d's bump is `scene::tessellate_object` at the slider's
/// tolerance written by `scene::mesh::save_obj` (their round trip through tobj, on the bump's
/// closed form, is `crates/scene/tests/obj.rs`); the app opens the file it wrote as a mesh,
/// felt through the baseline, and Save refuses to write a mesh as a scene.
#[test]
fn an_exported_obj_opens_as_a_mesh_felt_through_the_baseline() {
    let mut state = stepped_3d();
    let tol = 5e-4;
    let dir = std::env::temp_dir().join(format!("viewer-obj-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("bump.obj");
    let spatial = state.spatial.as_mut().expect("3-D");
    spatial.set_tolerance(tol);
    let written = spatial.export_obj(&path).expect("export");
    let mesh = spatial.tessellation().expect("mesh");
    assert_eq!(written, mesh.triangles().len());
    let bump = scene::bundled::Bundled::find("thesis-3d")
        .expect("bundled")
        .scene()
        .expect("valid");
    assert_eq!(
        Some(&mesh),
        scene::tessellate_object(&bump, 0, tol).as_ref(),
        "the export is the object's tessellation"
    );
    // Its vertices, parameters and faces are `write_obj`'s (the name and comment aside).
    let geometry = |text: &str| -> Vec<String> {
        text.lines()
            .filter(|l| !l.starts_with('#') && !l.starts_with("o "))
            .map(str::to_owned)
            .collect()
    };
    let mut expected = Vec::new();
    scene::mesh::write_obj(&mesh, "bump", "", &mut expected).expect("to memory");
    let file = std::fs::read_to_string(&path).expect("written");
    assert_eq!(
        geometry(&file),
        geometry(&String::from_utf8(expected).expect("UTF-8"))
    );
    // And the app opens it as a mesh, felt with the baseline.
    state.open_obj(&path);
    assert_eq!(state.files.error, None);
    let spatial = state.spatial.as_mut().expect("3-D");
    assert!(spatial.stepped().is_some_and(|s| s.renders_mesh()));
    assert_eq!(spatial.mesh_triangles, Some(mesh.triangles().len()));
    // An opened mesh has no NURBS object to switch back to: it stays felt.
    assert!(!spatial.can_tessellate());
    spatial.set_tolerance(1e-3);
    spatial.set_render_mesh(false);
    assert!(spatial.stepped().is_some_and(|s| s.renders_mesh()));
    press_apex(&mut state, 0.001);
    let k = state.latest().expect("ticks").tick;
    assert_eq!((k.mode, k.mu), (Mode::Slip, 0.0), "{k:?}");
    // Save has no scene/1 for a mesh: it says so and writes nothing (the placeholder scene
    // the idle planar loop holds is not what the user sees).
    let saved = dir.join("saved.json");
    state.save_scene(&saved);
    let e = state.files.error.clone().expect("refused");
    assert!(
        e.contains("is a mesh") && e.contains("nothing was written"),
        "{e}"
    );
    assert!(!saved.exists(), "no file written");
    assert!(state.spatial.as_ref().is_some_and(|s| s.is_opened_mesh()));
    let _ = std::fs::remove_dir_all(&dir);
}

/// An invalid OBJ names the file and the line, and the running scene stays.
#[test]
fn an_invalid_obj_is_refused_naming_the_line() {
    let mut state = stepped_3d();
    let dir = std::env::temp_dir().join(format!("viewer-bad-obj-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("bad.obj");
    std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n").expect("write");
    state.open_obj(&path);
    let e = state.files.error.clone().expect("refused");
    assert!(
        e.starts_with(&format!(
            "{}:4: face corner \"7\": vertex 7 does not exist",
            path.display()
        )),
        "{e}"
    );
    assert!(e.ends_with("the running scene is unchanged"), "{e}");
    assert_eq!(state.scene.label, "thesis-3d");
    press_apex(&mut state, 0.001);
    assert_ne!(state.latest().expect("ticks").tick.mode, Mode::Free);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The mouse in the 3-D view: a primary drag moves the hand's target in the view plane (no
/// component along the view direction; to the camera's right for a drag to the right, by
/// the distance the field of view gives at the target's depth: 2·d·tan(fov/2) per view
/// height), and the wheel while the hand is held pushes it along the view direction, 1 mm
/// per 50 points of scroll.
#[test]
fn dragging_in_the_3d_view_moves_the_hand_in_the_view_plane_and_the_wheel_in_depth() {
    let state = stepped_3d();
    let mut h = Harness::builder()
        .with_size(egui::Vec2::new(800.0, 600.0))
        .build_ui_state(
            |ui, v: &mut ViewerUi| {
                view3d::view_3d_ui(ui, &mut v.state, &mut v.camera3d, false);
            },
            ViewerUi::new(state),
        );
    h.run_steps(2);
    let camera = h.state().camera3d;
    let start = h.state().state.spatial.as_ref().expect("3-D").target;
    let centre = egui::pos2(400.0, 300.0);
    h.hover_at(centre);
    h.run_steps(1);
    h.drag_at(centre);
    h.run_steps(1);
    let grabbed = h.state().state.spatial.as_ref().expect("3-D").target;
    h.hover_at(centre + egui::vec2(100.0, 0.0));
    h.run_steps(2);
    let moved = h.state().state.spatial.as_ref().expect("3-D").target;
    let delta = moved - grabbed;
    let view = camera.view_dir();
    let right = view.cross(Vec3::Z).normalize();
    assert!(delta.dot(view).abs() < 1e-6, "{delta}");
    assert!(delta.dot(right) > 0.99 * delta.length(), "{delta}");
    // The view fills the window less egui's 8-point margins: 584 points high.
    let depth = (grabbed - camera.eye()).dot(view);
    let expected = 100.0 * 2.0 * depth * (camera.fov_y_rad * 0.5).tan() / 584.0;
    assert!(
        (delta.length() - expected).abs() < 0.02 * expected,
        "{} vs {expected}",
        delta.length()
    );
    // A press puts the hand under the pointer, at the depth it had.
    let rect = egui::Rect::from_min_max(egui::pos2(8.0, 8.0), egui::pos2(792.0, 592.0));
    let under = camera.project(rect, grabbed).expect("in front");
    assert!((under - centre).length() < 0.5, "{under:?}");
    assert!(((grabbed - start).dot(view)).abs() < 1e-6);

    // Back to the centre, then the wheel while holding.
    h.hover_at(centre);
    h.run_steps(2);
    let before = h.state().state.spatial.as_ref().expect("3-D").target;
    h.event(egui::Event::MouseWheel {
        unit: egui::MouseWheelUnit::Point,
        delta: egui::vec2(0.0, 50.0),
        phase: egui::TouchPhase::Move,
        modifiers: egui::Modifiers::NONE,
        source: egui::MouseWheelSource::Wheel,
    });
    h.run_steps(60);
    let after = h.state().state.spatial.as_ref().expect("3-D").target;
    let push = after - before;
    assert!((push.dot(view) - 1e-3).abs() < 2e-5, "{push}");
    assert!((push - view * push.dot(view)).length() < 2e-5, "{push}");
    h.drop_at(centre);
    h.run_steps(1);
    assert!(!h.state().state.dragging);
}
