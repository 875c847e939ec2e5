//! Writing a [`Scene`] back as a `scene/1` document (the app's Save), the inverse of
//! [`Scene::from_json_str`]. Numbers are written as the shortest decimals that read back as
//! the same `f32`; points are Cartesian (the homogeneous coordinates divided by the weight),
//! so a curve with unit weights reads back bit for bit, and a rational one to within an ulp
//! of each coordinate (the reader multiplies by the weight again).

use friction::{FrictionMaterial, ModelKind, Stribeck};
use nurbs::Vec4;
use serde_json::{Map, Value, json};

use crate::scene::{FORMAT, Material, Object, Patch, Scene, SceneError};

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
    json!({
        "name": o.name(),
        "material": material(o.material()),
        "patches": o.patches().iter().map(patch).collect::<Vec<_>>(),
    })
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
                    Object::new(o.name().to_owned(), material, o.patches().to_vec()).map_err(
                        |error| SceneError::Object {
                            index: i,
                            name: o.name().to_owned(),
                            error,
                        },
                    )
                } else {
                    Ok(o.clone())
                }
            })
            .collect::<Result<Vec<_>, _>>()?;
        Scene::new(objects)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every bundled scene reads back from what it writes: the same objects, names,
    /// materials, degrees and knots exactly; the control points exactly where the weights
    /// are 1, and within the reader's own rounding elsewhere (x·w/w: one ulp of the
    /// coordinate, relative 2⁻²³, and a second for the reader's multiply).
    #[test]
    fn every_bundled_scene_round_trips() {
        for text in [
            include_str!("../../../scenes/thesis-2d.json"),
            include_str!("../../../scenes/thesis-3d.json"),
            include_str!("../../../scenes/examples.json"),
        ] {
            let scene = Scene::from_json_str(text).unwrap_or_else(|e| panic!("{e}"));
            let back = Scene::from_json_str(&scene.to_json_string())
                .unwrap_or_else(|e| panic!("{e}\n{}", scene.to_json_string()));
            assert_eq!(back.objects().len(), scene.objects().len());
            for (a, b) in scene.objects().iter().zip(back.objects()) {
                assert_eq!(a.name(), b.name());
                assert_eq!(a.material(), b.material());
                assert_eq!(a.patches().len(), b.patches().len());
                for (p, q) in a.patches().iter().zip(b.patches()) {
                    let close = |x: f32, y: f32, w: f32| {
                        if w == 1.0 {
                            x == y
                        } else {
                            (x - y).abs() <= 2.0 * f32::EPSILON * x.abs().max(f32::MIN_POSITIVE)
                        }
                    };
                    match (p, q) {
                        (Patch::Curve2(c), Patch::Curve2(d)) => {
                            assert_eq!(c.degree(), d.degree());
                            assert_eq!(c.knots(), d.knots());
                            for (h, k) in c.points().iter().zip(d.points()) {
                                assert_eq!(h.z, k.z, "weight");
                                assert!(close(h.x, k.x, h.z) && close(h.y, k.y, h.z), "{h} {k}");
                            }
                        }
                        (Patch::Surface(s), Patch::Surface(t)) => {
                            assert_eq!(s.degree(), t.degree());
                            assert_eq!(s.knots(), t.knots());
                            for (h, k) in s.points().iter().zip(t.points()) {
                                assert_eq!(h.w, k.w, "weight");
                                assert!(
                                    close(h.x, k.x, h.w)
                                        && close(h.y, k.y, h.w)
                                        && close(h.z, k.z, h.w),
                                    "{h} {k}"
                                );
                            }
                        }
                        (Patch::Curve3(c), Patch::Curve3(d)) => {
                            assert_eq!(c.knots(), d.knots());
                            assert_eq!(c.points().len(), d.points().len());
                        }
                        _ => panic!("patch kind changed"),
                    }
                }
            }
        }
    }

    /// A new material is validated as the reader would (the object's own check) and
    /// replaces only that object's.
    #[test]
    fn with_material_replaces_one_objects_material() {
        let scene = Scene::from_json_str(include_str!("../../../scenes/examples.json"))
            .unwrap_or_else(|e| panic!("{e}"));
        let m = Material::new(500.0, 1.0, 0.4, 0.3).expect("valid");
        let changed = scene.with_material(0, m).expect("valid");
        assert_eq!(changed.objects()[0].material(), &m);
        assert_eq!(changed.objects()[1..], scene.objects()[1..]);
        assert!(scene.with_material(99, m).is_ok_and(|s| s == scene));
    }
}
