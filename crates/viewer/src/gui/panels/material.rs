//! The material panel: the editor's values for the material of the object felt.

use eframe::egui;
use egui::{Color32, RichText};
use friction::{FrictionMaterial, ModelKind, Stribeck};

use crate::gui::scene_view::SceneView;
#[cfg(doc)]
use crate::gui::state::AppState;
use crate::gui::surface_scene::SpatialState;

/// The material panel: the editor's values for the material of the object felt (stiffness,
/// damping, μs, μd, the Stribeck speed and shape, the friction model), applied as they are
/// dragged or, typed, on Enter or when the field loses focus; validated before anything is
/// sent, and why the last values were refused (the running material stays, and is shown).
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
                            .suffix(unit)
                            // A typed value applies on Enter or when the field loses
                            // focus, not per keystroke (typing 2000 would run 2, 20, 200).
                            .update_while_editing(false),
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
                ui.add(
                    egui::DragValue::new(exponent)
                        .range(1..=255)
                        .update_while_editing(false),
                )
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
