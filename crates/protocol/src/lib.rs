//! The wire protocol shared by the firmware and the host: 64-byte frames with a CRC, the
//! messages, the scene upload and the compact binary scene.
//!
//! The crate root and [`device_side`] are `no_std` and allocation-free except
//! [`encode_scene`] (host, `std`); `host_side` (feature `std`) is the host's half.
//!
//! - **Shared**: [`Message`] and [`Frame`] (the tables below), the CRCs, the binary scene
//!   ([`SceneStore`], [`encode_scene`]), the upload and its receiver ([`SceneReceiver`]).
//! - **The device's half**, [`device_side`]: the session a device runs behind its transport
//!   and the board's USB HID class (feature `usb`).
//! - **The host's half**, `host_side` (feature `std`): the `Link` trait and its transports
//!   (USB HID, serial, TCP) and the simulated device on a thread.
//!
//! `tests/frames.rs` checks the tables below against hand-written frame bytes.
//! Decoding is total: any byte string gives a message or an [`ErrorCode`], never a panic.
//! All multi-byte values are little-endian; floats are IEEE-754 `f32`.
//!
//! # Frame (at most 64 bytes: one USB full-speed HID report)
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 1 | protocol version ([`VERSION`] = 1) |
//! | 1 | 1 | message type ([`MessageType`]) |
//! | 2 | 2 | sequence number (u16, per sender, wrapping) |
//! | 4 | 1 | payload length `n` (0 ..= [`MAX_PAYLOAD`] = 57) |
//! | 5 | n | payload |
//! | 5 + n | 2 | CRC-16/CCITT-FALSE of bytes `0 .. 5 + n` |
//!
//! A frame may be followed by padding (a fixed 64-byte HID report); the decoder ignores it.
//! The decoder checks length, then CRC, then version, type and payload, so a damaged frame
//! reads as [`ErrorCode::BadLength`] or [`ErrorCode::BadCrc`], and the sequence number is only
//! trusted (echoed in the nack) once the CRC is good.
//!
//! # Messages (payload bytes)
//!
//! | type | message | dir | payload | layout |
//! |---|---|---|---|---|
//! | 0x01 | [`Message::Hello`] | both | 8 | software version `[u8; 3]`, scene capacity u32, max payload u8 |
//! | 0x02 | [`Message::Heartbeat`] | → dev | 4 | host uptime ms u32 |
//! | 0x10 | [`Message::SceneBegin`] | → dev | 8 | total length u32, CRC-32 of the scene u32 |
//! | 0x11 | [`Message::SceneChunk`] | → dev | 5 ..= 57 | byte offset u32, 1 ..= [`MAX_CHUNK`] = 53 bytes |
//! | 0x12 | [`Message::SceneCommit`] | → dev | 0 | |
//! | 0x13 | [`Message::ScenePoints`] | → dev | 13 ..= 53 | object u8, patch u8, first control point u16, flags u8 (bit 0 [`POINTS_APPLY`], bit 1 [`POINTS_SPATIAL`]), then 1 ..= 6 planar points x, y or 1 ..= 4 surface points x, y, z (f32, m); below |
//! | 0x20 | [`Message::Ack`] | → host | 2 | acked sequence number u16 |
//! | 0x21 | [`Message::Nack`] | → host | 7 | rejected seq u16 ([`UNKNOWN_SEQ`] if unreadable), [`ErrorCode`] u8, object u8, patch u8 ([`NO_INDEX`] if none), expected seq u16 |
//! | 0x30 | [`Message::SetMaterial`] | → dev | 52 | object u8, material (51, below) |
//! | 0x31 | [`Message::EnableForces`] | → dev | 0 | |
//! | 0x32 | [`Message::DisableForces`] | → dev | 0 | |
//! | 0x33 | [`Message::Calibrate`] | → dev | 0 | |
//! | 0x34 | [`Message::ClearFaults`] | → dev | 2 | fault mask u16 |
//! | 0x35 | [`Message::HandTarget`] | → dev | 8 | virtual hand target x, y (f32, m); simulated plants only, a board nacks it with [`ErrorCode::NotSimulated`] |
//! | 0x36 | [`Message::Excite`] | → dev | 16 | torque amplitude per joint (f32 × 2, N·m), half-period per joint (u16 × 2, ms), duration u32 (ms) |
//! | 0x40 | [`Message::Status`] | → host | 18 | flags u8 (bit 0 forces enabled, bit 1 calibrated), faults u16, scene length u32, scene CRC-32 u32, upload bytes received u32, expected seq u16, last error u8 |
//! | 0x50 | [`Message::Telemetry`] | → host | 57 | below |
//!
//! Material (51 bytes): 12 × f32 — stiffness N/m, damping N·s/m, μs, μd, transition time s,
//! convergence tolerance m, stop speed m/s, viscous N·s/m, Karnopp band m/s, bristle
//! stiffness N/m, bristle damping N·s/m, Stribeck speed m/s — then Stribeck tag u8 (0 linear,
//! 1 power, 2 smoothstep), exponent u8 (≥ 1 for power, else 0), model u8 (0 stick–slip,
//! 1 Coulomb–viscous, 2 Karnopp, 3 Dahl, 4 LuGre). Decoding validates the `scene/1` ranges
//! ([`friction::FrictionMaterial::validate`], the rules the scene loader applies too).
//!
//! Telemetry (57 bytes, so the frame is exactly 64):
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 4 | time µs (u32) |
//! | 4 | 8 | HIP x, y (f32, m) |
//! | 12 | 8 | CP x, y |
//! | 20 | 8 | GO x, y |
//! | 28 | 4 | normal force (f32, N) |
//! | 32 | 4 | GO parameter u (f32): the GO's parameter on its patch (the scene patch's, shared by the pieces it is split into), where the force acts; 0 when nothing renders. The friction force follows from the total and normal forces. |
//! | 36 | 8 | total force x, y (f32, N) |
//! | 44 | 4 | Ψ (f32) |
//! | 48 | 2 | μ × 10⁴ (u16) |
//! | 50 | 2 | tick duration µs (u16) |
//! | 52 | 2 | fault flags (u16) |
//! | 54 | 2 | feature: kind in bits 15–14 (0 patch, 1 vertex, 2 edge, 3 corner), index in bits 13–0; 0xFFFF none |
//! | 56 | 1 | friction mode in bits 3–0 (0 free, 1 stuck, 2 transition, 3 slip); the cause of its last switch in bits 7–4 (0 none, 1 contact, 2 breakaway, 3 converged, 4 stopped, 5 reversed, 6 normal-force jump, 7 released) |
//!
//! Every float of telemetry is finite and the feature index at most [`MAX_FEATURE_INDEX`]
//! (0x3FFE; larger indices saturate there), so a frame with NaN or an infinity, or a feature
//! code 0x3FFF / 0x7FFF / 0xBFFF, is malformed: [`ErrorCode::BadField`].
//!
//! A device numbers its telemetry frames and its replies (hello, ack, nack, status) on two
//! counters (each every value from 0, wrapping; [`device_side::Numbering`]): telemetry
//! numbers count the frames the device produced, one per millisecond, so the host sees
//! dropped telemetry as gaps in them whatever replies were sent meanwhile (over USB the
//! replies travel on an endpoint of their own, and their order relative to telemetry is not
//! kept). A host numbers its own frames on one counter, skipping [`UNKNOWN_SEQ`].
//!
//! # Scene upload
//!
//! `SceneBegin { total_len, crc32 }`, then `SceneChunk`s whose offsets follow each other with
//! no gap or overlap, then `SceneCommit`; the device acks or nacks every frame.
//! [`SceneReceiver`] implements the device side; [`scene_upload`] produces the messages. The
//! upload is for a new scene or a new topology; a shape that moves (a deformable model's) goes
//! as control-point updates.
//!
//! # Control-point update
//!
//! One or more [`Message::ScenePoints`] of one object of the active scene, the last with the
//! apply flag: new Cartesian positions for control points of its patches (a patch as
//! uploaded, its points as the scene stores them, a surface's net `i` along u major), x, y for
//! a planar curve, x, y, z with [`POINTS_SPATIAL`] for a surface. The weights are frozen: they
//! are not sent, and a point goes into the scene as `(w·x, w·y[, w·z], w)` with the weight it
//! was uploaded with ([`write_points`], which a host also runs on its copy to know the scene's
//! CRC-32). An update may span frames (more than [`MAX_POINTS_2D`] or [`MAX_POINTS_3D`]
//! points) and patches (the curves on both sides of a join move together, or the chain comes
//! apart); the device stages the frames and applies them all on the apply frame, so the tick
//! never sees half an update: the receiver copies the active scene into its staging buffer,
//! writes the points there, and on the apply frame validates the result as a commit with the
//! object's topology unchanged ([`SceneValidator::validate_reshape`],
//! [`SceneStore::decode_reshaped`]) before it swaps it in with its new CRC-32 (what
//! `Status.scene_crc32` reports). The device then gives its controller the reshaped object at
//! a tick boundary, keeping the renderer (no search, no ramp-in;
//! `Controller::replace_object`, `Controller::reshape_object`). Every refusal names its
//! cause ([`ErrorCode::NoActiveScene`], [`ErrorCode::NoSuchPatch`],
//! [`ErrorCode::PointsPastPatch`], [`ErrorCode::PointsKind`], [`ErrorCode::BadField`] for a
//! non-finite coordinate, [`ErrorCode::StagingBusy`], [`ErrorCode::TopologyChanged`], a
//! validation's own code) and drops the whole update, its later frames refused with
//! [`ErrorCode::UpdateAborted`] up to its apply frame; the active scene, its CRC and the
//! controller stay as they were. A scene upload that begins between an update's frames drops
//! the update too, its later frames refused with [`ErrorCode::UpdateInterrupted`] up to its
//! apply frame: no part of it lands on the uploaded scene. [`points_update`] produces the
//! frames.
//!
//! # Scene on the wire
//!
//! | bytes | field |
//! |---|---|
//! | 4 | magic `"NRBS"` |
//! | 1 | format version ([`SCENE_VERSION`] = 1) |
//! | 1 | object count (1 ..= [`MAX_OBJECTS`]) |
//! | 2 | reserved, 0 |
//! | per object: 51 | material (as above) |
//! | 1 | patch count (≥ 1) |
//! | per planar curve: 1 | kind [`KIND_CURVE2`] = 1 |
//! | 1 | degree |
//! | 2 | knot count `m` (u16) |
//! | 2 | control point count `n` (u16) |
//! | 4m | knots (f32) |
//! | 12n | homogeneous points `(w·x, w·y, w)` (f32) |
//! | per surface: 1 | kind [`KIND_SURFACE`] = 2 |
//! | 2 | degrees p, q |
//! | 4 | knot counts along u, v (u16 each) |
//! | 4 | control point counts along u, v (u16 each) |
//! | 4 (m_u + m_v) | knots U then V (f32) |
//! | 16 n_u n_v | homogeneous points `(w·x, w·y, w·z, w)`, `i` along u major (f32) |
//!
//! Points are homogeneous, as `nurbs` stores them, so a scene survives the trip
//! bit-for-bit. Nothing may follow the last patch. [`SceneStore::decode`] validates it all
//! with the host's own checks: materials, `nurbs::Curve::new` / `nurbs::Surface::new` per
//! patch, `tracker::Chain::new` / `tracker::Shell::new` per object.

#![cfg_attr(not(feature = "std"), no_std)]
#![warn(missing_docs)]

mod crc;
pub mod device_side;
mod error;
#[cfg(feature = "std")]
pub mod host_side;
mod message;
mod receiver;
mod scene;
mod wire;

pub use crc::{Crc32, crc16_ccitt_false, crc32};
pub use error::ErrorCode;
pub use message::{
    CRC_LEN, Frame, FrameError, HEADER_LEN, Hello, MAX_CHUNK, MAX_FEATURE_INDEX, MAX_FRAME,
    MAX_PAYLOAD, MAX_POINTS_2D, MAX_POINTS_3D, Message, MessageType, NO_INDEX, Nack, POINTS_APPLY,
    POINTS_HEADER_LEN, POINTS_SPATIAL, SceneChunk, ScenePoints, Status, TELEMETRY_LEN, Telemetry,
    UNKNOWN_SEQ, VERSION, next_seq,
};
pub use receiver::{SceneReceiver, SceneValidator};
pub use scene::{
    KIND_CURVE2, KIND_SURFACE, MAX_CURVE_POINTS, MAX_KNOTS, MAX_OBJECTS, MAX_PATCHES,
    MAX_SURFACE_POINTS, PatchKind, PointSpan, SCENE_MAGIC, SCENE_VERSION, SceneFault, SceneStore,
    WireSceneError, decode_scene, patch_points, points_span, write_points,
};
#[cfg(feature = "std")]
pub use scene::{WireObject, WirePatch, encode_scene};
pub use wire::MATERIAL_LEN;

use nurbs::{Vec2, Vec3};

/// USB vendor id of the board (its HID interface carries the frames, one per 64-byte report):
/// pid.codes' open-source vendor id. A placeholder until the project has a product id of its
/// own. Here (no_std) so that the firmware and the host (`protocol::host_side`) share it.
pub const USB_VID: u16 = 0x1209;
/// USB product id of the board: pid.codes' test PID (`0x0001`), reserved for development and
/// not unique; replace it with an allocated one before boards leave the lab.
pub const USB_PID: u16 = 0x0001;

/// The report descriptor of the board's first HID interface: one vendor-defined collection
/// ([`HID_USAGE_TELEMETRY`]) with a 64-byte ([`MAX_FRAME`]) input report (telemetry) and a
/// 64-byte output report (the host's frames) and no report ids, so every report is one
/// frame. The board's firmware presents it; the host's `HidLink` (`protocol::host_side`,
/// feature `std`) relies on it (it writes report id 0 before each frame and reads bare
/// frames). The replies have an interface of their own, [`REPLY_REPORT_DESCRIPTOR`].
#[rustfmt::skip]
pub const REPORT_DESCRIPTOR: &[u8] = &[
    0x06, 0x00, 0xFF, // Usage Page (vendor defined 0xFF00)
    0x09, 0x01,       // Usage (1)
    0xA1, 0x01,       // Collection (application)
    0x09, 0x02,       //   Usage (2)
    0x15, 0x00,       //   Logical minimum (0)
    0x26, 0xFF, 0x00, //   Logical maximum (255)
    0x75, 0x08,       //   Report size (8 bits)
    0x95, 0x40,       //   Report count (64)
    0x81, 0x02,       //   Input (data, variable, absolute)
    0x09, 0x03,       //   Usage (3)
    0x15, 0x00,       //   Logical minimum (0)
    0x26, 0xFF, 0x00, //   Logical maximum (255)
    0x75, 0x08,       //   Report size (8 bits)
    0x95, 0x40,       //   Report count (64)
    0x91, 0x02,       //   Output (data, variable, absolute)
    0xC0,             // End collection
];

/// The board's USB interface of the host's frames (OUT) and the telemetry (IN),
/// [`REPORT_DESCRIPTOR`]'s.
pub const HID_TELEMETRY_INTERFACE: u8 = 0;
/// The board's USB interface of the replies (IN only), [`REPLY_REPORT_DESCRIPTOR`]'s.
pub const HID_REPLY_INTERFACE: u8 = 1;
/// The HID usage page of the board's report descriptors (vendor defined).
pub const HID_USAGE_PAGE: u16 = 0xFF00;
/// The usage of [`REPORT_DESCRIPTOR`]'s collection (interface 0: host frames, telemetry).
pub const HID_USAGE_TELEMETRY: u16 = 0x01;
/// The usage of [`REPLY_REPORT_DESCRIPTOR`]'s collection (interface 1: replies), by which a
/// host tells the two interfaces of a board apart.
pub const HID_USAGE_REPLIES: u16 = 0x10;

/// The report descriptor of the board's second HID interface, the replies' (ack, nack,
/// status, hello): one vendor-defined collection ([`HID_USAGE_REPLIES`]) with a 64-byte input
/// report and no report ids, so that replies have an IN endpoint of their own and cost the
/// telemetry on interface 0's none (`device_side::usb`).
#[rustfmt::skip]
pub const REPLY_REPORT_DESCRIPTOR: &[u8] = &[
    0x06, 0x00, 0xFF, // Usage Page (vendor defined 0xFF00)
    0x09, 0x10,       // Usage (0x10)
    0xA1, 0x01,       // Collection (application)
    0x09, 0x11,       //   Usage (0x11)
    0x15, 0x00,       //   Logical minimum (0)
    0x26, 0xFF, 0x00, //   Logical maximum (255)
    0x75, 0x08,       //   Report size (8 bits)
    0x95, 0x40,       //   Report count (64)
    0x81, 0x02,       //   Input (data, variable, absolute)
    0xC0,             // End collection
];

/// The frames of one control-point update of object `object` ([`Message::ScenePoints`]):
/// for each `(patch, first, points)` of `patches`, its planar points (x, y, m) from control
/// point `first` on, in frames of up to [`MAX_POINTS_2D`], the last frame of all with the
/// apply flag, so that the device applies them together (move the curves on both sides of
/// a join in one update: the chain must stay joined). Nothing for no points. Indices past
/// `u16::MAX` saturate (no patch has that many points: the device refuses them).
pub fn points_update<'a>(
    object: u8,
    patches: &'a [(u8, u16, &'a [Vec2])],
) -> impl Iterator<Item = Message> + 'a {
    let frames = patches
        .iter()
        .map(|(_, _, p)| p.len().div_ceil(MAX_POINTS_2D))
        .sum::<usize>();
    patches
        .iter()
        .flat_map(|&(patch, first, points)| {
            points
                .chunks(MAX_POINTS_2D)
                .enumerate()
                .map(move |(k, chunk)| (patch, offset_index(first, k * MAX_POINTS_2D), chunk))
        })
        .enumerate()
        .filter_map(move |(i, (patch, first, chunk))| {
            ScenePoints::planar(object, patch, first, i + 1 == frames, chunk)
                .map(Message::ScenePoints)
        })
}

/// [`points_update`] for surfaces: points (x, y, z, m) in frames of up to [`MAX_POINTS_3D`].
pub fn points_update_spatial<'a>(
    object: u8,
    patches: &'a [(u8, u16, &'a [Vec3])],
) -> impl Iterator<Item = Message> + 'a {
    let frames = patches
        .iter()
        .map(|(_, _, p)| p.len().div_ceil(MAX_POINTS_3D))
        .sum::<usize>();
    patches
        .iter()
        .flat_map(|&(patch, first, points)| {
            points
                .chunks(MAX_POINTS_3D)
                .enumerate()
                .map(move |(k, chunk)| (patch, offset_index(first, k * MAX_POINTS_3D), chunk))
        })
        .enumerate()
        .filter_map(move |(i, (patch, first, chunk))| {
            ScenePoints::spatial(object, patch, first, i + 1 == frames, chunk)
                .map(Message::ScenePoints)
        })
}

/// `first + k`, saturated at `u16::MAX`.
fn offset_index(first: u16, k: usize) -> u16 {
    first.saturating_add(u16::try_from(k).unwrap_or(u16::MAX))
}

/// The messages that upload `scene`: a begin, chunks of up to [`MAX_CHUNK`] bytes, a commit.
/// Scenes longer than `u32::MAX` bytes are not representable; the receiver's capacity is far
/// smaller anyway.
pub fn scene_upload(scene: &[u8]) -> impl Iterator<Item = Message> + '_ {
    let total_len = u32::try_from(scene.len()).unwrap_or(u32::MAX);
    let begin = Message::SceneBegin {
        total_len,
        crc32: crc32(scene),
    };
    let chunks = scene.chunks(MAX_CHUNK).enumerate().filter_map(|(i, data)| {
        let offset = u32::try_from(i * MAX_CHUNK).ok()?;
        SceneChunk::new(offset, data).map(Message::SceneChunk)
    });
    core::iter::once(begin)
        .chain(chunks)
        .chain(core::iter::once(Message::SceneCommit))
}
