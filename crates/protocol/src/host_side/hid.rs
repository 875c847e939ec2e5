//! USB HID transport: one frame per 64-byte report, as the board's report descriptor
//! ([`REPORT_DESCRIPTOR`](crate::REPORT_DESCRIPTOR), shared with the firmware)
//! declares them.

use std::ffi::CString;
use std::time::{Duration, Instant};

use hidapi::{HidApi, HidDevice};

use super::{Link, LinkError, Sequencer};
use crate::{Frame, MAX_FRAME};
pub use crate::{USB_PID, USB_VID};

/// One HID device with the board's vendor and product id.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HidDeviceInfo {
    /// OS path (hidraw node on Linux), for [`HidLink::open`].
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

/// The HID devices with [`USB_VID`] / [`USB_PID`]. An empty list when none is plugged in; an
/// error ([`LinkError::Hid`]) only when the OS backend itself is unavailable (no hidraw, no
/// sysfs, no permission to enumerate).
pub fn list_hid() -> Result<Vec<HidDeviceInfo>, LinkError> {
    let api = HidApi::new()?;
    Ok(api
        .device_list()
        .filter(|d| d.vendor_id() == USB_VID && d.product_id() == USB_PID)
        .map(|d| HidDeviceInfo {
            path: d.path().to_string_lossy().into_owned(),
            vendor_id: d.vendor_id(),
            product_id: d.product_id(),
            product: d.product_string().map(str::to_owned),
            serial_number: d.serial_number().map(str::to_owned),
        })
        .collect())
}

/// A board over USB HID.
pub struct HidLink {
    device: HidDevice,
    seq: Sequencer,
}

impl core::fmt::Debug for HidLink {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("HidLink").field("seq", &self.seq).finish()
    }
}

impl HidLink {
    /// Opens the device at `path` (from [`list_hid`]).
    pub fn open(path: &str) -> Result<Self, LinkError> {
        let api = HidApi::new()?;
        let path = CString::new(path).map_err(|e| LinkError::Io(std::io::Error::other(e)))?;
        Ok(HidLink {
            device: api.open_path(&path)?,
            seq: Sequencer::default(),
        })
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

    /// Opens the first device with [`USB_VID`] / [`USB_PID`].
    pub fn open_first() -> Result<Self, LinkError> {
        let api = HidApi::new()?;
        Ok(HidLink {
            device: api.open(USB_VID, USB_PID)?,
            seq: Sequencer::default(),
        })
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
        let deadline = super::deadline(timeout);
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            // Whole milliseconds, rounded up: rounding down would poll with a zero timeout
            // for the deadline's last millisecond, a busy loop that takes a core from
            // whatever should be sending the report.
            let ms = i32::try_from(left.as_micros().div_ceil(1000)).unwrap_or(i32::MAX);
            let mut buf = [0u8; MAX_FRAME];
            let n = self.device.read_timeout(&mut buf, ms)?;
            if n > 0 {
                return self.seq.decode_reply(&buf[..n]).map(Some);
            }
            if Instant::now() >= deadline {
                return Ok(None);
            }
        }
    }
}
