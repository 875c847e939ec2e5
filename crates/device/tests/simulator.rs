//! The simulated pantograph against the physics it models: energy conservation without
//! dissipation, the hand's static equilibrium, the equilibrium against a motor force
//! (τ = Jᵀ F), and encoder quantisation.
#![allow(clippy::unwrap_used)]

use device::simulator::{MAX_HAND_SPEED_M_PER_S, SimParams, SimulatedPantograph, VirtualHand};
use device::spec::DeviceSpec;
use nurbs::{Point, Vec2, Vec3};

const DT: f32 = 1e-3;

fn start() -> Vec2 {
    Vec2::new(0.0, 0.09)
}

/// No motor, no damping anywhere, the hand's spring only: kinetic + spring energy is
/// conserved (semi-implicit Euler is symplectic: the energy error stays bounded, here below
/// 1 % over 200 ms of oscillation).
#[test]
fn energy_is_conserved_without_dissipation() {
    let spec = DeviceSpec {
        joint_damping_nms_per_rad: [f32::MIN_POSITIVE; 2],
        joint_coulomb_nm: [0.0; 2],
        ..DeviceSpec::default()
    };
    let params = SimParams {
        hand_damping_ns_per_m: f32::MIN_POSITIVE,
        substeps: 20,
        ..SimParams::default()
    };
    let mut sim = SimulatedPantograph::new(spec, params, start()).unwrap();
    let target = start() + Vec2::new(0.01, 0.005);
    let energy = |s: &SimulatedPantograph| {
        let (x, _) = s.hip().unwrap();
        s.kinetic_energy().unwrap()
            + 0.5 * params.hand_stiffness_n_per_m * (target - x).length_squared()
    };
    let e0 = energy(&sim);
    let mut max_ke: f32 = 0.0;
    for _ in 0..200 {
        sim.step([0.0; 2], target, DT).unwrap();
        max_ke = max_ke.max(sim.kinetic_energy().unwrap());
        let e = energy(&sim);
        assert!((e - e0).abs() < 0.01 * e0, "energy {e} vs {e0}");
    }
    assert!(
        max_ke > 0.5 * e0,
        "the arm actually swung (max KE {max_ke} of {e0})"
    );
}

/// A mechanism without dry friction.
fn frictionless() -> DeviceSpec {
    DeviceSpec {
        joint_coulomb_nm: [0.0; 2],
        ..DeviceSpec::default()
    }
}

/// With damping and no motor force the hand brings the HIP to its target.
#[test]
fn hand_pulls_the_handle_to_its_target() {
    let mut sim = SimulatedPantograph::new(frictionless(), SimParams::default(), start()).unwrap();
    let target = Vec2::new(-0.02, 0.11);
    for _ in 0..3000 {
        sim.step([0.0; 2], target, DT).unwrap();
    }
    let (x, v) = sim.hip().unwrap();
    assert!((x - target).length() < 1e-4, "HIP {x:?}");
    assert!(v.length() < 1e-3);
}

/// Motors rendering a constant force F against the hand: at rest the forces balance,
/// k_h (target − x) + F = 0, so x = target + F / k_h. The currents come from τ = Jᵀ F through
/// the description's motor model, so this checks the whole chain force → torque → current →
/// torque → acceleration.
#[test]
fn motor_force_balances_the_hand() {
    let spec = frictionless();
    let params = SimParams::default();
    let mut sim = SimulatedPantograph::new(spec, params, start()).unwrap();
    let arm = spec.validate().unwrap();
    let force = Vec2::new(1.5, -0.9);
    let target = start();
    for _ in 0..4000 {
        let tau = arm.joint_torques(sim.joint_angles(), force).unwrap();
        let currents = [0, 1].map(|i| {
            spec.motor_direction[i].sign() * tau[i]
                / (spec.transmission_ratio[i] * spec.torque_constant_nm_per_a[i])
        });
        sim.step(currents, target, DT).unwrap();
    }
    let (x, _) = sim.hip().unwrap();
    let expected = target + force / params.hand_stiffness_n_per_m;
    assert!((x - expected).length() < 2e-5, "{x:?} vs {expected:?}");
}

/// Coulomb friction at the joints: a hand whose pull needs at most half the friction torque
/// at each joint (τ = Jᵀ F) leaves the handle exactly where it is; twice the friction torque
/// moves it, and it comes to rest short of the hand's target by no more than the friction
/// can hold, |x − target| ≤ ‖J⁻ᵀ τ_c‖ / k_h.
#[test]
fn coulomb_friction_holds_a_weak_pull_and_yields_to_a_strong_one() {
    let spec = DeviceSpec::default();
    let params = SimParams::default();
    let arm = spec.validate().unwrap();
    let theta = arm.inverse(start()).unwrap();
    let direction = Vec2::new(0.6, 0.8);
    let tau_unit = arm.joint_torques(theta, direction).unwrap();
    // The force along `direction` whose larger joint torque is the friction torque.
    let f_c = spec.joint_coulomb_nm[0] / tau_unit[0].abs().max(tau_unit[1].abs());
    for (scale, moves) in [(0.5, false), (2.0, true)] {
        let mut sim = SimulatedPantograph::new(spec, params, start()).unwrap();
        let target = start() + direction * (scale * f_c / params.hand_stiffness_n_per_m);
        for _ in 0..500 {
            sim.step([0.0; 2], target, DT).unwrap();
        }
        let moved = sim.joint_angles() != theta;
        assert_eq!(moved, moves, "pull {scale} × friction");
        if moves {
            let (x, v) = sim.hip().unwrap();
            assert!(v.length() < 1e-6, "at rest: {v:?}");
            // Held short of the target by at most the friction's reach along both joints.
            let hold = 2.0 * f_c / params.hand_stiffness_n_per_m;
            assert!((x - target).length() <= hold, "{x:?} vs {target:?}");
            assert!((x - start()).length() > 0.0);
        }
    }
}

/// Encoders read whole counts: the angle from the counts is within one count of the true
/// angle, and the counts move by the expected amount when the joint turns.
#[test]
fn encoder_counts_quantise_the_joint_angles() {
    let spec = DeviceSpec::default();
    let mut sim = SimulatedPantograph::new(spec, SimParams::default(), start()).unwrap();
    let per_rad = spec.counts_per_joint_rad();
    for _ in 0..500 {
        sim.step([0.3, -0.2], start() + Vec2::new(0.02, 0.0), DT)
            .unwrap();
        let from_counts = spec.joint_angles(sim.encoder_counts());
        let truth = sim.joint_angles();
        for i in 0..2 {
            assert!(
                (from_counts[i] - truth[i]).abs() <= 1.0 / per_rad[i] + 1e-6,
                "joint {i}: {} vs {}",
                from_counts[i],
                truth[i]
            );
        }
    }
}

#[test]
fn bad_parameters_are_rejected() {
    let bad = SimParams {
        handle_mass_kg: f32::NAN,
        ..SimParams::default()
    };
    assert!(SimulatedPantograph::new(DeviceSpec::default(), bad, start()).is_err());
    assert!(
        SimulatedPantograph::new(
            DeviceSpec::default(),
            SimParams::default(),
            Vec2::new(0.0, 0.5)
        )
        .is_err()
    );
}

/// A glide covers its way in the time given at a steady speed, the same in 2-D and 3-D: the
/// way over the time, checked on a 3-4-5 triangle (5 mm in 0.1 s: 50 mm/s, so 100 steps of
/// 1 ms move 0.5 mm each). A glide faster than the hand goes is held to its top speed, a
/// time of 0 (or not finite) means as fast as it goes, and a non-finite target is ignored.
#[test]
fn a_glide_covers_its_way_in_its_time_at_most_at_the_top_speed() {
    fn check<P: Point>(from: P, to: P) {
        let mut hand = VirtualHand::at(from);
        hand.glide(to, 0.1);
        for k in 1..=100 {
            let at = hand.step(1e-3);
            let expected = from + (to - from) * (k as f32 / 100.0);
            // f32 rounding over k steps near 0.1 m: k × ulp(0.1)/2 ≈ 7e-9·k m.
            assert!(
                (at - expected).length_squared() < (1e-8 * k as f32).powi(2),
                "step {k}: {at:?} against {expected:?}"
            );
        }
        assert_eq!(hand.step(1e-3), to, "arrived and staying");

        // 5 mm in 1 ms would be 5 m/s: the hand goes at its top speed instead.
        let mut hand = VirtualHand::at(from);
        hand.glide(to, 1e-3);
        let moved = (hand.step(1e-3) - from).length_squared().sqrt();
        let top = MAX_HAND_SPEED_M_PER_S * 1e-3;
        assert!((moved - top).abs() < 1e-3 * top, "{moved} against {top}");
        for over_s in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            let mut hand = VirtualHand::at(from);
            hand.glide(to, over_s);
            let moved = (hand.step(1e-3) - from).length_squared().sqrt();
            assert!((moved - top).abs() < 1e-3 * top, "over {over_s}: {moved}");
        }
        let mut hand = VirtualHand::at(from);
        hand.glide(from + (to - from) * f32::NAN, 0.1);
        assert_eq!(hand.command_point(), from, "a NaN target is ignored");
    }
    check(Vec2::new(0.0, 0.1), Vec2::new(0.003, 0.104));
    check(Vec3::new(0.0, 0.1, 0.0), Vec3::new(0.003, 0.1, 0.004));
}
