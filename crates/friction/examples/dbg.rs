use friction::*;
use nurbs::{Vec3, construct};
use tracker::Shell;
fn main() {
    let xs = [-0.04f32, -0.0133, 0.0133, 0.04];
    let ys = [0.06f32, 0.08, 0.10, 0.12];
    let rows: Vec<Vec<Vec3>> = (0..4)
        .map(|i| (0..4).map(|j| Vec3::new(xs[i], ys[j], 0.0)).collect())
        .collect();
    let s = construct::bezier_patch(&rows).unwrap();
    let views = [s.view()];
    let shell = Shell::new(&views).unwrap();
    let n = s.view().normal(0.5, 0.5);
    let start = s.view().point(0.5, 0.5);
    let t1 = n.any_orthonormal_vector();
    let t2 = n.cross(t1);
    let wiggle = [
        (0.0f32, 0.0f32),
        (-0.004537063, 0.0),
        (-0.0054689953, -0.0059124078),
    ];
    let depth = 0.0005;
    let above = start + n * 0.005;
    let pressed = start - n * depth;
    let mut pts = vec![above, pressed];
    let mut phase = 0.0f32;
    for &(a, b) in &wiggle {
        phase += 1.0;
        let mut off = Vec3::ZERO;
        for (i, &t) in [t1, t2].iter().enumerate() {
            off += t * (a * (phase * (1.3 + i as f32)).sin() + b * (phase * 0.7).cos());
        }
        pts.push(pressed + off);
    }
    pts.push(pressed);
    pts.push(above);
    let mut path = vec![pts[0]];
    for w in pts.windows(2) {
        let n = ((w[1] - w[0]).length() / 5e-5).ceil().max(1.0) as usize;
        for k in 1..=n {
            path.push(w[0] + (w[1] - w[0]) * (k as f32 / n as f32));
        }
    }
    let t = 1e-3;
    let mut r = FrictionRenderer::new(&shell, FrictionMaterial::default(), path[0], t);
    let (mut px, mut pf) = (path[0], Vec3::ZERO);
    let mut work = 0.0;
    let mut last_mode = None;
    for (k, &x) in path.iter().enumerate() {
        let o = r.tick(&shell, x, (x - px) / t, t);
        let dw = (pf + o.friction).dot(x - px) * 0.5;
        work += dw;
        if Some(o.mode) != last_mode || dw > 1e-6 {
            println!(
                "{k} {:?} dw={dw:.2e} W={work:.2e} f={:?} fn={:.3} go={:?} hip={x:?}",
                o.mode, o.friction, o.normal_force_n, o.go
            );
            last_mode = Some(o.mode);
        }
        pf = o.friction;
        px = x;
    }
}
