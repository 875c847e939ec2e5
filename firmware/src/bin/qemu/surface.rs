//! The surface run: the friction renderer on a surface (the planar pantograph cannot reach
//! one), every tick counted.

use super::*;

/// The friction renderer alone (the planar pantograph cannot reach a surface) on object 0 of
/// [`SURFACE_SCENE`], the HIP on [`SURFACE_PATH`] at the loop's rate `rate_hz`: every
/// `FrictionRenderer::tick` counted, and the global search that starts it counted alone.
/// The path is sampled at its own rate (1 kHz: a table at 10 kHz would not fit the flash);
/// between two samples the HIP moves on the straight line, `rate_hz / path rate` ticks per
/// sample (the path is piecewise linear in (u, v, height), so the chord is within
/// micrometres of it over 1 ms).
#[inline(never)]
pub(crate) fn surface_run(meter: &mut Meter, rate_hz: f64) {
    let path = match HipPath::parse(SURFACE_PATH) {
        Ok(p) => p,
        Err(e) => fail(format_args!("surface path: {e}")),
    };
    let name = path.name;
    let mut store = SceneStore::new();
    if let Err(e) = store.decode(SURFACE_SCENE) {
        fail(format_args!("scene {name}: {e}"));
    }
    // The shell holds its own copy of the object's surfaces, built in place
    // ([`SceneStore::rebuild_shell`]: no shell returned through the stack).
    let mut shell = tracker::Shell::EMPTY;
    if let Err(e) = store.rebuild_shell(0, &mut shell) {
        fail(format_args!("scene {name}: {e}"));
    }
    let Some(material) = store.material(0) else {
        fail(format_args!("scene {name}: no material"));
    };
    let per_point = (libm::round(rate_hz / path.rate_hz) as usize).max(1);
    let t = (1.0 / (path.rate_hz * per_point as f64)) as f32;
    let point = |i: usize| match path.point(i) {
        Ok(p) => p,
        Err(e) => fail(format_args!("{e}")),
    };
    let hip0 = point(0);
    let overhead = meter.overhead;
    let (mut renderer, search) =
        meter.instructions(|| FrictionRenderer::new(&shell, material, hip0));
    let mut all = Stats::default();
    let mut by_mode = [Stats::default(); 4];
    let mut previous = hip0;
    let ticks = path.ticks().saturating_sub(1) * per_point + 1;
    for i in 0..ticks {
        let (k, j) = (i / per_point, i % per_point);
        let hip = if j == 0 {
            point(k)
        } else {
            let (a, b) = (point(k), point(k + 1));
            a + (b - a) * (j as f32 / per_point as f32)
        };
        let velocity = (hip - previous) * (1.0 / t);
        previous = hip;
        let (out, n) = meter.instructions(|| renderer.tick(&shell, hip, velocity, t));
        let n = match n {
            Ok(n) => n.saturating_sub(overhead),
            Err(e) => fail(format_args!("tick {i}: instruction count: {e:?}")),
        };
        all.add(n, i);
        by_mode[mode_index(out.mode)].add(n, i);
    }
    hprintln!(
        "run scene={} rate_hz={} ticks={} path_rate_hz={}",
        name,
        rate_hz,
        all.n,
        path.rate_hz
    );
    hprintln!(
        "instructions_acquisition scene={} count={:?}",
        name,
        search.ok().map(|n| n.saturating_sub(overhead))
    );
    hprintln!("instructions_per_tick scene={} {}", name, all);
    print_by_mode(name, &by_mode);
}
