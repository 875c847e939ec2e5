//! NURBS curves in 2-D and 3-D over borrowed storage.

use crate::basis::ders_basis_funs;
use crate::bbox::Aabb;
use crate::control::{check_homogeneous, largest_weight};
use crate::error::{At, NurbsError};
use crate::knots::{Dir, Knots};
use crate::point::Point;
use crate::{MAX_DERIV, MAX_ORDER};

/// A validated NURBS curve borrowing its knots and homogeneous control points
/// `(w·x, w)`.
///
/// Evaluation is total: parameters are clamped into the domain (NaN maps to its start), and
/// every output is finite for finite, validated data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Curve<'a, P: Point> {
    knots: Knots<'a>,
    points: &'a [P::Hom],
}

/// Point and derivatives with respect to `u`. Entries above the requested order are zero.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CurveDerivs<P> {
    /// `C(u)`.
    pub point: P,
    /// `C'(u)`.
    pub du: P,
    /// `C''(u)`.
    pub duu: P,
}

/// Point, derivatives and the differential geometry derived from them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CurveFrame<P> {
    /// `C(u)`, `C'(u)`, `C''(u)`.
    pub derivs: CurveDerivs<P>,
    /// Unit tangent (the limit direction where `C'` vanishes).
    pub tangent: P,
    /// Unit normal, see [`Point::curve_normal`].
    pub normal: P,
    /// Curvature: signed for planar curves (positive turning counter-clockwise, so positive on a
    /// counter-clockwise circle), unsigned for spatial ones; 0 where `C'` vanishes.
    pub curvature: f32,
}

/// Below this relative size a first derivative counts as vanished (a degenerate
/// parametrisation such as a collapsed control polygon edge).
const DEGENERATE_REL: f32 = 1e-5;

impl<'a, P: Point> Curve<'a, P> {
    /// Validates a curve of `degree` with `knots` and homogeneous control points
    /// `points[i] = (w_i·P_i, w_i)`. Besides the knots and every control point and weight,
    /// the geometry: a curve of no length or with a span collapsed to a point is refused
    /// ([`crate::MIN_EXTENT`]).
    ///
    /// ```
    /// use nurbs::{Curve, NurbsError, Vec2, Vec3};
    ///
    /// // The quadratic Bézier curve of P0, P1, P2 (weights 1, so the homogeneous points are
    /// // (x, y, 1)).
    /// let (p0, p1, p2) = (Vec2::new(0.0, 0.0), Vec2::new(1.0, 2.0), Vec2::new(3.0, 1.0));
    /// let knots = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
    /// let points = [p0.extend(1.0), p1.extend(1.0), p2.extend(1.0)];
    /// let c = Curve::<Vec2>::new(2, &knots, &points)?;
    ///
    /// // De Casteljau at u = 1/2 (P&T §1.3): C(1/2) = (P0 + 2 P1 + P2) / 4 = (1.25, 1.25).
    /// let mid = (p0 + 2.0 * p1 + p2) / 4.0;
    /// // A handful of f32 roundings (ε = 1.2e-7) on values of size ~1: 1e-6 relative.
    /// assert!((c.point(0.5) - mid).length() <= 1e-6 * mid.length());
    /// // Clamped knots interpolate the end points; the basis there is exactly (1, 0, 0).
    /// assert_eq!((c.point(0.0), c.point(1.0)), (p0, p2));
    /// // Evaluation clamps the parameter into the domain [0, 1].
    /// assert_eq!(c.point(7.0), p2);
    ///
    /// // A knot vector one short is refused, and the error says what was expected.
    /// assert_eq!(
    ///     Curve::<Vec2>::new(2, &knots[..5], &points).unwrap_err().to_string(),
    ///     "knots: expected 6 knots (control points + degree + 1), found 5"
    /// );
    /// // So is a polyline whose second segment has no length (P1 = P2), naming the span.
    /// let knots = [0.0, 0.0, 0.5, 1.0, 1.0];
    /// let points = [Vec3::new(0.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0)];
    /// assert_eq!(
    ///     Curve::<Vec2>::new(1, &knots, &points),
    ///     Err(NurbsError::CollapsedSpan { index: 2, first: 1, last: 2, extent: 0.0 })
    /// );
    /// # Ok::<(), NurbsError>(())
    /// ```
    pub fn new(degree: usize, knots: &'a [f32], points: &'a [P::Hom]) -> Result<Self, NurbsError> {
        let knots = Knots::validate(knots, degree, points.len(), Dir::Curve)?;
        let largest = largest_weight(points.iter().map(|&h| P::split(h).1));
        for (i, &h) in points.iter().enumerate() {
            check_homogeneous::<P>(At::I(i), h, largest)?;
        }
        let curve = Curve { knots, points };
        check_extent(&curve)?;
        Ok(curve)
    }

    /// A view over data that was validated before (by an owned type).
    #[cfg(feature = "alloc")]
    pub(crate) fn from_validated(knots: Knots<'a>, points: &'a [P::Hom]) -> Self {
        Curve { knots, points }
    }

    /// The curve of data [`Curve::new`] accepted before (the same `degree`, `knots` and
    /// `points`), without checking it again: for storage that validated its contents once and
    /// holds nothing else (a device's scene store builds its views with it, between two
    /// ticks). Data `Curve::new` refuses makes a curve whose evaluation may panic; debug
    /// builds check.
    pub fn new_unchecked(degree: usize, knots: &'a [f32], points: &'a [P::Hom]) -> Self {
        debug_assert!(
            Self::new(degree, knots, points).is_ok(),
            "Curve::new_unchecked on data Curve::new refuses"
        );
        Curve {
            knots: Knots::whole(knots, degree),
            points,
        }
    }

    /// The curve of `knots` (a window or the whole vector, e.g. from
    /// [`Knots::window_unchecked`]) and its homogeneous control points, for storage that
    /// validated both with [`Curve::new`] before and kept them unchanged: O(1), no check in
    /// release builds. Points of another count than the knots need make a curve whose
    /// evaluation may panic; debug builds check.
    #[inline]
    pub fn from_knots_unchecked(knots: Knots<'a>, points: &'a [P::Hom]) -> Self {
        debug_assert!(
            points.len() == knots.n_points(),
            "Curve::from_knots_unchecked: {} points for knots of {}",
            points.len(),
            knots.n_points()
        );
        Curve { knots, points }
    }

    /// Degree.
    #[inline]
    pub fn degree(&self) -> usize {
        self.knots.degree()
    }

    /// The validated knot vector.
    #[inline]
    pub fn knots(&self) -> Knots<'a> {
        self.knots
    }

    /// Homogeneous control points.
    #[inline]
    pub fn points(&self) -> &'a [P::Hom] {
        self.points
    }

    /// Cartesian control point `i` and its weight, or `None` past the end.
    #[inline]
    pub fn control_point(&self, i: usize) -> Option<(P, f32)> {
        self.points.get(i).map(|&h| {
            let (xw, w) = P::split(h);
            (xw * (1.0 / w), w)
        })
    }

    /// Parameter domain `[a, b]`.
    #[inline]
    pub fn domain(&self) -> (f32, f32) {
        self.knots.domain()
    }

    /// Whether start and end points coincide within `tol` (metres): a closed curve, on which a
    /// tracker wraps the parameter instead of clamping it.
    pub fn is_closed(&self, tol: f32) -> bool {
        let (a, b) = self.domain();
        (self.point(a) - self.point(b)).length_squared() <= tol * tol
    }

    /// Box of the control polygon (of the points that act on the domain, for a window);
    /// contains the whole curve (the convex hull property: with positive weights every point is an
    /// affine combination of the control points with non-negative coefficients).
    ///
    /// ```
    /// use nurbs::{Curve, Vec2};
    ///
    /// // Quadratic Bézier P0 = (0, 0), P1 = (1, 2), P2 = (3, 1).
    /// let (p0, p1, p2) = (Vec2::new(0.0, 0.0), Vec2::new(1.0, 2.0), Vec2::new(3.0, 1.0));
    /// let knots = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
    /// let points = [p0.extend(1.0), p1.extend(1.0), p2.extend(1.0)];
    /// let c = Curve::<Vec2>::new(2, &knots, &points)?;
    /// let bb = c.bounding_box();
    /// // The box of the control points (weights 1: exact), not of the curve: y(u) = 4u − 3u²
    /// // peaks at 4/3 (u = 2/3), below P1's 2.
    /// assert_eq!((bb.min, bb.max), (Vec2::new(0.0, 0.0), Vec2::new(3.0, 2.0)));
    /// let top = c.point(2.0 / 3.0);
    /// // y is a sum of three products of size ≤ 1.4: 1e-6 is a few ulp.
    /// assert!((top.y - 4.0 / 3.0).abs() < 1e-6);
    /// assert!((0..=100).all(|i| bb.contains(c.point(i as f32 / 100.0))));
    /// # Ok::<(), nurbs::NurbsError>(())
    /// ```
    pub fn bounding_box(&self) -> Aabb<P> {
        // Validation guarantees at least degree + 1 >= 2 points.
        Aabb::from_homogeneous(&self.points[self.knots.point_indices()]).unwrap_or(Aabb {
            min: P::ZERO,
            max: P::ZERO,
        })
    }

    /// `C(u)` (Piegl & Tiller A4.1).
    #[inline]
    pub fn point(&self, u: f32) -> P {
        self.derivs_of::<0>(u).point
    }

    /// `C(u)` and its derivatives up to `order` (at most [`MAX_DERIV`]) (Piegl & Tiller A3.2 on
    /// the homogeneous curve, then A4.2 for the rational quotient).
    ///
    /// ```
    /// use nurbs::{Curve, Vec2};
    ///
    /// // Quadratic Bézier, differentiating its Bernstein form:
    /// // C'(u) = 2[(1 − u)(P1 − P0) + u(P2 − P1)], so C'(0) = 2(P1 − P0) and
    /// // C'(1) = 2(P2 − P1), and C'' = 2(P2 − 2 P1 + P0) throughout.
    /// let (p0, p1, p2) = (Vec2::new(0.0, 0.0), Vec2::new(1.0, 2.0), Vec2::new(3.0, 1.0));
    /// let knots = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
    /// let points = [p0.extend(1.0), p1.extend(1.0), p2.extend(1.0)];
    /// let c = Curve::<Vec2>::new(2, &knots, &points)?;
    /// let dd = 2.0 * (p2 - 2.0 * p1 + p0);
    /// for u in [0.0, 0.3, 1.0] {
    ///     let d = c.derivs(u, 2);
    ///     let du = 2.0 * ((1.0 - u) * (p1 - p0) + u * (p2 - p1));
    ///     // Sums of three terms of size ≤ 8 after a few f32 roundings (ε = 1.2e-7):
    ///     // 1e-6 relative, about 8 ε.
    ///     assert!((d.du - du).length() <= 1e-6 * du.length(), "C'({u}) = {}", d.du);
    ///     assert!((d.duu - dd).length() <= 1e-6 * dd.length(), "C''({u}) = {}", d.duu);
    /// }
    /// // Orders above the one requested are zero.
    /// assert_eq!(c.derivs(0.3, 1).duu, Vec2::ZERO);
    /// # Ok::<(), nurbs::NurbsError>(())
    /// ```
    #[inline]
    pub fn derivs(&self, u: f32, order: usize) -> CurveDerivs<P> {
        // Monomorphised per order so the small loops unroll.
        match order {
            0 => self.derivs_of::<0>(u),
            1 => self.derivs_of::<1>(u),
            _ => self.derivs_of::<2>(u),
        }
    }

    #[inline]
    fn derivs_of<const D: usize>(&self, u: f32) -> CurveDerivs<P> {
        let u = self.knots.clamp(u);
        let p = self.degree();
        let span = self.knots.find_span(u);
        let mut nders = [[0.0; MAX_ORDER]; MAX_DERIV + 1];
        ders_basis_funs(self.knots.as_slice(), span, u, p, D, &mut nders);
        let mut aw = [P::Hom::default(); MAX_DERIV + 1];
        for (j, &pw) in self.points[span - p..][..p + 1].iter().enumerate() {
            for k in 0..=D {
                aw[k] += pw * nders[k][j];
            }
        }
        // A4.2 with the binomial coefficients for k <= 2 written out.
        let (a0, w0) = P::split(aw[0]);
        let (a1, w1) = P::split(aw[1]);
        let (a2, w2) = P::split(aw[2]);
        let inv_w = 1.0 / w0;
        let c0 = a0 * inv_w;
        let c1 = if D >= 1 {
            (a1 - c0 * w1) * inv_w
        } else {
            P::ZERO
        };
        let c2 = if D >= 2 {
            (a2 - c1 * (2.0 * w1) - c0 * w2) * inv_w
        } else {
            P::ZERO
        };
        CurveDerivs {
            point: c0,
            du: c1,
            duu: c2,
        }
    }

    /// The same curve restricted to a window of its knot vector (from
    /// [`Knots::c0_pieces`] or [`Knots::span_window`] of [`Self::knots`]); `None` if `knots` is
    /// not a window onto this curve's knot vector.
    ///
    /// ```
    /// use nurbs::{Curve, Vec2};
    ///
    /// // The polyline P0 → P1 → P2 with its corner at u = 1/2: on each span the derivative
    /// // is the chord over the span's length, (P[i+1] − P[i]) / Δu.
    /// let (p0, p1, p2) = (Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0));
    /// let knots = [0.0, 0.0, 0.5, 1.0, 1.0];
    /// let points = [p0.extend(1.0), p1.extend(1.0), p2.extend(1.0)];
    /// let c = Curve::<Vec2>::new(1, &knots, &points)?;
    /// let first = c.window(c.knots().span_window(1).unwrap()).unwrap();
    /// assert_eq!(first.domain(), (0.0, 0.5));
    /// // At the corner the whole curve evaluates on the second span (the one starting
    /// // there); the window onto the first span gives the limit from inside it.
    /// // Differences of exact values over 0.5: exact in f32.
    /// assert_eq!(c.derivs(0.5, 1).du, (p2 - p1) / 0.5);
    /// assert_eq!(first.derivs(0.5, 1).du, (p1 - p0) / 0.5);
    /// assert_eq!(first.point(0.9), p1); // clamped into the window
    /// // Knots of another vector are not a window onto this curve.
    /// let other = [0.0, 0.0, 0.5, 1.0, 1.0];
    /// assert!(c.window(nurbs::Knots::new(&other, 1, 3)?).is_none());
    /// # Ok::<(), nurbs::NurbsError>(())
    /// ```
    pub fn window(&self, knots: Knots<'a>) -> Option<Self> {
        let same = core::ptr::eq(knots.as_slice(), self.knots.as_slice())
            && knots.degree() == self.degree();
        same.then_some(Curve {
            knots,
            points: self.points,
        })
    }

    /// The pieces between the C⁰ breaks of the curve (interior knots of multiplicity ≥ the
    /// degree, where it generally has a corner), as windows onto it, in order: the curve
    /// itself when it has none. No copy, no allocation.
    ///
    /// ```
    /// use nurbs::{Curve, Vec2};
    ///
    /// // Two quadratic Bézier pieces joined at u = 1, a knot of multiplicity 2 = p: the curve
    /// // passes through P2 there with a corner: each piece is a Bézier curve, arriving
    /// // along 2(P2 − P1) from the left and leaving along 2(P3 − P2) to the right.
    /// let p = [(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (2.0, 1.0), (2.0, 2.0)].map(Vec2::from);
    /// let knots = [0.0, 0.0, 0.0, 1.0, 1.0, 2.0, 2.0, 2.0];
    /// let points = p.map(|q| q.extend(1.0));
    /// let c = Curve::<Vec2>::new(2, &knots, &points)?;
    /// let pieces: Vec<_> = c.c0_pieces().collect();
    /// assert_eq!(pieces.len(), 2);
    /// assert_eq!((pieces[0].domain(), pieces[1].domain()), ((0.0, 1.0), (1.0, 2.0)));
    /// // Exact here: the basis at a knot of multiplicity p is a unit vector.
    /// assert_eq!((pieces[0].point(1.0), pieces[1].point(1.0)), (p[2], p[2]));
    /// assert_eq!(pieces[0].derivs(1.0, 1).du, 2.0 * (p[2] - p[1]));
    /// assert_eq!(pieces[1].derivs(1.0, 1).du, 2.0 * (p[3] - p[2]));
    /// // The unit tangents on either side of the corner: along x, then along y (to the
    /// // normalisation's `math::sqrt`, ≤ 4 ε = 4.8e-7 relative).
    /// assert!((pieces[0].frame(1.0).tangent - Vec2::X).length() <= 1e-6);
    /// assert!((pieces[1].frame(1.0).tangent - Vec2::Y).length() <= 1e-6);
    /// # Ok::<(), nurbs::NurbsError>(())
    /// ```
    pub fn c0_pieces(&self) -> impl Iterator<Item = Self> + use<'a, P> {
        let points = self.points;
        self.knots
            .c0_pieces()
            .map(move |knots| Curve { knots, points })
    }

    /// Point, derivatives, unit tangent, unit normal and curvature at `u`.
    ///
    /// Curvature is `κ = (C' ⊥· C'') / |C'|³` for planar curves (signed) and
    /// `|C' × C''| / |C'|³` for spatial ones (the Frenet formulas).
    ///
    /// ```
    /// use nurbs::{Curve, Vec2, Vec3};
    ///
    /// // The quarter circle of radius r as a rational quadratic Bézier curve (P&T §1.4):
    /// // P0 = (r, 0), P1 = (r, r) with weight cos 45° = √2/2, P2 = (0, r).
    /// let r = 2.0f32;
    /// let w = core::f32::consts::FRAC_1_SQRT_2;
    /// let knots = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
    /// let points = [Vec3::new(r, 0.0, 1.0), Vec3::new(w * r, w * r, w), Vec3::new(0.0, r, 1.0)];
    /// let c = Curve::<Vec2>::new(2, &knots, &points)?;
    /// for i in 0..=20 {
    ///     let f = c.frame(i as f32 / 20.0);
    ///     let p = f.derivs.point;
    ///     // |C(u)| = r for every u. The weight rounded to f32 (relative error ≤ ε/2 = 6e-8)
    ///     // and the quotient's roundings keep this to a few ε: 1e-6 relative.
    ///     assert!((p.length() - r).abs() <= 1e-6 * r, "|C| = {}", p.length());
    ///     // A counter-clockwise circle: curvature +1/r, unit tangent ⟂ radius, and the
    ///     // planar normal t × k̂ = C / r points outward. The curvature divides by |C'|³
    ///     // after the rational second derivative (P&T A4.2) and `math::sqrt` (≤ 4 ε):
    ///     // 2e-6 relative, about 16 ε.
    ///     assert!((f.curvature * r - 1.0).abs() <= 2e-6, "κ = {}", f.curvature);
    ///     assert!(f.tangent.dot(p).abs() <= 1e-6 * r);
    ///     assert!((f.normal - p / r).length() <= 1e-6);
    /// }
    /// // End derivative of a rational Bézier curve: C'(0) = p (w1 / w0) (P1 − P0) = (0, √2 r).
    /// let d0 = c.derivs(0.0, 1).du;
    /// assert!((d0 - Vec2::new(0.0, 2.0 * w * r)).length() <= 1e-6 * r);
    /// // By symmetry C(1/2) lies on the bisector: (r, r) / √2.
    /// assert!((c.point(0.5) - Vec2::splat(w * r)).length() <= 1e-6 * r);
    /// # Ok::<(), nurbs::NurbsError>(())
    /// ```
    pub fn frame(&self, u: f32) -> CurveFrame<P> {
        let u = self.knots.clamp(u);
        self.frame_from(u, self.derivs(u, 2))
    }

    /// [`Curve::frame`] at `u` from `d`, the point and derivatives there up to order 2
    /// ([`Curve::derivs`]`(u, 2)`, e.g. kept from an earlier evaluation): the same frame,
    /// without evaluating them again.
    pub fn frame_from(&self, u: f32, d: CurveDerivs<P>) -> CurveFrame<P> {
        let (tangent, degenerate, l1) = self.tangent_of(u, &d);
        let curvature = if degenerate {
            0.0
        } else {
            let len = crate::math::sqrt(l1);
            P::curvature_numerator(d.du, d.duu) / (l1 * len)
        };
        CurveFrame {
            derivs: d,
            tangent,
            normal: P::curve_normal(tangent, d.duu),
            curvature,
        }
    }
}

impl<P: Point> Curve<'_, P> {
    /// The unit tangent of [`Curve::frame_from`] alone (no normal, no curvature): the same
    /// value, for a caller that needs only the direction.
    pub fn tangent_from(&self, u: f32, d: &CurveDerivs<P>) -> P {
        self.tangent_of(u, d).0
    }

    /// The unit tangent at `u` from the derivatives there, whether `C'` counts as vanished,
    /// and `|C'|²`.
    fn tangent_of(&self, u: f32, d: &CurveDerivs<P>) -> (P, bool, f32) {
        let u = self.knots.clamp(u);
        let l1 = d.du.length_squared();
        let scale = self.knots.domain_len();
        let degenerate = l1
            <= (DEGENERATE_REL * scale) * (DEGENERATE_REL * scale) * d.duu.length_squared()
            || l1 <= f32::MIN_POSITIVE;
        let tangent = if !degenerate {
            d.du.try_normalize()
        } else {
            // C'(u ± h) ≈ ±h C''(u): the limit direction seen from inside the domain.
            let (_, b) = self.domain();
            let side = if u >= b { -1.0 } else { 1.0 };
            (d.duu * side).try_normalize()
        };
        let tangent = tangent
            .or_else(|| {
                let (a, b) = self.domain();
                (self.point(b) - self.point(a)).try_normalize()
            })
            .unwrap_or_else(|| unit_first_axis::<P>());
        (tangent, degenerate, l1)
    }
}

/// `(1, 0, …)`: the last-resort direction for a curve that is a single point.
fn unit_first_axis<P: Point>() -> P {
    let mut c = [0.0f32; 4];
    c[0] = 1.0;
    P::from_coords(&c[..P::DIM]).unwrap_or(P::ZERO)
}

/// Refuses a curve of no length ([`NurbsError::ZeroLength`]) or with a knot span collapsed
/// to a point ([`NurbsError::CollapsedSpan`]), both measured against [`MIN_EXTENT`].
fn check_extent<P: Point>(curve: &Curve<'_, P>) -> Result<(), NurbsError> {
    let points = curve.points();
    let extent = crate::extent::spread(points.iter().map(|&h| crate::extent::cartesian::<P>(h)));
    if extent < crate::MIN_EXTENT {
        return Err(NurbsError::ZeroLength { extent });
    }
    let knots = curve.knots();
    let (k, p) = (knots.as_slice(), knots.degree());
    for i in knots.span_indices().filter(|&i| k[i] < k[i + 1]) {
        let extent = crate::extent::spread(
            points[i - p..=i]
                .iter()
                .map(|&h| crate::extent::cartesian::<P>(h)),
        );
        if extent < crate::MIN_EXTENT {
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
