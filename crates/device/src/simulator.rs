//! The simulated pantograph: the five-bar's rigid-body dynamics with the motors' reflected
//! inertia, joint damping, encoder quantisation and current limits, driven by a virtual hand
//! (a spring-damper pulling the handle towards a target that a script or the mouse moves).
//!
//! # Model
//!
//! Joint space, `θ = (θ₁, θ₂)`:
//!
//! `M(θ) θ̈ = τ_motor − B θ̇ − τ_c sign(θ̇) + J(θ)ᵀ F_hand`, with `M(θ) = I_r 𝟙 + m_h JᵀJ`,
//!
//! where `I_r` is each motor's rotor inertia reflected through the capstan (`n² I_rotor`,
//! which dominates the light links), `m_h` the mass of the handle at the HIP, `B` and `τ_c`
//! the joint damping and Coulomb friction of the device description, `τ_motor = n k_t I`
//! (the current clamped to the motor's limit: torque saturation) and
//! `F_hand = k_h (target − x) − b_h ẋ` while a hand holds the handle (zero once it is
//! [released](SimulatedPantograph::release)). Integrated with semi-implicit Euler at
//! [`SimParams::substeps`] steps per call, so the plant runs faster than the controller.
//!
//! What makes a sampled wall active is all here: the currents of one call are held over the
//! whole call (zero-order hold) and, with [`SimParams::command_delay`], applied one call
//! late (the board computes a tick's currents from counts read at its start); the encoders
//! quantise the angles ([`SimulatedPantograph::encoder_counts`]).
//!
//! Coulomb friction is applied as an impulse that may stop a joint but never reverse it: with
//! `ω'` the joint rates after the other torques over a substep `h`, the rates become
//! `ω' − h M⁻¹ τ_c sign(ω')`, and a joint whose rate that would change in sign stops (stuck)
//! instead.

use nurbs::{Point, Vec2};

use crate::kinematics::{KinematicsError, Pantograph};
use crate::spec::{DeviceSpec, SpecError};

/// Physical parameters of the simulation that the device description does not carry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimParams {
    /// Rotor inertia reflected to each joint, `n² I_rotor` (kg·m²).
    pub reflected_inertia_kg_m2: f32,
    /// Mass of the handle at the HIP (kg).
    pub handle_mass_kg: f32,
    /// The virtual hand's grip stiffness (N/m).
    pub hand_stiffness_n_per_m: f32,
    /// The virtual hand's damping (N·s/m).
    pub hand_damping_ns_per_m: f32,
    /// Integration steps per call of [`SimulatedPantograph::step`].
    pub substeps: u32,
    /// The motors apply the currents of the previous call of [`SimulatedPantograph::step`]
    /// (one tick of computation delay), not those of this one.
    pub command_delay: bool,
}

impl Default for SimParams {
    /// A desktop pantograph held by a relaxed hand: rotor 3·10⁻⁶ kg·m² through 10:1
    /// (3·10⁻⁴ kg·m² at the joint), a 20 g handle, a 300 N/m, 2 N·s/m grip, 10 substeps, one
    /// tick of command delay.
    fn default() -> Self {
        SimParams {
            reflected_inertia_kg_m2: 3e-4,
            handle_mass_kg: 0.02,
            hand_stiffness_n_per_m: 300.0,
            hand_damping_ns_per_m: 2.0,
            substeps: 10,
            command_delay: true,
        }
    }
}

impl SimParams {
    /// The default plant touched by a light fingertip instead of a grip: 100 N/m, 0.1 N·s/m
    /// (a fingertip pad resting on the handle; its damping a twentieth of a relaxed grip's).
    pub fn fingertip() -> Self {
        SimParams {
            hand_stiffness_n_per_m: 100.0,
            hand_damping_ns_per_m: 0.1,
            ..SimParams::default()
        }
    }
}

/// The fastest a [`VirtualHand`]'s target follows its command (m/s). A hand does not
/// teleport: a command far from the handle would otherwise yank it through the hand's spring
/// past the device's 1 m/s speed limit and latch the velocity fault.
pub const MAX_HAND_SPEED_M_PER_S: f32 = 0.3;

/// The virtual hand of a simulated plant: the point its spring pulls the handle towards
/// (the argument of [`SimulatedPantograph::step`]) follows the commanded one at up to
/// [`MAX_HAND_SPEED_M_PER_S`], in the device's own time, however commands arrive (a link may
/// deliver them late and in bursts).
///
/// A command may say how long the pointer took to get there ([`VirtualHand::glide`]): the
/// target then moves at the steady speed that covers the way in that time, so a drag the UI
/// samples at a few frames a second reaches the hand as one smooth motion, one frame late,
/// not as bursts at the top speed with a stop at every frame. Planar ([`Vec2`]) and spatial
/// ([`nurbs::Vec3`]) hands are the same code.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VirtualHand<P = Vec2> {
    target: P,
    command: P,
    /// The speed the target moves at towards the command (m/s), ≤ the top speed.
    speed_m_per_s: f32,
}

impl<P: Point> VirtualHand<P> {
    /// A hand at rest at `at`.
    pub const fn at(at: P) -> Self {
        VirtualHand {
            target: at,
            command: at,
            speed_m_per_s: MAX_HAND_SPEED_M_PER_S,
        }
    }

    /// Commands the hand towards `to` as fast as it goes; a non-finite command is ignored.
    pub fn command(&mut self, to: P) {
        self.glide(to, 0.0);
    }

    /// Commands the hand towards `to`, to get there `over_s` seconds from now at a steady
    /// speed (the time the pointer took to move there), at most [`MAX_HAND_SPEED_M_PER_S`];
    /// `over_s` ≤ 0 (or not finite): as fast as the hand goes. A non-finite `to` is ignored.
    pub fn glide(&mut self, to: P, over_s: f32) {
        if !to.is_finite() {
            return;
        }
        self.command = to;
        let way_sq = (to - self.target).length_squared();
        // speed = way / over_s, compared squared so no square root is taken at the top speed.
        let top = MAX_HAND_SPEED_M_PER_S;
        self.speed_m_per_s =
            if over_s > 0.0 && over_s.is_finite() && way_sq < (top * over_s) * (top * over_s) {
                libm::sqrtf(way_sq) / over_s
            } else {
                top
            };
    }

    /// Moves the target one period `dt_s` towards the command and returns it.
    pub fn step(&mut self, dt_s: f32) -> P {
        self.target = approach(self.target, self.command, self.speed_m_per_s * dt_s);
        self.target
    }

    /// Where the spring pulls now.
    pub fn target(&self) -> P {
        self.target
    }

    /// Where the hand is going.
    pub fn command_point(&self) -> P {
        self.command
    }
}

/// `from` one step towards `to`: at most `max_step` (m) along the way.
pub fn approach<P: Point>(from: P, to: P, max_step: f32) -> P {
    let to_go = to - from;
    let d2 = to_go.length_squared();
    if d2 > max_step * max_step {
        from + to_go * (max_step / libm::sqrtf(d2))
    } else {
        to
    }
}

/// Why the simulator could not start or move.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SimulatorError {
    /// The device description is invalid.
    Spec(SpecError),
    /// The start point is not reachable, or the arm reached a singular configuration.
    Kinematics(KinematicsError),
    /// A parameter is not finite or not positive.
    Param(&'static str),
}

impl core::fmt::Display for SimulatorError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SimulatorError::Spec(e) => write!(f, "device description: {e}"),
            SimulatorError::Kinematics(e) => write!(f, "simulated arm: {e}"),
            SimulatorError::Param(name) => {
                write!(f, "simulation parameter {name} must be finite and > 0")
            }
        }
    }
}

impl core::error::Error for SimulatorError {}

/// The simulated device.
#[derive(Clone, Copy, Debug)]
pub struct SimulatedPantograph {
    spec: DeviceSpec,
    arm: Pantograph,
    params: SimParams,
    theta_rad: [f32; 2],
    omega_rad_per_s: [f32; 2],
    /// The currents the motors apply during the next call (with a command delay).
    pending_currents_a: [f32; 2],
    held: bool,
}

impl SimulatedPantograph {
    /// A device at rest with its HIP at `hip_in_device`.
    pub fn new(
        spec: DeviceSpec,
        params: SimParams,
        hip_in_device: Vec2,
    ) -> Result<Self, SimulatorError> {
        let arm = spec.validate().map_err(SimulatorError::Spec)?;
        for (name, v) in [
            ("reflected_inertia_kg_m2", params.reflected_inertia_kg_m2),
            ("handle_mass_kg", params.handle_mass_kg),
            ("hand_stiffness_n_per_m", params.hand_stiffness_n_per_m),
            ("hand_damping_ns_per_m", params.hand_damping_ns_per_m),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(SimulatorError::Param(name));
            }
        }
        if params.substeps == 0 {
            return Err(SimulatorError::Param("substeps"));
        }
        let theta_rad = arm
            .inverse(hip_in_device)
            .map_err(SimulatorError::Kinematics)?;
        Ok(SimulatedPantograph {
            spec,
            arm,
            params,
            theta_rad,
            omega_rad_per_s: [0.0; 2],
            pending_currents_a: [0.0; 2],
            held: true,
        })
    }

    /// The hand lets go: from now on nobody holds the handle (its own mass, the device's own
    /// friction and damping, and the motors).
    pub fn release(&mut self) {
        self.held = false;
    }

    /// A hand takes the handle (again) with this spring and damper (N/m, N·s/m); values that
    /// are not finite and > 0 leave the hand as it was.
    pub fn grip(&mut self, hand_stiffness_n_per_m: f32, hand_damping_ns_per_m: f32) {
        let valid = |v: f32| v.is_finite() && v > 0.0;
        if valid(hand_stiffness_n_per_m) && valid(hand_damping_ns_per_m) {
            self.params.hand_stiffness_n_per_m = hand_stiffness_n_per_m;
            self.params.hand_damping_ns_per_m = hand_damping_ns_per_m;
            self.held = true;
        }
    }

    /// Whether a hand holds the handle.
    pub fn is_held(&self) -> bool {
        self.held
    }

    /// The simulation's parameters.
    pub fn params(&self) -> &SimParams {
        &self.params
    }

    /// Joint angles (rad).
    pub fn joint_angles(&self) -> [f32; 2] {
        self.theta_rad
    }

    /// Joint rates (rad/s).
    pub fn joint_rates(&self) -> [f32; 2] {
        self.omega_rad_per_s
    }

    /// HIP position (m) and velocity (m/s), from the true joint state.
    pub fn hip(&self) -> Result<(Vec2, Vec2), KinematicsError> {
        let config = self.arm.configuration(self.theta_rad)?;
        let j = self.arm.jacobian_at(&config)?;
        Ok((config.hip_in_device, j.velocity(self.omega_rad_per_s)))
    }

    /// What the encoders read: the joint angles quantised to whole counts, with the
    /// description's direction and offset (the inverse of [`DeviceSpec::joint_angles`]).
    pub fn encoder_counts(&self) -> [i32; 2] {
        let per_rad = self.spec.counts_per_joint_rad();
        [0, 1].map(|i| {
            let counts = libm::floorf(
                self.spec.encoder_direction[i].sign() * self.theta_rad[i] * per_rad[i],
            );
            self.spec.encoder_offset_counts[i].wrapping_add(counts as i32)
        })
    }

    /// Kinetic energy `½ θ̇ᵀ M θ̇` (J).
    pub fn kinetic_energy(&self) -> Result<f32, KinematicsError> {
        let m = self.mass_matrix(self.theta_rad)?;
        let w = self.omega_rad_per_s;
        Ok(0.5
            * (w[0] * (m[0][0] * w[0] + m[0][1] * w[1]) + w[1] * (m[1][0] * w[0] + m[1][1] * w[1])))
    }

    fn mass_matrix(&self, theta: [f32; 2]) -> Result<[[f32; 2]; 2], KinematicsError> {
        let j = self.arm.jacobian(theta)?;
        let (ir, mh) = (
            self.params.reflected_inertia_kg_m2,
            self.params.handle_mass_kg,
        );
        let mut m = [[0.0; 2]; 2];
        for a in 0..2 {
            for b in 0..2 {
                let jtj = j.m[0][a] * j.m[0][b] + j.m[1][a] * j.m[1][b];
                m[a][b] = mh * jtj + if a == b { ir } else { 0.0 };
            }
        }
        Ok(m)
    }

    /// Advances the device by `dt_s` with the given motor currents (A, clamped to the
    /// description's limits) and the hand pulling towards `hand_target`. An arm driven into a
    /// singular or unassembled configuration stops there and reports the error (the real one
    /// would hit its end stops).
    pub fn step(
        &mut self,
        motor_currents_a: [f32; 2],
        hand_target: Vec2,
        dt_s: f32,
    ) -> Result<(), KinematicsError> {
        let h = dt_s / self.params.substeps as f32;
        let motor_currents_a = if self.params.command_delay {
            core::mem::replace(&mut self.pending_currents_a, motor_currents_a)
        } else {
            motor_currents_a
        };
        let s = &self.spec;
        let tau_motor = [0, 1].map(|i| {
            let limit = s.current_limit_a[i];
            let current = if motor_currents_a[i].is_finite() {
                motor_currents_a[i].clamp(-limit, limit)
            } else {
                0.0
            };
            s.motor_direction[i].sign()
                * current
                * s.transmission_ratio[i]
                * s.torque_constant_nm_per_a[i]
        });
        for _ in 0..self.params.substeps {
            let config = self.arm.configuration(self.theta_rad)?;
            let j = self.arm.jacobian_at(&config)?;
            let v = j.velocity(self.omega_rad_per_s);
            let hand = if self.held {
                (hand_target - config.hip_in_device) * self.params.hand_stiffness_n_per_m
                    - v * self.params.hand_damping_ns_per_m
            } else {
                Vec2::ZERO
            };
            // Velocity-product term m_h Jᵀ (J̇ θ̇): J̇ θ̇ = d/ds J(θ + s θ̇) θ̇, a forward difference
            // over 10⁻³ rad along θ̇.
            let w = self.omega_rad_per_s;
            let speed = libm::sqrtf(w[0] * w[0] + w[1] * w[1]);
            let coriolis = if speed > 1e-6 {
                let eps = 1e-3 / speed;
                let ahead = [
                    self.theta_rad[0] + eps * w[0],
                    self.theta_rad[1] + eps * w[1],
                ];
                let jdot_w = (self.arm.jacobian(ahead)?.velocity(w) - v) * (1.0 / eps);
                j.torques(jdot_w * self.params.handle_mass_kg)
            } else {
                [0.0; 2]
            };
            let tau_hand = j.torques(hand);
            let m = self.mass_matrix(self.theta_rad)?;
            let rhs = [0, 1].map(|i| {
                tau_motor[i] + tau_hand[i]
                    - coriolis[i]
                    - s.joint_damping_nms_per_rad[i] * self.omega_rad_per_s[i]
            });
            let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
            let acc = [
                (m[1][1] * rhs[0] - m[0][1] * rhs[1]) / det,
                (m[0][0] * rhs[1] - m[1][0] * rhs[0]) / det,
            ];
            // The rates after the other torques, then the friction torques' impulse through
            // the same mass matrix, −h M⁻¹ τ_c sign(ω'); a joint the impulse would reverse
            // stops instead.
            let free = [0, 1].map(|i| self.omega_rad_per_s[i] + acc[i] * h);
            let tau_c = [0, 1].map(|i| {
                if free[i] == 0.0 {
                    0.0
                } else {
                    s.joint_coulomb_nm[i].copysign(free[i])
                }
            });
            let slow = [
                (m[1][1] * tau_c[0] - m[0][1] * tau_c[1]) / det * h,
                (m[0][0] * tau_c[1] - m[1][0] * tau_c[0]) / det * h,
            ];
            for i in 0..2 {
                let after = free[i] - slow[i];
                self.omega_rad_per_s[i] = if after * free[i] <= 0.0 { 0.0 } else { after };
                self.theta_rad[i] += self.omega_rad_per_s[i] * h;
            }
        }
        Ok(())
    }
}
