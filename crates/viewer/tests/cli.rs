//! The `viewer` binary end to end: output against closed-form geometry, exit statuses and
//! messages.

use std::io::Write;
use std::path::PathBuf;
use std::process::{Command, Output, Stdio};

fn examples() -> String {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/examples.json");
    path.to_str().expect("UTF-8 path").to_owned()
}

/// Runs the binary with `stdin` as standard input.
fn viewer(args: &[&str], stdin: &str) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_viewer"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("viewer starts");
    if let Some(mut input) = child.stdin.take() {
        // The process may exit before reading (invalid scene): a broken pipe is expected then.
        let _ = input.write_all(stdin.as_bytes());
    }
    child.wait_with_output().expect("viewer runs")
}

fn stdout_lines(out: &Output) -> Vec<serde_json::Value> {
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("each output line is one JSON object"))
        .collect()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn vector(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .expect("an array")
        .iter()
        .map(|x| x.as_f64().expect("a number"))
        .collect()
}

fn number(v: &serde_json::Value) -> f64 {
    v.as_f64().expect("a number")
}

/// A scene file in a fresh temporary directory, removed on drop.
struct TempScene {
    dir: PathBuf,
    path: PathBuf,
}

impl TempScene {
    fn new(name: &str, text: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("viewer-cli-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join(format!("{name}.json"));
        std::fs::write(&path, text).expect("write scene");
        TempScene { dir, path }
    }

    fn path(&self) -> &str {
        self.path.to_str().expect("UTF-8 path")
    }
}

impl Drop for TempScene {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

#[test]
fn circle_points_lie_on_the_circle() {
    // scenes/examples.json, object 1: centre (0, 0.09), radius 0.03, counter-clockwise.
    let (c, r) = ([0.0, 0.09], 0.03);
    let input: String = (0..=64).map(|k| format!("{}\n", k as f64 / 64.0)).collect();
    let out = viewer(
        &["eval", &examples(), "--object", "1", "--patch", "0"],
        &format!("# u\n{input}"),
    );
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(out.status.code(), Some(0));
    assert!(out.stderr.is_empty(), "{}", stderr(&out));
    let lines = stdout_lines(&out);
    assert_eq!(lines.len(), 65);
    for line in &lines {
        let p = vector(&line["p"]);
        let n = vector(&line["normal"]);
        let t = vector(&line["tangent"]);
        let radius = (p[0] - c[0]).hypot(p[1] - c[1]);
        assert!((radius - r).abs() < 1e-6, "|p - c| = {radius} at {line}");
        // Outward normal (p − c)/r, tangent a quarter turn counter-clockwise from it.
        let outward = [(p[0] - c[0]) / r, (p[1] - c[1]) / r];
        assert!(
            (n[0] - outward[0]).abs() < 1e-4 && (n[1] - outward[1]).abs() < 1e-4,
            "{line}"
        );
        assert!(
            (t[0] + outward[1]).abs() < 1e-4 && (t[1] - outward[0]).abs() < 1e-4,
            "{line}"
        );
        let curvature = number(&line["curvature"]);
        assert!(
            (curvature - 1.0 / r).abs() < 1e-3 / r,
            "curvature {curvature} at {line}"
        );
    }
    // Quarter points of the 9-point circle are its control points on the circle.
    let quarter = vector(&lines[16]["p"]);
    assert!(
        quarter[0].abs() < 1e-7 && (quarter[1] - 0.12).abs() < 1e-7,
        "{quarter:?}"
    );
}

/// scenes/examples.json, object 0: the cubic wave (knots 0 0 0 0 ½ 1 1 1 1), against the
/// file's data evaluated in f64 by the Cox–de Boor recursion (testkit's, Piegl & Tiller eq.
/// 2.5), its derivative against finite differences of that reference.
#[test]
fn cubic_matches_cox_de_boor() {
    let knots = [0.0, 0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0, 1.0];
    let points = [
        [-0.04, 0.08],
        [-0.02, 0.12],
        [0.0, 0.07],
        [0.02, 0.12],
        [0.04, 0.08],
    ];
    let reference = |u: f64| {
        let mut p = [0.0; 2];
        for (i, cp) in points.iter().enumerate() {
            let n = testkit::cox_de_boor(&knots, 3, i, u);
            p[0] += n * cp[0];
            p[1] += n * cp[1];
        }
        p
    };
    let us = [0.0, 0.1, 0.3, 0.5, 0.55, 0.9, 1.0];
    let input: String = us.iter().map(|u| format!("{u}\n")).collect();
    let out = viewer(&["eval", &examples(), "--object", "0"], &input);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let lines = stdout_lines(&out);
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
fn surface_matches_the_bezier_closed_form() {
    // scenes/examples.json, object 2: a bicubic Bézier patch with evenly spaced x (along u)
    // and y (along v) and the four inner points raised by h = 0.02. Bernstein sums give
    // x = −0.03 + 0.06 u, y = 0.06 + 0.06 v, z = h (B1 + B2)(u) (B1 + B2)(v)
    // = 9 h u(1−u) v(1−v).
    let h = 0.02;
    let grid = [0.0, 0.1, 0.25, 0.5, 0.8, 1.0];
    let mut input = String::new();
    for u in grid {
        for v in grid {
            input.push_str(&format!("{u} {v}\n"));
        }
    }
    let out = viewer(&["eval", &examples(), "--object", "2"], &input);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let lines = stdout_lines(&out);
    assert_eq!(lines.len(), grid.len() * grid.len());
    for line in &lines {
        let (u, v) = (number(&line["u"]), number(&line["v"]));
        let p = vector(&line["p"]);
        let expected = [
            -0.03 + 0.06 * u,
            0.06 + 0.06 * v,
            9.0 * h * u * (1.0 - u) * v * (1.0 - v),
        ];
        for k in 0..3 {
            assert!(
                (p[k] - expected[k]).abs() < 1e-6,
                "p = {p:?}, expected {expected:?}"
            );
        }
        let du = [0.06, 0.0, 9.0 * h * (1.0 - 2.0 * u) * v * (1.0 - v)];
        let dv = [0.0, 0.06, 9.0 * h * u * (1.0 - u) * (1.0 - 2.0 * v)];
        let duv = 9.0 * h * (1.0 - 2.0 * u) * (1.0 - 2.0 * v);
        for (got, want) in [(vector(&line["du"]), du), (vector(&line["dv"]), dv)] {
            for k in 0..3 {
                assert!(
                    (got[k] - want[k]).abs() < 1e-5,
                    "{got:?} vs {want:?} at {line}"
                );
            }
        }
        assert!((vector(&line["duv"])[2] - duv).abs() < 1e-4, "{line}");
        let n = [
            du[1] * dv[2] - du[2] * dv[1],
            du[2] * dv[0] - du[0] * dv[2],
            du[0] * dv[1] - du[1] * dv[0],
        ];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        let normal = vector(&line["normal"]);
        for k in 0..3 {
            assert!(
                (normal[k] - n[k] / len).abs() < 1e-5,
                "{normal:?} at {line}"
            );
        }
    }
}

#[test]
fn bad_line_exits_1_after_answering_the_lines_before() {
    let out = viewer(
        &["eval", &examples(), "--object", "1"],
        "0\n0.5\n\n0.5 x\n0.7\n",
    );
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(stdout_lines(&out).len(), 2);
    let err = stderr(&out);
    assert!(err.contains("line 4 (\"0.5 x\")"), "{err}");
    assert!(err.contains("expected 1 value(s)"), "{err}");
    assert!(err.contains("object 1 (\"circle\"), patch 0"), "{err}");
}

#[test]
fn out_of_domain_exits_1_and_reports_the_domain() {
    let out = viewer(
        &["eval", &examples(), "--object", "2"],
        "0.5 0.5\n0.5 1.25\n",
    );
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(stdout_lines(&out).len(), 1);
    let err = stderr(&out);
    assert!(
        err.contains("line 2 (\"0.5 1.25\"): v = 1.25 is outside the domain [0, 1]"),
        "{err}"
    );
    // Comment lines count in the numbering; the lines before the bad one are answered.
    let out = viewer(
        &["eval", &examples(), "--object", "2"],
        "0 0\n# c\n1 1\n1 -1\n0 0\n",
    );
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(stdout_lines(&out).len(), 2);
    let err = stderr(&out);
    assert!(
        err.contains("line 4 (\"1 -1\"): v = -1 is outside the domain [0, 1]"),
        "{err}"
    );
    let out = viewer(&["eval", &examples()], "inf\n");
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("line 1 (\"inf\"): u: inf is not a finite number"));
}

#[test]
fn invalid_scene_exits_2_naming_object_patch_and_field() {
    let scene = TempScene::new(
        "bad-knots",
        r#"{ "format": "scene/1", "objects": [ { "name": "lid",
            "material": { "stiffness_n_per_m": 1, "damping_ns_per_m": 0, "mu_static": 0.5, "mu_dynamic": 0.5 },
            "patches": [
              { "degree": 1, "knots": [0, 0, 1, 1], "points": [[0, 0.1], [0.01, 0.1]] },
              { "degree": 2, "knots": [0, 0, 0, 1, 1], "points": [[0, 0.1], [0.01, 0.1], [0.02, 0.1]] }
            ] } ] }"#,
    );
    let out = viewer(&["eval", scene.path()], "0.5\n");
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty());
    let err = stderr(&out);
    assert!(err.contains("bad-knots.json"), "{err}");
    assert!(
        err.contains("object 0 (\"lid\"), patch 1: knots: expected 6 knots"),
        "{err}"
    );

    let scene = TempScene::new("typo", r#"{ "format": "scene/1", "object": [] }"#);
    let out = viewer(&["eval", scene.path()], "");
    assert_eq!(out.status.code(), Some(2));
    let err = stderr(&out);
    assert!(err.contains("unknown field `object`"), "{err}");
    assert!(err.contains("line 1 column"), "{err}");
}

#[test]
fn missing_file_and_bad_indices_exit_2() {
    let out = viewer(&["eval", "no/such/scene.json"], "");
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("no/such/scene.json"));

    let out = viewer(&["eval", &examples(), "--object", "3"], "0\n");
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("--object 3"), "{}", stderr(&out));

    let out = viewer(
        &["eval", &examples(), "--object", "1", "--patch", "1"],
        "0\n",
    );
    assert_eq!(out.status.code(), Some(2));
    let err = stderr(&out);
    assert!(
        err.contains("--patch 1: object 1 (\"circle\") has 1 patch"),
        "{err}"
    );

    let out = viewer(&["eval", &examples(), "--object", "x"], "");
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn help_documents_input_output_and_exit_status() {
    let out = viewer(&["eval", "--help"], "");
    assert_eq!(out.status.code(), Some(0));
    let help = String::from_utf8_lossy(&out.stdout);
    for needle in [
        "--object",
        "--patch",
        "`u v` for a surface",
        "#",
        "u, p, du, duu, tangent, normal, curvature",
        "u, v, p, du, dv, duu, duv, dvv, normal",
        "Exit status",
        "2  bad command line",
    ] {
        assert!(help.contains(needle), "help lacks {needle:?}:\n{help}");
    }
}

/// `viewer` alone is `viewer gui`, which opens a window: only its refusals are tested here
/// (they happen before any window; the window itself is `cargo xtask ci`'s Xvfb test).
#[test]
fn gui_refuses_unknown_devices_and_bad_scenes_before_opening_a_window() {
    for device in ["usb", "serial:", "tcp:127.0.0.1", "tcp:127.0.0.1:http"] {
        let out = viewer(&["gui", "--device", device], "");
        assert_eq!(out.status.code(), Some(2), "{device}");
        let err = stderr(&out);
        assert!(
            err.contains(&format!("{device:?} is not a device")),
            "{err}"
        );
        assert!(err.contains("tcp:HOST:PORT"), "{err}");
    }
    let out = viewer(&["gui", "no-such-scene.json"], "");
    assert_eq!(out.status.code(), Some(2));
    let err = stderr(&out);
    assert!(err.contains("no-such-scene.json"), "{err}");
    let help = viewer(&["--help"], "");
    let text = String::from_utf8_lossy(&help.stdout);
    assert!(
        text.contains("Without a subcommand the desktop app starts"),
        "{text}"
    );
}

/// Scene numbers that f32 evaluation cannot carry: a weight of 1e-20 beside weights of 1 and
/// a coordinate of 3e38 used to load and print `null` derivatives with exit 0; now the scene
/// is refused (exit 2) naming file, object, patch and field, and nothing is printed.
#[test]
fn eval_refuses_scenes_f32_cannot_evaluate() {
    let scene = |weights: &str, x: &str| {
        format!(
            r#"{{ "format": "scene/1", "objects": [ {{ "name": "arc",
            "material": {{ "stiffness_n_per_m": 1, "damping_ns_per_m": 0, "mu_static": 0.5, "mu_dynamic": 0.5 }},
            "patches": [ {{ "degree": 2, "knots": [0, 0, 0, 1, 1, 1],
              "points": [[0, 0.1], [{x}, 0.12], [0.02, 0.1]], "weights": {weights} }} ] }} ] }}"#
        )
    };
    let ok = TempScene::new("arc-ok", &scene("[1, 0.5, 1]", "0.01"));
    let out = viewer(&["eval", ok.path()], "0\n0.5\n1\n");
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert_eq!(stdout_lines(&out).len(), 3);
    for (name, weights, x, says) in [
        (
            "tiny-weight",
            "[1, 1e-20, 1]",
            "0.01",
            "patch 0: weights[1]: weight 1e-20 is less than 1e-6",
        ),
        (
            "huge-point",
            "[1, 1, 1]",
            "3e38",
            "patch 0: points[1]: coordinate magnitude 3e38 exceeds 1e6",
        ),
    ] {
        let bad = TempScene::new(name, &scene(weights, x));
        let out = viewer(&["eval", bad.path()], "0\n0.5\n1\n");
        assert_eq!(out.status.code(), Some(2), "{name}");
        assert!(out.stdout.is_empty(), "{name}");
        let err = stderr(&out);
        assert!(err.contains(&format!("{name}.json")), "{err}");
        assert!(err.contains("object 0 (\"arc\")"), "{err}");
        assert!(err.contains(says), "{err}");
    }
    // A domain of 1e-30 is valid (spans are relative to it) but its second derivatives,
    // 0.01 m / (1e-30)², overflow f32: the answer is refused (exit 1), never printed as null.
    let tiny = TempScene::new(
        "tiny-domain",
        &scene("[1, 1, 1]", "0.01").replace("[0, 0, 0, 1, 1, 1]", "[0, 0, 0, 1e-30, 1e-30, 1e-30]"),
    );
    let out = viewer(&["eval", tiny.path()], "0\n");
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(out.stdout.is_empty());
    assert!(stderr(&out).contains("line 1 (\"0\"): the answer's duu is not a finite f32"));
}

/// `viewer plot` draws a `sim --device` run log; a file that is not a run log is refused
/// with exit 2, naming the file and the line.
#[test]
fn plot_draws_a_run_log_and_refuses_other_files() {
    let dir = TempScene::new("plot", "not a scene");
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let scene = root.join("scenes/thesis-2d.json");
    let trajectory = dir.dir.join("press.csv");
    std::fs::write(&trajectory, "t,x,y\n0,0.0,0.1\n0.4,0.0,0.09\n").expect("write");
    let log = dir.dir.join("run.csv");
    let png = dir.dir.join("run.png");
    let s = |p: &PathBuf| p.to_str().expect("UTF-8 path").to_owned();
    let out = viewer(
        &[
            "sim",
            &s(&scene),
            "--device",
            "--trajectory",
            &s(&trajectory),
            "--out",
            &s(&log),
        ],
        "",
    );
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let out = viewer(&["plot", &s(&log), "--out", &s(&png)], "");
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let bytes = std::fs::read(&png).expect("the plot");
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"), "a PNG");

    let out = viewer(&["plot", dir.path(), "--out", &s(&png)], "");
    assert_eq!(out.status.code(), Some(2));
    let err = stderr(&out);
    assert!(
        err.contains("plot.json: line 1 is not a run log's header"),
        "{err}"
    );
}

/// Every mesh `viewer gui --mesh` refuses is refused the same way, before any window: exit 2
/// and one short message naming the file, the line where one is at fault, and what is wrong.
/// Lines tobj refuses (a vertex with w = 0, a face corner of four indices, a vertex line of
/// a megabyte) and a mesh of 80,000 triangles, more than the loop scans in a tick.
#[test]
fn gui_refuses_every_invalid_mesh_with_exit_2_and_its_reason() {
    let dir = std::env::temp_dir().join(format!("viewer-cli-obj-all-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n";
    let long = format!("v 0 0 0{}", " 1".repeat(500_000));
    // 200 × 200 unit squares, two triangles each.
    let n = 200;
    let mut grid = String::new();
    for j in 0..=n {
        for i in 0..=n {
            grid += &format!("v {i} {j} 0\n");
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i + 1;
            let (b, c, d) = (a + 1, a + n + 1, a + n + 2);
            grid += &format!("f {a} {b} {d}\nf {a} {d} {c}\n");
        }
    }
    let cases = [
        (
            "w0.obj",
            format!("{head}v 1 1 0 0\nf 1 2 3\n"),
            ":6:",
            "w = 0",
        ),
        (
            "corner.obj",
            format!("{head}f 1/1/1/1 2 3\n"),
            ":6:",
            "face corner \"1/1/1/1\"",
        ),
        (
            "long.obj",
            format!("{head}{long}\nf 1 2 3\n"),
            ":6:",
            "a vertex (v) takes 3 numbers",
        ),
        ("big.obj", grid, ":", "80000 triangles"),
    ];
    for (name, text, line, reason) in cases {
        let path = dir.join(name);
        std::fs::write(&path, text).expect("write");
        let path_text = path.to_str().expect("UTF-8 path");
        let out = viewer(&["gui", "--mesh", path_text], "");
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{name}: {err}");
        assert!(
            err.starts_with(&format!("error: invalid mesh: {path_text}{line}")),
            "{name}: {err}"
        );
        assert!(err.contains(reason), "{name}: {err}");
        assert!(err.len() < 400, "{name}: a short message: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `viewer gui --mesh FILE.obj` refuses an invalid mesh before opening a window, naming the
/// file and the line (exit 2); a mesh and a scene together are refused by the command line.
#[test]
fn gui_refuses_an_invalid_mesh_before_opening_a_window() {
    let dir = std::env::temp_dir().join(format!("viewer-cli-obj-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("bad.obj");
    std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nv 0 0 zero\n").expect("write");
    let path_text = path.to_str().expect("UTF-8 path");
    let out = viewer(&["gui", "--mesh", path_text], "");
    assert_eq!(out.status.code(), Some(2));
    let err = stderr(&out);
    assert!(
        err.contains(&format!(
            "{path_text}:5: a vertex (v): \"zero\" is not a number"
        )),
        "{err}"
    );
    let out = viewer(&["gui", "s.json", "--mesh", path_text], "");
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("cannot be used with"),
        "{}",
        stderr(&out)
    );
    let _ = std::fs::remove_dir_all(&dir);
}
