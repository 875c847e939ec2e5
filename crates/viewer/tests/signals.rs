//! A run interrupted as a terminal user quits it (Ctrl-C: SIGINT; `kill`: SIGTERM) leaves a
//! file of complete rows and exits with 128 + the signal's number: `viewer sim --out` and
//! `viewer device monitor`, each sent a real signal (by the `kill` command) while it runs.
//! `viewer gui --record` needs a display: `cargo xtask ci`'s window test interrupts it under
//! Xvfb the same way.
#![cfg(unix)]

use std::io::{BufRead, BufReader};
use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// How long a test waits for the viewer to start writing, and then to exit after the signal
/// (a loaded CI machine runs the debug build slowly).
const PATIENCE: Duration = Duration::from_secs(60);

/// A fresh temporary directory, removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> Self {
        let dir =
            std::env::temp_dir().join(format!("viewer-signals-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("temp dir");
        TempDir(dir)
    }

    fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A child process killed (SIGKILL) if the test fails before it has exited.
struct Running(Child);

impl Running {
    /// Sends `signal` (`INT`, `TERM`) with the `kill` command, as a shell user would.
    fn signal(&self, signal: &str) {
        let sent = Command::new("kill")
            .arg(format!("-{signal}"))
            .arg(self.0.id().to_string())
            .status()
            .expect("the kill command runs");
        assert!(sent.success(), "kill -{signal} failed");
    }

    /// Waits for the exit, at most [`PATIENCE`].
    fn wait(&mut self) -> ExitStatus {
        let start = Instant::now();
        loop {
            if let Some(status) = self.0.try_wait().expect("wait") {
                return status;
            }
            assert!(
                start.elapsed() < PATIENCE,
                "the viewer has not exited {} s after the signal",
                PATIENCE.as_secs()
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        if self.0.try_wait().ok().flatten().is_none() {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
}

/// Polls `path` until `ready` holds of its text, at most [`PATIENCE`].
fn wait_for(path: &Path, what: &str, ready: impl Fn(&str) -> bool) {
    let start = Instant::now();
    while !std::fs::read(path).is_ok_and(|b| ready(&String::from_utf8_lossy(&b))) {
        assert!(
            start.elapsed() < PATIENCE,
            "{}: no {what} within {} s",
            path.display(),
            PATIENCE.as_secs()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn exit_code(status: ExitStatus, signal: &str) -> Option<i32> {
    assert!(
        status.signal().is_none(),
        "the viewer was killed by signal {:?} after SIG{signal}: it did not handle it",
        status.signal()
    );
    status.code()
}

/// The rows of the run log at `path`, every one complete ([`host::runlog::parse_complete`]:
/// the text ends with a newline, every row has the header's columns and reads back, numbers
/// where the columns are numbers).
fn complete_rows(path: &Path) -> usize {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let log = host::runlog::parse_complete(&text, path).unwrap_or_else(|e| panic!("{e}"));
    log.run.ticks.len()
}

/// `viewer sim` on thesis-2d along a trajectory of 400 s (400,000 ticks at 1 kHz), sent
/// `signal` once its progress shows 10 %: the run log holds the ticks run so far, every row
/// complete, at least the 40,000 of that 10 % and fewer than all, and no temporary file is
/// left beside it.
fn sim_interrupted(signal: &str, code: i32) {
    let dir = TempDir::new(&format!("sim-{signal}"));
    let trajectory = dir.path("long.csv");
    // Back and forth over the right arc, pressing into it (thesis-2d.csv's first stroke).
    let mut text = String::from("t,x,y\n");
    for i in 0..=200 {
        let (x, y) = if i % 2 == 0 {
            (0.0222862, 0.0753909)
        } else {
            (-0.0044642, 0.0907426)
        };
        text += &format!("{},{x},{y}\n", i * 2);
    }
    std::fs::write(&trajectory, text).expect("trajectory");
    let out = dir.path("run.csv");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/thesis-2d.json");
    let mut child = Running(
        Command::new(env!("CARGO_BIN_EXE_viewer"))
            .arg("sim")
            .arg(scene)
            .arg("--trajectory")
            .arg(&trajectory)
            .arg("--out")
            .arg(&out)
            .stderr(Stdio::piped())
            .spawn()
            .expect("viewer runs"),
    );
    let stderr = child.0.stderr.take().expect("stderr");
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let mut seen = Vec::new();
    loop {
        let line = rx
            .recv_timeout(PATIENCE)
            .unwrap_or_else(|_| panic!("no 10 % progress within {PATIENCE:?}: {seen:?}"));
        let at_10 = line.starts_with("sim:") && line.contains("10%");
        seen.push(line);
        if at_10 {
            break;
        }
    }
    child.signal(signal);
    let status = child.wait();
    let said: Vec<String> = seen.into_iter().chain(rx.try_iter()).collect();
    assert_eq!(exit_code(status, signal), Some(code), "{said:?}");
    let rows = complete_rows(&out);
    assert!(
        (40_000..400_000).contains(&rows),
        "{rows} rows: the ticks up to the signal"
    );
    let left: Vec<_> = std::fs::read_dir(&dir.0)
        .expect("dir")
        .filter_map(Result::ok)
        .map(|e| e.file_name())
        .filter(|n| n.to_string_lossy().contains(".tmp"))
        .collect();
    assert!(left.is_empty(), "temporary files left: {left:?}");
    assert!(
        said.iter().any(|l| l.contains("interrupted")),
        "stderr says so: {said:?}"
    );
}

#[test]
fn sim_interrupted_by_sigint_writes_the_ticks_so_far() {
    sim_interrupted("INT", 130);
}

#[test]
fn sim_interrupted_by_sigterm_writes_the_ticks_so_far() {
    sim_interrupted("TERM", 143);
}

/// Whether `line` is one whole line of `device monitor`'s output (its --help lists them): a
/// telemetry line has all nine fields, the last one the faults.
fn monitor_line_complete(line: &str) -> bool {
    if let Some(rest) = line.strip_prefix("t=") {
        let fields: Vec<&str> = line.split(' ').collect();
        let keys: Vec<&str> = fields
            .iter()
            .map(|f| f.split_once('=').map_or("", |(k, _)| k))
            .collect();
        return keys
            == [
                "t", "seq", "hip", "force", "normal", "mode", "cause", "feature", "faults",
            ]
            && rest
                .split_once('s')
                .is_some_and(|(t, _)| t.parse::<f64>().is_ok())
            && fields[2].ends_with(')')
            && fields[3].ends_with(')')
            && !fields[8].trim_start_matches("faults=").is_empty();
    }
    line.starts_with("faults: ")
        || line.starts_with("dropped ") && line.ends_with(')')
        || line.starts_with("nack: ")
        || line.starts_with("bad frame: ")
        || line.starts_with("the device restarted")
        || line.starts_with("received ") && line.contains(" telemetry frames, dropped ")
}

/// `viewer device monitor --sim` writing to a file, sent `signal` after some telemetry: every
/// line is complete, and the last one is the summary of a finished run.
fn monitor_interrupted(signal: &str, code: i32) {
    let dir = TempDir::new(&format!("monitor-{signal}"));
    let path = dir.path("monitor.txt");
    let file = std::fs::File::create(&path).expect("output file");
    let mut child = Running(
        Command::new(env!("CARGO_BIN_EXE_viewer"))
            .args(["device", "monitor", "--sim", "--every", "10"])
            .stdout(file)
            .stderr(Stdio::null())
            .spawn()
            .expect("viewer runs"),
    );
    // Several lines, and one being written: a line every 10 ms.
    wait_for(&path, "telemetry lines", |text| {
        text.lines().filter(|l| l.starts_with("t=")).count() >= 20
    });
    child.signal(signal);
    let status = child.wait();
    let text = std::fs::read_to_string(&path).expect("read");
    assert_eq!(exit_code(status, signal), Some(code), "{text}");
    assert!(text.ends_with('\n'), "the last line is cut: {text:?}");
    for line in text.lines() {
        assert!(monitor_line_complete(line), "incomplete line {line:?}");
    }
    let telemetry = text.lines().filter(|l| l.starts_with("t=")).count();
    assert!(telemetry >= 20, "{text}");
    let last = text.lines().last().unwrap_or_default();
    let received: u64 = last
        .strip_prefix("received ")
        .and_then(|r| r.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("the last line is not the summary: {last:?}"));
    assert!(received >= 10 * (telemetry as u64 - 1), "{last}");
}

#[test]
fn monitor_interrupted_by_sigint_ends_with_whole_lines_and_its_summary() {
    monitor_interrupted("INT", 130);
}

#[test]
fn monitor_interrupted_by_sigterm_ends_with_whole_lines_and_its_summary() {
    monitor_interrupted("TERM", 143);
}
