//! Pantograph kinematics, device spec, encoders, motors and calibration.
//!
//! References come from outside the code under test: an f64 forward kinematics written in a
//! different form (angles by the law of cosines instead of the circle-intersection formula),
//! central finite differences, virtual work, and values worked by hand.

#![allow(clippy::unwrap_used)]

use core::f64::consts::PI as PI64;
use device::kinematics::{KinematicsError, Pantograph, Singularity};
use device::spec::{Calibration, CalibrationError, CommandError, DeviceSpec, Direction, SpecError};
use nurbs::Vec2;
use proptest::prelude::*;

/// Independent f64 forward kinematics: the HIP is `P1 + b1 (cos(φ + β), sin(φ + β))` with `φ`
/// the direction of `P1 → P2` and `β` the angle at `P1` of the triangle `P1 P2 E`.
fn fk_ref(d: f64, l: [f64; 2], b: [f64; 2], theta: [f64; 2]) -> Option<[f64; 2]> {
    let p1 = [-d / 2.0 + l[0] * theta[0].cos(), l[0] * theta[0].sin()];
    let p2 = [d / 2.0 + l[1] * theta[1].cos(), l[1] * theta[1].sin()];
    let u = [p2[0] - p1[0], p2[1] - p1[1]];
    let dist = u[0].hypot(u[1]);
    let cos_beta = (b[0] * b[0] + dist * dist - b[1] * b[1]) / (2.0 * b[0] * dist);
    if !(-1.0..=1.0).contains(&cos_beta) {
        return None;
    }
    let angle = u[1].atan2(u[0]) + cos_beta.acos();
    Some([p1[0] + b[0] * angle.cos(), p1[1] + b[0] * angle.sin()])
}

fn default_ref(theta: [f64; 2]) -> [f64; 2] {
    let s = DeviceSpec::default();
    fk_ref(
        s.base_separation_m as f64,
        s.proximal_m.map(f64::from),
        s.distal_m.map(f64::from),
        theta,
    )
    .unwrap()
}

/// Central-difference Jacobian of the f64 reference.
fn jacobian_fd(theta: [f64; 2]) -> [[f64; 2]; 2] {
    let h = 1e-6;
    let mut j = [[0.0; 2]; 2];
    for col in 0..2 {
        let mut plus = theta;
        let mut minus = theta;
        plus[col] += h;
        minus[col] -= h;
        let (a, b) = (default_ref(plus), default_ref(minus));
        j[0][col] = (a[0] - b[0]) / (2.0 * h);
        j[1][col] = (a[1] - b[1]) / (2.0 * h);
    }
    j
}

/// 2-norm condition number from the eigenvalues of `JᵀJ`, in f64.
fn condition_ref(m: [[f32; 2]; 2]) -> f64 {
    let [[a, b], [c, d]] = m.map(|r| r.map(f64::from));
    let p = a * a + c * c;
    let q = a * b + c * d;
    let r = b * b + d * d;
    let mean = 0.5 * (p + r);
    let rad = (0.25 * (p - r) * (p - r) + q * q).sqrt();
    ((mean + rad) / (mean - rad)).sqrt()
}

fn default_pantograph() -> Pantograph {
    DeviceSpec::default().pantograph().unwrap()
}

/// The architecture's workspace box x ∈ [−0.05, 0.05], y ∈ [0.05, 0.13] on a 2.5 mm grid.
fn box_grid() -> impl Iterator<Item = Vec2> {
    (0..=40).flat_map(|i| {
        (0..=32).map(move |j| Vec2::new(-0.05 + 0.0025 * i as f32, 0.05 + 0.0025 * j as f32))
    })
}

#[test]
fn default_spec_is_valid_and_has_typical_dimensions() {
    let spec = DeviceSpec::default();
    spec.validate().unwrap();
    assert!((0.04..=0.06).contains(&spec.base_separation_m));
    for i in 0..2 {
        assert!((0.07..=0.1).contains(&spec.proximal_m[i]));
        assert!((0.09..=0.12).contains(&spec.distal_m[i]));
    }
    assert_eq!(spec.workspace.min_in_device, Vec2::new(-0.05, 0.05));
    assert_eq!(spec.workspace.max_in_device, Vec2::new(0.05, 0.13));
}

#[test]
fn default_reaches_the_workspace_box_well_conditioned() {
    let spec = DeviceSpec::default();
    let pantograph = default_pantograph();
    let mut worst_condition: f64 = 0.0;
    let mut worst_round_trip: f32 = 0.0;
    let mut theta1_max = f32::MIN;
    let mut theta2_min = f32::MAX;
    let mut weakest_force_n = f64::MAX;
    let mut points = 0;
    for p in box_grid() {
        let theta = pantograph.inverse(p).unwrap();
        let back = pantograph.forward(theta).unwrap();
        let err = (back - p).length();
        assert!(err <= 1e-6, "FK(IK({p})) = {back}, off by {err} m");
        let j = pantograph.jacobian(theta).unwrap();
        let kappa = condition_ref(j.m);
        assert!(kappa < 10.0, "condition {kappa} at {p}");
        assert!((j.condition_number() as f64 - kappa).abs() <= 1e-3 * kappa);
        // The f64 reference agrees on the HIP too.
        let r = default_ref(theta.map(f64::from));
        assert!((r[0] - p.x as f64).abs() < 1e-6 && (r[1] - p.y as f64).abs() < 1e-6);
        assert!(theta[0] < spec.end_stop_rad[0] && theta[1] > spec.end_stop_rad[1]);
        // The force the motors can push in every direction: |Jᵀ F|∞ ≤ τmax.
        let tau_max = (spec.current_limit_a[0]
            * spec.torque_constant_nm_per_a[0]
            * spec.transmission_ratio[0]) as f64;
        let col = |c: usize| (j.m[0][c] as f64).hypot(j.m[1][c] as f64);
        weakest_force_n = weakest_force_n.min(tau_max / col(0).max(col(1)));
        worst_condition = worst_condition.max(kappa);
        worst_round_trip = worst_round_trip.max(err);
        theta1_max = theta1_max.max(theta[0]);
        theta2_min = theta2_min.min(theta[1]);
        points += 1;
    }
    assert!(weakest_force_n >= spec.max_force_n as f64);
    eprintln!(
        "{points} points: worst condition {worst_condition:.3}, worst FK∘IK error {worst_round_trip:e} m, \
         θ1 ≤ {:.1}°, θ2 ≥ {:.1}°, isotropic force ≥ {weakest_force_n:.2} N",
        theta1_max.to_degrees(),
        theta2_min.to_degrees()
    );
}

#[test]
fn jacobian_matches_central_differences_over_the_workspace() {
    let pantograph = default_pantograph();
    for p in box_grid().step_by(7) {
        let theta = pantograph.inverse(p).unwrap();
        let j = pantograph.jacobian(theta).unwrap();
        let fd = jacobian_fd(theta.map(f64::from));
        let scale = fd.iter().flatten().map(|v| v * v).sum::<f64>().sqrt();
        for row in 0..2 {
            for col in 0..2 {
                let diff = (j.m[row][col] as f64 - fd[row][col]).abs();
                assert!(
                    diff <= 1e-4 * scale,
                    "J[{row}][{col}] = {} vs finite difference {} at {p}",
                    j.m[row][col],
                    fd[row][col]
                );
            }
        }
    }
}

#[test]
fn jacobian_signs_at_the_symmetric_pose() {
    // Symmetric pose: both elbows out, HIP on the y axis. Turning the left motor
    // counterclockwise swings its elbow down-left and pulls the HIP left and down; the right
    // motor counterclockwise pushes the HIP left and up (mirror image).
    let pantograph = default_pantograph();
    let theta = pantograph.inverse(Vec2::new(0.0, 0.1)).unwrap();
    assert!((theta[0] - (core::f32::consts::PI - theta[1])).abs() < 1e-5);
    let j = pantograph.jacobian(theta).unwrap();
    assert!(j.m[0][0] < 0.0 && j.m[1][0] < 0.0, "{:?}", j.m);
    assert!(j.m[0][1] < 0.0 && j.m[1][1] > 0.0, "{:?}", j.m);
    assert!((j.m[0][0] - j.m[0][1]).abs() < 1e-5 && (j.m[1][0] + j.m[1][1]).abs() < 1e-5);
}

#[test]
fn ik_of_fk_returns_the_joint_angles() {
    let pantograph = default_pantograph();
    for p in box_grid().step_by(5) {
        let base = pantograph.inverse(p).unwrap();
        for (d1, d2) in [(0.01, -0.02), (-0.015, 0.0), (0.0, 0.012)] {
            let theta = [base[0] + d1, base[1] + d2];
            let hip = pantograph.forward(theta).unwrap();
            let again = pantograph.inverse(hip).unwrap();
            for i in 0..2 {
                assert!(
                    (again[i] - theta[i]).abs() < 1e-4,
                    "θ = {theta:?} → {hip} → {again:?}"
                );
            }
        }
    }
}

#[test]
fn torques_do_the_same_virtual_work_as_the_force() {
    let pantograph = default_pantograph();
    let forces = [
        Vec2::new(1.0, 0.0),
        Vec2::new(0.0, -2.0),
        Vec2::new(-1.5, 0.7),
    ];
    let steps = [[1e-5, 0.0], [0.0, 1e-5], [-7e-6, 4e-6]];
    for p in box_grid().step_by(11) {
        let theta = pantograph.inverse(p).unwrap();
        let t64 = theta.map(f64::from);
        for force in forces {
            let tau = pantograph.joint_torques(theta, force).unwrap();
            for dtheta in steps {
                let plus = default_ref([t64[0] + dtheta[0] / 2.0, t64[1] + dtheta[1] / 2.0]);
                let minus = default_ref([t64[0] - dtheta[0] / 2.0, t64[1] - dtheta[1] / 2.0]);
                let work_force =
                    force.x as f64 * (plus[0] - minus[0]) + force.y as f64 * (plus[1] - minus[1]);
                let work_joints = tau[0] as f64 * dtheta[0] + tau[1] as f64 * dtheta[1];
                let scale = (force.length() as f64) * 0.2 * 1e-5;
                assert!(
                    (work_force - work_joints).abs() <= 1e-4 * scale,
                    "F·dx = {work_force:e}, τ·dθ = {work_joints:e} at {p}"
                );
            }
        }
    }
}

#[test]
fn unreachable_targets_give_their_error() {
    let pantograph = default_pantograph();
    assert!(matches!(
        pantograph.inverse(Vec2::new(0.0, 0.3)),
        Err(KinematicsError::TooFar { max_m, .. }) if (max_m - 0.18).abs() < 1e-6
    ));
    assert!(matches!(
        pantograph.inverse(Vec2::new(0.4, 0.0)),
        Err(KinematicsError::TooFar { joint: 0, .. })
    ));
    // |l − b| = 0.02 m: 10 mm above the left motor is too close for arm 1.
    assert!(matches!(
        pantograph.inverse(Vec2::new(-0.025, 0.01)),
        Err(KinematicsError::TooClose { joint: 0, min_m, .. }) if (min_m - 0.02).abs() < 1e-6
    ));
    assert!(matches!(
        pantograph.inverse(Vec2::new(0.025, 0.0)),
        Err(KinematicsError::TooClose { joint: 1, .. })
    ));
    // 10 mm in front of the motors the elbows-out arms put the HIP below the line through
    // the elbows (elbows at y ≈ 0.035 m, x ≈ ±0.097 m): the other assembly mode.
    assert!(matches!(
        pantograph.inverse(Vec2::new(0.0, 0.01)),
        Err(KinematicsError::OtherAssemblyMode { .. })
    ));
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        assert!(matches!(
            pantograph.inverse(Vec2::new(bad, 0.1)),
            Err(KinematicsError::NonFinite {
                quantity: "hip x",
                ..
            })
        ));
        assert!(matches!(
            pantograph.inverse(Vec2::new(0.0, bad)),
            Err(KinematicsError::NonFinite {
                quantity: "hip y",
                ..
            })
        ));
        assert!(matches!(
            pantograph.forward([0.0, bad]),
            Err(KinematicsError::NonFinite {
                quantity: "joint angle θ2",
                ..
            })
        ));
        assert!(matches!(
            pantograph.joint_torques([2.0, 1.0], Vec2::new(bad, 0.0)),
            Err(KinematicsError::NonFinite {
                quantity: "force x",
                ..
            })
        ));
    }
    // Huge but finite targets overflow to an infinite distance: still "too far".
    assert!(matches!(
        pantograph.inverse(Vec2::new(3e38, 3e38)),
        Err(KinematicsError::TooFar { .. })
    ));
}

/// Forward kinematics takes sin/cos from `device::math`, whose error bound holds up to
/// ±8192 rad (1300 revolutions; a real joint turns less than one): beyond, the angle is
/// refused by name instead of evaluated with a reduction that lost its accuracy.
#[test]
fn forward_kinematics_refuses_angles_beyond_the_reduction_range() {
    let pantograph = default_pantograph();
    let max = device::math::SIN_COS_MAX_ANGLE_RAD;
    for (theta, quantity) in [
        ([2.0 * max, 0.5], "joint angle θ1"),
        ([2.5, -1e6], "joint angle θ2"),
        ([f32::MAX, 0.5], "joint angle θ1"),
    ] {
        match pantograph.forward(theta) {
            Err(KinematicsError::AngleOutOfRange {
                quantity: q,
                value_rad,
                max_rad,
            }) => {
                assert_eq!(q, quantity);
                assert!(value_rad.abs() > max_rad && max_rad == max, "{theta:?}");
            }
            other => panic!("{theta:?}: {other:?}"),
        }
        let message = pantograph.forward(theta).unwrap_err().to_string();
        assert!(
            message.contains(quantity) && message.contains("no pose"),
            "{message}"
        );
    }
    // Up to the edge of the range the angle is evaluated as accurately as near zero: the
    // f64 reference of the same f32 angles (a pose 1273 revolutions away), within the 2e-5 m
    // of the random-pantograph property.
    let turns = 1273.0 * core::f32::consts::TAU;
    let far = [2.0 + turns, 1.0 - turns];
    assert!(far[0].abs() <= max && far[1].abs() <= max);
    let hip = pantograph.forward(far).unwrap();
    let r = default_ref(far.map(f64::from));
    let err = (f64::from(hip.x) - r[0]).hypot(f64::from(hip.y) - r[1]);
    assert!(err < 2e-5, "{err:e} m ({hip} vs {r:?})");
}

#[test]
fn forward_kinematics_without_intersection() {
    let pantograph = default_pantograph();
    // Arms stretched outward along the x axis: elbows 0.21 m apart, distal links reach 0.2 m.
    let err = pantograph
        .forward([core::f32::consts::PI, 0.0])
        .unwrap_err();
    match err {
        KinematicsError::DistalLinksApart {
            elbow_distance_m,
            min_m,
            max_m,
        } => {
            assert!((elbow_distance_m - 0.21).abs() < 1e-6);
            assert_eq!(min_m, 0.0);
            assert!((max_m - 0.2).abs() < 1e-6);
        }
        other => panic!("{other:?}"),
    }
    // Elbows on top of each other: cos θ1 = 0.025 / 0.08, θ2 = π − θ1.
    let t1 = (0.025f64 / 0.08).acos();
    let theta = [t1 as f32, (PI64 - t1) as f32];
    assert!(matches!(
        pantograph.forward(theta),
        Err(KinematicsError::ElbowsCoincide { .. })
    ));
}

#[test]
fn singular_configurations_give_the_singular_error() {
    let pantograph = default_pantograph();
    // Distal links almost aligned: elbows symmetric, 0.2 m − 1 µm apart (b1 + b2 = 0.2 m).
    let half = (0.2f64 - 1e-6) / 2.0;
    let c = (half - 0.025) / 0.08;
    let t1 = PI64 - c.acos();
    let theta = [t1 as f32, (PI64 - t1) as f32];
    let hip = pantograph.forward(theta).unwrap();
    assert!(hip.x.abs() < 1e-4);
    assert!(matches!(
        pantograph.jacobian(theta),
        Err(KinematicsError::Singular {
            singularity: Singularity::DistalLinksAligned,
            ..
        })
    ));
    assert!(matches!(
        pantograph.joint_torques(theta, Vec2::new(1.0, 0.0)),
        Err(KinematicsError::Singular { .. })
    ));
    assert!(matches!(
        pantograph.inverse(hip),
        Err(KinematicsError::Singular { .. })
    ));

    // Left arm stretched: HIP at distance l1 + b1 = 0.18 m from the left motor, at 60°.
    let phi = PI64 / 3.0;
    let e = [-0.025 + 0.18 * phi.cos(), 0.18 * phi.sin()];
    // Right arm elbows out, by the law of cosines (l2 = 0.08, b2 = 0.1).
    let (dx, dy) = (e[0] - 0.025, e[1]);
    let rho = dx.hypot(dy);
    let alpha = ((0.08f64 * 0.08 + rho * rho - 0.01) / (2.0 * 0.08 * rho)).acos();
    let theta = [phi as f32, (dy.atan2(dx) - alpha) as f32];
    let hip = pantograph.forward(theta).unwrap();
    assert!((hip.x as f64 - e[0]).abs() < 1e-5 && (hip.y as f64 - e[1]).abs() < 1e-5);
    match pantograph.jacobian(theta) {
        Err(KinematicsError::Singular {
            singularity,
            condition,
            max_condition,
        }) => {
            assert_eq!(singularity, Singularity::ArmAligned { joint: 0 });
            assert!(condition > max_condition);
            assert!(!condition.is_nan());
        }
        other => panic!("{other:?}"),
    }
    // Targets just inside the reach are rejected as singular, not returned ill-conditioned.
    let inside = Vec2::new(
        (-0.025 + (0.18 - 1e-6) * phi.cos()) as f32,
        ((0.18 - 1e-6) * phi.sin()) as f32,
    );
    assert!(matches!(
        pantograph.inverse(inside),
        Err(KinematicsError::Singular {
            singularity: Singularity::ArmAligned { joint: 0 },
            ..
        })
    ));
}

#[test]
fn errors_display_the_problem_and_values() {
    let pantograph = default_pantograph();
    let far = pantograph
        .inverse(Vec2::new(0.0, 0.3))
        .unwrap_err()
        .to_string();
    assert!(
        far.contains("out of reach") && far.contains("0.18"),
        "{far}"
    );
    let nan = pantograph.forward([f32::NAN, 0.0]).unwrap_err().to_string();
    assert!(nan.contains("θ1") && nan.contains("NaN"), "{nan}");
    let spec = DeviceSpec {
        proximal_m: [0.08, -1.0],
        ..DeviceSpec::default()
    };
    let msg = spec.validate().unwrap_err().to_string();
    assert!(msg.contains("proximal_m[1]") && msg.contains("-1"), "{msg}");
}

#[test]
fn spec_validation_names_the_bad_field() {
    let base = DeviceSpec::default();
    let cases: [(DeviceSpec, &str); 6] = [
        (
            DeviceSpec {
                distal_m: [f32::NAN, 0.1],
                ..base
            },
            "distal_m[0]",
        ),
        (
            DeviceSpec {
                base_separation_m: 0.0,
                ..base
            },
            "base_separation_m",
        ),
        (
            DeviceSpec {
                encoder_counts_per_rev: [4096, 0],
                ..base
            },
            "encoder_counts_per_rev[1]",
        ),
        (
            DeviceSpec {
                torque_constant_nm_per_a: [f32::INFINITY, 0.02],
                ..base
            },
            "torque_constant_nm_per_a[0]",
        ),
        (
            DeviceSpec {
                max_velocity_m_per_s: -1.0,
                ..base
            },
            "max_velocity_m_per_s",
        ),
        (
            DeviceSpec {
                joint_damping_nms_per_rad: [0.0, -1e-4],
                ..base
            },
            "joint_damping_nms_per_rad[1]",
        ),
    ];
    for (spec, field) in cases {
        let err = spec.validate().unwrap_err();
        let named = match err {
            SpecError::NonFinite { field, .. }
            | SpecError::NonPositive { field, .. }
            | SpecError::OutOfRange { field, .. } => field,
            other => panic!("{other:?}"),
        };
        assert_eq!(named, field);
    }
    assert!(matches!(
        DeviceSpec {
            max_force_n: 0.0,
            ..base
        }
        .validate(),
        Err(SpecError::NonPositive {
            field: "max_force_n",
            ..
        })
    ));
    // A workspace reaching beyond the arms.
    let mut spec = base;
    spec.workspace.max_in_device.y = 0.3;
    assert!(matches!(
        spec.validate(),
        Err(SpecError::UnreachableWorkspace {
            cause: KinematicsError::TooFar { .. },
            ..
        })
    ));
    // An empty workspace.
    let mut spec = base;
    spec.workspace.max_in_device.x = -0.06;
    assert!(matches!(
        spec.validate(),
        Err(SpecError::OutOfRange {
            field: "workspace.max_in_device.x",
            ..
        })
    ));
    // End stops that cut into the workspace (the box needs θ1 up to about 210°).
    let spec = DeviceSpec {
        end_stop_rad: [core::f32::consts::PI, -0.25 * core::f32::consts::PI],
        ..base
    };
    assert!(matches!(
        spec.validate(),
        Err(SpecError::BeyondEndStop { joint: 0, .. })
    ));
    // A stricter singularity limit than the box allows.
    let spec = DeviceSpec {
        max_condition_number: 2.0,
        ..base
    };
    assert!(matches!(
        spec.validate(),
        Err(SpecError::UnreachableWorkspace {
            cause: KinematicsError::Singular { .. },
            ..
        })
    ));
    assert!(matches!(
        DeviceSpec {
            max_condition_number: 0.5,
            ..base
        }
        .validate(),
        Err(SpecError::OutOfRange {
            field: "max_condition_number",
            ..
        })
    ));
}

#[test]
fn encoder_counts_to_joint_angles_by_hand() {
    // 4096 counts per motor revolution × 10:1 capstan = 40960 counts per joint revolution.
    let mut spec = DeviceSpec::default();
    let per_rad = spec.counts_per_joint_rad();
    assert!((per_rad[0] as f64 - 40960.0 / (2.0 * PI64)).abs() < 1e-3);
    let a = spec.joint_angles([10240, -20480]);
    assert!((a[0] as f64 - PI64 / 2.0).abs() < 1e-6);
    assert!((a[1] as f64 + PI64).abs() < 1e-6);
    spec.encoder_offset_counts = [1000, i32::MAX - 5];
    spec.encoder_direction = [Direction::Negative, Direction::Positive];
    // 1000 + 5120 counts past the offset, reversed: −π/4.
    // i32::MIN + 4 − (i32::MAX − 5) wraps to 10 counts: 10 · 2π / 40960 = π / 2048.
    let a = spec.joint_angles([6120, i32::MIN + 4]);
    assert!((a[0] as f64 + PI64 / 4.0).abs() < 1e-6);
    assert!((a[1] as f64 - PI64 / 2048.0).abs() < 1e-9);
    spec.transmission_ratio = [13.5, 13.5];
    spec.encoder_counts_per_rev = [2000, 2000];
    // 27000 counts per joint revolution: 6750 counts from the offset is a quarter turn.
    let a = spec.joint_angles([1000 - 6750, (i32::MAX - 5).wrapping_add(6750)]);
    assert!((a[0] as f64 - PI64 / 2.0).abs() < 1e-6);
    assert!((a[1] as f64 - PI64 / 2.0).abs() < 1e-6);
}

#[test]
fn calibration_recovers_known_offsets() {
    let mut spec = DeviceSpec {
        encoder_direction: [Direction::Positive, Direction::Negative],
        ..DeviceSpec::default()
    };
    let true_offsets = [12345, -6789];
    // End stops 5π/4 and −π/4 are 25600 and −5120 counts of 40960 per revolution; the right
    // encoder counts backwards, so it reads −6789 + 5120.
    let raw = [12345 + 25600, -6789 + 5120];
    let mut cal = Calibration::new();
    assert!(!cal.is_calibrated());
    assert_eq!(cal.offsets(), None);
    assert_eq!(
        cal.joint_angles(&spec, raw),
        Err(CalibrationError::NotCalibrated { joint: 0 })
    );
    assert_eq!(
        spec.motor_command(&cal, [0.1, 0.1]),
        Err(CommandError::Uncalibrated)
    );
    assert_eq!(cal.record_end_stop(&spec, 0, raw[0]), Ok(true_offsets[0]));
    assert!(!cal.is_calibrated());
    assert_eq!(
        spec.motor_command(&cal, [0.1, 0.1]),
        Err(CommandError::Uncalibrated)
    );
    assert_eq!(
        cal.record_end_stop(&spec, 2, 0),
        Err(CalibrationError::NoSuchJoint { joint: 2 })
    );
    assert_eq!(cal.record_end_stop(&spec, 1, raw[1]), Ok(true_offsets[1]));
    assert!(cal.is_calibrated());
    assert_eq!(cal.offsets(), Some(true_offsets));
    let at_stops = cal.joint_angles(&spec, raw).unwrap();
    assert!((at_stops[0] as f64 - 1.25 * PI64).abs() < 1e-6);
    assert!((at_stops[1] as f64 + 0.25 * PI64).abs() < 1e-6);
    assert!(spec.motor_command(&cal, [0.1, 0.1]).is_ok());
    cal.apply(&mut spec).unwrap();
    assert_eq!(spec.encoder_offset_counts, true_offsets);

    let mut home = Calibration::default();
    assert_eq!(home.record_home(&spec, raw), Ok(true_offsets));
    assert!(home.is_calibrated());
    home.reset();
    assert!(!home.is_calibrated());
    assert!(home.apply(&mut spec).is_err());

    // End stops that are not whole counts round to the nearest count.
    let spec = DeviceSpec {
        end_stop_rad: [3.9, -0.8],
        ..DeviceSpec::default()
    };
    let k = 40960.0 / (2.0 * PI64);
    let stop_counts = [(3.9 * k).round() as i32, (-0.8 * k).round() as i32];
    let mut cal = Calibration::new();
    let offsets = cal
        .record_home(&spec, [500 + stop_counts[0], -500 + stop_counts[1]])
        .unwrap();
    assert_eq!(offsets, [500, -500]);
}

#[test]
fn motor_currents_and_saturation() {
    let spec = DeviceSpec::default();
    let mut cal = Calibration::new();
    cal.record_home(&spec, [0, 0]).unwrap();
    // I = τ / (n k_t) = 0.1 / (10 · 0.0234) = 0.42735 A.
    let cmd = spec.motor_command(&cal, [0.1, -0.05]).unwrap();
    assert!((cmd.current_a[0] - 0.427_350_4).abs() < 1e-6);
    assert!((cmd.current_a[1] + 0.213_675_2).abs() < 1e-6);
    assert_eq!(cmd.saturated, [false, false]);
    assert_eq!(cmd.scale, 1.0);
    // 4.27 A and 2.14 A both exceed 2 A; both are scaled by 2 / 4.27 to keep the ratio.
    let cmd = spec.motor_command(&cal, [1.0, 0.5]).unwrap();
    assert!((cmd.current_a[0] - 2.0).abs() < 1e-6);
    assert!((cmd.current_a[1] - 1.0).abs() < 1e-6);
    assert_eq!(cmd.saturated, [true, true]);
    assert!((cmd.scale - 0.468).abs() < 1e-6);
    let cmd = spec.motor_command(&cal, [0.0, -0.6]).unwrap();
    assert_eq!(cmd.saturated, [false, true]);
    assert!((cmd.current_a[1] + 2.0).abs() < 1e-6);
    // Reversed motor wiring flips the current.
    let reversed = DeviceSpec {
        motor_direction: [Direction::Negative, Direction::Positive],
        ..spec
    };
    let cmd = reversed.motor_command(&cal, [0.1, 0.0]).unwrap();
    assert!((cmd.current_a[0] + 0.427_350_4).abs() < 1e-6);
    assert!(matches!(
        spec.motor_command(&cal, [f32::NAN, 0.0]),
        Err(CommandError::NonFinite { .. })
    ));
    assert!(matches!(
        spec.motor_command(&cal, [0.0, f32::MAX]),
        Err(CommandError::NonFinite { .. }) | Ok(_)
    ));
}

fn any_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        proptest::num::f32::ANY,
        -1.0f32..1.0,
        Just(f32::NAN),
        Just(f32::INFINITY),
        Just(f32::MAX),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// Random valid pantographs at random angles: forward kinematics matches the f64
    /// reference, the Jacobian matches finite differences, and IK inverts FK.
    #[test]
    fn random_pantographs_are_consistent(
        d in 0.02f32..0.08,
        l1 in 0.05f32..0.12,
        l2 in 0.05f32..0.12,
        b1 in 0.07f32..0.15,
        b2 in 0.07f32..0.15,
        t1 in 1.6f32..3.8,
        t2 in -0.7f32..1.5,
    ) {
        let pantograph = Pantograph::new(d, [l1, l2], [b1, b2]).unwrap();
        let (dd, l, b) = (d as f64, [l1 as f64, l2 as f64], [b1 as f64, b2 as f64]);
        let theta = [t1, t2];
        let reference = fk_ref(dd, l, b, [t1 as f64, t2 as f64]);
        match (pantograph.forward(theta), reference) {
            (Ok(hip), Some(r)) => {
                prop_assert!(hip.is_finite());
                prop_assert!((hip.x as f64 - r[0]).abs() < 2e-5 && (hip.y as f64 - r[1]).abs() < 2e-5,
                    "{hip} vs {r:?}");
                if let Ok(j) = pantograph.jacobian(theta) {
                    let h = 1e-6;
                    for col in 0..2 {
                        let mut plus = [t1 as f64, t2 as f64];
                        let mut minus = plus;
                        plus[col] += h;
                        minus[col] -= h;
                        let (Some(a), Some(m)) = (fk_ref(dd, l, b, plus), fk_ref(dd, l, b, minus)) else {
                            continue;
                        };
                        let fd = [(a[0] - m[0]) / (2.0 * h), (a[1] - m[1]) / (2.0 * h)];
                        let scale = fd[0].hypot(fd[1]).max(1e-3) * j.condition_number() as f64;
                        for row in 0..2 {
                            prop_assert!((j.m[row][col] as f64 - fd[row]).abs() <= 1e-4 * scale,
                                "J[{row}][{col}] = {} vs {}", j.m[row][col], fd[row]);
                        }
                    }
                }
                if let Ok(back) = pantograph.inverse(hip) {
                    let again = pantograph.forward(back).unwrap();
                    prop_assert!((again - hip).length() < 1e-5, "{hip} → {back:?} → {again}");
                }
            }
            (Err(_), _) => {}
            (Ok(hip), None) => {
                // Only at the tangency, where f32 and f64 round differently.
                prop_assert!(pantograph.jacobian(theta).is_err(), "{hip}");
            }
        }
    }

    /// Garbage in: errors, never panics, never NaN.
    #[test]
    fn garbage_never_panics_or_gives_nan(
        a in any_f32(), b in any_f32(), c in any_f32(), e in any_f32(),
        d in any_f32(), l in any_f32(), m in any_f32(),
    ) {
        let pantograph = default_pantograph();
        if let Ok(hip) = pantograph.forward([a, b]) {
            prop_assert!(hip.is_finite());
        }
        if let Ok(j) = pantograph.jacobian([a, b]) {
            prop_assert!(j.m.iter().flatten().all(|v| v.is_finite()));
        }
        if let Ok(tau) = pantograph.joint_torques([a, b], Vec2::new(c, e)) {
            prop_assert!(tau.iter().all(|v| v.is_finite()));
        }
        if let Ok(theta) = pantograph.inverse(Vec2::new(c, e)) {
            prop_assert!(theta.iter().all(|v| v.is_finite()));
        }
        let _ = pantograph.inverse(Vec2::new(a, b)).map_err(|err| err.to_string());
        if let Ok(other) = Pantograph::new(d, [l, m], [m, l]) {
            if let Ok(hip) = other.forward([a, b]) {
                prop_assert!(hip.is_finite());
            }
            if let Ok(theta) = other.inverse(Vec2::new(c, e)) {
                prop_assert!(theta.iter().all(|v| v.is_finite()));
            }
            let _ = other.jacobian([a, b]);
        }
        let spec = DeviceSpec::default();
        let mut cal = Calibration::new();
        cal.record_home(&spec, [0, 0]).unwrap();
        if let Ok(cmd) = spec.motor_command(&cal, [a, b]) {
            for i in 0..2 {
                prop_assert!(cmd.current_a[i].is_finite());
                prop_assert!(cmd.current_a[i].abs() <= spec.current_limit_a[i] * (1.0 + 1e-6));
            }
        }
        let bad = DeviceSpec { proximal_m: [d, l], end_stop_rad: [m, c], ..spec };
        let _ = bad.validate();
        let _ = Calibration::new().record_end_stop(&bad, 0, 7);
    }

    /// Any counts give finite angles.
    #[test]
    fn any_counts_give_finite_angles(c1 in any::<i32>(), c2 in any::<i32>(), o1 in any::<i32>(), o2 in any::<i32>()) {
        let spec = DeviceSpec { encoder_offset_counts: [o1, o2], ..DeviceSpec::default() };
        let a = spec.joint_angles([c1, c2]);
        prop_assert!(a.iter().all(|v| v.is_finite() && v.abs() <= 2.0 * core::f32::consts::PI * 52_429.0));
    }
}

/// The error is far below the physical resolution: an angle error δ moves (sin, cos) by δ,
/// so the bound is an angle error, and it must be under a hundredth of one encoder count.
#[test]
fn sin_cos_bound_is_far_below_one_encoder_count() {
    let bound = device::math::SIN_COS_MAX_ERROR;
    let spec = DeviceSpec::default();
    for per_rad in spec.counts_per_joint_rad() {
        let count_rad = 1.0 / per_rad;
        assert!(
            bound <= 0.01 * count_rad,
            "{bound:e} vs one count {count_rad:e} rad"
        );
    }
}
