//! `viewer zwidth`: the Z-width of the simulated pantograph.

use std::io::{self};
use std::process::ExitCode;

use anyhow::Context;
use viewer::cli::{EXIT_BAD_INPUT, EXIT_BAD_SETUP};

use crate::{create_outputs, fail};

pub(crate) fn zwidth_command(args: &viewer::cli::ZwidthArgs) -> ExitCode {
    use host::zwidth::sweep_on;
    use viewer::zwidth_figure::{DAMPINGS, STIFFNESSES};
    let spec = match crate::device_spec(args.device_spec.as_deref()) {
        Ok(spec) => spec,
        Err(code) => return code,
    };
    // Before the sweep (minutes), so that a bad output path does not wait for it; written to
    // temporary files renamed over the targets once both are complete.
    let (out, plot_file) = match create_outputs(&args.out, args.plot.as_deref()) {
        Ok(files) => files,
        Err(e) => return fail(&e, EXIT_BAD_INPUT),
    };
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
        match sweep_on(
            &spec,
            args.rate_hz,
            args.hand,
            (&STIFFNESSES, &DAMPINGS),
            controller,
            args.speed,
            progress,
        ) {
            Ok(mut more) => cells.append(&mut more),
            Err(e) => return fail(&anyhow::Error::new(e).context("zwidth"), EXIT_BAD_SETUP),
        }
    }
    let written = out
        .file()
        .and_then(|f| host::zwidth::write_csv(&cells, io::BufWriter::new(f)))
        .with_context(|| format!("cannot write {}", args.out.display()));
    if let Err(e) = written {
        return fail(&e, EXIT_BAD_INPUT);
    }
    if let (Some(png), Some(file)) = (&args.plot, &plot_file)
        && let Err(e) = viewer::zwidth_figure::write_png(
            &cells,
            args.rate_hz,
            args.hand.name(),
            file.temp_path(),
        )
    {
        return fail(
            &anyhow::Error::new(e).context(format!("cannot draw {}", png.display())),
            EXIT_BAD_INPUT,
        );
    }
    let committed = out
        .commit()
        .and_then(|()| plot_file.map_or(Ok(()), |f| f.commit()))
        .with_context(|| format!("cannot write {}", args.out.display()));
    if let Err(e) = committed {
        return fail(&e, EXIT_BAD_INPUT);
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
