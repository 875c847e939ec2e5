//! `viewer closest` as a user runs it: output against the closed form, exit statuses.
#![allow(clippy::unwrap_used)]

use std::io::Write;
use std::process::{Command, Stdio};

fn closest(args: &[&str], input: &str) -> (i32, String, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_viewer"))
        .arg("closest")
        .args(args)
        .current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(input.as_bytes())
        .unwrap();
    let out = child.wait_with_output().unwrap();
    (
        out.status.code().unwrap(),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

/// Object 1 of the examples is the circle of radius 30 mm around (0, 0.09): the closest point
/// to q is c + r (q − c)/|q − c|, signed distance |q − c| − r.
#[test]
fn circle_closest_points_match_the_closed_form() {
    let (code, out, err) = closest(
        &["scenes/examples.json", "--object", "1"],
        "0.05 0.1\n0 0.1\n",
    );
    assert_eq!(code, 0, "{err}");
    let lines: Vec<serde_json::Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 2);
    for (line, (qx, qy)) in lines.iter().zip([(0.05f64, 0.1f64), (0.0, 0.1)]) {
        let (dx, dy) = (qx, qy - 0.09);
        let d = (dx * dx + dy * dy).sqrt();
        let (px, py) = (0.03 * dx / d, 0.09 + 0.03 * dy / d);
        assert!((line["point"][0].as_f64().unwrap() - px).abs() < 1e-6);
        assert!((line["point"][1].as_f64().unwrap() - py).abs() < 1e-6);
        assert!((line["signed_distance"].as_f64().unwrap() - (d - 0.03)).abs() < 1e-6);
    }
}

#[test]
fn exit_statuses() {
    let (code, out, err) = closest(
        &["scenes/examples.json", "--object", "1"],
        "0.05 0.1\n0.05\n",
    );
    assert_eq!(code, 1);
    assert_eq!(out.lines().count(), 1, "the good line was answered");
    assert!(err.contains("line 2"), "{err}");
    let (code, _, err) = closest(&["scenes/examples.json", "--object", "9"], "");
    assert_eq!(code, 2);
    assert!(err.contains("--object 9"), "{err}");
    let (code, _, err) = closest(&["no-such-scene.json"], "");
    assert_eq!(code, 2);
    assert!(err.contains("no-such-scene.json"), "{err}");
}
