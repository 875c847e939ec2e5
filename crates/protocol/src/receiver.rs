//! The device side of a link: sequence tracking and scene upload.

use super::scene::{SceneStore, WireSceneError, points_span, write_points};
use super::{
    Crc32, ErrorCode, Frame, Message, NO_INDEX, Nack, SceneChunk, ScenePoints, UNKNOWN_SEQ, crc32,
    next_seq,
};

/// Checks an assembled scene before the receiver activates it.
pub trait SceneValidator {
    /// `Ok` when the device can run `scene`.
    fn validate(&mut self, scene: &[u8]) -> Result<(), WireSceneError>;

    /// `Ok` when the device can run `reshaped`, the active scene `active` with control points
    /// of object `object` moved ([`Message::ScenePoints`]), in place of `active` without
    /// starting its renderer anew: the object's topology must not have changed
    /// ([`SceneFault::TopologyChanged`](super::SceneFault::TopologyChanged)). The provided
    /// method validates `reshaped` alone (a closure cannot compare topologies); a
    /// [`SceneStore`] compares them ([`SceneStore::decode_reshaped`]).
    fn validate_reshape(
        &mut self,
        active: &[u8],
        reshaped: &[u8],
        object: u8,
    ) -> Result<(), WireSceneError> {
        let _ = (active, object);
        self.validate(reshaped)
    }
}

impl<F: FnMut(&[u8]) -> Result<(), WireSceneError>> SceneValidator for F {
    fn validate(&mut self, scene: &[u8]) -> Result<(), WireSceneError> {
        self(scene)
    }
}

/// Decodes the scene into the store: on success the store holds exactly the scene the
/// receiver activates; on failure the store is empty. So validate into a scratch store (or,
/// after a failed commit, decode [`SceneReceiver::active_scene`] again), not into the store
/// the tick is running on.
impl<const K: usize, const C: usize, const S: usize> SceneValidator for SceneStore<K, C, S> {
    fn validate(&mut self, scene: &[u8]) -> Result<(), WireSceneError> {
        self.decode(scene)
    }

    fn validate_reshape(
        &mut self,
        active: &[u8],
        reshaped: &[u8],
        object: u8,
    ) -> Result<(), WireSceneError> {
        self.decode_reshaped(active, reshaped, usize::from(object))
    }
}

/// Where a control-point update is ([`Message::ScenePoints`]). `Idle` first: its value is all
/// zero bits, as the whole receiver's is when new (a board's `static` of it needs no image in
/// flash).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Points {
    /// None in progress.
    Idle,
    /// Points of `object` staged: the staging buffer holds the active scene with them
    /// written in.
    Staged { object: u8 },
    /// A frame of the update was refused: its other frames are too, up to and including its
    /// apply frame.
    Aborted,
    /// A scene upload began between the update's frames: the staged points were for the
    /// scene before it, so the update is dropped and its other frames are refused, up to and
    /// including its apply frame (applied to the uploaded scene, they would be a part of an
    /// update).
    Interrupted,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Upload {
    total_len: usize,
    crc32: u32,
    received: usize,
    crc_so_far: Crc32,
}

/// Receives host frames on the device: tracks the host's sequence numbers and assembles
/// uploaded scenes in a double buffer of `N` bytes each (no allocation).
///
/// - The first frame, and any [`Message::Hello`], sets the expected sequence number; after
///   that each frame must carry the next one (wrapping). A frame with another number is
///   rejected with [`ErrorCode::SequenceGap`] (the nack carries the expected number) and
///   changes nothing: a frame was lost or repeated, and the host resynchronises on the
///   nack's number.
/// - **Every rejected frame leaves the upload in progress and the active scene as they
///   were.** A frame that carries the expected number and a good CRC but is refused (a bad
///   field, a chunk out of order, a failed commit) still uses up its number, as an accepted
///   one does: it arrived, and the host's next frame, already on its way behind it, follows
///   it. So a host that sends heartbeats and hand targets without waiting for each ack loses
///   only the refused frame, not every frame behind it. The nack carries the number
///   expected next.
/// - An upload runs `SceneBegin` → `SceneChunk`s in order (each at the offset where the last
///   ended) → `SceneCommit`. Chunks go to the staging buffer; the commit checks the length,
///   the CRC-32 and the validator, and only then swaps staging and active. A new
///   `SceneBegin` (or a `Hello`) abandons an upload in progress.
/// - A control-point update is one or more [`Message::ScenePoints`] of one object, the last
///   with its apply flag. Its first frame copies the active scene into the staging buffer,
///   each frame writes its points there (`(w·x, w·y[, w·z], w)` with the weight `w` already
///   there), and the apply frame computes the staged scene's CRC-32 and checks it with the
///   validator ([`SceneValidator::validate_reshape`]: valid, same topology) before it swaps
///   staging and active. So the active scene only ever changes by whole updates. Refused:
///   without an active scene ([`ErrorCode::NoActiveScene`]), an object or patch it does not
///   have ([`ErrorCode::NoSuchPatch`]), points past the patch's
///   ([`ErrorCode::PointsPastPatch`]) or of the other kind ([`ErrorCode::PointsKind`]),
///   during an upload or an update of another object ([`ErrorCode::StagingBusy`]), a
///   result that fails validation (its [`WireSceneError`]'s code) or changes the topology
///   ([`ErrorCode::TopologyChanged`]). A refused frame drops its whole update: the update's
///   later frames are refused too ([`ErrorCode::UpdateAborted`]), up to and including its
///   apply frame. A `SceneBegin` between an update's frames drops the update whole: its
///   later frames are refused ([`ErrorCode::UpdateInterrupted`]) up to and including its
///   apply frame, so no part of it lands on the uploaded scene (the wire names no update, so
///   a host that abandons an update half-sent and uploads has its next update refused so
///   too, or says `Hello` first). A `Hello` (a new session) drops an update not yet applied,
///   interrupted or not. An update whose apply frame never arrived (lost on the way: the next frame is a sequence gap)
///   stays staged, and the object's next update is applied over it: an update that sends
///   every point of the patches it moves (a deformable model's whole shape) is whole
///   whatever came before.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneReceiver<const N: usize = 8192> {
    buffers: [[u8; N]; 2],
    active: usize,
    active_len: usize,
    active_crc: u32,
    upload: Option<Upload>,
    points: Points,
    expected_seq: Option<u16>,
    simulated_plant: bool,
}

impl<const N: usize> Default for SceneReceiver<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> SceneReceiver<N> {
    /// A receiver with an empty active scene and no sequence number yet.
    pub const fn new() -> Self {
        SceneReceiver {
            buffers: [[0; N]; 2],
            active: 0,
            active_len: 0,
            active_crc: 0,
            upload: None,
            points: Points::Idle,
            expected_seq: None,
            simulated_plant: false,
        }
    }

    /// A receiver for a device whose plant is simulated (the host's simulator, the firmware
    /// under QEMU): it accepts [`Message::HandTarget`], which a board's receiver refuses
    /// with [`ErrorCode::NotSimulated`].
    pub const fn for_simulated_plant() -> Self {
        let mut r = Self::new();
        r.simulated_plant = true;
        r
    }

    /// The active scene's bytes (empty before the first commit).
    pub fn active_scene(&self) -> &[u8] {
        &self.buffers[self.active & 1][..self.active_len.min(N)]
    }

    /// CRC-32 of the active scene (0 before the first commit).
    pub fn active_crc32(&self) -> u32 {
        self.active_crc
    }

    /// The sequence number expected next, once known.
    pub fn expected_seq(&self) -> Option<u16> {
        self.expected_seq
    }

    /// Bytes received of the upload in progress, if any.
    pub fn upload_received(&self) -> Option<usize> {
        self.upload.map(|u| u.received)
    }

    /// Decodes and handles one frame. Scene-upload messages are handled here; every
    /// accepted frame is returned so the caller acts on the others (and acks it, see
    /// [`SceneReceiver::reply`]). Rejections come back as the nack to send.
    pub fn receive(
        &mut self,
        bytes: &[u8],
        validator: &mut impl SceneValidator,
    ) -> Result<Frame, Nack> {
        let frame = match Frame::decode(bytes) {
            Ok(frame) => frame,
            Err(e) => {
                // A good CRC makes its number trustworthy: in sequence, the frame uses it up.
                if let Some(seq) = e.seq
                    && self.expected_seq.is_none_or(|x| x == seq)
                {
                    self.expected_seq = Some(next_seq(seq));
                }
                return Err(self.nack(e.seq, e.code, None));
            }
        };
        let seq = frame.seq;
        let resync = matches!(frame.message, Message::Hello(_)) || self.expected_seq.is_none();
        if !resync && self.expected_seq != Some(seq) {
            return Err(self.nack(Some(seq), ErrorCode::SequenceGap, None));
        }
        let handled = self.handle(&frame, validator);
        self.expected_seq = Some(next_seq(seq));
        handled.map(|()| frame).map_err(|nack| Nack {
            expected_seq: next_seq(seq),
            ..nack
        })
    }

    /// Handles an in-sequence frame's message: scene upload here, the rest the caller's.
    fn handle(&mut self, frame: &Frame, validator: &mut impl SceneValidator) -> Result<(), Nack> {
        let seq = frame.seq;
        match frame.message {
            Message::Hello(_) => {
                self.upload = None;
                self.points = Points::Idle;
            }
            Message::SceneBegin { total_len, crc32 } => {
                // The wire names no update: the frames after this one may be the rest of the
                // staged update, which must not land part-way on another scene. (An update
                // already aborted stays so, for the same reason.)
                if matches!(self.points, Points::Staged { .. }) {
                    self.points = Points::Interrupted;
                }
                self.begin(total_len, crc32, seq)?;
            }
            Message::SceneChunk(ref chunk) => self.chunk(chunk, seq)?,
            Message::SceneCommit => self.commit(validator, seq)?,
            Message::ScenePoints(ref points) => self.scene_points(points, validator, seq)?,
            Message::Ack { .. } | Message::Nack(_) | Message::Status(_) | Message::Telemetry(_) => {
                return Err(self.nack(Some(seq), ErrorCode::UnexpectedMessage, None));
            }
            Message::HandTarget { .. } if !self.simulated_plant => {
                return Err(self.nack(Some(seq), ErrorCode::NotSimulated, None));
            }
            Message::HandTarget { .. } => {}
            Message::Heartbeat { .. }
            | Message::SetMaterial { .. }
            | Message::EnableForces
            | Message::DisableForces
            | Message::Calibrate
            | Message::ClearFaults { .. }
            | Message::Excite { .. } => {}
        }
        Ok(())
    }

    /// The reply to the outcome of [`SceneReceiver::receive`]: an ack or the nack.
    pub fn reply(outcome: &Result<Frame, Nack>) -> Message {
        match outcome {
            Ok(frame) => Message::Ack { seq: frame.seq },
            Err(nack) => Message::Nack(*nack),
        }
    }

    fn nack(&self, seq: Option<u16>, code: ErrorCode, scene: Option<&WireSceneError>) -> Nack {
        let index = |i: Option<u8>| i.unwrap_or(NO_INDEX);
        Nack {
            seq: seq.unwrap_or(UNKNOWN_SEQ),
            code,
            object: index(scene.and_then(|e| e.object)),
            patch: index(scene.and_then(|e| e.patch)),
            expected_seq: self.expected_seq.unwrap_or(UNKNOWN_SEQ),
        }
    }

    /// A nack about patch `patch` (when given) of object `object`.
    fn nack_at(&self, seq: u16, code: ErrorCode, object: u8, patch: Option<u8>) -> Nack {
        Nack {
            object,
            patch: patch.unwrap_or(NO_INDEX),
            ..self.nack(Some(seq), code, None)
        }
    }

    /// One frame of a control-point update; a refusal drops the update it belongs to.
    fn scene_points(
        &mut self,
        points: &ScenePoints,
        validator: &mut impl SceneValidator,
        seq: u16,
    ) -> Result<(), Nack> {
        let result = self.stage_points(points, validator, seq);
        if points.apply {
            // Applied or refused, the update ends with its apply frame.
            self.points = Points::Idle;
        } else if result.is_err() && self.points != Points::Interrupted {
            self.points = Points::Aborted;
        }
        result
    }

    fn stage_points(
        &mut self,
        p: &ScenePoints,
        validator: &mut impl SceneValidator,
        seq: u16,
    ) -> Result<(), Nack> {
        let refuse = |this: &Self, code, patch: bool| {
            Err(this.nack_at(seq, code, p.object, patch.then_some(p.patch)))
        };
        match self.points {
            Points::Aborted => return refuse(self, ErrorCode::UpdateAborted, false),
            Points::Interrupted => return refuse(self, ErrorCode::UpdateInterrupted, false),
            Points::Idle | Points::Staged { .. } => {}
        }
        if self.active_len == 0 {
            return refuse(self, ErrorCode::NoActiveScene, false);
        }
        if self.upload.is_some()
            || matches!(self.points, Points::Staged { object } if object != p.object)
        {
            return refuse(self, ErrorCode::StagingBusy, false);
        }
        if let Err(code) = points_span(self.active_scene(), p) {
            return refuse(self, code, true);
        }
        let len = self.active_len.min(N);
        let staging_index = (self.active + 1) & 1;
        let [b0, b1] = &mut self.buffers;
        let (active, staging) = if staging_index == 1 {
            (&*b0, b1)
        } else {
            (&*b1, b0)
        };
        if self.points == Points::Idle {
            staging[..len].copy_from_slice(&active[..len]);
            self.points = Points::Staged { object: p.object };
        }
        // The staging copy has the active scene's layout: the span checked above is its too.
        if let Err(code) = write_points(&mut staging[..len], p) {
            return refuse(self, code, true);
        }
        if !p.apply {
            return Ok(());
        }
        let (active, staging) = if staging_index == 1 {
            (&self.buffers[0][..len], &self.buffers[1][..len])
        } else {
            (&self.buffers[1][..len], &self.buffers[0][..len])
        };
        let crc = crc32(staging);
        if let Err(e) = validator.validate_reshape(active, staging, p.object) {
            let nack = self.nack(Some(seq), e.code(), Some(&e));
            return Err(Nack {
                object: p.object,
                ..nack
            });
        }
        self.active = staging_index;
        self.active_crc = crc;
        Ok(())
    }

    fn begin(&mut self, total_len: u32, crc32: u32, seq: u16) -> Result<(), Nack> {
        let total_len = usize::try_from(total_len).unwrap_or(usize::MAX);
        if total_len > N {
            return Err(self.nack(Some(seq), ErrorCode::SceneTooLarge, None));
        }
        self.upload = Some(Upload {
            total_len,
            crc32,
            received: 0,
            crc_so_far: Crc32::new(),
        });
        Ok(())
    }

    fn chunk(&mut self, chunk: &SceneChunk, seq: u16) -> Result<(), Nack> {
        let Some(mut upload) = self.upload else {
            return Err(self.nack(Some(seq), ErrorCode::NoUpload, None));
        };
        let offset = usize::try_from(chunk.offset).unwrap_or(usize::MAX);
        let data = chunk.data();
        let code = if offset < upload.received {
            Some(ErrorCode::DuplicateChunk)
        } else if offset > upload.received {
            Some(ErrorCode::MissingChunk)
        } else if data.len() > upload.total_len - upload.received {
            Some(ErrorCode::ChunkPastEnd)
        } else {
            None
        };
        if let Some(code) = code {
            return Err(self.nack(Some(seq), code, None));
        }
        let end = offset + data.len();
        let staging = &mut self.buffers[(self.active + 1) & 1];
        let Some(dst) = staging.get_mut(offset..end) else {
            // Unreachable: `end <= total_len <= N`.
            return Err(self.nack(Some(seq), ErrorCode::ChunkPastEnd, None));
        };
        dst.copy_from_slice(data);
        upload.crc_so_far.update(data);
        upload.received = end;
        self.upload = Some(upload);
        Ok(())
    }

    fn commit(&mut self, validator: &mut impl SceneValidator, seq: u16) -> Result<(), Nack> {
        let Some(upload) = self.upload else {
            return Err(self.nack(Some(seq), ErrorCode::NoUpload, None));
        };
        if upload.received != upload.total_len {
            return Err(self.nack(Some(seq), ErrorCode::LengthMismatch, None));
        }
        let staging_index = (self.active + 1) & 1;
        let Some(scene) = self.buffers[staging_index].get(..upload.total_len) else {
            return Err(self.nack(Some(seq), ErrorCode::LengthMismatch, None));
        };
        // The running CRC covers exactly the bytes written, so recomputing is a cross-check
        // that costs one pass at commit only.
        let crc = upload.crc_so_far.finish();
        if crc != upload.crc32 || crc32(scene) != crc {
            return Err(self.nack(Some(seq), ErrorCode::SceneCrc, None));
        }
        if let Err(e) = validator.validate(scene) {
            return Err(self.nack(Some(seq), e.code(), Some(&e)));
        }
        self.active = staging_index;
        self.active_len = upload.total_len;
        self.active_crc = crc;
        self.upload = None;
        Ok(())
    }
}
