//! Mathematical promises of NURBS (The NURBS Book, §§2.2, 3.2, 4.2) as property tests over
//! random valid curves and surfaces: affine invariance, end-point interpolation, continuity at
//! knots, convex hull (bounding box), totality of evaluation.
#![allow(clippy::unwrap_used)]

use glam::{Mat2, Mat3, Vec2, Vec3, Vec4};
use nurbs::{Aabb, Curve, CurveBuf, NurbsError, Point, SurfaceBuf};
use proptest::prelude::*;
use testkit::{
    CurveSpec, EPS32, curve_spec, from3, interior_knots, min_gap, next_down, rel_err, surface_spec,
    wide,
};

fn mat3() -> impl Strategy<Value = Mat3> {
    proptest::array::uniform9(-2.0f32..2.0).prop_map(|m| Mat3::from_cols_array(&m))
}

fn vec3() -> impl Strategy<Value = Vec3> {
    [-3.0f32..3.0, -3.0f32..3.0, -3.0f32..3.0].prop_map(Vec3::from_array)
}

/// Parameters that must all evaluate to finite values: both ends exactly, just inside them,
/// outside the domain, NaN and infinities (clamped), plus `t` inside.
fn tricky_params(a: f32, b: f32, t: f64) -> [f32; 12] {
    [
        a,
        b,
        next_down(b),
        a + (b - a) * 1e-7,
        ((a as f64 + t * (b as f64 - a as f64)) as f32).min(b),
        a - 1.0,
        b + 1e6,
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::MAX,
        -f32::MAX,
    ]
}

fn pmax_of(spec: &CurveSpec, dim: usize) -> f64 {
    spec.pts
        .iter()
        .map(|p| {
            p[..dim]
                .iter()
                .map(|x| (*x as f64).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .fold(0.0, f64::max)
}

fn check_affine<P: Point>(
    spec: &CurveSpec,
    f: impl Fn(P) -> P,
    scale: f64,
    t: f64,
) -> Result<(), TestCaseError> {
    let c = spec.build::<P>();
    let g = c.map_points(&f).unwrap();
    let (a, b) = c.view().domain();
    for u in [a, b, ((a as f64 + t * (b as f64 - a as f64)) as f32).min(b)] {
        let lhs = wide(g.view().point(u));
        let rhs = wide(f(c.view().point(u)));
        // Both sides round a few ulps of the largest term, |A| |P|max + |t| (bounded by
        // `scale`); the f32 affine map itself adds a few more.
        prop_assert!(
            rel_err(lhs, rhs, scale) <= 64.0 * EPS32,
            "u={u}: {lhs} vs {rhs}"
        );
    }
    Ok(())
}

/// Checks continuity of C and of the derivatives the multiplicity allows across every
/// interior knot: the left limit (evaluated one ulp below the knot, in the left span) equals
/// the value at the knot (right span).
fn check_continuity<P: Point>(spec: &CurveSpec) -> Result<(), TestCaseError> {
    let c = spec.build::<P>();
    let c = c.view();
    let p = spec.p;
    let pmax = pmax_of(spec, P::DIM).max(1e-3);
    let d = p as f64 / min_gap(&spec.knots) * spec.weight_ratio();
    // Rounding: 32 ulps of the derivative scales, as in curves.rs. The one-ulp step between
    // the two evaluations moves the k-th derivative by at most (next scale) × step.
    let s = [pmax, pmax * d, pmax * d * d, pmax * d * d * d];
    for (k, m) in interior_knots(&spec.knots, p) {
        let left = next_down(k);
        let step = (k - left) as f64;
        let dl = c.derivs(left, 2);
        let dr = c.derivs(k, 2);
        let pairs = [(dl.point, dr.point), (dl.du, dr.du), (dl.duu, dr.duu)];
        // C^(p − m) at a knot of multiplicity m (P&T P2.5).
        let smooth = (p - m).min(2);
        for (order, (l, r)) in pairs.iter().enumerate().take(smooth + 1) {
            let tol = 32.0 * EPS32 * s[order] + 2.0 * s[order + 1] * step;
            let e = (wide(*l) - wide(*r)).abs().max_element();
            prop_assert!(
                e <= tol,
                "knot {k} (multiplicity {m}, degree {p}): order {order} jumps by {e} > {tol}"
            );
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(testkit::config())]

    /// Affine invariance: mapping the control points by x ↦ A x + t maps every
    /// curve point the same way, for rational curves too.
    #[test]
    fn curve_affine_invariance(spec in curve_spec(5, 5), m in mat3(), tr in vec3(), t in 0.0f64..1.0) {
        let scale3 = m.to_cols_array().iter().map(|x| x.abs() as f64).sum::<f64>() * pmax_of(&spec, 3) + tr.length() as f64 + 1e-3;
        check_affine::<Vec3>(&spec, |x| m * x + tr, scale3, t)?;
        let m2 = Mat2::from_cols(m.x_axis.truncate(), m.y_axis.truncate());
        let tr2 = tr.truncate();
        let scale2 = m2.to_cols_array().iter().map(|x| x.abs() as f64).sum::<f64>() * pmax_of(&spec, 2) + tr2.length() as f64 + 1e-3;
        check_affine::<Vec2>(&spec, |x| m2 * x + tr2, scale2, t)?;
    }

    #[test]
    fn surface_affine_invariance(spec in surface_spec(4, 4), m in mat3(), tr in vec3(), tu in 0.0f64..1.0, tv in 0.0f64..1.0) {
        let s = spec.build();
        let g = s.map_points(|x| m * x + tr).unwrap();
        let ((u0, u1), (v0, v1)) = s.view().domain();
        let scale = m.to_cols_array().iter().map(|x| x.abs() as f64).sum::<f64>() * spec.pmax() + tr.length() as f64 + 1e-3;
        let u = ((u0 as f64 + tu * (u1 as f64 - u0 as f64)) as f32).min(u1);
        let v = ((v0 as f64 + tv * (v1 as f64 - v0 as f64)) as f32).min(v1);
        for (u, v) in [(u, v), (u0, v1), (u1, v)] {
            let lhs = g.view().point(u, v).as_dvec3();
            let rhs = (m * s.view().point(u, v) + tr).as_dvec3();
            prop_assert!(rel_err(lhs, rhs, scale) <= 64.0 * EPS32, "({u}, {v}): {lhs} vs {rhs}");
        }
    }

    /// Clamped knots interpolate the end control points: C(a) = P0, C(b) = Pn.
    #[test]
    fn curve_end_interpolation(spec in curve_spec(5, 5)) {
        let c = spec.build::<Vec3>();
        let c = c.view();
        let (a, b) = c.domain();
        let n = spec.pts.len() - 1;
        let (p0, _) = c.control_point(0).unwrap();
        let (pn, _) = c.control_point(n).unwrap();
        let pmax = pmax_of(&spec, 3).max(1e-3);
        prop_assert!(rel_err(wide(c.point(a)), wide(p0), pmax) <= 4.0 * EPS32);
        prop_assert!(rel_err(wide(c.point(b)), wide(pn), pmax) <= 4.0 * EPS32);
        // And the input data round-trip through the homogeneous form.
        prop_assert!(rel_err(wide(p0), wide(from3::<Vec3>(spec.pts[0])), pmax) <= 2.0 * EPS32);
    }

    /// The four corners of a surface are its corner control points, and each boundary is the
    /// curve of the boundary row/column of the net.
    #[test]
    fn surface_corners_and_edges(spec in surface_spec(5, 5), t in 0.0f64..=1.0) {
        let s = spec.build();
        let sv = s.view();
        let ((u0, u1), (v0, v1)) = sv.domain();
        let (nu, nv) = sv.counts();
        let pmax = spec.pmax().max(1e-3);
        for (u, v, i, j) in [(u0, v0, 0, 0), (u1, v0, nu - 1, 0), (u0, v1, 0, nv - 1), (u1, v1, nu - 1, nv - 1)] {
            let (p, _) = sv.control_point(i, j).unwrap();
            prop_assert!(rel_err(sv.point(u, v).as_dvec3(), p.as_dvec3(), pmax) <= 4.0 * EPS32, "corner ({i}, {j})");
        }
        // v = v0 edge: the curve with knots U and the column j = 0 of the net.
        let col: Vec<Vec4> = (0..nu).map(|i| sv.points()[i * nv]).collect();
        let edge = Curve::<Vec3>::new(spec.p, &spec.ku, &col).unwrap();
        let u = ((u0 as f64 + t * (u1 as f64 - u0 as f64)) as f32).min(u1);
        prop_assert!(rel_err(sv.point(u, v0).as_dvec3(), edge.point(u).as_dvec3(), pmax) <= 32.0 * EPS32);
        // u = u1 edge: the last row.
        let row = &sv.points()[(nu - 1) * nv..];
        let edge = Curve::<Vec3>::new(spec.q, &spec.kv, row).unwrap();
        let v = ((v0 as f64 + t * (v1 as f64 - v0 as f64)) as f32).min(v1);
        prop_assert!(rel_err(sv.point(u1, v).as_dvec3(), edge.point(v).as_dvec3(), pmax) <= 32.0 * EPS32);
    }

    /// Continuity at interior knots: a knot of multiplicity m leaves the curve C^(p − m), so
    /// the value always, and the first and second derivatives when m ≤ p − 1, p − 2, have equal
    /// left and right limits.
    #[test]
    fn continuity_at_interior_knots(spec in curve_spec(5, 5)) {
        check_continuity::<Vec2>(&spec)?;
        check_continuity::<Vec3>(&spec)?;
    }

    /// Evaluation is total: finite at the exact domain ends, just inside, outside, at NaN and
    /// ±inf; out-of-domain parameters evaluate exactly as their clamped value.
    #[test]
    fn curve_evaluation_is_total(spec in curve_spec(5, 5), t in 0.0f64..1.0) {
        total_curve::<Vec2>(&spec, t)?;
        total_curve::<Vec3>(&spec, t)?;
    }

    #[test]
    fn surface_evaluation_is_total(spec in surface_spec(5, 5), tu in 0.0f64..1.0, tv in 0.0f64..1.0) {
        let s = spec.build();
        let s = s.view();
        let ((u0, u1), (v0, v1)) = s.domain();
        let us = tricky_params(u0, u1, tu);
        let vs = tricky_params(v0, v1, tv);
        for (i, &u) in us.iter().enumerate() {
            // Pair each u with two v's, so all 12 × 12 classes are not needed for coverage.
            for &v in [vs[i], vs[(i + 5) % vs.len()]].iter() {
                let d = s.derivs(u, v, 2);
                let n = s.normal(u, v);
                for x in [d.point, d.du, d.dv, d.duu, d.duv, d.dvv, n] {
                    prop_assert!(x.is_finite(), "S({u}, {v}): {d:?} n = {n}");
                }
                prop_assert!((n.length() - 1.0).abs() <= 1e-6);
                let (uc, vc) = (u.clamp(u0, u1), v.clamp(v0, v1));
                let (uc, vc) = (if u.is_nan() { u0 } else { uc }, if v.is_nan() { v0 } else { vc });
                prop_assert_eq!(s.point(u, v), s.point(uc, vc));
            }
        }
    }

    /// Convex hull property: with positive weights every point lies in the box of
    /// the control points.
    #[test]
    fn bounding_boxes_contain_the_geometry(
        cs in curve_spec(5, 5), ss in surface_spec(4, 4), ts in proptest::collection::vec(0.0f64..=1.0, 8),
    ) {
        let c = cs.build::<Vec3>();
        let c = c.view();
        let bb = c.bounding_box();
        for i in 0..cs.pts.len() {
            prop_assert!(bb.contains(c.control_point(i).unwrap().0));
        }
        let (a, b) = c.domain();
        // Evaluation may round a few ulps of |P|max outside a face the curve touches.
        let slack = 8.0 * EPS32 * pmax_of(&cs, 3).max(1e-3);
        for &t in &ts {
            let u = ((a as f64 + t * (b as f64 - a as f64)) as f32).min(b);
            prop_assert!((bb.distance_squared(c.point(u)) as f64).sqrt() <= slack);
        }
        let s = ss.build();
        let s = s.view();
        let bb = s.bounding_box();
        let ((u0, u1), (v0, v1)) = s.domain();
        let slack = 8.0 * EPS32 * ss.pmax().max(1e-3);
        for w in ts.windows(2) {
            let u = ((u0 as f64 + w[0] * (u1 as f64 - u0 as f64)) as f32).min(u1);
            let v = ((v0 as f64 + w[1] * (v1 as f64 - v0 as f64)) as f32).min(v1);
            prop_assert!((bb.distance_squared(s.point(u, v)) as f64).sqrt() <= slack);
        }
    }

    /// `CurveBuf` and `Curve::new` over the same data are the same curve.
    #[test]
    fn owned_and_borrowed_views_agree(spec in curve_spec(5, 5), t in 0.0f64..=1.0) {
        let buf = spec.build::<Vec2>();
        let borrowed = Curve::<Vec2>::new(spec.p, &spec.knots, buf.points()).unwrap();
        prop_assert_eq!(buf.view(), borrowed);
        let (a, b) = borrowed.domain();
        let u = ((a as f64 + t * (b as f64 - a as f64)) as f32).min(b);
        prop_assert_eq!(buf.view().frame(u), borrowed.frame(u));
        let again = CurveBuf::<Vec2>::new(spec.p, spec.knots.clone(), buf.points().to_vec()).unwrap();
        prop_assert_eq!(again, buf);
    }
}

fn total_curve<P: Point>(spec: &CurveSpec, t: f64) -> Result<(), TestCaseError> {
    let c = spec.build::<P>();
    let c = c.view();
    let (a, b) = c.domain();
    for u in tricky_params(a, b, t) {
        let f = c.frame(u);
        let d = f.derivs;
        for x in [d.point, d.du, d.duu, f.tangent, f.normal] {
            prop_assert!(x.is_finite(), "u = {u}: {f:?}");
        }
        prop_assert!(f.curvature.is_finite());
        prop_assert!((wide(f.tangent).length() - 1.0).abs() <= 1e-6);
        prop_assert!((wide(f.normal).length() - 1.0).abs() <= 1e-6);
        let uc = if u.is_nan() { a } else { u.clamp(a, b) };
        prop_assert_eq!(c.point(u), c.point(uc));
        prop_assert_eq!(c.derivs(u, 2), c.derivs(uc, 2));
    }
    Ok(())
}

#[test]
fn map_points_rejects_non_finite_images() {
    let c = nurbs::construct::line(Vec2::ZERO, Vec2::ONE).unwrap();
    let e = c.map_points(|p| p * f32::NAN).unwrap_err();
    assert!(matches!(e, NurbsError::PointNotFinite { .. }));
    let s = nurbs::construct::bilinear(Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE).unwrap();
    let e = s
        .map_points(|p| p + Vec3::splat(f32::INFINITY))
        .unwrap_err();
    assert!(matches!(e, NurbsError::PointNotFinite { .. }));
    // A legitimate map keeps the structure.
    let moved: SurfaceBuf = s.map_points(|p| p * 2.0).unwrap();
    assert_eq!(moved.counts(), s.counts());
    assert_eq!(moved.knots(), s.knots());
}

#[test]
fn aabb_queries() {
    let b = Aabb {
        min: Vec2::new(-1.0, 0.0),
        max: Vec2::new(2.0, 4.0),
    };
    assert!(b.contains(Vec2::new(0.0, 1.0)));
    assert!(b.contains(Vec2::new(2.0, 4.0)), "closed box");
    assert!(!b.contains(Vec2::new(2.1, 1.0)));
    assert_eq!(b.center(), Vec2::new(0.5, 2.0));
    assert_eq!(b.distance_squared(Vec2::new(0.0, 1.0)), 0.0);
    // (5, 8): 3 to the right, 4 above the corner (2, 4).
    assert_eq!(b.distance_squared(Vec2::new(5.0, 8.0)), 25.0);
    // Farthest corner of the box from (0, 0) is (−1, 4) or (2, 4): 2² + 4² = 20.
    assert_eq!(b.max_distance_squared(Vec2::ZERO), 20.0);
    let g = b.include(Vec2::new(-3.0, 5.0));
    assert_eq!(g.min, Vec2::new(-3.0, 0.0));
    assert_eq!(g.max, Vec2::new(2.0, 5.0));
    let u = b.union(Aabb {
        min: Vec2::new(0.0, -2.0),
        max: Vec2::new(1.0, 1.0),
    });
    assert_eq!(u.min, Vec2::new(-1.0, -2.0));
    assert_eq!(u.max, Vec2::new(2.0, 4.0));
    assert!(Aabb::<Vec2>::from_homogeneous(&[]).is_none());
    let h = [Vec3::new(2.0, 2.0, 2.0), Vec3::new(-3.0, 9.0, 3.0)];
    let hb = Aabb::<Vec2>::from_homogeneous(&h).unwrap();
    assert_eq!(hb.min, Vec2::new(-1.0, 1.0));
    assert_eq!(hb.max, Vec2::new(1.0, 3.0));
}
