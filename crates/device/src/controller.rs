//! The whole haptic tick: encoder counts → kinematics → tracker → friction → safety → Jᵀ F →
//! motor currents, and one telemetry frame. No allocation, no panic.
//!
//! # The scene is the controller's
//!
//! [`Controller::load_scene`] takes the object (a [`tracker::Chain`], which owns its data, or
//! a board's `&'static mut Chain` slot) with its material, and every tick renders that
//! object: a tick cannot be handed another object than the one the renderer's state belongs
//! to, so that mismatch (which used to index past the end of a shorter chain) cannot be
//! written. A firmware or host loads a new object at a tick boundary, after the whole scene
//! was received and validated; [`Controller::unload_scene`] gives the object back.
//!
//! # A moving shape keeps its renderer
//!
//! A deformable model moves its control points many times a second; loading each shape would
//! restart the renderer (a search, no force until it is back, a ramp-in) every time. So the
//! object can be exchanged for the same object reshaped, at a tick boundary, with the renderer
//! kept: [`Controller::replace_object`] (a new object, the old one returned so its views can be
//! dropped), [`Controller::reshape`] (the same by value) or
//! [`Controller::reshape_object`] (the object moved in place, [`tracker::Chain::reshape`]: what
//! a board does between two ticks). The new shape must have the old one's topology
//! ([`tracker::Object::topology`]: pieces, domains, vertex or edge kinds, closedness), so that
//! the tracker's feature indices name the same features; another is refused with nothing
//! changed. What rides on the surface moves with it (the stuck god-object, the last tick's CP
//! and HIP: [`friction::FrictionRenderer::follow_reshape`]), so the force changes by at most
//! the stiffness times the largest control-point move.
//!
//! # Acquisition is not the tick's
//!
//! A renderer starts from the object's global closest-point search ([`tracker::Object::start`]),
//! which costs tens of ticks' worth of work (about 50,000 instructions on thesis-2d on a
//! Cortex-M4F, against about 2,500 for a tick). So a tick never runs it. After a scene is
//! loaded or its material set, each tick with a pose publishes an [`AcquisitionRequest`]
//! (the HIP and the scene's generation) and renders no force; whoever has the time runs
//! [`acquire`] on it (the board's lowest-priority task; a host loop or a test right after the
//! tick, through [`Controller::acquire_now`]) and hands the result back with
//! [`Controller::complete_acquisition`]. The renderer then starts tracking from that closest
//! point (the tracker's feedback catches up with a HIP that moved meanwhile) and the force
//! ramps in from zero. A result for an older scene (its generation) is refused.
//!
//! # Time
//!
//! The controller runs on the board's monotonic clock in integer microseconds
//! (`now_us: u64`, e.g. a 32-bit hardware timer extended by counting its wraps). Nothing
//! compares absolute times: the watchdog measures the heartbeat's age as the wrapping
//! difference of two clock readings and, independently, as the number of ticks since, times
//! the period, and trips on the larger, so uptimes of weeks, counter wraps, a clock that
//! steps back (its wrapping difference is huge) or stalls all keep the timeout meaning
//! 100 ms. A heartbeat carries no time stamp: [`Controller::heartbeat`] marks it received and
//! the next tick stamps it, so a heartbeat "from the future" cannot exist. The telemetry's
//! `time_us` is the clock modulo 2³² (it wraps every 71.6 min).
//!
//! # Limits
//!
//! The force limit is the smaller of [`DeviceSpec::max_force_n`] and
//! [`SafetyConfig::max_force_n`], the speed limit the smaller of the two speed limits: the
//! safety layer is built with those ([`Controller::safety_config`]).

use friction::{FrictionMaterial, FrictionOutput, FrictionRenderer, Mode, SwitchCause};
use nurbs::Vec2;
use tracker::Object;

use crate::kinematics::Pantograph;
use crate::safety::{ConfigError, Faults, Safety, SafetyConfig, SafetyInput};
use crate::spec::{Calibration, CalibrationError, DeviceSpec, SpecError};
use crate::telemetry::Telemetry;
use crate::wall::{Bound, PassivityConfig, PassivityError};

mod acquisition;
mod excitation;
pub use acquisition::{Acquisition, AcquisitionRequest, acquire};
use excitation::ExcitationRun;
pub use excitation::{Excitation, ExcitationRefusal};

/// Why a controller could not be built or a command was refused.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ControllerError {
    /// The device description is invalid.
    Spec(SpecError),
    /// The safety limits are invalid.
    Safety(ConfigError),
    /// The material fails the device's sampled-data passivity bound at this rate and the
    /// passivity controller is off ([`crate::wall::check_wall`]).
    Passivity(PassivityError),
    /// Calibration failed.
    Calibration(CalibrationError),
    /// The material is beyond what the device renders even with the passivity controller on:
    /// the quantisation bound, or stiffer than the controller is demonstrated to
    /// ([`crate::wall::check_wall`]).
    BeyondDevice(PassivityError),
    /// A material was set with no scene loaded.
    NoScene,
    /// An identification run was refused: the device is not calibrated, or a torque is
    /// beyond what its motors give at their current limit (the field names which).
    Excitation(&'static str),
    /// A reshape was refused: the new object's topology ([`tracker::Object::topology`]:
    /// its pieces, their domains, the kinds of its vertices or edges, whether it closes)
    /// differs from the loaded one's, so the renderer's feature indices would not name the
    /// same features. Load it as a new scene instead.
    Topology,
}

impl core::fmt::Display for ControllerError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ControllerError::Spec(e) => write!(f, "device description: {e}"),
            ControllerError::Safety(e) => write!(f, "safety limits: {e}"),
            ControllerError::Passivity(e) | ControllerError::BeyondDevice(e) => write!(f, "{e}"),
            ControllerError::Calibration(e) => write!(f, "calibration: {e}"),
            ControllerError::NoScene => write!(f, "no scene loaded: load an object first"),
            ControllerError::Excitation(why) => write!(f, "identification run refused: {why}"),
            ControllerError::Topology => write!(
                f,
                "the new object's topology differs from the loaded one's (pieces, domains, \
                 vertex or edge kinds, closedness): upload it as a new scene"
            ),
        }
    }
}

impl core::error::Error for ControllerError {}

/// What one tick commands.
///
/// [`Controller::tick_into`] writes it in place (every field, every tick), so a board keeps one
/// and the tick copies nothing out: returned by value from a tick that is not inlined into its
/// caller, the output was built in a temporary and copied twice (about 1,000 instructions a
/// tick on the Cortex-M4F).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TickOutput {
    /// The tick's telemetry frame.
    pub telemetry: Telemetry,
    /// Motor currents (A), within the device's limits; zero while forces are off.
    pub currents_a: [f32; 2],
    /// The joint angles (rad) the tick measured, `None` before calibration or in an
    /// unassembled pose.
    pub joint_angles_rad: Option<[f32; 2]>,
    /// The joint torques (N·m) the currents produce: `Jᵀ F` of the safe force
    /// (`telemetry.force_n`) at [`TickOutput::joint_angles_rad`], scaled down with the
    /// currents when a current limit cut them; zero while the currents are.
    pub joint_torques_nm: [f32; 2],
    /// The renderer's output before the safety layer, `None` without a scene or a pose.
    pub render: Option<FrictionOutput<Vec2>>,
}

impl TickOutput {
    /// An output of no tick: zero currents and torques, no pose, no render, a telemetry frame
    /// at time 0 that is all zeros, free, no feature and no fault. The initial value of the
    /// buffer [`Controller::tick_into`] writes.
    pub const IDLE: TickOutput = TickOutput {
        telemetry: Telemetry::IDLE,
        currents_a: [0.0; 2],
        joint_angles_rad: None,
        joint_torques_nm: [0.0; 2],
        render: None,
    };
}

impl Default for TickOutput {
    fn default() -> Self {
        TickOutput::IDLE
    }
}

/// The loaded scene: the object, its material and where its renderer is.
#[derive(Debug)]
struct Scene<O: Object<P = Vec2>> {
    object: O,
    material: FrictionMaterial,
    /// Which load or material this scene is (see [`AcquisitionRequest::generation`]).
    generation: u32,
    state: SceneState<O>,
}

/// A scene whose object is out with an acquisition task: what it goes back into.
#[derive(Clone, Copy, Debug)]
struct LentScene {
    material: FrictionMaterial,
    generation: u32,
}

/// Where a loaded scene's renderer is: waiting for the acquisition that starts it, or
/// rendering. (The object stays in [`Scene`]: a chain is a few KiB, and moving it from one
/// variant to the other would copy it on the tick's stack.)
// One of these lives in the controller, in place (no allocation on the board): the renderer's
// size (its CP and proxy trackers) is the controller's, whichever variant is current.
#[allow(clippy::large_enum_variant)]
#[derive(Debug)]
enum SceneState<O: Object<P = Vec2>> {
    /// No renderer yet: the tick renders no force and publishes an [`AcquisitionRequest`]
    /// from `request_hip`, the HIP of the last tick with a pose (`None` before one).
    AwaitingAcquisition { request_hip: Option<Vec2> },
    /// The renderer, built from an [`Acquisition`] (it needs the closest point to start
    /// tracking).
    Rendering { renderer: FrictionRenderer<O> },
}

impl<O: Object<P = Vec2>> SceneState<O> {
    /// The state carried from `old` onto `new`, the same object reshaped (see
    /// [`Controller::replace_object`]).
    fn carried(self, old: &O, new: &O) -> SceneState<O> {
        match self {
            SceneState::AwaitingAcquisition { request_hip } => {
                SceneState::AwaitingAcquisition { request_hip }
            }
            SceneState::Rendering { renderer } => SceneState::Rendering {
                renderer: renderer.reshape(old, new),
            },
        }
    }
}

/// The controller of one device.
#[derive(Debug)]
pub struct Controller<O: Object<P = Vec2>> {
    spec: DeviceSpec,
    arm: Pantograph,
    calibration: Calibration,
    safety: Safety,
    period_s: f32,
    period_us: u64,
    scene: Option<Scene<O>>,
    /// The scene whose object is lent to an acquisition task
    /// ([`Controller::lend_for_acquisition`]): `scene` is `None` meanwhile.
    lent: Option<LentScene>,
    forces_enabled: bool,
    heartbeat_pending: bool,
    /// Clock reading of the tick that stamped the last heartbeat (the first tick, before any).
    last_heartbeat_us: Option<u64>,
    ticks_since_heartbeat: u64,
    previous: Option<([f32; 2], Vec2)>,
    last_currents_a: [f32; 2],
    /// The generation the next scene or material gets.
    next_generation: u32,
    /// An identification run, while one lasts.
    excitation: Option<ExcitationRun>,
    /// The (mode, cause) the last tick's telemetry reported: a tick that renders nothing
    /// after contact reports the switch to free as [`SwitchCause::Released`].
    reported: (Mode, SwitchCause),
}

impl<O: Object<P = Vec2>> Controller<O> {
    /// A controller for `spec` with the safety limits `safety` (whose period is the tick
    /// period), the force and speed limits lowered to the device's own where those are
    /// smaller. Starts uncalibrated, with forces disabled and no scene.
    pub fn new(spec: DeviceSpec, safety: SafetyConfig) -> Result<Self, ControllerError> {
        let arm = spec.validate().map_err(ControllerError::Spec)?;
        safety.validate().map_err(ControllerError::Safety)?;
        let config = Self::effective_limits(&spec, &arm, safety)?;
        let safety = Safety::new(config).map_err(ControllerError::Safety)?;
        Ok(Controller {
            spec,
            arm,
            calibration: Calibration::new(),
            safety,
            period_s: config.period_s,
            period_us: config.period_us(),
            scene: None,
            lent: None,
            forces_enabled: false,
            heartbeat_pending: false,
            last_heartbeat_us: None,
            ticks_since_heartbeat: 0,
            previous: None,
            last_currents_a: [0.0; 2],
            next_generation: 0,
            excitation: None,
            reported: (Mode::Free, SwitchCause::None),
        })
    }

    /// `safety` with its force and speed limits lowered to the device's (both validated) and
    /// the passivity figures the device's own at the handle (`arm`: its validated kinematics).
    fn effective_limits(
        spec: &DeviceSpec,
        arm: &Pantograph,
        safety: SafetyConfig,
    ) -> Result<SafetyConfig, ControllerError> {
        let device = spec.at_handle_of(arm).map_err(ControllerError::Spec)?;
        Ok(SafetyConfig {
            passivity: PassivityConfig {
                device,
                ..safety.passivity
            },
            max_force_n: safety.max_force_n.min(spec.max_force_n),
            max_velocity_m_per_s: safety.max_velocity_m_per_s.min(spec.max_velocity_m_per_s),
            ..safety
        })
    }

    /// The limits the safety layer enforces: the configuration given to
    /// [`Controller::new`] with the device's force and speed limits applied.
    pub fn safety_config(&self) -> &SafetyConfig {
        self.safety.config()
    }

    /// Calibrates against the end stops: `raw_counts` read with both joints resting on them.
    pub fn calibrate(&mut self, raw_counts: [i32; 2]) -> Result<(), ControllerError> {
        self.calibration
            .record_home(&self.spec, raw_counts)
            .map_err(ControllerError::Calibration)?;
        self.previous = None;
        Ok(())
    }

    /// Whether the device is calibrated (no force before it is).
    pub fn is_calibrated(&self) -> bool {
        self.calibration.is_calibrated()
    }

    /// Makes `object` with `material` the scene from the next tick (call at a tick boundary,
    /// after the scene was received and validated); the renderer starts afresh on it and the
    /// force ramps in. Rejects a wall past the device's sampled-data passivity bound unless
    /// `passivity_control` is on, in which case the time-domain passivity controller is
    /// enabled for this scene; even then a wall past the quantisation bound or what the
    /// controller is demonstrated to is refused ([`ControllerError::BeyondDevice`], naming
    /// the bound; [`crate::wall::check_wall`]). On error the previous scene stays loaded.
    pub fn load_scene(
        &mut self,
        object: O,
        material: FrictionMaterial,
        passivity_control: bool,
    ) -> Result<(), ControllerError> {
        self.accept_material(&material, passivity_control)?;
        self.install_scene(object, material, passivity_control);
        Ok(())
    }

    /// Makes `object` with `material` the scene (its renderer awaits an acquisition), with the
    /// passivity controller as given: the material was accepted, or is measured.
    fn install_scene(&mut self, object: O, material: FrictionMaterial, passivity_control: bool) {
        self.use_material(&material, passivity_control);
        self.lent = None;
        self.scene = Some(Scene {
            object,
            material,
            generation: self.bump_generation(),
            state: SceneState::AwaitingAcquisition { request_hip: None },
        });
    }

    /// [`Controller::load_scene`] without the acceptance: any valid stiffness renders, with the
    /// passivity controller as asked. For measuring where walls stop being stable (the
    /// Z-width on a simulated plant, `host::zwidth`), never for a hand on a real device; host
    /// builds only.
    #[cfg(feature = "std")]
    pub fn load_scene_for_measurement(
        &mut self,
        object: O,
        material: FrictionMaterial,
        passivity_control: bool,
    ) {
        self.install_scene(object, material, passivity_control);
    }

    /// [`Controller::load_scene`] with the passivity controller on only where the material
    /// needs it (stiffer than the device renders passively at this rate) and
    /// `allow_passivity_control`; returns whether it is on. On error the previous scene stays.
    pub fn load_scene_as_needed(
        &mut self,
        object: O,
        material: FrictionMaterial,
        allow_passivity_control: bool,
    ) -> Result<bool, ControllerError> {
        self.try_load_scene(object, material, allow_passivity_control)
            .map_err(|(_, e)| e)
    }

    /// [`Controller::load_scene_as_needed`] that hands `object` back with the error, for a
    /// device whose object is a slot it must not lose.
    pub fn try_load_scene(
        &mut self,
        object: O,
        material: FrictionMaterial,
        allow_passivity_control: bool,
    ) -> Result<bool, (O, ControllerError)> {
        match self.accepts_material(&material, allow_passivity_control) {
            Ok(passivity_control) => {
                self.install_scene(object, material, passivity_control);
                Ok(passivity_control)
            }
            Err(e) => Err((object, e)),
        }
    }

    /// Whether the loaded object is lent to an acquisition
    /// ([`Controller::lend_for_acquisition`]) and not back yet.
    pub fn object_lent(&self) -> bool {
        self.lent.is_some()
    }

    /// Whether [`Controller::load_scene_as_needed`] would load a scene of `material`, and
    /// with the passivity controller on (`Ok(true)`) or off: the check alone, nothing
    /// changes. A device that keeps its object in a slot of its own checks first, so that a
    /// load it then makes cannot be refused.
    pub fn accepts_material(
        &self,
        material: &FrictionMaterial,
        allow_passivity_control: bool,
    ) -> Result<bool, ControllerError> {
        match self.accept_material(material, false) {
            Ok(()) => Ok(false),
            Err(ControllerError::Passivity(_)) if allow_passivity_control => {
                self.accept_material(material, true).map(|()| true)
            }
            Err(e) => Err(e),
        }
    }

    /// [`Controller::set_material`] with the passivity controller on only where the material
    /// needs it, as [`Controller::load_scene_as_needed`]; returns whether it is on.
    pub fn set_material_as_needed(
        &mut self,
        material: FrictionMaterial,
        allow_passivity_control: bool,
    ) -> Result<bool, ControllerError> {
        match self.set_material(material, false) {
            Err(ControllerError::Passivity(_)) if allow_passivity_control => {
                self.set_material(material, true).map(|()| true)
            }
            other => other.map(|()| false),
        }
    }

    /// Replaces the loaded object's material (the renderer restarts with it, the force ramps
    /// in), with the same check as [`Controller::load_scene`].
    pub fn set_material(
        &mut self,
        material: FrictionMaterial,
        passivity_control: bool,
    ) -> Result<(), ControllerError> {
        if self.scene.is_none() && self.lent.is_none() {
            return Err(ControllerError::NoScene);
        }
        self.accept_material(&material, passivity_control)?;
        self.use_material(&material, passivity_control);
        if let Some(scene) = self.scene.as_mut() {
            scene.material = material;
        }
        if let Some(lent) = self.lent.as_mut() {
            lent.material = material;
        }
        self.reacquire();
        Ok(())
    }

    fn bump_generation(&mut self) -> u32 {
        let g = self.next_generation;
        self.next_generation = g.wrapping_add(1);
        g
    }

    /// What the renderer waits for: `Some` after a tick with a pose, from a scene load or a
    /// material change until [`Controller::complete_acquisition`] accepts a result; the tick
    /// renders no force meanwhile. See the module docs.
    pub fn acquisition_request(&self) -> Option<AcquisitionRequest> {
        let scene = self.scene.as_ref()?;
        match scene.state {
            SceneState::AwaitingAcquisition {
                request_hip: Some(hip_m),
            } => Some(AcquisitionRequest {
                hip_m,
                generation: scene.generation,
            }),
            SceneState::AwaitingAcquisition { request_hip: None }
            | SceneState::Rendering { .. } => None,
        }
    }

    /// Starts the renderer from `acquisition` (one frame evaluation, no search), the force
    /// ramping in from zero. Refused (`false`, nothing changes) when the acquisition is for
    /// another scene or material than the loaded one, or the renderer already runs.
    pub fn complete_acquisition(&mut self, acquisition: Acquisition<O::State>) -> bool {
        let Some(scene) = self.scene.as_mut() else {
            return false;
        };
        if matches!(scene.state, SceneState::Rendering { .. })
            || scene.generation != acquisition.generation
        {
            return false;
        }
        let mut renderer =
            FrictionRenderer::from_tracking(&scene.object, scene.material, acquisition.state);
        // The renderer's mode decisions get the hysteresis of the encoder's quantum at the
        // handle (its worst over the workspace): one count of noise cannot flip a mode.
        renderer.set_resolution(self.safety.config().passivity.device.resolution_m);
        scene.state = SceneState::Rendering { renderer };
        self.safety.restart_ramp_and_observer();
        true
    }

    /// [`acquire`] on the pending request and [`Controller::complete_acquisition`] at once,
    /// for a loop that has the time between ticks (the host's simulator, tests); `true` when
    /// the renderer started. The board runs the two halves in different tasks.
    pub fn acquire_now(&mut self) -> bool {
        let Some(request) = self.acquisition_request() else {
            return false;
        };
        let Some(scene) = self.scene.as_ref() else {
            return false;
        };
        let acquisition = acquire(&scene.object, request);
        self.complete_acquisition(acquisition)
    }

    /// The board's half of an acquisition ([`acquire`] runs in another task): when the
    /// renderer waits for one ([`Controller::acquisition_request`]), the loaded object is
    /// taken out and lent with the request. The tick needs no object meanwhile (it renders no
    /// force until the acquisition comes back), so the search reads the object itself while
    /// the tick runs, and nothing is copied (a device lends `&'static mut Chain`). While lent,
    /// the controller has no object ([`Controller::object`] is `None`; a reshape is refused as
    /// [`ControllerError::NoScene`]); a material change is kept and makes the search stale.
    /// Give the object back with [`Controller::return_from_acquisition`].
    pub fn lend_for_acquisition(&mut self) -> Option<(O, AcquisitionRequest)> {
        let request = self.acquisition_request()?;
        let scene = self.scene.take()?;
        self.lent = Some(LentScene {
            material: scene.material,
            generation: scene.generation,
        });
        Some((scene.object, request))
    }

    /// Takes back the object [`Controller::lend_for_acquisition`] lent, with the search's
    /// result (`None`: the search did not run), and starts the renderer from it as
    /// [`Controller::complete_acquisition`] does; `Ok(true)` when the renderer started,
    /// `Ok(false)` when the result was stale or missing (the renderer waits for a new one).
    /// `Err(object)` hands the object back to the caller when the controller no longer waits
    /// for it: a scene was loaded or unloaded meanwhile.
    pub fn return_from_acquisition(
        &mut self,
        object: O,
        acquisition: Option<Acquisition<O::State>>,
    ) -> Result<bool, O> {
        let Some(lent) = self.lent.take() else {
            return Err(object);
        };
        self.scene = Some(Scene {
            object,
            material: lent.material,
            generation: lent.generation,
            state: SceneState::AwaitingAcquisition { request_hip: None },
        });
        Ok(acquisition.is_some_and(|a| self.complete_acquisition(a)))
    }

    fn accept_material(
        &self,
        material: &FrictionMaterial,
        passivity_control: bool,
    ) -> Result<(), ControllerError> {
        let (k, b) = (material.stiffness_n_per_m, material.damping_ns_per_m);
        if let Err(e) = self.safety.check_wall(k, b, false) {
            // No controller lifts the quantisation bound: the tank sees only quantised motion.
            if matches!(
                e,
                PassivityError::TooStiff {
                    bound: Bound::Quantisation,
                    ..
                }
            ) {
                return Err(ControllerError::BeyondDevice(e));
            }
            if !passivity_control {
                return Err(ControllerError::Passivity(e));
            }
            self.safety
                .check_wall(k, b, true)
                .map_err(ControllerError::BeyondDevice)?;
        }
        Ok(())
    }

    /// The safety layer set up for rendering `material`: the passivity controller on or off,
    /// the tank's stiffness, the ramp and the observer restarted.
    fn use_material(&mut self, material: &FrictionMaterial, passivity_control: bool) {
        self.safety.set_passivity_control(passivity_control);
        self.safety.set_wall_stiffness(material.stiffness_n_per_m);
        self.safety.restart_ramp_and_observer();
    }

    /// Replaces the loaded object with `object`, the same object with its control points
    /// moved (a deformable model's new shape), at a tick boundary, keeping the scene's
    /// renderer: the CP tracker's feature, the friction mode and god-object, the material, the
    /// generation (an acquisition in flight stays valid), the safety layer's ramp and
    /// observer. No search and no ramp-in: the next tick renders `object`. What rides on the
    /// surface moves with it ([`friction::FrictionRenderer::follow_reshape`]: the GO by the
    /// surface's displacement under it, so the force changes by at most the stiffness times
    /// the largest control-point move). Returns the object it replaced, so the caller can
    /// drop its views before reusing their storage.
    ///
    /// Refused, with nothing changed, without a scene ([`ControllerError::NoScene`]) or when
    /// `object`'s topology differs from the loaded one's ([`ControllerError::Topology`]):
    /// the renderer's feature indices must name the same features. A few evaluations, no
    /// allocation, no panic.
    pub fn replace_object(&mut self, object: O) -> Result<O, ControllerError> {
        let scene = self.scene.as_mut().ok_or(ControllerError::NoScene)?;
        if scene.object.topology() != object.topology() {
            return Err(ControllerError::Topology);
        }
        if let SceneState::Rendering { renderer } = &mut scene.state {
            renderer.follow_reshape(&scene.object, &object);
        }
        Ok(core::mem::replace(&mut scene.object, object))
    }

    /// [`Controller::replace_object`] in place: `reshape` moves the loaded object onto its new
    /// geometry itself (a chain onto the same store's curves with moved points,
    /// [`tracker::Chain::reshape`]), so no second object is built, copied or returned: for a
    /// device short of time and stack between two ticks. The renderer follows as with
    /// `replace_object` (the points under its CP and GO are taken before `reshape` runs).
    /// `reshape` must refuse (return `false` with the object unchanged) a new shape of
    /// another topology, as `Chain::reshape` does; then nothing changes
    /// ([`ControllerError::Topology`]). Without a scene, [`ControllerError::NoScene`].
    pub fn reshape_object(
        &mut self,
        reshape: impl FnOnce(&mut O) -> bool,
    ) -> Result<(), ControllerError> {
        let scene = self.scene.as_mut().ok_or(ControllerError::NoScene)?;
        let anchors = match &scene.state {
            SceneState::Rendering { renderer } => Some(renderer.anchors(&scene.object)),
            SceneState::AwaitingAcquisition { .. } => None,
        };
        if !reshape(&mut scene.object) {
            return Err(ControllerError::Topology);
        }
        if let (SceneState::Rendering { renderer }, Some(anchors)) = (&mut scene.state, anchors) {
            renderer.follow_anchors(anchors, &scene.object);
        }
        Ok(())
    }

    /// [`Controller::replace_object`] by value: the same controller, renderer and all,
    /// rendering `object`; the old object is dropped. Refused as `replace_object` is, handing
    /// the controller back untouched.
    #[allow(
        clippy::result_large_err,
        reason = "the error hands the controller back unchanged; there is no allocator to box it"
    )]
    pub fn reshape(mut self, object: O) -> Result<Self, (Self, ControllerError)> {
        let Some(scene) = self.scene.take() else {
            return Err((self, ControllerError::NoScene));
        };
        if scene.object.topology() != object.topology() {
            self.scene = Some(scene);
            return Err((self, ControllerError::Topology));
        }
        let state = scene.state.carried(&scene.object, &object);
        let scene = Scene {
            object,
            material: scene.material,
            generation: scene.generation,
            state,
        };
        Ok(self.with_scene(Some(scene)))
    }

    /// This controller with `scene` in place of its own.
    fn with_scene<O2: Object<P = Vec2>>(self, scene: Option<Scene<O2>>) -> Controller<O2> {
        Controller {
            spec: self.spec,
            arm: self.arm,
            calibration: self.calibration,
            safety: self.safety,
            period_s: self.period_s,
            period_us: self.period_us,
            scene,
            lent: None,
            forces_enabled: self.forces_enabled,
            heartbeat_pending: self.heartbeat_pending,
            last_heartbeat_us: self.last_heartbeat_us,
            ticks_since_heartbeat: self.ticks_since_heartbeat,
            previous: self.previous,
            last_currents_a: self.last_currents_a,
            next_generation: self.next_generation,
            excitation: self.excitation,
            reported: self.reported,
        }
    }

    /// The loaded object, if any.
    pub fn object(&self) -> Option<&O> {
        self.scene.as_ref().map(|s| &s.object)
    }

    /// The device description.
    pub fn spec(&self) -> &DeviceSpec {
        &self.spec
    }

    /// Whether the loaded material renders with the time-domain passivity controller on.
    pub fn passivity_control(&self) -> bool {
        self.safety.passivity_control()
    }

    /// Whether force output is enabled (the safety layer may still hold it off).
    pub fn forces_enabled(&self) -> bool {
        self.forces_enabled
    }

    /// Drops the scene: no object, no force. Returns the object (`None` without a scene, or
    /// while it is lent: then [`Controller::return_from_acquisition`] hands it back).
    pub fn unload_scene(&mut self) -> Option<O> {
        self.lent = None;
        self.bump_generation();
        self.scene.take().map(|scene| scene.object)
    }

    /// Starts an identification run from the next tick (see [`Excitation`]): the renderer
    /// stops (it starts again from a fresh acquisition when the run ends), and the safety
    /// layer applies every fault, its saturation and its rate limit, but no ramp-in and no
    /// energy tank. Refused when not calibrated or when a torque is not finite or beyond the
    /// motor's torque at its current limit. Forces must be on for anything to move.
    pub fn excite(&mut self, excitation: Excitation) -> Result<(), ControllerError> {
        excitation
            .check(
                self.spec.max_joint_torque_nm(),
                self.calibration.is_calibrated(),
            )
            .map_err(|r| ControllerError::Excitation(r.reason()))?;
        self.excitation = Some(ExcitationRun {
            excitation,
            started_us: None,
        });
        self.reacquire();
        Ok(())
    }

    /// Whether an identification run is in progress.
    pub fn exciting(&self) -> bool {
        self.excitation.is_some()
    }

    /// Restarts the renderer from a fresh acquisition (the HIP moved without it).
    fn reacquire(&mut self) {
        let generation = self.bump_generation();
        if let Some(scene) = self.scene.as_mut() {
            scene.generation = generation;
            scene.state = SceneState::AwaitingAcquisition { request_hip: None };
        }
        // An acquisition out for the scene before is stale when it comes back.
        if let Some(lent) = self.lent.as_mut() {
            lent.generation = generation;
        }
        self.safety.restart_ramp_and_observer();
    }

    /// Records a host heartbeat; the next tick stamps it with its own clock reading.
    pub fn heartbeat(&mut self) {
        self.heartbeat_pending = true;
    }

    /// Enables or disables force output (enabling starts the ramp-in).
    pub fn set_forces_enabled(&mut self, enabled: bool) {
        if enabled && !self.forces_enabled {
            self.safety.restart_ramp_and_observer();
        }
        self.forces_enabled = enabled;
    }

    /// Clears the latched faults whose condition is gone; returns those still latched.
    pub fn clear_faults(&mut self) -> Faults {
        // A heartbeat received since the last tick ends the watchdog's condition (the next
        // tick stamps it).
        let ended = if self.heartbeat_pending {
            Faults::WATCHDOG
        } else {
            Faults::empty()
        };
        self.safety.clear_faults_including_ended(ended)
    }

    /// The latched faults.
    pub fn faults(&self) -> Faults {
        self.safety.faults()
    }

    /// One tick at `now_us` (the board's monotonic clock, µs; see the module docs) on the
    /// raw encoder `counts`, returned by value: [`Controller::tick_into`] into a fresh
    /// [`TickOutput`], for host loops and tests. A board calls `tick_into` on a buffer it
    /// keeps, which copies nothing.
    pub fn tick(&mut self, counts: [i32; 2], now_us: u64) -> TickOutput {
        let mut out = TickOutput::IDLE;
        self.tick_into(counts, now_us, &mut out);
        out
    }

    /// One tick at `now_us` (the board's monotonic clock, µs; see the module docs) on the
    /// raw encoder `counts`, its output written into `out`: every field of it, whatever it
    /// held before. Total: any counts and any clock reading give finite currents within the
    /// limits; every path goes through the safety layer.
    pub fn tick_into(&mut self, counts: [i32; 2], now_us: u64, out: &mut TickOutput) {
        let t = self.period_s;
        let heartbeat_age_us = self.heartbeat_age_us(now_us);
        // Kinematics. Uncalibrated counts have no pose (forces are off then); calibrated
        // counts that no pose of the mechanism gives are an encoder fault for the safety
        // layer, which then latches it and cuts the force, and the last good pose is kept
        // so that the next sample is checked against it.
        let theta = self.calibration.joint_angles(&self.spec, counts).ok();
        // Solved once: the pose, the velocity and Jᵀ F below all use this configuration.
        let state = theta.and_then(|theta| self.arm.configuration(theta).ok());
        let (hip, velocity, joint_step) = match (&state, self.previous) {
            (Some(config), Some((prev_theta, prev_hip))) => (
                config.hip_in_device,
                (config.hip_in_device - prev_hip) * (1.0 / t),
                [
                    config.joints_rad[0] - prev_theta[0],
                    config.joints_rad[1] - prev_theta[1],
                ],
            ),
            (Some(config), None) => (config.hip_in_device, Vec2::ZERO, [0.0; 2]),
            (None, _) => (Vec2::ZERO, Vec2::ZERO, [0.0; 2]),
        };
        if let Some(config) = &state {
            self.previous = Some((config.joints_rad, config.hip_in_device));
        }

        // Rendering, on the loaded object only. The frame's rendering fields are written on
        // both paths (the buffer holds the previous tick's).
        // An identification run replaces the rendering: the joint torques of its square waves,
        // as the force at the handle that gives them, F = J⁻ᵀ τ.
        let mut excitation_force = None;
        if let Some(run) = self.excitation.as_mut() {
            let started = *run.started_us.get_or_insert(now_us);
            let elapsed = now_us.wrapping_sub(started);
            if elapsed >= run.excitation.duration_us {
                self.excitation = None;
                self.reacquire();
            } else {
                let tau = run.excitation.torques_at(elapsed);
                excitation_force = Some(
                    state
                        .as_ref()
                        .and_then(|config| self.arm.jacobian_at(config).ok())
                        .map_or(Vec2::ZERO, |j| {
                            let m = j.m;
                            let det = j.determinant();
                            // Jᵀ F = τ solved by Cramer's rule (a well-conditioned J: the
                            // pose passed the kinematics' condition check).
                            Vec2::new(
                                (m[1][1] * tau[0] - m[1][0] * tau[1]) / det,
                                (m[0][0] * tau[1] - m[0][1] * tau[0]) / det,
                            )
                        }),
                );
            }
        }
        let telemetry = &mut out.telemetry;
        // Documented to wrap: the clock modulo 2³².
        telemetry.time_us = now_us as u32;
        telemetry.hip_m = hip;
        telemetry.tick_us = 0;
        let mut force = excitation_force.unwrap_or(Vec2::ZERO);
        let scene = self
            .scene
            .as_mut()
            .filter(|_| state.is_some() && excitation_force.is_none());
        if let Some(Scene {
            object,
            state: SceneState::Rendering { renderer },
            ..
        }) = scene
        {
            let render = out.render.insert(renderer.tick(object, hip, velocity, t));
            force = render.total;
            telemetry.cp_m = render.contact.point;
            telemetry.go_m = render.go;
            telemetry.force_normal_n = render.normal_force_n;
            telemetry.go_param = render.go_params[0];
            telemetry.psi = render.psi;
            telemetry.mu_e4 = Telemetry::quantize_mu(render.mu);
            telemetry.feature = (render.mode != Mode::Free).then_some(render.contact.feature);
            telemetry.mode = render.mode;
            telemetry.cause = render.cause;
        } else {
            if let Some(Scene {
                state: SceneState::AwaitingAcquisition { request_hip },
                ..
            }) = scene
            {
                // Until an acquisition starts the renderer: no force, a request (module docs).
                *request_hip = Some(hip);
            }
            out.render = None;
            telemetry.cp_m = Vec2::ZERO;
            telemetry.go_m = Vec2::ZERO;
            telemetry.force_normal_n = 0.0;
            telemetry.go_param = 0.0;
            telemetry.psi = 0.0;
            telemetry.mu_e4 = 0;
            telemetry.feature = None;
            telemetry.mode = Mode::Free;
            telemetry.cause = SwitchCause::None;
        }
        // The cause is why the mode last changed, across renderers: a tick that renders
        // nothing (awaiting an acquisition after a material change, no pose, an
        // identification run) or a fresh renderer that has not switched yet names none, and
        // the contact it ends is released.
        telemetry.cause = telemetry.cause.or_carried(telemetry.mode, self.reported);
        self.reported = (telemetry.mode, telemetry.cause);

        // Safety, every tick, then Jᵀ F → currents.
        let safe = self.safety.apply(&SafetyInput {
            force_n: force,
            hip_in_device_m: hip,
            hip_velocity_m_per_s: velocity,
            joint_step_rad: joint_step,
            heartbeat_age_us,
            motor_current_a: self.last_currents_a,
            forces_enabled: self.forces_enabled,
            calibrated: self.calibration.is_calibrated(),
            pose_valid: state.is_some(),
            identification: excitation_force.is_some(),
        });
        telemetry.faults = safe.faults.bits();
        telemetry.force_n = safe.force_n;
        let command = state.as_ref().and_then(|config| {
            let tau = self.arm.joint_torques_at(config, safe.force_n).ok()?;
            let command = self.spec.motor_command(&self.calibration, tau).ok()?;
            Some((command.current_a, tau.map(|t| t * command.scale)))
        });
        let (currents_a, joint_torques_nm) = command.unwrap_or(([0.0; 2], [0.0; 2]));
        self.last_currents_a = currents_a;
        out.currents_a = currents_a;
        out.joint_angles_rad = state.map(|config| config.joints_rad);
        out.joint_torques_nm = joint_torques_nm;
    }

    /// Stamps a pending heartbeat with `now_us` and returns the heartbeat's age, µs: the
    /// larger of the wrapping clock difference and the ticks counted since times the period.
    fn heartbeat_age_us(&mut self, now_us: u64) -> u64 {
        if self.heartbeat_pending || self.last_heartbeat_us.is_none() {
            // Before the first heartbeat the first tick starts the timeout.
            self.heartbeat_pending = false;
            self.last_heartbeat_us = Some(now_us);
            self.ticks_since_heartbeat = 0;
        }
        let by_clock = self
            .last_heartbeat_us
            .map_or(0, |stamp| now_us.wrapping_sub(stamp));
        let by_ticks = self.ticks_since_heartbeat.saturating_mul(self.period_us);
        self.ticks_since_heartbeat = self.ticks_since_heartbeat.saturating_add(1);
        by_clock.max(by_ticks)
    }
}
