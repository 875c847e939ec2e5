//! Where features meet (issue 29): the force is continuous across a convex vertex's bisector
//! and a C⁰ knot while the hand stays within both faces' reach, for μ = 0 too; no closed loop
//! of the hand around a valley's vertex gains energy (the loop the issue measured, and a
//! hill-climbing search for others); the damping keeps the force in the friction cone; and a
//! slide on a small convex arc breaks away once, then slips at μ_d.
//!
//! Work is the trapezoid rule on the total force, as in `passivity.rs`; its slack is the same
//! (½ K h per metre the GO travels, ½ |ΔF| h per jump), derived there.
#![allow(clippy::unwrap_used)]

mod common;

use common::{Run, T, run, segment, with_mu as material};
use friction::{FrictionMaterial, Mode, SwitchCause};
use nurbs::{CurveBuf, Vec2, construct};
use tracker::Chain;

const K: f32 = 1000.0;

/// Through `pts` in order, in steps of at most `h`, starting at `pts[0]`.
fn polyline(pts: &[Vec2], h: f32) -> Vec<Vec2> {
    let mut path = vec![pts[0]];
    for w in pts.windows(2) {
        path.extend(segment(w[0], w[1], h));
    }
    path
}

/// The trapezoid rule's slack for a run with HIP step `h` (see `passivity.rs`).
fn slack(r: &Run<Vec2>, h: f32) -> f64 {
    0.5 * f64::from(K * h) * r.go_travel_m + 2.0 * r.max_jump_n * f64::from(h) + 1e-8
}

/// Two straight 40 mm faces meeting at `apex`, the outside above: a roof whose outward normals
/// are `theta_deg` apart (`valley = false`), or a valley whose faces rise at `theta_deg / 2`
/// on either side. Returns the two curves (right face first, traced towards the apex, so the
/// normals point out) and their outward normals.
fn two_faces(apex: Vec2, theta_deg: f32, valley: bool) -> ([CurveBuf<Vec2>; 2], [Vec2; 2]) {
    let half = (theta_deg / 2.0).to_radians();
    let down = if valley { 1.0 } else { -1.0 };
    let right = apex + Vec2::new(half.cos(), down * half.sin()) * 0.04;
    let left = apex + Vec2::new(-half.cos(), down * half.sin()) * 0.04;
    let a = construct::line(right, apex).unwrap();
    let b = construct::line(apex, left).unwrap();
    let t_a = (apex - right).normalize();
    let t_b = (left - apex).normalize();
    ([a, b], [Vec2::new(t_a.y, -t_a.x), Vec2::new(t_b.y, -t_b.x)])
}

/// A face's reach: whether `x` is under it and its foot on the face falls on the face.
type Reach = Box<dyn Fn(Vec2) -> bool>;

/// A corner to cross: its name, its two faces, the angle between their normals at the corner
/// (degrees) and their reaches.
type Shape = (String, [CurveBuf<Vec2>; 2], f32, [Reach; 2]);

/// The reach of the segment `a`–`b` with outward normal `n`.
fn segment_reach(a: Vec2, b: Vec2, n: Vec2) -> Reach {
    Box::new(move |x: Vec2| {
        let t = b - a;
        let along = (x - a).dot(t) / t.length_squared();
        (0.0..=1.0).contains(&along) && (x - a).dot(n) < 0.0
    })
}

/// The reach of the arc about `centre` of radius `r` from `from_rad` to `to_rad` (a convex
/// arc: its foot is along the ray from the centre).
fn arc_reach(centre: Vec2, r: f32, from_rad: f32, to_rad: f32) -> Reach {
    Box::new(move |x: Vec2| {
        let d = x - centre;
        let phi = d.y.atan2(d.x);
        d.length() < r && (from_rad..=to_rad).contains(&phi)
    })
}

/// The largest force step over the ticks where the HIP is in contact and within both faces'
/// reach (this tick and the last), against the bound `3 K |ΔHIP| + 0.25 N`: the spring's
/// own change is `K |ΔHIP|`, and the rest is what a tracker step and a slide may add.
fn worst_step_within_reach(r: &Run<Vec2>, path: &[Vec2], faces: &[Reach]) -> (f32, f32, usize) {
    let (mut worst, mut worst_excess, mut counted) = (0.0f32, f32::NEG_INFINITY, 0);
    for k in 1..path.len() {
        let (o, p) = (&r.out[k], &r.out[k - 1]);
        let both = |x: Vec2| faces.iter().all(|reach| reach(x));
        if o.mode == Mode::Free || p.mode == Mode::Free || !both(path[k]) || !both(path[k - 1]) {
            continue;
        }
        counted += 1;
        let step = (o.total - p.total).length();
        let bound = 3.0 * K * (path[k] - path[k - 1]).length() + 0.25;
        worst = worst.max(step);
        worst_excess = worst_excess.max(step - bound);
    }
    (worst, worst_excess, counted)
}

/// Crossing a convex vertex's bisector pressed 1, 2 and 4 mm in, on roofs whose normals are
/// 60°, 90° and 120° apart and on thesis-2d's two arcs, with μ = 0 and μ = 0.5: the force
/// changes per tick by at most `3 K |ΔHIP| + 0.25 N` while the HIP is within both faces'
/// reach. (The single-spring renderer jumped by `2 sin(θ/2) K d`: 4.0–6.9 N at 4 mm.)
#[test]
fn the_force_is_continuous_across_a_convex_vertex() {
    let apex = Vec2::new(0.0, 0.09);
    let mut shapes: Vec<Shape> = Vec::new();
    for theta in [60.0f32, 90.0, 120.0] {
        let (c, n) = two_faces(apex, theta, false);
        let ends = [c[0].view().point(0.0), c[1].view().point(1.0)];
        let reach = [
            segment_reach(ends[0], apex, n[0]),
            segment_reach(apex, ends[1], n[1]),
        ];
        shapes.push((format!("roof {theta}°"), c, theta, reach));
    }
    // thesis-2d (Fig. 3.2.1): 60° arcs of radius 40 mm about (∓20, 60) mm meeting at
    // (0, 94.64) mm, their normals 60° apart there.
    let r_arc = 0.04f32;
    let arc1 = construct::arc(
        Vec2::new(-0.02, 0.06),
        Vec2::new(r_arc, 0.0),
        Vec2::new(0.0, r_arc),
        0.0,
        60f32.to_radians(),
    )
    .unwrap();
    let arc2 = construct::arc(
        Vec2::new(0.02, 0.06),
        Vec2::new(r_arc, 0.0),
        Vec2::new(0.0, r_arc),
        120f32.to_radians(),
        60f32.to_radians(),
    )
    .unwrap();
    let reach = [
        arc_reach(Vec2::new(-0.02, 0.06), r_arc, 0.0, 60f32.to_radians()),
        arc_reach(
            Vec2::new(0.02, 0.06),
            r_arc,
            120f32.to_radians(),
            180f32.to_radians(),
        ),
    ];
    shapes.push(("thesis-2d".into(), [arc1, arc2], 60.0, reach));
    for (label, curves, theta, faces) in &shapes {
        let views = [curves[0].view(), curves[1].view()];
        let chain = Chain::new(&views).unwrap();
        let top = chain.vertices()[1].position;
        let half = (theta / 2.0).to_radians();
        let n_right = Vec2::new(half.sin(), half.cos());
        let n_left = Vec2::new(-half.sin(), half.cos());
        for depth in [0.001f32, 0.002, 0.004] {
            // Across the bisector at `depth` under both faces' tangent lines, from a point
            // where the right face is the nearer to its mirror image.
            let centre = top - Vec2::new(0.0, depth / half.cos());
            let w = 0.5 * depth / half.sin();
            let (p1, p2) = (centre + Vec2::new(w, 0.0), centre - Vec2::new(w, 0.0));
            let h = 1e-5;
            let path = polyline(&[p1 + n_right * 0.003, p1, p2, p2 + n_left * 0.003], h);
            for mu in [0.0f32, 0.5] {
                let r = run(&chain, material(mu, mu), &path);
                let (worst, excess, counted) = worst_step_within_reach(&r, &path, faces);
                println!(
                    "{label}, {} mm, μ = {mu}: largest step within reach {worst:.4} N over {counted} ticks",
                    depth * 1e3
                );
                assert!(counted > 50, "{label}: the path stays within reach");
                assert!(
                    excess <= 0.0,
                    "{label}, {depth} m, μ {mu}: a step of {worst} N"
                );
            }
        }
    }
}

/// A C⁰ knot inside one curve (a degree-1 polyline through a convex corner, split at load
/// into two pieces) behaves as a vertex: continuous across its bisector.
#[test]
fn the_force_is_continuous_across_a_c0_knot() {
    let apex = Vec2::new(0.0, 0.09);
    let half = 45f32.to_radians();
    let right = apex + Vec2::new(half.cos(), -half.sin()) * 0.04;
    let left = apex + Vec2::new(-half.cos(), -half.sin()) * 0.04;
    let c = CurveBuf::from_cartesian(1, vec![0.0, 0.0, 0.5, 1.0, 1.0], &[right, apex, left], None)
        .unwrap();
    let views = [c.view()];
    let chain = Chain::new(&views).unwrap();
    assert_eq!(chain.curves().len(), 2, "split at the knot");
    let n_right = Vec2::new(half.sin(), half.cos());
    let n_left = Vec2::new(-half.sin(), half.cos());
    let faces = [
        segment_reach(right, apex, n_right),
        segment_reach(apex, left, n_left),
    ];
    let depth = 0.004;
    let centre = apex - Vec2::new(0.0, depth / half.cos());
    let w = 0.5 * depth / half.sin();
    let (p1, p2) = (centre + Vec2::new(w, 0.0), centre - Vec2::new(w, 0.0));
    let path = polyline(&[p1 + n_right * 0.003, p1, p2, p2 + n_left * 0.003], 1e-5);
    for mu in [0.0f32, 0.5] {
        let r = run(&chain, material(mu, mu), &path);
        let (worst, excess, counted) = worst_step_within_reach(&r, &path, &faces);
        println!("C⁰ knot, 4 mm, μ = {mu}: largest step {worst:.4} N over {counted} ticks");
        assert!(counted > 50 && excess <= 0.0, "μ {mu}: a step of {worst} N");
    }
}

/// The loop the issue measured around a 45° valley's vertex (two 40 mm faces rising at 45°),
/// μ_s = μ_d = 0.1: four corners given as (offset along the valley, depth under the vertex),
/// traced at 10 mm/s from and back to free space, 20 laps. The single-spring renderer gave
/// the hand +2,550 µJ over the 20 laps here (+128 µJ a lap; the issue measured +157); now the
/// loop takes energy out.
#[test]
fn the_valley_loop_that_pumped_now_dissipates() {
    let apex = Vec2::new(0.0, 0.08);
    let (curves, normals) = two_faces(apex, 90.0, true);
    let views = [curves[0].view(), curves[1].view()];
    let chain = Chain::new(&views).unwrap();
    let _ = normals;
    // Offsets along the valley (x) and depths under the vertex (−y).
    let corner = |off_mm: f32, depth_mm: f32| apex + Vec2::new(off_mm, -depth_mm) * 1e-3;
    let loop_pts = [
        corner(-0.39, 1.21),
        corner(4.81, 3.89),
        corner(1.94, 1.06),
        corner(0.30, 1.50),
    ];
    let outside = corner(2.0, -3.0);
    let mut pts = vec![outside];
    for _ in 0..20 {
        pts.extend_from_slice(&loop_pts);
    }
    pts.push(loop_pts[0]);
    pts.push(outside);
    let h = 1e-5; // 10 mm/s at 1 kHz
    let path = polyline(&pts, h);
    let r = run(&chain, material(0.1, 0.1), &path);
    let s = slack(&r, h);
    println!(
        "valley loop, 20 laps: {:+.3} µJ (slack {:.3} µJ), GO travel {:.2} mm",
        r.work_j * 1e6,
        s * 1e6,
        r.go_travel_m * 1e3
    );
    assert!(r.work_j <= s, "{} µJ of work on the hand", r.work_j * 1e6);
    assert!(
        r.out.iter().any(|o| o.mode == Mode::Slip),
        "the loop slides"
    );
}

/// A small deterministic generator (xorshift32) for the search: the test needs no seed from
/// outside and finds the same loops every run.
struct Rng(u32);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        (self.0 >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
    }
}

/// A hill-climbing search for closed loops that gain energy around a valley's vertex (faces
/// rising at 30°, 45° and 60°) and a roof's apex (normals 90° apart), at μ 0.05, 0.1 and 0.15 with μ_s ≥ μ_d: four corners
/// within 5 mm of the vertex and at least 0.5 mm inside, five laps entered from and left to
/// free space, each step a random move of the corners kept when the loop's net work on the
/// hand rises (6 restarts × 100 moves a case, three from the loop the issue found, scaled).
/// The best
/// loop found may not do
/// more work than the rule's slack.
#[test]
fn a_search_finds_no_loop_that_gains_energy_at_a_vertex() {
    let mut rng = Rng(0x2026_1207);
    let h = 2e-5;
    let mut best_overall = f64::NEG_INFINITY;
    // (The angle between the normals: twice a valley's faces' rise.)
    for (theta, valley) in [(60.0f32, true), (90.0, true), (120.0, true), (90.0, false)] {
        let apex = Vec2::new(0.0, 0.08);
        let (curves, _) = two_faces(apex, theta, valley);
        let views = [curves[0].view(), curves[1].view()];
        let chain = Chain::new(&views).unwrap();
        for (mu_s, mu_d) in [(0.05f32, 0.05f32), (0.1, 0.1), (0.15, 0.1)] {
            let m = material(mu_s, mu_d);
            let outside = apex + Vec2::new(0.002, 0.003);
            let evaluate = |c: &[Vec2; 4]| {
                let mut pts = vec![outside];
                for _ in 0..5 {
                    pts.extend_from_slice(c);
                }
                pts.push(c[0]);
                pts.push(outside);
                let path = polyline(&pts, h);
                let r = run(&chain, m, &path);
                (r.work_j - slack(&r, h), r.work_j)
            };
            // Every corner at least 0.5 mm inside (below both faces' lines at a roof, below
            // the nearer face at a valley) and within 5 mm of the vertex: a loop in free space
            // does no work and teaches the search nothing.
            let rise = if valley { 1.0 } else { -1.0 } * (90.0 - theta / 2.0).to_radians().tan();
            let inside = |c: Vec2| {
                let r = c - apex;
                let r = if r.length() > 0.005 {
                    r * (0.005 / r.length())
                } else {
                    r
                };
                let surface = rise * r.x.abs();
                let cos = (1.0 / (1.0 + rise * rise)).sqrt();
                apex + Vec2::new(r.x, r.y.min(surface - 0.0005 / cos))
            };
            // Six restarts of 100 moves each: from the pumping loop (offsets along the
            // valley and depths under the vertex, mm) at three scales, and from random loops
            // 0.5–4 mm under the vertex.
            let mut best = (f64::NEG_INFINITY, f64::NEG_INFINITY);
            let mut best_corners = [apex; 4];
            for restart in 0..6 {
                let mut corners: [Vec2; 4] = if restart < 3 {
                    let scale = [1.0f32, 0.6, 1.5][restart];
                    [(-0.39, 1.21), (4.81, 3.89), (1.94, 1.06), (0.30, 1.50)]
                        .map(|(x, d): (f32, f32)| inside(apex + Vec2::new(x, -d) * (scale * 1e-3)))
                } else {
                    core::array::from_fn(|_| {
                        inside(
                            apex + Vec2::new(0.004 * rng.next(), -0.00225 + 0.00175 * rng.next()),
                        )
                    })
                };
                let mut here = evaluate(&corners);
                for _ in 0..100 {
                    let mut trial = corners;
                    for c in trial.iter_mut() {
                        *c = inside(*c + Vec2::new(rng.next(), rng.next()) * 0.0003);
                    }
                    let score = evaluate(&trial);
                    if score.1 > here.1 {
                        here = score;
                        corners = trial;
                    }
                }
                if here.1 > best.1 {
                    best = here;
                    best_corners = corners;
                }
            }
            let corners = best_corners;
            println!(
                "{} {theta}°, μ {mu_s}/{mu_d}: best loop {:+.3} µJ over its slack ({:+.3} µJ of work)",
                if valley { "valley" } else { "roof" },
                best.0 * 1e6,
                best.1 * 1e6
            );
            best_overall = best_overall.max(best.0);
            assert!(
                best.0 <= 0.0,
                "a loop gains {} µJ beyond the slack: {corners:?}",
                best.0 * 1e6
            );
        }
    }
    assert!(best_overall.is_finite());
}

/// Damping inside the cone: sliding on a floor with B = 1 N·s/m, then withdrawing along the
/// normal at 45 mm/s. The damping lowers F_N; the friction follows it down (|F_T| ≤ μ F_N every
/// tick, to f32's 1e-5 N) and is zero where F_N is. (The single spring kept its tangential part:
/// F_T/F_N reached 1.3, and 8 mN at F_N = 0.)
#[test]
fn damping_keeps_the_force_in_the_cone() {
    let floor = construct::line(Vec2::new(0.05, 0.08), Vec2::new(-0.05, 0.08)).unwrap();
    let views = [floor.view()];
    let chain = Chain::new(&views).unwrap();
    for b in [0.5f32, 1.0] {
        let m = FrictionMaterial {
            damping_ns_per_m: b,
            ..material(0.7, 0.5)
        };
        // Press 2 mm, slide 5 mm at 30 mm/s, withdraw at 45 mm/s.
        let mut pts = vec![Vec2::new(0.0, 0.085), Vec2::new(0.0, 0.078)];
        let mut path = polyline(&pts, 1e-5);
        pts = vec![Vec2::new(0.0, 0.078), Vec2::new(0.005, 0.078)];
        path.extend(polyline(&pts, 3e-5).into_iter().skip(1));
        pts = vec![Vec2::new(0.005, 0.078), Vec2::new(0.005, 0.085)];
        path.extend(polyline(&pts, 4.5e-5).into_iter().skip(1));
        let r = run(&chain, m, &path);
        let mut worst = f32::NEG_INFINITY;
        for o in &r.out {
            let f_t = o.friction.length();
            let mu = if o.mode == Mode::Slip { 0.5 } else { 0.7 };
            worst = worst.max(f_t - mu * o.normal_force_n);
            assert!(o.total.dot(o.normal) >= -1e-5, "pulls: {o:?}");
        }
        println!("B = {b}: largest F_T − μ F_N {worst:.2e} N");
        assert!(worst <= 1e-5, "B {b}: F_T exceeds μ F_N by {worst} N");
    }
}

/// Start-up on small convex arcs (R = 5 and 10 mm), pressed 0.5–4 mm and slid along at 0.5–3
/// mm/s: one breakaway, then steady slip, and the friction on every tick the GO slides is at
/// least μ_d F_N (a slide puts the spring on the cone's edge; a premature breakaway once
/// dropped it to 0.45 F_N).
#[test]
fn a_slide_on_a_small_arc_breaks_away_once() {
    let (mu_s, mu_d) = (0.7f32, 0.5f32);
    for radius in [0.005f32, 0.01] {
        let centre = Vec2::new(0.0, 0.08);
        let circle = construct::circle(centre, radius).unwrap();
        let views = [circle.view()];
        let chain = Chain::new(&views).unwrap();
        for depth in [0.0005f32, 0.002, 0.004] {
            if depth > 0.5 * radius {
                continue;
            }
            for speed in [0.0005f32, 0.003] {
                // Down onto the top, then around the centre at radius R − d through 60°.
                let rr = radius - depth;
                let mut path = polyline(
                    &[
                        centre + Vec2::new(0.0, radius + 0.002),
                        centre + Vec2::new(0.0, rr),
                    ],
                    1e-5,
                );
                let arc_len = rr * 60f32.to_radians();
                let ticks = (arc_len / (speed * T)) as usize;
                for k in 1..=ticks {
                    let phi = 90f32.to_radians() - (k as f32 / ticks as f32) * 60f32.to_radians();
                    path.push(centre + Vec2::new(phi.cos(), phi.sin()) * rr);
                }
                let r = run(&chain, material(mu_s, mu_d), &path);
                let breakaways = r
                    .out
                    .windows(2)
                    .filter(|w| w[0].mode == Mode::Stuck && w[1].cause == SwitchCause::Breakaway)
                    .count();
                let mut lowest = f32::INFINITY;
                for w in r.out.windows(2) {
                    let o = &w[1];
                    if o.go != w[0].go && matches!(o.mode, Mode::Slip | Mode::Transition) {
                        lowest = lowest.min(o.friction.length() / o.normal_force_n);
                    }
                }
                println!(
                    "R {} mm, {} mm deep, {} mm/s: {breakaways} breakaway(s), lowest sliding F_T/F_N {lowest:.5}",
                    radius * 1e3,
                    depth * 1e3,
                    speed * 1e3
                );
                let modes: Vec<(usize, Mode, SwitchCause)> = r
                    .out
                    .windows(2)
                    .enumerate()
                    .filter(|(_, w)| w[0].mode != w[1].mode)
                    .map(|(k, w)| (k + 1, w[1].mode, w[1].cause))
                    .collect();
                assert_eq!(breakaways, 1, "R {radius}, d {depth}, v {speed}: {modes:?}");
                // f32: a slide puts the spring on the cone's edge to 1e-5 of μ.
                let tol = 1e-4;
                assert!(lowest >= mu_d * (1.0 - tol), "F_T/F_N fell to {lowest}");
            }
        }
    }
}
