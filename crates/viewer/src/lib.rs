#![doc = include_str!("../README.md")]
#![warn(missing_docs)]

pub mod cli;
pub mod closest;
pub mod deform_plot;
pub mod device_report;
pub mod eval;
pub mod experiment_plot;
#[cfg(feature = "gui")]
pub mod gui;
pub mod interrupt;
pub mod output;
pub mod plot;
pub mod stribeck;
pub mod zwidth_figure;
