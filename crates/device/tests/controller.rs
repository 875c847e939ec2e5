//! Scripted fault cases of the whole tick ([`Controller::tick`]): a bad encoder sample, the
//! clock (weeks of uptime, wraps, steps back, stalls), scene swaps between objects of
//! different sizes, and the device's own force limit. The HIP is held still at a pose by
//! feeding the encoder counts a simulated pantograph reads there, so every force is the
//! renderer's penalty force `K · depth` shaped by the safety layer, whose limits are the
//! independent reference.

#![allow(clippy::unwrap_used)]

use core::f32::consts::PI;

use device::controller::{Controller, TickOutput, acquire};
use device::safety::{Faults, SafetyConfig};
use device::simulator::{SimParams, SimulatedPantograph};
use device::spec::DeviceSpec;
use friction::{FrictionMaterial, Mode, SwitchCause};
use nurbs::{CurveBuf, Vec2, construct};
use tracker::{Chain, Object};

const T: f32 = 1e-3;
const PERIOD_US: u64 = 1000;
/// Ramp-in after forces come on (s).
const RAMP_S: f32 = 0.02;

/// Thesis-2d's two arcs: curve 0 on the circle of radius 4 cm about (−0.02, 0.06) (the right
/// arc), curve 1 its mirror image (the left arc); they meet at the vertex (0, 0.0946).
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

/// Penetration of a point inside the right arc's circle (m): 4 cm minus the distance to its
/// centre.
fn right_arc_depth(p: Vec2) -> f32 {
    0.04 - (p - Vec2::new(-0.02, 0.06)).length()
}

/// One tick, then the acquisition a board runs outside it ([`Controller::acquire_now`]), as
/// the host's loops do.
fn tick<O: Object<P = Vec2>>(c: &mut Controller<O>, counts: [i32; 2], now_us: u64) -> TickOutput {
    let out = c.tick(counts, now_us);
    c.acquire_now();
    out
}

fn safety() -> SafetyConfig {
    SafetyConfig {
        period_s: T,
        ramp_time_s: RAMP_S,
        ..SafetyConfig::default()
    }
}

/// A calibrated controller with forces enabled (no scene).
fn controller(spec: DeviceSpec, safety: SafetyConfig) -> Controller<Chain> {
    let mut c = Controller::new(spec, safety).unwrap();
    let stops = spec.end_stop_counts();
    c.calibrate(stops).unwrap();
    c.set_forces_enabled(true);
    c
}

/// The encoder counts of the arm at rest with its HIP at `hip`.
fn counts_at(spec: DeviceSpec, hip: Vec2) -> [i32; 2] {
    SimulatedPantograph::new(spec, SimParams::default(), hip)
        .unwrap()
        .encoder_counts()
}

/// The counts of joint angles `theta` (rad), as the encoders would read them.
fn counts_of_joints(spec: DeviceSpec, theta: [f32; 2]) -> [i32; 2] {
    let per_rad = spec.counts_per_joint_rad();
    [0, 1].map(|i| {
        spec.encoder_offset_counts[i]
            + (spec.encoder_direction[i].sign() * theta[i] * per_rad[i]).floor() as i32
    })
}

/// 1000 N/m, undamped: over the passive bound at 1 kHz, so the passivity controller is on.
fn material() -> FrictionMaterial {
    FrictionMaterial::default()
}

#[test]
fn an_unreachable_encoder_sample_latches_and_the_force_comes_back_ramped() {
    // A device rated for 5 N, so the effective limit is the safety layer's 5 N.
    let spec = DeviceSpec {
        max_force_n: 5.0,
        ..DeviceSpec::default()
    };
    let config = safety();
    let step_n = config.max_force_rate_n_per_s * T;
    let limit = config.max_force_n;
    let arcs = arcs();
    let views = [arcs[0].view(), arcs[1].view()];
    let chain = Chain::new(&views).unwrap();
    let mut c = controller(spec, config);
    c.load_scene(chain, material(), true).unwrap();
    // 8 mm inside the right arc: K · depth = 8 N, saturated at 5 N.
    let hip = Vec2::new(0.008, 0.075);
    assert!(right_arc_depth(hip) * 1000.0 > 1.5 * limit);
    let good = counts_at(spec, hip);
    // θ = (π, 0): both proximal links along the base line, elbows 0.21 m apart, farther than
    // the distal links reach (0.2 m): no pose.
    let bad = counts_of_joints(spec, [PI, 0.0]);

    let mut now_us = 0;
    let mut step = |c: &mut Controller<Chain>, counts| {
        c.heartbeat();
        let out = tick(c, counts, now_us);
        now_us += PERIOD_US;
        out
    };
    let mut forces = Vec::new();
    for _ in 0..100 {
        forces.push(step(&mut c, good).telemetry.force_n);
    }
    let pressed = *forces.last().unwrap();
    assert!(
        (pressed.length() - limit).abs() < 1e-3,
        "held at the limit: {pressed}"
    );

    let out = step(&mut c, bad);
    assert!(Faults::from_bits_truncate(out.telemetry.faults).contains(Faults::ENCODER));
    assert_eq!(out.currents_a, [0.0; 2]);
    assert_eq!(out.joint_angles_rad, None);
    forces.push(out.telemetry.force_n);
    // Good samples again: the fault stays latched, no force, until the host clears it.
    for _ in 0..50 {
        let out = step(&mut c, good);
        assert_eq!(out.telemetry.faults, Faults::ENCODER.bits());
        assert_eq!(out.currents_a, [0.0; 2]);
        forces.push(out.telemetry.force_n);
    }
    assert_eq!(c.clear_faults(), Faults::empty());
    let cleared_at = forces.len();
    let ramp_ticks = (RAMP_S / T).round() as usize;
    let mut asked = Vec::new();
    for _ in 0..ramp_ticks + 20 {
        let out = step(&mut c, good);
        assert_eq!(out.telemetry.faults, 0);
        forces.push(out.telemetry.force_n);
        asked.push(out.render.unwrap().total.length());
    }
    // Every tick: either the force is cut to zero (the safe state, immediate by design), or
    // it changed by at most the rate limit.
    for (k, w) in forces.windows(2).enumerate() {
        let change = (w[1] - w[0]).length();
        assert!(
            w[1] == Vec2::ZERO || change <= step_n * (1.0 + 1e-5),
            "tick {}: |ΔF| = {change} N > {step_n} N ({} -> {})",
            k + 1,
            w[0],
            w[1]
        );
    }
    // The recovery is the ramp-in: the renderer's force scaled linearly from zero over
    // RAMP_S, then saturated, |F_k| ≤ min(limit, |F_asked| k T / ramp) (to f32 rounding),
    // and back at the limit when it ends.
    for (k, (f, asked)) in forces[cleared_at..].iter().zip(&asked).enumerate() {
        let ramp = (k as f32 * T / RAMP_S).min(1.0);
        let bound = limit.min(asked * ramp);
        assert!(
            f.length() <= bound + 1e-4,
            "recovery tick {k}: {f} over the ramp's {bound} N"
        );
    }
    let back = forces.last().unwrap().length();
    assert!((back - limit).abs() < 1e-3, "force back to {back} N");
}

#[test]
fn the_force_limit_is_the_smaller_of_device_and_safety_limits() {
    let arcs = arcs();
    let views = [arcs[0].view(), arcs[1].view()];
    // 8 mm inside: 8 N asked for.
    let hip = Vec2::new(0.008, 0.075);
    for (device_n, safety_n) in [(3.0, 5.0), (5.0, 3.0), (2.0, 2.5)] {
        let spec = DeviceSpec {
            max_force_n: device_n,
            ..DeviceSpec::default()
        };
        let config = SafetyConfig {
            max_force_n: safety_n,
            ..safety()
        };
        let limit: f32 = f32::min(device_n, safety_n);
        let mut c = controller(spec, config);
        assert_eq!(c.safety_config().max_force_n, limit);
        c.load_scene(Chain::new(&views).unwrap(), material(), true)
            .unwrap();
        let counts = counts_at(spec, hip);
        let mut largest: f32 = 0.0;
        for k in 0..200u64 {
            c.heartbeat();
            let out = tick(&mut c, counts, k * PERIOD_US);
            assert_eq!(out.telemetry.faults, 0);
            largest = largest.max(out.telemetry.force_n.length());
        }
        // Saturation keeps |F| ≤ limit to rounding of one scaling (a few ulp).
        assert!(
            largest <= limit * (1.0 + 1e-6) && largest >= limit * (1.0 - 1e-4),
            "device {device_n} N, safety {safety_n} N: largest force {largest} N"
        );
    }
}

/// A controller pressing 4 mm into the right arc (4 N at K = 1000 N/m, under the 5 N limit
/// of a 5 N device), with forces fully ramped in by `start_us + 100 ms`.
fn pressing(chain: Chain, start_us: u64) -> (Controller<Chain>, [i32; 2], u64) {
    let spec = DeviceSpec {
        max_force_n: 5.0,
        ..DeviceSpec::default()
    };
    let mut c = controller(spec, safety());
    c.load_scene(chain, material(), true).unwrap();
    let counts = counts_at(spec, Vec2::new(0.0125, 0.075));
    let mut now = start_us;
    for _ in 0..100 {
        c.heartbeat();
        let out = tick(&mut c, counts, now);
        assert_eq!(out.telemetry.faults, 0);
        now = now.wrapping_add(PERIOD_US);
    }
    (c, counts, now)
}

/// Ticks without heartbeats from `now`, advancing the clock by `step_us` per tick; returns the
/// number of ticks (from 1) until the first with the watchdog fault, checking the force is
/// on before and zero from then.
fn ticks_until_watchdog(
    c: &mut Controller<Chain>,
    counts: [i32; 2],
    mut now: u64,
    step_us: u64,
) -> usize {
    for k in 0..1000 {
        let out = tick(c, counts, now);
        now = now.wrapping_add(step_us);
        if Faults::from_bits_truncate(out.telemetry.faults).contains(Faults::WATCHDOG) {
            assert_eq!(out.telemetry.force_n, Vec2::ZERO);
            assert_eq!(out.currents_a, [0.0; 2]);
            return k + 1;
        }
        assert!(out.telemetry.force_n.length() > 1.0, "tick {k}: force on");
    }
    panic!("the watchdog never tripped");
}

/// The default 100 ms timeout at 1 ms ticks: the last heartbeat was stamped by the tick before
/// the first silent one, so the k-th silent tick sees an age of k ms and the first age over
/// 100 ms is at k = 101.
const WATCHDOG_TICKS: usize = 101;

#[test]
fn the_watchdog_takes_100_ms_after_three_weeks_of_uptime() {
    let arcs = arcs();
    let views = [arcs[0].view(), arcs[1].view()];
    // Three weeks in µs: 1.8144e12, where an f32 of seconds resolves only 0.125 s.
    let three_weeks_us = 21 * 86_400 * 1_000_000;
    let (mut c, counts, now) = pressing(Chain::new(&views).unwrap(), three_weeks_us);
    assert_eq!(
        ticks_until_watchdog(&mut c, counts, now, PERIOD_US),
        WATCHDOG_TICKS
    );
}

#[test]
fn the_watchdog_counts_across_a_clock_wrap() {
    let arcs = arcs();
    let views = [arcs[0].view(), arcs[1].view()];
    // The 100 ms of pressing end 30 ms before the 64-bit clock wraps: the silent ticks
    // straddle the wrap.
    let start = u64::MAX - 130 * PERIOD_US + 1;
    let (mut c, counts, now) = pressing(Chain::new(&views).unwrap(), start);
    assert!(now > u64::MAX - 31 * PERIOD_US);
    assert_eq!(
        ticks_until_watchdog(&mut c, counts, now, PERIOD_US),
        WATCHDOG_TICKS
    );
}

#[test]
fn a_clock_that_steps_back_trips_the_watchdog_at_once() {
    let arcs = arcs();
    let views = [arcs[0].view(), arcs[1].view()];
    let (mut c, counts, now) = pressing(Chain::new(&views).unwrap(), 5_000_000);
    // A heartbeat, then the clock reads one second earlier (a reset of the timer).
    c.heartbeat();
    tick(&mut c, counts, now);
    let out = tick(&mut c, counts, now - 1_000_000);
    assert!(Faults::from_bits_truncate(out.telemetry.faults).contains(Faults::WATCHDOG));
    assert_eq!(out.telemetry.force_n, Vec2::ZERO);
    // Heartbeats from then on, on the new clock: the fault clears and the force ramps in.
    for k in 1..=5 {
        c.heartbeat();
        tick(&mut c, counts, now - 1_000_000 + k * PERIOD_US);
    }
    assert_eq!(c.clear_faults(), Faults::empty());
    c.heartbeat();
    let out = tick(&mut c, counts, now - 1_000_000 + 6 * PERIOD_US);
    assert_eq!(out.telemetry.faults, 0);
    assert_eq!(out.telemetry.force_n, Vec2::ZERO, "the ramp starts at zero");
}

#[test]
fn a_stalled_clock_still_trips_the_watchdog_by_the_tick_count() {
    let arcs = arcs();
    let views = [arcs[0].view(), arcs[1].view()];
    let (mut c, counts, now) = pressing(Chain::new(&views).unwrap(), 1_000_000);
    assert_eq!(ticks_until_watchdog(&mut c, counts, now, 0), WATCHDOG_TICKS);
}

#[test]
fn a_heartbeat_is_stamped_by_the_next_tick() {
    // A heartbeat carries no time: however long before a tick it arrived, the age counts
    // from that tick, so no heartbeat can be "from the future" and keep forces on.
    let arcs = arcs();
    let views = [arcs[0].view(), arcs[1].view()];
    let (mut c, counts, now) = pressing(Chain::new(&views).unwrap(), 0);
    c.heartbeat();
    // The heartbeat-stamping tick is tick 0 of the silence: the fault comes 101 ticks later.
    tick(&mut c, counts, now);
    assert_eq!(
        ticks_until_watchdog(&mut c, counts, now + PERIOD_US, PERIOD_US),
        WATCHDOG_TICKS
    );
}

#[test]
fn telemetry_time_wraps_modulo_two_to_the_32_microseconds() {
    let mut c: Controller<Chain> = controller(DeviceSpec::default(), safety());
    let counts = counts_at(DeviceSpec::default(), Vec2::new(0.0, 0.09));
    // 71.6 min: the last µs before the wrap, then the wrap itself, then 5 µs past it.
    for (now_us, time_us) in [
        ((1u64 << 32) - 1, u32::MAX),
        (1 << 32, 0),
        ((1 << 32) + 5, 5),
        ((3 << 32) + 7, 7),
    ] {
        c.heartbeat();
        assert_eq!(tick(&mut c, counts, now_us).telemetry.time_us, time_us);
    }
}

#[test]
fn swapping_to_a_shorter_chain_while_touching_its_missing_curve_is_total() {
    // The reported case: a 2-curve chain, the HIP pressing into curve 1 (the left arc), then
    // a 1-curve chain (the right arc alone) loaded at a tick boundary. The renderer's state
    // for the old chain named curve 1; it used to be indexed into the new one.
    let arcs = arcs();
    let both = [arcs[0].view(), arcs[1].view()];
    let right = [arcs[0].view()];
    let spec = DeviceSpec::default();
    let mut c = controller(spec, safety());
    c.load_scene(Chain::new(&both).unwrap(), material(), true)
        .unwrap();
    let on_left = counts_at(spec, Vec2::new(-0.0125, 0.075));
    let mut now = 0;
    let mut last = None;
    for _ in 0..100 {
        c.heartbeat();
        last = Some(tick(&mut c, on_left, now));
        now += PERIOD_US;
    }
    let touching = last.unwrap().render.unwrap();
    assert_eq!(touching.contact.patch, 1, "pressing curve 1");
    assert!(touching.total.length() > 1.0);

    c.load_scene(Chain::new(&right).unwrap(), material(), true)
        .unwrap();
    assert_eq!(c.object().map(|o| o.patch_count()), Some(1));
    let config = safety();
    let mut previous = tick(&mut c, on_left, now).telemetry.force_n;
    for _ in 0..200 {
        c.heartbeat();
        now += PERIOD_US;
        let out = tick(&mut c, on_left, now);
        assert!(out.currents_a.iter().all(|i| i.is_finite()));
        let render = out.render.unwrap();
        assert_eq!(render.contact.patch, 0, "the new chain has one curve");
        let change = (out.telemetry.force_n - previous).length();
        assert!(change <= config.max_force_rate_n_per_s * T * (1.0 + 1e-5));
        previous = out.telemetry.force_n;
    }
}

/// One scripted step of the adversarial run.
#[derive(Clone, Debug)]
enum Step {
    /// The arm moved by `step` (m, a random walk within 12 mm of a point near both arcs and
    /// their vertex), the clock advancing `dt_us`, a heartbeat or not.
    Pose {
        step: (f32, f32),
        dt_us: u64,
        heartbeat: bool,
    },
    /// Raw counts from anywhere (a glitch, a lost count, noise).
    Counts([i32; 2]),
    /// The clock jumps to an arbitrary reading.
    Clock(u64),
    ClearFaults,
    /// Load the other chain (2 curves ↔ 1 curve) at this tick boundary.
    Swap,
    Unload,
    ToggleForces,
}

fn step() -> impl proptest::strategy::Strategy<Value = Step> {
    use proptest::prelude::*;
    prop_oneof![
        80 => ((-3e-4f32..3e-4, -3e-4f32..3e-4), prop_oneof![
            20 => Just(PERIOD_US),
            1 => Just(0u64),
            1 => 0u64..1_000_000,
        ], prop::bool::weighted(0.9))
            .prop_map(|(step, dt_us, heartbeat)| Step::Pose { step, dt_us, heartbeat }),
        2 => any::<[i32; 2]>().prop_map(Step::Counts),
        1 => any::<u64>().prop_map(Step::Clock),
        4 => Just(Step::ClearFaults),
        2 => Just(Step::Swap),
        1 => Just(Step::Unload),
        1 => Just(Step::ToggleForces),
    ]
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

    /// No sequence of poses, encoder glitches, clock jumps, scene swaps and host commands
    /// gets past the safety layer: currents finite and within the motors' limits, the force
    /// within the effective limit, and a non-zero force never more than one rate-limit step
    /// from the previous tick's (a cut to zero is the only larger change). Faults cut the
    /// force often here; in a run of the 64 cases, 62 had force on, for 41 ticks on average.
    #[test]
    fn no_input_pushes_the_tick_past_the_safety_layer(
        steps in proptest::collection::vec(step(), 1..400),
    ) {
        let spec = DeviceSpec::default();
        let config = safety();
        let limit = config.max_force_n.min(spec.max_force_n);
        let step_n = config.max_force_rate_n_per_s * T;
        let arm = spec.validate().unwrap();
        let arcs = arcs();
        let both = [arcs[0].view(), arcs[1].view()];
        let right = [arcs[0].view()];
        let chains = [Chain::new(&both).unwrap(), Chain::new(&right).unwrap()];
        let mut which = 0;
        let mut c = controller(spec, config);
        c.load_scene(chains[0], material(), true).unwrap();
        // Near both arcs and their vertex, inside and outside.
        let base = Vec2::new(0.0, 0.09);
        let mut hip = base;
        let mut now: u64 = 0;
        let mut previous = Vec2::ZERO;
        for s in steps {
            let counts = match s {
                Step::Pose { step, dt_us, heartbeat } => {
                    now = now.wrapping_add(dt_us);
                    if heartbeat {
                        c.heartbeat();
                    }
                    hip = (hip + Vec2::new(step.0, step.1))
                        .clamp(base - Vec2::splat(0.012), base + Vec2::splat(0.012));
                    counts_of_joints(spec, arm.inverse(hip).unwrap())
                }
                Step::Counts(counts) => counts,
                Step::Clock(t) => {
                    now = t;
                    counts_at(spec, base)
                }
                Step::ClearFaults => {
                    c.clear_faults();
                    continue;
                }
                Step::Swap => {
                    which = 1 - which;
                    c.load_scene(chains[which], material(), true).unwrap();
                    continue;
                }
                Step::Unload => {
                    c.unload_scene();
                    continue;
                }
                Step::ToggleForces => {
                    c.set_forces_enabled(!c.forces_enabled());
                    continue;
                }
            };
            let out = tick(&mut c, counts, now);
            for (i, current) in out.currents_a.iter().enumerate() {
                proptest::prop_assert!(current.is_finite());
                proptest::prop_assert!(current.abs() <= spec.current_limit_a[i] * (1.0 + 1e-6));
            }
            let f = out.telemetry.force_n;
            proptest::prop_assert!(f.is_finite());
            proptest::prop_assert!(f.length() <= limit * (1.0 + 1e-6), "{}", f);
            proptest::prop_assert!(
                f == Vec2::ZERO || (f - previous).length() <= step_n * (1.0 + 1e-5),
                "{} -> {}", previous, f
            );
            previous = f;
        }
    }
}

#[test]
fn the_tick_renders_nothing_until_an_acquisition_starts_it_and_a_stale_one_is_refused() {
    // The global closest-point search is not the tick's (device::controller, "Acquisition is
    // not the tick's"): after a load the tick only publishes a request; a result for an
    // earlier scene is refused; the accepted one starts the renderer, whose force then
    // ramps in from zero to the penalty force K · depth.
    let arcs = arcs();
    let views = [arcs[0].view(), arcs[1].view()];
    let chain = Chain::new(&views).unwrap();
    let spec = DeviceSpec::default();
    let config = safety();
    let mut c = controller(spec, config);
    c.load_scene(chain, material(), true).unwrap();
    // 2 mm inside the right arc, 30° along it (3.8 cm from its centre): K · depth = 2 N,
    // under every limit.
    let counts = counts_at(
        spec,
        Vec2::new(-0.02 + 0.038 * 0.866_025_4, 0.06 + 0.038 * 0.5),
    );
    let mut now = 0;
    let mut first_request = None;
    for _ in 0..3 {
        c.heartbeat();
        let out = c.tick(counts, now);
        now += PERIOD_US;
        assert_eq!(
            out.telemetry.force_n,
            Vec2::ZERO,
            "no force before acquisition"
        );
        assert!(out.render.is_none());
        let request = c.acquisition_request().expect("a tick with a pose asks");
        assert_eq!(
            request.hip_m, out.telemetry.hip_m,
            "searches from the tick's HIP"
        );
        assert_eq!(*first_request.get_or_insert(request), request);
    }
    let request = first_request.unwrap();
    let hip = request.hip_m;
    let depth = right_arc_depth(hip);
    assert!((depth - 0.002).abs() < 1e-4, "depth {depth}");

    // Searched for this scene, handed in after its material changed: refused.
    let stale = acquire(&chain, request);
    c.set_material(material(), true).unwrap();
    assert!(!c.complete_acquisition(stale));
    c.heartbeat();
    let out = c.tick(counts, now);
    now += PERIOD_US;
    assert_eq!(out.telemetry.force_n, Vec2::ZERO);
    let fresh = c.acquisition_request().unwrap();
    assert_ne!(fresh.generation, request.generation);

    assert!(c.complete_acquisition(acquire(&chain, fresh)));
    assert_eq!(c.acquisition_request(), None);
    assert!(
        !c.complete_acquisition(acquire(&chain, fresh)),
        "the renderer already runs"
    );

    // The ramp: zero on the first tick after the hand-over, K · depth after ramp_time_s, and
    // never above the linear ramp (k T / ramp) · K · depth on the way (the rate limit may
    // only slow it).
    let full = material().stiffness_n_per_m * depth;
    let ramp_ticks = (RAMP_S / T).round() as usize;
    for k in 0..ramp_ticks + 20 {
        c.heartbeat();
        let out = c.tick(counts, now);
        now += PERIOD_US;
        let f = out.telemetry.force_n.length();
        let linear = full * (k as f32 / ramp_ticks as f32).min(1.0);
        // f32 rounding of K · depth and the ramp factor: a few ulps of 2 N.
        assert!(
            f <= linear + 1e-5,
            "tick {k}: {f} N over the ramp's {linear} N"
        );
        if k >= ramp_ticks + 10 {
            // The tracker converged on the circle's closest point: K times the exact depth,
            // to the encoder's resolution (counts quantise the HIP by ~10 µm: 1e-2 N).
            assert!((f - full).abs() < 1e-2, "tick {k}: {f} N, K depth {full} N");
        }
    }
}

/// [`Controller::tick_into`] writes every field of its buffer: a buffer reused across ticks,
/// starting from another controller's rendering output (a force, a render, a feature), holds
/// exactly what [`Controller::tick`] returns fresh on a twin controller, tick by tick, through
/// no pose (uncalibrated), a pose awaiting its acquisition, contact, free space, an encoder
/// fault (no pose again) and a material change (awaiting again).
#[test]
fn tick_into_overwrites_everything_a_fresh_tick_gives() {
    let arcs = arcs();
    let views = [arcs[0].view(), arcs[1].view()];
    let chain = Chain::new(&views).unwrap();
    let spec = DeviceSpec::default();
    let (mut pressed, counts, now) = pressing(chain, 0);
    let mut buffer = tick(&mut pressed, counts, now);
    assert!(buffer.render.is_some() && buffer.telemetry.force_n.length() > 1.0);

    let mut fresh: Controller<Chain> = Controller::new(spec, safety()).unwrap();
    let mut reused: Controller<Chain> = Controller::new(spec, safety()).unwrap();
    let inside = counts_at(spec, Vec2::new(0.0125, 0.075));
    let outside = counts_at(spec, Vec2::new(0.0, 0.06));
    // Counts no pose gives (both joints a half turn away): an encoder fault once calibrated.
    let unreachable = counts_of_joints(spec, [0.0, PI]);
    #[derive(Clone, Copy)]
    enum Setup {
        Nothing,
        Start,
        ClearFaults,
        NewMaterial,
    }
    let phases = [
        (Setup::Nothing, inside, 3),
        (Setup::Start, inside, 60),
        (Setup::Nothing, outside, 20),
        (Setup::Nothing, inside, 20),
        (Setup::Nothing, unreachable, 2),
        (Setup::ClearFaults, inside, 5),
        (Setup::NewMaterial, inside, 1),
    ];
    let mut now = 0;
    let mut ticks = 0;
    let mut faulted = false;
    for (setup, counts, n) in phases {
        for c in [&mut fresh, &mut reused] {
            match setup {
                Setup::Nothing => {}
                Setup::Start => {
                    c.calibrate(spec.end_stop_counts()).unwrap();
                    c.set_forces_enabled(true);
                    c.load_scene(chain, material(), true).unwrap();
                }
                Setup::ClearFaults => {
                    c.clear_faults();
                }
                Setup::NewMaterial => c.set_material(material(), true).unwrap(),
            }
        }
        for _ in 0..n {
            fresh.heartbeat();
            reused.heartbeat();
            let expected = fresh.tick(counts, now);
            reused.tick_into(counts, now, &mut buffer);
            assert_eq!(buffer, expected, "tick {ticks}");
            faulted |= buffer.telemetry.faults != 0;
            fresh.acquire_now();
            reused.acquire_now();
            now += PERIOD_US;
            ticks += 1;
        }
    }
    assert_eq!(ticks, 111);
    // The run went through the states it claims: a fault latched; after the material change
    // the renderer awaits its acquisition (no render, a pose).
    assert!(faulted);
    assert!(buffer.render.is_none() && buffer.joint_angles_rad.is_some());
}

/// An identification run: refused before calibration and beyond the motors' torque; then
/// the tick commands exactly the square waves' joint torques (J^T F of the force it reports
/// gives them back: the force is J^-T tau), flipping at each half-period, through no ramp-in
/// (full amplitude on the first tick) while the scene waits; at the end the run stops, the
/// force is zero and the renderer waits for a fresh acquisition. (No physics here: the
/// encoders stand still; `host::identify` runs it on the simulated pantograph.)
#[test]
fn an_identification_run_commands_its_square_waves_then_hands_back_to_the_scene() {
    use device::controller::{ControllerError, Excitation};
    let spec = DeviceSpec::default();
    let excitation = Excitation {
        torque_nm: [0.008, -0.007],
        half_period_us: [3_000, 5_000],
        duration_us: 12_000,
    };
    let mut raw: Controller<Chain> = Controller::new(spec, safety()).unwrap();
    assert!(matches!(
        raw.excite(excitation),
        Err(ControllerError::Excitation("not calibrated"))
    ));
    let curves = arcs();
    let views = [curves[0].view(), curves[1].view()];
    let chain = Chain::new(&views).unwrap();
    let mut c = controller(spec, safety());
    c.load_scene(chain, material(), true).unwrap();
    // The motor's torque at its current limit: 2 A × 23.4 mN·m/A × 10 = 0.468 N·m.
    let too_much = Excitation {
        torque_nm: [0.5, 0.0],
        ..excitation
    };
    assert!(matches!(
        c.excite(too_much),
        Err(ControllerError::Excitation("torque_nm[0] beyond the motor"))
    ));
    c.excite(excitation).unwrap();
    assert!(c.exciting());
    let counts = counts_at(spec, Vec2::new(0.0, 0.09));
    let t0 = 5_000_000u64;
    for k in 0..12u64 {
        let out = tick(&mut c, counts, t0 + k * 1000);
        let elapsed = k * 1000;
        let expected = [0, 1].map(|i| {
            let half = u64::from(excitation.half_period_us[i]);
            excitation.torque_nm[i]
                * if (elapsed / half).is_multiple_of(2) {
                    1.0
                } else {
                    -1.0
                }
        });
        // τ = Jᵀ F through f32 Cramer and back: a few ulps of the 10 mN·m torques.
        for i in 0..2 {
            assert!(
                (out.joint_torques_nm[i] - expected[i]).abs() < 1e-6,
                "tick {k}: {:?} vs {expected:?}",
                out.joint_torques_nm
            );
        }
        assert_eq!(out.telemetry.mode, friction::Mode::Free);
        assert!(out.render.is_none(), "tick {k}: the scene is not rendered");
    }
    // 12 ms in: the run is over, the tick renders no force and asks for an acquisition
    // (which the helper runs), and the next tick renders the scene again.
    let out = tick(&mut c, counts, t0 + 12_000);
    assert!(!c.exciting());
    assert_eq!(out.telemetry.force_n, Vec2::ZERO);
    assert!(out.render.is_none());
    let out = tick(&mut c, counts, t0 + 13_000);
    assert!(out.render.is_some(), "the renderer runs again");
}

/// A contact the renderer ends by stopping (a material change restarts it from a fresh
/// acquisition) is a switch to free whose cause is `released`, as when the HIP leaves the
/// object, not `none`; the renderer that starts again switches back by `contact`.
#[test]
fn a_contact_ended_by_a_material_change_is_released() {
    let arcs = arcs();
    let views = [arcs[0].view(), arcs[1].view()];
    let chain = Chain::new(&views).unwrap();
    let (mut c, counts, mut now) = pressing(chain, 0);
    let mut next = |c: &mut Controller<Chain>| {
        c.heartbeat();
        let out = c.tick(counts, now);
        now += PERIOD_US;
        (out.telemetry.mode, out.telemetry.cause)
    };
    assert_eq!(next(&mut c), (Mode::Stuck, SwitchCause::Contact));
    c.set_material(material(), true).unwrap();
    for _ in 0..3 {
        assert_eq!(next(&mut c), (Mode::Free, SwitchCause::Released));
    }
    assert!(c.acquire_now());
    assert_eq!(next(&mut c), (Mode::Stuck, SwitchCause::Contact));
}

/// The telemetry's GO parameter (issue 30: a host deforming the object takes where the
/// force acts from the device, not by solving for it) is the GO's: the right arc evaluated
/// there is the telemetry's GO point, and that point lies on the circle where the pressed
/// HIP's radius meets it (the handle pressed in at once, the GO stays at the first contact:
/// the HIP (12.5, 75) mm is at atan2(15, 32.5) = 24.78° from the centre (−20, 60) mm).
#[test]
fn the_telemetry_carries_the_gos_parameter() {
    let arcs = arcs();
    let views = [arcs[0].view(), arcs[1].view()];
    let (mut c, counts, now) = pressing(Chain::new(&views).unwrap(), 0);
    let out = tick(&mut c, counts, now);
    let t = out.telemetry;
    assert_ne!(t.mode, Mode::Free, "{t:?}");
    let render = out.render.expect("rendering");
    assert_eq!(t.go_param, render.go_params[0]);
    assert!((0.0..=1.0).contains(&t.go_param), "{}", t.go_param);
    // f32 evaluation of a 4 cm arc: ~1e-8 m.
    let on_arc = views[0].point(t.go_param);
    assert!(
        (on_arc - t.go_m).length() < 1e-7,
        "{on_arc:?} vs {:?}",
        t.go_m
    );
    let centre = Vec2::new(-0.02, 0.06);
    let angle = (t.go_m.y - centre.y)
        .atan2(t.go_m.x - centre.x)
        .to_degrees();
    let expected = 0.015f32.atan2(0.0325).to_degrees();
    // The encoders' quantum at the handle (~12 µm) on a 4 cm radius: 0.02°.
    assert!((angle - expected).abs() < 0.05, "{angle}° vs {expected}°");
}
