#![doc = include_str!("../README.md")]
#![cfg_attr(not(feature = "std"), no_std)]
#![warn(missing_docs)]
pub mod safety;
pub mod kinematics;
pub mod spec;
pub mod protocol;
pub mod simulator;
