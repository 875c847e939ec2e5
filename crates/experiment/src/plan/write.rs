//! A plan written back as an `experiment/1` document.

use super::error::{PlanError, invalid};
use super::validate::{Plan, is_path};

impl Plan {
    /// The plan as run, for `DIR/plan.json` beside its results: [`Plan::to_json_string`] with
    /// every scene path made absolute (resolved against [`Plan::folder`]), so that the copy
    /// loads from any folder; bundled scene names stay as they are.
    pub fn to_json_string_resolved(&self) -> Result<String, PlanError> {
        let mut spec = self.spec().clone();
        for (i, s) in spec.stimuli.iter_mut().enumerate() {
            if is_path(&s.scene) {
                let path = std::path::absolute(self.folder().join(&s.scene)).map_err(|e| {
                    invalid(
                        format!("stimuli[{i}].scene"),
                        format!("cannot resolve: {e}"),
                    )
                })?;
                s.scene = path.to_string_lossy().into_owned();
            }
        }
        let mut text = serde_json::to_string_pretty(&spec).unwrap_or_default();
        text.push('\n');
        Ok(text)
    }

    /// The plan as a pretty-printed `experiment/1` document (defaults written out), which
    /// [`Plan::from_json_str`] reads back as the same plan.
    pub fn to_json_string(&self) -> String {
        // Serializing plain structs, maps and finite numbers cannot fail.
        let mut text = serde_json::to_string_pretty(self.spec()).unwrap_or_default();
        text.push('\n');
        text
    }
}
