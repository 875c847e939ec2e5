//! The thesis-2d scenario closed through the real dynamics: the trajectory moves the virtual
//! hand's target, the simulated pantograph carries the handle, and the device's `Controller`
//! (kinematics → tracker → friction → safety → Jᵀ F → currents) pushes back.
#![allow(clippy::unwrap_used)]

use device::controller::Controller;
use device::safety::SafetyConfig;
use device::simulator::{SimParams, SimulatedPantograph};
use device::spec::DeviceSpec;
use friction::Mode;
use nurbs::Vec2;
use tracker::Chain;
use viewer::scene::Scene;
use viewer::trajectory::Trajectory;

#[test]
fn thesis_2d_stick_slip_through_the_simulated_pantograph() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/");
    let scene = Scene::load(format!("{dir}thesis-2d.json")).unwrap();
    let traj = Trajectory::load(format!("{dir}thesis-2d.csv")).unwrap();
    let object = &scene.objects()[0];
    let curves = object.curve_views().unwrap();
    let chain = Chain::new(&curves).unwrap();

    let spec = DeviceSpec::default();
    let t = 1e-3f32;
    let safety = SafetyConfig {
        period_s: t,
        ramp_time_s: 0.02,
        ..SafetyConfig::default()
    };
    let mut controller: Controller<Chain<'_>> = Controller::new(spec, safety).unwrap();
    // K = 1000 N/m at 1 kHz needs b > K T / 2 = 0.5 N·s/m: at the bound of the default
    // device's damping, so the scene is refused without the passivity controller.
    let material = object.material().friction_material();
    assert!(controller.load_scene(chain, material, false).is_err());
    controller.load_scene(chain, material, true).unwrap();

    // Calibrate on the end stops: the counts the encoders read there.
    let per_rad = spec.counts_per_joint_rad();
    let stops = [0, 1].map(|i| {
        spec.encoder_offset_counts[i]
            + (spec.encoder_direction[i].sign() * spec.end_stop_rad[i] * per_rad[i]).floor() as i32
    });
    controller.calibrate(stops).unwrap();
    controller.set_forces_enabled(true);

    let start = traj.at(traj.start_s());
    let hand = SimParams {
        hand_stiffness_n_per_m: 2000.0,
        hand_damping_ns_per_m: 5.0,
        ..SimParams::default()
    };
    let mut sim =
        SimulatedPantograph::new(spec, hand, Vec2::new(start[0] as f32, start[1] as f32)).unwrap();
    let mut modes: Vec<Mode> = Vec::new();
    let mut max_force: f32 = 0.0;
    let n = traj.tick_count(1000.0) as usize;
    for k in 0..n {
        let now = traj.tick_time_s(k, 1000.0);
        controller.heartbeat();
        let target = traj.at(now);
        let out = controller.tick(sim.encoder_counts(), k as u64 * 1000);
        assert!(out.currents_a.iter().all(|c| c.is_finite()));
        assert_eq!(
            out.telemetry.faults, 0,
            "tick {k}: faults {:#x}",
            out.telemetry.faults
        );
        max_force = max_force.max(out.telemetry.force_n.length());
        if modes.last() != Some(&out.telemetry.mode) {
            modes.push(out.telemetry.mode);
        }
        sim.step(
            out.currents_a,
            Vec2::new(target[0] as f32, target[1] as f32),
            t,
        )
        .unwrap();
    }
    eprintln!("modes {modes:?} max force {max_force}");
    // Through the hand’s compliance the HIP presses less deeply than the target, but the
    // friction sequence of §3.2.1 survives: contact sticks, breaks away through the
    // transition into slip, and sticks again, more than once.
    let stick_slip = modes
        .windows(3)
        .filter(|w| w == &[Mode::Stuck, Mode::Transition, Mode::Slip])
        .count();
    assert!(stick_slip >= 2, "modes {modes:?}");
    assert!(modes.contains(&Mode::Free));
    assert!(
        max_force > 0.5 && max_force <= 5.0 + 1e-3,
        "max force {max_force}"
    );
}
