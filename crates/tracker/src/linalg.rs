//! The few linear-algebra operations the trackers need, for `N = 1` (curves) and `N = 2`
//! (surfaces) parameters, written once for both.

/// `a` (symmetric `N×N`, N ≤ 2) solved against `b`; `None` when `a` is singular or not
/// positive definite within `rel_tol` of its scale.
#[inline]
pub(crate) fn solve_spd<const N: usize>(
    a: [[f32; N]; N],
    b: [f32; N],
    rel_tol: f32,
) -> Option<[f32; N]> {
    let mut x = [0.0; N];
    match N {
        1 => {
            let d = a[0][0];
            // Written so that NaN also fails.
            let positive = d > rel_tol * d.abs() && d > f32::MIN_POSITIVE;
            if !positive {
                return None;
            }
            x[0] = b[0] / d;
        }
        2 => {
            let (p, q, r) = (a[0][0], a[0][1], a[1][1]);
            let det = p * r - q * q;
            let scale = p * r + q * q;
            let positive = p > 0.0 && det > rel_tol * scale && det > f32::MIN_POSITIVE;
            if !positive {
                return None;
            }
            let inv = 1.0 / det;
            x[0] = (r * b[0] - q * b[1]) * inv;
            x[1] = (p * b[1] - q * b[0]) * inv;
        }
        _ => return None,
    }
    if x.iter().all(|v| v.is_finite()) {
        Some(x)
    } else {
        None
    }
}

/// Trace of an `N×N` matrix: an upper bound on the largest eigenvalue of a positive
/// semi-definite one (and equal to it for N = 1).
#[inline]
pub(crate) fn trace<const N: usize>(a: &[[f32; N]; N]) -> f32 {
    let mut t = 0.0;
    for (i, row) in a.iter().enumerate() {
        t += row[i];
    }
    t
}

/// `Σ x_i²`.
#[inline]
pub(crate) fn norm2<const N: usize>(x: &[f32; N]) -> f32 {
    x.iter().map(|v| v * v).sum()
}

/// `s·I`.
#[inline]
pub(crate) fn scaled_identity<const N: usize>(s: f32) -> [[f32; N]; N] {
    let mut m = [[0.0; N]; N];
    for (i, row) in m.iter_mut().enumerate() {
        row[i] = s;
    }
    m
}

/// `s·A`.
#[inline]
pub(crate) fn scale<const N: usize>(a: &[[f32; N]; N], s: f32) -> [[f32; N]; N] {
    let mut m = *a;
    for row in m.iter_mut() {
        for v in row.iter_mut() {
            *v *= s;
        }
    }
    m
}

/// `A x`.
#[inline]
pub(crate) fn mat_vec<const N: usize>(a: &[[f32; N]; N], x: &[f32; N]) -> [f32; N] {
    let mut y = [0.0; N];
    for i in 0..N {
        for j in 0..N {
            y[i] += a[i][j] * x[j];
        }
    }
    y
}

/// `G⁻¹` of a symmetric positive semi-definite `G`, with Levenberg–Marquardt damping
/// `λ = 10⁻³ trace(G)` added to the diagonal where `G` is singular (a degenerate
/// parametrisation such as a pole): steps then go along the directions that still move the
/// point.
#[inline]
pub(crate) fn regularized_inverse<const N: usize>(g: &[[f32; N]; N]) -> [[f32; N]; N] {
    if let Some(inv) = inverse_spd(g, 1e-6) {
        return inv;
    }
    let lambda = 1e-3 * nurbs::math::max(f32::MIN_POSITIVE, trace(g));
    let mut gr = *g;
    for (i, row) in gr.iter_mut().enumerate() {
        row[i] += lambda;
    }
    inverse_spd(&gr, 0.0).unwrap_or([[0.0; N]; N])
}

/// Inverse of a symmetric positive definite `N×N` matrix (N ≤ 2), `None` when singular
/// within `rel_tol`.
#[inline]
pub(crate) fn inverse_spd<const N: usize>(
    a: &[[f32; N]; N],
    rel_tol: f32,
) -> Option<[[f32; N]; N]> {
    let mut inv = [[0.0; N]; N];
    for i in 0..N {
        let mut e = [0.0; N];
        e[i] = 1.0;
        let col = solve_spd(*a, e, rel_tol)?;
        for j in 0..N {
            inv[j][i] = col[j];
        }
    }
    Some(inv)
}

/// Largest eigenvalue of `M H` for symmetric `M` (positive semi-definite) and symmetric `H`:
/// the eigenvalues are real, `tr/2 ± √(tr²/4 − det)`.
#[inline]
pub(crate) fn max_eigenvalue_product<const N: usize>(m: &[[f32; N]; N], h: &[[f32; N]; N]) -> f32 {
    let mut mh = [[0.0; N]; N];
    for i in 0..N {
        for j in 0..N {
            for k in 0..N {
                mh[i][j] += m[i][k] * h[k][j];
            }
        }
    }
    match N {
        1 => mh[0][0],
        2 => {
            let tr = mh[0][0] + mh[1][1];
            let det = mh[0][0] * mh[1][1] - mh[0][1] * mh[1][0];
            let disc = nurbs::math::max(0.0, 0.25 * tr * tr - det);
            0.5 * tr + nurbs::math::sqrt(disc)
        }
        _ => 0.0,
    }
}
