//! The planar loop the app runs on the simulated pantograph: the device's [`Controller`] on
//! one planar object of a scene, stepped one tick at a time ([`HapticLoop::step`], the same
//! [`tick::device_tick`] as `viewer sim --device`), driven by a virtual hand whose target the
//! UI moves. The scene reaches it as the device's upload ([`PlanarSession`]): the in-process
//! simulator decodes it with the device's own receiver, as a board would. It runs on a
//! [`Backend`](crate::backend::Backend) like every loop the app drives.
//!
//! A deformable object (one with a `"dynamics"` block) deforms under the hand on
//! [`LoopCommand::Deform`], through the loops' one lifecycle ([`Deformation`]): every device
//! tick feeds it, every step (1 ms, ten device ticks) steps it, and its new shape reaches the
//! device as the control-point update a device behind a link gets ([`PointsUpdate`]), through
//! the device's own receiver ([`upload::DeviceScene::apply_points`]: validated as on a board),
//! the controller moved onto the updated store's curves ([`Controller::reshape_object`]: its
//! renderer, feature, friction state and safety ramp stay; no search, no ramp-in). The shape
//! reaches the UI through a [`SharedShape`](crate::deform::SharedShape).

use std::sync::Arc;

use device::controller::Controller;
use device::safety::Faults;
use device::simulator::{SimParams, SimulatedPantograph, VirtualHand};
use device::spec::DeviceSpec;
use friction::FrictionMaterial;
use nurbs::Vec2;
use protocol::SceneFault;
use tracker::Chain;

use crate::backend::{LoopCommand, PointsUpdate, RATE_HZ, Reply, Sample, Steppable};
use crate::deform::{DeformChangeError, DeformStatus, Deformer, SharedShape};
use crate::deformation::Deformation;

/// The device's tick rate in the loop (Hz): the board's. The loop thread wakes at
/// [`RATE_HZ`] and runs [`TICKS_PER_STEP`] device ticks per wake.
pub const DEVICE_RATE_HZ: f64 = 10_000.0;
/// Device ticks per step of the loop (per 1 ms wake).
pub const TICKS_PER_STEP: u32 = (DEVICE_RATE_HZ / RATE_HZ) as u32;
use crate::error::{MaterialChangeError, SimError};
use crate::tick::{self, Tick};
use crate::upload::{self, DEVICE_OBJECT, DeviceScene, UploadError};
use scene::{Material, Scene, Space};

/// Where the handle (and the hand's target) starts: in the middle of the default device's
/// workspace, above the bundled planar scenes.
pub const START_HIP: Vec2 = Vec2::new(0.0, 0.11);

/// The fastest the virtual hand's target follows its command (m/s): the simulated
/// plant's ([`device::simulator::VirtualHand`]).
pub const MAX_HAND_SPEED_M_PER_S: f32 = device::simulator::MAX_HAND_SPEED_M_PER_S;

/// A scene the loop renders: the scene, the index of the object the device renders (the
/// first planar one; `None` when the scene has none), that object as the device received it,
/// and the controller built for it (which holds its own copy of the object: nothing borrowed).
pub struct PlanarSession {
    scene: Scene,
    object: Option<usize>,
    received: Option<Received>,
    controller: Controller<Chain>,
    passivity_control: bool,
}

/// An object as the device received it: the wire scene uploaded, and the device's receiver
/// and store holding it (as moved since by control-point updates).
#[derive(Debug)]
struct Received {
    wire: Vec<u8>,
    device: DeviceScene,
}

impl std::fmt::Debug for PlanarSession {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PlanarSession")
            .field("object", &self.object())
            .field("passivity_control", &self.passivity_control())
            .finish_non_exhaustive()
    }
}

/// Why a scene cannot be rendered.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The controller or the chain refused the object.
    #[error("{0}")]
    Sim(#[from] SimError),
    /// The device refused its upload.
    #[error("{0}")]
    Upload(#[from] UploadError),
}

impl PlanarSession {
    /// The default device at [`DEVICE_RATE_HZ`], calibrated on its end stops, forces enabled, with
    /// the first object of planar curves of `scene` loaded (none when it has none: the
    /// pantograph is planar, so a scene of surfaces renders nothing). The controller's own
    /// checks apply: a material stiffer than the device renders is refused, naming the limit.
    pub fn new(scene: Scene) -> Result<Self, SessionError> {
        let object = scene
            .objects()
            .iter()
            .position(|o| o.space() == Space::Planar);
        Self::with_object(scene, object)
    }

    /// [`PlanarSession::new`] with object `object` (which must be planar), or none. The object
    /// reaches the controller as a board's would: its wire scene ([`upload::wire_scene`])
    /// goes frame by frame through the device's receiver ([`DeviceScene::receive`]), and the
    /// controller renders the store the device decoded.
    pub fn with_object(scene: Scene, object: Option<usize>) -> Result<Self, SessionError> {
        let received = match object {
            Some(index) => {
                let wire = upload::wire_scene(&scene, index)?;
                let device = DeviceScene::receive(&wire)?;
                Some(Received { wire, device })
            }
            None => None,
        };
        let (controller, passivity_control) = build_controller(received.as_ref(), object)?;
        Ok(PlanarSession {
            scene,
            object,
            received,
            controller,
            passivity_control,
        })
    }

    /// The scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The index of the object the device renders, if any.
    pub fn object(&self) -> Option<usize> {
        self.object
    }

    /// The wire scene the device received (the rendered object alone, at rest), if it
    /// renders one: what an upload to a board carries.
    pub fn wire(&self) -> Option<&[u8]> {
        self.received.as_ref().map(|r| r.wire.as_slice())
    }

    /// The CRC-32 the device reports for its active scene (`Status::scene_crc32`), if it
    /// renders one: the upload's, or, while the object deforms, its current shape's.
    pub fn scene_crc32(&self) -> Option<u32> {
        self.received.as_ref().map(|r| r.device.crc32())
    }

    /// Whether the controller renders the material with the passivity controller on (the
    /// material is stiffer than the device renders passively at [`DEVICE_RATE_HZ`]).
    pub fn passivity_control(&self) -> bool {
        self.passivity_control
    }
}

/// The controller of the default device for what the device received (nothing rendered
/// without an object), calibrated on its end stops, forces enabled, and whether it runs the
/// passivity controller.
fn build_controller(
    received: Option<&Received>,
    object: Option<usize>,
) -> Result<(Controller<Chain>, bool), SessionError> {
    let spec = DeviceSpec::default();
    let (mut controller, passivity_control) = match received {
        Some(r) => {
            let material = r
                .device
                .store()
                .material(usize::from(DEVICE_OBJECT))
                .unwrap_or_default();
            tick::device_controller(store_chain(r, object)?, material, DEVICE_RATE_HZ)?
        }
        None => {
            let safety = device::safety::SafetyConfig {
                period_s: (1.0 / DEVICE_RATE_HZ) as f32,
                ramp_time_s: tick::DEVICE_RAMP_TIME_S,
                ..device::safety::SafetyConfig::default()
            };
            (
                Controller::new(spec, safety).map_err(SimError::Controller)?,
                false,
            )
        }
    };
    controller
        .calibrate(tick::end_stop_counts(&spec))
        .map_err(SimError::Controller)?;
    controller.set_forces_enabled(true);
    Ok((controller, passivity_control))
}

/// The chain of the object the device decoded (object [`DEVICE_OBJECT`] of its store;
/// `object` of the scene, named in the error).
fn store_chain(received: &Received, object: Option<usize>) -> Result<Chain, SessionError> {
    let index = object.unwrap_or(0);
    let store = received.device.store();
    store
        .chain(usize::from(DEVICE_OBJECT))
        .map_err(|e| match e.fault {
            SceneFault::Chain(error) => SimError::Chain { index, error }.into(),
            _ => UploadError::Refused(e.code()).into(),
        })
}

/// Moves `session`'s device onto `update`, as a device behind a link takes it: the update
/// through the device's receiver ([`DeviceScene::apply_points`]), then, when it moved the
/// rendered object, the controller onto the updated store's curves in place
/// ([`Controller::reshape_object`] with [`Chain::reshape`]: the renderer carried on). Refused
/// with the device's reason.
fn apply_points(
    session: &mut PlanarSession,
    update: &PointsUpdate,
) -> Result<(), DeformChangeError> {
    let received = session
        .received
        .as_mut()
        .ok_or(DeformChangeError::NoObject)?;
    let object = received
        .device
        .apply_points(update)
        .map_err(|e| DeformChangeError::Update(e.to_string()))?;
    if object != DEVICE_OBJECT {
        // The device renders one object; another's points change nothing it renders.
        return Ok(());
    }
    let controller = &mut session.controller;
    received
        .device
        .store()
        .with_curves(usize::from(object), |curves| {
            controller.reshape_object(|chain| chain.reshape(curves))
        })
        .map_err(|e| DeformChangeError::Update(e.to_string()))?
        .map_err(DeformChangeError::Controller)
}

/// The loop's state: the session, the simulated arm and the hand, and the object's
/// deformation. Stepped one tick at a time.
#[derive(Debug)]
pub struct HapticLoop {
    session: PlanarSession,
    material: Option<FrictionMaterial>,
    arm: SimulatedPantograph,
    hand: VirtualHand,
    tick: u64,
    period_s: f32,
    last_error: Option<String>,
    deformation: Deformation,
}

impl HapticLoop {
    /// A loop on `session` with the handle at rest at `start_hip`, held by the default
    /// relaxed hand of `viewer sim --device` ([`SimParams::default`], 300 N/m).
    pub fn new(session: PlanarSession, start_hip: Vec2) -> Result<Self, SessionError> {
        let arm = SimulatedPantograph::new(DeviceSpec::default(), SimParams::default(), start_hip)
            .map_err(SimError::Simulator)?;
        let material = material_of(&session);
        Ok(HapticLoop {
            session,
            material,
            arm,
            hand: VirtualHand::at(start_hip),
            tick: 0,
            period_s: (1.0 / DEVICE_RATE_HZ) as f32,
            last_error: None,
            // Every step's shape goes to the device: it is in this process.
            deformation: Deformation::new(1),
        })
    }

    /// One step of the loop: [`TICKS_PER_STEP`] device ticks at [`DEVICE_RATE_HZ`] (see
    /// [`HapticLoop::device_tick`]), then, while the object deforms, one step of its dynamics
    /// (1 ms) and the device moved onto its new shape; returns the last tick's record,
    /// so the UI and the recorder get one record per millisecond, evenly spaced.
    pub fn step(&mut self) -> Tick {
        for _ in 1..TICKS_PER_STEP {
            self.device_tick();
        }
        let tick = self.device_tick();
        self.step_object();
        tick
    }

    /// One device tick (see [`tick::device_tick`]); while the object deforms the tick feeds it
    /// ([`Deformation::feed`]) and records its displacement at the CP ([`Tick::deform`]). An
    /// arm driven into a singular pose stays there; the tick is then recorded at the last pose
    /// and [`HapticLoop::last_error`] says why.
    pub fn device_tick(&mut self) -> Tick {
        let target = self.hand.step(self.period_s);
        let t_s = self.tick as f64 / DEVICE_RATE_HZ;
        // The device clock: integer microseconds, as a board's timer.
        let now_us = (self.tick as f64 * 1e6 / DEVICE_RATE_HZ).round() as u64;
        let period_s = self.period_s;
        let controller = &mut self.session.controller;
        let result = tick::device_tick(controller, &mut self.arm, t_s, now_us, target, period_s);
        self.tick += 1;
        let error = match result {
            Ok((mut tick, _)) => {
                self.deformation.feed(&mut tick);
                return tick;
            }
            Err(e) => e.to_string(),
        };
        self.last_error = Some(error);
        let hip = self.arm.hip().map(|(p, _)| p).unwrap_or(target);
        Tick {
            hip: nurbs::Vec3::new(hip.x, hip.y, 0.0),
            ..Tick::idle(t_s)
        }
    }

    /// The loop's time (s).
    fn time_s(&self) -> f64 {
        self.tick as f64 / DEVICE_RATE_HZ
    }

    /// One dynamics step of a deforming object under what the step's ticks fed it, the device
    /// moved onto the new shape ([`apply_points`]), and the shape published when it is due. A
    /// step that fails (the dynamics refuse a load, the shape leaves f32, the device refuses
    /// it) makes the object rigid again and [`HapticLoop::last_error`] says why.
    fn step_object(&mut self) {
        let t_s = self.time_s();
        let dt_s = f64::from(TICKS_PER_STEP) / DEVICE_RATE_HZ;
        let session = &mut self.session;
        if let Some(e) = self
            .deformation
            .step(dt_s, t_s, &mut |u| apply_points(session, u))
        {
            self.last_error = Some(e);
        }
    }

    /// Makes the rendered object deformable (`true`) from the next tick, from its rest shape,
    /// or rigid at its rest shape again (`false`: the device gets the rest shape back as a
    /// control-point update; no search, no ramp-in). Asking for what already is changes
    /// nothing. The object's shape is published in [`HapticLoop::shared_shape`] while it
    /// deforms. Refused, with nothing changed, when no object is rendered or it is rigid (no
    /// `"dynamics"` block).
    pub fn set_deforming(&mut self, on: bool) -> Result<DeformStatus, DeformChangeError> {
        let t_s = self.time_s();
        if on {
            let (session, material) = (&self.session, self.material);
            self.deformation
                .start(|| rest_deformer(session, material), DEVICE_OBJECT, t_s)?;
        } else {
            let session = &mut self.session;
            self.deformation
                .stop(t_s, &mut |u| apply_points(session, u))?;
        }
        Ok(self.deformation.status())
    }

    /// Whether the rendered object deforms.
    pub fn deforming(&self) -> bool {
        self.deformation.deforming()
    }

    /// The deforming object's dynamics, while it deforms.
    pub fn deformer(&self) -> Option<&Deformer> {
        self.deformation.deformer()
    }

    /// Where the loop publishes the deforming object's shape (the same for the loop's life).
    pub fn shared_shape(&self) -> &Arc<SharedShape> {
        self.deformation.shared_shape()
    }

    /// The controller.
    fn controller(&self) -> &Controller<Chain> {
        &self.session.controller
    }

    /// The controller, to command.
    fn controller_mut(&mut self) -> &mut Controller<Chain> {
        &mut self.session.controller
    }

    /// Commands the virtual hand's target (m, device frame): from the next tick it moves
    /// there at up to [`MAX_HAND_SPEED_M_PER_S`]; a non-finite target is ignored.
    pub fn set_hand_target(&mut self, target: Vec2) {
        self.hand.command(target);
    }

    /// Who holds the handle from the next tick: a grip or a fingertip takes it (at its
    /// current target), a released hand lets go.
    pub fn set_hand(&mut self, hand: crate::hand::Hand) {
        match hand {
            crate::hand::Hand::Released => self.arm.release(),
            held => {
                let p = held.params();
                self.arm
                    .grip(p.hand_stiffness_n_per_m, p.hand_damping_ns_per_m);
            }
        }
    }

    /// Whether a hand holds the simulated handle.
    pub fn hand_held(&self) -> bool {
        self.arm.is_held()
    }

    /// The hand's target (where it is on its way to the command).
    pub fn hand_target(&self) -> Vec2 {
        self.hand.target()
    }

    /// Device ticks so far (at [`DEVICE_RATE_HZ`]).
    pub fn ticks(&self) -> u64 {
        self.tick
    }

    /// Validates `material` (every field, then the controller's own check) and, when both
    /// accept it, renders the object with it from the next tick (the renderer restarts, the
    /// force ramps in; a deforming object starts again from rest, its contact as stiff as the
    /// material). On error the running material stays.
    pub fn set_material(
        &mut self,
        material: FrictionMaterial,
    ) -> Result<FrictionMaterial, MaterialChangeError> {
        Material::from_friction(material)?;
        if self.session.object().is_none() {
            return Err(MaterialChangeError::NoObject);
        }
        let passivity = self
            .controller_mut()
            .set_material_as_needed(material, true)
            .map_err(MaterialChangeError::Controller)?;
        self.session.passivity_control = passivity;
        self.material = Some(material);
        if self.deformation.deforming() {
            let t_s = self.time_s();
            let rest = rest_deformer(&self.session, Some(material));
            let session = &mut self.session;
            let restarted = self
                .deformation
                .restart(|| rest, t_s, &mut |u| apply_points(session, u));
            if let Err(e) = restarted {
                self.last_error = Some(format!("{e}; the object is rigid again"));
            }
        }
        Ok(material)
    }

    /// The material the loop renders, if it renders an object.
    pub fn material(&self) -> Option<FrictionMaterial> {
        self.material
    }

    /// Renders `session` from the next tick; the arm, the hand and the forces' switch stay
    /// as they are. A deforming object is dropped with the old session: the new one renders
    /// its object rigid, at rest, until it is asked to deform.
    pub fn swap_session(&mut self, session: PlanarSession) {
        let forces = self.forces_enabled();
        self.deformation.forget(self.time_s());
        self.material = material_of(&session);
        self.session = session;
        self.set_forces_enabled(forces);
    }

    /// The session.
    pub fn session(&self) -> &PlanarSession {
        &self.session
    }

    /// Enables or disables the forces.
    pub fn set_forces_enabled(&mut self, enabled: bool) {
        self.controller_mut().set_forces_enabled(enabled);
    }

    /// Whether forces are enabled.
    pub fn forces_enabled(&self) -> bool {
        self.controller().forces_enabled()
    }

    /// Clears the latched faults whose condition is gone; returns those still latched.
    pub fn clear_faults(&mut self) -> Faults {
        self.controller_mut().clear_faults()
    }

    /// Calibrates the controller on the simulated arm's end stops (where it was homed).
    pub fn calibrate(&mut self) {
        let counts = tick::end_stop_counts(&DeviceSpec::default());
        if let Err(e) = self.controller_mut().calibrate(counts) {
            self.last_error = Some(e.to_string());
        }
    }

    /// The latched faults.
    pub fn faults(&self) -> Faults {
        self.controller().faults()
    }

    /// Why the last tick could not move the arm, if it could not.
    pub fn last_error(&self) -> Option<&str> {
        self.last_error.as_deref()
    }
}

/// The dynamics of `session`'s object at rest, its contact as stiff as `material` (the
/// running one, when it has one).
fn rest_deformer(
    session: &PlanarSession,
    material: Option<FrictionMaterial>,
) -> Result<Deformer, DeformChangeError> {
    let index = session.object().ok_or(DeformChangeError::NoObject)?;
    let mut deformer = Deformer::new(session.scene(), index)?;
    if let Some(m) = material {
        deformer.set_contact_stiffness(m.stiffness_n_per_m);
    }
    Ok(deformer)
}

fn material_of(session: &PlanarSession) -> Option<FrictionMaterial> {
    session
        .object()
        .and_then(|i| session.scene().object(i))
        .map(|o| o.material().friction_material())
}

impl Steppable for HapticLoop {
    type Session = PlanarSession;

    fn apply(&mut self, command: LoopCommand) -> Option<Reply> {
        match command {
            LoopCommand::HandTarget(t) => {
                self.set_hand_target(Vec2::new(t.x, t.y));
                None
            }
            LoopCommand::SetMaterial(m) => Some(Reply::Material(self.set_material(m))),
            LoopCommand::Swap(session) => {
                self.swap_session(*session);
                Some(Reply::Swapped)
            }
            // The app's own simulated device takes shapes as sessions (`Swap`) or from its own
            // deforming object (`Deform`); control-point updates are the protocol's, for a
            // device behind a link.
            LoopCommand::Mesh(_) | LoopCommand::ScenePoints(_) => {
                Some(Reply::Unsupported(command.name()))
            }
            LoopCommand::Forces(on) => {
                self.set_forces_enabled(on);
                None
            }
            LoopCommand::ClearFaults => Some(Reply::FaultsCleared(self.clear_faults())),
            LoopCommand::Calibrate => {
                self.calibrate();
                None
            }
            LoopCommand::Hand(hand) => {
                self.set_hand(hand);
                None
            }
            LoopCommand::Deform(on) => Some(Reply::Deform(self.set_deforming(on))),
        }
    }

    fn step_sample(&mut self) -> Sample {
        let tick = self.step();
        Sample {
            tick,
            hand_target: self.hand_target(),
            period_us: None,
            forces_enabled: self.forces_enabled(),
        }
    }
}
