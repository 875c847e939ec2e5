//! The device's half of the protocol, `no_std` and allocation-free: what a device runs behind
//! its transport (the board's USB or UART, the firmware under QEMU, the simulated device on a
//! host thread).
//!
//! - [`session`]: each frame through the receiver, acked or nacked, commands applied to the
//!   `device::controller::Controller`, events for the caller's storage or plant.
//! - `usb` (feature `usb`): the board's USB HID device, generic over the bus.
//!
//! The host's half is [`host_side`](crate#modules) (feature `std`).

pub mod session;
#[cfg(feature = "usb")]
pub mod usb;
