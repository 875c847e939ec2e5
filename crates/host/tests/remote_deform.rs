//! A deformable object on a device behind a link (`LoopCommand::Deform` to the host of a remote
//! device): the host steps the string on the device's telemetry (locating the CP on its copy
//! of the shape) and streams the shape back as control-point updates; the simulated device
//! (`protocol::host_side::SimLink`, the protocol a board speaks) renders it. Real time.

#![allow(clippy::unwrap_used)]

use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use host::backend::{LinkEvent, LoopCommand, Reply, Sample};
use host::devices::open_sim;
use host::planar::PlanarSession;
use nurbs::Vec2;
use protocol::{Status, crc32};
use scene::{Bundled, Scene};

const PATIENCE: Duration = Duration::from_secs(20);
/// The string's rest line, length, tension; the contact's stiffness.
const Y: f32 = 0.115;
const L: f64 = 0.08;
const T: f64 = 5.0;
const K_C: f64 = 1000.0;

fn deformable() -> Scene {
    Bundled::find("deformable")
        .and_then(|b| b.scene().ok())
        .expect("the bundled deformable scene")
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
    let link = host::remote::spawn(
        "sim".to_owned(),
        || open_sim(protocol::host_side::SimConfig::default()),
        true,
        None,
    )
    .unwrap();
    let below = Vec2::new(0.0, Y - 0.01);
    link.send(LoopCommand::HandTarget(below.extend(0.0)));
    link.send(LoopCommand::Swap(Box::new(session)));
    let crc0 = crc32(&host::upload::wire_scene(&scene, 0).unwrap());
    let mut status: Option<Status> = None;
    let mut samples: Vec<Sample> = Vec::new();
    let mut deforming = None;
    let poll =
        |status: &mut Option<Status>, samples: &mut Vec<Sample>, deforming: &mut Option<bool>| {
            for r in link.drain_replies() {
                match r {
                    Reply::Link(LinkEvent::Status(s)) => *status = Some(s),
                    Reply::Link(LinkEvent::Refused { what, reason }) => {
                        panic!("refused {what}: {reason}")
                    }
                    Reply::Link(LinkEvent::Lost(reason)) => panic!("lost: {reason}"),
                    Reply::Deform(result) => *deforming = Some(result.unwrap().deforming),
                    _ => {}
                }
            }
            link.drain_samples(|s| samples.push(s));
        };
    let start = Instant::now();
    while !status.is_some_and(|s| s.scene_crc32 == crc0 && s.forces_enabled) {
        assert!(start.elapsed() < PATIENCE, "no scene: {status:?}");
        std::thread::sleep(Duration::from_millis(5));
        poll(&mut status, &mut samples, &mut deforming);
    }
    link.send(LoopCommand::Deform(true));
    // The grip's target 6 mm past the rest line over half a second, then held for 1.5 s.
    let inside = Vec2::new(0.0, Y + 0.006);
    for i in 0..=50 {
        let t = i as f32 / 50.0;
        link.send(LoopCommand::HandTarget(
            (below + (inside - below) * t).extend(0.0),
        ));
        std::thread::sleep(Duration::from_millis(10));
        poll(&mut status, &mut samples, &mut deforming);
    }
    // Held for 1.5 s of the device's time: the string settles on the device's clock, which
    // falls behind the wall's on a loaded machine (the simulated device waits for room to
    // send its replies).
    let device_now = |samples: &[Sample]| samples.last().map_or(0.0, |s| s.tick.t_s);
    let sent_before = link.counters().points_sent.load(Ordering::Relaxed);
    let held_from = device_now(&samples);
    let hold = Instant::now();
    while device_now(&samples) < held_from + 1.5 {
        assert!(hold.elapsed() < PATIENCE, "the device's clock stalled");
        std::thread::sleep(Duration::from_millis(10));
        poll(&mut status, &mut samples, &mut deforming);
    }
    let sent = link.counters().points_sent.load(Ordering::Relaxed) - sent_before;
    let rate = sent as f64 / (device_now(&samples) - held_from);
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
    link.send(LoopCommand::Deform(false));
    let back = Instant::now();
    while !(deforming == Some(false) && status.is_some_and(|s| s.scene_crc32 == crc0)) {
        assert!(back.elapsed() < PATIENCE, "not back at rest: {status:?}");
        std::thread::sleep(Duration::from_millis(10));
        poll(&mut status, &mut samples, &mut deforming);
    }
    let c = link.counters();
    let (sent, applied, refused) = (
        c.points_sent.load(Ordering::Relaxed),
        c.points_applied.load(Ordering::Relaxed),
        c.points_refused.load(Ordering::Relaxed),
    );
    assert_eq!(refused, 0);
    assert!(applied + 2 >= sent, "{applied} of {sent} applied");
}
