use friction::{FrictionMaterial, FrictionRenderer};
use nurbs::{Vec2, Vec3};
fn main() {
    let d = std::f32::consts::PI / 180.0;
    let a0 = nurbs::construct::arc(
        Vec2::new(-0.02, 0.06),
        Vec2::X * 0.04,
        Vec2::Y * 0.04,
        0.0,
        60.0 * d,
    )
    .unwrap();
    let a1 = nurbs::construct::arc(
        Vec2::new(0.02, 0.06),
        Vec2::X * 0.04,
        Vec2::Y * 0.04,
        120.0 * d,
        60.0 * d,
    )
    .unwrap();
    let views = vec![a0.view(), a1.view()];
    let chain = tracker::Chain::new(&views).unwrap();
    let traj: Vec<(f32, Vec2)> = std::fs::read_to_string("scenes/thesis-2d.csv")
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f32> = l.split(',').map(|x| x.parse().unwrap()).collect();
            (v[0], Vec2::new(v[1], v[2]))
        })
        .collect();
    let t = 1e-3;
    let mut r = FrictionRenderer::new(&chain, FrictionMaterial::default(), traj[0].1, t);
    let mut prev = traj[0].1;
    let mut last_mode = None;
    let mut last_f = Vec2::ZERO;
    for (k, &(time, hip)) in traj.iter().enumerate() {
        let o = r.tick(&chain, hip, (hip - prev) / t, t);
        let df = (o.total - last_f).length();
        if Some(o.mode) != last_mode || k % 100 == 0 || df > 0.05 {
            println!(
                "{time:.3} {:?} patch={} feat={:?} fn={:.3} ff={:.3} mu={:.3} go={:?}/{:?} cpu={:.3} df={:.3} dhip={:.5}",
                o.mode,
                o.contact.patch,
                o.contact.feature,
                o.normal_force_n,
                o.friction_force_n,
                o.mu,
                o.go_patch,
                o.go_params[0],
                o.contact.params[0],
                df,
                (hip - prev).length()
            );
            last_mode = Some(o.mode);
        }
        last_f = o.total;
        prev = hip;
    }
    let _ = Vec3::ZERO;
}
