//! Reading a run log back (`viewer plot`): the CSV [`Run::write_csv`] writes, from `sim` or
//! from a GUI recording, into a [`Run`] whose ticks carry every logged column. What the log
//! does not hold (velocities, normals, tangents, CP and GO parameters, the feature) is zero;
//! [`RunLog::has_parameters`] is false.

use std::path::{Path, PathBuf};

use friction::{FrictionMaterial, Mode, SwitchCause};
use nurbs::Vec3;

use crate::sim::{DEVICE_COLUMNS, DeviceSample, Run, Tick, csv_header};
use scene::Space;

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

/// Parses a run log's text; errors name `path` and the line.
pub fn parse(text: &str, path: &Path) -> Result<RunLog, RunLogError> {
    let mut lines = text.lines();
    let header = lines.next().unwrap_or("").trim();
    let (space, device) = [Space::Planar, Space::Spatial]
        .into_iter()
        .flat_map(|space| [(space, false), (space, true)])
        .find(|&(space, device)| {
            let base = csv_header(space);
            if device {
                header == format!("{base},{DEVICE_COLUMNS}")
            } else {
                header == base
            }
        })
        .ok_or_else(|| RunLogError::Header {
            path: path.to_owned(),
        })?;
    let dim = space.dim();
    let columns = 1 + 4 * dim + 8 + if device { 5 } else { 0 };
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{self, Trajectory};
    use scene::Scene;

    /// A `sim --device` run written and read back gives the same logged columns.
    #[test]
    fn round_trip_of_a_device_run() {
        let scene = Scene::from_json_str(include_str!("../../../scenes/thesis-2d.json"))
            .unwrap_or_else(|e| panic!("{e}"));
        let trajectory = Trajectory::parse("t,x,y\n0,0.0,0.1\n0.3,0.0,0.09\n", Path::new("t.csv"))
            .unwrap_or_else(|e| panic!("{e}"));
        let run = sim::run_device(
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
    }
}
