//! Evaluation cost: point + first derivatives of a bicubic 8×8 surface (non-rational and
//! rational), and a cubic curve point + two derivatives.

use criterion::{Criterion, criterion_group, criterion_main};
use nurbs::{CurveBuf, SurfaceBuf, Vec2, Vec3};
use std::hint::black_box;

fn bicubic(rational: bool) -> SurfaceBuf {
    let rows: Vec<Vec<Vec3>> = (0..8)
        .map(|i| {
            (0..8)
                .map(|j| {
                    let (x, y) = (i as f32 / 7.0, j as f32 / 7.0);
                    Vec3::new(x, y, 0.1 * (3.0 * x).sin() * (2.0 * y).cos())
                })
                .collect()
        })
        .collect();
    let weights: Vec<Vec<f32>> = (0..8)
        .map(|i| (0..8).map(|j| 1.0 + 0.5 * ((i + j) % 3) as f32).collect())
        .collect();
    SurfaceBuf::from_rows(
        (3, 3),
        (
            nurbs::construct::uniform_knots(8, 3),
            nurbs::construct::uniform_knots(8, 3),
        ),
        &rows,
        rational.then_some(weights.as_slice()),
    )
    .expect("valid bench surface")
}

fn params() -> Vec<(f32, f32)> {
    (0..64)
        .map(|k| (((k * 37) % 64) as f32 / 63.0, ((k * 11) % 64) as f32 / 63.0))
        .collect()
}

fn bench(c: &mut Criterion) {
    let ps = params();
    for (name, rational) in [("bicubic8x8", false), ("bicubic8x8_rational", true)] {
        let s = bicubic(rational);
        let view = s.view();
        let mut i = 0;
        c.bench_function(&format!("surface/{name}/point+d1"), |b| {
            b.iter(|| {
                let (u, v) = ps[i & 63];
                i += 1;
                black_box(view.derivs(black_box(u), black_box(v), 1))
            })
        });
        c.bench_function(&format!("surface/{name}/point"), |b| {
            b.iter(|| {
                let (u, v) = ps[i & 63];
                i += 1;
                black_box(view.point(black_box(u), black_box(v)))
            })
        });
    }
    let pts: Vec<Vec2> = (0..8)
        .map(|i| Vec2::new(i as f32 / 7.0, ((i * 5) % 3) as f32 * 0.1))
        .collect();
    let curve = CurveBuf::from_cartesian(3, nurbs::construct::uniform_knots(8, 3), &pts, None)
        .expect("valid curve");
    let view = curve.view();
    let mut i = 0;
    c.bench_function("curve/cubic8/point+d1+d2", |b| {
        b.iter(|| {
            let (u, _) = ps[i & 63];
            i += 1;
            black_box(view.derivs(black_box(u), 2))
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
