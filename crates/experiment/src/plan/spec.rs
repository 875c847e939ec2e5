//! The plan as written in the file: the structures serde reads it into and writes it from,
//! unvalidated.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// The format tag of a plan file.
pub const FORMAT: &str = "experiment/1";

/// The material fields a condition, a reference or a level may set (the numeric fields of
/// [`friction::FrictionMaterial`], as named in `scene/1`).
pub const MATERIAL_FIELDS: &[&str] = &[
    "stiffness_n_per_m",
    "damping_ns_per_m",
    "mu_static",
    "mu_dynamic",
    "transition_time_s",
    "converge_tol_m",
    "stop_speed_m_per_s",
    "viscous_ns_per_m",
    "karnopp_band_m_per_s",
    "bristle_stiffness_n_per_m",
    "bristle_damping_ns_per_m",
    "stribeck_speed_m_per_s",
];

/// The experimental design.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Design {
    /// Each trial renders one stimulus; the participant names it (thesis §4.3).
    #[serde(rename = "identification")]
    Identification,
    /// Two intervals, reference and comparison, the comparison set by adaptive staircases.
    #[serde(rename = "2afc-staircase")]
    TwoAfcStaircase,
    /// Two intervals, reference and comparison, the comparison one of fixed `levels`.
    #[serde(rename = "constant-stimuli")]
    ConstantStimuli,
}

impl Design {
    /// The name in the file.
    pub fn name(self) -> &'static str {
        match self {
            Design::Identification => "identification",
            Design::TwoAfcStaircase => "2afc-staircase",
            Design::ConstantStimuli => "constant-stimuli",
        }
    }

    /// Whether a trial has two intervals (reference and comparison).
    pub fn two_interval(self) -> bool {
        self != Design::Identification
    }
}

/// A plan as written in the file (unvalidated; see [the module docs](crate::plan) for each field).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanSpec {
    /// `"experiment/1"`.
    pub format: String,
    /// The experiment's name.
    pub name: String,
    /// The seed of the trial order.
    pub seed: u64,
    /// The design.
    pub design: Design,
    /// What is rendered.
    pub stimuli: Vec<StimulusSpec>,
    /// Material variants crossed with the stimuli.
    #[serde(default = "default_conditions")]
    pub conditions: Vec<ConditionSpec>,
    /// Runs of each cell.
    #[serde(default = "one")]
    pub repetitions: u32,
    /// Blocks the runs are split into.
    #[serde(default = "one")]
    pub blocks: u32,
    /// Practice trials before the first block.
    #[serde(default)]
    pub practice_trials: u32,
    /// Longest exploration of one trial (s); none: no limit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exploration_time_s: Option<f64>,
    /// The field a 2AFC design varies and its reference value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference: Option<ReferenceSpec>,
    /// Comparison values of a `constant-stimuli` design.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub levels: Vec<f64>,
    /// The staircases of a `2afc-staircase` design.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub staircases: Vec<StaircaseSpec>,
    /// Whether the staircases run interleaved.
    #[serde(default = "yes")]
    pub interleave: bool,
    /// How each block orders its conditions across participants: `"mixed"` (the default),
    /// `"latin-square"` or a table of orders ([`ConditionOrders`](crate::plan::ConditionOrders)).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub condition_order: Option<serde_json::Value>,
}

fn one() -> u32 {
    1
}

fn yes() -> bool {
    true
}

fn default_conditions() -> Vec<ConditionSpec> {
    vec![ConditionSpec {
        name: "scene".to_owned(),
        material: BTreeMap::new(),
    }]
}

/// A stimulus: one object of a scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StimulusSpec {
    /// Its name (the participant's answer in an identification design).
    pub name: String,
    /// A `scene/1` file relative to the plan's folder, or a bundled scene's name.
    pub scene: String,
    /// The object's index in the scene.
    #[serde(default)]
    pub object: usize,
}

/// A condition: overrides of the stimuli's material.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConditionSpec {
    /// Its name.
    pub name: String,
    /// Field ([`MATERIAL_FIELDS`]) → value.
    #[serde(default)]
    pub material: BTreeMap<String, f64>,
}

/// The material field a 2AFC design varies, and the reference's value of it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReferenceSpec {
    /// One of [`MATERIAL_FIELDS`].
    pub field: String,
    /// The reference stimulus's value.
    pub value: f64,
}

/// One adaptive staircase.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StaircaseSpec {
    /// Its name.
    pub name: String,
    /// The first comparison value.
    pub start: f64,
    /// The transformed up/down rule.
    #[serde(default)]
    pub rule: RuleSpec,
    /// The step.
    pub step: StepSpec,
    /// When it ends.
    pub stop: StopSpec,
    /// `[lo, hi]`: the level is kept within them.
    pub bounds: [f64; 2],
}

/// Levitt's transformed up/down rule.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RuleSpec {
    /// Correct answers in a row that make the task harder.
    pub down: u32,
    /// Wrong answers in a row that make it easier.
    pub up: u32,
}

impl Default for RuleSpec {
    /// 2-down/1-up, which converges on 70.7 % correct (Levitt 1971).
    fn default() -> Self {
        RuleSpec { down: 2, up: 1 }
    }
}

/// A staircase's step.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StepSpec {
    /// Added (additive) or multiplied by (multiplicative).
    pub size: f64,
    /// How the step applies.
    #[serde(default)]
    pub kind: StepKind,
    /// Reversals after which the step becomes `reduced_size`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reduce_after_reversals: Option<u32>,
    /// The step after `reduce_after_reversals` reversals.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reduced_size: Option<f64>,
}

/// How a staircase's step applies to its level.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StepKind {
    /// `level ± size`.
    #[default]
    Additive,
    /// `level × size` or `level ÷ size`.
    Multiplicative,
}

/// When a staircase ends.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum StopSpec {
    /// After this many reversals.
    Reversals(u32),
    /// After this many trials.
    Trials(u32),
}
