//! Validation of control points and weights, shared by curves and surfaces and so by every
//! loader (the viewer's JSON scenes, the device's wire scenes): one set of rules.

use crate::error::{At, NurbsError};
use crate::point::Point;

/// The largest of the weights that are finite and positive (0 when there is none): the
/// reference for [`crate::MIN_WEIGHT_RATIO`]. Weights that are themselves invalid are reported
/// by [`check_control_point`] and take no part here, so they cannot mask each other.
pub(crate) fn largest_weight(weights: impl Iterator<Item = f32>) -> f32 {
    weights
        .filter(|w| w.is_finite() && *w > 0.0)
        .fold(0.0, f32::max)
}

/// Checks one Cartesian control point and its weight against the rules in the crate docs:
/// weight finite and > 0, a normal `f32`, at least [`crate::MIN_WEIGHT_RATIO`] × `largest`
/// (the patch's largest weight); every coordinate finite and within
/// ±[`crate::MAX_COORDINATE`].
#[cfg(feature = "alloc")]
pub(crate) fn check_control_point<P: Point>(
    at: At,
    point: P,
    w: f32,
    largest: f32,
) -> Result<(), NurbsError> {
    check_weight(at, w, largest)?;
    check_point(at, point)
}

/// [`check_control_point`] for a homogeneous point `(w·P, w)`. The weight is checked first,
/// so a weight too small to divide by is reported as such, not as the overflow of `P`.
pub(crate) fn check_homogeneous<P: Point>(
    at: At,
    h: P::Hom,
    largest: f32,
) -> Result<(), NurbsError> {
    let (xw, w) = P::split(h);
    check_weight(at, w, largest)?;
    if !xw.is_finite() {
        return Err(NurbsError::PointNotFinite { at });
    }
    check_point(at, xw * (1.0 / w))
}

fn check_weight(at: At, w: f32, largest: f32) -> Result<(), NurbsError> {
    if !(w.is_finite() && w > 0.0) {
        return Err(NurbsError::Weight { at, value: w });
    }
    if !w.is_normal() || w < crate::MIN_WEIGHT_RATIO * largest {
        return Err(NurbsError::WeightTooSmall {
            at,
            value: w,
            largest,
        });
    }
    Ok(())
}

fn check_point<P: Point>(at: At, point: P) -> Result<(), NurbsError> {
    if !point.is_finite() {
        return Err(NurbsError::PointNotFinite { at });
    }
    let value = point.as_slice().iter().fold(0.0f32, |m, c| m.max(c.abs()));
    if value > crate::MAX_COORDINATE {
        return Err(NurbsError::PointOutOfRange { at, value });
    }
    Ok(())
}
