//! `viewer zwidth`: the Z-width of the simulated pantograph.

use std::io::{self};
use std::process::ExitCode;

use anyhow::anyhow;
use viewer::cli::EXIT_BAD_SETUP;

use crate::fail;

pub(crate) fn zwidth_command(args: &viewer::cli::ZwidthArgs) -> ExitCode {
    use host::zwidth::sweep;
    use viewer::zwidth_figure::{DAMPINGS, STIFFNESSES};
    let mut cells = Vec::new();
    for controller in [false, true] {
        let progress = |done: usize, total: usize| {
            if done.is_multiple_of(13) || done == total {
                eprintln!(
                    "zwidth: controller {}: {done}/{total} cells",
                    if controller { "on" } else { "off" }
                );
            }
        };
        match sweep(
            args.rate_hz,
            args.hand,
            &STIFFNESSES,
            &DAMPINGS,
            controller,
            args.speed,
            progress,
        ) {
            Ok(mut more) => cells.append(&mut more),
            Err(e) => return fail(&anyhow::Error::new(e).context("zwidth"), EXIT_BAD_SETUP),
        }
    }
    let written = std::fs::File::create(&args.out)
        .and_then(|f| host::zwidth::write_csv(&cells, io::BufWriter::new(f)));
    if let Err(e) = written {
        return fail(
            &anyhow!("cannot write {}: {e}", args.out.display()),
            EXIT_BAD_SETUP,
        );
    }
    if let Some(png) = &args.plot
        && let Err(e) =
            viewer::zwidth_figure::write_png(&cells, args.rate_hz, args.hand.name(), png)
    {
        return fail(&anyhow::Error::new(e), EXIT_BAD_SETUP);
    }
    for controller in [false, true] {
        let largest = cells
            .iter()
            .filter(|c| {
                c.impact.passivity_control == controller && c.impact.damping_ns_per_m == 0.0
            })
            .take_while(|c| c.outcome.stable)
            .last()
            .map_or(0.0, |c| c.impact.stiffness_n_per_m);
        println!(
            "zwidth: {} Hz, {}, controller {}: stable up to K = {largest} N/m (B = 0)",
            args.rate_hz,
            args.hand.name(),
            if controller { "on" } else { "off" }
        );
    }
    ExitCode::SUCCESS
}
