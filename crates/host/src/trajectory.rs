//! Prescribed HIP paths for `sim`: a CSV file of timed positions, linearly interpolated.
//!
//! ```text
//! # comment lines and blank lines are skipped
//! t,x,y
//! 0.0, 0.0, 0.1
//! 0.5, 0.0, 0.078
//! 1.5, 0.02, 0.078
//! ```
//!
//! The header is `t,x,y` (a planar path) or `t,x,y,z` (a spatial one); every following line
//! has that many comma-separated numbers: time in seconds, position in metres in the device
//! frame. Times strictly increase, every value is finite (times within the range of `f32`,
//! positions within ±[`nurbs::MAX_COORDINATE`] m), and there are at least two rows.
//! Spaces around values and Windows line ends are accepted.

use std::path::{Path, PathBuf};

use scene::Space;

/// A validated trajectory: at least two samples, strictly increasing finite times, finite
/// positions (`z = 0` for planar ones).
#[derive(Clone, Debug, PartialEq)]
pub struct Trajectory {
    space: Space,
    times_s: Vec<f64>,
    points: Vec<[f64; 3]>,
}

/// Why a trajectory was rejected. File errors name the file and the line (from 1).
#[derive(Debug, thiserror::Error)]
pub enum TrajectoryError {
    /// The file could not be read (missing, unreadable, not UTF-8).
    #[error("cannot read {}: {error}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// A bad line of the file.
    #[error("{}: line {line}: {problem}", path.display())]
    Line {
        /// The file.
        path: PathBuf,
        /// Line number, from 1.
        line: usize,
        /// What is wrong.
        problem: TrajectoryProblem,
    },
    /// A bad sample given to [`Trajectory::from_samples`].
    #[error("sample {index}: {problem}")]
    Sample {
        /// Index of the sample, from 0.
        index: usize,
        /// What is wrong.
        problem: TrajectoryProblem,
    },
}

impl TrajectoryError {
    /// The line number (from 1) of a file error.
    pub fn line(&self) -> Option<usize> {
        match self {
            TrajectoryError::Line { line, .. } => Some(*line),
            _ => None,
        }
    }

    /// What is wrong, for a line or sample error.
    pub fn problem(&self) -> Option<&TrajectoryProblem> {
        match self {
            TrajectoryError::Line { problem, .. } | TrajectoryError::Sample { problem, .. } => {
                Some(problem)
            }
            TrajectoryError::Read { .. } => None,
        }
    }
}

/// What is wrong with a line of a trajectory.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TrajectoryProblem {
    /// No header (the file is empty or only comments).
    #[error("no header: expected `t,x,y` or `t,x,y,z`")]
    Empty,
    /// The header is not `t,x,y` or `t,x,y,z`.
    #[error("header `{found}`: expected `t,x,y` or `t,x,y,z`")]
    Header {
        /// The line as found.
        found: String,
    },
    /// A row with the wrong number of values.
    #[error("{found} value(s), expected {expected} ({})", HEADERS[*expected - 3])]
    Columns {
        /// Values in the header.
        expected: usize,
        /// Values found.
        found: usize,
    },
    /// A value that is not a number.
    #[error("{column}: `{value}` is not a number")]
    NotANumber {
        /// Its column (`t`, `x`, `y` or `z`).
        column: &'static str,
        /// The text found.
        value: String,
    },
    /// NaN or an infinity.
    #[error("{column}: {value} is not a finite number")]
    NotFinite {
        /// Its column.
        column: &'static str,
        /// The text found.
        value: String,
    },
    /// A finite number the loop cannot use: a time that overflows its `f32`, or a position
    /// beyond [`nurbs::MAX_COORDINATE`] metres, the range scene coordinates are held to.
    #[error("{column}: {value} is outside [-{max:e}, {max:e}], {why}")]
    OutOfRange {
        /// Its column.
        column: &'static str,
        /// The text found.
        value: String,
        /// The bound.
        max: f64,
        /// What the bound is.
        why: &'static str,
    },
    /// A time not after the previous one.
    #[error("t = {t} is not after the previous time {previous}; times must strictly increase")]
    NotIncreasing {
        /// This row's time.
        t: f64,
        /// The previous row's time.
        previous: f64,
    },
    /// Fewer than two rows.
    #[error("{found} data row(s); a trajectory needs at least 2")]
    TooFewRows {
        /// Rows found.
        found: usize,
    },
}

const HEADERS: [&str; 2] = ["t,x,y", "t,x,y,z"];
const COLUMNS: [&str; 4] = ["t", "x", "y", "z"];

impl Trajectory {
    /// Reads and validates a trajectory file; errors name the file and line.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, TrajectoryError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|error| TrajectoryError::Read {
            path: path.to_owned(),
            error,
        })?;
        Self::parse(&text, path)
    }

    /// Parses and validates the text of a trajectory file; `path` is only used in errors.
    pub fn parse(text: &str, path: impl AsRef<Path>) -> Result<Self, TrajectoryError> {
        let at = |line: usize, problem| TrajectoryError::Line {
            path: path.as_ref().to_owned(),
            line,
            problem,
        };
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut lines = text
            .split('\n')
            .enumerate()
            .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l).trim()))
            .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
        let last_line = text.trim_end().split('\n').count().max(1);
        let Some((header_line, header)) = lines.next() else {
            return Err(at(last_line, TrajectoryProblem::Empty));
        };
        let names: Vec<&str> = header.split(',').map(str::trim).collect();
        let space = match names.as_slice() {
            ["t", "x", "y"] => Space::Planar,
            ["t", "x", "y", "z"] => Space::Spatial,
            _ => {
                return Err(at(
                    header_line,
                    TrajectoryProblem::Header {
                        found: header.to_owned(),
                    },
                ));
            }
        };
        let mut builder = Builder::new(space);
        for (line, row) in lines {
            let values = parse_row(row, space).map_err(|p| at(line, p))?;
            builder.push(values).map_err(|p| at(line, p))?;
        }
        builder.finish().map_err(|p| at(last_line, p))
    }

    /// A trajectory of `(t, [x, y, z])` samples (`z` ignored for a planar one), validated like
    /// a file.
    pub fn from_samples(
        space: Space,
        samples: impl IntoIterator<Item = (f64, [f64; 3])>,
    ) -> Result<Self, TrajectoryError> {
        let mut builder = Builder::new(space);
        let mut count = 0;
        for (index, (t, p)) in samples.into_iter().enumerate() {
            let mut values = [t, p[0], p[1], p[2]];
            if space == Space::Planar {
                values[3] = 0.0;
            }
            for (column, v) in COLUMNS.into_iter().zip(values) {
                check_value(column, v, &v.to_string())
                    .map_err(|problem| TrajectoryError::Sample { index, problem })?;
            }
            builder
                .push(values)
                .map_err(|problem| TrajectoryError::Sample { index, problem })?;
            count = index + 1;
        }
        builder.finish().map_err(|problem| TrajectoryError::Sample {
            index: count.saturating_sub(1),
            problem,
        })
    }

    /// Planar (`t,x,y`) or spatial (`t,x,y,z`).
    pub fn space(&self) -> Space {
        self.space
    }

    /// The sample times (s), strictly increasing.
    pub fn times_s(&self) -> &[f64] {
        &self.times_s
    }

    /// The sample positions (m), `z = 0` for a planar trajectory.
    pub fn points(&self) -> &[[f64; 3]] {
        &self.points
    }

    /// First sample time (s).
    pub fn start_s(&self) -> f64 {
        self.times_s[0]
    }

    /// Last sample time (s).
    pub fn end_s(&self) -> f64 {
        self.times_s[self.times_s.len() - 1]
    }

    /// The position at `t_s` by linear interpolation between the samples around it; the first
    /// or last position outside the sampled time.
    pub fn at(&self, t_s: f64) -> [f64; 3] {
        let n = self.times_s.len();
        // First sample strictly after t: the segment is the one before it.
        let after = self.times_s.partition_point(|&x| x <= t_s);
        if after == 0 {
            return self.points[0];
        }
        if after == n {
            return self.points[n - 1];
        }
        let (k0, k1) = (after - 1, after);
        let s = (t_s - self.times_s[k0]) / (self.times_s[k1] - self.times_s[k0]);
        let (a, b) = (self.points[k0], self.points[k1]);
        [0, 1, 2].map(|i| a[i] + (b[i] - a[i]) * s)
    }

    /// Number of ticks at `rate_hz` from the first to the last sample time, both included
    /// when the duration is a whole number of periods: `⌊duration · rate⌋ + 1`.
    pub fn tick_count(&self, rate_hz: f64) -> f64 {
        // The epsilon keeps a whole number of periods whole despite rounding (1.5 s · 1000).
        ((self.end_s() - self.start_s()) * rate_hz + 1e-9).floor() + 1.0
    }

    /// Time of tick `i` at `rate_hz` (s).
    pub fn tick_time_s(&self, i: usize, rate_hz: f64) -> f64 {
        self.start_s() + i as f64 / rate_hz
    }
}

/// Collects rows and checks the order of times.
struct Builder {
    space: Space,
    times_s: Vec<f64>,
    points: Vec<[f64; 3]>,
}

impl Builder {
    fn new(space: Space) -> Self {
        Builder {
            space,
            times_s: Vec::new(),
            points: Vec::new(),
        }
    }

    fn push(&mut self, [t, x, y, z]: [f64; 4]) -> Result<(), TrajectoryProblem> {
        if let Some(&previous) = self.times_s.last().filter(|&&p| t <= p) {
            return Err(TrajectoryProblem::NotIncreasing { t, previous });
        }
        self.times_s.push(t);
        self.points.push([x, y, z]);
        Ok(())
    }

    fn finish(self) -> Result<Trajectory, TrajectoryProblem> {
        if self.times_s.len() < 2 {
            return Err(TrajectoryProblem::TooFewRows {
                found: self.times_s.len(),
            });
        }
        Ok(Trajectory {
            space: self.space,
            times_s: self.times_s,
            points: self.points,
        })
    }
}

/// `[t, x, y, z]` of one data line (`z = 0` for a planar one).
fn parse_row(row: &str, space: Space) -> Result<[f64; 4], TrajectoryProblem> {
    let expected = space.dim() + 1;
    let fields: Vec<&str> = row.split(',').map(str::trim).collect();
    if fields.len() != expected {
        return Err(TrajectoryProblem::Columns {
            expected,
            found: fields.len(),
        });
    }
    let mut values = [0.0; 4];
    for ((v, column), text) in values.iter_mut().zip(COLUMNS).zip(fields) {
        *v = text
            .parse::<f64>()
            .map_err(|_| TrajectoryProblem::NotANumber {
                column,
                value: text.to_owned(),
            })?;
        check_value(column, *v, text)?;
    }
    Ok(values)
}

/// A value of column `column` (`text` as written, for the message) that the loop can use: finite,
/// a time within `f32`'s range (the loop's type), a position within ±[`nurbs::MAX_COORDINATE`]
/// metres (which also keeps it finite in `f32`).
fn check_value(column: &'static str, v: f64, text: &str) -> Result<(), TrajectoryProblem> {
    if !v.is_finite() {
        return Err(TrajectoryProblem::NotFinite {
            column,
            value: text.to_owned(),
        });
    }
    let (max, why) = if column == "t" {
        (
            f64::from(f32::MAX),
            "the range of the f32 the loop computes in",
        )
    } else {
        (
            f64::from(nurbs::MAX_COORDINATE),
            "the coordinate range of scenes (metres, nurbs::MAX_COORDINATE)",
        )
    };
    if v.abs() > max {
        return Err(TrajectoryProblem::OutOfRange {
            column,
            value: text.to_owned(),
            max,
            why,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Trajectory, TrajectoryError> {
        Trajectory::parse(text, "path/traj.csv")
    }

    /// The error message and line of a bad file.
    fn error(text: &str) -> (String, Option<usize>) {
        match parse(text) {
            Ok(t) => panic!("expected an error, got {t:?}"),
            Err(e) => (e.to_string(), e.line()),
        }
    }

    #[test]
    fn planar_and_spatial() {
        let t = parse("t,x,y\n0,0,0.1\n0.5,0.01,0.09\n").expect("valid");
        assert_eq!(t.space(), Space::Planar);
        assert_eq!(t.times_s(), [0.0, 0.5]);
        assert_eq!(t.points(), [[0.0, 0.1, 0.0], [0.01, 0.09, 0.0]]);
        let t = parse("# a comment\r\n\r\n t , x , y , z \r\n0, 1, 2, 3\r\n1, 4, 5, 6\r\n\r\n")
            .expect("valid with CRLF, spaces, comments and blank lines");
        assert_eq!(t.space(), Space::Spatial);
        assert_eq!(t.points(), [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
        assert_eq!((t.start_s(), t.end_s()), (0.0, 1.0));
        let t = parse("\u{feff}t,x,y\n-1,0,0\n2e-3,0,0\n").expect("BOM, exponents");
        assert_eq!(t.times_s(), [-1.0, 0.002]);
    }

    #[test]
    fn each_error_names_the_file_and_line() {
        let cases: [(&str, usize, &str); 12] = [
            ("", 1, "no header: expected `t,x,y` or `t,x,y,z`"),
            ("# only\n\n", 1, "no header"),
            ("time,x,y\n0,0,0\n", 1, "header `time,x,y`: expected"),
            ("t,x\n0,0\n", 1, "header `t,x`"),
            ("t,x,y\n0,0,0\n1,0\n", 3, "2 value(s), expected 3 (t,x,y)"),
            (
                "t,x,y,z\n0,0,0,0\n1,0,0,0,0\n",
                3,
                "5 value(s), expected 4 (t,x,y,z)",
            ),
            ("t,x,y\n0,0,0\n1,0,abc\n", 3, "y: `abc` is not a number"),
            ("t,x,y\n0,,0\n1,0,0\n", 2, "x: `` is not a number"),
            (
                "t,x,y\n0,0,0\nNaN,0,0\n",
                3,
                "t: NaN is not a finite number",
            ),
            (
                "t,x,y\n0,0,0\n1,inf,0\n",
                3,
                "x: inf is not a finite number",
            ),
            (
                "t,x,y\n0,0,0\n# c\n0.5,0,0\n0.4,0,0\n",
                5,
                "t = 0.4 is not after the previous time 0.5; times must strictly increase",
            ),
            (
                "t,x,y\n0,0,0\n",
                2,
                "1 data row(s); a trajectory needs at least 2",
            ),
        ];
        for (text, line, message) in cases {
            let (msg, at) = error(text);
            assert_eq!(at, Some(line), "{text:?}: {msg}");
            let prefix = format!("path/traj.csv: line {line}: ");
            assert!(msg.starts_with(&prefix), "{text:?}: {msg}");
            assert!(msg.contains(message), "{text:?}: {msg} lacks {message:?}");
        }
        // Finite in f64 but not usable by the f32 loop (1e39 used to give hip_x = inf in the
        // run log, with exit 0).
        for (text, line, message) in [
            (
                "t,x,y\n0,0,0\n1,1e39,0\n",
                3,
                "x: 1e39 is outside [-1e6, 1e6]",
            ),
            (
                "t,x,y,z\n0,0,0,0\n1,0,0,-3e7\n",
                3,
                "z: -3e7 is outside [-1e6, 1e6]",
            ),
            (
                "t,x,y\n0,0,0\n1e39,0,0\n",
                3,
                "t: 1e39 is outside [-3.4028234663852886e38",
            ),
        ] {
            let (msg, at) = error(text);
            assert_eq!(at, Some(line), "{text:?}: {msg}");
            assert!(
                msg.starts_with(&format!("path/traj.csv: line {line}: ")),
                "{msg}"
            );
            assert!(msg.contains(message), "{text:?}: {msg} lacks {message:?}");
        }
        // The bound itself is usable.
        assert!(parse("t,x,y\n0,0,0\n1,1e6,-1e6\n").is_ok());
        // Equal times are not increasing either.
        let (msg, at) = error("t,x,y\n0,0,0\n0,1,1\n");
        assert_eq!(at, Some(3));
        assert!(
            msg.contains("t = 0 is not after the previous time 0"),
            "{msg}"
        );
        // The header alone: no rows, reported at the header's line.
        let (msg, at) = error("t,x,y,z\n");
        assert_eq!(at, Some(1));
        assert!(msg.contains("0 data row(s)"), "{msg}");
    }

    #[test]
    fn missing_file_names_it() {
        let e = Trajectory::load("no/such/traj.csv").expect_err("missing");
        assert!(
            e.to_string().starts_with("cannot read no/such/traj.csv"),
            "{e}"
        );
        assert_eq!(e.line(), None);
    }

    #[test]
    fn interpolation_is_exact_at_knots_and_linear_between() {
        let t =
            parse("t,x,y,z\n0,0,0.1,0\n0.5,0.02,0.08,-0.01\n2,-0.04,0.08,0.05\n").expect("valid");
        assert_eq!(t.at(0.0), [0.0, 0.1, 0.0]);
        assert_eq!(t.at(0.5), [0.02, 0.08, -0.01]);
        assert_eq!(t.at(2.0), [-0.04, 0.08, 0.05]);
        // Outside: held at the ends.
        assert_eq!(t.at(-1.0), [0.0, 0.1, 0.0]);
        assert_eq!(t.at(3.0), [-0.04, 0.08, 0.05]);
        // Between: the straight line, checked at the thirds of each segment.
        let close = |a: [f64; 3], b: [f64; 3]| (0..3).all(|i| (a[i] - b[i]).abs() < 1e-15);
        assert!(close(t.at(0.25), [0.01, 0.09, -0.005]), "{:?}", t.at(0.25));
        assert!(close(t.at(1.0), [0.0, 0.08, 0.01]), "{:?}", t.at(1.0));
        assert!(close(t.at(1.5), [-0.02, 0.08, 0.03]), "{:?}", t.at(1.5));
    }

    #[test]
    fn ticks_cover_the_sampled_time() {
        let t = parse("t,x,y\n0.5,0,0\n2,0,0\n").expect("valid");
        assert_eq!(t.tick_count(1000.0), 1501.0);
        assert_eq!(t.tick_time_s(0, 1000.0), 0.5);
        assert_eq!(t.tick_time_s(1500, 1000.0), 2.0);
        // Not a whole number of periods: the last tick is before the end.
        assert_eq!(t.tick_count(3.0), 5.0);
        assert!(t.tick_time_s(4, 3.0) <= 2.0);
    }

    #[test]
    fn samples_are_validated_like_files() {
        let t = Trajectory::from_samples(
            Space::Planar,
            [(0.0, [0.0, 0.1, 7.0]), (1.0, [0.01, 0.1, 7.0])],
        )
        .expect("valid");
        assert_eq!(t.points()[0], [0.0, 0.1, 0.0]);
        let e = Trajectory::from_samples(
            Space::Spatial,
            [(0.0, [0.0; 3]), (1.0, [0.0, f64::NAN, 0.0])],
        )
        .expect_err("NaN");
        assert_eq!(e.to_string(), "sample 1: y: NaN is not a finite number");
        let e = Trajectory::from_samples(Space::Planar, [(0.0, [0.0; 3]), (1.0, [0.0, 2e6, 0.0])])
            .expect_err("beyond the coordinate range");
        assert!(
            e.to_string()
                .starts_with("sample 1: y: 2000000 is outside [-1e6, 1e6]"),
            "{e}"
        );
        let e = Trajectory::from_samples(Space::Spatial, [(0.0, [0.0; 3])]).expect_err("one");
        assert!(e.to_string().contains("at least 2"), "{e}");
    }
}
