//! The telemetry the app keeps of the loop it runs (or of the run log it replays): the last
//! [`HISTORY_S`] seconds of samples, which the views, the plots and the status bar read, the
//! mode switches seen, and the statistics of the loop's tick period and of the UI's frames.

use std::collections::VecDeque;

use friction::{Mode, SwitchCause};
use host::backend::{self, Sample};

/// Seconds of telemetry the plots show.
pub const HISTORY_S: f64 = 5.0;
/// Samples in the tick-jitter statistics window (1 s at 1 kHz).
pub const JITTER_WINDOW: usize = 1000;
/// Frames in the frame-time statistics window.
pub const FRAME_WINDOW: usize = 120;

/// The telemetry, shared by the panels and the views.
#[derive(Clone, Debug, Default)]
pub struct Telemetry {
    /// The last [`HISTORY_S`] seconds of samples.
    pub history: VecDeque<Sample>,
    /// Recent tick periods (µs), for the jitter shown live.
    pub recent_periods: VecDeque<f32>,
    /// Tick-period statistics since the loop started.
    pub jitter: JitterStats,
    /// Recent frame intervals (ms) and the time the UI spent per frame (ms).
    pub frames: VecDeque<(f32, f32)>,
    /// The mode switches seen, newest last (at most 64).
    pub switches: VecDeque<Switch>,
    /// Samples received in all.
    pub received: u64,
    /// The mode of the last sample pushed, which a switch is noted against; none after a
    /// scene opened or the history was forgotten.
    last_mode: Option<Mode>,
    /// Whose ticks the history holds: the spatial hand's loop (`true`) or the planar
    /// device's; `None` before the first poll.
    pub spatial_source: Option<bool>,
}

impl Telemetry {
    /// Takes in one live sample: its period into the tick statistics, itself into the
    /// history. (The app counts it in [`Telemetry::received`] itself, replay or not.)
    pub fn take(&mut self, s: Sample) {
        if let Some(p) = s.period_us {
            self.jitter.add(p);
            if self.recent_periods.len() == JITTER_WINDOW {
                self.recent_periods.pop_front();
            }
            self.recent_periods.push_back(p);
        }
        self.push(s);
    }

    /// Appends `s` to the history (noting a mode switch) and drops what is older than
    /// [`HISTORY_S`]: a live sample, or one of a replay's window.
    pub fn push(&mut self, s: Sample) {
        // A tick older than the newest is another loop's (another scene's hand started its
        // clock again): the history so far is not on its time axis.
        if self.history.back().is_some_and(|b| s.tick.t_s < b.tick.t_s) {
            self.history.clear();
            self.switches.clear();
            self.last_mode = None;
        }
        if let Some(last) = self.last_mode
            && last != s.tick.mode
        {
            if self.switches.len() == 64 {
                self.switches.pop_front();
            }
            self.switches.push_back(Switch {
                t_s: s.tick.t_s,
                from: last,
                to: s.tick.mode,
                cause: s.tick.cause,
            });
        }
        self.last_mode = Some(s.tick.mode);
        self.history.push_back(s);
        while let Some(first) = self.history.front() {
            if s.tick.t_s - first.tick.t_s > HISTORY_S {
                self.history.pop_front();
            } else {
                break;
            }
        }
    }

    /// Forgets the history and the switches (a replay opens, moves or closes).
    pub fn clear_history(&mut self) {
        self.history.clear();
        self.switches.clear();
        self.last_mode = None;
    }

    /// Forgets the switches (another scene opened: they were the previous scene's), and the
    /// mode they were noted against, so that the new scene's first sample is no switch.
    /// The history stays for the plots, which scroll it out.
    pub fn scene_opened(&mut self) {
        self.switches.clear();
        self.last_mode = None;
    }

    /// Forgets the history and the tick statistics (another loop starts: a device switch).
    pub fn restart(&mut self) {
        self.history.clear();
        self.last_mode = None;
        self.recent_periods.clear();
        self.jitter = JitterStats::default();
    }

    /// The newest sample.
    pub fn latest(&self) -> Option<&Sample> {
        self.history.back()
    }

    /// Records one frame: the interval since the previous one and the UI's own time (ms).
    pub fn record_frame(&mut self, interval_ms: f32, ui_ms: f32) {
        if self.frames.len() == FRAME_WINDOW {
            self.frames.pop_front();
        }
        self.frames.push_back((interval_ms, ui_ms));
    }

    /// Mean and largest recent frame interval (ms), and the mean UI time (ms).
    pub fn frame_stats(&self) -> Option<(f32, f32, f32)> {
        if self.frames.is_empty() {
            return None;
        }
        let n = self.frames.len() as f32;
        let mean = self.frames.iter().map(|f| f.0).sum::<f32>() / n;
        let max = self.frames.iter().map(|f| f.0).fold(0.0, f32::max);
        let ui = self.frames.iter().map(|f| f.1).sum::<f32>() / n;
        Some((mean, max, ui))
    }

    /// Mean recent tick period and largest and 99th-percentile |period − 1 ms| (µs), over
    /// the last [`JITTER_WINDOW`] ticks received.
    pub fn recent_jitter(&self) -> Option<(f32, f32, f32)> {
        if self.recent_periods.is_empty() {
            return None;
        }
        let nominal = 1e6 / backend::RATE_HZ as f32;
        let n = self.recent_periods.len();
        let mean = self.recent_periods.iter().sum::<f32>() / n as f32;
        let mut dev: Vec<f32> = self
            .recent_periods
            .iter()
            .map(|p| (p - nominal).abs())
            .collect();
        dev.sort_by(f32::total_cmp);
        let p99 = dev[((n as f32 * 0.99).ceil() as usize).clamp(1, n) - 1];
        Some((mean, dev[n - 1], p99))
    }
}

/// Running statistics of the loop's tick period.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct JitterStats {
    /// Periods seen (µs).
    pub count: u64,
    sum_us: f64,
    /// Largest |period − 1 ms| seen (µs).
    pub max_abs_us: f32,
    /// Histogram of |period − 1 ms| in 10 µs bins (the last bin: 10 ms and more).
    bins: Vec<u64>,
}

impl JitterStats {
    fn add(&mut self, period_us: f32) {
        if self.bins.is_empty() {
            self.bins = vec![0; 1001];
        }
        let jitter = (period_us - 1e6 / backend::RATE_HZ as f32).abs();
        self.count += 1;
        self.sum_us += f64::from(period_us);
        self.max_abs_us = self.max_abs_us.max(jitter);
        let bin = ((jitter / 10.0) as usize).min(self.bins.len() - 1);
        self.bins[bin] += 1;
    }

    /// Mean period (µs).
    pub fn mean_period_us(&self) -> Option<f64> {
        (self.count > 0).then(|| self.sum_us / self.count as f64)
    }

    /// The `q`-quantile of |period − 1 ms| (µs), to the 10 µs bin above it.
    pub fn quantile_us(&self, q: f64) -> Option<f32> {
        if self.count == 0 {
            return None;
        }
        let want = (q * self.count as f64).ceil() as u64;
        let mut seen = 0;
        for (i, n) in self.bins.iter().enumerate() {
            seen += n;
            if seen >= want {
                return Some((i as f32 + 1.0) * 10.0);
            }
        }
        Some(self.max_abs_us)
    }
}

/// A change of friction mode seen in the telemetry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Switch {
    /// When (s, loop time).
    pub t_s: f64,
    /// From.
    pub from: Mode,
    /// To.
    pub to: Mode,
    /// Why.
    pub cause: SwitchCause,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The jitter statistics: quantiles to the 10 µs bin above, the largest exactly.
    #[test]
    fn jitter_statistics() {
        let mut j = JitterStats::default();
        for p in [1000.0, 1004.0, 996.0, 1025.0, 1300.0] {
            j.add(p);
        }
        assert_eq!(j.count, 5);
        assert_eq!(j.max_abs_us, 300.0);
        assert_eq!(j.mean_period_us(), Some(1065.0));
        // |jitter| = 0, 4, 4, 25, 300: the median in the first bin (0-10 µs), the 80 %
        // quantile in the 20-30 µs bin, the largest in the 300-310 µs bin.
        assert_eq!(j.quantile_us(0.5), Some(10.0));
        assert_eq!(j.quantile_us(0.8), Some(30.0));
        assert_eq!(j.quantile_us(1.0), Some(310.0));
    }
}
