//! Deformable objects (D-NURBS, crate `deform`) on the host: the static shape under a load and
//! the free motion after it is removed (`viewer deform`), and the haptic loop pushing one
//! (`viewer sim --deform`): the rendered contact force acts back on the object at the contact
//! point (`f_p = Jᵀ(−F)`), the object steps at [`DYNAMICS_RATE_HZ`] or faster, and the
//! renderer (its CP tracker, GO and friction state) carries over onto each new shape, so the
//! tracker follows the moving surface from where it was.

use std::io::{self, Write};

use deform::{Body, Coupling, Nodes};
use friction::{FrictionMaterial, FrictionRenderer, Mode};
use nurbs::Vec3;
use scene::{Object, ObjectError, Patch, Scene, Space};
use tracker::{Chain, ChainTracker, Object as TrackedObject, Shell, ShellTracker};

use crate::sim::{Run, SimError, Trajectory, validate};
use crate::tick::{Tick, point, render_tick};

/// The slowest rate the object steps at in a loop (Hz): a loop at up to twice this steps the
/// object every tick, a faster one every `⌊rate / DYNAMICS_RATE_HZ⌋` ticks.
pub const DYNAMICS_RATE_HZ: f64 = 1000.0;

/// Most steps of a `--release` run.
pub const MAX_STEPS: usize = 10_000_000;

/// Why a deformable object could not be loaded, loaded or run.
#[derive(Debug, thiserror::Error)]
pub enum DeformError {
    /// No such object.
    #[error("--object {index}: the scene has {count} object(s), indices 0..={}", count - 1)]
    ObjectIndex {
        /// Asked for.
        index: usize,
        /// Objects in the scene.
        count: usize,
    },
    /// The object has no `dynamics` block.
    #[error(
        "object {index} ({name:?}) is rigid: give it a \"dynamics\" block in the scene file to \
         make it deformable"
    )]
    Rigid {
        /// Object index.
        index: usize,
        /// Its name.
        name: String,
    },
    /// The body could not be built or solved.
    #[error("object {index}: {message}")]
    Dynamics {
        /// Object index.
        index: usize,
        /// What is wrong (names the `dynamics` field where there is one).
        message: String,
    },
    /// A command-line value that is wrong (the message names the option).
    #[error("{0}")]
    Argument(String),
    /// The deformed shape is not a valid patch (a control point left the range of f32).
    #[error("object {index}: the deformed shape is invalid: {error}")]
    Shape {
        /// Object index.
        index: usize,
        /// Why.
        error: ObjectError,
    },
    /// The loop could not run.
    #[error(transparent)]
    Sim(#[from] SimError),
}

/// A load on a deformable object.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Load {
    /// Force per unit rest length (N/m) or area (N/m²), everywhere.
    Uniform([f64; 3]),
    /// A force (N) at one parameter (`[u, 0]` on curves).
    Point {
        /// Where.
        params: [f64; 2],
        /// The force (N).
        force_n: [f64; 3],
    },
}

/// How many parameters and coordinates a patch of `object` has.
fn dims(object: &Object) -> (usize, usize) {
    match object.patches().first() {
        Some(Patch::Surface(_)) => (2, 3),
        Some(Patch::Curve3(_)) => (1, 3),
        _ => (1, 2),
    }
}

impl Load {
    /// Parses `uniform:FX,FY[,FZ]` or `point:U[,V],FX,FY[,FZ]` for `object` (two force
    /// components for a planar curve, three otherwise; `V` on surfaces only), with the point's
    /// parameters inside the patch's domain.
    pub fn parse(text: &str, object: &Object) -> Result<Load, DeformError> {
        let (n_params, n_coords) = dims(object);
        let bad = |why: String| DeformError::Argument(format!("--load {text:?}: {why}"));
        let (kind, rest) = text
            .split_once(':')
            .ok_or_else(|| bad("expected uniform:FX,FY[,FZ] or point:U[,V],FX,FY[,FZ]".into()))?;
        let numbers = rest
            .split(',')
            .map(|s| {
                s.trim()
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite() && (v.abs() as f32).is_finite())
                    .ok_or_else(|| bad(format!("{s:?} is not a finite number")))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let force = |xs: &[f64]| {
            let mut f = [0.0; 3];
            f[..n_coords].copy_from_slice(xs);
            f
        };
        let axes = if n_coords == 2 { "FX,FY" } else { "FX,FY,FZ" };
        match kind {
            "uniform" if numbers.len() == n_coords => Ok(Load::Uniform(force(&numbers))),
            "uniform" => Err(bad(format!(
                "a uniform load on this object is uniform:{axes} ({n_coords} numbers), found {}",
                numbers.len()
            ))),
            "point" if numbers.len() == n_params + n_coords => {
                let mut params = [0.0; 2];
                params[..n_params].copy_from_slice(&numbers[..n_params]);
                check_params(object, params, n_params).map_err(bad)?;
                Ok(Load::Point {
                    params,
                    force_n: force(&numbers[n_params..]),
                })
            }
            "point" => {
                let at = if n_params == 1 { "U" } else { "U,V" };
                Err(bad(format!(
                    "a point load on this object is point:{at},{axes} ({} numbers), found {}",
                    n_params + n_coords,
                    numbers.len()
                )))
            }
            other => Err(bad(format!("{other:?} is not uniform or point"))),
        }
    }

    /// Adds this load to `load` (the generalised forces of `body`).
    pub fn apply(&self, body: &mut Body, load: &mut [[f64; 3]]) {
        match *self {
            Load::Uniform(q) => body.add_uniform_load(load, q),
            Load::Point { params, force_n } => body.add_point_force(load, params, force_n),
        }
    }
}

/// Parses a probe parameter `U` (curves) or `U,V` (surfaces) of `object`, inside its domain.
pub fn parse_probe(text: &str, object: &Object) -> Result<[f64; 2], DeformError> {
    let (n_params, _) = dims(object);
    let bad = |why: String| DeformError::Argument(format!("--probe {text:?}: {why}"));
    let numbers = text
        .split(',')
        .map(|s| s.trim().parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| bad("not a list of finite numbers".into()))?;
    if numbers.len() != n_params {
        let want = if n_params == 1 {
            "U (a curve)"
        } else {
            "U,V (a surface)"
        };
        return Err(bad(format!(
            "expected {want}, found {} numbers",
            numbers.len()
        )));
    }
    let mut params = [0.0; 2];
    params[..n_params].copy_from_slice(&numbers);
    check_params(object, params, n_params).map_err(bad)?;
    Ok(params)
}

fn check_params(object: &Object, params: [f64; 2], n_params: usize) -> Result<(), String> {
    let Some(Ok(body)) = object.body() else {
        return Ok(());
    };
    let domain = body.shape().domain();
    for (k, (&p, (lo, hi))) in params.iter().zip(domain).take(n_params).enumerate() {
        if !(lo..=hi).contains(&p) {
            let name = ["U", "V"][k];
            return Err(format!(
                "{name} = {p} is outside the patch's domain [{lo}, {hi}]"
            ));
        }
    }
    Ok(())
}

/// Object `index` of `scene` and its deformable body at rest.
pub fn body(scene: &Scene, index: usize) -> Result<(&Object, Body), DeformError> {
    let object = scene.object(index).ok_or(DeformError::ObjectIndex {
        index,
        count: scene.objects().len(),
    })?;
    let body = object
        .body()
        .ok_or_else(|| DeformError::Rigid {
            index,
            name: object.name().to_owned(),
        })?
        .map_err(|e| dynamics_error(index, object, e))?;
    Ok((object, body))
}

fn dynamics_error(index: usize, object: &Object, e: deform::DynamicsError) -> DeformError {
    let surface = matches!(object.patches().first(), Some(Patch::Surface(_)));
    DeformError::Dynamics {
        index,
        message: e.message(surface),
    }
}

/// `scene` with object `index` in the shape of `body`.
pub fn reshaped_scene(scene: &Scene, index: usize, body: &Body) -> Result<Scene, DeformError> {
    let mut objects = scene.objects().to_vec();
    objects[index] = objects[index]
        .reshaped(&body.points())
        .map_err(|error| DeformError::Shape { index, error })?;
    Scene::new(objects).map_err(|_| DeformError::ObjectIndex { index, count: 0 })
}

/// The equilibrium of object `index` under `load`: the scene with the object in that shape
/// (its `dynamics` block kept; read again, the shape is its new rest shape), and the body.
pub fn static_shape(scene: &Scene, index: usize, load: Load) -> Result<(Scene, Body), DeformError> {
    let (object, mut body) = body(scene, index)?;
    let mut f = body.zero_load();
    load.apply(&mut body, &mut f);
    body.solve_static(&f)
        .map_err(|e| dynamics_error(index, object, e))?;
    Ok((reshaped_scene(scene, index, &body)?, body))
}

/// One sample of a `--release` trace: time (s) and the probe's position (m).
pub type ProbeSample = (f64, [f64; 3]);

/// Starts object `index` from its equilibrium under `load`, removes the load at `t = 0` and
/// steps it every `dt_s` for `duration_s`: the position of the point at `probe` at `t = 0` and
/// after every step.
pub fn release(
    scene: &Scene,
    index: usize,
    load: Load,
    duration_s: f64,
    dt_s: f64,
    probe: [f64; 2],
) -> Result<Vec<ProbeSample>, DeformError> {
    if !(dt_s.is_finite() && dt_s > 0.0 && dt_s <= 1.0) {
        return Err(DeformError::Argument(format!(
            "--dt {dt_s}: the step must be a time in (0, 1] s"
        )));
    }
    let steps = duration_s / dt_s;
    if !(duration_s.is_finite() && duration_s > 0.0 && steps <= MAX_STEPS as f64) {
        return Err(DeformError::Argument(format!(
            "--duration {duration_s}: must be positive and at most {MAX_STEPS} steps of --dt"
        )));
    }
    let (_, mut body) = static_shape(scene, index, load)?;
    let object = &scene.objects()[index];
    let zero = body.zero_load();
    let steps = steps.round().max(1.0) as usize;
    let mut trace = Vec::with_capacity(steps + 1);
    trace.push((0.0, body.point(probe)));
    for i in 1..=steps {
        body.step(dt_s, &zero)
            .map_err(|e| dynamics_error(index, object, e))?;
        trace.push((i as f64 * dt_s, body.point(probe)));
    }
    Ok(trace)
}

/// Writes a `--release` trace: `t_s,x,y` (planar curves) or `t_s,x,y,z`.
pub fn write_trace(mut out: impl Write, space: Space, trace: &[ProbeSample]) -> io::Result<()> {
    let dim = space.dim();
    writeln!(out, "t_s,{}", ["x", "y", "z"][..dim].join(","))?;
    for (t, p) in trace {
        write!(out, "{t}")?;
        for x in &p[..dim] {
            write!(out, ",{x:?}")?;
        }
        writeln!(out)?;
    }
    out.flush()
}

/// The views of one shape of an object, for the loop: a chain of planar curves or a shell of
/// surfaces, whose tracking state holds no borrow (so it carries over from shape to shape).
trait Views {
    type O<'a>: TrackedObject<State = Self::State, P = Self::P>;
    type State: Copy + core::fmt::Debug;
    type P: nurbs::Point;
    fn view(object: &Object, index: usize) -> Result<Self::O<'_>, SimError>;
}

struct ChainViews;
struct ShellViews;

impl Views for ChainViews {
    type O<'a> = Chain<'a>;
    type State = ChainTracker;
    type P = nurbs::Vec2;
    fn view(object: &Object, index: usize) -> Result<Chain<'_>, SimError> {
        let curves = object.curve_views().unwrap_or_default();
        Chain::new(&curves).map_err(|error| SimError::Chain { index, error })
    }
}

impl Views for ShellViews {
    type O<'a> = Shell<'a>;
    type State = ShellTracker;
    type P = Vec3;
    fn view(object: &Object, index: usize) -> Result<Shell<'_>, SimError> {
        let surfaces = object.surface_views().unwrap_or_default();
        Shell::new(&surfaces).map_err(|error| SimError::Shell { index, error })
    }
}

/// [`crate::sim::run`] with object `index` deformable: every tick renders against the
/// object's current shape; its force, reversed, loads the object at the CP; the object steps
/// every `⌊rate / DYNAMICS_RATE_HZ⌋` ticks (at least every tick) under the mean of those
/// ticks' loads; the ticks record the object's displacement at the CP ([`Tick::deform`]).
pub fn run(
    scene: &Scene,
    index: usize,
    trajectory: &Trajectory,
    rate_hz: f64,
    progress: impl FnMut(usize, usize),
) -> Result<Run, DeformError> {
    let n = validate(scene, index, trajectory, rate_hz)?;
    let (object, body) = body(scene, index)?;
    let material = object.material().friction_material();
    let ticks = match trajectory.space() {
        Space::Planar => simulate::<ChainViews>(
            object, index, body, material, trajectory, rate_hz, n, progress,
        )?,
        Space::Spatial => simulate::<ShellViews>(
            object, index, body, material, trajectory, rate_hz, n, progress,
        )?,
    };
    Ok(Run {
        space: trajectory.space(),
        object: index,
        object_name: object.name().to_owned(),
        material,
        rate_hz,
        ticks,
    })
}

/// The penalty contact of `tick` as a spring on the object: stuck, the friction spring ties
/// the HIP to the GO's point of the object in every direction; otherwise the normal spring
/// acts at the CP along the normal.
fn contact_spring(tick: &Tick, stiffness_n_per_m: f64) -> Coupling {
    let hip = tick.hip.to_array().map(f64::from);
    if tick.mode == Mode::Stuck {
        Coupling {
            params: tick.go_params.map(f64::from),
            anchor: hip,
            stiffness: stiffness_n_per_m,
            normal: None,
        }
    } else {
        Coupling {
            params: tick.cp_params.map(f64::from),
            anchor: hip,
            stiffness: stiffness_n_per_m,
            normal: Some(tick.normal.to_array().map(f64::from)),
        }
    }
}

/// Ticks per dynamics step at `rate_hz`.
pub fn ticks_per_step(rate_hz: f64) -> usize {
    ((rate_hz / DYNAMICS_RATE_HZ).floor() as usize).max(1)
}

#[allow(clippy::too_many_arguments)]
fn simulate<V: Views>(
    rest: &Object,
    index: usize,
    mut body: Body,
    material: FrictionMaterial,
    trajectory: &Trajectory,
    rate_hz: f64,
    n: usize,
    mut progress: impl FnMut(usize, usize),
) -> Result<Vec<Tick>, DeformError> {
    let period_s = (1.0 / rate_hz) as f32;
    let k_contact = f64::from(material.stiffness_n_per_m);
    let per_step = ticks_per_step(rate_hz);
    let dt_s = per_step as f64 / rate_hz;
    let start = trajectory.at(trajectory.start_s());
    let mut shape = rest.clone();
    // The renderer's type names its object's lifetime; between shapes it is held for no
    // borrow (`'static` views of nothing) and rebound to each shape's views.
    let mut carried: Option<FrictionRenderer<V::O<'static>>> = None;
    let mut previous = start;
    let mut load: Nodes = body.zero_load();
    let mut ticks = Vec::with_capacity(n);
    let mut i = 0;
    while i < n {
        let object = V::view(&shape, index)?;
        let mut renderer: FrictionRenderer<V::O<'_>> = match carried.take() {
            Some(r) => r.rebind(),
            None => FrictionRenderer::new(&object, material, point::<V::P>(start)),
        };
        // The contact's spring, implicit in the object's step (`deform::Coupling`): from the
        // latest tick in contact; the rest of the rendered force (friction while sliding, the
        // wall's damping) acts explicitly, averaged over the step's ticks.
        let mut coupling: Option<Coupling> = None;
        let mut explicit = [0.0; 3];
        let mut in_contact = 0usize;
        for _ in 0..per_step.min(n - i) {
            let t_s = trajectory.tick_time_s(i, rate_hz);
            let xyz = trajectory.at(t_s);
            let velocity = if i == 0 {
                [0.0; 3]
            } else {
                [0, 1, 2].map(|k| (xyz[k] - previous[k]) * rate_hz)
            };
            previous = xyz;
            let (hip, hip_velocity) = (point::<V::P>(xyz), point::<V::P>(velocity));
            let mut tick = render_tick(&mut renderer, &object, t_s, hip, hip_velocity, period_s);
            if tick.patch.is_some() {
                let c = contact_spring(&tick, k_contact);
                let spring = body.coupling_force(&c);
                let rendered = tick.force.to_array().map(|x| -f64::from(x));
                for a in 0..3 {
                    explicit[a] += rendered[a] - spring[a];
                }
                in_contact += 1;
                coupling = Some(c);
            }
            let d = body.displacement_at(tick.cp_params.map(f64::from));
            tick.deform = Some(Vec3::from_array(d.map(|x| x as f32)));
            ticks.push(tick);
            i += 1;
            progress(i, n);
        }
        if let Some(c) = &coupling {
            let mean = explicit.map(|x| x / in_contact as f64);
            body.add_point_force(&mut load, c.params, mean);
        }
        body.step_coupled(dt_s, &load, coupling.as_ref())
            .map_err(|e| dynamics_error(index, rest, e))?;
        load.iter_mut().for_each(|f| *f = [0.0; 3]);
        let next = rest
            .reshaped(&body.points())
            .map_err(|error| DeformError::Shape { index, error })?;
        // The renderer rides onto the new shape (what sits on the surface moves with it) and
        // is held, borrowing nothing, until the next round's views.
        let moved = renderer.reshape(&object, &V::view(&next, index)?);
        carried = Some(moved.rebind());
        drop(object);
        shape = next;
    }
    Ok(ticks)
}
