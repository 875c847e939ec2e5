//! Passivity of the whole rendered force: over a closed path of the HIP the total force (normal
//! plus friction, not friction alone, which a stuck spring makes conservative by construction)
//! does no positive work, in every mode, across sharp vertices and shell edges, on curved
//! patches, in 2-D and 3-D; the force stays in the friction cone about the true normal, never
//! pulls in, and nothing is NaN; and with μ = 0 the force is the penalty wall `K·depth·n` at the
//! true closest point, computed here from the exact geometry.
//!
//! Work is integrated with the trapezoid rule, `Σ ½ (F_k + F_{k+1})·(x_{k+1} − x_k)`, which is
//! exact for a spring to a fixed point (so the zero-order hold's half-step lead does not count).
//! Two effects remain, each bounded below from the physics, never a fit to the code's output:
//! - where the force jumps (the penalty wall at the inner bisector of a convex vertex), the rule
//!   errs by at most `½ |ΔF| h` per crossing, `h` the HIP's step;
//! - a slide moves the GO by about the HIP's tangential step within the tick, which the rule
//!   counts as `½ K h · (GO's travel)` of work on the hand.
#![allow(clippy::unwrap_used)]

mod common;

use common::{run, segment, with_mu};
use friction::{FrictionMaterial, Mode};
use nurbs::{Point, Vec2, Vec3, construct};
use proptest::prelude::*;
use tracker::{Chain, Object, Shell};

const K: f32 = 1000.0;

/// Through the corners `pts` in order and back to the first, in steps of at most `h`, from
/// `start` (outside) in to the first corner and back out to `start`.
fn closed<P: Point>(start: P, pts: &[P], h: f32) -> Vec<P> {
    let mut path = vec![start];
    let mut at = start;
    for &p in pts.iter().chain(core::iter::once(&pts[0])) {
        path.extend(segment(at, p, h));
        at = p;
    }
    path.extend(segment(at, start, h));
    path
}

/// The wedge: two straight faces meeting at the apex (0, 0.09) with an interior angle of 106°,
/// the outside above. Returns the curves (right face first, traced right to left so that the
/// normals point out) and the faces' outward unit normals.
fn wedge() -> ([nurbs::CurveBuf<Vec2>; 2], [Vec2; 2]) {
    let half = 53f32.to_radians();
    let apex = Vec2::new(0.0, 0.09);
    // Down the faces, 40 mm each, at 53° from the vertical.
    let right = apex + Vec2::new(half.sin(), -half.cos()) * 0.04;
    let left = apex + Vec2::new(-half.sin(), -half.cos()) * 0.04;
    let a = construct::line(right, apex).unwrap();
    let b = construct::line(apex, left).unwrap();
    let n_right = Vec2::new(half.cos(), half.sin());
    let n_left = Vec2::new(-half.cos(), half.sin());
    ([a, b], [n_right, n_left])
}

/// The wedge's faces' exact penalty walls at `x` (f64): `K·d·n` of each face whose line `x`
/// lies under (`d` the depth below the face's line) and whose projection of `x` falls on the
/// face itself (within its reach), with how far inside the reach it projects.
fn wedge_walls(x: Vec2, normals: [Vec2; 2]) -> Vec<([f64; 2], f64)> {
    let apex = [0.0f64, 0.09];
    let rel = [f64::from(x.x) - apex[0], f64::from(x.y) - apex[1]];
    let k = f64::from(K);
    let mut walls = Vec::new();
    for n in normals {
        let (nx, ny) = (f64::from(n.x), f64::from(n.y));
        let d = -(rel[0] * nx + rel[1] * ny);
        // Along the face away from the apex: the normal turned towards the outside of the
        // other face (−n⊥ for the right face, whose normal has a positive x).
        let along = if nx > 0.0 { [ny, -nx] } else { [-ny, nx] };
        let reach = rel[0] * along[0] + rel[1] * along[1];
        if d > 0.0 && reach >= 0.0 {
            walls.push(([k * d * nx, k * d * ny], reach));
        }
    }
    walls
}

/// A square of side `side` centred at `centre`, clockwise or not.
fn square(centre: Vec2, side: f32, clockwise: bool) -> Vec<Vec2> {
    let h = side / 2.0;
    let mut c = vec![
        centre + Vec2::new(-h, -h),
        centre + Vec2::new(-h, h),
        centre + Vec2::new(h, h),
        centre + Vec2::new(h, -h),
    ];
    if !clockwise {
        c.reverse();
    }
    c
}

/// The HIP's step on the wedge's loops (m): fine enough that the trapezoid rule's error at the
/// bisector, ½ |ΔF| h per crossing, stays below a microjoule.
const WEDGE_STEP: f32 = 1e-6;

/// The wedge's closed loops: 1 mm and 6 mm squares about the bisector 3 mm under the apex and
/// a 6 mm one beside it, both ways round, each entered from 5 mm above the apex.
fn wedge_loops() -> Vec<(String, Vec<Vec2>)> {
    let mut loops = Vec::new();
    for (side, centre) in [
        (0.001f32, Vec2::new(0.0, 0.087)),
        (0.006, Vec2::new(0.0, 0.084)),
        (0.006, Vec2::new(0.003, 0.084)),
    ] {
        for clockwise in [true, false] {
            let path = closed(
                Vec2::new(0.0, 0.095),
                &square(centre, side, clockwise),
                WEDGE_STEP,
            );
            loops.push((format!("square {side} at {centre:?}, cw {clockwise}"), path));
        }
    }
    loops
}

/// The wedge with μ = 0 is the god-object's wall: every tick in contact the force is the exact
/// penalty wall `K·d·n` of one face that holds the HIP in its reach, the face the contact came
/// in on for as long as it does (across the bisector too: no kick there); the GO changes face
/// only when the HIP leaves its face's reach, and then the spring does not get longer (the
/// storage falls); around every loop the force does no positive work beyond the rule's error.
#[test]
fn frictionless_wedge_is_the_god_objects_wall_and_does_no_work() {
    let (curves, normals) = wedge();
    let views = [curves[0].view(), curves[1].view()];
    let chain = Chain::new(&views).unwrap();
    let h = WEDGE_STEP;
    let mut crossed = 0;
    for (label, path) in wedge_loops() {
        let r = run(&chain, with_mu(0.0, 0.0), &path);
        let mut face: Option<usize> = None;
        for (k, (o, &x)) in r.out.iter().zip(&path).enumerate() {
            if o.mode == Mode::Free {
                face = None;
                continue;
            }
            let walls = wedge_walls(x, normals);
            // Which face's wall the force is: the tracker's one Gauss–Newton step on a line is
            // exact, so the error is f32's: positions of 0.1 m carry 1e-8 m, K × that 1e-5 N
            // (2e-5 N for the two coordinates).
            let matched = walls.iter().position(|(e, _)| {
                let err = ((f64::from(o.total.x) - e[0]).powi(2)
                    + (f64::from(o.total.y) - e[1]).powi(2))
                .sqrt();
                err <= 2e-5 + 1e-3 * f64::from(o.total.length())
            });
            let Some(m) = matched else {
                // One tick of contact outside every face's reach is the GO following the HIP
                // off a face: the entry from free space lands where the HIP is.
                assert!(
                    walls.is_empty() || k == 0,
                    "{label}, {x:?}: {:?} is no face's wall {walls:?}",
                    o.total
                );
                continue;
            };
            let side = usize::from(walls[m].0[0] < 0.0);
            if let Some(prev) = face
                && prev != side
            {
                // The GO changed face: only where the HIP left the old face's reach, and with
                // the spring no longer than the tick before at this HIP.
                // (More than a step inside the reach: at the apex itself both faces hold it.)
                let still = walls
                    .iter()
                    .any(|(e, reach)| usize::from(e[0] < 0.0) == prev && *reach > f64::from(h));
                assert!(
                    !still,
                    "{label}, {x:?}: left face {prev} while in its reach"
                );
                let before = f64::from((r.out[k - 1].go - x).length());
                let after = f64::from((o.go - x).length());
                assert!(after <= before + 1e-8, "{label}: {before} -> {after}");
                crossed += 1;
            }
            face = Some(side);
        }
        // The rule errs by ½ |ΔF| h where the force jumps (a face change, at most 2 K d).
        let bound = r.max_jump_n * f64::from(h) + 1e-7;
        println!("μ = 0, {label}: {:+.3} µJ", r.work_j * 1e6);
        assert!(
            r.work_j <= bound,
            "{label}: {} µJ (bound {} µJ)",
            r.work_j * 1e6,
            bound * 1e6
        );
    }
    // The 6 mm squares reach past a face's end: the face changes are exercised.
    assert!(crossed > 0);
}

/// The wedge with the default friction, the same loops: the total force only takes energy out
/// (the bound is the rule's error alone), stays in the cone about the true normal and never
/// pulls the hand in ([`check_passive`]).
#[test]
fn wedge_with_friction_is_passive() {
    let (curves, _) = wedge();
    let views = [curves[0].view(), curves[1].view()];
    let chain = Chain::new(&views).unwrap();
    for (label, path) in wedge_loops() {
        let work = check_passive(&chain, FrictionMaterial::default(), &path, WEDGE_STEP).unwrap();
        println!("μ default, {label}: {:+.3} µJ", work * 1e6);
    }
}

/// A 6 mm square sliding on an exact circular arc (R = 30 mm, the rational quadratic circle),
/// pressed 2 mm in: friction dissipates at least μ_d F_N over the stretches where the GO slides
/// (the lower bound), and the whole force never returns energy (the upper).
#[test]
fn arc_loops_dissipate() {
    let centre = Vec2::new(0.0, 0.06);
    // Counter-clockwise from 30° to 150°: the outward normal points away from the centre.
    let arc = construct::arc(
        centre,
        Vec2::new(0.03, 0.0),
        Vec2::new(0.0, 0.03),
        30f32.to_radians(),
        120f32.to_radians(),
    )
    .unwrap();
    let views = [arc.view()];
    let chain = Chain::new(&views).unwrap();
    let h = 5e-6;
    let top = centre + Vec2::new(0.0, 0.03);
    for clockwise in [true, false] {
        let path = closed(
            top + Vec2::new(0.0, 0.005),
            &square(top - Vec2::new(0.0, 0.005), 0.006, clockwise),
            h,
        );
        let r = run(&chain, FrictionMaterial::default(), &path);
        let slack = 0.5 * f64::from(K * h) * r.go_travel_m;
        println!("arc R 30 mm, cw {clockwise}: {:+.3} µJ", r.work_j * 1e6);
        assert!(
            r.work_j <= slack,
            "cw {clockwise}: {} µJ (slack {} µJ)",
            r.work_j * 1e6,
            slack * 1e6
        );
        // The GO slides for most of each side; μ_d K × (the smallest depth on the loop,
        // 2 mm) × its travel is the least friction can take out, less the rule's ½ K h.
        let least = 0.5 * f64::from(K) * 0.002 * r.go_travel_m - slack;
        assert!(r.go_travel_m > 0.005, "GO travel {}", r.go_travel_m);
        assert!(
            -r.work_j >= 0.9 * least,
            "cw {clockwise}: dissipated {} mJ, at least {} mJ",
            -r.work_j * 1e3,
            least * 1e3
        );
    }
}

/// A closed HIP path: from 5 mm above `start` straight down to `depth`, a loop of random
/// wiggles around the press point in the surface's tangent directions (reversed for the other
/// orientation), and back up the same line, in steps of `h`.
fn wiggle_loop<P: Point>(
    start: P,
    normal: P,
    tangents: &[P],
    depth: f32,
    wiggle: &[(f32, f32)],
    reverse: bool,
    h: f32,
) -> Vec<P> {
    let pressed = start - normal * depth;
    let mut corners = Vec::new();
    let mut phase = 0.0f32;
    for &(a, b) in wiggle {
        phase += 1.0;
        let mut off = P::ZERO;
        for (i, &t) in tangents.iter().enumerate() {
            off += t * (a * (phase * (1.3 + i as f32)).sin() + b * (phase * 0.7).cos());
        }
        corners.push(pressed + off);
    }
    if reverse {
        corners.reverse();
    }
    corners.insert(0, pressed);
    closed(start + normal * 0.005, &corners, h)
}

/// The check shared by the wedge and the properties, per tick: nothing is NaN, the force stays
/// in the cone of μ_s about the true normal (μ_d F_N in slip) and never pulls in, and a slide
/// never lengthens the spring (the GO's move at this HIP, the mechanism of passivity); over the
/// whole path, the total work is at most the rule's error. Returns the work (J).
fn check_passive<O: Object>(
    object: &O,
    material: FrictionMaterial,
    path: &[O::P],
    h: f32,
) -> Result<f64, TestCaseError>
where
    O::P: Point,
{
    let r = run(object, material, path);
    for (k, o) in r.out.iter().enumerate() {
        prop_assert!(o.total.is_finite() && o.normal_force_n.is_finite());
        prop_assert!(o.total.dot(o.normal) >= -1e-5, "pulls in: {o:?}");
        let f_t = o.friction.length_squared().sqrt();
        // The renderer's cone test has a 1e-5 relative slack; the spring is a difference of
        // f32 positions under 0.25 m, each put within two ulps (3e-8 m) of where it is meant
        // to be: K × 3e-8 m of force, which is what counts at light contact.
        let mu = if o.mode == Mode::Slip {
            material.mu_dynamic
        } else {
            material.mu_static
        };
        // Where the contact goes over from one patch to the next, the trackers take the new
        // patch a tick late and stand a tick at its end (no tick evaluates two patches): for
        // those ticks the GO may lag the cone's edge by the HIP's last two steps, K |ΔHIP| a
        // step of friction.
        // (Every patch here has the domain [0, 1]: a tracker standing at a patch's end has a
        // parameter of 0 or 1.)
        let at_end = |q: [f32; 2]| q.iter().any(|&t| t <= 0.0 || t >= 1.0);
        let switching = at_end(o.go_params)
            || at_end(o.contact.params)
            || (k.saturating_sub(2)..k).any(|j| {
                let (a, b) = (&r.out[j], &r.out[j + 1]);
                a.contact.feature != b.contact.feature || a.go_patch != b.go_patch
            });
        let lag = if switching {
            let step = |j: usize| {
                (path[j] - path[j.saturating_sub(1)])
                    .length_squared()
                    .sqrt()
            };
            material.stiffness_n_per_m * (step(k) + step(k.saturating_sub(1)))
        } else {
            0.0
        };
        prop_assert!(
            f_t <= mu * o.normal_force_n * (1.0 + 1e-4) + material.stiffness_n_per_m * 3e-8 + lag,
            "outside the cone of {mu}: {o:?}"
        );
        if let Some(p) = k
            .checked_sub(1)
            .map(|j| &r.out[j])
            .filter(|p| p.mode != Mode::Free && o.mode != Mode::Free && p.go != o.go)
        {
            // The renderer lets a slide lengthen the spring by the rounding of an f32 point of
            // the surface, two ulps of coordinates below 0.25 m (2 × 1.5e-8 m), and the lengths
            // here are rounded once more (|v| ≤ 10 mm: 1e-9 m).
            let before = (p.go - path[k]).length_squared().sqrt();
            let after = (o.go - path[k]).length_squared().sqrt();
            prop_assert!(
                after <= before + 3.1e-8,
                "a slide lengthened the spring from {before} m to {after} m: {o:?}"
            );
        }
    }
    let slack = 0.5 * f64::from(material.stiffness_n_per_m * h) * r.go_travel_m
        + 2.0 * r.max_jump_n * f64::from(h)
        + 1e-8;
    prop_assert!(
        r.work_j <= slack,
        "the force did {} µJ of work (slack {} µJ)",
        r.work_j * 1e6,
        slack * 1e6
    );
    Ok(r.work_j)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    /// Chains with a sharp vertex, a roof or a valley of random angle, random friction
    /// (μ = 0 included), random loops pressed in near the vertex at random depths, both ways.
    #[test]
    fn total_force_is_passive_across_sharp_vertices(
        h in -0.02f32..0.02,
        x0 in -0.008f32..0.008,
        depth in 0.0005f32..0.005,
        wiggle in prop::collection::vec((-0.006f32..0.006, -0.006f32..0.006), 2..8),
        reverse: bool,
        mu_s in prop::sample::select(vec![0.0f32, 0.3, 0.7, 1.0]),
        ratio in 0.3f32..1.0,
    ) {
        let a = construct::line(Vec2::new(0.04, 0.08), Vec2::new(0.0, 0.08 + h)).unwrap();
        let b = construct::line(Vec2::new(0.0, 0.08 + h), Vec2::new(-0.04, 0.08)).unwrap();
        let views = [a.view(), b.view()];
        let chain = Chain::new(&views).unwrap();
        let (c, u) = if x0 >= 0.0 { (&a, 1.0 - x0 / 0.04) } else { (&b, -x0 / 0.04) };
        let (start, n) = (c.view().point(u), c.view().frame(u).normal);
        let t = Vec2::new(-n.y, n.x);
        let step = 1e-5;
        let path = wiggle_loop(start, n, &[t], depth, &wiggle, reverse, step);
        check_passive(&chain, with_mu(mu_s, mu_s * ratio), &path, step)?;
    }

    /// Random smooth planar bumps (cubic Bézier), convex and concave stretches.
    #[test]
    fn total_force_is_passive_on_curved_chains(
        h1 in -0.015f32..0.015, h2 in -0.015f32..0.015,
        depth in 0.0005f32..0.005,
        wiggle in prop::collection::vec((-0.006f32..0.006, -0.006f32..0.006), 2..8),
        reverse: bool,
        mu_s in prop::sample::select(vec![0.0f32, 0.3, 0.7, 1.0]),
    ) {
        let c = construct::bezier_curve(&[
            Vec2::new(0.045, 0.08), Vec2::new(0.015, 0.08 + h1), Vec2::new(-0.015, 0.08 + h2), Vec2::new(-0.045, 0.08),
        ]).unwrap();
        let views = [c.view()];
        let chain = Chain::new(&views).unwrap();
        let (start, n) = (c.view().point(0.5), c.view().frame(0.5).normal);
        let t = Vec2::new(-n.y, n.x);
        let step = 1e-5;
        let path = wiggle_loop(start, n, &[t], depth, &wiggle, reverse, step);
        check_passive(&chain, with_mu(mu_s, 0.7 * mu_s), &path, step)?;
    }

    /// Shells of two bilinear patches meeting at an edge of random dihedral angle, a ridge or a
    /// valley, loops across the edge in both tangent directions.
    #[test]
    fn total_force_is_passive_across_shell_edges(
        slope in prop::sample::select(vec![-0.6f32, -0.3, 0.3, 0.6]),
        x0 in -0.008f32..0.008,
        depth in 0.0005f32..0.004,
        wiggle in prop::collection::vec((-0.006f32..0.006, -0.006f32..0.006), 2..6),
        reverse: bool,
        mu_s in prop::sample::select(vec![0.0f32, 0.7]),
    ) {
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
        let step = 2e-5;
        let path = wiggle_loop(start, n, &[t1, t2], depth, &wiggle, reverse, step);
        check_passive(&shell, with_mu(mu_s, 0.7 * mu_s), &path, step)?;
    }

    /// Random smooth bicubic bumps, loops in both tangent directions.
    #[test]
    fn total_force_is_passive_on_curved_shells(
        heights in prop::collection::vec(-0.008f32..0.012, 4),
        depth in 0.0005f32..0.004,
        wiggle in prop::collection::vec((-0.006f32..0.006, -0.006f32..0.006), 2..6),
        reverse: bool,
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
        let step = 2e-5;
        let path = wiggle_loop(start, n, &[t1, t2], depth, &wiggle, reverse, step);
        check_passive(&shell, FrictionMaterial::default(), &path, step)?;
    }
}
