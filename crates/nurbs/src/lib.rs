#![doc = include_str!("../README.md")]
#![cfg_attr(not(feature = "std"), no_std)]
#![warn(missing_docs)]

#[cfg(feature = "alloc")]
extern crate alloc;

mod basis;
mod bbox;
#[cfg(feature = "alloc")]
pub mod construct;
mod curve;
mod error;
mod knots;
#[cfg(feature = "alloc")]
mod owned;
mod point;
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
pub use surface::{Surface, SurfaceDerivs};

/// Highest supported degree in either direction.
pub const MAX_DEGREE: usize = 7;
/// Highest supported order (`degree + 1`): the size of the fixed basis-function buffers.
pub const MAX_ORDER: usize = MAX_DEGREE + 1;
/// Smallest non-empty knot span, relative to the domain length. Shorter spans make the
/// basis derivatives overflow `f32` (they scale with 1 / span^order), so validation rejects
/// them.
pub const MIN_SPAN_REL: f32 = 1e-5;
/// Highest derivative order evaluated.
pub const MAX_DERIV: usize = 2;
