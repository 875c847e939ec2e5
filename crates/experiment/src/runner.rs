//! Running a plan headless with a simulated participant
//! (`viewer experiment run PLAN.json --participant sim:SEED --out DIR`), through the same
//! [`Session`] as the app's participant screen, so the files are the same.
//!
//! **2AFC** (`2afc-staircase`, `constant-stimuli`): each trial presents the reference and the
//! comparison in the session's order. Both intervals are explored by the same press: the hand
//! comes down on the object at x = 0 from 10 mm above its top to 2 mm past where a rigid
//! surface would be in [`PRESS_DOWN_S`], then goes back up in [`PRESS_UP_S`], prescribed at
//! 1 kHz through [`host::sim::run`]. The participant feels each interval's stiffness from the
//! rendered positions and forces ([`felt_stiffness`]) and says which was stiffer
//! ([`SimParticipant::stiffer`]).
//!
//! A staircase's `down` rule makes the task harder. For a staircase that starts below the
//! reference, harder means a level closer to the reference, i.e. higher: it runs on the level
//! mirrored about the reference (`r² / x` for multiplicative steps, so that its factors stay
//! factors of the level; `2r − x` for additive ones), and its answer is correct when the
//! participant chose the reference as stiffer. For a staircase above the reference it is
//! correct when the participant chose the comparison. At a level equal to the reference
//! (a bound can sit there) neither is right, and the staircase's side decides as stated,
//! which the participant meets half the time: the truth for identical stimuli.
//!
//! **Identification**: the participant taps the object at nine points across the stimuli's
//! common bounding box (the same for every stimulus, so the exploration says nothing of which
//! is presented), through [`host::sim::explore`]: at each point the hand comes down at
//! [`TAP_SPEED_M_PER_S`] from above the box until the force reaches [`TAP_STOP_N`], noting the
//! height where it first reached [`TAP_TOUCH_N`] and the force's direction at the end, and goes
//! back up. From the heights and directions it forms two cues of the shape
//! ([`shape_cues`]), with its noise ([`SimParticipant::feel_taps`]), and names the candidate
//! whose pictured shape gives the nearest cues ([`SimParticipant::identify`]). Friction acts
//! where it physically does: a tap that sticks on a slope pushes back vertically, not along
//! the normal, so the direction cue flattens where the slope is inside the friction cone.
//!
//! Written to the output folder: `trials.csv` ([`crate::session`]'s columns), `traces/
//! trial-NNNN-a.csv` (and `-b.csv` for 2AFC: each interval's run log), and `plan.json` (the
//! plan with absolute scene paths).

use std::fs::File;
use std::path::Path;

use host::error::SimError;
use host::sim::{self, Trajectory};
use host::tick::Tick;

use scene::{Scene, Space};

use crate::error::RunError;
use crate::plan::{Design, Plan};
use crate::rng::Prng;
use crate::session::{Response, Session, TrialRecord};
use crate::sim_participant::{SimParticipant, Tap, felt_stiffness, shape_cues};

pub use crate::session::{MAX_TRIALS, TRIALS_HEADER};

/// Height of the press's start above the object's top (m).
pub const PRESS_ABOVE_M: f64 = 0.010;
/// How far the press goes past the rigid surface (m).
pub const PRESS_DEPTH_M: f64 = 0.002;
/// Duration of the press down (s).
pub const PRESS_DOWN_S: f64 = 0.5;
/// Duration of the way back up (s).
pub const PRESS_UP_S: f64 = 0.2;
/// Tick rate of the simulated exploration (Hz).
pub const RATE_HZ: f64 = sim::DEFAULT_RATE_HZ;
/// Speed of a tap's way down, and of the moves between taps (m/s).
pub const TAP_SPEED_M_PER_S: f64 = 0.05;
/// The force at which a tap counts as touching (N): a quarter of a millimetre into a
/// 1,000 N/m wall.
pub const TAP_TOUCH_N: f64 = 0.25;
/// The force at which a tap stops pressing and reads the force's direction (N).
pub const TAP_STOP_N: f64 = 1.0;
/// How far above the stimuli's common box the hand moves between taps (m).
pub const TAP_CLEARANCE_M: f64 = 0.005;

/// One staircase at the end of a run.
#[derive(Clone, Debug, PartialEq)]
pub struct StaircaseSummary {
    /// Its name in the plan.
    pub name: String,
    /// Whether it is below the reference (run mirrored).
    pub below: bool,
    /// Trials it took.
    pub trials: usize,
    /// Its reversal levels (stimulus values), in order.
    pub reversal_levels: Vec<f64>,
    /// Whether its stopping rule was met.
    pub finished: bool,
    /// Its threshold: the mean of its last reversals ([`StaircaseSummary::threshold_reversals`]
    /// of them), `None` without reversals.
    pub threshold: Option<f64>,
    /// How many reversals the threshold averages: those made at the reduced step when the
    /// step is reduced, otherwise all but the first two (Levitt 1971 discards the early
    /// ones, made before the track reached the threshold region), and an even number of them
    /// so that as many turn up as down.
    pub threshold_reversals: usize,
}

/// What a run did.
#[derive(Clone, Debug, PartialEq)]
pub struct RunSummary {
    /// Trials the folder held already (a resumed run), answered in earlier sessions.
    pub resumed: usize,
    /// Trials run in this session (practice included).
    pub trials: usize,
    /// Practice trials among them.
    pub practice: usize,
    /// Trials answered correctly, practice excluded.
    pub correct: usize,
    /// The reference value (2AFC designs).
    pub reference: Option<f64>,
    /// Each staircase, in the plan's order (staircase designs).
    pub staircases: Vec<StaircaseSummary>,
}

impl std::fmt::Display for RunSummary {
    /// One line: the trials, the proportion correct and each staircase's threshold.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let n = self.trials - self.practice;
        if self.trials == 0 && self.resumed > 0 {
            write!(
                f,
                "the run was complete already ({} trials answered): nothing to run",
                self.resumed
            )?;
        } else {
            if self.resumed > 0 {
                write!(f, "resumed after {} trials: ", self.resumed)?;
            }
            write!(
                f,
                "{} trials ({} practice), {} of {n} correct",
                self.trials, self.practice, self.correct
            )?;
        }
        for s in &self.staircases {
            match s.threshold {
                Some(t) => write!(
                    f,
                    "; {:?}: threshold {t:.4} (mean of the last {} of {} reversals, {} trials{})",
                    s.name,
                    s.threshold_reversals,
                    s.reversal_levels.len(),
                    s.trials,
                    if s.finished { "" } else { ", unfinished" }
                )?,
                None => write!(f, "; {:?}: no reversal", s.name)?,
            }
        }
        Ok(())
    }
}

/// The height (m) and slope dy/dx of the object's highest curve point over `x`, and the
/// height of its top. Each curve is sampled at 4096 parameters and the crossings of `x`
/// interpolated linearly (exact on straight pieces).
fn surface_at(scene: &Scene, object: usize, x: f64) -> Result<(f64, f64, f64), RunError> {
    let o = scene.object(object).ok_or_else(|| {
        RunError::Unsupported(format!(
            "the stimulus's object {object} is not in its scene"
        ))
    })?;
    let (mut surface, mut slope, mut top) = (f64::NEG_INFINITY, 0.0, f64::NEG_INFINITY);
    for [x0, y0, x1, y1] in segments(scene, object)? {
        top = top.max(y0).max(y1);
        if (x0 <= x && x1 >= x) || (x1 <= x && x0 >= x) {
            let (y, g) = if x1 == x0 {
                (y0.max(y1), 0.0)
            } else {
                let g = (y1 - y0) / (x1 - x0);
                (y0 + g * (x - x0), g)
            };
            if y > surface {
                (surface, slope) = (y, g);
            }
        }
    }
    if surface.is_finite() {
        Ok((surface, slope, top))
    } else {
        Err(RunError::NoSurface {
            object,
            name: o.name().to_owned(),
            x,
        })
    }
}

/// The object's curves as 4096 straight segments each, `[x0, y0, x1, y1]`.
fn segments(scene: &Scene, object: usize) -> Result<Vec<[f64; 4]>, RunError> {
    let o = scene.object(object).ok_or_else(|| {
        RunError::Unsupported(format!(
            "the stimulus's object {object} is not in its scene"
        ))
    })?;
    let curves = o.curve_views().ok_or_else(|| {
        RunError::Unsupported(format!(
            "object {object} ({:?}) is not planar: the exploration is planar for now",
            o.name()
        ))
    })?;
    const SAMPLES: usize = 4096;
    let mut out = Vec::with_capacity(curves.len() * SAMPLES);
    for c in &curves {
        let (u0, u1) = c.domain();
        let points: Vec<(f64, f64)> = (0..=SAMPLES)
            .map(|i| {
                let u = u0 + (u1 - u0) * i as f32 / SAMPLES as f32;
                let p = c.point(u);
                (f64::from(p.x), f64::from(p.y))
            })
            .collect();
        out.extend(points.windows(2).map(|w| [w[0].0, w[0].1, w[1].0, w[1].1]));
    }
    Ok(out)
}

/// The press of every 2AFC interval: straight down at x = 0 from [`PRESS_ABOVE_M`] above the
/// object's top to [`PRESS_DEPTH_M`] under its surface, then back.
fn press(surface_m: f64, top_m: f64) -> Result<Trajectory, RunError> {
    let start = [0.0, top_m + PRESS_ABOVE_M, 0.0];
    let bottom = [0.0, surface_m - PRESS_DEPTH_M, 0.0];
    Trajectory::from_samples(
        Space::Planar,
        [
            (0.0, start),
            (PRESS_DOWN_S, bottom),
            (PRESS_DOWN_S + PRESS_UP_S, start),
        ],
    )
    .map_err(RunError::Trajectory)
}

/// Where the identification taps come down and between which heights they move: the nine
/// points `centre + k d`, `k = −4..=4`, over 80 % of the stimuli's common bounding box, the
/// height [`TAP_CLEARANCE_M`] above it and the floor as far under it.
#[derive(Clone, Debug, PartialEq)]
struct TapPlan {
    xs: Vec<f64>,
    d: f64,
    above: f64,
    floor: f64,
}

impl TapPlan {
    fn new(plan: &Plan) -> Result<TapPlan, RunError> {
        let mut b = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        for (i, st) in plan.spec().stimuli.iter().enumerate() {
            let scene = plan.scene(i).ok_or_else(|| {
                RunError::Unsupported(format!("the plan has no scene for stimulus {i}"))
            })?;
            for [x0, y0, x1, y1] in segments(scene, st.object)? {
                b = [
                    b[0].min(x0).min(x1),
                    b[1].min(y0).min(y1),
                    b[2].max(x0).max(x1),
                    b[3].max(y0).max(y1),
                ];
            }
        }
        let centre = 0.5 * (b[0] + b[2]);
        let d = 0.8 * 0.5 * (b[2] - b[0]) / 4.0;
        Ok(TapPlan {
            xs: (-4..=4).map(|k| centre + f64::from(k) * d).collect(),
            d,
            above: b[3] + TAP_CLEARANCE_M,
            floor: b[1] - TAP_CLEARANCE_M,
        })
    }

    /// The taps a rigid, frictionless copy of the stimulus would give (heights and slopes of
    /// its geometry): what its picture shows.
    fn pictured(&self, scene: &Scene, object: usize) -> Result<Vec<Tap>, RunError> {
        self.xs
            .iter()
            .map(|&x| {
                let (height, slope, _) = surface_at(scene, object, x)?;
                Ok(Tap { x, height, slope })
            })
            .collect()
    }
}

/// What a tapping hand is doing.
#[derive(Clone, Copy, Debug)]
enum TapPhase {
    /// Moving over to tap `i`.
    Over(usize),
    /// Coming down at tap `i`; the height where it touched.
    Down(usize, Option<f64>),
    /// Going back up from tap `i`.
    Up(usize),
}

/// Taps `scene`'s object at the plan's points through the haptic loop ([`sim::explore`]);
/// returns the run and what each tap felt (`None` for a tap that reached the floor without
/// touching).
fn tap(
    scene: &Scene,
    object: usize,
    taps: &TapPlan,
    max_ticks: usize,
) -> Result<(sim::Run, Vec<Option<Tap>>), SimError> {
    let step = TAP_SPEED_M_PER_S / RATE_HZ;
    let mut at = [taps.xs[0], taps.above];
    let mut phase = TapPhase::Down(0, None);
    let mut felt: Vec<Option<Tap>> = vec![None; taps.xs.len()];
    let run = sim::explore(
        scene,
        object,
        [at[0], at[1], 0.0],
        RATE_HZ,
        max_ticks,
        |last: &Tick| {
            let f = last.force;
            let force = f64::from(f.length());
            phase = match phase {
                TapPhase::Over(i) => {
                    let dx = taps.xs[i] - at[0];
                    at[0] += dx.clamp(-step, step);
                    if dx.abs() <= step {
                        TapPhase::Down(i, None)
                    } else {
                        phase
                    }
                }
                TapPhase::Down(i, touched) => {
                    // `at` is where this tick's record was taken.
                    let touched = touched.or((force >= TAP_TOUCH_N).then_some(at[1]));
                    if force >= TAP_STOP_N || at[1] <= taps.floor {
                        felt[i] = touched.map(|height| Tap {
                            x: taps.xs[i],
                            height,
                            slope: if f.y > 0.0 {
                                -f64::from(f.x) / f64::from(f.y)
                            } else {
                                0.0
                            },
                        });
                        TapPhase::Up(i)
                    } else {
                        at[1] -= step;
                        TapPhase::Down(i, touched)
                    }
                }
                TapPhase::Up(i) => {
                    at[1] = (at[1] + 2.0 * step).min(taps.above);
                    if at[1] < taps.above {
                        phase
                    } else if i + 1 < taps.xs.len() {
                        TapPhase::Over(i + 1)
                    } else {
                        return None;
                    }
                }
            };
            Some([at[0], at[1], 0.0])
        },
    )?;
    Ok((run, felt))
}

/// Writes a run log under `DIR/traces`; returns its name relative to `DIR`.
fn write_trace(dir: &Path, name: String, run: &sim::Run) -> Result<String, RunError> {
    let path = dir.join("traces").join(&name);
    File::create(&path)
        .and_then(|file| run.write_csv(file))
        .map_err(|cause| RunError::Write { path, cause })?;
    Ok(format!("traces/{name}"))
}

/// The participant's label in `trials.csv`: its `--participant` text, normalised.
pub fn participant_label(p: &SimParticipant) -> String {
    format!(
        "sim:{}:weber={}:lapse={}:acuity_mm={}:direction_deg={}",
        p.seed,
        p.weber,
        p.lapse,
        p.acuity_m * 1e3,
        p.direction_rad.to_degrees()
    )
}

/// Each staircase of a session (staircase designs; none otherwise), in the plan's order: its
/// reversals as [`crate::staircase`] defines them, the levels as presented (mirrored back for
/// a staircase below the reference), and the threshold from them.
pub fn staircase_summaries(session: &Session) -> Vec<StaircaseSummary> {
    let spec = session.plan().spec();
    let Some((stairs, sides)) = session.stairs() else {
        return Vec::new();
    };
    stairs
        .iter()
        .zip(sides)
        .zip(&spec.staircases)
        .map(|((stair, side), s)| {
            let reversal_levels: Vec<f64> = stair
                .reversal_levels()
                .iter()
                .map(|&v| side.mirror(v))
                .collect();
            let n = reversal_levels.len();
            let after = match stair.config().reduced_step {
                Some((after, _)) => after,
                None => 2,
            };
            let mut k = n.saturating_sub(after);
            if k % 2 == 1 {
                k -= 1;
            }
            let k = if k == 0 { n } else { k };
            let threshold =
                (k > 0).then(|| reversal_levels[n - k..].iter().sum::<f64>() / k as f64);
            StaircaseSummary {
                name: s.name.clone(),
                below: side.below,
                trials: stair.track().len(),
                finished: stair.is_finished(),
                threshold,
                threshold_reversals: k,
                reversal_levels,
            }
        })
        .collect()
}

/// Runs `plan` with a simulated participant into `out_dir` (module docs): a [`Session`]
/// (resuming one already there), each trial explored through the haptic loop and answered
/// from what was felt. The participant's noise comes from its own seed.
pub fn run(
    plan: &Plan,
    participant: &SimParticipant,
    out_dir: &Path,
) -> Result<RunSummary, RunError> {
    let spec = plan.spec();
    let design = spec.design;
    // Everything the exploration needs is checked before anything is written.
    let taps = if design == Design::Identification {
        let taps = TapPlan::new(plan)?;
        let pictured = (0..spec.stimuli.len())
            .map(|i| {
                let scene = plan.scene(i).ok_or_else(|| {
                    RunError::Unsupported(format!("the plan has no scene for stimulus {i}"))
                })?;
                let cues = shape_cues(&taps.pictured(scene, spec.stimuli[i].object)?)
                    .ok_or_else(|| RunError::Unsupported("nine taps expected".to_owned()))?;
                Ok(cues)
            })
            .collect::<Result<Vec<[f64; 2]>, RunError>>()?;
        Some((taps, pictured))
    } else {
        for (i, st) in spec.stimuli.iter().enumerate() {
            let scene = plan.scene(i).ok_or_else(|| {
                RunError::Unsupported(format!("the plan has no scene for stimulus {i}"))
            })?;
            surface_at(scene, st.object, 0.0)?;
        }
        None
    };
    let max_ticks = spec
        .exploration_time_s
        .map_or(sim::MAX_TICKS, |t| (t * RATE_HZ).ceil() as usize);
    let mut session = Session::open(plan.clone(), &participant_label(participant), out_dir)?;
    let mut noise = Prng::new(participant.seed);
    let (mut trials, mut practice, mut correct) = (0, 0, 0);
    let mut clock_s = 0.0;
    while let Some(trial) = session.next_trial()? {
        let n = trial.number;
        let t_start_s = clock_s;
        let mut traces = Vec::new();
        let response = if let Some((taps, pictured)) = &taps {
            let (run, felt) =
                tap(&trial.intervals[0], trial.object, taps, max_ticks).map_err(|cause| {
                    RunError::Sim {
                        trial: n,
                        interval: 'a',
                        cause,
                    }
                })?;
            clock_s += run.ticks.len() as f64 / RATE_HZ;
            traces.push(write_trace(out_dir, format!("trial-{n:04}-a.csv"), &run)?);
            let felt = felt
                .iter()
                .zip(&taps.xs)
                .map(|(t, &x)| t.ok_or(RunError::NoTouch { trial: n, x }))
                .collect::<Result<Vec<Tap>, RunError>>()?;
            let cues = shape_cues(&participant.feel_taps(&felt, &mut noise))
                .ok_or_else(|| RunError::Unsupported("nine taps expected".to_owned()))?;
            Response::Stimulus(participant.identify(cues, pictured, taps.d, &mut noise))
        } else {
            let mut felt = [0.0; 2];
            for (k, (scene, interval)) in trial.intervals.iter().zip(['a', 'b']).enumerate() {
                let (surface, _, top) = surface_at(scene, trial.object, 0.0)?;
                let trajectory = press(surface, top)?;
                let run = sim::run(scene, trial.object, &trajectory, RATE_HZ, |_, _| {}).map_err(
                    |cause| RunError::Sim {
                        trial: n,
                        interval,
                        cause,
                    },
                )?;
                clock_s += run.ticks.len() as f64 / RATE_HZ;
                let samples: Vec<([f32; 3], [f32; 3])> = run
                    .ticks
                    .iter()
                    .map(|t| (t.hip.to_array(), t.force.to_array()))
                    .collect();
                felt[k] =
                    felt_stiffness(&samples).ok_or(RunError::NotFelt { trial: n, interval })?;
                traces.push(write_trace(
                    out_dir,
                    format!("trial-{n:04}-{interval}.csv"),
                    &run,
                )?);
            }
            let second = participant.stiffer(felt[0], felt[1], &mut noise);
            Response::Interval(if second { 2 } else { 1 })
        };
        let record = TrialRecord {
            response_time_s: 0.0,
            traces,
            t_start_s,
        };
        let right = session.respond(response, &record)?;
        trials += 1;
        if trial.practice {
            practice += 1;
        } else if right {
            correct += 1;
        }
    }

    let staircases = staircase_summaries(&session);
    Ok(RunSummary {
        resumed: session.resumed(),
        trials,
        practice,
        correct,
        reference: spec.reference.as_ref().map(|r| r.value),
        staircases,
    })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// Taps on the straight roof, whose sides slope at exactly 45° (ends (±0.03, 0.065),
    /// vertex (0, 0.095)). Without friction the force is the surface normal, so the felt slope
    /// is the side's, ∓1. With Coulomb friction the vertical press slides (tan 45° = 1 > μs =
    /// 0.7) and the force leans from the normal towards the vertical by the friction angle
    /// atan μ: the felt slope is tan(45° − atan μ) = (1 − μ)/(1 + μ). The renderer's μ follows
    /// the Stribeck curve between μd = 0.5 (fast) and μs = 0.7 (slow), so the felt slope lies
    /// in [(1 − μs)/(1 + μs), (1 − μd)/(1 + μd)] = [0.176, 0.333]: a third to a sixth of the
    /// true slope, the flattening friction brings to the direction cue.
    /// The heights: the touch level F = 0.25 N is reached a depth d = F / K along the normal
    /// (K = 1,000 N/m), i.e. Δy = d / cos 45° under the surface; sliding on the cone's edge the
    /// spring is stretched 1/cos(atan μd) = √(1 + μd²) times the normal depth, so
    /// Δy = d / (cos 45° √(1 + μd²)). The tap descends 50 µm a tick, so the touch is noted up
    /// to one step deeper (and 1 µm for f32 positions).
    #[test]
    fn taps_feel_the_normal_without_friction_and_the_friction_cone_with_it() {
        let plan = Plan::load(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../experiments/thesis-shapes.json"),
        )
        .unwrap();
        let taps = TapPlan::new(&plan).unwrap();
        let straight = 2;
        let scene = plan.scene(straight).unwrap();
        let d = TAP_TOUCH_N / 1000.0;
        let cos45 = std::f64::consts::FRAC_1_SQRT_2;
        let step = TAP_SPEED_M_PER_S / RATE_HZ;
        let cone = |mu: f64| (1.0 - mu) / (1.0 + mu);
        for (condition, slopes, lever) in [
            (1, [1.0 - 1e-3, 1.0 + 1e-3], 1.0),
            (0, [cone(0.7), cone(0.5)], 1.49f64.sqrt()),
        ] {
            // The spring's stretch over the normal depth is at most √(1 + μs²).
            let lowest = d / (cos45 * lever);
            let material = plan.material(straight, condition, None).unwrap();
            let scene = scene.with_material(0, material).unwrap();
            let (run, felt) = tap(&scene, 0, &taps, 60_000).unwrap();
            assert!(run.ticks.len() > 1000);
            for t in felt.iter().map(|t| t.unwrap()) {
                if t.x.abs() < 1e-9 {
                    continue; // the vertex: no single slope
                }
                let (h, g, _) = surface_at(&scene, 0, t.x).unwrap();
                eprintln!(
                    "condition {condition}: x {:+.4} felt slope {:+.4} (side {g:+.3}), height {:.5} (geometry {h:.5})",
                    t.x, t.slope, t.height
                );
                assert!(
                    t.slope.abs() >= slopes[0] && t.slope.abs() <= slopes[1],
                    "{t:?} not in {slopes:?}"
                );
                assert_eq!(t.slope.signum(), g.signum(), "{t:?}");
                let below = h - t.height;
                assert!(
                    below > lowest - 1e-6 && below < lowest + step + 1e-6,
                    "{t:?}: {below} not in [{lowest}, {}]",
                    lowest + step
                );
            }
        }
    }
}
