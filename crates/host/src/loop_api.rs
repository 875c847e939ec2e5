//! What the UI and a loop say to each other, whatever the loop: the [`LoopCommand`]s a loop
//! takes, the [`Reply`]s and [`Sample`]s it answers with, the counters it shares, and the
//! [`Steppable`] trait a loop implements. [`crate::backend`] runs a loop on its thread or steps
//! it in place; the loops are [`crate::planar`], [`crate::spatial`] and [`crate::remote`].

use std::fmt;
use std::sync::atomic::{AtomicBool, AtomicU64};

use device::safety::Faults;
use friction::FrictionMaterial;
use nurbs::{Vec2, Vec3};
use tracker::TriMesh;

use crate::deform::{DeformChangeError, DeformStatus};
use crate::error::{MaterialChangeError, MeshError};
use crate::planar_session::PlanarSession;
use crate::tick::Tick;
use crate::upload::PointsUpdate;

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
    /// Move the hand's target to `to` (m, device frame; a planar loop takes x and y), getting
    /// there `over_s` seconds from now at a steady speed: the time the pointer took to move
    /// there (the UI's frame interval), so the hand's motion does not depend on the frame
    /// rate ([`device::simulator::VirtualHand::glide`]); 0: as fast as the hand goes
    /// ([`LoopCommand::hand_to`]).
    HandTarget {
        /// Where the hand goes (m, device frame).
        to: Vec3,
        /// How long it takes to get there (s).
        over_s: f32,
    },
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

impl<S> LoopCommand<S> {
    /// Move the hand to `to` as fast as it goes.
    pub fn hand_to(to: Vec3) -> Self {
        LoopCommand::HandTarget { to, over_s: 0.0 }
    }

    /// What the command asks, as [`Reply::Unsupported`] names it.
    pub fn name(&self) -> &'static str {
        match self {
            LoopCommand::HandTarget { .. } => "the hand's target",
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

/// A loop [`LoopThread`](crate::backend::LoopThread) and [`Backend`](crate::backend::Backend) run: the planar [`HapticLoop`](crate::planar::HapticLoop), or the spatial hand
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
