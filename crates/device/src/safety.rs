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
//!    gets exactly zero; the passivity controller's damper; the thermal derating; saturation
//!    to the device's force limit; the force rate limit; a last non-finite guard that cuts
//!    the force and latches [`Faults::NUMERIC`].
//!
//! Free space (the renderer asks for exactly zero: its penalty force is unilateral, zero
//! only out of contact) gets zero force, with no damper and no rate-limited tail, so that the
//! mechanism's own damping is all a user feels there. Switching off is immediate (not
//! rate-limited); switching back on starts the ramp-in, whose first tick outputs zero and
//! which reaches the full force after `ramp_time_s`. Faults stay latched until [`Safety::clear_faults`], which clears only
//! the causes whose condition is gone.
//!
//! Passivity has two parts: [`check_passivity`], the sampled-data bound a scene loader applies
//! to each material (thesis eq. 1.1), and a time-domain passivity observer/controller
//! (Hannaford & Ryu 2002) enabled per scene with [`Safety::set_passivity_control`], for
//! materials between that bound and [`Safety::check_renderable`] (the same bound with a
//! relaxed grip's damping added); stiffer ones the device does not render at all. The
//! observer's account is per contact: it restarts at zero in free space.
//!
//! Everything here is `f32`, allocation-free and total: no input makes `apply` panic or
//! return a non-finite force. The tick path has no transcendental functions; a square root
//! is taken only on the rare paths that actually saturate or rate-limit the force.

use core::fmt;

use crate::math;
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
        /// A joint step larger than [`SafetyConfig::max_joint_step_rad`] in one tick, or
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
        /// The passivity controller added damping.
        const DAMPING = 1 << 4;
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
    DAMPING => "damping",
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

/// Parameters of the sampled-data passivity check and the passivity observer/controller.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PassivityConfig {
    /// The mechanism's physical damping b, N·s/m (thesis eq. 1.1).
    pub device_damping_n_s_per_m: f32,
    /// Floor on the speed in the controller's α = −E / (T |v|²), m/s, so it never divides by
    /// zero at rest.
    pub min_speed_m_per_s: f32,
    /// Cap on the controller's damping α, N·s/m. A rendered damper is itself subject to
    /// eq. 1.1, so an unbounded α chatters on velocity noise.
    pub max_damping_n_s_per_m: f32,
    /// The damping a relaxed grip adds at the handle, N·s/m: the most the passivity
    /// controller may count on. With it on, a wall is rendered only while eq. 1.1 holds for
    /// the device and the grip together, `b + b_grip > K T / 2 + |B|`
    /// ([`Safety::check_renderable`]); a stiffer wall is active unless the hand damps more
    /// than a relaxed grip, and closed through the simulated pantograph it bounces (the
    /// stiffness sweep in `tests/tests/closed_loop.rs`): the observer's damper, acting on
    /// velocity quantised by the encoders, does not stop that.
    pub grip_damping_n_s_per_m: f32,
}

impl Default for PassivityConfig {
    fn default() -> Self {
        Self {
            device_damping_n_s_per_m: 0.5,
            min_speed_m_per_s: 1e-3,
            max_damping_n_s_per_m: 50.0,
            // The low end of a human grip's damping on a stylus (a few N·s/m), and the
            // simulated pantograph's default hand.
            grip_damping_n_s_per_m: 2.0,
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
    /// Largest plausible joint-angle change in one tick, rad; more is an encoder glitch.
    pub max_joint_step_rad: f32,
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
            max_joint_step_rad: 0.05,
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
            (self.max_joint_step_rad, "max_joint_step_rad"),
            (self.heartbeat_timeout_s, "heartbeat_timeout_s"),
            (
                self.thermal.continuous_current_a,
                "thermal.continuous_current_a",
            ),
            (self.thermal.peak_current_a, "thermal.peak_current_a"),
            (self.thermal.time_constant_s, "thermal.time_constant_s"),
            (
                self.passivity.min_speed_m_per_s,
                "passivity.min_speed_m_per_s",
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
                self.passivity.device_damping_n_s_per_m,
                "passivity.device_damping_n_s_per_m",
            ),
            (
                self.passivity.max_damping_n_s_per_m,
                "passivity.max_damping_n_s_per_m",
            ),
            (
                self.passivity.grip_damping_n_s_per_m,
                "passivity.grip_damping_n_s_per_m",
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

/// A material that the sampled-data passivity bound rejects, or bad arguments.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PassivityError {
    /// `b > K T / 2 + |B|` fails: the stiffness is above the largest renderable one.
    TooStiff {
        /// The stiffness asked for, N/m.
        stiffness_n_per_m: f32,
        /// The largest stiffness that passes, `2 (b − |B|) / T`, N/m (0 when `|B| ≥ b`).
        max_stiffness_n_per_m: f32,
    },
    /// An argument is non-finite or out of range (stiffness < 0, period ≤ 0, b < 0).
    InvalidParameter(&'static str),
}

impl fmt::Display for PassivityError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::TooStiff {
                stiffness_n_per_m,
                max_stiffness_n_per_m,
            } => write!(
                f,
                "stiffness {stiffness_n_per_m:.1} N/m is not passive on this device: the limit is \
                 {max_stiffness_n_per_m:.1} N/m (b > K T / 2 + |B|); lower it or enable the \
                 passivity controller"
            ),
            Self::InvalidParameter(name) => write!(f, "passivity check: invalid {name}"),
        }
    }
}

impl core::error::Error for PassivityError {}

/// Largest stiffness a sampled-data spring–damper can render passively,
/// `K_max = 2 (b − |B|) / T` (thesis eq. 1.1 solved for K), clamped at 0.
pub fn max_passive_stiffness(
    damping_n_s_per_m: f32,
    period_s: f32,
    device_damping_n_s_per_m: f32,
) -> f32 {
    (2.0 * (device_damping_n_s_per_m - libm::fabsf(damping_n_s_per_m)) / period_s).max(0.0)
}

/// Thesis eq. (1.1), after Colgate & Schenkel: a virtual wall of stiffness K and damping B
/// sampled at period T with zero-order hold on a device of physical damping b is passive iff
/// `b > K T / 2 + |B|`. The error carries the limit `2 (b − |B|) / T` for the scene loader's
/// message.
pub fn check_passivity(
    stiffness_n_per_m: f32,
    damping_n_s_per_m: f32,
    period_s: f32,
    device_damping_n_s_per_m: f32,
) -> Result<(), PassivityError> {
    if !(stiffness_n_per_m.is_finite() && stiffness_n_per_m >= 0.0) {
        return Err(PassivityError::InvalidParameter("stiffness"));
    }
    if !damping_n_s_per_m.is_finite() {
        return Err(PassivityError::InvalidParameter("damping"));
    }
    if !(period_s.is_finite() && period_s > 0.0) {
        return Err(PassivityError::InvalidParameter("period"));
    }
    if !(device_damping_n_s_per_m.is_finite() && device_damping_n_s_per_m >= 0.0) {
        return Err(PassivityError::InvalidParameter("device damping"));
    }
    let max_stiffness_n_per_m =
        max_passive_stiffness(damping_n_s_per_m, period_s, device_damping_n_s_per_m);
    // Strict: the bound is an open inequality, and K = 0 with |B| = b is marginal.
    if stiffness_n_per_m < max_stiffness_n_per_m {
        Ok(())
    } else {
        Err(PassivityError::TooStiff {
            stiffness_n_per_m,
            max_stiffness_n_per_m,
        })
    }
}

/// The safety layer's state. One per device; [`Safety::apply`] once per tick.
#[derive(Clone, Debug)]
pub struct Safety {
    config: SafetyConfig,
    // Derived once from the config so the tick only multiplies and compares.
    max_force_sq: f32,
    max_force_step_n: f32,
    ramp_step: Option<f32>,
    max_speed_sq: f32,
    thermal_gain: f32,
    inv_continuous_sq: f32,
    inv_derate_span: f32,
    min_speed_sq: f32,
    inv_period_s: f32,
    heartbeat_timeout_us: u64,

    latched: Faults,
    /// Conditions present at the last tick; `clear_faults` keeps these.
    present: Faults,
    forces_on: bool,
    ramp_ticks: u32,
    last_force_n: Vec2,
    last_position_m: Option<Vec2>,
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
        let min_speed_sq = config.passivity.min_speed_m_per_s * config.passivity.min_speed_m_per_s;
        Ok(Self {
            max_force_sq: config.max_force_n * config.max_force_n,
            max_force_step_n: config.max_force_rate_n_per_s * config.period_s,
            ramp_step,
            max_speed_sq: config.max_velocity_m_per_s * config.max_velocity_m_per_s,
            thermal_gain: -libm::expm1f(-config.period_s / th.time_constant_s),
            inv_continuous_sq: 1.0 / (th.continuous_current_a * th.continuous_current_a),
            inv_derate_span: 1.0 / (th.trip_threshold - th.derate_threshold),
            min_speed_sq,
            inv_period_s: 1.0 / config.period_s,
            heartbeat_timeout_us: config.heartbeat_timeout_us(),
            config,
            latched: Faults::empty(),
            present: Faults::empty(),
            forces_on: false,
            ramp_ticks: 0,
            last_force_n: Vec2::ZERO,
            last_position_m: None,
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
    }

    /// Whether the device renders a wall of this stiffness and damping at all, with the
    /// passivity controller on: [`check_passivity`] with the device's damping plus
    /// [`PassivityConfig::grip_damping_n_s_per_m`]. The error carries that limit.
    pub fn check_renderable(
        &self,
        stiffness_n_per_m: f32,
        damping_n_s_per_m: f32,
    ) -> Result<(), PassivityError> {
        let p = &self.config.passivity;
        check_passivity(
            stiffness_n_per_m,
            damping_n_s_per_m,
            self.config.period_s,
            p.device_damping_n_s_per_m + p.grip_damping_n_s_per_m,
        )
    }

    /// Turns the passivity controller on or off (per scene: on for scenes whose materials
    /// fail [`check_passivity`]). The observer runs either way.
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

    /// The sampled-data passivity bound, [`check_passivity`] (the free function), for a wall
    /// of this stiffness and damping with this device's period and physical damping; no other
    /// property of a material is checked here.
    pub fn check_passivity(
        &self,
        stiffness_n_per_m: f32,
        damping_n_s_per_m: f32,
    ) -> Result<(), PassivityError> {
        check_passivity(
            stiffness_n_per_m,
            damping_n_s_per_m,
            self.config.period_s,
            self.config.passivity.device_damping_n_s_per_m,
        )
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
            .any(|s| libm::fabsf(*s) > cfg.max_joint_step_rad)
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
            self.last_force_n = Vec2::ZERO;
            return SafetyOutput {
                faults: self.latched,
                ..SafetyOutput::OFF
            };
        }
        if !self.forces_on {
            self.forces_on = true;
            self.ramp_ticks = 0;
            self.energy_j = 0.0;
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
        // Free space: the renderer asks for nothing, so nothing is applied (no damper, no
        // rate-limited tail: the mechanism's own damping is all the user feels), and the
        // rendered environment, a penalty spring at zero depth, stores no energy, so the
        // observer starts the next contact from zero instead of damping free motion for
        // energy the last contact delivered.
        if input.force_n == Vec2::ZERO {
            self.last_force_n = Vec2::ZERO;
            self.energy_j = 0.0;
            return SafetyOutput {
                force_n: Vec2::ZERO,
                flags,
                faults: self.latched,
            };
        }
        let mut force = input.force_n * ramp;

        // Hannaford & Ryu 2002: a variable damper dissipates the energy the observer found
        // the environment to have generated, α = −E / (T |v|²), with a floor on |v|².
        if self.passivity_control && self.energy_j < 0.0 {
            let v = input.hip_velocity_m_per_s;
            let speed_sq = math::max(self.min_speed_sq, v.length_squared());
            let alpha = math::min(
                cfg.passivity.max_damping_n_s_per_m,
                -self.energy_j * self.inv_period_s / speed_sq,
            );
            force -= v * alpha;
            flags |= Flags::DAMPING;
        }

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
        }

        if !force.is_finite() {
            // Unreachable for a valid config; kept so no path can send NaN to the motors.
            self.latched |= Faults::NUMERIC;
            self.forces_on = false;
            self.last_force_n = Vec2::ZERO;
            return SafetyOutput {
                faults: self.latched,
                ..SafetyOutput::OFF
            };
        }
        self.last_force_n = force;
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
        if let Some(previous) = self.last_position_m
            && self.last_force_n != Vec2::ZERO
        {
            let work_on_user_j = self.last_force_n.dot(position - previous);
            let energy = self.energy_j - work_on_user_j;
            self.energy_j = if energy.is_finite() { energy } else { 0.0 };
        }
        self.last_position_m = Some(position);
    }
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
