//! `viewer device …` end to end: listing without hardware, monitoring the simulated device.

use std::process::{Command, Output};

fn viewer(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_viewer"))
        .args(args)
        .output()
        .expect("viewer runs")
}

#[test]
fn monitor_sim_prints_telemetry_and_exits_0() {
    let out = viewer(&[
        "device",
        "monitor",
        "--sim",
        // A full second, so a loaded CI machine still sees many frames after the handshake.
        "--seconds",
        "1",
        "--every",
        "10",
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let telemetry = stdout.lines().filter(|l| l.starts_with("t=")).count();
    assert!(telemetry >= 2, "{stdout}");
    assert!(
        stdout
            .lines()
            .any(|l| l.contains("hip=") && l.contains("mode=free"))
    );
    let last = stdout.lines().last().unwrap_or_default();
    assert!(
        last.starts_with("received ") && last.contains("dropped"),
        "{last}"
    );
}

#[test]
fn list_exits_0_with_or_without_devices() {
    let out = viewer(&["device", "list"]);
    assert!(out.status.success(), "{out:?}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.trim() == "no devices found" || stdout.starts_with("kind"),
        "{stdout}"
    );
}

#[test]
fn monitor_needs_a_device_and_a_valid_duration() {
    let out = viewer(&["device", "monitor"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--sim"));
    for bad in [
        &["--sim", "--seconds", "-1"][..],
        &["--sim", "--hid"],
        &["--sim", "--every", "0"],
        // Past u64::MAX seconds: used to panic (exit 101) in Duration::from_secs_f64.
        &["--sim", "--seconds", "1e20"],
        &["--sim", "--seconds", "1e300"],
    ] {
        let mut args = vec!["device", "monitor"];
        args.extend_from_slice(bad);
        let out = viewer(&args);
        assert_eq!(out.status.code(), Some(2), "{bad:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("panicked"), "{err}");
    }
}

/// `device identify --sim`: the protocol's identification run on the simulated device (its
/// handle released) finds the joints' Coulomb friction within 10 % of the description's
/// 3 mN·m (the damping, a few per cent of the torque, is `host::identify`'s test); without a
/// device it exits 2 naming the choices.
#[test]
fn identify_sim_measures_the_joints() {
    let out = viewer(&["device", "identify", "--sim"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for joint in ["joint 1:", "joint 2:"] {
        let line = stdout
            .lines()
            .find(|l| l.starts_with(joint))
            .unwrap_or_else(|| panic!("{stdout}"));
        let coulomb: f64 = line
            .split("Coulomb ")
            .nth(1)
            .and_then(|rest| rest.split_whitespace().next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("{line}"));
        assert!((coulomb - 3e-3).abs() < 3e-4, "{line}");
    }
    assert!(stdout.contains("10000 Hz: walls up to"), "{stdout}");
    let none = viewer(&["device", "identify"]);
    assert_eq!(none.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&none.stderr).contains("--sim"));
}
