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
//! device as the control-point update a device behind a link gets ([`PointsUpdate`](crate::upload::PointsUpdate)), through
//! the device's own receiver ([`DeviceScene::apply_points`](crate::upload::DeviceScene::apply_points): validated as on a board),
//! the controller moved onto the updated store's curves ([`Controller::reshape_object`]: its
//! renderer, feature, friction state and safety ramp stay; no search, no ramp-in). The shape
//! reaches the UI through a [`SharedShape`](crate::deform::SharedShape).

use std::sync::Arc;

use device::controller::Controller;
use device::safety::Faults;
use device::simulator::{SimParams, SimulatedPantograph, VirtualHand};
use friction::FrictionMaterial;
use nurbs::Vec2;
use tracker::Chain;

use crate::deform::{DeformChangeError, DeformStatus, Deformer, SharedShape};
use crate::deformation::Deformation;
use crate::error::{MaterialChangeError, SimError};
use crate::loop_api::{LoopCommand, RATE_HZ, Reply, Sample, Steppable};
use crate::planar_session::apply_points;
pub use crate::planar_session::{DEVICE_RATE_HZ, PlanarSession, SessionError};
use crate::tick::{self, Tick};
use crate::upload::DEVICE_OBJECT;
use scene::Material;

/// Device ticks per step of the loop (per 1 ms wake).
pub const TICKS_PER_STEP: u32 = (DEVICE_RATE_HZ / RATE_HZ) as u32;

/// Where the handle (and the hand's target) starts: in the middle of the default device's
/// workspace, above the bundled planar scenes.
pub const START_HIP: Vec2 = Vec2::new(0.0, 0.11);

/// The fastest the virtual hand's target follows its command (m/s): the simulated
/// plant's ([`device::simulator::VirtualHand`]).
pub const MAX_HAND_SPEED_M_PER_S: f32 = device::simulator::MAX_HAND_SPEED_M_PER_S;

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
        let arm = SimulatedPantograph::new(*session.spec(), SimParams::default(), start_hip)
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

    /// Commands the virtual hand's target to `target`, getting there in `over_s` at a steady
    /// speed (at most [`MAX_HAND_SPEED_M_PER_S`]): [`VirtualHand::glide`].
    pub fn glide_hand(&mut self, target: Vec2, over_s: f32) {
        self.hand.glide(target, over_s);
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
        let counts = tick::end_stop_counts(self.session.spec());
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
            LoopCommand::HandTarget { to, over_s } => {
                self.glide_hand(Vec2::new(to.x, to.y), over_s);
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
