//! Device description, encoder and motor conversions, and calibration against the end stops.
//!
//! A [`DeviceSpec`] is to the pantograph what a device specification is in the big haptics
//! SDKs: geometry, sensors, actuators and limits in one `Copy` value, checked once by
//! [`DeviceSpec::validate`].
//!
//! # Drive train
//!
//! Each joint is driven by a motor through a capstan of ratio `n` (joint drum radius over
//! motor pulley radius), with the encoder on the motor shaft:
//!
//! ```text
//! θ = s_enc · (c − c₀) · 2π / (N · n)        c raw counts, c₀ offset, N counts per motor rev
//! I = s_mot · τ / (n · k_t)                  τ joint torque, k_t torque constant
//! ```
//!
//! where `s_enc`, `s_mot` are the [`Direction`] signs that map the wiring onto the
//! counterclockwise joint angles of [`crate::kinematics`].
//!
//! # Calibration procedure
//!
//! Incremental encoders only count relative motion, so the offsets `c₀` are unknown at power
//! up, and a [`Calibration`] starts uncalibrated: it refuses joint angles and motor commands
//! ([`Calibration::joint_angles`], [`DeviceSpec::motor_command`]) until every joint is
//! calibrated, so no force is output before.
//!
//! 1. With the motors off, move the left arm outward (counterclockwise) until it rests on its
//!    end stop, at the known angle `end_stop_rad[0]`, and record the raw count with
//!    [`Calibration::record_end_stop`]`(spec, 0, counts)`.
//! 2. Do the same with the right arm, outward (clockwise), to `end_stop_rad[1]`.
//!    (Or rest both at once and call [`Calibration::record_home`].)
//! 3. Each record sets `c₀ = c_stop − round(s_enc · θ_stop · N · n / 2π)`; once both are set,
//!    [`Calibration::is_calibrated`] is true and [`Calibration::apply`] writes the offsets into
//!    the spec.

pub use crate::error::SpecError;
use crate::error::{finite, positive};
use crate::kinematics::Pantograph;
use core::f32::consts::{PI, TAU};
use core::fmt;
use nurbs::Vec2;

/// Sense of an encoder or a motor relative to the counterclockwise joint angle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// Counts (or positive current) turn the joint counterclockwise.
    Positive,
    /// Counts (or positive current) turn the joint clockwise.
    Negative,
}

impl Direction {
    /// +1 or −1.
    pub fn sign(self) -> f32 {
        match self {
            Direction::Positive => 1.0,
            Direction::Negative => -1.0,
        }
    }
}

/// An axis-aligned box in the device frame (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorkspaceBox {
    /// Lower-left corner (m).
    pub min_in_device: Vec2,
    /// Upper-right corner (m).
    pub max_in_device: Vec2,
}

impl WorkspaceBox {
    /// Whether `p` lies in the box (edges included).
    pub fn contains(&self, p: Vec2) -> bool {
        p.x >= self.min_in_device.x
            && p.x <= self.max_in_device.x
            && p.y >= self.min_in_device.y
            && p.y <= self.max_in_device.y
    }
}

/// Description of a pantograph: geometry, encoders, drive train, motors and limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeviceSpec {
    /// Distance between the motor axes (m).
    pub base_separation_m: f32,
    /// Proximal link lengths `[l1, l2]`, motor axis to elbow (m).
    pub proximal_m: [f32; 2],
    /// Distal link lengths `[b1, b2]`, elbow to HIP (m).
    pub distal_m: [f32; 2],
    /// Largest Jacobian condition number accepted before a configuration counts as singular.
    pub max_condition_number: f32,
    /// Encoder counts per motor revolution (after quadrature decoding).
    pub encoder_counts_per_rev: [u32; 2],
    /// Sense of each encoder.
    pub encoder_direction: [Direction; 2],
    /// Raw count at which each joint angle is zero (written by calibration).
    pub encoder_offset_counts: [i32; 2],
    /// Capstan ratio, motor revolutions per joint revolution.
    pub transmission_ratio: [f32; 2],
    /// Sense of each motor (positive current → positive joint torque for `Positive`).
    pub motor_direction: [Direction; 2],
    /// Motor torque constants (N·m/A).
    pub torque_constant_nm_per_a: [f32; 2],
    /// Largest motor current (A).
    pub current_limit_a: [f32; 2],
    /// Largest force rendered at the HIP (N).
    pub max_force_n: f32,
    /// Largest HIP speed before the safety layer faults (m/s).
    pub max_velocity_m_per_s: f32,
    /// The box the device guarantees to reach, well-conditioned and inside the end stops.
    pub workspace: WorkspaceBox,
    /// Identified viscous damping at each joint (N·m·s/rad), non-negative
    /// ([`DeviceSpec::at_handle`] maps it to the handle).
    pub joint_damping_nms_per_rad: [f32; 2],
    /// Identified Coulomb (dry) friction torque at each joint (N·m), non-negative: motor
    /// brushes and bearings seen through the capstan.
    pub joint_coulomb_nm: [f32; 2],
    /// Joint angle at each outer end stop (rad): the left arm cannot turn counterclockwise
    /// beyond `end_stop_rad[0]`, the right arm not clockwise beyond `end_stop_rad[1]`.
    pub end_stop_rad: [f32; 2],
}

impl Default for DeviceSpec {
    /// A desktop pantograph: motor axes 50 mm apart, 80 mm proximal and 100 mm distal links,
    /// 1024-line encoders (4096 counts/rev) on 23.4 mN·m/A motors behind 10:1 capstans,
    /// 2 A, 3 N, 1 m/s; it reaches x ∈ [−0.05, 0.05] m, y ∈ [0.05, 0.13] m with a Jacobian
    /// condition number below 6.
    fn default() -> Self {
        Self {
            base_separation_m: 0.05,
            proximal_m: [0.08, 0.08],
            distal_m: [0.10, 0.10],
            max_condition_number: crate::kinematics::DEFAULT_MAX_CONDITION,
            encoder_counts_per_rev: [4096, 4096],
            encoder_direction: [Direction::Positive, Direction::Positive],
            encoder_offset_counts: [0, 0],
            transmission_ratio: [10.0, 10.0],
            motor_direction: [Direction::Positive, Direction::Positive],
            torque_constant_nm_per_a: [0.0234, 0.0234],
            current_limit_a: [2.0, 2.0],
            max_force_n: 3.0,
            max_velocity_m_per_s: 1.0,
            workspace: WorkspaceBox {
                min_in_device: Vec2::new(-0.05, 0.05),
                max_in_device: Vec2::new(0.05, 0.13),
            },
            joint_damping_nms_per_rad: [1.0e-4, 1.0e-4],
            // 0.3 mN·m at the motor (a small brushed motor's friction torque) through 10:1.
            joint_coulomb_nm: [3.0e-3, 3.0e-3],
            end_stop_rad: [1.25 * PI, -0.25 * PI],
        }
    }
}

/// Samples per side of the workspace grid checked by [`DeviceSpec::validate`].
const WORKSPACE_GRID: usize = 11;

impl DeviceSpec {
    /// The kinematic model of this device.
    pub fn pantograph(&self) -> Result<Pantograph, SpecError> {
        Pantograph::new(self.base_separation_m, self.proximal_m, self.distal_m)?
            .with_max_condition(self.max_condition_number)
    }

    /// Check every field, then that the workspace box is reached (on an 11 × 11 grid) with
    /// the joints inside their end stops; returns the kinematic model.
    pub fn validate(&self) -> Result<Pantograph, SpecError> {
        let pantograph = self.pantograph()?;
        for i in 0..2 {
            let cpr = self.encoder_counts_per_rev[i];
            if cpr == 0 {
                return Err(SpecError::NonPositive {
                    field: ["encoder_counts_per_rev[0]", "encoder_counts_per_rev[1]"][i],
                    value: 0.0,
                });
            }
            positive(
                ["transmission_ratio[0]", "transmission_ratio[1]"][i],
                self.transmission_ratio[i],
            )?;
            positive(
                ["torque_constant_nm_per_a[0]", "torque_constant_nm_per_a[1]"][i],
                self.torque_constant_nm_per_a[i],
            )?;
            positive(
                ["current_limit_a[0]", "current_limit_a[1]"][i],
                self.current_limit_a[i],
            )?;
            for (field, value) in [
                (
                    [
                        "joint_damping_nms_per_rad[0]",
                        "joint_damping_nms_per_rad[1]",
                    ][i],
                    self.joint_damping_nms_per_rad[i],
                ),
                (
                    ["joint_coulomb_nm[0]", "joint_coulomb_nm[1]"][i],
                    self.joint_coulomb_nm[i],
                ),
            ] {
                finite(field, value)?;
                if value < 0.0 {
                    return Err(SpecError::OutOfRange {
                        field,
                        value,
                        requirement: "non-negative",
                    });
                }
            }
            finite(
                ["end_stop_rad[0]", "end_stop_rad[1]"][i],
                self.end_stop_rad[i],
            )?;
            let counts_per_rad = self.counts_per_joint_rad()[i];
            if counts_per_rad.is_nan() || counts_per_rad * TAU >= i32::MAX as f32 {
                return Err(SpecError::OutOfRange {
                    field: ["transmission_ratio[0]", "transmission_ratio[1]"][i],
                    value: self.transmission_ratio[i],
                    requirement: "such that a joint revolution spans fewer than 2³¹ counts",
                });
            }
        }
        positive("max_force_n", self.max_force_n)?;
        positive("max_velocity_m_per_s", self.max_velocity_m_per_s)?;
        let lo = self.workspace.min_in_device;
        let hi = self.workspace.max_in_device;
        finite("workspace.min_in_device.x", lo.x)?;
        finite("workspace.min_in_device.y", lo.y)?;
        finite("workspace.max_in_device.x", hi.x)?;
        finite("workspace.max_in_device.y", hi.y)?;
        if hi.x <= lo.x {
            return Err(SpecError::OutOfRange {
                field: "workspace.max_in_device.x",
                value: hi.x,
                requirement: "greater than workspace.min_in_device.x",
            });
        }
        if hi.y <= lo.y {
            return Err(SpecError::OutOfRange {
                field: "workspace.max_in_device.y",
                value: hi.y,
                requirement: "greater than workspace.min_in_device.y",
            });
        }
        let step = (hi - lo) / (WORKSPACE_GRID - 1) as f32;
        for i in 0..WORKSPACE_GRID {
            for j in 0..WORKSPACE_GRID {
                let p = lo + Vec2::new(i as f32 * step.x, j as f32 * step.y);
                let joints =
                    pantograph
                        .inverse(p)
                        .map_err(|cause| SpecError::UnreachableWorkspace {
                            point_in_device: p,
                            cause,
                        })?;
                let beyond = [
                    joints[0] > self.end_stop_rad[0],
                    joints[1] < self.end_stop_rad[1],
                ];
                for joint in 0..2 {
                    if beyond[joint] {
                        return Err(SpecError::BeyondEndStop {
                            joint,
                            point_in_device: p,
                            angle_rad: joints[joint],
                            end_stop_rad: self.end_stop_rad[joint],
                        });
                    }
                }
            }
        }
        Ok(pantograph)
    }

    /// What the mechanism itself does at the handle, at the worst pose of the guaranteed
    /// workspace (the 11 × 11 grid [`DeviceSpec::validate`] checks): the figures the
    /// acceptance of a wall counts on ([`crate::wall::check_wall`]). Setup, not the tick
    /// (square roots, f64 inside). See [`AtHandle`].
    pub fn at_handle(&self) -> Result<AtHandle, SpecError> {
        self.at_handle_of(&self.validate()?)
    }

    /// [`DeviceSpec::at_handle`] with the kinematic model `validate` returned (not validated
    /// again).
    pub(crate) fn at_handle_of(&self, pantograph: &Pantograph) -> Result<AtHandle, SpecError> {
        let lo = self.workspace.min_in_device;
        let step = (self.workspace.max_in_device - lo) / (WORKSPACE_GRID - 1) as f32;
        let count_rad = self.counts_per_joint_rad().map(|c| 1.0 / f64::from(c));
        let mut worst = AtHandle {
            damping_n_s_per_m: f32::INFINITY,
            coulomb_n: f32::INFINITY,
            resolution_m: 0.0,
        };
        for i in 0..WORKSPACE_GRID {
            for j in 0..WORKSPACE_GRID {
                let p = lo + Vec2::new(i as f32 * step.x, j as f32 * step.y);
                // `validate` reached every grid point, so these succeed.
                let jac = pantograph
                    .inverse(p)
                    .and_then(|theta| pantograph.jacobian(theta))
                    .map_err(|cause| SpecError::UnreachableWorkspace {
                        point_in_device: p,
                        cause,
                    })?;
                let m = jac.m.map(|row| row.map(f64::from));
                let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
                // J⁻¹: joint rates per handle velocity.
                let inv = [
                    [m[1][1] / det, -m[0][1] / det],
                    [-m[1][0] / det, m[0][0] / det],
                ];
                let scaled = |w: [f64; 2]| {
                    [
                        [w[0] * inv[0][0], w[0] * inv[0][1]],
                        [w[1] * inv[1][0], w[1] * inv[1][1]],
                    ]
                };
                let b = self
                    .joint_damping_nms_per_rad
                    .map(|b| libm::sqrt(f64::from(b)));
                let damping = min_singular_value(scaled(b));
                let coulomb = min_singular_value(scaled(self.joint_coulomb_nm.map(f64::from)));
                let step_m = (0..2).fold(0.0f64, |acc, k| {
                    let column = libm::hypot(m[0][k], m[1][k]);
                    acc.max(column * count_rad[k])
                });
                worst.damping_n_s_per_m = worst.damping_n_s_per_m.min((damping * damping) as f32);
                worst.coulomb_n = worst.coulomb_n.min(coulomb as f32);
                worst.resolution_m = worst.resolution_m.max(step_m as f32);
            }
        }
        Ok(worst)
    }

    /// Encoder counts per joint radian, `N · n / 2π`.
    pub fn counts_per_joint_rad(&self) -> [f32; 2] {
        [0, 1].map(|i| self.encoder_counts_per_rev[i] as f32 * self.transmission_ratio[i] / TAU)
    }

    /// Each joint's torque at its motor's current limit (N·m): `current_limit_a` ×
    /// `torque_constant_nm_per_a` × `transmission_ratio`, the most an identification run may
    /// ask for ([`Excitation::check`](crate::controller::Excitation::check)).
    pub fn max_joint_torque_nm(&self) -> [f32; 2] {
        [0, 1].map(|i| {
            self.current_limit_a[i] * self.torque_constant_nm_per_a[i] * self.transmission_ratio[i]
        })
    }

    /// The raw counts the encoders read with both joints resting on their end stops
    /// ([`DeviceSpec::end_stop_rad`]): what a calibration of an arm on its stops records, and
    /// what the simulated pantograph's calibration uses.
    pub fn end_stop_counts(&self) -> [i32; 2] {
        let per_rad = self.counts_per_joint_rad();
        [0, 1].map(|i| {
            let counts = self.encoder_direction[i].sign() * self.end_stop_rad[i] * per_rad[i];
            self.encoder_offset_counts[i].wrapping_add(libm::floorf(counts) as i32)
        })
    }

    /// Joint angles (rad) from raw encoder counts with the spec's offsets. The count
    /// difference wraps like the 32-bit hardware counter.
    pub fn joint_angles(&self, counts: [i32; 2]) -> [f32; 2] {
        self.joint_angles_with_offsets(counts, self.encoder_offset_counts)
    }

    /// Joint angles (rad) from raw encoder counts and the given offsets.
    pub fn joint_angles_with_offsets(&self, counts: [i32; 2], offsets: [i32; 2]) -> [f32; 2] {
        let per_rad = self.counts_per_joint_rad();
        [0, 1].map(|i| {
            self.encoder_direction[i].sign() * counts[i].wrapping_sub(offsets[i]) as f32
                / per_rad[i]
        })
    }

    /// Motor currents for joint torques (N·m), refused until `calibration` is complete.
    /// Currents over a limit scale both currents by the same factor, which keeps the
    /// direction of the force at the HIP; [`MotorCommand::saturated`] reports it. The spec
    /// must have passed [`DeviceSpec::validate`] (positive limits and constants); then the
    /// currents are finite and within the limits for any torques.
    pub fn motor_command(
        &self,
        calibration: &Calibration,
        joint_torques_nm: [f32; 2],
    ) -> Result<MotorCommand, CommandError> {
        if !calibration.is_calibrated() {
            return Err(CommandError::Uncalibrated);
        }
        let mut current_a = [0.0; 2];
        let mut scale = 1.0_f32;
        let mut saturated = [false; 2];
        for i in 0..2 {
            let tau = joint_torques_nm[i];
            if !tau.is_finite() {
                return Err(CommandError::NonFinite {
                    quantity: ["torque τ1", "torque τ2"][i],
                    value: tau,
                });
            }
            let current = self.motor_direction[i].sign() * tau
                / (self.transmission_ratio[i] * self.torque_constant_nm_per_a[i]);
            if !current.is_finite() {
                return Err(CommandError::NonFinite {
                    quantity: ["current 1", "current 2"][i],
                    value: current,
                });
            }
            let limit = self.current_limit_a[i];
            if current.abs() > limit {
                saturated[i] = true;
                // A comparison, not `f32::min` (a `fminf` call on the M4F): both are finite.
                let cut = limit / current.abs();
                if cut < scale {
                    scale = cut;
                }
            }
            current_a[i] = current;
        }
        Ok(MotorCommand {
            current_a: current_a.map(|c| c * scale),
            saturated,
            scale,
        })
    }
}

/// The mechanism's own damping, friction and resolution seen at the handle, each at the worst
/// pose of the guaranteed workspace ([`DeviceSpec::at_handle`]).
///
/// With `J` the Jacobian (handle velocity per joint rate), the joints' viscous damping
/// `diag(b)` acts at the handle as `J⁻ᵀ diag(b) J⁻¹`, whose smallest eigenvalue is the least
/// damping any direction of motion meets. The joints' Coulomb torques `τ_c` resist a handle
/// velocity `v` with the power `Σ τ_ci |(J⁻¹v)_i| ≥ ‖diag(τ_c) J⁻¹ v‖₂`, so the least friction
/// force along any direction is at least the smallest singular value of `diag(τ_c) J⁻¹`.
/// One encoder count of joint `i` moves the handle by `|J e_i| · 2π / (N n)`: the largest of
/// those is the position quantum Δ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AtHandle {
    /// Least viscous damping at the handle, N·s/m (the `b` of thesis eq. 1.1).
    pub damping_n_s_per_m: f32,
    /// Least Coulomb friction force at the handle, N (the `f_c` of Abbott & Okamura 2005).
    pub coulomb_n: f32,
    /// Largest handle displacement of one encoder count, m (their Δ).
    pub resolution_m: f32,
}

/// Smallest singular value of a 2 × 2 matrix: `σ²_min = (s − √(s² − 4 det²)) / 2`,
/// `s = ‖A‖²_F`, computed as `2 det² / (s + √(s² − 4 det²))` to avoid cancellation.
fn min_singular_value(a: [[f64; 2]; 2]) -> f64 {
    let s = a[0][0] * a[0][0] + a[0][1] * a[0][1] + a[1][0] * a[1][0] + a[1][1] * a[1][1];
    let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    let root = libm::sqrt((s * s - 4.0 * det * det).max(0.0));
    let sum = s + root;
    if sum > 0.0 {
        libm::sqrt(2.0 * det * det / sum)
    } else {
        0.0
    }
}

/// Currents for the two motors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorCommand {
    /// Commanded currents (A), within the limits.
    pub current_a: [f32; 2],
    /// Which joints asked for more than their current limit.
    pub saturated: [bool; 2],
    /// Factor applied to both currents (1 without saturation).
    pub scale: f32,
}

/// Why no motor command was produced (the motors must then be driven with zero current).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CommandError {
    /// The encoders are not calibrated yet.
    Uncalibrated,
    /// A torque is NaN or infinite, or its current overflowed.
    NonFinite {
        /// Which quantity.
        quantity: &'static str,
        /// Its value.
        value: f32,
    },
}

impl fmt::Display for CommandError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            CommandError::Uncalibrated => {
                write!(f, "encoders not calibrated: no force output")
            }
            CommandError::NonFinite { quantity, value } => {
                write!(f, "{quantity} = {value} is not finite")
            }
        }
    }
}

impl core::error::Error for CommandError {}

/// Why a calibration step failed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CalibrationError {
    /// Joint index other than 0 or 1.
    NoSuchJoint {
        /// The index given.
        joint: usize,
    },
    /// The end-stop angle in counts is not representable (non-finite or beyond ±2³¹).
    EndStopOutOfRange {
        /// Joint (0: left, 1: right).
        joint: usize,
        /// The end-stop angle in counts.
        counts: f32,
    },
    /// Joint angles were asked for before both joints were calibrated.
    NotCalibrated {
        /// First joint not calibrated (0: left, 1: right).
        joint: usize,
    },
}

impl fmt::Display for CalibrationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            CalibrationError::NoSuchJoint { joint } => {
                write!(f, "joint index {joint}: the pantograph has joints 0 and 1")
            }
            CalibrationError::EndStopOutOfRange { joint, counts } => write!(
                f,
                "end_stop_rad[{joint}] is {counts} counts: not representable as an encoder count"
            ),
            CalibrationError::NotCalibrated { joint } => {
                write!(f, "joint {} is not calibrated", joint + 1)
            }
        }
    }
}

impl core::error::Error for CalibrationError {}

/// Encoder offsets found at the end stops; uncalibrated at start (see the module docs for the
/// procedure).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Calibration {
    offsets: [Option<i32>; 2],
}

impl Calibration {
    /// Uncalibrated.
    pub const fn new() -> Self {
        Self {
            offsets: [None, None],
        }
    }

    /// Record the raw count `raw_counts` read while `joint` rests on its end stop at
    /// `spec.end_stop_rad[joint]`; returns the offset found.
    pub fn record_end_stop(
        &mut self,
        spec: &DeviceSpec,
        joint: usize,
        raw_counts: i32,
    ) -> Result<i32, CalibrationError> {
        if joint > 1 {
            return Err(CalibrationError::NoSuchJoint { joint });
        }
        let stop_counts = spec.encoder_direction[joint].sign()
            * spec.end_stop_rad[joint]
            * spec.counts_per_joint_rad()[joint];
        // i32::MAX as f32 rounds up to 2³¹, so the bound is strict.
        if stop_counts.is_nan() || stop_counts.abs() >= i32::MAX as f32 {
            return Err(CalibrationError::EndStopOutOfRange {
                joint,
                counts: stop_counts,
            });
        }
        let offset = raw_counts.wrapping_sub(libm::roundf(stop_counts) as i32);
        self.offsets[joint] = Some(offset);
        Ok(offset)
    }

    /// Record both joints resting on their end stops at once.
    pub fn record_home(
        &mut self,
        spec: &DeviceSpec,
        raw_counts: [i32; 2],
    ) -> Result<[i32; 2], CalibrationError> {
        let mut next = *self;
        let a = next.record_end_stop(spec, 0, raw_counts[0])?;
        let b = next.record_end_stop(spec, 1, raw_counts[1])?;
        *self = next;
        Ok([a, b])
    }

    /// Whether both joints are calibrated (force output allowed).
    pub fn is_calibrated(&self) -> bool {
        self.offsets[0].is_some() && self.offsets[1].is_some()
    }

    /// The offsets once both joints are calibrated.
    pub fn offsets(&self) -> Option<[i32; 2]> {
        match self.offsets {
            [Some(a), Some(b)] => Some([a, b]),
            _ => None,
        }
    }

    /// Forget the offsets (back to uncalibrated).
    pub fn reset(&mut self) {
        *self = Self::new();
    }

    /// Write the offsets into `spec.encoder_offset_counts`.
    pub fn apply(&self, spec: &mut DeviceSpec) -> Result<(), CalibrationError> {
        spec.encoder_offset_counts = self.checked_offsets()?;
        Ok(())
    }

    /// Joint angles (rad) from raw counts with the calibrated offsets.
    pub fn joint_angles(
        &self,
        spec: &DeviceSpec,
        counts: [i32; 2],
    ) -> Result<[f32; 2], CalibrationError> {
        Ok(spec.joint_angles_with_offsets(counts, self.checked_offsets()?))
    }

    fn checked_offsets(&self) -> Result<[i32; 2], CalibrationError> {
        match self.offsets {
            [Some(a), Some(b)] => Ok([a, b]),
            [None, _] => Err(CalibrationError::NotCalibrated { joint: 0 }),
            [_, None] => Err(CalibrationError::NotCalibrated { joint: 1 }),
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// The safety layer's default figures are the default pantograph's, to 0.1 %.
    #[test]
    fn the_safety_default_is_the_default_pantograph_at_the_handle() {
        let computed = DeviceSpec::default().at_handle().unwrap();
        let default = crate::wall::PassivityConfig::default().device;
        for (a, b) in [
            (computed.damping_n_s_per_m, default.damping_n_s_per_m),
            (computed.coulomb_n, default.coulomb_n),
            (computed.resolution_m, default.resolution_m),
        ] {
            assert!((a - b).abs() <= 1e-3 * a, "{a} vs {b}");
        }
    }

    /// The figures against a hand computation at one pose: with the grid's worst pose the
    /// damping is at most, and the resolution at least, what the centre of the workspace
    /// gives, `b_j / σ_max(J)²` and `max_i |J e_i| · 2π/(N n)` there.
    #[test]
    fn worst_pose_figures_bound_the_centre_pose() {
        let spec = DeviceSpec::default();
        let figures = spec.at_handle().unwrap();
        let arm = spec.validate().unwrap();
        let centre = (spec.workspace.min_in_device + spec.workspace.max_in_device) * 0.5;
        let j = arm.jacobian(arm.inverse(centre).unwrap()).unwrap().m;
        let m = j.map(|r| r.map(f64::from));
        // σ_max² = largest eigenvalue of JᵀJ.
        let a = m[0][0] * m[0][0] + m[1][0] * m[1][0];
        let d = m[0][1] * m[0][1] + m[1][1] * m[1][1];
        let c = m[0][0] * m[0][1] + m[1][0] * m[1][1];
        let sigma_max_sq = (a + d) / 2.0 + (((a - d) / 2.0).powi(2) + c * c).sqrt();
        let b_centre = 1e-4 / sigma_max_sq;
        assert!(f64::from(figures.damping_n_s_per_m) <= b_centre * 1.0001);
        // The damping bound is tight to a small factor across this workspace (κ ≤ 6).
        assert!(f64::from(figures.damping_n_s_per_m) > b_centre / 10.0);
        let count = std::f64::consts::TAU / (4096.0 * 10.0);
        let step = a.sqrt().max(d.sqrt()) * count;
        assert!(f64::from(figures.resolution_m) >= step * 0.9999);
        // The issue's range: 12–25 µm per count at the handle.
        assert!(
            (12e-6..25e-6).contains(&figures.resolution_m),
            "{figures:?}"
        );
        // Coulomb: τ_c / σ_max at the centre bounds the worst pose from above.
        assert!(f64::from(figures.coulomb_n) <= 3e-3 / sigma_max_sq.sqrt() * 1.0001);
    }
}
