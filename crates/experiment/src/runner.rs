//! Running a `2afc-staircase` plan headless with a simulated participant
//! (`viewer experiment run PLAN.json --participant sim:SEED --out DIR`).
//!
//! Each trial presents the reference and the comparison (the staircase's level) in a random
//! order. Both intervals are explored by the same press: the hand comes down on the object at
//! x = 0 from 10 mm above its top to 2 mm past where a rigid surface would be in
//! [`PRESS_DOWN_S`], then goes back up in [`PRESS_UP_S`], prescribed at 1 kHz through
//! [`host::sim::run`]. The participant feels each interval's stiffness from the rendered
//! positions and forces ([`felt_stiffness`]) and says which was stiffer
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
//! Written to the output folder: `trials.csv` (one row per trial, long format), `traces/
//! trial-NNNN-a.csv` and `-b.csv` (each interval's run log, first and second interval), and
//! `plan.json` (the plan with absolute scene paths).

use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use host::sim::{self, SimError, Trajectory, TrajectoryError};

use scene::{Scene, SceneError, Space};
use thiserror::Error;

use crate::participant::{SimParticipant, felt_stiffness};
use crate::plan::{Design, Plan, PlanError, StaircaseSpec, StepKind, StopSpec};
use crate::rng::Prng;
use crate::staircase::{Interleaved, Staircase, StaircaseConfig, StaircaseError, Step, Stop};

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
/// Most trials a run may take before it is declared stuck (a staircase that never reverses).
pub const MAX_TRIALS: usize = 10_000;

/// The header of `trials.csv`.
pub const TRIALS_HEADER: &str = "participant,session,block,trial,design,stimulus,condition,\
staircase,level,reference,comparison_interval,response,correct,response_time_s,trace,t_start_s";

/// Why a run could not be made.
#[derive(Debug, Error)]
pub enum RunError {
    /// The runner only runs `2afc-staircase` plans.
    #[error("the plan's design is {0:?}: only \"2afc-staircase\" plans can be run so far")]
    Design(&'static str),
    /// A plan feature the runner does not handle yet.
    #[error("{0}")]
    Unsupported(String),
    /// The plan has no reference.
    #[error("a 2afc-staircase plan needs a \"reference\"")]
    NoReference,
    /// A staircase's parameters are refused.
    #[error("staircase {name:?}: {cause}")]
    Staircase {
        /// Its name in the plan.
        name: String,
        /// What is wrong.
        cause: StaircaseError,
    },
    /// The plan's material at a level is refused.
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// The stimulus's scene with the material at a level is refused.
    #[error("the scene with the stimulus's material at {level}: {cause}")]
    Scene {
        /// The value of the reference field.
        level: f64,
        /// What is wrong.
        cause: SceneError,
    },
    /// The object has nothing under the press.
    #[error("object {object} ({name:?}) has no surface under x = 0 where the press comes down")]
    NoSurface {
        /// Its index in the scene.
        object: usize,
        /// Its name.
        name: String,
    },
    /// The press could not be made a trajectory.
    #[error("the press trajectory: {0}")]
    Trajectory(TrajectoryError),
    /// A simulated interval failed.
    #[error("trial {trial}, interval {interval}: the simulation failed: {cause}")]
    Sim {
        /// The trial (from 1).
        trial: usize,
        /// `a` or `b`.
        interval: char,
        /// What failed.
        cause: SimError,
    },
    /// The press rendered no force to feel.
    #[error("trial {trial}, interval {interval}: the press felt no force (the object was missed)")]
    NotFelt {
        /// The trial (from 1).
        trial: usize,
        /// `a` or `b`.
        interval: char,
    },
    /// The staircases did not finish.
    #[error("the staircases had not finished after {0} trials")]
    TooManyTrials(usize),
    /// A folder could not be made.
    #[error("cannot create the folder {path}: {cause}")]
    CreateDir {
        /// The folder.
        path: PathBuf,
        /// Why.
        cause: io::Error,
    },
    /// A file could not be written.
    #[error("cannot write {path}: {cause}")]
    Write {
        /// The file.
        path: PathBuf,
        /// Why.
        cause: io::Error,
    },
}

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
    /// Trials run.
    pub trials: usize,
    /// The reference value.
    pub reference: f64,
    /// Each staircase, in the plan's order.
    pub staircases: Vec<StaircaseSummary>,
}

impl std::fmt::Display for RunSummary {
    /// One line: the trials and each staircase's threshold.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} trials", self.trials)?;
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

/// How a plan's staircase runs: on the level itself or mirrored about the reference.
#[derive(Clone, Copy, Debug)]
struct Side {
    below: bool,
    multiplicative: bool,
    reference: f64,
}

impl Side {
    /// The staircase's value for a level, and back (an involution).
    fn mirror(self, x: f64) -> f64 {
        match (self.below, self.multiplicative) {
            (false, _) => x,
            (true, true) => self.reference * self.reference / x,
            (true, false) => 2.0 * self.reference - x,
        }
    }
}

fn step(kind: StepKind, size: f64) -> Step {
    match kind {
        StepKind::Additive => Step::Additive(size),
        StepKind::Multiplicative => Step::Multiplicative(size),
    }
}

fn staircase(spec: &StaircaseSpec, reference: f64) -> Result<(Staircase, Side), RunError> {
    let [lo, hi] = spec.bounds;
    let side = Side {
        below: spec.start < reference || (spec.start == reference && hi <= reference),
        multiplicative: spec.step.kind == StepKind::Multiplicative,
        reference,
    };
    let (a, b) = (side.mirror(lo), side.mirror(hi));
    let config = StaircaseConfig {
        start: side.mirror(spec.start),
        n_down: spec.rule.down,
        n_up: spec.rule.up,
        step: step(spec.step.kind, spec.step.size),
        reduced_step: spec
            .step
            .reduce_after_reversals
            .zip(spec.step.reduced_size)
            .map(|(after, size)| (after as usize, step(spec.step.kind, size))),
        min: a.min(b),
        max: a.max(b),
        stop: match spec.stop {
            StopSpec::Reversals(n) => Stop {
                reversals: Some(n as usize),
                trials: None,
            },
            StopSpec::Trials(n) => Stop {
                reversals: None,
                trials: Some(n as usize),
            },
        },
    };
    let stair = Staircase::new(config).map_err(|cause| RunError::Staircase {
        name: spec.name.clone(),
        cause,
    })?;
    Ok((stair, side))
}

/// The height of the object's highest curve point over x = 0 (m): where a rigid surface would
/// stop the press. Each curve is sampled at 4096 parameters and the crossings of x = 0
/// interpolated linearly (exact on straight pieces).
fn surface_at_x0(scene: &Scene, object: usize) -> Result<(f64, f64), RunError> {
    let o = scene.object(object).ok_or_else(|| {
        RunError::Unsupported(format!(
            "the stimulus's object {object} is not in its scene"
        ))
    })?;
    let no_surface = || RunError::NoSurface {
        object,
        name: o.name().to_owned(),
    };
    let curves = o.curve_views().ok_or_else(|| {
        RunError::Unsupported(format!(
            "object {object} ({:?}) is not planar: the press is planar for now",
            o.name()
        ))
    })?;
    const SAMPLES: usize = 4096;
    let (mut surface, mut top) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
    for c in &curves {
        let (u0, u1) = c.domain();
        let points: Vec<(f64, f64)> = (0..=SAMPLES)
            .map(|i| {
                let u = u0 + (u1 - u0) * i as f32 / SAMPLES as f32;
                let p = c.point(u);
                (f64::from(p.x), f64::from(p.y))
            })
            .collect();
        for w in points.windows(2) {
            let ((x0, y0), (x1, y1)) = (w[0], w[1]);
            top = top.max(y0).max(y1);
            if (x0 <= 0.0 && x1 >= 0.0) || (x1 <= 0.0 && x0 >= 0.0) {
                let y = if x1 == x0 {
                    y0.max(y1)
                } else {
                    y0 + (y1 - y0) * (0.0 - x0) / (x1 - x0)
                };
                surface = surface.max(y);
            }
        }
    }
    if surface.is_finite() {
        Ok((surface, top))
    } else {
        Err(no_surface())
    }
}

/// The press of every interval: straight down at x = 0 from [`PRESS_ABOVE_M`] above the
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

/// Quotes a CSV field when it needs it (RFC 4180).
fn csv_field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_owned()
    }
}

fn create_dir(path: &Path) -> Result<(), RunError> {
    fs::create_dir_all(path).map_err(|cause| RunError::CreateDir {
        path: path.to_owned(),
        cause,
    })
}

/// The participant's label in `trials.csv`: its `--participant` text, normalised.
pub fn participant_label(p: &SimParticipant) -> String {
    format!("sim:{}:weber={}:lapse={}", p.seed, p.weber, p.lapse)
}

/// Runs a `2afc-staircase` plan with a simulated participant, writing `trials.csv`,
/// `traces/` and `plan.json` into `out_dir` (created if missing). The staircases are
/// interleaved with the plan's seed; the interval order is drawn from a stream seeded by the
/// plan's seed + 1; the participant's noise from its own seed. Practice trials are not run.
pub fn run_2afc(
    plan: &Plan,
    participant: &SimParticipant,
    out_dir: &Path,
) -> Result<RunSummary, RunError> {
    let spec = plan.spec();
    if spec.design != Design::TwoAfcStaircase {
        return Err(RunError::Design(spec.design.name()));
    }
    if spec.stimuli.len() != 1 || spec.conditions.len() != 1 {
        return Err(RunError::Unsupported(format!(
            "the plan has {} stimuli and {} conditions: the runner runs one of each so far",
            spec.stimuli.len(),
            spec.conditions.len()
        )));
    }
    let reference = spec.reference.as_ref().ok_or(RunError::NoReference)?.value;
    let (stimulus, condition) = (0, 0);
    let object = spec.stimuli[stimulus].object;
    let base = plan.scene(stimulus).ok_or_else(|| {
        RunError::Unsupported(format!("the plan has no scene for stimulus {stimulus}"))
    })?;
    let (surface, top) = surface_at_x0(base, object)?;
    let trajectory = press(surface, top)?;
    let scene_at = |level: f64| -> Result<Scene, RunError> {
        let material = plan.material(stimulus, condition, Some(level))?;
        base.with_material(object, material)
            .map_err(|cause| RunError::Scene { level, cause })
    };
    let reference_scene = scene_at(reference)?;

    let mut stairs = Vec::new();
    let mut sides = Vec::new();
    for s in &spec.staircases {
        let (stair, side) = staircase(s, reference)?;
        stairs.push(stair);
        sides.push(side);
    }
    let mut interleaved = Interleaved::new(stairs, spec.seed);
    let mut order = Prng::new(spec.seed.wrapping_add(1));
    let mut noise = Prng::new(participant.seed);

    create_dir(out_dir)?;
    let traces = out_dir.join("traces");
    create_dir(&traces)?;
    let plan_path = out_dir.join("plan.json");
    let plan_json = plan.to_json_string_resolved()?;
    fs::write(&plan_path, plan_json + "\n").map_err(|cause| RunError::Write {
        path: plan_path,
        cause,
    })?;
    let trials_path = out_dir.join("trials.csv");
    let write_error = |cause| RunError::Write {
        path: trials_path.clone(),
        cause,
    };
    let mut trials_csv = BufWriter::new(File::create(&trials_path).map_err(write_error)?);
    writeln!(trials_csv, "{TRIALS_HEADER}").map_err(write_error)?;

    let label = csv_field(&participant_label(participant));
    let interval_s = PRESS_DOWN_S + PRESS_UP_S;
    let mut trial = 0;
    while let Some((index, value)) = interleaved.next_trial() {
        if trial >= MAX_TRIALS {
            return Err(RunError::TooManyTrials(trial));
        }
        trial += 1;
        let side = sides[index];
        let level = side.mirror(value);
        let comparison_first = order.bernoulli(0.5);
        let comparison_scene = scene_at(level)?;
        let (first, second) = if comparison_first {
            (&comparison_scene, &reference_scene)
        } else {
            (&reference_scene, &comparison_scene)
        };
        let mut felt = [0.0; 2];
        let mut names = Vec::new();
        for (k, (scene, interval)) in [(first, 'a'), (second, 'b')].into_iter().enumerate() {
            let run =
                sim::run(scene, object, &trajectory, RATE_HZ, |_, _| {}).map_err(|cause| {
                    RunError::Sim {
                        trial,
                        interval,
                        cause,
                    }
                })?;
            let samples: Vec<([f32; 3], [f32; 3])> = run
                .ticks
                .iter()
                .map(|t| (t.hip.to_array(), t.force.to_array()))
                .collect();
            felt[k] = felt_stiffness(&samples).ok_or(RunError::NotFelt { trial, interval })?;
            let name = format!("trial-{trial:04}-{interval}.csv");
            let path = traces.join(&name);
            File::create(&path)
                .and_then(|file| run.write_csv(file))
                .map_err(|cause| RunError::Write { path, cause })?;
            names.push(format!("traces/{name}"));
        }
        let second_stiffer = participant.stiffer(felt[0], felt[1], &mut noise);
        let chose_comparison = second_stiffer != comparison_first;
        let correct = chose_comparison != side.below;
        interleaved
            .respond(correct)
            .map_err(|cause| RunError::Staircase {
                name: spec.staircases[index].name.clone(),
                cause,
            })?;
        writeln!(
            trials_csv,
            "{label},1,1,{trial},{},{},{},{},{level:?},{reference:?},{},{},{},0,{},{:.3}",
            spec.design.name(),
            csv_field(&spec.stimuli[stimulus].name),
            csv_field(&spec.conditions[condition].name),
            csv_field(&spec.staircases[index].name),
            if comparison_first { 1 } else { 2 },
            if second_stiffer { 2 } else { 1 },
            u8::from(correct),
            csv_field(&names.join(";")),
            (trial - 1) as f64 * 2.0 * interval_s,
        )
        .map_err(write_error)?;
    }
    trials_csv.flush().map_err(write_error)?;

    let staircases = interleaved
        .stairs()
        .iter()
        .zip(&sides)
        .zip(&spec.staircases)
        .map(|((stair, &side), s)| {
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
        .collect();
    Ok(RunSummary {
        trials: trial,
        reference,
        staircases,
    })
}
