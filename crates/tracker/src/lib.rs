#![doc = include_str!("../README.md")]
#![cfg_attr(not(feature = "std"), no_std)]
#![warn(missing_docs)]

#[cfg(feature = "alloc")]
extern crate alloc;

mod chain;
mod contact;
mod global;
mod linalg;
mod newton;
mod patch;
mod track;

pub use chain::{
    Chain, ChainError, ChainTracker, JOIN_TOL_M, MAX_CHAIN_CURVES, Vertex, VertexKind,
};
pub use contact::{Contact, Feature, Penalty};
pub use global::{
    BezierPiece, BezierSplit, Closest, CurvePiece, GlobalConfig, SurfacePiece, closest_point,
};
pub use newton::{NewtonConfig, NewtonResult, newton};
pub use patch::{Jet, Patch};
pub use track::{
    Law, PERIODIC_TOL, Track, Tracker, TrackerConfig, stable_gain_limit, theorem_gain,
};
