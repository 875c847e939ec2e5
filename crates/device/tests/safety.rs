//! Scripted scenarios for each rule of the safety layer, the sampled-spring energy leak
//! against its closed form (and the passivity bound's margin against it), and a property
//! test that no input gets a non-finite or oversized force through. The wall acceptance's
//! bounds against hand-computed values are in `wall.rs`.

#![allow(clippy::unwrap_used)]

use device::safety::{
    ConfigError, Faults, Flags, Safety, SafetyConfig, SafetyInput, ThermalConfig,
};
use device::wall::WallLimits;
use nurbs::Vec2;
use proptest::prelude::*;

mod common;
use common::device;

const T: f32 = 1e-3;
/// A HIP position well inside the default workspace box.
const HOME: Vec2 = Vec2::new(0.0, 0.09);

/// Default limits, no ramp (so shaping tests see the command at once).
fn no_ramp() -> SafetyConfig {
    SafetyConfig {
        ramp_time_s: 0.0,
        ..SafetyConfig::default()
    }
}

/// A valid, quiet tick with a fresh heartbeat.
fn tick(force_n: Vec2) -> SafetyInput {
    SafetyInput {
        force_n,
        hip_in_device_m: HOME,
        hip_velocity_m_per_s: Vec2::ZERO,
        joint_step_rad: [0.0; 2],
        heartbeat_age_us: 0,
        motor_current_a: [0.0; 2],
        forces_enabled: true,
        calibrated: true,
        pose_valid: true,
        identification: false,
    }
}

fn close(a: f32, b: f32, tol: f32) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn default_config_is_valid() {
    SafetyConfig::default().validate().unwrap();
    assert!(Safety::new(SafetyConfig::default()).is_ok());
}

#[test]
fn config_errors_name_the_field() {
    let bad = SafetyConfig {
        max_force_n: f32::NAN,
        ..SafetyConfig::default()
    };
    assert_eq!(
        Safety::new(bad).unwrap_err(),
        ConfigError::NotPositive("max_force_n")
    );
    let bad = SafetyConfig {
        ramp_time_s: -1.0,
        ..SafetyConfig::default()
    };
    assert_eq!(bad.validate(), Err(ConfigError::Negative("ramp_time_s")));
    let mut bad = SafetyConfig::default();
    bad.workspace.min_in_device.x = 1.0;
    assert_eq!(bad.validate(), Err(ConfigError::EmptyWorkspace));
    let mut bad = SafetyConfig::default();
    bad.thermal.peak_current_a = 0.5;
    assert_eq!(bad.validate(), Err(ConfigError::PeakBelowContinuous));
    let mut bad = SafetyConfig::default();
    bad.thermal.derate_threshold = 1.2;
    assert_eq!(bad.validate(), Err(ConfigError::ThermalThresholds));
    assert!(
        ConfigError::NotPositive("period_s")
            .to_string()
            .contains("period_s")
    );
}

#[test]
fn faults_display_names_every_bit() {
    assert_eq!(Faults::empty().to_string(), "none");
    assert_eq!(
        (Faults::NUMERIC | Faults::WATCHDOG).to_string(),
        "numeric|watchdog"
    );
    assert_eq!(
        Faults::ALL.to_string(),
        "numeric|velocity|encoder|watchdog|workspace|thermal"
    );
    assert_eq!(Faults::from_bits_truncate(0xffff), Faults::ALL);
    assert_eq!(
        (Flags::SATURATED | Flags::RAMPING).to_string(),
        "saturated|ramping"
    );
}

#[test]
fn forces_off_while_disabled_or_uncalibrated() {
    let mut safety = Safety::new(no_ramp()).unwrap();
    let f = Vec2::new(1.0, 0.0);
    let mut input = tick(f);
    input.forces_enabled = false;
    assert_eq!(safety.apply(&input).force_n, Vec2::ZERO);
    input.forces_enabled = true;
    input.calibrated = false;
    // Uncalibrated: the position outside the box means nothing, no workspace fault.
    input.hip_in_device_m = Vec2::new(5.0, 5.0);
    let out = safety.apply(&input);
    assert_eq!(out.force_n, Vec2::ZERO);
    assert!(out.faults.is_empty());
    let out = safety.apply(&tick(f));
    assert_eq!(out.force_n, f);
}

#[test]
fn nan_mid_run_latches_numeric_until_cleared() {
    let mut safety = Safety::new(no_ramp()).unwrap();
    let f = Vec2::new(1.0, -0.5);
    for _ in 0..10 {
        let out = safety.apply(&tick(f));
        assert_eq!(out.force_n, f);
        assert!(out.faults.is_empty());
    }
    let mut poisoned = tick(f);
    poisoned.hip_velocity_m_per_s.y = f32::NAN;
    let out = safety.apply(&poisoned);
    assert_eq!(out.force_n, Vec2::ZERO);
    assert_eq!(out.faults, Faults::NUMERIC);
    // The NaN is gone, the fault stays.
    for _ in 11..20 {
        let out = safety.apply(&tick(f));
        assert_eq!(out.force_n, Vec2::ZERO);
        assert_eq!(out.faults, Faults::NUMERIC);
    }
    assert_eq!(safety.clear_faults(), Faults::empty());
    let out = safety.apply(&tick(f));
    assert_eq!(out.force_n, f);
    assert!(out.faults.is_empty());
}

#[test]
fn clear_faults_keeps_numeric_while_the_nan_is_still_there() {
    let mut safety = Safety::new(no_ramp()).unwrap();
    let mut poisoned = tick(Vec2::X);
    poisoned.force_n.x = f32::NAN;
    safety.apply(&poisoned);
    assert_eq!(safety.clear_faults(), Faults::NUMERIC);
}

#[test]
fn every_non_finite_field_latches_numeric() {
    let poisons: [fn(&mut SafetyInput, f32); 9] = [
        |i, v| i.force_n.x = v,
        |i, v| i.force_n.y = v,
        |i, v| i.hip_in_device_m.x = v,
        |i, v| i.hip_in_device_m.y = v,
        |i, v| i.hip_velocity_m_per_s.x = v,
        |i, v| i.joint_step_rad[0] = v,
        |i, v| i.joint_step_rad[1] = v,
        |i, v| i.motor_current_a[0] = v,
        |i, v| i.motor_current_a[1] = v,
    ];
    for (field, poison) in poisons.iter().enumerate() {
        for value in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let mut safety = Safety::new(no_ramp()).unwrap();
            safety.apply(&tick(Vec2::X));
            let mut input = tick(Vec2::X);
            poison(&mut input, value);
            let out = safety.apply(&input);
            assert_eq!(out.force_n, Vec2::ZERO, "field {field} = {value}");
            assert!(out.faults.contains(Faults::NUMERIC), "field {field}");
            assert!(safety.thermal_state().iter().all(|t| t.is_finite()));
        }
    }
}

#[test]
fn saturation_clamps_magnitude_and_keeps_direction() {
    let config = SafetyConfig {
        max_force_rate_n_per_s: 1e6,
        ..no_ramp()
    };
    let mut safety = Safety::new(config).unwrap();
    // |(6, 8)| = 10 N against a 5 N limit: (3, 4).
    let out = safety.apply(&tick(Vec2::new(6.0, 8.0)));
    assert!(out.flags.contains(Flags::SATURATED));
    assert!(out.faults.is_empty(), "saturation is a flag, not a fault");
    assert!(close(out.force_n.x, 3.0, 1e-6) && close(out.force_n.y, 4.0, 1e-6));
    assert!(out.force_n.length() <= 5.0 * (1.0 + 1e-6));
    // Huge but finite commands saturate too, without overflow.
    let out = safety.apply(&tick(Vec2::new(-3e38, 3e38)));
    let expected = Vec2::new(-1.0, 1.0).normalize() * 5.0;
    assert!((out.force_n - expected).length() < 1e-5);
    let out = safety.apply(&tick(Vec2::new(1.0, 1.0)));
    assert!(!out.flags.contains(Flags::SATURATED));
}

#[test]
fn rate_limit_steps_exactly_max_rate_times_period() {
    let config = SafetyConfig {
        max_force_rate_n_per_s: 500.0,
        ..no_ramp()
    };
    let step = 500.0 * T; // 0.5 N per tick
    let mut safety = Safety::new(config).unwrap();
    let target = Vec2::new(0.0, -4.0);
    let mut previous = Vec2::ZERO;
    // 4 N in 0.5 N steps: limited on ticks 0..=6, the eighth step lands on the target.
    for k in 0..8 {
        let out = safety.apply(&tick(target));
        let change = (out.force_n - previous).length();
        assert_eq!(out.flags.contains(Flags::RATE_LIMITED), k < 7, "tick {k}");
        assert!(close(change, step, 1e-6), "tick {k}: {change}");
        assert!(close(out.force_n.y, -step * (k + 1) as f32, 1e-5));
        previous = out.force_n;
    }
    let out = safety.apply(&tick(target));
    assert!(!out.flags.contains(Flags::RATE_LIMITED));
    assert!(close((out.force_n - target).length(), 0.0, 1e-5));
    // Going down is limited too, including across directions.
    let out = safety.apply(&tick(Vec2::new(3.0, 0.0)));
    assert!(close((out.force_n - target).length(), step, 1e-6));
}

#[test]
fn ramp_in_after_enable_is_linear_from_zero() {
    let ramp_s = 0.1;
    let config = SafetyConfig {
        ramp_time_s: ramp_s,
        ..SafetyConfig::default()
    };
    let mut safety = Safety::new(config).unwrap();
    let f = Vec2::new(3.0, 0.0);
    let mut input = tick(f);
    input.forces_enabled = false;
    for _ in 0..5 {
        assert_eq!(safety.apply(&input).force_n, Vec2::ZERO);
    }
    let ramp_ticks = (ramp_s / T).round() as usize;
    for k in 0..=ramp_ticks + 10 {
        let out = safety.apply(&tick(f));
        let expected = 3.0 * (k as f32 * T / ramp_s).min(1.0);
        assert!(
            close(out.force_n.x, expected, 1e-5),
            "tick {k}: {} vs {expected}",
            out.force_n.x
        );
        assert_eq!(out.flags.contains(Flags::RAMPING), k < ramp_ticks, "{k}");
        assert!(!out.flags.contains(Flags::RATE_LIMITED));
    }
}

#[test]
fn ramp_in_after_scene_swap_with_hip_inside() {
    let ramp_s = 0.05;
    let config = SafetyConfig {
        ramp_time_s: ramp_s,
        ..SafetyConfig::default()
    };
    let mut safety = Safety::new(config).unwrap();
    // Old scene: free space, ramp long finished.
    for _ in 0..200 {
        assert_eq!(safety.apply(&tick(Vec2::ZERO)).force_n, Vec2::ZERO);
    }
    // The new scene puts an object around the HIP: the renderer asks for 3 N at once.
    safety.restart_ramp_and_observer();
    let f = Vec2::new(0.0, 3.0);
    let ramp_ticks = (ramp_s / T).round() as usize;
    for k in 0..=ramp_ticks + 5 {
        let out = safety.apply(&tick(f));
        let expected = 3.0 * (k as f32 * T / ramp_s).min(1.0);
        assert!(close(out.force_n.y, expected, 1e-5), "tick {k}");
    }
    // Without the swap notification the same step is only rate-limited: a 2 N kick.
    let mut unswapped = Safety::new(config).unwrap();
    for _ in 0..200 {
        unswapped.apply(&tick(Vec2::ZERO));
    }
    let kick = unswapped.apply(&tick(f)).force_n;
    assert!(close(kick.y, 2000.0 * T, 1e-5), "{kick}");
}

#[test]
fn watchdog_trips_on_first_tick_past_timeout() {
    // The 0.1 s default timeout is 100 000 µs; an age of exactly that is still fresh.
    let mut safety = Safety::new(no_ramp()).unwrap();
    assert_eq!(safety.config().heartbeat_timeout_us(), 100_000);
    let f = Vec2::new(0.5, 0.5);
    for age_us in [0, 1, 99_999, 100_000] {
        let mut input = tick(f);
        input.heartbeat_age_us = age_us;
        let out = safety.apply(&input);
        assert_eq!(out.force_n, f, "age {age_us} µs");
        assert!(out.faults.is_empty());
    }
    for age_us in [100_001, u64::MAX] {
        let mut safety = Safety::new(no_ramp()).unwrap();
        let mut input = tick(f);
        input.heartbeat_age_us = age_us;
        let out = safety.apply(&input);
        assert_eq!(out.force_n, Vec2::ZERO, "age {age_us} µs");
        assert_eq!(out.faults, Faults::WATCHDOG);
        // Still quiet: cannot clear. Heartbeat back: clears, forces come back.
        assert_eq!(safety.clear_faults(), Faults::WATCHDOG);
        safety.apply(&tick(f));
        assert_eq!(safety.clear_faults(), Faults::empty());
        assert_eq!(safety.apply(&tick(f)).force_n, f);
    }
}

#[test]
fn unreachable_pose_latches_encoder_fault_and_cuts_the_force() {
    let mut safety = Safety::new(no_ramp()).unwrap();
    let f = Vec2::Y;
    assert_eq!(safety.apply(&tick(f)).force_n, f);
    let mut input = tick(f);
    input.pose_valid = false;
    let out = safety.apply(&input);
    assert_eq!(out.force_n, Vec2::ZERO);
    assert_eq!(out.faults, Faults::ENCODER);
    assert_eq!(safety.clear_faults(), Faults::ENCODER, "pose still invalid");
    // A good pose again: the fault stays latched until cleared.
    assert_eq!(safety.apply(&tick(f)).faults, Faults::ENCODER);
    assert_eq!(safety.apply(&tick(f)).force_n, Vec2::ZERO);
    assert_eq!(safety.clear_faults(), Faults::empty());
    assert_eq!(safety.apply(&tick(f)).force_n, f);
    // Uncalibrated there is no pose to be invalid: no fault.
    let mut safety = Safety::new(no_ramp()).unwrap();
    input.calibrated = false;
    assert!(safety.apply(&input).faults.is_empty());
}

#[test]
fn encoder_jump_latches_encoder_fault() {
    let mut safety = Safety::new(no_ramp()).unwrap();
    let f = Vec2::Y;
    let mut input = tick(f);
    input.joint_step_rad = [0.049, -0.049];
    assert_eq!(safety.apply(&input).force_n, f);
    input.joint_step_rad = [0.0, -0.2];
    let out = safety.apply(&input);
    assert_eq!(out.force_n, Vec2::ZERO);
    assert_eq!(out.faults, Faults::ENCODER);
    let out = safety.apply(&tick(f));
    assert_eq!(out.faults, Faults::ENCODER);
    assert_eq!(out.force_n, Vec2::ZERO);
    assert_eq!(safety.clear_faults(), Faults::empty());
}

#[test]
fn velocity_over_limit_latches() {
    let mut safety = Safety::new(no_ramp()).unwrap();
    let f = Vec2::X;
    let mut input = tick(f);
    input.hip_velocity_m_per_s = Vec2::new(0.6, 0.79); // |v| = 0.99 m/s
    assert_eq!(safety.apply(&input).force_n, f);
    input.hip_velocity_m_per_s = Vec2::new(0.6, 0.81); // |v| = 1.008 m/s
    let out = safety.apply(&input);
    assert_eq!(out.force_n, Vec2::ZERO);
    assert_eq!(out.faults, Faults::VELOCITY);
    assert_eq!(safety.clear_faults(), Faults::VELOCITY, "still too fast");
    input.hip_velocity_m_per_s = Vec2::ZERO;
    let out = safety.apply(&input);
    assert_eq!(out.faults, Faults::VELOCITY, "latched after slowing down");
    assert_eq!(safety.clear_faults(), Faults::empty());
}

#[test]
fn workspace_exit_latches_and_clears_only_back_inside() {
    let mut safety = Safety::new(no_ramp()).unwrap();
    let f = Vec2::new(-1.0, 0.0);
    let mut input = tick(f);
    input.hip_in_device_m = Vec2::new(0.06, 0.09); // on the boundary: inside
    assert_eq!(safety.apply(&input).force_n, f);
    input.hip_in_device_m = Vec2::new(0.0601, 0.09);
    let out = safety.apply(&input);
    assert_eq!(out.force_n, Vec2::ZERO);
    assert_eq!(out.faults, Faults::WORKSPACE);
    assert_eq!(safety.clear_faults(), Faults::WORKSPACE);
    input.hip_in_device_m = HOME;
    assert_eq!(safety.apply(&input).faults, Faults::WORKSPACE);
    assert_eq!(safety.clear_faults(), Faults::empty());
    assert_eq!(safety.apply(&input).force_n, f);
}

#[test]
fn faults_accumulate_and_clear_independently() {
    let mut safety = Safety::new(no_ramp()).unwrap();
    let mut input = tick(Vec2::X);
    input.heartbeat_age_us = 1_000_000;
    input.hip_in_device_m = Vec2::new(1.0, 1.0);
    let out = safety.apply(&input);
    assert_eq!(out.faults, Faults::WATCHDOG | Faults::WORKSPACE);
    input.heartbeat_age_us = 0;
    safety.apply(&input);
    assert_eq!(safety.clear_faults(), Faults::WORKSPACE);
}

#[test]
fn thermal_derates_then_trips_along_the_first_order_response() {
    let tau = 1.0_f64;
    let config = SafetyConfig {
        thermal: ThermalConfig {
            continuous_current_a: 1.0,
            peak_current_a: 3.0,
            time_constant_s: tau as f32,
            derate_threshold: 0.8,
            trip_threshold: 1.0,
        },
        ..no_ramp()
    };
    let mut safety = Safety::new(config).unwrap();
    let current = 2.0_f64;
    let steady = (current / 1.0).powi(2); // θ∞ = (I / I_cont)² = 4
    // θ(t) = θ∞ (1 − e^(−t/τ)): derate past t = −τ ln(1 − 0.8/4) = 0.2231 s, trip at
    // t = −τ ln(1 − 1/4) = 0.2877 s.
    let t_derate = -tau * (1.0 - 0.8 / steady).ln();
    let t_trip = -tau * (1.0 - 1.0 / steady).ln();
    let first_derate = (t_derate / T as f64).floor() as usize + 1;
    let first_trip = (t_trip / T as f64).ceil() as usize;
    assert_eq!((first_derate, first_trip), (224, 288));

    let f = Vec2::new(2.0, 0.0);
    for k in 1..=first_trip {
        let mut input = tick(f);
        input.motor_current_a = [current as f32, -0.5];
        let out = safety.apply(&input);
        let theta = steady * (1.0 - (-(k as f64) * T as f64 / tau).exp());
        let [theta_0, theta_1] = safety.thermal_state();
        assert!(
            (theta_0 as f64 - theta).abs() < 1e-4 * theta,
            "tick {k}: {theta_0} vs {theta}"
        );
        assert!(theta_1 < 0.25 + 1e-6);
        if k < first_derate {
            assert_eq!(out.force_n, f, "tick {k}");
            assert!(!out.flags.contains(Flags::DERATING));
        } else if k < first_trip {
            // Linear derate from 1 at θ = 0.8 down to 0 at θ = 1.
            let expected = 2.0 * (1.0 - theta) / 0.2;
            assert!(out.flags.contains(Flags::DERATING), "tick {k}");
            assert!(
                (out.force_n.x as f64 - expected).abs() < 2e-3,
                "tick {k}: {} vs {expected}",
                out.force_n.x
            );
            assert!(out.faults.is_empty());
        } else {
            assert_eq!(out.force_n, Vec2::ZERO);
            assert_eq!(out.faults, Faults::THERMAL);
        }
    }
    // Cooling: θ(t) = θ_trip e^(−t/τ) must fall below the derate threshold (not just below
    // trip) before the fault clears.
    let theta_trip = safety.thermal_state()[0] as f64;
    let first_clear = ((theta_trip / 0.8).ln() * tau / T as f64).ceil() as usize;
    assert_eq!(first_clear, 225);
    for k in 1..=first_clear {
        let out = safety.apply(&tick(f));
        assert_eq!(out.force_n, Vec2::ZERO);
        let remaining = safety.clear_faults();
        assert_eq!(remaining.is_empty(), k == first_clear, "cooling tick {k}");
    }
    // Back on with a ramp-in (none configured here) and no derating.
    let out = safety.apply(&tick(f));
    assert_eq!(out.force_n, f);
}

#[test]
fn thermal_model_clamps_current_to_peak() {
    let mut a = Safety::new(no_ramp()).unwrap();
    let mut b = Safety::new(no_ramp()).unwrap();
    for _ in 0..100 {
        let mut input = tick(Vec2::ZERO);
        input.motor_current_a = [-50.0, 3.0];
        a.apply(&input);
        input.motor_current_a = [3.0, 3.0];
        b.apply(&input);
    }
    assert_eq!(a.thermal_state(), b.thermal_state());
}

/// The sampled-spring scenario: the HIP is driven along x = A sin(ωt) (an ideal velocity
/// source, the user's hand) through a spring F = −K x rendered at period T with zero-order
/// hold. Returns the work the device did on the user over each cycle, in J.
fn sampled_spring_work_per_cycle(passivity_control: bool, cycles: usize) -> (Vec<f64>, Safety) {
    // The force acts over the interval after the tick that computed it: no output delay.
    let mut config = no_ramp();
    config.passivity.output_delay_ticks = 0;
    let mut safety = Safety::new(config).unwrap();
    safety.set_passivity_control(passivity_control);
    let n = SPRING_SAMPLES_PER_CYCLE;
    let omega = 2.0 * std::f64::consts::PI / (n as f64 * T as f64);
    let x = |k: usize| (SPRING_AMPLITUDE_M * (omega * k as f64 * T as f64).sin()) as f32;
    let mut work = vec![0.0; cycles];
    for k in 0..n * cycles {
        let position = Vec2::new(x(k), HOME.y);
        let velocity = SPRING_AMPLITUDE_M * omega * (omega * k as f64 * T as f64).cos();
        let mut input = tick(Vec2::new(-SPRING_K * position.x, 0.0));
        input.hip_in_device_m = position;
        input.hip_velocity_m_per_s = Vec2::new(velocity as f32, 0.0);
        let out = safety.apply(&input);
        assert!(out.faults.is_empty());
        // F[k] is held while the HIP moves from x[k] to x[k+1].
        work[k / n] += out.force_n.x as f64 * (x(k + 1) as f64 - x(k) as f64);
    }
    // One more tick so the observer sees the last interval. The spring still asks for its
    // force there (x = A sin 2πc is a few 1e-19 m, not 0): a request of exactly zero is free
    // space, where the observer forgets the contact.
    let end = x(n * cycles);
    assert_ne!(end, 0.0);
    let mut last = tick(Vec2::new(-SPRING_K * end, 0.0));
    last.hip_in_device_m = Vec2::new(end, HOME.y);
    safety.apply(&last);
    (work, safety)
}

const SPRING_K: f32 = 1000.0;
const SPRING_AMPLITUDE_M: f64 = 0.004;
/// 2 Hz at 1 kHz.
const SPRING_SAMPLES_PER_CYCLE: usize = 500;

#[test]
fn sampled_spring_leaks_energy_per_its_closed_form() {
    let (work, _) = sampled_spring_work_per_cycle(false, 5);
    // Exact discrete sum with x_k = A sin(kφ), φ = ωT, N φ = 2π:
    //   W = Σ −K x_k (x_{k+1} − x_k) = K (Σ x_k² − Σ x_k x_{k+1})
    //     = K (N A²/2 − N A²/2 cos φ) = (N K A² / 2)(1 − cos φ)
    //     ≈ π K ω T A² / 2     (1 − cos φ ≈ φ²/2).
    let n = SPRING_SAMPLES_PER_CYCLE as f64;
    let k = SPRING_K as f64;
    let a = SPRING_AMPLITUDE_M;
    let phi = 2.0 * std::f64::consts::PI / n;
    let omega = phi / T as f64;
    let exact = n * k * a * a / 2.0 * (1.0 - phi.cos());
    let approx = std::f64::consts::PI * k * omega * T as f64 * a * a / 2.0;
    assert!((exact - 3.158e-4).abs() < 1e-6, "{exact}");
    assert!((approx - exact).abs() < 1e-4 * exact);
    for (cycle, w) in work.iter().enumerate() {
        assert!(*w > 0.0, "the spring is active");
        assert!(
            (w - exact).abs() < 1e-3 * exact,
            "cycle {cycle}: simulated {w:e} J vs closed form {exact:e} J"
        );
    }
    // The leak equals what a physical damper b = K T / 2 dissipates over the cycle,
    // ∮ b v² dt = π b ω A²: exactly the marginal case of b > K T / 2 (eq. 1.1).
    let b_equivalent = exact / (std::f64::consts::PI * omega * a * a);
    assert!((b_equivalent - k * T as f64 / 2.0).abs() < 1e-4 * b_equivalent);
    for (scale, passes) in [(1.001, true), (0.999, false)] {
        let p = device(b_equivalent as f32 * scale, 0.0, 20e-6);
        let passive = WallLimits::new(&p, 0.0, T).passive_n_per_m;
        assert_eq!(SPRING_K < passive, passes, "b × {scale}: {passive} N/m");
    }
}

#[test]
fn passivity_controller_removes_the_leak() {
    let cycles = 20;
    let (leaky, leaky_safety) = sampled_spring_work_per_cycle(false, cycles);
    let (controlled, safety) = sampled_spring_work_per_cycle(true, cycles);
    let leak_per_cycle = leaky[0];
    let leaked: f64 = leaky.iter().sum();
    // Without control the observer sees the environment go active by the whole leak.
    assert!(
        (leaky_safety.observed_energy_j() as f64 + leaked).abs() < 1e-3 * leaked,
        "observer {} vs leaked {leaked}",
        leaky_safety.observed_energy_j()
    );
    // With the tank the spring gives back at most what it received: the net work on the
    // user stays at or below zero except for the tank's prediction error, F · (Δx_next −
    // Δx_last) per tick, at most K A · A ω² T² each: over the whole run that is
    // N · cycles · K A² ω² T² (1.3 µJ per cycle here, against a 316 µJ leak per cycle).
    let omega = 2.0 * std::f64::consts::PI / (SPRING_SAMPLES_PER_CYCLE as f64 * T as f64);
    let per_cycle = SPRING_SAMPLES_PER_CYCLE as f64
        * SPRING_K as f64
        * SPRING_AMPLITUDE_M.powi(2)
        * (omega * T as f64).powi(2);
    let mut net = 0.0;
    for (cycle, w) in controlled.iter().enumerate() {
        net += w;
        assert!(
            net <= per_cycle * (cycle + 1) as f64,
            "cycle {cycle}: net {net:e} J delivered (uncontrolled: {leak_per_cycle:e} J/cycle)"
        );
    }
    // And it still renders the spring: the user feels (and does) real work each cycle; the
    // tank does not simply switch the force off. Work the user does pushing in during the
    // first quarter: K A² / 2 = 8 mJ per push, of which the spring returns almost all.
    assert!(net.abs() < 0.05 * leaked, "net {net:e} J");
    assert!(safety.observed_energy_j() as f64 >= -per_cycle * cycles as f64);
}

#[test]
fn free_space_gets_no_force_and_empties_the_tank() {
    // The environment pushes the HIP 1 mm along its 2 N force: it delivered 2 mJ, so the
    // observer holds a deficit (E < 0)...
    let mut config = no_ramp();
    config.passivity.output_delay_ticks = 0;
    let mut safety = Safety::new(config).unwrap();
    safety.set_passivity_control(true);
    safety.apply(&tick(Vec2::new(-2.0, 0.0)));
    let mut moving = tick(Vec2::new(-2.0, 0.0));
    moving.hip_in_device_m = HOME - Vec2::new(0.001, 0.0);
    moving.hip_velocity_m_per_s = Vec2::new(-1.0, 0.0);
    safety.apply(&moving);
    assert!(
        (safety.observed_energy_j() + 2e-3).abs() < 1e-6,
        "{}",
        safety.observed_energy_j()
    );
    // ... then the HIP leaves the object moving at 0.3 m/s: the renderer asks for nothing.
    // The device applies nothing, at once (no rate-limited tail from the 2 N before), and the
    // observer forgets the contact's energy.
    let mut free = tick(Vec2::ZERO);
    free.hip_in_device_m = HOME - Vec2::new(0.0013, 0.0);
    free.hip_velocity_m_per_s = Vec2::new(-0.3, 0.0);
    let out = safety.apply(&free);
    assert_eq!(out.force_n, Vec2::ZERO);
    assert!(!out.flags.contains(Flags::ENERGY_LIMITED));
    assert_eq!(safety.observed_energy_j(), 0.0);
    for _ in 0..10 {
        free.hip_in_device_m.x -= 0.0003;
        assert_eq!(safety.apply(&free).force_n, Vec2::ZERO);
    }
}

/// The energy a wall of stiffness `k` capped at `f_max` gives back from depth `d`, in f64:
/// the integral of `min(k x, f_max)` over `[0, d]` summed in 200,000 slices by the midpoint
/// rule (exact on the linear and the constant part; the one slice across the kink at
/// `f_max / k` errs by at most `k h² / 8`, 7e-14 J here), an independent reference for the
/// closed form the safety layer uses.
fn capped_wall_work_j(k: f64, f_max: f64, d: f64) -> f64 {
    let n = 200_000;
    let h = d / n as f64;
    (0..n)
        .map(|i| (k * (i as f64 + 0.5) * h).min(f_max) * h)
        .sum()
}

/// Issue 29: when a fault clears with the handle deep inside, the tank opened with the
/// energy of the *requested* force, `|F|² / 2K`, not with what the force-capped wall can give
/// back; the wall then had credit to throw the handle out faster than it came in. Here: K =
/// 1000 N/m, the force capped at 3 N, the handle 10.6 mm in (the wall asks for 10.6 N). The
/// capped wall gives back 3² / 2000 + 3 (0.0106 − 0.003) = 27.3 mJ; the old opening balance
/// was 10.6² / 2000 = 56.2 mJ.
#[test]
fn a_tank_opened_deep_inside_holds_what_the_capped_wall_gives_back() {
    let (k, f_max, depth) = (1000.0f32, 3.0f32, 0.0106f32);
    let mut config = no_ramp();
    config.max_force_n = f_max;
    config.passivity.output_delay_ticks = 0;
    let mut safety = Safety::new(config).unwrap();
    safety.set_wall_stiffness(k);
    safety.set_passivity_control(true);
    // A velocity fault latches and clears with the handle at rest 10.6 mm inside.
    let inside = HOME;
    let mut input = tick(Vec2::new(0.0, k * depth));
    input.hip_in_device_m = inside;
    input.hip_velocity_m_per_s = Vec2::new(0.0, 2.0);
    assert_eq!(safety.apply(&input).faults, Faults::VELOCITY);
    input.hip_velocity_m_per_s = Vec2::ZERO;
    safety.apply(&input);
    assert_eq!(safety.clear_faults(), Faults::empty());
    let out = safety.apply(&input);
    assert!(
        out.force_n.y > 0.0 && out.force_n.y <= f_max,
        "{:?}",
        out.force_n
    );

    let stored = capped_wall_work_j(k as f64, f_max as f64, depth as f64);
    assert!((stored - 0.0273).abs() < 1e-9, "{stored}");
    // f32: the closed form's few roundings, 4 ε relative.
    let opened = safety.observed_energy_j() as f64;
    assert!(
        (opened - stored).abs() <= 4.0 * f32::EPSILON as f64 * stored,
        "the tank opened with {opened:e} J; the capped wall gives back {stored:e} J \
         (uncapped ½ K d² = {:e} J)",
        0.5 * k as f64 * (depth as f64).powi(2)
    );
    // Below the cap the opening balance is the spring's ½ K d² (2 mm: 2 mJ).
    let mut shallow = Safety::new(config).unwrap();
    shallow.set_wall_stiffness(k);
    shallow.set_passivity_control(true);
    shallow.apply(&tick(Vec2::new(0.0, k * 0.002)));
    let opened = shallow.observed_energy_j() as f64;
    assert!(
        (opened - 2e-3).abs() <= 4.0 * f32::EPSILON as f64 * 2e-3,
        "{opened}"
    );

    // The handle then leaves along the force at 10 mm/s (10 µm a tick) to the surface: the
    // tank lets the capped wall give back what it holds, and no more. The device's work
    // (the held force over each step, a left sum of the capped spring) exceeds the integral
    // by at most K d_cap h / 2 = 15 µJ on the linear part; the tank cuts that excess.
    let step = 1e-5f32;
    let mut given = 0.0f64;
    let mut position = inside;
    let mut depth_now = depth;
    let mut held = out.force_n;
    while depth_now > step {
        position.y += step;
        depth_now -= step;
        given += held.y as f64 * step as f64;
        let mut next = tick(Vec2::new(0.0, k * depth_now));
        next.hip_in_device_m = position;
        next.hip_velocity_m_per_s = Vec2::new(0.0, 0.01);
        held = safety.apply(&next).force_n;
    }
    let slack = 0.5 * k as f64 * (f_max / k) as f64 * step as f64;
    assert!(
        given <= stored + slack && given >= stored - 2.0 * slack,
        "the wall gave back {given:e} J of the {stored:e} J it holds"
    );
}

/// A scripted impact: the handle enters a wall of K = 1000 N/m (the force capped at 3 N, the
/// default 2000 N/s rate limit) at `speed`, for 15 ms, turns back at once and leaves at the
/// same speed, at `rate_hz` with `delay` ticks of output delay. Returns the work the user
/// did on the wall and the work the wall did on the user (J), each as the held force over
/// each step (with the delay, the force of the tick before), in f64.
fn impact_work(rate_hz: f32, speed: f32, delay: u32) -> (f64, f64, usize) {
    let period = 1.0 / rate_hz;
    let mut config = no_ramp();
    config.period_s = period;
    config.max_force_n = 3.0;
    config.max_velocity_m_per_s = 2.0;
    config.passivity.output_delay_ticks = delay;
    let mut safety = Safety::new(config).unwrap();
    safety.set_wall_stiffness(1000.0);
    safety.set_passivity_control(true);
    let n = (0.015 * rate_hz) as usize;
    let depth = |i: usize| speed * period * (if i <= n { i } else { 2 * n - i }) as f32;
    let (mut received, mut given) = (0.0f64, 0.0f64);
    let mut held = [Vec2::ZERO; 2];
    for i in 0..=2 * n + 1 {
        // Past the surface (i = 2n + 1) the renderer asks for nothing.
        let d = if i > 2 * n { -speed * period } else { depth(i) };
        if i > 0 {
            let previous = if i - 1 > 2 * n { 0.0 } else { depth(i - 1) };
            // +y is out of the wall: the step out is the depth lost.
            let step_out = (previous - d) as f64;
            let acting = if delay > 0 { held[0] } else { held[1] };
            let work = acting.y as f64 * step_out;
            if work > 0.0 {
                given += work;
            } else {
                received -= work;
            }
        }
        let mut input = tick(if d > 0.0 {
            Vec2::new(0.0, 1000.0 * d)
        } else {
            Vec2::ZERO
        });
        input.hip_in_device_m = HOME - Vec2::new(0.0, d);
        input.hip_velocity_m_per_s = Vec2::new(0.0, speed);
        let out = safety.apply(&input);
        assert!(out.faults.is_empty(), "{:?}", out.faults);
        held = [held[1], out.force_n];
    }
    (received, given, 2 * n + 2)
}

/// Issue 29: an impact at 0.86 m/s (8.6 × the demonstrated speed) returned more than the
/// hand put in. One cause the tank can close: the rate limiter ran after it, so a cut of the
/// force to what the tank holds (3 N to nothing) took two ticks at 1 kHz (2 N a tick) and
/// fifteen at 10 kHz, the force held above the tank's meanwhile (0.14 mJ more out than in at
/// 1 kHz, 0.30 mJ at 10 kHz with a tick of delay, in this scripted bounce). Now the cut goes
/// through; the wall gives back what it received, to f32 rounding of the tank's balance: at
/// most 4 ε of the 35 mJ it holds per tick, 4 µJ over the 302 ticks at 10 kHz.
#[test]
fn a_fast_impact_gives_back_no_more_than_it_received() {
    for rate_hz in [1_000.0, 10_000.0] {
        for delay in [0, 1] {
            let (received, given, ticks) = impact_work(rate_hz, 0.86, delay);
            let rounding = ticks as f64 * 4.0 * f32::EPSILON as f64 * 0.035;
            assert!(
                received > 0.02,
                "{rate_hz} Hz: the wall was pressed: {received:e} J"
            );
            assert!(
                given <= received + rounding,
                "{rate_hz} Hz, delay {delay}: gave {given:e} J for {received:e} J received \
                 ({:e} J more)",
                given - received
            );
            // And the tank renders the wall: it gives back nearly all it received.
            assert!(
                given >= 0.9 * received,
                "{rate_hz} Hz: gave {given:e} J of {received:e}"
            );
        }
    }
}

fn scalar() -> impl Strategy<Value = f32> {
    prop_oneof![
        30 => -0.2f32..0.2,
        1 => any::<f32>(),
        1 => prop_oneof![
            Just(f32::NAN),
            Just(f32::INFINITY),
            Just(f32::NEG_INFINITY),
            Just(f32::MAX),
            Just(-f32::MAX),
        ],
    ]
}

fn vec2() -> impl Strategy<Value = Vec2> {
    (scalar(), scalar()).prop_map(|(x, y)| Vec2::new(x, y))
}

prop_compose! {
    fn random_tick()(
        force in (scalar(), scalar()).prop_map(|(x, y)| Vec2::new(x * 100.0, y * 100.0)),
        offset in vec2(),
        velocity in vec2(),
        steps in (scalar(), scalar()),
        age_us in any::<u64>(),
        pose_valid in prop::bool::weighted(0.9),
        currents in (scalar(), scalar()),
        forces_enabled in prop::bool::weighted(0.9),
        calibrated in prop::bool::weighted(0.9),
        clear in prop::bool::weighted(0.3),
        identification in prop::bool::weighted(0.1),
    ) -> (SafetyInput, bool) {
        (SafetyInput {
            force_n: force,
            hip_in_device_m: HOME + offset * 0.1,
            hip_velocity_m_per_s: velocity,
            joint_step_rad: [steps.0 * 0.1, steps.1 * 0.1],
            heartbeat_age_us: age_us,
            motor_current_a: [currents.0 * 10.0, currents.1 * 10.0],
            forces_enabled,
            calibrated,
            pose_valid,
            identification,
        }, clear)
    }
}

proptest! {
    #[test]
    fn output_is_finite_and_within_the_force_limit(
        ticks in prop::collection::vec(random_tick(), 1..60),
        passivity_control in any::<bool>(),
        ramp in prop::bool::ANY,
    ) {
        let config = SafetyConfig {
            ramp_time_s: if ramp { 0.01 } else { 0.0 },
            ..SafetyConfig::default()
        };
        let max = config.max_force_n;
        let mut safety = Safety::new(config).unwrap();
        safety.set_passivity_control(passivity_control);
        for (input, clear) in &ticks {
            if *clear {
                safety.clear_faults();
            }
            let out = safety.apply(input);
            prop_assert!(out.force_n.is_finite(), "{:?} -> {:?}", input, out);
            prop_assert!(out.force_n.length() <= max * (1.0 + 1e-6), "{:?}", out);
            if !input.is_finite() {
                prop_assert_eq!(out.force_n, Vec2::ZERO);
                prop_assert!(out.faults.contains(Faults::NUMERIC));
            }
            prop_assert!(safety.observed_energy_j().is_finite());
        }
    }
}

/// The wall pressed deeper during the ramp-in is whole after it, with the passivity
/// controller's tank on. A flaky `cargo xtask hid` (3.98 N asked, 0.08 N given for 10 s, no
/// fault) suggested that a handle going in while the ramp scales the force puts in less work
/// than the wall then stores, so that the tank would cut the force at the ramp's end for
/// good. This checks that suspicion and finds it does not hold. Here K = 1000 N/m, the contact
/// starts 0.5 mm in, the handle goes 3.5 mm further over the first 0.2 s of the 0.5 s ramp,
/// then holds 4 mm in, where the wall asks 4 N (under the 5 N cap).
#[test]
fn a_wall_pressed_in_during_the_ramp_is_whole_after_it() {
    let k = 1000.0f32;
    let mut config = SafetyConfig::default();
    config.passivity.output_delay_ticks = 0;
    let period_s = config.period_s;
    let mut safety = Safety::new(config).unwrap();
    safety.set_wall_stiffness(k);
    safety.set_passivity_control(true);
    let surface_y = HOME.y + 0.0005;
    let depth_at = |tick: u32| 0.0005 + 0.0035 * (tick as f32 / 200.0).min(1.0);
    let mut last = Vec2::ZERO;
    for i in 0..1000u32 {
        let depth = depth_at(i);
        let mut input = tick(Vec2::new(0.0, k * depth));
        input.hip_in_device_m = Vec2::new(0.0, surface_y - depth);
        let speed = if i < 200 {
            0.0035 / (200.0 * period_s)
        } else {
            0.0
        };
        input.hip_velocity_m_per_s = Vec2::new(0.0, -speed);
        last = safety.apply(&input).force_n;
        if i >= 600 {
            // 0.1 s after the ramp's end: the whole wall, 4 N (f32 of the products: 1e-5 N).
            assert!(
                close(last.y, k * 0.004, 1e-3),
                "tick {i}: the wall gives {} N of {} N",
                last.y,
                k * 0.004
            );
        }
    }
    // And no more than the wall holds: the tank's credit is at most what the wall stores at
    // 4 mm, ½ K d² = 8 mJ (f32: 4 ε relative).
    let stored = 0.5 * k * 0.004f32 * 0.004;
    assert!(
        safety.observed_energy_j() <= stored * (1.0 + 4.0 * f32::EPSILON),
        "{} J credited, the wall stores {stored} J",
        safety.observed_energy_j()
    );
    assert!(last.y > 0.0);
}
