//! Proptest strategies: random valid knot vectors, curves and surfaces.

use super::*;

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
