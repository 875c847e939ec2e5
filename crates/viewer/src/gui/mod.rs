//! The desktop app (`viewer gui`, and `viewer` alone): egui on eframe's wgpu renderer.
//!
//! Rerun-style: the haptic loop runs on its own thread ([`host::haptic::LoopThread`]) and
//! the UI reads what it sends, never waiting for it; [`state::AppState`] holds everything
//! apart from the drawing, so tests drive it without a window, and the panels below are
//! small functions named by what they show (`*_ui`), each snapshot-tested with
//! `egui_kittest`.

pub mod editing;
pub mod replay;
pub mod spatial;
pub mod state;
pub mod view;
pub mod view3d;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use eframe::egui;
use egui::{Color32, RichText};
use egui_plot::{Corner, Legend, Line, Plot, PlotPoints, Span};
use friction::{FrictionMaterial, Mode, ModelKind, Stribeck};

use host::runlog::Recorder;
use host::trajectory::Trajectory;
use scene::Scene;
use scene::bundled::BUNDLED;
use state::AppState;
use view::{View2d, mode_colour, view_2d_ui};
use view3d::{Camera3d, view_3d_ui};

/// Plot colours of the force lines.
const NORMAL: Color32 = Color32::from_rgb(40, 110, 200);
const FRICTION: Color32 = Color32::from_rgb(200, 90, 40);
const TOTAL: Color32 = Color32::from_rgb(30, 30, 30);

/// Points per plotted series at most (the history is decimated to this).
const PLOT_POINTS: usize = 1000;

/// The UI: the state, the 2-D view's camera and the open-scene field.
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
            shown: None,
        }
    }

    /// The whole window: scenes on top, status at the bottom, materials on the left,
    /// telemetry on the right, the 2-D view in the middle.
    pub fn ui(&mut self, ui: &mut egui::Ui) {
        egui::Panel::top("scenes").show(ui, |ui| scenes_ui(ui, &mut self.state));
        egui::Panel::bottom("status").show(ui, |ui| {
            status_bar_ui(ui, &mut self.state, self.recording.as_deref());
        });
        egui::Panel::left("materials")
            .default_size(250.0)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| {
                    device_ui(ui, &mut self.state);
                    ui.separator();
                    objects_ui(ui, &mut self.state);
                    ui.separator();
                    materials_ui(ui, &mut self.state);
                });
            });
        egui::Panel::right("telemetry")
            .default_size(430.0)
            .show(ui, |ui| telemetry_ui(ui, &self.state));
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
}

/// The device: which one the app drives (the simulator in the app, the emulated board over
/// TCP, a board over USB HID or serial), connect, calibrate, and what the link reports
/// (firmware, calibration, scene, quality, why it was lost).
pub fn device_ui(ui: &mut egui::Ui, state: &mut AppState) {
    use host::devices::Target;
    use state::DeviceChoice;
    ui.heading("Device");
    match &state.device {
        DeviceChoice::Simulated => {
            ui.label("simulated pantograph (in the app)");
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
                connect = Some(None);
            }
            ui.label("in the app, no board");
            ui.end_row();
            let emulated = ui.button("Emulated");
            if emulated.clicked() {
                connect = Some(Some(Target::Tcp(state.device_form.tcp.trim().to_owned())));
            }
            ui.add(egui::TextEdit::singleline(&mut state.device_form.tcp).desired_width(120.0))
                .on_hover_text("HOST:PORT of `cargo xtask qemu --serve HOST:PORT`")
                .labelled_by(emulated.id);
            ui.end_row();
            if ui.button("USB HID").clicked() {
                connect = Some(Some(Target::Hid));
            }
            ui.label("the first board");
            ui.end_row();
            let serial = ui.button("Serial");
            if serial.clicked() {
                connect = Some(Some(Target::Serial(
                    state.device_form.serial.trim().to_owned(),
                )));
            }
            ui.add(egui::TextEdit::singleline(&mut state.device_form.serial).desired_width(120.0))
                .labelled_by(serial.id);
            ui.end_row();
        });
    match connect {
        Some(None) => state.use_simulated(),
        Some(Some(target)) => state.connect(target),
        None => {}
    }
    if let DeviceChoice::Linked(_) = state.device {
        let link = state.link.clone();
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
            state.calibrate();
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
}

/// The scene's objects and their patches (kind, degree, control points, domain); the object
/// felt is marked, and a click on another planar one (2-D) or one with surfaces (3-D) renders
/// that one.
pub fn objects_ui(ui: &mut egui::Ui, state: &mut AppState) {
    use scene::{Patch, Space};
    ui.heading("Objects");
    if let Some(spatial) = state.spatial.as_ref().filter(|s| s.is_opened_mesh()) {
        // The scene model behind a mesh is the idle placeholder: show the mesh alone.
        ui.label(format!(
            "(rendered) mesh {}: {} triangles",
            spatial.view.rendered_name.as_deref().unwrap_or(""),
            spatial.mesh_triangles.unwrap_or(0)
        ));
        return;
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
                let renderable = o.space() == Space::Planar || spatial::can_be_felt(o);
                if renderable && !rendered && ui.button("Render this one").clicked() {
                    render = Some(i);
                }
            });
    }
    if let Some(i) = render {
        state.render_object(i);
    }
}

/// The bundled scenes, one click each, and a path field to open a scene file.
pub fn scenes_ui(ui: &mut egui::Ui, state: &mut AppState) {
    ui.horizontal_wrapped(|ui| {
        ui.label(RichText::new("Scenes").strong());
        for b in BUNDLED {
            let selected = state.scene.label == b.name;
            if ui.selectable_label(selected, b.name).clicked() {
                state.open_bundled(b.name);
            }
        }
        ui.separator();
        ui.label("file:");
        let field = ui.add(
            egui::TextEdit::singleline(&mut state.scene_path)
                .hint_text("path/to/scene.json")
                .desired_width(260.0),
        );
        let enter = field.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
        let path = PathBuf::from(state.scene_path.trim());
        let obj = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("obj"));
        if (ui.button("Open").clicked() || enter) && !state.scene_path.trim().is_empty() {
            if obj {
                state.open_obj(&path);
            } else {
                state.open_path(&path);
            }
        }
        if ui
            .button("Open OBJ…")
            .on_hover_text("open the path as a Wavefront OBJ mesh (the polygonal baseline)")
            .clicked()
            && !state.scene_path.trim().is_empty()
        {
            state.open_obj(&path);
        }
        if ui.button("Save").clicked() && !state.scene_path.trim().is_empty() {
            let path = PathBuf::from(state.scene_path.trim());
            state.save_scene(&path);
        }
        ui.separator();
        ui.label("run log:");
        let field = ui.add(
            egui::TextEdit::singleline(&mut state.replay_path)
                .hint_text("run.csv")
                .desired_width(160.0),
        );
        let enter = field.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
        if (ui.button("Replay").clicked() || enter) && !state.replay_path.trim().is_empty() {
            let path = PathBuf::from(state.replay_path.trim());
            state.open_replay(&path);
        }
    });
    if let Some(e) = &state.scene_error {
        ui.colored_label(Color32::from_rgb(190, 30, 30), e);
    }
    if let Some(e) = &state.replay_error {
        ui.colored_label(Color32::from_rgb(190, 30, 30), e);
    }
    if let Some(m) = &state.scene_saved {
        ui.label(m);
    }
    replay_ui(ui, state);
}

/// The replay's controls: play or pause, the cursor over the log's time, the speed, and
/// back to the live loop.
pub fn replay_ui(ui: &mut egui::Ui, state: &mut AppState) {
    let Some(r) = &state.replay else {
        return;
    };
    let (start, end) = r.span();
    let (mut cursor, mut playing, mut speed) = (r.cursor(), r.playing, r.speed);
    let label = r.label.clone();
    // A log drawn in the other view shows where it can: the log does not name its scene.
    let elsewhere = match (r.space, state.spatial.is_some()) {
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
                for s in replay::SPEEDS {
                    ui.selectable_value(&mut speed, s, format!("{s}×"));
                }
            });
        live = ui.button("Back to live").clicked();
    });
    if live {
        state.close_replay();
        return;
    }
    if let Some(r) = &mut state.replay {
        r.playing = playing;
        r.speed = speed;
    }
    if state.replay.as_ref().is_some_and(|r| r.cursor() != cursor) {
        state.seek_replay(cursor);
    }
}

/// The rendered object's material: stiffness, damping, μs, μd and the Stribeck speed,
/// applied as they are edited; a value the material or the device refuses is named and the
/// running material stays.
pub fn materials_ui(ui: &mut egui::Ui, state: &mut AppState) {
    ui.heading("Material");
    let spatial = state.spatial.as_ref().filter(|s| s.has_loop());
    if let Some(s) = spatial {
        let name = s.view.rendered_name.as_deref().unwrap_or("");
        ui.label(format!("felt by the spatial hand: {name}"));
        if s.render_mesh {
            ui.label("as a mesh: the polygonal baseline renders K·depth and b, no friction");
        }
    } else {
        let Some(index) = state.scene.rendered else {
            ui.label("No object to render.");
            return;
        };
        if let Some(o) = state.scene.objects.get(index) {
            ui.label(format!("object {index}: {}", o.name));
        }
    }
    let m = &mut state.edited_material;
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
    if changed || m.stribeck != stribeck_before || m.model != model_before {
        state.apply_material();
    }
    ui.horizontal(|ui| {
        if ui.button("Revert to running").clicked() {
            state.revert_material();
        }
    });
    if let Some(e) = &state.material_error {
        ui.colored_label(Color32::from_rgb(190, 30, 30), e);
        ui.label("The running material is unchanged.");
    }
    if let Some(r) = state.running_material {
        ui.separator();
        ui.label(RichText::new("Running").strong());
        ui.label(material_text(&r));
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

/// The telemetry: the newest values, the mode switches, and plots of the last
/// [`state::HISTORY_S`] seconds.
pub fn telemetry_ui(ui: &mut egui::Ui, state: &AppState) {
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
    let step = (state.history.len() / PLOT_POINTS).max(1);
    let series = |f: &dyn Fn(&state::AppState, usize) -> f64| -> PlotPoints<'static> {
        state
            .history
            .iter()
            .enumerate()
            .step_by(step)
            .map(|(i, s)| [s.tick.t_s - t_now, f(state, i)])
            .collect()
    };
    let at = |st: &AppState, i: usize| st.history[i].tick;
    let link = egui::Id::unique("telemetry-time");
    let plot = |name: &str, height: f32| {
        Plot::new(name.to_owned())
            .height(height)
            .link_axis(link, egui::Vec2b::new(true, false))
            .allow_scroll(false)
            .allow_zoom(false)
            .allow_drag(false)
            .include_x(-state::HISTORY_S)
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
            Line::new("normal", series(&|s, i| f64::from(at(s, i).normal_force_n))).color(NORMAL),
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

/// The mode bands of the history, in plot time (s before the newest tick).
fn mode_spans(state: &AppState, t_now: f64) -> Vec<(Mode, f64, f64)> {
    let mut spans: Vec<(Mode, f64, f64)> = Vec::new();
    for s in &state.history {
        let t = s.tick.t_s - t_now;
        match spans.last_mut() {
            Some((mode, _, to)) if *mode == s.tick.mode => *to = t,
            _ => spans.push((s.tick.mode, t, t)),
        }
    }
    spans.retain(|(m, _, _)| *m != Mode::Free);
    spans
}

/// Forces on/off, the latched faults and their clear button, the loop's tick rate and
/// jitter, the frame time, the dropped samples, the recording.
pub fn status_bar_ui(ui: &mut egui::Ui, state: &mut AppState, recording: Option<&Path>) {
    ui.horizontal_wrapped(|ui| {
        let mut on = state.forces_requested;
        if ui.checkbox(&mut on, "forces").changed() {
            state.set_forces(on);
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
            state.clear_faults();
        }
        if let Some(f) = state.faults_after_clear
            && !f.is_empty()
            && !faults.is_empty()
        {
            let names: Vec<&str> = f.names().collect();
            ui.label(format!("still present: {}", names.join(", ")));
        }
        ui.separator();
        match state.recent_jitter() {
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
        if let Some((mean, max, ui_ms)) = state.frame_stats() {
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
            self.ui
                .state
                .set_hand_target(nurbs::Vec2::new(p[0] as f32, p[1] as f32));
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
            self.ui.state.record_frame(interval, ui_ms);
            self.intervals.push(interval);
        }
        self.ui_total_ms += f64::from(ui_ms);
        self.frames += 1;
        if self
            .options
            .quit_after_frames
            .is_some_and(|n| self.frames >= n)
        {
            ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
        }
        // The loop ticks on: redraw at about 60 Hz (a display's vsync may slow this).
        ui.ctx().request_repaint_after(Duration::from_millis(15));
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
        let j = &self.ui.state.jitter;
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
            received: self.ui.state.received,
        };
        if let Ok(mut s) = self.summary.lock() {
            *s = summary;
        }
        self.ui.state.shutdown();
    }
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
    let mut state = AppState::new(&label, scene, true, record_tx)?;
    if let Some(path) = &options.mesh {
        state.open_obj(path);
        if let Some(e) = state.scene_error.take() {
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
