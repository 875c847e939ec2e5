//! Curve evaluation, derivatives and frames against closed forms (The NURBS Book Ex4.1 and the
//! rational quarter circle) and against central differences of an independent `f64`
//! evaluation of the definition.
#![allow(clippy::unwrap_used)]

use glam::{DVec3, Vec2, Vec3};
use nurbs::{Curve, CurveBuf, NurbsError, Point};
use proptest::prelude::*;
use testkit::{
    EPS32, RefCurve, central1, central2, curve_spec, from3, in_span, min_gap, rel_err, wide,
};

/// Ex4.1: P0 = (1,0), P1 = (1,1), P2 = (0,1), w = {1, 1, 2}, U = {0,0,0,1,1,1} is the quarter
/// unit circle C(u) = ((1−u²)/(1+u²), 2u/(1+u²)), counter-clockwise.
const EX41_KNOTS: [f32; 6] = [0., 0., 0., 1., 1., 1.];
const EX41_HOM: [Vec3; 3] = [
    Vec3::new(1.0, 0.0, 1.0),
    Vec3::new(1.0, 1.0, 1.0),
    Vec3::new(0.0, 2.0, 2.0),
];

/// `C, C', C''` of Ex4.1 by differentiating the closed form by hand:
/// x = 2/(1+u²) − 1, x' = −4u/(1+u²)², x'' = (12u² − 4)/(1+u²)³,
/// y = 2u/(1+u²),    y' = 2(1−u²)/(1+u²)², y'' = (4u³ − 12u)/(1+u²)³.
fn ex41(u: f64) -> [DVec3; 3] {
    let s = 1.0 + u * u;
    [
        DVec3::new((1.0 - u * u) / s, 2.0 * u / s, 0.0),
        DVec3::new(-4.0 * u / (s * s), 2.0 * (1.0 - u * u) / (s * s), 0.0),
        DVec3::new(
            (12.0 * u * u - 4.0) / (s * s * s),
            (4.0 * u * u * u - 12.0 * u) / (s * s * s),
            0.0,
        ),
    ]
}

#[test]
fn ex4_1_rational_quarter_circle_planar() {
    let c = Curve::<Vec2>::new(2, &EX41_KNOTS, &EX41_HOM).unwrap();
    assert_eq!(c.control_point(2), Some((Vec2::new(0.0, 1.0), 2.0)));
    assert_eq!(c.control_point(3), None);
    for s in 0..=200 {
        let u = s as f32 / 200.0;
        let [p, d1, d2] = ex41(u as f64);
        let f = c.frame(u);
        let d = f.derivs;
        // Magnitudes here are at most 4; the f32 pipeline stays within a few ulps of that.
        let tol = 32.0 * EPS32;
        assert!(rel_err(wide(d.point), p, 1.0) <= tol, "C({u})");
        assert!(rel_err(wide(d.du), d1, 2.0) <= tol, "C'({u})");
        assert!(rel_err(wide(d.duu), d2, 4.0) <= tol, "C''({u})");
        assert!(
            ((d.point.length() as f64) - 1.0).abs() <= tol,
            "|C({u})| = 1"
        );
        // Unit circle, counter-clockwise: curvature +1, tangent (−y, x), normal outward = C.
        assert!(
            (f.curvature as f64 - 1.0).abs() <= 1e-5,
            "κ({u}) = {}",
            f.curvature
        );
        let t = DVec3::new(-p.y, p.x, 0.0);
        assert!(rel_err(wide(f.tangent), t, 1.0) <= 1e-6, "T({u})");
        assert!(rel_err(wide(f.normal), p, 1.0) <= 1e-6, "N({u})");
    }
    // C'(0) = (0, 2), C'(1) = (−1, 0): the tangents of Ex4.1 at the ends.
    assert_eq!(c.derivs(0.0, 1).du, Vec2::new(0.0, 2.0));
    assert!((c.derivs(1.0, 1).du - Vec2::new(-1.0, 0.0)).length() <= 1e-6);
}

#[test]
fn ex4_1_in_space_has_principal_normal_towards_centre() {
    // The same quarter circle in the plane z = 0.5 of 3-D space.
    let hom: Vec<_> = EX41_HOM
        .iter()
        .map(|h| glam::Vec4::new(h.x, h.y, 0.5 * h.z, h.z))
        .collect();
    let c = Curve::<Vec3>::new(2, &EX41_KNOTS, &hom).unwrap();
    for s in 0..=50 {
        let u = s as f32 / 50.0;
        let [p, _, _] = ex41(u as f64);
        let f = c.frame(u);
        assert!(rel_err(wide(f.derivs.point), p + DVec3::Z * 0.5, 1.0) <= 32.0 * EPS32);
        // Spatial curvature is unsigned, and the principal normal points to the centre.
        assert!((f.curvature as f64 - 1.0).abs() <= 1e-5);
        assert!(
            rel_err(wide(f.normal), -p, 1.0) <= 1e-5,
            "N({u}) = {:?}",
            f.normal
        );
        assert!(rel_err(wide(f.tangent), DVec3::new(-p.y, p.x, 0.0), 1.0) <= 1e-6);
    }
}

/// The 90° arc with the weight cos 45° on the corner (P&T §7.3): every point on the unit circle
/// and, by symmetry, C(½) on the bisector.
#[test]
fn quarter_circle_with_corner_weight() {
    let w = std::f32::consts::FRAC_1_SQRT_2;
    let hom = [
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(w, w, w),
        Vec3::new(0.0, 1.0, 1.0),
    ];
    let c = Curve::<Vec2>::new(2, &EX41_KNOTS, &hom).unwrap();
    let mid = c.point(0.5);
    assert!((mid - Vec2::splat(w)).length() <= 2e-7, "{mid:?}");
    let mut last_angle = -1.0;
    for s in 0..=100 {
        let p = c.point(s as f32 / 100.0);
        assert!((p.length() - 1.0).abs() <= 4.0 * f32::EPSILON);
        let angle = p.y.atan2(p.x);
        assert!(angle > last_angle, "angle increases along u");
        last_angle = angle;
    }
}

/// A quarter circle of radius 2 run clockwise has curvature −1/2.
#[test]
fn clockwise_circle_has_negative_curvature() {
    let w = std::f32::consts::FRAC_1_SQRT_2;
    let hom = [
        Vec3::new(0.0, 2.0, 1.0),
        Vec3::new(2.0 * w, 2.0 * w, w),
        Vec3::new(2.0, 0.0, 1.0),
    ];
    let c = Curve::<Vec2>::new(2, &EX41_KNOTS, &hom).unwrap();
    for s in 0..=20 {
        let f = c.frame(s as f32 / 20.0);
        assert!((f.curvature + 0.5).abs() <= 1e-5, "κ = {}", f.curvature);
        // n = t × k̂ points towards the centre on a clockwise circle.
        let inward = -f.derivs.point / 2.0;
        assert!((f.normal - inward).length() <= 1e-5);
    }
}

/// A collapsed first (last) edge of the control polygon makes C' vanish at the end; the frame
/// returns the limit tangent, the direction of travel: P2 − P1 at the start and
/// P_{n−1} − P_{n−2} at the end (C'(u) ≈ (u − a) C''(a) with C''(a) ∥ P2 − P1).
#[test]
fn degenerate_end_tangents_are_limits() {
    let pts = [
        Vec2::new(0.0, 0.0),
        Vec2::new(0.0, 0.0),
        Vec2::new(1.0, 2.0),
        Vec2::new(3.0, 2.0),
        Vec2::new(3.0, 2.0),
    ];
    let knots = vec![0.0, 0.0, 0.0, 0.25, 0.75, 1.0, 1.0, 1.0];
    let c = CurveBuf::from_cartesian(2, knots, &pts, None).unwrap();
    let c = c.view();
    let start = c.frame(0.0);
    assert!(start.derivs.du.length() <= 1e-6);
    assert!((start.tangent - Vec2::new(1.0, 2.0).normalize()).length() <= 1e-6);
    assert!(start.tangent.is_finite() && start.normal.is_finite());
    assert_eq!(start.curvature, 0.0);
    let end = c.frame(1.0);
    assert!(
        (end.tangent - Vec2::X).length() <= 1e-6,
        "{:?}",
        end.tangent
    );
    assert_eq!(end.curvature, 0.0);
    // Just inside, the ordinary tangent already points the same way.
    let inside = c.frame(1e-3);
    assert!((inside.tangent - start.tangent).length() <= 1e-2);
}

/// A single point (all control points equal) has no tangent, normal or closest point to
/// speak of: it is refused at construction, so evaluation never sees it.
#[test]
fn point_curve_is_refused() {
    let p = Vec3::new(1.0, -2.0, 3.0);
    let c = CurveBuf::from_cartesian(3, vec![0., 0., 0., 0., 1., 1., 1., 1.], &[p; 4], None);
    assert_eq!(c, Err(NurbsError::ZeroLength { extent: 0.0 }));
}

/// Straight 3-D line: curvature 0, tangent along it, and a unit normal orthogonal to it even
/// though the principal normal is undefined.
#[test]
fn straight_line_frame() {
    let (a, b) = (Vec3::new(1.0, 2.0, 3.0), Vec3::new(-2.0, 0.5, 4.0));
    let c = nurbs::construct::line(a, b).unwrap();
    let c = c.view();
    let t = (b - a).normalize();
    for s in 0..=10 {
        let u = s as f32 / 10.0;
        let f = c.frame(u);
        assert!((f.derivs.point - (a + (b - a) * u)).length() <= 1e-6);
        assert!((f.derivs.du - (b - a)).length() <= 1e-6);
        assert_eq!(f.derivs.duu, Vec3::ZERO);
        assert!((f.tangent - t).length() <= 1e-6);
        assert!((f.normal.length() - 1.0).abs() <= 1e-6);
        assert!(f.normal.dot(f.tangent).abs() <= 1e-6);
        assert_eq!(f.curvature, 0.0);
    }
    assert!(!c.is_closed(1e-3));
}

/// A nearly straight spatial cubic: C'' is almost parallel to C', so its component orthogonal
/// to the tangent (the principal normal direction) is ~1e-5 of |C''|. The normal must still be
/// orthogonal to the tangent and match the f64 principal normal from the Bézier derivative
/// formulas C' = 3 Σ B_{i,2} ΔP_i, C'' = 6 Σ B_{i,1} Δ²P_i (P&T eq. 1.10).
#[test]
fn nearly_straight_spatial_normal() {
    let pts = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(3.0, 0.0, 0.0),
        Vec3::new(7.0, 1e-4, 2e-4),
    ];
    let c = nurbs::construct::bezier_curve(&pts).unwrap();
    let c = c.view();
    let p: Vec<DVec3> = pts.iter().map(|p| p.as_dvec3()).collect();
    for s in 1..10 {
        let u = s as f32 / 10.0;
        let x = u as f64;
        let b2 = [(1.0 - x) * (1.0 - x), 2.0 * x * (1.0 - x), x * x];
        let d1 = ((p[1] - p[0]) * b2[0] + (p[2] - p[1]) * b2[1] + (p[3] - p[2]) * b2[2]) * 3.0;
        let d2 = ((p[2] - p[1] * 2.0 + p[0]) * (1.0 - x) + (p[3] - p[2] * 2.0 + p[1]) * x) * 6.0;
        let t = d1.normalize();
        let perp = d2 - t * d2.dot(t);
        let n_ref = perp.normalize();
        let f = c.frame(u);
        // |perp| / |C''| is ~1e-5 here: the f32 derivatives fix the direction of perp only to
        // about eps / 1e-5 ≈ 1e-2, hence the loose direction check. Orthogonality to the
        // returned tangent, though, does not depend on that conditioning and must hold to a
        // few ulps.
        assert!(
            perp.length() / d2.length() < 1e-4,
            "test is meant to be near-straight"
        );
        assert!(
            f.normal.dot(f.tangent).abs() <= 1e-6,
            "u={u}: n·t = {}",
            f.normal.dot(f.tangent)
        );
        assert!(
            (f.normal.as_dvec3() - n_ref).length() <= 1e-2,
            "u={u}: {:?} vs {n_ref}",
            f.normal
        );
    }
}

/// Non-rational cubic with an interior knot at a non-dyadic value on the domain [−3, 7]:
/// evaluation agrees with the f64 definition at 101 points including both ends.
#[test]
fn arbitrary_domain_matches_definition() {
    let knots = vec![-3.0, -3.0, -3.0, -3.0, 0.3, 0.3, 4.1, 7.0, 7.0, 7.0, 7.0];
    let pts = [
        Vec2::new(0.0, 0.0),
        Vec2::new(1.0, 3.0),
        Vec2::new(2.0, -1.0),
        Vec2::new(4.0, 4.0),
        Vec2::new(5.0, 0.5),
        Vec2::new(6.0, 2.0),
        Vec2::new(7.0, -2.0),
    ];
    let c = CurveBuf::from_cartesian(3, knots, &pts, None).unwrap();
    let c = c.view();
    let r = RefCurve::new(&c);
    assert_eq!(c.domain(), (-3.0, 7.0));
    for s in 0..=100 {
        let u = -3.0 + s as f32 * 0.1;
        let u = u.min(7.0);
        assert!(
            rel_err(wide(c.point(u)), r.point(u as f64), 7.0) <= 16.0 * EPS32,
            "u={u}"
        );
    }
    assert_eq!(c.point(-3.0), pts[0]);
    assert_eq!(c.point(7.0), pts[6]);
}

/// Derivative and frame checks of one random curve at one parameter.
fn check_derivs<P: Point>(
    spec: &testkit::CurveSpec,
    pick: f64,
    t: f64,
) -> Result<(), TestCaseError> {
    let buf = spec.build::<P>();
    let c = buf.view();
    let r = RefCurve::new(&c);
    let (u, len) = in_span(&spec.knots, pick, t);
    let uf = u as f64;
    let f = |x: f64| r.point(x);

    // Rounding scale of the k-th derivative: |P|max (R p / Δmin)^k, with R = wmax / wmin
    // (A4.2 divides by w once per order) and p / Δmin bounding the basis derivatives.
    // The f64 central differences (h = 1e-5 / 1e-4 of the span for C' / C'', stencil inside
    // the span) add ~0.2 ulp of these scales through f64 rounding (eps64 |C| / h²) and, for
    // non-rational data, ~0.2 ulp of truncation (h² |C⁗| / 12). Over 20 000 random curves of
    // degree ≤ 5 the total error stayed below 3 ulps of the scale; 32 ulps leaves a 10× margin,
    // while a wrong term in the basis derivatives or in A4.2 is an error of order the scale.
    let pmax = r.cartesian().iter().map(|p| p.length()).fold(0.0, f64::max);
    let dscale = spec.p as f64 / min_gap(&spec.knots) * spec.weight_ratio();
    let s = [pmax, pmax * dscale, pmax * dscale * dscale];
    let tol = 32.0 * EPS32;

    let d = c.derivs(u, 2);
    let ref0 = r.point(uf);
    let ref1 = central1(f, uf, 1e-5 * len);
    let ref2 = central2(f, uf, 1e-4 * len);
    prop_assert!(
        rel_err(wide(d.point), ref0, s[0]) <= tol,
        "C: {:?} vs {ref0}",
        d.point
    );
    prop_assert!(
        rel_err(wide(d.du), ref1, s[1]) <= tol,
        "C': {:?} vs {ref1}",
        d.du
    );
    prop_assert!(
        rel_err(wide(d.duu), ref2, s[2]) <= tol,
        "C'': {:?} vs {ref2}",
        d.duu
    );

    // Lower orders leave the higher entries zero and agree with the full evaluation.
    let d0 = c.derivs(u, 0);
    let d1 = c.derivs(u, 1);
    prop_assert_eq!(d0.du, P::ZERO);
    prop_assert_eq!(d1.duu, P::ZERO);
    prop_assert_eq!(d0.point, d.point);
    prop_assert_eq!(d1.du, d.du);
    prop_assert!(rel_err(wide(c.point(u)), ref0, s[0]) <= tol);

    // Frame against the f64 derivatives, where the tangent is well defined (|C'| not small
    // against its scale). First-order perturbation bounds with δ1 = tol·s1, δ2 = tol·s2.
    let fr = c.frame(u);
    let l1 = ref1.length();
    prop_assert!(((wide(fr.tangent).length()) - 1.0).abs() <= 1e-6);
    prop_assert!(((wide(fr.normal).length()) - 1.0).abs() <= 1e-6);
    prop_assert!(wide(fr.tangent).dot(wide(fr.normal)).abs() <= 1e-6);
    if l1 >= 0.05 * s[1] {
        let (d1e, d2e) = (tol * s[1], tol * s[2]);
        let t_ref = ref1 / l1;
        prop_assert!((wide(fr.tangent) - t_ref).length() <= 2.0 * d1e / l1 + 1e-6);
        let num = if P::DIM == 2 {
            ref1.x * ref2.y - ref1.y * ref2.x
        } else {
            ref1.cross(ref2).length()
        };
        let kappa = num / (l1 * l1 * l1);
        let dnum = d1e * ref2.length() + l1 * d2e;
        let dkappa =
            4.0 * (dnum + 3.0 * num.abs() * d1e / l1) / (l1 * l1 * l1) + 1e-6 * kappa.abs();
        prop_assert!(
            (fr.curvature as f64 - kappa).abs() <= dkappa,
            "κ = {}, f64 {kappa} ± {dkappa}",
            fr.curvature
        );
        if P::DIM == 2 {
            // n = t × k̂ = (t.y, −t.x).
            let n_ref = DVec3::new(t_ref.y, -t_ref.x, 0.0);
            prop_assert!((wide(fr.normal) - n_ref).length() <= 2.0 * d1e / l1 + 1e-6);
        } else {
            // Principal normal: the part of C'' orthogonal to the tangent, where it is not small.
            let perp = ref2 - t_ref * ref2.dot(t_ref);
            if perp.length() >= 0.05 * s[2] {
                let n_ref = perp.normalize();
                let bound = 4.0 * (d2e + ref2.length() * 2.0 * d1e / l1) / perp.length() + 1e-6;
                prop_assert!((wide(fr.normal) - n_ref).length() <= bound);
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(testkit::config())]

    /// C, C', C'' of random planar curves (degree 1–5, interior multiplicities up to the
    /// degree, rational or not, arbitrary domains) against the f64 definition and its central
    /// differences, inside a knot span (the curve is C^∞ there).
    #[test]
    fn planar_derivatives_match_central_differences(
        spec in curve_spec(5, 5), pick in 0.0f64..1.0, t in 0.05f64..0.95,
    ) {
        check_derivs::<Vec2>(&spec, pick, t)?;
    }

    #[test]
    fn spatial_derivatives_match_central_differences(
        spec in curve_spec(5, 5), pick in 0.0f64..1.0, t in 0.05f64..0.95,
    ) {
        check_derivs::<Vec3>(&spec, pick, t)?;
    }

    /// Degree 1 rational curves: C'' is not zero (the quotient is not linear), and A4.2 must
    /// still produce it although the basis has no second derivative.
    #[test]
    fn rational_linear_second_derivative(
        a in [-2.0f32..2.0, -2.0f32..2.0, -2.0f32..2.0],
        b in [-2.0f32..2.0, -2.0f32..2.0, -2.0f32..2.0],
        wa in 0.2f32..5.0, wb in 0.2f32..5.0, u in 0.05f64..0.95,
    ) {
        let pts = [from3::<Vec3>(a), from3::<Vec3>(b)];
        let c = CurveBuf::from_cartesian(1, vec![0.0, 0.0, 1.0, 1.0], &pts, Some(&[wa, wb])).unwrap();
        let c = c.view();
        // Closed form: C(u) = A + (B − A) s(u), s = wb u / (wa (1−u) + wb u),
        // s' = wa wb / D², s'' = −2 wa wb (wb − wa) / D³, D = wa (1−u) + wb u.
        let (wa, wb) = (wa as f64, wb as f64);
        let den = wa * (1.0 - u) + wb * u;
        let ba = DVec3::from_array(b.map(|x| x as f64)) - DVec3::from_array(a.map(|x| x as f64));
        let s1 = wa * wb / (den * den);
        let s2 = -2.0 * wa * wb * (wb - wa) / (den * den * den);
        let d = c.derivs(u as f32, 2);
        // Relative to |B − A| times the largest possible |s''| (≤ 2·25·5), 64 ulps.
        let scale = 4.0 * 250.0;
        prop_assert!(rel_err(wide(d.du), ba * s1, scale) <= 64.0 * EPS32);
        prop_assert!(rel_err(wide(d.duu), ba * s2, scale) <= 64.0 * EPS32);
    }
}
