//! One view of curves (`N = 1` parameter) and surfaces (`N = 2`) for the tracking
//! algorithms, so planar curves, spatial curves and surfaces share one implementation.

use nurbs::{Aabb, Curve, Point, Surface, Vec3};

/// Point, first and second derivatives of a patch at a parameter `t ∈ ℝᴺ`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Jet<P, const N: usize> {
    /// `S(t)`.
    pub point: P,
    /// `∂S/∂tᵢ`.
    pub d: [P; N],
    /// `∂²S/∂tᵢ∂tⱼ` (zero unless evaluated with order 2).
    pub dd: [[P; N]; N],
}

impl<P: Point, const N: usize> Jet<P, N> {
    /// First fundamental form `Gᵢⱼ = Sᵢ·Sⱼ`.
    #[inline]
    pub fn metric(&self) -> [[f32; N]; N] {
        let mut g = [[0.0; N]; N];
        for i in 0..N {
            for j in 0..N {
                g[i][j] = self.d[i].dot(self.d[j]);
            }
        }
        g
    }

    /// Projection error `Ψᵢ = Γ·Sᵢ` with `Γ = S − x` (thesis §2.1.2).
    #[inline]
    pub fn psi(&self, gamma: P) -> [f32; N] {
        let mut psi = [0.0; N];
        for i in 0..N {
            psi[i] = gamma.dot(self.d[i]);
        }
        psi
    }

    /// Hessian of `½|S(t) − x|²`: `Hᵢⱼ = Sᵢ·Sⱼ + Γ·Sᵢⱼ` (needs a jet of order 2).
    #[inline]
    pub fn hessian(&self, gamma: P) -> [[f32; N]; N] {
        let mut h = self.metric();
        for i in 0..N {
            for j in 0..N {
                h[i][j] += gamma.dot(self.dd[i][j]);
            }
        }
        h
    }

    /// `Σ δᵢ Sᵢ`: the first-order displacement on the patch for a parameter step `δ`.
    #[inline]
    pub fn displacement(&self, delta: &[f32; N]) -> P {
        let mut v = P::ZERO;
        for i in 0..N {
            v += self.d[i] * delta[i];
        }
        v
    }
}

/// A parametric patch with `N` parameters that the trackers can follow.
pub trait Patch<const N: usize> {
    /// The space the patch lives in.
    type P: Point;

    /// Parameter domain per direction, `[(min, max); N]`.
    fn domain(&self) -> [(f32, f32); N];

    /// Point and derivatives up to `order` (1 or 2) at `t` (clamped into the domain).
    fn jet(&self, t: [f32; N], order: usize) -> Jet<Self::P, N>;

    /// Unit outward normal at `t`, given the jet there (order 1 is enough).
    fn normal(&self, t: [f32; N], jet: &Jet<Self::P, N>) -> Self::P;

    /// Box that contains the patch (control-net box).
    fn bounding_box(&self) -> Aabb<Self::P>;

    /// Whether the patch closes on itself along each direction (start and end iso-lines
    /// coincide within `tol` metres): a tracker wraps such a parameter instead of clamping.
    fn periodic(&self, tol: f32) -> [bool; N];

    /// Which sides of the domain collapse to a single point (the poles of a sphere of
    /// revolution): `[[at min, at max]; N]`. Crossing such a side continues on the opposite
    /// side of the pole.
    fn collapsed(&self, tol: f32) -> [[bool; 2]; N] {
        let _ = tol;
        [[false; 2]; N]
    }

    /// The middle of the domain.
    fn center(&self) -> [f32; N] {
        let d = self.domain();
        let mut t = [0.0; N];
        for i in 0..N {
            t[i] = 0.5 * (d[i].0 + d[i].1);
        }
        t
    }
}

impl<P: Point> Patch<1> for Curve<'_, P> {
    type P = P;

    #[inline]
    fn domain(&self) -> [(f32, f32); 1] {
        [Curve::domain(self)]
    }

    #[inline]
    fn jet(&self, t: [f32; 1], order: usize) -> Jet<P, 1> {
        let d = self.derivs(t[0], order);
        Jet {
            point: d.point,
            d: [d.du],
            dd: [[d.duu]],
        }
    }

    #[inline]
    fn normal(&self, t: [f32; 1], jet: &Jet<P, 1>) -> P {
        match jet.d[0].try_normalize() {
            Some(tangent) => P::curve_normal(tangent, jet.dd[0][0]),
            // Vanishing derivative: the curve's own limit frame.
            None => self.frame(t[0]).normal,
        }
    }

    fn bounding_box(&self) -> Aabb<P> {
        Curve::bounding_box(self)
    }

    fn periodic(&self, tol: f32) -> [bool; 1] {
        [self.is_closed(tol)]
    }
}

impl Patch<2> for Surface<'_> {
    type P = Vec3;

    #[inline]
    fn domain(&self) -> [(f32, f32); 2] {
        let (u, v) = Surface::domain(self);
        [u, v]
    }

    #[inline]
    fn jet(&self, t: [f32; 2], order: usize) -> Jet<Vec3, 2> {
        let d = self.derivs(t[0], t[1], order);
        Jet {
            point: d.point,
            d: [d.du, d.dv],
            dd: [[d.duu, d.duv], [d.duv, d.dvv]],
        }
    }

    #[inline]
    fn normal(&self, t: [f32; 2], jet: &Jet<Vec3, 2>) -> Vec3 {
        let d = nurbs::SurfaceDerivs {
            point: jet.point,
            du: jet.d[0],
            dv: jet.d[1],
            ..Default::default()
        };
        self.normal_from(t[0], t[1], &d)
    }

    fn bounding_box(&self) -> Aabb<Vec3> {
        Surface::bounding_box(self)
    }

    fn collapsed(&self, tol: f32) -> [[bool; 2]; 2] {
        let ((u0, u1), (v0, v1)) = Surface::domain(self);
        const SAMPLES: usize = 5;
        let tol2 = tol * tol;
        let mut out = [[true; 2]; 2];
        for k in 1..SAMPLES {
            let s = k as f32 / (SAMPLES - 1) as f32;
            let (u, v) = (u0 + (u1 - u0) * s, v0 + (v1 - v0) * s);
            for (side, fixed) in [u0, u1].into_iter().enumerate() {
                if (self.point(fixed, v) - self.point(fixed, v0)).length_squared() > tol2 {
                    out[0][side] = false;
                }
            }
            for (side, fixed) in [v0, v1].into_iter().enumerate() {
                if (self.point(u, fixed) - self.point(u0, fixed)).length_squared() > tol2 {
                    out[1][side] = false;
                }
            }
        }
        out
    }

    fn periodic(&self, tol: f32) -> [bool; 2] {
        let ((u0, u1), (v0, v1)) = Surface::domain(self);
        const SAMPLES: usize = 9;
        let tol2 = tol * tol;
        let mut closed = [true; 2];
        for k in 0..SAMPLES {
            let s = k as f32 / (SAMPLES - 1) as f32;
            let v = v0 + (v1 - v0) * s;
            let u = u0 + (u1 - u0) * s;
            if (self.point(u0, v) - self.point(u1, v)).length_squared() > tol2 {
                closed[0] = false;
            }
            if (self.point(u, v0) - self.point(u, v1)).length_squared() > tol2 {
                closed[1] = false;
            }
        }
        closed
    }
}
