//! Multi-patch 3-D objects: topology, and the feature state machine against the exact
//! nearest feature of a box (faces, edges, corners are known in closed form) and across the
//! smooth seams of a sphere.
#![allow(clippy::unwrap_used)]

use nurbs::{SurfaceBuf, Vec3, construct};
use tracker::{Contact, Feature, Penalty, Shell, ShellError, ShellTracker, Side, TrackerConfig};

const T: f32 = 1e-3;
const H: f32 = 0.02;

/// The six faces of the cube [−H, H]³ as bilinear patches with outward `S_u × S_v`, in the
/// order +z, −z, +x, −x, +y, −y.
fn cube() -> Vec<SurfaceBuf> {
    let h = H;
    let faces = [
        (Vec3::new(-h, -h, h), Vec3::X, Vec3::Y),
        (Vec3::new(-h, -h, -h), Vec3::Y, Vec3::X),
        (Vec3::new(h, -h, -h), Vec3::Y, Vec3::Z),
        (Vec3::new(-h, -h, -h), Vec3::Z, Vec3::Y),
        (Vec3::new(-h, h, -h), Vec3::Z, Vec3::X),
        (Vec3::new(-h, -h, -h), Vec3::X, Vec3::Z),
    ];
    faces
        .iter()
        .map(|&(o, a, b)| {
            let (a, b) = (a * 2.0 * h, b * 2.0 * h);
            construct::bilinear(o, o + a, o + b, o + a + b).unwrap()
        })
        .collect()
}

/// Face index of the outward axis direction (`axis` 0..3, `positive`).
fn face_of(axis: usize, positive: bool) -> usize {
    match (axis, positive) {
        (2, true) => 0,
        (2, false) => 1,
        (0, true) => 2,
        (0, false) => 3,
        (1, true) => 4,
        _ => 5,
    }
}

/// The exact nearest feature of the cube, as the set of faces that touch it.
fn nearest_faces(x: Vec3) -> Vec<usize> {
    let c = x.to_array();
    let outside: Vec<usize> = (0..3).filter(|&i| c[i].abs() > H).collect();
    if outside.is_empty() {
        // Inside: the face with the smallest depth.
        let i = (0..3)
            .max_by(|&a, &b| c[a].abs().total_cmp(&c[b].abs()))
            .unwrap();
        return vec![face_of(i, c[i] > 0.0)];
    }
    let mut f: Vec<usize> = outside.iter().map(|&i| face_of(i, c[i] > 0.0)).collect();
    f.sort();
    f
}

/// The faces touching the FSM's active feature.
fn feature_faces(shell: &Shell, f: Feature) -> Vec<usize> {
    let mut v: Vec<usize> = match f {
        Feature::Patch(i) => vec![i as usize],
        Feature::Edge(e) => {
            let e = shell.edges()[e as usize];
            let mut v = vec![e.a.0 as usize];
            v.extend(e.b.map(|b| b.0 as usize));
            v
        }
        Feature::Corner(c) => shell.corners()[c as usize]
            .incident()
            .iter()
            .map(|i| i.0 as usize)
            .collect(),
        Feature::Vertex(_) => vec![],
    };
    v.sort();
    v.dedup();
    v
}

fn run(shell: &Shell, path: &[Vec3]) -> Vec<(Vec3, Contact<Vec3>)> {
    let mut tr = ShellTracker::new(shell, path[0], TrackerConfig::default());
    path.iter()
        .map(|&x| (x, tr.update(shell, x, T, true)))
        .collect()
}

#[test]
fn cube_topology() {
    let faces = cube();
    let views: Vec<_> = faces.iter().map(|f| f.view()).collect();
    let shell = Shell::new(&views).unwrap();
    assert!(shell.is_closed());
    assert_eq!(shell.edges().len(), 12);
    assert_eq!(shell.corners().len(), 8);
    assert!(shell.corners().iter().all(|c| c.incident().len() == 3));
    for i in 0..6 {
        assert!(shell.sides(i).iter().all(|s| matches!(s, Side::Shared(_))));
    }
}

#[test]
fn inward_cube_is_rejected() {
    let faces: Vec<SurfaceBuf> = cube()
        .iter()
        .map(|f| {
            // Swap u and v: the normal flips.
            let v = f.view();
            let p = |i, j| v.control_point(i, j).unwrap().0;
            construct::bilinear(p(0, 0), p(0, 1), p(1, 0), p(1, 1)).unwrap()
        })
        .collect();
    let views: Vec<_> = faces.iter().map(|f| f.view()).collect();
    assert_eq!(Shell::new(&views).unwrap_err(), ShellError::InwardNormals);
}

/// Orbit around the cube outside, in the plane z = 0 and in a tilted plane that passes over
/// corners: every tick's feature matches the exact nearest feature, but for the few ticks at
/// region boundaries.
#[test]
fn orbit_matches_exact_nearest_feature() {
    let faces = cube();
    let views: Vec<_> = faces.iter().map(|f| f.view()).collect();
    let shell = Shell::new(&views).unwrap();
    for tilt in [0.0f32, 0.6] {
        let axis_b = Vec3::new(0.0, tilt.cos(), tilt.sin());
        let path: Vec<Vec3> = (0..=3000)
            .map(|k| {
                let a = k as f32 / 3000.0 * std::f32::consts::TAU;
                (Vec3::X * a.cos() + axis_b * a.sin()) * 0.035
                    + Vec3::new(0.0, 0.0, 0.3 * tilt * 0.035)
            })
            .collect();
        let out = run(&shell, &path);
        let mismatches: Vec<_> = out
            .iter()
            .filter(|(x, c)| feature_faces(&shell, c.feature) != nearest_faces(*x))
            .collect();
        assert!(
            mismatches.len() <= 12,
            "tilt {tilt}: {} of {} ticks disagree, first {:?}",
            mismatches.len(),
            out.len(),
            mismatches
                .first()
                .map(|(x, c)| (x, c.feature, nearest_faces(*x)))
        );
        // Distance: exact distance to the box.
        for (x, c) in &out {
            let q = x.clamp(Vec3::splat(-H), Vec3::splat(H));
            assert!(
                (-c.depth - (*x - q).length()).abs() < 1e-5,
                "x {x:?} depth {}",
                c.depth
            );
        }
        if tilt > 0.0 {
            assert!(
                out.iter()
                    .any(|(_, c)| matches!(c.feature, Feature::Corner(_)))
            );
        }
        assert!(
            out.iter()
                .any(|(_, c)| matches!(c.feature, Feature::Edge(_)))
        );
    }
}

/// Pressed 3 mm into the cube and moved around inside: faces switch at the bisector planes,
/// never through an edge or corner, and match the exact nearest face.
#[test]
fn inside_switches_faces_at_bisectors() {
    let faces = cube();
    let views: Vec<_> = faces.iter().map(|f| f.view()).collect();
    let shell = Shell::new(&views).unwrap();
    let d = H - 0.003;
    let waypoints = [
        Vec3::new(0.0, -d, 0.0),
        Vec3::new(d, -d, 0.005),
        Vec3::new(d, d, -0.005),
        Vec3::new(-d, d, 0.0),
        Vec3::new(-d, -d, d),
        Vec3::new(0.0, -d, 0.0),
    ];
    let mut path = Vec::new();
    for w in waypoints.windows(2) {
        for k in 0..800 {
            path.push(w[0] + (w[1] - w[0]) * (k as f32 / 800.0));
        }
    }
    let out = run(&shell, &path);
    assert!(
        out.iter()
            .all(|(_, c)| matches!(c.feature, Feature::Patch(_)) && c.inside)
    );
    let mismatches = out
        .iter()
        .filter(|(x, c)| feature_faces(&shell, c.feature) != nearest_faces(*x))
        .count();
    assert!(
        mismatches <= 8,
        "{mismatches} ticks disagree with the nearest face"
    );
}

/// A sphere made of two half-spheres of revolution: two smooth seams (edges) and two poles.
/// Inside, 2 mm deep, sweeping across a seam: force equals the exact sphere force and never
/// jumps by more than stiffness × HIP step.
#[test]
fn sphere_halves_smooth_seams() {
    let r = 0.03;
    let c = Vec3::new(0.0, 0.09, 0.0);
    let meridian = construct::arc(
        c,
        Vec3::X * r,
        Vec3::Z * r,
        -std::f32::consts::FRAC_PI_2,
        std::f32::consts::PI,
    )
    .unwrap();
    let half1 = construct::revolve(&meridian, c, Vec3::Z, std::f32::consts::PI).unwrap();
    let half2 = half1
        .map_points(|p| c + glam_rotate_z(p - c, std::f32::consts::PI))
        .unwrap();
    let halves = [half1, half2];
    let views: Vec<_> = halves.iter().map(|f| f.view()).collect();
    let shell = Shell::new(&views).unwrap();
    assert!(shell.is_closed());
    for i in 0..2 {
        let s = shell.sides(i);
        assert!(
            matches!(s[0], Side::Shared(_)) && matches!(s[1], Side::Shared(_)),
            "{s:?}"
        );
        assert_eq!(s[2], Side::Collapsed);
        assert_eq!(s[3], Side::Collapsed);
    }
    let k = 1000.0;
    let pen = Penalty {
        stiffness_n_per_m: k,
        damping_ns_per_m: 0.0,
    };
    // Sweep the longitude across 0 (the seam at u = 0 of half 1), at latitude 0.3 rad.
    let lat: f32 = 0.3;
    let path: Vec<Vec3> = (0..=1000)
        .map(|i| {
            let lon = -0.5 + i as f32 / 1000.0;
            c + Vec3::new(lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()) * (r - 0.002)
        })
        .collect();
    let out = run(&shell, &path);
    let mut prev: Option<(Vec3, Vec3)> = None;
    let mut switches = 0;
    let mut last_patch = out[0].1.feature;
    for (x, ct) in &out {
        let f = ct.penalty_force(&pen, Vec3::ZERO);
        let exact = (*x - c).normalize() * (k * (r - (*x - c).length()));
        assert!(
            (f - exact).length() < 2e-3,
            "force {f:?} vs exact {exact:?} at {x:?} ({:?})",
            ct.feature
        );
        if let Some((fp, xp)) = prev {
            assert!((f - fp).length() <= k * (*x - xp).length() + 2e-3);
        }
        if ct.feature != last_patch {
            switches += 1;
            last_patch = ct.feature;
        }
        prev = Some((f, *x));
    }
    assert_eq!(switches, 1, "crossed the seam exactly once");
}

fn glam_rotate_z(v: Vec3, a: f32) -> Vec3 {
    Vec3::new(
        v.x * a.cos() - v.y * a.sin(),
        v.x * a.sin() + v.y * a.cos(),
        v.z,
    )
}

/// A sheet folded along u = 1/2 (a knot of multiplicity 1 = p): flat on z = 0 for u ≤ 1/2,
/// `S = (2u, v, 0)`, then up the plane x = 1, `S = (1, v, 2u − 1)`: one patch the shell
/// splits into two pieces, windows onto the same knots.
fn folded_sheet() -> SurfaceBuf {
    let rows: Vec<Vec<Vec3>> = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, 1.0)]
        .iter()
        .map(|&p| vec![p, p + Vec3::Y])
        .collect();
    SurfaceBuf::from_rows(
        (1, 1),
        (vec![0.0, 0.0, 0.5, 1.0, 1.0], vec![0.0, 0.0, 1.0, 1.0]),
        &rows,
        None::<&[Vec<f32>]>,
    )
    .unwrap()
}

/// The two half-spheres of [`sphere_halves_smooth_seams`]: rational, with poles.
fn sphere_halves() -> Vec<SurfaceBuf> {
    let (r, c) = (0.03, Vec3::new(0.0, 0.09, 0.0));
    let meridian = construct::arc(
        c,
        Vec3::X * r,
        Vec3::Z * r,
        -std::f32::consts::FRAC_PI_2,
        std::f32::consts::PI,
    )
    .unwrap();
    let half1 = construct::revolve(&meridian, c, Vec3::Z, std::f32::consts::PI).unwrap();
    let half2 = half1
        .map_points(|p| c + glam_rotate_z(p - c, std::f32::consts::PI))
        .unwrap();
    vec![half1, half2]
}

/// Every piece's point and derivatives to order 2 at interior parameters (fractions of its
/// domain that are no knot), as bits.
fn readings(shell: &Shell) -> Vec<[u32; 18]> {
    const AT: [f32; 4] = [0.13, 0.41, 0.77, 0.94];
    let mut out = Vec::new();
    for s in shell.surfaces() {
        let ((u0, u1), (v0, v1)) = s.domain();
        for a in AT {
            for b in AT {
                let d = s.derivs(u0 + (u1 - u0) * a, v0 + (v1 - v0) * b, 2);
                let v = [d.point, d.du, d.dv, d.duu, d.duv, d.dvv];
                out.push(std::array::from_fn(|k| v[k / 3][k % 3].to_bits()));
            }
        }
    }
    out
}

/// The shell owns its data: one built from surfaces keeps rendering, bit for bit, after the
/// surfaces' storage is gone, and so does one rebuilt in place from a copy that is gone too.
/// Both have the topology, sides, edges and corners that the views of the surfaces give
/// ([`Shell::topology_of`]), their pieces evaluate exactly as the given patches do inside
/// each piece (a window finds the same knot span), and a tracker run on either reports the
/// same contacts.
#[test]
fn a_shell_owns_its_data() {
    let shapes: [(&str, Vec<SurfaceBuf>, [Vec3; 2]); 3] = [
        (
            "cube",
            cube(),
            [
                Vec3::new(0.03, 0.001, 0.015),
                Vec3::new(-0.005, -0.002, 0.018),
            ],
        ),
        (
            "sphere halves",
            sphere_halves(),
            [Vec3::new(0.035, 0.09, 0.005), Vec3::new(-0.01, 0.115, 0.01)],
        ),
        (
            "folded sheet",
            vec![folded_sheet()],
            [Vec3::new(0.2, 0.5, 0.01), Vec3::new(1.05, 0.5, 0.3)],
        ),
    ];
    for (name, surfaces, [from, to]) in shapes {
        let path: Vec<Vec3> = (0..=600).map(|k| from.lerp(to, k as f32 / 600.0)).collect();
        let (built, before, topology) = {
            let storage = surfaces.clone();
            let views: Vec<_> = storage.iter().map(|s| s.view()).collect();
            let shell = Shell::new(&views).unwrap();
            let topology = <Shell>::topology_of(&views).unwrap();
            assert_eq!(shell.topology(), topology, "{name}");
            // Each piece evaluates as its source patch does at the same parameters.
            for (i, piece) in shell.surfaces().enumerate() {
                let given = views[shell.source_patch(i)];
                let ((u0, u1), (v0, v1)) = piece.domain();
                for (a, b) in [(0.13, 0.41), (0.77, 0.94), (0.41, 0.13)] {
                    let (u, v) = (u0 + (u1 - u0) * a, v0 + (v1 - v0) * b);
                    let (p, q) = (piece.derivs(u, v, 2), given.derivs(u, v, 2));
                    assert_eq!(
                        [p.point, p.du, p.dv].map(|x| x.to_array().map(f32::to_bits)),
                        [q.point, q.du, q.dv].map(|x| x.to_array().map(f32::to_bits)),
                        "{name}: piece {i} at ({u}, {v})"
                    );
                }
            }
            (shell, readings(&shell), topology)
        };
        let mut rebuilt = Shell::EMPTY;
        {
            let copy = surfaces.clone();
            let views: Vec<_> = copy.iter().map(|s| s.view()).collect();
            rebuilt.rebuild(&views).unwrap();
        }
        drop(surfaces);
        for shell in [&built, &rebuilt] {
            assert_eq!(shell.topology(), topology, "{name}");
            assert_eq!(readings(shell), before, "{name}");
        }
        assert_eq!(
            (built.surface_count(), built.is_closed()),
            (rebuilt.surface_count(), rebuilt.is_closed()),
            "{name}"
        );
        assert_eq!(built.edges(), rebuilt.edges(), "{name}");
        assert_eq!(built.corners(), rebuilt.corners(), "{name}");
        for i in 0..built.surface_count() {
            assert_eq!(built.sides(i), rebuilt.sides(i), "{name}");
            assert_eq!(built.source_patch(i), rebuilt.source_patch(i), "{name}");
        }
        let (a, b) = (run(&built, &path), run(&rebuilt, &path));
        assert!(a.iter().any(|(_, c)| c.inside), "{name}: the path touches");
        assert_eq!(a, b, "{name}");
    }
}

/// Patches whose knots or control points do not fit the shell's storage are refused with
/// the counts and the capacities, by the shell and by its checks on views, and a failed
/// rebuild leaves no patches. The cube's six bilinear faces hold 6 × (4 + 4) = 48 knots and
/// 6 × 4 = 24 control points.
#[test]
fn patches_beyond_the_capacity_are_refused() {
    let faces = cube();
    let views: Vec<_> = faces.iter().map(|f| f.view()).collect();
    assert!(Shell::<48, 24>::from_surfaces(&views).is_ok());
    assert_eq!(Shell::<48, 24>::check(&views), Ok(()));
    for (knot_capacity, point_capacity, result) in [
        (47, 24, Shell::<47, 24>::from_surfaces(&views).map(drop)),
        (48, 23, Shell::<48, 23>::from_surfaces(&views).map(drop)),
        (47, 24, Shell::<47, 24>::check(&views)),
        (48, 23, Shell::<48, 23>::topology_of(&views).map(drop)),
    ] {
        let e = ShellError::Capacity {
            knots: 48,
            points: 24,
            knot_capacity,
            point_capacity,
        };
        assert_eq!(result, Err(e));
        assert_eq!(
            e.to_string(),
            format!(
                "patches: 48 knots (u and v) and 24 control points in all, at most \
                 {knot_capacity} and {point_capacity} per object"
            )
        );
    }
    let mut shell = Shell::<48, 24>::from_surfaces(&views).unwrap();
    assert!(shell.rebuild(&views[..5]).is_ok());
    let more: Vec<_> = views.iter().chain(&views[..1]).copied().collect();
    assert!(matches!(
        Shell::<48, 24>::from_surfaces(&more),
        Err(ShellError::Capacity { .. })
    ));
    assert!(shell.rebuild(&more).is_err());
    assert_eq!(shell.surface_count(), 0);
}
