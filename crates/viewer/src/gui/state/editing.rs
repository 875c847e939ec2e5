//! [`AppState`]'s edit operations: what the edit panel asks (an [`EditAction`]), the
//! control-point drags, undo and redo, each applied through [`AppState::apply_edit`].

use super::*;
use crate::gui::editing::{EditAction, PointDrag, control_point};
use crate::gui::scene_view::SceneView;
use nurbs::Vec2;
use scene::edit::{self, EditError, PointRef};
use scene::{Material, Patch, Scene};

impl AppState {
    /// Does what the edit panel asked; whether an edit was applied.
    pub fn edit_action(&mut self, action: EditAction) -> bool {
        match action {
            EditAction::SetWeight(at, weight) => self.set_point_weight(at, weight),
            EditAction::InsertKnot => self.insert_knot_at_selected(),
            EditAction::Split => self.split_at_selected(),
            EditAction::JoinNext => self.join_selected_with_next(),
            EditAction::Undo => self.undo(),
            EditAction::Redo => self.redo(),
        }
    }

    /// Renders `scene`, the result of an edit labelled `label`, from the next tick, and records
    /// the scene before it for undo. The running material is kept (written into the edited
    /// object when the editor changed it), the view is not refitted. When the device refuses
    /// the scene the running one stays and [`EditState::error`] says why (returns false).
    pub fn apply_edit(&mut self, scene: Scene, label: &str) -> bool {
        let before = self.scene.model.clone();
        if !self.swap_edited(scene, label) {
            return false;
        }
        self.edit.history.push(before, label);
        true
    }

    /// [`AppState::apply_edit`] of an edit's result; an edit that failed is shown as the
    /// error, the running scene unchanged.
    pub fn apply_edit_result(&mut self, result: Result<Scene, EditError>, label: &str) -> bool {
        match result {
            Ok(scene) => self.apply_edit(scene, label),
            Err(e) => {
                self.edit.error = Some(format!("{label}: {e}; the running scene is unchanged"));
                false
            }
        }
    }

    fn swap_edited(&mut self, scene: Scene, label: &str) -> bool {
        let scene = match self.with_running_material(scene) {
            Ok(s) => s,
            Err(e) => {
                self.edit.error = Some(format!("{label}: {e}; the running scene is unchanged"));
                return false;
            }
        };
        let (object, running) = (self.scene.rendered, self.scene.label.clone());
        if let Err(e) = self.swap(&running, scene, object, true) {
            self.edit.error = Some(e.replacen(&running, label, 1));
            return false;
        }
        self.edit.error = None;
        self.edit.last = Some(label.to_owned());
        self.edit.weight_draft = None;
        true
    }

    /// `scene` with the rendered object's material set to the running one, when the material
    /// editor changed it: an edit of the geometry does not revert the material.
    fn with_running_material(&self, scene: Scene) -> Result<Scene, String> {
        let (Some(i), Some(running)) = (self.scene.rendered, self.running_material) else {
            return Ok(scene);
        };
        match scene.object(i) {
            Some(o) if o.material().friction_material() != running => {
                let m = Material::from_friction(running).map_err(|e| e.to_string())?;
                edit::set_material(&scene, i, m).map_err(|e| e.to_string())
            }
            _ => Ok(scene),
        }
    }

    /// Undoes the last edit; false when there is none or the device refuses the scene.
    pub fn undo(&mut self) -> bool {
        let Some(entry) = self.edit.history.next_undo().cloned() else {
            return false;
        };
        let current = self.scene.model.clone();
        if !self.swap_edited(entry.scene, &format!("undo {}", entry.label)) {
            return false;
        }
        self.edit.history.undo(current);
        true
    }

    /// Redoes the last undone edit; false when there is none or the device refuses it.
    pub fn redo(&mut self) -> bool {
        let Some(entry) = self.edit.history.next_redo().cloned() else {
            return false;
        };
        let before = self.scene.model.clone();
        if !self.swap_edited(entry.scene, &format!("redo {}", entry.label)) {
            return false;
        }
        self.edit.history.redo(before);
        true
    }

    /// Selects a control point (or none).
    pub fn select_point(&mut self, at: Option<PointRef>) {
        self.edit.selected = at.filter(|&at| control_point(&self.scene.model, at).is_some());
        self.edit.weight_draft = None;
    }

    /// Position and weight of the selected control point.
    pub fn selected_point(&self) -> Option<(Vec2, f32)> {
        self.edit
            .selected
            .and_then(|at| control_point(&self.scene.model, at))
    }

    /// The control point of a planar curve nearest to `p` within `radius_m`, the selected one
    /// first and the rendered object's before the others when several are as near.
    pub fn handle_near(&self, p: Vec2, radius_m: f32) -> Option<PointRef> {
        let mut best: Option<(f32, PointRef)> = None;
        for (i, o) in self.scene.model.objects().iter().enumerate() {
            for (k, patch) in o.patches().iter().enumerate() {
                let Patch::Curve2(c) = patch else { continue };
                for j in 0..c.points().len() {
                    let at = PointRef::new(i, k, j);
                    let Some((q, _)) = c.view().control_point(j) else {
                        continue;
                    };
                    let d = (q - p).length();
                    let rank = if Some(at) == self.edit.selected {
                        0.0
                    } else if Some(i) == self.scene.rendered {
                        1e-9
                    } else {
                        2e-9
                    };
                    if d <= radius_m && best.is_none_or(|(b, _)| d + rank < b) {
                        best = Some((d + rank, at));
                    }
                }
            }
        }
        best.map(|(_, at)| at)
    }

    /// Starts dragging control point `at` (and selects it).
    pub fn begin_point_drag(&mut self, at: PointRef) {
        self.select_point(Some(at));
        let Some((from, _)) = control_point(&self.scene.model, at) else {
            return;
        };
        self.edit.drag = Some(PointDrag {
            at,
            from,
            to: from,
            preview: Ok((self.scene.model.clone(), self.scene.clone())),
        });
    }

    /// Moves the dragged control point to `to` (m): the preview only; the edit is applied when
    /// the drag ends.
    pub fn drag_point_to(&mut self, to: Vec2) {
        let Some(drag) = &mut self.edit.drag else {
            return;
        };
        if drag.to == to {
            return;
        }
        drag.to = to;
        drag.preview = edit::move_point(&self.scene.model, drag.at, to)
            .map(|s| {
                let v = SceneView::new(&self.scene.label, &s, self.scene.rendered);
                (s, v)
            })
            .map_err(|e| e.to_string());
    }

    /// Ends the drag: applies the move when the point moved (returns whether an edit was
    /// applied).
    pub fn end_point_drag(&mut self) -> bool {
        let Some(drag) = self.edit.drag.take() else {
            return false;
        };
        if drag.to == drag.from {
            return false;
        }
        match drag.preview {
            Ok((scene, _)) => self.apply_edit(scene, "move point"),
            Err(e) => {
                self.edit.error = Some(format!("move point: {e}; the running scene is unchanged"));
                false
            }
        }
    }

    /// Moves control point `at` to `to` (m) at once, as a whole drag does.
    pub fn move_point(&mut self, at: PointRef, to: Vec2) -> bool {
        self.begin_point_drag(at);
        self.drag_point_to(to);
        self.end_point_drag()
    }

    /// Sets the weight of control point `at`.
    pub fn set_point_weight(&mut self, at: PointRef, weight: f64) -> bool {
        let result = edit::set_weight(&self.scene.model, at, weight);
        self.apply_edit_result(result, "set weight")
    }

    /// The selected point's patch and the parameter that stands for it
    /// ([`edit::parameter_of`]).
    fn selected_parameter(&mut self, label: &str) -> Option<(PointRef, f32)> {
        let found = self.edit.selected.and_then(|at| {
            match self.scene.model.object(at.object)?.patch(at.patch)? {
                Patch::Curve2(c) => edit::parameter_of(c, at.index).map(|u| (at, u)),
                _ => None,
            }
        });
        if found.is_none() {
            self.edit.error = Some(format!("{label}: select a control point first"));
        }
        found
    }

    /// Inserts a knot into the selected point's patch at the point's parameter.
    pub fn insert_knot_at_selected(&mut self) -> bool {
        let Some((at, u)) = self.selected_parameter("insert knot") else {
            return false;
        };
        let result = edit::insert_knot(&self.scene.model, at.object, at.patch, u);
        self.apply_edit_result(result, &format!("insert knot u = {u}"))
    }

    /// Splits the selected point's patch at the point's parameter.
    pub fn split_at_selected(&mut self) -> bool {
        let Some((at, u)) = self.selected_parameter("split") else {
            return false;
        };
        let result = edit::split_patch(&self.scene.model, at.object, at.patch, u);
        self.apply_edit_result(result, &format!("split at u = {u}"))
    }

    /// Joins the selected point's patch with the next one.
    pub fn join_selected_with_next(&mut self) -> bool {
        let Some(at) = self.edit.selected else {
            self.edit.error = Some("join: select a control point first".into());
            return false;
        };
        let result = edit::join_next(&self.scene.model, at.object, at.patch);
        self.apply_edit_result(result, "join with next")
    }
}
