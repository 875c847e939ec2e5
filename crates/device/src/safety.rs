//! The per-tick safety layer between the renderer and the motors.
//!
//! [`Safety::apply`] runs once per haptic tick on the force the renderer asks for and returns
//! the force that may reach the motors. In the order `apply` takes them (a later step never
//! undoes an earlier one):
//!
//! 1. **Passivity observer**: the energy of the interval that just ended is accounted first,
//!    whatever happens to the force after (see [`Safety::observed_energy_j`]).
//! 2. **Faults**, every condition evaluated on every tick and latched:
//!    - *numbers*: any non-finite value anywhere in the [`SafetyInput`] latches
//!      [`Faults::NUMERIC`];
//!    - *thermal*: a first-order thermal model per motor (run whether forces are on or off,
//!      so the motors cool while off) latches [`Faults::THERMAL`] at its trip threshold;
//!    - *encoder*: a joint step larger than the device can physically make in one tick, or
//!      calibrated encoder counts that no pose of the mechanism gives
//!      ([`SafetyInput::pose_valid`]), latch [`Faults::ENCODER`];
//!    - *motion* (only with a pose): HIP speed above the limit latches [`Faults::VELOCITY`],
//!      the HIP outside the workspace box [`Faults::WORKSPACE`];
//!    - *host*: a heartbeat age above the timeout latches [`Faults::WATCHDOG`] on the first
//!      tick past it. The age is an integer interval in microseconds
//!      ([`SafetyInput::heartbeat_age_us`]), never a difference of absolute float times.
//! 3. **Gate**: zero force while any fault is latched, while forces are disabled, while the
//!    device is not calibrated or has no pose.
//! 4. **Shaping** (flags, not faults), in this order: the ramp-in after forces come on
//!    (enable, calibration, cleared faults) or after [`Safety::restart_ramp_and_observer`]
//!    (a scene load, a material change, an acquisition, forces enabled), so a HIP already
//!    inside an object feels the force grow from zero instead of a kick; free space (below)
//!    gets exactly zero; the passivity controller's energy tank; the thermal derating; saturation
//!    to the device's force limit; the force rate limit; a last non-finite guard that cuts
//!    the force and latches [`Faults::NUMERIC`].
//!
//! Free space (the renderer asks for exactly zero: its penalty force is unilateral, zero
//! only out of contact) gets zero force, with no rate-limited tail, so that the
//! mechanism's own damping is all a user feels there. Switching off is immediate (not
//! rate-limited); switching back on starts the ramp-in, whose first tick outputs zero and
//! which reaches the full force after `ramp_time_s`. Faults stay latched until [`Safety::clear_faults`], which clears only
//! the causes whose condition is gone.
//!
//! Passivity has two parts: the load-time wall acceptance of [`crate::wall`]
//! ([`check_wall`], the bounds from the device's own figures a scene loader applies to each
//! material: the sampled-data bound of thesis eq. 1.1 with the device's damping and dry
//! friction, and the encoder quantisation bound; see [`PassivityConfig`]), and, here, a
//! time-domain passivity observer (Hannaford & Ryu 2002) with an energy tank for a
//! controller, enabled per scene with [`Safety::set_passivity_control`], for materials past
//! the first bound and within what the controller is demonstrated to; stiffer ones the device
//! does not render at all. The observer's account is per contact: it
//! restarts at zero in free space.
//!
//! Everything here is `f32`, allocation-free and total: no input makes `apply` panic or
//! return a non-finite force. The tick path has no transcendental functions; a square root
//! is taken only on the rare paths that actually saturate or rate-limit the force.

use core::fmt;

use crate::math;
use crate::wall::{PassivityConfig, PassivityError, check_wall};
use nurbs::Vec2;

bitflags::bitflags! {
    /// Latched force-off causes. Each bit stays set until [`Safety::clear_faults`] finds its
    /// condition gone.
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
    pub struct Faults: u16 {
        /// A non-finite value in the input (or, defensively, in the computed force).
        const NUMERIC = 1 << 0;
        /// HIP speed above [`SafetyConfig::max_velocity_m_per_s`].
        const VELOCITY = 1 << 1;
        /// A joint step larger than [`SafetyConfig::max_joint_rate_rad_per_s`] times the
        /// period in one tick, or
        /// encoder counts that no pose of the mechanism gives.
        const ENCODER = 1 << 2;
        /// No host heartbeat for longer than [`SafetyConfig::heartbeat_timeout_s`].
        const WATCHDOG = 1 << 3;
        /// HIP outside [`SafetyConfig::workspace`].
        const WORKSPACE = 1 << 4;
        /// A motor's thermal state reached [`ThermalConfig::trip_threshold`].
        const THERMAL = 1 << 5;
    }
}

bitflags::bitflags! {
    /// What the shaping stages did to this tick's force. Information, not faults.
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
    pub struct Flags: u8 {
        /// The force was clamped to [`SafetyConfig::max_force_n`].
        const SATURATED = 1 << 0;
        /// The change from the previous tick was clamped to `max_force_rate · period`.
        const RATE_LIMITED = 1 << 1;
        /// The ramp-in after enable or scene swap is still scaling the force.
        const RAMPING = 1 << 2;
        /// The thermal model is derating the force.
        const DERATING = 1 << 3;
        /// The passivity controller limited the force to the energy the contact holds.
        const ENERGY_LIMITED = 1 << 4;
    }
}

/// The names the telemetry, the monitor and the run logs show, lowest bit first, and a
/// `Display` of the set bits joined with `|` (`none` when empty).
macro_rules! bit_names {
    ($name:ident { $($flag:ident => $text:literal,)* }) => {
        impl $name {
            /// Every named bit.
            pub const ALL: Self = Self::all();
            const NAMED: &'static [(Self, &'static str)] = &[$((Self::$flag, $text)),*];

            /// The names of the set bits, lowest bit first.
            pub fn names(self) -> impl Iterator<Item = &'static str> {
                Self::NAMED
                    .iter()
                    .filter(move |(bit, _)| self.contains(*bit))
                    .map(|(_, name)| *name)
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                if self.is_empty() {
                    return f.write_str("none");
                }
                for (i, name) in self.names().enumerate() {
                    if i > 0 {
                        f.write_str("|")?;
                    }
                    f.write_str(name)?;
                }
                Ok(())
            }
        }
    };
}

bit_names!(Faults {
    NUMERIC => "numeric",
    VELOCITY => "velocity",
    ENCODER => "encoder",
    WATCHDOG => "watchdog",
    WORKSPACE => "workspace",
    THERMAL => "thermal",
});

bit_names!(Flags {
    SATURATED => "saturated",
    RATE_LIMITED => "rate-limited",
    RAMPING => "ramping",
    DERATING => "derating",
    ENERGY_LIMITED => "energy",
});

pub use crate::spec::WorkspaceBox;

/// Per-motor first-order thermal model.
///
/// The state θ is the winding temperature rise normalised so that θ = 1 is the steady state
/// of the continuous current rating:
///
/// ```text
/// τ θ' = (I / I_cont)² − θ
/// ```
///
/// discretised exactly for a current held over a tick, `θ ← θ + (u − θ)(1 − e^(−T/τ))`
/// with `u = (I / I_cont)²`, so θ(t) = u (1 − e^(−t/τ)) from cold under a constant current.
/// The current is clamped to the peak rating first (the amplifier cannot deliver more, and a
/// current estimate computed from a pre-saturation torque command can overshoot it).
/// θ ≥ 0 always. Above `derate_threshold` the force is scaled by
/// `(trip − θ) / (trip − derate)`; at `trip_threshold` the fault latches.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThermalConfig {
    /// Continuous current rating, A (θ = 1 in steady state).
    pub continuous_current_a: f32,
    /// Peak current rating, A; larger current estimates are clamped to it.
    pub peak_current_a: f32,
    /// Winding thermal time constant, s.
    pub time_constant_s: f32,
    /// θ above which the force is derated (fraction of the rated rise).
    pub derate_threshold: f32,
    /// θ at which the thermal fault latches; greater than `derate_threshold`.
    pub trip_threshold: f32,
}

impl Default for ThermalConfig {
    fn default() -> Self {
        Self {
            continuous_current_a: 1.0,
            peak_current_a: 3.0,
            time_constant_s: 20.0,
            derate_threshold: 0.8,
            trip_threshold: 1.0,
        }
    }
}

/// The limits the safety layer enforces. Validated once by [`Safety::new`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SafetyConfig {
    /// Tick period T, s.
    pub period_s: f32,
    /// Largest force magnitude the device may output, N.
    pub max_force_n: f32,
    /// Largest change of the force vector per second, N/s (per tick: `max · period`).
    pub max_force_rate_n_per_s: f32,
    /// Ramp-in duration after forces come on or after a scene swap, s; 0 disables the ramp.
    pub ramp_time_s: f32,
    /// Largest HIP speed, m/s, before the velocity fault.
    pub max_velocity_m_per_s: f32,
    /// Largest plausible joint rate, rad/s: a joint-angle change of more than this times the
    /// period in one tick is an encoder glitch. (A rate, so that it means the same at any tick
    /// rate; the default, 50 rad/s, is 0.05 rad per millisecond, and the 1 m/s velocity fault
    /// comes first: it is about 10–20 rad/s at the joints.)
    pub max_joint_rate_rad_per_s: f32,
    /// Host heartbeat timeout, s (default 100 ms); the watchdog compares it, rounded to
    /// whole microseconds once ([`SafetyConfig::heartbeat_timeout_us`]), with integer
    /// intervals.
    pub heartbeat_timeout_s: f32,
    /// Box the HIP must stay inside.
    pub workspace: WorkspaceBox,
    /// Motor thermal model.
    pub thermal: ThermalConfig,
    /// Passivity parameters.
    pub passivity: PassivityConfig,
}

impl Default for SafetyConfig {
    /// Conservative values for the default pantograph at 1 kHz. The workspace box is 1 cm
    /// larger on every side than the box bundled scenes lie in (x ∈ [−0.05, 0.05],
    /// y ∈ [0.05, 0.13]); the device damping is a placeholder until measured.
    fn default() -> Self {
        Self {
            period_s: 1e-3,
            max_force_n: 5.0,
            max_force_rate_n_per_s: 2000.0,
            ramp_time_s: 0.5,
            max_velocity_m_per_s: 1.0,
            max_joint_rate_rad_per_s: 50.0,
            heartbeat_timeout_s: 0.1,
            workspace: WorkspaceBox {
                min_in_device: Vec2::new(-0.06, 0.04),
                max_in_device: Vec2::new(0.06, 0.14),
            },
            thermal: ThermalConfig::default(),
            passivity: PassivityConfig::default(),
        }
    }
}

/// A [`SafetyConfig`] field that is out of range.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConfigError {
    /// The field must be finite and strictly positive.
    NotPositive(&'static str),
    /// The field must be finite and ≥ 0.
    Negative(&'static str),
    /// `workspace.min_in_device` must be finite and below `workspace.max_in_device` on both axes.
    EmptyWorkspace,
    /// `thermal.peak_current_a` must be ≥ `thermal.continuous_current_a`.
    PeakBelowContinuous,
    /// Need 0 < `thermal.derate_threshold` < `thermal.trip_threshold`.
    ThermalThresholds,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NotPositive(field) => write!(f, "safety config: {field} must be finite and > 0"),
            Self::Negative(field) => write!(f, "safety config: {field} must be finite and >= 0"),
            Self::EmptyWorkspace => f.write_str(
                "safety config: workspace.min_in_device must be finite and below workspace.max_in_device",
            ),
            Self::PeakBelowContinuous => f.write_str(
                "safety config: thermal.peak_current_a must be >= thermal.continuous_current_a",
            ),
            Self::ThermalThresholds => f.write_str(
                "safety config: need 0 < thermal.derate_threshold < thermal.trip_threshold",
            ),
        }
    }
}

impl core::error::Error for ConfigError {}

impl SafetyConfig {
    /// The heartbeat timeout in whole microseconds, as the watchdog compares it (at least
    /// 1 µs for a valid config).
    pub fn heartbeat_timeout_us(&self) -> u64 {
        // `as` saturates, so no value makes this wrap.
        (libm::round(f64::from(self.heartbeat_timeout_s) * 1e6) as u64).max(1)
    }

    /// The tick period in whole microseconds, at least 1 (for counting elapsed ticks as
    /// time).
    pub fn period_us(&self) -> u64 {
        (libm::round(f64::from(self.period_s) * 1e6) as u64).max(1)
    }

    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let positive = [
            (self.period_s, "period_s"),
            (self.max_force_n, "max_force_n"),
            (self.max_force_rate_n_per_s, "max_force_rate_n_per_s"),
            (self.max_velocity_m_per_s, "max_velocity_m_per_s"),
            (self.max_joint_rate_rad_per_s, "max_joint_rate_rad_per_s"),
            (self.heartbeat_timeout_s, "heartbeat_timeout_s"),
            (
                self.thermal.continuous_current_a,
                "thermal.continuous_current_a",
            ),
            (self.thermal.peak_current_a, "thermal.peak_current_a"),
            (self.thermal.time_constant_s, "thermal.time_constant_s"),
            (
                self.passivity.impact_speed_m_per_s,
                "passivity.impact_speed_m_per_s",
            ),
            (
                self.passivity.device.resolution_m,
                "passivity.device.resolution_m",
            ),
        ];
        for (value, field) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(ConfigError::NotPositive(field));
            }
        }
        let non_negative = [
            (self.ramp_time_s, "ramp_time_s"),
            (
                self.passivity.device.damping_n_s_per_m,
                "passivity.device.damping_n_s_per_m",
            ),
            (
                self.passivity.device.coulomb_n,
                "passivity.device.coulomb_n",
            ),
            (
                self.passivity.controller_stiffness_n_per_m,
                "passivity.controller_stiffness_n_per_m",
            ),
            (
                self.passivity.controller_damping_ns_per_m,
                "passivity.controller_damping_ns_per_m",
            ),
        ];
        for (value, field) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return Err(ConfigError::Negative(field));
            }
        }
        let ws = self.workspace;
        if !(ws.min_in_device.is_finite()
            && ws.max_in_device.is_finite()
            && ws.min_in_device.cmplt(ws.max_in_device).all())
        {
            return Err(ConfigError::EmptyWorkspace);
        }
        let th = self.thermal;
        if th.peak_current_a < th.continuous_current_a {
            return Err(ConfigError::PeakBelowContinuous);
        }
        if !(th.derate_threshold.is_finite()
            && th.trip_threshold.is_finite()
            && th.derate_threshold > 0.0
            && th.derate_threshold < th.trip_threshold)
        {
            return Err(ConfigError::ThermalThresholds);
        }
        Ok(())
    }
}

/// What the safety layer sees each tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SafetyInput {
    /// Force the renderer asks for, N, on the user, device frame.
    pub force_n: Vec2,
    /// HIP position, m, device frame.
    pub hip_in_device_m: Vec2,
    /// HIP velocity, m/s, device frame.
    pub hip_velocity_m_per_s: Vec2,
    /// Change of each joint angle since the previous tick, rad.
    pub joint_step_rad: [f32; 2],
    /// Time since the last host heartbeat, µs: an integer interval on the board's monotonic
    /// clock, never an absolute time, so uptimes of weeks and counter wraps do not change
    /// what the timeout means. [`Controller`](crate::controller::Controller) measures it as
    /// the larger of the wrapping clock difference (a clock that steps back reads as a huge
    /// age) and the ticks counted since, times the period (a clock that stalls still ages).
    pub heartbeat_age_us: u64,
    /// Motor current per motor, A (measured, or estimated from the previous tick's torque
    /// command); the sign is ignored.
    pub motor_current_a: [f32; 2],
    /// The host or the user has enabled forces.
    pub forces_enabled: bool,
    /// The device is calibrated (encoders homed), so position and velocity mean something.
    pub calibrated: bool,
    /// The encoder counts give a pose the mechanism can be in. When `false` (calibrated),
    /// the position, velocity and joint step are meaningless and [`Faults::ENCODER`]
    /// latches.
    pub pose_valid: bool,
    /// The force is an identification run's excitation, not a wall's: no ramp-in and no
    /// energy tank (the run must apply the torques it was asked for); every fault, the
    /// derating, the saturation and the rate limit apply as always.
    pub identification: bool,
}

impl SafetyInput {
    /// Whether every number in the input is finite.
    pub fn is_finite(&self) -> bool {
        self.force_n.is_finite()
            && self.hip_in_device_m.is_finite()
            && self.hip_velocity_m_per_s.is_finite()
            && self.joint_step_rad.iter().all(|x| x.is_finite())
            && self.motor_current_a.iter().all(|x| x.is_finite())
    }
}

/// What the safety layer lets through this tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SafetyOutput {
    /// Force to apply, N, device frame. Always finite, `|force_n| ≤ max_force_n` (to within
    /// a few ulp of rounding).
    pub force_n: Vec2,
    /// What the shaping stages did.
    pub flags: Flags,
    /// The latched faults after this tick.
    pub faults: Faults,
}

impl SafetyOutput {
    const OFF: Self = Self {
        force_n: Vec2::ZERO,
        flags: Flags::empty(),
        faults: Faults::empty(),
    };
}

/// The safety layer's state. One per device; [`Safety::apply`] once per tick.
#[derive(Clone, Debug)]
pub struct Safety {
    config: SafetyConfig,
    // Derived once from the config so the tick only multiplies and compares.
    max_force_sq: f32,
    max_force_step_n: f32,
    max_joint_step_rad: f32,
    ramp_step: Option<f32>,
    max_speed_sq: f32,
    thermal_gain: f32,
    inv_continuous_sq: f32,
    inv_derate_span: f32,
    heartbeat_timeout_us: u64,

    latched: Faults,
    /// Conditions present at the last tick; `clear_faults` keeps these.
    present: Faults,
    forces_on: bool,
    ramp_ticks: u32,
    last_force_n: Vec2,
    /// The force of the tick before `last_force_n`.
    previous_force_n: Vec2,
    last_position_m: Option<Vec2>,
    /// The HIP's displacement over the last period (zero without two poses).
    last_step_m: Vec2,
    /// The displacement over the period before that.
    step_before_m: Vec2,
    /// The tank ran dry in this contact and the user has not pushed in since.
    drained: bool,
    /// The rendered wall's stiffness (N/m), for the tank's opening balance; 0 when unknown.
    wall_stiffness_n_per_m: f32,
    /// Rendering (re)started since the last free-space tick (a scene load, a material
    /// change, an acquisition, forces on): the next contact force opens the tank with the
    /// spring's stored energy, as the handle may already be inside.
    contact_new: bool,
    thermal: [f32; 2],
    energy_j: f32,
    passivity_control: bool,
}

impl Safety {
    /// A safety layer with no faults latched, forces off until the first enabled tick, motors
    /// cold, passivity controller off.
    pub fn new(config: SafetyConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let th = config.thermal;
        let ramp_step = (config.ramp_time_s > 0.0).then(|| config.period_s / config.ramp_time_s);
        Ok(Self {
            max_force_sq: config.max_force_n * config.max_force_n,
            max_force_step_n: config.max_force_rate_n_per_s * config.period_s,
            max_joint_step_rad: config.max_joint_rate_rad_per_s * config.period_s,
            ramp_step,
            max_speed_sq: config.max_velocity_m_per_s * config.max_velocity_m_per_s,
            thermal_gain: -libm::expm1f(-config.period_s / th.time_constant_s),
            inv_continuous_sq: 1.0 / (th.continuous_current_a * th.continuous_current_a),
            inv_derate_span: 1.0 / (th.trip_threshold - th.derate_threshold),
            heartbeat_timeout_us: config.heartbeat_timeout_us(),
            config,
            latched: Faults::empty(),
            present: Faults::empty(),
            forces_on: false,
            ramp_ticks: 0,
            last_force_n: Vec2::ZERO,
            previous_force_n: Vec2::ZERO,
            last_position_m: None,
            last_step_m: Vec2::ZERO,
            step_before_m: Vec2::ZERO,
            drained: false,
            wall_stiffness_n_per_m: 0.0,
            contact_new: true,
            thermal: [0.0; 2],
            energy_j: 0.0,
            passivity_control: false,
        })
    }

    /// The configuration in force.
    pub fn config(&self) -> &SafetyConfig {
        &self.config
    }

    /// Whether the last tick let force through (no fault, enabled, calibrated).
    pub fn forces_on(&self) -> bool {
        self.forces_on
    }

    /// The latched faults.
    pub fn faults(&self) -> Faults {
        self.latched
    }

    /// The conditions found at the most recent [`apply`](Self::apply) (latched or not).
    pub fn present_conditions(&self) -> Faults {
        self.present
    }

    /// Clears the latched faults whose condition was absent at the most recent
    /// [`apply`](Self::apply), and returns those that stay latched. "Absent" means: the last
    /// input was all finite (numeric); speed within the limit (velocity); joint steps within
    /// the limit (encoder; the caller should re-home if counts may have been lost); heartbeat
    /// age within the timeout (watchdog); HIP inside the box (workspace); both motors cooled
    /// below the *derate* threshold, not just below trip (thermal). Forces come back with a
    /// ramp-in.
    pub fn clear_faults(&mut self) -> Faults {
        self.clear_faults_including_ended(Faults::empty())
    }

    /// [`clear_faults`](Self::clear_faults), and also clears the causes in `ended` even when
    /// their condition was present at the most recent [`apply`](Self::apply): conditions the
    /// caller knows are gone since (a heartbeat received since clears [`Faults::WATCHDOG`]).
    /// A condition still there trips again at the next tick.
    pub fn clear_faults_including_ended(&mut self, ended: Faults) -> Faults {
        self.latched = self.latched & self.present & !ended;
        self.latched
    }

    /// Restarts the ramp-in (the force grows from zero again: a new scene or material, or a
    /// renderer that just started, may put the HIP inside an object) and resets the
    /// passivity observer's energy (it belonged to what was rendered before). The controller
    /// calls it on a scene load, a material change, a completed acquisition and when forces
    /// are enabled.
    pub fn restart_ramp_and_observer(&mut self) {
        self.ramp_ticks = 0;
        self.energy_j = 0.0;
        self.drained = false;
        self.contact_new = true;
    }

    /// [`check_wall`] at this layer's period with its passivity figures.
    pub fn check_wall(
        &self,
        stiffness_n_per_m: f32,
        damping_ns_per_m: f32,
        controller: bool,
    ) -> Result<(), PassivityError> {
        check_wall(
            stiffness_n_per_m,
            damping_ns_per_m,
            self.config.period_s,
            &self.config.passivity,
            controller,
        )
    }

    /// The stiffness of the wall being rendered (N/m): when rendering (re)starts with the
    /// handle inside (a scene load, a material change, forces on, a fault cleared), the tank
    /// opens with the energy a spring of this stiffness gives back from the depth of the first
    /// force, `d = |F| / K`, capped at the force limit as the device applies it: `½ K d²`
    /// while `K d ≤ F_max`, `F_max² / 2K + F_max (d − F_max / K)` beyond (the uncapped
    /// `½ K d²` would let the wall throw the handle out with more than it can hold), so the
    /// wall may push the handle out. A contact entered from free space opens empty (the
    /// user's work pushing in fills it). 0 or non-finite: the tank always opens empty.
    pub fn set_wall_stiffness(&mut self, stiffness_n_per_m: f32) {
        self.wall_stiffness_n_per_m = if stiffness_n_per_m.is_finite() && stiffness_n_per_m > 0.0 {
            stiffness_n_per_m
        } else {
            0.0
        };
    }

    /// Turns the passivity controller on or off (per scene: on for scenes whose materials
    /// fail the passivity bound of [`check_wall`]). The observer runs either way.
    pub fn set_passivity_control(&mut self, enabled: bool) {
        self.passivity_control = enabled;
    }

    /// Whether the passivity controller is on.
    pub fn passivity_control(&self) -> bool {
        self.passivity_control
    }

    /// The passivity observer's energy, J: the energy the user has put into the rendered
    /// environment since forces came on or the scene changed. Negative means the environment
    /// has delivered more energy to the user than it received (it is active).
    pub fn observed_energy_j(&self) -> f32 {
        self.energy_j
    }

    /// Each motor's normalised thermal state θ (1 = steady state at continuous current).
    pub fn thermal_state(&self) -> [f32; 2] {
        self.thermal
    }

    /// One tick: evaluates every condition, latches faults, and shapes the renderer's force.
    pub fn apply(&mut self, input: &SafetyInput) -> SafetyOutput {
        // The observer accounts for the interval that just ended, before any gating.
        self.observe_energy(input);
        let cfg = &self.config;
        let finite = input.is_finite();
        // Conditions that latch a fault now, and those that block clearing it.
        let mut trip = Faults::empty();
        let mut present = Faults::empty();
        if !finite {
            trip |= Faults::NUMERIC;
        }

        // Thermal model runs every tick, forces on or off, so the motors cool while off.
        if input.motor_current_a.iter().all(|i| i.is_finite()) {
            let peak = cfg.thermal.peak_current_a;
            for (theta, current) in self.thermal.iter_mut().zip(input.motor_current_a) {
                let i = math::min(peak, libm::fabsf(current));
                let steady = i * i * self.inv_continuous_sq;
                *theta = math::max(0.0, *theta + (steady - *theta) * self.thermal_gain);
            }
        }
        let theta = math::max(self.thermal[0], self.thermal[1]);
        if theta >= cfg.thermal.trip_threshold {
            trip |= Faults::THERMAL;
        }
        if theta > cfg.thermal.derate_threshold {
            present |= Faults::THERMAL;
        }

        if input
            .joint_step_rad
            .iter()
            .any(|s| libm::fabsf(*s) > self.max_joint_step_rad)
        {
            trip |= Faults::ENCODER;
        }
        // Before homing no pose is known and forces are off anyway; after it, counts that no
        // pose of the mechanism produces are an encoder fault like a jump.
        let pose_known = input.calibrated && input.pose_valid;
        if input.calibrated && !input.pose_valid {
            trip |= Faults::ENCODER;
        }
        // Position and velocity are meaningless without a pose.
        if pose_known {
            if input.hip_velocity_m_per_s.length_squared() > self.max_speed_sq {
                trip |= Faults::VELOCITY;
            }
            // NaN fails `contains`, but NaN is already a numeric fault.
            if input.hip_in_device_m.is_finite() && !cfg.workspace.contains(input.hip_in_device_m) {
                trip |= Faults::WORKSPACE;
            }
        }
        if input.heartbeat_age_us > self.heartbeat_timeout_us {
            trip |= Faults::WATCHDOG;
        }
        present |= trip;
        self.present = present;
        self.latched |= trip;

        if !(finite && self.latched.is_empty() && input.forces_enabled && pose_known) {
            self.forces_on = false;
            self.hold(Vec2::ZERO);
            return SafetyOutput {
                faults: self.latched,
                ..SafetyOutput::OFF
            };
        }
        if !self.forces_on {
            self.forces_on = true;
            self.ramp_ticks = 0;
            self.energy_j = 0.0;
            self.drained = false;
            self.contact_new = true;
        }

        let mut flags = Flags::empty();
        let ramp = match self.ramp_step {
            Some(step) => math::min(1.0, self.ramp_ticks as f32 * step),
            None => 1.0,
        };
        if ramp < 1.0 {
            flags |= Flags::RAMPING;
            self.ramp_ticks = self.ramp_ticks.saturating_add(1);
        }
        // Free space: the renderer asks for nothing, so nothing is applied (no rate-limited
        // tail: the mechanism's own damping is all the user feels), and the
        // rendered environment, a penalty spring at zero depth, stores no energy, so the
        // tank starts the next contact from zero instead of holding back a new contact for
        // energy the last one delivered.
        if input.force_n == Vec2::ZERO {
            self.hold(Vec2::ZERO);
            self.energy_j = 0.0;
            self.drained = false;
            // A contact entered from here opens with an empty tank: the user's work pushing
            // in is what fills it (a sampled wall that was at zero force over the entering
            // tick received none).
            self.contact_new = false;
            return SafetyOutput {
                force_n: Vec2::ZERO,
                flags,
                faults: self.latched,
            };
        }
        let ramp = if input.identification { 1.0 } else { ramp };
        let mut force = input.force_n * ramp;

        if self.contact_new {
            self.contact_new = false;
            if self.wall_stiffness_n_per_m > 0.0 {
                // What the wall can give back from where the handle is: the requested (not yet
                // ramped) force's depth, at the force the device can apply.
                self.energy_j = capped_wall_energy_j(
                    input.force_n,
                    self.config.max_force_n,
                    self.max_force_sq,
                    self.wall_stiffness_n_per_m,
                );
            }
        }
        if self.passivity_control && !input.identification {
            let limited = self.limit_to_energy(force);
            if limited != force {
                force = limited;
                flags |= Flags::ENERGY_LIMITED;
            }
        }

        let cfg = &self.config;
        if theta > cfg.thermal.derate_threshold {
            let scale =
                ((cfg.thermal.trip_threshold - theta) * self.inv_derate_span).clamp(0.0, 1.0);
            force *= scale;
            flags |= Flags::DERATING;
        }

        if !force.is_finite() || force.length_squared() > self.max_force_sq {
            force = clamp_length(force, cfg.max_force_n);
            flags |= Flags::SATURATED;
        }

        let delta = force - self.last_force_n;
        if delta.length_squared() > self.max_force_step_n * self.max_force_step_n {
            force = self.last_force_n + clamp_length(delta, self.max_force_step_n);
            flags |= Flags::RATE_LIMITED;
            // The rate limiter must not hold back the tank's cut: a force it keeps above
            // what the tank allowed does work the contact never received (at 1 kHz and
            // 2000 N/s, a cut from 3 N to 0 takes two ticks, the first 1 N over the tank).
            // Such a force is dropped for this tick, as free space drops it (the one step
            // the rate limit lets through: towards nothing); a kick upwards stays limited.
            if flags.contains(Flags::ENERGY_LIMITED) && self.energy_scale(force) < 1.0 {
                force = Vec2::ZERO;
            }
        }

        if !force.is_finite() {
            // Unreachable for a valid config; kept so no path can send NaN to the motors.
            self.latched |= Faults::NUMERIC;
            self.forces_on = false;
            self.hold(Vec2::ZERO);
            return SafetyOutput {
                faults: self.latched,
                ..SafetyOutput::OFF
            };
        }
        self.hold(force);
        SafetyOutput {
            force_n: force,
            flags,
            faults: self.latched,
        }
    }

    /// Passivity observer. Sign convention: E is the energy that flowed *into* the rendered
    /// environment from the user, so energy flowing out of the device into the user is
    /// negative and a passive environment keeps E ≥ 0. Per tick, `E −= F · Δx`, where F is the
    /// force that was held (zero-order hold) over the last period and Δx the HIP displacement
    /// over that same period, i.e. `F · v · T` with v the backward-difference velocity. Pairing
    /// the held force with the displacement it acted through is what makes the observer see
    /// the sampled-data leak; `F[k] · v[k]` at the same sample would not.
    fn observe_energy(&mut self, input: &SafetyInput) {
        let position = input.hip_in_device_m;
        if !(input.pose_valid && position.is_finite()) {
            self.last_position_m = None;
            return;
        }
        if let Some(previous) = self.last_position_m {
            let step = position - previous;
            // The force that acted over the interval: this tick's, or on a board whose output
            // lags a tick (`PassivityConfig::output_delay_ticks`), the one before.
            let acting = if self.config.passivity.output_delay_ticks > 0 {
                self.previous_force_n
            } else {
                self.last_force_n
            };
            let work_on_user_j = acting.dot(step);
            if work_on_user_j != 0.0 {
                let energy = self.energy_j - work_on_user_j;
                self.energy_j = if energy.is_finite() { energy } else { 0.0 };
            }
            self.step_before_m = self.last_step_m;
            self.last_step_m = step;
        } else {
            self.step_before_m = Vec2::ZERO;
            self.last_step_m = Vec2::ZERO;
        }
        self.last_position_m = Some(position);
    }
}

impl Safety {
    /// The factor (1 when it fits, less when not, 0 for an empty tank) that brings the work
    /// `force` is predicted to do on the user over the period it acts (from the last
    /// displacements) within the tank's energy, less what the force already held will still
    /// do with an output delay.
    fn energy_scale(&self, force: Vec2) -> f32 {
        let delayed = self.config.passivity.output_delay_ticks > 0;
        // With an output delay the force held now still acts over the next period: its work is
        // already spent.
        let pending_j = if delayed {
            math::max(0.0, self.last_force_n.dot(self.next_step_m(1.0)))
        } else {
            0.0
        };
        let budget_j = math::max(self.energy_j - pending_j, 0.0);
        let ahead = if delayed { 2.0 } else { 1.0 };
        let predicted_j = force.dot(self.next_step_m(ahead));
        if predicted_j > budget_j {
            budget_j / predicted_j
        } else {
            1.0
        }
    }

    /// The displacement over the period `periods` ahead of the last one, extrapolated
    /// linearly from the last two (the motion's acceleration counted: a bounce reverses within
    /// a few periods, and the last step alone misjudges the work a held force does there).
    fn next_step_m(&self, periods: f32) -> Vec2 {
        self.last_step_m + (self.last_step_m - self.step_before_m) * periods
    }

    /// Records the force this tick holds until the next.
    fn hold(&mut self, force: Vec2) {
        self.previous_force_n = self.last_force_n;
        self.last_force_n = force;
    }

    /// The energy tank (see [`PassivityConfig`]): `force` as far as the contact's energy pays
    /// for it. The work it would do on the user over the next period is predicted from the
    /// last displacement, `W = F · Δx`; when `W` exceeds the energy the user has put in, `E`
    /// (less what the force already held will still do, with an output delay), the force is
    /// scaled to `E / W` of itself (to zero when the tank is empty). Once the tank has run dry
    /// the force grows back only as a spring of the wall's stiffness would from where it
    /// stands, by K per metre the user pushes in (a handle at rest inside a wall that has
    /// already given back what it received gets no new push, which would be a pulse, then a
    /// cut, then a pulse), until it meets the wall's own force again.
    fn limit_to_energy(&mut self, force: Vec2) -> Vec2 {
        let scale = self.energy_scale(force);
        let mut limited = force;
        if scale < 1.0 {
            limited = force * scale;
            self.drained = true;
        }
        if self.drained {
            // |F| grows back only as a spring of the wall's stiffness would from where it is:
            // by K per metre the user pushes in against it (zero when the handle rests or
            // moves out). Square roots only here, in the drained state.
            let now = math::sqrt(limited.length_squared());
            let pushed_in_m = if now > 0.0 {
                math::max(0.0, -limited.dot(self.last_step_m) / now)
            } else {
                0.0
            };
            let cap = math::sqrt(self.last_force_n.length_squared())
                + self.wall_stiffness_n_per_m * pushed_in_m;
            if now > cap {
                limited *= cap / now;
            } else if limited == force {
                // Caught up with the wall: the tank governs alone again.
                self.drained = false;
            }
        }
        limited
    }
}

/// The energy a penalty wall of stiffness `k` whose force the device caps at `f_max` gives
/// back to a handle it pushes out from the depth `d = |f| / k` at which it asks for `f`: the
/// work of `min(k x, f_max)` from `x = d` to 0,
///
/// ```text
/// ∫₀ᵈ min(k x, f_max) dx = k d² / 2 = |f|² / 2k                             for |f| ≤ f_max,
///                        = f_max² / 2k + f_max (d − f_max / k)
///                        = f_max (2 |f| − f_max) / 2k                       beyond,
/// ```
///
/// the first part the triangle up to the depth `f_max / k` where the cap starts, the second
/// the rectangle beyond it. `f_max_sq` is `f_max²`; the square root is taken only beyond the
/// cap, once per contact. 0 for a non-finite `f`.
fn capped_wall_energy_j(f: Vec2, f_max: f32, f_max_sq: f32, k: f32) -> f32 {
    let f_sq = f.length_squared();
    let energy = if f_sq <= f_max_sq {
        f_sq / (2.0 * k)
    } else {
        f_max * (2.0 * math::sqrt(f_sq) - f_max) / (2.0 * k)
    };
    if energy.is_finite() { energy } else { 0.0 }
}

/// `v` scaled to length `max` if longer, for any `v` with finite or infinite components (NaN
/// gives zero). Takes one square root; called only when the caller has found `v` too long.
fn clamp_length(v: Vec2, max: f32) -> Vec2 {
    if v.is_nan() {
        return Vec2::ZERO;
    }
    // Scale into [−1, 1] first so |v|² cannot overflow.
    let largest = math::max(libm::fabsf(v.x), libm::fabsf(v.y));
    if largest == 0.0 {
        return Vec2::ZERO;
    }
    let unit = if largest.is_finite() {
        v / largest
    } else {
        Vec2::new(
            if v.x.is_infinite() { v.x.signum() } else { 0.0 },
            if v.y.is_infinite() { v.y.signum() } else { 0.0 },
        )
    };
    let length = math::sqrt(unit.length_squared());
    if length * largest <= max {
        return v;
    }
    unit * (max / length)
}
