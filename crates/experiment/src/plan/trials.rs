//! The trials of a plan in the order they run: the plan's own order and each participant's.

use std::fmt;

use super::error::PlanError;
use super::spec::Design;
use super::validate::Plan;
use crate::rng::Prng;

/// Which interval of a 2AFC trial holds the comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Interval {
    /// The first.
    First,
    /// The second.
    Second,
}

/// One trial of a plan, in the order it runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrialSpec {
    /// Position in the whole list (from 0, practice included).
    pub index: usize,
    /// The block (from 0); `None` for practice trials.
    pub block: Option<usize>,
    /// Whether it is a practice trial (before the first block, not analysed).
    pub practice: bool,
    /// Index in the plan's stimuli.
    pub stimulus: usize,
    /// Index in the plan's conditions.
    pub condition: usize,
    /// The comparison value of `reference.field` (constant stimuli), else `None`.
    pub level: Option<f64>,
    /// Which interval holds the comparison (2AFC designs), else `None`.
    pub comparison_interval: Option<Interval>,
}

impl Plan {
    /// The trials of an `identification` or `constant-stimuli` plan, in order: the practice
    /// trials (flagged, `block: None`), then the blocks. Each block runs every stimulus ×
    /// condition (× level) `repetitions / blocks` times, shuffled (Fisher–Yates with
    /// [`Prng`] seeded by the plan's `seed`); in 2AFC designs each cell's comparison
    /// interval alternates from a random start, so within a block each cell has it first and
    /// second equally often (±1 when the cell runs an odd number of times). Practice trials
    /// are drawn from shuffled rounds of all cells. A plan that counterbalances its
    /// conditions (`condition_order`) runs each block's conditions one after another, each
    /// condition's cells shuffled, in its first order here ([`Plan::trials_for`]: the
    /// participant's).
    ///
    /// A `2afc-staircase` plan chooses its levels online: its list holds only the practice
    /// trials, with `level: None`.
    pub fn trials(&self) -> Vec<TrialSpec> {
        let order = self.condition_orders().map(|o| o.rows()[0].as_slice());
        self.trials_seeded(self.spec().seed, order)
    }

    /// The trials of [`Plan::trials`] in `participant`'s order: shuffled by the stream of
    /// [`Plan::order_seed`], so every participant's order is reproducible and two
    /// participants' differ (with the plan's seed alone, `sim:5` and `sim:6` ran the same
    /// sequence). A plan that counterbalances its conditions runs them in the
    /// participant's row ([`ConditionOrders::row_for`](crate::plan::ConditionOrders::row_for):
    /// refused for an ID that ends in no number).
    pub fn trials_for(&self, participant: &str) -> Result<Vec<TrialSpec>, PlanError> {
        let order = match self.condition_orders() {
            Some(o) => Some(o.row_for(participant)?),
            None => None,
        };
        Ok(self.trials_seeded(self.order_seed(participant), order))
    }

    /// The seed of `participant`'s trial order: the plan's seed and the participant's ID
    /// mixed by a fixed hash (FNV-1a over the ID's bytes, then SplitMix64's finaliser over
    /// the seed's sum with it), the same on every platform and in every version.
    pub fn order_seed(&self, participant: &str) -> u64 {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in participant.bytes() {
            h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
        let mut z = self
            .spec()
            .seed
            .wrapping_add(h)
            .wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// The trials shuffled by `seed`, each block's conditions one after another in `order`
    /// (indices) when given, else mixed.
    fn trials_seeded(&self, seed: u64, order: Option<&[usize]>) -> Vec<TrialSpec> {
        let spec = self.spec();
        let levels: Vec<Option<f64>> = match spec.design {
            Design::ConstantStimuli => spec.levels.iter().copied().map(Some).collect(),
            _ => vec![None],
        };
        let mut cells = Vec::new();
        for stimulus in 0..spec.stimuli.len() {
            for condition in 0..spec.conditions.len() {
                for &level in &levels {
                    cells.push((stimulus, condition, level));
                }
            }
        }
        let two = spec.design.two_interval();
        let mut rng = Prng::new(seed);
        let mut trials = Vec::new();
        let trial = |block, practice, (stimulus, condition, level), interval| TrialSpec {
            index: 0,
            block,
            practice,
            stimulus,
            condition,
            level,
            comparison_interval: if two { Some(interval) } else { None },
        };
        let practice = spec.practice_trials as usize;
        while trials.len() < practice {
            let mut round: Vec<TrialSpec> = cells
                .iter()
                .map(|&cell| {
                    let first = rng.bernoulli(0.5);
                    trial(None, true, cell, interval_of(first))
                })
                .collect();
            rng.shuffle(&mut round);
            round.truncate(practice - trials.len());
            trials.extend(round);
        }
        if spec.design != Design::TwoAfcStaircase {
            let per_block = (spec.repetitions / spec.blocks) as usize;
            for block in 0..spec.blocks as usize {
                let mut list = Vec::with_capacity(cells.len() * per_block);
                for &cell in &cells {
                    let first = rng.bernoulli(0.5);
                    for k in 0..per_block {
                        list.push(trial(
                            Some(block),
                            false,
                            cell,
                            interval_of(first ^ (k % 2 == 1)),
                        ));
                    }
                }
                match order {
                    None => rng.shuffle(&mut list),
                    Some(order) => {
                        // One stretch per condition, in the row's order, each shuffled.
                        let mut ordered = Vec::with_capacity(list.len());
                        for &condition in order {
                            let mut stretch: Vec<TrialSpec> = list
                                .iter()
                                .filter(|t| t.condition == condition)
                                .copied()
                                .collect();
                            rng.shuffle(&mut stretch);
                            ordered.extend(stretch);
                        }
                        list = ordered;
                    }
                }
                trials.extend(list);
            }
        }
        for (i, t) in trials.iter_mut().enumerate() {
            t.index = i;
        }
        trials
    }
}

fn interval_of(first: bool) -> Interval {
    if first {
        Interval::First
    } else {
        Interval::Second
    }
}

impl fmt::Display for Interval {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Interval::First => "first",
            Interval::Second => "second",
        })
    }
}
