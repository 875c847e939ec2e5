#![doc = include_str!("../README.md")]
#![cfg_attr(not(feature = "std"), no_std)]
#![warn(missing_docs)]
pub mod board_io;
pub mod controller;
pub mod error;
pub mod kinematics;
/// The tick's elementary functions, from `nurbs` (the lowest crate on the tick path).
pub use nurbs::math;
pub mod safety;
pub mod simulator;
pub mod spec;
pub mod telemetry;
pub mod wall;
