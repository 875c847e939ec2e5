#![doc = include_str!("../README.md")]
#![warn(missing_docs)]

pub mod cli;
pub mod closest;
pub mod devices;
pub mod edit;
pub mod eval;
#[cfg(feature = "gui")]
pub mod gui;
pub mod haptic;
pub mod haptic3d;
pub mod mesh;
pub mod output;
pub mod plot;
pub mod remote;
pub mod runlog;
pub mod scene;
mod scene_json;
pub mod sim;
pub mod stribeck;
pub mod trajectory;
pub mod upload;
