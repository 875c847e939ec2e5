//! Host side of the wire protocol (`std`): one [`Link`] trait and its three transports.
//!
//! - [`HidLink`]: USB HID, one frame per 64-byte report ([`list_hid`] enumerates boards by
//!   [`USB_VID`] / [`USB_PID`]);
//! - [`SerialLink`]: a serial port (USB CDC-ACM or a UART), frames [COBS](cobs)-encoded and
//!   delimited by `0x00` ([`list_serial`] enumerates ports);
//! - [`SimLink`]: the simulated pantograph and the device's own [`Controller`] on a thread of
//!   this process, speaking the same frames.
//!
//! A link numbers the frames it sends (per sender, wrapping, as the protocol requires) and
//! hands back every frame it receives with the device's sequence number; the device numbers
//! telemetry and replies apart, so the caller sees dropped telemetry as gaps in the
//! telemetry's numbers ([`GapCounter::telemetry`]).
//!
//! [`Controller`]: device::controller::Controller

/// `timeout` from now; a timeout too long for the clock (`Duration::MAX`: wait for ever)
/// becomes a century instead of the panic of `Instant + Duration`.
pub(crate) fn deadline(timeout: Duration) -> Instant {
    const CENTURY: Duration = Duration::from_secs(100 * 365 * 24 * 3600);
    let now = Instant::now();
    now.checked_add(timeout)
        .or_else(|| now.checked_add(CENTURY))
        .unwrap_or(now)
}

pub mod cobs;
mod hid;
mod requests;
mod serial;
mod simulated;

use std::time::{Duration, Instant};

pub use hid::{HidDeviceInfo, HidLink, USB_PID, USB_VID, list_hid};
pub use requests::{Answer, Requests};
pub use serial::{BAUD, SerialLink, SerialPortInfo, Stream, StreamLink, TcpLink, list_serial};
#[cfg(unix)]
pub use serial::{PseudoTerminal, pseudo_terminal};
#[cfg(feature = "usb")]
pub use simulated::SimReports;
pub use simulated::{SimConfig, SimHand, SimLink};

use crate::{
    Frame, FrameError, Hello, MAX_FRAME, MAX_PAYLOAD, Message, Nack, points_update, scene_upload,
};
use device::controller::ControllerError;
use device::simulator::SimulatorError;
use nurbs::Vec2;

/// Why a link operation failed.
#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    /// The HID backend failed (no hidraw / udev, permission, device gone).
    #[error("USB HID: {0}")]
    Hid(#[from] hidapi::HidError),
    /// The serial port failed.
    #[error("serial port: {0}")]
    Serial(#[from] serialport::Error),
    /// Reading or writing the transport failed.
    #[error("I/O: {0}")]
    Io(#[from] std::io::Error),
    /// Bytes arrived that are not a frame.
    #[error("bad frame: {}", .0.code)]
    Frame(FrameError),
    /// The device rejected a frame.
    #[error("device rejected frame {}: {}", .0.seq, .0.code)]
    Nack(Nack),
    /// No answer in time.
    #[error("no answer from the device within {0:?}")]
    Timeout(Duration),
    /// The other end is gone (the simulator thread stopped, the device was unplugged).
    #[error("link closed")]
    Closed,
    /// The simulated device could not start.
    #[error("simulated device: {0}")]
    Simulator(#[from] SimulatorError),
    /// The simulated device's controller could not start.
    #[error("simulated device: {0}")]
    Controller(#[from] ControllerError),
}

/// The host's own [`Hello`]: this crate's version, no scene capacity (the host receives no
/// scenes), the protocol's payload size.
pub fn host_hello() -> Hello {
    Hello {
        software: software_version(),
        scene_capacity: 0,
        max_payload: MAX_PAYLOAD as u8,
    }
}

fn software_version() -> [u8; 3] {
    let part = |s: &str| s.parse::<u8>().unwrap_or(0);
    [
        part(env!("CARGO_PKG_VERSION_MAJOR")),
        part(env!("CARGO_PKG_VERSION_MINOR")),
        part(env!("CARGO_PKG_VERSION_PATCH")),
    ]
}

/// Numbers the frames a host sends (wrapping u16) and encodes them.
///
/// The two ends number by different rules, and each end's gap check knows the other's: a
/// host skips [`UNKNOWN_SEQ`](crate::UNKNOWN_SEQ) ([`next_seq`](crate::next_seq): a nack's
/// expected number must never read as "unknown"), which the device's receiver expects; a
/// device numbers its telemetry and its replies apart, every value
/// ([`Numbering`](crate::device_side::Numbering)), which the host's [`GapCounter`] expects of
/// the telemetry.
#[derive(Clone, Copy, Debug, Default)]
pub struct Sequencer {
    next: u16,
}

impl Sequencer {
    /// Encodes `message` as the next frame into a zero-padded 64-byte report; returns the
    /// report, the frame's length and its sequence number.
    pub fn encode(&mut self, message: &Message) -> ([u8; MAX_FRAME], usize, u16) {
        let seq = self.next;
        self.next = crate::next_seq(self.next);
        let (report, n) = Frame {
            seq,
            message: *message,
        }
        .to_report();
        (report, n, seq)
    }

    /// Decodes a frame from the device and follows its sequence-gap nacks: a frame was lost
    /// on the way, the device waits for the number the nack names, so the next frame is
    /// numbered with it (otherwise every later frame would be refused as a gap too). Other
    /// refusals use up their number on the device as here (see
    /// [`SceneReceiver`](crate::SceneReceiver)), so they change nothing.
    pub fn decode_reply(&mut self, bytes: &[u8]) -> Result<Frame, LinkError> {
        let frame = Frame::decode(bytes).map_err(LinkError::Frame)?;
        if let Message::Nack(n) = frame.message
            && n.code == crate::ErrorCode::SequenceGap
            && n.expected_seq != crate::UNKNOWN_SEQ
        {
            self.next = n.expected_seq;
        }
        Ok(frame)
    }
}

/// A connection to a device.
pub trait Link: core::fmt::Debug {
    /// Sends `message` as the next frame; returns its sequence number.
    fn send(&mut self, message: &Message) -> Result<u16, LinkError>;

    /// The next frame from the device, or `None` when none arrived within `timeout`.
    fn recv(&mut self, timeout: Duration) -> Result<Option<Frame>, LinkError>;

    /// Sends `message` and waits for its ack; other frames arriving meanwhile (telemetry)
    /// are dropped. A nack is [`LinkError::Nack`].
    fn request(&mut self, message: &Message, timeout: Duration) -> Result<(), LinkError> {
        let mut requests = Requests::new();
        requests.send(self, [*message], (), Instant::now())?;
        let deadline = deadline(timeout);
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.recv(left)? {
                Some(frame) => match (requests.answer(&frame.message), frame.message) {
                    (Some(Answer::Acked(())), _) => return Ok(()),
                    (Some(Answer::Refused((), n)), _) => return Err(LinkError::Nack(n)),
                    // With one frame sent and waited for, a frame the device could not read
                    // is most likely it.
                    (None, Message::Nack(n)) if n.seq == crate::UNKNOWN_SEQ => {
                        return Err(LinkError::Nack(n));
                    }
                    (None, _) => {}
                },
                None => return Err(LinkError::Timeout(timeout)),
            }
            if Instant::now() >= deadline {
                return Err(LinkError::Timeout(timeout));
            }
        }
    }

    /// Opens the session: sends the host's [`Hello`] and waits for the device's. Frames
    /// that do not decode before it are skipped: a byte stream joined while the device was
    /// already sending (a board that streams from boot, an emulated UART that kept running)
    /// starts with the tail of a frame, which is no fault of the session about to begin.
    fn hello(&mut self, timeout: Duration) -> Result<Hello, LinkError> {
        self.send(&Message::Hello(host_hello()))?;
        let deadline = deadline(timeout);
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.recv(left) {
                Ok(Some(Frame {
                    message: Message::Hello(h),
                    ..
                })) => return Ok(h),
                Ok(Some(_)) | Err(LinkError::Frame(_)) => {}
                Ok(None) => return Err(LinkError::Timeout(timeout)),
                Err(e) => return Err(e),
            }
            if Instant::now() >= deadline {
                return Err(LinkError::Timeout(timeout));
            }
        }
    }

    /// Uploads a wire scene (from [`encode_scene`](crate::encode_scene)): begin,
    /// chunks, commit, each acked before the next is sent. `timeout` is per frame.
    fn upload_scene(&mut self, scene: &[u8], timeout: Duration) -> Result<(), LinkError> {
        for message in scene_upload(scene) {
            self.request(&message, timeout)?;
        }
        Ok(())
    }

    /// Moves control points of object `object` of the device's active scene in place
    /// ([`points_update`]: `(patch, first, points)` per patch, applied together), each
    /// frame acked before the next is sent, so it returns once the device applied the
    /// update (its renderer carries on, on the new shape). `timeout` is per frame. For a
    /// stream of shapes, [`Link::send_points`] does not wait.
    fn update_points(
        &mut self,
        object: u8,
        patches: &[(u8, u16, &[Vec2])],
        timeout: Duration,
    ) -> Result<(), LinkError> {
        for message in points_update(object, patches) {
            self.request(&message, timeout)?;
        }
        Ok(())
    }

    /// Sends the frames of a control-point update ([`points_update`]) without waiting, for
    /// shapes streamed faster than a round trip; returns their sequence numbers, whose acks
    /// (or nacks) arrive among the device's frames. The update is applied when its last
    /// frame is acked; a nack of any of its frames drops it whole (send the next shape).
    fn send_points(
        &mut self,
        object: u8,
        patches: &[(u8, u16, &[Vec2])],
    ) -> Result<Vec<u16>, LinkError> {
        points_update(object, patches)
            .map(|message| self.send(&message))
            .collect()
    }
}

/// Counts the telemetry frames lost between a device's sequence numbers (wrapping), and the
/// device's restarts. A device numbers its telemetry on a counter of its own, every value
/// ([`Numbering`](crate::device_side::Numbering)), so 0xFFFF → 0 is the next frame and
/// 0xFFFE → 0 one lost; its replies are numbered apart (over USB they arrive on another
/// endpoint, in no set order with the telemetry), so give it telemetry only
/// ([`GapCounter::telemetry`]). A host's frames, which skip 0xFFFF, are the device's
/// receiver's to check, not this counter's.
///
/// A number behind the last one (a wrapping step of half the range or more) is the device
/// starting its numbering again (a reset, a reflash, a new session on a shared link), not
/// 65,000 lost frames: at a frame a millisecond that many would be half a minute of silence,
/// which a link declares lost long before ([`crate::host_side`]'s users give up after 0.5 s).
#[derive(Clone, Copy, Debug, Default)]
pub struct GapCounter {
    last: Option<u16>,
    /// Frames missing so far.
    pub dropped: u64,
    /// Frames seen so far.
    pub received: u64,
    /// Times the numbering went backwards (the device restarted).
    pub restarts: u64,
}

impl GapCounter {
    /// Records `frame` if it is telemetry ([`GapCounter::observe`] of its number); a reply
    /// changes nothing (its number counts replies). Returns the telemetry frames missing just
    /// before it.
    pub fn telemetry(&mut self, frame: &Frame) -> u16 {
        if matches!(frame.message, Message::Telemetry(_)) {
            self.observe(frame.seq)
        } else {
            0
        }
    }

    /// Records a frame with sequence number `seq`; returns how many frames were missing
    /// just before it (0 when it follows the last one, and when the numbering went back:
    /// see [`GapCounter::restarts`]).
    pub fn observe(&mut self, seq: u16) -> u16 {
        let step = self.last.map_or(1, |last| seq.wrapping_sub(last));
        self.last = Some(seq);
        self.received += 1;
        if step == 0 {
            return 0; // the same frame again: nothing lost
        }
        if step >= 0x8000 {
            self.restarts += 1;
            return 0;
        }
        let gap = step - 1;
        self.dropped += u64::from(gap);
        gap
    }
}
