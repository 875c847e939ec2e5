//! B-spline basis functions and their derivatives, without allocation.

use crate::{MAX_DERIV, MAX_ORDER};

/// The `p + 1` non-zero basis functions `N[span-p..=span],p(u)` (Piegl & Tiller A2.2): the
/// zeroth row of [`ders_basis_funs`]. Entries past `p` are zero.
///
/// They are non-negative and sum to 1 (partition of unity, P&T P2.4), which is what makes a
/// B-spline curve an affine combination of its control points.
///
/// ```
/// use nurbs::{Knots, MAX_ORDER, basis_funs};
///
/// // On the Bézier knots [0,0,0,1,1,1] the Cox–de Boor recurrence (P&T eq. 2.5) gives the
/// // Bernstein polynomials (P&T §1.3): (1 − u)², 2u(1 − u), u².
/// let knots = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
/// let k = Knots::new(&knots, 2, 3)?;
/// let u = 0.3;
/// let mut n = [0.0; MAX_ORDER];
/// basis_funs(&knots, k.find_span(u), u, 2, &mut n);
/// let bernstein = [(1.0 - u) * (1.0 - u), 2.0 * u * (1.0 - u), u * u];
/// // Three levels of the triangle, each a few f32 roundings (ε = 1.2e-7) of values ≤ 1:
/// // 1e-6 absolute is about 8 ε.
/// for j in 0..3 {
///     assert!((n[j] - bernstein[j]).abs() < 1e-6, "N{j} = {}", n[j]);
/// }
/// assert_eq!(&n[3..], &[0.0; MAX_ORDER - 3]);
///
/// // Partition of unity on a non-uniform cubic knot vector, at every span.
/// let knots = [0.0, 0.0, 0.0, 0.0, 0.2, 0.7, 1.0, 1.0, 1.0, 1.0];
/// let k = Knots::new(&knots, 3, 6)?;
/// for u in [0.0, 0.1, 0.2, 0.45, 0.7, 0.99, 1.0] {
///     basis_funs(&knots, k.find_span(u), u, 3, &mut n);
///     let sum: f32 = n.iter().sum();
///     assert!(n.iter().all(|&x| x >= 0.0));
///     // Four terms, each within a few ε of its true value: 1e-6 is about 8 ε.
///     assert!((sum - 1.0).abs() < 1e-6, "sum {sum} at u = {u}");
/// }
/// # Ok::<(), nurbs::NurbsError>(())
/// ```
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
///
/// ```
/// use nurbs::{Knots, MAX_DERIV, MAX_ORDER, ders_basis_funs};
///
/// // Bernstein basis of degree 2 on [0, 1]: (1 − u)², 2u(1 − u), u², whose derivatives are
/// // −2(1 − u), 2 − 4u, 2u and second derivatives 2, −4, 2.
/// let knots = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
/// let k = Knots::new(&knots, 2, 3)?;
/// let u = 0.3;
/// let mut ders = [[0.0; MAX_ORDER]; MAX_DERIV + 1];
/// ders_basis_funs(&knots, k.find_span(u), u, 2, 2, &mut ders);
/// let d1 = [-2.0 * (1.0 - u), 2.0 - 4.0 * u, 2.0 * u];
/// let d2 = [2.0, -4.0, 2.0];
/// // Values of size ≤ 4 after a few f32 roundings each (ε = 1.2e-7): 1e-6 absolute is
/// // about 2 ulp at 4.
/// for j in 0..3 {
///     assert!((ders[1][j] - d1[j]).abs() < 1e-6, "N'{j} = {}", ders[1][j]);
///     assert!((ders[2][j] - d2[j]).abs() < 1e-6, "N''{j} = {}", ders[2][j]);
/// }
/// // The derivatives of a partition of unity sum to 0.
/// assert!(ders[1].iter().sum::<f32>().abs() < 1e-6);
/// assert!(ders[2].iter().sum::<f32>().abs() < 1e-6);
///
/// // Rows past the requested order are zeroed.
/// ders_basis_funs(&knots, k.find_span(u), u, 2, 1, &mut ders);
/// assert_eq!(ders[2], [0.0; MAX_ORDER]);
/// # Ok::<(), nurbs::NurbsError>(())
/// ```
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
