//! Bayesian credible intervals of a fit's threshold and Weber fraction: the posterior on a
//! grid of threshold and width under the binomial likelihood and weak priors.

use super::*;

/// Bayesian credible intervals ([`credible`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Credible {
    /// Interval of `threshold_75`: the central `coverage` of its marginal posterior.
    pub threshold_75: Interval,
    /// Interval of `weber_75`, when the fit has a reference.
    pub weber_75: Option<Interval>,
}

/// Grid points per axis of [`credible`]'s posterior: threshold, width, lapse rate. With the
/// lapse rate fixed every width's cell at a threshold has the same 75 % point, so the
/// threshold axis alone resolves the quantiles: at 121 cells an end of a folded Weibull's 95 %
/// interval was 1.8 % of its width off a dense integration of the same posterior
/// (`tests/fit.rs`, `folded_fits_match_psignifit`'s constant set), at 241 under 0.5 %.
const GRID: [usize; 3] = [241, 81, 11];

/// psignifit 4's default prior of the threshold (the level where `F = ½`, in `u`): flat over
/// the data's range `[u0, u1]`, falling off with a raised cosine to zero half the range
/// beyond each end.
fn threshold_prior(t: f64, u0: f64, u1: f64) -> f64 {
    let spread = u1 - u0;
    if t < u0 - 0.5 * spread || t > u1 + 0.5 * spread {
        0.0
    } else if t < u0 {
        0.5 * (1.0 + (2.0 * std::f64::consts::PI * (u0 - t) / spread).cos())
    } else if t > u1 {
        0.5 * (1.0 + (2.0 * std::f64::consts::PI * (t - u1) / spread).cos())
    } else {
        1.0
    }
}

/// psignifit 4's default prior of the width (from `F = 0.05` to `F = 0.95`, in `u`): flat
/// from twice the smallest step between two levels, `w_min`, to the data's range `w_max`,
/// rising from zero at `w_min` and falling to zero at `3 w_max` with raised cosines.
fn width_prior(w: f64, w_min: f64, w_max: f64) -> f64 {
    let rise = if w <= w_min {
        0.0
    } else if w < 2.0 * w_min {
        0.5 * (1.0 - (std::f64::consts::PI * (w - w_min) / w_min).cos())
    } else {
        1.0
    };
    let fall = if w >= 3.0 * w_max {
        0.0
    } else if w > w_max {
        0.5 * (1.0 + (0.5 * std::f64::consts::PI * (w - w_max) / w_max).cos())
    } else {
        1.0
    };
    rise * fall
}

/// One axis of the posterior's grid: `n` cell centres over `[lo, hi]`.
fn axis(lo: f64, hi: f64, n: usize) -> impl Iterator<Item = f64> {
    (0..n).map(move |i| lo + (hi - lo) * (i as f64 + 0.5) / n as f64)
}

/// The posterior's grid over a box of threshold, log width and lapse: each cell's
/// `(threshold_75 in u, log weight)`, and the marginal log weights per threshold and width
/// index (for the refined box).
struct Grid {
    cells: Vec<(f64, f64)>,
    marginal_t: Vec<f64>,
    marginal_w: Vec<f64>,
}

/// Bayesian credible intervals of the 75 % threshold and the Weber fraction, psignifit 4's
/// method (Schütt, Harmeling, Macke & Wichmann 2016): the binomial likelihood of `data` times
/// its default priors of threshold and width (above) and its lapse prior Beta(1, 10), here on
/// `[0, λ_max]` (psignifit's own bound is 0.5) and without psignifit's overdispersion term, integrated on a grid over threshold, width and lapse rate (the width's
/// axis logarithmic), first over the priors' whole support and then over the box that holds
/// the posterior's mass; the interval is the central `coverage` of the marginal posterior of
/// `threshold_75` (the level where `ψ = 0.75`, computed in every cell).
///
/// Unlike a parametric bootstrap, which draws from the one best-fitting function, the
/// posterior keeps every psychometric function the data allow: the shallow ones an adaptive
/// run (whose levels cluster at the threshold) cannot exclude widen the interval as they
/// should.
pub fn credible(
    data: &[Point],
    model: Model,
    options: FitOptions,
    coverage: f64,
) -> Result<Credible, FitError> {
    if !(coverage > 0.0 && coverage < 1.0) {
        return Err(FitError::Coverage(coverage));
    }
    let u_axis = validate(data, model, &options)?;
    let prep = prepare(data, u_axis)?;
    // A folded model's levels at the reference (u = −∞) inform neither prior.
    let mut levels: Vec<f64> = prep.u.iter().copied().filter(|u| u.is_finite()).collect();
    levels.sort_by(f64::total_cmp);
    let w_min = levels
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 0.0)
        .fold(f64::INFINITY, f64::min);
    let (u0, u1) = (prep.u_min, prep.u_max);
    let w_max = u1 - u0;
    let span = model.quantile(0.95) - model.quantile(0.05);
    let q50 = model.quantile(0.5);
    let lapse_max = options.lapse_max.max(0.0);
    // Per lapse rate, once: its Beta(1, 10) prior up to its constant, and where the sigmoid
    // puts the 75 % point (`z`: `threshold_75 = m + s z`); a fixed lapse (λ_max = 0) is λ = 0.
    let lapses: Vec<(f64, f64, f64)> =
        axis(0.0, lapse_max, if lapse_max > 0.0 { GRID[2] } else { 1 })
            .filter_map(|lapse| {
                let z = model.quantile(sigmoid_at(lapse, TARGET_75)?);
                Some((lapse, (1.0 - lapse).powi(9), z))
            })
            .collect();
    let grid = |t: (f64, f64), lw: (f64, f64)| -> Grid {
        let mut cells = Vec::with_capacity(GRID[0] * GRID[1] * lapses.len());
        let mut marginal_t = vec![f64::NEG_INFINITY; GRID[0]];
        let mut marginal_w = vec![f64::NEG_INFINITY; GRID[1]];
        for (i, th) in axis(t.0, t.1, GRID[0]).enumerate() {
            let prior_t = threshold_prior(th, u0, u1);
            if prior_t <= 0.0 {
                continue;
            }
            for (j, ln_w) in axis(lw.0, lw.1, GRID[1]).enumerate() {
                let w = ln_w.exp();
                // Flat in the width: its log axis carries the Jacobian w.
                let prior_w = width_prior(w, w_min, w_max) * w;
                if prior_w <= 0.0 {
                    continue;
                }
                let s = w / span;
                let m = th - s * q50;
                for &(lapse, prior_l, z) in &lapses {
                    let log_w =
                        prep.kernel(model, m, s, lapse) + (prior_t * prior_w * prior_l).ln();
                    cells.push((m + s * z, log_w));
                    marginal_t[i] = log_add(marginal_t[i], log_w);
                    marginal_w[j] = log_add(marginal_w[j], log_w);
                }
            }
        }
        Grid {
            cells,
            marginal_t,
            marginal_w,
        }
    };
    let t_full = (u0 - 0.5 * w_max, u1 + 0.5 * w_max);
    let lw_full = (w_min.ln(), (3.0 * w_max).ln());
    let coarse = grid(t_full, lw_full);
    // The refined box: the cells whose marginal is within e⁻¹⁶ (1e-7) of the largest, one
    // cell more on each side.
    let refine = |marginal: &[f64], range: (f64, f64)| -> (f64, f64) {
        let top = marginal.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let kept: Vec<usize> = (0..marginal.len())
            .filter(|&i| marginal[i] >= top - 16.0)
            .collect();
        let (first, last) = (
            kept.first().copied().unwrap_or(0),
            kept.last().copied().unwrap_or(marginal.len() - 1),
        );
        let step = (range.1 - range.0) / marginal.len() as f64;
        (
            range.0 + step * first.saturating_sub(1) as f64,
            range.0 + step * (last + 2).min(marginal.len()) as f64,
        )
    };
    let fine = grid(
        refine(&coarse.marginal_t, t_full),
        refine(&coarse.marginal_w, lw_full),
    );
    let top = fine
        .cells
        .iter()
        .map(|c| c.1)
        .fold(f64::NEG_INFINITY, f64::max);
    if !top.is_finite() {
        return Err(FitError::NoThreshold);
    }
    let mut weighted: Vec<(f64, f64)> = fine
        .cells
        .iter()
        .map(|&(t, lw)| (t, (lw - top).exp()))
        .filter(|c| c.1 > 0.0 && c.0.is_finite())
        .collect();
    weighted.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Cells with the same threshold (every width's, with the lapse rate fixed) are one mass.
    let mut masses: Vec<(f64, f64)> = Vec::with_capacity(weighted.len());
    for (t, w) in weighted {
        match masses.last_mut() {
            Some(last) if last.0 == t => last.1 += w,
            _ => masses.push((t, w)),
        }
    }
    let total: f64 = masses.iter().map(|c| c.1).sum();
    // Each mass spread evenly between the midpoints to its neighbours (half a spacing beyond
    // the ends): the piecewise-linear CDF of the grid's histogram, centred on its cells.
    let edge = |j: usize| -> f64 {
        let n = masses.len();
        if n < 2 {
            return masses.first().map_or(f64::NAN, |c| c.0);
        }
        if j == 0 {
            masses[0].0 - 0.5 * (masses[1].0 - masses[0].0)
        } else if j == n {
            masses[n - 1].0 + 0.5 * (masses[n - 1].0 - masses[n - 2].0)
        } else {
            0.5 * (masses[j - 1].0 + masses[j].0)
        }
    };
    let quantile = |q: f64| -> f64 {
        let goal = q * total;
        let mut cum = 0.0;
        for (j, &(_, w)) in masses.iter().enumerate() {
            if cum + w >= goal {
                let (a, b) = (edge(j), edge(j + 1));
                return a + (b - a) * ((goal - cum) / w).clamp(0.0, 1.0);
            }
            cum += w;
        }
        edge(masses.len())
    };
    let tail = 0.5 * (1.0 - coverage);
    let (lower, upper) = (quantile(tail), quantile(1.0 - tail));
    let threshold_75 = Interval {
        lower: u_axis.level(lower),
        upper: u_axis.level(upper),
    };
    if !(threshold_75.lower.is_finite() && threshold_75.upper.is_finite()) {
        return Err(FitError::NoThreshold);
    }
    Ok(Credible {
        threshold_75,
        weber_75: options.reference.map(|r| Interval {
            lower: u_axis.weber(lower, r),
            upper: u_axis.weber(upper, r),
        }),
    })
}

/// `ln(eᵃ + eᵇ)` without overflow.
fn log_add(a: f64, b: f64) -> f64 {
    let (hi, lo) = if a > b { (a, b) } else { (b, a) };
    if lo == f64::NEG_INFINITY {
        hi
    } else {
        hi + (lo - hi).exp().ln_1p()
    }
}
