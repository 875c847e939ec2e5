#![doc = include_str!("../README.md")]
#![warn(missing_docs)]

pub mod backend;
pub mod devices;
pub mod planar;
pub mod remote;
pub mod runlog;
pub mod sim;
pub mod spatial;
pub mod tick;
pub mod trajectory;
pub mod upload;
