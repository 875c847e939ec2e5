//! The haptic loop pushing a deformable object (`viewer sim --deform`): the bundled taut
//! string (L = 80 mm, T = 5 N, ρ = 0.1 kg/m, γ = 10 N·s/m², 12 control points) under a
//! prescribed HIP, against the series stiffness of contact and string, and what a hand feels:
//! no feature switch, no jump of the CP, no work done on the hand over a closed path, and the
//! string springs back.

use host::deform;
use host::sim::Trajectory;
use scene::{Bundled, Scene, Space};

fn deformable() -> Scene {
    Bundled::find("deformable")
        .and_then(|b| b.scene().ok())
        .expect("the bundled deformable scene")
}

/// The string's rest line.
const Y: f64 = 0.115;
/// The drum's centre (y; it lies in z = 0).
const DRUM_Y: f64 = 0.09;
const L: f64 = 0.08;
const T: f64 = 5.0;
/// The material's contact stiffness (N/m).
const K_C: f64 = 1000.0;

/// Press the string's middle `depth` past its rest line in 0.3 s, hold 0.7 s, go back out in
/// 0.3 s and wait 0.5 s: a closed path of the hand.
fn press(depth: f64) -> Trajectory {
    let free = Y - 0.01;
    let p = Y + depth;
    let samples = [(0.0, free), (0.3, p), (1.0, p), (1.3, free), (1.8, free)];
    Trajectory::from_samples(Space::Planar, samples.map(|(t, y)| (t, [0.0, y, 0.0])))
        .expect("valid trajectory")
}

/// The grip's target from 10 mm below the rest line to 6 mm past it in 0.3 s, then held until
/// `until_s`.
fn grip_press(until_s: f64) -> Trajectory {
    let samples = [(0.0, Y - 0.01), (0.3, Y + 0.006), (until_s, Y + 0.006)];
    Trajectory::from_samples(Space::Planar, samples.map(|(t, y)| (t, [0.0, y, 0.0])))
        .expect("valid trajectory")
}

/// The series stiffness's band (below) widened by the encoders' quantum over `depth` (19.6 µm
/// at the handle: what the controller sees of the depth), `0` on the host's exact HIP.
fn series_band(depth: f64, quantum_m: f64) -> (f64, f64) {
    let series = |k_o: f64| K_C * k_o / (K_C + k_o);
    let k_o = 4.0 * T / L;
    let h = L / 9.0;
    let q = quantum_m / depth;
    (
        series(k_o * (1.0 + 0.45 * h / L)) * (1.0 - q),
        series(k_o * (1.0 + 0.6 * h / L)) * (1.0 + q),
    )
}

/// Held at a depth `d` past the rest line, the contact spring `k_c` and the string's midpoint
/// stiffness `k_o` share the push in series: `F = d k_c k_o / (k_c + k_o)`. `k_o` is the
/// string's `4T/L` = 250 N/m stiffened by its discretisation by 0.45–0.6 of `h/L`
/// (`h = L/9`; crate `deform`'s test of the midpoint stiffness), so `F/d` lies in
/// [207.9, 210.5] N/m. The hold lasts 0.7 s, 35 decay times of the mass-proportional damping
/// (γ/2ρ = 50 s⁻¹): what is left of the transient is far below the band.
#[test]
fn pushed_string_gives_the_series_stiffness_of_contact_and_string() {
    let scene = deformable();
    let depth = 0.004;
    let run = deform::run(&scene, 0, &press(depth), 1000.0, |_, _| {}).expect("runs");
    let held = run
        .ticks
        .iter()
        .rfind(|k| k.t_s <= 1.0)
        .expect("a tick of the hold");
    let k = f64::from(held.normal_force_n) / depth;
    let (lo, hi) = series_band(depth, 0.0);
    assert!(
        (lo..=hi).contains(&k),
        "F/d = {k} N/m, series stiffness in [{lo}, {hi}] N/m"
    );
    // The string's own displacement at the CP is the rest of the depth: F = k_c (d − w).
    let w = f64::from(held.deform.expect("a deform run")[1]);
    let from_contact = depth - f64::from(held.normal_force_n) / K_C;
    assert!(
        (w - from_contact).abs() < 1e-3 * depth,
        "string moved {w} m, the contact says {from_contact} m"
    );
}

/// The CP tracker stays on the string's one patch while it moves, and the CP moves with the
/// HIP and the string, never by more: per tick the HIP's step (0.047 mm at the press's
/// 47 mm/s) plus the string's, which rides on the finger at the same speed while pressed: the
/// CP may move 0.1 mm, no more.
#[test]
fn tracker_follows_the_moving_string_without_jumping() {
    let scene = deformable();
    let run = deform::run(&scene, 0, &press(0.004), 1000.0, |_, _| {}).expect("runs");
    let mut worst: f32 = 0.0;
    for pair in run.ticks.windows(2) {
        assert!(
            matches!(pair[1].feature, tracker::Feature::Patch(0)),
            "feature {:?} at {} s",
            pair[1].feature,
            pair[1].t_s
        );
        worst = worst.max((pair[1].cp - pair[0].cp).length());
    }
    assert!(worst < 1e-4, "the CP jumped {worst} m in one tick");
}

/// Over the closed path (in, hold, out) the rendered force does no positive work on the hand
/// (trapezoid rule over the HIP's steps): the string's damping and the friction only take
/// energy. And it does take some: the press stores `½ F d` ≈ 1.6 mJ, of which the damping
/// keeps part; the bound below is what the integration of a passive exchange cannot exceed
/// in rounding (f32 forces of ~1 N over ~1e4 µm steps: 1e-9 J).
#[test]
fn closed_path_does_no_work_on_the_hand_and_the_string_springs_back() {
    let scene = deformable();
    let run = deform::run(&scene, 0, &press(0.004), 1000.0, |_, _| {}).expect("runs");
    let work: f64 = run
        .ticks
        .windows(2)
        .map(|p| {
            let f = (p[0].force + p[1].force) * 0.5;
            f64::from(f.dot(p[1].hip - p[0].hip))
        })
        .sum();
    assert!(work <= -1e-5, "the force did {work} J of work on the hand");
    let last = run.ticks.last().expect("ticks");
    assert_eq!(last.patch, None, "the hand let go");
    let w = last.deform.expect("a deform run").length();
    assert!(w < 1e-6, "the string is still {w} m from rest 0.5 s after");
}

/// Through the device: the simulated pantograph held by a relaxed grip (300 N/m) whose target
/// presses 6 mm past the string's rest line, at the board's 10 kHz, the controller moved onto
/// each new shape of the string every millisecond. Held, the force over the handle's own depth
/// past the rest line is the same series stiffness of contact and string ([207.9, 210.5] N/m,
/// above), give or take what the encoders' quantum does to the depth the controller sees
/// (19.6 µm at the handle over a ~3.5 mm depth: 0.6 %); the string took the rest of the depth.
/// No feature switch, no renderer restart (a restart would ramp the force in again from 0).
#[test]
fn device_loop_pushes_the_string_at_the_series_stiffness() {
    let scene = deformable();
    let run = deform::run_device(
        &scene,
        0,
        &grip_press(1.2),
        10_000.0,
        host::hand::Hand::Grip.params(),
        |_, _| {},
    )
    .expect("runs");
    let held = run.run.ticks.last().expect("ticks");
    let depth = f64::from(held.hip.y) - Y;
    let k = f64::from(held.normal_force_n) / depth;
    let (lo, hi) = series_band(depth, 19.6e-6);
    assert!(
        (lo..=hi).contains(&k),
        "F/d = {k} N/m at d = {depth} m, in [{lo}, {hi}]"
    );
    let contact: Vec<_> = run.run.ticks.iter().filter(|k| k.patch.is_some()).collect();
    assert!(
        contact
            .iter()
            .all(|k| matches!(k.feature, tracker::Feature::Patch(0)))
    );
    // Once the force is up it never falls back to a ramp's start.
    let peak = contact
        .iter()
        .position(|k| k.normal_force_n > 0.5)
        .expect("pressed");
    assert!(contact[peak..].iter().all(|k| k.normal_force_n > 0.4));
}

/// A device behind a link reports its CP as a position (telemetry carries the GO's
/// parameter, not the CP's); the host's `Deformer::locate_cp` finds its parameter on its copy
/// of the shape. Replayed over the device loop's own ticks (the same feeding and steps, so the same
/// shapes), the located CP parameter is the controller's tracker's to within 1e-3 in u
/// (0.08 mm along the string: the tracker converges to ~1e-5 m, the f32 positions of the frame
/// are exact to 1e-8 m).
#[test]
fn located_parameters_match_the_trackers() {
    let scene = deformable();
    let free = Y - 0.01;
    let p = Y + 0.006;
    let samples = [(0.0, free), (0.3, p), (0.6, p), (0.9, free)];
    let samples = samples.map(|(t, y)| (t, [0.002 * t, y, 0.0]));
    let trajectory = Trajectory::from_samples(Space::Planar, samples).expect("valid");
    let run = deform::run_device(
        &scene,
        0,
        &trajectory,
        10_000.0,
        host::hand::Hand::Grip.params(),
        |_, _| {},
    )
    .expect("runs");
    let mut deformer = deform::Deformer::new(&scene, 0).expect("deformable");
    let mut worst: f32 = 0.0;
    let mut located = 0;
    for (i, tick) in run.run.ticks.iter().enumerate() {
        if tick.patch.is_some() {
            let mut bare = *tick;
            bare.cp_params = [0.0; 2];
            deformer.locate_cp(&mut bare);
            worst = worst.max((bare.cp_params[0] - tick.cp_params[0]).abs());
            located += 1;
        }
        deformer.feed(tick);
        if (i + 1) % 10 == 0 {
            deformer.step(1e-3).expect("steps");
        }
    }
    assert!(located > 1000, "only {located} ticks in contact");
    assert!(worst < 1e-3, "located u off by {worst}");
}

/// Passivity over many closed paths of the hand: pressed 2, 4 or 8 mm past the rest line,
/// stroked 0, 10 or 25 mm along the string and back at 20 or 100 mm/s, let go; on the
/// string as bundled and undamped (γ = 0, where nothing but friction takes energy and a
/// coupling that made energy would show it). The rendered force never does positive work on
/// the hand (trapezoid rule over the HIP's 1 kHz steps; the bound is the f32 rounding of
/// ~1 N forces over the path, 1e-7 J).
#[test]
fn no_closed_path_does_positive_work() {
    let bundled = deformable();
    let undamped = undamped();
    for scene in [&bundled, &undamped] {
        for depth in [0.002, 0.004, 0.008] {
            for stroke in [0.0, 0.01, 0.025] {
                for speed in [0.02, 0.1] {
                    let trajectory = closed_path(depth, stroke, speed);
                    let run = deform::run(scene, 0, &trajectory, 1000.0, |_, _| {}).expect("runs");
                    let work = work_on_hand(&run.ticks);
                    assert!(
                        work <= 1e-7,
                        "depth {depth}, stroke {stroke}, speed {speed}: {work} J on the hand"
                    );
                }
            }
        }
    }
}

/// The same through the device (the simulated pantograph at 10 kHz, the controller reshaped
/// every millisecond) on the undamped string, held by a relaxed grip and by a light
/// fingertip whose target follows the path: the force after the safety layer does no positive
/// work on the handle's true path (which closes to within the hand's lag; the bound adds
/// what the residual force, < 1 mN at rest, could do over that gap).
///
/// And on the bundled string (γ = 10 N·s/m²) with the device rendering a shape 4 ms old, as
/// a device behind a link does (`run_device_lagged`: the update every 2 ms, the frame and the
/// link's latency). A lagging shape is a delayed spring, which gives energy; the string's
/// damping must take it. Measured on these paths: the bundled string stays passive up to
/// 4 ms of lag (one path gains 4 mJ at 8 ms), the undamped string up to 1 ms (up to 9 mJ at
/// 2 ms and 25 mJ at 4 ms).
#[test]
fn no_closed_path_through_the_device_does_positive_work() {
    for (scene, lag) in [(undamped(), 0), (deformable(), 4)] {
        for hand in [host::hand::Hand::Grip, host::hand::Hand::Finger] {
            for depth in [0.004, 0.008] {
                for speed in [0.02, 0.1] {
                    let trajectory = closed_path(depth, 0.025, speed);
                    let run = deform::run_device_lagged(
                        &scene,
                        0,
                        &trajectory,
                        10_000.0,
                        hand.params(),
                        lag,
                        |_, _| {},
                    )
                    .expect("runs");
                    let work = work_on_hand(&run.run.ticks);
                    assert!(
                        work <= 1e-6,
                        "lag {lag} ms, {hand:?}, depth {depth}, speed {speed}: {work} J on the hand"
                    );
                }
            }
        }
    }
}

/// A handle let go while it presses the undamped string: nothing holds it but the string and
/// the device's own friction and damping. The pair does not ring up. Passivity bounds the
/// force: at the release the springs in series hold `F₀²/2k_s` (k_s the series stiffness,
/// ≥ 207.9 N/m), and a later force F needs at least `F²/2k_c` in the contact spring alone, so
/// `F ≤ F₀ √(k_c/k_s)` = 2.19 F₀ whatever the handle does (measured: it never exceeds F₀, the
/// string throws the handle off). 0.3 s later the force is below the release's.
#[test]
fn released_handle_on_the_undamped_string_does_not_ring_up() {
    let scene = undamped();
    let trajectory = closed_path(0.006, 0.0, 0.05);
    let release_at_s = 0.35;
    let hand = host::hand::DeviceHand {
        params: host::hand::Hand::Released.params(),
        release_at_s: Some(release_at_s),
    };
    let run = deform::run_device(&scene, 0, &trajectory, 10_000.0, hand, |_, _| {}).expect("runs");
    let at_release = run
        .run
        .ticks
        .iter()
        .rfind(|k| k.t_s <= release_at_s)
        .map(|k| k.force.length())
        .expect("ticks");
    assert!(
        at_release > 0.3,
        "pressing with {at_release} N at the release"
    );
    let after = run.run.ticks.iter().filter(|k| k.t_s > release_at_s);
    let peak = after.clone().map(|k| k.force.length()).fold(0.0, f32::max);
    let bound = at_release * (K_C / 207.9).sqrt() as f32;
    assert!(
        peak <= bound,
        "{peak} N after, {at_release} N at the release"
    );
    let late = after
        .filter(|k| k.t_s > release_at_s + 0.3)
        .map(|k| k.force.length())
        .fold(0.0, f32::max);
    assert!(late < at_release, "still {late} N 0.3 s after");
}

/// The bundled scene with the string undamped (γ = 0).
fn undamped() -> Scene {
    let text = deformable().to_json_string().replacen(
        "\"damping_ns_per_m2\": 10.0",
        "\"damping_ns_per_m2\": 0.0",
        1,
    );
    let scene = Scene::from_json_str(&text).expect("valid");
    assert_eq!(scene.objects()[0].dynamics().map(|d| d.damping), Some(0.0));
    scene
}

/// In from 10 mm below the rest line to `depth` past it at the string's middle, hold 0.1 s,
/// stroke `stroke` along it and back, out, wait 0.2 s: at `speed`.
fn closed_path(depth: f64, stroke: f64, speed: f64) -> Trajectory {
    let free = Y - 0.01;
    let p = Y + depth;
    let t_in = (p - free) / speed;
    let t_stroke = (stroke / speed).max(1e-3);
    let samples = [
        (0.0, [0.0, free, 0.0]),
        (t_in, [0.0, p, 0.0]),
        (t_in + 0.1, [0.0, p, 0.0]),
        (t_in + 0.1 + t_stroke, [stroke, p, 0.0]),
        (t_in + 0.1 + 2.0 * t_stroke + 1e-3, [0.0, p, 0.0]),
        (2.0 * t_in + 0.1 + 2.0 * t_stroke + 2e-3, [0.0, free, 0.0]),
        (2.0 * t_in + 0.3 + 2.0 * t_stroke, [0.0, free, 0.0]),
    ];
    Trajectory::from_samples(Space::Planar, samples).expect("valid")
}

/// The work of the rendered force on the hand over its path (trapezoid rule).
fn work_on_hand(ticks: &[host::tick::Tick]) -> f64 {
    ticks
        .windows(2)
        .map(|p| {
            let f = (p[0].force + p[1].force) * 0.5;
            f64::from(f.dot(p[1].hip - p[0].hip))
        })
        .sum()
}

/// The drum skin (object 1: a 100 mm square, 50 N/m, 10 × 10 bicubic) pressed 3 mm at its
/// centre from above and let go, on the spatial path (`Shell`): the skin gives (a membrane
/// under a point load has no finite stiffness in the continuum, so the discrete one only
/// bounds it: the force lies below the rigid wall's K d = 3 N and the skin takes a
/// displacement), the tracker stays on its one patch, and the closed path does no positive
/// work on the hand.
#[test]
fn pressed_drum_gives_and_stays_passive() {
    let scene = deformable();
    let (above, pressed) = (0.01, -0.003);
    let samples = [
        (0.0, above),
        (0.3, pressed),
        (0.8, pressed),
        (1.1, above),
        (1.4, above),
    ];
    let trajectory =
        Trajectory::from_samples(Space::Spatial, samples.map(|(t, z)| (t, [0.0, DRUM_Y, z])))
            .expect("valid trajectory");
    let run = deform::run(&scene, 1, &trajectory, 1000.0, |_, _| {}).expect("runs");
    let held = run.ticks.iter().rfind(|k| k.t_s <= 0.8).expect("the hold");
    let w = -held.deform.expect("a deform run").z;
    let f = held.normal_force_n;
    // The contact's share: F = K (d − w) with d = 3 mm.
    assert!(w > 0.5e-3 && w < 3e-3, "the skin moved {w} m");
    assert!(
        (f - 1000.0 * (0.003 - w)).abs() < 0.01,
        "F = {f} N with the skin at {w} m"
    );
    assert!(
        run.ticks
            .iter()
            .filter(|k| k.patch.is_some())
            .all(|k| matches!(k.feature, tracker::Feature::Patch(0)))
    );
    let work = work_on_hand(&run.ticks);
    assert!(work <= 1e-7, "{work} J on the hand");
}

/// The same press with the device rendering a shape `lag` milliseconds old, as a device
/// behind a link does (its shape arrives as control-point updates): the object's side of the
/// contact is the spring at the device's own GO, so the lag moves what the hand feels and
/// never feeds the object a force of the lag itself (before, the object was loaded with the
/// rendered force minus the spring on its own newer shape, `k` times the shape's lag, and the
/// string pressed through 2 ms of lag bounced off the finger). Held, every tick of the last
/// 0.2 s is in the series stiffness's band (above): a string still ringing leaves it.
#[test]
fn device_behind_a_lagging_link_pushes_the_string_at_the_series_stiffness() {
    let scene = deformable();
    let trajectory = grip_press(1.5);
    for lag in [2, 8, 20] {
        let run = deform::run_device_lagged(
            &scene,
            0,
            &trajectory,
            10_000.0,
            host::hand::Hand::Grip.params(),
            lag,
            |_, _| {},
        )
        .expect("runs");
        let ticks = &run.run.ticks;
        let end = ticks.last().expect("ticks").t_s;
        let peak = ticks.iter().map(|k| k.normal_force_n).fold(0.0, f32::max);
        let (mut k_min, mut k_max) = (f64::MAX, f64::MIN);
        for held in ticks.iter().filter(|k| k.t_s >= end - 0.2) {
            let depth = f64::from(held.hip.y) - Y;
            let k = f64::from(held.normal_force_n) / depth;
            let (lo, hi) = series_band(depth, 19.6e-6);
            k_min = k_min.min(k);
            k_max = k_max.max(k);
            assert!(
                (lo..=hi).contains(&k),
                "lag {lag} ms: F/d = {k} N/m at d = {depth} m (t = {} s), in [{lo}, {hi}]",
                held.t_s
            );
        }
        eprintln!("lag {lag} ms: held F/d {k_min:.2}..{k_max:.2} N/m, peak force {peak:.3} N");
    }
}
