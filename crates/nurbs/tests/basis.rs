//! Basis functions and span search against worked examples of The NURBS Book (Piegl & Tiller,
//! 2nd ed.), Bernstein polynomials, and the Cox–de Boor definition in `f64`.
#![allow(clippy::unwrap_used)]

use nurbs::{Knots, MAX_DEGREE, MAX_DERIV, MAX_ORDER, basis_funs, ders_basis_funs};
use proptest::prelude::*;
use testkit::{EPS32, all_basis, basis, knots_strategy, widen};

/// Ex2.2 / Ex2.3: U = {0,0,0,1,2,3,4,4,5,5,5}, p = 2, eight basis functions.
const EX_U: [f32; 11] = [0., 0., 0., 1., 2., 3., 4., 4., 5., 5., 5.];

/// The book's closed forms of Ex2.2, one quadratic `c0 + c1 u + c2 u²` per function and span
/// `[s, s+1)`: `(function, span start, [c0, c1, c2])`. Written out from the printed formulas,
/// e.g. N_{3,2} = ½(u−1)² on [1,2), −11/2 + 5u − u² on [2,3), ½(4−u)² on [3,4).
const EX_PIECES: [(usize, f64, [f64; 3]); 15] = [
    (0, 0.0, [1.0, -2.0, 1.0]),    // (1−u)²
    (1, 0.0, [0.0, 2.0, -1.5]),    // 2u − 3/2 u²
    (1, 1.0, [2.0, -2.0, 0.5]),    // ½(2−u)²
    (2, 0.0, [0.0, 0.0, 0.5]),     // ½u²
    (2, 1.0, [-1.5, 3.0, -1.0]),   // −3/2 + 3u − u²
    (2, 2.0, [4.5, -3.0, 0.5]),    // ½(3−u)²
    (3, 1.0, [0.5, -1.0, 0.5]),    // ½(u−1)²
    (3, 2.0, [-5.5, 5.0, -1.0]),   // −11/2 + 5u − u²
    (3, 3.0, [8.0, -4.0, 0.5]),    // ½(4−u)²
    (4, 2.0, [2.0, -2.0, 0.5]),    // ½(u−2)²
    (4, 3.0, [-16.0, 10.0, -1.5]), // −16 + 10u − 3/2 u²
    (5, 3.0, [9.0, -6.0, 1.0]),    // (u−3)²
    (5, 4.0, [25.0, -10.0, 1.0]),  // (5−u)²
    (6, 4.0, [-40.0, 18.0, -2.0]), // 2(u−4)(5−u)
    (7, 4.0, [16.0, -8.0, 1.0]),   // (u−4)²
];

/// `[value, first, second derivative]` of `N_{i,2}` of Ex2.2 at `u`, from the closed forms.
fn ex_closed_form(i: usize, u: f64) -> [f64; 3] {
    // Span [s, s+1) containing u; u = 5 belongs to [4, 5].
    let s = u.floor().min(4.0);
    let mut out = [0.0; 3];
    for &(f, start, c) in &EX_PIECES {
        if f == i && start == s {
            out = [
                c[0] + c[1] * u + c[2] * u * u,
                c[1] + 2.0 * c[2] * u,
                2.0 * c[2],
            ];
        }
    }
    out
}

#[test]
fn ex2_3_basis_at_five_halves() {
    let k = Knots::new(&EX_U, 2, 8).unwrap();
    let u = 2.5;
    let span = k.find_span(u);
    assert_eq!(span, 4, "Ex2.3: u = 5/2 lies in [u4, u5) = [2, 3)");

    let mut n = [0.0; MAX_ORDER];
    basis_funs(&EX_U, span, u, 2, &mut n);
    // N_{2,2} = 1/8, N_{3,2} = 6/8, N_{4,2} = 1/8. These are dyadic rationals and the
    // algorithm's operations on u = 2.5 are exact in binary, but allow a few ulps anyway.
    let expected = [1.0 / 8.0, 6.0 / 8.0, 1.0 / 8.0];
    for j in 0..3 {
        assert!(
            (n[j] - expected[j]).abs() <= 4.0 * f32::EPSILON,
            "N[{j}] = {}",
            n[j]
        );
    }

    let mut d = [[0.0; MAX_ORDER]; MAX_DERIV + 1];
    ders_basis_funs(&EX_U, span, u, 2, 2, &mut d);
    // The book's derivative example at the same u: N'_{2,2} = −1/2, N'_{3,2} = 0, N'_{4,2} = 1/2; second derivatives from the
    // closed forms ½(3−u)², −11/2 + 5u − u², ½(u−2)²: 1, −2, 1.
    let expected = [
        [1.0 / 8.0, 6.0 / 8.0, 1.0 / 8.0],
        [-0.5, 0.0, 0.5],
        [1.0, -2.0, 1.0],
    ];
    for k in 0..3 {
        for j in 0..3 {
            assert!(
                (d[k][j] - expected[k][j]).abs() <= 8.0 * f32::EPSILON,
                "ders[{k}][{j}] = {}, book {}",
                d[k][j],
                expected[k][j]
            );
        }
    }
}

#[test]
fn ex2_2_closed_forms_everywhere() {
    let k = Knots::new(&EX_U, 2, 8).unwrap();
    // 1001 samples over [0, 5], including every knot and both ends.
    for s in 0..=1000 {
        let u = s as f32 * 0.005;
        let span = k.find_span(u);
        let mut d = [[0.0; MAX_ORDER]; MAX_DERIV + 1];
        ders_basis_funs(&EX_U, span, u, 2, 2, &mut d);
        let mut n = [0.0; MAX_ORDER];
        basis_funs(&EX_U, span, u, 2, &mut n);
        for i in 0..8 {
            let exact = ex_closed_form(i, u as f64);
            let (val, der) = if i + 2 >= span && i <= span {
                let j = i + 2 - span;
                (
                    [n[j] as f64, d[1][j] as f64, d[2][j] as f64],
                    d[0][j] as f64,
                )
            } else {
                ([0.0; 3], 0.0)
            };
            // Values are at most 1 and slopes at most 2 (and second derivatives at most 4)
            // here; the f32 recursion loses a few ulps per level.
            for o in 0..3 {
                assert!(
                    (val[o] - exact[o]).abs() <= 1e-6 * (1 + 2 * o) as f64,
                    "u = {u}, N_{i},2 order {o}: {} vs book {}",
                    val[o],
                    exact[o]
                );
            }
            assert!((der - exact[0]).abs() <= 1e-6, "ders row 0 at u = {u}");
        }
    }
}

#[test]
fn find_span_book_example_and_ends() {
    let k = Knots::new(&EX_U, 2, 8).unwrap();
    // A2.1 returns i with u_i <= u < u_{i+1}.
    assert_eq!(k.find_span(0.0), 2);
    assert_eq!(k.find_span(0.5), 2);
    assert_eq!(k.find_span(1.0), 3);
    assert_eq!(k.find_span(2.5), 4);
    assert_eq!(k.find_span(3.999), 5);
    // The double knot u6 = u7 = 4: span [u7, u8) = [4, 5).
    assert_eq!(k.find_span(4.0), 7);
    // u = u_max: the last non-empty span, n = m − p − 1 = 10 − 2 − 1 = 7.
    assert_eq!(k.find_span(5.0), 7);
    // Out of the domain: clamped.
    assert_eq!(k.find_span(-1.0), 2);
    assert_eq!(k.find_span(7.0), 7);
    assert_eq!(k.find_span(f32::NAN), 2);
    assert_eq!(k.find_span(f32::INFINITY), 7);
    assert_eq!(k.find_span(f32::NEG_INFINITY), 2);
}

#[test]
fn knots_accessors() {
    let k = Knots::new(&EX_U, 2, 8).unwrap();
    assert_eq!(k.degree(), 2);
    assert_eq!(k.n_points(), 8);
    assert_eq!(k.domain(), (0.0, 5.0));
    assert_eq!(k.domain_len(), 5.0);
    assert_eq!(k.as_slice(), &EX_U);
    assert!(k.contains(0.0) && k.contains(5.0) && k.contains(2.0));
    assert!(!k.contains(-0.1) && !k.contains(5.1) && !k.contains(f32::NAN));
    assert_eq!(k.clamp(-3.0), 0.0);
    assert_eq!(k.clamp(9.0), 5.0);
    assert_eq!(k.clamp(1.25), 1.25);
    assert_eq!(k.clamp(f32::NAN), 0.0);
    assert_eq!(k.clamp(f32::INFINITY), 5.0);
    assert_eq!(k.clamp(f32::NEG_INFINITY), 0.0);
}

fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

/// Bernstein polynomial `B_{i,n}(t)` (eq. 1.8), 0 outside `0..=n`.
fn bernstein(n: usize, i: isize, t: f64) -> f64 {
    if i < 0 || i as usize > n {
        return 0.0;
    }
    let i = i as usize;
    binomial(n, i) * t.powi(i as i32) * (1.0 - t).powi((n - i) as i32)
}

/// On a Bézier knot vector over `[a, b]` the B-spline basis is the Bernstein basis in
/// `t = (u − a) / (b − a)` (P&T §2.2). Derivatives from eq. 1.9:
/// `B'_{i,n} = n (B_{i−1,n−1} − B_{i,n−1})`, times `1/(b − a)` per order.
#[test]
fn bezier_knots_give_bernstein_basis_all_degrees() {
    let (a, b) = (-3.0f32, 7.0f32);
    for p in 1..=MAX_DEGREE {
        let mut knots = vec![a; p + 1];
        knots.extend(vec![b; p + 1]);
        let k = Knots::new(&knots, p, p + 1).unwrap();
        for s in 0..=64 {
            let u = a + (b - a) * s as f32 / 64.0;
            let t = (u - a) as f64 / (b - a) as f64;
            let span = k.find_span(u);
            assert_eq!(span, p);
            let mut d = [[0.0; MAX_ORDER]; MAX_DERIV + 1];
            ders_basis_funs(&knots, span, u, p, 2, &mut d);
            let len = (b - a) as f64;
            for i in 0..=p {
                let ii = i as isize;
                let b0 = bernstein(p, ii, t);
                let b1 = p as f64 * (bernstein(p - 1, ii - 1, t) - bernstein(p - 1, ii, t)) / len;
                let b2 = if p >= 2 {
                    (p * (p - 1)) as f64
                        * (bernstein(p - 2, ii - 2, t) - 2.0 * bernstein(p - 2, ii - 1, t)
                            + bernstein(p - 2, ii, t))
                        / (len * len)
                } else {
                    0.0
                };
                // |B| <= 1, |B'| <= 2p/len, |B''| <= 4p²/len²; allow 64 ulps of each scale.
                let tol = 64.0 * EPS32;
                assert!((d[0][i] as f64 - b0).abs() <= tol, "p={p} i={i} t={t}");
                assert!(
                    (d[1][i] as f64 - b1).abs() <= tol * 2.0 * p as f64 / len,
                    "p={p} i={i} t={t}: {} vs {b1}",
                    d[1][i]
                );
                assert!(
                    (d[2][i] as f64 - b2).abs() <= tol * 4.0 * (p * p) as f64 / (len * len),
                    "p={p} i={i} t={t}: {} vs {b2}",
                    d[2][i]
                );
            }
        }
    }
}

/// Rows above the requested order, and above the degree, are zero (a degree-1 basis has no
/// second derivative).
#[test]
fn ders_rows_past_order_are_zero() {
    let knots = [0.0f32, 0.0, 0.5, 1.0, 1.0];
    let mut d = [[7.0; MAX_ORDER]; MAX_DERIV + 1];
    ders_basis_funs(&knots, 1, 0.25, 1, 2, &mut d);
    assert_eq!(d[2], [0.0; MAX_ORDER]);
    // Hat functions on [0, 0.5): N_0 = 1 − 2u, N_1 = 2u; slopes −2 and 2.
    assert_eq!(&d[0][..2], &[0.5, 0.5]);
    assert_eq!(&d[1][..2], &[-2.0, 2.0]);

    let mut d = [[7.0; MAX_ORDER]; MAX_DERIV + 1];
    ders_basis_funs(&EX_U, 4, 2.5, 2, 0, &mut d);
    assert_eq!(d[1], [0.0; MAX_ORDER]);
    assert_eq!(d[2], [0.0; MAX_ORDER]);
}

/// Degree, knot vector and a parameter: a domain end, a knot value (interior knots are where
/// span selection matters) or an arbitrary point.
fn basis_case() -> impl Strategy<Value = (usize, Vec<f32>, f32)> {
    (1..=5usize)
        .prop_flat_map(|p| (Just(p), knots_strategy(p, 5, p), 0..4u8, 0.0f64..1.0))
        .prop_map(|(p, k, mode, t)| {
            let (a, b) = (k[0], k[k.len() - 1]);
            let u = match mode {
                0 => a,
                1 => b,
                2 => k[((t * k.len() as f64) as usize).min(k.len() - 1)],
                _ => ((a as f64 + t * (b as f64 - a as f64)) as f32).min(b),
            };
            (p, k, u)
        })
}

proptest! {
    #![proptest_config(testkit::config())]

    /// Partition of unity and non-negativity (P&T P2.4, P2.3) for `basis_funs` and row 0 of
    /// `ders_basis_funs`; derivative rows sum to zero (derivative of the constant 1). Every
    /// value also matches the Cox–de Boor definition evaluated in f64.
    #[test]
    fn partition_of_unity_and_definition((p, knots, u) in basis_case()) {
        let n = knots.len() - p - 1;
        let k = Knots::new(&knots, p, n).unwrap();
        let b = k.domain().1;
        let span = k.find_span(u);
        prop_assert!(span >= p && span < n);
        prop_assert!(knots[span] <= u && (u < knots[span + 1] || (u == b && knots[span] < b)));

        let mut nf = [0.0; MAX_ORDER];
        basis_funs(&knots, span, u, p, &mut nf);
        let mut d = [[0.0; MAX_ORDER]; MAX_DERIV + 1];
        ders_basis_funs(&knots, span, u, p, 2, &mut d);

        let sum: f64 = nf[..=p].iter().map(|&x| x as f64).sum();
        let sum0: f64 = d[0][..=p].iter().map(|&x| x as f64).sum();
        // Each of the p levels of the recursion rounds every entry once or twice.
        prop_assert!((sum - 1.0).abs() <= 4.0 * (p + 1) as f64 * EPS32, "sum = {sum}");
        prop_assert!((sum0 - 1.0).abs() <= 4.0 * (p + 1) as f64 * EPS32, "sum0 = {sum0}");
        prop_assert!(nf[..=p].iter().all(|&x| x >= 0.0));
        prop_assert!(d[0][..=p].iter().all(|&x| x >= 0.0));

        // Derivative rows: N^(k) is bounded by (2p / gap)^k, the natural scale of the
        // rounding errors.
        let gap = testkit::min_gap(&knots);
        let kw = widen(&knots);
        let reference = [
            all_basis(&kw, p, u as f64, 0),
            all_basis(&kw, p, u as f64, 1),
            all_basis(&kw, p, u as f64, 2),
        ];
        for order in 0..=2 {
            let scale = (2.0 * p as f64 / gap).powi(order as i32);
            let tol = 64.0 * (p + 1) as f64 * EPS32 * scale;
            if order > 0 {
                let s: f64 = d[order][..=p].iter().map(|&x| x as f64).sum();
                prop_assert!(s.abs() <= tol, "row {order} sums to {s}");
            }
            for i in 0..n {
                let code = if i + p >= span && i <= span {
                    d[order][i + p - span] as f64
                } else {
                    0.0
                };
                let want = if order > p { 0.0 } else { reference[order][i] };
                prop_assert!(
                    (code - want).abs() <= tol,
                    "N^({order})_{i},{p}({u}) = {code}, definition {want}"
                );
            }
        }
        for j in 0..=p {
            prop_assert!((nf[j] - d[0][j]).abs() <= 2.0 * f32::EPSILON);
        }
    }

    /// The basis derivatives agree with central differences of the f64 definition inside a
    /// span (where the basis is a polynomial).
    #[test]
    fn basis_derivatives_match_finite_differences(
        (p, knots, _) in basis_case(), pick in 0.0f64..1.0, t in 0.05f64..0.95,
    ) {
        let n = knots.len() - p - 1;
        let k = Knots::new(&knots, p, n).unwrap();
        let (u, len) = testkit::in_span(&knots, pick, t);
        let span = k.find_span(u);
        let mut d = [[0.0; MAX_ORDER]; MAX_DERIV + 1];
        ders_basis_funs(&knots, span, u, p, 2, &mut d);
        let kw = widen(&knots);
        let uf = u as f64;
        // h = 1e-4 of the span: the stencil stays inside it (u is at least 5% from its ends),
        // truncation h²|N'''|/6 and f64 rounding eps/h² are both < 1e-7 of the scale below.
        let h = 1e-4 * len;
        let gap = testkit::min_gap(&knots);
        for j in 0..=p {
            let i = span - p + j;
            let f = |x: f64| basis(&kw, p, i, x, 0);
            let d1 = (f(uf + h) - f(uf - h)) / (2.0 * h);
            let d2 = (f(uf + h) - 2.0 * f(uf) + f(uf - h)) / (h * h);
            let s1 = 2.0 * p as f64 / gap;
            prop_assert!((d[1][j] as f64 - d1).abs() <= 1e-5 * s1, "N'_{i}: {} vs {d1}", d[1][j]);
            if p >= 2 {
                prop_assert!(
                    (d[2][j] as f64 - d2).abs() <= 1e-5 * s1 * s1,
                    "N''_{i}: {} vs {d2}", d[2][j]
                );
            }
        }
    }

    /// A2.1's span satisfies u_span <= u < u_span+1 for any u inside the domain, and it is a
    /// non-empty span.
    #[test]
    fn find_span_brackets_u((p, knots, u) in basis_case()) {
        let n = knots.len() - p - 1;
        let k = Knots::new(&knots, p, n).unwrap();
        let b = k.domain().1;
        let s = k.find_span(u);
        prop_assert!(knots[s] < knots[s + 1]);
        if u < b {
            prop_assert!(knots[s] <= u && u < knots[s + 1]);
        } else {
            prop_assert_eq!(s, n - 1);
        }
    }
}
