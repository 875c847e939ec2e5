use friction::{FrictionMaterial, FrictionRenderer};
use nurbs::Vec3;
fn main() {
    let xs = [-0.04f32, -0.0133333, 0.0133333, 0.04];
    let ys = [0.06f32, 0.08, 0.10, 0.12];
    let rows: Vec<Vec<Vec3>> = (0..4)
        .map(|i| {
            (0..4)
                .map(|j| {
                    Vec3::new(
                        xs[i],
                        ys[j],
                        if (1..3).contains(&i) && (1..3).contains(&j) {
                            0.012
                        } else {
                            0.0
                        },
                    )
                })
                .collect()
        })
        .collect();
    let s = nurbs::construct::bezier_patch(&rows).unwrap();
    let views = vec![s.view()];
    let shell = tracker::Shell::new(&views).unwrap();
    let traj: Vec<(f32, Vec3)> = std::fs::read_to_string("scenes/thesis-3d.csv")
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f32> = l.split(',').map(|x| x.parse().unwrap()).collect();
            (v[0], Vec3::new(v[1], v[2], v[3]))
        })
        .collect();
    let t = 1e-3;
    let mut r = FrictionRenderer::new(&shell, FrictionMaterial::default(), traj[0].1, t);
    let mut prev = traj[0].1;
    let mut last_mode = None;
    let mut last_f = Vec3::ZERO;
    for (k, &(time, hip)) in traj.iter().enumerate() {
        let o = r.tick(&shell, hip, (hip - prev) / t, t);
        let df = (o.total - last_f).length();
        if Some(o.mode) != last_mode || k % 100 == 0 || df > 0.05 {
            println!(
                "{time:.3} {:?} fn={:.3} ff={:.3} mu={:.3} go={:?} cp={:?} df={:.3}",
                o.mode,
                o.normal_force_n,
                o.friction_force_n,
                o.mu,
                o.go_params,
                o.contact.params,
                df
            );
            last_mode = Some(o.mode);
        }
        last_f = o.total;
        prev = hip;
    }
}
