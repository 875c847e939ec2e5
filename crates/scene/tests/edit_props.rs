//! Scene edits are total: whatever the indices, positions, weights and parameters (out of
//! range, non-finite, huge), an edit returns a scene that is valid as a loaded one is, or an
//! error naming where; it never panics, and the scene it was given is unchanged.

use nurbs::Vec2;
use proptest::prelude::*;
use scene::edit::{self, PointRef};
use scene::{Object, Patch, Scene};

fn scene(name: &str) -> Scene {
    let json = match name {
        "thesis-2d" => include_str!("../../../scenes/thesis-2d.json"),
        _ => include_str!("../../../scenes/examples.json"),
    };
    Scene::from_json_str(json).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Validates `s` again from its parts, as a scene built by hand would be.
fn revalidate(s: &Scene) {
    let objects: Vec<Object> = s
        .objects()
        .iter()
        .map(|o| {
            Object::new(o.name(), *o.material(), o.patches().to_vec())
                .unwrap_or_else(|e| panic!("{e}"))
        })
        .collect();
    Scene::new(objects).unwrap_or_else(|e| panic!("{e}"));
}

fn coordinate() -> impl Strategy<Value = f32> {
    prop_oneof![
        8 => -0.1f32..0.2,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(3e6f32),
    ]
}

fn weight() -> impl Strategy<Value = f64> {
    prop_oneof![
        8 => 0.01f64..100.0,
        1 => Just(0.0),
        1 => Just(-1.0),
        1 => Just(f64::NAN),
        1 => Just(1e300),
    ]
}

fn parameter() -> impl Strategy<Value = f32> {
    prop_oneof![8 => -0.2f32..1.2, 1 => Just(f32::NAN), 1 => Just(0.0), 1 => Just(1.0)]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn every_edit_is_total(
        which in 0usize..2,
        object in 0usize..4,
        patch in 0usize..4,
        index in 0usize..12,
        x in coordinate(),
        y in coordinate(),
        w in weight(),
        u in parameter(),
        op in 0usize..5,
    ) {
        let s = scene(["thesis-2d", "examples"][which]);
        let copy = s.clone();
        let at = PointRef::new(object, patch, index);
        let result = match op {
            0 => edit::move_point(&s, at, Vec2::new(x, y)),
            1 => edit::set_weight(&s, at, w),
            2 => edit::insert_knot(&s, object, patch, u),
            3 => edit::split_patch(&s, object, patch, u),
            _ => edit::join_next(&s, object, patch),
        };
        match result {
            Ok(edited) => {
                revalidate(&edited);
                // Every planar curve of the edited object still meets its neighbour.
                if let Some(curves) = edited.object(object).and_then(|o| o.curve_views()) {
                    prop_assert!(tracker::Chain::new(&curves).is_ok());
                }
                if op == 0 {
                    let moved = match edited.object(object).and_then(|o| o.patch(patch)) {
                        Some(Patch::Curve2(c)) => c.view().control_point(index),
                        _ => None,
                    };
                    let (p, _) = moved.expect("the moved point exists");
                    // (w·P, w) round trip: a few ulps of the coordinates.
                    prop_assert!((p - Vec2::new(x, y)).length() < 1e-6);
                }
            }
            Err(e) => {
                let msg = e.to_string();
                prop_assert!(msg.starts_with(&format!("object {object}")), "{}", msg);
            }
        }
        prop_assert_eq!(s, copy);
    }
}
