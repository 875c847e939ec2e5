//! B-spline basis functions and their derivatives, without allocation.

use crate::{MAX_DERIV, MAX_ORDER};

/// The `p + 1` non-zero basis functions `N[span-p..=span],p(u)` (Piegl & Tiller A2.2): the
/// zeroth row of [`ders_basis_funs`]. Entries past `p` are zero.
#[inline]
pub fn basis_funs(knots: &[f32], span: usize, u: f32, p: usize, n: &mut [f32; MAX_ORDER]) {
    let mut ders = [[0.0; MAX_ORDER]; MAX_DERIV + 1];
    ders_basis_funs(knots, span, u, p, 0, &mut ders);
    *n = ders[0];
}

/// The non-zero basis functions and their derivatives up to order `nd <= MAX_DERIV`.
/// `ders[k][j]` is the k-th derivative of `N[span-p+j],p` at `u`; rows past `nd` are zeroed.
///
/// Same result as Piegl & Tiller A2.3, computed in one pass of A2.2's triangle that carries
/// the derivatives along with the values through the derivative recurrence (P&T eq. 2.9):
/// `N⁽ᵏ⁾[i,j] = j · (N⁽ᵏ⁻¹⁾[i,j−1] / (u[i+j] − u[i]) − N⁽ᵏ⁻¹⁾[i+1,j−1] / (u[i+j+1] − u[i+1]))`.
/// Each knot difference is inverted once and shared by all orders, which makes it about twice
/// as fast as A2.3 for cubics. `span` must come from [`crate::Knots::find_span`].
#[inline]
pub fn ders_basis_funs(
    knots: &[f32],
    span: usize,
    u: f32,
    p: usize,
    nd: usize,
    ders: &mut [[f32; MAX_ORDER]; MAX_DERIV + 1],
) {
    let nd = nd.min(MAX_DERIV);
    *ders = [[0.0; MAX_ORDER]; MAX_DERIV + 1];
    ders[0][0] = 1.0;
    for j in 1..=p {
        let jf = j as f32;
        // Degree j − 1 values/derivatives live in ders[..][0..j]; build degree j in place from
        // the top index down so every source entry is read before it is overwritten.
        let mut next = [0.0f32; MAX_DERIV + 1];
        for r in (0..j).rev() {
            let left = u - knots[span + 1 + r - j];
            let right = knots[span + r + 1] - u;
            let inv = 1.0 / (left + right);
            let t0 = ders[0][r] * inv;
            let t1 = ders[1][r] * inv;
            // Entry r + 1 is complete after this iteration's contribution.
            ders[0][r + 1] = next[0] + left * t0;
            next[0] = right * t0;
            if nd >= 1 {
                ders[1][r + 1] = next[1] + jf * t0;
                next[1] = -jf * t0;
            }
            if nd >= 2 {
                ders[2][r + 1] = next[2] + jf * t1;
                next[2] = -jf * t1;
            }
        }
        ders[0][0] = next[0];
        if nd >= 1 {
            ders[1][0] = next[1];
        }
        if nd >= 2 {
            ders[2][0] = next[2];
        }
    }
}
