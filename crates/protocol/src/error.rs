//! Error codes carried by nacks.

/// Why a frame was rejected. Every code has a fixed value on the wire (the `code` byte of a
/// [`Nack`](super::Nack)); new codes are only ever appended.
#[repr(u8)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ErrorCode {
    /// The byte string is shorter than a frame header plus CRC, longer than 64 bytes, or its
    /// payload-length byte exceeds 57 or the bytes available.
    BadLength = 1,
    /// The frame CRC does not match.
    BadCrc = 2,
    /// The protocol version byte is not [`VERSION`](super::VERSION).
    BadVersion = 3,
    /// The message type byte is not a known message.
    UnknownType = 4,
    /// The payload length is wrong for the message type.
    BadPayloadLength = 5,
    /// A payload field holds a value outside its range (an enum tag, a flag byte, a
    /// non-finite float where a number is needed).
    BadField = 6,
    /// A material is out of range (negative, not finite, `mu_dynamic > mu_static`, …).
    BadMaterial = 7,
    /// The frame's sequence number is not the one the receiver expects (a frame was lost or
    /// repeated). Nothing changed; the nack carries the expected number.
    SequenceGap = 8,
    /// A message the receiver does not accept in this direction (e.g. telemetry sent to the
    /// device).
    UnexpectedMessage = 9,
    /// A scene chunk or commit without a scene begin.
    NoUpload = 10,
    /// The announced scene is larger than the receiver's buffer.
    SceneTooLarge = 11,
    /// A chunk whose offset lies before the bytes already received: a duplicate or a chunk
    /// sent out of order.
    DuplicateChunk = 12,
    /// A chunk whose offset lies after the bytes already received: a chunk is missing.
    MissingChunk = 13,
    /// A chunk that extends past the announced total length.
    ChunkPastEnd = 14,
    /// Commit before all announced bytes arrived.
    LengthMismatch = 15,
    /// The CRC-32 of the assembled scene differs from the one announced.
    SceneCrc = 16,
    /// The scene bytes are not the wire scene format (magic, version, truncated, trailing
    /// bytes, unknown patch kind, zero counts).
    SceneFormat = 17,
    /// The scene exceeds the device's fixed storage (objects, patches, knots, points).
    SceneCapacity = 18,
    /// A patch fails NURBS validation (`nurbs::Curve::new` / `nurbs::Surface::new`).
    ScenePatch = 19,
    /// An object's patches do not form a valid chain / shell, or mix kinds.
    SceneTopology = 20,
    /// A message only a simulated plant accepts ([`Message::HandTarget`](super::Message)),
    /// sent to a board that drives real motors.
    NotSimulated = 21,
    /// A control-point update ([`Message::ScenePoints`](super::Message)) with no active scene
    /// to update.
    NoActiveScene = 22,
    /// A control-point update for an object or a patch the active scene does not have (the
    /// nack names them).
    NoSuchPatch = 23,
    /// A control-point update that runs past the patch's control points (first index plus
    /// count beyond them).
    PointsPastPatch = 24,
    /// A control-point update whose points are planar for a surface patch, or spatial for a
    /// planar curve.
    PointsKind = 25,
    /// A control-point update that changes its object's topology (its curves split at other
    /// corners, a vertex turned from convex to reflex or smooth, a chain closed or opened):
    /// the renderer's features would not be the same; upload the scene instead.
    TopologyChanged = 26,
    /// A control-point update while the staging buffer holds something else (an upload in
    /// progress, or an update of another object not applied yet), or a commit or an update
    /// that found no store free to validate into (the one before is not in use yet: a
    /// board's tick takes it at its next boundary; send the frame again).
    StagingBusy = 27,
    /// A frame of a control-point update after an earlier frame of the same update was
    /// refused: the whole update is dropped, up to and including its apply frame.
    UpdateAborted = 28,
    /// A frame of a control-point update after a scene upload began between its frames: the
    /// update was dropped whole (its points were for the scene before the upload), and its
    /// frames are refused up to and including its apply frame.
    UpdateInterrupted = 29,
    /// An identification run ([`Message::Excite`](super::Message)) on a device not calibrated
    /// (its joint angles, and so the run's forces, are unknown).
    NotCalibrated = 30,
    /// An identification run whose torque on a joint is beyond what its motor gives at its
    /// current limit (the device description's `current_limit_a` × `torque_constant_nm_per_a`
    /// × `transmission_ratio`).
    TorqueBeyondMotor = 31,
}

impl ErrorCode {
    /// Every code, in wire order.
    pub const ALL: [ErrorCode; 31] = [
        ErrorCode::BadLength,
        ErrorCode::BadCrc,
        ErrorCode::BadVersion,
        ErrorCode::UnknownType,
        ErrorCode::BadPayloadLength,
        ErrorCode::BadField,
        ErrorCode::BadMaterial,
        ErrorCode::SequenceGap,
        ErrorCode::UnexpectedMessage,
        ErrorCode::NoUpload,
        ErrorCode::SceneTooLarge,
        ErrorCode::DuplicateChunk,
        ErrorCode::MissingChunk,
        ErrorCode::ChunkPastEnd,
        ErrorCode::LengthMismatch,
        ErrorCode::SceneCrc,
        ErrorCode::SceneFormat,
        ErrorCode::SceneCapacity,
        ErrorCode::ScenePatch,
        ErrorCode::SceneTopology,
        ErrorCode::NotSimulated,
        ErrorCode::NoActiveScene,
        ErrorCode::NoSuchPatch,
        ErrorCode::PointsPastPatch,
        ErrorCode::PointsKind,
        ErrorCode::TopologyChanged,
        ErrorCode::StagingBusy,
        ErrorCode::UpdateAborted,
        ErrorCode::UpdateInterrupted,
        ErrorCode::NotCalibrated,
        ErrorCode::TorqueBeyondMotor,
    ];

    /// The code with wire value `value`, if any.
    pub fn from_u8(value: u8) -> Option<Self> {
        Self::ALL.iter().copied().find(|&c| c as u8 == value)
    }

    /// Short description.
    pub fn message(self) -> &'static str {
        match self {
            ErrorCode::BadLength => "bad frame length",
            ErrorCode::BadCrc => "frame CRC mismatch",
            ErrorCode::BadVersion => "unsupported protocol version",
            ErrorCode::UnknownType => "unknown message type",
            ErrorCode::BadPayloadLength => "wrong payload length for the message type",
            ErrorCode::BadField => "payload field out of range",
            ErrorCode::BadMaterial => "material out of range",
            ErrorCode::SequenceGap => "unexpected sequence number",
            ErrorCode::UnexpectedMessage => "message not accepted in this direction",
            ErrorCode::NoUpload => "scene chunk or commit without begin",
            ErrorCode::SceneTooLarge => "scene larger than the receive buffer",
            ErrorCode::DuplicateChunk => "duplicate or out-of-order scene chunk",
            ErrorCode::MissingChunk => "missing scene chunk",
            ErrorCode::ChunkPastEnd => "scene chunk past the announced length",
            ErrorCode::LengthMismatch => "commit before all scene bytes arrived",
            ErrorCode::SceneCrc => "scene CRC-32 mismatch",
            ErrorCode::SceneFormat => "malformed scene bytes",
            ErrorCode::SceneCapacity => "scene exceeds device storage",
            ErrorCode::ScenePatch => "invalid NURBS patch",
            ErrorCode::SceneTopology => "invalid object topology",
            ErrorCode::NotSimulated => "only a simulated plant takes a hand target",
            ErrorCode::NoActiveScene => "no active scene to update",
            ErrorCode::NoSuchPatch => "no such object or patch in the active scene",
            ErrorCode::PointsPastPatch => "control points past the end of the patch",
            ErrorCode::PointsKind => "planar points for a surface or spatial points for a curve",
            ErrorCode::TopologyChanged => {
                "the moved points change the object's topology: upload the scene instead"
            }
            ErrorCode::StagingBusy => {
                "staging is busy: an upload, or an update of another object, is in progress"
            }
            ErrorCode::UpdateAborted => "an earlier frame of this update was refused",
            ErrorCode::UpdateInterrupted => {
                "a scene upload began between this update's frames: the update was dropped"
            }
            ErrorCode::NotCalibrated => "not calibrated: calibrate the device first",
            ErrorCode::TorqueBeyondMotor => {
                "excitation torque beyond the motor's torque at its current limit"
            }
        }
    }
}

impl core::fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{} (code {})", self.message(), *self as u8)
    }
}

impl core::error::Error for ErrorCode {}
