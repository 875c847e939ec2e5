#![doc = include_str!("../README.md")]
#![warn(missing_docs)]

pub mod backend;
pub mod closed_loop;
pub mod deform;
pub mod deformation;
pub mod device_file;
pub mod devices;
pub mod error;
pub mod hand;
pub mod identify;
pub mod loop_api;
pub mod planar;
pub mod planar_session;
pub mod remote;
pub mod runlog;
pub mod sim;
pub mod spatial;
pub mod tick;
pub mod trajectory;
pub mod upload;
pub mod zwidth;

/// What the unit tests of several modules share.
#[cfg(test)]
pub(crate) mod test_scenes {
    use scene::{Bundled, Scene};

    /// The bundled thesis-2d scene (two arcs meeting at a vertex).
    pub(crate) fn thesis_2d() -> Scene {
        Bundled::find("thesis-2d")
            .and_then(|b| b.scene().ok())
            .expect("the bundled thesis-2d")
    }
}
