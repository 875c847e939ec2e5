//! Global closest-point search: the true closest point on a patch, found from nothing (no
//! warm start), by branch and bound over the patch's rational Bézier pieces and a Newton
//! polish (P&T §6.1) at the leaves.
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
//!    Cartesian control points, so the squared distance from `x` to their box is a lower
//!    bound for the piece; its corner control points lie on the patch and give upper bounds.
//! 3. **Branch and bound.** Pieces are visited nearest box first, depth-first, halved at the
//!    parameter midpoint by de Casteljau on the homogeneous points (a surface piece across
//!    its longer direction, measured on the control net), nearer child first. A piece is
//!    pruned when its lower bound cannot beat the best distance so far by more than
//!    [`GlobalConfig::tolerance`].
//! 4. **Leaves.** A piece whose box is small against the best distance so far (or smaller
//!    than the tolerance, or at the depth cap) is polished by [`newton`] on the whole patch
//!    from the piece's middle parameter. The best point seen is polished once more at the end.
//!
//! # Stack
//!
//! The search recurses; each level keeps one piece (the sibling still to visit). A surface
//! piece is `[[Vec4; 8]; 8]` (1 KiB), and the depth is capped at
//! [`BezierPiece::MAX_DEPTH`] = 10 for surfaces, so the recursion needs about 11 KiB
//! (measured on x86-64, release: under 14 KiB for the whole call, Newton included). Curve
//! pieces are 128 B (`Vec4`) or 96 B (`Vec3`) with a depth cap of 16: about 4 KiB.

use core::ops::{Add, Mul};

use crate::newton::{NewtonConfig, newton};
use crate::patch::{Jet, Patch};
use crate::track::PERIODIC_TOL;
use nurbs::{Aabb, Curve, MAX_ORDER, Point, Surface, Vec3, Vec4};

/// Settings of [`closest_point`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GlobalConfig {
    /// Distance tolerance (metres). A piece is pruned unless it could hold a point closer than
    /// the best so far by more than this, and a piece smaller than this is not split further.
    pub tolerance: f32,
    /// A piece whose control box diagonal is at most this fraction of the best distance so
    /// far is a leaf: at that size the distance has a single minimum over the piece, and
    /// Newton from its middle finds it.
    pub leaf_ratio: f32,
    /// Depth cap of the subdivision; the piece type's [`BezierPiece::MAX_DEPTH`] caps it again
    /// so that the stack stays bounded.
    pub max_depth: u8,
    /// The polish.
    pub newton: NewtonConfig,
}

impl Default for GlobalConfig {
    fn default() -> Self {
        GlobalConfig {
            tolerance: 1e-7,
            leaf_ratio: 0.25,
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
    /// Bézier pieces (and sub-pieces) the branch and bound examined.
    pub pieces_visited: u32,
    /// Newton polishes run.
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
pub trait BezierSplit<const N: usize>: Patch<N> {
    /// A piece.
    type Piece: BezierPiece<Self::P, N>;

    /// Number of knot intervals of the domain per direction, empty ones included
    /// (`n_points − degree`).
    fn interval_counts(&self) -> [usize; N];

    /// The piece over knot interval `k` (interval `k` of a direction is `[U[p+k], U[p+k+1]]`);
    /// `None` when that interval is empty or out of range.
    fn bezier_piece(&self, k: [usize; N]) -> Option<Self::Piece>;
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
/// `s` (`knots[s] < knots[s+1]`), with `ctrl[j] = P[s−p+j]`: de Boor's algorithm with a
/// distinct argument per level (P&T §5.2 via the de Boor recurrence, Ramshaw's blossoming).
/// With arguments in the span every `α` is in [0, 1], so weights stay positive.
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
    let m = points.map(|p| (p - x).dot(v)).fold(f32::INFINITY, f32::min);
    if m > 0.0 {
        // `max` drops a NaN from an overflowing m².
        box_lb.max(m * m / v2)
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
fn lerp(a: f32, b: f32) -> f32 {
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
        let m = lerp(self.range.0, self.range.1);
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
        [self.points().len() - self.degree()]
    }

    fn bezier_piece(&self, k: [usize; 1]) -> Option<CurvePiece<P>> {
        let p = self.degree();
        let knots = self.knots().as_slice();
        if k[0] >= self.interval_counts()[0] {
            return None;
        }
        let s = p + k[0];
        let (a, b) = (knots[s], knots[s + 1]);
        if !(a < b) {
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
    const MAX_DEPTH: u32 = 10;

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
        let m = lerp(self.range[dir].0, self.range[dir].1);
        self.range[dir].1 = m;
        upper.range[dir].0 = m;
        upper
    }
}

impl BezierSplit<2> for Surface<'_> {
    type Piece = SurfacePiece;

    fn interval_counts(&self) -> [usize; 2] {
        let (nu, nv) = self.counts();
        let (p, q) = self.degree();
        [nu - p, nv - q]
    }

    fn bezier_piece(&self, k: [usize; 2]) -> Option<SurfacePiece> {
        let (p, q) = self.degree();
        let (ku, kv) = self.knots();
        let (ku, kv) = (ku.as_slice(), kv.as_slice());
        let counts = self.interval_counts();
        if k[0] >= counts[0] || k[1] >= counts[1] {
            return None;
        }
        let (su, sv) = (p + k[0], q + k[1]);
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
}

// ---------------------------------------------------------------------------------------------
// The search
// ---------------------------------------------------------------------------------------------

/// The patch with its periodicity computed once: [`newton`] asks for it on every call, and a
/// surface answers by sampling its boundary.
struct Cached<'s, S, const N: usize> {
    patch: &'s S,
    periodic: [bool; N],
}

impl<S: Patch<N>, const N: usize> Patch<N> for Cached<'_, S, N> {
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
}

struct Search<'s, S: BezierSplit<N>, const N: usize> {
    patch: Cached<'s, S, N>,
    x: S::P,
    cfg: GlobalConfig,
    max_depth: u32,
    best_t: [f32; N],
    best_d2: f32,
    /// `√best_d2`, kept for the pruning test.
    best_d: f32,
    visited: u32,
    polishes: u32,
}

impl<S: BezierSplit<N>, const N: usize> Search<'_, S, N> {
    /// Takes `point` as the best if it is closer, or (`ties`) as close: a polished point wins
    /// a tie against a corner, whose distance can agree to the last bit while its parameter
    /// is off the stationary point.
    fn offer(&mut self, t: [f32; N], point: S::P, ties: bool) {
        let d2 = (point - self.x).length_squared();
        if d2 < self.best_d2 || (ties && d2 == self.best_d2) {
            self.best_d2 = d2;
            self.best_d = libm::sqrtf(d2);
            self.best_t = t;
        }
    }

    /// No point within a box at squared distance `lb` can beat the best by more than the
    /// tolerance (NaN counts as hopeless, so the search always ends).
    fn hopeless(&self, lb: f32) -> bool {
        let reach = self.best_d - self.cfg.tolerance;
        !(reach > 0.0 && lb < reach * reach)
    }

    fn polish(&mut self, t0: [f32; N]) {
        self.polishes = self.polishes.saturating_add(1);
        let r = newton(&self.patch, self.x, t0, &self.cfg.newton);
        self.offer(r.t, r.point, true);
    }

    /// Visits a piece whose box is `bb`. `polished`: a Newton polish already ran from an
    /// enclosing piece.
    fn descend(&mut self, piece: &mut S::Piece, bb: Aabb<S::P>, depth: u32, polished: bool) {
        if self.hopeless(piece.lower_bound(self.x, &bb)) {
            return;
        }
        self.visited = self.visited.saturating_add(1);
        for k in 0..1usize << N {
            if let Some((t, point)) = piece.corner(k) {
                self.offer(t, point, false);
            }
        }
        let params = piece.params();
        let mut middle = [0.0; N];
        for i in 0..N {
            middle[i] = lerp(params[i].0, params[i].1);
        }
        let diag2 = (bb.max - bb.min).length_squared();
        // The first piece on a branch that is small against the best distance gets a polish:
        // its local minimum is a good upper bound early, which is what makes pruning bite.
        let mut polished = polished;
        if !polished && diag2 <= self.cfg.leaf_ratio * self.cfg.leaf_ratio * self.best_d2 {
            self.polish(middle);
            polished = true;
        }
        let tol2 = self.cfg.tolerance * self.cfg.tolerance;
        if diag2 <= tol2 || depth >= self.max_depth {
            // A leaf: its middle is a sample; a sample that beats everything so far sits in
            // the best basin seen yet, so polish it.
            let before = self.best_d2;
            self.offer(middle, piece.point_at([0.5; N]), false);
            if self.best_d2 < before {
                self.polish(middle);
            }
            return;
        }
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
    let mut search = Search {
        patch: Cached {
            patch,
            periodic: patch.periodic(PERIODIC_TOL),
        },
        x,
        cfg: *cfg,
        max_depth: u32::from(cfg.max_depth).min(S::Piece::MAX_DEPTH),
        best_t: start,
        best_d2: d2,
        best_d: libm::sqrtf(d2),
        visited: 0,
        polishes: 0,
    };

    // Pass 1: every piece's corners for a first upper bound, and the piece nearest by box.
    let counts = patch.interval_counts();
    let total = counts.iter().fold(1usize, |a, &c| a.saturating_mul(c));
    let mut nearest: Option<(usize, f32)> = None;
    for flat in 0..total {
        if let Some(piece) = patch.bezier_piece(unflatten(flat, &counts)) {
            for k in 0..1usize << N {
                if let Some((t, point)) = piece.corner(k) {
                    search.offer(t, point, false);
                }
            }
            let bb = piece.bounding_box();
            let lb = piece.lower_bound(x, &bb);
            if nearest.is_none_or(|(_, best)| lb < best) {
                nearest = Some((flat, lb));
            }
        }
    }
    // Pass 2: branch and bound, nearest piece first, then the rest in order.
    if let Some((near, _)) = nearest {
        for flat in core::iter::once(near).chain((0..total).filter(|&f| f != near)) {
            if let Some(mut piece) = patch.bezier_piece(unflatten(flat, &counts)) {
                let bb = piece.bounding_box();
                search.descend(&mut piece, bb, 0, false);
            }
        }
    }
    search.polish(search.best_t);

    let t = search.best_t;
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
