//! A participant's session of a plan: which trial comes next, what is presented in it, and
//! the row of `trials.csv` its answer makes. The headless runner ([`crate::runner`]) and the
//! app's participant screen both run a plan through it, so both write the same files and
//! a run that was paused or aborted resumes at its next trial.
//!
//! The trial order is a function of the plan's seed and the participant's ID
//! ([`Plan::order_seed`]): reproducible for a participant, different across participants.
//! It is the fixed list of an `identification` or `constant-stimuli` plan
//! ([`Plan::trials_for`]), and for a `2afc-staircase` plan its practice trials followed by the
//! interleaved staircases ([`Interleaved`], seeded by the order seed; each trial's interval
//! order drawn from a stream seeded by it + 1). Resuming replays the rows already in `DIR/trials.csv`
//! through the same rules (each row must be the trial the plan gives at that point, or the
//! folder holds another run and is refused), so the staircases continue where they were.
//!
//! `trials.csv` (RFC 4180, one row per answered trial, written and flushed as each answer
//! comes, so an interrupted session loses at most the trial in progress):
//!
//! | column | meaning |
//! |---|---|
//! | `participant` | the participant's ID (`sim:…` for simulated ones) |
//! | `session` | 1, then one more for each resumption |
//! | `block` | the block (from 1); 0 for practice trials |
//! | `trial` | the trial (from 1, practice included) |
//! | `practice` | 1 for a practice trial (not analysed), else 0 |
//! | `design` | `identification`, `2afc-staircase` or `constant-stimuli` |
//! | `stimulus` | the presented stimulus's name |
//! | `condition` | the condition's name |
//! | `staircase` | the staircase's name (staircase designs) |
//! | `level` | the comparison's value of the reference field (2AFC designs) |
//! | `reference` | the reference value (2AFC designs) |
//! | `comparison_interval` | 1 or 2: the interval that held the comparison (2AFC designs) |
//! | `response` | the answered stimulus's name (identification); 1 or 2, the interval chosen as the more intense (2AFC) |
//! | `correct` | 1 or 0 |
//! | `response_time_s` | from the end of the exploration to the answer (s) |
//! | `trace` | the trial's run logs under `DIR`, `;`-separated (one per interval) |
//! | `t_start_s` | when the trial started, from the session's start (s) |
//!
//! In a 2AFC trial the answer is correct when the participant chose the comparison as more
//! intense and the comparison is at or above the reference, or chose the reference and the
//! comparison is below it.

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use scene::Scene;

use crate::error::RunError;
use crate::plan::{Design, Interval, Plan, StaircaseSpec, StepKind, StopSpec, TrialSpec};
use crate::rng::Prng;
use crate::staircase::{Interleaved, Staircase, StaircaseConfig, Step, Stop};

/// The header of `trials.csv`.
pub const TRIALS_HEADER: &str = "participant,session,block,trial,practice,design,stimulus,\
condition,staircase,level,reference,comparison_interval,response,correct,response_time_s,\
trace,t_start_s";

pub use crate::plan::MAX_TRIALS;

/// One trial to present.
#[derive(Clone, Debug, PartialEq)]
pub struct Trial {
    /// Its number (from 1, practice included): its row in `trials.csv`.
    pub number: usize,
    /// Whether it is a practice trial.
    pub practice: bool,
    /// Its block (from 1); 0 for practice.
    pub block: usize,
    /// Index of the stimulus in the plan.
    pub stimulus: usize,
    /// Index of the condition in the plan.
    pub condition: usize,
    /// The object of the stimulus's scene that is felt.
    pub object: usize,
    /// Index of the staircase in the plan (staircase designs).
    pub staircase: Option<usize>,
    /// The comparison's value (2AFC designs).
    pub level: Option<f64>,
    /// The reference value (2AFC designs).
    pub reference: Option<f64>,
    /// Whether the comparison comes first (2AFC designs).
    pub comparison_first: Option<bool>,
    /// The scenes to present, in order: one for identification, two intervals for 2AFC.
    pub intervals: Vec<Scene>,
}

/// A participant's answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Response {
    /// Identification: the stimulus (index in the plan) the participant named.
    Stimulus(usize),
    /// 2AFC: the interval (1 or 2) the participant chose as the more intense.
    Interval(u8),
}

/// How a trial went, beside its answer.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TrialRecord {
    /// From the end of the exploration to the answer (s).
    pub response_time_s: f64,
    /// The trial's run logs, relative to the session's folder.
    pub traces: Vec<String>,
    /// When the trial started, from the session's start (s).
    pub t_start_s: f64,
}

/// How a plan's staircase runs: on the level itself or mirrored about the reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Side {
    pub(crate) below: bool,
    multiplicative: bool,
    reference: f64,
}

impl Side {
    /// The staircase's value for a level, and back (an involution).
    pub(crate) fn mirror(self, x: f64) -> f64 {
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

/// A plan's staircase, run on the level or mirrored (see [`crate::runner`]'s docs).
pub(crate) fn staircase(
    spec: &StaircaseSpec,
    reference: f64,
) -> Result<(Staircase, Side), RunError> {
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

/// The staircases of a `2afc-staircase` plan.
struct Stairs {
    interleaved: Interleaved,
    sides: Vec<Side>,
    order: Prng,
    /// The staircase trial in progress: (staircase, level).
    pending: Option<(usize, f64, bool)>,
}

/// A participant's session of a plan, writing into a folder.
pub struct Session {
    plan: Plan,
    participant: String,
    session: u32,
    trials_path: PathBuf,
    /// `trials.csv`, open for appending once the folder is made.
    trials_csv: Option<BufWriter<File>>,
    /// The fixed trials (all of them, or a staircase plan's practice).
    list: Vec<TrialSpec>,
    stairs: Option<Stairs>,
    /// Rows written so far (resumed ones included).
    answered: usize,
    /// Rows found when the session opened.
    resumed: usize,
    /// The trial handed out and not yet answered.
    current: Option<Trial>,
}

impl std::fmt::Debug for Session {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Session")
            .field("participant", &self.participant)
            .field("session", &self.session)
            .field("answered", &self.answered)
            .finish_non_exhaustive()
    }
}

fn create_dir(path: &Path) -> Result<(), RunError> {
    fs::create_dir_all(path).map_err(|cause| RunError::CreateDir {
        path: path.to_owned(),
        cause,
    })
}

impl Session {
    /// Opens `participant`'s session of `plan` in `out_dir` (created if missing): a new run
    /// writes `plan.json` and the header of `trials.csv`; a folder that already holds this
    /// plan's run by this participant is resumed at its next trial. A folder holding another
    /// plan's or another participant's run, or rows that are not what the plan gives, is
    /// refused and left as it is.
    pub fn open(plan: Plan, participant: &str, out_dir: &Path) -> Result<Session, RunError> {
        let spec = plan.spec();
        let seed = plan.order_seed(participant);
        let reference = spec.reference.as_ref().map(|r| r.value);
        let stairs = if spec.design == Design::TwoAfcStaircase {
            let reference = reference.ok_or(RunError::NoReference)?;
            let mut list = Vec::new();
            let mut sides = Vec::new();
            for s in &spec.staircases {
                let (stair, side) = staircase(s, reference)?;
                list.push(stair);
                sides.push(side);
            }
            Some(Stairs {
                interleaved: Interleaved::new(list, seed),
                sides,
                order: Prng::new(seed.wrapping_add(1)),
                pending: None,
            })
        } else {
            None
        };
        if spec.design.two_interval() && reference.is_none() {
            return Err(RunError::NoReference);
        }
        let plan_json = plan.to_json_string_resolved()? + "\n";
        let plan_path = out_dir.join("plan.json");
        let trials_path = out_dir.join("trials.csv");
        let previous = match fs::read_to_string(&trials_path) {
            Ok(text) => Some(text),
            Err(e) if e.kind() == io::ErrorKind::NotFound => None,
            Err(cause) => {
                return Err(RunError::Write {
                    path: trials_path,
                    cause,
                });
            }
        };
        if previous.is_some() {
            let found = fs::read_to_string(&plan_path).unwrap_or_default();
            if found != plan_json {
                return Err(RunError::Resume {
                    path: plan_path,
                    line: 0,
                    reason: "the folder holds a run of another plan (its plan.json differs \
                             from this plan as run); give another --out"
                        .to_owned(),
                });
            }
        }
        let list = plan.trials_for(participant)?;
        let mut session = Session {
            session: 1,
            participant: participant.to_owned(),
            trials_csv: None,
            trials_path: trials_path.clone(),
            list,
            stairs,
            answered: 0,
            resumed: 0,
            current: None,
            plan,
        };
        if let Some(text) = &previous {
            session.replay(text)?;
        }
        create_dir(out_dir)?;
        create_dir(&out_dir.join("traces"))?;
        let write_error = |path: &Path| {
            let path = path.to_owned();
            move |cause| RunError::Write { path, cause }
        };
        if previous.is_none() {
            fs::write(&plan_path, &plan_json).map_err(write_error(&plan_path))?;
        }
        let file = OpenOptions::new()
            .create(true)
            .append(true)
            .open(&trials_path)
            .map_err(write_error(&trials_path))?;
        let mut csv = BufWriter::new(file);
        if previous.as_deref().is_none_or(str::is_empty) {
            writeln!(csv, "{TRIALS_HEADER}")
                .and_then(|()| csv.flush())
                .map_err(write_error(&trials_path))?;
        }
        session.trials_csv = Some(csv);
        Ok(session)
    }

    /// Replays the rows of a previous session.
    fn replay(&mut self, text: &str) -> Result<(), RunError> {
        let path = self.trials_path.clone();
        let refuse = |line: usize, reason: String| RunError::Resume {
            path: path.clone(),
            line,
            reason,
        };
        let records = crate::csv::records(text).map_err(|e| refuse(e.line, e.message))?;
        let mut rows = records.iter();
        match rows.next() {
            Some(header) if header.fields.join(",") == TRIALS_HEADER => {}
            None => return Ok(()),
            Some(header) => {
                return Err(refuse(
                    header.line,
                    format!("the header is not {TRIALS_HEADER:?}"),
                ));
            }
        }
        let column = |name: &str| TRIALS_HEADER.split(',').position(|c| c == name);
        let [
            c_participant,
            c_session,
            c_trial,
            c_stimulus,
            c_condition,
            c_level,
            c_correct,
        ] = [
            "participant",
            "session",
            "trial",
            "stimulus",
            "condition",
            "level",
            "correct",
        ]
        .map(|c| column(c).unwrap_or(0));
        for record in rows {
            let n = record.line;
            let fields = &record.fields;
            if fields.len() != TRIALS_HEADER.split(',').count() {
                return Err(refuse(n, "not a complete row of trials.csv".to_owned()));
            }
            if fields[c_participant] != self.participant {
                return Err(refuse(
                    n,
                    format!(
                        "the folder holds participant {:?}'s run, not {:?}'s",
                        fields[c_participant], self.participant
                    ),
                ));
            }
            let trial = self
                .next_trial()?
                .ok_or_else(|| refuse(n, "the plan has no more trials".to_owned()))?;
            let spec = self.plan.spec();
            let expected_level = trial.level.map(|l| format!("{l:?}")).unwrap_or_default();
            if fields[c_trial] != trial.number.to_string()
                || fields[c_stimulus] != spec.stimuli[trial.stimulus].name
                || fields[c_condition] != spec.conditions[trial.condition].name
                || fields[c_level] != expected_level
            {
                return Err(refuse(
                    n,
                    format!(
                        "the row is not the plan's trial {} (stimulus {:?}, condition {:?}, \
                         level {expected_level:?})",
                        trial.number,
                        spec.stimuli[trial.stimulus].name,
                        spec.conditions[trial.condition].name
                    ),
                ));
            }
            let correct = match fields[c_correct].as_str() {
                "1" => true,
                "0" => false,
                other => return Err(refuse(n, format!("correct = {other:?} is not 0 or 1"))),
            };
            let session: u32 = fields[c_session]
                .parse()
                .map_err(|_| refuse(n, format!("session = {:?}", fields[c_session])))?;
            self.session = self.session.max(session.saturating_add(1));
            self.advance(correct)?;
            self.resumed += 1;
        }
        Ok(())
    }

    /// The plan.
    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// The session number (1, then one more for each resumption).
    pub fn number(&self) -> u32 {
        self.session
    }

    /// Rows answered so far, resumed ones included.
    pub fn answered(&self) -> usize {
        self.answered
    }

    /// Rows found in the folder when the session opened.
    pub fn resumed(&self) -> usize {
        self.resumed
    }

    /// The trials of the fixed list (practice and, except for staircases, every trial): how
    /// far a progress bar goes.
    pub fn planned(&self) -> usize {
        self.list.len()
    }

    /// The staircases and how each runs (staircase designs).
    pub(crate) fn stairs(&self) -> Option<(&[Staircase], &[Side])> {
        self.stairs
            .as_ref()
            .map(|s| (s.interleaved.stairs(), s.sides.as_slice()))
    }

    /// The next trial, or `None` when the plan is done; the same trial again until it is
    /// answered.
    pub fn next_trial(&mut self) -> Result<Option<Trial>, RunError> {
        if let Some(t) = &self.current {
            return Ok(Some(t.clone()));
        }
        if self.answered >= MAX_TRIALS {
            return Err(RunError::TooManyTrials(self.answered));
        }
        let spec = self.plan.spec();
        let reference = spec.reference.as_ref().map(|r| r.value);
        let number = self.answered + 1;
        let (staircase, level, comparison_first, practice, block, stimulus, condition) =
            if let Some(t) = self.list.get(self.answered) {
                let level = match (t.level, &self.stairs) {
                    (Some(l), _) => Some(l),
                    // A staircase plan's practice runs at the first staircase's start.
                    (None, Some(_)) => spec.staircases.first().map(|s| s.start),
                    (None, None) => None,
                };
                (
                    None,
                    level,
                    t.comparison_interval.map(|i| i == Interval::First),
                    t.practice,
                    t.block.map_or(0, |b| b + 1),
                    t.stimulus,
                    t.condition,
                )
            } else if let Some(stairs) = &mut self.stairs {
                let Some((index, value)) = stairs.interleaved.next_trial() else {
                    return Ok(None);
                };
                let level = stairs.sides[index].mirror(value);
                let first = stairs.order.bernoulli(0.5);
                stairs.pending = Some((index, level, first));
                (Some(index), Some(level), Some(first), false, 1, 0, 0)
            } else {
                return Ok(None);
            };
        let base = self.plan.scene(stimulus).ok_or_else(|| {
            RunError::Unsupported(format!("the plan has no scene for stimulus {stimulus}"))
        })?;
        let object = spec.stimuli[stimulus].object;
        let scene_at = |level: Option<f64>| -> Result<Scene, RunError> {
            let material = self.plan.material(stimulus, condition, level)?;
            base.with_material(object, material)
                .map_err(|cause| RunError::Scene {
                    level: level.unwrap_or(f64::NAN),
                    cause,
                })
        };
        let intervals = match comparison_first {
            Some(first) => {
                let comparison = scene_at(level)?;
                let reference_scene = scene_at(reference)?;
                if first {
                    vec![comparison, reference_scene]
                } else {
                    vec![reference_scene, comparison]
                }
            }
            None => vec![scene_at(None)?],
        };
        let trial = Trial {
            number,
            practice,
            block,
            stimulus,
            condition,
            object,
            staircase,
            level,
            reference: if comparison_first.is_some() {
                reference
            } else {
                None
            },
            comparison_first,
            intervals,
        };
        self.current = Some(trial.clone());
        Ok(Some(trial))
    }

    /// Whether `response` to `trial` is correct (module docs).
    pub fn is_correct(&self, trial: &Trial, response: Response) -> Result<bool, RunError> {
        match (
            response,
            trial.comparison_first,
            trial.level,
            trial.reference,
        ) {
            (Response::Stimulus(s), None, ..) if s < self.plan.spec().stimuli.len() => {
                Ok(s == trial.stimulus)
            }
            (Response::Interval(k @ (1 | 2)), Some(first), Some(level), Some(reference)) => {
                let chose_comparison = (k == 1) == first;
                Ok(chose_comparison == (level >= reference))
            }
            _ => Err(RunError::Response(format!(
                "{response:?} is not an answer to trial {} of a {} plan",
                trial.number,
                self.plan.spec().design.name()
            ))),
        }
    }

    /// Records the answer to the trial in progress (the one [`Session::next_trial`] gave):
    /// writes and flushes its row, moves the staircase on; returns whether it was correct.
    pub fn respond(&mut self, response: Response, record: &TrialRecord) -> Result<bool, RunError> {
        let trial = self
            .current
            .clone()
            .ok_or_else(|| RunError::Response("no trial is in progress".to_owned()))?;
        let correct = self.is_correct(&trial, response)?;
        let spec = self.plan.spec();
        let number = |x: Option<f64>| x.map(|v| format!("{v:?}")).unwrap_or_default();
        let answer = match response {
            Response::Stimulus(s) => crate::csv::field(&spec.stimuli[s].name),
            Response::Interval(k) => k.to_string(),
        };
        let row = format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{answer},{},{:.3},{},{:.3}",
            crate::csv::field(&self.participant),
            self.session,
            trial.block,
            trial.number,
            u8::from(trial.practice),
            spec.design.name(),
            crate::csv::field(&spec.stimuli[trial.stimulus].name),
            crate::csv::field(&spec.conditions[trial.condition].name),
            trial
                .staircase
                .map(|s| crate::csv::field(&spec.staircases[s].name))
                .unwrap_or_default(),
            number(trial.level),
            number(trial.reference),
            trial
                .comparison_first
                .map(|f| if f { "1" } else { "2" })
                .unwrap_or_default(),
            u8::from(correct),
            record.response_time_s,
            crate::csv::field(&record.traces.join(";")),
            record.t_start_s,
        );
        let path = self.trials_path.clone();
        let csv = self.trials_csv.as_mut().ok_or_else(|| RunError::Write {
            path: path.clone(),
            cause: io::Error::other("the session's trials.csv is not open"),
        })?;
        writeln!(csv, "{row}")
            .and_then(|()| csv.flush())
            .map_err(|cause| RunError::Write { path, cause })?;
        self.advance(correct)?;
        Ok(correct)
    }

    /// Moves past the trial in progress, answered `correct`.
    fn advance(&mut self, correct: bool) -> Result<(), RunError> {
        self.current = None;
        if self.answered >= self.list.len()
            && let Some(stairs) = &mut self.stairs
            && let Some((index, _, _)) = stairs.pending.take()
        {
            let name = self.plan.spec().staircases[index].name.clone();
            stairs
                .interleaved
                .respond(correct)
                .map_err(|cause| RunError::Staircase { name, cause })?;
        }
        self.answered += 1;
        Ok(())
    }
}
