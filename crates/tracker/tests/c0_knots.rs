//! Interior knots of full multiplicity (which the loaders accept) are corners of a curve and
//! creases of a surface: the chain and the shell split patches there at load, so the feature
//! state machine knows them as vertices and edges. A HIP resting near such a knot must get a
//! settled closest point and normal, not one that jumps between the two sides every tick.
#![allow(clippy::unwrap_used)]

use nurbs::{CurveBuf, SurfaceBuf, Vec2, Vec3};
use tracker::{Chain, ChainTracker, Feature, Shell, ShellTracker, Side, TrackerConfig, VertexKind};

const T: f32 = 1e-3;

/// The roof profile, right to left so that the outward normal `(t.y, −t.x)` points up:
/// a quadratic with a double knot at u = 1, so it is two straight legs of slope ±½ meeting at
/// the apex (0, 0.1) (each leg's three control points are collinear).
const ROOF: [Vec2; 5] = [
    Vec2::new(0.04, 0.08),
    Vec2::new(0.02, 0.09),
    Vec2::new(0.0, 0.1),
    Vec2::new(-0.02, 0.09),
    Vec2::new(-0.04, 0.08),
];
const ROOF_KNOTS: [f32; 8] = [0.0, 0.0, 0.0, 1.0, 1.0, 2.0, 2.0, 2.0];
const APEX: Vec2 = Vec2::new(0.0, 0.1);

fn roof_curve() -> CurveBuf<Vec2> {
    CurveBuf::from_cartesian(2, ROOF_KNOTS.to_vec(), &ROOF, None).unwrap()
}

/// Angle between two unit vectors in degrees.
fn angle_deg(a: Vec2, b: Vec2) -> f32 {
    a.perp_dot(b).atan2(a.dot(b)).to_degrees()
}

#[test]
fn roof_apex_is_a_convex_vertex() {
    let c = roof_curve();
    let views = [c.view()];
    let chain = Chain::new(&views).unwrap();
    assert_eq!(chain.curves().len(), 2);
    assert_eq!((chain.source_curve(0), chain.source_curve(1)), (0, 0));
    assert_eq!(tracker::Object::source_patch(&chain, 1), 0);
    // The pieces share the curve's parameters: each is a window onto its domain.
    assert_eq!(chain.curve(0).domain(), (0.0, 1.0));
    assert_eq!(chain.curve(1).domain(), (1.0, 2.0));
    let apex = chain.vertices()[1];
    assert_eq!(apex.kind, VertexKind::Convex);
    // The apex is the middle control point, interpolated at the double knot.
    assert!((apex.position - APEX).length() <= 1e-8);
    // The legs' directions: (−2, 1)/√5 in, (−2, −1)/√5 out.
    let s5 = 5f32.sqrt();
    assert!((apex.t_in - Vec2::new(-2.0, 1.0) / s5).length() < 1e-6);
    assert!((apex.t_out - Vec2::new(-2.0, -1.0) / s5).length() < 1e-6);
}

/// A HIP resting just outside the apex (0.3 mm above it, 0.05 mm to the side: inside the
/// apex's external wedge, which spans the normals of the two legs, ±26.6° about the vertical).
/// The closest point is the apex and the normal is `(x − apex)/|x − apex|`. Before the split
/// the tracker ran on the one curve and flipped between the legs every tick.
#[test]
fn hip_resting_above_the_apex_settles_on_the_vertex() {
    let c = roof_curve();
    let views = [c.view()];
    let chain = Chain::new(&views).unwrap();
    let hip = APEX + Vec2::new(0.00005, 0.0003);
    let mut tr = ChainTracker::new(&chain, hip, TrackerConfig::default());
    let contacts: Vec<_> = (0..200).map(|_| tr.update(&chain, hip, T, true)).collect();
    let exact = (hip - APEX).normalize();
    for (k, c) in contacts.iter().enumerate().skip(5) {
        assert_eq!(c.feature, Feature::Vertex(1), "tick {k}");
        // The vertex contact is exact: the apex in f32, the normal from it.
        assert!((c.point - APEX).length() <= 1e-8, "tick {k}: {:?}", c.point);
        assert!(angle_deg(c.normal, exact).abs() < 1e-3, "tick {k}");
        // Depth −|x − apex| = −0.304 mm, to f32 rounding of coordinates of 0.1 m.
        let d = (hip - APEX).length();
        assert!((c.depth + d).abs() <= 1e-8, "tick {k}: {}", c.depth);
    }
    // Settled: no change at all over the last ticks.
    let last = contacts[contacts.len() - 1];
    for c in &contacts[100..] {
        assert_eq!(c.normal, last.normal);
        assert_eq!(c.point, last.point);
    }
}

/// A HIP resting just above the right leg near the apex (inside that leg's region, 0.2 mm
/// from the apex along it): the closest point is its orthogonal projection onto the straight
/// leg, and stays there.
#[test]
fn hip_resting_beside_the_apex_settles_on_the_leg() {
    let c = roof_curve();
    let views = [c.view()];
    let chain = Chain::new(&views).unwrap();
    let t_leg = (ROOF[0] - APEX).normalize();
    let n_leg = Vec2::new(1.0, 2.0) / 5f32.sqrt();
    let foot = APEX + t_leg * 0.0002;
    let hip = foot + n_leg * 0.0003;
    let mut tr = ChainTracker::new(&chain, hip, TrackerConfig::default());
    let contacts: Vec<_> = (0..300).map(|_| tr.update(&chain, hip, T, true)).collect();
    for (k, c) in contacts.iter().enumerate().skip(50) {
        assert_eq!(c.feature, Feature::Patch(0), "tick {k}");
        // f32 coordinates of 0.1 m: a few ulps (≈ 7·10⁻⁹ m each).
        assert!((c.point - foot).length() <= 5e-8, "tick {k}: {:?}", c.point);
        assert!(angle_deg(c.normal, n_leg).abs() < 1e-3, "tick {k}");
    }
    let a = contacts[200].normal;
    for c in &contacts[200..] {
        assert!(angle_deg(c.normal, a).abs() < 1e-4);
    }
}

/// The roof extruded along z: a surface of degrees (2, 1) with the double knot at u = 1, so
/// it has a crease (the ridge) along v. Its outward normal `S_u × S_v` points up.
fn roof_surface() -> SurfaceBuf {
    let rows: Vec<Vec<Vec3>> = ROOF
        .iter()
        .map(|p| vec![Vec3::new(p.x, p.y, -0.02), Vec3::new(p.x, p.y, 0.02)])
        .collect();
    SurfaceBuf::from_rows(
        (2, 1),
        (ROOF_KNOTS.to_vec(), vec![0.0, 0.0, 1.0, 1.0]),
        &rows,
        None::<&[Vec<f32>]>,
    )
    .unwrap()
}

#[test]
fn ridge_is_an_edge_of_the_split_shell() {
    let s = roof_surface();
    let views = [s.view()];
    let shell = Shell::new(&views).unwrap();
    assert_eq!(shell.surface_count(), 2);
    assert_eq!((shell.source_patch(0), shell.source_patch(1)), (0, 0));
    // Piece 0 ends at u = 1 (side 1), piece 1 starts there (side 0): one shared edge.
    let (Side::Shared(e0), Side::Shared(e1)) = (shell.sides(0)[1], shell.sides(1)[0]) else {
        panic!("ridge sides: {:?} {:?}", shell.sides(0), shell.sides(1));
    };
    assert_eq!(e0, e1);
    let shared = shell.edges().iter().filter(|e| e.b.is_some()).count();
    assert_eq!(shared, 1);
}

/// A HIP resting just above the ridge, halfway along it: the closest point is on the ridge
/// line (x = 0, y = 0.1) below the HIP and the normal runs from there to the HIP.
#[test]
fn hip_resting_above_the_ridge_settles_on_the_edge() {
    let s = roof_surface();
    let views = [s.view()];
    let shell = Shell::new(&views).unwrap();
    let hip = Vec3::new(0.00005, 0.1003, 0.005);
    let foot = Vec3::new(0.0, 0.1, 0.005);
    let mut tr = ShellTracker::new(&shell, hip, TrackerConfig::default());
    let contacts: Vec<_> = (0..300).map(|_| tr.update(&shell, hip, T, true)).collect();
    let exact = (hip - foot).normalize();
    for (k, c) in contacts.iter().enumerate().skip(50) {
        assert!(
            matches!(c.feature, Feature::Edge(_)),
            "tick {k}: {:?}",
            c.feature
        );
        assert!((c.point - foot).length() <= 5e-8, "tick {k}: {:?}", c.point);
        let angle = c.normal.angle_between(exact).to_degrees();
        assert!(angle < 1e-2, "tick {k}: {angle}°");
    }
    let a = contacts[200].normal;
    for c in &contacts[200..] {
        assert!(c.normal.angle_between(a).to_degrees() < 1e-3);
    }
}

/// Full-multiplicity knots where the patch does not turn are not split: the rational circle
/// has double knots at its quarter points and the sphere of revolution double knot lines along
/// its quarter meridians and parallels, all tangent continuous (the exact constructions of The
/// NURBS Book §7.5, §8.5).
#[test]
fn tangent_continuous_full_multiplicity_knots_stay_whole() {
    let circle = nurbs::construct::circle(Vec2::new(0.0, 0.09), 0.03).unwrap();
    let k = circle.view().knots();
    // Precondition: the construction really has interior C⁰ knots.
    assert!(k.c0_pieces().count() > 1);
    let views = [circle.view()];
    let chain = Chain::new(&views).unwrap();
    assert_eq!(chain.curves().len(), 1);
    assert_eq!(chain.curve(0), circle.view());

    let sphere = nurbs::construct::sphere(Vec3::new(0.0, 0.09, 0.0), 0.03).unwrap();
    assert!(sphere.view().c0_pieces().count() > 1);
    let views = [sphere.view()];
    let shell = Shell::new(&views).unwrap();
    assert_eq!(shell.surface_count(), 1);
}

/// A rational roof: the same legs with the apex control point's neighbours weighted, so the
/// legs are conic arcs (still meeting at a corner, the double knot). The chain splits there,
/// and a HIP above the apex settles on the vertex with the exact vertex normal.
#[test]
fn rational_roof_apex_is_a_vertex() {
    let w = [1.0, 3.0, 1.0, 0.4, 1.0];
    let c = CurveBuf::from_cartesian(2, ROOF_KNOTS.to_vec(), &ROOF, Some(&w)).unwrap();
    let views = [c.view()];
    let chain = Chain::new(&views).unwrap();
    assert_eq!(chain.curves().len(), 2);
    assert_eq!(chain.vertices()[1].kind, VertexKind::Convex);
    let hip = APEX + Vec2::new(0.0, 0.0004);
    let mut tr = ChainTracker::new(&chain, hip, TrackerConfig::default());
    let contacts: Vec<_> = (0..100).map(|_| tr.update(&chain, hip, T, true)).collect();
    for c in &contacts[5..] {
        assert_eq!(c.feature, Feature::Vertex(1));
        assert!((c.point - APEX).length() <= 1e-8);
        assert!(angle_deg(c.normal, Vec2::Y).abs() < 1e-3);
    }
}

/// Splitting can push a chain past its fixed storage: the error says so, with both counts.
#[test]
fn too_many_pieces_is_a_clear_error() {
    // A polyline of 40 segments: one degree-1 curve, 39 interior knots, all corners (zigzag).
    let n = 41;
    let pts: Vec<Vec2> = (0..n)
        .map(|i| Vec2::new(0.04 - 0.002 * i as f32, 0.08 + 0.002 * (i % 2) as f32))
        .collect();
    let mut knots = vec![0.0f32];
    knots.extend((0..n).map(|i| i as f32 / (n - 1) as f32));
    knots.push(1.0);
    let c = CurveBuf::from_cartesian(1, knots, &pts, None).unwrap();
    let views = [c.view()];
    let err = Chain::new(&views).unwrap_err();
    assert_eq!(
        err,
        tracker::ChainError::TooManyPieces {
            count: 1,
            pieces: 40
        }
    );
    assert_eq!(
        err.to_string(),
        "patches: split at their corners (interior knots of full multiplicity), the 1 curve(s) make 40 curves, at most 32 per object"
    );
}
