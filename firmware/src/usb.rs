//! The board's USB side, run in its USB interrupt: host reports in to the protocol task,
//! the protocol task's replies and the tick's telemetry out, each on its own IN endpoint. The
//! HID device, its endpoints and the numbering of what goes out are
//! `protocol::device_side::usb::HidPort` and its `Outbox`
//! (the same code the host runs over USB/IP in `cargo xtask hid`); this is what the board
//! puts behind it, its queues ([`ReportPump`]).

use heapless::spsc::{Consumer, Producer};
use protocol::device_side::usb::ReportPump;
use protocol::{Frame, Message};

use crate::protocol_task::{FRAMES, REPLIES, REPORTS, Report};

/// The queues of the USB task.
pub struct Usb {
    /// Host reports to the protocol task.
    pub reports: Producer<'static, Report, REPORTS>,
    /// The protocol task's replies.
    pub replies: Consumer<'static, Message, REPLIES>,
    /// The tick's telemetry frames.
    pub frames: Consumer<'static, Report, FRAMES>,
}

impl core::fmt::Debug for Usb {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Usb").finish_non_exhaustive()
    }
}

impl ReportPump for Usb {
    fn reply(&mut self) -> Option<Message> {
        self.replies.peek().copied()
    }

    /// The oldest telemetry frame; one that does not decode (unreachable: the tick encodes
    /// them) is dropped rather than sent.
    fn frame(&mut self) -> Option<Message> {
        loop {
            match Frame::decode(self.frames.peek()?) {
                Ok(frame) => return Some(frame.message),
                Err(_) => {
                    let _ = self.frames.dequeue();
                }
            }
        }
    }

    fn take_reply(&mut self) {
        let _ = self.replies.dequeue();
    }

    fn take_frame(&mut self) {
        let _ = self.frames.dequeue();
    }

    /// A host report, copied into a zero-padded [`Report`] for the protocol task; a full
    /// queue drops it (the host sees no ack and resends).
    fn received(&mut self, bytes: &[u8]) {
        let mut report = [0u8; protocol::MAX_FRAME];
        if let Some(dst) = report.get_mut(..bytes.len()) {
            dst.copy_from_slice(bytes);
        }
        let _ = self.reports.enqueue(report);
    }

    /// Drops the waiting telemetry (nothing to send it to).
    fn drop_frames(&mut self) {
        while self.frames.dequeue().is_some() {}
    }
}
