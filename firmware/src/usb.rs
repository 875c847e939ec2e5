//! The board's USB side, run in its USB interrupt: host reports in to the protocol task,
//! replies and telemetry out as IN reports, one device sequence number over all of them.
//! The HID device and its endpoints are `device::usb::HidPort` (the same code the host runs
//! over USB/IP in `cargo xtask hid`); this is what the board puts behind it, the queueing and
//! numbering ([`ReportPump`]).

use device::protocol::{Frame, Message};
use device::usb::ReportPump;
use heapless::spsc::{Consumer, Producer};

use crate::protocol_task::{FRAMES, REPLIES, REPORTS, Report};

/// The queues of the USB task and its sequence number.
pub struct Usb {
    /// Host reports to the protocol task.
    pub reports: Producer<'static, Report, REPORTS>,
    /// The protocol task's replies.
    pub replies: Consumer<'static, Message, REPLIES>,
    /// The tick's telemetry frames.
    pub frames: Consumer<'static, Report, FRAMES>,
    /// Device sequence number, over every frame sent (the host counts gaps in it).
    pub seq: u16,
}

impl core::fmt::Debug for Usb {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Usb")
            .field("seq", &self.seq)
            .finish_non_exhaustive()
    }
}

impl ReportPump for Usb {
    /// The next report to send: a reply first, else the oldest telemetry frame; numbered
    /// with the device's sequence. `None` when nothing is waiting.
    fn next_report(&mut self) -> Option<Report> {
        let message = match self.replies.peek() {
            Some(m) => *m,
            None => match self.frames.peek().map(|r| Frame::decode(r)) {
                Some(Ok(frame)) => frame.message,
                Some(Err(_)) => {
                    // Unreachable (the tick encodes them); dropped rather than sent.
                    let _ = self.frames.dequeue();
                    return None;
                }
                None => return None,
            },
        };
        Some(
            Frame {
                seq: self.seq,
                message,
            }
            .to_report()
            .0,
        )
    }

    /// The report of [`Usb::next_report`] was sent.
    fn sent(&mut self) {
        if self.replies.dequeue().is_none() {
            let _ = self.frames.dequeue();
        }
        self.seq = self.seq.wrapping_add(1);
    }

    /// A host report, copied into a zero-padded [`Report`] for the protocol task; a full
    /// queue drops it (the host sees no ack and resends).
    fn received(&mut self, bytes: &[u8]) {
        let mut report = [0u8; device::protocol::MAX_FRAME];
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
