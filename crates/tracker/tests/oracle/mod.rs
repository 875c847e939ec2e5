//! References for the tracker tests that share no code with the crates under test: `f64`
//! NURBS evaluation straight from the definition (Cox–de Boor recursion, The NURBS Book
//! eq. 2.5, its derivative eq. 2.10 and the quotient rule for the rational form), closest
//! points by dense sampling polished with an `f64` Newton iteration, and proptest strategies
//! for random convex curves and surfaces.
#![allow(dead_code)]

use core::ops::{Add, Mul, Neg, Sub};
use nurbs::{Curve, CurveBuf, Point, Surface, SurfaceBuf, Vec2, Vec3, construct};
use proptest::prelude::*;

/// The haptic tick of the thesis's setup (1 kHz).
pub const T: f32 = 1e-3;

// ---------------------------------------------------------------------------------------------
// f64 vectors
// ---------------------------------------------------------------------------------------------

/// A 3-vector in `f64` (planar points have z = 0).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct D3(pub [f64; 3]);

impl D3 {
    pub const ZERO: D3 = D3([0.0; 3]);

    pub fn new(x: f64, y: f64, z: f64) -> Self {
        D3([x, y, z])
    }
    pub fn dot(self, o: D3) -> f64 {
        (0..3).map(|i| self.0[i] * o.0[i]).sum()
    }
    pub fn cross(self, o: D3) -> D3 {
        let [a, b, c] = self.0;
        let [x, y, z] = o.0;
        D3([b * z - c * y, c * x - a * z, a * y - b * x])
    }
    pub fn norm(self) -> f64 {
        self.dot(self).sqrt()
    }
    pub fn unit(self) -> D3 {
        self * (1.0 / self.norm())
    }
    pub fn x(self) -> f64 {
        self.0[0]
    }
    pub fn y(self) -> f64 {
        self.0[1]
    }
    pub fn z(self) -> f64 {
        self.0[2]
    }
    /// Planar normal of a tangent, the crate's convention `(t.y, −t.x)`.
    pub fn perp_cw(self) -> D3 {
        D3([self.0[1], -self.0[0], 0.0])
    }
}

impl Add for D3 {
    type Output = D3;
    fn add(self, o: D3) -> D3 {
        D3([self.0[0] + o.0[0], self.0[1] + o.0[1], self.0[2] + o.0[2]])
    }
}
impl Sub for D3 {
    type Output = D3;
    fn sub(self, o: D3) -> D3 {
        D3([self.0[0] - o.0[0], self.0[1] - o.0[1], self.0[2] - o.0[2]])
    }
}
impl Mul<f64> for D3 {
    type Output = D3;
    fn mul(self, s: f64) -> D3 {
        D3([self.0[0] * s, self.0[1] * s, self.0[2] * s])
    }
}
impl Neg for D3 {
    type Output = D3;
    fn neg(self) -> D3 {
        self * -1.0
    }
}

/// A crate point widened to `f64` (z = 0 for planar points).
pub fn wide<P: Point>(p: P) -> D3 {
    let s = p.as_slice();
    D3([
        s[0] as f64,
        s.get(1).copied().unwrap_or(0.0) as f64,
        s.get(2).copied().unwrap_or(0.0) as f64,
    ])
}

pub fn v2(p: D3) -> Vec2 {
    Vec2::new(p.x() as f32, p.y() as f32)
}

pub fn v3(p: D3) -> Vec3 {
    Vec3::new(p.x() as f32, p.y() as f32, p.z() as f32)
}

/// Angle between two vectors in degrees, `f64`.
pub fn angle_deg(a: D3, b: D3) -> f64 {
    let c = a.cross(b).norm();
    let d = a.dot(b);
    c.atan2(d).to_degrees()
}

// ---------------------------------------------------------------------------------------------
// Basis functions from the definition
// ---------------------------------------------------------------------------------------------

/// `d^order/du^order N_{i,p}(u)` by the Cox–de Boor recursion (eq. 2.5) and eq. 2.10, with
/// 0/0 = 0; spans are half-open except the last non-empty one, closed at the domain end.
pub fn basis(k: &[f64], p: usize, i: usize, u: f64, order: usize) -> f64 {
    if order == 0 && p == 0 {
        let last = k[k.len() - 1];
        let (a, b) = (k[i], k[i + 1]);
        let inside = a <= u && u < b;
        let at_end = u == last && a < b && b == last;
        return if inside || at_end { 1.0 } else { 0.0 };
    }
    if p == 0 {
        return 0.0;
    }
    let d1 = k[i + p] - k[i];
    let d2 = k[i + p + 1] - k[i + 1];
    let mut r = 0.0;
    if order == 0 {
        if d1 > 0.0 {
            r += (u - k[i]) / d1 * basis(k, p - 1, i, u, 0);
        }
        if d2 > 0.0 {
            r += (k[i + p + 1] - u) / d2 * basis(k, p - 1, i + 1, u, 0);
        }
        return r;
    }
    if d1 > 0.0 {
        r += basis(k, p - 1, i, u, order - 1) / d1;
    }
    if d2 > 0.0 {
        r -= basis(k, p - 1, i + 1, u, order - 1) / d2;
    }
    p as f64 * r
}

fn widen(k: &[f32]) -> Vec<f64> {
    k.iter().map(|&x| x as f64).collect()
}

// ---------------------------------------------------------------------------------------------
// Reference curves and surfaces
// ---------------------------------------------------------------------------------------------

/// A NURBS curve in `f64`, from the exact `f32` data of a crate curve.
#[derive(Clone, Debug)]
pub struct RefCurve {
    pub p: usize,
    pub knots: Vec<f64>,
    /// `(w·P, w)`.
    pub hom: Vec<(D3, f64)>,
}

/// `C`, `C'`, `C''` in `f64`.
#[derive(Clone, Copy, Debug)]
pub struct RefJet {
    pub p: D3,
    pub d1: D3,
    pub d2: D3,
}

impl RefCurve {
    pub fn new<P: Point>(c: &Curve<'_, P>) -> Self {
        RefCurve {
            p: c.degree(),
            knots: widen(c.knots().as_slice()),
            hom: c
                .points()
                .iter()
                .map(|&h| {
                    let (xw, w) = P::split(h);
                    (wide(xw), w as f64)
                })
                .collect(),
        }
    }

    pub fn domain(&self) -> (f64, f64) {
        (
            self.knots[self.p],
            self.knots[self.knots.len() - 1 - self.p],
        )
    }

    pub fn clamp(&self, u: f64) -> f64 {
        let (a, b) = self.domain();
        u.clamp(a, b)
    }

    /// `A^(k) = Σ N_i^(k) w_i P_i` and `W^(k) = Σ N_i^(k) w_i` for k = 0, 1, 2.
    fn sums(&self, u: f64) -> [(D3, f64); 3] {
        let mut s = [(D3::ZERO, 0.0); 3];
        for (i, &(xw, w)) in self.hom.iter().enumerate() {
            for (k, sk) in s.iter_mut().enumerate() {
                let n = basis(&self.knots, self.p, i, u, k);
                if n != 0.0 {
                    sk.0 = sk.0 + xw * n;
                    sk.1 += w * n;
                }
            }
        }
        s
    }

    pub fn point(&self, u: f64) -> D3 {
        let mut a = D3::ZERO;
        let mut w = 0.0;
        for (i, &(xw, wi)) in self.hom.iter().enumerate() {
            let n = basis(&self.knots, self.p, i, u, 0);
            a = a + xw * n;
            w += wi * n;
        }
        a * (1.0 / w)
    }

    /// Quotient rule: `C = A/W`, `C' = (A' − W'C)/W`, `C'' = (A'' − 2W'C' − W''C)/W`.
    pub fn jet(&self, u: f64) -> RefJet {
        let [(a0, w0), (a1, w1), (a2, w2)] = self.sums(u);
        let p = a0 * (1.0 / w0);
        let d1 = (a1 - p * w1) * (1.0 / w0);
        let d2 = (a2 - d1 * (2.0 * w1) - p * w2) * (1.0 / w0);
        RefJet { p, d1, d2 }
    }

    /// Signed curvature of a planar curve (positive turning counter-clockwise).
    pub fn curvature(&self, u: f64) -> f64 {
        let j = self.jet(u);
        let c = j.d1.x() * j.d2.y() - j.d1.y() * j.d2.x();
        c / j.d1.norm().powi(3)
    }

    /// Planar unit normal `(t.y, −t.x)`.
    pub fn normal(&self, u: f64) -> D3 {
        self.jet(u).d1.unit().perp_cw()
    }
}

/// A NURBS surface in `f64`, from the exact `f32` data of a crate surface.
#[derive(Clone, Debug)]
pub struct RefSurface {
    pub p: usize,
    pub q: usize,
    pub ku: Vec<f64>,
    pub kv: Vec<f64>,
    pub nv: usize,
    pub hom: Vec<(D3, f64)>,
}

/// `S` and its partial derivatives in `f64`.
#[derive(Clone, Copy, Debug)]
pub struct RefSurfJet {
    pub p: D3,
    pub su: D3,
    pub sv: D3,
    pub suu: D3,
    pub suv: D3,
    pub svv: D3,
}

impl RefSurface {
    pub fn new(s: &Surface<'_>) -> Self {
        let (p, q) = s.degree();
        let (ku, kv) = s.knots();
        RefSurface {
            p,
            q,
            ku: widen(ku.as_slice()),
            kv: widen(kv.as_slice()),
            nv: s.counts().1,
            hom: s
                .points()
                .iter()
                .map(|h| (wide(h.truncate()), h.w as f64))
                .collect(),
        }
    }

    pub fn domain(&self) -> [(f64, f64); 2] {
        [
            (self.ku[self.p], self.ku[self.ku.len() - 1 - self.p]),
            (self.kv[self.q], self.kv[self.kv.len() - 1 - self.q]),
        ]
    }

    /// `∂^(a+b)/∂u^a∂v^b` of `A` and `W`.
    fn sum(&self, u: f64, v: f64, a: usize, b: usize) -> (D3, f64) {
        let nu = self.hom.len() / self.nv;
        let mut s = (D3::ZERO, 0.0);
        for i in 0..nu {
            let bu = basis(&self.ku, self.p, i, u, a);
            if bu == 0.0 {
                continue;
            }
            for j in 0..self.nv {
                let bv = basis(&self.kv, self.q, j, v, b);
                if bv == 0.0 {
                    continue;
                }
                let (xw, w) = self.hom[i * self.nv + j];
                s.0 = s.0 + xw * (bu * bv);
                s.1 += w * bu * bv;
            }
        }
        s
    }

    pub fn point(&self, u: f64, v: f64) -> D3 {
        let (a, w) = self.sum(u, v, 0, 0);
        a * (1.0 / w)
    }

    /// Quotient rule for the rational surface (The NURBS Book eq. 4.20).
    pub fn jet(&self, u: f64, v: f64) -> RefSurfJet {
        let (a00, w00) = self.sum(u, v, 0, 0);
        let (a10, w10) = self.sum(u, v, 1, 0);
        let (a01, w01) = self.sum(u, v, 0, 1);
        let (a20, w20) = self.sum(u, v, 2, 0);
        let (a11, w11) = self.sum(u, v, 1, 1);
        let (a02, w02) = self.sum(u, v, 0, 2);
        let inv = 1.0 / w00;
        let p = a00 * inv;
        let su = (a10 - p * w10) * inv;
        let sv = (a01 - p * w01) * inv;
        let suu = (a20 - su * (2.0 * w10) - p * w20) * inv;
        let svv = (a02 - sv * (2.0 * w01) - p * w02) * inv;
        let suv = (a11 - su * w01 - sv * w10 - p * w11) * inv;
        RefSurfJet {
            p,
            su,
            sv,
            suu,
            suv,
            svv,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Reference closest points
// ---------------------------------------------------------------------------------------------

/// The global closest point of a curve to a point, in `f64`.
#[derive(Clone, Copy, Debug)]
pub struct RefClosest {
    pub u: f64,
    pub point: D3,
    pub distance: f64,
    /// Local minima of the distance over the dense samples (1: unimodal).
    pub local_minima: usize,
    /// `f'' = |C'|² + Γ·C''` of `f = ½|C − x|²` at the closest point.
    pub hessian: f64,
    /// `|C'|²` there.
    pub metric: f64,
}

/// Dense sampling (`samples` intervals) of `½|C(u) − x|²`, then `f64` Newton from the best
/// sample, clamped into the domain.
pub fn closest_on_curve(c: &RefCurve, x: D3, samples: usize) -> RefClosest {
    let (a, b) = c.domain();
    let f: Vec<f64> = (0..=samples)
        .map(|k| {
            let u = a + (b - a) * k as f64 / samples as f64;
            (c.point(u) - x).dot(c.point(u) - x)
        })
        .collect();
    let mut best = 0;
    let mut local_minima = 0;
    for k in 0..=samples {
        if f[k] < f[best] {
            best = k;
        }
        let left = k == 0 || f[k] < f[k - 1];
        let right = k == samples || f[k] <= f[k + 1];
        if left && right {
            local_minima += 1;
        }
    }
    let mut u = a + (b - a) * best as f64 / samples as f64;
    for _ in 0..60 {
        let j = c.jet(u);
        let g = j.p - x;
        let fp = g.dot(j.d1);
        let fpp = j.d1.dot(j.d1) + g.dot(j.d2);
        let step = if fpp > 0.0 {
            -fp / fpp
        } else {
            -fp / j.d1.dot(j.d1)
        };
        let next = c.clamp(u + step.clamp(-(b - a) / samples as f64, (b - a) / samples as f64));
        if next == u {
            break;
        }
        u = next;
    }
    let j = c.jet(u);
    let g = j.p - x;
    RefClosest {
        u,
        point: j.p,
        distance: g.norm(),
        local_minima,
        hessian: j.d1.dot(j.d1) + g.dot(j.d2),
        metric: j.d1.dot(j.d1),
    }
}

/// The global closest point of a surface, in `f64`.
#[derive(Clone, Copy, Debug)]
pub struct RefSurfClosest {
    pub t: [f64; 2],
    pub point: D3,
    pub distance: f64,
    /// Eigenvalues `λ₁ ≤ λ₂` of `G⁻¹H` at the closest point (`1 + κᵢ d` on the convex side).
    pub gh_eigen: [f64; 2],
    /// Hessian `H = Sᵢ·Sⱼ + Γ·Sᵢⱼ` of `½|S − x|²` there.
    pub hessian: [[f64; 2]; 2],
    /// First fundamental form `G` there.
    pub metric: [[f64; 2]; 2],
}

/// Dense grid sampling, then `f64` Newton on `Ψ = 0` with the full Hessian.
pub fn closest_on_surface(s: &RefSurface, x: D3, samples: usize) -> RefSurfClosest {
    let [(u0, u1), (v0, v1)] = s.domain();
    let at = |k: usize, lo: f64, hi: f64| lo + (hi - lo) * k as f64 / samples as f64;
    let mut best = (f64::INFINITY, [u0, v0]);
    for i in 0..=samples {
        for j in 0..=samples {
            let t = [at(i, u0, u1), at(j, v0, v1)];
            let g = s.point(t[0], t[1]) - x;
            if g.dot(g) < best.0 {
                best = (g.dot(g), t);
            }
        }
    }
    let mut t = best.1;
    let hu = (u1 - u0) / samples as f64;
    let hv = (v1 - v0) / samples as f64;
    for _ in 0..60 {
        let j = s.jet(t[0], t[1]);
        let g = j.p - x;
        let psi = [g.dot(j.su), g.dot(j.sv)];
        let h = [
            [j.su.dot(j.su) + g.dot(j.suu), j.su.dot(j.sv) + g.dot(j.suv)],
            [j.su.dot(j.sv) + g.dot(j.suv), j.sv.dot(j.sv) + g.dot(j.svv)],
        ];
        let det = h[0][0] * h[1][1] - h[0][1] * h[1][0];
        if !(det > 0.0 && h[0][0] > 0.0) {
            break;
        }
        let du = -(h[1][1] * psi[0] - h[0][1] * psi[1]) / det;
        let dv = -(h[0][0] * psi[1] - h[1][0] * psi[0]) / det;
        let next = [
            (t[0] + du.clamp(-hu, hu)).clamp(u0, u1),
            (t[1] + dv.clamp(-hv, hv)).clamp(v0, v1),
        ];
        if next == t {
            break;
        }
        t = next;
    }
    let j = s.jet(t[0], t[1]);
    let g = j.p - x;
    let gm = [
        [j.su.dot(j.su), j.su.dot(j.sv)],
        [j.su.dot(j.sv), j.sv.dot(j.sv)],
    ];
    let h = [
        [gm[0][0] + g.dot(j.suu), gm[0][1] + g.dot(j.suv)],
        [gm[1][0] + g.dot(j.suv), gm[1][1] + g.dot(j.svv)],
    ];
    RefSurfClosest {
        t,
        point: j.p,
        distance: g.norm(),
        gh_eigen: generalized_eigen(h, gm),
        hessian: h,
        metric: gm,
    }
}

/// Eigenvalues of a symmetric 2×2 matrix, ascending.
pub fn sym_eigen(a: [[f64; 2]; 2]) -> [f64; 2] {
    generalized_eigen(a, [[1.0, 0.0], [0.0, 1.0]])
}

/// Eigenvalues of `G⁻¹H` (symmetric `H`, positive definite `G`), ascending.
pub fn generalized_eigen(h: [[f64; 2]; 2], g: [[f64; 2]; 2]) -> [f64; 2] {
    // det(H − λG) = 0: a λ² − b λ + c = 0.
    let a = g[0][0] * g[1][1] - g[0][1] * g[1][0];
    let b = h[0][0] * g[1][1] + h[1][1] * g[0][0] - 2.0 * h[0][1] * g[0][1];
    let c = h[0][0] * h[1][1] - h[0][1] * h[1][0];
    let disc = (b * b - 4.0 * a * c).max(0.0).sqrt();
    [(b - disc) / (2.0 * a), (b + disc) / (2.0 * a)]
}

// ---------------------------------------------------------------------------------------------
// Random convex shapes
// ---------------------------------------------------------------------------------------------

/// A random convex planar Bézier curve inside the pantograph workspace: degree 2–4, control
/// points in counter-clockwise order on a sector of a random ellipse (sweep ≤ 2.4 rad < π), so
/// the control polygon is convex and so is the curve (variation diminishing). Outward normals
/// `(t.y, −t.x)` point away from the ellipse centre.
pub fn convex_curve() -> impl Strategy<Value = CurveBuf<Vec2>> {
    (
        2usize..=4,
        (0.015f32..0.045, 0.015f32..0.045),
        0.0f32..core::f32::consts::TAU,
        0.0f32..core::f32::consts::TAU,
        0.8f32..2.4,
        proptest::collection::vec(0.1f32..1.0, 4),
    )
        .prop_map(|(p, (a, b), rot, start, sweep, gaps)| {
            // Increasing angles with random gaps.
            let total: f32 = gaps[..p].iter().sum();
            let mut angle = start;
            let (sr, cr) = rot.sin_cos();
            let center = Vec2::new(0.0, 0.09);
            let mut pts = Vec::with_capacity(p + 1);
            for k in 0..=p {
                let (s, c) = angle.sin_cos();
                let local = Vec2::new(a * c, b * s);
                pts.push(
                    center + Vec2::new(cr * local.x - sr * local.y, sr * local.x + cr * local.y),
                );
                if k < p {
                    angle += sweep * gaps[k] / total;
                }
            }
            construct::bezier_curve(&pts).expect("valid Bézier")
        })
}

/// A random convex dome: the bicubic Bézier patch whose control net samples the paraboloid
/// `z = z₀ − x²/(2R₁) − y²/(2R₂)` on a uniform 4×4 grid over `[−w₁, w₁] × [−w₂, w₂]`, rotated
/// about z. It is the tensor Bernstein approximant of a separable concave quadratic, and the
/// univariate Bernstein operator maps `x²` to `(1 − 1/n) x² + (linear)`: the patch is again a
/// concave separable quadratic in (x, y) plus a linear term, a convex cap with normals
/// (`S_u × S_v`) pointing up, away from its inside.
pub fn convex_dome() -> impl Strategy<Value = SurfaceBuf> {
    (
        (0.02f32..0.1, 0.02f32..0.1),
        (0.015f32..0.04, 0.015f32..0.04),
        0.0f32..core::f32::consts::TAU,
    )
        .prop_map(|((r1, r2), (w1, w2), rot)| dome(r1, r2, w1, w2, rot))
}

/// See [`convex_dome`].
pub fn dome(r1: f32, r2: f32, w1: f32, w2: f32, rot: f32) -> SurfaceBuf {
    let (sr, cr) = rot.sin_cos();
    let center = Vec3::new(0.0, 0.09, 0.0);
    let rows: Vec<Vec<Vec3>> = (0..4)
        .map(|i| {
            (0..4)
                .map(|j| {
                    let x = w1 * (2.0 * i as f32 / 3.0 - 1.0);
                    let y = w2 * (2.0 * j as f32 / 3.0 - 1.0);
                    let z = -x * x / (2.0 * r1) - y * y / (2.0 * r2);
                    center + Vec3::new(cr * x - sr * y, sr * x + cr * y, z)
                })
                .collect()
        })
        .collect();
    construct::bezier_patch(&rows).expect("valid patch")
}
