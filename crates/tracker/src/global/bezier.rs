//! The global search's pieces: every non-empty knot span of a patch as a rational Bézier
//! piece (its control points the blossoms of the span, de Boor with distinct arguments), the
//! bounds a piece gives on the distance to it, and its halving by de Casteljau (step 1 to 3
//! of the [module's algorithm](super)).

use core::ops::{Add, Mul};

use crate::patch::Patch;
use nurbs::{Aabb, Curve, MAX_ORDER, Point, Surface, Vec3, Vec4};

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
pub(super) fn mid<H: Copy + Add<Output = H> + Mul<f32, Output = H>>(a: H, b: H) -> H {
    (a + b) * 0.5
}

/// The blossom `f(args[0], …, args[p−1])` of the degree-`p` B-spline over the non-empty span
/// `s` (`knots[s] < knots[s+1]`), with `ctrl[j] = P[s−p+j]`: de Boor's algorithm (the
/// triangular scheme of P&T eq. 5.15 / A5.2) with a distinct argument per level, which
/// evaluates the blossom (Ramshaw). With arguments in the span every `α` is in [0, 1], so
/// weights stay positive.
#[inline]
pub(super) fn blossom<H: Copy + Add<Output = H> + Mul<f32, Output = H>>(
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
pub(super) fn extract<H: Copy + Add<Output = H> + Mul<f32, Output = H>>(
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
pub(super) fn halve<H: Copy + Add<Output = H> + Mul<f32, Output = H>>(
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
pub(super) fn de_casteljau<H: Copy + Add<Output = H> + Mul<f32, Output = H>>(
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
pub(super) fn hull_lower_bound<P: Point>(
    points: impl Iterator<Item = P>,
    x: P,
    bb: &Aabb<P>,
) -> f32 {
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
pub(super) fn cartesian<P: Point>(h: P::Hom) -> P {
    let (xw, w) = P::split(h);
    xw * (1.0 / w)
}

#[inline]
pub(super) fn midpoint(a: f32, b: f32) -> f32 {
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
