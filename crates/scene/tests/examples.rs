//! `scenes/examples.json` as the loader reads it: its objects, the planar ones inside the
//! device's workspace, and its circle the exact rational circle of `nurbs::construct`.

use std::path::PathBuf;

use nurbs::Point;
use scene::{Patch, Scene};

fn examples() -> Scene {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/examples.json");
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn example_scene_contents() {
    let scene = examples();
    let names: Vec<(&str, &str)> = scene
        .objects()
        .iter()
        .map(|o| (o.name(), o.patches()[0].kind()))
        .collect();
    assert_eq!(
        names,
        [
            ("cubic wave", "planar curve"),
            ("circle", "planar curve"),
            ("bump", "surface"),
        ]
    );
    for object in scene.objects() {
        let m = object.material();
        assert!(m.mu_static() >= m.mu_dynamic());
    }
}

#[test]
fn planar_examples_lie_in_the_device_workspace() {
    // Convex hull property: the control polygon's box contains the curve.
    for object in examples().objects() {
        for patch in object.patches() {
            if let Patch::Curve2(c) = patch {
                let b = c.view().bounding_box();
                assert!(
                    b.min.x >= -0.05 && b.max.x <= 0.05 && b.min.y >= 0.05 && b.max.y <= 0.13,
                    "{} leaves the workspace: {b:?}",
                    object.name()
                );
            }
        }
    }
}

#[test]
fn circle_equals_the_exact_construction() {
    // The file's circle and nurbs' constructor describe the same curve.
    let scene = examples();
    let Patch::Curve2(file) = &scene.objects()[1].patches()[0] else {
        panic!("planar curve")
    };
    let exact = nurbs::construct::circle(nurbs::Vec2::new(0.0, 0.09), 0.03).expect("valid");
    for k in 0..=32 {
        let u = k as f32 / 32.0;
        let (a, b) = (file.view().point(u), exact.view().point(u));
        assert!((a - b).length() < 1e-7, "u = {u}: {a} vs {b}");
        assert_eq!(a.as_slice().len(), 2);
    }
}
