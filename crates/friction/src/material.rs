//! Friction parameters of a material.

/// How μ falls from μ_s to μ_d during the stuck → slip transition, as a function of
/// `s = |Ψ_GO| / |Ψ_GO at breakaway|` ∈ [0, 1] (1 at breakaway, 0 once the god-object has
/// caught up): `μ = μ_d + (μ_s − μ_d) · m(s)`.
///
/// The projection error of the god-object is proportional to its speed along the surface
/// (`ṫ = −KΨ`), so `m` shapes the velocity-dependent Stribeck drop. All shapes are
/// polynomials: no transcendental functions in the tick.
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
    /// Time constant of the god-object's convergence to the closest point in the transition
    /// (s): each tick closes `T / τ` of the gap (normalised law) on top of following the
    /// HIP's motion (feed-forward), so the transition lasts a few τ whatever the speed.
    pub transition_time_s: f32,
    /// The transition ends when the god-object is this close to the closest point (m).
    pub converge_tol_m: f32,
    /// Slip ends when the closest point moves slower than this (m/s).
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
    /// Stribeck velocity v_s (m/s) of LuGre.
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
