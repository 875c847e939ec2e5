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
    let mut r = FrictionRenderer::new(&chain, FrictionMaterial::default(), path[0]);
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

/// While slipping, pressing deeper (and holding) stops the GO's slide: the renderer sticks
/// again, and the friction force carries over continuously (the GO stays where its spring
/// already carries it).
#[test]
fn slip_to_stuck_keeps_the_friction_force() {
    let mut p = press_and_slide();
    let last = *p.last().unwrap();
    let deeper = last - Vec2::new(0.0, 0.002);
    p.extend(lerp(last, deeper, 100));
    // The slip speed, lagged by τ/3 = 20 ms, takes ln(30/0.5)·τ/3 ≈ 82 ms to fall below the
    // stop speed.
    p.extend(std::iter::repeat_n(deeper, 300));
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
    // Reversed once the HIP has come back a tenth of μ_d × 2 mm (4 ticks of 27 µm).
    let k_rev = 400;
    assert_eq!(r.out[k_rev - 1].mode, Mode::Slip);
    assert_eq!(r.out[k_rev + 4].mode, Mode::Stuck);
    assert_eq!(r.out[k_rev + 4].cause, SwitchCause::Reversed);
    // Force continuity through the whole run: per tick, at most K times the HIP step plus the
    // Stribeck decay (μ falls by at most (μ_s − μ_d)·T/τ·max m' per tick, τ = 60 ms, m′ = 1).
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

// ---- Every edge of the state machine (Fig. 3.1.2), each driven by its own trigger ----------

use friction::SwitchCause;

/// The material's defaults these tests rely on: frictional memory τ, the Stribeck speed.
const TAU: f32 = 0.06;
const V_S: f32 = 0.01;

/// Indices where the mode changed, with the new mode and the cause reported.
fn switches(r: &Run) -> Vec<(usize, Mode, SwitchCause)> {
    (1..r.out.len())
        .filter(|&k| r.out[k].mode != r.out[k - 1].mode)
        .map(|k| (k, r.out[k].mode, r.out[k].cause))
        .collect()
}

/// The edges of a press and a steady slide, in order, and nothing else.
const PRESS_AND_SLIDE: [(Mode, SwitchCause); 3] = [
    (Mode::Stuck, SwitchCause::Contact),
    (Mode::Transition, SwitchCause::Breakaway),
    (Mode::Slip, SwitchCause::Converged),
];

/// The new modes and causes of `switches`.
fn edges(switches: &[(usize, Mode, SwitchCause)]) -> Vec<(Mode, SwitchCause)> {
    switches.iter().map(|w| (w.1, w.2)).collect()
}

/// Press to `depth` at x = 0, then slide along +x at `speed` for `ticks`.
fn press_then_slide(depth: f32, speed: f32, ticks: usize) -> Vec<Vec2> {
    let y = 0.08 - depth;
    let mut p: Vec<Vec2> = lerp(Vec2::new(0.0, 0.085), Vec2::new(0.0, y), 100).collect();
    p.extend((0..ticks).map(|k| Vec2::new(speed * T * k as f32, y)));
    p
}

/// Ticks of the transition for a contact sliding at `v` at `depth`, from the closed form: it
/// runs at `min(1, v/v_s)/τ` per second and ends once `(μ − μ_d)·depth ≤ converge_tol`, with
/// μ − μ_d = (μ_s − μ_d)(1 − progress) on the linear shape. The breakaway tick runs the first
/// step, and the edge is taken on the tick after the progress gets there.
fn transition_ticks(v: f32, depth: f32) -> usize {
    let tol = 1e-5;
    let needed = 1.0 - tol / (0.2 * depth);
    let per_tick = (T / TAU) * (v / V_S).min(1.0);
    (needed / per_tick).ceil() as usize
}

#[test]
fn contact_breakaway_converged_in_order_and_nothing_else() {
    // 30 mm/s, above the Stribeck speed: the transition takes τ.
    let r = run(&press_then_slide(0.002, 0.03, 300));
    let s = switches(&r);
    assert_eq!(edges(&s), PRESS_AND_SLIDE);
    // Contact where the HIP crosses y = 0.08: 5/7 of the 100-tick press.
    assert_eq!(s[0].0, 72);
    // Breakaway at K Δx > μ_s K depth: Δx = 1.4 mm at 30 µm per tick, the 47th tick of the
    // slide (100 + 47, x = 1.41 mm; at x = 1.38 mm it still holds).
    assert_eq!(s[1].0, 147);
    // τ/T = 60 ticks, less the last 2.5 % that converge_tol (10 µm of 0.4 mm) spares.
    assert_eq!(s[2].0 - s[1].0, transition_ticks(0.03, 0.002));
    assert_eq!(transition_ticks(0.03, 0.002), 59);
}

#[test]
fn slip_sticks_when_the_hand_stops_for_cause_stopped() {
    let mut p = press_then_slide(0.002, 0.03, 300);
    let last = *p.last().unwrap();
    p.extend(std::iter::repeat_n(last, 400));
    let r = run(&p);
    let s = switches(&r);
    let &(k, mode, cause) = s.last().unwrap();
    assert_eq!((mode, cause), (Mode::Stuck, SwitchCause::Stopped));
    // A stop is read from the GO's own motion: the last slide is on the last tick the hand
    // moves (tick 399, the path's 400th point); ticks 400–404 are the 5 ms hold without a
    // slide, and tick 405 sticks. No tick more than 5 ms after a slide is labelled slip.
    let last_slide = (1..k)
        .rev()
        .find(|&j| r.out[j].go != r.out[j - 1].go)
        .unwrap();
    assert_eq!((last_slide, k), (399, 405));
    // The friction force carries over: μ_d F_N = 1 N against the motion, unchanged.
    assert!((r.out[k].friction - Vec2::new(-1.0, 0.0)).length() < 1e-3);
    assert!((r.out.last().unwrap().friction - Vec2::new(-1.0, 0.0)).length() < 1e-3);
}

#[test]
fn slip_sticks_when_the_hand_reverses_for_cause_reversed() {
    let mut p = press_then_slide(0.002, 0.03, 300);
    let last = *p.last().unwrap();
    p.extend((1..=50).map(|k| last - Vec2::new(0.03 * T * k as f32, 0.0)));
    let r = run(&p);
    let s = switches(&r);
    let &(k, mode, cause) = s.last().unwrap();
    assert_eq!((mode, cause), (Mode::Stuck, SwitchCause::Reversed));
    // Reversed once the spring has relaxed a tenth below μ_d F_N: the HIP came back by
    // 0.1 × μ_d × 2 mm = 0.1 mm, the 4th tick at 30 µm per tick (tick 399 is the last forward).
    assert!((402..=404).contains(&k), "reversed at tick {k}");
    // Stuck from there: nothing else fires until breakaway the other way, which needs the HIP
    // to move the spring from 0.9 N one way to 1.4 N the other, 2.3 mm: beyond these 50 ticks.
    assert_eq!(s.len(), 4, "{s:?}");
}

#[test]
fn a_sudden_normal_force_jump_sticks_for_cause_normal_force_jump() {
    // Slide at 1 mm depth, then in one tick go 1 mm deeper while sliding on: F_N doubles,
    // μ_d F_N[k] = 1.0 N > μ_s F_N[k−1] = 0.7 N.
    let mut p = press_then_slide(0.001, 0.03, 300);
    let last = *p.last().unwrap();
    p.extend((1..=20).map(|k| last + Vec2::new(0.03 * T * k as f32, -0.001)));
    let r = run(&p);
    let s = switches(&r);
    let &(k, mode, cause) = s.last().unwrap();
    assert_eq!(
        (k, mode, cause),
        (400, Mode::Stuck, SwitchCause::NormalForceJump)
    );
    // The friction force is continuous across the switch (the GO stays where it was): it
    // changes only by K times the tangential step, 30 µm.
    let df = (r.out[400].friction - r.out[399].friction).length();
    assert!(df <= K * 3e-5 + 1e-4, "{df}");
}

#[test]
fn leaving_the_object_is_cause_released() {
    let mut p = press_then_slide(0.002, 0.03, 300);
    let last = *p.last().unwrap();
    p.extend(lerp(last, last + Vec2::new(0.0, 0.005), 50));
    let r = run(&p);
    let &(k, mode, cause) = switches(&r).last().unwrap();
    assert_eq!((mode, cause), (Mode::Free, SwitchCause::Released));
    // Out where the HIP crosses y = 0.08: 2/5 of the 50-tick pull, 20 ticks in.
    assert_eq!(k, 420);
}

/// The stuck self-transition of Fig. 3.1.2 (reset the GO to the CP when the CP stops or
/// reverses while stuck) is deliberately absent: the thesis's own Fig. 3.2.2 keeps the friction
/// force "still" while stuck and pressing along the normal (4 → 5, 10 → 11), which the reset
/// would drop to zero in one tick. Here: stuck with 1 N of friction, the HIP presses straight
/// in for 100 ticks (the CP stands still) and the friction stays exactly where it was.
#[test]
fn stuck_keeps_its_friction_when_the_cp_stops() {
    let mut p = press_then_slide(0.002, 0.03, 34); // 1 mm of slide: stuck at 1 N
    let last = *p.last().unwrap();
    p.extend(lerp(last, last - Vec2::new(0.0, 0.001), 100));
    let r = run(&p);
    assert!(r.out[100..].iter().all(|o| o.mode == Mode::Stuck));
    let held = r.out[133].friction;
    assert!((held.x + 0.99).abs() < 0.01, "{held:?}");
    for o in &r.out[134..] {
        assert!((o.friction - held).length() < 1e-4);
    }
}

/// §3.1.1, Fig. 3.1.1(b): the transition from μ_s to μ_d runs faster the faster the hand,
/// `τ · max(1, v_s/v)`: at 1, 2, 5 and 8 mm/s it lasts τ v_s / v (strictly shorter the faster),
/// at and above v_s = 10 mm/s it lasts τ, and μ never rises on the way. Then every speed slips
/// at exactly μ_d: the steady friction does not depend on the speed, nor on how the slide was
/// reached (slowing from 30 to 3 mm/s slips at μ_d as a 3 mm/s slide from rest does).
#[test]
fn stribeck_faster_slides_lose_static_friction_sooner() {
    let speeds = [0.001f32, 0.002, 0.005, 0.008, 0.01, 0.02, 0.04];
    let mut lengths = Vec::new();
    for &v in &speeds {
        // Breakaway after 1.4 mm of slide, the transition, then 200 ms of slip.
        let ticks = (0.0015 / (v * T)) as usize + transition_ticks(v, 0.002) + 200;
        let r = run(&press_then_slide(0.002, v, ticks));
        let s = switches(&r);
        assert_eq!(edges(&s), PRESS_AND_SLIDE, "v = {v}");
        let len = s[2].0 - s[1].0;
        // One tick of slack: the f32 sum of up to 200 progress steps of 0.005 can fall short of
        // the end by an ulp.
        let n = transition_ticks(v, 0.002);
        assert!(
            (n..=n + 1).contains(&len),
            "v = {v}: {len} ticks, closed form {n}"
        );
        lengths.push(len);
        for w in r.out[s[1].0..s[2].0].windows(2) {
            assert!(w[1].mu <= w[0].mu, "v = {v}: μ rose in the transition");
        }
        // Slip: μ_d F_N = 1 N against the motion, every tick.
        for o in &r.out[s[2].0..] {
            assert!(
                (o.friction - Vec2::new(-1.0, 0.0)).length() < 1e-3,
                "v = {v}"
            );
        }
    }
    for (i, w) in lengths.windows(2).enumerate() {
        if speeds[i + 1] <= V_S {
            assert!(w[1] < w[0], "{speeds:?}: {lengths:?}");
        } else {
            assert_eq!(w[1], w[0], "{speeds:?}: {lengths:?}");
        }
    }
    // The path does not matter: 30 mm/s slowed to 3 mm/s slips at μ_d as from rest.
    let mut p = press_then_slide(0.002, 0.03, 300);
    let last = *p.last().unwrap();
    p.extend((1..=1000).map(|k| last + Vec2::new(0.003 * T * k as f32, 0.0)));
    let r = run(&p);
    assert_eq!(r.out.last().unwrap().mode, Mode::Slip);
    assert!((r.out.last().unwrap().friction - Vec2::new(-1.0, 0.0)).length() < 1e-3);
}
