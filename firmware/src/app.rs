//! The board-independent app: builds the controller on a validated scene exactly as the
//! host's `viewer sim --device` does (`host::closed_loop::run_device`), and runs one tick against a
//! [`Board`]. The board binary and the QEMU binary share it, so the emulated run exercises the
//! code the board runs. The board's acquisition job ([`AcquisitionJob`], [`run_job`]), which
//! runs the same search as [`App::acquire`] in another task, is here too.
//!
//! The app's object is a chain slot it is given once (`&'a mut Chain`: a board's static, the
//! QEMU binary's `main` frame) and never copies: a scene is rebuilt into the slot in place
//! from the link's store ([`App::load`]), a control-point update moves it in place
//! ([`App::reshape`]), and the acquisition task borrows it whole while the renderer waits
//! for it ([`App::lend_job`]). No chain is built on any stack.

use device::controller::{
    Acquisition, AcquisitionRequest, Controller, ControllerError, TickOutput, acquire,
};
use device::safety::SafetyConfig;
use device::spec::DeviceSpec;
use device::telemetry::TelemetryDecimator;
use protocol::device_side::Numbering;
use protocol::device_side::session::DeviceCommand;
use protocol::{ErrorCode, MAX_FRAME, Message, SceneFault, SceneStore, WireSceneError};
use tracker::{Chain, ChainError, ChainTracker};

use crate::board::Board;

/// Why the app could not start.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AppError {
    /// The object is lent to the acquisition task: a scene cannot be loaded or reshaped until
    /// it is back (a board does not ask meanwhile).
    Lent,
    /// The scene has no such object.
    NoObject(usize),
    /// The object is made of surfaces; the planar pantograph renders chains of curves.
    NotPlanar(usize),
    /// The object's curves do not form a chain (the store validated it, so unexpected).
    Chain(ChainError),
    /// The controller refused its setup (device, limits, material or calibration).
    Controller(ControllerError),
}

impl AppError {
    /// The code a device reports for a scene or an update it accepted on the link but could
    /// not give the controller (the status's `last_error`): the controller's topology check
    /// ([`ErrorCode::TopologyChanged`]), no scene to reshape ([`ErrorCode::NoActiveScene`]),
    /// a material beyond the device ([`ErrorCode::BadMaterial`]), anything else as a scene
    /// the device cannot render ([`ErrorCode::SceneTopology`]).
    pub fn code(&self) -> ErrorCode {
        match self {
            AppError::Controller(ControllerError::Topology) => ErrorCode::TopologyChanged,
            AppError::Controller(ControllerError::NoScene) => ErrorCode::NoActiveScene,
            AppError::Controller(
                ControllerError::Passivity(_) | ControllerError::BeyondDevice(_),
            ) => ErrorCode::BadMaterial,
            _ => ErrorCode::SceneTopology,
        }
    }
}

impl core::fmt::Display for AppError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            AppError::Lent => write!(f, "the object is out with the acquisition task"),
            AppError::NoObject(o) => write!(f, "the scene has no object {o}"),
            AppError::NotPlanar(o) => {
                write!(
                    f,
                    "object {o} is a surface; the pantograph renders planar curves"
                )
            }
            AppError::Chain(e) => write!(f, "chain: {e}"),
            AppError::Controller(e) => write!(f, "controller: {e}"),
        }
    }
}

/// The object of an [`App`]: its chain slot ([`tracker::Chain`] of `K` knots and `C` control
/// points, a store's capacities: any object of a `SceneStore<K, C, _>` fits).
pub type Slot<'a, const K: usize, const C: usize> = &'a mut Chain<K, C>;

/// The app: the controller of the default pantograph with one object of a validated scene,
/// in its chain slot.
#[derive(Debug)]
pub struct App<'a, const K: usize, const C: usize> {
    controller: Controller<Slot<'a, K, C>>,
    /// The slot while the controller has no scene in it.
    spare: Option<Slot<'a, K, C>>,
    /// The link's sequence numbers, telemetry and replies apart.
    numbering: Numbering,
    /// The tick's output, written in place by every tick (`Controller::tick_into`).
    out: TickOutput,
    /// The ticks' telemetry folded into one frame per millisecond.
    decimator: TelemetryDecimator,
}

/// The app before its first scene: the controller without a scene, its chain slot and the
/// link's sequence numbers.
#[derive(Debug)]
pub struct Parked<'a, const K: usize, const C: usize> {
    controller: Controller<Slot<'a, K, C>>,
    slot: Slot<'a, K, C>,
    numbering: Numbering,
    decimator: TelemetryDecimator,
}

impl<'a, const K: usize, const C: usize> Parked<'a, K, C> {
    /// The default [`DeviceSpec`] at `period_s`, the safety layer's ramp-in over `ramp_time_s`
    /// and its other limits the defaults; no scene; its object in `slot`.
    pub fn new(slot: Slot<'a, K, C>, period_s: f32, ramp_time_s: f32) -> Result<Self, AppError> {
        Self::with_safety(
            slot,
            SafetyConfig {
                period_s,
                ramp_time_s,
                ..SafetyConfig::default()
            },
        )
    }

    /// The default [`DeviceSpec`] with the safety limits `safety` (its period is the tick's);
    /// no scene; its object in `slot`. Telemetry goes out once per millisecond
    /// ([`TelemetryDecimator::for_period_s`] of the period).
    pub fn with_safety(slot: Slot<'a, K, C>, safety: SafetyConfig) -> Result<Self, AppError> {
        let controller =
            Controller::new(DeviceSpec::default(), safety).map_err(AppError::Controller)?;
        Ok(Parked {
            controller,
            slot,
            numbering: Numbering::default(),
            decimator: TelemetryDecimator::for_period_s(safety.period_s),
        })
    }

    /// The app with object `object` of `store` loaded. As the host's simulator does, a
    /// material stiffer than the device renders passively is loaded with the passivity
    /// controller on ([`App::passivity_control`]). On error the app runs without a scene (no
    /// force) and the error says why.
    pub fn load<const S: usize>(
        self,
        store: &SceneStore<K, C, S>,
        object: usize,
    ) -> (App<'a, K, C>, Result<(), AppError>) {
        let mut app = self.unloaded();
        let loaded = app.load(store, object);
        (app, loaded)
    }

    /// The app with no scene loaded (no force until one is, see [`App::load`]).
    pub fn unloaded(self) -> App<'a, K, C> {
        App {
            controller: self.controller,
            spare: Some(self.slot),
            numbering: self.numbering,
            out: TickOutput::IDLE,
            decimator: self.decimator,
        }
    }
}

impl<'a, const K: usize, const C: usize> App<'a, K, C> {
    /// The default [`DeviceSpec`] at `period_s` with object `object` of `store` loaded into
    /// `slot`, the safety layer's ramp-in over `ramp_time_s` and its other limits the
    /// defaults (see [`Parked::load`]).
    pub fn new<const S: usize>(
        slot: Slot<'a, K, C>,
        store: &SceneStore<K, C, S>,
        object: usize,
        period_s: f32,
        ramp_time_s: f32,
    ) -> Result<Self, AppError> {
        let (app, loaded) = Parked::new(slot, period_s, ramp_time_s)?.load(store, object);
        loaded.map(|()| app)
    }

    /// Loads object `object` of `store` in place of the current scene (at a tick boundary:
    /// the renderer waits for its acquisition, then the force ramps in), the passivity
    /// controller on when the material needs it. The chain is rebuilt in the app's slot
    /// ([`SceneStore::rebuild_chain`]), so the scene before is gone whatever happens: a
    /// material the device refuses leaves it loaded (checked first), anything else (an object
    /// the link's validation would have refused) leaves no scene. Refused while the object is
    /// lent ([`AppError::Lent`]).
    pub fn load<const S: usize>(
        &mut self,
        store: &SceneStore<K, C, S>,
        object: usize,
    ) -> Result<(), AppError> {
        let material = store.material(object).ok_or(AppError::NoObject(object))?;
        self.controller
            .accepts_material(&material, true)
            .map_err(AppError::Controller)?;
        let slot = match self.spare.take() {
            Some(slot) => slot,
            None => self.controller.unload_scene().ok_or(AppError::Lent)?,
        };
        if let Err(e) = store.rebuild_chain(object, slot) {
            self.spare = Some(slot);
            return Err(app_error(e, object));
        }
        match self.controller.try_load_scene(slot, material, true) {
            Ok(_) => Ok(()),
            Err((slot, e)) => {
                self.spare = Some(slot);
                Err(AppError::Controller(e))
            }
        }
    }

    /// Moves the controller's object onto object `object` of `store`: the same scene with
    /// control points moved (a control-point update, validated with its topology against the
    /// scene before by the link, `protocol::SceneStore::decode_reshaped`), at a tick
    /// boundary. The chain is moved in place ([`Controller::reshape_object`] with
    /// [`Chain::reshape`]: no second chain built, four evaluations a curve, the new points
    /// copied into the chain) and the renderer carries on, on the new shape (no acquisition,
    /// no ramp-in); the store is not borrowed after. On error (no scene loaded, another
    /// topology) nothing changes.
    pub fn reshape<const S: usize>(
        &mut self,
        store: &SceneStore<K, C, S>,
        object: usize,
    ) -> Result<(), AppError> {
        let controller = &mut self.controller;
        store
            .with_curves(object, |curves| {
                controller.reshape_object(|chain| chain.reshape(curves))
            })
            .map_err(|e| app_error(e, object))?
            .map_err(AppError::Controller)
    }

    /// Applies a command of the link ([`protocol::device_side::session::DeviceCommand::apply`]): calibration on
    /// `home_counts`, a material with the passivity controller on where it needs it (as
    /// [`App::load`]). The error is the code for the status's `last_error`.
    pub fn apply(
        &mut self,
        command: DeviceCommand,
        home_counts: [i32; 2],
    ) -> Result<(), ErrorCode> {
        command.apply(&mut self.controller, home_counts, true)
    }

    /// The acquisition job for the search the renderer waits for, if it waits for one: the
    /// object itself, lent ([`Controller::lend_for_acquisition`]; the tick renders no force
    /// until [`App::job_done`] gives it back). `None` while a job is out.
    pub fn lend_job(&mut self) -> Option<AcquisitionJob<Slot<'a, K, C>>> {
        self.controller
            .lend_for_acquisition()
            .map(|(object, request)| AcquisitionJob { object, request })
    }

    /// A lent job is back: the object returns to the controller and the renderer starts
    /// from the search's result (when it is still the scene's, see
    /// [`Controller::return_from_acquisition`]); `true` when it started.
    pub fn job_done(&mut self, done: JobDone<Slot<'a, K, C>>) -> bool {
        match self
            .controller
            .return_from_acquisition(done.object, done.acquisition)
        {
            Ok(started) => started,
            Err(slot) => {
                self.spare = Some(slot);
                false
            }
        }
    }

    /// Whether the object is out with an acquisition job.
    pub fn job_out(&self) -> bool {
        self.controller.object_lent()
    }

    /// Sends `message` to the host as the app's next frame of its kind (telemetry and
    /// replies are numbered apart, [`Numbering`]).
    pub fn send<B: Board>(&mut self, board: &mut B, message: &Message) {
        let frame = self.numbering.frame(message);
        let mut bytes = [0u8; MAX_FRAME];
        let n = frame.encode(&mut bytes);
        board.link_send(bytes.get(..n).unwrap_or(&bytes));
    }

    /// Whether the scene runs with the passivity controller on.
    pub fn passivity_control(&self) -> bool {
        self.controller.passivity_control()
    }

    /// The controller.
    pub fn controller(&self) -> &Controller<Slot<'a, K, C>> {
        &self.controller
    }

    /// The controller (for commands the link delivers: calibration, forces, faults).
    pub fn controller_mut(&mut self) -> &mut Controller<Slot<'a, K, C>> {
        &mut self.controller
    }

    /// Runs the acquisition the controller waits for, if any (the global closest-point search
    /// after a scene load; see `device::controller`, "Acquisition is not the tick's"): call it
    /// between ticks, never inside one. `true` when it started the renderer.
    pub fn acquire(&mut self) -> bool {
        self.controller.acquire_now()
    }

    /// One haptic tick: encoders and clock from the board, [`Controller::tick_into`] on the
    /// app's own output (bracketed by [`Board::around_tick`]), the latched faults, currents
    /// and driver enable to the board, then the tick's telemetry into the decimator, which
    /// sends the window's frame to the link once per millisecond (see `device::telemetry`).
    /// Returns the tick's output (its own telemetry frame, not the decimated one).
    pub fn tick<B: Board>(&mut self, board: &mut B) -> &TickOutput {
        let counts = board.encoder_counts();
        let now_us = board.now_us();
        let (controller, out) = (&mut self.controller, &mut self.out);
        board.around_tick(|| controller_tick(controller, counts, now_us, out));
        board.set_faults(self.out.telemetry.faults);
        board.set_driver_enabled(self.controller.forces_enabled());
        board.set_motor_currents(self.out.currents_a);
        if let Some(us) = board.last_tick_us() {
            self.out.telemetry.tick_us = us;
        }
        if let Some(frame) = self.decimator.push(&self.out.telemetry) {
            let message = Message::Telemetry(*frame);
            self.send(board, &message);
        }
        &self.out
    }

    /// Ticks per telemetry frame.
    pub fn ticks_per_frame(&self) -> u32 {
        self.decimator.ticks_per_frame()
    }
}

/// [`Controller::tick_into`], inlined into [`App::tick`] (its one caller, as LTO would anyway)
/// unless the feature `tick-not-inlined` asks for an ordinary call: the QEMU build that
/// measures the tick as a function of its own, so that its budget is shown to hold without
/// LTO's inlining.
#[cfg_attr(feature = "tick-not-inlined", inline(never))]
#[cfg_attr(not(feature = "tick-not-inlined"), inline(always))]
fn controller_tick<const K: usize, const C: usize>(
    controller: &mut Controller<Slot<'_, K, C>>,
    counts: [i32; 2],
    now_us: u64,
    out: &mut TickOutput,
) {
    controller.tick_into(counts, now_us, out);
}

/// What a store's refusal to give object `object` as a chain means to the app.
fn app_error(e: WireSceneError, object: usize) -> AppError {
    match e.fault {
        SceneFault::Chain(e) => AppError::Chain(e),
        SceneFault::MixedKinds => AppError::NotPlanar(object),
        _ => AppError::NoObject(object),
    }
}

/// The result of the global closest-point search on a chain, for
/// `Controller::complete_acquisition`.
pub type ChainAcquisition = Acquisition<ChainTracker>;

/// What a board's tick asks its acquisition task for: the global closest-point search on the
/// object, from the request's HIP. Made only by [`App::lend_job`], with the object itself (the
/// tick has none until the job's [`JobDone`] comes back).
#[derive(Debug)]
pub struct AcquisitionJob<O> {
    object: O,
    request: AcquisitionRequest,
}

/// A finished [`AcquisitionJob`]: its object and the search's result, for [`App::job_done`].
#[derive(Debug)]
pub struct JobDone<O> {
    object: O,
    acquisition: Option<ChainAcquisition>,
}

impl<O> AcquisitionJob<O> {
    /// The job not run (it could not be sent): its object, back to [`App::job_done`].
    pub fn refused(self) -> JobDone<O> {
        JobDone {
            object: self.object,
            acquisition: None,
        }
    }
}

/// Runs one job: the global search on the job's object. Not inlined, so that its frame (the
/// search) exists only while it runs.
#[inline(never)]
pub fn run_job<const K: usize, const C: usize>(
    job: AcquisitionJob<Slot<'_, K, C>>,
) -> JobDone<Slot<'_, K, C>> {
    let acquisition = acquire(&job.object, job.request);
    JobDone {
        object: job.object,
        acquisition: Some(acquisition),
    }
}
