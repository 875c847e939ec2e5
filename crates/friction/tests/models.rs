//! Each friction law against its defining equation, with closed-form solutions where the
//! equation has one.
#![allow(clippy::unwrap_used)]

use friction::Stribeck;
use friction::models::{CoulombViscous, Dahl, FrictionLaw, Karnopp, LuGre, TangentialInput};
use nurbs::Vec2;
use proptest::prelude::*;

fn input(v: Vec2, fn_n: f32, applied: Vec2) -> TangentialInput<Vec2> {
    TangentialInput {
        velocity: v,
        normal_force_n: fn_n,
        applied,
        period_s: 1e-3,
    }
}

proptest! {
    /// F = −(μ F_N sgn v + σ₂ v).
    #[test]
    fn coulomb_viscous_is_its_equation(vx in -1.0f32..1.0, vy in -1.0f32..1.0, fn_n in 0.0f32..10.0,
                                       mu in 0.0f32..1.0, s2 in 0.0f32..5.0) {
        let v = Vec2::new(vx, vy);
        prop_assume!(v.length() > 1e-3);
        let mut law = CoulombViscous { mu, viscous_ns_per_m: s2 };
        let f = law.force(&input(v, fn_n, Vec2::ZERO));
        let expected = -(v.normalize() * mu * fn_n + v * s2);
        prop_assert!((f - expected).length() <= 1e-5 * (1.0 + expected.length()));
    }

    /// Inside the band the friction cancels the applied force up to μ_s F_N; outside it is
    /// Coulomb plus viscous with μ_d.
    #[test]
    fn karnopp_is_its_equation(ax in -5.0f32..5.0, fn_n in 0.1f32..10.0, v in -0.5f32..0.5) {
        let mut law = Karnopp { mu_static: 0.7, mu_dynamic: 0.5, viscous_ns_per_m: 0.2, band_m_per_s: 0.01 };
        let applied = Vec2::new(ax, 0.0);
        let f = law.force(&input(Vec2::new(v, 0.0), fn_n, applied));
        let expected = if v.abs() < 0.01 {
            -ax.clamp(-0.7 * fn_n, 0.7 * fn_n)
        } else {
            -(v.signum() * 0.5 * fn_n + 0.2 * v)
        };
        prop_assert!((f.x - expected).abs() <= 1e-5 * (1.0 + expected.abs()), "{} vs {}", f.x, expected);
        prop_assert_eq!(f.y, 0.0);
    }
}

/// Dahl at constant speed from rest: the exact solution of dF/dt = σ₀ v (1 − F/F_c) is
/// F(t) = F_c (1 − e^(−σ₀ v t / F_c)); the semi-implicit step converges to it at first order.
#[test]
fn dahl_matches_closed_form_at_constant_speed() {
    let (sigma0, mu, fn_n, v) = (2000.0f32, 0.5f32, 2.0f32, 0.01f32);
    let fc = mu * fn_n;
    let t = 1e-4;
    let mut law = Dahl {
        mu,
        sigma0_n_per_m: sigma0,
        state: Vec2::ZERO,
    };
    for k in 1..=2000 {
        let f = law.force(&TangentialInput {
            velocity: Vec2::new(v, 0.0),
            normal_force_n: fn_n,
            applied: Vec2::ZERO,
            period_s: t,
        });
        let time = k as f32 * t;
        let exact = fc * (1.0 - (-(sigma0 * v * time / fc) as f64).exp() as f32);
        // First-order method: error ≲ (σ₀ v T / F_c) · F_c / 2 = 1e-3 N here.
        assert!(
            (-f.x - exact).abs() < 2e-3,
            "t = {time}: {} vs {exact}",
            -f.x
        );
        assert!(-f.x <= fc + 1e-6, "Dahl force never exceeds F_c");
    }
}

/// LuGre's steady state at constant velocity: dz/dt = 0 gives z = g(v)/σ₀ and
/// F = g(v) + σ₂ v, with g(0) = F_s, g(v_s) = (F_s + F_c)/2, g(∞) → F_c.
#[test]
fn lugre_steady_state_is_g_plus_viscous() {
    let mut law = LuGre {
        mu_static: 0.7,
        mu_dynamic: 0.5,
        sigma0_n_per_m: 5000.0,
        sigma1_ns_per_m: 1.0,
        sigma2_ns_per_m: 0.3,
        stribeck_speed_m_per_s: 0.01,
        z: Vec2::ZERO,
    };
    let fn_n = 2.0;
    assert!((law.g(0.0, fn_n) - 1.4).abs() < 1e-6);
    assert!((law.g(0.01, fn_n) - 1.2).abs() < 1e-6);
    assert!((law.g(1e3, fn_n) - 1.0).abs() < 1e-4);
    for v in [0.002f32, 0.01, 0.05, -0.03] {
        FrictionLaw::<Vec2>::reset(&mut law);
        let mut f = Vec2::ZERO;
        for _ in 0..20000 {
            f = law.force(&input(Vec2::new(v, 0.0), fn_n, Vec2::ZERO));
        }
        let expected = -(v.signum() * law.g(v.abs(), fn_n) + 0.3 * v);
        assert!(
            (f.x - expected).abs() < 1e-3,
            "v = {v}: {} vs {expected}",
            f.x
        );
    }
}

#[test]
fn stribeck_shapes_run_from_static_to_dynamic() {
    for s in [
        Stribeck::Linear,
        Stribeck::Power { exponent: 3 },
        Stribeck::Smoothstep,
    ] {
        assert_eq!(s.mu(0.7, 0.5, 1.0), 0.7);
        assert_eq!(s.mu(0.7, 0.5, 0.0), 0.5);
        let mut prev = 0.5;
        for k in 0..=100 {
            let mu = s.mu(0.7, 0.5, k as f32 / 100.0);
            assert!(mu >= prev - 1e-7, "{s:?} is monotone");
            prev = mu;
        }
    }
    assert!((Stribeck::Linear.mu(0.7, 0.5, 0.25) - 0.55).abs() < 1e-6);
    assert!((Stribeck::Smoothstep.mu(0.7, 0.5, 0.5) - 0.6).abs() < 1e-6);
}
