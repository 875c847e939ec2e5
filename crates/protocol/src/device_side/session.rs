//! The device side of a link, once for every device: the host's simulator
//! ([`link::SimLink`](crate::host_side::SimLink)), the firmware under QEMU and the board. A [`DeviceSession`] takes
//! each frame the host sent through its [`SceneReceiver`] (sequence numbers, scene upload),
//! acks or nacks it, answers a hello with the device's hello and a heartbeat with a status.
//! What it asks of the device comes back as an [`Event`]: a [`DeviceCommand`] for the controller
//! (applied at once by a single-threaded device, [`DeviceCommand::apply`], or queued to a board's
//! tick, which owns the controller), a committed scene (the caller swaps its scene storage at
//! a tick boundary), a control-point update applied to the active scene (the caller gives the
//! controller the updated object at a tick boundary, keeping its renderer) or a hand target
//! (only a simulated plant's session accepts one).
//!
//! No allocation, no panic; replies go through the caller's `reply` (which frames them with
//! the device's own sequence numbers). The session never touches the controller: a status is
//! made of the [`DeviceState`] the caller passes.

use friction::FrictionMaterial;
use nurbs::Vec2;
use tracker::Object;

use crate::{
    ErrorCode, Frame, Hello, MAX_PAYLOAD, Message, NO_INDEX, Nack, SceneReceiver, SceneValidator,
    Status, UNKNOWN_SEQ,
};
use device::controller::{Controller, ControllerError, Excitation, ExcitationRefusal};
use device::spec::DeviceSpec;

/// A command for the controller, from a frame the session accepted. A single-threaded
/// device applies it at once ([`DeviceCommand::apply`]); a board queues it to its tick, which owns
/// the controller.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DeviceCommand {
    /// The host is alive ([`Controller::heartbeat`]).
    Heartbeat,
    /// A new material for object 0.
    SetMaterial(FrictionMaterial),
    /// Forces on or off.
    Forces(bool),
    /// Calibrate against the end stops (the joints rest on them).
    Calibrate,
    /// Clear the latched faults whose condition is gone.
    ClearFaults,
    /// Start an identification run ([`Controller::excite`]).
    Excite(Excitation),
}

impl DeviceCommand {
    /// Applies the command to `controller`. A calibration records `home_counts` (the encoder
    /// counts with the joints on their end stops); a material is loaded with the passivity
    /// controller on only where it needs it and `allow_passivity_control`
    /// ([`Controller::set_material_as_needed`]). The error is the code for the status's
    /// `last_error`.
    pub fn apply<O: Object<P = Vec2>>(
        self,
        controller: &mut Controller<O>,
        home_counts: [i32; 2],
        allow_passivity_control: bool,
    ) -> Result<(), ErrorCode> {
        match self {
            DeviceCommand::Heartbeat => controller.heartbeat(),
            DeviceCommand::Forces(on) => controller.set_forces_enabled(on),
            DeviceCommand::Calibrate => {
                controller
                    .calibrate(home_counts)
                    .map_err(|_| ErrorCode::BadField)?;
            }
            DeviceCommand::ClearFaults => {
                controller.clear_faults();
            }
            DeviceCommand::Excite(excitation) => {
                // The session's check again, on the controller as it is now (a board's tick
                // runs this after the session acked): the same refusal, the same code.
                excitation
                    .check(
                        controller.spec().max_joint_torque_nm(),
                        controller.is_calibrated(),
                    )
                    .map_err(excitation_code)?;
                controller
                    .excite(excitation)
                    .map_err(|_| ErrorCode::BadField)?;
            }
            DeviceCommand::SetMaterial(material) => {
                // Without a scene there is nothing to set (the next upload brings its own).
                if let Err(ControllerError::Passivity(_) | ControllerError::BeyondDevice(_)) =
                    controller.set_material_as_needed(material, allow_passivity_control)
                {
                    return Err(ErrorCode::BadMaterial);
                }
            }
        }
        Ok(())
    }
}

/// The code of a nack or a `last_error` for an identification run refused.
fn excitation_code(refusal: ExcitationRefusal) -> ErrorCode {
    match refusal {
        ExcitationRefusal::NotCalibrated => ErrorCode::NotCalibrated,
        ExcitationRefusal::TorqueBeyondMotor { .. } => ErrorCode::TorqueBeyondMotor,
        // The decoder refuses a zero period or duration already.
        ExcitationRefusal::ZeroPeriodOrDuration => ErrorCode::BadField,
    }
}

/// What a hello and a status report of the device: its software version and a snapshot of
/// the controller, so that a session whose controller belongs to another task (a board's
/// tick) can answer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DeviceState {
    /// The device's software version, `[major, minor, patch]`.
    pub software: [u8; 3],
    /// Force output enabled.
    pub forces_enabled: bool,
    /// Calibrated.
    pub calibrated: bool,
    /// The latched faults' bits.
    pub faults: u16,
}

impl DeviceState {
    /// A device running `software` with `controller` as it is now.
    pub fn of<O: Object<P = Vec2>>(software: [u8; 3], controller: &Controller<O>) -> Self {
        DeviceState {
            software,
            forces_enabled: controller.forces_enabled(),
            calibrated: controller.is_calibrated(),
            faults: controller.faults().bits(),
        }
    }
}
impl DeviceState {
    /// The state without its software version in one word, for a device that hands it from
    /// one task to another through an atomic (a board's tick to its link task): the fault
    /// bits in bits 0–15, forces enabled in bit 16, calibrated in bit 17.
    pub fn to_word(&self) -> u32 {
        u32::from(self.faults)
            | (u32::from(self.forces_enabled) << 16)
            | (u32::from(self.calibrated) << 17)
    }

    /// The state of `software` whose other fields [`DeviceState::to_word`] packed into `word`
    /// (bits 18–31 are ignored).
    pub fn from_word(software: [u8; 3], word: u32) -> Self {
        DeviceState {
            software,
            forces_enabled: word & (1 << 16) != 0,
            calibrated: word & (1 << 17) != 0,
            faults: word as u16,
        }
    }
}

/// What the caller must do after [`DeviceSession::handle`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// Nothing beyond what the session did.
    None,
    /// A scene was committed: the validator (the scratch store) holds it; load it at the next
    /// tick boundary.
    SceneCommitted,
    /// A control-point update of object `object` was applied to the active scene
    /// ([`Message::ScenePoints`]): the validator (the scratch store) holds the updated scene;
    /// at the next tick boundary give the controller its new object in place of the old one
    /// ([`Controller::replace_object`], which keeps the renderer), not a fresh load.
    ScenePointsUpdated {
        /// The object whose points moved (a device that renders object 0 only has nothing to
        /// do for the others).
        object: u8,
    },
    /// The virtual hand's new target (m, device frame); only from a simulated plant's session.
    HandTarget(Vec2),
    /// A command for the controller.
    DeviceCommand(DeviceCommand),
}

/// The device side of one link.
#[derive(Clone, Debug)]
pub struct DeviceSession<const N: usize> {
    receiver: SceneReceiver<N>,
    last_error: u8,
    /// Each joint's torque at its motor's current limit (N·m,
    /// [`DeviceSpec::max_joint_torque_nm`]): an identification run beyond it is nacked.
    /// Zero until [`DeviceSession::set_motor_limits`]: a device that does not say refuses every
    /// run that moves anything.
    max_torque_nm: [f32; 2],
}

impl<const N: usize> DeviceSession<N> {
    /// A session of a device whose plant is simulated or not (a board's session refuses
    /// hand targets with [`ErrorCode::NotSimulated`]). A board's is all zero bits (a static
    /// of it needs no image in flash).
    pub const fn new(simulated_plant: bool) -> Self {
        DeviceSession {
            receiver: if simulated_plant {
                SceneReceiver::for_simulated_plant()
            } else {
                SceneReceiver::new()
            },
            last_error: 0,
            max_torque_nm: [0.0; 2],
        }
    }

    /// The receiver (the active scene's bytes and CRC, the upload in progress).
    pub fn receiver(&self) -> &SceneReceiver<N> {
        &self.receiver
    }

    /// The device's motors, for the check of an identification run before it is acked: the
    /// description the device's controller runs (`spec`).
    pub fn set_motor_limits(&mut self, spec: &DeviceSpec) {
        self.max_torque_nm = spec.max_joint_torque_nm();
    }

    /// Records why a command failed for the next status (`last_error`): it stays until a
    /// status carried it or a later request was accepted.
    pub fn note_error(&mut self, code: ErrorCode) {
        self.last_error = code as u8;
    }

    /// The device's status: the controller's `state` with the receiver's.
    pub fn status(&self, state: DeviceState) -> Status {
        let r = &self.receiver;
        Status {
            forces_enabled: state.forces_enabled,
            calibrated: state.calibrated,
            faults: state.faults,
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

    /// A frame the receiver accepted, or the nack of a command the device would refuse
    /// (an identification run it cannot run), in sequence: its number is used up, as any
    /// refused frame's.
    fn check_command(&self, frame: Frame, state: &DeviceState) -> Result<Frame, Nack> {
        let Message::Excite {
            torque_nm,
            half_period_ms,
            duration_ms,
        } = frame.message
        else {
            return Ok(frame);
        };
        excitation(torque_nm, half_period_ms, duration_ms)
            .check(self.max_torque_nm, state.calibrated)
            .map(|()| frame)
            .map_err(|refusal| Nack {
                seq: frame.seq,
                code: excitation_code(refusal),
                object: NO_INDEX,
                patch: NO_INDEX,
                expected_seq: self.receiver.expected_seq().unwrap_or(UNKNOWN_SEQ),
            })
    }

    /// Handles one frame from the host (`bytes`, undelimited). `scratch` validates a commit
    /// (decoding it into the store that becomes active on [`Event::SceneCommitted`]); `state`
    /// is the device's, for a hello or a heartbeat's status; `reply` sends a message to the
    /// host. A
    /// rejected frame changes nothing but the status's `last_error`.
    ///
    /// `last_error` is the latest refusal not yet reported: a heartbeat's status carries it
    /// and clears it (read), and an accepted request clears it (superseded) — not a heartbeat
    /// nor a hand target, which stream on their own and would wipe it before a status could
    /// say it. An identification run is checked here ([`Excitation::check`], with `state`'s
    /// calibration and [`DeviceSession::set_motor_limits`]) and a refusal nacked with its code, so
    /// the host is not told the run started. (A board's `state` is its tick's last, at most a
    /// tick old: a calibration it has not applied yet reads as not calibrated; the tick
    /// checks the run again, `DeviceCommand::apply`.)
    pub fn handle(
        &mut self,
        bytes: &[u8],
        scratch: &mut impl SceneValidator,
        state: DeviceState,
        reply: &mut impl FnMut(&Message),
    ) -> Event {
        let outcome = self
            .receiver
            .receive(bytes, scratch)
            .and_then(|frame| self.check_command(frame, &state));
        reply(&SceneReceiver::<N>::reply(&outcome));
        let frame = match outcome {
            Ok(frame) => frame,
            Err(nack) => {
                self.last_error = nack.code as u8;
                return Event::None;
            }
        };
        if !matches!(
            frame.message,
            Message::Heartbeat { .. } | Message::HandTarget { .. }
        ) {
            self.last_error = 0;
        }
        match frame.message {
            Message::Hello(_) => reply(&Message::Hello(Hello {
                software: state.software,
                scene_capacity: u32::try_from(N).unwrap_or(u32::MAX),
                max_payload: MAX_PAYLOAD as u8,
            })),
            Message::Heartbeat { .. } => {
                reply(&Message::Status(self.status(state)));
                self.last_error = 0;
                return Event::DeviceCommand(DeviceCommand::Heartbeat);
            }
            Message::SceneCommit => return Event::SceneCommitted,
            Message::ScenePoints(p) if p.apply => {
                return Event::ScenePointsUpdated { object: p.object };
            }
            Message::SetMaterial {
                object: 0,
                material,
            } => return Event::DeviceCommand(DeviceCommand::SetMaterial(material)),
            Message::SetMaterial { .. } => {
                // One object is rendered: object 0.
                self.last_error = ErrorCode::BadField as u8;
            }
            Message::EnableForces => return Event::DeviceCommand(DeviceCommand::Forces(true)),
            Message::DisableForces => return Event::DeviceCommand(DeviceCommand::Forces(false)),
            Message::Calibrate => return Event::DeviceCommand(DeviceCommand::Calibrate),
            Message::ClearFaults { .. } => return Event::DeviceCommand(DeviceCommand::ClearFaults),
            Message::HandTarget { target_m } => return Event::HandTarget(target_m),
            Message::Excite {
                torque_nm,
                half_period_ms,
                duration_ms,
            } => {
                return Event::DeviceCommand(DeviceCommand::Excite(excitation(
                    torque_nm,
                    half_period_ms,
                    duration_ms,
                )));
            }
            _ => {}
        }
        Event::None
    }
}

/// The run an [`Message::Excite`] asks for: milliseconds on the wire, microseconds for the
/// controller.
fn excitation(torque_nm: [f32; 2], half_period_ms: [u16; 2], duration_ms: u32) -> Excitation {
    Excitation {
        torque_nm,
        half_period_us: half_period_ms.map(|ms| u32::from(ms) * 1000),
        duration_us: u64::from(duration_ms) * 1000,
    }
}
