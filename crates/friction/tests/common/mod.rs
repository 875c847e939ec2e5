//! What the passivity and feature tests share: a run of the renderer over a prescribed HIP
//! path at 1 kHz with its trapezoid work, and the path's segments.
#![allow(dead_code)]

use friction::{FrictionMaterial, FrictionOutput, FrictionRenderer, Mode};
use nurbs::Point;
use tracker::Object;

/// The tick period of every run (s).
pub const T: f32 = 1e-3;

/// The default material with its coefficients set.
pub fn with_mu(mu_static: f32, mu_dynamic: f32) -> FrictionMaterial {
    FrictionMaterial {
        mu_static,
        mu_dynamic,
        ..FrictionMaterial::default()
    }
}

/// What a run of the renderer over `path` did: the outputs, the trapezoid work of the total
/// force on the HIP (J, summed in f64), the GO's travel (m) and the largest force step (N).
pub struct Run<P> {
    pub out: Vec<FrictionOutput<P>>,
    pub work_j: f64,
    pub go_travel_m: f64,
    pub max_jump_n: f64,
}

pub fn run<O: Object>(object: &O, material: FrictionMaterial, path: &[O::P]) -> Run<O::P>
where
    O::P: Point,
{
    let mut r = FrictionRenderer::new(object, material, path[0]);
    let mut out: Vec<FrictionOutput<O::P>> = Vec::with_capacity(path.len());
    let mut work = 0.0f64;
    let mut travel = 0.0f64;
    let mut jump = 0.0f64;
    for (k, &x) in path.iter().enumerate() {
        let prev_x = if k > 0 { path[k - 1] } else { x };
        let o = r.tick(object, x, (x - prev_x) * (1.0 / T), T);
        if let Some(p) = out.last() {
            work += f64::from((p.total + o.total).dot(x - prev_x)) * 0.5;
            if p.mode != Mode::Free && o.mode != Mode::Free {
                travel += f64::from((o.go - p.go).length_squared()).sqrt();
            }
            jump = jump.max(f64::from((o.total - p.total).length_squared()).sqrt());
        }
        out.push(o);
    }
    Run {
        out,
        work_j: work,
        go_travel_m: travel,
        max_jump_n: jump,
    }
}

/// `a → b` in steps of at most `h`, without `a`.
pub fn segment<P: Point>(a: P, b: P, h: f32) -> impl Iterator<Item = P> {
    let n = ((b - a).length_squared().sqrt() / h).ceil().max(1.0) as usize;
    (1..=n).map(move |k| a + (b - a) * (k as f32 / n as f32))
}
