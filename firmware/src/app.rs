//! The board-independent app: builds the controller on a validated scene exactly as the
//! host's `viewer sim --device` does (`viewer::sim::run_device`), and runs one tick against a
//! [`Board`]. The board binary and the QEMU binary share it, so the emulated run exercises the
//! code the board runs.

use device::controller::{Controller, ControllerError, TickOutput};
use device::protocol::{Frame, MAX_FRAME, Message, SceneStore};
use device::safety::SafetyConfig;
use device::spec::DeviceSpec;
use friction::FrictionMaterial;
use tracker::{Chain, ChainError, MAX_CHAIN_CURVES};

use crate::board::Board;

/// Why the app could not start.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AppError {
    /// The scene has no such object.
    NoObject(usize),
    /// The object is made of surfaces; the planar pantograph renders chains of curves.
    NotPlanar(usize),
    /// The object's curves do not form a chain (the store validated it, so unexpected).
    Chain(ChainError),
    /// The controller refused its setup (device, limits, material or calibration).
    Controller(ControllerError),
}

impl core::fmt::Display for AppError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
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

/// The app: the controller of the default pantograph with one object of a validated scene.
#[derive(Debug)]
pub struct App<'s> {
    controller: Controller<Chain<'s>>,
    passivity_control: bool,
    seq: u16,
}

impl<'s> App<'s> {
    /// The default [`DeviceSpec`] at `period_s` with object `object` of `store` loaded, the
    /// safety layer's ramp-in over `ramp_time_s` and its other limits the defaults. As the
    /// host's simulator does, a material stiffer than the device renders passively is loaded
    /// with the passivity controller on ([`App::passivity_control`]).
    pub fn new<const K: usize, const C: usize, const S: usize>(
        store: &'s SceneStore<K, C, S>,
        object: usize,
        period_s: f32,
        ramp_time_s: f32,
    ) -> Result<Self, AppError> {
        let chain = chain(store, object)?;
        let material = store.material(object).ok_or(AppError::NoObject(object))?;
        let mut app = Self::without_scene(period_s, ramp_time_s)?;
        app.load_chain(chain, material)?;
        Ok(app)
    }

    /// The controller of [`App::new`] with no scene loaded (no force until one is, see
    /// [`App::load`]).
    pub fn without_scene(period_s: f32, ramp_time_s: f32) -> Result<Self, AppError> {
        let safety = SafetyConfig {
            period_s,
            ramp_time_s,
            ..SafetyConfig::default()
        };
        let controller =
            Controller::new(DeviceSpec::default(), safety).map_err(AppError::Controller)?;
        Ok(App {
            controller,
            passivity_control: false,
            seq: 0,
        })
    }

    /// Loads object `object` of `store` in place of the current scene (at a tick boundary:
    /// the renderer restarts on it and the force ramps in), as [`App::new`] does. On error
    /// the current scene stays loaded.
    pub fn load<const K: usize, const C: usize, const S: usize>(
        &mut self,
        store: &'s SceneStore<K, C, S>,
        object: usize,
    ) -> Result<(), AppError> {
        let chain = chain(store, object)?;
        let material = store.material(object).ok_or(AppError::NoObject(object))?;
        self.load_chain(chain, material)
    }

    /// Replaces the loaded object's material, with the passivity controller on when the
    /// material needs it (as [`App::load`]). On error the material stays.
    pub fn set_material(&mut self, material: FrictionMaterial) -> Result<(), AppError> {
        let passivity_control = match self.controller.set_material(material, false) {
            Ok(()) => false,
            Err(ControllerError::Passivity(_)) => {
                self.controller
                    .set_material(material, true)
                    .map_err(AppError::Controller)?;
                true
            }
            Err(e) => return Err(AppError::Controller(e)),
        };
        self.passivity_control = passivity_control;
        Ok(())
    }

    /// The same app for views of another lifetime, without a scene (calibration, safety
    /// state, forces and heartbeat carried over; see `Controller::rebind`).
    pub fn rebind<'t>(self) -> App<'t> {
        App {
            controller: self.controller.rebind(),
            passivity_control: false,
            seq: self.seq,
        }
    }

    fn load_chain(&mut self, chain: Chain<'s>, material: FrictionMaterial) -> Result<(), AppError> {
        let controller = &mut self.controller;
        let passivity_control = match controller.load_scene(chain, material, false) {
            Ok(()) => false,
            Err(ControllerError::Passivity(_)) => {
                controller
                    .load_scene(chain, material, true)
                    .map_err(AppError::Controller)?;
                true
            }
            Err(e) => return Err(AppError::Controller(e)),
        };
        self.passivity_control = passivity_control;
        Ok(())
    }

    /// Whether the scene runs with the passivity controller on.
    pub fn passivity_control(&self) -> bool {
        self.passivity_control
    }

    /// The controller.
    pub fn controller(&self) -> &Controller<Chain<'s>> {
        &self.controller
    }

    /// The controller (for commands the link delivers: calibration, forces, faults).
    pub fn controller_mut(&mut self) -> &mut Controller<Chain<'s>> {
        &mut self.controller
    }

    /// Runs the acquisition the controller waits for, if any (the global closest-point search
    /// after a scene load; see `device::controller`, "Acquisition is not the tick's"): call it
    /// between ticks, never inside one. `true` when it started the renderer.
    pub fn acquire(&mut self) -> bool {
        self.controller.acquire_now()
    }

    /// One haptic tick: encoders and clock from the board, [`Controller::tick`] (bracketed by
    /// [`Board::around_tick`]), the latched faults, currents and driver enable to the board,
    /// the telemetry frame to the link when the board wants one ([`Board::wants_frame`]; the
    /// frame's sequence number counts the frames built).
    pub fn tick<B: Board>(&mut self, board: &mut B) -> TickOutput {
        let counts = board.encoder_counts();
        let now_us = board.now_us();
        let controller = &mut self.controller;
        let mut out = board.around_tick(|| controller.tick(counts, now_us));
        board.set_faults(out.telemetry.faults);
        board.set_driver_enabled(self.controller.forces_enabled());
        board.set_motor_currents(out.currents_a);
        if let Some(us) = board.last_tick_us() {
            out.telemetry.tick_us = us;
        }
        if !board.wants_frame() {
            return out;
        }
        let frame = Frame {
            seq: self.seq,
            message: Message::Telemetry(out.telemetry),
        };
        self.seq = self.seq.wrapping_add(1);
        let mut bytes = [0u8; MAX_FRAME];
        let n = frame.encode(&mut bytes);
        board.link_send(bytes.get(..n).unwrap_or(&bytes));
        out
    }
}

/// Object `object` of `store` as a chain of planar curves: the object [`App::new`] and
/// [`App::load`] give the controller (the same views for the same store, so a task that runs
/// the acquisition on its own copy searches the controller's object).
pub fn chain<'s, const K: usize, const C: usize, const S: usize>(
    store: &'s SceneStore<K, C, S>,
    object: usize,
) -> Result<Chain<'s>, AppError> {
    let n = store
        .patch_count(object)
        .ok_or(AppError::NoObject(object))?;
    let first = store.curve(object, 0).ok_or(AppError::NotPlanar(object))?;
    let mut curves = [first; MAX_CHAIN_CURVES];
    for (p, c) in curves.iter_mut().enumerate().take(n).skip(1) {
        *c = store.curve(object, p).ok_or(AppError::NotPlanar(object))?;
    }
    let given = curves
        .get(..n)
        .ok_or(AppError::Chain(ChainError::TooManyCurves { count: n }))?;
    Chain::new(given).map_err(AppError::Chain)
}
