//! The `device …` subcommands' arguments: the device a command talks to, and each
//! subcommand's own.

use std::path::PathBuf;
use std::time::Duration;

use clap::{Args, Subcommand};

/// `device …` subcommands.
#[derive(Debug, Subcommand)]
pub enum DeviceSubcommand {
    /// List the boards (USB HID and USB serial) that answer the protocol's hello.
    #[command(after_long_help = DEVICE_LIST_AFTER)]
    List,
    /// Print a device's telemetry, dropped frames and faults.
    #[command(after_long_help = DEVICE_MONITOR_AFTER)]
    Monitor(MonitorArgs),
    /// Serve the simulated pantograph on a pseudo-terminal, as a board on a serial port.
    #[command(after_long_help = DEVICE_SIM_PTY_AFTER)]
    SimPty(SimPtyArgs),
    /// Measure a device's own joint damping and Coulomb friction through the protocol.
    #[command(after_long_help = DEVICE_IDENTIFY_AFTER)]
    Identify(DeviceIdentifyArgs),
    /// Print the default device description as a `device/1` file, or check FILE and print it
    /// as read (every field required; errors name the field; exit 2 for a bad file).
    Spec {
        /// A `device/1` file to check.
        #[arg(value_name = "FILE")]
        file: Option<PathBuf>,
    },
}

const DEVICE_IDENTIFY_AFTER: &str = "\
The device must be calibrated (hold the handle against its end stops and run the app's \
Calibrate, or `--sim`, which calibrates itself) and nothing must touch the handle: it moves \
by itself, a few degrees at each joint. The command clears the faults, enables the forces, \
sends the protocol's Excite (square waves of joint torque, 8 and 7 mN m, half-periods of 150 \
and 210 ms, for 6 s), records the telemetry (one frame per millisecond) with heartbeats, \
disables the forces and fits the joints' damping and Coulomb friction as `viewer identify` \
does, from each frame's HIP (joint angles by inverse kinematics) and force (torques, J^T F). \
`--sim` runs the simulated device in this process with nobody holding its handle.

Exit status: 0 identified, 2 the device could not be opened, refused or did not move.";

/// `device identify` arguments.
#[derive(Debug, Args)]
pub struct DeviceIdentifyArgs {
    /// Which device (with `--sim`, its handle released).
    #[command(flatten)]
    pub device: DeviceArgs,
}

/// The device a `device` subcommand talks to: exactly one of these.
#[derive(Debug, Args)]
pub struct DeviceArgs {
    /// Serial port of the board (`/dev/ttyACM0`, `COM3`).
    #[arg(long, value_name = "PATH", conflicts_with_all = ["hid", "sim", "tcp"])]
    pub port: Option<PathBuf>,
    /// A board over TCP, `HOST:PORT`: the firmware under QEMU (`cargo xtask qemu --serve
    /// 127.0.0.1:PORT`), whose UART speaks the serial link's COBS framing.
    #[arg(long, value_name = "HOST:PORT", conflicts_with_all = ["hid", "sim"])]
    pub tcp: Option<String>,
    /// The first USB HID board.
    #[arg(long, conflicts_with = "sim")]
    pub hid: bool,
    /// The simulated pantograph in this process (no hardware needed).
    #[arg(long)]
    pub sim: bool,
    /// The device's description, a `device/1` file (`viewer device spec` prints the
    /// default): the simulated pantograph's with --sim; for a board, the geometry and
    /// encoders `device identify` reads its telemetry with (the board itself runs the
    /// description it was built with).
    #[arg(long, value_name = "FILE")]
    pub device_spec: Option<PathBuf>,
}

impl DeviceArgs {
    /// The device chosen, `None` when none was.
    pub fn target(&self) -> Option<host::devices::Target> {
        use host::devices::Target;
        match (&self.port, &self.tcp, self.hid, self.sim) {
            (Some(path), ..) => Some(Target::Serial(path.to_string_lossy().into_owned())),
            (None, Some(address), ..) => Some(Target::Tcp(address.clone())),
            (None, None, true, _) => Some(Target::Hid),
            (None, None, false, true) => Some(Target::Sim),
            (None, None, false, false) => None,
        }
    }
}

/// What a `device` subcommand says when no device was chosen.
pub const CHOOSE_A_DEVICE: &str =
    "choose a device with --port PATH, --tcp HOST:PORT, --hid or --sim";

const DEVICE_SIM_PTY_AFTER: &str = "\
Opens a pseudo-terminal (Linux, macOS), prints its path (`/dev/pts/N`) on standard output \
and serves the simulated pantograph on it: the serial link's COBS frames over a real tty, as \
a board's USB serial port, so the serial path can be tried without a board. Hosts come and \
go: `viewer gui --device serial:PATH` (a board's setup: press Clear, Calibrate and Forces on) \
or `viewer device monitor --port PATH`. The device keeps ticking in between, with its \
watchdog: without a host's heartbeats its forces are off.

Exit status:
  0  ran for --seconds (or until interrupted)
  1  the pseudo-terminal failed during the run
  2  bad command line, or no pseudo-terminal could be opened (or none on this OS)

Example:
  viewer device sim-pty --seconds 60";

/// Arguments of `device sim-pty`.
#[derive(Debug, Args)]
pub struct SimPtyArgs {
    /// Stop after this many seconds (finite, >= 0); without it, run until interrupted.
    #[arg(long, value_name = "S", value_parser = seconds, allow_negative_numbers = true)]
    pub seconds: Option<Duration>,
    /// The simulated pantograph served, a `device/1` file (`viewer device spec` prints the
    /// default).
    #[arg(long, value_name = "FILE")]
    pub device_spec: Option<PathBuf>,
}

const DEVICE_LIST_AFTER: &str = "\
Enumerates HID devices with the board's USB id (pid.codes 1209:0001, a placeholder) and USB \
serial ports, sends each a hello and waits 200 ms for the answer. Prints a table of those that \
answered (kind, path, firmware version, scene capacity, product), or `no devices found`. A \
backend the OS does not provide is reported on standard error.

Exit status:
  0  always, with or without devices";

const DEVICE_MONITOR_AFTER: &str = "\
Output, one line each:
  t=<s> seq=<n> hip=(x,y) force=(fx,fy) normal=<N> mode=<mode> feature=<f> faults=<list>
                                     every --every'th telemetry frame (m, N, device frame)
  dropped <n> frame(s) before seq <s> (total <t>)
                                     a gap in the device's sequence numbers
  faults: <list>                     the latched faults changed (`-` when none)
  nack: frame <s>: <reason>          the device rejected a frame
A last line `received <n> telemetry frames, dropped <m>` ends the run, also one that Ctrl-C
(SIGINT) or SIGTERM stops. Each line is written whole, so output cut short never ends
mid-line.

The monitor is the host: it sends a heartbeat every 50 ms, which keeps the device's watchdog
fed. With --sim the simulated pantograph runs in real time (calibrated at once, forces off, no
scene) and its virtual hand moves on a slow 1 cm circle.

Exit status:
  0  ran for --seconds
  1  the link failed during the run, or the output could not be written
  130  stopped by Ctrl-C (SIGINT); 143 by SIGTERM (a second signal ends it at once)
  2  bad command line, or the device could not be opened or did not answer the hello

Examples:
  viewer device monitor --sim --seconds 2 --every 100
  viewer device monitor --tcp 127.0.0.1:4444 --seconds 2   (after `cargo xtask qemu --serve 127.0.0.1:4444`)";

/// Arguments of `device monitor`.
#[derive(Debug, Args)]
pub struct MonitorArgs {
    /// Which device.
    #[command(flatten)]
    pub device: DeviceArgs,
    /// Stop after this many seconds (finite, >= 0, at most u64::MAX s); without it, run
    /// until interrupted.
    #[arg(long, value_name = "S", value_parser = seconds, allow_negative_numbers = true)]
    pub seconds: Option<Duration>,
    /// Print every N-th telemetry frame (N >= 1).
    #[arg(long, value_name = "N", default_value_t = 100, value_parser = clap::value_parser!(u64).range(1..))]
    pub every: u64,
}

fn seconds(text: &str) -> Result<Duration, String> {
    match text.trim().parse::<f64>() {
        // `Duration::from_secs_f64` panics past u64::MAX seconds; the checked form does not.
        Ok(s) if s.is_finite() && s >= 0.0 => Duration::try_from_secs_f64(s).map_err(|_| {
            format!(
                "{s} s is longer than a duration can be (at most {} s)",
                u64::MAX
            )
        }),
        Ok(s) => Err(format!("{s} is not a duration; it must be finite and >= 0")),
        Err(e) => Err(format!("{e}")),
    }
}
