//! The rules a plan's fields follow, checked on the spec as written: names, material fields,
//! the design's fields, staircases, and the number of trials.

use friction::FrictionMaterial;

use super::error::{PlanError, invalid};
use super::spec::{
    ConditionSpec, Design, MATERIAL_FIELDS, PlanSpec, StaircaseSpec, StepKind, StopSpec,
};

pub(super) fn check_name(field: &str, name: &str) -> Result<(), PlanError> {
    if name.trim().is_empty() {
        return Err(invalid(field, "empty; a name is needed"));
    }
    Ok(())
}

pub(super) fn check_conditions(conditions: &[ConditionSpec]) -> Result<(), PlanError> {
    if conditions.is_empty() {
        return Err(invalid(
            "conditions",
            "empty; leave it out for one condition without overrides",
        ));
    }
    for (i, c) in conditions.iter().enumerate() {
        check_name(&format!("conditions[{i}].name"), &c.name)?;
        if let Some(j) = conditions[..i].iter().position(|o| o.name == c.name) {
            return Err(invalid(
                format!("conditions[{i}].name"),
                format!("{:?} is also the name of conditions[{j}]", c.name),
            ));
        }
        for field in c.material.keys() {
            check_field(&format!("conditions[{i}].material.{field}"), field)?;
        }
    }
    Ok(())
}

fn check_field(at: &str, field: &str) -> Result<(), PlanError> {
    if MATERIAL_FIELDS.contains(&field) {
        Ok(())
    } else {
        Err(invalid(at, not_a_field(field)))
    }
}

fn not_a_field(field: &str) -> String {
    format!(
        "{field:?} is not a material field; the fields are {}",
        MATERIAL_FIELDS.join(", ")
    )
}

/// Sets material field `field` (one of [`MATERIAL_FIELDS`]) to `value`.
pub(super) fn set_field(m: &mut FrictionMaterial, field: &str, value: f64) -> Result<(), String> {
    // The loop's type is f32; a value beyond it would become infinite.
    let v = value as f32;
    if !v.is_finite() {
        return Err(format!("{value} is not representable in f32"));
    }
    let slot = match field {
        "stiffness_n_per_m" => &mut m.stiffness_n_per_m,
        "damping_ns_per_m" => &mut m.damping_ns_per_m,
        "mu_static" => &mut m.mu_static,
        "mu_dynamic" => &mut m.mu_dynamic,
        "transition_time_s" => &mut m.transition_time_s,
        "converge_tol_m" => &mut m.converge_tol_m,
        "stop_speed_m_per_s" => &mut m.stop_speed_m_per_s,
        "viscous_ns_per_m" => &mut m.viscous_ns_per_m,
        "karnopp_band_m_per_s" => &mut m.karnopp_band_m_per_s,
        "bristle_stiffness_n_per_m" => &mut m.bristle_stiffness_n_per_m,
        "bristle_damping_ns_per_m" => &mut m.bristle_damping_ns_per_m,
        "stribeck_speed_m_per_s" => &mut m.stribeck_speed_m_per_s,
        _ => return Err(not_a_field(field)),
    };
    *slot = v;
    Ok(())
}

pub(super) fn check_design(spec: &PlanSpec) -> Result<(), PlanError> {
    let design = spec.design.name();
    let only = |field: &str, for_design: &str| {
        invalid(
            field,
            format!("only for {for_design} designs, this one is {design}"),
        )
    };
    match spec.design {
        Design::Identification => {
            if spec.reference.is_some() {
                return Err(only("reference", "2afc-staircase and constant-stimuli"));
            }
        }
        Design::TwoAfcStaircase | Design::ConstantStimuli => match &spec.reference {
            None => {
                return Err(invalid(
                    "reference",
                    format!("missing; a {design} design needs {{\"field\", \"value\"}}"),
                ));
            }
            Some(r) => {
                check_field("reference.field", &r.field)?;
                if !r.value.is_finite() {
                    return Err(invalid("reference.value", "not finite"));
                }
            }
        },
    }
    if spec.design != Design::ConstantStimuli && !spec.levels.is_empty() {
        return Err(only("levels", "constant-stimuli"));
    }
    if spec.design == Design::ConstantStimuli && spec.levels.is_empty() {
        return Err(invalid(
            "levels",
            "empty; a constant-stimuli design needs at least one",
        ));
    }
    if spec.design != Design::TwoAfcStaircase {
        if !spec.staircases.is_empty() {
            return Err(only("staircases", "2afc-staircase"));
        }
        if !spec.interleave {
            return Err(only("interleave", "2afc-staircase"));
        }
        return Ok(());
    }
    if spec.staircases.is_empty() {
        return Err(invalid(
            "staircases",
            "empty; a 2afc-staircase design needs at least one",
        ));
    }
    for (i, s) in spec.staircases.iter().enumerate() {
        check_staircase(i, s, &spec.staircases[..i])?;
        if let Some(r) = spec.reference.as_ref().map(|r| r.value) {
            check_side(i, s, r)?;
        }
    }
    Ok(())
}

/// A staircase stays on one side of the reference: a comparison equal to it has no right
/// answer (the participant guesses, and the trial tells nothing), and one that crosses it
/// turns a right answer into a wrong one. Its bounds must not reach the reference (the
/// shipped JND plan's did: about 15 trials of each run were at the reference itself); the
/// message gives the bound one step away.
fn check_side(i: usize, s: &StaircaseSpec, reference: f64) -> Result<(), PlanError> {
    let [lo, hi] = s.bounds;
    if !(lo <= reference && reference <= hi) {
        return Ok(());
    }
    let size = s.step.reduced_size.unwrap_or(s.step.size);
    let (near_above, near_below) = match s.step.kind {
        StepKind::Multiplicative => (reference * size, reference / size),
        StepKind::Additive => (reference + size, reference - size),
    };
    let suggestion = if s.start > reference {
        format!("[{near_above}, {hi}]")
    } else {
        format!("[{lo}, {near_below}]")
    };
    Err(invalid(
        format!("staircases[{i}].bounds"),
        format!(
            "[{lo}, {hi}] reaches the reference {reference}: a comparison equal to it has no \
             right answer; bound the staircase on one side, e.g. {suggestion}"
        ),
    ))
}

/// Most trials a session takes: a plan asking for more is refused at load, and a session that
/// reaches it (a staircase that never stops) ends with [`RunError::TooManyTrials`]. 10,000
/// trials at a few seconds each is a working day at the device.
///
/// [`RunError::TooManyTrials`]: crate::error::RunError::TooManyTrials
pub const MAX_TRIALS: usize = 10_000;

/// The trials a plan asks for, counted before anything is built: practice plus, unless its
/// levels are chosen online (a staircase), every stimulus × condition (× level) `repetitions`
/// times; each within [`MAX_TRIALS`], the field that passes it named.
pub(super) fn check_counts(spec: &PlanSpec) -> Result<(), PlanError> {
    let most = MAX_TRIALS as u64;
    let practice = u64::from(spec.practice_trials);
    if practice > most {
        return Err(invalid(
            "practice_trials",
            format!("{practice} is more than a session's {MAX_TRIALS} trials"),
        ));
    }
    for (i, s) in spec.staircases.iter().enumerate() {
        if let StopSpec::Trials(n) = s.stop
            && u64::from(n) > most
        {
            return Err(invalid(
                format!("staircases[{i}].stop.trials"),
                format!("{n} is more than a session's {MAX_TRIALS} trials"),
            ));
        }
    }
    if spec.design == Design::TwoAfcStaircase {
        return Ok(());
    }
    let levels = if spec.design == Design::ConstantStimuli {
        spec.levels.len().max(1)
    } else {
        1
    };
    // Saturating: a count past u64 is still more than MAX_TRIALS.
    let cells = (spec.stimuli.len() as u64)
        .saturating_mul(spec.conditions.len() as u64)
        .saturating_mul(levels as u64);
    let runs = cells.saturating_mul(u64::from(spec.repetitions));
    let total = runs.saturating_add(practice);
    if total > most {
        let field = if runs <= most {
            "practice_trials"
        } else if spec.design == Design::ConstantStimuli && cells > most {
            "levels"
        } else {
            "repetitions"
        };
        let levels = if spec.design == Design::ConstantStimuli {
            format!(" × {levels} levels")
        } else {
            String::new()
        };
        return Err(invalid(
            field,
            format!(
                "{} stimuli × {} conditions{levels} × {} repetitions + {practice} practice \
                 trials = {total} trials, more than a session's {MAX_TRIALS}",
                spec.stimuli.len(),
                spec.conditions.len(),
                spec.repetitions,
            ),
        ));
    }
    Ok(())
}

fn check_staircase(i: usize, s: &StaircaseSpec, before: &[StaircaseSpec]) -> Result<(), PlanError> {
    let at = |field: &str| format!("staircases[{i}].{field}");
    check_name(&at("name"), &s.name)?;
    if let Some(j) = before.iter().position(|o| o.name == s.name) {
        return Err(invalid(
            at("name"),
            format!("{:?} is also the name of staircases[{j}]", s.name),
        ));
    }
    if s.rule.down == 0 {
        return Err(invalid(at("rule.down"), "0; at least 1 is needed"));
    }
    if s.rule.up == 0 {
        return Err(invalid(at("rule.up"), "0; at least 1 is needed"));
    }
    let step_size = |field: &str, size: f64| match s.step.kind {
        StepKind::Additive if !(size > 0.0 && size.is_finite()) => {
            Err(invalid(at(field), format!("{size} is not positive")))
        }
        StepKind::Multiplicative if !(size > 1.0 && size.is_finite()) => Err(invalid(
            at(field),
            format!(
                "{size} is not above 1 (a multiplicative step multiplies or divides the level by it)"
            ),
        )),
        _ => Ok(()),
    };
    step_size("step.size", s.step.size)?;
    match (s.step.reduce_after_reversals, s.step.reduced_size) {
        (Some(0), _) => {
            return Err(invalid(
                at("step.reduce_after_reversals"),
                "0; at least 1 is needed",
            ));
        }
        (Some(_), Some(r)) => step_size("step.reduced_size", r)?,
        (Some(_), None) => {
            return Err(invalid(
                at("step.reduced_size"),
                "missing; reduce_after_reversals needs it",
            ));
        }
        (None, Some(_)) => {
            return Err(invalid(
                at("step.reduce_after_reversals"),
                "missing; reduced_size needs it",
            ));
        }
        (None, None) => {}
    }
    match s.stop {
        StopSpec::Reversals(0) => {
            return Err(invalid(at("stop.reversals"), "0; at least 1 is needed"));
        }
        StopSpec::Trials(0) => return Err(invalid(at("stop.trials"), "0; at least 1 is needed")),
        _ => {}
    }
    let [lo, hi] = s.bounds;
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        return Err(invalid(
            at("bounds"),
            format!("[{lo}, {hi}] is not an interval [lo, hi] with lo < hi"),
        ));
    }
    if s.step.kind == StepKind::Multiplicative && lo <= 0.0 {
        return Err(invalid(
            at("bounds[0]"),
            format!("{lo} is not positive (a multiplicative staircase stays positive)"),
        ));
    }
    if !(lo..=hi).contains(&s.start) {
        return Err(invalid(
            at("start"),
            format!("{} is not within bounds [{lo}, {hi}]", s.start),
        ));
    }
    Ok(())
}
