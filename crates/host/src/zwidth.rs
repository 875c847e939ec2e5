//! The Z-width of the simulated pantograph: which walls (stiffness K, damping B) stay stable
//! at a tick rate, for a hand that grips the handle, a light fingertip, or nobody.
//!
//! One cell is one impact: the hand brings the handle from 15 mm in front of a straight,
//! frictionless wall towards it at the impact speed, then
//! - [`Hand::Grip`] and [`Hand::Finger`] keep pushing: the hand's target stops 1 mm inside the
//!   wall and stays there (impact, then hold);
//! - [`Hand::Released`] lets go just before the wall (2 ms of travel, at most 1 mm): the
//!   handle flies into it on its own momentum, and nobody holds it afterwards (its own mass,
//!   the device's own friction and damping, the motors).
//!
//! The run continues for [`HOLD_S`] after the first contact, on the device's controller (the
//! tick the board runs) closed through [`SimulatedPantograph`] (zero-order hold, one tick of
//! command delay, encoder quantisation, Coulomb friction and damping, torque saturation).
//!
//! A cell is **stable** when, over the last [`SETTLE_S`] of the run,
//! - the rendered force is steady: its magnitude varies by at most one encoder quantum's
//!   worth of wall force, `K Δ` (a handle at rest reads constant counts, so a resting
//!   contact holds a constant force; a moving one in a limit cycle does not), and
//! - for a released handle, the mechanical energy (kinetic plus the wall's `½ K d²`) has not
//!   grown beyond what it brought to the wall: a passive wall gives back at most what it got.

use device::controller::Controller;
use device::safety::SafetyConfig;
use device::simulator::SimulatedPantograph;
use device::spec::DeviceSpec;
use friction::FrictionMaterial;
use nurbs::{Vec2, construct};
use tracker::Chain;

use crate::error::SimError;

/// How long each cell runs after the first contact (s).
pub const HOLD_S: f64 = 0.6;
/// The final window a cell is judged on (s).
pub const SETTLE_S: f64 = 0.2;
/// Where the wall is: the line y = WALL_Y_M across the workspace, the object beyond it.
pub const WALL_Y_M: f32 = 0.10;
/// How far in front of the wall the handle starts (m).
const START_GAP_M: f32 = 0.015;
/// How far inside the wall a holding hand's target stops, and how far in front of the wall a
/// releasing hand lets go (m).
const HAND_MARGIN_M: f32 = 0.001;

pub use crate::hand::Hand;

/// One cell of the sweep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Impact {
    /// Tick rate (Hz).
    pub rate_hz: f64,
    /// Wall stiffness K (N/m).
    pub stiffness_n_per_m: f32,
    /// Wall damping B (N·s/m).
    pub damping_ns_per_m: f32,
    /// Speed of the hand towards the wall (m/s).
    pub speed_m_per_s: f32,
    /// Who holds the handle.
    pub hand: Hand,
    /// Whether the passivity controller (the energy tank) is on.
    pub passivity_control: bool,
}

/// What one impact did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outcome {
    /// Steady force and, released, no energy gained (see the module docs).
    pub stable: bool,
    /// Peak-to-peak of the force magnitude over the final window (N).
    pub ripple_n: f32,
    /// The largest mechanical energy after the first contact over the energy at it (released
    /// handle; 0 otherwise). Above 1: the wall gave back more than it got.
    pub energy_ratio: f32,
    /// Whether the handle touches the wall at the end.
    pub in_contact_at_end: bool,
    /// Handle speed at the end (m/s).
    pub final_speed_m_per_s: f32,
    /// The force at the end (N).
    pub final_force_n: f32,
}

/// The straight wall y = [`WALL_Y_M`], the object on the far side (y > WALL_Y_M).
fn wall() -> nurbs::CurveBuf<Vec2> {
    // Traversed towards +x, so that its outward side faces the motors: the object lies
    // beyond the line.
    #[allow(clippy::expect_used)]
    construct::line(Vec2::new(-0.04, WALL_Y_M), Vec2::new(0.04, WALL_Y_M))
        .expect("two distinct points make a line")
}

/// Runs one impact on the default pantograph.
pub fn impact(cell: &Impact) -> Result<Outcome, SimError> {
    impact_on(DeviceSpec::default(), cell)
}

/// Runs one impact on the pantograph `spec`.
pub fn impact_on(spec: DeviceSpec, cell: &Impact) -> Result<Outcome, SimError> {
    crate::error::check_rate(cell.rate_hz)?;
    let period_s = (1.0 / cell.rate_hz) as f32;
    let safety = SafetyConfig {
        period_s,
        ramp_time_s: 0.0,
        ..SafetyConfig::default()
    };
    let material = FrictionMaterial {
        stiffness_n_per_m: cell.stiffness_n_per_m,
        damping_ns_per_m: cell.damping_ns_per_m,
        mu_static: 0.0,
        mu_dynamic: 0.0,
        ..FrictionMaterial::default()
    };
    let curve = wall();
    let curves = [curve.view()];
    let chain = Chain::new(&curves).map_err(|error| SimError::Chain { index: 0, error })?;
    let mut controller: Controller<Chain> =
        Controller::new(spec, safety).map_err(SimError::Controller)?;
    let start = Vec2::new(0.0, WALL_Y_M - START_GAP_M);
    let mut arm =
        SimulatedPantograph::new(spec, cell.hand.params(), start).map_err(SimError::Simulator)?;
    controller
        .calibrate(spec.end_stop_counts())
        .map_err(SimError::Controller)?;
    // The simulated encoders count from the spec's zero; calibrating on the end-stop counts
    // maps them back onto the same angles.
    controller.load_scene_for_measurement(chain, material, cell.passivity_control);
    controller.set_forces_enabled(true);

    let t = f64::from(period_s);
    let period_us = (1e6 / cell.rate_hz).round() as u64;
    let approach_s = f64::from(START_GAP_M + HAND_MARGIN_M) / f64::from(cell.speed_m_per_s);
    let max_ticks = ((approach_s * 3.0 + HOLD_S) * cell.rate_hz) as usize + 1;
    let settle_ticks = (SETTLE_S * cell.rate_hz) as usize;
    let resolution = spec
        .at_handle()
        .map_err(|e| SimError::Controller(device::controller::ControllerError::Spec(e)))?
        .resolution_m;
    let k = cell.stiffness_n_per_m;

    let mut contact_at: Option<usize> = None;
    let mut impact_energy = 0.0f32;
    let mut max_energy = 0.0f32;
    let mut final_energy;
    let mut forces: Vec<f32> = Vec::with_capacity(settle_ticks + 1);
    let mut last_force;
    let mut tick = 0usize;
    loop {
        let (hip, _) = arm.hip().map_err(|error| SimError::Arm {
            t_s: tick as f64 * t,
            error,
        })?;
        let depth = hip.y - WALL_Y_M;
        if contact_at.is_none() && depth >= 0.0 {
            contact_at = Some(tick);
        }
        // Let go just before the wall: within 2 ms of travel (at most 1 mm), so that a slow
        // handle still reaches it against the device's dry friction.
        let release_m = HAND_MARGIN_M.min(cell.speed_m_per_s * 2e-3);
        if cell.hand == Hand::Released && arm.is_held() && depth >= -release_m {
            arm.release();
        }
        // Out of contact the handle's energy is all kinetic: compared with what it brought,
        // it says what the wall gave back. (Inside, a sampled wall's stored energy is not
        // ½ K d²: judged only once the handle is out, or at the end.)
        let kinetic = arm.kinetic_energy().unwrap_or(f32::NAN);
        if contact_at == Some(tick) {
            impact_energy = kinetic;
        }
        if contact_at.is_some() && depth < 0.0 {
            max_energy = max_energy.max(kinetic);
        }
        let hand_y = (f64::from(start.y) + f64::from(cell.speed_m_per_s) * tick as f64 * t)
            .min(f64::from(WALL_Y_M + HAND_MARGIN_M)) as f32;
        controller.heartbeat();
        let out = controller.tick(arm.encoder_counts(), tick as u64 * period_us);
        controller.acquire_now();
        last_force = out.telemetry.force_n.length();
        // The energy the wall still holds is what its rendered force can give back, |F|²/2K
        // (a tank that has run dry renders less than K d, and stores less).
        final_energy = kinetic + last_force * last_force / (2.0 * k);
        arm.step(out.currents_a, Vec2::new(0.0, hand_y), period_s)
            .map_err(|error| SimError::Arm {
                t_s: tick as f64 * t,
                error,
            })?;
        tick += 1;
        let done = contact_at.is_some_and(|c| tick >= c + (HOLD_S * cell.rate_hz) as usize);
        if done || tick >= max_ticks {
            break;
        }
        if contact_at.is_some_and(|c| tick + settle_ticks >= c + (HOLD_S * cell.rate_hz) as usize) {
            forces.push(last_force);
        }
    }
    let (hip, velocity) = arm.hip().map_err(|error| SimError::Arm {
        t_s: tick as f64 * t,
        error,
    })?;
    let ripple = forces.iter().copied().fold(f32::NEG_INFINITY, f32::max)
        - forces.iter().copied().fold(f32::INFINITY, f32::min);
    let ripple = if forces.is_empty() { 0.0 } else { ripple };
    let energy_ratio = if cell.hand == Hand::Released && impact_energy > 0.0 {
        max_energy.max(final_energy) / impact_energy
    } else {
        0.0
    };
    // One encoder quantum's worth of wall force: what a contact at rest may flicker by.
    let steady = ripple <= k * resolution;
    let passive = cell.hand != Hand::Released || energy_ratio <= 1.0;
    Ok(Outcome {
        stable: contact_at.is_some() && steady && passive,
        ripple_n: ripple,
        energy_ratio,
        in_contact_at_end: hip.y >= WALL_Y_M,
        final_speed_m_per_s: velocity.length(),
        final_force_n: last_force,
    })
}

/// One cell of a sweep with its outcome.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    /// What was run.
    pub impact: Impact,
    /// What it did.
    pub outcome: Outcome,
}

/// Every (K, B) of `stiffnesses` × `dampings` at `rate_hz` for `hand`, with and without the
/// passivity controller (`controller`), on the default pantograph; `progress(done, total)`
/// after each cell.
pub fn sweep(
    rate_hz: f64,
    hand: Hand,
    stiffnesses: &[f32],
    dampings: &[f32],
    controller: bool,
    speed_m_per_s: f32,
    progress: impl FnMut(usize, usize),
) -> Result<Vec<Cell>, SimError> {
    let grid = (stiffnesses, dampings);
    let spec = DeviceSpec::default();
    sweep_on(
        &spec,
        rate_hz,
        hand,
        grid,
        controller,
        speed_m_per_s,
        progress,
    )
}

/// [`sweep`] on the pantograph `spec`, over the grid `(stiffnesses, dampings)`.
pub fn sweep_on(
    spec: &DeviceSpec,
    rate_hz: f64,
    hand: Hand,
    (stiffnesses, dampings): (&[f32], &[f32]),
    controller: bool,
    speed_m_per_s: f32,
    mut progress: impl FnMut(usize, usize),
) -> Result<Vec<Cell>, SimError> {
    let total = stiffnesses.len() * dampings.len();
    let mut cells = Vec::with_capacity(total);
    for &damping_ns_per_m in dampings {
        for &stiffness_n_per_m in stiffnesses {
            let impact = Impact {
                rate_hz,
                stiffness_n_per_m,
                damping_ns_per_m,
                speed_m_per_s,
                hand,
                passivity_control: controller,
            };
            let outcome = impact_on(*spec, &impact)?;
            cells.push(Cell { impact, outcome });
            progress(cells.len(), total);
        }
    }
    Ok(cells)
}

/// The CSV header of [`write_csv`].
pub const CSV_HEADER: &str = "rate_hz,hand,controller,stiffness_n_per_m,damping_ns_per_m,speed_m_per_s,stable,ripple_n,energy_ratio,in_contact_at_end,final_force_n";

/// The cells as CSV, one row per cell under [`CSV_HEADER`].
pub fn write_csv(cells: &[Cell], mut out: impl std::io::Write) -> std::io::Result<()> {
    writeln!(out, "{CSV_HEADER}")?;
    for c in cells {
        let (i, o) = (&c.impact, &c.outcome);
        writeln!(
            out,
            "{},{},{},{},{},{},{},{},{},{},{}",
            i.rate_hz,
            i.hand.name(),
            i.passivity_control,
            i.stiffness_n_per_m,
            i.damping_ns_per_m,
            i.speed_m_per_s,
            o.stable,
            o.ripple_n,
            o.energy_ratio,
            o.in_contact_at_end,
            o.final_force_n
        )?;
    }
    Ok(())
}
