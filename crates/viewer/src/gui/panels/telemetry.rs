//! The telemetry panel: the newest values, the mode switches and the plots of the history.

use eframe::egui;
use egui::{Color32, RichText};
use egui_plot::{Line, Plot, PlotPoints, Span};
use friction::Mode;

use crate::gui::state::{AppState, HISTORY_S};
use crate::gui::view::mode_colour;

/// Plot colours of the force lines.
const NORMAL: Color32 = Color32::from_rgb(40, 110, 200);
const FRICTION: Color32 = Color32::from_rgb(200, 90, 40);
const TOTAL: Color32 = Color32::from_rgb(30, 30, 30);

/// Points per plotted series at most (the history is decimated to this).
const PLOT_POINTS: usize = 1000;

/// The Ψ plot spans at least ±this (m²): Ψ = Γ·S_u, so a 1 µm projection error on a curve of
/// 0.1 m per unit parameter. At rest Ψ is f32 rounding (~1e-9 m²), which autoscaled filled
/// the plot with a solid block of noise.
pub const PSI_FLOOR: f64 = 1e-7;

/// The Ψ plot's id (its memory holds its bounds).
pub const PSI_PLOT_ID: &str = "telemetry-psi";

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
        // Wide enough for "transition" beside "switch cause" (they ran together).
        egui::Grid::new("now")
            .num_columns(4)
            .spacing([16.0, 4.0])
            .min_col_width(72.0)
            .show(ui, |ui| {
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
        };
        // The legends are rows above the plots: inside, they covered the traces.
        ui.label(RichText::new("forces (N) over the friction mode").strong());
        legend_row(
            ui,
            &[
                ("normal", NORMAL),
                ("friction", FRICTION),
                ("|total|", TOTAL),
                (Mode::Stuck.name(), mode_colour(Mode::Stuck)),
                (Mode::Transition.name(), mode_colour(Mode::Transition)),
                (Mode::Slip.name(), mode_colour(Mode::Slip)),
            ],
        );
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
        ui.label(RichText::new("μ, depth (mm), Ψ (m²)").strong());
        legend_row(ui, &[("μ", FRICTION), ("depth mm", NORMAL), ("Ψ", TOTAL)]);
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
            .id(egui::Id::unique(PSI_PLOT_ID))
            .include_y(-PSI_FLOOR)
            .include_y(PSI_FLOOR)
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

/// A plot's legend as a row of coloured names above it.
fn legend_row(ui: &mut egui::Ui, entries: &[(&str, Color32)]) {
    ui.horizontal_wrapped(|ui| {
        for (name, colour) in entries {
            ui.label(RichText::new(format!("— {name}")).color(*colour).small());
        }
    });
}
