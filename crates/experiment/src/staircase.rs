//! Levitt's transformed up/down staircases (Levitt 1971, J. Acoust. Soc. Am. 49, 467).
//!
//! An `n`-down/`m`-up staircase lowers the level after `n` consecutive correct answers and
//! raises it after `m` consecutive wrong ones. It converges to the level where the probability
//! of a lower move equals that of a higher one: `p^n = 1 − p^n` for `m = 1`, i.e.
//! `p = 0.5^(1/n)`: 70.7 % correct for 2-down/1-up, 79.4 % for 3-down/1-up.
//!
//! As PsychoPy's `StairHandler`, a staircase is an object that gives the next level and takes
//! the response; [`Interleaved`] runs several of them with a seeded random choice among the
//! unfinished ones on each trial.
//!
//! A **reversal** is a change of direction of the level's track, and this module is its one
//! definition (the runner's summary and the analysis both read it from [`Staircase`]). A
//! response *moves* the level when its rule fires and the level changes: a step clamped at a
//! bound (the level already there) is no move and sets no direction. A move opposite to the
//! previous move is a reversal, counted at the trial whose response made it, with that trial's
//! level; the first move has nothing to reverse and is not one. The move a trial's response
//! makes is known as soon as the response is, so the last trial of a track can be a reversal
//! (when the stopping rule counts reversals, the last one always is), although the level it
//! moves to is never presented.

use crate::fit::Prng;
use thiserror::Error;

/// How the level moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Step {
    /// `level ± step`.
    Additive(f64),
    /// `level × factor` up, `level / factor` down (`factor > 1`).
    Multiplicative(f64),
}

impl Step {
    fn valid(self) -> bool {
        match self {
            Step::Additive(d) => d.is_finite() && d > 0.0,
            Step::Multiplicative(f) => f.is_finite() && f > 1.0,
        }
    }

    fn apply(self, level: f64, up: bool) -> f64 {
        match (self, up) {
            (Step::Additive(d), true) => level + d,
            (Step::Additive(d), false) => level - d,
            (Step::Multiplicative(f), true) => level * f,
            (Step::Multiplicative(f), false) => level / f,
        }
    }
}

/// When a staircase stops: the first of the limits given that is reached.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stop {
    /// Stop after this many reversals.
    pub reversals: Option<usize>,
    /// Stop after this many trials.
    pub trials: Option<usize>,
}

/// A staircase's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StaircaseConfig {
    /// The first trial's level.
    pub start: f64,
    /// Consecutive correct answers that lower the level (`n` of `n`-down).
    pub n_down: u32,
    /// Consecutive wrong answers that raise the level (`m` of `m`-up).
    pub n_up: u32,
    /// The initial step.
    pub step: Step,
    /// A smaller step used once the given number of reversals has happened.
    pub reduced_step: Option<(usize, Step)>,
    /// Lowest level presented (the level is clamped to it).
    pub min: f64,
    /// Highest level presented.
    pub max: f64,
    /// The stopping rule.
    pub stop: Stop,
}

/// What is wrong with a staircase's configuration or use.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum StaircaseError {
    /// `n_down` or `n_up` is zero.
    #[error("n_down ({n_down}) and n_up ({n_up}) must be at least 1")]
    BadRule {
        /// Consecutive correct answers to step down.
        n_down: u32,
        /// Consecutive wrong answers to step up.
        n_up: u32,
    },
    /// A step is not positive, or a factor not above 1.
    #[error("step {0:?} must be a positive increment or a factor above 1")]
    BadStep(Step),
    /// The bounds are not finite and ordered, or the start is outside them.
    #[error("start {start} must lie within finite bounds [{min}, {max}]")]
    BadBounds {
        /// Start level.
        start: f64,
        /// Lower bound.
        min: f64,
        /// Upper bound.
        max: f64,
    },
    /// Multiplicative steps need positive levels.
    #[error("multiplicative steps need a positive lower bound, got {0}")]
    NonPositiveLevels(f64),
    /// Neither a reversal nor a trial limit: the staircase would never end.
    #[error("the stopping rule needs a reversal or a trial limit")]
    NoStop,
    /// A response was given to a finished staircase.
    #[error("the staircase has finished")]
    Finished,
    /// A response was given to an interleaved set with no trial pending.
    #[error("no trial is pending: call next() first")]
    NoPendingTrial,
}

/// One trial of a track.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trial {
    /// The level presented.
    pub level: f64,
    /// Whether it was answered correctly.
    pub correct: bool,
    /// Whether this response moved the level opposite to its previous move (its level is a
    /// reversal level; module docs).
    pub reversal: bool,
}

/// A transformed up/down staircase.
#[derive(Debug, Clone, PartialEq)]
pub struct Staircase {
    config: StaircaseConfig,
    level: f64,
    correct_run: u32,
    wrong_run: u32,
    /// The direction of the last move of the level: `Some(true)` up, `Some(false)` down.
    last_move_up: Option<bool>,
    track: Vec<Trial>,
    reversal_levels: Vec<f64>,
}

impl Staircase {
    /// A staircase at its start level; the configuration is checked.
    pub fn new(config: StaircaseConfig) -> Result<Self, StaircaseError> {
        if config.n_down == 0 || config.n_up == 0 {
            return Err(StaircaseError::BadRule {
                n_down: config.n_down,
                n_up: config.n_up,
            });
        }
        for step in std::iter::once(config.step).chain(config.reduced_step.map(|(_, s)| s)) {
            if !step.valid() {
                return Err(StaircaseError::BadStep(step));
            }
        }
        let StaircaseConfig {
            start, min, max, ..
        } = config;
        if !(min.is_finite()
            && max.is_finite()
            && start.is_finite()
            && min <= start
            && start <= max)
        {
            return Err(StaircaseError::BadBounds { start, min, max });
        }
        let multiplicative = matches!(config.step, Step::Multiplicative(_))
            || matches!(config.reduced_step, Some((_, Step::Multiplicative(_))));
        if multiplicative && min <= 0.0 {
            return Err(StaircaseError::NonPositiveLevels(min));
        }
        if config.stop.reversals.is_none() && config.stop.trials.is_none() {
            return Err(StaircaseError::NoStop);
        }
        Ok(Self {
            config,
            level: start,
            correct_run: 0,
            wrong_run: 0,
            last_move_up: None,
            track: Vec::new(),
            reversal_levels: Vec::new(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &StaircaseConfig {
        &self.config
    }

    /// The level of the next trial.
    pub fn level(&self) -> f64 {
        self.level
    }

    /// Whether the stopping rule has been met.
    pub fn is_finished(&self) -> bool {
        let stop = self.config.stop;
        stop.reversals
            .is_some_and(|r| self.reversal_levels.len() >= r)
            || stop.trials.is_some_and(|t| self.track.len() >= t)
    }

    /// The trials so far.
    pub fn track(&self) -> &[Trial] {
        &self.track
    }

    /// The levels of the reversals so far.
    pub fn reversal_levels(&self) -> &[f64] {
        &self.reversal_levels
    }

    /// The threshold estimate: the mean of the last `k` reversal levels (all of them when
    /// fewer); `None` before the first reversal or for `k = 0`.
    pub fn threshold(&self, k: usize) -> Option<f64> {
        let n = self.reversal_levels.len().min(k);
        (n > 0).then(|| {
            self.reversal_levels[self.reversal_levels.len() - n..]
                .iter()
                .sum::<f64>()
                / n as f64
        })
    }

    fn current_step(&self) -> Step {
        match self.config.reduced_step {
            Some((after, step)) if self.reversal_levels.len() >= after => step,
            _ => self.config.step,
        }
    }

    /// Records the response to the trial at [`level`](Self::level) and moves the level.
    pub fn respond(&mut self, correct: bool) -> Result<(), StaircaseError> {
        if self.is_finished() {
            return Err(StaircaseError::Finished);
        }
        let level = self.level;
        let mut next_move = None;
        if correct {
            self.correct_run += 1;
            self.wrong_run = 0;
            if self.correct_run >= self.config.n_down {
                next_move = Some(false);
            }
        } else {
            self.wrong_run += 1;
            self.correct_run = 0;
            if self.wrong_run >= self.config.n_up {
                next_move = Some(true);
            }
        }
        let mut reversal = false;
        if let Some(up) = next_move {
            self.correct_run = 0;
            self.wrong_run = 0;
            // A step clamped at the bound it points to leaves the level, and the direction, as
            // they were (module docs).
            let moves = if up {
                level < self.config.max
            } else {
                level > self.config.min
            };
            if moves {
                reversal = self.last_move_up.is_some_and(|last| last != up);
                if reversal {
                    self.reversal_levels.push(level);
                }
                self.last_move_up = Some(up);
            }
            // The step in force after this reversal count (Levitt's step reduction after the
            // first k reversals applies from the move that follows the k-th).
            let step = self.current_step();
            self.level = step
                .apply(level, up)
                .clamp(self.config.min, self.config.max);
        }
        self.track.push(Trial {
            level,
            correct,
            reversal,
        });
        Ok(())
    }
}

/// Several staircases run together; each trial goes to one of the unfinished staircases,
/// chosen uniformly by a seeded stream, so that the participant cannot follow any one track.
#[derive(Debug, Clone)]
pub struct Interleaved {
    stairs: Vec<Staircase>,
    rng: Prng,
    pending: Option<usize>,
}

impl Interleaved {
    /// Interleaves `stairs` with the choice stream seeded by `seed`.
    pub fn new(stairs: Vec<Staircase>, seed: u64) -> Self {
        Self {
            stairs,
            rng: Prng::new(seed),
            pending: None,
        }
    }

    /// The next trial: the chosen staircase's index and its level, or `None` when all have
    /// finished. Calling it again before [`respond`](Self::respond) returns the same trial.
    pub fn next_trial(&mut self) -> Option<(usize, f64)> {
        if let Some(i) = self.pending {
            return Some((i, self.stairs[i].level()));
        }
        let open: Vec<usize> = (0..self.stairs.len())
            .filter(|&i| !self.stairs[i].is_finished())
            .collect();
        if open.is_empty() {
            return None;
        }
        let i = open[self.rng.index(open.len())];
        self.pending = Some(i);
        Some((i, self.stairs[i].level()))
    }

    /// Records the response to the pending trial.
    pub fn respond(&mut self, correct: bool) -> Result<(), StaircaseError> {
        let i = self.pending.take().ok_or(StaircaseError::NoPendingTrial)?;
        self.stairs[i].respond(correct)
    }

    /// Whether every staircase has finished.
    pub fn is_finished(&self) -> bool {
        self.stairs.iter().all(Staircase::is_finished)
    }

    /// The staircases.
    pub fn stairs(&self) -> &[Staircase] {
        &self.stairs
    }
}
