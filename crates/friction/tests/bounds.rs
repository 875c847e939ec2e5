//! Every material the rules accept renders finite forces: each numeric field at the bound
//! `FrictionMaterial::validate` allows (alone and all together), under every friction model,
//! pressed hard and slid fast at 1 kHz and at 10 kHz. (Before the upper bounds, LuGre and
//! Karnopp materials with a viscous or bristle-damping coefficient of about 1e30 passed the
//! rules and rendered a friction force of −∞.)
#![allow(clippy::unwrap_used)]

use friction::{FrictionMaterial, FrictionRenderer, MaterialError, ModelKind};
use nurbs::{Vec2, construct};
use tracker::Chain;

/// The HIP's path: from 5 mm above a horizontal line, in to 20 mm deep at 1 m/s, then four
/// strokes of ±20 mm at 3 m/s (faster than a hand), sampled every `period_s`; one tick in the
/// middle gets the velocity of a metre per tick, as a wrong clock would give.
fn path(period_s: f32) -> Vec<Vec2> {
    let mut p = Vec::new();
    let mut x = Vec2::new(0.0, 0.005);
    let mut go = |to: Vec2, speed: f32, p: &mut Vec<Vec2>| {
        let n = ((to - x).length() / (speed * period_s)).ceil().max(1.0) as usize;
        for k in 1..=n {
            p.push(x.lerp(to, k as f32 / n as f32));
        }
        x = to;
    };
    go(Vec2::new(0.0, -0.02), 1.0, &mut p);
    for _ in 0..4 {
        go(Vec2::new(0.02, -0.02), 3.0, &mut p);
        go(Vec2::new(-0.02, -0.02), 3.0, &mut p);
    }
    p
}

/// Copies one field (or two, for μd, which must stay ≤ μs) from the second material.
type SetField = fn(&mut FrictionMaterial, &FrictionMaterial);

fn extremes() -> Vec<(String, FrictionMaterial)> {
    let base = FrictionMaterial::default();
    let max = FrictionMaterial::MAX;
    let mut list = vec![("all at their maxima".to_owned(), max)];
    let fields: [(&str, SetField); 12] = [
        ("stiffness_n_per_m", |m, x| {
            m.stiffness_n_per_m = x.stiffness_n_per_m
        }),
        ("damping_ns_per_m", |m, x| {
            m.damping_ns_per_m = x.damping_ns_per_m
        }),
        ("mu_static", |m, x| m.mu_static = x.mu_static),
        ("mu_dynamic", |m, x| {
            m.mu_dynamic = x.mu_dynamic;
            m.mu_static = x.mu_static;
        }),
        ("transition_time_s", |m, x| {
            m.transition_time_s = x.transition_time_s
        }),
        ("converge_tol_m", |m, x| m.converge_tol_m = x.converge_tol_m),
        ("stop_speed_m_per_s", |m, x| {
            m.stop_speed_m_per_s = x.stop_speed_m_per_s
        }),
        ("viscous_ns_per_m", |m, x| {
            m.viscous_ns_per_m = x.viscous_ns_per_m
        }),
        ("karnopp_band_m_per_s", |m, x| {
            m.karnopp_band_m_per_s = x.karnopp_band_m_per_s
        }),
        ("bristle_stiffness_n_per_m", |m, x| {
            m.bristle_stiffness_n_per_m = x.bristle_stiffness_n_per_m;
        }),
        ("bristle_damping_ns_per_m", |m, x| {
            m.bristle_damping_ns_per_m = x.bristle_damping_ns_per_m;
        }),
        ("stribeck_speed_m_per_s", |m, x| {
            m.stribeck_speed_m_per_s = x.stribeck_speed_m_per_s
        }),
    ];
    for (name, set) in fields {
        let mut m = base;
        set(&mut m, &max);
        list.push((format!("{name} at its maximum"), m));
    }
    list
}

#[test]
fn every_accepted_material_renders_finite_forces() {
    let line = construct::line(Vec2::new(-0.05, 0.0), Vec2::new(0.05, 0.0)).unwrap();
    let views = [line.view()];
    let chain = Chain::new(&views).unwrap();
    for model in [
        ModelKind::StickSlip,
        ModelKind::CoulombViscous,
        ModelKind::Karnopp,
        ModelKind::Dahl,
        ModelKind::LuGre,
    ] {
        for (what, material) in extremes() {
            let material = FrictionMaterial { model, ..material };
            material.validate().unwrap();
            for period_s in [1e-3f32, 1e-4] {
                let path = path(period_s);
                let mut r = FrictionRenderer::new(&chain, material, path[0]);
                let mut previous = path[0];
                for (k, &x) in path.iter().enumerate() {
                    let mut velocity = (x - previous) * (1.0 / period_s);
                    // A clock that went wrong once mid-stroke: a metre in a tick.
                    if k == path.len() / 2 {
                        velocity = Vec2::new(1.0 / period_s, 0.0);
                    }
                    let o = r.tick(&chain, x, velocity, period_s);
                    previous = x;
                    let finite = [o.normal_force_n, o.friction_force_n, o.mu]
                        .iter()
                        .chain(o.total.to_array().iter())
                        .chain(o.friction.to_array().iter())
                        .chain(o.go.to_array().iter())
                        .all(|v| v.is_finite());
                    assert!(
                        finite,
                        "{model:?}, {what}, {period_s} s: tick {k} at {x:?}: {o:?}"
                    );
                }
            }
        }
    }
}

/// The adversarial run's values are refused, naming the field.
#[test]
fn huge_coefficients_are_refused_naming_the_field() {
    for (field, material) in [
        (
            "viscous_ns_per_m",
            FrictionMaterial {
                viscous_ns_per_m: 1e30,
                ..FrictionMaterial::default()
            },
        ),
        (
            "bristle_damping_ns_per_m",
            FrictionMaterial {
                bristle_damping_ns_per_m: 1e30,
                ..FrictionMaterial::default()
            },
        ),
        (
            "stiffness_n_per_m",
            FrictionMaterial {
                stiffness_n_per_m: 1e30,
                ..FrictionMaterial::default()
            },
        ),
    ] {
        let e = material.validate().unwrap_err();
        assert!(matches!(e, MaterialError::TooLarge { .. }), "{e}");
        assert_eq!(e.field(), field);
        assert!(e.to_string().contains(field), "{e}");
    }
}
