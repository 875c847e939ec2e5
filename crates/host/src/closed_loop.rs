//! The closed loop of `viewer sim --device`: [`run_device`] runs a prescribed scenario through
//! the device instead of on a prescribed HIP ([`crate::sim::run`]): the trajectory moves the
//! target of a virtual hand ([`DeviceHand`]) that holds the handle of a
//! [`SimulatedPantograph`], and the device's own [`Controller`] (encoder counts → kinematics →
//! tracker → friction → safety → Jᵀ F → motor currents) pushes back. Its ticks carry a
//! [`DeviceSample`](crate::tick::DeviceSample) as well, and the run log gets the
//! [`DEVICE_COLUMNS`](crate::runlog::DEVICE_COLUMNS).

use device::controller::Controller;
use device::simulator::SimulatedPantograph;
use device::spec::DeviceSpec;
use device::telemetry::TelemetryDecimator;
use friction::FrictionMaterial;
use nurbs::Vec2;
use protocol::Telemetry;
use tracker::Chain;

use crate::error::SimError;
use crate::hand::DeviceHand;
use crate::sim::{Proceed, Run, validate};
use crate::tick::{Tick, device_controller_on, device_tick, end_stop_counts, vec2};
use crate::trajectory::Trajectory;
use scene::{Scene, Space};

/// The default device's controller at `rate_hz` with `chain` and `material` loaded
/// ([`device_controller`]), calibrated on the end stops and with forces on, as a closed-loop
/// run starts it; and whether the passivity controller is on.
pub(crate) fn ready_controller(
    spec: DeviceSpec,
    chain: Chain,
    material: FrictionMaterial,
    rate_hz: f64,
) -> Result<(Controller<Chain>, bool), SimError> {
    let (mut controller, passivity_control) = device_controller_on(spec, chain, material, rate_hz)?;
    controller
        .calibrate(end_stop_counts(&spec))
        .map_err(SimError::Controller)?;
    controller.set_forces_enabled(true);
    Ok((controller, passivity_control))
}

/// The closed loop's ticks: `n` ticks at `rate_hz` of the default simulated pantograph,
/// started where the trajectory starts and held by `hand`, whose target follows the
/// trajectory; each tick is `tick(arm, t_s, now_us, target)` (the device clock in whole
/// microseconds, as a board's timer), its frames folded by the board's decimator.
pub(crate) fn drive_device<E: From<SimError>, P: Proceed>(
    spec: DeviceSpec,
    trajectory: &Trajectory,
    rate_hz: f64,
    hand: DeviceHand,
    n: usize,
    mut progress: impl FnMut(usize, usize) -> P,
    mut tick: impl FnMut(&mut SimulatedPantograph, f64, u64, Vec2) -> Result<(Tick, Telemetry), E>,
) -> Result<(Vec<Tick>, Vec<Telemetry>), E> {
    let start = trajectory.at(trajectory.start_s());
    let mut arm =
        SimulatedPantograph::new(spec, hand.params, vec2(start)).map_err(SimError::Simulator)?;
    let mut ticks = Vec::with_capacity(n);
    // The board's decimator, on the same period (firmware::app).
    let mut decimator = TelemetryDecimator::for_period_s((1.0 / rate_hz) as f32);
    let mut telemetry = Vec::with_capacity(n / decimator.ticks_per_frame() as usize + 1);
    for i in 0..n {
        let t_s = trajectory.tick_time_s(i, rate_hz);
        let now_us = (i as f64 * 1e6 / rate_hz).round() as u64;
        let target = vec2(trajectory.at(t_s));
        if hand.release_at_s.is_some_and(|at| t_s >= at) && arm.is_held() {
            arm.release();
        }
        let (record, frame) = tick(&mut arm, t_s, now_us, target)?;
        ticks.push(record);
        telemetry.extend(decimator.push(&frame).copied());
        if !progress(i + 1, n).proceed() {
            break;
        }
    }
    Ok((ticks, telemetry))
}

/// A closed-loop run ([`run_device`]).
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceRun {
    /// The ticks, each with its [`DeviceSample`](crate::tick::DeviceSample).
    pub run: Run,
    /// Whether the material is stiffer than the device renders passively at this rate, so
    /// that the controller renders it with the time-domain passivity controller on.
    pub passivity_control: bool,
    /// The telemetry frames a board sends: the ticks' frames as the controller made them,
    /// folded by `device::telemetry::TelemetryDecimator` into one per millisecond (every
    /// tick's at 1 kHz and below; a last window shorter than a millisecond sends none). The
    /// firmware under QEMU is compared with them frame by frame by `cargo xtask qemu`.
    pub telemetry: Vec<Telemetry>,
}

/// Checks everything [`run_device`] checks before its first tick, without running it; returns
/// the number of ticks.
pub fn validate_device(
    scene: &Scene,
    object: usize,
    trajectory: &Trajectory,
    rate_hz: f64,
) -> Result<usize, SimError> {
    validate_device_on(&DeviceSpec::default(), scene, object, trajectory, rate_hz)
}

/// [`validate_device`] on the pantograph `spec`.
pub fn validate_device_on(
    spec: &DeviceSpec,
    scene: &Scene,
    object: usize,
    trajectory: &Trajectory,
    rate_hz: f64,
) -> Result<usize, SimError> {
    if let Some(o) = scene.object(object)
        && o.space() == Space::Spatial
    {
        return Err(SimError::Surface {
            index: object,
            name: o.name().to_owned(),
        });
    }
    let ticks = validate(scene, object, trajectory, rate_hz)?;
    // The controller's own checks (a stiffness beyond the device, among others) before the
    // run, on the same setup `run_device` uses.
    let material = scene.objects()[object].material().friction_material();
    with_chain(scene, object, |chain| {
        device_controller_on(*spec, chain, material, rate_hz).map(|_| ())
    })?;
    Ok(ticks)
}

/// Object `object`'s curves as a chain, handed to `f` (the chain borrows the curves).
fn with_chain<R>(
    scene: &Scene,
    object: usize,
    f: impl FnOnce(Chain) -> Result<R, SimError>,
) -> Result<R, SimError> {
    let o = &scene.objects()[object];
    let curves = o.curve_views().ok_or_else(|| SimError::Surface {
        index: object,
        name: o.name().to_owned(),
    })?;
    let chain = Chain::new(&curves).map_err(|error| SimError::Chain {
        index: object,
        error,
    })?;
    f(chain)
}

/// The closed loop: object `object` of `scene` (planar curves only) on the default
/// [`DeviceSpec`] at `rate_hz`, the virtual hand's target moving along `trajectory` and
/// holding the handle with the grip of `hand`.
///
/// The controller calibrates on the end stops, enables forces (ramping in over
/// [`DEVICE_RAMP_TIME_S`](crate::tick::DEVICE_RAMP_TIME_S)), gets a heartbeat every tick and renders the object's material,
/// with the passivity controller on when the material is stiffer than the device renders
/// passively ([`DeviceRun::passivity_control`]); a material stiffer than the device renders
/// even with it is refused ([`ControllerError::BeyondDevice`](device::controller::ControllerError::BeyondDevice),
/// naming the limit). Each tick
/// the controller reads the simulated encoders (on a clock of whole microseconds since the
/// start), and the simulated pantograph then moves for one period under the controller's
/// currents and the hand. The ticks' HIP and HIP velocity are the handle's
/// true ones (not the target's), `force` the force after the safety layer, the other
/// rendering fields the renderer's. `progress(done, total)` is called after every tick, and
/// may end the run there ([`Proceed`]).
pub fn run_device<P: Proceed>(
    scene: &Scene,
    object: usize,
    trajectory: &Trajectory,
    rate_hz: f64,
    hand: impl Into<DeviceHand>,
    progress: impl FnMut(usize, usize) -> P,
) -> Result<DeviceRun, SimError> {
    let spec = DeviceSpec::default();
    run_device_on(&spec, scene, object, trajectory, rate_hz, hand, progress)
}

/// [`run_device`] on the pantograph `spec` (a `device/1` file's, [`crate::device_file`]):
/// its controller and its simulated mechanism.
pub fn run_device_on<P: Proceed>(
    spec: &DeviceSpec,
    scene: &Scene,
    object: usize,
    trajectory: &Trajectory,
    rate_hz: f64,
    hand: impl Into<DeviceHand>,
    progress: impl FnMut(usize, usize) -> P,
) -> Result<DeviceRun, SimError> {
    let hand: DeviceHand = hand.into();
    let n = validate_device_on(spec, scene, object, trajectory, rate_hz)?;
    let o = &scene.objects()[object];
    let material = o.material().friction_material();
    with_chain(scene, object, |chain| {
        let (mut controller, passivity_control) =
            ready_controller(*spec, chain, material, rate_hz)?;
        let period_s = (1.0 / rate_hz) as f32;
        let (ticks, telemetry) = drive_device(
            *spec,
            trajectory,
            rate_hz,
            hand,
            n,
            progress,
            |arm, t_s, now_us, target| {
                device_tick(&mut controller, arm, t_s, now_us, target, period_s)
            },
        )?;
        Ok(DeviceRun {
            run: Run {
                space: Space::Planar,
                object,
                object_name: o.name().to_owned(),
                material,
                rate_hz,
                ticks,
            },
            passivity_control,
            telemetry,
        })
    })
}
