//! The guest's run: QEMU on the kernel and the initramfs, its console read until it powers
//! off; and, in the guest, the accelerator it runs under.

use std::io::{BufRead, BufReader, Write};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// The whole guest run may take this long (boot, attach, the session's ~20 s) under TCG on a
/// loaded 2-core machine; it took about a minute on an idle one.
const GUEST_TIMEOUT: Duration = Duration::from_secs(600);
/// A KVM guest that has not reached its init by then is not booting (nested virtualisation
/// that hangs in the firmware, as on some cloud machines): the check falls back to TCG.
pub(super) const KVM_BOOT_TIMEOUT: Duration = Duration::from_secs(20);

/// Kills QEMU however the check ends.
struct Guest(Child);

impl Drop for Guest {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Boots the guest with accelerator `accel` and reads its console until it powers off.
/// With `boot_timeout`, a guest that has not printed its init's first line by then is
/// abandoned ("did not reach its init").
pub(super) fn boot(
    kernel: &Path,
    initrd: &Path,
    accel: &str,
    boot_timeout: Option<Duration>,
) -> Result<(String, Vec<String>, Duration), String> {
    // The session reads the accelerator from the kernel's command line (`hid.accel=`): it
    // requires every telemetry frame under KVM, and measures what TCG lets through.
    let append =
        format!("console=ttyS0 loglevel=6 panic=-1 clocksource=tsc tsc=reliable hid.accel={accel}");
    let args: Vec<String> = [
        "-accel",
        accel,
        "-m",
        "1024",
        "-smp",
        "2",
        "-nographic",
        "-no-reboot",
        "-nic",
        "none",
        "-virtfs",
        "local,path=/,mount_tag=host,security_model=none,readonly=on,multidevs=remap",
        "-append",
        &append,
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    println!(
        "\n==> qemu-system-x86_64 {} -kernel {} -initrd {}",
        args.join(" "),
        kernel.display(),
        initrd.display()
    );
    let start = Instant::now();
    let mut child = Command::new("qemu-system-x86_64")
        .args(&args)
        .arg("-kernel")
        .arg(kernel)
        .arg("-initrd")
        .arg(initrd)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| format!("hid: cannot start qemu-system-x86_64: {e}"))?;
    let stdout = child.stdout.take().ok_or("hid: QEMU's console")?;
    let _guest = Guest(child);
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).split(b'\n').map_while(Result::ok) {
            if tx
                .send(String::from_utf8_lossy(&line).into_owned())
                .is_err()
            {
                break;
            }
        }
    });
    let mut console = Vec::new();
    let mut booted = false;
    let out = std::io::stdout();
    loop {
        let limit = match (booted, boot_timeout) {
            (false, Some(t)) => t,
            _ => GUEST_TIMEOUT,
        };
        let left = limit.saturating_sub(start.elapsed());
        match rx.recv_timeout(left) {
            Ok(line) => {
                // The firmware's screen clearing (escape sequences) may precede a line.
                let line = line.replace('\r', "");
                let line = match line.rfind("\x1b[2J") {
                    Some(at) => line[at + 4..].to_string(),
                    None => line,
                };
                let _ = writeln!(out.lock(), "guest | {line}");
                booted |= line.starts_with("hid: guest booted");
                console.push(line);
            }
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
            Err(mpsc::RecvTimeoutError::Timeout) if !booted && boot_timeout.is_some() => {
                return Err(format!("did not reach its init within {limit:?}"));
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {
                return Err(format!(
                    "hid: the guest ran past {GUEST_TIMEOUT:?}; its console:\n{}",
                    console.join("\n")
                ));
            }
        }
    }
    Ok((accel.to_string(), console, start.elapsed()))
}

/// The accelerator the guest runs under (`hid.accel=` on its kernel's command line, which
/// [`boot`] sets), or "unknown".
pub(super) fn guest_accel() -> String {
    std::fs::read_to_string("/proc/cmdline")
        .ok()
        .and_then(|c| {
            c.split_whitespace()
                .find_map(|w| w.strip_prefix("hid.accel=").map(str::to_owned))
        })
        .unwrap_or_else(|| "unknown".into())
}
