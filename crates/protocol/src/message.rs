//! Messages and frames.

use friction::{FrictionMaterial, Mode, SwitchCause};
use nurbs::{Vec2, Vec3};
use tracker::Feature;

pub use device::telemetry::Telemetry;

use super::wire::{MATERIAL_LEN, Reader, Sink, Writer, get_material, put_material};
use super::{ErrorCode, crc::crc16_ccitt_false};

/// Protocol version (first byte of every frame).
pub const VERSION: u8 = 1;
/// Largest frame: one USB full-speed HID report.
pub const MAX_FRAME: usize = 64;
/// Bytes before the payload: version, type, sequence (u16), payload length.
pub const HEADER_LEN: usize = 5;
/// Bytes of the trailing CRC-16.
pub const CRC_LEN: usize = 2;
/// Largest payload.
pub const MAX_PAYLOAD: usize = MAX_FRAME - HEADER_LEN - CRC_LEN;
/// Largest scene chunk: the payload minus the u32 offset.
pub const MAX_CHUNK: usize = MAX_PAYLOAD - 4;
/// The sequence number a nack carries when the rejected frame's own number is unknown
/// (the frame was too damaged to trust it). No host frame is numbered with it: the host's
/// numbers go from 0xFFFE to 0 ([`next_seq`]), so a nack's expected number is never
/// ambiguous.
pub const UNKNOWN_SEQ: u16 = 0xFFFF;

/// The sequence number after `seq` for frames from the host: one more, wrapping from 0xFFFE to
/// 0 past [`UNKNOWN_SEQ`]. (Were 0xFFFF a frame's number and that frame lost, the device's
/// sequence-gap nacks would carry `expected_seq = 0xFFFF`, which a host cannot tell from
/// "unknown", and the link would never resynchronise.)
pub const fn next_seq(seq: u16) -> u16 {
    let next = seq.wrapping_add(1);
    if next == UNKNOWN_SEQ { 0 } else { next }
}
/// Object / patch index of a nack that concerns no particular object or patch.
pub const NO_INDEX: u8 = 0xFF;
/// Bytes of a [`Message::ScenePoints`] payload before its points: object u8, patch u8, first
/// control point u16, flags u8.
pub const POINTS_HEADER_LEN: usize = 5;
/// Most planar control points (x, y) one [`Message::ScenePoints`] frame carries.
pub const MAX_POINTS_2D: usize = (MAX_PAYLOAD - POINTS_HEADER_LEN) / 8;
/// Most surface control points (x, y, z) one [`Message::ScenePoints`] frame carries.
pub const MAX_POINTS_3D: usize = (MAX_PAYLOAD - POINTS_HEADER_LEN) / 12;
/// [`ScenePoints`] flag: the last frame of an update; the staged points apply with it.
pub const POINTS_APPLY: u8 = 1;
/// [`ScenePoints`] flag: the points are a surface's (x, y, z); without it a planar curve's
/// (x, y).
pub const POINTS_SPATIAL: u8 = 2;

/// A message type byte.
#[repr(u8)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MessageType {
    /// [`Message::Hello`].
    Hello = 0x01,
    /// [`Message::Heartbeat`].
    Heartbeat = 0x02,
    /// [`Message::SceneBegin`].
    SceneBegin = 0x10,
    /// [`Message::SceneChunk`].
    SceneChunk = 0x11,
    /// [`Message::SceneCommit`].
    SceneCommit = 0x12,
    /// [`Message::ScenePoints`].
    ScenePoints = 0x13,
    /// [`Message::Ack`].
    Ack = 0x20,
    /// [`Message::Nack`].
    Nack = 0x21,
    /// [`Message::SetMaterial`].
    SetMaterial = 0x30,
    /// [`Message::EnableForces`].
    EnableForces = 0x31,
    /// [`Message::DisableForces`].
    DisableForces = 0x32,
    /// [`Message::Calibrate`].
    Calibrate = 0x33,
    /// [`Message::ClearFaults`].
    ClearFaults = 0x34,
    /// [`Message::HandTarget`].
    HandTarget = 0x35,
    /// [`Message::Excite`].
    Excite = 0x36,
    /// [`Message::Status`].
    Status = 0x40,
    /// [`Message::Telemetry`].
    Telemetry = 0x50,
}

impl MessageType {
    /// Every type.
    pub const ALL: [MessageType; 17] = [
        MessageType::Hello,
        MessageType::Heartbeat,
        MessageType::SceneBegin,
        MessageType::SceneChunk,
        MessageType::SceneCommit,
        MessageType::ScenePoints,
        MessageType::Ack,
        MessageType::Nack,
        MessageType::SetMaterial,
        MessageType::EnableForces,
        MessageType::DisableForces,
        MessageType::Calibrate,
        MessageType::ClearFaults,
        MessageType::HandTarget,
        MessageType::Excite,
        MessageType::Status,
        MessageType::Telemetry,
    ];

    /// The type with wire value `value`, if any.
    pub fn from_u8(value: u8) -> Option<Self> {
        Self::ALL.iter().copied().find(|&t| t as u8 == value)
    }

    /// The payload length range of the type (fixed for all but scene chunks and points).
    pub fn payload_len(self) -> core::ops::RangeInclusive<usize> {
        let n = match self {
            MessageType::Hello => 8,
            MessageType::Heartbeat => 4,
            MessageType::SceneBegin => 8,
            MessageType::SceneChunk => return 5..=MAX_PAYLOAD,
            MessageType::SceneCommit => 0,
            MessageType::ScenePoints => {
                return POINTS_HEADER_LEN + 8..=POINTS_HEADER_LEN + 8 * MAX_POINTS_2D;
            }
            MessageType::Ack => 2,
            MessageType::Nack => 7,
            MessageType::SetMaterial => 1 + MATERIAL_LEN,
            MessageType::EnableForces | MessageType::DisableForces | MessageType::Calibrate => 0,
            MessageType::ClearFaults => 2,
            MessageType::HandTarget => 8,
            MessageType::Excite => 16,
            MessageType::Status => 18,
            MessageType::Telemetry => TELEMETRY_LEN,
        };
        n..=n
    }
}

/// Version and capabilities, sent by either side when a link opens.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Hello {
    /// Firmware or host software version (major, minor, patch).
    pub software: [u8; 3],
    /// Largest scene the sender can receive (bytes).
    pub scene_capacity: u32,
    /// Largest payload the sender handles ([`MAX_PAYLOAD`]).
    pub max_payload: u8,
}

/// A piece of an uploaded scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SceneChunk {
    /// Byte offset of the chunk in the scene.
    pub offset: u32,
    len: u8,
    data: [u8; MAX_CHUNK],
}

impl SceneChunk {
    /// A chunk of `data` (1 to [`MAX_CHUNK`] bytes) at `offset`; `None` for other lengths.
    pub fn new(offset: u32, data: &[u8]) -> Option<Self> {
        if data.is_empty() || data.len() > MAX_CHUNK {
            return None;
        }
        let mut buf = [0; MAX_CHUNK];
        buf[..data.len()].copy_from_slice(data);
        Some(SceneChunk {
            offset,
            len: data.len() as u8,
            data: buf,
        })
    }

    /// The chunk's bytes.
    pub fn data(&self) -> &[u8] {
        &self.data[..usize::from(self.len).min(MAX_CHUNK)]
    }
}

/// Control points of one patch of the active scene, replaced in place
/// ([`Message::ScenePoints`]): Cartesian points (a planar curve's x, y or a surface's x, y, z;
/// metres, finite), from control point `first` on, of patch `patch` of object `object`. The
/// weights are the scene's, frozen: not sent, never changed (a point goes into the scene as
/// `(w·x, w·y, w)` with its weight `w` as uploaded). An update may take several frames (more
/// points than one frame holds, or several patches of the object, whose joins must move
/// together); the device stages them and applies them all with the frame that has
/// [`ScenePoints::apply`] set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScenePoints {
    /// Object index in the active scene.
    pub object: u8,
    /// Patch index within the object (as uploaded, not split at corners).
    pub patch: u8,
    /// Index of the first control point replaced (a surface's net `i` along u major, as the
    /// wire scene stores it).
    pub first: u16,
    /// The last frame of the update: validate and apply everything staged.
    pub apply: bool,
    spatial: bool,
    len: u8,
    coords: [f32; 3 * MAX_POINTS_3D],
}

impl ScenePoints {
    /// Planar points (1 to [`MAX_POINTS_2D`]); `None` for other counts.
    pub fn planar(object: u8, patch: u8, first: u16, apply: bool, points: &[Vec2]) -> Option<Self> {
        if points.is_empty() || points.len() > MAX_POINTS_2D {
            return None;
        }
        let mut coords = [0.0; 3 * MAX_POINTS_3D];
        for (c, p) in coords.chunks_exact_mut(2).zip(points) {
            c.copy_from_slice(&[p.x, p.y]);
        }
        Some(ScenePoints {
            object,
            patch,
            first,
            apply,
            spatial: false,
            len: points.len() as u8,
            coords,
        })
    }

    /// Surface points (1 to [`MAX_POINTS_3D`]); `None` for other counts.
    pub fn spatial(
        object: u8,
        patch: u8,
        first: u16,
        apply: bool,
        points: &[Vec3],
    ) -> Option<Self> {
        if points.is_empty() || points.len() > MAX_POINTS_3D {
            return None;
        }
        let mut coords = [0.0; 3 * MAX_POINTS_3D];
        for (c, p) in coords.chunks_exact_mut(3).zip(points) {
            c.copy_from_slice(&[p.x, p.y, p.z]);
        }
        Some(ScenePoints {
            object,
            patch,
            first,
            apply,
            spatial: true,
            len: points.len() as u8,
            coords,
        })
    }

    /// Whether the points are a surface's (x, y, z) rather than a planar curve's (x, y).
    pub fn is_spatial(&self) -> bool {
        self.spatial
    }

    /// Coordinates per point: 2 or 3.
    pub fn dims(&self) -> usize {
        if self.spatial { 3 } else { 2 }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        usize::from(self.len)
    }

    /// Whether there are no points (never, for a message from a constructor or the wire).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The coordinates, point after point (`dims()` each).
    pub fn coords(&self) -> &[f32] {
        &self.coords[..(self.len() * self.dims()).min(self.coords.len())]
    }

    /// The planar points (none when spatial).
    pub fn planar_points(&self) -> impl Iterator<Item = Vec2> + '_ {
        let c = if self.spatial { &[][..] } else { self.coords() };
        c.chunks_exact(2).map(|c| Vec2::new(c[0], c[1]))
    }

    /// The surface points (none when planar).
    pub fn spatial_points(&self) -> impl Iterator<Item = Vec3> + '_ {
        let c = if self.spatial { self.coords() } else { &[][..] };
        c.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2]))
    }
}

/// A rejected frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Nack {
    /// Sequence number of the rejected frame, [`UNKNOWN_SEQ`] when it could not be read.
    pub seq: u16,
    /// Why.
    pub code: ErrorCode,
    /// Object at fault in a rejected scene, [`NO_INDEX`] otherwise.
    pub object: u8,
    /// Patch (within the object) at fault in a rejected scene, [`NO_INDEX`] otherwise.
    pub patch: u8,
    /// The sequence number the receiver expects next.
    pub expected_seq: u16,
}

/// Device state, sent in reply to a heartbeat.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Status {
    /// Forces are enabled.
    pub forces_enabled: bool,
    /// The device has been calibrated.
    pub calibrated: bool,
    /// Latched fault flags (bit meanings belong to the safety layer).
    pub faults: u16,
    /// Length of the active scene (bytes).
    pub scene_len: u32,
    /// CRC-32 of the active scene.
    pub scene_crc32: u32,
    /// Bytes received of an upload in progress (0 when none).
    pub upload_received: u32,
    /// Sequence number the device expects next from the host.
    pub expected_seq: u16,
    /// Wire value of the latest refusal's code, 0 if none: cleared once a status carried it,
    /// or when a later request was accepted (`protocol::device_side::session::DeviceSession::handle`).
    pub last_error: u8,
}

/// Payload bytes of a telemetry frame.
pub const TELEMETRY_LEN: usize = 57;

/// Largest feature index telemetry carries; larger ones saturate.
pub const MAX_FEATURE_INDEX: u16 = 0x3FFE;
const NO_FEATURE: u16 = 0xFFFF;

fn feature_to_u16(f: Option<Feature>) -> u16 {
    let (kind, i) = match f {
        None => return NO_FEATURE,
        Some(Feature::Patch(i)) => (0, i),
        Some(Feature::Vertex(i)) => (1, i),
        Some(Feature::Edge(i)) => (2, i),
        Some(Feature::Corner(i)) => (3, i),
    };
    (kind << 14) | i.min(MAX_FEATURE_INDEX)
}

/// The inverse of [`feature_to_u16`]; `Err` for the codes it never produces (index 0x3FFF
/// of a patch, vertex or edge: indices saturate at [`MAX_FEATURE_INDEX`]).
fn feature_from_u16(v: u16) -> Result<Option<Feature>, ErrorCode> {
    if v == NO_FEATURE {
        return Ok(None);
    }
    let i = v & 0x3FFF;
    if i > MAX_FEATURE_INDEX {
        return Err(ErrorCode::BadField);
    }
    Ok(Some(match v >> 14 {
        0 => Feature::Patch(i),
        1 => Feature::Vertex(i),
        2 => Feature::Edge(i),
        _ => Feature::Corner(i),
    }))
}

/// A float field of telemetry: the device's safety layer and renderer only ever produce
/// finite values, so NaN or an infinity is a malformed frame.
fn finite(r: &mut Reader<'_>) -> Result<f32, ErrorCode> {
    match r.f32() {
        Some(v) if v.is_finite() => Ok(v),
        Some(_) => Err(ErrorCode::BadField),
        None => Err(ErrorCode::BadPayloadLength),
    }
}

/// The mode byte: the mode's code (its index in [`Mode::ALL`]) in the low nibble, the switch
/// cause's (its index in [`SwitchCause::ALL`]) in the high one.
fn mode_to_u8(m: Mode, c: SwitchCause) -> u8 {
    let code = |i: Option<usize>| i.unwrap_or(0) as u8;
    code(Mode::ALL.iter().position(|&x| x == m))
        | code(SwitchCause::ALL.iter().position(|&x| x == c)) << 4
}

fn mode_from_u8(v: u8) -> Option<(Mode, SwitchCause)> {
    let mode = *Mode::ALL.get(usize::from(v & 0x0F))?;
    let cause = *SwitchCause::ALL.get(usize::from(v >> 4))?;
    Some((mode, cause))
}

/// Every message of the protocol. `→ dev` / `→ host` give the direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Message {
    /// Both ways: versions and capabilities; resynchronises sequence numbers.
    Hello(Hello),
    /// → dev: the host is alive (feeds the device watchdog); the device answers with status.
    Heartbeat {
        /// Host time (ms).
        uptime_ms: u32,
    },
    /// → dev: a scene upload starts.
    SceneBegin {
        /// Length of the whole scene (bytes).
        total_len: u32,
        /// CRC-32/ISO-HDLC of the whole scene.
        crc32: u32,
    },
    /// → dev: the next piece of the scene.
    SceneChunk(SceneChunk),
    /// → dev: all pieces sent; verify, validate and activate.
    SceneCommit,
    /// → dev: replace control points of a patch of the active scene in place (staged; the
    /// frame with the apply flag validates the update and activates it, between ticks).
    ScenePoints(ScenePoints),
    /// → host: the frame with this sequence number was accepted.
    Ack {
        /// Sequence number of the accepted frame.
        seq: u16,
    },
    /// → host: a frame was rejected.
    Nack(Nack),
    /// → dev: replace the material of one object of the active scene.
    SetMaterial {
        /// Object index.
        object: u8,
        /// The material (validated on decode).
        material: FrictionMaterial,
    },
    /// → dev: enable forces (ramped in by the safety layer).
    EnableForces,
    /// → dev: disable forces.
    DisableForces,
    /// → dev: run the calibration against the end stops.
    Calibrate,
    /// → dev: clear the latched faults in `mask`.
    ClearFaults {
        /// Fault bits to clear.
        mask: u16,
    },
    /// → dev: where the virtual hand pulls the handle (m, device frame). Only a simulated plant
    /// (the host's simulator, the firmware under QEMU) has a virtual hand; a board refuses it
    /// with [`ErrorCode::NotSimulated`].
    HandTarget {
        /// The hand's target (finite, checked on decode).
        target_m: Vec2,
    },
    /// → dev: an identification run ([`Excitation`](device::controller::Excitation)): the
    /// motors apply square waves of joint torque for a while instead of rendering; the
    /// telemetry shows the motion and the force. Nacked, not acked, when the device is not
    /// calibrated ([`ErrorCode::NotCalibrated`]) or a torque is beyond its motors
    /// ([`ErrorCode::TorqueBeyondMotor`]).
    Excite {
        /// Square-wave amplitude per joint (N·m, finite, checked on decode).
        torque_nm: [f32; 2],
        /// Half-period per joint (ms, ≥ 1).
        half_period_ms: [u16; 2],
        /// How long the run lasts (ms, ≥ 1).
        duration_ms: u32,
    },
    /// → host: device state.
    Status(Status),
    /// → host: one haptic tick.
    Telemetry(Telemetry),
}

impl Message {
    /// The message's type byte.
    pub fn message_type(&self) -> MessageType {
        match self {
            Message::Hello(_) => MessageType::Hello,
            Message::Heartbeat { .. } => MessageType::Heartbeat,
            Message::SceneBegin { .. } => MessageType::SceneBegin,
            Message::SceneChunk(_) => MessageType::SceneChunk,
            Message::SceneCommit => MessageType::SceneCommit,
            Message::ScenePoints(_) => MessageType::ScenePoints,
            Message::Ack { .. } => MessageType::Ack,
            Message::Nack(_) => MessageType::Nack,
            Message::SetMaterial { .. } => MessageType::SetMaterial,
            Message::EnableForces => MessageType::EnableForces,
            Message::DisableForces => MessageType::DisableForces,
            Message::Calibrate => MessageType::Calibrate,
            Message::ClearFaults { .. } => MessageType::ClearFaults,
            Message::HandTarget { .. } => MessageType::HandTarget,
            Message::Excite { .. } => MessageType::Excite,
            Message::Status(_) => MessageType::Status,
            Message::Telemetry(_) => MessageType::Telemetry,
        }
    }

    fn put_payload(&self, w: &mut impl Sink) {
        match self {
            Message::Hello(h) => {
                w.put(&h.software);
                w.u32(h.scene_capacity);
                w.u8(h.max_payload);
            }
            Message::Heartbeat { uptime_ms } => w.u32(*uptime_ms),
            Message::SceneBegin { total_len, crc32 } => {
                w.u32(*total_len);
                w.u32(*crc32);
            }
            Message::SceneChunk(c) => {
                w.u32(c.offset);
                w.put(c.data());
            }
            Message::ScenePoints(p) => {
                w.u8(p.object);
                w.u8(p.patch);
                w.u16(p.first);
                let apply = if p.apply { POINTS_APPLY } else { 0 };
                let spatial = if p.spatial { POINTS_SPATIAL } else { 0 };
                w.u8(apply | spatial);
                for &c in p.coords() {
                    w.f32(c);
                }
            }
            Message::SceneCommit
            | Message::EnableForces
            | Message::DisableForces
            | Message::Calibrate => {}
            Message::Ack { seq } => w.u16(*seq),
            Message::Nack(n) => {
                w.u16(n.seq);
                w.u8(n.code as u8);
                w.u8(n.object);
                w.u8(n.patch);
                w.u16(n.expected_seq);
            }
            Message::SetMaterial { object, material } => {
                w.u8(*object);
                put_material(w, material);
            }
            Message::ClearFaults { mask } => w.u16(*mask),
            Message::HandTarget { target_m } => {
                w.f32(target_m.x);
                w.f32(target_m.y);
            }
            Message::Excite {
                torque_nm,
                half_period_ms,
                duration_ms,
            } => {
                w.f32(torque_nm[0]);
                w.f32(torque_nm[1]);
                w.u16(half_period_ms[0]);
                w.u16(half_period_ms[1]);
                w.u32(*duration_ms);
            }
            Message::Status(s) => {
                w.u8(u8::from(s.forces_enabled) | (u8::from(s.calibrated) << 1));
                w.u16(s.faults);
                w.u32(s.scene_len);
                w.u32(s.scene_crc32);
                w.u32(s.upload_received);
                w.u16(s.expected_seq);
                w.u8(s.last_error);
            }
            Message::Telemetry(t) => {
                w.u32(t.time_us);
                for v in [t.hip_m, t.cp_m, t.go_m] {
                    w.f32(v.x);
                    w.f32(v.y);
                }
                w.f32(t.force_normal_n);
                w.f32(t.go_param);
                w.f32(t.force_n.x);
                w.f32(t.force_n.y);
                w.f32(t.psi);
                w.u16(t.mu_e4);
                w.u16(t.tick_us);
                w.u16(t.faults);
                w.u16(feature_to_u16(t.feature));
                w.u8(mode_to_u8(t.mode, t.cause));
            }
        }
    }

    /// Decodes the payload of a message of type `ty`.
    pub fn decode_payload(ty: MessageType, payload: &[u8]) -> Result<Message, ErrorCode> {
        if !ty.payload_len().contains(&payload.len()) {
            return Err(ErrorCode::BadPayloadLength);
        }
        let r = &mut Reader::new(payload);
        // The length was checked above, so a short read cannot happen; it still maps to an
        // error rather than a panic.
        let short = ErrorCode::BadPayloadLength;
        let msg = match ty {
            MessageType::Hello => Message::Hello(Hello {
                software: [
                    r.u8().ok_or(short)?,
                    r.u8().ok_or(short)?,
                    r.u8().ok_or(short)?,
                ],
                scene_capacity: r.u32().ok_or(short)?,
                max_payload: r.u8().ok_or(short)?,
            }),
            MessageType::Heartbeat => Message::Heartbeat {
                uptime_ms: r.u32().ok_or(short)?,
            },
            MessageType::SceneBegin => Message::SceneBegin {
                total_len: r.u32().ok_or(short)?,
                crc32: r.u32().ok_or(short)?,
            },
            MessageType::SceneChunk => {
                let offset = r.u32().ok_or(short)?;
                let data = r.take(r.remaining()).ok_or(short)?;
                Message::SceneChunk(SceneChunk::new(offset, data).ok_or(short)?)
            }
            MessageType::SceneCommit => Message::SceneCommit,
            MessageType::ScenePoints => {
                let object = r.u8().ok_or(short)?;
                let patch = r.u8().ok_or(short)?;
                let first = r.u16().ok_or(short)?;
                let flags = r.u8().ok_or(short)?;
                if flags & !(POINTS_APPLY | POINTS_SPATIAL) != 0 {
                    return Err(ErrorCode::BadField);
                }
                let spatial = flags & POINTS_SPATIAL != 0;
                let (size, most) = if spatial {
                    (12, MAX_POINTS_3D)
                } else {
                    (8, MAX_POINTS_2D)
                };
                let n = r.remaining() / size;
                if !r.remaining().is_multiple_of(size) || n == 0 || n > most {
                    return Err(short);
                }
                let mut coords = [0.0; 3 * MAX_POINTS_3D];
                for c in coords.iter_mut().take(n * (size / 4)) {
                    *c = finite(r)?;
                }
                Message::ScenePoints(ScenePoints {
                    object,
                    patch,
                    first,
                    apply: flags & POINTS_APPLY != 0,
                    spatial,
                    len: n as u8,
                    coords,
                })
            }
            MessageType::Ack => Message::Ack {
                seq: r.u16().ok_or(short)?,
            },
            MessageType::Nack => Message::Nack(Nack {
                seq: r.u16().ok_or(short)?,
                code: ErrorCode::from_u8(r.u8().ok_or(short)?).ok_or(ErrorCode::BadField)?,
                object: r.u8().ok_or(short)?,
                patch: r.u8().ok_or(short)?,
                expected_seq: r.u16().ok_or(short)?,
            }),
            MessageType::SetMaterial => Message::SetMaterial {
                object: r.u8().ok_or(short)?,
                material: get_material(r)?,
            },
            MessageType::EnableForces => Message::EnableForces,
            MessageType::DisableForces => Message::DisableForces,
            MessageType::Calibrate => Message::Calibrate,
            MessageType::ClearFaults => Message::ClearFaults {
                mask: r.u16().ok_or(short)?,
            },
            MessageType::HandTarget => Message::HandTarget {
                target_m: Vec2::new(finite(r)?, finite(r)?),
            },
            MessageType::Excite => {
                let torque_nm = [finite(r)?, finite(r)?];
                let half_period_ms = [r.u16().ok_or(short)?, r.u16().ok_or(short)?];
                let duration_ms = r.u32().ok_or(short)?;
                if half_period_ms.contains(&0) || duration_ms == 0 {
                    return Err(ErrorCode::BadField);
                }
                Message::Excite {
                    torque_nm,
                    half_period_ms,
                    duration_ms,
                }
            }
            MessageType::Status => {
                let flags = r.u8().ok_or(short)?;
                if flags & !0b11 != 0 {
                    return Err(ErrorCode::BadField);
                }
                Message::Status(Status {
                    forces_enabled: flags & 1 != 0,
                    calibrated: flags & 2 != 0,
                    faults: r.u16().ok_or(short)?,
                    scene_len: r.u32().ok_or(short)?,
                    scene_crc32: r.u32().ok_or(short)?,
                    upload_received: r.u32().ok_or(short)?,
                    expected_seq: r.u16().ok_or(short)?,
                    last_error: r.u8().ok_or(short)?,
                })
            }
            MessageType::Telemetry => {
                let time_us = r.u32().ok_or(short)?;
                let mut v = [Vec2::ZERO; 4];
                for p in &mut v[..3] {
                    *p = Vec2::new(finite(r)?, finite(r)?);
                }
                let force_normal_n = finite(r)?;
                let go_param = finite(r)?;
                v[3] = Vec2::new(finite(r)?, finite(r)?);
                let psi = finite(r)?;
                let mu_e4 = r.u16().ok_or(short)?;
                let tick_us = r.u16().ok_or(short)?;
                let faults = r.u16().ok_or(short)?;
                let feature = feature_from_u16(r.u16().ok_or(short)?)?;
                let (mode, cause) =
                    mode_from_u8(r.u8().ok_or(short)?).ok_or(ErrorCode::BadField)?;
                Message::Telemetry(Telemetry {
                    time_us,
                    hip_m: v[0],
                    cp_m: v[1],
                    go_m: v[2],
                    force_normal_n,
                    go_param,
                    force_n: v[3],
                    psi,
                    mu_e4,
                    tick_us,
                    faults,
                    feature,
                    mode,
                    cause,
                })
            }
        };
        Ok(msg)
    }
}

/// A decoded frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Sequence number.
    pub seq: u16,
    /// The message.
    pub message: Message,
}

/// Why a byte string is not a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameError {
    /// Why.
    pub code: ErrorCode,
    /// The frame's sequence number when its CRC was good, so it can be trusted.
    pub seq: Option<u16>,
}

impl Frame {
    /// Encodes into `out` and returns the frame length (7 to 64 bytes). Bytes of `out` past
    /// that are left as they are (pad with zeros for a fixed-size HID report).
    pub fn encode(&self, out: &mut [u8; MAX_FRAME]) -> usize {
        let mut payload = [0u8; MAX_PAYLOAD];
        let mut w = Writer::new(&mut payload);
        self.message.put_payload(&mut w);
        // Every payload fits MAX_PAYLOAD by construction (see `MessageType::payload_len`).
        let n = w.finish().unwrap_or(0);
        out[0] = VERSION;
        out[1] = self.message.message_type() as u8;
        out[2..4].copy_from_slice(&self.seq.to_le_bytes());
        out[4] = n as u8;
        out[HEADER_LEN..HEADER_LEN + n].copy_from_slice(&payload[..n]);
        let end = HEADER_LEN + n;
        let crc = crc16_ccitt_false(&out[..end]);
        out[end..end + CRC_LEN].copy_from_slice(&crc.to_le_bytes());
        end + CRC_LEN
    }

    /// Encodes into a new 64-byte report, zero padded, and returns it with the frame length.
    pub fn to_report(&self) -> ([u8; MAX_FRAME], usize) {
        let mut out = [0; MAX_FRAME];
        let n = self.encode(&mut out);
        (out, n)
    }

    /// Decodes a frame from `bytes`: exactly a frame, or a frame followed by padding (as in a
    /// 64-byte HID report). Total: never panics, every malformed input gives an error code.
    ///
    /// Checks, in order: length (header and CRC present, at most 64 bytes, payload-length
    /// byte ≤ 57 and within `bytes`), CRC, version, type, payload length for the type,
    /// payload fields.
    pub fn decode(bytes: &[u8]) -> Result<Frame, FrameError> {
        let fail = |code, seq| Err(FrameError { code, seq });
        if bytes.len() < HEADER_LEN + CRC_LEN || bytes.len() > MAX_FRAME {
            return fail(ErrorCode::BadLength, None);
        }
        let n = usize::from(bytes[4]);
        let end = HEADER_LEN + n;
        if n > MAX_PAYLOAD || end + CRC_LEN > bytes.len() {
            return fail(ErrorCode::BadLength, None);
        }
        let crc = u16::from_le_bytes([bytes[end], bytes[end + 1]]);
        if crc != crc16_ccitt_false(&bytes[..end]) {
            return fail(ErrorCode::BadCrc, None);
        }
        let seq = u16::from_le_bytes([bytes[2], bytes[3]]);
        if bytes[0] != VERSION {
            return fail(ErrorCode::BadVersion, Some(seq));
        }
        let Some(ty) = MessageType::from_u8(bytes[1]) else {
            return fail(ErrorCode::UnknownType, Some(seq));
        };
        match Message::decode_payload(ty, &bytes[HEADER_LEN..end]) {
            Ok(message) => Ok(Frame { seq, message }),
            Err(code) => fail(code, Some(seq)),
        }
    }
}
