//! Axis-aligned bounding boxes from the control net.

use crate::point::Point;

/// An axis-aligned box. By the convex-hull property (positive weights), the box of the
/// Cartesian control points contains the whole curve or surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb<P> {
    /// Lower corner.
    pub min: P,
    /// Upper corner.
    pub max: P,
}

impl<P: Point> Aabb<P> {
    /// The box around homogeneous control points (each divided by its weight). `None` for an
    /// empty slice.
    pub fn from_homogeneous(points: &[P::Hom]) -> Option<Self> {
        let mut it = points.iter().map(|&h| {
            let (xw, w) = P::split(h);
            xw * (1.0 / w)
        });
        let first = it.next()?;
        Some(it.fold(
            Aabb {
                min: first,
                max: first,
            },
            |b, p| b.include(p),
        ))
    }

    /// The smallest box containing `self` and `p`.
    #[inline]
    pub fn include(self, p: P) -> Self {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// The smallest box containing both.
    #[inline]
    pub fn union(self, other: Self) -> Self {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// Whether `p` is inside or on the box.
    #[inline]
    pub fn contains(&self, p: P) -> bool {
        // Written with `<=` so that NaN coordinates are outside.
        let (lo, hi) = (p - self.min, self.max - p);
        lo.min(hi).min(P::ZERO) == P::ZERO && (lo.dot(lo) + hi.dot(hi)).is_finite()
    }

    /// Centre of the box.
    #[inline]
    pub fn center(&self) -> P {
        (self.min + self.max) * 0.5
    }

    /// Squared distance from `p` to the box (0 inside): a lower bound on the squared distance
    /// from `p` to anything inside the box.
    #[inline]
    pub fn distance_squared(&self, p: P) -> f32 {
        let clamped = p.max(self.min).min(self.max);
        (p - clamped).length_squared()
    }

    /// Squared distance from `p` to the farthest point of the box: an upper bound on the
    /// squared distance from `p` to anything inside.
    #[inline]
    pub fn max_distance_squared(&self, p: P) -> f32 {
        let a = p - self.min;
        let b = self.max - p;
        let far = a.max(-a).max(b.max(-b));
        far.length_squared()
    }
}
