//! The crate's error types, each where every module that returns or carries it reaches it
//! without an import circle: [`SimError`] (a run could not start: [`crate::sim`],
//! [`crate::closed_loop`], [`crate::tick`], the loops, [`crate::zwidth`]), [`MaterialChangeError`]
//! and [`MeshError`] (the replies of [`crate::backend`] from the planar, spatial and remote
//! loops); and the limits their messages state ([`MAX_TICKS`], [`MAX_HAPTIC_TRIANGLES`], the
//! tick-rate rule of [`check_rate`]).

use device::controller::ControllerError;
use device::kinematics::KinematicsError;
use device::simulator::SimulatorError;
use scene::{MaterialError, Space};
use tracker::{ChainError, ShellError};

/// Largest number of ticks of one run (about 2 GB of records; 2.8 h at 1 kHz).
pub const MAX_TICKS: usize = 10_000_000;

/// Most triangles a mesh the loop renders may have: the baseline scans every triangle each
/// tick, measured at 30 to 42 ns a triangle in the test profile on the project's 2-core
/// machine under load (`measure_tick_costs` in [`crate::spatial`]'s tests), so 10 000 take
/// about 0.4 ms of the 1 ms tick.
pub const MAX_HAPTIC_TRIANGLES: usize = 10_000;

/// Why a simulation could not start.
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum SimError {
    /// No such object.
    #[error("--object {index}: the scene has {count} object(s), indices 0..={}", count - 1)]
    ObjectIndex {
        /// Index asked for.
        index: usize,
        /// Objects in the scene (at least one).
        count: usize,
    },
    /// The tick rate is not a positive finite number whose value and period are normal
    /// `f32`s (the loop's type; see [`check_rate`]).
    #[error("--rate-hz {rate_hz:e}: {}", rate_rule())]
    Rate {
        /// The rate given.
        rate_hz: f64,
    },
    /// The trajectory lasts less than one period: one tick, no motion to simulate.
    #[error(
        "{duration_s} s at {rate_hz:e} Hz is a single tick; a run needs at least 2 (the HIP \
         velocity is a backward difference): raise --rate-hz to at least {:e} Hz or lengthen \
         the trajectory",
        1.0 / duration_s
    )]
    TooFewTicks {
        /// Trajectory duration (s).
        duration_s: f64,
        /// Rate (Hz).
        rate_hz: f64,
    },
    /// The trajectory's dimension does not match the object's.
    #[error(
        "the trajectory is {trajectory} but object {index} ({name:?}) is {}; {}",
        match object { Space::Planar => "a 2-D chain of planar curves",
                       Space::Spatial => "a 3-D shell of surfaces" },
        match trajectory { Space::Planar => "a t,x,y trajectory needs an object of planar curves",
                           Space::Spatial => "a t,x,y,z trajectory needs an object of surfaces" }
    )]
    Space {
        /// The trajectory's space.
        trajectory: Space,
        /// The object's space.
        object: Space,
        /// Object index.
        index: usize,
        /// Object name.
        name: String,
    },
    /// The run would be too long to hold in memory.
    #[error(
        "{ticks} ticks ({duration_s} s at {rate_hz} Hz): at most {MAX_TICKS} per run; \
         lower --rate-hz or shorten the trajectory"
    )]
    TooManyTicks {
        /// Ticks the run would have.
        ticks: f64,
        /// Trajectory duration (s).
        duration_s: f64,
        /// Rate (Hz).
        rate_hz: f64,
    },
    /// The object is not a valid chain (the scene loader rejects these already).
    #[error("object {index}: {error}")]
    Chain {
        /// Object index.
        index: usize,
        /// What is wrong.
        error: ChainError,
    },
    /// The object is not a valid shell (the scene loader rejects these already).
    #[error("object {index}: {error}")]
    Shell {
        /// Object index.
        index: usize,
        /// What is wrong.
        error: ShellError,
    },
    /// `--device` with an object of surfaces: the pantograph has two degrees of freedom.
    #[error(
        "--device: object {index} ({name:?}) is a 3-D shell of surfaces, but the pantograph \
         is a 2-DoF planar device; it renders only objects of planar curves"
    )]
    Surface {
        /// Object index.
        index: usize,
        /// Object name.
        name: String,
    },
    /// The device controller refused its configuration or the material.
    #[error("device controller: {0}")]
    Controller(ControllerError),
    /// The simulated pantograph could not start (the trajectory's first point out of reach,
    /// or a bad parameter).
    #[error("simulated pantograph: {0}")]
    Simulator(SimulatorError),
    /// The simulated arm was driven into a singular or unassembled configuration.
    #[error("simulated pantograph at t = {t_s} s: {error}")]
    Arm {
        /// Time of the tick (s).
        t_s: f64,
        /// What happened.
        error: KinematicsError,
    },
}

/// What [`check_rate`] asks of a tick rate, in words.
pub fn rate_rule() -> String {
    format!(
        "the tick rate must be finite and > 0, and it and its period 1/rate must fit the f32 \
         the loop computes in (about {:e} to {:e})",
        f32::MIN_POSITIVE,
        f32::MAX
    )
}

/// A tick rate the loop can run at: finite and > 0, and both the rate and its period
/// `1 / rate` positive normal `f32`s, since the loop computes in `f32` (`--rate-hz 1e-300`
/// would have a period of 1e300 s, infinite in `f32`).
pub fn check_rate(rate_hz: f64) -> Result<(), SimError> {
    let fits = |v: f64| (v as f32).is_normal();
    if rate_hz.is_finite() && rate_hz > 0.0 && fits(rate_hz) && fits(1.0 / rate_hz) {
        Ok(())
    } else {
        Err(SimError::Rate { rate_hz })
    }
}

/// Why a material was not applied. The running material is unchanged.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MaterialChangeError {
    /// A value is out of its range (the message names the field).
    #[error("{0}")]
    Invalid(#[from] MaterialError),
    /// The device's controller refused it (a stiffness beyond the device; the message names
    /// the limit).
    #[error("device controller: {0}")]
    Controller(ControllerError),
    /// The scene has no object the device renders.
    #[error("the scene has no object of planar curves for the device to render")]
    NoObject,
    /// The device behind the link refused it (its reason).
    #[error("the device refused the material: {0}")]
    Device(String),
}

/// Why a mesh was not taken for rendering.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MeshError {
    /// More triangles than the loop scans in a tick.
    #[error(
        "{triangles} triangles: the polygonal baseline scans every triangle each tick, at most \
         {MAX_HAPTIC_TRIANGLES}; use a coarser chordal tolerance or a smaller mesh"
    )]
    TooManyTriangles {
        /// Triangles in the mesh.
        triangles: usize,
    },
    /// No triangle of nonzero area.
    #[error("the mesh has no triangle of nonzero area")]
    Empty,
}
