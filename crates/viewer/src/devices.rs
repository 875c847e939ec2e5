//! `viewer device …`: find boards that speak the protocol, and monitor a device's telemetry.

use std::io::Write;
use std::time::{Duration, Instant};

use device::host::{
    GapCounter, HidLink, Link, LinkError, SerialLink, SimConfig, SimHand, SimLink, TcpLink,
    list_hid, list_serial,
};
use device::protocol::{Frame, Hello, Message, Telemetry};
use device::safety::Faults;
use friction::Mode;
use nurbs::Vec2;

/// How long a candidate has to answer a hello in `device list`.
pub const PROBE_TIMEOUT: Duration = Duration::from_millis(200);
/// The monitor's heartbeat period: half the device's default watchdog timeout.
pub const HEARTBEAT_PERIOD: Duration = Duration::from_millis(50);

/// A device that answered a hello.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Found {
    /// `hid` or `serial`.
    pub kind: &'static str,
    /// The OS path to open it with.
    pub path: String,
    /// Its hello.
    pub hello: Hello,
    /// Its product string, if it reports one.
    pub product: Option<String>,
}

/// Enumerates HID boards and USB serial ports and keeps those that answer a hello within
/// [`PROBE_TIMEOUT`]. Backends that are unavailable are reported in the second list (as
/// messages) rather than failing the whole search.
pub fn find_devices() -> (Vec<Found>, Vec<String>) {
    let mut found = Vec::new();
    let mut problems = Vec::new();
    match list_hid() {
        Ok(devices) => {
            for d in devices {
                match HidLink::open(&d.path).and_then(|mut l| l.hello(PROBE_TIMEOUT)) {
                    Ok(hello) => found.push(Found {
                        kind: "hid",
                        path: d.path,
                        hello,
                        product: d.product,
                    }),
                    Err(e) => problems.push(format!("{}: {e}", d.path)),
                }
            }
        }
        Err(e) => problems.push(format!("HID enumeration unavailable: {e}")),
    }
    match list_serial() {
        // Only USB ports: probing every legacy UART node costs a timeout each and writes
        // bytes to whatever is attached.
        Ok(ports) => {
            for p in ports.into_iter().filter(|p| p.usb_id.is_some()) {
                if let Ok(hello) =
                    SerialLink::open(&p.path).and_then(|mut l| l.hello(PROBE_TIMEOUT))
                {
                    found.push(Found {
                        kind: "serial",
                        path: p.path,
                        hello,
                        product: p.product,
                    });
                }
            }
        }
        Err(e) => problems.push(format!("serial port enumeration unavailable: {e}")),
    }
    (found, problems)
}

/// Writes the table of `device list`, or `no devices found`.
pub fn write_table(found: &[Found], mut out: impl Write) -> std::io::Result<()> {
    if found.is_empty() {
        return writeln!(out, "no devices found");
    }
    writeln!(
        out,
        "{:<7} {:<24} {:<9} {:>14}  product",
        "kind", "path", "firmware", "scene capacity"
    )?;
    for f in found {
        let [a, b, c] = f.hello.software;
        writeln!(
            out,
            "{:<7} {:<24} {:<9} {:>14}  {}",
            f.kind,
            f.path,
            format!("{a}.{b}.{c}"),
            f.hello.scene_capacity,
            f.product.as_deref().unwrap_or("-")
        )?;
    }
    Ok(())
}

/// Which device `device monitor` talks to.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Target {
    /// A serial port.
    Serial(String),
    /// A board over TCP (`HOST:PORT`), the firmware under QEMU.
    Tcp(String),
    /// The first HID board.
    Hid,
    /// The simulated pantograph in this process.
    Sim,
}

/// An open link, with the simulated hand when the device is the simulator.
#[derive(Debug)]
pub struct Opened {
    /// The link.
    pub link: Box<dyn Link>,
    /// The device's hello.
    pub hello: Hello,
    /// The simulated hand, for [`Target::Sim`].
    pub hand: Option<SimHand>,
}

/// Opens the link to `target` and says hello.
pub fn open(target: &Target) -> Result<Opened, LinkError> {
    let (mut link, hand): (Box<dyn Link>, _) = match target {
        Target::Serial(path) => (Box::new(SerialLink::open(path)?), None),
        Target::Tcp(address) => (
            Box::new(TcpLink::connect(address, Duration::from_secs(2))?),
            None,
        ),
        Target::Hid => (Box::new(HidLink::open_first()?), None),
        Target::Sim => {
            let sim = SimLink::spawn(SimConfig::default())?;
            let hand = sim.hand()?;
            (Box::new(sim), Some(hand))
        }
    };
    let hello = link.hello(Duration::from_secs(1))?;
    if hand.is_some() {
        // Homing is instant in simulation; without it the telemetry has no HIP.
        link.request(&Message::Calibrate, Duration::from_secs(1))?;
    }
    Ok(Opened { link, hello, hand })
}

/// What a monitor run saw.
#[derive(Clone, Copy, Debug, Default)]
pub struct MonitorSummary {
    /// Telemetry frames received.
    pub telemetry: u64,
    /// Frames lost (gaps in the device's sequence numbers).
    pub dropped: u64,
}

fn mode_name(mode: Mode) -> &'static str {
    match mode {
        Mode::Free => "free",
        Mode::Stuck => "stuck",
        Mode::Transition => "transition",
        Mode::Slip => "slip",
    }
}

fn faults_text(bits: u16) -> String {
    let faults = Faults::from_bits_truncate(bits);
    if faults.is_empty() {
        "-".to_owned()
    } else {
        faults.names().collect::<Vec<_>>().join(",")
    }
}

fn telemetry_line(seq: u16, t: &Telemetry) -> String {
    format!(
        "t={:.6}s seq={seq} hip=({:+.5},{:+.5}) force=({:+.3},{:+.3}) normal={:.3} mode={} cause={} feature={} faults={}",
        f64::from(t.time_us) * 1e-6,
        t.hip_m.x,
        t.hip_m.y,
        t.force_n.x,
        t.force_n.y,
        t.force_normal_n,
        mode_name(t.mode),
        t.cause.name(),
        t.feature.map_or("-".to_owned(), |f| format!("{f:?}")),
        faults_text(t.faults),
    )
}

/// Monitors `link` for `duration` (forever when `None`): writes every `every`-th telemetry
/// frame as a line, a line for every gap in the sequence numbers, every change of the fault
/// flags, and nacks; sends a heartbeat every [`HEARTBEAT_PERIOD`] (the monitor is the host,
/// so it keeps the watchdog fed). `hand` is called with the elapsed time and may move the
/// simulated hand.
pub fn monitor(
    link: &mut dyn Link,
    duration: Option<Duration>,
    every: u64,
    mut hand: impl FnMut(Duration) -> Result<(), LinkError>,
    mut out: impl Write,
) -> anyhow::Result<MonitorSummary> {
    let start = Instant::now();
    let mut gaps = GapCounter::default();
    let mut summary = MonitorSummary::default();
    let mut last_faults: Option<u16> = None;
    let mut next_heartbeat = start;
    let every = every.max(1);
    loop {
        let now = Instant::now();
        let elapsed = now - start;
        if duration.is_some_and(|d| elapsed >= d) {
            break;
        }
        if now >= next_heartbeat {
            let uptime_ms = u32::try_from(elapsed.as_millis()).unwrap_or(u32::MAX);
            link.send(&Message::Heartbeat { uptime_ms })?;
            next_heartbeat = now + HEARTBEAT_PERIOD;
        }
        hand(elapsed)?;
        let frame = match link.recv(Duration::from_millis(10)) {
            Ok(Some(frame)) => frame,
            Ok(None) => continue,
            Err(LinkError::Frame(e)) => {
                writeln!(out, "bad frame: {}", e.code)?;
                continue;
            }
            Err(e) => return Err(e.into()),
        };
        let Frame { seq, message } = frame;
        let gap = gaps.observe(seq);
        if gap > 0 {
            writeln!(
                out,
                "dropped {gap} frame(s) before seq {seq} (total {})",
                gaps.dropped
            )?;
        }
        match message {
            Message::Telemetry(t) => {
                if last_faults != Some(t.faults) {
                    writeln!(out, "faults: {}", faults_text(t.faults))?;
                    last_faults = Some(t.faults);
                }
                if summary.telemetry % every == 0 {
                    writeln!(out, "{}", telemetry_line(seq, &t))?;
                }
                summary.telemetry += 1;
            }
            Message::Nack(n) => writeln!(out, "nack: frame {}: {}", n.seq, n.code)?,
            _ => {}
        }
    }
    summary.dropped = gaps.dropped;
    Ok(summary)
}

/// The simulated hand's path in `device monitor --sim`: a slow 1 cm circle around the
/// handle's start, one turn every 4 s, so the telemetry moves.
pub fn sim_hand_target(elapsed: Duration) -> Vec2 {
    let phase = elapsed.as_secs_f32() * std::f32::consts::TAU / 4.0;
    SimConfig::default().start_hip + Vec2::new(phase.cos() - 1.0, phase.sin()) * 0.01
}
