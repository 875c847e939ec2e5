//! Closest-point tracking against references the tracker did not produce: `f64` dense sampling
//! polished by Newton on random convex curves and domes, the closed-form closest points of the
//! circle, sphere and torus, and tick budgets derived from the update law.
//!
//! Measured convergence ([`convergence_statistics`], a deterministic sample of 300 random
//! cases each, printed with `--nocapture`; stationary HIP, random start, converged = error
//! within 1 µm for good), ticks median / p95 / max:
//!
//! - convex curves, normalised law: 4 / 9 / 14;
//! - convex curves, plain law (`K T H*` in [0.2, 1.9]): 4 / 29 / 46;
//! - convex domes, normalised law: 5 / 7 / 10;
//! - convex domes, plain law (`K T λ_max(H*)` in [0.2, 1.9]): 17 / 73 / 140 (the plain law
//!   pays for the conditioning of `H`; the normalised one does not).
//!
//! No case exceeded its derived budget.
#![allow(clippy::unwrap_used)]

use glam::DVec3;
use nurbs::{CurveBuf, Point, SurfaceBuf, Vec2, Vec3, construct};
use proptest::prelude::*;
use proptest::strategy::ValueTree;
use proptest::test_runner::{TestCaseError, TestRunner};
use testkit::{
    RefClosest, RefCurve, RefSurface, T, closest_on_curve, closest_on_surface, convex_curve,
    convex_dome, sym_eigen, v2, v3, wide,
};
use tracker::{Law, Patch, Track, Tracker, TrackerConfig};

/// Trust region of the default configuration: at most this fraction of the domain per tick.
const STEP_FRACTION: f64 = 0.25;
/// Point accuracy that counts as converged (metres).
const POINT_TOL: f64 = 1e-6;

// ---------------------------------------------------------------------------------------------
// Tick budgets
// ---------------------------------------------------------------------------------------------

/// The law under test, as the tests see it.
#[derive(Clone, Copy, Debug)]
enum LawUnderTest {
    /// `δ = −α G⁻¹ Ψ`, α = 1.
    Normalized,
    /// `δ = −K T Ψ` with `K = kt / (T H*)`: `kt` is the gain relative to the deadbeat gain at
    /// the closest point.
    Plain { kt: f64 },
}

/// Tick budget for a curve, derived from the law (not from the code).
///
/// Write `e = u − u*` and `Ψ(u) = H̄(u) e`, with `H̄` the secant slope of `Ψ` (the mean of `H`
/// over `[u*, u]`). One tick of either law with the step guard is `δ = −Ψ / M(u)`,
/// `M = max(m₀, H)`: `m₀ = |C'|²/α` (normalised) or `1/(KT)` (plain), and the guard caps
/// `ρ = H/m₀` at 1 by raising `M` to `H`. An unclipped step maps `e ↦ e (1 − H̄/M)`; let
/// `q̄ = sup |1 − H̄/M|` over `|u − u*| ≤ |e₀|` (from the `f64` reference). A step clipped by
/// the trust region (`|δ| = s = 0.25 · domain length`) lies between no step and the full step,
/// so `|e'| ≤ max(|e| − s, q̄ |e|)`: while `|e| ≥ E = s / (1 − q̄)` the error drops by at least
/// `s` per tick (the far phase, `⌈(|e₀| − E)/s⌉` ticks, the trust region's travel time), below
/// `E` it contracts by `q̄` per tick (`⌈ln(e_tol / min(|e₀|, E)) / ln q̄⌉` ticks). Near the
/// solution `q̄ → |1 − ρ*|`, `ρ* = min(H*/G*, 1)` (normalised: 1, i.e. Newton, on the convex
/// side where `H* = G*(1 + κd) ≥ G*`) or `min(KT H*, 1)` (plain).
///
/// Returns `None` when `q̄ ≥ 0.98` (the bound says nothing useful).
fn curve_tick_budget(
    rc: &RefCurve,
    x: DVec3,
    r: &RefClosest,
    u0: f64,
    law: LawUnderTest,
    e_tol: f64,
) -> Option<usize> {
    let (a, b) = rc.domain();
    let e0 = (u0 - r.u).abs();
    let s = STEP_FRACTION * (b - a);
    let (lo, hi) = ((r.u - e0).max(a), (r.u + e0).min(b));
    let mut q = 0.0f64;
    for k in 0..=400 {
        let u = lo + (hi - lo) * k as f64 / 400.0;
        if (u - r.u).abs() < 1e-9 {
            continue;
        }
        let j = rc.jet(u);
        let g = j.p - x;
        let h = j.d1.dot(j.d1) + g.dot(j.d2);
        let h_bar = g.dot(j.d1) / (u - r.u);
        let m0 = match law {
            LawUnderTest::Normalized => j.d1.dot(j.d1),
            LawUnderTest::Plain { kt } => r.hessian / kt,
        };
        q = q.max((1.0 - h_bar / m0.max(h)).abs());
    }
    if q >= 0.98 {
        return None;
    }
    let e_switch = s / (1.0 - q);
    let far = ((e0 - e_switch) / s).ceil().max(0.0);
    let near = if e0 <= e_tol {
        0.0
    } else {
        ((e_tol / e0.min(e_switch)).ln() / q.ln()).ceil().max(0.0)
    };
    Some((far + near) as usize)
}

/// Ticks until the error stays within tolerance for the rest of `max_ticks` (None if it
/// never settles).
fn settle_ticks(
    mut err_after_tick: impl FnMut() -> f64,
    max_ticks: usize,
    tol: f64,
) -> Option<usize> {
    let mut settled = None;
    for k in 1..=max_ticks {
        if err_after_tick() <= tol {
            settled.get_or_insert(k);
        } else {
            settled = None;
        }
    }
    settled
}

fn config(law: Law) -> TrackerConfig {
    TrackerConfig {
        law,
        ..TrackerConfig::default()
    }
}

/// Outcome of one convergence case: measured and predicted ticks.
#[derive(Clone, Copy, Debug)]
struct Ticks {
    measured: usize,
    predicted: usize,
}

/// A stationary HIP off a random convex curve, a random start, one law: the tracker reaches
/// the global closest point within [`curve_tick_budget`] ticks and stays there. `None` when the
/// case falls outside the analysis (distance not unimodal, or `q̄` too close to 1).
///
/// `side > 0` puts the HIP outside (convex side) at up to 4 cm; `side < 0` inside, at up to half
/// the smallest radius of curvature.
fn curve_case(
    curve: &CurveBuf<Vec2>,
    u_foot: f64,
    side: f64,
    u0: f32,
    law: LawUnderTest,
) -> Result<Option<Ticks>, TestCaseError> {
    let view = curve.view();
    let rc = RefCurve::new(&view);
    let r_min = (0..=200)
        .map(|k| 1.0 / rc.curvature(k as f64 / 200.0).abs())
        .fold(f64::INFINITY, f64::min);
    let d = if side > 0.0 {
        0.001 + 0.04 * side
    } else {
        0.5 * r_min * side - 0.001
    };
    let x = rc.point(u_foot) + rc.normal(u_foot) * d;
    let r = closest_on_curve(&rc, x, 2000);
    if r.local_minima != 1 {
        return Ok(None);
    }
    let e_tol = POINT_TOL / r.metric.sqrt();
    let Some(predicted) = curve_tick_budget(&rc, x, &r, u0 as f64, law, e_tol) else {
        return Ok(None);
    };
    let tracker_law = match law {
        LawUnderTest::Normalized => Law::Normalized { alpha: 1.0 },
        LawUnderTest::Plain { kt } => Law::Plain {
            gain: (kt / (T as f64 * r.hessian)) as f32,
        },
    };
    let hip = v2(x);
    let mut tracker = Tracker::new(&view, [u0], config(tracker_law));
    let mut last = None;
    let measured = settle_ticks(
        || {
            let t = tracker.update(&view, hip, T);
            last = Some(t);
            (t.t[0] as f64 - r.u).abs()
        },
        predicted + 50,
        e_tol,
    );
    let measured = measured.unwrap_or(usize::MAX);
    if std::env::var("DBG").is_ok() && measured == predicted {
        println!(
            "TIGHT {law:?} u0 {u0} u* {} e0 {} pred {predicted}",
            r.u,
            (u0 as f64 - r.u).abs()
        );
    }
    prop_assert!(
        measured <= predicted.max(1),
        "{law:?}: converged after {measured} ticks, predicted ≤ {predicted} (u0 {u0}, u* {})",
        r.u
    );
    let last = last.unwrap();
    prop_assert!((wide(last.point) - r.point).length() <= 1.5 * POINT_TOL);
    Ok(Some(Ticks {
        measured,
        predicted,
    }))
}

/// A stationary HIP above (outside) or below (inside) a random convex dome, a random start:
/// the tracker reaches the closest point within `travel + local + 2` ticks.
///
/// `travel = ⌈|Δt|∞ / 0.25⌉` is the trust region's travel time. `local` is the linear
/// contraction from the start's error `e₀` to 1 µm with the rate of the linearised map
/// `e ↦ (I − M H*) e` at the solution: normalised law `M = G*⁻¹/max(1, λ₂)`, whose modes contract
/// by `|1 − λᵢ/max(1, λ₂)|` in the `G*` norm (point error), `λᵢ` the eigenvalues of `G*⁻¹H*`
/// (`1 + κᵢ d`); plain law `M = KT·I` (guard-capped at `λ_max(KT H*) = 1`), contracting the
/// Euclidean parameter error by `max |1 − μᵢ|`, `μᵢ` the eigenvalues of the capped `KT H*`.
/// The 2 extra ticks cover the transition from the nonlinear far phase and the superlinear
/// finish where the rate is ~0 (Newton).
fn dome_case(
    dome: &SurfaceBuf,
    foot: (f64, f64),
    side: f64,
    start: (f32, f32),
    law: LawUnderTest,
) -> Result<Option<Ticks>, TestCaseError> {
    let view = dome.view();
    let rs = RefSurface::new(&view);
    let j = rs.jet(foot.0, foot.1);
    let n = j.su.cross(j.sv).normalize();
    let d = if side > 0.0 {
        0.002 + 0.03 * side
    } else {
        0.006 * side - 0.001
    };
    let x = j.p + n * d;
    let r = closest_on_surface(&rs, x, 60);
    let [l1, l2] = r.gh_eigen;
    if l1.is_nan() || l1 <= 0.2 {
        return Ok(None);
    }
    let t0 = [start.0 as f64, start.1 as f64];
    let dt = [t0[0] - r.t[0], t0[1] - r.t[1]];
    let travel = (dt[0].abs().max(dt[1].abs()) / STEP_FRACTION).ceil();
    let (tracker_law, q, e0, e_tol, err_of): (Law, f64, f64, f64, ErrorOf) = match law {
        LawUnderTest::Normalized => {
            let q = if l2 >= 1.0 { 1.0 - l1 / l2 } else { 1.0 - l1 };
            let e0 = (rs.point(t0[0], t0[1]) - r.point).length();
            let cp = r.point;
            (
                Law::Normalized { alpha: 1.0 },
                q,
                e0,
                POINT_TOL,
                Box::new(move |t: &Track<Vec3, 2>| (wide(t.point) - cp).length()),
            )
        }
        LawUnderTest::Plain { kt } => {
            let [h1, h2] = sym_eigen(r.hessian);
            let gain = kt / (T as f64 * h2);
            let cap = (kt).max(1.0);
            let q = [h1, h2]
                .iter()
                .map(|h| (1.0 - gain * T as f64 * h / cap).abs())
                .fold(0.0, f64::max);
            let g_max = sym_eigen(r.metric)[1];
            let e0 = (dt[0] * dt[0] + dt[1] * dt[1]).sqrt();
            let ts = r.t;
            (
                Law::Plain { gain: gain as f32 },
                q,
                e0,
                POINT_TOL / g_max.sqrt(),
                Box::new(move |t: &Track<Vec3, 2>| {
                    ((t.t[0] as f64 - ts[0]).powi(2) + (t.t[1] as f64 - ts[1]).powi(2)).sqrt()
                }),
            )
        }
    };
    if q >= 0.98 {
        return Ok(None);
    }
    let local = if e0 <= e_tol || q < 1e-12 {
        0.0
    } else {
        ((e_tol / e0).ln() / q.ln()).ceil().max(0.0)
    };
    let predicted = (travel + local) as usize + 2;
    let hip = v3(x);
    let mut tracker = Tracker::new(&view, [start.0, start.1], config(tracker_law));
    let measured = settle_ticks(
        || err_of(&tracker.update(&view, hip, T)),
        predicted + 50,
        e_tol,
    )
    .unwrap_or(usize::MAX);
    prop_assert!(
        measured <= predicted,
        "{law:?}: converged after {measured} ticks, predicted ≤ {predicted} (q {q}, λ {l1} {l2})"
    );
    Ok(Some(Ticks {
        measured,
        predicted,
    }))
}

/// The error measure of a dome case, from a tracker report.
type ErrorOf = Box<dyn Fn(&Track<Vec3, 2>) -> f64>;
/// One random convergence case for [`convergence_statistics`].
type CaseFn = Box<dyn FnMut(&mut TestRunner) -> Option<Ticks>>;

fn plain_kt() -> impl Strategy<Value = f64> {
    0.2f64..1.9
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn normalised_law_converges_on_convex_curves(
        curve in convex_curve(), foot in 0.05f64..0.95, side in -1.0f64..1.0, u0 in 0.0f32..1.0,
    ) {
        let ok = curve_case(&curve, foot, side, u0, LawUnderTest::Normalized)?;
        prop_assume!(ok.is_some());
    }

    #[test]
    fn plain_law_converges_on_convex_curves(
        curve in convex_curve(), foot in 0.05f64..0.95, side in -1.0f64..1.0, u0 in 0.0f32..1.0,
        kt in plain_kt(),
    ) {
        let ok = curve_case(&curve, foot, side, u0, LawUnderTest::Plain { kt })?;
        prop_assume!(ok.is_some());
    }

    #[test]
    fn normalised_law_converges_on_convex_domes(
        dome in convex_dome(), foot in (0.1f64..0.9, 0.1f64..0.9), side in -1.0f64..1.0,
        start in (0.0f32..1.0, 0.0f32..1.0),
    ) {
        let ok = dome_case(&dome, foot, side, start, LawUnderTest::Normalized)?;
        prop_assume!(ok.is_some());
    }

    #[test]
    fn plain_law_converges_on_convex_domes(
        dome in convex_dome(), foot in (0.1f64..0.9, 0.1f64..0.9), side in -1.0f64..1.0,
        start in (0.0f32..1.0, 0.0f32..1.0), kt in plain_kt(),
    ) {
        let ok = dome_case(&dome, foot, side, start, LawUnderTest::Plain { kt })?;
        prop_assume!(ok.is_some());
    }
}

/// The same cases on a fixed sample (a deterministic RNG), asserting the same budgets and
/// printing the measured tick counts.
#[test]
fn convergence_statistics() {
    let mut runner = TestRunner::deterministic();
    let mut report = |name: &str, mut case: CaseFn| {
        let mut ticks = Vec::new();
        let mut slack = Vec::new();
        for _ in 0..300 {
            if let Some(t) = case(&mut runner) {
                ticks.push(t.measured);
                slack.push(t.predicted as f64 - t.measured as f64);
            }
        }
        ticks.sort_unstable();
        let mean = ticks.iter().sum::<usize>() as f64 / ticks.len() as f64;
        println!(
            "{name}: {} cases, ticks median {} mean {mean:.1} p95 {} max {}; min slack to the budget {}",
            ticks.len(),
            ticks[ticks.len() / 2],
            ticks[ticks.len() * 95 / 100],
            ticks[ticks.len() - 1],
            slack.iter().cloned().fold(f64::INFINITY, f64::min),
        );
        assert!(ticks.len() >= 200, "too few cases inside the analysis");
    };
    for plain in [false, true] {
        report(
            if plain {
                "curves, plain law"
            } else {
                "curves, normalised law"
            },
            Box::new(move |runner| {
                let args = (
                    convex_curve(),
                    0.05f64..0.95,
                    -1.0f64..1.0,
                    0.0f32..1.0,
                    plain_kt(),
                );
                let (c, foot, side, u0, kt) = args.new_tree(runner).unwrap().current();
                let law = if plain {
                    LawUnderTest::Plain { kt }
                } else {
                    LawUnderTest::Normalized
                };
                curve_case(&c, foot, side, u0, law).unwrap()
            }),
        );
        report(
            if plain {
                "domes, plain law"
            } else {
                "domes, normalised law"
            },
            Box::new(move |runner| {
                let args = (
                    convex_dome(),
                    (0.1f64..0.9, 0.1f64..0.9),
                    -1.0f64..1.0,
                    (0.0f32..1.0, 0.0f32..1.0),
                    plain_kt(),
                );
                let (s, foot, side, start, kt) = args.new_tree(runner).unwrap().current();
                let law = if plain {
                    LawUnderTest::Plain { kt }
                } else {
                    LawUnderTest::Normalized
                };
                dome_case(&s, foot, side, start, law).unwrap()
            }),
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Exact oracles
// ---------------------------------------------------------------------------------------------

const CENTER2: Vec2 = Vec2::new(0.0, 0.09);
const CENTER3: Vec3 = Vec3::new(0.0, 0.09, 0.0);

/// Runs `ticks` updates at a fixed HIP and returns the last report.
fn run<S: Patch<N>, const N: usize>(
    patch: &S,
    tracker: &mut Tracker<S::P, N>,
    hip: S::P,
    ticks: usize,
) -> Track<S::P, N> {
    let mut last = tracker.update(patch, hip, T);
    for _ in 1..ticks {
        last = tracker.update(patch, hip, T);
    }
    last
}

/// A start near the closest point `cp` of a closed surface: the nearest 16×16 grid parameter,
/// plus `jitter` (wrapped in u, clamped in v).
fn near_start(view: &nurbs::Surface<'_>, cp: DVec3, jitter: (f32, f32)) -> [f32; 2] {
    let mut best = (f64::INFINITY, [0.0f32; 2]);
    for i in 0..16 {
        for j in 0..=16 {
            let t = [i as f32 / 16.0, j as f32 / 16.0];
            let dd = (wide(view.point(t[0], t[1])) - cp).length();
            if dd < best.0 {
                best = (dd, t);
            }
        }
    }
    [
        (best.1[0] + jitter.0).rem_euclid(1.0),
        (best.1[1] + jitter.1).clamp(0.0, 1.0),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Circle: closest point `c + r (x − c)/|x − c|`, outward normal `(x − c)/|x − c|`, signed
    /// distance `|x − c| − r`, from any start. The budget of 200 ticks covers the slowest case
    /// in range, a HIP at `D = 0.2 r` inside: the farthest point is an unstable equilibrium the
    /// normalised step leaves by a factor `1 + D/r = 1.2` per tick (≈ 50 ticks from 10⁻⁴ rad),
    /// and the closest point attracts with `1 − D/r = 0.8` per tick (≈ 50 ticks to 1 µm).
    #[test]
    fn circle_matches_closed_form(
        angle in 0.0f64..std::f64::consts::TAU, rad in 0.006f64..0.08, u0 in 0.0f32..1.0,
    ) {
        let r = 0.03;
        let c = construct::circle(CENTER2, r as f32).unwrap();
        let view = c.view();
        let dir = DVec3::new(angle.cos(), angle.sin(), 0.0);
        let x = wide(CENTER2) + dir * rad;
        let mut tracker = Tracker::new(&view, [u0], TrackerConfig::default());
        let t = run(&view, &mut tracker, v2(x), 200);
        let cp = wide(CENTER2) + dir * r;
        prop_assert!((wide(t.point) - cp).length() < POINT_TOL, "{:?} vs {cp:?}", t.point);
        prop_assert!((wide(t.normal) - dir).length() < 1e-4);
        prop_assert!((t.signed_distance as f64 - (rad - r)).abs() < 1e-6);
    }

    /// Sphere: closest point `c + r (x − c)/|x − c|`, HIPs inside and outside, starts near
    /// the solution (within ±0.1 of the nearest 16×16 grid parameter). Closest points stay
    /// within 44° of the equator (|n_z| ≤ 0.7): near the poles the test point can stick on the
    /// pole, see [`does_not_stick_at_sphere_poles`].
    #[test]
    fn sphere_matches_closed_form(
        azimuth in 0.0f64..std::f64::consts::TAU, nz in -0.7f64..0.7, rad in 0.01f64..0.08,
        jitter in (-0.1f32..0.1, -0.1f32..0.1),
    ) {
        let dir = DVec3::new(azimuth.cos() * (1.0 - nz * nz).sqrt(), azimuth.sin() * (1.0 - nz * nz).sqrt(), nz);
        let r = 0.03;
        let s = construct::sphere(CENTER3, r as f32).unwrap();
        let view = s.view();
        let x = wide(CENTER3) + dir * rad;
        let cp = wide(CENTER3) + dir * r;
        let start = near_start(&view, cp, jitter);
        let mut tracker = Tracker::new(&view, start, TrackerConfig::default());
        let t = run(&view, &mut tracker, v3(x), 60);
        prop_assert!((wide(t.point) - cp).length() < POINT_TOL, "{:?} vs {cp:?}", t.point);
        prop_assert!((wide(t.normal) - dir).length() < 1e-4, "normal {:?}", t.normal);
    }

    /// Torus (major R, minor r, axis z): the closest point is `q + r (x − q)/|x − q|` with `q` the
    /// point of the tube's centre circle in the HIP's azimuth. Starts near the solution (within
    /// ±0.08 of the nearest 16×16 grid parameter), inside the basin of the global minimum (the
    /// torus has other local minima, on the far side of the hole).
    #[test]
    fn torus_matches_closed_form(
        azimuth in 0.0f64..std::f64::consts::TAU, tube_angle in 0.0f64..std::f64::consts::TAU,
        off in 0.003f64..0.02, jitter in (-0.08f32..0.08, -0.08f32..0.08),
    ) {
        let (major, minor) = (0.03, 0.01);
        let s = construct::torus(Vec3::ZERO, major as f32, minor as f32).unwrap();
        let view = s.view();
        let radial = DVec3::new(azimuth.cos(), azimuth.sin(), 0.0);
        let q = radial * major;
        let tube_dir = radial * tube_angle.cos() + DVec3::new(0.0, 0.0, tube_angle.sin());
        let x = q + tube_dir * off;
        let cp = q + tube_dir * minor;
        let start = near_start(&view, cp, (jitter.0, jitter.1));
        let mut tracker = Tracker::new(&view, start, TrackerConfig::default());
        let t = run(&view, &mut tracker, v3(x), 60);
        prop_assert!((wide(t.point) - cp).length() < POINT_TOL, "{:?} vs {cp:?}", t.point);
        prop_assert!((wide(t.normal) - tube_dir).length() < 1e-4);
    }
}

// ---------------------------------------------------------------------------------------------
// Safety properties
// ---------------------------------------------------------------------------------------------

/// A HIP path: straight line from `a` to `b`, `ticks` ticks.
fn line_path(a: DVec3, b: DVec3, ticks: usize) -> impl Iterator<Item = DVec3> {
    (0..ticks).map(move |k| a + (b - a) * (k as f64 / (ticks - 1) as f64))
}

fn workspace_point() -> impl Strategy<Value = DVec3> {
    (-0.06f64..0.06, 0.03f64..0.15).prop_map(|(x, y)| DVec3::new(x, y, 0.0))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// The test point is on the curve, so its distance to the HIP is never below the true
    /// minimum distance (up to `f32` rounding of the evaluation, far below 0.1 µm here), whatever
    /// the law, gain, start or HIP motion. (The reported `signed_distance`, a normal component,
    /// can be smaller while unconverged; only `|signed_distance| ≤ |TP − HIP|` holds.)
    #[test]
    fn tracked_distance_never_below_minimum(
        curve in convex_curve(), a in workspace_point(), b in workspace_point(),
        u0 in 0.0f32..1.0, law in prop_oneof![
            Just(Law::Normalized { alpha: 1.0 }),
            (1e2f32..1e7).prop_map(|gain| Law::Plain { gain }),
        ],
        guard in any::<bool>(), feedforward in any::<bool>(),
    ) {
        let view = curve.view();
        let rc = RefCurve::new(&view);
        let mut tracker = Tracker::new(&view, [u0], TrackerConfig {
            law, step_guard: guard, feedforward, convergence_radius: 1e-3, ..TrackerConfig::default()
        });
        // 0.3 s at 1 kHz: at most ~0.5 m/s.
        for (k, x) in line_path(a, b, 300).enumerate() {
            let t = tracker.update(&view, v2(x), T);
            let p = wide(t.point);
            prop_assert!((p - rc.point(t.t[0] as f64)).length() < 1e-7, "TP off the curve");
            let tracked = (p - x).length();
            prop_assert!((t.signed_distance as f64).abs() <= tracked + 1e-7);
            if k % 10 == 0 {
                let min = closest_on_curve(&rc, x, 400).distance;
                prop_assert!(tracked >= min - 1e-7, "tick {k}: tracked {tracked} < minimum {min}");
            }
        }
    }
}

/// Coordinates over many magnitudes: the workspace, ±1 km, and log-uniform up to 10³⁰ m.
fn wild_coord() -> impl Strategy<Value = f32> {
    prop_oneof![
        -0.2f32..0.2,
        -1e3f32..1e3,
        (0.0f32..30.0, any::<bool>()).prop_map(|(e, neg)| {
            let v = 10f32.powf(e);
            if neg { -v } else { v }
        }),
    ]
}

fn any_config() -> impl Strategy<Value = TrackerConfig> {
    (
        prop_oneof![
            (-3.0f32..12.0).prop_map(|e| Law::Plain {
                gain: 10f32.powf(e)
            }),
            (0.0f32..3.0).prop_map(|alpha| Law::Normalized { alpha }),
        ],
        1u8..=4,
        any::<bool>(),
        -9.0f32..0.0,
        any::<bool>(),
        0.0f32..1.0,
    )
        .prop_map(
            |(law, iterations, feedforward, eps, step_guard, frac)| TrackerConfig {
                law,
                iterations,
                feedforward,
                convergence_radius: 10f32.powf(eps),
                step_guard,
                max_step_fraction: frac,
            },
        )
}

fn check_track<P: Point, const N: usize>(
    t: &Track<P, N>,
    domain: [(f32, f32); N],
) -> Result<(), TestCaseError> {
    for i in 0..N {
        prop_assert!(
            t.t[i] >= domain[i].0 && t.t[i] <= domain[i].1,
            "t {:?} outside",
            t.t
        );
        prop_assert!(t.psi[i].is_finite(), "psi {:?}", t.psi);
    }
    prop_assert!(t.point.is_finite() && t.normal.is_finite(), "{t:?}");
    prop_assert!(t.signed_distance.is_finite(), "{t:?}");
    prop_assert!(
        (t.normal.length_squared() - 1.0).abs() < 1e-3,
        "normal {t:?}"
    );
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]

    /// Parameters stay in the domain and every output is finite, for HIPs from the workspace
    /// out to 10³⁰ m (the distance stays representable: |x|·√2 < f32::MAX), the centre of a
    /// circle (every point closest, Ψ ≡ 0 and H ≡ 0 up to rounding), and any configuration,
    /// including gains far beyond the stability limit with the guard off.
    #[test]
    fn curves_stay_in_domain_and_finite(
        cfg in any_config(), closed in any::<bool>(), curve in convex_curve(), u0 in 0.0f32..1.0,
        hips in proptest::collection::vec((wild_coord(), wild_coord(), 0u8..4), 1..12),
    ) {
        let circle = construct::circle(CENTER2, 0.03).unwrap();
        let curve = if closed { circle } else { curve };
        let view = curve.view();
        let mut tracker = Tracker::new(&view, [u0], cfg);
        for (x, y, kind) in hips {
            // One HIP in four at the circle's centre.
            let hip = if kind == 0 { CENTER2 } else { Vec2::new(x, y) };
            for _ in 0..5 {
                let t = tracker.update(&view, hip, T);
                check_track(&t, [view.domain()])?;
            }
        }
    }

    #[test]
    fn surfaces_stay_in_domain_and_finite(
        cfg in any_config(), sphere in any::<bool>(), dome in convex_dome(),
        start in (0.0f32..1.0, 0.0f32..1.0),
        hips in proptest::collection::vec((wild_coord(), wild_coord(), wild_coord(), 0u8..4), 1..8),
    ) {
        let s = if sphere { construct::sphere(CENTER3, 0.03).unwrap() } else { dome };
        let view = s.view();
        let (du, dv) = view.domain();
        let mut tracker = Tracker::new(&view, [start.0, start.1], cfg);
        for (x, y, z, kind) in hips {
            let hip = if kind == 0 { CENTER3 } else { Vec3::new(x, y, z) };
            for _ in 0..5 {
                let t = tracker.update(&view, hip, T);
                check_track(&t, [du, dv])?;
            }
        }
    }
}

/// Beyond the representable range: a HIP at `(f32::MAX, f32::MAX)` is finite, but its
/// distance to the circle (≈ 4.8·10³⁸ m) exceeds `f32::MAX`, and with the test point facing
/// it (t = 0.125, 45°) `Track::signed_distance = −Γ·n` overflows to `inf`, although
/// `Tracker::update` promises "finite values for finite input": the report saturates.
#[test]
fn signed_distance_finite_for_hip_near_f32_max() {
    let c = construct::circle(CENTER2, 0.03).unwrap();
    let view = c.view();
    let mut tracker = Tracker::new(&view, [0.125], TrackerConfig::default());
    let t = tracker.update(&view, Vec2::new(f32::MAX, f32::MAX), T);
    assert!(t.signed_distance.is_finite(), "{t:?}");
}

/// A HIP moving at 0.1 m/s along a great circle over the north pole of a sphere of
/// revolution, 1 cm outside: the closest point moves `v T r/R` = 75 µm per tick, and both laws
/// should stay within one tick's motion of it (the normalised law is deadbeat; the plain law's
/// gain 8·10⁴ puts `KT λ(H)` near 1 on this path, `H ≈ |S_v|² D/r ≈ 0.012`, and the guard caps
/// it at 1). They do not: at the pole `S_u = 0`, so `Ψ_u = 0` and
/// no law can turn `u` by the half turn the crossing needs, while `v` is clamped at the pole.
/// The plain law stays at the pole for good (error 35 mm at the end, the HIP having moved on);
/// the normalised law escapes through its regularised `G⁻¹` but falls behind around the
/// crossing (0.5 mm on this path, 1–4 mm on great circles of other azimuths: many ticks'
/// worth of motion). A fix has to treat a collapsed side as a crossing
/// (continuing past the pole maps `(u, v₁ + δ)` to `(u + half period, v₁ − δ)`) rather than a
/// clamp. The tracker now crosses the pole that way.
#[test]
fn follows_hip_over_sphere_pole() {
    let r = 0.03f64;
    let s = construct::sphere(CENTER3, r as f32).unwrap();
    let view = s.view();
    let (rad, speed) = (0.04f64, 0.1f64);
    let omega = speed / rad;
    let hip = |k: usize| {
        let th = 0.8 + omega * k as f64 * T as f64;
        wide(CENTER3) + DVec3::new(th.cos(), 0.0, th.sin()) * rad
    };
    let cp_of = |x: DVec3| wide(CENTER3) + (x - wide(CENTER3)).normalize() * r;
    let cp_step = speed * T as f64 * r / rad;
    // Start on the closest point of the first HIP (parameters from a fine grid + the tracker).
    let mut failures = Vec::new();
    for law in [Law::Normalized { alpha: 1.0 }, Law::Plain { gain: 8e4 }] {
        let mut tracker = Tracker::new(&view, [0.0, 0.5], TrackerConfig::default());
        run(&view, &mut tracker, v3(hip(0)), 100);
        tracker.set_config(config(law));
        let mut worst = (0.0f64, 0);
        for k in 0..800 {
            let x = hip(k);
            let t = tracker.update(&view, v3(x), T);
            let err = (wide(t.point) - cp_of(x)).length();
            if err > worst.0 {
                worst = (err, k);
            }
        }
        // One tick of closest-point motion, plus one more: the plain law's steady lag is
        // (1 − ρ)/ρ ticks with ρ = K T λ(H) < 1 off the pole, and the crossing itself costs
        // the normalised law part of a tick.
        if worst.0 > 2.0 * cp_step {
            failures.push(format!(
                "{law:?}: {:.2} mm behind at tick {}",
                worst.0 * 1e3,
                worst.1
            ));
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// Stationary HIPs whose closest point is far from any pole still leave the test point stuck
/// on a pole of a sphere of revolution for good (500 ticks; found by random search, ~1.5 % of
/// random starts and HIPs): once a step or the trust region puts `v` on the pole, `S_u = 0`
/// makes `Ψ_u = 0`, and when the HIP lies behind the current meridian `Ψ_v = Γ·S_v` asks for
/// `v` beyond the pole, which is clamped. Cases: (a) a start on the south pole facing away
/// from a HIP 49° from it (a reset onto a pole, e.g. by a feature switch, reaches this state);
/// (b) a start at latitude −59° for a HIP on the equator, which falls into the south pole;
/// (c) a start at 45° for a HIP over latitude 79°, which ends on the north pole. Same cause as
/// [`follows_hip_over_sphere_pole`].
#[test]
fn does_not_stick_at_sphere_poles() {
    let r = 0.03f64;
    let s = construct::sphere(CENTER3, r as f32).unwrap();
    let view = s.view();
    let cases = [
        (
            [0.7286659, 0.14092493, -0.6592146],
            0.0724f32,
            [0.30672583, 0.0],
        ),
        (
            [0.25419453, 0.96706116, -0.013337731],
            0.04347036,
            [0.387913, 0.17020759],
        ),
        (
            [-0.12355144, 0.1496698, 0.98098624],
            0.015623169,
            [0.5524, 0.7471215],
        ),
    ];
    let mut stuck = Vec::new();
    for (dir, rad, start) in cases {
        // The HIP exactly as the search built it, in f32.
        let dir = Vec3::from_array(dir).normalize();
        let x = CENTER3 + dir * rad;
        let cp = wide(CENTER3) + wide(dir) * r;
        let mut tracker = Tracker::new(&view, start, TrackerConfig::default());
        let t = run(&view, &mut tracker, x, 500);
        if (wide(t.point) - cp).length() > POINT_TOL {
            stuck.push(format!(
                "start {start:?}: stuck at t {:?}, Ψ {:?}",
                t.t, t.psi
            ));
        }
    }
    assert!(stuck.is_empty(), "{stuck:#?}");
}

// ---------------------------------------------------------------------------------------------
// Closed curves and feed-forward
// ---------------------------------------------------------------------------------------------

/// A HIP orbiting a circle twice (both directions, 0.1 m/s at 1 cm outside): the parameter
/// wraps across the seam exactly twice, never leaves [0, 1], and the test point stays on the
/// exact closest point and moves continuously: at most the closest point's own displacement
/// per tick, `v T r/R`, plus rounding.
#[test]
fn wraps_across_the_seam_continuously() {
    let (r, orbit, speed) = (0.03f64, 0.04f64, 0.1f64);
    let c = construct::circle(CENTER2, r as f32).unwrap();
    let view = c.view();
    let omega = speed / orbit;
    let ticks = (2.0 * std::f64::consts::TAU / omega / T as f64).ceil() as usize;
    for sense in [1.0f64, -1.0] {
        let hip_at = |k: usize| {
            let a = 0.3 + sense * omega * k as f64 * T as f64;
            wide(CENTER2) + DVec3::new(a.cos(), a.sin(), 0.0) * orbit
        };
        let start = (0.3f64 / std::f64::consts::TAU) as f32;
        let mut tracker = Tracker::new(&view, [start], TrackerConfig::default());
        let mut prev: Option<Track<Vec2, 1>> = None;
        let mut wraps = 0;
        let cp_step = speed * T as f64 * r / orbit;
        for k in 0..=ticks {
            let x = hip_at(k);
            let t = tracker.update(&view, v2(x), T);
            assert!((0.0..=1.0).contains(&t.t[0]));
            let cp = wide(CENTER2) + (x - wide(CENTER2)).normalize() * r;
            if k > 3 {
                assert!(
                    (wide(t.point) - cp).length() < POINT_TOL,
                    "tick {k}: off the closest point"
                );
            }
            if let Some(p) = prev {
                if (t.t[0] - p.t[0]).abs() > 0.5 {
                    wraps += 1;
                }
                if k > 3 {
                    let moved = (wide(t.point) - wide(p.point)).length();
                    assert!(
                        moved <= cp_step * 1.001 + 2e-7,
                        "tick {k}: jumped {moved} m"
                    );
                }
            }
            prev = Some(t);
        }
        assert_eq!(wraps, 2, "sense {sense}");
    }
}

/// Steady-state lag of the plain law with a small gain behind a HIP gliding along a straight
/// segment (length L, so G = H = L² everywhere and the linear analysis is exact).
///
/// Per tick the closest point advances `Δ = v T / L` in parameter. Write `r_k` for the
/// reported parameter error after tick k and `c = K T L²`. Without feed-forward,
/// `r_k = (1 − c)(r_{k−1} − Δ)`, so `|r| → (1 − c) Δ / c` (19 Δ at c = 0.05). With the
/// feed-forward `G⁻¹ Jᵀ Δx = Δ` added, `r_k = (1 − c)(r_{k−1} − Δ) + Δ → Δ`: the lag drops to
/// at most one tick's motion, a ratio of `(1 − c)/c`.
#[test]
fn feedforward_cuts_the_steady_state_lag() {
    let (len, speed, c_gain) = (0.1f64, 0.05f64, 0.05f64);
    let a = Vec2::new(-0.05, 0.09);
    let line = construct::line(a, a + Vec2::new(len as f32, 0.0)).unwrap();
    let view = line.view();
    let gain = (c_gain / (T as f64 * len * len)) as f32;
    let delta = speed * T as f64 / len;
    let lag = |feedforward: bool| {
        let cfg = TrackerConfig {
            law: Law::Plain { gain },
            feedforward,
            // Ψ stays near H·19Δ = 1e-4 without feed-forward: keep the whole run in the ball.
            convergence_radius: 1e-2,
            ..TrackerConfig::default()
        };
        let hip = |k: usize| wide(a) + DVec3::new(0.01 + speed * k as f64 * T as f64, 0.005, 0.0);
        let mut tracker = Tracker::new(&view, [0.1], cfg);
        let mut r = 0.0;
        for k in 0..1200 {
            let x = hip(k);
            let t = tracker.update(&view, v2(x), T);
            r = t.t[0] as f64 - (x.x - a.x as f64) / len;
        }
        r.abs()
    };
    let (without, with) = (lag(false), lag(true));
    println!(
        "feed-forward: steady-state lag {:.2} Δ without, {:.2} Δ with",
        without / delta,
        with / delta
    );
    let predicted = (1.0 - c_gain) / c_gain * delta;
    assert!(
        (without - predicted).abs() < 0.02 * predicted,
        "lag without {without}"
    );
    assert!(with <= 1.02 * delta, "lag with {with}");
    assert!(without / with >= 0.9 * (1.0 - c_gain) / c_gain);
}

/// Feed-forward makes the reported tracking error vanish for a HIP at constant speed
/// ("asymptotically, not only practically, stable", `TrackerConfig::feedforward`). The
/// feedback term already uses this tick's HIP, so the predicted motion enters scaled by
/// `1 − ρ` (predict, then correct), giving `r_k = (1 − c) r_{k−1} → 0` rather than a one-tick
/// lead from counting the motion twice.
#[test]
fn feedforward_tracks_constant_speed_without_error() {
    let (len, speed) = (0.1f64, 0.05f64);
    let a = Vec2::new(-0.05, 0.09);
    let line = construct::line(a, a + Vec2::new(len as f32, 0.0)).unwrap();
    let view = line.view();
    let delta = speed * T as f64 / len;
    for law in [
        Law::Normalized { alpha: 1.0 },
        Law::Plain {
            gain: (0.05 / (T as f64 * len * len)) as f32,
        },
    ] {
        let cfg = TrackerConfig {
            law,
            feedforward: true,
            convergence_radius: 1e-2,
            ..TrackerConfig::default()
        };
        let mut tracker = Tracker::new(&view, [0.1], cfg);
        let mut r = 0.0;
        for k in 0..1200 {
            let x = wide(a) + DVec3::new(0.01 + speed * k as f64 * T as f64, 0.005, 0.0);
            let t = tracker.update(&view, v2(x), T);
            r = t.t[0] as f64 - (x.x - a.x as f64) / len;
        }
        assert!(
            r.abs() < 0.1 * delta,
            "{law:?}: steady-state error {} Δ",
            r / delta
        );
    }
}
