//! The spatial hand behind the GUI's 3-D view: an impedance point (the HIP goes where the hand
//! puts it, the force is only shown) on an object of surfaces, stepped one tick at a time at
//! [`RATE_HZ`] by the same per-tick step as `viewer sim` on a spatial scene
//! ([`tick::render_tick`]: the friction renderer on a [`Shell`]), or, on a mesh, by the
//! polygonal baseline of the thesis (§2.1.3, Fig. 2.1.2 (b)): the closest triangle of a
//! [`TriMesh`] and the penalty `K·depth` along its face normal, without friction.
//!
//! The loop runs on the thread of [`crate::backend::LoopThread`], or stepped in place, through
//! the same [`crate::backend::Backend`] as the planar loop (it is a [`Steppable`]); its
//! commands, replies and samples are the planar loop's ([`LoopCommand`], [`Reply`], [`Sample`]),
//! swapping in a [`SpatialSession`]. Tests step a [`SpatialLoop`] directly.
//!
//! A deformable object of surfaces (one with a `"dynamics"` block) deforms under the hand on
//! [`LoopCommand::Deform`], through the loops' one lifecycle ([`Deformation`]): every tick
//! feeds it and steps it (1 ms), and its new shape reaches the hand as the control-point
//! update a device gets ([`PointsUpdate`], of surface points), the renderer carried onto the
//! updated shell ([`FrictionRenderer::follow_reshape`]: no search, no restart). The shape
//! reaches the UI through a [`SharedShape`].

use std::sync::Arc;

use device::simulator::VirtualHand;
use friction::{FrictionMaterial, FrictionRenderer, Mode, SwitchCause};
use nurbs::{Vec2, Vec3};
use tracker::{Contact, Feature, Penalty, Shell, TriMesh};

use crate::backend::{LoopCommand, PointsUpdate, RATE_HZ, Reply, Sample, Steppable};
use crate::deform::{DeformChangeError, DeformError, DeformStatus, Deformer, SharedShape};
use crate::deformation::Deformation;
pub use crate::error::MAX_HAPTIC_TRIANGLES;
use crate::error::{MaterialChangeError, MeshError, SimError};
use crate::tick::{self, Tick};
use scene::{Material, Object, Scene, Space};

/// Height of the hand's start above the top of the object (m).
pub const START_CLEARANCE_M: f32 = 0.01;

/// The object the spatial hand feels: object `object` (of surfaces) of a scene through the
/// friction renderer, or a mesh through the penalty baseline. It owns the scene, and the
/// shell it renders owns its copy of the object's surfaces ([`Shell`]): nothing borrowed.
pub struct SpatialSession {
    scene: Option<Scene>,
    object: usize,
    /// The object in the shape it is rendered in (the scene's, or moved by control-point
    /// updates), for a NURBS session.
    shape: Option<Object>,
    material: FrictionMaterial,
    name: String,
    /// The object's shell and its renderer (none for a mesh session).
    rendering: Option<ShellRendering>,
}

/// The shell of a NURBS object and its renderer.
#[derive(Clone, Copy)]
struct ShellRendering {
    shell: Shell,
    renderer: FrictionRenderer<Shell>,
}

impl ShellRendering {
    /// Carries the renderer onto `shape`, object `index` with its control points moved: what
    /// rides on the surface moves with it, no search, no restart
    /// ([`FrictionRenderer::follow_reshape`]). On error nothing changed.
    fn follow(&mut self, shape: &Object, index: usize) -> Result<(), SimError> {
        let shell = shell_of(shape, index)?;
        self.renderer.follow_reshape(&self.shell, &shell);
        self.shell = shell;
        Ok(())
    }
}

impl std::fmt::Debug for SpatialSession {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SpatialSession")
            .field("name", &self.name())
            .field("object", &self.object())
            .finish_non_exhaustive()
    }
}

impl SpatialSession {
    /// Object `object` of `scene` (it must be of surfaces), its renderer started at `hip`.
    pub fn nurbs(scene: Scene, object: usize, hip: Vec3) -> Result<Self, SimError> {
        let count = scene.objects().len();
        let o = scene.object(object).ok_or(SimError::ObjectIndex {
            index: object,
            count,
        })?;
        let material = o.material().friction_material();
        let name = o.name().to_owned();
        let rendering = shell_rendering(&scene, object, material, hip)?;
        let shape = scene.object(object).cloned();
        Ok(SpatialSession {
            scene: Some(scene),
            object,
            shape,
            material,
            name,
            rendering: Some(rendering),
        })
    }

    /// A mesh object named `name` with `material` (the mesh itself goes to
    /// [`SpatialLoop::set_mesh`]).
    pub fn mesh(name: &str, material: FrictionMaterial) -> Self {
        SpatialSession {
            scene: None,
            object: 0,
            shape: None,
            material,
            name: name.to_owned(),
            rendering: None,
        }
    }

    /// The scene, for a NURBS session.
    pub fn scene(&self) -> Option<&Scene> {
        self.scene.as_ref()
    }

    /// The object's index in the scene.
    pub fn object(&self) -> usize {
        self.object
    }

    /// The object's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The material.
    pub fn material(&self) -> FrictionMaterial {
        self.material
    }

    /// Whether there is a NURBS object to render.
    pub fn has_nurbs(&self) -> bool {
        self.rendering.is_some()
    }

    /// Moves the object's control points as `update` says (whole patches of the rendered
    /// object), the renderer carried onto the new shell ([`ShellRendering::follow`]). Refused,
    /// nothing changed, for another object, part of a patch, or a shape the object refuses.
    fn apply_points(&mut self, update: &PointsUpdate<Vec3>) -> Result<(), DeformChangeError> {
        let index = self.object;
        if usize::from(update.object) != index {
            return Err(DeformChangeError::Update(format!(
                "object {}: the hand renders object {index}",
                update.object
            )));
        }
        let (Some(shape), Some(rendering)) = (&self.shape, &mut self.rendering) else {
            return Err(DeformChangeError::NoObject);
        };
        let mut next = None;
        for (patch, first, points) in &update.patches {
            if *first != 0 {
                return Err(DeformChangeError::Update(format!(
                    "object {index}, patch {patch}: points from {first} on; the hand takes \
                     whole patches"
                )));
            }
            let points: Vec<[f64; 3]> =
                points.iter().map(|p| p.to_array().map(f64::from)).collect();
            next = Some(
                next.as_ref()
                    .unwrap_or(shape)
                    .reshaped_patch(usize::from(*patch), &points)
                    .map_err(|error| DeformError::Shape { index, error })?,
            );
        }
        let Some(next) = next else {
            return Ok(());
        };
        rendering
            .follow(&next, index)
            .map_err(|e| DeformChangeError::Object(e.into()))?;
        self.shape = Some(next);
        Ok(())
    }

    /// Restarts the renderer at `hip` with `material`.
    fn restart(&mut self, hip: Vec3, material: FrictionMaterial) {
        if let Some(r) = &mut self.rendering {
            r.renderer = FrictionRenderer::new(&r.shell, material, hip);
        }
    }
}

/// The shell of `object`'s surfaces (object `index` of the scene).
fn shell_of(object: &Object, index: usize) -> Result<Shell, SimError> {
    let surfaces = object.surface_views().unwrap_or_default();
    Shell::new(&surfaces).map_err(|error| SimError::Shell { index, error })
}

fn shell_rendering(
    scene: &Scene,
    index: usize,
    material: FrictionMaterial,
    hip: Vec3,
) -> Result<ShellRendering, SimError> {
    let o = scene.object(index).ok_or(SimError::ObjectIndex {
        index,
        count: scene.objects().len(),
    })?;
    let surfaces = o.surface_views().ok_or_else(|| SimError::Space {
        trajectory: Space::Spatial,
        object: o.space(),
        index,
        name: o.name().to_owned(),
    })?;
    let shell = Shell::new(&surfaces).map_err(|error| SimError::Shell { index, error })?;
    let renderer = FrictionRenderer::new(&shell, material, hip);
    Ok(ShellRendering { shell, renderer })
}

/// Where the spatial hand starts over `scene`'s object `object`: above the middle of its
/// control points' box, [`START_CLEARANCE_M`] above their top (the surface lies in their convex
/// hull, so the hand starts in free space).
pub fn start_hip(points: impl IntoIterator<Item = Vec3>) -> Vec3 {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in points {
        lo = lo.min(p);
        hi = hi.max(p);
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return Vec3::new(0.0, 0.09, START_CLEARANCE_M);
    }
    let c = (lo + hi) * 0.5;
    Vec3::new(c.x, c.y, hi.z + START_CLEARANCE_M)
}

/// The control points of object `object` of `scene` (dehomogenised).
pub fn control_points(scene: &Scene, object: usize) -> Vec<Vec3> {
    use scene::Patch;
    let Some(o) = scene.object(object) else {
        return Vec::new();
    };
    o.patches()
        .iter()
        .flat_map(|p| match p {
            Patch::Surface(s) => s.points().to_vec(),
            Patch::Curve3(c) => c.points().to_vec(),
            Patch::Curve2(c) => c
                .points()
                .iter()
                .map(|h| nurbs::Vec4::new(h.x, h.y, 0.0, h.z))
                .collect(),
        })
        .map(|h| Vec3::new(h.x / h.w, h.y / h.w, h.z / h.w))
        .collect()
}

/// The spatial loop: the session, the mesh rendered instead of the NURBS object when one is
/// set, the HIP and the hand's command.
#[derive(Debug)]
pub struct SpatialLoop {
    session: SpatialSession,
    mesh: Option<TriMesh>,
    material: FrictionMaterial,
    /// The hand: the HIP is its target.
    hand: VirtualHand<Vec3>,
    previous_hip: Vec3,
    forces_enabled: bool,
    tick: u64,
    period_s: f32,
    deformation: Deformation<Vec3>,
    last_error: Option<String>,
    /// The (mode, cause) the last tick reported ([`SwitchCause::or_carried`]).
    reported: (Mode, SwitchCause),
}

/// Checks that the loop can render `mesh` in a tick.
pub fn check_mesh(mesh: &TriMesh) -> Result<(), MeshError> {
    let triangles = mesh.triangles().len();
    if triangles == 0 {
        Err(MeshError::Empty)
    } else if triangles > MAX_HAPTIC_TRIANGLES {
        Err(MeshError::TooManyTriangles { triangles })
    } else {
        Ok(())
    }
}

impl SpatialLoop {
    /// A loop on `session` with the HIP at rest at `hip`, forces on.
    pub fn new(session: SpatialSession, hip: Vec3) -> Self {
        let material = session.material();
        SpatialLoop {
            session,
            mesh: None,
            material,
            hand: VirtualHand::at(hip),
            previous_hip: hip,
            forces_enabled: true,
            tick: 0,
            period_s: (1.0 / RATE_HZ) as f32,
            // The loop's rate is the dynamics' (crate::deform::DYNAMICS_RATE_HZ): every step's
            // shape goes to the renderer.
            deformation: Deformation::new(1),
            last_error: None,
            reported: (Mode::Free, SwitchCause::None),
        }
    }

    /// One tick: the HIP (the hand's target, [`VirtualHand`]) moves towards the hand's command at up to
    /// [`MAX_HAND_SPEED_M_PER_S`](crate::planar::MAX_HAND_SPEED_M_PER_S) (the tracker follows a hand, not a teleport), its velocity
    /// is the backward difference, and the mesh (when set) or the NURBS object renders the
    /// force. With forces off the contact is still shown, the force is zero. A deforming
    /// object is pushed by the tick's force (reversed), steps (1 ms) and takes its new shape,
    /// the renderer carried onto it; the tick records its displacement at the CP
    /// ([`Tick::deform`]).
    pub fn step(&mut self) -> Tick {
        self.previous_hip = self.hand.target();
        let hip = self.hand.step(self.period_s);
        let velocity = (hip - self.previous_hip) / self.period_s;
        let t_s = self.tick as f64 / RATE_HZ;
        self.tick += 1;
        let period_s = self.period_s;
        let mut tick = match (&self.mesh, self.session.rendering.as_mut()) {
            (Some(mesh), _) => mesh_tick(mesh, &self.material, t_s, hip, velocity),
            (None, Some(r)) => {
                tick::render_tick(&mut r.renderer, &r.shell, t_s, hip, velocity, period_s)
            }
            (None, None) => free_tick(t_s, hip, velocity),
        };
        // The mesh baseline names no cause, nor does a renderer restarted by a material
        // change or the switch between the mesh and the NURBS object.
        tick.cause = tick.cause.or_carried(tick.mode, self.reported);
        self.reported = (tick.mode, tick.cause);
        if !self.forces_enabled {
            tick.force = Vec3::ZERO;
        }
        self.deformation.feed(&mut tick);
        self.step_object();
        tick
    }

    /// The loop's time (s).
    fn time_s(&self) -> f64 {
        self.tick as f64 / RATE_HZ
    }

    /// One dynamics step of a deforming object, its renderer carried onto the new shape, and
    /// the shape published when it is due. A step that fails makes the object rigid again and
    /// [`SpatialLoop::last_error`] says why.
    fn step_object(&mut self) {
        let t_s = self.time_s();
        let session = &mut self.session;
        if let Some(e) = self
            .deformation
            .step(1.0 / RATE_HZ, t_s, &mut |u| session.apply_points(u))
        {
            self.last_error = Some(e);
        }
    }

    /// Makes the NURBS object deformable (`true`) from the next tick, from its rest shape, or
    /// rigid at its rest shape again (`false`); the renderer is carried onto the shape either
    /// way (no search, no restart). Asking for what already is changes nothing. The shape is
    /// published in [`SpatialLoop::shared_shape`] while it deforms. Refused, with nothing
    /// changed, while a mesh is felt, without a NURBS object, or when it is rigid (no
    /// `"dynamics"` block).
    pub fn set_deforming(&mut self, on: bool) -> Result<DeformStatus, DeformChangeError> {
        let t_s = self.time_s();
        if on {
            let index = self.session.object();
            let object = u8::try_from(index).map_err(|_| {
                DeformChangeError::Update(format!(
                    "object {index}: an update names objects 0 to {}",
                    u8::MAX
                ))
            })?;
            let (session, mesh, material) = (&self.session, self.mesh.is_some(), self.material);
            self.deformation.start(
                || {
                    if mesh {
                        return Err(DeformChangeError::Mesh);
                    }
                    rest_deformer(session, material)
                },
                object,
                t_s,
            )?;
        } else {
            self.stop_deforming()?;
        }
        Ok(self.deformation.status())
    }

    /// Whether the object deforms.
    pub fn deforming(&self) -> bool {
        self.deformation.deforming()
    }

    /// The deforming object's dynamics, while it deforms.
    pub fn deformer(&self) -> Option<&Deformer> {
        self.deformation.deformer()
    }

    /// Where the loop publishes the deforming object's shape (the same for the loop's life).
    pub fn shared_shape(&self) -> &Arc<SharedShape> {
        self.deformation.shared_shape()
    }

    /// Why the object stopped deforming by itself, if it did.
    pub fn last_error(&self) -> Option<&str> {
        self.last_error.as_deref()
    }

    /// The renderer back on the rest shape.
    fn stop_deforming(&mut self) -> Result<(), DeformChangeError> {
        let t_s = self.time_s();
        let session = &mut self.session;
        self.deformation.stop(t_s, &mut |u| session.apply_points(u))
    }

    /// Commands the hand (m, device frame) as fast as it goes; a non-finite target is ignored.
    pub fn set_hand_target(&mut self, target: Vec3) {
        self.hand.command(target);
    }

    /// Commands the hand to `target`, getting there in `over_s` at a steady speed
    /// ([`VirtualHand::glide`]).
    pub fn glide_hand(&mut self, target: Vec3, over_s: f32) {
        self.hand.glide(target, over_s);
    }

    /// The HIP.
    pub fn hip(&self) -> Vec3 {
        self.hand.target()
    }

    /// The hand's command.
    pub fn hand_target(&self) -> Vec3 {
        self.hand.command_point()
    }

    /// Renders `mesh` (the penalty baseline) from the next tick, or, with `None`, the NURBS
    /// object again (its renderer restarted at the HIP). A mesh the loop cannot scan in a
    /// tick is refused and the running rendering stays.
    pub fn set_mesh(&mut self, mesh: Option<TriMesh>) -> Result<(), MeshError> {
        if let Some(m) = &mesh {
            check_mesh(m)?;
            // The mesh is the rest shape's tessellation: a deforming object is rigid again.
            if let Err(e) = self.stop_deforming() {
                self.last_error = Some(e.to_string());
            }
        } else {
            self.session.restart(self.hand.target(), self.material);
        }
        self.mesh = mesh;
        Ok(())
    }

    /// Whether a mesh is rendered (rather than the NURBS object).
    pub fn renders_mesh(&self) -> bool {
        self.mesh.is_some()
    }

    /// Validates `material` and renders with it from the next tick (the renderer restarts; a
    /// deforming object starts again from rest, its contact as stiff as the material).
    pub fn set_material(
        &mut self,
        material: FrictionMaterial,
    ) -> Result<FrictionMaterial, MaterialChangeError> {
        Material::from_friction(material)?;
        self.material = material;
        if self.deformation.deforming() {
            let t_s = self.time_s();
            let rest = rest_deformer(&self.session, material);
            let session = &mut self.session;
            let restarted = self
                .deformation
                .restart(|| rest, t_s, &mut |u| session.apply_points(u));
            if let Err(e) = restarted {
                self.last_error = Some(format!("{e}; the object is rigid again"));
            }
        }
        // On the rest shape: the renderer starts afresh at the HIP.
        self.session.restart(self.hand.target(), material);
        Ok(material)
    }

    /// The material rendered.
    pub fn material(&self) -> FrictionMaterial {
        self.material
    }

    /// Renders another object from the next tick; the HIP stays where it is. A deforming
    /// object is dropped with the old session: the new one is rigid, at rest, until it is
    /// asked to deform.
    pub fn swap(&mut self, mut session: SpatialSession) {
        self.deformation.forget(self.time_s());
        self.material = session.material();
        session.restart(self.hand.target(), self.material);
        self.session = session;
        self.mesh = None;
    }

    /// The session.
    pub fn session(&self) -> &SpatialSession {
        &self.session
    }

    /// Enables or disables the forces.
    pub fn set_forces_enabled(&mut self, enabled: bool) {
        self.forces_enabled = enabled;
    }

    /// Whether forces are enabled.
    pub fn forces_enabled(&self) -> bool {
        self.forces_enabled
    }

    /// Ticks so far.
    pub fn ticks(&self) -> u64 {
        self.tick
    }
}

/// The NURBS object's dynamics at rest, its contact as stiff as `material`.
fn rest_deformer(
    session: &SpatialSession,
    material: FrictionMaterial,
) -> Result<Deformer, DeformChangeError> {
    let scene = session.scene().ok_or(DeformChangeError::NoObject)?;
    if !session.has_nurbs() {
        return Err(DeformChangeError::NoObject);
    }
    let mut deformer = Deformer::new(scene, session.object())?;
    deformer.set_contact_stiffness(material.stiffness_n_per_m);
    Ok(deformer)
}

/// One tick of the polygonal baseline: the closest point over the triangles, the depth
/// `(point − HIP)·n` along the closest triangle's face normal `n`, and the penalty of
/// [`Contact::normal_force`] (`K·depth − b·v·n`, never pulling), without friction: in contact
/// it reports slip at μ = 0, the CP and the GO are the closest point, `cp_patch` the
/// triangle's index and `cp_params` the surface parameters interpolated there (a tessellated
/// NURBS surface; zero for an imported mesh).
pub fn mesh_tick(
    mesh: &TriMesh,
    material: &FrictionMaterial,
    t_s: f64,
    hip: Vec3,
    hip_velocity: Vec3,
) -> Tick {
    let Some(hit) = mesh.closest(hip) else {
        return free_tick(t_s, hip, hip_velocity);
    };
    let depth = (hit.point - hip).dot(hit.normal);
    let contact = Contact {
        feature: Feature::Patch(0),
        patch: 0,
        params: hit.t,
        point: hit.point,
        normal: hit.normal,
        depth,
        psi: [0.0; 2],
        inside: depth > 0.0,
    };
    let penalty = Penalty {
        stiffness_n_per_m: material.stiffness_n_per_m,
        damping_ns_per_m: material.damping_ns_per_m,
    };
    let normal_force_n = contact.normal_force(&penalty, hip_velocity);
    let touching = depth > 0.0;
    Tick {
        cp: hit.point,
        go: hit.point,
        patch: touching.then_some(0),
        mode: if touching { Mode::Slip } else { Mode::Free },
        depth_m: depth,
        normal_force_n,
        normal: hit.normal,
        force: hit.normal * normal_force_n,
        cp_patch: hit.triangle,
        cp_param: hit.t[0],
        cp_params: hit.t,
        go_patch: hit.triangle,
        go_param: hit.t[0],
        go_params: hit.t,
        ..free_tick(t_s, hip, hip_velocity)
    }
}

/// A tick with nothing in contact at `hip`.
fn free_tick(t_s: f64, hip: Vec3, hip_velocity: Vec3) -> Tick {
    Tick {
        hip,
        hip_velocity,
        cp: hip,
        go: hip,
        ..Tick::idle(t_s)
    }
}

impl Steppable for SpatialLoop {
    type Session = SpatialSession;

    /// Every command: the hand, the material, a session, a mesh ([`Reply::Mesh`]: refused when
    /// [`check_mesh`] refuses it, the UI checks before sending), the forces, deforming the
    /// object ([`Reply::Deform`]); clearing faults
    /// answers that none are latched (the spatial hand has no safety layer); calibrating is
    /// [`Reply::Unsupported`] (there is no arm).
    fn apply(&mut self, command: LoopCommand<SpatialSession>) -> Option<Reply> {
        match command {
            LoopCommand::HandTarget { to, over_s } => {
                self.glide_hand(to, over_s);
                None
            }
            LoopCommand::SetMaterial(m) => Some(Reply::Material(self.set_material(m))),
            LoopCommand::Swap(session) => {
                self.swap(*session);
                Some(Reply::Swapped)
            }
            LoopCommand::Mesh(mesh) => Some(Reply::Mesh(self.set_mesh(mesh.map(|m| *m)))),
            LoopCommand::Forces(on) => {
                self.set_forces_enabled(on);
                None
            }
            LoopCommand::ClearFaults => Some(Reply::FaultsCleared(device::safety::Faults::empty())),
            LoopCommand::Deform(on) => Some(Reply::Deform(self.set_deforming(on))),
            LoopCommand::Calibrate | LoopCommand::Hand(_) | LoopCommand::ScenePoints(_) => {
                Some(Reply::Unsupported(command.name()))
            }
        }
    }

    /// The sample's `hand_target` is the hand's command projected on the plane (x, y); the
    /// 3-D command is the UI's own (the GUI's `SpatialState::target`).
    fn step_sample(&mut self) -> Sample {
        let tick = self.step();
        let c = self.hand_target();
        Sample {
            tick,
            hand_target: Vec2::new(c.x, c.y),
            period_us: None,
            forces_enabled: self.forces_enabled,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use scene::{Object, Patch, tessellate_object};

    /// The plane z = 0 over x ∈ [−0.03, 0.03], y ∈ [0.06, 0.12] (normal +z), K = 1000 N/m,
    /// no damping, μ_s = 0.7, μ_d = 0.5.
    fn floor() -> Scene {
        let s = nurbs::construct::bilinear(
            Vec3::new(-0.03, 0.06, 0.0),
            Vec3::new(0.03, 0.06, 0.0),
            Vec3::new(-0.03, 0.12, 0.0),
            Vec3::new(0.03, 0.12, 0.0),
        )
        .expect("plane");
        let material = Material::new(1000.0, 0.0, 0.7, 0.5).expect("material");
        let o = Object::new("floor", material, vec![Patch::Surface(s)]).expect("object");
        Scene::new(vec![o]).expect("scene")
    }

    /// Pressing the hand d = 2 mm straight down into the plane: F_N = K·d = 2 N along +z.
    /// The HIP is at rest (v = 0, so the damping term is zero anyway) and the plane's depth is
    /// the HIP's height exactly, so the only error is f32 rounding of z ≈ −0.002 (ulp 2.3e-10
    /// m, 2.3e-7 N at K = 1000 N/m): 1e-5 N allows forty ulps. Straight down, the GO stays
    /// above the HIP: no friction.
    #[test]
    fn pressing_d_into_a_plane_gives_k_d() {
        let scene = floor();
        let start = start_hip(control_points(&scene, 0));
        assert!((start - Vec3::new(0.0, 0.09, START_CLEARANCE_M)).length() < 1e-7);
        let session = SpatialSession::nurbs(scene, 0, start).expect("session");
        let mut spatial = SpatialLoop::new(session, start);
        let pressed = Vec3::new(start.x, start.y, -0.002);
        spatial.set_hand_target(pressed);
        // 12 mm at 0.3 m/s: 40 ticks; 100 more at rest.
        let ticks: Vec<Tick> = (0..140).map(|_| spatial.step()).collect();
        let k = ticks[ticks.len() - 1];
        assert_eq!(k.hip, pressed);
        assert_ne!(k.mode, Mode::Free);
        assert!((k.normal_force_n - 2.0).abs() < 1e-5, "{k:?}");
        assert!(
            (k.force - Vec3::new(0.0, 0.0, 2.0)).length() < 1e-5,
            "{k:?}"
        );
        assert!(k.friction.length() < 1e-5, "{k:?}");
        // Free until the HIP crosses z = 0 (tick 33 puts it at 10 mm − 34 × 0.3 mm < 0).
        assert!(ticks[..30].iter().all(|t| t.mode == Mode::Free));

        // The tessellated plane (two triangles, exact): the same K·d, by the baseline.
        let scene = floor();
        let mesh = tessellate_object(&scene, 0, 1e-4).expect("mesh");
        assert_eq!(mesh.triangles().len(), 2);
        spatial.set_mesh(Some(mesh)).expect("mesh taken");
        let k = spatial.step();
        assert_eq!((k.mode, k.mu), (Mode::Slip, 0.0));
        assert!(
            (k.force - Vec3::new(0.0, 0.0, 2.0)).length() < 1e-5,
            "{k:?}"
        );
    }

    /// Every switch names its cause, also where no renderer names one: the mesh baseline
    /// enters contact by `contact` and leaves it by `released`, and a contact ended by a
    /// material change (the renderer restarts) is `released` too, never `none`.
    #[test]
    fn switches_without_a_renderer_of_their_own_name_their_cause() {
        let scene = floor();
        let start = start_hip(control_points(&scene, 0));
        let mesh = tessellate_object(&scene, 0, 1e-4).expect("mesh");
        let session = SpatialSession::nurbs(scene, 0, start).expect("session");
        let mut spatial = SpatialLoop::new(session, start);
        let pressed = Vec3::new(start.x, start.y, -0.002);
        let mut ticks: Vec<Tick> = Vec::new();
        let mut run = |spatial: &mut SpatialLoop, n: usize| {
            let from = ticks.len();
            ticks.extend((0..n).map(|_| spatial.step()));
            // (from, to, cause) of each switch in these ticks (and at their first).
            ticks[from.max(1) - 1..]
                .windows(2)
                .filter(|w| w[0].mode != w[1].mode)
                .map(|w| (w[0].mode, w[1].mode, w[1].cause))
                .collect::<Vec<_>>()
        };
        // The NURBS renderer stuck, its material changed (it restarts): free by `released`
        // if it shows free at all, stuck again by `contact`.
        spatial.set_hand_target(pressed);
        run(&mut spatial, 140);
        let material = FrictionMaterial {
            mu_dynamic: 0.3,
            ..spatial.material
        };
        assert!(spatial.set_material(material).is_ok());
        for (from, to, cause) in run(&mut spatial, 20) {
            let expected = if to == Mode::Free {
                SwitchCause::Released
            } else {
                SwitchCause::Contact
            };
            assert_eq!(cause, expected, "{from:?} -> {to:?}");
        }
        // The mesh: out, in, out.
        spatial.set_mesh(Some(mesh)).expect("mesh taken");
        spatial.set_hand_target(start);
        let mut seen = run(&mut spatial, 100);
        spatial.set_hand_target(pressed);
        seen.extend(run(&mut spatial, 100));
        spatial.set_hand_target(start);
        seen.extend(run(&mut spatial, 100));
        let last: Vec<(Mode, SwitchCause)> = seen.iter().map(|s| (s.1, s.2)).collect();
        assert!(
            last.ends_with(&[
                (Mode::Free, SwitchCause::Released),
                (Mode::Slip, SwitchCause::Contact),
                (Mode::Free, SwitchCause::Released),
            ]),
            "{seen:?}"
        );
    }

    /// What a tick of the baseline costs per triangle, and a NURBS tick on the same object
    /// (`cargo test -p viewer --lib measure_tick_costs -- --ignored --nocapture`; timing, so
    /// not run by default and not asserted).
    #[test]
    #[ignore]
    fn measure_tick_costs() {
        let scene = Scene::from_json_str(include_str!("../../../scenes/thesis-3d.json"))
            .unwrap_or_else(|e| panic!("{e}"));
        let start = start_hip(control_points(&scene, 0));
        let pressed = Vec3::new(0.0, 0.09, 0.00475);
        for tol in [1e-3, 2e-4, 5e-5] {
            let mesh = tessellate_object(&scene, 0, tol).expect("mesh");
            let n = mesh.triangles().len();
            let m = FrictionMaterial::default();
            let runs = 2000;
            let t = std::time::Instant::now();
            for _ in 0..runs {
                std::hint::black_box(mesh_tick(&mesh, &m, 0.0, pressed, Vec3::ZERO));
            }
            let per_tick = t.elapsed().as_secs_f64() / runs as f64;
            println!(
                "mesh at {tol} m: {n} triangles, {:.1} µs per tick, {:.1} ns per triangle",
                per_tick * 1e6,
                per_tick * 1e9 / n as f64
            );
        }
        let session = SpatialSession::nurbs(scene, 0, start).expect("session");
        let mut spatial = SpatialLoop::new(session, start);
        spatial.set_hand_target(pressed);
        for _ in 0..200 {
            spatial.step();
        }
        let runs = 20_000;
        let t = std::time::Instant::now();
        for _ in 0..runs {
            std::hint::black_box(spatial.step());
        }
        println!(
            "NURBS (friction renderer on the shell): {:.2} µs per tick",
            t.elapsed().as_secs_f64() / runs as f64 * 1e6
        );
    }

    /// The spatial loop on its own thread (the planar loop's `LoopThread`): it ticks, takes
    /// the hand's command and a material, and reports K·d once pressed (polled for up to 10 s
    /// of wall time; nothing here is timed).
    #[test]
    fn the_spatial_loop_runs_on_the_loop_thread() {
        use std::time::{Duration, Instant};
        let scene = floor();
        let start = start_hip(control_points(&scene, 0));
        let session = SpatialSession::nurbs(scene, 0, start).expect("session");
        let thread = crate::backend::LoopThread::spawn(SpatialLoop::new(session, start), None)
            .expect("spawn");
        let softer = FrictionMaterial {
            stiffness_n_per_m: 500.0,
            ..FrictionMaterial::default()
        };
        assert!(thread.send(LoopCommand::SetMaterial(softer)));
        assert!(thread.send(LoopCommand::hand_to(Vec3::new(start.x, start.y, -0.002))));
        let waited = Instant::now();
        let (mut last, mut replies) = (None, Vec::new());
        while waited.elapsed() < Duration::from_secs(10) {
            thread.drain_samples(|s| last = Some(s));
            replies.extend(thread.drain_replies());
            if last.is_some_and(|s: Sample| (s.tick.normal_force_n - 1.0).abs() < 1e-5) {
                break;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        let s = last.expect("samples");
        // K·d with the new K: 500 N/m × 2 mm.
        assert!((s.tick.normal_force_n - 1.0).abs() < 1e-5, "{s:?}");
        assert!(s.period_us.is_some());
        assert!(matches!(replies.first(), Some(Reply::Material(Ok(m))) if *m == softer));
    }

    /// A mesh beyond what a tick scans is refused and the NURBS rendering stays.
    #[test]
    fn a_too_fine_mesh_is_refused() {
        let scene = floor();
        let start = start_hip(control_points(&scene, 0));
        let session = SpatialSession::nurbs(scene, 0, start).expect("session");
        let mut spatial = SpatialLoop::new(session, start);
        let mut triangles = Vec::new();
        let mut vertices = Vec::new();
        for i in 0..=MAX_HAPTIC_TRIANGLES as u32 {
            let x = i as f32 * 1e-3;
            vertices.extend([
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 1e-3, 0.0, 0.0),
                Vec3::new(x, 1e-3, 0.0),
            ]);
            triangles.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        let mesh = TriMesh::from_triangles(vertices, Vec::new(), &triangles);
        let e = spatial.set_mesh(Some(mesh)).expect_err("refused");
        assert_eq!(
            e,
            MeshError::TooManyTriangles {
                triangles: MAX_HAPTIC_TRIANGLES + 1
            }
        );
        assert!(!spatial.renders_mesh());
    }

    /// Through the app's backend, stepped: clearing faults answers that none are latched,
    /// calibrating is unsupported (no arm), a mesh too big for a tick is refused by its reply
    /// and the NURBS object stays.
    #[test]
    fn the_spatial_loop_answers_every_command() {
        use crate::backend::{Backend, Sent};
        use device::safety::Faults;
        let scene = floor();
        let start = start_hip(control_points(&scene, 0));
        let session = SpatialSession::nurbs(scene, 0, start).expect("session");
        let mut backend =
            Backend::start(SpatialLoop::new(session, start), false, None).expect("start");
        let sent = backend.command(LoopCommand::ClearFaults);
        assert!(
            matches!(sent, Sent::Applied(Some(Reply::FaultsCleared(f))) if f == Faults::empty())
        );
        let sent = backend.command(LoopCommand::Calibrate);
        assert!(matches!(
            sent,
            Sent::Applied(Some(Reply::Unsupported("the calibration")))
        ));
        let empty = TriMesh::from_triangles(Vec::new(), Vec::new(), &[]);
        let sent = backend.command(LoopCommand::Mesh(Some(Box::new(empty))));
        assert!(matches!(
            sent,
            Sent::Applied(Some(Reply::Mesh(Err(MeshError::Empty))))
        ));
        assert!(backend.stepped().is_some_and(|s| !s.renders_mesh()));
        assert_eq!(backend.step(2).len(), 2);
    }
}
