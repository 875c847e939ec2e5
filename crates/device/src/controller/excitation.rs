//! Identification runs: square waves of joint torque instead of the rendering
//! ([`Controller::excite`](super::Controller::excite)), and the one check a device makes before it runs one.

/// An identification run ([`Controller::excite`](super::Controller::excite)): instead of rendering, the motors apply
/// square waves of joint torque, `±torque_nm[i]` flipping every `half_period_us[i]`, for
/// `duration_us`, starting positive at the first tick after the command. The telemetry shows
/// the motion (the HIP) and the force at the handle, `F = J⁻ᵀ τ`, from which a host recovers
/// the torques (`host::identify`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Excitation {
    /// Square-wave amplitude per joint (N·m).
    pub torque_nm: [f32; 2],
    /// Half-period per joint (µs, > 0).
    pub half_period_us: [u32; 2],
    /// Length of the run (µs, > 0).
    pub duration_us: u64,
}

/// Why a device refuses an identification run ([`Excitation::check`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExcitationRefusal {
    /// The device is not calibrated.
    NotCalibrated,
    /// The torque on joint `joint` (0 or 1) is not finite or beyond the motor's torque at its
    /// current limit ([`DeviceSpec::max_joint_torque_nm`](crate::spec::DeviceSpec::max_joint_torque_nm)).
    TorqueBeyondMotor {
        /// The joint.
        joint: usize,
    },
    /// A half-period or the duration is zero.
    ZeroPeriodOrDuration,
}

impl ExcitationRefusal {
    /// What [`ControllerError::Excitation`](super::ControllerError::Excitation) says.
    pub fn reason(self) -> &'static str {
        match self {
            ExcitationRefusal::NotCalibrated => "not calibrated",
            ExcitationRefusal::TorqueBeyondMotor { joint: 0 } => "torque_nm[0] beyond the motor",
            ExcitationRefusal::TorqueBeyondMotor { .. } => "torque_nm[1] beyond the motor",
            ExcitationRefusal::ZeroPeriodOrDuration => "zero period or duration",
        }
    }
}

impl Excitation {
    /// Whether a device whose joints give at most `max_torque_nm`
    /// ([`DeviceSpec::max_joint_torque_nm`](crate::spec::DeviceSpec::max_joint_torque_nm)) and is `calibrated` or not runs this: the one
    /// check of [`Controller::excite`](super::Controller::excite) and of the link's session, which refuses a run before
    /// it acks it (`crate::session`).
    pub fn check(
        &self,
        max_torque_nm: [f32; 2],
        calibrated: bool,
    ) -> Result<(), ExcitationRefusal> {
        if !calibrated {
            return Err(ExcitationRefusal::NotCalibrated);
        }
        for (joint, (&tau, &most)) in self.torque_nm.iter().zip(&max_torque_nm).enumerate() {
            if !(tau.is_finite() && libm::fabsf(tau) <= most) {
                return Err(ExcitationRefusal::TorqueBeyondMotor { joint });
            }
        }
        if self.half_period_us.contains(&0) || self.duration_us == 0 {
            return Err(ExcitationRefusal::ZeroPeriodOrDuration);
        }
        Ok(())
    }

    /// The joint torques `elapsed_us` into the run.
    pub fn torques_at(&self, elapsed_us: u64) -> [f32; 2] {
        [0, 1].map(|i| {
            let half = u64::from(self.half_period_us[i].max(1));
            if (elapsed_us / half).is_multiple_of(2) {
                self.torque_nm[i]
            } else {
                -self.torque_nm[i]
            }
        })
    }
}

/// A run in progress: what, and the clock reading of its first tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct ExcitationRun {
    pub(super) excitation: Excitation,
    pub(super) started_us: Option<u64>,
}
