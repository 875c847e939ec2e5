//! The host of a device behind a link streaming a moving shape ([`LoopCommand::ScenePoints`]) to
//! the simulated device ([`protocol::host_side::SimLink`], the protocol a board speaks), real time,
//! 100 shapes a second: every update sent is applied, the hand stays in contact on the same
//! arc, and the device's scene ends as the host's own scene edited the same way and uploaded
//! (`scene::edit::move_point`, `host::upload::wire_scene`: an independent path to the bytes).

#![allow(clippy::unwrap_used)]

use std::time::{Duration, Instant};

use device::safety::Faults;
use friction::Mode;
use host::backend::{LinkEvent, LoopCommand, PointsUpdate, Reply, Sample};
use host::devices::open_sim;
use host::planar::PlanarSession;
use nurbs::Vec2;
use protocol::{Status, crc32};
use scene::Scene;
use scene::edit::{PointRef, move_point};
use tracker::Feature;

const PATIENCE: Duration = Duration::from_secs(20);

fn thesis_2d() -> Scene {
    Scene::from_json_str(include_str!("../../../scenes/thesis-2d.json"))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// The right arc's middle control point.
fn p1(scene: &Scene) -> Vec2 {
    match &scene.objects()[0].patches()[0] {
        scene::Patch::Curve2(c) => c.view().control_point(1).unwrap().0,
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_moving_shape_streams_to_the_device_and_lands_as_the_host_edits_it() {
    let scene = thesis_2d();
    let session = PlanarSession::new(scene.clone()).unwrap();
    let link = host::remote::spawn(
        "sim".to_owned(),
        || open_sim(protocol::host_side::SimConfig::default()),
        true,
        None,
    )
    .unwrap();
    let above = Vec2::new(0.01, 0.11);
    link.send(LoopCommand::hand_to(above.extend(0.0)));
    link.send(LoopCommand::Swap(Box::new(session)));
    let crc0 = crc32(&host::upload::wire_scene(&scene, 0).unwrap());
    let mut status: Option<Status> = None;
    let mut samples: Vec<Sample> = Vec::new();
    let poll = |status: &mut Option<Status>, samples: &mut Vec<Sample>| {
        for r in link.drain_replies() {
            match r {
                Reply::Link(LinkEvent::Status(s)) => *status = Some(s),
                Reply::Link(LinkEvent::Refused { what, reason }) => {
                    panic!("refused {what}: {reason}")
                }
                Reply::Link(LinkEvent::Lost(reason)) => panic!("lost: {reason}"),
                _ => {}
            }
        }
        link.drain_samples(|s| samples.push(s));
    };
    let start = Instant::now();
    while !status.is_some_and(|s| s.scene_crc32 == crc0 && s.forces_enabled) {
        assert!(start.elapsed() < PATIENCE, "no scene: {status:?}");
        std::thread::sleep(Duration::from_millis(5));
        poll(&mut status, &mut samples);
    }
    // 4 mm into the right arc at 30° over half a second, then held until stuck.
    let a = 30.0f32.to_radians();
    let inside = Vec2::new(-0.02, 0.06) + Vec2::new(a.cos(), a.sin()) * 0.036;
    for i in 0..=50 {
        let t = i as f32 / 50.0;
        link.send(LoopCommand::hand_to(
            (above + (inside - above) * t).extend(0.0),
        ));
        std::thread::sleep(Duration::from_millis(10));
        poll(&mut status, &mut samples);
    }
    let start = Instant::now();
    while !samples
        .last()
        .is_some_and(|s| s.tick.mode == Mode::Stuck && s.tick.normal_force_n > 1.0)
    {
        assert!(start.elapsed() < PATIENCE, "no contact");
        std::thread::sleep(Duration::from_millis(10));
        poll(&mut status, &mut samples);
    }
    std::thread::sleep(Duration::from_millis(200));
    poll(&mut status, &mut samples);
    samples.clear();

    // The right arc's middle point 1 mm out and back at 2 Hz, a shape every 10 ms for 1 s.
    let p1 = p1(&scene);
    let out = (p1 - Vec2::new(-0.02, 0.06)).normalize();
    let mut last = p1;
    let began = Instant::now();
    for k in 1..=100u32 {
        let due = began + Duration::from_millis(10 * u64::from(k));
        std::thread::sleep(due.saturating_duration_since(Instant::now()));
        let t = k as f32 * 0.01;
        last = p1 + out * (1e-3 * (2.0 * std::f32::consts::PI * 2.0 * t).sin());
        link.send(LoopCommand::ScenePoints(Box::new(PointsUpdate {
            object: 0,
            patches: vec![(0, 1, vec![last])],
        })));
        poll(&mut status, &mut samples);
    }
    let c = link.counters();
    let load = |a: &std::sync::atomic::AtomicU64| a.load(std::sync::atomic::Ordering::Relaxed);
    let start = Instant::now();
    while load(&c.points_sent) + load(&c.points_superseded) < 100
        || load(&c.points_applied) + load(&c.points_refused) < load(&c.points_sent)
    {
        assert!(start.elapsed() < PATIENCE, "updates unanswered");
        std::thread::sleep(Duration::from_millis(5));
        poll(&mut status, &mut samples);
    }
    let (sent, applied, superseded) = (
        load(&c.points_sent),
        load(&c.points_applied),
        load(&c.points_superseded),
    );
    assert_eq!(load(&c.points_refused), 0);
    assert_eq!(applied, sent);
    // The host thread turns every millisecond: nothing waits long enough to be replaced.
    assert_eq!(sent + superseded, 100);
    assert!(sent >= 95, "{sent} sent, {superseded} superseded");
    // Contact all along, on the right arc, without a fault.
    assert!(samples.iter().all(|s| {
        s.tick.mode != Mode::Free
            && s.tick.feature == Feature::Patch(0)
            && s.tick.device.is_some_and(|d| d.faults == 0)
    }));
    // The device's scene is the host's scene with the point moved, uploaded.
    let edited = move_point(&scene, PointRef::new(0, 0, 1), last).unwrap();
    let crc = crc32(&host::upload::wire_scene(&edited, 0).unwrap());
    status = None;
    let start = Instant::now();
    while status.is_none_or(|s| s.scene_crc32 != crc) {
        assert!(
            start.elapsed() < Duration::from_secs(2),
            "device CRC {status:?}, the host's {crc:#x}"
        );
        std::thread::sleep(Duration::from_millis(5));
        poll(&mut status, &mut samples);
    }
    assert_eq!(
        status.map(|s| Faults::from_bits_truncate(s.faults)),
        Some(Faults::empty())
    );
}
