//! The physical parameters of a deformable object, as a user states them: per unit arc length
//! (curves) or area (surfaces) of the rest shape.

/// Which control points are held in place.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Fixed {
    /// A curve's first and last control points; a surface's boundary rows and columns.
    Edge,
    /// These control points (indices into the patch's points; a surface's `(i, j)` is
    /// `i · count_v + j`).
    Points(Vec<usize>),
}

/// The D-NURBS parameters of one object (thesis eqs. 4.5–4.9 with the weights frozen): mass
/// `μ`, damping `γ`, and the elasticity `α` (stretching) and `β` (bending), stated per unit
/// of the rest shape's arc length (curves) or area (surfaces).
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    /// Mass per length (kg/m) or per area (kg/m²). Default [`Params::CURVE`] /
    /// [`Params::SURFACE`].
    pub density: f64,
    /// Damping per length (N·s/m²) or per area (N·s/m³): a force per unit length (area) per
    /// unit velocity, against the velocity.
    pub damping: f64,
    /// Tension (N) of a curve or membrane tension (N/m) of a surface: resistance to the
    /// displacement's gradient along the rest shape (the taut string, the drum).
    pub tension: f64,
    /// Bending stiffness: `EI` (N·m²) of a curve, the plate's `D` (N·m) of a surface.
    pub bending: f64,
    /// The control points held in place.
    pub fixed: Fixed,
    /// When `Some(τ)`, the object is plastic: its rest shape creeps towards its current shape
    /// with time constant `τ` (s), so a dent stays (a Maxwell element in series with the
    /// elasticity; τ below the step makes it follow at once).
    pub plastic_time_s: Option<f64>,
}

/// One of the numeric parameters, for errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    /// [`Params::density`].
    Density,
    /// [`Params::damping`].
    Damping,
    /// [`Params::tension`].
    Tension,
    /// [`Params::bending`].
    Bending,
    /// [`Params::plastic_time_s`].
    PlasticTime,
}

impl Quantity {
    /// The scene file's field of this quantity for a curve or a surface.
    pub fn field(self, surface: bool) -> &'static str {
        match (self, surface) {
            (Quantity::Density, false) => "density_kg_per_m",
            (Quantity::Density, true) => "density_kg_per_m2",
            (Quantity::Damping, false) => "damping_ns_per_m2",
            (Quantity::Damping, true) => "damping_ns_per_m3",
            (Quantity::Tension, false) => "tension_n",
            (Quantity::Tension, true) => "tension_n_per_m",
            (Quantity::Bending, false) => "bending_n_m2",
            (Quantity::Bending, true) => "bending_n_m",
            (Quantity::PlasticTime, _) => "plastic_time_s",
        }
    }
}

/// Largest accepted value of every parameter: far past any object a hand pushes (a steel
/// wire of 1 mm² under its breaking load is ~10³ N), and small enough that every product the
/// assembly and the integrator form stays finite in f64.
pub const MAX_PARAM: f64 = 1e9;

/// Default plastic time constant (s) when a scene says `"plastic": true` without one: a dent
/// held for a few tenths of a second stays.
pub const DEFAULT_PLASTIC_TIME_S: f64 = 0.1;

impl Params {
    /// Defaults of a curve: a 10 cm string of 0.1 kg/m under 5 N (first mode
    /// `(1/2L)√(T/ρ)` ≈ 35 Hz, midpoint stiffness `4T/L` = 200 N/m), damped to about a fifth
    /// of critical in that mode (`γ / (2ρω)` ≈ 0.2), no bending, ends fixed, elastic.
    pub const CURVE: Params = Params {
        density: 0.1,
        damping: 10.0,
        tension: 5.0,
        bending: 0.0,
        fixed: Fixed::Edge,
        plastic_time_s: None,
    };

    /// Defaults of a surface: a drum skin of 1 kg/m² under 50 N/m, damped, no bending, its
    /// boundary fixed, elastic.
    pub const SURFACE: Params = Params {
        density: 1.0,
        damping: 100.0,
        tension: 50.0,
        bending: 0.0,
        fixed: Fixed::Edge,
        plastic_time_s: None,
    };

    /// The defaults of a curve or a surface.
    pub fn default_for(surface: bool) -> Params {
        if surface {
            Params::SURFACE
        } else {
            Params::CURVE
        }
    }

    /// Checks every value: finite, within [`MAX_PARAM`], density and the plastic time
    /// positive, the others non-negative, and some stiffness.
    pub fn validate(&self) -> Result<(), crate::DynamicsError> {
        use crate::DynamicsError::{NoStiffness, Param};
        let check = |quantity, value: f64, positive: bool| {
            let rule = if positive {
                "a positive number"
            } else {
                "a non-negative number"
            };
            let ok = value.is_finite()
                && value <= MAX_PARAM
                && if positive { value > 0.0 } else { value >= 0.0 };
            if ok {
                Ok(())
            } else {
                Err(Param {
                    quantity,
                    value,
                    rule,
                })
            }
        };
        check(Quantity::Density, self.density, true)?;
        check(Quantity::Damping, self.damping, false)?;
        check(Quantity::Tension, self.tension, false)?;
        check(Quantity::Bending, self.bending, false)?;
        if let Some(t) = self.plastic_time_s {
            check(Quantity::PlasticTime, t, true)?;
        }
        if self.tension == 0.0 && self.bending == 0.0 {
            return Err(NoStiffness);
        }
        Ok(())
    }
}
