//! NURBS surfaces in 3-D over borrowed storage.

use crate::basis::ders_basis_funs;
use crate::bbox::Aabb;
use crate::control::{check_homogeneous, largest_weight};
use crate::error::{At, NurbsError};
use crate::knots::{Dir, Knots};
use crate::point::Point;
use crate::{MAX_DERIV, MAX_ORDER};
use glam::{Vec3, Vec4};

/// A validated NURBS surface borrowing its knots and homogeneous control net.
///
/// `points[i * count_v + j] = (w_ij·P_ij, w_ij)`, with `i` along u and `j` along v. Evaluation
/// clamps `(u, v)` into the domain and is total.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface<'a> {
    ku: Knots<'a>,
    kv: Knots<'a>,
    points: &'a [Vec4],
}

/// `S` and its partial derivatives. Entries above the requested order are zero.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SurfaceDerivs {
    /// `S(u, v)`.
    pub point: Vec3,
    /// `∂S/∂u`.
    pub du: Vec3,
    /// `∂S/∂v`.
    pub dv: Vec3,
    /// `∂²S/∂u²`.
    pub duu: Vec3,
    /// `∂²S/∂u∂v`.
    pub duv: Vec3,
    /// `∂²S/∂v²`.
    pub dvv: Vec3,
}

/// A first derivative this much smaller (relative, parameter-scale free) than the other counts
/// as vanished: the surface is degenerate there, like the poles of a sphere of revolution.
const DEGENERATE_REL: f32 = 1e-4;

impl<'a> Surface<'a> {
    /// Validates a surface of degrees `(p, q)` with knot vectors `(U, V)` and a control net of
    /// `count_v` points along v (the count along u is `points.len() / count_v`). Besides the
    /// knots and every control point and weight, the geometry: a surface of no area or with a
    /// cell collapsed to a line, a curve or a point is refused ([`MIN_EXTENT`](crate::MIN_EXTENT)); a side
    /// collapsed to a point (a pole) is not. Costs four evaluations per cell.
    ///
    /// ```
    /// use nurbs::{Field, NurbsError, Surface, Vec3};
    ///
    /// // A bilinear patch (degrees (1, 1), a hyperbolic paraboloid):
    /// // S(u, v) = (1−u)(1−v) P00 + u(1−v) P10 + (1−u)v P01 + uv P11 (the tensor product
    /// // of the linear bases), which for these corners is (2u, v, uv).
    /// let (p00, p10) = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(2.0, 0.0, 0.0));
    /// let (p01, p11) = (Vec3::new(0.0, 1.0, 0.0), Vec3::new(2.0, 1.0, 1.0));
    /// let knots = [0.0, 0.0, 1.0, 1.0];
    /// // Row-major with i along u: [P00, P01, P10, P11], weights 1.
    /// let net = [p00, p01, p10, p11].map(|p| p.extend(1.0));
    /// let s = Surface::new((1, 1), (&knots, &knots), 2, &net)?;
    /// assert_eq!(s.counts(), (2, 2));
    /// for (u, v) in [(0.0, 0.0), (0.25, 0.75), (0.5, 0.5), (1.0, 0.3)] {
    ///     let want = Vec3::new(2.0 * u, v, u * v);
    ///     // Four products of values ≤ 2 summed in f32 (ε = 1.2e-7): 1e-6 absolute.
    ///     assert!((s.point(u, v) - want).length() <= 1e-6, "S({u}, {v}) = {}", s.point(u, v));
    /// }
    ///
    /// // The errors name the direction: here the u knot vector is one short.
    /// assert_eq!(
    ///     Surface::new((1, 1), (&knots[..3], &knots), 2, &net),
    ///     Err(NurbsError::KnotCount { field: Field::KnotsU, expected: 4, found: 3 })
    /// );
    /// # Ok::<(), NurbsError>(())
    /// ```
    pub fn new(
        degree: (usize, usize),
        knots: (&'a [f32], &'a [f32]),
        count_v: usize,
        points: &'a [Vec4],
    ) -> Result<Self, NurbsError> {
        let count_u = points.len().checked_div(count_v).unwrap_or(0);
        let kv = Knots::validate(knots.1, degree.1, count_v, Dir::V)?;
        let ku = Knots::validate(knots.0, degree.0, count_u, Dir::U)?;
        if count_u * count_v != points.len() {
            return Err(NurbsError::RaggedNet {
                field: crate::Field::Points,
                row: count_u,
                expected: count_v,
                found: points.len() - count_u * count_v,
            });
        }
        let largest = largest_weight(points.iter().map(|h| h.w));
        for (k, &h) in points.iter().enumerate() {
            check_homogeneous::<Vec3>(At::Ij(k / count_v, k % count_v), h, largest)?;
        }
        let surface = Surface { ku, kv, points };
        check_area(&surface)?;
        Ok(surface)
    }

    /// A view over data that was validated before (by an owned type).
    #[cfg(feature = "alloc")]
    pub(crate) fn from_validated(ku: Knots<'a>, kv: Knots<'a>, points: &'a [Vec4]) -> Self {
        Surface { ku, kv, points }
    }

    /// The surface of knot vectors `ku`, `kv` (windows or whole vectors, e.g. from
    /// [`Knots::window_unchecked`]) and its homogeneous control net (row-major, `i` along u),
    /// for storage that validated all three with [`Surface::new`] before and kept them
    /// unchanged: O(1), no check in release builds (as [`crate::Curve::from_knots_unchecked`]).
    /// A net of another size than the knots need makes a surface whose evaluation may panic;
    /// debug builds check.
    #[inline]
    pub fn from_knots_unchecked(ku: Knots<'a>, kv: Knots<'a>, points: &'a [Vec4]) -> Self {
        debug_assert!(
            points.len() == ku.n_points() * kv.n_points(),
            "Surface::from_knots_unchecked: {} points for knots of {} × {}",
            points.len(),
            ku.n_points(),
            kv.n_points()
        );
        Surface { ku, kv, points }
    }

    /// Degrees `(p, q)`.
    #[inline]
    pub fn degree(&self) -> (usize, usize) {
        (self.ku.degree(), self.kv.degree())
    }

    /// Knot vectors `(U, V)`.
    #[inline]
    pub fn knots(&self) -> (Knots<'a>, Knots<'a>) {
        (self.ku, self.kv)
    }

    /// Control net size `(along u, along v)`.
    #[inline]
    pub fn counts(&self) -> (usize, usize) {
        (self.ku.n_points(), self.kv.n_points())
    }

    /// Homogeneous control net, row-major with `i` along u.
    #[inline]
    pub fn points(&self) -> &'a [Vec4] {
        self.points
    }

    /// Cartesian control point `(i, j)` and its weight, or `None` outside the net.
    pub fn control_point(&self, i: usize, j: usize) -> Option<(Vec3, f32)> {
        let (nu, nv) = self.counts();
        if i >= nu || j >= nv {
            return None;
        }
        let h = self.points[i * nv + j];
        Some((h.truncate() / h.w, h.w))
    }

    /// Domains `((u_min, u_max), (v_min, v_max))`.
    #[inline]
    pub fn domain(&self) -> ((f32, f32), (f32, f32)) {
        (self.ku.domain(), self.kv.domain())
    }

    /// Box of the control net (of the points that act on the domain, for a window); contains
    /// the whole surface.
    pub fn bounding_box(&self) -> Aabb<Vec3> {
        let empty = Aabb {
            min: Vec3::ZERO,
            max: Vec3::ZERO,
        };
        if self.ku.is_whole() && self.kv.is_whole() {
            return Aabb::from_homogeneous(self.points).unwrap_or(empty);
        }
        let nv = self.kv.n_points();
        let cols = self.kv.point_indices();
        let mut bb: Option<Aabb<Vec3>> = None;
        for i in self.ku.point_indices() {
            if let Some(row) = Aabb::from_homogeneous(&self.points[i * nv..][cols.clone()]) {
                bb = Some(match bb {
                    Some(b) => b.include(row.min).include(row.max),
                    None => row,
                });
            }
        }
        bb.unwrap_or(empty)
    }

    /// The same surface restricted to windows of its knot vectors (from [`Knots::c0_pieces`]
    /// or [`Knots::span_window`] of [`Self::knots`]); `None` if they are not windows onto this
    /// surface's knot vectors.
    pub fn window(&self, ku: Knots<'a>, kv: Knots<'a>) -> Option<Self> {
        let same = |a: Knots<'_>, b: Knots<'_>| {
            core::ptr::eq(a.as_slice(), b.as_slice()) && a.degree() == b.degree()
        };
        (same(ku, self.ku) && same(kv, self.kv)).then_some(Surface {
            ku,
            kv,
            points: self.points,
        })
    }

    /// The pieces between the C⁰ break lines of the surface (interior knots of multiplicity ≥
    /// the degree in either direction, where it generally has a crease), as windows onto it:
    /// `u` pieces outer, `v` pieces inner; the surface itself when it has none. No copy, no
    /// allocation.
    ///
    /// ```
    /// use nurbs::{Surface, Vec3};
    ///
    /// // A sheet folded along u = 1/2 (knot of multiplicity 1 = p): flat on z = 0 for
    /// // u ≤ 1/2, S = (2u, v, 0), then up the plane x = 1, S = (1, v, 2u − 1).
    /// let rows = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 1.0]].map(Vec3::from);
    /// // Row i along u holds [P_i0, P_i1] = [P_i, P_i + (0, 1, 0)], weights 1.
    /// let net: Vec<_> = rows
    ///     .iter()
    ///     .flat_map(|&p| [p.extend(1.0), (p + Vec3::Y).extend(1.0)])
    ///     .collect();
    /// let (ku, kv) = ([0.0, 0.0, 0.5, 1.0, 1.0], [0.0, 0.0, 1.0, 1.0]);
    /// let s = Surface::new((1, 1), (&ku, &kv), 2, &net)?;
    /// let pieces: Vec<_> = s.c0_pieces().collect();
    /// assert_eq!(pieces.len(), 2);
    /// assert_eq!(pieces[1].domain(), ((0.5, 1.0), (0.0, 1.0)));
    /// // S_u × S_v = (2, 0, 0) × (0, 1, 0) = (0, 0, 2) on the first piece and
    /// // (0, 0, 2) × (0, 1, 0) = (−2, 0, 0) on the second; at the crease each piece gives
    /// // its own side's normal. The derivatives are exact here; the normalisation's
    /// // `math::sqrt` is within 4 ε = 4.8e-7 relative.
    /// assert!((pieces[0].normal(0.5, 0.5) - Vec3::Z).length() <= 1e-6);
    /// assert!((pieces[1].normal(0.5, 0.5) + Vec3::X).length() <= 1e-6);
    /// // Each piece's box is the box of its own part of the net.
    /// let b = pieces[1].bounding_box();
    /// assert_eq!((b.min, b.max), (Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 1.0)));
    /// # Ok::<(), nurbs::NurbsError>(())
    /// ```
    pub fn c0_pieces(&self) -> impl Iterator<Item = Self> + use<'a> {
        let (kv, points) = (self.kv, self.points);
        self.ku
            .c0_pieces()
            .flat_map(move |ku| kv.c0_pieces().map(move |kv| Surface { ku, kv, points }))
    }

    /// `S(u, v)` (Piegl & Tiller A4.3).
    #[inline]
    pub fn point(&self, u: f32, v: f32) -> Vec3 {
        self.derivs_of::<0>(u, v).point
    }

    /// `S` and its partial derivatives up to total order `order` (at most [`MAX_DERIV`])
    /// (Piegl & Tiller A3.6 on the homogeneous surface, then A4.4).
    ///
    /// ```
    /// # use nurbs::{Surface, Vec3};
    /// # let (p00, p10) = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(2.0, 0.0, 0.0));
    /// # let (p01, p11) = (Vec3::new(0.0, 1.0, 0.0), Vec3::new(2.0, 1.0, 1.0));
    /// # let knots = [0.0, 0.0, 1.0, 1.0];
    /// # let net = [p00, p01, p10, p11].map(|p| p.extend(1.0));
    /// # let s = Surface::new((1, 1), (&knots, &knots), 2, &net)?;
    /// // The bilinear patch of `Surface::new`: S(u, v) = (2u, v, uv).
    /// // S_u = (2, 0, v), S_v = (0, 1, u), S_uv = (0, 0, 1), S_uu = S_vv = 0.
    /// let (u, v) = (0.25, 0.75);
    /// let d = s.derivs(u, v, 2);
    /// // Sums of four products of values ≤ 2 (ε = 1.2e-7 each): 1e-6 absolute.
    /// assert!((d.du - Vec3::new(2.0, 0.0, v)).length() <= 1e-6);
    /// assert!((d.dv - Vec3::new(0.0, 1.0, u)).length() <= 1e-6);
    /// assert!((d.duv - Vec3::Z).length() <= 1e-6);
    /// assert!(d.duu.length() <= 1e-6 && d.dvv.length() <= 1e-6);
    /// # Ok::<(), nurbs::NurbsError>(())
    /// ```
    #[inline]
    pub fn derivs(&self, u: f32, v: f32, order: usize) -> SurfaceDerivs {
        // Monomorphised per order so the small loops unroll.
        match order {
            0 => self.derivs_of::<0>(u, v),
            1 => self.derivs_of::<1>(u, v),
            _ => self.derivs_of::<2>(u, v),
        }
    }

    #[inline]
    fn derivs_of<const D: usize>(&self, u: f32, v: f32) -> SurfaceDerivs {
        let (u, v) = (self.ku.clamp(u), self.kv.clamp(v));
        let (p, q) = self.degree();
        let nv = self.kv.n_points();
        let (su, sv) = (self.ku.find_span(u), self.kv.find_span(v));
        let mut nu_d = [[0.0; MAX_ORDER]; MAX_DERIV + 1];
        let mut nv_d = [[0.0; MAX_ORDER]; MAX_DERIV + 1];
        ders_basis_funs(self.ku.as_slice(), su, u, p, D, &mut nu_d);
        ders_basis_funs(self.kv.as_slice(), sv, v, q, D, &mut nv_d);
        // skl[k][l]: homogeneous ∂^(k+l) / ∂u^k ∂v^l, k + l <= D.
        let mut skl = [[Vec4::ZERO; MAX_DERIV + 1]; MAX_DERIV + 1];
        for r in 0..=p {
            let row = &self.points[(su - p + r) * nv + sv - q..][..q + 1];
            let mut temp = [Vec4::ZERO; MAX_DERIV + 1];
            for (s, &pw) in row.iter().enumerate() {
                for l in 0..=D {
                    temp[l] += pw * nv_d[l][s];
                }
            }
            for k in 0..=D {
                for l in 0..=D - k {
                    skl[k][l] += temp[l] * nu_d[k][r];
                }
            }
        }
        rational_surface_derivs(&skl, D)
    }

    /// Unit normal `S_u × S_v / |S_u × S_v|` at `(u, v)`; see [`Surface::normal_from`].
    ///
    /// ```
    /// # use nurbs::{Surface, Vec3};
    /// # let (p00, p10) = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(2.0, 0.0, 0.0));
    /// # let (p01, p11) = (Vec3::new(0.0, 1.0, 0.0), Vec3::new(2.0, 1.0, 1.0));
    /// # let knots = [0.0, 0.0, 1.0, 1.0];
    /// # let net = [p00, p01, p10, p11].map(|p| p.extend(1.0));
    /// # let s = Surface::new((1, 1), (&knots, &knots), 2, &net)?;
    /// // The bilinear patch of `Surface::new`: S(u, v) = (2u, v, uv).
    /// // S_u × S_v = (2, 0, v) × (0, 1, u) = (−v, −2u, 2).
    /// for (u, v) in [(0.0, 0.0), (0.25, 0.75), (1.0, 1.0)] {
    ///     let want = Vec3::new(-v, -2.0 * u, 2.0).normalize();
    ///     // A cross product and a normalisation (`math::sqrt`, ≤ 4 ε) of values ≤ 2:
    ///     // 1e-6 on a unit vector is about 8 ε.
    ///     assert!((s.normal(u, v) - want).length() <= 1e-6, "n({u}, {v}) = {}", s.normal(u, v));
    /// }
    /// # Ok::<(), nurbs::NurbsError>(())
    /// ```
    #[inline]
    pub fn normal(&self, u: f32, v: f32) -> Vec3 {
        let d = self.derivs(u, v, 1);
        self.normal_from(u, v, &d)
    }

    /// Unit normal from already evaluated first derivatives at `(u, v)`.
    ///
    /// Where one first derivative vanishes (the poles of a sphere of revolution, a collapsed
    /// edge) it returns the finite limit normal: if `S_u → 0` at `v = v₀`, then
    /// `S_u(u, v₀ + h) ≈ h S_uv` and the normal is the direction of `h (S_uv × S_v)` with `h`
    /// pointing into the domain (and symmetrically for `S_v → 0`).
    pub fn normal_from(&self, u: f32, v: f32, d: &SurfaceDerivs) -> Vec3 {
        let (u, v) = (self.ku.clamp(u), self.kv.clamp(v));
        let n = d.du.cross(d.dv);
        let lu = d.du.length_squared() * sq(self.ku.domain_len());
        let lv = d.dv.length_squared() * sq(self.kv.domain_len());
        let rel = DEGENERATE_REL * DEGENERATE_REL;
        let u_vanishes = lu <= rel * lv;
        let v_vanishes = lv <= rel * lu;
        if !u_vanishes
            && !v_vanishes
            && let Some(n) = Point::try_normalize(n)
        {
            return n;
        }
        let d2 = self.derivs(u, v, 2);
        if u_vanishes && !v_vanishes {
            // Into the domain from the nearer end.
            let (v0, v1) = self.kv.domain();
            let h = if v - v0 > v1 - v { -1.0 } else { 1.0 };
            if let Some(n) = Point::try_normalize(d2.duv.cross(d2.dv) * h) {
                return n;
            }
        }
        if v_vanishes && !u_vanishes {
            let (u0, u1) = self.ku.domain();
            let h = if u - u0 > u1 - u { -1.0 } else { 1.0 };
            if let Some(n) = Point::try_normalize(d2.du.cross(d2.duv) * h) {
                return n;
            }
        }
        // Both vanish or are parallel: look a little way towards the middle of the domain.
        let ((u0, u1), (v0, v1)) = self.domain();
        let nudge = 1e-3;
        let un = u + (0.5 * (u0 + u1) - u) * nudge;
        let vn = v + (0.5 * (v0 + v1) - v) * nudge;
        let dn = self.derivs(un, vn, 1);
        Point::try_normalize(dn.du.cross(dn.dv)).unwrap_or(Vec3::Z)
    }
}

#[inline]
fn sq(x: f32) -> f32 {
    x * x
}

/// Piegl & Tiller A4.4 for total order `d <= 2`: Cartesian derivatives of the rational surface
/// from the homogeneous ones.
#[inline]
fn rational_surface_derivs(
    skl: &[[Vec4; MAX_DERIV + 1]; MAX_DERIV + 1],
    d: usize,
) -> SurfaceDerivs {
    const BIN: [[f32; 3]; 3] = [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [1.0, 2.0, 1.0]];
    let w = |k: usize, l: usize| skl[k][l].w;
    let inv_w = 1.0 / w(0, 0);
    let mut c = [[Vec3::ZERO; MAX_DERIV + 1]; MAX_DERIV + 1];
    for k in 0..=d {
        for l in 0..=d - k {
            let mut v = skl[k][l].truncate();
            for j in 1..=l {
                v -= c[k][l - j] * (BIN[l][j] * w(0, j));
            }
            for i in 1..=k {
                v -= c[k - i][l] * (BIN[k][i] * w(i, 0));
                let mut v2 = Vec3::ZERO;
                for j in 1..=l {
                    v2 += c[k - i][l - j] * (BIN[l][j] * w(i, j));
                }
                v -= v2 * BIN[k][i];
            }
            c[k][l] = v * inv_w;
        }
    }
    SurfaceDerivs {
        point: c[0][0],
        du: c[1][0],
        dv: c[0][1],
        duu: c[2][0],
        duv: c[1][1],
        dvv: c[0][2],
    }
}

/// The area of the cell `[u0, u1] × [v0, v1]` of `s`: `∫∫ |S_u × S_v| du dv` by 2 × 2
/// Gauss–Legendre quadrature.
fn cell_area(s: &Surface<'_>, (u0, u1): (f32, f32), (v0, v1): (f32, f32)) -> f32 {
    let (hu, hv) = (0.5 * (u1 - u0), 0.5 * (v1 - v0));
    let mut sum = 0.0;
    for gu in crate::extent::GAUSS_2 {
        for gv in crate::extent::GAUSS_2 {
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

/// Refuses a surface of no area ([`NurbsError::ZeroArea`]) or with a cell (a pair of knot
/// spans) collapsed to a line, a curve or a point ([`NurbsError::CollapsedCell`]): the area
/// over the diameter of the control net, a mean width, below [`MIN_EXTENT`](crate::MIN_EXTENT). One evaluation
/// pass: four first-derivative evaluations per cell.
fn check_area(s: &Surface<'_>) -> Result<(), NurbsError> {
    let (ku, kv) = s.knots();
    let (p, q) = s.degree();
    let (uk, vk) = (ku.as_slice(), kv.as_slice());
    let mut area = 0.0;
    let mut collapsed = None;
    for i in ku.span_indices().filter(|&i| uk[i] < uk[i + 1]) {
        for j in kv.span_indices().filter(|&j| vk[j] < vk[j + 1]) {
            let cell = cell_area(s, (uk[i], uk[i + 1]), (vk[j], vk[j + 1]));
            area += cell;
            let width = cell / net_diameter(s, i - p..=i, j - q..=j).max(crate::MIN_EXTENT);
            if collapsed.is_none() && crate::extent::too_thin(width) {
                collapsed = Some(NurbsError::CollapsedCell {
                    span: (i, j),
                    width,
                });
            }
        }
    }
    let (nu, nv) = s.counts();
    let width = area / net_diameter(s, 0..=nu - 1, 0..=nv - 1).max(crate::MIN_EXTENT);
    if crate::extent::too_thin(width) {
        return Err(NurbsError::ZeroArea { width });
    }
    collapsed.map_or(Ok(()), Err)
}
