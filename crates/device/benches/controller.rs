//! Per-call cost of [`Controller::tick`], the whole haptic tick: encoder counts → kinematics
//! → tracker → friction → safety (passivity controller on) → Jᵀ F → currents → telemetry.
//! The object is thesis-2d's (two rational arcs meeting at a vertex, K = 1000 N/m,
//! μ_s = 0.7, μ_d = 0.5). The counts come from a simulated pantograph whose virtual hand
//! slides along the first arc, pressed in, back and forth; they are precomputed and replayed
//! cyclically, so only the controller is timed. The free case replays counts of a HIP that
//! moves in free space away from the object.

use criterion::{Criterion, criterion_group, criterion_main};
use device::controller::Controller;
use device::safety::SafetyConfig;
use device::simulator::{SimParams, SimulatedPantograph};
use device::spec::DeviceSpec;
use friction::FrictionMaterial;
use nurbs::{Vec2, construct};
use std::f32::consts::{PI, TAU};
use std::hint::black_box;
use tracker::Chain;

const T: f32 = 1e-3;
const PERIOD_US: u64 = 1000;

fn controller(spec: DeviceSpec, chain: Chain) -> Controller<Chain> {
    let safety = SafetyConfig {
        period_s: T,
        ramp_time_s: 0.02,
        ..SafetyConfig::default()
    };
    let mut c = Controller::new(spec, safety).expect("controller");
    // K = 1000 N/m with no damping is beyond the passive bound at 1 kHz.
    c.load_scene(chain, FrictionMaterial::default(), true)
        .expect("material");
    let stops = spec.end_stop_counts();
    c.calibrate(stops).expect("calibration");
    c.set_forces_enabled(true);
    c
}

/// The encoder counts of ticks `record` of the closed loop whose hand target is `target(t)`.
fn closed_loop_counts(
    chain: &Chain,
    target: impl Fn(f32) -> Vec2,
    record: std::ops::Range<usize>,
) -> Vec<[i32; 2]> {
    let spec = DeviceSpec::default();
    let mut c = controller(spec, *chain);
    let mut arm =
        SimulatedPantograph::new(spec, SimParams::default(), target(0.0)).expect("reachable");
    let mut counts = Vec::with_capacity(record.len());
    for k in 0..record.end {
        let now = k as f32 * T;
        c.heartbeat();
        let out = c.tick(arm.encoder_counts(), k as u64 * PERIOD_US);
        c.acquire_now();
        assert_eq!(out.telemetry.faults, 0, "tick {k}");
        if record.contains(&k) {
            counts.push(arm.encoder_counts());
        }
        arm.step(out.currents_a, target(now), T).expect("arm moves");
    }
    counts
}

fn bench_counts(
    c: &mut Criterion,
    name: &str,
    chain: &Chain,
    counts: &[[i32; 2]],
    in_contact: bool,
) {
    let mut ctl: Controller<Chain> = controller(DeviceSpec::default(), *chain);
    let n = counts.len();
    let mut k = 0;
    let tick = |ctl: &mut Controller<Chain>, k: usize| {
        // The clock runs on while the counts cycle; only the watchdog reads it.
        ctl.heartbeat();
        let out = ctl.tick(black_box(counts[k % n]), k as u64 * PERIOD_US);
        ctl.acquire_now();
        out
    };
    // One pass to settle, one to check that the replay is the case it claims to be.
    let mut modes = [0usize; 4];
    for pass in 0..2 {
        for _ in 0..n {
            let out = tick(&mut ctl, k);
            assert_eq!(out.telemetry.faults, 0, "{name}: tick {k}");
            if pass == 1 {
                modes[out.telemetry.mode as usize] += 1;
            }
            k += 1;
        }
    }
    eprintln!("{name}: ticks free/stuck/transition/slip = {modes:?}");
    assert_eq!(modes[0] == 0, in_contact, "{name}: {modes:?}");
    assert!(in_contact || modes[0] == n, "{name}: {modes:?}");
    c.bench_function(name, |b| {
        b.iter(|| {
            let out = tick(&mut ctl, k);
            k += 1;
            black_box(out)
        })
    });
}

fn thesis_2d(c: &mut Criterion) {
    let d = PI / 180.0;
    let centre = Vec2::new(-0.02, 0.06);
    let a0 = construct::arc(centre, Vec2::X * 0.04, Vec2::Y * 0.04, 0.0, 60.0 * d).expect("arc");
    let a1 = construct::arc(
        Vec2::new(0.02, 0.06),
        Vec2::X * 0.04,
        Vec2::Y * 0.04,
        120.0 * d,
        60.0 * d,
    )
    .expect("arc");
    let views = [a0.view(), a1.view()];
    let chain = Chain::new(&views).expect("chain");

    // Approach the first arc at 35° from 5 mm outside over 0.3 s, press the target 4 mm in,
    // then slide ±15° about 35° once a second (±10 mm at up to 63 mm/s); record the third
    // and fourth second, two whole periods, so that the replay wraps smoothly.
    let on_arc = |angle: f32, radius: f32| centre + Vec2::new(angle.cos(), angle.sin()) * radius;
    let sliding = |t: f32| {
        if t < 0.3 {
            on_arc(35.0 * d, 0.045 - (0.009 * t / 0.3))
        } else {
            on_arc((35.0 + 15.0 * (TAU * (t - 0.3)).sin()) * d, 0.036)
        }
    };
    let contact = closed_loop_counts(&chain, sliding, 2300..4300);
    bench_counts(
        c,
        "controller_tick/thesis-2d/sliding",
        &chain,
        &contact,
        true,
    );

    // Free space: a 10 mm circle 2 cm outside the object, once a second.
    let free = |t: f32| Vec2::new(0.0, 0.12) + Vec2::new((TAU * t).cos(), (TAU * t).sin()) * 0.01;
    let free_counts = closed_loop_counts(&chain, free, 1000..3000);
    bench_counts(
        c,
        "controller_tick/thesis-2d/free",
        &chain,
        &free_counts,
        false,
    );
}

criterion_group!(benches, thesis_2d);
criterion_main!(benches);
