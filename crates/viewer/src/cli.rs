//! The command line, as clap types. `main.rs` runs it; later issues add `device …` and the
//! GUI when no subcommand is given.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

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
     index, or no subcommand (the desktop GUI is not there yet)";

/// Haptic rendering of NURBS models: the desktop viewer (to come) and headless tools.
#[derive(Debug, Parser)]
#[command(name = "viewer", version, after_help = EXIT_CODES)]
pub struct Cli {
    /// What to do. Without a subcommand the desktop GUI will start; for now this prints the
    /// help and exits with status 2.
    #[command(subcommand)]
    pub command: Option<Command>,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Evaluate one patch of a scene at parameters read from standard input.
    #[command(long_about = EVAL_ABOUT, after_long_help = EVAL_AFTER)]
    Eval(EvalArgs),
    /// Closest points of one object to query points read from standard input.
    #[command(long_about = CLOSEST_ABOUT, after_long_help = CLOSEST_AFTER)]
    Closest(ClosestArgs),
    /// Simulate the haptic loop along a prescribed HIP trajectory and write a run log.
    #[command(long_about = SIM_ABOUT, after_long_help = SIM_AFTER)]
    Sim(SimArgs),
}

const CLOSEST_ABOUT: &str = "\
Closest points of one object to query points read from standard input.

Reads one point per line: `x y` for an object of planar curves, `x y z` for an object of \
surfaces (metres, whitespace-separated). Blank lines and lines starting with `#` are \
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

Errors: a wrong number of values, a value that is not a finite number or a malformed line
stops the run with a message on standard error naming the line number and its content; the
lines before it have been answered.

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
been answered.

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
  increase, all values are finite, at least two samples. Blank lines and lines starting
  with `#` are skipped. Example:
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

Plot (--plot, PNG): normal, friction and total force magnitude against time over coloured
bands of the mode (top), the CP and GO parameters against time (bottom).

Progress goes to standard error, every 10%.

Exit status:
  0  run log (and plot) written
  1  the run log or the plot could not be written
  2  bad command line (--rate-hz must be finite and > 0), unreadable or invalid scene or
     trajectory (the message names the file and line), bad --object, or a trajectory whose
     dimension does not match the object

Example:
  viewer sim scenes/examples.json --object 1 --trajectory press.csv --out run.csv --plot run.png";

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
    /// Tick rate in Hz (finite, > 0).
    #[arg(
        long,
        value_name = "HZ",
        default_value_t = 1000.0,
        value_parser = tick_rate,
        allow_negative_numbers = true
    )]
    pub rate_hz: f64,
    /// Index of the object in the scene's `objects` array, from 0.
    #[arg(long, value_name = "I", default_value_t = 0)]
    pub object: usize,
}

fn tick_rate(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(r) if r.is_finite() && r > 0.0 => Ok(r),
        Ok(r) => Err(format!("{r} is not a tick rate; it must be finite and > 0")),
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
    fn command_line_is_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn eval_arguments() {
        let cli =
            Cli::try_parse_from(["viewer", "eval", "s.json", "--object", "2", "--patch", "1"])
                .expect("valid command line");
        let Some(Command::Eval(args)) = cli.command else {
            panic!("eval")
        };
        assert_eq!(args.scene, PathBuf::from("s.json"));
        assert_eq!((args.select.object, args.select.patch), (2, 1));
        let cli = Cli::try_parse_from(["viewer", "eval", "s.json"]).expect("defaults");
        let Some(Command::Eval(args)) = cli.command else {
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
        let Some(Command::Sim(args)) = cli.command else {
            panic!("sim")
        };
        assert_eq!(args.scene, PathBuf::from("s.json"));
        assert_eq!(args.trajectory, PathBuf::from("t.csv"));
        assert_eq!(args.out, PathBuf::from("r.csv"));
        assert_eq!((args.plot, args.rate_hz, args.object), (None, 1000.0, 0));
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
        let Some(Command::Sim(args)) = cli.command else {
            panic!("sim")
        };
        assert_eq!(args.plot, Some(PathBuf::from("r.png")));
        assert_eq!((args.rate_hz, args.object), (2500.0, 2));
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
}
