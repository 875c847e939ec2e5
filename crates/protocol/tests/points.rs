//! Control-point updates on the wire ([`Message::ScenePoints`]): the frame's layout and its
//! round trip, the receiver's staging (applied whole, on the apply frame only), each way an
//! update is refused with the active scene and its CRC unchanged, the device's CRC against
//! the host's independently re-encoded scene, and the simulated device behind a link
//! rendering the moving curve without losing contact.

#![allow(clippy::unwrap_used)]

use std::time::Duration;

use friction::{FrictionMaterial, Mode};
use nurbs::construct::{arc, bezier_patch};
use nurbs::{CurveBuf, SurfaceBuf, Vec2, Vec3};
use protocol::device_side::session::{DeviceSession, DeviceState, Event};
use protocol::host_side::{GapCounter, Link, SimConfig, SimLink};
use protocol::*;
use tracker::Feature;

const TIMEOUT: Duration = Duration::from_secs(5);

/// Thesis-2d's arcs: the right arc on the circle of radius 4 cm about (−0.02, 0.06) from 0°
/// to 60°, the left its mirror image, meeting at the vertex (0, 0.0946).
fn arcs() -> [CurveBuf<Vec2>; 2] {
    let d = std::f32::consts::PI / 180.0;
    let r = 0.04;
    [
        arc(
            Vec2::new(-0.02, 0.06),
            Vec2::X * r,
            Vec2::Y * r,
            0.0,
            60.0 * d,
        )
        .unwrap(),
        arc(
            Vec2::new(0.02, 0.06),
            Vec2::X * r,
            Vec2::Y * r,
            120.0 * d,
            60.0 * d,
        )
        .unwrap(),
    ]
}

/// A clamped cubic B-spline of ten control points: more than one frame holds.
fn wave() -> CurveBuf<Vec2> {
    let points: Vec<Vec2> = (0..10)
        .map(|i| Vec2::new(-0.045 + 0.01 * i as f32, 0.13 + 0.004 * (i % 2) as f32))
        .collect();
    let mut knots = vec![0.0; 4];
    knots.extend((1..7).map(|k| k as f32 / 7.0));
    knots.extend([1.0; 4]);
    CurveBuf::from_cartesian(3, knots, &points, None).unwrap()
}

fn sheet() -> SurfaceBuf {
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

/// The scene: object 0 the arcs, object 1 the wave, object 2 a surface; encoded by the
/// host's encoder from the curves given.
fn scene_of(arcs: &[CurveBuf<Vec2>; 2], wave: &CurveBuf<Vec2>) -> Vec<u8> {
    let sheet = sheet();
    let a = [
        WirePatch::Curve(arcs[0].view()),
        WirePatch::Curve(arcs[1].view()),
    ];
    let w = [WirePatch::Curve(wave.view())];
    let s = [WirePatch::Surface(sheet.view())];
    let m = FrictionMaterial::default();
    encode_scene(&[
        WireObject {
            material: m,
            patches: &a,
        },
        WireObject {
            material: m,
            patches: &w,
        },
        WireObject {
            material: m,
            patches: &s,
        },
    ])
    .unwrap()
}

fn scene() -> Vec<u8> {
    scene_of(&arcs(), &wave())
}

/// Cartesian control point `i` of `c`.
fn point(c: &CurveBuf<Vec2>, i: usize) -> Vec2 {
    c.view().control_point(i).unwrap().0
}

/// The device side: a session, its scratch store, and the frames it answered.
struct Device {
    session: Box<DeviceSession<4096>>,
    scratch: Box<SceneStore>,
}

/// The host side: numbers its frames.
struct Host {
    seq: u16,
}

impl Host {
    fn frame(&mut self, message: Message) -> Vec<u8> {
        let (report, n) = Frame {
            seq: self.seq,
            message,
        }
        .to_report();
        self.seq = self.seq.wrapping_add(1);
        report[..n].to_vec()
    }
}

impl Device {
    fn new() -> Self {
        Device {
            session: Box::new(DeviceSession::new(false)),
            scratch: Box::new(SceneStore::new()),
        }
    }

    /// Handles `message`: the session's event and its reply (an ack or a nack).
    fn handle(&mut self, host: &mut Host, message: Message) -> (Event, Message) {
        let bytes = host.frame(message);
        let mut reply = None;
        let state = DeviceState::default();
        let event =
            self.session
                .handle(&bytes, self.scratch.as_mut(), state, &mut |m: &Message| {
                    if matches!(m, Message::Ack { .. } | Message::Nack(_)) {
                        reply = Some(*m);
                    }
                });
        (event, reply.unwrap())
    }

    /// Uploads `scene`, every frame acked.
    fn upload(&mut self, host: &mut Host, scene: &[u8]) {
        for m in scene_upload(scene) {
            let (_, reply) = self.handle(host, m);
            assert!(matches!(reply, Message::Ack { .. }), "{m:?}: {reply:?}");
        }
    }

    fn active(&self) -> (Vec<u8>, u32) {
        let r = self.session.receiver();
        (r.active_scene().to_vec(), r.active_crc32())
    }
}

/// A device with [`scene`] active, and its host.
fn loaded() -> (Device, Host) {
    let mut device = Device::new();
    let mut host = Host { seq: 7 };
    device.upload(&mut host, &scene());
    (device, host)
}

// ---------------------------------------------------------------------------------------
// The frame

#[test]
fn the_frame_carries_its_header_and_the_points_in_order() {
    let points = [Vec2::new(0.25, -1.5), Vec2::new(3.0, 0.125)];
    let m = Message::ScenePoints(ScenePoints::planar(2, 5, 0x0102, true, &points).unwrap());
    let (report, n) = Frame { seq: 9, message: m }.to_report();
    assert_eq!(report[1], 0x13);
    let payload = &report[HEADER_LEN..n - CRC_LEN];
    let mut expected = vec![2, 5, 0x02, 0x01, POINTS_APPLY];
    for v in [0.25f32, -1.5, 3.0, 0.125] {
        expected.extend(v.to_le_bytes());
    }
    assert_eq!(payload, &expected[..]);
    // Six planar or four surface points fill a frame; weights are not sent.
    assert_eq!((MAX_POINTS_2D, MAX_POINTS_3D), (6, 4));
    let full = [Vec2::ONE; MAX_POINTS_2D];
    let n = Frame {
        seq: 0,
        message: Message::ScenePoints(ScenePoints::planar(0, 0, 0, false, &full).unwrap()),
    }
    .to_report()
    .1;
    assert_eq!(
        n,
        HEADER_LEN + POINTS_HEADER_LEN + 8 * MAX_POINTS_2D + CRC_LEN
    );
    assert!(ScenePoints::planar(0, 0, 0, false, &[Vec2::ONE; 7]).is_none());
    assert!(ScenePoints::planar(0, 0, 0, false, &[]).is_none());
    assert!(ScenePoints::spatial(0, 0, 0, false, &[Vec3::ONE; 5]).is_none());
    let s = ScenePoints::spatial(1, 0, 3, false, &[Vec3::new(1.0, 2.0, 3.0)]).unwrap();
    assert_eq!(
        s.spatial_points().collect::<Vec<_>>(),
        [Vec3::new(1.0, 2.0, 3.0)]
    );
    assert_eq!(s.planar_points().count(), 0);
    let f = Frame {
        seq: 1,
        message: Message::ScenePoints(s),
    };
    assert_eq!(Frame::decode(&f.to_report().0), Ok(f));
}

/// A ScenePoints frame with `payload`, its CRC correct.
fn raw(payload: &[u8]) -> Vec<u8> {
    let mut f = vec![
        VERSION,
        MessageType::ScenePoints as u8,
        4,
        0,
        payload.len() as u8,
    ];
    f.extend_from_slice(payload);
    let crc = crc16_ccitt_false(&f);
    f.extend(crc.to_le_bytes());
    f
}

#[test]
fn each_malformed_points_frame_has_its_code() {
    let header = |flags: u8| vec![0u8, 0, 0, 0, flags];
    let with = |flags: u8, coords: &[f32]| {
        let mut p = header(flags);
        for c in coords {
            p.extend(c.to_le_bytes());
        }
        raw(&p)
    };
    let code = |bytes: &[u8]| Frame::decode(bytes).unwrap_err().code;
    // No points, or a point cut short.
    assert_eq!(code(&raw(&header(0))), ErrorCode::BadPayloadLength);
    assert_eq!(code(&with(0, &[1.0])), ErrorCode::BadPayloadLength);
    // Three coordinates are not planar points, two not a surface point.
    assert_eq!(
        code(&with(0, &[1.0, 2.0, 3.0])),
        ErrorCode::BadPayloadLength
    );
    assert_eq!(
        code(&with(POINTS_SPATIAL, &[1.0, 2.0])),
        ErrorCode::BadPayloadLength
    );
    // Five surface points would be 65 bytes of payload.
    assert_eq!(
        code(&with(POINTS_SPATIAL, &[1.0; 15])),
        ErrorCode::BadLength
    );
    // An unknown flag.
    assert_eq!(code(&with(4, &[1.0, 2.0])), ErrorCode::BadField);
    // Non-finite coordinates.
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        assert_eq!(code(&with(0, &[1.0, bad])), ErrorCode::BadField, "{bad}");
        assert_eq!(
            code(&with(POINTS_SPATIAL, &[bad, 1.0, 2.0])),
            ErrorCode::BadField
        );
    }
    // The good ones decode.
    assert!(Frame::decode(&with(POINTS_APPLY, &[1.0, 2.0])).is_ok());
    assert!(Frame::decode(&with(POINTS_SPATIAL, &[1.0, 2.0, 3.0])).is_ok());
}

#[test]
fn the_update_frames_split_points_and_mark_the_last() {
    let ten: Vec<Vec2> = (0..10).map(|i| Vec2::splat(i as f32)).collect();
    let two = [Vec2::ONE, Vec2::ZERO];
    let frames: Vec<ScenePoints> = points_update(3, &[(1, 2, &ten[..]), (4, 0, &two[..])])
        .map(|m| match m {
            Message::ScenePoints(p) => p,
            other => panic!("{other:?}"),
        })
        .collect();
    let summary: Vec<(u8, u8, u16, usize, bool)> = frames
        .iter()
        .map(|p| (p.object, p.patch, p.first, p.len(), p.apply))
        .collect();
    assert_eq!(
        summary,
        [(3, 1, 2, 6, false), (3, 1, 8, 4, false), (3, 4, 0, 2, true)]
    );
    assert_eq!(frames[1].planar_points().next(), Some(Vec2::splat(6.0)));
    assert_eq!(points_update(0, &[]).count(), 0);
    let sheet = [Vec3::ONE; 6];
    let spatial: Vec<(usize, bool)> = points_update_spatial(2, &[(0, 0, &sheet[..])])
        .map(|m| match m {
            Message::ScenePoints(p) => (p.len(), p.apply),
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(spatial, [(4, false), (2, true)]);
}

// ---------------------------------------------------------------------------------------
// The receiver

#[test]
fn an_update_gives_the_scene_and_crc_the_host_encodes() {
    let (mut device, mut host) = loaded();
    let arcs = arcs();
    let to = point(&arcs[0], 1) + Vec2::new(1e-3, 0.5e-3);
    let mut event = Event::None;
    for m in points_update(0, &[(0, 1, &[to][..])]) {
        let (e, reply) = device.handle(&mut host, m);
        assert!(matches!(reply, Message::Ack { .. }), "{reply:?}");
        event = e;
    }
    assert_eq!(event, Event::ScenePointsUpdated { object: 0 });
    // The host's scene, re-encoded from its moved curve (its point stored as (w·x, w·y, w)
    // by the curve's own `with_point`, the encoder, then the device's own validation).
    let moved = [arcs[0].with_point(1, to).unwrap(), arcs[1].clone()];
    let host_scene = scene_of(&moved, &wave());
    let (active, crc) = device.active();
    assert_eq!(active, host_scene);
    assert_eq!(crc, crc32(&host_scene));
    assert_eq!(
        device.session.status(DeviceState::default()).scene_crc32,
        crc32(&host_scene)
    );
    // A host keeping its own copy with `write_points` gets the same bytes.
    let mut copy = scene();
    for m in points_update(0, &[(0, 1, &[to][..])]) {
        let Message::ScenePoints(p) = m else {
            unreachable!()
        };
        write_points(&mut copy, &p).unwrap();
    }
    assert_eq!(copy, host_scene);
    // The scratch store holds the updated scene, for the controller's new object.
    let c = device.scratch.curve(0, 0).unwrap();
    assert_eq!(c.control_point(1).unwrap().0, to);
}

#[test]
fn a_surface_update_lands_as_the_host_encodes_it() {
    let (mut device, mut host) = loaded();
    let sheet = sheet();
    // Net point (1, 1) (index 1·3 + 1 = 4 along u major) lifted 1 mm, and its neighbour.
    let (n_u, n_v) = sheet.counts();
    let lifted: Vec<Vec3> = (4..6)
        .map(|k| {
            let h = sheet.points()[k];
            h.truncate() / h.w + Vec3::new(0.0, 0.0, 1e-3)
        })
        .collect();
    let mut event = Event::None;
    for m in points_update_spatial(2, &[(0, 4, &lifted[..])]) {
        let (e, reply) = device.handle(&mut host, m);
        assert!(matches!(reply, Message::Ack { .. }), "{reply:?}");
        event = e;
    }
    assert_eq!(event, Event::ScenePointsUpdated { object: 2 });
    // The host's surface with the same points, its weights kept: (w·x, w·y, w·z, w).
    let mut points = sheet.points().to_vec();
    for (k, p) in (4..6).zip(&lifted) {
        let w = points[k].w;
        points[k] = (*p * w).extend(w);
    }
    let (ku, kv) = sheet.knots();
    let moved = SurfaceBuf::new(sheet.degree(), (ku.to_vec(), kv.to_vec()), n_v, points).unwrap();
    assert_eq!(moved.counts(), (n_u, n_v));
    let arcs = arcs();
    let a = [
        WirePatch::Curve(arcs[0].view()),
        WirePatch::Curve(arcs[1].view()),
    ];
    let wave = wave();
    let w = [WirePatch::Curve(wave.view())];
    let s = [WirePatch::Surface(moved.view())];
    let m = FrictionMaterial::default();
    let host_scene = encode_scene(&[
        WireObject {
            material: m,
            patches: &a,
        },
        WireObject {
            material: m,
            patches: &w,
        },
        WireObject {
            material: m,
            patches: &s,
        },
    ])
    .unwrap();
    assert_eq!(device.active(), (host_scene.clone(), crc32(&host_scene)));
}

#[test]
fn a_multi_frame_update_applies_only_with_its_apply_frame() {
    let (mut device, mut host) = loaded();
    let before = device.active();
    let wave = wave();
    let lifted: Vec<Vec2> = (0..10)
        .map(|i| point(&wave, i) + Vec2::new(0.0, 1e-3 * i as f32))
        .collect();
    let frames: Vec<Message> = points_update(1, &[(0, 0, &lifted[..])]).collect();
    assert_eq!(frames.len(), 2);
    let (event, reply) = device.handle(&mut host, frames[0]);
    assert!(matches!(reply, Message::Ack { .. }));
    assert_eq!(event, Event::None);
    assert_eq!(device.active(), before, "staged, not applied");
    let (event, _) = device.handle(&mut host, frames[1]);
    assert_eq!(event, Event::ScenePointsUpdated { object: 1 });
    let moved = CurveBuf::from_cartesian(3, wave.knots().to_vec(), &lifted, None).unwrap();
    let host_scene = scene_of(&arcs(), &moved);
    assert_eq!(device.active(), (host_scene.clone(), crc32(&host_scene)));

    // The vertex where the arcs meet moves in one update of both patches: the end of the
    // right arc and the start of the left.
    let arcs = arcs();
    let vertex = point(&arcs[0], 2) + Vec2::new(0.0, 2e-3);
    let mut event = Event::None;
    for m in points_update(0, &[(0, 2, &[vertex][..]), (1, 0, &[vertex][..])]) {
        let (e, reply) = device.handle(&mut host, m);
        assert!(matches!(reply, Message::Ack { .. }), "{reply:?}");
        event = e;
    }
    assert_eq!(event, Event::ScenePointsUpdated { object: 0 });
    let both = [
        arcs[0].with_point(2, vertex).unwrap(),
        arcs[1].with_point(0, vertex).unwrap(),
    ];
    let host_scene = scene_of(&both, &moved);
    assert_eq!(device.active(), (host_scene.clone(), crc32(&host_scene)));
}

/// Sends the frames of one update; returns the last reply and event.
fn send_update(device: &mut Device, host: &mut Host, frames: &[Message]) -> (Event, Message) {
    let mut last = None;
    for &m in frames {
        last = Some(device.handle(host, m));
    }
    last.unwrap()
}

fn nack_of(reply: Message) -> Nack {
    match reply {
        Message::Nack(n) => n,
        other => panic!("not a nack: {other:?}"),
    }
}

fn planar(object: u8, patch: u8, first: u16, apply: bool, points: &[Vec2]) -> Message {
    Message::ScenePoints(ScenePoints::planar(object, patch, first, apply, points).unwrap())
}

#[test]
fn each_faulty_update_has_its_code_and_changes_nothing() {
    let arcs = arcs();
    let p1 = point(&arcs[0], 1);
    let here = [p1];

    // No active scene.
    let mut fresh = Device::new();
    let mut host = Host { seq: 0 };
    let (event, reply) = fresh.handle(&mut host, planar(0, 0, 1, true, &here));
    assert_eq!(event, Event::None);
    assert_eq!(nack_of(reply).code, ErrorCode::NoActiveScene);
    assert_eq!(fresh.active(), (Vec::new(), 0));

    // (what, frames, code, the nack's object and patch)
    let reflex = Vec2::new(0.02, 0.12);
    let end = point(&arcs[0], 2) + Vec2::new(0.0, 1e-3);
    let cases: Vec<(&str, Vec<Message>, ErrorCode, u8, u8)> = vec![
        (
            "no such object",
            vec![planar(9, 0, 0, true, &here)],
            ErrorCode::NoSuchPatch,
            9,
            0,
        ),
        (
            "no such patch",
            vec![planar(0, 2, 0, true, &here)],
            ErrorCode::NoSuchPatch,
            0,
            2,
        ),
        (
            "past the patch's points",
            vec![planar(0, 0, 2, true, &[p1, p1])],
            ErrorCode::PointsPastPatch,
            0,
            0,
        ),
        (
            "first index past the patch",
            vec![planar(0, 0, 3, true, &here)],
            ErrorCode::PointsPastPatch,
            0,
            0,
        ),
        (
            "spatial points for a curve",
            vec![Message::ScenePoints(
                ScenePoints::spatial(0, 0, 1, true, &[Vec3::ONE]).unwrap(),
            )],
            ErrorCode::PointsKind,
            0,
            0,
        ),
        (
            "planar points for a surface",
            vec![planar(2, 0, 0, true, &here)],
            ErrorCode::PointsKind,
            2,
            0,
        ),
        (
            "an end point moved alone: the chain comes apart (fails validation)",
            vec![planar(0, 0, 2, true, &[end])],
            ErrorCode::SceneTopology,
            0,
            NO_INDEX,
        ),
        (
            "the vertex turns reflex: another topology",
            vec![planar(0, 0, 1, true, &[reflex])],
            ErrorCode::TopologyChanged,
            0,
            NO_INDEX,
        ),
        (
            "a point so far that its weighted coordinates overflow f32 (fails validation)",
            vec![planar(0, 0, 1, true, &[Vec2::new(3e38, 0.0)])],
            ErrorCode::ScenePatch,
            0,
            0,
        ),
        (
            "a frame of another object while one is staged",
            vec![planar(0, 0, 1, false, &here), planar(1, 0, 0, true, &here)],
            ErrorCode::StagingBusy,
            1,
            NO_INDEX,
        ),
        (
            "the rest of an update whose first frame was refused",
            vec![
                planar(0, 0, 3, false, &here),
                planar(0, 0, 1, false, &here),
                planar(0, 0, 1, true, &here),
            ],
            ErrorCode::UpdateAborted,
            0,
            NO_INDEX,
        ),
    ];
    for (what, frames, code, object, patch) in cases {
        let (mut device, mut host) = loaded();
        let before = device.active();
        let (event, reply) = send_update(&mut device, &mut host, &frames);
        let n = nack_of(reply);
        assert_eq!((n.code, n.object, n.patch), (code, object, patch), "{what}");
        assert_eq!(event, Event::None, "{what}");
        assert_eq!(device.active(), before, "{what}: the active scene changed");
        assert_eq!(
            device.session.status(DeviceState::default()).last_error,
            code as u8,
            "{what}"
        );
        // The device goes on: the next update is applied.
        let (event, reply) = device.handle(&mut host, planar(0, 0, 1, true, &here));
        assert!(matches!(reply, Message::Ack { .. }), "{what}: {reply:?}");
        assert_eq!(event, Event::ScenePointsUpdated { object: 0 }, "{what}");
    }

    // During an upload the staging buffer is the upload's.
    let (mut device, mut host) = loaded();
    let before = device.active();
    let next = scene();
    let begin = Message::SceneBegin {
        total_len: next.len() as u32,
        crc32: crc32(&next),
    };
    device.handle(&mut host, begin);
    let (_, reply) = device.handle(&mut host, planar(0, 0, 1, true, &here));
    assert_eq!(nack_of(reply).code, ErrorCode::StagingBusy);
    assert_eq!(device.active(), before);
    // A hello (a new session) drops an update not yet applied, the upload's begin before
    // it too: the new session's update applies alone.
    let (mut device, mut host) = loaded();
    let moved = p1 + Vec2::new(1e-3, 0.0);
    device.handle(&mut host, planar(0, 0, 1, false, &[moved]));
    device.handle(&mut host, begin);
    device.handle(&mut host, Message::Hello(protocol::host_side::host_hello()));
    let (event, _) = device.handle(&mut host, planar(0, 1, 0, true, &[point(&arcs[1], 0)]));
    assert_eq!(event, Event::ScenePointsUpdated { object: 0 });
    assert_eq!(device.active().0, scene(), "the dropped point did not land");
}

/// A scene upload between the frames of a multi-frame update drops the update whole: its
/// remaining frames are refused with [`ErrorCode::UpdateInterrupted`] up to and including its
/// apply frame, and the scene the upload brought stays as uploaded. Before, the upload reset
/// the update, and its apply frame, arriving after the commit, applied its own points alone to
/// the new scene: half an update. Frames written out by hand (the wave's ten points: six in
/// the first frame, four in the apply frame), and the upload's scene as the reference.
#[test]
fn an_upload_between_the_frames_of_an_update_drops_it_whole() {
    let wave = wave();
    let lifted: Vec<Vec2> = (0..10)
        .map(|i| point(&wave, i) + Vec2::new(0.0, 1e-3))
        .collect();
    let first = planar(1, 0, 0, false, &lifted[..6]);
    let last = planar(1, 0, 6, true, &lifted[6..]);
    // The upload brings a scene whose left arc's free end moved 1 mm: another scene than
    // the one the update's first frame was staged on.
    let arcs = arcs();
    let uploaded = scene_of(
        &[
            arcs[0].clone(),
            arcs[1]
                .with_point(2, point(&arcs[1], 2) + Vec2::new(0.0, -1e-3))
                .unwrap(),
        ],
        &wave,
    );
    assert_ne!(uploaded, scene());

    // The upload whole between the two frames, and the upload's begin alone.
    for whole in [true, false] {
        let (mut device, mut host) = loaded();
        let (event, reply) = device.handle(&mut host, first);
        assert!(matches!(reply, Message::Ack { .. }), "{reply:?}");
        assert_eq!(event, Event::None);
        let expected = if whole {
            device.upload(&mut host, &uploaded);
            (uploaded.clone(), crc32(&uploaded))
        } else {
            let begin = Message::SceneBegin {
                total_len: uploaded.len() as u32,
                crc32: crc32(&uploaded),
            };
            let (_, reply) = device.handle(&mut host, begin);
            assert!(matches!(reply, Message::Ack { .. }), "{reply:?}");
            device.active()
        };
        let (event, reply) = device.handle(&mut host, last);
        let n = nack_of(reply);
        assert_eq!(
            (n.code, n.object, n.patch),
            (ErrorCode::UpdateInterrupted, 1, NO_INDEX),
            "whole upload: {whole}"
        );
        assert_eq!(event, Event::None);
        assert_eq!(device.active(), expected, "whole upload: {whole}");
        assert_eq!(
            device.session.status(DeviceState::default()).last_error,
            ErrorCode::UpdateInterrupted as u8
        );
        // The update ended with its apply frame: after the upload, the next one, whole, is
        // applied.
        if whole {
            let (event, reply) = send_update(&mut device, &mut host, &[first, last]);
            assert!(matches!(reply, Message::Ack { .. }), "{reply:?}");
            assert_eq!(event, Event::ScenePointsUpdated { object: 1 });
        }
    }
}

// ---------------------------------------------------------------------------------------
// The simulated device behind a link

fn unpaced() -> SimLink {
    SimLink::spawn(SimConfig {
        paced: false,
        start_hip: Vec2::new(0.03, 0.075),
        ..SimConfig::default()
    })
    .unwrap()
}

/// Reads until `n` telemetry frames arrived, feeding the watchdog; returns them and the acks
/// and nacks seen.
fn read(link: &mut SimLink, n: usize, gaps: &mut GapCounter) -> (Vec<Telemetry>, Vec<Message>) {
    let mut telemetry = Vec::new();
    let mut answers = Vec::new();
    while telemetry.len() < n {
        let frame = link.recv(TIMEOUT).unwrap().expect("a frame");
        gaps.telemetry(&frame);
        match frame.message {
            Message::Telemetry(t) => {
                if telemetry.len().is_multiple_of(20) {
                    link.send(&Message::Heartbeat { uptime_ms: 0 }).unwrap();
                }
                telemetry.push(t);
            }
            m @ (Message::Ack { .. } | Message::Nack(_)) => answers.push(m),
            _ => {}
        }
    }
    (telemetry, answers)
}

#[test]
fn the_simulated_device_renders_a_curve_moving_under_the_hand() {
    let mut link = unpaced();
    link.hello(TIMEOUT).unwrap();
    let arcs = arcs();
    let views = [
        WirePatch::Curve(arcs[0].view()),
        WirePatch::Curve(arcs[1].view()),
    ];
    let material = FrictionMaterial::default();
    let encode =
        |patches: &[WirePatch<'_>]| encode_scene(&[WireObject { material, patches }]).unwrap();
    let scene = encode(&views);
    link.upload_scene(&scene, TIMEOUT).unwrap();
    link.request(&Message::Calibrate, TIMEOUT).unwrap();
    link.request(&Message::EnableForces, TIMEOUT).unwrap();
    for m in [
        Message::Heartbeat { uptime_ms: 0 },
        Message::ClearFaults { mask: u16::MAX },
    ] {
        link.send(&m).unwrap();
    }
    let mut gaps = GapCounter::default();
    read(&mut link, 100, &mut gaps);
    // Into the right arc, 4 mm deep at 30°, over 400 ms, then held.
    let a = 30.0f32.to_radians();
    let inside = Vec2::new(-0.02, 0.06) + Vec2::new(a.cos(), a.sin()) * 0.036;
    let from = Vec2::new(0.03, 0.075);
    for k in 1..=20 {
        link.set_hand_target(from.lerp(inside, k as f32 / 20.0))
            .unwrap();
        read(&mut link, 20, &mut gaps);
    }
    let (settled, _) = read(&mut link, 500, &mut gaps);
    let held = *settled.last().unwrap();
    assert_eq!(held.mode, Mode::Stuck, "{held:?}");
    assert_eq!(held.feature, Some(Feature::Patch(0)));

    // 1 mm amplitude of the right arc's middle point, outward, at 2 Hz; one shape every
    // 10 ms (100 Hz) for a second, sent without waiting for the acks.
    let p1 = point(&arcs[0], 1);
    let out = (p1 - Vec2::new(-0.02, 0.06)).normalize();
    let mut sent = Vec::new();
    let mut telemetry = Vec::new();
    let mut answers = Vec::new();
    let mut last_to = p1;
    for k in 1..=100 {
        let t = k as f32 * 0.01;
        last_to = p1 + out * (1e-3 * (2.0 * std::f32::consts::PI * 2.0 * t).sin());
        sent.extend(link.send_points(0, &[(0, 1, &[last_to][..])]).unwrap());
        let (tm, ans) = read(&mut link, 10, &mut gaps);
        telemetry.extend(tm);
        answers.extend(ans);
    }
    // The last acks follow within a few frames; a loaded machine may delay the device's
    // thread, so read on (up to a second of frames) until they are all in.
    let count_acked = |answers: &[Message]| {
        answers
            .iter()
            .filter(|m| matches!(m, Message::Ack { seq } if sent.contains(seq)))
            .count()
    };
    for _ in 0..20 {
        let (tm, ans) = read(&mut link, 50, &mut gaps);
        telemetry.extend(tm);
        answers.extend(ans);
        if count_acked(&answers) >= sent.len() {
            break;
        }
    }
    let acked = count_acked(&answers);
    let nacked: Vec<&Message> = answers
        .iter()
        .filter(|m| matches!(m, Message::Nack(_)))
        .collect();
    assert!(nacked.is_empty(), "{nacked:?}");
    assert_eq!(acked, sent.len(), "every update acked");
    assert_eq!(gaps.dropped, 0);
    // In contact on the same arc all along, no fault, and the force followed the surface.
    // At 30° (u = 0.5) the middle point's share of the curve is R₁ = w₁/(1 + w₁) = 0.464
    // (w₁ = cos 30°), along the normal there: the surface moves ±0.464 mm. A rigid hand
    // would feel ±K × that, 0.93 N peak to peak; the hand's spring (2000 N/m) in series with
    // the wall (1000 N/m) takes a third of it when quasi-static, 0.62 N. Between the two,
    // with margins for the arm's own motion and the telemetry keeping each millisecond's
    // largest force.
    assert!(
        telemetry
            .iter()
            .all(|t| t.mode != Mode::Free && t.feature == Some(Feature::Patch(0)) && t.faults == 0)
    );
    let (lo, hi) = telemetry.iter().fold((f32::MAX, f32::MIN), |(lo, hi), t| {
        (lo.min(t.force_normal_n), hi.max(t.force_normal_n))
    });
    assert!(
        (0.45..=1.05).contains(&(hi - lo)),
        "normal force {lo} .. {hi} N"
    );
    // The device's scene is the host's, re-encoded from the last shape.
    link.send(&Message::Heartbeat { uptime_ms: 0 }).unwrap();
    let status = loop {
        if let Some(Frame {
            message: Message::Status(s),
            ..
        }) = link.recv(TIMEOUT).unwrap()
        {
            break s;
        }
    };
    let moved = arcs[0].with_point(1, last_to).unwrap();
    let host_scene = encode(&[
        WirePatch::Curve(moved.view()),
        WirePatch::Curve(arcs[1].view()),
    ]);
    assert_eq!(status.scene_crc32, crc32(&host_scene));
    assert_eq!(status.scene_len as usize, host_scene.len());
}
