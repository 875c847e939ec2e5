//! Psychometric functions for two-alternative forced choice (2AFC), fitted by maximum
//! likelihood with a bounded lapse rate, as PsychoPy does.
//!
//! The model is `ψ(x) = γ + (1 − γ − λ) F(x; α, β)` with the guess rate `γ = 0.5` and the
//! lapse rate `λ ∈ [0, λ_max]`, `λ_max = 0.1` by default. That is this stack's choice, not
//! psignifit 4's default (checked against psignifit 4.3 from PyPI: `λ ∈ [0, 0.5]` with a
//! Beta(1, 10) prior, an overdispersion term `η` fitted beside it, and MAP estimates): the
//! runs here have a few lapses per hundred trials at most, and on the short runs a staircase
//! gives, a bound at 0.1 keeps the slope from trading against lapses. The point estimates
//! (threshold, slope, Weber fraction: what `analyze`'s summary reports) are maximum
//! likelihood, not psignifit's MAP; on sparse sets (5 levels × 10 trials) the two differ by a
//! few percent in the 75 % point and up to a third in the slope. Every `F`
//! here is a location–scale family `G((u − m) / s)` on `u = x`, `u = ln x` or, for the
//! folded models, `u = ln d` with `d = |ln(x / r)|` the log ratio to the reference `r`:
//!
//! | [`Model`]           | `u`    | `G(z)`                | `F`                          | `α`          | `β`          |
//! |---------------------|--------|-----------------------|------------------------------|--------------|--------------|
//! | `Gaussian`          | `x`    | `Φ(z)`                | `Φ((x − α) / β)`             | mean `m`     | sd `s`       |
//! | `LogGaussian`       | `ln x` | `Φ(z)`                | `Φ((ln x − α) / β)`          | `m` (log)    | `s` (log)    |
//! | `Weibull`           | `ln x` | `1 − exp(−exp(z))`    | `1 − exp(−(x / α)^β)`        | scale `eᵐ`   | shape `1/s`  |
//! | `FoldedGaussian`    | `ln d` | `2 Φ(exp(z)) − 1`     | `2 Φ((d / α)^β) − 1`         | scale `eᵐ`   | shape `1/s`  |
//! | `FoldedLogGaussian` | `ln d` | `Φ(z)`                | `Φ(β ln(d / α))`             | scale `eᵐ`   | shape `1/s`  |
//! | `FoldedWeibull`     | `ln d` | `1 − exp(−exp(z))`    | `1 − exp(−(d / α)^β)`        | scale `eᵐ`   | shape `1/s`  |
//!
//! (the Weibull `1 − exp(−(x/α)^β)` is the Gumbel distribution of `ln x`).
//!
//! The folded models are for a 2AFC discrimination against a reference (`analyze` fits
//! them): the comparison `x` and the reference are told apart by how far `x` is from `r`
//! on either side, and at `x = r` the answer is a guess by construction. Each folded `F` is
//! 0 at `d = 0`, so `ψ(r) = ½` whatever the parameters, `ψ` rises with `d`, and the 75 %
//! point lies above the reference: `threshold_75 = r e^{d₇₅}` and `weber_75 = e^{d₇₅} − 1 >
//! 0`, for the point estimate and for every point of an interval alike. Levels at the
//! reference carry no information about the parameters (they enter the likelihood as a
//! constant); `x` and `r²/x` are the same `d`. `FoldedGaussian` at `β = 1` is the
//! equal-variance Gaussian observer, `ψ = ½ + (½ − λ)(2Φ(d/α) − 1)`: the simulated
//! participant's own function ([`crate::sim_participant`]). The unfolded models can put
//! `ψ(r)` anywhere and a threshold on either side of `r`.
//!
//! The fit maximises the binomial log-likelihood with Nelder–Mead on unconstrained
//! parameters `(m, ln s, t)` with `λ = λ_max sin² t`, restarted from its own optimum until it
//! stops improving; it is deterministic. The scale `s` is kept within `[10⁻⁶, 10³]` times the
//! range of `u` over the data: a data set whose likelihood keeps rising towards a step
//! function or a flat line (perfectly separated, or falling with the level) ends on that
//! bound.
//!
//! Intervals of the 75 % threshold and the Weber fraction: [`credible`], the central part of
//! the Bayesian posterior under psignifit 4's default priors of threshold and width (set on
//! `u`, as psignifit sets them on the stimulus levels it is given) with the
//! lapse rate's Beta(1, 10) on `[0, λ_max]` and no overdispersion (what `analyze` reports),
//! or [`bootstrap`], a parametric bootstrap's percentiles. Over 200 simulated runs of the
//! shipped staircase plan (two interleaved 2-down/1-up staircases, ~90 trials) analysed with
//! the folded Weibull, the posterior's 95 % intervals cover the true Weber fraction in 185
//! (W = 0.2) and 187 (W = 0.15) runs, none of them reaching below 0 (`examples/recovery.rs`;
//! the folded Gaussian 184 and 186, the folded log-Gaussian 184 and 180). The unfolded
//! log-Gaussian this crate fitted before covered it in 194 and 191 with intervals a sixth to
//! a third wider, 11 and 33 of which reached below 0: it spent part of the data on where
//! `ψ` stands at the reference, which the folded models know. With the plan's earlier bounds,
//! which reached the reference, a bootstrap's intervals covered it in 158 of 200 runs
//! (re-running the staircases in each resample) and the posterior's in 186 (unfolded
//! log-Gaussian). The bootstrap draws from the one best-fitting function, and a staircase's
//! levels, clustered at the threshold, leave its slope poorly known: the posterior keeps the
//! shallow functions the data allow, and they widen the interval as they should.

mod credible;
mod normal;

pub use crate::rng::Prng;
pub use credible::{Credible, credible};
pub use normal::{normal_cdf, normal_pdf, normal_quantile};
use thiserror::Error;

/// The guess rate of a two-alternative forced choice.
pub const GUESS_2AFC: f64 = 0.5;

/// The performance level the threshold is defined at.
pub const TARGET_75: f64 = 0.75;

/// One stimulus level of a 2AFC data set: psignifit's `[level, n_correct, n_total]` row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// The stimulus level (for a JND, the comparison's value against the reference).
    pub level: f64,
    /// Trials presented at this level.
    pub n_trials: u32,
    /// Trials answered correctly at this level.
    pub n_correct: u32,
}

/// The sigmoid `F` of the psychometric function.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Model {
    /// Cumulative Gaussian on the level: `F = Φ((x − α) / β)`.
    Gaussian,
    /// Cumulative Gaussian on the log level: `F = Φ((ln x − α) / β)`; levels must be positive.
    LogGaussian,
    /// Weibull: `F = 1 − exp(−(x / α)^β)`; levels must be positive.
    Weibull,
    /// Folded 2AFC about the reference `r` (module docs): `F = 2Φ((d / α)^β) − 1` of
    /// `d = |ln(x / r)|`, at `β = 1` the equal-variance Gaussian observer's.
    FoldedGaussian,
    /// Folded 2AFC about the reference: `F = Φ(β ln(d / α))`, the log-normal distribution
    /// function of `d = |ln(x / r)|`.
    FoldedLogGaussian,
    /// Folded 2AFC about the reference: `F = 1 − exp(−(d / α)^β)`, the Weibull of
    /// `d = |ln(x / r)|`.
    FoldedWeibull,
}

/// The coordinate `u` a model's sigmoid is a location–scale family on.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Axis {
    /// `u = x`.
    Level,
    /// `u = ln x`.
    LogLevel,
    /// `u = ln d`, `d = |ln(x / r)|` with the reference `r`: `u = −∞` at the reference.
    LogLogRatio(f64),
}

impl Axis {
    fn u(self, x: f64) -> f64 {
        match self {
            Axis::Level => x,
            Axis::LogLevel => x.ln(),
            Axis::LogLogRatio(r) => (x / r).ln().abs().ln(),
        }
    }

    /// The level at `u` (for the log ratio, the one above the reference).
    fn level(self, u: f64) -> f64 {
        match self {
            Axis::Level => u,
            Axis::LogLevel => u.exp(),
            Axis::LogLogRatio(r) => r * u.exp().exp(),
        }
    }

    /// `du/dx` at the level `x` (for the log ratio, `x` above the reference).
    fn du_dx(self, x: f64) -> f64 {
        match self {
            Axis::Level => 1.0,
            Axis::LogLevel => 1.0 / x,
            Axis::LogLogRatio(r) => 1.0 / (x * (x / r).ln()),
        }
    }

    /// The Weber fraction `x / r − 1` of the level at `u`; on the log ratio `e^d − 1`,
    /// which is positive for every finite `u`.
    fn weber(self, u: f64, reference: f64) -> f64 {
        match self {
            Axis::LogLogRatio(_) => u.exp().exp_m1(),
            _ => self.level(u) / reference - 1.0,
        }
    }
}

impl Model {
    fn uses_log(self) -> bool {
        !matches!(self, Model::Gaussian)
    }

    /// The model's axis; `None` for a folded model without a reference.
    fn axis(self, reference: Option<f64>) -> Option<Axis> {
        match self {
            Model::Gaussian => Some(Axis::Level),
            Model::LogGaussian | Model::Weibull => Some(Axis::LogLevel),
            _ => reference.map(Axis::LogLogRatio),
        }
    }

    /// Whether `α = eᵐ` and `β = 1/s` (a scale and a shape) rather than `m` and `s`.
    fn scale_shape(self) -> bool {
        !matches!(self, Model::Gaussian | Model::LogGaussian)
    }

    /// `G(z)`, the standard sigmoid.
    fn cdf(self, z: f64) -> f64 {
        match self {
            Model::Gaussian | Model::LogGaussian | Model::FoldedLogGaussian => normal_cdf(z),
            Model::Weibull | Model::FoldedWeibull => -(-z.exp()).exp_m1(),
            // 2Φ(t) − 1 = erf(t / √2).
            Model::FoldedGaussian => libm::erf(z.exp() * std::f64::consts::FRAC_1_SQRT_2),
        }
    }

    /// `G'(z)`.
    fn pdf(self, z: f64) -> f64 {
        match self {
            Model::Gaussian | Model::LogGaussian | Model::FoldedLogGaussian => normal_pdf(z),
            Model::Weibull | Model::FoldedWeibull => (z - z.exp()).exp(),
            Model::FoldedGaussian => 2.0 * normal_pdf(z.exp()) * z.exp(),
        }
    }

    /// `G⁻¹(p)` for `p ∈ (0, 1)`.
    fn quantile(self, p: f64) -> f64 {
        match self {
            Model::Gaussian | Model::LogGaussian | Model::FoldedLogGaussian => normal_quantile(p),
            Model::Weibull | Model::FoldedWeibull => (-(-p).ln_1p()).ln(),
            Model::FoldedGaussian => normal_quantile(0.5 * (1.0 + p)).ln(),
        }
    }
}

/// Options of [`fit`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitOptions {
    /// The upper bound of the lapse rate; `0` fixes the lapse rate at zero.
    pub lapse_max: f64,
    /// The reference of a JND experiment, for `weber_75 = threshold_75 / reference − 1`;
    /// a folded model is anchored there (`ψ = ½`) and needs it.
    pub reference: Option<f64>,
}

impl Default for FitOptions {
    /// The lapse rate in `[0, 0.1]` (see the module docs: not psignifit's `[0, 0.5]`), no
    /// reference.
    fn default() -> Self {
        Self {
            lapse_max: 0.1,
            reference: None,
        }
    }
}

/// What is wrong with a fit's input, or why it could not be made.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FitError {
    /// The data set is empty.
    #[error("no data to fit")]
    NoData,
    /// A level is NaN or infinite.
    #[error("point {index}: level {level} is not finite")]
    LevelNotFinite {
        /// Index of the point in the data.
        index: usize,
        /// The offending level.
        level: f64,
    },
    /// A log-scale model got a level that is not positive.
    #[error("point {index}: level {level} must be positive for the {model:?} model")]
    LevelNotPositive {
        /// Index of the point in the data.
        index: usize,
        /// The offending level.
        level: f64,
        /// The model that takes logarithms.
        model: Model,
    },
    /// More correct answers than trials.
    #[error("point {index}: {n_correct} correct out of {n_trials} trials")]
    CorrectExceedsTrials {
        /// Index of the point in the data.
        index: usize,
        /// Trials at that level.
        n_trials: u32,
        /// Correct answers at that level.
        n_correct: u32,
    },
    /// Fewer than two distinct levels carry trials (for a folded model: distinct log ratios
    /// other than the reference's, where `ψ = ½` whatever the parameters): slope and location
    /// cannot both be fitted.
    #[error("need trials at two or more distinct levels, found {distinct}")]
    TooFewLevels {
        /// Distinct levels with at least one trial.
        distinct: usize,
    },
    /// No level is answered above chance: there is no psychometric function to fit.
    #[error("every level is answered at or below chance (50 % correct): nothing to fit")]
    AtChance,
    /// The lapse bound is not in `[0, 0.5)`.
    #[error("lapse_max {0} must be in [0, 0.5)")]
    BadLapseMax(f64),
    /// The reference is not a positive finite number.
    #[error("reference {0} must be positive and finite")]
    BadReference(f64),
    /// A folded model was asked for without the reference it is anchored at.
    #[error("the {0:?} model is anchored at the reference: give one")]
    NoReference(Model),
    /// The optimum is not a finite set of parameters.
    #[error("the likelihood maximisation did not reach finite parameters")]
    NotConverged,
    /// The likelihood is maximised by a degenerate function whose 75 % point or parameters lie
    /// beyond the floating-point range (typically data that fall with the level, fitted on a
    /// log scale).
    #[error("the fitted function is degenerate: its 75 % point or parameters are not finite")]
    NoThreshold,
    /// An interval's coverage is not strictly between 0 and 1.
    #[error("coverage {0} must lie strictly between 0 and 1")]
    Coverage(f64),
    /// The bootstrap was asked for too few resamples.
    #[error("bootstrap needs at least 2 resamples, got {0}")]
    TooFewResamples(usize),
    /// Too many bootstrap resamples could not be fitted for the interval to mean anything.
    #[error("{failed} of {resamples} bootstrap resamples could not be fitted")]
    BootstrapFailed {
        /// Resamples whose fit failed.
        failed: usize,
        /// Resamples drawn.
        resamples: usize,
    },
}

/// A maximum-likelihood psychometric fit.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// The sigmoid fitted.
    pub model: Model,
    /// The options it was fitted with.
    pub options: FitOptions,
    /// Location `α` (see the table in the module docs).
    pub alpha: f64,
    /// Spread or shape `β` (see the table in the module docs).
    pub beta: f64,
    /// Lapse rate `λ`.
    pub lapse: f64,
    /// The level where `ψ = 0.75`.
    pub threshold_75: f64,
    /// `threshold_75 / reference − 1`, when a reference was given.
    pub weber_75: Option<f64>,
    /// `dψ/dx` at `threshold_75`.
    pub slope: f64,
    /// The binomial log-likelihood at the optimum (with the binomial coefficients).
    pub log_likelihood: f64,
    /// The deviance against the saturated model, `2 Σ [k ln(k / nψ) + (n−k) ln((n−k) / n(1−ψ))]`.
    pub deviance: f64,
}

impl Fit {
    /// `ψ(x)`, the probability of a correct answer at level `x` (NaN for a folded model
    /// without a reference).
    pub fn psi(&self, x: f64) -> f64 {
        let (m, s) = self.location_scale();
        self.axis().map_or(f64::NAN, |axis| {
            psi_u(self.model, axis.u(x), m, s, self.lapse)
        })
    }

    /// The level where `ψ = p`, for `p` strictly between the guess rate and `1 − λ` (for a
    /// folded model, the one above the reference).
    pub fn level_at(&self, p: f64) -> Option<f64> {
        let (m, s) = self.location_scale();
        level_at(self.model, self.axis()?, m, s, self.lapse, p)
    }

    fn axis(&self) -> Option<Axis> {
        self.model.axis(self.options.reference)
    }

    fn location_scale(&self) -> (f64, f64) {
        if self.model.scale_shape() {
            (self.alpha.ln(), 1.0 / self.beta)
        } else {
            (self.alpha, self.beta)
        }
    }
}

/// A two-sided interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    /// Lower end.
    pub lower: f64,
    /// Upper end.
    pub upper: f64,
}

impl Interval {
    /// Whether `x` lies in `[lower, upper]`.
    pub fn contains(&self, x: f64) -> bool {
        self.lower <= x && x <= self.upper
    }

    /// The interval of a threshold as Weber fractions against `reference`: `x / r − 1`.
    fn weber(&self, reference: f64) -> Interval {
        Interval {
            lower: self.lower / reference - 1.0,
            upper: self.upper / reference - 1.0,
        }
    }
}

/// Options of [`bootstrap`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BootstrapOptions {
    /// Resamples drawn (psignifit and the literature use ≥ 1000 for 95 % intervals).
    pub resamples: usize,
    /// Seed of the resampling stream.
    pub seed: u64,
    /// Coverage of the percentile interval, e.g. `0.95`.
    pub coverage: f64,
}

impl Default for BootstrapOptions {
    fn default() -> Self {
        Self {
            resamples: 1000,
            seed: 0,
            coverage: 0.95,
        }
    }
}

/// Parametric-bootstrap percentile intervals.
#[derive(Debug, Clone, PartialEq)]
pub struct Bootstrap {
    /// Interval of `threshold_75`.
    pub threshold_75: Interval,
    /// Interval of `weber_75` (the fit's `ci95_weber` at the default coverage), when the fit
    /// has a reference.
    pub weber_75: Option<Interval>,
    /// Resamples whose fit succeeded and entered the intervals.
    pub fitted: usize,
    /// Resamples whose fit failed (e.g. every level at chance) and were left out.
    pub failed: usize,
}

/// A simulated 2AFC observer for a JND experiment: it answers correctly with probability
/// `ψ(x) = 0.5 + (0.5 − λ) Φ((x / r − 1 − μ) / σ)`, with `μ` chosen so that `ψ = 0.75` at
/// `x / r − 1 = W`. It is the unfolded `Gaussian` model's observer, for comparisons above the
/// reference: its `ψ(r)` is above ½ (a folded observer is a [`Fit`] of a folded model).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observer {
    /// The true Weber fraction `W` (at 75 % correct).
    pub weber: f64,
    /// The reference `r`.
    pub reference: f64,
    /// The spread `σ` of the cumulative Gaussian, in Weber-fraction units.
    pub sigma: f64,
    /// The lapse rate `λ` (`< 0.25`).
    pub lapse: f64,
}

impl Observer {
    /// The mean `μ` of the underlying Gaussian, in Weber-fraction units.
    pub fn mu(&self) -> f64 {
        let f = (TARGET_75 - GUESS_2AFC) / (1.0 - GUESS_2AFC - self.lapse);
        self.weber - self.sigma * normal_quantile(f)
    }

    /// The probability of a correct answer at comparison level `x`.
    pub fn psi(&self, x: f64) -> f64 {
        let z = (x / self.reference - 1.0 - self.mu()) / self.sigma;
        GUESS_2AFC + (1.0 - GUESS_2AFC - self.lapse) * normal_cdf(z)
    }

    /// The comparison level where `ψ = p`, for `p` in `(0.5, 1 − λ)`.
    pub fn level_at(&self, p: f64) -> Option<f64> {
        let f = (p - GUESS_2AFC) / (1.0 - GUESS_2AFC - self.lapse);
        (f > 0.0 && f < 1.0)
            .then(|| self.reference * (1.0 + self.mu() + self.sigma * normal_quantile(f)))
    }

    /// One trial at level `x`: `true` when answered correctly.
    pub fn respond(&self, x: f64, rng: &mut Prng) -> bool {
        rng.bernoulli(self.psi(x))
    }

    /// A constant-stimuli data set: `n_trials` trials at each level.
    pub fn run_constant(&self, levels: &[f64], n_trials: u32, rng: &mut Prng) -> Vec<Point> {
        levels
            .iter()
            .map(|&level| Point {
                level,
                n_trials,
                n_correct: rng.binomial(n_trials, self.psi(level)),
            })
            .collect()
    }
}

fn psi_u(model: Model, u: f64, m: f64, s: f64, lapse: f64) -> f64 {
    GUESS_2AFC + (1.0 - GUESS_2AFC - lapse) * model.cdf((u - m) / s)
}

fn level_at(model: Model, axis: Axis, m: f64, s: f64, lapse: f64, p: f64) -> Option<f64> {
    sigmoid_at(lapse, p).map(|z| axis.level(m + s * model.quantile(z)))
}

/// The sigmoid's value `F` where `ψ = p` with lapse rate `lapse`, for `p` strictly between
/// the guess rate and `1 − λ`.
fn sigmoid_at(lapse: f64, p: f64) -> Option<f64> {
    let f = (p - GUESS_2AFC) / (1.0 - GUESS_2AFC - lapse);
    (f > 0.0 && f < 1.0).then_some(f)
}

/// Validated data in the fit's coordinate `u`, with the binomial constants. A folded
/// model's levels at the reference have `u = −∞` and `ψ = ½` whatever the parameters: they
/// enter the likelihood as a constant and nothing else (the range, the start, the counts of
/// levels).
struct Prepared {
    axis: Axis,
    u: Vec<f64>,
    n: Vec<f64>,
    k: Vec<f64>,
    /// `Σ ln C(n, k)`.
    log_binom: f64,
    /// The saturated model's log-likelihood without the binomial coefficients.
    saturated: f64,
    /// The range of the finite `u`.
    u_min: f64,
    u_max: f64,
}

/// Checks the options and the data; the model's axis.
fn validate(data: &[Point], model: Model, options: &FitOptions) -> Result<Axis, FitError> {
    if !(0.0..0.5).contains(&options.lapse_max) {
        return Err(FitError::BadLapseMax(options.lapse_max));
    }
    if let Some(r) = options.reference
        && !(r.is_finite() && r > 0.0)
    {
        return Err(FitError::BadReference(r));
    }
    let axis = model
        .axis(options.reference)
        .ok_or(FitError::NoReference(model))?;
    if data.is_empty() {
        return Err(FitError::NoData);
    }
    for (index, p) in data.iter().enumerate() {
        if !p.level.is_finite() {
            return Err(FitError::LevelNotFinite {
                index,
                level: p.level,
            });
        }
        if model.uses_log() && p.level <= 0.0 {
            return Err(FitError::LevelNotPositive {
                index,
                level: p.level,
                model,
            });
        }
        if p.n_correct > p.n_trials {
            return Err(FitError::CorrectExceedsTrials {
                index,
                n_trials: p.n_trials,
                n_correct: p.n_correct,
            });
        }
    }
    Ok(axis)
}

fn xlogy(x: f64, y: f64) -> f64 {
    if x == 0.0 { 0.0 } else { x * y.ln() }
}

fn prepare(data: &[Point], axis: Axis) -> Result<Prepared, FitError> {
    let used: Vec<&Point> = data.iter().filter(|p| p.n_trials > 0).collect();
    let u: Vec<f64> = used.iter().map(|p| axis.u(p.level)).collect();
    let mut levels: Vec<f64> = u.iter().copied().filter(|u| u.is_finite()).collect();
    levels.sort_by(f64::total_cmp);
    levels.dedup();
    if levels.len() < 2 {
        return Err(FitError::TooFewLevels {
            distinct: levels.len(),
        });
    }
    if used
        .iter()
        .zip(&u)
        .all(|(p, u)| !u.is_finite() || 2 * p.n_correct <= p.n_trials)
    {
        return Err(FitError::AtChance);
    }
    let n: Vec<f64> = used.iter().map(|p| f64::from(p.n_trials)).collect();
    let k: Vec<f64> = used.iter().map(|p| f64::from(p.n_correct)).collect();
    let mut log_binom = 0.0;
    let mut saturated = 0.0;
    for i in 0..u.len() {
        log_binom +=
            libm::lgamma(n[i] + 1.0) - libm::lgamma(k[i] + 1.0) - libm::lgamma(n[i] - k[i] + 1.0);
        let ph = k[i] / n[i];
        saturated += xlogy(k[i], ph) + xlogy(n[i] - k[i], 1.0 - ph);
    }
    let (u_min, u_max) = (levels[0], levels[levels.len() - 1]);
    Ok(Prepared {
        axis,
        u,
        n,
        k,
        log_binom,
        saturated,
        u_min,
        u_max,
    })
}

/// Smallest probability the likelihood takes logs of; keeps `ln ψ` finite when a trial
/// contradicts a near-step function.
const P_FLOOR: f64 = 1e-300;

impl Prepared {
    /// The log-likelihood without the binomial coefficients.
    fn kernel(&self, model: Model, m: f64, s: f64, lapse: f64) -> f64 {
        let mut ll = 0.0;
        for i in 0..self.u.len() {
            let p = psi_u(model, self.u[i], m, s, lapse);
            ll += self.k[i] * p.max(P_FLOOR).ln()
                + (self.n[i] - self.k[i]) * (1.0 - p).max(P_FLOOR).ln();
        }
        ll
    }

    fn range(&self) -> f64 {
        self.u_max - self.u_min
    }

    /// The bounds of `ln s`: from a millionth of the level range (a step function) to a
    /// thousand ranges (a flat line); the optimum of any data set with an informative slope
    /// lies well inside.
    fn log_s_bounds(&self) -> (f64, f64) {
        let r = self.range();
        ((r * 1e-6).ln(), (r * 1e3).ln())
    }

    /// A starting point: the level where the pooled proportion correct first reaches 75 %
    /// (linear interpolation between sorted levels), a spread of a quarter of the range.
    fn start(&self) -> (f64, f64) {
        let mut idx: Vec<usize> = (0..self.u.len())
            .filter(|&i| self.u[i].is_finite())
            .collect();
        idx.sort_by(|&a, &b| self.u[a].total_cmp(&self.u[b]));
        let p: Vec<f64> = idx.iter().map(|&i| self.k[i] / self.n[i]).collect();
        let us: Vec<f64> = idx.iter().map(|&i| self.u[i]).collect();
        let mut m = 0.5 * (self.u_min + self.u_max);
        for j in 1..us.len() {
            if p[j - 1] < TARGET_75 && p[j] >= TARGET_75 {
                let w = (TARGET_75 - p[j - 1]) / (p[j] - p[j - 1]);
                m = us[j - 1] + w * (us[j] - us[j - 1]);
                break;
            }
        }
        if p.iter().all(|&q| q >= TARGET_75) {
            m = self.u_min;
        } else if p.iter().all(|&q| q < TARGET_75) {
            m = self.u_max;
        }
        (m, 0.25 * self.range())
    }
}

/// Fits `model` to `data` by maximum likelihood.
///
/// Levels with no trials are ignored. Errors name the point and field at fault.
pub fn fit(data: &[Point], model: Model, options: FitOptions) -> Result<Fit, FitError> {
    let axis = validate(data, model, &options)?;
    let prep = prepare(data, axis)?;
    fit_prepared(&prep, model, options)
}

fn fit_prepared(prep: &Prepared, model: Model, options: FitOptions) -> Result<Fit, FitError> {
    let (lo, hi) = prep.log_s_bounds();
    let lapse_max = options.lapse_max;
    let free_lapse = lapse_max > 0.0;
    let unpack = |th: &[f64]| -> (f64, f64, f64) {
        let lapse = if free_lapse {
            lapse_max * th[2].sin().powi(2)
        } else {
            0.0
        };
        (th[0], th[1].clamp(lo, hi).exp(), lapse)
    };
    let objective = |th: &[f64]| -> f64 {
        let (m, s, lapse) = unpack(th);
        // The clamp leaves a flat plateau outside the bounds; a small slope back towards the
        // box keeps the simplex from wandering on it.
        let outside = (th[1] - th[1].clamp(lo, hi)).abs();
        -prep.kernel(model, m, s, lapse) + outside
    };
    let (m0, s0) = prep.start();
    let range = prep.range();
    let mut best: Option<(Vec<f64>, f64)> = None;
    // Starts on both sides of the heuristic spread; the lapse starts small (t = 0.3 gives
    // λ ≈ 0.09 λ_max) because most data sets have few lapses.
    for &s_start in &[s0, 0.05 * range] {
        let mut x0 = vec![m0, s_start.ln()];
        let mut steps = vec![0.25 * range, 0.7];
        if free_lapse {
            x0.push(0.3);
            steps.push(0.4);
        }
        let (x, f) = nelder_mead_restarted(&objective, &x0, &steps);
        if best.as_ref().is_none_or(|(_, fb)| f < *fb) {
            best = Some((x, f));
        }
    }
    let (theta, _) = best.ok_or(FitError::NotConverged)?;
    let (m, s, lapse) = unpack(&theta);
    if !(m.is_finite() && s.is_finite() && lapse.is_finite()) {
        return Err(FitError::NotConverged);
    }
    let kernel = prep.kernel(model, m, s, lapse);
    let z_t = model.quantile(sigmoid_at(lapse, TARGET_75).ok_or(FitError::NotConverged)?);
    let u_t = m + s * z_t;
    let threshold_75 = prep.axis.level(u_t);
    let slope = (1.0 - GUESS_2AFC - lapse) * model.pdf(z_t) / s * prep.axis.du_dx(threshold_75);
    let (alpha, beta) = if model.scale_shape() {
        (m.exp(), 1.0 / s)
    } else {
        (m, s)
    };
    let representable = alpha.is_finite()
        && beta.is_finite()
        && beta > 0.0
        && (!model.scale_shape() || alpha > 0.0);
    let weber_75 = options.reference.map(|r| prep.axis.weber(u_t, r));
    if !(threshold_75.is_finite() && slope.is_finite() && representable)
        || weber_75.is_some_and(|w| !w.is_finite())
    {
        return Err(FitError::NoThreshold);
    }
    Ok(Fit {
        model,
        options,
        alpha,
        beta,
        lapse,
        threshold_75,
        weber_75,
        slope,
        log_likelihood: kernel + prep.log_binom,
        deviance: 2.0 * (prep.saturated - kernel).max(0.0),
    })
}

/// Nelder–Mead restarted from its own optimum with a fresh simplex until a restart no
/// longer improves the value (restarts cure the simplex's premature collapse).
fn nelder_mead_restarted(f: &dyn Fn(&[f64]) -> f64, x0: &[f64], steps: &[f64]) -> (Vec<f64>, f64) {
    let (mut x, mut fx) = nelder_mead(f, x0, steps);
    for _ in 0..8 {
        let (y, fy) = nelder_mead(f, &x, steps);
        let improved = fx - fy > 1e-10 * (1.0 + fx.abs());
        if fy < fx {
            x = y;
            fx = fy;
        }
        if !improved {
            break;
        }
    }
    (x, fx)
}

/// Nelder–Mead with the standard coefficients (reflection 1, expansion 2, contraction ½,
/// shrink ½; Lagarias et al. 1998), stopped when the simplex's values agree to 1e-12
/// relative or after 2000 evaluations.
fn nelder_mead(f: &dyn Fn(&[f64]) -> f64, x0: &[f64], steps: &[f64]) -> (Vec<f64>, f64) {
    let d = x0.len();
    let mut simplex: Vec<Vec<f64>> = vec![x0.to_vec()];
    for i in 0..d {
        let mut v = x0.to_vec();
        v[i] += steps[i];
        simplex.push(v);
    }
    let mut values: Vec<f64> = simplex.iter().map(|v| f(v)).collect();
    let mut evals = d + 1;
    while evals < 2000 {
        let mut order: Vec<usize> = (0..=d).collect();
        order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
        simplex = order.iter().map(|&i| simplex[i].clone()).collect();
        values = order.iter().map(|&i| values[i]).collect();
        let (fb, fw) = (values[0], values[d]);
        if (fw - fb).abs() <= 1e-12 * (1.0 + fb.abs()) {
            let span = simplex[1..]
                .iter()
                .flat_map(|v| v.iter().zip(&simplex[0]).map(|(a, b)| (a - b).abs()))
                .fold(0.0, f64::max);
            if span < 1e-9 {
                break;
            }
        }
        let centroid: Vec<f64> = (0..d)
            .map(|j| simplex[..d].iter().map(|v| v[j]).sum::<f64>() / d as f64)
            .collect();
        let along = |t: f64| -> Vec<f64> {
            (0..d)
                .map(|j| centroid[j] + t * (simplex[d][j] - centroid[j]))
                .collect()
        };
        let xr = along(-1.0);
        let fr = f(&xr);
        evals += 1;
        if fr < values[0] {
            let xe = along(-2.0);
            let fe = f(&xe);
            evals += 1;
            if fe < fr {
                simplex[d] = xe;
                values[d] = fe;
            } else {
                simplex[d] = xr;
                values[d] = fr;
            }
        } else if fr < values[d - 1] {
            simplex[d] = xr;
            values[d] = fr;
        } else {
            let (xc, fc) = if fr < values[d] {
                let xc = along(-0.5);
                let fc = f(&xc);
                (xc, fc)
            } else {
                let xc = along(0.5);
                let fc = f(&xc);
                (xc, fc)
            };
            evals += 1;
            if fc < values[d].min(fr) {
                simplex[d] = xc;
                values[d] = fc;
            } else {
                for i in 1..=d {
                    let v: Vec<f64> = (0..d)
                        .map(|j| simplex[0][j] + 0.5 * (simplex[i][j] - simplex[0][j]))
                        .collect();
                    values[i] = f(&v);
                    simplex[i] = v;
                }
                evals += d;
            }
        }
    }
    let best = (0..=d)
        .min_by(|&a, &b| values[a].total_cmp(&values[b]))
        .unwrap_or(0);
    (simplex[best].clone(), values[best])
}

/// The `q`-quantile of sorted data, linear interpolation between order statistics
/// (Hyndman & Fan type 7, R's and NumPy's default).
fn quantile_sorted(sorted: &[f64], q: f64) -> f64 {
    let h = (sorted.len() - 1) as f64 * q;
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(sorted.len() - 1);
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

/// Parametric bootstrap of `fit` on `data` (the data it was fitted to): each resample draws
/// `k* ~ Binomial(n, ψ̂(x))` at every level and is refitted with the same model and options;
/// the intervals are the percentiles of the refitted thresholds and Weber fractions.
///
/// Resamples that cannot be fitted (all at chance) are left out and counted; more than 10 %
/// of them failing is an error, as the interval would then be conditional on an unlikely
/// subset.
pub fn bootstrap(
    fit: &Fit,
    data: &[Point],
    options: &BootstrapOptions,
) -> Result<Bootstrap, FitError> {
    if options.resamples < 2 {
        return Err(FitError::TooFewResamples(options.resamples));
    }
    let axis = validate(data, fit.model, &fit.options)?;
    let mut prep = prepare(data, axis)?;
    let probs: Vec<f64> = prep
        .u
        .iter()
        .map(|&u| {
            let (m, s) = fit.location_scale();
            psi_u(fit.model, u, m, s, fit.lapse)
        })
        .collect();
    let mut rng = Prng::new(options.seed);
    let mut thresholds = Vec::with_capacity(options.resamples);
    let mut failed = 0;
    for _ in 0..options.resamples {
        let mut sat = 0.0;
        let mut log_binom = 0.0;
        for i in 0..prep.u.len() {
            let n = prep.n[i];
            let k = f64::from(rng.binomial(n as u32, probs[i]));
            prep.k[i] = k;
            let ph = k / n;
            sat += xlogy(k, ph) + xlogy(n - k, 1.0 - ph);
            log_binom += libm::lgamma(n + 1.0) - libm::lgamma(k + 1.0) - libm::lgamma(n - k + 1.0);
        }
        prep.saturated = sat;
        prep.log_binom = log_binom;
        if prep.k.iter().zip(&prep.n).all(|(k, n)| 2.0 * k <= *n) {
            failed += 1;
            continue;
        }
        match fit_prepared(&prep, fit.model, fit.options) {
            Ok(f) => thresholds.push(f.threshold_75),
            Err(_) => failed += 1,
        }
    }
    percentile_intervals(thresholds, failed, options, fit.options.reference)
}

/// The percentile intervals of the refitted thresholds (and Weber fractions against
/// `reference`); an error when fewer than 2 were fitted or more than 10 % failed.
fn percentile_intervals(
    mut thresholds: Vec<f64>,
    failed: usize,
    options: &BootstrapOptions,
    reference: Option<f64>,
) -> Result<Bootstrap, FitError> {
    if thresholds.len() < 2 || failed * 10 > options.resamples {
        return Err(FitError::BootstrapFailed {
            failed,
            resamples: options.resamples,
        });
    }
    thresholds.sort_by(f64::total_cmp);
    let tail = 0.5 * (1.0 - options.coverage);
    let threshold_75 = Interval {
        lower: quantile_sorted(&thresholds, tail),
        upper: quantile_sorted(&thresholds, 1.0 - tail),
    };
    let weber_75 = reference.map(|r| threshold_75.weber(r));
    Ok(Bootstrap {
        threshold_75,
        weber_75,
        fitted: thresholds.len(),
        failed,
    })
}
