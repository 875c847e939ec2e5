//! Algorithm 1 on a flat floor, where every force has a closed form: K = 1000 N/m,
//! μ_s = 0.7, μ_d = 0.5, floor y = 0.08 m with the outside above it.
#![allow(clippy::unwrap_used)]

use friction::{FrictionMaterial, FrictionOutput, FrictionRenderer, Mode};
use nurbs::{CurveBuf, Vec2, construct};
use tracker::Chain;

const T: f32 = 1e-3;
const K: f32 = 1000.0;

fn floor() -> CurveBuf<Vec2> {
    // Right to left, so the normal t × k̂ points up (+y).
    construct::line(Vec2::new(0.05, 0.08), Vec2::new(-0.05, 0.08)).unwrap()
}

struct Run {
    out: Vec<FrictionOutput<Vec2>>,
    hips: Vec<Vec2>,
}

fn run(path: &[Vec2]) -> Run {
    let f = floor();
    let views = [f.view()];
    let chain = Chain::new(&views).unwrap();
    let mut r = FrictionRenderer::new(&chain, FrictionMaterial::default(), path[0], T);
    let mut prev = path[0];
    let out = path
        .iter()
        .map(|&x| {
            let o = r.tick(&chain, x, (x - prev) / T, T);
            prev = x;
            o
        })
        .collect();
    Run {
        out,
        hips: path.to_vec(),
    }
}

fn lerp(a: Vec2, b: Vec2, n: usize) -> impl Iterator<Item = Vec2> {
    (0..n).map(move |k| a + (b - a) * (k as f32 / n as f32))
}

/// Press 2 mm in, then slide along the floor at 30 mm/s.
fn press_and_slide() -> Vec<Vec2> {
    let mut p: Vec<Vec2> = lerp(Vec2::new(0.0, 0.085), Vec2::new(0.0, 0.078), 100).collect();
    p.extend(lerp(Vec2::new(0.0, 0.078), Vec2::new(0.009, 0.078), 300));
    p
}

#[test]
fn stuck_friction_is_the_spring_until_mu_s_fn_then_slip_at_mu_d_fn() {
    let r = run(&press_and_slide());
    let mut saw = [false; 4];
    for (o, x) in r.out.iter().zip(&r.hips) {
        let depth = (0.08 - x.y).max(0.0);
        match o.mode {
            Mode::Free => {
                saw[0] = true;
                assert_eq!(o.total, Vec2::ZERO);
            }
            Mode::Stuck => {
                saw[1] = true;
                // Closed form: the GO is pinned where contact began (x = 0), so the friction is
                // K times the tangential offset, and the normal force K times the depth.
                assert!(
                    (o.normal_force_n - K * depth).abs() < 1e-3,
                    "{} vs {}",
                    o.normal_force_n,
                    K * depth
                );
                assert!(
                    (o.friction.x - K * (0.0 - x.x)).abs() < 2e-3,
                    "{:?} at {x:?}",
                    o.friction
                );
                assert!(o.friction.length() <= 0.7 * o.normal_force_n + 1e-4);
            }
            Mode::Transition => {
                saw[2] = true;
                assert!(o.mu <= 0.7 + 1e-6 && o.mu >= 0.5 - 1e-6);
                // The GO follows its target half the way per tick, so the friction trails the
                // Stribeck curve by at most a tick's worth of μ's fall, and never exceeds it.
                assert!(o.friction.length() <= o.mu * o.normal_force_n + 1e-4);
                assert!(o.friction.length() >= 0.5 * o.normal_force_n - 1e-4);
            }
            Mode::Slip => {
                saw[3] = true;
                // Closed form: 0.5 × 1000 N/m × 2 mm = 1 N, against the motion (−x).
                assert!((o.normal_force_n - 2.0).abs() < 1e-3);
                assert!(
                    (o.friction - Vec2::new(-1.0, 0.0)).length() < 1e-3,
                    "{:?}",
                    o.friction
                );
            }
        }
    }
    assert_eq!(saw, [true; 4], "free, stuck, transition and slip all occur");
    // Breakaway happens where K·Δx first exceeds μ_s·K·depth: Δx = 0.7 × 2 mm = 1.4 mm.
    let first_transition = r
        .out
        .iter()
        .position(|o| o.mode == Mode::Transition)
        .unwrap();
    let x_break = r.hips[first_transition].x;
    assert!(
        (x_break - 0.0014).abs() <= 0.00003 + 1e-6,
        "breakaway at x = {x_break}"
    );
    // The mode sequence is exactly free → stuck → transition → slip.
    let mut seq: Vec<Mode> = Vec::new();
    for o in &r.out {
        if seq.last() != Some(&o.mode) {
            seq.push(o.mode);
        }
    }
    assert_eq!(
        seq,
        vec![Mode::Free, Mode::Stuck, Mode::Transition, Mode::Slip]
    );
}

/// While slipping, pressing deeper makes μ_d F_N[k] exceed μ_s F_N[k−1] or stops the CP: the
/// renderer sticks again, and the friction force carries over continuously (the GO is reset
/// where its spring reproduces the previous friction force).
#[test]
fn slip_to_stuck_keeps_the_friction_force() {
    let mut p = press_and_slide();
    let last = *p.last().unwrap();
    p.extend(lerp(last, last - Vec2::new(0.0, 0.002), 100));
    let r = run(&p);
    let switch = (1..r.out.len())
        .find(|&k| r.out[k - 1].mode == Mode::Slip && r.out[k].mode == Mode::Stuck)
        .unwrap();
    let before = r.out[switch - 1].friction;
    let after = r.out[switch].friction;
    assert!((before - Vec2::new(-1.0, 0.0)).length() < 1e-3);
    // The HIP moved 20 µm into the floor in that tick: the tangential force may change by at
    // most K × 20 µm × (tangential share, here 0) plus rounding.
    assert!((after - before).length() < 1e-3, "{before:?} → {after:?}");
    // Pressing on without tangential motion keeps the friction force while F_N grows.
    let end = r.out.last().unwrap();
    assert_eq!(end.mode, Mode::Stuck);
    assert!((end.friction - before).length() < 1e-3);
    let depth = 0.08 - r.hips.last().unwrap().y;
    assert!((end.normal_force_n - K * depth).abs() < 1e-3);
}

/// Reversing while slipping: stuck again with the same force, then the spring unloads and
/// reloads the other way until breakaway at μ_s F_N in the new direction.
#[test]
fn reversal_sticks_then_breaks_away_the_other_way() {
    let mut p = press_and_slide();
    let last = *p.last().unwrap();
    p.extend(lerp(last, last - Vec2::new(0.008, 0.0), 300));
    let r = run(&p);
    let k_rev = 400;
    assert_eq!(r.out[k_rev - 1].mode, Mode::Slip);
    assert_eq!(r.out[k_rev + 1].mode, Mode::Stuck);
    // Force continuity through the whole run: per tick, at most K times the HIP step plus the
    // Stribeck decay (μ falls by at most (μ_s − μ_d)·T/τ·max m' per tick, τ = 20 ms, m' = 1).
    for k in 1..r.out.len() {
        let df = (r.out[k].total - r.out[k - 1].total).length();
        let dx = (r.hips[k] - r.hips[k - 1]).length();
        let bound = K * dx * (1.0 + 0.7) + 0.2 * 2.0 * (T / 0.02) * 1.5 + 1e-3;
        assert!(
            df <= bound,
            "tick {k}: |ΔF| = {df} > {bound} ({:?} → {:?})",
            r.out[k - 1].mode,
            r.out[k].mode
        );
    }
    // Finally slipping the other way: friction +x at μ_d F_N.
    let end = r.out.last().unwrap();
    assert_eq!(end.mode, Mode::Slip);
    assert!((end.friction - Vec2::new(1.0, 0.0)).length() < 1e-3);
}
