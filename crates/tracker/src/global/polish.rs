//! The global search's polish: Newton's method made safe for a search from a sampled piece
//! (Levenberg–Marquardt damping, bounds as an active set; see [the module](super)).

use crate::linalg::solve_spd;
use crate::newton::NewtonConfig;
use crate::patch::Patch;
use crate::track::PERIODIC_TOL;
use nurbs::Point;

use super::wrap_or_clamp;

/// Hard cap on the iterations of one polish, whatever [`NewtonConfig::max_iterations`] says.
const MAX_POLISH_ITERATIONS: u32 = 64;

/// The polish: Newton's method for `Ψ(t) = 0` as in [`newton`](crate::newton()) (P&T §6.1,
/// full Hessian `H = Sᵢ·Sⱼ + Γ·Sᵢⱼ`, stopping tests of eq. 6.4–6.5), made safe for a global
/// search:
/// - Levenberg–Marquardt damping, `δ = −(H + λ diag G)⁻¹ Ψ`, with `λ` raised until the step
///   does not move away from `x` and lowered after every success: pure Newton near a
///   minimum, a scaled gradient step in a curved valley or where `H` is indefinite. Plain
///   Newton with clamping can jump into another basin, or onto a corner of the domain, and
///   lose the minimum a leaf was sampling;
/// - bounds as an active set: a direction whose parameter sits on an open bound with `Ψᵢ` or
///   the step pushing outwards is held, and the others take the reduced step, so it
///   converges to minima on the boundary instead of stalling there.
///
/// Returns the parameters and the point there.
pub(super) fn projected_newton<S: Patch<N>, const N: usize>(
    patch: &S,
    x: S::P,
    t0: [f32; N],
    cfg: &NewtonConfig,
) -> ([f32; N], S::P) {
    const LAMBDA_MIN: f32 = 1e-4;
    const ATTEMPTS: usize = 16;
    let domain = patch.domain();
    let periodic = patch.periodic(PERIODIC_TOL);
    let eps1_sq = cfg.point_tol * cfg.point_tol;
    let eps2_sq = cfg.cosine_tol * cfg.cosine_tol;
    let mut t = t0;
    let mut jet = patch.jet(t, 2);
    let mut lambda = 0.0f32;
    // The configured cap, but never unbounded work (a cap of u32::MAX with zero tolerances
    // would otherwise creep along the noise floor for a long time).
    for _ in 0..cfg.max_iterations.min(MAX_POLISH_ITERATIONS) {
        let gamma = jet.point - x;
        let g2 = gamma.length_squared();
        // Also stops on NaN (a NaN tolerance included).
        let apart = g2 > eps1_sq;
        if !apart {
            break;
        }
        let psi = jet.psi(gamma);
        let at_lower = |i: usize| !periodic[i] && t[i] <= domain[i].0;
        let at_upper = |i: usize| !periodic[i] && t[i] >= domain[i].1;
        let mut held = [false; N];
        for i in 0..N {
            held[i] = (at_lower(i) && psi[i] > 0.0) || (at_upper(i) && psi[i] < 0.0);
        }
        // P&T eq. (6.4) on the free directions.
        if (0..N).all(|i| held[i] || psi[i] * psi[i] <= eps2_sq * jet.d[i].length_squared() * g2) {
            break;
        }
        let hessian = jet.hessian(gamma);
        let metric = jet.metric();
        // Near the minimum the distance is flat to within the rounding of the evaluation
        // (coordinates carry errors of a few ε |S|), so a step may raise it by that much.
        let scale =
            nurbs::math::sqrt(jet.point.length_squared()) + nurbs::math::sqrt(x.length_squared());
        let noise = 8.0 * f32::EPSILON * nurbs::math::sqrt(g2) * scale;
        let mut moved = None;
        for _ in 0..ATTEMPTS {
            let Some(mut delta) = damped_step(&hessian, &metric, &psi, &held, lambda) else {
                lambda = nurbs::math::max(LAMBDA_MIN, 4.0 * lambda);
                continue;
            };
            // Also hold the directions on a bound that this step pushes outwards: a clamped
            // step need not go downhill.
            for _ in 0..N {
                let mut grown = false;
                for i in 0..N {
                    let out = (at_lower(i) && delta[i] < 0.0) || (at_upper(i) && delta[i] > 0.0);
                    if !held[i] && out {
                        held[i] = true;
                        grown = true;
                    }
                }
                if !grown {
                    break;
                }
                delta = damped_step(&hessian, &metric, &psi, &held, lambda).unwrap_or([0.0; N]);
            }
            // Stop the step where it first meets a bound, and land exactly on it: clamping
            // the other components instead would move along the boundary by a step computed
            // for a free parameter, possibly into another basin.
            let mut alpha = 1.0f32;
            let mut limit = None;
            for i in 0..N {
                if held[i] || periodic[i] {
                    continue;
                }
                let (a, b) = domain[i];
                let room = if delta[i] < 0.0 {
                    (t[i] - a) / -delta[i]
                } else if delta[i] > 0.0 {
                    (b - t[i]) / delta[i]
                } else {
                    f32::INFINITY
                };
                if room < alpha {
                    alpha = nurbs::math::max(0.0, room);
                    limit = Some((i, if delta[i] < 0.0 { a } else { b }));
                }
            }
            let mut tn = t;
            for i in 0..N {
                if !held[i] {
                    tn[i] = wrap_or_clamp(t[i] + alpha * delta[i], domain[i], periodic[i]);
                }
            }
            if let Some((i, bound)) = limit {
                tn[i] = bound;
            }
            let jn = patch.jet(tn, 2);
            if (jn.point - x).length_squared() <= g2 + noise {
                moved = Some((tn, jn));
                lambda = if lambda > 4.0 * LAMBDA_MIN {
                    0.25 * lambda
                } else {
                    0.0
                };
                break;
            }
            lambda = nurbs::math::max(LAMBDA_MIN, 4.0 * lambda);
        }
        let Some((tn, jn)) = moved else {
            break;
        };
        let mut dt = [0.0; N];
        for i in 0..N {
            dt[i] = tn[i] - t[i];
        }
        // A wrapped step is long in parameter while the point barely moves: measure both.
        let small = (jn.point - jet.point).length_squared() <= eps1_sq
            && jet.displacement(&dt).length_squared() <= eps1_sq;
        t = tn;
        jet = jn;
        if small {
            break;
        }
    }
    (t, jet.point)
}

/// `−(H + λ diag G)⁻¹ Ψ` on the directions not `held` (zero on the held ones); `None` where
/// the damped matrix is not positive definite.
fn damped_step<const N: usize>(
    hessian: &[[f32; N]; N],
    metric: &[[f32; N]; N],
    psi: &[f32; N],
    held: &[bool; N],
    lambda: f32,
) -> Option<[f32; N]> {
    let mut a = *hessian;
    let mut rhs = [0.0; N];
    // Marquardt's diag G, plus a little of Levenberg's identity (scaled by trace G) so that a
    // vanishing Sᵢ (a pole) is damped too.
    let floor = 1e-3 * crate::linalg::trace(metric) + f32::MIN_POSITIVE;
    for i in 0..N {
        if held[i] {
            for j in 0..N {
                a[i][j] = 0.0;
                a[j][i] = 0.0;
            }
            a[i][i] = 1.0;
        } else {
            a[i][i] += lambda * (metric[i][i] + floor);
            rhs[i] = -psi[i];
        }
    }
    let d = solve_spd(a, rhs, 1e-6)?;
    let mut out = [0.0; N];
    for i in 0..N {
        if !held[i] {
            out[i] = d[i];
        }
    }
    Some(out)
}
