//! `cargo xtask hid`: the USB HID link end to end without a board.
//!
//! The board's USB device (`protocol::device_side::usb::HidPort`: its descriptor, endpoints and report pump,
//! the code the firmware runs) runs on the host's simulated pantograph
//! (`protocol::host_side::simulated::SimReports`) over USB/IP (`usbip-device`). A Linux kernel attaches it
//! with `usbip attach` (`vhci-hcd`), parses its report descriptor (`usbhid`, `hid-generic`)
//! and gives it a `/dev/hidraw` node, which the host side uses unchanged: `viewer device list`
//! and a session over `protocol::host_side::HidLink` (hidapi's hidraw backend).
//!
//! The machine's own kernel has no `vhci-hcd`, so all of this runs in a small guest:
//! `qemu-system-x86_64` (KVM when it boots, TCG otherwise) on Debian's `linux-image-amd64`
//! with an initramfs built here (busybox and the modules; the Debian packages are fetched with
//! `apt-get download` into `target/hid-guest/` and unpacked there, nothing is installed). The
//! project's binaries and the `usbip` tool run in the guest from the host's file system,
//! shared read-only over virtio-9p, in a chroot: the binaries the host built, with the host's
//! libraries. The chroot is a tmpfs of the guest's own with the host's top-level folders bound
//! into it and its own `/tmp` and `/run`, so that nothing of the host's is mounted over and a
//! checkout under `/tmp` stays visible (issue 35). The guest has no network but its own
//! loopback, where the USB/IP device listens.
//!
//! The guest prints its results on its console (`hid: ...` lines), which this reads.
//!
//! # Rates
//!
//! The board's device has two HID interfaces (`protocol::device_side::usb`): telemetry on
//! interface 0's IN endpoint, replies on interface 1's, so acks cost the telemetry nothing.
//! The session asserts that over 10 s in contact, heartbeats acked every 50 ms, no
//! telemetry frame the device's endpoint took is missing from the session's frames (their
//! sequence numbers, given as the endpoint takes a frame) and none is out of order; under
//! KVM, that none is lost at all (device time against frames received).
//!
//! Over USB/IP nothing paces the interrupt endpoints to one report a millisecond (the
//! guest's `vhci-hcd` completes an IN request as soon as the device answers it), so the
//! rate is what the guest reads. Under TCG that is less than 1 kHz: the guest's kernel
//! alone, a plain `cat` of the node with nothing written (no replies at all), took 435 to
//! 983 reports a second in three runs on a 2-core machine shared with other builds, and the
//! session 396 to 997 a second while acked (60 % to 0.44 % lost, every lost frame dropped
//! by the device's queue, none of its replies dropped). The simulated device produces 1 kHz of its clock (paced to the guest's,
//! skipping time only when it falls 100 ms behind) and its four-frame telemetry queue drops
//! what the reader does not take, as a board's does: frames lost before the endpoint, which
//! the session measures (`lost`, with the rate: frames received per second of the guest's
//! clock) and the device counts (`hid-guest: device: … dropped` on the console), and which
//! are not asserted under TCG.

mod cpio;
mod guest;
mod initramfs;
mod packages;
mod session;

use std::path::Path;

use guest::{KVM_BOOT_TIMEOUT, boot};
use initramfs::{GuestInit, init_script, write_initramfs};
use packages::{fetch_packages, find_kernel};

pub use session::{guest_device, guest_session};

/// The host packages `cargo xtask hid` installs when missing.
const HOST_PACKAGES: &[(&str, &str)] = &[
    (
        "qemu-system-x86",
        "the guest that runs the USB HID check (`cargo xtask hid`)",
    ),
    (
        "libudev1",
        "the `usbip` tool, run in the guest from the host's file system",
    ),
];

/// Runs the check: builds the guest, boots it, returns the lines it measured.
pub fn run(root: &Path, target: &Path, viewer: &Path) -> Result<Vec<String>, String> {
    crate::ensure_packages(HOST_PACKAGES, "the USB HID check")?;
    let cache = target.join("hid-guest");
    let unpacked = fetch_packages(&cache)?;
    let xtask = std::env::current_exe().map_err(|e| format!("hid: the xtask binary: {e}"))?;
    let kernel = find_kernel(&unpacked)?;
    let initrd = cache.join("initrd.cpio");
    let init = GuestInit::from_host(root, target, &unpacked, &xtask, viewer)?;
    write_initramfs(&initrd, &unpacked, &init_script(&init)?)?;
    let kvm = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open("/dev/kvm")
        .is_ok();
    let mut lines = Vec::new();
    let outcome = if kvm {
        match boot(&kernel, &initrd, "kvm", Some(KVM_BOOT_TIMEOUT)) {
            Ok(out) => Ok(out),
            Err(e) if e.contains("did not reach its init") => {
                lines.push(format!(
                    "hid: /dev/kvm opens but a KVM guest {e}: running under TCG instead"
                ));
                boot(&kernel, &initrd, "tcg", None)
            }
            Err(e) => Err(e),
        }
    } else {
        lines.push("hid: no usable /dev/kvm: running the guest under TCG".into());
        boot(&kernel, &initrd, "tcg", None)
    };
    let (accel, console, elapsed) = outcome?;
    lines.push(format!(
        "hid: guest ran under {accel} for {:.1} s",
        elapsed.as_secs_f64()
    ));
    let results: Vec<&str> = console
        .iter()
        .filter_map(|l| l.trim_end().strip_prefix("hid: ").map(|_| l.trim_end()))
        .collect();
    lines.extend(results.iter().map(|s| s.to_string()));
    if console.iter().any(|l| l.trim_end() == "hid: PASSED") {
        Ok(lines)
    } else {
        let tail: Vec<&String> = console.iter().rev().take(60).collect();
        let tail: Vec<&str> = tail.iter().rev().map(|s| s.as_str()).collect();
        Err(format!(
            "hid: the guest's check failed:\n{}\n--- the guest's console, last lines ---\n{}",
            lines.join("\n"),
            tail.join("\n")
        ))
    }
}
