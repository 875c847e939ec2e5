//! Editing the scene from the 2-D view: the selection, the drag of a control point, the
//! undo history; the [`AppState`](super::state::AppState) methods the view (and tests) call
//! are `state/editing.rs`'s.
//! Every edit is one of the pure operations of [`scene::edit`] on the scene being rendered,
//! applied through one method,
//! [`AppState::apply_edit`](super::state::AppState::apply_edit)(super::state::AppState::apply_edit), which swaps the edited scene in as opening a scene does
//! (the hand, the arm and the forces' switch stay) but keeps the running material (a material
//! changed in the editor stays) and the view. An edit that fails leaves the running scene and
//! says why in [`EditState::error`]. [`EditState`] is also the edit panel (its [`EditState::ui`]
//! over the 2-D view), whose buttons come back as an [`EditAction`].

use eframe::egui;
use egui::Color32;
use nurbs::Vec2;

use super::scene_view::SceneView;
use scene::edit::{History, PointRef};
use scene::{Patch, Scene};

/// The editing state of the 2-D view, and the edit panel's.
#[derive(Debug, Default)]
pub struct EditState {
    /// Edit mode: control points are handles.
    pub enabled: bool,
    /// Draw the Voronoi region boundaries of the rendered object.
    pub show_regions: bool,
    /// The selected control point.
    pub selected: Option<PointRef>,
    /// A control point being dragged.
    pub drag: Option<PointDrag>,
    /// Undo and redo.
    pub history: History,
    /// Why the last edit was refused (the running scene is unchanged).
    pub error: Option<String>,
    /// What the last edit applied did.
    pub last: Option<String>,
    /// The weight being typed or dragged in the weight field, applied when done.
    pub weight_draft: Option<f64>,
}

/// A control point on its way to a new place: the edit is applied when the drag ends.
#[derive(Debug)]
pub struct PointDrag {
    /// The point.
    pub at: PointRef,
    /// Where it was (m).
    pub from: Vec2,
    /// Where the pointer has it now (m).
    pub to: Vec2,
    /// The scene with the point there and its drawing, or why that scene is invalid.
    pub preview: Result<(Scene, SceneView), String>,
}

impl EditState {
    /// Drops the selection when the point is gone from `scene` (a join removes points).
    pub fn keep_valid_selection(&mut self, scene: &Scene) {
        if self
            .selected
            .is_some_and(|at| control_point(scene, at).is_none())
        {
            self.selected = None;
        }
    }

    /// Forgets the history, the selection and any drag (a new scene was opened).
    pub fn reset(&mut self) {
        self.history.clear();
        self.selected = None;
        self.drag = None;
        self.error = None;
        self.last = None;
        self.weight_draft = None;
    }
}

/// What the edit panel asks ([`AppState::edit_action`](super::state::AppState::edit_action)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EditAction {
    /// Set a control point's weight ([`AppState::set_point_weight`](super::state::AppState::set_point_weight)).
    SetWeight(PointRef, f64),
    /// [`AppState::insert_knot_at_selected`](super::state::AppState::insert_knot_at_selected).
    InsertKnot,
    /// [`AppState::split_at_selected`](super::state::AppState::split_at_selected).
    Split,
    /// [`AppState::join_selected_with_next`](super::state::AppState::join_selected_with_next).
    JoinNext,
    /// [`AppState::undo`](super::state::AppState::undo).
    Undo,
    /// [`AppState::redo`](super::state::AppState::redo).
    Redo,
}

impl EditState {
    /// The edit panel over the 2-D view of `scene`: the selected point (position, weight),
    /// the edit buttons, the history and the last error; what was asked.
    pub fn ui(&mut self, ui: &mut egui::Ui, scene: &Scene) -> Option<EditAction> {
        let mut action = None;
        egui::Frame::group(ui.style())
            .fill(Color32::from_rgba_unmultiplied(255, 255, 255, 235))
            .show(ui, |ui| {
                ui.set_width(280.0);
                ui.label(egui::RichText::new("Edit").strong());
                let selected = self.selected;
                let point = selected.and_then(|at| control_point(scene, at));
                match (selected, point) {
                    (Some(at), Some((p, w))) => {
                        ui.label(format!(
                            "object {}, patch {}, point {}: ({:.2}, {:.2}) mm",
                            at.object,
                            at.patch,
                            at.index,
                            p.x * 1e3,
                            p.y * 1e3
                        ));
                        ui.horizontal(|ui| {
                            let name = ui.label("weight");
                            let draft = self.weight_draft.get_or_insert(f64::from(w));
                            let r = ui
                                .add(
                                    egui::DragValue::new(draft)
                                        .speed(0.01)
                                        .max_decimals(4)
                                        .update_while_editing(false),
                                )
                                .labelled_by(name.id);
                            let done = r.drag_stopped() || (r.changed() && !r.dragged());
                            if done && let Some(weight) = self.weight_draft.take() {
                                action = Some(EditAction::SetWeight(at, weight));
                            }
                        });
                    }
                    _ => {
                        ui.label("press a control point to select it, drag it to move it");
                    }
                }
                ui.horizontal(|ui| {
                    let some = selected.is_some();
                    if ui
                        .add_enabled(some, egui::Button::new("insert knot"))
                        .on_hover_text("at the selected point's parameter (its Greville abscissa)")
                        .clicked()
                    {
                        action = Some(EditAction::InsertKnot);
                    }
                    if ui
                        .add_enabled(some, egui::Button::new("split"))
                        .on_hover_text("the patch in two at the selected point's parameter")
                        .clicked()
                    {
                        action = Some(EditAction::Split);
                    }
                    if ui
                        .add_enabled(some, egui::Button::new("join next"))
                        .on_hover_text("the selected point's patch with the next one")
                        .clicked()
                    {
                        action = Some(EditAction::JoinNext);
                    }
                });
                ui.horizontal(|ui| {
                    let (undo, redo) = self.history.depth();
                    if ui
                        .add_enabled(undo > 0, egui::Button::new(format!("undo ({undo})")))
                        .on_hover_text("Ctrl+Z")
                        .clicked()
                    {
                        action = Some(EditAction::Undo);
                    }
                    if ui
                        .add_enabled(redo > 0, egui::Button::new(format!("redo ({redo})")))
                        .on_hover_text("Ctrl+Shift+Z")
                        .clicked()
                    {
                        action = Some(EditAction::Redo);
                    }
                });
                if let Some(last) = &self.last {
                    ui.label(
                        egui::RichText::new(format!("last: {last}")).color(Color32::from_gray(90)),
                    );
                }
                if let Some(e) = &self.error {
                    ui.colored_label(Color32::from_rgb(190, 30, 30), e);
                }
            });
        action
    }
}

/// Cartesian position and weight of control point `at` of `scene`, when it is one of a planar
/// curve.
pub fn control_point(scene: &Scene, at: PointRef) -> Option<(Vec2, f32)> {
    match scene.object(at.object)?.patch(at.patch)? {
        Patch::Curve2(c) => c.view().control_point(at.index),
        _ => None,
    }
}
