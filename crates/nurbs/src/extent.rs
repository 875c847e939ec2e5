//! Degenerate geometry: the one check, run by [`Curve::new`] and [`Surface::new`] and so by
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
use crate::curve::Curve;
use crate::error::NurbsError;
use crate::point::Point;
use crate::surface::Surface;
use glam::Vec3;

/// The largest distance of `points` from the first of them (0 for none).
fn spread<P: Point>(points: impl Iterator<Item = P>) -> f32 {
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
fn cartesian<P: Point>(h: P::Hom) -> P {
    let (xw, w) = P::split(h);
    xw * (1.0 / w)
}

/// Refuses a curve of no length ([`NurbsError::ZeroLength`]) or with a knot span collapsed
/// to a point ([`NurbsError::CollapsedSpan`]), both measured against [`MIN_EXTENT`].
pub(crate) fn check_curve<P: Point>(curve: &Curve<'_, P>) -> Result<(), NurbsError> {
    let points = curve.points();
    let extent = spread(points.iter().map(|&h| cartesian::<P>(h)));
    if extent < MIN_EXTENT {
        return Err(NurbsError::ZeroLength { extent });
    }
    let knots = curve.knots();
    let (k, p) = (knots.as_slice(), knots.degree());
    for i in knots.span_indices().filter(|&i| k[i] < k[i + 1]) {
        let extent = spread(points[i - p..=i].iter().map(|&h| cartesian::<P>(h)));
        if extent < MIN_EXTENT {
            return Err(NurbsError::CollapsedSpan {
                index: i,
                first: i - p,
                last: i,
                extent,
            });
        }
    }
    Ok(())
}

/// Gauss–Legendre nodes of order 2 on [−1, 1] (both weights 1): exact for cubics, enough to
/// tell a cell with area from one without.
const GAUSS_2: [f32; 2] = [-0.577_350_26, 0.577_350_26];

/// The area of the cell `[u0, u1] × [v0, v1]` of `s`: `∫∫ |S_u × S_v| du dv` by 2 × 2
/// Gauss–Legendre quadrature.
fn cell_area(s: &Surface<'_>, (u0, u1): (f32, f32), (v0, v1): (f32, f32)) -> f32 {
    let (hu, hv) = (0.5 * (u1 - u0), 0.5 * (v1 - v0));
    let mut sum = 0.0;
    for gu in GAUSS_2 {
        for gv in GAUSS_2 {
            let d = s.derivs(u0 + hu * (1.0 + gu), v0 + hv * (1.0 + gv), 1);
            sum += d.du.cross(d.dv).length();
        }
    }
    sum * hu * hv
}

/// The diagonal of the box of the Cartesian control points `(i, j)`, `i` in `rows`, `j` in
/// `cols`: at least the diameter of the image of the cell they control.
fn net_diameter(
    s: &Surface<'_>,
    rows: core::ops::RangeInclusive<usize>,
    cols: core::ops::RangeInclusive<usize>,
) -> f32 {
    let nv = s.counts().1;
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for i in rows {
        for &h in &s.points()[i * nv..][cols.clone()] {
            let p = h.truncate() / h.w;
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    (hi - lo).length()
}

/// A mean width below [`MIN_EXTENT`], or NaN (none on validated data, but a NaN must not
/// pass as an area).
fn too_thin(width: f32) -> bool {
    width.is_nan() || width < MIN_EXTENT
}

/// Refuses a surface of no area ([`NurbsError::ZeroArea`]) or with a cell (a pair of knot
/// spans) collapsed to a line, a curve or a point ([`NurbsError::CollapsedCell`]): the area
/// over the diameter of the control net, a mean width, below [`MIN_EXTENT`]. One evaluation
/// pass: four first-derivative evaluations per cell.
pub(crate) fn check_surface(s: &Surface<'_>) -> Result<(), NurbsError> {
    let (ku, kv) = s.knots();
    let (p, q) = s.degree();
    let (uk, vk) = (ku.as_slice(), kv.as_slice());
    let mut area = 0.0;
    let mut collapsed = None;
    for i in ku.span_indices().filter(|&i| uk[i] < uk[i + 1]) {
        for j in kv.span_indices().filter(|&j| vk[j] < vk[j + 1]) {
            let cell = cell_area(s, (uk[i], uk[i + 1]), (vk[j], vk[j + 1]));
            area += cell;
            let width = cell / net_diameter(s, i - p..=i, j - q..=j).max(MIN_EXTENT);
            if collapsed.is_none() && too_thin(width) {
                collapsed = Some(NurbsError::CollapsedCell {
                    span: (i, j),
                    width,
                });
            }
        }
    }
    let (nu, nv) = s.counts();
    let width = area / net_diameter(s, 0..=nu - 1, 0..=nv - 1).max(MIN_EXTENT);
    if too_thin(width) {
        return Err(NurbsError::ZeroArea { width });
    }
    collapsed.map_or(Ok(()), Err)
}
