//! The board's USB HID device (feature `usb`): the `usb-device` 0.3 device with the board's
//! ids and strings, the `usbd-hid` class with [`REPORT_DESCRIPTOR`], and the pump between
//! its endpoints and the protocol, generic over the bus. The board runs it on the STM32's
//! OTG_FS peripheral (`firmware/src/bin/board.rs`); the host runs the same code over USB/IP
//! (`usbip-device`, `cargo xtask hid`), so the descriptor, the endpoints and the report
//! pump a Linux kernel enumerates in CI are the board's.
//!
//! What sits behind the port is a [`ReportPump`]: the board's queues to its protocol task
//! and tick (`firmware::usb::Usb`), or the host's simulated pantograph
//! (`protocol::host_side::simulated::SimReports`); the port's [`Outbox`] sends what waits in them in one
//! order for both.

use usb_device::bus::{UsbBus, UsbBusAllocator};
use usb_device::device::{
    StringDescriptors, UsbDevice, UsbDeviceBuilder, UsbDeviceState, UsbVidPid,
};
use usbd_hid::hid_class::HIDClass;

use crate::{Frame, MAX_FRAME, Message, REPORT_DESCRIPTOR, USB_PID, USB_VID};

/// The manufacturer string the board reports.
pub const MANUFACTURER: &str = "nurbs-haptics";
/// The product string the board reports (`viewer device list` prints it).
pub const PRODUCT: &str = "NURBS haptic pantograph";
/// The interrupt endpoints' polling interval (ms): one report each way per millisecond, the
/// telemetry's rate (`crate::telemetry`).
pub const POLL_MS: u8 = 1;

/// What the USB port carries: host reports in; out, the device's replies and telemetry
/// frames waiting in their queues, which the port's [`Outbox`] sends in the board's order.
pub trait ReportPump {
    /// A host report (up to [`MAX_FRAME`] bytes) arrived on the OUT endpoint.
    fn received(&mut self, report: &[u8]);
    /// The oldest reply waiting (ack, nack, status, hello), left in its queue.
    fn reply(&mut self) -> Option<Message>;
    /// The oldest telemetry frame waiting, left in its queue.
    fn frame(&mut self) -> Option<Message>;
    /// Takes the reply [`ReportPump::reply`] gave: it was sent.
    fn take_reply(&mut self);
    /// Takes the frame [`ReportPump::frame`] gave: it was sent.
    fn take_frame(&mut self);
    /// The device is not configured (no host): drop the waiting telemetry rather than queue
    /// it.
    fn drop_frames(&mut self);
}

/// The order of the IN endpoint, the board's and the host's simulation's alike: a reply
/// before any telemetry frame (a reply answers a request the host waits on; a frame late by
/// a report is still in order), each report numbered with the device's sequence when it is
/// sent (the host counts gaps in it), a report the endpoint could not take offered again
/// with the same number.
#[derive(Debug, Default)]
pub struct Outbox {
    seq: u16,
    /// What the report [`Outbox::next`] gave holds: a reply (`true`) or a frame.
    offered: Option<bool>,
}

impl Outbox {
    /// The next report to send from `pump`, `None` when nothing waits; it stays next until
    /// [`Outbox::sent`].
    pub fn next(&mut self, pump: &mut impl ReportPump) -> Option<[u8; MAX_FRAME]> {
        let (message, reply) = match pump.reply() {
            Some(m) => (m, true),
            None => (pump.frame()?, false),
        };
        self.offered = Some(reply);
        Some(
            Frame {
                seq: self.seq,
                message,
            }
            .to_report()
            .0,
        )
    }

    /// The report [`Outbox::next`] gave went out: it leaves its queue and the sequence moves
    /// on.
    pub fn sent(&mut self, pump: &mut impl ReportPump) {
        match self.offered.take() {
            Some(true) => pump.take_reply(),
            Some(false) => pump.take_frame(),
            None => return,
        }
        self.seq = self.seq.wrapping_add(1);
    }
}

/// The board's USB HID device on bus `B`.
pub struct HidPort<'a, B: UsbBus> {
    device: UsbDevice<'a, B>,
    hid: HIDClass<'a, B>,
    outbox: Outbox,
}

impl<B: UsbBus> core::fmt::Debug for HidPort<'_, B> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("HidPort")
            .field("state", &self.device.state())
            .finish_non_exhaustive()
    }
}

impl<'a, B: UsbBus> HidPort<'a, B> {
    /// The HID class with the protocol's report descriptor, and the device with the board's
    /// ids ([`USB_VID`]:[`USB_PID`]), strings (serial number `serial`) and a 64-byte control
    /// endpoint. Errors only if the bus cannot hold the endpoints or the strings.
    pub fn new(bus: &'a UsbBusAllocator<B>, serial: &'a str) -> Result<Self, usb_device::UsbError> {
        let hid = HIDClass::new(bus, REPORT_DESCRIPTOR, POLL_MS);
        let device = UsbDeviceBuilder::new(bus, UsbVidPid(USB_VID, USB_PID))
            .strings(&[StringDescriptors::default()
                .manufacturer(MANUFACTURER)
                .product(PRODUCT)
                .serial_number(serial)])
            .map_err(|_| usb_device::UsbError::InvalidState)?
            .max_packet_size_0(64)
            .map_err(|_| usb_device::UsbError::InvalidState)?
            .build();
        Ok(HidPort {
            device,
            hid,
            outbox: Outbox::default(),
        })
    }

    /// Whether the host configured the device (it then reads reports).
    pub fn configured(&self) -> bool {
        self.device.state() == UsbDeviceState::Configured
    }

    /// One service of the port: enumeration and control requests, host reports into
    /// `pump`, and at most one report out of it when the IN endpoint is free. The board calls
    /// it from its USB interrupt (and after each telemetry frame), the host in its loop.
    pub fn poll(&mut self, pump: &mut impl ReportPump) {
        if self.device.poll(&mut [&mut self.hid]) {
            let mut buf = [0u8; MAX_FRAME];
            while let Ok(n) = self.hid.pull_raw_output(&mut buf) {
                if n == 0 {
                    break;
                }
                pump.received(buf.get(..n).unwrap_or(&[]));
            }
        }
        if !self.configured() {
            pump.drop_frames();
            return;
        }
        if let Some(report) = self.outbox.next(pump)
            && self.hid.push_raw_input(&report).is_ok()
        {
            self.outbox.sent(pump);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::VecDeque;
    use std::vec::Vec;

    /// Two queues of messages, and what was taken.
    #[derive(Default)]
    struct Queues {
        replies: VecDeque<Message>,
        frames: VecDeque<Message>,
    }

    impl ReportPump for Queues {
        fn received(&mut self, _: &[u8]) {}
        fn reply(&mut self) -> Option<Message> {
            self.replies.front().copied()
        }
        fn frame(&mut self) -> Option<Message> {
            self.frames.front().copied()
        }
        fn take_reply(&mut self) {
            self.replies.pop_front();
        }
        fn take_frame(&mut self) {
            self.frames.pop_front();
        }
        fn drop_frames(&mut self) {
            self.frames.clear();
        }
    }

    fn ack(seq: u16) -> Message {
        Message::Ack { seq }
    }

    fn decoded(report: [u8; MAX_FRAME]) -> (u16, Message) {
        let frame = Frame::decode(&report).expect("a valid frame");
        (frame.seq, frame.message)
    }

    /// Two frames wait, then a reply arrives: the reply goes first, the frames after it in
    /// their order, each report one sequence number on; a report the endpoint refused is
    /// offered again with the same number.
    #[test]
    fn replies_overtake_frames_and_numbers_follow_what_was_sent() {
        let mut q = Queues::default();
        q.frames.push_back(ack(10));
        q.frames.push_back(ack(11));
        q.replies.push_back(ack(20));
        let mut outbox = Outbox::default();
        let first = outbox.next(&mut q).expect("waiting");
        assert_eq!(decoded(first), (0, ack(20)));
        // The endpoint was busy: not sent, offered again unchanged.
        assert_eq!(outbox.next(&mut q), Some(first));
        outbox.sent(&mut q);
        let mut sent = Vec::new();
        while let Some(report) = outbox.next(&mut q) {
            sent.push(decoded(report));
            outbox.sent(&mut q);
        }
        assert_eq!(sent, [(1, ack(10)), (2, ack(11))]);
        assert!(q.replies.is_empty() && q.frames.is_empty());
        // Nothing offered: `sent` moves nothing.
        outbox.sent(&mut q);
        q.replies.push_back(ack(21));
        assert_eq!(decoded(outbox.next(&mut q).expect("waiting")), (3, ack(21)));
    }
}
