//! The command handlers of the `viewer` binary, one file per command (or family); `main`
//! dispatches and keeps what they share (the exit codes, `fail`, the Ctrl-C flag).

mod deformation;
mod experiments;
mod geometry;
mod hardware;
mod identification;
mod plotting;
mod simulation;
mod window;
mod zwidth_sweep;

pub(crate) use deformation::*;
pub(crate) use experiments::*;
pub(crate) use geometry::*;
pub(crate) use hardware::*;
pub(crate) use identification::*;
pub(crate) use plotting::*;
pub(crate) use simulation::*;
pub(crate) use window::*;
pub(crate) use zwidth_sweep::*;
