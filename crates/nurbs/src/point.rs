//! The one abstraction over dimension: planar (`Vec2`) and spatial (`Vec3`) curves share every
//! algorithm through [`Point`].

use core::fmt::Debug;
use core::ops::{Add, AddAssign, Mul, Neg, Sub, SubAssign};
use glam::{Vec2, Vec3, Vec4};

/// A Cartesian point or vector type that NURBS curves can live in.
///
/// `Hom` is the homogeneous (weighted) form `(w·x, w)` used for rational evaluation
/// (Piegl & Tiller §4.2): `Vec3` for planar points, `Vec4` for spatial ones.
pub trait Point:
    Copy
    + Debug
    + Default
    + PartialEq
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<f32, Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
{
    /// Homogeneous form `(w·x, w)`.
    type Hom: Copy
        + Debug
        + Default
        + PartialEq
        + Add<Output = Self::Hom>
        + Sub<Output = Self::Hom>
        + Mul<f32, Output = Self::Hom>
        + AddAssign;
    /// Number of Cartesian coordinates.
    const DIM: usize;
    /// The zero vector.
    const ZERO: Self;

    /// `(w·self, w)`.
    fn weighted(self, w: f32) -> Self::Hom;
    /// Splits a homogeneous value into its first `DIM` coordinates and its weight, without
    /// dividing.
    fn split(h: Self::Hom) -> (Self, f32);
    /// Dot product.
    fn dot(self, other: Self) -> f32;
    /// Component-wise minimum.
    fn min(self, other: Self) -> Self;
    /// Component-wise maximum.
    fn max(self, other: Self) -> Self;
    /// All coordinates finite.
    fn is_finite(self) -> bool;
    /// Coordinates as a slice.
    fn as_slice(&self) -> &[f32];
    /// Builds a point from exactly `DIM` coordinates; `None` for any other length.
    fn from_coords(c: &[f32]) -> Option<Self>;
    /// Squared norm of the "cross product" of `a` and `b`: `|a × b|²` in 3-D, the squared
    /// perp-dot product in 2-D. Computed as `|a|²|b|² − (a·b)²` is numerically worse, so each
    /// dimension uses its exact form.
    fn cross_norm_squared(a: Self, b: Self) -> f32;
    /// Signed (2-D: positive when turning counter-clockwise) or unsigned (3-D) curvature
    /// numerator: `a ⊥· b` in 2-D, `|a × b|` in 3-D.
    fn curvature_numerator(d1: Self, d2: Self) -> f32;
    /// The unit normal of a curve with unit tangent `t` and second derivative `d2`.
    ///
    /// Planar: `n = t × k̂ = (t.y, −t.x)`, so a counter-clockwise closed curve has outward
    /// normals. Spatial: the principal normal (the part of `d2` orthogonal to `t`, pointing to the
    /// centre of curvature); on a straight piece, where that is undefined, a fixed unit vector
    /// orthogonal to `t`.
    fn curve_normal(t: Self, d2: Self) -> Self;

    /// Squared length.
    #[inline]
    fn length_squared(self) -> f32 {
        self.dot(self)
    }

    /// Unit vector in the direction of `self`, or `None` if `self` is (numerically) zero or not
    /// finite.
    #[inline]
    fn try_normalize(self) -> Option<Self> {
        let l2 = self.length_squared();
        if l2 > f32::MIN_POSITIVE && l2.is_finite() {
            let n = self * (1.0 / crate::math::sqrt(l2));
            Some(n)
        } else {
            None
        }
    }
}

impl Point for Vec2 {
    type Hom = Vec3;
    const DIM: usize = 2;
    const ZERO: Self = Vec2::ZERO;

    #[inline]
    fn weighted(self, w: f32) -> Vec3 {
        (self * w).extend(w)
    }
    #[inline]
    fn split(h: Vec3) -> (Self, f32) {
        (h.truncate(), h.z)
    }
    #[inline]
    fn dot(self, other: Self) -> f32 {
        Vec2::dot(self, other)
    }
    #[inline]
    fn min(self, other: Self) -> Self {
        Vec2::min(self, other)
    }
    #[inline]
    fn max(self, other: Self) -> Self {
        Vec2::max(self, other)
    }
    #[inline]
    fn is_finite(self) -> bool {
        Vec2::is_finite(self)
    }
    #[inline]
    fn as_slice(&self) -> &[f32] {
        self.as_ref()
    }
    #[inline]
    fn from_coords(c: &[f32]) -> Option<Self> {
        match c {
            [x, y] => Some(Vec2::new(*x, *y)),
            _ => None,
        }
    }
    #[inline]
    fn cross_norm_squared(a: Self, b: Self) -> f32 {
        let c = a.perp_dot(b);
        c * c
    }
    #[inline]
    fn curvature_numerator(d1: Self, d2: Self) -> f32 {
        d1.perp_dot(d2)
    }
    #[inline]
    fn curve_normal(t: Self, _d2: Self) -> Self {
        Vec2::new(t.y, -t.x)
    }
}

impl Point for Vec3 {
    type Hom = Vec4;
    const DIM: usize = 3;
    const ZERO: Self = Vec3::ZERO;

    #[inline]
    fn weighted(self, w: f32) -> Vec4 {
        (self * w).extend(w)
    }
    #[inline]
    fn split(h: Vec4) -> (Self, f32) {
        (h.truncate(), h.w)
    }
    #[inline]
    fn dot(self, other: Self) -> f32 {
        Vec3::dot(self, other)
    }
    #[inline]
    fn min(self, other: Self) -> Self {
        Vec3::min(self, other)
    }
    #[inline]
    fn max(self, other: Self) -> Self {
        Vec3::max(self, other)
    }
    #[inline]
    fn is_finite(self) -> bool {
        Vec3::is_finite(self)
    }
    #[inline]
    fn as_slice(&self) -> &[f32] {
        self.as_ref()
    }
    #[inline]
    fn from_coords(c: &[f32]) -> Option<Self> {
        match c {
            [x, y, z] => Some(Vec3::new(*x, *y, *z)),
            _ => None,
        }
    }
    #[inline]
    fn cross_norm_squared(a: Self, b: Self) -> f32 {
        a.cross(b).length_squared()
    }
    #[inline]
    fn curvature_numerator(d1: Self, d2: Self) -> f32 {
        crate::math::sqrt(d1.cross(d2).length_squared())
    }
    #[inline]
    fn curve_normal(t: Self, d2: Self) -> Self {
        let perp = d2 - t * d2.dot(t);
        // Relative test: |perp| small against |d2| means a straight piece.
        if perp.length_squared() > 1e-12 * crate::math::max(f32::MIN_POSITIVE, d2.length_squared())
            && perp.length_squared() > f32::MIN_POSITIVE
        {
            // Second Gram–Schmidt pass: on a nearly straight piece the first one cancels most of
            // `d2` and leaves a rounding error of order eps·|d2| along `t`, which would tilt the
            // normal by eps·|d2|/|perp| (up to ~0.1 rad at the threshold above).
            let perp = perp - t * perp.dot(t);
            perp * (1.0 / crate::math::sqrt(perp.length_squared()))
        } else {
            t.any_orthonormal_vector()
        }
    }
}
