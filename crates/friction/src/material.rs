//! Friction parameters of a material.

/// The Stribeck curve of the stuck → slip transition: how μ falls from μ_s to μ_d with the
/// god-object's slip speed `v`, `μ(v) = μ_d + (μ_s − μ_d) · m(s)` with
/// `s = 1 − (v / v_s)²` clamped to [0, 1] (1 at rest, 0 at and above the Stribeck speed `v_s`,
/// [`FrictionMaterial::stribeck_speed_m_per_s`]).
///
/// The curve reaches μ_d at a finite speed, so the transition ends (thesis §3.1.1: μ = μ_d once
/// the GO has caught up) and slip renders exactly μ_d. All shapes are polynomials in `v²`: no
/// square roots or transcendental functions in the tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Stribeck {
    /// `m(s) = s`: the thesis's linear interpolation between μ_s and μ_d.
    Linear,
    /// `m(s) = sⁿ`: a sharper drop right after breakaway for larger `n`.
    Power {
        /// The exponent `n` ≥ 1.
        exponent: u8,
    },
    /// `m(s) = 3s² − 2s³`: zero slope at both ends.
    Smoothstep,
}

impl Stribeck {
    /// `m(s)` for `s` clamped to [0, 1].
    #[inline]
    pub fn shape(&self, s: f32) -> f32 {
        let s = if s.is_nan() { 0.0 } else { s.clamp(0.0, 1.0) };
        match *self {
            Stribeck::Linear => s,
            Stribeck::Power { exponent } => {
                let mut m = 1.0;
                for _ in 0..exponent.max(1) {
                    m *= s;
                }
                m
            }
            Stribeck::Smoothstep => s * s * (3.0 - 2.0 * s),
        }
    }

    /// `μ = μ_d + (μ_s − μ_d) · m(s)`.
    #[inline]
    pub fn mu(&self, mu_static: f32, mu_dynamic: f32, s: f32) -> f32 {
        mu_dynamic + (mu_static - mu_dynamic) * self.shape(s)
    }

    /// μ at slip speed `speed_m_per_s` on a curve that reaches μ_d at `stribeck_speed_m_per_s`:
    /// `s = 1 − (v / v_s)²`.
    #[inline]
    pub fn mu_at_speed(
        &self,
        mu_static: f32,
        mu_dynamic: f32,
        speed_m_per_s: f32,
        stribeck_speed_m_per_s: f32,
    ) -> f32 {
        let vs_sq = stribeck_speed_m_per_s * stribeck_speed_m_per_s;
        let s = if vs_sq > 0.0 {
            1.0 - speed_m_per_s * speed_m_per_s / vs_sq
        } else {
            0.0
        };
        self.mu(mu_static, mu_dynamic, s)
    }
}

/// Which friction law renders the material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ModelKind {
    /// The thesis's stick–slip god-object algorithm (Algorithm 1).
    StickSlip,
    /// Coulomb plus viscous friction.
    CoulombViscous,
    /// Karnopp's stick band around zero velocity.
    Karnopp,
    /// Dahl's bristle model.
    Dahl,
    /// The LuGre model.
    LuGre,
}

/// Friction and contact parameters of a material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrictionMaterial {
    /// Contact stiffness `K` (N/m), also the god-object spring.
    pub stiffness_n_per_m: f32,
    /// Damping on the normal velocity (N·s/m).
    pub damping_ns_per_m: f32,
    /// Static coefficient μ_s.
    pub mu_static: f32,
    /// Dynamic coefficient μ_d ≤ μ_s.
    pub mu_dynamic: f32,
    /// The μ_s → μ_d modulation in the stuck → slip transition.
    pub stribeck: Stribeck,
    /// Frictional memory (s): the slip speed that sets μ on the Stribeck curve follows the
    /// god-object's speed with this first-order lag, so μ cannot fall faster than the
    /// contact's own time constant, however hard the hand jerks (Hess & Soom's lag).
    pub transition_time_s: f32,
    /// The transition ends when the god-object is within this distance of its slip position,
    /// where the spring carries exactly μ_d F_N (m).
    pub converge_tol_m: f32,
    /// The transition or slip sticks when the god-object's slip speed falls below this, or when
    /// the closest point moves back towards the god-object faster than this (m/s).
    pub stop_speed_m_per_s: f32,
    /// The friction law.
    pub model: ModelKind,
    /// Viscous coefficient σ₂ (N·s/m) of the Coulomb, Karnopp and LuGre laws.
    pub viscous_ns_per_m: f32,
    /// Karnopp's stick band half-width (m/s).
    pub karnopp_band_m_per_s: f32,
    /// Bristle stiffness σ₀ (N/m) of Dahl and LuGre.
    pub bristle_stiffness_n_per_m: f32,
    /// Bristle damping σ₁ (N·s/m) of LuGre.
    pub bristle_damping_ns_per_m: f32,
    /// Stribeck speed v_s (m/s): of the stick–slip transition's curve ([`Stribeck`]), where μ
    /// reaches μ_d; and of LuGre's `g(v)`.
    pub stribeck_speed_m_per_s: f32,
}

impl Default for FrictionMaterial {
    /// The thesis's simulation material: K = 1000 N/m, μ_s = 0.7, μ_d = 0.5.
    fn default() -> Self {
        FrictionMaterial {
            stiffness_n_per_m: 1000.0,
            damping_ns_per_m: 0.0,
            mu_static: 0.7,
            mu_dynamic: 0.5,
            stribeck: Stribeck::Linear,
            transition_time_s: 0.02,
            converge_tol_m: 1e-5,
            stop_speed_m_per_s: 1e-3,
            model: ModelKind::StickSlip,
            viscous_ns_per_m: 0.0,
            karnopp_band_m_per_s: 1e-3,
            bristle_stiffness_n_per_m: 2000.0,
            bristle_damping_ns_per_m: 0.0,
            stribeck_speed_m_per_s: 0.01,
        }
    }
}
