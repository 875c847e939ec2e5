//! The `closest` command: the closest point of one object to query points read line by line,
//! by the global search (`tracker::closest_point` on every patch, the nearest kept).
//!
//! Input: one point per line, `x y` for a planar object, `x y z` for an object of surfaces or
//! of spatial curves (a wire) (metres); blank lines and lines starting with `#` are skipped. Output, one JSON object per
//! point, flushed at once:
//! `{"patch", "u", ["v",] "point", "distance", "signed_distance", "normal"}`, the signed
//! distance negative inside the object. A wire has no inside: its signed distance is the
//! distance, and its normal the unit vector from the closest point to the query.

use std::io::{BufRead, Write};

use nurbs::{Point, Vec2, Vec3};
use serde::Serialize;
use tracker::{BezierSplit, GlobalConfig, closest_point};

use crate::eval::{Answer, EvalError, Finite, answer_lines, parse_query, write_answer};
use scene::Object;

/// One answer.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClosestPoint {
    /// Index of the patch the closest point lies on.
    pub patch: usize,
    /// Its first parameter.
    pub u: f32,
    /// Its second parameter (surfaces only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub v: Option<f32>,
    /// The closest point.
    pub point: Vec<f32>,
    /// Distance from the query to it (m).
    pub distance: f32,
    /// The distance, negative when the query is inside the object.
    pub signed_distance: f32,
    /// Unit outward normal of the patch there.
    pub normal: Vec<f32>,
}

impl Finite for ClosestPoint {
    fn fields(&self) -> Vec<(&'static str, &[f32])> {
        vec![
            ("u", core::slice::from_ref(&self.u)),
            ("v", self.v.as_slice()),
            ("point", &self.point),
            ("distance", core::slice::from_ref(&self.distance)),
            (
                "signed_distance",
                core::slice::from_ref(&self.signed_distance),
            ),
            ("normal", &self.normal),
        ]
    }
}

/// The nearest of the patches' global closest points to `x`.
fn nearest<S: BezierSplit<N>, const N: usize>(patches: &[S], x: S::P) -> Option<ClosestPoint> {
    let cfg = GlobalConfig::default();
    let mut best: Option<(usize, tracker::Closest<S::P, N>)> = None;
    for (i, p) in patches.iter().enumerate() {
        let c = closest_point(p, x, &cfg);
        if best
            .as_ref()
            .is_none_or(|(_, b)| c.distance_squared < b.distance_squared)
        {
            best = Some((i, c));
        }
    }
    best.map(|(patch, c)| {
        let distance = c.distance_squared.sqrt();
        // The side comes from the patch's outward normal at the closest point: exact in a
        // patch's interior, and right at convex and reflex edges and vertices too, where the
        // query lies in the wedge between the adjacent patches' normals.
        let signed_distance = if c.signed_distance < 0.0 {
            -distance
        } else {
            distance
        };
        ClosestPoint {
            patch,
            u: c.t[0],
            v: (N == 2).then(|| c.t[N - 1]),
            point: c.point.as_slice().to_vec(),
            distance,
            signed_distance,
            normal: c.normal.as_slice().to_vec(),
        }
    })
}

/// The signed distance (m, negative inside) from `p` to a planar object, by the same global
/// search as [`run`]; `None` for an object that is not of planar curves (or has none).
pub fn signed_distance_2d(object: &Object, p: Vec2) -> Option<f32> {
    nearest(&object.curve_views()?, p).map(|c| c.signed_distance)
}

/// Answers every query point in `input` for `object`, one JSON line each on `output`.
/// Returns the number answered; stops at the first bad line.
pub fn run<R: BufRead, W: Write>(
    object: &Object,
    input: R,
    mut output: W,
) -> Result<usize, EvalError> {
    // Queries are held to the coordinate range of scenes: beyond it squared distances and the
    // search's products leave f32 (`1e30 1e30` used to print `"distance": null`).
    let all = (-nurbs::MAX_COORDINATE, nurbs::MAX_COORDINATE);
    if let Some(curves) = object.curve_views() {
        answer_lines(input, |text| {
            let [x, y] = parse_query(text, ["x", "y"], "x y", [all; 2])?;
            let c = nearest(&curves, Vec2::new(x, y)).ok_or(Answer::Output(
                EvalError::Unsupported("the object has no patches"),
            ))?;
            write_answer(&mut output, &c)
        })
    } else if let Some(surfaces) = object.surface_views() {
        answer_lines(input, |text| {
            let [x, y, z] = parse_query(text, ["x", "y", "z"], "x y z", [all; 3])?;
            let c = nearest(&surfaces, Vec3::new(x, y, z)).ok_or(Answer::Output(
                EvalError::Unsupported("the object has no patches"),
            ))?;
            write_answer(&mut output, &c)
        })
    } else if let Some(wires) = object.wire_views() {
        answer_lines(input, |text| {
            let [x, y, z] = parse_query(text, ["x", "y", "z"], "x y z", [all; 3])?;
            let q = Vec3::new(x, y, z);
            let mut c = nearest(&wires, q).ok_or(Answer::Output(EvalError::Unsupported(
                "the object has no patches",
            )))?;
            // A wire has no inside: the distance is unsigned and the normal is the direction
            // from the closest point to the query (the gradient of the distance), which is
            // orthogonal to the wire wherever the closest point is not an end.
            c.signed_distance = c.distance;
            let to_query = q - Vec3::from_slice(&c.point);
            if let Some(n) = to_query.try_normalize() {
                c.normal = n.to_array().to_vec();
            }
            write_answer(&mut output, &c)
        })
    } else {
        Err(EvalError::Unsupported(
            "the object mixes patch kinds; closest needs one kind",
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use scene::{Patch, Scene};

    /// A 30 mm circle around (0, 0.09), as in `scenes/examples.json`, and a unit sphere.
    const SCENE: &str = r#"{"format": "scene/1", "objects": [
      {"name": "circle", "material": {"stiffness_n_per_m": 1000, "damping_ns_per_m": 0, "mu_static": 0.5, "mu_dynamic": 0.4},
       "patches": [{"degree": 2, "knots": [0,0,0,0.25,0.25,0.5,0.5,0.75,0.75,1,1,1],
         "points": [[0.03,0.09],[0.03,0.12],[0,0.12],[-0.03,0.12],[-0.03,0.09],[-0.03,0.06],[0,0.06],[0.03,0.06],[0.03,0.09]],
         "weights": [1,0.70710678,1,0.70710678,1,0.70710678,1,0.70710678,1]}]},
      {"name": "bilinear", "material": {"stiffness_n_per_m": 1000, "damping_ns_per_m": 0, "mu_static": 0.5, "mu_dynamic": 0.4},
       "patches": [{"degree": [1, 1], "knots": [[0,0,1,1],[0,0,1,1]],
         "points": [[[0,0,0],[0,1,0]],[[1,0,0],[1,1,0]]]}]}
    ]}"#;

    fn answers(object: usize, input: &str) -> (Result<usize, EvalError>, Vec<serde_json::Value>) {
        let scene = Scene::from_json_str(SCENE).expect("valid scene");
        let mut out = Vec::new();
        let r = run(&scene.objects()[object], input.as_bytes(), &mut out);
        let lines = String::from_utf8(out)
            .expect("UTF-8")
            .lines()
            .map(|l| serde_json::from_str(l).expect("JSON"))
            .collect();
        (r, lines)
    }

    fn num(v: &serde_json::Value) -> f32 {
        v.as_f64().expect("number") as f32
    }

    /// Closed form: the closest point of a circle to x is c + r (x − c)/|x − c|, at distance
    /// |x − c| − r (negative inside).
    #[test]
    fn circle_matches_closed_form_inside_and_out() {
        let (r, lines) = answers(0, "0.05 0.10\n0.01 0.085\n# comment\n\n-0.02 0.13\n");
        assert_eq!(r.expect("ok"), 3);
        let c = Vec2::new(0.0, 0.09);
        for (line, q) in lines.iter().zip([
            Vec2::new(0.05, 0.10),
            Vec2::new(0.01, 0.085),
            Vec2::new(-0.02, 0.13),
        ]) {
            let exact = c + (q - c).normalize() * 0.03;
            let p = Vec2::new(num(&line["point"][0]), num(&line["point"][1]));
            assert!((p - exact).length() < 1e-6, "{p:?} vs {exact:?}");
            let d = (q - c).length() - 0.03;
            assert!((num(&line["signed_distance"]) - d).abs() < 1e-6);
            assert!((num(&line["distance"]) - d.abs()).abs() < 1e-6);
            let n = Vec2::new(num(&line["normal"][0]), num(&line["normal"][1]));
            assert!((n - (q - c).normalize()).length() < 1e-4);
            assert!(line.get("v").is_none());
        }
    }

    /// The bilinear patch is the unit square in z = 0 with normal +z: the closest point is the
    /// clamped projection.
    #[test]
    fn square_patch_projects_and_clamps() {
        let (r, lines) = answers(1, "0.25 0.5 2\n1.5 0.5 -1\n");
        assert_eq!(r.expect("ok"), 2);
        assert!(
            (num(&lines[0]["u"]) - 0.25).abs() < 1e-6 && (num(&lines[0]["v"]) - 0.5).abs() < 1e-6
        );
        assert!((num(&lines[0]["signed_distance"]) - 2.0).abs() < 1e-6);
        assert!((num(&lines[1]["u"]) - 1.0).abs() < 1e-6);
        let d = (0.25f32 + 1.0).sqrt();
        assert!((num(&lines[1]["distance"]) - d).abs() < 1e-5);
        assert!(
            num(&lines[1]["signed_distance"]) < 0.0,
            "below the patch: behind its normal"
        );
    }

    /// A wire of two patches: a full circle of radius r = 0.03 around c = (0, 0.09, 0.01) in
    /// a plane tilted about the x axis (axes e1 = x, e2 = (0, cos a, sin a)), and a straight
    /// segment along z off to the side. Exact closest points: for the circle, project the
    /// query onto the plane and go radially to the circle, distance √(h² + (ρ − r)²) with
    /// h the height above the plane and ρ the in-plane distance from c; for the segment,
    /// the clamped projection.
    #[test]
    fn wire_matches_exact_constructions() {
        use nurbs::construct::{arc, line};
        let (c, r, a) = (Vec3::new(0.0, 0.09, 0.01), 0.03f32, 0.4f32);
        let (e1, e2) = (Vec3::X, Vec3::new(0.0, a.cos(), a.sin()));
        let n = e1.cross(e2);
        let circle = arc(c, e1 * r, e2 * r, 0.0, std::f32::consts::TAU).expect("circle");
        let (s0, s1) = (Vec3::new(0.1, 0.0, -0.02), Vec3::new(0.1, 0.0, 0.02));
        let segment = line(s0, s1).expect("segment");
        let material = scene::Material::new(1000.0, 0.0, 0.5, 0.4).expect("material");
        let wire = Object::new(
            "wire",
            material,
            vec![Patch::Curve3(circle), Patch::Curve3(segment)],
        )
        .expect("a wire is a valid object");
        let queries = [
            Vec3::new(0.05, 0.1, 0.03),
            Vec3::new(-0.01, 0.06, -0.02),
            Vec3::new(0.0, 0.12, 0.02),
            Vec3::new(0.11, 0.005, 0.0),
            Vec3::new(0.1, 0.0, 0.05),
        ];
        let input: String = queries
            .iter()
            .map(|q| format!("{} {} {}\n", q.x, q.y, q.z))
            .collect();
        let mut out = Vec::new();
        assert_eq!(run(&wire, input.as_bytes(), &mut out).expect("answered"), 5);
        let lines: Vec<serde_json::Value> = String::from_utf8(out)
            .expect("UTF-8")
            .lines()
            .map(|l| serde_json::from_str(l).expect("JSON"))
            .collect();
        for (line, q) in lines.iter().zip(queries) {
            // Exact candidates on each patch, in f64 from the construction.
            let d = (q - c).as_dvec3();
            let n64 = n.as_dvec3();
            let h = d.dot(n64);
            let inplane = d - n64 * h;
            let rho = inplane.length();
            let on_circle = c.as_dvec3() + inplane * (f64::from(r) / rho);
            let dist_circle = (h * h + (rho - f64::from(r)).powi(2)).sqrt();
            let seg = (s1 - s0).as_dvec3();
            let t = ((q - s0).as_dvec3().dot(seg) / seg.length_squared()).clamp(0.0, 1.0);
            let on_segment = s0.as_dvec3() + seg * t;
            let dist_segment = (q.as_dvec3() - on_segment).length();
            let (patch, exact, dist) = if dist_circle < dist_segment {
                (0, on_circle, dist_circle)
            } else {
                (1, on_segment, dist_segment)
            };
            let p = glam::DVec3::new(
                line["point"][0].as_f64().expect("x"),
                line["point"][1].as_f64().expect("y"),
                line["point"][2].as_f64().expect("z"),
            );
            assert_eq!(line["patch"], patch, "{q:?}");
            // f32 evaluation of coordinates of order 0.1 m, and the global search's
            // tolerance (GlobalConfig default, well below a micrometre): 1e-6 m.
            assert!((p - exact).length() < 1e-6, "{q:?}: {p:?} vs {exact:?}");
            let got = line["distance"].as_f64().expect("distance");
            assert!((got - dist).abs() < 1e-6, "{q:?}: {got} vs {dist}");
            assert_eq!(line["signed_distance"], line["distance"], "no inside");
            // The normal points from the closest point to the query.
            let nrm = glam::DVec3::new(
                line["normal"][0].as_f64().expect("nx"),
                line["normal"][1].as_f64().expect("ny"),
                line["normal"][2].as_f64().expect("nz"),
            );
            let to_q = (q.as_dvec3() - exact).normalize();
            assert!((nrm - to_q).length() < 1e-4, "{q:?}: {nrm:?} vs {to_q:?}");
            assert!(line.get("v").is_none());
        }
    }

    #[test]
    fn queries_beyond_the_coordinate_range_are_refused() {
        let (r, lines) = answers(0, "0.05 0.1\n1e30 1e30\n");
        assert_eq!(lines.len(), 1);
        let e = r.expect_err("1e30 is out of range").to_string();
        assert!(
            e.starts_with("line 2 (\"1e30 1e30\"): x = 1000000000000000000000000000000 is outside"),
            "{e}"
        );
        let (r, lines) = answers(1, "1e6 -1e6 1e6\n");
        assert_eq!((r.expect("at the bound"), lines.len()), (1, 1));
    }

    #[test]
    fn bad_lines_name_the_line() {
        let (r, lines) = answers(0, "0.05 0.10\n0.05\n");
        assert_eq!(lines.len(), 1);
        let e = r.expect_err("second line is bad").to_string();
        assert!(e.contains("line 2") && e.contains("x y"), "{e}");
        let (r, _) = answers(1, "1 2 nan\n");
        assert!(r.expect_err("NaN").to_string().contains("z"));
        let (r, _) = answers(0, "1 abc\n");
        assert!(r.expect_err("not a number").to_string().contains("\"abc\""));
    }
}
