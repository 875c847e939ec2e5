//! `viewer device …`'s printing half: the table of `device list`, and `device monitor`'s
//! lines of telemetry, gaps, faults and nacks. Finding and opening devices is
//! [`host::devices`].

use std::io::Write;
use std::time::{Duration, Instant};

use device::safety::Faults;
use friction::Mode;
use host::devices::{Found, HEARTBEAT_PERIOD};
use protocol::host_side::{GapCounter, Link, LinkError, SimConfig};
use protocol::{Frame, Message, Telemetry};

use crate::interrupt::Interrupt;
use nurbs::Vec2;

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

/// Writes `line` and its newline to `out` in one write, so that output cut short (the process
/// killed) never ends mid-line: through the standard output's line buffer, or a file.
fn write_line(out: &mut impl Write, line: std::fmt::Arguments<'_>) -> std::io::Result<()> {
    let mut text = line.to_string();
    text.push('\n');
    out.write_all(text.as_bytes())
}

/// Monitors `link` for `duration` (forever when `None`) or until `interrupt` is raised
/// (Ctrl-C): writes every `every`-th telemetry frame as a line, a line for every gap in the
/// sequence numbers, every change of the fault flags, and nacks, each line whole; sends a
/// heartbeat every [`HEARTBEAT_PERIOD`] (the monitor is the host, so it keeps the watchdog
/// fed). `hand` is called with the elapsed time and may move the simulated hand.
pub fn monitor(
    link: &mut dyn Link,
    duration: Option<Duration>,
    every: u64,
    interrupt: &Interrupt,
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
        if duration.is_some_and(|d| elapsed >= d) || interrupt.requested() {
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
                write_line(&mut out, format_args!("bad frame: {}", e.code))?;
                continue;
            }
            Err(e) => return Err(e.into()),
        };
        let restarts = gaps.restarts;
        // Telemetry only: replies are numbered apart.
        let gap = gaps.telemetry(&frame);
        let Frame { seq, message } = frame;
        if gaps.restarts > restarts {
            write_line(
                &mut out,
                format_args!(
                    "the device restarted its frame numbering at seq {seq} (a reset?); nothing counted as dropped"
                ),
            )?;
        }
        if gap > 0 {
            write_line(
                &mut out,
                format_args!(
                    "dropped {gap} frame(s) before seq {seq} (total {})",
                    gaps.dropped
                ),
            )?;
        }
        match message {
            Message::Telemetry(t) => {
                if last_faults != Some(t.faults) {
                    write_line(&mut out, format_args!("faults: {}", faults_text(t.faults)))?;
                    last_faults = Some(t.faults);
                }
                if summary.telemetry % every == 0 {
                    write_line(&mut out, format_args!("{}", telemetry_line(seq, &t)))?;
                }
                summary.telemetry += 1;
            }
            Message::Nack(n) => {
                write_line(&mut out, format_args!("nack: frame {}: {}", n.seq, n.code))?
            }
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

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use std::collections::VecDeque;

    /// A device that sends the frames it was given, then nothing.
    #[derive(Debug)]
    struct Replay(VecDeque<Frame>);

    impl Link for Replay {
        fn send(&mut self, _: &Message) -> Result<u16, LinkError> {
            Ok(0)
        }
        fn recv(&mut self, _: Duration) -> Result<Option<Frame>, LinkError> {
            Ok(self.0.pop_front())
        }
    }

    /// A device reset mid-stream (its numbering starts again at 0) is reported as a restart,
    /// not as ~65,000 dropped frames; a real gap after it is still counted.
    #[test]
    fn monitor_reports_a_device_restart_not_a_huge_loss() {
        let seqs = (700..710).chain(0..5).chain(7..9);
        // Telemetry frames: the device numbers telemetry apart from its replies, and the
        // monitor counts gaps in the telemetry's numbers.
        let frames = seqs
            .map(|seq| Frame {
                seq,
                message: Message::Telemetry(protocol::Telemetry::IDLE),
            })
            .collect();
        let mut out = Vec::new();
        let summary = monitor(
            &mut Replay(frames),
            Some(Duration::from_millis(50)),
            1,
            &Interrupt::default(),
            |_| Ok(()),
            &mut out,
        )
        .unwrap();
        let out = String::from_utf8(out).unwrap();
        assert_eq!(summary.dropped, 2, "{out}");
        assert!(
            out.contains("restarted its frame numbering at seq 0"),
            "{out}"
        );
        assert!(out.contains("dropped 2 frame(s) before seq 7"), "{out}");
    }
}
