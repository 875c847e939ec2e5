//! Every loop the app runs (the planar device of [`crate::planar`], the spatial hand of
//! [`crate::spatial`], the host of a device behind a link in [`crate::remote`]) takes the same [`LoopCommand`] and answers with the
//! same [`Reply`] and [`Sample`]; a loop is [`Steppable`], and [`Backend`] runs any of them on
//! its own thread ([`LoopThread`]) or steps it in place (tests).
//!
//! [`LoopThread`] runs a [`Steppable`] loop on its own thread at its tick rate. The UI talks to it
//! through channels only and never waits for it: commands (hand target, material, scene swap,
//! forces, clear faults) go through a bounded channel the loop drains at every tick boundary
//! (a full channel drops the command and counts it); every tick goes back as a [`Sample`]
//! through another bounded channel (a full channel drops the sample and counts it, so a slow
//! frame never delays a tick); replies to commands come through a third, unbounded one (they
//! are rare). With `--record` a third consumer, the [`Recorder`](crate::runlog::Recorder) thread, gets every tick
//! through its own bounded channel and writes the run log.
//!
//! Tests step a loop in place ([`Backend::Stepped`], or a [`HapticLoop`](crate::planar::HapticLoop) directly): no thread,
//! no clock, the same ticks for the same inputs.

use std::fmt;
use std::io;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, Sender, SyncSender, TryRecvError, TrySendError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use device::safety::Faults;
use friction::FrictionMaterial;
use nurbs::{Vec2, Vec3};
use tracker::TriMesh;

use crate::deform::{DeformChangeError, DeformStatus};
use crate::error::{MaterialChangeError, MeshError};
use crate::planar::PlanarSession;
use crate::runlog::RecordTx;
use crate::tick::Tick;

/// The loop's tick rate (Hz).
pub const RATE_HZ: f64 = 1000.0;

/// Ticks the UI channel holds (2 s at 1 kHz): a UI that stalls longer loses samples.
pub const TELEMETRY_CAPACITY: usize = 2048;
/// Commands the loop's channel holds between two ticks.
pub const COMMAND_CAPACITY: usize = 256;
/// Ticks the recorder's channel holds (4 s at 1 kHz).
pub const RECORD_CAPACITY: usize = 4096;

/// What the UI asks of a loop: one command type for every loop, generic over the session a
/// loop swaps in (`S`: [`PlanarSession`] for the planar device and the host of a device behind a
/// link, [`crate::spatial::SpatialSession`] for the spatial hand). A loop answers a command
/// it does not support with [`Reply::Unsupported`] and changes nothing.
#[derive(Debug)]
pub enum LoopCommand<S = PlanarSession> {
    /// Move the hand's target (m, device frame); a planar loop takes x and y.
    HandTarget(Vec3),
    /// Set the rendered object's material ([`HapticLoop::set_material`](crate::planar::HapticLoop::set_material)).
    SetMaterial(FrictionMaterial),
    /// Render another session ([`HapticLoop::swap_session`](crate::planar::HapticLoop::swap_session)); built by the UI, swapped in at a
    /// tick boundary.
    Swap(Box<S>),
    /// Render this mesh instead of the session's object (the polygonal baseline), or the
    /// object again (`None`). The spatial hand only.
    Mesh(Option<Box<TriMesh>>),
    /// Enable or disable the forces.
    Forces(bool),
    /// Clear the latched faults.
    ClearFaults,
    /// Calibrate against the end stops (the simulated arm is homed at once). The device only.
    Calibrate,
    /// Who holds the simulated pantograph's handle (a released hand lets go at once). The
    /// simulated device in the app only.
    Hand(crate::hand::Hand),
    /// Move control points of the device's scene in place (a deformable model's new shape,
    /// [`PointsUpdate`]): the device's renderer carries on, on the new shape, with no new
    /// acquisition or ramp. A device behind a link only ([`crate::remote`]): sent at once,
    /// not queued behind requests, and the newest update replaces one not sent yet.
    ScenePoints(Box<PointsUpdate>),
    /// Make the rendered object deformable (`true`: the hand pushes it and it moves, a
    /// [`Deformer`](crate::deform::Deformer) stepped by the loop, its renderer carried onto
    /// each new shape) or rigid at its rest shape again (`false`). The object needs a
    /// `"dynamics"` block. Answered with [`Reply::Deform`]; a loop that cannot deform answers
    /// [`Reply::Unsupported`].
    Deform(bool),
}

/// New control points for patches of one object of the device's scene
/// ([`LoopCommand::ScenePoints`], [`protocol::points_update`]; `P` = [`Vec3`] for a
/// surface's, [`protocol::points_update_spatial`]). Send whole patches (or at least
/// every point that moved since the device's last applied shape): an update replaced by a
/// newer one before it went out is never sent. A deforming object's shape reaches every loop
/// as one of these ([`crate::deformation::Deformation`]).
#[derive(Clone, Debug, PartialEq)]
pub struct PointsUpdate<P = Vec2> {
    /// The object in the device's scene (a session's upload makes its object the scene's
    /// object [`crate::upload::DEVICE_OBJECT`]).
    pub object: u8,
    /// Per patch: its index in the object, the index of its first control point given, and
    /// the new Cartesian points (m; planar x, y, or x, y, z). The weights stay the scene's.
    /// Patches that share a point at a join move together in one update.
    pub patches: Vec<(u8, u16, Vec<P>)>,
}

impl PointsUpdate {
    /// The update's frames, in the order they go to the device
    /// ([`protocol::points_update`]: the last applies them all).
    pub fn messages(&self) -> Vec<protocol::Message> {
        let patches: Vec<(u8, u16, &[Vec2])> = self
            .patches
            .iter()
            .map(|(patch, first, points)| (*patch, *first, &points[..]))
            .collect();
        protocol::points_update(self.object, &patches).collect()
    }
}

impl<S> LoopCommand<S> {
    /// What the command asks, as [`Reply::Unsupported`] names it.
    pub fn name(&self) -> &'static str {
        match self {
            LoopCommand::HandTarget(_) => "the hand's target",
            LoopCommand::SetMaterial(_) => "the material",
            LoopCommand::Swap(_) => "the scene swap",
            LoopCommand::Mesh(_) => "a mesh",
            LoopCommand::Forces(_) => "forces on/off",
            LoopCommand::ClearFaults => "clearing the faults",
            LoopCommand::Calibrate => "the calibration",
            LoopCommand::Hand(_) => "the hand model",
            LoopCommand::ScenePoints(_) => "the control-point update",
            LoopCommand::Deform(_) => "deforming the object",
        }
    }
}

/// What the loop answers.
#[derive(Debug)]
pub enum Reply {
    /// The result of a [`LoopCommand::SetMaterial`].
    Material(Result<FrictionMaterial, MaterialChangeError>),
    /// A [`LoopCommand::Swap`] took effect.
    Swapped,
    /// Faults still latched after a [`LoopCommand::ClearFaults`].
    FaultsCleared(Faults),
    /// The result of a [`LoopCommand::Mesh`]: a mesh the loop cannot scan in a tick is refused
    /// and the running rendering stays.
    Mesh(Result<(), MeshError>),
    /// The result of a [`LoopCommand::Deform`]: whether the object now deforms and where the loop
    /// publishes its shape, or why it was refused (nothing changed).
    Deform(Result<DeformStatus, DeformChangeError>),
    /// The loop does not support the command ([`LoopCommand::name`]); nothing changed.
    Unsupported(&'static str),
    /// What a device behind a link said or did ([`crate::remote`]).
    Link(LinkEvent),
}

/// What happened on the link to a device ([`crate::remote`]).
#[derive(Clone, Debug, PartialEq)]
pub enum LinkEvent {
    /// The device answered the hello.
    Connected {
        /// What the link is (`tcp 127.0.0.1:7000`, `hid`, …).
        device: String,
        /// The device's hello (firmware version, scene capacity).
        hello: protocol::Hello,
        /// Whether the device's plant is simulated (it takes hand targets).
        simulated_plant: bool,
    },
    /// The device's status (the answer to every heartbeat).
    Status(protocol::Status),
    /// The device refused a command (`what`), for `reason`; its state is unchanged.
    Refused {
        /// The command.
        what: &'static str,
        /// The device's reason.
        reason: String,
    },
    /// The link is gone (or never came up); the device's watchdog turns its forces off.
    Lost(String),
}

/// One tick as the UI receives it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// The tick.
    pub tick: Tick,
    /// The hand's target during the tick (m).
    pub hand_target: Vec2,
    /// Time since the previous tick began (µs), `None` for the first tick or in a stepped
    /// loop (no clock).
    pub period_us: Option<f32>,
    /// Whether forces were enabled.
    pub forces_enabled: bool,
}

/// Counters the loop thread shares with the UI.
#[derive(Debug, Default)]
pub struct LoopCounters {
    /// Samples dropped because the UI's channel was full.
    pub dropped_samples: AtomicU64,
    /// Commands dropped because the loop's channel was full.
    pub dropped_commands: AtomicU64,
    /// Ticks dropped because the recorder's channel was full.
    pub dropped_records: AtomicU64,
    /// Ticks run.
    pub ticks: AtomicU64,
    /// Whether the OS gave the loop thread real-time scheduling ([`raise_priority`]).
    pub realtime: AtomicBool,
    /// Frames of a device behind a link lost on the way (gaps in its sequence numbers).
    pub link_lost_frames: AtomicU64,
    /// Corrupt frames from a device behind a link.
    pub link_bad_frames: AtomicU64,
    /// The latest heartbeat's round trip to a device behind a link (µs; 0 before one).
    pub link_rtt_us: AtomicU64,
    /// Control-point updates ([`LoopCommand::ScenePoints`]) sent to a device behind a link.
    pub points_sent: AtomicU64,
    /// Control-point updates the device applied (the ack of their apply frame).
    pub points_applied: AtomicU64,
    /// Control-point updates the device refused, or never answered.
    pub points_refused: AtomicU64,
    /// Control-point updates replaced by a newer one before they were sent.
    pub points_superseded: AtomicU64,
}

/// Asks the OS to run the calling thread ahead of every normal one: real-time FIFO
/// scheduling at the lowest real-time priority, where the OS allows it (root, CAP_SYS_NICE or
/// an rtprio limit); elsewhere nothing changes. Returns whether it took. The loop sleeps
/// until its next tick is due, so it takes about 5 % of a core; Linux also keeps 5 % of every
/// second for normal threads whatever real-time threads do.
pub fn raise_priority() -> bool {
    #[cfg(unix)]
    {
        use thread_priority::unix::{set_thread_priority_and_policy, thread_native_id};
        use thread_priority::{RealtimeThreadSchedulePolicy, ThreadPriority, ThreadSchedulePolicy};
        set_thread_priority_and_policy(
            thread_native_id(),
            ThreadPriority::Min,
            ThreadSchedulePolicy::Realtime(RealtimeThreadSchedulePolicy::Fifo),
        )
        .is_ok()
    }
    #[cfg(not(unix))]
    {
        thread_priority::set_current_thread_priority(thread_priority::ThreadPriority::Max).is_ok()
    }
}

/// A loop [`LoopThread`] and [`Backend`] run: the planar [`HapticLoop`](crate::planar::HapticLoop), or the spatial hand
/// of [`crate::spatial`]. One tick at a time, commands applied between ticks.
pub trait Steppable: Send + 'static {
    /// What [`LoopCommand::Swap`] swaps in.
    type Session: fmt::Debug + Send + 'static;
    /// Applies one command; the reply, if it has one. Every command gets an answer or a
    /// documented no-op: one the loop does not support is [`Reply::Unsupported`].
    fn apply(&mut self, command: LoopCommand<Self::Session>) -> Option<Reply>;
    /// Runs one tick; its sample without a period (the thread adds it).
    fn step_sample(&mut self) -> Sample;
}

/// A [`HapticLoop`](crate::planar::HapticLoop) (or another [`Steppable`], or the host of a device behind a link) on its
/// own thread, ticking in real time at [`RATE_HZ`], taking [`LoopCommand`]s that swap in sessions
/// of type `S`. Dropping it stops the thread (and, with it, the recorder's input).
#[derive(Debug)]
pub struct LoopThread<S: Send + 'static = PlanarSession> {
    commands: SyncSender<LoopCommand<S>>,
    samples: Receiver<Sample>,
    replies: Receiver<Reply>,
    counters: Arc<LoopCounters>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl<S: Send + 'static> LoopThread<S> {
    /// Starts `haptic` on a thread named `haptic-loop`; every tick also goes to `record`
    /// when given.
    pub fn spawn<L: Steppable<Session = S>>(
        mut haptic: L,
        record: Option<RecordTx>,
    ) -> io::Result<Self> {
        Self::spawn_with("haptic-loop", record, move |ends| {
            ends.counters
                .realtime
                .store(raise_priority(), Ordering::Relaxed);
            run_paced(&mut haptic, &ends);
        })
    }

    /// Starts `body` on a thread named `name` with the thread's ends of the channels: the
    /// host of a device behind a link ([`crate::remote`]) is the other body.
    pub fn spawn_with(
        name: &str,
        record: Option<RecordTx>,
        body: impl FnOnce(LoopEnds<S>) + Send + 'static,
    ) -> io::Result<Self> {
        let (commands, command_rx) = mpsc::sync_channel(COMMAND_CAPACITY);
        let (sample_tx, samples) = mpsc::sync_channel(TELEMETRY_CAPACITY);
        let (reply_tx, replies) = mpsc::channel();
        let counters = Arc::new(LoopCounters::default());
        let stop = Arc::new(AtomicBool::new(false));
        let ends = LoopEnds {
            commands: command_rx,
            samples: sample_tx,
            replies: reply_tx,
            record,
            counters: counters.clone(),
            stop: stop.clone(),
        };
        let thread = std::thread::Builder::new()
            .name(name.into())
            .spawn(move || body(ends))?;
        Ok(LoopThread {
            commands,
            samples,
            replies,
            counters,
            stop,
            thread: Some(thread),
        })
    }

    /// Sends a command without waiting; a full channel drops it (counted) and returns false.
    pub fn send(&self, command: LoopCommand<S>) -> bool {
        match self.commands.try_send(command) {
            Ok(()) => true,
            Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => {
                self.counters
                    .dropped_commands
                    .fetch_add(1, Ordering::Relaxed);
                false
            }
        }
    }

    /// The samples that arrived since the last call, without waiting.
    pub fn drain_samples(&self, mut f: impl FnMut(Sample)) {
        while let Ok(s) = self.samples.try_recv() {
            f(s);
        }
    }

    /// The replies that arrived since the last call, without waiting.
    pub fn drain_replies(&self) -> Vec<Reply> {
        self.replies.try_iter().collect()
    }

    /// The shared counters.
    pub fn counters(&self) -> &LoopCounters {
        &self.counters
    }

    /// Whether the thread is still running.
    pub fn is_running(&self) -> bool {
        self.thread.as_ref().is_some_and(|t| !t.is_finished())
    }
}

impl<S: Send + 'static> Drop for LoopThread<S> {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// The loop thread's ends of its channels.
#[derive(Debug)]
pub struct LoopEnds<S = PlanarSession> {
    /// Commands from the UI.
    pub commands: Receiver<LoopCommand<S>>,
    samples: SyncSender<Sample>,
    /// Replies to the UI.
    pub replies: Sender<Reply>,
    record: Option<RecordTx>,
    /// The counters shared with the UI.
    pub counters: Arc<LoopCounters>,
    stop: Arc<AtomicBool>,
}

impl<S> LoopEnds<S> {
    /// Whether the UI asked the thread to stop.
    pub fn stopping(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// Sends a reply (a UI gone is not an error: the thread sees it at its next sample).
    pub fn reply(&self, reply: Reply) {
        let _ = self.replies.send(reply);
    }

    /// Hands one tick to the UI and the recorder, dropping it (counted) where a channel is
    /// full; false when the UI is gone.
    pub fn publish(&self, sample: Sample) -> bool {
        self.counters.ticks.fetch_add(1, Ordering::Relaxed);
        match self.samples.try_send(sample) {
            Ok(()) => {}
            Err(TrySendError::Full(_)) => {
                self.counters
                    .dropped_samples
                    .fetch_add(1, Ordering::Relaxed);
            }
            Err(TrySendError::Disconnected(_)) => return false,
        }
        if let Some(record) = &self.record
            && !record.try_send(sample.tick)
        {
            self.counters
                .dropped_records
                .fetch_add(1, Ordering::Relaxed);
        }
        true
    }
}

/// The thread's loop: at each tick boundary the pending commands, then one tick, its sample
/// to the UI and the recorder (dropped, and counted, when their channels are full), then a
/// sleep until the next tick is due on an absolute schedule (so lateness does not
/// accumulate; more than 100 ms behind, after a suspend, the schedule restarts).
fn run_paced<L: Steppable>(haptic: &mut L, ends: &LoopEnds<L::Session>) {
    let period = Duration::from_secs_f64(1.0 / RATE_HZ);
    let mut epoch = Instant::now();
    let mut since_epoch: u32 = 0;
    let mut previous: Option<Instant> = None;
    while !ends.stopping() {
        let begun = Instant::now();
        loop {
            match ends.commands.try_recv() {
                Ok(c) => {
                    if let Some(r) = haptic.apply(c) {
                        ends.reply(r);
                    }
                }
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => return,
            }
        }
        let sample = Sample {
            period_us: previous.map(|p| (begun - p).as_secs_f32() * 1e6),
            ..haptic.step_sample()
        };
        previous = Some(begun);
        if !ends.publish(sample) {
            return;
        }
        since_epoch += 1;
        let due = epoch + period * since_epoch;
        let now = Instant::now();
        if due > now {
            std::thread::sleep(due - now);
        } else if now - due > Duration::from_millis(100) {
            epoch = now;
            since_epoch = 0;
        }
    }
}

/// How the app runs a loop: on its own thread in real time, or stepped in place (tests: no
/// thread, no clock). The planar app state and the spatial hand both hold one; a device
/// behind a link is a [`Backend::Thread`] of [`HapticLoop`](crate::planar::HapticLoop)'s commands too
/// ([`crate::remote::spawn`]).
pub enum Backend<L: Steppable> {
    /// On its own thread in real time.
    Thread(LoopThread<L::Session>),
    /// Here, one tick per [`Backend::step`].
    Stepped(Box<L>),
    /// Stopped ([`Backend::stop`]): commands are dropped, nothing ticks.
    Stopped,
}

impl<L: Steppable + fmt::Debug> fmt::Debug for Backend<L> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Backend::Thread(t) => f.debug_tuple("Thread").field(t).finish(),
            Backend::Stepped(l) => f.debug_tuple("Stepped").field(l).finish(),
            Backend::Stopped => f.write_str("Stopped"),
        }
    }
}

/// What became of a command given to a [`Backend`].
#[derive(Debug)]
pub enum Sent {
    /// Queued for the loop's thread; its reply, if any, comes through [`Backend::drain`].
    Queued,
    /// Applied at once by the stepped loop; its reply, if it has one.
    Applied(Option<Reply>),
    /// Dropped: the thread's channel was full (counted in
    /// [`LoopCounters::dropped_commands`]), or the loop is stopped.
    Dropped,
}

impl Sent {
    /// Whether the loop took the command (queued or applied).
    pub fn taken(&self) -> bool {
        !matches!(self, Sent::Dropped)
    }

    /// The reply of a stepped loop.
    pub fn reply(self) -> Option<Reply> {
        match self {
            Sent::Applied(reply) => reply,
            Sent::Queued | Sent::Dropped => None,
        }
    }
}

impl<L: Steppable> Backend<L> {
    /// `haptic` on its thread (`threaded`; every tick also to `record`) or stepped in place.
    pub fn start(haptic: L, threaded: bool, record: Option<RecordTx>) -> io::Result<Self> {
        Ok(if threaded {
            Backend::Thread(LoopThread::spawn(haptic, record)?)
        } else {
            Backend::Stepped(Box::new(haptic))
        })
    }

    /// Sends the command to the thread without waiting, or applies it to the stepped loop.
    pub fn command(&mut self, command: LoopCommand<L::Session>) -> Sent {
        match self {
            Backend::Thread(t) => {
                if t.send(command) {
                    Sent::Queued
                } else {
                    Sent::Dropped
                }
            }
            Backend::Stepped(l) => Sent::Applied(l.apply(command)),
            Backend::Stopped => Sent::Dropped,
        }
    }

    /// Runs `n` ticks of a stepped loop (none otherwise); their samples.
    pub fn step(&mut self, n: usize) -> Vec<Sample> {
        match self {
            Backend::Stepped(l) => (0..n).map(|_| l.step_sample()).collect(),
            Backend::Thread(_) | Backend::Stopped => Vec::new(),
        }
    }

    /// What the thread sent since the last call, without waiting: samples and replies
    /// (nothing for a stepped or stopped loop, whose replies come back at once).
    pub fn drain(&self) -> (Vec<Sample>, Vec<Reply>) {
        match self {
            Backend::Thread(t) => {
                let mut samples = Vec::new();
                t.drain_samples(|s| samples.push(s));
                (samples, t.drain_replies())
            }
            Backend::Stepped(_) | Backend::Stopped => (Vec::new(), Vec::new()),
        }
    }

    /// The stepped loop (tests).
    pub fn stepped(&self) -> Option<&L> {
        match self {
            Backend::Stepped(l) => Some(l),
            Backend::Thread(_) | Backend::Stopped => None,
        }
    }

    /// The thread's counters, when threaded.
    pub fn counters(&self) -> Option<&LoopCounters> {
        match self {
            Backend::Thread(t) => Some(t.counters()),
            Backend::Stepped(_) | Backend::Stopped => None,
        }
    }

    /// Whether the loop runs on its own thread.
    pub fn is_threaded(&self) -> bool {
        matches!(self, Backend::Thread(_))
    }

    /// Whether the loop is running: its thread is alive, or it is stepped in place.
    pub fn is_running(&self) -> bool {
        match self {
            Backend::Thread(t) => t.is_running(),
            Backend::Stepped(_) => true,
            Backend::Stopped => false,
        }
    }

    /// Stops the loop (joins its thread; the recorder's input closes with it).
    pub fn stop(&mut self) {
        *self = Backend::Stopped;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planar::{HapticLoop, START_HIP};
    use crate::test_scenes::thesis_2d;

    /// The thread ticks on its own and answers commands; dropping it stops it. Polled for up
    /// to 10 s of wall time (a loaded machine may be slow; nothing here is timed).
    #[test]
    fn loop_thread_ticks_and_answers() {
        let session = PlanarSession::new(thesis_2d()).expect("session");
        let haptic = HapticLoop::new(session, START_HIP).expect("loop");
        let thread = LoopThread::spawn(haptic, None).expect("spawn");
        assert!(thread.send(LoopCommand::HandTarget(Vec3::new(0.0, 0.105, 0.0))));
        let bad = FrictionMaterial {
            mu_dynamic: 0.9,
            ..FrictionMaterial::default()
        };
        assert!(thread.send(LoopCommand::SetMaterial(bad)));
        let waited = Instant::now();
        let (mut samples, mut replies) = (Vec::new(), Vec::new());
        while (samples.len() < 50 || replies.is_empty())
            && waited.elapsed() < Duration::from_secs(10)
        {
            thread.drain_samples(|s| samples.push(s));
            replies.extend(thread.drain_replies());
            std::thread::sleep(Duration::from_millis(5));
        }
        assert!(samples.len() >= 50, "{} samples", samples.len());
        assert!(samples.windows(2).all(|w| w[1].tick.t_s > w[0].tick.t_s));
        assert!(samples.iter().skip(1).all(|s| s.period_us.is_some()));
        assert!(
            samples
                .last()
                .is_some_and(|s| s.hand_target == Vec2::new(0.0, 0.105))
        );
        match replies.first() {
            Some(Reply::Material(Err(MaterialChangeError::Invalid(e)))) => {
                assert_eq!(e.field(), "mu_dynamic");
            }
            other => panic!("{other:?}"),
        }
        assert!(thread.is_running());
        assert!(thread.counters().ticks.load(Ordering::Relaxed) >= 50);
        drop(thread);
    }

    /// A stepped backend applies a command at once and answers it, a command the loop does
    /// not support included (nothing changes); a stopped one drops commands and runs no tick.
    #[test]
    fn a_stepped_backend_answers_every_command() {
        let session = PlanarSession::new(thesis_2d()).expect("session");
        let haptic = HapticLoop::new(session, START_HIP).expect("loop");
        let mut backend = Backend::start(haptic, false, None).expect("start");
        assert!(!backend.is_threaded() && backend.is_running());
        let sent = backend.command(LoopCommand::Mesh(None));
        assert!(matches!(
            sent,
            Sent::Applied(Some(Reply::Unsupported("a mesh")))
        ));
        let sent = backend.command(LoopCommand::HandTarget(Vec3::new(0.0, 0.105, 0.5)));
        assert!(matches!(sent, Sent::Applied(None)));
        assert_eq!(backend.step(3).len(), 3);
        // Each step is ten device ticks (10 kHz under a 1 kHz loop).
        assert_eq!(
            backend.stepped().map(HapticLoop::ticks),
            Some(3 * u64::from(crate::planar::TICKS_PER_STEP))
        );
        assert!(backend.counters().is_none());
        backend.stop();
        assert!(!backend.is_running());
        assert!(!backend.command(LoopCommand::ClearFaults).taken());
        assert!(backend.step(1).is_empty());
    }
}
