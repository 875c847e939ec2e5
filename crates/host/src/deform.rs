//! Deformable objects (D-NURBS, crate `deform`) on the host: the static shape under a load and
//! the free motion after it is removed (`viewer deform`), and the haptic loop pushing one
//! (`viewer sim --deform`): the rendered contact force acts back on the object at the contact
//! point (`f_p = Jᵀ(−F)`), the object steps at [`DYNAMICS_RATE_HZ`] or faster, and the
//! renderer (its CP tracker, GO and friction state) carries over onto each new shape, so the
//! tracker follows the moving surface from where it was.

use std::io::{self, Write};
use std::sync::{Arc, Mutex, PoisonError};

use deform::{Body, Coupling, Nodes};

use friction::{FrictionMaterial, FrictionRenderer};
use nurbs::Vec3;
use scene::{Object, ObjectError, Patch, Scene, Space};
use tracker::{Chain, ChainTracker, Object as TrackedObject, Shell, ShellTracker};

use device::controller::{Controller, ControllerError};
use device::spec::DeviceSpec;

use crate::closed_loop::{DeviceRun, drive_device, ready_controller, validate_device};
use crate::error::SimError;
use crate::hand::DeviceHand;
use crate::sim::{HipSamples, Proceed, Run, Trajectory, validate};
use crate::tick::{Tick, device_tick, point, render_tick};

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

/// Why a loop did not take a [`LoopCommand::Deform`](crate::backend::LoopCommand::Deform): the object
/// it renders is unchanged.
#[derive(Debug, thiserror::Error)]
pub enum DeformChangeError {
    /// The loop renders no object.
    #[error("no object is rendered: there is nothing to deform")]
    NoObject,
    /// The spatial hand feels a mesh (the polygonal baseline), not the NURBS object.
    #[error("the hand feels the object's mesh: feel the NURBS surface to deform it")]
    Mesh,
    /// The object is rigid (no `"dynamics"` block), or its body or shape could not be built.
    #[error(transparent)]
    Object(#[from] DeformError),
    /// The device's controller refused the object's new shape (its topology changed).
    #[error("device controller: {0}")]
    Controller(ControllerError),
    /// The device (or the loop's own copy of the object) refused a control-point update of
    /// the object's new shape ([`crate::backend::PointsUpdate`]); the reason names the field.
    #[error("the object's new shape was refused: {0}")]
    Update(String),
}

/// What a loop answers a [`LoopCommand::Deform`](crate::backend::LoopCommand::Deform) it took.
#[derive(Clone, Debug)]
pub struct DeformStatus {
    /// Whether the object now deforms (`false`: rigid, at its rest shape).
    pub deforming: bool,
    /// Where the loop publishes the object's shape while it deforms (the same for the loop's
    /// whole life: a reader keeps it across commands and scene swaps).
    pub shape: Arc<SharedShape>,
}

/// Loop steps of 1 ms between two publications of a deforming object's shape: 17 ms, so at
/// most 59 Hz, a display's rate (a frame drawn between two publications shows the same shape).
pub const PUBLISH_EVERY_MS: u32 = 17;

/// A deformable object's shape as a loop publishes it for the UI.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShapeFrame {
    /// Whether the object deforms; `false` once it is rigid again (at rest), or before it
    /// ever deformed.
    pub deforming: bool,
    /// The object's index in the loop's scene.
    pub object: usize,
    /// Its first patch's control points (m, the scene's order; `z = 0` on planar curves).
    pub points: Vec<[f64; 3]>,
    /// The loop's time of the shape (s).
    pub t_s: f64,
    /// Publications so far: a reader tells a new shape from one it has read.
    pub version: u64,
}

/// The shape of a loop's deformable object, shared with the UI: the loop writes it at most
/// every [`PUBLISH_EVERY_MS`] and only when it gets the lock at once (`try_lock`: a tick never
/// waits for a frame; a publication missed is made at the next step), into buffers sized when
/// deforming starts, so a publication allocates nothing. The UI copies it out when it draws.
#[derive(Debug, Default)]
pub struct SharedShape(Mutex<ShapeFrame>);

impl SharedShape {
    /// An empty shape (not deforming), to share.
    pub fn new() -> Arc<Self> {
        Arc::new(SharedShape::default())
    }

    /// Loop side, when `deformer` starts (a command, not a tick: this may wait for a reader
    /// and allocates the buffers): its rest shape, published.
    pub fn start(&self, deformer: &Deformer, t_s: f64) {
        let mut frame = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        frame.points.resize(deformer.body().n_points(), [0.0; 3]);
        frame.deforming = true;
        frame.object = deformer.index();
        write_points(&mut frame, deformer, t_s);
    }

    /// Loop side, every tick it may publish: `deformer`'s current control points, unless a
    /// reader holds the lock (then `false`: try again later). Copies into the buffers
    /// [`SharedShape::start`] sized: no allocation, no wait.
    pub fn publish(&self, deformer: &Deformer, t_s: f64) -> bool {
        match self.0.try_lock() {
            Ok(mut frame) => {
                write_points(&mut frame, deformer, t_s);
                true
            }
            Err(_) => false,
        }
    }

    /// Loop side, after each step of `deformer`: counts the step in `since_publish` and
    /// publishes once [`PUBLISH_EVERY_MS`] steps have passed since the last publication (a
    /// reader holding the lock only delays it to the next step).
    pub fn publish_when_due(&self, since_publish: &mut u32, deformer: &Deformer, t_s: f64) {
        *since_publish += 1;
        if *since_publish >= PUBLISH_EVERY_MS && self.publish(deformer, t_s) {
            *since_publish = 0;
        }
    }

    /// Loop side, when the object is rigid again (a command or a scene swap): not deforming.
    pub fn stop(&self, t_s: f64) {
        let mut frame = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        frame.deforming = false;
        frame.t_s = t_s;
        frame.version += 1;
    }

    /// UI side: copies the shape into `into` when it is newer than `into` (another version);
    /// whether it did. Holds the lock for the copy only.
    pub fn read_into(&self, into: &mut ShapeFrame) -> bool {
        let frame = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        if frame.version == into.version {
            return false;
        }
        into.clone_from(&frame);
        true
    }
}

/// The deformer's control points (rest plus displacement, no allocation) into `frame`.
fn write_points(frame: &mut ShapeFrame, deformer: &Deformer, t_s: f64) {
    let body = deformer.body();
    for ((out, p), u) in frame
        .points
        .iter_mut()
        .zip(body.rest())
        .zip(body.displacement())
    {
        *out = [p[0] + u[0], p[1] + u[1], p[2] + u[2]];
    }
    frame.t_s = t_s;
    frame.version += 1;
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

/// What the loop renders of one shape of an object: a chain of planar curves or a shell of
/// surfaces, holding its own copy of the shape (so the renderer carries over from shape to
/// shape, and the shape's object can go).
trait Views {
    type O: TrackedObject<State = Self::State, P = Self::P>;
    type State: Copy + core::fmt::Debug;
    type P: nurbs::Point;
    fn view(object: &Object, index: usize) -> Result<Self::O, SimError>;
}

struct ChainViews;
struct ShellViews;

impl Views for ChainViews {
    type O = Chain;
    type State = ChainTracker;
    type P = nurbs::Vec2;
    fn view(object: &Object, index: usize) -> Result<Chain, SimError> {
        let curves = object.curve_views().unwrap_or_default();
        Chain::new(&curves).map_err(|error| SimError::Chain { index, error })
    }
}

impl Views for ShellViews {
    type O = Shell;
    type State = ShellTracker;
    type P = Vec3;
    fn view(object: &Object, index: usize) -> Result<Shell, SimError> {
        let surfaces = object.surface_views().unwrap_or_default();
        Shell::new(&surfaces).map_err(|error| SimError::Shell { index, error })
    }
}

/// [`crate::sim::run`] with object `index` deformable: every tick renders against the
/// object's current shape; its force, reversed, loads the object at the CP; the object steps
/// every `⌊rate / DYNAMICS_RATE_HZ⌋` ticks (at least every tick) under the mean of those
/// ticks' loads; the ticks record the object's displacement at the CP ([`Tick::deform`]).
/// `progress` may end the run after a tick ([`Proceed`]).
pub fn run<P: Proceed>(
    scene: &Scene,
    index: usize,
    trajectory: &Trajectory,
    rate_hz: f64,
    progress: impl FnMut(usize, usize) -> P,
) -> Result<Run, DeformError> {
    let n = validate(scene, index, trajectory, rate_hz)?;
    let deformer = Deformer::new(scene, index)?;
    let object = deformer.rest().clone();
    let material = object.material().friction_material();
    let ticks = match trajectory.space() {
        Space::Planar => {
            simulate::<ChainViews, P>(deformer, material, trajectory, rate_hz, n, progress)?
        }
        Space::Spatial => {
            simulate::<ShellViews, P>(deformer, material, trajectory, rate_hz, n, progress)?
        }
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

/// A deformable object in a haptic loop: its body, its rest shape, and what the loop's ticks
/// since its last step did to it. The loop [feeds](Deformer::feed) it every rendered tick and
/// [steps](Deformer::step) it at its dynamics rate; the contact's spring acts in the object's
/// implicit step ([`Coupling`]: the spring `k (GO − HIP)` that renders both the normal and the
/// friction force ties the HIP to the GO's point of the object in every direction), the rest
/// of the rendered force (what the GO's sliding caps, the wall's damping) explicitly,
/// averaged over the step's ticks.
#[derive(Clone, Debug)]
pub struct Deformer {
    index: usize,
    rest: Object,
    body: Body,
    stiffness_n_per_m: f64,
    load: Nodes,
    explicit: [f64; 3],
    fed: usize,
    coupling: Option<Coupling>,
    /// The CP's parameters [`Deformer::locate_cp`] found last (its next start).
    located: [f64; 2],
}

impl Deformer {
    /// Object `index` of `scene`, at rest; its contact stiffness is its material's.
    pub fn new(scene: &Scene, index: usize) -> Result<Self, DeformError> {
        let (object, body) = body(scene, index)?;
        Ok(Deformer {
            index,
            rest: object.clone(),
            load: body.zero_load(),
            stiffness_n_per_m: f64::from(object.material().stiffness_n_per_m()),
            body,
            explicit: [0.0; 3],
            fed: 0,
            coupling: None,
            located: [0.5, 0.5],
        })
    }

    /// Fills in the CP's parameters of a tick that carries its position only (a device's
    /// telemetry frame, [`crate::remote::tick_of`], which gives the GO's parameter, where the
    /// force acts, but has no room for the CP's): the point of the current shape nearest it,
    /// by Gauss–Newton from where it was last ([`Body::project`]; the contact moves little
    /// in a millisecond). The CP's parameter only places [`Tick::deform`].
    pub fn locate_cp(&mut self, tick: &mut Tick) {
        let target = tick.cp.to_array().map(f64::from);
        self.located = self.body.project(target, self.located, 6);
        tick.cp_params = self.located.map(|x| x as f32);
        tick.cp_param = tick.cp_params[0];
    }

    /// Renders the contact with stiffness `stiffness_n_per_m` from the next tick (a material
    /// change: the contact spring in the object's step is the material's).
    pub fn set_contact_stiffness(&mut self, stiffness_n_per_m: f32) {
        self.stiffness_n_per_m = f64::from(stiffness_n_per_m);
    }

    /// The object's index in its scene.
    pub fn index(&self) -> usize {
        self.index
    }

    /// The object at rest (its scene's).
    pub fn rest(&self) -> &Object {
        &self.rest
    }

    /// The patches of the object whose control points the body's nodes are, in the nodes'
    /// order: each patch's index in the object and its number of control points. The body is
    /// its object's first patch (`scene/1` deforms objects of one patch: joined patches would
    /// have to share their end points as they move, [`Object::body`]).
    pub fn patches(&self) -> [(usize, usize); 1] {
        [(0, self.body.n_points())]
    }

    /// The body.
    pub fn body(&self) -> &Body {
        &self.body
    }

    /// The current control points (m).
    pub fn points(&self) -> Nodes {
        self.body.points()
    }

    /// The rest shape's control points (m).
    pub fn rest_points(&self) -> Nodes {
        self.body.rest().to_vec()
    }

    /// One rendered tick: while in contact its force, reversed, loads the object. Returns the
    /// object's displacement from rest at the tick's CP ([`Tick::deform`]).
    pub fn feed(&mut self, tick: &Tick) -> Vec3 {
        self.fed += 1;
        if tick.patch.is_some() {
            let hip = tick.hip.to_array().map(f64::from);
            let k = self.stiffness_n_per_m;
            // The rendered force is `k (GO − HIP)` (normal and friction spring in one) while
            // the GO does not slide, so the object's side of it is one spring in every
            // direction at the GO's point. Implicit in the step: an explicit tangential
            // spring of k on a light undamped string gains energy (measured: 16 mJ over a
            // 25 mm stroke and back). While the GO slides the force is capped at μ F_N; the
            // difference is the explicit remainder.
            let c = Coupling {
                params: tick.go_params.map(f64::from),
                anchor: hip,
                stiffness: k,
                normal: None,
            };
            // The remainder is measured against the spring the tick rendered, at the tick's
            // own GO: on a device behind a link that GO lies on the shape the device was
            // sent last, not on this one, and the spring's difference between the two shapes
            // (k times the link's lag of the shape) is no force of the contact.
            let go = tick.go.to_array().map(f64::from);
            let rendered = tick.force.to_array().map(|x| -f64::from(x));
            for a in 0..3 {
                self.explicit[a] += rendered[a] - k * (hip[a] - go[a]);
            }
            self.coupling = Some(c);
        }
        let d = self.body.displacement_at(tick.cp_params.map(f64::from));
        Vec3::from_array(d.map(|x| x as f32))
    }

    /// Steps the object by `dt_s` under what the ticks fed since the last step did to it.
    pub fn step(&mut self, dt_s: f64) -> Result<(), DeformError> {
        if let Some(c) = &self.coupling {
            let mean = self.explicit.map(|x| x / self.fed.max(1) as f64);
            self.body.add_point_force(&mut self.load, c.params, mean);
        }
        let stepped = self
            .body
            .step_coupled(dt_s, &self.load, self.coupling.as_ref())
            .map_err(|e| dynamics_error(self.index, &self.rest, e));
        self.load.iter_mut().for_each(|f| *f = [0.0; 3]);
        self.explicit = [0.0; 3];
        self.fed = 0;
        self.coupling = None;
        stepped
    }

    /// The object in its current shape.
    pub fn shape(&self) -> Result<Object, DeformError> {
        self.rest
            .reshaped(&self.body.points())
            .map_err(|error| DeformError::Shape {
                index: self.index,
                error,
            })
    }
}

/// Ticks per dynamics step at `rate_hz`.
pub fn ticks_per_step(rate_hz: f64) -> usize {
    ((rate_hz / DYNAMICS_RATE_HZ).floor() as usize).max(1)
}

fn simulate<V: Views, P: Proceed>(
    mut deformer: Deformer,
    material: FrictionMaterial,
    trajectory: &Trajectory,
    rate_hz: f64,
    n: usize,
    mut progress: impl FnMut(usize, usize) -> P,
) -> Result<Vec<Tick>, DeformError> {
    let index = deformer.index();
    let period_s = (1.0 / rate_hz) as f32;
    let per_step = ticks_per_step(rate_hz);
    let dt_s = per_step as f64 / rate_hz;
    let start = trajectory.at(trajectory.start_s());
    let mut object = V::view(deformer.rest(), index)?;
    let mut renderer = FrictionRenderer::new(&object, material, point::<V::P>(start));
    let mut hips = HipSamples::new(trajectory, rate_hz);
    let mut ticks = Vec::with_capacity(n);
    let mut i = 0;
    while i < n {
        for _ in 0..per_step.min(n - i) {
            let (t_s, hip, hip_velocity) = hips.tick::<V::P>(i);
            let mut tick = render_tick(&mut renderer, &object, t_s, hip, hip_velocity, period_s);
            tick.deform = Some(deformer.feed(&tick));
            ticks.push(tick);
            i += 1;
            if !progress(i, n).proceed() {
                return Ok(ticks);
            }
        }
        deformer.step(dt_s)?;
        // The renderer rides onto the new shape (what sits on the surface moves with it).
        let next = V::view(&deformer.shape()?, index)?;
        renderer.follow_reshape(&object, &next);
        object = next;
    }
    Ok(ticks)
}

/// `controller` moved onto `shape`, object `index` with its control points moved
/// ([`Controller::replace_object`]: the same renderer, no search, no ramp-in; the controller
/// keeps its own copy of the new chain), or the reason, with the controller unchanged.
///
/// The chain is built from the shape's curves directly: [`run_device`] loads no upload. (The
/// app's planar loop sends its shapes through the device's receiver instead,
/// [`crate::deformation::Deformation`]: about 1 µs a step more for the bundled string.)
pub(crate) fn carry(
    controller: &mut Controller<Chain>,
    shape: &Object,
    index: usize,
) -> Result<(), DeformChangeError> {
    let chain = ChainViews::view(shape, index)
        .map_err(|e| DeformChangeError::Object(DeformError::Sim(e)))?;
    controller
        .replace_object(chain)
        .map(drop)
        .map_err(DeformChangeError::Controller)
}

/// [`crate::closed_loop::run_device`] with object `index` deformable: the closed loop through the
/// simulated pantograph and the device's controller at `rate_hz`, the object fed every tick
/// (the controller's rendering of it, the handle's true HIP) and stepped every
/// `⌊rate / DYNAMICS_RATE_HZ⌋` ticks, the controller moved onto each new shape between two
/// ticks ([`Controller::reshape`]), as a board does with the control-point updates a host
/// sends. `progress` may end the run after a tick ([`Proceed`]).
pub fn run_device<P: Proceed>(
    scene: &Scene,
    index: usize,
    trajectory: &Trajectory,
    rate_hz: f64,
    hand: impl Into<DeviceHand>,
    progress: impl FnMut(usize, usize) -> P,
) -> Result<DeviceRun, DeformError> {
    run_device_lagged(scene, index, trajectory, rate_hz, hand, 0, progress)
}

/// [`run_device`] with the device `lag_steps` dynamics steps behind the object: the
/// controller is moved onto the shape of `lag_steps` steps before, as a device behind a link
/// renders the shape it was sent last (the update interval, the link's latency, a host
/// thread held up by its machine).
pub fn run_device_lagged<P: Proceed>(
    scene: &Scene,
    index: usize,
    trajectory: &Trajectory,
    rate_hz: f64,
    hand: impl Into<DeviceHand>,
    lag_steps: usize,
    progress: impl FnMut(usize, usize) -> P,
) -> Result<DeviceRun, DeformError> {
    let hand: DeviceHand = hand.into();
    let mut in_flight: std::collections::VecDeque<Object> =
        std::collections::VecDeque::with_capacity(lag_steps + 1);
    let n = validate_device(scene, index, trajectory, rate_hz)?;
    let mut deformer = Deformer::new(scene, index)?;
    let material = deformer.rest().material().friction_material();
    let period_s = (1.0 / rate_hz) as f32;
    let per_step = ticks_per_step(rate_hz);
    let dt_s = per_step as f64 / rate_hz;
    let (mut controller, passivity_control) = ready_controller(
        DeviceSpec::default(),
        ChainViews::view(deformer.rest(), index)?,
        material,
        rate_hz,
    )?;
    let mut i = 0;
    let (ticks, telemetry) = drive_device(
        DeviceSpec::default(),
        trajectory,
        rate_hz,
        hand,
        n,
        progress,
        |arm, t_s, now_us, target| {
            let (mut tick, frame) =
                device_tick(&mut controller, arm, t_s, now_us, target, period_s)?;
            tick.deform = Some(deformer.feed(&tick));
            i += 1;
            if i % per_step == 0 {
                deformer.step(dt_s)?;
                in_flight.push_back(deformer.shape()?);
                // The shape of `lag_steps` steps before, once there is one.
                let lagged = (in_flight.len() > lag_steps).then(|| in_flight.pop_front());
                let Some(next) = lagged.flatten() else {
                    return Ok((tick, frame));
                };
                match carry(&mut controller, &next, index) {
                    Ok(()) => {}
                    Err(DeformChangeError::Object(e)) => return Err(e),
                    Err(DeformChangeError::Controller(e)) => {
                        return Err(SimError::Controller(e).into());
                    }
                    Err(
                        DeformChangeError::NoObject
                        | DeformChangeError::Mesh
                        | DeformChangeError::Update(_),
                    ) => {
                        return Err(SimError::Controller(ControllerError::NoScene).into());
                    }
                };
            }
            Ok((tick, frame))
        },
    )?;
    Ok(DeviceRun {
        run: Run {
            space: Space::Planar,
            object: index,
            object_name: deformer.rest().name().to_owned(),
            material,
            rate_hz,
            ticks,
        },
        passivity_control,
        telemetry,
    })
}
