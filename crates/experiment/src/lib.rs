#![doc = include_str!("../README.md")]
#![warn(missing_docs)]

pub mod analyze;
pub mod csv;
pub mod error;
pub mod fit;
pub mod plan;
pub mod rng;
pub mod runner;
pub mod session;
pub mod sim_participant;
pub mod staircase;
pub mod trace;
