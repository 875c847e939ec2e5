//! Shared test helpers: an independent `f64` reference evaluator, central differences and
//! proptest strategies for valid random curves and surfaces.
//!
//! The reference evaluates the Cox–de Boor recursion (The NURBS Book, eq. 2.5) and its
//! derivative formula (eq. 2.10) directly from the definition, in `f64`, on the exact values
//! the crate stores (`f32` knots and homogeneous points widened losslessly). It shares no code
//! with the crate's triangular algorithms A2.2/A2.3/A3.2/A4.2.
#![allow(dead_code)]

use glam::{DVec3, Vec3, Vec4};
use nurbs::{Curve, CurveBuf, Point, Surface, SurfaceBuf};
use proptest::collection::vec;
use proptest::prelude::*;

/// 256 cases per property unless `PROPTEST_CASES` asks for more (for soak runs), so the whole
/// suite stays fast in debug builds.
pub fn config() -> ProptestConfig {
    let mut c = ProptestConfig::default();
    if std::env::var_os("PROPTEST_CASES").is_none() {
        c.cases = 256;
    }
    c
}

/// Unit roundoff of `f32`, as `f64`.
pub const EPS32: f64 = f32::EPSILON as f64;

// ---------------------------------------------------------------------------------------------
// Reference basis functions (definition, not the crate's algorithm)
// ---------------------------------------------------------------------------------------------

/// `N_{i,p}(u)` by the Cox–de Boor recursion (eq. 2.5) with the 0/0 = 0 convention. Spans are
/// half-open, except the last non-empty one, which is closed so that `u = b` gives the limit
/// from the left (the crate's documented convention, and the book's A2.1 special case).
pub fn cox_de_boor(k: &[f64], p: usize, i: usize, u: f64) -> f64 {
    cox_de_boor_der(k, p, i, u, 0)
}

/// `d^order/du^order N_{i,p}(u)` by eq. 2.10 applied recursively:
/// `N^(k)_{i,p} = p (N^(k-1)_{i,p-1} / (u_{i+p} - u_i) - N^(k-1)_{i+1,p-1} / (u_{i+p+1} - u_{i+1}))`.
pub fn cox_de_boor_der(k: &[f64], p: usize, i: usize, u: f64, order: usize) -> f64 {
    if order == 0 {
        if p == 0 {
            let last = k[k.len() - 1];
            let (a, b) = (k[i], k[i + 1]);
            let inside = a <= u && u < b;
            let at_end = u == last && a < b && b == last;
            return if inside || at_end { 1.0 } else { 0.0 };
        }
        let mut r = 0.0;
        let d1 = k[i + p] - k[i];
        if d1 > 0.0 {
            r += (u - k[i]) / d1 * cox_de_boor_der(k, p - 1, i, u, 0);
        }
        let d2 = k[i + p + 1] - k[i + 1];
        if d2 > 0.0 {
            r += (k[i + p + 1] - u) / d2 * cox_de_boor_der(k, p - 1, i + 1, u, 0);
        }
        return r;
    }
    if p == 0 {
        return 0.0;
    }
    let mut r = 0.0;
    let d1 = k[i + p] - k[i];
    if d1 > 0.0 {
        r += cox_de_boor_der(k, p - 1, i, u, order - 1) / d1;
    }
    let d2 = k[i + p + 1] - k[i + 1];
    if d2 > 0.0 {
        r -= cox_de_boor_der(k, p - 1, i + 1, u, order - 1) / d2;
    }
    p as f64 * r
}

/// All `n` basis functions (or their `order`-th derivatives) at `u`.
pub fn all_basis(k: &[f64], p: usize, u: f64, order: usize) -> Vec<f64> {
    let n = k.len() - p - 1;
    (0..n).map(|i| cox_de_boor_der(k, p, i, u, order)).collect()
}

pub fn widen(k: &[f32]) -> Vec<f64> {
    k.iter().map(|&x| x as f64).collect()
}

/// First `DIM` (at most 3) coordinates of a point, widened; missing ones are 0.
pub fn to_d3<P: Point>(p: P) -> DVec3 {
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

/// The rational curve `Σ N_i (w_i P_i) / Σ N_i w_i` in `f64`.
#[derive(Clone, Debug)]
pub struct RefCurve {
    pub p: usize,
    pub knots: Vec<f64>,
    /// `(w·x, w·y, w·z)` and `w`.
    pub hom: Vec<(DVec3, f64)>,
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
                    (to_d3(xw), w as f64)
                })
                .collect(),
        }
    }

    pub fn point(&self, u: f64) -> DVec3 {
        let n = all_basis(&self.knots, self.p, u, 0);
        let mut a = DVec3::ZERO;
        let mut w = 0.0;
        for (ni, (xw, wi)) in n.iter().zip(&self.hom) {
            a += *xw * *ni;
            w += ni * wi;
        }
        a / w
    }

    /// Cartesian control points.
    pub fn cartesian(&self) -> Vec<DVec3> {
        self.hom.iter().map(|(xw, w)| *xw / *w).collect()
    }
}

/// The rational tensor-product surface in `f64`.
#[derive(Clone, Debug)]
pub struct RefSurface {
    pub p: usize,
    pub q: usize,
    pub ku: Vec<f64>,
    pub kv: Vec<f64>,
    pub nv: usize,
    pub hom: Vec<(DVec3, f64)>,
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
                .map(|h| (h.truncate().as_dvec3(), h.w as f64))
                .collect(),
        }
    }

    pub fn point(&self, u: f64, v: f64) -> DVec3 {
        let bu = all_basis(&self.ku, self.p, u, 0);
        let bv = all_basis(&self.kv, self.q, v, 0);
        let mut a = DVec3::ZERO;
        let mut w = 0.0;
        for (i, nu) in bu.iter().enumerate() {
            if *nu == 0.0 {
                continue;
            }
            for (j, nv) in bv.iter().enumerate() {
                let (xw, wij) = self.hom[i * self.nv + j];
                a += xw * (nu * nv);
                w += nu * nv * wij;
            }
        }
        a / w
    }

    pub fn cartesian(&self) -> Vec<DVec3> {
        self.hom.iter().map(|(xw, w)| *xw / *w).collect()
    }
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

// ---------------------------------------------------------------------------------------------
// Strategies
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
    let max_mult = max_mult.clamp(1, p);
    (-5.0f64..5.0, 0.5f64..10.0, 0..=max_interior)
        .prop_flat_map(move |(a, len, k)| {
            (
                Just(a),
                Just(len),
                vec(0.2f64..1.0, k + 1),
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
    pub p: usize,
    pub knots: Vec<f32>,
    pub pts: Vec<[f32; 3]>,
    /// `None`: non-rational.
    pub weights: Option<Vec<f32>>,
}

impl CurveSpec {
    pub fn build<P: Point>(&self) -> CurveBuf<P> {
        let pts: Vec<P> = self.pts.iter().map(|&c| from3(c)).collect();
        CurveBuf::from_cartesian(self.p, self.knots.clone(), &pts, self.weights.as_deref())
            .expect("strategy produces valid curves")
    }

    pub fn weight_ratio(&self) -> f64 {
        weight_ratio(self.weights.as_deref())
    }
}

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
/// to `max_mult` (capped at the degree), rational or not.
pub fn curve_spec(max_p: usize, max_mult: usize) -> impl Strategy<Value = CurveSpec> {
    (1..=max_p)
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
    pub p: usize,
    pub q: usize,
    pub ku: Vec<f32>,
    pub kv: Vec<f32>,
    /// `rows[i][j]`, `i` along u.
    pub rows: Vec<Vec<Vec3>>,
    pub weights: Option<Vec<Vec<f32>>>,
}

impl SurfaceSpec {
    pub fn build(&self) -> SurfaceBuf {
        SurfaceBuf::from_rows(
            (self.p, self.q),
            (self.ku.clone(), self.kv.clone()),
            &self.rows,
            self.weights.as_deref(),
        )
        .expect("strategy produces valid surfaces")
    }

    pub fn weight_ratio(&self) -> f64 {
        match &self.weights {
            None => 1.0,
            Some(w) => {
                let flat: Vec<f32> = w.iter().flatten().copied().collect();
                weight_ratio(Some(&flat))
            }
        }
    }

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
    (1..=max_p, 1..=max_p)
        .prop_flat_map(move |(p, q)| {
            (
                Just(p),
                Just(q),
                knots_strategy(p, 3, max_mult),
                knots_strategy(q, 3, max_mult),
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

/// A parameter in a random non-empty span, at relative position `t ∈ [0, 1]`, and the span
/// length. `pick ∈ [0, 1)` chooses the span.
pub fn in_span(k: &[f32], pick: f64, t: f64) -> (f32, f64) {
    let s = spans(k);
    let idx = ((pick * s.len() as f64) as usize).min(s.len() - 1);
    let (_, a, b) = s[idx];
    let u = (a as f64 + t * (b as f64 - a as f64)) as f32;
    (u, b as f64 - a as f64)
}

/// Largest absolute coordinate difference, relative to `scale`.
pub fn rel_err(a: DVec3, b: DVec3, scale: f64) -> f64 {
    (a - b).abs().max_element() / scale
}

pub fn hom3(p: Vec3, w: f32) -> Vec4 {
    (p * w).extend(w)
}
