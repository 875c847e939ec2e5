//! Per-tick cost of tracking + friction: the thesis-2d object (two rational arcs meeting at a
//! vertex) and a bicubic surface, with the HIP sliding at constant depth (slip: the most
//! expensive mode, with the GO towed behind the CP) and pressed still (stuck).

use criterion::{Criterion, criterion_group, criterion_main};
use friction::{FrictionMaterial, FrictionRenderer};
use nurbs::{Vec2, Vec3, construct};
use std::hint::black_box;
use tracker::{Chain, Object, Shell};

const T: f32 = 1e-3;

/// Runs `warm` ticks along `path` (cyclically, back and forth) and then benchmarks one tick.
fn bench_object<O: Object>(c: &mut Criterion, name: &str, object: &O, path: &[O::P]) {
    let mut r = FrictionRenderer::new(object, FrictionMaterial::default(), path[0]);
    let n = path.len();
    // Ping-pong along the path so the motion stays smooth.
    let at = |k: usize| {
        let m = k % (2 * n - 2);
        if m < n { path[m] } else { path[2 * n - 2 - m] }
    };
    let mut k = 0;
    let mut prev = path[0];
    for _ in 0..2 * n {
        let x = at(k);
        r.tick(object, x, (x - prev) * (1.0 / T), T);
        prev = x;
        k += 1;
    }
    c.bench_function(name, |b| {
        b.iter(|| {
            let x = at(k);
            let o = r.tick(object, black_box(x), (x - prev) * (1.0 / T), T);
            prev = x;
            k += 1;
            black_box(o)
        })
    });
}

fn thesis_2d(c: &mut Criterion) {
    let d = std::f32::consts::PI / 180.0;
    let a0 = construct::arc(
        Vec2::new(-0.02, 0.06),
        Vec2::X * 0.04,
        Vec2::Y * 0.04,
        0.0,
        60.0 * d,
    )
    .expect("arc");
    let a1 = construct::arc(
        Vec2::new(0.02, 0.06),
        Vec2::X * 0.04,
        Vec2::Y * 0.04,
        120.0 * d,
        60.0 * d,
    )
    .expect("arc");
    let views = [a0.view(), a1.view()];
    let chain = Chain::new(&views).expect("chain");
    // 2 mm deep on the first arc, sliding over 20°–50° at 30 mm/s.
    let slide: Vec<Vec2> = (0..1000)
        .map(|k| {
            let a = (20.0 + 30.0 * k as f32 / 999.0) * d;
            Vec2::new(-0.02, 0.06) + Vec2::new(a.cos(), a.sin()) * 0.038
        })
        .collect();
    bench_object(c, "tick/thesis-2d/slip", &chain, &slide);
    let still = vec![slide[500]; 2];
    bench_object(c, "tick/thesis-2d/stuck", &chain, &still);
}

fn bicubic(c: &mut Criterion) {
    let rows: Vec<Vec<Vec3>> = (0..8)
        .map(|i| {
            (0..8)
                .map(|j| {
                    let (x, y) = (i as f32 / 7.0 * 0.08 - 0.04, j as f32 / 7.0 * 0.08 + 0.05);
                    Vec3::new(x, y, 0.01 * (60.0 * x).sin() * (40.0 * y).cos())
                })
                .collect()
        })
        .collect();
    let mut k = vec![0.0f32; 4];
    k.extend([0.2, 0.4, 0.6, 0.8]);
    k.extend([1.0; 4]);
    let s = nurbs::SurfaceBuf::from_rows::<_, &[f32]>((3, 3), (k.clone(), k), &rows, None)
        .expect("surface");
    let view = s.view();
    let views = [view];
    let shell = Shell::new(&views).expect("shell");
    let slide: Vec<Vec3> = (0..1000)
        .map(|k| {
            let v = 0.3 + 0.4 * k as f32 / 999.0;
            view.point(0.5, v) - view.normal(0.5, v) * 0.002
        })
        .collect();
    bench_object(c, "tick/bicubic8x8/slip", &shell, &slide);
    let still = vec![slide[500]; 2];
    bench_object(c, "tick/bicubic8x8/stuck", &shell, &still);
}

criterion_group!(benches, thesis_2d, bicubic);
criterion_main!(benches);
