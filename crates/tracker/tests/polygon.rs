//! The polygonal baseline (tessellation + closest point on segments and triangles) against
//! closed forms: the sagitta of a circular chord, the exact distances to circles, spheres and
//! tori, and a closest-point-on-triangle reference by the KKT case split (face projection, else
//! the best of the three edges) that shares nothing with Ericson's Voronoi-region walk.
#![allow(clippy::unwrap_used)]

use glam::DVec3;
use nurbs::{Vec2, Vec3, construct};
use proptest::prelude::*;
use std::sync::OnceLock;
use testkit::{RefCurve, angle_deg, convex_curve, v2, wide};
use tracker::{
    MAX_MESH_CELLS, MAX_POLYLINE_VERTICES, Polyline, TriMesh, closest_point_on_triangle,
};

const CENTER: Vec2 = Vec2::new(0.0, 0.09);

/// Segments a polygon inscribed in a circle of radius `r` needs at least, for chord heights
/// (sagittas `r(1 − cos(θ/2))`) at most `tol`: `⌈2π / θ_max⌉`, `θ_max = 2 acos(1 − tol/r)`.
fn min_inscribed_segments(r: f64, tol: f64) -> usize {
    let theta_max = 2.0 * (1.0 - tol / r).acos();
    (std::f64::consts::TAU / theta_max).ceil() as usize
}

/// Polyline of the exact rational circle: vertices on the circle, every chord's sagitta (closed
/// form from the chord length) within the tolerance, and a segment count between the minimum
/// any inscribed polygon needs and the bound bisection guarantees.
///
/// Bound: the bisection tree of each of the 4 quarter spans has leaves = internal nodes + 1,
/// and every internal node is an arc whose sampled chord height exceeded `tol`, so its angle
/// exceeds `θ_max`; internal nodes of one depth are disjoint, so each depth holds at most
/// `2π/θ_max` of them, and angles halve per depth up to the rational parametrisation's speed
/// variation inside a 90° span (less than 2: the quarter-circle weight is cos 45°), which adds
/// at most one level to the geometric sum `2 · 2π/θ_max`. Hence leaves ≤ 4⌈2π/θ_max⌉ + 4.
#[test]
fn circle_polyline_sagitta_and_segment_count() {
    let r = 0.03f32;
    let c = construct::circle(CENTER, r).unwrap();
    for tol in [1e-3f32, 3e-4, 1e-4, 1e-5] {
        let poly = Polyline::tessellate(&c.view(), tol);
        let pts = poly.points();
        for p in pts {
            let radial = (wide(*p) - wide(CENTER)).length();
            assert!(
                (radial - r as f64).abs() < 1e-7,
                "vertex off the circle by {radial}"
            );
        }
        let mut worst = 0.0f64;
        for w in pts.windows(2) {
            let chord = (wide(w[1]) - wide(w[0])).length();
            let half = chord / 2.0;
            let sagitta = r as f64 - (r as f64 * r as f64 - half * half).sqrt();
            worst = worst.max(sagitta);
        }
        assert!(
            worst <= tol as f64 + 1e-8,
            "tol {tol}: worst sagitta {worst}"
        );
        let n = poly.segment_count();
        let n_min = min_inscribed_segments(r as f64, tol as f64);
        assert!(
            n >= n_min && n <= 4 * n_min + 4,
            "tol {tol}: {n} segments, minimum {n_min}"
        );
        // Closed: first and last vertex coincide, parameters span the domain.
        assert!((pts[0] - pts[pts.len() - 1]).length() < 1e-7);
        assert_eq!(poly.params()[0], 0.0);
        assert_eq!(*poly.params().last().unwrap(), 1.0);
        assert!(poly.params().windows(2).all(|w| w[0] < w[1]));
    }
}

/// A polygon inscribed in a circle with sagittas ≤ tol is within tol of the circle and the
/// circle within tol of it (radially), so its distance to any point differs from the exact
/// distance `| |x − c| − r |` by at most tol.
#[test]
fn circle_polyline_distance_error_within_tolerance() {
    let r = 0.03f32;
    let c = construct::circle(CENTER, r).unwrap();
    let tol = 5e-4f32;
    let poly = Polyline::tessellate(&c.view(), tol);
    let mut worst = 0.0f64;
    for k in 0..2000 {
        let a = k as f64 * 0.0137;
        let rad = 0.005 + 0.05 * ((k * 7919) % 1000) as f64 / 1000.0;
        let x = wide(CENTER) + DVec3::new(a.cos(), a.sin(), 0.0) * rad;
        let hit = poly.closest(v2(x));
        let exact = ((x - wide(CENTER)).length() - r as f64).abs();
        let err = (hit.distance_squared as f64).sqrt() - exact;
        worst = worst.max(err.abs());
    }
    assert!(worst <= tol as f64 + 1e-7, "distance error {worst}");
}

/// The segment normal differs from the circle's radial normal at the closest point by at most
/// half the segment's angle (the segment normal is the radial direction of the chord's
/// midpoint), and sweeping HIPs around the circle reaches that worst case: the force-direction
/// artefact of the polygonal method is real, not a bound artefact.
#[test]
fn circle_polyline_normal_error_reaches_half_segment_angle() {
    let r = 0.03f32;
    let c = construct::circle(CENTER, r).unwrap();
    let poly = Polyline::tessellate(&c.view(), 5e-4);
    let pts = poly.points();
    let half_angle = |i: usize| {
        let (a, b) = (wide(pts[i]) - wide(CENTER), wide(pts[i + 1]) - wide(CENTER));
        angle_deg(a, b) / 2.0
    };
    let max_half = (0..poly.segment_count())
        .map(half_angle)
        .fold(0.0, f64::max);
    let mut worst = 0.0f64;
    for k in 0..20000 {
        let a = std::f64::consts::TAU * k as f64 / 20000.0;
        let x = wide(CENTER) + DVec3::new(a.cos(), a.sin(), 0.0) * 0.04;
        let hit = poly.closest(v2(x));
        let radial = wide(hit.point) - wide(CENTER);
        let err = angle_deg(wide(hit.normal), radial);
        assert!(
            err <= half_angle(hit.segment) + 1e-3,
            "normal error {err}° beyond half the segment angle {}°",
            half_angle(hit.segment)
        );
        worst = worst.max(err);
    }
    assert!(
        worst >= 0.95 * max_half,
        "worst {worst}°, half-angle {max_half}°"
    );
}

/// The closest point on a segment by dense sampling, `f64`.
fn sampled_segment_distance(a: DVec3, b: DVec3, x: DVec3) -> f64 {
    (0..=2000)
        .map(|k| (a + (b - a) * (k as f64 / 2000.0) - x).length())
        .fold(f64::INFINITY, f64::min)
}

/// Closest point on a triangle by the KKT case split: the projection on the plane if its
/// barycentric coordinates are all non-negative, else the closest point on one of the edges.
fn kkt_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let n = (b - a).cross(c - a);
    let q = p - n * ((p - a).dot(n) / n.dot(n));
    let area = |u: DVec3, v: DVec3, w: DVec3| (v - u).cross(w - u).dot(n);
    let total = area(a, b, c);
    let w = [area(q, b, c), area(a, q, c), area(a, b, q)].map(|x| x / total);
    if w.iter().all(|&x| x >= 0.0) {
        return q;
    }
    let on_edge = |u: DVec3, v: DVec3| {
        let s = ((p - u).dot(v - u) / (v - u).dot(v - u)).clamp(0.0, 1.0);
        u + (v - u) * s
    };
    [on_edge(a, b), on_edge(b, c), on_edge(c, a)]
        .into_iter()
        .min_by(|x, y| (*x - p).length().total_cmp(&(*y - p).length()))
        .unwrap()
}

fn coord() -> impl Strategy<Value = f32> {
    -0.05f32..0.05
}

fn point3() -> impl Strategy<Value = Vec3> {
    (coord(), coord(), coord()).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Ericson's closest point equals the KKT reference, and its barycentric coordinates are a
    /// convex combination that reproduces it.
    #[test]
    fn triangle_closest_point_matches_kkt(a in point3(), b in point3(), c in point3(), p in point3()) {
        let n = (b - a).cross(c - a);
        prop_assume!(n.length() > 1e-2 * (b - a).length().max((c - a).length()).powi(2));
        let (q, w) = closest_point_on_triangle(p, a, b, c);
        let reference = kkt_triangle(wide(p), wide(a), wide(b), wide(c));
        prop_assert!((wide(q) - reference).length() < 1e-6, "{q} vs {reference:?}");
        prop_assert!(w.iter().all(|&x| (-1e-6..=1.0 + 1e-6).contains(&x)));
        prop_assert!((w[0] + w[1] + w[2] - 1.0).abs() < 1e-5);
        let recon = a * w[0] + b * w[1] + c * w[2];
        prop_assert!((recon - q).length() < 1e-6);
    }

    /// The polyline of a random convex curve: vertices on the curve, the closest point matches
    /// dense sampling of every segment, and the interpolated parameter lies between the
    /// segment's vertex parameters.
    #[test]
    fn polyline_closest_matches_sampling(
        curve in convex_curve(),
        x in (coord(), 0.04f32..0.14),
        tol in 1e-4f32..2e-3,
    ) {
        let x = Vec2::new(x.0, x.1);
        let view = curve.view();
        let reference = RefCurve::new(&view);
        let poly = Polyline::tessellate(&view, tol);
        for (p, &t) in poly.points().iter().zip(poly.params()) {
            prop_assert!((wide(*p) - reference.point(t as f64)).length() < 1e-6);
        }
        let hit = poly.closest(x);
        let sampled = poly
            .points()
            .windows(2)
            .map(|w| sampled_segment_distance(wide(w[0]), wide(w[1]), wide(x)))
            .fold(f64::INFINITY, f64::min);
        let d = (hit.distance_squared as f64).sqrt();
        // Sampling overestimates by at most half a sample spacing (segments < 0.2 m).
        prop_assert!(d <= sampled + 1e-6 && d >= sampled - 1e-4 - 1e-6, "{d} vs {sampled}");
        let (ta, tb) = (poly.params()[hit.segment], poly.params()[hit.segment + 1]);
        prop_assert!(hit.t >= ta && hit.t <= tb);
        prop_assert!((hit.normal.length() - 1.0).abs() < 1e-5);
        // The segment normal is orthogonal to the segment.
        let seg = poly.points()[hit.segment + 1] - poly.points()[hit.segment];
        prop_assert!(hit.normal.dot(seg).abs() <= 1e-5 * seg.length());
    }

    /// Sphere mesh against the exact distance `| |x − c| − r |`.
    #[test]
    fn sphere_mesh_distance_error(dir in point3(), rad in 0.005f32..0.06) {
        prop_assume!(dir.length() > 1e-3);
        let (center, r, tol) = sphere_setup();
        let mesh = sphere_mesh();
        let x = center + dir.normalize() * rad;
        let hit = mesh.closest(x).unwrap();
        let exact = ((wide(x) - wide(center)).length() - r as f64).abs();
        let err = ((hit.distance_squared as f64).sqrt() - exact).abs();
        prop_assert!(err <= MESH_SLACK * tol as f64 + 1e-7, "error {err}");
    }

    /// Torus mesh against the exact distance `| |(ρ − R, z)| − r |`.
    #[test]
    fn torus_mesh_distance_error(x in point3()) {
        let (center, major, minor, tol) = (Vec3::ZERO, 0.03f32, 0.01f32, 3e-4f32);
        let mesh = torus_mesh();
        let hit = mesh.closest(x).unwrap();
        let q = wide(x) - wide(center);
        let rho = (q.x * q.x + q.y * q.y).sqrt();
        let exact = (((rho - major as f64).powi(2) + q.z.powi(2)).sqrt() - minor as f64).abs();
        let err = ((hit.distance_squared as f64).sqrt() - exact).abs();
        prop_assert!(err <= MESH_SLACK * tol as f64 + 1e-7, "error {err}");
    }
}

/// Allowance of the mesh's sampled chord-height estimate over the true deviation. For a
/// locally quadratic deviation over a (near-)rectangular cell split along its diagonal, the
/// largest deviation of a triangle lies at its hypotenuse midpoint, which is the sampled cell
/// centre; what is left is the variation of curvature across a cell and the non-affine
/// (rational) parametrisation, small at the tolerances used here.
const MESH_SLACK: f64 = 1.25;

fn sphere_setup() -> (Vec3, f32, f32) {
    (Vec3::new(0.0, 0.09, 0.0), 0.03, 3e-4)
}

fn sphere_mesh() -> &'static TriMesh {
    static MESH: OnceLock<TriMesh> = OnceLock::new();
    MESH.get_or_init(|| {
        let (center, r, tol) = sphere_setup();
        TriMesh::tessellate(&construct::sphere(center, r).unwrap().view(), tol)
    })
}

fn torus_mesh() -> &'static TriMesh {
    static MESH: OnceLock<TriMesh> = OnceLock::new();
    MESH.get_or_init(|| {
        TriMesh::tessellate(
            &construct::torus(Vec3::ZERO, 0.03, 0.01).unwrap().view(),
            3e-4,
        )
    })
}

/// Sphere mesh: vertices on the sphere, outward triangle normals, and every triangle within
/// the tolerance of the sphere: the largest gap between a triangle and the sphere is
/// `r − dist(c, triangle)` (the sphere point above the triangle point nearest the centre),
/// computed with the KKT reference.
#[test]
fn sphere_mesh_chord_height() {
    let (center, r, tol) = sphere_setup();
    let mesh = sphere_mesh();
    let c = wide(center);
    for v in mesh.vertices() {
        assert!(((wide(*v) - c).length() - r as f64).abs() < 1e-7);
    }
    let mut worst = 0.0f64;
    for (tri, n) in mesh.triangles().iter().zip(mesh.normals()) {
        let [a, b, d] = tri.map(|i| wide(mesh.vertices()[i as usize]));
        let centroid = (a + b + d) * (1.0 / 3.0);
        assert!(wide(*n).dot(centroid - c) > 0.0, "inward triangle normal");
        let gap = r as f64 - (kkt_triangle(c, a, b, d) - c).length();
        worst = worst.max(gap);
    }
    assert!(
        worst <= MESH_SLACK * tol as f64,
        "worst chord height {worst}"
    );
    assert!(
        worst >= 0.25 * tol as f64,
        "mesh finer than needed: {worst}"
    );
    assert!(mesh.triangles().len() <= 2 * MAX_MESH_CELLS);
}

/// The caps bound the work for tolerances that cannot be met (NaN, zero, negative).
#[test]
fn caps_bound_degenerate_tolerances() {
    let c = construct::circle(CENTER, 0.03).unwrap();
    for tol in [f32::NAN, 0.0, -1.0] {
        let poly = Polyline::tessellate(&c.view(), tol);
        assert!(poly.points().len() <= MAX_POLYLINE_VERTICES);
        assert!(poly.points().iter().all(|p| p.is_finite()));
        let hit = poly.closest(Vec2::new(0.1, 0.1));
        assert!(hit.point.is_finite() && hit.distance_squared.is_finite());
    }
    let s = construct::sphere(Vec3::new(0.0, 0.09, 0.0), 0.03).unwrap();
    let mesh = TriMesh::tessellate(&s.view(), f32::NAN);
    assert!(mesh.triangles().len() <= 2 * MAX_MESH_CELLS);
    assert!(mesh.closest(Vec3::ZERO).unwrap().point.is_finite());
    // A straight line needs no refinement at a positive tolerance.
    let line = construct::line(Vec2::new(-0.04, 0.06), Vec2::new(0.04, 0.12)).unwrap();
    assert_eq!(Polyline::tessellate(&line.view(), 1e-6).segment_count(), 1);
}

/// `TriMesh::from_triangles` keeps valid triangles with their right-hand normals, drops one
/// whose index is out of range and one of zero area, and pads missing parameters with zero.
#[test]
fn from_triangles_keeps_the_valid_ones() {
    let vertices = vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(2.0, 0.0, 0.0),
    ];
    let mesh = TriMesh::from_triangles(
        vertices,
        vec![[0.5, 0.5]],
        &[[0, 1, 2], [0, 2, 1], [0, 1, 9], [0, 1, 3]],
    );
    assert_eq!(mesh.triangles(), &[[0, 1, 2], [0, 2, 1]]);
    assert_eq!(mesh.normals(), &[Vec3::Z, -Vec3::Z]);
    assert_eq!(mesh.params(), &[[0.5, 0.5], [0.0; 2], [0.0; 2], [0.0; 2]]);
    let hit = mesh.closest(Vec3::new(0.25, 0.25, 1.0)).expect("a hit");
    assert_eq!(hit.point, Vec3::new(0.25, 0.25, 0.0));
}
