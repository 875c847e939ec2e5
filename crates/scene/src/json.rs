//! The `scene/1` file format: objects made of NURBS patches, each with its material.
//!
//! A scene is read in two steps. serde parses the JSON into private raw types that mirror the
//! file (strict: unknown fields are errors), then validation turns them into [`Scene`],
//! [`Object`], [`Material`] and [`Patch`], whose patches are already validated `nurbs` curves
//! and surfaces. Every error says where it is: object index and name, patch index, field
//! (and, for JSON errors, line and column).
//!
//! ```json
//! {
//!   "format": "scene/1",
//!   "objects": [
//!     { "name": "wedge",
//!       "material": { "stiffness_n_per_m": 1000.0, "damping_ns_per_m": 0.0,
//!                     "mu_static": 0.7, "mu_dynamic": 0.5 },
//!       "patches": [
//!         { "degree": 3, "knots": [0, 0, 0, 0, 1, 1, 1, 1],
//!           "points": [[0.0, 0.0], [0.01, 0.02], [0.03, 0.01], [0.04, 0.0]],
//!           "weights": [1, 1, 1, 1] } ] } ]
//! }
//! ```
//!
//! A patch with a scalar `degree` is a curve: flat `knots`, `points[i]` of 2 (planar) or 3
//! (spatial) Cartesian coordinates, all of one dimension. A patch with `degree: [p, q]` is a
//! surface: `knots: [U, V]`, `points[i][j]` of 3 coordinates with `i` along u and `j` along v.
//! `weights` is optional (all 1) and has the shape of `points` without the coordinates.
//! Points are Cartesian (not multiplied by their weight), in metres, in the device frame.
//!
//! An object is either a 2-D chain of planar curves ([`tracker::Chain`]: consecutive curves
//! join end to start, a closed chain runs counter-clockwise) or a 3-D shell of surfaces
//! ([`tracker::Shell`]); a single patch of either kind is a valid object. Spatial curves and
//! objects that mix planar curves and surfaces are rejected.
//!
//! The `material` has four required fields (`stiffness_n_per_m` ≥ 0 and ≤ 1e6,
//! `damping_ns_per_m` ≥ 0 and ≤ 1e4, `mu_static` and `mu_dynamic` ≥ 0 and ≤ 10, μd ≤ μs) and
//! optional friction-rendering fields, whose defaults are
//! [`friction::FrictionMaterial::default`]'s (see [`Material::friction_material`]). The upper
//! bounds ([`friction::FrictionMaterial::MAX`]) are far beyond what a device renders and keep
//! every force the renderer computes finite:
//!
//! | field | default | valid |
//! |---|---|---|
//! | `stribeck` | `"linear"` | `"linear"`, `{"power": n}` (integer n in 1..=255), `"smoothstep"` |
//! | `transition_time_s` | 0.06 | > 0, ≤ 100 |
//! | `converge_tol_m` | 1e-5 | > 0, ≤ 1 |
//! | `stop_speed_m_per_s` | 5e-4 | ≥ 0, ≤ 100 |
//! | `model` | `"stick_slip"` | `"stick_slip"`, `"coulomb_viscous"`, `"karnopp"`, `"dahl"`, `"lugre"` |
//! | `viscous_ns_per_m` | 0 | ≥ 0, ≤ 1e4 |
//! | `karnopp_band_m_per_s` | 1e-3 | ≥ 0, ≤ 100 |
//! | `bristle_stiffness_n_per_m` | 2000 | > 0, ≤ 1e7 |
//! | `bristle_damping_ns_per_m` | 0 | ≥ 0, ≤ 1e4 |
//! | `stribeck_speed_m_per_s` | 0.01 | > 0, ≤ 100 |
//!
//! An object of one patch may carry a `"dynamics"` block, which makes it deformable (D-NURBS,
//! crate `deform`); without one it is rigid. Its fields, per unit arc length (curves) or area
//! (surfaces) of the rest shape, with the defaults of [`Params::CURVE`] / [`Params::SURFACE`]:
//!
//! | curve field | surface field | default (curve / surface) | valid |
//! |---|---|---|---|
//! | `density_kg_per_m` | `density_kg_per_m2` | 0.1 / 1 | > 0 |
//! | `damping_ns_per_m2` | `damping_ns_per_m3` | 10 / 100 | ≥ 0 |
//! | `tension_n` | `tension_n_per_m` | 5 / 50 | ≥ 0 |
//! | `bending_n_m2` | `bending_n_m` | 0 / 0 | ≥ 0, tension + bending > 0 |
//! | `fixed` | `fixed` | `"ends"` / `"boundary"` | that, or `[i, …]` / `[[i, j], …]` |
//! | `plastic` | `plastic` | `false` | `true`: the rest shape follows the shape |
//! | `plastic_time_s` | `plastic_time_s` | 0.1 (with `plastic`) | > 0 |
//!
//! All at most 10⁹. A field of the other kind (`tension_n_per_m` on a curve) is refused naming
//! the right one.
//!
//! A fixed control point is held in place (a pin: its position, not its tangent). The object
//! must be held: a motion that costs no energy is refused at load (`dynamics: fixed: the
//! object is not held …`), since a load would send it away. Tension resists only stretching,
//! so one fixed point holds a string or a membrane; bending alone resists only curvature, so
//! a beam needs two and a plate three not on one line. An end is clamped (position and
//! tangent) by fixing its first two control points, `[0, 1]` (the curve's tangent at the end
//! is along the first leg of the polygon). What cannot be said: a point held in one direction
//! only (a roller), a spring support, a prescribed non-zero displacement, a hold that moves.
//!
//! Every number must be finite and representable in `f32` (the loop's type). Control point
//! coordinates lie within ±[`nurbs::MAX_COORDINATE`] (10⁶ m); weights are positive normal
//! `f32`s, each at least [`nurbs::MIN_WEIGHT_RATIO`] (10⁻⁶) of its patch's largest weight:
//! the same rules the device applies to an uploaded scene.
//!
//! Writing a [`Scene`] back as a `scene/1` document (the app's Save), the inverse of
//! [`Scene::from_json_str`]. Numbers are written as the shortest decimals that read back as
//! the same `f32`; points are Cartesian (the homogeneous coordinates divided by the weight),
//! so a curve with unit weights reads back bit for bit, and a rational one to within an ulp
//! of each coordinate (the reader multiplies by the weight again).

use std::fmt::Write as _;
use std::path::Path;

use friction::{FrictionMaterial, ModelKind, Stribeck};
use nurbs::{At, CurveBuf, Field, NurbsError, Point, SurfaceBuf, Vec3, Vec4};
use serde::Deserialize;
use serde::de::{self, DeserializeOwned, Deserializer, SeqAccess, Visitor};
use serde_json::{Map, Value, json};

use deform::{DEFAULT_PLASTIC_TIME_S, Quantity};

use crate::{
    FORMAT, Fixed, Material, MaterialError, Object, ObjectError, Params, Patch, PatchError, Scene,
    SceneError,
};

impl Scene {
    /// Parses and validates a `scene/1` document.
    pub fn from_json_str(text: &str) -> Result<Self, SceneError> {
        // The format is checked first so that a file of another version is reported as such,
        // not as a list of unknown fields.
        // Read as a map rather than a struct, which serde would also accept as an array.
        let header: serde_json::Map<String, serde_json::Value> = parse(text)?;
        match header.get("format") {
            Some(serde_json::Value::String(f)) if f == FORMAT => {}
            found => {
                return Err(SceneError::Format {
                    found: found.map(serde_json::Value::to_string),
                });
            }
        }
        let raw: RawScene = parse(text)?;
        Self::from_raw(raw)
    }

    /// Reads, parses and validates a `scene/1` file; errors name the file.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, SceneError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|error| SceneError::Read {
            path: path.to_owned(),
            error,
        })?;
        Self::from_json_str(&text).map_err(|error| SceneError::File {
            path: path.to_owned(),
            error: Box::new(error),
        })
    }

    fn from_raw(raw: RawScene) -> Result<Self, SceneError> {
        let objects = raw
            .objects
            .into_iter()
            .enumerate()
            .map(|(index, o)| {
                let name = o.name.clone();
                Object::from_raw(o).map_err(|error| SceneError::Object { index, name, error })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Scene::new(objects)
    }
}

impl Object {
    fn from_raw(raw: RawObject) -> Result<Self, ObjectError> {
        let material = Material::from_raw(&raw.material)?;
        let patches = raw
            .patches
            .iter()
            .enumerate()
            .map(|(index, p)| {
                Patch::from_raw(p).map_err(|error| ObjectError::Patch { index, error })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let dynamics = match &raw.dynamics {
            Some(d) => Some(dynamics_from_raw(d, &patches)?),
            None => None,
        };
        Object::new(raw.name, material, patches)?.with_dynamics(dynamics)
    }
}

/// The `dynamics` block of an object whose patches are `patches`: the field names of its kind
/// (a curve's `tension_n`, a surface's `tension_n_per_m`, …), absent fields the defaults of
/// [`Params::default_for`], `fixed` as `"ends"`/`"boundary"` or indices.
fn dynamics_from_raw(d: &RawDynamics, patches: &[Patch]) -> Result<Params, ObjectError> {
    let err = |message: String| ObjectError::Dynamics { message };
    let (surface, count_v, count) = match patches.first() {
        Some(Patch::Surface(s)) => (true, s.counts().1, s.points().len()),
        Some(Patch::Curve2(c)) => (false, 0, c.points().len()),
        Some(Patch::Curve3(c)) => (false, 0, c.points().len()),
        None => (false, 0, 0),
    };
    let kind = if surface { "surface" } else { "curve" };
    // (value, the field of this kind, the other kind's field): a field of the other kind is
    // refused naming the right one.
    let pick = |mine: Option<F32>, theirs: Option<F32>, quantity: Quantity, default: f64| {
        if theirs.is_some() {
            return Err(err(format!(
                "dynamics.{}: a field of a {}, but this object is a {kind} (use {})",
                quantity.field(!surface),
                if surface { "curve" } else { "surface" },
                quantity.field(surface)
            )));
        }
        Ok(mine.map_or(default, |v| f64::from(v.0)))
    };
    let (c, s) = (d, d);
    let mine = |a: Option<F32>, b: Option<F32>| if surface { (b, a) } else { (a, b) };
    let defaults = Params::default_for(surface);
    let (m, t) = mine(c.density_kg_per_m, s.density_kg_per_m2);
    let density = pick(m, t, Quantity::Density, defaults.density)?;
    let (m, t) = mine(c.damping_ns_per_m2, s.damping_ns_per_m3);
    let damping = pick(m, t, Quantity::Damping, defaults.damping)?;
    let (m, t) = mine(c.tension_n, s.tension_n_per_m);
    let tension = pick(m, t, Quantity::Tension, defaults.tension)?;
    let (m, t) = mine(c.bending_n_m2, s.bending_n_m);
    let bending = pick(m, t, Quantity::Bending, defaults.bending)?;
    let edge = if surface { "boundary" } else { "ends" };
    let fixed = match &d.fixed {
        None => Fixed::Edge,
        Some(Value::String(name)) if name == edge => Fixed::Edge,
        Some(Value::Array(items)) => {
            let mut list = Vec::with_capacity(items.len());
            for (k, item) in items.iter().enumerate() {
                let index = if surface {
                    item.as_array()
                        .filter(|ij| ij.len() == 2)
                        .and_then(|ij| Some((ij[0].as_u64()?, ij[1].as_u64()?)))
                        .and_then(|(i, j)| {
                            let (i, j) = (usize::try_from(i).ok()?, usize::try_from(j).ok()?);
                            (j < count_v && i < count / count_v.max(1)).then_some(i * count_v + j)
                        })
                } else {
                    item.as_u64()
                        .and_then(|i| usize::try_from(i).ok())
                        .filter(|&i| i < count)
                };
                let what = if surface {
                    format!(
                        "an [i, j] pair of a control point (i < {}, j < {count_v})",
                        count / count_v.max(1)
                    )
                } else {
                    format!("a control point index below {count}")
                };
                list.push(
                    index
                        .ok_or_else(|| err(format!("dynamics.fixed[{k}]: {item} is not {what}")))?,
                );
            }
            Fixed::Points(list)
        }
        Some(other) => {
            let list = if surface { "[[i, j], …]" } else { "[i, …]" };
            return Err(err(format!(
                "dynamics.fixed: {other} is not \"{edge}\" or a list {list} of control points"
            )));
        }
    };
    let plastic_time_s = match (d.plastic, d.plastic_time_s) {
        (Some(true), t) => Some(t.map_or(DEFAULT_PLASTIC_TIME_S, |v| f64::from(v.0))),
        (_, Some(_)) => {
            return Err(err(
                "dynamics.plastic_time_s: given, but plastic is not true".to_owned(),
            ));
        }
        _ => None,
    };
    Ok(Params {
        density,
        damping,
        tension,
        bending,
        fixed,
        plastic_time_s,
    })
}

impl Material {
    fn from_raw(m: &RawMaterial) -> Result<Self, MaterialError> {
        let d = FrictionMaterial::default();
        let stribeck = match m.stribeck {
            None | Some(RawStribeck::Linear) => Stribeck::Linear,
            Some(RawStribeck::Smoothstep) => Stribeck::Smoothstep,
            Some(RawStribeck::Power(n)) if n.fract() == 0.0 && (1.0..=255.0).contains(&n) => {
                Stribeck::Power { exponent: n as u8 }
            }
            Some(RawStribeck::Power(value)) => return Err(MaterialError::Exponent { value }),
        };
        let model = match m.model {
            None | Some(RawModel::StickSlip) => ModelKind::StickSlip,
            Some(RawModel::CoulombViscous) => ModelKind::CoulombViscous,
            Some(RawModel::Karnopp) => ModelKind::Karnopp,
            Some(RawModel::Dahl) => ModelKind::Dahl,
            Some(RawModel::LuGre) => ModelKind::LuGre,
        };
        Material::from_friction(FrictionMaterial {
            stiffness_n_per_m: m.stiffness_n_per_m.0,
            damping_ns_per_m: m.damping_ns_per_m.0,
            mu_static: m.mu_static.0,
            mu_dynamic: m.mu_dynamic.0,
            stribeck,
            transition_time_s: m.transition_time_s.map_or(d.transition_time_s, |v| v.0),
            converge_tol_m: m.converge_tol_m.map_or(d.converge_tol_m, |v| v.0),
            stop_speed_m_per_s: m.stop_speed_m_per_s.map_or(d.stop_speed_m_per_s, |v| v.0),
            model,
            viscous_ns_per_m: m.viscous_ns_per_m.map_or(d.viscous_ns_per_m, |v| v.0),
            karnopp_band_m_per_s: m
                .karnopp_band_m_per_s
                .map_or(d.karnopp_band_m_per_s, |v| v.0),
            bristle_stiffness_n_per_m: m
                .bristle_stiffness_n_per_m
                .map_or(d.bristle_stiffness_n_per_m, |v| v.0),
            bristle_damping_ns_per_m: m
                .bristle_damping_ns_per_m
                .map_or(d.bristle_damping_ns_per_m, |v| v.0),
            stribeck_speed_m_per_s: m
                .stribeck_speed_m_per_s
                .map_or(d.stribeck_speed_m_per_s, |v| v.0),
        })
    }
}

impl Patch {
    fn from_raw(raw: &RawPatch) -> Result<Self, PatchError> {
        match &raw.degree {
            Nested::Num(_) => {
                let degree = integer(&raw.degree, Field::Degree.name())?;
                curve_from_raw(raw, degree)
            }
            Nested::List(pq) if pq.len() == 2 => {
                let p = integer(&pq[0], Field::DegreeU.name())?;
                let q = integer(&pq[1], Field::DegreeV.name())?;
                surface_from_raw(raw, (p, q))
            }
            Nested::List(pq) => Err(shape(
                "degree",
                format!(
                    "expected an integer (curve) or [p, q] (surface), found an array of {}",
                    pq.len()
                ),
            )),
        }
    }
}

fn curve_from_raw(raw: &RawPatch, degree: usize) -> Result<Patch, PatchError> {
    let knots = numbers(&raw.knots, "knots")?;
    let coords = list(&raw.points, "points", "an array of points")?
        .iter()
        .enumerate()
        .map(|(i, p)| numbers(p, &format!("points[{i}]")))
        .collect::<Result<Vec<_>, _>>()?;
    let weights = raw
        .weights
        .as_ref()
        .map(|w| numbers(w, "weights"))
        .transpose()?;
    // The first point fixes the dimension; an empty polygon is left to nurbs to reject.
    match coords.first().map_or(2, Vec::len) {
        2 => Ok(Patch::Curve2(curve_buf(degree, knots, &coords, weights)?)),
        3 => Ok(Patch::Curve3(curve_buf(degree, knots, &coords, weights)?)),
        found => Err(shape(
            "points[0]",
            format!("{found} coordinates, expected 2 (planar curve) or 3 (spatial curve)"),
        )),
    }
}

fn curve_buf<P: Point>(
    degree: usize,
    knots: Vec<f32>,
    coords: &[Vec<f32>],
    weights: Option<Vec<f32>>,
) -> Result<CurveBuf<P>, NurbsError> {
    let points = coords
        .iter()
        .enumerate()
        .map(|(i, c)| {
            P::from_coords(c).ok_or(NurbsError::Dimension {
                at: At::I(i),
                expected: P::DIM,
                found: c.len(),
            })
        })
        .collect::<Result<Vec<P>, _>>()?;
    CurveBuf::from_cartesian(degree, knots, &points, weights.as_deref())
}

fn surface_from_raw(raw: &RawPatch, degree: (usize, usize)) -> Result<Patch, PatchError> {
    let uv = list(&raw.knots, "knots", "[U, V], two arrays of knots")?;
    let [ku, kv] = uv else {
        return Err(shape(
            "knots",
            format!(
                "a surface needs two knot vectors [U, V], found {} entries",
                uv.len()
            ),
        ));
    };
    let knots = (numbers(ku, "knots[0]")?, numbers(kv, "knots[1]")?);
    let rows = list(&raw.points, "points", "an array of rows of points")?
        .iter()
        .enumerate()
        .map(|(i, row)| {
            list(row, &format!("points[{i}]"), "a row of points")?
                .iter()
                .enumerate()
                .map(|(j, p)| {
                    let c = numbers(p, &format!("points[{i}][{j}]"))?;
                    <Vec3 as Point>::from_coords(&c).ok_or_else(|| {
                        NurbsError::Dimension {
                            at: At::Ij(i, j),
                            expected: 3,
                            found: c.len(),
                        }
                        .into()
                    })
                })
                .collect::<Result<Vec<Vec3>, PatchError>>()
        })
        .collect::<Result<Vec<_>, _>>()?;
    let weights = match &raw.weights {
        None => None,
        Some(w) => Some(
            list(w, "weights", "an array of rows of weights")?
                .iter()
                .enumerate()
                .map(|(i, row)| numbers(row, &format!("weights[{i}]")))
                .collect::<Result<Vec<_>, _>>()?,
        ),
    };
    // nurbs reports this as a count of weights against control points; here they are rows.
    if let Some(w) = weights.as_ref().filter(|w| w.len() != rows.len()) {
        return Err(shape(
            "weights",
            format!(
                "{} rows of weights given for {} rows of points",
                w.len(),
                rows.len()
            ),
        ));
    }
    Ok(Patch::Surface(SurfaceBuf::from_rows(
        degree,
        knots,
        &rows,
        weights.as_deref(),
    )?))
}

fn shape(field: impl Into<String>, problem: impl Into<String>) -> PatchError {
    PatchError::Shape {
        field: field.into(),
        problem: problem.into(),
    }
}

fn integer(n: &Nested, field: &str) -> Result<usize, PatchError> {
    match *n {
        // `as` saturates; nurbs rejects a huge degree with its own message.
        Nested::Num(x) if x >= 0.0 && x.fract() == 0.0 => Ok(x as usize),
        Nested::Num(x) => Err(shape(field, format!("{x} is not a non-negative integer"))),
        Nested::List(_) => Err(shape(field, "expected an integer, found an array")),
    }
}

fn list<'a>(n: &'a Nested, field: &str, what: &str) -> Result<&'a [Nested], PatchError> {
    match n {
        Nested::List(items) => Ok(items),
        Nested::Num(_) => Err(shape(field, format!("expected {what}, found a number"))),
    }
}

fn numbers(n: &Nested, field: &str) -> Result<Vec<f32>, PatchError> {
    list(n, field, "an array of numbers")?
        .iter()
        .enumerate()
        .map(|(i, x)| match *x {
            // Rounded once to the f32 of the loop. A value that f32 cannot hold (it overflows
            // to ∞ or a non-zero value underflows to 0) is reported as written, not as the ∞
            // or 0 that nurbs would see.
            Nested::Num(v) => to_f32(v).map_err(|problem| shape(format!("{field}[{i}]"), problem)),
            Nested::List(_) => Err(shape(
                format!("{field}[{i}]"),
                "expected a number, found an array",
            )),
        })
        .collect()
}

/// `v` rounded once to the f32 of the loop, or why it cannot be: it overflows to ∞, or a
/// non-zero value underflows to 0 (the message gives the value as written, not the ∞ or 0
/// later checks would see).
fn to_f32(v: f64) -> Result<f32, String> {
    let r = v as f32;
    if r.is_finite() && (r != 0.0 || v == 0.0) {
        Ok(r)
    } else {
        Err(format!(
            "{v:.3e} is outside the range of f32 (magnitudes {:e} to {:e}), the type the \
             haptic loop computes in",
            f32::from_bits(1),
            f32::MAX
        ))
    }
}

/// A number of a JSON file read as the loop's `f32`: out of the range of `f32` (an overflow
/// to ∞, or a non-zero value that underflows to 0) is a JSON error, with the line, column and
/// field. Written as the shortest decimal that reads back as the same `f32`. The other file
/// formats of the workspace (`device/1`) read their numbers through it too.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct F32(pub f32);

impl serde::Serialize for F32 {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_f32(self.0)
    }
}

impl<'de> Deserialize<'de> for F32 {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = f64::deserialize(d)?;
        to_f32(v).map(F32).map_err(de::Error::custom)
    }
}

// ---------------------------------------------------------------------------------------------
// Raw types: the file as written. New fields go here (with `#[serde(default)]` when optional)
// and into the validation above.

#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "Scene")]
struct RawScene {
    #[allow(dead_code, reason = "checked before, in `Scene::from_json_str`")]
    format: String,
    objects: Vec<RawObject>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "Object")]
struct RawObject {
    name: String,
    material: RawMaterial,
    patches: Vec<RawPatch>,
    #[serde(default)]
    dynamics: Option<RawDynamics>,
}

/// Both kinds' fields: which apply follows from the patches, and a field of the other kind is
/// refused by name.
#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "Dynamics")]
struct RawDynamics {
    #[serde(default)]
    density_kg_per_m: Option<F32>,
    #[serde(default)]
    density_kg_per_m2: Option<F32>,
    #[serde(default)]
    damping_ns_per_m2: Option<F32>,
    #[serde(default)]
    damping_ns_per_m3: Option<F32>,
    #[serde(default)]
    tension_n: Option<F32>,
    #[serde(default)]
    tension_n_per_m: Option<F32>,
    #[serde(default)]
    bending_n_m2: Option<F32>,
    #[serde(default)]
    bending_n_m: Option<F32>,
    #[serde(default)]
    fixed: Option<Value>,
    #[serde(default)]
    plastic: Option<bool>,
    #[serde(default)]
    plastic_time_s: Option<F32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "Material")]
struct RawMaterial {
    stiffness_n_per_m: F32,
    damping_ns_per_m: F32,
    mu_static: F32,
    mu_dynamic: F32,
    #[serde(default)]
    stribeck: Option<RawStribeck>,
    #[serde(default)]
    transition_time_s: Option<F32>,
    #[serde(default)]
    converge_tol_m: Option<F32>,
    #[serde(default)]
    stop_speed_m_per_s: Option<F32>,
    #[serde(default)]
    model: Option<RawModel>,
    #[serde(default)]
    viscous_ns_per_m: Option<F32>,
    #[serde(default)]
    karnopp_band_m_per_s: Option<F32>,
    #[serde(default)]
    bristle_stiffness_n_per_m: Option<F32>,
    #[serde(default)]
    bristle_damping_ns_per_m: Option<F32>,
    #[serde(default)]
    stribeck_speed_m_per_s: Option<F32>,
}

/// `"linear"`, `{"power": n}` or `"smoothstep"`.
#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case", rename = "Stribeck")]
enum RawStribeck {
    Linear,
    Power(f64),
    Smoothstep,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "snake_case", rename = "Model")]
enum RawModel {
    StickSlip,
    CoulombViscous,
    Karnopp,
    Dahl,
    #[serde(rename = "lugre")]
    LuGre,
}

/// The arrays are read as nested numbers and shaped afterwards, because whether a patch is a
/// curve or a surface follows from `degree`, which may come after the other fields.
#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "Patch")]
struct RawPatch {
    degree: Nested,
    knots: Nested,
    points: Nested,
    #[serde(default)]
    weights: Option<Nested>,
}

/// A number or an array of (arrays of …) numbers.
enum Nested {
    Num(f64),
    List(Vec<Nested>),
}

impl<'de> Deserialize<'de> for Nested {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct NestedVisitor;
        impl<'de> Visitor<'de> for NestedVisitor {
            type Value = Nested;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a number or an array")
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Nested, E> {
                Ok(Nested::Num(v as f64))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Nested, E> {
                Ok(Nested::Num(v as f64))
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Nested, E> {
                Ok(Nested::Num(v))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Nested, A::Error> {
                let mut items = Vec::with_capacity(seq.size_hint().unwrap_or(0).min(1024));
                while let Some(item) = seq.next_element()? {
                    items.push(item);
                }
                Ok(Nested::List(items))
            }
        }
        d.deserialize_any(NestedVisitor)
    }
}

/// Why a JSON document did not parse into its type ([`parse_at`]).
#[derive(Debug)]
pub struct JsonError {
    /// The field path where it failed (`objects[0].name`); `None` after the document (trailing
    /// characters).
    pub path: Option<serde_path_to_error::Path>,
    /// serde_json's error; its message ends with the line and column.
    pub error: serde_json::Error,
}

/// Parses the whole of `text` as a `T`, keeping the path of the field an error is in: the
/// reader of `scene/1`, and of the workspace's other JSON formats (`experiment/1`,
/// `device/1`).
pub fn parse_at<T: DeserializeOwned>(text: &str) -> Result<T, JsonError> {
    let mut de = serde_json::Deserializer::from_str(text);
    let value = serde_path_to_error::deserialize(&mut de).map_err(|e| JsonError {
        path: Some(e.path().clone()),
        error: e.into_inner(),
    })?;
    de.end().map_err(|error| JsonError { path: None, error })?;
    Ok(value)
}

fn parse<T: DeserializeOwned>(text: &str) -> Result<T, SceneError> {
    parse_at(text).map_err(|e| SceneError::Json {
        location: e
            .path
            .map_or_else(String::new, |path| describe(&path, text)),
        error: e.error,
    })
}

/// `objects[0].patches[1].points[2]` → `object 0 ("wedge"), patch 1: points[2]`, in the words
/// of the validation errors.
fn describe(path: &serde_path_to_error::Path, text: &str) -> String {
    use serde_path_to_error::Segment;
    let segments: Vec<&Segment> = path.iter().collect();
    let mut head = Vec::new();
    let mut rest = segments.as_slice();
    if let Some((index, tail)) = keyed_index(rest, "objects") {
        head.push(match object_name(text, index) {
            Some(name) => format!("object {index} ({name:?})"),
            None => format!("object {index}"),
        });
        rest = tail;
        if let Some((index, tail)) = keyed_index(rest, "patches") {
            head.push(format!("patch {index}"));
            rest = tail;
        }
    }
    let mut field = String::new();
    for s in rest {
        match s {
            Segment::Map { key } | Segment::Enum { variant: key } => {
                if !field.is_empty() {
                    field.push('.');
                }
                field.push_str(key);
            }
            Segment::Seq { index } => {
                let _ = write!(field, "[{index}]");
            }
            Segment::Unknown => field.push('?'),
        }
    }
    // Same punctuation as the validation errors: `object 0 ("a"), material.x` and
    // `object 0 ("a"), patch 1: knots`.
    let separator = if head.len() == 1 { ", " } else { ": " };
    let mut out = head.join(", ");
    if !field.is_empty() {
        if !out.is_empty() {
            out.push_str(separator);
        }
        out.push_str(&field);
    }
    out
}

/// `(index, rest)` when `path` starts with the field `name` and an index into it.
fn keyed_index<'a>(
    path: &'a [&'a serde_path_to_error::Segment],
    name: &str,
) -> Option<(usize, &'a [&'a serde_path_to_error::Segment])> {
    use serde_path_to_error::Segment;
    match path {
        [Segment::Map { key }, Segment::Seq { index }, tail @ ..] if key == name => {
            Some((*index, tail))
        }
        _ => None,
    }
}

/// The name of object `index`, if the document is valid JSON and has one.
fn object_name(text: &str, index: usize) -> Option<String> {
    let v: serde_json::Value = serde_json::from_str(text).ok()?;
    v.get("objects")?
        .get(index)?
        .get("name")?
        .as_str()
        .map(str::to_owned)
}

// ---------------------------------------------------------------------------------------------
// Writing.

/// An `f32` as the JSON number of its shortest decimal (which reads back as the same `f32`).
fn num(x: f32) -> Value {
    // A finite f32's shortest decimal always parses as an f64; a scene holds finite values
    // only (validated), and a non-finite one would become `null`, which the reader refuses.
    format!("{x}")
        .parse::<f64>()
        .ok()
        .and_then(serde_json::Number::from_f64)
        .map_or(Value::Null, Value::Number)
}

fn nums(xs: &[f32]) -> Value {
    Value::Array(xs.iter().copied().map(num).collect())
}

fn material(m: &Material) -> Value {
    let f: FrictionMaterial = m.friction_material();
    let mut out = Map::new();
    for (k, v) in [
        ("stiffness_n_per_m", f.stiffness_n_per_m),
        ("damping_ns_per_m", f.damping_ns_per_m),
        ("mu_static", f.mu_static),
        ("mu_dynamic", f.mu_dynamic),
        ("transition_time_s", f.transition_time_s),
        ("converge_tol_m", f.converge_tol_m),
        ("stop_speed_m_per_s", f.stop_speed_m_per_s),
        ("viscous_ns_per_m", f.viscous_ns_per_m),
        ("karnopp_band_m_per_s", f.karnopp_band_m_per_s),
        ("bristle_stiffness_n_per_m", f.bristle_stiffness_n_per_m),
        ("bristle_damping_ns_per_m", f.bristle_damping_ns_per_m),
        ("stribeck_speed_m_per_s", f.stribeck_speed_m_per_s),
    ] {
        out.insert(k.into(), num(v));
    }
    out.insert(
        "stribeck".into(),
        match f.stribeck {
            Stribeck::Linear => json!("linear"),
            Stribeck::Power { exponent } => json!({ "power": exponent }),
            Stribeck::Smoothstep => json!("smoothstep"),
        },
    );
    out.insert(
        "model".into(),
        json!(match f.model {
            ModelKind::StickSlip => "stick_slip",
            ModelKind::CoulombViscous => "coulomb_viscous",
            ModelKind::Karnopp => "karnopp",
            ModelKind::Dahl => "dahl",
            ModelKind::LuGre => "lugre",
        }),
    );
    Value::Object(out)
}

/// Cartesian coordinates and weight of a homogeneous point with `n` coordinates.
fn cartesian(h: Vec4, n: usize) -> (Value, Value) {
    let c = [h.x / h.w, h.y / h.w, h.z / h.w];
    (nums(&c[..n]), num(h.w))
}

fn patch(p: &Patch) -> Value {
    match p {
        Patch::Curve2(c) => {
            let (points, weights): (Vec<_>, Vec<_>) = c
                .points()
                .iter()
                .map(|h| cartesian(Vec4::new(h.x, h.y, 0.0, h.z), 2))
                .unzip();
            json!({ "degree": c.degree(), "knots": nums(c.knots()), "points": points, "weights": weights })
        }
        Patch::Curve3(c) => {
            let (points, weights): (Vec<_>, Vec<_>) =
                c.points().iter().map(|h| cartesian(*h, 3)).unzip();
            json!({ "degree": c.degree(), "knots": nums(c.knots()), "points": points, "weights": weights })
        }
        Patch::Surface(s) => {
            let (nu, nv) = s.counts();
            let (ku, kv) = s.knots();
            let (p, q) = s.degree();
            let row = |i: usize| -> (Value, Value) {
                let (pts, ws): (Vec<_>, Vec<_>) = (0..nv)
                    .map(|j| cartesian(s.points()[i * nv + j], 3))
                    .unzip();
                (Value::Array(pts), Value::Array(ws))
            };
            let (points, weights): (Vec<_>, Vec<_>) = (0..nu).map(row).unzip();
            json!({ "degree": [p, q], "knots": [nums(ku), nums(kv)], "points": points, "weights": weights })
        }
    }
}

fn object(o: &Object) -> Value {
    let mut out = json!({
        "name": o.name(),
        "material": material(o.material()),
        "patches": o.patches().iter().map(patch).collect::<Vec<_>>(),
    });
    if let (Some(d), Value::Object(map)) = (o.dynamics(), &mut out) {
        map.insert("dynamics".to_owned(), dynamics(d, o.patches()));
    }
    out
}

fn dynamics(d: &Params, patches: &[Patch]) -> Value {
    let count_v = match patches.first() {
        Some(Patch::Surface(s)) => Some(s.counts().1),
        _ => None,
    };
    let surface = count_v.is_some();
    let mut out = Map::new();
    for (q, v) in [
        (Quantity::Density, d.density),
        (Quantity::Damping, d.damping),
        (Quantity::Tension, d.tension),
        (Quantity::Bending, d.bending),
    ] {
        out.insert(q.field(surface).to_owned(), num(v as f32));
    }
    let fixed = match (&d.fixed, count_v) {
        (Fixed::Edge, None) => json!("ends"),
        (Fixed::Edge, Some(_)) => json!("boundary"),
        (Fixed::Points(list), None) => json!(list),
        (Fixed::Points(list), Some(nv)) => {
            json!(list.iter().map(|k| [k / nv, k % nv]).collect::<Vec<_>>())
        }
    };
    out.insert("fixed".to_owned(), fixed);
    out.insert("plastic".to_owned(), json!(d.plastic_time_s.is_some()));
    if let Some(t) = d.plastic_time_s {
        out.insert("plastic_time_s".to_owned(), num(t as f32));
    }
    Value::Object(out)
}

impl Scene {
    /// The scene as a `scene/1` document (pretty-printed JSON).
    pub fn to_json_string(&self) -> String {
        let doc = json!({
            "format": FORMAT,
            "objects": self.objects().iter().map(object).collect::<Vec<_>>(),
        });
        // Serialising a Value built from strings and numbers cannot fail.
        serde_json::to_string_pretty(&doc).unwrap_or_default()
    }

    /// The scene with object `index`'s material replaced by `material`.
    pub fn with_material(&self, index: usize, material: Material) -> Result<Scene, SceneError> {
        let objects = self
            .objects()
            .iter()
            .enumerate()
            .map(|(i, o)| {
                if i == index {
                    Object::new(o.name().to_owned(), material, o.patches().to_vec())
                        .and_then(|x| x.with_dynamics(o.dynamics().cloned()))
                        .map_err(|error| SceneError::Object {
                            index: i,
                            name: o.name().to_owned(),
                            error,
                        })
                } else {
                    Ok(o.clone())
                }
            })
            .collect::<Result<Vec<_>, _>>()?;
        Scene::new(objects)
    }
}
