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
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, Sender, SyncSender, TryRecvError, TrySendError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

pub use crate::loop_api::{
    COMMAND_CAPACITY, LinkEvent, LoopCommand, LoopCounters, RATE_HZ, RECORD_CAPACITY, Reply,
    Sample, Steppable, TELEMETRY_CAPACITY, raise_priority,
};
use crate::planar_session::PlanarSession;
use crate::runlog::RecordTx;
pub use crate::upload::PointsUpdate;

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

    /// Sends a command without waiting; a full channel, or a thread that ended, drops it
    /// (counted) and returns false.
    pub fn send(&self, command: LoopCommand<S>) -> bool {
        self.offer(command).taken()
    }

    /// Sends a command without waiting: [`Sent::Queued`], or why it was dropped (counted):
    /// [`Sent::Dropped`] for a full channel, [`Sent::Stopped`] for a thread that ended (a
    /// device's link lost).
    pub fn offer(&self, command: LoopCommand<S>) -> Sent {
        let refused = match self.commands.try_send(command) {
            Ok(()) => return Sent::Queued,
            Err(TrySendError::Full(_)) => Sent::Dropped,
            Err(TrySendError::Disconnected(_)) => Sent::Stopped,
        };
        self.counters
            .dropped_commands
            .fetch_add(1, Ordering::Relaxed);
        refused
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
    /// [`LoopCounters::dropped_commands`]).
    Dropped,
    /// Dropped: the loop is not running (stopped, or its thread ended: a device's link lost).
    Stopped,
}

impl Sent {
    /// Why the loop did not take the command (`None` when it did), for a message: "its queue
    /// is full", or "it is not running".
    pub fn refusal(&self) -> Option<&'static str> {
        match self {
            Sent::Queued | Sent::Applied(_) => None,
            Sent::Dropped => Some("its queue is full"),
            Sent::Stopped => {
                Some("it is not running (the device's link was lost, or the loop stopped)")
            }
        }
    }

    /// Whether the loop took the command (queued or applied).
    pub fn taken(&self) -> bool {
        !matches!(self, Sent::Dropped | Sent::Stopped)
    }

    /// The reply of a stepped loop.
    pub fn reply(self) -> Option<Reply> {
        match self {
            Sent::Applied(reply) => reply,
            Sent::Queued | Sent::Dropped | Sent::Stopped => None,
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
            Backend::Thread(t) => t.offer(command),
            Backend::Stepped(l) => Sent::Applied(l.apply(command)),
            Backend::Stopped => Sent::Stopped,
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
    use crate::error::MaterialChangeError;
    use crate::planar::{HapticLoop, START_HIP};
    use crate::test_scenes::thesis_2d;
    use friction::FrictionMaterial;
    use nurbs::{Vec2, Vec3};

    /// The thread ticks on its own and answers commands; dropping it stops it. Polled for up
    /// to 10 s of wall time (a loaded machine may be slow; nothing here is timed).
    #[test]
    fn loop_thread_ticks_and_answers() {
        let session = PlanarSession::new(thesis_2d()).expect("session");
        let haptic = HapticLoop::new(session, START_HIP).expect("loop");
        let thread = LoopThread::spawn(haptic, None).expect("spawn");
        assert!(thread.send(LoopCommand::hand_to(Vec3::new(0.0, 0.105, 0.0))));
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
        let sent = backend.command(LoopCommand::hand_to(Vec3::new(0.0, 0.105, 0.5)));
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
