#![doc = include_str!("../README.md")]
#![cfg_attr(not(feature = "std"), no_std)]
#![warn(missing_docs)]

mod material;
pub mod models;
mod render;

pub use material::{FrictionMaterial, MaterialError, ModelKind, Stribeck};
pub use render::{Anchors, FrictionOutput, FrictionRenderer, Mode, SwitchCause, cp_config};
