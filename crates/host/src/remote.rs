//! The app's loop on a device behind a link: the firmware under QEMU over TCP, a board over
//! USB HID or serial, or the host's simulated device ([`protocol::host_side::SimLink`]). The device
//! runs the haptic loop; this thread is its host: it keeps the watchdog fed, turns the UI's
//! [`LoopCommand`]s into protocol messages, and each telemetry frame into a [`Sample`], through
//! the same channels as the in-process loop ([`LoopThread::spawn_with`]), so the app does
//! not care which it drives.
//!
//! - Requests (scene upload, material, forces, calibration, clearing faults) go one at a
//!   time: the next is sent when the device acks the one in flight, as
//!   [`Link::upload_scene`](protocol::host_side::Link::upload_scene) does, but without waiting, so telemetry keeps flowing. A nack is
//!   a [`LinkEvent::Refused`] naming the device's reason (or a material error); the device's
//!   state is unchanged.
//! - Heartbeats go every [`HEARTBEAT_PERIOD`]; the device answers each with its status
//!   ([`LinkEvent::Status`]), and its round trip is the link's latency.
//! - Control-point updates ([`LoopCommand::ScenePoints`]: a deformable model's moving shape) go
//!   without waiting, as soon as no upload is queued or in flight (the device's staging
//!   buffer is the upload's until it commits): their frames are sent at once, several
//!   updates may be in flight, and an update the UI replaces before it went out is never
//!   sent (the newest shape wins). The ack of an update's last frame means the device applied
//!   it ([`LoopCounters::points_applied`](crate::backend::LoopCounters)); a nack of any of its
//!   frames, that it dropped the whole update ([`LinkEvent::Refused`]).
//! - Hand targets go, without waiting, to a device whose plant is simulated: the pointer's
//!   targets glide in this thread's time as in the in-process loops
//!   ([`LoopCommand::HandTarget`]), and the glide's point goes every [`HAND_PERIOD`] while it
//!   changes. The device's virtual hand follows them at a
//!   bounded speed in its own time ([`device::simulator::VirtualHand`]: a hand does not
//!   teleport, and a link may deliver targets late and in bursts); a board (a real hand on the handle) refuses them and the thread stops
//!   sending them.
//! - Requests wait for the device's first status (the answer to the first heartbeat), so
//!   that clearing the boot fault (the watchdog, tripped before any host spoke) finds its
//!   condition gone.
//! - The link is lost when it fails or the device is silent for [`SILENCE_TIMEOUT`]: the
//!   thread says so ([`LinkEvent::Lost`]) and ends. The device's own watchdog turns its
//!   forces off once heartbeats stop (a board's within 100 ms), whatever the host does.

use std::collections::VecDeque;
use std::sync::atomic::Ordering;
use std::sync::mpsc::TryRecvError;
use std::time::{Duration, Instant};

use device::safety::Faults;
use device::simulator::VirtualHand;
use friction::Mode;
use nurbs::{Vec2, Vec3};
use protocol::host_side::{Answer, GapCounter, LinkError, Requests};
use protocol::{ErrorCode, Frame, Message, Status, Telemetry, scene_upload};
use tracker::Feature;

use crate::backend::{LinkEvent, LoopCommand, LoopEnds, LoopThread, PointsUpdate, Reply, Sample};
use crate::deform::{DeformChangeError, DeformStatus, Deformer};
use crate::deformation::Deformation;
use crate::devices::{HEARTBEAT_PERIOD, Opened};
use crate::error::MaterialChangeError;
use crate::tick::{DeviceSample, Tick};
use crate::upload::DEVICE_OBJECT;
use scene::Scene;

/// A device silent this long is gone (telemetry comes every tick, so this is hundreds of
/// frames).
pub const SILENCE_TIMEOUT: Duration = Duration::from_millis(500);
/// How long the setup waits for a simulated handle to reach the hand before it goes on.
pub const SETTLE_TIMEOUT: Duration = Duration::from_secs(3);
/// How close the handle must come to the hand's target to count as there (m).
pub const SETTLED_M: f32 = 1e-3;

/// How often the virtual hand's target is sent: 100 frames a second of 16 bytes, a third of
/// what the emulated board's UART carries under QEMU (about 5 kB/s, see
/// `firmware/src/bin/qemu-serve.rs`), leaving room for the heartbeats and the uploads.
pub const HAND_PERIOD: Duration = Duration::from_millis(10);
/// A request the device has not answered within this is given up.
pub const REQUEST_TIMEOUT: Duration = Duration::from_secs(2);

/// Starts the host of a device on a thread: `open` connects and says hello (it runs on the
/// thread, so a slow connection never blocks the UI); `device` names the link for the UI.
/// With `setup`, once connected, the thread clears the faults, calibrates (a simulated plant
/// is homed at once; a board must be at its end stops) and enables the forces; a board
/// without it waits for the user's commands. Every tick also goes to `record`.
pub fn spawn(
    device: String,
    open: impl FnOnce() -> Result<Opened, LinkError> + Send + 'static,
    setup: bool,
    record: Option<crate::runlog::RecordTx>,
) -> std::io::Result<LoopThread> {
    LoopThread::spawn_with("device-link", record, move |ends| {
        let reason = match open() {
            Ok(opened) => Host::new(device, opened, setup).run(&ends),
            Err(e) => format!("cannot connect to {device}: {e}"),
        };
        ends.reply(Reply::Link(LinkEvent::Lost(reason)));
    })
}

/// What a request in flight was for.
#[derive(Clone, Copy, Debug)]
enum Purpose {
    /// A step of a scene upload; `last` is its commit.
    Upload {
        last: bool,
    },
    Material(friction::FrictionMaterial),
    Forces,
    Calibrate,
    ClearFaults,
    /// Not a message: the queue waits here until the handle of a simulated plant has
    /// followed the virtual hand to the pointer's target (or [`SETTLE_TIMEOUT`] passed).
    Settle,
    /// A control-point update (never queued: sent at once, see [`Host::send_points`]).
    Points,
}

impl Purpose {
    fn name(self) -> &'static str {
        match self {
            Purpose::Upload { .. } => "the scene upload",
            Purpose::Material(_) => "the material",
            Purpose::Forces => "forces on/off",
            Purpose::Calibrate => "the calibration",
            Purpose::ClearFaults => "clearing the faults",
            Purpose::Settle => "moving the handle to the hand",
            Purpose::Points => "the control-point update",
        }
    }
}

struct Host {
    device: String,
    opened: Opened,
    /// Requests waiting for the one in flight.
    queue: VecDeque<(Message, Purpose)>,
    /// Requests sent and not answered: at most one from the queue, and the control-point
    /// updates ([`Purpose::Points`]), several at a time.
    requests: Requests<Purpose>,
    /// Whether the device takes hand targets (until it refuses one).
    simulated_plant: bool,
    gaps: GapCounter,
    heartbeat_due: Instant,
    /// Sequence number and send time of the newest heartbeat.
    heartbeat: Option<(u16, Instant)>,
    status: Option<Status>,
    /// The pointer's hand, gliding in this thread's time between the pointer's samples
    /// ([`VirtualHand::glide`]), and when it was last stepped; its target goes to the device.
    hand: Option<(VirtualHand, Instant)>,
    /// The hand's target as last sent, and when.
    hand_target: Option<(Vec2, Instant)>,
    /// The newest HIP, once the device is calibrated.
    hip: Option<Vec2>,
    /// When the setup began waiting for the handle.
    settle_since: Option<Instant>,
    /// A command refused before it was sent, to report at the end of the turn.
    refused_now: Option<(Purpose, String)>,
    /// The newest control-point update not sent yet.
    points_pending: Option<PointsUpdate>,
    /// The scene the device renders (its object's index), for a [`LoopCommand::Deform`].
    scene: Option<(Scene, usize)>,
    /// The device's object's deformation: stepped on the device's telemetry, its shape sent
    /// back to the device every [`DEFORM_UPDATE_EVERY`] frames.
    deformation: Deformation,
    clock: DeviceClock,
    started: Instant,
    heard: Instant,
}

impl Host {
    fn new(device: String, opened: Opened, setup: bool) -> Self {
        let now = Instant::now();
        let mut host = Host {
            device,
            simulated_plant: opened.hand.is_some(),
            opened,
            queue: VecDeque::new(),
            requests: Requests::new(),
            gaps: GapCounter::default(),
            heartbeat_due: now,
            heartbeat: None,
            status: None,
            hand: None,
            hand_target: None,
            hip: None,
            settle_since: None,
            refused_now: None,
            points_pending: None,
            scene: None,
            deformation: Deformation::new(DEFORM_UPDATE_EVERY),
            clock: DeviceClock::default(),
            started: now,
            heard: now,
        };
        if setup {
            host.simulated_plant = true;
            host.request(
                Message::ClearFaults {
                    mask: Faults::all().bits(),
                },
                Purpose::ClearFaults,
            );
            host.request(Message::Calibrate, Purpose::Calibrate);
            // A simulated handle starts where its device put it, maybe inside an object: it
            // first follows the hand to the pointer's target, then the forces go on (and the
            // scene, which the app sends next).
            host.request(Message::Calibrate, Purpose::Settle);
            host.request(Message::EnableForces, Purpose::Forces);
        }
        host
    }

    fn request(&mut self, message: Message, purpose: Purpose) {
        self.queue.push_back((message, purpose));
    }

    /// Runs until the link is lost or the UI stops the thread; returns why it ended.
    fn run(mut self, ends: &LoopEnds) -> String {
        ends.reply(Reply::Link(LinkEvent::Connected {
            device: self.device.clone(),
            hello: self.opened.hello,
            simulated_plant: self.simulated_plant,
        }));
        loop {
            if ends.stopping() {
                return format!("disconnected from {}", self.device);
            }
            if let Err(reason) = self.turn(ends) {
                return reason;
            }
        }
    }

    /// One turn: the UI's commands, the request queue, the heartbeat, then the frames that
    /// arrive within a millisecond.
    fn turn(&mut self, ends: &LoopEnds) -> Result<(), String> {
        loop {
            match ends.commands.try_recv() {
                Ok(c) => self.command(ends, c).map_err(|e| self.lost(&e))?,
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => return Err("the app closed".into()),
            }
            if let Some((purpose, reason)) = self.refused_now.take() {
                self.refused(ends, purpose, reason);
            }
        }
        let now = Instant::now();
        for purpose in self.requests.expire(now, REQUEST_TIMEOUT) {
            if let Purpose::Points = purpose {
                ends.counters.points_refused.fetch_add(1, Ordering::Relaxed);
            }
            self.refused(
                ends,
                purpose,
                format!("no answer within {REQUEST_TIMEOUT:?}"),
            );
        }
        if now >= self.heartbeat_due {
            let uptime_ms = u32::try_from((now - self.started).as_millis()).unwrap_or(u32::MAX);
            let seq = self
                .opened
                .link
                .send(&Message::Heartbeat { uptime_ms })
                .map_err(|e| self.lost(&e))?;
            self.heartbeat = Some((seq, now));
            self.heartbeat_due = now + HEARTBEAT_PERIOD;
        }
        let queued_in_flight = self.requests.any(|p| !matches!(p, Purpose::Points));
        if let Some((_, Purpose::Settle)) = self.queue.front()
            && !queued_in_flight
        {
            let since = *self.settle_since.get_or_insert(now);
            let settled = match (self.hand.map(|(h, _)| h.command_point()), self.hip) {
                (Some(target), Some(hip)) => (hip - target).length() < SETTLED_M,
                (None, _) => true,
                (_, None) => false,
            };
            if settled || now - since > SETTLE_TIMEOUT {
                self.queue.pop_front();
            }
        }
        if !queued_in_flight
            && self.status.is_some()
            && !matches!(self.queue.front(), Some((_, Purpose::Settle)))
            && let Some((message, purpose)) = self.queue.pop_front()
        {
            self.requests
                .send(&mut *self.opened.link, [message], purpose, now)
                .map_err(|e| self.lost(&e))?;
        }
        self.move_hand(now).map_err(|e| self.lost(&e))?;
        self.send_points(ends, now).map_err(|e| self.lost(&e))?;
        let until = now + Duration::from_millis(1);
        loop {
            let left = until.saturating_duration_since(Instant::now());
            match self.opened.link.recv(left) {
                Ok(Some(frame)) => {
                    self.heard = Instant::now();
                    self.frame(ends, frame)?;
                }
                Ok(None) => break,
                // A corrupt frame is counted as a lost one; the link goes on.
                Err(LinkError::Frame(_)) => {
                    ends.counters
                        .link_bad_frames
                        .fetch_add(1, Ordering::Relaxed);
                }
                Err(e) => return Err(self.lost(&e)),
            }
            if Instant::now() >= until {
                break;
            }
        }
        if self.heard.elapsed() > SILENCE_TIMEOUT {
            return Err(format!(
                "{}: no frame from the device for {} ms",
                self.device,
                SILENCE_TIMEOUT.as_millis()
            ));
        }
        Ok(())
    }

    /// Steps the pointer's hand to `now` and sends its target, at most every [`HAND_PERIOD`].
    fn move_hand(&mut self, now: Instant) -> Result<(), LinkError> {
        let Some((hand, stepped)) = &mut self.hand else {
            return Ok(());
        };
        let command = hand.step((now - *stepped).as_secs_f32());
        *stepped = now;
        if !self.simulated_plant
            || self
                .hand_target
                .is_some_and(|(t, sent)| t == command || now - sent < HAND_PERIOD)
        {
            return Ok(());
        }
        match &self.opened.hand {
            Some(hand) => hand.set_target(command)?,
            None => {
                self.opened
                    .link
                    .send(&Message::HandTarget { target_m: command })?;
            }
        }
        self.hand_target = Some((command, now));
        Ok(())
    }

    /// Sends the pending control-point update, once the device has answered a heartbeat and
    /// no upload is queued or in flight (an update unanswered for [`REQUEST_TIMEOUT`] is
    /// given up in [`Host::turn`]).
    fn send_points(&mut self, ends: &LoopEnds, now: Instant) -> Result<(), LinkError> {
        let uploading = self.requests.any(|p| matches!(p, Purpose::Upload { .. }))
            || self
                .queue
                .iter()
                .any(|(_, p)| matches!(p, Purpose::Upload { .. }));
        if self.status.is_none() || uploading {
            return Ok(());
        }
        let Some(update) = self.points_pending.take() else {
            return Ok(());
        };
        let before = self.requests.len();
        self.requests.send(
            &mut *self.opened.link,
            update.messages(),
            Purpose::Points,
            now,
        )?;
        if self.requests.len() > before {
            ends.counters.points_sent.fetch_add(1, Ordering::Relaxed);
        }
        Ok(())
    }

    fn lost(&self, e: &LinkError) -> String {
        format!("{}: {e}", self.device)
    }

    fn command(&mut self, ends: &LoopEnds, command: LoopCommand) -> Result<(), LinkError> {
        match command {
            LoopCommand::HandTarget { to, over_s } => {
                let to = Vec2::new(to.x, to.y);
                match &mut self.hand {
                    Some((hand, _)) => hand.glide(to, over_s),
                    // The first target goes to the device as it is: the device's own hand
                    // moves there at its top speed.
                    None => self.hand = Some((VirtualHand::at(to), Instant::now())),
                }
            }
            LoopCommand::SetMaterial(m) => self.request(
                Message::SetMaterial {
                    object: 0,
                    material: m,
                },
                Purpose::Material(m),
            ),
            LoopCommand::Swap(session) => match session.wire() {
                Some(wire) => {
                    // The new object starts rigid (its upload brings its shape).
                    if self.deformation.deforming() {
                        self.points_pending = None;
                        self.deformation.forget(self.clock.t_s());
                    }
                    self.scene = session.object().map(|o| (session.scene().clone(), o));
                    let steps: Vec<Message> = scene_upload(wire).collect();
                    let n = steps.len();
                    for (i, m) in steps.into_iter().enumerate() {
                        self.request(m, Purpose::Upload { last: i + 1 == n });
                    }
                }
                None => {
                    self.refused_now = Some((
                        Purpose::Upload { last: true },
                        "the scene has no object of planar curves for the pantograph; the \
                         device keeps its scene"
                            .to_owned(),
                    ));
                }
            },
            LoopCommand::Forces(on) => self.request(
                if on {
                    Message::EnableForces
                } else {
                    Message::DisableForces
                },
                Purpose::Forces,
            ),
            LoopCommand::ClearFaults => self.request(
                Message::ClearFaults {
                    mask: Faults::all().bits(),
                },
                Purpose::ClearFaults,
            ),
            LoopCommand::Calibrate => self.request(Message::Calibrate, Purpose::Calibrate),
            // The device renders NURBS objects through the protocol; a mesh is the app's. The
            // hand on a board's handle is a person's.
            LoopCommand::Mesh(_) | LoopCommand::Hand(_) => {
                ends.reply(Reply::Unsupported(command.name()))
            }
            LoopCommand::ScenePoints(update) => {
                if self.points_pending.replace(*update).is_some() {
                    ends.counters
                        .points_superseded
                        .fetch_add(1, Ordering::Relaxed);
                }
            }
            LoopCommand::Deform(on) => {
                let reply = self.set_deforming(on);
                ends.reply(Reply::Deform(reply));
            }
        }
        Ok(())
    }

    fn refused(&mut self, ends: &LoopEnds, purpose: Purpose, reason: String) {
        match purpose {
            Purpose::Material(_) => {
                ends.reply(Reply::Material(Err(MaterialChangeError::Device(reason))));
            }
            Purpose::Upload { .. } => {
                // The rest of this upload is moot: the device dropped it.
                while matches!(self.queue.front(), Some((_, Purpose::Upload { .. }))) {
                    self.queue.pop_front();
                }
                ends.reply(Reply::Link(LinkEvent::Refused {
                    what: purpose.name(),
                    reason,
                }));
            }
            _ => ends.reply(Reply::Link(LinkEvent::Refused {
                what: purpose.name(),
                reason,
            })),
        }
    }

    fn frame(&mut self, ends: &LoopEnds, frame: Frame) -> Result<(), String> {
        // Telemetry only: the device numbers its replies apart.
        let lost = self.gaps.telemetry(&frame);
        let Frame { message, .. } = frame;
        if lost > 0 {
            ends.counters
                .link_lost_frames
                .fetch_add(u64::from(lost), Ordering::Relaxed);
        }
        match message {
            Message::Telemetry(t) => {
                let sample = self.sample(&t);
                if !ends.publish(sample) {
                    return Err("the app closed".into());
                }
            }
            Message::Status(s) => {
                if let Some((_, sent)) = self.heartbeat.take() {
                    let rtt = u64::try_from(sent.elapsed().as_micros()).unwrap_or(u64::MAX);
                    ends.counters.link_rtt_us.store(rtt, Ordering::Relaxed);
                }
                self.status = Some(s);
                ends.reply(Reply::Link(LinkEvent::Status(s)));
            }
            Message::Ack { .. } | Message::Nack(_) => match self.requests.answer(&message) {
                Some(Answer::Acked(Purpose::Points)) => {
                    ends.counters.points_applied.fetch_add(1, Ordering::Relaxed);
                }
                Some(Answer::Acked(purpose)) => match purpose {
                    Purpose::Material(m) => ends.reply(Reply::Material(Ok(m))),
                    Purpose::Upload { last: true } => ends.reply(Reply::Swapped),
                    Purpose::ClearFaults => ends.reply(Reply::FaultsCleared(
                        Faults::from_bits_truncate(self.status.map_or(0, |s| s.faults)),
                    )),
                    Purpose::Upload { last: false }
                    | Purpose::Forces
                    | Purpose::Calibrate
                    | Purpose::Settle
                    | Purpose::Points => {}
                },
                Some(Answer::Refused(purpose, n)) => {
                    // A refused update is dropped whole; its later frames' nacks
                    // (`UpdateAborted`) find it gone.
                    if let Purpose::Points = purpose {
                        ends.counters.points_refused.fetch_add(1, Ordering::Relaxed);
                    }
                    self.refused(ends, purpose, n.code.message().to_owned());
                }
                None => {
                    if let Message::Nack(n) = message
                        && n.code == ErrorCode::NotSimulated
                        && self.simulated_plant
                    {
                        // A board: the hand on the handle is real.
                        self.simulated_plant = false;
                        ends.reply(Reply::Link(LinkEvent::Refused {
                            what: "the virtual hand",
                            reason: format!(
                                "{}; the device's plant is real: move its handle by hand",
                                n.code.message()
                            ),
                        }));
                    }
                }
            },
            _ => {}
        }
        Ok(())
    }

    /// Makes the device's object deformable or rigid again ([`LoopCommand::Deform`]); rigid
    /// again, the device gets the rest shape back.
    fn set_deforming(&mut self, on: bool) -> Result<DeformStatus, DeformChangeError> {
        let t_s = self.clock.t_s();
        if on {
            let scene = self.scene.as_ref();
            self.deformation.start(
                || {
                    let (scene, object) = scene.ok_or(DeformChangeError::NoObject)?;
                    Ok(Deformer::new(scene, *object)?)
                },
                DEVICE_OBJECT,
                t_s,
            )?;
        } else {
            let pending = &mut self.points_pending;
            self.deformation.stop(t_s, &mut |u| queue(pending, u))?;
        }
        Ok(self.deformation.status())
    }

    /// The UI's sample of a telemetry frame; while the object deforms the frame feeds it and
    /// steps it (one step per frame, of the frame's period), its new shape queued for the
    /// device.
    fn sample(&mut self, t: &Telemetry) -> Sample {
        let (t_s, period_us) = self.clock.advance(t.time_us);
        if t.hip_m != Vec2::ZERO {
            self.hip = Some(t.hip_m);
        }
        let forces_enabled = self.status.is_some_and(|s| s.forces_enabled);
        let mut tick = tick_of(t, t_s);
        if self.deformation.deforming() {
            // The frame gives the GO's parameter, where the force acts; the CP's, where the
            // displacement is shown, is located on the host's copy of the shape first. Then
            // the force loads it.
            self.deformation.locate_contact(&mut tick);
            self.deformation.feed(&mut tick);
            let dt_s = period_us
                .map_or(1e-3, |p| f64::from(p) * 1e-6)
                .clamp(1e-4, 1e-2);
            let pending = &mut self.points_pending;
            // A failed step leaves the object rigid, its rest shape queued (the link's
            // refusals of updates come back as replies of their own).
            let _ = self.deformation.step(dt_s, t_s, &mut |u| queue(pending, u));
        }
        Sample {
            tick,
            hand_target: self.hand_target.map_or(t.hip_m, |(p, _)| p),
            period_us,
            forces_enabled,
        }
    }
}

/// Telemetry frames (1 ms each) between two control-point updates of a deforming object:
/// 500 Hz. The device renders the contact against the shape the host sent last, a shape that
/// lags the host's object by the update interval, a frame of telemetry and the link: a
/// delayed spring, which gives the hand energy that the object's damping must take. Measured
/// through the simulated device (`host::deform::run_device_lagged`, `tests/deform.rs`): the
/// bundled string (γ = 10 N·s/m²) stays passive over closed paths of the hand up to 4 ms of
/// lag, an undamped one up to 1 ms. Every 2 frames keeps the bundled string's lag within
/// that; a 12-point curve is 2 frames an update, so 1000 frames a second go to the device.
pub const DEFORM_UPDATE_EVERY: u32 = 2;

/// Queues `update` for the link ([`Host::send_points`]): it replaces one not sent yet (the
/// newest shape wins).
fn queue(
    pending: &mut Option<PointsUpdate>,
    update: &PointsUpdate,
) -> Result<(), DeformChangeError> {
    *pending = Some(update.clone());
    Ok(())
}

/// The device's 32-bit microsecond clock, unwrapped.
#[derive(Clone, Copy, Debug, Default)]
struct DeviceClock {
    last: Option<u32>,
    total_us: u64,
}

impl DeviceClock {
    /// Device time (s) of the newest frame.
    fn t_s(&self) -> f64 {
        self.total_us as f64 * 1e-6
    }

    /// Device time (s) of a frame stamped `time_us`, and the period since the previous frame
    /// (µs; the device's own tick period, its jitter free of the host's scheduling).
    fn advance(&mut self, time_us: u32) -> (f64, Option<f32>) {
        let period = self.last.map(|last| time_us.wrapping_sub(last));
        self.total_us += u64::from(period.unwrap_or(0));
        self.last = Some(time_us);
        (self.total_us as f64 * 1e-6, period.map(|p| p as f32))
    }
}

/// The tick a telemetry frame describes. The wire carries the HIP, CP, GO, the total force
/// and both magnitudes; the normal is recovered from the CP: the CP is the closest point, so
/// the HIP lies on its normal, and the unit normal is (CP − HIP)/|CP − HIP| inside the
/// object (the tick renders no force outside). The friction vector is the total minus the
/// normal force. Quantities the frame does not carry (joint angles, torques, velocity, the
/// parameters) are zero.
pub fn tick_of(t: &Telemetry, t_s: f64) -> Tick {
    let v3 = |v: Vec2| Vec3::new(v.x, v.y, 0.0);
    let inward = t.cp_m - t.hip_m;
    let depth = inward.length();
    let in_contact = t.mode != Mode::Free && depth > 0.0;
    let normal = if in_contact {
        inward / depth
    } else {
        Vec2::ZERO
    };
    let tangent = Vec2::new(-normal.y, normal.x);
    let friction = t.force_n - normal * t.force_normal_n;
    Tick {
        t_s,
        hip: v3(t.hip_m),
        cp: v3(t.cp_m),
        go: v3(t.go_m),
        patch: match t.feature {
            Some(Feature::Patch(p)) => Some(usize::from(p)),
            _ => None,
        },
        feature: t.feature.unwrap_or(Feature::Patch(0)),
        mode: t.mode,
        cause: t.cause,
        depth_m: if in_contact { depth } else { 0.0 },
        normal_force_n: t.force_normal_n,
        friction_force_n: friction.dot(tangent),
        mu: t.mu(),
        psi: t.psi,
        normal: v3(normal),
        tangent: v3(tangent),
        friction: v3(friction),
        force: v3(t.force_n),
        // Where the force acts, on the GO's patch (the CP's feature's patch, which is the
        // object's only patch when it deforms); the CP's parameter is not in the frame.
        go_patch: match t.feature {
            Some(Feature::Patch(p)) => usize::from(p),
            _ => 0,
        },
        go_param: t.go_param,
        go_params: [t.go_param, 0.0],
        deform: None,
        device: Some(DeviceSample {
            theta_rad: [0.0; 2],
            tau_nm: [0.0; 2],
            faults: t.faults,
        }),
        ..Tick::idle(t_s)
    }
}
