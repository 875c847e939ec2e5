//! Stream transports, serial and TCP: each frame COBS-encoded and followed by a `0x00`
//! delimiter.

use std::io::{Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

use serialport::{SerialPort, SerialPortType};

use super::{Link, LinkError, Sequencer, cobs};
use crate::{ErrorCode, Frame, FrameError, MAX_FRAME, Message};

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

/// A pseudo-terminal: a device served on `device` ([`super::SimLink::serve`]) is reached at
/// `path` as a board's serial port ([`SerialLink::open`]). It holds the other end open too,
/// so hosts can come and go.
#[cfg(unix)]
pub struct PseudoTerminal {
    /// The end a device is served on.
    pub device: Box<dyn SerialPort>,
    /// The path hosts open (`/dev/pts/N`).
    pub path: String,
    _host_end: serialport::TTYPort,
}

#[cfg(unix)]
impl core::fmt::Debug for PseudoTerminal {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("PseudoTerminal")
            .field("path", &self.path)
            .finish_non_exhaustive()
    }
}

/// Opens a new pseudo-terminal (raw mode), for the serial path without a board.
#[cfg(unix)]
pub fn pseudo_terminal() -> Result<PseudoTerminal, LinkError> {
    let (device, host_end) = serialport::TTYPort::pair()?;
    let path = SerialPort::name(&host_end)
        .ok_or_else(|| LinkError::Io(std::io::Error::other("the pseudo-terminal has no path")))?;
    Ok(PseudoTerminal {
        device: Box::new(device),
        path,
        _host_end: host_end,
    })
}

/// A byte stream the COBS framing runs over: a serial port, a TCP connection.
pub trait Stream: Read + Write {
    /// Bounds the next read's wait.
    fn set_read_timeout(&mut self, timeout: Duration) -> std::io::Result<()>;
    /// A name for messages.
    fn name(&self) -> String;
}

impl Stream for Box<dyn SerialPort> {
    fn set_read_timeout(&mut self, timeout: Duration) -> std::io::Result<()> {
        self.set_timeout(timeout).map_err(std::io::Error::from)
    }

    fn name(&self) -> String {
        SerialPort::name(self.as_ref()).unwrap_or_else(|| "serial port".into())
    }
}

impl Stream for TcpStream {
    fn set_read_timeout(&mut self, timeout: Duration) -> std::io::Result<()> {
        // A zero timeout means "block" to the OS; the shortest wait stands in for it.
        TcpStream::set_read_timeout(self, Some(timeout.max(Duration::from_micros(1))))
    }

    fn name(&self) -> String {
        self.peer_addr()
            .map_or_else(|_| "tcp".into(), |a| format!("tcp:{a}"))
    }
}

/// The packets of a COBS byte stream: bytes in, the complete `0x00`-delimited packets out.
/// Either end of a stream link uses it: the host ([`StreamLink`]) and a device served on a
/// stream ([`super::SimLink::serve`]).
#[derive(Debug, Default)]
pub(crate) struct Packets {
    pending: Vec<u8>,
}

impl Packets {
    /// Appends bytes read from the stream.
    pub(crate) fn push(&mut self, bytes: &[u8]) {
        self.pending.extend_from_slice(bytes);
    }

    /// The next complete, non-empty packet (empty ones are delimiters sent back to back:
    /// line idle, resync), its delimiter consumed; `None` until one is complete. Bytes
    /// without a delimiter for longer than any frame's encoding are noise and are dropped.
    pub(crate) fn next_packet(&mut self) -> Option<Vec<u8>> {
        loop {
            let Some(end) = self.pending.iter().position(|&b| b == 0) else {
                if self.pending.len() > cobs::max_encoded_len(MAX_FRAME) {
                    self.pending.clear();
                }
                return None;
            };
            let packet = self.pending[..end].to_vec();
            self.pending.drain(..=end);
            if !packet.is_empty() {
                return Some(packet);
            }
        }
    }
}

/// Reads what `stream` has within `timeout` into `packets`; false when nothing came.
/// A stream that ended is [`LinkError::Closed`].
pub(crate) fn read_packets(
    stream: &mut impl Stream,
    packets: &mut Packets,
    timeout: Duration,
) -> Result<bool, LinkError> {
    stream.set_read_timeout(timeout)?;
    let mut buf = [0u8; 4096];
    match stream.read(&mut buf) {
        Ok(0) => Err(LinkError::Closed),
        Ok(n) => {
            packets.push(&buf[..n]);
            Ok(true)
        }
        Err(e)
            if matches!(
                e.kind(),
                std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock
            ) =>
        {
            Ok(false)
        }
        Err(e) => Err(e.into()),
    }
}

/// Writes `frame` (its bytes, at most [`MAX_FRAME`]) to `stream` COBS-encoded with its
/// delimiter, and flushes.
pub(crate) fn write_packet(stream: &mut impl Write, frame: &[u8]) -> std::io::Result<()> {
    let mut bytes = cobs::encode(frame);
    bytes.push(0);
    stream.write_all(&bytes)?;
    stream.flush()
}

/// A board over a byte stream: each frame COBS-encoded and followed by a `0x00` delimiter.
/// [`SerialLink`] over a serial port, [`TcpLink`] over TCP (the firmware under QEMU, whose
/// UART QEMU serves on a TCP port).
pub struct StreamLink<S: Stream> {
    stream: S,
    seq: Sequencer,
    packets: Packets,
}

/// A board over a serial port.
pub type SerialLink = StreamLink<Box<dyn SerialPort>>;

/// A board (the emulated one) over TCP.
pub type TcpLink = StreamLink<TcpStream>;

impl<S: Stream> core::fmt::Debug for StreamLink<S> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("StreamLink")
            .field("stream", &self.stream.name())
            .field("seq", &self.seq)
            .finish()
    }
}

impl StreamLink<Box<dyn SerialPort>> {
    /// Opens the port at `path` at [`BAUD`].
    pub fn open(path: &str) -> Result<Self, LinkError> {
        let port = serialport::new(path, BAUD)
            .timeout(Duration::from_millis(10))
            .open()?;
        Ok(Self::over(port))
    }
}

impl StreamLink<TcpStream> {
    /// Connects to `address` (`HOST:PORT`), waiting at most `timeout`.
    pub fn connect(address: &str, timeout: Duration) -> Result<Self, LinkError> {
        let mut last = None;
        for addr in address.to_socket_addrs()? {
            match TcpStream::connect_timeout(&addr, timeout) {
                Ok(stream) => {
                    stream.set_nodelay(true)?;
                    return Ok(Self::over(stream));
                }
                Err(e) => last = Some(e),
            }
        }
        Err(last
            .unwrap_or_else(|| {
                std::io::Error::new(
                    std::io::ErrorKind::NotFound,
                    format!("{address} names no address"),
                )
            })
            .into())
    }
}

impl<S: Stream> StreamLink<S> {
    /// The link over `stream`.
    pub fn over(stream: S) -> Self {
        StreamLink {
            stream,
            seq: Sequencer::default(),
            packets: Packets::default(),
        }
    }

    /// Sends raw bytes as they are (no framing): for tests of a device's handling of
    /// malformed input.
    pub fn send_raw(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        self.stream.write_all(bytes)?;
        self.stream.flush()?;
        Ok(())
    }
}

impl<S: Stream> Link for StreamLink<S> {
    fn send(&mut self, message: &Message) -> Result<u16, LinkError> {
        let (report, n, seq) = self.seq.encode(message);
        write_packet(&mut self.stream, &report[..n])?;
        Ok(seq)
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<Frame>, LinkError> {
        let deadline = super::deadline(timeout);
        loop {
            if let Some(packet) = self.packets.next_packet() {
                let bad = |code| LinkError::Frame(FrameError { code, seq: None });
                let frame = cobs::decode(&packet).map_err(|_| bad(ErrorCode::BadLength))?;
                return self.seq.decode_reply(&frame).map(Some);
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(None);
            }
            if !read_packets(&mut self.stream, &mut self.packets, left)? {
                return Ok(None);
            }
        }
    }
}
