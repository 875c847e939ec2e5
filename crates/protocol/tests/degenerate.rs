//! Degenerate geometry is refused on every way a scene enters the device (issue 29, item 8):
//! the wire decoder, the receiver's commit and a control-point update. The measured case is a
//! closed rational quadratic circle whose nine control points all collapse to (0, 0.09): the
//! device used to accept it and then held the hand 3 N towards that point from 17 mm away.
//! One validation ([`nurbs::Curve::new`], and with it every wire patch) refuses it, naming the
//! object, the patch and what is wrong; the active scene stays as it was.

#![allow(clippy::unwrap_used)]

use friction::FrictionMaterial;
use nurbs::construct::circle;
use nurbs::{CurveBuf, Vec2};
use protocol::device_side::session::{DeviceSession, DeviceState, Event};
use protocol::*;

/// The point the ring collapses to.
const CENTRE: Vec2 = Vec2::new(0.0, 0.09);

/// The exact rational circle of radius 2 cm about [`CENTRE`] (9 points, degree 2).
fn ring() -> CurveBuf<Vec2> {
    circle(CENTRE, 0.02).unwrap()
}

fn ring_scene() -> Vec<u8> {
    let ring = ring();
    encode_scene(&[WireObject {
        material: FrictionMaterial::default(),
        patches: &[WirePatch::Curve(ring.view())],
    }])
    .unwrap()
}

/// The wire bytes of `(x·w, y·w, w)`.
fn hom_bytes(p: Vec2, w: f32) -> Vec<u8> {
    [p.x * w, p.y * w, w]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect()
}

/// The ring's wire scene with every control point moved to `to(i)` (weights kept): bytes a
/// host can send although no `CurveBuf` holds that curve. Each point's 12 bytes are found in
/// the encoded scene by value.
fn ring_scene_moved(to: impl Fn(usize) -> Vec2) -> Vec<u8> {
    let ring = ring();
    let mut bytes = ring_scene();
    for (i, &h) in ring.points().iter().enumerate() {
        let original: Vec<u8> = h.to_array().iter().flat_map(|v| v.to_le_bytes()).collect();
        let at = bytes
            .windows(12)
            .position(|w| w == original.as_slice())
            .unwrap();
        bytes[at..at + 12].copy_from_slice(&hom_bytes(to(i), h.z));
    }
    bytes
}

/// The device side: a session and its scratch store.
struct Device {
    session: Box<DeviceSession<4096>>,
    scratch: Box<SceneStore>,
    seq: u16,
}

impl Device {
    fn new() -> Self {
        Device {
            session: Box::new(DeviceSession::new(false)),
            scratch: Box::new(SceneStore::new()),
            seq: 0,
        }
    }

    /// Handles `message`: the session's event and its reply (an ack or a nack).
    fn handle(&mut self, message: Message) -> (Event, Message) {
        let (report, n) = Frame {
            seq: self.seq,
            message,
        }
        .to_report();
        self.seq = self.seq.wrapping_add(1);
        let mut reply = None;
        let event = self.session.handle(
            &report[..n],
            self.scratch.as_mut(),
            DeviceState::default(),
            &mut |m: &Message| {
                if matches!(m, Message::Ack { .. } | Message::Nack(_)) {
                    reply = Some(*m);
                }
            },
        );
        (event, reply.unwrap())
    }

    /// Sends every frame of an upload: the last event and reply (the commit's).
    fn upload(&mut self, scene: &[u8]) -> (Event, Message) {
        let mut last = None;
        for m in scene_upload(scene) {
            last = Some(self.handle(m));
        }
        last.unwrap()
    }

    fn active(&self) -> (Vec<u8>, u32) {
        let r = self.session.receiver();
        (r.active_scene().to_vec(), r.active_crc32())
    }
}

fn nack_of(reply: Message) -> Nack {
    match reply {
        Message::Nack(n) => n,
        other => panic!("not a nack: {other:?}"),
    }
}

/// The collapsed ring, a span of it collapsed, and the ring collapsed to within f32 rounding
/// (each point one or two f32 steps off the centre: 7.5 nm at 0.09 m, far below the
/// 1 µm `nurbs::MIN_EXTENT`), each with the words its error must carry.
fn degenerate_rings() -> Vec<(&'static str, Vec<u8>, &'static str)> {
    let points: Vec<Vec2> = (0..9)
        .map(|i| ring().view().control_point(i).unwrap().0)
        .collect();
    let ulp = |x: f32, k: u32| f32::from_bits(x.to_bits() + k);
    vec![
        (
            "all nine points at (0, 0.09)",
            ring_scene_moved(|_| CENTRE),
            "no length",
        ),
        (
            "all nine points within two f32 steps of (0, 0.09)",
            ring_scene_moved(|i| Vec2::new(i as f32 * 1e-12, ulp(CENTRE.y, (i % 3) as u32))),
            "no length",
        ),
        (
            // Points 3 and 4 onto point 2: the span [0.25, 0.5] (points 2..=4) is a point.
            "the second quarter collapsed onto points[2]",
            ring_scene_moved(|i| {
                if i == 3 || i == 4 {
                    points[2]
                } else {
                    points[i]
                }
            }),
            "knots[4]",
        ),
    ]
}

#[test]
fn the_wire_decoder_refuses_a_collapsed_ring_by_object_and_patch() {
    let mut store = Box::new(SceneStore::new());
    for (what, bytes, words) in degenerate_rings() {
        let e = decode_scene(&bytes, &mut store).unwrap_err();
        assert_eq!(
            (e.code(), e.object, e.patch),
            (ErrorCode::ScenePatch, Some(0), Some(0)),
            "{what}: {e}"
        );
        let msg = e.to_string();
        assert!(msg.contains(words), "{what}: {msg}");
        assert!(matches!(e.fault, SceneFault::Patch(_)), "{what}: {e:?}");
        assert_eq!(store.object_count(), 0, "{what}: the store was left filled");
    }
    // The ring itself is accepted (the bytes were found and moved, nothing else changed):
    // its top at (0, 0.11) to f32 rounding (a few 2⁻²⁷ m steps).
    decode_scene(
        &ring_scene_moved(|i| ring().view().control_point(i).unwrap().0),
        &mut store,
    )
    .unwrap();
    let top = store.curve(0, 0).unwrap().point(0.25);
    assert!((top - Vec2::new(0.0, 0.11)).length() < 1e-7, "{top}");
}

#[test]
fn the_receiver_refuses_to_commit_a_collapsed_ring() {
    for (what, bytes, _) in degenerate_rings() {
        let mut device = Device::new();
        let (event, reply) = device.upload(&ring_scene());
        assert!(matches!(reply, Message::Ack { .. }), "{what}: {reply:?}");
        assert_eq!(event, Event::SceneCommitted, "{what}");
        let before = device.active();
        let reply = device.upload(&bytes);
        refused_unchanged(&device, reply, &before, what);
    }
}

/// The reply refuses patch 0 of object 0 (`ScenePatch`), nothing happened, and the device's
/// active scene and its CRC are still `before`.
fn refused_unchanged(
    device: &Device,
    (event, reply): (Event, Message),
    before: &(Vec<u8>, u32),
    what: &str,
) {
    let n = nack_of(reply);
    assert_eq!(
        (n.code, n.object, n.patch),
        (ErrorCode::ScenePatch, 0, 0),
        "{what}"
    );
    assert_eq!(event, Event::None, "{what}");
    assert_eq!(&device.active(), before, "{what}: the active scene changed");
}

#[test]
fn a_points_update_that_collapses_the_ring_is_refused_and_changes_nothing() {
    let points: Vec<Vec2> = (0..9)
        .map(|i| ring().view().control_point(i).unwrap().0)
        .collect();
    let collapsed = [CENTRE; 9];
    let quarter = [points[2], points[2]];
    let cases: [(&str, u16, &[Vec2]); 2] = [
        ("all nine points to (0, 0.09)", 0, &collapsed),
        ("points 3 and 4 onto points[2]", 3, &quarter),
    ];
    for (what, first, to) in cases {
        let mut device = Device::new();
        let (_, reply) = device.upload(&ring_scene());
        assert!(matches!(reply, Message::Ack { .. }), "{what}: {reply:?}");
        let before = device.active();
        let mut last = None;
        for m in points_update(0, &[(0, first, to)]) {
            last = Some(device.handle(m));
        }
        let reply = last.unwrap();
        refused_unchanged(&device, reply, &before, what);
        // The device goes on: moving the top point 1 mm along the top edge of the control
        // polygon (the ring stays smooth, its topology the same) is applied.
        let nudged = [points[2] + Vec2::new(1e-3, 0.0)];
        let (event, reply) = device.handle(Message::ScenePoints(
            ScenePoints::planar(0, 0, 2, true, &nudged).unwrap(),
        ));
        assert!(matches!(reply, Message::Ack { .. }), "{what}: {reply:?}");
        assert_eq!(event, Event::ScenePointsUpdated { object: 0 }, "{what}");
    }
}
