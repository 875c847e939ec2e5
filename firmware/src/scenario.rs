//! The compact scenario table the QEMU binary runs: what the host's `viewer sim --device`
//! computes before its loop (tick rate, ramp-in time, end-stop counts, start point and the
//! hand's target at every tick), converted by `cargo xtask qemu` with the host crates so the
//! MCU needs no CSV or JSON parser and takes the same f32 values the host's loop does.
//!
//! Layout, little-endian (written by `xtask/src/main.rs`, `scenario_table`):
//!
//! | bytes | field |
//! |---|---|
//! | 4 | magic `HSCN` |
//! | 1 | version, [`VERSION`] |
//! | 1 | name length `L` |
//! | L | scene name, UTF-8 |
//! | 8 | tick rate (Hz), f64 |
//! | 4 | ramp-in time (s), f32 |
//! | 8 | end-stop encoder counts, 2 × i32 |
//! | 8 | start of the HIP (m), 2 × f32 |
//! | 4 | tick count `N`, u32 |
//! | 8 N | the hand's target at each tick (m), 2 × f32 |

use nurbs::Vec2;

/// First bytes of a scenario table.
pub const MAGIC: [u8; 4] = *b"HSCN";
/// Version of the layout.
pub const VERSION: u8 = 1;

/// Why a table was refused: the field and its byte offset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScenarioError {
    /// Byte offset of the field.
    pub offset: usize,
    /// The field (as in the layout table).
    pub field: &'static str,
    /// What is wrong with it.
    pub problem: &'static str,
}

impl core::fmt::Display for ScenarioError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "scenario table, byte {}: {}: {}",
            self.offset, self.field, self.problem
        )
    }
}

/// A parsed scenario table, borrowing its bytes.
#[derive(Clone, Copy, Debug)]
pub struct Scenario<'a> {
    /// The scene's name (e.g. `thesis-2d`).
    pub name: &'a str,
    /// Tick rate (Hz).
    pub rate_hz: f64,
    /// The safety layer's ramp-in time (s).
    pub ramp_time_s: f32,
    /// Raw encoder counts with both joints on their end stops (calibration).
    pub end_stop_counts: [i32; 2],
    /// Where the HIP starts (m).
    pub start_m: Vec2,
    targets: &'a [u8],
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    /// The header both tables start with: `magic` (`wrong` when it differs), the version,
    /// the scene's name and the tick rate; returns the name and the rate.
    fn header(
        &mut self,
        magic: [u8; 4],
        wrong: &'static str,
    ) -> Result<(&'a str, f64), ScenarioError> {
        let bad = |offset, field, problem| ScenarioError {
            offset,
            field,
            problem,
        };
        if self.array::<4>("magic")? != magic {
            return Err(bad(0, "magic", wrong));
        }
        if self.array::<1>("version")?[0] != VERSION {
            return Err(bad(4, "version", "unknown version"));
        }
        let len = usize::from(self.array::<1>("name length")?[0]);
        let at = self.at;
        let name = core::str::from_utf8(self.take(len, "name")?)
            .map_err(|_| bad(at, "name", "not UTF-8"))?;
        let at = self.at;
        let rate_hz = f64::from_le_bytes(self.array("tick rate")?);
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(bad(at, "tick rate", "not finite and positive"));
        }
        Ok((name, rate_hz))
    }

    fn take(&mut self, n: usize, field: &'static str) -> Result<&'a [u8], ScenarioError> {
        let end = self.at.checked_add(n);
        let got = end.and_then(|end| self.bytes.get(self.at..end));
        match (got, end) {
            (Some(b), Some(end)) => {
                self.at = end;
                Ok(b)
            }
            _ => Err(ScenarioError {
                offset: self.at,
                field,
                problem: "truncated",
            }),
        }
    }

    fn array<const N: usize>(&mut self, field: &'static str) -> Result<[u8; N], ScenarioError> {
        let mut a = [0u8; N];
        a.copy_from_slice(self.take(N, field)?);
        Ok(a)
    }

    fn f32(&mut self, field: &'static str) -> Result<f32, ScenarioError> {
        let at = self.at;
        let v = f32::from_le_bytes(self.array(field)?);
        if v.is_finite() {
            Ok(v)
        } else {
            Err(ScenarioError {
                offset: at,
                field,
                problem: "not finite",
            })
        }
    }
}

impl<'a> Scenario<'a> {
    /// Parses a table; every field is checked (finite numbers, a positive rate, the target
    /// list as long as its count says and nothing after it).
    pub fn parse(bytes: &'a [u8]) -> Result<Self, ScenarioError> {
        let r = &mut Reader { bytes, at: 0 };
        let bad = |offset, field, problem| ScenarioError {
            offset,
            field,
            problem,
        };
        let (name, rate_hz) = r.header(MAGIC, "not HSCN")?;
        let at = r.at;
        let ramp_time_s = r.f32("ramp-in time")?;
        if ramp_time_s <= 0.0 {
            return Err(bad(at, "ramp-in time", "not positive"));
        }
        let end_stop_counts = [
            i32::from_le_bytes(r.array("end-stop counts")?),
            i32::from_le_bytes(r.array("end-stop counts")?),
        ];
        let start_m = Vec2::new(r.f32("start")?, r.f32("start")?);
        let at = r.at;
        let n = u32::from_le_bytes(r.array("tick count")?) as usize;
        let len = n.checked_mul(8).ok_or(bad(at, "tick count", "too large"))?;
        let targets = r.take(len, "targets")?;
        if r.at != bytes.len() {
            return Err(bad(r.at, "targets", "bytes after the last target"));
        }
        let scenario = Scenario {
            name,
            rate_hz,
            ramp_time_s,
            end_stop_counts,
            start_m,
            targets,
        };
        for i in 0..n {
            scenario.target(i).map_err(|mut e| {
                e.offset += at + 4;
                e
            })?;
        }
        Ok(scenario)
    }

    /// Number of ticks.
    pub fn ticks(&self) -> usize {
        self.targets.len() / 8
    }

    /// The hand's target at tick `i` (m); an error past the end.
    pub fn target(&self, i: usize) -> Result<Vec2, ScenarioError> {
        let r = &mut Reader {
            bytes: self.targets,
            at: i.saturating_mul(8),
        };
        Ok(Vec2::new(r.f32("target")?, r.f32("target")?))
    }
}

/// First bytes of a HIP-path table.
pub const PATH_MAGIC: [u8; 4] = *b"HPTH";

/// A prescribed path of the HIP in space, tick by tick, for a renderer run on its own (a
/// surface: the planar pantograph cannot reach it). Layout, little-endian (written by
/// `xtask/src/qemu.rs`, `path_table`):
///
/// | bytes | field |
/// |---|---|
/// | 4 | magic `HPTH` |
/// | 1 | version, [`VERSION`] |
/// | 1 | name length `L` |
/// | L | scene name, UTF-8 |
/// | 8 | tick rate (Hz), f64 |
/// | 4 | tick count `N`, u32 |
/// | 12 N | the HIP at each tick (m), 3 × f32 |
#[derive(Clone, Copy, Debug)]
pub struct HipPath<'a> {
    /// The scene's name.
    pub name: &'a str,
    /// Tick rate (Hz).
    pub rate_hz: f64,
    points: &'a [u8],
}

impl<'a> HipPath<'a> {
    /// Parses a table; every field is checked as in [`Scenario::parse`].
    pub fn parse(bytes: &'a [u8]) -> Result<Self, ScenarioError> {
        let r = &mut Reader { bytes, at: 0 };
        let bad = |offset, field, problem| ScenarioError {
            offset,
            field,
            problem,
        };
        let (name, rate_hz) = r.header(PATH_MAGIC, "not HPTH")?;
        let at = r.at;
        let n = u32::from_le_bytes(r.array("tick count")?) as usize;
        let len = n
            .checked_mul(12)
            .ok_or(bad(at, "tick count", "too large"))?;
        let points = r.take(len, "points")?;
        if r.at != bytes.len() {
            return Err(bad(r.at, "points", "bytes after the last point"));
        }
        let path = HipPath {
            name,
            rate_hz,
            points,
        };
        for i in 0..n {
            path.point(i).map_err(|mut e| {
                e.offset += at + 4;
                e
            })?;
        }
        Ok(path)
    }

    /// Number of ticks.
    pub fn ticks(&self) -> usize {
        self.points.len() / 12
    }

    /// The HIP at tick `i` (m); an error past the end.
    pub fn point(&self, i: usize) -> Result<nurbs::Vec3, ScenarioError> {
        let r = &mut Reader {
            bytes: self.points,
            at: i.saturating_mul(12),
        };
        Ok(nurbs::Vec3::new(
            r.f32("point")?,
            r.f32("point")?,
            r.f32("point")?,
        ))
    }
}
