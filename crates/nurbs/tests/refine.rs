//! Knot insertion, splitting, joining and control-point edits, against references that do
//! not come from the code under test: a textbook example worked by hand, the rational circle,
//! closed-form basis functions, and the `f64` evaluation of `testkit`.
//!
//! # Error bound of a refinement
//!
//! Boehm's step forms `Q = α̂·A + (1 − α̂)·B` in `f32`, coordinate by coordinate, from
//! homogeneous points `A`, `B` whose coordinates are at most `M` in magnitude (`M_a` for the
//! weighted coordinates `w·x`, `M_w` for the weights). `α̂ = (u − U_i)/(U_{i+p} − U_i)`
//! carries three roundings (relative ε/2 each), so `|α̂ − α| ≤ 1.5 ε`, which moves `Q` by at
//! most `1.5 ε |A − B| ≤ 3 ε M`; `1 − α̂`, the two products and the sum add at most `2 ε M`:
//! `5 ε M`, taken as `6 ε M` per inserted knot. A convex combination does not amplify
//! earlier errors, so `r` insertions at one place give at most `6 r ε M`. On the curve
//! `C = A/W` (`A = Σ N_i wP_i`, `W = Σ N_i w_i`, the `N_i ≥ 0` summing to 1) errors
//! `|δA| ≤ 6 r ε M_a` and `|δW| ≤ 6 r ε M_w` move `C` by `|δA − C δW| / W
//! ≤ 6 r ε (M_a + M_c M_w) / w_min` (max norm; `M_c` the largest Cartesian coordinate, which
//! bounds `C` by the convex hull property). The comparisons evaluate both curves in `f64`,
//! so this bound is all there is. It is a worst case: the errors measured are far smaller
//! (neighbouring points are close, so `|A − B|` is far below `2M`).
#![allow(clippy::unwrap_used)]

use glam::{DVec3, Vec2, Vec3};
use nurbs::construct;
use nurbs::{CurveBuf, NurbsError, Point, RefineError};
use proptest::prelude::*;
use testkit::{EPS32, RefCurve, curve_spec, wide};

/// `M_a`, `M_w`, `M_c` and the smallest weight of a curve (module docs).
fn magnitudes<P: Point>(c: &CurveBuf<P>) -> (f64, f64, f64, f64) {
    let (mut ma, mut mw, mut mc, mut wmin) = (0.0f64, 0.0f64, 0.0f64, f64::INFINITY);
    for &h in c.points() {
        let (xw, w) = P::split(h);
        let x = xw * (1.0 / w);
        for &v in xw.as_slice() {
            ma = ma.max(f64::from(v.abs()));
        }
        for &v in x.as_slice() {
            mc = mc.max(f64::from(v.abs()));
        }
        mw = mw.max(f64::from(w));
        wmin = wmin.min(f64::from(w));
    }
    (ma, mw, mc, wmin)
}

/// The bound of the module docs for `r` insertions at one place.
fn refine_bound<P: Point>(c: &CurveBuf<P>, r: usize) -> f64 {
    let (ma, mw, mc, wmin) = magnitudes(c);
    6.0 * r as f64 * EPS32 * (ma + mc * mw) / wmin
}

fn max_norm(v: DVec3) -> f64 {
    v.abs().max_element()
}

/// Parameters across the domain, both ends included.
fn params(domain: (f64, f64), n: usize) -> impl Iterator<Item = f64> {
    (0..=n).map(move |i| domain.0 + (domain.1 - domain.0) * i as f64 / n as f64)
}

/// Largest distance (max norm) between two curves over `original`'s domain, both in `f64`.
fn deviation(original: &RefCurve, other: &RefCurve) -> f64 {
    params(original.domain(), 997)
        .map(|u| max_norm(original.point(u) - other.point(u)))
        .fold(0.0, f64::max)
}

/// The Piegl & Tiller example 5.1 (§5.2, Fig. 5.2): the cubic on
/// U = {0,0,0,0,1,2,3,4,5,5,5,5} with u = 5/2 inserted once. u lies in span k = 5
/// ([2, 3)), so Q_0..Q_2 = P_0..P_2, Q_6..Q_8 = P_5..P_7 and, with
/// α_i = (u − u_i)/(u_{i+3} − u_i): α_3 = 5/6, α_4 = 1/2, α_5 = 1/6, and
/// Q_i = α_i P_i + (1 − α_i) P_{i−1}. The book leaves the P_i symbolic; with the points below,
/// by hand:
/// Q_3 = 5/6 (6, 3) + 1/6 (3, 3) = (5.5, 3),
/// Q_4 = 1/2 (7, 0) + 1/2 (6, 3) = (6.5, 1.5),
/// Q_5 = 1/6 (9, −1) + 5/6 (7, 0) = (22/3, −1/6).
#[test]
fn boehm_on_the_nurbs_book_example_5_1() {
    let p = [
        [0.0, 0.0],
        [1.0, 2.0],
        [3.0, 3.0],
        [6.0, 3.0],
        [7.0, 0.0],
        [9.0, -1.0],
        [12.0, 0.0],
        [13.0, 2.0],
    ]
    .map(Vec2::from_array);
    let knots = vec![0.0, 0.0, 0.0, 0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 5.0, 5.0, 5.0];
    let c = CurveBuf::from_cartesian(3, knots, &p, None).unwrap();
    let q = c.insert_knot(2.5).unwrap();
    assert_eq!(
        q.knots(),
        &[
            0.0, 0.0, 0.0, 0.0, 1.0, 2.0, 2.5, 3.0, 4.0, 5.0, 5.0, 5.0, 5.0
        ]
    );
    let expected = [
        p[0],
        p[1],
        p[2],
        Vec2::new(5.5, 3.0),
        Vec2::new(6.5, 1.5),
        Vec2::new(22.0 / 3.0, -1.0 / 6.0),
        p[5],
        p[6],
        p[7],
    ];
    assert_eq!(q.points().len(), expected.len());
    for (i, (h, e)) in q.points().iter().zip(expected).enumerate() {
        // Weights stay 1 exactly (convex combinations of 1 and 1); the points to the bound of
        // the module docs with M = 13 and one insertion: a few ulps of 13.
        assert_eq!(h.z, 1.0, "Q_{i}");
        let err = (h.truncate() - e).abs().max_element();
        assert!(
            f64::from(err) <= 6.0 * EPS32 * 13.0,
            "Q_{i} = {h}, expected {e}"
        );
    }
}

/// Every point of the rational circle stays on it after knot insertion: in the f64
/// evaluation of the refined control points, at the radius to the bound of the module docs
/// (plus the original's own deviation, from rounding its control points to f32).
#[test]
fn knot_insertion_keeps_the_rational_circle_a_circle() {
    let centre = Vec2::new(0.01, 0.09);
    let r = 0.03f32;
    let circle = construct::circle(centre, r).unwrap();
    let reference = RefCurve::new(&circle.view());
    let radius_dev = |c: &RefCurve| {
        params(c.domain(), 1999)
            .map(|u| ((c.point(u) - wide(centre)).length() - f64::from(r)).abs())
            .fold(0.0, f64::max)
    };
    let original_dev = radius_dev(&reference);
    // Between the quarter knots (which are full already: multiplicity 2), next to one, next
    // to a new one, and repeatedly at one place.
    assert!(matches!(
        circle.insert_knot(0.25),
        Err(RefineError::MultiplicityFull {
            multiplicity: 2,
            ..
        })
    ));
    let mut c = circle.clone();
    let mut inserted = 0;
    for u in [0.1, 0.2501, 0.3, 0.6, 0.6001, 0.9] {
        c = c.insert_knot(u).unwrap();
        inserted += 1;
    }
    c = c.insert_knot(0.1).unwrap();
    inserted += 1;
    assert_eq!(c.points().len(), circle.points().len() + inserted);
    let refined = RefCurve::new(&c.view());
    let bound = refine_bound(&circle, inserted);
    let dev = deviation(&reference, &refined);
    assert!(dev <= bound, "moved by {dev:e}, bound {bound:e}");
    let on_circle = radius_dev(&refined);
    assert!(
        on_circle <= original_dev + bound,
        "radius off by {on_circle:e} (original {original_dev:e}, bound {bound:e})"
    );
}

proptest! {
    #![proptest_config(testkit::config())]

    /// Knot insertion anywhere inside the domain leaves any curve where it was.
    #[test]
    fn knot_insertion_leaves_the_shape(spec in curve_spec(4, 4), t in 0.001f64..0.999) {
        let c: CurveBuf<Vec3> = spec.build();
        let (a, b) = c.view().domain();
        let u = (f64::from(a) + (f64::from(b) - f64::from(a)) * t) as f32;
        match c.insert_knot(u) {
            Ok(q) => {
                prop_assert_eq!(q.points().len(), c.points().len() + 1);
                let dev = deviation(&RefCurve::new(&c.view()), &RefCurve::new(&q.view()));
                let bound = refine_bound(&c, 1);
                prop_assert!(dev <= bound, "moved by {:e}, bound {:e}", dev, bound);
            }
            // Refused only where the rules say so: the knot is full, or too close to another.
            Err(RefineError::MultiplicityFull { multiplicity, .. }) => {
                prop_assert_eq!(multiplicity, c.degree());
            }
            Err(RefineError::Invalid(NurbsError::SpanTooShort { .. })) => {}
            Err(e) => prop_assert!(false, "{}", e),
        }
    }

    /// Splitting gives two curves that together are the original and share C(u); joining
    /// them again gives the original back.
    #[test]
    fn split_then_join_reproduces_the_curve(spec in curve_spec(4, 4), t in 0.05f64..0.95) {
        let c: CurveBuf<Vec3> = spec.build();
        let (a, b) = c.view().domain();
        let u = (f64::from(a) + (f64::from(b) - f64::from(a)) * t) as f32;
        let (left, right) = match c.split_at(u) {
            Ok(pieces) => pieces,
            Err(RefineError::Invalid(NurbsError::SpanTooShort { .. })) => return Ok(()),
            Err(e) => return Err(TestCaseError::fail(e.to_string())),
        };
        let (rc, rl, rr) = (
            RefCurve::new(&c.view()),
            RefCurve::new(&left.view()),
            RefCurve::new(&right.view()),
        );
        prop_assert_eq!(rl.domain(), (f64::from(a), f64::from(u)));
        prop_assert_eq!(rr.domain(), (f64::from(u), f64::from(b)));
        let bound = refine_bound(&c, c.degree());
        for piece in [&rl, &rr] {
            let dev = params(piece.domain(), 499)
                .map(|v| max_norm(piece.point(v) - rc.point(v)))
                .fold(0.0, f64::max);
            prop_assert!(dev <= bound, "piece off by {:e}, bound {:e}", dev, bound);
        }
        // Both pieces hold C(u) as a control point: the left's last, the right's first.
        prop_assert_eq!(left.points().last(), right.points().first());
        let cu = rc.point(f64::from(u));
        prop_assert!(max_norm(rl.point(f64::from(u)) - cu) <= bound);
        // The two end points are one control point, but the f32 evaluations that compare them
        // round differently: a tolerance of a few ulps of the [-2, 2] coordinates.
        let joined = left.join(&right, 1e-5).unwrap();
        let dev = deviation(&rc, &RefCurve::new(&joined.view()));
        prop_assert!(dev <= bound, "join(split) off by {:e}, bound {:e}", dev, bound);
        prop_assert_eq!(joined.view().domain(), (a, b));
    }
}

/// The split of the circle at a quarter knot and at a parameter between knots: both pieces on
/// the circle, meeting at C(u).
#[test]
fn split_circle_pieces_stay_on_it() {
    let circle = construct::circle(Vec2::ZERO, 1.0).unwrap();
    let reference = RefCurve::new(&circle.view());
    for u in [0.25, 0.4] {
        let (l, r) = circle.split_at(u).unwrap();
        let bound = refine_bound(&circle, 2);
        for piece in [RefCurve::new(&l.view()), RefCurve::new(&r.view())] {
            for v in params(piece.domain(), 200) {
                let radius = piece.point(v).length();
                assert!(
                    (radius - 1.0).abs() <= bound + 2.0 * EPS32,
                    "u {u}, v {v}: {radius}"
                );
            }
        }
        let shared = RefCurve::new(&l.view()).point(f64::from(u));
        assert!(max_norm(shared - reference.point(f64::from(u))) <= bound);
    }
}

#[test]
fn refused_edits_name_what_is_wrong() {
    let c =
        construct::bezier_curve(&[Vec2::ZERO, Vec2::new(1.0, 1.0), Vec2::new(2.0, 0.0)]).unwrap();
    let e = c.insert_knot(1.5).unwrap_err();
    assert_eq!(
        e,
        RefineError::ParameterOutsideDomain {
            u: 1.5,
            domain: (0.0, 1.0)
        }
    );
    assert_eq!(
        e.to_string(),
        "u: 1.5 is outside the open domain (0, 1) of the patch"
    );
    assert!(matches!(
        c.insert_knot(f32::NAN),
        Err(RefineError::ParameterNotFinite { .. })
    ));
    // The ends are not interior: a split there would leave an empty piece.
    assert!(matches!(
        c.split_at(0.0),
        Err(RefineError::ParameterOutsideDomain { .. })
    ));
    // Twice at 0.5 fills the quadratic's knot; a third would tear it.
    let full = c.insert_knot(0.5).unwrap().insert_knot(0.5).unwrap();
    let e = full.insert_knot(0.5).unwrap_err();
    assert_eq!(
        e,
        RefineError::MultiplicityFull {
            u: 0.5,
            multiplicity: 2
        }
    );
    assert!(e.to_string().starts_with("knots: u = 0.5"), "{e}");
    // A knot a millionth of the domain from another: the span would be too short.
    let e = c
        .insert_knot(0.5)
        .unwrap()
        .insert_knot(0.500_000_5)
        .unwrap_err();
    assert!(
        matches!(e, RefineError::Invalid(NurbsError::SpanTooShort { .. })),
        "{e}"
    );
    assert!(e.to_string().starts_with("knots["), "{e}");

    let line = construct::line(Vec2::new(2.0, 0.0), Vec2::new(3.0, 0.0)).unwrap();
    let e = c.join(&line, 1e-6).unwrap_err();
    assert_eq!(
        e,
        RefineError::DegreeMismatch {
            first: 2,
            second: 1
        }
    );
    assert!(e.to_string().starts_with("degree: "), "{e}");
    let apart = construct::bezier_curve(&[
        Vec2::new(2.0, 0.1),
        Vec2::new(3.0, 1.0),
        Vec2::new(4.0, 0.0),
    ])
    .unwrap();
    let e = c.join(&apart, 1e-3).unwrap_err();
    assert!(
        matches!(e, RefineError::EndsApart { gap, tol } if (gap - 0.1).abs() < 1e-6 && tol == 1e-3),
        "{e:?}"
    );
    assert!(c.join(&apart, f32::NAN).is_err());

    let e = c.with_point(3, Vec2::ZERO).unwrap_err();
    assert_eq!(e, RefineError::PointIndex { index: 3, count: 3 });
    assert_eq!(
        e.to_string(),
        "points[3]: no such control point, the patch has 3"
    );
    for w in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        let e = c.with_weight(1, w).unwrap_err();
        assert!(
            matches!(e, RefineError::Invalid(NurbsError::Weight { .. })),
            "{w}: {e}"
        );
        assert!(e.to_string().starts_with("weights[1]: "), "{e}");
    }
    assert!(matches!(
        c.with_point(1, Vec2::new(f32::NAN, 0.0)),
        Err(RefineError::Invalid(NurbsError::PointNotFinite { .. }))
    ));
}

/// Joining two arcs that meet with different end weights: the second's weights are scaled,
/// and the whole stays on the circle.
#[test]
fn join_scales_the_weights_of_the_second_curve() {
    let a = construct::arc(Vec2::ZERO, Vec2::X, Vec2::Y, 0.0, 1.0).unwrap();
    let b = construct::arc(Vec2::ZERO, Vec2::X, Vec2::Y, 1.0, 1.0).unwrap();
    // Scale all of b's weights by 3: the same curve.
    let scaled: Vec<Vec3> = b.points().iter().map(|&h| h * 3.0).collect();
    let b3 = CurveBuf::new(b.degree(), b.knots().to_vec(), scaled).unwrap();
    let joined = a.join(&b3, 1e-6).unwrap();
    assert_eq!(joined.view().domain(), (0.0, 2.0));
    let r = RefCurve::new(&joined.view());
    for u in params(r.domain(), 400) {
        let radius = r.point(u).length();
        assert!((radius - 1.0).abs() < 1e-6, "{u}: {radius}");
    }
}

/// The uniform quadratic B-spline basis function on the knots {0, 1, 2, 3} in closed form.
fn n_uniform_quadratic(u: f64) -> f64 {
    match u {
        u if (0.0..1.0).contains(&u) => u * u / 2.0,
        u if (1.0..2.0).contains(&u) => (-2.0 * u * u + 6.0 * u - 3.0) / 2.0,
        u if (2.0..=3.0).contains(&u) => (3.0 - u) * (3.0 - u) / 2.0,
        _ => 0.0,
    }
}

/// Moving P_i of a B-spline by Δ moves C(u) by N_{i,p}(u)·Δ (linearity in the control
/// points), and nothing outside the support of N_{i,p}.
#[test]
fn moving_a_control_point_moves_the_curve_by_its_basis_function() {
    let knots = vec![0.0, 0.0, 0.0, 1.0, 2.0, 3.0, 4.0, 4.0, 4.0];
    let pts = [
        [0.0, 0.0],
        [1.0, 1.0],
        [2.0, -1.0],
        [3.0, 1.0],
        [4.0, 0.0],
        [5.0, 0.5],
    ]
    .map(Vec2::from_array);
    let c = CurveBuf::from_cartesian(2, knots, &pts, None).unwrap();
    // N_{2,2} has the knots U_2..U_5 = {0, 1, 2, 3}: the uniform quadratic, support [0, 3].
    let delta = Vec2::new(0.25, -0.5);
    let moved = c.with_point(2, pts[2] + delta).unwrap();
    let (r0, r1) = (RefCurve::new(&c.view()), RefCurve::new(&moved.view()));
    for u in params((0.0, 4.0), 400) {
        let shift = r1.point(u) - r0.point(u);
        let expected = wide(delta) * n_uniform_quadratic(u);
        // The moved point is exact in f32 (0.25 and 0.5 steps of small integers), so only f64
        // evaluation rounding remains.
        assert!(
            max_norm(shift - expected) < 1e-12,
            "{u}: {shift} vs {expected}"
        );
        if u >= 3.0 {
            assert_eq!(shift, DVec3::ZERO, "{u}: outside the support");
        }
    }
    // The f32 evaluation agrees where N vanishes: bit for bit, since the span's points are the
    // same.
    for u in [3.0f32, 3.3, 3.9, 4.0] {
        assert_eq!(c.view().point(u), moved.view().point(u), "{u}");
    }
}

/// Raising w_i pulls C(u) toward P_i: the new point lies on the segment from the old one to
/// P_i (P&T §4.3, eq. 4.2 rearranged as a convex combination), strictly closer wherever
/// N_{i,p}(u) > 0.
#[test]
fn raising_a_weight_pulls_the_curve_toward_its_point() {
    let pts = [
        Vec2::ZERO,
        Vec2::new(1.0, 2.0),
        Vec2::new(3.0, 2.0),
        Vec2::new(4.0, 0.0),
    ];
    let c = construct::bezier_curve(&pts).unwrap();
    let heavy = c.with_weight(1, 3.0).unwrap();
    let light = c.with_weight(1, 0.5).unwrap();
    let (r0, rh, rl) = (
        RefCurve::new(&c.view()),
        RefCurve::new(&heavy.view()),
        RefCurve::new(&light.view()),
    );
    let p1 = wide(pts[1]);
    for u in params((0.0, 1.0), 100).skip(1).take(99) {
        let (old, new) = (r0.point(u), rh.point(u));
        assert!((new - p1).length() < (old - p1).length(), "{u}");
        // Collinear with the old point and P_1.
        let cross = (new - old).cross(p1 - old).length();
        assert!(cross < 1e-12 * (p1 - old).length(), "{u}");
        assert!((rl.point(u) - p1).length() > (old - p1).length(), "{u}");
    }
}
