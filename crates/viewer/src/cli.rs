//! The command line, as clap types. `main.rs` runs it; later issues add `closest`, `sim`,
//! `device …`, and the GUI when no subcommand is given.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

/// Exit status: an input line was bad (not a number, wrong count, outside the domain) or the
/// output could not be written.
pub const EXIT_BAD_INPUT: u8 = 1;
/// Exit status: the command line, the scene file or the object/patch index was invalid.
pub const EXIT_BAD_SETUP: u8 = 2;

const EXIT_CODES: &str = "\
Exit status:
  0  success
  1  a bad input line (eval), or the output could not be written
  2  bad command line, unreadable or invalid scene, bad --object/--patch index,
     or no subcommand (the desktop GUI is not there yet)";

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
}
