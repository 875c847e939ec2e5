//! Feedback-stabilised closest-point tracking (thesis §2.1.2): a test point (TP) on the patch
//! moves with `ṫ = −K Ψ`, `Ψᵢ = Γ·Sᵢ`, `Γ = S(t) − x_HIP`, warm-started from the last tick.
//!
//! # Discrete stability
//!
//! One explicit Euler step of the plain law is `δ = −K T Ψ`. Near the closest point
//! `Ψ(t + δ) ≈ Ψ(t) + H δ` with `H = Sᵢ·Sⱼ + Γ·Sᵢⱼ` (the Hessian of `½|Γ|²`), so the error
//! obeys `e ← (I − K T H) e`, which is stable iff `0 < K T λ(H) < 2` for every eigenvalue.
//! On the surface (`Γ → 0`) `H` is the first fundamental form `G`; at signed distance `d`
//! on a curve of curvature `κ` it is `|S_u|² (1 + κ d)` (positive `κ d` on the convex side).
//! [`stable_gain_limit`] gives `2 / (T λ_max(H))`. With [`TrackerConfig::step_guard`] (on by
//! default) either law caps `ρ = λ_max(M H)` of its step `δ = −M Ψ` at 1, the deadbeat
//! (Newton) step: beyond it a step only overshoots, beyond 2 it diverges.
//!
//! The normalised law scales the gain by the inverse metric, `δ = −α G⁻¹ Ψ`, which for
//! `α = 1` is one Gauss–Newton step: dimensionless, independent of the parametrisation speed,
//! and stable for `0 < α (1 + κ d) < 2`.

use crate::linalg::{
    mat_vec, max_eigenvalue_product, norm2, regularized_inverse, scale, scaled_identity, solve_spd,
};
use crate::patch::{Jet, Patch};
use nurbs::Point;

/// The update law.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Law {
    /// The thesis's `ṫ = −K Ψ`, Euler-integrated over the tick; `gain` is `K` in
    /// parameter² / (m² s).
    Plain {
        /// `K`.
        gain: f32,
    },
    /// `δ = −α G⁻¹ Ψ` per iteration (a damped Gauss–Newton step; `α = 1` is the full step).
    Normalized {
        /// `α`, dimensionless, stable in (0, 2).
        alpha: f32,
    },
}

/// Tracker settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackerConfig {
    /// Update law and gain.
    pub law: Law,
    /// Updates per tick (default 1). The plain law splits the tick into this many Euler steps;
    /// the normalised law takes this many Gauss–Newton steps.
    pub iterations: u8,
    /// Feed-forward inside the ε-ball: when `|Ψ| < convergence_radius`, add
    /// `H⁻¹ Jᵀ Δx_HIP`, the first-order motion of the closest point caused by the HIP's
    /// displacement over the tick (implicit function theorem on `Ψ(t, x) = 0`; `G⁻¹` where
    /// `H` is not positive definite). This
    /// is the thesis's compensation that makes the tracking asymptotically, not only
    /// practically, stable against a moving HIP.
    pub feedforward: bool,
    /// ε of the theorem, in the units of Ψ (m² per parameter unit).
    pub convergence_radius: f32,
    /// Cap the plain law's gain at the discrete stability limit (see the module docs).
    pub step_guard: bool,
    /// Largest parameter step per iteration, as a fraction of the domain length (a trust
    /// region that keeps one bad step from leaving the basin of the closest point).
    pub max_step_fraction: f32,
}

impl Default for TrackerConfig {
    fn default() -> Self {
        TrackerConfig {
            law: Law::Normalized { alpha: 1.0 },
            iterations: 1,
            feedforward: false,
            convergence_radius: 1e-6,
            step_guard: true,
            max_step_fraction: 0.25,
        }
    }
}

/// The smallest gain `K > 2 Γ̄ V̄ / ε²` of Theorem 2.1.1 (thesis eq. 2.16), with `gamma_bar`
/// the bound on `|Γ|` (metres, the workspace size), `v_bar` the HIP speed bound (m/s) and
/// `eps` the convergence radius ε (units of Ψ). Multiply by a margin > 1 to use it.
pub fn theorem_gain(gamma_bar: f32, v_bar: f32, eps: f32) -> f32 {
    2.0 * gamma_bar * v_bar / (eps * eps)
}

/// The largest plain-law gain that keeps the discrete update stable at `jet`, for a HIP at
/// `hip` and tick `period_s`: `2 / (T λ_max(H))`, `H = Sᵢ·Sⱼ + Γ·Sᵢⱼ` (jet of order 2).
/// Infinite where `H` has no positive eigenvalue (near a centre of curvature every step
/// size is "stable" for the linearisation, and the trust region governs).
pub fn stable_gain_limit<P: Point, const N: usize>(jet: &Jet<P, N>, hip: P, period_s: f32) -> f32 {
    let h = jet.hessian(jet.point - hip);
    let lmax = max_eigenvalue(&h);
    if lmax > 0.0 {
        2.0 / (period_s * lmax)
    } else {
        f32::INFINITY
    }
}

/// Largest eigenvalue of a symmetric `N×N` matrix, N ≤ 2.
pub(crate) fn max_eigenvalue<const N: usize>(a: &[[f32; N]; N]) -> f32 {
    match N {
        1 => a[0][0],
        2 => {
            let (p, q, r) = (a[0][0], a[0][1], a[1][1]);
            let m = 0.5 * (p + r);
            let d = 0.5 * (p - r);
            m + nurbs::math::sqrt(d * d + q * q)
        }
        _ => f32::NAN,
    }
}

/// What one tracker update found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Track<P, const N: usize> {
    /// Parameters of the test point.
    pub t: [f32; N],
    /// The test point `S(t)`: the closest-point estimate.
    pub point: P,
    /// Unit outward normal at `t`.
    pub normal: P,
    /// Projection error `Ψ` at the new `t` for this tick's HIP.
    pub psi: [f32; N],
    /// `(x_HIP − S)·n`: positive outside, negative inside (penetration).
    pub signed_distance: f32,
    /// Whether a parameter sits on an open boundary of the domain (the closest point may be
    /// on a neighbouring feature).
    pub at_boundary: [i8; N],
}

/// A closest-point tracker on one patch with `N` parameters.
///
/// It keeps the test point's parameters and the jet there between ticks; the patch itself is
/// passed to every call, so the tracker holds no borrow and lives in a `static` on the MCU.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tracker<P: Point, const N: usize> {
    cfg: TrackerConfig,
    t: [f32; N],
    jet: Jet<P, N>,
    domain: [(f32, f32); N],
    periodic: [bool; N],
    collapsed: [[bool; 2]; N],
    last_hip: Option<P>,
}

/// Tolerance (metres) for deciding a patch closes on itself.
pub const PERIODIC_TOL: f32 = 1e-6;

impl<P: Point, const N: usize> Tracker<P, N> {
    /// A tracker on `patch` starting at `t0` (clamped into the domain).
    pub fn new<S: Patch<N, P = P>>(patch: &S, t0: [f32; N], cfg: TrackerConfig) -> Self {
        let periodic = patch.periodic(PERIODIC_TOL);
        let collapsed = patch.collapsed(PERIODIC_TOL);
        Self::with_topology(patch, t0, cfg, periodic, collapsed)
    }

    /// A tracker on `patch` whose closedness (`periodic`) and collapsed sides are already known
    /// (an object classifies its patches once at load), so no sampling happens here.
    pub fn with_topology<S: Patch<N, P = P>>(
        patch: &S,
        t0: [f32; N],
        cfg: TrackerConfig,
        periodic: [bool; N],
        collapsed: [[bool; 2]; N],
    ) -> Self {
        let domain = patch.domain();
        let mut t = t0;
        for i in 0..N {
            t[i] = clamp(t[i], domain[i]);
        }
        Tracker {
            cfg,
            t,
            jet: patch.jet(t, 2),
            domain,
            periodic,
            collapsed,
            last_hip: None,
        }
    }

    /// [`Tracker::with_topology`] at `t0` (inside the domain) with `jet`, the patch's jet of
    /// order 2 there, evaluated beforehand: no evaluation.
    pub(crate) fn with_jet<S: Patch<N, P = P>>(
        patch: &S,
        t0: [f32; N],
        jet: Jet<P, N>,
        cfg: TrackerConfig,
        periodic: [bool; N],
        collapsed: [[bool; 2]; N],
    ) -> Self {
        Tracker {
            cfg,
            t: t0,
            jet,
            domain: patch.domain(),
            periodic,
            collapsed,
            last_hip: None,
        }
    }

    /// Moves the test point to `t` on the same patch (re-initialisation).
    pub fn reset<S: Patch<N, P = P>>(&mut self, patch: &S, t: [f32; N]) {
        for i in 0..N {
            self.t[i] = clamp(t[i], self.domain[i]);
        }
        self.jet = patch.jet(self.t, 2);
        self.last_hip = None;
    }

    /// Re-evaluates the cached jet at the current parameters on `patch`, keeping everything
    /// else (the parameters, the HIP of the last update): for a patch whose control points
    /// moved under the tracker (same knots, so the same domain), so that the next update steps
    /// from the moved patch's geometry rather than the old one's.
    pub fn refresh<S: Patch<N, P = P>>(&mut self, patch: &S) {
        self.jet = patch.jet(self.t, 2);
    }

    /// Current parameters.
    pub fn t(&self) -> [f32; N] {
        self.t
    }

    /// The patch's jet (order 2) at [`Tracker::t`], as the last update left it.
    pub fn jet(&self) -> &Jet<P, N> {
        &self.jet
    }

    /// The settings.
    pub fn config(&self) -> &TrackerConfig {
        &self.cfg
    }

    /// Changes the settings (takes effect on the next update).
    pub fn set_config(&mut self, cfg: TrackerConfig) {
        self.cfg = cfg;
    }

    /// Which directions wrap around.
    pub fn periodic(&self) -> [bool; N] {
        self.periodic
    }

    /// One tick: moves the test point towards the closest point to `hip` and reports the
    /// contact geometry there. `period_s` is the tick period `T`. Total: never panics, and
    /// returns finite values for finite input.
    pub fn update<S: Patch<N, P = P>>(&mut self, patch: &S, hip: P, period_s: f32) -> Track<P, N> {
        let iterations = self.cfg.iterations.max(1);
        let dt = period_s / iterations as f32;
        let hip_step = match self.last_hip {
            Some(prev) if self.cfg.feedforward => hip - prev,
            _ => P::ZERO,
        };
        for k in 0..iterations {
            let gamma = self.jet.point - hip;
            let psi = self.jet.psi(gamma);
            let g = self.jet.metric();
            // δ = −M Ψ with M = K T·I (plain) or α G⁻¹ (normalised).
            let mut m = match self.cfg.law {
                Law::Plain { gain } => scaled_identity::<N>(gain * dt),
                Law::Normalized { alpha } => scale(&regularized_inverse(&g), alpha),
            };
            if self.cfg.step_guard {
                // The linearised error map is e ← (I − M H) e. Its stiffest mode moves
                // ρ = λ_max(M H) times a Newton step; beyond ρ = 1 a step only overshoots (and
                // beyond 2 it diverges), so cap ρ at the deadbeat value 1.
                let rho = max_eigenvalue_product(&m, &self.jet.hessian(gamma));
                if rho > 1.0 {
                    m = scale(&m, 1.0 / rho);
                }
            }
            let mut delta = mat_vec(&m, &psi);
            for v in delta.iter_mut() {
                *v = -*v;
            }
            // Feed-forward once per tick, inside the ε-ball only. The feedback step already
            // sees this tick's HIP, so predicting first and correcting after gives
            // δ = −M Ψ(t, x) + (I − M H) δ_ff: nothing is added for a deadbeat step (M = H⁻¹),
            // all of δ_ff for a slow one.
            if k == 0
                && self.cfg.feedforward
                && norm2(&psi) < self.cfg.convergence_radius * self.cfg.convergence_radius
            {
                // Implicit function theorem on Ψ(t, x) = 0: H dt = Jᵀ dx.
                let h = self.jet.hessian(gamma);
                let rhs = self.jet.psi(hip_step);
                let ff = solve_spd(h, rhs, 1e-6)
                    .unwrap_or_else(|| mat_vec(&regularized_inverse(&g), &rhs));
                let mh_ff = mat_vec(&m, &mat_vec(&h, &ff));
                for i in 0..N {
                    delta[i] += ff[i] - mh_ff[i];
                }
            }
            self.step(patch, delta);
        }
        self.last_hip = Some(hip);
        self.report(patch, hip)
    }

    /// Applies a parameter step with the trust region, clamping or wrapping, and refreshes the
    /// cached jet.
    fn step<S: Patch<N, P = P>>(&mut self, patch: &S, delta: [f32; N]) {
        let mut t = self.t;
        for i in 0..N {
            let (a, b) = self.domain[i];
            let len = b - a;
            let max = self.cfg.max_step_fraction.clamp(0.0, 0.5) * len;
            let d = if delta[i].is_finite() {
                delta[i].clamp(-max, max)
            } else {
                0.0
            };
            t[i] = self.t[i] + d;
        }
        for i in 0..N {
            let (a, b) = self.domain[i];
            let len = b - a;
            if self.periodic[i] {
                // |d| ≤ len / 2, so one wrap is enough.
                if t[i] > b {
                    t[i] -= len;
                } else if t[i] < a {
                    t[i] += len;
                }
            } else if let Some(j) = (0..N).find(|&j| j != i && self.periodic[j]) {
                // Past a pole: continue down the opposite meridian (half a period round).
                let over = if t[i] > b && self.collapsed[i][1] {
                    Some(b)
                } else if t[i] < a && self.collapsed[i][0] {
                    Some(a)
                } else {
                    None
                };
                if let Some(pole) = over {
                    t[i] = 2.0 * pole - t[i];
                    let (aj, bj) = self.domain[j];
                    t[j] += 0.5 * (bj - aj);
                    if t[j] > bj {
                        t[j] -= bj - aj;
                    }
                }
            }
        }
        for i in 0..N {
            self.t[i] = clamp(t[i], self.domain[i]);
        }
        self.jet = patch.jet(self.t, 2);
    }

    /// Contact geometry at the current test point.
    fn report<S: Patch<N, P = P>>(&self, patch: &S, hip: P) -> Track<P, N> {
        let normal = patch.normal(self.t, &self.jet);
        let gamma = self.jet.point - hip;
        let mut at_boundary = [0i8; N];
        for i in 0..N {
            if !self.periodic[i] {
                let (a, b) = self.domain[i];
                at_boundary[i] = if self.t[i] <= a {
                    -1
                } else if self.t[i] >= b {
                    1
                } else {
                    0
                };
            }
        }
        Track {
            t: self.t,
            point: self.jet.point,
            normal,
            psi: self.jet.psi(gamma),
            // Saturated: a HIP near f32::MAX must not report an infinite distance.
            signed_distance: (-gamma.dot(normal)).clamp(-f32::MAX, f32::MAX),
            at_boundary,
        }
    }
}

/// `−G⁻¹ Ψ`: the Gauss–Newton step, regularised where `G` is singular.
#[inline]
pub(crate) fn gauss_newton_step<const N: usize>(g: &[[f32; N]; N], psi: &[f32; N]) -> [f32; N] {
    let mut d = mat_vec(&regularized_inverse(g), psi);
    for v in d.iter_mut() {
        *v = -*v;
    }
    d
}

#[inline]
pub(crate) fn clamp(t: f32, (a, b): (f32, f32)) -> f32 {
    // NaN → a.
    nurbs::math::min(b, nurbs::math::max(a, t))
}
