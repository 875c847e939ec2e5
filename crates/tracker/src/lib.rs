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
mod object;
mod patch;
#[cfg(feature = "alloc")]
mod polygon;
mod shell;
mod split;
mod track;

pub use chain::{
    CHAIN_KNOTS, CHAIN_POINTS, Chain, ChainError, ChainTopology, ChainTracker, JOIN_TOL_M,
    MAX_CHAIN_CURVES, Vertex, VertexKind,
};
pub use contact::{Contact, Feature, Penalty};
pub use global::{
    BezierPiece, BezierSplit, Closest, CurvePiece, GlobalConfig, RELATIVE_TOLERANCE, SurfacePiece,
    closest_point,
};
pub use newton::{NewtonConfig, NewtonResult, newton};
pub use object::{Object, PatchFrame};
pub use patch::{Jet, Patch};
#[cfg(feature = "alloc")]
pub use polygon::{
    MAX_CURVE_DEPTH, MAX_MESH_CELLS, MAX_POLYLINE_VERTICES, Polyline, SegmentHit, TriMesh,
    TriangleHit, closest_point_on_segment, closest_point_on_triangle,
};
pub use shell::{
    Corner, Edge, MAX_CORNER_VALENCE, MAX_SHELL_CORNERS, MAX_SHELL_EDGES, MAX_SHELL_PATCHES,
    SHELL_JOIN_TOL_M, SHELL_KNOTS, SHELL_POINTS, Shell, ShellError, ShellTopology, ShellTracker,
    Side,
};
pub use track::{
    Law, PERIODIC_TOL, Track, Tracker, TrackerConfig, stable_gain_limit, theorem_gain,
};
