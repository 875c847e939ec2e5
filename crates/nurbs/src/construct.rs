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
