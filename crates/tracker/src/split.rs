//! Splitting patches at their corners and creases at load: interior knots of full
//! multiplicity (`nurbs::Knots::c0_pieces`) where the patch actually turns. A rational circle
//! or a surface of revolution has such knots at its quarter points although it is tangent
//! continuous there; those joins are kept, so smooth patches stay whole.

use nurbs::{Curve, Knots, Point, Surface};

/// Unit tangents (normals) closer than this count as equal: the same test as a smooth vertex
/// of a chain (`|t_in × t_out| ≤ 10⁻⁴`, i.e. 0.1 mrad), far above the f32 rounding of a unit
/// vector (≈ 10⁻⁷) and far below any corner a hand can feel.
const SMOOTH_TOL: f32 = 1e-4;

fn same_direction<P: Point>(a: P, b: P) -> bool {
    (a - b).length_squared() <= SMOOTH_TOL * SMOOTH_TOL
}

/// Merges consecutive windows of `knots` whose join `smooth` accepts; calls `emit` with each
/// resulting window, in order.
fn merge<'a>(
    knots: Knots<'a>,
    mut smooth: impl FnMut(Knots<'a>, Knots<'a>) -> bool,
    mut emit: impl FnMut(Knots<'a>),
) {
    let mut current: Option<Knots<'a>> = None;
    for next in knots.c0_pieces() {
        current = match current {
            None => Some(next),
            Some(cur) => match cur.extend_to(next) {
                Some(joined) if smooth(cur, next) => Some(joined),
                _ => {
                    emit(cur);
                    Some(next)
                }
            },
        };
    }
    if let Some(cur) = current {
        emit(cur);
    }
}

/// The pieces of `c` between its corners (C⁰ knots where the one-sided tangents differ).
pub(crate) fn curve_pieces<'a, P: Point>(c: &Curve<'a, P>, mut emit: impl FnMut(Curve<'a, P>)) {
    let smooth = |a: Knots<'a>, b: Knots<'a>| match (c.window(a), c.window(b)) {
        (Some(a), Some(b)) => {
            same_direction(a.frame(a.domain().1).tangent, b.frame(b.domain().0).tangent)
        }
        _ => true,
    };
    merge(c.knots(), smooth, |k| emit(c.window(k).unwrap_or(*c)));
}

/// Samples along a knot line for the crease test.
const LINE_SAMPLES: usize = 5;

/// The pieces of `s` between its creases (C⁰ knot lines where the one-sided normals differ
/// somewhere along the line), `u` pieces outer, `v` pieces inner. At most `MAX_PIECES` pieces
/// along `v` are kept; past that, extras are emitted as `s` itself, so that the caller's
/// count of pieces overflows its capacity too.
pub(crate) fn surface_pieces<'a, const MAX_PIECES: usize>(
    s: &Surface<'a>,
    mut emit: impl FnMut(Surface<'a>),
) {
    let (ku, kv) = s.knots();
    // A u break is smooth when the normals of the two sides agree along the line.
    let smooth_u = |a: Knots<'a>, b: Knots<'a>| match (s.window(a, kv), s.window(b, kv)) {
        (Some(sa), Some(sb)) => {
            let u = a.domain().1;
            let (v0, v1) = kv.domain();
            (0..LINE_SAMPLES).all(|k| {
                let v = v0 + (v1 - v0) * k as f32 / (LINE_SAMPLES - 1) as f32;
                same_direction(sa.normal(u, v), sb.normal(u, v))
            })
        }
        _ => true,
    };
    let smooth_v = |a: Knots<'a>, b: Knots<'a>| match (s.window(ku, a), s.window(ku, b)) {
        (Some(sa), Some(sb)) => {
            let v = a.domain().1;
            let (u0, u1) = ku.domain();
            (0..LINE_SAMPLES).all(|k| {
                let u = u0 + (u1 - u0) * k as f32 / (LINE_SAMPLES - 1) as f32;
                same_direction(sa.normal(u, v), sb.normal(u, v))
            })
        }
        _ => true,
    };
    let mut vs = [kv; MAX_PIECES];
    let mut n_v = 0;
    merge(kv, smooth_v, |k| {
        if n_v < MAX_PIECES {
            vs[n_v] = k;
        }
        n_v += 1;
    });
    merge(ku, smooth_u, |wu| {
        for &wv in &vs[..n_v.min(MAX_PIECES)] {
            emit(s.window(wu, wv).unwrap_or(*s));
        }
        // More v pieces than fit: emit extras so that the caller's count overflows too.
        for _ in MAX_PIECES..n_v {
            emit(*s);
        }
    });
}
