//! Exact constructions (Piegl & Tiller ch. 7–8). Their geometry is known in closed form, so
//! they double as test oracles. Angles are computed in `f64` and rounded once to `f32`.
//!
//! Orientation: circles and ellipses run counter-clockwise (outward planar normals); surfaces
//! of revolution have `u` around the axis (counter-clockwise seen from the axis tip) and `v`
//! along the profile, so `S_u × S_v` points away from the axis where the profile runs along
//! the axis direction. Sphere, cylinder and torus normals point outward.

use alloc::vec;
use alloc::vec::Vec;
use core::f64::consts::{FRAC_PI_2, PI, TAU};
use glam::{DVec3, Vec2, Vec3, Vec4};

use crate::error::NurbsError;
use crate::point::Point;
use crate::{CurveBuf, SurfaceBuf};

/// Clamped knots `[0; p+1], [1; p+1]` of a Bézier segment.
fn bezier_knots(p: usize) -> Vec<f32> {
    let mut k = vec![0.0; p + 1];
    k.resize(2 * p + 2, 1.0);
    k
}

/// The clamped uniform knot vector on [0, 1] for `n_points` control points of `degree`
/// (interior knots evenly spaced, each once); empty when `n_points <= degree`.
pub fn uniform_knots(n_points: usize, degree: usize) -> Vec<f32> {
    if n_points <= degree {
        return Vec::new();
    }
    let spans = n_points - degree;
    let mut k = vec![0.0; degree + 1];
    k.extend((1..spans).map(|i| i as f32 / spans as f32));
    k.resize(n_points + degree + 1, 1.0);
    k
}

/// The straight segment from `a` to `b`, degree 1, domain [0, 1].
///
/// ```
/// use nurbs::{Vec3, construct};
///
/// let (a, b) = (Vec3::new(1.0, 2.0, 3.0), Vec3::new(4.0, -2.0, 3.0));
/// let line = construct::line(a, b)?;
/// let c = line.view();
/// for u in [0.0, 0.3, 0.5, 1.0] {
///     let f = c.frame(u);
///     // C(u) = a + u (b − a); a lerp of values ≤ 4 in f32 (ε = 1.2e-7): 1e-6 absolute.
///     assert!((f.derivs.point - a.lerp(b, u)).length() <= 1e-6);
///     // The derivative is the chord over the domain's length 1 (exact: b − a is exact),
///     // and a straight line has no curvature.
///     assert_eq!(f.derivs.du, b - a);
///     assert_eq!(f.derivs.duu, Vec3::ZERO);
///     assert_eq!(f.curvature, 0.0);
///     // Unit tangent (b − a) / 5 after `math::sqrt` (≤ 4 ε): 1e-6 is about 8 ε.
///     assert!((f.tangent - (b - a) / 5.0).length() <= 1e-6);
/// }
/// # Ok::<(), nurbs::NurbsError>(())
/// ```
pub fn line<P: Point>(a: P, b: P) -> Result<CurveBuf<P>, NurbsError> {
    CurveBuf::from_cartesian(1, vec![0.0, 0.0, 1.0, 1.0], &[a, b], None)
}

/// The Bézier curve of the given control points (degree = count − 1), domain [0, 1].
pub fn bezier_curve<P: Point>(points: &[P]) -> Result<CurveBuf<P>, NurbsError> {
    let p = points.len().saturating_sub(1);
    CurveBuf::from_cartesian(p, bezier_knots(p), points, None)
}

/// Knots and per-segment data of a rational quadratic arc split into at most 90° pieces
/// (Piegl & Tiller A7.1). Returns `(knots, [(cos, sin, weight)])` for the `2·narcs + 1`
/// control points, in the arc's own `(x, y)` frame with unit radius.
fn unit_arc(start_rad: f64, sweep_rad: f64) -> (Vec<f32>, Vec<(f64, f64, f64)>) {
    let sweep = sweep_rad.clamp(0.0, TAU);
    // The tolerance absorbs f32 rounding of the sweep (a quarter circle given as
    // `FRAC_PI_2 as f32` is one arc, not two).
    let narcs = (libm::ceil(sweep / FRAC_PI_2 - 1e-6) as usize).clamp(1, 4);
    let dtheta = sweep / narcs as f64;
    let w1 = libm::cos(dtheta / 2.0);
    let mut pts = Vec::with_capacity(2 * narcs + 1);
    pts.push((libm::cos(start_rad), libm::sin(start_rad), 1.0));
    for i in 1..=narcs {
        let end = start_rad + dtheta * i as f64;
        let mid = end - dtheta / 2.0;
        // The middle point is where the end tangents meet: radius / cos(Δθ/2) along the bisector.
        pts.push((libm::cos(mid) / w1, libm::sin(mid) / w1, w1));
        pts.push((libm::cos(end), libm::sin(end), 1.0));
    }
    let mut knots = vec![0.0f32; 3];
    for i in 1..narcs {
        let k = (i as f64 / narcs as f64) as f32;
        knots.push(k);
        knots.push(k);
    }
    knots.extend([1.0f32; 3]);
    (knots, pts)
}

/// A rational quadratic arc `center + cos θ · x_axis + sin θ · y_axis` for θ from `start_rad`
/// over `sweep_rad` (clamped to [0, 2π]), domain [0, 1].
///
/// With orthogonal axes of equal length `r` this is an exact circular arc of radius `r`; any
/// other pair gives its affine image, an exact elliptical arc.
pub fn arc<P: Point>(
    center: P,
    x_axis: P,
    y_axis: P,
    start_rad: f32,
    sweep_rad: f32,
) -> Result<CurveBuf<P>, NurbsError> {
    let (knots, unit) = unit_arc(start_rad as f64, sweep_rad as f64);
    let pts: Vec<P::Hom> = unit
        .iter()
        .map(|&(c, s, w)| (center + x_axis * c as f32 + y_axis * s as f32).weighted(w as f32))
        .collect();
    CurveBuf::new(2, knots, pts)
}

/// The full counter-clockwise circle of `radius` around `center`, starting at angle 0,
/// rational quadratic with 9 control points.
///
/// Four 90° arcs (Piegl & Tiller A7.1): the middle control point of each lies where the
/// arc's end tangents meet, with weight cos 45°, which makes every arc exact.
///
/// ```
/// use nurbs::{Vec2, construct};
///
/// let (center, r) = (Vec2::new(0.1, -0.05), 0.03);
/// let circle = construct::circle(center, r)?;
/// let c = circle.view();
/// assert!(c.is_closed(1e-9));
/// for i in 0..=40 {
///     let f = c.frame(i as f32 / 40.0);
///     let radial = f.derivs.point - center;
///     // Exact in real arithmetic; in f32 the points are rounded at coordinates up to
///     // 0.13, where an ulp is 1.5e-8, and C − c cancels the centre: 1e-7 absolute (about
///     // 7 ulp, 3.3e-6 relative to r).
///     assert!((radial.length() - r).abs() <= 1e-7, "|C − c| = {}", radial.length());
///     // Counter-clockwise, so the signed curvature is +1/r and the normal t × k̂ points
///     // out along the radius. The curvature divides by |C'|³ after the rational second
///     // derivative (P&T A4.2) and `math::sqrt` (≤ 4 ε): 1e-5 relative, about 80 ε.
///     assert!((f.curvature * r - 1.0).abs() <= 1e-5, "κ r = {}", f.curvature * r);
///     // The radial direction carries the 3.3e-6 above: 5e-6 on a unit vector.
///     assert!((f.normal - radial / r).length() <= 5e-6);
/// }
/// // The quarters start at angles 0, π/2, π and 3π/2, at u = 0, 1/4, 1/2 and 3/4.
/// let top = c.point(0.25);
/// assert!((top - (center + Vec2::new(0.0, r))).length() <= 1e-6 * r);
/// # Ok::<(), nurbs::NurbsError>(())
/// ```
pub fn circle(center: Vec2, radius: f32) -> Result<CurveBuf<Vec2>, NurbsError> {
    arc(
        center,
        Vec2::X * radius,
        Vec2::Y * radius,
        0.0,
        core::f32::consts::TAU,
    )
}

/// The full counter-clockwise ellipse with semi-axes `a` (along x) and `b` (along y).
pub fn ellipse(center: Vec2, a: f32, b: f32) -> Result<CurveBuf<Vec2>, NurbsError> {
    arc(
        center,
        Vec2::X * a,
        Vec2::Y * b,
        0.0,
        core::f32::consts::TAU,
    )
}

/// The tensor-product Bézier patch of `rows[i][j]` (`i` along u), degrees = counts − 1.
pub fn bezier_patch<R: AsRef<[Vec3]>>(rows: &[R]) -> Result<SurfaceBuf, NurbsError> {
    let p = rows.len().saturating_sub(1);
    let q = rows
        .first()
        .map_or(0, |r| r.as_ref().len())
        .saturating_sub(1);
    SurfaceBuf::from_rows::<R, &[f32]>((p, q), (bezier_knots(p), bezier_knots(q)), rows, None)
}

/// The bilinear patch `S(u, v)` with `S(0,0) = p00`, `S(1,0) = p10`, `S(0,1) = p01`,
/// `S(1,1) = p11`.
pub fn bilinear(p00: Vec3, p10: Vec3, p01: Vec3, p11: Vec3) -> Result<SurfaceBuf, NurbsError> {
    bezier_patch(&[[p00, p01], [p10, p11]])
}

/// The surface swept by rotating `profile` by `sweep_rad` around the axis through
/// `axis_origin` along `axis_dir` (Piegl & Tiller A8.1). `u` runs around the axis
/// (counter-clockwise about `axis_dir`, domain [0, 1]), `v` along the profile (its own
/// domain). Profile points on the axis collapse to a pole.
pub fn revolve(
    profile: &CurveBuf<Vec3>,
    axis_origin: Vec3,
    axis_dir: Vec3,
    sweep_rad: f32,
) -> Result<SurfaceBuf, NurbsError> {
    let axis = axis_dir.as_dvec3().try_normalize().unwrap_or(DVec3::Z);
    let origin = axis_origin.as_dvec3();
    let (knots_u, unit) = unit_arc(0.0, sweep_rad as f64);
    let prof = profile.points();
    let count_v = prof.len();
    let size = profile
        .view()
        .bounding_box()
        .max_distance_squared(axis_origin)
        .max(f32::MIN_POSITIVE) as f64;
    let mut pts = vec![Vec4::ZERO; unit.len() * count_v];
    for (j, h) in prof.iter().enumerate() {
        let wj = h.w as f64;
        let pj = h.truncate().as_dvec3() / wj;
        let o = origin + axis * (pj - origin).dot(axis);
        let x = pj - o;
        let r2 = x.length_squared();
        for (i, &(c, s, wa)) in unit.iter().enumerate() {
            let p = if r2 <= 1e-14 * size {
                o
            } else {
                let y = axis.cross(x);
                o + x * c + y * s
            };
            let w = wj * wa;
            pts[i * count_v + j] = (p * w).as_vec3().extend(w as f32);
        }
    }
    SurfaceBuf::new(
        (2, profile.degree()),
        (knots_u, profile.knots().to_vec()),
        count_v,
        pts,
    )
}

/// A unit vector orthogonal to `axis` (the start of the `u` sweep of the revolved shapes).
fn radial(axis: Vec3) -> Vec3 {
    axis.try_normalize()
        .unwrap_or(Vec3::Z)
        .any_orthonormal_vector()
}

/// The lateral surface of a cylinder: base circle around `base_center` in the plane normal to
/// `axis`, `height` along `axis`. Outward normals.
///
/// ```
/// use nurbs::{Vec3, construct};
///
/// let (base, axis, r, h) = (Vec3::new(0.0, 0.0, 0.1), Vec3::Z, 0.04, 0.2);
/// let cylinder = construct::cylinder(base, axis, r, h)?;
/// let s = cylinder.view();
/// for i in 0..=8 {
///     for j in 0..=4 {
///         let (u, v) = (i as f32 / 8.0, j as f32 / 4.0);
///         let p = s.point(u, v) - base;
///         let radial = Vec3::new(p.x, p.y, 0.0);
///         // Distance r from the axis and height v h along it, to f32 rounding of
///         // coordinates ≤ 0.3 (ulp 3e-8): 1e-6 relative to r is 4e-8.
///         assert!((radial.length() - r).abs() <= 1e-6 * r, "radius {}", radial.length());
///         assert!((p.z - v * h).abs() <= 1e-7);
///         // Outward normal: the radial direction (a cross product and `math::sqrt`,
///         // ≤ 4 ε: 1e-6 on a unit vector is about 8 ε).
///         assert!((s.normal(u, v) - radial / r).length() <= 1e-6);
///     }
/// }
/// # Ok::<(), nurbs::NurbsError>(())
/// ```
pub fn cylinder(
    base_center: Vec3,
    axis: Vec3,
    radius: f32,
    height: f32,
) -> Result<SurfaceBuf, NurbsError> {
    let a = axis.try_normalize().unwrap_or(Vec3::Z);
    let x = radial(a);
    let start = base_center + x * radius;
    let profile = line(start, start + a * height)?;
    revolve(&profile, base_center, a, core::f32::consts::TAU)
}

/// The sphere of `radius` around `center`, poles on the z axis (`v = 0` south, `v = 1`
/// north). Outward normals, finite at the poles.
///
/// ```
/// use nurbs::{Vec3, construct};
///
/// let (center, r) = (Vec3::new(1.0, 2.0, -1.0), 0.5);
/// let sphere = construct::sphere(center, r)?;
/// let s = sphere.view();
/// for i in 0..=8 {
///     for j in 0..=8 {
///         let (u, v) = (i as f32 / 8.0, j as f32 / 8.0);
///         let p = s.point(u, v);
///         // |S − c| = r everywhere; the centre's coordinates (ulp ≤ 2.4e-7 at 2) limit
///         // this: 2e-6 relative to r is 1e-6, four ulp.
///         assert!(((p - center).length() - r).abs() <= 2e-6 * r);
///         // The outward normal is the radius direction, also at the poles v = 0, 1
///         // (their finite limit): the 2e-6 above plus a normalisation, 5e-6.
///         assert!((s.normal(u, v) - (p - center) / r).length() <= 5e-6, "n({u}, {v})");
///     }
/// }
/// // v = 0 is the south pole, v = 1 the north pole, whatever u.
/// assert!((s.point(0.3, 0.0) - (center - r * Vec3::Z)).length() <= 1e-6);
/// assert!((s.normal(0.3, 1.0) - Vec3::Z).length() <= 5e-6);
/// # Ok::<(), nurbs::NurbsError>(())
/// ```
pub fn sphere(center: Vec3, radius: f32) -> Result<SurfaceBuf, NurbsError> {
    let x = radial(Vec3::Z);
    let meridian = arc(
        center,
        x * radius,
        Vec3::Z * radius,
        -FRAC_PI_2 as f32,
        PI as f32,
    )?;
    revolve(&meridian, center, Vec3::Z, core::f32::consts::TAU)
}

/// The torus around the z axis through `center`, with `major` radius (centre to tube centre)
/// and `minor` radius (tube). `v = 0` on the outer equator. Outward normals.
pub fn torus(center: Vec3, major: f32, minor: f32) -> Result<SurfaceBuf, NurbsError> {
    let x = radial(Vec3::Z);
    let tube = arc(
        center + x * major,
        x * minor,
        Vec3::Z * minor,
        0.0,
        core::f32::consts::TAU,
    )?;
    revolve(&tube, center, Vec3::Z, core::f32::consts::TAU)
}
