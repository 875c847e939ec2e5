//! `viewer experiment run` and `viewer experiment analyze`: a plan run headless or with a participant at the screen, and its analysis.

use std::process::ExitCode;

use anyhow::{Context, anyhow};
use viewer::cli::{EXIT_BAD_INPUT, EXIT_BAD_SETUP};
use viewer::output::AtomicFile;

use crate::fail;
#[cfg(feature = "gui")]
use crate::{interrupt_or_default, interrupted_or_success};

pub(crate) fn experiment_command(command: &viewer::cli::ExperimentSubcommand) -> ExitCode {
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
    if args.device_spec.is_some() {
        let e = anyhow::anyhow!(
            "--device-spec describes a real participant's simulated pantograph; {} runs the \
             renderer alone, with no device",
            args.participant
        );
        return fail(&e, EXIT_BAD_SETUP);
    }
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

pub(crate) fn experiment_analyze_command(args: &viewer::cli::ExperimentAnalyzeArgs) -> ExitCode {
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
pub(crate) fn participant_command(args: &viewer::cli::ExperimentRunArgs) -> ExitCode {
    use experiment::error::RunError;
    use experiment::plan::Plan;
    use viewer::gui::participant::{ParticipantRun, run_window};
    if args.participant.trim().is_empty() {
        return fail(
            &anyhow!("--participant: give the participant's ID (P01), or sim:SEED"),
            EXIT_BAD_SETUP,
        );
    }
    // A bad device file is refused before the run's folder is touched.
    let spec = match crate::device_spec(args.device_spec.as_deref()) {
        Ok(spec) => spec,
        Err(code) => return code,
    };
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
    // Ctrl-C or SIGTERM pauses the run and closes the window, as Quit does; the answers so
    // far are in trials.csv and the same command resumes.
    let interrupt = interrupt_or_default("experiment run");
    match run_window(run, args.device.0.clone(), spec, Some(interrupt.clone())) {
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
            interrupted_or_success(&interrupt)
        }
        Err(e) => fail(&e, EXIT_BAD_INPUT),
    }
}

#[cfg(not(feature = "gui"))]
pub(crate) fn participant_command(args: &viewer::cli::ExperimentRunArgs) -> ExitCode {
    let e = anyhow!(
        "--participant {:?}: a real participant runs in the app, and this viewer was built \
         without its `gui` feature; rebuild with the default features, or run a simulated \
         participant (sim:SEED)",
        args.participant
    );
    fail(&e, EXIT_BAD_SETUP)
}
