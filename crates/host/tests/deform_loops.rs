//! The app's loops pushing a deformable object ([`LoopCommand::Deform`]): the planar loop (the
//! device's controller on the simulated pantograph at 10 kHz, held by the relaxed 300 N/m
//! grip) on the bundled taut string, and the spatial hand (an impedance point at 1 kHz) on the
//! bundled drum skin. Held, each settles where the contact spring and the object share the
//! push in series; the controller or renderer is carried onto every new shape (no ramp-in, no
//! search, no feature change); turning deform off brings the rest shape back the same way.

use host::backend::{LoopCommand, Reply, Steppable};
use host::deform::{DeformChangeError, ShapeFrame};
use host::planar::{HapticLoop, PlanarSession};
use host::spatial::{SpatialLoop, SpatialSession, control_points, start_hip};
use host::tick::Tick;
use nurbs::{Vec2, Vec3};
use scene::{Bundled, Scene};

fn deformable() -> Scene {
    Bundled::find("deformable")
        .and_then(|b| b.scene().ok())
        .expect("the bundled deformable scene")
}

/// The string's rest line (y, m), its length and tension, the material's contact stiffness.
const Y: f64 = 0.115;
const L: f64 = 0.08;
const T: f64 = 5.0;
const K_C: f64 = 1000.0;

fn series(k_c: f64, k_o: f64) -> f64 {
    k_c * k_o / (k_c + k_o)
}

/// The device's resolution at the handle (m): one encoder count of a joint moves the handle
/// by at most this much.
fn resolution_m() -> f64 {
    let at = device::spec::DeviceSpec::default()
        .at_handle()
        .expect("the default device");
    f64::from(at.resolution_m)
}

/// The band `F/d` of a handle held `d` past the string's rest line must lie in, with contact
/// stiffness `k_c`: the series of `k_c` and the string's midpoint stiffness (`4T/L` stiffened
/// by 0.45–0.6 of `h/L`, `h = L/9`: `tests/deform.rs`), widened by `1 ± 2Δ/d` for the encoders'
/// HIP (one count per joint, at most Δ each) against the handle's true one.
fn string_band(k_c: f64, d: f64) -> (f64, f64) {
    let (k_o, h) = (4.0 * T / L, L / 9.0);
    let q = 2.0 * resolution_m() / d;
    (
        series(k_c, k_o * (1.0 + 0.45 * h / L)) * (1.0 - q),
        series(k_c, k_o * (1.0 + 0.6 * h / L)) * (1.0 + q),
    )
}

/// A loop's answer to [`LoopCommand::Deform`]: whether the object deforms, or why not.
fn deform(l: &mut impl Steppable, on: bool) -> Result<bool, DeformChangeError> {
    match l.apply(LoopCommand::Deform(on)) {
        Some(Reply::Deform(r)) => r.map(|s| s.deforming),
        other => panic!("{other:?}"),
    }
}

/// [`deform`], which must take.
fn deform_reply(l: &mut impl Steppable, on: bool) -> Result<bool, String> {
    deform(l, on).map_err(|e| e.to_string())
}

/// The rendered force before the safety layer: the normal force along the normal plus the
/// friction.
fn rendered(t: &Tick) -> Vec3 {
    t.normal * t.normal_force_n + t.friction
}

/// The planar loop on the string, deform on, the hand's target pushed 10 mm past the
/// string's middle from below (its outside) and held for 1 s.
///
/// The handle (HIP) settles where the hand's spring, the contact and the string balance; at
/// its depth `d` past the rest line the contact spring `k_c` and the string's midpoint
/// stiffness `k_o` share the push in series, `F = d k_c k_o / (k_c + k_o)`. `k_o` is `4T/L` =
/// 250 N/m stiffened by its discretisation by 0.45–0.6 of `h/L` (`tests/deform.rs`), so
/// `F/d` lies in [207.9, 210.5] N/m.
///
/// At 10 kHz the controller renders the force from the encoders' HIP, not the handle's true
/// one: one count per joint is at most the device's resolution Δ at the handle
/// ([`device::spec::AtHandle::resolution_m`]), so the measured HIP is within 2Δ of the true
/// one and `F/d` (with the true `d`) within a factor `1 ± 2Δ/d` of the band. The safety
/// layer's shaping stays out of it: the 1.2 N push is below the 3 N limit, rises at under the
/// 2000 N/s rate limit, and every tick's output equals the renderer's force (checked). The
/// transient has died out after 1 s (the string's damping alone decays as e^(−50 t), the hand
/// and handle settle faster; the force is steady to 1e-4 N over the last 0.3 s, checked).
#[test]
fn planar_loop_pushing_the_string_settles_at_the_series_stiffness() {
    let below = Vec2::new(0.0, 0.10);
    let session = PlanarSession::with_object(deformable(), Some(0)).expect("session");
    let mut l = HapticLoop::new(session, below).expect("loop");
    for _ in 0..300 {
        l.step();
    }
    assert_eq!(deform_reply(&mut l, true), Ok(true));
    let shape = l.shared_shape().clone();
    let mut frame = ShapeFrame::default();
    assert!(shape.read_into(&mut frame));
    assert!(frame.deforming && frame.object == 0 && frame.points.len() == 12);

    let target = Vec2::new(0.0, 0.125);
    l.set_hand_target(target);
    let ticks: Vec<Tick> = (0..1300).map(|_| l.step()).collect();
    assert!(
        ticks.iter().all(|t| t.deform.is_some()),
        "every tick records it"
    );
    let first = ticks
        .iter()
        .position(|t| t.patch.is_some())
        .expect("contact");
    for t in &ticks[first..] {
        assert_eq!(t.patch, Some(0), "contact lost at {} s", t.t_s);
        assert!(
            matches!(t.feature, tracker::Feature::Patch(0)),
            "feature {:?} at {} s",
            t.feature,
            t.t_s
        );
        // A ramp-in (or an acquisition) would scale the output below the renderer's force.
        assert!(
            (t.force - rendered(t)).length() < 1e-4,
            "output {} vs rendered {} at {} s",
            t.force,
            rendered(t),
            t.t_s
        );
    }
    let held = ticks.last().expect("ticks");
    let steady = &ticks[1000..];
    let spread = steady
        .iter()
        .map(|t| (t.normal_force_n - held.normal_force_n).abs())
        .fold(0.0, f32::max);
    assert!(spread < 1e-4, "still moving: F_N varies by {spread} N");

    // Pushed from below: the HIP is above the rest line.
    let d = f64::from(held.hip.y) - Y;
    let k = f64::from(held.normal_force_n) / d;
    let (lo, hi) = string_band(K_C, d);
    println!(
        "planar: d = {d} m, F = {} N, F/d = {k} N/m in [{lo}, {hi}] (Δ = {} m)",
        held.normal_force_n,
        resolution_m()
    );
    assert!(
        (lo..=hi).contains(&k),
        "F/d = {k} N/m, series stiffness in [{lo}, {hi}] N/m (d = {d} m)"
    );
    // The string's share of the push is its displacement at the CP.
    let w = f64::from(held.deform.expect("deforming")[1]);
    assert!(w > 0.6 * d && w < d, "the string moved {w} m of {d} m");

    // Published at most every 17 ms: 1300 steps give at most 77 versions, and the newest is
    // the deformer's shape at most 17 steps old.
    assert!(shape.read_into(&mut frame));
    assert!(frame.version <= 2 + 1300 / 17, "{} versions", frame.version);
    let now = l.deformer().expect("deforming").points();
    let moved = frame
        .points
        .iter()
        .zip(&now)
        .map(|(a, b)| (a[1] - b[1]).abs())
        .fold(0.0, f64::max);
    assert!(moved < 1e-5, "the published shape is {moved} m off");

    // Off, still pressed: the rest shape is back at once, the force carried (no ramp-in: a
    // ramp's first tick outputs zero), and the handle settles against the rigid string.
    let before = held.force.length();
    assert_eq!(deform_reply(&mut l, false), Ok(false));
    assert!(shape.read_into(&mut frame) && !frame.deforming);
    let after: Vec<Tick> = (0..1000).map(|_| l.step()).collect();
    assert!(
        after
            .iter()
            .all(|t| t.deform.is_none() && t.patch == Some(0))
    );
    assert!(
        after[0].force.length() >= before,
        "{} N after, {before} N before",
        after[0].force.length()
    );
    let last = after.last().expect("ticks");
    assert!((f64::from(last.cp.y) - Y).abs() < 1e-6, "CP {}", last.cp);
    let d = f64::from(last.hip.y) - Y;
    let k = f64::from(last.normal_force_n) / d;
    let q = 2.0 * resolution_m() / d;
    assert!(
        (k / K_C - 1.0).abs() <= q,
        "rigid again: F/d = {k} N/m, K = {K_C} N/m within {q:e}"
    );
}

/// A material change while deforming starts the object again from rest with the new contact
/// stiffness; a scene swap renders the new session rigid, which then deforms from rest.
#[test]
fn material_change_and_swap_while_deforming_start_from_rest() {
    let below = Vec2::new(0.0, 0.10);
    let session = PlanarSession::with_object(deformable(), Some(0)).expect("session");
    let mut l = HapticLoop::new(session, below).expect("loop");
    assert_eq!(deform_reply(&mut l, true), Ok(true));
    l.set_hand_target(Vec2::new(0.0, 0.125));
    for _ in 0..500 {
        l.step();
    }
    let pushed = l.deformer().expect("deforming").body().displacement()[6][1];
    assert!(pushed > 1e-3, "{pushed}");
    let softer = friction::FrictionMaterial {
        stiffness_n_per_m: 500.0,
        ..l.material().expect("a material")
    };
    match l.apply(LoopCommand::SetMaterial(softer)) {
        Some(Reply::Material(Ok(m))) => assert_eq!(m, softer),
        other => panic!("{other:?}"),
    }
    assert!(l.deforming());
    let rest = l.deformer().expect("deforming").body().displacement();
    assert!(rest.iter().all(|u| *u == [0.0; 3]), "from rest");
    for _ in 0..1000 {
        l.step();
    }
    let held = l.step();
    let d = f64::from(held.hip.y) - Y;
    let k = f64::from(held.normal_force_n) / d;
    let (lo, hi) = string_band(500.0, d);
    println!("softer: F/d = {k} N/m in [{lo}, {hi}]");
    assert!(
        (lo..=hi).contains(&k),
        "F/d = {k} N/m, series in [{lo}, {hi}]"
    );

    let session = PlanarSession::with_object(deformable(), Some(0)).expect("session");
    assert!(matches!(
        l.apply(LoopCommand::Swap(Box::new(session))),
        Some(Reply::Swapped)
    ));
    assert!(!l.deforming());
    let mut frame = ShapeFrame::default();
    assert!(l.shared_shape().read_into(&mut frame) && !frame.deforming);
    l.step();
    assert_eq!(deform_reply(&mut l, true), Ok(true));
    let rest = l.deformer().expect("deforming").body().displacement();
    assert!(rest.iter().all(|u| *u == [0.0; 3]), "from rest");
    for _ in 0..200 {
        assert_eq!(l.step().patch, Some(0));
    }
}

/// A rigid object, or no object, is refused with the reason, and nothing changes.
#[test]
fn a_rigid_object_is_refused() {
    let thesis = Bundled::find("thesis-2d")
        .and_then(|b| b.scene().ok())
        .expect("thesis-2d");
    let mut l = HapticLoop::new(
        PlanarSession::new(thesis).expect("session"),
        Vec2::new(0.0, 0.11),
    )
    .expect("loop");
    let e = deform(&mut l, true).expect_err("rigid");
    assert!(e.to_string().contains("rigid"), "{e}");
    assert!(!l.deforming());
    l.step();
    let none = PlanarSession::with_object(deformable(), None).expect("session");
    l.swap_session(none);
    assert!(matches!(
        deform(&mut l, true),
        Err(DeformChangeError::NoObject)
    ));
}

/// The spatial hand on the drum skin (object 1: 100 × 100 mm, τ = 50 N/m, fixed boundary),
/// deform on, pressed `d` = 3 mm into its centre and held 0.7 s.
///
/// The hand is an impedance point: the HIP is where the hand puts it. The contact spring and
/// the skin's point stiffness at its centre share the push in series. A point load on a
/// continuous membrane has no finite stiffness (`w ~ (F/2πτ) ln(a/r)`), so `k_o` is the
/// discretised skin's: its static solve under a point force at the centre
/// ([`deform::Body::solve_static`], checked against the Poisson solution in crate `deform`),
/// which shares nothing with the loop (no renderer, no integrator, no contact coupling). The
/// hold is 35 decay times of the mass-proportional damping (γ/2ρ = 50 s⁻¹), so what the
/// transient leaves is e⁻³⁵ of the push. What remains is f32: the shape reaches the renderer
/// as f32 control points (ulp 7.5e-9 m near 0.1 m, 2.5e-6 of d) and the CP tracker converges
/// to about that too: 1e-4 relative is forty times that.
#[test]
fn spatial_loop_pressing_the_drum_settles_at_the_series_stiffness() {
    let scene = deformable();
    let start = start_hip(control_points(&scene, 1));
    assert!(
        (start - Vec3::new(0.0, 0.09, 0.01)).length() < 1e-6,
        "{start}"
    );
    let (_, mut body) = host::deform::body(&scene, 1).expect("the drum");
    let mut load = body.zero_load();
    body.add_point_force(&mut load, [0.5, 0.5], [0.0, 0.0, -1.0]);
    body.solve_static(&load).expect("held at its boundary");
    let k_o = 1.0 / -body.displacement_at([0.5, 0.5])[2];

    let session = SpatialSession::nurbs(scene, 1, start).expect("session");
    let mut l = SpatialLoop::new(session, start);
    assert_eq!(deform_reply(&mut l, true), Ok(true));
    let depth = 0.003;
    l.set_hand_target(Vec3::new(0.0, 0.09, -depth));
    // 13 mm at 0.3 m/s: 44 ticks; then the hold.
    let ticks: Vec<Tick> = (0..750).map(|_| l.step()).collect();
    let first = ticks
        .iter()
        .position(|t| t.patch.is_some())
        .expect("contact");
    assert!(
        ticks[first..]
            .iter()
            .all(|t| t.patch == Some(0) && t.deform.is_some())
    );
    let held = ticks.last().expect("ticks");
    let k = f64::from(held.normal_force_n) / f64::from(depth);
    let expected = series(K_C, k_o);
    println!("spatial: k_o = {k_o} N/m, F/d = {k} N/m, series {expected} N/m");
    assert!(
        (k / expected - 1.0).abs() < 1e-4,
        "F/d = {k} N/m, series of {K_C} and {k_o} N/m is {expected} N/m"
    );
    // Pressed straight down at the centre: the force is along +z.
    assert!(
        (held.force.normalize() - Vec3::Z).length() < 1e-4,
        "{held:?}"
    );
    let w = -f64::from(held.deform.expect("deforming")[2]);
    assert!(
        (w * k_o / f64::from(held.normal_force_n) - 1.0).abs() < 1e-3,
        "the skin moved {w} m under {} N",
        held.normal_force_n
    );

    // Off: the renderer is carried back onto the rest shape; the hand still 3 mm in feels K·d.
    assert_eq!(deform_reply(&mut l, false), Ok(false));
    let t = l.step();
    assert_eq!(t.patch, Some(0));
    assert!(t.deform.is_none());
    assert!(
        (f64::from(t.normal_force_n) - K_C * f64::from(depth)).abs() < 1e-3,
        "{t:?}"
    );
}

/// The spatial hand refuses to deform a mesh it feels, and a mesh set while deforming makes
/// the object rigid first.
#[test]
fn spatial_loop_deforms_the_nurbs_surface_only() {
    let scene = deformable();
    let start = start_hip(control_points(&scene, 1));
    let mesh = scene::tessellate_object(&scene, 1, 1e-3).expect("mesh");
    let session = SpatialSession::nurbs(scene, 1, start).expect("session");
    let mut l = SpatialLoop::new(session, start);
    assert_eq!(deform_reply(&mut l, true), Ok(true));
    l.set_mesh(Some(mesh.clone())).expect("a small mesh");
    assert!(!l.deforming());
    assert!(matches!(deform(&mut l, true), Err(DeformChangeError::Mesh)));
    l.set_mesh(None).expect("back to NURBS");
    assert_eq!(deform_reply(&mut l, true), Ok(true));
}
