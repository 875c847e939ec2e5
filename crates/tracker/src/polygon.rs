//! The polygonal baseline: the "intermediate representation" methods the thesis compares the
//! tracker against (§2.1.3, Figure 2.1.2 (b)). A curve is tessellated into a polyline and a
//! surface into triangles, both to a chordal tolerance, and the closest point is searched on the
//! flat pieces. The normal reported there is the piece's own (segment or triangle) normal, which
//! jumps from piece to piece and differs from the true normal by up to half the turning angle
//! between pieces: the force-direction artefact of this family of methods.
//!
//! Host only (`alloc`): tessellation allocates, and the search visits every piece.

use alloc::vec::Vec;
use nurbs::{Curve, Point, Surface, Vec3};

/// Deepest bisection of one knot span of a curve.
pub const MAX_CURVE_DEPTH: u32 = 16;
/// Most vertices a [`Polyline`] gets.
pub const MAX_POLYLINE_VERTICES: usize = 1 << 16;
/// Most grid cells (two triangles each) a [`TriMesh`] gets.
pub const MAX_MESH_CELLS: usize = 1 << 16;
/// Most refinement passes of the surface grid.
const MAX_MESH_PASSES: u32 = 16;

/// The closest point of a [`Polyline`] to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentHit<P> {
    /// Closest point on the polyline.
    pub point: P,
    /// Curve parameter at `point`, interpolated linearly between the segment's end vertices.
    pub t: f32,
    /// Squared distance from the query point to `point`.
    pub distance_squared: f32,
    /// Index of the segment (between vertices `segment` and `segment + 1`).
    pub segment: usize,
    /// Position along the segment, 0 at its start vertex and 1 at its end.
    pub along: f32,
    /// The segment's unit normal (see [`Polyline::segment_normal`]).
    pub normal: P,
}

/// A curve approximated by straight segments, with the curve parameter of every vertex.
#[derive(Clone, Debug, PartialEq)]
pub struct Polyline<P> {
    points: Vec<P>,
    params: Vec<f32>,
    normals: Vec<P>,
}

impl<P: Point> Polyline<P> {
    /// Tessellates `curve` to the chordal tolerance `tol_m` (metres) by adaptive bisection.
    ///
    /// Every knot span is one starting interval (the curve is smooth inside a span only). An
    /// interval is split at its parameter midpoint while the chord height, the largest distance
    /// of the curve points at ¼, ½ and ¾ of the interval from the chord, exceeds `tol_m`; a
    /// span is bisected at most [`MAX_CURVE_DEPTH`] times and the polyline never exceeds
    /// [`MAX_POLYLINE_VERTICES`] vertices, so the work stays bounded for a zero, negative or
    /// NaN tolerance. Vertices lie on the curve; zero-length segments are dropped.
    pub fn tessellate(curve: &Curve<'_, P>, tol_m: f32) -> Self {
        let (a, b) = curve.domain();
        let mut points = Vec::new();
        let mut params = Vec::new();
        let first = curve.point(a);
        points.push(first);
        params.push(a);
        let knots = curve.knots().as_slice();
        let spans = knots.windows(2).filter(|w| w[1] > w[0]).count();
        let mut ctx = CurveTess {
            curve,
            tol_m,
            points,
            params,
            splits_left: MAX_POLYLINE_VERTICES.saturating_sub(1 + spans),
        };
        let mut start = a;
        let mut start_point = first;
        for &k in knots {
            if k > start && k <= b {
                let end_point = curve.point(k);
                ctx.subdivide(start, start_point, k, end_point, 0);
                start = k;
                start_point = end_point;
            }
        }
        let CurveTess { points, params, .. } = ctx;
        Polyline::from_vertices(points, params)
    }

    /// A polyline through `points`, whose curve parameters are `params` (same length, at least
    /// two entries to have a segment).
    fn from_vertices(points: Vec<P>, params: Vec<f32>) -> Self {
        let n = points.len().saturating_sub(1);
        let dirs: Vec<Option<P>> = (0..n)
            .map(|i| (points[i + 1] - points[i]).try_normalize())
            .collect();
        let normals = (0..n)
            .map(|i| {
                let Some(dir) = dirs[i] else {
                    return P::ZERO;
                };
                // Discrete second derivative: the turn from the previous to the next segment.
                // Planar normals ignore it; spatial ones point towards the side the polyline
                // turns to (the discrete principal normal).
                let prev = if i > 0 { dirs[i - 1] } else { None };
                let next = dirs.get(i + 1).copied().flatten();
                let turn = next.unwrap_or(dir) - prev.unwrap_or(dir);
                P::curve_normal(dir, turn)
            })
            .collect();
        Polyline {
            points,
            params,
            normals,
        }
    }

    /// The vertices (all on the curve).
    pub fn points(&self) -> &[P] {
        &self.points
    }

    /// The curve parameter of each vertex, non-decreasing.
    pub fn params(&self) -> &[f32] {
        &self.params
    }

    /// Number of segments.
    pub fn segment_count(&self) -> usize {
        self.points.len().saturating_sub(1)
    }

    /// Unit normal of segment `i`: for planar curves the segment direction turned clockwise,
    /// `(d.y, −d.x)`, the same convention as the curve's normals (outward on a
    /// counter-clockwise closed curve); for spatial curves the component of the turn between
    /// the neighbouring segments orthogonal to this one. Zero for a degenerate polyline or an
    /// index past the end.
    pub fn segment_normal(&self, i: usize) -> P {
        self.normals.get(i).copied().unwrap_or(P::ZERO)
    }

    /// The closest point to `x` over all segments (a linear scan). A polyline with a single
    /// vertex reports that vertex.
    pub fn closest(&self, x: P) -> SegmentHit<P> {
        let mut best = SegmentHit {
            point: self.points[0],
            t: self.params[0],
            distance_squared: (self.points[0] - x).length_squared(),
            segment: 0,
            along: 0.0,
            normal: self.segment_normal(0),
        };
        for i in 0..self.segment_count() {
            let (a, b) = (self.points[i], self.points[i + 1]);
            let (point, along) = closest_point_on_segment(a, b, x);
            let d2 = (point - x).length_squared();
            if d2 < best.distance_squared {
                let (ta, tb) = (self.params[i], self.params[i + 1]);
                best = SegmentHit {
                    point,
                    t: ta + (tb - ta) * along,
                    distance_squared: d2,
                    segment: i,
                    along,
                    normal: self.normals[i],
                };
            }
        }
        best
    }
}

/// Working state of the recursive curve tessellation.
struct CurveTess<'c, 'a, P: Point> {
    curve: &'c Curve<'a, P>,
    tol_m: f32,
    points: Vec<P>,
    params: Vec<f32>,
    /// Every pending interval emits one vertex and every split adds one interval, so
    /// limiting the splits to `MAX_POLYLINE_VERTICES − 1 − spans` caps the vertex count.
    splits_left: usize,
}

impl<P: Point> CurveTess<'_, '_, P> {
    /// Emits the vertices of `(u0, u1]`; the vertex at `u0` has been emitted already.
    fn subdivide(&mut self, u0: f32, p0: P, u1: f32, p1: P, depth: u32) {
        let um = 0.5 * (u0 + u1);
        // `um` can equal an end in f32 once the interval is a few ulps wide.
        let splittable = depth < MAX_CURVE_DEPTH && self.splits_left > 0 && um > u0 && um < u1;
        if splittable && self.exceeds(u0, p0, u1, p1) {
            self.splits_left -= 1;
            let pm = self.curve.point(um);
            self.subdivide(u0, p0, um, pm, depth + 1);
            self.subdivide(um, pm, u1, p1, depth + 1);
        } else if p1 != p0 {
            self.points.push(p1);
            self.params.push(u1);
        } else if let Some(last) = self.params.last_mut() {
            // A zero-length piece: keep the vertex, move its parameter to the interval's end so
            // the parameters still cover the domain.
            *last = u1;
        }
    }

    /// Whether the chord height over `[u0, u1]`, sampled at ¼, ½ and ¾, exceeds the tolerance
    /// (true for a NaN tolerance).
    fn exceeds(&self, u0: f32, p0: P, u1: f32, p1: P) -> bool {
        [0.25f32, 0.5, 0.75].iter().any(|&s| {
            let p = self.curve.point(u0 + (u1 - u0) * s);
            let (q, _) = closest_point_on_segment(p0, p1, p);
            exceeds((p - q).length_squared(), self.tol_m)
        })
    }
}

/// Whether a squared deviation `h2` exceeds the tolerance `tol_m`: always for a NaN, and for
/// any nonzero deviation when the tolerance is not positive (the caps then bound the work).
fn exceeds(h2: f32, tol_m: f32) -> bool {
    if tol_m.is_nan() || h2.is_nan() {
        true
    } else if tol_m <= 0.0 {
        h2 > 0.0
    } else {
        h2 > tol_m * tol_m
    }
}

/// The closest point to `x` on the segment `a b`, and its position along the segment in
/// `[0, 1]` (0 for a degenerate segment).
pub fn closest_point_on_segment<P: Point>(a: P, b: P, x: P) -> (P, f32) {
    let ab = b - a;
    let l2 = ab.length_squared();
    let s = if l2 > 0.0 { (x - a).dot(ab) / l2 } else { 0.0 };
    // NaN (non-finite input) → 0.
    let s = if s.is_nan() { 0.0 } else { s.clamp(0.0, 1.0) };
    (a + ab * s, s)
}

/// The closest point to `p` on the triangle `a b c` and its barycentric coordinates
/// `(w_a, w_b, w_c)` (Ericson, Real-Time Collision Detection §5.1.5: Voronoi regions of the
/// vertices, then the edges, then the face). The triangle must not be degenerate.
pub fn closest_point_on_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> (Vec3, [f32; 3]) {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, [1.0, 0.0, 0.0]);
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (b, [0.0, 1.0, 0.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (a + ab * v, [1.0 - v, v, 0.0]);
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (c, [0.0, 0.0, 1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (a + ac * w, [1.0 - w, 0.0, w]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * w, [0.0, 1.0 - w, w]);
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    (a + ab * v + ac * w, [1.0 - v - w, v, w])
}

/// The closest point of a [`TriMesh`] to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    /// Closest point on the mesh.
    pub point: Vec3,
    /// Surface parameters at `point`, interpolated barycentrically from the triangle's vertices.
    pub t: [f32; 2],
    /// Squared distance from the query point to `point`.
    pub distance_squared: f32,
    /// Index of the triangle.
    pub triangle: usize,
    /// Barycentric coordinates of `point` in the triangle.
    pub barycentric: [f32; 3],
    /// The triangle's unit normal.
    pub normal: Vec3,
}

/// A surface approximated by triangles, with the surface parameters of every vertex.
#[derive(Clone, Debug, PartialEq)]
pub struct TriMesh {
    vertices: Vec<Vec3>,
    params: Vec<[f32; 2]>,
    triangles: Vec<[u32; 3]>,
    normals: Vec<Vec3>,
}

impl TriMesh {
    /// Tessellates `surface` to the chordal tolerance `tol_m` (metres) on an adaptive
    /// tensor-product grid.
    ///
    /// The grid starts at the distinct knots in each direction. Each pass evaluates every cell
    /// at three midpoints: of its two u-edges (distance from the edge chord), of its two
    /// v-edges, and of its centre (distance from the cell's two triangles). A u-interval
    /// (v-interval) whose u-edge (v-edge) midpoint, or centre, deviates by more than `tol_m` is
    /// bisected across the whole grid. Passes repeat until no cell exceeds the tolerance, up to
    /// [`MAX_MESH_CELLS`] cells. Each cell `(u_i, v_j)–(u_{i+1}, v_{j+1})` becomes the triangles
    /// `(00, 10, 11)` and `(00, 11, 01)`, oriented like `S_u × S_v`; degenerate triangles (of
    /// zero area, or slivers of a collapsed edge such as a pole) are dropped.
    pub fn tessellate(surface: &Surface<'_>, tol_m: f32) -> Self {
        let (ku, kv) = surface.knots();
        let mut us = distinct_knots(ku.as_slice(), ku.domain());
        let mut vs = distinct_knots(kv.as_slice(), kv.domain());
        let exceeds = |h2: f32| exceeds(h2, tol_m);
        for _ in 0..MAX_MESH_PASSES {
            let grid = Grid::evaluate(surface, &us, &vs);
            let mut split_u = alloc::vec![false; us.len() - 1];
            let mut split_v = alloc::vec![false; vs.len() - 1];
            for i in 0..us.len() - 1 {
                let um = 0.5 * (us[i] + us[i + 1]);
                for j in 0..vs.len() - 1 {
                    let vm = 0.5 * (vs[j] + vs[j + 1]);
                    let [p00, p10, p01, p11] = grid.cell(i, j);
                    let u_edges = [(vs[j], p00, p10), (vs[j + 1], p01, p11)];
                    if u_edges.iter().any(|&(v, a, b)| {
                        let p = surface.point(um, v);
                        exceeds((closest_point_on_segment(a, b, p).0 - p).length_squared())
                    }) {
                        split_u[i] = true;
                    }
                    let v_edges = [(us[i], p00, p01), (us[i + 1], p10, p11)];
                    if v_edges.iter().any(|&(u, a, b)| {
                        let p = surface.point(u, vm);
                        exceeds((closest_point_on_segment(a, b, p).0 - p).length_squared())
                    }) {
                        split_v[j] = true;
                    }
                    let c = surface.point(um, vm);
                    let h2 = cell_triangles(p00, p10, p01, p11)
                        .into_iter()
                        .flatten()
                        .map(|[a, b, d]| {
                            (closest_point_on_triangle(c, a, b, d).0 - c).length_squared()
                        })
                        .fold(f32::INFINITY, f32::min);
                    if h2.is_finite() && exceeds(h2) {
                        split_u[i] = true;
                        split_v[j] = true;
                    }
                }
            }
            let new_nu = us.len() - 1 + split_u.iter().filter(|&&s| s).count();
            let new_nv = vs.len() - 1 + split_v.iter().filter(|&&s| s).count();
            let unchanged = new_nu == us.len() - 1 && new_nv == vs.len() - 1;
            if unchanged || new_nu * new_nv > MAX_MESH_CELLS {
                break;
            }
            us = refine(&us, &split_u);
            vs = refine(&vs, &split_v);
        }
        TriMesh::from_grid(&Grid::evaluate(surface, &us, &vs), &us, &vs)
    }

    fn from_grid(grid: &Grid, us: &[f32], vs: &[f32]) -> Self {
        let nv = vs.len();
        let mut params = Vec::with_capacity(grid.points.len());
        for &u in us {
            for &v in vs {
                params.push([u, v]);
            }
        }
        let mut triangles = Vec::new();
        let mut normals = Vec::new();
        let index = |i: usize, j: usize| (i * nv + j) as u32;
        for i in 0..us.len() - 1 {
            for j in 0..nv - 1 {
                let corners = [
                    index(i, j),
                    index(i + 1, j),
                    index(i, j + 1),
                    index(i + 1, j + 1),
                ];
                let [i00, i10, i01, i11] = corners;
                for tri in [[i00, i10, i11], [i00, i11, i01]] {
                    let [a, b, c] = tri.map(|k| grid.points[k as usize]);
                    if let Some(n) = triangle_normal(a, b, c) {
                        triangles.push(tri);
                        normals.push(n);
                    }
                }
            }
        }
        TriMesh {
            vertices: grid.points.clone(),
            params,
            triangles,
            normals,
        }
    }

    /// A mesh of given triangles (an imported mesh, or several tessellations joined):
    /// `vertices`, the surface parameters of each (`[0, 0]` where there are none: `params`
    /// shorter than `vertices` is padded), and triangles of vertex indices. Triangles with an
    /// index out of range or of zero area get no normal and are dropped.
    pub fn from_triangles(
        vertices: Vec<Vec3>,
        mut params: Vec<[f32; 2]>,
        triangles: &[[u32; 3]],
    ) -> Self {
        params.resize(vertices.len(), [0.0; 2]);
        let mut kept = Vec::with_capacity(triangles.len());
        let mut normals = Vec::with_capacity(triangles.len());
        for tri in triangles {
            let [Some(a), Some(b), Some(c)] = tri.map(|k| vertices.get(k as usize).copied()) else {
                continue;
            };
            if let Some(n) = triangle_normal(a, b, c) {
                kept.push(*tri);
                normals.push(n);
            }
        }
        TriMesh {
            vertices,
            params,
            triangles: kept,
            normals,
        }
    }

    /// The vertices (all on the surface).
    pub fn vertices(&self) -> &[Vec3] {
        &self.vertices
    }

    /// The surface parameters of each vertex.
    pub fn params(&self) -> &[[f32; 2]] {
        &self.params
    }

    /// Vertex indices of each triangle.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Unit normal of each triangle.
    pub fn normals(&self) -> &[Vec3] {
        &self.normals
    }

    /// The closest point to `x` over all triangles (a linear scan); `None` for a mesh without
    /// triangles (a surface degenerate everywhere).
    pub fn closest(&self, x: Vec3) -> Option<TriangleHit> {
        let mut best: Option<TriangleHit> = None;
        for (k, tri) in self.triangles.iter().enumerate() {
            let [a, b, c] = tri.map(|i| self.vertices[i as usize]);
            let (point, w) = closest_point_on_triangle(x, a, b, c);
            let d2 = (point - x).length_squared();
            if best.is_none_or(|h| d2 < h.distance_squared) {
                let [pa, pb, pc] = tri.map(|i| self.params[i as usize]);
                let t = [0, 1].map(|d| w[0] * pa[d] + w[1] * pb[d] + w[2] * pc[d]);
                best = Some(TriangleHit {
                    point,
                    t,
                    distance_squared: d2,
                    triangle: k,
                    barycentric: w,
                    normal: self.normals[k],
                });
            }
        }
        best
    }
}

/// Surface points on a tensor grid, `points[i * vs.len() + j] = S(us[i], vs[j])`.
struct Grid {
    points: Vec<Vec3>,
    nv: usize,
}

impl Grid {
    fn evaluate(surface: &Surface<'_>, us: &[f32], vs: &[f32]) -> Self {
        let mut points = Vec::with_capacity(us.len() * vs.len());
        for &u in us {
            for &v in vs {
                points.push(surface.point(u, v));
            }
        }
        Grid {
            points,
            nv: vs.len(),
        }
    }

    /// Corners `[p00, p10, p01, p11]` of cell `(i, j)`.
    fn cell(&self, i: usize, j: usize) -> [Vec3; 4] {
        let at = |i: usize, j: usize| self.points[i * self.nv + j];
        [at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)]
    }
}

/// The two triangles of a cell, `None` where degenerate.
fn cell_triangles(p00: Vec3, p10: Vec3, p01: Vec3, p11: Vec3) -> [Option<[Vec3; 3]>; 2] {
    [[p00, p10, p11], [p00, p11, p01]].map(|[a, b, c]| triangle_normal(a, b, c).map(|_| [a, b, c]))
}

/// Unit normal `(b − a) × (c − a)` normalised, `None` for a degenerate triangle: one of
/// (numerically) zero area, or with an edge shorter than 10⁻⁴ of the longest. The second test
/// catches the slivers of collapsed grid edges (a pole evaluated at different `u` gives points
/// a few ulps apart), whose normals are rounding noise.
fn triangle_normal(a: Vec3, b: Vec3, c: Vec3) -> Option<Vec3> {
    let n = (b - a).cross(c - a);
    let edges = [
        (b - a).length_squared(),
        (c - b).length_squared(),
        (a - c).length_squared(),
    ];
    let longest = edges.iter().copied().fold(0.0, f32::max);
    let shortest = edges.iter().copied().fold(f32::INFINITY, f32::min);
    if n.length_squared() <= 1e-12 * longest * longest || shortest <= 1e-8 * longest {
        return None;
    }
    n.try_normalize()
}

/// The distinct knot values inside `[a, b]`, in order, including both ends.
fn distinct_knots(knots: &[f32], (a, b): (f32, f32)) -> Vec<f32> {
    let mut out = alloc::vec![a];
    for &k in knots {
        if k > *out.last().unwrap_or(&a) && k <= b {
            out.push(k);
        }
    }
    if out.len() < 2 {
        out.push(b);
    }
    out
}

/// `values` with the midpoint inserted into every interval marked in `split` (unless the
/// interval is too narrow to split in `f32`).
fn refine(values: &[f32], split: &[bool]) -> Vec<f32> {
    let mut out = Vec::with_capacity(values.len() + split.len());
    for i in 0..values.len() - 1 {
        out.push(values[i]);
        let m = 0.5 * (values[i] + values[i + 1]);
        if split[i] && m > values[i] && m < values[i + 1] {
            out.push(m);
        }
    }
    out.extend(values.last());
    out
}
