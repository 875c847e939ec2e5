//! The rest shape of a patch with frozen weights: its rational basis functions `R_k` and their
//! derivatives up to order 2 at any parameter, and Gauss–Legendre quadrature over its knot
//! spans. With the weights frozen a point of the patch is `x(u) = Σ R_k(u) p_k`, linear in
//! the control points, so the Jacobian of D-NURBS (thesis eq. 4.5) is `J = [R_0 I, R_1 I, …]`
//! and every matrix is a scalar matrix times the identity of the space.

use nurbs::{
    CurveBuf, Knots, MAX_DERIV, MAX_ORDER, Point, SurfaceBuf, Vec2, Vec3, ders_basis_funs,
};

/// The basis functions of a patch's control points around one parameter: `index[m]` is the
/// control point, `r[m]` its `R`, and the derivatives `[∂u, ∂v]`, `[∂uu, ∂uv, ∂vv]`.
#[derive(Clone, Debug, Default)]
pub struct Local {
    /// Control point indices.
    pub index: Vec<usize>,
    /// `R_k`.
    pub r: Vec<f64>,
    /// `(∂R/∂u, ∂R/∂v)` (`∂v = 0` on curves).
    pub d1: Vec<[f64; 2]>,
    /// `(∂²R/∂u², ∂²R/∂u∂v, ∂²R/∂v²)`.
    pub d2: Vec<[f64; 3]>,
    /// The unnormalised `N w` and its derivatives (a buffer of [`Shape::eval`]).
    weighted: Vec<[f64; 6]>,
}

/// A patch's rest shape: knots, weights and Cartesian control points (`z = 0` for planar
/// curves).
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// A curve (planar or spatial).
    Curve {
        /// Degree.
        degree: usize,
        /// Knot vector.
        knots: Vec<f32>,
        /// Weights.
        weights: Vec<f64>,
    },
    /// A surface, control points row by row (`i` along u, `count_v` per row).
    Surface {
        /// Degrees `(p, q)`.
        degree: (usize, usize),
        /// Knot vectors.
        knots: (Vec<f32>, Vec<f32>),
        /// Control points per row (along v).
        count_v: usize,
        /// Weights.
        weights: Vec<f64>,
    },
}

/// One row of basis derivatives of one direction (`ders[k][j]`, `k ≤ 2`), in f64.
type Ders = [[f64; MAX_ORDER]; 3];

fn ders(knots: &[f32], degree: usize, n_points: usize, t: f64) -> Option<(usize, Ders)> {
    let k = Knots::new(knots, degree, n_points).ok()?;
    let t = t as f32;
    let span = k.find_span(t);
    let mut d = [[0.0f32; MAX_ORDER]; MAX_DERIV + 1];
    ders_basis_funs(knots, span, k.clamp(t), degree, 2, &mut d);
    let mut out = [[0.0; MAX_ORDER]; 3];
    for (o, row) in out.iter_mut().zip(&d) {
        for (x, y) in o.iter_mut().zip(row) {
            *x = f64::from(*y);
        }
    }
    Some((span - degree, out))
}

impl Shape {
    /// The rest shape of a curve and its Cartesian control points (`z = 0` when planar).
    pub fn of_curve<P: Point>(
        curve: &CurveBuf<P>,
        to3: impl Fn(P) -> [f64; 3],
    ) -> (Self, Vec<[f64; 3]>) {
        let (weights, points) = curve
            .points()
            .iter()
            .map(|&h| {
                let (wp, w) = P::split(h);
                let w = f64::from(w);
                (w, to3(wp).map(|c| c / w))
            })
            .unzip();
        let shape = Shape::Curve {
            degree: curve.degree(),
            knots: curve.knots().to_vec(),
            weights,
        };
        (shape, points)
    }

    /// The rest shape of a planar curve.
    pub fn of_curve2(curve: &CurveBuf<Vec2>) -> (Self, Vec<[f64; 3]>) {
        Self::of_curve(curve, |p| [f64::from(p.x), f64::from(p.y), 0.0])
    }

    /// The rest shape of a spatial curve.
    pub fn of_curve3(curve: &CurveBuf<Vec3>) -> (Self, Vec<[f64; 3]>) {
        Self::of_curve(curve, |p| [f64::from(p.x), f64::from(p.y), f64::from(p.z)])
    }

    /// The rest shape of a surface.
    pub fn of_surface(surface: &SurfaceBuf) -> (Self, Vec<[f64; 3]>) {
        let (weights, points) = surface
            .points()
            .iter()
            .map(|h| {
                let w = f64::from(h.w);
                let p = [h.x, h.y, h.z].map(|c| f64::from(c) / w);
                (w, p)
            })
            .unzip();
        let (ku, kv) = surface.knots();
        let shape = Shape::Surface {
            degree: surface.degree(),
            knots: (ku.to_vec(), kv.to_vec()),
            count_v: surface.counts().1,
            weights,
        };
        (shape, points)
    }

    /// Number of control points.
    pub fn n_points(&self) -> usize {
        match self {
            Shape::Curve { weights, .. } | Shape::Surface { weights, .. } => weights.len(),
        }
    }

    /// Whether this is a surface.
    pub fn is_surface(&self) -> bool {
        matches!(self, Shape::Surface { .. })
    }

    /// The half-bandwidth of the matrices in this numbering.
    pub fn bandwidth(&self) -> usize {
        match self {
            Shape::Curve { degree, .. } => *degree,
            Shape::Surface {
                degree: (p, q),
                count_v,
                ..
            } => p * count_v + q,
        }
    }

    /// The parametric domain, `[(u0, u1), (v0, v1)]` (`v` is `(0, 0)` on curves).
    pub fn domain(&self) -> [(f64, f64); 2] {
        let dom = |knots: &[f32], p: usize, n: usize| {
            Knots::new(knots, p, n)
                .map(|k| {
                    let (a, b) = k.domain();
                    (f64::from(a), f64::from(b))
                })
                .unwrap_or((0.0, 0.0))
        };
        match self {
            Shape::Curve {
                degree,
                knots,
                weights,
            } => [dom(knots, *degree, weights.len()), (0.0, 0.0)],
            Shape::Surface {
                degree: (p, q),
                knots: (ku, kv),
                count_v,
                weights,
            } => {
                let nu = weights.len() / count_v.max(&1);
                [dom(ku, *p, nu), dom(kv, *q, *count_v)]
            }
        }
    }

    /// The rational basis functions and their derivatives at `params` (`[u, 0]` on curves),
    /// clamped into the domain. Quotient rule on `R = N w / W`, `W = Σ N w`.
    pub fn eval(&self, params: [f64; 2], out: &mut Local) {
        out.index.clear();
        out.r.clear();
        out.d1.clear();
        out.d2.clear();
        // Unnormalised `A = N w` with its derivatives [A, Au, Av, Auu, Auv, Avv].
        let mut a = std::mem::take(&mut out.weighted);
        a.clear();
        match self {
            Shape::Curve {
                degree,
                knots,
                weights,
            } => {
                let Some((first, d)) = ders(knots, *degree, weights.len(), params[0]) else {
                    return;
                };
                for j in 0..=*degree {
                    let k = first + j;
                    let w = weights[k];
                    out.index.push(k);
                    a.push([d[0][j] * w, d[1][j] * w, 0.0, d[2][j] * w, 0.0, 0.0]);
                }
            }
            Shape::Surface {
                degree: (p, q),
                knots: (ku, kv),
                count_v,
                weights,
            } => {
                let nu = weights.len() / count_v.max(&1);
                let (Some((fu, du)), Some((fv, dv))) = (
                    ders(ku, *p, nu, params[0]),
                    ders(kv, *q, *count_v, params[1]),
                ) else {
                    return;
                };
                for i in 0..=*p {
                    for j in 0..=*q {
                        let k = (fu + i) * count_v + fv + j;
                        let w = weights[k];
                        out.index.push(k);
                        a.push([
                            du[0][i] * dv[0][j] * w,
                            du[1][i] * dv[0][j] * w,
                            du[0][i] * dv[1][j] * w,
                            du[2][i] * dv[0][j] * w,
                            du[1][i] * dv[1][j] * w,
                            du[0][i] * dv[2][j] * w,
                        ]);
                    }
                }
            }
        }
        let mut s = [0.0; 6];
        for x in &a {
            for c in 0..6 {
                s[c] += x[c];
            }
        }
        let [w, wu, wv, wuu, wuv, wvv] = s;
        for x in &a {
            let r = x[0] / w;
            let ru = (x[1] - r * wu) / w;
            let rv = (x[2] - r * wv) / w;
            let ruu = (x[3] - 2.0 * ru * wu - r * wuu) / w;
            let ruv = (x[4] - ru * wv - rv * wu - r * wuv) / w;
            let rvv = (x[5] - 2.0 * rv * wv - r * wvv) / w;
            out.r.push(r);
            out.d1.push([ru, rv]);
            out.d2.push([ruu, ruv, rvv]);
        }
        out.weighted = a;
    }

    /// Gauss–Legendre points and weights over every non-empty knot span (tensor products on
    /// surfaces), `order` points per direction per span: `(params, weight)` with the weight in
    /// parameter measure (`du` or `du dv`).
    pub fn quadrature(&self, order: usize) -> Vec<([f64; 2], f64)> {
        let (nodes, weights) = gauss_legendre(order);
        let spans = |knots: &[f32], p: usize, n: usize| -> Vec<(f64, f64)> {
            let Ok(k) = Knots::new(knots, p, n) else {
                return Vec::new();
            };
            k.span_indices()
                .filter(|&i| knots[i] < knots[i + 1])
                .map(|i| (f64::from(knots[i]), f64::from(knots[i + 1])))
                .collect()
        };
        let rule = |(a, b): (f64, f64)| {
            let h = 0.5 * (b - a);
            nodes
                .iter()
                .zip(&weights)
                .map(move |(x, w)| (a + h * (x + 1.0), h * w))
        };
        match self {
            Shape::Curve {
                degree,
                knots,
                weights: w,
            } => spans(knots, *degree, w.len())
                .into_iter()
                .flat_map(rule)
                .map(|(u, w)| ([u, 0.0], w))
                .collect(),
            Shape::Surface {
                degree: (p, q),
                knots: (ku, kv),
                count_v,
                weights: w,
            } => {
                let nu = w.len() / count_v.max(&1);
                let su: Vec<_> = spans(ku, *p, nu).into_iter().flat_map(rule).collect();
                let sv: Vec<_> = spans(kv, *q, *count_v).into_iter().flat_map(rule).collect();
                su.iter()
                    .flat_map(|&(u, wu)| sv.iter().map(move |&(v, wv)| ([u, v], wu * wv)))
                    .collect()
            }
        }
    }

    /// The degree along u (the quadrature order follows it).
    pub fn max_degree(&self) -> usize {
        match self {
            Shape::Curve { degree, .. } => *degree,
            Shape::Surface { degree: (p, q), .. } => *p.max(q),
        }
    }
}

/// The `n`-point Gauss–Legendre rule on `[−1, 1]` (crate `gauss-quad`, Bogaert's algorithm):
/// nodes and weights, exact for polynomials of degree `2n − 1`.
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let n = std::num::NonZeroUsize::new(n).unwrap_or(std::num::NonZeroUsize::MIN);
    gauss_quad::legendre::GaussLegendre::new(n)
        .iter()
        .map(|&(x, w)| (x, w))
        .unzip()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each n-point rule integrates `x^k` exactly for `k ≤ 2n − 1` (the integral over
    /// `[−1, 1]` is `2/(k+1)` for even `k`, 0 for odd), to rounding.
    #[test]
    fn gauss_legendre_is_exact_to_degree_2n_minus_1() {
        for n in 1..=8 {
            let (x, w) = gauss_legendre(n);
            for k in 0..2 * n {
                let got: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(k as i32)).sum();
                let exact = if k % 2 == 0 {
                    2.0 / (k + 1) as f64
                } else {
                    0.0
                };
                assert!(
                    (got - exact).abs() < 1e-14,
                    "n = {n}, x^{k}: {got} vs {exact}"
                );
            }
        }
    }

    /// The rational basis of the exact quarter circle (weights 1, √½, 1) sums to one with
    /// derivatives summing to zero, and its derivatives match central finite differences of
    /// the values (step 1e-3: truncation `h² R'''/6` ≈ 1e-6, f32 basis values ≈ 1e-7/h).
    #[test]
    fn rational_basis_partition_of_unity_and_finite_differences() {
        let shape = Shape::Curve {
            degree: 2,
            knots: vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
            weights: vec![1.0, std::f64::consts::FRAC_1_SQRT_2, 1.0],
        };
        let mut l = Local::default();
        let (mut lm, mut lp) = (Local::default(), Local::default());
        let h = 1e-3;
        for u in [0.1, 0.37, 0.5, 0.8] {
            shape.eval([u, 0.0], &mut l);
            let sum: f64 = l.r.iter().sum();
            let dsum: f64 = l.d1.iter().map(|d| d[0]).sum();
            assert!((sum - 1.0).abs() < 1e-6 && dsum.abs() < 1e-5);
            shape.eval([u - h, 0.0], &mut lm);
            shape.eval([u + h, 0.0], &mut lp);
            for m in 0..l.r.len() {
                let fd1 = (lp.r[m] - lm.r[m]) / (2.0 * h);
                let fd2 = (lp.d1[m][0] - lm.d1[m][0]) / (2.0 * h);
                assert!(
                    (fd1 - l.d1[m][0]).abs() < 2e-4,
                    "R' at {u}: {fd1} vs {}",
                    l.d1[m][0]
                );
                assert!(
                    (fd2 - l.d2[m][0]).abs() < 2e-3,
                    "R'' at {u}: {fd2} vs {}",
                    l.d2[m][0]
                );
            }
        }
    }
}
