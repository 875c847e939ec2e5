//! A scene as the planar loop renders it ([`PlanarSession`]): the scene, the object the device
//! renders, that object as the device received it (the wire upload through the device's own
//! receiver, [`crate::upload::DeviceScene`]) and the controller built on it.

use device::controller::Controller;
use device::spec::DeviceSpec;
use protocol::SceneFault;
use tracker::Chain;

use crate::deform::DeformChangeError;
use crate::error::SimError;
use crate::tick;
use crate::upload::{self, DEVICE_OBJECT, DeviceScene, PointsUpdate, UploadError};
use scene::{Scene, Space};

/// The device's tick rate in the loop (Hz): the board's. The loop thread wakes at
/// [`RATE_HZ`](crate::loop_api::RATE_HZ) and runs
/// [`TICKS_PER_STEP`](crate::planar::TICKS_PER_STEP) device ticks per wake.
pub const DEVICE_RATE_HZ: f64 = 10_000.0;

/// A scene the loop renders: the scene, the index of the object the device renders (the
/// first planar one; `None` when the scene has none), that object as the device received it,
/// and the controller built for it (which holds its own copy of the object: nothing borrowed).
pub struct PlanarSession {
    /// The device the session runs on.
    spec: DeviceSpec,
    scene: Scene,
    object: Option<usize>,
    received: Option<Received>,
    pub(crate) controller: Controller<Chain>,
    pub(crate) passivity_control: bool,
}

/// An object as the device received it: the wire scene uploaded, and the device's receiver
/// and store holding it (as moved since by control-point updates).
#[derive(Debug)]
struct Received {
    wire: Vec<u8>,
    device: DeviceScene,
}

impl std::fmt::Debug for PlanarSession {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PlanarSession")
            .field("object", &self.object())
            .field("passivity_control", &self.passivity_control())
            .finish_non_exhaustive()
    }
}

/// Why a scene cannot be rendered.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The controller or the chain refused the object.
    #[error("{0}")]
    Sim(#[from] SimError),
    /// The device refused its upload.
    #[error("{0}")]
    Upload(#[from] UploadError),
}

impl PlanarSession {
    /// The default device at [`DEVICE_RATE_HZ`], calibrated on its end stops, forces enabled, with
    /// the first object of planar curves of `scene` loaded (none when it has none: the
    /// pantograph is planar, so a scene of surfaces renders nothing). The controller's own
    /// checks apply: a material stiffer than the device renders is refused, naming the limit.
    pub fn new(scene: Scene) -> Result<Self, SessionError> {
        Self::new_on(DeviceSpec::default(), scene)
    }

    /// [`PlanarSession::new`] on the device `spec` (a `device/1` file's).
    pub fn new_on(spec: DeviceSpec, scene: Scene) -> Result<Self, SessionError> {
        let object = scene
            .objects()
            .iter()
            .position(|o| o.space() == Space::Planar);
        Self::on(spec, scene, object)
    }

    /// [`PlanarSession::new`] with object `object` (which must be planar), or none. The object
    /// reaches the controller as a board's would: its wire scene ([`upload::wire_scene`])
    /// goes frame by frame through the device's receiver ([`DeviceScene::receive`]), and the
    /// controller renders the store the device decoded.
    pub fn with_object(scene: Scene, object: Option<usize>) -> Result<Self, SessionError> {
        Self::on(DeviceSpec::default(), scene, object)
    }

    /// [`PlanarSession::with_object`] on the device `spec` (a `device/1` file's) in place of
    /// the default.
    pub fn on(spec: DeviceSpec, scene: Scene, object: Option<usize>) -> Result<Self, SessionError> {
        let received = match object {
            Some(index) => {
                let wire = upload::wire_scene(&scene, index)?;
                let device = DeviceScene::receive(&wire)?;
                Some(Received { wire, device })
            }
            None => None,
        };
        let (controller, passivity_control) = build_controller(spec, received.as_ref(), object)?;
        Ok(PlanarSession {
            spec,
            scene,
            object,
            received,
            controller,
            passivity_control,
        })
    }

    /// The device it runs on.
    pub fn spec(&self) -> &DeviceSpec {
        &self.spec
    }

    /// The scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The index of the object the device renders, if any.
    pub fn object(&self) -> Option<usize> {
        self.object
    }

    /// The wire scene the device received (the rendered object alone, at rest), if it
    /// renders one: what an upload to a board carries.
    pub fn wire(&self) -> Option<&[u8]> {
        self.received.as_ref().map(|r| r.wire.as_slice())
    }

    /// The CRC-32 the device reports for its active scene (`Status::scene_crc32`), if it
    /// renders one: the upload's, or, while the object deforms, its current shape's.
    pub fn scene_crc32(&self) -> Option<u32> {
        self.received.as_ref().map(|r| r.device.crc32())
    }

    /// Whether the controller renders the material with the passivity controller on (the
    /// material is stiffer than the device renders passively at [`DEVICE_RATE_HZ`]).
    pub fn passivity_control(&self) -> bool {
        self.passivity_control
    }
}

/// The controller of the device `spec` for what the device received (nothing rendered
/// without an object), calibrated on its end stops, forces enabled, and whether it runs the
/// passivity controller.
fn build_controller(
    spec: DeviceSpec,
    received: Option<&Received>,
    object: Option<usize>,
) -> Result<(Controller<Chain>, bool), SessionError> {
    let (mut controller, passivity_control) = match received {
        Some(r) => {
            let material = r
                .device
                .store()
                .material(usize::from(DEVICE_OBJECT))
                .unwrap_or_default();
            tick::device_controller_on(spec, store_chain(r, object)?, material, DEVICE_RATE_HZ)?
        }
        None => {
            let safety = device::safety::SafetyConfig {
                period_s: (1.0 / DEVICE_RATE_HZ) as f32,
                ramp_time_s: tick::DEVICE_RAMP_TIME_S,
                ..device::safety::SafetyConfig::default()
            };
            (
                Controller::new(spec, safety).map_err(SimError::Controller)?,
                false,
            )
        }
    };
    controller
        .calibrate(tick::end_stop_counts(&spec))
        .map_err(SimError::Controller)?;
    controller.set_forces_enabled(true);
    Ok((controller, passivity_control))
}

/// The chain of the object the device decoded (object [`DEVICE_OBJECT`] of its store;
/// `object` of the scene, named in the error).
fn store_chain(received: &Received, object: Option<usize>) -> Result<Chain, SessionError> {
    let index = object.unwrap_or(0);
    let store = received.device.store();
    store
        .chain(usize::from(DEVICE_OBJECT))
        .map_err(|e| match e.fault {
            SceneFault::Chain(error) => SimError::Chain { index, error }.into(),
            _ => UploadError::Refused(e.code()).into(),
        })
}

/// Moves `session`'s device onto `update`, as a device behind a link takes it: the update
/// through the device's receiver ([`DeviceScene::apply_points`]), then, when it moved the
/// rendered object, the controller onto the updated store's curves in place
/// ([`Controller::reshape_object`] with [`Chain::reshape`]: the renderer carried on). Refused
/// with the device's reason.
pub(crate) fn apply_points(
    session: &mut PlanarSession,
    update: &PointsUpdate,
) -> Result<(), DeformChangeError> {
    let received = session
        .received
        .as_mut()
        .ok_or(DeformChangeError::NoObject)?;
    let object = received
        .device
        .apply_points(update)
        .map_err(|e| DeformChangeError::Update(e.to_string()))?;
    if object != DEVICE_OBJECT {
        // The device renders one object; another's points change nothing it renders.
        return Ok(());
    }
    let controller = &mut session.controller;
    received
        .device
        .store()
        .with_curves(usize::from(object), |curves| {
            controller.reshape_object(|chain| chain.reshape(curves))
        })
        .map_err(|e| DeformChangeError::Update(e.to_string()))?
        .map_err(DeformChangeError::Controller)
}
