//! A deformable object on a device behind a link (`LoopCommand::Deform` to the host of a remote
//! device): the host steps the string on the device's telemetry (locating the CP on its copy
//! of the shape) and streams the shape back as control-point updates; the simulated device
//! (`protocol::host_side::SimLink`, the protocol a board speaks) renders it. Real time.
//!
//! One deformation path (issue 30 item 2): the app's own simulated device (the planar loop)
//! takes the shape the same way, as control-point updates that change the device's active
//! scene, and an object that is not its scene's first deforms on both. The reference for what
//! the device holds is independent of the update path: the deformer's shape as a scene object
//! (`Deformer::shape`) uploaded (`wire_scene`) and its CRC-32 taken, against the CRC the
//! device reports for its active scene; at rest, the upload's, bit for bit.

#![allow(clippy::unwrap_used)]

use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use host::backend::{LinkEvent, LoopCommand, LoopThread, Reply, Sample, Steppable};
use host::deform::ShapeFrame;
use host::devices::open_sim;
use host::planar::{HapticLoop, PlanarSession};
use host::upload::wire_scene;
use nurbs::Vec2;
use protocol::{Status, crc32};
use scene::{Bundled, Scene};

const PATIENCE: Duration = Duration::from_secs(20);
/// The string's rest line, length, tension; the contact's stiffness.
const Y: f32 = 0.115;
const L: f64 = 0.08;
const T: f64 = 5.0;
const K_C: f64 = 1000.0;

fn bundled(name: &str) -> Scene {
    Bundled::find(name)
        .and_then(|b| b.scene().ok())
        .unwrap_or_else(|| panic!("the bundled {name} scene"))
}

fn deformable() -> Scene {
    bundled("deformable")
}

/// The host of the simulated device, set up (faults cleared, calibrated, forces on), the
/// hand's target at `hand`, sent `session`.
fn sim_host(session: PlanarSession, hand: Vec2) -> LoopThread {
    let link = host::remote::spawn(
        "sim".to_owned(),
        || open_sim(protocol::host_side::SimConfig::default()),
        true,
        None,
    )
    .unwrap();
    link.send(LoopCommand::hand_to(hand.extend(0.0)));
    link.send(LoopCommand::Swap(Box::new(session)));
    link
}

/// What the host has said so far; any refusal or a lost link fails the test.
#[derive(Default)]
struct Seen {
    status: Option<Status>,
    samples: Vec<Sample>,
    deforming: Option<bool>,
    /// The shape the host publishes, as last read when it answered a `Deform`.
    shape: ShapeFrame,
}

impl Seen {
    fn poll(&mut self, link: &LoopThread) {
        for r in link.drain_replies() {
            match r {
                Reply::Link(LinkEvent::Status(s)) => self.status = Some(s),
                Reply::Link(LinkEvent::Refused { what, reason }) => {
                    panic!("refused {what}: {reason}")
                }
                Reply::Link(LinkEvent::Lost(reason)) => panic!("lost: {reason}"),
                Reply::Deform(result) => {
                    let status = result.unwrap();
                    status.shape.read_into(&mut self.shape);
                    self.deforming = Some(status.deforming);
                }
                _ => {}
            }
        }
        link.drain_samples(|s| self.samples.push(s));
    }

    /// Polls `link` until `done`, for at most [`PATIENCE`].
    fn until(&mut self, link: &LoopThread, what: &str, done: impl Fn(&Seen) -> bool) {
        let start = Instant::now();
        while !done(self) {
            assert!(start.elapsed() < PATIENCE, "{what}: {:?}", self.status);
            std::thread::sleep(Duration::from_millis(5));
            self.poll(link);
        }
    }

    /// Makes the object rigid again and waits for the device's scene to be `rest` (its
    /// CRC-32); every update the host sent was applied, none refused (the last two may still
    /// be on their way). Returns how many were sent.
    fn rigid_again(&mut self, link: &LoopThread, rest: u32) -> u64 {
        link.send(LoopCommand::Deform(false));
        self.until(link, "not back at rest", |s| {
            s.deforming == Some(false) && s.status.is_some_and(|s| s.scene_crc32 == rest)
        });
        let c = link.counters();
        let (sent, applied, refused) = (
            c.points_sent.load(Ordering::Relaxed),
            c.points_applied.load(Ordering::Relaxed),
            c.points_refused.load(Ordering::Relaxed),
        );
        assert_eq!(refused, 0);
        assert!(applied + 2 >= sent, "{applied} of {sent} applied");
        sent
    }

    /// The device's scene's CRC-32 is `crc` (and its forces are on).
    fn scene_is(&self, crc: u32) -> bool {
        self.status
            .is_some_and(|s| s.scene_crc32 == crc && s.forces_enabled)
    }
}

/// Pushed through the link, the string holds the handle at the series stiffness of contact
/// and string ([207.9, 210.5] N/m, `tests/deform.rs`; the encoder quantum, 19.6 µm over the
/// ~5.4 mm depth, widens it by 0.4 %), while the host sends the device a shape every second
/// telemetry frame (500 a second, `host::remote::DEFORM_UPDATE_EVERY`; at least 400 on a
/// loaded machine) and every one it sends is applied; let rigid again, the device's scene is
/// the rest shape's bit for bit (its CRC the uploaded scene's).
#[test]
fn a_string_pushed_through_the_link_deforms_on_the_device() {
    let scene = deformable();
    let session = PlanarSession::with_object(scene.clone(), Some(0)).unwrap();
    let below = Vec2::new(0.0, Y - 0.01);
    let link = sim_host(session, below);
    let crc0 = crc32(&wire_scene(&scene, 0).unwrap());
    let mut seen = Seen::default();
    seen.until(&link, "no scene", |s| s.scene_is(crc0));
    link.send(LoopCommand::Deform(true));
    // The grip's target 6 mm past the rest line over half a second, then held for 1.5 s.
    let inside = Vec2::new(0.0, Y + 0.006);
    for i in 0..=50 {
        let t = i as f32 / 50.0;
        link.send(LoopCommand::hand_to(
            (below + (inside - below) * t).extend(0.0),
        ));
        std::thread::sleep(Duration::from_millis(10));
        seen.poll(&link);
    }
    // Held for 1.5 s of the device's time: the string settles on the device's clock, which
    // falls behind the wall's on a loaded machine (the simulated device waits for room to
    // send its replies).
    let device_now = |samples: &[Sample]| samples.last().map_or(0.0, |s| s.tick.t_s);
    let sent_before = link.counters().points_sent.load(Ordering::Relaxed);
    let held_from = device_now(&seen.samples);
    let hold = Instant::now();
    while device_now(&seen.samples) < held_from + 1.5 {
        assert!(hold.elapsed() < PATIENCE, "the device's clock stalled");
        std::thread::sleep(Duration::from_millis(10));
        seen.poll(&link);
    }
    let (samples, deforming) = (&seen.samples, seen.deforming);
    let sent = link.counters().points_sent.load(Ordering::Relaxed) - sent_before;
    let rate = sent as f64 / (device_now(samples) - held_from);
    assert_eq!(deforming, Some(true));
    assert!(rate >= 400.0, "{rate} shapes a second");
    let last = samples.last().expect("telemetry");
    let series = |k_o: f64| K_C * k_o / (K_C + k_o);
    let (k_o, h) = (4.0 * T / L, L / 9.0);
    let quantum = 19.6e-6 / f64::from(last.tick.hip.y - Y);
    let (lo, hi) = (
        series(k_o * (1.0 + 0.45 * h / L)) * (1.0 - quantum),
        series(k_o * (1.0 + 0.6 * h / L)) * (1.0 + quantum),
    );
    // Every frame of the hold's last 100 ms, not one that happens to be last.
    for s in samples.iter().filter(|s| s.tick.t_s >= last.tick.t_s - 0.1) {
        let depth = f64::from(s.tick.hip.y - Y);
        let k = f64::from(s.tick.normal_force_n) / depth;
        assert!(
            (lo..=hi).contains(&k),
            "F/d = {k} N/m at d = {depth} m (t = {} s), in [{lo}, {hi}]",
            s.tick.t_s
        );
    }
    assert!(
        last.tick.deform.is_some_and(|d| d.y > 0.001),
        "{:?}",
        last.tick.deform
    );
    // Rigid again: the device gets the rest shape back.
    seen.rigid_again(&link, crc0);
}

/// A rigid planar object first, the bundled deformable string second: the string is object 1.
fn string_second() -> Scene {
    let rigid = bundled("thesis-2d").objects()[0].clone();
    let string = deformable().objects()[0].clone();
    assert!(rigid.dynamics().is_none() && string.dynamics().is_some());
    Scene::new(vec![rigid, string]).unwrap()
}

/// The string as scene object 1 through the link (the in-process device's twin is
/// `tests/deform_path.rs`): the host deforms scene object 1 (its published shape says so), its
/// updates name the object's place on the device and are all applied (none refused), the
/// device's scene moves off the upload while deforming and is the upload's bit for bit once
/// rigid again.
#[test]
fn an_object_not_first_in_its_scene_deforms_through_the_link() {
    let scene = string_second();
    let rest = crc32(&wire_scene(&scene, 1).unwrap());
    let session = PlanarSession::with_object(scene, Some(1)).unwrap();
    let link = sim_host(session, Vec2::new(0.0, Y - 0.01));
    let mut seen = Seen::default();
    seen.until(&link, "the upload", |s| s.scene_is(rest));
    link.send(LoopCommand::Deform(true));
    link.send(LoopCommand::hand_to(Vec2::new(0.0, Y + 0.006).extend(0.0)));
    seen.until(&link, "a moved shape on the device", |s| {
        s.deforming == Some(true) && s.status.is_some_and(|s| s.scene_crc32 != rest)
    });
    let sent = seen.rigid_again(&link, rest);
    assert!(sent > 0);
    // The shape the host published while deforming: scene object 1's.
    assert_eq!((seen.shape.object, seen.shape.points.len()), (1, 12));
}

/// The CRC-32 of `object` uploaded alone: what a device holding it reports.
fn crc_of(object: scene::Object) -> u32 {
    crc32(&wire_scene(&Scene::new(vec![object]).unwrap(), 0).unwrap())
}

/// The planar loop (the app's simulated device) on the string as object 1: deforming, the
/// device's active scene is the deformer's current shape after every step (the update went
/// through the device's receiver, not around it), the published shape names object 1; rigid
/// again, the device's scene is the upload's bit for bit.
#[test]
fn in_process_device_takes_the_shape_as_a_points_update_of_any_object() {
    let scene = string_second();
    let rest = crc32(&wire_scene(&scene, 1).unwrap());
    let session = PlanarSession::with_object(scene.clone(), Some(1)).unwrap();
    assert_eq!(session.scene_crc32(), Some(rest));
    let mut l = HapticLoop::new(session, Vec2::new(0.0, 0.10)).unwrap();
    let on = match l.apply(LoopCommand::Deform(true)) {
        Some(Reply::Deform(r)) => r.unwrap(),
        other => panic!("{other:?}"),
    };
    let mut frame = ShapeFrame::default();
    assert!(on.deforming && on.shape.read_into(&mut frame));
    assert_eq!((frame.object, frame.points.len()), (1, 12));
    // Started from rest: nothing was sent, the device holds the upload.
    assert_eq!(l.session().scene_crc32(), Some(rest));

    l.set_hand_target(Vec2::new(0.0, 0.125));
    let mut moved = 0;
    for _ in 0..600 {
        let t = l.step();
        let shape = l.deformer().unwrap().shape().unwrap();
        assert_eq!(
            l.session().scene_crc32(),
            Some(crc_of(shape)),
            "at {} s",
            t.t_s
        );
        moved += usize::from(l.session().scene_crc32() != Some(rest));
    }
    assert!(l.last_error().is_none(), "{:?}", l.last_error());
    let pushed = l.deformer().unwrap().body().displacement()[6][1];
    assert!(pushed > 1e-3 && moved > 300, "{pushed} m, {moved} shapes");

    match l.apply(LoopCommand::Deform(false)) {
        Some(Reply::Deform(r)) => assert!(!r.unwrap().deforming),
        other => panic!("{other:?}"),
    }
    assert_eq!(l.session().scene_crc32(), Some(rest));
    // The controller renders the rest shape again: pressed, the contact is on the rest line.
    let t = (0..200).map(|_| l.step()).last().unwrap();
    assert_eq!(t.patch, Some(0));
    assert!(t.deform.is_none());
    assert!((t.cp.y - Y).abs() < 1e-6, "CP {}", t.cp);
}
