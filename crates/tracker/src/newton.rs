//! Newton–Raphson point inversion (Piegl & Tiller §6.1), the baseline the thesis compares
//! against (§2.1.3), generic over curves and surfaces.

use crate::linalg::solve_spd;
use crate::patch::Patch;
use crate::track::{PERIODIC_TOL, clamp, gauss_newton_step};
use nurbs::Point;

/// Stopping tolerances of P&T eq. (6.4)–(6.5).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NewtonConfig {
    /// ε₁: point coincidence `|S − x| ≤ ε₁` and "parameter stopped" `|Σ δᵢ Sᵢ| ≤ ε₁` (metres).
    pub point_tol: f32,
    /// ε₂: zero cosine `|Sᵢ·Γ| / (|Sᵢ| |Γ|) ≤ ε₂` for every direction.
    pub cosine_tol: f32,
    /// Iteration cap.
    pub max_iterations: u32,
}

impl Default for NewtonConfig {
    fn default() -> Self {
        NewtonConfig {
            point_tol: 1e-7,
            cosine_tol: 1e-5,
            max_iterations: 32,
        }
    }
}

/// The outcome of [`newton`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NewtonResult<P, const N: usize> {
    /// Final parameters.
    pub t: [f32; N],
    /// `S(t)`.
    pub point: P,
    /// Squared distance `|S(t) − x|²`.
    pub distance_squared: f32,
    /// Iterations taken.
    pub iterations: u32,
    /// Whether a stopping test (rather than the iteration cap) ended the loop.
    pub converged: bool,
}

/// Newton iteration for the closest point to `x` from `t0`: solve `Ψ(t) = 0` with the full
/// Hessian `H = Sᵢ·Sⱼ + Γ·Sᵢⱼ`, falling back to a Gauss–Newton step where `H` is not positive
/// definite. Parameters are clamped at open boundaries and wrapped on closed ones. Stops on
/// point coincidence, zero cosine, or a negligible parameter change (P&T §6.1).
pub fn newton<S: Patch<N>, const N: usize>(
    patch: &S,
    x: S::P,
    t0: [f32; N],
    cfg: &NewtonConfig,
) -> NewtonResult<S::P, N> {
    let domain = patch.domain();
    // Closedness costs a few dozen evaluations: find it out only if a step leaves the domain.
    let mut periodic: Option<[bool; N]> = None;
    let mut t = t0;
    for i in 0..N {
        t[i] = clamp(t[i], domain[i]);
    }
    let eps1_sq = cfg.point_tol * cfg.point_tol;
    let eps2_sq = cfg.cosine_tol * cfg.cosine_tol;
    let mut jet = patch.jet(t, 2);
    let mut iterations = 0;
    let mut converged = false;
    while iterations < cfg.max_iterations {
        let gamma = jet.point - x;
        let g2 = gamma.length_squared();
        if g2 <= eps1_sq {
            converged = true;
            break;
        }
        let psi = jet.psi(gamma);
        // Zero cosine in every direction; a vanishing Sᵢ (pole) carries no information.
        let zero_cos = (0..N).all(|i| psi[i] * psi[i] <= eps2_sq * jet.d[i].length_squared() * g2);
        if zero_cos {
            converged = true;
            break;
        }
        let mut neg = [0.0; N];
        for i in 0..N {
            neg[i] = -psi[i];
        }
        let delta = solve_spd(jet.hessian(gamma), neg, 1e-6)
            .unwrap_or_else(|| gauss_newton_step(&jet.metric(), &psi));
        let mut moved = [0.0; N];
        for i in 0..N {
            let (a, b) = domain[i];
            let mut ti = t[i] + delta[i];
            let leaves = ti > domain[i].1 || ti < domain[i].0;
            if leaves && periodic.get_or_insert_with(|| patch.periodic(PERIODIC_TOL))[i] {
                let len = b - a;
                if ti > b || ti < a {
                    ti = a + (ti - a) - len * libm::floorf((ti - a) / len);
                }
            }
            let ti = clamp(ti, domain[i]);
            moved[i] = ti - t[i];
            t[i] = ti;
        }
        iterations += 1;
        let step = jet.displacement(&moved);
        jet = patch.jet(t, 2);
        if step.length_squared() <= eps1_sq {
            converged = true;
            break;
        }
    }
    NewtonResult {
        t,
        point: jet.point,
        distance_squared: (jet.point - x).length_squared(),
        iterations,
        converged,
    }
}
