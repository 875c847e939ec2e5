//! Independent references: NURBS curves and surfaces evaluated in f64 from the definition
//! (Cox–de Boor), and their closest points by dense sampling and a polish, for the tests to
//! compare the crates' f32 code against.

use super::*;

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
