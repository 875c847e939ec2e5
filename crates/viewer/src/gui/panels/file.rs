//! The scene panel: the bundled scenes and the path of a scene file (or OBJ mesh) to open or
//! save.

use std::path::PathBuf;

use eframe::egui;
use egui::{Color32, RichText};
use scene::bundled::BUNDLED;

#[cfg(doc)]
use crate::gui::state::AppState;

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
        let empty = self.path.trim().is_empty();
        let open = ui.button("Open").clicked() || (enter && !empty);
        let open_obj = ui
            .button("Open OBJ…")
            .on_hover_text(
                "open the path typed in the file field as a Wavefront OBJ mesh (the polygonal \
                 baseline)",
            )
            .clicked();
        let save = ui.button("Save").clicked();
        if (open || open_obj || save) && empty {
            // The app has no file dialog (it would need a desktop portal or zenity): the path
            // is typed, and a click with none says so rather than doing nothing.
            self.error = Some(format!(
                "type the path of the {} into the file field first (this app has no file \
                 dialog)",
                if open_obj { "OBJ mesh" } else { "scene file" }
            ));
        } else if open {
            action = Some(if obj {
                FileAction::OpenObj(path)
            } else {
                FileAction::OpenScene(path)
            });
        } else if open_obj {
            action = Some(FileAction::OpenObj(path));
        } else if save {
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

    /// With nothing typed, a click on Open OBJ… (or Open, or Save) says where the path goes
    /// instead of doing nothing: there is no file dialog to fall back on.
    #[test]
    fn a_click_with_no_path_says_where_to_type_it() {
        for (button, what) in [
            ("Open OBJ…", "OBJ mesh"),
            ("Open", "scene file"),
            ("Save", "scene file"),
        ] {
            let mut panel = FilePanel::default();
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
            assert_eq!(asked, None, "{button}");
            let error = panel.error.unwrap_or_default();
            assert!(
                error.contains(&format!("type the path of the {what}")),
                "{button}: {error}"
            );
            assert!(error.contains("no file dialog"), "{error}");
        }
    }
}
