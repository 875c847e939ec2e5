//! The app's panels, one struct each (egui's demo app, rerun's viewer): a panel holds its own
//! form state (the fields typed, the message of its last action) and draws itself with its
//! `ui` methods from what the app state shares (the running scene, the link, the telemetry).
//! What a panel asks of the loop comes back as an action that [`super::ViewerUi`] hands to
//! the [`AppState`] method that does it, so that tests drive the same methods without a
//! window. The panels that keep no state of their own (objects, telemetry, status bar) are
//! structs all the same, so that every panel is found, drawn and tested the same way.

use std::path::{Path, PathBuf};

use eframe::egui;
use egui::{Color32, RichText};
use egui_plot::{Corner, Legend, Line, Plot, PlotPoints, Span};
use friction::{FrictionMaterial, Mode, ModelKind, Stribeck};
use host::devices::Target;
use scene::bundled::BUNDLED;
use scene::{Patch, Space};

use super::replay::Replay;
use super::spatial::SpatialState;
use super::state::{AppState, DeviceChoice, HISTORY_S, SceneView};
use super::view::mode_colour;

/// Plot colours of the force lines.
const NORMAL: Color32 = Color32::from_rgb(40, 110, 200);
const FRICTION: Color32 = Color32::from_rgb(200, 90, 40);
const TOTAL: Color32 = Color32::from_rgb(30, 30, 30);

/// Points per plotted series at most (the history is decimated to this).
const PLOT_POINTS: usize = 1000;

/// The device panel: which device the app drives (the simulator in the app, the emulated
/// board over TCP, a board over USB HID or serial), and the fields naming a link.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DevicePanel {
    /// The emulated board's address (`cargo xtask qemu --serve HOST:PORT`).
    pub tcp: String,
    /// A board's serial port.
    pub serial: String,
}

impl Default for DevicePanel {
    fn default() -> Self {
        DevicePanel {
            tcp: "127.0.0.1:7878".into(),
            serial: "/dev/ttyACM0".into(),
        }
    }
}

/// What the device panel asks.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum DeviceAction {
    /// Drive the simulated pantograph in the app ([`AppState::use_simulated`]).
    Simulated,
    /// Drive a device behind a link ([`AppState::connect`]).
    Connect(Target),
    /// Who holds the simulated handle ([`AppState::set_hand`]).
    Hand(host::hand::Hand),
}

impl DevicePanel {
    /// The device driven and the choice of another; the one clicked, if one was.
    pub fn choice_ui(
        &mut self,
        ui: &mut egui::Ui,
        device: &DeviceChoice,
        hand: host::hand::Hand,
    ) -> Option<DeviceAction> {
        ui.heading("Device");
        let mut chosen = None;
        match device {
            DeviceChoice::Simulated => {
                ui.label("simulated pantograph (in the app), 10 kHz");
                ui.horizontal(|ui| {
                    ui.label("hand:");
                    for (option, text, hover) in [
                        (
                            host::hand::Hand::Grip,
                            "grip",
                            "a relaxed grip: 300 N/m, 2 N·s/m",
                        ),
                        (
                            host::hand::Hand::Finger,
                            "fingertip",
                            "a light fingertip: 100 N/m, 0.1 N·s/m",
                        ),
                        (
                            host::hand::Hand::Released,
                            "released",
                            "nobody holds the handle: its own mass, the device's friction",
                        ),
                    ] {
                        if ui
                            .selectable_label(hand == option, text)
                            .on_hover_text(hover)
                            .clicked()
                            && hand != option
                        {
                            chosen = Some(DeviceAction::Hand(option));
                        }
                    }
                });
            }
            DeviceChoice::Linked(name) => {
                ui.label(format!("linked: {name}"));
            }
        }
        let mut connect = None;
        egui::Grid::new("device-choice")
            .num_columns(2)
            .show(ui, |ui| {
                if ui.button("Simulated").clicked() {
                    connect = Some(DeviceAction::Simulated);
                }
                ui.label("in the app, no board");
                ui.end_row();
                let emulated = ui.button("Emulated");
                if emulated.clicked() {
                    connect = Some(DeviceAction::Connect(Target::Tcp(
                        self.tcp.trim().to_owned(),
                    )));
                }
                ui.add(egui::TextEdit::singleline(&mut self.tcp).desired_width(120.0))
                    .on_hover_text("HOST:PORT of `cargo xtask qemu --serve HOST:PORT`")
                    .labelled_by(emulated.id);
                ui.end_row();
                if ui.button("USB HID").clicked() {
                    connect = Some(DeviceAction::Connect(Target::Hid));
                }
                ui.label("the first board");
                ui.end_row();
                let serial = ui.button("Serial");
                if serial.clicked() {
                    connect = Some(DeviceAction::Connect(Target::Serial(
                        self.serial.trim().to_owned(),
                    )));
                }
                ui.add(egui::TextEdit::singleline(&mut self.serial).desired_width(120.0))
                    .labelled_by(serial.id);
                ui.end_row();
            });
        connect.or(chosen)
    }

    /// What the link reports (firmware, calibration, scene, quality, why it was lost) and the
    /// Calibrate button; true when it was clicked.
    pub fn link_ui(&self, ui: &mut egui::Ui, state: &AppState) -> bool {
        let mut calibrate = false;
        if let DeviceChoice::Linked(_) = state.device {
            let link = &state.link;
            match &link.hello {
                Some(h) => {
                    let [a, b, c] = h.software;
                    ui.label(format!(
                        "firmware {a}.{b}.{c}, scene capacity {} B{}",
                        h.scene_capacity,
                        if link.simulated_plant {
                            ", simulated arm (the mouse is the hand)"
                        } else {
                            ", real arm (your hand on the handle)"
                        }
                    ));
                }
                None if link.lost.is_none() => {
                    ui.label("connecting…");
                }
                None => {}
            }
            if let Some(s) = link.status {
                ui.label(format!(
                    "{}, forces {}, scene {} B (CRC {:08x})",
                    if s.calibrated {
                        "calibrated"
                    } else {
                        "not calibrated"
                    },
                    if s.forces_enabled { "on" } else { "off" },
                    s.scene_len,
                    s.scene_crc32
                ));
            }
            if let Some((lost, bad, rtt_us)) = state.link_quality() {
                ui.label(format!(
                    "link: {lost} frames lost, {bad} corrupt, heartbeat round trip {:.1} ms",
                    rtt_us as f64 * 1e-3
                ));
            }
            if ui
                .add_enabled(link.lost.is_none(), egui::Button::new("Calibrate"))
                .on_hover_text("a board: hold the handle against its end stops first")
                .clicked()
            {
                calibrate = true;
            }
            if let Some(r) = &link.refused {
                ui.colored_label(Color32::from_rgb(190, 30, 30), r);
            }
            if let Some(reason) = &link.lost {
                ui.colored_label(
                    Color32::from_rgb(190, 30, 30),
                    format!("link lost: {reason}; forces off (the device's watchdog)"),
                );
            }
        }
        calibrate
    }
}

/// The objects panel: the scene's objects and their patches (kind, degree, control points,
/// domain), the object felt marked, and, in a scene with a deformable object, the *deform*
/// switch of the object felt. It keeps no state (egui keeps the headers' open state).
#[derive(Clone, Copy, Debug, Default)]
pub struct ObjectsPanel;

/// What the objects panel asks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ObjectsAction {
    /// Render this object instead ([`AppState::render_object`]).
    Render(usize),
    /// Make the object felt deformable or rigid again ([`AppState::set_deform`]).
    Deform(bool),
}

impl ObjectsPanel {
    /// The objects of `state`'s scene; what was clicked: *Render this one* on another planar
    /// object (2-D) or one with surfaces (3-D), or the *deform* switch.
    pub fn ui(&mut self, ui: &mut egui::Ui, state: &AppState) -> Option<ObjectsAction> {
        ui.heading("Objects");
        if let Some(spatial) = state.spatial.as_ref().filter(|s| s.is_opened_mesh()) {
            // The scene model behind a mesh is the idle placeholder: show the mesh alone.
            ui.label(format!(
                "(rendered) mesh {}: {} triangles",
                spatial.view.rendered_name.as_deref().unwrap_or(""),
                spatial.mesh_triangles.unwrap_or(0)
            ));
            return None;
        }
        let felt = state.felt_object();
        let mut render = None;
        for (i, o) in state.scene.model.objects().iter().enumerate() {
            let rendered = felt == Some(i);
            // The panel is narrow: a long name is cut (the full one is inside).
            let short: String = o.name().chars().take(24).collect();
            let cut = if short.len() < o.name().len() {
                "..."
            } else {
                ""
            };
            let title = format!(
                "{}{i}: {short}{cut}",
                if rendered { "(rendered) " } else { "" }
            );
            egui::CollapsingHeader::new(title)
                .id_salt(("object", i))
                .default_open(false)
                .show(ui, |ui| {
                    ui.label(format!(
                        "{} ({}, {} patches)",
                        o.name(),
                        o.space(),
                        o.patches().len()
                    ));
                    for (j, p) in o.patches().iter().enumerate() {
                        let text = match p {
                            Patch::Curve2(c) => {
                                let (a, b) = c.view().domain();
                                format!(
                                    "patch {j}: planar curve, degree {}, {} points, u in [{a}, {b}]",
                                    c.degree(),
                                    c.points().len()
                                )
                            }
                            Patch::Curve3(c) => format!(
                                "patch {j}: spatial curve, degree {}, {} points",
                                c.degree(),
                                c.points().len()
                            ),
                            Patch::Surface(s) => {
                                let (p, q) = s.degree();
                                let (nu, nv) = s.counts();
                                format!("patch {j}: surface, degree ({p}, {q}), {nu}×{nv} points")
                            }
                        };
                        ui.label(text);
                    }
                    let renderable = o.space() == Space::Planar || super::spatial::can_be_felt(o);
                    if renderable && !rendered && ui.button("Render this one").clicked() {
                        render = Some(ObjectsAction::Render(i));
                    }
                });
        }
        render.or(Self::deform_ui(ui, state))
    }

    /// The *deform* switch, in a scene with a deformable object: enabled when the object felt
    /// is one (its hover text says what it does, with the object's parameters and first
    /// natural frequency), and why it was refused.
    fn deform_ui(ui: &mut egui::Ui, state: &AppState) -> Option<ObjectsAction> {
        let objects = state.scene.model.objects();
        if !objects.iter().any(|o| o.dynamics().is_some()) {
            return None;
        }
        let d = &state.deform;
        let mesh = state.spatial.as_ref().is_some_and(|s| s.render_mesh);
        let mut on = d.requested;
        let switch = ui.add_enabled(
            d.info.is_some() && !mesh,
            egui::Checkbox::new(&mut on, "deform"),
        );
        let switch = match &d.info {
            Some(info) => switch.on_hover_text(info.describe()),
            None => switch,
        };
        let why = if mesh {
            "the hand feels the object's mesh: feel the NURBS surface to deform it".to_owned()
        } else {
            let felt = state
                .felt_object()
                .map_or("no object".to_owned(), |i| format!("object {i}"));
            format!("{felt} is rigid: give it a \"dynamics\" block in the scene file")
        };
        let switch = switch.on_disabled_hover_text(why);
        if let Some(e) = &d.error {
            ui.colored_label(Color32::from_rgb(190, 30, 30), e);
        }
        switch.changed().then_some(ObjectsAction::Deform(on))
    }
}

/// The scene panel: the bundled scenes, one click each, and the path of a scene file (or an
/// OBJ mesh) to open, or to save the running scene to, with the message of the last attempt.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct FilePanel {
    /// The path typed into the file field.
    pub path: String,
    /// Why the last scene could not be opened or saved (the running scene is unchanged).
    pub error: Option<String>,
    /// Where the scene was last saved, as a message.
    pub saved: Option<String>,
}

/// What the scene panel asks.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum FileAction {
    /// Open a bundled scene ([`AppState::open_bundled`]).
    OpenBundled(&'static str),
    /// Open a scene file ([`AppState::open_path`]).
    OpenScene(PathBuf),
    /// Open an OBJ mesh ([`AppState::open_obj`]).
    OpenObj(PathBuf),
    /// Save the running scene ([`AppState::save_scene`]).
    Save(PathBuf),
}

impl FilePanel {
    /// The bundled scenes (`running` selected) and the file field with its buttons, in the
    /// row being laid out; what was clicked.
    pub fn ui(&mut self, ui: &mut egui::Ui, running: &str) -> Option<FileAction> {
        let mut action = None;
        ui.label(RichText::new("Scenes").strong());
        for b in BUNDLED {
            let selected = running == b.name;
            if ui.selectable_label(selected, b.name).clicked() {
                action = Some(FileAction::OpenBundled(b.name));
            }
        }
        ui.separator();
        ui.label("file:");
        let field = ui.add(
            egui::TextEdit::singleline(&mut self.path)
                .hint_text("path/to/scene.json")
                .desired_width(260.0),
        );
        let enter = field.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
        let path = PathBuf::from(self.path.trim());
        let obj = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("obj"));
        if (ui.button("Open").clicked() || enter) && !self.path.trim().is_empty() {
            action = Some(if obj {
                FileAction::OpenObj(path.clone())
            } else {
                FileAction::OpenScene(path.clone())
            });
        }
        if ui
            .button("Open OBJ…")
            .on_hover_text("open the path as a Wavefront OBJ mesh (the polygonal baseline)")
            .clicked()
            && !self.path.trim().is_empty()
        {
            action = Some(FileAction::OpenObj(path.clone()));
        }
        if ui.button("Save").clicked() && !self.path.trim().is_empty() {
            action = Some(FileAction::Save(path));
        }
        action
    }

    /// Why the last scene could not be opened or saved.
    pub fn error_ui(&self, ui: &mut egui::Ui) {
        if let Some(e) = &self.error {
            ui.colored_label(Color32::from_rgb(190, 30, 30), e);
        }
    }

    /// Where the scene was last saved.
    pub fn saved_ui(&self, ui: &mut egui::Ui) {
        if let Some(m) = &self.saved {
            ui.label(m);
        }
    }
}

/// The replay panel: the path of a run log to replay, why the last one could not be, and
/// the controls of the replay.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ReplayPanel {
    /// The path typed into the run-log field.
    pub path: String,
    /// Why the last run log could not be replayed.
    pub error: Option<String>,
}

/// What the replay's controls ask.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ReplayAction {
    /// Back to the live loop ([`AppState::close_replay`]).
    Live,
    /// Play or pause, at this speed, from this cursor ([`AppState::steer_replay`]).
    Steer {
        /// Whether it plays.
        playing: bool,
        /// Speed (× real time).
        speed: f64,
        /// The cursor (s, the log's time).
        cursor_s: f64,
    },
}

impl ReplayPanel {
    /// The run-log field and its button (in the scene panel's row); the path to replay when
    /// asked.
    pub fn open_ui(&mut self, ui: &mut egui::Ui) -> Option<PathBuf> {
        ui.label("run log:");
        let field = ui.add(
            egui::TextEdit::singleline(&mut self.path)
                .hint_text("run.csv")
                .desired_width(160.0),
        );
        let enter = field.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
        ((ui.button("Replay").clicked() || enter) && !self.path.trim().is_empty())
            .then(|| PathBuf::from(self.path.trim()))
    }

    /// Why the last run log could not be replayed.
    pub fn error_ui(&self, ui: &mut egui::Ui) {
        if let Some(e) = &self.error {
            ui.colored_label(Color32::from_rgb(190, 30, 30), e);
        }
    }

    /// The replay's controls: play or pause, the cursor over the log's time, the speed, and
    /// back to the live loop (nothing without a replay). `in_3d`: the 3-D view is shown.
    pub fn controls_ui(
        &mut self,
        ui: &mut egui::Ui,
        replay: Option<&Replay>,
        in_3d: bool,
    ) -> Option<ReplayAction> {
        let r = replay?;
        let (start, end) = r.span();
        let (mut cursor, mut playing, mut speed) = (r.cursor(), r.playing, r.speed);
        let label = r.label.clone();
        // A log drawn in the other view shows where it can: the log does not name its scene.
        let elsewhere = match (r.space, in_3d) {
            (scene::Space::Spatial, false) => Some(
                "a 3-D log in the 2-D view: its x and y only; open its scene of surfaces to see it in 3-D",
            ),
            (scene::Space::Planar, true) => {
                Some("a 2-D log in the 3-D view: in the plane z = 0; open its planar scene")
            }
            _ => None,
        };
        let mut live = false;
        if let Some(note) = elsewhere {
            ui.colored_label(Color32::from_rgb(160, 100, 0), note);
        }
        ui.horizontal_wrapped(|ui| {
            ui.label(RichText::new(format!("replaying {label}")).strong());
            if ui.button(if playing { "Pause" } else { "Play" }).clicked() {
                playing = !playing;
                if playing && cursor >= end {
                    cursor = start;
                }
            }
            ui.add(
                egui::Slider::new(&mut cursor, start..=end)
                    .suffix(" s")
                    .fixed_decimals(3)
                    .text("time"),
            );
            egui::ComboBox::from_label("speed")
                .selected_text(format!("{speed}×"))
                .show_ui(ui, |ui| {
                    for s in super::replay::SPEEDS {
                        ui.selectable_value(&mut speed, s, format!("{s}×"));
                    }
                });
            live = ui.button("Back to live").clicked();
        });
        if live {
            return Some(ReplayAction::Live);
        }
        (playing != r.playing || speed != r.speed || cursor != r.cursor()).then_some(
            ReplayAction::Steer {
                playing,
                speed,
                cursor_s: cursor,
            },
        )
    }
}

/// The material panel: the editor's values for the material of the object felt (stiffness,
/// damping, μs, μd, the Stribeck speed and shape, the friction model), applied as they are
/// edited, and why the last values were refused (the running material stays).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MaterialPanel {
    /// The editor's values.
    pub edited: FrictionMaterial,
    /// Why the edited material was not applied.
    pub error: Option<String>,
}

impl MaterialPanel {
    /// The editor on `running` (the default material when nothing is rendered).
    pub fn new(running: Option<FrictionMaterial>) -> Self {
        MaterialPanel {
            edited: running.unwrap_or_default(),
            error: None,
        }
    }

    /// The object felt and the editor; whether a value changed (to apply), or `None` when
    /// there is no object to render (nothing more to draw).
    pub fn form_ui(
        &mut self,
        ui: &mut egui::Ui,
        scene: &SceneView,
        spatial: Option<&SpatialState>,
    ) -> Option<bool> {
        ui.heading("Material");
        let spatial = spatial.filter(|s| s.has_loop());
        if let Some(s) = spatial {
            let name = s.view.rendered_name.as_deref().unwrap_or("");
            ui.label(format!("felt by the spatial hand: {name}"));
            if s.render_mesh {
                ui.label("as a mesh: the polygonal baseline renders K·depth and b, no friction");
            }
        } else {
            let Some(index) = scene.rendered else {
                ui.label("No object to render.");
                return None;
            };
            if let Some(o) = scene.objects.get(index) {
                ui.label(format!("object {index}: {}", o.name));
            }
        }
        let m = &mut self.edited;
        let (stribeck_before, model_before) = (m.stribeck, m.model);
        let mut changed = false;
        egui::Grid::new("material").num_columns(2).show(ui, |ui| {
            let mut row = |ui: &mut egui::Ui, label: &str, v: &mut f32, speed: f64, unit: &str| {
                let name = ui.label(label);
                changed |= ui
                    .add(
                        egui::DragValue::new(v)
                            .speed(speed)
                            .max_decimals(4)
                            .suffix(unit),
                    )
                    .labelled_by(name.id)
                    .changed();
                ui.end_row();
            };
            row(ui, "stiffness K", &mut m.stiffness_n_per_m, 10.0, " N/m");
            row(ui, "damping b", &mut m.damping_ns_per_m, 0.05, " N·s/m");
            row(ui, "μ static", &mut m.mu_static, 0.01, "");
            row(ui, "μ dynamic", &mut m.mu_dynamic, 0.01, "");
            row(
                ui,
                "Stribeck speed",
                &mut m.stribeck_speed_m_per_s,
                0.001,
                " m/s",
            );
            row(ui, "transition time", &mut m.transition_time_s, 0.001, " s");
            row(ui, "stop speed", &mut m.stop_speed_m_per_s, 0.0001, " m/s");
            let name = ui.label("Stribeck shape");
            let shape = |s: Stribeck| match s {
                Stribeck::Linear => "linear".to_owned(),
                Stribeck::Power { exponent } => format!("power {exponent}"),
                Stribeck::Smoothstep => "smoothstep".to_owned(),
            };
            egui::ComboBox::from_id_salt("stribeck")
                .selected_text(shape(m.stribeck))
                .show_ui(ui, |ui| {
                    ui.selectable_value(&mut m.stribeck, Stribeck::Linear, "linear");
                    let power = match m.stribeck {
                        Stribeck::Power { exponent } => exponent,
                        _ => 2,
                    };
                    ui.selectable_value(
                        &mut m.stribeck,
                        Stribeck::Power { exponent: power },
                        "power n",
                    );
                    ui.selectable_value(&mut m.stribeck, Stribeck::Smoothstep, "smoothstep");
                })
                .response
                .labelled_by(name.id);
            ui.end_row();
            if let Stribeck::Power { exponent } = &mut m.stribeck {
                let name = ui.label("exponent n");
                ui.add(egui::DragValue::new(exponent).range(1..=255))
                    .labelled_by(name.id);
                ui.end_row();
            }
            let name = ui.label("friction model");
            egui::ComboBox::from_id_salt("model")
                .selected_text(model_name(m.model))
                .show_ui(ui, |ui| {
                    for k in [
                        ModelKind::StickSlip,
                        ModelKind::CoulombViscous,
                        ModelKind::Karnopp,
                        ModelKind::Dahl,
                        ModelKind::LuGre,
                    ] {
                        ui.selectable_value(&mut m.model, k, model_name(k));
                    }
                })
                .response
                .labelled_by(name.id);
            ui.end_row();
            match m.model {
                ModelKind::StickSlip => {}
                ModelKind::CoulombViscous => {
                    row(ui, "viscous", &mut m.viscous_ns_per_m, 0.05, " N·s/m");
                }
                ModelKind::Karnopp => {
                    row(ui, "viscous", &mut m.viscous_ns_per_m, 0.05, " N·s/m");
                    row(
                        ui,
                        "stick band",
                        &mut m.karnopp_band_m_per_s,
                        0.0001,
                        " m/s",
                    );
                }
                ModelKind::Dahl | ModelKind::LuGre => {
                    row(
                        ui,
                        "bristle K",
                        &mut m.bristle_stiffness_n_per_m,
                        10.0,
                        " N/m",
                    );
                    row(
                        ui,
                        "bristle b",
                        &mut m.bristle_damping_ns_per_m,
                        0.05,
                        " N·s/m",
                    );
                    row(ui, "viscous", &mut m.viscous_ns_per_m, 0.05, " N·s/m");
                }
            }
        });
        Some(changed || m.stribeck != stribeck_before || m.model != model_before)
    }

    /// The revert button; true when clicked ([`AppState::revert_material`]).
    pub fn revert_ui(&self, ui: &mut egui::Ui) -> bool {
        ui.horizontal(|ui| ui.button("Revert to running").clicked())
            .inner
    }

    /// Why the edited material was refused, and the running one.
    pub fn feedback_ui(&self, ui: &mut egui::Ui, running: Option<FrictionMaterial>) {
        if let Some(e) = &self.error {
            ui.colored_label(Color32::from_rgb(190, 30, 30), e);
            ui.label("The running material is unchanged.");
        }
        if let Some(r) = running {
            ui.separator();
            ui.label(RichText::new("Running").strong());
            ui.label(material_text(&r));
        }
    }
}

/// The scene file's name of a friction model.
fn model_name(k: ModelKind) -> &'static str {
    match k {
        ModelKind::StickSlip => "stick–slip (thesis)",
        ModelKind::CoulombViscous => "Coulomb + viscous",
        ModelKind::Karnopp => "Karnopp",
        ModelKind::Dahl => "Dahl",
        ModelKind::LuGre => "LuGre",
    }
}

fn material_text(m: &FrictionMaterial) -> String {
    let stribeck = match m.stribeck {
        Stribeck::Power { exponent } => format!("power {exponent}"),
        other => format!("{other:?}").to_lowercase(),
    };
    format!(
        "K = {} N/m, b = {} N·s/m\nμs = {}, μd = {}\nStribeck: {stribeck}, v_s = {} m/s\nmodel: {:?}",
        m.stiffness_n_per_m,
        m.damping_ns_per_m,
        m.mu_static,
        m.mu_dynamic,
        m.stribeck_speed_m_per_s,
        m.model
    )
}

/// The telemetry panel: the newest values, the mode switches, and plots of the last
/// [`HISTORY_S`] seconds of the history the app state keeps. It keeps no state.
#[derive(Clone, Copy, Debug, Default)]
pub struct TelemetryPanel;

impl TelemetryPanel {
    /// The telemetry of `state`.
    pub fn ui(&mut self, ui: &mut egui::Ui, state: &AppState) {
        ui.heading("Telemetry");
        let Some(latest) = state.latest() else {
            ui.label("waiting for the loop…");
            return;
        };
        let k = &latest.tick;
        egui::Grid::new("now").num_columns(4).show(ui, |ui| {
            ui.label("mode");
            ui.label(
                RichText::new(k.mode.name())
                    .color(mode_colour(k.mode))
                    .strong(),
            );
            ui.label("switch cause");
            ui.label(k.cause.name());
            ui.end_row();
            ui.label("F_N");
            ui.label(format!("{:.3} N", k.normal_force_n));
            ui.label("F_T");
            ui.label(format!("{:+.3} N", k.friction_force_n));
            ui.end_row();
            ui.label("|F| (device)");
            ui.label(format!("{:.3} N", k.force.length()));
            ui.label("depth");
            ui.label(format!("{:.3} mm", k.depth_m.max(0.0) * 1e3));
            ui.end_row();
            ui.label("μ");
            ui.label(format!("{:.3}", k.mu));
            ui.label("Ψ");
            ui.label(format!("{:.2e}", k.psi));
            ui.end_row();
        });
        let switches: Vec<String> = state
            .telemetry
            .switches
            .iter()
            .rev()
            .take(3)
            .map(|s| {
                format!(
                    "{:.3} s  {} -> {}  ({})",
                    s.t_s,
                    s.from.name(),
                    s.to.name(),
                    s.cause.name()
                )
            })
            .collect();
        if !switches.is_empty() {
            ui.label(RichText::new("last switches").strong());
            for s in switches {
                ui.label(s);
            }
        }

        let t_now = k.t_s;
        let step = (state.telemetry.history.len() / PLOT_POINTS).max(1);
        let series = |f: &dyn Fn(&AppState, usize) -> f64| -> PlotPoints<'static> {
            state
                .telemetry
                .history
                .iter()
                .enumerate()
                .step_by(step)
                .map(|(i, s)| [s.tick.t_s - t_now, f(state, i)])
                .collect()
        };
        let at = |st: &AppState, i: usize| st.telemetry.history[i].tick;
        let link = egui::Id::unique("telemetry-time");
        let plot = |name: &str, height: f32| {
            Plot::new(name.to_owned())
                .height(height)
                .link_axis(link, egui::Vec2b::new(true, false))
                .allow_scroll(false)
                .allow_zoom(false)
                .allow_drag(false)
                .include_x(-HISTORY_S)
                .include_x(0.0)
                .y_axis_min_width(36.0)
                .legend(Legend::default().position(Corner::LeftTop))
        };
        ui.label(RichText::new("forces (N) over the friction mode").strong());
        plot("forces", 150.0).include_y(0.0).show(ui, |p| {
            for (mode, from, to) in mode_spans(state, t_now) {
                p.span(
                    Span::new(mode.name(), from..=to)
                        .fill(mode_colour(mode).gamma_multiply(0.25))
                        .border_width(0.0),
                );
            }
            p.line(
                Line::new("normal", series(&|s, i| f64::from(at(s, i).normal_force_n)))
                    .color(NORMAL),
            );
            p.line(
                Line::new(
                    "friction",
                    series(&|s, i| f64::from(at(s, i).friction_force_n)),
                )
                .color(FRICTION),
            );
            p.line(
                Line::new(
                    "|total|",
                    series(&|s, i| f64::from(at(s, i).force.length())),
                )
                .color(TOTAL),
            );
        });
        ui.label(RichText::new("μ, depth (mm), Ψ").strong());
        plot("mu-depth", 90.0).include_y(0.0).show(ui, |p| {
            p.line(Line::new("μ", series(&|s, i| f64::from(at(s, i).mu))).color(FRICTION));
            p.line(
                Line::new(
                    "depth mm",
                    series(&|s, i| f64::from(at(s, i).depth_m.max(0.0)) * 1e3),
                )
                .color(NORMAL),
            );
        });
        plot("psi", 70.0)
            .y_axis_formatter(|mark, _| format!("{:.0e}", mark.value))
            .y_axis_min_width(44.0)
            .show(ui, |p| {
                p.line(Line::new("Ψ", series(&|s, i| f64::from(at(s, i).psi))).color(TOTAL));
            });
        ui.label(RichText::new("tick period (µs)").strong());
        if state.is_threaded() {
            plot("period", 80.0).include_y(1000.0).show(ui, |p| {
                let points: PlotPoints<'static> = state
                    .telemetry
                    .history
                    .iter()
                    .step_by(step)
                    .filter_map(|s| s.period_us.map(|v| [s.tick.t_s - t_now, f64::from(v)]))
                    .collect();
                p.line(Line::new("period", points).color(TOTAL));
            });
        } else {
            ui.label("stepped loop: no clock, no jitter");
        }
    }
}

/// The mode bands of the history, in plot time (s before the newest tick).
fn mode_spans(state: &AppState, t_now: f64) -> Vec<(Mode, f64, f64)> {
    let mut spans: Vec<(Mode, f64, f64)> = Vec::new();
    for s in &state.telemetry.history {
        let t = s.tick.t_s - t_now;
        match spans.last_mut() {
            Some((mode, _, to)) if *mode == s.tick.mode => *to = t,
            _ => spans.push((s.tick.mode, t, t)),
        }
    }
    spans.retain(|(m, _, _)| *m != Mode::Free);
    spans
}

/// The status bar: forces on/off, the latched faults and their clear button, the loop's tick
/// rate and jitter, the frame time, the dropped samples, the recording. It keeps no state.
#[derive(Clone, Copy, Debug, Default)]
pub struct StatusBar;

/// What the status bar asks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StatusAction {
    /// Forces on or off ([`AppState::set_forces`]).
    Forces(bool),
    /// Clear the latched faults ([`AppState::clear_faults`]).
    ClearFaults,
}

impl StatusBar {
    /// The status of `state`, and where `recording` goes; what was clicked.
    pub fn ui(
        &mut self,
        ui: &mut egui::Ui,
        state: &AppState,
        recording: Option<&Path>,
    ) -> Option<StatusAction> {
        let mut action = None;
        ui.horizontal_wrapped(|ui| {
            let mut on = state.forces_requested;
            if ui.checkbox(&mut on, "forces").changed() {
                action = Some(StatusAction::Forces(on));
            }
            if on && !state.forces_on() {
                ui.label("(off…)");
            }
            if let Some(reason) = &state.link.lost {
                ui.colored_label(
                    Color32::from_rgb(190, 30, 30),
                    format!("link lost ({reason}): forces off"),
                );
            }
            ui.separator();
            let faults = state.faults();
            if faults.is_empty() {
                ui.label("faults: none");
            } else {
                let names: Vec<&str> = faults.names().collect();
                ui.colored_label(
                    Color32::from_rgb(190, 30, 30),
                    format!("faults latched: {} (forces off)", names.join(", ")),
                );
            }
            if ui
                .add_enabled(!faults.is_empty(), egui::Button::new("Clear faults"))
                .clicked()
            {
                action = Some(StatusAction::ClearFaults);
            }
            if let Some(f) = state.faults_after_clear
                && !f.is_empty()
                && !faults.is_empty()
            {
                let names: Vec<&str> = f.names().collect();
                ui.label(format!("still present: {}", names.join(", ")));
            }
            ui.separator();
            match state.telemetry.recent_jitter() {
                Some((mean, max, p99)) => {
                    let priority = if state.loop_realtime() {
                        "real-time"
                    } else {
                        "normal priority"
                    };
                    ui.label(format!(
                        "tick {mean:.1} µs (1 kHz, {priority}): jitter p99 {p99:.0} µs, max {max:.0} µs"
                    ));
                }
                None => {
                    ui.label("tick: stepped (no clock)");
                }
            }
            ui.separator();
            if let Some((mean, max, ui_ms)) = state.telemetry.frame_stats() {
                ui.label(format!(
                    "frame {mean:.1} ms (max {max:.1}), UI {ui_ms:.1} ms"
                ));
                ui.separator();
            }
            let (samples, commands, records) = state.dropped();
            ui.label(format!("dropped: {samples} frames"));
            if commands > 0 {
                ui.label(format!(", {commands} commands"));
            }
            if let Some(path) = recording {
                ui.separator();
                ui.label(format!("recording {} ({records} dropped)", path.display()));
            }
            if !state.loop_running() {
                ui.colored_label(Color32::from_rgb(190, 30, 30), "haptic loop stopped");
            }
            if let Some(e) = state.arm_error() {
                ui.colored_label(Color32::from_rgb(190, 30, 30), e);
            }
            if let Some(e) = &state.loop_refused {
                ui.colored_label(Color32::from_rgb(190, 30, 30), e);
            }
        });
        action
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use egui_kittest::Harness;
    use egui_kittest::kittest::Queryable;

    /// What the scene panel asks when `button` is clicked with `path` typed: the panel does
    /// nothing itself, the app does the action.
    fn file_action(path: &str, button: &str) -> Option<FileAction> {
        let mut panel = FilePanel {
            path: path.into(),
            ..FilePanel::default()
        };
        let mut asked = None;
        {
            let mut h = Harness::new_ui(|ui| {
                ui.horizontal_wrapped(|ui| {
                    if let Some(a) = panel.ui(ui, "thesis-2d") {
                        asked = Some(a);
                    }
                });
            });
            h.get_by_label(button).click();
            h.run();
        }
        assert_eq!(panel.path, path, "the typed path stays");
        asked
    }

    #[test]
    fn the_file_panel_asks_for_what_was_clicked() {
        let scene = PathBuf::from("scenes/mine.json");
        assert_eq!(
            file_action("scenes/mine.json", "Open"),
            Some(FileAction::OpenScene(scene.clone()))
        );
        assert_eq!(
            file_action("scenes/mine.json", "Save"),
            Some(FileAction::Save(scene))
        );
        // A path ending in .obj opens as a mesh, through Open as through Open OBJ….
        let mesh = PathBuf::from("pyramid.OBJ");
        assert_eq!(
            file_action("pyramid.OBJ", "Open"),
            Some(FileAction::OpenObj(mesh.clone()))
        );
        assert_eq!(
            file_action("pyramid.OBJ", "Open OBJ…"),
            Some(FileAction::OpenObj(mesh))
        );
        assert_eq!(
            file_action("", "examples"),
            Some(FileAction::OpenBundled("examples"))
        );
        // No path, nothing to open or save.
        assert_eq!(file_action("  ", "Save"), None);
    }

    /// The replay's controls: Play asks to play from where the cursor is, Back to live asks
    /// to close the replay; without a replay nothing is drawn or asked.
    #[test]
    fn the_replay_controls_ask_to_steer_or_close() {
        let ticks = (0..3)
            .map(|i| host::tick::Tick::idle(f64::from(i) * 1e-3))
            .collect();
        let replay = Replay::of("run.csv".into(), ticks);
        let controls = |button: &str| {
            let mut panel = ReplayPanel::default();
            let mut asked = None;
            {
                let mut h = Harness::new_ui(|ui| {
                    if let Some(a) = panel.controls_ui(ui, Some(&replay), false) {
                        asked = Some(a);
                    }
                });
                h.get_by_label(button).click();
                h.run();
            }
            asked
        };
        assert_eq!(
            controls("Play"),
            Some(ReplayAction::Steer {
                playing: true,
                speed: 1.0,
                cursor_s: 0.0
            })
        );
        assert_eq!(controls("Back to live"), Some(ReplayAction::Live));
        let mut panel = ReplayPanel::default();
        let mut h = Harness::new_ui(|ui| assert_eq!(panel.controls_ui(ui, None, false), None));
        h.run();
    }
}
