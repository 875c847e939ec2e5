//! The scene as the 3-D view draws it: surfaces tessellated for display only (smooth normals
//! from the surface), control nets and spatial curves, a mesh felt in place of its surface
//! (flat shaded) and a deforming object over its rest shape, as vertex lists for the GPU.

use std::sync::Arc;

use nurbs::Vec3;
use scene::{Object, Patch, Scene};
use tracker::TriMesh;

/// Chordal tolerance of the display tessellation (m): display only, finer than any haptic
/// tessellation the slider offers.
pub const DISPLAY_TOL_M: f32 = 2e-4;
/// Samples per spatial curve drawn.
pub const WIRE_SAMPLES: usize = 256;
/// Floats per vertex on the GPU: position (3), normal (3; zero for unlit lines), colour (4).
pub const VERTEX_FLOATS: usize = 10;

const SURFACE: [f32; 4] = [0.55, 0.68, 0.85, 1.0];
const FACETED: [f32; 4] = [0.85, 0.68, 0.45, 1.0];
const NET: [f32; 4] = [0.45, 0.45, 0.45, 1.0];
const WIRE: [f32; 4] = [0.15, 0.15, 0.15, 1.0];
/// The rest shape behind a deforming surface: faint blue-grey lines (premultiplied alpha).
const REST: [f32; 4] = [0.3 * 0.45, 0.35 * 0.45, 0.5 * 0.45, 0.45];
/// Grid cells per direction of a deforming surface's display mesh (each becomes two
/// triangles): a fixed grid, re-evaluated at the loop's publication rate, not an adaptive
/// tessellation.
pub const MOVING_GRID: usize = 32;
/// Iso-parameter lines per direction drawn of the rest shape behind a deforming surface.
pub const REST_LINES: usize = 9;

/// Triangles and lines ready for the GPU: the scene as drawn.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Geometry {
    /// Triangle vertices, [`VERTEX_FLOATS`] floats each, three per triangle.
    pub triangles: Vec<f32>,
    /// The centroid of each triangle (for the back-to-front sort).
    pub centroids: Vec<Vec3>,
    /// Line-list vertices, [`VERTEX_FLOATS`] floats each, two per segment.
    pub lines: Vec<f32>,
    /// Identifies this geometry (the GPU buffers are rebuilt when it changes).
    pub revision: u64,
}

impl Geometry {
    fn push_vertex(buf: &mut Vec<f32>, p: Vec3, n: Vec3, c: [f32; 4]) {
        buf.extend_from_slice(&[p.x, p.y, p.z, n.x, n.y, n.z]);
        buf.extend_from_slice(&c);
    }

    fn triangle(&mut self, p: [Vec3; 3], n: [Vec3; 3], c: [f32; 4]) {
        for k in 0..3 {
            Self::push_vertex(&mut self.triangles, p[k], n[k], c);
        }
        self.centroids.push((p[0] + p[1] + p[2]) / 3.0);
    }

    fn segment(&mut self, a: Vec3, b: Vec3, c: [f32; 4]) {
        Self::push_vertex(&mut self.lines, a, Vec3::ZERO, c);
        Self::push_vertex(&mut self.lines, b, Vec3::ZERO, c);
    }

    /// Triangles in this geometry.
    pub fn triangle_count(&self) -> usize {
        self.centroids.len()
    }

    /// Line segments in this geometry.
    pub fn segment_count(&self) -> usize {
        self.lines.len() / (2 * VERTEX_FLOATS)
    }
}

/// The scene as the 3-D view draws it.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene3d {
    /// Where it came from (a bundled name or a path).
    pub label: String,
    /// The name of the object the hand feels, if any.
    pub rendered_name: Option<String>,
    /// Bounding box of everything drawn (m).
    pub bounds: (Vec3, Vec3),
    /// The shaded surfaces (display tessellation, smooth normals from the surface) and the
    /// control nets and curves.
    base: Geometry,
    /// The mesh the hand feels when it is a mesh (flat shaded, drawn instead of the rendered
    /// object's smooth surface), and the index of that object.
    faceted: Option<(usize, Geometry)>,
    /// Per object: the range of its triangles in `base.triangles` (in triangles).
    object_triangles: Vec<std::ops::Range<usize>>,
    /// Per object: the range of its segments in `base.lines` (in segments).
    object_lines: Vec<std::ops::Range<usize>>,
    /// A deforming object's current shape (drawn instead of its rest shape, which is drawn
    /// faint behind it), and the index of that object.
    moving: Option<(usize, Geometry)>,
    /// What goes to the GPU.
    pub geometry: Arc<Geometry>,
}

/// A counter for [`Geometry::revision`].
fn next_revision() -> u64 {
    use std::sync::atomic::{AtomicU64, Ordering};
    static NEXT: AtomicU64 = AtomicU64::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

impl Scene3d {
    /// The drawable geometry of `scene`; `rendered` names the object the hand feels.
    pub fn new(label: &str, scene: &Scene, rendered: Option<usize>) -> Self {
        let mut base = Geometry::default();
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        let mut grow = |p: Vec3| {
            lo = lo.min(p);
            hi = hi.max(p);
        };
        let mut object_triangles = Vec::new();
        let mut object_lines = Vec::new();
        for o in scene.objects() {
            let first = base.triangle_count();
            let first_line = base.segment_count();
            for p in o.patches() {
                match p {
                    Patch::Surface(s) => {
                        let view = s.view();
                        let mesh = TriMesh::tessellate(&view, DISPLAY_TOL_M);
                        let normals: Vec<Vec3> = mesh
                            .params()
                            .iter()
                            .map(|t| view.normal(t[0], t[1]))
                            .collect();
                        for tri in mesh.triangles() {
                            let i = tri.map(|k| k as usize);
                            let p = i.map(|k| mesh.vertices()[k]);
                            let n = i.map(|k| normals[k]);
                            base.triangle(p, n, SURFACE);
                        }
                        mesh.vertices().iter().for_each(|&p| grow(p));
                        // The control net: rows and columns of control points.
                        let (nu, nv) = view.counts();
                        let at = |i: usize, j: usize| {
                            view.points()
                                .get(i * nv + j)
                                .map(|h| Vec3::new(h.x / h.w, h.y / h.w, h.z / h.w))
                        };
                        for i in 0..nu {
                            for j in 0..nv {
                                let Some(a) = at(i, j) else { continue };
                                grow(a);
                                let next_u = (i + 1 < nu).then(|| at(i + 1, j)).flatten();
                                let next_v = (j + 1 < nv).then(|| at(i, j + 1)).flatten();
                                for b in [next_u, next_v].into_iter().flatten() {
                                    base.segment(a, b, NET);
                                }
                            }
                        }
                    }
                    Patch::Curve3(c) => {
                        let view = c.view();
                        let (a, b) = view.domain();
                        let pts: Vec<Vec3> = (0..=WIRE_SAMPLES)
                            .map(|i| view.point(a + (b - a) * i as f32 / WIRE_SAMPLES as f32))
                            .collect();
                        pts.iter().for_each(|&p| grow(p));
                        for w in pts.windows(2) {
                            base.segment(w[0], w[1], WIRE);
                        }
                    }
                    Patch::Curve2(c) => {
                        let view = c.view();
                        let (a, b) = view.domain();
                        let pts: Vec<Vec3> = (0..=WIRE_SAMPLES)
                            .map(|i| {
                                let p = view.point(a + (b - a) * i as f32 / WIRE_SAMPLES as f32);
                                Vec3::new(p.x, p.y, 0.0)
                            })
                            .collect();
                        pts.iter().for_each(|&p| grow(p));
                        for w in pts.windows(2) {
                            base.segment(w[0], w[1], WIRE);
                        }
                    }
                }
            }
            object_triangles.push(first..base.triangle_count());
            object_lines.push(first_line..base.segment_count());
        }
        let rendered_name = rendered
            .and_then(|i| scene.object(i))
            .map(|o| o.name().to_owned());
        Self::assemble(
            label,
            rendered_name,
            (lo, hi),
            base,
            (object_triangles, object_lines),
        )
    }

    /// A scene of one mesh (an opened OBJ file), flat shaded.
    pub fn of_mesh(label: &str, name: &str, mesh: &TriMesh) -> Self {
        let mut base = Geometry::default();
        faceted_into(&mut base, mesh);
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for &p in mesh.vertices() {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        let ranges = (
            std::iter::once(0..base.triangle_count()).collect(),
            std::iter::once(0..base.segment_count()).collect(),
        );
        Self::assemble(label, Some(name.to_owned()), (lo, hi), base, ranges)
    }

    fn assemble(
        label: &str,
        rendered_name: Option<String>,
        (lo, hi): (Vec3, Vec3),
        base: Geometry,
        (object_triangles, object_lines): (
            Vec<std::ops::Range<usize>>,
            Vec<std::ops::Range<usize>>,
        ),
    ) -> Self {
        let bounds = if lo.is_finite() && hi.is_finite() {
            (lo, hi)
        } else {
            (Vec3::new(-0.05, 0.05, 0.0), Vec3::new(0.05, 0.13, 0.0))
        };
        let mut s = Scene3d {
            label: label.to_owned(),
            rendered_name,
            bounds,
            base,
            faceted: None,
            object_triangles,
            object_lines,
            moving: None,
            geometry: Arc::new(Geometry::default()),
        };
        s.rebuild();
        s
    }

    /// Shows object `object` as the faceted `mesh` (the hand feels the mesh), or, with
    /// `None`, as its smooth surface again.
    pub fn set_faceted(&mut self, faceted: Option<(usize, &TriMesh)>) {
        self.faceted = faceted.map(|(object, mesh)| {
            let mut g = Geometry::default();
            faceted_into(&mut g, mesh);
            (object, g)
        });
        self.rebuild();
    }

    /// Shows object `object` in its current shape `now` over its rest shape `rest`, drawn
    /// faint (a deforming object, [`crate::gui::moving_shape`]), or, with `None`, at rest again.
    pub fn set_moving(&mut self, moving: Option<(usize, &Object, &Object)>) {
        self.moving = moving.map(|(object, rest, now)| {
            let mut g = Geometry::default();
            moving_into(&mut g, rest, now);
            (object, g)
        });
        self.rebuild();
    }

    /// Whether a deforming object's current shape is shown.
    pub fn is_moving(&self) -> bool {
        self.moving.is_some()
    }

    fn rebuild(&mut self) {
        let mut g = Geometry {
            revision: next_revision(),
            ..Geometry::default()
        };
        let range = |ranges: &[std::ops::Range<usize>], i: Option<usize>| {
            i.and_then(|i| ranges.get(i).cloned()).unwrap_or(0..0)
        };
        let faceted = self.faceted.as_ref().map(|(i, _)| *i);
        let moving = self.moving.as_ref().map(|(i, _)| *i);
        let hidden = [
            range(&self.object_triangles, faceted),
            range(&self.object_triangles, moving),
        ];
        let stride = 3 * VERTEX_FLOATS;
        for (k, c) in self.base.centroids.iter().enumerate() {
            if !hidden.iter().any(|h| h.contains(&k)) {
                g.triangles
                    .extend_from_slice(&self.base.triangles[k * stride..(k + 1) * stride]);
                g.centroids.push(*c);
            }
        }
        // A deforming object's control net moves with it: its rest net is not drawn.
        let hidden_lines = range(&self.object_lines, moving);
        let stride = 2 * VERTEX_FLOATS;
        for k in 0..self.base.segment_count() {
            if !hidden_lines.contains(&k) {
                g.lines
                    .extend_from_slice(&self.base.lines[k * stride..(k + 1) * stride]);
            }
        }
        for (_, extra) in self.faceted.iter().chain(&self.moving) {
            g.triangles.extend_from_slice(&extra.triangles);
            g.centroids.extend_from_slice(&extra.centroids);
            g.lines.extend_from_slice(&extra.lines);
        }
        self.geometry = Arc::new(g);
    }
}

/// A deforming object: its surfaces in the shape `now` on a [`MOVING_GRID`] grid, smooth
/// shaded, with their control nets, over [`REST_LINES`] iso-parameter lines each way of the
/// rest shape `rest`, faint.
fn moving_into(g: &mut Geometry, rest: &Object, now: &Object) {
    let (Some(rest), Some(now)) = (rest.surface_views(), now.surface_views()) else {
        return;
    };
    for (r, s) in rest.iter().zip(&now) {
        let ((u0, u1), (v0, v1)) = s.domain();
        let n = MOVING_GRID;
        let at = |i: usize, j: usize| {
            let (u, v) = (
                u0 + (u1 - u0) * i as f32 / n as f32,
                v0 + (v1 - v0) * j as f32 / n as f32,
            );
            (s.point(u, v), s.normal(u, v))
        };
        let grid: Vec<(Vec3, Vec3)> = (0..=n)
            .flat_map(|i| (0..=n).map(move |j| (i, j)))
            .map(|(i, j)| at(i, j))
            .collect();
        let idx = |i: usize, j: usize| i * (n + 1) + j;
        for i in 0..n {
            for j in 0..n {
                let [a, b, c, d] = [idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)];
                for tri in [[a, b, c], [a, c, d]] {
                    g.triangle(tri.map(|k| grid[k].0), tri.map(|k| grid[k].1), SURFACE);
                }
            }
        }
        let (nu, nv) = s.counts();
        let net = |i: usize, j: usize| {
            s.points()
                .get(i * nv + j)
                .map(|h| Vec3::new(h.x / h.w, h.y / h.w, h.z / h.w))
        };
        for i in 0..nu {
            for j in 0..nv {
                let Some(a) = net(i, j) else { continue };
                let next_u = (i + 1 < nu).then(|| net(i + 1, j)).flatten();
                let next_v = (j + 1 < nv).then(|| net(i, j + 1)).flatten();
                for b in [next_u, next_v].into_iter().flatten() {
                    g.segment(a, b, NET);
                }
            }
        }
        let ((u0, u1), (v0, v1)) = r.domain();
        let samples = 4 * MOVING_GRID;
        let lerp = |a: f32, b: f32, k: usize, n: usize| a + (b - a) * k as f32 / n as f32;
        for k in 0..=REST_LINES {
            let (u, v) = (lerp(u0, u1, k, REST_LINES), lerp(v0, v1, k, REST_LINES));
            for m in 0..samples {
                let (a, b) = (lerp(v0, v1, m, samples), lerp(v0, v1, m + 1, samples));
                g.segment(r.point(u, a), r.point(u, b), REST);
                let (a, b) = (lerp(u0, u1, m, samples), lerp(u0, u1, m + 1, samples));
                g.segment(r.point(a, v), r.point(b, v), REST);
            }
        }
    }
}

/// `mesh` flat shaded (each triangle its face normal), its edges drawn thin.
fn faceted_into(g: &mut Geometry, mesh: &TriMesh) {
    let edge = [0.55, 0.42, 0.25, 1.0];
    for (tri, n) in mesh.triangles().iter().zip(mesh.normals()) {
        let p = tri.map(|k| mesh.vertices()[k as usize]);
        g.triangle(p, [*n; 3], FACETED);
        // Lifted a little along the normal so that the edges are not hidden by the faces
        // (there is no depth test; the lift only matters for the back-to-front order).
        let lift = *n * 1e-5;
        for k in 0..3 {
            g.segment(p[k] + lift, p[(k + 1) % 3] + lift, edge);
        }
    }
}
