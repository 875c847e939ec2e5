//! A scene as a device receives it: the wire scene of the object the device renders
//! ([`wire_scene`]), and the device side of its upload for the simulated pantograph in this
//! process ([`receive`]): the same frames a board gets, through the device's own receiver
//! ([`protocol::device_side::session::DeviceSession`]), decoded into the device's own [`SceneStore`].
//!
//! So every scene the app renders, on any device, is the one the upload carried: an edit
//! that does not survive the wire format (f32, the device's capacities and checks) is refused
//! before it reaches the loop, with the device's reason.

use nurbs::Vec2;
use protocol::device_side::session::{DeviceSession, DeviceState, Event};
use protocol::host_side::Sequencer;
use protocol::{
    ErrorCode, Message, SceneStore, WireObject, WirePatch, WireSceneError, encode_scene,
    scene_upload,
};

use scene::Scene;

/// Scene capacity of the simulated device (bytes), as the host simulator's and the emulated
/// board's receivers.
pub const SIM_SCENE_CAPACITY: usize = 8192;

/// Why a scene cannot be uploaded. The device's running scene is unchanged.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum UploadError {
    /// The object is not a chain of planar curves (the pantograph renders those only).
    #[error("object {index} ({name}) is not a chain of planar curves: the pantograph is planar")]
    NotPlanar {
        /// Object index in the scene.
        index: usize,
        /// Its name.
        name: String,
    },
    /// There is no such object.
    #[error("the scene has no object {index} (it has {count})")]
    NoObject {
        /// The index asked for.
        index: usize,
        /// Objects in the scene.
        count: usize,
    },
    /// The wire format cannot hold it (a capacity, a count), as the device would decide.
    #[error("object {index} ({name}) as a wire scene: {error}")]
    Encode {
        /// Object index in the scene.
        index: usize,
        /// Its name.
        name: String,
        /// What the encoder refused.
        error: WireSceneError,
    },
    /// The device refused a frame of the upload.
    #[error("the device refused the upload: {}", .0.message())]
    Refused(ErrorCode),
    /// The device's receiver never committed the scene.
    #[error("the device did not commit the upload")]
    NotCommitted,
}

/// The index in the device's scene of the object a session uploads ([`wire_scene`]): a
/// control-point update of that object names this one.
pub const DEVICE_OBJECT: u8 = 0;

/// The wire scene a device gets for object `index` of `scene`: that object alone, as the
/// device's object [`DEVICE_OBJECT`] (a device renders its first object).
pub fn wire_scene(scene: &Scene, index: usize) -> Result<Vec<u8>, UploadError> {
    let object = scene.object(index).ok_or(UploadError::NoObject {
        index,
        count: scene.objects().len(),
    })?;
    let curves = object.curve_views().ok_or_else(|| UploadError::NotPlanar {
        index,
        name: object.name().to_owned(),
    })?;
    let patches: Vec<WirePatch<'_>> = curves.iter().copied().map(WirePatch::Curve).collect();
    encode_scene(&[WireObject {
        material: object.material().friction_material(),
        patches: &patches,
    }])
    .map_err(|error| UploadError::Encode {
        index,
        name: object.name().to_owned(),
        error,
    })
}

/// The simulated device's side of uploading `wire` ([`DeviceScene::receive`]): the store the
/// device decoded and the CRC-32 it reports for its active scene.
pub fn receive(wire: &[u8]) -> Result<(Box<SceneStore>, u32), UploadError> {
    let device = DeviceScene::receive(wire)?;
    let crc32 = device.crc32();
    Ok((device.store, crc32))
}

/// A scene as the simulated device in this process holds it: the device's own receiver
/// ([`DeviceSession`], which keeps the active wire scene) and the store it decoded the scene
/// into. Uploads and control-point updates reach it as frames, as they reach a board.
#[derive(Debug)]
pub struct DeviceScene {
    session: Box<DeviceSession<SIM_SCENE_CAPACITY>>,
    store: Box<SceneStore>,
    host: Sequencer,
}

/// The state a [`DeviceScene`]'s receiver is told the device is in (the replies it would make
/// are not read).
const STATE: DeviceState = DeviceState {
    software: [0; 3],
    forces_enabled: false,
    calibrated: true,
    faults: 0,
};

impl DeviceScene {
    /// Uploads `wire`: every frame of the upload (begin, chunks, commit, as
    /// [`protocol::host_side::Link::upload_scene`] sends them to a board), encoded with sequence
    /// numbers and handled by a device [`DeviceSession`] of [`SIM_SCENE_CAPACITY`] bytes,
    /// which validates the commit by decoding it into a [`SceneStore`].
    pub fn receive(wire: &[u8]) -> Result<Self, UploadError> {
        let mut device = DeviceScene {
            session: Box::new(DeviceSession::new(true)),
            store: Box::new(SceneStore::new()),
            host: Sequencer::default(),
        };
        let mut committed = false;
        for message in scene_upload(wire) {
            committed |= device.handle(&message)? == Event::SceneCommitted;
        }
        if !committed {
            return Err(UploadError::NotCommitted);
        }
        Ok(device)
    }

    /// Moves control points of the device's scene as `update` says: its frames
    /// ([`PointsUpdate::messages`], what the host of a device behind a link sends) through the device's
    /// receiver, which writes them into a copy of the active scene, validates it
    /// ([`SceneStore::decode_reshaped`]: the same checks as an upload, and the object's
    /// topology kept) and makes it active. Returns the object whose points moved; the store
    /// holds the new scene. Refused with the device's reason, nothing changed.
    pub fn apply_points(&mut self, update: &PointsUpdate) -> Result<u8, UploadError> {
        let mut applied = None;
        for message in update.messages() {
            if let Event::ScenePointsUpdated { object } = self.handle(&message)? {
                applied = Some(object);
            }
        }
        applied.ok_or(UploadError::NotCommitted)
    }

    /// One host frame through the device's receiver; a nack is the device's refusal.
    fn handle(&mut self, message: &Message) -> Result<Event, UploadError> {
        let (frame, len, _) = self.host.encode(message);
        let mut refused = None;
        let event = self
            .session
            .handle(&frame[..len], self.store.as_mut(), STATE, &mut |reply| {
                if let Message::Nack(n) = reply {
                    refused = Some(n.code);
                }
            });
        match refused {
            Some(code) => Err(UploadError::Refused(code)),
            None => Ok(event),
        }
    }

    /// The store the device decoded its active scene into.
    pub fn store(&self) -> &SceneStore {
        &self.store
    }

    /// The CRC-32 the device reports for its active scene (`Status::scene_crc32`).
    pub fn crc32(&self) -> u32 {
        self.session.receiver().active_crc32()
    }
}

/// New control points for patches of one object of the device's scene
/// ([`LoopCommand::ScenePoints`](crate::loop_api::LoopCommand::ScenePoints), [`protocol::points_update`]; `P` = [`Vec3`](nurbs::Vec3) for a
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_scenes::thesis_2d;
    use protocol::crc32;

    /// The store the device decodes holds the scene's curves exactly (the wire carries f32,
    /// the scene's type: no rounding) and its material; the CRC is the upload's.
    #[test]
    fn the_device_receives_the_scene_exactly() {
        let scene = thesis_2d();
        let wire = wire_scene(&scene, 0).expect("planar");
        let (store, crc) = receive(&wire).expect("received");
        assert_eq!(crc, crc32(&wire));
        let object = scene.object(0).expect("object 0");
        let curves = object.curve_views().expect("curves");
        assert_eq!(store.object_count(), 1);
        assert_eq!(store.patch_count(0), Some(curves.len()));
        for (p, c) in curves.iter().enumerate() {
            let d = store.curve(0, p).expect("curve");
            assert_eq!(d.knots(), c.knots());
            assert_eq!(d.points(), c.points());
        }
        assert_eq!(
            store.material(0),
            Some(object.material().friction_material())
        );
    }

    /// A wire scene the device's receiver refuses (cut one byte short: the begin announces
    /// that length and CRC, so the transfer checks pass and the device's decode refuses it)
    /// is an error naming the device's reason.
    #[test]
    fn a_truncated_scene_is_refused_with_the_devices_reason() {
        let wire = wire_scene(&thesis_2d(), 0).expect("planar");
        let e = receive(&wire[..wire.len() - 1]).expect_err("truncated");
        assert!(matches!(e, UploadError::Refused(_)), "{e}");
        assert!(e.to_string().starts_with("the device refused the upload: "));
    }
}
