//! `viewer sim --device`: the thesis-2d scenario closed through the simulated pantograph and
//! the device's controller, as a library call and as a command.

use std::path::PathBuf;
use std::process::{Command, Output};

use device::kinematics::Pantograph;
use device::spec::DeviceSpec;
use friction::Mode;
use host::runlog::{DEVICE_COLUMNS, csv_header};
use host::sim::{self, SimParams, Trajectory};
use nurbs::Vec2;
use scene::{Scene, Space};

fn scenes(name: &str) -> String {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name);
    path.to_str().expect("UTF-8 path").to_owned()
}

/// `J = ∂x/∂θ` by central differences of the forward kinematics: an independent check of the
/// controller's analytic Jacobian.
fn jacobian_fd(arm: &Pantograph, theta: [f32; 2]) -> [[f64; 2]; 2] {
    let h = 1e-3f32;
    let mut j = [[0.0; 2]; 2];
    for c in 0..2 {
        let (mut plus, mut minus) = (theta, theta);
        plus[c] += h;
        minus[c] -= h;
        let p = arm.forward(plus).expect("reachable");
        let m = arm.forward(minus).expect("reachable");
        j[0][c] = (f64::from(p.x) - f64::from(m.x)) / (2.0 * f64::from(h));
        j[1][c] = (f64::from(p.y) - f64::from(m.y)) / (2.0 * f64::from(h));
    }
    j
}

#[test]
fn thesis_2d_closed_loop() {
    let scene = Scene::load(scenes("thesis-2d.json")).expect("scene");
    let trajectory = Trajectory::load(scenes("thesis-2d.csv")).expect("trajectory");
    let result = sim::run_device(
        &scene,
        0,
        &trajectory,
        1000.0,
        SimParams::default(),
        |_, _| {},
    )
    .expect("closed loop runs");
    // K = 1000 N/m, b = 0 at 1 kHz: beyond the device's passive stiffness.
    assert!(result.passivity_control);
    let run = &result.run;
    assert!(run.is_device_run());
    assert_eq!(run.ticks.len(), 2521);

    let mut modes: Vec<Mode> = Vec::new();
    for k in &run.ticks {
        if modes.last() != Some(&k.mode) {
            modes.push(k.mode);
        }
    }
    let stick_slip = modes
        .windows(3)
        .filter(|w| w == &[Mode::Stuck, Mode::Transition, Mode::Slip])
        .count();
    assert!(stick_slip >= 2, "modes {modes:?}");

    let arm = DeviceSpec::default().pantograph().expect("valid spec");
    let mut max_force: f32 = 0.0;
    for k in &run.ticks {
        let d = k.device.expect("device sample");
        assert_eq!(d.faults, 0, "t = {}: faults {}", k.t_s, d.faults);
        // The logged angles are the measured pose of the logged (true) HIP, to within the
        // encoder quantum (2π / 40960 rad on links of 0.1 m: ~15 µm).
        let measured = arm.forward(d.theta_rad).expect("assembled");
        let hip = Vec2::new(k.hip.x, k.hip.y);
        assert!(
            (measured - hip).length() < 1e-4,
            "t = {}: {measured} vs {hip}",
            k.t_s
        );
        // τ = Jᵀ F at the logged angles. The central difference of f32 positions near 0.1 m
        // (7.5 nm apart) over 2 mrad carries 3.75e-6 m/rad per entry: two entries times |F|.
        let j = jacobian_fd(&arm, d.theta_rad);
        let f = [f64::from(k.force.x), f64::from(k.force.y)];
        let rounding = 2.0 * 3.75e-6 * f64::from(k.force.length());
        for c in 0..2 {
            let expected = j[0][c] * f[0] + j[1][c] * f[1];
            let got = f64::from(d.tau_nm[c]);
            assert!(
                (got - expected).abs() < 1e-5 + rounding + 1e-4 * expected.abs(),
                "t = {}: tau{} = {got}, Jᵀ F = {expected}",
                k.t_s,
                c + 1
            );
        }
        max_force = max_force.max(k.force.length());
    }
    assert!(max_force > 0.5, "max force {max_force}");

    let mut out = Vec::new();
    run.write_csv(&mut out).expect("write to memory");
    let text = String::from_utf8(out).expect("UTF-8");
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines[0],
        format!("{},{DEVICE_COLUMNS}", csv_header(Space::Planar))
    );
    assert!(
        lines[0].ends_with(",force_x,force_y,theta1_rad,theta2_rad,tau1_nm,tau2_nm,faults"),
        "{}",
        lines[0]
    );
    assert_eq!(lines.len(), 1 + run.ticks.len());
    assert!(lines[1..].iter().all(|l| l.split(',').count() == 22));
    assert!(lines[1..].iter().all(|l| l.ends_with(",0")));
}

#[test]
fn surfaces_are_refused() {
    let scene = Scene::load(scenes("thesis-3d.json")).expect("scene");
    let trajectory = Trajectory::load(scenes("thesis-3d.csv")).expect("trajectory");
    let e = sim::run_device(
        &scene,
        0,
        &trajectory,
        1000.0,
        SimParams::default(),
        |_, _| {},
    )
    .expect_err("a surface");
    assert!(matches!(e, sim::SimError::Surface { index: 0, .. }), "{e}");
    assert!(e.to_string().contains("2-DoF"), "{e}");
}

fn viewer(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_viewer"))
        .args(args)
        .output()
        .expect("viewer runs")
}

#[test]
fn device_command() {
    let dir = std::env::temp_dir().join(format!("viewer-sim-device-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let out = dir.join("run.csv");
    let png = dir.join("run.png");
    let (out_s, png_s) = (
        out.to_str().expect("UTF-8").to_owned(),
        png.to_str().expect("UTF-8").to_owned(),
    );
    let result = viewer(&[
        "sim",
        &scenes("thesis-2d.json"),
        "--device",
        "--trajectory",
        &scenes("thesis-2d.csv"),
        "--out",
        &out_s,
        "--plot",
        &png_s,
    ]);
    let stderr = String::from_utf8_lossy(&result.stderr).into_owned();
    assert_eq!(result.status.code(), Some(0), "{stderr}");
    assert!(stderr.contains("passivity controller is on"), "{stderr}");
    assert!(stderr.contains("sim: 100% (2521/2521 ticks)"), "{stderr}");
    let text = std::fs::read_to_string(&out).expect("run log");
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some(
            "t_s,hip_x,hip_y,cp_x,cp_y,go_x,go_y,patch,mode,cause,depth_m,normal_force_n,\
             friction_force_n,mu,psi,force_x,force_y,theta1_rad,theta2_rad,tau1_nm,tau2_nm,\
             faults"
        )
    );
    assert_eq!(lines.count(), 2521);
    let png_bytes = std::fs::read(&png).expect("plot");
    assert!(png_bytes.starts_with(b"\x89PNG"));

    let surface = viewer(&[
        "sim",
        &scenes("thesis-3d.json"),
        "--device",
        "--trajectory",
        &scenes("thesis-3d.csv"),
        "--out",
        &out_s,
    ]);
    let stderr = String::from_utf8_lossy(&surface.stderr).into_owned();
    assert_eq!(surface.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("2-DoF planar device"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}
