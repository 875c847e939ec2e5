//! The app's state for a scene without planar objects: the 3-D view's geometry, the spatial
//! hand's loop ([`host::spatial`]) and the choice between feeling the NURBS object and its
//! tessellation (the polygonal baseline) at a chordal tolerance, and the OBJ export.

use std::path::Path;

use friction::FrictionMaterial;
use nurbs::Vec3;
use tracker::TriMesh;

use super::view3d::geometry::Scene3d;
use host::backend::{Backend, LoopCommand, Reply, Sample};
use host::runlog::RecordTx;
use host::spatial::{self, SpatialLoop, SpatialSession, check_mesh};
use scene::mesh::{self, ObjMesh};
use scene::{Scene, Space, tessellate_object};

/// The chordal tolerance the mesh representation starts with (m).
pub const DEFAULT_TOLERANCE_M: f32 = 1e-3;

/// Reads the OBJ file at `path` and checks that the loop can feel it ([`check_mesh`]): what
/// `viewer gui --mesh` checks before the window opens and the app's *Open* does, one message
/// naming the file (and the line) for every refusal.
pub fn load_mesh(path: &Path) -> anyhow::Result<ObjMesh> {
    let obj = mesh::load_obj(path)?;
    check_mesh(&obj.mesh).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    Ok(obj)
}

/// The 3-D side of the app.
#[derive(Debug)]
pub struct SpatialState {
    /// The spatial hand's loop; `None` when the scene has nothing to feel (only curves).
    backend: Option<Backend<SpatialLoop>>,
    /// The NURBS scene and the index of the object felt (none for an opened mesh).
    source: Option<(Scene, usize)>,
    /// The material the loop was last given.
    material: FrictionMaterial,
    /// What the 3-D view draws.
    pub view: Scene3d,
    /// The hand's command (m).
    pub target: Vec3,
    /// Where the hand started (m).
    pub start: Vec3,
    /// Whether the hand feels the object's tessellation rather than the NURBS object.
    pub render_mesh: bool,
    /// The chordal tolerance of that tessellation (m).
    pub tolerance_m: f32,
    /// Triangles of the mesh felt, when one is.
    pub mesh_triangles: Option<usize>,
    /// What the last action said (an error, or where an export went).
    pub message: Option<String>,
    /// The path typed into the export field.
    pub export_path: String,
}

impl SpatialState {
    /// The 3-D state of `scene` (labelled `label`): the spatial hand on its object `object`
    /// when that one has surfaces, else on its first object of surfaces (none when it has
    /// none: only curves are drawn), threaded or stepped.
    pub fn of_scene(
        label: &str,
        scene: &Scene,
        object: Option<usize>,
        threaded: bool,
        record: Option<RecordTx>,
    ) -> anyhow::Result<Self> {
        let object = object
            .filter(|&i| scene.object(i).is_some_and(can_be_felt))
            .or_else(|| scene.objects().iter().position(can_be_felt));
        let view = Scene3d::new(label, scene, object);
        let (backend, start) = match object {
            Some(i) => {
                let start = spatial::start_hip(spatial::control_points(scene, i));
                let session = SpatialSession::nurbs(scene.clone(), i, start)?;
                let spatial = SpatialLoop::new(session, start);
                (Some(Backend::start(spatial, threaded, record)?), start)
            }
            None => (None, spatial::start_hip(view_corners(&view))),
        };
        let material = object
            .and_then(|i| scene.object(i))
            .map(|o| o.material().friction_material())
            .unwrap_or_default();
        Ok(SpatialState {
            backend,
            material,
            source: object.map(|i| (scene.clone(), i)),
            view,
            target: start,
            start,
            render_mesh: false,
            tolerance_m: DEFAULT_TOLERANCE_M,
            mesh_triangles: None,
            message: None,
            export_path: String::new(),
        })
    }

    /// The 3-D state of an opened mesh, felt through the polygonal baseline with `material`.
    pub fn of_mesh(
        label: &str,
        obj: ObjMesh,
        material: FrictionMaterial,
        threaded: bool,
        record: Option<RecordTx>,
    ) -> anyhow::Result<Self> {
        check_mesh(&obj.mesh).map_err(|e| anyhow::anyhow!("{label}: {e}"))?;
        let view = Scene3d::of_mesh(label, &obj.name, &obj.mesh);
        let start = spatial::start_hip(obj.mesh.vertices().iter().copied());
        let triangles = obj.mesh.triangles().len();
        let mut spatial = SpatialLoop::new(SpatialSession::mesh(&obj.name, material), start);
        spatial
            .set_mesh(Some(obj.mesh))
            .map_err(|e| anyhow::anyhow!("{label}: {e}"))?;
        Ok(SpatialState {
            backend: Some(Backend::start(spatial, threaded, record)?),
            material,
            source: None,
            view,
            target: start,
            start,
            render_mesh: true,
            tolerance_m: DEFAULT_TOLERANCE_M,
            mesh_triangles: Some(triangles),
            message: None,
            export_path: String::new(),
        })
    }

    /// The index of the scene's object the spatial hand feels (none for an opened mesh or a
    /// scene of curves only).
    pub fn object(&self) -> Option<usize> {
        self.source.as_ref().map(|(_, i)| *i)
    }

    /// Whether this is an opened OBJ mesh (felt, with no NURBS scene behind it).
    pub fn is_opened_mesh(&self) -> bool {
        self.source.is_none() && self.backend.is_some()
    }

    /// Whether the object felt is a NURBS object that can be tessellated (and exported).
    pub fn can_tessellate(&self) -> bool {
        self.source.is_some()
    }

    /// The material of the object felt, if there is one.
    pub fn material(&self) -> Option<FrictionMaterial> {
        self.backend.as_ref()?;
        Some(self.material)
    }

    /// Whether there is a loop (an object of surfaces or a mesh to feel).
    pub fn has_loop(&self) -> bool {
        self.backend.is_some()
    }

    fn command(&mut self, command: LoopCommand<SpatialSession>) -> Option<Reply> {
        let sent = self.backend.as_mut()?.command(command);
        if let Some(why) = sent.refusal() {
            self.message = Some(format!("the spatial loop dropped a command: {why}"));
        }
        sent.reply()
    }

    /// Moves the hand (m) as fast as it goes; non-finite targets are ignored.
    pub fn set_target(&mut self, target: Vec3) {
        self.glide_to(target, 0.0);
    }

    /// Moves the hand (m), getting there `over_s` seconds from now at a steady speed: the
    /// pointer's own pace ([`LoopCommand::HandTarget`]); non-finite targets are ignored.
    pub fn glide_to(&mut self, target: Vec3, over_s: f32) {
        if target.is_finite() {
            self.target = target;
            self.command(LoopCommand::HandTarget { to: target, over_s });
        }
    }

    /// Enables or disables the forces.
    pub fn set_forces(&mut self, on: bool) {
        self.command(LoopCommand::Forces(on));
    }

    /// Makes the NURBS object deformable or rigid again ([`LoopCommand::Deform`]); the reply,
    /// for a stepped loop.
    pub fn deform(&mut self, on: bool) -> Option<Reply> {
        self.command(LoopCommand::Deform(on))
    }

    /// Sets the material (validated by the loop); the reply, for a stepped loop.
    pub fn set_material(&mut self, material: FrictionMaterial) -> Option<Reply> {
        let reply = self.command(LoopCommand::SetMaterial(material));
        if let Some(Reply::Material(Ok(m))) = &reply {
            self.material = *m;
        }
        reply
    }

    /// The NURBS object's tessellation at the current tolerance.
    pub fn tessellation(&self) -> Option<TriMesh> {
        let (scene, object) = self.source.as_ref()?;
        tessellate_object(scene, *object, self.tolerance_m)
    }

    /// Feels the tessellation at the current tolerance (`true`) or the NURBS object. A mesh
    /// the loop cannot scan in a tick is refused with a message and the NURBS object stays.
    /// Nothing changes for an opened mesh (there is no NURBS object).
    pub fn set_render_mesh(&mut self, on: bool) {
        let Some(object) = self.source.as_ref().map(|(_, i)| *i) else {
            return;
        };
        if !on {
            self.render_mesh = false;
            self.mesh_triangles = None;
            self.view.set_faceted(None);
            self.message = None;
            self.command(LoopCommand::Mesh(None));
            return;
        }
        let Some(mesh) = self.tessellation() else {
            return;
        };
        if let Err(e) = check_mesh(&mesh) {
            self.message = Some(format!("{e}; the hand still feels the NURBS surface"));
            return;
        }
        self.view.set_faceted(Some((object, &mesh)));
        self.render_mesh = true;
        self.mesh_triangles = Some(mesh.triangles().len());
        self.message = None;
        self.command(LoopCommand::Mesh(Some(Box::new(mesh))));
    }

    /// Sets the chordal tolerance (m, clamped to 0.01–10 mm); a mesh being felt is
    /// re-tessellated.
    pub fn set_tolerance(&mut self, tol_m: f32) {
        if tol_m.is_finite() {
            self.tolerance_m = tol_m.clamp(1e-5, 1e-2);
        }
        if self.render_mesh && self.can_tessellate() {
            self.set_render_mesh(true);
        }
    }

    /// Writes the NURBS object's tessellation at the current tolerance to `path` as OBJ.
    pub fn export_obj(&mut self, path: &Path) -> std::io::Result<usize> {
        let Some(mesh) = self.tessellation() else {
            return Err(std::io::Error::other("no NURBS object to export"));
        };
        let name = self.view.rendered_name.clone().unwrap_or_default();
        let comment = format!(
            "{name} from {}, tessellated to a chordal tolerance of {} m (vt: surface u v)",
            self.view.label, self.tolerance_m
        );
        mesh::save_obj(&mesh, &name, &comment, path)?;
        Ok(mesh.triangles().len())
    }

    /// [`SpatialState::export_obj`] to the path typed in the export field; the message says
    /// what happened.
    pub fn export_obj_to_path(&mut self) {
        let path = self.export_path.trim().to_owned();
        if path.is_empty() {
            self.message = Some("type the path of the OBJ file to write".into());
            return;
        }
        self.message = Some(match self.export_obj(Path::new(&path)) {
            Ok(n) => format!("wrote {path} ({n} triangles)"),
            Err(e) => format!("export failed: {e}"),
        });
    }

    /// Runs `n` ticks of a stepped loop; their samples.
    pub fn step(&mut self, n: usize) -> Vec<Sample> {
        self.backend.as_mut().map_or_else(Vec::new, |b| b.step(n))
    }

    /// What a threaded loop sent since the last call.
    pub fn drain(&self) -> (Vec<Sample>, Vec<Reply>) {
        self.backend
            .as_ref()
            .map_or_else(|| (Vec::new(), Vec::new()), Backend::drain)
    }

    /// The loop, when stepped (tests).
    pub fn stepped(&self) -> Option<&SpatialLoop> {
        self.backend.as_ref().and_then(Backend::stepped)
    }

    /// Samples and commands the spatial loop's channels dropped.
    pub fn dropped(&self) -> (u64, u64) {
        use std::sync::atomic::Ordering;
        self.backend
            .as_ref()
            .and_then(Backend::counters)
            .map_or((0, 0), |c| {
                (
                    c.dropped_samples.load(Ordering::Relaxed),
                    c.dropped_commands.load(Ordering::Relaxed),
                )
            })
    }
}

fn view_corners(view: &Scene3d) -> Vec<Vec3> {
    let (lo, hi) = view.bounds;
    vec![lo, hi]
}

/// Whether the spatial hand can feel `object`: a spatial object with surfaces (the spatial
/// loop feels surfaces; spatial curves are drawn only).
pub fn can_be_felt(object: &scene::Object) -> bool {
    object.space() == Space::Spatial && object.surface_views().is_some_and(|s| !s.is_empty())
}
