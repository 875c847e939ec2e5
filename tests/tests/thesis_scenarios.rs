//! The thesis's friction scenarios (§3.2.1, §3.2.2) run through the whole pipeline (`sim`:
//! tracker, Voronoi feature FSM, stick–slip friction) on the scenes shipped in `scenes/`,
//! checked against the claims the thesis makes about them.
#![allow(clippy::unwrap_used)]

use friction::Mode;
use viewer::scene::Scene;
use viewer::sim::{Run, Tick, run};
use viewer::trajectory::Trajectory;

fn simulate(name: &str) -> Run {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/");
    let scene = Scene::load(format!("{dir}{name}.json")).unwrap();
    let traj = Trajectory::load(format!("{dir}{name}.csv")).unwrap();
    run(&scene, 0, &traj, 1000.0, |_, _| {}).unwrap()
}

fn mode_sequence(ticks: &[Tick]) -> Vec<Mode> {
    let mut seq: Vec<Mode> = Vec::new();
    for t in ticks {
        if seq.last() != Some(&t.mode) {
            seq.push(t.mode);
        }
    }
    seq
}

const K: f32 = 1000.0;
const MU_S: f32 = 0.7;
const MU_D: f32 = 0.5;
const TAU_S: f32 = 0.02;
const T: f32 = 1e-3;

/// Static friction: the friction force is the tangential part of the spring to the pinned GO,
/// never above μ_s F_N; dynamic friction after the transition is μ_d F_N.
fn check_friction_laws(r: &Run) {
    for (k, t) in r.ticks.iter().enumerate() {
        let ff = t.friction.length();
        match t.mode {
            Mode::Stuck => {
                let spring = (t.go - t.hip) * K;
                let tangential = spring - t.normal * spring.dot(t.normal);
                // The tick a breakaway is detected reports the clamped value, not the spring.
                if r.ticks.get(k + 1).is_none_or(|n| n.mode == Mode::Stuck) {
                    assert!(
                        (t.friction - tangential).length() < 1e-3,
                        "tick {k}: {:?} vs spring {tangential:?}",
                        t.friction
                    );
                }
                assert!(
                    ff <= MU_S * t.normal_force_n + 1e-4,
                    "tick {k}: {ff} > μ_s F_N"
                );
            }
            Mode::Slip => {
                // The GO trails the CP by μ_d·depth and follows its target half the way per tick,
                // so it lags one tick of motion (K·|ΔHIP|); on a curved patch the split of the
                // spring is corrected over a few ticks (κ·depth ≈ 0.05 for 2 mm on R = 40 mm),
                // so allow 3 %.
                let dx = k
                    .checked_sub(1)
                    .map_or(0.0, |p| (t.hip - r.ticks[p].hip).length());
                let tol = 0.03 * t.normal_force_n + 1.5 * K * dx + 2e-3;
                assert!(
                    (ff - MU_D * t.normal_force_n).abs() <= tol,
                    "tick {k}: slip friction {ff} vs μ_d F_N = {}",
                    MU_D * t.normal_force_n
                );
            }
            Mode::Transition => {
                assert!(ff <= t.mu * t.normal_force_n + 1e-4);
                assert!(t.mu <= MU_S + 1e-6 && t.mu >= MU_D - 1e-6);
            }
            Mode::Free => assert_eq!(t.force.length(), 0.0),
        }
    }
}

/// Force continuity. The rendered force is the spring K (GO − HIP) with its friction part
/// clamped at μ F_N, both continuous in GO and HIP, so per tick it changes by at most K times
/// how far the HIP and the GO moved, times (1 + μ_s) for the split into normal and friction
/// parts. The GO moves towards a target that follows the HIP (≤ 1.5 × its step, the factor
/// covering the CP's faster motion on a convex curve) and closes the rest of its gap to the CP
/// at the transition's rate T/τ; the gap is at most |GO − CP| + μ_s·depth. Returns the ticks
/// where the GO crossed a vertex onto another patch, which this bound does not cover: there the
/// normal flips by the corner's angle (see the corner test).
fn check_continuity(r: &Run) -> Vec<usize> {
    let mut crossings = Vec::new();
    for k in 1..r.ticks.len() {
        let (a, b) = (&r.ticks[k - 1], &r.ticks[k]);
        if a.mode != Mode::Free && b.mode != Mode::Free && a.go_patch != b.go_patch {
            crossings.push(k);
            continue;
        }
        let df = (b.force - a.force).length();
        let dx = (b.hip - a.hip).length();
        let gap = (a.go - a.cp).length().max((b.go - b.cp).length())
            + MU_S * a.depth_m.max(b.depth_m).max(0.0);
        let bound = K * (2.5 * dx + (T / TAU_S) * gap) * (1.0 + MU_S) + 2e-3;
        assert!(
            df <= bound,
            "tick {k} ({:?} → {:?}): |ΔF| = {df} N > {bound} N",
            a.mode,
            b.mode
        );
    }
    crossings
}

#[test]
fn thesis_2d_events_1_to_13() {
    let r = simulate("thesis-2d");
    use Mode::*;
    // Events of §3.2.1: press in (1: stuck), slide (2: breakaway, 2→3 transition, 3 slip),
    // press deeper (4: stuck), slide (6: breakaway, 7: slip), pull out along the normal (the CP
    // stops: stuck; the normal force falls until the spring exceeds μ_s F_N: transition; 9:
    // free), re-enter near the corner (10–11: stuck), slide across the Voronoi boundary
    // (still stuck), break away onto the second curve (12: transition, 13: slip), hold (stuck).
    assert_eq!(
        mode_sequence(&r.ticks),
        vec![
            Free, Stuck, Transition, Slip, Stuck, Transition, Slip, Stuck, Transition, Free, Stuck,
            Transition, Slip, Stuck
        ]
    );
    check_friction_laws(&r);
    let crossings = check_continuity(&r);
    // The GO crosses the vertex once, in the corner event.
    assert_eq!(crossings.len(), 1, "{crossings:?}");
}

/// Event 4: pressing deeper while slipping sticks again and the friction force carries on
/// (the thesis's force continuity at the slip → stuck switch).
#[test]
fn thesis_2d_slip_to_stuck_keeps_the_friction_force() {
    let r = simulate("thesis-2d");
    let k = (1..r.ticks.len())
        .find(|&k| r.ticks[k - 1].mode == Mode::Slip && r.ticks[k].mode == Mode::Stuck)
        .unwrap();
    let (a, b) = (&r.ticks[k - 1], &r.ticks[k]);
    assert!(
        (b.friction - a.friction).length() < 0.02,
        "{:?} → {:?}",
        a.friction,
        b.friction
    );
    assert!((a.friction.length() - MU_D * a.normal_force_n).abs() < 0.05);
}

/// §3.1.2, Fig. 3.2.1(k): near the corner the HIP crosses the Voronoi boundary between the
/// curves (the bisector x = 0 of this symmetric roof) while stuck; the active feature stays on
/// the first curve until breakaway, then the GO is released onto the second curve and slides
/// there over the vertex (its position is continuous).
#[test]
fn thesis_2d_static_friction_at_the_corner() {
    let r = simulate("thesis-2d");
    let last_free = r.ticks.iter().rposition(|t| t.mode == Mode::Free).unwrap();
    let corner = &r.ticks[last_free + 1..];
    let stuck_past_boundary = corner
        .iter()
        .filter(|t| t.mode == Mode::Stuck && t.hip.x < 0.0 && t.patch == Some(0))
        .count();
    assert!(
        stuck_past_boundary > 20,
        "stuck on curve 1 past the boundary for {stuck_past_boundary} ticks"
    );
    let breakaway = corner
        .iter()
        .position(|t| t.mode == Mode::Transition)
        .unwrap();
    assert!(
        corner[..breakaway].iter().all(|t| t.patch == Some(0)),
        "no switch before breakaway"
    );
    assert!(
        corner[breakaway..]
            .iter()
            .skip(2)
            .all(|t| t.patch == Some(1)),
        "on curve 2 after breakaway"
    );
    assert_eq!(corner.last().unwrap().go_patch, 1);
    // The GO slides over the vertex instead of jumping to the second curve's closest point
    // (3.4 mm away at breakaway): no step longer than half a millimetre (it waits at the vertex
    // for a few ticks while its target moves on, then takes half the gap), and the force falls
    // steeply but over many ticks, as in Fig. 3.2.2 (12 → 13), never by more than 1.5 N per tick.
    for w in corner.windows(2) {
        assert!(
            (w[1].go - w[0].go).length() < 5e-4,
            "GO jumped {:?} → {:?}",
            w[0].go,
            w[1].go
        );
        // Where the GO changes curve the normal used to split the spring flips by the corner's
        // angle: the force may then change by up to |F| · |n₁ − n₀| (1 + μ_s) on top of the
        // spring's own change. Elsewhere the general bound of `check_continuity` holds.
        if w[0].go_patch != w[1].go_patch {
            let flip = (w[1].normal - w[0].normal).length();
            let bound = w[0].force.length() * flip * (1.0 + MU_S) + K * 1e-3;
            assert!((w[1].force - w[0].force).length() <= bound);
        }
    }
    let f_break = corner[breakaway].force.length();
    let f_slip = corner
        .iter()
        .find(|t| t.mode == Mode::Slip)
        .unwrap()
        .force
        .length();
    assert!(
        f_slip < 0.6 * f_break,
        "the force falls from {f_break} N to {f_slip} N at the corner"
    );
}

#[test]
fn thesis_3d_stick_slip_along_v() {
    let r = simulate("thesis-3d");
    use Mode::*;
    // §3.2.2 (Fig. 3.2.7): press in (1→2), slide along v (stuck, breakaway at 3, transition,
    // slip until 4), press deeper (stuck at 5), slide again (breakaway at 7, 7→8 transition,
    // slip).
    assert_eq!(
        mode_sequence(&r.ticks),
        vec![Free, Stuck, Transition, Slip, Stuck, Transition, Slip]
    );
    check_friction_laws(&r);
    assert!(check_continuity(&r).is_empty());
    // u stays constant: the CP and GO stay on u = 0.5 (the trajectory keeps u fixed).
    for t in r.ticks.iter().filter(|t| t.mode != Mode::Free) {
        assert!(
            (t.cp_params[0] - 0.5).abs() < 1e-3,
            "cp u = {}",
            t.cp_params[0]
        );
        assert!(
            (t.go_params[0] - 0.5).abs() < 1e-3,
            "go u = {}",
            t.go_params[0]
        );
    }
}

/// The runner compares friction laws: the same path through every model the material can
/// name. Each runs without NaN, never exceeds μ_s F_N, and the Coulomb law gives exactly
/// μ_d F_N against the motion while the closest point slides.
#[test]
fn every_friction_model_runs_the_thesis_2d_path() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/");
    let text = std::fs::read_to_string(format!("{dir}thesis-2d.json")).unwrap();
    let traj = Trajectory::load(format!("{dir}thesis-2d.csv")).unwrap();
    for model in ["stick_slip", "coulomb_viscous", "karnopp", "dahl", "lugre"] {
        let edited = text.replacen(
            "\"mu_dynamic\": 0.5",
            &format!("\"mu_dynamic\": 0.5, \"model\": \"{model}\""),
            1,
        );
        let scene = Scene::from_json_str(&edited).unwrap();
        let r = run(&scene, 0, &traj, 1000.0, |_, _| {}).unwrap();
        for t in &r.ticks {
            assert!(t.force.is_finite() && t.friction.is_finite(), "{model}");
            assert!(
                t.friction.length() <= MU_S * t.normal_force_n + 1e-3,
                "{model}: {t:?}"
            );
        }
        if model == "coulomb_viscous" {
            let sliding: Vec<&Tick> = r
                .ticks
                .iter()
                .filter(|t| t.mode == Mode::Slip && t.normal_force_n > 0.5)
                .collect();
            assert!(sliding.len() > 100);
            for t in sliding {
                assert!((t.friction.length() - MU_D * t.normal_force_n).abs() < 1e-3);
            }
        }
    }
}
