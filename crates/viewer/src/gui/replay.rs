//! Replaying a run log (from `viewer sim --out` or a `--record`ing) through the app's views
//! and plots: a cursor over the log's time, played at a chosen speed or scrubbed. The views
//! read the same history they read from the live loop: the [`HISTORY_S`] seconds of ticks up
//! to the cursor, as the loop would have sent them.

use std::path::Path;

use host::backend::Sample;
use host::runlog::{self, RunLogError};
use host::tick::Tick;
use scene::Space;

use super::telemetry::HISTORY_S;

/// Replay speeds the UI offers (× real time).
pub const SPEEDS: [f64; 5] = [0.1, 0.25, 0.5, 1.0, 2.0];

/// A run log being replayed.
#[derive(Clone, Debug, PartialEq)]
pub struct Replay {
    /// Where it came from.
    pub label: String,
    ticks: Vec<Tick>,
    /// The cursor (s, the log's time).
    cursor_s: f64,
    /// Whether it plays.
    pub playing: bool,
    /// Speed (× real time).
    pub speed: f64,
    /// The log's space: a planar run (2-D view) or a run on surfaces (3-D view).
    pub space: Space,
}

impl Replay {
    /// Reads the run log at `path`; the cursor at its start, paused.
    pub fn open(path: &Path) -> Result<Self, RunLogError> {
        let log = runlog::read(path)?;
        Ok(Replay {
            space: log.run.space,
            ..Self::of(path.display().to_string(), log.run.ticks)
        })
    }

    /// A replay of the planar `ticks` (non-empty, in time order, as a run log holds them).
    pub fn of(label: String, ticks: Vec<Tick>) -> Self {
        let cursor_s = ticks.first().map_or(0.0, |t| t.t_s);
        Replay {
            label,
            ticks,
            cursor_s,
            playing: false,
            speed: 1.0,
            space: Space::Planar,
        }
    }

    /// The log's first and last tick times (s).
    pub fn span(&self) -> (f64, f64) {
        match (self.ticks.first(), self.ticks.last()) {
            (Some(a), Some(b)) => (a.t_s, b.t_s),
            _ => (0.0, 0.0),
        }
    }

    /// The cursor (s).
    pub fn cursor(&self) -> f64 {
        self.cursor_s
    }

    /// Moves the cursor to `t_s`, clamped to the log's span (a non-finite time is ignored).
    pub fn seek(&mut self, t_s: f64) {
        if t_s.is_finite() {
            let (a, b) = self.span();
            self.cursor_s = t_s.clamp(a, b);
        }
    }

    /// Advances a playing replay by `wall_s` seconds of real time at its speed; it pauses at
    /// the end.
    pub fn advance(&mut self, wall_s: f64) {
        if !(self.playing && wall_s.is_finite() && wall_s > 0.0) {
            return;
        }
        let (_, end) = self.span();
        self.seek(self.cursor_s + wall_s * self.speed);
        if self.cursor_s >= end {
            self.playing = false;
        }
    }

    /// Index one past the last tick at or before the cursor.
    fn end_index(&self) -> usize {
        self.ticks.partition_point(|t| t.t_s <= self.cursor_s)
    }

    /// The ticks of the [`HISTORY_S`] seconds up to the cursor, as the live loop's samples:
    /// the period is the log's own time step, the hand's target the HIP (a log does not hold
    /// the target), the forces on when the tick rendered a force or was in contact.
    pub fn window(&self) -> impl Iterator<Item = Sample> + '_ {
        let end = self.end_index();
        let start = self.ticks[..end].partition_point(|t| t.t_s < self.cursor_s - HISTORY_S);
        (start..end).map(move |i| {
            let tick = self.ticks[i];
            let period_us = i
                .checked_sub(1)
                .map(|j| ((tick.t_s - self.ticks[j].t_s) * 1e6) as f32);
            Sample {
                tick,
                hand_target: nurbs::Vec2::new(tick.hip.x, tick.hip.y),
                period_us,
                forces_enabled: true,
            }
        })
    }

    /// Ticks in the log.
    pub fn len(&self) -> usize {
        self.ticks.len()
    }

    /// Whether the log is empty (a run log never is).
    pub fn is_empty(&self) -> bool {
        self.ticks.is_empty()
    }
}
