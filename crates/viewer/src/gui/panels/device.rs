//! The device panel: which device the app drives and the fields naming a link.

use eframe::egui;
use egui::Color32;
use host::devices::Target;

use crate::gui::state::{AppState, DeviceChoice};

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
