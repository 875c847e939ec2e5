//! `viewer device list`, `monitor` and `sim-pty`: devices behind links.

use std::io::{self, Write};
use std::process::ExitCode;

use anyhow::{Context, anyhow};
use viewer::cli::{EXIT_BAD_INPUT, EXIT_BAD_SETUP};

use crate::commands::device_identify;
use crate::{fail, interrupt_or_default, interrupted_or_success};

pub(crate) fn device_command(command: &viewer::cli::DeviceSubcommand) -> ExitCode {
    use viewer::cli::DeviceSubcommand;
    use viewer::device_report;
    match command {
        DeviceSubcommand::List => {
            let (found, problems) = host::devices::find_devices();
            for p in problems {
                eprintln!("device list: {p}");
            }
            match device_report::write_table(&found, io::stdout().lock()) {
                Ok(()) => ExitCode::SUCCESS,
                Err(e) if e.kind() == io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
                Err(e) => fail(&anyhow::Error::new(e), EXIT_BAD_INPUT),
            }
        }
        DeviceSubcommand::Monitor(args) => device_monitor(args),
        DeviceSubcommand::Identify(args) => device_identify(args),
        DeviceSubcommand::SimPty(args) => device_sim_pty(args),
        DeviceSubcommand::Spec { file } => {
            let spec = match crate::device_spec(file.as_deref()) {
                Ok(spec) => spec,
                Err(code) => return code,
            };
            match writeln!(
                io::stdout().lock(),
                "{}",
                host::device_file::to_json_string(&spec)
            ) {
                Ok(()) => ExitCode::SUCCESS,
                Err(e) if e.kind() == io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
                Err(e) => fail(&anyhow::Error::new(e), EXIT_BAD_INPUT),
            }
        }
    }
}

#[cfg(unix)]
pub(crate) fn device_sim_pty(args: &viewer::cli::SimPtyArgs) -> ExitCode {
    use protocol::host_side::{SimConfig, SimLink};
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};
    let spec = match crate::device_spec(args.device_spec.as_deref()) {
        Ok(spec) => spec,
        Err(code) => return code,
    };
    let pty = match protocol::host_side::pseudo_terminal().context("cannot open a pseudo-terminal")
    {
        Ok(pty) => pty,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    let sim = match SimLink::spawn(SimConfig {
        spec,
        ..SimConfig::default()
    })
    .context("cannot start the simulator")
    {
        Ok(sim) => sim,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    println!("{}", pty.path);
    eprintln!(
        "device sim-pty: the simulated pantograph is on {path}: `viewer gui --device serial:{path}` \
         or `viewer device monitor --port {path}`",
        path = pty.path
    );
    let stop = Arc::new(AtomicBool::new(false));
    if let Some(after) = args.seconds {
        let stop = stop.clone();
        std::thread::spawn(move || {
            std::thread::sleep(after);
            stop.store(true, Ordering::Relaxed);
        });
    }
    let path = pty.path.clone();
    // The host end stays open in `pty`, so the device's end never sees it close.
    let served = sim.serve(pty.device, &stop);
    match served.with_context(|| format!("serving on {path}")) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => fail(&e, EXIT_BAD_INPUT),
    }
}

#[cfg(not(unix))]
pub(crate) fn device_sim_pty(_: &viewer::cli::SimPtyArgs) -> ExitCode {
    fail(
        &anyhow!("device sim-pty: pseudo-terminals need Linux or macOS"),
        EXIT_BAD_SETUP,
    )
}

pub(crate) fn device_monitor(args: &viewer::cli::MonitorArgs) -> ExitCode {
    use std::time::Duration;
    use viewer::device_report;
    let Some(target) = args.device.target() else {
        let e = anyhow!("device monitor: {}", viewer::cli::CHOOSE_A_DEVICE);
        return fail(&e, EXIT_BAD_SETUP);
    };
    let spec = match crate::device_spec(args.device.device_spec.as_deref()) {
        Ok(spec) => spec,
        Err(code) => return code,
    };
    let mut opened = match host::devices::open_with(&target, &spec)
        .with_context(|| format!("cannot open {target:?}"))
    {
        Ok(opened) => opened,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    let [a, b, c] = opened.hello.software;
    eprintln!(
        "device monitor: connected to {target:?}: firmware {a}.{b}.{c}, scene capacity {} bytes",
        opened.hello.scene_capacity
    );
    let hand = opened.hand.clone();
    let move_hand = |elapsed: Duration| match &hand {
        Some(hand) => hand.set_target(device_report::sim_hand_target(elapsed)),
        None => Ok(()),
    };
    let duration = args.seconds;
    let interrupt = interrupt_or_default("device monitor");
    let mut out = io::stdout().lock();
    match device_report::monitor(
        opened.link.as_mut(),
        duration,
        args.every,
        &interrupt,
        move_hand,
        &mut out,
    ) {
        Ok(summary) => {
            let _ = out.write_all(
                format!(
                    "received {} telemetry frames, dropped {}\n",
                    summary.telemetry, summary.dropped
                )
                .as_bytes(),
            );
            let _ = out.flush();
            if let Some(signal) = interrupt.signal_name() {
                eprintln!("device monitor: interrupted by {signal}");
            }
            interrupted_or_success(&interrupt)
        }
        // The reader went away (`| head`): not an error of ours.
        Err(e)
            if e.downcast_ref::<io::Error>()
                .is_some_and(|e| e.kind() == io::ErrorKind::BrokenPipe) =>
        {
            ExitCode::SUCCESS
        }
        Err(e) => fail(&e.context("device monitor"), EXIT_BAD_INPUT),
    }
}
