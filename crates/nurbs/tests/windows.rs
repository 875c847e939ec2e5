//! Windows onto a knot vector (`Knots::c0_pieces`, `span_window`): the pieces between C⁰
//! breaks cover the domain, evaluate as the whole patch inside, and at their ends give the
//! one-sided limit from inside, checked against the independent `f64` reference's polynomial
//! of that span (`testkit::basis_in_span`).
#![allow(clippy::unwrap_used)]

use glam::{Vec2, Vec3};
use nurbs::{CurveBuf, SurfaceBuf};
use testkit::{EPS32, RefCurve, RefSurface, Side, wide};

/// A planar "roof": degree 2 with a double (full-multiplicity) knot at 1, so the curve has a
/// corner at its middle control point.
fn roof() -> CurveBuf<Vec2> {
    let pts = [
        Vec2::new(-0.04, 0.08),
        Vec2::new(-0.02, 0.09),
        Vec2::new(0.0, 0.1),
        Vec2::new(0.02, 0.09),
        Vec2::new(0.04, 0.08),
    ];
    CurveBuf::from_cartesian(2, vec![0.0, 0.0, 0.0, 1.0, 1.0, 2.0, 2.0, 2.0], &pts, None).unwrap()
}

#[test]
fn curve_pieces_split_at_full_multiplicity_knots_only() {
    let c = roof();
    let v = c.view();
    let pieces: Vec<_> = v.c0_pieces().collect();
    assert_eq!(pieces.len(), 2);
    assert_eq!(pieces[0].domain(), (0.0, 1.0));
    assert_eq!(pieces[1].domain(), (1.0, 2.0));
    // A simple interior knot of a quadratic is C¹: no break.
    let pts = [Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y];
    let smooth =
        CurveBuf::from_cartesian(2, vec![0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0], &pts, None).unwrap();
    let sv = smooth.view();
    let only: Vec<_> = sv.c0_pieces().collect();
    assert_eq!(only.len(), 1);
    assert_eq!(only[0], sv);
    // Degree 1: every interior knot is a break.
    let poly = CurveBuf::from_cartesian(1, vec![0.0, 0.0, 0.3, 0.7, 1.0, 1.0], &pts, None).unwrap();
    assert_eq!(poly.view().c0_pieces().count(), 3);
}

#[test]
fn curve_pieces_evaluate_one_sided_at_their_ends() {
    let c = roof();
    let v = c.view();
    let r = RefCurve::new(&v);
    let pieces: Vec<_> = v.c0_pieces().collect();
    // Span indices of the two pieces: [0, 1] is span 2, [1, 2] span 4.
    for (piece, span) in pieces.iter().zip([2usize, 4]) {
        let (a, b) = piece.domain();
        for u in [a, 0.5 * (a + b), b] {
            let d = piece.derivs(u, 2);
            let j = r.jet_on(f64::from(u), Side::Span(span));
            // f32 evaluation of a quadratic with coordinates ≤ 0.1 m: a few ε per operation,
            // derivatives scaled by 1/span length (1 here) per order.
            let tol = 16.0 * EPS32 * 0.1;
            assert!((wide(d.point) - j.p).length() <= tol);
            assert!((wide(d.du) - j.d1).length() <= 4.0 * tol);
            assert!((wide(d.duu) - j.d2).length() <= 16.0 * tol);
        }
    }
    // The corner: the two one-sided tangents differ (here by 2·atan(0.5) ≈ 53°).
    let t_left = pieces[0].derivs(1.0, 1).du.normalize();
    let t_right = pieces[1].derivs(1.0, 1).du.normalize();
    let cos = t_left.dot(t_right);
    let expected = (2.0 * 0.5f32.atan()).cos();
    assert!((cos - expected).abs() < 1e-5, "{cos} vs {expected}");
    // Clamping keeps each piece inside its window.
    assert_eq!(pieces[0].point(1.7), pieces[0].point(1.0));
    assert_eq!(pieces[1].point(0.2), pieces[1].point(1.0));
    // The box of a window holds only the control points acting on it.
    let bb = pieces[0].bounding_box();
    assert_eq!(bb.max.x, 0.0);
}

#[test]
fn span_windows_cover_each_span() {
    let c = roof();
    let v = c.view();
    let k = v.knots();
    let spans: Vec<_> = k.span_indices().filter_map(|i| k.span_window(i)).collect();
    assert_eq!(spans.len(), 2);
    assert_eq!(spans[0].domain(), (0.0, 1.0));
    assert!(k.span_window(3).is_none());
}

#[test]
fn surface_pieces_split_along_both_directions() {
    // Bilinear in u with an interior knot (a crease line at u = 0.4), biquadratic-in-v with a
    // double knot at v = 0.5 (another crease line): 2 × 2 pieces.
    let (nu, nv) = (3, 5);
    let rows: Vec<Vec<Vec3>> = (0..nu)
        .map(|i| {
            (0..nv)
                .map(|j| {
                    let (x, y) = (i as f32 * 0.02, j as f32 * 0.01);
                    Vec3::new(x, y, 0.01 * ((i + j) % 2) as f32)
                })
                .collect()
        })
        .collect();
    let s = SurfaceBuf::from_rows(
        (1, 2),
        (
            vec![0.0, 0.0, 0.4, 1.0, 1.0],
            vec![0.0, 0.0, 0.0, 0.5, 0.5, 1.0, 1.0, 1.0],
        ),
        &rows,
        None::<&[Vec<f32>]>,
    )
    .unwrap();
    let view = s.view();
    let r = RefSurface::new(&view);
    let pieces: Vec<_> = view.c0_pieces().collect();
    assert_eq!(pieces.len(), 4);
    let domains: Vec<_> = pieces.iter().map(|p| p.domain()).collect();
    assert_eq!(
        domains,
        vec![
            ((0.0, 0.4), (0.0, 0.5)),
            ((0.0, 0.4), (0.5, 1.0)),
            ((0.4, 1.0), (0.0, 0.5)),
            ((0.4, 1.0), (0.5, 1.0)),
        ]
    );
    // At the shared corner (0.4, 0.5) each piece gives its own one-sided derivatives.
    let spans = [(1, 2), (1, 4), (2, 2), (2, 4)];
    for (piece, (su, sv)) in pieces.iter().zip(spans) {
        let d = piece.derivs(0.4, 0.5, 1);
        let j = r.jet_on(0.4f32 as f64, 0.5, [Side::Span(su), Side::Span(sv)]);
        // Coordinates ≤ 0.05 m, spans ≥ 0.4 long: derivatives ≤ a few 0.1 m; f32 rounding.
        let tol = 32.0 * EPS32 * 0.1;
        assert!((wide(d.point) - j.p).length() <= tol);
        assert!(
            (wide(d.du) - j.su).length() <= 8.0 * tol,
            "{:?} {:?}",
            d.du,
            j.su
        );
        assert!(
            (wide(d.dv) - j.sv).length() <= 8.0 * tol,
            "{:?} {:?}",
            d.dv,
            j.sv
        );
    }
    // The whole surface's box contains every piece's box.
    let whole = view.bounding_box();
    for p in &pieces {
        let b = p.bounding_box();
        assert!(b.min.cmpge(whole.min).all() && b.max.cmple(whole.max).all());
    }
}
