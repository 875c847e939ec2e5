//! `viewer`: see `viewer --help`.

use std::io::{self, Write};
use std::process::ExitCode;

use clap::Parser;
use viewer::cli::{Cli, CliCommand, GuiArgs};
use viewer::interrupt::Interrupt;

mod commands;
use commands::*;

fn main() -> ExitCode {
    match Cli::parse().command {
        None => gui_command(&GuiArgs::default()),
        Some(CliCommand::Gui(args)) => gui_command(&args),
        Some(CliCommand::Plot(args)) => plot_command(&args),
        Some(CliCommand::Eval(args)) => eval_command(&args),
        Some(CliCommand::Sim(args)) => sim_command(&args),
        Some(CliCommand::Closest(args)) => closest_command(&args),
        Some(CliCommand::Device(command)) => device_command(&command),
        Some(CliCommand::Zwidth(args)) => zwidth_command(&args),
        Some(CliCommand::Identify(args)) => identify_command(&args),
        Some(CliCommand::Deform(args)) => deform_command(&args),
        Some(CliCommand::Experiment(command)) => experiment_command(&command),
    }
}

/// [`Interrupt::install`], or, if the handlers cannot be installed, a flag that never rises
/// (Ctrl-C then ends `command` as it would without them).
pub(crate) fn interrupt_or_default(command: &str) -> Interrupt {
    Interrupt::install().unwrap_or_else(|e| {
        eprintln!(
            "{command}: warning: cannot handle Ctrl-C and SIGTERM ({e}); they end it at once"
        );
        Interrupt::default()
    })
}

/// The exit status of a command that finished its output: 128 + the signal's number if a
/// signal stopped it (130 SIGINT, 143 SIGTERM), else 0.
pub(crate) fn interrupted_or_success(interrupt: &Interrupt) -> ExitCode {
    interrupt
        .exit_code()
        .map_or(ExitCode::SUCCESS, ExitCode::from)
}

pub(crate) fn fail(error: &anyhow::Error, code: u8) -> ExitCode {
    let _ = writeln!(io::stderr(), "error: {error:#}");
    ExitCode::from(code)
}

/// The device a command models: the `device/1` file at `path`, or the default without one;
/// a bad file is reported (naming the field) and its exit status (2) returned.
pub(crate) fn device_spec(
    path: Option<&std::path::Path>,
) -> Result<device::spec::DeviceSpec, ExitCode> {
    host::device_file::load_or_default(path)
        .map_err(|e| fail(&anyhow::Error::new(e), viewer::cli::EXIT_BAD_SETUP))
}

/// The temporary files of a command's output and optional plot ([`AtomicFile`]), created
/// before its work so that a bad path fails at once (exit 1) instead of after the run; the
/// targets appear only when each is committed.
pub(crate) fn create_outputs(
    out: &std::path::Path,
    plot: Option<&std::path::Path>,
) -> anyhow::Result<(
    viewer::output::AtomicFile,
    Option<viewer::output::AtomicFile>,
)> {
    use anyhow::Context;
    use viewer::output::AtomicFile;
    let out =
        AtomicFile::create(out).with_context(|| format!("cannot create {}", out.display()))?;
    let plot = plot
        .map(|p| {
            AtomicFile::create(p).with_context(|| format!("cannot create plot {}", p.display()))
        })
        .transpose()?;
    Ok((out, plot))
}
