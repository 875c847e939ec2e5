#![doc = include_str!("../README.md")]
#![allow(clippy::unwrap_used)]

use glam::{DVec3, Vec2, Vec3, Vec4};
use nurbs::{Curve, CurveBuf, Point, Surface, SurfaceBuf, construct};
use proptest::collection::vec;
use proptest::prelude::*;

/// The haptic tick of the thesis's setup (1 kHz).
pub const T: f32 = 1e-3;

/// Unit roundoff of `f32`, as `f64`.
pub const EPS32: f64 = f32::EPSILON as f64;

/// 256 cases per property unless `PROPTEST_CASES` asks for more (for soak runs), so the whole
/// suite stays fast in debug builds.
pub fn config() -> ProptestConfig {
    let mut c = ProptestConfig::default();
    if std::env::var_os("PROPTEST_CASES").is_none() {
        c.cases = 256;
    }
    c
}

// ---------------------------------------------------------------------------------------------
// Vectors
// ---------------------------------------------------------------------------------------------

/// A crate point widened to `f64`; missing coordinates (planar points) are 0.
pub fn wide<P: Point>(p: P) -> DVec3 {
    let s = p.as_slice();
    DVec3::new(
        s[0] as f64,
        s.get(1).copied().unwrap_or(0.0) as f64,
        s.get(2).copied().unwrap_or(0.0) as f64,
    )
}

/// Builds a `P` from the first `DIM` coordinates of `c`.
pub fn from3<P: Point>(c: [f32; 3]) -> P {
    P::from_coords(&c[..P::DIM]).expect("DIM <= 3")
}

/// `x, y` of a reference vector, narrowed.
pub fn v2(p: DVec3) -> Vec2 {
    p.truncate().as_vec2()
}

/// A reference vector, narrowed.
pub fn v3(p: DVec3) -> Vec3 {
    p.as_vec3()
}

/// Planar normal of a tangent, the crates' convention `(t.y, −t.x)`.
pub fn perp_cw(t: DVec3) -> DVec3 {
    DVec3::new(t.y, -t.x, 0.0)
}

/// Angle between two vectors in degrees.
pub fn angle_deg(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b)).to_degrees()
}

/// Largest absolute coordinate difference, relative to `scale`.
pub fn rel_err(a: DVec3, b: DVec3, scale: f64) -> f64 {
    (a - b).abs().max_element() / scale
}

/// Homogeneous `(w·P, w)`.
pub fn hom3(p: Vec3, w: f32) -> Vec4 {
    (p * w).extend(w)
}

// ---------------------------------------------------------------------------------------------
// Basis functions from the definition
// ---------------------------------------------------------------------------------------------

/// `d^order/du^order N_{i,p}(u)` by the Cox–de Boor recursion (eq. 2.5) and eq. 2.10
/// (`N^(k)_{i,p} = p (N^(k-1)_{i,p-1} / (u_{i+p} − u_i) − N^(k-1)_{i+1,p-1} / (u_{i+p+1} − u_{i+1}))`),
/// with 0/0 = 0. Spans are half-open, except the last non-empty one, which is closed so that
/// `u = b` gives the limit from the left (the crates' documented convention, and the book's
/// A2.1 special case).
pub fn basis(k: &[f64], p: usize, i: usize, u: f64, order: usize) -> f64 {
    basis_rec(k, p, i, u, order, &|i| {
        let last = k[k.len() - 1];
        let (a, b) = (k[i], k[i + 1]);
        (a <= u && u < b) || (u == last && a < b && b == last)
    })
}

/// Like [`basis`], but the polynomial piece of span `span` (`N_{i,0} = 1` iff `i = span`),
/// evaluated at any `u`: at a knot this is the one-sided limit from inside that span.
pub fn basis_in_span(k: &[f64], p: usize, i: usize, u: f64, order: usize, span: usize) -> f64 {
    basis_rec(k, p, i, u, order, &|i| i == span)
}

fn basis_rec(
    k: &[f64],
    p: usize,
    i: usize,
    u: f64,
    order: usize,
    unit: &dyn Fn(usize) -> bool,
) -> f64 {
    if p == 0 {
        return if order == 0 && unit(i) { 1.0 } else { 0.0 };
    }
    let d1 = k[i + p] - k[i];
    let d2 = k[i + p + 1] - k[i + 1];
    let mut r = 0.0;
    if order == 0 {
        if d1 > 0.0 {
            r += (u - k[i]) / d1 * basis_rec(k, p - 1, i, u, 0, unit);
        }
        if d2 > 0.0 {
            r += (k[i + p + 1] - u) / d2 * basis_rec(k, p - 1, i + 1, u, 0, unit);
        }
        return r;
    }
    if d1 > 0.0 {
        r += basis_rec(k, p - 1, i, u, order - 1, unit) / d1;
    }
    if d2 > 0.0 {
        r -= basis_rec(k, p - 1, i + 1, u, order - 1, unit) / d2;
    }
    p as f64 * r
}

/// `N_{i,p}(u)`: [`basis`] of order 0.
pub fn cox_de_boor(k: &[f64], p: usize, i: usize, u: f64) -> f64 {
    basis(k, p, i, u, 0)
}

/// All `n` basis functions (or their `order`-th derivatives) at `u`.
pub fn all_basis(k: &[f64], p: usize, u: f64, order: usize) -> Vec<f64> {
    let n = k.len() - p - 1;
    (0..n).map(|i| basis(k, p, i, u, order)).collect()
}

/// Knots widened to `f64` (exactly).
pub fn widen(k: &[f32]) -> Vec<f64> {
    k.iter().map(|&x| x as f64).collect()
}

/// Which basis functions to use: the crates' half-open convention, or one span's polynomial.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// [`basis`].
    Default,
    /// [`basis_in_span`] of this span.
    Span(usize),
}

fn basis_at(k: &[f64], p: usize, i: usize, u: f64, order: usize, side: Side) -> f64 {
    match side {
        Side::Default => basis(k, p, i, u, order),
        Side::Span(s) => basis_in_span(k, p, i, u, order, s),
    }
}

// ---------------------------------------------------------------------------------------------
// Reference curves and surfaces
// ---------------------------------------------------------------------------------------------

/// The rational curve `Σ N_i (w_i P_i) / Σ N_i w_i` in `f64`, from the exact `f32` data of a
/// crate curve.
#[derive(Clone, Debug)]
pub struct RefCurve {
    /// Degree.
    pub p: usize,
    /// Knots, widened.
    pub knots: Vec<f64>,
    /// `(w·P, w)`, widened (planar points have z = 0).
    pub hom: Vec<(DVec3, f64)>,
}

/// `C`, `C'`, `C''` in `f64`.
#[derive(Clone, Copy, Debug)]
pub struct RefJet {
    /// `C`.
    pub p: DVec3,
    /// `C'`.
    pub d1: DVec3,
    /// `C''`.
    pub d2: DVec3,
}

impl RefCurve {
    /// The reference of a crate curve.
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

    /// `[knots[p], knots[n + 1]]`.
    pub fn domain(&self) -> (f64, f64) {
        (
            self.knots[self.p],
            self.knots[self.knots.len() - 1 - self.p],
        )
    }

    /// `u` clamped into the domain.
    pub fn clamp(&self, u: f64) -> f64 {
        let (a, b) = self.domain();
        u.clamp(a, b)
    }

    /// Non-empty spans `(index, a, b)` inside the domain.
    pub fn spans(&self) -> Vec<(usize, f64, f64)> {
        spans_of(&self.knots, self.p)
    }

    /// `A^(k) = Σ N_i^(k) w_i P_i` and `W^(k) = Σ N_i^(k) w_i` for k = 0, 1, 2.
    fn sums(&self, u: f64, side: Side) -> [(DVec3, f64); 3] {
        let mut s = [(DVec3::ZERO, 0.0); 3];
        for (i, &(xw, w)) in self.hom.iter().enumerate() {
            for (k, sk) in s.iter_mut().enumerate() {
                let n = basis_at(&self.knots, self.p, i, u, k, side);
                if n != 0.0 {
                    sk.0 += xw * n;
                    sk.1 += w * n;
                }
            }
        }
        s
    }

    /// `C(u)`.
    pub fn point(&self, u: f64) -> DVec3 {
        self.point_on(u, Side::Default)
    }

    /// `C(u)` from the basis functions of `side`.
    pub fn point_on(&self, u: f64, side: Side) -> DVec3 {
        let mut a = DVec3::ZERO;
        let mut w = 0.0;
        for (i, &(xw, wi)) in self.hom.iter().enumerate() {
            let n = basis_at(&self.knots, self.p, i, u, 0, side);
            a += xw * n;
            w += wi * n;
        }
        a / w
    }

    /// Quotient rule: `C = A/W`, `C' = (A' − W'C)/W`, `C'' = (A'' − 2W'C' − W''C)/W`.
    pub fn jet(&self, u: f64) -> RefJet {
        self.jet_on(u, Side::Default)
    }

    /// [`Self::jet`] from the basis functions of `side`.
    pub fn jet_on(&self, u: f64, side: Side) -> RefJet {
        let [(a0, w0), (a1, w1), (a2, w2)] = self.sums(u, side);
        let p = a0 / w0;
        let d1 = (a1 - p * w1) / w0;
        let d2 = (a2 - d1 * (2.0 * w1) - p * w2) / w0;
        RefJet { p, d1, d2 }
    }

    /// Signed curvature of a planar curve (positive turning counter-clockwise).
    pub fn curvature(&self, u: f64) -> f64 {
        let j = self.jet(u);
        let c = j.d1.x * j.d2.y - j.d1.y * j.d2.x;
        c / j.d1.length().powi(3)
    }

    /// Planar unit normal `(t.y, −t.x)`.
    pub fn normal(&self, u: f64) -> DVec3 {
        perp_cw(self.jet(u).d1.normalize())
    }

    /// Cartesian control points.
    pub fn cartesian(&self) -> Vec<DVec3> {
        self.hom.iter().map(|(xw, w)| *xw / *w).collect()
    }
}

/// The rational tensor-product surface in `f64`, from the exact `f32` data of a crate
/// surface.
#[derive(Clone, Debug)]
pub struct RefSurface {
    /// Degree along u.
    pub p: usize,
    /// Degree along v.
    pub q: usize,
    /// Knots along u, widened.
    pub ku: Vec<f64>,
    /// Knots along v, widened.
    pub kv: Vec<f64>,
    /// Control points along v.
    pub nv: usize,
    /// `(w·P, w)` row-major with `i` along u, widened.
    pub hom: Vec<(DVec3, f64)>,
}

/// `S` and its partial derivatives in `f64`.
#[derive(Clone, Copy, Debug)]
pub struct RefSurfJet {
    /// `S`.
    pub p: DVec3,
    /// `S_u`.
    pub su: DVec3,
    /// `S_v`.
    pub sv: DVec3,
    /// `S_uu`.
    pub suu: DVec3,
    /// `S_uv`.
    pub suv: DVec3,
    /// `S_vv`.
    pub svv: DVec3,
}

impl RefSurface {
    /// The reference of a crate surface.
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
                .map(|h| (h.truncate().as_dvec3(), h.w as f64))
                .collect(),
        }
    }

    /// `[(u_min, u_max), (v_min, v_max)]`.
    pub fn domain(&self) -> [(f64, f64); 2] {
        [
            (self.ku[self.p], self.ku[self.ku.len() - 1 - self.p]),
            (self.kv[self.q], self.kv[self.kv.len() - 1 - self.q]),
        ]
    }

    /// `∂^(a+b)/∂u^a∂v^b` of `A` and `W`.
    fn sum(&self, u: f64, v: f64, a: usize, b: usize, side: [Side; 2]) -> (DVec3, f64) {
        let nu = self.hom.len() / self.nv;
        let mut s = (DVec3::ZERO, 0.0);
        for i in 0..nu {
            let bu = basis_at(&self.ku, self.p, i, u, a, side[0]);
            if bu == 0.0 {
                continue;
            }
            for j in 0..self.nv {
                let bv = basis_at(&self.kv, self.q, j, v, b, side[1]);
                if bv == 0.0 {
                    continue;
                }
                let (xw, w) = self.hom[i * self.nv + j];
                s.0 += xw * (bu * bv);
                s.1 += w * bu * bv;
            }
        }
        s
    }

    /// `S(u, v)`.
    pub fn point(&self, u: f64, v: f64) -> DVec3 {
        self.point_on(u, v, [Side::Default; 2])
    }

    /// `S(u, v)` from the basis functions of `side`.
    pub fn point_on(&self, u: f64, v: f64, side: [Side; 2]) -> DVec3 {
        let (a, w) = self.sum(u, v, 0, 0, side);
        a / w
    }

    /// Quotient rule for the rational surface (The NURBS Book eq. 4.20).
    pub fn jet(&self, u: f64, v: f64) -> RefSurfJet {
        self.jet_on(u, v, [Side::Default; 2])
    }

    /// [`Self::jet`] from the basis functions of `side`.
    pub fn jet_on(&self, u: f64, v: f64, side: [Side; 2]) -> RefSurfJet {
        let (a00, w00) = self.sum(u, v, 0, 0, side);
        let (a10, w10) = self.sum(u, v, 1, 0, side);
        let (a01, w01) = self.sum(u, v, 0, 1, side);
        let (a20, w20) = self.sum(u, v, 2, 0, side);
        let (a11, w11) = self.sum(u, v, 1, 1, side);
        let (a02, w02) = self.sum(u, v, 0, 2, side);
        let p = a00 / w00;
        let su = (a10 - p * w10) / w00;
        let sv = (a01 - p * w01) / w00;
        let suu = (a20 - su * (2.0 * w10) - p * w20) / w00;
        let svv = (a02 - sv * (2.0 * w01) - p * w02) / w00;
        let suv = (a11 - su * w01 - sv * w10 - p * w11) / w00;
        RefSurfJet {
            p,
            su,
            sv,
            suu,
            suv,
            svv,
        }
    }

    /// Cartesian control points.
    pub fn cartesian(&self) -> Vec<DVec3> {
        self.hom.iter().map(|(xw, w)| *xw / *w).collect()
    }
}

// ---------------------------------------------------------------------------------------------
// Reference closest points
// ---------------------------------------------------------------------------------------------

/// The global closest point of a curve to a point, in `f64`.
#[derive(Clone, Copy, Debug)]
pub struct RefClosest {
    /// Parameter.
    pub u: f64,
    /// `C(u)`.
    pub point: DVec3,
    /// `|C(u) − x|`.
    pub distance: f64,
    /// Local minima of the distance over the dense samples (1: unimodal).
    pub local_minima: usize,
    /// `f'' = |C'|² + Γ·C''` of `f = ½|C − x|²` at the closest point.
    pub hessian: f64,
    /// `|C'|²` there.
    pub metric: f64,
}

/// Dense sampling (`samples` intervals) of `½|C(u) − x|²`, then `f64` Newton from the best
/// sample, clamped into the domain. For curves that are smooth across their knots; see
/// [`closest_on_curve_pieces`] for creases.
pub fn closest_on_curve(c: &RefCurve, x: DVec3, samples: usize) -> RefClosest {
    let (a, b) = c.domain();
    let f: Vec<f64> = (0..=samples)
        .map(|k| {
            let u = a + (b - a) * k as f64 / samples as f64;
            (c.point(u) - x).length_squared()
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
        distance: g.length(),
        local_minima,
        hessian: j.d1.dot(j.d1) + g.dot(j.d2),
        metric: j.d1.dot(j.d1),
    }
}

/// The global closest point of a surface, in `f64`.
#[derive(Clone, Copy, Debug)]
pub struct RefSurfClosest {
    /// Parameters.
    pub t: [f64; 2],
    /// `S(t)`.
    pub point: DVec3,
    /// `|S(t) − x|`.
    pub distance: f64,
    /// Eigenvalues `λ₁ ≤ λ₂` of `G⁻¹H` at the closest point (`1 + κᵢ d` on the convex side).
    pub gh_eigen: [f64; 2],
    /// Hessian `H = Sᵢ·Sⱼ + Γ·Sᵢⱼ` of `½|S − x|²` there.
    pub hessian: [[f64; 2]; 2],
    /// First fundamental form `G` there.
    pub metric: [[f64; 2]; 2],
}

/// Dense grid sampling, then `f64` Newton on `Ψ = 0` with the full Hessian. For surfaces
/// that are smooth across their knots; see [`closest_on_surface_pieces`] for creases.
pub fn closest_on_surface(s: &RefSurface, x: DVec3, samples: usize) -> RefSurfClosest {
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
        distance: g.length(),
        gh_eigen: generalized_eigen(h, gm),
        hessian: h,
        metric: gm,
    }
}

/// A brute-force closest point: parameters and distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Nearest<const N: usize> {
    /// Parameters.
    pub t: [f64; N],
    /// Distance.
    pub distance: f64,
}

/// Minimises a smooth `f(s)` over `[a, b]` from `s0`: Newton on `f'` with the exact `f''`
/// where it is positive, a gradient step scaled to the interval otherwise, each step halved
/// until `f` does not increase, and clamped into `[a, b]`.
fn minimise_1d(f: impl Fn(f64) -> (f64, f64, f64), (a, b): (f64, f64), s0: f64) -> f64 {
    let mut s = s0;
    let (mut fs, mut d1, mut d2) = f(s);
    for _ in 0..100 {
        let mut step = if d2 > 0.0 {
            -d1 / d2
        } else {
            -d1.signum() * (b - a) * 0.05
        };
        let mut moved = false;
        for _ in 0..60 {
            let next = (s + step).clamp(a, b);
            if next == s {
                break;
            }
            let (fn_, n1, n2) = f(next);
            if fn_ <= fs {
                moved = fn_ < fs || next != s;
                s = next;
                (fs, d1, d2) = (fn_, n1, n2);
                break;
            }
            step *= 0.5;
        }
        if !moved {
            break;
        }
    }
    s
}

/// Closest point of a curve by brute force per Bézier piece: every non-empty span sampled
/// densely (`samples` intervals), polished from its best sample and from its best interior
/// local minimum, with one-sided evaluation inside the span; the span's end points offered as
/// they are. Exact at creases (full-multiplicity interior knots), where a polish over the
/// whole curve would see a derivative jump.
pub fn closest_on_curve_pieces(c: &RefCurve, x: DVec3, samples: usize) -> Nearest<1> {
    let mut best = Nearest {
        t: [c.domain().0],
        distance: f64::INFINITY,
    };
    let mut offer = |u: f64, d: f64| {
        if d < best.distance {
            best = Nearest {
                t: [u],
                distance: d,
            };
        }
    };
    for (span, a, b) in c.spans() {
        let side = Side::Span(span);
        let f = |u: f64| {
            let j = c.jet_on(u, side);
            let g = j.p - x;
            (
                0.5 * g.length_squared(),
                g.dot(j.d1),
                j.d1.length_squared() + g.dot(j.d2),
            )
        };
        let at = |k: usize| a + (b - a) * k as f64 / samples as f64;
        let vals: Vec<f64> = (0..=samples).map(|k| f(at(k)).0).collect();
        for k in 0..=samples {
            let left = k == 0 || vals[k] <= vals[k - 1];
            let right = k == samples || vals[k] <= vals[k + 1];
            if left && right {
                let u = minimise_1d(f, (a, b), at(k));
                offer(u, (2.0 * f(u).0).sqrt());
            }
        }
        for u in [a, b] {
            offer(u, (c.point_on(u, side) - x).length());
        }
    }
    best
}

/// Closest point of a surface by brute force per Bézier piece: in every non-empty span box,
/// a dense grid (`samples` intervals per direction) polished by a damped `f64` Newton from
/// each of its sampled local minima, each of the four boundary curves minimised in one
/// dimension likewise, and the four corners, all with one-sided evaluation inside the piece.
/// Exact at creases, where the minimum often lies on a boundary curve or a corner.
pub fn closest_on_surface_pieces(s: &RefSurface, x: DVec3, samples: usize) -> Nearest<2> {
    let [(u0, _), (v0, _)] = s.domain();
    let mut best = Nearest {
        t: [u0, v0],
        distance: f64::INFINITY,
    };
    let mut offer = |t: [f64; 2], d: f64| {
        if d < best.distance {
            best = Nearest { t, distance: d };
        }
    };
    for (su, ua, ub) in spans_of(&s.ku, s.p) {
        for (sv, va, vb) in spans_of(&s.kv, s.q) {
            let side = [Side::Span(su), Side::Span(sv)];
            let dist = |t: [f64; 2]| (s.point_on(t[0], t[1], side) - x).length();
            // Corners.
            for t in [[ua, va], [ub, va], [ua, vb], [ub, vb]] {
                offer(t, dist(t));
            }
            // Boundary curves: f(w) along a side, with its first and second derivatives.
            for fixed_u in [true, false] {
                let (lo, hi) = if fixed_u { (va, vb) } else { (ua, ub) };
                for c in if fixed_u { [ua, ub] } else { [va, vb] } {
                    let param = |w: f64| if fixed_u { [c, w] } else { [w, c] };
                    let f = |w: f64| {
                        let t = param(w);
                        let j = s.jet_on(t[0], t[1], side);
                        let g = j.p - x;
                        let (d1, d2) = if fixed_u {
                            (j.sv, j.svv)
                        } else {
                            (j.su, j.suu)
                        };
                        (
                            0.5 * g.length_squared(),
                            g.dot(d1),
                            d1.length_squared() + g.dot(d2),
                        )
                    };
                    let at = |k: usize| lo + (hi - lo) * k as f64 / samples as f64;
                    let vals: Vec<f64> = (0..=samples).map(|k| f(at(k)).0).collect();
                    for k in 0..=samples {
                        let left = k == 0 || vals[k] <= vals[k - 1];
                        let right = k == samples || vals[k] <= vals[k + 1];
                        if left && right {
                            let w = minimise_1d(f, (lo, hi), at(k));
                            offer(param(w), dist(param(w)));
                        }
                    }
                }
            }
            // Interior: grid local minima polished by damped Newton, clamped to the box.
            let at = |k: usize, lo: f64, hi: f64| lo + (hi - lo) * k as f64 / samples as f64;
            let n = samples + 1;
            let mut grid = vec![0.0; n * n];
            for i in 0..n {
                for j in 0..n {
                    grid[i * n + j] = dist([at(i, ua, ub), at(j, va, vb)]);
                }
            }
            // Grid minima on the box's rim too: an interior minimum near a side samples lowest
            // there.
            for i in 0..n {
                for j in 0..n {
                    let g = grid[i * n + j];
                    let (ia, ib) = (i.saturating_sub(1), (i + 1).min(samples));
                    let (ja, jb) = (j.saturating_sub(1), (j + 1).min(samples));
                    let local = (ia..=ib).all(|a| (ja..=jb).all(|b| grid[a * n + b] >= g));
                    if local {
                        let t = polish_box(
                            s,
                            x,
                            [at(i, ua, ub), at(j, va, vb)],
                            side,
                            [(ua, ub), (va, vb)],
                        );
                        offer(t, dist(t));
                    }
                }
            }
        }
    }
    best
}

/// Damped Newton (Levenberg–Marquardt on the full Hessian) for `min ½|S − x|²` in a box,
/// steps clamped into the box and accepted only when the distance does not increase.
fn polish_box(
    s: &RefSurface,
    x: DVec3,
    t0: [f64; 2],
    side: [Side; 2],
    bx: [(f64, f64); 2],
) -> [f64; 2] {
    let mut t = t0;
    let f = |t: [f64; 2]| (s.point_on(t[0], t[1], side) - x).length_squared();
    let mut ft = f(t);
    let mut lambda = 0.0;
    for _ in 0..200 {
        let j = s.jet_on(t[0], t[1], side);
        let g = j.p - x;
        let psi = [g.dot(j.su), g.dot(j.sv)];
        let gm = [
            [j.su.dot(j.su), j.su.dot(j.sv)],
            [j.su.dot(j.sv), j.sv.dot(j.sv)],
        ];
        let h = [
            [gm[0][0] + g.dot(j.suu), gm[0][1] + g.dot(j.suv)],
            [gm[1][0] + g.dot(j.suv), gm[1][1] + g.dot(j.svv)],
        ];
        let mut moved = false;
        for _ in 0..40 {
            let a = [
                [h[0][0] + lambda * gm[0][0], h[0][1]],
                [h[1][0], h[1][1] + lambda * gm[1][1]],
            ];
            let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
            if det > 0.0 && a[0][0] > 0.0 {
                let du = -(a[1][1] * psi[0] - a[0][1] * psi[1]) / det;
                let dv = -(a[0][0] * psi[1] - a[1][0] * psi[0]) / det;
                let next = [
                    (t[0] + du).clamp(bx[0].0, bx[0].1),
                    (t[1] + dv).clamp(bx[1].0, bx[1].1),
                ];
                if next == t {
                    return t;
                }
                let fn_ = f(next);
                if fn_ <= ft {
                    moved = fn_ < ft;
                    t = next;
                    ft = fn_;
                    lambda *= 0.25;
                    break;
                }
            }
            lambda = (lambda * 4.0).max(1e-3);
        }
        if !moved {
            break;
        }
    }
    t
}

/// Non-empty spans `(index, a, b)` of a knot vector of degree `p` inside its domain.
fn spans_of(k: &[f64], p: usize) -> Vec<(usize, f64, f64)> {
    (p..k.len() - p - 1)
        .filter(|&i| k[i] < k[i + 1])
        .map(|i| (i, k[i], k[i + 1]))
        .collect()
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
// Central differences
// ---------------------------------------------------------------------------------------------

/// `f'(x) ≈ (f(x+h) − f(x−h)) / 2h`, truncation error `h² |f'''| / 6`.
pub fn central1(f: impl Fn(f64) -> DVec3, x: f64, h: f64) -> DVec3 {
    (f(x + h) - f(x - h)) / (2.0 * h)
}

/// `f''(x) ≈ (f(x+h) − 2f(x) + f(x−h)) / h²`, truncation error `h² |f''''| / 12`.
pub fn central2(f: impl Fn(f64) -> DVec3, x: f64, h: f64) -> DVec3 {
    (f(x + h) - f(x) * 2.0 + f(x - h)) / (h * h)
}

/// `∂²f/∂u∂v ≈ (f(u+h,v+k) − f(u+h,v−k) − f(u−h,v+k) + f(u−h,v−k)) / 4hk`.
pub fn central_mixed(f: impl Fn(f64, f64) -> DVec3, u: f64, v: f64, h: f64, k: f64) -> DVec3 {
    (f(u + h, v + k) - f(u + h, v - k) - f(u - h, v + k) + f(u - h, v - k)) / (4.0 * h * k)
}

// ---------------------------------------------------------------------------------------------
// Knot-vector facts used by the tests
// ---------------------------------------------------------------------------------------------

/// Non-empty spans `[k_i, k_{i+1})` as `(i, k_i, k_{i+1})`.
pub fn spans(k: &[f32]) -> Vec<(usize, f32, f32)> {
    k.windows(2)
        .enumerate()
        .filter(|(_, w)| w[0] < w[1])
        .map(|(i, w)| (i, w[0], w[1]))
        .collect()
}

/// Smallest non-zero distance between consecutive knots.
pub fn min_gap(k: &[f32]) -> f64 {
    spans(k)
        .iter()
        .map(|&(_, a, b)| b as f64 - a as f64)
        .fold(f64::INFINITY, f64::min)
}

/// Distinct interior knot values with their multiplicities.
pub fn interior_knots(k: &[f32], p: usize) -> Vec<(f32, usize)> {
    let inner = &k[p + 1..k.len() - p - 1];
    let mut out: Vec<(f32, usize)> = Vec::new();
    for &x in inner {
        match out.last_mut() {
            Some((y, m)) if *y == x => *m += 1,
            _ => out.push((x, 1)),
        }
    }
    out
}

/// The next representable `f32` below `x` (`f32::next_down` is newer than the MSRV).
pub fn next_down(x: f32) -> f32 {
    if x == 0.0 {
        -f32::from_bits(1)
    } else if x > 0.0 {
        f32::from_bits(x.to_bits() - 1)
    } else {
        f32::from_bits(x.to_bits() + 1)
    }
}

/// A parameter in a random non-empty span, at relative position `t ∈ [0, 1]`, and the span
/// length. `pick ∈ [0, 1)` chooses the span.
pub fn in_span(k: &[f32], pick: f64, t: f64) -> (f32, f64) {
    let s = spans(k);
    let idx = ((pick * s.len() as f64) as usize).min(s.len() - 1);
    let (_, a, b) = s[idx];
    let u = (a as f64 + t * (b as f64 - a as f64)) as f32;
    (u, b as f64 - a as f64)
}

// ---------------------------------------------------------------------------------------------
// Strategies: random valid curves and surfaces
// ---------------------------------------------------------------------------------------------

/// A clamped knot vector of degree `p` on a random domain `[a, a + len]` (`a ∈ [-5, 5]`,
/// `len ∈ [0.5, 10]`), with up to `max_interior` distinct interior knots of multiplicity
/// `1..=max_mult.min(p)`. Consecutive distinct knots are at least 4% of the domain apart, so
/// derivatives stay within a known scale.
pub fn knots_strategy(
    p: usize,
    max_interior: usize,
    max_mult: usize,
) -> impl Strategy<Value = Vec<f32>> {
    knots_in(p, max_interior, max_mult, -5.0..5.0, 0.5..10.0, 0.2)
}

/// [`knots_strategy`] with the domain start drawn from `start`, its length from `len`, and
/// gaps between consecutive distinct knots drawn from `[min_gap, 1]` before normalisation (so
/// they are at least `min_gap / (k + 1)` of the domain apart for `k` interior knots).
pub fn knots_in(
    p: usize,
    max_interior: usize,
    max_mult: usize,
    start: std::ops::Range<f64>,
    len: std::ops::Range<f64>,
    min_gap: f64,
) -> impl Strategy<Value = Vec<f32>> {
    let max_mult = max_mult.clamp(1, p);
    (start, len, 0..=max_interior)
        .prop_flat_map(move |(a, len, k)| {
            (
                Just(a),
                Just(len),
                vec(min_gap..1.0, k + 1),
                vec(1..=max_mult, k),
            )
        })
        .prop_map(move |(a, len, gaps, mults)| {
            let total: f64 = gaps.iter().sum();
            let mut knots = vec![a as f32; p + 1];
            let mut acc = 0.0;
            for (g, &m) in gaps.iter().zip(&mults) {
                acc += g;
                let x = (a + len * acc / total) as f32;
                knots.extend(std::iter::repeat_n(x, m));
            }
            knots.extend(std::iter::repeat_n((a + len) as f32, p + 1));
            knots
        })
}

/// Data of a random valid curve (Cartesian points in 3-D; planar curves use `x, y`).
#[derive(Clone, Debug)]
pub struct CurveSpec {
    /// Degree.
    pub p: usize,
    /// Knots.
    pub knots: Vec<f32>,
    /// Cartesian control points.
    pub pts: Vec<[f32; 3]>,
    /// `None`: non-rational.
    pub weights: Option<Vec<f32>>,
}

impl CurveSpec {
    /// The curve.
    pub fn build<P: Point>(&self) -> CurveBuf<P> {
        let pts: Vec<P> = self.pts.iter().map(|&c| from3(c)).collect();
        CurveBuf::from_cartesian(self.p, self.knots.clone(), &pts, self.weights.as_deref())
            .expect("strategy produces valid curves")
    }

    /// Largest over smallest weight.
    pub fn weight_ratio(&self) -> f64 {
        weight_ratio(self.weights.as_deref())
    }

    /// Largest control-point norm.
    pub fn pmax(&self) -> f64 {
        self.pts
            .iter()
            .map(|c| Vec3::from_array(*c).length() as f64)
            .fold(0.0, f64::max)
    }
}

/// Largest over smallest weight (1 for `None`).
pub fn weight_ratio(w: Option<&[f32]>) -> f64 {
    match w {
        None => 1.0,
        Some(w) => {
            let max = w.iter().fold(0.0f32, |a, &b| a.max(b));
            let min = w.iter().fold(f32::INFINITY, |a, &b| a.min(b));
            (max / min) as f64
        }
    }
}

fn coord() -> impl Strategy<Value = f32> {
    -2.0f32..2.0
}

fn point3() -> impl Strategy<Value = [f32; 3]> {
    [coord(), coord(), coord()]
}

/// Weights in [0.2, 5] for a rational curve, or `None`.
fn weights(n: usize) -> impl Strategy<Value = Option<Vec<f32>>> {
    prop_oneof![Just(None), vec(0.2f32..5.0, n).prop_map(Some)]
}

/// Random valid curve: degree 1..=`max_p`, up to 4 distinct interior knots of multiplicity up
/// to `max_mult` (capped at the degree; `max_mult ≥ p` allows creases), rational or not.
pub fn curve_spec(max_p: usize, max_mult: usize) -> impl Strategy<Value = CurveSpec> {
    curve_spec_in(1..=max_p, max_mult)
}

/// [`curve_spec`] with the degree drawn from `degrees`.
pub fn curve_spec_in(
    degrees: std::ops::RangeInclusive<usize>,
    max_mult: usize,
) -> impl Strategy<Value = CurveSpec> {
    degrees
        .prop_flat_map(move |p| (Just(p), knots_strategy(p, 4, max_mult)))
        .prop_flat_map(|(p, knots)| {
            let n = knots.len() - p - 1;
            (Just(p), Just(knots), vec(point3(), n), weights(n))
        })
        .prop_map(|(p, knots, pts, weights)| CurveSpec {
            p,
            knots,
            pts,
            weights,
        })
}

/// Data of a random valid surface.
#[derive(Clone, Debug)]
pub struct SurfaceSpec {
    /// Degree along u.
    pub p: usize,
    /// Degree along v.
    pub q: usize,
    /// Knots along u.
    pub ku: Vec<f32>,
    /// Knots along v.
    pub kv: Vec<f32>,
    /// `rows[i][j]`, `i` along u.
    pub rows: Vec<Vec<Vec3>>,
    /// `None`: non-rational.
    pub weights: Option<Vec<Vec<f32>>>,
}

impl SurfaceSpec {
    /// The surface.
    pub fn build(&self) -> SurfaceBuf {
        SurfaceBuf::from_rows(
            (self.p, self.q),
            (self.ku.clone(), self.kv.clone()),
            &self.rows,
            self.weights.as_deref(),
        )
        .expect("strategy produces valid surfaces")
    }

    /// Largest over smallest weight.
    pub fn weight_ratio(&self) -> f64 {
        match &self.weights {
            None => 1.0,
            Some(w) => {
                let flat: Vec<f32> = w.iter().flatten().copied().collect();
                weight_ratio(Some(&flat))
            }
        }
    }

    /// Largest control-point norm.
    pub fn pmax(&self) -> f64 {
        self.rows
            .iter()
            .flatten()
            .map(|p| p.length() as f64)
            .fold(0.0, f64::max)
    }
}

/// Random valid surface: degrees 1..=`max_p` in each direction, up to 3 distinct interior knots
/// per direction of multiplicity up to `max_mult`, rational or not.
pub fn surface_spec(max_p: usize, max_mult: usize) -> impl Strategy<Value = SurfaceSpec> {
    surface_spec_in(1..=max_p, 3, max_mult)
}

/// [`surface_spec`] with both degrees drawn from `degrees` and up to `max_interior` distinct
/// interior knots per direction.
pub fn surface_spec_in(
    degrees: std::ops::RangeInclusive<usize>,
    max_interior: usize,
    max_mult: usize,
) -> impl Strategy<Value = SurfaceSpec> {
    (degrees.clone(), degrees)
        .prop_flat_map(move |(p, q)| {
            (
                Just(p),
                Just(q),
                knots_strategy(p, max_interior, max_mult),
                knots_strategy(q, max_interior, max_mult),
            )
        })
        .prop_flat_map(|(p, q, ku, kv)| {
            let nu = ku.len() - p - 1;
            let nv = kv.len() - q - 1;
            let rows = vec(vec(point3().prop_map(Vec3::from_array), nv), nu);
            let w = prop_oneof![Just(None), vec(vec(0.2f32..5.0, nv), nu).prop_map(Some)];
            (Just(p), Just(q), Just(ku), Just(kv), rows, w)
        })
        .prop_map(|(p, q, ku, kv, rows, weights)| SurfaceSpec {
            p,
            q,
            ku,
            kv,
            rows,
            weights,
        })
}

// ---------------------------------------------------------------------------------------------
// Strategies: random convex shapes in the pantograph workspace
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
        vec(0.1f32..1.0, 4),
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
