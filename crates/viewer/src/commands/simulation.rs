//! `viewer sim`: the prescribed run, headless.

use std::process::ExitCode;

use anyhow::{Context, anyhow};
use host::sim::{self, Trajectory};
use scene::Scene;
use viewer::cli::{EXIT_BAD_INPUT, EXIT_BAD_SETUP, SimArgs};
use viewer::plot;

use crate::{create_outputs, fail, interrupt_or_default, interrupted_or_success};

pub(crate) fn sim_command(args: &SimArgs) -> ExitCode {
    let scene = match Scene::load(&args.scene).context("invalid scene") {
        Ok(scene) => scene,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    let trajectory = match Trajectory::load(&args.trajectory).context("invalid trajectory") {
        Ok(t) => t,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    // A bad device file is refused before anything runs or is written (exit 2).
    let spec = match crate::device_spec(args.device_spec.as_deref()) {
        Ok(spec) => spec,
        Err(code) => return code,
    };
    let checked = if args.device {
        host::closed_loop::validate_device_on(
            &spec,
            &scene,
            args.object,
            &trajectory,
            args.rate_hz(),
        )
    } else {
        sim::validate(&scene, args.object, &trajectory, args.rate_hz())
    };
    if let Err(e) = checked {
        return fail(&anyhow::Error::new(e), EXIT_BAD_SETUP);
    }
    if args.deform
        && let Err(e) = host::deform::body(&scene, args.object)
    {
        return fail(&anyhow::Error::new(e), EXIT_BAD_SETUP);
    }
    if args.plot.as_ref() == Some(&args.out) {
        let e = anyhow!(
            "--plot and --out both name {}; the run log and the plot need two files",
            args.out.display()
        );
        return fail(&e, EXIT_BAD_SETUP);
    }
    // Before the run, so that a bad output path does not wait for it. Both outputs are
    // written to temporary files and renamed over their targets only when both are complete:
    // a failure anywhere leaves an existing run log and plot as they were.
    let (out, plot_file) = match create_outputs(&args.out, args.plot.as_deref()) {
        Ok(files) => files,
        Err(e) => return fail(&e, EXIT_BAD_INPUT),
    };
    // Ctrl-C or SIGTERM ends the run after the tick it is on; the ticks so far are written.
    let interrupt = interrupt_or_default("sim");
    let mut shown = 0;
    let progress = |done: usize, total: usize| {
        let tenths = done * 10 / total.max(1);
        if tenths > shown {
            shown = tenths;
            eprintln!("sim: {:>3}% ({done}/{total} ticks)", tenths * 10);
        }
        if interrupt.requested() {
            std::ops::ControlFlow::Break(())
        } else {
            std::ops::ControlFlow::Continue(())
        }
    };
    let rate_hz = args.rate_hz();
    let result = if args.device && args.deform {
        host::deform::run_device(
            &scene,
            args.object,
            &trajectory,
            rate_hz,
            args.device_hand(),
            progress,
        )
        .map(|device_run| device_run.run)
        .map_err(anyhow::Error::new)
    } else if args.device {
        host::closed_loop::run_device_on(
            &spec,
            &scene,
            args.object,
            &trajectory,
            rate_hz,
            args.device_hand(),
            progress,
        )
        .map(|device_run| {
            if device_run.passivity_control {
                let m = &device_run.run.material;
                eprintln!(
                    "sim: note: K = {} N/m with b = {} N·s/m exceeds what the device renders \
                     passively at {} Hz; the passivity controller is on",
                    m.stiffness_n_per_m, m.damping_ns_per_m, rate_hz
                );
            }
            device_run.run
        })
        .map_err(anyhow::Error::new)
    } else if args.deform {
        host::deform::run(&scene, args.object, &trajectory, rate_hz, progress)
            .map_err(anyhow::Error::new)
    } else {
        sim::run(&scene, args.object, &trajectory, args.rate_hz(), progress)
            .map_err(anyhow::Error::new)
    };
    let run = match result {
        Ok(run) => run,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    if let Some(signal) = interrupt.signal_name() {
        eprintln!(
            "sim: interrupted by {signal} after {} ticks (t = {} s); writing them",
            run.ticks.len(),
            run.ticks.last().map_or(0.0, |k| k.t_s)
        );
    }
    if let Err(e) = out
        .file()
        .and_then(|f| run.write_csv(f))
        .with_context(|| format!("cannot write {}", args.out.display()))
    {
        return fail(&e, EXIT_BAD_INPUT);
    }
    if let (Some(file), Some(path)) = (&plot_file, &args.plot) {
        // Drawn into the temporary file; errors name the file the user asked for.
        if let Err(e) = plot::write_png_as(&run, file.temp_path(), path, plot::DEFAULT_SIZE) {
            return fail(&anyhow::Error::new(e), EXIT_BAD_INPUT);
        }
    }
    let committed = out
        .commit()
        .with_context(|| format!("cannot write {}", args.out.display()))
        .and_then(|()| match (plot_file, &args.plot) {
            (Some(file), Some(path)) => file
                .commit()
                .with_context(|| format!("cannot write plot {}", path.display())),
            _ => Ok(()),
        });
    match committed {
        Ok(()) => interrupted_or_success(&interrupt),
        Err(e) => fail(&e, EXIT_BAD_INPUT),
    }
}
