//! The board's USB HID device (feature `usb`): the `usb-device` 0.3 device with the board's
//! ids and strings, the `usbd-hid` class with [`REPORT_DESCRIPTOR`], and the pump between
//! its endpoints and the protocol, generic over the bus. The board runs it on the STM32's
//! OTG_FS peripheral (`firmware/src/bin/board.rs`); the host runs the same code over USB/IP
//! (`usbip-device`, `cargo xtask hid`), so the descriptor, the endpoints and the report
//! pump a Linux kernel enumerates in CI are the board's.
//!
//! What sits behind the port is a [`ReportPump`]: the board's queues to its protocol task
//! and tick (`firmware::usb::Usb`), or the host's simulated pantograph
//! (`device::host::sim::SimReports`).

use usb_device::bus::{UsbBus, UsbBusAllocator};
use usb_device::device::{
    StringDescriptors, UsbDevice, UsbDeviceBuilder, UsbDeviceState, UsbVidPid,
};
use usbd_hid::hid_class::HIDClass;

use crate::protocol::{MAX_FRAME, REPORT_DESCRIPTOR, USB_PID, USB_VID};

/// The manufacturer string the board reports.
pub const MANUFACTURER: &str = "nurbs-haptics";
/// The product string the board reports (`viewer device list` prints it).
pub const PRODUCT: &str = "NURBS haptic pantograph";
/// The interrupt endpoints' polling interval (ms): one report each way per millisecond, the
/// telemetry's rate (`crate::telemetry`).
pub const POLL_MS: u8 = 1;

/// What the USB port carries: host reports in, the device's frames out, one 64-byte frame
/// per report.
pub trait ReportPump {
    /// A host report (up to [`MAX_FRAME`] bytes) arrived on the OUT endpoint.
    fn received(&mut self, report: &[u8]);
    /// The next report to send on the IN endpoint, if one waits; it stays next until
    /// [`ReportPump::sent`].
    fn next_report(&mut self) -> Option<[u8; MAX_FRAME]>;
    /// The report of [`ReportPump::next_report`] went out.
    fn sent(&mut self);
    /// The device is not configured (no host): drop what waits rather than queue it.
    fn drop_frames(&mut self);
}

/// The board's USB HID device on bus `B`.
pub struct HidPort<'a, B: UsbBus> {
    device: UsbDevice<'a, B>,
    hid: HIDClass<'a, B>,
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
        Ok(HidPort { device, hid })
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
        if let Some(report) = pump.next_report()
            && self.hid.push_raw_input(&report).is_ok()
        {
            pump.sent();
        }
    }
}
