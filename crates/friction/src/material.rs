//! Friction parameters of a material.

/// The shape of μ's fall from μ_s to μ_d through the stuck → slip transition (thesis §3.1.1,
/// Fig. 3.1.1(b)): `μ = μ_d + (μ_s − μ_d) · m(s)`, with `s` the share of the transition still to
/// run (1 at breakaway, 0 at its end).
///
/// How fast the transition runs is the Stribeck effect: it takes
/// [`FrictionMaterial::transition_time_s`] τ for a contact sliding at or above the Stribeck
/// speed `v_s`, and `τ v_s / v` at a slower `v` ([`FrictionMaterial::transition_duration_s`]).
/// Then slip renders exactly μ_d: the steady friction is not velocity-weakening, so a steady
/// slide at any speed settles instead of juddering. All shapes are polynomials: no square
/// roots or transcendental functions in the tick.
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
    /// The shape of μ's fall from μ_s to μ_d in the stuck → slip transition.
    pub stribeck: Stribeck,
    /// Frictional memory (s): the shortest the stuck → slip transition takes (at or above the
    /// Stribeck speed), so μ cannot fall faster than the contact's own time constant however
    /// hard the hand jerks (Hess & Soom's lag); a third of it is the time constant of the
    /// god-object's low-passed slip speed. The default, 60 ms, is several periods of a relaxed grip on the
    /// handle (300 N/m on some 50 g rings at about 12 Hz): the handle follows the friction's
    /// fall without ringing back and sticking again, where 20 ms made the app's hand
    /// stick–slip along thesis-2d's arc.
    pub transition_time_s: f32,
    /// The transition ends when the god-object at the transition's μ is within this distance
    /// of its slip position at μ_d, `(μ − μ_d)·depth ≤ converge_tol_m` (m).
    pub converge_tol_m: f32,
    /// The transition or slip sticks when the god-object's low-passed slip speed falls below
    /// this, or when the HIP moves back towards the god-object faster than this (m/s). Below
    /// the slowest tracing speed a hand keeps up (1 mm/s), so a slow steady slide never sticks.
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
    /// Stribeck speed v_s (m/s): a stick–slip transition at a sliding speed `v` below it takes
    /// `τ v_s / v` instead of τ ([`Stribeck`]); and the speed of LuGre's `g(v)`.
    pub stribeck_speed_m_per_s: f32,
}

impl FrictionMaterial {
    /// How long the stuck → slip transition takes for a contact sliding at `speed_m_per_s`:
    /// `τ · max(1, v_s / v)` (infinite at rest).
    pub fn transition_duration_s(&self, speed_m_per_s: f32) -> f32 {
        if speed_m_per_s >= self.stribeck_speed_m_per_s {
            self.transition_time_s
        } else {
            self.transition_time_s * self.stribeck_speed_m_per_s / speed_m_per_s
        }
    }
}

/// Why a material is invalid; the message starts with `material.<field>`, the field's name in
/// the `scene/1` format.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MaterialError {
    /// A value is negative or not finite.
    Range {
        /// The field.
        field: &'static str,
        /// The value given.
        value: f32,
    },
    /// A value that must be strictly positive is not, or is not finite.
    Positive {
        /// The field.
        field: &'static str,
        /// The value given.
        value: f32,
    },
    /// The exponent of `stribeck: {"power": n}` is not an integer in 1..=255 (as written in
    /// a file, hence `f64`).
    Exponent {
        /// The value given.
        value: f64,
    },
    /// A value above what a device can render ([`FrictionMaterial::MAX`]).
    TooLarge {
        /// The field.
        field: &'static str,
        /// The value given.
        value: f32,
        /// The largest value accepted.
        max: f32,
    },
    /// Dynamic friction exceeds static friction.
    FrictionOrder {
        /// Static friction coefficient.
        mu_static: f32,
        /// Dynamic friction coefficient.
        mu_dynamic: f32,
    },
}

impl MaterialError {
    /// The field at fault.
    pub fn field(&self) -> &'static str {
        match self {
            MaterialError::Range { field, .. }
            | MaterialError::Positive { field, .. }
            | MaterialError::TooLarge { field, .. } => field,
            MaterialError::Exponent { .. } => "stribeck",
            MaterialError::FrictionOrder { .. } => "mu_dynamic",
        }
    }
}

impl core::fmt::Display for MaterialError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            MaterialError::Range { field, value } => {
                write!(f, "material.{field}: {value} must be finite and >= 0")
            }
            MaterialError::Positive { field, value } => {
                write!(f, "material.{field}: {value} must be finite and > 0")
            }
            MaterialError::TooLarge { field, value, max } => write!(
                f,
                "material.{field}: {value} is larger than {max}, the most a device renders"
            ),
            MaterialError::Exponent { value } => write!(
                f,
                "material.stribeck.power: {value} must be an integer from 1 to 255"
            ),
            MaterialError::FrictionOrder {
                mu_static,
                mu_dynamic,
            } => write!(
                f,
                "material.mu_dynamic: {mu_dynamic} is larger than mu_static ({mu_static}); \
                 dynamic friction must not exceed static friction"
            ),
        }
    }
}

impl core::error::Error for MaterialError {}

impl FrictionMaterial {
    /// The largest value of each field the rules accept: far beyond any device's rendering
    /// (a desktop device renders a few thousand N/m and a few N·s/m; μ above 2 is glue),
    /// low enough that every force the renderer computes stays finite in `f32` for any HIP
    /// in a workspace (|x| ≤ 1 m) at any speed a clock can produce (10⁴ m/s: a metre in a
    /// 10 kHz tick). The model and Stribeck shape are those of the default.
    pub const MAX: FrictionMaterial = FrictionMaterial {
        stiffness_n_per_m: 1e6,
        damping_ns_per_m: 1e4,
        mu_static: 10.0,
        mu_dynamic: 10.0,
        stribeck: Stribeck::Linear,
        transition_time_s: 100.0,
        converge_tol_m: 1.0,
        stop_speed_m_per_s: 100.0,
        model: ModelKind::StickSlip,
        viscous_ns_per_m: 1e4,
        karnopp_band_m_per_s: 100.0,
        bristle_stiffness_n_per_m: 1e7,
        bristle_damping_ns_per_m: 1e4,
        stribeck_speed_m_per_s: 100.0,
    };

    /// The one set of material rules, applied by the scene loader, the app's material editor
    /// and the device to an uploaded material: every value finite and at most
    /// [`FrictionMaterial::MAX`]'s; stiffness, damping, μs, μd, stop speed, viscous, Karnopp
    /// band and bristle damping ≥ 0; transition time, convergence tolerance, bristle
    /// stiffness and Stribeck speed > 0; μd ≤ μs; a Stribeck power exponent ≥ 1. The first
    /// field at fault, in the format's order.
    pub fn validate(&self) -> Result<(), MaterialError> {
        let at_most = |field, value: f32, max: f32| {
            if value <= max {
                Ok(())
            } else {
                Err(MaterialError::TooLarge { field, value, max })
            }
        };
        let non_negative = |field, value: f32, max| {
            if value.is_finite() && value >= 0.0 {
                at_most(field, value, max)
            } else {
                Err(MaterialError::Range { field, value })
            }
        };
        let positive = |field, value: f32, max| {
            if value.is_finite() && value > 0.0 {
                at_most(field, value, max)
            } else {
                Err(MaterialError::Positive { field, value })
            }
        };
        let m = Self::MAX;
        non_negative(
            "stiffness_n_per_m",
            self.stiffness_n_per_m,
            m.stiffness_n_per_m,
        )?;
        non_negative(
            "damping_ns_per_m",
            self.damping_ns_per_m,
            m.damping_ns_per_m,
        )?;
        non_negative("mu_static", self.mu_static, m.mu_static)?;
        non_negative("mu_dynamic", self.mu_dynamic, m.mu_dynamic)?;
        if self.mu_dynamic > self.mu_static {
            return Err(MaterialError::FrictionOrder {
                mu_static: self.mu_static,
                mu_dynamic: self.mu_dynamic,
            });
        }
        if let Stribeck::Power { exponent: 0 } = self.stribeck {
            return Err(MaterialError::Exponent { value: 0.0 });
        }
        positive(
            "transition_time_s",
            self.transition_time_s,
            m.transition_time_s,
        )?;
        positive("converge_tol_m", self.converge_tol_m, m.converge_tol_m)?;
        non_negative(
            "stop_speed_m_per_s",
            self.stop_speed_m_per_s,
            m.stop_speed_m_per_s,
        )?;
        non_negative(
            "viscous_ns_per_m",
            self.viscous_ns_per_m,
            m.viscous_ns_per_m,
        )?;
        non_negative(
            "karnopp_band_m_per_s",
            self.karnopp_band_m_per_s,
            m.karnopp_band_m_per_s,
        )?;
        positive(
            "bristle_stiffness_n_per_m",
            self.bristle_stiffness_n_per_m,
            m.bristle_stiffness_n_per_m,
        )?;
        non_negative(
            "bristle_damping_ns_per_m",
            self.bristle_damping_ns_per_m,
            m.bristle_damping_ns_per_m,
        )?;
        positive(
            "stribeck_speed_m_per_s",
            self.stribeck_speed_m_per_s,
            m.stribeck_speed_m_per_s,
        )
    }
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
            transition_time_s: 0.06,
            converge_tol_m: 1e-5,
            stop_speed_m_per_s: 5e-4,
            model: ModelKind::StickSlip,
            viscous_ns_per_m: 0.0,
            karnopp_band_m_per_s: 1e-3,
            bristle_stiffness_n_per_m: 2000.0,
            bristle_damping_ns_per_m: 0.0,
            stribeck_speed_m_per_s: 0.01,
        }
    }
}
