//! Board glue around [`device::Controller`]: the board-independent app ([`app`], with the
//! acquisition job a board runs in another task), the trait a board implements for it
//! ([`board`]), the scene double buffer the board's link task and tick share and the tick's
//! side of it ([`swap`]), the board's protocol task and USB queues (`protocol_task`, `usb`,
//! feature `board`), and the compact scenario table the QEMU binary runs ([`scenario`]). No
//! rendering logic lives here: it is all in the root crates.
//!
//! See `README.md` for what runs where and how to run it (`cargo xtask qemu`).
#![no_std]
#![warn(missing_docs)]

pub mod app;
pub mod board;
pub mod handover;
pub mod netduino;
#[cfg(feature = "board")]
pub mod protocol_task;
pub mod scenario;
#[cfg(feature = "board")]
pub mod usb;

/// This firmware's version, as its hello reports it: `[major, minor, patch]` of the crate.
pub fn software_version() -> [u8; 3] {
    let part = |s: &str| s.parse::<u8>().unwrap_or(0);
    [
        part(env!("CARGO_PKG_VERSION_MAJOR")),
        part(env!("CARGO_PKG_VERSION_MINOR")),
        part(env!("CARGO_PKG_VERSION_PATCH")),
    ]
}
