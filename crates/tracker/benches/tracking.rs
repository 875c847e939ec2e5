//! Closest-point cost and accuracy on identical geometry: this crate's tracker (one
//! Gauss–Newton step per tick), its Newton point inversion and its global search, against the
//! closest-point searches of two Rust CAD kernels, `truck-geometry` and `curvo` (f64).
//!
//! Geometry: a bicubic 8×8 non-rational surface `z = 0.1 sin(3x) cos(2y)` and a planar cubic
//! with 8 control points `y = 0.1 sin(4x)`, clamped uniform knots. The f32 control points and
//! knots are the source of truth; the f64 kernels get them cast exactly, so all methods see
//! the same patch.
//!
//! The haptic interface point (HIP) moves along a closed path of 1024 points about 0.1 mm
//! apart, from 1 mm inside to 2 mm outside the patch, and every warm-started method is handed
//! the previous tick's answer (its own). Before timing, an accuracy table goes to stderr:
//! every method against a reference closest point computed in f64 by an evaluator written
//! here (P&T A2.1, A2.3) and Newton from the exact construction of the path (the HIP is
//! `S(t*) + d n(t*)`, so `t*` is stationary by construction; f64 Newton absorbs the rounding
//! of the HIP to f32).
//!
//! The baselines as called: truck `BSplineSurface::search_nearest_parameter(x, (u, v), 100)`
//! and `BSplineCurve::search_nearest_parameter(x, u, 100)` (Newton with the full Hessian; each
//! of the six derivatives is a separate evaluation over the whole net; `None` as hint runs a
//! 50-sample presearch first); curvo `NurbsSurface3D::find_closest_parameter(&x, Some((u, v)))`
//! (argmin Newton damped by γ = 0.25, up to 100 iterations, until the step is below f64 ε;
//! `None` tessellates first) and `NurbsCurve2D::find_closest_parameter(&x)`, which takes no
//! hint (a polyline presearch of `points × degree` samples, then at most 5 Newton steps).

use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion, criterion_group, criterion_main};
use nalgebra::{SVector, Vector2, Vector3};
use nurbs::{CurveBuf, SurfaceBuf, Vec2, Vec3};
use std::f64::consts::TAU;
use std::hint::black_box;
use tracker::{GlobalConfig, NewtonConfig, Tracker, TrackerConfig, closest_point, newton};
use truck_geometry::prelude::{ParametricCurve, ParametricSurface, SearchNearestParameter};

/// HIP positions per closed path (a power of two: the index wraps with a mask).
const PATH_LEN: usize = 1024;
/// Mean HIP displacement per tick, metres.
const STEP_M: f64 = 1e-4;
/// Haptic tick.
const PERIOD_S: f32 = 1e-3;
/// Newton iteration cap handed to truck (its own doc example uses 100).
const TRUCK_TRIALS: usize = 100;
/// Passes over the path before a warm-started method is measured.
const WARM_CYCLES: usize = 2;

// ---------------------------------------------------------------------------------------------
// Geometry (f32, the source of truth)
// ---------------------------------------------------------------------------------------------

fn surface_net() -> Vec<Vec<Vec3>> {
    (0..8)
        .map(|i| {
            (0..8)
                .map(|j| {
                    let (x, y) = (i as f32 / 7.0, j as f32 / 7.0);
                    Vec3::new(x, y, 0.1 * (3.0 * x).sin() * (2.0 * y).cos())
                })
                .collect()
        })
        .collect()
}

fn curve_points() -> Vec<Vec2> {
    (0..8)
        .map(|i| {
            let x = i as f32 / 7.0;
            Vec2::new(x, 0.1 * (4.0 * x).sin())
        })
        .collect()
}

fn cast(k: &[f32]) -> Vec<f64> {
    k.iter().map(|&x| f64::from(x)).collect()
}

// ---------------------------------------------------------------------------------------------
// Independent f64 reference evaluator (non-rational, degree ≤ 3)
// ---------------------------------------------------------------------------------------------

/// Knot span of `u` (P&T A2.1), clamped knot vector.
fn find_span(knots: &[f64], p: usize, u: f64) -> usize {
    let n = knots.len() - p - 2;
    if u >= knots[n + 1] {
        return n;
    }
    if u <= knots[p] {
        return p;
    }
    let (mut lo, mut hi) = (p, n + 1);
    let mut mid = (lo + hi) / 2;
    while u < knots[mid] || u >= knots[mid + 1] {
        if u < knots[mid] {
            hi = mid;
        } else {
            lo = mid;
        }
        mid = (lo + hi) / 2;
    }
    mid
}

/// Non-zero basis functions and their first two derivatives at `u` (P&T A2.3).
fn ders_basis(knots: &[f64], p: usize, span: usize, u: f64) -> [[f64; 4]; 3] {
    let mut ndu = [[0.0; 4]; 4];
    let mut left = [0.0; 4];
    let mut right = [0.0; 4];
    ndu[0][0] = 1.0;
    for j in 1..=p {
        left[j] = u - knots[span + 1 - j];
        right[j] = knots[span + j] - u;
        let mut saved = 0.0;
        for r in 0..j {
            ndu[j][r] = right[r + 1] + left[j - r];
            let temp = ndu[r][j - 1] / ndu[j][r];
            ndu[r][j] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        ndu[j][j] = saved;
    }
    let mut ders = [[0.0; 4]; 3];
    for j in 0..=p {
        ders[0][j] = ndu[j][p];
    }
    let n = p.min(2);
    for r in 0..=p {
        let (mut s1, mut s2) = (0, 1);
        let mut a = [[0.0; 4]; 2];
        a[0][0] = 1.0;
        for k in 1..=n {
            let mut d = 0.0;
            let rk = r as isize - k as isize;
            let pk = p - k;
            if r >= k {
                a[s2][0] = a[s1][0] / ndu[pk + 1][rk as usize];
                d = a[s2][0] * ndu[rk as usize][pk];
            }
            let j1 = if rk >= -1 { 1 } else { (-rk) as usize };
            let j2 = if r as isize - 1 <= pk as isize {
                k - 1
            } else {
                p - r
            };
            for j in j1..=j2 {
                let idx = (rk + j as isize) as usize;
                a[s2][j] = (a[s1][j] - a[s1][j - 1]) / ndu[pk + 1][idx];
                d += a[s2][j] * ndu[idx][pk];
            }
            if r <= pk {
                a[s2][k] = -a[s1][k - 1] / ndu[pk + 1][r];
                d += a[s2][k] * ndu[r][pk];
            }
            ders[k][r] = d;
            std::mem::swap(&mut s1, &mut s2);
        }
    }
    let mut f = p as f64;
    for k in 1..=n {
        for j in 0..=p {
            ders[k][j] *= f;
        }
        f *= (p - k) as f64;
    }
    ders
}

struct Surface64 {
    p: usize,
    knots_u: Vec<f64>,
    knots_v: Vec<f64>,
    net: Vec<Vec<Vector3<f64>>>,
}

/// `[S, S_u, S_v, S_uu, S_uv, S_vv]`.
type SurfaceJet64 = [Vector3<f64>; 6];

impl Surface64 {
    fn jet(&self, [u, v]: [f64; 2]) -> SurfaceJet64 {
        let p = self.p;
        let su = find_span(&self.knots_u, p, u);
        let sv = find_span(&self.knots_v, p, v);
        let nu = ders_basis(&self.knots_u, p, su, u);
        let nv = ders_basis(&self.knots_v, p, sv, v);
        let mut out = [Vector3::zeros(); 6];
        for (slot, (a, b)) in [(0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2)]
            .into_iter()
            .enumerate()
        {
            for i in 0..=p {
                for j in 0..=p {
                    out[slot] += self.net[su - p + i][sv - p + j] * (nu[a][i] * nv[b][j]);
                }
            }
        }
        out
    }

    fn point(&self, t: [f64; 2]) -> Vector3<f64> {
        self.jet(t)[0]
    }

    fn normal(&self, t: [f64; 2]) -> Vector3<f64> {
        let j = self.jet(t);
        j[1].cross(&j[2]).normalize()
    }

    /// Newton on `(S − x)·S_i = 0` with the full Hessian, to round-off.
    fn closest(&self, x: Vector3<f64>, mut t: [f64; 2]) -> [f64; 2] {
        for _ in 0..50 {
            let [s, su, sv, suu, suv, svv] = self.jet(t);
            let g = s - x;
            let f = [su.dot(&g), sv.dot(&g)];
            let (a, b, d) = (
                su.dot(&su) + g.dot(&suu),
                su.dot(&sv) + g.dot(&suv),
                sv.dot(&sv) + g.dot(&svv),
            );
            let det = a * d - b * b;
            let step = [(d * f[0] - b * f[1]) / det, (a * f[1] - b * f[0]) / det];
            t = [
                (t[0] - step[0]).clamp(0.0, 1.0),
                (t[1] - step[1]).clamp(0.0, 1.0),
            ];
            if step[0].abs() + step[1].abs() < 1e-15 {
                break;
            }
        }
        t
    }
}

struct Curve64 {
    p: usize,
    knots: Vec<f64>,
    points: Vec<Vector2<f64>>,
}

impl Curve64 {
    /// `[C, C', C'']`.
    fn jet(&self, [u]: [f64; 1]) -> [Vector2<f64>; 3] {
        let p = self.p;
        let span = find_span(&self.knots, p, u);
        let n = ders_basis(&self.knots, p, span, u);
        let mut out = [Vector2::zeros(); 3];
        for (k, o) in out.iter_mut().enumerate() {
            for i in 0..=p {
                *o += self.points[span - p + i] * n[k][i];
            }
        }
        out
    }

    fn point(&self, t: [f64; 1]) -> Vector2<f64> {
        self.jet(t)[0]
    }

    fn normal(&self, t: [f64; 1]) -> Vector2<f64> {
        let d = self.jet(t)[1].normalize();
        Vector2::new(-d.y, d.x)
    }

    fn closest(&self, x: Vector2<f64>, [mut u]: [f64; 1]) -> [f64; 1] {
        for _ in 0..50 {
            let [c, d1, d2] = self.jet([u]);
            let g = c - x;
            let step = d1.dot(&g) / (d1.dot(&d1) + g.dot(&d2));
            u = (u - step).clamp(0.0, 1.0);
            if step.abs() < 1e-15 {
                break;
            }
        }
        [u]
    }
}

// ---------------------------------------------------------------------------------------------
// HIP path and reference closest points
// ---------------------------------------------------------------------------------------------

/// The path, with the reference closest point per HIP (f64, for the HIP rounded to f32).
struct Path<const N: usize, const D: usize> {
    /// HIP as every method sees it: rounded to f32, then widened again.
    hip: Vec<SVector<f64, D>>,
    t_ref: Vec<[f64; N]>,
    point_ref: Vec<SVector<f64, D>>,
    dist_ref: Vec<f64>,
}

impl<const N: usize, const D: usize> Path<N, D> {
    fn build(
        nominal: impl Fn(f64, f64) -> ([f64; N], SVector<f64, D>),
        point: impl Fn([f64; N]) -> SVector<f64, D>,
        closest: impl Fn(SVector<f64, D>, [f64; N]) -> [f64; N],
    ) -> Self {
        // Scale the parameter excursion so the mean step is STEP_M (the map is nearly linear at
        // this size: two rescalings settle it).
        let length = |scale: f64| -> f64 {
            let pts: Vec<_> = (0..PATH_LEN)
                .map(|k| nominal(k as f64 / PATH_LEN as f64, scale).1)
                .collect();
            (0..PATH_LEN)
                .map(|k| (pts[(k + 1) % PATH_LEN] - pts[k]).norm())
                .sum()
        };
        let target = STEP_M * PATH_LEN as f64;
        let mut scale = 0.02;
        for _ in 0..3 {
            scale *= target / length(scale);
        }
        let mut path = Path {
            hip: Vec::with_capacity(PATH_LEN),
            t_ref: Vec::with_capacity(PATH_LEN),
            point_ref: Vec::with_capacity(PATH_LEN),
            dist_ref: Vec::with_capacity(PATH_LEN),
        };
        let mut max_shift = 0.0f64;
        for k in 0..PATH_LEN {
            let (t0, x) = nominal(k as f64 / PATH_LEN as f64, scale);
            let x = x.map(|c| f64::from(c as f32));
            let t = closest(x, t0);
            for i in 0..N {
                max_shift = max_shift.max((t[i] - t0[i]).abs());
            }
            let p = point(t);
            path.hip.push(x);
            path.t_ref.push(t);
            path.point_ref.push(p);
            path.dist_ref.push((x - p).norm());
        }
        // The construction is exact up to the f32 rounding of the HIP.
        assert!(
            max_shift < 1e-6,
            "reference left the construction: {max_shift:e}"
        );
        let steps: Vec<f64> = (0..PATH_LEN)
            .map(|k| (path.hip[(k + 1) % PATH_LEN] - path.hip[k]).norm())
            .collect();
        eprintln!(
            "  path: {PATH_LEN} HIPs, step mean {:.3} mm, max {:.3} mm; distance {:.2}..{:.2} mm; \
             reference moved ≤ {max_shift:.1e} from the construction",
            1e3 * steps.iter().sum::<f64>() / PATH_LEN as f64,
            1e3 * steps.iter().copied().fold(0.0, f64::max),
            1e3 * path.dist_ref.iter().copied().fold(f64::INFINITY, f64::min),
            1e3 * path.dist_ref.iter().copied().fold(0.0, f64::max),
        );
        path
    }

    fn vec3(&self, i: usize) -> Vec3 {
        let x = &self.hip[i];
        Vec3::new(x[0] as f32, x[1] as f32, x[2] as f32)
    }

    fn vec2(&self, i: usize) -> Vec2 {
        let x = &self.hip[i];
        Vec2::new(x[0] as f32, x[1] as f32)
    }
}

// ---------------------------------------------------------------------------------------------
// Accuracy and timing harness
// ---------------------------------------------------------------------------------------------

/// One closest-point query per HIP index; `None` when the method reports a failure.
trait Step<const N: usize>: FnMut(usize) -> Option<[f64; N]> {}
impl<const N: usize, F: FnMut(usize) -> Option<[f64; N]>> Step<N> for F {}

fn accuracy<const N: usize, const D: usize>(
    name: &str,
    path: &Path<N, D>,
    point: impl Fn([f64; N]) -> SVector<f64, D>,
    warm_cycles: usize,
    mut step: impl Step<N>,
) {
    for _ in 0..warm_cycles {
        for i in 0..PATH_LEN {
            step(i);
        }
    }
    let (mut max_d, mut max_p, mut sum_p, mut failures) = (0.0f64, 0.0f64, 0.0, 0);
    for i in 0..PATH_LEN {
        match step(i) {
            Some(t) => {
                let p = point(t);
                max_d = max_d.max(((path.hip[i] - p).norm() - path.dist_ref[i]).abs());
                let e = (p - path.point_ref[i]).norm();
                max_p = max_p.max(e);
                sum_p += e;
            }
            None => failures += 1,
        }
    }
    let n_ok = (PATH_LEN - failures).max(1) as f64;
    eprintln!(
        "  {name:<28} {max_d:>12.2e} {max_p:>12.2e} {:>12.2e} {failures:>6}",
        sum_p / n_ok
    );
}

fn table_header(title: &str) {
    eprintln!("\n{title}");
    eprintln!(
        "  {:<28} {:>12} {:>12} {:>12} {:>6}",
        "method", "max|Δdist|/m", "max|Δcp|/m", "mean|Δcp|/m", "fails"
    );
}

fn time<const N: usize>(g: &mut BenchmarkGroup<'_, WallTime>, id: &str, mut step: impl Step<N>) {
    for _ in 0..WARM_CYCLES {
        for i in 0..PATH_LEN {
            black_box(step(i));
        }
    }
    let mut i = 0;
    g.bench_function(id, |b| {
        b.iter(|| {
            i = (i + 1) % PATH_LEN;
            step(black_box(i))
        })
    });
}

fn f64x2(t: [f32; 2]) -> [f64; 2] {
    [f64::from(t[0]), f64::from(t[1])]
}

fn f32x2(t: [f64; 2]) -> [f32; 2] {
    [t[0] as f32, t[1] as f32]
}

// ---------------------------------------------------------------------------------------------
// Surface
// ---------------------------------------------------------------------------------------------

fn surface(c: &mut Criterion) {
    let net32 = surface_net();
    let knots32 = nurbs::construct::uniform_knots(8, 3);
    let ours = SurfaceBuf::from_rows::<_, Vec<f32>>(
        (3, 3),
        (knots32.clone(), knots32.clone()),
        &net32,
        None,
    )
    .expect("valid bench surface");
    let view = ours.view();
    let net64: Vec<Vec<Vector3<f64>>> = net32
        .iter()
        .map(|row| row.iter().map(|p| p.as_dvec3().to_array().into()).collect())
        .collect();
    let knots64 = cast(&knots32);
    let reference = Surface64 {
        p: 3,
        knots_u: knots64.clone(),
        knots_v: knots64.clone(),
        net: net64.clone(),
    };
    let truck_surface = truck_geometry::prelude::BSplineSurface::new(
        (
            truck_geometry::prelude::KnotVec::from(knots64.clone()),
            truck_geometry::prelude::KnotVec::from(knots64.clone()),
        ),
        net64
            .iter()
            .map(|row| {
                row.iter()
                    .map(|p| truck_geometry::prelude::Point3::new(p.x, p.y, p.z))
                    .collect()
            })
            .collect(),
    );
    let curvo_surface = curvo::prelude::NurbsSurface3D::<f64>::new(
        3,
        3,
        knots64.clone(),
        knots64.clone(),
        net64
            .iter()
            .map(|row| {
                row.iter()
                    .map(|p| nalgebra::Point4::new(p.x, p.y, p.z, 1.0))
                    .collect()
            })
            .collect(),
    );

    // Identical geometry: the kernels and our f32 surface against the reference evaluator.
    // truck's jet is checked term by term, since its Newton uses all six. truck-geometry 0.5.0
    // gets S_uu and S_vv wrong near clamped ends (here in every span but the middle one of
    // five; half the true value at the boundary), so only S is asserted.
    let na3 = |w: truck_geometry::prelude::Vector3| Vector3::new(w.x, w.y, w.z);
    let mut dev_truck = [0.0f64; 6];
    let (mut dev_curvo, mut dev_ours) = (0.0f64, 0.0f64);
    for a in 0..=16 {
        for b in 0..=16 {
            let t = [a as f64 / 16.0, b as f64 / 16.0];
            let r = reference.jet(t);
            let (u, v) = (t[0], t[1]);
            let p = truck_surface.subs(u, v);
            let truck_jet = [
                Vector3::new(p.x, p.y, p.z),
                na3(truck_surface.uder(u, v)),
                na3(truck_surface.vder(u, v)),
                na3(truck_surface.uuder(u, v)),
                na3(truck_surface.uvder(u, v)),
                na3(truck_surface.vvder(u, v)),
            ];
            for k in 0..6 {
                dev_truck[k] = dev_truck[k].max((truck_jet[k] - r[k]).norm());
            }
            dev_curvo = dev_curvo.max((curvo_surface.point_at(u, v).coords - r[0]).norm());
            let o = view.point(u as f32, v as f32).as_dvec3().to_array();
            dev_ours = dev_ours.max((Vector3::from(o) - r[0]).norm());
        }
    }
    eprintln!(
        "\nsurface: bicubic 8×8; max deviation from the f64 reference over a 17×17 grid: \
         curvo S {dev_curvo:.1e}, ours (f32) S {dev_ours:.1e}, truck S {:.1e} S_u {:.1e} \
         S_v {:.1e} S_uu {:.1e} S_uv {:.1e} S_vv {:.1e}",
        dev_truck[0], dev_truck[1], dev_truck[2], dev_truck[3], dev_truck[4], dev_truck[5]
    );
    assert!(
        dev_truck[0] < 1e-12 && dev_curvo < 1e-12 && dev_ours < 1e-6,
        "the kernels do not see the same surface"
    );

    // Parameter circle around (0.45, 0.55); the HIP rides 1 mm inside to 2 mm outside.
    let path = Path::<2, 3>::build(
        |s, r| {
            let th = TAU * s;
            let t = [0.45 + r * th.cos(), 0.55 + r * th.sin()];
            let d = 0.5e-3 + 1.5e-3 * (5.0 * th).sin();
            (t, reference.point(t) + reference.normal(t) * d)
        },
        |t| reference.point(t),
        |x, t| reference.closest(x, t),
    );
    let hips32: Vec<Vec3> = (0..PATH_LEN).map(|i| path.vec3(i)).collect();
    let hips_truck: Vec<_> = path
        .hip
        .iter()
        .map(|x| truck_geometry::prelude::Point3::new(x.x, x.y, x.z))
        .collect();
    let hips_curvo: Vec<_> = path
        .hip
        .iter()
        .map(|x| nalgebra::Point3::from(*x))
        .collect();
    let t_start = path.t_ref[PATH_LEN - 1];
    let ncfg = &NewtonConfig::default();
    let gcfg = &GlobalConfig::default();
    // The factories below are called twice (accuracy, timing): their steps borrow.
    let (hips32, hips_truck, hips_curvo) = (&hips32, &hips_truck, &hips_curvo);
    let (truck_surface, curvo_surface) = (&truck_surface, &curvo_surface);

    let ours_tracker = || {
        let mut tracker = Tracker::new(&view, f32x2(t_start), TrackerConfig::default());
        move |i: usize| {
            let tr = tracker.update(&view, hips32[i], PERIOD_S);
            black_box(&tr);
            Some(f64x2(tr.t))
        }
    };
    let ours_newton = || {
        let mut t = f32x2(t_start);
        move |i: usize| {
            let r = newton(&view, hips32[i], t, ncfg);
            black_box(&r);
            t = r.t;
            Some(f64x2(t))
        }
    };
    let ours_global = || {
        move |i: usize| {
            let r = closest_point(&view, hips32[i], gcfg);
            black_box(&r);
            Some(f64x2(r.t))
        }
    };
    let truck_warm = || {
        let mut t = (t_start[0], t_start[1]);
        move |i: usize| {
            let r = truck_surface.search_nearest_parameter(hips_truck[i], t, TRUCK_TRIALS)?;
            t = r;
            Some([r.0, r.1])
        }
    };
    let truck_cold = || {
        move |i: usize| {
            let r = truck_surface.search_nearest_parameter(
                hips_truck[i],
                None::<(f64, f64)>,
                TRUCK_TRIALS,
            )?;
            Some([r.0, r.1])
        }
    };
    let curvo_warm = || {
        let mut t = (t_start[0], t_start[1]);
        move |i: usize| {
            let r = curvo_surface
                .find_closest_parameter(&hips_curvo[i], Some(t))
                .ok()?;
            t = r;
            Some([r.0, r.1])
        }
    };
    let curvo_cold = || {
        move |i: usize| {
            let r = curvo_surface
                .find_closest_parameter(&hips_curvo[i], None)
                .ok()?;
            Some([r.0, r.1])
        }
    };

    table_header("surface accuracy (f64 evaluation at each method's parameters vs reference)");
    let pt = |t: [f64; 2]| reference.point(t);
    accuracy(
        "ours tracker.update (warm)",
        &path,
        pt,
        WARM_CYCLES,
        ours_tracker(),
    );
    accuracy("ours newton (warm)", &path, pt, WARM_CYCLES, ours_newton());
    accuracy("ours closest_point (cold)", &path, pt, 0, ours_global());
    accuracy("truck (warm hint)", &path, pt, WARM_CYCLES, truck_warm());
    accuracy("truck (hint None)", &path, pt, 0, truck_cold());
    accuracy("curvo (warm hint)", &path, pt, WARM_CYCLES, curvo_warm());
    accuracy("curvo (hint None)", &path, pt, 0, curvo_cold());
    {
        let mut t = f32x2(t_start);
        let mut iterations = 0u64;
        for i in 0..PATH_LEN {
            let r = newton(&view, hips32[i], t, ncfg);
            iterations += u64::from(r.iterations);
            t = r.t;
        }
        eprintln!(
            "  ours newton (warm): {:.2} iterations per tick",
            iterations as f64 / PATH_LEN as f64
        );
    }

    let mut g = c.benchmark_group("surface");
    time(&mut g, "ours_tracker_update", ours_tracker());
    time(&mut g, "ours_newton_warm", ours_newton());
    time(&mut g, "truck_warm", truck_warm());
    time(&mut g, "curvo_warm", curvo_warm());
    g.finish();
    let mut g = c.benchmark_group("surface_cold");
    g.sample_size(20);
    time(&mut g, "ours_global", ours_global());
    time(&mut g, "truck_cold", truck_cold());
    time(&mut g, "curvo_cold", curvo_cold());
    g.finish();
}

// ---------------------------------------------------------------------------------------------
// Curve
// ---------------------------------------------------------------------------------------------

fn curve(c: &mut Criterion) {
    let pts32 = curve_points();
    let knots32 = nurbs::construct::uniform_knots(8, 3);
    let ours = CurveBuf::from_cartesian(3, knots32.clone(), &pts32, None).expect("valid curve");
    let view = ours.view();
    let pts64: Vec<Vector2<f64>> = pts32
        .iter()
        .map(|p| Vector2::new(f64::from(p.x), f64::from(p.y)))
        .collect();
    let knots64 = cast(&knots32);
    let reference = Curve64 {
        p: 3,
        knots: knots64.clone(),
        points: pts64.clone(),
    };
    let truck_curve = truck_geometry::prelude::BSplineCurve::new(
        truck_geometry::prelude::KnotVec::from(knots64.clone()),
        pts64
            .iter()
            .map(|p| truck_geometry::prelude::Point2::new(p.x, p.y))
            .collect(),
    );
    let curvo_curve = curvo::prelude::NurbsCurve2D::<f64>::try_new(
        3,
        pts64
            .iter()
            .map(|p| nalgebra::Point3::new(p.x, p.y, 1.0))
            .collect(),
        knots64.clone(),
    )
    .expect("valid curvo curve");

    let na2 = |w: truck_geometry::prelude::Vector2| Vector2::new(w.x, w.y);
    let mut dev_truck = [0.0f64; 3];
    let (mut dev_curvo, mut dev_ours) = (0.0f64, 0.0f64);
    for a in 0..=64 {
        let t = [a as f64 / 64.0];
        let r = reference.jet(t);
        let p = truck_curve.subs(t[0]);
        let truck_jet = [
            Vector2::new(p.x, p.y),
            na2(truck_curve.der(t[0])),
            na2(truck_curve.der2(t[0])),
        ];
        for k in 0..3 {
            dev_truck[k] = dev_truck[k].max((truck_jet[k] - r[k]).norm());
        }
        dev_curvo = dev_curvo.max((curvo_curve.point_at(t[0]).coords - r[0]).norm());
        let o = view.point(t[0] as f32);
        dev_ours = dev_ours.max((Vector2::new(f64::from(o.x), f64::from(o.y)) - r[0]).norm());
    }
    eprintln!(
        "\ncurve: planar cubic, 8 points; max deviation from the f64 reference over 65 \
         samples: curvo C {dev_curvo:.1e}, ours (f32) C {dev_ours:.1e}, truck C {:.1e} \
         C' {:.1e} C'' {:.1e}",
        dev_truck[0], dev_truck[1], dev_truck[2]
    );
    assert!(
        dev_truck[0] < 1e-12 && dev_curvo < 1e-12 && dev_ours < 1e-6,
        "the kernels do not see the same curve"
    );

    // The HIP sweeps back and forth along the middle of the curve, 1 mm inside to 2 mm
    // outside.
    let path = Path::<1, 2>::build(
        |s, a| {
            let th = TAU * s;
            let t = [0.5 + a * th.sin()];
            let d = 0.5e-3 + 1.5e-3 * (3.0 * th).cos();
            (t, reference.point(t) + reference.normal(t) * d)
        },
        |t| reference.point(t),
        |x, t| reference.closest(x, t),
    );
    let hips32: Vec<Vec2> = (0..PATH_LEN).map(|i| path.vec2(i)).collect();
    let hips_truck: Vec<_> = path
        .hip
        .iter()
        .map(|x| truck_geometry::prelude::Point2::new(x.x, x.y))
        .collect();
    let hips_curvo: Vec<_> = path
        .hip
        .iter()
        .map(|x| nalgebra::Point2::from(*x))
        .collect();
    let t_start = path.t_ref[PATH_LEN - 1][0];
    let ncfg = &NewtonConfig::default();
    let gcfg = &GlobalConfig::default();
    let (hips32, hips_truck, hips_curvo) = (&hips32, &hips_truck, &hips_curvo);
    let (truck_curve, curvo_curve) = (&truck_curve, &curvo_curve);

    let ours_tracker = || {
        let mut tracker = Tracker::new(&view, [t_start as f32], TrackerConfig::default());
        move |i: usize| {
            let tr = tracker.update(&view, hips32[i], PERIOD_S);
            black_box(&tr);
            Some([f64::from(tr.t[0])])
        }
    };
    let ours_newton = || {
        let mut t = [t_start as f32];
        move |i: usize| {
            let r = newton(&view, hips32[i], t, ncfg);
            black_box(&r);
            t = r.t;
            Some([f64::from(t[0])])
        }
    };
    let ours_global = || {
        move |i: usize| {
            let r = closest_point(&view, hips32[i], gcfg);
            black_box(&r);
            Some([f64::from(r.t[0])])
        }
    };
    let truck_warm = || {
        let mut t = t_start;
        move |i: usize| {
            t = truck_curve.search_nearest_parameter(hips_truck[i], t, TRUCK_TRIALS)?;
            Some([t])
        }
    };
    let truck_cold = || {
        move |i: usize| {
            let t =
                truck_curve.search_nearest_parameter(hips_truck[i], None::<f64>, TRUCK_TRIALS)?;
            Some([t])
        }
    };
    // curvo's curve search takes no hint: every call samples the curve and polishes.
    let curvo_cold = || {
        move |i: usize| {
            let t = curvo_curve.find_closest_parameter(&hips_curvo[i]).ok()?;
            Some([t])
        }
    };

    table_header("curve accuracy (f64 evaluation at each method's parameters vs reference)");
    let pt = |t: [f64; 1]| reference.point(t);
    accuracy(
        "ours tracker.update (warm)",
        &path,
        pt,
        WARM_CYCLES,
        ours_tracker(),
    );
    accuracy("ours newton (warm)", &path, pt, WARM_CYCLES, ours_newton());
    accuracy("ours closest_point (cold)", &path, pt, 0, ours_global());
    accuracy("truck (warm hint)", &path, pt, WARM_CYCLES, truck_warm());
    accuracy("truck (hint None)", &path, pt, 0, truck_cold());
    accuracy("curvo (no hint in API)", &path, pt, 0, curvo_cold());
    {
        let mut t = [t_start as f32];
        let mut iterations = 0u64;
        for i in 0..PATH_LEN {
            let r = newton(&view, hips32[i], t, ncfg);
            iterations += u64::from(r.iterations);
            t = r.t;
        }
        eprintln!(
            "  ours newton (warm): {:.2} iterations per tick",
            iterations as f64 / PATH_LEN as f64
        );
    }

    let mut g = c.benchmark_group("curve");
    time(&mut g, "ours_tracker_update", ours_tracker());
    time(&mut g, "ours_newton_warm", ours_newton());
    time(&mut g, "truck_warm", truck_warm());
    g.finish();
    let mut g = c.benchmark_group("curve_cold");
    g.sample_size(20);
    time(&mut g, "ours_global", ours_global());
    time(&mut g, "truck_cold", truck_cold());
    time(&mut g, "curvo_cold", curvo_cold());
    g.finish();
}

criterion_group!(benches, surface, curve);
criterion_main!(benches);
