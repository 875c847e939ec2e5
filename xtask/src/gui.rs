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
use std::process::Command;
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
    let viewer = viewer.to_string_lossy();
    let args = [
        "-a",
        "-s",
        "-screen 0 1600x1000x24",
        &viewer,
        "gui",
        "--demo",
        "--quit-after-frames",
        WINDOW_FRAMES,
    ];
    println!("\n==> xvfb-run {}", args.join(" "));
    // winit asks for a runtime directory, which a CI shell may not have.
    let runtime = std::env::temp_dir().join("xtask-gui-runtime");
    std::fs::create_dir_all(&runtime)
        .and_then(|()| {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(&runtime, std::fs::Permissions::from_mode(0o700))
        })
        .map_err(|e| format!("{}: {e}", runtime.display()))?;
    let started = Instant::now();
    let mut child = Command::new("xvfb-run")
        .args(args)
        .envs(crate::CI_ENV.iter().copied())
        .env("XDG_RUNTIME_DIR", &runtime)
        .spawn()
        .map_err(|e| format!("cannot start xvfb-run: {e}"))?;
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
