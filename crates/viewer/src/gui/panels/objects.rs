//! The objects panel: the scene's objects and their patches, and the *deform* switch.

use eframe::egui;
use egui::Color32;
use scene::{Patch, Space};

use crate::gui::state::AppState;

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
                    let renderable = o.space() == Space::Planar || crate::gui::surface_scene::can_be_felt(o);
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
