//! `viewer`: see `viewer --help`.

use std::io::{self, Write};
use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, Result, anyhow};
use clap::Parser;
use host::sim::{self, Trajectory};
use scene::{Patch, Scene};
use viewer::cli::{
    Cli, CliCommand, ClosestArgs, EXIT_BAD_INPUT, EXIT_BAD_SETUP, EvalArgs, GuiArgs,
    PatchSelection, PlotArgs, SimArgs,
};
use viewer::closest;
use viewer::eval::{self, EvalError};
use viewer::interrupt::Interrupt;
use viewer::output::AtomicFile;
use viewer::plot;

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

fn experiment_command(command: &viewer::cli::ExperimentSubcommand) -> ExitCode {
    use experiment::error::RunError;
    use experiment::plan::Plan;
    use experiment::runner::run;
    use experiment::sim_participant::SimParticipant;
    use viewer::cli::ExperimentSubcommand;
    let args = match command {
        ExperimentSubcommand::Run(args) => args,
        ExperimentSubcommand::Analyze(args) => return experiment_analyze_command(args),
    };
    let participant = match SimParticipant::parse(&args.participant) {
        Some(Ok(p)) => p,
        Some(Err(e)) => return fail(&anyhow::Error::new(e), EXIT_BAD_SETUP),
        None => return participant_command(args),
    };
    let plan = match Plan::load(&args.plan)
        .with_context(|| format!("invalid plan {}", args.plan.display()))
    {
        Ok(plan) => plan,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    match run(&plan, &participant, &args.out) {
        Ok(summary) => {
            println!("experiment run: {summary}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            let code = match e {
                RunError::Unsupported(_)
                | RunError::Resume { .. }
                | RunError::NoReference
                | RunError::Staircase { .. }
                | RunError::Plan(_)
                | RunError::Scene { .. }
                | RunError::NoSurface { .. }
                | RunError::Trajectory(_) => EXIT_BAD_SETUP,
                RunError::Sim { .. }
                | RunError::NotFelt { .. }
                | RunError::NoTouch { .. }
                | RunError::Response(_)
                | RunError::TooManyTrials(_)
                | RunError::CreateDir { .. }
                | RunError::Write { .. } => EXIT_BAD_INPUT,
            };
            fail(&anyhow::Error::new(e), code)
        }
    }
}

fn experiment_analyze_command(args: &viewer::cli::ExperimentAnalyzeArgs) -> ExitCode {
    use experiment::analyze::{AnalyzeOptions, analyze, parse_model};
    let Some(model) = parse_model(&args.model) else {
        return fail(
            &anyhow!("--model {:?}: not a model", args.model),
            EXIT_BAD_SETUP,
        );
    };
    let options = AnalyzeOptions { model };
    let figure = args
        .figure
        .clone()
        .unwrap_or_else(|| args.dir.join("summary.png"));
    let summary = match analyze(&args.dir, &options) {
        Ok(s) => s,
        Err(e) => {
            let code = if e.is_bad_input() {
                EXIT_BAD_SETUP
            } else {
                EXIT_BAD_INPUT
            };
            return fail(&anyhow::Error::new(e), code);
        }
    };
    let drawn = AtomicFile::create(&figure)
        .with_context(|| format!("cannot create figure {}", figure.display()))
        .and_then(|file| {
            viewer::experiment_plot::write_png(&summary, file.temp_path(), &figure)?;
            file.commit()
                .with_context(|| format!("cannot write figure {}", figure.display()))
        });
    if let Err(e) = drawn {
        return fail(&e, EXIT_BAD_INPUT);
    }
    println!("experiment analyze: {summary}");
    ExitCode::SUCCESS
}

/// `experiment run` with a real participant: the app's participant screen
/// ([`viewer::gui::participant`]).
#[cfg(feature = "gui")]
fn participant_command(args: &viewer::cli::ExperimentRunArgs) -> ExitCode {
    use experiment::error::RunError;
    use experiment::plan::Plan;
    use viewer::gui::participant::{ParticipantRun, run_window};
    if args.participant.trim().is_empty() {
        return fail(
            &anyhow!("--participant: give the participant's ID (P01), or sim:SEED"),
            EXIT_BAD_SETUP,
        );
    }
    let plan = match Plan::load(&args.plan)
        .with_context(|| format!("invalid plan {}", args.plan.display()))
    {
        Ok(plan) => plan,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    let run = match ParticipantRun::open(plan, &args.participant, &args.out) {
        Ok(run) => run,
        Err(e) => {
            let code = match e {
                RunError::CreateDir { .. } | RunError::Write { .. } => EXIT_BAD_INPUT,
                _ => EXIT_BAD_SETUP,
            };
            return fail(&anyhow::Error::new(e), code);
        }
    };
    let session = run.session();
    if run.phase() == &viewer::gui::participant::Phase::Done {
        println!(
            "experiment run: {} holds all {} trials of the plan already; nothing to run",
            args.out.display(),
            session.answered()
        );
        return ExitCode::SUCCESS;
    }
    if session.resumed() > 0 {
        eprintln!(
            "experiment run: {} resumed at trial {} (session {})",
            args.out.display(),
            session.resumed() + 1,
            session.number()
        );
    }
    match run_window(run, args.device.0.clone()) {
        Ok(outcome) => {
            println!(
                "experiment run: {} trials answered{}",
                outcome.answered,
                if outcome.done {
                    ", the plan is done"
                } else {
                    "; run the same command again to resume"
                }
            );
            ExitCode::SUCCESS
        }
        Err(e) => fail(&e, EXIT_BAD_INPUT),
    }
}

#[cfg(not(feature = "gui"))]
fn participant_command(args: &viewer::cli::ExperimentRunArgs) -> ExitCode {
    let e = anyhow!(
        "--participant {:?}: a real participant runs in the app, and this viewer was built \
         without its `gui` feature; rebuild with the default features, or run a simulated \
         participant (sim:SEED)",
        args.participant
    );
    fail(&e, EXIT_BAD_SETUP)
}

fn deform_command(args: &viewer::cli::DeformArgs) -> ExitCode {
    use host::deform::{self, Load};
    let scene = match Scene::load(&args.scene).context("invalid scene") {
        Ok(scene) => scene,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    let setup = deform::body(&scene, args.object).and_then(|(object, body)| {
        let load = Load::parse(&args.load, object)?;
        let probe = match &args.probe {
            Some(p) => Some(deform::parse_probe(p, object)?),
            None => None,
        };
        Ok((object.space(), body, load, probe))
    });
    let (space, body, load, probe) = match setup {
        Ok(s) => s,
        Err(e) => return fail(&anyhow::Error::new(e), EXIT_BAD_SETUP),
    };
    match body.lowest_mode_hz() {
        Ok(f) => eprintln!("deform: lowest natural frequency {f:.4} Hz"),
        Err(e) => eprintln!("deform: no natural frequency: {e}"),
    }
    type Writer = Box<dyn FnOnce(&mut std::fs::File) -> Result<()>>;
    let (path, write): (&Path, Writer) = match (&args.out, &args.trace) {
        (Some(out), _) => {
            let (shaped, body) = match deform::static_shape(&scene, args.object, load) {
                Ok(s) => s,
                Err(e) => return fail(&anyhow::Error::new(e), EXIT_BAD_SETUP),
            };
            let largest = body
                .displacement()
                .iter()
                .map(|d| (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt())
                .fold(0.0, f64::max);
            eprintln!("deform: static: largest control-point displacement {largest:e} m");
            if let Some(plot) = &args.plot {
                let drawn = AtomicFile::create(plot)
                    .with_context(|| format!("cannot create plot {}", plot.display()))
                    .and_then(|file| {
                        viewer::deform_plot::write_png(
                            &scene.objects()[args.object],
                            &shaped.objects()[args.object],
                            load,
                            file.temp_path(),
                            plot,
                        )?;
                        file.commit()
                            .with_context(|| format!("cannot write plot {}", plot.display()))
                    });
                if let Err(e) = drawn {
                    return fail(&e, EXIT_BAD_INPUT);
                }
            }
            (
                out,
                Box::new(move |f| Ok(f.write_all(shaped.to_json_string().as_bytes())?)),
            )
        }
        (None, Some(trace_path)) => {
            let (Some(duration), Some(dt), Some(probe)) = (args.duration, args.dt, probe) else {
                return fail(&anyhow!("--release needs --duration, --dt and --probe"), 2);
            };
            let trace = match deform::release(&scene, args.object, load, duration, dt, probe) {
                Ok(t) => t,
                Err(e) => return fail(&anyhow::Error::new(e), EXIT_BAD_SETUP),
            };
            eprintln!("deform: release: {} steps", trace.len() - 1);
            (
                trace_path,
                Box::new(move |f| Ok(deform::write_trace(io::BufWriter::new(f), space, &trace)?)),
            )
        }
        (None, None) => return fail(&anyhow!("--static needs --out, --release --trace"), 2),
    };
    let out = match AtomicFile::create(path)
        .with_context(|| format!("cannot create {}", path.display()))
    {
        Ok(f) => f,
        Err(e) => return fail(&e, EXIT_BAD_INPUT),
    };
    let written = out
        .file()
        .map_err(anyhow::Error::from)
        .and_then(|mut f| write(&mut f))
        .and_then(|()| out.commit().map_err(anyhow::Error::from))
        .with_context(|| format!("cannot write {}", path.display()));
    match written {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => fail(&e, EXIT_BAD_INPUT),
    }
}

fn device_identify(args: &viewer::cli::DeviceIdentifyArgs) -> ExitCode {
    use device::spec::DeviceSpec;
    use host::devices::Target;
    use protocol::host_side::SimConfig;
    let spec = DeviceSpec::default();
    let opened = match args.device.target() {
        // Nobody holds the simulated handle, and it runs as fast as the host reads.
        Some(Target::Sim) => host::devices::open_sim(SimConfig {
            paced: false,
            released: true,
            ..SimConfig::default()
        })
        .context("the simulated device"),
        Some(target) => {
            host::devices::open(&target).with_context(|| format!("cannot open {target:?}"))
        }
        None => Err(anyhow!("device identify: {}", viewer::cli::CHOOSE_A_DEVICE)),
    };
    let mut link = match opened {
        Ok(opened) => opened.link,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    eprintln!("device identify: exciting the joints for 6 s; keep your hands off the handle");
    match host::identify::identify_link(link.as_mut(), &spec, &host::identify::EXCITATION) {
        Ok(found) => print_identified(&found, &spec, None),
        Err(e) => fail(
            &anyhow::Error::new(e).context("device identify"),
            EXIT_BAD_SETUP,
        ),
    }
}

fn identify_command(args: &viewer::cli::IdentifyArgs) -> ExitCode {
    use device::spec::DeviceSpec;
    use host::identify::{EXCITATION, identify_simulated};
    let default = DeviceSpec::default();
    let truth = DeviceSpec {
        joint_damping_nms_per_rad: args
            .damping
            .map_or(default.joint_damping_nms_per_rad, |b| [b; 2]),
        joint_coulomb_nm: args.coulomb.map_or(default.joint_coulomb_nm, |c| [c; 2]),
        ..default
    };
    let found = match identify_simulated(
        truth,
        device::simulator::SimParams::default(),
        nurbs::Vec2::new(0.0, 0.09),
        &EXCITATION,
        10_000.0,
    ) {
        Ok(found) => found,
        Err(e) => return fail(&anyhow::Error::new(e).context("identify"), EXIT_BAD_SETUP),
    };
    print_identified(&found, &truth, Some(&truth))
}

/// Prints what an identification found (against `truth` when it is known: a simulation),
/// what it means at the handle and the walls it lets the device render.
fn print_identified(
    found: &host::identify::IdentifiedJoints,
    spec: &device::spec::DeviceSpec,
    truth: Option<&device::spec::DeviceSpec>,
) -> ExitCode {
    use device::safety::SafetyConfig;
    use device::wall::{PassivityConfig, WallLimits};
    for i in 0..2 {
        let known = |value: f32| match truth {
            Some(_) => format!(" (simulator {value:.3e})"),
            None => String::new(),
        };
        println!(
            "joint {}: damping {:.3e} N m s/rad{}, Coulomb {:.3e} N m{}, {} samples",
            i + 1,
            found.damping_nms_per_rad[i],
            known(truth.map_or(0.0, |t| t.joint_damping_nms_per_rad[i])),
            found.coulomb_nm[i],
            known(truth.map_or(0.0, |t| t.joint_coulomb_nm[i])),
            found.samples[i]
        );
    }
    let identified = found.apply(spec);
    let at_handle = match identified.at_handle() {
        Ok(h) => h,
        Err(e) => return fail(&anyhow!("the identified description: {e}"), EXIT_BAD_SETUP),
    };
    println!(
        "at the handle (worst pose): damping {:.4} N s/m, Coulomb friction {:.4} N, {:.1} um per count",
        at_handle.damping_n_s_per_m,
        at_handle.coulomb_n,
        at_handle.resolution_m * 1e6
    );
    let passivity = PassivityConfig {
        device: at_handle,
        ..SafetyConfig::default().passivity
    };
    for rate_hz in [1000.0f32, 10_000.0] {
        let limits = WallLimits::new(&passivity, 0.0, 1.0 / rate_hz);
        let (alone, _) = limits.max(false);
        let (with, _) = limits.max(true);
        println!(
            "{rate_hz:.0} Hz: walls up to {alone:.0} N/m (passivity {:.0}, quantisation {:.0}), \
             {with:.0} N/m with the passivity controller (B = 0)",
            limits.passive_n_per_m, limits.quantisation_n_per_m
        );
    }
    ExitCode::SUCCESS
}

fn zwidth_command(args: &viewer::cli::ZwidthArgs) -> ExitCode {
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

fn closest_command(args: &ClosestArgs) -> ExitCode {
    let scene = match Scene::load(&args.scene).context("invalid scene") {
        Ok(scene) => scene,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    let Some(object) = scene.object(args.object) else {
        let n = scene.objects().len();
        let e = anyhow!(
            "--object {}: {} has {n} object(s), indices 0..={}",
            args.object,
            args.scene.display(),
            n.saturating_sub(1)
        );
        return fail(&e, EXIT_BAD_SETUP);
    };
    match closest::run(object, io::stdin().lock(), io::stdout().lock()) {
        Ok(_) => ExitCode::SUCCESS,
        Err(EvalError::Write(e)) if e.kind() == io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
        Err(e) => fail(
            &anyhow::Error::new(e).context(format!(
                "closest on object {} ({:?})",
                args.object,
                object.name()
            )),
            EXIT_BAD_INPUT,
        ),
    }
}

#[cfg(feature = "gui")]
fn gui_command(args: &GuiArgs) -> ExitCode {
    // The scene is checked before the window opens, so that a bad one is a setup error.
    if let Some(path) = &args.scene
        && let Err(e) = Scene::load(path).context("invalid scene")
    {
        return fail(&e, EXIT_BAD_SETUP);
    }
    if let Some(path) = &args.mesh
        && let Err(e) = viewer::gui::surface_scene::load_mesh(path).context("invalid mesh")
    {
        return fail(&e, EXIT_BAD_SETUP);
    }
    if let Some(path) = &args.record
        && let Err(e) = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .with_context(|| format!("cannot create the record file {}", path.display()))
    {
        return fail(&e, EXIT_BAD_SETUP);
    }
    let options = viewer::gui::GuiOptions {
        scene: args.scene.clone(),
        record: args.record.clone(),
        quit_after_frames: args.quit_after_frames,
        device: args.device.0.clone(),
        demo: args.demo,
        mesh: args.mesh.clone(),
        // Ctrl-C or SIGTERM closes the window as a click would; the recording is completed.
        interrupt: Some(interrupt_or_default("viewer gui")),
    };
    let interrupt = options.interrupt.clone().unwrap_or_default();
    match viewer::gui::run(options) {
        Ok(summary) => {
            eprintln!("viewer gui: {summary}");
            interrupted_or_success(&interrupt)
        }
        Err(e) => fail(&e, EXIT_BAD_INPUT),
    }
}

#[cfg(not(feature = "gui"))]
fn gui_command(_: &GuiArgs) -> ExitCode {
    let e = anyhow!(
        "this viewer was built without its `gui` feature; use a subcommand (viewer --help) \
         or rebuild with the default features"
    );
    fail(&e, EXIT_BAD_SETUP)
}

fn plot_command(args: &PlotArgs) -> ExitCode {
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

fn eval_command(args: &EvalArgs) -> ExitCode {
    let scene = match Scene::load(&args.scene).context("invalid scene") {
        Ok(scene) => scene,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    let (label, patch) = match select(&scene, &args.scene, args.select) {
        Ok(selected) => selected,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    match eval::run(patch, io::stdin().lock(), io::stdout().lock()) {
        Ok(_) => ExitCode::SUCCESS,
        // The reader went away (`| head`): not an error of ours.
        Err(EvalError::Write(e)) if e.kind() == io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
        Err(e) => fail(
            &anyhow::Error::new(e).context(format!("eval of {label}")),
            EXIT_BAD_INPUT,
        ),
    }
}

fn sim_command(args: &SimArgs) -> ExitCode {
    let scene = match Scene::load(&args.scene).context("invalid scene") {
        Ok(scene) => scene,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    let trajectory = match Trajectory::load(&args.trajectory).context("invalid trajectory") {
        Ok(t) => t,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    let checked = if args.device {
        host::closed_loop::validate_device(&scene, args.object, &trajectory, args.rate_hz())
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
    let out = match AtomicFile::create(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))
    {
        Ok(f) => f,
        Err(e) => return fail(&e, EXIT_BAD_INPUT),
    };
    let plot_file = match args.plot.as_ref().map(|path| {
        AtomicFile::create(path).with_context(|| format!("cannot create plot {}", path.display()))
    }) {
        None => None,
        Some(Ok(f)) => Some(f),
        Some(Err(e)) => return fail(&e, EXIT_BAD_INPUT),
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
        host::closed_loop::run_device(
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

/// [`Interrupt::install`], or, if the handlers cannot be installed, a flag that never rises
/// (Ctrl-C then ends `command` as it would without them).
fn interrupt_or_default(command: &str) -> Interrupt {
    Interrupt::install().unwrap_or_else(|e| {
        eprintln!(
            "{command}: warning: cannot handle Ctrl-C and SIGTERM ({e}); they end it at once"
        );
        Interrupt::default()
    })
}

/// The exit status of a command that finished its output: 128 + the signal's number if a
/// signal stopped it (130 SIGINT, 143 SIGTERM), else 0.
fn interrupted_or_success(interrupt: &Interrupt) -> ExitCode {
    interrupt
        .exit_code()
        .map_or(ExitCode::SUCCESS, ExitCode::from)
}

/// The selected patch and a label naming it: `object 1 ("circle"), patch 0 (planar curve)`.
fn select<'a>(scene: &'a Scene, file: &Path, sel: PatchSelection) -> Result<(String, &'a Patch)> {
    let objects = scene.objects().len();
    let object = scene.object(sel.object).ok_or_else(|| {
        anyhow!(
            "--object {}: {} has {objects} object(s), indices 0..={}",
            sel.object,
            file.display(),
            objects.saturating_sub(1)
        )
    })?;
    let patches = object.patches().len();
    let patch = object.patch(sel.patch).ok_or_else(|| {
        anyhow!(
            "--patch {}: object {} ({:?}) has {patches} patch(es), indices 0..={}",
            sel.patch,
            sel.object,
            object.name(),
            patches.saturating_sub(1)
        )
    })?;
    let label = format!(
        "object {} ({:?}), patch {} ({})",
        sel.object,
        object.name(),
        sel.patch,
        patch.kind()
    );
    Ok((label, patch))
}

fn fail(error: &anyhow::Error, code: u8) -> ExitCode {
    let _ = writeln!(io::stderr(), "error: {error:#}");
    ExitCode::from(code)
}

fn device_command(command: &viewer::cli::DeviceSubcommand) -> ExitCode {
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
    }
}

#[cfg(unix)]
fn device_sim_pty(args: &viewer::cli::SimPtyArgs) -> ExitCode {
    use protocol::host_side::{SimConfig, SimLink};
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};
    let pty = match protocol::host_side::pseudo_terminal().context("cannot open a pseudo-terminal")
    {
        Ok(pty) => pty,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    let sim = match SimLink::spawn(SimConfig::default()).context("cannot start the simulator") {
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
fn device_sim_pty(_: &viewer::cli::SimPtyArgs) -> ExitCode {
    fail(
        &anyhow!("device sim-pty: pseudo-terminals need Linux or macOS"),
        EXIT_BAD_SETUP,
    )
}

fn device_monitor(args: &viewer::cli::MonitorArgs) -> ExitCode {
    use std::time::Duration;
    use viewer::device_report;
    let Some(target) = args.device.target() else {
        let e = anyhow!("device monitor: {}", viewer::cli::CHOOSE_A_DEVICE);
        return fail(&e, EXIT_BAD_SETUP);
    };
    let mut opened =
        match host::devices::open(&target).with_context(|| format!("cannot open {target:?}")) {
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
