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

mod bezier;
mod polish;

use bezier::midpoint;
pub use bezier::{BezierPiece, BezierSplit, CurvePiece, SurfacePiece};
use polish::projected_newton;

use crate::newton::NewtonConfig;
use crate::patch::{Jet, Patch};
use crate::track::{PERIODIC_TOL, clamp};
use nurbs::{Aabb, Point};

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
