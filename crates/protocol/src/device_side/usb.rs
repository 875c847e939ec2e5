//! The board's USB HID device (feature `usb`): the `usb-device` 0.3 device with the board's
//! ids and strings, two `usbd-hid` interfaces, and the pump between their endpoints and the
//! protocol, generic over the bus. The board runs it on the STM32's OTG_FS peripheral
//! (`firmware/src/bin/board.rs`); the host runs the same code over USB/IP (`usbip-device`,
//! `cargo xtask hid`), so the descriptors, the endpoints and the report pump a Linux kernel
//! enumerates in CI are the board's.
//!
//! Interface 0 ([`REPORT_DESCRIPTOR`]) has an interrupt OUT endpoint (the host's frames) and
//! an interrupt IN endpoint that carries telemetry only; interface 1
//! ([`REPLY_REPORT_DESCRIPTOR`]) has one interrupt IN endpoint for the replies (ack, nack,
//! status, hello). A full-speed interrupt endpoint carries one report per millisecond, the
//! telemetry's rate: a reply sent on the telemetry endpoint took a telemetry frame's slot
//! (0.6 % of the frames lost while a session was acked, measured through a Linux guest), on
//! its own endpoint it costs none. A telemetry frame is 64 bytes of 64 (`TELEMETRY_LEN`), so
//! a reply cannot ride in it.
//!
//! The two endpoints are read apart, so their relative order is lost on the way: telemetry
//! and replies are numbered apart ([`Numbering`]). A host that reads interface 0 only (a tool
//! that opens one hidraw node) gets every telemetry frame; the replies then wait on the
//! device, one in the endpoint and a queue's worth behind it, and newer ones are dropped
//! (the board's reply queue, `SimReports`'), so such a host sees no acks.
//!
//! What sits behind the port is a [`ReportPump`]: the board's queues to its protocol task
//! and tick (`firmware::usb::Usb`), or the host's simulated pantograph
//! (`protocol::host_side::simulated::SimReports`); the port's [`Outbox`] sends what waits in
//! them by the same rules for both.

use usb_device::bus::{UsbBus, UsbBusAllocator};
use usb_device::device::{
    StringDescriptors, UsbDevice, UsbDeviceBuilder, UsbDeviceState, UsbVidPid,
};
use usbd_hid::hid_class::HIDClass;

use super::Numbering;
use crate::{
    Frame, MAX_FRAME, Message, REPLY_REPORT_DESCRIPTOR, REPORT_DESCRIPTOR, USB_PID, USB_VID,
};

/// The manufacturer string the board reports.
pub const MANUFACTURER: &str = "nurbs-haptics";
/// The product string the board reports (`viewer device list` prints it).
pub const PRODUCT: &str = "NURBS haptic pantograph";
/// The interrupt endpoints' polling interval (ms): one report each way per millisecond, the
/// telemetry's rate (`crate::telemetry`).
pub const POLL_MS: u8 = 1;

/// What the USB port carries: host reports in; out, the device's replies and telemetry
/// frames waiting in their queues, which the port's [`Outbox`] sends on their endpoints.
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

/// The two streams a device sends, each on its own IN endpoint.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stream {
    /// Telemetry frames, interface 0's IN endpoint.
    Telemetry,
    /// Replies (ack, nack, status, hello), interface 1's IN endpoint.
    Replies,
}

/// What goes out on each IN endpoint, the board's and the host's simulation's alike: each
/// stream's oldest report, numbered with its own counter ([`Numbering`]) when it is sent, a
/// report the endpoint could not take offered again with the same number. The streams never
/// wait for each other: a reply waiting does not delay a telemetry frame, nor the reverse.
#[derive(Debug, Default)]
pub struct Outbox {
    numbering: Numbering,
    /// Whether [`Outbox::next`] gave a report of the stream (telemetry, replies).
    offered: [bool; 2],
}

impl Outbox {
    fn slot(stream: Stream) -> usize {
        match stream {
            Stream::Telemetry => 0,
            Stream::Replies => 1,
        }
    }

    /// The next report of `stream` to send from `pump`, `None` when nothing waits; it stays
    /// next until [`Outbox::sent`].
    pub fn next(&mut self, stream: Stream, pump: &mut impl ReportPump) -> Option<[u8; MAX_FRAME]> {
        let message = match stream {
            Stream::Telemetry => pump.frame(),
            Stream::Replies => pump.reply(),
        };
        let offered = message.is_some();
        if let Some(flag) = self.offered.get_mut(Self::slot(stream)) {
            *flag = offered;
        }
        let message = message?;
        Some(
            Frame {
                seq: self.numbering.peek(&message),
                message,
            }
            .to_report()
            .0,
        )
    }

    /// The report [`Outbox::next`] gave of `stream` went out: it leaves its queue and the
    /// stream's number moves on.
    pub fn sent(&mut self, stream: Stream, pump: &mut impl ReportPump) {
        let Some(flag) = self.offered.get_mut(Self::slot(stream)) else {
            return;
        };
        if !core::mem::take(flag) {
            return;
        }
        let message = match stream {
            Stream::Telemetry => pump.frame(),
            Stream::Replies => pump.reply(),
        };
        match stream {
            Stream::Telemetry => pump.take_frame(),
            Stream::Replies => pump.take_reply(),
        }
        if let Some(m) = message {
            self.numbering.advance(&m);
        }
    }
}

/// The board's USB HID device on bus `B`: interface 0 (host frames in, telemetry out) and
/// interface 1 (replies out).
pub struct HidPort<'a, B: UsbBus> {
    device: UsbDevice<'a, B>,
    hid: HIDClass<'a, B>,
    replies: HIDClass<'a, B>,
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
    /// The two HID interfaces with the protocol's report descriptors, and the device with the
    /// board's ids ([`USB_VID`]:[`USB_PID`]), strings (serial number `serial`) and a 64-byte
    /// control endpoint. Errors only if the bus cannot hold the endpoints or the strings.
    pub fn new(bus: &'a UsbBusAllocator<B>, serial: &'a str) -> Result<Self, usb_device::UsbError> {
        // Allocated in interface order: the telemetry's is interface 0, the replies' 1.
        let hid = HIDClass::new(bus, REPORT_DESCRIPTOR, POLL_MS);
        let replies = HIDClass::new_ep_in(bus, REPLY_REPORT_DESCRIPTOR, POLL_MS);
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
            replies,
            outbox: Outbox::default(),
        })
    }

    /// Whether the host configured the device (it then reads reports).
    pub fn configured(&self) -> bool {
        self.device.state() == UsbDeviceState::Configured
    }

    /// One service of the port: enumeration and control requests, host reports into
    /// `pump`, and at most one report out on each IN endpoint that is free (a reply on
    /// interface 1's, a telemetry frame on interface 0's). The board calls it from its USB
    /// interrupt (and after each telemetry frame), the host in its loop.
    pub fn poll(&mut self, pump: &mut impl ReportPump) {
        if self.device.poll(&mut [&mut self.hid, &mut self.replies]) {
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
        for (stream, class) in [
            (Stream::Replies, &self.replies),
            (Stream::Telemetry, &self.hid),
        ] {
            if let Some(report) = self.outbox.next(stream, pump)
                && class.push_raw_input(&report).is_ok()
            {
                self.outbox.sent(stream, pump);
            }
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

    fn telemetry(time_us: u32) -> Message {
        Message::Telemetry(crate::Telemetry {
            time_us,
            ..device::controller::TickOutput::IDLE.telemetry
        })
    }

    /// Sends everything waiting on `stream`, as an endpoint that takes every report.
    fn drain(outbox: &mut Outbox, stream: Stream, q: &mut Queues) -> Vec<(u16, Message)> {
        let mut sent = Vec::new();
        while let Some(report) = outbox.next(stream, q) {
            sent.push(decoded(report));
            outbox.sent(stream, q);
        }
        sent
    }

    /// Two frames wait, then a reply arrives: each goes out on its own endpoint, the frames
    /// numbered 0, 1 and the reply 0 (two counters); a report the endpoint refused is offered
    /// again with the same number; nothing offered, `sent` moves nothing.
    #[test]
    fn telemetry_and_replies_are_numbered_apart() {
        let mut q = Queues::default();
        q.frames.push_back(telemetry(1000));
        q.frames.push_back(telemetry(2000));
        q.replies.push_back(ack(20));
        let mut outbox = Outbox::default();
        let first = outbox.next(Stream::Replies, &mut q).expect("waiting");
        assert_eq!(decoded(first), (0, ack(20)));
        // The endpoint was busy: not sent, offered again unchanged.
        assert_eq!(outbox.next(Stream::Replies, &mut q), Some(first));
        outbox.sent(Stream::Replies, &mut q);
        assert_eq!(
            drain(&mut outbox, Stream::Telemetry, &mut q),
            [(0, telemetry(1000)), (1, telemetry(2000))]
        );
        assert!(q.replies.is_empty() && q.frames.is_empty());
        outbox.sent(Stream::Replies, &mut q);
        outbox.sent(Stream::Telemetry, &mut q);
        q.replies.push_back(ack(21));
        q.frames.push_back(telemetry(3000));
        assert_eq!(drain(&mut outbox, Stream::Replies, &mut q), [(1, ack(21))]);
        assert_eq!(
            drain(&mut outbox, Stream::Telemetry, &mut q),
            [(2, telemetry(3000))]
        );
    }

    /// A reply never delays telemetry: with replies waiting that their endpoint does not take
    /// (a host that reads interface 0 only, or a slow one), every telemetry frame still goes
    /// out at once, numbered one after the other; the replies wait, unspent, and go out
    /// numbered from 0 when their endpoint frees.
    #[test]
    fn a_reply_never_delays_a_telemetry_report() {
        let mut q = Queues::default();
        let mut outbox = Outbox::default();
        let mut frames = Vec::new();
        for k in 0..10u16 {
            q.replies.push_back(ack(k));
            q.frames.push_back(telemetry(u32::from(k) * 1000));
            // The replies' endpoint is busy: offered, not sent.
            assert!(outbox.next(Stream::Replies, &mut q).is_some());
            let report = outbox
                .next(Stream::Telemetry, &mut q)
                .expect("a frame waits");
            outbox.sent(Stream::Telemetry, &mut q);
            frames.push(decoded(report));
            assert!(q.frames.is_empty(), "frame {k} held back");
        }
        let expected: Vec<(u16, Message)> = (0..10u16)
            .map(|k| (k, telemetry(u32::from(k) * 1000)))
            .collect();
        assert_eq!(frames, expected);
        let replies: Vec<(u16, Message)> = (0..10u16).map(|k| (k, ack(k))).collect();
        assert_eq!(drain(&mut outbox, Stream::Replies, &mut q), replies);
    }

    /// Each counter wraps from 0xFFFF to 0 on its own (every value, as the host's gap
    /// counter expects), the other unmoved.
    #[test]
    fn each_counter_wraps_on_its_own() {
        let mut q = Queues::default();
        let mut outbox = Outbox::default();
        for _ in 0..0x1_0000u32 {
            q.frames.push_back(telemetry(0));
            drain(&mut outbox, Stream::Telemetry, &mut q);
        }
        q.frames.push_back(telemetry(7));
        q.replies.push_back(ack(7));
        assert_eq!(
            drain(&mut outbox, Stream::Telemetry, &mut q),
            [(0, telemetry(7))]
        );
        assert_eq!(drain(&mut outbox, Stream::Replies, &mut q), [(0, ack(7))]);
    }
}
