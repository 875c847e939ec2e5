#![doc = include_str!("../README.md")]
#![warn(missing_docs)]

pub mod band;
mod body;
mod params;
pub mod shape;

pub use body::{Body, Coupling, Energy, Nodes};
pub use params::{DEFAULT_PLASTIC_TIME_S, Fixed, MAX_PARAM, Params, Quantity};
pub use shape::Shape;

/// Why a deformable object could not be built, loaded or stepped. The parameter errors name
/// the scene file's field (`{field}` for a curve; [`DynamicsError::field`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DynamicsError {
    /// A parameter out of its range.
    #[error("{}: {value} is not {rule} up to {MAX_PARAM:e}", quantity.field(false))]
    Param {
        /// Which.
        quantity: Quantity,
        /// Its value.
        value: f64,
        /// What it must be.
        rule: &'static str,
    },
    /// Neither tension nor bending: nothing brings the object back.
    #[error("tension and bending are both 0: the object would have no stiffness")]
    NoStiffness,
    /// A fixed control point that the patch does not have.
    #[error("fixed: control point {index} does not exist (the patch has {count})")]
    FixedIndex {
        /// The index given.
        index: usize,
        /// The patch's number of control points.
        count: usize,
    },
    /// A control point listed twice in `fixed`.
    #[error("fixed: control point {index} is listed twice")]
    FixedTwice {
        /// The index.
        index: usize,
    },
    /// A load or point list of the wrong length.
    #[error("expected {expected} control points, found {found}")]
    PointCount {
        /// The patch's number of control points.
        expected: usize,
        /// Given.
        found: usize,
    },
    /// A load with a non-finite entry.
    #[error("the load has a non-finite component")]
    Load,
    /// A step that is not a positive time up to 1 s, or whose system cannot be factored.
    #[error("step: {dt_s} s is not a time step in (0, 1] s")]
    Step {
        /// The step asked for.
        dt_s: f64,
    },
    /// The rest shape stops (zero speed or a degenerate metric) at a quadrature point, where
    /// arc length and area are undefined.
    #[error(
        "the rest shape is degenerate at (u, v) = ({:.4}, {:.4}): its parametrisation stops there, so arc length is undefined",
        params[0], params[1]
    )]
    ZeroSpeed {
        /// Where.
        params: [f64; 2],
    },
    /// Nothing holds the object against a static load (or a mode): its stiffness with the
    /// fixed points is singular.
    #[error(
        "fixed: the object is not held: it can move without deforming; fix at least one \
         control point (with bending only: two of a curve, three not on one line of a surface)"
    )]
    NotHeld,
    /// The mass matrix is singular (a rest shape of zero length or area).
    #[error("the rest shape has no length or area to carry mass")]
    Degenerate,
}

impl DynamicsError {
    /// The message with a surface's field names (`density_kg_per_m2`, …) where the error names
    /// a parameter.
    pub fn message(&self, surface: bool) -> String {
        match self {
            DynamicsError::Param {
                quantity,
                value,
                rule,
            } => format!(
                "{}: {value} is not {rule} up to {MAX_PARAM:e}",
                quantity.field(surface)
            ),
            other => other.to_string(),
        }
    }
}
