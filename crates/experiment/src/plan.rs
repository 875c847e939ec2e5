//! The `experiment/1` plan file: what an experiment renders, in which designs, in which order.
//!
//! A plan is read in two steps, as `scene/1` is: serde parses the JSON into [`PlanSpec`]
//! (strict: unknown fields are errors, and JSON errors name the field path, line and column),
//! then [`Plan::from_spec`] validates it and loads its scenes. Every error names its field and
//! position (`stimuli[2].object: …`, `staircases[0].step.size: …`).
//!
//! ```json
//! {
//!   "format": "experiment/1",
//!   "name": "thesis shapes",
//!   "seed": 20,
//!   "design": "identification",
//!   "stimuli": [ { "name": "convex", "scene": "shapes/shapes-convex-strong.json", "object": 0 } ],
//!   "conditions": [ { "name": "friction", "material": {} },
//!                   { "name": "frictionless", "material": { "mu_static": 0, "mu_dynamic": 0 } } ],
//!   "repetitions": 4, "blocks": 2, "practice_trials": 5, "exploration_time_s": 20
//! }
//! ```
//!
//! | field | default | meaning, valid values |
//! |---|---|---|
//! | `format` | required | `"experiment/1"` |
//! | `name` | required | not empty |
//! | `seed` | required | u64; with the participant's ID, each participant's trial order follows from it ([`Plan::trials_for`]: reproducible per participant, different across participants) |
//! | `design` | required | `"identification"`, `"2afc-staircase"` or `"constant-stimuli"` |
//! | `stimuli` | required | at least one `{ "name", "scene", "object" }`, names distinct |
//! | `stimuli[i].scene` | required | a `scene/1` file, relative to the plan's folder, or a bundled scene's name ([`scene::Bundled`]) when it has no `/` and does not end in `.json` |
//! | `stimuli[i].object` | 0 | index of an object of that scene |
//! | `conditions` | one condition `"scene"` without overrides | `{ "name", "material" }`, names distinct; crossed with the stimuli |
//! | `conditions[i].material` | `{}` | overrides of the stimulus's material: any of [`MATERIAL_FIELDS`] with a number; the result must be a valid material for every stimulus |
//! | `repetitions` | 1 | ≥ 1: how often each stimulus × condition (× level) is run; with the practice trials at most [`MAX_TRIALS`] trials in all |
//! | `blocks` | 1 | ≥ 1 and divides `repetitions`: each block runs every cell `repetitions / blocks` times |
//! | `practice_trials` | 0 | flagged trials before the first block, drawn from the same cells; counted in [`MAX_TRIALS`] |
//! | `exploration_time_s` | none (no limit) | > 0: the longest a participant explores one trial |
//! | `reference` | none | `{ "field", "value" }`: the material field a 2AFC design varies and the reference stimulus's value; required by `2afc-staircase` and `constant-stimuli`, refused by `identification` |
//! | `levels` | `[]` | `constant-stimuli` only, at least one: the comparison values of `reference.field` |
//! | `staircases` | `[]` | `2afc-staircase` only, at least one, names distinct (below) |
//! | `interleave` | `true` | `2afc-staircase` only: run the staircases interleaved (trial by trial at random) or one after another |
//!
//! A staircase, `{ "name", "start", "rule", "step", "stop", "bounds" }`:
//!
//! | field | default | meaning, valid values |
//! |---|---|---|
//! | `start` | required | first comparison value, within `bounds` |
//! | `rule` | `{"down": 2, "up": 1}` | Levitt's transformed rule: `down` correct in a row make it harder, `up` wrong make it easier; both ≥ 1 |
//! | `step.size` | required | > 0 (`additive`: added or subtracted) or > 1 (`multiplicative`: multiplied or divided by) |
//! | `step.kind` | `"additive"` | `"additive"` or `"multiplicative"` (then `start` and `bounds` are > 0) |
//! | `step.reduce_after_reversals` | none | ≥ 1: after this many reversals the step becomes `reduced_size`; both or neither |
//! | `step.reduced_size` | none | as `size` |
//! | `stop` | required | `{"reversals": n}` or `{"trials": n}`, 1 ≤ n ≤ [`MAX_TRIALS`] |
//! | `bounds` | required | `[lo, hi]`, lo < hi; the level is clamped to them |
//!
//! In 2AFC designs, the reference and each comparison value of `reference.field` (levels,
//! staircase starts and bounds) must give a valid material for every stimulus and condition.
//!
//! [`Plan::trials`] lists the trials of an `identification` or `constant-stimuli` plan;
//! [`Plan::to_json_string`] writes the plan back as read (defaults written out, with its seed);
//! [`Plan::to_json_string_resolved`] with absolute scene paths, for the `DIR/plan.json` kept
//! beside a run's results.

use crate::rng::Prng;
use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use friction::FrictionMaterial;
use scene::{Bundled, Material, Scene, SceneError};
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

/// Why a plan was rejected. The message names the file (for [`Plan::load`]) and the field.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// The file could not be read.
    #[error("cannot read {}: {error}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// An error in the named file.
    #[error("{}: {error}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// The error in it.
        error: Box<PlanError>,
    },
    /// JSON syntax error, wrong type, missing or unknown field; serde_json's message ends with
    /// the line and column.
    #[error("{}{error}", if location.is_empty() || location == "." { String::new() } else { format!("{location}: ") })]
    Json {
        /// The field path, e.g. `stimuli[2].object`; empty or `.` at the top level.
        location: String,
        /// serde_json's error.
        error: serde_json::Error,
    },
    /// A field with an invalid value.
    #[error("{field}: {message}")]
    Invalid {
        /// The field path, e.g. `staircases[0].step.size`.
        field: String,
        /// What is wrong with it.
        message: String,
    },
    /// A stimulus's scene could not be loaded or is invalid.
    #[error("{field}: {error}")]
    Scene {
        /// The field path, e.g. `stimuli[1].scene`.
        field: String,
        /// The scene's error.
        error: Box<SceneError>,
    },
}

impl PlanError {
    /// The field the error is about (`stimuli[2].object`; `format`; the JSON path of a JSON
    /// error; for a file, the field of the error in it).
    pub fn field(&self) -> Option<&str> {
        match self {
            PlanError::Read { .. } => None,
            PlanError::File { error, .. } => error.field(),
            PlanError::Json { location, .. } => Some(location),
            PlanError::Invalid { field, .. } | PlanError::Scene { field, .. } => Some(field),
        }
    }
}

fn invalid(field: impl Into<String>, message: impl Into<String>) -> PlanError {
    PlanError::Invalid {
        field: field.into(),
        message: message.into(),
    }
}

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

/// A plan as written in the file (unvalidated; see the module docs for each field).
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

/// A validated plan with its stimuli's scenes loaded.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    spec: PlanSpec,
    scenes: Vec<Scene>,
    /// The folder relative scene paths are resolved against.
    folder: PathBuf,
}

impl Plan {
    /// Parses and validates an `experiment/1` document; relative scene paths are resolved
    /// against `folder` (the plan file's folder).
    pub fn from_json_str(text: &str, folder: &Path) -> Result<Self, PlanError> {
        // The format is checked first so that a file of another version is reported as such,
        // not as a list of unknown fields.
        let header: serde_json::Map<String, serde_json::Value> = parse(text)?;
        match header.get("format") {
            Some(serde_json::Value::String(f)) if f == FORMAT => {}
            Some(found) => {
                return Err(invalid(
                    "format",
                    format!("unsupported format {found}, expected \"{FORMAT}\""),
                ));
            }
            None => return Err(invalid("format", format!("missing, expected \"{FORMAT}\""))),
        }
        Self::from_spec(parse(text)?, folder)
    }

    /// Reads, parses and validates a plan file; errors name the file.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, PlanError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|error| PlanError::Read {
            path: path.to_owned(),
            error,
        })?;
        let folder = path.parent().unwrap_or(Path::new(""));
        Self::from_json_str(&text, folder).map_err(|error| PlanError::File {
            path: path.to_owned(),
            error: Box::new(error),
        })
    }

    /// Validates `spec` and loads its scenes (relative paths against `folder`).
    pub fn from_spec(spec: PlanSpec, folder: &Path) -> Result<Self, PlanError> {
        if spec.format != FORMAT {
            return Err(invalid(
                "format",
                format!(
                    "unsupported format {:?}, expected \"{FORMAT}\"",
                    spec.format
                ),
            ));
        }
        if spec.name.trim().is_empty() {
            return Err(invalid("name", "empty; a plan needs a name"));
        }
        let scenes = load_stimuli(&spec.stimuli, folder)?;
        check_conditions(&spec.conditions)?;
        if spec.repetitions == 0 {
            return Err(invalid("repetitions", "0; at least 1 is needed"));
        }
        if spec.blocks == 0 {
            return Err(invalid("blocks", "0; at least 1 is needed"));
        }
        if !spec.repetitions.is_multiple_of(spec.blocks) {
            return Err(invalid(
                "blocks",
                format!(
                    "{} does not divide repetitions ({}): every block runs each cell equally often",
                    spec.blocks, spec.repetitions
                ),
            ));
        }
        if let Some(t) = spec.exploration_time_s
            && !(t > 0.0 && t.is_finite())
        {
            return Err(invalid(
                "exploration_time_s",
                format!("{t} is not positive"),
            ));
        }
        check_design(&spec)?;
        check_counts(&spec)?;
        let plan = Plan {
            spec,
            scenes,
            folder: folder.to_owned(),
        };
        plan.check_materials()?;
        Ok(plan)
    }

    /// The plan as written (validated).
    pub fn spec(&self) -> &PlanSpec {
        &self.spec
    }

    /// The scene of stimulus `index` (loaded with the plan), if there is one.
    pub fn scene(&self, stimulus: usize) -> Option<&Scene> {
        self.scenes.get(stimulus)
    }

    /// The material of `stimulus` under `condition`, with `reference.field` set to `level`
    /// (if any): the stimulus object's material, then the condition's overrides, then the level.
    pub fn material(
        &self,
        stimulus: usize,
        condition: usize,
        level: Option<f64>,
    ) -> Result<Material, PlanError> {
        let base = self
            .scenes
            .get(stimulus)
            .zip(self.spec.stimuli.get(stimulus))
            .and_then(|(s, st)| s.object(st.object))
            .ok_or_else(|| invalid("stimuli", format!("no stimulus {stimulus}")))?;
        let cond = self
            .spec
            .conditions
            .get(condition)
            .ok_or_else(|| invalid("conditions", format!("no condition {condition}")))?;
        let mut m = base.material().friction_material();
        for (field, &value) in &cond.material {
            set_field(&mut m, field, value)
                .map_err(|e| invalid(format!("conditions[{condition}].material.{field}"), e))?;
        }
        if let (Some(level), Some(reference)) = (level, &self.spec.reference) {
            set_field(&mut m, &reference.field, level)
                .map_err(|e| invalid("reference.field", e))?;
        }
        Material::from_friction(m).map_err(|e| {
            invalid(
                format!("conditions[{condition}].material"),
                format!(
                    "with stimulus {stimulus} ({:?}){}: {e}",
                    self.spec.stimuli[stimulus].name,
                    match level {
                        Some(l) => format!(" at level {l}"),
                        None => String::new(),
                    }
                ),
            )
        })
    }

    /// Every stimulus × condition must make a valid material, at the reference value and at
    /// every comparison value the design can ask for.
    fn check_materials(&self) -> Result<(), PlanError> {
        let mut values: Vec<(String, Option<f64>)> = vec![(String::new(), None)];
        if let Some(r) = &self.spec.reference {
            values.push(("reference.value".to_owned(), Some(r.value)));
        }
        for (i, &l) in self.spec.levels.iter().enumerate() {
            values.push((format!("levels[{i}]"), Some(l)));
        }
        for (i, s) in self.spec.staircases.iter().enumerate() {
            values.push((format!("staircases[{i}].start"), Some(s.start)));
            values.push((format!("staircases[{i}].bounds[0]"), Some(s.bounds[0])));
            values.push((format!("staircases[{i}].bounds[1]"), Some(s.bounds[1])));
        }
        for (field, level) in values {
            for s in 0..self.spec.stimuli.len() {
                for c in 0..self.spec.conditions.len() {
                    self.material(s, c, level).map_err(|e| match (&e, level) {
                        (PlanError::Invalid { message, .. }, Some(_)) => {
                            invalid(field.clone(), format!("{message} (condition {c})"))
                        }
                        _ => e,
                    })?;
                }
            }
        }
        Ok(())
    }

    /// The trials of an `identification` or `constant-stimuli` plan, in order: the practice
    /// trials (flagged, `block: None`), then the blocks. Each block runs every stimulus ×
    /// condition (× level) `repetitions / blocks` times, shuffled (Fisher–Yates with
    /// [`Prng`] seeded by the plan's `seed`); in 2AFC designs each cell's comparison
    /// interval alternates from a random start, so within a block each cell has it first and
    /// second equally often (±1 when the cell runs an odd number of times). Practice trials
    /// are drawn from shuffled rounds of all cells.
    ///
    /// A `2afc-staircase` plan chooses its levels online: its list holds only the practice
    /// trials, with `level: None`.
    pub fn trials(&self) -> Vec<TrialSpec> {
        self.trials_seeded(self.spec.seed)
    }

    /// The trials of [`Plan::trials`] in `participant`'s order: shuffled by the stream of
    /// [`Plan::order_seed`], so every participant's order is reproducible and two
    /// participants' differ (with the plan's seed alone, `sim:5` and `sim:6` ran the same
    /// sequence).
    pub fn trials_for(&self, participant: &str) -> Vec<TrialSpec> {
        self.trials_seeded(self.order_seed(participant))
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
            .spec
            .seed
            .wrapping_add(h)
            .wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    fn trials_seeded(&self, seed: u64) -> Vec<TrialSpec> {
        let spec = &self.spec;
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
                rng.shuffle(&mut list);
                trials.extend(list);
            }
        }
        for (i, t) in trials.iter_mut().enumerate() {
            t.index = i;
        }
        trials
    }

    /// The folder the stimuli's relative scene paths are resolved against.
    pub fn folder(&self) -> &Path {
        &self.folder
    }

    /// The plan as run, for `DIR/plan.json` beside its results: [`Plan::to_json_string`] with
    /// every scene path made absolute (resolved against [`Plan::folder`]), so that the copy
    /// loads from any folder; bundled scene names stay as they are.
    pub fn to_json_string_resolved(&self) -> Result<String, PlanError> {
        let mut spec = self.spec.clone();
        for (i, s) in spec.stimuli.iter_mut().enumerate() {
            if is_path(&s.scene) {
                let path = std::path::absolute(self.folder.join(&s.scene)).map_err(|e| {
                    invalid(
                        format!("stimuli[{i}].scene"),
                        format!("cannot resolve: {e}"),
                    )
                })?;
                s.scene = path.to_string_lossy().into_owned();
            }
        }
        let mut text = serde_json::to_string_pretty(&spec).unwrap_or_default();
        text.push('\n');
        Ok(text)
    }

    /// The plan as a pretty-printed `experiment/1` document (defaults written out), which
    /// [`Plan::from_json_str`] reads back as the same plan.
    pub fn to_json_string(&self) -> String {
        // Serializing plain structs, maps and finite numbers cannot fail.
        let mut text = serde_json::to_string_pretty(&self.spec).unwrap_or_default();
        text.push('\n');
        text
    }
}

fn interval_of(first: bool) -> Interval {
    if first {
        Interval::First
    } else {
        Interval::Second
    }
}

fn load_stimuli(stimuli: &[StimulusSpec], folder: &Path) -> Result<Vec<Scene>, PlanError> {
    if stimuli.is_empty() {
        return Err(invalid(
            "stimuli",
            "the plan has no stimuli, at least one is needed",
        ));
    }
    let mut scenes = Vec::with_capacity(stimuli.len());
    for (i, s) in stimuli.iter().enumerate() {
        check_name(&format!("stimuli[{i}].name"), &s.name)?;
        if let Some(j) = stimuli[..i].iter().position(|o| o.name == s.name) {
            return Err(invalid(
                format!("stimuli[{i}].name"),
                format!("{:?} is also the name of stimuli[{j}]", s.name),
            ));
        }
        let field = format!("stimuli[{i}].scene");
        let scene_error = |error| PlanError::Scene {
            field: field.clone(),
            error: Box::new(error),
        };
        let scene = if is_path(&s.scene) {
            Scene::load(folder.join(&s.scene)).map_err(scene_error)?
        } else {
            match Bundled::find(&s.scene) {
                Some(b) => b.scene().map_err(scene_error)?,
                None => {
                    let names: Vec<&str> = scene::bundled::BUNDLED.iter().map(|b| b.name).collect();
                    return Err(invalid(
                        field,
                        format!(
                            "{:?} is not a bundled scene (they are {}) nor a path (a path contains / or ends in .json)",
                            s.scene,
                            names.join(", ")
                        ),
                    ));
                }
            }
        };
        let count = scene.objects().len();
        if s.object >= count {
            return Err(invalid(
                format!("stimuli[{i}].object"),
                format!(
                    "{} is not an object of {} (it has {count})",
                    s.object, s.scene
                ),
            ));
        }
        scenes.push(scene);
    }
    Ok(scenes)
}

/// A scene reference is a path if it contains `/` or ends in `.json`, else a bundled name.
fn is_path(scene: &str) -> bool {
    scene.contains('/') || scene.ends_with(".json")
}

fn check_name(field: &str, name: &str) -> Result<(), PlanError> {
    if name.trim().is_empty() {
        return Err(invalid(field, "empty; a name is needed"));
    }
    Ok(())
}

fn check_conditions(conditions: &[ConditionSpec]) -> Result<(), PlanError> {
    if conditions.is_empty() {
        return Err(invalid(
            "conditions",
            "empty; leave it out for one condition without overrides",
        ));
    }
    for (i, c) in conditions.iter().enumerate() {
        check_name(&format!("conditions[{i}].name"), &c.name)?;
        if let Some(j) = conditions[..i].iter().position(|o| o.name == c.name) {
            return Err(invalid(
                format!("conditions[{i}].name"),
                format!("{:?} is also the name of conditions[{j}]", c.name),
            ));
        }
        for field in c.material.keys() {
            check_field(&format!("conditions[{i}].material.{field}"), field)?;
        }
    }
    Ok(())
}

fn check_field(at: &str, field: &str) -> Result<(), PlanError> {
    if MATERIAL_FIELDS.contains(&field) {
        Ok(())
    } else {
        Err(invalid(at, not_a_field(field)))
    }
}

fn not_a_field(field: &str) -> String {
    format!(
        "{field:?} is not a material field; the fields are {}",
        MATERIAL_FIELDS.join(", ")
    )
}

/// Sets material field `field` (one of [`MATERIAL_FIELDS`]) to `value`.
fn set_field(m: &mut FrictionMaterial, field: &str, value: f64) -> Result<(), String> {
    // The loop's type is f32; a value beyond it would become infinite.
    let v = value as f32;
    if !v.is_finite() {
        return Err(format!("{value} is not representable in f32"));
    }
    let slot = match field {
        "stiffness_n_per_m" => &mut m.stiffness_n_per_m,
        "damping_ns_per_m" => &mut m.damping_ns_per_m,
        "mu_static" => &mut m.mu_static,
        "mu_dynamic" => &mut m.mu_dynamic,
        "transition_time_s" => &mut m.transition_time_s,
        "converge_tol_m" => &mut m.converge_tol_m,
        "stop_speed_m_per_s" => &mut m.stop_speed_m_per_s,
        "viscous_ns_per_m" => &mut m.viscous_ns_per_m,
        "karnopp_band_m_per_s" => &mut m.karnopp_band_m_per_s,
        "bristle_stiffness_n_per_m" => &mut m.bristle_stiffness_n_per_m,
        "bristle_damping_ns_per_m" => &mut m.bristle_damping_ns_per_m,
        "stribeck_speed_m_per_s" => &mut m.stribeck_speed_m_per_s,
        _ => return Err(not_a_field(field)),
    };
    *slot = v;
    Ok(())
}

fn check_design(spec: &PlanSpec) -> Result<(), PlanError> {
    let design = spec.design.name();
    let only = |field: &str, for_design: &str| {
        invalid(
            field,
            format!("only for {for_design} designs, this one is {design}"),
        )
    };
    match spec.design {
        Design::Identification => {
            if spec.reference.is_some() {
                return Err(only("reference", "2afc-staircase and constant-stimuli"));
            }
        }
        Design::TwoAfcStaircase | Design::ConstantStimuli => match &spec.reference {
            None => {
                return Err(invalid(
                    "reference",
                    format!("missing; a {design} design needs {{\"field\", \"value\"}}"),
                ));
            }
            Some(r) => {
                check_field("reference.field", &r.field)?;
                if !r.value.is_finite() {
                    return Err(invalid("reference.value", "not finite"));
                }
            }
        },
    }
    if spec.design != Design::ConstantStimuli && !spec.levels.is_empty() {
        return Err(only("levels", "constant-stimuli"));
    }
    if spec.design == Design::ConstantStimuli && spec.levels.is_empty() {
        return Err(invalid(
            "levels",
            "empty; a constant-stimuli design needs at least one",
        ));
    }
    if spec.design != Design::TwoAfcStaircase {
        if !spec.staircases.is_empty() {
            return Err(only("staircases", "2afc-staircase"));
        }
        if !spec.interleave {
            return Err(only("interleave", "2afc-staircase"));
        }
        return Ok(());
    }
    if spec.staircases.is_empty() {
        return Err(invalid(
            "staircases",
            "empty; a 2afc-staircase design needs at least one",
        ));
    }
    for (i, s) in spec.staircases.iter().enumerate() {
        check_staircase(i, s, &spec.staircases[..i])?;
        if let Some(r) = spec.reference.as_ref().map(|r| r.value) {
            check_side(i, s, r)?;
        }
    }
    Ok(())
}

/// A staircase stays on one side of the reference: a comparison equal to it has no right
/// answer (the participant guesses, and the trial tells nothing), and one that crosses it
/// turns a right answer into a wrong one. Its bounds must not reach the reference (the
/// shipped JND plan's did: about 15 trials of each run were at the reference itself); the
/// message gives the bound one step away.
fn check_side(i: usize, s: &StaircaseSpec, reference: f64) -> Result<(), PlanError> {
    let [lo, hi] = s.bounds;
    if !(lo <= reference && reference <= hi) {
        return Ok(());
    }
    let size = s.step.reduced_size.unwrap_or(s.step.size);
    let (near_above, near_below) = match s.step.kind {
        StepKind::Multiplicative => (reference * size, reference / size),
        StepKind::Additive => (reference + size, reference - size),
    };
    let suggestion = if s.start > reference {
        format!("[{near_above}, {hi}]")
    } else {
        format!("[{lo}, {near_below}]")
    };
    Err(invalid(
        format!("staircases[{i}].bounds"),
        format!(
            "[{lo}, {hi}] reaches the reference {reference}: a comparison equal to it has no \
             right answer; bound the staircase on one side, e.g. {suggestion}"
        ),
    ))
}

/// Most trials a session takes: a plan asking for more is refused at load, and a session that
/// reaches it (a staircase that never stops) ends with [`RunError::TooManyTrials`]. 10,000
/// trials at a few seconds each is a working day at the device.
///
/// [`RunError::TooManyTrials`]: crate::error::RunError::TooManyTrials
pub const MAX_TRIALS: usize = 10_000;

/// The trials a plan asks for, counted before anything is built: practice plus, unless its
/// levels are chosen online (a staircase), every stimulus × condition (× level) `repetitions`
/// times; each within [`MAX_TRIALS`], the field that passes it named.
fn check_counts(spec: &PlanSpec) -> Result<(), PlanError> {
    let most = MAX_TRIALS as u64;
    let practice = u64::from(spec.practice_trials);
    if practice > most {
        return Err(invalid(
            "practice_trials",
            format!("{practice} is more than a session's {MAX_TRIALS} trials"),
        ));
    }
    for (i, s) in spec.staircases.iter().enumerate() {
        if let StopSpec::Trials(n) = s.stop
            && u64::from(n) > most
        {
            return Err(invalid(
                format!("staircases[{i}].stop.trials"),
                format!("{n} is more than a session's {MAX_TRIALS} trials"),
            ));
        }
    }
    if spec.design == Design::TwoAfcStaircase {
        return Ok(());
    }
    let levels = if spec.design == Design::ConstantStimuli {
        spec.levels.len().max(1)
    } else {
        1
    };
    // Saturating: a count past u64 is still more than MAX_TRIALS.
    let cells = (spec.stimuli.len() as u64)
        .saturating_mul(spec.conditions.len() as u64)
        .saturating_mul(levels as u64);
    let runs = cells.saturating_mul(u64::from(spec.repetitions));
    let total = runs.saturating_add(practice);
    if total > most {
        let field = if runs <= most {
            "practice_trials"
        } else if spec.design == Design::ConstantStimuli && cells > most {
            "levels"
        } else {
            "repetitions"
        };
        let levels = if spec.design == Design::ConstantStimuli {
            format!(" × {levels} levels")
        } else {
            String::new()
        };
        return Err(invalid(
            field,
            format!(
                "{} stimuli × {} conditions{levels} × {} repetitions + {practice} practice \
                 trials = {total} trials, more than a session's {MAX_TRIALS}",
                spec.stimuli.len(),
                spec.conditions.len(),
                spec.repetitions,
            ),
        ));
    }
    Ok(())
}

fn check_staircase(i: usize, s: &StaircaseSpec, before: &[StaircaseSpec]) -> Result<(), PlanError> {
    let at = |field: &str| format!("staircases[{i}].{field}");
    check_name(&at("name"), &s.name)?;
    if let Some(j) = before.iter().position(|o| o.name == s.name) {
        return Err(invalid(
            at("name"),
            format!("{:?} is also the name of staircases[{j}]", s.name),
        ));
    }
    if s.rule.down == 0 {
        return Err(invalid(at("rule.down"), "0; at least 1 is needed"));
    }
    if s.rule.up == 0 {
        return Err(invalid(at("rule.up"), "0; at least 1 is needed"));
    }
    let step_size = |field: &str, size: f64| match s.step.kind {
        StepKind::Additive if !(size > 0.0 && size.is_finite()) => {
            Err(invalid(at(field), format!("{size} is not positive")))
        }
        StepKind::Multiplicative if !(size > 1.0 && size.is_finite()) => Err(invalid(
            at(field),
            format!(
                "{size} is not above 1 (a multiplicative step multiplies or divides the level by it)"
            ),
        )),
        _ => Ok(()),
    };
    step_size("step.size", s.step.size)?;
    match (s.step.reduce_after_reversals, s.step.reduced_size) {
        (Some(0), _) => {
            return Err(invalid(
                at("step.reduce_after_reversals"),
                "0; at least 1 is needed",
            ));
        }
        (Some(_), Some(r)) => step_size("step.reduced_size", r)?,
        (Some(_), None) => {
            return Err(invalid(
                at("step.reduced_size"),
                "missing; reduce_after_reversals needs it",
            ));
        }
        (None, Some(_)) => {
            return Err(invalid(
                at("step.reduce_after_reversals"),
                "missing; reduced_size needs it",
            ));
        }
        (None, None) => {}
    }
    match s.stop {
        StopSpec::Reversals(0) => {
            return Err(invalid(at("stop.reversals"), "0; at least 1 is needed"));
        }
        StopSpec::Trials(0) => return Err(invalid(at("stop.trials"), "0; at least 1 is needed")),
        _ => {}
    }
    let [lo, hi] = s.bounds;
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        return Err(invalid(
            at("bounds"),
            format!("[{lo}, {hi}] is not an interval [lo, hi] with lo < hi"),
        ));
    }
    if s.step.kind == StepKind::Multiplicative && lo <= 0.0 {
        return Err(invalid(
            at("bounds[0]"),
            format!("{lo} is not positive (a multiplicative staircase stays positive)"),
        ));
    }
    if !(lo..=hi).contains(&s.start) {
        return Err(invalid(
            at("start"),
            format!("{} is not within bounds [{lo}, {hi}]", s.start),
        ));
    }
    Ok(())
}

/// Parses with the field path in the error, as `scene/1` does.
fn parse<T: serde::de::DeserializeOwned>(text: &str) -> Result<T, PlanError> {
    let mut de = serde_json::Deserializer::from_str(text);
    let value = serde_path_to_error::deserialize(&mut de).map_err(|e| PlanError::Json {
        location: e.path().to_string(),
        error: e.into_inner(),
    })?;
    de.end().map_err(|error| PlanError::Json {
        location: String::new(),
        error,
    })?;
    Ok(value)
}

impl fmt::Display for Interval {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Interval::First => "first",
            Interval::Second => "second",
        })
    }
}
