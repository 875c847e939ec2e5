//! `viewer experiment analyze` as a user runs it: a synthesized identification run of the
//! thesis-shapes plan analysed (summary paragraph, summary.json, the figure), and refusals.
#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};
use std::process::Command;

use experiment::plan::Plan;
use experiment::rng::Prng;

const HEADER: &str = "participant,session,block,trial,practice,design,stimulus,condition,\
staircase,level,reference,comparison_interval,response,correct,response_time_s,trace,t_start_s";

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn analyze(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_viewer"))
        .args(["experiment", "analyze"])
        .args(args)
        .current_dir(repo())
        .output()
        .unwrap();
    (
        out.status.code().unwrap(),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

/// A run folder of the thesis-shapes plan answered by a made-up participant: right with
/// probability 0.8 with friction and 0.55 without, otherwise a neighbouring shape.
pub fn synthesize_thesis_shapes(dir: &Path) {
    let plan = Plan::load(repo().join("experiments/thesis-shapes.json")).unwrap();
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(
        dir.join("plan.json"),
        plan.to_json_string_resolved().unwrap(),
    )
    .unwrap();
    let spec = plan.spec();
    let n = spec.stimuli.len();
    let mut rng = Prng::new(31);
    let mut csv = format!("{HEADER}\n");
    for t in plan.trials() {
        let p_right = if t.condition == 0 { 0.8 } else { 0.55 };
        let answered = if rng.bernoulli(p_right) {
            t.stimulus
        } else if t.stimulus == 0 || (t.stimulus + 1 < n && rng.bernoulli(0.5)) {
            t.stimulus + 1
        } else {
            t.stimulus - 1
        };
        csv.push_str(&format!(
            "P01,1,{},{},{},identification,{},{},,,,,{},{},4.2,,{}\n",
            t.block.map_or(0, |b| b + 1),
            t.index + 1,
            u8::from(t.practice),
            spec.stimuli[t.stimulus].name,
            spec.conditions[t.condition].name,
            spec.stimuli[answered].name,
            u8::from(answered == t.stimulus),
            t.index * 30,
        ));
    }
    std::fs::write(dir.join("trials.csv"), csv).unwrap();
}

#[test]
fn an_identification_run_is_analysed_into_a_summary_and_a_figure() {
    let dir = std::env::temp_dir().join(format!("viewer-analyze-id-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    synthesize_thesis_shapes(&dir);
    let (code, out, err) = analyze(&[dir.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(out.lines().count(), 1, "{out}");
    assert!(
        out.starts_with("experiment analyze: thesis shapes"),
        "{out}"
    );
    assert!(
        out.contains("\"friction\": ") && out.contains("Fisher"),
        "{out}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(json["trials"], 40);
    assert_eq!(json["practice_trials"], 5);
    let png = std::fs::read(dir.join("summary.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    // An explicit --figure goes where it is told.
    let figure = dir.join("elsewhere.png");
    let (code, _, err) = analyze(&[dir.to_str().unwrap(), "--figure", figure.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(figure.is_file());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_runs_and_options_are_refused_with_status_2() {
    let dir = std::env::temp_dir().join(format!("viewer-analyze-bad-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    synthesize_thesis_shapes(&dir);
    let csv = std::fs::read_to_string(dir.join("trials.csv")).unwrap();
    let bad = csv.replacen("identification,convex-strong", "identification,wavy", 1);
    std::fs::write(dir.join("trials.csv"), bad).unwrap();
    let (code, _, err) = analyze(&[dir.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("trials.csv:") && err.contains("(stimulus): \"wavy\""),
        "{err}"
    );
    assert!(!dir.join("summary.json").exists());
    let (code, _, err) = analyze(&[dir.to_str().unwrap(), "--model", "logistic"]);
    assert_eq!(code, 2, "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}
