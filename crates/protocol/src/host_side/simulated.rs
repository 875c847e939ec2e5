//! In-process link: the simulated pantograph and the device's [`Controller`] on a thread,
//! behind the same frames a board sends.
//!
//! The thread plays the firmware: at every tick it handles the frames the host sent
//! ([`SceneReceiver`] for sequence numbers and scene uploads), runs one controller tick on
//! the simulated encoders, steps the simulated arm with the commanded currents and the
//! virtual hand, and sends telemetry as a board does: one frame per millisecond, every tick's
//! at 1 kHz, the ticks folded into it at a faster rate (`crate::telemetry`). Every accepted frame is acked (rejected ones
//! nacked); a hello is also answered with the device's hello, a heartbeat with a status.
//!
//! The thread validates (decodes) uploads into its [`SceneStore`]; a committed scene's
//! object is loaded into the controller, which keeps its own copy of it
//! ([`SceneStore::chain`]), so the store is free for the next upload at once. A control-point
//! update ([`Message::ScenePoints`]) keeps the renderer: the controller's chain is moved onto
//! the updated store's curves in place ([`Controller::reshape_object`]), between two ticks.
//! The device clock is the tick count times the period in integer microseconds, as a
//! board's timer. The first object
//! of the scene is rendered, when it is a chain of planar curves (the pantograph is planar:
//! surfaces are accepted but render nothing).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender, SyncSender, TryRecvError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use nurbs::Vec2;
use tracker::Chain;

use super::serial::{Packets, Stream, read_packets, write_packet};
use super::{Link, LinkError, Sequencer, cobs, software_version};
use crate::device_side::Numbering;
use crate::device_side::session::{DeviceSession, DeviceState, Event};
use crate::{ErrorCode, Frame, MAX_FRAME, Message, SceneStore};
use device::controller::Controller;
use device::safety::SafetyConfig;
use device::simulator::{SimParams, SimulatedPantograph, VirtualHand};
use device::spec::DeviceSpec;
use device::telemetry::TelemetryDecimator;

/// Scene capacity of the simulated device (bytes), as the firmware's receiver.
const SCENE_CAPACITY: usize = 8192;
/// Frames the simulated device may have in flight to the host. When the host falls behind, a
/// paced simulation drops telemetry (the host sees gaps); an unpaced one waits.
const QUEUE: usize = 64;

/// How to run the simulated device.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimConfig {
    /// The device.
    pub spec: DeviceSpec,
    /// Its safety limits; `period_s` is the tick period.
    pub safety: SafetyConfig,
    /// The simulated arm and hand.
    pub params: SimParams,
    /// Where the handle starts (m, device frame); the hand's target starts there too.
    pub start_hip: Vec2,
    /// Tick in real time (`true`), or as fast as the host reads telemetry (`false`, for
    /// tests: nothing is dropped and the run does not depend on the machine's speed).
    pub paced: bool,
    /// Render materials stiffer than the device renders passively, with the passivity
    /// controller on (a board decides this in its firmware; the wire does not carry it).
    pub passivity_control: bool,
    /// Nobody holds the handle (its own mass, the device's friction and the motors): an
    /// identification run's plant. The hand's targets then move nothing.
    pub released: bool,
}

impl Default for SimConfig {
    /// The default pantograph at the board's 10 kHz with the default limits, held by a firm
    /// hand (2000 N/m, 5 N·s/m) at (0, 0.09) m, paced, passivity controller on.
    fn default() -> Self {
        SimConfig {
            spec: DeviceSpec::default(),
            safety: SafetyConfig {
                period_s: 1e-4,
                ..SafetyConfig::default()
            },
            params: SimParams {
                hand_stiffness_n_per_m: 2000.0,
                hand_damping_ns_per_m: 5.0,
                ..SimParams::default()
            },
            start_hip: Vec2::new(0.0, 0.09),
            paced: true,
            passivity_control: true,
            released: false,
        }
    }
}

#[derive(Debug)]
enum ToDevice {
    Frame([u8; MAX_FRAME]),
    HandTarget(Vec2),
}

/// The simulated device on its own thread. Dropping the link stops the thread.
#[derive(Debug)]
pub struct SimLink {
    to_device: Option<Sender<ToDevice>>,
    from_device: Option<Receiver<[u8; MAX_FRAME]>>,
    thread: Option<JoinHandle<()>>,
    seq: Sequencer,
}

impl SimLink {
    /// Starts the simulated device (uncalibrated, forces off, no scene).
    pub fn spawn(config: SimConfig) -> Result<Self, LinkError> {
        let controller: Controller<Chain> = Controller::new(config.spec, config.safety)?;
        let mut arm = SimulatedPantograph::new(config.spec, config.params, config.start_hip)?;
        if config.released {
            arm.release();
        }
        let (to_device, commands) = mpsc::channel();
        let (frames, from_device) = mpsc::sync_channel(QUEUE);
        let thread = std::thread::Builder::new()
            .name("sim-device".into())
            .spawn(move || {
                let mut session = Box::new(DeviceSession::new(true));
                session.set_motor_limits(&config.spec);
                let mut device = SimDevice {
                    config,
                    commands,
                    frames,
                    arm,
                    hand: VirtualHand::at(config.start_hip),
                    session,
                    scratch: Box::new(SceneStore::new()),
                    // A device's numbering: telemetry and replies apart, every value.
                    numbering: Numbering::default(),
                    tick: 0,
                    started: Instant::now(),
                    decimator: TelemetryDecimator::for_period_s(config.safety.period_s),
                };
                device.run(controller);
            })?;
        Ok(SimLink {
            to_device: Some(to_device),
            from_device: Some(from_device),
            thread: Some(thread),
            seq: Sequencer::default(),
        })
    }

    /// Moves the virtual hand's target (m, device frame): the hand pulls the handle there
    /// through its spring.
    pub fn set_hand_target(&self, target: Vec2) -> Result<(), LinkError> {
        self.command(ToDevice::HandTarget(target))
    }

    /// A handle that moves the virtual hand while the link itself is borrowed elsewhere.
    pub fn hand(&self) -> Result<SimHand, LinkError> {
        Ok(SimHand {
            to_device: self.to_device.clone().ok_or(LinkError::Closed)?,
        })
    }

    fn command(&self, command: ToDevice) -> Result<(), LinkError> {
        self.to_device
            .as_ref()
            .ok_or(LinkError::Closed)?
            .send(command)
            .map_err(|_| LinkError::Closed)
    }
}

/// Moves the virtual hand of a [`SimLink`] (see [`SimLink::hand`]).
#[derive(Clone, Debug)]
pub struct SimHand {
    to_device: Sender<ToDevice>,
}

impl SimHand {
    /// See [`SimLink::set_hand_target`].
    pub fn set_target(&self, target: Vec2) -> Result<(), LinkError> {
        self.to_device
            .send(ToDevice::HandTarget(target))
            .map_err(|_| LinkError::Closed)
    }
}

impl Drop for SimLink {
    fn drop(&mut self) {
        // Closing both channels ends the thread whether it waits to send or to tick (a
        // `SimHand` still alive keeps the command channel open: the thread then ends at its
        // next telemetry frame, which finds the host's receiver gone).
        self.to_device.take();
        self.from_device.take();
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

impl SimLink {
    /// Serves this simulated device on `stream` as a board serves its serial port: the
    /// host's COBS packets in, the device's frames (acks, nacks, status, telemetry) out, so a
    /// host reaches it through a [`super::StreamLink`] (a pseudo-terminal's other end, for
    /// the serial path without a board). A packet that is not COBS reaches the device as
    /// its raw bytes, which it refuses as a board does (a nack). Returns when `stop` is set,
    /// the stream fails or ends, or the device's thread is gone.
    pub fn serve<S: Stream>(self, mut stream: S, stop: &AtomicBool) -> Result<(), LinkError> {
        let to_device = self.to_device.as_ref().ok_or(LinkError::Closed)?;
        let from_device = self.from_device.as_ref().ok_or(LinkError::Closed)?;
        let mut packets = Packets::default();
        while !stop.load(Ordering::Relaxed) {
            read_packets(&mut stream, &mut packets, Duration::from_millis(1))?;
            while let Some(packet) = packets.next_packet() {
                let bytes = cobs::decode(&packet).unwrap_or(packet);
                let mut report = [0u8; MAX_FRAME];
                let n = bytes.len().min(MAX_FRAME);
                report[..n].copy_from_slice(&bytes[..n]);
                to_device
                    .send(ToDevice::Frame(report))
                    .map_err(|_| LinkError::Closed)?;
            }
            // At most what the queue holds per round, so a stream that takes no bytes (no
            // host reading the other end) cannot keep this loop from reading or stopping.
            let mut writable = true;
            for _ in 0..QUEUE {
                match from_device.try_recv() {
                    Ok(report) if writable => {
                        // The device's frames are valid: re-encoding gives their length.
                        let n = Frame::decode(&report).map_or(MAX_FRAME, |f| f.to_report().1);
                        match write_packet(&mut stream, &report[..n]) {
                            Ok(()) => {}
                            // Nobody reads the other end: this round's frames are lost, as a
                            // UART's bytes are (COBS resynchronises at the next delimiter).
                            Err(e)
                                if matches!(
                                    e.kind(),
                                    std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock
                                ) =>
                            {
                                writable = false;
                            }
                            Err(e) => return Err(e.into()),
                        }
                    }
                    Ok(_) => {}
                    Err(TryRecvError::Empty) => break,
                    Err(TryRecvError::Disconnected) => return Err(LinkError::Closed),
                }
            }
        }
        Ok(())
    }
}

impl Link for SimLink {
    fn send(&mut self, message: &Message) -> Result<u16, LinkError> {
        let (report, _, seq) = self.seq.encode(message);
        self.command(ToDevice::Frame(report))?;
        Ok(seq)
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<Frame>, LinkError> {
        let from_device = self.from_device.as_ref().ok_or(LinkError::Closed)?;
        match from_device.recv_timeout(timeout) {
            Ok(bytes) => self.seq.decode_reply(&bytes).map(Some),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(LinkError::Closed),
        }
    }
}

/// Why the thread stopped ticking.
enum EpochEnd {
    /// A scene upload was committed into `scratch`.
    Swap,
    /// A control-point update of object `object` was applied; `scratch` holds the scene.
    Points { object: u8 },
    /// The host is gone.
    Stop,
}

struct SimDevice {
    config: SimConfig,
    commands: Receiver<ToDevice>,
    frames: SyncSender<[u8; MAX_FRAME]>,
    arm: SimulatedPantograph,
    hand: VirtualHand,
    session: Box<DeviceSession<SCENE_CAPACITY>>,
    /// Where uploads and updates are validated (decoded), then loaded from.
    scratch: Box<SceneStore>,
    numbering: Numbering,
    tick: u64,
    started: Instant,
    /// The ticks' telemetry, one frame per millisecond as a board sends it.
    decimator: TelemetryDecimator,
}

impl SimDevice {
    /// Ticks until the host leaves; a committed scene or an update goes to the controller
    /// between two ticks, as on a board.
    fn run(&mut self, mut controller: Controller<Chain>) {
        loop {
            match self.epoch(&mut controller) {
                EpochEnd::Stop => return,
                EpochEnd::Swap => self.load(&mut controller),
                // The pantograph renders object 0; the others' points change nothing here.
                EpochEnd::Points { object: 0 } => self.reshape(&mut controller),
                EpochEnd::Points { .. } => {}
            }
        }
    }

    /// Loads object 0 of the committed scene afresh (the renderer waits for its
    /// acquisition); without one (a scene of surfaces) nothing renders.
    fn load(&mut self, controller: &mut Controller<Chain>) {
        controller.unload_scene();
        if let (Ok(chain), Some(material)) = (self.scratch.chain(0), self.scratch.material(0))
            && controller
                .load_scene_as_needed(chain, material, self.config.passivity_control)
                .is_err()
        {
            self.session.note_error(ErrorCode::BadMaterial);
        }
    }

    /// Moves the rendered object onto the updated scene's object 0, the renderer carried on
    /// ([`Controller::reshape_object`] with [`Chain::reshape`]).
    fn reshape(&mut self, controller: &mut Controller<Chain>) {
        let moved = self.scratch.with_curves(0, |curves| {
            controller.reshape_object(|chain| chain.reshape(curves))
        });
        if !matches!(moved, Ok(Ok(()))) {
            // No scene loaded (its material was refused), or another topology.
            self.session.note_error(ErrorCode::TopologyChanged);
        }
    }

    /// The device clock (µs): ticks times the period, as a board's timer would read.
    fn now_us(&self) -> u64 {
        self.tick.saturating_mul(self.config.safety.period_us())
    }

    /// Ticks on the current scene until a new one is committed or the host leaves.
    fn epoch(&mut self, controller: &mut Controller<Chain>) -> EpochEnd {
        let period_s = self.config.safety.period_s;
        loop {
            loop {
                match self.commands.try_recv() {
                    Ok(ToDevice::HandTarget(t)) => self.hand.command(t),
                    Ok(ToDevice::Frame(bytes)) => match self.handle(controller, &bytes) {
                        Ok(Some(end)) => return end,
                        Ok(None) => {}
                        Err(()) => return EpochEnd::Stop,
                    },
                    Err(TryRecvError::Empty) => break,
                    Err(TryRecvError::Disconnected) => return EpochEnd::Stop,
                }
            }
            let begun = Instant::now();
            let mut out = controller.tick(self.arm.encoder_counts(), self.now_us());
            // An arm driven into a singular pose stays there, as a real one on its stops.
            let hand = self.hand.step(period_s);
            let _ = self.arm.step(out.currents_a, hand, period_s);
            out.telemetry.tick_us = u16::try_from(begun.elapsed().as_micros()).unwrap_or(u16::MAX);
            // The global search after a swap, outside the tick as on the board.
            controller.acquire_now();
            if let Some(frame) = self.decimator.push(&out.telemetry) {
                let message = Message::Telemetry(*frame);
                if self.emit(&message).is_err() {
                    return EpochEnd::Stop;
                }
            }
            self.tick += 1;
            // Paced per telemetry frame (1 ms), not per tick: the thread wakes once a
            // millisecond and runs that millisecond's ticks, as the app's loop does.
            if self.config.paced
                && self
                    .tick
                    .is_multiple_of(u64::from(self.decimator.ticks_per_frame()))
            {
                let due =
                    self.started + Duration::from_secs_f64(self.tick as f64 * f64::from(period_s));
                let now = Instant::now();
                if due > now {
                    std::thread::sleep(due - now);
                } else if now - due > Duration::from_millis(100) {
                    // Far behind (the machine was suspended): restart the clock, don't race.
                    self.started =
                        now - Duration::from_secs_f64(self.tick as f64 * f64::from(period_s));
                }
            }
        }
    }

    /// Handles one host frame; `Ok(Some(_))` when it committed a scene or applied an update.
    fn handle(
        &mut self,
        controller: &mut Controller<Chain>,
        bytes: &[u8],
    ) -> Result<Option<EpochEnd>, ()> {
        // The simulated joints "rest on their end stops": the counts read there.
        let home = self.config.spec.end_stop_counts();
        let (paced, frames, numbering) = (self.config.paced, &self.frames, &mut self.numbering);
        let mut gone = false;
        let event = self.session.handle(
            bytes,
            &mut *self.scratch,
            DeviceState::of(software_version(), controller),
            &mut |m: &Message| gone |= emit(paced, frames, numbering, m).is_err(),
        );
        if gone {
            return Err(());
        }
        Ok(match event {
            Event::SceneCommitted => Some(EpochEnd::Swap),
            Event::ScenePointsUpdated { object } => Some(EpochEnd::Points { object }),
            Event::HandTarget(target) => {
                self.hand.command(target);
                None
            }
            Event::DeviceCommand(command) => {
                if let Err(code) = command.apply(controller, home, self.config.passivity_control) {
                    self.session.note_error(code);
                }
                None
            }
            Event::None => None,
        })
    }

    /// Sends one frame to the host (see [`emit`]).
    fn emit(&mut self, message: &Message) -> Result<(), ()> {
        emit(
            self.config.paced,
            &self.frames,
            &mut self.numbering,
            message,
        )
    }
}

/// Sends one frame to the host, numbered as its kind ([`Numbering`]). Paced, a full queue
/// drops a telemetry frame (its sequence number is spent, so the host sees the gap in the
/// telemetry's numbers), as a board drops telemetry its link cannot carry; replies (acks,
/// nacks, status, hello) wait for room, since a host waits on them. Unpaced, every frame
/// waits for the host.
fn emit(
    paced: bool,
    frames: &SyncSender<[u8; MAX_FRAME]>,
    numbering: &mut Numbering,
    message: &Message,
) -> Result<(), ()> {
    let (report, _) = numbering.report(message);
    if paced && matches!(message, Message::Telemetry(_)) {
        match frames.try_send(report) {
            Ok(()) | Err(mpsc::TrySendError::Full(_)) => Ok(()),
            Err(mpsc::TrySendError::Disconnected(_)) => Err(()),
        }
    } else {
        frames.send(report).map_err(|_| ())
    }
}

/// The simulated device's frames as the reports of the board's USB HID device
/// ([`crate::device_side::usb::HidPort`]) run on the host, over USB/IP in `cargo xtask hid`: host reports
/// go to the device's thread as a board's OUT reports go to its protocol task, and the
/// device's frames wait in a board's two queues (`firmware::usb::Usb`): the replies (ack,
/// nack, status, hello) in a queue of [`SimReports::REPLIES`], and telemetry in a queue of
/// [`SimReports::FRAMES`] frames, each dropping the newest when full (the host sees the
/// missing millisecond in the frames' device time and their numbers, or a request not
/// answered). The port's [`crate::device_side::usb::Outbox`] sends each queue on its own
/// endpoint, as the board's. Feature `usb`.
#[cfg(feature = "usb")]
#[derive(Debug)]
pub struct SimReports {
    link: SimLink,
    replies: std::collections::VecDeque<Message>,
    frames: std::collections::VecDeque<Message>,
    sent: u64,
    dropped: u64,
    dropped_replies: u64,
}

#[cfg(feature = "usb")]
impl SimLink {
    /// This device behind a USB port instead of a host link ([`SimReports`]).
    pub fn into_reports(self) -> SimReports {
        SimReports {
            link: self,
            replies: std::collections::VecDeque::new(),
            frames: std::collections::VecDeque::new(),
            sent: 0,
            dropped: 0,
            dropped_replies: 0,
        }
    }
}

#[cfg(feature = "usb")]
impl SimReports {
    /// Telemetry frames waiting for the IN endpoint, as the board's queue
    /// (`firmware::protocol_task::FRAMES`).
    pub const FRAMES: usize = 4;
    /// Replies waiting for their IN endpoint, as the board's queue
    /// (`firmware::protocol_task::REPLIES`, a `heapless::spsc::Queue` of 4 that holds 3): a
    /// host that does not read the replies' interface fills it, and further replies are
    /// dropped, as on the board.
    pub const REPLIES: usize = 3;

    /// Whether the device's thread still runs (it stops when it cannot send).
    pub fn running(&self) -> bool {
        self.link.thread.as_ref().is_some_and(|t| !t.is_finished())
    }

    /// Reports sent so far.
    pub fn sent_count(&self) -> u64 {
        self.sent
    }

    /// Telemetry frames dropped so far because the queue was full.
    pub fn dropped_count(&self) -> u64 {
        self.dropped
    }

    /// Replies dropped so far because their queue was full.
    pub fn dropped_replies(&self) -> u64 {
        self.dropped_replies
    }

    /// Moves what the device's thread sent into the reply and telemetry queues.
    fn collect(&mut self) {
        let Some(from_device) = &self.link.from_device else {
            return;
        };
        while let Ok(report) = from_device.try_recv() {
            // The device's own frames: they decode.
            let Ok(frame) = Frame::decode(&report) else {
                continue;
            };
            match frame.message {
                Message::Telemetry(_) if self.frames.len() >= Self::FRAMES => {
                    self.dropped += 1;
                }
                m @ Message::Telemetry(_) => self.frames.push_back(m),
                _ if self.replies.len() >= Self::REPLIES => self.dropped_replies += 1,
                m => self.replies.push_back(m),
            }
        }
    }
}

#[cfg(feature = "usb")]
impl crate::device_side::usb::ReportPump for SimReports {
    fn received(&mut self, report: &[u8]) {
        let mut frame = [0u8; MAX_FRAME];
        let n = report.len().min(MAX_FRAME);
        frame[..n].copy_from_slice(&report[..n]);
        // A device thread that is gone answers nothing: the host times out, as with a board
        // that stopped.
        let _ = self.link.command(ToDevice::Frame(frame));
    }

    fn reply(&mut self) -> Option<Message> {
        self.collect();
        self.replies.front().copied()
    }

    fn frame(&mut self) -> Option<Message> {
        self.collect();
        self.frames.front().copied()
    }

    fn take_reply(&mut self) {
        self.replies.pop_front();
        self.sent += 1;
    }

    fn take_frame(&mut self) {
        self.frames.pop_front();
        self.sent += 1;
    }

    fn drop_frames(&mut self) {
        self.collect();
        self.frames.clear();
    }
}
