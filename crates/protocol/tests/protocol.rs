//! The wire protocol: checksums against published check values, message round trips, total
//! decoding, the scene upload state machine and the binary scene.

#![allow(clippy::unwrap_used)]

use friction::{FrictionMaterial, Mode, ModelKind, Stribeck, SwitchCause};
use nurbs::construct::{bezier_curve, bezier_patch, circle, sphere};
use nurbs::{CurveBuf, SurfaceBuf, Vec2, Vec3};
use proptest::prelude::*;
use protocol::*;
use tracker::Feature;

// ---------------------------------------------------------------------------------------
// Checksums

#[test]
fn crc_check_values() {
    // The "check" values of the CRC catalogue (reveng.sourceforge.io/crc-catalogue).
    assert_eq!(crc16_ccitt_false(b"123456789"), 0x29B1);
    assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    assert_eq!(crc16_ccitt_false(b""), 0xFFFF);
    assert_eq!(crc32(b""), 0);
    assert_eq!(
        (crc16_bitwise(b"123456789"), crc32_bitwise(b"123456789")),
        (0x29B1, 0xCBF4_3926)
    );
    // zlib's crc32 of the pangram.
    assert_eq!(
        crc32(b"The quick brown fox jumps over the lazy dog"),
        0x414F_A339
    );
}

/// Bit-at-a-time CRCs straight from the catalogue's parameters (width, poly, init, refin,
/// refout, xorout): independent of any table, so agreement on every input shows the wire's
/// checksums are those of the protocol docs, whatever implements them.
fn crc16_bitwise(data: &[u8]) -> u16 {
    let mut reg = 0xFFFFu16;
    for &b in data {
        reg ^= u16::from(b) << 8;
        for _ in 0..8 {
            reg = if reg & 0x8000 != 0 {
                (reg << 1) ^ 0x1021
            } else {
                reg << 1
            };
        }
    }
    reg
}

fn crc32_bitwise(data: &[u8]) -> u32 {
    let mut reg = 0xFFFF_FFFFu32;
    for &b in data {
        reg ^= u32::from(b);
        for _ in 0..8 {
            reg = if reg & 1 != 0 {
                (reg >> 1) ^ 0xEDB8_8320
            } else {
                reg >> 1
            };
        }
    }
    reg ^ 0xFFFF_FFFF
}

proptest! {
    #[test]
    fn crcs_equal_the_bitwise_definition(data in prop::collection::vec(any::<u8>(), 0..300)) {
        prop_assert_eq!(crc16_ccitt_false(&data), crc16_bitwise(&data));
        prop_assert_eq!(crc32(&data), crc32_bitwise(&data));
    }

    #[test]
    fn crc32_incremental_equals_one_shot(data in prop::collection::vec(any::<u8>(), 0..300), cut in 0usize..300) {
        let cut = cut.min(data.len());
        let mut c = Crc32::new();
        c.update(&data[..cut]);
        c.update(&data[cut..]);
        prop_assert_eq!(c.finish(), crc32(&data));
        // Pieces of every size, the empty one included, change nothing.
        let mut pieces = Crc32::new();
        for chunk in data.chunks(cut.max(1)) {
            pieces.update(chunk);
            pieces.update(&[]);
        }
        prop_assert_eq!(pieces.finish(), crc32_bitwise(&data));
    }
}

// ---------------------------------------------------------------------------------------
// Strategies

fn finite() -> impl Strategy<Value = f32> {
    -1e6f32..1e6
}

fn vec2() -> impl Strategy<Value = Vec2> {
    (finite(), finite()).prop_map(|(x, y)| Vec2::new(x, y))
}

fn vec3() -> impl Strategy<Value = Vec3> {
    (finite(), finite(), finite()).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

fn material() -> impl Strategy<Value = FrictionMaterial> {
    (
        (0.0f32..1e5, 0.0f32..100.0, 0.0f32..2.0, 0.0f32..1.0),
        (1e-4f32..1.0, 1e-7f32..1e-3, 0.0f32..1.0, 0.0f32..10.0),
        (0.0f32..1.0, 1.0f32..1e5, 0.0f32..10.0, 1e-4f32..1.0),
        (0u8..3, 1u8..=255, 0u8..5),
    )
        .prop_map(
            |((k, d, mu_s, frac), (tt, tol, stop, visc), (band, bk, bd, vs), (st, e, model))| {
                FrictionMaterial {
                    stiffness_n_per_m: k,
                    damping_ns_per_m: d,
                    mu_static: mu_s,
                    mu_dynamic: mu_s * frac,
                    stribeck: match st {
                        0 => Stribeck::Linear,
                        1 => Stribeck::Power { exponent: e },
                        _ => Stribeck::Smoothstep,
                    },
                    transition_time_s: tt,
                    converge_tol_m: tol,
                    stop_speed_m_per_s: stop,
                    model: [
                        ModelKind::StickSlip,
                        ModelKind::CoulombViscous,
                        ModelKind::Karnopp,
                        ModelKind::Dahl,
                        ModelKind::LuGre,
                    ][usize::from(model)],
                    viscous_ns_per_m: visc,
                    karnopp_band_m_per_s: band,
                    bristle_stiffness_n_per_m: bk,
                    bristle_damping_ns_per_m: bd,
                    stribeck_speed_m_per_s: vs,
                }
            },
        )
}

fn feature() -> impl Strategy<Value = Option<Feature>> {
    prop_oneof![
        Just(None),
        (0u16..=MAX_FEATURE_INDEX).prop_map(|i| Some(Feature::Patch(i))),
        (0u16..=MAX_FEATURE_INDEX).prop_map(|i| Some(Feature::Vertex(i))),
        (0u16..=MAX_FEATURE_INDEX).prop_map(|i| Some(Feature::Edge(i))),
        (0u16..=MAX_FEATURE_INDEX).prop_map(|i| Some(Feature::Corner(i))),
    ]
}

fn telemetry() -> impl Strategy<Value = Telemetry> {
    (
        (any::<u32>(), vec2(), vec2(), vec2()),
        (finite(), finite(), vec2(), finite()),
        (
            any::<u16>(),
            any::<u16>(),
            any::<u16>(),
            feature(),
            0usize..4,
        ),
        0usize..SwitchCause::ALL.len(),
    )
        .prop_map(
            |(
                (time_us, hip_m, cp_m, go_m),
                (fnorm, ffric, force_n, psi),
                (mu_e4, tick_us, faults, feature, mode),
                cause,
            )| {
                Telemetry {
                    time_us,
                    hip_m,
                    cp_m,
                    go_m,
                    force_normal_n: fnorm,
                    go_param: ffric,
                    force_n,
                    psi,
                    mu_e4,
                    tick_us,
                    faults,
                    feature,
                    mode: [Mode::Free, Mode::Stuck, Mode::Transition, Mode::Slip][mode],
                    cause: SwitchCause::ALL[cause],
                }
            },
        )
}

fn error_code() -> impl Strategy<Value = ErrorCode> {
    prop::sample::select(ErrorCode::ALL.to_vec())
}

/// Every message type.
fn message() -> impl Strategy<Value = Message> {
    prop_oneof![
        (any::<[u8; 3]>(), any::<u32>(), any::<u8>()).prop_map(
            |(software, scene_capacity, max_payload)| {
                Message::Hello(Hello {
                    software,
                    scene_capacity,
                    max_payload,
                })
            }
        ),
        any::<u32>().prop_map(|uptime_ms| Message::Heartbeat { uptime_ms }),
        (any::<u32>(), any::<u32>())
            .prop_map(|(total_len, crc32)| Message::SceneBegin { total_len, crc32 }),
        (
            any::<u32>(),
            prop::collection::vec(any::<u8>(), 1..=MAX_CHUNK)
        )
            .prop_map(|(offset, data)| Message::SceneChunk(
                SceneChunk::new(offset, &data).unwrap()
            )),
        Just(Message::SceneCommit),
        (
            any::<u8>(),
            any::<u8>(),
            any::<u16>(),
            any::<bool>(),
            prop::collection::vec(vec2(), 1..=MAX_POINTS_2D)
        )
            .prop_map(
                |(object, patch, first, apply, points)| Message::ScenePoints(
                    ScenePoints::planar(object, patch, first, apply, &points).unwrap()
                )
            ),
        (
            any::<u8>(),
            any::<u8>(),
            any::<u16>(),
            any::<bool>(),
            prop::collection::vec(vec3(), 1..=MAX_POINTS_3D)
        )
            .prop_map(
                |(object, patch, first, apply, points)| Message::ScenePoints(
                    ScenePoints::spatial(object, patch, first, apply, &points).unwrap()
                )
            ),
        vec2().prop_map(|target_m| Message::HandTarget { target_m }),
        (
            prop::array::uniform2(-1.0f32..1.0),
            prop::array::uniform2(1u16..),
            1u32..
        )
            .prop_map(|(torque_nm, half_period_ms, duration_ms)| Message::Excite {
                torque_nm,
                half_period_ms,
                duration_ms
            }),
        any::<u16>().prop_map(|seq| Message::Ack { seq }),
        (
            any::<u16>(),
            error_code(),
            any::<u8>(),
            any::<u8>(),
            any::<u16>()
        )
            .prop_map(
                |(seq, code, object, patch, expected_seq)| Message::Nack(Nack {
                    seq,
                    code,
                    object,
                    patch,
                    expected_seq
                })
            ),
        (any::<u8>(), material())
            .prop_map(|(object, material)| Message::SetMaterial { object, material }),
        Just(Message::EnableForces),
        Just(Message::DisableForces),
        Just(Message::Calibrate),
        any::<u16>().prop_map(|mask| Message::ClearFaults { mask }),
        (
            any::<bool>(),
            any::<bool>(),
            any::<u16>(),
            any::<u32>(),
            any::<u32>(),
            any::<u32>(),
            any::<u16>(),
            any::<u8>()
        )
            .prop_map(
                |(
                    forces_enabled,
                    calibrated,
                    faults,
                    scene_len,
                    scene_crc32,
                    upload_received,
                    expected_seq,
                    last_error,
                )| {
                    Message::Status(Status {
                        forces_enabled,
                        calibrated,
                        faults,
                        scene_len,
                        scene_crc32,
                        upload_received,
                        expected_seq,
                        last_error,
                    })
                }
            ),
        telemetry().prop_map(Message::Telemetry),
    ]
}

fn encode(seq: u16, message: Message) -> Vec<u8> {
    let (report, n) = Frame { seq, message }.to_report();
    report[..n].to_vec()
}

// ---------------------------------------------------------------------------------------
// Frames and messages

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1024))]

    #[test]
    fn every_message_round_trips(seq in any::<u16>(), message in message()) {
        let (report, n) = Frame { seq, message }.to_report();
        let ty = message.message_type();
        prop_assert!(n <= MAX_FRAME);
        prop_assert!(ty.payload_len().contains(&(n - HEADER_LEN - CRC_LEN)));
        // Exactly a frame, and a frame in a zero-padded 64-byte report.
        prop_assert_eq!(Frame::decode(&report[..n]), Ok(Frame { seq, message }));
        prop_assert_eq!(Frame::decode(&report), Ok(Frame { seq, message }));
    }

    #[test]
    fn decoding_any_bytes_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..80)) {
        let _ = Frame::decode(&bytes);
    }

    #[test]
    fn decoding_any_payload_never_panics(ty in 0usize..MessageType::ALL.len(), payload in prop::collection::vec(any::<u8>(), 0..60)) {
        let _ = Message::decode_payload(MessageType::ALL[ty], &payload);
    }

    /// CRC-16 detects every error burst of up to 16 bits, so every single-byte corruption of
    /// a frame is caught: as a CRC error, or as a length error when the length byte moved
    /// the CRC out of the frame.
    #[test]
    fn one_corrupted_byte_is_rejected(seq in any::<u16>(), message in message(), at in any::<prop::sample::Index>(), flip in 1u8..=255) {
        let mut frame = encode(seq, message);
        let at = at.index(frame.len());
        frame[at] ^= flip;
        let err = Frame::decode(&frame).unwrap_err();
        if at == 4 {
            prop_assert!(matches!(err.code, ErrorCode::BadLength | ErrorCode::BadCrc), "{:?}", err);
        } else {
            prop_assert_eq!(err, FrameError { code: ErrorCode::BadCrc, seq: None });
        }
    }
}

/// Builds a frame with an arbitrary header and payload and a correct CRC.
fn raw_frame(version: u8, ty: u8, seq: u16, payload: &[u8]) -> Vec<u8> {
    let mut f = vec![version, ty];
    f.extend_from_slice(&seq.to_le_bytes());
    f.push(payload.len() as u8);
    f.extend_from_slice(payload);
    let crc = crc16_ccitt_false(&f);
    f.extend_from_slice(&crc.to_le_bytes());
    f
}

#[test]
fn each_malformed_frame_has_its_code() {
    let code = |bytes: &[u8]| Frame::decode(bytes).unwrap_err().code;
    assert_eq!(code(&[]), ErrorCode::BadLength);
    assert_eq!(code(&[1, 2, 0, 0, 0, 0]), ErrorCode::BadLength);
    assert_eq!(code(&[0; 65]), ErrorCode::BadLength);
    // Payload length larger than the bytes given, and larger than MAX_PAYLOAD.
    assert_eq!(
        code(&raw_frame(1, 2, 0, &[0; 4])[..10]),
        ErrorCode::BadLength
    );
    let mut long = raw_frame(1, 2, 0, &[0; 4]);
    long[4] = 58;
    long.resize(64, 0);
    assert_eq!(code(&long), ErrorCode::BadLength);
    let mut bad_crc = raw_frame(1, 2, 0, &[0; 4]);
    bad_crc[9] ^= 1;
    assert_eq!(code(&bad_crc), ErrorCode::BadCrc);
    assert_eq!(code(&raw_frame(2, 2, 7, &[0; 4])), ErrorCode::BadVersion);
    assert_eq!(
        Frame::decode(&raw_frame(2, 2, 7, &[0; 4])).unwrap_err().seq,
        Some(7)
    );
    assert_eq!(code(&raw_frame(1, 0x7F, 0, &[])), ErrorCode::UnknownType);
    assert_eq!(
        code(&raw_frame(1, 2, 0, &[0; 3])),
        ErrorCode::BadPayloadLength
    );
    assert_eq!(
        code(&raw_frame(1, 0x12, 0, &[0])),
        ErrorCode::BadPayloadLength
    );
    assert_eq!(
        code(&raw_frame(1, 0x11, 0, &[0; 4])),
        ErrorCode::BadPayloadLength
    );
    // A mode byte out of range (mode 9; cause 8, the first code past the last cause), a status
    // flag byte with unknown bits, an unknown nack code.
    for byte in [9u8, 0x81] {
        let mut t = encode(0, Message::Telemetry(telemetry_example()));
        t[HEADER_LEN + 56] = byte;
        let n = t.len() - 2;
        let crc = crc16_ccitt_false(&t[..n]);
        t[n..].copy_from_slice(&crc.to_le_bytes());
        assert_eq!(code(&t), ErrorCode::BadField, "mode byte {byte:#x}");
    }
    assert_eq!(code(&raw_frame(1, 0x40, 0, &[4; 18])), ErrorCode::BadField);
    assert_eq!(
        code(&raw_frame(1, 0x21, 0, &[0, 0, 200, 0, 0, 0, 0])),
        ErrorCode::BadField
    );
    // Materials: μd > μs, negative stiffness, power exponent 0, unknown model.
    let m = FrictionMaterial::default();
    for bad in [
        FrictionMaterial {
            mu_dynamic: 0.9,
            ..m
        },
        FrictionMaterial {
            stiffness_n_per_m: -1.0,
            ..m
        },
        FrictionMaterial {
            transition_time_s: f32::NAN,
            ..m
        },
        FrictionMaterial {
            stribeck: Stribeck::Power { exponent: 0 },
            ..m
        },
    ] {
        let f = encode(
            0,
            Message::SetMaterial {
                object: 0,
                material: bad,
            },
        );
        assert_eq!(code(&f), ErrorCode::BadMaterial, "{bad:?}");
    }
    let mut payload = encode(
        0,
        Message::SetMaterial {
            object: 0,
            material: m,
        },
    )[HEADER_LEN..HEADER_LEN + 52]
        .to_vec();
    payload[51] = 5;
    assert_eq!(code(&raw_frame(1, 0x30, 0, &payload)), ErrorCode::BadField);
}

/// The telemetry frame with payload bytes `at..at + bytes.len()` replaced, CRC recomputed.
fn telemetry_with(at: usize, bytes: &[u8]) -> Vec<u8> {
    let mut t = encode(0, Message::Telemetry(telemetry_example()));
    t[HEADER_LEN + at..HEADER_LEN + at + bytes.len()].copy_from_slice(bytes);
    let n = t.len() - 2;
    let crc = crc16_ccitt_false(&t[..n]);
    t[n..].copy_from_slice(&crc.to_le_bytes());
    t
}

/// Telemetry the encoder cannot produce is malformed: NaN or an infinity in any of its nine
/// float fields (offsets 4 to 44 of the layout), or a feature code whose index is 0x3FFF
/// (indices saturate at MAX_FEATURE_INDEX = 0x3FFE, and 0xFFFF means none). Before, the
/// host decoded all of these as telemetry.
#[test]
fn telemetry_the_encoder_cannot_produce_is_malformed() {
    let code = |bytes: &[u8]| Frame::decode(bytes).map_err(|e| e.code);
    assert!(code(&telemetry_with(0, &[0; 0])).is_ok());
    for offset in (4..=44).step_by(4) {
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            assert_eq!(
                code(&telemetry_with(offset, &bad.to_le_bytes())),
                Err(ErrorCode::BadField),
                "{bad} at {offset}"
            );
        }
        // The largest finite values still decode (a bound, not a range check).
        assert!(code(&telemetry_with(offset, &f32::MAX.to_le_bytes())).is_ok());
    }
    for bad in [0x3FFFu16, 0x7FFF, 0xBFFF] {
        assert_eq!(
            code(&telemetry_with(54, &bad.to_le_bytes())),
            Err(ErrorCode::BadField),
            "{bad:#x}"
        );
    }
    // What the encoder does produce: every kind at the saturated index, and none.
    for (kind, feature) in [
        (0u16, Feature::Patch(MAX_FEATURE_INDEX)),
        (1, Feature::Vertex(MAX_FEATURE_INDEX)),
        (2, Feature::Edge(MAX_FEATURE_INDEX)),
        (3, Feature::Corner(MAX_FEATURE_INDEX)),
    ] {
        let v = (kind << 14) | MAX_FEATURE_INDEX;
        let Ok(Frame {
            message: Message::Telemetry(t),
            ..
        }) = Frame::decode(&telemetry_with(54, &v.to_le_bytes()))
        else {
            panic!("{v:#x} decodes")
        };
        assert_eq!(t.feature, Some(feature));
        let saturated = Telemetry {
            feature: Some(match feature {
                Feature::Patch(_) => Feature::Patch(u16::MAX),
                Feature::Vertex(_) => Feature::Vertex(u16::MAX),
                Feature::Edge(_) => Feature::Edge(u16::MAX),
                Feature::Corner(_) => Feature::Corner(u16::MAX),
            }),
            ..telemetry_example()
        };
        assert_eq!(
            encode(0, Message::Telemetry(saturated)),
            telemetry_with(54, &v.to_le_bytes())
        );
    }
    let none = Frame::decode(&telemetry_with(54, &0xFFFFu16.to_le_bytes())).unwrap();
    assert!(matches!(
        none.message,
        Message::Telemetry(Telemetry { feature: None, .. })
    ));
}

fn telemetry_example() -> Telemetry {
    Telemetry {
        time_us: 1_000_000,
        hip_m: Vec2::new(0.01, 0.09),
        cp_m: Vec2::new(0.01, 0.0895),
        go_m: Vec2::new(0.0098, 0.0895),
        force_normal_n: 0.5,
        go_param: 0.2,
        force_n: Vec2::new(-0.2, 0.5),
        psi: 1e-4,
        mu_e4: Telemetry::quantize_mu(0.7),
        tick_us: 180,
        faults: 0,
        feature: Some(Feature::Vertex(2)),
        mode: Mode::Stuck,
        cause: SwitchCause::Reversed,
    }
}

#[test]
fn telemetry_fills_one_report_exactly() {
    let f = encode(3, Message::Telemetry(telemetry_example()));
    assert_eq!(f.len(), MAX_FRAME);
    assert_eq!(TELEMETRY_LEN, MAX_PAYLOAD);
    assert!((telemetry_example().mu() - 0.7).abs() < 1e-4);
    assert_eq!(Telemetry::quantize_mu(f32::NAN), 0);
    assert_eq!(Telemetry::quantize_mu(1e9), u16::MAX);
}

#[test]
fn codes_and_types_have_distinct_wire_values() {
    for (i, c) in ErrorCode::ALL.iter().enumerate() {
        assert_eq!(ErrorCode::from_u8(*c as u8), Some(*c));
        assert_eq!(*c as u8, i as u8 + 1);
    }
    assert_eq!(ErrorCode::from_u8(0), None);
    for t in MessageType::ALL {
        assert_eq!(MessageType::from_u8(t as u8), Some(t));
        assert!(*t.payload_len().end() <= MAX_PAYLOAD);
    }
}

// ---------------------------------------------------------------------------------------
// Scenes

fn cubic() -> CurveBuf<Vec2> {
    bezier_curve(&[
        Vec2::new(-0.04, 0.08),
        Vec2::new(-0.02, 0.11),
        Vec2::new(0.02, 0.07),
        Vec2::new(0.04, 0.1),
    ])
    .unwrap()
}

fn ring() -> CurveBuf<Vec2> {
    circle(Vec2::new(0.0, 0.09), 0.02).unwrap()
}

fn patch() -> SurfaceBuf {
    let rows = [
        [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 0.01, 0.01),
            Vec3::new(0.0, 0.02, 0.0),
        ],
        [
            Vec3::new(0.01, 0.0, 0.01),
            Vec3::new(0.01, 0.01, 0.02),
            Vec3::new(0.01, 0.02, 0.01),
        ],
    ];
    bezier_patch(&rows).unwrap()
}

fn material_a() -> FrictionMaterial {
    FrictionMaterial::default()
}

fn material_b() -> FrictionMaterial {
    FrictionMaterial {
        stiffness_n_per_m: 800.0,
        mu_static: 0.4,
        mu_dynamic: 0.3,
        stribeck: Stribeck::Power { exponent: 3 },
        model: ModelKind::LuGre,
        ..FrictionMaterial::default()
    }
}

/// A rational circle, a cubic, and (second) a surface object.
fn scene_bytes(with_surfaces: bool) -> Vec<u8> {
    let (ring, cubic, patch, ball) = (ring(), cubic(), patch(), sphere(Vec3::ZERO, 0.02).unwrap());
    let circle_patches = [WirePatch::Curve(ring.view())];
    let cubic_patches = [WirePatch::Curve(cubic.view())];
    let surface_patches = [WirePatch::Surface(patch.view())];
    let ball_patches = [WirePatch::Surface(ball.view())];
    let mut objects = vec![
        WireObject {
            material: material_a(),
            patches: &circle_patches,
        },
        WireObject {
            material: material_b(),
            patches: &cubic_patches,
        },
    ];
    if with_surfaces {
        objects.push(WireObject {
            material: material_a(),
            patches: &surface_patches,
        });
        objects.push(WireObject {
            material: material_b(),
            patches: &ball_patches,
        });
    }
    encode_scene(&objects).unwrap()
}

#[test]
fn scene_decodes_to_the_same_curves_and_surfaces() {
    let bytes = scene_bytes(true);
    let mut store = Box::new(SceneStore::new());
    decode_scene(&bytes, &mut store).unwrap();
    assert_eq!(store.object_count(), 4);
    assert_eq!(store.material(0), Some(material_a()));
    assert_eq!(store.material(1), Some(material_b()));
    assert_eq!(store.kind(0), Some(PatchKind::Curve2));
    assert_eq!(store.kind(2), Some(PatchKind::Surface));
    assert!(store.surface(0, 0).is_none());
    assert!(store.curve(0, 1).is_none());
    assert!(store.curve(9, 0).is_none());
    let (ring, cubic, patch) = (ring(), cubic(), patch());
    assert_eq!(store.curve(0, 0).unwrap(), ring.view());
    assert_eq!(store.curve(1, 0).unwrap(), cubic.view());
    assert_eq!(store.surface(2, 0).unwrap(), patch.view());
    for k in 0..=100 {
        let u = k as f32 / 100.0;
        assert_eq!(store.curve(0, 0).unwrap().point(u), ring.view().point(u));
        assert_eq!(store.curve(1, 0).unwrap().point(u), cubic.view().point(u));
        // The circle is exact: every point at the radius (independent reference).
        let r = (store.curve(0, 0).unwrap().point(u) - Vec2::new(0.0, 0.09)).length();
        assert!((r - 0.02).abs() < 1e-6, "{r}");
        assert_eq!(
            store.surface(2, 0).unwrap().point(u, 1.0 - u),
            patch.view().point(u, 1.0 - u)
        );
    }
}

#[test]
fn truncated_or_extended_scenes_are_format_errors() {
    let bytes = scene_bytes(true);
    let mut store = Box::new(SceneStore::new());
    for n in 0..bytes.len() {
        let e = decode_scene(&bytes[..n], &mut store).unwrap_err();
        assert_eq!(e.code(), ErrorCode::SceneFormat, "prefix {n}: {e}");
        assert_eq!(store.object_count(), 0);
    }
    let mut longer = bytes.clone();
    longer.push(0);
    assert_eq!(
        decode_scene(&longer, &mut store).unwrap_err().code(),
        ErrorCode::SceneFormat
    );
}

/// Offsets into the wire scene of `scene_bytes(false)`.
const OBJ0: usize = 8;
const OBJ0_PATCH0: usize = OBJ0 + MATERIAL_LEN + 1;
const OBJ0_KNOTS: usize = OBJ0_PATCH0 + 6;

fn patched(f: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
    let mut b = scene_bytes(false);
    f(&mut b);
    b
}

#[test]
fn each_invalid_scene_has_its_code_and_location() {
    let mut store = Box::new(SceneStore::new());
    let mut check = |bytes: Vec<u8>, code: ErrorCode, object: Option<u8>, patch: Option<u8>| {
        let e = decode_scene(&bytes, &mut store).unwrap_err();
        assert_eq!((e.code(), e.object, e.patch), (code, object, patch), "{e}");
    };
    check(patched(|b| b[0] = b'X'), ErrorCode::SceneFormat, None, None);
    check(patched(|b| b[4] = 2), ErrorCode::SceneFormat, None, None);
    check(patched(|b| b[5] = 0), ErrorCode::SceneFormat, None, None);
    check(patched(|b| b[5] = 9), ErrorCode::SceneCapacity, None, None);
    // μd > μs in object 0.
    check(
        patched(|b| b[OBJ0 + 12..OBJ0 + 16].copy_from_slice(&0.9f32.to_le_bytes())),
        ErrorCode::BadMaterial,
        Some(0),
        None,
    );
    check(
        patched(|b| b[OBJ0_PATCH0] = 7),
        ErrorCode::SceneFormat,
        Some(0),
        Some(0),
    );
    // Knot vector of the circle made decreasing.
    check(
        patched(|b| b[OBJ0_KNOTS..OBJ0_KNOTS + 4].copy_from_slice(&5.0f32.to_le_bytes())),
        ErrorCode::ScenePatch,
        Some(0),
        Some(0),
    );
    // A zero weight: the w of the first homogeneous point of the circle (12 knots).
    let w0 = OBJ0_KNOTS + 12 * 4 + 8;
    check(
        patched(|b| b[w0..w0 + 4].copy_from_slice(&0.0f32.to_le_bytes())),
        ErrorCode::ScenePatch,
        Some(0),
        Some(0),
    );
    // Huge counts: more points than there are bytes is truncation, not a capacity overflow.
    check(
        patched(|b| b[OBJ0_PATCH0 + 4..OBJ0_PATCH0 + 6].copy_from_slice(&u16::MAX.to_le_bytes())),
        ErrorCode::SceneFormat,
        Some(0),
        Some(0),
    );

    // Topology: two curves that do not join, a clockwise closed chain, mixed kinds.
    let (ring, cubic, surf) = (ring(), cubic(), patch());
    let cw = ring.map_points(|p| Vec2::new(-p.x, p.y)).unwrap();
    let cases: [(&[WirePatch<'_>], Option<u8>); 3] = [
        (
            &[
                WirePatch::Curve(ring.view()),
                WirePatch::Curve(cubic.view()),
            ],
            None,
        ),
        (&[WirePatch::Curve(cw.view())], None),
        (
            &[
                WirePatch::Curve(ring.view()),
                WirePatch::Surface(surf.view()),
            ],
            Some(1),
        ),
    ];
    for (patches, patch) in cases {
        let e = encode_scene(&[WireObject {
            material: material_a(),
            patches,
        }])
        .unwrap_err();
        assert_eq!(
            (e.code(), e.object, e.patch),
            (ErrorCode::SceneTopology, Some(0), patch),
            "{e}"
        );
    }
}

/// The wire scene goes through the same weight rule as the JSON loader (`nurbs`'s one
/// control-point validation): a weight of 9.2e-41 (subnormal; the surface path used to divide
/// it out to a finite point and evaluate NaN) or 1e-20 beside weights of 1 is a patch error
/// naming object, patch and weight, with the reason.
#[test]
fn weights_too_small_for_f32_are_patch_errors() {
    let mut rows = [[Vec3::ZERO; 3]; 2];
    for (i, row) in rows.iter_mut().enumerate() {
        for (j, p) in row.iter_mut().enumerate() {
            *p = Vec3::new(0.01 * i as f32, 0.01 * j as f32, 0.0);
        }
    }
    // A marker coordinate, to find the point's bytes.
    rows[0][1].z = 0.012_345;
    let surface = bezier_patch(&rows).unwrap();
    let patches = [WirePatch::Surface(surface.view())];
    let bytes = encode_scene(&[WireObject {
        material: material_a(),
        patches: &patches,
    }])
    .unwrap();
    let hom = |p: Vec3, w: f32| -> Vec<u8> {
        [p.x * w, p.y * w, p.z * w, w]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect()
    };
    let original = hom(rows[0][1], 1.0);
    let at = bytes
        .windows(16)
        .position(|w| w == original.as_slice())
        .unwrap();
    let mut store = Box::new(SceneStore::new());
    for (w, why) in [(9.2e-41f32, "subnormal"), (1e-20, "significant digits")] {
        let mut b = bytes.clone();
        b[at..at + 16].copy_from_slice(&hom(rows[0][1], w));
        let e = decode_scene(&b, &mut store).unwrap_err();
        assert_eq!(
            (e.code(), e.object, e.patch),
            (ErrorCode::ScenePatch, Some(0), Some(0))
        );
        let msg = e.to_string();
        assert!(msg.contains("weights[0][1]") && msg.contains(why), "{msg}");
        assert_eq!(store.object_count(), 0);
    }
    // The unmodified scene is accepted (the search found the right bytes).
    decode_scene(&bytes, &mut store).unwrap();
}

#[test]
fn store_capacity_is_enforced() {
    let line = bezier_curve(&[Vec2::new(0.0, 0.0), Vec2::new(0.01, 0.0)]).unwrap();
    let one = [WirePatch::Curve(line.view())];
    let objects = vec![
        WireObject {
            material: material_a(),
            patches: &one,
        };
        MAX_OBJECTS + 1
    ];
    assert_eq!(
        encode_scene(&objects).unwrap_err().code(),
        ErrorCode::SceneCapacity
    );
    assert!(encode_scene(&objects[..MAX_OBJECTS]).is_ok());
    // A curve of more control points than the store holds.
    let n = MAX_CURVE_POINTS + 1;
    let pts: Vec<Vec2> = (0..n).map(|i| Vec2::new(i as f32 * 1e-4, 0.0)).collect();
    let knots = nurbs::construct::uniform_knots(n, 1);
    let big = CurveBuf::<Vec2>::from_cartesian(1, knots, &pts, None).unwrap();
    let e = encode_scene(&[WireObject {
        material: material_a(),
        patches: &[WirePatch::Curve(big.view())],
    }])
    .unwrap_err();
    assert_eq!(
        (e.code(), e.object, e.patch),
        (ErrorCode::SceneCapacity, Some(0), Some(0))
    );
}

/// A store with smaller capacities (a board's) takes every scene that fits exactly as the
/// default one does, and refuses, as a capacity error at the patch that overflows, one knot or
/// one control point more than it holds, leaving itself empty.
#[test]
fn a_small_store_holds_what_fits_and_refuses_one_more() {
    // The ring (a closed rational quadratic circle) alone: its knot and point counts.
    let ring = ring();
    let (n_knots, n_points) = (
        ring.view().knots().as_slice().len(),
        ring.view().points().len(),
    );
    let bytes = encode_scene(&[WireObject {
        material: material_b(),
        patches: &[WirePatch::Curve(ring.view())],
    }])
    .unwrap();
    assert_eq!(SceneStore::<9, 7, 1>::KNOT_CAPACITY, 9);
    assert_eq!(
        (n_knots, n_points),
        (12, 9),
        "the ring's counts changed: update the test"
    );

    let mut exact = SceneStore::<12, 9, 1>::empty();
    decode_scene(&bytes, &mut exact).unwrap();
    let mut default = Box::new(SceneStore::new());
    decode_scene(&bytes, &mut default).unwrap();
    assert_eq!(exact.material(0), Some(material_b()));
    assert_eq!(exact.material(0), default.material(0));
    assert_eq!(exact.curve(0, 0), default.curve(0, 0));
    assert_eq!(exact.curve(0, 0).unwrap(), ring.view());

    let mut short_of_knots = SceneStore::<11, 9, 1>::empty();
    let e = decode_scene(&bytes, &mut short_of_knots).unwrap_err();
    assert_eq!(
        (e.code(), e.object, e.patch),
        (ErrorCode::SceneCapacity, Some(0), Some(0))
    );
    assert_eq!(short_of_knots.object_count(), 0);
    assert_eq!(short_of_knots.material(0), None);

    let mut short_of_points = SceneStore::<12, 8, 1>::empty();
    let e = decode_scene(&bytes, &mut short_of_points).unwrap_err();
    assert_eq!(
        (e.code(), e.object, e.patch),
        (ErrorCode::SceneCapacity, Some(0), Some(0))
    );
    assert_eq!(short_of_points.curve(0, 0), None);
    // The failed store still takes a scene that fits afterwards.
    decode_scene(&bytes, &mut exact).unwrap();
    assert_eq!(exact.object_count(), 1);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn decoding_any_scene_bytes_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let mut store = Box::new(SceneStore::new());
        if decode_scene(&bytes, &mut store).is_err() {
            prop_assert_eq!(store.object_count(), 0);
        }
    }

    #[test]
    fn decoding_a_mutated_scene_never_panics(at in any::<prop::sample::Index>(), value in any::<u8>()) {
        let mut bytes = scene_bytes(true);
        let at = at.index(bytes.len());
        bytes[at] = value;
        let mut store = Box::new(SceneStore::new());
        let _ = decode_scene(&bytes, &mut store);
    }
}

// ---------------------------------------------------------------------------------------
// The receiver

type Receiver = SceneReceiver<4096>;

fn never(_: &[u8]) -> Result<(), WireSceneError> {
    panic!("the validator must not run")
}

fn accept_all(_: &[u8]) -> Result<(), WireSceneError> {
    Ok(())
}

/// A host: numbers its frames.
struct Host {
    seq: u16,
}

/// After a refusal of an in-sequence frame with a good CRC: the active scene, its CRC and the
/// upload's progress are those of `before`, and the frame used up its number (`next` is
/// expected), so the host's next frame, already on its way, goes through.
fn refused_in_sequence(rx: &Receiver, before: &Receiver, next: u16) {
    assert_eq!(rx.active_scene(), before.active_scene());
    assert_eq!(rx.active_crc32(), before.active_crc32());
    assert_eq!(rx.upload_received(), before.upload_received());
    assert_eq!(rx.expected_seq(), Some(next));
}

impl Host {
    fn frame(&mut self, message: Message) -> Vec<u8> {
        let f = encode(self.seq, message);
        self.seq = next_seq(self.seq);
        f
    }
}

/// Uploads `scene` with every frame acked; returns the receiver and the host.
fn upload(rx: &mut Receiver, host: &mut Host, scene: &[u8], store: &mut SceneStore) {
    for m in scene_upload(scene) {
        let f = host.frame(m);
        let outcome = rx.receive(&f, store);
        assert!(outcome.is_ok(), "{m:?}: {outcome:?}");
        assert_eq!(
            Receiver::reply(&outcome),
            Message::Ack {
                seq: host.seq.wrapping_sub(1)
            }
        );
    }
}

/// A receiver with `scene_bytes(false)` active, and the host that uploaded it.
fn loaded() -> (Box<Receiver>, Host) {
    let mut rx = Box::new(Receiver::new());
    let mut host = Host { seq: 100 };
    let hello = host.frame(Message::Hello(Hello {
        software: [0, 1, 0],
        scene_capacity: 0,
        max_payload: MAX_PAYLOAD as u8,
    }));
    rx.receive(&hello, &mut never).unwrap();
    upload(
        &mut rx,
        &mut host,
        &scene_bytes(false),
        &mut SceneStore::new(),
    );
    (rx, host)
}

#[test]
fn full_upload_round_trip() {
    let mut rx = Box::new(Receiver::new());
    let mut host = Host { seq: 0 };
    let mut store = Box::new(SceneStore::new());
    let scene = scene_bytes(true);
    assert!(scene.len() > 10 * MAX_CHUNK, "{}", scene.len());
    upload(&mut rx, &mut host, &scene, &mut store);
    assert_eq!(rx.active_scene(), &scene[..]);
    assert_eq!(rx.active_crc32(), crc32(&scene));
    assert_eq!(rx.expected_seq(), Some(host.seq));
    assert_eq!(rx.upload_received(), None);
    // The validator's store holds the scene; evaluate it against the originals.
    let (ring, cubic) = (ring(), cubic());
    for k in 0..=64 {
        let u = k as f32 / 64.0;
        assert_eq!(store.curve(0, 0).unwrap().point(u), ring.view().point(u));
        assert_eq!(store.curve(1, 0).unwrap().point(u), cubic.view().point(u));
    }
    // A second scene replaces the first.
    let second = scene_bytes(false);
    upload(&mut rx, &mut host, &second, &mut store);
    assert_eq!(rx.active_scene(), &second[..]);
    assert_eq!(store.object_count(), 2);
}

#[test]
fn sequence_gap_is_nacked_and_changes_nothing() {
    let (mut rx, mut host) = loaded();
    let before = (*rx).clone();
    let expected = host.seq;
    host.seq = expected.wrapping_add(2);
    let f = host.frame(Message::EnableForces);
    let nack = rx.receive(&f, &mut never).unwrap_err();
    assert_eq!(nack.code, ErrorCode::SequenceGap);
    assert_eq!(nack.seq, expected.wrapping_add(2));
    assert_eq!(nack.expected_seq, expected);
    assert_eq!(*rx, before);
    // A repeated frame too.
    let f = encode(expected.wrapping_sub(1), Message::EnableForces);
    assert_eq!(
        rx.receive(&f, &mut never).unwrap_err().code,
        ErrorCode::SequenceGap
    );
    assert_eq!(*rx, before);
    // The right number goes through; a hello resynchronises.
    let f = encode(expected, Message::EnableForces);
    assert_eq!(
        rx.receive(&f, &mut never).unwrap().message,
        Message::EnableForces
    );
    let f = encode(
        9,
        Message::Hello(Hello {
            software: [0; 3],
            scene_capacity: 0,
            max_payload: 57,
        }),
    );
    rx.receive(&f, &mut never).unwrap();
    assert_eq!(rx.expected_seq(), Some(10));
    assert_eq!(rx.active_scene(), before.active_scene());
}

#[test]
fn device_bound_messages_only() {
    let (mut rx, mut host) = loaded();
    let before = (*rx).clone();
    for m in [
        Message::Ack { seq: 1 },
        Message::Telemetry(telemetry_example()),
    ] {
        let f = host.frame(m);
        let nack = rx.receive(&f, &mut never).unwrap_err();
        assert_eq!(nack.code, ErrorCode::UnexpectedMessage);
        assert_eq!(nack.expected_seq, host.seq);
        refused_in_sequence(&rx, &before, host.seq);
    }
}

#[test]
fn each_upload_error_has_its_code_and_changes_nothing() {
    let (mut rx, mut host) = loaded();
    let old = rx.active_scene().to_vec();
    let new = scene_bytes(true);
    let msgs: Vec<Message> = scene_upload(&new).collect();
    let n_chunks = msgs.len() - 2;

    let expect = |rx: &mut Receiver, host: &mut Host, m: Message, code: ErrorCode| {
        let before = (*rx).clone();
        let seq = host.seq;
        let f = host.frame(m);
        let nack = rx.receive(&f, &mut accept_all).unwrap_err();
        assert_eq!(nack.code, code, "{m:?}");
        assert_eq!(nack.seq, seq);
        refused_in_sequence(rx, &before, host.seq);
        assert_eq!(rx.active_scene(), &old[..]);
    };
    let accept = |rx: &mut Receiver, host: &mut Host, m: Message| {
        let f = host.frame(m);
        rx.receive(&f, &mut accept_all).unwrap();
    };

    // Chunk and commit without a begin.
    expect(&mut rx, &mut host, msgs[1], ErrorCode::NoUpload);
    expect(
        &mut rx,
        &mut host,
        Message::SceneCommit,
        ErrorCode::NoUpload,
    );
    // Too large for the buffer.
    expect(
        &mut rx,
        &mut host,
        Message::SceneBegin {
            total_len: 4097,
            crc32: 0,
        },
        ErrorCode::SceneTooLarge,
    );
    accept(&mut rx, &mut host, msgs[0]);
    // Missing chunk (the second before the first), commit before the end.
    expect(&mut rx, &mut host, msgs[2], ErrorCode::MissingChunk);
    expect(
        &mut rx,
        &mut host,
        Message::SceneCommit,
        ErrorCode::LengthMismatch,
    );
    accept(&mut rx, &mut host, msgs[1]);
    // Duplicate.
    expect(&mut rx, &mut host, msgs[1], ErrorCode::DuplicateChunk);
    for m in &msgs[2..=n_chunks] {
        accept(&mut rx, &mut host, *m);
    }
    // Past the end: one more byte at the right offset.
    let past = Message::SceneChunk(SceneChunk::new(new.len() as u32, &[0]).unwrap());
    expect(&mut rx, &mut host, past, ErrorCode::ChunkPastEnd);
    accept(&mut rx, &mut host, Message::SceneCommit);
    assert_eq!(rx.active_scene(), &new[..]);
}

#[test]
fn a_chunk_overrunning_the_total_is_rejected() {
    let (mut rx, mut host) = loaded();
    let f = host.frame(Message::SceneBegin {
        total_len: 10,
        crc32: crc32(&[0; 10]),
    });
    rx.receive(&f, &mut never).unwrap();
    let before = (*rx).clone();
    let f = host.frame(Message::SceneChunk(SceneChunk::new(0, &[0; 11]).unwrap()));
    assert_eq!(
        rx.receive(&f, &mut never).unwrap_err().code,
        ErrorCode::ChunkPastEnd
    );
    refused_in_sequence(&rx, &before, host.seq);
}

#[test]
fn commit_checks_crc_and_validation_and_keeps_the_old_scene() {
    let (mut rx, mut host) = loaded();
    let old = rx.active_scene().to_vec();
    let mut store = Box::new(SceneStore::new());

    // Wrong CRC announced.
    let new = scene_bytes(true);
    let mut msgs: Vec<Message> = scene_upload(&new).collect();
    msgs[0] = Message::SceneBegin {
        total_len: new.len() as u32,
        crc32: crc32(&new) ^ 1,
    };
    let last = msgs.pop().unwrap();
    for m in msgs {
        let f = host.frame(m);
        rx.receive(&f, &mut *store).unwrap();
    }
    let before = (*rx).clone();
    let f = host.frame(last);
    assert_eq!(
        rx.receive(&f, &mut *store).unwrap_err().code,
        ErrorCode::SceneCrc
    );
    refused_in_sequence(&rx, &before, host.seq);
    assert_eq!(rx.active_scene(), &old[..]);

    // Correct CRC of bytes that fail validation: a zero weight in object 0, patch 0.
    let w0 = OBJ0_KNOTS + 12 * 4 + 8;
    let bad = patched(|b| b[w0..w0 + 4].copy_from_slice(&0.0f32.to_le_bytes()));
    let mut msgs: Vec<Message> = scene_upload(&bad).collect();
    let last = msgs.pop().unwrap();
    for m in msgs {
        let f = host.frame(m);
        rx.receive(&f, &mut *store).unwrap();
    }
    let before = (*rx).clone();
    let f = host.frame(last);
    let nack = rx.receive(&f, &mut *store).unwrap_err();
    assert_eq!(
        (nack.code, nack.object, nack.patch),
        (ErrorCode::ScenePatch, 0, 0)
    );
    refused_in_sequence(&rx, &before, host.seq);
    assert_eq!(rx.active_scene(), &old[..]);

    // A topology failure reported by a custom validator names no patch.
    let f = host.frame(Message::SceneBegin {
        total_len: 1,
        crc32: crc32(&[7]),
    });
    rx.receive(&f, &mut *store).unwrap();
    let f = host.frame(Message::SceneChunk(SceneChunk::new(0, &[7]).unwrap()));
    rx.receive(&f, &mut *store).unwrap();
    let f = encode(host.seq, Message::SceneCommit);
    let nack = rx.receive(&f, &mut *store).unwrap_err();
    assert_eq!(
        (nack.code, nack.object, nack.patch),
        (ErrorCode::SceneFormat, NO_INDEX, NO_INDEX)
    );
    assert_eq!(rx.active_scene(), &old[..]);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Random bytes (including random 64-byte reports) never panic the receiver and never
    /// change it: not its sequence number, not an upload in progress, not the active scene.
    #[test]
    fn random_bytes_never_change_the_receiver(
        frames in prop::collection::vec(prop::collection::vec(any::<u8>(), 0..70), 1..8),
        mid_upload in any::<bool>(),
    ) {
        let (mut rx, mut host) = loaded();
        if mid_upload {
            let new = scene_bytes(true);
            for m in scene_upload(&new).take(4) {
                let f = host.frame(m);
                rx.receive(&f, &mut never).unwrap();
            }
        }
        let before = (*rx).clone();
        for f in &frames {
            let nack = rx.receive(f, &mut never).unwrap_err();
            prop_assert!(nack.code != ErrorCode::SceneFormat);
            prop_assert_eq!(&*rx, &before);
        }
    }

    /// Every frame of an upload with one byte corrupted is rejected (the CRC catches payload
    /// corruption) and leaves the receiver, and so the active scene, byte-identical.
    #[test]
    fn corrupted_upload_frames_are_rejected(which in any::<prop::sample::Index>(), at in any::<prop::sample::Index>(), flip in 1u8..=255) {
        let (mut rx, mut host) = loaded();
        let new = scene_bytes(true);
        let msgs: Vec<Message> = scene_upload(&new).collect();
        let which = which.index(msgs.len());
        for m in &msgs[..which] {
            let f = host.frame(*m);
            rx.receive(&f, &mut accept_all).unwrap();
        }
        let before = (*rx).clone();
        let mut f = encode(host.seq, msgs[which]);
        let at = at.index(f.len());
        f[at] ^= flip;
        let nack = rx.receive(&f, &mut never).unwrap_err();
        prop_assert!(matches!(nack.code, ErrorCode::BadCrc | ErrorCode::BadLength), "{:?}", nack);
        prop_assert_eq!(nack.seq, UNKNOWN_SEQ);
        prop_assert_eq!(&*rx, &before);
    }

    /// Chunks sent in any order other than the right one, with duplicates and omissions: every
    /// chunk out of place is rejected with its code, and the scene becomes active only if all
    /// of it arrived in order.
    #[test]
    fn shuffled_duplicated_or_missing_chunks(order in prop::collection::vec(0usize..40, 0..60)) {
        let (mut rx, mut host) = loaded();
        let old = rx.active_scene().to_vec();
        let new = scene_bytes(true);
        let msgs: Vec<Message> = scene_upload(&new).collect();
        let chunks = &msgs[1..msgs.len() - 1];
        let f = host.frame(msgs[0]);
        rx.receive(&f, &mut accept_all).unwrap();
        let mut next = 0;
        for &i in &order {
            let Some(chunk) = chunks.get(i) else { continue };
            let before = (*rx).clone();
            let f = encode(host.seq, *chunk);
            match rx.receive(&f, &mut accept_all) {
                Ok(_) => {
                    prop_assert_eq!(i, next);
                    next += 1;
                    host.seq = host.seq.wrapping_add(1);
                }
                Err(nack) => {
                    let code = if i < next { ErrorCode::DuplicateChunk } else { ErrorCode::MissingChunk };
                    prop_assert_eq!(nack.code, code);
                    // Refused in sequence: the number is used up, nothing else changes.
                    host.seq = host.seq.wrapping_add(1);
                    refused_in_sequence(&rx, &before, host.seq);
                }
            }
        }
        let f = encode(host.seq, Message::SceneCommit);
        let outcome = rx.receive(&f, &mut accept_all);
        if next == chunks.len() {
            prop_assert!(outcome.is_ok());
            prop_assert_eq!(rx.active_scene(), &new[..]);
        } else {
            prop_assert_eq!(outcome.unwrap_err().code, ErrorCode::LengthMismatch);
            prop_assert_eq!(rx.active_scene(), &old[..]);
        }
    }
}

#[test]
fn accepted_frames_are_returned_and_acked() {
    let (mut rx, mut host) = loaded();
    for m in [
        Message::Heartbeat { uptime_ms: 5 },
        Message::SetMaterial {
            object: 1,
            material: material_b(),
        },
        Message::EnableForces,
        Message::DisableForces,
        Message::Calibrate,
        Message::ClearFaults { mask: 0b101 },
    ] {
        let seq = host.seq;
        let f = host.frame(m);
        let outcome = rx.receive(&f, &mut never);
        assert_eq!(outcome, Ok(Frame { seq, message: m }));
        assert_eq!(Receiver::reply(&outcome), Message::Ack { seq });
        assert_eq!(rx.expected_seq(), Some(host.seq));
    }
}

#[test]
fn hello_abandons_an_upload_but_keeps_the_scene() {
    let (mut rx, mut host) = loaded();
    let old = rx.active_scene().to_vec();
    let new = scene_bytes(true);
    for m in scene_upload(&new).take(3) {
        let f = host.frame(m);
        rx.receive(&f, &mut never).unwrap();
    }
    assert_eq!(rx.upload_received(), Some(2 * MAX_CHUNK));
    let f = host.frame(Message::Hello(Hello {
        software: [0, 1, 0],
        scene_capacity: 0,
        max_payload: MAX_PAYLOAD as u8,
    }));
    rx.receive(&f, &mut never).unwrap();
    assert_eq!(rx.upload_received(), None);
    assert_eq!(rx.active_scene(), &old[..]);
    let f = host.frame(Message::SceneCommit);
    assert_eq!(
        rx.receive(&f, &mut never).unwrap_err().code,
        ErrorCode::NoUpload
    );
}

#[test]
fn a_board_refuses_a_hand_target_and_a_simulated_plant_takes_it() {
    // A board's receiver (`SceneReceiver::new`): refused with its own code, nothing changed
    // (sequence number, upload, active scene).
    let (mut rx, mut host) = loaded();
    let before = (*rx).clone();
    let target = Message::HandTarget {
        target_m: nurbs::Vec2::new(0.01, 0.09),
    };
    let seq = host.seq;
    let f = host.frame(target);
    let nack = rx.receive(&f, &mut never).unwrap_err();
    assert_eq!(nack.code, ErrorCode::NotSimulated);
    assert_eq!(nack.seq, seq);
    refused_in_sequence(&rx, &before, host.seq);

    // A simulated plant's receiver hands the message on, with its target, and moves on.
    let mut sim: SceneReceiver<8192> = SceneReceiver::for_simulated_plant();
    let frame = sim.receive(&f, &mut never).unwrap();
    assert_eq!(frame.message, target);
    assert_eq!(sim.expected_seq(), Some(seq.wrapping_add(1)));

    // A non-finite target is not a message (decoding checks it).
    let mut bytes = [0u8; MAX_FRAME];
    let n = Frame {
        seq: 0,
        message: Message::HandTarget {
            target_m: nurbs::Vec2::new(f32::NAN, 0.0),
        },
    }
    .encode(&mut bytes);
    assert_eq!(
        sim.receive(&bytes[..n], &mut never).unwrap_err().code,
        ErrorCode::BadField
    );
}

#[test]
fn a_frame_sent_behind_a_refused_one_goes_through() {
    // A host that does not wait for each ack (heartbeats and hand targets stream while it
    // uploads): a chunk without a begin is refused, and the heartbeat already sent behind it
    // is accepted, not refused as a sequence gap. A lost frame is still a gap.
    let (mut rx, mut host) = loaded();
    let chunk = host.frame(Message::SceneChunk(SceneChunk::new(0, &[1, 2, 3]).unwrap()));
    let heartbeat_seq = host.seq;
    let heartbeat = host.frame(Message::Heartbeat { uptime_ms: 1 });
    assert_eq!(
        rx.receive(&chunk, &mut never).unwrap_err().code,
        ErrorCode::NoUpload
    );
    assert_eq!(
        rx.receive(&heartbeat, &mut never).map(|f| f.seq),
        Ok(heartbeat_seq)
    );
    let _lost = host.frame(Message::EnableForces);
    let after_loss = host.frame(Message::DisableForces);
    let nack = rx.receive(&after_loss, &mut never).unwrap_err();
    assert_eq!(nack.code, ErrorCode::SequenceGap);
    assert_eq!(nack.expected_seq, heartbeat_seq.wrapping_add(1));
}

/// The report descriptor read as the USB HID 1.11 spec defines its short items (§6.2.2.2:
/// a prefix byte with the tag in bits 7–2 and the data size 0, 1, 2 or 4 bytes in bits 1–0):
/// one input and one output report of exactly one frame each, no report id (the host's
/// `HidLink` writes id 0 before a frame and reads bare frames), every collection closed.
#[test]
fn report_descriptor_declares_one_frame_each_way_without_report_ids() {
    // Item tags with their size bits cleared (HID 1.11 §6.2.2.4–7).
    const INPUT: u8 = 0x80;
    const OUTPUT: u8 = 0x90;
    const COLLECTION: u8 = 0xA0;
    const END_COLLECTION: u8 = 0xC0;
    const REPORT_SIZE: u8 = 0x74;
    const REPORT_ID: u8 = 0x84;
    const REPORT_COUNT: u8 = 0x94;
    let (mut size_bits, mut count) = (0u32, 0u32);
    let (mut input_bits, mut output_bits, mut depth) = (Vec::new(), Vec::new(), 0i32);
    let mut at = 0;
    while at < REPORT_DESCRIPTOR.len() {
        let prefix = REPORT_DESCRIPTOR[at];
        let len = [0, 1, 2, 4][usize::from(prefix & 3)];
        let data = &REPORT_DESCRIPTOR[at + 1..at + 1 + len];
        let value = data
            .iter()
            .rev()
            .fold(0u32, |v, b| (v << 8) | u32::from(*b));
        match prefix & 0xFC {
            REPORT_SIZE => size_bits = value,
            REPORT_COUNT => count = value,
            REPORT_ID => panic!("report id {value}: HidLink sends unnumbered reports"),
            INPUT => input_bits.push(size_bits * count),
            OUTPUT => output_bits.push(size_bits * count),
            COLLECTION => depth += 1,
            END_COLLECTION => depth -= 1,
            _ => {}
        }
        assert!(
            depth >= 0,
            "end collection without a collection at byte {at}"
        );
        at += 1 + len;
    }
    assert_eq!(
        at,
        REPORT_DESCRIPTOR.len(),
        "the last item runs past the end"
    );
    assert_eq!(depth, 0, "a collection is not closed");
    let frame_bits = 8 * MAX_FRAME as u32;
    assert_eq!(input_bits, [frame_bits], "one input report of one frame");
    assert_eq!(output_bits, [frame_bits], "one output report of one frame");
}

/// A lost host frame costs one nack wherever it falls in the numbering, the wrap included:
/// the host's `Sequencer` follows the device's sequence-gap nack and the next 50 frames go
/// through. Before host numbers skipped 0xFFFF, losing the frame numbered 0xFFFF left the
/// device expecting 0xFFFF, which its nacks cannot name (it is `UNKNOWN_SEQ`), and 0 of the
/// next 50 frames were accepted.
#[test]
fn a_lost_frame_costs_one_nack_anywhere_in_the_numbering() {
    use protocol::host_side::Sequencer;
    for lost in [0x1234u16, 0xFFFD, 0xFFFE, 0x0000, 0x0001] {
        let mut rx = Box::new(Receiver::new());
        let mut host = Sequencer::default();
        // Bring the host's numbering to a few frames before the loss.
        while host.encode(&Message::EnableForces).2 != lost.wrapping_sub(6) {}
        let hello = host
            .encode(&Message::Hello(Hello {
                software: [0, 1, 0],
                scene_capacity: 0,
                max_payload: MAX_PAYLOAD as u8,
            }))
            .0;
        rx.receive(&hello, &mut never).unwrap();
        let mut accepted_after_nack = 0;
        let mut nacks = 0;
        let mut dropped = false;
        for _ in 0..60 {
            let (report, n, seq) = host.encode(&Message::Heartbeat { uptime_ms: 1 });
            assert_ne!(seq, UNKNOWN_SEQ, "no host frame is numbered 0xFFFF");
            if seq == lost && !dropped {
                dropped = true;
                continue; // lost on the way (its number is sent again after the nack)
            }
            match rx.receive(&report[..n], &mut never) {
                Ok(_) if nacks > 0 => accepted_after_nack += 1,
                Ok(_) => {}
                Err(nack) => {
                    nacks += 1;
                    assert_eq!(nack.code, ErrorCode::SequenceGap, "lost {lost:#06x}");
                    assert_eq!(nack.expected_seq, lost, "lost {lost:#06x}");
                    // The reply reaches the host, which renumbers from the expected frame.
                    let reply = encode(0, Message::Nack(nack));
                    host.decode_reply(&reply).unwrap();
                }
            }
        }
        // The loss costs exactly one (nacked) frame.
        assert!(dropped);
        assert_eq!(nacks, 1, "lost {lost:#06x}");
        assert!(
            accepted_after_nack >= 50,
            "lost {lost:#06x}: {accepted_after_nack}"
        );
    }
}
