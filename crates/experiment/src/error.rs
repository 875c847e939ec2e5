//! The crate's error type for making a run, [`RunError`], in a module of its own: both the
//! [`Session`](crate::session::Session) (opening, resuming, the next trial) and the
//! [`runner`](crate::runner) return it, and the runner drives the session.

use std::io;
use std::path::PathBuf;

use host::error::SimError;
use host::sim::TrajectoryError;
use scene::SceneError;
use thiserror::Error;

use crate::plan::PlanError;
use crate::staircase::StaircaseError;

/// Why a run could not be made.
#[derive(Debug, Error)]
pub enum RunError {
    /// The folder holds rows the session cannot resume from.
    #[error("{}{}: cannot resume: {reason}", path.display(), if *line > 0 { format!(":{line}") } else { String::new() })]
    Resume {
        /// The file.
        path: PathBuf,
        /// Its line (from 1; 0 for the whole file).
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// An answer that does not fit the trial.
    #[error("{0}")]
    Response(String),
    /// A plan feature the runner does not handle yet.
    #[error("{0}")]
    Unsupported(String),
    /// The plan has no reference.
    #[error("a 2afc-staircase plan needs a \"reference\"")]
    NoReference,
    /// A staircase's parameters are refused.
    #[error("staircase {name:?}: {cause}")]
    Staircase {
        /// Its name in the plan.
        name: String,
        /// What is wrong.
        cause: StaircaseError,
    },
    /// The plan's material at a level is refused.
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// The stimulus's scene with the material at a level is refused.
    #[error("the scene with the stimulus's material at {level}: {cause}")]
    Scene {
        /// The value of the reference field.
        level: f64,
        /// What is wrong.
        cause: SceneError,
    },
    /// The object has nothing under the press.
    #[error("object {object} ({name:?}) has no surface under x = {x} where the hand comes down")]
    NoSurface {
        /// Its index in the scene.
        object: usize,
        /// Its name.
        name: String,
        /// Where the hand comes down (m).
        x: f64,
    },
    /// The press could not be made a trajectory.
    #[error("the press trajectory: {0}")]
    Trajectory(TrajectoryError),
    /// A simulated interval failed.
    #[error("trial {trial}, interval {interval}: the simulation failed: {cause}")]
    Sim {
        /// The trial (from 1).
        trial: usize,
        /// `a` or `b`.
        interval: char,
        /// What failed.
        cause: SimError,
    },
    /// The press rendered no force to feel.
    #[error("trial {trial}, interval {interval}: the press felt no force (the object was missed)")]
    NotFelt {
        /// The trial (from 1).
        trial: usize,
        /// `a` or `b`.
        interval: char,
    },
    /// The staircases did not finish.
    #[error("the staircases had not finished after {0} trials")]
    TooManyTrials(usize),
    /// An identification plan whose stimuli cannot be told apart by taps.
    #[error(
        "trial {trial}: the taps found no surface at x = {x} m (the stimulus has nothing under the tap)"
    )]
    NoTouch {
        /// The trial (from 1).
        trial: usize,
        /// Where the tap came down (m).
        x: f64,
    },
    /// A folder could not be made.
    #[error("cannot create the folder {path}: {cause}")]
    CreateDir {
        /// The folder.
        path: PathBuf,
        /// Why.
        cause: io::Error,
    },
    /// A file could not be written.
    #[error("cannot write {path}: {cause}")]
    Write {
        /// The file.
        path: PathBuf,
        /// Why.
        cause: io::Error,
    },
}
