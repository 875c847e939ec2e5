//! The GUI's part of `cargo xtask ci`.
//!
//! - [`ensure_packages`], before the tests: the viewer's snapshot tests render through wgpu
//!   on Mesa's software Vulkan driver (lavapipe), and the window test needs an X server; on a
//!   machine without them this installs, with apt-get, `mesa-vulkan-drivers` (lavapipe) and
//!   `libvulkan1` (the Vulkan loader), `xvfb` and `xauth` (a virtual X server and
//!   `xvfb-run`), and the X11 libraries winit loads at run time (`libxkbcommon-x11-0`,
//!   `libxcursor1`, `libxi6`, `libxrandr2`).
//! - [`window_test`], after the tests: the `viewer` binary the tests built (the test
//!   profile's, no second build) opens its real window under Xvfb with the hand moving along
//!   the thesis path (`--demo`), closes itself after a few seconds of frames
//!   (`--quit-after-frames`) and must exit with status 0; its last line (frames, frame time,
//!   tick period and jitter) is printed.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Debian packages the GUI checks need, and why.
const PACKAGES: &[(&str, &str)] = &[
    (
        "mesa-vulkan-drivers",
        "Mesa's software Vulkan driver (lavapipe)",
    ),
    ("libvulkan1", "the Vulkan loader"),
    ("xvfb", "a virtual X server and xvfb-run"),
    ("xauth", "X authority files for xvfb-run"),
    ("libxkbcommon-x11-0", "keyboard handling winit loads on X11"),
    ("libxcursor1", "cursors winit loads on X11"),
    ("libxi6", "input events winit loads on X11"),
    ("libxrandr2", "monitor geometry winit loads on X11"),
];

/// Frames the window test draws before the app closes itself (about 3 s at 60 Hz).
const WINDOW_FRAMES: &str = "180";
/// The window test fails if the app has not exited by then.
const WINDOW_TIMEOUT: Duration = Duration::from_secs(180);

/// Installs the [`PACKAGES`] that are missing (apt-get, as root), saying which and why.
pub(crate) fn ensure_packages() -> Result<(), String> {
    crate::ensure_packages(PACKAGES, "the viewer's GUI tests")
}

/// Runs the viewer's real window under Xvfb and checks that it closes itself with status 0.
/// `viewer` is the binary `cargo test --workspace` built (for the CLI tests): running it
/// directly needs no second build. (`cargo run -p viewer` would rebuild the whole GUI stack:
/// no other package depends on the app, so the test build's feature set, unified with the
/// viewer's dev-dependencies, is the only one built; that rebuild took most of the window
/// test's 180 s.)
pub(crate) fn window_test(viewer: &Path) -> Result<(), String> {
    if !viewer.is_file() {
        return Err(format!(
            "{}: the viewer binary the tests build is missing",
            viewer.display()
        ));
    }
    let started = Instant::now();
    let mut child = spawn_under_xvfb(
        viewer,
        &["gui", "--demo", "--quit-after-frames", WINDOW_FRAMES],
        Stdio::inherit(),
        Stdio::inherit(),
    )?;
    loop {
        match child.try_wait() {
            Ok(Some(status)) if status.success() => {
                println!(
                    "xtask: the viewer's window ran under Xvfb and closed itself after {WINDOW_FRAMES} frames ({:.1} s)",
                    started.elapsed().as_secs_f64()
                );
                return Ok(());
            }
            Ok(Some(status)) => {
                return Err(format!(
                    "the viewer's window test under Xvfb exited with {status}"
                ));
            }
            Ok(None) if started.elapsed() > WINDOW_TIMEOUT => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!(
                    "the viewer's window under Xvfb did not close itself within {} s",
                    WINDOW_TIMEOUT.as_secs()
                ));
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(100)),
            Err(e) => return Err(format!("waiting for xvfb-run: {e}")),
        }
    }
}

/// Starts `viewer ARGS` under Xvfb (`xvfb-run -a` picks a free display), its standard error
/// to `stderr`. The viewer is xvfb-run's child, and xvfb-run exits with its status.
fn spawn_under_xvfb(
    viewer: &Path,
    args: &[&str],
    stderr: Stdio,
    stdout: Stdio,
) -> Result<Child, String> {
    let viewer = viewer.to_string_lossy();
    let mut all = vec!["-a", "-s", "-screen 0 1600x1000x24", &viewer];
    all.extend(args);
    println!("\n==> xvfb-run {}", all.join(" "));
    // winit asks for a runtime directory, which a CI shell may not have.
    let runtime = std::env::temp_dir().join("xtask-gui-runtime");
    std::fs::create_dir_all(&runtime)
        .and_then(|()| {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(&runtime, std::fs::Permissions::from_mode(0o700))
        })
        .map_err(|e| format!("{}: {e}", runtime.display()))?;
    Command::new("xvfb-run")
        .args(all)
        .envs(crate::CI_ENV.iter().copied())
        .env("XDG_RUNTIME_DIR", &runtime)
        .stderr(stderr)
        .stdout(stdout)
        .spawn()
        .map_err(|e| format!("cannot start xvfb-run: {e}"))
}

/// The process `parent` started whose command name is `name` (from `/proc/PID/stat`).
fn child_named(parent: u32, name: &str) -> Option<u32> {
    std::fs::read_dir("/proc").ok()?.find_map(|entry| {
        let pid: u32 = entry.ok()?.file_name().to_str()?.parse().ok()?;
        let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
        // `PID (COMM) STATE PPID …`; COMM may hold spaces and parentheses.
        let (head, tail) = stat.rsplit_once(") ")?;
        let comm = head.split_once(" (")?.1;
        let ppid: u32 = tail.split(' ').nth(1)?.parse().ok()?;
        (ppid == parent && comm == name).then_some(pid)
    })
}

/// Rows the recording holds before the signal is sent: a second of the 1 kHz loop.
const RECORD_ROWS_BEFORE_SIGNAL: usize = 1000;

/// Ctrl-C ends a recording cleanly: `viewer gui --demo --record run.csv` under Xvfb, sent
/// SIGINT (with `kill`, to the viewer itself) once its run log holds
/// [`RECORD_ROWS_BEFORE_SIGNAL`] rows, must close its window, complete the recording (it says
/// `recorded N ticks` on standard error, which a viewer killed by the signal never does) and
/// exit with 130; every row of the run log must be complete
/// ([`host::runlog::parse_complete`]), and at least as many as before the signal.
pub(crate) fn record_interrupt_test(viewer: &Path) -> Result<(), String> {
    let dir = std::env::temp_dir().join(format!("xtask-gui-record-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let record = dir.join("run.csv");
    let record_arg = record.to_string_lossy().into_owned();
    let mut child = spawn_under_xvfb(
        viewer,
        &["gui", "--demo", "--record", &record_arg],
        Stdio::piped(),
        Stdio::inherit(),
    )?;
    let (interrupted, said, _) = interrupt_echoed(&mut child, |child, viewer_pid| {
        interrupt_recording(child, &record, viewer_pid)
    });
    let result = interrupted.and_then(|status| check_interrupted_recording(status, &record, &said));
    let _ = std::fs::remove_dir_all(&dir);
    result
}

/// Runs `interrupt` on `child` (xvfb-run with the viewer under it; `interrupt` records the
/// viewer's PID in its second argument once it finds it) while the viewer's standard error
/// and output, where piped, are echoed to standard error and kept; ends the viewer and
/// xvfb-run if `interrupt` left them running. Returns `interrupt`'s result, then what the
/// viewer wrote on standard error and on standard output (empty for a stream not piped).
fn interrupt_echoed(
    child: &mut Child,
    interrupt: impl FnOnce(&mut Child, &mut Option<u32>) -> Result<std::process::ExitStatus, String>,
) -> (Result<std::process::ExitStatus, String>, String, String) {
    let echo = |stream: Option<Box<dyn std::io::Read + Send>>| {
        std::thread::spawn(move || {
            use std::io::BufRead;
            let mut said = String::new();
            for line in stream
                .map(std::io::BufReader::new)
                .into_iter()
                .flat_map(|r| r.lines().map_while(Result::ok))
            {
                eprintln!("{line}");
                said.push_str(&line);
                said.push('\n');
            }
            said
        })
    };
    let err = echo(child.stderr.take().map(|s| Box::new(s) as _));
    let out = echo(child.stdout.take().map(|s| Box::new(s) as _));
    let mut viewer_pid = None;
    let interrupted = interrupt(child, &mut viewer_pid);
    if child.try_wait().ok().flatten().is_none() {
        // Failed on the way: end the viewer (xvfb-run then stops its X server) and xvfb-run.
        if let Some(pid) = viewer_pid {
            let _ = Command::new("kill")
                .args(["-KILL", &pid.to_string()])
                .status();
        }
        let _ = child.kill();
        let _ = child.wait();
    }
    (
        interrupted,
        err.join().unwrap_or_default(),
        out.join().unwrap_or_default(),
    )
}

/// Waits for the recording to hold [`RECORD_ROWS_BEFORE_SIGNAL`] rows, sends the viewer
/// SIGINT and waits for xvfb-run to exit.
fn interrupt_recording(
    child: &mut Child,
    record: &Path,
    viewer_pid: &mut Option<u32>,
) -> Result<std::process::ExitStatus, String> {
    let rows = || {
        std::fs::read(record).map_or(0, |t| {
            t.iter().filter(|&&b| b == b'\n').count().saturating_sub(1)
        })
    };
    interrupt_when(child, viewer_pid, || {
        let n = rows();
        (n >= RECORD_ROWS_BEFORE_SIGNAL)
            .then_some(format!("{n} rows recorded"))
            .ok_or_else(|| {
                format!(
                    "{}: {n} rows, {RECORD_ROWS_BEFORE_SIGNAL} wanted",
                    record.display()
                )
            })
    })
}

/// Waits until `ready` says the viewer is where the test wants it (`Ok(what)`, else
/// `Err(where it is)`), sends it SIGINT and waits for xvfb-run to exit.
fn interrupt_when(
    child: &mut Child,
    viewer_pid: &mut Option<u32>,
    ready: impl Fn() -> Result<String, String>,
) -> Result<std::process::ExitStatus, String> {
    let started = Instant::now();
    let what = loop {
        if let Some(status) = child.try_wait().map_err(|e| format!("xvfb-run: {e}"))? {
            return Err(format!("the viewer exited with {status} before the signal"));
        }
        if viewer_pid.is_none() {
            *viewer_pid = child_named(child.id(), "viewer");
        }
        match (ready(), viewer_pid.is_some()) {
            (Ok(what), true) => break what,
            (Err(at), _) if started.elapsed() > WINDOW_TIMEOUT => {
                return Err(format!("{at} after {} s", WINDOW_TIMEOUT.as_secs()));
            }
            _ => std::thread::sleep(Duration::from_millis(50)),
        }
    };
    let pid = viewer_pid.unwrap_or_default().to_string();
    println!("xtask: {what}; kill -INT {pid} (the viewer)");
    let sent = Command::new("kill")
        .args(["-INT", &pid])
        .status()
        .map_err(|e| format!("cannot run kill: {e}"))?;
    if !sent.success() {
        return Err(format!("kill -INT {pid} failed"));
    }
    let signalled = Instant::now();
    loop {
        if let Some(status) = child.try_wait().map_err(|e| format!("xvfb-run: {e}"))? {
            return Ok(status);
        }
        if signalled.elapsed() > Duration::from_secs(60) {
            return Err("the viewer did not exit within 60 s of SIGINT".into());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn check_interrupted_recording(
    status: std::process::ExitStatus,
    record: &Path,
    said: &str,
) -> Result<(), String> {
    let text = std::fs::read_to_string(record).map_err(|e| format!("{}: {e}", record.display()))?;
    let log = host::runlog::parse_complete(&text, record)
        .map_err(|e| format!("the recording interrupted by SIGINT: {e}"))?;
    let rows = log.run.ticks.len();
    if rows < RECORD_ROWS_BEFORE_SIGNAL {
        return Err(format!(
            "{rows} rows after SIGINT, fewer than the {RECORD_ROWS_BEFORE_SIGNAL} before it"
        ));
    }
    // xvfb-run exits with the viewer's status; a shell reports 130 for a child killed by
    // SIGINT too, so the summary line is what tells a clean stop.
    if !said.contains("viewer gui: recorded ") {
        return Err(format!(
            "the viewer did not complete its recording after SIGINT (exit {status}); it said:\n{said}"
        ));
    }
    if status.code() != Some(130) {
        return Err(format!(
            "the viewer exited with {status} after SIGINT, not 130"
        ));
    }
    println!("xtask: SIGINT closed the viewer's window: exit 130, {rows} complete rows recorded");
    Ok(())
}

/// Ctrl-C pauses a participant's run as Quit does: `viewer experiment run thesis-shapes.json
/// --participant P01 --out DIR` under Xvfb, sent SIGINT once the session is open (`DIR/plan.json`
/// written) and its window has had a second, must say so on standard error, print its summary
/// (`0 trials answered; run the same command again to resume`, which a viewer killed by the
/// signal never does) and exit with 130; `DIR` keeps the plan and no answered row.
pub(crate) fn participant_interrupt_test(viewer: &Path, root: &Path) -> Result<(), String> {
    let dir = std::env::temp_dir().join(format!("xtask-gui-participant-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let plan = root.join("experiments").join("thesis-shapes.json");
    let (plan_arg, dir_arg) = (
        plan.to_string_lossy().into_owned(),
        dir.to_string_lossy().into_owned(),
    );
    let mut child = spawn_under_xvfb(
        viewer,
        &[
            "experiment",
            "run",
            &plan_arg,
            "--participant",
            "P01",
            "--out",
            &dir_arg,
        ],
        Stdio::piped(),
        Stdio::piped(),
    )?;
    let opened = dir.join("plan.json");
    let since = std::cell::Cell::new(None::<Instant>);
    let (interrupted, said, printed) = interrupt_echoed(&mut child, |child, viewer_pid| {
        interrupt_when(child, viewer_pid, || {
            match (opened.is_file(), since.get()) {
                (false, _) => Err(format!("{} not written", opened.display())),
                (true, None) => {
                    since.set(Some(Instant::now()));
                    Err("the session just opened".into())
                }
                (true, Some(t)) if t.elapsed() < Duration::from_secs(1) => {
                    Err("the session opened under a second ago".into())
                }
                (true, Some(_)) => Ok("the participant's session is open".into()),
            }
        })
    });
    let rows = std::fs::read_to_string(dir.join("trials.csv"))
        .map_or(0, |t| t.lines().count().saturating_sub(1));
    let _ = std::fs::remove_dir_all(&dir);
    let status = interrupted?;
    if !said.contains("experiment run: SIGINT")
        || !printed.contains("0 trials answered; run the same command again to resume")
    {
        return Err(format!(
            "the participant's run did not pause on SIGINT (exit {status}); it said:\n{said}{printed}"
        ));
    }
    if status.code() != Some(130) || rows != 0 {
        return Err(format!(
            "after SIGINT the participant's run exited with {status} and {rows} answered rows, not 130 and none"
        ));
    }
    println!(
        "xtask: SIGINT paused the participant's run and closed its window: exit 130, nothing answered"
    );
    Ok(())
}
