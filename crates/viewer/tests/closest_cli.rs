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

/// A query of `1e30 1e30` used to print `"distance": null` with exit 0; now it is a bad line
/// (exit 1) naming the line and the field, after the lines before it were answered.
#[test]
fn queries_f32_cannot_carry_exit_1_without_null() {
    let (code, out, err) = closest(
        &["scenes/examples.json", "--object", "1"],
        "0.05 0.1\n1e30 1e30\n",
    );
    assert_eq!(code, 1, "{err}");
    assert_eq!(out.lines().count(), 1);
    assert!(!out.contains("null"), "{out}");
    assert!(err.contains("line 2 (\"1e30 1e30\"): x = "), "{err}");
    assert!(
        err.contains("outside the domain [-1000000, 1000000]"),
        "{err}"
    );
}

/// A wire (spatial curves) is answered: the straight segment from (0, 0, 0) to (0.1, 0, 0)
/// in 3-D, whose closest point is the clamped projection (exact construction).
#[test]
fn wires_are_answered() {
    let dir = std::env::temp_dir().join(format!("viewer-closest-wire-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("wire.json");
    std::fs::write(
        &scene,
        r#"{ "format": "scene/1", "objects": [ { "name": "wire",
            "material": { "stiffness_n_per_m": 1, "damping_ns_per_m": 0, "mu_static": 0.5, "mu_dynamic": 0.5 },
            "patches": [ { "degree": 1, "knots": [0, 0, 1, 1], "points": [[0, 0, 0], [0.1, 0, 0]] } ] } ] }"#,
    )
    .unwrap();
    let (code, out, err) = closest(&[scene.to_str().unwrap()], "0.03 0.04 0\n0.2 0 0.1\n");
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(code, 0, "{err}");
    let lines: Vec<serde_json::Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    // (0.03, 0.04, 0): foot (0.03, 0, 0) at u = 0.3, distance 0.04, direction +y.
    // (0.2, 0, 0.1): clamped to the end (0.1, 0, 0), distance √(0.01 + 0.01).
    let expected = [
        ([0.03, 0.0, 0.0], 0.3, 0.04),
        ([0.1, 0.0, 0.0], 1.0, 0.02f64.sqrt()),
    ];
    for (line, (p, u, d)) in lines.iter().zip(expected) {
        for k in 0..3 {
            assert!(
                (line["point"][k].as_f64().unwrap() - p[k]).abs() < 1e-7,
                "{line}"
            );
        }
        // f32 rounding of values of order 0.1: 1e-7.
        assert!((line["u"].as_f64().unwrap() - u).abs() < 1e-6, "{line}");
        assert!(
            (line["distance"].as_f64().unwrap() - d).abs() < 1e-7,
            "{line}"
        );
        assert_eq!(line["signed_distance"], line["distance"]);
    }
    assert!((lines[0]["normal"][1].as_f64().unwrap() - 1.0).abs() < 1e-6);
}
