//! Why a plan was rejected: [`PlanError`], each naming its field.

use std::path::PathBuf;

use scene::SceneError;

/// Why a plan was rejected. The message names the file (for [`Plan::load`](crate::plan::Plan::load)) and the field.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// The file could not be read.
    #[error("cannot read {}: {error}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// An error in the named file.
    #[error("{}: {error}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// The error in it.
        error: Box<PlanError>,
    },
    /// JSON syntax error, wrong type, missing or unknown field; serde_json's message ends with
    /// the line and column.
    #[error("{}{error}", if location.is_empty() || location == "." { String::new() } else { format!("{location}: ") })]
    Json {
        /// The field path, e.g. `stimuli[2].object`; empty or `.` at the top level.
        location: String,
        /// serde_json's error.
        error: serde_json::Error,
    },
    /// A field with an invalid value.
    #[error("{field}: {message}")]
    Invalid {
        /// The field path, e.g. `staircases[0].step.size`.
        field: String,
        /// What is wrong with it.
        message: String,
    },
    /// A stimulus's scene could not be loaded or is invalid.
    #[error("{field}: {error}")]
    Scene {
        /// The field path, e.g. `stimuli[1].scene`.
        field: String,
        /// The scene's error.
        error: Box<SceneError>,
    },
}

impl PlanError {
    /// The field the error is about (`stimuli[2].object`; `format`; the JSON path of a JSON
    /// error; for a file, the field of the error in it).
    pub fn field(&self) -> Option<&str> {
        match self {
            PlanError::Read { .. } => None,
            PlanError::File { error, .. } => error.field(),
            PlanError::Json { location, .. } => Some(location),
            PlanError::Invalid { field, .. } | PlanError::Scene { field, .. } => Some(field),
        }
    }
}

pub(super) fn invalid(field: impl Into<String>, message: impl Into<String>) -> PlanError {
    PlanError::Invalid {
        field: field.into(),
        message: message.into(),
    }
}
