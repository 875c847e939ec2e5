//! The real-time check of a trial's run log: that it is an unbroken loop at its rate.
//!
//! A run log (`host::runlog`, the files under `DIR/traces/`) has one row per tick with the
//! tick's time `t_s` first. The loop ran at `rate_hz` with no dropped tick when every step
//! between consecutive rows is one period; a step of `k` periods (rounded) is `k − 1` dropped
//! ticks. The tolerance on a step is a tenth of a period: far above the written times'
//! rounding (`f64` printed shortest, exact to ~1e-15 s) and far below a lost tick.

use thiserror::Error;

/// What the timing check found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timing {
    /// Rows (ticks).
    pub ticks: usize,
    /// The run's duration, first to last row (s).
    pub duration_s: f64,
    /// Ticks missing between rows.
    pub dropped: usize,
    /// Steps that were not a whole number of periods within a tenth of one (a clock that
    /// jitters or went backwards).
    pub irregular: usize,
}

/// Why a run log could not be checked.
#[derive(Clone, Debug, PartialEq, Eq, Error)]
pub enum TraceError {
    /// No header with `t_s` first.
    #[error("the run log's first column is not t_s")]
    Header,
    /// A time that is not a number.
    #[error("line {line}: t_s = {text:?} is not a number")]
    Time {
        /// The line (from 1).
        line: usize,
        /// Its text.
        text: String,
    },
    /// The rate is not a positive finite number.
    #[error("the rate {0} Hz is not a positive finite number")]
    Rate(String),
}

/// Checks the `t_s` column of a run log against `rate_hz` (module docs).
pub fn check(log: &str, rate_hz: f64) -> Result<Timing, TraceError> {
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return Err(TraceError::Rate(rate_hz.to_string()));
    }
    let mut lines = log.lines().enumerate();
    match lines.next() {
        Some((_, h)) if h.split(',').next() == Some("t_s") => {}
        _ => return Err(TraceError::Header),
    }
    let period = 1.0 / rate_hz;
    let mut times = Vec::new();
    for (i, line) in lines {
        if line.is_empty() {
            continue;
        }
        let text = line.split(',').next().unwrap_or_default();
        let t: f64 = text
            .parse()
            .ok()
            .filter(|t: &f64| t.is_finite())
            .ok_or_else(|| TraceError::Time {
                line: i + 1,
                text: text.to_owned(),
            })?;
        times.push(t);
    }
    let (mut dropped, mut irregular) = (0, 0);
    for w in times.windows(2) {
        let steps = (w[1] - w[0]) / period;
        let k = steps.round();
        if k < 1.0 || (steps - k).abs() > 0.1 {
            irregular += 1;
        } else {
            dropped += k as usize - 1;
        }
    }
    Ok(Timing {
        ticks: times.len(),
        duration_s: times.last().zip(times.first()).map_or(0.0, |(b, a)| b - a),
        dropped,
        irregular,
    })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// Hand-made logs: an unbroken one, one with ticks 3 and 4 missing (2 dropped), one
    /// whose clock stepped back; and bad input named.
    #[test]
    fn counts_dropped_ticks_and_irregular_steps() {
        let log = |times: &[&str]| {
            let mut s = String::from("t_s,hip_x\n");
            for t in times {
                s += &format!("{t},0\n");
            }
            s
        };
        let ok = check(&log(&["0", "0.001", "0.002", "0.003"]), 1000.0).unwrap();
        assert_eq!((ok.ticks, ok.dropped, ok.irregular), (4, 0, 0));
        assert!((ok.duration_s - 0.003).abs() < 1e-12);
        let gap = check(&log(&["0", "0.001", "0.002", "0.005"]), 1000.0).unwrap();
        assert_eq!((gap.dropped, gap.irregular), (2, 0));
        let back = check(&log(&["0", "0.001", "0.0005", "0.0015"]), 1000.0).unwrap();
        assert_eq!(back.irregular, 1);
        assert_eq!(
            check(&log(&["0", "x"]), 1000.0),
            Err(TraceError::Time {
                line: 3,
                text: "x".to_owned()
            })
        );
        assert_eq!(check("hip_x\n", 1000.0), Err(TraceError::Header));
        assert!(check(&log(&["0"]), f64::NAN).is_err());
    }
}
