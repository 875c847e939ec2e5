//! Every class of invalid input is rejected with its own `NurbsError` variant (never a panic),
//! and the message names the offending field.
#![allow(clippy::unwrap_used)]

use glam::{Vec2, Vec3, Vec4};
use nurbs::{At, Curve, CurveBuf, Field, Knots, MAX_DEGREE, NurbsError, Surface, SurfaceBuf};
use proptest::prelude::*;

/// Degree 2, four points, U = {0,0,0,½,1,1,1}: valid.
const K: [f32; 7] = [0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0];

fn hom2(x: f32, y: f32, w: f32) -> Vec3 {
    Vec3::new(x * w, y * w, w)
}

fn pts4() -> [Vec3; 4] {
    [
        hom2(0.0, 0.0, 1.0),
        hom2(1.0, 1.0, 1.0),
        hom2(2.0, 0.0, 1.0),
        hom2(3.0, 1.0, 1.0),
    ]
}

fn curve_err(degree: usize, knots: &[f32], pts: &[Vec3]) -> NurbsError {
    Curve::<Vec2>::new(degree, knots, pts).unwrap_err()
}

/// The error's message contains every one of `needles`.
fn says(e: NurbsError, needles: &[&str]) {
    let msg = e.to_string();
    for n in needles {
        assert!(msg.contains(n), "message {msg:?} should mention {n:?}");
    }
}

#[test]
fn valid_baseline_is_accepted() {
    assert!(Curve::<Vec2>::new(2, &K, &pts4()).is_ok());
    // Interior multiplicity equal to the degree is allowed (C0 joint).
    let k = [0.0, 0.0, 0.0, 0.5, 0.5, 1.0, 1.0, 1.0];
    let p5: Vec<Vec3> = (0..5).map(|i| hom2(i as f32, 0.0, 1.0)).collect();
    assert!(Curve::<Vec2>::new(2, &k, &p5).is_ok());
    // Any domain, negative included.
    let k = [-3.0, -3.0, -3.0, 7.0, 7.0, 7.0];
    assert!(Curve::<Vec2>::new(2, &k, &pts4()[..3]).is_ok());
    // Highest degree.
    let mut k = vec![0.0; MAX_DEGREE + 1];
    k.extend(vec![1.0; MAX_DEGREE + 1]);
    let p: Vec<Vec3> = (0..=MAX_DEGREE).map(|i| hom2(i as f32, 0.0, 1.0)).collect();
    assert!(Curve::<Vec2>::new(MAX_DEGREE, &k, &p).is_ok());
}

#[test]
fn wrong_knot_count() {
    let e = curve_err(2, &K[..6], &pts4());
    assert_eq!(
        e,
        NurbsError::KnotCount {
            field: Field::Knots,
            expected: 7,
            found: 6
        }
    );
    says(e, &["knots", "7", "6"]);
    let mut long = K.to_vec();
    long.push(1.0);
    assert!(matches!(
        curve_err(2, &long, &pts4()),
        NurbsError::KnotCount {
            expected: 7,
            found: 8,
            ..
        }
    ));
    assert!(matches!(
        Knots::new(&[], 1, 2),
        Err(NurbsError::KnotCount { found: 0, .. })
    ));
}

#[test]
fn decreasing_knots() {
    let k = [0.0, 0.0, 0.0, 0.6, 0.4, 1.0, 1.0, 1.0];
    let p5 = [hom2(0.0, 0.0, 1.0); 5];
    let e = curve_err(2, &k, &p5);
    assert_eq!(
        e,
        NurbsError::KnotsDecreasing {
            field: Field::Knots,
            index: 4
        }
    );
    says(e, &["knots[4]"]);
    // Decreasing at the very end.
    let k = [0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 0.9];
    assert_eq!(
        curve_err(2, &k, &pts4()),
        NurbsError::KnotsDecreasing {
            field: Field::Knots,
            index: 6
        }
    );
}

#[test]
fn non_finite_knots() {
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let mut k = K;
        k[3] = bad;
        let e = curve_err(2, &k, &pts4());
        assert_eq!(
            e,
            NurbsError::KnotNotFinite {
                field: Field::Knots,
                index: 3
            }
        );
        says(e, &["knots[3]"]);
        // At the ends too (a NaN end would otherwise compare unequal, an infinite domain
        // would pass the clamping test).
        let mut k = K;
        k[6] = bad;
        assert!(matches!(
            curve_err(2, &k, &pts4()),
            NurbsError::KnotNotFinite { index: 6, .. }
        ));
        let k = [bad; 7];
        assert!(matches!(
            curve_err(2, &k, &pts4()),
            NurbsError::KnotNotFinite { index: 0, .. }
        ));
    }
}

#[test]
fn not_clamped() {
    for k in [
        [0.0, 0.0, 0.1, 0.5, 1.0, 1.0, 1.0],
        [0.0, 0.0, 0.0, 0.5, 0.9, 1.0, 1.0],
        [0.0, 0.1, 0.2, 0.5, 0.8, 0.9, 1.0],
    ] {
        let e = curve_err(2, &k, &pts4());
        assert_eq!(
            e,
            NurbsError::NotClamped {
                field: Field::Knots
            }
        );
        says(e, &["knots", "clamped"]);
    }
}

#[test]
fn empty_domain() {
    let e = curve_err(2, &[2.5; 7], &pts4());
    assert_eq!(
        e,
        NurbsError::EmptyDomain {
            field: Field::Knots
        }
    );
    says(e, &["knots", "empty"]);
}

#[test]
fn interior_multiplicity_above_degree() {
    let k = [0.0, 0.0, 0.0, 0.5, 0.5, 0.5, 1.0, 1.0, 1.0];
    let p6 = [hom2(0.0, 0.0, 1.0); 6];
    let e = curve_err(2, &k, &p6);
    assert_eq!(
        e,
        NurbsError::KnotMultiplicity {
            field: Field::Knots,
            index: 3,
            multiplicity: 3
        }
    );
    says(e, &["knots[3]", "3 times"]);
    // An end knot repeated p + 2 times: the first basis function would vanish identically.
    let k = [0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
    assert_eq!(
        curve_err(2, &k, &pts4()),
        NurbsError::KnotMultiplicity {
            field: Field::Knots,
            index: 0,
            multiplicity: 4
        }
    );
}

#[test]
fn degree_out_of_range() {
    let e = curve_err(0, &[0.0, 0.5, 1.0, 1.0], &pts4()[..3]);
    assert_eq!(
        e,
        NurbsError::Degree {
            field: Field::Degree,
            degree: 0
        }
    );
    says(e, &["degree", "0"]);
    let n = MAX_DEGREE + 2;
    let mut k = vec![0.0; MAX_DEGREE + 2];
    k.extend(vec![1.0; MAX_DEGREE + 2]);
    let p = vec![hom2(0.0, 0.0, 1.0); n];
    let e = curve_err(MAX_DEGREE + 1, &k, &p);
    assert_eq!(
        e,
        NurbsError::Degree {
            field: Field::Degree,
            degree: 8
        }
    );
    says(e, &["degree", "8", "7"]);
    assert!(matches!(
        Knots::new(&k, usize::MAX, n),
        Err(NurbsError::Degree { .. })
    ));
}

#[test]
fn too_few_points() {
    let e = curve_err(3, &[0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0], &pts4()[..3]);
    assert_eq!(
        e,
        NurbsError::TooFewPoints {
            field: Field::Points,
            found: 3,
            needed: 4
        }
    );
    says(e, &["points", "3", "4"]);
    assert!(matches!(
        curve_err(1, &[], &[]),
        NurbsError::TooFewPoints { found: 0, .. }
    ));
}

#[test]
fn bad_weights() {
    for w in [0.0, -0.0, -1.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let mut p = pts4();
        p[2] = Vec3::new(1.0, 1.0, w);
        let e = curve_err(2, &K, &p);
        assert!(
            matches!(e, NurbsError::Weight { at: At::I(2), value } if value.to_bits() == w.to_bits()),
            "w = {w}: {e:?}"
        );
        says(e, &["weights[2]"]);
    }
}

#[test]
fn non_finite_points() {
    for (x, y) in [
        (f32::NAN, 0.0),
        (0.0, f32::INFINITY),
        (f32::NEG_INFINITY, 1.0),
    ] {
        let mut p = pts4();
        p[1] = Vec3::new(x, y, 1.0);
        let e = curve_err(2, &K, &p);
        assert_eq!(e, NurbsError::PointNotFinite { at: At::I(1) });
        says(e, &["points[1]"]);
    }
    // Finite homogeneous coordinates whose Cartesian point overflows: w·x = 1e38, w = 1e-3.
    let mut p = pts4();
    p[3] = Vec3::new(1e38, 0.0, 1e-3);
    assert_eq!(
        curve_err(2, &K, &p),
        NurbsError::PointNotFinite { at: At::I(3) }
    );
    // Spatial curves check the z coordinate as well.
    let mut p3 = [Vec4::new(0.0, 0.0, 0.0, 1.0); 4];
    p3[0].z = f32::NAN;
    assert_eq!(
        Curve::<Vec3>::new(2, &K, &p3).unwrap_err(),
        NurbsError::PointNotFinite { at: At::I(0) }
    );
}

#[test]
fn curve_buf_from_cartesian() {
    let pts = [Vec2::ZERO, Vec2::X, Vec2::Y, Vec2::ONE];
    let e = CurveBuf::from_cartesian(2, K.to_vec(), &pts, Some(&[1.0, 1.0, 1.0])).unwrap_err();
    assert_eq!(
        e,
        NurbsError::WeightCount {
            expected: 4,
            found: 3
        }
    );
    says(e, &["weights", "3", "4"]);
    let e = CurveBuf::from_cartesian(2, K.to_vec(), &pts, Some(&[1.0, 1.0, 1.0, 1.0, 1.0]))
        .unwrap_err();
    assert!(matches!(e, NurbsError::WeightCount { found: 5, .. }));

    let e =
        CurveBuf::from_cartesian(2, K.to_vec(), &pts, Some(&[1.0, 1.0, 1.0, -2.0])).unwrap_err();
    assert_eq!(
        e,
        NurbsError::Weight {
            at: At::I(3),
            value: -2.0
        }
    );
    says(e, &["weights[3]", "-2"]);

    let mut bad = pts;
    bad[2].y = f32::NAN;
    let e = CurveBuf::from_cartesian(2, K.to_vec(), &bad, None).unwrap_err();
    assert_eq!(e, NurbsError::PointNotFinite { at: At::I(2) });

    // Knot errors come through as well.
    let e = CurveBuf::from_cartesian(2, K[..6].to_vec(), &pts, None).unwrap_err();
    assert!(matches!(e, NurbsError::KnotCount { .. }));

    // And the accepted curve stores (w·P, w).
    let c = CurveBuf::from_cartesian(2, K.to_vec(), &pts, Some(&[1.0, 2.0, 0.5, 1.0])).unwrap();
    assert_eq!(c.points()[1], Vec3::new(2.0, 0.0, 2.0));
    assert_eq!(c.degree(), 2);
    assert_eq!(c.knots(), &K);
    assert_eq!(c.view().control_point(2), Some((Vec2::Y, 0.5)));
}

/// Degree (1, 2), 2 × 3 net, U = {0,0,1,1}, V = {0,0,0,1,1,1}: valid.
const KU: [f32; 4] = [0.0, 0.0, 1.0, 1.0];
const KV: [f32; 6] = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0];

fn net() -> Vec<Vec4> {
    (0..6)
        .map(|k| Vec4::new((k / 3) as f32, (k % 3) as f32, 0.0, 1.0))
        .collect()
}

fn surf_err(
    degree: (usize, usize),
    ku: &[f32],
    kv: &[f32],
    count_v: usize,
    pts: &[Vec4],
) -> NurbsError {
    Surface::new(degree, (ku, kv), count_v, pts).unwrap_err()
}

#[test]
fn surface_errors_name_the_direction() {
    assert!(Surface::new((1, 2), (&KU, &KV), 3, &net()).is_ok());

    let e = surf_err((1, 2), &KU[..3], &KV, 3, &net());
    assert_eq!(
        e,
        NurbsError::KnotCount {
            field: Field::KnotsU,
            expected: 4,
            found: 3
        }
    );
    says(e, &["knots[0] (u)"]);

    let mut kv = KV;
    kv[2] = 0.5;
    let e = surf_err((1, 2), &KU, &kv, 3, &net());
    assert_eq!(
        e,
        NurbsError::NotClamped {
            field: Field::KnotsV
        }
    );
    says(e, &["knots[1] (v)"]);

    let mut ku = KU;
    ku[1] = f32::NAN;
    assert_eq!(
        surf_err((1, 2), &ku, &KV, 3, &net()),
        NurbsError::KnotNotFinite {
            field: Field::KnotsU,
            index: 1
        }
    );

    let e = surf_err((0, 2), &KU, &KV, 3, &net());
    assert_eq!(
        e,
        NurbsError::Degree {
            field: Field::DegreeU,
            degree: 0
        }
    );
    says(e, &["degree[0] (u)"]);
    let e = surf_err((1, 9), &KU, &KV, 3, &net());
    assert_eq!(
        e,
        NurbsError::Degree {
            field: Field::DegreeV,
            degree: 9
        }
    );
    says(e, &["degree[1] (v)"]);

    let kv = [0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
    assert!(matches!(
        surf_err((1, 2), &KU, &kv, 3, &net()),
        NurbsError::KnotCount {
            field: Field::KnotsV,
            ..
        }
    ));
    let kv = [0.0, 0.0, 0.0, 0.5, 0.5, 0.5, 1.0, 1.0, 1.0];
    let p12: Vec<Vec4> = (0..12).map(|_| Vec4::W).collect();
    assert!(matches!(
        surf_err((1, 2), &KU, &kv, 6, &p12),
        NurbsError::KnotMultiplicity {
            field: Field::KnotsV,
            index: 3,
            multiplicity: 3
        }
    ));
    let kv = [1.0; 6];
    assert_eq!(
        surf_err((1, 2), &KU, &kv, 3, &net()),
        NurbsError::EmptyDomain {
            field: Field::KnotsV
        }
    );
}

#[test]
fn surface_point_and_weight_errors_name_the_entry() {
    let mut p = net();
    p[5].w = 0.0; // i = 1, j = 2
    let e = surf_err((1, 2), &KU, &KV, 3, &p);
    assert_eq!(
        e,
        NurbsError::Weight {
            at: At::Ij(1, 2),
            value: 0.0
        }
    );
    says(e, &["weights[1][2]"]);

    let mut p = net();
    p[1].z = f32::INFINITY; // i = 0, j = 1
    let e = surf_err((1, 2), &KU, &KV, 3, &p);
    assert_eq!(e, NurbsError::PointNotFinite { at: At::Ij(0, 1) });
    says(e, &["points[0][1]"]);

    let mut p = net();
    p[3] = Vec4::new(1e38, 0.0, 0.0, 1e-3);
    assert_eq!(
        surf_err((1, 2), &KU, &KV, 3, &p),
        NurbsError::PointNotFinite { at: At::Ij(1, 0) }
    );
}

#[test]
fn surface_net_shape() {
    // count_v = 0 must not divide by zero.
    assert!(Surface::new((1, 2), (&KU, &KV), 0, &net()).is_err());
    assert!(Surface::new((1, 2), (&KU, &KV), 0, &[]).is_err());
    // Seven points do not make a 2 × 3 net.
    let mut p = net();
    p.push(Vec4::W);
    let e = surf_err((1, 2), &KU, &KV, 3, &p);
    assert!(matches!(
        e,
        NurbsError::RaggedNet {
            field: Field::Points,
            ..
        }
    ));
    says(e, &["points"]);
    // Too few rows for the u degree.
    let e = surf_err((1, 2), &KU, &KV, 3, &net()[..3]);
    assert!(
        matches!(e, NurbsError::TooFewPoints { found: 1, .. }),
        "{e:?}"
    );
    // A huge count_v is a validation error, not an overflow.
    assert!(Surface::new((1, 2), (&KU, &KV), usize::MAX, &net()).is_err());
}

#[test]
fn surface_buf_from_rows() {
    let rows = vec![
        vec![Vec3::ZERO, Vec3::Y, Vec3::Y * 2.0],
        vec![Vec3::X, Vec3::X + Vec3::Y],
    ];
    let e = SurfaceBuf::from_rows::<_, Vec<f32>>((1, 2), (KU.to_vec(), KV.to_vec()), &rows, None)
        .unwrap_err();
    assert_eq!(
        e,
        NurbsError::RaggedNet {
            field: Field::Points,
            row: 1,
            expected: 3,
            found: 2
        }
    );
    says(e, &["points[1]", "row 0 has 3"]);

    let rows = vec![
        vec![Vec3::ZERO, Vec3::Y, Vec3::Y * 2.0],
        vec![Vec3::X, Vec3::X + Vec3::Y, Vec3::ONE],
    ];
    let w = vec![vec![1.0, 1.0, 1.0], vec![1.0, 1.0]];
    let e = SurfaceBuf::from_rows((1, 2), (KU.to_vec(), KV.to_vec()), &rows, Some(&w)).unwrap_err();
    assert_eq!(
        e,
        NurbsError::RaggedNet {
            field: Field::Weights,
            row: 1,
            expected: 3,
            found: 2
        }
    );
    says(e, &["weights[1]"]);

    let w = vec![vec![1.0, 1.0, 1.0]];
    let e = SurfaceBuf::from_rows((1, 2), (KU.to_vec(), KV.to_vec()), &rows, Some(&w)).unwrap_err();
    assert_eq!(
        e,
        NurbsError::WeightCount {
            expected: 2,
            found: 1
        }
    );

    let w = vec![vec![1.0, 1.0, 1.0], vec![1.0, f32::NAN, 1.0]];
    let e = SurfaceBuf::from_rows((1, 2), (KU.to_vec(), KV.to_vec()), &rows, Some(&w)).unwrap_err();
    assert!(matches!(
        e,
        NurbsError::Weight {
            at: At::Ij(1, 1),
            ..
        }
    ));
    says(e, &["weights[1][1]"]);

    let mut bad = rows.clone();
    bad[0][2].x = f32::NAN;
    let e = SurfaceBuf::from_rows::<_, Vec<f32>>((1, 2), (KU.to_vec(), KV.to_vec()), &bad, None)
        .unwrap_err();
    assert_eq!(e, NurbsError::PointNotFinite { at: At::Ij(0, 2) });

    let empty: Vec<Vec<Vec3>> = Vec::new();
    assert!(
        SurfaceBuf::from_rows::<_, Vec<f32>>((1, 2), (KU.to_vec(), KV.to_vec()), &empty, None)
            .is_err()
    );

    let ok = SurfaceBuf::from_rows(
        (1, 2),
        (KU.to_vec(), KV.to_vec()),
        &rows,
        Some(&[[1.0, 2.0, 1.0], [1.0, 1.0, 0.5]]),
    )
    .unwrap();
    assert_eq!(ok.counts(), (2, 3));
    assert_eq!(ok.degree(), (1, 2));
    assert_eq!(ok.points()[1], Vec4::new(0.0, 2.0, 0.0, 2.0));
    assert_eq!(ok.knots(), (&KU[..], &KV[..]));
}

#[test]
fn dimension_message_names_the_point() {
    let e = NurbsError::Dimension {
        at: At::I(2),
        expected: 3,
        found: 2,
    };
    says(e, &["points[2]", "2 coordinates", "expected 3"]);
}

#[test]
fn field_names() {
    let names = [
        (Field::Degree, "degree"),
        (Field::DegreeU, "degree[0] (u)"),
        (Field::DegreeV, "degree[1] (v)"),
        (Field::Knots, "knots"),
        (Field::KnotsU, "knots[0] (u)"),
        (Field::KnotsV, "knots[1] (v)"),
        (Field::Points, "points"),
        (Field::Weights, "weights"),
    ];
    for (f, n) in names {
        assert_eq!(f.name(), n);
    }
}

// -------------------------------------------------------------------------------------------
// Garbage in, error (or a valid object) out, never a panic
// -------------------------------------------------------------------------------------------

/// Floats of every class: NaN, ±inf, ±0, subnormals, huge, and small integers (so that
/// repeats, ties and sorted runs happen often enough to get past the first checks).
fn any_float() -> impl Strategy<Value = f32> {
    prop_oneof![
        3 => (-3i8..=3).prop_map(f32::from),
        2 => -10.0f32..10.0,
        1 => any::<f32>(),
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(f32::MIN_POSITIVE / 4.0),
        1 => Just(f32::MAX),
    ]
}

/// Knot vectors: garbage, or sorted garbage (more likely to pass the early checks).
fn garbage_knots() -> impl Strategy<Value = Vec<f32>> {
    prop_oneof![
        proptest::collection::vec(any_float(), 0..24),
        proptest::collection::vec(any_float(), 0..24).prop_map(|mut v| {
            v.sort_by(f32::total_cmp);
            v
        }),
    ]
}

fn any_count() -> impl Strategy<Value = usize> {
    prop_oneof![
        4 => 0usize..30,
        1 => any::<usize>(),
        1 => Just(usize::MAX),
    ]
}

fn garbage_params() -> impl Strategy<Value = Vec<f32>> {
    proptest::collection::vec(any_float(), 4)
}

proptest! {
    #![proptest_config(testkit::config())]

    #[test]
    fn knots_new_never_panics(
        knots in garbage_knots(), degree in prop_oneof![0usize..12, any::<usize>()], n in any_count(),
        us in garbage_params(),
    ) {
        if let Ok(k) = Knots::new(&knots, degree, n) {
            // A valid knot vector keeps its promises.
            prop_assert!((1..=MAX_DEGREE).contains(&k.degree()));
            let (a, b) = k.domain();
            prop_assert!(a < b);
            for u in us {
                let s = k.find_span(u);
                prop_assert!(s >= degree && s < n);
                prop_assert!(k.contains(k.clamp(u)));
            }
        }
    }

    #[test]
    fn curve_new_never_panics(
        degree in 0usize..10, knots in garbage_knots(),
        pts in proptest::collection::vec([any_float(), any_float(), any_float(), any_float()], 0..14),
        us in garbage_params(),
    ) {
        let h2: Vec<Vec3> = pts.iter().map(|c| Vec3::new(c[0], c[1], c[3])).collect();
        let h3: Vec<Vec4> = pts.iter().map(|&c| Vec4::from_array(c)).collect();
        if let Ok(c) = Curve::<Vec2>::new(degree, &knots, &h2) {
            for &u in &us {
                let _ = (c.point(u), c.derivs(u, 2), c.frame(u), c.bounding_box(), c.is_closed(0.1));
            }
        }
        if let Ok(c) = Curve::<Vec3>::new(degree, &knots, &h3) {
            for &u in &us {
                let _ = (c.point(u), c.derivs(u, 2), c.frame(u), c.bounding_box());
            }
        }
        let cart: Vec<Vec2> = pts.iter().map(|c| Vec2::new(c[0], c[1])).collect();
        let w: Vec<f32> = pts.iter().map(|c| c[3]).collect();
        let _ = CurveBuf::from_cartesian(degree, knots.clone(), &cart, Some(&w[..w.len().saturating_sub(us.len() % 2)]));
        let _ = CurveBuf::from_cartesian(degree, knots, &cart, None);
    }

    #[test]
    fn surface_new_never_panics(
        degree in (0usize..10, 0usize..10), ku in garbage_knots(), kv in garbage_knots(),
        count_v in any_count(),
        pts in proptest::collection::vec([any_float(), any_float(), any_float(), any_float()], 0..40),
        us in garbage_params(),
    ) {
        let h: Vec<Vec4> = pts.iter().map(|&c| Vec4::from_array(c)).collect();
        if let Ok(s) = Surface::new(degree, (&ku, &kv), count_v, &h) {
            for w in us.windows(2) {
                let _ = (s.point(w[0], w[1]), s.derivs(w[0], w[1], 2), s.normal(w[0], w[1]));
            }
        }
    }

    #[test]
    fn surface_from_rows_never_panics(
        degree in (0usize..5, 0usize..5), ku in garbage_knots(), kv in garbage_knots(),
        rows in proptest::collection::vec(proptest::collection::vec([any_float(), any_float(), any_float()], 0..6), 0..6),
        weights in proptest::option::of(proptest::collection::vec(proptest::collection::vec(any_float(), 0..6), 0..6)),
    ) {
        let rows: Vec<Vec<Vec3>> = rows.into_iter().map(|r| r.into_iter().map(Vec3::from_array).collect()).collect();
        if let Ok(s) = SurfaceBuf::from_rows(degree, (ku, kv), &rows, weights.as_deref()) {
            let _ = s.view().normal(0.5, 0.5);
        }
    }
}

/// Spans far shorter than the domain would overflow the basis derivatives (they scale with
/// 1/span^k); validation rejects them with the knot's index.
#[test]
fn tiny_knot_span_is_rejected() {
    let knots = [0.0f32, 0.0, 1e-39, 1.0, 1.0];
    let pts = [
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(2.0, 1.0, 1.0),
    ];
    let err = nurbs::Curve::<nurbs::Vec2>::new(1, &knots, &pts).unwrap_err();
    assert_eq!(
        err,
        NurbsError::SpanTooShort {
            field: nurbs::Field::Knots,
            index: 2
        }
    );
    assert!(err.to_string().contains("knots[2]"));
    // A span of 1e-4 of the domain is fine and evaluates to finite values everywhere.
    let knots = [0.0f32, 0.0, 1e-4, 1.0, 1.0];
    let c = nurbs::Curve::<nurbs::Vec2>::new(1, &knots, &pts).unwrap();
    for u in [0.0, 5e-5, 1e-4, 0.5, 1.0] {
        let d = c.derivs(u, 2);
        assert!(d.point.is_finite() && d.du.is_finite() && d.duu.is_finite());
    }
}

/// A surface with too few rows or columns names the direction.
#[test]
fn too_few_points_names_the_direction() {
    let row = vec![Vec3::ZERO; 4];
    let rows = vec![row.clone(), row];
    let k4 = vec![0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0];
    let err = nurbs::SurfaceBuf::from_rows::<_, &[f32]>((3, 3), (k4.clone(), k4), &rows, None)
        .unwrap_err();
    assert!(err.to_string().contains("along u"), "{err}");
}

/// Weights too small for f32 are refused by the one check every loader goes through
/// (`Curve::new` for the wire scene, `CurveBuf::from_cartesian` for JSON), with a message that
/// says why. Before, 1e-20 beside weights of 1 was accepted and its second derivative
/// overflowed; the wire's 9.2e-41 (subnormal) was accepted and evaluated to NaN.
#[test]
fn weights_too_small_for_f32_are_refused_with_the_reason() {
    use nurbs::MIN_WEIGHT_RATIO;
    for w in [1e-20f32, 9.2e-41, 0.9e-6] {
        let mut p = pts4();
        p[2] = hom2(2.0, 0.0, w);
        let e = curve_err(2, &K, &p);
        assert_eq!(
            e,
            NurbsError::WeightTooSmall {
                at: At::I(2),
                value: w,
                largest: 1.0
            },
            "w = {w:e}"
        );
        let why = if w.is_normal() {
            "significant digits"
        } else {
            "subnormal"
        };
        says(e, &["weights[2]", why]);
        let e = CurveBuf::<Vec2>::from_cartesian(
            2,
            K.to_vec(),
            &[Vec2::ZERO, Vec2::ONE, Vec2::X, Vec2::Y],
            Some(&[1.0, 1.0, w, 1.0]),
        )
        .unwrap_err();
        assert!(matches!(e, NurbsError::WeightTooSmall { at: At::I(2), .. }));
    }
    // The bound is relative: a weight of 1e-20 is fine when it is the patch's largest, and
    // scaling all weights by one factor gives the same curve (projective invariance, Piegl &
    // Tiller §4.2), down to the rounding of one f32 product per coordinate.
    let unit = CurveBuf::<Vec2>::from_cartesian(
        2,
        K.to_vec(),
        &[Vec2::ZERO, Vec2::ONE, Vec2::X, Vec2::Y],
        Some(&[1.0, 0.5, 2.0, 1.0]),
    )
    .unwrap();
    let scaled = CurveBuf::<Vec2>::from_cartesian(
        2,
        K.to_vec(),
        &[Vec2::ZERO, Vec2::ONE, Vec2::X, Vec2::Y],
        Some(&[1e-20, 0.5e-20, 2e-20, 1e-20]),
    )
    .unwrap();
    for k in 0..=20 {
        let u = k as f32 / 20.0;
        let (a, b) = (unit.view().derivs(u, 2), scaled.view().derivs(u, 2));
        // Coordinates are O(1) and derivatives O(10) here; a few ulps of that.
        assert!((a.point - b.point).length() < 1e-5, "u = {u}");
        assert!((a.duu - b.duu).length() < 1e-3, "u = {u}");
    }
    // At the bound itself (ratio exactly MIN_WEIGHT_RATIO) everything evaluates finite, at
    // the knots and between them.
    let mut p = pts4();
    p[2] = hom2(2.0, 0.0, MIN_WEIGHT_RATIO);
    let c = Curve::<Vec2>::new(2, &K, &p).unwrap();
    for k in 0..=1000 {
        let d = c.derivs(k as f32 / 1000.0, 2);
        assert!(d.point.is_finite() && d.du.is_finite() && d.duu.is_finite());
    }
    // Surfaces follow the same rule.
    let mut net = net();
    net[4] = Vec4::new(0.0, 0.0, 0.0, 1e-20);
    assert!(matches!(
        surf_err((1, 2), &KU, &KV, 3, &net),
        NurbsError::WeightTooSmall {
            at: At::Ij(1, 1),
            ..
        }
    ));
}

/// Coordinates beyond `MAX_COORDINATE` are refused (3e38 used to evaluate to infinite
/// derivatives); up to it they evaluate finite.
#[test]
fn coordinates_beyond_the_bound_are_refused() {
    use nurbs::MAX_COORDINATE;
    let mut p = pts4();
    p[1] = hom2(3e38, 0.0, 1.0);
    let e = curve_err(2, &K, &p);
    assert_eq!(
        e,
        NurbsError::PointOutOfRange {
            at: At::I(1),
            value: 3e38
        }
    );
    says(e, &["points[1]", "3e38"]);
    let mut p = pts4();
    p[1] = hom2(-MAX_COORDINATE, MAX_COORDINATE, 1.0);
    p[3] = hom2(MAX_COORDINATE, -MAX_COORDINATE, 1.0);
    let c = Curve::<Vec2>::new(2, &K, &p).unwrap();
    for k in 0..=100 {
        let d = c.derivs(k as f32 / 100.0, 2);
        assert!(d.point.is_finite() && d.du.is_finite() && d.duu.is_finite());
    }
    let e = SurfaceBuf::from_rows::<_, &[f32]>(
        (1, 1),
        (vec![0.0, 0.0, 1.0, 1.0], vec![0.0, 0.0, 1.0, 1.0]),
        &[[Vec3::ZERO, Vec3::X], [Vec3::Y, Vec3::new(0.0, 0.0, -2e6)]],
        None,
    )
    .unwrap_err();
    assert_eq!(
        e,
        NurbsError::PointOutOfRange {
            at: At::Ij(1, 1),
            value: 2e6
        }
    );
}

// -------------------------------------------------------------------------------------------
// Degenerate geometry (`nurbs::MIN_EXTENT`, 1 µm in a scene)
// -------------------------------------------------------------------------------------------

/// The exact rational circle of radius 2 cm about (0, 0.09) (9 points, degree 2, four
/// quarter-circle spans) with its control points given as `f(i, P_i)`.
fn ring_with(f: impl Fn(usize, Vec2) -> Vec2) -> Result<CurveBuf<Vec2>, NurbsError> {
    let ring = nurbs::construct::circle(Vec2::new(0.0, 0.09), 0.02).unwrap();
    let points: Vec<Vec3> = ring
        .points()
        .iter()
        .enumerate()
        .map(|(i, &h)| {
            let p = f(i, h.truncate() / h.z);
            p.extend(1.0) * h.z
        })
        .collect();
    CurveBuf::new(2, ring.knots().to_vec(), points)
}

#[test]
fn a_curve_of_no_length_is_refused() {
    let centre = Vec2::new(0.0, 0.09);
    // The measured case: all nine points at (0, 0.09). Stored as (w·P, w) with w = √½ and
    // divided back, they land up to an f32 step (2⁻²⁷ m ≈ 7.5 nm at 0.09 m) apart: why the
    // check needs a tolerance, not equality.
    let e = ring_with(|_, _| centre).unwrap_err();
    assert!(
        matches!(e, NurbsError::ZeroLength { extent } if extent <= 7.5e-9),
        "{e:?}"
    );
    says(e, &["points", "no length", "1e-6"]);
    // Collapsed in f32: each point up to 3 f32 steps off (2⁻²⁷ m ≈ 7.5 nm at 0.09 m) along y
    // and 1 nm along x, within 3 × 7.5 + 1 = 23.4 nm of points[0]: refused all the same.
    let step = |k: u32| f32::from_bits(centre.y.to_bits() + k);
    let e = ring_with(|i, _| Vec2::new(1e-9 * (i % 2) as f32, step(i as u32 % 4))).unwrap_err();
    let NurbsError::ZeroLength { extent } = e else {
        panic!("{e:?}")
    };
    assert!(extent > 0.0 && extent <= 2.4e-8, "{extent}");
    // The same for a spatial curve (a wire), and for a line whose two ends are 0.5 µm apart,
    // while ends 2 µm apart make a line.
    let wire = nurbs::construct::line(Vec3::new(0.0, 0.09, 0.0), Vec3::new(0.0, 0.09, 5e-7));
    assert!(
        matches!(wire, Err(NurbsError::ZeroLength { extent }) if (extent - 5e-7).abs() < 1e-12),
        "{wire:?}"
    );
    assert!(nurbs::construct::line(Vec2::new(0.0, 0.09), Vec2::new(2e-6, 0.09)).is_ok());
    // The ring itself is valid.
    assert!(ring_with(|_, p| p).is_ok());
}

#[test]
fn a_span_collapsed_to_a_point_is_refused_by_its_knots() {
    // Points 3 and 4 onto point 2: the span knots[4] to knots[5] = [0.25, 0.5], whose points
    // are 2 to 4 (P&T: span i uses points i − p ..= i), is the point (0, 0.11).
    let e = ring_with(|i, p| {
        if (2..=4).contains(&i) {
            Vec2::new(0.0, 0.11)
        } else {
            p
        }
    })
    .unwrap_err();
    assert!(
        matches!(
            e,
            NurbsError::CollapsedSpan { index: 4, first: 2, last: 4, extent } if extent <= 7.5e-9
        ),
        "{e:?}"
    );
    says(
        e,
        &[
            "knots[4] to knots[5]",
            "points[2] to points[4]",
            "no length",
        ],
    );
    // A polyline with a repeated point: the middle segment (knots[2] to knots[3]).
    let k = [0.0, 0.0, 0.3, 0.6, 1.0, 1.0];
    let p = [
        hom2(-0.02, 0.1, 1.0),
        hom2(0.0, 0.08, 1.0),
        hom2(0.0, 0.08, 1.0),
        hom2(0.02, 0.1, 1.0),
    ];
    assert_eq!(
        curve_err(1, &k, &p),
        NurbsError::CollapsedSpan {
            index: 2,
            first: 1,
            last: 2,
            extent: 0.0
        }
    );
    // A repeated point of a cubic is a cusp, not a collapsed span: every span keeps three
    // distinct points of its four.
    let k = [0.0, 0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0, 1.0];
    let p = [
        hom2(-0.02, 0.1, 1.0),
        hom2(-0.01, 0.08, 1.0),
        hom2(0.0, 0.08, 1.0),
        hom2(0.0, 0.08, 1.0),
        hom2(0.02, 0.1, 1.0),
    ];
    assert!(Curve::<Vec2>::new(3, &k, &p).is_ok());
    // A zero-length span in parameter (a repeated knot) is no span at all.
    let k = [0.0, 0.0, 0.0, 0.5, 0.5, 1.0, 1.0, 1.0];
    let p: Vec<Vec3> = (0..5).map(|i| hom2(0.01 * i as f32, 0.09, 1.0)).collect();
    assert!(Curve::<Vec2>::new(2, &k, &p).is_ok());
}

/// A degree (1, 2) surface of two cells along v (V = {0,0,0,½,1,1,1}), rows `i` = 0, 1 at
/// x = 0 and 1 cm, `f(i, j)` the point (j along v).
fn two_cells(f: impl Fn(usize, usize) -> Vec3) -> Result<Surface<'static>, NurbsError> {
    const KV2: [f32; 7] = [0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0];
    let pts: Vec<Vec4> = (0..8).map(|k| f(k / 4, k % 4).extend(1.0)).collect();
    Surface::new((1, 2), (&KU, &KV2), 4, Vec::leak(pts))
}

#[test]
fn a_surface_of_no_area_or_with_a_collapsed_cell_is_refused() {
    let flat = |i: usize, j: usize| Vec3::new(0.01 * i as f32, 0.08 + 0.01 * j as f32, 0.0);
    assert!(two_cells(flat).is_ok());
    // Collapsed to a point, to a line (both rows on one segment), onto a curve (both rows the
    // same parabola-like arc: no two points on a line, the area is zero all the same).
    type Net = Box<dyn Fn(usize, usize) -> Vec3>;
    let cases: [(&str, Net); 3] = [
        ("a point", Box::new(|_, _| Vec3::new(0.0, 0.09, 0.0))),
        ("a line", Box::new(move |_, j| flat(0, j))),
        (
            "a curve",
            Box::new(|_, j: usize| Vec3::new(0.01 * j as f32, 0.08, 0.001 * (j * j) as f32)),
        ),
    ];
    for (what, f) in cases {
        let e = two_cells(f).unwrap_err();
        assert!(matches!(e, NurbsError::ZeroArea { .. }), "{what}: {e:?}");
        says(e, &["points", "no area"]);
    }
    // One cell collapsed: the v-span [½, 1] (knots[1] (v)[3], points j = 1 to 3) of both rows
    // onto one line; the other cell keeps its point (1, 0).
    let e = two_cells(|i, j| if j >= 1 { flat(0, j) } else { flat(i, j) }).unwrap_err();
    assert!(
        matches!(e, NurbsError::CollapsedCell { span: (1, 3), width } if width < 1e-8),
        "{e:?}"
    );
    says(
        e,
        &[
            "knots[0] (u)[1] to [2] by knots[1] (v)[3] to [4]",
            "no area",
        ],
    );
    // A cell 2 µm wide has area; 0.5 µm does not. Mean width of the 1 cm × w strip: its area
    // over its diagonal, w · 1 cm / √(1 cm² + w²) ≈ w.
    for (w, ok) in [(2e-6f32, true), (5e-7, false)] {
        let strip = two_cells(|i, j| Vec3::new(w * i as f32, 0.08 + 0.005 * j as f32, 0.0));
        assert_eq!(strip.is_ok(), ok, "{w}: {strip:?}");
    }
}

#[test]
fn collapsed_sides_are_legitimate() {
    // A sphere's poles and a disk's centre (a side collapsed to a point) and a cone's apex:
    // the cells beside them keep their area.
    let sphere = nurbs::construct::sphere(Vec3::new(0.0, 0.09, 0.0), 0.02);
    assert!(sphere.is_ok(), "{sphere:?}");
    let sphere = nurbs::construct::sphere(Vec3::ZERO, 1e-4);
    assert!(sphere.is_ok(), "a 0.1 mm sphere: {sphere:?}");
    let radius = nurbs::construct::line(Vec3::ZERO, Vec3::new(0.02, 0.0, 0.0)).unwrap();
    let disk = nurbs::construct::revolve(&radius, Vec3::ZERO, Vec3::Z, std::f32::consts::TAU);
    assert!(disk.is_ok(), "{disk:?}");
    let slant = nurbs::construct::line(Vec3::ZERO, Vec3::new(0.02, 0.0, 0.03)).unwrap();
    let cone = nurbs::construct::revolve(&slant, Vec3::ZERO, Vec3::Z, std::f32::consts::PI);
    assert!(cone.is_ok(), "{cone:?}");
    // Every torus and cylinder of the constructors too.
    assert!(nurbs::construct::torus(Vec3::ZERO, 0.03, 0.01).is_ok());
    assert!(nurbs::construct::cylinder(Vec3::ZERO, Vec3::Z, 0.01, 0.02).is_ok());
}
