#![doc = include_str!("../README.md")]
#![allow(clippy::unwrap_used)]

use glam::{DVec3, Vec2, Vec3, Vec4};
use nurbs::{Curve, CurveBuf, Point, Surface, SurfaceBuf, construct};
use proptest::collection::vec;
use proptest::prelude::*;

mod reference;
mod strategies;

pub use reference::*;
pub use strategies::*;

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
