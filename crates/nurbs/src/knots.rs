//! Knot vectors: validation and span search (Piegl & Tiller A2.1).

use crate::MAX_DEGREE;
use crate::error::{Field, NurbsError};

/// Which parametric direction a knot vector belongs to; picks the field names for errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Dir {
    Curve,
    U,
    V,
}

impl Dir {
    pub(crate) fn degree_field(self) -> Field {
        match self {
            Dir::Curve => Field::Degree,
            Dir::U => Field::DegreeU,
            Dir::V => Field::DegreeV,
        }
    }
    pub(crate) fn knots_field(self) -> Field {
        match self {
            Dir::Curve => Field::Knots,
            Dir::U => Field::KnotsU,
            Dir::V => Field::KnotsV,
        }
    }
}

/// A validated, clamped knot vector of a given degree, borrowed.
///
/// Invariants (checked by [`Knots::new`]): `1 <= degree <= MAX_DEGREE`, at least `degree + 1`
/// control points, `len = points + degree + 1`, all knots finite and non-decreasing, the first
/// and last `degree + 1` knots equal (and no more than that), interior multiplicity at most
/// `degree`, and a domain of non-zero length. Any domain `[a, b]` is allowed.
///
/// A knot vector can also be a *window* onto part of its domain, between two of its knots
/// ([`Knots::c0_pieces`]): the domain, clamping and span search are then those of the window,
/// and at the window's ends evaluation is the one-sided limit from inside it. The knot values
/// and control points stay those of the whole vector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Knots<'a> {
    knots: &'a [f32],
    degree: usize,
    /// Index of the last knot equal to the domain start (`degree` for the whole vector).
    first: usize,
    /// Index of the first knot equal to the domain end (`n_points` for the whole vector).
    last: usize,
}

impl<'a> Knots<'a> {
    /// Validates `knots` for a curve of `degree` with `n_points` control points.
    ///
    /// The count rule is Piegl & Tiller §3.2, `m = n + p + 1` (`m + 1` knots for `n + 1`
    /// control points); clamping (ends of multiplicity `p + 1`) makes the curve start
    /// and end at its first and last control points.
    ///
    /// ```
    /// use nurbs::{Field, Knots, NurbsError};
    ///
    /// // Quadratic, 4 control points: 4 + 2 + 1 = 7 knots, domain [0, 2].
    /// let k = Knots::new(&[0.0, 0.0, 0.0, 1.0, 2.0, 2.0, 2.0], 2, 4)?;
    /// assert_eq!((k.degree(), k.n_points(), k.domain()), (2, 4, (0.0, 2.0)));
    /// // Span search (P&T A2.1): knots[i] <= u < knots[i + 1]; the end of the domain
    /// // belongs to the last non-empty span.
    /// assert_eq!(k.find_span(0.5), 2);
    /// assert_eq!(k.find_span(1.0), 3);
    /// assert_eq!(k.find_span(2.0), 3);
    ///
    /// // One knot short: the error says how many were needed.
    /// assert_eq!(
    ///     Knots::new(&[0.0, 0.0, 0.0, 1.0, 2.0, 2.0], 2, 4),
    ///     Err(NurbsError::KnotCount { field: Field::Knots, expected: 7, found: 6 })
    /// );
    /// // An interior knot of multiplicity 3 > p = 2 would tear the curve apart.
    /// assert_eq!(
    ///     Knots::new(&[0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 2.0, 2.0, 2.0], 2, 6),
    ///     Err(NurbsError::KnotMultiplicity { field: Field::Knots, index: 3, multiplicity: 3 })
    /// );
    /// // Not clamped: the curve would not pass through its end points.
    /// assert_eq!(
    ///     Knots::new(&[0.0, 0.0, 0.5, 1.0, 1.0, 1.0], 2, 3),
    ///     Err(NurbsError::NotClamped { field: Field::Knots })
    /// );
    /// # Ok::<(), NurbsError>(())
    /// ```
    pub fn new(knots: &'a [f32], degree: usize, n_points: usize) -> Result<Self, NurbsError> {
        Self::validate(knots, degree, n_points, Dir::Curve)
    }

    pub(crate) fn validate(
        knots: &'a [f32],
        degree: usize,
        n_points: usize,
        dir: Dir,
    ) -> Result<Self, NurbsError> {
        let field = dir.knots_field();
        if degree == 0 || degree > MAX_DEGREE {
            return Err(NurbsError::Degree {
                field: dir.degree_field(),
                degree,
            });
        }
        if n_points < degree + 1 {
            return Err(NurbsError::TooFewPoints {
                field: match dir {
                    Dir::Curve => Field::Points,
                    Dir::U => Field::PointsU,
                    Dir::V => Field::PointsV,
                },
                found: n_points,
                needed: degree + 1,
            });
        }
        // Saturating: a control point count near usize::MAX (garbage from a file or a wire)
        // must be a KnotCount error, not an overflow panic.
        let expected = n_points.saturating_add(degree + 1);
        if knots.len() != expected {
            return Err(NurbsError::KnotCount {
                field,
                expected,
                found: knots.len(),
            });
        }
        if let Some(index) = knots.iter().position(|k| !k.is_finite()) {
            return Err(NurbsError::KnotNotFinite { field, index });
        }
        if let Some(index) = knots.windows(2).position(|w| w[1] < w[0]) {
            return Err(NurbsError::KnotsDecreasing {
                field,
                index: index + 1,
            });
        }
        let p = degree;
        let last = knots.len() - 1;
        if knots[0] != knots[p] || knots[last - p] != knots[last] {
            return Err(NurbsError::NotClamped { field });
        }
        if knots[p] >= knots[last - p] {
            return Err(NurbsError::EmptyDomain { field });
        }
        let min_span = crate::MIN_SPAN_REL * (knots[last - p] - knots[p]);
        if let Some(index) = knots
            .windows(2)
            .position(|w| w[1] > w[0] && w[1] - w[0] < min_span)
        {
            return Err(NurbsError::SpanTooShort {
                field,
                index: index + 1,
            });
        }
        // Multiplicity of every distinct value: ends exactly p + 1, interior at most p.
        let mut start = 0;
        while start < knots.len() {
            let mut end = start;
            while end + 1 < knots.len() && knots[end + 1] == knots[start] {
                end += 1;
            }
            let multiplicity = end - start + 1;
            let at_end = start == 0 || end == last;
            let allowed = if at_end { p + 1 } else { p };
            if multiplicity > allowed {
                return Err(NurbsError::KnotMultiplicity {
                    field,
                    index: start,
                    multiplicity,
                });
            }
            start = end + 1;
        }
        Ok(Self::whole(knots, degree))
    }

    /// The whole domain of validated knots.
    pub(crate) fn whole(knots: &'a [f32], degree: usize) -> Self {
        Knots {
            knots,
            degree,
            first: degree,
            last: knots.len() - 1 - degree,
        }
    }

    /// A view over a knot vector that was validated before (by an owned type).
    #[cfg(feature = "alloc")]
    pub(crate) fn from_validated(knots: &'a [f32], degree: usize) -> Self {
        Self::whole(knots, degree)
    }

    /// The window's bounds: the index of the last knot equal to its start and of the first
    /// equal to its end (`(degree, knots.len() − 1 − degree)` for the whole vector). With the
    /// knot values and the degree they are all a window is, so an owner that keeps its knots
    /// in fixed-capacity storage (a tracker's chain) keeps a window as these two numbers and
    /// makes it again with [`Knots::window_unchecked`].
    #[inline]
    pub fn bounds(&self) -> (usize, usize) {
        (self.first, self.last)
    }

    /// The window `bounds` ([`Knots::bounds`]) onto `knots` of `degree`, a vector
    /// [`Knots::new`] accepted before and its owner kept unchanged since, without validating
    /// it again: O(1), for views made in a haptic tick. Data `Knots::new` refuses, or bounds
    /// that are not a window's, make a view whose evaluation may panic; debug builds check.
    #[inline]
    pub fn window_unchecked(knots: &'a [f32], degree: usize, bounds: (usize, usize)) -> Self {
        debug_assert!(
            knots.len() > degree + 1
                && Self::validate(knots, degree, knots.len() - degree - 1, Dir::Curve).is_ok()
                && degree <= bounds.0
                && bounds.0 < bounds.1
                && bounds.1 < knots.len() - degree,
            "Knots::window_unchecked on data Knots::new refuses"
        );
        Knots {
            knots,
            degree,
            first: bounds.0,
            last: bounds.1,
        }
    }

    /// Whether this is the whole domain, not a window onto part of it.
    #[inline]
    pub fn is_whole(&self) -> bool {
        self.first == self.degree && self.last == self.knots.len() - 1 - self.degree
    }

    /// Indices `i` of the non-empty spans `[knots[i], knots[i + 1]]` of the domain (or window).
    #[inline]
    pub fn span_indices(&self) -> core::ops::Range<usize> {
        self.first..self.last
    }

    /// Indices of the control points whose basis functions are non-zero somewhere in the
    /// domain (or window): `first − p ..= last − 1`.
    #[inline]
    pub fn point_indices(&self) -> core::ops::RangeInclusive<usize> {
        self.first - self.degree..=self.last - 1
    }

    /// Whether the interior knot at index `i` (inside the domain or window) is a C⁰ break: its
    /// multiplicity is at least the degree, so the curve is only C⁰ there and generally has a
    /// corner (a crease on a surface). Every interior knot of a degree-1 basis is one.
    fn is_c0_break(&self, i: usize) -> bool {
        let k = self.knots;
        let x = k[i];
        if !(x > k[self.first] && x < k[self.last]) {
            return false;
        }
        let mut lo = i;
        while lo > 0 && k[lo - 1] == x {
            lo -= 1;
        }
        let mut hi = i;
        while hi + 1 < k.len() && k[hi + 1] == x {
            hi += 1;
        }
        hi - lo + 1 >= self.degree
    }

    /// The pieces of the domain (or window) between consecutive C⁰ breaks
    /// (interior knots of multiplicity at least the degree), in order, as windows: one piece, equal to `self`, when there is
    /// no break. Each piece is smooth (at least C¹) inside.
    ///
    /// A B-spline of degree `p` is `C^(p−m)` at a knot of multiplicity `m` (Piegl & Tiller
    /// §2.2, P2.5), so the breaks are the interior knots with `m >= p`.
    ///
    /// ```
    /// use nurbs::Knots;
    ///
    /// // Quadratic: 1.0 has multiplicity 2 = p (a C⁰ break), 2.0 only 1 (C¹, no break).
    /// let k = Knots::new(&[0.0, 0.0, 0.0, 1.0, 1.0, 2.0, 3.0, 3.0, 3.0], 2, 6)?;
    /// let domains: Vec<_> = k.c0_pieces().map(|w| w.domain()).collect();
    /// assert_eq!(domains, [(0.0, 1.0), (1.0, 3.0)]);
    /// assert!(k.c0_pieces().all(|w| !w.is_whole()));
    /// // The pieces join again into the whole domain.
    /// let mut pieces = k.c0_pieces();
    /// let (a, b) = (pieces.next().unwrap(), pieces.next().unwrap());
    /// assert_eq!(a.extend_to(b), Some(k));
    /// // A window's span search stays inside it: at the break, the first piece answers with
    /// // its own last span (the limit from the left), the whole vector with the next one.
    /// assert_eq!((a.find_span(1.0), k.find_span(1.0)), (2, 4));
    /// # Ok::<(), nurbs::NurbsError>(())
    /// ```
    pub fn c0_pieces(&self) -> impl Iterator<Item = Knots<'a>> + use<'a> {
        let this = *self;
        let mut start = self.first;
        core::iter::from_fn(move || {
            if start >= this.last {
                return None;
            }
            // The next break after `start`: the first index of its run of equal knots.
            let mut end = start + 1;
            while end < this.last && !this.is_c0_break(end) {
                end += 1;
            }
            let piece = Knots {
                first: start,
                last: end,
                ..this
            };
            // The next piece starts at the last index of the break's run.
            let mut next = end;
            while next + 1 < this.last && this.knots[next + 1] == this.knots[end] {
                next += 1;
            }
            start = if end >= this.last { this.last } else { next };
            Some(piece)
        })
    }

    /// The window from the start of `self` to the end of `next`, when both are windows onto
    /// the same knot vector and `next` starts where `self` ends (consecutive
    /// [`Self::c0_pieces`]); `None` otherwise.
    pub fn extend_to(&self, next: Knots<'a>) -> Option<Knots<'a>> {
        let same = core::ptr::eq(self.knots, next.knots) && self.degree == next.degree;
        (same && next.first >= self.last && self.knots[self.last] == self.knots[next.first])
            .then_some(Knots {
                last: next.last,
                ..*self
            })
    }

    /// The window onto the single non-empty span `i` (`knots[i] < knots[i + 1]`, inside the
    /// domain or window), or `None`.
    pub fn span_window(&self, i: usize) -> Option<Knots<'a>> {
        if !(self.span_indices().contains(&i) && self.knots[i] < self.knots[i + 1]) {
            return None;
        }
        // `i` is the last index of its value and `i + 1` the first of its own, since
        // knots[i] < knots[i + 1].
        Some(Knots {
            first: i,
            last: i + 1,
            ..*self
        })
    }

    /// Degree of the basis.
    #[inline]
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// The knot values.
    #[inline]
    pub fn as_slice(&self) -> &'a [f32] {
        self.knots
    }

    /// Number of control points (basis functions).
    #[inline]
    pub fn n_points(&self) -> usize {
        self.knots.len() - self.degree - 1
    }

    /// Parameter domain `[a, b] = [knots[p], knots[n + 1]]`.
    #[inline]
    pub fn domain(&self) -> (f32, f32) {
        (self.knots[self.first], self.knots[self.last])
    }

    /// Length of the parameter domain.
    #[inline]
    pub fn domain_len(&self) -> f32 {
        let (a, b) = self.domain();
        b - a
    }

    /// Whether `u` lies in the closed domain.
    #[inline]
    pub fn contains(&self, u: f32) -> bool {
        let (a, b) = self.domain();
        u >= a && u <= b
    }

    /// `u` clamped into the domain; NaN maps to the start of the domain.
    #[inline]
    pub fn clamp(&self, u: f32) -> f32 {
        let (a, b) = self.domain();
        // `math::max(a, u)` is `a` for a NaN `u`.
        crate::math::min(b, crate::math::max(a, u))
    }

    /// Knot span index `i` with `knots[i] <= u < knots[i + 1]` (Piegl & Tiller A2.1), for `u`
    /// clamped into the domain. At `u = b` it returns the last non-empty span, so evaluation at
    /// the end of the domain is the limit from the left (and, in a window, at its start the
    /// limit from the right).
    #[inline]
    pub fn find_span(&self, u: f32) -> usize {
        let u = self.clamp(u);
        let k = self.knots;
        let (first, last) = (self.first, self.last);
        if u >= k[last] {
            return last - 1;
        }
        if u <= k[first] {
            return first;
        }
        // Invariant: k[low] <= u < k[high].
        let (mut low, mut high) = (first, last);
        while high - low > 1 {
            let mid = (low + high) / 2;
            if u < k[mid] {
                high = mid;
            } else {
                low = mid;
            }
        }
        low
    }
}
