//! The protocol's tables (the crate docs) against frames written from them byte by byte.
//!
//! The constants below were printed by `tests/frames.py`, an encoder of the tables written
//! apart from this crate with Python's `struct`, `binascii.crc_hqx` (CRC-16/CCITT-FALSE) and
//! `zlib.crc32` (CRC-32/ISO-HDLC), one commented line per field. Each frame must encode to
//! exactly its bytes and decode back to its message, as must the padded 64-byte HID report,
//! so a change of layout, field order, byte order or CRC shows here, whatever the round
//! trips of `tests/protocol.rs` say.

use friction::{FrictionMaterial, Mode, ModelKind, Stribeck, SwitchCause};
use nurbs::{Curve, Vec2, Vec3};
use protocol::*;
use tracker::Feature;

// Printed by tests/frames.py from the protocol table.
const HELLO: &[u8] = &[
    0x01, 0x01, 0x02, 0x01, 0x08, // version 1, type 0x01, seq 258, payload 8
    0x01, // software major
    0x02, // minor
    0x03, // patch
    0x00, 0x20, 0x00, 0x00, // scene capacity 8192
    0x39, // max payload 57
    0xF7, 0xF1, // CRC-16/CCITT-FALSE 0xF1F7
];
const HEARTBEAT: &[u8] = &[
    0x01, 0x02, 0x07, 0x00, 0x04, // version 1, type 0x02, seq 7, payload 4
    0x78, 0x56, 0x34, 0x12, // uptime 0x12345678 ms
    0x4F, 0x3C, // CRC-16/CCITT-FALSE 0x3C4F
];
const SCENE_BEGIN: &[u8] = &[
    0x01, 0x10, 0x08, 0x00, 0x08, // version 1, type 0x10, seq 8, payload 8
    0x2C, 0x01, 0x00, 0x00, // total length 300
    0x26, 0x39, 0xF4, 0xCB, // CRC-32 0xCBF43926
    0x31, 0xFF, // CRC-16/CCITT-FALSE 0xFF31
];
const SCENE_CHUNK: &[u8] = &[
    0x01, 0x11, 0x09, 0x00, 0x09, // version 1, type 0x11, seq 9, payload 9
    0x35, 0x00, 0x00, 0x00, // offset 53
    0x4E, 0x52, 0x42, 0x53, 0x01, // 5 bytes "NRBS\x01"
    0x52, 0x41, // CRC-16/CCITT-FALSE 0x4152
];
const SCENE_COMMIT: &[u8] = &[
    0x01, 0x12, 0x0A, 0x00, 0x00, // version 1, type 0x12, seq 10, payload 0
    0x53, 0x8A, // CRC-16/CCITT-FALSE 0x8A53
];
const POINTS_PLANAR: &[u8] = &[
    0x01, 0x13, 0x0B, 0x00, 0x15, // version 1, type 0x13, seq 11, payload 21
    0x01, // object 1
    0x02, // patch 2
    0x03, 0x00, // first point 3
    0x01, // flags: apply
    0x00, 0x00, 0x00, 0x3F, // f32 0.5
    0x00, 0x00, 0x80, 0xBE, // f32 -0.25
    0x00, 0x00, 0x80, 0x3F, // f32 1.0
    0x00, 0x00, 0x00, 0x40, // f32 2.0
    0x28, 0xC0, // CRC-16/CCITT-FALSE 0xC028
];
const POINTS_SPATIAL: &[u8] = &[
    0x01, 0x13, 0x0C, 0x00, 0x11, // version 1, type 0x13, seq 12, payload 17
    0x00, // object 0
    0x01, // patch 1
    0x04, 0x00, // first point 4
    0x02, // flags: spatial, not apply
    0x00, 0x00, 0x00, 0x3F, // f32 0.5
    0x00, 0x00, 0x80, 0x3E, // f32 0.25
    0x00, 0x00, 0x80, 0xBF, // f32 -1.0
    0xED, 0xF4, // CRC-16/CCITT-FALSE 0xF4ED
];
const ACK: &[u8] = &[
    0x01, 0x20, 0x00, 0x00, 0x02, // version 1, type 0x20, seq 0, payload 2
    0xFE, 0xFF, // acked seq 0xFFFE
    0xF9, 0x3C, // CRC-16/CCITT-FALSE 0x3CF9
];
const NACK: &[u8] = &[
    0x01, 0x21, 0x01, 0x00, 0x07, // version 1, type 0x21, seq 1, payload 7
    0xFF, 0xFF, // rejected seq: unknown 0xFFFF
    0x02, // code 2 BadCrc
    0xFF, // object: none
    0xFF, // patch: none
    0x0D, 0x00, // expected seq 13
    0x33, 0x1A, // CRC-16/CCITT-FALSE 0x1A33
];
const SET_MATERIAL: &[u8] = &[
    0x01, 0x30, 0x0E, 0x00, 0x34, // version 1, type 0x30, seq 14, payload 52
    0x02, // object 2
    0x00, 0x00, 0x7A, 0x44, // stiffness N/m 1000.0
    0x00, 0x00, 0x00, 0x40, // damping N·s/m 2.0
    0x00, 0x00, 0x00, 0x3F, // mu_s 0.5
    0x00, 0x00, 0x80, 0x3E, // mu_d 0.25
    0x00, 0x00, 0x80, 0x3D, // transition s 0.0625
    0x17, 0xB7, 0xD1, 0x38, // converge tol m 0.0001
    0x6F, 0x12, 0x83, 0x3A, // stop speed m/s 0.001
    0x00, 0x00, 0x00, 0x3F, // viscous N·s/m 0.5
    0x6F, 0x12, 0x83, 0x3A, // Karnopp band m/s 0.001
    0x00, 0x40, 0x9C, 0x45, // bristle stiffness N/m 5000.0
    0x00, 0x00, 0x80, 0x3F, // bristle damping N·s/m 1.0
    0x0A, 0xD7, 0x23, 0x3C, // Stribeck speed m/s 0.01
    0x01, // Stribeck tag: 1 power
    0x02, // exponent 2
    0x00, // model 0 stick-slip
    0xFE, 0xDB, // CRC-16/CCITT-FALSE 0xDBFE
];
const ENABLE_FORCES: &[u8] = &[
    0x01, 0x31, 0x0F, 0x00, 0x00, // version 1, type 0x31, seq 15, payload 0
    0x31, 0xCD, // CRC-16/CCITT-FALSE 0xCD31
];
const DISABLE_FORCES: &[u8] = &[
    0x01, 0x32, 0x10, 0x00, 0x00, // version 1, type 0x32, seq 16, payload 0
    0xBF, 0x39, // CRC-16/CCITT-FALSE 0x39BF
];
const CALIBRATE: &[u8] = &[
    0x01, 0x33, 0x11, 0x00, 0x00, // version 1, type 0x33, seq 17, payload 0
    0x3B, 0x78, // CRC-16/CCITT-FALSE 0x783B
];
const CLEAR_FAULTS: &[u8] = &[
    0x01, 0x34, 0x12, 0x00, 0x02, // version 1, type 0x34, seq 18, payload 2
    0x01, 0x80, // mask 0x8001
    0x82, 0xEC, // CRC-16/CCITT-FALSE 0xEC82
];
const HAND_TARGET: &[u8] = &[
    0x01, 0x35, 0x13, 0x00, 0x08, // version 1, type 0x35, seq 19, payload 8
    0x0A, 0xD7, 0x23, 0x3C, // f32 0.01
    0x00, 0x00, 0x00, 0x3E, // f32 0.125
    0xE0, 0x5C, // CRC-16/CCITT-FALSE 0x5CE0
];
const EXCITE: &[u8] = &[
    0x01, 0x36, 0x14, 0x00, 0x10, // version 1, type 0x36, seq 20, payload 16
    0xCD, 0xCC, 0x4C, 0x3D, // f32 0.05
    0xCD, 0xCC, 0x4C, 0xBD, // f32 -0.05
    0x14, 0x00, // half period 20 ms
    0x23, 0x00, // half period 35 ms
    0xD0, 0x07, 0x00, 0x00, // duration 2000 ms
    0xD7, 0x8E, // CRC-16/CCITT-FALSE 0x8ED7
];
const STATUS: &[u8] = &[
    0x01, 0x40, 0x02, 0x00, 0x12, // version 1, type 0x40, seq 2, payload 18
    0x03, // flags: forces on, calibrated
    0x04, 0x00, // faults 0x0004
    0x2C, 0x01, 0x00, 0x00, // scene length 300
    0xEF, 0xBE, 0xAD, 0xDE, // scene CRC-32 0xDEADBEEF
    0x6A, 0x00, 0x00, 0x00, // upload received 106
    0x2A, 0x00, // expected seq 42
    0x10, // last error 16 SceneCrc
    0x76, 0x29, // CRC-16/CCITT-FALSE 0x2976
];
const TELEMETRY: &[u8] = &[
    0x01, 0x50, 0x03, 0x00, 0x39, // version 1, type 0x50, seq 3, payload 57
    0x40, 0x42, 0x0F, 0x00, // time 1000000 us
    0x0A, 0xD7, 0x23, 0x3C, // f32 0.01
    0x0A, 0xD7, 0xA3, 0x3C, // f32 0.02
    0x58, 0x39, 0x34, 0x3C, // f32 0.011
    0x9E, 0xEF, 0xA7, 0x3C, // f32 0.0205
    0x31, 0x08, 0x2C, 0x3C, // f32 0.0105
    0x30, 0x4C, 0xA6, 0x3C, // f32 0.0203
    0x00, 0x00, 0xC0, 0x3F, // f32 1.5
    0x00, 0x00, 0x80, 0x3E, // f32 0.25
    0x00, 0x00, 0x00, 0x3F, // f32 0.5
    0x00, 0x00, 0xA0, 0xBF, // f32 -1.25
    0xBD, 0x37, 0x86, 0x35, // f32 1e-06
    0x88, 0x13, // mu 0.5 = 5000e-4
    0x25, 0x00, // tick 37 us
    0x00, 0x00, // faults 0
    0x03, 0x40, // feature: vertex 3 = 1<<14 | 3
    0x23, // mode 3 slip | cause 2 breakaway << 4
    0x83, 0x47, // CRC-16/CCITT-FALSE 0x4783
];
const SCENE: &[u8] = &[
    0x4E, 0x52, 0x42, 0x53, // magic "NRBS"
    0x01, // format version 1
    0x01, // 1 object
    0x00, 0x00, // reserved
    0x00, 0x00, 0x7A, 0x44, // stiffness N/m 1000.0
    0x00, 0x00, 0x00, 0x40, // damping N·s/m 2.0
    0x00, 0x00, 0x00, 0x3F, // mu_s 0.5
    0x00, 0x00, 0x80, 0x3E, // mu_d 0.25
    0x00, 0x00, 0x80, 0x3D, // transition s 0.0625
    0x17, 0xB7, 0xD1, 0x38, // converge tol m 0.0001
    0x6F, 0x12, 0x83, 0x3A, // stop speed m/s 0.001
    0x00, 0x00, 0x00, 0x3F, // viscous N·s/m 0.5
    0x6F, 0x12, 0x83, 0x3A, // Karnopp band m/s 0.001
    0x00, 0x40, 0x9C, 0x45, // bristle stiffness N/m 5000.0
    0x00, 0x00, 0x80, 0x3F, // bristle damping N·s/m 1.0
    0x0A, 0xD7, 0x23, 0x3C, // Stribeck speed m/s 0.01
    0x01, // Stribeck tag: 1 power
    0x02, // exponent 2
    0x00, // model 0 stick-slip
    0x01, // 1 patch
    0x01, // kind 1: planar curve
    0x01, // degree 1
    0x04, 0x00, // 4 knots
    0x02, 0x00, // 2 points
    0x00, 0x00, 0x00, 0x00, // f32 0.0
    0x00, 0x00, 0x00, 0x00, // f32 0.0
    0x00, 0x00, 0x80, 0x3F, // f32 1.0
    0x00, 0x00, 0x80, 0x3F, // f32 1.0
    0x00, 0x00, 0x00, 0x00, // f32 0.0
    0x00, 0x00, 0x00, 0x00, // f32 0.0
    0x00, 0x00, 0x80, 0x3F, // f32 1.0
    0x0A, 0xD7, 0x23, 0x3D, // f32 0.04
    0x0A, 0xD7, 0xA3, 0x3C, // f32 0.02
    0x00, 0x00, 0x00, 0x40, // f32 2.0
];
const SCENE_CRC32: u32 = 0xB7C673F8; // zlib.crc32, CRC-32/ISO-HDLC, 106 bytes

/// The material of the tables' frames (each value as `tests/frames.py` writes it).
fn material() -> FrictionMaterial {
    FrictionMaterial {
        stiffness_n_per_m: 1000.0,
        damping_ns_per_m: 2.0,
        mu_static: 0.5,
        mu_dynamic: 0.25,
        stribeck: Stribeck::Power { exponent: 2 },
        transition_time_s: 0.0625,
        converge_tol_m: 1e-4,
        stop_speed_m_per_s: 0.001,
        model: ModelKind::StickSlip,
        viscous_ns_per_m: 0.5,
        karnopp_band_m_per_s: 0.001,
        bristle_stiffness_n_per_m: 5000.0,
        bristle_damping_ns_per_m: 1.0,
        stribeck_speed_m_per_s: 0.01,
    }
}

/// Every message of the table, with the bytes written for it.
fn table() -> Vec<(Frame, &'static [u8])> {
    let f = |seq, message| Frame { seq, message };
    vec![
        (
            f(
                0x0102,
                Message::Hello(Hello {
                    software: [1, 2, 3],
                    scene_capacity: 8192,
                    max_payload: 57,
                }),
            ),
            HELLO,
        ),
        (
            f(
                7,
                Message::Heartbeat {
                    uptime_ms: 0x1234_5678,
                },
            ),
            HEARTBEAT,
        ),
        (
            f(
                8,
                Message::SceneBegin {
                    total_len: 300,
                    crc32: 0xCBF4_3926,
                },
            ),
            SCENE_BEGIN,
        ),
        (
            f(
                9,
                Message::SceneChunk(SceneChunk::new(53, b"NRBS\x01").expect("5 bytes")),
            ),
            SCENE_CHUNK,
        ),
        (f(10, Message::SceneCommit), SCENE_COMMIT),
        (
            f(
                11,
                Message::ScenePoints(
                    ScenePoints::planar(
                        1,
                        2,
                        3,
                        true,
                        &[Vec2::new(0.5, -0.25), Vec2::new(1.0, 2.0)],
                    )
                    .expect("2 points"),
                ),
            ),
            POINTS_PLANAR,
        ),
        (
            f(
                12,
                Message::ScenePoints(
                    ScenePoints::spatial(0, 1, 4, false, &[Vec3::new(0.5, 0.25, -1.0)])
                        .expect("1 point"),
                ),
            ),
            POINTS_SPATIAL,
        ),
        (f(0, Message::Ack { seq: 0xFFFE }), ACK),
        (
            f(
                1,
                Message::Nack(Nack {
                    seq: UNKNOWN_SEQ,
                    code: ErrorCode::BadCrc,
                    object: NO_INDEX,
                    patch: NO_INDEX,
                    expected_seq: 13,
                }),
            ),
            NACK,
        ),
        (
            f(
                14,
                Message::SetMaterial {
                    object: 2,
                    material: material(),
                },
            ),
            SET_MATERIAL,
        ),
        (f(15, Message::EnableForces), ENABLE_FORCES),
        (f(16, Message::DisableForces), DISABLE_FORCES),
        (f(17, Message::Calibrate), CALIBRATE),
        (f(18, Message::ClearFaults { mask: 0x8001 }), CLEAR_FAULTS),
        (
            f(
                19,
                Message::HandTarget {
                    target_m: Vec2::new(0.01, 0.125),
                },
            ),
            HAND_TARGET,
        ),
        (
            f(
                20,
                Message::Excite {
                    torque_nm: [0.05, -0.05],
                    half_period_ms: [20, 35],
                    duration_ms: 2000,
                },
            ),
            EXCITE,
        ),
        (
            f(
                2,
                Message::Status(Status {
                    forces_enabled: true,
                    calibrated: true,
                    faults: 0x0004,
                    scene_len: 300,
                    scene_crc32: 0xDEAD_BEEF,
                    upload_received: 106,
                    expected_seq: 42,
                    last_error: ErrorCode::SceneCrc as u8,
                }),
            ),
            STATUS,
        ),
        (
            f(
                3,
                Message::Telemetry(Telemetry {
                    time_us: 1_000_000,
                    hip_m: Vec2::new(0.01, 0.02),
                    cp_m: Vec2::new(0.011, 0.0205),
                    go_m: Vec2::new(0.0105, 0.0203),
                    force_normal_n: 1.5,
                    go_param: 0.25,
                    force_n: Vec2::new(0.5, -1.25),
                    psi: 1e-6,
                    mu_e4: 5000,
                    tick_us: 37,
                    faults: 0,
                    feature: Some(Feature::Vertex(3)),
                    mode: Mode::Slip,
                    cause: SwitchCause::Breakaway,
                }),
            ),
            TELEMETRY,
        ),
    ]
}

#[test]
fn every_message_encodes_to_the_bytes_of_the_table() {
    let table = table();
    // Every message type of the table once (ScenePoints twice: planar and spatial).
    let mut types: Vec<u8> = table.iter().map(|(_, b)| b[1]).collect();
    types.dedup();
    assert_eq!(types.len(), 17);
    for (frame, bytes) in table {
        let mut out = [0xAA; MAX_FRAME];
        let n = frame.encode(&mut out);
        assert_eq!(&out[..n], bytes, "{frame:?}");
        // What follows the frame is left as it was.
        assert!(out[n..].iter().all(|&b| b == 0xAA));
        let (report, m) = frame.to_report();
        assert_eq!((&report[..m], m), (bytes, bytes.len()));
        assert!(report[m..].iter().all(|&b| b == 0));
    }
}

#[test]
fn the_bytes_of_the_table_decode_to_their_messages() {
    for (frame, bytes) in table() {
        assert_eq!(Frame::decode(bytes), Ok(frame), "{bytes:02X?}");
        // The same frame in a zero-padded 64-byte HID report.
        let mut report = [0u8; MAX_FRAME];
        report[..bytes.len()].copy_from_slice(bytes);
        assert_eq!(Frame::decode(&report), Ok(frame));
        // The payload-length byte and the frame's length agree with the table's header.
        assert_eq!(
            usize::from(bytes[4]),
            bytes.len() - HEADER_LEN - CRC_LEN,
            "{frame:?}"
        );
    }
    // The telemetry frame is exactly one report.
    assert_eq!(TELEMETRY.len(), MAX_FRAME);
}

#[test]
fn a_frame_whose_crc_is_sent_big_endian_is_refused() {
    // The CRC is little-endian like every other field: swapping its bytes breaks it.
    for (_, bytes) in table() {
        let mut swapped = bytes.to_vec();
        let n = swapped.len();
        swapped.swap(n - 2, n - 1);
        if swapped[n - 2] != swapped[n - 1] {
            let e = Frame::decode(&swapped).expect_err("a swapped CRC");
            assert_eq!((e.code, e.seq), (ErrorCode::BadCrc, None));
        }
    }
}

#[test]
fn the_scene_of_the_table_encodes_and_decodes_exactly() {
    // One degree-1 curve from (0, 0) to (0.02, 0.01), its second point of weight 2: the wire
    // carries the homogeneous (w·x, w·y, w).
    let knots = [0.0, 0.0, 1.0, 1.0];
    let points = [Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.04, 0.02, 2.0)];
    let curve: Curve<'_, Vec2> = Curve::new(1, &knots, &points).expect("a valid line");
    let bytes = encode_scene(&[WireObject {
        material: material(),
        patches: &[WirePatch::Curve(curve)],
    }])
    .expect("fits the format");
    assert_eq!(bytes, SCENE);
    assert_eq!(crc32(SCENE), SCENE_CRC32);

    let mut store = Box::new(SceneStore::<64, 64, 0>::empty());
    decode_scene(SCENE, &mut store).expect("the table's scene is valid");
    assert_eq!(store.object_count(), 1);
    assert_eq!(store.material(0), Some(material()));
    assert_eq!(store.curve(0, 0), Some(curve));
    // The rational line's midpoint parameter maps to (w0 p0 + w1 p1)/(w0 + w1) = 2/3 of the way.
    let mid = store.curve(0, 0).expect("decoded").point(0.5);
    assert!((mid - Vec2::new(0.02 * 2.0 / 3.0, 0.01 * 2.0 / 3.0)).length() < 1e-8);
}
