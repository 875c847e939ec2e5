//! The whole haptic tick: encoder counts → kinematics → tracker → friction → safety → Jᵀ F →
//! motor currents, and one telemetry frame. No allocation, no panic.
//!
//! The controller holds no borrow of the scene: the active object is passed to every
//! [`Controller::tick`], so the firmware (or the host simulator) owns the scene storage and
//! can swap it between two ticks; [`Controller::load_scene`] resets the renderer at that
//! boundary, after the whole scene has been received and validated.

use friction::{FrictionMaterial, FrictionOutput, FrictionRenderer, Mode};
use nurbs::Vec2;
use tracker::Object;

use crate::kinematics::Pantograph;
use crate::protocol::Telemetry;
use crate::safety::{ConfigError, Faults, PassivityError, Safety, SafetyConfig, SafetyInput};
use crate::spec::{Calibration, CalibrationError, DeviceSpec, SpecError};

/// Why a controller could not be built or a command was refused.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ControllerError {
    /// The device description is invalid.
    Spec(SpecError),
    /// The safety limits are invalid.
    Safety(ConfigError),
    /// The material is stiffer than the device renders passively at this rate and the
    /// passivity controller is off.
    Passivity(PassivityError),
    /// Calibration failed.
    Calibration(CalibrationError),
}

impl core::fmt::Display for ControllerError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ControllerError::Spec(e) => write!(f, "device description: {e}"),
            ControllerError::Safety(e) => write!(f, "safety limits: {e}"),
            ControllerError::Passivity(e) => write!(
                f,
                "{e} (enable the passivity controller to render it anyway)"
            ),
            ControllerError::Calibration(e) => write!(f, "calibration: {e}"),
        }
    }
}

impl core::error::Error for ControllerError {}

/// What one tick commands.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TickOutput {
    /// Motor currents (A), within the device's limits; zero while forces are off.
    pub currents_a: [f32; 2],
    /// The tick's telemetry frame.
    pub telemetry: Telemetry,
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

/// The controller of one device.
#[derive(Debug)]
pub struct Controller<O: Object<P = Vec2>> {
    spec: DeviceSpec,
    arm: Pantograph,
    calibration: Calibration,
    safety: Safety,
    period_s: f32,
    material: Option<FrictionMaterial>,
    renderer: Option<FrictionRenderer<O>>,
    forces_enabled: bool,
    last_heartbeat_s: f32,
    previous: Option<([f32; 2], Vec2)>,
    last_currents_a: [f32; 2],
}

impl<O: Object<P = Vec2>> Controller<O> {
    /// A controller for `spec` with the safety limits `safety` (whose period is the tick
    /// period). Starts uncalibrated, with forces disabled and no scene.
    pub fn new(spec: DeviceSpec, safety: SafetyConfig) -> Result<Self, ControllerError> {
        let arm = spec.validate().map_err(ControllerError::Spec)?;
        let period_s = safety.period_s;
        let safety = Safety::new(safety).map_err(ControllerError::Safety)?;
        Ok(Controller {
            spec,
            arm,
            calibration: Calibration::new(),
            safety,
            period_s,
            material: None,
            renderer: None,
            forces_enabled: false,
            last_heartbeat_s: 0.0,
            previous: None,
            last_currents_a: [0.0; 2],
        })
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

    /// Makes `material` the active object's material from the next tick (call after the
    /// scene swap, at a tick boundary). Rejects a stiffness the device cannot render
    /// passively unless `passivity_control` is on, in which case the time-domain passivity
    /// controller is enabled for this scene.
    pub fn load_scene(
        &mut self,
        material: FrictionMaterial,
        passivity_control: bool,
    ) -> Result<(), ControllerError> {
        let check = self
            .safety
            .check_material(material.stiffness_n_per_m, material.damping_ns_per_m);
        if let (Err(e), false) = (check, passivity_control) {
            return Err(ControllerError::Passivity(e));
        }
        self.safety.set_passivity_control(passivity_control);
        self.safety.notify_scene_swap();
        self.material = Some(material);
        self.renderer = None;
        Ok(())
    }

    /// The same controller for another object type (calibration, safety state, material,
    /// forces and heartbeat carried over), with the renderer reset as [`Controller::load_scene`]
    /// resets it. Lets a host that owns its scene storage rebuild borrowed views after a swap:
    /// the controller's type names the views' lifetime, so it cannot outlive the storage.
    pub fn rebind<O2: Object<P = Vec2>>(self) -> Controller<O2> {
        Controller {
            spec: self.spec,
            arm: self.arm,
            calibration: self.calibration,
            safety: self.safety,
            period_s: self.period_s,
            material: self.material,
            renderer: None,
            forces_enabled: self.forces_enabled,
            last_heartbeat_s: self.last_heartbeat_s,
            previous: self.previous,
            last_currents_a: self.last_currents_a,
        }
    }

    /// The device description.
    pub fn spec(&self) -> &DeviceSpec {
        &self.spec
    }

    /// Whether force output is enabled (the safety layer may still hold it off).
    pub fn forces_enabled(&self) -> bool {
        self.forces_enabled
    }

    /// Drops the scene: no object, no force.
    pub fn unload_scene(&mut self) {
        self.material = None;
        self.renderer = None;
    }

    /// Records a host heartbeat at `now_s`.
    pub fn heartbeat(&mut self, now_s: f32) {
        self.last_heartbeat_s = now_s;
    }

    /// Enables or disables force output (enabling starts the ramp-in).
    pub fn set_forces_enabled(&mut self, enabled: bool) {
        if enabled && !self.forces_enabled {
            self.safety.notify_scene_swap();
        }
        self.forces_enabled = enabled;
    }

    /// Clears the latched faults whose condition is gone; returns those still latched.
    pub fn clear_faults(&mut self) -> Faults {
        self.safety.clear_faults()
    }

    /// The latched faults.
    pub fn faults(&self) -> Faults {
        self.safety.faults()
    }

    /// One tick. `object` is the active scene's object (the one `load_scene` set the material
    /// for), `counts` the raw encoder counts, `now_s` the time.
    pub fn tick(&mut self, object: Option<&O>, counts: [i32; 2], now_s: f32) -> TickOutput {
        let t = self.period_s;
        let mut telemetry = Telemetry {
            time_us: (now_s.max(0.0) * 1e6) as u32,
            hip_m: Vec2::ZERO,
            cp_m: Vec2::ZERO,
            go_m: Vec2::ZERO,
            force_normal_n: 0.0,
            force_friction_n: 0.0,
            force_n: Vec2::ZERO,
            psi: 0.0,
            mu_e4: 0,
            tick_us: 0,
            faults: self.safety.faults().bits(),
            feature: None,
            mode: Mode::Free,
        };
        // Kinematics: no calibration or an unassembled pose means no HIP and no force.
        let state = self
            .calibration
            .joint_angles(&self.spec, counts)
            .ok()
            .and_then(|theta| self.arm.forward(theta).ok().map(|hip| (theta, hip)));
        let Some((theta, hip)) = state else {
            self.previous = None;
            self.last_currents_a = [0.0; 2];
            return TickOutput {
                currents_a: [0.0; 2],
                telemetry,
                joint_angles_rad: None,
                joint_torques_nm: [0.0; 2],
                render: None,
            };
        };
        let (velocity, joint_step) = match self.previous {
            Some((prev_theta, prev_hip)) => (
                (hip - prev_hip) * (1.0 / t),
                [theta[0] - prev_theta[0], theta[1] - prev_theta[1]],
            ),
            None => (Vec2::ZERO, [0.0; 2]),
        };
        self.previous = Some((theta, hip));
        telemetry.hip_m = hip;

        // Rendering.
        let mut force = Vec2::ZERO;
        let mut render = None;
        if let (Some(object), Some(material)) = (object, self.material) {
            let renderer = self
                .renderer
                .get_or_insert_with(|| FrictionRenderer::new(object, material, hip, t));
            let out = renderer.tick(object, hip, velocity, t);
            force = out.total;
            telemetry.cp_m = out.contact.point;
            telemetry.go_m = out.go;
            telemetry.force_normal_n = out.normal_force_n;
            telemetry.force_friction_n = out.friction_force_n;
            telemetry.psi = out.psi;
            telemetry.mu_e4 = Telemetry::quantize_mu(out.mu);
            telemetry.feature = (out.mode != Mode::Free).then_some(out.contact.feature);
            telemetry.mode = out.mode;
            render = Some(out);
        }

        // Safety, then Jᵀ F → currents.
        let safe = self.safety.apply(&SafetyInput {
            force_n: force,
            hip_in_device_m: hip,
            hip_velocity_m_per_s: velocity,
            joint_step_rad: joint_step,
            now_s,
            last_heartbeat_s: self.last_heartbeat_s,
            motor_current_a: self.last_currents_a,
            forces_enabled: self.forces_enabled,
            calibrated: self.calibration.is_calibrated(),
        });
        telemetry.faults = safe.faults.bits();
        telemetry.force_n = safe.force_n;
        let (currents_a, joint_torques_nm) = self
            .arm
            .joint_torques(theta, safe.force_n)
            .ok()
            .and_then(|tau| {
                let command = self.spec.motor_command(&self.calibration, tau).ok()?;
                Some((command.current_a, tau.map(|t| t * command.scale)))
            })
            .unwrap_or(([0.0; 2], [0.0; 2]));
        self.last_currents_a = currents_a;
        TickOutput {
            currents_a,
            telemetry,
            joint_angles_rad: Some(theta),
            joint_torques_nm,
            render,
        }
    }
}
