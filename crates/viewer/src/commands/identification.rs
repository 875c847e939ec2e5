//! `viewer identify` and `viewer device identify`: the walls a device renders, and its damping and friction identified.

use std::process::ExitCode;

use anyhow::{Context, anyhow};
use viewer::cli::EXIT_BAD_SETUP;

use crate::fail;

pub(crate) fn device_identify(args: &viewer::cli::DeviceIdentifyArgs) -> ExitCode {
    use host::devices::Target;
    use protocol::host_side::SimConfig;
    let spec = match crate::device_spec(args.device.device_spec.as_deref()) {
        Ok(spec) => spec,
        Err(code) => return code,
    };
    let opened = match args.device.target() {
        // Nobody holds the simulated handle, and it runs as fast as the host reads.
        Some(Target::Sim) => host::devices::open_sim(SimConfig {
            paced: false,
            released: true,
            spec,
            ..SimConfig::default()
        })
        .context("the simulated device"),
        Some(target) => {
            host::devices::open(&target).with_context(|| format!("cannot open {target:?}"))
        }
        None => Err(anyhow!("device identify: {}", viewer::cli::CHOOSE_A_DEVICE)),
    };
    let mut link = match opened {
        Ok(opened) => opened.link,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    eprintln!("device identify: exciting the joints for 6 s; keep your hands off the handle");
    match host::identify::identify_link(link.as_mut(), &spec, &host::identify::EXCITATION) {
        Ok(found) => print_identified(&found, &spec, None),
        Err(e) => fail(
            &anyhow::Error::new(e).context("device identify"),
            EXIT_BAD_SETUP,
        ),
    }
}

pub(crate) fn identify_command(args: &viewer::cli::IdentifyArgs) -> ExitCode {
    use device::spec::DeviceSpec;
    use host::identify::{EXCITATION, identify_simulated};
    let default = match crate::device_spec(args.device_spec.as_deref()) {
        Ok(spec) => spec,
        Err(code) => return code,
    };
    let truth = DeviceSpec {
        joint_damping_nms_per_rad: args
            .damping
            .map_or(default.joint_damping_nms_per_rad, |b| [b; 2]),
        joint_coulomb_nm: args.coulomb.map_or(default.joint_coulomb_nm, |c| [c; 2]),
        ..default
    };
    let found = match identify_simulated(
        truth,
        device::simulator::SimParams::default(),
        nurbs::Vec2::new(0.0, 0.09),
        &EXCITATION,
        10_000.0,
    ) {
        Ok(found) => found,
        Err(e) => return fail(&anyhow::Error::new(e).context("identify"), EXIT_BAD_SETUP),
    };
    print_identified(&found, &truth, Some(&truth))
}

/// Prints what an identification found (against `truth` when it is known: a simulation),
/// what it means at the handle and the walls it lets the device render.
pub(crate) fn print_identified(
    found: &host::identify::IdentifiedJoints,
    spec: &device::spec::DeviceSpec,
    truth: Option<&device::spec::DeviceSpec>,
) -> ExitCode {
    use device::safety::SafetyConfig;
    use device::wall::{PassivityConfig, WallLimits};
    for i in 0..2 {
        let known = |value: f32| match truth {
            Some(_) => format!(" (simulator {value:.3e})"),
            None => String::new(),
        };
        let noise = |v: f64| {
            if v < 0.0 {
                " (below 0: none, taken as 0)"
            } else {
                ""
            }
        };
        println!(
            "joint {}: damping {:.3e} N m s/rad{}{}, Coulomb {:.3e} N m{}{}, {} samples",
            i + 1,
            found.damping_nms_per_rad[i],
            noise(found.damping_nms_per_rad[i]),
            known(truth.map_or(0.0, |t| t.joint_damping_nms_per_rad[i])),
            found.coulomb_nm[i],
            noise(found.coulomb_nm[i]),
            known(truth.map_or(0.0, |t| t.joint_coulomb_nm[i])),
            found.samples[i]
        );
    }
    let identified = found.apply(spec);
    let at_handle = match identified.at_handle() {
        Ok(h) => h,
        Err(e) => return fail(&anyhow!("the identified description: {e}"), EXIT_BAD_SETUP),
    };
    println!(
        "at the handle (worst pose): damping {:.4} N s/m, Coulomb friction {:.4} N, {:.1} um per count",
        at_handle.damping_n_s_per_m,
        at_handle.coulomb_n,
        at_handle.resolution_m * 1e6
    );
    let passivity = PassivityConfig {
        device: at_handle,
        ..SafetyConfig::default().passivity
    };
    for rate_hz in [1000.0f32, 10_000.0] {
        let limits = WallLimits::new(&passivity, 0.0, 1.0 / rate_hz);
        let (alone, _) = limits.max(false);
        let (with, _) = limits.max(true);
        println!(
            "{rate_hz:.0} Hz: walls up to {alone:.0} N/m (passivity {:.0}, quantisation {:.0}), \
             {with:.0} N/m with the passivity controller (B = 0)",
            limits.passive_n_per_m, limits.quantisation_n_per_m
        );
    }
    ExitCode::SUCCESS
}
