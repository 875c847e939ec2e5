//! Typed validation errors. Every invalid input is rejected once, at construction, with an
//! error that names the field; evaluation itself never fails.

use core::fmt;

/// Which input field an error refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    /// Degree of a curve.
    Degree,
    /// Degree of a surface along u.
    DegreeU,
    /// Degree of a surface along v.
    DegreeV,
    /// Knot vector of a curve.
    Knots,
    /// Knot vector of a surface along u.
    KnotsU,
    /// Knot vector of a surface along v.
    KnotsV,
    /// Control points.
    Points,
    /// Control net rows (the count along u).
    PointsU,
    /// Control net columns (the count along v).
    PointsV,
    /// Weights.
    Weights,
}

impl Field {
    /// The field's name as it appears in a `scene/1` file.
    pub const fn name(self) -> &'static str {
        match self {
            Field::Degree => "degree",
            Field::DegreeU => "degree[0] (u)",
            Field::DegreeV => "degree[1] (v)",
            Field::Knots => "knots",
            Field::KnotsU => "knots[0] (u)",
            Field::KnotsV => "knots[1] (v)",
            Field::Points => "points",
            Field::PointsU => "points (rows, along u)",
            Field::PointsV => "points[i] (along v)",
            Field::Weights => "weights",
        }
    }
}

/// Position of a control point or weight: `[i]` on a curve, `[i][j]` on a surface.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum At {
    /// Index into a curve's control polygon.
    I(usize),
    /// Index into a surface's control net, `i` along u and `j` along v.
    Ij(usize, usize),
}

impl fmt::Display for At {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            At::I(i) => write!(f, "[{i}]"),
            At::Ij(i, j) => write!(f, "[{i}][{j}]"),
        }
    }
}

/// Why a curve or surface definition was rejected.
///
/// Each variant names the field (and the index) at fault, and its `Display` text uses the
/// names of a `scene/1` file, so a loader can pass it on to whoever wrote the file.
///
/// ```
/// use nurbs::{At, Curve, NurbsError, Vec2, Vec3};
///
/// let knots = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
/// // A zero weight on the middle point: the rational quotient would divide by zero there.
/// let points = [Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 1.0)];
/// let err = Curve::<Vec2>::new(2, &knots, &points).unwrap_err();
/// assert_eq!(err, NurbsError::Weight { at: At::I(1), value: 0.0 });
/// assert_eq!(err.to_string(), "weights[1]: weight 0 must be finite and > 0");
///
/// // A weight a million times smaller than the others is refused too (`MIN_WEIGHT_RATIO`).
/// let points = [Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, 0.0, 1e-7), Vec3::new(1.0, 0.0, 1.0)];
/// assert!(matches!(
///     Curve::<Vec2>::new(2, &knots, &points),
///     Err(NurbsError::WeightTooSmall { at: At::I(1), largest: 1.0, .. })
/// ));
/// // Degree 8 is above `MAX_DEGREE`.
/// let err = Curve::<Vec2>::new(8, &knots, &points).unwrap_err();
/// assert_eq!(err.to_string(), "degree: degree 8 is not supported (must be 1..=7)");
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum NurbsError {
    /// Degree is 0 or above [`crate::MAX_DEGREE`].
    Degree {
        /// Which degree.
        field: Field,
        /// The degree given.
        degree: usize,
    },
    /// Knot count is not (number of control points) + degree + 1.
    KnotCount {
        /// Which knot vector.
        field: Field,
        /// Required count.
        expected: usize,
        /// Given count.
        found: usize,
    },
    /// A knot is NaN or infinite.
    KnotNotFinite {
        /// Which knot vector.
        field: Field,
        /// Index of the knot.
        index: usize,
    },
    /// `knots[index] < knots[index - 1]`.
    KnotsDecreasing {
        /// Which knot vector.
        field: Field,
        /// Index of the first knot that is smaller than its predecessor.
        index: usize,
    },
    /// The first or last `degree + 1` knots are not equal (the curve must interpolate its end
    /// points).
    NotClamped {
        /// Which knot vector.
        field: Field,
    },
    /// First and last knot are equal: the parameter domain has zero length.
    EmptyDomain {
        /// Which knot vector.
        field: Field,
    },
    /// Two distinct knots are closer than [`crate::MIN_SPAN_REL`] of the domain: the basis
    /// functions' derivatives would overflow `f32` there.
    SpanTooShort {
        /// Which knot vector.
        field: Field,
        /// Index of the second knot of the span.
        index: usize,
    },
    /// An interior knot repeats more than `degree` times, which would tear the curve apart.
    KnotMultiplicity {
        /// Which knot vector.
        field: Field,
        /// Index of the first copy of the knot.
        index: usize,
        /// How often it repeats.
        multiplicity: usize,
    },
    /// Fewer than `degree + 1` control points in a direction.
    TooFewPoints {
        /// Which control points.
        field: Field,
        /// Given count.
        found: usize,
        /// Minimum count (degree + 1).
        needed: usize,
    },
    /// A control point has a NaN or infinite coordinate.
    PointNotFinite {
        /// Position of the point.
        at: At,
    },
    /// A weight is not finite or not strictly positive.
    Weight {
        /// Position of the weight.
        at: At,
        /// The offending value.
        value: f32,
    },
    /// A weight that is valid on its own but too small for `f32` evaluation: subnormal, or
    /// below [`crate::MIN_WEIGHT_RATIO`] × the patch's largest weight.
    WeightTooSmall {
        /// Position of the weight.
        at: At,
        /// The offending value.
        value: f32,
        /// The patch's largest (finite, positive) weight.
        largest: f32,
    },
    /// A control point coordinate larger in magnitude than [`crate::MAX_COORDINATE`].
    PointOutOfRange {
        /// Position of the point.
        at: At,
        /// Its largest coordinate magnitude.
        value: f32,
    },
    /// The number of weights differs from the number of control points.
    WeightCount {
        /// Required count.
        expected: usize,
        /// Given count.
        found: usize,
    },
    /// A row of the control net (or of the weights) has a different length from the first.
    RaggedNet {
        /// Which array.
        field: Field,
        /// Index of the offending row.
        row: usize,
        /// Length of row 0.
        expected: usize,
        /// Length of this row.
        found: usize,
    },
    /// Every control point of a curve lies within [`crate::MIN_EXTENT`] of `points[0]`: the
    /// curve is a single point, with no length (a closed curve whose points all collapsed).
    ZeroLength {
        /// The largest distance of a control point from `points[0]`.
        extent: f32,
    },
    /// The control points of a knot span of a curve, `points[first]` to `points[last]`, all
    /// lie within [`crate::MIN_EXTENT`] of the first: the span's image is a point.
    CollapsedSpan {
        /// Index of the span's first knot (the span is `knots[index]` to `knots[index + 1]`).
        index: usize,
        /// The span's first control point.
        first: usize,
        /// The span's last control point.
        last: usize,
        /// The largest distance of one of them from `points[first]`.
        extent: f32,
    },
    /// A surface whose area over the diameter of its control net (a mean width) is less than
    /// [`crate::MIN_EXTENT`]: it lies on a line, a curve or a point.
    ZeroArea {
        /// The mean width.
        width: f32,
    },
    /// A cell of a surface (knot span `span.0` along u by `span.1` along v) whose area over the
    /// diameter of its control points is less than [`crate::MIN_EXTENT`]: the cell collapsed
    /// to a line, a curve or a point. (A side collapsed to a point, such as a sphere's pole,
    /// leaves its cells their area.)
    CollapsedCell {
        /// Indices of the cell's first knots along u and v.
        span: (usize, usize),
        /// The cell's mean width.
        width: f32,
    },
    /// A control point has the wrong number of coordinates.
    Dimension {
        /// Position of the point.
        at: At,
        /// Required coordinates.
        expected: usize,
        /// Given coordinates.
        found: usize,
    },
}

impl fmt::Display for NurbsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use NurbsError::*;
        match *self {
            Degree { field, degree } => write!(
                f,
                "{}: degree {degree} is not supported (must be 1..={})",
                field.name(),
                crate::MAX_DEGREE
            ),
            KnotCount {
                field,
                expected,
                found,
            } => write!(
                f,
                "{}: expected {expected} knots (control points + degree + 1), found {found}",
                field.name()
            ),
            KnotNotFinite { field, index } => {
                write!(f, "{}[{index}]: knot is not a finite number", field.name())
            }
            KnotsDecreasing { field, index } => write!(
                f,
                "{}[{index}]: knots must be non-decreasing, but this one is smaller than the one before",
                field.name()
            ),
            NotClamped { field } => write!(
                f,
                "{}: the first and last degree + 1 knots must be equal (clamped knot vector)",
                field.name()
            ),
            EmptyDomain { field } => write!(
                f,
                "{}: first and last knot are equal, the parameter domain is empty",
                field.name()
            ),
            SpanTooShort { field, index } => write!(
                f,
                "{}[{index}]: knot differs from the one before by less than {} of the domain (merge the two knots or space them out)",
                field.name(),
                crate::MIN_SPAN_REL
            ),
            KnotMultiplicity {
                field,
                index,
                multiplicity,
            } => write!(
                f,
                "{}[{index}]: interior knot repeated {multiplicity} times, more than the degree (the patch would fall apart)",
                field.name()
            ),
            TooFewPoints {
                field,
                found,
                needed,
            } => write!(
                f,
                "{}: {found} control points, at least degree + 1 = {needed} needed",
                field.name()
            ),
            PointNotFinite { at } => write!(f, "points{at}: coordinate is not a finite number"),
            Weight { at, value } => {
                write!(f, "weights{at}: weight {value} must be finite and > 0")
            }
            WeightTooSmall {
                at,
                value,
                largest: _,
            } if !value.is_normal() => write!(
                f,
                "weights{at}: weight {value:e} is subnormal in f32 (below {:e}): its reciprocal \
                 overflows and rational evaluation gives NaN; weights are scale-free, scale \
                 them all up",
                f32::MIN_POSITIVE
            ),
            WeightTooSmall { at, value, largest } => write!(
                f,
                "weights{at}: weight {value:e} is less than {:e} of the patch's largest weight \
                 {largest:e}: f32 keeps about 7 significant digits, so its point would vanish \
                 in rounding beside the others and the rational derivatives overflow; bring \
                 the weights closer together",
                crate::MIN_WEIGHT_RATIO
            ),
            PointOutOfRange { at, value } => write!(
                f,
                "points{at}: coordinate magnitude {value:e} exceeds {:e} (the model's unit, \
                 metres in a scene): too coarse in f32 and its derivatives overflow",
                crate::MAX_COORDINATE
            ),
            WeightCount { expected, found } => write!(
                f,
                "weights: {found} weights given for {expected} control points"
            ),
            RaggedNet {
                field,
                row,
                expected,
                found,
            } => write!(
                f,
                "{}[{row}]: row has {found} entries, row 0 has {expected} (control net must be rectangular)",
                field.name()
            ),
            Dimension {
                at,
                expected,
                found,
            } => write!(f, "points{at}: {found} coordinates, expected {expected}"),
            ZeroLength { extent } => write!(
                f,
                "points: every control point lies within {extent:.1e} of points[0], less than \
                 {:.0e} (1 µm in a scene): the curve has no length, it is a single point",
                crate::MIN_EXTENT
            ),
            CollapsedSpan {
                index,
                first,
                last,
                extent,
            } => write!(
                f,
                "knots[{index}] to knots[{}]: the span's control points points[{first}] to \
                 points[{last}] all lie within {extent:.1e} of points[{first}], less than \
                 {:.0e} (1 µm in a scene): the span collapses to a point, it has no length; \
                 move them apart or remove the span",
                index + 1,
                crate::MIN_EXTENT
            ),
            ZeroArea { width } => write!(
                f,
                "points: the surface has no area: its area over the diameter of its control \
                 net is {width:.1e}, less than {:.0e} (1 µm in a scene): it lies on a line, a \
                 curve or a point",
                crate::MIN_EXTENT
            ),
            CollapsedCell {
                span: (i, j),
                width,
            } => write!(
                f,
                "{}[{i}] to [{}] by {}[{j}] to [{}]: the cell has no area: its area over the \
                 diameter of its control points is {width:.1e}, less than {:.0e} (1 µm in a \
                 scene): it collapses to a line, a curve or a point",
                Field::KnotsU.name(),
                i + 1,
                Field::KnotsV.name(),
                j + 1,
                crate::MIN_EXTENT
            ),
        }
    }
}

impl core::error::Error for NurbsError {}
