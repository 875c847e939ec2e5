//! One tick of the haptic loop on the host, the step every host loop runs: [`render_tick`]
//! (the friction renderer on a prescribed HIP: `viewer sim`, the app's spatial hand) and
//! [`device_tick`] (the device's whole `Controller` on the simulated pantograph: `viewer sim
//! --device`, the app's planar loop), the controller's setup they share
//! ([`device_controller`]), and the [`Tick`] record both produce.

use device::controller::{Controller, TickOutput};
use device::safety::SafetyConfig;
use device::simulator::SimulatedPantograph;
use device::spec::DeviceSpec;
use friction::{FrictionMaterial, FrictionOutput, FrictionRenderer, Mode, SwitchCause};
use nurbs::{Point, Vec2, Vec3};
use protocol::Telemetry;
use tracker::{Chain, Feature, Object as TrackedObject};

use crate::error::SimError;

/// What one tick of the pipeline produced. Vectors are in the device frame, `z = 0` in a
/// planar run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tick {
    /// Time (s).
    pub t_s: f64,
    /// HIP position (m).
    pub hip: Vec3,
    /// HIP velocity fed to the renderer (m/s): backward difference of the sampled HIP.
    pub hip_velocity: Vec3,
    /// Closest point (CP) on the object (m).
    pub cp: Vec3,
    /// God-object (GO) (m): the point of application of the force; equal to the CP except
    /// while stuck or in transition.
    pub go: Vec3,
    /// The active patch (the CP tracker's patch) while in contact, `None` when free.
    pub patch: Option<usize>,
    /// The active feature of the CP tracker (patch, vertex, edge or corner).
    pub feature: Feature,
    /// Friction mode after the tick.
    pub mode: Mode,
    /// Why the mode last changed (this tick or earlier).
    pub cause: SwitchCause,
    /// Signed penetration depth at the CP (m): positive inside, negative outside. The CSV's
    /// `depth_m` is this clamped at 0.
    pub depth_m: f32,
    /// Normal force (N), ≥ 0.
    pub normal_force_n: f32,
    /// Friction force (N), signed along [`Tick::tangent`].
    pub friction_force_n: f32,
    /// Friction coefficient in use (0 when free).
    pub mu: f32,
    /// The CP tracker's projection error Ψ (thesis eq. 2.8; `[Ψ_u]` on curves).
    pub psi: f32,
    /// Unit normal at the point of application.
    pub normal: Vec3,
    /// Unit tangent at the point of application, the sign reference of
    /// [`Tick::friction_force_n`]: along increasing `u` on curves; on surfaces along `u` or
    /// `v`, whichever the friction lies closer to ([`FrictionOutput::tangent`]).
    pub tangent: Vec3,
    /// Friction force vector (N).
    pub friction: Vec3,
    /// Total force on the HIP (N): normal plus friction.
    pub force: Vec3,
    /// Patch of the CP tracker (also when free).
    pub cp_patch: usize,
    /// First parameter (`u`) of the CP on [`Tick::cp_patch`].
    pub cp_param: f32,
    /// Parameters of the CP (`[u, 0]` on curves).
    pub cp_params: [f32; 2],
    /// Patch of the GO.
    pub go_patch: usize,
    /// First parameter (`u`) of the GO on [`Tick::go_patch`].
    pub go_param: f32,
    /// Parameters of the GO (`[u, 0]` on curves).
    pub go_params: [f32; 2],
    /// What the device did this tick, in a [`run_device`](crate::closed_loop::run_device) run; `None` in a prescribed-HIP
    /// run.
    pub device: Option<DeviceSample>,
    /// The deformable object's displacement from its rest shape at the CP (m), in a run
    /// with a deformable object ([`crate::deform`]); `None` otherwise.
    pub deform: Option<Vec3>,
}

impl Tick {
    /// A tick at `t_s` that rendered nothing: free, every vector and value zero, the HIP at
    /// the origin, no device sample.
    pub fn idle(t_s: f64) -> Self {
        Tick {
            t_s,
            hip: Vec3::ZERO,
            hip_velocity: Vec3::ZERO,
            cp: Vec3::ZERO,
            go: Vec3::ZERO,
            patch: None,
            feature: Feature::Patch(0),
            mode: Mode::Free,
            cause: SwitchCause::None,
            depth_m: 0.0,
            normal_force_n: 0.0,
            friction_force_n: 0.0,
            mu: 0.0,
            psi: 0.0,
            normal: Vec3::ZERO,
            tangent: Vec3::ZERO,
            friction: Vec3::ZERO,
            force: Vec3::ZERO,
            cp_patch: 0,
            cp_param: 0.0,
            cp_params: [0.0; 2],
            go_patch: 0,
            go_param: 0.0,
            go_params: [0.0; 2],
            device: None,
            deform: None,
        }
    }
}

/// The device side of one closed-loop tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeviceSample {
    /// Joint angles the controller measured from the encoder counts (rad); 0 when it could
    /// not (uncalibrated or unassembled).
    pub theta_rad: [f32; 2],
    /// Joint torques the motor currents produce (N·m): `Jᵀ F` of [`Tick::force`] at
    /// [`DeviceSample::theta_rad`], unless a current limit scaled them down.
    pub tau_nm: [f32; 2],
    /// The latched fault bits ([`device::safety::Faults`]); 0 when none.
    pub faults: u16,
}

/// One tick of a prescribed-HIP run, the step of [`run`](crate::sim::run) and of the GUI's spatial hand
/// (`haptic3d`): the renderer turns the HIP and its velocity into a force, recorded as a
/// [`Tick`] whose patch indices name the scene's patches.
pub fn render_tick<O: TrackedObject>(
    renderer: &mut FrictionRenderer<O>,
    object: &O,
    t_s: f64,
    hip: O::P,
    hip_velocity: O::P,
    period_s: f32,
) -> Tick {
    let out = renderer.tick(object, hip, hip_velocity, period_s);
    in_source_patches(record(t_s, hip, hip_velocity, &out), object)
}

/// Ramp-in of the force after it is enabled (s): short, so that a trajectory that starts
/// close to the object still feels it.
pub const DEVICE_RAMP_TIME_S: f32 = 0.02;

/// The default device at `rate_hz` with `chain` and `material` loaded, the passivity
/// controller on only when the material needs it (returned as the flag).
pub fn device_controller(
    chain: Chain,
    material: FrictionMaterial,
    rate_hz: f64,
) -> Result<(Controller<Chain>, bool), SimError> {
    device_controller_on(DeviceSpec::default(), chain, material, rate_hz)
}

/// [`device_controller`] on the pantograph `spec`.
pub fn device_controller_on(
    spec: DeviceSpec,
    chain: Chain,
    material: FrictionMaterial,
    rate_hz: f64,
) -> Result<(Controller<Chain>, bool), SimError> {
    let safety = SafetyConfig {
        period_s: (1.0 / rate_hz) as f32,
        ramp_time_s: DEVICE_RAMP_TIME_S,
        ..SafetyConfig::default()
    };
    let mut controller: Controller<Chain> =
        Controller::new(spec, safety).map_err(SimError::Controller)?;
    let passivity_control = controller
        .load_scene_as_needed(chain, material, true)
        .map_err(SimError::Controller)?;
    Ok((controller, passivity_control))
}

/// One closed-loop tick, the step of [`run_device`](crate::closed_loop::run_device) and of the GUI's haptic loop: a heartbeat,
/// one controller tick on the simulated encoders at `now_us` (the device clock), the
/// acquisition a scene load asks for (between ticks, as a board's lower-priority task:
/// `device::controller`, "Acquisition is not the tick's"), then the simulated pantograph moves
/// for `period_s` under the controller's currents and the virtual hand pulling towards
/// `hand_target`. Returns the tick's record, with the handle's true HIP before the move (patch
/// indices naming the scene's patches), and its telemetry frame. An arm driven into a singular
/// pose is [`SimError::Arm`]; it stays where it was.
pub fn device_tick<O: TrackedObject<P = Vec2>>(
    controller: &mut Controller<O>,
    arm: &mut SimulatedPantograph,
    t_s: f64,
    now_us: u64,
    hand_target: Vec2,
    period_s: f32,
) -> Result<(Tick, Telemetry), SimError> {
    let (hip, hip_velocity) = arm.hip().map_err(|error| SimError::Arm { t_s, error })?;
    controller.heartbeat();
    let out = controller.tick(arm.encoder_counts(), now_us);
    controller.acquire_now();
    let tick = device_record(t_s, hip, hip_velocity, &out);
    let tick = match controller.object() {
        Some(object) => in_source_patches(tick, object),
        None => tick,
    };
    arm.step(out.currents_a, hand_target, period_s)
        .map_err(|error| SimError::Arm { t_s, error })?;
    Ok((tick, out.telemetry))
}

/// The raw counts the encoders of `spec` read with both joints resting on their end stops:
/// what [`run_device`](crate::closed_loop::run_device) calibrates on (and the firmware's QEMU run, through `cargo xtask qemu`);
/// [`DeviceSpec::end_stop_counts`].
pub fn end_stop_counts(spec: &DeviceSpec) -> [i32; 2] {
    spec.end_stop_counts()
}

/// The tick with its patch indices naming the scene's patches: the tracker splits patches at
/// interior corners and creases into pieces that share their source's parameters.
fn in_source_patches<O: TrackedObject>(mut tick: Tick, object: &O) -> Tick {
    tick.patch = tick.patch.map(|p| object.source_patch(p));
    tick.cp_patch = object.source_patch(tick.cp_patch);
    tick.go_patch = object.source_patch(tick.go_patch);
    tick
}

pub(crate) fn vec2(xyz: [f64; 3]) -> Vec2 {
    Vec2::new(xyz[0] as f32, xyz[1] as f32)
}

fn device_record(t_s: f64, hip: Vec2, hip_velocity: Vec2, out: &TickOutput) -> Tick {
    let mut tick = match &out.render {
        Some(render) => record(t_s, hip, hip_velocity, render),
        None => Tick {
            hip: vec3(hip),
            hip_velocity: vec3(hip_velocity),
            ..Tick::idle(t_s)
        },
    };
    tick.force = vec3(out.telemetry.force_n);
    // The controller's (mode, cause), which names a contact ended by the renderer stopping.
    tick.mode = out.telemetry.mode;
    tick.cause = out.telemetry.cause;
    tick.device = Some(DeviceSample {
        theta_rad: out.joint_angles_rad.unwrap_or([0.0; 2]),
        tau_nm: out.joint_torques_nm,
        faults: out.telemetry.faults,
    });
    tick
}

fn record<P: Point>(t_s: f64, hip: P, hip_velocity: P, out: &FrictionOutput<P>) -> Tick {
    let c = &out.contact;
    Tick {
        t_s,
        hip: vec3(hip),
        hip_velocity: vec3(hip_velocity),
        cp: vec3(c.point),
        go: vec3(out.go),
        patch: (out.mode != Mode::Free).then_some(c.patch as usize),
        feature: c.feature,
        mode: out.mode,
        cause: out.cause,
        depth_m: c.depth,
        normal_force_n: out.normal_force_n,
        friction_force_n: out.friction_force_n,
        mu: out.mu,
        psi: out.psi,
        normal: vec3(out.normal),
        tangent: vec3(out.tangent),
        friction: vec3(out.friction),
        force: vec3(out.total),
        cp_patch: c.patch as usize,
        cp_param: c.params[0],
        cp_params: c.params,
        go_patch: out.go_patch as usize,
        go_param: out.go_params[0],
        go_params: out.go_params,
        device: None,
        deform: None,
    }
}

/// The first `P::DIM` coordinates, rounded to the loop's `f32`.
pub(crate) fn point<P: Point>(xyz: [f64; 3]) -> P {
    let c = xyz.map(|v| v as f32);
    P::from_coords(&c[..P::DIM]).unwrap_or(P::ZERO)
}

fn vec3<P: Point>(p: P) -> Vec3 {
    let c = p.as_slice();
    let at = |i: usize| c.get(i).copied().unwrap_or(0.0);
    Vec3::new(at(0), at(1), at(2))
}
