#![doc = include_str!("../README.md")]
#![cfg_attr(not(feature = "std"), no_std)]
#![warn(missing_docs)]
pub mod board_io;
pub mod controller;
pub mod error;
pub mod kinematics;
#[cfg(feature = "std")]
pub mod link;
/// The tick's elementary functions, from `nurbs` (the lowest crate on the tick path).
pub use nurbs::math;
pub mod protocol;
pub mod safety;
pub mod session;
pub mod simulator;
pub mod spec;
pub mod telemetry;
#[cfg(feature = "usb")]
pub mod usb;
pub mod wall;
