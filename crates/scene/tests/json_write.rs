//! Writing `scene/1`: every bundled scene reads back from what it writes, and
//! `Scene::with_material` replaces one object's material.

use scene::{Material, Patch, Scene};

/// Every bundled scene reads back from what it writes: the same objects, names,
/// materials, degrees and knots exactly; the control points exactly where the weights
/// are 1, and within the reader's own rounding elsewhere (x·w/w: one ulp of the
/// coordinate, relative 2⁻²³, and a second for the reader's multiply).
#[test]
fn every_bundled_scene_round_trips() {
    for text in [
        include_str!("../../../scenes/thesis-2d.json"),
        include_str!("../../../scenes/thesis-3d.json"),
        include_str!("../../../scenes/examples.json"),
    ] {
        let scene = Scene::from_json_str(text).unwrap_or_else(|e| panic!("{e}"));
        let back = Scene::from_json_str(&scene.to_json_string())
            .unwrap_or_else(|e| panic!("{e}\n{}", scene.to_json_string()));
        assert_eq!(back.objects().len(), scene.objects().len());
        for (a, b) in scene.objects().iter().zip(back.objects()) {
            assert_eq!(a.name(), b.name());
            assert_eq!(a.material(), b.material());
            assert_eq!(a.patches().len(), b.patches().len());
            for (p, q) in a.patches().iter().zip(b.patches()) {
                let close = |x: f32, y: f32, w: f32| {
                    if w == 1.0 {
                        x == y
                    } else {
                        (x - y).abs() <= 2.0 * f32::EPSILON * x.abs().max(f32::MIN_POSITIVE)
                    }
                };
                match (p, q) {
                    (Patch::Curve2(c), Patch::Curve2(d)) => {
                        assert_eq!(c.degree(), d.degree());
                        assert_eq!(c.knots(), d.knots());
                        for (h, k) in c.points().iter().zip(d.points()) {
                            assert_eq!(h.z, k.z, "weight");
                            assert!(close(h.x, k.x, h.z) && close(h.y, k.y, h.z), "{h} {k}");
                        }
                    }
                    (Patch::Surface(s), Patch::Surface(t)) => {
                        assert_eq!(s.degree(), t.degree());
                        assert_eq!(s.knots(), t.knots());
                        for (h, k) in s.points().iter().zip(t.points()) {
                            assert_eq!(h.w, k.w, "weight");
                            assert!(
                                close(h.x, k.x, h.w)
                                    && close(h.y, k.y, h.w)
                                    && close(h.z, k.z, h.w),
                                "{h} {k}"
                            );
                        }
                    }
                    (Patch::Curve3(c), Patch::Curve3(d)) => {
                        assert_eq!(c.knots(), d.knots());
                        assert_eq!(c.points().len(), d.points().len());
                    }
                    _ => panic!("patch kind changed"),
                }
            }
        }
    }
}

/// A new material is validated as the reader would (the object's own check) and
/// replaces only that object's.
#[test]
fn with_material_replaces_one_objects_material() {
    let scene = Scene::from_json_str(include_str!("../../../scenes/examples.json"))
        .unwrap_or_else(|e| panic!("{e}"));
    let m = Material::new(500.0, 1.0, 0.4, 0.3).expect("valid");
    let changed = scene.with_material(0, m).expect("valid");
    assert_eq!(changed.objects()[0].material(), &m);
    assert_eq!(changed.objects()[1..], scene.objects()[1..]);
    assert!(scene.with_material(99, m).is_ok_and(|s| s == scene));
}
