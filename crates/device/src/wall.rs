//! Load-time wall acceptance: which materials a device renders at a tick rate.
//!
//! A scene loader asks [`check_wall`] about each material before the tick ever sees it. The
//! bounds come from the device's own figures at the handle ([`AtHandle`], from
//! [`DeviceSpec::at_handle`](crate::spec::DeviceSpec::at_handle)): the sampled-data
//! passivity bound of thesis eq. 1.1 with the device's damping and dry friction, and the
//! encoder quantisation bound (see [`PassivityConfig`]). With the passivity controller of the
//! per-tick layer ([`Safety::set_passivity_control`](crate::safety::Safety::set_passivity_control))
//! a wall past the first bound is accepted up to what the controller is demonstrated to
//! ([`WallLimits`]); stiffer ones the device does not render at all. A refusal
//! ([`PassivityError`]) names the bound, its numbers and the lowest standard rate
//! ([`RATES_HZ`]) that renders the wall.
//!
//! Setup, not the tick: [`Safety::check_wall`](crate::safety::Safety::check_wall) runs this
//! at the safety layer's period with its figures, as
//! [`Controller::load_scene`](crate::controller::Controller::load_scene) and
//! [`Controller::set_material`](crate::controller::Controller::set_material) do before they
//! accept a material. [`PassivityConfig`] also carries the parameters of the per-tick
//! passivity controller, which the safety layer reads from
//! [`SafetyConfig::passivity`](crate::safety::SafetyConfig::passivity).

use core::fmt;

pub use crate::spec::AtHandle;

/// What a wall's acceptance counts on, and the passivity controller's parameters.
///
/// # Which walls a device renders
///
/// A material of stiffness K and damping B is accepted at period T when both bounds hold
/// ([`check_wall`]), each from the mechanism's own figures at the worst pose
/// ([`DeviceSpec::at_handle`](crate::spec::DeviceSpec::at_handle)), never from a hand:
///
/// 1. **Sampled-data passivity** (Colgate & Schenkel; thesis eq. 1.1), `b > K T / 2 + |B|`,
///    with `b` the device's viscous damping plus its Coulomb friction `f_c` counted as the
///    damping it is at least up to the impact speed `v`, `f_c |ẋ| ≥ (f_c / v) ẋ²` for
///    `|ẋ| ≤ v`: `K < 2 (b + f_c / v − |B|) / T`. (The zero-order hold's energy leak grows
///    as `K T ẋ² / 2`; dry friction absorbs `f_c |ẋ|`, so it covers the leak up to that speed.)
/// 2. **Quantisation** (Abbott & Okamura 2005): `K ≤ 2 f_c / Δ`, Δ the handle's motion per
///    encoder count. A higher rate does not raise it.
///
/// With the passivity controller on, a wall that fails the first bound is still accepted up to
/// [`PassivityConfig::controller_stiffness_n_per_m`] and
/// [`PassivityConfig::controller_damping_ns_per_m`]: how far the controller is *demonstrated*
/// to keep walls stable with a released handle, a light fingertip and a grip, at 1 and
/// 10 kHz, through the simulated pantograph (the test `tests/tests/zwidth.rs` runs exactly
/// that cell and fails if it is not). The quantisation bound holds either way.
///
/// # The passivity controller: an energy tank
///
/// The observer (Hannaford & Ryu 2002) sums the work the user does on the rendered
/// environment, `E −= F · Δx` with F the force that acted over the displacement Δx (the held
/// force, [`PassivityConfig::output_delay_ticks`] late). The controller lets the force do on
/// the user at most the energy E holds: the next period's work, predicted from the last
/// displacement, is scaled down to E, and while the tank is empty the force grows only as the
/// user pushes in. A contact thus gives back at most what it received, so a released handle
/// leaves a wall no faster than it came. The tank is emptied in free space (a penalty wall at
/// zero depth stores nothing). When rendering restarts with the handle inside (a scene load,
/// forces on, a fault cleared) it opens with what the wall, capped at the force limit, gives
/// back from there ([`Safety::set_wall_stiffness`](crate::safety::Safety::set_wall_stiffness)). The rate limiter never holds the force
/// above the tank's cut: a rate-limited force the tank cannot pay for is dropped to zero for
/// the tick (the one step the rate limit lets through, as in free space).
///
/// # Where the guarantee ends
///
/// The force is decided before the motion it acts over: the tank predicts the next step by
/// extrapolating the last two linearly, so the bound is exact while the handle's step changes
/// at a constant rate (any speed, any rate: a scripted 0.86 m/s bounce at 1 and 10 kHz gives
/// back what it received, to f32 rounding). Where the motion departs from that within a tick
/// (the hand turning back, a jerk), the tank can overspend by `|F| · |Δ²s|` (`Δ²s` the second
/// difference of the steps, at most `2 a T²` for a hand accelerating at `a`) each time it runs
/// dry; it then holds the force at zero until the user's work has paid the debt back, so a
/// contact returns at most its intake plus one such error per time the tank runs dry. That
/// error, and the observer's counting on positions quantised to the encoder's Δ (about
/// `F Δ` per contact), are covered by the device's own dry friction only up to the
/// demonstrated impacts (0.1 m/s, `tests/tests/zwidth.rs`): beyond them, e.g. a fingertip
/// striking at 0.86 m/s at 1 kHz, a contact may give back a fraction of a millijoule more
/// than it received (0.84 mJ measured in one 30 ms contact at K = 1000 N/m, before the rate
/// limiter stopped holding back the tank's cuts). A higher rate shrinks `a T²` as `T²`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PassivityConfig {
    /// The mechanism's damping, Coulomb friction and resolution at the handle, at its worst
    /// pose. [`Controller::new`](crate::controller::Controller::new) sets them from the
    /// device description; the default is the default pantograph's.
    pub device: AtHandle,
    /// The fastest impact the passivity bound covers, m/s (the dry friction's equivalent
    /// damping is `f_c / v` up to this speed).
    pub impact_speed_m_per_s: f32,
    /// The stiffness up to which the passivity controller is demonstrated (N/m).
    pub controller_stiffness_n_per_m: f32,
    /// The wall damping |B| up to which the passivity controller is demonstrated (N·s/m).
    pub controller_damping_ns_per_m: f32,
    /// Ticks between a tick's force and the motors producing it: 0 when the output is set
    /// within the tick, 1 when it takes effect at the next (the simulated pantograph's
    /// [`SimParams::command_delay`](crate::simulator::SimParams::command_delay)). The
    /// observer pairs each displacement with the force that acted over it.
    pub output_delay_ticks: u32,
}

impl Default for PassivityConfig {
    fn default() -> Self {
        Self {
            device: DEFAULT_AT_HANDLE,
            impact_speed_m_per_s: 0.1,
            controller_stiffness_n_per_m: CONTROLLER_STIFFNESS_N_PER_M,
            controller_damping_ns_per_m: CONTROLLER_DAMPING_NS_PER_M,
            output_delay_ticks: 1,
        }
    }
}

/// The default pantograph's figures at the handle, as
/// [`DeviceSpec::at_handle`](crate::spec::DeviceSpec::at_handle) computes them (a unit test
/// checks they agree to 0.1 %).
const DEFAULT_AT_HANDLE: AtHandle = AtHandle {
    damping_n_s_per_m: 3.2757e-3,
    coulomb_n: 1.7170e-2,
    resolution_m: 1.9592e-5,
};

/// The stiffness the passivity controller is demonstrated to: released handle, fingertip and
/// grip all stable at 1 and 10 kHz after impacts at 100 and 20 mm/s (`tests/tests/zwidth.rs`).
/// Beyond the default device's quantisation bound (about 1750 N/m) the tank leaks at 1 kHz:
/// it counts the energy on positions quantised to the encoder's Δ, an error of about F Δ per
/// contact, which the device's dry friction no longer absorbs.
pub const CONTROLLER_STIFFNESS_N_PER_M: f32 = 1700.0;
/// The wall damping the passivity controller is demonstrated to (same test).
pub const CONTROLLER_DAMPING_NS_PER_M: f32 = 1.0;

/// The standard tick rates a refusal suggests (Hz).
pub const RATES_HZ: [u32; 4] = [1_000, 2_000, 5_000, 10_000];

/// Which of the bounds of [`PassivityConfig`] refused a wall.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bound {
    /// The sampled-data passivity bound with the device's own damping and friction.
    Passivity,
    /// The encoder quantisation bound.
    Quantisation,
    /// Beyond what the passivity controller is demonstrated to.
    Controller,
}

/// The largest stiffness each bound of [`PassivityConfig`] accepts for a wall damping B at a
/// period T.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallLimits {
    /// `2 (b + f_c / v − |B|) / T`, clamped at 0 (N/m).
    pub passive_n_per_m: f32,
    /// `2 f_c / Δ` (N/m).
    pub quantisation_n_per_m: f32,
    /// With the passivity controller: the demonstrated stiffness when |B| is within the
    /// demonstrated damping, else 0 (N/m).
    pub controller_n_per_m: f32,
}

impl WallLimits {
    /// The bounds for wall damping `damping_ns_per_m` at `period_s`.
    pub fn new(passivity: &PassivityConfig, damping_ns_per_m: f32, period_s: f32) -> Self {
        let d = &passivity.device;
        let b = d.damping_n_s_per_m + d.coulomb_n / passivity.impact_speed_m_per_s;
        let damping = libm::fabsf(damping_ns_per_m);
        let controller_n_per_m = if damping <= passivity.controller_damping_ns_per_m {
            passivity.controller_stiffness_n_per_m
        } else {
            0.0
        };
        WallLimits {
            passive_n_per_m: (2.0 * (b - damping) / period_s).max(0.0),
            quantisation_n_per_m: 2.0 * d.coulomb_n / d.resolution_m,
            controller_n_per_m,
        }
    }

    /// The wall damping |B| at and beyond which no stiffness is accepted, with or without the
    /// passivity controller (N·s/m): `b + f_c / v`, where `2 (b + f_c / v − |B|) / T` reaches
    /// 0, or the controller's demonstrated damping if that is larger.
    pub fn max_damping_ns_per_m(passivity: &PassivityConfig, controller: bool) -> f32 {
        let d = &passivity.device;
        let passive = d.damping_n_s_per_m + d.coulomb_n / passivity.impact_speed_m_per_s;
        if controller {
            passive.max(passivity.controller_damping_ns_per_m)
        } else {
            passive
        }
    }

    /// The largest stiffness accepted, with or without the passivity controller, and the
    /// bound that sets it.
    pub fn max(&self, controller: bool) -> (f32, Bound) {
        let (rate_limited, bound) = if controller && self.controller_n_per_m > self.passive_n_per_m
        {
            (self.controller_n_per_m, Bound::Controller)
        } else {
            (self.passive_n_per_m, Bound::Passivity)
        };
        if self.quantisation_n_per_m < rate_limited {
            (self.quantisation_n_per_m, Bound::Quantisation)
        } else {
            (rate_limited, bound)
        }
    }
}

/// A wall the bounds of [`PassivityConfig`] refuse, or bad arguments.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PassivityError {
    /// The stiffness is above the largest accepted one.
    TooStiff {
        /// The stiffness asked for, N/m.
        stiffness_n_per_m: f32,
        /// The wall damping asked for, N·s/m.
        damping_ns_per_m: f32,
        /// The largest stiffness accepted, N/m.
        max_stiffness_n_per_m: f32,
        /// The bound that sets it.
        bound: Bound,
        /// The tick period, s.
        period_s: f32,
        /// The figures the bounds used.
        passivity: PassivityConfig,
        /// The lowest of [`RATES_HZ`] at which the wall is accepted (with the same passivity
        /// controller setting), if any.
        renders_at_hz: Option<u32>,
    },
    /// The wall damping alone is beyond the device: with it no stiffness is accepted at any
    /// rate (the largest stiffness would be 0 N/m), so it is the damping that must come down.
    TooDamped {
        /// The wall damping asked for, N·s/m.
        damping_ns_per_m: f32,
        /// The stiffness asked for, N/m.
        stiffness_n_per_m: f32,
        /// The largest |B| any stiffness is accepted with, N·s/m
        /// ([`WallLimits::max_damping_ns_per_m`]).
        max_damping_ns_per_m: f32,
        /// Whether the passivity controller was counted.
        controller: bool,
        /// The figures the bounds used.
        passivity: PassivityConfig,
    },
    /// An argument is non-finite or out of range (stiffness < 0, period ≤ 0).
    InvalidParameter(&'static str),
}

impl fmt::Display for PassivityError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Self::TooStiff {
            stiffness_n_per_m: k,
            damping_ns_per_m: damping,
            max_stiffness_n_per_m: max,
            bound,
            period_s,
            passivity: p,
            renders_at_hz,
        } = self
        else {
            match self {
                Self::InvalidParameter(name) => write!(f, "wall check: invalid {name}")?,
                Self::TooDamped {
                    damping_ns_per_m: damping,
                    stiffness_n_per_m: k,
                    max_damping_ns_per_m: max,
                    controller,
                    passivity: p,
                } => {
                    let d = &p.device;
                    write!(
                        f,
                        "damping |B| = {:.3} N·s/m is beyond what this device renders at any \
                         rate: the sampled-data passivity bound K < 2 (b + f_c/v - |B|) / T \
                         leaves no stiffness (not even K = {k:.0} N/m) once |B| reaches \
                         b + f_c/v = {:.3} N·s/m (the device's own damping b = {:.4} N·s/m and \
                         Coulomb friction f_c = {:.4} N counted up to v = {} m/s)",
                        libm::fabsf(*damping),
                        d.damping_n_s_per_m + d.coulomb_n / p.impact_speed_m_per_s,
                        d.damping_n_s_per_m,
                        d.coulomb_n,
                        p.impact_speed_m_per_s,
                    )?;
                    let demonstrated = p.controller_damping_ns_per_m;
                    if *controller {
                        write!(
                            f,
                            ", and the passivity controller is demonstrated up to |B| = \
                             {demonstrated} N·s/m; lower the damping to {max:.3} N·s/m or less"
                        )?;
                    } else {
                        write!(f, "; lower the damping below {max:.3} N·s/m")?;
                        if demonstrated > *max {
                            write!(
                                f,
                                " or enable the passivity controller (demonstrated up to \
                                 |B| = {demonstrated} N·s/m)"
                            )?;
                        }
                    }
                }
                Self::TooStiff { .. } => {}
            }
            return Ok(());
        };
        let d = &p.device;
        let rate_hz = 1.0 / period_s;
        write!(
            f,
            "stiffness {k:.0} N/m is beyond what this device renders at {rate_hz:.0} Hz: "
        )?;
        match bound {
            Bound::Passivity => write!(
                f,
                "the sampled-data passivity bound K < 2 (b + f_c/v - |B|) / T is {max:.0} N/m \
                 (the device's own damping b = {:.4} N·s/m and Coulomb friction f_c = {:.4} N \
                 counted up to v = {} m/s, |B| = {} N·s/m); raise the tick rate or the \
                 device's damping, lower K, or enable the passivity controller",
                d.damping_n_s_per_m,
                d.coulomb_n,
                p.impact_speed_m_per_s,
                libm::fabsf(*damping),
            )?,
            Bound::Quantisation => write!(
                f,
                "the encoder quantisation bound K <= 2 f_c / Δ is {max:.0} N/m (f_c = {:.4} N, \
                 Δ = {:.1} µm per count); it does not depend on the rate: a finer encoder or \
                 more device friction raises it",
                d.coulomb_n,
                d.resolution_m * 1e6,
            )?,
            Bound::Controller => write!(
                f,
                "the passivity controller is demonstrated up to K = {:.0} N/m with |B| <= {} \
                 N·s/m, so the limit is {max:.0} N/m; raise the tick rate or lower K",
                p.controller_stiffness_n_per_m, p.controller_damping_ns_per_m,
            )?,
        }
        match renders_at_hz {
            Some(hz) => write!(f, "; it renders at {hz} Hz"),
            None => Ok(()),
        }
    }
}

impl core::error::Error for PassivityError {}

/// Whether a wall of stiffness K and damping B is accepted at `period_s` by the bounds of
/// `passivity` (see [`PassivityConfig`]), with or without the passivity controller. The
/// refusal names the bound, its numbers and the lowest standard rate that renders the wall.
pub fn check_wall(
    stiffness_n_per_m: f32,
    damping_ns_per_m: f32,
    period_s: f32,
    passivity: &PassivityConfig,
    controller: bool,
) -> Result<(), PassivityError> {
    if !(stiffness_n_per_m.is_finite() && stiffness_n_per_m >= 0.0) {
        return Err(PassivityError::InvalidParameter("stiffness"));
    }
    if !damping_ns_per_m.is_finite() {
        return Err(PassivityError::InvalidParameter("damping"));
    }
    if !(period_s.is_finite() && period_s > 0.0) {
        return Err(PassivityError::InvalidParameter("period"));
    }
    let accepted = |period_s: f32| {
        let (max, bound) = WallLimits::new(passivity, damping_ns_per_m, period_s).max(controller);
        // Strict below the passivity bound (an open inequality; K = 0 with |B| = b is
        // marginal), inclusive at the others.
        let ok = match bound {
            Bound::Passivity => stiffness_n_per_m < max,
            Bound::Quantisation | Bound::Controller => stiffness_n_per_m <= max,
        };
        (ok, max, bound)
    };
    let (ok, max, bound) = accepted(period_s);
    if ok {
        return Ok(());
    }
    // No stiffness at all: the damping is what is beyond the device, and no rate helps
    // (b + f_c/v − |B| does not depend on T, nor does the controller's demonstrated |B|).
    if max <= 0.0 && bound != Bound::Quantisation {
        return Err(PassivityError::TooDamped {
            damping_ns_per_m,
            stiffness_n_per_m,
            max_damping_ns_per_m: WallLimits::max_damping_ns_per_m(passivity, controller),
            controller,
            passivity: *passivity,
        });
    }
    let renders_at_hz = RATES_HZ
        .into_iter()
        .find(|hz| 1.0 / (*hz as f32) < period_s && accepted(1.0 / *hz as f32).0);
    Err(PassivityError::TooStiff {
        stiffness_n_per_m,
        damping_ns_per_m,
        max_stiffness_n_per_m: max,
        bound,
        period_s,
        passivity: *passivity,
        renders_at_hz,
    })
}
