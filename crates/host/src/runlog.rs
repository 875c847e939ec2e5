//! The run-log format, in one place: one CSV row per tick with the tick's internals. `viewer
//! sim` writes a whole [`Run`] ([`Run::write_csv`]); the app records its loops while they run
//! ([`Recorder`], fed by the loops through a bounded channel, flushed every
//! [`FLUSH_PERIOD`], whole rows only, so a file cut short by a killed process never ends
//! mid-row); `viewer plot` and the app's replay read a log back ([`read`]) into a
//! [`Run`] whose ticks carry every logged column. What the log does not hold (velocities,
//! normals, tangents, CP and GO parameters, the feature) is zero; [`RunLog::has_parameters`]
//! is false.

use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, Receiver, SyncSender};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use friction::{FrictionMaterial, Mode, SwitchCause};
use nurbs::Vec3;
use scene::Space;

use crate::loop_api::{RATE_HZ, RECORD_CAPACITY};
use crate::sim::Run;
use crate::tick::{DeviceSample, Tick};

/// A run log read back.
#[derive(Clone, Debug, PartialEq)]
pub struct RunLog {
    /// The ticks (material and object unknown: the defaults, object 0, the file's name).
    pub run: Run,
    /// Whether the ticks carry CP and GO parameters (a run log does not).
    pub has_parameters: bool,
}

/// Why a run log could not be read.
#[derive(Debug, thiserror::Error)]
pub enum RunLogError {
    /// The file could not be read.
    #[error("cannot read {}: {error}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// The header is not a run log's.
    #[error(
        "{}: line 1 is not a run log's header (the columns of `viewer sim --out`: `{}`, the \
         3-D columns, or either followed by the --device columns)",
        path.display(), csv_header(Space::Planar)
    )]
    Header {
        /// The file.
        path: PathBuf,
    },
    /// A row is malformed.
    #[error("{}: line {line}: {message}", path.display())]
    Row {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// The text does not end with a newline: its last row may have been cut.
    #[error("{}: the last row has no newline (cut short?)", path.display())]
    Unterminated {
        /// The file.
        path: PathBuf,
    },
    /// No rows.
    #[error("{}: the run log has no rows", path.display())]
    Empty {
        /// The file.
        path: PathBuf,
    },
}

/// Reads the run log at `path`.
pub fn read(path: &Path) -> Result<RunLog, RunLogError> {
    let text = std::fs::read_to_string(path).map_err(|error| RunLogError::Read {
        path: path.to_owned(),
        error,
    })?;
    parse(&text, path)
}

/// [`parse`], and the text ends with a newline: a run log a writer finished, every row
/// complete, not one cut where a killed process stopped writing (a row cut inside its last
/// number would still parse). The tests that interrupt `viewer sim`, `gui --record` and their
/// like check their files with this.
pub fn parse_complete(text: &str, path: &Path) -> Result<RunLog, RunLogError> {
    if !text.ends_with('\n') {
        return Err(RunLogError::Unterminated {
            path: path.to_owned(),
        });
    }
    parse(text, path)
}

/// Parses a run log's text; errors name `path` and the line.
pub fn parse(text: &str, path: &Path) -> Result<RunLog, RunLogError> {
    let mut lines = text.lines();
    let header = lines.next().unwrap_or("").trim();
    let (space, extra) = [Space::Planar, Space::Spatial]
        .into_iter()
        .flat_map(|space| {
            [(false, false), (true, false), (false, true), (true, true)]
                .map(|(device, deform)| (space, Columns { device, deform }))
        })
        .find(|&(space, extra)| header == full_header(space, extra))
        .ok_or_else(|| RunLogError::Header {
            path: path.to_owned(),
        })?;
    let device = extra.device;
    let dim = space.dim();
    let columns = 1 + 4 * dim + 8 + if device { 5 } else { 0 } + if extra.deform { dim } else { 0 };
    let mut ticks = Vec::new();
    for (i, line) in lines.enumerate() {
        let n = i + 2;
        if line.trim().is_empty() {
            continue;
        }
        let row_error = |message: String| RunLogError::Row {
            path: path.to_owned(),
            line: n,
            message,
        };
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != columns {
            return Err(row_error(format!(
                "{} columns, the header has {columns}",
                cells.len()
            )));
        }
        let names: Vec<String> = header.split(',').map(str::to_owned).collect();
        let number = |c: usize| -> Result<f64, RunLogError> {
            cells[c]
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    row_error(format!(
                        "{}: {:?} is not a finite number",
                        names[c], cells[c]
                    ))
                })
        };
        let vector = |c: usize| -> Result<Vec3, RunLogError> {
            let mut v = [0.0f32; 3];
            for (k, x) in v.iter_mut().take(dim).enumerate() {
                *x = number(c + k)? as f32;
            }
            Ok(Vec3::from_array(v))
        };
        let t_s = number(0)?;
        let hip = vector(1)?;
        let cp = vector(1 + dim)?;
        let go = vector(1 + 2 * dim)?;
        let c = 1 + 3 * dim;
        let patch = match cells[c].parse::<i64>() {
            Ok(-1) => None,
            Ok(p) if p >= 0 => Some(p as usize),
            _ => {
                return Err(row_error(format!(
                    "patch: {:?} is not -1 or an index",
                    cells[c]
                )));
            }
        };
        let mode = Mode::ALL
            .into_iter()
            .find(|m| m.name() == cells[c + 1])
            .ok_or_else(|| {
                row_error(format!(
                    "mode: {:?} is not free, stuck, transition or slip",
                    cells[c + 1]
                ))
            })?;
        let cause = SwitchCause::ALL
            .into_iter()
            .find(|s| s.name() == cells[c + 2])
            .ok_or_else(|| row_error(format!("cause: {:?} is not a switch cause", cells[c + 2])))?;
        let depth_m = number(c + 3)? as f32;
        let normal_force_n = number(c + 4)? as f32;
        let friction_force_n = number(c + 5)? as f32;
        let mu = number(c + 6)? as f32;
        let psi = number(c + 7)? as f32;
        let force = vector(c + 8)?;
        let sample = if device {
            let d = c + 8 + dim;
            let faults = cells[d + 4].parse::<u16>().map_err(|_| {
                row_error(format!("faults: {:?} is not a fault bitset", cells[d + 4]))
            })?;
            Some(DeviceSample {
                theta_rad: [number(d)? as f32, number(d + 1)? as f32],
                tau_nm: [number(d + 2)? as f32, number(d + 3)? as f32],
                faults,
            })
        } else {
            None
        };
        let deform = if extra.deform {
            Some(vector(c + 8 + dim + if device { 5 } else { 0 })?)
        } else {
            None
        };
        ticks.push(Tick {
            t_s,
            hip,
            hip_velocity: Vec3::ZERO,
            cp,
            go,
            patch,
            feature: tracker::Feature::Patch(patch.unwrap_or(0) as u16),
            mode,
            cause,
            depth_m,
            normal_force_n,
            friction_force_n,
            mu,
            psi,
            normal: Vec3::ZERO,
            tangent: Vec3::ZERO,
            friction: Vec3::ZERO,
            force,
            cp_patch: patch.unwrap_or(0),
            cp_param: 0.0,
            cp_params: [0.0; 2],
            go_patch: patch.unwrap_or(0),
            go_param: 0.0,
            go_params: [0.0; 2],
            device: sample,
            deform,
        });
    }
    if ticks.is_empty() {
        return Err(RunLogError::Empty {
            path: path.to_owned(),
        });
    }
    let rate_hz = if ticks.len() > 1 {
        let span = ticks[ticks.len() - 1].t_s - ticks[0].t_s;
        ((ticks.len() - 1) as f64 / span).round()
    } else {
        0.0
    };
    let name = path
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    Ok(RunLog {
        run: Run {
            space,
            object: 0,
            object_name: name,
            material: FrictionMaterial::default(),
            rate_hz,
            ticks,
        },
        has_parameters: false,
    })
}

// ---------------------------------------------------------------------------------------------
// Writing.

/// The columns a device run ([`run_device`](crate::closed_loop::run_device)) appends to [`csv_header`]: the measured joint
/// angles (rad), the joint torques (N·m) and the latched fault bits as a decimal number.
pub const DEVICE_COLUMNS: &str = "theta1_rad,theta2_rad,tau1_nm,tau2_nm,faults";

/// The run log's header: `t_s,hip_x,hip_y[,hip_z],cp_x,cp_y[,cp_z],go_x,go_y[,go_z],patch,mode,
/// cause,depth_m,normal_force_n,friction_force_n,mu,psi,force_x,force_y[,force_z]` (the `_z` columns
/// for spatial runs only).
pub fn csv_header(space: Space) -> String {
    let axes: &[&str] = match space {
        Space::Planar => &["x", "y"],
        Space::Spatial => &["x", "y", "z"],
    };
    let vector = |name: &str| {
        axes.iter()
            .map(|a| format!("{name}_{a}"))
            .collect::<Vec<_>>()
            .join(",")
    };
    format!(
        "t_s,{},{},{},patch,mode,cause,depth_m,normal_force_n,friction_force_n,mu,psi,{}",
        vector("hip"),
        vector("cp"),
        vector("go"),
        vector("force")
    )
}

/// The columns a deformable-object run (`viewer sim --deform`) appends: the object's
/// displacement from its rest shape at the CP (m), `deform_x,deform_y[,deform_z]`.
pub fn deform_columns(space: Space) -> String {
    ["x", "y", "z"][..space.dim()]
        .iter()
        .map(|a| format!("deform_{a}"))
        .collect::<Vec<_>>()
        .join(",")
}

/// Which columns a run log has beyond [`csv_header`]'s.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Columns {
    /// [`DEVICE_COLUMNS`] (a closed-loop run of the device).
    pub device: bool,
    /// [`deform_columns`] (a run with a deformable object).
    pub deform: bool,
}

/// The whole header line's text for `space` with `extra` columns.
fn full_header(space: Space, extra: Columns) -> String {
    let mut header = csv_header(space);
    if extra.device {
        header = format!("{header},{DEVICE_COLUMNS}");
    }
    if extra.deform {
        header = format!("{header},{}", deform_columns(space));
    }
    header
}

/// Writes the run log's header line: [`csv_header`], followed by [`DEVICE_COLUMNS`] and
/// [`deform_columns`] as `extra` says.
pub fn write_csv_header(mut w: impl Write, space: Space, extra: Columns) -> io::Result<()> {
    writeln!(w, "{}", full_header(space, extra))
}

impl Tick {
    /// The first run-log column of this tick with a NaN or an infinity, if any.
    pub fn non_finite_column(&self) -> Option<&'static str> {
        let k = self;
        let d = k.device.unwrap_or(DeviceSample {
            theta_rad: [0.0; 2],
            tau_nm: [0.0; 2],
            faults: 0,
        });
        let columns: [(&'static str, &[f32]); 12] = [
            ("hip", &k.hip.to_array()),
            ("cp", &k.cp.to_array()),
            ("go", &k.go.to_array()),
            ("depth_m", &[k.depth_m]),
            ("normal_force_n", &[k.normal_force_n]),
            ("friction_force_n", &[k.friction_force_n]),
            ("mu", &[k.mu]),
            ("psi", &[k.psi]),
            ("force", &k.force.to_array()),
            ("theta_rad", &d.theta_rad),
            ("tau_nm", &d.tau_nm),
            ("deform", &k.deform.unwrap_or(Vec3::ZERO).to_array()),
        ];
        if !k.t_s.is_finite() {
            return Some("t_s");
        }
        columns
            .into_iter()
            .find(|(_, v)| !v.iter().all(|x| x.is_finite()))
            .map(|(name, _)| name)
    }

    /// Writes this tick as one run-log row (see [`Run::write_csv`]); the `extra` columns too
    /// ([`DEVICE_COLUMNS`], 0 without a [`DeviceSample`]; [`deform_columns`], 0 without a
    /// displacement). Does not check finiteness ([`Tick::non_finite_column`]).
    pub fn write_csv_row(&self, mut w: impl Write, space: Space, extra: Columns) -> io::Result<()> {
        let k = self;
        let dim = space.dim();
        write!(w, "{}", k.t_s)?;
        for v in [k.hip, k.cp, k.go] {
            for x in &v.to_array()[..dim] {
                write!(w, ",{x:?}")?;
            }
        }
        let patch = k.patch.map_or(-1, |p| p as i64);
        write!(
            w,
            ",{patch},{},{},{:?},{:?},{:?},{:?},{:?}",
            k.mode.name(),
            k.cause.name(),
            k.depth_m.max(0.0),
            k.normal_force_n,
            k.friction_force_n,
            k.mu,
            k.psi
        )?;
        for x in &k.force.to_array()[..dim] {
            write!(w, ",{x:?}")?;
        }
        if extra.device {
            let d = k.device.unwrap_or(DeviceSample {
                theta_rad: [0.0; 2],
                tau_nm: [0.0; 2],
                faults: 0,
            });
            write!(
                w,
                ",{:?},{:?},{:?},{:?},{}",
                d.theta_rad[0], d.theta_rad[1], d.tau_nm[0], d.tau_nm[1], d.faults
            )?;
        }
        if extra.deform {
            for x in &k.deform.unwrap_or(Vec3::ZERO).to_array()[..dim] {
                write!(w, ",{x:?}")?;
            }
        }
        writeln!(w)
    }
}

impl Run {
    /// Writes the run log: [`csv_header`], then one row per tick. `patch` is −1 when free,
    /// `mode` one of `free`, `stuck`, `transition`, `slip`, `cause` why the mode last changed
    /// ([`SwitchCause::name`]), `psi` the CP tracker's projection error Ψ, `depth_m` the penetration depth
    /// clamped at 0 (so 0 when free). A device run (its first tick has a [`DeviceSample`])
    /// appends [`DEVICE_COLUMNS`] (0 in a tick without a sample).
    ///
    /// A run with a non-finite value in any column is not written (an `InvalidData` error
    /// naming the tick and column): a run log never holds `NaN` or `inf`.
    pub fn write_csv(&self, out: impl Write) -> io::Result<()> {
        if let Some((i, column)) = self.first_non_finite() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!(
                    "tick {i} (t = {} s): {column} is not finite; nothing written",
                    self.ticks[i].t_s
                ),
            ));
        }
        let mut w = io::BufWriter::new(out);
        let extra = Columns {
            device: self.is_device_run(),
            deform: self.ticks.first().is_some_and(|k| k.deform.is_some()),
        };
        write_csv_header(&mut w, self.space, extra)?;
        for k in &self.ticks {
            k.write_csv_row(&mut w, self.space, extra)?;
        }
        w.flush()
    }

    /// The first tick and run-log column with a NaN or an infinity.
    fn first_non_finite(&self) -> Option<(usize, &'static str)> {
        self.ticks
            .iter()
            .enumerate()
            .find_map(|(i, k)| k.non_finite_column().map(|c| (i, c)))
    }

    /// Whether this is a closed-loop run of the device ([`run_device`](crate::closed_loop::run_device)): its ticks carry a
    /// [`DeviceSample`].
    pub fn is_device_run(&self) -> bool {
        self.ticks.first().is_some_and(|k| k.device.is_some())
    }
}

/// Writes the ticks it receives to run logs (the columns of `viewer sim`), flushed at least
/// once a second, completed when the loops stop: the planar loop's ticks to the path given
/// (with the device's columns, as `viewer sim --device`), the spatial hand's to
/// [`spatial_log_path`] of it (as `viewer sim` on a scene of surfaces), created at its first
/// tick. Each log's time column runs on across loop restarts (a scene opened in 3-D, a device
/// switch): a tick whose time is not after the last one written continues one period later,
/// so a recording stays one run log with one rate.
#[derive(Debug)]
pub struct Recorder {
    thread: Option<JoinHandle<io::Result<RecordSummary>>>,
    path: PathBuf,
}

/// What a recording wrote.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RecordSummary {
    /// Rows written to the planar log.
    pub rows: u64,
    /// Rows written to the spatial log ([`spatial_log_path`]); 0 when there is none.
    pub spatial_rows: u64,
    /// Ticks skipped because a value was not finite (a run log never holds NaN or inf).
    pub skipped: u64,
}

/// A loop's input to the [`Recorder`]: its ticks go to the run log of its space.
#[derive(Clone, Debug)]
pub struct RecordTx {
    tx: SyncSender<(Space, Tick)>,
    space: Space,
}

impl RecordTx {
    /// The same recorder, for a loop whose ticks are of `space`.
    pub fn for_space(&self, space: Space) -> Self {
        RecordTx {
            tx: self.tx.clone(),
            space,
        }
    }

    /// Hands `tick` to the recorder, waiting while its channel is full (never on a loop's
    /// tick path: [`RecordTx::try_send`] is that one); false when it is gone.
    pub fn send(&self, tick: Tick) -> bool {
        self.tx.send((self.space, tick)).is_ok()
    }

    /// Hands `tick` to the recorder; false when its channel is full or it is gone.
    pub fn try_send(&self, tick: Tick) -> bool {
        self.tx.try_send((self.space, tick)).is_ok()
    }
}

/// Where a recording to `path` writes the spatial hand's ticks: `RUN.csv` → `RUN.3d.csv`.
pub fn spatial_log_path(path: &Path) -> PathBuf {
    let stem = path.file_stem().unwrap_or_default().to_string_lossy();
    let name = match path.extension() {
        Some(ext) => format!("{stem}.3d.{}", ext.to_string_lossy()),
        None => format!("{stem}.3d"),
    };
    path.with_file_name(name)
}

/// How often the recorder flushes at the latest.
pub const FLUSH_PERIOD: Duration = Duration::from_millis(500);

impl Recorder {
    /// Creates `path` (writing its header) and starts the writer thread; returns it and the
    /// planar loops' input (see [`RecordTx::for_space`] for the spatial hand's).
    pub fn start(path: &Path) -> io::Result<(Self, RecordTx)> {
        let planar = LogWriter::create(path, Space::Planar)?;
        let spatial_path = spatial_log_path(path);
        let (tx, rx) = mpsc::sync_channel::<(Space, Tick)>(RECORD_CAPACITY);
        let thread = std::thread::Builder::new()
            .name("recorder".into())
            .spawn(move || record(planar, &spatial_path, &rx))?;
        Ok((
            Recorder {
                thread: Some(thread),
                path: path.to_owned(),
            },
            RecordTx {
                tx,
                space: Space::Planar,
            },
        ))
    }

    /// Waits for the writer to finish (after the loops' senders are gone) and flushes.
    pub fn finish(mut self) -> io::Result<RecordSummary> {
        let path = self.path.clone();
        match self.thread.take().map(JoinHandle::join) {
            Some(Ok(result)) => {
                result.map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", path.display())))
            }
            Some(Err(_)) => Err(io::Error::other(format!(
                "{}: the recorder thread panicked",
                path.display()
            ))),
            None => Ok(RecordSummary::default()),
        }
    }
}

/// Bytes of rows a [`LogWriter`] gathers before it writes them to its file.
const ROWS_BUFFER: usize = 64 * 1024;

/// One run log being written by the [`Recorder`], whole rows at a time: rows gather in
/// `rows` and reach the file together, only ever at a row boundary (when [`ROWS_BUFFER`]
/// bytes have gathered, every [`FLUSH_PERIOD`], and at the end). A `BufWriter` would write
/// whenever its buffer fills, mid-row, and a process killed before its next flush left the
/// log's last row cut.
struct LogWriter {
    file: File,
    rows: Vec<u8>,
    space: Space,
    /// The time column of the last row written (s), and what is added to the loop's time.
    last_t_s: Option<f64>,
    offset_s: f64,
}

impl LogWriter {
    /// A recording's columns: the planar loop is the device's (with its columns).
    fn columns(space: Space) -> Columns {
        Columns {
            device: space == Space::Planar,
            deform: false,
        }
    }

    /// Creates `path` with the header of a log of `space` (the planar one with the device's
    /// columns: the planar loop is the device's).
    fn create(path: &Path, space: Space) -> io::Result<Self> {
        let mut log = LogWriter {
            file: File::create(path)?,
            rows: Vec::with_capacity(ROWS_BUFFER + 1024),
            space,
            last_t_s: None,
            offset_s: 0.0,
        };
        write_csv_header(&mut log.rows, space, Self::columns(space))?;
        log.flush()?;
        Ok(log)
    }

    /// Writes `tick`, its time continued past the last row when the loop restarted.
    fn write(&mut self, tick: &Tick) -> io::Result<()> {
        let mut t_s = tick.t_s + self.offset_s;
        if let Some(last) = self.last_t_s
            && t_s <= last
        {
            self.offset_s = last + 1.0 / RATE_HZ - tick.t_s;
            t_s = last + 1.0 / RATE_HZ;
        }
        self.last_t_s = Some(t_s);
        Tick { t_s, ..*tick }.write_csv_row(
            &mut self.rows,
            self.space,
            Self::columns(self.space),
        )?;
        if self.rows.len() >= ROWS_BUFFER {
            self.flush()?;
        }
        Ok(())
    }

    /// Writes the rows gathered so far to the file, in one piece.
    fn flush(&mut self) -> io::Result<()> {
        self.file.write_all(&self.rows)?;
        self.rows.clear();
        Ok(())
    }

    fn finish(mut self) -> io::Result<()> {
        self.flush()?;
        self.file.sync_all()
    }
}

fn record(
    mut planar: LogWriter,
    spatial_path: &Path,
    rx: &Receiver<(Space, Tick)>,
) -> io::Result<RecordSummary> {
    let mut summary = RecordSummary::default();
    let mut spatial: Option<LogWriter> = None;
    let mut flushed = Instant::now();
    loop {
        match rx.recv_timeout(FLUSH_PERIOD) {
            Ok((_, tick)) if tick.non_finite_column().is_some() => summary.skipped += 1,
            Ok((Space::Planar, tick)) => {
                planar.write(&tick)?;
                summary.rows += 1;
            }
            Ok((Space::Spatial, tick)) => {
                let log = match &mut spatial {
                    Some(log) => log,
                    None => spatial.insert(LogWriter::create(spatial_path, Space::Spatial)?),
                };
                log.write(&tick)?;
                summary.spatial_rows += 1;
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {}
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
        }
        if flushed.elapsed() >= FLUSH_PERIOD {
            planar.flush()?;
            if let Some(log) = &mut spatial {
                log.flush()?;
            }
            flushed = Instant::now();
        }
    }
    planar.finish()?;
    spatial.map_or(Ok(()), LogWriter::finish)?;
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::closed_loop::run_device;
    use crate::planar::{HapticLoop, PlanarSession, START_HIP};
    use crate::sim::{self, Trajectory};
    use crate::test_scenes::thesis_2d;
    use scene::Scene;

    /// A `sim --device` run written and read back gives the same logged columns.
    #[test]
    fn round_trip_of_a_device_run() {
        let scene = Scene::from_json_str(include_str!("../../../scenes/thesis-2d.json"))
            .unwrap_or_else(|e| panic!("{e}"));
        let trajectory = Trajectory::parse("t,x,y\n0,0.0,0.1\n0.3,0.0,0.09\n", Path::new("t.csv"))
            .unwrap_or_else(|e| panic!("{e}"));
        let run = run_device(
            &scene,
            0,
            &trajectory,
            1000.0,
            sim::SimParams::default(),
            |_, _| {},
        )
        .unwrap_or_else(|e| panic!("{e}"))
        .run;
        let mut out = Vec::new();
        run.write_csv(&mut out).expect("write");
        let text = String::from_utf8(out).expect("UTF-8");
        let log = parse(&text, Path::new("run.csv")).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(log.run.ticks.len(), run.ticks.len());
        assert_eq!(log.run.rate_hz, 1000.0);
        for (a, b) in log.run.ticks.iter().zip(&run.ticks) {
            // `{:?}` of an f32 prints the shortest text that parses back to the same f32, so
            // every logged f32 column round-trips exactly.
            assert_eq!((a.t_s, a.hip, a.cp, a.go), (b.t_s, b.hip, b.cp, b.go));
            assert_eq!((a.mode, a.cause, a.patch), (b.mode, b.cause, b.patch));
            assert_eq!(a.depth_m, b.depth_m.max(0.0));
            assert_eq!(
                (a.normal_force_n, a.mu, a.psi),
                (b.normal_force_n, b.mu, b.psi)
            );
            assert_eq!((a.friction_force_n, a.force), (b.friction_force_n, b.force));
            assert_eq!(a.device, b.device);
        }
    }

    #[test]
    fn errors_name_the_line_and_column() {
        let path = Path::new("r.csv");
        let e = parse("t,x,y\n0,0,0\n", path).expect_err("not a run log");
        assert!(
            e.to_string()
                .starts_with("r.csv: line 1 is not a run log's header"),
            "{e}"
        );
        let header = csv_header(Space::Planar);
        let e = parse(&format!("{header}\n1,2\n"), path).expect_err("short");
        assert_eq!(e.to_string(), "r.csv: line 2: 2 columns, the header has 17");
        let row = "0,0.0,0.1,0.0,0.0,0.0,0.0,-1,flying,none,0.0,0.0,0.0,0.0,0.0,0.0,0.0";
        let e = parse(&format!("{header}\n{row}\n"), path).expect_err("mode");
        assert!(e.to_string().contains("line 2: mode: \"flying\""), "{e}");
        let row = "0,NaN,0.1,0.0,0.0,0.0,0.0,-1,free,none,0.0,0.0,0.0,0.0,0.0,0.0,0.0";
        let e = parse(&format!("{header}\n{row}\n"), path).expect_err("NaN");
        assert!(
            e.to_string()
                .contains("line 2: hip_x: \"NaN\" is not a finite number"),
            "{e}"
        );
        let e = parse(&format!("{header}\n"), path).expect_err("empty");
        assert!(e.to_string().contains("no rows"), "{e}");
        // Cut inside the last number: it parses, but is not complete.
        let row = "0,0.0,0.1,0.0,0.0,0.0,0.0,-1,free,none,0.0,0.0,0.0,0.0,0.0,0.0,0.25";
        let cut = format!("{header}\n{}", &row[..row.len() - 1]);
        assert!(parse(&cut, path).is_ok());
        let e = parse_complete(&cut, path).expect_err("cut");
        assert_eq!(
            e.to_string(),
            "r.csv: the last row has no newline (cut short?)"
        );
        assert!(parse_complete(&format!("{header}\n{row}\n"), path).is_ok());
    }

    /// What reaches the file between two flushes is whole rows only: after rows worth
    /// several [`ROWS_BUFFER`]s and no flush, the file (as a process killed now leaves it)
    /// ends with a newline and reads back completely, and it holds the rest after the
    /// flush. A `BufWriter` would have written its full buffers, the last one cut mid-row.
    #[test]
    fn a_log_reaches_its_file_in_whole_rows() {
        let dir = std::env::temp_dir().join(format!("viewer-rows-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("rows.csv");
        let mut log = LogWriter::create(&path, Space::Planar).expect("create");
        let session = PlanarSession::new(thesis_2d()).expect("session");
        let mut haptic = HapticLoop::new(session, START_HIP).expect("loop");
        let ticks = 3000;
        for _ in 0..ticks {
            log.write(&haptic.step()).expect("write");
        }
        let on_disk = std::fs::read_to_string(&path).expect("read");
        let rows = parse_complete(&on_disk, &path)
            .unwrap_or_else(|e| panic!("{e}"))
            .run
            .ticks
            .len();
        assert!(
            on_disk.len() >= 2 * ROWS_BUFFER && rows < ticks,
            "{rows} rows, {} bytes before the flush",
            on_disk.len()
        );
        log.finish().expect("finish");
        let text = std::fs::read_to_string(&path).expect("read");
        let log = parse_complete(&text, &path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(log.run.ticks.len(), ticks);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The recorder writes the header of `sim --device` logs and one row per tick, readable
    /// by `viewer plot`'s reader; rows reach the file while it runs (the flush period is
    /// 0.5 s: polled for up to 10 s, so a loaded machine does not fail it), and all of them
    /// when it finishes.
    #[test]
    fn recorder_writes_a_run_log_while_running_and_completes_it() {
        let dir = std::env::temp_dir().join(format!("viewer-recorder-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("rec.csv");
        let (recorder, tx) = Recorder::start(&path).expect("start");
        let session = PlanarSession::new(thesis_2d()).expect("session");
        let mut haptic = HapticLoop::new(session, START_HIP).expect("loop");
        for _ in 0..300 {
            assert!(tx.send(haptic.step()), "recorder alive");
        }
        let waited = Instant::now();
        let rows = || std::fs::read_to_string(&path).map_or(0, |t| t.lines().count());
        while rows() < 301 && waited.elapsed() < Duration::from_secs(10) {
            std::thread::sleep(Duration::from_millis(20));
        }
        assert_eq!(rows(), 301, "flushed while running");
        for _ in 0..200 {
            assert!(tx.send(haptic.step()), "recorder alive");
        }
        drop(tx);
        let summary = recorder.finish().expect("finish");
        assert_eq!(
            summary,
            RecordSummary {
                rows: 500,
                ..RecordSummary::default()
            }
        );
        assert!(
            !spatial_log_path(&path).exists(),
            "no spatial log without 3-D ticks"
        );
        let text = std::fs::read_to_string(&path).expect("read");
        assert_eq!(
            text.lines().next(),
            Some(format!("{},{}", csv_header(Space::Planar), DEVICE_COLUMNS).as_str())
        );
        let log = crate::runlog::parse(&text, &path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(log.run.ticks.len(), 500);
        assert_eq!(log.run.rate_hz, RATE_HZ);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A recording across loop restarts stays one run log of each space: the planar loop
    /// restarted (as on a device switch, its clock back at 0) continues one period after its
    /// last row, and the spatial hand's ticks go to `rec.3d.csv` with the spatial columns.
    /// The reference is the tick period: every step of each log's time column is 1 ms (to
    /// f64 rounding of sums of 1e-3, far below 1e-9 s). Without the continuation the planar
    /// clock would step back at row 150, and the run log reader, which takes the rate from
    /// the column's span, would read 300 rows over 0.149 s as 2 kHz.
    #[test]
    fn a_recording_continues_across_restarts_and_keeps_the_3d_ticks_apart() {
        let dir = std::env::temp_dir().join(format!("viewer-rec3d-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("rec.csv");
        let (recorder, tx) = Recorder::start(&path).expect("start");
        let spatial_tx = tx.for_space(Space::Spatial);
        for _ in 0..2 {
            let session = PlanarSession::new(thesis_2d()).expect("session");
            let mut haptic = HapticLoop::new(session, START_HIP).expect("loop");
            for _ in 0..150 {
                assert!(tx.send(haptic.step()), "recorder alive");
            }
        }
        for i in 0..120 {
            let mut tick = Tick::idle(i as f64 / RATE_HZ);
            tick.hip = nurbs::Vec3::new(0.0, 0.09, 0.02 - i as f32 * 1e-4);
            assert!(spatial_tx.send(tick), "recorder alive");
        }
        drop((tx, spatial_tx));
        let summary = recorder.finish().expect("finish");
        assert_eq!(
            summary,
            RecordSummary {
                rows: 300,
                spatial_rows: 120,
                skipped: 0
            }
        );
        let planar = std::fs::read_to_string(&path).expect("read");
        let log = crate::runlog::parse(&planar, &path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((log.run.ticks.len(), log.run.rate_hz), (300, RATE_HZ));
        let one_period = |ticks: &[Tick]| {
            ticks
                .windows(2)
                .all(|w| (w[1].t_s - w[0].t_s - 1.0 / RATE_HZ).abs() < 1e-9)
        };
        assert!(one_period(&log.run.ticks));
        // The first row is the first step's last device tick, 0.9 ms in (10 kHz under 1 kHz).
        let first = log.run.ticks[0].t_s;
        let device_period = 1.0 / crate::planar::DEVICE_RATE_HZ;
        let ticks_per_step = f64::from(crate::planar::TICKS_PER_STEP);
        assert!(
            (first - (ticks_per_step - 1.0) * device_period).abs() < 1e-9,
            "{first}"
        );
        let last = log.run.ticks.last().expect("rows").t_s;
        assert!((last - first - 299.0 / RATE_HZ).abs() < 1e-9, "{last}");
        let spatial_path = spatial_log_path(&path);
        assert_eq!(spatial_path, dir.join("rec.3d.csv"));
        let text = std::fs::read_to_string(&spatial_path).expect("read 3-D");
        assert_eq!(
            text.lines().next(),
            Some(csv_header(Space::Spatial).as_str())
        );
        let log = crate::runlog::parse(&text, &spatial_path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((log.run.ticks.len(), log.run.rate_hz), (120, RATE_HZ));
        assert!(one_period(&log.run.ticks));
        let hip = log.run.ticks[119].hip;
        assert!((hip.z - (0.02 - 119.0 * 1e-4)).abs() < 1e-7, "{hip:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
