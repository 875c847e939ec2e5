//! The device's half of the protocol, `no_std` and allocation-free: what a device runs behind
//! its transport (the board's USB or UART, the firmware under QEMU, the simulated device on a
//! host thread).
//!
//! - [`session`]: each frame through the receiver, acked or nacked, commands applied to the
//!   `device::controller::Controller`, events for the caller's storage or plant.
//! - `usb` (feature `usb`): the board's USB HID device, generic over the bus.
//! - [`Numbering`]: the sequence numbers of a device's frames, telemetry and replies apart.
//!
//! The host's half is [`host_side`](crate#modules) (feature `std`).

pub mod session;
#[cfg(feature = "usb")]
pub mod usb;

use crate::{Frame, MAX_FRAME, Message};

/// The sequence numbers of what a device sends: telemetry frames count on one counter, replies
/// (ack, nack, status, hello) on another, each from 0, every value, wrapping (0xFFFF → 0 is
/// the next frame, as the host's `GapCounter` expects).
///
/// Two counters, not one, because the two need not travel together: over USB the replies have
/// an endpoint of their own (`usb::HidPort`), and the host reads the two endpoints apart, so
/// their relative order is lost. With one counter a reply read late would look like telemetry
/// out of order, and telemetry between replies like gaps. Each kind numbered on its own, the
/// host counts lost telemetry exactly (its numbers are contiguous whatever the replies do) on
/// every transport, the byte streams (UART, TCP) included, where both share one stream.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Numbering {
    telemetry: u16,
    replies: u16,
}

impl Numbering {
    /// Whether `message` is numbered as telemetry (else as a reply).
    pub fn is_telemetry(message: &Message) -> bool {
        matches!(message, Message::Telemetry(_))
    }

    /// The number `message` would be sent with, without spending it.
    pub fn peek(&self, message: &Message) -> u16 {
        if Self::is_telemetry(message) {
            self.telemetry
        } else {
            self.replies
        }
    }

    /// Spends the number of `message`'s kind: it went out (or was dropped by the device and
    /// should show as a gap).
    pub fn advance(&mut self, message: &Message) {
        let counter = if Self::is_telemetry(message) {
            &mut self.telemetry
        } else {
            &mut self.replies
        };
        *counter = counter.wrapping_add(1);
    }

    /// `message` as the next frame of its kind (its number spent).
    pub fn frame(&mut self, message: &Message) -> Frame {
        let seq = self.peek(message);
        self.advance(message);
        Frame {
            seq,
            message: *message,
        }
    }

    /// `message` as the next frame of its kind, encoded into a zero-padded 64-byte report;
    /// the report and the frame's length.
    pub fn report(&mut self, message: &Message) -> ([u8; MAX_FRAME], usize) {
        self.frame(message).to_report()
    }
}
