//! The participant's run, apart from its drawing: [`ParticipantRun`] (see the module above).

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use experiment::error::RunError;
use experiment::plan::{Design, Plan};
use experiment::session::{Response, Session, Trial, TrialRecord};
use host::runlog::{Columns, write_csv_header};
use host::tick::Tick;
use scene::Space;

use crate::gui::state::AppState;

/// What the participant is doing.
#[derive(Clone, Debug, PartialEq)]
pub enum Phase {
    /// The stimulus (interval [`ParticipantRun::interval`] of the trial) is there to feel.
    Exploring,
    /// The stimulus is gone; the answer is asked.
    Answering,
    /// After a practice trial's answer: whether it was right.
    Feedback {
        /// Whether the answer was correct.
        correct: bool,
        /// What the screen says: `correct`, or `wrong, it was …`.
        message: String,
    },
    /// Nothing is rendered; the run waits (before its first trial, too).
    Paused,
    /// Every trial of the plan is answered.
    Done,
}

/// A participant's run of a plan, apart from the drawing (module docs).
#[derive(Debug)]
pub struct ParticipantRun {
    session: Session,
    out_dir: PathBuf,
    /// The stimuli's names, in the plan's order.
    names: Vec<String>,
    /// Whether trials have two intervals (2AFC).
    two_interval: bool,
    /// Whether staircases set the trials after the practice (their number is not known).
    staircase: bool,
    /// The comparative of the 2AFC answer: "stiffer", or "more intense".
    comparative: &'static str,
    /// The plan's longest exploration (s).
    exploration_s: Option<f64>,
    trial: Option<Trial>,
    phase: Phase,
    /// The phase a pause returns to; `None` before the first trial (it starts one).
    resume_to: Option<Phase>,
    /// The interval felt (0 or 1).
    interval: usize,
    /// Presentations so far: each scene sent gets its own label.
    presented: u64,
    /// The label of the scene sent last, to know when the loop took it.
    shown_label: String,
    /// Whether the stimulus is on (the loop took the scene, the handle was out of every
    /// object, and the forces are on).
    stimulus_on: bool,
    /// When the current stretch of exploration began, and the exploration before it (s).
    explore_since_s: f64,
    explored_s: f64,
    /// When the answer was asked (s).
    answer_since_s: f64,
    /// When the pause began (s).
    paused_at_s: f64,
    /// When the trial began (s), and the session's clock origin.
    trial_start_s: f64,
    origin_s: Option<f64>,
    /// Each interval's ticks while its stimulus was on.
    traces: Vec<Vec<Tick>>,
    /// The last problem (a scene the loop refused, a file that could not be written), for
    /// the experimenter.
    pub error: Option<String>,
}

/// Writes `ticks` as a run log (the columns of the app's `--record`) to `DIR/traces/NAME`;
/// returns its path relative to `DIR`. Ticks with a value that is not finite are left out, as
/// the recorder does.
pub fn write_trace(dir: &Path, name: &str, ticks: &[Tick]) -> Result<String, RunError> {
    let path = dir.join("traces").join(name);
    let columns = Columns {
        device: true,
        deform: false,
    };
    let written = File::create(&path).and_then(|file| {
        let mut w = BufWriter::new(file);
        write_csv_header(&mut w, Space::Planar, columns)?;
        for k in ticks.iter().filter(|k| k.non_finite_column().is_none()) {
            k.write_csv_row(&mut w, Space::Planar, columns)?;
        }
        w.flush()?;
        w.into_inner()
            .map_err(io::IntoInnerError::into_error)?
            .sync_all()
    });
    written.map_err(|cause| RunError::Write { path, cause })?;
    Ok(format!("traces/{name}"))
}

impl ParticipantRun {
    /// Opens `participant`'s session of `plan` in `out_dir` (a folder holding this run is
    /// resumed at its next trial, see [`Session::open`]); the run starts paused, or done when
    /// the folder holds every trial's answer.
    pub fn open(plan: Plan, participant: &str, out_dir: &Path) -> Result<Self, RunError> {
        let spec = plan.spec();
        let names = spec.stimuli.iter().map(|s| s.name.clone()).collect();
        let two_interval = spec.design.two_interval();
        let staircase = spec.design == Design::TwoAfcStaircase;
        let comparative = match &spec.reference {
            Some(r) if r.field.starts_with("stiffness") => "stiffer",
            _ => "more intense",
        };
        let exploration_s = spec.exploration_time_s;
        let mut session = Session::open(plan, participant, out_dir)?;
        // A folder whose every trial is answered opens done.
        let phase = if session.next_trial()?.is_some() {
            Phase::Paused
        } else {
            Phase::Done
        };
        Ok(ParticipantRun {
            session,
            out_dir: out_dir.to_owned(),
            names,
            two_interval,
            staircase,
            comparative,
            exploration_s,
            trial: None,
            phase,
            resume_to: None,
            interval: 0,
            presented: 0,
            shown_label: String::new(),
            stimulus_on: false,
            explore_since_s: 0.0,
            explored_s: 0.0,
            answer_since_s: 0.0,
            paused_at_s: 0.0,
            trial_start_s: 0.0,
            origin_s: None,
            traces: Vec::new(),
            error: None,
        })
    }

    /// The session (rows answered, planned, resumed).
    pub fn session(&self) -> &Session {
        &self.session
    }

    /// The phase.
    pub fn phase(&self) -> &Phase {
        &self.phase
    }

    /// The trial in progress.
    pub fn trial(&self) -> Option<&Trial> {
        self.trial.as_ref()
    }

    /// The interval felt (0 or 1).
    pub fn interval(&self) -> usize {
        self.interval
    }

    /// Whether trials have two intervals (2AFC).
    pub fn is_two_interval(&self) -> bool {
        self.two_interval
    }

    /// Whether staircases set the trials after the practice (how many is not known).
    pub fn is_staircase(&self) -> bool {
        self.staircase
    }

    /// The comparative of the 2AFC question: "stiffer" (a stiffness plan), or "more intense".
    pub fn comparative(&self) -> &'static str {
        self.comparative
    }

    /// Whether the stimulus is on: the loop took the trial's scene, the handle was out of
    /// every object of it, and the forces are on.
    pub fn stimulus_on(&self) -> bool {
        self.stimulus_on
    }

    /// Whether the trial's stimulus waits for the handle to come out of an object of it
    /// (the screen says "lift the handle"): the loop took the scene, the handle is inside.
    pub fn awaiting_lift(&self, state: &AppState) -> bool {
        self.phase == Phase::Exploring
            && !self.stimulus_on
            && state.scene.label == self.shown_label
            && !handle_clear(state)
    }

    /// Whether a trial was started in this session (the pause screen says "resume").
    pub fn started(&self) -> bool {
        self.origin_s.is_some()
    }

    /// The answers, in the order of their buttons and keys: the stimuli's names
    /// (identification), or "first/second was stiffer" (2AFC).
    pub fn answers(&self) -> Vec<(String, Response)> {
        if self.two_interval {
            ["first", "second"]
                .iter()
                .zip(1u8..)
                .map(|(which, k)| {
                    (
                        format!("{which} was {}", self.comparative),
                        Response::Interval(k),
                    )
                })
                .collect()
        } else {
            self.names
                .iter()
                .enumerate()
                .map(|(i, n)| (n.clone(), Response::Stimulus(i)))
                .collect()
        }
    }

    /// Seconds of exploration left at `now_s` (none without a limit).
    pub fn time_left(&self, now_s: f64) -> Option<f64> {
        let running = if self.phase == Phase::Exploring && self.stimulus_on {
            now_s - self.explore_since_s
        } else {
            0.0
        };
        self.exploration_s
            .map(|t| (t - self.explored_s - running).max(0.0))
    }

    /// The progress line: `Trial 3 of 45`, or for the staircases after the fixed trials
    /// `Trial 12 (staircase: until the staircases end)`.
    pub fn progress(&self) -> String {
        let planned = self.session.planned();
        let n = self
            .trial
            .as_ref()
            .map_or(self.session.answered() + 1, |t| t.number);
        let practice = if self.trial.as_ref().is_some_and(|t| t.practice) {
            "Practice · "
        } else {
            ""
        };
        if n <= planned {
            format!("{practice}Trial {n} of {planned}")
        } else {
            format!("{practice}Trial {n} (staircase: until the staircases end)")
        }
    }

    /// Starts the run, or resumes it after a pause: a paused exploration goes on with the
    /// time it had left, a paused answer is asked again (its response time leaves the pause
    /// out).
    pub fn resume(&mut self, state: &mut AppState, now_s: f64) {
        if self.phase != Phase::Paused {
            return;
        }
        let paused = now_s - self.paused_at_s;
        match self.resume_to.take() {
            None => {
                self.origin_s.get_or_insert(now_s);
                self.next_trial(state, now_s);
            }
            Some(Phase::Exploring) => {
                self.phase = Phase::Exploring;
                self.present(state, self.interval, now_s);
            }
            Some(Phase::Answering) => {
                self.answer_since_s += paused;
                self.phase = Phase::Answering;
            }
            Some(other) => self.phase = other,
        }
    }

    /// Pauses: the stimulus goes (forces off) and the clock of the phase stops.
    pub fn pause(&mut self, state: &mut AppState, now_s: f64) {
        match self.phase {
            Phase::Paused | Phase::Done => return,
            Phase::Exploring | Phase::Answering | Phase::Feedback { .. } => {}
        }
        self.stimulus_off(state, now_s);
        self.resume_to = Some(std::mem::replace(&mut self.phase, Phase::Paused));
        self.paused_at_s = now_s;
    }

    /// Pauses a running run, resumes a paused one.
    pub fn toggle_pause(&mut self, state: &mut AppState, now_s: f64) {
        if self.phase == Phase::Paused {
            self.resume(state, now_s);
        } else {
            self.pause(state, now_s);
        }
    }

    /// Once a frame: takes in the ticks felt, switches the stimulus on once the loop took
    /// its scene and the handle is out of every object of it (the exploration's clock starts
    /// then), and ends the exploration when its time is up.
    pub fn tick(&mut self, state: &mut AppState, now_s: f64) {
        self.collect(state);
        if self.phase != Phase::Exploring {
            return;
        }
        self.tick_scene(state, now_s);
        if self.time_left(now_s).is_some_and(|t| t <= 0.0) {
            self.end_exploration(state, now_s);
        }
    }

    /// Feels interval `interval` (0 or 1) of a 2AFC trial instead of the other.
    pub fn feel(&mut self, state: &mut AppState, interval: usize, now_s: f64) {
        let intervals = self.trial.as_ref().map_or(0, |t| t.intervals.len());
        if self.phase == Phase::Exploring && interval < intervals && interval != self.interval {
            self.present(state, interval, now_s);
        }
    }

    /// Ends the exploration (the participant is ready, or the time is up): the stimulus goes
    /// and the answer is asked; the response time runs from now.
    pub fn end_exploration(&mut self, state: &mut AppState, now_s: f64) {
        if self.phase != Phase::Exploring {
            return;
        }
        self.stimulus_off(state, now_s);
        self.phase = Phase::Answering;
        self.answer_since_s = now_s;
    }

    /// Answers the trial: writes its run logs and its row of `trials.csv`; a practice trial
    /// shows whether it was right, a test trial goes on to the next. Returns whether it was
    /// correct; an answer out of turn or a file that cannot be written is an error (also kept
    /// in [`ParticipantRun::error`]).
    pub fn answer(
        &mut self,
        state: &mut AppState,
        response: Response,
        now_s: f64,
    ) -> Result<bool, RunError> {
        let result = self.try_answer(state, response, now_s);
        if let Err(e) = &result {
            self.error = Some(e.to_string());
        }
        result
    }

    fn try_answer(
        &mut self,
        state: &mut AppState,
        response: Response,
        now_s: f64,
    ) -> Result<bool, RunError> {
        let Some(trial) = self
            .trial
            .clone()
            .filter(|_| self.phase == Phase::Answering)
        else {
            return Err(RunError::Response(
                "an answer is asked only after the exploration".to_owned(),
            ));
        };
        // Checked before anything is written.
        self.session.is_correct(&trial, response)?;
        let mut traces = Vec::new();
        for (k, letter) in (0..trial.intervals.len()).zip(['a', 'b']) {
            let name = format!("trial-{:04}-{letter}.csv", trial.number);
            let ticks = self.traces.get(k).map_or(&[][..], Vec::as_slice);
            traces.push(write_trace(&self.out_dir, &name, ticks)?);
        }
        let record = TrialRecord {
            response_time_s: (now_s - self.answer_since_s).max(0.0),
            traces,
            t_start_s: self.trial_start_s - self.origin_s.unwrap_or(self.trial_start_s),
        };
        let correct = self.session.respond(response, &record)?;
        self.error = None;
        if trial.practice {
            let message = if correct {
                "correct".to_owned()
            } else if let Some(first) = trial.comparison_first {
                let comparison_stronger = trial.level >= trial.reference;
                let first_stronger = first == comparison_stronger;
                format!(
                    "wrong, the {} was {}",
                    if first_stronger { "first" } else { "second" },
                    self.comparative
                )
            } else {
                format!("wrong, it was {}", self.names[trial.stimulus])
            };
            self.phase = Phase::Feedback { correct, message };
        } else {
            self.next_trial(state, now_s);
        }
        Ok(correct)
    }

    /// After a practice trial's feedback: the next trial.
    pub fn next(&mut self, state: &mut AppState, now_s: f64) {
        if matches!(self.phase, Phase::Feedback { .. }) {
            self.next_trial(state, now_s);
        }
    }

    /// Starts the session's next trial (or ends the run).
    fn next_trial(&mut self, state: &mut AppState, now_s: f64) {
        self.stimulus_off(state, now_s);
        match self.session.next_trial() {
            Ok(Some(trial)) => {
                self.traces = vec![Vec::new(); trial.intervals.len()];
                self.trial = Some(trial);
                self.explored_s = 0.0;
                self.trial_start_s = now_s;
                self.phase = Phase::Exploring;
                self.present(state, 0, now_s);
            }
            Ok(None) => {
                self.trial = None;
                self.phase = Phase::Done;
            }
            Err(e) => {
                self.error = Some(e.to_string());
                self.resume_to = None;
                self.paused_at_s = now_s;
                self.phase = Phase::Paused;
            }
        }
    }

    /// Sends interval `k` of the trial to the loop (the app's scene swap, which uploads it
    /// to a connected device); the stimulus comes on once the loop took it and the handle is
    /// out of it ([`ParticipantRun::tick`]).
    fn present(&mut self, state: &mut AppState, k: usize, now_s: f64) {
        self.stimulus_off(state, now_s);
        self.interval = k;
        let Some(trial) = &self.trial else {
            return;
        };
        let Some(scene) = trial.intervals.get(k) else {
            return;
        };
        self.presented += 1;
        // Not shown on the participant's screen; unique, so that its arrival is known.
        let label = format!(
            "trial {} interval {} ({})",
            trial.number,
            k + 1,
            self.presented
        );
        match state.swap(&label, scene.clone(), Some(trial.object), false) {
            Ok(()) => self.shown_label = label,
            Err(e) => self.error = Some(e),
        }
        self.tick_scene(state, now_s);
    }

    /// Switches the stimulus on once the loop took its scene (at once for a stepped loop)
    /// and the handle is out of every object of it: a trial never starts with the handle
    /// pressed into the shape (the previous trial's press), which on a board is a jolt. The
    /// forces then ramp in (the controller's ramp on enabling) and the exploration's clock
    /// runs from now.
    fn tick_scene(&mut self, state: &mut AppState, now_s: f64) {
        if self.phase == Phase::Exploring
            && !self.stimulus_on
            && state.scene.label == self.shown_label
            && handle_clear(state)
        {
            state.set_forces(true);
            state.capture = Some(Vec::new());
            self.stimulus_on = true;
            self.explore_since_s = now_s;
        }
    }

    /// The stimulus goes: forces off, the ticks felt so far kept, the time explored added up.
    fn stimulus_off(&mut self, state: &mut AppState, now_s: f64) {
        if self.stimulus_on && self.phase == Phase::Exploring {
            self.explored_s += now_s - self.explore_since_s;
        }
        self.collect(state);
        state.capture = None;
        if self.stimulus_on || state.forces_requested {
            state.set_forces(false);
        }
        self.stimulus_on = false;
    }

    /// Moves the ticks the UI took in into the interval's trace.
    fn collect(&mut self, state: &mut AppState) {
        if let Some(captured) = state.capture.as_mut() {
            let ticks = std::mem::take(captured);
            if self.stimulus_on
                && let Some(trace) = self.traces.get_mut(self.interval)
            {
                trace.extend(ticks);
            }
        }
    }
}

/// How far out of every object the handle must be for a stimulus to come on (m): a tenth of
/// a millimetre past the surface, five encoder counts of the default device at the handle
/// (19.6 µm each), so that encoder noise at the surface does not count as out.
pub const LIFT_CLEARANCE_M: f32 = 1e-4;

/// Whether the handle (the newest sample's HIP; before any, the hand's target, where the
/// simulated handle starts) is at least [`LIFT_CLEARANCE_M`] out of every planar object of
/// the scene in the loop.
fn handle_clear(state: &AppState) -> bool {
    let hip = state.latest().map_or(state.hand_target, |s| {
        nurbs::Vec2::new(s.tick.hip.x, s.tick.hip.y)
    });
    state
        .scene
        .model
        .objects()
        .iter()
        .all(|o| crate::closest::signed_distance_2d(o, hip).is_none_or(|d| d >= LIFT_CLEARANCE_M))
}
