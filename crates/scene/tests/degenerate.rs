//! Degenerate geometry in a `scene/1` file is refused by name (issue 29, item 8): a closed
//! curve whose control points all collapse to one point (the measured case: the rational
//! circle's nine points all at (0, 0.09), which the device then rendered as a 3 N pull
//! towards that point from 17 mm away), a span of a curve collapsed to a point, a surface
//! collapsed to a line or a point. A sphere's poles (a patch side collapsed to a point) stay
//! legitimate, and so does every bundled scene (`bundled` tests).

#![allow(clippy::unwrap_used)]

use scene::Scene;

/// A one-object scene named "ring" of `patch` (a JSON object).
fn scene_of(patch: &str) -> String {
    format!(
        r#"{{ "format": "scene/1", "objects": [ {{ "name": "ring",
              "material": {{ "stiffness_n_per_m": 1000.0, "damping_ns_per_m": 0.0,
                             "mu_static": 0.7, "mu_dynamic": 0.5 }},
              "patches": [ {patch} ] }} ] }}"#
    )
}

/// The rational circle of `scenes/examples.json` with its control points replaced.
fn circle_with(points: &str) -> String {
    scene_of(&format!(
        r#"{{ "degree": 2,
             "knots": [0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1],
             "points": {points},
             "weights": [1, 0.7071067811865476, 1, 0.7071067811865476, 1,
                         0.7071067811865476, 1, 0.7071067811865476, 1] }}"#
    ))
}

fn error_of(text: &str) -> String {
    match Scene::from_json_str(text) {
        Ok(_) => panic!("accepted: {text}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn a_ring_collapsed_to_one_point_is_refused_by_name() {
    let collapsed = circle_with(&format!("[{}]", ["[0.0, 0.09]"; 9].join(", ")));
    let msg = error_of(&collapsed);
    assert!(
        msg.starts_with("object 0 (\"ring\"), patch 0: points: "),
        "{msg}"
    );
    assert!(msg.contains("no length"), "{msg}");
    // The same ring, each point a few f32 steps (≤ 3 × 7.5 nm at 0.09 m) apart: collapsed
    // in f32 as well.
    let noisy = circle_with(
        "[[0.0, 0.09], [0.0, 0.09000001], [1e-9, 0.09], [0.0, 0.09000002], [0.0, 0.09],
          [2e-9, 0.09], [0.0, 0.08999999], [0.0, 0.09], [0.0, 0.09]]",
    );
    let msg = error_of(&noisy);
    assert!(msg.contains("no length"), "{msg}");
    // The uncollapsed circle loads (the file is otherwise valid).
    Scene::from_json_str(&circle_with(
        "[[0.03, 0.09], [0.03, 0.12], [0.0, 0.12], [-0.03, 0.12], [-0.03, 0.09],
          [-0.03, 0.06], [0.0, 0.06], [0.03, 0.06], [0.03, 0.09]]",
    ))
    .unwrap();
}

#[test]
fn a_collapsed_span_is_refused_by_its_knots() {
    // Points 3 and 4 moved onto point 2: the span [0.25, 0.5] (knots[4] to knots[5], points
    // 2 to 4) is the point (0, 0.12); the rest of the curve is still a loop.
    let msg = error_of(&circle_with(
        "[[0.03, 0.09], [0.03, 0.12], [0.0, 0.12], [0.0, 0.12], [0.0, 0.12],
          [-0.03, 0.06], [0.0, 0.06], [0.03, 0.06], [0.03, 0.09]]",
    ));
    assert!(
        msg.starts_with("object 0 (\"ring\"), patch 0: knots[4]"),
        "{msg}"
    );
    assert!(msg.contains("points[2] to points[4]"), "{msg}");
    // A polyline with two coincident consecutive points: its middle segment has no length.
    let msg = error_of(&scene_of(
        r#"{ "degree": 1, "knots": [0, 0, 0.3, 0.6, 1, 1],
             "points": [[-0.02, 0.1], [0.0, 0.08], [0.0, 0.08], [0.02, 0.1]] }"#,
    ));
    assert!(msg.contains("knots[2]"), "{msg}");
    assert!(msg.contains("points[1] to points[2]"), "{msg}");
}

/// A bilinear patch's JSON with corners `c`.
fn bilinear(c: [[f32; 3]; 4]) -> String {
    let p = |v: [f32; 3]| format!("[{}, {}, {}]", v[0], v[1], v[2]);
    scene_of(&format!(
        r#"{{ "degree": [1, 1], "knots": [[0, 0, 1, 1], [0, 0, 1, 1]],
             "points": [[{}, {}], [{}, {}]] }}"#,
        p(c[0]),
        p(c[1]),
        p(c[2]),
        p(c[3])
    ))
}

#[test]
fn a_surface_collapsed_to_a_line_or_a_point_is_refused() {
    let cases = [
        (
            "a point",
            [
                [0.0, 0.09, 0.0],
                [0.0, 0.09, 0.0],
                [0.0, 0.09, 0.0],
                [0.0, 0.09, 0.0],
            ],
        ),
        (
            "a line (two rows on one segment)",
            [
                [0.0, 0.08, 0.0],
                [0.0, 0.1, 0.0],
                [0.0, 0.08, 0.0],
                [0.0, 0.1, 0.0],
            ],
        ),
        (
            "a line (all four corners on it)",
            [
                [-0.02, 0.08, 0.0],
                [-0.01, 0.09, 0.0],
                [0.0, 0.1, 0.0],
                [0.01, 0.11, 0.0],
            ],
        ),
    ];
    for (what, corners) in cases {
        let msg = error_of(&bilinear(corners));
        assert!(
            msg.starts_with("object 0 (\"ring\"), patch 0: "),
            "{what}: {msg}"
        );
        assert!(msg.contains("no area"), "{what}: {msg}");
    }
    // A 1 cm square loads.
    Scene::from_json_str(&bilinear([
        [0.0, 0.08, 0.0],
        [0.0, 0.09, 0.0],
        [0.01, 0.08, 0.0],
        [0.01, 0.09, 0.0],
    ]))
    .unwrap();
}
