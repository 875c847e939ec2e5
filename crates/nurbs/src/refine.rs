//! Shape-preserving edits of owned curves (`alloc` feature): knot insertion (Boehm's
//! algorithm, Piegl & Tiller §5.2, A5.1 with r = 1), splitting at a parameter by inserting it
//! to full multiplicity (P&T §5.3), and joining two curves that meet end to start.
//!
//! Every operation works on the homogeneous control points `(w·P, w)`, where knot insertion
//! is the plain B-spline one (P&T eq. 5.15 applied to `Pʷ`), so rational curves (circles,
//! arcs) keep their exact shape. Each result is validated again as a new [`CurveBuf`]: a knot
//! so close to an existing one that the span would be shorter than [`crate::MIN_SPAN_REL`]
//! is refused like any invalid knot vector.

use alloc::vec::Vec;
use core::fmt;

use crate::error::NurbsError;
use crate::owned::CurveBuf;
use crate::point::Point;

/// Why a curve edit was refused. The curve given is unchanged.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum RefineError {
    /// The parameter is NaN or infinite.
    ParameterNotFinite {
        /// The value given.
        u: f32,
    },
    /// The parameter lies outside the curve's domain (or on an end, for a split, where one
    /// piece would be empty).
    ParameterOutsideDomain {
        /// The value given.
        u: f32,
        /// The domain `[a, b]`.
        domain: (f32, f32),
    },
    /// The knot already has multiplicity `degree`: one more would tear the curve apart.
    MultiplicityFull {
        /// The knot.
        u: f32,
        /// Its multiplicity (the degree).
        multiplicity: usize,
    },
    /// Curves of different degrees cannot be joined without degree elevation, which this
    /// crate does not do.
    DegreeMismatch {
        /// Degree of the first curve.
        first: usize,
        /// Degree of the second curve.
        second: usize,
    },
    /// The first curve's end and the second's start are farther apart than the tolerance.
    EndsApart {
        /// Their distance (the curve's unit).
        gap: f32,
        /// The tolerance.
        tol: f32,
    },
    /// A control point index past the end.
    PointIndex {
        /// The index given.
        index: usize,
        /// Number of control points.
        count: usize,
    },
    /// The edited curve is invalid (its message names the field).
    Invalid(NurbsError),
}

impl From<NurbsError> for RefineError {
    fn from(e: NurbsError) -> Self {
        RefineError::Invalid(e)
    }
}

impl fmt::Display for RefineError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            RefineError::ParameterNotFinite { u } => {
                write!(f, "u: {u} is not a finite number")
            }
            RefineError::ParameterOutsideDomain { u, domain: (a, b) } => {
                write!(
                    f,
                    "u: {u} is outside the open domain ({a}, {b}) of the patch"
                )
            }
            RefineError::MultiplicityFull { u, multiplicity } => write!(
                f,
                "knots: u = {u} is already a knot of multiplicity {multiplicity} (the degree); \
                 one more would tear the patch apart"
            ),
            RefineError::DegreeMismatch { first, second } => write!(
                f,
                "degree: the patches have degrees {first} and {second}; only patches of one \
                 degree are joined (no degree elevation)"
            ),
            RefineError::EndsApart { gap, tol } => write!(
                f,
                "points: the first patch ends {gap} away from where the second starts (more \
                 than {tol})"
            ),
            RefineError::PointIndex { index, count } => write!(
                f,
                "points[{index}]: no such control point, the patch has {count}"
            ),
            RefineError::Invalid(e) => write!(f, "{e}"),
        }
    }
}

impl core::error::Error for RefineError {}

/// Knots and homogeneous points being refined, not yet validated.
struct Raw<H> {
    degree: usize,
    knots: Vec<f32>,
    points: Vec<H>,
}

impl<H: Copy + core::ops::Add<Output = H> + core::ops::Mul<f32, Output = H>> Raw<H> {
    /// Multiplicity of the value `u` in the knot vector.
    fn multiplicity(&self, u: f32) -> usize {
        self.knots.iter().filter(|&&k| k == u).count()
    }

    /// Inserts `u` once, for `a < u < b` (Boehm; P&T eq. 5.15 with r = 1): with `k` the span
    /// `U[k] <= u < U[k+1]`, `Q_i = α_i P_i + (1 − α_i) P_{i−1}` for `k − p + 1 <= i <= k`
    /// (indices where `α_i = (u − U[i]) / (U[i+p] − U[i])` lies strictly between 0 and 1;
    /// P&T's lower bound `k − p` has α = 1 when u is not yet a knot and is copied as it is),
    /// `Q_i = P_i` below and `Q_i = P_{i−1}` above.
    fn insert(&mut self, u: f32) {
        let p = self.degree;
        let k = self.knots.partition_point(|&x| x <= u) - 1;
        let s = self.multiplicity(u);
        let mut q = Vec::with_capacity(self.points.len() + 1);
        q.extend_from_slice(&self.points[..=k - p]);
        for i in k - p + 1..=k - s {
            let alpha = (u - self.knots[i]) / (self.knots[i + p] - self.knots[i]);
            q.push(self.points[i] * alpha + self.points[i - 1] * (1.0 - alpha));
        }
        q.extend_from_slice(&self.points[k - s..]);
        self.points = q;
        self.knots.insert(k + 1, u);
    }
}

impl<P: Point> CurveBuf<P> {
    fn raw(&self) -> Raw<P::Hom> {
        Raw {
            degree: self.degree(),
            knots: self.knots().to_vec(),
            points: self.points().to_vec(),
        }
    }

    /// `u` finite and strictly inside the domain.
    fn interior(&self, u: f32) -> Result<(), RefineError> {
        if !u.is_finite() {
            return Err(RefineError::ParameterNotFinite { u });
        }
        let domain = self.view().domain();
        if !(u > domain.0 && u < domain.1) {
            return Err(RefineError::ParameterOutsideDomain { u, domain });
        }
        Ok(())
    }

    /// The same curve with the knot `u` inserted once (one more control point), for `u`
    /// strictly inside the domain and of multiplicity below the degree.
    ///
    /// ```
    /// use nurbs::{RefineError, Vec2, construct};
    ///
    /// let (p0, p1, p2) = (Vec2::new(0.0, 0.0), Vec2::new(1.0, 2.0), Vec2::new(3.0, 1.0));
    /// let c = construct::bezier_curve(&[p0, p1, p2])?;
    /// let r = c.insert_knot(0.5)?;
    /// // Boehm (P&T eq. 5.15) on [0,0,0,1,1,1] at u = 1/2: both α are 1/2, so the new
    /// // polygon is P0, (P0 + P1)/2, (P1 + P2)/2, P2 (exact in f32: halves of small
    /// // integers).
    /// assert_eq!(r.knots(), [0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0]);
    /// let want = [p0, (p0 + p1) / 2.0, (p1 + p2) / 2.0, p2].map(|p| p.extend(1.0));
    /// assert_eq!(r.points(), want);
    /// // The shape is unchanged: both evaluate alike, to a few f32 roundings (1e-6 absolute
    /// // on coordinates ≤ 3 is about 4 ulp).
    /// for i in 0..=10 {
    ///     let u = i as f32 / 10.0;
    ///     assert!((r.view().point(u) - c.view().point(u)).length() <= 1e-6);
    /// }
    /// // A knot of full multiplicity (the degree) refuses one more.
    /// assert_eq!(
    ///     r.insert_knot(0.5)?.insert_knot(0.5),
    ///     Err(RefineError::MultiplicityFull { u: 0.5, multiplicity: 2 })
    /// );
    /// # Ok::<(), RefineError>(())
    /// ```
    pub fn insert_knot(&self, u: f32) -> Result<Self, RefineError> {
        self.interior(u)?;
        let mut raw = self.raw();
        let s = raw.multiplicity(u);
        if s >= raw.degree {
            return Err(RefineError::MultiplicityFull { u, multiplicity: s });
        }
        raw.insert(u);
        Ok(CurveBuf::new(raw.degree, raw.knots, raw.points)?)
    }

    /// The curve cut at `u` (strictly inside the domain) into the piece on `[a, u]` and the
    /// piece on `[u, b]`, which keep their parameters: `u` is inserted until it has
    /// multiplicity `degree` (P&T §5.3: the curve then passes through the control point there,
    /// `C(u)`, which both pieces share as their end and start).
    ///
    /// ```
    /// use nurbs::{Vec2, construct};
    ///
    /// let (p0, p1, p2) = (Vec2::new(0.0, 0.0), Vec2::new(1.0, 2.0), Vec2::new(3.0, 1.0));
    /// let c = construct::bezier_curve(&[p0, p1, p2])?;
    /// let (left, right) = c.split_at(0.5)?;
    /// // De Casteljau at 1/2 (P&T §1.3): the left half's polygon is P0, (P0 + P1)/2, M and
    /// // the right half's M, (P1 + P2)/2, P2, with M = C(1/2) = (P0 + 2 P1 + P2)/4.
    /// // Exact in f32 (quarters of small integers).
    /// let m = (p0 + 2.0 * p1 + p2) / 4.0;
    /// let h = |q: [Vec2; 3]| q.map(|p| p.extend(1.0));
    /// assert_eq!(left.points(), h([p0, (p0 + p1) / 2.0, m]));
    /// assert_eq!(right.points(), h([m, (p1 + p2) / 2.0, p2]));
    /// assert_eq!(left.knots(), [0.0, 0.0, 0.0, 0.5, 0.5, 0.5]);
    /// assert_eq!(right.knots(), [0.5, 0.5, 0.5, 1.0, 1.0, 1.0]);
    /// // Joined again, they are the curve with 1/2 inserted twice: the same shape.
    /// let joined = left.join(&right, 0.0)?;
    /// assert_eq!(joined.points().len(), 5);
    /// assert!((joined.view().point(0.3) - c.view().point(0.3)).length() <= 1e-6);
    /// # Ok::<(), nurbs::RefineError>(())
    /// ```
    pub fn split_at(&self, u: f32) -> Result<(Self, Self), RefineError> {
        self.interior(u)?;
        let mut raw = self.raw();
        let p = raw.degree;
        while raw.multiplicity(u) < p {
            raw.insert(u);
        }
        // U[j..j+p] are the p copies of u; the left piece has the j points before them and
        // closes with one more copy of u, the right one opens with it.
        let j = raw.knots.partition_point(|&x| x < u);
        let mut left_knots = raw.knots[..j + p].to_vec();
        left_knots.push(u);
        let mut right_knots = Vec::with_capacity(raw.knots.len() - j + 1);
        right_knots.push(u);
        right_knots.extend_from_slice(&raw.knots[j..]);
        let left = CurveBuf::new(p, left_knots, raw.points[..j].to_vec())?;
        let right = CurveBuf::new(p, right_knots, raw.points[j - 1..].to_vec())?;
        Ok((left, right))
    }

    /// This curve followed by `next`, as one curve, when both have the same degree and `next`
    /// starts within `tol` of where this one ends. `next`'s parameter is shifted to start where
    /// this one's domain ends; the joint is a knot of multiplicity `degree` (the join is C⁰ in
    /// general, and exactly the original curve again for the two pieces of [`Self::split_at`]).
    /// `next`'s weights are scaled so its first weight equals this one's last (the shape of a
    /// rational curve does not change when all its weights are scaled alike); the joint is
    /// this curve's end point, so `next`'s start moves to it by at most `tol`.
    pub fn join(&self, next: &Self, tol: f32) -> Result<Self, RefineError> {
        let p = self.degree();
        if next.degree() != p {
            return Err(RefineError::DegreeMismatch {
                first: p,
                second: next.degree(),
            });
        }
        let (a, b) = (self.view(), next.view());
        let gap = math_len(a.point(a.domain().1) - b.point(b.domain().0));
        // False for a NaN gap or tolerance too.
        let within = gap <= tol;
        if !within {
            return Err(RefineError::EndsApart { gap, tol });
        }
        let end = self.knots()[self.knots().len() - 1];
        let shift = end - next.knots()[0];
        let mut knots = self.knots()[..self.knots().len() - 1].to_vec();
        knots.extend(next.knots()[p + 1..].iter().map(|&k| k + shift));
        let w_end = P::split(self.points()[self.points().len() - 1]).1;
        let w_start = P::split(next.points()[0]).1;
        let scale = w_end / w_start;
        let mut points = self.points().to_vec();
        points.extend(next.points()[1..].iter().map(|&h| h * scale));
        Ok(CurveBuf::new(p, knots, points)?)
    }

    /// The curve with control point `index` moved to `to` (its weight unchanged).
    pub fn with_point(&self, index: usize, to: P) -> Result<Self, RefineError> {
        let count = self.points().len();
        let Some(&h) = self.points().get(index) else {
            return Err(RefineError::PointIndex { index, count });
        };
        let mut points = self.points().to_vec();
        points[index] = to.weighted(P::split(h).1);
        Ok(CurveBuf::new(self.degree(), self.knots().to_vec(), points)?)
    }

    /// The curve with the weight of control point `index` set to `w` (its Cartesian point
    /// unchanged); the weight rules of [`CurveBuf::new`] apply.
    pub fn with_weight(&self, index: usize, w: f32) -> Result<Self, RefineError> {
        let count = self.points().len();
        let Some(&h) = self.points().get(index) else {
            return Err(RefineError::PointIndex { index, count });
        };
        let (xw, w0) = P::split(h);
        let mut points = self.points().to_vec();
        points[index] = (xw * (1.0 / w0)).weighted(w);
        Ok(CurveBuf::new(self.degree(), self.knots().to_vec(), points)?)
    }
}

fn math_len<P: Point>(v: P) -> f32 {
    crate::math::sqrt(v.length_squared())
}
