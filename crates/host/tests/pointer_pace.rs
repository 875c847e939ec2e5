//! The pointer's hand at the UI's frame rate (issue 31, item 1): a drag the UI samples at a
//! few frames a second reaches the loop as targets with the time the pointer took
//! ([`LoopCommand::HandTarget`]'s `over_s`), and the hand glides between them at the
//! pointer's pace, so a steady drag along a frictional floor slips steadily, as the same drag
//! fed every tick does, where targets taken as fast as the hand goes made it stop and stick
//! at every frame.

use friction::Mode;
use host::backend::{LoopCommand, Steppable};
use host::planar::{HapticLoop, PlanarSession};
use host::tick::Tick;
use nurbs::Vec2;
use scene::Scene;

/// A floor at y = 100 mm from x = −30 to 30 mm (outward +y, the object below), K = 800 N/m,
/// μ_s = 0.6, μ_d = 0.4.
fn floor() -> Scene {
    Scene::from_json_str(
        r#"{"format": "scene/1", "objects": [{"name": "floor",
            "material": {"stiffness_n_per_m": 800.0, "damping_ns_per_m": 0.0,
                         "mu_static": 0.6, "mu_dynamic": 0.4},
            "patches": [
              {"degree": 1, "knots": [0, 0, 1, 1], "points": [[0.03, 0.10], [-0.03, 0.10]]}
            ]}]}"#,
    )
    .expect("the floor scene")
}

/// One step of the app's planar loop: 1 ms (ten device ticks at the board's 10 kHz).
const TICK_S: f64 = 1e-3;
/// The drag: from x = 20 mm to −20 mm at 20 mm/s, the hand's target 3 mm into the floor.
const FROM_X: f32 = 0.02;
const SPEED_M_PER_S: f32 = 0.02;
const DRAG_S: f64 = 2.0;
const DEPTH_Y: f32 = 0.097;

/// How the pointer reaches the loop during the drag.
#[derive(Clone, Copy, Debug)]
enum Pointer {
    /// Every tick (the reference: a hand on the handle).
    EveryTick,
    /// At `fps` frames a second, each target with the frame's interval.
    Paced(f64),
    /// At `fps` frames a second, each target as fast as the hand goes (the old way).
    Jumps(f64),
}

/// The drag's ticks after the press has settled, with the hand's target at each.
fn drag(pointer: Pointer) -> Vec<(Tick, Vec2)> {
    let session = PlanarSession::with_object(floor(), Some(0)).expect("session");
    let mut l = HapticLoop::new(session, Vec2::new(FROM_X, 0.105)).expect("loop");
    // Press in and settle (0.5 s).
    l.set_hand_target(Vec2::new(FROM_X, DEPTH_Y));
    for _ in 0..500 {
        l.step();
    }
    let ticks = (DRAG_S / TICK_S).round() as usize;
    let mut out = Vec::with_capacity(ticks);
    let mut frame_due = 0.0;
    for k in 0..ticks {
        let t = k as f64 * TICK_S;
        let pointer_at = Vec2::new(FROM_X - SPEED_M_PER_S * t as f32, DEPTH_Y);
        let command = |over_s: f32| LoopCommand::HandTarget {
            to: pointer_at.extend(0.0),
            over_s,
        };
        match pointer {
            Pointer::EveryTick => {
                l.apply(command(TICK_S as f32));
            }
            Pointer::Paced(fps) | Pointer::Jumps(fps) if t >= frame_due - 1e-9 => {
                let over_s = if matches!(pointer, Pointer::Paced(_)) {
                    (1.0 / fps) as f32
                } else {
                    0.0
                };
                l.apply(command(over_s));
                frame_due += 1.0 / fps;
            }
            _ => {}
        }
        let tick = l.step();
        out.push((tick, l.hand_target()));
    }
    out
}

/// The share of the drag's ticks stuck, from 0.5 s on (after the breakaway at the start).
fn stuck_share(ticks: &[(Tick, Vec2)]) -> f64 {
    let from = (0.5 / TICK_S) as usize;
    let stuck = ticks[from..]
        .iter()
        .filter(|(t, _)| t.mode == Mode::Stuck)
        .count();
    stuck as f64 / (ticks.len() - from) as f64
}

#[test]
fn a_drag_seen_at_four_frames_a_second_slips_as_a_drag_fed_every_tick() {
    let reference = drag(Pointer::EveryTick);
    let paced = drag(Pointer::Paced(4.0));
    let jumps = drag(Pointer::Jumps(4.0));
    let (r, p, j) = (
        stuck_share(&reference),
        stuck_share(&paced),
        stuck_share(&jumps),
    );
    eprintln!("stuck share: every tick {r:.4}, paced {p:.4}, jumps {j:.4}");

    // Paced, the hand's target moves at the pointer's 20 mm/s on every step after the first
    // frame, one frame (0.25 s) behind it: a stop would be a step of zero motion, a burst one
    // of 0.3 m/s × 1 ms = 300 µm against the pointer's 20 µm. The target is an f32 near
    // 20 mm (ulp 1.9e-9 m) moved 2,500 device ticks a frame, so it may arrive up to
    // 2,500 × ulp/2 = 2.3 µm early or late: 2.5 µm on the position, 15 % of one step at a
    // frame boundary.
    let step = f64::from(SPEED_M_PER_S) * TICK_S;
    let frame_s = 0.25;
    let first_frame = (frame_s / TICK_S) as usize + 1;
    for (k, w) in paced.windows(2).enumerate().skip(first_frame) {
        let moved = f64::from((w[1].1 - w[0].1).length());
        assert!(
            (moved - step).abs() < 0.15 * step,
            "the hand moved {moved:e} m in a step at {} s, the pointer {step:e} m",
            w[1].0.t_s
        );
        // `w[1]` is the hand after step k + 1, which it took k + 2 steps to reach from the
        // pointer's first position (a target applied before a step moves the hand in it).
        let behind = (k + 2) as f64 * TICK_S - frame_s;
        let expected = f64::from(FROM_X) - f64::from(SPEED_M_PER_S) * behind;
        assert!(
            (f64::from(w[1].1.x) - expected).abs() < 2.5e-6,
            "the hand at x = {} m, the pointer a frame earlier at {expected} m",
            w[1].1.x
        );
    }
    // What the hand feels: the reference slips all along once broken away; paced, the drag
    // may be stuck at most 1 % of the time more (a slip-to-stick at the start of a frame
    // would stick for the ~10 ms a 20 mm/s hand takes to load the 0.6-vs-0.4 friction margin
    // again: 4 frames a second × 1.5 s × 10 ms = 6 % of the window).
    assert!(
        p <= r + 0.01,
        "paced: stuck {p:.4} of the drag, every tick {r:.4}"
    );
    // The old way, each frame's target taken at 0.3 m/s, the hand stops for 14/15 of every
    // frame, and the handle sticks at each stop: the measure sees it.
    assert!(j > r + 0.5, "jumps: stuck {j:.4}, every tick {r:.4}");
}
