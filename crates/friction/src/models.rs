//! The classical friction models of thesis §1.4.1, behind one trait, for comparison with the
//! stick–slip god-object algorithm. Each works on a tangential velocity vector and returns the
//! friction force on the HIP (opposing the motion), generic over planar and spatial contact.

use nurbs::Point;
use nurbs::math::{self, sqrt};

/// What a velocity-based friction law sees each tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TangentialInput<P> {
    /// Tangential velocity of the contact point (m/s).
    pub velocity: P,
    /// Normal force magnitude (N), ≥ 0.
    pub normal_force_n: f32,
    /// Tangential force the user applies (N), used by Karnopp's stick band.
    pub applied: P,
    /// Tick period (s).
    pub period_s: f32,
}

/// A velocity-based friction law.
pub trait FrictionLaw<P: Point> {
    /// Friction force on the HIP for this tick (tangential, opposing the motion).
    fn force(&mut self, input: &TangentialInput<P>) -> P;
    /// Forget internal state (contact lost).
    fn reset(&mut self);
}

/// `v / |v|`, zero at rest.
#[inline]
fn direction<P: Point>(v: P) -> P {
    v.try_normalize().unwrap_or(P::ZERO)
}

/// Coulomb plus viscous: `F = −(μ_d F_N sgn v + σ₂ v)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CoulombViscous {
    /// Coulomb coefficient μ_d.
    pub mu: f32,
    /// Viscous coefficient σ₂ (N·s/m).
    pub viscous_ns_per_m: f32,
}

impl<P: Point> FrictionLaw<P> for CoulombViscous {
    fn force(&mut self, i: &TangentialInput<P>) -> P {
        -(direction(i.velocity) * (self.mu * i.normal_force_n) + i.velocity * self.viscous_ns_per_m)
    }
    fn reset(&mut self) {}
}

/// Karnopp: inside the band `|v| < D_v` the friction balances the applied force up to
/// `μ_s F_N` (stick); outside it is Coulomb plus viscous.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Karnopp {
    /// μ_s.
    pub mu_static: f32,
    /// μ_d.
    pub mu_dynamic: f32,
    /// σ₂ (N·s/m).
    pub viscous_ns_per_m: f32,
    /// Band half-width `D_v` (m/s).
    pub band_m_per_s: f32,
}

impl<P: Point> FrictionLaw<P> for Karnopp {
    fn force(&mut self, i: &TangentialInput<P>) -> P {
        if i.velocity.length_squared() < self.band_m_per_s * self.band_m_per_s {
            let limit = self.mu_static * i.normal_force_n;
            let a2 = i.applied.length_squared();
            if a2 <= limit * limit {
                -i.applied
            } else {
                -direction(i.applied) * limit
            }
        } else {
            -(direction(i.velocity) * (self.mu_dynamic * i.normal_force_n)
                + i.velocity * self.viscous_ns_per_m)
        }
    }
    fn reset(&mut self) {}
}

/// Dahl (exponent 1): `dF/dt = σ₀ (v − |v| F / F_c)` with `F_c = μ_d F_N`; the friction on the
/// HIP is `−F`. Integrated semi-implicitly (`F` at the new step on the right), which keeps
/// `|F| ≤ F_c` for any tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dahl<P> {
    /// μ_d.
    pub mu: f32,
    /// σ₀ (N/m).
    pub sigma0_n_per_m: f32,
    /// The state `F`.
    pub state: P,
}

impl<P: Point> FrictionLaw<P> for Dahl<P> {
    fn force(&mut self, i: &TangentialInput<P>) -> P {
        let fc = self.mu * i.normal_force_n;
        let speed2 = i.velocity.length_squared();
        let decay = if fc > 0.0 && speed2 > 0.0 {
            self.sigma0_n_per_m * sqrt(speed2) * i.period_s / fc
        } else if speed2 > 0.0 {
            f32::INFINITY
        } else {
            0.0
        };
        // F' = (F + σ₀ v T) / (1 + σ₀ |v| T / F_c)
        let next =
            (self.state + i.velocity * (self.sigma0_n_per_m * i.period_s)) * (1.0 / (1.0 + decay));
        let next = if next.is_finite() { next } else { P::ZERO };
        // |F| ≤ F_c holds for a constant normal force; when F_N falls the bristles slip to
        // the new limit.
        self.state = clamp_length(next, math::max(0.0, fc));
        -self.state
    }
    fn reset(&mut self) {
        self.state = P::ZERO;
    }
}

/// LuGre: `dz/dt = v − σ₀ |v| z / g(v)`, `F = σ₀ z + σ₁ dz/dt + σ₂ v`, with the Stribeck curve
/// in the algebraic form `g(v) = F_c + (F_s − F_c) / (1 + (|v|/v_s)²)` (same end values and
/// scale as the usual Gaussian, without `exp` in the tick). `F_s = μ_s F_N`, `F_c = μ_d F_N`;
/// the friction on the HIP is `−F`. `z` is integrated semi-implicitly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LuGre<P> {
    /// μ_s.
    pub mu_static: f32,
    /// μ_d.
    pub mu_dynamic: f32,
    /// σ₀ (N/m).
    pub sigma0_n_per_m: f32,
    /// σ₁ (N·s/m).
    pub sigma1_ns_per_m: f32,
    /// σ₂ (N·s/m).
    pub sigma2_ns_per_m: f32,
    /// v_s (m/s).
    pub stribeck_speed_m_per_s: f32,
    /// Bristle deflection `z` (m).
    pub z: P,
}

impl<P: Point> LuGre<P> {
    /// `g(v)` in newtons.
    pub fn g(&self, speed: f32, normal_force_n: f32) -> f32 {
        let fs = self.mu_static * normal_force_n;
        let fc = self.mu_dynamic * normal_force_n;
        let r = speed / math::max(f32::MIN_POSITIVE, self.stribeck_speed_m_per_s);
        fc + (fs - fc) / (1.0 + r * r)
    }
}

impl<P: Point> FrictionLaw<P> for LuGre<P> {
    fn force(&mut self, i: &TangentialInput<P>) -> P {
        let speed = sqrt(i.velocity.length_squared());
        let g = self.g(speed, i.normal_force_n);
        let k = if g > 0.0 {
            self.sigma0_n_per_m * speed / g
        } else if speed > 0.0 {
            f32::INFINITY
        } else {
            0.0
        };
        let z_next = (self.z + i.velocity * i.period_s) * (1.0 / (1.0 + k * i.period_s));
        let z_next = if z_next.is_finite() { z_next } else { P::ZERO };
        // The steady deflection is g(v)/σ₀ ≤ F_s/σ₀; when F_N falls the bristles slip to it.
        let z_next = clamp_length(
            z_next,
            math::max(0.0, g) / math::max(f32::MIN_POSITIVE, self.sigma0_n_per_m),
        );
        let zdot = (z_next - self.z) * (1.0 / math::max(f32::MIN_POSITIVE, i.period_s));
        self.z = z_next;
        -(self.z * self.sigma0_n_per_m
            + zdot * self.sigma1_ns_per_m
            + i.velocity * self.sigma2_ns_per_m)
    }
    fn reset(&mut self) {
        self.z = P::ZERO;
    }
}

/// `v` shortened to at most `max` long.
#[inline]
fn clamp_length<P: Point>(v: P, max: f32) -> P {
    let l2 = v.length_squared();
    if l2 > max * max && l2 > 0.0 {
        v * (max / sqrt(l2))
    } else {
        v
    }
}
