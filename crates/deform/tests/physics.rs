//! The D-NURBS bodies against closed forms of continuum mechanics: the taut string (static
//! parabola, first mode, midpoint stiffness), the Euler–Bernoulli beam, the square membrane
//! (first mode, uniform load), the trapezoidal rule's energy identities. Every reference is
//! the textbook formula, never the code's own output.

use deform::{Body, DynamicsError, Fixed, Params, Shape};
use nurbs::{CurveBuf, SurfaceBuf, Vec2, Vec3};

mod common;
use common::{L, greville, uniform_knots};

/// A straight cubic curve from (0, 0) to (L, 0) with `n` control points at the Greville
/// abscissae.
fn string(n: usize, params: Params) -> Body {
    let knots = uniform_knots(3, n);
    let points: Vec<Vec2> = greville(&knots, 3, n)
        .iter()
        .map(|&g| Vec2::new((L * g) as f32, 0.0))
        .collect();
    let c = CurveBuf::from_cartesian(3, knots, &points, None).expect("valid curve");
    let (shape, rest) = Shape::of_curve2(&c);
    Body::new(shape, rest, params).expect("valid body")
}

/// The flat square `[0, L]²` as a bicubic with `n × n` control points at the Greville
/// abscissae (a linear parametrisation).
fn membrane(n: usize, params: Params) -> Body {
    let knots = uniform_knots(3, n);
    let g = greville(&knots, 3, n);
    let rows: Vec<Vec<Vec3>> = g
        .iter()
        .map(|&gu| {
            g.iter()
                .map(|&gv| Vec3::new((L * gu) as f32, (L * gv) as f32, 0.0))
                .collect()
        })
        .collect();
    let s = SurfaceBuf::from_rows::<_, Vec<f32>>((3, 3), (knots.clone(), knots), &rows, None)
        .expect("valid surface");
    let (shape, rest) = Shape::of_surface(&s);
    Body::new(shape, rest, params).expect("valid body")
}

fn string_params(tension: f64, bending: f64) -> Params {
    Params {
        density: 0.1,
        damping: 0.0,
        tension,
        bending,
        fixed: Fixed::Edge,
        plastic_time_s: None,
    }
}

/// A taut string under a uniform transverse load `q` sags in the parabola
/// `w(x) = q x (L − x) / (2T)`. The parabola lies in the cubic spline space (linear
/// parametrisation), so Galerkin's answer is exact up to rounding: the f32 knots and basis
/// values (ε ≈ 6e-8) amplified by the condition of `K` (~n² ≈ 150): 1e-5 relative.
#[test]
fn string_under_uniform_load_is_the_parabola() {
    let (t, q) = (5.0, -2.0);
    let mut body = string(12, string_params(t, 0.0));
    let mut load = body.zero_load();
    body.add_uniform_load(&mut load, [0.0, q, 0.0]);
    body.solve_static(&load).expect("held at its ends");
    let sag = q * L * L / (8.0 * t);
    let mut worst: f64 = 0.0;
    for i in 0..=20 {
        let u = i as f64 / 20.0;
        let p = body.point([u, 0.0]);
        let x = L * u;
        let w = q * x * (L - x) / (2.0 * t);
        assert!((p[0] - x).abs() < 1e-5 * L, "x at u = {u}: {} vs {x}", p[0]);
        assert!(
            (p[1] - w).abs() <= 1e-5 * sag.abs(),
            "w at u = {u}: {} vs {w}",
            p[1]
        );
        worst = worst.max((p[1] - w).abs() / sag.abs());
    }
    eprintln!("string parabola: largest error {worst:e} of the sag {sag} m");
}

/// The fixed string's first mode is `f₁ = (1/2L) √(T/ρ)`. Rayleigh–Ritz bounds the discrete
/// frequency from below by the exact one; from above, the dispersion of consistent-mass `C²`
/// cubics is `(kh)⁶/30240` (Hughes, Reali & Sangalli 2008) with `kh = π/9` (12 points,
/// `h = L/9`): 6e-8. The bound allows 2e-7.
#[test]
fn string_first_mode_matches_the_closed_form() {
    let (t, rho) = (5.0, 0.1);
    let body = string(12, string_params(t, 0.0));
    let exact = (t / rho).sqrt() / (2.0 * L);
    let f = body.lowest_mode_hz().expect("held");
    let rel = f / exact - 1.0;
    eprintln!("string first mode: {f} Hz vs {exact} Hz ({rel:e})");
    assert!(
        (-1e-9..2e-7).contains(&rel),
        "f₁ = {f} Hz vs {exact} Hz ({rel:e})"
    );
}

/// Released from its sag the string rings at its first mode: the period between upward zero
/// crossings of the midpoint, undamped, stepped at 10 kHz. Newmark's average acceleration
/// lengthens periods by `(ω Δt)²/12 = 4.11e-5` (ω = 2π·35.36 Hz, Δt = 1e-4 s); the spatial
/// discretisation adds 6e-8 (above) and the higher modes (odd harmonics, 1/27 of the first at
/// the midpoint, nearly harmonic) move the crossings by less than 1e-5 of the period.
#[test]
fn released_string_rings_at_its_first_mode() {
    let (t, rho) = (5.0, 0.1);
    let mut body = string(12, string_params(t, 0.0));
    let mut load = body.zero_load();
    body.add_uniform_load(&mut load, [0.0, -2.0, 0.0]);
    body.solve_static(&load).expect("held");
    let zero = body.zero_load();
    let dt = 1e-4;
    let mut crossings = Vec::new();
    let mut prev = body.point([0.5, 0.0])[1];
    for i in 1..=2000 {
        body.step(dt, &zero).expect("steps");
        let y = body.point([0.5, 0.0])[1];
        if prev < 0.0 && y >= 0.0 {
            crossings.push((i as f64 - y / (y - prev)) * dt);
        }
        prev = y;
    }
    assert!(crossings.len() >= 4, "only {} crossings", crossings.len());
    let period = (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64;
    let exact = 2.0 * L / (t / rho).sqrt();
    let rel = period / exact - 1.0;
    let omega_dt = 2.0 * std::f64::consts::PI / exact * dt;
    let elongation = omega_dt * omega_dt / 12.0;
    eprintln!("string ringing: period {period} s vs {exact} s ({rel:e}; Newmark {elongation:e})");
    assert!(
        (rel - elongation).abs() < 1e-5,
        "period {period} s vs {exact} s ({rel:e}; Newmark's elongation {elongation:e})"
    );
}

/// A point force at the middle of a taut string deflects it by `F L / (4T)`: the string's
/// stiffness there is `4T/L`. The kink under the force is not in the C² spline space, so
/// Galerkin's string is stiffer (its compliance is a lower bound), by about the effect of
/// spreading the force over one knot span `h`: `w = (F L/4T)(1 − h/2L)`, a stiffness higher
/// by `h/2L`. The test holds the excess to between 0.45 and 0.6 of `h/L`, at two resolutions
/// (it halves with `h`: the discretisation, not a modelling error).
#[test]
fn string_midpoint_stiffness_is_4t_over_l() {
    let t = 5.0;
    for n in [12, 48] {
        let mut body = string(n, string_params(t, 0.0));
        let mut load = body.zero_load();
        let f = -0.5;
        body.add_point_force(&mut load, [0.5, 0.0], [0.0, f, 0.0]);
        body.solve_static(&load).expect("held");
        let w = body.displacement_at([0.5, 0.0])[1];
        let k = f / w;
        let exact = 4.0 * t / L;
        let h = L / (n - 3) as f64;
        let excess = (k / exact - 1.0) / (h / L);
        eprintln!("string midpoint, n = {n}: {k} N/m vs 4T/L = {exact} N/m ({excess} h/L)");
        assert!(
            (0.45..0.6).contains(&excess),
            "n = {n}: k = {k} N/m vs 4T/L = {exact} N/m ({excess} h/L)"
        );
    }
}

/// Bending alone: a simply supported beam (ends held, free to turn) under a uniform load
/// sags `5 q L⁴ / (384 EI)` at its middle (Euler–Bernoulli). The exact deflection is a
/// quartic, not in the cubic space; Galerkin's point values converge as the energy error
/// squared, `O(h^{2(p−1)}) = (h/L)⁴ = 2.4e-7` with `h = L/45` (48 points). Bound 5e-7.
#[test]
fn beam_under_uniform_load_matches_euler_bernoulli() {
    let (ei, q) = (1e-3, -1.0);
    let mut body = string(48, string_params(0.0, ei));
    let mut load = body.zero_load();
    body.add_uniform_load(&mut load, [0.0, q, 0.0]);
    body.solve_static(&load).expect("held");
    let w = body.displacement_at([0.5, 0.0])[1];
    let exact = 5.0 * q * L.powi(4) / (384.0 * ei);
    let rel = w / exact - 1.0;
    eprintln!("beam: {w} m vs {exact} m ({rel:e})");
    assert!(rel.abs() < 5e-7, "w = {w} m vs {exact} m ({rel:e})");
}

/// The square membrane of side `a` under tension τ has its first mode at
/// `f₁₁ = (1/2) √(τ/ρ) √2 / a`. Ritz bounds it below; above, the bicubic's dispersion
/// `(kh)⁶/30240` with `kh = π/7` (10 × 10 points, `h = a/7`) is 2.7e-7. Bound 5e-7.
#[test]
fn membrane_first_mode_matches_the_closed_form() {
    let (tau, rho) = (50.0, 1.0);
    let body = membrane(
        10,
        Params {
            density: rho,
            damping: 0.0,
            tension: tau,
            bending: 0.0,
            fixed: Fixed::Edge,
            plastic_time_s: None,
        },
    );
    let exact = 0.5 * (tau / rho).sqrt() * 2f64.sqrt() / L;
    let f = body.lowest_mode_hz().expect("held");
    let rel = f / exact - 1.0;
    eprintln!("membrane first mode: {f} Hz vs {exact} Hz ({rel:e})");
    assert!(
        (-1e-9..5e-7).contains(&rel),
        "f₁₁ = {f} Hz vs {exact} Hz ({rel:e})"
    );
}

/// A square membrane under a uniform pressure `q` bulges by `0.0736713 q a²/τ` at its centre
/// (the maximum of the Poisson problem `−Δw = 1` on the unit square, by its Fourier series,
/// 0.07367135). The solution has `r² log r` singularities at the corners, which cap the
/// bicubic's convergence at `O(h²)` with a small constant (the corner terms are ~1e-2 of the
/// bulge): 1e-2·(1/7)² = 2e-4.
#[test]
fn membrane_under_pressure_matches_the_poisson_solution() {
    let (tau, q) = (50.0, -100.0);
    let mut body = membrane(
        10,
        Params {
            tension: tau,
            ..Params::SURFACE
        },
    );
    let mut load = body.zero_load();
    body.add_uniform_load(&mut load, [0.0, 0.0, q]);
    body.solve_static(&load).expect("held at its boundary");
    let w = body.displacement_at([0.5, 0.5])[2];
    let exact = 0.073_671_35 * q * L * L / tau;
    let rel = w / exact - 1.0;
    eprintln!("membrane under pressure: {w} m vs {exact} m ({rel:e})");
    assert!(rel.abs() < 2e-4, "w = {w} m vs {exact} m ({rel:e})");
}

/// Undamped and unloaded, the trapezoidal rule conserves `½vᵀMv + ½uᵀKu` exactly; what is
/// left is f64 rounding, about ε·cond(K_eff) ≈ 1e-14 per step, a random walk over 10⁵ steps
/// (√10⁵ · 1e-14 ≈ 3e-12): 1e-11 relative. Tension and bending both, a coarse 1 kHz step.
#[test]
fn undamped_energy_is_conserved_over_1e5_steps() {
    let mut body = string(12, string_params(5.0, 1e-4));
    let mut load = body.zero_load();
    body.add_point_force(&mut load, [0.3, 0.0], [0.2, -1.0, 0.0]);
    body.solve_static(&load).expect("held");
    let zero = body.zero_load();
    let e0 = body.energy().total_j();
    assert!(e0 > 0.0);
    let mut worst: f64 = 0.0;
    for _ in 0..100_000 {
        body.step(1e-3, &zero).expect("steps");
        worst = worst.max((body.energy().total_j() / e0 - 1.0).abs());
    }
    eprintln!("undamped energy over 1e5 steps: largest drift {worst:e}");
    assert!(worst < 1e-11, "energy drifted by {worst:e}");
}

/// With damping the trapezoidal rule loses exactly `Δt v̄ᵀ D v̄` per step (`v̄` the step's mean
/// velocity): the energy falls, never rises, and by that amount (to rounding, 1e-9 of the
/// energy).
#[test]
fn damped_energy_falls_by_the_dissipated_work() {
    let mut body = string(
        12,
        Params {
            damping: 2.0,
            ..string_params(5.0, 0.0)
        },
    );
    let mut load = body.zero_load();
    body.add_uniform_load(&mut load, [0.0, -2.0, 0.0]);
    body.solve_static(&load).expect("held");
    let zero = body.zero_load();
    let dt = 1e-3;
    let gamma = 2.0;
    let e0 = body.energy().total_j();
    let mass_over_rho = {
        // D = γ/ρ M: the dissipation uses M/ρ.
        body.mass().clone()
    };
    for _ in 0..500 {
        let before = body.energy().total_j();
        let v0 = body.velocity().to_vec();
        body.step(dt, &zero).expect("steps");
        let after = body.energy().total_j();
        let mean: Vec<[f64; 3]> = v0
            .iter()
            .zip(body.velocity())
            .map(|(a, b)| {
                [
                    0.5 * (a[0] + b[0]),
                    0.5 * (a[1] + b[1]),
                    0.5 * (a[2] + b[2]),
                ]
            })
            .collect();
        let dissipated = dt * gamma / 0.1 * mass_over_rho.quadratic(&mean);
        assert!(
            after <= before + 1e-12 * e0,
            "energy rose: {before} → {after}"
        );
        assert!(
            ((before - after) - dissipated).abs() <= 1e-9 * e0,
            "lost {} J, dissipated {dissipated} J",
            before - after
        );
    }
}

/// An elastic string pushed and let go comes back; a plastic one keeps its dent.
#[test]
fn plastic_string_keeps_its_dent_and_elastic_one_does_not() {
    let dent = |plastic: Option<f64>| {
        let mut body = string(
            12,
            Params {
                damping: 5.0,
                plastic_time_s: plastic,
                ..string_params(5.0, 0.0)
            },
        );
        let mut push = body.zero_load();
        body.add_point_force(&mut push, [0.5, 0.0], [0.0, -0.5, 0.0]);
        let zero = body.zero_load();
        for _ in 0..100 {
            body.step(1e-3, &push).expect("steps");
        }
        let pushed = body.point([0.5, 0.0])[1];
        for _ in 0..2000 {
            body.step(1e-3, &zero).expect("steps");
        }
        (pushed, body.point([0.5, 0.0])[1])
    };
    let (pushed, after) = dent(None);
    // F/k = 0.5 / 200 = 2.5 mm static; the push lasts several of the 30 ms periods.
    assert!(pushed < -1e-3, "elastic push reached only {pushed}");
    assert!(
        after.abs() < 1e-3 * pushed.abs(),
        "elastic string stayed at {after}"
    );
    let (pushed, after) = dent(Some(0.01));
    assert!(
        pushed < -1e-3 && after < 0.5 * pushed,
        "plastic: pushed {pushed}, then {after}"
    );
}

/// Parameters out of range are refused naming the field.
#[test]
fn bad_parameters_name_their_field() {
    let c = CurveBuf::from_cartesian(1, vec![0.0, 0.0, 1.0, 1.0], &[Vec2::ZERO, Vec2::X], None)
        .expect("valid");
    let (shape, rest) = Shape::of_curve2(&c);
    let err = |p: Params| Body::new(shape.clone(), rest.clone(), p).err();
    assert!(matches!(
        err(Params {
            density: 0.0,
            ..Params::CURVE
        }),
        Some(DynamicsError::Param { .. })
    ));
    let e = err(Params {
        tension: f64::NAN,
        ..Params::CURVE
    })
    .expect("refused");
    assert!(e.message(false).starts_with("tension_n:"), "{e}");
    assert!(e.message(true).starts_with("tension_n_per_m:"), "{e}");
    assert_eq!(
        err(Params {
            tension: 0.0,
            bending: 0.0,
            ..Params::CURVE
        }),
        Some(DynamicsError::NoStiffness)
    );
    assert_eq!(
        err(Params {
            fixed: Fixed::Points(vec![5]),
            ..Params::CURVE
        }),
        Some(DynamicsError::FixedIndex { index: 5, count: 2 })
    );
}

/// The implicit contact spring (`Coupling`) makes one linear system with the string: with
/// γ = 0 its energy, the string's plus the spring's `½ k |P (a − x)|²`, is conserved by the
/// trapezoidal rule as the string's own is (1e-11 relative over 10⁴ steps at 1 kHz, where an
/// explicit spring of 1000 N/m on this string's ~4 g would gain energy every step), and its
/// rest state is the series equilibrium `w = a k/(k + k_o)` with `k_o` the string's own
/// midpoint stiffness from its static solve.
#[test]
fn implicit_contact_spring_conserves_energy_and_settles_in_series() {
    let k = 1000.0;
    let anchor = [0.5 * L, 0.004, 0.0];
    let spring = |normal| deform::Coupling {
        params: [0.5, 0.0],
        anchor,
        stiffness: k,
        normal,
    };
    for normal in [Some([0.0, 1.0, 0.0]), None] {
        let mut body = string(12, string_params(5.0, 0.0));
        let zero = body.zero_load();
        let energy = |body: &mut Body| {
            let c = spring(normal);
            let f = body.coupling_force(&c);
            body.energy().total_j() + 0.5 * (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]) / k
        };
        let e0 = energy(&mut body);
        let mut worst: f64 = 0.0;
        for _ in 0..10_000 {
            let c = spring(normal);
            body.step_coupled(1e-3, &zero, Some(&c)).expect("steps");
            worst = worst.max((energy(&mut body) / e0 - 1.0).abs());
        }
        eprintln!("coupled energy over 1e4 steps, normal {normal:?}: largest drift {worst:e}");
        assert!(worst < 1e-11, "{normal:?}: energy drifted by {worst:e}");
    }
    let mut body = string(
        12,
        Params {
            damping: 5.0,
            ..string_params(5.0, 0.0)
        },
    );
    let mut probe = body.zero_load();
    body.add_point_force(&mut probe, [0.5, 0.0], [0.0, 1.0, 0.0]);
    body.solve_static(&probe).expect("held");
    let k_o = 1.0 / body.displacement_at([0.5, 0.0])[1];
    body.reset();
    let zero = body.zero_load();
    for _ in 0..3000 {
        let c = spring(Some([0.0, 1.0, 0.0]));
        body.step_coupled(1e-3, &zero, Some(&c)).expect("steps");
    }
    let w = body.displacement_at([0.5, 0.0])[1];
    let series = anchor[1] * k / (k + k_o);
    eprintln!("coupled string at rest: {w} m vs series {series} m");
    // Decay: mass-proportional damping γ/2ρ = 25 s⁻¹ over 3 s leaves e⁻⁷⁵.
    assert!((w / series - 1.0).abs() < 1e-9, "w = {w} m vs {series} m");
}

/// `project` finds the parameters of a point of the (deformed) shape from a start a tenth of
/// the domain away: on the sagging string, the point at u = 0.37 comes back to 1e-7 in u
/// (Gauss–Newton converges quadratically on a point of the curve itself, 8 steps, down to the
/// basis functions' f32 parameter, whose quantum at 0.37 is 3e-8).
#[test]
fn projection_recovers_the_parameters_of_a_point_of_the_shape() {
    let mut body = string(12, string_params(5.0, 0.0));
    let mut load = body.zero_load();
    body.add_uniform_load(&mut load, [0.0, -20.0, 0.0]);
    body.solve_static(&load).expect("held");
    let target = body.point([0.37, 0.0]);
    let found = body.project(target, [0.27, 0.0], 8);
    assert!((found[0] - 0.37).abs() < 1e-7, "u = {}", found[0]);
    let mut drum = membrane(10, Params::SURFACE);
    let mut load = drum.zero_load();
    drum.add_uniform_load(&mut load, [0.0, 0.0, -100.0]);
    drum.solve_static(&load).expect("held");
    let target = drum.point([0.3, 0.6]);
    let found = drum.project(target, [0.4, 0.5], 8);
    assert!(
        (found[0] - 0.3).abs() < 1e-7 && (found[1] - 0.6).abs() < 1e-7,
        "{found:?}"
    );
}
