//! The `experiment/1` plan: the shipped plans load, every validation rule names its field, the
//! trial order is balanced and randomised, and a plan reads back as written.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use experiment::plan::{Design, Interval, Plan, PlanError, TrialSpec};
use experiment::rng::Prng;
use serde_json::{Value, json};

fn experiments() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../experiments")
}

fn thesis_shapes() -> Plan {
    Plan::load(experiments().join("thesis-shapes.json")).expect("thesis-shapes.json")
}

/// A small valid identification plan, relative to `experiments/`.
fn base() -> Value {
    json!({
        "format": "experiment/1",
        "name": "test",
        "seed": 7,
        "design": "identification",
        "stimuli": [
            { "name": "convex", "scene": "shapes/shapes-convex-strong.json", "object": 0 },
            { "name": "concave", "scene": "shapes/shapes-concave-strong.json" },
            { "name": "bundled", "scene": "thesis-2d", "object": 0 }
        ],
        "conditions": [
            { "name": "friction", "material": {} },
            { "name": "frictionless", "material": { "mu_static": 0.0, "mu_dynamic": 0.0 } }
        ],
        "repetitions": 4,
        "blocks": 2,
        "practice_trials": 3
    })
}

fn staircase_base() -> Value {
    json!({
        "format": "experiment/1",
        "name": "jnd",
        "seed": 1,
        "design": "2afc-staircase",
        "stimuli": [ { "name": "straight", "scene": "shapes/shapes-straight.json" } ],
        "reference": { "field": "stiffness_n_per_m", "value": 500.0 },
        "staircases": [ {
            "name": "above", "start": 800.0,
            "step": { "size": 1.2, "kind": "multiplicative" },
            "stop": { "reversals": 8 }, "bounds": [600.0, 1500.0]
        } ]
    })
}

fn constant_base() -> Value {
    json!({
        "format": "experiment/1",
        "name": "constant",
        "seed": 3,
        "design": "constant-stimuli",
        "stimuli": [ { "name": "straight", "scene": "shapes/shapes-straight.json" } ],
        "reference": { "field": "stiffness_n_per_m", "value": 500.0 },
        "levels": [400.0, 450.0, 550.0, 600.0],
        "repetitions": 6,
        "blocks": 3
    })
}

fn read(v: &Value) -> Result<Plan, PlanError> {
    Plan::from_json_str(&v.to_string(), &experiments())
}

/// `v` with the value at the JSON pointer `at` set to `with` (a missing object key is added).
fn with(mut v: Value, at: &str, with: Value) -> Value {
    let (parent, key) = at.rsplit_once('/').expect(at);
    match v.pointer_mut(parent).expect(at) {
        Value::Object(map) => {
            map.insert(key.to_owned(), with);
        }
        Value::Array(items) => items[key.parse::<usize>().expect(at)] = with,
        _ => panic!("{at}: not in an object or array"),
    }
    v
}

/// The error of reading `v`, which must name `field` first and contain `words`.
fn refused(v: &Value, field: &str, words: &str) {
    let error = read(v).expect_err("the plan should be refused");
    let message = error.to_string();
    assert_eq!(error.field(), Some(field), "{message}");
    assert!(message.starts_with(&format!("{field}: ")), "{message}");
    assert!(message.contains(words), "{message:?} lacks {words:?}");
}

#[test]
fn shipped_plans_load() {
    let shapes = thesis_shapes();
    assert_eq!(shapes.spec().design, Design::Identification);
    assert_eq!(shapes.spec().stimuli.len(), 5);
    assert_eq!(shapes.spec().conditions.len(), 2);
    // friction off: μ = 0 on every shape; on: the scene's own.
    for s in 0..5 {
        let off = shapes.material(s, 1, None).expect("frictionless");
        assert_eq!((off.mu_static(), off.mu_dynamic()), (0.0, 0.0));
        let on = shapes.material(s, 0, None).expect("friction");
        assert!(on.mu_static() > 0.0 && on.mu_dynamic() > 0.0);
    }
    let jnd = Plan::load(experiments().join("stiffness-jnd.json")).expect("stiffness-jnd.json");
    assert_eq!(jnd.spec().design, Design::TwoAfcStaircase);
    assert_eq!(jnd.spec().staircases.len(), 2);
    assert!(jnd.spec().interleave);
    let reference = jnd.spec().reference.as_ref().expect("reference");
    assert_eq!(
        (reference.field.as_str(), reference.value),
        ("stiffness_n_per_m", 500.0)
    );
    let starts: Vec<f64> = jnd.spec().staircases.iter().map(|s| s.start).collect();
    assert!(starts.iter().any(|&s| s > 500.0) && starts.iter().any(|&s| s < 500.0));
    let stiff = jnd.material(0, 0, Some(800.0)).expect("level");
    assert_eq!(stiff.stiffness_n_per_m(), 800.0);
    // The small test plans are valid too.
    for v in [base(), staircase_base(), constant_base()] {
        read(&v).expect("test plan");
    }
}

/// The five shapes are roofs whose vertex is the chain's joint, inside the pantograph's
/// workspace, with the app's start point (0, 0.11) above (outside) them.
#[test]
fn shapes_are_two_curves_meeting_below_the_start_point() {
    let shapes = thesis_shapes();
    for s in 0..5 {
        let object = &shapes.scene(s).expect("scene").objects()[0];
        let curves = object.curve_views().expect("planar");
        assert_eq!(curves.len(), 2);
        for c in &curves {
            for p in c.points() {
                // Homogeneous (x·w, y·w, w).
                let (x, y) = (p.x / p.z, p.y / p.z);
                assert!((-0.04..=0.04).contains(&x) && (0.06..=0.12).contains(&y));
                assert!(
                    y < 0.11 - 0.01,
                    "every point at least 1 cm below the start point"
                );
            }
            // Homogeneous → Cartesian control points of both curves.
            let xy = |c: usize| -> Vec<(f32, f32)> {
                curves[c]
                    .points()
                    .iter()
                    .map(|p| (p.x / p.z, p.y / p.z))
                    .collect()
            };
            let (right, left) = (xy(0), xy(1));
            // Right end → vertex → left end: the direction over the top is −x, whose right-hand
            // side (t × k̂ = (t_y, −t_x) = (0, 1)) is up, towards the start point.
            assert!(right[0].0 > 0.0 && left[2].0 < 0.0);
            assert_eq!(right[2], left[0], "the curves meet at the vertex");
            assert_eq!(right[2].0, 0.0);
            // The middle control point lies to the right of the chord (outside: convex), on it
            // (straight) or to its left (inside: concave), in the order of the stimuli. The cross
            // product's size is ~1e-4 m² for the bowed ones; 1e-9 only absorbs rounding.
            let (a, m, b) = (right[0], right[1], right[2]);
            let cross = (b.0 - a.0) * (m.1 - a.1) - (b.1 - a.1) * (m.0 - a.0);
            let side = if cross.abs() < 1e-9 {
                0
            } else if cross < 0.0 {
                1
            } else {
                -1
            };
            assert_eq!(side, [1, 1, 0, -1, -1][s], "shape {s}: cross {cross}");
        }
    }
}

#[test]
fn format_is_checked_first() {
    refused(
        &with(base(), "/format", json!("experiment/2")),
        "format",
        "unsupported",
    );
    let mut v = base();
    v.as_object_mut().expect("object").remove("format");
    refused(&v, "format", "missing");
}

#[test]
fn unknown_fields_are_refused_with_their_path() {
    let mut v = base();
    v["stimuli"][1]["colour"] = json!("red");
    let message = read(&v).expect_err("unknown field").to_string();
    assert!(message.starts_with("stimuli[1]"), "{message}");
    assert!(
        message.contains("unknown field `colour`") && message.contains("line"),
        "{message}"
    );
    let mut v = staircase_base();
    v["staircases"][0]["step"]["sise"] = json!(1);
    let message = read(&v).expect_err("unknown field").to_string();
    assert!(message.starts_with("staircases[0].step"), "{message}");
}

#[test]
fn wrong_types_name_their_field() {
    let message = read(&with(base(), "/stimuli/0/object", json!(-1)))
        .expect_err("negative index")
        .to_string();
    assert!(message.starts_with("stimuli[0].object: "), "{message}");
    let message = read(&with(base(), "/design", json!("yes-no")))
        .expect_err("design")
        .to_string();
    assert!(message.starts_with("design: "), "{message}");
}

#[test]
fn name_must_not_be_empty() {
    refused(&with(base(), "/name", json!(" ")), "name", "empty");
}

#[test]
fn stimuli_must_not_be_empty() {
    refused(
        &with(base(), "/stimuli", json!([])),
        "stimuli",
        "no stimuli",
    );
}

#[test]
fn stimulus_names_are_distinct() {
    refused(
        &with(base(), "/stimuli/2/name", json!("convex")),
        "stimuli[2].name",
        "also the name of stimuli[0]",
    );
}

#[test]
fn stimulus_object_must_exist() {
    refused(
        &with(base(), "/stimuli/1/object", json!(5)),
        "stimuli[1].object",
        "5 is not an object of shapes/shapes-concave-strong.json (it has 1)",
    );
}

#[test]
fn stimulus_scene_must_load() {
    refused(
        &with(base(), "/stimuli/0/scene", json!("../scenes/no-such.json")),
        "stimuli[0].scene",
        "cannot read",
    );
    refused(
        &with(base(), "/stimuli/2/scene", json!("thesis-4d")),
        "stimuli[2].scene",
        "not a bundled scene",
    );
}

#[test]
fn condition_fields_are_material_fields() {
    refused(
        &with(base(), "/conditions/1/material", json!({ "mu_statc": 0.1 })),
        "conditions[1].material.mu_statc",
        "is not a material field; the fields are stiffness_n_per_m",
    );
}

#[test]
fn condition_must_make_a_valid_material() {
    // μ_d > μ_s with the scene's μ_s 0.7.
    refused(
        &with(
            base(),
            "/conditions/1/material",
            json!({ "mu_dynamic": 0.9 }),
        ),
        "conditions[1].material",
        "with stimulus 0",
    );
    refused(
        &with(
            base(),
            "/conditions/0/material",
            json!({ "stiffness_n_per_m": -5.0 }),
        ),
        "conditions[0].material",
        "stiffness_n_per_m",
    );
}

#[test]
fn condition_names_are_distinct_and_present() {
    refused(
        &with(base(), "/conditions/1/name", json!("friction")),
        "conditions[1].name",
        "also the name of conditions[0]",
    );
    refused(
        &with(base(), "/conditions", json!([])),
        "conditions",
        "empty",
    );
}

#[test]
fn repetitions_and_blocks() {
    refused(
        &with(base(), "/repetitions", json!(0)),
        "repetitions",
        "at least 1",
    );
    refused(&with(base(), "/blocks", json!(0)), "blocks", "at least 1");
    refused(
        &with(base(), "/blocks", json!(3)),
        "blocks",
        "3 does not divide repetitions (4)",
    );
}

#[test]
fn exploration_time_is_positive() {
    refused(
        &with(base(), "/exploration_time_s", json!(0.0)),
        "exploration_time_s",
        "0 is not positive",
    );
}

#[test]
fn design_fields_belong_to_their_design() {
    let mut v = base();
    v["reference"] = json!({ "field": "stiffness_n_per_m", "value": 500.0 });
    refused(
        &v,
        "reference",
        "only for 2afc-staircase and constant-stimuli",
    );
    let mut v = base();
    v["levels"] = json!([1.0]);
    refused(&v, "levels", "only for constant-stimuli");
    let mut v = constant_base();
    v["staircases"] = staircase_base()["staircases"].clone();
    refused(&v, "staircases", "only for 2afc-staircase");
    let mut v = constant_base();
    v["interleave"] = json!(false);
    refused(&v, "interleave", "only for 2afc-staircase");
}

#[test]
fn two_interval_designs_need_a_reference() {
    let mut v = staircase_base();
    v.as_object_mut().expect("object").remove("reference");
    refused(&v, "reference", "missing");
    refused(
        &with(
            staircase_base(),
            "/reference/field",
            json!("stifness_n_per_m"),
        ),
        "reference.field",
        "\"stifness_n_per_m\" is not a material field; the fields are stiffness_n_per_m, ",
    );
    refused(
        &with(constant_base(), "/reference/value", json!(-500.0)),
        "reference.value",
        "stiffness_n_per_m",
    );
}

#[test]
fn constant_stimuli_levels() {
    refused(
        &with(constant_base(), "/levels", json!([])),
        "levels",
        "at least one",
    );
    refused(
        &with(constant_base(), "/levels/2", json!(-1.0)),
        "levels[2]",
        "stiffness_n_per_m",
    );
}

#[test]
fn staircases_must_not_be_empty() {
    refused(
        &with(staircase_base(), "/staircases", json!([])),
        "staircases",
        "at least one",
    );
}

#[test]
fn staircase_step_size() {
    let v = with(
        staircase_base(),
        "/staircases/0/step",
        json!({ "size": -1, "kind": "additive" }),
    );
    refused(&v, "staircases[0].step.size", "-1 is not positive");
    let v = with(staircase_base(), "/staircases/0/step/size", json!(1.0));
    refused(&v, "staircases[0].step.size", "1 is not above 1");
}

#[test]
fn staircase_step_reduction() {
    let v = with(
        staircase_base(),
        "/staircases/0/step/reduce_after_reversals",
        json!(4),
    );
    refused(&v, "staircases[0].step.reduced_size", "missing");
    let v = with(
        staircase_base(),
        "/staircases/0/step/reduced_size",
        json!(1.1),
    );
    refused(&v, "staircases[0].step.reduce_after_reversals", "missing");
    let mut v = staircase_base();
    v["staircases"][0]["step"]["reduce_after_reversals"] = json!(4);
    v["staircases"][0]["step"]["reduced_size"] = json!(0.5);
    refused(&v, "staircases[0].step.reduced_size", "0.5 is not above 1");
}

#[test]
fn staircase_rule() {
    let v = with(
        staircase_base(),
        "/staircases/0/rule",
        json!({ "down": 0, "up": 1 }),
    );
    refused(&v, "staircases[0].rule.down", "at least 1");
    let v = with(
        staircase_base(),
        "/staircases/0/rule",
        json!({ "down": 2, "up": 0 }),
    );
    refused(&v, "staircases[0].rule.up", "at least 1");
}

#[test]
fn staircase_stop() {
    let v = with(
        staircase_base(),
        "/staircases/0/stop",
        json!({ "reversals": 0 }),
    );
    refused(&v, "staircases[0].stop.reversals", "at least 1");
    let v = with(
        staircase_base(),
        "/staircases/0/stop",
        json!({ "trials": 0 }),
    );
    refused(&v, "staircases[0].stop.trials", "at least 1");
}

#[test]
fn staircase_bounds_and_start() {
    let v = with(
        staircase_base(),
        "/staircases/0/bounds",
        json!([900.0, 600.0]),
    );
    refused(&v, "staircases[0].bounds", "lo < hi");
    let v = with(
        staircase_base(),
        "/staircases/0/bounds",
        json!([0.0, 1500.0]),
    );
    refused(&v, "staircases[0].bounds[0]", "0 is not positive");
    let v = with(staircase_base(), "/staircases/0/start", json!(2000.0));
    refused(&v, "staircases[0].start", "not within bounds [600, 1500]");
    // An additive staircase may reach 0 N/m (a valid material) but not below.
    let mut v = staircase_base();
    v["staircases"][0]["step"] = json!({ "size": 50.0 });
    v["staircases"][0]["start"] = json!(300.0);
    v["staircases"][0]["bounds"] = json!([-100.0, 450.0]);
    refused(&v, "staircases[0].bounds[0]", "stiffness_n_per_m");
}

#[test]
fn staircase_names_are_distinct() {
    let mut v = staircase_base();
    let copy = v["staircases"][0].clone();
    v["staircases"].as_array_mut().expect("array").push(copy);
    refused(&v, "staircases[1].name", "also the name of staircases[0]");
}

fn cell(t: &TrialSpec) -> (usize, usize, Option<u64>) {
    (t.stimulus, t.condition, t.level.map(f64::to_bits))
}

/// Counts of each cell among `trials`.
fn counts<'a>(
    trials: impl Iterator<Item = &'a TrialSpec>,
) -> HashMap<(usize, usize, Option<u64>), usize> {
    let mut c = HashMap::new();
    for t in trials {
        *c.entry(cell(t)).or_insert(0) += 1;
    }
    c
}

#[test]
fn identification_is_balanced() {
    let plan = thesis_shapes();
    let trials = plan.trials();
    // 5 stimuli × 2 conditions × 4 repetitions + 5 practice trials.
    assert_eq!(trials.len(), 5 + 5 * 2 * 4);
    for (i, t) in trials.iter().enumerate() {
        assert_eq!(t.index, i);
        assert_eq!(t.practice, i < 5);
        assert_eq!(t.practice, t.block.is_none());
        assert_eq!(t.comparison_interval, None);
        assert_eq!(t.level, None);
    }
    let main = counts(trials.iter().filter(|t| !t.practice));
    assert_eq!(main.len(), 10);
    assert!(main.values().all(|&n| n == 4), "{main:?}");
    for block in 0..2 {
        let in_block: Vec<&TrialSpec> = trials.iter().filter(|t| t.block == Some(block)).collect();
        assert_eq!(in_block.len(), 20);
        let c = counts(in_block.into_iter());
        assert_eq!(c.len(), 10);
        assert!(c.values().all(|&n| n == 2), "block {block}: {c:?}");
    }
    // Blocks run in order.
    let blocks: Vec<usize> = trials.iter().filter_map(|t| t.block).collect();
    assert!(blocks.windows(2).all(|w| w[0] <= w[1]));
    // 5 practice trials out of one round of 10 cells: no cell twice.
    assert!(
        counts(trials.iter().filter(|t| t.practice))
            .values()
            .all(|&n| n == 1)
    );
}

#[test]
fn constant_stimuli_is_balanced_in_levels_and_intervals() {
    let plan = read(&constant_base()).expect("plan");
    let trials = plan.trials();
    assert_eq!(trials.len(), 4 * 6);
    let c = counts(trials.iter());
    assert_eq!(c.len(), 4);
    assert!(c.values().all(|&n| n == 6));
    // 2 runs of each level per block: one with the comparison first, one second.
    for block in 0..3 {
        for level in [400.0, 450.0, 550.0, 600.0] {
            let intervals: Vec<Interval> = trials
                .iter()
                .filter(|t| t.block == Some(block) && t.level == Some(level))
                .map(|t| t.comparison_interval.expect("2AFC"))
                .collect();
            assert_eq!(intervals.len(), 2);
            assert_ne!(intervals[0], intervals[1], "block {block}, level {level}");
        }
    }
}

/// Over many seeds, which interval a cell's run has is random: the first trial's comparison
/// interval is first about half the time (200 seeds: mean 100, σ = √(200·¼) ≈ 7.1; 5σ).
#[test]
fn interval_order_is_randomised() {
    let mut first = 0;
    for seed in 0..200 {
        let plan = read(&with(constant_base(), "/seed", json!(seed))).expect("plan");
        if plan.trials()[0].comparison_interval == Some(Interval::First) {
            first += 1;
        }
    }
    assert!((65..=135).contains(&first), "{first}");
}

#[test]
fn same_seed_same_order_other_seed_other_order() {
    let a = thesis_shapes();
    assert_eq!(a.trials(), a.trials());
    let again = Plan::load(experiments().join("thesis-shapes.json")).expect("again");
    assert_eq!(a.trials(), again.trials());
    let mut spec = a.spec().clone();
    spec.seed += 1;
    let b = Plan::from_spec(spec, &experiments()).expect("other seed");
    let order = |p: &Plan| p.trials().iter().map(cell).collect::<Vec<_>>();
    assert_ne!(order(&a), order(&b));
}

#[test]
fn order_is_not_the_unshuffled_one() {
    let plan = thesis_shapes();
    let block0: Vec<(usize, usize)> = plan
        .trials()
        .iter()
        .filter(|t| t.block == Some(0))
        .map(|t| (t.stimulus, t.condition))
        .collect();
    let mut sorted = block0.clone();
    sorted.sort_unstable();
    assert_ne!(block0, sorted);
}

/// Over 200 seeds, the first main trial's stimulus is each of the five with probability 1/5
/// (10 equally likely cells, 2 per stimulus): its count is Binomial(200, 1/5), mean 40,
/// σ = √(200·0.2·0.8) ≈ 5.66. The bound 40 ± 5σ ≈ [12, 68] fails for a fair shuffle with
/// probability below 10⁻⁵ (five normal tails of 5σ, each ≈ 3·10⁻⁷ doubled), while a shuffle
/// stuck on one order puts all 200 on one stimulus.
#[test]
fn first_trial_stimulus_is_uniform_over_seeds() {
    let shapes = thesis_shapes();
    let mut hits = [0usize; 5];
    for seed in 0..200 {
        let mut spec = shapes.spec().clone();
        spec.seed = seed;
        let plan = Plan::from_spec(spec, &experiments()).expect("plan");
        let first = plan
            .trials()
            .into_iter()
            .find(|t| !t.practice)
            .expect("a main trial");
        hits[first.stimulus] += 1;
    }
    assert!(hits.iter().all(|&n| (12..=68).contains(&n)), "{hits:?}");
}

#[test]
fn staircase_plan_lists_only_practice() {
    let plan = read(&with(staircase_base(), "/practice_trials", json!(3))).expect("plan");
    let trials = plan.trials();
    assert_eq!(trials.len(), 3);
    assert!(
        trials
            .iter()
            .all(|t| t.practice && t.comparison_interval.is_some())
    );
}

#[test]
fn to_json_string_round_trips() {
    for plan in [
        thesis_shapes(),
        Plan::load(experiments().join("stiffness-jnd.json")).expect("jnd"),
        read(&constant_base()).expect("constant"),
        read(&base()).expect("base"),
    ] {
        let text = plan.to_json_string();
        let back = Plan::from_json_str(&text, &experiments()).expect(&text);
        assert_eq!(back, plan);
        assert_eq!(back.trials(), plan.trials());
        assert_eq!(back.to_json_string(), text);
    }
}

/// Fisher–Yates over 3 items: each of the 6 permutations about 1/6 of 6000 shuffles
/// (Binomial(6000, 1/6): mean 1000, σ ≈ 28.9; 5σ ≈ 144).
#[test]
fn shuffle_is_uniform_over_permutations() {
    let mut rng = Prng::new(99);
    let mut seen: HashMap<[u8; 3], usize> = HashMap::new();
    for _ in 0..6000 {
        let mut items = [0u8, 1, 2];
        rng.shuffle(&mut items);
        *seen.entry(items).or_insert(0) += 1;
    }
    assert_eq!(seen.len(), 6);
    assert!(
        seen.values().all(|&n| (856..=1144).contains(&n)),
        "{seen:?}"
    );
}

/// The plan as run, written beside its results, loads from another folder with the same
/// scenes and trials.
#[test]
fn resolved_copy_loads_from_anywhere() {
    let plan = thesis_shapes();
    let text = plan.to_json_string_resolved().expect("resolved");
    let elsewhere = std::env::temp_dir();
    let back = Plan::from_json_str(&text, &elsewhere).expect(&text);
    assert_eq!(back.trials(), plan.trials());
    for s in 0..plan.spec().stimuli.len() {
        assert_eq!(back.scene(s), plan.scene(s));
        assert!(Path::new(&back.spec().stimuli[s].scene).is_absolute());
    }
    // Bundled names are kept.
    let with_bundled = read(&base()).expect("base");
    let text = with_bundled.to_json_string_resolved().expect("resolved");
    let back = Plan::from_json_str(&text, &elsewhere).expect(&text);
    assert_eq!(back.spec().stimuli[2].scene, "thesis-2d");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(48))]

    /// For any seed, block count and repetitions per block, every block runs every cell
    /// equally often, and each cell's comparison interval is first and second equally often
    /// within a block (±1 for an odd count).
    #[test]
    fn every_block_is_balanced(seed in proptest::prelude::any::<u64>(), blocks in 1u32..4, per_block in 1u32..4, practice in 0u32..7) {
        let mut spec = read(&constant_base()).expect("plan").spec().clone();
        spec.seed = seed;
        spec.blocks = blocks;
        spec.repetitions = blocks * per_block;
        spec.practice_trials = practice;
        let plan = Plan::from_spec(spec, &experiments()).expect("valid");
        let trials = plan.trials();
        proptest::prop_assert_eq!(trials.len(), (practice + 4 * blocks * per_block) as usize);
        for block in 0..blocks as usize {
            let c = counts(trials.iter().filter(|t| t.block == Some(block)));
            proptest::prop_assert_eq!(c.len(), 4);
            proptest::prop_assert!(c.values().all(|&n| n == per_block as usize));
            for key in c.keys() {
                let first = trials
                    .iter()
                    .filter(|t| t.block == Some(block) && cell(t) == *key)
                    .filter(|t| t.comparison_interval == Some(Interval::First))
                    .count() as i64;
                proptest::prop_assert!((2 * first - i64::from(per_block)).abs() <= 1);
            }
        }
    }
}

/// A session holds at most `MAX_TRIALS` trials: a plan asking for more is refused at load,
/// naming the field that passes it, before any list is built (1e9 repetitions would be a
/// 128 GB list), and a plan of exactly that many loads and lists them all.
#[test]
fn counts_are_bounded_by_what_a_session_holds() {
    use experiment::plan::MAX_TRIALS;
    assert_eq!(MAX_TRIALS, 10_000);
    // base(): 3 stimuli × 2 conditions, blocks 2. 6 × 1666 + 4 = 10,000 exactly.
    let full = with(
        with(base(), "/repetitions", json!(1666)),
        "/practice_trials",
        json!(4),
    );
    let plan = read(&full).expect("a plan of exactly MAX_TRIALS trials");
    assert_eq!(plan.trials().len(), MAX_TRIALS);
    // One practice trial more.
    refused(
        &with(full.clone(), "/practice_trials", json!(5)),
        "practice_trials",
        "= 10001 trials, more than a session's 10000",
    );
    // Two repetitions more (blocks must divide them).
    refused(
        &with(full, "/repetitions", json!(1668)),
        "repetitions",
        "3 stimuli × 2 conditions × 1668 repetitions + 4 practice trials = 10012 trials",
    );
    for (field, value, words) in [
        ("repetitions", 1_000_000_000u32, "= 6000000003 trials"),
        (
            "practice_trials",
            1_000_000_000,
            "1000000000 is more than a session's 10000",
        ),
    ] {
        let v = with(
            with(base(), "/blocks", json!(1)),
            &format!("/{field}"),
            json!(value),
        );
        refused(&v, field, words);
    }
    let v = with(
        with(base(), "/blocks", json!(1_000_000_000)),
        "/repetitions",
        json!(1_000_000_000),
    );
    refused(&v, "repetitions", "more than a session's 10000");
    // A constant-stimuli plan of 10,001 levels: one repetition is already too many.
    let levels: Vec<f64> = (0..=MAX_TRIALS).map(|i| 400.0 + i as f64 * 0.01).collect();
    let v = with(
        with(
            with(constant_base(), "/levels", json!(levels)),
            "/repetitions",
            json!(1),
        ),
        "/blocks",
        json!(1),
    );
    refused(&v, "levels", "× 10001 levels × 1 repetitions");
    // A staircase's own trial limit.
    let v = with(
        staircase_base(),
        "/staircases/0/stop",
        json!({ "trials": 10_001 }),
    );
    refused(
        &v,
        "staircases[0].stop.trials",
        "10001 is more than a session's 10000",
    );
}

/// Every participant has an order of their own: the same ID gives the same order (a resumed
/// run replays it), another ID another one (`sim:5` and `sim:6` ran the same sequence when the
/// order followed the plan's seed alone), each the same trials block by block, so each stays
/// balanced as the plan's.
#[test]
fn each_participant_has_an_order_of_their_own() {
    let plan = thesis_shapes();
    let of = |id: &str| plan.trials_for(id).expect("mixed blocks: any ID");
    let (a, b) = (of("sim:5"), of("sim:6"));
    assert_eq!(a, of("sim:5"));
    let order = |t: &[TrialSpec]| t.iter().map(cell).collect::<Vec<_>>();
    assert_ne!(order(&a), order(&b));
    assert_ne!(order(&a), order(&plan.trials()));
    // Over 20 participants, no two orders coincide.
    let mut seen: Vec<Vec<(usize, usize, Option<u64>)>> =
        (0..20).map(|i| order(&of(&format!("P{i:02}")))).collect();
    seen.sort();
    seen.dedup();
    assert_eq!(seen.len(), 20);
    // The same cells in every block (and as many practice trials), in another order.
    let cells_of = |t: &[TrialSpec], block: Option<usize>| {
        let mut c: Vec<_> = t.iter().filter(|x| x.block == block).map(cell).collect();
        c.sort();
        c
    };
    for block in [Some(0), Some(1)] {
        assert_eq!(cells_of(&a, block), cells_of(&plan.trials(), block));
        assert_eq!(cells_of(&b, block), cells_of(&plan.trials(), block));
    }
    assert_eq!(
        cells_of(&a, None).len(),
        cells_of(&plan.trials(), None).len()
    );
}

/// A staircase whose bounds reach the reference is refused, naming its bounds and the bound
/// one step away (the shipped JND plan's did: about 15 trials of a run were at the reference,
/// where a 2AFC answer is a coin flip); the shipped plans keep off it.
#[test]
fn a_staircase_stays_off_the_reference() {
    refused(
        &with(
            staircase_base(),
            "/staircases/0/bounds",
            json!([500.0, 1500.0]),
        ),
        "staircases[0].bounds",
        "[500, 1500] reaches the reference 500",
    );
    refused(
        &with(
            staircase_base(),
            "/staircases/0/bounds",
            json!([400.0, 1500.0]),
        ),
        "staircases[0].bounds",
        "e.g. [600, 1500]",
    );
    // From below (start 300): the suggestion ends a step under the reference, 500 / 1.2.
    let below = with(
        with(staircase_base(), "/staircases/0/start", json!(300.0)),
        "/staircases/0/bounds",
        json!([100.0, 500.0]),
    );
    refused(
        &below,
        "staircases[0].bounds",
        "e.g. [100, 416.6666666666667]",
    );
    let plan = Plan::load(experiments().join("stiffness-jnd.json")).expect("the shipped plan");
    let r = plan
        .spec()
        .reference
        .as_ref()
        .map(|r| r.value)
        .expect("a reference");
    for s in &plan.spec().staircases {
        assert!(!(s.bounds[0] <= r && r <= s.bounds[1]), "{}", s.name);
    }
}

// ----- counterbalancing the conditions (`condition_order`) -----

/// The balanced Latin square of 4 conditions is the textbook's (Williams 1949; e.g. Bradley
/// 1958): A B D C / B C A D / C D B A / D A C B.
#[test]
fn the_williams_square_of_four_is_the_textbooks() {
    let rows = experiment::plan::ConditionOrders::williams(4);
    assert_eq!(
        rows.rows(),
        [[0, 1, 3, 2], [1, 2, 0, 3], [2, 3, 1, 0], [3, 0, 2, 1]]
    );
}

/// For 1 to 9 conditions: each row is an order of all of them, each condition comes once in
/// each position over the rows, and each condition is followed by each other equally often
/// (once over the n rows when n is even, twice over the 2n rows when n is odd): the property
/// that balances first-order carry-over, counted here from the rows alone.
#[test]
fn williams_squares_are_latin_and_balance_carry_over() {
    for n in 1..=9usize {
        let orders = experiment::plan::ConditionOrders::williams(n);
        let rows = orders.rows();
        let expected_rows = if n % 2 == 0 { n } else { 2 * n };
        assert_eq!(rows.len(), expected_rows, "n = {n}");
        for row in rows {
            let mut sorted = row.clone();
            sorted.sort();
            assert_eq!(sorted, (0..n).collect::<Vec<_>>(), "n = {n}: {row:?}");
        }
        for position in 0..n {
            let mut counts = vec![0; n];
            for row in rows {
                counts[row[position]] += 1;
            }
            assert!(
                counts.iter().all(|&c| c == rows.len() / n),
                "n = {n}, position {position}: {counts:?}"
            );
        }
        let mut pairs = vec![vec![0; n]; n];
        for row in rows {
            for w in row.windows(2) {
                pairs[w[0]][w[1]] += 1;
            }
        }
        let each = if n % 2 == 0 { 1 } else { 2 };
        for (a, followers) in pairs.iter().enumerate() {
            for (b, &count) in followers.iter().enumerate() {
                let want = if a == b || n == 1 { 0 } else { each };
                assert_eq!(count, want, "n = {n}: {a} then {b}");
            }
        }
    }
}

/// A plan with `"condition_order": "latin-square"` over its two conditions: P01 runs the
/// first row (friction, then frictionless) in every block, P02 the second; each block is the
/// first condition's trials, then the other's, the same trials as a mixed block; the
/// practice stays mixed.
#[test]
fn a_latin_square_plan_runs_each_participants_row_of_conditions() {
    let mut v = base();
    v["condition_order"] = json!("latin-square");
    let plan = read(&v).expect("a counterbalanced plan");
    let mixed = read(&base()).expect("mixed");
    for (id, first) in [("P01", 0), ("P02", 1), ("P03", 0), ("lab-12", 1)] {
        let trials = plan.trials_for(id).expect(id);
        assert_eq!(trials.len(), mixed.trials_for(id).expect(id).len());
        for block in 0..2 {
            let conditions: Vec<usize> = trials
                .iter()
                .filter(|t| t.block == Some(block))
                .map(|t| t.condition)
                .collect();
            // 3 stimuli × 2 repetitions of each condition in a block, one stretch each.
            let expected: Vec<usize> = [first, 1 - first]
                .iter()
                .flat_map(|&c| std::iter::repeat_n(c, 6))
                .collect();
            assert_eq!(conditions, expected, "{id}, block {block}");
        }
    }
    // Written out, the same table as the square's rows.
    let mut t = base();
    t["condition_order"] = json!([["friction", "frictionless"], ["frictionless", "friction"]]);
    let table = read(&t).expect("a table");
    assert_eq!(
        table.trials_for("P02").expect("P02"),
        plan.trials_for("P02").expect("P02")
    );
}

/// Counterbalancing refuses what it cannot do, naming the field.
#[test]
fn condition_orders_that_cannot_run_are_refused_by_name() {
    let with = |order: Value| {
        let mut v = base();
        v["condition_order"] = order;
        v
    };
    let message = |v: &Value| read(v).expect_err("refused").to_string();
    let plan = read(&with(json!("latin-square"))).expect("valid");
    let e = plan.trials_for("alice").expect_err("no number").to_string();
    assert!(
        e.contains("condition_order") && e.contains("\"alice\""),
        "{e}"
    );
    for (order, names) in [
        (json!("latin"), "condition_order"),
        (json!([]), "condition_order"),
        (json!([["friction"]]), "condition_order[0]"),
        (json!([["friction", "sticky"]]), "condition_order[0][1]"),
        (json!([["friction", "friction"]]), "condition_order[0][1]"),
        (
            json!([["friction", "frictionless"], "friction"]),
            "condition_order[1]",
        ),
    ] {
        let e = message(&with(order.clone()));
        assert!(e.contains(names), "{order}: {e}");
    }
    let mut s = staircase_base();
    s["condition_order"] = json!("latin-square");
    let e = message(&s);
    assert!(e.contains("condition_order") && e.contains("online"), "{e}");
    // "mixed" is the default, and reads back as written.
    let mixed = read(&with(json!("mixed"))).expect("mixed");
    assert!(mixed.condition_orders().is_none());
}
