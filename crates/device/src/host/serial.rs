//! Serial transport: each frame COBS-encoded and followed by a `0x00` delimiter.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use serialport::{SerialPort, SerialPortType};

use super::{Link, LinkError, Sequencer, cobs};
use crate::protocol::{ErrorCode, Frame, FrameError, MAX_FRAME, Message};

/// Baud rate used to open ports (ignored by USB CDC-ACM, which runs at USB speed).
pub const BAUD: u32 = 921_600;

/// One serial port.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SerialPortInfo {
    /// OS path (`/dev/ttyACM0`, `COM3`), for [`SerialLink::open`].
    pub path: String,
    /// USB vendor and product id, for USB ports.
    pub usb_id: Option<(u16, u16)>,
    /// Product string, for USB ports that report one.
    pub product: Option<String>,
}

/// The serial ports of this machine (any kind: which ones speak the protocol takes a hello to
/// find out). Empty when there are none.
pub fn list_serial() -> Result<Vec<SerialPortInfo>, LinkError> {
    Ok(serialport::available_ports()?
        .into_iter()
        .map(|p| {
            let (usb_id, product) = match p.port_type {
                SerialPortType::UsbPort(u) => (Some((u.vid, u.pid)), u.product),
                _ => (None, None),
            };
            SerialPortInfo {
                path: p.port_name,
                usb_id,
                product,
            }
        })
        .collect())
}

/// A board over a serial port.
pub struct SerialLink {
    port: Box<dyn SerialPort>,
    seq: Sequencer,
    pending: Vec<u8>,
}

impl core::fmt::Debug for SerialLink {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("SerialLink")
            .field("port", &self.port.name())
            .field("seq", &self.seq)
            .finish()
    }
}

impl SerialLink {
    /// Opens the port at `path` at [`BAUD`].
    pub fn open(path: &str) -> Result<Self, LinkError> {
        let port = serialport::new(path, BAUD)
            .timeout(Duration::from_millis(10))
            .open()?;
        Ok(SerialLink {
            port,
            seq: Sequencer::default(),
            pending: Vec::new(),
        })
    }

    /// The next complete packet in `pending`, if any (the delimiter is consumed).
    fn take_packet(&mut self) -> Option<Vec<u8>> {
        let end = self.pending.iter().position(|&b| b == 0)?;
        let packet = self.pending[..end].to_vec();
        self.pending.drain(..=end);
        Some(packet)
    }
}

impl Link for SerialLink {
    fn send(&mut self, message: &Message) -> Result<u16, LinkError> {
        let (report, n, seq) = self.seq.encode(message);
        let mut bytes = cobs::encode(&report[..n]);
        bytes.push(0);
        self.port.write_all(&bytes)?;
        self.port.flush()?;
        Ok(seq)
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<Frame>, LinkError> {
        let deadline = super::deadline(timeout);
        loop {
            while let Some(packet) = self.take_packet() {
                // Empty packets are delimiters sent back to back (line idle, resync).
                if packet.is_empty() {
                    continue;
                }
                let bad = |code| LinkError::Frame(FrameError { code, seq: None });
                let frame = cobs::decode(&packet).map_err(|_| bad(ErrorCode::BadLength))?;
                return Frame::decode(&frame).map(Some).map_err(LinkError::Frame);
            }
            // Without a delimiter for longer than any frame, the bytes are noise.
            if self.pending.len() > cobs::max_encoded_len(MAX_FRAME) {
                self.pending.clear();
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(None);
            }
            self.port.set_timeout(left)?;
            let mut buf = [0u8; 256];
            match self.port.read(&mut buf) {
                Ok(0) => return Err(LinkError::Closed),
                Ok(n) => self.pending.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => return Ok(None),
                Err(e) => return Err(e.into()),
            }
        }
    }
}
