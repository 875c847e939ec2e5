//! The host ↔ firmware session of `cargo xtask qemu`: the QEMU binary `qemu-serve` with its
//! UART on a TCP port, driven through the real protocol by the host's own link
//! (`protocol::host_side::TcpLink`), as `viewer device monitor --tcp` does: hello, scene upload and
//! commit, forces on, the virtual hand into the object and along it (stuck → slip in the
//! telemetry), malformed and out-of-order frames refused with the device running on and its
//! scene unchanged, a second scene swapped in while in contact, the curve moving under the
//! held hand by a stream of control-point updates (every one acked, the device's CRC the
//! host's afterwards, contact kept on the same arc, the rendered depth that of the moved
//! curve), and heartbeat loss turning the force off at the watchdog's timeout.

use std::collections::HashMap;
use std::net::TcpListener;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use device::safety::Faults;
use friction::{FrictionMaterial, Mode};
use nurbs::Vec2;
use protocol::host_side::{Answer, GapCounter, Link, Requests, TcpLink};
use protocol::{
    ErrorCode, Message, Nack, SceneChunk, Status, Telemetry, crc32, points_update, scene_upload,
};
use scene::Scene;

/// How long a reply may take (real time: QEMU runs without -icount here, so its clock is the
/// host's).
const REPLY: Duration = Duration::from_secs(5);
/// Heartbeats every 50 ms, as `device monitor`'s: a fifth of the emulated board's 250 ms
/// watchdog (`firmware/src/bin/qemu-serve.rs`), so that QEMU on a loaded machine may stall
/// for most of 200 ms without tripping it.
const HEARTBEAT: Duration = Duration::from_millis(50);
/// The emulated board's heartbeat timeout (µs).
const WATCHDOG_US: u32 = 250_000;
/// The control-point stream: the right arc's middle control point moves `POINTS_AMPLITUDE_M`
/// out and back along the line from the arc's centre through it, at `POINTS_FREQUENCY_HZ`, one
/// shape every `POINTS_PERIOD` for `POINTS_DURATION` (a deformable model's surface at the
/// rate a D-NURBS host integrates it).
const POINTS_AMPLITUDE_M: f32 = 1e-3;
const POINTS_FREQUENCY_HZ: f32 = 2.0;
const POINTS_PERIOD: Duration = Duration::from_millis(8);
const POINTS_DURATION: Duration = Duration::from_secs(2);
/// The update rate the stream must reach (acked updates per second).
const POINTS_RATE_MIN_HZ: f64 = 100.0;

/// The hand's target every 10 ms: at the slide's 17 mm/s a step of 0.17 mm, under half the
/// hand's spring stretch at breakaway (μs F_N / 2000 N/m ≈ 0.4 mm), so the steps do not make
/// their own stick–slip.
const TARGET_PERIOD: Duration = Duration::from_millis(10);

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
    .chain([format!("tcp:{address},server=on,wait={wait}")])
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

/// What a frame the host sent waits for (the request/ack engine's tag, [`Requests`]).
#[derive(Clone, Copy, Debug)]
enum Sent {
    /// The request [`Host::send_awaiting`] waits for, by its count.
    Awaited(u32),
    /// A heartbeat, by its count.
    Heartbeat(u32),
    /// A streamed control-point update and its displacement (m).
    Points(f32),
}

/// The host's side: the link, its heartbeat and the virtual hand's target.
pub(crate) struct Host<L: Link> {
    pub(crate) link: L,
    pub(crate) heartbeats: bool,
    /// Whether [`Host::pump`] sends the hand's target (every [`TARGET_PERIOD`]); off, the
    /// hand holds its last target and the link carries heartbeats only.
    pub(crate) targets: bool,
    last_heartbeat: Instant,
    last_target: Instant,
    /// Telemetry received, in order.
    pub(crate) telemetry: Vec<Telemetry>,
    /// Gaps in the telemetry's sequence numbers (replies are numbered apart).
    pub(crate) gaps: GapCounter,
    /// Nacks of frames nobody waited for.
    pub(crate) nacks: Vec<(u16, ErrorCode)>,
    /// Frames sent and not answered.
    requests: Requests<Sent>,
    /// Requests [`Host::send_awaiting`] sent (the newest is the one it waits for), and the
    /// answer to the newest.
    awaited: u32,
    answer: Option<Result<(), ErrorCode>>,
    /// The last status (a heartbeat's answer).
    status: Option<Status>,
    /// Heartbeats sent; the index in `telemetry` of the first frame after the newest one's
    /// ack: the tick that stamped it.
    heartbeats_sent: u32,
    pub(crate) stamp_index: Option<usize>,
    /// The number of telemetry frames received when the newest heartbeat was sent: every one
    /// of them left the device before it handled that heartbeat, whatever the transport's
    /// order (over USB, replies and telemetry come on two endpoints, read apart).
    pub(crate) heartbeat_index: usize,
    /// The control-point stream under way ([`Host::stream_points`]), with the displacement
    /// of the newest update acked.
    points: Option<(PointsRun, f32)>,
}

impl<L: Link> Host<L> {
    /// The host's side of a session on `link`, heartbeats on.
    pub(crate) fn new(link: L) -> Self {
        Host {
            link,
            heartbeats: true,
            targets: true,
            last_heartbeat: Instant::now(),
            last_target: Instant::now(),
            telemetry: Vec::new(),
            gaps: GapCounter::default(),
            nacks: Vec::new(),
            requests: Requests::new(),
            awaited: 0,
            answer: None,
            status: None,
            heartbeats_sent: 0,
            stamp_index: None,
            heartbeat_index: 0,
            points: None,
        }
    }

    /// Heartbeats sent so far.
    pub(crate) fn heartbeats_sent(&self) -> u32 {
        self.heartbeats_sent
    }

    /// Sends a heartbeat when one is due (while heartbeats are on, every [`HEARTBEAT`]).
    fn heartbeat(&mut self) -> Result<(), String> {
        if !self.heartbeats || self.last_heartbeat.elapsed() < HEARTBEAT {
            return Ok(());
        }
        let now = Instant::now();
        self.heartbeats_sent += 1;
        self.requests
            .send(
                &mut self.link,
                [Message::Heartbeat { uptime_ms: 0 }],
                Sent::Heartbeat(self.heartbeats_sent),
                now,
            )
            .map_err(|e| format!("session: heartbeat: {e}"))?;
        self.stamp_index = None;
        self.heartbeat_index = self.telemetry.len();
        self.last_heartbeat = now;
        Ok(())
    }

    /// Receives for up to `timeout` and takes in what came: telemetry, answers, a status.
    fn receive(&mut self, timeout: Duration) -> Result<(), String> {
        // An answer this late will not come (and a late one must not answer a newer request).
        self.requests.expire(Instant::now(), REPLY);
        let frame = self
            .link
            .recv(timeout)
            .map_err(|e| format!("session: link: {e}"))?;
        let Some(frame) = frame else {
            return Ok(());
        };
        self.gaps.telemetry(&frame);
        let message = frame.message;
        match (self.requests.answer(&message), message) {
            (_, Message::Telemetry(t)) => {
                if let Some((run, current)) = &mut self.points {
                    run.frames.push((t, *current));
                }
                self.telemetry.push(t);
            }
            (Some(Answer::Acked(Sent::Awaited(k))), _) if k == self.awaited => {
                self.answer = Some(Ok(()));
            }
            (Some(Answer::Refused(Sent::Awaited(k), n)), _) if k == self.awaited => {
                self.answer = Some(Err(n.code));
            }
            (Some(Answer::Acked(Sent::Heartbeat(k))), _) if k == self.heartbeats_sent => {
                self.stamp_index = Some(self.telemetry.len());
            }
            (Some(Answer::Acked(Sent::Points(d))), _) => {
                if let Some((run, current)) = &mut self.points {
                    // The device acks an update when it applied it, before the tick that
                    // renders it: the frames behind this ack are of this shape.
                    *current = d;
                    run.acked.push((run.start.elapsed(), d));
                }
            }
            (Some(Answer::Refused(Sent::Points(_), n)), _) => {
                if let Some((run, _)) = &mut self.points {
                    run.nacks.push(n);
                }
            }
            (_, Message::Nack(n)) => self.nacks.push((n.seq, n.code)),
            (_, Message::Status(s)) => self.status = Some(s),
            _ => {}
        }
        Ok(())
    }

    /// Reads for `d`, sending heartbeats (while on, every [`HEARTBEAT`]) and the hand's target
    /// `target(t)` (`t` from 0 to 1 over `d`, every [`TARGET_PERIOD`]).
    pub(crate) fn pump(
        &mut self,
        d: Duration,
        mut target: impl FnMut(f32) -> Vec2,
    ) -> Result<(), String> {
        let start = Instant::now();
        loop {
            let t = (start.elapsed().as_secs_f32() / d.as_secs_f32()).min(1.0);
            self.heartbeat()?;
            if self.targets && self.last_target.elapsed() >= TARGET_PERIOD {
                self.link
                    .send(&Message::HandTarget {
                        target_m: target(t),
                    })
                    .map_err(|e| format!("session: hand target: {e}"))?;
                self.last_target = Instant::now();
            }
            self.receive(Duration::from_millis(2))?;
            if start.elapsed() >= d {
                return Ok(());
            }
        }
    }

    /// Sends `m` and pumps, the hand held at `at`, until the device answers it.
    pub(crate) fn send_awaiting(
        &mut self,
        m: &Message,
        at: Vec2,
    ) -> Result<Result<(), ErrorCode>, String> {
        self.awaited += 1;
        self.answer = None;
        self.requests
            .send(
                &mut self.link,
                [*m],
                Sent::Awaited(self.awaited),
                Instant::now(),
            )
            .map_err(|e| format!("session: {:?}: {e}", m.message_type()))?;
        let start = Instant::now();
        while self.answer.is_none() && start.elapsed() < REPLY {
            self.pump(Duration::from_millis(10), |_| at)?;
        }
        self.answer.take().ok_or_else(|| {
            format!(
                "session: no answer to {:?} within {REPLY:?} ({} telemetry frames so far, \
                 unawaited nacks {:?})",
                m.message_type(),
                self.telemetry.len(),
                self.nacks
            )
        })
    }

    /// [`Host::send_awaiting`], a nack being an error.
    pub(crate) fn request(&mut self, m: &Message, at: Vec2) -> Result<(), String> {
        self.send_awaiting(m, at)?
            .map_err(|code| format!("session: {:?} refused: {code}", m.message_type()))
    }

    /// Uploads and commits `scene`, frame by frame, the hand held at `at`.
    pub(crate) fn upload(&mut self, scene: &[u8], at: Vec2) -> Result<(), String> {
        for m in scene_upload(scene) {
            self.request(&m, at)?;
        }
        Ok(())
    }

    /// Streams control-point updates of the right arc's middle point (patch 0, point 1 of
    /// object 0, at `p1` with the scene as uploaded) moving by `offset(t)` (m, along `out`),
    /// one every [`POINTS_PERIOD`] for [`POINTS_DURATION`], without waiting for the acks;
    /// heartbeats go on, hand targets do not (the hand holds its last one). Returns when every
    /// update is answered (or [`REPLY`] after the last was sent).
    fn stream_points(
        &mut self,
        p1: Vec2,
        out: Vec2,
        offset: impl Fn(f32) -> f32,
    ) -> Result<PointsRun, String> {
        let start = Instant::now();
        self.points = Some((PointsRun::new(start), 0.0));
        let mut k = 0u32;
        let waiting = |host: &Self| host.requests.any(|p| matches!(p, Sent::Points(_)));
        let result = loop {
            let now = Instant::now();
            self.heartbeat()?;
            let due = start + POINTS_PERIOD * k;
            if now >= due && now - start < POINTS_DURATION {
                let d = offset((POINTS_PERIOD * k).as_secs_f32());
                let to = [p1 + out * d];
                self.requests
                    .send(
                        &mut self.link,
                        points_update(0, &[(0, 1, &to[..])]),
                        Sent::Points(d),
                        now,
                    )
                    .map_err(|e| format!("session: points: {e}"))?;
                if let Some((run, _)) = &mut self.points {
                    run.sent.push(now - start);
                }
                k += 1;
            }
            self.receive(Duration::from_millis(1))?;
            let elapsed = start.elapsed();
            if elapsed >= POINTS_DURATION && !waiting(self) {
                break Ok(());
            }
            if elapsed >= POINTS_DURATION + REPLY {
                let left = self.requests.len();
                break Err(format!(
                    "session: control-point updates unanswered {REPLY:?} after the stream \
                     ({left} frames in flight)"
                ));
            }
        };
        let run = self.points.take().map(|(run, _)| run);
        result.and_then(|()| run.ok_or_else(|| "session: the stream's record is gone".into()))
    }

    /// The active scene's CRC-32, from the status answering the next heartbeat.
    pub(crate) fn scene_crc(&mut self, at: Vec2) -> Result<u32, String> {
        self.status = None;
        let start = Instant::now();
        while self.status.is_none() && start.elapsed() < REPLY {
            self.pump(Duration::from_millis(10), |_| at)?;
        }
        self.status
            .map(|s| s.scene_crc32)
            .ok_or_else(|| "session: no status after a heartbeat".to_string())
    }
}

/// What a control-point stream ([`Host::stream_points`]) saw.
struct PointsRun {
    /// When the stream began.
    start: Instant,
    /// When each update was sent (since the stream began).
    sent: Vec<Duration>,
    /// When each acked update's ack arrived, and its displacement (m).
    acked: Vec<(Duration, f32)>,
    /// Nacks of updates.
    nacks: Vec<Nack>,
    /// The telemetry, each frame with the displacement of the last update acked before it
    /// (the shape the tick rendered).
    frames: Vec<(Telemetry, f32)>,
}

impl PointsRun {
    fn new(start: Instant) -> Self {
        PointsRun {
            start,
            sent: Vec::new(),
            acked: Vec::new(),
            nacks: Vec::new(),
            frames: Vec::new(),
        }
    }
}

/// The wire scene of object 0 of `scene` with `material` (the app's own upload).
fn wire_scene(scene: &Scene, material: FrictionMaterial) -> Result<Vec<u8>, String> {
    let material =
        scene::Material::from_friction(material).map_err(|e| format!("session: material: {e}"))?;
    let scene = scene
        .with_material(0, material)
        .map_err(|e| format!("session: {e}"))?;
    host::upload::wire_scene(&scene, 0).map_err(|e| format!("session: wire scene: {e}"))
}

/// The curve moving under the held hand: the right arc's middle control point streamed out
/// and back ([`Host::stream_points`]) while the hand holds `at` in contact with the arc
/// (`scene` with `material`, the active scene). Checks that every update is acked, at
/// [`POINTS_RATE_MIN_HZ`] or more; that the device's scene ends as the host's own scene with
/// the point moved there (`scene::edit::move_point`, re-encoded: an independent path to the
/// bytes); that the telemetry keeps coming, in contact on the same arc without a fault; and
/// that the depth the device renders is the moved curve's: each frame's depth (|CP − HIP|)
/// against the global closest point of the shape the device had applied when it sent the
/// frame (the last update acked before it).
fn points_phase(
    host: &mut Host<TcpLink>,
    scene: &Scene,
    material: FrictionMaterial,
    at: Vec2,
) -> Result<Vec<String>, String> {
    use scene::edit::{PointRef, move_point};
    let material =
        scene::Material::from_friction(material).map_err(|e| format!("points: material: {e}"))?;
    let scene = scene
        .with_material(0, material)
        .map_err(|e| format!("points: {e}"))?;
    let right = match scene.objects()[0].patches().first() {
        Some(scene::Patch::Curve2(c)) => c.clone(),
        other => return Err(format!("points: the right arc is {other:?}")),
    };
    let p1 = right
        .view()
        .control_point(1)
        .ok_or("points: the right arc has no point 1")?
        .0;
    // Out through the point from the arc's centre: along the arc's normal where the hand is.
    let out = (p1 - Vec2::new(-0.02, 0.06)).normalize();
    let offset =
        |t: f32| POINTS_AMPLITUDE_M * (2.0 * std::f32::consts::PI * POINTS_FREQUENCY_HZ * t).sin();
    host.pump(Duration::from_millis(100), |_| at)?;
    let run = host.stream_points(p1, out, offset)?;
    let (sent, acked) = (run.sent.len(), run.acked.len());
    let span = match (run.sent.first(), run.acked.last()) {
        (Some(a), Some((b, _))) => b.saturating_sub(*a).as_secs_f64(),
        _ => 0.0,
    };
    let rate_hz = if span > 0.0 { acked as f64 / span } else { 0.0 };
    if !run.nacks.is_empty() || acked != sent {
        return Err(format!(
            "points: {acked} of {sent} updates acked, nacks {:?}",
            run.nacks
        ));
    }
    if rate_hz < POINTS_RATE_MIN_HZ {
        return Err(format!(
            "points: {acked} updates in {span:.2} s: {rate_hz:.1} Hz, under {POINTS_RATE_MIN_HZ} Hz"
        ));
    }
    // The device's scene against the host's: the last shape, edited and re-encoded.
    let last = run.acked.last().map_or(0.0, |(_, d)| *d);
    let edited = move_point(&scene, PointRef::new(0, 0, 1), p1 + out * last)
        .map_err(|e| format!("points: {e}"))?;
    let wire = host::upload::wire_scene(&edited, 0).map_err(|e| format!("points: {e}"))?;
    let crc = host.scene_crc(at)?;
    if crc != crc32(&wire) {
        return Err(format!(
            "points: the device's scene CRC {crc:#x} is not the host's {:#x}",
            crc32(&wire)
        ));
    }
    // The telemetry during the stream.
    let frames = &run.frames;
    let faults = frames.iter().fold(0, |f, (t, _)| f | t.faults);
    let mut features: Vec<_> = frames.iter().map(|(t, _)| t.feature).collect();
    features.dedup();
    let seen = modes(&frames.iter().map(|(t, _)| *t).collect::<Vec<_>>());
    if frames.len() < 1000
        || faults != 0
        || seen.contains(&Mode::Free)
        || features
            .iter()
            .any(|f| *f != Some(tracker::Feature::Patch(0)))
    {
        return Err(format!(
            "points: {} frames, faults {faults:#x}, modes {seen:?}, features {features:?}",
            frames.len(),
        ));
    }
    // Each frame's depth against the shape it rendered, and against the arc as uploaded (what
    // a device that ignored the updates would render).
    let cfg = tracker::GlobalConfig::default();
    let k = scene.objects()[0]
        .material()
        .friction_material()
        .stiffness_n_per_m;
    let mut shapes: HashMap<u32, nurbs::CurveBuf<Vec2>> = HashMap::new();
    let mut worst_um = 0.0f32;
    let mut unmoved_um = 0.0f32;
    let mut force_n = 0.0f32;
    let (mut lo, mut hi) = (f32::MAX, f32::MIN);
    let (mut f_lo, mut f_hi) = (f32::MAX, f32::MIN);
    for (t, d) in frames {
        let curve = match shapes.entry(d.to_bits()) {
            std::collections::hash_map::Entry::Occupied(e) => e.into_mut(),
            std::collections::hash_map::Entry::Vacant(e) => e.insert(
                right
                    .with_point(1, p1 + out * *d)
                    .map_err(|e| format!("points: {e}"))?,
            ),
        };
        let expected = -tracker::closest_point(&curve.view(), t.hip_m, &cfg).signed_distance;
        let uploaded = -tracker::closest_point(&right.view(), t.hip_m, &cfg).signed_distance;
        let rendered = (t.cp_m - t.hip_m).length();
        worst_um = worst_um.max((rendered - expected).abs() * 1e6);
        unmoved_um = unmoved_um.max((rendered - uploaded).abs() * 1e6);
        force_n = force_n.max((t.force_normal_n - k * expected).abs());
        lo = lo.min(expected);
        hi = hi.max(expected);
        f_lo = f_lo.min(t.force_normal_n);
        f_hi = f_hi.max(t.force_normal_n);
    }
    let lines = vec![
        format!(
            "session points updates={sent} acked={acked} rate_hz={rate_hz:.1} period_ms={} \
             span_s={span:.2} amplitude_mm={} frequency_hz={} crc={crc:#x} expected={:#x} \
             frames={} modes={seen:?} feature=Patch(0) faults={faults:#x}",
            POINTS_PERIOD.as_millis(),
            POINTS_AMPLITUDE_M * 1e3,
            POINTS_FREQUENCY_HZ,
            crc32(&wire),
            frames.len()
        ),
        format!(
            "session points depth_mm={:.3}..{:.3} depth_error_um={worst_um:.2} \
             depth_error_vs_uploaded_arc_um={unmoved_um:.1} normal_force_n={f_lo:.3}..{f_hi:.3} \
             largest_normal_force_minus_k_depth_n={force_n:.4}",
            lo * 1e3,
            hi * 1e3
        ),
    ];
    // The device renders the moved curve: its depth is the moved curve's, to the tracker's
    // convergence (one Gauss–Newton step a tick; an update moves the contact by at most
    // 2π f A × 8 ms = 0.1 mm, and a step leaves |κ d| ≈ 4 mm / 36 mm of a parameter error:
    // 11 µm after the update's first tick, 1.2 µm after the next, and a frame is a
    // millisecond's tick), and it moves (the surface's 1 mm at this point is about a third of
    // a millimetre of depth). In the stuck spring the normal force is K times the depth at
    // the GO, which rides on the surface: within K × 20 µm of K × the depth.
    if worst_um > 20.0 || hi - lo < 0.3e-3 || force_n > k * 20e-6 {
        return Err(format!(
            "points: the device did not render the moving curve\n{}",
            lines.join("\n")
        ));
    }
    Ok(lines)
}

/// The modes of `t` in order, repeats collapsed.
fn modes(t: &[Telemetry]) -> Vec<Mode> {
    let mut out: Vec<Mode> = Vec::new();
    for m in t.iter().map(|t| t.mode) {
        if out.last() != Some(&m) {
            out.push(m);
        }
    }
    out
}

/// A free TCP address on the loopback interface.
fn free_address() -> Result<String, String> {
    let port = TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map_err(|e| format!("session: no free TCP port: {e}"))?
        .port();
    Ok(format!("127.0.0.1:{port}"))
}

/// Boots `elf` (`qemu-serve`) under QEMU with its UART served on `address`.
fn start(elf: &Path, address: &str, wait: bool, what: &str) -> Result<Qemu, String> {
    let args = serve_args(address, wait);
    println!(
        "\n==> qemu-system-arm {} -kernel {} ({what})",
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
    Ok(Qemu(child))
}

/// The desktop app's device link (`viewer gui --device tcp:HOST:PORT`): the host of a device
/// behind a link that the app's state drives ([`host::remote`]), without the GUI, against the
/// emulated board, as a user would start it: the board boots first (`cargo xtask qemu
/// --serve`), then the host connects. Its setup clears the boot fault, calibrates and enables
/// the forces; the scene goes as the app sends it (a `Swap` of thesis-2d, uploaded); the
/// device's status must then report exactly that scene's CRC with the forces on. The hand's
/// target goes 4 mm into the right arc: the device must render contact (stuck, a normal
/// force) without a fault. (The app's own wiring of this thread is tested against the
/// simulated device on a pseudo-terminal in `crates/viewer/tests/device_link.rs`.)
pub fn app(elf: &Path, root: &Path) -> Result<Vec<String>, String> {
    use host::backend::{LinkEvent, LoopCommand, Reply, Sample};
    use host::devices::Target;
    use host::planar::PlanarSession;
    let address = free_address()?;
    let _qemu = start(elf, &address, false, "the desktop app's link")?;
    // The board is up once QEMU listens (its emulation runs without waiting for a client);
    // give the firmware a moment to enable its USART, which drops bytes before that.
    let started = Instant::now();
    while std::net::TcpStream::connect(&address).is_err() {
        if started.elapsed() > Duration::from_secs(20) {
            return Err(format!("app: QEMU did not listen on {address} within 20 s"));
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    std::thread::sleep(Duration::from_millis(500));
    let scene_path = root.join("scenes").join("thesis-2d.json");
    let scene = Scene::load(&scene_path).map_err(|e| format!("{}: {e}", scene_path.display()))?;
    let wire = host::upload::wire_scene(&scene, 0).map_err(|e| format!("app: {e}"))?;
    let session = PlanarSession::new(scene).map_err(|e| format!("app: {e}"))?;
    let target = Target::Tcp(address.clone());
    let link = host::remote::spawn(
        format!("tcp {address}"),
        move || host::devices::open(&target),
        true,
        None,
    )
    .map_err(|e| format!("app: cannot start the link's thread: {e}"))?;
    let above = Vec2::new(0.01, 0.11);
    link.send(LoopCommand::hand_to(above.extend(0.0)));
    link.send(LoopCommand::Swap(Box::new(session)));

    // What the app's state keeps of the link: the newest status and sample, the history.
    let mut status = None;
    let mut hello = None;
    let mut history: Vec<Sample> = Vec::new();
    let poll = |status: &mut Option<protocol::Status>,
                hello: &mut Option<protocol::Hello>,
                history: &mut Vec<Sample>|
     -> Result<(), String> {
        for reply in link.drain_replies() {
            match reply {
                Reply::Link(LinkEvent::Connected { hello: h, .. }) => *hello = Some(h),
                Reply::Link(LinkEvent::Status(s)) => *status = Some(s),
                Reply::Link(LinkEvent::Lost(reason)) => {
                    return Err(format!("app: link lost: {reason}"));
                }
                Reply::Link(LinkEvent::Refused { what, reason }) => {
                    return Err(format!("app: the device refused {what}: {reason}"));
                }
                _ => {}
            }
        }
        link.drain_samples(|s| history.push(s));
        Ok(())
    };
    let crc = crc32(&wire);
    let since = Instant::now();
    while !status.is_some_and(|st: protocol::Status| {
        st.scene_crc32 == crc && st.forces_enabled && st.calibrated
    }) {
        if since.elapsed() > Duration::from_secs(20) {
            return Err(format!(
                "app: no upload and forces on within 20 s; status {status:?}"
            ));
        }
        std::thread::sleep(Duration::from_millis(10));
        poll(&mut status, &mut hello, &mut history)?;
    }
    let setup = since.elapsed();
    let firmware = format!("{:?}", hello.as_ref().ok_or("app: no hello")?.software);
    // Above the arcs, then 4 mm into the right arc at 41.4° (see `run`).
    let centre = Vec2::new(-0.02, 0.06);
    let a = 41.4_f32.to_radians();
    let inside = centre + Vec2::new(a.cos(), a.sin()) * 0.036;
    let steps = 50;
    for i in 0..=steps {
        link.send(LoopCommand::hand_to(
            (above + (inside - above) * (i as f32 / steps as f32)).extend(0.0),
        ));
        std::thread::sleep(Duration::from_millis(10));
        poll(&mut status, &mut hello, &mut history)?;
    }
    let since = Instant::now();
    while !history
        .last()
        .is_some_and(|l| l.tick.mode == Mode::Stuck && l.tick.normal_force_n > 0.5)
    {
        if since.elapsed() > Duration::from_secs(20) {
            return Err("app: no contact within 20 s".to_owned());
        }
        std::thread::sleep(Duration::from_millis(10));
        poll(&mut status, &mut hello, &mut history)?;
    }
    let contact = since.elapsed();
    let last = history.last().ok_or("app: no telemetry")?.tick;
    let faults = last.device.map_or(0, |d| d.faults);
    let c = link.counters();
    let (lost, bad, rtt_us) = (
        c.link_lost_frames
            .load(std::sync::atomic::Ordering::Relaxed),
        c.link_bad_frames.load(std::sync::atomic::Ordering::Relaxed),
        c.link_rtt_us.load(std::sync::atomic::Ordering::Relaxed),
    );
    if faults != 0 {
        let first = history
            .iter()
            .position(|s| s.tick.device.is_some_and(|d| d.faults & !0x8 != 0));
        let around: Vec<String> = first
            .map(|i| {
                history
                    .iter()
                    .skip(i.saturating_sub(3))
                    .take(6)
                    .map(|s| {
                        format!(
                            "t={:.4} hip=({:.5},{:.5}) target=({:.5},{:.5}) mode={:?} faults={:#x}",
                            s.tick.t_s,
                            s.tick.hip.x,
                            s.tick.hip.y,
                            s.hand_target.x,
                            s.hand_target.y,
                            s.tick.mode,
                            s.tick.device.map_or(0, |d| d.faults)
                        )
                    })
                    .collect()
            })
            .unwrap_or_default();
        return Err(format!(
            "app: faults {faults:#x} in contact; first at {first:?} of {}:\n{}",
            history.len(),
            around.join("\n")
        ));
    }
    drop(link);
    Ok(vec![format!(
        "app link firmware={firmware} setup_ms={} contact_ms={} normal_n={:.3} depth_mm={:.3} \
         frames_lost={lost} corrupt={bad} rtt_us={rtt_us}",
        setup.as_millis(),
        contact.as_millis(),
        last.normal_force_n,
        last.depth_m * 1e3
    )])
}

/// Runs the session against `elf` (the `qemu-serve` binary) and returns its result lines.
pub fn run(elf: &Path, root: &Path) -> Result<Vec<String>, String> {
    let address = free_address()?;
    let _qemu = start(elf, &address, true, "the host session")?;
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
    let mut host = Host::new(link);
    let mut lines = Vec::new();
    // QEMU starts the emulation when the connection arrives, and its USART drops what it
    // receives before the firmware has enabled it: speak once the device has.
    while host
        .link
        .recv(Duration::from_millis(50))
        .map_err(|e| format!("session: link: {e}"))?
        .is_none()
    {
        if started.elapsed() > Duration::from_secs(20) {
            return Err("session: the emulated board sent nothing within 20 s of boot".into());
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
    // The watchdog tripped between boot and the first heartbeat.
    host.request(&Message::ClearFaults { mask: 0xFFFF }, above)?;
    host.request(&Message::Calibrate, above)?;
    host.upload(&first, above)?;
    host.request(&Message::EnableForces, above)?;
    host.telemetry.clear();
    // The right arc is the circle of radius 40 mm about (−20, 60) mm from 0° to 60°. Into it
    // 4 mm deep at 41.4° (x = 7 mm), hold, then along it, 4 mm deep, to 15° (16.6 mm in 1 s).
    let centre = Vec2::new(-0.02, 0.06);
    let deep = |deg: f32| {
        let a = deg.to_radians();
        centre + Vec2::new(a.cos(), a.sin()) * 0.036
    };
    let inside = deep(41.4);
    host.pump(Duration::from_millis(500), |t| above + (inside - above) * t)?;
    host.pump(Duration::from_millis(300), |_| inside)?;
    host.pump(Duration::from_millis(1000), |t| {
        deep(41.4 + (15.0 - 41.4) * t)
    })?;
    let along = deep(15.0);
    host.pump(Duration::from_millis(200), |_| along)?;
    let seen = modes(&host.telemetry);
    let faults = host.telemetry.iter().fold(0, |f, t| f | t.faults);
    lines.push(format!(
        "session contact ticks={} modes={seen:?} faults={faults:#x}",
        host.telemetry.len()
    ));
    let stuck = seen.iter().position(|&m| m == Mode::Stuck);
    let slip = seen.iter().rposition(|&m| m == Mode::Slip);
    if !matches!((stuck, slip), (Some(a), Some(b)) if a < b) || faults != 0 {
        return Err(format!(
            "session: pressing into thesis-2d and sliding along it did not go stuck → slip \
             without faults: modes {seen:?}, faults {faults:#x}"
        ));
    }

    // Malformed and out-of-order frames, in contact: refused, the device runs on, the active
    // scene unchanged.
    let before = host.scene_crc(along)?;
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
    let chunk = Message::SceneChunk(SceneChunk::new(0, &[1, 2, 3]).ok_or("session: chunk")?);
    let out_of_order = host.send_awaiting(&chunk, along)?;
    let ticks_before = host.telemetry.len();
    host.pump(Duration::from_millis(200), |_| along)?;
    // Still ticking: telemetry keeps coming (at 1 kHz of the device's clock; a loaded host
    // may slow QEMU, so only a tenth of the 200 ms is asked for).
    let running = host.telemetry.len() > ticks_before + 20;
    let after = host.scene_crc(along)?;
    lines.push(format!(
        "session malformed nacks={:?} chunk_without_begin={out_of_order:?} running={running} \
         scene_unchanged={}",
        host.nacks,
        after == before
    ));
    if host.nacks.is_empty() || out_of_order != Err(ErrorCode::NoUpload) || !running {
        return Err(format!(
            "session: malformed frames: nacks {:?}, chunk without begin {out_of_order:?}, \
             running on: {running}",
            host.nacks
        ));
    }
    if after != before {
        return Err(format!(
            "session: a refused frame changed the active scene: CRC {before:#x} → {after:#x}"
        ));
    }

    // A second scene (the same curves, half as stiff) swapped in while in contact.
    let softer = FrictionMaterial {
        stiffness_n_per_m: material.stiffness_n_per_m * 0.5,
        ..material
    };
    let second = wire_scene(&scene, softer)?;
    host.upload(&second, along)?;
    host.telemetry.clear();
    host.pump(Duration::from_millis(300), |_| along)?;
    let swapped = host.scene_crc(along)?;
    let last = host.telemetry.last().copied();
    let in_contact = last.is_some_and(|t| t.mode != Mode::Free && t.force_n.length() > 0.0);
    lines.push(format!(
        "session swap crc={swapped:#x} expected={:#x} in_contact_after={in_contact}",
        crc32(&second)
    ));
    if swapped != crc32(&second) || !in_contact {
        return Err(format!(
            "session: the second scene is not active and rendering (CRC {swapped:#x}, expected \
             {:#x}; last telemetry {last:?})",
            crc32(&second)
        ));
    }

    lines.extend(points_phase(&mut host, &scene, softer, along)?);

    lines.push(watchdog_phase(&mut host, along, WATCHDOG_US)?);
    Ok(lines)
}

/// Heartbeat loss: the force goes off at the watchdog's timeout (`timeout_us`), the hand held
/// at `along`. The tick that stamped the last heartbeat is the first telemetry after its ack
/// (the device acks a frame when it handles it, between ticks, and the next tick stamps the
/// heartbeat). Returns the line it measured.
fn watchdog_phase<L: Link>(
    host: &mut Host<L>,
    along: Vec2,
    timeout_us: u32,
) -> Result<String, String> {
    host.heartbeats = false;
    host.pump(Duration::from_millis(400), |_| along)?;
    let stamped = host
        .stamp_index
        .and_then(|i| host.telemetry.get(i..))
        .ok_or("session: no telemetry after the last heartbeat's ack")?;
    let stamp = stamped[0].time_us;
    let Some(k) = stamped
        .iter()
        .position(|t| Faults::from_bits_truncate(t.faults).contains(Faults::WATCHDOG))
    else {
        return Err("session: the watchdog never tripped without heartbeats".into());
    };
    // The heartbeat's age on the k-th tick after the stamping one, as the device measures it:
    // the larger of its clock's difference and k periods (`device::controller`, "Time").
    let age = |k: usize| {
        let t = stamped.get(k).map_or(0, |t| t.time_us.wrapping_sub(stamp));
        t.max(k as u32 * 1000)
    };
    let forced = stamped[k..]
        .iter()
        .map(|t| t.force_n.length())
        .fold(0.0f32, f32::max);
    let line = format!(
        "session watchdog trip_tick={k} age_before_us={} age_at_trip_us={} largest_force_from_trip_n={forced}",
        age(k.saturating_sub(1)),
        age(k)
    );
    // The first tick whose age is past the timeout trips (not one before, not one later), and
    // from that tick on there is no force.
    if k == 0 || age(k - 1) > timeout_us || age(k) <= timeout_us || forced != 0.0 {
        return Err(format!(
            "session: the watchdog tripped on tick {k} after the last heartbeat (ages {} and {} \
             µs around it, timeout {timeout_us} µs) with up to {forced} N from then on",
            age(k.saturating_sub(1)),
            age(k)
        ));
    }
    Ok(line)
}
