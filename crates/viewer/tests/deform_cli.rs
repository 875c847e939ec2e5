//! `viewer deform` and `viewer sim --deform` end to end: the files they write, checked against
//! the taut string's closed forms, and their refusals.

use std::path::PathBuf;
use std::process::{Command, Output};

fn scenes(name: &str) -> String {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name);
    path.to_str().expect("UTF-8 path").to_owned()
}

fn viewer(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_viewer"))
        .args(args)
        .output()
        .expect("viewer runs")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("viewer-deform-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("temp dir");
        TempDir(dir)
    }

    fn path(&self, name: &str) -> String {
        self.0.join(name).to_str().expect("UTF-8 path").to_owned()
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The bundled string: 80 mm at y = 0.09 under 5 N, 0.1 kg/m.
const L: f64 = 0.08;
const T: f64 = 5.0;
const RHO: f64 = 0.1;

/// `--static` under 2 N/m writes a valid scene whose string sags in the parabola
/// `q x (L − x)/2T`: at u = ½ (the control points at the Greville abscissae make x linear in
/// u) by `q L²/8T` = 0.32 mm. The file holds f32 coordinates (ulp 7e-9 m at 0.09 m) and the
/// solve is exact in the spline space: 1e-7 m.
#[test]
fn static_sag_is_the_parabola() {
    let dir = TempDir::new("static");
    let out = dir.path("sag.json");
    let run = viewer(&[
        "deform",
        &scenes("deformable.json"),
        "--load",
        "uniform:0,-2",
        "--static",
        "--out",
        &out,
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    let scene = scene::Scene::load(&out).expect("a valid scene");
    let object = &scene.objects()[0];
    assert!(object.dynamics().is_some(), "the dynamics block is kept");
    let curves = object.curve_views().expect("planar");
    let mid = curves[0].point(0.5);
    let sag = 2.0 * L * L / (8.0 * T);
    assert!(
        (f64::from(mid.y) - (0.09 - sag)).abs() < 1e-7,
        "middle at {} vs {}",
        mid.y,
        0.09 - sag
    );
}

/// `--release` rings at the string's first mode, `(1/2L)√(T/ρ)` = 44.19 Hz undamped (printed),
/// slowed by the scene's mass-proportional damping γ = 10 N·s/m² (decay rate `γ/2ρ` = 50 s⁻¹
/// in every mode) to `√(ω₁² − (γ/2ρ)²)/2π` = 43.47 Hz: the probe's upward zero crossings
/// about the rest line (the file's f32 0.09), over the first five periods while the amplitude
/// is far above the f32 rest line's rounding. Newmark's elongation at 20 kHz is 2e-5; the
/// third mode (1/27 of the first at the middle, damped to a frequency that is not 3 × the
/// first's) moves single crossings by up to 1e-3 of a period: 1e-3.
#[test]
fn release_trace_rings_at_the_first_mode() {
    let dir = TempDir::new("release");
    let trace = dir.path("ring.csv");
    let run = viewer(&[
        "deform",
        &scenes("deformable.json"),
        "--load",
        "uniform:0,-2",
        "--release",
        "--duration",
        "0.2",
        "--dt",
        "5e-5",
        "--probe",
        "0.5",
        "--trace",
        &trace,
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(
        stderr(&run).contains("lowest natural frequency 44.19"),
        "{}",
        stderr(&run)
    );
    let text = std::fs::read_to_string(&trace).expect("trace");
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("t_s,x,y"));
    let rows: Vec<(f64, f64)> = lines
        .map(|l| {
            let c: Vec<f64> = l.split(',').map(|x| x.parse().expect("number")).collect();
            (c[0], c[2] - f64::from(0.09f32))
        })
        .collect();
    assert_eq!(rows.len(), 4001);
    let crossings: Vec<f64> = rows
        .windows(2)
        .filter(|w| w[0].1 < 0.0 && w[1].1 >= 0.0)
        .map(|w| w[0].0 + (w[1].0 - w[0].0) * (-w[0].1) / (w[1].1 - w[0].1))
        .collect();
    assert!(crossings.len() >= 6, "{crossings:?}");
    let f = 5.0 / (crossings[5] - crossings[0]);
    let omega = std::f64::consts::PI / L * (T / RHO).sqrt();
    let decay = 10.0 / (2.0 * RHO);
    let exact = (omega * omega - decay * decay).sqrt() / (2.0 * std::f64::consts::PI);
    assert!((f / exact - 1.0).abs() < 1e-3, "{f} Hz vs {exact} Hz");
}

/// `sim --deform` writes the run log with the displacement columns, the string moving with
/// the finger: at the hold, `deform_y` is the share of the 4 mm press the string takes in
/// series with the contact (k_c / (k_c + k_o) ≈ 0.79).
#[test]
fn sim_deform_logs_the_displacement_at_the_cp() {
    let dir = TempDir::new("sim");
    let out = dir.path("run.csv");
    let run = viewer(&[
        "sim",
        &scenes("deformable.json"),
        "--deform",
        "--trajectory",
        &scenes("deformable.csv"),
        "--out",
        &out,
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    let log = host::runlog::read(std::path::Path::new(&out)).expect("a run log");
    let held = log
        .run
        .ticks
        .iter()
        .rfind(|k| k.t_s <= 1.0)
        .expect("the hold");
    let w = f64::from(held.deform.expect("deform columns")[1]);
    let share = w / 0.004;
    assert!(
        (0.78..0.80).contains(&share),
        "the string took {share} of the press"
    );
}

/// Refusals name what is wrong and exit 2; nothing is written.
#[test]
fn bad_input_is_refused_naming_it() {
    let dir = TempDir::new("bad");
    let out = dir.path("x.json");
    for (args, says) in [
        (
            vec!["--load", "uniform:0,-2,1", "--static", "--out", &out],
            "uniform:FX,FY",
        ),
        (
            vec!["--load", "point:2,0,-1", "--static", "--out", &out],
            "outside the patch's domain",
        ),
        (
            vec!["--load", "push:1", "--static", "--out", &out],
            "not uniform or point",
        ),
        (
            vec!["--load", "uniform:0,nan", "--static", "--out", &out],
            "not a finite number",
        ),
        (
            vec![
                "--object",
                "5",
                "--load",
                "uniform:0,1",
                "--static",
                "--out",
                &out,
            ],
            "--object 5",
        ),
        (
            vec![
                "--load",
                "uniform:0,1",
                "--release",
                "--duration",
                "1",
                "--dt",
                "0",
                "--probe",
                "0.5",
                "--trace",
                &out,
            ],
            "--dt 0",
        ),
        (
            vec![
                "--load",
                "uniform:0,1",
                "--release",
                "--duration",
                "1",
                "--dt",
                "1e-3",
                "--probe",
                "0.5,0.5",
                "--trace",
                &out,
            ],
            "--probe",
        ),
    ] {
        let scene = scenes("deformable.json");
        let mut all = vec!["deform", &scene[..]];
        all.extend(args.iter().copied());
        let run = viewer(&all);
        assert_eq!(run.status.code(), Some(2), "{all:?}: {}", stderr(&run));
        assert!(stderr(&run).contains(says), "{all:?}: {}", stderr(&run));
        assert!(!std::path::Path::new(&out).exists());
    }
    let rigid = viewer(&[
        "deform",
        &scenes("thesis-2d.json"),
        "--load",
        "uniform:0,1",
        "--static",
        "--out",
        &out,
    ]);
    assert_eq!(rigid.status.code(), Some(2));
    assert!(stderr(&rigid).contains("is rigid"), "{}", stderr(&rigid));
    let surface = viewer(&[
        "sim",
        &scenes("deformable.json"),
        "--object",
        "1",
        "--deform",
        "--device",
        "--trajectory",
        &scenes("deformable.csv"),
        "--out",
        &out,
    ]);
    assert_eq!(surface.status.code(), Some(2));
    assert!(stderr(&surface).contains("2-DoF"), "{}", stderr(&surface));
}
