//! The participant screen: [`ParticipantUi`] draws a [`ParticipantRun`], and the window
//! that runs it (see the module above).

use std::time::Instant;

use eframe::egui;
use egui::{Align2, Color32, FontId, Key, RichText, Sense, Stroke, Vec2 as EVec2};
use experiment::plan::Plan;
use experiment::session::Response;
use nurbs::Vec2;

use crate::gui::state::{AppState, DeviceChoice};
use crate::gui::view::{View2d, pointer_interval_s};

use super::run::*;

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
    /// Quit was clicked during the run: the top bar asks to confirm.
    confirm_quit: bool,
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
            confirm_quit: false,
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
                        run.feel(s, 0, now);
                    } else if pressed(Key::Num2) {
                        run.feel(s, 1, now);
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
                let paused = self.run.phase() == &Phase::Paused;
                let done = self.run.phase() == &Phase::Done;
                // Quit sits next to Pause: during a run it asks first (the trial in progress
                // is not answered; answered trials are saved and the run resumes from them).
                if self.confirm_quit && !done {
                    if ui.button(big("Keep going".into())).clicked() {
                        self.confirm_quit = false;
                    }
                    if ui.button(big("Quit now".into())).clicked() {
                        quit = true;
                    }
                    ui.label(
                        RichText::new(
                            "Quit? The trial in progress is not saved; answered ones are, \
                             and the run resumes from them.",
                        )
                        .size(16.0)
                        .color(Color32::from_rgb(150, 90, 0)),
                    );
                    return;
                }
                if ui.button(big("Quit".into())).clicked() {
                    if done {
                        quit = true;
                    } else {
                        self.confirm_quit = true;
                    }
                }
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
                                self.run.feel(&mut self.state, k, now);
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
                let over_s = pointer_interval_s(ui, state.dragging);
                state.dragging = true;
                state.glide_hand_to(self.view.device_of(rect, p), over_s);
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
            Phase::Exploring if self.run.awaiting_lift(&self.state) => {
                centre(
                    "Lift the handle out of the shape",
                    Color32::from_rgb(150, 90, 0),
                );
            }
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
/// stimulus with the forces off, driving `device` (the simulated pantograph `spec` in the
/// app when `None`; a device's link set up as `viewer gui --device` sets it up, its forces turned off
/// after the set-up's), so that nothing is felt before the first trial.
pub fn participant_state(
    plan: &Plan,
    device: Option<host::devices::Target>,
    spec: device::spec::DeviceSpec,
) -> anyhow::Result<AppState> {
    use anyhow::Context;
    let scene = plan
        .scene(0)
        .cloned()
        .context("the plan has no scene for its first stimulus")?;
    let mut state = AppState::on(spec, "participant", scene, true, None)?;
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
    spec: device::spec::DeviceSpec,
    interrupt: Option<crate::interrupt::Interrupt>,
) -> anyhow::Result<Outcome> {
    let state = participant_state(run.session().plan(), device, spec)?;
    let outcome = std::sync::Arc::new(std::sync::Mutex::new(Outcome::default()));
    let app = ParticipantApp {
        ui: ParticipantUi::new(state, run),
        outcome: outcome.clone(),
        interrupt: interrupt.clone(),
        repaint: Default::default(),
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
            if let Some(interrupt) = interrupt {
                crate::gui::wake_on_interrupt(interrupt, cc.egui_ctx.clone(), "experiment run")?;
            }
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
    /// Ctrl-C or SIGTERM: the run pauses (the trial in progress is not answered) and the
    /// window closes, as Quit does.
    interrupt: Option<crate::interrupt::Interrupt>,
    /// When to draw again with no input.
    repaint: crate::gui::repaint::Repaint,
}

impl eframe::App for ParticipantApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        self.ui.state.poll();
        let interrupted = self
            .interrupt
            .as_ref()
            .is_some_and(crate::interrupt::Interrupt::requested);
        if self.ui.ui(ui) || interrupted {
            let now = self.ui.now_s();
            self.ui.run.pause(&mut self.ui.state, now);
            ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
        }
        // Full pace while a trial runs (its clock, the stimulus coming on), else the app's.
        let next = if *self.ui.run.phase() == Phase::Exploring {
            crate::gui::repaint::ACTIVE_FRAME
        } else {
            self.repaint.after_frame(&self.ui.state, false)
        };
        ui.ctx().request_repaint_after(next);
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
