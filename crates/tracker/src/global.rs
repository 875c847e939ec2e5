//! Global closest-point search: the true closest point on a patch, found from nothing (no
//! warm start), by branch and bound over the patch's rational Bézier pieces, with a
//! safeguarded Newton polish (P&T §6.1) at the leaves.
//!
//! # Algorithm
//!
//! 1. **Bézier extraction.** Every non-empty knot span (span pair on a surface) is one
//!    rational Bézier piece. Its `k`-th control point is the blossom
//!    `f(a, …, a, b, …, b)` (`p − k` times `a`, `k` times `b`) of the homogeneous B-spline
//!    over the span `[a, b]`, computed by de Boor's algorithm with distinct arguments — no
//!    knot insertion, no allocation. A surface is blossomed along `u` column by column, then
//!    along `v` row by row.
//! 2. **Bounds.** With positive weights a rational Bézier piece lies in the convex hull of its
//!    Cartesian control points. The lower bound is the larger of the squared distances from
//!    `x` to their box and to a slab facing `x` ([`BezierPiece::lower_bound`]); the corner
//!    control points lie on the patch and give upper bounds.
//! 3. **Branch and bound.** Pieces are visited nearest first, depth-first, halved at the
//!    parameter midpoint by de Casteljau on the homogeneous points (a surface piece across
//!    the direction in which its control net is longer), nearer child first. A piece is
//!    pruned when its lower bound cannot beat the best distance so far by more than
//!    [`GlobalConfig::tolerance`]. The first piece on a branch whose box is small against the
//!    best distance ([`GlobalConfig::polish_ratio`]) is polished from its middle, for an early,
//!    tight upper bound.
//! 4. **Leaves.** Subdivision stops at the depth cap or below the tolerance; a leaf that is
//!    still not pruned is polished from its middle parameter (and from its nearest corner
//!    when that is nearer than the middle: a leaf can straddle two minima). The best point
//!    found is polished once more at the end, so that it satisfies the first-order condition.
//!
//! The polish is Newton's method as in [`newton`](crate::newton()), with Levenberg–Marquardt
//! damping and bounds handled as an active set (see `projected_newton`): plain Newton with
//! clamping can jump out of the basin a leaf samples, or stall on the boundary of the domain
//! short of a minimum there. It runs inside the *smooth region* of the piece it starts from
//! ([`BezierSplit::region`]: the part of the patch between interior knots of full
//! multiplicity, a window whose evaluation at its ends is one-sided), never across a crease:
//! there the derivatives jump, and a polish that crosses one settles on the wrong side (issue
//! 11: 3.7 µm too far beside a knot of a bilinear patch). A minimum on a crease is then a
//! minimum on the region's boundary, which the active set finds from either side, and corners
//! of pieces are offered as they are. The final polish stays in the region of the best point.
//! On a patch without such knots the region is the whole patch.
//!
//! The tolerance is relative to the patch's size ([`RELATIVE_TOLERANCE`]), capped by
//! [`GlobalConfig::tolerance`]: the answer is proven to `f32` precision whatever the scale.
//!
//! # Cost
//!
//! On a bicubic 8 × 8 net (25 pieces), queries around the surface visit about 27 pieces and
//! run about 10 polishes on average (see the `pieces_visited` test). The worst case is a query
//! equidistant from much of the patch (the centre of a sphere): nothing can be pruned and
//! every leaf is visited, `2^MAX_DEPTH` per piece.
//!
//! # Stack
//!
//! The search recurses, one level per halving; each level keeps one piece (the sibling still
//! to visit) and little else (the per-piece work is out of line). A surface piece is
//! `[[Vec4; 8]; 8]` (1 KiB) and surfaces stop at depth 9 ([`BezierPiece::MAX_DEPTH`] of
//! [`SurfacePiece`]): ten levels of 1.2 KiB. Worst case for a surface, from the release
//! build's frame sizes on thumbv7em: entry 0.4 KiB + root piece 1.1 KiB + 10 × 1.2 KiB + the
//! polish at the deepest leaf (surface jet included) 2.0 KiB ≈ 15.5 KiB; measured on x86-64
//! by stack painting, 15.7 KiB (before the search kept its two region windows, about 0.2 KiB
//! more in the entry frame; not re-measured). A curve piece is 96 B (planar) or 128 B
//! (spatial), the depth cap 16: about 7 KiB.

use core::ops::{Add, Mul};

use crate::linalg::solve_spd;
use crate::newton::NewtonConfig;
use crate::patch::{Jet, Patch};
use crate::track::{PERIODIC_TOL, clamp};
use nurbs::{Aabb, Curve, MAX_ORDER, Point, Surface, Vec3, Vec4};

/// Settings of [`closest_point`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GlobalConfig {
    /// Distance tolerance (metres). A piece is pruned unless it could hold a point closer than
    /// the best so far by more than this, and a piece smaller than this is not split further.
    /// The search uses the smaller of this and [`RELATIVE_TOLERANCE`] times the diagonal of the
    /// patch's control box (and likewise for the polish's `point_tol`), so that the lower bound
    /// proves the answer to `f32` precision relative to the patch's size, whatever its scale.
    pub tolerance: f32,
    /// The first piece on a branch whose control box diagonal is at most this fraction of the
    /// best distance so far is polished from its middle: at that size the piece usually holds
    /// a single minimum, and finding it early makes pruning effective.
    pub polish_ratio: f32,
    /// Depth cap of the subdivision; the piece type's [`BezierPiece::MAX_DEPTH`] caps it again
    /// so that the stack stays bounded.
    pub max_depth: u8,
    /// Tolerances (P&T eq. 6.4–6.5) and iteration cap of each polish.
    pub newton: NewtonConfig,
}

/// The relative part of [`GlobalConfig::tolerance`]: 8 ε₃₂, a few roundings of a coordinate of
/// the patch's size (de Boor evaluation of a point is accurate to a few ε |P|max, so a finer
/// proof would only compare rounding noise).
pub const RELATIVE_TOLERANCE: f32 = 8.0 * f32::EPSILON;

impl Default for GlobalConfig {
    fn default() -> Self {
        GlobalConfig {
            tolerance: 1e-7,
            polish_ratio: 0.25,
            max_depth: 16,
            newton: NewtonConfig::default(),
        }
    }
}

/// The result of [`closest_point`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Closest<P, const N: usize> {
    /// Parameters of the closest point.
    pub t: [f32; N],
    /// The closest point `S(t)`.
    pub point: P,
    /// `|S(t) − x|²` (`f32::MAX` for a non-finite query; `+∞` once the distance overflows
    /// `f32`, beyond about 1.8·10¹⁹ m).
    pub distance_squared: f32,
    /// Unit outward normal at `t`.
    pub normal: P,
    /// `(x − S)·n`: positive outside, negative inside.
    pub signed_distance: f32,
    /// Bézier pieces and sub-pieces the branch and bound examined (those not pruned on
    /// arrival): the measure of work, with `polishes`.
    pub pieces_visited: u32,
    /// Polishes (local Newton solves) run.
    pub polishes: u32,
}

/// A rational Bézier piece of a patch: homogeneous control points over a parameter box.
pub trait BezierPiece<P: Point, const N: usize>: Clone + core::fmt::Debug {
    /// Depth cap for this piece type (bounds the search's stack).
    const MAX_DEPTH: u32;

    /// The piece's parameter box in the patch's parameters.
    fn params(&self) -> [(f32, f32); N];

    /// Box of the Cartesian control points: contains the piece (positive weights).
    fn bounding_box(&self) -> Aabb<P>;

    /// A lower bound on the squared distance from `x` to the piece, given its
    /// [`bounding_box`](Self::bounding_box): the larger of the distance to the box and the
    /// distance to the slab `{y : (y − x)·v ≥ min_i (P_i − x)·v}` with `v` pointing from `x` to
    /// the box centre (both contain the control points' convex hull). The slab is what stays
    /// tight for a far query and a tilted piece, where the box is loose.
    fn lower_bound(&self, x: P, bb: &Aabb<P>) -> f32;

    /// Corner `k < 2ᴺ` (bit `i` set: the end of direction `i`) with its parameters: corner
    /// control points lie on the patch. `None` for `k ≥ 2ᴺ`.
    fn corner(&self, k: usize) -> Option<([f32; N], P)>;

    /// The piece at local parameters `s ∈ [0, 1]ᴺ` (de Casteljau), i.e. the patch at
    /// `params().0 + s (params().1 − params().0)`.
    fn point_at(&self, s: [f32; N]) -> P;

    /// The direction worth halving: the one along which the control net is longer.
    fn split_direction(&self) -> usize;

    /// Halves the piece at the parameter midpoint of direction `dir` (de Casteljau): `self`
    /// becomes the lower half, the upper half is returned. Directions `≥ N` are ignored
    /// (`self` is returned unchanged as both halves).
    fn split(&mut self, dir: usize) -> Self;
}

/// Patches that split into rational Bézier pieces, one per non-empty knot interval.
pub trait BezierSplit<const N: usize>: Patch<N> + Copy {
    /// A piece.
    type Piece: BezierPiece<Self::P, N>;

    /// Number of knot intervals of the domain per direction, empty ones included
    /// (`n_points − degree` for a whole knot vector).
    fn interval_counts(&self) -> [usize; N];

    /// The piece over knot interval `k` (interval `k` of a direction is `[U[f+k], U[f+k+1]]`
    /// with `f` the index of the domain's first knot, `p` for a whole knot vector); `None`
    /// when that interval is empty or out of range.
    fn bezier_piece(&self, k: [usize; N]) -> Option<Self::Piece>;

    /// The smooth region that holds knot interval `k`: the piece of the patch between its C⁰
    /// breaks (interior knots of multiplicity ≥ the degree: corners of a curve, creases of a
    /// surface), as a window onto the patch whose evaluation at its ends is one-sided. The
    /// polish runs inside it, so that it never steps across a crease, where the derivatives
    /// jump. The patch itself when it has no such knot.
    fn region(&self, k: [usize; N]) -> Self;
}

// ---------------------------------------------------------------------------------------------
// Blossoming and de Casteljau on homogeneous points
// ---------------------------------------------------------------------------------------------

/// `(a + b) / 2`.
#[inline]
fn mid<H: Copy + Add<Output = H> + Mul<f32, Output = H>>(a: H, b: H) -> H {
    (a + b) * 0.5
}

/// The blossom `f(args[0], …, args[p−1])` of the degree-`p` B-spline over the non-empty span
/// `s` (`knots[s] < knots[s+1]`), with `ctrl[j] = P[s−p+j]`: de Boor's algorithm (the
/// triangular scheme of P&T eq. 5.15 / A5.2) with a distinct argument per level, which
/// evaluates the blossom (Ramshaw). With arguments in the span every `α` is in [0, 1], so
/// weights stay positive.
#[inline]
fn blossom<H: Copy + Add<Output = H> + Mul<f32, Output = H>>(
    knots: &[f32],
    p: usize,
    s: usize,
    ctrl: &[H; MAX_ORDER],
    args: &[f32; MAX_ORDER],
) -> H {
    let mut d = *ctrl;
    for r in 1..=p {
        let t = args[r - 1];
        for j in (r..=p).rev() {
            let lo = knots[s + j - p];
            let hi = knots[s + 1 + j - r];
            // hi ≥ knots[s+1] > knots[s] ≥ lo for a non-empty span.
            let alpha = (t - lo) / (hi - lo);
            d[j] = d[j - 1] * (1.0 - alpha) + d[j] * alpha;
        }
    }
    d[p]
}

/// Bézier control points of the degree-`p` B-spline over the non-empty span `s`: the `k`-th
/// is `f(a^(p−k), b^k)` over `[a, b] = [knots[s], knots[s+1]]`.
#[inline]
fn extract<H: Copy + Add<Output = H> + Mul<f32, Output = H>>(
    knots: &[f32],
    p: usize,
    s: usize,
    ctrl: &[H; MAX_ORDER],
) -> [H; MAX_ORDER] {
    let (a, b) = (knots[s], knots[s + 1]);
    let mut out = *ctrl;
    for (k, o) in out.iter_mut().enumerate().take(p + 1) {
        let mut args = [a; MAX_ORDER];
        for (r, arg) in args.iter_mut().enumerate().take(p) {
            if r >= p - k {
                *arg = b;
            }
        }
        *o = blossom(knots, p, s, ctrl, &args);
    }
    out
}

/// De Casteljau halving of `pts[0..=p]`: `pts` becomes the lower half, the upper half is
/// returned.
#[inline]
fn halve<H: Copy + Add<Output = H> + Mul<f32, Output = H>>(
    pts: &mut [H; MAX_ORDER],
    p: usize,
) -> [H; MAX_ORDER] {
    // Row r of the triangle overwrites w[0..=p−r]; w[p−r] is final after row r, so w ends up
    // holding the upper half, and w[0] of row r is the lower half's r-th point.
    let mut w = *pts;
    for r in 1..=p {
        for j in 0..=p - r {
            w[j] = mid(w[j], w[j + 1]);
        }
        pts[r] = w[0];
    }
    w
}

/// De Casteljau evaluation of `pts[0..=p]` at `s`.
#[inline]
fn de_casteljau<H: Copy + Add<Output = H> + Mul<f32, Output = H>>(
    pts: &[H; MAX_ORDER],
    p: usize,
    s: f32,
) -> H {
    let mut w = *pts;
    for r in 1..=p {
        for j in 0..=p - r {
            w[j] = w[j] * (1.0 - s) + w[j + 1] * s;
        }
    }
    w[0]
}

/// See [`BezierPiece::lower_bound`].
#[inline]
fn hull_lower_bound<P: Point>(points: impl Iterator<Item = P>, x: P, bb: &Aabb<P>) -> f32 {
    let box_lb = bb.distance_squared(x);
    let v = bb.center() - x;
    let v2 = v.length_squared();
    if !(v2 > 0.0 && v2.is_finite()) {
        return box_lb;
    }
    let m = points
        .map(|p| (p - x).dot(v))
        .fold(f32::INFINITY, nurbs::math::min);
    if m > 0.0 {
        // `max` drops a NaN from an overflowing m².
        nurbs::math::max(box_lb, m * m / v2)
    } else {
        box_lb
    }
}

#[inline]
fn cartesian<P: Point>(h: P::Hom) -> P {
    let (xw, w) = P::split(h);
    xw * (1.0 / w)
}

#[inline]
fn midpoint(a: f32, b: f32) -> f32 {
    0.5 * (a + b)
}

// ---------------------------------------------------------------------------------------------
// Curves
// ---------------------------------------------------------------------------------------------

/// A rational Bézier piece of a curve: `degree + 1` homogeneous control points over
/// `[params.0, params.1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurvePiece<P: Point> {
    pts: [P::Hom; MAX_ORDER],
    degree: usize,
    range: (f32, f32),
}

impl<P: Point> CurvePiece<P> {
    /// Degree.
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// Homogeneous control points `(w·P, w)`.
    pub fn points(&self) -> &[P::Hom] {
        &self.pts[..=self.degree]
    }
}

impl<P: Point> BezierPiece<P, 1> for CurvePiece<P> {
    const MAX_DEPTH: u32 = 16;

    fn params(&self) -> [(f32, f32); 1] {
        [self.range]
    }

    fn bounding_box(&self) -> Aabb<P> {
        let first = cartesian::<P>(self.pts[0]);
        let mut bb = Aabb {
            min: first,
            max: first,
        };
        for &h in &self.pts[1..=self.degree] {
            bb = bb.include(cartesian::<P>(h));
        }
        bb
    }

    fn lower_bound(&self, x: P, bb: &Aabb<P>) -> f32 {
        let pts = self.pts[..=self.degree].iter().map(|&h| cartesian::<P>(h));
        hull_lower_bound(pts, x, bb)
    }

    fn corner(&self, k: usize) -> Option<([f32; 1], P)> {
        match k {
            0 => Some(([self.range.0], cartesian::<P>(self.pts[0]))),
            1 => Some(([self.range.1], cartesian::<P>(self.pts[self.degree]))),
            _ => None,
        }
    }

    fn point_at(&self, s: [f32; 1]) -> P {
        cartesian::<P>(de_casteljau(&self.pts, self.degree, s[0]))
    }

    fn split_direction(&self) -> usize {
        0
    }

    fn split(&mut self, dir: usize) -> Self {
        if dir != 0 {
            return *self;
        }
        let m = midpoint(self.range.0, self.range.1);
        let upper = CurvePiece {
            pts: halve(&mut self.pts, self.degree),
            degree: self.degree,
            range: (m, self.range.1),
        };
        self.range.1 = m;
        upper
    }
}

impl<P: Point> BezierSplit<1> for Curve<'_, P> {
    type Piece = CurvePiece<P>;

    fn interval_counts(&self) -> [usize; 1] {
        [self.knots().span_indices().len()]
    }

    fn bezier_piece(&self, k: [usize; 1]) -> Option<CurvePiece<P>> {
        let p = self.degree();
        let knots = self.knots().as_slice();
        if k[0] >= self.interval_counts()[0] {
            return None;
        }
        let s = self.knots().span_indices().start + k[0];
        let (a, b) = (knots[s], knots[s + 1]);
        if a >= b {
            return None;
        }
        let mut ctrl = [P::Hom::default(); MAX_ORDER];
        ctrl[..=p].copy_from_slice(&self.points()[s - p..=s]);
        Some(CurvePiece {
            pts: extract(knots, p, s, &ctrl),
            degree: p,
            range: (a, b),
        })
    }

    fn region(&self, k: [usize; 1]) -> Self {
        let s = self.knots().span_indices().start + k[0];
        self.c0_pieces()
            .find(|c| c.knots().span_indices().contains(&s))
            .unwrap_or(*self)
    }
}

// ---------------------------------------------------------------------------------------------
// Surfaces
// ---------------------------------------------------------------------------------------------

/// A rational tensor-product Bézier piece of a surface: `(p + 1) × (q + 1)` homogeneous
/// control points `pts[i][j]` (`i` along u) over a parameter box.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfacePiece {
    pts: [[Vec4; MAX_ORDER]; MAX_ORDER],
    degree: (usize, usize),
    range: [(f32, f32); 2],
}

impl SurfacePiece {
    /// Degrees `(p, q)`.
    pub fn degree(&self) -> (usize, usize) {
        self.degree
    }

    /// Homogeneous control point `(i, j)`, or `None` outside the net.
    pub fn point(&self, i: usize, j: usize) -> Option<Vec4> {
        let (p, q) = self.degree;
        if i > p || j > q {
            return None;
        }
        Some(self.pts[i][j])
    }

    fn cartesian(&self, i: usize, j: usize) -> Vec3 {
        cartesian::<Vec3>(self.pts[i][j])
    }
}

impl BezierPiece<Vec3, 2> for SurfacePiece {
    const MAX_DEPTH: u32 = 9;

    fn params(&self) -> [(f32, f32); 2] {
        self.range
    }

    fn bounding_box(&self) -> Aabb<Vec3> {
        let (p, q) = self.degree;
        let first = self.cartesian(0, 0);
        let mut bb = Aabb {
            min: first,
            max: first,
        };
        for row in &self.pts[..=p] {
            for &h in &row[..=q] {
                bb = bb.include(cartesian::<Vec3>(h));
            }
        }
        bb
    }

    fn lower_bound(&self, x: Vec3, bb: &Aabb<Vec3>) -> f32 {
        let (p, q) = self.degree;
        let pts = self.pts[..=p]
            .iter()
            .flat_map(move |row| row[..=q].iter().map(|&h| cartesian::<Vec3>(h)));
        hull_lower_bound(pts, x, bb)
    }

    fn corner(&self, k: usize) -> Option<([f32; 2], Vec3)> {
        if k >= 4 {
            return None;
        }
        let (p, q) = self.degree;
        let (iu, iv) = (k & 1, (k >> 1) & 1);
        let u = if iu == 0 {
            self.range[0].0
        } else {
            self.range[0].1
        };
        let v = if iv == 0 {
            self.range[1].0
        } else {
            self.range[1].1
        };
        Some(([u, v], self.cartesian(iu * p, iv * q)))
    }

    fn point_at(&self, s: [f32; 2]) -> Vec3 {
        let (p, q) = self.degree;
        let mut col = [Vec4::ZERO; MAX_ORDER];
        for (c, row) in col.iter_mut().zip(&self.pts).take(p + 1) {
            *c = de_casteljau(row, q, s[1]);
        }
        cartesian::<Vec3>(de_casteljau(&col, p, s[0]))
    }

    fn split_direction(&self) -> usize {
        // Control-polygon lengths L along each direction, compared through
        // L_u² ≈ p Σ|ΔᵤP|² / (q + 1) (p legs per polygon, q + 1 polygons) and the same for v.
        let (p, q) = self.degree;
        let (mut su, mut sv) = (0.0f32, 0.0f32);
        for i in 0..=p {
            for j in 0..=q {
                let c = self.cartesian(i, j);
                if i < p {
                    su += (self.cartesian(i + 1, j) - c).length_squared();
                }
                if j < q {
                    sv += (self.cartesian(i, j + 1) - c).length_squared();
                }
            }
        }
        if su * (p * (p + 1)) as f32 >= sv * (q * (q + 1)) as f32 {
            0
        } else {
            1
        }
    }

    fn split(&mut self, dir: usize) -> Self {
        let (p, q) = self.degree;
        let mut upper = self.clone();
        match dir {
            0 => {
                for j in 0..=q {
                    let mut col = [Vec4::ZERO; MAX_ORDER];
                    for i in 0..=p {
                        col[i] = self.pts[i][j];
                    }
                    let hi = halve(&mut col, p);
                    for i in 0..=p {
                        self.pts[i][j] = col[i];
                        upper.pts[i][j] = hi[i];
                    }
                }
            }
            1 => {
                for i in 0..=p {
                    upper.pts[i] = halve(&mut self.pts[i], q);
                }
            }
            _ => return upper,
        }
        let m = midpoint(self.range[dir].0, self.range[dir].1);
        self.range[dir].1 = m;
        upper.range[dir].0 = m;
        upper
    }
}

impl BezierSplit<2> for Surface<'_> {
    type Piece = SurfacePiece;

    fn interval_counts(&self) -> [usize; 2] {
        let (ku, kv) = self.knots();
        [ku.span_indices().len(), kv.span_indices().len()]
    }

    fn bezier_piece(&self, k: [usize; 2]) -> Option<SurfacePiece> {
        let (p, q) = self.degree();
        let (knots_u, knots_v) = self.knots();
        let (ku, kv) = (knots_u.as_slice(), knots_v.as_slice());
        let counts = self.interval_counts();
        if k[0] >= counts[0] || k[1] >= counts[1] {
            return None;
        }
        let (su, sv) = (
            knots_u.span_indices().start + k[0],
            knots_v.span_indices().start + k[1],
        );
        let (ua, ub, va, vb) = (ku[su], ku[su + 1], kv[sv], kv[sv + 1]);
        if !(ua < ub && va < vb) {
            return None;
        }
        let nv = self.counts().1;
        let net = self.points();
        let mut pts = [[Vec4::ZERO; MAX_ORDER]; MAX_ORDER];
        // Along u, one control column at a time, then along v, row by row: the tensor-product
        // blossom is the u-blossom of the v-blossoms and vice versa.
        for j in 0..=q {
            let mut col = [Vec4::ZERO; MAX_ORDER];
            for i in 0..=p {
                col[i] = net[(su - p + i) * nv + (sv - q + j)];
            }
            let b = extract(ku, p, su, &col);
            for i in 0..=p {
                pts[i][j] = b[i];
            }
        }
        for row in pts.iter_mut().take(p + 1) {
            *row = extract(kv, q, sv, row);
        }
        Some(SurfacePiece {
            pts,
            degree: (p, q),
            range: [(ua, ub), (va, vb)],
        })
    }

    fn region(&self, k: [usize; 2]) -> Self {
        let (ku, kv) = self.knots();
        let (su, sv) = (
            ku.span_indices().start + k[0],
            kv.span_indices().start + k[1],
        );
        let pu = ku.c0_pieces().find(|w| w.span_indices().contains(&su));
        let pv = kv.c0_pieces().find(|w| w.span_indices().contains(&sv));
        match (pu, pv) {
            (Some(pu), Some(pv)) => self.window(pu, pv).unwrap_or(*self),
            _ => *self,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The search
// ---------------------------------------------------------------------------------------------

/// A smooth region of the patch (see [`BezierSplit::region`]) with its periodicity: every
/// polish asks for it, and a surface answers by sampling its boundary, so it is computed once
/// for the whole patch and inherited by the regions that span a whole closed direction.
#[derive(Clone, Copy)]
struct Cached<S, const N: usize> {
    patch: S,
    periodic: [bool; N],
}

impl<S: Patch<N>, const N: usize> Cached<S, N> {
    /// `region` of a patch whose own periodicity is `whole` over `domain`.
    fn new(region: S, whole: [bool; N], domain: [(f32, f32); N]) -> Self {
        let mut periodic = whole;
        let d = region.domain();
        for i in 0..N {
            periodic[i] &= d[i] == domain[i];
        }
        Cached {
            patch: region,
            periodic,
        }
    }
}

impl<S: Patch<N>, const N: usize> Patch<N> for Cached<S, N> {
    type P = S::P;

    fn domain(&self) -> [(f32, f32); N] {
        self.patch.domain()
    }

    fn jet(&self, t: [f32; N], order: usize) -> Jet<S::P, N> {
        self.patch.jet(t, order)
    }

    fn normal(&self, t: [f32; N], jet: &Jet<S::P, N>) -> S::P {
        self.patch.normal(t, jet)
    }

    fn bounding_box(&self) -> Aabb<S::P> {
        self.patch.bounding_box()
    }

    fn periodic(&self, tol: f32) -> [bool; N] {
        if tol == PERIODIC_TOL {
            self.periodic
        } else {
            self.patch.periodic(tol)
        }
    }

    fn collapsed(&self, tol: f32) -> [[bool; 2]; N] {
        self.patch.collapsed(tol)
    }
}

struct Search<'s, S: BezierSplit<N>, const N: usize> {
    patch: &'s S,
    /// Periodicity and domain of the whole patch.
    periodic: [bool; N],
    domain: [(f32, f32); N],
    /// The patch has no C⁰ knots: every region is the whole patch.
    smooth: bool,
    /// The smooth region of the root piece being searched: polishes run inside it.
    region: Cached<S, N>,
    x: S::P,
    cfg: GlobalConfig,
    max_depth: u32,
    best_t: [f32; N],
    /// The region `best_t` was found in (its final polish stays there).
    best_region: Cached<S, N>,
    best_d2: f32,
    /// `√best_d2`, kept for the pruning test.
    best_d: f32,
    visited: u32,
    polishes: u32,
}

impl<S: BezierSplit<N>, const N: usize> Search<'_, S, N> {
    /// The region of knot interval `k`, with its periodicity.
    fn region_of(&self, k: [usize; N]) -> Cached<S, N> {
        if self.smooth {
            return Cached {
                patch: *self.patch,
                periodic: self.periodic,
            };
        }
        Cached::new(self.patch.region(k), self.periodic, self.domain)
    }

    /// Takes `point` as the best if it is closer, or (`polished`) as close: a polished point
    /// wins a tie against a corner, whose distance can agree to the last bit while its parameter
    /// is off the stationary point.
    fn offer(&mut self, t: [f32; N], point: S::P, polished: bool) {
        let d2 = (point - self.x).length_squared();
        if d2 < self.best_d2 || (polished && d2 == self.best_d2) {
            self.best_d2 = d2;
            self.best_d = nurbs::math::sqrt(d2);
            self.best_t = t;
            self.best_region = self.region;
        }
    }

    /// No point within a box at squared distance `lb` can beat the best by more than the
    /// tolerance (NaN counts as hopeless, so the search always ends).
    fn hopeless(&self, lb: f32) -> bool {
        let reach = self.best_d - self.cfg.tolerance;
        !(reach > 0.0 && lb < reach * reach)
    }

    fn polish(&mut self, t0: [f32; N]) {
        let region = self.region;
        let (t, point) = self.run_polish(&region, t0);
        self.offer(t, point, true);
    }

    /// [`projected_newton`] from `t0` inside `region` (out of line: its state must not sit in
    /// every frame of the recursion).
    #[inline(never)]
    fn run_polish(&mut self, region: &Cached<S, N>, t0: [f32; N]) -> ([f32; N], S::P) {
        self.polishes = self.polishes.saturating_add(1);
        projected_newton(region, self.x, t0, &self.cfg.newton)
    }

    /// Pass 1: every piece's corners for a first upper bound; returns the (flat index of the)
    /// piece nearest by its lower bound, and the diagonal of the box of all pieces' control
    /// points (the patch's size). Out of line, like [`Self::root`], so that the pieces
    /// it extracts do not sit in [`closest_point`]'s frame during the recursion.
    #[inline(never)]
    fn survey(&mut self, counts: &[usize; N], total: usize) -> (Option<usize>, f32) {
        let mut nearest: Option<(usize, f32)> = None;
        let mut all: Option<Aabb<S::P>> = None;
        for flat in 0..total {
            let k = unflatten(flat, counts);
            if let Some(piece) = self.patch.bezier_piece(k) {
                self.region = self.region_of(k);
                for k in 0..1usize << N {
                    if let Some((t, point)) = piece.corner(k) {
                        self.offer(t, point, false);
                    }
                }
                let bb = piece.bounding_box();
                let lb = piece.lower_bound(self.x, &bb);
                if nearest.is_none_or(|(_, best)| lb < best) {
                    nearest = Some((flat, lb));
                }
                all = Some(match all {
                    Some(a) => a.include(bb.min).include(bb.max),
                    None => bb,
                });
            }
        }
        let size = all.map_or(0.0, |a| nurbs::math::sqrt((a.max - a.min).length_squared()));
        (nearest.map(|(flat, _)| flat), size)
    }

    /// Branch and bound from the piece over knot interval `k`.
    #[inline(never)]
    fn root(&mut self, k: [usize; N]) {
        // Recursing on the piece inside the option (not a copy of it) keeps one piece here.
        let mut slot = self.patch.bezier_piece(k);
        if let Some(piece) = slot.as_mut() {
            self.region = self.region_of(k);
            let bb = piece.bounding_box();
            self.descend(piece, bb, 0, false);
        }
    }

    /// Visits a piece whose box is `bb`, at `depth` halvings below its knot span. `polished`:
    /// a polish already ran from an enclosing piece.
    fn descend(&mut self, piece: &mut S::Piece, bb: Aabb<S::P>, depth: u32, polished: bool) {
        if self.hopeless(piece.lower_bound(self.x, &bb)) {
            return;
        }
        let leaf = depth >= self.max_depth;
        let Some(polished) = self.examine(piece, &bb, leaf, polished) else {
            return;
        };
        let dir = piece.split_direction();
        let mut upper = piece.split(dir);
        let bb_lo = piece.bounding_box();
        let bb_hi = upper.bounding_box();
        if piece.lower_bound(self.x, &bb_lo) <= upper.lower_bound(self.x, &bb_hi) {
            self.descend(piece, bb_lo, depth + 1, polished);
            self.descend(&mut upper, bb_hi, depth + 1, polished);
        } else {
            self.descend(&mut upper, bb_hi, depth + 1, polished);
            self.descend(piece, bb_lo, depth + 1, polished);
        }
    }

    /// The work on one piece that survived pruning, out of line so that its locals are not
    /// in every frame of the recursion: offers the corners, polishes where due, and returns
    /// `None` at a leaf (`leaf`: the depth cap is reached) or `Some(polished)` when the piece
    /// is to be split.
    #[inline(never)]
    fn examine(
        &mut self,
        piece: &S::Piece,
        bb: &Aabb<S::P>,
        leaf: bool,
        polished: bool,
    ) -> Option<bool> {
        self.visited = self.visited.saturating_add(1);
        for k in 0..1usize << N {
            if let Some((t, point)) = piece.corner(k) {
                self.offer(t, point, false);
            }
        }
        let params = piece.params();
        let mut middle = [0.0; N];
        for i in 0..N {
            middle[i] = midpoint(params[i].0, params[i].1);
        }
        let diag2 = (bb.max - bb.min).length_squared();
        // The first piece on a branch that is small against the best distance gets a polish:
        // its local minimum is a good upper bound early, which is what makes pruning bite.
        let polish_here =
            !polished && diag2 <= self.cfg.polish_ratio * self.cfg.polish_ratio * self.best_d2;
        if polish_here {
            self.polish(middle);
        }
        let tol2 = self.cfg.tolerance * self.cfg.tolerance;
        if !(leaf || diag2 <= tol2) {
            return Some(polished || polish_here);
        }
        // A leaf that survived pruning may still hold a better minimum than the best so far
        // (two basins can differ by less than a leaf's sampling error), so it gets its own
        // polish. A leaf can hold two minima, typically one inside and one on an edge of the
        // domain; when a corner is nearer than the middle, the polish from the middle may
        // slide into the other one, so polish from that corner as well.
        if !polish_here {
            self.polish(middle);
        }
        let d2_middle = (piece.point_at([0.5; N]) - self.x).length_squared();
        let mut nearest: Option<([f32; N], f32)> = None;
        for k in 0..1usize << N {
            if let Some((t, point)) = piece.corner(k) {
                let d2 = (point - self.x).length_squared();
                if d2 < d2_middle && nearest.is_none_or(|(_, best)| d2 < best) {
                    nearest = Some((t, d2));
                }
            }
        }
        if let Some((t, _)) = nearest {
            self.polish(t);
        }
        None
    }
}

/// Hard cap on the iterations of one polish, whatever [`NewtonConfig::max_iterations`] says.
const MAX_POLISH_ITERATIONS: u32 = 64;

/// The polish: Newton's method for `Ψ(t) = 0` as in [`newton`](crate::newton()) (P&T §6.1,
/// full Hessian `H = Sᵢ·Sⱼ + Γ·Sᵢⱼ`, stopping tests of eq. 6.4–6.5), made safe for a global
/// search:
/// - Levenberg–Marquardt damping, `δ = −(H + λ diag G)⁻¹ Ψ`, with `λ` raised until the step
///   does not move away from `x` and lowered after every success: pure Newton near a
///   minimum, a scaled gradient step in a curved valley or where `H` is indefinite. Plain
///   Newton with clamping can jump into another basin, or onto a corner of the domain, and
///   lose the minimum a leaf was sampling;
/// - bounds as an active set: a direction whose parameter sits on an open bound with `Ψᵢ` or
///   the step pushing outwards is held, and the others take the reduced step, so it
///   converges to minima on the boundary instead of stalling there.
///
/// Returns the parameters and the point there.
fn projected_newton<S: Patch<N>, const N: usize>(
    patch: &S,
    x: S::P,
    t0: [f32; N],
    cfg: &NewtonConfig,
) -> ([f32; N], S::P) {
    const LAMBDA_MIN: f32 = 1e-4;
    const ATTEMPTS: usize = 16;
    let domain = patch.domain();
    let periodic = patch.periodic(PERIODIC_TOL);
    let eps1_sq = cfg.point_tol * cfg.point_tol;
    let eps2_sq = cfg.cosine_tol * cfg.cosine_tol;
    let mut t = t0;
    let mut jet = patch.jet(t, 2);
    let mut lambda = 0.0f32;
    // The configured cap, but never unbounded work (a cap of u32::MAX with zero tolerances
    // would otherwise creep along the noise floor for a long time).
    for _ in 0..cfg.max_iterations.min(MAX_POLISH_ITERATIONS) {
        let gamma = jet.point - x;
        let g2 = gamma.length_squared();
        // Also stops on NaN (a NaN tolerance included).
        let apart = g2 > eps1_sq;
        if !apart {
            break;
        }
        let psi = jet.psi(gamma);
        let at_lower = |i: usize| !periodic[i] && t[i] <= domain[i].0;
        let at_upper = |i: usize| !periodic[i] && t[i] >= domain[i].1;
        let mut held = [false; N];
        for i in 0..N {
            held[i] = (at_lower(i) && psi[i] > 0.0) || (at_upper(i) && psi[i] < 0.0);
        }
        // P&T eq. (6.4) on the free directions.
        if (0..N).all(|i| held[i] || psi[i] * psi[i] <= eps2_sq * jet.d[i].length_squared() * g2) {
            break;
        }
        let hessian = jet.hessian(gamma);
        let metric = jet.metric();
        // Near the minimum the distance is flat to within the rounding of the evaluation
        // (coordinates carry errors of a few ε |S|), so a step may raise it by that much.
        let scale =
            nurbs::math::sqrt(jet.point.length_squared()) + nurbs::math::sqrt(x.length_squared());
        let noise = 8.0 * f32::EPSILON * nurbs::math::sqrt(g2) * scale;
        let mut moved = None;
        for _ in 0..ATTEMPTS {
            let Some(mut delta) = damped_step(&hessian, &metric, &psi, &held, lambda) else {
                lambda = nurbs::math::max(LAMBDA_MIN, 4.0 * lambda);
                continue;
            };
            // Also hold the directions on a bound that this step pushes outwards: a clamped
            // step need not go downhill.
            for _ in 0..N {
                let mut grown = false;
                for i in 0..N {
                    let out = (at_lower(i) && delta[i] < 0.0) || (at_upper(i) && delta[i] > 0.0);
                    if !held[i] && out {
                        held[i] = true;
                        grown = true;
                    }
                }
                if !grown {
                    break;
                }
                delta = damped_step(&hessian, &metric, &psi, &held, lambda).unwrap_or([0.0; N]);
            }
            // Stop the step where it first meets a bound, and land exactly on it: clamping
            // the other components instead would move along the boundary by a step computed
            // for a free parameter, possibly into another basin.
            let mut alpha = 1.0f32;
            let mut limit = None;
            for i in 0..N {
                if held[i] || periodic[i] {
                    continue;
                }
                let (a, b) = domain[i];
                let room = if delta[i] < 0.0 {
                    (t[i] - a) / -delta[i]
                } else if delta[i] > 0.0 {
                    (b - t[i]) / delta[i]
                } else {
                    f32::INFINITY
                };
                if room < alpha {
                    alpha = nurbs::math::max(0.0, room);
                    limit = Some((i, if delta[i] < 0.0 { a } else { b }));
                }
            }
            let mut tn = t;
            for i in 0..N {
                if !held[i] {
                    tn[i] = wrap_or_clamp(t[i] + alpha * delta[i], domain[i], periodic[i]);
                }
            }
            if let Some((i, bound)) = limit {
                tn[i] = bound;
            }
            let jn = patch.jet(tn, 2);
            if (jn.point - x).length_squared() <= g2 + noise {
                moved = Some((tn, jn));
                lambda = if lambda > 4.0 * LAMBDA_MIN {
                    0.25 * lambda
                } else {
                    0.0
                };
                break;
            }
            lambda = nurbs::math::max(LAMBDA_MIN, 4.0 * lambda);
        }
        let Some((tn, jn)) = moved else {
            break;
        };
        let mut dt = [0.0; N];
        for i in 0..N {
            dt[i] = tn[i] - t[i];
        }
        // A wrapped step is long in parameter while the point barely moves: measure both.
        let small = (jn.point - jet.point).length_squared() <= eps1_sq
            && jet.displacement(&dt).length_squared() <= eps1_sq;
        t = tn;
        jet = jn;
        if small {
            break;
        }
    }
    (t, jet.point)
}

/// `−(H + λ diag G)⁻¹ Ψ` on the directions not `held` (zero on the held ones); `None` where
/// the damped matrix is not positive definite.
fn damped_step<const N: usize>(
    hessian: &[[f32; N]; N],
    metric: &[[f32; N]; N],
    psi: &[f32; N],
    held: &[bool; N],
    lambda: f32,
) -> Option<[f32; N]> {
    let mut a = *hessian;
    let mut rhs = [0.0; N];
    // Marquardt's diag G, plus a little of Levenberg's identity (scaled by trace G) so that a
    // vanishing Sᵢ (a pole) is damped too.
    let floor = 1e-3 * crate::linalg::trace(metric) + f32::MIN_POSITIVE;
    for i in 0..N {
        if held[i] {
            for j in 0..N {
                a[i][j] = 0.0;
                a[j][i] = 0.0;
            }
            a[i][i] = 1.0;
        } else {
            a[i][i] += lambda * (metric[i][i] + floor);
            rhs[i] = -psi[i];
        }
    }
    let d = solve_spd(a, rhs, 1e-6)?;
    let mut out = [0.0; N];
    for i in 0..N {
        if !held[i] {
            out[i] = d[i];
        }
    }
    Some(out)
}

/// `t` wrapped into `[a, b]` on a closed direction, clamped on an open one (NaN → `a`).
fn wrap_or_clamp(t: f32, (a, b): (f32, f32), periodic: bool) -> f32 {
    if periodic && (t < a || t > b) {
        let len = b - a;
        clamp(t - len * libm::floorf((t - a) / len), (a, b))
    } else {
        clamp(t, (a, b))
    }
}

/// Knot-interval index number `flat` of a grid of `counts`, first direction fastest.
fn unflatten<const N: usize>(mut flat: usize, counts: &[usize; N]) -> [usize; N] {
    let mut k = [0; N];
    for i in 0..N {
        let c = counts[i].max(1);
        k[i] = flat % c;
        flat /= c;
    }
    k
}

/// The true closest point on `patch` to `x`, found without a starting guess (see the module
/// docs for the method). Total: for finite `x` every output is free of NaN; for a non-finite
/// `x` it returns the start of the domain with `distance_squared = f32::MAX`.
pub fn closest_point<S: BezierSplit<N>, const N: usize>(
    patch: &S,
    x: S::P,
    cfg: &GlobalConfig,
) -> Closest<S::P, N> {
    let domain = patch.domain();
    let mut start = [0.0; N];
    for i in 0..N {
        start[i] = domain[i].0;
    }
    if !x.is_finite() {
        let jet = patch.jet(start, 2);
        return Closest {
            t: start,
            point: jet.point,
            distance_squared: f32::MAX,
            normal: patch.normal(start, &jet),
            signed_distance: 0.0,
            pieces_visited: 0,
            polishes: 0,
        };
    }
    let d2 = (patch.jet(start, 0).point - x).length_squared();
    let periodic = patch.periodic(PERIODIC_TOL);
    let first = Cached::new(patch.region([0; N]), periodic, domain);
    let mut search = Search {
        patch,
        periodic,
        domain,
        smooth: first.patch.domain() == domain,
        region: first,
        x,
        cfg: *cfg,
        max_depth: u32::from(cfg.max_depth).min(S::Piece::MAX_DEPTH),
        best_t: start,
        best_region: first,
        best_d2: d2,
        best_d: nurbs::math::sqrt(d2),
        visited: 0,
        polishes: 0,
    };

    let counts = patch.interval_counts();
    let total = counts.iter().fold(1usize, |a, &c| a.saturating_mul(c));
    let (near, size) = search.survey(&counts, total);
    // `min` keeps the configured values for a NaN size (a patch beyond f32).
    search.cfg.tolerance = cfg.tolerance.min(RELATIVE_TOLERANCE * size);
    search.cfg.newton.point_tol = cfg.newton.point_tol.min(RELATIVE_TOLERANCE * size);
    let cfg = search.cfg;
    if let Some(near) = near {
        // Branch and bound, nearest piece first, then the rest in order.
        for flat in core::iter::once(near).chain((0..total).filter(|&f| f != near)) {
            search.root(unflatten(flat, &counts));
        }
    }
    // The final polish settles on the stationary point of the best basin. Near a minimum
    // the distance is flat, so a sample can beat the stationary point by rounding noise
    // alone; within the tolerance plus that noise, the polished point wins.
    let best_region = search.best_region;
    let (t_polished, point) = search.run_polish(&best_region, search.best_t);
    let scale = nurbs::math::sqrt(x.length_squared()) + nurbs::math::sqrt(point.length_squared());
    let slack = cfg.tolerance + 8.0 * f32::EPSILON * scale;
    let t = if nurbs::math::sqrt((point - x).length_squared()) <= search.best_d + slack {
        t_polished
    } else {
        search.best_t
    };
    let jet = patch.jet(t, 2);
    let normal = patch.normal(t, &jet);
    let gamma = x - jet.point;
    let distance_squared = gamma.length_squared();
    let mut signed_distance = gamma.dot(normal);
    if signed_distance.is_nan() {
        // Only when x − S overflows: report the (infinite) distance unsigned.
        signed_distance = f32::INFINITY;
    }
    Closest {
        t,
        point: jet.point,
        distance_squared,
        normal,
        signed_distance,
        pieces_visited: search.visited,
        polishes: search.polishes,
    }
}
