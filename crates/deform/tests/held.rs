//! What holds a deformable object: a body whose stiffness leaves a motion free (a rigid one,
//! or for bending alone a rotation) is refused when it is built, by name, since a load would
//! send it away (issue: a string with `"fixed": []` under 1e-9 N/m sagged 1,759 m). The
//! supports that hold are counted from the motions that cost no energy (textbook statics):
//! tension resists only the displacement's gradient, so a translation is free and one fixed
//! point holds a string or a membrane; bending resists only curvature, so every linear field
//! is free and two points hold a beam, three not on one line a plate.

use deform::{Body, DynamicsError, Fixed, Params, Shape};
use nurbs::{CurveBuf, SurfaceBuf, Vec2, Vec3};

mod common;
use common::{L, greville, uniform_knots};

fn params(tension: f64, bending: f64, fixed: Fixed) -> Params {
    Params {
        density: 0.1,
        damping: 0.0,
        tension,
        bending,
        fixed,
        plastic_time_s: None,
    }
}

/// A straight cubic of 12 control points from (0, 0) to (L, 0), linearly parametrised.
fn string(params: Params) -> Result<Body, DynamicsError> {
    let knots = uniform_knots(3, 12);
    let points: Vec<Vec2> = greville(&knots, 3, 12)
        .iter()
        .map(|&g| Vec2::new((L * g) as f32, 0.0))
        .collect();
    let c = CurveBuf::from_cartesian(3, knots, &points, None).expect("valid curve");
    let (shape, rest) = Shape::of_curve2(&c);
    Body::new(shape, rest, params)
}

/// The flat square [0, L]² as a bicubic of 6 × 6 control points (index `i · 6 + j`).
fn sheet(params: Params) -> Result<Body, DynamicsError> {
    let knots = uniform_knots(3, 6);
    let g = greville(&knots, 3, 6);
    let rows: Vec<Vec<Vec3>> = g
        .iter()
        .map(|&gu| {
            g.iter()
                .map(|&gv| Vec3::new((L * gu) as f32, (L * gv) as f32, 0.0))
                .collect()
        })
        .collect();
    let s = SurfaceBuf::from_rows::<_, Vec<f32>>((3, 3), (knots.clone(), knots), &rows, None)
        .expect("valid surface");
    let (shape, rest) = Shape::of_surface(&s);
    Body::new(shape, rest, params)
}

fn points(p: &[usize]) -> Fixed {
    Fixed::Points(p.to_vec())
}

#[test]
fn an_object_left_free_to_move_is_refused_by_name() {
    let free = [
        (
            "string, nothing fixed",
            string(params(5.0, 0.0, points(&[]))),
        ),
        (
            "membrane, nothing fixed",
            sheet(params(50.0, 0.0, points(&[]))),
        ),
        // Bending alone: a rotation about the one fixed end costs nothing.
        ("beam, one end", string(params(0.0, 1e-3, points(&[0])))),
        (
            "beam, nothing fixed",
            string(params(0.0, 1e-3, points(&[]))),
        ),
        // A plate turns about the line through collinear supports (the first row, i = 0).
        (
            "plate, three points on one line",
            sheet(params(0.0, 1e-2, points(&[0, 2, 5]))),
        ),
        (
            "plate, two corners",
            sheet(params(0.0, 1e-2, points(&[0, 35]))),
        ),
    ];
    let accepted: Vec<&str> = free
        .iter()
        .filter(|(_, built)| built.is_ok())
        .map(|(what, _)| *what)
        .collect();
    assert!(
        accepted.is_empty(),
        "accepted though free to move: {accepted:?}"
    );
    for (what, built) in free {
        let Err(e) = built else { continue };
        assert_eq!(e, DynamicsError::NotHeld, "{what}");
        let message = e.to_string();
        assert!(message.starts_with("fixed: "), "{what}: {message}");
        assert!(message.contains("not held"), "{what}: {message}");
    }
}

#[test]
fn the_fewest_supports_that_hold_are_accepted() {
    let held = [
        ("string, one end", string(params(5.0, 0.0, points(&[0])))),
        (
            "membrane, one corner",
            sheet(params(50.0, 0.0, points(&[0]))),
        ),
        (
            "beam, two points",
            string(params(0.0, 1e-3, points(&[0, 11]))),
        ),
        (
            "plate, three corners",
            sheet(params(0.0, 1e-2, points(&[0, 5, 30]))),
        ),
        ("string, both ends", string(params(5.0, 0.0, Fixed::Edge))),
    ];
    for (what, built) in held {
        if let Err(e) = built {
            panic!("{what}: {e}");
        }
    }
}

/// A string of tension `T` held at `x = 0` only, under a transverse load `q` per length, is
/// the cantilevered string: `T w'' = −q`, `w(0) = 0`, `T w'(L) = 0` (a free end carries no
/// transverse force), so `w(x) = (q/T)(L x − x²/2)`, `q L²/(2T)` at the tip. The cubic space
/// holds this parabola, so the static solve is exact up to rounding (1e-5 of the tip, as for
/// the string held at both ends in `tests/physics.rs`).
#[test]
fn a_string_held_at_one_end_sags_as_the_closed_form() {
    let (t, q) = (5.0, -2.0);
    let mut body = string(params(t, 0.0, points(&[0]))).expect("held at one end");
    let mut load = body.zero_load();
    body.add_uniform_load(&mut load, [0.0, q, 0.0]);
    body.solve_static(&load).expect("held");
    let tip = q * L * L / (2.0 * t);
    for i in 0..=10 {
        let u = i as f64 / 10.0;
        let x = L * u;
        let w = q / t * (L * x - x * x / 2.0);
        let p = body.point([u, 0.0]);
        assert!(
            (p[1] - w).abs() <= 1e-5 * tip.abs(),
            "u = {u}: {} vs {w}",
            p[1]
        );
    }
}
