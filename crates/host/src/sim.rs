//! The host simulation behind `viewer sim`: a HIP that follows a prescribed trajectory, and the
//! whole haptic pipeline (closest-point tracking, the Voronoi feature state machine, friction)
//! run once per tick, as in the thesis's simulations (§3.2).
//!
//! Each tick `i` at `t = t₀ + i / rate`: the HIP is the trajectory interpolated at `t`, its
//! velocity the backward difference of the sampled HIP (zero at the first tick), and one
//! [`FrictionRenderer`] for the object turns them into a [`FrictionOutput`](friction::FrictionOutput), recorded as a
//! [`Tick`]. Planar trajectories drive a chain of planar curves ([`tracker::Chain`]), spatial
//! ones a shell of surfaces ([`tracker::Shell`]); [`Tick`] stores both as `Vec3` with `z = 0`
//! for planar runs.
//!
//! [`crate::closed_loop`] runs the same scenario through the simulated device instead
//! (`viewer sim --device`), holding its handle by one of the hands of [`crate::hand`].
//!
//! [`Run::write_csv`] writes the run log: one row per tick, columns [`csv_header`](crate::runlog::csv_header), followed
//! by [`DEVICE_COLUMNS`](crate::runlog::DEVICE_COLUMNS) for device runs.

use std::ops::ControlFlow;

pub use device::simulator::SimParams;
use friction::{FrictionMaterial, FrictionRenderer};
use tracker::{Chain, Object as TrackedObject, Shell};

pub use crate::error::MAX_TICKS;
use crate::error::{SimError, check_rate};
use crate::tick::{Tick, point, render_tick};
pub use crate::trajectory::{Trajectory, TrajectoryError, TrajectoryProblem};
use scene::{Scene, Space};

/// Default tick rate of `sim` (Hz).
pub const DEFAULT_RATE_HZ: f64 = 1000.0;

/// What a run's `progress(done, total)` returns: `()` to run on to the end, or a
/// [`ControlFlow`] whose `Break` ends the run after the tick just done (`viewer sim`
/// interrupted by Ctrl-C keeps the ticks run so far). The check is the caller's, between two
/// ticks, not inside one.
pub trait Proceed {
    /// Whether the run goes on.
    fn proceed(self) -> bool;
}

impl Proceed for () {
    fn proceed(self) -> bool {
        true
    }
}

impl Proceed for ControlFlow<()> {
    fn proceed(self) -> bool {
        self.is_continue()
    }
}

/// A whole simulation.
#[derive(Clone, Debug, PartialEq)]
pub struct Run {
    /// Planar or spatial.
    pub space: Space,
    /// Index of the object in the scene.
    pub object: usize,
    /// Its name.
    pub object_name: String,
    /// The material it was rendered with.
    pub material: FrictionMaterial,
    /// Tick rate (Hz).
    pub rate_hz: f64,
    /// One record per tick.
    pub ticks: Vec<Tick>,
}

/// Object `object` of `scene`, checked with the tick rate: what every run starts from.
fn rendered_object(scene: &Scene, object: usize, rate_hz: f64) -> Result<&scene::Object, SimError> {
    let o = scene.object(object).ok_or(SimError::ObjectIndex {
        index: object,
        count: scene.objects().len(),
    })?;
    check_rate(rate_hz)?;
    Ok(o)
}

/// Checks everything [`run`] checks before its first tick, without running it; returns the
/// number of ticks.
pub fn validate(
    scene: &Scene,
    object: usize,
    trajectory: &Trajectory,
    rate_hz: f64,
) -> Result<usize, SimError> {
    let o = rendered_object(scene, object, rate_hz)?;
    if o.space() != trajectory.space() {
        return Err(SimError::Space {
            trajectory: trajectory.space(),
            object: o.space(),
            index: object,
            name: o.name().to_owned(),
        });
    }
    let ticks = trajectory.tick_count(rate_hz);
    // Finite times and rate: never NaN.
    if ticks > MAX_TICKS as f64 {
        return Err(SimError::TooManyTicks {
            ticks,
            duration_s: trajectory.end_s() - trajectory.start_s(),
            rate_hz,
        });
    }
    if ticks < 2.0 {
        return Err(SimError::TooFewTicks {
            duration_s: trajectory.end_s() - trajectory.start_s(),
            rate_hz,
        });
    }
    Ok(ticks as usize)
}

/// Runs object `object` of `scene` with its material along `trajectory` at `rate_hz`.
/// `progress(done, total)` is called after every tick, and may end the run there
/// ([`Proceed`]).
pub fn run<P: Proceed>(
    scene: &Scene,
    object: usize,
    trajectory: &Trajectory,
    rate_hz: f64,
    progress: impl FnMut(usize, usize) -> P,
) -> Result<Run, SimError> {
    let n = validate(scene, object, trajectory, rate_hz)?;
    let o = &scene.objects()[object];
    let material = o.material().friction_material();
    let space_error = || SimError::Space {
        trajectory: trajectory.space(),
        object: o.space(),
        index: object,
        name: o.name().to_owned(),
    };
    let ticks = match trajectory.space() {
        Space::Planar => {
            let curves = o.curve_views().ok_or_else(space_error)?;
            let chain = Chain::new(&curves).map_err(|error| SimError::Chain {
                index: object,
                error,
            })?;
            simulate(
                &chain,
                material,
                rate_hz,
                n,
                prescribed(trajectory, rate_hz, n),
                progress,
            )
        }
        Space::Spatial => {
            let surfaces = o.surface_views().ok_or_else(space_error)?;
            let shell = Shell::new(&surfaces).map_err(|error| SimError::Shell {
                index: object,
                error,
            })?;
            simulate(
                &shell,
                material,
                rate_hz,
                n,
                prescribed(trajectory, rate_hz, n),
                progress,
            )
        }
    };
    Ok(Run {
        space: trajectory.space(),
        object,
        object_name: o.name().to_owned(),
        material,
        rate_hz,
        ticks,
    })
}

/// The HIP of tick `i` of `n` prescribed by `trajectory`: its time and position.
fn prescribed(
    trajectory: &Trajectory,
    rate_hz: f64,
    n: usize,
) -> impl FnMut(usize, Option<&Tick>) -> Option<(f64, [f64; 3])> {
    move |i, _| {
        (i < n).then(|| {
            let t_s = trajectory.tick_time_s(i, rate_hz);
            (t_s, trajectory.at(t_s))
        })
    }
}

/// The tick loop, once for chains and shells: `hip_at(i, last)` gives tick `i`'s time and
/// HIP from the previous tick's record (`None` at tick 0), or ends the run; the HIP velocity
/// is the backward difference of the HIPs (zero at the first tick). At most [`MAX_TICKS`].
fn simulate<O: TrackedObject, P: Proceed>(
    object: &O,
    material: FrictionMaterial,
    rate_hz: f64,
    expected: usize,
    mut hip_at: impl FnMut(usize, Option<&Tick>) -> Option<(f64, [f64; 3])>,
    mut progress: impl FnMut(usize, usize) -> P,
) -> Vec<Tick> {
    let period_s = (1.0 / rate_hz) as f32;
    let mut ticks: Vec<Tick> = Vec::with_capacity(expected);
    let Some((t0, start)) = hip_at(0, None) else {
        return ticks;
    };
    let mut renderer = FrictionRenderer::new(object, material, point::<O::P>(start));
    let (mut next, mut previous) = (Some((t0, start)), start);
    while let Some((t_s, xyz)) = next {
        let i = ticks.len();
        let velocity = if i == 0 {
            [0.0; 3]
        } else {
            [0, 1, 2].map(|k| (xyz[k] - previous[k]) * rate_hz)
        };
        previous = xyz;
        ticks.push(render_tick(
            &mut renderer,
            object,
            t_s,
            point::<O::P>(xyz),
            point::<O::P>(velocity),
            period_s,
        ));
        if !progress(ticks.len(), expected).proceed() {
            break;
        }
        next = if ticks.len() < MAX_TICKS {
            hip_at(ticks.len(), ticks.last())
        } else {
            None
        };
    }
    ticks
}

/// Runs object `object` of `scene` with its material under a hand that decides where to go
/// from what it felt: the HIP starts at `start` (tick 0, t = 0) and each later tick's HIP is
/// `hand(last)`, where `last` is the previous tick's record (its position, force, mode, …);
/// `None` ends the run, as does reaching `max_ticks` (at most [`MAX_TICKS`]). This is how a
/// simulated participant explores an object: pressing until it feels a force, following a
/// surface. The HIP velocity is the backward difference of the HIPs, as in [`run`].
pub fn explore(
    scene: &Scene,
    object: usize,
    start: [f64; 3],
    rate_hz: f64,
    max_ticks: usize,
    mut hand: impl FnMut(&Tick) -> Option<[f64; 3]>,
) -> Result<Run, SimError> {
    let o = rendered_object(scene, object, rate_hz)?;
    let max_ticks = max_ticks.min(MAX_TICKS);
    let material = o.material().friction_material();
    let mut hip_at = |i: usize, last: Option<&Tick>| -> Option<(f64, [f64; 3])> {
        match last {
            None => Some((0.0, start)),
            Some(_) if i >= max_ticks => None,
            Some(last) => hand(last).map(|p| (i as f64 / rate_hz, p)),
        }
    };
    let chain_error = |error| SimError::Chain {
        index: object,
        error,
    };
    let ticks = match o.space() {
        Space::Planar => {
            let curves = o.curve_views().unwrap_or_default();
            let chain = Chain::new(&curves).map_err(chain_error)?;
            simulate(&chain, material, rate_hz, 0, &mut hip_at, |_, _| {})
        }
        Space::Spatial => {
            let surfaces = o.surface_views().unwrap_or_default();
            let shell = Shell::new(&surfaces).map_err(|error| SimError::Shell {
                index: object,
                error,
            })?;
            simulate(&shell, material, rate_hz, 0, &mut hip_at, |_, _| {})
        }
    };
    Ok(Run {
        space: o.space(),
        object,
        object_name: o.name().to_owned(),
        material,
        rate_hz,
        ticks,
    })
}

/// The prescribed HIP of each tick: the trajectory at the tick's time, its velocity the
/// backward difference of the sampled HIP (zero at the first tick).
pub(crate) struct HipSamples<'a> {
    trajectory: &'a Trajectory,
    rate_hz: f64,
    previous: [f64; 3],
}

impl<'a> HipSamples<'a> {
    pub(crate) fn new(trajectory: &'a Trajectory, rate_hz: f64) -> Self {
        HipSamples {
            trajectory,
            rate_hz,
            previous: trajectory.at(trajectory.start_s()),
        }
    }

    /// Tick `i`'s time, HIP and HIP velocity (ticks in order).
    pub(crate) fn tick<P: nurbs::Point>(&mut self, i: usize) -> (f64, P, P) {
        let t_s = self.trajectory.tick_time_s(i, self.rate_hz);
        let xyz = self.trajectory.at(t_s);
        let velocity = if i == 0 {
            [0.0; 3]
        } else {
            [0, 1, 2].map(|k| (xyz[k] - self.previous[k]) * self.rate_hz)
        };
        self.previous = xyz;
        (t_s, point::<P>(xyz), point::<P>(velocity))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::runlog::csv_header;
    use friction::Mode;
    use nurbs::Vec3;

    /// Object 0, a flat floor: the line y = 0.08 drawn from x = 0.05 to −0.05, so that its
    /// outward normal `t × k̂` points up (+y). K = 1000 N/m, μ_s = 0.7, μ_d = 0.5, no damping.
    /// Object 1, the plane z = 0 over x ∈ [−0.03, 0.03], y ∈ [0.06, 0.12], normal +z;
    /// K = 500 N/m, μ_s = 0.4, μ_d = 0.3.
    fn floor_scene() -> Scene {
        Scene::from_json_str(
            r#"{ "format": "scene/1", "objects": [
              { "name": "floor",
                "material": { "stiffness_n_per_m": 1000, "damping_ns_per_m": 0,
                              "mu_static": 0.7, "mu_dynamic": 0.5 },
                "patches": [ { "degree": 1, "knots": [0, 0, 1, 1],
                               "points": [[0.05, 0.08], [-0.05, 0.08]] } ] },
              { "name": "bump",
                "material": { "stiffness_n_per_m": 500, "damping_ns_per_m": 0,
                              "mu_static": 0.4, "mu_dynamic": 0.3 },
                "patches": [ { "degree": [1, 1], "knots": [[0, 0, 1, 1], [0, 0, 1, 1]],
                               "points": [[[-0.03, 0.06, 0], [-0.03, 0.12, 0]],
                                          [[0.03, 0.06, 0], [0.03, 0.12, 0]]] } ] } ] }"#,
        )
        .unwrap_or_else(|e| panic!("{e}"))
    }

    /// Approach from above, press 2 mm in, hold, then slide 20 mm to the right.
    fn press_and_slide() -> Trajectory {
        Trajectory::from_samples(
            Space::Planar,
            [
                (0.0, [0.0, 0.085, 0.0]),
                (0.1, [0.0, 0.078, 0.0]),
                (0.2, [0.0, 0.078, 0.0]),
                (1.2, [0.02, 0.078, 0.0]),
            ],
        )
        .unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn header_columns() {
        assert_eq!(
            csv_header(Space::Planar),
            "t_s,hip_x,hip_y,cp_x,cp_y,go_x,go_y,patch,mode,cause,depth_m,normal_force_n,\
             friction_force_n,mu,psi,force_x,force_y"
        );
        assert_eq!(
            csv_header(Space::Spatial),
            "t_s,hip_x,hip_y,hip_z,cp_x,cp_y,cp_z,go_x,go_y,go_z,patch,mode,cause,depth_m,\
             normal_force_n,friction_force_n,mu,psi,force_x,force_y,force_z"
        );
    }

    #[test]
    fn press_in_and_slide_on_a_floor() {
        let scene = floor_scene();
        let mut calls = 0;
        let run = run(&scene, 0, &press_and_slide(), 1000.0, |done, total| {
            calls += 1;
            assert_eq!((done, total), (calls, 1201));
        })
        .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(run.ticks.len(), 1201);
        assert_eq!(calls, 1201);
        assert_eq!(run.space, Space::Planar);

        // The modes appear in the order of Algorithm 1, each once.
        let mut order: Vec<Mode> = Vec::new();
        for k in &run.ticks {
            if order.last() != Some(&k.mode) {
                order.push(k.mode);
            }
        }
        assert_eq!(
            order,
            [Mode::Free, Mode::Stuck, Mode::Transition, Mode::Slip],
            "mode sequence"
        );

        // Pressed 2 mm into a floor of K = 1000 N/m: F_N = 2 N along +y.
        let at = |t: f64| {
            run.ticks
                .iter()
                .find(|k| (k.t_s - t).abs() < 1e-9)
                .unwrap_or_else(|| panic!("a tick at {t}"))
        };
        let held = at(0.15);
        assert_eq!(held.mode, Mode::Stuck);
        assert_eq!(held.patch, Some(0));
        assert!((held.depth_m - 0.002).abs() < 1e-6, "{held:?}");
        assert!((held.normal_force_n - 2.0).abs() < 1e-3, "{held:?}");
        assert!(held.friction_force_n.abs() < 1e-3, "{held:?}");
        assert!((held.force - Vec3::new(0.0, 2.0, 0.0)).length() < 1e-3);

        // Free before contact: nothing.
        let free = at(0.0);
        assert_eq!((free.mode, free.patch), (Mode::Free, None));
        assert_eq!(free.force, Vec3::ZERO);

        // Stuck while sliding starts: the GO stays where contact began, the spring K·(GO −
        // HIP) carries the friction until |F_T| = μ_s F_N = 1.4 N, i.e. 1.4 mm of travel.
        let stuck: Vec<&Tick> = run
            .ticks
            .iter()
            .filter(|k| k.mode == Mode::Stuck && k.t_s > 0.2)
            .collect();
        let last_stuck = stuck.last().expect("stuck while sliding");
        assert!(
            (last_stuck.go.x - 0.0).abs() < 1e-6,
            "GO pinned at x = 0: {last_stuck:?}"
        );
        let travel = last_stuck.hip.x;
        assert!((travel - 0.0014).abs() < 3e-5, "breakaway after {travel} m");

        // Slip: F_N = K·2 mm = 2 N and the friction μ_d·F_N = 1 N against the motion (−x).
        let slips: Vec<&Tick> = run.ticks.iter().filter(|k| k.mode == Mode::Slip).collect();
        assert!(slips.len() > 500, "{} slip ticks", slips.len());
        // The first is the tick that ends the transition, with its μ slightly above μ_d.
        for k in &slips[1..] {
            assert!((k.normal_force_n - 2.0).abs() < 1e-3, "{k:?}");
            assert!((k.friction.x + 1.0).abs() < 1e-3, "{k:?}");
            assert!(k.friction.y.abs() < 1e-3, "{k:?}");
            assert!(
                (k.force - Vec3::new(-1.0, 2.0, 0.0)).length() < 2e-3,
                "{k:?}"
            );
            assert_eq!(k.mu, 0.5);
            // The GO is on the floor, at or behind the CP (Algorithm 1 has it at the CP; a
            // renderer may let it trail so that its spring carries the friction).
            assert!(
                (k.go.y - 0.08).abs() < 1e-6 && k.go.x <= k.cp.x + 1e-6,
                "{k:?}"
            );
            // The floor's parameter runs right to left: u = (0.05 − x) / 0.1.
            assert!((k.cp_param - (0.05 - k.hip.x) / 0.1).abs() < 1e-4, "{k:?}");
        }
        // friction_force_n is signed along the tangent, which runs along −x on this floor.
        assert!((slips[1].friction_force_n - 1.0).abs() < 1e-3);
        // The unit tangent of the axis-aligned floor is −x̂ up to the normalisation
        // v (1/√|v|²): |v|² rounds once (u = ε/2 relative, u/2 after the root), the root
        // errs by at most `nurbs::math::SQRT_MAX_REL_ERROR` (4 ε, not correctly rounded),
        // the reciprocal and the product round once each (u): 4 ε + 1.25 ε.
        let tangent_tol = nurbs::math::SQRT_MAX_REL_ERROR + 1.25 * f32::EPSILON;
        assert!(
            (slips[1].tangent.x + 1.0).abs() <= tangent_tol,
            "{}",
            slips[1].tangent.x
        );
    }

    #[test]
    fn csv_has_one_row_per_tick() {
        let scene = floor_scene();
        let run =
            run(&scene, 0, &press_and_slide(), 200.0, |_, _| {}).unwrap_or_else(|e| panic!("{e}"));
        let mut out = Vec::new();
        run.write_csv(&mut out).expect("write to memory");
        let text = String::from_utf8(out).expect("UTF-8");
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], csv_header(Space::Planar));
        assert_eq!(lines.len(), 1 + run.ticks.len());
        assert_eq!(run.ticks.len(), 241);
        for line in &lines[1..] {
            assert_eq!(line.split(',').count(), 17, "{line}");
        }
        assert!(lines[1].starts_with("0,0.0,0.085,"), "{}", lines[1]);
        assert!(
            lines[1].contains(",-1,free,none,0.0,0.0,0.0,"),
            "{}",
            lines[1]
        );
        let last: Vec<&str> = lines[lines.len() - 1].split(',').collect();
        assert_eq!(last[0], "1.2");
        assert_eq!((last[7], last[8]), ("0", "slip"));
        assert_eq!(last[9], "converged");
        let depth: f32 = last[10].parse().expect("number");
        assert!((depth - 0.002).abs() < 1e-6);
        // A value that is not finite is never written: the whole log is refused.
        let mut bad = run.clone();
        bad.ticks[7].psi = f32::NAN;
        let mut out = Vec::new();
        let e = bad.write_csv(&mut out).expect_err("NaN");
        assert!(
            e.to_string().starts_with("tick 7 (t = 0.035 s): psi"),
            "{e}"
        );
        assert!(out.is_empty());
    }

    #[test]
    fn spatial_run_on_a_flat_patch() {
        // The plane z = 0 with normal S_u × S_v = +z; press 2 mm and slide along y.
        let scene = floor_scene();
        let trajectory = Trajectory::from_samples(
            Space::Spatial,
            [
                (0.0, [0.0, 0.08, 0.005]),
                (0.1, [0.0, 0.08, -0.002]),
                (0.6, [0.0, 0.1, -0.002]),
            ],
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let run = run(&scene, 1, &trajectory, 1000.0, |_, _| {}).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(run.space, Space::Spatial);
        let modes: Vec<Mode> = run.ticks.iter().map(|k| k.mode).collect();
        let first_slip = modes.iter().position(|&m| m == Mode::Slip).expect("slips");
        assert!(
            modes[first_slip..].iter().all(|&m| m == Mode::Slip),
            "slips to the end"
        );
        let last = run.ticks.last().expect("ticks");
        // K = 500 N/m, 2 mm: F_N = 1 N; μ_d = 0.3: friction 0.3 N against +y.
        assert!((last.normal_force_n - 1.0).abs() < 1e-3, "{last:?}");
        assert!(
            (last.friction - Vec3::new(0.0, -0.3, 0.0)).length() < 1e-3,
            "{last:?}"
        );
        let mut out = Vec::new();
        run.write_csv(&mut out).expect("write");
        let text = String::from_utf8(out).expect("UTF-8");
        assert_eq!(
            text.lines().next(),
            Some(csv_header(Space::Spatial).as_str())
        );
        assert!(text.lines().skip(1).all(|l| l.split(',').count() == 21));
    }

    #[test]
    fn setup_errors() {
        let scene = floor_scene();
        let planar = press_and_slide();
        let e = run(&scene, 2, &planar, 1000.0, |_, _| {}).expect_err("no object 2");
        assert_eq!(
            e.to_string(),
            "--object 2: the scene has 2 object(s), indices 0..=1"
        );
        for rate in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e-300, 1e300, 1e39] {
            let e = run(&scene, 0, &planar, rate, |_, _| {}).expect_err("bad rate");
            assert!(matches!(e, SimError::Rate { .. }), "{e}");
        }
        let e = run(&scene, 1, &planar, 1000.0, |_, _| {}).expect_err("2-D on a surface");
        assert_eq!(
            e.to_string(),
            "the trajectory is 2-D but object 1 (\"bump\") is a 3-D shell of surfaces; a t,x,y \
             trajectory needs an object of planar curves"
        );
        let spatial = Trajectory::from_samples(Space::Spatial, [(0.0, [0.0; 3]), (1.0, [0.0; 3])])
            .expect("valid");
        let e = run(&scene, 0, &spatial, 1000.0, |_, _| {}).expect_err("3-D on a curve");
        assert!(
            e.to_string()
                .contains("a t,x,y,z trajectory needs an object of surfaces"),
            "{e}"
        );
        let long = Trajectory::from_samples(Space::Planar, [(0.0, [0.0; 3]), (1e5, [0.0; 3])])
            .expect("valid");
        let e = validate(&scene, 0, &long, 1000.0).expect_err("too long");
        assert!(matches!(e, SimError::TooManyTicks { .. }), "{e}");
        assert_eq!(validate(&scene, 0, &planar, 1000.0), Ok(1201));
        // 1.2 s at 1 Hz is two ticks; at 0.5 Hz one, which is refused with the rate it needs.
        assert_eq!(validate(&scene, 0, &planar, 1.0), Ok(2));
        let e = validate(&scene, 0, &planar, 0.5).expect_err("one tick");
        assert!(matches!(e, SimError::TooFewTicks { .. }), "{e}");
        assert!(e.to_string().contains("at least 8.33"), "{e}");
    }

    /// A one-patch roof (degree 1, apex at the interior knot 0.5) is split into two pieces at
    /// load; the run log still names the scene's patch 0, at the GO and the CP alike, and the
    /// parameters stay the patch's own (right leg u < 0.5, left leg u > 0.5).
    #[test]
    fn run_log_names_the_scenes_patches_not_the_pieces() {
        let scene = Scene::from_json_str(
            r#"{ "format": "scene/1", "objects": [
              { "name": "roof",
                "material": { "stiffness_n_per_m": 1000, "damping_ns_per_m": 0,
                              "mu_static": 0.7, "mu_dynamic": 0.5 },
                "patches": [ { "degree": 1, "knots": [0, 0, 0.5, 1, 1],
                               "points": [[0.02, 0.06], [0.0, 0.08], [-0.02, 0.06]] } ] } ] }"#,
        )
        .unwrap_or_else(|e| panic!("{e}"));
        // Press into the left leg, then slide over to it from the right one.
        let trajectory = Trajectory::from_samples(
            Space::Planar,
            [
                (0.0, [-0.01, 0.075, 0.0]),
                (0.1, [-0.01, 0.068, 0.0]),
                (0.2, [-0.01, 0.068, 0.0]),
            ],
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let r = run(&scene, 0, &trajectory, 1000.0, |_, _| {}).unwrap_or_else(|e| panic!("{e}"));
        let touching: Vec<&Tick> = r.ticks.iter().filter(|t| t.mode != Mode::Free).collect();
        assert!(touching.len() > 100);
        for t in touching {
            assert_eq!((t.patch, t.cp_patch, t.go_patch), (Some(0), 0, 0));
            assert!(
                t.cp_params[0] > 0.5 && t.go_params[0] > 0.5,
                "{:?}",
                t.cp_params
            );
        }
    }
}
