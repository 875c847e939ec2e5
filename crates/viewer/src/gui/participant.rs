//! The participant screen of a psychophysics run (thesis §4.3): `viewer experiment run PLAN
//! --participant P01 --out DIR [--device …]` opens the app in this mode.
//!
//! [`ParticipantRun`] is the run's logic, apart from the drawing: an
//! [`experiment::session::Session`] (which writes `DIR/trials.csv` and resumes a folder at its
//! next trial) and the phase of the trial in progress. It loads each trial's scene into the
//! app's haptic loop through [`AppState`]'s own scene swap (the path that uploads to a
//! connected device), switches the stimulus on (forces on) once the loop took it and off
//! (forces off) when the exploration ends, and keeps every tick the UI takes in while the
//! stimulus is on, written at the answer as the trial's run logs `DIR/traces/trial-NNNN-a.csv`
//! (and `-b.csv` for the second interval of a 2AFC trial), in the columns of the app's
//! `--record` run log. Its clock is the caller's (`now_s`, seconds), so tests drive it
//! without a window.
//!
//! [`ParticipantUi`] draws it: the trial's number and progress, the exploration timer, the
//! hand's cursor and nothing of the object (no curve, no contact point, no god-object, no
//! force arrow, no friction-mode colour), and the answer panel.
//!
//! Keys: `1`/`2` feel interval 1 or 2 (2AFC, while exploring); Enter ends the exploration,
//! goes on after a practice trial's feedback, and starts or resumes; `1`…`9` name a stimulus
//! (identification, when answering); `F`/`←` "first", `S`/`→` "second" (2AFC, when
//! answering); `P` pauses and resumes, Esc pauses.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use eframe::egui;
use egui::{Align2, Color32, FontId, Key, RichText, Sense, Stroke, Vec2 as EVec2};
use experiment::error::RunError;
use experiment::plan::{Design, Plan};
use experiment::session::{Response, Session, Trial, TrialRecord};
use host::runlog::{Columns, write_csv_header};
use host::tick::Tick;
use nurbs::Vec2;
use scene::Space;

use super::state::{AppState, DeviceChoice};
use super::view::View2d;

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
    /// Whether the stimulus is on (the loop took the scene and the forces are on).
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

    /// Whether the stimulus is on: the loop took the trial's scene and the forces are on.
    pub fn stimulus_on(&self) -> bool {
        self.stimulus_on
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
        let running = if self.phase == Phase::Exploring {
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
                self.explore_since_s = now_s;
                self.present(state, self.interval);
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
            Phase::Exploring => self.explored_s += now_s - self.explore_since_s,
            Phase::Answering | Phase::Feedback { .. } => {}
        }
        self.stimulus_off(state);
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
    /// its scene, and ends the exploration when its time is up.
    pub fn tick(&mut self, state: &mut AppState, now_s: f64) {
        self.collect(state);
        if self.phase != Phase::Exploring {
            return;
        }
        self.tick_scene(state);
        if self.time_left(now_s).is_some_and(|t| t <= 0.0) {
            self.end_exploration(state, now_s);
        }
    }

    /// Feels interval `interval` (0 or 1) of a 2AFC trial instead of the other.
    pub fn feel(&mut self, state: &mut AppState, interval: usize) {
        let intervals = self.trial.as_ref().map_or(0, |t| t.intervals.len());
        if self.phase == Phase::Exploring && interval < intervals && interval != self.interval {
            self.present(state, interval);
        }
    }

    /// Ends the exploration (the participant is ready, or the time is up): the stimulus goes
    /// and the answer is asked; the response time runs from now.
    pub fn end_exploration(&mut self, state: &mut AppState, now_s: f64) {
        if self.phase != Phase::Exploring {
            return;
        }
        self.explored_s += now_s - self.explore_since_s;
        self.stimulus_off(state);
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
        self.stimulus_off(state);
        match self.session.next_trial() {
            Ok(Some(trial)) => {
                self.traces = vec![Vec::new(); trial.intervals.len()];
                self.trial = Some(trial);
                self.explored_s = 0.0;
                self.explore_since_s = now_s;
                self.trial_start_s = now_s;
                self.phase = Phase::Exploring;
                self.present(state, 0);
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
    /// to a connected device); the stimulus comes on once the loop took it
    /// ([`ParticipantRun::tick`]).
    fn present(&mut self, state: &mut AppState, k: usize) {
        self.stimulus_off(state);
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
        self.tick_scene(state);
    }

    /// Switches the stimulus on at once when the loop already took its scene (a stepped
    /// loop).
    fn tick_scene(&mut self, state: &mut AppState) {
        if self.phase == Phase::Exploring
            && !self.stimulus_on
            && state.scene.label == self.shown_label
        {
            state.set_forces(true);
            state.capture = Some(Vec::new());
            self.stimulus_on = true;
        }
    }

    /// The stimulus goes: forces off, the ticks felt so far kept.
    fn stimulus_off(&mut self, state: &mut AppState) {
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

/// Text of the answer panel: large.
fn big(text: impl Into<String>) -> RichText {
    RichText::new(text).size(20.0)
}

/// The participant's window: the app's state (its haptic loop), the run, and the cursor
/// view's camera.
#[derive(Debug)]
pub struct ParticipantUi {
    /// The app's state.
    pub state: AppState,
    /// The run.
    pub run: ParticipantRun,
    /// The cursor view's camera (fitted to the device's safety box, the same for every
    /// trial: the view says nothing of the object's size).
    pub view: View2d,
    /// The clock's origin.
    started: Instant,
    /// A fixed time (s) instead of the clock (tests).
    pub frozen_s: Option<f64>,
}

impl ParticipantUi {
    /// The window on `state` running `run`.
    pub fn new(state: AppState, run: ParticipantRun) -> Self {
        ParticipantUi {
            state,
            run,
            view: View2d::default(),
            started: Instant::now(),
            frozen_s: None,
        }
    }

    /// Seconds since the window opened (or the frozen time).
    pub fn now_s(&self) -> f64 {
        self.frozen_s
            .unwrap_or_else(|| self.started.elapsed().as_secs_f64())
    }

    /// The whole window: progress, timer and pause on top, the answer panel at the bottom,
    /// the hand's cursor in the middle. Returns true when the participant (or experimenter)
    /// asked to quit.
    pub fn ui(&mut self, ui: &mut egui::Ui) -> bool {
        let now = self.now_s();
        self.run.tick(&mut self.state, now);
        self.keys(ui, now);
        let mut quit = false;
        egui::Panel::top("participant-progress").show(ui, |ui| {
            quit = self.top_ui(ui, now);
        });
        egui::Panel::bottom("participant-answers")
            .min_size(110.0)
            .show(ui, |ui| self.answer_ui(ui, now));
        egui::CentralPanel::no_frame().show(ui, |ui| self.cursor_ui(ui));
        quit
    }

    fn keys(&mut self, ui: &egui::Ui, now: f64) {
        let pressed = |k: Key| ui.input(|i| i.key_pressed(k));
        let (s, run) = (&mut self.state, &mut self.run);
        if pressed(Key::P) {
            run.toggle_pause(s, now);
            return;
        }
        if pressed(Key::Escape) {
            run.pause(s, now);
            return;
        }
        match run.phase().clone() {
            Phase::Exploring => {
                if pressed(Key::Enter) {
                    run.end_exploration(s, now);
                } else if run.is_two_interval() {
                    if pressed(Key::Num1) {
                        run.feel(s, 0);
                    } else if pressed(Key::Num2) {
                        run.feel(s, 1);
                    }
                }
            }
            Phase::Answering => {
                let keyed = if run.is_two_interval() {
                    if pressed(Key::F) || pressed(Key::ArrowLeft) {
                        Some(Response::Interval(1))
                    } else if pressed(Key::S) || pressed(Key::ArrowRight) {
                        Some(Response::Interval(2))
                    } else {
                        None
                    }
                } else {
                    const DIGITS: [Key; 9] = [
                        Key::Num1,
                        Key::Num2,
                        Key::Num3,
                        Key::Num4,
                        Key::Num5,
                        Key::Num6,
                        Key::Num7,
                        Key::Num8,
                        Key::Num9,
                    ];
                    let n = run.answers().len();
                    DIGITS
                        .iter()
                        .take(n)
                        .position(|&k| pressed(k))
                        .map(Response::Stimulus)
                };
                if let Some(r) = keyed {
                    let _ = run.answer(s, r, now);
                }
            }
            Phase::Feedback { .. } => {
                if pressed(Key::Enter) {
                    run.next(s, now);
                }
            }
            Phase::Paused => {
                if pressed(Key::Enter) {
                    run.resume(s, now);
                }
            }
            Phase::Done => {}
        }
    }

    fn top_ui(&mut self, ui: &mut egui::Ui, now: f64) -> bool {
        let mut quit = false;
        ui.horizontal(|ui| {
            let run = &self.run;
            let big = |t: String| RichText::new(t).size(22.0);
            if run.phase() == &Phase::Done {
                ui.label(big("Done".to_owned()));
            } else {
                ui.label(big(run.progress()));
            }
            let planned = run.session().planned().max(1);
            let answered = run.session().answered().min(planned);
            // Past a staircase plan's practice the number of trials left is not known.
            let known = !run.is_staircase() || run.session().answered() < planned;
            ui.add_visible(
                known,
                egui::ProgressBar::new(answered as f32 / planned as f32)
                    .desired_width(200.0)
                    .text(format!("{answered} / {planned} answered")),
            );
            if let Some(left) = run.time_left(now)
                && matches!(run.phase(), Phase::Exploring)
            {
                ui.label(big(format!("Time left: {:.0} s", left.ceil())));
            }
            ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
                if ui.button(big("Quit".into())).clicked() {
                    quit = true;
                }
                let paused = self.run.phase() == &Phase::Paused;
                let done = self.run.phase() == &Phase::Done;
                if !paused
                    && !done
                    && ui
                        .button(big("Pause (P)".into()))
                        .on_hover_text("the stimulus goes until you resume")
                        .clicked()
                {
                    self.run.pause(&mut self.state, now);
                }
            });
        });
        if self.run.session().resumed() > 0 {
            ui.label(format!(
                "Resumed at trial {} (session {}).",
                self.run.session().resumed() + 1,
                self.run.session().number()
            ));
        }
        quit
    }

    fn answer_ui(&mut self, ui: &mut egui::Ui, now: f64) {
        ui.add_space(8.0);
        match self.run.phase().clone() {
            Phase::Exploring => {
                ui.horizontal(|ui| {
                    if self.run.is_two_interval() {
                        for (k, name) in ["Feel interval 1 (1)", "Feel interval 2 (2)"]
                            .iter()
                            .enumerate()
                        {
                            let on = self.run.interval() == k;
                            if ui.selectable_label(on, big(*name)).clicked() {
                                self.run.feel(&mut self.state, k);
                            }
                        }
                        ui.separator();
                    }
                    if ui.button(big("Answer (Enter)")).clicked() {
                        self.run.end_exploration(&mut self.state, now);
                    }
                });
            }
            Phase::Answering => {
                ui.label(big(if self.run.is_two_interval() {
                    format!(
                        "Which was {}? (keys F or Left: first, S or Right: second)",
                        self.run.comparative()
                    )
                } else {
                    "Which was it? (or press its number)".to_owned()
                }));
                ui.horizontal_wrapped(|ui| {
                    for (i, (name, response)) in self.run.answers().into_iter().enumerate() {
                        let text = if self.run.is_two_interval() {
                            name
                        } else {
                            format!("{} {name}", i + 1)
                        };
                        let button = egui::Button::new(big(text)).min_size(EVec2::new(140.0, 44.0));
                        if ui.add(button).clicked() {
                            let _ = self.run.answer(&mut self.state, response, now);
                        }
                    }
                });
            }
            Phase::Feedback { correct, message } => {
                ui.horizontal(|ui| {
                    let colour = if correct {
                        Color32::from_rgb(30, 130, 50)
                    } else {
                        Color32::from_rgb(190, 40, 40)
                    };
                    ui.label(big(message).color(colour));
                    if ui.button(big("Next trial (Enter)")).clicked() {
                        self.run.next(&mut self.state, now);
                    }
                });
            }
            Phase::Paused => {
                ui.horizontal(|ui| {
                    let label = if self.run.started() {
                        "Resume (Enter)"
                    } else {
                        "Start (Enter)"
                    };
                    if ui.button(big(label)).clicked() {
                        self.run.resume(&mut self.state, now);
                    }
                    self.device_ui(ui);
                });
            }
            Phase::Done => {
                ui.label(big(format!(
                    "Done: {} trials. Thank you.",
                    self.run.session().answered()
                )));
            }
        }
        let error = self
            .run
            .error
            .clone()
            .or_else(|| self.state.files.error.clone())
            .or_else(|| self.state.link.lost.clone())
            .or_else(|| self.state.link.refused.clone());
        if let Some(e) = error {
            ui.colored_label(Color32::from_rgb(190, 40, 40), e);
        }
    }

    /// For the experimenter, while paused: the device, its faults, and its calibration.
    fn device_ui(&mut self, ui: &mut egui::Ui) {
        let s = &mut self.state;
        ui.separator();
        match &s.device {
            DeviceChoice::Simulated => {
                ui.label("simulated pantograph: drag with the mouse to move the hand");
            }
            DeviceChoice::Linked(name) => {
                let status = if let Some(lost) = &s.link.lost {
                    lost.clone()
                } else if s.link.hello.is_some() {
                    format!("{name}: connected")
                } else {
                    format!("{name}: connecting...")
                };
                ui.label(status);
                if ui
                    .button("Calibrate")
                    .on_hover_text("hold the handle against its end stops first")
                    .clicked()
                {
                    s.calibrate();
                }
                if ui.button("Clear faults").clicked() {
                    s.clear_faults();
                }
            }
        }
        let faults = s.faults();
        if !faults.is_empty() {
            ui.colored_label(
                Color32::from_rgb(190, 40, 40),
                format!("faults: {faults:?}"),
            );
        }
    }

    /// The view: the hand's cursor only. The simulated pantograph's hand follows a drag.
    fn cursor_ui(&mut self, ui: &mut egui::Ui) {
        let size = ui.available_size();
        let (response, painter) = ui.allocate_painter(size, Sense::click_and_drag());
        let rect = response.rect;
        self.view.last_rect = Some(rect);
        painter.rect_filled(rect, 0.0, Color32::from_gray(250));
        let state = &mut self.state;
        if self.view.fit_pending {
            let b = state.reach.safety_box;
            self.view.fit(
                rect,
                (b.min_in_device, b.max_in_device),
                host::planar::START_HIP,
            );
        }
        let primary_down = ui.input(|i| i.pointer.primary_down());
        if response.is_pointer_button_down_on() && primary_down {
            if let Some(p) = response.interact_pointer_pos() {
                state.dragging = true;
                state.set_hand_target(self.view.device_of(rect, p));
            }
        } else {
            state.dragging = false;
        }
        let painter = painter.with_clip_rect(rect);
        let neutral = Color32::from_rgb(70, 80, 110);
        if state.device == DeviceChoice::Simulated || state.link.simulated_plant {
            let target = self.view.screen_of(rect, state.hand_target);
            let s = Stroke::new(1.5, Color32::from_rgb(150, 150, 200));
            painter.line_segment(
                [target - EVec2::new(6.0, 0.0), target + EVec2::new(6.0, 0.0)],
                s,
            );
            painter.line_segment(
                [target - EVec2::new(0.0, 6.0), target + EVec2::new(0.0, 6.0)],
                s,
            );
        }
        if let Some(sample) = state.latest() {
            let hip = sample.tick.hip;
            let at = self.view.screen_of(rect, Vec2::new(hip.x, hip.y));
            painter.circle_filled(at, 7.0, neutral);
            painter.circle_stroke(at, 7.0, Stroke::new(1.5, Color32::BLACK));
        }
        let centre = |text: &str, colour: Color32| {
            painter.text(
                rect.center() - EVec2::new(0.0, rect.height() * 0.3),
                Align2::CENTER_CENTER,
                text,
                FontId::proportional(28.0),
                colour,
            );
        };
        match self.run.phase() {
            Phase::Exploring if !self.run.stimulus_on() => {
                centre("loading...", Color32::from_gray(120));
            }
            Phase::Exploring if self.run.is_two_interval() => {
                centre(
                    &format!("Interval {}", self.run.interval() + 1),
                    Color32::from_gray(60),
                );
            }
            Phase::Exploring => {}
            Phase::Answering => centre("Answer below", Color32::from_gray(60)),
            Phase::Feedback { .. } => {}
            Phase::Paused if self.run.started() => centre("Paused", Color32::from_gray(60)),
            Phase::Paused => centre("Press Start when you are ready", Color32::from_gray(60)),
            Phase::Done => centre("Thank you.", Color32::from_gray(60)),
        }
    }
}

/// What a participant's window left behind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Outcome {
    /// Rows of `trials.csv` (resumed ones included).
    pub answered: usize,
    /// Whether every trial of the plan is answered.
    pub done: bool,
}

/// The app's state for a participant's window: the loop on its thread on the plan's first
/// stimulus with the forces off, driving `device` (the simulated pantograph in the app when
/// `None`; a device's link set up as `viewer gui --device` sets it up, its forces turned off
/// after the set-up's), so that nothing is felt before the first trial.
pub fn participant_state(
    plan: &Plan,
    device: Option<host::devices::Target>,
) -> anyhow::Result<AppState> {
    use anyhow::Context;
    let scene = plan
        .scene(0)
        .cloned()
        .context("the plan has no scene for its first stimulus")?;
    let mut state = AppState::new("participant", scene, true, None)?;
    state.set_forces(false);
    if let Some(target) = device {
        state.connect(target);
        // After the set-up's forces-on in the link's queue.
        state.set_forces(false);
    }
    Ok(state)
}

/// Opens the participant's window on `run`: the loop on the plan's first stimulus with the
/// forces off, driving `device` (the simulated pantograph in the app when `None`), until the
/// window closes.
pub fn run_window(
    run: ParticipantRun,
    device: Option<host::devices::Target>,
) -> anyhow::Result<Outcome> {
    let state = participant_state(run.session().plan(), device)?;
    let outcome = std::sync::Arc::new(std::sync::Mutex::new(Outcome::default()));
    let app = ParticipantApp {
        ui: ParticipantUi::new(state, run),
        outcome: outcome.clone(),
    };
    let native = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title("Haptics experiment")
            .with_inner_size([1200.0, 800.0]),
        ..Default::default()
    };
    eframe::run_native(
        "nurbs-haptics-participant",
        native,
        Box::new(move |cc| {
            cc.egui_ctx.set_theme(egui::Theme::Light);
            Ok(Box::new(app))
        }),
    )
    .map_err(|e| anyhow::anyhow!("cannot run the window: {e}"))?;
    let outcome = outcome.lock().map(|o| *o).unwrap_or_default();
    Ok(outcome)
}

struct ParticipantApp {
    ui: ParticipantUi,
    outcome: std::sync::Arc<std::sync::Mutex<Outcome>>,
}

impl eframe::App for ParticipantApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        self.ui.state.poll();
        if self.ui.ui(ui) {
            let now = self.ui.now_s();
            self.ui.run.pause(&mut self.ui.state, now);
            ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
        }
        ui.ctx()
            .request_repaint_after(std::time::Duration::from_millis(15));
    }

    fn on_exit(&mut self) {
        let now = self.ui.now_s();
        self.ui.run.pause(&mut self.ui.state, now);
        if let Ok(mut o) = self.outcome.lock() {
            *o = Outcome {
                answered: self.ui.run.session().answered(),
                done: self.ui.run.phase() == &Phase::Done,
            };
        }
        self.ui.state.shutdown();
    }
}
