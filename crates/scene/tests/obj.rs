//! OBJ export: an object's tessellation (`tessellate_object`) written by `mesh::save_obj`
//! and read back by an independent reader (tobj), checked against the closed form of
//! thesis-3d's bump.

use nurbs::Vec3;
use scene::bundled::Bundled;
use scene::{mesh, tessellate_object};

/// thesis-3d's bicubic bump: its control net is linear in x and y (x from −0.04 to 0.04, y
/// from 0.06 to 0.12, evenly spaced) with the four inner points raised 12 mm, so the surface
/// is z = 0.012 · 9 u(1 − u) v(1 − v), u = (x + 0.04)/0.08, v = (y − 0.06)/0.06 (the cubic
/// Bernstein weights of the inner points sum to 3u(1 − u)).
fn bump_z(x: f32, y: f32) -> f32 {
    let u = (x + 0.04) / 0.08;
    let v = (y - 0.06) / 0.06;
    0.012 * 9.0 * u * (1.0 - u) * v * (1.0 - v)
}

/// The OBJ export of thesis-3d's bump, read back with tobj: the same vertices as the
/// tessellation (bit for bit: f32 written as its shortest round-tripping decimal), every
/// vertex on the surface (the closed form above, to f32 rounding: 1e-6 m) and every
/// triangle's centroid within the chordal tolerance of it (vertically: the bump's slope is
/// below 0.35, so the vertical distance is within 6 % of the normal one).
#[test]
fn obj_export_round_trips_and_lies_on_the_surface() {
    let bump = Bundled::find("thesis-3d")
        .expect("bundled")
        .scene()
        .unwrap_or_else(|e| panic!("{e}"));
    let tol = 5e-4;
    let mesh = tessellate_object(&bump, 0, tol).expect("a surface object");
    let dir = std::env::temp_dir().join(format!("scene-obj-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("bump.obj");
    mesh::save_obj(&mesh, "bump", "thesis-3d's bump", &path).expect("export");

    let (models, _) = tobj::load_obj(&path, &tobj::GPU_LOAD_OPTIONS).expect("tobj reads it");
    assert_eq!(models.len(), 1);
    let m = &models[0].mesh;
    let read: Vec<Vec3> = m
        .positions
        .chunks_exact(3)
        .map(|p| Vec3::new(p[0], p[1], p[2]))
        .collect();
    // single_index (GPU options) may reorder: compare as sets of bit patterns.
    let key = |p: &Vec3| p.to_array().map(f32::to_bits);
    let mut a: Vec<[u32; 3]> = read.iter().map(key).collect();
    let mut b: Vec<[u32; 3]> = mesh.vertices().iter().map(key).collect();
    a.sort_unstable();
    b.sort_unstable();
    a.dedup();
    b.dedup();
    assert_eq!(a, b, "the same vertices");
    assert_eq!(m.indices.len(), 3 * mesh.triangles().len());
    for p in &read {
        assert!((p.z - bump_z(p.x, p.y)).abs() < 1e-6, "{p} off the surface");
    }
    for t in m.indices.chunks_exact(3) {
        let c = t.iter().map(|&i| read[i as usize]).sum::<Vec3>() / 3.0;
        let off = (c.z - bump_z(c.x, c.y)).abs();
        assert!(off <= tol * 1.06, "centroid {c} is {off} m off");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
