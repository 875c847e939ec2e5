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
//! | `condition_order` | `"mixed"` | identification and constant stimuli: `"mixed"` (each block mixes all its cells), `"latin-square"` (each block runs the conditions one after another, in a balanced Latin square's order counterbalanced across participants by the number their ID ends in) or a table of orders, `[["a", "b"], ["b", "a"]]` ([`ConditionOrders`]) |
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

mod checks;
mod error;
mod order;
mod spec;
mod trials;
mod validate;
mod write;

pub use checks::MAX_TRIALS;
pub use error::PlanError;
pub use order::ConditionOrders;
pub use spec::{
    ConditionSpec, Design, FORMAT, MATERIAL_FIELDS, PlanSpec, ReferenceSpec, RuleSpec,
    StaircaseSpec, StepKind, StepSpec, StimulusSpec, StopSpec,
};
pub use trials::{Interval, TrialSpec};
pub use validate::Plan;
