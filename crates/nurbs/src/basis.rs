//! B-spline basis functions and their derivatives, without allocation.

use crate::{MAX_DERIV, MAX_ORDER};

/// The `p + 1` non-zero basis functions `N[span-p..=span],p(u)` (Piegl & Tiller A2.2).
///
/// `span` must come from [`crate::Knots::find_span`] for the same `u`, `knots` and `p`.
/// Entries past `p` are left untouched.
#[inline]
pub fn basis_funs(knots: &[f32], span: usize, u: f32, p: usize, n: &mut [f32; MAX_ORDER]) {
    let mut left = [0.0f32; MAX_ORDER];
    let mut right = [0.0f32; MAX_ORDER];
    n[0] = 1.0;
    for j in 1..=p {
        left[j] = u - knots[span + 1 - j];
        right[j] = knots[span + j] - u;
        let mut saved = 0.0;
        for r in 0..j {
            let temp = n[r] / (right[r + 1] + left[j - r]);
            n[r] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        n[j] = saved;
    }
}

/// The non-zero basis functions and their derivatives up to order `nd <= MAX_DERIV`
/// (Piegl & Tiller A2.3). `ders[k][j]` is the k-th derivative of `N[span-p+j],p` at `u`.
/// Rows past `nd` are zeroed.
#[inline]
pub fn ders_basis_funs(
    knots: &[f32],
    span: usize,
    u: f32,
    p: usize,
    nd: usize,
    ders: &mut [[f32; MAX_ORDER]; MAX_DERIV + 1],
) {
    let nd = nd.min(MAX_DERIV).min(p);
    let mut ndu = [[0.0f32; MAX_ORDER]; MAX_ORDER];
    let mut left = [0.0f32; MAX_ORDER];
    let mut right = [0.0f32; MAX_ORDER];
    ndu[0][0] = 1.0;
    for j in 1..=p {
        left[j] = u - knots[span + 1 - j];
        right[j] = knots[span + j] - u;
        let mut saved = 0.0;
        for r in 0..j {
            // Lower triangle: knot differences; upper triangle: basis functions.
            ndu[j][r] = right[r + 1] + left[j - r];
            let temp = ndu[r][j - 1] / ndu[j][r];
            ndu[r][j] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        ndu[j][j] = saved;
    }
    for row in ders.iter_mut() {
        *row = [0.0; MAX_ORDER];
    }
    for j in 0..=p {
        ders[0][j] = ndu[j][p];
    }
    // A2.3's coefficient table, two alternating rows.
    let mut a = [[0.0f32; MAX_ORDER]; 2];
    for r in 0..=p {
        let (mut s1, mut s2) = (0usize, 1usize);
        a[0][0] = 1.0;
        for k in 1..=nd {
            let mut d = 0.0;
            let rk = r as isize - k as isize;
            let pk = p - k;
            if rk >= 0 {
                let rk = rk as usize;
                a[s2][0] = a[s1][0] / ndu[pk + 1][rk];
                d = a[s2][0] * ndu[rk][pk];
            }
            let j1 = if rk >= -1 { 1 } else { (-rk) as usize };
            let j2 = if r <= pk + 1 { k - 1 } else { p - r };
            for j in j1..=j2 {
                let idx = (rk + j as isize) as usize;
                a[s2][j] = (a[s1][j] - a[s1][j - 1]) / ndu[pk + 1][idx];
                d += a[s2][j] * ndu[idx][pk];
            }
            if r <= pk {
                a[s2][k] = -a[s1][k - 1] / ndu[pk + 1][r];
                d += a[s2][k] * ndu[r][pk];
            }
            ders[k][r] = d;
            core::mem::swap(&mut s1, &mut s2);
        }
    }
    let mut factor = p as f32;
    for k in 1..=nd {
        for d in ders[k].iter_mut().take(p + 1) {
            *d *= factor;
        }
        factor *= (p - k) as f32;
    }
}
