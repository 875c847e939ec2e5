//! Multi-patch 2-D objects: the feature state machine against brute-force nearest features,
//! on the thesis's three-curve object (Fig. 2.1.4) and across corners, both directions.
#![allow(clippy::unwrap_used)]

use nurbs::{CurveBuf, Vec2, construct};
use tracker::{
    Chain, ChainError, ChainTracker, Contact, Feature, Penalty, TrackerConfig, VertexKind,
};

const T: f32 = 1e-3;

/// A curved triangle like the thesis's Fig. 2.1.4: three cubic Bézier curves (four control
/// points each, corners shared), counter-clockwise, inside the pantograph workspace. `bulge`
/// pushes the inner control points outward (0 gives straight sides).
fn three_curves(bulge: f32) -> Vec<CurveBuf<Vec2>> {
    let corners = [
        Vec2::new(-0.03, 0.07),
        Vec2::new(0.03, 0.07),
        Vec2::new(0.0, 0.12),
    ];
    let centroid = (corners[0] + corners[1] + corners[2]) / 3.0;
    (0..3)
        .map(|i| {
            let a = corners[i];
            let b = corners[(i + 1) % 3];
            let mid = (a + b) * 0.5;
            let out = (mid - centroid).normalize() * bulge;
            let p1 = a + (b - a) / 3.0 + out;
            let p2 = a + (b - a) * (2.0 / 3.0) + out;
            construct::bezier_curve(&[a, p1, p2, b]).unwrap()
        })
        .collect()
}

/// The nearest feature by brute force: dense sampling of every curve; a closest point within
/// `end_tol` of a curve end counts as that vertex.
fn nearest_feature(curves: &[CurveBuf<Vec2>], x: Vec2) -> Feature {
    let n = curves.len();
    let mut best = (f32::INFINITY, Feature::Patch(0));
    for (i, c) in curves.iter().enumerate() {
        let v = c.view();
        for s in 0..=4000 {
            let u = s as f32 / 4000.0;
            let d = (v.point(u) - x).length_squared();
            if d < best.0 {
                let f = if s == 0 {
                    Feature::Vertex(i as u16)
                } else if s == 4000 {
                    Feature::Vertex(((i + 1) % n) as u16)
                } else {
                    Feature::Patch(i as u16)
                };
                best = (d, f);
            }
        }
    }
    best.1
}

fn run_path(curves: &[CurveBuf<Vec2>], path: &[Vec2]) -> Vec<(Vec2, Contact<Vec2>)> {
    let views: Vec<_> = curves.iter().map(|c| c.view()).collect();
    let chain = Chain::new(&views).unwrap();
    let mut tr = ChainTracker::new(&chain, path[0], TrackerConfig::default());
    path.iter()
        .map(|&x| (x, tr.update(&chain, x, T, true)))
        .collect()
}

/// Collapses repeats: the sequence of distinct features visited.
fn sequence(features: impl Iterator<Item = Feature>) -> Vec<Feature> {
    let mut out: Vec<Feature> = Vec::new();
    for f in features {
        if out.last() != Some(&f) {
            out.push(f);
        }
    }
    out
}

/// A circle of `radius` around the object's centroid, `steps` ticks, counter-clockwise or
/// clockwise.
fn orbit(radius: f32, steps: usize, ccw: bool) -> Vec<Vec2> {
    let c = Vec2::new(0.0, 0.07 + 0.05 / 3.0);
    (0..=steps)
        .map(|k| {
            let s = k as f32 / steps as f32;
            // Start below edge 0 (angle −90°).
            let a = -std::f32::consts::FRAC_PI_2
                + if ccw { 1.0 } else { -1.0 } * s * std::f32::consts::TAU;
            c + Vec2::new(a.cos(), a.sin()) * radius
        })
        .collect()
}

#[test]
fn orbit_outside_visits_every_external_region_in_order_both_ways() {
    let curves = three_curves(0.004);
    // 0.1 m orbit at 2000 ticks: 0.3 mm per tick, 0.3 m/s.
    for ccw in [true, false] {
        let path = orbit(0.05, 2000, ccw);
        let run = run_path(&curves, &path);
        let seq = sequence(run.iter().map(|(_, c)| c.feature));
        let expected: Vec<Feature> = if ccw {
            vec![
                Feature::Patch(0),
                Feature::Vertex(1),
                Feature::Patch(1),
                Feature::Vertex(2),
                Feature::Patch(2),
                Feature::Vertex(0),
                Feature::Patch(0),
            ]
        } else {
            vec![
                Feature::Patch(0),
                Feature::Vertex(0),
                Feature::Patch(2),
                Feature::Vertex(2),
                Feature::Patch(1),
                Feature::Vertex(1),
                Feature::Patch(0),
            ]
        };
        assert_eq!(seq, expected, "ccw = {ccw}");
        // Every tick agrees with the brute-force nearest feature, but for ticks right at a
        // region boundary (the tracker runs one tick behind the HIP there).
        let mismatches = run
            .iter()
            .filter(|(x, c)| nearest_feature(&curves, *x) != c.feature)
            .count();
        assert!(
            mismatches <= 6,
            "{mismatches} ticks disagree with the nearest feature"
        );
        assert!(run.iter().all(|(_, c)| !c.inside && c.depth < 0.0));
    }
}

#[test]
fn external_contact_geometry_matches_brute_force_distance() {
    let curves = three_curves(0.004);
    let path = orbit(0.04, 1500, true);
    let run = run_path(&curves, &path);
    for (x, c) in run.iter().skip(20) {
        // Brute-force distance to the object.
        let mut best = f32::INFINITY;
        for cv in &curves {
            let v = cv.view();
            for s in 0..=4000 {
                best = best.min((v.point(s as f32 / 4000.0) - *x).length());
            }
        }
        // Sampling at 1/4000 of a ~6 cm curve is within ~1e-8 m of the true distance.
        assert!(
            (-c.depth - best).abs() < 2e-6,
            "x = {x:?}: depth {} vs distance {best}",
            c.depth
        );
        assert!((c.normal.length() - 1.0).abs() < 1e-5);
        // The normal points from the closest point to the HIP.
        assert!((*x - c.point).normalize().dot(c.normal) > 0.9999);
    }
}

/// A HIP pressed 2 mm into the object slides around inside it, parallel to the boundary: the
/// internal regions switch curve to curve at the corner bisectors, never through a vertex.
#[test]
fn inside_path_switches_at_bisectors_both_ways() {
    let curves = three_curves(0.0);
    // Straight sides: the inset triangle 2 mm inside, walked along its perimeter.
    let a = Vec2::new(-0.03, 0.07);
    let b = Vec2::new(0.03, 0.07);
    let c = Vec2::new(0.0, 0.12);
    let centroid = (a + b + c) / 3.0;
    let inset = |p: Vec2| centroid + (p - centroid) * 0.8;
    let corners = [inset(a), inset(b), inset(c)];
    for forward in [true, false] {
        let mut path = Vec::new();
        // Start in the middle of side 0 (bottom).
        let start = (corners[0] + corners[1]) * 0.5;
        let pts: Vec<Vec2> = if forward {
            vec![start, corners[1], corners[2], corners[0], start]
        } else {
            vec![start, corners[0], corners[2], corners[1], start]
        };

        for w in pts.windows(2) {
            for k in 0..600 {
                path.push(w[0] + (w[1] - w[0]) * (k as f32 / 600.0));
            }
        }
        let run = run_path(&curves, &path);
        let seq = sequence(run.iter().map(|(_, c)| c.feature));
        let expected = if forward {
            vec![
                Feature::Patch(0),
                Feature::Patch(1),
                Feature::Patch(2),
                Feature::Patch(0),
            ]
        } else {
            vec![
                Feature::Patch(0),
                Feature::Patch(2),
                Feature::Patch(1),
                Feature::Patch(0),
            ]
        };
        assert_eq!(seq, expected, "forward = {forward}");
        assert!(run.iter().all(|(_, c)| c.inside && c.depth > 0.0));
        // Straight sides: the FSM's choice is exactly the nearest side (ties at the bisector
        // aside).
        let mismatches = run
            .iter()
            .filter(|(x, c)| nearest_feature(&curves, *x) != c.feature)
            .count();
        // A switch across a corner is taken on the tick after it is decided (no tick evaluates
        // two curves): one tick late at each of the three, and as many ties at the bisectors.
        assert!(
            mismatches <= 6,
            "{mismatches} ticks disagree with the nearest feature"
        );
    }
}

/// Pressing into a convex corner from its external wedge: vertex contact outside, then the
/// curve whose side of the bisector the HIP ends up on once inside.
#[test]
fn corner_approach_from_outside() {
    let curves = three_curves(0.004);
    let corner = Vec2::new(0.03, 0.07);
    // From 1 cm out along the corner's outer bisector to 2 mm inside, slightly toward edge 0.
    let out_dir = Vec2::new(1.0, -0.6).normalize();
    let start = corner + out_dir * 0.01;
    let end = corner + Vec2::new(-0.004, 0.0015);
    let path: Vec<Vec2> = (0..=1000)
        .map(|k| start + (end - start) * (k as f32 / 1000.0))
        .collect();
    let run = run_path(&curves, &path);
    let seq = sequence(run.iter().map(|(_, c)| c.feature));
    assert_eq!(seq.first(), Some(&Feature::Vertex(1)));
    assert_eq!(seq.last(), Some(&nearest_feature(&curves, end)));
    assert!(run.last().unwrap().1.inside);
}

/// Crossing the join between two G¹ arcs of a circle inside the object: the penalty force
/// changes by no more than the stiffness times the HIP step (plus rounding), because depth
/// and normal are continuous there (the same closest point and normal from both sides).
#[test]
fn no_force_jump_across_smooth_join() {
    let c = Vec2::new(0.0, 0.09);
    let r = 0.03;
    let left = construct::arc(c, Vec2::X * r, Vec2::Y * r, 0.0, std::f32::consts::PI).unwrap();
    let right = construct::arc(
        c,
        Vec2::X * r,
        Vec2::Y * r,
        std::f32::consts::PI,
        std::f32::consts::PI,
    )
    .unwrap();
    let curves = [left, right];
    let views: Vec<_> = curves.iter().map(|c| c.view()).collect();
    let chain = Chain::new(&views).unwrap();
    assert!(chain.is_closed());
    assert!(
        chain
            .vertices()
            .iter()
            .all(|v| v.kind == VertexKind::Smooth)
    );
    let k = 1000.0;
    let pen = Penalty {
        stiffness_n_per_m: k,
        damping_ns_per_m: 0.0,
    };
    // 2 mm deep, sweeping across the join at angle π (and 0 on the way back).
    for (a0, a1) in [(2.8f32, 3.5f32), (0.4, -0.4)] {
        let path: Vec<Vec2> = (0..=700)
            .map(|i| {
                let a = a0 + (a1 - a0) * i as f32 / 700.0;
                c + Vec2::new(a.cos(), a.sin()) * (r - 0.002)
            })
            .collect();
        let mut tr = ChainTracker::new(&chain, path[0], TrackerConfig::default());
        let mut prev: Option<(Vec2, Vec2)> = None;
        let mut patches = Vec::new();
        for &x in &path {
            let ct = tr.update(&chain, x, T, true);
            patches.push(ct.feature);
            let f = ct.penalty_force(&pen, Vec2::ZERO);
            // Exact force for a circle: k (r − |x − c|) along (x − c)/|x − c|.
            let exact = (x - c).normalize() * (k * (r - (x - c).length()));
            assert!(
                (f - exact).length() < 1e-3,
                "force {f:?} vs exact {exact:?}"
            );
            if let Some((fp, xp)) = prev {
                assert!((f - fp).length() <= k * (x - xp).length() + 1e-3);
            }
            prev = Some((f, x));
        }
        assert_eq!(
            sequence(patches.into_iter()).len(),
            2,
            "crossed the join once"
        );
    }
}

#[test]
fn chain_validation_errors() {
    let a = construct::line(Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0)).unwrap();
    let b = construct::line(Vec2::new(1.0, 0.1), Vec2::new(0.0, 0.0)).unwrap();
    let views = [a.view(), b.view()];
    assert!(matches!(
        Chain::new(&views),
        Err(ChainError::Gap { curve: 1, .. })
    ));
    assert!(matches!(Chain::new(&[]), Err(ChainError::Empty)));
    let mut cw = three_curves(0.0);
    cw.reverse();
    let cw: Vec<CurveBuf<Vec2>> = cw
        .iter()
        .map(|c| {
            let pts: Vec<Vec2> = (0..4)
                .rev()
                .map(|i| c.view().control_point(i).unwrap().0)
                .collect();
            construct::bezier_curve(&pts).unwrap()
        })
        .collect();
    let views: Vec<_> = cw.iter().map(|c| c.view()).collect();
    assert_eq!(Chain::new(&views).unwrap_err(), ChainError::Clockwise);
}

/// Each curve of `curves` with its inner control points (all but the ends) moved by `by`.
fn inner_moved(curves: &[CurveBuf<Vec2>], by: Vec2) -> Vec<CurveBuf<Vec2>> {
    curves
        .iter()
        .map(|c| {
            let n = c.points().len();
            let mut moved = c.clone();
            for i in 1..n - 1 {
                let (p, _) = c.view().control_point(i).unwrap();
                moved = moved.with_point(i, p + by).unwrap();
            }
            moved
        })
        .collect()
}

/// `Chain::reshape` moves a chain onto its curves' new points exactly as `Chain::new` builds
/// the chain of them: the same vertices and topology, and a tracker run over the same HIP path
/// (around the object, through every vertex region and across the corners) finds the same
/// contacts on both, bit for bit. A shape of another topology, or curves that come apart,
/// are refused with the chain unchanged.
#[test]
fn reshape_in_place_is_the_chain_new_builds() {
    // A closed curved triangle (three convex corners) and a polyline with corners inside
    // one curve (pieces split at load).
    let triangle = three_curves(0.005);
    let zigzag = vec![
        CurveBuf::from_cartesian(
            1,
            vec![0.0, 0.0, 1.0, 2.0, 3.0, 3.0],
            &[
                Vec2::new(-0.04, 0.08),
                Vec2::new(-0.015, 0.1),
                Vec2::new(0.015, 0.085),
                Vec2::new(0.04, 0.1),
            ],
            None,
        )
        .unwrap(),
    ];
    for (name, curves) in [("triangle", triangle), ("zigzag", zigzag)] {
        let moved = inner_moved(&curves, Vec2::new(0.7e-3, -0.4e-3));
        let views: Vec<_> = curves.iter().map(|c| c.view()).collect();
        let moved_views: Vec<_> = moved.iter().map(|c| c.view()).collect();
        let fresh = Chain::new(&moved_views).unwrap();
        let mut chain = Chain::new(&views).unwrap();
        assert!(chain.reshape(&moved_views), "{name}");
        assert_eq!(chain.vertices(), fresh.vertices(), "{name}");
        assert_eq!(chain.topology(), fresh.topology(), "{name}");
        assert!(chain.has_topology(&fresh.topology()), "{name}");
        // The chain holds the moved curves' data (its own copy), piece for piece.
        assert_eq!(chain.curve_count(), fresh.curve_count(), "{name}");
        for (a, b) in chain.curves().zip(fresh.curves()) {
            assert_eq!(a, b, "{name}: the moved data");
        }
        let path = orbit(0.04, 720, true);
        let cfg = TrackerConfig::default();
        let mut on_reshaped = ChainTracker::new(&chain, path[0], cfg);
        let mut on_fresh = ChainTracker::new(&fresh, path[0], cfg);
        for &x in &path {
            assert_eq!(
                on_reshaped.update(&chain, x, T, true),
                on_fresh.update(&fresh, x, T, true),
                "{name} at {x}"
            );
        }
    }

    // Refused, unchanged: the triangle's first side bulged so far inward that its corner
    // turns reflex; its first side's end moved off the next side's start; another count.
    let triangle = three_curves(0.005);
    let views: Vec<_> = triangle.iter().map(|c| c.view()).collect();
    let mut chain = Chain::new(&views).unwrap();
    let before = (chain.vertices().to_vec(), chain.topology());
    let mut dented = triangle.clone();
    let (p2, _) = triangle[0].view().control_point(2).unwrap();
    dented[0] = triangle[0]
        .with_point(2, p2 + Vec2::new(0.06, 0.03))
        .unwrap();
    let mut apart = triangle.clone();
    let (end, _) = triangle[0].view().control_point(3).unwrap();
    apart[0] = triangle[0]
        .with_point(3, end + Vec2::new(0.0, 1e-3))
        .unwrap();
    let dented_views: Vec<_> = dented.iter().map(|c| c.view()).collect();
    assert_ne!(
        Chain::new(&dented_views).map(|c| c.topology()).ok(),
        Some(before.1),
        "the dent changes a vertex's kind"
    );
    let apart_views: Vec<_> = apart.iter().map(|c| c.view()).collect();
    for (what, given) in [
        ("a reflex corner", &dented_views[..]),
        ("a gap", &apart_views[..]),
        ("two curves of three", &views[..2]),
        ("no curves", &[][..]),
    ] {
        assert!(!chain.reshape(given), "{what}");
        assert_eq!(
            (chain.vertices().to_vec(), chain.topology()),
            before,
            "{what}"
        );
        assert_eq!(
            chain.curve(0).points(),
            views[0].points(),
            "{what}: data kept"
        );
    }
}
