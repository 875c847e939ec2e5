//! A validated [`Plan`]: read, checked field by field, its scenes loaded, and the materials
//! its trials render.

use std::path::{Path, PathBuf};

use scene::{Bundled, Material, Scene};

use super::checks::{check_conditions, check_counts, check_design, check_name, set_field};
use super::error::{PlanError, invalid};
use super::order::ConditionOrders;
use super::spec::{FORMAT, PlanSpec, StimulusSpec};

/// A validated plan with its stimuli's scenes loaded.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    spec: PlanSpec,
    scenes: Vec<Scene>,
    /// The folder relative scene paths are resolved against.
    folder: PathBuf,
    /// The orders of the conditions across participants (`None`: mixed blocks).
    orders: Option<ConditionOrders>,
}

impl Plan {
    /// Parses and validates an `experiment/1` document; relative scene paths are resolved
    /// against `folder` (the plan file's folder).
    pub fn from_json_str(text: &str, folder: &Path) -> Result<Self, PlanError> {
        // The format is checked first so that a file of another version is reported as such,
        // not as a list of unknown fields.
        let header: serde_json::Map<String, serde_json::Value> = parse(text)?;
        match header.get("format") {
            Some(serde_json::Value::String(f)) if f == FORMAT => {}
            Some(found) => {
                return Err(invalid(
                    "format",
                    format!("unsupported format {found}, expected \"{FORMAT}\""),
                ));
            }
            None => return Err(invalid("format", format!("missing, expected \"{FORMAT}\""))),
        }
        Self::from_spec(parse(text)?, folder)
    }

    /// Reads, parses and validates a plan file; errors name the file.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, PlanError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|error| PlanError::Read {
            path: path.to_owned(),
            error,
        })?;
        let folder = path.parent().unwrap_or(Path::new(""));
        Self::from_json_str(&text, folder).map_err(|error| PlanError::File {
            path: path.to_owned(),
            error: Box::new(error),
        })
    }

    /// Validates `spec` and loads its scenes (relative paths against `folder`).
    pub fn from_spec(spec: PlanSpec, folder: &Path) -> Result<Self, PlanError> {
        if spec.format != FORMAT {
            return Err(invalid(
                "format",
                format!(
                    "unsupported format {:?}, expected \"{FORMAT}\"",
                    spec.format
                ),
            ));
        }
        if spec.name.trim().is_empty() {
            return Err(invalid("name", "empty; a plan needs a name"));
        }
        let scenes = load_stimuli(&spec.stimuli, folder)?;
        check_conditions(&spec.conditions)?;
        if spec.repetitions == 0 {
            return Err(invalid("repetitions", "0; at least 1 is needed"));
        }
        if spec.blocks == 0 {
            return Err(invalid("blocks", "0; at least 1 is needed"));
        }
        if !spec.repetitions.is_multiple_of(spec.blocks) {
            return Err(invalid(
                "blocks",
                format!(
                    "{} does not divide repetitions ({}): every block runs each cell equally often",
                    spec.blocks, spec.repetitions
                ),
            ));
        }
        if let Some(t) = spec.exploration_time_s
            && !(t > 0.0 && t.is_finite())
        {
            return Err(invalid(
                "exploration_time_s",
                format!("{t} is not positive"),
            ));
        }
        check_design(&spec)?;
        check_counts(&spec)?;
        let orders =
            ConditionOrders::read(spec.condition_order.as_ref(), &spec.conditions, spec.design)?;
        let plan = Plan {
            spec,
            scenes,
            folder: folder.to_owned(),
            orders,
        };
        plan.check_materials()?;
        Ok(plan)
    }

    /// The plan as written (validated).
    pub fn spec(&self) -> &PlanSpec {
        &self.spec
    }

    /// The orders of the conditions across participants, when the plan counterbalances
    /// them (`condition_order`); `None` for mixed blocks.
    pub fn condition_orders(&self) -> Option<&ConditionOrders> {
        self.orders.as_ref()
    }

    /// The scene of stimulus `index` (loaded with the plan), if there is one.
    pub fn scene(&self, stimulus: usize) -> Option<&Scene> {
        self.scenes.get(stimulus)
    }

    /// The material of `stimulus` under `condition`, with `reference.field` set to `level`
    /// (if any): the stimulus object's material, then the condition's overrides, then the level.
    pub fn material(
        &self,
        stimulus: usize,
        condition: usize,
        level: Option<f64>,
    ) -> Result<Material, PlanError> {
        let base = self
            .scenes
            .get(stimulus)
            .zip(self.spec.stimuli.get(stimulus))
            .and_then(|(s, st)| s.object(st.object))
            .ok_or_else(|| invalid("stimuli", format!("no stimulus {stimulus}")))?;
        let cond = self
            .spec
            .conditions
            .get(condition)
            .ok_or_else(|| invalid("conditions", format!("no condition {condition}")))?;
        let mut m = base.material().friction_material();
        for (field, &value) in &cond.material {
            set_field(&mut m, field, value)
                .map_err(|e| invalid(format!("conditions[{condition}].material.{field}"), e))?;
        }
        if let (Some(level), Some(reference)) = (level, &self.spec.reference) {
            set_field(&mut m, &reference.field, level)
                .map_err(|e| invalid("reference.field", e))?;
        }
        Material::from_friction(m).map_err(|e| {
            invalid(
                format!("conditions[{condition}].material"),
                format!(
                    "with stimulus {stimulus} ({:?}){}: {e}",
                    self.spec.stimuli[stimulus].name,
                    match level {
                        Some(l) => format!(" at level {l}"),
                        None => String::new(),
                    }
                ),
            )
        })
    }

    /// Every stimulus × condition must make a valid material, at the reference value and at
    /// every comparison value the design can ask for.
    fn check_materials(&self) -> Result<(), PlanError> {
        let mut values: Vec<(String, Option<f64>)> = vec![(String::new(), None)];
        if let Some(r) = &self.spec.reference {
            values.push(("reference.value".to_owned(), Some(r.value)));
        }
        for (i, &l) in self.spec.levels.iter().enumerate() {
            values.push((format!("levels[{i}]"), Some(l)));
        }
        for (i, s) in self.spec.staircases.iter().enumerate() {
            values.push((format!("staircases[{i}].start"), Some(s.start)));
            values.push((format!("staircases[{i}].bounds[0]"), Some(s.bounds[0])));
            values.push((format!("staircases[{i}].bounds[1]"), Some(s.bounds[1])));
        }
        for (field, level) in values {
            for s in 0..self.spec.stimuli.len() {
                for c in 0..self.spec.conditions.len() {
                    self.material(s, c, level).map_err(|e| match (&e, level) {
                        (PlanError::Invalid { message, .. }, Some(_)) => {
                            invalid(field.clone(), format!("{message} (condition {c})"))
                        }
                        _ => e,
                    })?;
                }
            }
        }
        Ok(())
    }

    /// The folder the stimuli's relative scene paths are resolved against.
    pub fn folder(&self) -> &Path {
        &self.folder
    }
}

fn load_stimuli(stimuli: &[StimulusSpec], folder: &Path) -> Result<Vec<Scene>, PlanError> {
    if stimuli.is_empty() {
        return Err(invalid(
            "stimuli",
            "the plan has no stimuli, at least one is needed",
        ));
    }
    let mut scenes = Vec::with_capacity(stimuli.len());
    for (i, s) in stimuli.iter().enumerate() {
        check_name(&format!("stimuli[{i}].name"), &s.name)?;
        if let Some(j) = stimuli[..i].iter().position(|o| o.name == s.name) {
            return Err(invalid(
                format!("stimuli[{i}].name"),
                format!("{:?} is also the name of stimuli[{j}]", s.name),
            ));
        }
        let field = format!("stimuli[{i}].scene");
        let scene_error = |error| PlanError::Scene {
            field: field.clone(),
            error: Box::new(error),
        };
        let scene = if is_path(&s.scene) {
            Scene::load(folder.join(&s.scene)).map_err(scene_error)?
        } else {
            match Bundled::find(&s.scene) {
                Some(b) => b.scene().map_err(scene_error)?,
                None => {
                    let names: Vec<&str> = scene::bundled::BUNDLED.iter().map(|b| b.name).collect();
                    return Err(invalid(
                        field,
                        format!(
                            "{:?} is not a bundled scene (they are {}) nor a path (a path contains / or ends in .json)",
                            s.scene,
                            names.join(", ")
                        ),
                    ));
                }
            }
        };
        let count = scene.objects().len();
        if s.object >= count {
            return Err(invalid(
                format!("stimuli[{i}].object"),
                format!(
                    "{} is not an object of {} (it has {count})",
                    s.object, s.scene
                ),
            ));
        }
        scenes.push(scene);
    }
    Ok(scenes)
}

/// A scene reference is a path if it contains `/` or ends in `.json`, else a bundled name.
pub(super) fn is_path(scene: &str) -> bool {
    scene.contains('/') || scene.ends_with(".json")
}

/// Parses with the field path in the error, as `scene/1` does.
fn parse<T: serde::de::DeserializeOwned>(text: &str) -> Result<T, PlanError> {
    scene::json::parse_at(text).map_err(|e| PlanError::Json {
        location: e.path.map_or_else(String::new, |path| path.to_string()),
        error: e.error,
    })
}
