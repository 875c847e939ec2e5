//! The status bar: forces, faults, the loop's rate and jitter, the frame time, the recording.

use std::path::Path;

use eframe::egui;
use egui::Color32;

use crate::gui::state::AppState;

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
