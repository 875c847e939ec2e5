//! Properties of the stick–slip renderer over random smooth surfaces and random HIP paths:
//! the friction force never exceeds μ_s F_N, nothing is ever NaN, and friction does no net
//! positive work on the HIP around a closed path (it only dissipates).
#![allow(clippy::unwrap_used)]

use friction::{FrictionMaterial, FrictionRenderer, Mode};
use nurbs::{Point, Vec2, Vec3, construct};
use proptest::prelude::*;
use tracker::{Chain, Object, Shell};

const T: f32 = 1e-3;

/// A closed HIP path: from 5 mm above `start` straight down to `depth`, a loop of random
/// wiggles around the press point in the surface's tangent directions, and back up the same
/// line. Every step is at most `step` metres.
fn closed_path<P: nurbs::Point>(
    start: P,
    normal: P,
    tangents: &[P],
    depth: f32,
    wiggle: &[(f32, f32)],
) -> Vec<P> {
    let above = start + normal * 0.005;
    let pressed = start - normal * depth;
    let mut pts = vec![above, pressed];
    let mut phase = 0.0f32;
    for &(a, b) in wiggle {
        phase += 1.0;
        let mut off = P::ZERO;
        for (i, &t) in tangents.iter().enumerate() {
            off += t * (a * (phase * (1.3 + i as f32)).sin() + b * (phase * 0.7).cos());
        }
        pts.push(pressed + off);
    }
    pts.push(pressed);
    pts.push(above);
    // Resample at 50 µm per tick.
    let mut out = vec![pts[0]];
    for w in pts.windows(2) {
        let n = ((w[1] - w[0]).length_squared().sqrt() / 5e-5)
            .ceil()
            .max(1.0) as usize;
        for k in 1..=n {
            out.push(w[0] + (w[1] - w[0]) * (k as f32 / n as f32));
        }
    }
    out
}

/// Runs the renderer; checks the bound and finiteness per tick; returns the friction work on
/// the HIP (trapezoidal rule, exact for the piecewise linear spring forces of the stuck state).
fn check_run<O: Object>(
    object: &O,
    path: &[O::P],
    material: FrictionMaterial,
) -> Result<f32, TestCaseError> {
    let mut r = FrictionRenderer::new(object, material, path[0]);
    let mut prev_x = path[0];
    let mut prev_f = O::P::ZERO;
    let mut work = 0.0f32;
    let mut prev_go: Option<O::P> = None;
    for &x in path {
        let o = r.tick(object, x, (x - prev_x) * (1.0 / T), T);
        // Friction opposes the GO's slide: it never points along the way the GO moved (f32
        // rounding of a force of a few newtons over steps of micrometres: 1e-9 J).
        if let Some(g) = prev_go.filter(|_| o.mode != Mode::Free) {
            let along = o.friction.dot(o.go - g);
            prop_assert!(
                along <= 1e-9,
                "friction along the slide: {along} in {:?}",
                o.mode
            );
        }
        prev_go = (o.mode != Mode::Free).then_some(o.go);
        prop_assert!(o.total.is_finite() && o.friction.is_finite() && o.normal_force_n.is_finite());
        prop_assert!(o.normal_force_n >= 0.0);
        let limit = material.mu_static * o.normal_force_n;
        prop_assert!(
            o.friction.length_squared().sqrt() <= limit * (1.0 + 1e-4) + 1e-5,
            "|F_f| = {} > μ_s F_N = {} in {:?}",
            o.friction.length_squared().sqrt(),
            limit,
            o.mode
        );
        if o.mode == Mode::Slip {
            // μ_d F_N, or less while the spring re-stretches after the HIP pressed deeper.
            prop_assert!(
                o.friction.length_squared().sqrt()
                    <= material.mu_dynamic * o.normal_force_n * (1.0 + 1e-3) + 1e-5
            );
        }
        work += (prev_f + o.friction).dot(x - prev_x) * 0.5;
        prev_f = o.friction;
        prev_x = x;
    }
    Ok(work)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Random smooth planar bumps (cubic Bézier, outward up), random loops at random depths.
    #[test]
    fn planar_friction_bounded_finite_and_dissipative(
        h1 in -0.01f32..0.015, h2 in -0.01f32..0.015,
        depth in 0.0005f32..0.004,
        wiggle in prop::collection::vec((-0.006f32..0.006, -0.006f32..0.006), 2..8),
        mu_s in 0.3f32..1.0, ratio in 0.3f32..1.0,
    ) {
        // Right to left so the normal points up.
        let c = construct::bezier_curve(&[
            Vec2::new(0.045, 0.08), Vec2::new(0.015, 0.08 + h1), Vec2::new(-0.015, 0.08 + h2), Vec2::new(-0.045, 0.08),
        ]).unwrap();
        let views = [c.view()];
        let chain = Chain::new(&views).unwrap();
        let (start, n) = (c.view().point(0.5), c.view().frame(0.5).normal);
        let t = Vec2::new(-n.y, n.x);
        let path = closed_path(start, n, &[t], depth, &wiggle);
        let material = FrictionMaterial { mu_static: mu_s, mu_dynamic: mu_s * ratio, ..FrictionMaterial::default() };
        let work = check_run(&chain, &path, material)?;
        // Dissipation: never positive beyond f32 rounding of the sum (forces ≲ 10 N, steps 50 µm).
        prop_assert!(work <= 1e-6, "friction did {work} J of positive work");
    }

    /// Random smooth bicubic bumps, random loops in both tangent directions.
    #[test]
    fn spatial_friction_bounded_finite_and_dissipative(
        heights in prop::collection::vec(-0.008f32..0.012, 4),
        depth in 0.0005f32..0.004,
        wiggle in prop::collection::vec((-0.006f32..0.006, -0.006f32..0.006), 2..6),
    ) {
        let xs = [-0.04f32, -0.0133, 0.0133, 0.04];
        let ys = [0.06f32, 0.08, 0.10, 0.12];
        let rows: Vec<Vec<Vec3>> = (0..4)
            .map(|i| (0..4).map(|j| {
                let inner = (1..3).contains(&i) && (1..3).contains(&j);
                let z = if inner { heights[(i - 1) * 2 + (j - 1)] } else { 0.0 };
                Vec3::new(xs[i], ys[j], z)
            }).collect())
            .collect();
        let s = construct::bezier_patch(&rows).unwrap();
        let views = [s.view()];
        let shell = Shell::new(&views).unwrap();
        let n = s.view().normal(0.5, 0.5);
        let start = s.view().point(0.5, 0.5);
        let t1 = n.any_orthonormal_vector();
        let t2 = n.cross(t1);
        let path = closed_path(start, n, &[t1, t2], depth, &wiggle);
        let work = check_run(&shell, &path, FrictionMaterial::default())?;
        prop_assert!(work <= 1e-6, "friction did {work} J of positive work");
    }

    /// Chains with a sharp vertex, convex (a roof) or concave (a valley) of random angle,
    /// loops pressed in near the vertex so that the GO crosses it: bounded, finite, and
    /// friction does no net positive work, corners included.
    #[test]
    fn friction_is_dissipative_across_sharp_vertices(
        h in prop::sample::select(vec![-0.015f32, -0.008, -0.003, 0.003, 0.008, 0.015]),
        x0 in -0.008f32..0.008,
        depth in 0.0005f32..0.003,
        wiggle in prop::collection::vec((-0.006f32..0.006, -0.006f32..0.006), 2..8),
    ) {
        // Right to left so the normals point up; the vertex at x = 0 is h above the ends.
        let a = construct::line(Vec2::new(0.04, 0.08), Vec2::new(0.0, 0.08 + h)).unwrap();
        let b = construct::line(Vec2::new(0.0, 0.08 + h), Vec2::new(-0.04, 0.08)).unwrap();
        let views = [a.view(), b.view()];
        let chain = Chain::new(&views).unwrap();
        let (c, u) = if x0 >= 0.0 { (&a, 1.0 - x0 / 0.04) } else { (&b, -x0 / 0.04) };
        let (start, n) = (c.view().point(u), c.view().frame(u).normal);
        let t = Vec2::new(-n.y, n.x);
        let path = closed_path(start, n, &[t], depth, &wiggle);
        let work = check_run(&chain, &path, FrictionMaterial::default())?;
        prop_assert!(work <= 1e-6, "friction did {work} J of positive work");
    }

    /// Shells of two bilinear patches meeting at an edge x = 0 of random dihedral angle, a
    /// ridge or a valley, loops across the edge in both tangent directions.
    #[test]
    fn friction_is_dissipative_across_shell_edges(
        slope in prop::sample::select(vec![-0.4f32, -0.2, 0.2, 0.4]),
        x0 in -0.008f32..0.008,
        depth in 0.0005f32..0.003,
        wiggle in prop::collection::vec((-0.006f32..0.006, -0.006f32..0.006), 2..6),
    ) {
        // z = slope·|x|·(−1): a ridge for slope > 0; u along x, v along y, S_u × S_v = +z.
        let z = |x: f32| -slope * x.abs();
        let patch = |x0: f32, x1: f32| {
            construct::bezier_patch(&[
                vec![Vec3::new(x0, 0.06, z(x0)), Vec3::new(x0, 0.12, z(x0))],
                vec![Vec3::new(x1, 0.06, z(x1)), Vec3::new(x1, 0.12, z(x1))],
            ])
            .unwrap()
        };
        let (left, right) = (patch(-0.04, 0.0), patch(0.0, 0.04));
        let views = [left.view(), right.view()];
        let shell = Shell::new(&views).unwrap();
        let s = if x0 < 0.0 { &left } else { &right };
        let u = if x0 < 0.0 { 1.0 + x0 / 0.04 } else { x0 / 0.04 };
        let n = s.view().normal(u, 0.5);
        let start = s.view().point(u, 0.5);
        let t1 = Vec3::new(1.0, 0.0, 0.0);
        let t1 = (t1 - n * t1.dot(n)).normalize();
        let t2 = n.cross(t1);
        let path = closed_path(start, n, &[t1, t2], depth, &wiggle);
        let work = check_run(&shell, &path, FrictionMaterial::default())?;
        prop_assert!(work <= 1e-6, "friction did {work} J of positive work");
    }
}
