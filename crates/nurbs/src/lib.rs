#![doc = include_str!("../README.md")]
#![cfg_attr(not(feature = "std"), no_std)]
#![warn(missing_docs)]

#[cfg(feature = "alloc")]
extern crate alloc;

mod basis;
mod bbox;
#[cfg(feature = "alloc")]
pub mod construct;
mod control;
mod curve;
mod error;
mod extent;
mod knots;
pub mod math;
#[cfg(feature = "alloc")]
mod owned;
mod point;
#[cfg(feature = "alloc")]
mod refine;
mod surface;

pub use basis::{basis_funs, ders_basis_funs};
pub use bbox::Aabb;
pub use curve::{Curve, CurveDerivs, CurveFrame};
pub use error::{At, Field, NurbsError};
pub use glam::{Vec2, Vec3, Vec4};
pub use knots::Knots;
#[cfg(feature = "alloc")]
pub use owned::{CurveBuf, SurfaceBuf};
pub use point::Point;
#[cfg(feature = "alloc")]
pub use refine::RefineError;
pub use surface::{Surface, SurfaceDerivs};

/// Highest supported degree in either direction.
pub const MAX_DEGREE: usize = 7;
/// Highest supported order (`degree + 1`): the size of the fixed basis-function buffers.
pub const MAX_ORDER: usize = MAX_DEGREE + 1;
/// Smallest non-empty knot span, relative to the domain length. Shorter spans make the
/// basis derivatives overflow `f32` (they scale with 1 / span^order), so validation rejects
/// them.
pub const MIN_SPAN_REL: f32 = 1e-5;
/// Smallest weight of a patch relative to its largest weight. f32 keeps about seven
/// significant digits, so a weight a million times smaller than another of the same patch
/// contributes to the rational denominator at the level of the others' rounding, and the
/// rational derivatives, which divide by the denominator once per order, overflow near its
/// control point (a weight of 1e-20 beside weights of 1 gives infinite second derivatives).
/// Validation rejects such weights; weights are scale-free, so scale them closer together.
pub const MIN_WEIGHT_RATIO: f32 = 1e-6;
/// Largest magnitude of a control point coordinate (in the model's unit: metres in a scene).
/// f32 resolves 10⁶ only to about 0.06, far coarser than any haptic contact, and the
/// trackers' squared distances and the derivatives over the shortest allowed knot spans
/// ([`MIN_SPAN_REL`]) of larger coordinates come near `f32::MAX` (a coordinate of 3e38
/// evaluates to infinite derivatives). Validation rejects larger coordinates.
pub const MAX_COORDINATE: f32 = 1e6;
/// Smallest extent of geometry, in the model's unit (metres in a scene): a curve whose
/// control points all lie within it of the first has no length, a knot span whose control
/// points do collapses to a point, and a surface or a cell whose area over the diameter of
/// its control net is less than it collapses to a line, a curve or a point; validation
/// refuses them ([`NurbsError::ZeroLength`], [`NurbsError::CollapsedSpan`],
/// [`NurbsError::ZeroArea`], [`NurbsError::CollapsedCell`]).
///
/// 1 µm, from `f32` at the workspace's scale. Scenes live within 0.25 m of the device's
/// origin, where `f32` steps are at most 2⁻²⁶ m ≈ 15 nm; a control point stored as
/// `(w·P, w)` and divided back lands within about two steps of where it was meant, so points
/// meant to coincide lie within 0.05 µm of each other (√3 × 2 × 15 nm). 1 µm is twenty times
/// that, so geometry collapsed in `f32` rounding is refused as surely as geometry collapsed
/// exactly. It is also a twentieth of the pantograph's encoder quantum (19.6 µm at the
/// handle) and far below anything a hand resolves, so no geometry that can be felt is
/// refused. (Far from the origin, at coordinates of 10 m and more, `f32` rounding itself
/// exceeds 1 µm and only geometry collapsed more exactly than that is caught.)
pub const MIN_EXTENT: f32 = 1e-6;
/// Highest derivative order evaluated.
pub const MAX_DERIV: usize = 2;
