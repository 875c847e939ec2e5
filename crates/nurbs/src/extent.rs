//! Degenerate geometry: the one check, run by [`Curve::new`](crate::Curve::new) and
//! [`Surface::new`](crate::Surface::new) and so by
//! every loader (the `scene/1` files, the device's wire scenes and their control-point
//! updates), that a curve has length and a surface area, span by span.
//!
//! A curve whose control points all coincide is a point; a knot span whose `p + 1` control
//! points coincide is a point too (on a span the `p + 1` basis functions are linearly
//! independent, so `C` is constant there exactly when they do, weights or not). A closest
//! point, a tangent and a normal mean nothing there, and a renderer pressed against it pulls
//! the hand towards that point from anywhere around it. Such data is refused at construction,
//! with the span named; evaluation never sees it.
//!
//! Curves are measured on their control points, with no evaluation: with positive weights a
//! span lies in the convex hull of its control points, so when they all lie within
//! [`MIN_EXTENT`] of the first, so does the span, and the refusal is never of a span whose
//! image is any longer. Surfaces can lose their area without any control points coinciding
//! (two rows on one line, a net folded onto a curve), so a cell is measured by its image: its
//! area by Gauss quadrature of `|S_u × S_v|` divided by the diameter of its control net (an
//! upper bound of the image's), a mean width. A side collapsed to a point (a sphere's pole, a
//! disk's centre) leaves the cells beside it their area, and is accepted.

use crate::MIN_EXTENT;
use crate::point::Point;

/// The largest distance of `points` from the first of them (0 for none).
pub(crate) fn spread<P: Point>(points: impl Iterator<Item = P>) -> f32 {
    let mut first = None;
    let mut largest = 0.0f32;
    for p in points {
        match first {
            None => first = Some(p),
            Some(f) => largest = largest.max((p - f).length_squared()),
        }
    }
    libm::sqrtf(largest)
}

/// The Cartesian form of a homogeneous point (its weight was validated: normal, positive).
pub(crate) fn cartesian<P: Point>(h: P::Hom) -> P {
    let (xw, w) = P::split(h);
    xw * (1.0 / w)
}

/// Gauss–Legendre nodes of order 2 on [−1, 1] (both weights 1): exact for cubics, enough to
/// tell a cell with area from one without.
pub(crate) const GAUSS_2: [f32; 2] = [-0.577_350_26, 0.577_350_26];

/// A mean width below [`MIN_EXTENT`], or NaN (none on validated data, but a NaN must not
/// pass as an area).
pub(crate) fn too_thin(width: f32) -> bool {
    width.is_nan() || width < MIN_EXTENT
}
