//! USB HID transport: one frame per 64-byte report, as the board's report descriptors
//! ([`REPORT_DESCRIPTOR`](crate::REPORT_DESCRIPTOR) and
//! [`REPLY_REPORT_DESCRIPTOR`](crate::REPLY_REPORT_DESCRIPTOR), shared with the firmware)
//! declare them.
//!
//! A board has two HID interfaces (`device_side::usb`): interface 0 takes the host's frames
//! and sends telemetry, interface 1 sends the replies, so that replies cost the 1 kHz
//! telemetry nothing. The OS gives each its own node (`/dev/hidrawN` on Linux); [`list_hid`]
//! lists a board once, by its interface 0, and [`HidLink::open`] finds the replies' node
//! beside it and reads both, each on a thread of its own, into one queue.

use std::ffi::CString;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, SyncSender};
use std::thread::JoinHandle;
use std::time::Duration;

use hidapi::{DeviceInfo, HidApi, HidDevice};

use super::{Link, LinkError, Sequencer};
use crate::{Frame, HID_REPLY_INTERFACE, HID_USAGE_PAGE, HID_USAGE_REPLIES, MAX_FRAME};
pub use crate::{USB_PID, USB_VID};

/// One board with the board's vendor and product id (its interface 0).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HidDeviceInfo {
    /// OS path (hidraw node on Linux) of the board's interface 0, for [`HidLink::open`].
    pub path: String,
    /// Vendor id.
    pub vendor_id: u16,
    /// Product id.
    pub product_id: u16,
    /// Product string, if the device reports one.
    pub product: Option<String>,
    /// Serial number, if the device reports one.
    pub serial_number: Option<String>,
}

/// Whether `d` is a board's replies interface (interface 1): by the usage of its collection
/// ([`HID_USAGE_REPLIES`], which every backend parses from the report descriptor), or by its
/// interface number where the backend gives no usage.
fn is_reply_interface(d: &DeviceInfo) -> bool {
    if d.usage_page() == HID_USAGE_PAGE {
        d.usage() == HID_USAGE_REPLIES
    } else {
        d.interface_number() == i32::from(HID_REPLY_INTERFACE)
    }
}

fn is_board(d: &DeviceInfo) -> bool {
    d.vendor_id() == USB_VID && d.product_id() == USB_PID
}

/// The boards with [`USB_VID`] / [`USB_PID`], one entry each (its interface 0; the replies'
/// interface is [`HidLink::open`]'s to find). An empty list when none is plugged in; an error
/// ([`LinkError::Hid`]) only when the OS backend itself is unavailable (no hidraw, no sysfs,
/// no permission to enumerate).
pub fn list_hid() -> Result<Vec<HidDeviceInfo>, LinkError> {
    let api = HidApi::new()?;
    Ok(api
        .device_list()
        .filter(|d| is_board(d) && !is_reply_interface(d))
        .map(|d| HidDeviceInfo {
            path: d.path().to_string_lossy().into_owned(),
            vendor_id: d.vendor_id(),
            product_id: d.product_id(),
            product: d.product_string().map(str::to_owned),
            serial_number: d.serial_number().map(str::to_owned),
        })
        .collect())
}

/// The node of the replies' interface of the board whose interface 0 is at `path`, if it has
/// one. On Linux by sysfs: the hidraw node whose HID device hangs off the same USB device
/// (`/sys/class/hidraw/NAME/device` is `…/<usb device>/<interface>/<hid device>`) with
/// `bInterfaceNumber` 1, which holds whatever the serial numbers (every board says "0001"
/// today). Elsewhere, the one reply interface with the same ids and serial number, if there
/// is exactly one.
fn reply_sibling(api: &HidApi, path: &str) -> Option<String> {
    #[cfg(target_os = "linux")]
    if let Some(node) = sysfs_sibling(std::path::Path::new("/sys/class/hidraw"), path) {
        return Some(node);
    }
    let me = api
        .device_list()
        .find(|d| d.path().to_string_lossy() == path)?;
    let mut siblings = api.device_list().filter(|d| {
        is_board(d) && is_reply_interface(d) && d.serial_number() == me.serial_number()
    });
    let sibling = siblings.next()?;
    siblings
        .next()
        .is_none()
        .then(|| sibling.path().to_string_lossy().into_owned())
}

/// [`reply_sibling`] on Linux: `class` is sysfs' `/sys/class/hidraw` (a folder of links to
/// the hidraw devices, each with a `device` link to its HID device); `/dev/NAME` the nodes.
#[cfg(target_os = "linux")]
fn sysfs_sibling(class: &std::path::Path, path: &str) -> Option<String> {
    let name = std::path::Path::new(path).file_name()?.to_str()?;
    // …/<usb device>/<usb interface>/<hid device>
    let hid_of = |name: &str| std::fs::canonicalize(class.join(name).join("device")).ok();
    let mine = hid_of(name)?;
    let usb_device = mine.parent()?.parent()?.to_path_buf();
    std::fs::read_dir(class)
        .ok()?
        .flatten()
        .filter_map(|e| e.file_name().to_str().map(str::to_owned))
        .filter(|other| other != name)
        .find(|other| {
            hid_of(other).is_some_and(|hid| {
                hid.parent().is_some_and(|interface| {
                    interface.parent() == Some(usb_device.as_path())
                        && std::fs::read_to_string(interface.join("bInterfaceNumber"))
                            .ok()
                            .and_then(|n| u8::from_str_radix(n.trim(), 16).ok())
                            == Some(HID_REPLY_INTERFACE)
                })
            })
        })
        .map(|other| format!("/dev/{other}"))
}

/// Reports from the board's nodes (or a reader's error, after which it stops).
type Incoming = Result<([u8; MAX_FRAME], usize), LinkError>;

/// Reads `device` into `to` until `stop`, or an error (sent, then the thread ends).
fn read_into(device: HidDevice, to: SyncSender<Incoming>, stop: Arc<AtomicBool>) {
    // Long enough not to spin, short enough that dropping the link does not wait.
    const POLL_MS: i32 = 20;
    while !stop.load(Ordering::Relaxed) {
        let mut buf = [0u8; MAX_FRAME];
        let sent = match device.read_timeout(&mut buf, POLL_MS) {
            Ok(0) => continue,
            Ok(n) => to.send(Ok((buf, n))),
            Err(e) => {
                let _ = to.send(Err(e.into()));
                return;
            }
        };
        if sent.is_err() {
            return;
        }
    }
}

/// Reports queued from the readers to [`Link::recv`]: a second of telemetry, as the
/// kernel's own buffer per reader (64 reports) is far smaller and drops what overflows it.
const QUEUE: usize = 1024;

/// A board over USB HID: frames written to interface 0; telemetry read from interface 0 and
/// replies from interface 1 (a board without it sends them on interface 0), each node read by
/// a thread of its own into one queue. Dropping the link stops the threads.
pub struct HidLink {
    device: HidDevice,
    seq: Sequencer,
    incoming: Receiver<Incoming>,
    stop: Arc<AtomicBool>,
    readers: Vec<JoinHandle<()>>,
    replies_path: Option<String>,
}

impl core::fmt::Debug for HidLink {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("HidLink")
            .field("seq", &self.seq)
            .field("replies_path", &self.replies_path)
            .finish_non_exhaustive()
    }
}

impl Drop for HidLink {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for reader in self.readers.drain(..) {
            let _ = reader.join();
        }
    }
}

impl HidLink {
    /// Opens the board whose interface 0 is at `path` (from [`list_hid`]) and its replies'
    /// interface beside it, when it has one.
    pub fn open(path: &str) -> Result<Self, LinkError> {
        let api = HidApi::new()?;
        let replies_path = reply_sibling(&api, path);
        let open = |p: &str| -> Result<HidDevice, LinkError> {
            let c = CString::new(p).map_err(|e| LinkError::Io(std::io::Error::other(e)))?;
            Ok(api.open_path(&c)?)
        };
        let device = open(path)?;
        let mut readers = vec![open(path)?];
        if let Some(p) = &replies_path {
            readers.push(open(p)?);
        }
        let (to, incoming) = mpsc::sync_channel(QUEUE);
        let stop = Arc::new(AtomicBool::new(false));
        let readers = readers
            .into_iter()
            .enumerate()
            .map(|(i, reader)| {
                let (to, stop) = (to.clone(), stop.clone());
                std::thread::Builder::new()
                    .name(format!("hid-reader-{i}"))
                    .spawn(move || read_into(reader, to, stop))
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(HidLink {
            device,
            seq: Sequencer::default(),
            incoming,
            stop,
            readers,
            replies_path,
        })
    }

    /// The node of the board's replies' interface, if it has one (else its replies come on
    /// interface 0's).
    pub fn replies_path(&self) -> Option<&str> {
        self.replies_path.as_deref()
    }

    /// Sends `bytes` as one output report as they are (no sequence number, no CRC; zero
    /// padded to [`MAX_FRAME`], at most that many): for tests of a device's handling of
    /// malformed input.
    pub fn send_raw(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        let mut out = [0u8; MAX_FRAME + 1];
        let n = bytes.len().min(MAX_FRAME);
        out[1..=n].copy_from_slice(&bytes[..n]);
        self.device.write(&out)?;
        Ok(())
    }

    /// Opens the first board [`list_hid`] lists.
    pub fn open_first() -> Result<Self, LinkError> {
        let first = list_hid()?.into_iter().next().ok_or_else(|| {
            LinkError::Io(std::io::Error::new(
                std::io::ErrorKind::NotFound,
                format!("no HID device {USB_VID:04x}:{USB_PID:04x}"),
            ))
        })?;
        Self::open(&first.path)
    }
}

impl Link for HidLink {
    fn send(&mut self, message: &crate::Message) -> Result<u16, LinkError> {
        let (report, _, seq) = self.seq.encode(message);
        // hidapi wants the report id first; the board's reports are unnumbered (id 0).
        let mut out = [0u8; MAX_FRAME + 1];
        out[1..].copy_from_slice(&report);
        self.device.write(&out)?;
        Ok(seq)
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<Frame>, LinkError> {
        match self.incoming.recv_timeout(timeout) {
            Ok(Ok((buf, n))) => self.seq.decode_reply(&buf[..n]).map(Some),
            Ok(Err(e)) => Err(e),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(LinkError::Closed),
        }
    }
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;
    use std::os::unix::fs::symlink;
    use std::path::Path;

    /// A sysfs as Linux lays it out for two boards on one hub (each interface 0 and 1, their
    /// HID devices under the interfaces) and a keyboard: every board finds its own interface
    /// 1's node, never the other board's (both report serial "0001") nor its own node.
    #[test]
    fn the_reply_node_is_the_same_usb_devices_interface_1() {
        let root = std::env::temp_dir().join(format!("hid-sysfs-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let devices = root.join("devices/pci0000:00/usb1");
        let class = root.join("class/hidraw");
        std::fs::create_dir_all(&class).expect("a temporary sysfs");
        let mut n = 0;
        let mut add = |usb: &str, interface: u8, node: &str| {
            let dir = devices.join(usb).join(format!("{usb}:1.{interface}"));
            std::fs::create_dir_all(&dir).expect("a temporary sysfs");
            std::fs::write(dir.join("bInterfaceNumber"), format!("{interface:02x}\n"))
                .expect("a temporary sysfs");
            n += 1;
            let hid = dir.join(format!("0003:1209:0001.{n:04X}"));
            let raw = hid.join("hidraw").join(node);
            std::fs::create_dir_all(&raw).expect("a temporary sysfs");
            symlink(&hid, raw.join("device")).expect("a temporary sysfs");
            symlink(&raw, class.join(node)).expect("a temporary sysfs");
        };
        add("1-1", 0, "hidraw0");
        add("1-1", 1, "hidraw1");
        add("1-2", 1, "hidraw2");
        add("1-2", 0, "hidraw3");
        add("1-3", 0, "hidraw4");
        let sibling = |p: &str| sysfs_sibling(Path::new(&class), p);
        assert_eq!(sibling("/dev/hidraw0").as_deref(), Some("/dev/hidraw1"));
        assert_eq!(sibling("/dev/hidraw3").as_deref(), Some("/dev/hidraw2"));
        // A device with one interface (a board of older firmware, a keyboard): none.
        assert_eq!(sibling("/dev/hidraw4"), None);
        assert_eq!(sibling("/dev/hidraw9"), None);
        let _ = std::fs::remove_dir_all(&root);
    }
}
