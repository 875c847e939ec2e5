//! The 3-D view of a scene of surfaces (and spatial curves), drawn with wgpu inside egui
//! through a paint callback ([`egui_wgpu::Callback`]): the shaded surfaces (tessellated for
//! display only), their control nets and the spatial curves; over them, with egui's painter
//! and the same camera, the HIP, CP, GO, the hand's target and the force vectors.
//!
//! egui's render pass has no depth buffer (and the snapshot harness's has none either), so the
//! triangles are sorted back to front on the CPU every frame (painter's algorithm, a stable
//! sort: the same picture for the same camera) and drawn two-sided with a head light.
//!
//! Mouse: primary drag moves the hand in the view plane (the plane through the hand's target
//! perpendicular to the view direction); the wheel while the hand is held (or shift + wheel)
//! moves it in depth, 1 mm per 50 points of scroll, along the view direction; secondary or
//! middle drag, or alt + primary drag, orbits; the wheel zooms; a double click fits the scene.

use std::sync::Arc;

use eframe::egui;
use eframe::egui_wgpu::{self, wgpu};
use egui::{Align2, Color32, FontId, Pos2, Rect, Sense, Shape, Stroke};
use friction::Mode;
use glam::{Mat4, Vec4};
use nurbs::Vec3;
use tracker::TriMesh;

use super::spatial::SpatialState;
use super::state::AppState;
use super::view::mode_colour;
use scene::{Object, Patch, Scene};

/// Chordal tolerance of the display tessellation (m): display only, finer than any haptic
/// tessellation the slider offers.
pub const DISPLAY_TOL_M: f32 = 2e-4;
/// Samples per spatial curve drawn.
pub const WIRE_SAMPLES: usize = 256;
/// Force arrows: metres of the scene per newton.
pub const M_PER_N: f32 = 0.01;

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
    /// faint (a deforming object, [`super::deform`]), or, with `None`, at rest again.
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

/// The orbiting camera: it looks at `target` from `distance_m` away, from the direction given
/// by `yaw_rad` (about +z, from +x) and `pitch_rad` (above the x-y plane); z is up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera3d {
    /// The point looked at (m).
    pub target: Vec3,
    /// Azimuth of the eye about +z (rad).
    pub yaw_rad: f32,
    /// Elevation of the eye above the x-y plane (rad).
    pub pitch_rad: f32,
    /// Eye to target (m).
    pub distance_m: f32,
    /// Vertical field of view (rad).
    pub fov_y_rad: f32,
    /// Fit to the scene at the next frame.
    pub fit_pending: bool,
}

impl Default for Camera3d {
    fn default() -> Self {
        Camera3d {
            target: Vec3::new(0.0, 0.09, 0.0),
            yaw_rad: -60f32.to_radians(),
            pitch_rad: 22f32.to_radians(),
            distance_m: 0.25,
            fov_y_rad: 35f32.to_radians(),
            fit_pending: true,
        }
    }
}

impl Camera3d {
    /// The eye's position.
    pub fn eye(&self) -> Vec3 {
        let (sy, cy) = self.yaw_rad.sin_cos();
        let (sp, cp) = self.pitch_rad.sin_cos();
        self.target + Vec3::new(cp * cy, cp * sy, sp) * self.distance_m
    }

    /// Unit view direction, eye to target.
    pub fn view_dir(&self) -> Vec3 {
        (self.target - self.eye()).normalize_or(Vec3::NEG_Z)
    }

    /// Clip-space transform for a viewport of `aspect` (width / height), wgpu depth [0, 1].
    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        let near = self.distance_m * 0.02;
        let far = self.distance_m * 20.0;
        Mat4::perspective_rh(self.fov_y_rad, aspect.max(1e-3), near, far)
            * Mat4::look_at_rh(self.eye(), self.target, Vec3::Z)
    }

    /// Where `p` appears in `rect` (None behind the eye).
    pub fn project(&self, rect: Rect, p: Vec3) -> Option<Pos2> {
        let clip = self.view_proj(rect.aspect_ratio()) * Vec4::new(p.x, p.y, p.z, 1.0);
        if clip.w <= 1e-9 {
            return None;
        }
        let ndc = clip / clip.w;
        Some(Pos2::new(
            rect.center().x + ndc.x * rect.width() * 0.5,
            rect.center().y - ndc.y * rect.height() * 0.5,
        ))
    }

    /// The ray from the eye through `pos` in `rect`: origin and unit direction.
    pub fn ray(&self, rect: Rect, pos: Pos2) -> (Vec3, Vec3) {
        // From the camera's own frame rather than the inverse of its matrix: metres near
        // 0.1 through a perspective inverse lose a micrometre in f32.
        let forward = self.view_dir();
        let right = forward.cross(Vec3::Z).normalize_or(Vec3::X);
        let up = right.cross(forward);
        let half_h = (self.fov_y_rad * 0.5).tan();
        let half_w = half_h * rect.aspect_ratio();
        let ndc_x = (pos.x - rect.center().x) / (rect.width() * 0.5);
        let ndc_y = -(pos.y - rect.center().y) / (rect.height() * 0.5);
        let d = forward + right * (ndc_x * half_w) + up * (ndc_y * half_h);
        (self.eye(), d.normalize_or(forward))
    }

    /// Where the ray through `pos` meets the plane through `through` perpendicular to the
    /// view direction (the hand's plane); None when the ray runs parallel to it.
    pub fn on_view_plane(&self, rect: Rect, pos: Pos2, through: Vec3) -> Option<Vec3> {
        let (o, d) = self.ray(rect, pos);
        let n = self.view_dir();
        let den = d.dot(n);
        if den.abs() < 1e-6 {
            return None;
        }
        let t = (through - o).dot(n) / den;
        (t > 0.0).then(|| o + d * t)
    }

    /// Centres `bounds` (with `include`) in a view of `aspect` (width / height) at a
    /// distance that shows all of it: its bounding sphere within the narrower field of view.
    pub fn fit(&mut self, (lo, hi): (Vec3, Vec3), include: Vec3, aspect: f32) {
        let (lo, hi) = (lo.min(include), hi.max(include));
        self.target = (lo + hi) * 0.5;
        let radius = ((hi - lo).length() * 0.5).max(0.005);
        let half_y = self.fov_y_rad * 0.5;
        let half_x = (half_y.tan() * aspect.max(0.1)).atan();
        self.distance_m = radius / half_y.min(half_x).sin() * 0.95;
        self.fit_pending = false;
    }

    /// The head light's direction (towards the light): from behind the eye, above and to
    /// the right of it, so that a bump seen from the front still shows its relief.
    pub fn light_dir(&self) -> Vec3 {
        let forward = self.view_dir();
        let right = forward.cross(Vec3::Z).normalize_or(Vec3::X);
        let up = right.cross(forward);
        (-forward + up * 0.7 + right * 0.35).normalize_or(-forward)
    }

    /// Orbits by a drag of `delta` points.
    pub fn orbit(&mut self, delta: egui::Vec2) {
        self.yaw_rad -= delta.x * 0.01;
        let limit = 89f32.to_radians();
        self.pitch_rad = (self.pitch_rad + delta.y * 0.01).clamp(-limit, limit);
    }
}

/// The wgpu side of the view: pipelines and buffers, kept in egui_wgpu's callback resources.
struct Renderer3d {
    triangles: wgpu::RenderPipeline,
    lines: wgpu::RenderPipeline,
    uniforms: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    buffers: Option<GpuBuffers>,
}

struct GpuBuffers {
    revision: u64,
    triangles: wgpu::Buffer,
    lines: wgpu::Buffer,
    line_vertices: u32,
    indices: wgpu::Buffer,
    index_capacity: u64,
    index_count: u32,
}

const SHADER: &str = r"
struct Uniforms { view_proj: mat4x4<f32>, light: vec4<f32> };
@group(0) @binding(0) var<uniform> u: Uniforms;
struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) colour: vec4<f32>,
};
struct VertexOut { @builtin(position) clip: vec4<f32>, @location(0) colour: vec4<f32> };
@vertex fn vs_main(v: VertexIn) -> VertexOut {
    var out: VertexOut;
    out.clip = u.view_proj * vec4<f32>(v.position, 1.0);
    var shade = 1.0;
    if (dot(v.normal, v.normal) > 0.0) {
        // Two-sided head light: the surface seen from below is lit as from above.
        shade = 0.35 + 0.65 * abs(dot(normalize(v.normal), u.light.xyz));
    }
    out.colour = vec4<f32>(v.colour.rgb * shade, v.colour.a);
    return out;
}
@fragment fn fs_main(i: VertexOut) -> @location(0) vec4<f32> { return i.colour; }
";

/// Builds the view's pipelines for `render_state` (its target format) and keeps them in its
/// callback resources; call once, when the app (or a snapshot harness) starts. Without it the
/// view draws its overlay only and says so.
pub fn install(render_state: &egui_wgpu::RenderState) {
    let device = &render_state.device;
    let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("view3d"),
        source: wgpu::ShaderSource::Wgsl(SHADER.into()),
    });
    let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("view3d uniforms"),
        size: 80,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("view3d"),
        entries: &[wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::VERTEX,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: std::num::NonZeroU64::new(80),
            },
            count: None,
        }],
    });
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("view3d"),
        layout: &layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: uniforms.as_entire_binding(),
        }],
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("view3d"),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x4];
    let pipeline = |topology: wgpu::PrimitiveTopology| {
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("view3d"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs_main"),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: (VERTEX_FLOATS * 4) as u64,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &attributes,
                })],
                compilation_options: wgpu::PipelineCompilationOptions::default(),
            },
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs_main"),
                targets: &[Some(wgpu::ColorTargetState {
                    format: render_state.target_format,
                    blend: Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
                compilation_options: wgpu::PipelineCompilationOptions::default(),
            }),
            primitive: wgpu::PrimitiveState {
                topology,
                cull_mode: None,
                ..wgpu::PrimitiveState::default()
            },
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            multiview_mask: None,
            cache: None,
        })
    };
    let renderer = Renderer3d {
        triangles: pipeline(wgpu::PrimitiveTopology::TriangleList),
        lines: pipeline(wgpu::PrimitiveTopology::LineList),
        uniforms,
        bind_group,
        buffers: None,
    };
    render_state
        .renderer
        .write()
        .callback_resources
        .insert(renderer);
}

/// Whether [`install`] ran for the renderer of `ctx`'s painter; set by the app.
#[derive(Clone, Copy, Debug, Default)]
pub struct Installed(pub bool);

/// One frame of the view for the GPU.
struct Draw3d {
    geometry: Arc<Geometry>,
    /// Triangle vertex indices, back to front.
    order: Vec<u32>,
    uniforms: [f32; 20],
}

fn bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

impl egui_wgpu::CallbackTrait for Draw3d {
    fn prepare(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        _screen: &egui_wgpu::ScreenDescriptor,
        _encoder: &mut wgpu::CommandEncoder,
        resources: &mut egui_wgpu::CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        use wgpu::util::DeviceExt;
        let Some(r) = resources.get_mut::<Renderer3d>() else {
            return Vec::new();
        };
        queue.write_buffer(&r.uniforms, 0, &bytes(&self.uniforms));
        let g = &self.geometry;
        if r.buffers.as_ref().map(|b| b.revision) != Some(g.revision) {
            let vertex_buffer = |data: &[f32], label: &str| {
                // A buffer of at least one vertex: wgpu refuses empty vertex buffers.
                let mut data = data.to_vec();
                if data.is_empty() {
                    data.resize(VERTEX_FLOATS, 0.0);
                }
                device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents: &bytes(&data),
                    usage: wgpu::BufferUsages::VERTEX,
                })
            };
            let index_capacity = (g.triangle_count().max(1) * 3 * 4) as u64;
            r.buffers = Some(GpuBuffers {
                revision: g.revision,
                triangles: vertex_buffer(&g.triangles, "view3d triangles"),
                lines: vertex_buffer(&g.lines, "view3d lines"),
                line_vertices: (g.lines.len() / VERTEX_FLOATS) as u32,
                indices: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("view3d indices"),
                    size: index_capacity,
                    usage: wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
                index_capacity,
                index_count: 0,
            });
        }
        if let Some(b) = &mut r.buffers {
            let data: Vec<u8> = self.order.iter().flat_map(|i| i.to_le_bytes()).collect();
            if (data.len() as u64) <= b.index_capacity {
                queue.write_buffer(&b.indices, 0, &data);
                b.index_count = self.order.len() as u32;
            } else {
                b.index_count = 0;
            }
        }
        Vec::new()
    }

    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        resources: &egui_wgpu::CallbackResources,
    ) {
        let Some(r) = resources.get::<Renderer3d>() else {
            return;
        };
        let Some(b) = &r.buffers else {
            return;
        };
        pass.set_bind_group(0, &r.bind_group, &[]);
        if b.index_count > 0 {
            pass.set_pipeline(&r.triangles);
            pass.set_vertex_buffer(0, b.triangles.slice(..));
            pass.set_index_buffer(b.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..b.index_count, 0, 0..1);
        }
        if b.line_vertices > 0 {
            pass.set_pipeline(&r.lines);
            pass.set_vertex_buffer(0, b.lines.slice(..));
            pass.draw(0..b.line_vertices, 0..1);
        }
    }
}

/// The triangles' vertex indices, farthest triangle first (a stable sort on the distance of
/// the centroids from the eye).
pub fn back_to_front(geometry: &Geometry, eye: Vec3) -> Vec<u32> {
    let mut order: Vec<(f32, u32)> = geometry
        .centroids
        .iter()
        .enumerate()
        .map(|(k, c)| ((*c - eye).length_squared(), k as u32))
        .collect();
    order.sort_by(|a, b| b.0.total_cmp(&a.0));
    order
        .into_iter()
        .flat_map(|(_, k)| [3 * k, 3 * k + 1, 3 * k + 2])
        .collect()
}

/// The 3-D view, filling the space it is given. `installed` says whether the wgpu side is
/// there ([`install`]).
pub fn view_3d_ui(ui: &mut egui::Ui, state: &mut AppState, camera: &mut Camera3d, installed: bool) {
    let size = ui.available_size();
    let (response, painter) = ui.allocate_painter(size, Sense::click_and_drag());
    let rect = response.rect;
    painter.rect_filled(rect, 0.0, Color32::from_gray(245));
    let Some(spatial) = state.spatial.as_mut() else {
        painter.text(
            rect.center(),
            Align2::CENTER_CENTER,
            "no 3-D scene",
            FontId::proportional(16.0),
            Color32::from_gray(60),
        );
        return;
    };
    if camera.fit_pending || response.double_clicked() {
        camera.fit(spatial.view.bounds, spatial.start, rect.aspect_ratio());
    }
    controls_ui(ui, rect, spatial, camera);

    let modifiers = ui.input(|i| i.modifiers);
    let orbiting = response.dragged_by(egui::PointerButton::Secondary)
        || response.dragged_by(egui::PointerButton::Middle)
        || (modifiers.alt && response.dragged_by(egui::PointerButton::Primary));
    if orbiting {
        camera.orbit(response.drag_delta());
    }
    let primary_down = ui.input(|i| i.pointer.primary_down());
    let holding = response.is_pointer_button_down_on() && primary_down && !modifiers.alt;
    if response.hovered() {
        let (scroll, zoom) = ui.input(|i| (i.smooth_scroll_delta(), i.zoom_delta()));
        // The wheel moves the hand in depth while it is held (or with shift), else zooms.
        if modifiers.shift || holding {
            // Shift turns the wheel sideways on some platforms: take both axes.
            let notches = (scroll.y + scroll.x) / 50.0;
            if notches.abs() > 1e-3 {
                let target = spatial.target + camera.view_dir() * (notches * 1e-3);
                spatial.set_target(target);
            }
        } else {
            let factor = zoom * (scroll.y / 200.0).exp();
            if (factor - 1.0).abs() > 1e-4 {
                camera.distance_m = (camera.distance_m / factor).clamp(0.01, 2.0);
            }
        }
    }
    if !orbiting && holding {
        if let Some(p) = response.interact_pointer_pos()
            && let Some(target) = camera.on_view_plane(rect, p, spatial.target)
        {
            state.dragging = true;
            spatial.set_target(target);
        }
    } else {
        state.dragging = false;
    }

    let geometry = spatial.view.geometry.clone();
    if installed {
        let light = camera.light_dir();
        let mut uniforms = [0.0f32; 20];
        uniforms[..16].copy_from_slice(&camera.view_proj(rect.aspect_ratio()).to_cols_array());
        uniforms[16..19].copy_from_slice(&light.to_array());
        let draw = Draw3d {
            order: back_to_front(&geometry, camera.eye()),
            geometry,
            uniforms,
        };
        painter.add(egui_wgpu::Callback::new_paint_callback(rect, draw));
    }
    let painter = painter.with_clip_rect(rect);
    let latest = state.latest().copied();
    let spatial = state.spatial.as_ref();
    let deforming = state
        .deform
        .moving
        .is_some()
        .then(|| super::view::deform_summary(state));
    if let Some(spatial) = spatial {
        draw_hand(&painter, rect, camera, spatial, latest.as_ref());
        draw_axes(&painter, rect, camera);
        draw_legend(
            &painter,
            rect,
            spatial,
            latest.as_ref(),
            installed,
            deforming.as_deref(),
        );
    }
}

/// The representation switch, the chordal tolerance, the export and the fit buttons, top
/// right.
fn controls_ui(ui: &mut egui::Ui, rect: Rect, spatial: &mut SpatialState, camera: &mut Camera3d) {
    let area = Rect::from_min_max(
        egui::pos2(rect.right() - 330.0, rect.top() + 6.0),
        egui::pos2(rect.right() - 6.0, rect.top() + 130.0),
    );
    ui.scope_builder(egui::UiBuilder::new().max_rect(area), |ui| {
        egui::Frame::popup(ui.style()).show(ui, |ui| {
            ui.horizontal(|ui| {
                if ui.button("fit").clicked() {
                    camera.fit(spatial.view.bounds, spatial.start, rect.aspect_ratio());
                }
                if spatial.can_tessellate() {
                    let mut mesh = spatial.render_mesh;
                    ui.label("feel:");
                    let a = ui.radio_value(&mut mesh, false, "NURBS");
                    let b = ui.radio_value(&mut mesh, true, "mesh");
                    if a.changed() || b.changed() {
                        spatial.set_render_mesh(mesh);
                    }
                }
            });
            if spatial.can_tessellate() {
                let mut tol_mm = spatial.tolerance_m * 1e3;
                let slider = ui.add(
                    egui::Slider::new(&mut tol_mm, 0.05..=5.0)
                        .logarithmic(true)
                        .text("chordal tol. (mm)"),
                );
                if slider.drag_stopped() || (slider.changed() && !slider.dragged()) {
                    spatial.set_tolerance(tol_mm * 1e-3);
                } else if slider.changed() {
                    spatial.tolerance_m = tol_mm * 1e-3;
                }
                ui.horizontal(|ui| {
                    ui.add(
                        egui::TextEdit::singleline(&mut spatial.export_path)
                            .hint_text("out.obj")
                            .desired_width(150.0),
                    );
                    if ui.button("Export OBJ").clicked() {
                        spatial.export_obj_to_path();
                    }
                });
            }
            if let Some(m) = &spatial.message {
                ui.label(m);
            }
        });
    });
}

fn draw_hand(
    painter: &egui::Painter,
    rect: Rect,
    camera: &Camera3d,
    spatial: &SpatialState,
    latest: Option<&host::backend::Sample>,
) {
    let at = |p: Vec3| camera.project(rect, p);
    let blue = Color32::from_rgb(40, 110, 200);
    if let Some(t) = at(spatial.target) {
        let s = Stroke::new(1.5, Color32::from_rgb(90, 90, 200));
        painter.line_segment([t - egui::vec2(6.0, 0.0), t + egui::vec2(6.0, 0.0)], s);
        painter.line_segment([t - egui::vec2(0.0, 6.0), t + egui::vec2(0.0, 6.0)], s);
    }
    let Some(sample) = latest else {
        return;
    };
    let k = &sample.tick;
    let Some(hip) = at(k.hip) else {
        return;
    };
    let colour = mode_colour(k.mode);
    if k.mode != Mode::Free {
        if let (Some(cp), Some(go)) = (at(k.cp), at(k.go)) {
            painter.add(Shape::dashed_line(
                &[hip, cp],
                Stroke::new(1.0, Color32::from_gray(90)),
                3.0,
                3.0,
            ));
            painter.line_segment([hip, go], Stroke::new(1.0, Color32::from_gray(90)));
            painter.circle_stroke(cp, 4.0, Stroke::new(2.0, blue));
            painter.circle_filled(go, 4.5, colour);
            painter.circle_stroke(go, 4.5, Stroke::new(1.0, Color32::BLACK));
        }
        let arrow = |v: Vec3, colour: Color32, width: f32| {
            if let Some(end) = at(k.hip + v * M_PER_N)
                && (end - hip).length() > 1.0
            {
                painter.arrow(hip, end - hip, Stroke::new(width, colour));
            }
        };
        arrow(k.normal * k.normal_force_n, blue, 2.5);
        arrow(k.friction, colour, 2.5);
        arrow(k.force, Color32::from_gray(30), 1.0);
    }
    painter.circle_filled(hip, 6.0, colour);
    painter.circle_stroke(hip, 6.0, Stroke::new(1.5, Color32::BLACK));
}

/// x (red), y (green) and z (blue) in the bottom-left corner, 10 mm long at the target.
fn draw_axes(painter: &egui::Painter, rect: Rect, camera: &Camera3d) {
    let Some(o) = camera.project(rect, camera.target) else {
        return;
    };
    let corner = Pos2::new(rect.left() + 40.0, rect.bottom() - 40.0);
    for (axis, colour, name) in [
        (Vec3::X, Color32::from_rgb(200, 50, 50), "x"),
        (Vec3::Y, Color32::from_rgb(40, 150, 40), "y"),
        (Vec3::Z, Color32::from_rgb(40, 80, 210), "z"),
    ] {
        let Some(end) = camera.project(rect, camera.target + axis * 0.01) else {
            continue;
        };
        let d = (end - o).normalized() * 28.0;
        if d.is_finite() {
            painter.arrow(corner, d, Stroke::new(1.5, colour));
            painter.text(
                corner + d * 1.2,
                Align2::CENTER_CENTER,
                name,
                FontId::proportional(12.0),
                colour,
            );
        }
    }
}

fn draw_legend(
    painter: &egui::Painter,
    rect: Rect,
    spatial: &SpatialState,
    latest: Option<&host::backend::Sample>,
    installed: bool,
    deforming: Option<&str>,
) {
    let font = FontId::proportional(13.0);
    let text = Color32::from_gray(40);
    let x = rect.left() + 10.0;
    let mut y = rect.top() + 8.0;
    let mut line = |s: String, c: Color32| {
        painter.text(Pos2::new(x, y), Align2::LEFT_TOP, s, font.clone(), c);
        y += 17.0;
    };
    let felt = if spatial.render_mesh {
        format!(
            " (felt as its mesh, {} triangles)",
            spatial.mesh_triangles.unwrap_or(0)
        )
    } else {
        String::new()
    };
    match &spatial.view.rendered_name {
        Some(name) => line(format!("{}: {name}{felt}", spatial.view.label), text),
        None => line(
            format!("{}: no object of surfaces to feel", spatial.view.label),
            text,
        ),
    }
    if let Some(s) = latest {
        let k = &s.tick;
        line(super::view::tick_summary(k), mode_colour(k.mode));
        line(
            format!(
                "HIP ({:.1}, {:.1}, {:.1}) mm",
                k.hip.x * 1e3,
                k.hip.y * 1e3,
                k.hip.z * 1e3
            ),
            text,
        );
    }
    if let Some(d) = deforming {
        line(d.to_owned(), Color32::from_rgb(70, 90, 150));
    }
    if !installed {
        line(
            "(wgpu renderer not available: surfaces not drawn)".into(),
            Color32::from_rgb(190, 30, 30),
        );
    }
    let key_y = rect.bottom() - 8.0 - 17.0 * 3.0;
    let key = [
        "drag: hand  ·  wheel while dragging, or shift+wheel: depth  ·  right/alt-drag: orbit  \
         ·  wheel: zoom",
        "big dot: HIP (mode colour)  ·  ring: CP  ·  small dot: GO  ·  cross: hand",
        "arrows: blue normal, coloured friction, black total (10 mm per N)",
    ];
    for (i, s) in key.iter().enumerate() {
        painter.text(
            Pos2::new(rect.left() + 90.0, key_y + 17.0 * i as f32),
            Align2::LEFT_TOP,
            *s,
            font.clone(),
            Color32::from_gray(90),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hand's plane: a ray through the centre of the view meets the plane through the
    /// target at the target; one through a point 100 px to the right meets it to the right,
    /// at the distance the field of view gives (tan(fov/2) · d per half height).
    #[test]
    fn the_view_plane_follows_the_pointer() {
        let camera = Camera3d {
            target: Vec3::new(0.0, 0.09, 0.0),
            yaw_rad: 0.3,
            pitch_rad: 0.5,
            distance_m: 0.2,
            ..Camera3d::default()
        };
        let rect = Rect::from_min_size(Pos2::ZERO, egui::vec2(800.0, 600.0));
        let hit = camera
            .on_view_plane(rect, rect.center(), camera.target)
            .expect("hit");
        assert!((hit - camera.target).length() < 1e-6, "{hit}");
        let right = camera
            .on_view_plane(rect, rect.center() + egui::vec2(100.0, 0.0), camera.target)
            .expect("hit");
        let offset = right - camera.target;
        assert!(offset.dot(camera.view_dir()).abs() < 1e-6);
        let expected = (camera.fov_y_rad * 0.5).tan() * 0.2 * (100.0 / 300.0);
        assert!((offset.length() - expected).abs() < 1e-6, "{offset}");
        // And it projects back where the pointer is.
        let back = camera.project(rect, right).expect("in front");
        assert!((back - (rect.center() + egui::vec2(100.0, 0.0))).length() < 0.01);
    }
}
