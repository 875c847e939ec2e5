//! The board's protocol task, its lowest priority: host frames through the session (whose
//! receiver validates an upload, or a control-point update, into the board's one store),
//! commands and the committed store to the tick, replies to USB; and the acquisition jobs the
//! tick hands out (the search on the tick's own chain, lent). The validation builds a chain
//! and the search is deep, so they run in one task, one after the other, and their stack
//! frames never add up.
//!
//! The tick and this task share lock-free single-producer single-consumer queues
//! (`heapless::spsc`, the lengths below) and [`TickShared`]'s atomics, nothing else, so nothing
//! here can delay a tick.

use core::sync::atomic::{AtomicU8, AtomicU32, Ordering};

use heapless::spsc::{Consumer, Producer};
use protocol::device_side::session::{DeviceCommand, DeviceSession, DeviceState, Event};
use protocol::{ErrorCode, MAX_FRAME, Message, SceneStore};

use crate::app::{AcquisitionJob, JobDone, Slot, run_job};
use crate::handover::{Incoming, Validator};

/// One USB HID report: one protocol frame, zero-padded.
pub type Report = [u8; MAX_FRAME];

/// Queue sizes (heapless' spsc holds one less than its size): commands to the tick.
pub const COMMANDS: usize = 8;
/// Telemetry frames from the tick to USB.
pub const FRAMES: usize = 4;
/// Host reports waiting for the protocol task.
pub const REPORTS: usize = 4;
/// The protocol task's replies waiting for USB.
pub const REPLIES: usize = 4;
/// The committed store to the tick and back: one store, so neither queue overflows.
pub const STORES: usize = 2;
/// Acquisition jobs and their results: one at a time.
pub const JOBS: usize = 2;

/// What the tick and the protocol task share besides the queues.
#[derive(Debug)]
pub struct TickShared {
    /// The tick's [`DeviceState`] for the status replies ([`DeviceState::to_word`]).
    status: AtomicU32,
    /// What the committed store waiting for the tick is for ([`Incoming`]: 1 a scene, 2 a
    /// control-point update; 0 none): set here before it is queued, cleared by the tick once
    /// it took it in or refused it. No other upload or update is validated meanwhile (the
    /// store is with the tick).
    pending: AtomicU8,
    /// Why the tick refused the last command (an [`ErrorCode`], 0 for none), for the next
    /// status.
    command_error: AtomicU8,
}

impl TickShared {
    /// Nothing pending, no error, the state all zero (uncalibrated, forces off, no fault).
    pub const fn new() -> Self {
        TickShared {
            status: AtomicU32::new(0),
            pending: AtomicU8::new(PENDING_NONE),
            command_error: AtomicU8::new(0),
        }
    }

    /// The tick's state after its tick (its software version is not shared).
    pub fn set_state(&self, state: &DeviceState) {
        self.status.store(state.to_word(), Ordering::Release);
    }

    /// What the store waiting for the tick is for, if one does (read before taking it from
    /// the queue: the protocol task sets it before it queues the store).
    pub fn pending(&self) -> Option<Incoming> {
        match self.pending.load(Ordering::Acquire) {
            PENDING_SCENE => Some(Incoming::Scene),
            PENDING_POINTS => Some(Incoming::Points),
            _ => None,
        }
    }

    /// The tick took the pending store in, or refused it.
    pub fn commit_done(&self) {
        self.pending.store(PENDING_NONE, Ordering::Release);
    }

    /// The tick refused a command.
    pub fn command_refused(&self, code: ErrorCode) {
        self.command_error.store(code as u8, Ordering::Release);
    }
}

const PENDING_NONE: u8 = 0;
const PENDING_SCENE: u8 = 1;
const PENDING_POINTS: u8 = 2;

impl Default for TickShared {
    fn default() -> Self {
        Self::new()
    }
}

/// What [`Protocol::step`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    /// Nothing was waiting.
    Idle,
    /// Ran an acquisition job.
    Acquired,
    /// Handled a host report; its replies are queued for USB.
    Received,
}

/// The protocol task's state: a session with scene capacity `N` validating into the store
/// `T`; the tick's chains have `K` knots and `C` points.
pub struct Protocol<const N: usize, T: 'static, const K: usize, const C: usize> {
    /// The device side of the link.
    pub session: &'static mut DeviceSession<N>,
    /// What the tick shares with this task.
    pub shared: &'static TickShared,
    /// The store the next commit is validated into; `None` while it is with the tick.
    pub store: Option<&'static mut T>,
    /// Host reports from USB.
    pub reports: Consumer<'static, Report, REPORTS>,
    /// Replies to USB.
    pub replies: Producer<'static, Message, REPLIES>,
    /// Commands to the tick.
    pub commands: Producer<'static, DeviceCommand, COMMANDS>,
    /// The committed store to the tick.
    pub commits: Producer<'static, &'static mut T, STORES>,
    /// The store back from the tick.
    pub freed: Consumer<'static, &'static mut T, STORES>,
    /// Acquisition jobs from the tick.
    pub jobs: Consumer<'static, AcquisitionJob<Slot<'static, K, C>>, JOBS>,
    /// Their results to the tick.
    pub results: Producer<'static, JobDone<Slot<'static, K, C>>, JOBS>,
}

impl<const N: usize, T, const K: usize, const C: usize> core::fmt::Debug for Protocol<N, T, K, C> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Protocol")
            .field("store_here", &self.store.is_some())
            .finish_non_exhaustive()
    }
}

impl<const N: usize, const K: usize, const C: usize, const S: usize>
    Protocol<N, SceneStore<K, C, S>, K, C>
{
    /// Handles what is waiting: an acquisition job first, else one host report.
    pub fn step(&mut self) -> Step {
        if let Some(job) = self.jobs.dequeue() {
            // Room is certain: one job at a time.
            let _ = self.results.enqueue(run_job(job));
            return Step::Acquired;
        }
        if let Some(report) = self.reports.dequeue() {
            self.receive(&report);
            return Step::Received;
        }
        Step::Idle
    }

    /// Handles one host report. Not inlined (nor is [`run_job`]), so that the task's own
    /// frame stays small and the big frames (the validation's, the search's) exist only while
    /// they run.
    #[inline(never)]
    fn receive(&mut self, bytes: &[u8]) {
        if self.store.is_none() {
            self.store = self.freed.dequeue();
        }
        // While the previous commit or update is not taken in (the store is with the tick, or
        // the tick is about to take it), a commit or an update's apply frame is refused as
        // busy: the upload stays, its commit may be sent again.
        let pending = self.shared.pending().is_some();
        let mut validate = Validator::new(&mut self.store, pending);
        if let Some(code) = ErrorCode::from_u8(self.shared.command_error.swap(0, Ordering::AcqRel))
        {
            self.session.note_error(code);
        }
        let state = DeviceState::from_word(
            crate::software_version(),
            self.shared.status.load(Ordering::Acquire),
        );
        let replies = &mut self.replies;
        let event = self
            .session
            .handle(bytes, &mut validate, state, &mut |m: &Message| {
                // Dropped when the replies queue is full (the host sends faster than it reads):
                // it sees the missing acks.
                let _ = replies.enqueue(*m);
            });
        let incoming = match event {
            Event::SceneCommitted => Some(PENDING_SCENE),
            // The board renders object 0: another object's points change nothing it renders
            // (the receiver's scene has them, for the next validation).
            Event::ScenePointsUpdated { object: 0 } => Some(PENDING_POINTS),
            _ => None,
        };
        // The queue has room for the store, so it is always ready here.
        if let Some(kind) = incoming
            && self.commits.ready()
            && let Some(store) = self.store.take()
        {
            self.shared.pending.store(kind, Ordering::Release);
            let _ = self.commits.enqueue(store);
        }
        match event {
            Event::SceneCommitted | Event::ScenePointsUpdated { .. } => {}
            // A board's session refuses hand targets (no virtual hand here).
            Event::HandTarget(_) | Event::None => {}
            Event::DeviceCommand(command) => {
                if self.commands.enqueue(command).is_err() {
                    // The tick takes every command each tick; a full queue means a flood.
                    self.session.note_error(ErrorCode::UnexpectedMessage);
                }
            }
        }
    }
}
