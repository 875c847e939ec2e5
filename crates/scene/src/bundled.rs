//! The scenes that ship with the program (`scenes/*.json`), embedded so that a binary runs
//! from any directory.

use crate::{Scene, SceneError};

/// A scene that ships with the program.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Bundled {
    /// Short name (the file's stem).
    pub name: &'static str,
    /// The `scene/1` JSON.
    pub json: &'static str,
}

/// The bundled scenes, `scenes/*.json`.
pub const BUNDLED: &[Bundled] = &[
    Bundled {
        name: "thesis-2d",
        json: include_str!("../../../scenes/thesis-2d.json"),
    },
    Bundled {
        name: "thesis-3d",
        json: include_str!("../../../scenes/thesis-3d.json"),
    },
    Bundled {
        name: "examples",
        json: include_str!("../../../scenes/examples.json"),
    },
    Bundled {
        name: "deformable",
        json: include_str!("../../../scenes/deformable.json"),
    },
    Bundled {
        name: "torus",
        json: include_str!("../../../scenes/torus.json"),
    },
];

/// The thesis's 2-D hand path (`scenes/thesis-2d.csv`, `t,x,y`), which the app's `--demo`
/// plays as the hand's target, as `viewer sim --device` does.
pub const THESIS_2D_PATH_CSV: &str = include_str!("../../../scenes/thesis-2d.csv");

impl Bundled {
    /// The bundled scene called `name`, if there is one.
    pub fn find(name: &str) -> Option<&'static Bundled> {
        BUNDLED.iter().find(|b| b.name == name)
    }

    /// The scene, validated as any file is.
    pub fn scene(&self) -> Result<Scene, SceneError> {
        Scene::from_json_str(self.json)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every bundled scene is valid, and its name is its file's stem.
    #[test]
    fn every_bundled_scene_loads() {
        for b in BUNDLED {
            let from_disk = Scene::load(format!("../../scenes/{}.json", b.name)).expect(b.name);
            assert_eq!(b.scene().expect(b.name), from_disk, "{}", b.name);
        }
        assert!(Bundled::find("no such scene").is_none());
    }
}
