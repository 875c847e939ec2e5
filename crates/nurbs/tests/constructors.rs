//! Exact constructions checked against the geometry they claim: implicit equations, closed-form
//! normals and curvatures, de Casteljau, and rotations computed in `f64`.
#![allow(clippy::unwrap_used)]

use glam::{DQuat, DVec2, DVec3, Vec2, Vec3};
use nurbs::construct;
use nurbs::{NurbsError, SurfaceBuf};
use proptest::prelude::*;
use std::f64::consts::{PI, TAU};
use testkit::{EPS32, RefCurve, curve_spec};

/// Parameters to sample: both ends, every quarter and eighth (knots and arc midpoints of the
/// constructions), and irregular points in between.
fn samples() -> Vec<f32> {
    let mut u: Vec<f32> = (0..=64).map(|i| i as f32 / 64.0).collect();
    u.extend([0.013, 0.377, 0.5001, 0.731, 0.999, 0.9999]);
    u.sort_by(f32::total_cmp);
    u
}

/// Conditioning of curvature on an arc split into pieces of `dθ ≤ 90°`: the control points are
/// exact to eps·(|c| + r), but the curvature depends on the sagitta of each piece,
/// r (1 − cos(dθ/2)) ≈ r dθ²/8, so its relative error grows like 1/dθ² for short arcs.
fn arc_curvature_cond(sweep: f64) -> f64 {
    let sweep = sweep.min(TAU);
    let pieces = (sweep / (PI / 2.0)).ceil().max(1.0);
    let dtheta = sweep / pieces;
    1.0 / dtheta.min(1.0).powi(2)
}

fn vec2() -> impl Strategy<Value = Vec2> {
    [-1.0f32..1.0, -1.0f32..1.0].prop_map(Vec2::from_array)
}

fn vec3() -> impl Strategy<Value = Vec3> {
    [-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0].prop_map(Vec3::from_array)
}

/// A unit vector (f64, then rounded), uniformly enough for tests.
fn unit3() -> impl Strategy<Value = DVec3> {
    [-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0]
        .prop_map(|c| DVec3::from_array(c).try_normalize().unwrap_or(DVec3::Z))
}

/// Angle of `p` in (−π, π].
fn angle(p: DVec2) -> f64 {
    p.y.atan2(p.x)
}

fn d2(p: Vec2) -> DVec2 {
    p.as_dvec2()
}

// -------------------------------------------------------------------------------------------
// Circles, arcs, ellipses
// -------------------------------------------------------------------------------------------

#[test]
fn unit_circle_known_points() {
    let c = construct::circle(Vec2::ZERO, 1.0).unwrap();
    // A7.1 splits 360° into four 90° arcs: nine control points, double knots at ¼, ½, ¾, where
    // the curve passes through the quarter points.
    assert_eq!(c.points().len(), 9);
    let c = c.view();
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let expect = [
        (0.0, Vec2::new(1.0, 0.0)),
        (0.125, Vec2::new(h, h)),
        (0.25, Vec2::new(0.0, 1.0)),
        (0.375, Vec2::new(-h, h)),
        (0.5, Vec2::new(-1.0, 0.0)),
        (0.625, Vec2::new(-h, -h)),
        (0.75, Vec2::new(0.0, -1.0)),
        (0.875, Vec2::new(h, -h)),
        (1.0, Vec2::new(1.0, 0.0)),
    ];
    // The midpoint of each symmetric 90° arc is on its bisector (P&T §7.3).
    for (u, p) in expect {
        assert!((c.point(u) - p).length() <= 4.0 * f32::EPSILON, "C({u})");
    }
    assert!(c.is_closed(1e-6));
}

proptest! {
    #![proptest_config(testkit::config())]

    /// Every point of `circle` is at distance r from the centre, it runs counter-clockwise,
    /// curvature is +1/r, the tangent is ⟂ to the radius and the normal is (p − c)/r.
    #[test]
    fn circle_is_exact(center in vec2(), r in 0.01f32..10.0) {
        let c = construct::circle(center, r).unwrap();
        let c = c.view();
        let cd = d2(center);
        let rd = r as f64;
        // The control points are c + r (cos, sin) rounded once in f32, so the representable
        // circle is off by ~eps (|c| + r); rational evaluation adds a few ulps more. Derived
        // quantities (tangent, normal, curvature) are differences of control points and lose
        // the factor (|c| + r)/r on top.
        let cond = 1.0 + cd.length() / rd;
        let mut last = angle(d2(c.point(0.0)) - cd);
        let mut turned = 0.0;
        for u in samples() {
            let f = c.frame(u);
            let p = d2(f.derivs.point) - cd;
            prop_assert!((p.length() - rd).abs() <= 8.0 * EPS32 * rd * cond, "u={u}: |p−c| = {}", p.length());
            prop_assert!((f.curvature as f64 * rd - 1.0).abs() <= 64.0 * EPS32 * cond, "u={u}: κ r = {}", f.curvature * r);
            let n = p / rd;
            prop_assert!((d2(f.normal) - n).length() <= 32.0 * EPS32 * cond, "u={u}: n");
            let t = DVec2::new(-n.y, n.x);
            prop_assert!((d2(f.tangent) - t).length() <= 32.0 * EPS32 * cond, "u={u}: t");
            let a = angle(p);
            let mut step = a - last;
            if step < -PI { step += TAU; }
            prop_assert!(step >= -1e-6, "counter-clockwise");
            turned += step;
            last = a;
        }
        prop_assert!((turned - TAU).abs() <= 1e-4, "one full turn, got {turned}");
        prop_assert!(c.is_closed(1e-5 * (r + center.length())));
    }

    /// `ellipse` satisfies ((x−cx)/a)² + ((y−cy)/b)² = 1, its normal is the normalised gradient
    /// (x/a², y/b²) of that equation, and its curvature is the closed form
    /// κ = ab / (a² sin²θ + b² cos²θ)^{3/2} with (cos θ, sin θ) = (x/a, y/b).
    #[test]
    fn ellipse_is_exact(center in vec2(), a in 0.1f32..2.0, b in 0.1f32..2.0) {
        let e = construct::ellipse(center, a, b).unwrap();
        let e = e.view();
        let (ad, bd) = (a as f64, b as f64);
        let cd = d2(center);
        // As for the circle, relative to the smaller semi-axis, with the aspect ratio (≤ 20)
        // entering the derived quantities.
        let m = ad.min(bd);
        let cond = (1.0 + cd.length() / m) * (ad.max(bd) / m);
        for u in samples() {
            let f = e.frame(u);
            let p = d2(f.derivs.point) - cd;
            let (cs, sn) = (p.x / ad, p.y / bd);
            prop_assert!((cs * cs + sn * sn - 1.0).abs() <= 16.0 * EPS32 * cond, "u={u}: implicit");
            let grad = DVec2::new(p.x / (ad * ad), p.y / (bd * bd)).normalize();
            prop_assert!((d2(f.normal) - grad).length() <= 64.0 * EPS32 * cond, "u={u}: n");
            let kappa = ad * bd / (ad * ad * sn * sn + bd * bd * cs * cs).powf(1.5);
            prop_assert!(
                (f.curvature as f64 - kappa).abs() <= 256.0 * EPS32 * cond * kappa,
                "u={u}: κ = {}, closed form {kappa}", f.curvature
            );
        }
        // Starts on the positive x semi-axis.
        prop_assert!((d2(e.point(0.0)) - cd - DVec2::new(ad, 0.0)).length() <= 8.0 * EPS32 * (ad + cd.length()));
    }

    /// `arc` from θ0 over Δθ: starts at θ0, ends at θ0 + Δθ, stays on the circle, turns
    /// monotonically counter-clockwise through exactly Δθ, and has curvature +1/r.
    #[test]
    fn arc_is_exact(
        center in vec2(), r in 0.05f32..5.0, start in -3.2f32..3.2, sweep in 0.01f32..=std::f32::consts::TAU,
    ) {
        let arc = construct::arc(center, Vec2::X * r, Vec2::Y * r, start, sweep).unwrap();
        let arc = arc.view();
        let (cd, rd) = (d2(center), r as f64);
        let cond = 1.0 + cd.length() / rd;
        let sweep_d = (sweep as f64).min(TAU);
        let at = |th: f64| cd + DVec2::new(th.cos(), th.sin()) * rd;
        let tol = 16.0 * EPS32 * rd * cond;
        prop_assert!((d2(arc.point(0.0)) - at(start as f64)).length() <= tol);
        prop_assert!((d2(arc.point(1.0)) - at(start as f64 + sweep_d)).length() <= tol);
        let mut last = start as f64;
        for u in samples() {
            let f = arc.frame(u);
            let p = d2(f.derivs.point) - cd;
            prop_assert!((p.length() - rd).abs() <= 8.0 * EPS32 * rd * cond);
            let kcond = cond * arc_curvature_cond(sweep as f64);
            prop_assert!((f.curvature as f64 * rd - 1.0).abs() <= 64.0 * EPS32 * kcond, "κ r = {}", f.curvature * r);
            // Unwrap the angle next to the previous sample.
            let mut a = angle(p);
            while a < last - PI { a += TAU; }
            while a > last + PI { a -= TAU; }
            prop_assert!(a >= last - 1e-5, "monotone");
            last = a;
        }
        prop_assert!((last - (start as f64 + sweep_d)).abs() <= 1e-4 * cond, "total sweep");
    }

    /// A 3-D arc in a random plane: points on the circle and in the plane, unsigned curvature
    /// 1/r, principal normal towards the centre, and t × n along x_axis × y_axis.
    #[test]
    fn spatial_arc_is_exact(
        center in vec3(), r in 0.05f32..5.0, e1 in unit3(), e2 in unit3(),
        start in -3.2f32..3.2, sweep in 0.01f32..=std::f32::consts::TAU,
    ) {
        let x = e1;
        let y = (e2 - x * e2.dot(x)).try_normalize();
        prop_assume!(y.is_some());
        let y = y.unwrap_or(DVec3::Y);
        let z = x.cross(y);
        let rd = r as f64;
        let arc = construct::arc(
            center, (x * rd).as_vec3(), (y * rd).as_vec3(), start, sweep,
        ).unwrap();
        let arc = arc.view();
        let cd = center.as_dvec3();
        let cond = 1.0 + cd.length() / rd;
        for u in samples() {
            let f = arc.frame(u);
            let p = f.derivs.point.as_dvec3() - cd;
            prop_assert!((p.length() - rd).abs() <= 16.0 * EPS32 * rd * cond);
            prop_assert!(p.dot(z).abs() <= 16.0 * EPS32 * rd * cond, "in the plane");
            let kcond = cond * arc_curvature_cond(sweep as f64);
            prop_assert!((f.curvature as f64 * rd - 1.0).abs() <= 64.0 * EPS32 * kcond, "κ r = {}", f.curvature * r);
            let n = f.normal.as_dvec3();
            // The principal normal comes from C'' as well: same conditioning as κ.
            prop_assert!((n + p / rd).length() <= 64.0 * EPS32 * kcond, "towards the centre: {n}");
            let b = f.tangent.as_dvec3().cross(n);
            prop_assert!((b - z).length() <= 64.0 * EPS32 * kcond, "binormal");
        }
    }

    /// Non-orthogonal axes give the affine image of the circle: p = c + x cos θ + y sin θ, so
    /// solving for (cos θ, sin θ) yields a unit vector.
    #[test]
    fn skew_arc_is_affine_image_of_circle(
        center in vec2(), rx in 0.1f64..2.0, ry in 0.1f64..2.0, alpha in -3.2f64..3.2,
        gamma in 0.3f64..2.84, start in -3.2f32..3.2, sweep in 0.01f32..=std::f32::consts::TAU,
    ) {
        // Axes at an angle γ ∈ [0.3, π − 0.3] to each other: sin γ ≥ 0.29.
        let x = DVec2::from_angle(alpha) * rx;
        let y = DVec2::from_angle(alpha + gamma) * ry;
        let arc = construct::arc(center, x.as_vec2(), y.as_vec2(), start, sweep).unwrap();
        let arc = arc.view();
        let m = glam::DMat2::from_cols(x.as_vec2().as_dvec2(), y.as_vec2().as_dvec2());
        let inv = m.inverse();
        // Point errors of eps·(|c| + |x| + |y|) map through M⁻¹ (norm ≤ 1 / (min(rx, ry) sin γ)).
        let cond = (d2(center).length() + rx + ry) / (rx.min(ry) * gamma.sin());
        for u in samples() {
            let cs = inv * (d2(arc.point(u)) - d2(center));
            prop_assert!((cs.length() - 1.0).abs() <= 16.0 * EPS32 * cond, "|(cos, sin)| = {}", cs.length());
        }
    }
}

#[test]
fn degenerate_arcs_are_refused_and_long_sweeps_clamped() {
    // Zero sweep: a single point, a curve of no length, refused (`nurbs::MIN_EXTENT`); sweeps
    // beyond 2π are clamped to the full circle.
    assert!(matches!(
        construct::arc(Vec2::ZERO, Vec2::X, Vec2::Y, 0.3, 0.0),
        Err(NurbsError::ZeroLength { .. })
    ));
    let full = construct::arc(Vec2::ZERO, Vec2::X, Vec2::Y, 0.0, 100.0).unwrap();
    let full = full.view();
    assert!(full.is_closed(1e-6));
    assert!((full.point(0.5) + Vec2::X).length() <= 1e-6);
}

// -------------------------------------------------------------------------------------------
// Lines and Bézier curves
// -------------------------------------------------------------------------------------------

/// de Casteljau (P&T A1.5) in f64: a different algorithm from the crate's basis functions.
fn de_casteljau(p: &[DVec3], t: f64) -> DVec3 {
    let mut q = p.to_vec();
    for k in 1..q.len() {
        for i in 0..q.len() - k {
            q[i] = q[i] * (1.0 - t) + q[i + 1] * t;
        }
    }
    q[0]
}

proptest! {
    #![proptest_config(testkit::config())]

    #[test]
    fn line_is_exact(a in vec2(), b in vec2(), u in 0.0f32..=1.0) {
        let l = construct::line(a, b).unwrap();
        let l = l.view();
        let d = l.derivs(u, 2);
        prop_assert!((d.point - (a + (b - a) * u)).length() <= 4.0 * f32::EPSILON);
        prop_assert!((d.du - (b - a)).length() <= 4.0 * f32::EPSILON);
        prop_assert_eq!(d.duu, Vec2::ZERO);
        prop_assert_eq!(l.frame(u).curvature, 0.0);
    }

    /// `bezier_curve` against de Casteljau, and the end derivatives of eq. 1.10/1.11:
    /// C'(0) = n(P1 − P0), C''(0) = n(n−1)(P2 − 2P1 + P0), and symmetrically at 1.
    #[test]
    fn bezier_curve_is_de_casteljau(
        pts in proptest::collection::vec(vec3(), 2..=8), u in 0.0f32..=1.0,
    ) {
        let c = construct::bezier_curve(&pts).unwrap();
        let c = c.view();
        let n = pts.len() - 1;
        prop_assert_eq!(c.degree(), n);
        let p: Vec<DVec3> = pts.iter().map(|p| p.as_dvec3()).collect();
        // |P| <= √3; Bernstein sums round a few ulps per degree.
        prop_assert!((c.point(u).as_dvec3() - de_casteljau(&p, u as f64)).length() <= 16.0 * EPS32 * n as f64);
        let nf = n as f64;
        let d0 = c.derivs(0.0, 2);
        let d1 = c.derivs(1.0, 2);
        let tol1 = 32.0 * EPS32 * nf;
        let tol2 = 64.0 * EPS32 * nf * nf;
        prop_assert!((d0.du.as_dvec3() - (p[1] - p[0]) * nf).length() <= tol1);
        prop_assert!((d1.du.as_dvec3() - (p[n] - p[n - 1]) * nf).length() <= tol1);
        if n >= 2 {
            let c2 = nf * (nf - 1.0);
            prop_assert!((d0.duu.as_dvec3() - (p[2] - p[1] * 2.0 + p[0]) * c2).length() <= tol2);
            prop_assert!((d1.duu.as_dvec3() - (p[n] - p[n - 1] * 2.0 + p[n - 2]) * c2).length() <= tol2);
        }
    }
}

#[test]
fn bezier_curve_degree_limits() {
    assert!(matches!(
        construct::bezier_curve(&[Vec2::ZERO]),
        Err(NurbsError::Degree { degree: 0, .. })
    ));
    assert!(matches!(
        construct::bezier_curve::<Vec2>(&[]),
        Err(NurbsError::Degree { degree: 0, .. })
    ));
    let eight: Vec<Vec2> = (0..8).map(|i| Vec2::new(i as f32, 0.0)).collect();
    assert!(construct::bezier_curve(&eight).is_ok());
    assert!(matches!(
        construct::bezier_curve(&[Vec2::ZERO; 9]),
        Err(NurbsError::Degree { degree: 8, .. })
    ));
}

// -------------------------------------------------------------------------------------------
// Patches
// -------------------------------------------------------------------------------------------

proptest! {
    #![proptest_config(testkit::config())]

    /// S = (1−u)(1−v)P00 + u(1−v)P10 + (1−u)v P01 + uv P11 and its exact partials.
    #[test]
    fn bilinear_is_exact(
        p00 in vec3(), p10 in vec3(), p01 in vec3(), p11 in vec3(),
        u in 0.0f32..=1.0, v in 0.0f32..=1.0,
    ) {
        let s = construct::bilinear(p00, p10, p01, p11).unwrap();
        let s = s.view();
        let (u, v) = (u as f64, v as f64);
        let [a, b, c, d] = [p00, p10, p01, p11].map(|p| p.as_dvec3());
        let point = a * ((1.0 - u) * (1.0 - v)) + b * (u * (1.0 - v)) + c * ((1.0 - u) * v) + d * (u * v);
        let du = (b - a) * (1.0 - v) + (d - c) * v;
        let dv = (c - a) * (1.0 - u) + (d - b) * u;
        let duv = d - c - b + a;
        let sd = s.derivs(u as f32, v as f32, 2);
        let tol = 16.0 * EPS32;
        prop_assert!((sd.point.as_dvec3() - point).length() <= tol);
        prop_assert!((sd.du.as_dvec3() - du).length() <= tol);
        prop_assert!((sd.dv.as_dvec3() - dv).length() <= tol);
        prop_assert!((sd.duv.as_dvec3() - duv).length() <= tol);
        prop_assert_eq!(sd.duu, Vec3::ZERO);
        prop_assert_eq!(sd.dvv, Vec3::ZERO);
        let n = du.cross(dv);
        if n.length() > 1e-2 {
            // Normal error ≈ eps |∂S| / |S_u × S_v|.
            prop_assert!((s.normal(u as f32, v as f32).as_dvec3() - n.normalize()).length() <= 64.0 * EPS32 / n.length());
        }
    }

    /// `bezier_patch` against tensor-product de Casteljau, and the corner partials
    /// S_u(0,0) = p(P10 − P00), S_v(0,0) = q(P01 − P00), S_uv(0,0) = pq(P11 − P10 − P01 + P00).
    #[test]
    fn bezier_patch_is_de_casteljau(
        net in (2usize..=5, 2usize..=5).prop_flat_map(|(m, n)| proptest::collection::vec(proptest::collection::vec(vec3(), n), m)),
        u in 0.0f32..=1.0, v in 0.0f32..=1.0,
    ) {
        let s = construct::bezier_patch(&net).unwrap();
        let s = s.view();
        let (p, q) = (net.len() - 1, net[0].len() - 1);
        prop_assert_eq!(s.degree(), (p, q));
        let rows: Vec<Vec<DVec3>> = net.iter().map(|r| r.iter().map(|x| x.as_dvec3()).collect()).collect();
        let cols: Vec<DVec3> = rows.iter().map(|r| de_casteljau(r, v as f64)).collect();
        let want = de_casteljau(&cols, u as f64);
        prop_assert!((s.point(u, v).as_dvec3() - want).length() <= 32.0 * EPS32 * (p + q) as f64);
        let d = s.derivs(0.0, 0.0, 2);
        let (pf, qf) = (p as f64, q as f64);
        let tol = 64.0 * EPS32 * pf * qf;
        prop_assert!((d.du.as_dvec3() - (rows[1][0] - rows[0][0]) * pf).length() <= tol);
        prop_assert!((d.dv.as_dvec3() - (rows[0][1] - rows[0][0]) * qf).length() <= tol);
        prop_assert!((d.duv.as_dvec3() - (rows[1][1] - rows[1][0] - rows[0][1] + rows[0][0]) * (pf * qf)).length() <= tol);
    }
}

// -------------------------------------------------------------------------------------------
// Surfaces of revolution
// -------------------------------------------------------------------------------------------

/// Samples of `(u, v)` including all four edges.
fn grid() -> Vec<(f32, f32)> {
    let ts: Vec<f32> = (0..=16)
        .map(|i| i as f32 / 16.0)
        .chain([0.03, 0.61])
        .collect();
    ts.iter()
        .flat_map(|&u| ts.iter().map(move |&v| (u, v)))
        .collect()
}

proptest! {
    #![proptest_config(testkit::config())]

    /// Sphere: |p − c| = r everywhere, outward normal (p − c)/r everywhere, and at the poles
    /// (v = 0 south, v = 1 north) exactly the limit normals −z and +z for every u.
    #[test]
    fn sphere_is_exact(center in vec3(), r in 0.05f32..5.0) {
        let s = construct::sphere(center, r).unwrap();
        let s = s.view();
        let (cd, rd) = (center.as_dvec3(), r as f64);
        let cond = 1.0 + cd.length() / rd;
        for (u, v) in grid() {
            let p = s.point(u, v).as_dvec3() - cd;
            prop_assert!((p.length() - rd).abs() <= 16.0 * EPS32 * rd * cond, "({u}, {v}): |p − c| = {}", p.length());
            let n = s.normal(u, v);
            prop_assert!(n.is_finite());
            let want = if v == 0.0 {
                -DVec3::Z
            } else if v == 1.0 {
                DVec3::Z
            } else {
                p / rd
            };
            // Near the poles S_u is small and carries the rounding of the control points
            // relative to its size ~ r sin φ: the normal is good to ~eps·cond / sin φ there.
            let polar = (p.z / rd).clamp(-1.0, 1.0).acos();
            let sin_phi = polar.sin().max(1e-3);
            let tol = 256.0 * EPS32 * cond / sin_phi;
            prop_assert!((n.as_dvec3() - want).length() <= tol.max(1e-6), "({u}, {v}): n = {n}, want {want}");
        }
        for u in [0.0, 0.1, 0.25, 0.5, 0.77, 1.0] {
            prop_assert!((s.point(u, 0.0).as_dvec3() - (cd - DVec3::Z * rd)).length() <= 16.0 * EPS32 * rd * cond);
            prop_assert!((s.point(u, 1.0).as_dvec3() - (cd + DVec3::Z * rd)).length() <= 16.0 * EPS32 * rd * cond);
        }
    }

    /// Torus: (ρ − R)² + z² = r² with ρ the distance from the axis, outward normal
    /// (p − q)/r with q the nearest point of the core circle, v = 0 on the outer equator.
    #[test]
    fn torus_is_exact(center in vec3(), major in 0.5f32..3.0, ratio in 0.05f32..0.9) {
        let minor = major * ratio;
        let s = construct::torus(center, major, minor).unwrap();
        let s = s.view();
        let (cd, big, small) = (center.as_dvec3(), major as f64, minor as f64);
        let cond = 1.0 + (cd.length() + big) / small;
        for (u, v) in grid() {
            let p = s.point(u, v).as_dvec3() - cd;
            let rho = p.truncate().length();
            let tube = ((rho - big).powi(2) + p.z * p.z).sqrt();
            prop_assert!((tube - small).abs() <= 16.0 * EPS32 * small * cond, "({u}, {v}): tube radius {tube}");
            let q = (p.truncate() / rho * big).extend(0.0);
            let want = (p - q) / small;
            let n = s.normal(u, v).as_dvec3();
            prop_assert!((n - want).length() <= 256.0 * EPS32 * cond, "({u}, {v}): n = {n}, want {want}");
            if v == 0.0 || v == 1.0 {
                prop_assert!((rho - (big + small)).abs() <= 16.0 * EPS32 * small * cond && p.z.abs() <= 16.0 * EPS32 * small * cond);
            }
        }
    }

    /// Cylinder: distance r from the axis, axial coordinate in [0, h] with v = 0 on the base
    /// and v = 1 on the top, S_v = h â, outward radial normal.
    #[test]
    fn cylinder_is_exact(base in vec3(), axis in unit3(), r in 0.05f32..3.0, h in 0.05f32..3.0) {
        let s = construct::cylinder(base, axis.as_vec3(), r, h).unwrap();
        let s = s.view();
        // The constructor normalises the axis in f32.
        let a = axis.as_vec3().normalize().as_dvec3();
        let (bd, rd, hd) = (base.as_dvec3(), r as f64, h as f64);
        let cond = 1.0 + (bd.length() + hd) / rd;
        for (u, v) in grid() {
            let d = s.derivs(u, v, 1);
            let p = d.point.as_dvec3() - bd;
            let along = p.dot(a);
            let radial = p - a * along;
            prop_assert!((radial.length() - rd).abs() <= 16.0 * EPS32 * rd * cond);
            prop_assert!((along - v as f64 * hd).abs() <= 16.0 * EPS32 * (rd + hd) * cond);
            prop_assert!((d.dv.as_dvec3() - a * hd).length() <= 16.0 * EPS32 * (rd + hd) * cond);
            let n = s.normal(u, v).as_dvec3();
            prop_assert!((n - radial / rd).length() <= 128.0 * EPS32 * cond, "({u}, {v}): n = {n}");
        }
    }
}

/// Rotation by `angle` about the line through `o` along unit `axis`, in f64.
fn rotate(p: DVec3, o: DVec3, axis: DVec3, angle: f64) -> DVec3 {
    o + DQuat::from_axis_angle(axis, angle) * (p - o)
}

proptest! {
    #![proptest_config(testkit::config())]

    /// A surface of revolution is S(u, v) = Rot(θ(u)) profile(v), with θ(0) = 0, θ(1) = sweep
    /// and θ(u) the same for every v (the weights separate, P&T §8.5). Checked against the f64
    /// definition of a random profile (any degree, rational or not, arbitrary domain):
    /// S(0, v) = profile(v), S(1, v) = Rot(sweep) profile(v), and for every u the distance to
    /// the axis and the axial coordinate of profile(v) are preserved.
    #[test]
    fn revolve_rotates_the_profile(
        spec in curve_spec(4, 2), origin in vec3(), axis in unit3(), sweep in 0.1f32..=std::f32::consts::TAU,
        vs in proptest::collection::vec(0.0f64..=1.0, 4),
    ) {
        let prof = spec.build::<Vec3>();
        let r = RefCurve::new(&prof.view());
        let s = construct::revolve(&prof, origin, axis.as_vec3(), sweep).unwrap();
        let s = s.view();
        let (a, b) = prof.view().domain();
        prop_assert_eq!(s.domain().1, (a, b));
        prop_assert_eq!(s.domain().0, (0.0, 1.0));
        let ax = axis.as_vec3().as_dvec3().normalize();
        let o = origin.as_dvec3();
        let size = r.cartesian().iter().map(|p| (*p - o).length()).fold(0.0, f64::max) + o.length();
        // Control points are rotated in f64 and rounded once; evaluation adds a few ulps of the
        // overall size, amplified by the weight ratio of the profile.
        let tol = 64.0 * EPS32 * size * spec.weight_ratio();
        let sw = (sweep as f64).min(TAU);
        let mut vs = vs;
        vs.extend([0.0, 1.0]);
        for vt in vs {
            let v = ((a as f64 + vt * (b as f64 - a as f64)) as f32).min(b);
            let q = r.point(v as f64);
            prop_assert!((s.point(0.0, v).as_dvec3() - q).length() <= tol, "S(0, v) = profile(v)");
            prop_assert!((s.point(1.0, v).as_dvec3() - rotate(q, o, ax, sw)).length() <= tol, "S(1, v)");
            let qa = (q - o).dot(ax);
            let qr = (q - o - ax * qa).length();
            for u in [0.1f32, 0.25, 0.5, 0.62, 0.9] {
                let p = s.point(u, v).as_dvec3() - o;
                let pa = p.dot(ax);
                prop_assert!((pa - qa).abs() <= tol, "axial coordinate");
                prop_assert!(((p - ax * pa).length() - qr).abs() <= tol, "distance to the axis");
            }
        }
    }
}

/// Cone x² + y² = (k z)² built by revolving a line whose end lies on the axis. A cone's normal is
/// constant along each generator, so at the apex (a pole of the revolution) the limit normal
/// along the generator at angle φ is the closed form (cos φ, sin φ, −k) / √(1 + k²). The apex at
/// v = 0 and at v = 1 exercises both directions of the limit; the transposed net (u and v
/// swapped) exercises the branch where S_v vanishes, with normal S_v × S_u = −(S_u × S_v).
#[test]
fn cone_apex_normals_are_limits() {
    let k = 0.75f64;
    let apex = Vec3::ZERO;
    let rim = Vec3::new(k as f32 * 2.0, 0.0, 2.0);
    for (from, to) in [(apex, rim), (rim, apex)] {
        let prof = construct::line(from, to).unwrap();
        let s = construct::revolve(&prof, Vec3::ZERO, Vec3::Z, std::f32::consts::TAU).unwrap();
        let apex_v = if from == apex { 0.0 } else { 1.0 };
        // Orientation: S_u is counter-clockwise about z, S_v runs along the profile; the
        // outward normal of the cone is (cos φ, sin φ, −k)/√(1+k²) when the profile runs away
        // from the apex, and flips when it runs towards it.
        let sign = if from == apex { 1.0 } else { -1.0 };
        let view = s.view();
        let (nu, nv) = view.counts();
        let (ku, kv) = view.knots();
        let pts: Vec<_> = (0..nv)
            .flat_map(|j| (0..nu).map(move |i| (i, j)))
            .map(|(i, j)| view.points()[i * nv + j])
            .collect();
        let t = SurfaceBuf::new(
            (view.degree().1, view.degree().0),
            (kv.as_slice().to_vec(), ku.as_slice().to_vec()),
            nu,
            pts,
        )
        .unwrap();
        let tv = t.view();
        for s_ in 0..=16 {
            let u = s_ as f32 / 16.0;
            // Generator angle from a point off the apex.
            let off = view.point(u, 0.5).as_dvec3();
            let phi = off.y.atan2(off.x);
            let want = DVec3::new(phi.cos(), phi.sin(), -k) * sign / (1.0 + k * k).sqrt();
            let n = view.normal(u, apex_v).as_dvec3();
            assert!(
                (n - want).length() <= 1e-5,
                "u={u}: apex normal {n}, want {want}"
            );
            let n_mid = view.normal(u, 0.5).as_dvec3();
            assert!((n_mid - want).length() <= 1e-5, "u={u}: n = {n_mid}");
            let nt = tv.normal(apex_v, u).as_dvec3();
            assert!(
                (nt + want).length() <= 1e-5,
                "transposed u={u}: {nt}, want {}",
                -want
            );
        }
    }
}

#[test]
fn constructor_surfaces_orientation_outward() {
    // Documented: S_u × S_v points outward on sphere, cylinder and torus.
    let sphere = construct::sphere(Vec3::new(0.5, -1.0, 2.0), 1.5).unwrap();
    let torus = construct::torus(Vec3::new(0.5, -1.0, 2.0), 2.0, 0.5).unwrap();
    let cyl = construct::cylinder(
        Vec3::new(0.5, -1.0, 2.0),
        Vec3::new(1.0, 1.0, 0.0),
        0.7,
        2.0,
    )
    .unwrap();
    for (name, s, inside) in [
        ("sphere", sphere.view(), Vec3::new(0.5, -1.0, 2.0)),
        ("cylinder", cyl.view(), Vec3::ZERO),
        ("torus", torus.view(), Vec3::ZERO),
    ] {
        for &(u, v) in &[(0.1, 0.3), (0.4, 0.6), (0.8, 0.2)] {
            let d = s.derivs(u, v, 1);
            let n = d.du.cross(d.dv);
            let away = if name == "torus" {
                // Away from the core circle of radius 2 around (0.5, −1, 2).
                let c = Vec3::new(0.5, -1.0, 2.0);
                let rel = d.point - c;
                rel - rel.with_z(0.0).normalize() * 2.0
            } else if name == "cylinder" {
                let a = Vec3::new(1.0, 1.0, 0.0).normalize();
                let rel = d.point - Vec3::new(0.5, -1.0, 2.0);
                rel - a * rel.dot(a)
            } else {
                d.point - inside
            };
            assert!(n.dot(away) > 0.0, "{name} at ({u}, {v})");
        }
    }
}

#[test]
fn revolve_with_zero_axis_uses_z() {
    // Documented fallback of the constructors: a zero axis direction means +z.
    let prof = construct::line(Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 1.0)).unwrap();
    let a = construct::revolve(&prof, Vec3::ZERO, Vec3::ZERO, 1.0).unwrap();
    let b = construct::revolve(&prof, Vec3::ZERO, Vec3::Z, 1.0).unwrap();
    assert_eq!(a, b);
}

/// Uniform clamped knots: p + 1 zeros, evenly spaced interior knots, p + 1 ones, and the right
/// count for the control points (the Piegl & Tiller convention m = n + p + 1).
#[test]
fn uniform_knots_are_clamped_and_even() {
    assert_eq!(
        nurbs::construct::uniform_knots(5, 2),
        vec![0.0, 0.0, 0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0, 1.0, 1.0]
    );
    assert_eq!(
        nurbs::construct::uniform_knots(4, 3),
        vec![0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0]
    );
    assert!(nurbs::construct::uniform_knots(3, 3).is_empty());
    for (n, p) in [(8, 3), (12, 5), (2, 1)] {
        let k = nurbs::construct::uniform_knots(n, p);
        assert!(
            nurbs::Knots::new(&k, p, n).is_ok(),
            "{n} points, degree {p}"
        );
    }
}
