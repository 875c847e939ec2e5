//! The simulated participant of `viewer experiment run --participant sim:SEED[:weber=W][:lapse=L]`:
//! what it perceives of a stimulus it felt, from the forces and positions the loop rendered
//! (never from the stimulus's label), and how it decides.
//!
//! Stiffness: pressing an object, the participant feels the force grow with how far the hand
//! went past where the force began: its estimate is the least-squares slope of the force's
//! magnitude against that penetration along the force's direction (through the origin).
//! Judging two intervals (2AFC), it compares the logarithms of the two estimates, each with
//! Gaussian noise of standard deviation σ; two independent noises make the comparison's noise
//! σ√2, so the comparison at `k = r (1 + W)` is answered right with probability
//! `Φ(ln(1 + W) / (σ√2))`, which is 0.75 at `σ = ln(1 + W) / (√2 Φ⁻¹(0.75))`: the
//! participant's 75 %-correct point on the Weber scale is W. A lapse answers at random.

use crate::fit::{Prng, normal_quantile};

/// The simulated participant's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimParticipant {
    /// Seed of its decision noise.
    pub seed: u64,
    /// Its Weber fraction at 75 % correct in 2AFC (stiffness).
    pub weber: f64,
    /// The probability of a lapse (an answer at random).
    pub lapse: f64,
    /// The standard deviation of its felt contact heights (m): kinesthetic position noise.
    pub acuity_m: f64,
    /// The standard deviation of its felt force directions (rad).
    pub direction_rad: f64,
}

/// Default position noise of a simulated participant's felt contact heights: 1 mm, about the
/// finger's kinesthetic resolution for positions a few centimetres apart (Tan et al. 1994
/// report JNDs of 0.8–2.5 mm for joint displacements at the finger).
pub const DEFAULT_ACUITY_MM: f64 = 1.0;

/// Default noise of a simulated participant's felt force directions: 10°, under the
/// 18–33° force-direction JNDs Tan et al. (2006) measured, since the direction is read at
/// every tap with the hand at rest.
pub const DEFAULT_DIRECTION_DEG: f64 = 10.0;

/// Default Weber fraction of a simulated participant: about what people show for stiffness
/// (Jones & Tan 2013 report 8–22 %).
pub const DEFAULT_WEBER: f64 = 0.15;

/// Why a `--participant` was refused.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ParticipantError {
    /// Not `sim:SEED[:weber=W][:lapse=L]`.
    #[error(
        "--participant {0:?}: expected sim:SEED[:weber=W][:lapse=L][:acuity_mm=A][:direction_deg=D] (or a participant ID)"
    )]
    Form(String),
    /// A field out of its range.
    #[error("--participant {text:?}: {field} = {value} is not {rule}")]
    Field {
        /// The text given.
        text: String,
        /// `seed`, `weber` or `lapse`.
        field: &'static str,
        /// The value given.
        value: String,
        /// What it must be.
        rule: &'static str,
    },
}

impl SimParticipant {
    /// Parses `sim:SEED[:weber=W][:lapse=L][:acuity_mm=A][:direction_deg=D]`: a seed (u64),
    /// a Weber fraction in (0, 10] (default [`DEFAULT_WEBER`]), a lapse rate in [0, 0.5]
    /// (default 0), and for shapes the noise of felt heights in (0, 100] mm (default
    /// [`DEFAULT_ACUITY_MM`]) and of felt force directions in (0, 90]° (default
    /// [`DEFAULT_DIRECTION_DEG`]). `None` for text that is not a simulated participant (a
    /// real participant's ID).
    pub fn parse(text: &str) -> Option<Result<Self, ParticipantError>> {
        let rest = text.strip_prefix("sim:")?;
        Some(Self::parse_fields(text, rest))
    }

    fn parse_fields(text: &str, rest: &str) -> Result<Self, ParticipantError> {
        let field = |field, value: &str, rule| ParticipantError::Field {
            text: text.to_owned(),
            field,
            value: value.to_owned(),
            rule,
        };
        let mut parts = rest.split(':');
        let seed_text = parts.next().unwrap_or_default();
        let seed = seed_text
            .parse::<u64>()
            .map_err(|_| field("seed", seed_text, "a whole number from 0 to 2^64 - 1"))?;
        let mut p = SimParticipant {
            seed,
            weber: DEFAULT_WEBER,
            lapse: 0.0,
            acuity_m: DEFAULT_ACUITY_MM * 1e-3,
            direction_rad: DEFAULT_DIRECTION_DEG.to_radians(),
        };
        for part in parts {
            let (key, value) = part
                .split_once('=')
                .ok_or_else(|| ParticipantError::Form(text.to_owned()))?;
            let number = value.parse::<f64>().ok().filter(|v| v.is_finite());
            match key {
                "weber" => {
                    p.weber = number
                        .filter(|&w| w > 0.0 && w <= 10.0)
                        .ok_or_else(|| field("weber", value, "a Weber fraction in (0, 10]"))?;
                }
                "lapse" => {
                    p.lapse = number
                        .filter(|&l| (0.0..=0.5).contains(&l))
                        .ok_or_else(|| field("lapse", value, "a lapse rate in [0, 0.5]"))?;
                }
                "acuity_mm" => {
                    p.acuity_m = number
                        .filter(|&a| a > 0.0 && a <= 100.0)
                        .ok_or_else(|| field("acuity_mm", value, "a noise in (0, 100] mm"))?
                        * 1e-3;
                }
                "direction_deg" => {
                    p.direction_rad = number
                        .filter(|&a| a > 0.0 && a <= 90.0)
                        .ok_or_else(|| field("direction_deg", value, "a noise in (0, 90] degrees"))?
                        .to_radians();
                }
                _ => return Err(ParticipantError::Form(text.to_owned())),
            }
        }
        Ok(p)
    }

    /// The standard deviation of the noise on one log-stiffness estimate that puts the 2AFC
    /// 75 % point at the Weber fraction (module docs).
    pub fn sigma(&self) -> f64 {
        (1.0 + self.weber).ln() / (std::f64::consts::SQRT_2 * normal_quantile(0.75))
    }

    /// Which of two felt stiffnesses (estimates, N/m) the participant calls stiffer: `false`
    /// for the first, `true` for the second; `rng` draws its noise and lapses.
    pub fn stiffer(&self, first: f64, second: f64, rng: &mut Prng) -> bool {
        if rng.bernoulli(self.lapse) {
            return rng.bernoulli(0.5);
        }
        let sigma = self.sigma();
        let a = first.max(f64::MIN_POSITIVE).ln() + sigma * rng.normal();
        let b = second.max(f64::MIN_POSITIVE).ln() + sigma * rng.normal();
        b > a
    }
}

/// What one vertical tap on a shape felt.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tap {
    /// Where the tap came down (m).
    pub x: f64,
    /// The height at which the force first reached the touch level (m).
    pub height: f64,
    /// The surface slope dy/dx the force's direction conveys at the end of the press: the
    /// force taken as the surface normal `(−g, 1)/√(1 + g²)`.
    pub slope: f64,
}

/// Two cues of a two-sided shape (a roof over x = 0, taps symmetric about it), each the
/// shape's mean sagitta (m, positive where the sides bulge out, convex), from the taps at
/// `0, ±d, ±2d, ±3d, ±4d` (in that order, any sign first):
/// - from heights: `h(±2d) − (h(0) + h(±4d)) / 2` averaged over both sides;
/// - from force directions: the curvature `κ = Δg / 2d` between the slopes at `±d` and `±3d`,
///   as the sagitta `−κ (4d)² / 8` of an arc of that curvature over the side, averaged.
///
/// `None` unless the taps are those nine points.
pub fn shape_cues(taps: &[Tap]) -> Option<[f64; 2]> {
    if taps.len() != 9 {
        return None;
    }
    let d = taps.iter().map(|t| t.x.abs()).fold(0.0, f64::max) / 4.0;
    let at = |k: i32| {
        taps.iter()
            .find(|t| (t.x - f64::from(k) * d).abs() < 0.25 * d)
            .copied()
    };
    let mut pos = 0.0;
    let mut dir = 0.0;
    for side in [-1, 1] {
        let (h0, h2, h4) = (at(0)?, at(2 * side)?, at(4 * side)?);
        pos += 0.5 * (h2.height - 0.5 * (h0.height + h4.height));
        let (inner, outer) = (at(side)?, at(3 * side)?);
        let kappa = (outer.slope - inner.slope) / (outer.x - inner.x);
        dir += 0.5 * (-kappa * (4.0 * d).powi(2) / 8.0);
    }
    Some([pos, dir])
}

impl SimParticipant {
    /// The participant's felt taps: each height with Gaussian noise of [`Self::acuity_m`],
    /// each force direction (the angle of its slope's normal) with Gaussian noise of
    /// [`Self::direction_rad`].
    pub fn feel_taps(&self, taps: &[Tap], rng: &mut Prng) -> Vec<Tap> {
        taps.iter()
            .map(|t| Tap {
                x: t.x,
                height: t.height + self.acuity_m * rng.normal(),
                slope: (t.slope.atan() + self.direction_rad * rng.normal()).tan(),
            })
            .collect()
    }

    /// Which of the candidate shapes (their noiseless [`shape_cues`], in the plan's order:
    /// the pictures the participant chooses among) the felt cues are: the nearest in the
    /// distance that weighs each cue by its noise's variance. The height cue's variance is
    /// `0.875 σ_h²` (its weights 1/2, 1/2, 1/2, 1/4, 1/4 on five independent heights); the
    /// direction cue's `((4d)² / 8)² σ_g² / (2d)²` with the slope noise `σ_g = 2 σ_θ` (at a
    /// 45° slope `dg/dθ = 1 + g² = 2`). A lapse answers at random.
    pub fn identify(
        &self,
        felt: [f64; 2],
        candidates: &[[f64; 2]],
        d: f64,
        rng: &mut Prng,
    ) -> usize {
        if candidates.is_empty() {
            return 0;
        }
        if rng.bernoulli(self.lapse) {
            return rng.index(candidates.len());
        }
        let var_pos = 0.875 * self.acuity_m.powi(2);
        let sigma_g = 2.0 * self.direction_rad;
        let var_dir = ((4.0 * d).powi(2) / 8.0).powi(2) * sigma_g.powi(2) / (2.0 * d).powi(2);
        let distance =
            |c: &[f64; 2]| (felt[0] - c[0]).powi(2) / var_pos + (felt[1] - c[1]).powi(2) / var_dir;
        (0..candidates.len())
            .min_by(|&a, &b| distance(&candidates[a]).total_cmp(&distance(&candidates[b])))
            .unwrap_or(0)
    }
}

/// The stiffness (N/m) a press conveys: the least-squares slope, through the origin, of the
/// force's magnitude against the hand's travel past the point where the force began, measured
/// along the force's direction. `samples` are the hand's positions (m) and the forces on it
/// (N), in time order. `None` when the force never rose or the hand never went in.
pub fn felt_stiffness(samples: &[([f32; 3], [f32; 3])]) -> Option<f64> {
    let first = samples.iter().position(|(_, f)| norm(f) > 0.0)?;
    let contact = samples[first.saturating_sub(1)].0;
    let (mut fd, mut dd) = (0.0, 0.0);
    for (hip, force) in &samples[first..] {
        let f = norm(force);
        if f <= 0.0 {
            continue;
        }
        // The force pushes the hand out: the hand went in along −F.
        let d = -(0..3)
            .map(|k| f64::from(hip[k] - contact[k]) * f64::from(force[k]))
            .sum::<f64>()
            / f;
        if d > 0.0 {
            fd += f * d;
            dd += d * d;
        }
    }
    (dd > 0.0).then(|| fd / dd)
}

fn norm(v: &[f32; 3]) -> f64 {
    v.iter().map(|x| f64::from(*x).powi(2)).sum::<f64>().sqrt()
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_refuses_naming_the_field() {
        assert_eq!(
            SimParticipant::parse("sim:7:weber=0.2:lapse=0.02"),
            Some(Ok(SimParticipant {
                seed: 7,
                weber: 0.2,
                lapse: 0.02,
                acuity_m: 1e-3,
                direction_rad: 10f64.to_radians(),
            }))
        );
        assert_eq!(SimParticipant::parse("P01"), None);
        let err = |t: &str| match SimParticipant::parse(t) {
            Some(Err(e)) => e.to_string(),
            other => panic!("{t}: {other:?}"),
        };
        assert!(err("sim:x").contains("seed = x"));
        assert!(err("sim:1:weber=0").contains("weber = 0"));
        assert!(err("sim:1:lapse=0.9").contains("lapse = 0.9"));
        assert!(err("sim:1:speed=2").contains("expected sim:SEED"));
    }

    /// A linear spring of k pressed along −y: the felt stiffness is k, whatever the approach
    /// before contact. The contact point is the last sample without force, on the samples'
    /// grid here; the f32 positions (ulp 7e-9 m at 0.1 m) against depths of 0.02–2 mm leave
    /// at most ~4e-4 of the slope: 1e-3.
    #[test]
    fn felt_stiffness_of_a_linear_press_is_its_stiffness() {
        let k = 750.0f32;
        let samples: Vec<_> = (0..200)
            .map(|i| {
                let y = 0.1 - i as f32 * 2e-5;
                let depth = (0.098 - y).max(0.0);
                ([0.01, y, 0.0], [0.0, k * depth, 0.0])
            })
            .collect();
        let felt = felt_stiffness(&samples).expect("pressed");
        assert!((felt / f64::from(k) - 1.0).abs() < 1e-3, "{felt}");
    }

    /// The decision rule's 75 % point is the Weber fraction: over 40,000 noiseless-stimulus
    /// trials at k₂ = k₁ (1 + W) the participant says "second" 75 % of the time, within the
    /// binomial 4-sigma band √(0.75·0.25/40000)·4 = 0.0087; at k₂ = k₁, 50 %.
    #[test]
    fn the_75_percent_point_is_the_weber_fraction() {
        let p = SimParticipant {
            weber: 0.2,
            ..SimParticipant::parse("sim:3").unwrap().unwrap()
        };
        let mut rng = Prng::new(p.seed);
        let n = 40_000;
        let right = (0..n).filter(|_| p.stiffer(500.0, 600.0, &mut rng)).count();
        let rate = right as f64 / n as f64;
        assert!((rate - 0.75).abs() < 0.0087, "{rate}");
        let same = (0..n).filter(|_| p.stiffer(500.0, 500.0, &mut rng)).count();
        assert!((same as f64 / n as f64 - 0.5).abs() < 0.01);
    }
}
