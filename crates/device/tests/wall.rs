//! The load-time wall acceptance (`device::wall`): the passivity, quantisation and controller
//! bounds against hand-computed limits, and the refusals that name the bound.

#![allow(clippy::unwrap_used)]

use device::wall::{Bound, PassivityError, WallLimits, check_wall};

mod common;
use common::device;

fn close(a: f32, b: f32, tol: f32) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn wall_bounds_match_hand_computed_limits() {
    let p = device(0.005, 0.02, 20e-6);
    // Passivity at 1 kHz: 2 · 0.205 / 0.001 = 410 N/m; at 10 kHz 4100 N/m. Quantisation:
    // 2 · 0.02 / 20e-6 = 2000 N/m at any rate.
    let at_1k = WallLimits::new(&p, 0.0, 1e-3);
    assert!(close(at_1k.passive_n_per_m, 410.0, 1e-2));
    assert!(close(at_1k.quantisation_n_per_m, 2000.0, 1e-2));
    assert!(close(
        WallLimits::new(&p, 0.0, 1e-4).passive_n_per_m,
        4100.0,
        0.1
    ));
    assert!(check_wall(409.0, 0.0, 1e-3, &p, false).is_ok());
    match check_wall(411.0, 0.0, 1e-3, &p, false) {
        Err(PassivityError::TooStiff {
            stiffness_n_per_m,
            max_stiffness_n_per_m,
            bound,
            renders_at_hz,
            ..
        }) => {
            assert_eq!(stiffness_n_per_m, 411.0);
            assert!(close(max_stiffness_n_per_m, 410.0, 1e-2));
            assert_eq!(bound, Bound::Passivity);
            // 2 kHz: 820 N/m.
            assert_eq!(renders_at_hz, Some(2000));
        }
        other => panic!("{other:?}"),
    }
    // At 10 kHz quantisation binds before passivity: 2000 passes, 2001 does not, at any rate.
    assert!(check_wall(2000.0, 0.0, 1e-4, &p, false).is_ok());
    match check_wall(2001.0, 0.0, 1e-4, &p, false) {
        Err(PassivityError::TooStiff {
            bound: Bound::Quantisation,
            renders_at_hz: None,
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    // Wall damping B = ±0.1 N·s/m: 2 (0.205 − 0.1) / 0.001 = 210 N/m; its sign does not matter.
    for damping in [0.1, -0.1] {
        assert!(close(
            WallLimits::new(&p, damping, 1e-3).passive_n_per_m,
            210.0,
            1e-2
        ));
        assert!(check_wall(209.0, damping, 1e-3, &p, false).is_ok());
        assert!(check_wall(211.0, damping, 1e-3, &p, false).is_err());
    }
    // Wall damping beyond the device's: nothing passes passivity, the controller takes over
    // up to its demonstrated K = 1000 N/m and |B| = 1 N·s/m.
    assert!(check_wall(1.0, 0.3, 1e-3, &p, false).is_err());
    assert!(check_wall(1000.0, 0.3, 1e-3, &p, true).is_ok());
    match check_wall(1001.0, 0.3, 1e-3, &p, true) {
        Err(PassivityError::TooStiff {
            bound: Bound::Controller,
            max_stiffness_n_per_m,
            ..
        }) => assert_eq!(max_stiffness_n_per_m, 1000.0),
        other => panic!("{other:?}"),
    }
    assert!(check_wall(10.0, 1.5, 1e-3, &p, true).is_err());
    // The message names the bound, its numbers and what raises it.
    let message = check_wall(600.0, 0.0, 1e-3, &p, false)
        .unwrap_err()
        .to_string();
    for part in [
        "passivity bound",
        "410 N/m",
        "b = 0.0050",
        "f_c = 0.0200",
        "1000 Hz",
        "renders at 2000 Hz",
    ] {
        assert!(message.contains(part), "{part:?} in {message}");
    }
    let message = check_wall(2500.0, 0.0, 1e-4, &p, true)
        .unwrap_err()
        .to_string();
    for part in ["quantisation", "2000 N/m", "20.0 µm"] {
        assert!(message.contains(part), "{part:?} in {message}");
    }
    assert!(matches!(
        check_wall(1.0, 0.0, 0.0, &p, false),
        Err(PassivityError::InvalidParameter("period"))
    ));
    assert!(check_wall(-1.0, 0.0, 1e-3, &p, false).is_err());
}

/// A wall damping the device cannot render with any stiffness is refused naming the damping
/// and its bound, not a stiffness limit of 0 N/m. The bound by hand: K < 2 (b + f_c/v − |B|) / T
/// leaves some K > 0 only while |B| < b + f_c/v = 0.005 + 0.02 / 0.1 = 0.205 N·s/m; with the
/// passivity controller, also while |B| is within its demonstrated 1 N·s/m.
#[test]
fn a_damping_beyond_the_device_is_named_with_its_bound() {
    let p = device(0.005, 0.02, 20e-6);
    // Just below the bound a soft wall passes (2 · 0.002 / 0.001 = 4 N/m > 1 N/m).
    assert!(check_wall(1.0, 0.203, 1e-3, &p, false).is_ok());
    for (damping, controller, bound) in [(0.207, false, "0.205"), (1.01, true, "1.000")] {
        let e = check_wall(1.0, damping, 1e-3, &p, controller).unwrap_err();
        assert!(
            matches!(e, PassivityError::TooDamped { max_damping_ns_per_m, .. }
                if close(max_damping_ns_per_m, bound.parse().unwrap(), 1e-6)),
            "{e:?}"
        );
        let message = e.to_string();
        for part in ["damping", bound, "N·s/m", "lower the damping"] {
            assert!(message.contains(part), "{part:?} in {message}");
        }
        assert!(
            !message.contains("0 N/m"),
            "no stiffness limit of 0: {message}"
        );
        assert!(!message.contains("lower K"), "{message}");
    }
    assert!(check_wall(1.0, -0.207, 1e-3, &p, false).is_err());
    // With the controller, up to its demonstrated damping still passes.
    assert!(check_wall(10.0, 0.99, 1e-3, &p, true).is_ok());
}
