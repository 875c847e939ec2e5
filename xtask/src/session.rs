//! The host ↔ firmware session of `cargo xtask qemu`: the QEMU binary `qemu-serve` with its
//! UART on a TCP port, driven through the real protocol by the host's own link
//! (`device::host::TcpLink`), as `viewer device monitor --tcp` does.

use std::net::TcpListener;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use device::host::{Link, TcpLink};
use device::protocol::{
    ErrorCode, Frame, Message, Telemetry, WireObject, WirePatch, crc32, encode_scene,
};
use device::safety::Faults;
use friction::{FrictionMaterial, Mode};
use nurbs::Vec2;
use viewer::scene::Scene;

/// How long a reply may take (real time; QEMU runs without -icount here, so its clock is the
/// host's).
const REPLY: Duration = Duration::from_secs(2);
/// Heartbeats every 20 ms: well inside the device's 100 ms watchdog.
const HEARTBEAT: Duration = Duration::from_millis(20);

/// QEMU's arguments for `qemu-serve` with its UART served on `address` (`HOST:PORT`); `wait`
/// holds the emulation until a client connects.
pub fn serve_args(address: &str, wait: bool) -> Vec<String> {
    let wait = if wait { "on" } else { "off" };
    [
        "-machine",
        "netduinoplus2",
        "-nographic",
        "-monitor",
        "none",
        "-semihosting-config",
        "enable=on,target=native",
        "-serial",
    ]
    .iter()
    .map(|s| s.to_string())
    .chain([format!("tcp:{address},server=on,wait={wait},nodelay=on")])
    .collect()
}

/// Kills QEMU when the session ends, however it ends.
struct Qemu(Child);

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A session's link with its heartbeat.
struct Host {
    link: TcpLink,
    last_heartbeat: Instant,
    /// Telemetry received, in order.
    telemetry: Vec<Telemetry>,
    nacks: Vec<(u16, ErrorCode)>,
    heartbeats: bool,
}

impl Host {
    fn request(&mut self, m: &Message, what: &str) -> Result<(), String> {
        self.link
            .request(m, REPLY)
            .map_err(|e| format!("session: {what}: {e}"))
    }

    /// Reads for `d`, sending heartbeats (when on) and the hand target every tick or so.
    fn pump(&mut self, d: Duration, mut target: impl FnMut(f32) -> Vec2) -> Result<(), String> {
        let start = Instant::now();
        let mut last_target = Instant::now() - Duration::from_secs(1);
        while start.elapsed() < d {
            if self.heartbeats && self.last_heartbeat.elapsed() >= HEARTBEAT {
                self.link
                    .send(&Message::Heartbeat { uptime_ms: 0 })
                    .map_err(|e| format!("session: heartbeat: {e}"))?;
                self.last_heartbeat = Instant::now();
            }
            if last_target.elapsed() >= Duration::from_millis(5) {
                let t = start.elapsed().as_secs_f32() / d.as_secs_f32();
                self.link
                    .send(&Message::HandTarget {
                        target_m: target(t),
                    })
                    .map_err(|e| format!("session: hand target: {e}"))?;
                last_target = Instant::now();
            }
            match self.link.recv(Duration::from_millis(2)) {
                Ok(Some(Frame {
                    message: Message::Telemetry(t),
                    ..
                })) => self.telemetry.push(t),
                Ok(Some(Frame {
                    message: Message::Nack(n),
                    ..
                })) => self.nacks.push((n.seq, n.code)),
                Ok(_) => {}
                Err(e) => return Err(format!("session: link: {e}")),
            }
        }
        Ok(())
    }
}

/// The wire scene of object 0 of `scene` with `material`.
fn wire_scene(scene: &Scene, material: FrictionMaterial) -> Result<Vec<u8>, String> {
    let object = &scene.objects()[0];
    let curves = object
        .curve_views()
        .ok_or("session: object 0 is not made of planar curves")?;
    let patches: Vec<WirePatch<'_>> = curves.iter().copied().map(WirePatch::Curve).collect();
    encode_scene(&[WireObject {
        material,
        patches: &patches,
    }])
    .map_err(|e| format!("session: wire scene: {e}"))
}

fn modes(t: &[Telemetry]) -> Vec<Mode> {
    let mut out: Vec<Mode> = Vec::new();
    for m in t.iter().map(|t| t.mode) {
        if out.last() != Some(&m) {
            out.push(m);
        }
    }
    out
}

/// Runs the session against `elf` (the `qemu-serve` binary) and returns its result lines.
pub fn run(elf: &Path, root: &Path) -> Result<Vec<String>, String> {
    let port = TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map_err(|e| format!("session: no free TCP port: {e}"))?
        .port();
    let address = format!("127.0.0.1:{port}");
    let args = serve_args(&address, true);
    println!(
        "\n==> qemu-system-arm {} -kernel {} (session)",
        args.join(" "),
        elf.display()
    );
    let child = Command::new("qemu-system-arm")
        .args(&args)
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| format!("cannot start qemu-system-arm: {e}"))?;
    let _qemu = Qemu(child);
    let started = Instant::now();
    let link = loop {
        match TcpLink::connect(&address, Duration::from_millis(200)) {
            Ok(l) => break l,
            Err(_) if started.elapsed() < Duration::from_secs(20) => {
                std::thread::sleep(Duration::from_millis(100));
            }
            Err(e) => return Err(format!("session: cannot connect to QEMU on {address}: {e}")),
        }
    };
    let mut host = Host {
        link,
        last_heartbeat: Instant::now(),
        telemetry: Vec::new(),
        nacks: Vec::new(),
        heartbeats: true,
    };
    let mut lines = Vec::new();
    // QEMU starts the emulation when the connection arrives, and its USART drops what it
    // receives before the firmware has enabled it: speak once the device has.
    let booted = Instant::now();
    while host
        .link
        .recv(Duration::from_millis(50))
        .map_err(|e| format!("session: link: {e}"))?
        .is_none()
    {
        if booted.elapsed() > Duration::from_secs(10) {
            return Err("session: the emulated board sent nothing for 10 s after boot".into());
        }
    }
    let hello = host
        .link
        .hello(REPLY)
        .map_err(|e| format!("session: hello: {e}"))?;
    lines.push(format!(
        "session hello software={:?} scene_capacity={}",
        hello.software, hello.scene_capacity
    ));

    let scene_path = root.join("scenes").join("thesis-2d.json");
    let scene = Scene::load(&scene_path).map_err(|e| format!("{}: {e}", scene_path.display()))?;
    let material = scene.objects()[0].material().friction_material();
    let first = wire_scene(&scene, material)?;
    // Above the object (the arcs' top is at y = 94.6 mm), clear of it.
    let above = Vec2::new(0.01, 0.11);
    host.pump(Duration::from_millis(300), |_| above)?;
    host.request(&Message::ClearFaults { mask: 0xFFFF }, "clear faults")?;
    host.request(&Message::Calibrate, "calibrate")?;
    host.link
        .upload_scene(&first, REPLY)
        .map_err(|e| format!("session: upload: {e}"))?;
    host.request(&Message::EnableForces, "enable forces")?;
    host.telemetry.clear();
    // Into the right arc (its surface is at y = 86.5 mm at x = 10 mm) 4 mm deep, hold, then
    // along it by 15 mm.
    let inside = Vec2::new(0.01, 0.0825);
    host.pump(Duration::from_millis(400), |t| above + (inside - above) * t)?;
    host.pump(Duration::from_millis(300), |_| inside)?;
    let along = Vec2::new(0.025, 0.0725);
    host.pump(Duration::from_millis(800), |t| {
        inside + (along - inside) * t
    })?;
    let seen = modes(&host.telemetry);
    lines.push(format!(
        "session contact ticks={} modes={seen:?}",
        host.telemetry.len()
    ));
    let stuck = seen.iter().position(|&m| m == Mode::Stuck);
    let slip = seen.iter().rposition(|&m| m == Mode::Slip);
    if !matches!((stuck, slip), (Some(a), Some(b)) if a < b) {
        return Err(format!(
            "session: pressing into thesis-2d and sliding along it did not go stuck → slip: \
             modes {seen:?}"
        ));
    }

    // Malformed and out-of-order frames, in contact: refused, the device runs on, the active
    // scene unchanged.
    let status_crc = |host: &mut Host| -> Result<u32, String> {
        host.link
            .send(&Message::Heartbeat { uptime_ms: 0 })
            .map_err(|e| format!("session: heartbeat: {e}"))?;
        host.last_heartbeat = Instant::now();
        let deadline = Instant::now() + REPLY;
        while Instant::now() < deadline {
            match host.link.recv(Duration::from_millis(5)) {
                Ok(Some(Frame {
                    message: Message::Status(s),
                    ..
                })) => return Ok(s.scene_crc32),
                Ok(Some(Frame {
                    message: Message::Telemetry(t),
                    ..
                })) => host.telemetry.push(t),
                Ok(Some(Frame {
                    message: Message::Nack(n),
                    ..
                })) => host.nacks.push((n.seq, n.code)),
                Ok(Some(f)) => eprintln!("session: status: {f:?}"),
                Ok(None) => {}
                Err(e) => eprintln!("session: status: {e}"),
            }
        }
        Err("session: no status after a heartbeat".into())
    };
    let before = status_crc(&mut host)?;
    if before != crc32(&first) {
        return Err(format!(
            "session: the active scene's CRC {before:#x} is not the uploaded one's {:#x}",
            crc32(&first)
        ));
    }
    host.nacks.clear();
    host.link
        .send_raw(&[0x05, 0x01, 0x02, 0x03, 0x04, 0x00])
        .map_err(|e| format!("session: raw bytes: {e}"))?;
    let chunk = Message::SceneChunk(
        device::protocol::SceneChunk::new(0, &[1, 2, 3]).ok_or("session: chunk")?,
    );
    let out_of_order = host.link.request(&chunk, REPLY);
    host.pump(Duration::from_millis(100), |_| along)?;
    let after = status_crc(&mut host)?;
    let refused_chunk = matches!(out_of_order, Err(device::host::LinkError::Nack(n)) if n.code == ErrorCode::NoUpload);
    lines.push(format!(
        "session malformed nacks={:?} chunk_without_begin_refused={refused_chunk} scene_unchanged={}",
        host.nacks,
        after == before
    ));
    if host.nacks.is_empty() || !refused_chunk || after != before {
        return Err(format!(
            "session: malformed frames: nacks {:?}, chunk without begin {out_of_order:?}, scene \
             CRC {before:#x} → {after:#x}",
            host.nacks
        ));
    }

    // A second scene (the same curves, a softer material) swapped in while in contact.
    let softer = FrictionMaterial {
        stiffness_n_per_m: material.stiffness_n_per_m * 0.5,
        ..material
    };
    let second = wire_scene(&scene, softer)?;
    host.telemetry.clear();
    host.link
        .upload_scene(&second, REPLY)
        .map_err(|e| format!("session: second upload: {e}"))?;
    host.pump(Duration::from_millis(300), |_| along)?;
    let swapped = status_crc(&mut host)?;
    let in_contact = host
        .telemetry
        .last()
        .is_some_and(|t| t.mode != Mode::Free && t.force_normal_n > 0.0);
    lines.push(format!(
        "session swap crc={swapped:#x} expected={:#x} in_contact_after={in_contact}",
        crc32(&second)
    ));
    if swapped != crc32(&second) || !in_contact {
        return Err(format!(
            "session: the second scene is not active and rendering (CRC {swapped:#x}, expected \
             {:#x}; in contact after: {in_contact})",
            crc32(&second)
        ));
    }

    // Heartbeat loss: the force goes off at the watchdog's timeout. The tick that stamped the
    // last heartbeat is the first telemetry after its status.
    let _ = status_crc(&mut host)?;
    host.telemetry.clear();
    host.heartbeats = false;
    host.pump(Duration::from_millis(400), |_| along)?;
    let stamp = host
        .telemetry
        .first()
        .map(|t| t.time_us)
        .ok_or("session: no telemetry after the last heartbeat")?;
    let trip = host
        .telemetry
        .iter()
        .find(|t| Faults::from_bits_truncate(t.faults).contains(Faults::WATCHDOG))
        .ok_or("session: the watchdog never tripped without heartbeats")?;
    let after_us = trip.time_us.wrapping_sub(stamp);
    let forced = trip.force_n.length();
    lines.push(format!(
        "session watchdog trip_after_us={after_us} force_at_trip_n={forced}"
    ));
    // 100 ms, give or take the tick of the stamp and the tick of the trip (1 ms each).
    if !(99_000..=102_000).contains(&after_us) || forced != 0.0 {
        return Err(format!(
            "session: the watchdog tripped {after_us} µs after the last heartbeat with {forced} N \
             (expected 100 ms ± 2 ticks, 0 N)"
        ));
    }
    Ok(lines)
}
