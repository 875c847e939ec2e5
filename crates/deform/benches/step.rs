//! The cost of one dynamics step (the closing note's figures): curves of 12 and 48 control
//! points and a 10 × 10 bicubic surface, each with a point force, at 1 kHz, alone and with
//! the implicit contact spring a haptic loop adds.

use criterion::{Criterion, criterion_group, criterion_main};
use deform::{Body, Params, Shape};
use nurbs::{CurveBuf, SurfaceBuf, Vec2, Vec3};

fn uniform_knots(p: usize, n: usize) -> Vec<f32> {
    let inner = n - p;
    let mut k = vec![0.0; p + 1];
    k.extend((1..inner).map(|i| i as f32 / inner as f32));
    k.extend(vec![1.0; p + 1]);
    k
}

fn curve(n: usize) -> Body {
    let points: Vec<Vec2> = (0..n)
        .map(|i| Vec2::new(0.1 * i as f32 / (n - 1) as f32, 0.0))
        .collect();
    let c = CurveBuf::from_cartesian(3, uniform_knots(3, n), &points, None).expect("valid");
    let (shape, rest) = Shape::of_curve2(&c);
    Body::new(shape, rest, Params::CURVE).expect("valid")
}

fn surface(n: usize) -> Body {
    let rows: Vec<Vec<Vec3>> = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| {
                    Vec3::new(
                        0.1 * i as f32 / (n - 1) as f32,
                        0.1 * j as f32 / (n - 1) as f32,
                        0.0,
                    )
                })
                .collect()
        })
        .collect();
    let k = uniform_knots(3, n);
    let s =
        SurfaceBuf::from_rows::<_, Vec<f32>>((3, 3), (k.clone(), k), &rows, None).expect("valid");
    let (shape, rest) = Shape::of_surface(&s);
    Body::new(shape, rest, Params::SURFACE).expect("valid")
}

fn bench(c: &mut Criterion) {
    for (name, mut body, at) in [
        ("curve 12", curve(12), [0.5, 0.0]),
        ("curve 48", curve(48), [0.5, 0.0]),
        ("surface 10x10", surface(10), [0.5, 0.5]),
    ] {
        let mut load = body.zero_load();
        body.add_point_force(&mut load, at, [0.0, -1.0, -1.0]);
        body.step(1e-3, &load).expect("steps");
        c.bench_function(&format!("step {name}"), |b| {
            b.iter(|| body.step(1e-3, &load).expect("steps"))
        });
        // The loop's step: a contact spring at the point, implicit (three directions).
        let contact = deform::Coupling {
            params: at,
            anchor: body.point(at),
            stiffness: 1000.0,
            normal: None,
        };
        c.bench_function(&format!("step {name} with contact"), |b| {
            b.iter(|| {
                body.step_coupled(1e-3, &load, Some(&contact))
                    .expect("steps")
            })
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
