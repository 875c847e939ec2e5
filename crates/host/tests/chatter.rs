//! The renderer's modes through the simulated pantograph at the board's 10 kHz, where one
//! encoder count (19.6 µm at the handle) a tick is a 0.2 m/s velocity quantum (issue 29): no
//! mode change is undone within 5 ms, at light contact the mode does not flicker, and the
//! mode sequence is the one the same run gives at 1 kHz, up to timing.
//!
//! The hand is `viewer sim --device`'s relaxed grip (300 N/m, 2 N·s/m, `SimParams::default`).

use friction::{Mode, SwitchCause};
use host::closed_loop;
use host::sim::SimParams;
use host::tick::Tick;
use host::trajectory::Trajectory;
use scene::Scene;

/// A V opening upwards (the object below it), its faces rising at 26.6° from the vertex at
/// (0, 80) mm, K = 800 N/m, μ_s = 0.6, μ_d = 0.4: the concave corner the issue measured.
fn valley() -> Scene {
    Scene::from_json_str(
        r#"{"format": "scene/1", "objects": [{"name": "V",
            "material": {"stiffness_n_per_m": 800.0, "damping_ns_per_m": 0.0,
                         "mu_static": 0.6, "mu_dynamic": 0.4},
            "patches": [
              {"degree": 1, "knots": [0, 0, 1, 1], "points": [[0.04, 0.10], [0.0, 0.08]]},
              {"degree": 1, "knots": [0, 0, 1, 1], "points": [[0.0, 0.08], [-0.04, 0.10]]}
            ]}]}"#,
    )
    .expect("the V scene")
}

/// `t,x,y` rows through `(t, x, y)` corners, linear between them, every millisecond.
fn trajectory(corners: &[(f64, f64, f64)]) -> Trajectory {
    let mut csv = String::from("t,x,y\n");
    for w in corners.windows(2) {
        let ((t0, x0, y0), (t1, x1, y1)) = (w[0], w[1]);
        let n = ((t1 - t0) / 1e-3).round() as usize;
        for k in 0..n {
            let f = k as f64 / n as f64;
            csv.push_str(&format!(
                "{},{},{}\n",
                t0 + f * (t1 - t0),
                x0 + f * (x1 - x0),
                y0 + f * (y1 - y0)
            ));
        }
    }
    let (t, x, y) = corners[corners.len() - 1];
    csv.push_str(&format!("{t},{x},{y}\n"));
    Trajectory::parse(&csv, "chatter.csv").expect("a valid trajectory")
}

/// `(mode, cause, time)` of every stretch of one mode.
fn stretches(ticks: &[Tick]) -> Vec<(Mode, SwitchCause, f64)> {
    let mut seq: Vec<(Mode, SwitchCause, f64)> = Vec::new();
    for t in ticks {
        if seq.last().is_none_or(|s| s.0 != t.mode) {
            seq.push((t.mode, t.cause, t.t_s));
        }
    }
    seq
}

/// The mode changes undone within `window_s`: a switch away from a mode and back to it within
/// that time.
fn undone(seq: &[(Mode, SwitchCause, f64)], window_s: f64) -> Vec<String> {
    seq.windows(3)
        .filter(|w| w[0].0 == w[2].0 && w[2].2 - w[1].2 < window_s)
        .map(|w| {
            format!(
                "{:?} → {:?} ({:?}) → back after {:.2} ms at {:.4} s",
                w[0].0,
                w[1].0,
                w[1].1,
                (w[2].2 - w[1].2) * 1e3,
                w[1].2
            )
        })
        .collect()
}

/// The sequence of modes, each once per stretch.
fn modes(seq: &[(Mode, SwitchCause, f64)]) -> Vec<Mode> {
    seq.iter().map(|s| s.0).collect()
}

/// The sequence of modes held at least `min_s` each (shorter stretches dropped, equal
/// neighbours merged): the modes "up to timing", where one rate's run stops for a moment that
/// the other's does not.
fn lasting_modes(seq: &[(Mode, SwitchCause, f64)], min_s: f64) -> Vec<Mode> {
    let mut out: Vec<Mode> = Vec::new();
    for (k, s) in seq.iter().enumerate() {
        let lasted = seq.get(k + 1).map_or(f64::INFINITY, |n| n.2 - s.2);
        if lasted >= min_s && out.last() != Some(&s.0) {
            out.push(s.0);
        }
    }
    out
}

fn run(scene: &Scene, traj: &Trajectory, rate_hz: f64) -> Vec<Tick> {
    closed_loop::run_device(scene, 0, traj, rate_hz, SimParams::default(), |_, _| {})
        .expect("the run")
        .run
        .ticks
}

/// Crossing the V's vertex from one slope to the other pressed about 2 mm in, slowing to a
/// stop at the end of the traverse, then lifting off: no mode change undone within 5 ms at 10
/// kHz (the single-spring renderer had 21, stuck → transition → stuck within 0.1–0.4 ms, and
/// a free → stuck → free bounce at first contact), and the same modes as at 1 kHz.
#[test]
fn crossing_a_concave_corner_does_not_chatter_at_10_khz() {
    let scene = valley();
    // Over the right slope, pressed in, across the vertex to the left slope (about 2 mm under
    // the surface y = 0.08 + |x|/2 all the way), held, lifted.
    let depth = 0.0022;
    let traj = trajectory(&[
        (0.0, 0.02, 0.095),
        (0.3, 0.02, 0.09 - depth),
        (0.5, 0.02, 0.09 - depth),
        (1.3, 0.0, 0.08 - depth),
        (2.3, -0.018, 0.089 - depth),
        (2.6, -0.02, 0.09 - depth),
        (3.0, -0.02, 0.09 - depth),
        (3.3, -0.02, 0.095),
    ]);
    let fast = stretches(&run(&scene, &traj, 10_000.0));
    let slow = stretches(&run(&scene, &traj, 1000.0));
    println!(
        "10 kHz: {} mode changes: {:?}",
        fast.len() - 1,
        modes(&fast)
    );
    println!("1 kHz: {} mode changes: {:?}", slow.len() - 1, modes(&slow));
    let (fast_undone, slow_undone) = (undone(&fast, 5e-3), undone(&slow, 5e-3));
    assert!(fast_undone.is_empty(), "10 kHz: {fast_undone:#?}");
    assert!(slow_undone.is_empty(), "1 kHz: {slow_undone:#?}");
    assert_eq!(
        modes(&fast),
        modes(&slow),
        "the same modes at 10 kHz as at 1 kHz"
    );
    assert!(modes(&fast).contains(&Mode::Slip), "the traverse slides");
}

/// The thesis's own 2-D scenario through the device at 10 kHz: no mode change undone within
/// 5 ms, and the mode sequence of the 1 kHz run.
#[test]
fn thesis_2d_through_the_device_at_10_khz_keeps_its_modes() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/");
    let scene = Scene::load(format!("{dir}thesis-2d.json")).expect("scene");
    let traj = Trajectory::load(format!("{dir}thesis-2d.csv")).expect("trajectory");
    let fast = stretches(&run(&scene, &traj, 10_000.0));
    let slow = stretches(&run(&scene, &traj, 1000.0));
    println!("10 kHz: {:?}", modes(&fast));
    println!("1 kHz: {:?}", modes(&slow));
    let fast_undone = undone(&fast, 5e-3);
    assert!(fast_undone.is_empty(), "10 kHz: {fast_undone:#?}");
    assert_eq!(modes(&fast), modes(&slow));
}

/// Held at light contact (the hand's target 0.3 mm under the right slope, F_N about 0.2 N)
/// for 1.5 s at 10 kHz: the mode does not flicker (the single spring's logged mode flickered
/// at about 1 kHz at F_N ≤ 0.26 N).
#[test]
fn light_contact_does_not_flicker_at_10_khz() {
    let scene = valley();
    let traj = trajectory(&[
        (0.0, 0.02, 0.095),
        (0.3, 0.02, 0.09 - 0.0003),
        (1.8, 0.02, 0.09 - 0.0003),
    ]);
    let ticks = run(&scene, &traj, 10_000.0);
    let held: Vec<Tick> = ticks.into_iter().filter(|t| t.t_s >= 0.5).collect();
    let seq = stretches(&held);
    let f_n = held.iter().map(|t| t.normal_force_n).fold(0.0f32, f32::max);
    println!("light contact: largest F_N {f_n:.3} N, stretches {seq:?}");
    assert!(f_n > 0.0 && f_n < 0.3, "light contact: F_N up to {f_n} N");
    assert_eq!(seq.len(), 1, "one mode while held: {seq:?}");
}

/// Every planar object of every bundled scene (thesis-2d's roof, the cubic wave and circle of
/// `examples`, the taut string of `deformable` held rigid) pressed 2 mm in at the middle of
/// its first curve, slid 10 mm along it and lifted, through the device at 10 kHz: no mode
/// change undone within 5 ms, and the modes of the 1 kHz run up to timing (modes held 10 ms or
/// more: at 1 kHz the relaxed hand's handle can stall for 5 ms just after a breakaway on
/// thesis-2d's arc, which its 10 kHz run rides through).
#[test]
fn every_bundled_planar_object_keeps_its_modes_at_10_khz() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/");
    let mut tried = 0;
    for name in ["thesis-2d", "examples", "deformable"] {
        let scene = Scene::load(format!("{dir}{name}.json")).expect("scene");
        for (i, object) in scene.objects().iter().enumerate() {
            let Some(curves) = object.curve_views() else {
                continue;
            };
            let c = curves[0];
            let (a, b) = c.domain();
            let u = 0.5 * (a + b);
            let frame = c.frame(u);
            let (p, n, t) = (c.point(u), frame.normal, frame.tangent);
            let at = |v: nurbs::Vec2| (f64::from(v.x), f64::from(v.y));
            let corner = |s: f64, v: nurbs::Vec2| {
                let (x, y) = at(v);
                (s, x, y)
            };
            let traj = trajectory(&[
                corner(0.0, p + n * 0.005),
                corner(0.3, p - n * 0.002),
                corner(0.5, p - n * 0.002),
                corner(1.5, p - n * 0.002 + t * 0.01),
                corner(2.0, p - n * 0.002 + t * 0.01),
                corner(2.3, p + n * 0.005 + t * 0.01),
            ]);
            // Single-scene runs: an object the device refuses at a rate is no finding here.
            let single = Scene::new(vec![object.clone()]).expect("one object");
            let runs = [10_000.0, 1000.0].map(|rate| {
                closed_loop::run_device(&single, 0, &traj, rate, SimParams::default(), |_, _| {})
                    .map(|r| stretches(&r.run.ticks))
            });
            let [Ok(fast), Ok(slow)] = runs else {
                println!("{name} object {i}: refused by the device");
                continue;
            };
            println!("{name} object {i} ({}): {:?}", object.name(), modes(&fast));
            let fast_undone = undone(&fast, 5e-3);
            assert!(
                fast_undone.is_empty(),
                "{name} object {i}: {fast_undone:#?}"
            );
            assert_eq!(
                lasting_modes(&fast, 0.01),
                lasting_modes(&slow, 0.01),
                "{name} object {i}: {fast:?} {slow:?}"
            );
            tried += 1;
        }
    }
    assert!(tried >= 4, "{tried} planar objects run");
}
