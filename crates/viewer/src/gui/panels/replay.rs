//! The replay panel: the run log to replay and the replay's controls.

use std::path::PathBuf;

use eframe::egui;
use egui::{Color32, RichText};

use crate::gui::replay::Replay;
#[cfg(doc)]
use crate::gui::state::AppState;

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
                    for s in crate::gui::replay::SPEEDS {
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

#[cfg(test)]
mod tests {
    use super::*;
    use egui_kittest::Harness;
    use egui_kittest::kittest::Queryable;

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
