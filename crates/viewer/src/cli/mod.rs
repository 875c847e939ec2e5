//! The command line, as clap types. `main.rs` runs it; without a subcommand it starts the
//! GUI (`viewer gui`).

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

mod device;
pub use device::*;

/// Exit status: an input line was bad (not a number, wrong count, outside the domain; `eval`)
/// or the output could not be written.
pub const EXIT_BAD_INPUT: u8 = 1;
/// Exit status: the command line, the scene file, the trajectory file or the object/patch
/// index was invalid.
pub const EXIT_BAD_SETUP: u8 = 2;

const EXIT_CODES: &str = "\
Exit status:
  0  success
  1  a bad input line (eval), or the output could not be written
  2  bad command line, unreadable or invalid scene or trajectory, bad --object/--patch
     index
  130, 143  sim, gui, device monitor and experiment run --participant: stopped by Ctrl-C
     (SIGINT) or SIGTERM, their output written up to there in whole rows (a participant's
     run paused as Quit does, resumable); a second signal ends them at once

Without a subcommand the desktop app starts (`viewer gui` on the bundled thesis-2d scene).";

/// Haptic rendering of NURBS models: the desktop viewer and headless tools.
#[derive(Debug, Parser)]
#[command(name = "viewer", version, after_help = EXIT_CODES)]
pub struct Cli {
    /// What to do. Without a subcommand the desktop GUI starts (`viewer gui`).
    #[command(subcommand)]
    pub command: Option<CliCommand>,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum CliCommand {
    /// Evaluate one patch of a scene at parameters read from standard input.
    #[command(long_about = EVAL_ABOUT, after_long_help = EVAL_AFTER)]
    Eval(EvalArgs),
    /// Closest points of one object to query points read from standard input.
    #[command(long_about = CLOSEST_ABOUT, after_long_help = CLOSEST_AFTER)]
    Closest(ClosestArgs),
    /// Simulate the haptic loop along a prescribed HIP trajectory and write a run log.
    #[command(long_about = SIM_ABOUT, after_long_help = SIM_AFTER)]
    Sim(SimArgs),
    /// Talk to a haptic device: list the boards, monitor telemetry.
    #[command(subcommand)]
    Device(DeviceSubcommand),
    /// The desktop app: feel a scene with the mouse on the simulated pantograph (the default
    /// without a subcommand).
    #[command(long_about = GUI_ABOUT, after_long_help = GUI_AFTER)]
    Gui(GuiArgs),
    /// Draw a run log (from `sim --out` or `gui --record`) as a PNG, as `sim --plot` does.
    #[command(after_long_help = PLOT_AFTER)]
    Plot(PlotArgs),
    /// Sweep wall stiffness and damping through the simulated pantograph: which walls stay
    /// stable (the Z-width), with and without the passivity controller.
    #[command(after_long_help = ZWIDTH_AFTER)]
    Zwidth(ZwidthArgs),
    /// Measure the pantograph's own damping and Coulomb friction at the joints (on the
    /// simulated pantograph) and the walls they let it render.
    #[command(after_long_help = IDENTIFY_AFTER)]
    Identify(IdentifyArgs),
    /// Deformable objects (a scene's "dynamics" block): the static shape under a load, or the
    /// motion after the load is removed.
    #[command(after_long_help = DEFORM_AFTER)]
    Deform(DeformArgs),
    /// Psychophysics experiments (plans of format `experiment/1`).
    #[command(subcommand)]
    Experiment(ExperimentSubcommand),
}

/// `experiment …` subcommands.
#[derive(Debug, Subcommand)]
pub enum ExperimentSubcommand {
    /// Run a plan: headless with a simulated participant, or in the app's participant
    /// screen with a real one.
    #[command(after_long_help = EXPERIMENT_RUN_AFTER)]
    Run(ExperimentRunArgs),
    /// Analyse a run folder (plan.json, trials.csv): summary.json, a figure, one paragraph.
    #[command(after_long_help = EXPERIMENT_ANALYZE_AFTER)]
    Analyze(ExperimentAnalyzeArgs),
}

const EXPERIMENT_ANALYZE_AFTER: &str = "\
Reads DIR/plan.json (the plan as run) and DIR/trials.csv (one row per trial, header \
participant,session,block,trial,practice,design,stimulus,condition,staircase,level,reference,\
comparison_interval,response,correct,response_time_s,trace,t_start_s). Practice rows are not \
analysed. Every row is checked against the plan; an error names the file, line and column.

identification: per condition, the accuracy, the confusion matrix (rows presented, columns \
answered, in the plan's stimulus order) and the accuracy per stimulus; with two conditions, \
Fisher's exact test (two-sided) of their accuracies.

2afc-staircase, constant-stimuli: levels below the reference r are folded onto its upper \
side (r^2/x); the proportion correct per folded level is fitted by maximum likelihood as a \
function of the log ratio d = |ln(x/r)|, 0.5 at the reference (guess rate 0.5, lapse rate \
in [0, 0.1]): --model weibull (default) 1 - exp(-(d/a)^b), log-gaussian Phi(b ln(d/a)), \
gaussian 2 Phi((d/a)^b) - 1. The Weber fraction at 75 % correct (threshold / r - 1, above 0) \
gets a 95 % credible interval, the central 95 % of its Bayesian posterior under psignifit 4's \
default priors; each staircase's track and reversals (the staircase's own, replayed on the \
answers) are listed.

Written: DIR/summary.json (its fields are documented in the experiment crate's analyze \
module) and the figure (--figure, default DIR/summary.png): the confusion matrices as heat \
maps, or the staircase tracks and the fitted psychometric function. Standard output gets one \
paragraph: the accuracy per condition and Fisher's p, or the Weber fraction with its interval.

Exit status:
  0  analysed and written
  1  summary.json or the figure could not be written
  2  bad command line, a missing or invalid plan.json or trials.csv (wrong header, a bad \
     number, an unknown stimulus, a duplicate trial, a design other than the plan's)

Example:
  viewer experiment analyze runs/sim1 --model log-gaussian";

/// `viewer experiment analyze` arguments.
#[derive(Debug, Args)]
pub struct ExperimentAnalyzeArgs {
    /// The run folder (plan.json and trials.csv, as `experiment run` writes them).
    #[arg(value_name = "DIR")]
    pub dir: PathBuf,
    /// The psychometric function of 2AFC designs, of the log ratio to the reference.
    #[arg(long, value_name = "MODEL", default_value = "weibull", value_parser = ["gaussian", "log-gaussian", "weibull"])]
    pub model: String,
    /// The figure (PNG; default DIR/summary.png).
    #[arg(long, value_name = "PATH")]
    pub figure: Option<PathBuf>,
}

const EXPERIMENT_RUN_AFTER: &str = "\
A real participant (any --participant that does not start with sim:, e.g. P01) runs in the \
app's participant screen, on the device --device names. Each trial's scene is loaded into \
the haptic loop as the app loads any scene (uploaded to a connected board); the screen never \
draws the object, only the hand's cursor, the trial's number and progress, the exploration \
timer (the plan's exploration_time_s, for the whole trial: when it runs out the forces go \
off and the answer is asked) and the answer buttons: one per stimulus in the plan's order (keys 1-9) for \
identification; \"first was stiffer\" / \"second was stiffer\" (keys F/S or left/right) \
for 2AFC, whose two intervals the participant switches between at will (buttons, keys 1/2). \
Enter ends the exploration early; the response time runs from the end of the exploration to \
the answer. Practice trials say whether the answer was right (Enter: next trial), test trials \
say nothing. Pause (P or Esc) turns the forces off until Resume (P or Enter); Quit closes \
the window, and running the same command again resumes at the next unanswered trial (the \
trial in progress is presented again). Before the first trial the screen waits for Start, \
with the device's state, Calibrate and Clear faults for the experimenter.

A simulated participant (sim:...) runs headless. Any design runs (identification, \
2afc-staircase, constant-stimuli), practice trials first. \
2AFC: each trial presents the reference and the comparison in a random order; both are \
explored by the same press (straight down at x = 0 from 10 mm above the object's top to 2 mm \
past its surface in 0.5 s, back up in 0.2 s, at 1 kHz through the simulated loop); the \
participant feels each interval's stiffness from the rendered positions and forces and says \
which was stiffer, with the noise that puts its 75 % point at the Weber fraction W (default \
0.15). Identification: the participant taps the object at nine points across the stimuli's \
common box (down at 50 mm/s until the force reaches 1 N), notes where each tap touched and \
which way the force pushed, and names the stimulus whose picture fits best, with position \
noise A mm (default 1) and direction noise D degrees (default 10). A lapse rate L (default 0) \
answers at random.

Written to --out (created if missing; a folder holding this plan's run by the same \
participant is resumed at its next trial): trials.csv (one row per trial), \
traces/trial-NNNN-a.csv (and -b.csv for 2AFC: each interval's run log; a real participant's \
are the ticks felt while the stimulus was on, in the columns of gui --record) and plan.json \
(the plan with absolute scene paths). A simulated run prints one line: the trials, the \
proportion correct and each staircase's threshold (the mean of its last reversals); a real \
participant's prints the trials answered when the window closes.

Exit status:
  0  the plan ran to its end (or, for a real participant, the window was closed)
  1  the output could not be written, a trial failed, or the app's window could not open
  2  bad command line, unreadable or invalid plan, a folder holding another run, a
     participant sim:... that is not sim:SEED[:weber=W][:lapse=L][:acuity_mm=A][:direction_deg=D]

Examples:
  viewer experiment run experiments/stiffness-jnd.json --participant sim:1:weber=0.2 \\
      --out runs/sim1
  viewer experiment run experiments/thesis-shapes.json --participant P01 --out runs/P01 \\
      --device hid";

/// `viewer experiment run` arguments.
#[derive(Debug, Args)]
pub struct ExperimentRunArgs {
    /// The plan (JSON, format `experiment/1`).
    #[arg(value_name = "PLAN.json")]
    pub plan: PathBuf,
    /// Who answers: sim:SEED[:weber=W][:lapse=L][:acuity_mm=A][:direction_deg=D] (a
    /// simulated participant, headless), or a real participant's ID (P01: the app's
    /// participant screen).
    #[arg(long, value_name = "PARTICIPANT")]
    pub participant: String,
    /// The folder the run is written to.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// A real participant's device: `sim` (the simulated pantograph in the app, moved with
    /// the mouse), `hid`, `serial:PATH` or `tcp:HOST:PORT`, as for `viewer gui`.
    #[arg(long, value_name = "DEVICE", default_value = "sim", value_parser = gui_device)]
    pub device: GuiDevice,
    /// A real participant's simulated pantograph (`--device sim`), a `device/1` file
    /// (`viewer device spec` prints the default). A simulated participant runs the renderer
    /// alone, with no device to describe.
    #[arg(long, value_name = "FILE")]
    pub device_spec: Option<PathBuf>,
}

const DEFORM_AFTER: &str = "\
The object must have a \"dynamics\" block (D-NURBS: mass, damping, tension and bending per \
unit rest length or area, fixed points; see the scene format). Loads:
  uniform:FX,FY[,FZ]          force per unit rest length (N/m) of a curve or area (N/m^2) of
                              a surface, everywhere (FZ for spatial curves and surfaces)
  point:U[,V],FX,FY[,FZ]      a force (N) at the parameter U (curves) or U,V (surfaces)

--static solves K (p - p0) = f for the equilibrium under the load and writes the scene with
the object in that shape to --out (a scene/1 file; read again, that shape is its rest shape);
--plot draws a planar curve's rest and deformed shapes with the load's forces (red arrows,
ending where they push) into a PNG.
--release starts from that equilibrium, removes the load at t = 0 and steps the object
(Newmark's average acceleration) every --dt seconds for --duration seconds, writing the
point at --probe to --trace, one row per step: t_s,x,y (planar curves) or t_s,x,y,z.

Standard error gets the object's lowest natural frequency (Hz) and the largest displacement.

Exit status:
  0  written
  1  the output could not be written
  2  bad command line, unreadable or invalid scene, an object without dynamics, a load or
     probe of the wrong shape or outside the patch's domain, an object not held against the
     load (fix more points)

Example:
  viewer deform scenes/deformable.json --load uniform:0,-2 --static --out sagged.json
  viewer deform scenes/deformable.json --load point:0.5,0,-0.5 --release --duration 0.2 \\
      --dt 1e-4 --probe 0.5 --trace ring.csv";

/// `viewer deform` arguments.
#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("mode").required(true).args(["static_", "release"])))]
pub struct DeformArgs {
    /// Scene file (JSON, format `scene/1`).
    #[arg(value_name = "SCENE")]
    pub scene: PathBuf,
    /// Index of the object in the scene's `objects` array, from 0.
    #[arg(long, value_name = "I", default_value_t = 0)]
    pub object: usize,
    /// The load: uniform:FX,FY[,FZ] or point:U[,V],FX,FY[,FZ] (see below).
    #[arg(long, value_name = "LOAD", allow_hyphen_values = true)]
    pub load: String,
    /// Write the equilibrium shape under the load (a scene/1 file) to --out.
    #[arg(long = "static", requires = "out")]
    pub static_: bool,
    /// Where --static writes the deformed scene.
    #[arg(long, value_name = "DEFORMED.json", requires = "static_")]
    pub out: Option<PathBuf>,
    /// With --static, for a planar curve: also draw the rest shape, the deformed shape and
    /// the load into this PNG file.
    #[arg(long, value_name = "SHAPE.png", requires = "static_")]
    pub plot: Option<PathBuf>,
    /// Remove the load at t = 0 and trace the motion.
    #[arg(long, requires_all = ["duration", "dt", "probe", "trace"])]
    pub release: bool,
    /// With --release: how long to run (s).
    #[arg(
        long,
        value_name = "S",
        requires = "release",
        allow_negative_numbers = true
    )]
    pub duration: Option<f64>,
    /// With --release: the step (s).
    #[arg(
        long,
        value_name = "S",
        requires = "release",
        allow_negative_numbers = true
    )]
    pub dt: Option<f64>,
    /// With --release: the parameter whose point is traced, U (curves) or U,V (surfaces).
    #[arg(
        long,
        value_name = "U[,V]",
        requires = "release",
        allow_hyphen_values = true
    )]
    pub probe: Option<String>,
    /// With --release: where the trace goes (CSV).
    #[arg(long, value_name = "TRACE.csv", requires = "release")]
    pub trace: Option<PathBuf>,
}

const IDENTIFY_AFTER: &str = "\
Nobody holds the handle; both motors apply square waves of torque (8 and 7 mN m, half-periods \
of 150 and 210 ms) for 6 s at 10 kHz, and the encoders are read every tick. Joint rates and \
accelerations come from quadratics fitted over 20 ms of the quantised angles; per joint, \
torque = M theta'' + b theta' + tau_c sign(theta') (with the mass matrix, its change with the \
pose and the velocity products) is solved by least squares. The run is on the simulated \
pantograph, whose true damping and friction are the device description's, or the values \
given with --damping and --coulomb: the output compares them. Then it prints what the \
identified values mean at the handle (the worst pose of the workspace) and the stiffest \
wall accepted at 1 and 10 kHz, with and without the passivity controller.

A board (or the firmware under QEMU) is identified through the protocol with `viewer device \
identify`: the same square waves of torque, asked of the device with its Excite message.";

/// `viewer identify` arguments.
#[derive(Debug, Args)]
pub struct IdentifyArgs {
    /// The simulated joints' true viscous damping (N m s/rad), both joints.
    #[arg(
        long,
        value_name = "NMS_PER_RAD",
        value_parser = non_negative,
        allow_negative_numbers = true
    )]
    pub damping: Option<f32>,
    /// The simulated joints' true Coulomb friction torque (N m), both joints.
    #[arg(
        long,
        value_name = "NM",
        value_parser = non_negative,
        allow_negative_numbers = true
    )]
    pub coulomb: Option<f32>,
    /// The simulated device, a `device/1` file (`viewer device spec` prints the default);
    /// --damping and --coulomb replace its joints' values.
    #[arg(long, value_name = "FILE")]
    pub device_spec: Option<PathBuf>,
}

fn non_negative(text: &str) -> Result<f32, String> {
    let v: f32 = text
        .trim()
        .parse()
        .map_err(|_| format!("{text:?} is not a number"))?;
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(format!("{v} must be finite and >= 0"))
    }
}

const ZWIDTH_AFTER: &str = "\
Each cell is an impact at --speed (default 0.1 m/s) on a straight frictionless wall, then 0.6 s \
of hold, on the device's own controller closed through the simulated pantograph (zero-order \
hold, a tick of delay, encoder quantisation, the device's Coulomb friction and damping, torque \
saturation). --hand grip keeps a relaxed grip pushing 1 mm into the wall, --hand finger a light \
fingertip (100 N/m, 0.1 N·s/m), --hand released lets go 1 mm before the wall. A cell is stable \
when the force over the last 0.2 s varies by at most one encoder count's worth (K Δ) and a \
released handle leaves with no more kinetic energy than it brought. The grid is K = 100 … \
10,000 N/m (13 values) × B = 0 … 2 N·s/m (6), with the controller off and on. The CSV has \
one row per cell; the PNG draws the device's passivity bound 2 (b + f_c/v − B)/T and its \
quantisation bound 2 f_c/Δ over the cells.";

/// `viewer zwidth` arguments.
#[derive(Debug, Args)]
pub struct ZwidthArgs {
    /// Tick rate (Hz), 100 to 100,000.
    #[arg(long, default_value_t = 10_000.0, value_name = "HZ", value_parser = rate)]
    pub rate_hz: f64,
    /// Who holds the handle: grip, finger or released.
    #[arg(long, default_value = "released", value_name = "HAND")]
    pub hand: host::zwidth::Hand,
    /// Impact speed (m/s).
    #[arg(long, default_value_t = 0.1, value_name = "M_PER_S", value_parser = speed)]
    pub speed: f32,
    /// Where to write the cells (CSV).
    #[arg(long, value_name = "ZW.csv")]
    pub out: PathBuf,
    /// Where to draw the figure (PNG).
    #[arg(long, value_name = "ZW.png")]
    pub plot: Option<PathBuf>,
    /// The simulated pantograph's description, a `device/1` file (`viewer device spec`
    /// prints the default).
    #[arg(long, value_name = "FILE")]
    pub device_spec: Option<PathBuf>,
}

fn rate(text: &str) -> Result<f64, String> {
    let hz: f64 = text
        .parse()
        .map_err(|_| format!("{text:?} is not a number"))?;
    host::error::check_rate(hz).map_err(|e| e.to_string())?;
    // Each of the sweep's 156 cells runs about a second of device time: a rate past 100 kHz
    // would run for hours, below 100 Hz the plant's 1 m/s limit is a step of 10 mm.
    if !(100.0..=100_000.0).contains(&hz) {
        return Err(format!("{hz} Hz: the sweep runs at 100 to 100,000 Hz"));
    }
    Ok(hz)
}

fn speed(text: &str) -> Result<f32, String> {
    let v: f32 = text
        .parse()
        .map_err(|_| format!("{text:?} is not a number"))?;
    if v.is_finite() && v > 0.0 && v <= 0.3 {
        Ok(v)
    } else {
        Err(format!(
            "{v} m/s: the impact speed must be in (0, 0.3] m/s, the fastest the simulated hand moves"
        ))
    }
}

const GUI_ABOUT: &str = "\
The desktop app: the haptic loop (tracking, Voronoi feature switching, stick-slip friction, \
the device's safety layer) runs at the board's 10 kHz on its own thread on a simulated pantograph, held by \
a virtual hand that follows the mouse. Press and drag in the 2-D view to move the hand; the \
rendered force pushes the handle back, so sticking, breakaway and slipping show as you move.";

const GUI_AFTER: &str = "\
Without SCENE the bundled thesis-2d scene opens; the bundled scenes (thesis-2d, thesis-3d, \
examples, deformable, torus) are one click away in the app, and any scene file can be opened by its path. The \
device renders the first object of planar curves. A scene with none (surfaces) opens the 3-D \
view, where the hand is an impedance point moved in the view plane (shift + wheel or the \
wheel while held: depth) and felt through the friction renderer; --mesh FILE.obj opens a \
Wavefront mesh there, felt through the polygonal baseline.

--device picks what the app drives: sim (default) runs the simulated pantograph in the app; \
tcp:HOST:PORT connects to the firmware under QEMU (start it with `cargo xtask qemu --serve \
HOST:PORT`), whose simulated arm the mouse moves; hid and serial:PATH connect to a board, whose \
handle a real hand moves. The running scene is uploaded on connect and after every change (the \
device's upload: begin, chunks, commit); a board waits for Calibrate (handle at its end stops) \
and the forces switch. If the link drops, the app says so and the device's watchdog turns its \
forces off.

--record writes one run-log row per tick with the columns of `viewer sim --device` (see \
`viewer sim --help`), whole rows only, flushed at least every 0.5 s and completed when the \
window closes; `viewer plot` draws it. Ctrl-C (SIGINT) or SIGTERM closes the window as a \
click would, so the recording is completed (a second signal ends the app at once; the rows \
flushed by then are whole). The 3-D view's ticks go to a second log beside it, RUN.3d.csv, with \
the columns of `viewer sim` on a scene of surfaces. Each log's time runs on when a loop \
restarts (another scene, another device), so a recording stays one run at one rate.

When the window closes a line on standard error gives the frames drawn, the frame time, the \
loop's tick period and jitter, and the telemetry frames dropped.

Exit status:
  0  the window was closed
  1  the window could not be opened, or the recording could not be written
  130  Ctrl-C (SIGINT) closed the window (143: SIGTERM); the recording is complete
  2  bad command line (an unknown --device), unreadable or invalid scene, or a --record
     file that cannot be created

Examples:
  viewer
  viewer gui scenes/examples.json --record run.csv";

const PLOT_AFTER: &str = "\
Reads a run log with the header of `viewer sim --out` (2-D or 3-D, with or without the \
--device columns) and draws forces against time over coloured bands of the friction mode, and \
the joint torques for device logs. A run log carries no CP and GO parameters, so their panel \
of `sim --plot` is left out.

Exit status:
  0  plot written
  1  the plot could not be written
  2  bad command line, or an unreadable or invalid run log (the message names the line)

Example:
  viewer plot run.csv --out run.png";

/// Arguments of `gui`.
#[derive(Debug, Args, Default)]
pub struct GuiArgs {
    /// Scene file (JSON, format `scene/1`); the bundled thesis-2d scene without it.
    #[arg(value_name = "SCENE")]
    pub scene: Option<PathBuf>,
    /// The device: `sim` (the simulated pantograph in this process), `hid` (the first USB
    /// HID board), `serial:PATH` (a board on a serial port) or `tcp:HOST:PORT` (the firmware
    /// under QEMU, `cargo xtask qemu --serve HOST:PORT`).
    #[arg(long, value_name = "DEVICE", default_value = "sim", value_parser = gui_device)]
    pub device: GuiDevice,
    /// The simulated pantograph (`--device sim`), a `device/1` file (`viewer device spec`
    /// prints the default); a board runs the description it was built with.
    #[arg(long, value_name = "FILE")]
    pub device_spec: Option<PathBuf>,
    /// Record the telemetry to this run log (CSV) while the app runs.
    #[arg(long, value_name = "RUN.csv")]
    pub record: Option<PathBuf>,
    /// Close the window by itself after this many frames (for tests and CI).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    pub quit_after_frames: Option<u64>,
    /// Move the hand along the thesis's 2-D path (scenes/thesis-2d.csv), as a drag would.
    #[arg(long)]
    pub demo: bool,
    /// Open this Wavefront OBJ mesh instead of a scene: felt through the polygonal baseline
    /// (penalty along the closest triangle's face normal) in the 3-D view.
    #[arg(long, value_name = "FILE.obj", conflicts_with = "scene")]
    pub mesh: Option<PathBuf>,
}

/// The device of `viewer gui --device`: `None` for the simulated pantograph in the app.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct GuiDevice(pub Option<host::devices::Target>);

fn gui_device(text: &str) -> Result<GuiDevice, String> {
    parse_gui_device(text).map(GuiDevice)
}

/// Parses a `--device` of `viewer gui`.
pub fn parse_gui_device(text: &str) -> Result<Option<host::devices::Target>, String> {
    use host::devices::Target;
    let choices = "sim (the simulated pantograph in the app), hid (the first USB HID board), \
                   serial:PATH (a board on a serial port) or tcp:HOST:PORT (the firmware under \
                   QEMU: cargo xtask qemu --serve HOST:PORT)";
    match text {
        "sim" => Ok(None),
        "hid" => Ok(Some(Target::Hid)),
        t => match t.split_once(':') {
            Some(("serial", path)) if !path.is_empty() => Ok(Some(Target::Serial(path.into()))),
            Some(("tcp", address))
                if address
                    .rsplit_once(':')
                    .is_some_and(|(h, p)| !h.is_empty() && p.parse::<u16>().is_ok()) =>
            {
                Ok(Some(Target::Tcp(address.into())))
            }
            _ => Err(format!("{t:?} is not a device; choose {choices}")),
        },
    }
}

/// Arguments of `plot`.
#[derive(Debug, Args)]
pub struct PlotArgs {
    /// The run log (CSV).
    #[arg(value_name = "RUN.csv")]
    pub log: PathBuf,
    /// Where to write the PNG.
    #[arg(long, value_name = "RUN.png")]
    pub out: PathBuf,
}

const CLOSEST_ABOUT: &str = "\
Closest points of one object to query points read from standard input.

Reads one point per line: `x y` for an object of planar curves, `x y z` for an object of \
surfaces or of spatial curves (a wire) (metres, whitespace-separated, each within ±1e6). Blank lines and lines starting with `#` are \
skipped. For each point runs the global search (branch and bound over the patches' Bézier \
pieces, then Newton) on every patch and writes the nearest result as one JSON object on its \
own line, flushed at once.";

const CLOSEST_AFTER: &str = "\
Output fields:
  patch            index of the patch the closest point lies on
  u [, v]          its parameters (v only for surfaces)
  point            the closest point (m)
  distance         distance from the query to it (m)
  signed_distance  the distance, negative when the query is inside the object
  normal           unit outward normal of the patch at the closest point
A wire has no inside: its signed_distance is the distance, and its normal the unit vector
from the closest point towards the query.

Errors: a wrong number of values, a value that is not a finite number or lies outside ±1e6
(the coordinate range of scenes), or a malformed line stops the run with a message on
standard error naming the line number and its content; the lines before it have been
answered. No answer with a non-finite number is ever written.

Exit status:
  0  every line answered
  1  a bad input line, or the output could not be written
  2  bad command line, unreadable or invalid scene, or --object out of range

Example:
  printf '0.05 0.1\\n0 0.09\\n' | viewer closest scenes/examples.json --object 1";

/// Arguments of `closest`.
#[derive(Debug, Args)]
pub struct ClosestArgs {
    /// Scene file (JSON, format `scene/1`).
    #[arg(value_name = "SCENE")]
    pub scene: PathBuf,
    /// Index of the object in the scene's `objects` array, from 0.
    #[arg(long, value_name = "I", default_value_t = 0)]
    pub object: usize,
}

const EVAL_ABOUT: &str = "\
Evaluate one patch of a scene at parameters read from standard input.

Reads one query per line: `u` for a curve, `u v` for a surface (whitespace-separated \
numbers). Blank lines and lines starting with `#` are skipped. Writes one JSON object per \
query on its own line to standard output, flushed at once, so it can be used \
interactively or in a pipe.";

const EVAL_AFTER: &str = "\
Output fields (vectors are arrays of 2 or 3 numbers; metres, derivatives per parameter unit):
  curve:    u, p, du, duu, tangent, normal, curvature
            p = C(u), du = C'(u), duu = C''(u); unit tangent; unit normal (planar: tangent
            turned clockwise, outward on a counter-clockwise closed curve; spatial: principal
            normal); curvature in 1/m (planar: signed, > 0 turning counter-clockwise)
  surface:  u, v, p, du, dv, duu, duv, dvv, normal
            p = S(u,v) and its partial derivatives up to second order; unit normal
            S_u x S_v / |S_u x S_v| (finite limit where a derivative vanishes)

Errors: a parameter outside the patch's domain (the message gives the domain), a value that
is not a finite number, a wrong number of values or a malformed line stops the run with a
message on standard error naming the line number and its content; the lines before it have
been answered. No answer with a non-finite number is ever written (the scene's weights and
coordinates are held to ranges f32 evaluates finitely; see the scene errors).

Exit status:
  0  every line answered
  1  a bad input line, or the output could not be written
  2  bad command line, unreadable or invalid scene (the message names object, patch and
     field), or --object/--patch out of range

Example:
  printf '0\\n0.125\\n0.5\\n' | viewer eval scenes/examples.json --object 1 --patch 0";

/// Arguments of `eval`.
#[derive(Debug, Args)]
pub struct EvalArgs {
    /// Scene file (JSON, format `scene/1`).
    #[arg(value_name = "SCENE")]
    pub scene: PathBuf,
    /// Which patch.
    #[command(flatten)]
    pub select: PatchSelection,
}

const SIM_ABOUT: &str = "\
Simulate the haptic loop along a prescribed HIP trajectory and write a run log.

The HIP follows the trajectory, linearly interpolated and sampled at the tick rate from its \
first to its last time. Every tick runs the whole pipeline for one object of the scene: \
closest-point tracking with the Voronoi feature state machine, then the friction renderer \
with the object's material (the stick-slip algorithm of the thesis, or the model the \
material names); the HIP velocity is the backward difference of the sampled HIP. A 2-D \
trajectory needs an object of planar curves, a 3-D one an object of surfaces.";

const SIM_AFTER: &str = "\
Trajectory (--trajectory, CSV):
  a header line `t,x,y` (planar) or `t,x,y,z` (spatial), then one line per sample of as many
  comma-separated numbers: time in seconds, position in metres (device frame). Times strictly
  increase, all values are finite (times within f32, positions within ±1e6 m), at least two
  samples. Blank lines and lines starting with `#` are skipped. Example:
    t,x,y
    0.0, 0.0, 0.09
    0.5, 0.0, 0.078
    1.5, 0.02, 0.078

Run log (--out, CSV), one row per tick, with exactly these columns (the _z ones for 3-D):
  t_s                        time (s)
  hip_x,hip_y[,hip_z]        HIP position (m)
  cp_x,cp_y[,cp_z]           closest point on the object (m)
  go_x,go_y[,go_z]           god-object, where the force acts (m)
  patch                      active patch index, -1 when free
  mode                       free | stuck | transition | slip
  depth_m                    penetration depth (m), clamped at 0 (so 0 when free)
  normal_force_n             normal force (N), >= 0
  friction_force_n           friction force (N), signed along the patch tangent (direction
                             of increasing u; in 3-D of u or v, whichever the force lies
                             closer to)
  mu                         friction coefficient in use (0 when free)
  psi                        projection error of the GO in transition, of the CP otherwise
  force_x,force_y[,force_z]  total force on the HIP (N)
With --device five more columns follow:
  theta1_rad,theta2_rad      joint angles the controller measured from the encoders (rad)
  tau1_nm,tau2_nm            joint torques the motor currents produce (N m): J^T F of the
                             logged force at the logged angles (less if a current limit cut)
  faults                     latched safety faults, a decimal bitset: 1 numeric, 2 velocity,
                             4 encoder, 8 watchdog, 16 workspace, 32 thermal; 0 when none

Closed loop (--device): instead of the HIP, the trajectory moves the target of a virtual
hand that holds the handle of a simulated pantograph (the default device: rigid-body
dynamics, the joints' damping and Coulomb friction, encoder quantisation, current limits, a
tick of output delay), at the board's 10 kHz unless --rate-hz says otherwise. --hand grip (a
relaxed grip, 300 N/m and 2 N s/m; --hand-stiffness changes its spring), finger (a light
fingertip, 100 N/m, 0.1 N s/m) or released:T (the grip lets go at T s: nobody holds the
handle after). The device's controller calibrates on the end stops, enables forces (20 ms
ramp-in), gets a heartbeat every tick and renders the object's material if the device
renders it: the sampled-data passivity bound with the device's own damping and dry friction,
K < 2 (b + f_c/v - |B|)/T, and the encoder quantisation bound K <= 2 f_c/Delta (for the
default device about 350 N/m at 1 kHz, 1750 N/m at 10 kHz); past the first, the passivity
controller (an energy tank) renders it, as far as it is demonstrated (1700 N/m, |B| <= 1
N s/m; a note on standard error says so); past the quantisation bound, or the controller's,
it is refused (exit 2, naming the bound, its numbers and a rate that renders it, if any).
The force is the device's: at most 3 N, and none in free space. The hip_ columns are the
handle's actual position, force_ the force after the safety layer. Only objects of planar
curves (the pantograph is 2-DoF).

Deformable object (--deform): the object's \"dynamics\" block makes it a D-NURBS patch. Every
tick renders against its current shape; the rendered force, reversed, loads it at the contact
point (the contact's spring acts in the object's implicit step, the rest of the force
explicitly), it steps every floor(rate / 1000) ticks (every tick up to 2 kHz), and the
renderer (CP tracker, god-object, friction state) carries over onto each new shape, the
god-object moving with the point of the object it sits on. Two or three more columns follow:
  deform_x,deform_y[,deform_z]  the object's displacement from its rest shape at the CP (m)
With --device the object is fed the controller's rendering (the handle's true HIP) and the
controller is moved onto each new shape between two ticks, as a board is by the control-point
updates (ScenePoints) a host sends.

Plot (--plot, PNG): normal, friction and total force magnitude against time over coloured
bands of the mode (top), the CP and GO parameters against time (bottom); with --device also
the joint torques against time (a third panel).

The run log and the plot are written to temporary files beside them and renamed into place
only when both are complete: a run that fails leaves existing files as they were.

Ctrl-C (SIGINT) or SIGTERM stops the run after the tick it is on: the ticks run so far are
written as above (the run log in whole rows, and the plot), a line on standard error says so,
and the exit status is 130 (SIGINT) or 143 (SIGTERM). A second signal ends it at once, leaving
existing files as they were.

Progress goes to standard error, every 10%.

Exit status:
  0  run log (and plot) written
  1  the run log or the plot could not be written
  130  stopped by Ctrl-C (SIGINT), the ticks so far written; 143 by SIGTERM
  2  bad command line (--rate-hz must be finite and > 0, with it and its period within f32,
     and give at least 2 ticks), unreadable or invalid scene or
     trajectory (the message names the file and line), bad --object, or a trajectory whose
     dimension does not match the object, or --device with an object of surfaces, a
     trajectory that starts out of the device's reach, or a stiffness beyond the device

Example:
  viewer sim scenes/examples.json --object 1 --trajectory press.csv --out run.csv --plot run.png
  viewer sim scenes/thesis-2d.json --device --trajectory scenes/thesis-2d.csv --out run.csv
  viewer sim scenes/deformable.json --deform --trajectory scenes/deformable.csv --out run.csv";

/// Arguments of `sim`.
#[derive(Debug, Args)]
pub struct SimArgs {
    /// Scene file (JSON, format `scene/1`).
    #[arg(value_name = "SCENE")]
    pub scene: PathBuf,
    /// The HIP's path: CSV with a header `t,x,y` or `t,x,y,z` (see below).
    #[arg(long, value_name = "TRAJ.csv")]
    pub trajectory: PathBuf,
    /// Where to write the run log (CSV, one row per tick).
    #[arg(long, value_name = "RUN.csv")]
    pub out: PathBuf,
    /// Also draw the run into this PNG file.
    #[arg(long, value_name = "RUN.png")]
    pub plot: Option<PathBuf>,
    /// Tick rate in Hz (finite, > 0); the default is 1000, or with --device the board's
    /// 10000.
    #[arg(
        long = "rate-hz",
        value_name = "HZ",
        value_parser = tick_rate,
        allow_negative_numbers = true
    )]
    pub rate_hz_given: Option<f64>,
    /// Index of the object in the scene's `objects` array, from 0.
    #[arg(long, value_name = "I", default_value_t = 0)]
    pub object: usize,
    /// Close the loop through the simulated pantograph and the device's controller: the
    /// trajectory moves the virtual hand's target (see below).
    #[arg(long)]
    pub device: bool,
    /// With --device: who holds the handle: grip (a relaxed grip, 300 N/m, 2 N·s/m), finger
    /// (a light fingertip, 100 N/m, 0.1 N·s/m) or released:T (the grip lets go at T s).
    #[arg(
        long,
        value_name = "HAND",
        default_value = "grip",
        value_parser = host::hand::DeviceHand::parse,
        requires = "device"
    )]
    pub hand: host::hand::DeviceHand,
    /// With --device: the virtual hand's stiffness in N/m (finite, > 0), in place of the
    /// hand model's own.
    #[arg(
        long,
        value_name = "N_PER_M",
        value_parser = hand_stiffness,
        allow_negative_numbers = true,
        requires = "device"
    )]
    pub hand_stiffness: Option<f64>,
    /// The object deforms under the rendered force (its scene "dynamics" block): the force,
    /// reversed, loads it at the contact point, it steps at 1 kHz or faster, and the run log
    /// gets its displacement at the CP (see below).
    #[arg(long)]
    pub deform: bool,
    /// With --device: the simulated pantograph's description, a `device/1` file (`viewer
    /// device spec` prints the default). Not with --deform yet.
    #[arg(
        long,
        value_name = "FILE",
        requires = "device",
        conflicts_with = "deform"
    )]
    pub device_spec: Option<PathBuf>,
}

impl SimArgs {
    /// The tick rate: the one given, else 1 kHz, or the board's 10 kHz with --device.
    pub fn rate_hz(&self) -> f64 {
        self.rate_hz_given
            .unwrap_or(if self.device { 10_000.0 } else { 1000.0 })
    }

    /// The hand of a --device run: the model, with --hand-stiffness in place of its own.
    pub fn device_hand(&self) -> host::hand::DeviceHand {
        let mut hand = self.hand;
        if let Some(k) = self.hand_stiffness {
            hand.params.hand_stiffness_n_per_m = k as f32;
        }
        hand
    }
}

fn hand_stiffness(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        // The simulated hand computes in f32: the value must be a positive normal f32.
        Ok(k) if k.is_finite() && k > 0.0 && (k as f32).is_normal() => Ok(k),
        Ok(k) if k.is_finite() && k > 0.0 => Err(format!(
            "{k:e} N/m does not fit the f32 the simulation computes in (about {:e} to {:e})",
            f32::MIN_POSITIVE,
            f32::MAX
        )),
        Ok(k) => Err(format!("{k} is not a stiffness; it must be finite and > 0")),
        Err(e) => Err(format!("{e}")),
    }
}

fn tick_rate(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(r) => host::error::check_rate(r)
            .map(|()| r)
            .map_err(|_| host::error::rate_rule()),
        Err(e) => Err(format!("{e}")),
    }
}

/// Chooses one patch of a scene.
#[derive(Clone, Copy, Debug, Args)]
pub struct PatchSelection {
    /// Index of the object in the scene's `objects` array, from 0.
    #[arg(long, value_name = "I", default_value_t = 0)]
    pub object: usize,
    /// Index of the patch in the object's `patches` array, from 0.
    #[arg(long, value_name = "J", default_value_t = 0)]
    pub patch: usize,
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn gui_arguments() {
        let cli = Cli::try_parse_from(["viewer", "gui"]).expect("valid");
        let Some(CliCommand::Gui(args)) = cli.command else {
            panic!("gui")
        };
        assert_eq!(
            (args.scene, args.device, args.record),
            (None, GuiDevice(None), None)
        );
        let cli = Cli::try_parse_from([
            "viewer", "gui", "s.json", "--device", "sim", "--record", "r.csv",
        ])
        .expect("valid");
        let Some(CliCommand::Gui(args)) = cli.command else {
            panic!("gui")
        };
        assert_eq!(args.scene, Some(PathBuf::from("s.json")));
        assert_eq!(args.record, Some(PathBuf::from("r.csv")));
        use host::devices::Target;
        for (text, target) in [
            ("hid", Target::Hid),
            ("serial:/dev/ttyACM0", Target::Serial("/dev/ttyACM0".into())),
            ("tcp:localhost:4000", Target::Tcp("localhost:4000".into())),
        ] {
            let cli = Cli::try_parse_from(["viewer", "gui", "--device", text]).expect(text);
            let Some(CliCommand::Gui(args)) = cli.command else {
                panic!("gui")
            };
            assert_eq!(args.device, GuiDevice(Some(target)));
        }
        for bad in [
            "usb",
            "serial:",
            "tcp:localhost",
            "tcp::4000",
            "tcp:host:99999",
        ] {
            let e = Cli::try_parse_from(["viewer", "gui", "--device", bad]).expect_err(bad);
            let text = e.to_string();
            assert!(
                text.contains(&format!("{bad:?} is not a device"))
                    && text.contains("tcp:HOST:PORT"),
                "{text}"
            );
        }
        assert!(Cli::try_parse_from(["viewer", "gui", "--quit-after-frames", "0"]).is_err());
        let cli = Cli::try_parse_from(["viewer"]).expect("no subcommand");
        assert!(cli.command.is_none());
    }

    #[test]
    fn plot_arguments() {
        let cli = Cli::try_parse_from(["viewer", "plot", "r.csv", "--out", "r.png"]).expect("ok");
        let Some(CliCommand::Plot(args)) = cli.command else {
            panic!("plot")
        };
        assert_eq!(
            (args.log, args.out),
            (PathBuf::from("r.csv"), PathBuf::from("r.png"))
        );
        assert!(Cli::try_parse_from(["viewer", "plot", "r.csv"]).is_err());
    }

    #[test]
    fn command_line_is_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn eval_arguments() {
        let cli =
            Cli::try_parse_from(["viewer", "eval", "s.json", "--object", "2", "--patch", "1"])
                .expect("valid command line");
        let Some(CliCommand::Eval(args)) = cli.command else {
            panic!("eval")
        };
        assert_eq!(args.scene, PathBuf::from("s.json"));
        assert_eq!((args.select.object, args.select.patch), (2, 1));
        let cli = Cli::try_parse_from(["viewer", "eval", "s.json"]).expect("defaults");
        let Some(CliCommand::Eval(args)) = cli.command else {
            panic!("eval")
        };
        assert_eq!((args.select.object, args.select.patch), (0, 0));
        assert!(Cli::try_parse_from(["viewer", "eval", "s.json", "--object", "-1"]).is_err());
    }

    #[test]
    fn sim_arguments() {
        let cli = Cli::try_parse_from([
            "viewer",
            "sim",
            "s.json",
            "--trajectory",
            "t.csv",
            "--out",
            "r.csv",
        ])
        .expect("valid command line");
        let Some(CliCommand::Sim(args)) = cli.command else {
            panic!("sim")
        };
        assert_eq!(args.scene, PathBuf::from("s.json"));
        assert_eq!(args.trajectory, PathBuf::from("t.csv"));
        assert_eq!(args.out, PathBuf::from("r.csv"));
        assert_eq!((args.rate_hz(), args.object), (1000.0, 0));
        assert_eq!(args.plot, None);
        let cli = Cli::try_parse_from([
            "viewer",
            "sim",
            "s.json",
            "--trajectory",
            "t.csv",
            "--out",
            "r.csv",
            "--plot",
            "r.png",
            "--rate-hz",
            "2500",
            "--object",
            "2",
        ])
        .expect("valid command line");
        let Some(CliCommand::Sim(args)) = cli.command else {
            panic!("sim")
        };
        assert_eq!(args.plot, Some(PathBuf::from("r.png")));
        assert_eq!((args.rate_hz(), args.object), (2500.0, 2));
        for bad in ["0", "-5", "inf", "NaN", "fast"] {
            let e = Cli::try_parse_from([
                "viewer",
                "sim",
                "s.json",
                "--trajectory",
                "t.csv",
                "--out",
                "r.csv",
                "--rate-hz",
                bad,
            ])
            .expect_err(bad);
            assert!(e.to_string().contains("--rate-hz"), "{e}");
        }
        assert!(Cli::try_parse_from(["viewer", "sim", "s.json", "--out", "r.csv"]).is_err());
    }

    #[test]
    fn sim_device_arguments() {
        let base = [
            "viewer",
            "sim",
            "s.json",
            "--trajectory",
            "t.csv",
            "--out",
            "r.csv",
        ];
        let cli = Cli::try_parse_from(base).expect("valid");
        let Some(CliCommand::Sim(args)) = cli.command else {
            panic!("sim")
        };
        assert!(!args.device);
        let cli = Cli::try_parse_from(base.iter().chain(&["--device", "--hand-stiffness", "800"]))
            .expect("valid");
        let Some(CliCommand::Sim(args)) = cli.command else {
            panic!("sim")
        };
        assert!(args.device);
        assert_eq!(args.device_hand().params.hand_stiffness_n_per_m, 800.0);
        let cli = Cli::try_parse_from(base.iter().chain(&["--device"])).expect("valid");
        let Some(CliCommand::Sim(args)) = cli.command else {
            panic!("sim")
        };
        assert_eq!(args.device_hand().params.hand_stiffness_n_per_m, 300.0);
        assert_eq!(args.device_hand().release_at_s, None);
        // The board's rate by default in the closed loop.
        assert_eq!(args.rate_hz(), 10_000.0);
        for (given, stiffness, release) in [
            ("finger", 100.0, None),
            ("grip", 300.0, None),
            ("released:0.5", 300.0, Some(0.5)),
        ] {
            let cli = Cli::try_parse_from(base.iter().chain(&["--device", "--hand", given]))
                .expect(given);
            let Some(CliCommand::Sim(args)) = cli.command else {
                panic!("sim")
            };
            let hand = args.device_hand();
            assert_eq!(hand.params.hand_stiffness_n_per_m, stiffness, "{given}");
            assert_eq!(hand.release_at_s, release, "{given}");
        }
        for bad in ["released", "released:-1", "released:soon", "fist"] {
            let e = Cli::try_parse_from(base.iter().chain(&["--device", "--hand", bad]))
                .expect_err(bad);
            assert!(e.to_string().contains("--hand"), "{bad}: {e}");
        }
        assert!(Cli::try_parse_from(base.iter().chain(&["--hand", "finger"])).is_err());
        // The grip only means something in the closed loop.
        assert!(Cli::try_parse_from(base.iter().chain(&["--hand-stiffness", "800"])).is_err());
        for bad in ["0", "-1", "inf"] {
            let e = Cli::try_parse_from(base.iter().chain(&["--device", "--hand-stiffness", bad]))
                .expect_err(bad);
            assert!(e.to_string().contains("--hand-stiffness"), "{e}");
        }
    }
}
