//! The desktop app (`viewer gui`, and `viewer` alone): egui on eframe's wgpu renderer.
//!
//! Rerun-style: the haptic loop runs on its own thread ([`host::backend::Backend`]) and the
//! UI reads what it sends, never waiting for it; [`state::AppState`] holds everything apart
//! from the drawing, so tests drive it without a window. Each panel is a struct of
//! [`panels`] (egui's demo app) that owns its form state and draws itself; [`ViewerUi`] lays
//! them out and hands what they ask to the state's methods. Each is snapshot-tested with
//! `egui_kittest`. [`participant`] is the other window the app opens: a psychophysics run's
//! participant screen (`viewer experiment run PLAN --participant P01`), on the same state.

pub mod editing;
pub mod moving_shape;
pub mod panels;
pub mod participant;
pub mod reach;
pub mod repaint;
pub mod replay;
pub mod scene_view;
pub mod state;
pub mod surface_scene;
pub mod telemetry;
pub mod view;
pub mod view3d;

use std::path::PathBuf;
use std::time::{Duration, Instant};

use eframe::egui;

use crate::interrupt::Interrupt;
use host::runlog::Recorder;
use host::trajectory::Trajectory;
use panels::{
    DeviceAction, FileAction, ObjectsAction, ObjectsPanel, ReplayAction, StatusAction, StatusBar,
    TelemetryPanel,
};
use scene::Scene;
use scene::bundled::BUNDLED;
use state::AppState;
use view::{View2d, view_2d_ui};
use view3d::{Camera3d, view_3d_ui};

/// The narrowest the telemetry panel gets (px): its plots and the mode grid need this.
pub const TELEMETRY_MIN_PX: f32 = 400.0;

/// The UI: the state (with the panels that hold form state), the panels that hold none, and
/// the views' cameras.
#[derive(Debug)]
pub struct ViewerUi {
    /// The app's state.
    pub state: AppState,
    /// The 2-D view's camera.
    pub view: View2d,
    /// Where `--record` writes, shown in the status bar.
    pub recording: Option<PathBuf>,
    /// The 3-D view's camera.
    pub camera3d: Camera3d,
    /// Whether the 3-D view's wgpu pipelines are installed ([`view3d::install`]).
    pub wgpu_installed: bool,
    /// The objects panel.
    pub objects: ObjectsPanel,
    /// The telemetry panel.
    pub telemetry: TelemetryPanel,
    /// The status bar.
    pub status: StatusBar,
    /// The scene's label, the object felt and whether the 3-D view shows it, as last shown.
    shown: Option<(String, Option<usize>, bool)>,
}

impl ViewerUi {
    /// A UI on `state`.
    pub fn new(state: AppState) -> Self {
        ViewerUi {
            state,
            view: View2d::default(),
            recording: None,
            camera3d: Camera3d::default(),
            wgpu_installed: false,
            objects: ObjectsPanel,
            telemetry: TelemetryPanel,
            status: StatusBar,
            shown: None,
        }
    }

    /// The whole window: scenes on top, status at the bottom, materials on the left,
    /// telemetry on the right, the 2-D view in the middle.
    pub fn ui(&mut self, ui: &mut egui::Ui) {
        egui::Panel::top("scenes").show(ui, |ui| self.scenes_ui(ui));
        egui::Panel::bottom("status").show(ui, |ui| self.status_bar_ui(ui));
        egui::Panel::left("materials")
            .default_size(250.0)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| {
                    self.device_ui(ui);
                    ui.separator();
                    self.objects_ui(ui);
                    ui.separator();
                    self.materials_ui(ui);
                });
            });
        // At least TELEMETRY_MIN_PX wide, whatever it holds: waiting for a loop's first tick
        // (a failed link, back from a replay) it shrank to its one line, ~230 px.
        egui::Panel::right("telemetry")
            .default_size(430.0)
            .min_size(TELEMETRY_MIN_PX)
            .show(ui, |ui| self.telemetry_ui(ui));
        // A new scene, or another object of it felt (which may switch 2-D and 3-D), is shown
        // fitted, on the frame the loop took it.
        let shown = (
            self.state.scene.label.clone(),
            self.state.felt_object(),
            self.state.spatial.is_some(),
        );
        if self.shown.as_ref() != Some(&shown) {
            if self.shown.is_some() {
                self.view.fit_pending = true;
                self.camera3d.fit_pending = true;
            }
            self.shown = Some(shown);
        }
        egui::CentralPanel::no_frame().show(ui, |ui| {
            if self.state.spatial.is_some() {
                view_3d_ui(ui, &mut self.state, &mut self.camera3d, self.wgpu_installed);
            } else {
                view_2d_ui(ui, &mut self.state, &mut self.view);
            }
        });
    }

    /// The device panel: the device driven, the choice of another, what the link reports.
    pub fn device_ui(&mut self, ui: &mut egui::Ui) {
        let s = &mut self.state;
        match s.device_panel.choice_ui(ui, &s.device, s.hand) {
            Some(DeviceAction::Simulated) => s.use_simulated(),
            Some(DeviceAction::Connect(target)) => s.connect(target),
            Some(DeviceAction::Hand(hand)) => s.set_hand(hand),
            None => {}
        }
        if s.device_panel.link_ui(ui, s) {
            s.calibrate();
        }
    }

    /// The objects panel; a click renders another object, or switches *deform*.
    pub fn objects_ui(&mut self, ui: &mut egui::Ui) {
        match self.objects.ui(ui, &self.state) {
            Some(ObjectsAction::Render(i)) => self.state.render_object(i),
            Some(ObjectsAction::Deform(on)) => self.state.set_deform(on),
            None => {}
        }
    }

    /// The material panel; edited values are applied as they change.
    pub fn materials_ui(&mut self, ui: &mut egui::Ui) {
        let s = &mut self.state;
        let Some(changed) = s.materials.form_ui(ui, &s.scene, s.spatial.as_ref()) else {
            return;
        };
        if changed {
            s.apply_material();
        }
        if s.materials.revert_ui(ui) {
            s.revert_material();
        }
        s.materials.feedback_ui(ui, s.running_material);
    }

    /// The top bar: the scene panel and the replay panel's run-log field in one row, their
    /// messages, and the replay's controls.
    pub fn scenes_ui(&mut self, ui: &mut egui::Ui) {
        let s = &mut self.state;
        let (mut file, mut replay) = (None, None);
        ui.horizontal_wrapped(|ui| {
            file = s.files.ui(ui, &s.scene.label);
            ui.separator();
            replay = s.replay_panel.open_ui(ui);
        });
        match file {
            Some(FileAction::OpenBundled(name)) => s.open_bundled(name),
            Some(FileAction::OpenScene(path)) => s.open_path(&path),
            Some(FileAction::OpenObj(path)) => s.open_obj(&path),
            Some(FileAction::Save(path)) => s.save_scene(&path),
            None => {}
        }
        if let Some(path) = replay {
            s.open_replay(&path);
        }
        s.files.error_ui(ui);
        s.replay_panel.error_ui(ui);
        s.files.saved_ui(ui);
        let in_3d = s.spatial.is_some();
        match s.replay_panel.controls_ui(ui, s.replay.as_ref(), in_3d) {
            Some(ReplayAction::Live) => s.close_replay(),
            Some(ReplayAction::Steer {
                playing,
                speed,
                cursor_s,
            }) => s.steer_replay(playing, speed, cursor_s),
            None => {}
        }
    }

    /// The telemetry panel.
    pub fn telemetry_ui(&mut self, ui: &mut egui::Ui) {
        self.telemetry.ui(ui, &self.state);
    }

    /// The status bar; its buttons switch the forces and clear the faults.
    pub fn status_bar_ui(&mut self, ui: &mut egui::Ui) {
        match self.status.ui(ui, &self.state, self.recording.as_deref()) {
            Some(StatusAction::Forces(on)) => self.state.set_forces(on),
            Some(StatusAction::ClearFaults) => self.state.clear_faults(),
            None => {}
        }
    }
}

/// How `viewer gui` starts.
#[derive(Clone, Debug, Default)]
pub struct GuiOptions {
    /// The scene file; the bundled thesis-2d scene when `None`.
    pub scene: Option<PathBuf>,
    /// Record the run log here.
    pub record: Option<PathBuf>,
    /// Close the window by itself after this many frames (tests, CI).
    pub quit_after_frames: Option<u64>,
    /// Move the hand along the thesis's 2-D path, forth and back, as a drag would.
    pub demo: bool,
    /// The device behind a link to drive; the simulated pantograph in the app when `None`.
    pub device: Option<host::devices::Target>,
    /// An OBJ mesh to open instead of the scene.
    pub mesh: Option<PathBuf>,
    /// The simulated pantograph's description (a `device/1` file's, or the default).
    pub spec: device::spec::DeviceSpec,
    /// Close the window when this rises (Ctrl-C or SIGTERM: [`Interrupt::install`]), as if
    /// the user had closed it: the loops stop and the recording is completed.
    pub interrupt: Option<Interrupt>,
}

/// What a session measured, printed when the window closes.
#[derive(Clone, Debug, Default)]
pub struct Summary {
    /// Frames drawn.
    pub frames: u64,
    /// Mean and 95th-percentile frame interval (ms).
    pub frame_ms: Option<(f32, f32)>,
    /// Mean time the app's own UI code took per frame (ms): layout and state, before
    /// tessellation and rendering.
    pub ui_ms: Option<f32>,
    /// Whether the loop thread got real-time scheduling.
    pub realtime: bool,
    /// Mean tick period and 99th-percentile and largest |period − 1 ms| (µs).
    pub tick_us: Option<(f64, f32, f32)>,
    /// Samples dropped on the way to the UI.
    pub dropped: u64,
    /// Ticks run.
    pub received: u64,
}

impl std::fmt::Display for Summary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} frames", self.frames)?;
        if let Some((mean, p95)) = self.frame_ms {
            write!(f, ", frame time mean {mean:.1} ms (p95 {p95:.1} ms)")?;
        }
        if let Some(ui) = self.ui_ms {
            write!(f, ", UI {ui:.1} ms")?;
        }
        if let Some((mean, p99, max)) = self.tick_us {
            write!(
                f,
                "; {} ticks ({} priority), period mean {mean:.1} µs, jitter p99 {p99:.0} µs, \
                 max {max:.0} µs",
                self.received,
                if self.realtime { "real-time" } else { "normal" }
            )?;
        }
        write!(f, "; {} telemetry frames dropped", self.dropped)
    }
}

struct ViewerApp {
    ui: ViewerUi,
    options: GuiOptions,
    demo: Option<Trajectory>,
    started: Instant,
    last_frame: Option<Instant>,
    frames: u64,
    intervals: Vec<f32>,
    ui_total_ms: f64,
    repaint: repaint::Repaint,
    summary: std::sync::Arc<std::sync::Mutex<Summary>>,
}

impl eframe::App for ViewerApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let begun = Instant::now();
        if let Some(demo) = &self.demo {
            // Forth and back along the path, so that the target never jumps (a jump would
            // yank the handle past the device's speed limit and latch a fault).
            let span = demo.end_s() - demo.start_s();
            let phase = self.started.elapsed().as_secs_f64() % (2.0 * span);
            let t = demo.start_s()
                + if phase < span {
                    phase
                } else {
                    2.0 * span - phase
                };
            let p = demo.at(t);
            // Played at the frame's pace, as a drag is (`view::pointer_interval_s`).
            let over_s = self.last_frame.map_or(0.0, |l| {
                (begun - l).as_secs_f32().min(view::MAX_POINTER_INTERVAL_S)
            });
            self.ui
                .state
                .glide_hand_to(nurbs::Vec2::new(p[0] as f32, p[1] as f32), over_s);
        }
        self.ui.state.poll();
        if let Some(last) = self.last_frame {
            self.ui.state.advance_replay((begun - last).as_secs_f64());
        }
        self.ui.ui(ui);
        let interval = self.last_frame.map(|l| (begun - l).as_secs_f32() * 1e3);
        self.last_frame = Some(begun);
        let ui_ms = begun.elapsed().as_secs_f32() * 1e3;
        if let Some(interval) = interval {
            self.ui.state.telemetry.record_frame(interval, ui_ms);
            self.intervals.push(interval);
        }
        self.ui_total_ms += f64::from(ui_ms);
        self.frames += 1;
        if self
            .options
            .quit_after_frames
            .is_some_and(|n| self.frames >= n)
            || self
                .options
                .interrupt
                .as_ref()
                .is_some_and(Interrupt::requested)
        {
            ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
        }
        // The loop ticks on: redraw at the display's pace while something moves, a few
        // times a second while nothing does (`repaint`).
        let next = self
            .repaint
            .after_frame(&self.ui.state, self.demo.is_some());
        ui.ctx().request_repaint_after(next);
    }

    fn on_exit(&mut self) {
        let mut intervals = std::mem::take(&mut self.intervals);
        intervals.sort_by(f32::total_cmp);
        let frame_ms = (!intervals.is_empty()).then(|| {
            let mean = intervals.iter().sum::<f32>() / intervals.len() as f32;
            let p95 = intervals
                [((intervals.len() as f32 * 0.95).ceil() as usize).clamp(1, intervals.len()) - 1];
            (mean, p95)
        });
        let j = &self.ui.state.telemetry.jitter;
        let tick_us = j.mean_period_us().map(|mean| {
            (
                mean,
                j.quantile_us(0.99).unwrap_or(j.max_abs_us),
                j.max_abs_us,
            )
        });
        let summary = Summary {
            frames: self.frames,
            frame_ms,
            ui_ms: (self.frames > 0).then(|| (self.ui_total_ms / self.frames as f64) as f32),
            realtime: self.ui.state.loop_realtime(),
            tick_us,
            dropped: self.ui.state.dropped().0,
            received: self.ui.state.telemetry.received,
        };
        if let Ok(mut s) = self.summary.lock() {
            *s = summary;
        }
        self.ui.state.shutdown();
    }
}

/// A thread that asks `ctx` for a frame as soon as `interrupt` rises: the frame sees the flag
/// and closes the window, even when the app had no reason to draw one.
pub(crate) fn wake_on_interrupt(
    interrupt: Interrupt,
    ctx: egui::Context,
    who: &'static str,
) -> std::io::Result<()> {
    std::thread::Builder::new()
        .name("interrupt".into())
        .spawn(move || {
            while !interrupt.requested() {
                std::thread::sleep(Duration::from_millis(50));
            }
            if let Some(signal) = interrupt.signal_name() {
                eprintln!("{who}: {signal}: closing the window (again to quit at once)");
            }
            ctx.request_repaint();
        })
        .map(drop)
}

/// Runs the app until its window closes; returns what it measured. Errors name what could
/// not be opened (the scene, the record file, the window).
pub fn run(options: GuiOptions) -> anyhow::Result<Summary> {
    use anyhow::Context;
    let (label, scene) = match &options.scene {
        Some(path) => (
            path.display().to_string(),
            Scene::load(path).context("invalid scene")?,
        ),
        None => (
            BUNDLED[0].name.to_owned(),
            Scene::from_json_str(BUNDLED[0].json).context("the bundled thesis-2d scene")?,
        ),
    };
    let (recorder, record_tx) = match &options.record {
        Some(path) => {
            let (r, tx) = Recorder::start(path)
                .with_context(|| format!("cannot create the record file {}", path.display()))?;
            (Some(r), Some(tx))
        }
        None => (None, None),
    };
    let mut state = AppState::on(options.spec, &label, scene, true, record_tx)?;
    if let Some(path) = &options.mesh {
        state.open_obj(path);
        if let Some(e) = state.files.error.take() {
            anyhow::bail!("invalid mesh: {e}");
        }
    }
    if let Some(target) = options.device.clone() {
        state.connect(target);
    }
    let mut ui = ViewerUi::new(state);
    ui.recording = options.record.clone();
    let demo = if options.demo {
        Some(Trajectory::parse(
            scene::bundled::THESIS_2D_PATH_CSV,
            "scenes/thesis-2d.csv",
        )?)
    } else {
        None
    };
    let summary = std::sync::Arc::new(std::sync::Mutex::new(Summary::default()));
    let mut app = ViewerApp {
        ui,
        options: options.clone(),
        demo,
        started: Instant::now(),
        last_frame: None,
        frames: 0,
        intervals: Vec::new(),
        ui_total_ms: 0.0,
        repaint: repaint::Repaint::default(),
        summary: summary.clone(),
    };
    let native = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title("NURBS haptics viewer")
            .with_inner_size([1400.0, 860.0]),
        ..Default::default()
    };
    let result = eframe::run_native(
        "nurbs-haptics-viewer",
        native,
        Box::new(move |cc| {
            if let Some(interrupt) = app.options.interrupt.clone() {
                wake_on_interrupt(interrupt, cc.egui_ctx.clone(), "viewer gui")?;
            }
            cc.egui_ctx.set_theme(egui::Theme::Light);
            if let Some(render_state) = cc.wgpu_render_state.as_ref() {
                view3d::install(render_state);
                app.ui.wgpu_installed = true;
            }
            Ok(Box::new(app))
        }),
    );
    // The app (and the loop, whose sender feeds the recorder) is gone by now.
    let recorded = recorder.map(Recorder::finish).transpose();
    result.map_err(|e| anyhow::anyhow!("cannot run the window: {e}"))?;
    let recorded = recorded.context("the recording")?;
    let summary = summary.lock().map(|s| s.clone()).unwrap_or_default();
    if let (Some(r), Some(path)) = (recorded, &options.record) {
        eprintln!(
            "viewer gui: recorded {} ticks to {}{}{}",
            r.rows,
            path.display(),
            if r.spatial_rows > 0 {
                format!(
                    " and {} ticks of the 3-D view to {}",
                    r.spatial_rows,
                    host::runlog::spatial_log_path(path).display()
                )
            } else {
                String::new()
            },
            if r.skipped > 0 {
                format!(" ({} skipped: not finite)", r.skipped)
            } else {
                String::new()
            }
        );
    }
    Ok(summary)
}
