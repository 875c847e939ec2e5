//! The app's panels, one struct each (egui's demo app, rerun's viewer): a panel holds its own
//! form state (the fields typed, the message of its last action) and draws itself with its
//! `ui` methods from what the app state shares (the running scene, the link, the telemetry).
//! What a panel asks of the loop comes back as an action that [`super::ViewerUi`] hands to
//! the [`AppState`](super::state::AppState) method that does it, so that tests drive the same methods without a
//! window. The panels that keep no state of their own (objects, telemetry, status bar) are
//! structs all the same, so that every panel is found, drawn and tested the same way.

mod device;
mod file;
mod material;
mod objects;
mod replay;
mod status;
mod telemetry;

pub use device::{DeviceAction, DevicePanel};
pub use file::{FileAction, FilePanel};
pub use material::MaterialPanel;
pub use objects::{ObjectsAction, ObjectsPanel};
pub use replay::{ReplayAction, ReplayPanel};
pub use status::{StatusAction, StatusBar};
pub use telemetry::{PSI_FLOOR, PSI_PLOT_ID, TelemetryPanel};
