//! The analysis of a run folder (`viewer experiment analyze DIR`, thesis §4.3): its
//! `plan.json` and `trials.csv` in, `summary.json` out.
//!
//! `trials.csv` is RFC-4180 CSV (fields with commas, quotes or line breaks are quoted, `""`
//! is a quote) with exactly this header:
//!
//! ```text
//! participant,session,block,trial,practice,design,stimulus,condition,staircase,level,reference,comparison_interval,response,correct,response_time_s,trace,t_start_s
//! ```
//!
//! Practice rows (`practice` = 1) are checked and counted but not analysed. A trial number
//! may appear once only in the file (a resumed session continues the numbering). Every row
//! must match the plan: its `design`, a `stimulus`, `condition` and (2AFC staircases)
//! `staircase` the plan names, the plan's `reference` value, and a `correct` that agrees
//! with the `response`. Errors name the file, the line and the column at fault.
//!
//! # Identification
//!
//! Per condition (plan order): trials, accuracy, the confusion matrix (rows: the stimulus
//! presented, columns: the stimulus answered, both in the plan's stimulus order) and the
//! accuracy per stimulus. With exactly two conditions, the condition effect (the friction
//! effect of the thesis-shapes plan) is Fisher's exact test, two-sided, of the 2×2 table
//! correct/incorrect × condition: the probability, under the hypergeometric distribution of
//! the table with its margins fixed, of the tables at most as likely as the one observed
//! (with R's relative tolerance 10⁻⁷), as R's `fisher.test` computes it.
//!
//! # 2AFC (`2afc-staircase`, `constant-stimuli`)
//!
//! Levels below the reference `r` are folded onto its upper side by the multiplicative mirror
//! `x → r²/x` (the one the runner's multiplicative staircases use), so that the proportion
//! correct against the folded level is one 2AFC psychometric function with guess rate ½:
//! a comparison at `r/1.2` is as far from `r` as one at `1.2 r`. Trials are pooled per
//! distinct folded level into [`Point`]s and fitted per stimulus × condition cell that has
//! trials by maximum likelihood ([`crate::fit`]; point estimates are maximum likelihood, not
//! psignifit's MAP) with a folded model: `ψ = ½ + (½ − λ) F(d)` of the log ratio
//! `d = |ln(x / r)|`, the lapse rate `λ` in `[0, 0.1]` (this stack's bound, not psignifit 4's
//! `[0, 0.5]`), and by default (`weibull`) `F = 1 − exp(−(d / α)^β)`; `log-gaussian` is
//! `F = Φ(β ln(d / α))` and `gaussian` `F = 2Φ((d / α)^β) − 1`. Every such `F` is 0 at
//! `d = 0`: `ψ` is ½ at the reference, where the answer is a guess by construction, and rises
//! on either side of it, so the 75 % point and every point of its interval lie above `r`.
//! The Weber fraction at 75 % correct is `threshold_75 / r − 1 = e^{d₇₅} − 1 > 0`, its 95 %
//! interval the central 95 % of its Bayesian posterior under psignifit 4's default priors of
//! threshold and width (on `ln d`; the lapse rate's Beta(1, 10) on `[0, 0.1]`, no
//! overdispersion term) ([`fit::credible`]: over 200 simulated runs of the shipped staircase
//! plan it covered the true Weber fraction, 0.2, in 185; a parametric bootstrap's intervals,
//! with the unfolded fit used before, in only 79–84 %).
//!
//! A staircase's reversals are its [`crate::staircase`]'s, the one definition the runner's
//! summary uses too: the plan's staircase is replayed on the track's answers (each row's
//! level must be the one the staircase gives at that point, or the track is refused, naming
//! the line). A reversal is a move of the level opposite to its previous move, listed at the
//! trial whose answer made it; a step clamped at a bound is no move, and the last trial's
//! move counts although its level is never presented.
//!
//! # `summary.json`
//!
//! | field | meaning |
//! |---|---|
//! | `format` | `"experiment-summary/1"` |
//! | `plan` | the plan's `name` |
//! | `design` | `"identification"`, `"2afc-staircase"` or `"constant-stimuli"` |
//! | `participants` | the distinct `participant` labels, in order of appearance |
//! | `sessions` | the distinct `session` numbers, ascending |
//! | `trials` | rows analysed (practice rows left out) |
//! | `practice_trials` | practice rows (not analysed) |
//! | `identification` | identification designs only, else absent (below) |
//! | `two_afc` | 2AFC designs only, else absent (below) |
//!
//! `identification`:
//!
//! | field | meaning |
//! |---|---|
//! | `stimuli` | the stimulus names: the order of the confusion matrices' rows and columns |
//! | `conditions[i].name` | the condition (plan order) |
//! | `conditions[i].trials`, `.correct` | its trials and those answered right |
//! | `conditions[i].accuracy` | `correct / trials`; `null` without trials |
//! | `conditions[i].confusion` | `confusion[p][a]`: trials presenting stimulus `p` answered `a` |
//! | `conditions[i].per_stimulus[j]` | `{ "stimulus", "trials", "correct", "accuracy" }` (row `j`) |
//! | `condition_effect` | with exactly two conditions, else `null`: `{ "test", "conditions", "accuracy", "correct", "trials", "p_value" }`, the two conditions' accuracies and Fisher's two-sided exact p |
//!
//! `two_afc`:
//!
//! | field | meaning |
//! |---|---|
//! | `field`, `reference` | the plan's `reference`: the material field varied and its reference value `r` |
//! | `model` | the folded model fitted (above): `"weibull"` (default), `"log-gaussian"` or `"gaussian"` |
//! | `lapse_max` | the lapse rate's upper bound (0.1) |
//! | `cells[i].stimulus`, `.condition` | the cell (plan order; cells without trials are left out) |
//! | `cells[i].trials`, `.correct` | its trials and those answered right |
//! | `cells[i].points[j]` | `{ "level", "trials", "correct" }`: the trials pooled at one folded level, ascending |
//! | `cells[i].fit` | `null` when the data cannot be fitted (`fit_error` says why), else below |
//! | `cells[i].fit.threshold_75` | the folded level answered 75 % correct (above `r`) |
//! | `cells[i].fit.weber_75` | `threshold_75 / r − 1`, the Weber fraction (JND / reference), above 0 |
//! | `cells[i].fit.slope` | `dψ/dx` at `threshold_75` (per unit of the level) |
//! | `cells[i].fit.lapse` | the fitted lapse rate λ |
//! | `cells[i].fit.alpha`, `.beta` | the folded model's scale `α` (a log ratio `d`) and shape `β` ([`crate::fit`]) |
//! | `cells[i].fit.log_likelihood`, `.deviance` | at the optimum; the deviance against the saturated model |
//! | `cells[i].fit.ci95_threshold`, `.ci95_weber` | `[lo, hi]`, 95 % credible intervals (the posterior's 2.5 % and 97.5 % points); `null` when the posterior could not be computed (`ci_error` says why) |
//! | `cells[i].staircases[k]` | `2afc-staircase` only: `{ "name", "track": [{ "trial", "level", "correct" }], "reversals": [{ "trial", "level" }] }`, the levels as presented (not folded), in trial order; a reversal's `trial` is the one whose answer made it |

use std::collections::{BTreeSet, HashMap};
use std::fmt;
use std::path::{Path, PathBuf};

use serde::Serialize;
use thiserror::Error;

use crate::csv::Record;
use crate::fit::{self, Fit, FitOptions, Model, Point};
use crate::plan::{Design, Plan, PlanError, StaircaseSpec};

mod rows;

use rows::{C_LEVEL, Row, read_trials};

/// The format tag of `summary.json`.
pub const FORMAT: &str = "experiment-summary/1";

/// The columns of `trials.csv`, in order.
pub const TRIALS_COLUMNS: [&str; 17] = [
    "participant",
    "session",
    "block",
    "trial",
    "practice",
    "design",
    "stimulus",
    "condition",
    "staircase",
    "level",
    "reference",
    "comparison_interval",
    "response",
    "correct",
    "response_time_s",
    "trace",
    "t_start_s",
];

/// The relative tolerance of Fisher's test: tables whose probability is at most the
/// observed one times `1 + 10⁻⁷` count as "at most as likely" (R's `fisher.test`).
pub const FISHER_RELATIVE_TOLERANCE: f64 = 1e-7;

/// The lapse rate's upper bound: this stack's choice (psignifit 4 allows 0.5; see
/// [`crate::fit`]).
pub const LAPSE_MAX: f64 = 0.1;

/// Options of [`analyze`].
#[derive(Debug, Clone, PartialEq)]
pub struct AnalyzeOptions {
    /// The psychometric function of 2AFC fits: a folded model ([`model_name`]).
    pub model: Model,
}

impl Default for AnalyzeOptions {
    /// The folded Weibull.
    fn default() -> Self {
        Self {
            model: Model::FoldedWeibull,
        }
    }
}

/// The name of a 2AFC analysis's model in `summary.json` and on the command line. The
/// analysis fits the folded models only (`None` for the others, which it refuses).
pub fn model_name(model: Model) -> Option<&'static str> {
    match model {
        Model::FoldedGaussian => Some("gaussian"),
        Model::FoldedLogGaussian => Some("log-gaussian"),
        Model::FoldedWeibull => Some("weibull"),
        Model::Gaussian | Model::LogGaussian | Model::Weibull => None,
    }
}

/// The model of a name ([`model_name`]).
pub fn parse_model(name: &str) -> Option<Model> {
    match name {
        "gaussian" => Some(Model::FoldedGaussian),
        "log-gaussian" => Some(Model::FoldedLogGaussian),
        "weibull" => Some(Model::FoldedWeibull),
        _ => None,
    }
}

/// Why a run folder could not be analysed. Every message names the file.
#[derive(Debug, Error)]
pub enum AnalyzeError {
    /// The options are refused.
    #[error("{0}")]
    Options(String),
    /// `plan.json` is missing or invalid.
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// A file could not be read.
    #[error("cannot read {}: {error}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// A fault in `trials.csv`.
    #[error("{}:{line}: {}{message}", path.display(), column_text(*column, field))]
    Csv {
        /// The file.
        path: PathBuf,
        /// The line (from 1) the record starts on.
        line: usize,
        /// The column (from 1), when one is at fault.
        column: Option<usize>,
        /// The column's name, when one is at fault.
        field: Option<String>,
        /// What is wrong.
        message: String,
    },
    /// `summary.json` could not be written.
    #[error("cannot write {}: {error}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
}

fn column_text(column: Option<usize>, field: &Option<String>) -> String {
    match (column, field) {
        (Some(c), Some(f)) => format!("column {c} ({f}): "),
        (Some(c), None) => format!("column {c}: "),
        (None, Some(f)) => format!("{f}: "),
        (None, None) => String::new(),
    }
}

impl AnalyzeError {
    /// Whether the error is in the input (plan, trials, options) rather than in writing.
    pub fn is_bad_input(&self) -> bool {
        !matches!(self, AnalyzeError::Write { .. })
    }
}

/// The analysis of a run folder; `summary.json` is its JSON (see the module docs).
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    /// [`FORMAT`].
    pub format: &'static str,
    /// The plan's name.
    pub plan: String,
    /// The design's name.
    pub design: &'static str,
    /// Distinct participant labels, in order of appearance.
    pub participants: Vec<String>,
    /// Distinct session numbers, ascending.
    pub sessions: Vec<u64>,
    /// Rows analysed.
    pub trials: usize,
    /// Practice rows (not analysed).
    pub practice_trials: usize,
    /// The identification analysis.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub identification: Option<Identification>,
    /// The 2AFC analysis.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub two_afc: Option<TwoAfc>,
}

/// An identification design's results.
#[derive(Debug, Clone, Serialize)]
pub struct Identification {
    /// The stimulus names, the confusion matrices' order.
    pub stimuli: Vec<String>,
    /// Each condition, in plan order.
    pub conditions: Vec<ConditionResult>,
    /// Fisher's exact test between the two conditions, when there are exactly two.
    pub condition_effect: Option<ConditionEffect>,
}

/// One condition of an identification design.
#[derive(Debug, Clone, Serialize)]
pub struct ConditionResult {
    /// Its name.
    pub name: String,
    /// Trials.
    pub trials: u64,
    /// Trials answered right.
    pub correct: u64,
    /// `correct / trials`, `None` without trials.
    pub accuracy: Option<f64>,
    /// `confusion[presented][answered]`.
    pub confusion: Vec<Vec<u64>>,
    /// Per stimulus presented.
    pub per_stimulus: Vec<StimulusResult>,
}

/// One stimulus (one row of a confusion matrix).
#[derive(Debug, Clone, Serialize)]
pub struct StimulusResult {
    /// Its name.
    pub stimulus: String,
    /// Trials presenting it.
    pub trials: u64,
    /// Those answered with its name.
    pub correct: u64,
    /// `correct / trials`, `None` without trials.
    pub accuracy: Option<f64>,
}

/// Fisher's exact test of accuracy between two conditions.
#[derive(Debug, Clone, Serialize)]
pub struct ConditionEffect {
    /// `"fisher-exact-two-sided"`.
    pub test: &'static str,
    /// The two conditions.
    pub conditions: [String; 2],
    /// Their accuracies (`None` without trials).
    pub accuracy: [Option<f64>; 2],
    /// Their correct answers.
    pub correct: [u64; 2],
    /// Their trials.
    pub trials: [u64; 2],
    /// The two-sided p-value.
    pub p_value: f64,
}

/// A 2AFC design's results.
#[derive(Debug, Clone, Serialize)]
pub struct TwoAfc {
    /// The material field varied.
    pub field: String,
    /// The reference value.
    pub reference: f64,
    /// The sigmoid's name ([`model_name`]).
    pub model: &'static str,
    /// The lapse rate's bound.
    pub lapse_max: f64,
    /// Each stimulus × condition cell with trials, in plan order.
    pub cells: Vec<Cell>,
}

/// One stimulus × condition cell of a 2AFC design.
#[derive(Debug, Clone, Serialize)]
pub struct Cell {
    /// The stimulus's name.
    pub stimulus: String,
    /// The condition's name.
    pub condition: String,
    /// Trials.
    pub trials: u64,
    /// Trials answered right.
    pub correct: u64,
    /// The data at each folded level, ascending.
    pub points: Vec<PointResult>,
    /// The fit, `None` when the data cannot be fitted.
    pub fit: Option<FitResult>,
    /// Why there is no fit.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fit_error: Option<String>,
    /// The staircases' tracks (`2afc-staircase`), in plan order.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub staircases: Vec<Track>,
    /// The fit itself, for its curve ([`Fit::psi`]); not in the JSON.
    #[serde(skip)]
    pub fitted: Option<Fit>,
}

/// The trials at one folded level.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct PointResult {
    /// The folded level.
    pub level: f64,
    /// Trials.
    pub trials: u32,
    /// Trials answered right.
    pub correct: u32,
}

/// A psychometric fit with its credible intervals.
#[derive(Debug, Clone, Serialize)]
pub struct FitResult {
    /// The folded level answered 75 % correct (above the reference).
    pub threshold_75: f64,
    /// `threshold_75 / reference − 1`, above 0.
    pub weber_75: f64,
    /// `dψ/dx` at the threshold.
    pub slope: f64,
    /// The lapse rate.
    pub lapse: f64,
    /// The folded model's scale α, a log ratio.
    pub alpha: f64,
    /// Its shape β.
    pub beta: f64,
    /// Log-likelihood at the optimum.
    pub log_likelihood: f64,
    /// Deviance against the saturated model.
    pub deviance: f64,
    /// 95 % credible interval of `threshold_75`.
    pub ci95_threshold: Option<[f64; 2]>,
    /// 95 % credible interval of `weber_75`.
    pub ci95_weber: Option<[f64; 2]>,
    /// Why there are no intervals.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ci_error: Option<String>,
}

/// One staircase's track.
#[derive(Debug, Clone, Serialize)]
pub struct Track {
    /// Its name.
    pub name: String,
    /// Its trials, in trial order.
    pub track: Vec<TrackTrial>,
    /// Its reversals.
    pub reversals: Vec<Reversal>,
}

/// One trial of a staircase.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct TrackTrial {
    /// The trial number.
    pub trial: u64,
    /// The level presented (not folded).
    pub level: f64,
    /// Whether it was answered right.
    pub correct: bool,
}

/// A staircase's reversal ([`crate::staircase`]).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Reversal {
    /// The trial whose answer moved the level opposite to its previous move.
    pub trial: u64,
    /// Its level.
    pub level: f64,
}

// ---------------------------------------------------------------------------------------
// Statistics

/// `ln n!`.
fn ln_factorial(n: u64) -> f64 {
    libm::lgamma(n as f64 + 1.0)
}

/// Fisher's exact test, two-sided, of the 2×2 table `[[a, b], [c, d]]`: the sum of the
/// hypergeometric probabilities (margins fixed) of the tables at most as likely as the
/// observed one, with R's relative tolerance [`FISHER_RELATIVE_TOLERANCE`].
pub fn fisher_exact_two_sided(table: [[u64; 2]; 2]) -> f64 {
    let [[a, b], [c, d]] = table;
    let row1 = a + b;
    let row2 = c + d;
    let col1 = a + c;
    let n = row1 + row2;
    // P(X = x) for X the top-left cell: C(col1, x) C(n − col1, row1 − x) / C(n, row1).
    let ln_p = |x: u64| {
        ln_factorial(col1) - ln_factorial(x) - ln_factorial(col1 - x) + ln_factorial(n - col1)
            - ln_factorial(row1 - x)
            - ln_factorial(n - col1 - (row1 - x))
            - (ln_factorial(n) - ln_factorial(row1) - ln_factorial(row2))
    };
    let lo = col1.saturating_sub(row2);
    let hi = col1.min(row1);
    let logs: Vec<f64> = (lo..=hi).map(ln_p).collect();
    let max = logs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let d: Vec<f64> = logs.iter().map(|l| (l - max).exp()).collect();
    let total: f64 = d.iter().sum();
    let observed = d[(a - lo) as usize];
    let limit = observed * (1.0 + FISHER_RELATIVE_TOLERANCE);
    let p: f64 = d.iter().filter(|&&v| v <= limit).sum::<f64>() / total;
    p.min(1.0)
}

fn ratio(k: u64, n: u64) -> Option<f64> {
    (n > 0).then(|| k as f64 / n as f64)
}

fn identification(plan: &Plan, rows: &[Row]) -> Identification {
    let spec = plan.spec();
    let n = spec.stimuli.len();
    let stimuli: Vec<String> = spec.stimuli.iter().map(|s| s.name.clone()).collect();
    let conditions: Vec<ConditionResult> = spec
        .conditions
        .iter()
        .enumerate()
        .map(|(c, cond)| {
            let mut confusion = vec![vec![0u64; n]; n];
            for row in rows.iter().filter(|r| r.condition == c) {
                if let Some(a) = row.answered {
                    confusion[row.stimulus][a] += 1;
                }
            }
            let trials: u64 = confusion.iter().flatten().sum();
            let correct: u64 = (0..n).map(|i| confusion[i][i]).sum();
            let per_stimulus = (0..n)
                .map(|i| {
                    let t: u64 = confusion[i].iter().sum();
                    StimulusResult {
                        stimulus: stimuli[i].clone(),
                        trials: t,
                        correct: confusion[i][i],
                        accuracy: ratio(confusion[i][i], t),
                    }
                })
                .collect();
            ConditionResult {
                name: cond.name.clone(),
                trials,
                correct,
                accuracy: ratio(correct, trials),
                confusion,
                per_stimulus,
            }
        })
        .collect();
    let condition_effect = match conditions.as_slice() {
        [x, y] => Some(ConditionEffect {
            test: "fisher-exact-two-sided",
            conditions: [x.name.clone(), y.name.clone()],
            accuracy: [x.accuracy, y.accuracy],
            correct: [x.correct, y.correct],
            trials: [x.trials, y.trials],
            p_value: fisher_exact_two_sided([
                [x.correct, x.trials - x.correct],
                [y.correct, y.trials - y.correct],
            ]),
        }),
        _ => None,
    };
    Identification {
        stimuli,
        conditions,
        condition_effect,
    }
}

/// Folds `level` onto the upper side of `reference`: `r²/x` below it, `x` otherwise.
pub fn fold(level: f64, reference: f64) -> f64 {
    if level < reference {
        reference * reference / level
    } else {
        level
    }
}

/// The reversals of a plan's staircase on its track, the rows of `trials.csv` it ran in
/// trial order: the staircase (the one the run used, [`crate::session`]'s) replayed on their
/// answers, so the reversals are [`crate::staircase`]'s, the runner's own, the last trial's
/// move included. Each row's level must be the one the staircase gives at that point (to
/// 10⁻⁹ relative), or the track is not the plan's staircase and is refused.
fn staircase_reversals(
    spec: &StaircaseSpec,
    reference: f64,
    track: &[&Row],
    trials_path: &Path,
) -> Result<Vec<Reversal>, AnalyzeError> {
    let refuse = |row: &Row, message: String| AnalyzeError::Csv {
        path: trials_path.to_owned(),
        line: row.line,
        column: Some(C_LEVEL + 1),
        field: Some(TRIALS_COLUMNS[C_LEVEL].to_owned()),
        message,
    };
    let (mut stair, side) = crate::session::staircase(spec, reference)
        .map_err(|e| AnalyzeError::Options(e.to_string()))?;
    let mut out = Vec::new();
    for row in track {
        let expected = side.mirror(stair.level());
        let level = row.level.unwrap_or(reference);
        if (level - expected).abs() > 1e-9 * expected.abs() {
            return Err(refuse(
                row,
                format!(
                    "{level:?} is not the level staircase {:?} gives at its trial {} ({expected:?}): \
                     the track does not follow the plan's staircase",
                    spec.name,
                    stair.track().len() + 1
                ),
            ));
        }
        stair.respond(row.correct).map_err(|e| {
            refuse(
                row,
                format!(
                    "staircase {:?} has no trial {}: {e}",
                    spec.name,
                    stair.track().len() + 1
                ),
            )
        })?;
        if stair.track().last().is_some_and(|t| t.reversal) {
            out.push(Reversal {
                trial: row.trial,
                level,
            });
        }
    }
    Ok(out)
}

fn two_afc(
    plan: &Plan,
    rows: &[Row],
    options: &AnalyzeOptions,
    trials_path: &Path,
) -> Result<TwoAfc, AnalyzeError> {
    let spec = plan.spec();
    let reference = spec
        .reference
        .as_ref()
        .ok_or_else(|| AnalyzeError::Options("the 2AFC plan has no reference".to_owned()))?;
    let r = reference.value;
    let model = model_name(options.model).ok_or_else(|| {
        AnalyzeError::Options(format!(
            "the {:?} model is not a folded one: a 2AFC analysis fits a function of the log \
             ratio to the reference",
            options.model
        ))
    })?;
    let mut cells = Vec::new();
    for (s, stimulus) in spec.stimuli.iter().enumerate() {
        for (c, condition) in spec.conditions.iter().enumerate() {
            let mut cell_rows: Vec<&Row> = rows
                .iter()
                .filter(|row| row.stimulus == s && row.condition == c)
                .collect();
            if cell_rows.is_empty() {
                continue;
            }
            cell_rows.sort_by_key(|row| row.trial);
            // Pool per folded level (exact equality: the levels a design presents repeat
            // exactly, and r²/x of the same x is the same number).
            let mut points: Vec<Point> = Vec::new();
            for row in &cell_rows {
                let level = fold(row.level.unwrap_or(r), r);
                match points.iter_mut().find(|p| p.level == level) {
                    Some(p) => {
                        p.n_trials += 1;
                        p.n_correct += u32::from(row.correct);
                    }
                    None => points.push(Point {
                        level,
                        n_trials: 1,
                        n_correct: u32::from(row.correct),
                    }),
                }
            }
            points.sort_by(|a, b| a.level.total_cmp(&b.level));
            let fit_options = FitOptions {
                lapse_max: LAPSE_MAX,
                reference: Some(r),
            };
            let fitted = fit::fit(&points, options.model, fit_options).and_then(|f| {
                // A reference was given: the fit has a Weber fraction.
                let weber_75 = f.weber_75.ok_or(fit::FitError::NoReference(f.model))?;
                Ok((f, weber_75))
            });
            let (fit, fit_error, fitted) = match fitted {
                Ok((f, weber_75)) => {
                    let (ci_t, ci_w, ci_error) =
                        match fit::credible(&points, options.model, fit_options, 0.95) {
                            Ok(c) => (
                                Some([c.threshold_75.lower, c.threshold_75.upper]),
                                c.weber_75.map(|w| [w.lower, w.upper]),
                                None,
                            ),
                            Err(e) => (None, None, Some(e.to_string())),
                        };
                    let result = FitResult {
                        threshold_75: f.threshold_75,
                        weber_75,
                        slope: f.slope,
                        lapse: f.lapse,
                        alpha: f.alpha,
                        beta: f.beta,
                        log_likelihood: f.log_likelihood,
                        deviance: f.deviance,
                        ci95_threshold: ci_t,
                        ci95_weber: ci_w,
                        ci_error,
                    };
                    (Some(result), None, Some(f))
                }
                Err(e) => (None, Some(e.to_string()), None),
            };
            let mut staircases = Vec::new();
            if spec.design == Design::TwoAfcStaircase {
                for (k, st) in spec.staircases.iter().enumerate() {
                    let rows: Vec<&Row> = cell_rows
                        .iter()
                        .copied()
                        .filter(|row| row.staircase == Some(k))
                        .collect();
                    if rows.is_empty() {
                        continue;
                    }
                    staircases.push(Track {
                        name: st.name.clone(),
                        reversals: staircase_reversals(st, r, &rows, trials_path)?,
                        track: rows
                            .iter()
                            .map(|row| TrackTrial {
                                trial: row.trial,
                                level: row.level.unwrap_or(r),
                                correct: row.correct,
                            })
                            .collect(),
                    });
                }
            }
            cells.push(Cell {
                stimulus: stimulus.name.clone(),
                condition: condition.name.clone(),
                trials: cell_rows.len() as u64,
                correct: cell_rows.iter().filter(|row| row.correct).count() as u64,
                points: points
                    .iter()
                    .map(|p| PointResult {
                        level: p.level,
                        trials: p.n_trials,
                        correct: p.n_correct,
                    })
                    .collect(),
                fit,
                fit_error,
                staircases,
                fitted,
            });
        }
    }
    Ok(TwoAfc {
        field: reference.field.clone(),
        reference: r,
        model,
        lapse_max: LAPSE_MAX,
        cells,
    })
}

/// Analyses the run folder `dir` (`plan.json`, `trials.csv`) and writes `dir/summary.json`.
pub fn analyze(dir: &Path, options: &AnalyzeOptions) -> Result<Summary, AnalyzeError> {
    let summary = summarize(dir, options)?;
    let path = dir.join("summary.json");
    let mut text = serde_json::to_string_pretty(&summary).map_err(|e| AnalyzeError::Write {
        path: path.clone(),
        error: std::io::Error::other(e),
    })?;
    text.push('\n');
    std::fs::write(&path, text).map_err(|error| AnalyzeError::Write { path, error })?;
    Ok(summary)
}

/// [`analyze`] without writing `summary.json`.
pub fn summarize(dir: &Path, options: &AnalyzeOptions) -> Result<Summary, AnalyzeError> {
    let plan = Plan::load(dir.join("plan.json"))?;
    let trials_path = dir.join("trials.csv");
    let all = read_trials(&trials_path, &plan)?;
    let practice_trials = all.iter().filter(|r| r.practice).count();
    let rows: Vec<Row> = all.iter().filter(|r| !r.practice).cloned().collect();
    if rows.is_empty() {
        return Err(AnalyzeError::Csv {
            path: trials_path,
            line: all.last().map_or(1, |r| r.line),
            column: None,
            field: None,
            message: format!(
                "no trials to analyse ({practice_trials} practice trials, which are not analysed)"
            ),
        });
    }
    let mut participants: Vec<String> = Vec::new();
    for r in &all {
        if !participants.contains(&r.participant) {
            participants.push(r.participant.clone());
        }
    }
    let sessions: BTreeSet<u64> = all.iter().map(|r| r.session).collect();
    let spec = plan.spec();
    let (identification, two_afc) = match spec.design {
        Design::Identification => (Some(identification(&plan, &rows)), None),
        Design::TwoAfcStaircase | Design::ConstantStimuli => {
            (None, Some(two_afc(&plan, &rows, options, &trials_path)?))
        }
    };
    Ok(Summary {
        format: FORMAT,
        plan: spec.name.clone(),
        design: spec.design.name(),
        participants,
        sessions: sessions.into_iter().collect(),
        trials: rows.len(),
        practice_trials,
        identification,
        two_afc,
    })
}

fn percent(x: Option<f64>) -> String {
    match x {
        Some(v) => format!("{:.1} %", 100.0 * v),
        None => "n/a".to_owned(),
    }
}

impl fmt::Display for Summary {
    /// One paragraph: accuracy per condition and Fisher's p, or each cell's Weber fraction
    /// with its 95 % interval.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} ({}): {} trials analysed ({} practice left out)",
            self.plan, self.design, self.trials, self.practice_trials
        )?;
        if let Some(id) = &self.identification {
            for c in &id.conditions {
                write!(
                    f,
                    "; {:?}: {} correct of {} ({})",
                    c.name,
                    c.correct,
                    c.trials,
                    percent(c.accuracy)
                )?;
            }
            if let Some(e) = &id.condition_effect {
                write!(
                    f,
                    "; {:?} vs {:?}: Fisher's exact test, two-sided, p = {:.4}",
                    e.conditions[0], e.conditions[1], e.p_value
                )?;
            }
        }
        if let Some(t) = &self.two_afc {
            for c in &t.cells {
                write!(
                    f,
                    "; {} / {} ({} trials): ",
                    c.stimulus, c.condition, c.trials
                )?;
                match (&c.fit, &c.fit_error) {
                    (Some(fit), _) => {
                        write!(
                            f,
                            "Weber fraction at 75 % {:.4} (threshold {:.4} against reference {}, {} fit",
                            fit.weber_75, fit.threshold_75, t.reference, t.model
                        )?;
                        match fit.ci95_weber {
                            Some([lo, hi]) => {
                                write!(f, ", 95 % credible interval [{lo:.4}, {hi:.4}])")?
                            }
                            None => write!(
                                f,
                                ", no interval: {})",
                                fit.ci_error.as_deref().unwrap_or("no posterior")
                            )?,
                        }
                    }
                    (None, e) => write!(f, "no fit: {}", e.as_deref().unwrap_or("unknown"))?,
                }
            }
        }
        write!(f, ".")
    }
}
