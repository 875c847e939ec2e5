#![doc = include_str!("../README.md")]
#![warn(missing_docs)]

pub mod devices;
pub mod haptic;
pub mod haptic3d;
pub mod remote;
pub mod runlog;
pub mod sim;
pub mod tick;
pub mod trajectory;
pub mod upload;
