//! The app driving a device behind a link (`viewer gui --device …`), through the app's state:
//! the host's simulated device ([`protocol::host_side::SimLink`], the same protocol as a board)
//! behind a link the test can pull out.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use device::safety::Faults;
use host::devices::Opened;
use nurbs::Vec2;
use protocol::host_side::{Link, LinkError, SimConfig, SimLink};
use protocol::{Frame, Message, Telemetry, crc32};
use scene::Scene;
use viewer::gui::state::{AppState, DeviceChoice};

/// How long a test waits for something that takes milliseconds (a loaded machine is slow;
/// nothing here is timed).
const PATIENCE: Duration = Duration::from_secs(20);

/// A link that can be pulled out: once `cut`, what the host sends is lost and nothing
/// reaches it, as with an unplugged cable; the device's frames still come out of it into
/// `after_cut`, so the test sees what the device did.
#[derive(Debug)]
struct Pullable {
    inner: Box<dyn Link>,
    cut: Arc<AtomicBool>,
    after_cut: Arc<Mutex<Vec<Telemetry>>>,
}

impl Link for Pullable {
    fn send(&mut self, message: &Message) -> Result<u16, LinkError> {
        if self.cut.load(Ordering::SeqCst) {
            return Ok(0);
        }
        self.inner.send(message)
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<Frame>, LinkError> {
        if self.cut.load(Ordering::SeqCst) {
            if let Some(Frame {
                message: Message::Telemetry(t),
                ..
            }) = self.inner.recv(timeout)?
                && let Ok(mut v) = self.after_cut.lock()
            {
                v.push(t);
            }
            return Ok(None);
        }
        self.inner.recv(timeout)
    }
}

fn thesis_2d() -> Scene {
    Scene::from_json_str(include_str!("../../../scenes/thesis-2d.json"))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// Polls the app until `done`, or panics after [`PATIENCE`] naming `what`.
fn wait_for(state: &mut AppState, what: &str, mut done: impl FnMut(&AppState) -> bool) {
    let start = Instant::now();
    while !done(state) {
        assert!(
            start.elapsed() < PATIENCE,
            "waited {PATIENCE:?} for {what}; link {:?}",
            state.link
        );
        std::thread::sleep(Duration::from_millis(5));
        state.poll();
    }
}

/// An app on thesis-2d whose loop is on the host's simulated device behind a pullable link.
fn linked() -> (AppState, Arc<AtomicBool>, Arc<Mutex<Vec<Telemetry>>>) {
    let mut state = AppState::new("thesis-2d", thesis_2d(), true, None).expect("app");
    let cut = Arc::new(AtomicBool::new(false));
    let after_cut = Arc::new(Mutex::new(Vec::new()));
    let (c, a) = (cut.clone(), after_cut.clone());
    state.connect_with(
        "pullable".into(),
        move || {
            let sim = SimLink::spawn(SimConfig::default())?;
            let hand = sim.hand()?;
            let mut link = Pullable {
                inner: Box::new(sim),
                cut: c,
                after_cut: a,
            };
            let hello = link.hello(Duration::from_secs(2))?;
            Ok(Opened {
                link: Box::new(link),
                hello,
                hand: Some(hand),
            })
        },
        true,
    );
    (state, cut, after_cut)
}

/// Connecting uploads the running scene through the protocol (the device's status reports
/// the CRC of exactly the app's wire scene), the setup calibrates and enables the forces,
/// the mouse moves the simulated device's hand and the device renders the curve: pressed
/// 2 mm into the top of thesis-2d's right arc, the normal force is about K·depth.
#[test]
fn a_linked_device_gets_the_scene_and_renders_it() {
    let (mut state, _cut, _) = linked();
    assert_eq!(state.device, DeviceChoice::Linked("pullable".into()));
    let wire = host::upload::wire_scene(&thesis_2d(), 0).expect("wire");
    wait_for(&mut state, "the uploaded scene and the forces", |s| {
        s.link
            .status
            .is_some_and(|st| st.scene_crc32 == crc32(&wire) && st.forces_enabled)
    });
    assert!(state.forces_on());
    let status = state.link.status.expect("status");
    assert!(status.calibrated);
    assert_eq!(status.scene_len as usize, wire.len());
    press_and_check_k_depth(&mut state);
}

/// The hand goes down onto the top of the curve at x = 0 (thesis-2d's arcs meet the y-axis
/// at y = 0.1 m, see scenes/generate.py) and presses 4 mm below it; the device renders
/// F_N = K·depth once the handle has settled.
fn press_and_check_k_depth(state: &mut AppState) {
    let top = thesis_2d()
        .object(0)
        .and_then(|o| o.curve_views())
        .map(|c| {
            c.iter()
                .flat_map(|c| {
                    let (a, b) = c.domain();
                    (0..=400).map(move |i| c.point(a + (b - a) * i as f32 / 400.0))
                })
                .filter(|p| p.x.abs() < 2e-3)
                .map(|p| p.y)
                .fold(f32::NEG_INFINITY, f32::max)
        })
        .expect("curves");
    assert!(state.set_hand_target(Vec2::new(0.0, top - 0.004)));
    wait_for(state, "contact", |s| {
        s.latest().is_some_and(|l| l.tick.normal_force_n > 0.5)
    });
    // Let the handle settle (the hand's spring is 2000 N/m, the surface's K 1000 N/m: the
    // handle rests where they balance), then compare F_N with K·depth of the rendered
    // penetration: both come from the device, so they agree to the telemetry's rounding.
    std::thread::sleep(Duration::from_millis(500));
    state.poll();
    let k = state.running_material.expect("material").stiffness_n_per_m;
    let last = state.latest().expect("telemetry").tick;
    let expected = k * last.depth_m;
    assert!(
        (last.normal_force_n - expected).abs() < 0.02 * expected + 1e-3,
        "F_N {} vs K·depth {expected}",
        last.normal_force_n
    );
    // The handle rests between the hand and the surface: F_N = hand spring × stretch, so the
    // depth is 4 mm × 2000 / (2000 + K) within the friction's share.
    assert!(
        last.depth_m > 1e-3 && last.depth_m < 4e-3,
        "{}",
        last.depth_m
    );
}

/// The serial path without a board: the host's simulated device served on one end of a
/// pseudo-terminal ([`SimLink::serve`]: COBS packets over a real tty), and the app connected
/// to the other end by its path, as to a board's port (`--device serial:PATH`, the same
/// `SerialLink::open`). As for a board, the app uploads the scene at once and then waits for
/// the user: calibration and forces come from the app's own buttons, after which the device
/// renders the curve.
#[cfg(unix)]
#[test]
fn the_serial_path_over_a_pseudo_terminal() {
    // A machine without pseudo-terminals (no /dev/ptmx in a bare container) cannot run
    // this; it says so rather than failing on the machine.
    let pty = match protocol::host_side::pseudo_terminal() {
        Ok(pty) => pty,
        Err(e) => {
            eprintln!("skipped: no pseudo-terminal here: {e}");
            return;
        }
    };
    let path = pty.path.clone();
    let stop = Arc::new(AtomicBool::new(false));
    let server = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            let sim = SimLink::spawn(SimConfig::default())?;
            sim.serve(pty.device, &stop)
        })
    };
    let mut state = AppState::new("thesis-2d", thesis_2d(), true, None).expect("app");
    state.connect(host::devices::Target::Serial(path.clone()));
    let wire = host::upload::wire_scene(&thesis_2d(), 0).expect("wire");
    wait_for(&mut state, "the uploaded scene", |s| {
        s.link
            .status
            .is_some_and(|st| st.scene_crc32 == crc32(&wire))
    });
    let status = state.link.status.expect("status");
    assert!(!status.calibrated && !status.forces_enabled, "{status:?}");
    assert!(state.link.lost.is_none(), "{:?}", state.link.lost);
    // A device boots with a fault latched (forces stay off until the user clears it).
    state.clear_faults();
    state.calibrate();
    wait_for(&mut state, "calibrated", |s| {
        s.link.status.is_some_and(|st| st.calibrated)
    });
    state.set_forces(true);
    wait_for(&mut state, "the forces on", |s| {
        s.link.status.is_some_and(|st| st.forces_enabled)
    });
    press_and_check_k_depth(&mut state);
    assert!(state.link.lost.is_none(), "{:?}", state.link.lost);
    state.shutdown();
    stop.store(true, Ordering::SeqCst);
    let served = server.join().expect("the server thread");
    assert!(served.is_ok(), "{served:?}");
}

/// Pulling the link out: the app says the link is lost and shows the forces off within the
/// silence timeout, and the device's own watchdog turns its forces off: its telemetry after
/// the cut shows the watchdog fault, and zero force from that frame on.
///
/// When, in device time after the first frame that came out after the cut (`f0`): the
/// watchdog trips 100 ms (its timeout) after the last heartbeat the device got. That
/// heartbeat left at most one heartbeat period (50 ms) before the cut, and `f0` left the
/// device no later than the cut and at most the device's frame queue (64 frames, 64 ms at
/// 1 kHz) before it; the simulated device is paced, never faster than real time. So the trip
/// comes between 100 − 50 = 50 ms and 100 + 64 ms after `f0`, give or take a tick.
#[test]
fn pulling_the_link_turns_the_forces_off_and_says_so() {
    let (mut state, cut, after_cut) = linked();
    wait_for(&mut state, "the forces on", AppState::forces_on);
    wait_for(&mut state, "telemetry", |s| s.latest().is_some());
    cut.store(true, Ordering::SeqCst);
    wait_for(&mut state, "the link lost", |s| s.link.lost.is_some());
    assert!(!state.forces_on());
    assert!(!state.forces_requested);
    let reason = state.link.lost.clone().expect("reason");
    assert!(
        reason.contains("pullable") && reason.contains("no frame"),
        "{reason}"
    );

    let frames = after_cut.lock().expect("frames").clone();
    let trip = frames
        .iter()
        .position(|t| Faults::from_bits_truncate(t.faults).contains(Faults::WATCHDOG))
        .unwrap_or_else(|| panic!("no watchdog trip in {} frames after the cut", frames.len()));
    assert!(
        frames[trip..].iter().all(|t| t.force_n == Vec2::ZERO),
        "force after the trip"
    );
    let span_us = f64::from(frames[trip].time_us.wrapping_sub(frames[0].time_us));
    assert!(
        (50_000.0 - 1_000.0..=164_000.0 + 1_000.0).contains(&span_us),
        "the watchdog tripped {span_us} µs after the first frame after the cut"
    );
}

/// `viewer device sim-pty`: the path it prints opens as a serial port and the device behind
/// it answers the hello exactly as the in-process simulator does; with `--seconds` it exits
/// 0 on its own.
#[cfg(unix)]
#[test]
fn the_sim_pty_command_serves_a_device_a_serial_link_reaches() {
    use protocol::host_side::SerialLink;
    use std::io::BufRead;
    if let Err(e) = protocol::host_side::pseudo_terminal() {
        eprintln!("skipped: no pseudo-terminal here: {e}");
        return;
    }
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_viewer"))
        .args(["device", "sim-pty", "--seconds", "3"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("viewer runs");
    let mut line = String::new();
    std::io::BufReader::new(child.stdout.take().expect("stdout"))
        .read_line(&mut line)
        .expect("the path");
    let path = line.trim();
    assert!(path.starts_with("/dev/"), "{line:?}");
    let mut link = SerialLink::open(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let hello = link.hello(Duration::from_secs(2)).expect("hello");
    let direct = SimLink::spawn(SimConfig::default())
        .and_then(|mut sim| sim.hello(Duration::from_secs(2)))
        .expect("the in-process simulator's hello");
    assert_eq!(hello, direct);
    // Nobody reads the pseudo-terminal from here on: the device's frames pile up in it, and
    // the command still stops on time.
    drop(link);
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait") {
            break status;
        }
        if start.elapsed() > PATIENCE {
            let _ = child.kill();
            panic!("sim-pty --seconds 3 still ran after {PATIENCE:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(status.success(), "{status}");
}
