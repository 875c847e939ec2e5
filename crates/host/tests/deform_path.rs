//! One deformation path (issue 30 item 2): the app's own simulated device and a device behind
//! a link ([`device::link::SimLink`], the protocol a board speaks) take a deforming object's
//! shape the same way, as control-point updates that change the device's active scene, and a
//! deformable object that is not the scene's first one deforms on both.
//!
//! The reference for what the device holds is independent of the update path: the deformer's
//! current shape as a scene object ([`host::deform::Deformer::shape`]), encoded as an upload
//! ([`host::upload::wire_scene`]) and its CRC-32 taken, against the CRC the device reports for
//! its active scene. At rest that is the upload's CRC, bit for bit.

#![allow(clippy::unwrap_used)]

use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use device::protocol::{Status, crc32};
use host::backend::{LinkEvent, LoopCommand, Reply, Sample, Steppable};
use host::deform::ShapeFrame;
use host::devices::open_sim;
use host::planar::{HapticLoop, PlanarSession};
use host::upload::wire_scene;
use nurbs::Vec2;
use scene::{Bundled, Scene};

const PATIENCE: Duration = Duration::from_secs(20);
/// The string's rest line (m).
const Y: f32 = 0.115;

fn bundled(name: &str) -> Scene {
    Bundled::find(name)
        .and_then(|b| b.scene().ok())
        .unwrap_or_else(|| panic!("the bundled {name} scene"))
}

/// A rigid planar object first, the bundled deformable string second: the string is object 1.
fn string_second() -> Scene {
    let rigid = bundled("thesis-2d").objects()[0].clone();
    let string = bundled("deformable").objects()[0].clone();
    assert!(rigid.dynamics().is_none() && string.dynamics().is_some());
    Scene::new(vec![rigid, string]).unwrap()
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

/// The same object through the link: the host deforms scene object 1 (its published shape says
/// so), its updates name the object's place on the device and are all applied (none refused),
/// the device's scene moves off the upload while deforming, and is the upload's bit for bit
/// once rigid again.
#[test]
fn device_behind_a_link_follows_the_same_lifecycle() {
    let scene = string_second();
    let rest = crc32(&wire_scene(&scene, 1).unwrap());
    let session = PlanarSession::with_object(scene, Some(1)).unwrap();
    let link = host::remote::spawn(
        "sim".to_owned(),
        || open_sim(device::link::SimConfig::default()),
        true,
        None,
    )
    .unwrap();
    let below = Vec2::new(0.0, Y - 0.01);
    link.send(LoopCommand::HandTarget(below.extend(0.0)));
    link.send(LoopCommand::Swap(Box::new(session)));
    let mut status: Option<Status> = None;
    let mut samples: Vec<Sample> = Vec::new();
    let mut deforming = None;
    let mut frame = ShapeFrame::default();
    let mut poll = |status: &mut Option<Status>, deforming: &mut Option<bool>| {
        for r in link.drain_replies() {
            match r {
                Reply::Link(LinkEvent::Status(s)) => *status = Some(s),
                Reply::Link(LinkEvent::Refused { what, reason }) => {
                    panic!("refused {what}: {reason}")
                }
                Reply::Link(LinkEvent::Lost(reason)) => panic!("lost: {reason}"),
                Reply::Deform(result) => {
                    let s = result.unwrap();
                    s.shape.read_into(&mut frame);
                    *deforming = Some(s.deforming);
                }
                _ => {}
            }
        }
        link.drain_samples(|s| samples.push(s));
    };
    let wait = |what: &str,
                poll: &mut dyn FnMut(&mut Option<Status>, &mut Option<bool>),
                status: &mut Option<Status>,
                deforming: &mut Option<bool>,
                done: &dyn Fn(&Option<Status>, &Option<bool>) -> bool| {
        let start = Instant::now();
        while !done(status, deforming) {
            assert!(start.elapsed() < PATIENCE, "{what}: {status:?}");
            std::thread::sleep(Duration::from_millis(5));
            poll(status, deforming);
        }
    };
    wait(
        "the upload",
        &mut poll,
        &mut status,
        &mut deforming,
        &|s, _| s.is_some_and(|s| s.scene_crc32 == rest && s.forces_enabled),
    );
    link.send(LoopCommand::Deform(true));
    link.send(LoopCommand::HandTarget(
        Vec2::new(0.0, Y + 0.006).extend(0.0),
    ));
    wait(
        "a moved shape on the device",
        &mut poll,
        &mut status,
        &mut deforming,
        &|s, d| *d == Some(true) && s.is_some_and(|s| s.scene_crc32 != rest),
    );
    link.send(LoopCommand::Deform(false));
    wait(
        "the rest shape back",
        &mut poll,
        &mut status,
        &mut deforming,
        &|s, d| *d == Some(false) && s.is_some_and(|s| s.scene_crc32 == rest),
    );
    drop(poll);
    // The shape the host published when deforming started: scene object 1's.
    assert_eq!((frame.object, frame.points.len()), (1, 12));
    let c = link.counters();
    let (sent, applied, refused) = (
        c.points_sent.load(Ordering::Relaxed),
        c.points_applied.load(Ordering::Relaxed),
        c.points_refused.load(Ordering::Relaxed),
    );
    assert_eq!(refused, 0);
    assert!(
        sent > 0 && applied + 2 >= sent,
        "{applied} of {sent} applied"
    );
}
