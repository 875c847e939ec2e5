//! `cargo xtask ci`: installs what the checks need when it is missing, then runs every check
//! CI runs, in order, stopping at the first failure. `cargo xtask qemu`: the firmware under
//! QEMU, its instructions per tick and its size (see `qemu.rs`). `cargo xtask ci` also builds
//! the board binary and checks its budget (see `board.rs`).

mod board;
mod gui;
mod qemu;
mod session;

use std::env;
use std::path::Path;
use std::process::{Command, ExitCode};

/// The embedded target the no_std crates and the firmware are built for.
pub(crate) const EMBEDDED_TARGET: &str = "thumbv7em-none-eabihf";

/// no_std crates cross-built for the board (their default `std` feature off).
const NO_STD_CRATES: &[&str] = &["nurbs", "tracker", "friction", "device"];

fn main() -> ExitCode {
    let args: Vec<String> = env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("ci") => match ci() {
            Ok(()) => {
                println!("xtask ci: all checks passed");
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("xtask ci: FAILED: {e}");
                ExitCode::FAILURE
            }
        },
        Some("qemu") => match qemu::Options::parse(&args[1..]).and_then(|o| qemu::qemu(&o)) {
            Ok(()) => {
                println!("xtask qemu: done");
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("xtask qemu: FAILED: {e}");
                ExitCode::FAILURE
            }
        },
        _ => {
            eprintln!(
                "usage: cargo xtask ci | qemu [--opt-level 3|s|3,s]\n\n\
                 ci    install what is missing (rustup target {EMBEDDED_TARGET}, clippy, rustfmt),\n\
                 \x20     then: cargo fmt --check, clippy -D warnings, cargo test --workspace,\n\
                 \x20     cross-build every no_std crate for {EMBEDDED_TARGET}, and check\n\
                 \x20     firmware/ (fmt, clippy of its library and board binary for\n\
                 \x20     {EMBEDDED_TARGET}), build the board binary (release) and check its\n\
                 \x20     size (flash <= 128 KiB, RAM <= 32 KiB with a stack reserve), then\n\
                 \x20     `qemu` below\n\
                 qemu  install qemu-system-arm when missing, build firmware/ (release, LTO) at\n\
                 \x20     each opt-level (default 3), run the thesis-2d scenario on QEMU's\n\
                 \x20     netduinoplus2 with -icount shift=5, compare its telemetry frames\n\
                 \x20     (its UART) tick by tick with the host's run, print instructions\n\
                 \x20     per tick and the ELF's text/data/bss"
            );
            ExitCode::from(2)
        }
    }
}

fn ci() -> Result<(), String> {
    ensure_toolchain()?;
    gui::ensure_packages()?;
    let cargo = env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    run(&cargo, &["fmt", "--all", "--check"])?;
    run(
        &cargo,
        &[
            "clippy",
            "--workspace",
            "--all-targets",
            "--",
            "-D",
            "warnings",
        ],
    )?;
    // A fixed proptest seed in CI: a run that lands must not depend on luck. Plain
    // `cargo test` (and CI with PROPTEST_RNG_SEED set) explores new cases every run.
    let seed = env::var("PROPTEST_RNG_SEED").unwrap_or_else(|_| "20261122".into());
    run_with_env(
        &cargo,
        &["test", "--workspace"],
        &[("PROPTEST_RNG_SEED", &seed)],
    )?;
    for krate in NO_STD_CRATES {
        run(
            &cargo,
            &[
                "build",
                "--release",
                "-p",
                krate,
                "--no-default-features",
                "--target",
                EMBEDDED_TARGET,
            ],
        )?;
        run(
            &cargo,
            &[
                "clippy",
                "-p",
                krate,
                "--no-default-features",
                "--target",
                EMBEDDED_TARGET,
                "--",
                "-D",
                "warnings",
            ],
        )?;
    }
    gui::window_test(&cargo)?;
    qemu::check_firmware(&cargo)?;
    board::check_board(&cargo)?;
    // The firmware under QEMU: the thesis-2d scenario in the emulated MCU compared frame by
    // frame with the host's run, its instructions per tick and its sizes.
    qemu::qemu(&qemu::Options::default())?;
    Ok(())
}

/// Adds the embedded target and the clippy/rustfmt components when rustup lacks them.
pub(crate) fn ensure_toolchain() -> Result<(), String> {
    let targets = output("rustup", &["target", "list", "--installed"])
        .map_err(|e| format!("cannot ask rustup for installed targets ({e}); install rustup"))?;
    if !targets.lines().any(|l| l.trim() == EMBEDDED_TARGET) {
        println!("xtask: installing rust target {EMBEDDED_TARGET}");
        run("rustup", &["target", "add", EMBEDDED_TARGET])
            .map_err(|e| format!("could not install the rust target {EMBEDDED_TARGET}: {e}"))?;
    }
    let components = output("rustup", &["component", "list", "--installed"]).unwrap_or_default();
    for comp in ["clippy", "rustfmt"] {
        if !components.lines().any(|l| l.starts_with(comp)) {
            println!("xtask: installing rustup component {comp}");
            run("rustup", &["component", "add", comp])
                .map_err(|e| format!("could not install the rustup component {comp}: {e}"))?;
        }
    }
    Ok(())
}

pub(crate) fn output(cmd: &str, args: &[&str]) -> Result<String, String> {
    let out = Command::new(cmd)
        .args(args)
        .output()
        .map_err(|e| format!("cannot start `{cmd}`: {e}"))?;
    if !out.status.success() {
        return Err(format!("`{cmd} {}` failed", args.join(" ")));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

fn run(cmd: &str, args: &[&str]) -> Result<(), String> {
    run_with_env(cmd, args, &[])
}

fn run_with_env(cmd: &str, args: &[&str], vars: &[(&str, &str)]) -> Result<(), String> {
    run_in(Path::new("."), cmd, args, vars)
}

/// Runs `cmd` in `dir` with the extra environment `vars`, echoing it first.
pub(crate) fn run_in(
    dir: &Path,
    cmd: &str,
    args: &[&str],
    vars: &[(&str, &str)],
) -> Result<(), String> {
    let shown: Vec<String> = vars.iter().map(|(k, v)| format!("{k}={v} ")).collect();
    let place = if dir == Path::new(".") {
        String::new()
    } else {
        format!("(in {}) ", dir.display())
    };
    println!("\n==> {place}{}{cmd} {}", shown.concat(), args.join(" "));
    let status = Command::new(cmd)
        .current_dir(dir)
        .args(args)
        .envs(vars.iter().copied())
        .status()
        .map_err(|e| format!("cannot start `{cmd}`: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("`{cmd} {}` exited with {status}", args.join(" ")))
    }
}
