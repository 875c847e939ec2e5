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
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Knots<'a> {
    knots: &'a [f32],
    degree: usize,
}

impl<'a> Knots<'a> {
    /// Validates `knots` for a curve of `degree` with `n_points` control points.
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
        Ok(Knots { knots, degree })
    }

    /// A view over a knot vector that was validated before (by an owned type).
    #[cfg(feature = "alloc")]
    pub(crate) fn from_validated(knots: &'a [f32], degree: usize) -> Self {
        Knots { knots, degree }
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
        (
            self.knots[self.degree],
            self.knots[self.knots.len() - 1 - self.degree],
        )
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
        // `max` returns the non-NaN operand, so NaN becomes `a`.
        u.max(a).min(b)
    }

    /// Knot span index `i` with `knots[i] <= u < knots[i + 1]` (Piegl & Tiller A2.1), for `u`
    /// clamped into the domain. At `u = b` it returns the last non-empty span, so evaluation at
    /// the end of the domain is the limit from the left.
    #[inline]
    pub fn find_span(&self, u: f32) -> usize {
        let u = self.clamp(u);
        let k = self.knots;
        let p = self.degree;
        let n = self.n_points() - 1;
        if u >= k[n + 1] {
            return n;
        }
        if u <= k[p] {
            return p;
        }
        // Invariant: k[low] <= u < k[high].
        let (mut low, mut high) = (p, n + 1);
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
