//! `viewer plot`: a run log plotted.

use std::process::ExitCode;

use anyhow::Context;
use viewer::cli::{EXIT_BAD_INPUT, EXIT_BAD_SETUP, PlotArgs};
use viewer::output::AtomicFile;
use viewer::plot;

use crate::fail;

pub(crate) fn plot_command(args: &PlotArgs) -> ExitCode {
    let log = match host::runlog::read(&args.log) {
        Ok(log) => log,
        Err(e) => return fail(&anyhow::Error::new(e), EXIT_BAD_SETUP),
    };
    let out = match AtomicFile::create(&args.out)
        .with_context(|| format!("cannot create plot {}", args.out.display()))
    {
        Ok(f) => f,
        Err(e) => return fail(&e, EXIT_BAD_INPUT),
    };
    if let Err(e) = plot::write_png_panels(
        &log.run,
        out.temp_path(),
        &args.out,
        plot::DEFAULT_SIZE,
        log.has_parameters,
    ) {
        return fail(&anyhow::Error::new(e), EXIT_BAD_INPUT);
    }
    match out
        .commit()
        .with_context(|| format!("cannot write plot {}", args.out.display()))
    {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => fail(&e, EXIT_BAD_INPUT),
    }
}
