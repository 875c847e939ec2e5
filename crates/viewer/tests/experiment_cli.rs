//! `viewer experiment run` as a user runs it: the summary line, the files, the refusals.
#![allow(clippy::unwrap_used)]

use std::process::Command;

fn experiment_run(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_viewer"))
        .args(["experiment", "run"])
        .args(args)
        .current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
        .output()
        .unwrap();
    (
        out.status.code().unwrap(),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

#[test]
fn a_simulated_participant_runs_the_stiffness_plan() {
    let dir = std::env::temp_dir().join(format!("viewer-experiment-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let args = [
        "experiments/stiffness-jnd.json",
        "--participant",
        "sim:1:weber=0.2",
        "--out",
        dir.to_str().unwrap(),
    ];
    let (code, out, err) = experiment_run(&args);
    assert_eq!(code, 0, "{err}");
    assert_eq!(out.lines().count(), 1, "{out}");
    assert!(out.starts_with("experiment run: "), "{out}");
    assert!(out.contains("\"from above\": threshold"), "{out}");
    assert!(out.contains("\"from below\": threshold"), "{out}");
    let trials: usize = out["experiment run: ".len()..]
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    let csv = std::fs::read_to_string(dir.join("trials.csv")).unwrap();
    assert_eq!(csv.lines().count(), trials + 1);
    assert!(dir.join("plan.json").is_file());
    assert!(
        dir.join(format!("traces/trial-{trials:04}-b.csv"))
            .is_file()
    );
    // Run again into the finished folder: it says the run was complete (it said "0 trials
    // (0 practice), 0 of 0 correct"), with the same staircases, and writes nothing.
    let (code, again, err) = experiment_run(&args);
    assert_eq!(code, 0, "{err}");
    assert!(
        again.starts_with(&format!(
            "experiment run: the run was complete already ({trials} trials answered): nothing to run; "
        )),
        "{again}"
    );
    let staircases = |line: &str| line.split_once("; ").map(|(_, s)| s.to_owned());
    assert_eq!(staircases(&again), staircases(&out), "{again}");
    assert_eq!(
        std::fs::read_to_string(dir.join("trials.csv")).unwrap(),
        csv
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A real participant runs in the app's window (not opened here); what is wrong with the run
/// is refused before the window opens.
#[test]
fn a_real_participant_on_another_participants_folder_is_refused_with_status_2() {
    let dir = std::env::temp_dir().join(format!("viewer-experiment-p01-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = dir.to_str().unwrap();
    let (code, _, err) = experiment_run(&[
        "experiments/stiffness-jnd.json",
        "--participant",
        "sim:1:weber=0.2",
        "--out",
        out,
    ]);
    assert_eq!(code, 0, "{err}");
    let before = std::fs::read_to_string(dir.join("trials.csv")).unwrap();
    let (code, _, err) = experiment_run(&[
        "experiments/stiffness-jnd.json",
        "--participant",
        "P01",
        "--out",
        out,
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("cannot resume") && err.contains("\"P01\"'s"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(dir.join("trials.csv")).unwrap(),
        before
    );
    let (code, _, err) = experiment_run(&[
        "experiments/stiffness-jnd.json",
        "--participant",
        " ",
        "--out",
        out,
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--participant"), "{err}");
    let (code, _, err) = experiment_run(&[
        "experiments/stiffness-jnd.json",
        "--participant",
        "P01",
        "--out",
        out,
        "--device",
        "usb",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("\"usb\" is not a device"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}
