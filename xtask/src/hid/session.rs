//! What runs in the guest: the board's USB device on USB/IP (`xtask hid-guest-device`) and
//! the host's session over hidraw that checks the link (`xtask hid-guest-session`).

use std::path::Path;
use std::time::{Duration, Instant};

use nurbs::Vec2;
use protocol::host_side::{HidLink, Link, list_hid};
use protocol::{Message, Telemetry};
use scene::Scene;

use super::guest::guest_accel;
use crate::session::Host;

/// The simulated device's heartbeat timeout in the guest (µs): a quarter second, as the
/// emulated board's, so that an emulated guest's stalls do not trip it while heartbeats flow
/// every 50 ms.
const GUEST_WATCHDOG_US: u32 = 250_000;
/// How long the session counts telemetry (the 10 s).
const TELEMETRY_WINDOW: Duration = Duration::from_secs(10);
/// Round trips measured (heartbeat → its ack).
const ROUND_TRIPS: usize = 200;

/// In the guest (`xtask hid-guest-device`): the board's USB device on USB/IP, the simulated
/// pantograph behind it, until the guest powers off.
pub fn guest_device() -> Result<(), String> {
    use device::safety::SafetyConfig;
    use protocol::device_side::usb::HidPort;
    use protocol::host_side::{SimConfig, SimLink};
    use usb_device::bus::UsbBusAllocator;
    let config = SimConfig {
        // The board's telemetry rate with one tick per frame: an emulated guest keeps pace
        // with it (10 kHz ticks are the firmware's, measured under QEMU by `cargo xtask qemu`).
        safety: SafetyConfig {
            period_s: 1e-3,
            heartbeat_timeout_s: GUEST_WATCHDOG_US as f32 * 1e-6,
            ..SafetyConfig::default()
        },
        ..SimConfig::default()
    };
    let mut reports = SimLink::spawn(config)
        .map_err(|e| format!("hid-guest-device: {e}"))?
        .into_reports();
    let bus = UsbBusAllocator::new(usbip_device::UsbIpBus::new());
    let mut port = HidPort::new(&bus, "usbip").map_err(|e| format!("hid-guest-device: {e:?}"))?;
    let mut since = Instant::now();
    let mut sent0 = 0u64;
    while reports.running() {
        // USB/IP takes one request per poll: poll a few times, then sleep, so that the
        // guest's kernel (whose USB/IP threads carry every report) and the session have the
        // emulated CPUs (a busy loop here starved them: a tenth of the reports went through).
        for _ in 0..4 {
            port.poll(&mut reports);
        }
        std::thread::sleep(Duration::from_micros(200));
        if since.elapsed() > Duration::from_secs(2) {
            let n = reports.sent_count();
            eprintln!(
                "hid-guest: device: {} reports/s, {} telemetry frames and {} replies dropped in all",
                (n - sent0) / 2,
                reports.dropped_count(),
                reports.dropped_replies()
            );
            sent0 = n;
            since = Instant::now();
        }
    }
    Err("hid-guest-device: the simulated device stopped".into())
}

/// In the guest (`xtask hid-guest-session ROOT`): the host side over hidraw, printing
/// `hid: ...` lines and `hid: PASSED` when every check held.
pub fn guest_session(root: &Path) -> Result<(), String> {
    let result = session(root);
    match &result {
        Ok(lines) => {
            for l in lines {
                println!("hid: {l}");
            }
            println!("hid: PASSED");
        }
        Err(e) => println!("hid: FAILED: {e}"),
    }
    result.map(|_| ())
}

fn session(root: &Path) -> Result<Vec<String>, String> {
    let mut lines = Vec::new();
    let start = Instant::now();
    let devices = loop {
        let found = list_hid().map_err(|e| format!("hidapi: {e}"))?;
        if !found.is_empty() {
            break found;
        }
        if start.elapsed() > Duration::from_secs(20) {
            return Err("no HID device with the board's VID:PID within 20 s".into());
        }
        std::thread::sleep(Duration::from_millis(200));
    };
    let info = &devices[0];
    lines.push(format!(
        "found {} {:04x}:{:04x} product={:?} serial={:?}",
        info.path, info.vendor_id, info.product_id, info.product, info.serial_number
    ));
    // The board's second interface (the replies') may get its node a moment after the first.
    let link = loop {
        let link = HidLink::open(&info.path).map_err(|e| format!("open {}: {e}", info.path))?;
        if link.replies_path().is_some() || start.elapsed() > Duration::from_secs(25) {
            break link;
        }
        drop(link);
        std::thread::sleep(Duration::from_millis(200));
    };
    let replies = link
        .replies_path()
        .ok_or_else(|| format!("no replies interface beside {}", info.path))?
        .to_owned();
    lines.push(format!(
        "replies on {replies}, the board's interface {}",
        protocol::HID_REPLY_INTERFACE
    ));
    let mut host = Host::new(link);
    // The hand's target is sent when it moves, not streamed: every output report costs the
    // emulated guest a USB/IP round trip (see the notes on rates in `hid`'s module docs).
    host.targets = false;
    let hello = host
        .link
        .hello(Duration::from_secs(5))
        .map_err(|e| format!("hello: {e}"))?;
    lines.push(format!(
        "hello software={:?} scene_capacity={}",
        hello.software, hello.scene_capacity
    ));
    let scene_path = root.join("scenes").join("thesis-2d.json");
    let scene = Scene::load(&scene_path).map_err(|e| format!("{}: {e}", scene_path.display()))?;
    let scene = passive_at_guest_rate(&scene)?;
    let wire = host::upload::wire_scene(&scene, 0).map_err(|e| format!("wire scene: {e}"))?;
    let above = Vec2::new(0.01, 0.11);
    let mut retries = 0;
    retries += ask(&mut host, &Message::ClearFaults { mask: 0xFFFF }, above)?;
    retries += ask(&mut host, &Message::Calibrate, above)?;
    retries += upload(&mut host, &wire, above)?;
    retries += ask(&mut host, &Message::EnableForces, above)?;
    let crc = host.scene_crc(above)?;
    if crc != protocol::crc32(&wire) {
        return Err(format!(
            "the device's scene CRC {crc:#x} is not the uploaded scene's {:#x}",
            protocol::crc32(&wire)
        ));
    }
    lines.push(format!(
        "calibrated, cleared, scene of {} B uploaded and committed (CRC {crc:#010x}), forces on",
        wire.len()
    ));

    // Round trips: a heartbeat, then frames until its ack.
    let mut rtt = Vec::with_capacity(ROUND_TRIPS);
    for _ in 0..ROUND_TRIPS {
        let sent = Instant::now();
        let seq = host
            .link
            .send(&Message::Heartbeat { uptime_ms: 0 })
            .map_err(|e| format!("heartbeat: {e}"))?;
        loop {
            match host
                .link
                .recv(Duration::from_secs(2))
                .map_err(|e| format!("link: {e}"))?
            {
                Some(f) if f.message == (Message::Ack { seq }) => break,
                Some(_) => {}
                None => return Err("a heartbeat was not acked within 2 s".into()),
            }
        }
        rtt.push(sent.elapsed().as_secs_f64() * 1e3);
    }
    rtt.sort_by(f64::total_cmp);
    let pick = |q: f64| rtt[((rtt.len() - 1) as f64 * q).round() as usize];
    lines.push(format!(
        "round trip (heartbeat to ack, {ROUND_TRIPS} times): median {:.2} ms, 99th percentile {:.2} ms, max {:.2} ms",
        pick(0.5),
        pick(0.99),
        pick(1.0)
    ));

    // Into the right arc (the circle of radius 40 mm about (−20, 60) mm), 4 mm deep at
    // 41.4°, at a hand's pace: fifty steps of 0.54 mm, 10 ms apart (at least); then telemetry
    // counted for 10 s in contact. Ten 2.7 mm jumps (a 5.4 N pull each, through the firm
    // hand) bounced the handle off the 1 kHz wall, and the passivity controller's tank then
    // held the wall 3.6 mm in (0.25 N against 2.7 N): about half of the runs failed.
    // `crates/host/tests/run_device.rs` closes the same press through the same device.
    let inside = Vec2::new(-0.02, 0.06)
        + Vec2::new(41.4f32.to_radians().cos(), 41.4f32.to_radians().sin()) * 0.036;
    // Faults latched meanwhile (a heartbeat late behind a slow emulated round trip trips
    // the watchdog) are cleared first, and the forces enabled again.
    retries += ask(&mut host, &Message::ClearFaults { mask: 0xFFFF }, above)?;
    retries += ask(&mut host, &Message::EnableForces, above)?;
    // Once in about eight runs under the emulator the force was still lost to the tank after
    // such a press (not reproduced on the host, where the same press is a test): a press
    // whose last 100 ms do not hold the wall's force is said, with its trace, and made again
    // from free space (which empties the tank), as a user lifts and presses again; a second
    // loss fails the check below.
    let mut presses = 0;
    let press = loop {
        presses += 1;
        let press_from = host.telemetry.len();
        const STEPS: u16 = 50;
        for k in 1..=STEPS {
            let at = above + (inside - above) * (f32::from(k) / f32::from(STEPS));
            retries += ask(&mut host, &Message::HandTarget { target_m: at }, at)?;
            // Each step lasts 10 ms of the device's own clock. The emulated device is paced
            // to the host's clock but drops time when it falls behind, so host time alone
            // made the steps come twice as fast in its time in a failed CI run (50 steps in
            // 260 ms of device time: every step a bounce).
            let from = host.telemetry.last().map(|t| t.time_us);
            let started = Instant::now();
            loop {
                host.pump(Duration::from_millis(5), |_| at)?;
                let now = host.telemetry.last().map(|t| t.time_us);
                let stepped =
                    matches!((from, now), (Some(a), Some(b)) if b.wrapping_sub(a) >= 10_000);
                if stepped || started.elapsed() > Duration::from_secs(1) {
                    break;
                }
            }
        }
        host.pump(Duration::from_millis(300), |_| inside)?;
        let pressed = host.telemetry.get(press_from..).unwrap_or_default();
        // The press as the device reported it, for a message.
        let trace = press_trace(pressed);
        let settled = &pressed[pressed.len().saturating_sub(100)..];
        let held = settled.iter().filter(|t| t.force_n.length() > 0.1).count();
        if 2 * held >= settled.len() || presses == 2 {
            break trace;
        }
        lines.push(format!(
            "press {presses}: {held} of the last {} frames with a force over 0.1 N: lifted \
             and pressed again; the press (every 10th frame from the first contact, or from its start):\n{trace}",
            settled.len()
        ));
        retries += ask(&mut host, &Message::HandTarget { target_m: above }, above)?;
        host.pump(Duration::from_millis(300), |_| above)?;
    };
    lines.push(format!("presses into the arc: {presses}"));
    host.telemetry.clear();
    let (gaps_before, heartbeats_before) = (host.gaps.dropped, host.heartbeats_sent());
    host.pump(TELEMETRY_WINDOW, |_| inside)?;
    let seq_gaps = host.gaps.dropped - gaps_before;
    let heartbeats = host.heartbeats_sent() - heartbeats_before;
    let frames: &[Telemetry] = &host.telemetry;
    let (first, last) = match (frames.first(), frames.last()) {
        (Some(f), Some(l)) => (f.time_us, l.time_us),
        _ => return Err("no telemetry in 10 s with forces on".into()),
    };
    // One frame per millisecond of device time: what the device sent from the first frame to
    // the last, against what arrived. Every frame decoded (CRC-checked) and came in order:
    // its device time after the previous one's, on the millisecond grid.
    let span_ms = u64::from(last.wrapping_sub(first)) / 1000;
    let expected = span_ms + 1;
    let lost = expected.saturating_sub(frames.len() as u64);
    let rate = frames.len() as f64 / TELEMETRY_WINDOW.as_secs_f64();
    let pressing = frames.iter().filter(|t| t.force_n.length() > 0.1).count();
    let disordered = frames
        .windows(2)
        .filter(|w| {
            let d = w[1].time_us.wrapping_sub(w[0].time_us);
            d == 0 || d > 1_000_000 || d % 1000 != 0
        })
        .count();
    lines.push(format!(
        "telemetry over {:.0} s under {}: {} frames received ({rate:.0} per second) of {expected} \
         the device produced (device time {span_ms} ms), {lost} lost ({:.2} %), {disordered} out of order or \
         duplicated, {seq_gaps} missing from the telemetry's sequence numbers, with {heartbeats} \
         heartbeats sent meanwhile; {pressing} frames with a contact force over 0.1 N",
        TELEMETRY_WINDOW.as_secs_f64(),
        guest_accel(),
        frames.len(),
        100.0 * lost as f64 / expected as f64
    ));
    // What must hold: frames intact and in order; none missing from the sequence numbers,
    // which the device gives a telemetry frame as its endpoint takes it (so none was lost
    // between the device's endpoint and the session, while the heartbeats' acks and statuses
    // went on the other endpoint); the device's clock at 1 kHz (the span covers the window);
    // the hand in contact. None lost at all (device time against frames received) under
    // KVM. Under TCG the emulated guest reads fewer than 1000 reports a second (its kernel
    // alone: the plain reader above, nothing written, no replies), so the device's
    // four-frame queue drops frames before its endpoint, as a board's does for a host that
    // does not keep up: those are measured (`lost`, and the device's own count on its
    // `hid-guest: device:` lines), not asserted.
    let span_s = span_ms as f64 / 1000.0;
    let accel = guest_accel();
    if (accel == "kvm" && lost != 0)
        || seq_gaps != 0
        || disordered != 0
        || pressing < frames.len() / 2
        || !(8.0..=12.0).contains(&span_s)
    {
        let faults: Vec<u16> = frames.iter().map(|t| t.faults).collect();
        return Err(format!(
            "telemetry: {lost} frames lost, {seq_gaps} missing from the sequence numbers, \
             {disordered} out of order, {pressing} of {} in contact, device \
             time {span_s} s over a {:.0} s window; the last frame {:?}; faults seen {:?}; \
             the press (every 10th frame from the first contact, or from its start):\n{press}",
            frames.len(),
            TELEMETRY_WINDOW.as_secs_f64(),
            frames.last(),
            faults.iter().fold(0u16, |a, f| a | f)
        ));
    }

    // Garbage: an output report that is no frame gets a nack, and the device runs on.
    host.nacks.clear();
    host.link
        .send_raw(&[0x05, 0x01, 0x02, 0x03, 0x04, 0x00])
        .map_err(|e| format!("raw report: {e}"))?;
    let before = host.telemetry.len();
    host.pump(Duration::from_millis(300), |_| inside)?;
    let after = host.telemetry.len() - before;
    lines.push(format!(
        "garbage report: nacks {:?}, {after} telemetry frames in the 300 ms after it",
        host.nacks
    ));
    if host.nacks.is_empty() || after == 0 {
        return Err(format!(
            "garbage report: nacks {:?} and {after} frames after it (a nack and the device running on expected)",
            host.nacks
        ));
    }

    lines.push(format!(
        "requests sent again after their answer did not come within 5 s: {retries}"
    ));
    lines.push(watchdog(&mut host, inside)?);
    Ok(lines)
}

/// Attempts at a request before the session gives up.
const ATTEMPTS: usize = 3;

/// Every 10th frame of `frames` from the first with a normal force, or from the first when
/// none has one (at most 100 lines): the device time, HIP, the renderer's normal force, the
/// force applied, the friction state and the faults.
fn press_trace(frames: &[Telemetry]) -> String {
    // From the first contact; from the press's start when there was none (a press that never
    // touched says where the handle went and what the device reported meanwhile).
    let first = frames
        .iter()
        .position(|t| t.force_normal_n > 0.0)
        .unwrap_or(0);
    frames[first..]
        .iter()
        .step_by(10)
        .take(100)
        .map(|t| {
            format!(
                "  {:>9} us  hip ({:.5}, {:.5}) m  F_N {:.3} N  |F| {:.3} N  {:?} {:?}  faults {:#x}",
                t.time_us,
                t.hip_m.x,
                t.hip_m.y,
                t.force_normal_n,
                t.force_n.length(),
                t.mode,
                t.cause,
                t.faults
            )
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Sends `m` (an idempotent request) until the device answers, at most [`ATTEMPTS`] times;
/// returns how many times it was sent again. An answer can be lost on the host: the kernel
/// keeps 64 reports per hidraw reader and drops what comes while they are unread, acks
/// included, when the emulated reader falls behind.
fn ask(host: &mut Host<HidLink>, m: &Message, at: Vec2) -> Result<usize, String> {
    let mut last = String::new();
    for attempt in 0..ATTEMPTS {
        match host.send_awaiting(m, at) {
            Ok(Ok(())) => return Ok(attempt),
            Ok(Err(code)) => return Err(format!("{:?} refused: {code}", m.message_type())),
            // No answer: sent again.
            Err(e) => last = e,
        }
    }
    Err(last)
}

/// `scene` with its first object's wall softened to what the guest's simulated device (1 kHz
/// ticks, [`guest_device`]) renders passively without its passivity controller: nine tenths
/// of the device's own bound at that rate ([`WallLimits`], about 300 N/m for the default
/// device, against thesis-2d's 1000).
///
/// This check is of the USB link, not of the wall. At 1 kHz thesis-2d's wall needs the
/// controller's energy tank, and a press that bounces off it (the emulated device falls
/// behind the host and takes the hand's steps in bursts) can drain the tank. The force then
/// grows back only as a spring from where the handle stands, which is the tank's rule
/// against pulses at rest. In about one run in three under load the handle then rested 4 mm
/// in with 0.02 N of a 4 N wall (a CI run of db70919: "0 of 9908 in contact"). That
/// weakness is the tank's, at 1 kHz; the board renders thesis-2d at 10 kHz without it.
///
/// [`WallLimits`]: device::wall::WallLimits
fn passive_at_guest_rate(scene: &Scene) -> Result<Scene, String> {
    use device::safety::SafetyConfig;
    use device::wall::WallLimits;
    let safety = SafetyConfig::default();
    let (passive_n_per_m, _) = WallLimits::new(&safety.passivity, 0.0, 1e-3).max(false);
    let object = scene.object(0).ok_or("thesis-2d has no object")?;
    let mut material = object.material().friction_material();
    material.stiffness_n_per_m = (0.9 * passive_n_per_m).min(material.stiffness_n_per_m);
    let material =
        scene::Material::from_friction(material).map_err(|e| format!("material: {e}"))?;
    scene
        .with_material(0, material)
        .map_err(|e| format!("scene: {e}"))
}

/// [`Host::upload`], the whole upload begun again (at most [`ATTEMPTS`] times) when an answer
/// does not come; returns how many times it was begun again.
fn upload(host: &mut Host<HidLink>, wire: &[u8], at: Vec2) -> Result<usize, String> {
    let mut last = String::new();
    for attempt in 0..ATTEMPTS {
        match host.upload(wire, at) {
            Ok(()) => return Ok(attempt),
            Err(e) => last = e,
        }
    }
    Err(last)
}

/// Heartbeat loss over HID: the force goes off once the watchdog's timeout has passed since
/// the last heartbeat, and not before. The device handled the last heartbeat (it acked it)
/// after every telemetry frame that reached the host before the host sent it, so the newest
/// of those frames' device times is a lower bound `L` of the heartbeat's time: a faulted
/// frame earlier than `L` + timeout would be a premature trip. (Not the frames before its
/// ack: replies come on their own endpoint, read apart from the telemetry, so a frame of a
/// tick after the heartbeat may reach the host before the ack does; `L` is looser by a round
/// trip, a few milliseconds of the 250 ms timeout.) The frames after it may be stale (the
/// four-frame queue keeps its oldest frames when the link is slower than the telemetry), so
/// the trip is measured from `L`, reported, and required within the 600 ms the host waits.
fn watchdog(host: &mut Host<HidLink>, at: Vec2) -> Result<String, String> {
    host.heartbeats = false;
    host.pump(Duration::from_millis(600), |_| at)?;
    if host.stamp_index.is_none() {
        return Err("watchdog: no ack of the last heartbeat".into());
    }
    let split = host.heartbeat_index;
    let (before, after) = host.telemetry.split_at(split.min(host.telemetry.len()));
    let lower = before
        .iter()
        .map(|t| t.time_us)
        .max()
        .ok_or("watchdog: no telemetry before the last heartbeat was sent")?;
    let tripped = |t: &Telemetry| {
        device::safety::Faults::from_bits_truncate(t.faults)
            .contains(device::safety::Faults::WATCHDOG)
    };
    let k = after
        .iter()
        .position(tripped)
        .ok_or("watchdog: it never tripped in 600 ms without heartbeats")?;
    let since = after[k].time_us.wrapping_sub(lower);
    let forced = after[k..]
        .iter()
        .map(|t| t.force_n.length())
        .fold(0.0f32, f32::max);
    let untripped_after = after[k..].iter().filter(|t| !tripped(t)).count();
    let line = format!(
        "watchdog: the first faulted frame is {:.1} ms after the newest frame received before \
         the last heartbeat was sent (timeout {:.0} ms); largest force from then on {forced} N",
        f64::from(since) / 1e3,
        f64::from(GUEST_WATCHDOG_US) / 1e3
    );
    if since < GUEST_WATCHDOG_US || forced != 0.0 || untripped_after != 0 {
        return Err(format!(
            "{line}: a trip before the timeout, a force after it or the fault cleared by itself"
        ));
    }
    Ok(line)
}
