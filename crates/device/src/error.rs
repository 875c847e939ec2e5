//! The error types the kinematic model and the device description share: one home, so that
//! `kinematics` (which reports a bad link length as a [`SpecError`]) and `spec` (which reports
//! an unreachable workspace with its [`KinematicsError`]) depend on this module and not on
//! each other. Both modules re-export what they return.

use core::fmt;
use nurbs::Vec2;

/// Why a kinematic computation has no answer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum KinematicsError {
    /// An input is NaN or infinite, or a result overflowed.
    NonFinite {
        /// Which quantity (e.g. `"joint angle θ1"`, `"force x"`).
        quantity: &'static str,
        /// Its value.
        value: f32,
    },
    /// Forward kinematics: a joint angle is finite but farther from zero than
    /// [`crate::math::SIN_COS_MAX_ANGLE_RAD`] (thousands of revolutions: no pose of the
    /// mechanism, an encoder or calibration fault), where the tick's `sin`/`cos` lose their
    /// error bound.
    AngleOutOfRange {
        /// Which quantity (e.g. `"joint angle θ1"`).
        quantity: &'static str,
        /// Its value (rad).
        value_rad: f32,
        /// The largest magnitude accepted (rad).
        max_rad: f32,
    },
    /// Forward kinematics: both elbows are at the same point, so the distal links can turn
    /// freely about it.
    ElbowsCoincide {
        /// Distance between the elbows (m).
        elbow_distance_m: f32,
    },
    /// Forward kinematics: the distal links cannot meet (the circles about the elbows do not
    /// intersect).
    DistalLinksApart {
        /// Distance between the elbows (m).
        elbow_distance_m: f32,
        /// Smallest elbow distance at which they meet, `|b1 − b2|` (m).
        min_m: f32,
        /// Largest elbow distance at which they meet, `b1 + b2` (m).
        max_m: f32,
    },
    /// Inverse kinematics: the target is farther from a motor axis than its arm reaches.
    TooFar {
        /// Joint (0: left, 1: right).
        joint: usize,
        /// Distance from the motor axis to the target (m).
        distance_m: f32,
        /// Reach `li + bi` (m).
        max_m: f32,
    },
    /// Inverse kinematics: the target is closer to a motor axis than its arm can fold.
    TooClose {
        /// Joint (0: left, 1: right).
        joint: usize,
        /// Distance from the motor axis to the target (m).
        distance_m: f32,
        /// Shortest reach `|li − bi|` (m).
        min_m: f32,
    },
    /// Inverse kinematics: in the elbows-out working mode the distal links cross, so the
    /// device would be in the other assembly mode than forward kinematics assumes.
    OtherAssemblyMode {
        /// Target x (m).
        x_m: f32,
        /// Target y (m).
        y_m: f32,
    },
    /// The Jacobian is (near) singular: its condition number exceeds the limit.
    Singular {
        /// Which links are (nearly) aligned.
        singularity: Singularity,
        /// Condition number of the Jacobian (infinite when exactly singular).
        condition: f32,
        /// The accepted limit.
        max_condition: f32,
    },
}

/// Which links are aligned in a singular configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Singularity {
    /// A proximal link is aligned with its distal link (arm stretched or folded): the
    /// workspace boundary, where the HIP cannot move (or be pushed) along the arm.
    ArmAligned {
        /// Joint (0: left, 1: right).
        joint: usize,
    },
    /// The two distal links are aligned: the HIP can move with the motors held.
    DistalLinksAligned,
}

impl fmt::Display for Singularity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Singularity::ArmAligned { joint } => {
                write!(f, "proximal and distal links of arm {} aligned", joint + 1)
            }
            Singularity::DistalLinksAligned => write!(f, "distal links aligned"),
        }
    }
}

impl fmt::Display for KinematicsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            KinematicsError::NonFinite { quantity, value } => {
                write!(f, "{quantity} = {value} is not finite")
            }
            KinematicsError::AngleOutOfRange {
                quantity,
                value_rad,
                max_rad,
            } => write!(
                f,
                "{quantity} = {value_rad} rad is beyond ±{max_rad} rad: no pose of the mechanism"
            ),
            KinematicsError::ElbowsCoincide { elbow_distance_m } => write!(
                f,
                "elbows coincide ({elbow_distance_m} m apart): the distal links can turn freely"
            ),
            KinematicsError::DistalLinksApart {
                elbow_distance_m,
                min_m,
                max_m,
            } => write!(
                f,
                "distal links cannot meet: elbows {elbow_distance_m} m apart, must be within [{min_m}, {max_m}] m"
            ),
            KinematicsError::TooFar {
                joint,
                distance_m,
                max_m,
            } => write!(
                f,
                "target out of reach: {distance_m} m from motor axis {} exceeds reach {max_m} m",
                joint + 1
            ),
            KinematicsError::TooClose {
                joint,
                distance_m,
                min_m,
            } => write!(
                f,
                "target too close: {distance_m} m from motor axis {} is under the shortest reach {min_m} m",
                joint + 1
            ),
            KinematicsError::OtherAssemblyMode { x_m, y_m } => write!(
                f,
                "target ({x_m}, {y_m}) m needs crossed distal links (other assembly mode)"
            ),
            KinematicsError::Singular {
                singularity,
                condition,
                max_condition,
            } => write!(
                f,
                "singular configuration ({singularity}): Jacobian condition number {condition} exceeds {max_condition}"
            ),
        }
    }
}

impl core::error::Error for KinematicsError {}

/// Why a [`DeviceSpec`](crate::spec::DeviceSpec) was rejected.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SpecError {
    /// A field is NaN or infinite.
    NonFinite {
        /// Field name.
        field: &'static str,
        /// Its value.
        value: f32,
    },
    /// A field that must be positive is zero or negative.
    NonPositive {
        /// Field name.
        field: &'static str,
        /// Its value.
        value: f32,
    },
    /// A field is outside its range.
    OutOfRange {
        /// Field name.
        field: &'static str,
        /// Its value.
        value: f32,
        /// What it must be.
        requirement: &'static str,
    },
    /// A point of the workspace box cannot be reached well-conditioned.
    UnreachableWorkspace {
        /// The point (m).
        point_in_device: Vec2,
        /// Why inverse kinematics failed there.
        cause: KinematicsError,
    },
    /// A point of the workspace box needs a joint beyond its end stop.
    BeyondEndStop {
        /// Joint (0: left, 1: right).
        joint: usize,
        /// The point (m).
        point_in_device: Vec2,
        /// Joint angle it needs (rad).
        angle_rad: f32,
        /// The end stop (rad).
        end_stop_rad: f32,
    },
}

impl fmt::Display for SpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            SpecError::NonFinite { field, value } => write!(f, "{field} = {value}: not finite"),
            SpecError::NonPositive { field, value } => {
                write!(f, "{field} = {value}: must be positive")
            }
            SpecError::OutOfRange {
                field,
                value,
                requirement,
            } => write!(f, "{field} = {value}: must be {requirement}"),
            SpecError::UnreachableWorkspace {
                point_in_device: p,
                cause,
            } => write!(
                f,
                "workspace: point ({}, {}) m unreachable: {cause}",
                p.x, p.y
            ),
            SpecError::BeyondEndStop {
                joint,
                point_in_device: p,
                angle_rad,
                end_stop_rad,
            } => write!(
                f,
                "workspace: point ({}, {}) m needs joint {} at {angle_rad} rad, beyond end_stop_rad[{joint}] = {end_stop_rad} rad",
                p.x,
                p.y,
                joint + 1
            ),
        }
    }
}

impl core::error::Error for SpecError {}

pub(crate) fn finite(field: &'static str, value: f32) -> Result<(), SpecError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(SpecError::NonFinite { field, value })
    }
}

pub(crate) fn positive(field: &'static str, value: f32) -> Result<(), SpecError> {
    finite(field, value)?;
    if value > 0.0 {
        Ok(())
    } else {
        Err(SpecError::NonPositive { field, value })
    }
}
