//! The bundled example scene through the `viewer` library: loader and `eval`, against
//! references that do not use the code under test (an f64 Cox–de Boor recursion, the exact
//! circle, finite differences).

use std::path::PathBuf;

use nurbs::Point;
use scene::{Patch, Scene};
use viewer::eval;

fn examples() -> Scene {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scenes/examples.json");
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// Runs `eval` on `patch` and parses every output line.
fn eval_lines(patch: &Patch, input: &str) -> Vec<serde_json::Value> {
    let mut out = Vec::new();
    eval::run(patch, input.as_bytes(), &mut out).unwrap_or_else(|e| panic!("{e}"));
    String::from_utf8(out)
        .expect("UTF-8")
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON line"))
        .collect()
}

fn vector(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

/// B-spline basis function `N_{i,p}(u)` by the Cox–de Boor recursion (Piegl & Tiller eq. 2.5),
/// with the last span closed on the right so that `u = b` is inside the domain.
fn cox_de_boor(knots: &[f64], i: usize, p: usize, u: f64) -> f64 {
    if p == 0 {
        let last = knots[knots.len() - 1];
        let inside = knots[i] <= u && u < knots[i + 1];
        let at_end = u == last && knots[i] < u && knots[i + 1] == last;
        return if inside || at_end { 1.0 } else { 0.0 };
    }
    let mut n = 0.0;
    let left = knots[i + p] - knots[i];
    if left > 0.0 {
        n += (u - knots[i]) / left * cox_de_boor(knots, i, p - 1, u);
    }
    let right = knots[i + p + 1] - knots[i + 1];
    if right > 0.0 {
        n += (knots[i + p + 1] - u) / right * cox_de_boor(knots, i + 1, p - 1, u);
    }
    n
}

#[test]
fn example_scene_contents() {
    let scene = examples();
    let names: Vec<(&str, &str)> = scene
        .objects()
        .iter()
        .map(|o| (o.name(), o.patches()[0].kind()))
        .collect();
    assert_eq!(
        names,
        [
            ("cubic wave", "planar curve"),
            ("circle", "planar curve"),
            ("bump", "surface"),
        ]
    );
    for object in scene.objects() {
        let m = object.material();
        assert!(m.mu_static() >= m.mu_dynamic());
    }
}

#[test]
fn planar_examples_lie_in_the_device_workspace() {
    // Convex hull property: the control polygon's box contains the curve.
    for object in examples().objects() {
        for patch in object.patches() {
            if let Patch::Curve2(c) = patch {
                let b = c.view().bounding_box();
                assert!(
                    b.min.x >= -0.05 && b.max.x <= 0.05 && b.min.y >= 0.05 && b.max.y <= 0.13,
                    "{} leaves the workspace: {b:?}",
                    object.name()
                );
            }
        }
    }
}

#[test]
fn cubic_matches_cox_de_boor() {
    let scene = examples();
    let patch = &scene.objects()[0].patches()[0];
    let Patch::Curve2(curve) = patch else {
        panic!("planar curve")
    };
    // The file's data, in f64.
    let knots = [0.0, 0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0, 1.0];
    let points = [
        [-0.04, 0.08],
        [-0.02, 0.12],
        [0.0, 0.07],
        [0.02, 0.12],
        [0.04, 0.08],
    ];
    assert_eq!(curve.knots().len(), knots.len());
    let reference = |u: f64| {
        let mut p = [0.0; 2];
        for (i, cp) in points.iter().enumerate() {
            let n = cox_de_boor(&knots, i, 3, u);
            p[0] += n * cp[0];
            p[1] += n * cp[1];
        }
        p
    };
    let us = [0.0, 0.1, 0.3, 0.5, 0.55, 0.9, 1.0];
    let input: String = us.iter().map(|u| format!("{u}\n")).collect();
    let lines = eval_lines(patch, &input);
    assert_eq!(lines.len(), us.len());
    for (line, &u) in lines.iter().zip(&us) {
        let p = vector(&line["p"]);
        let want = reference(u);
        assert!(
            (p[0] - want[0]).abs() < 1e-6 && (p[1] - want[1]).abs() < 1e-6,
            "u = {u}: {p:?} vs {want:?}"
        );
        // One-sided differences at the ends, central inside.
        let h = 1e-5;
        let (a, b) = ((u - h).max(0.0), (u + h).min(1.0));
        let (pa, pb) = (reference(a), reference(b));
        let du = vector(&line["du"]);
        for k in 0..2 {
            let fd = (pb[k] - pa[k]) / (b - a);
            assert!(
                (du[k] - fd).abs() < 1e-3 * (1.0 + fd.abs()),
                "u = {u}: du {du:?}"
            );
        }
    }
}

#[test]
fn circle_radius_normal_and_curvature() {
    let scene = examples();
    let patch = &scene.objects()[1].patches()[0];
    let (c, r) = ([0.0, 0.09], 0.03);
    let input: String = (0..=40).map(|k| format!("{}\n", k as f64 / 40.0)).collect();
    for line in eval_lines(patch, &input) {
        let p = vector(&line["p"]);
        let n = vector(&line["normal"]);
        assert!(
            ((p[0] - c[0]).hypot(p[1] - c[1]) - r).abs() < 1e-6,
            "{line}"
        );
        assert!((n[0] - (p[0] - c[0]) / r).abs() < 1e-4, "{line}");
        assert!((n[1] - (p[1] - c[1]) / r).abs() < 1e-4, "{line}");
        let k = line["curvature"].as_f64().expect("number");
        assert!((k * r - 1.0).abs() < 1e-3, "{line}");
    }
}

#[test]
fn circle_equals_the_exact_construction() {
    // The file's circle and nurbs' constructor describe the same curve.
    let scene = examples();
    let Patch::Curve2(file) = &scene.objects()[1].patches()[0] else {
        panic!("planar curve")
    };
    let exact = nurbs::construct::circle(nurbs::Vec2::new(0.0, 0.09), 0.03).expect("valid");
    for k in 0..=32 {
        let u = k as f32 / 32.0;
        let (a, b) = (file.view().point(u), exact.view().point(u));
        assert!((a - b).length() < 1e-7, "u = {u}: {a} vs {b}");
        assert_eq!(a.as_slice().len(), 2);
    }
}

#[test]
fn bump_matches_bernstein_closed_form() {
    let scene = examples();
    let patch = &scene.objects()[2].patches()[0];
    let lines = eval_lines(patch, "0.5 0.5\n0.2 0.7\n");
    // z = 9 h u(1−u) v(1−v) with h = 0.02 (see crates/viewer/tests/cli.rs).
    for line in lines {
        let (u, v) = (
            line["u"].as_f64().expect("u"),
            line["v"].as_f64().expect("v"),
        );
        let p = vector(&line["p"]);
        let z = 9.0 * 0.02 * u * (1.0 - u) * v * (1.0 - v);
        assert!((p[2] - z).abs() < 1e-6, "{line}");
        assert!((p[0] - (-0.03 + 0.06 * u)).abs() < 1e-6, "{line}");
    }
}

#[test]
fn eval_stops_at_the_first_bad_line() {
    let scene = examples();
    let patch = &scene.objects()[2].patches()[0];
    let mut out = Vec::new();
    let e = eval::run(patch, "0 0\n# c\n1 1\n1 -1\n0 0\n".as_bytes(), &mut out)
        .expect_err("v = -1 is outside");
    assert_eq!(
        e.to_string(),
        "line 4 (\"1 -1\"): v = -1 is outside the domain [0, 1]"
    );
    assert_eq!(String::from_utf8_lossy(&out).lines().count(), 2);
}
