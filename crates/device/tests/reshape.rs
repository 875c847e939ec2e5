//! A loaded object reshaped under a held hand ([`Controller::replace_object`],
//! [`Controller::reshape`]): the renderer keeps its state and follows the moving curve, with
//! force steps bounded by the physics of a spring anchored on the surface; a topology change
//! is refused with nothing changed. The reference closest points come from `testkit`'s
//! independent f64 evaluation.

#![allow(clippy::unwrap_used)]

use core::f32::consts::PI;

use device::controller::{Controller, ControllerError, TickOutput};
use device::safety::SafetyConfig;
use device::simulator::{SimParams, SimulatedPantograph};
use device::spec::DeviceSpec;
use friction::{FrictionMaterial, Mode};
use nurbs::{CurveBuf, Vec2, construct};
use testkit::{RefCurve, closest_on_curve, wide};
use tracker::{Chain, Feature};

/// The board's tick.
const T: f32 = 1e-4;
const PERIOD_US: u64 = 100;
/// Ramp-in after forces come on (s): 200 ticks.
const RAMP_S: f32 = 0.02;
/// Ticks before the first reshape: the ramp and twice as long again to settle.
const SETTLE: usize = 600;
/// Ticks between two reshapes (a 1 kHz stream of shapes).
const EVERY: usize = 10;
/// Control-point step per reshape (m) and number of steps out (then as many back).
const STEP_M: f32 = 10e-6;
const STEPS: usize = 100;

/// Thesis-2d's two arcs: curve 0 on the circle of radius 4 cm about (−0.02, 0.06) (the right
/// arc), curve 1 its mirror image; they meet at the vertex (0, 0.0946).
fn arcs() -> [CurveBuf<Vec2>; 2] {
    let d = PI / 180.0;
    [
        construct::arc(
            Vec2::new(-0.02, 0.06),
            Vec2::X * 0.04,
            Vec2::Y * 0.04,
            0.0,
            60.0 * d,
        )
        .unwrap(),
        construct::arc(
            Vec2::new(0.02, 0.06),
            Vec2::X * 0.04,
            Vec2::Y * 0.04,
            120.0 * d,
            60.0 * d,
        )
        .unwrap(),
    ]
}

/// The direction the right arc's middle control point moves in: away from the circle's
/// centre, through the point.
fn outward() -> Vec2 {
    let arcs = arcs();
    let (p1, _) = arcs[0].view().control_point(1).unwrap();
    (p1 - Vec2::new(-0.02, 0.06)).normalize()
}

/// The arcs with the right arc's middle control point moved by `offset` (weights unchanged).
fn moved(offset: Vec2) -> [CurveBuf<Vec2>; 2] {
    let [right, left] = arcs();
    let (p1, _) = right.view().control_point(1).unwrap();
    [right.with_point(1, p1 + offset).unwrap(), left]
}

/// 1000 N/m, undamped: within the device's passivity bound at 10 kHz, so no energy tank.
fn material() -> FrictionMaterial {
    FrictionMaterial::default()
}

fn safety() -> SafetyConfig {
    SafetyConfig {
        period_s: T,
        ramp_time_s: RAMP_S,
        ..SafetyConfig::default()
    }
}

/// A calibrated controller with forces on and `chain` loaded.
fn loaded(chain: Chain) -> Controller<Chain> {
    let spec = DeviceSpec::default();
    let mut c = Controller::new(spec, safety()).unwrap();
    c.calibrate(spec.end_stop_counts()).unwrap();
    c.set_forces_enabled(true);
    c.load_scene(chain, material(), false).unwrap();
    c
}

/// 2 mm inside the right arc, at 30°, held there: the encoder counts of the arm at rest.
fn held_counts() -> [i32; 2] {
    let a = 30.0f32.to_radians();
    let hip = Vec2::new(-0.02, 0.06) + Vec2::new(a.cos(), a.sin()) * 0.038;
    SimulatedPantograph::new(DeviceSpec::default(), SimParams::default(), hip)
        .unwrap()
        .encoder_counts()
}

/// One tick at tick `k` with a heartbeat, then the acquisition outside it.
fn tick(c: &mut Controller<Chain>, counts: [i32; 2], k: usize) -> TickOutput {
    c.heartbeat();
    let out = c.tick(counts, k as u64 * PERIOD_US);
    c.acquire_now();
    out
}

/// The closest point of the right arc of `shape` to `x`, and the depth of `x` inside it
/// (f64 reference).
fn reference(shape: &[CurveBuf<Vec2>; 2], x: Vec2) -> (Vec2, f32) {
    let r = RefCurve::new(&shape[0].view());
    let c = closest_on_curve(&r, wide(x), 4000);
    (
        Vec2::new(c.point.x as f32, c.point.y as f32),
        c.distance as f32,
    )
}

#[test]
fn the_renderer_follows_a_curve_moving_under_a_held_hand() {
    let k = material().stiffness_n_per_m;
    // Every shape the stream goes through: out by 100 steps of 10 µm, then back.
    let offsets: Vec<f32> = (0..=STEPS)
        .chain((0..STEPS).rev())
        .map(|i| i as f32 * STEP_M)
        .collect();
    let shapes: Vec<[CurveBuf<Vec2>; 2]> = offsets.iter().map(|&s| moved(outward() * s)).collect();
    let views: Vec<[nurbs::Curve<'_, Vec2>; 2]> =
        shapes.iter().map(|s| [s[0].view(), s[1].view()]).collect();
    let mut c = loaded(Chain::new(&views[0]).unwrap());
    let counts = held_counts();
    let mut last = TickOutput::IDLE;
    for i in 0..SETTLE {
        last = tick(&mut c, counts, i);
    }
    assert_eq!(last.telemetry.mode, Mode::Stuck, "pressed in: {last:?}");
    assert_eq!(last.telemetry.feature, Some(Feature::Patch(0)));
    let hip = last.telemetry.hip_m;
    let (_, depth_before) = reference(&shapes[0], hip);
    let normal_before = last.telemetry.force_normal_n;
    let mut depth_out = 0.0;
    let mut normal_out = 0.0;
    let mut largest_step = 0.0f32;
    let mut largest_cp_error = 0.0f32;
    let mut i = SETTLE;
    for (j, view) in views.iter().enumerate().skip(1) {
        let old = c.replace_object(Chain::new(view).unwrap()).unwrap();
        // The replaced object is the previous shape (its own copy of it).
        assert_eq!(old.curve(0).points(), shapes[j - 1][0].points());
        let moved_m = STEP_M;
        for t in 0..EVERY {
            let out = tick(&mut c, counts, i);
            i += 1;
            let tm = out.telemetry;
            // No feature switch, no loss of contact, no new acquisition: the same patch, stuck.
            assert_eq!(tm.feature, Some(Feature::Patch(0)), "tick {i}: {tm:?}");
            assert_eq!(tm.mode, Mode::Stuck, "tick {i}: {tm:?}");
            assert!(out.render.is_some(), "tick {i}: renders");
            // The HIP stands still and the GO is anchored on the surface, so the force is the
            // spring K (GO − HIP) and changes only when the GO moves: by the surface's
            // displacement under it, at most the control point's move (NURBS points with their
            // weights unchanged are convex combinations of the control points). The slack is
            // f32's: K times a few ulps of 0.1 m coordinates (7.5e-9 m each).
            let step = (tm.force_n - last.telemetry.force_n).length();
            let bound = if t == 0 { k * moved_m } else { 0.0 };
            assert!(
                step <= bound + k * 3e-8,
                "tick {i}: the force stepped by {step} N, more than K × the move = {bound} N"
            );
            largest_step = largest_step.max(step);
            if t == 0 {
                // The CP on the moved curve after one tracker step: the contact moved at most
                // 10 µm, and a Gauss–Newton step leaves |κ d| ≈ 2.5 mm / 40 mm = 6 % of a
                // parameter error on a circle of radius 40 mm at 2.5 mm depth: 0.6 µm, so 1 µm
                // (f32 evaluation adds nanometres).
                let (cp, _) = reference(&shapes[j], tm.hip_m);
                let e = (tm.cp_m - cp).length();
                assert!(e <= 1e-6, "tick {i}: CP {:?} is {e} m off {cp:?}", tm.cp_m);
                largest_cp_error = largest_cp_error.max(e);
            }
            last = out;
        }
        if j == STEPS {
            let (_, d) = reference(&shapes[j], hip);
            depth_out = d;
            normal_out = last.telemetry.force_normal_n;
        }
    }
    // The force followed the surface out: the normal force grew by K times the depth's growth,
    // to first order in the displacement (the GO's material point and the new closest point
    // differ by the curve's tangential drift, second order: |ΔS| / R = 0.5 mm / 40 mm ≈ 1 %).
    let expected = k * (depth_out - depth_before);
    let grown = normal_out - normal_before;
    assert!(
        depth_out - depth_before > 3e-4,
        "the curve moved into the hand: depth {depth_before} → {depth_out} m"
    );
    assert!(
        (grown - expected).abs() <= 0.03 * expected,
        "normal force grew by {grown} N, K × the depth's growth is {expected} N"
    );
    // And came back with it.
    assert!(
        (last.telemetry.force_normal_n - normal_before).abs() <= 0.01 * normal_before,
        "back to {} N from {normal_before} N",
        last.telemetry.force_normal_n
    );
    eprintln!(
        "largest force step {largest_step} N (K × move = {} N), largest CP error {largest_cp_error} m",
        k * STEP_M
    );
}

#[test]
fn a_topology_change_is_refused_and_changes_nothing() {
    let base = arcs();
    // The right arc alone: one piece where there were two.
    let one = [base[0].view()];
    // The right arc's middle point moved up so far that its end tangent turns the vertex
    // reflex: the same pieces, another vertex kind.
    let turned = moved(Vec2::new(0.0, 0.12 - 0.083_094));
    let views = [base[0].view(), base[1].view()];
    let turned_views = [turned[0].view(), turned[1].view()];
    let a_chain = Chain::new(&views).unwrap();
    let turned_chain = Chain::new(&turned_views).unwrap();
    assert_ne!(
        a_chain.topology().vertex_kinds(),
        turned_chain.topology().vertex_kinds(),
        "the moved point turns the vertex"
    );
    // Two controllers on the same scene, ticked alike; one is asked to take the other
    // topologies (and refuses), the other is not.
    let mut a = loaded(a_chain);
    let mut b = loaded(Chain::new(&views).unwrap());
    let counts = held_counts();
    for i in 0..SETTLE {
        assert_eq!(tick(&mut a, counts, i), tick(&mut b, counts, i));
    }
    assert_eq!(
        a.replace_object(Chain::new(&one).unwrap()).err(),
        Some(ControllerError::Topology)
    );
    assert_eq!(
        a.replace_object(turned_chain).err(),
        Some(ControllerError::Topology)
    );
    // The lifetime-changing form hands the controller back.
    let mut a = match a.reshape(Chain::new(&one).unwrap()) {
        Ok(_) => panic!("a one-piece chain is another topology"),
        Err((a, e)) => {
            assert_eq!(e, ControllerError::Topology);
            a
        }
    };
    for i in SETTLE..SETTLE + 200 {
        assert_eq!(tick(&mut a, counts, i), tick(&mut b, counts, i), "tick {i}");
    }
    // Without a scene there is nothing to reshape.
    let spec = DeviceSpec::default();
    let mut empty: Controller<Chain> = Controller::new(spec, safety()).unwrap();
    assert_eq!(
        empty.replace_object(Chain::new(&views).unwrap()).err(),
        Some(ControllerError::NoScene)
    );
}

#[test]
fn reshaping_into_other_storage_is_replacing() {
    let base = arcs();
    let views = [base[0].view(), base[1].view()];
    let counts = held_counts();
    let mut a = loaded(Chain::new(&views).unwrap());
    let mut b = loaded(Chain::new(&views).unwrap());
    for i in 0..SETTLE {
        assert_eq!(tick(&mut a, counts, i), tick(&mut b, counts, i));
    }
    let shape = moved(outward() * 2e-4);
    let moved_views = [shape[0].view(), shape[1].view()];
    a.replace_object(Chain::new(&moved_views).unwrap()).unwrap();
    // The same shape in storage of its own, reached through a controller of another lifetime.
    let copy = shape.clone();
    let copy_views = [copy[0].view(), copy[1].view()];
    let mut b = match b.reshape(Chain::new(&copy_views).unwrap()) {
        Ok(b) => b,
        Err((_, e)) => panic!("same topology: {e}"),
    };
    for i in SETTLE..SETTLE + 200 {
        assert_eq!(tick(&mut a, counts, i), tick(&mut b, counts, i), "tick {i}");
    }
}

#[test]
fn reshaping_in_place_is_replacing() {
    // The shapes, built before the controllers that borrow them: out by 20 µm steps.
    let shapes: Vec<[CurveBuf<Vec2>; 2]> = (0..=20)
        .map(|step| moved(outward() * (step as f32 * 2e-5)))
        .collect();
    let views: Vec<[nurbs::Curve<'_, Vec2>; 2]> =
        shapes.iter().map(|s| [s[0].view(), s[1].view()]).collect();
    let turned = moved(Vec2::new(0.0, 0.12 - 0.083_094));
    let turned_views = [turned[0].view(), turned[1].view()];
    let counts = held_counts();
    let mut a = loaded(Chain::new(&views[0]).unwrap());
    let mut b = loaded(Chain::new(&views[0]).unwrap());
    for i in 0..SETTLE {
        assert_eq!(tick(&mut a, counts, i), tick(&mut b, counts, i));
    }
    // A shape of another topology is refused in place too, with nothing changed.
    assert_eq!(
        b.reshape_object(|c| c.reshape(&turned_views)),
        Err(ControllerError::Topology)
    );
    let mut i = SETTLE;
    for shape in &views[1..] {
        a.replace_object(Chain::new(shape).unwrap()).unwrap();
        // The same shape, the chain moved onto it in place (`Chain::reshape`: four jets and
        // no second chain): the same ticks, bit for bit.
        b.reshape_object(|c| c.reshape(shape)).unwrap();
        for _ in 0..EVERY {
            assert_eq!(tick(&mut a, counts, i), tick(&mut b, counts, i), "tick {i}");
            i += 1;
        }
    }
}
