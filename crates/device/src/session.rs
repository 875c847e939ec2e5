//! The device side of a link, once for every device: the host's simulator
//! ([`host::sim`](crate::host)), the firmware under QEMU and the board. A [`Session`] takes
//! each frame the host sent through its [`SceneReceiver`] (sequence numbers, scene upload),
//! acks or nacks it, answers a hello with the device's hello and a heartbeat with a status,
//! and applies the commands to the [`Controller`]. What depends on the device's storage or
//! plant comes back as an [`Event`]: a committed scene (the caller swaps its scene storage
//! at a tick boundary) or a hand target (only a simulated plant's session accepts one).
//!
//! No allocation, no panic; replies go through the caller's `reply` (which frames them with
//! the device's own sequence numbers).

use nurbs::Vec2;
use tracker::Object;

use crate::controller::{Controller, ControllerError};
use crate::protocol::{
    ErrorCode, Hello, MAX_PAYLOAD, Message, SceneReceiver, SceneValidator, Status,
};

/// What the caller must do after [`Session::handle`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// Nothing beyond what the session did.
    None,
    /// A scene was committed: the validator (the scratch store) holds it; load it at the next
    /// tick boundary.
    SceneCommitted,
    /// The virtual hand's new target (m, device frame); only from a simulated plant's session.
    HandTarget(Vec2),
}

/// The device side of one link.
#[derive(Clone, Debug)]
pub struct Session<const N: usize> {
    receiver: SceneReceiver<N>,
    software: [u8; 3],
    passivity_control: bool,
    last_error: u8,
}

impl<const N: usize> Session<N> {
    /// A session of a device running `software` (its version), whose plant is simulated or
    /// not (a board's session refuses hand targets with [`ErrorCode::NotSimulated`]), loading
    /// materials stiffer than it renders passively with the passivity controller when
    /// `passivity_control` (the firmware decides that; the wire does not carry it).
    pub const fn new(software: [u8; 3], simulated_plant: bool, passivity_control: bool) -> Self {
        Session {
            receiver: if simulated_plant {
                SceneReceiver::for_simulated_plant()
            } else {
                SceneReceiver::new()
            },
            software,
            passivity_control,
            last_error: 0,
        }
    }

    /// The receiver (the active scene's bytes and CRC, the upload in progress).
    pub fn receiver(&self) -> &SceneReceiver<N> {
        &self.receiver
    }

    /// Whether materials beyond the passive bound are loaded with the passivity controller.
    pub fn passivity_control(&self) -> bool {
        self.passivity_control
    }

    /// Records why a command failed for the next status (`last_error`).
    pub fn note_error(&mut self, code: ErrorCode) {
        self.last_error = code as u8;
    }

    /// The device's status now.
    pub fn status<O: Object<P = Vec2>>(&self, controller: &Controller<O>) -> Status {
        let r = &self.receiver;
        Status {
            forces_enabled: controller.forces_enabled(),
            calibrated: controller.is_calibrated(),
            faults: controller.faults().bits(),
            scene_len: u32::try_from(r.active_scene().len()).unwrap_or(u32::MAX),
            scene_crc32: r.active_crc32(),
            upload_received: r
                .upload_received()
                .and_then(|n| u32::try_from(n).ok())
                .unwrap_or(0),
            expected_seq: r.expected_seq().unwrap_or(0),
            last_error: self.last_error,
        }
    }

    /// Handles one frame from the host (`bytes`, undelimited). `scratch` validates a commit
    /// (decoding it into the store that becomes active on [`Event::SceneCommitted`]);
    /// `home_counts` are the encoder counts a calibration records (the joints on their end
    /// stops); `reply` sends a message to the host. A rejected frame changes nothing but the
    /// status's `last_error`.
    pub fn handle<O: Object<P = Vec2>>(
        &mut self,
        bytes: &[u8],
        scratch: &mut impl SceneValidator,
        controller: &mut Controller<O>,
        home_counts: [i32; 2],
        reply: &mut impl FnMut(&Message),
    ) -> Event {
        let outcome = self.receiver.receive(bytes, scratch);
        reply(&SceneReceiver::<N>::reply(&outcome));
        let frame = match outcome {
            Ok(frame) => frame,
            Err(nack) => {
                self.last_error = nack.code as u8;
                return Event::None;
            }
        };
        match frame.message {
            Message::Hello(_) => reply(&Message::Hello(Hello {
                software: self.software,
                scene_capacity: u32::try_from(N).unwrap_or(u32::MAX),
                max_payload: MAX_PAYLOAD as u8,
            })),
            Message::Heartbeat { .. } => {
                controller.heartbeat();
                reply(&Message::Status(self.status(controller)));
            }
            Message::SceneCommit => return Event::SceneCommitted,
            Message::SetMaterial {
                object: 0,
                material,
            } => {
                // Without a scene there is nothing to set (the next upload brings its own).
                if matches!(
                    controller.set_material(material, self.passivity_control),
                    Err(ControllerError::Passivity(_) | ControllerError::BeyondDevice(_))
                ) {
                    self.last_error = ErrorCode::BadMaterial as u8;
                }
            }
            Message::EnableForces => controller.set_forces_enabled(true),
            Message::DisableForces => controller.set_forces_enabled(false),
            Message::Calibrate if controller.calibrate(home_counts).is_err() => {
                self.last_error = ErrorCode::BadField as u8;
            }
            Message::ClearFaults { .. } => {
                controller.clear_faults();
            }
            Message::HandTarget { target_m } => return Event::HandTarget(target_m),
            _ => {}
        }
        Event::None
    }
}
