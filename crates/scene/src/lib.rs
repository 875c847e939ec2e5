#![doc = include_str!("../README.md")]
#![warn(missing_docs)]

pub mod bundled;
pub mod edit;
pub mod json;
pub mod mesh;
pub mod regions;

pub use bundled::Bundled;
pub use mesh::tessellate_object;

use std::path::PathBuf;

use friction::FrictionMaterial;
/// An invalid material value ([`FrictionMaterial::validate`], the one set of rules the device
/// applies to an uploaded material too). The message starts with `material.<field>`.
pub use friction::MaterialError;
use nurbs::{Curve, CurveBuf, NurbsError, Point, Surface, SurfaceBuf, Vec2, Vec3};
use tracker::{Chain, ChainError, Shell, ShellError};

use deform::Shape;
pub use deform::{Body, DynamicsError, Fixed, Params};

/// The value of the `format` field this module reads.
pub const FORMAT: &str = "scene/1";

/// A validated scene: at least one object.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    objects: Vec<Object>,
}

/// A named object: its material and at least one patch.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    name: String,
    material: Material,
    patches: Vec<Patch>,
    /// D-NURBS parameters when the object deforms ([`Object::with_dynamics`]).
    dynamics: Option<Params>,
}

/// Contact and friction material of an object: a validated
/// [`friction::FrictionMaterial`]. All values finite, non-negative (some strictly positive,
/// see the module docs), and `mu_static >= mu_dynamic`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    friction: FrictionMaterial,
}

/// One validated NURBS patch of an object.
#[derive(Clone, Debug, PartialEq)]
pub enum Patch {
    /// A planar curve (points with 2 coordinates).
    Curve2(CurveBuf<Vec2>),
    /// A spatial curve (points with 3 coordinates).
    Curve3(CurveBuf<Vec3>),
    /// A surface.
    Surface(SurfaceBuf),
}

/// Why a scene was rejected. The message names the file (for [`Scene::load`]), the object
/// (index and name), the patch and the field.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("cannot read {}: {error}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// An error in the named file.
    #[error("{}: {error}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// The error in it.
        error: Box<SceneError>,
    },
    /// JSON syntax error, wrong type, missing or unknown field. serde_json's message ends with
    /// the line and column.
    #[error("{}{error}", json_prefix(location, error))]
    Json {
        /// Where in the document, e.g. `object 0 ("wedge"), patch 1: points[2][0]`; empty at the
        /// top level.
        location: String,
        /// serde_json's error, with line and column.
        error: serde_json::Error,
    },
    /// Missing or unsupported `format`.
    #[error("format: {}, expected \"{FORMAT}\"", match found {
        Some(f) => format!("unsupported format {f}"),
        None => "missing".to_owned(),
    })]
    Format {
        /// The value found (as JSON text, so a string is quoted), if any.
        found: Option<String>,
    },
    /// `objects` is empty.
    #[error("objects: the scene has no objects, at least one is needed")]
    NoObjects,
    /// An error inside an object.
    #[error("object {index} ({name:?}), {error}")]
    Object {
        /// Index in `objects`.
        index: usize,
        /// The object's name.
        name: String,
        /// What is wrong.
        error: ObjectError,
    },
}

/// What precedes serde_json's message: the location, or for a file that is not JSON at all
/// (a syntax error at the top level: an OBJ, a CSV, a typo'd path to another file) a word
/// on what a scene file is, since "expected ident at line 1 column 2" alone does not say it.
fn json_prefix(location: &str, error: &serde_json::Error) -> String {
    use serde_json::error::Category;
    if location.is_empty() && matches!(error.classify(), Category::Syntax | Category::Eof) {
        "not valid JSON (a scene/1 file is a JSON document, {\"format\": \"scene/1\", …}): "
            .to_owned()
    } else {
        prefix(location)
    }
}

fn prefix(location: &str) -> String {
    if location.is_empty() {
        String::new()
    } else {
        format!("{location}: ")
    }
}

impl SceneError {
    /// Line and column (both from 1) of a JSON error.
    pub fn line_column(&self) -> Option<(usize, usize)> {
        match self {
            SceneError::Json { error, .. } => Some((error.line(), error.column())),
            SceneError::File { error, .. } => error.line_column(),
            _ => None,
        }
    }
}

/// An error inside one object.
#[derive(Debug, thiserror::Error)]
pub enum ObjectError {
    /// Invalid material.
    #[error(transparent)]
    Material(#[from] MaterialError),
    /// `patches` is empty.
    #[error("patches: the object has no patches, at least one is needed")]
    NoPatches,
    /// An error in one patch.
    #[error("patch {index}: {error}")]
    Patch {
        /// Index in `patches`.
        index: usize,
        /// What is wrong.
        error: PatchError,
    },
    /// A patch whose kind differs from the first patch's.
    #[error(
        "patch {index}: {}; an object is all planar curves (a 2-D chain), all surfaces (a 3-D \
         shell) or all spatial curves (a wire, for eval and closest)",
        match first { Some(first) => format!("a {found}, but patch 0 is a {first}"),
                      None => format!("a {found}") }
    )]
    Kind {
        /// Index in `patches`.
        index: usize,
        /// Its kind ([`Patch::kind`]).
        found: &'static str,
        /// The kind of patch 0 when that one is valid but different.
        first: Option<&'static str>,
    },
    /// The planar curves do not form a valid chain (its message starts with the field).
    #[error(transparent)]
    Chain(#[from] ChainError),
    /// The surfaces do not form a valid shell (its message starts with the field).
    #[error(transparent)]
    Shell(#[from] ShellError),
    /// An invalid `dynamics` block (the message starts with `dynamics` and names the field).
    #[error("{message}")]
    Dynamics {
        /// What is wrong, e.g. `dynamics.tension_n: -1 is not a non-negative number …`.
        message: String,
    },
}

/// An error in one patch.
#[derive(Debug, thiserror::Error)]
pub enum PatchError {
    /// The arrays have the wrong nesting or the wrong number of entries for the kind of patch.
    #[error("{field}: {problem}")]
    Shape {
        /// The field, e.g. `knots` or `points[3]`.
        field: String,
        /// What is wrong with it.
        problem: String,
    },
    /// The curve or surface is invalid (its message starts with the field).
    #[error(transparent)]
    Nurbs(#[from] NurbsError),
}

impl Scene {
    /// A scene of the given objects; at least one.
    pub fn new(objects: Vec<Object>) -> Result<Self, SceneError> {
        if objects.is_empty() {
            return Err(SceneError::NoObjects);
        }
        Ok(Scene { objects })
    }

    /// The objects (at least one).
    pub fn objects(&self) -> &[Object] {
        &self.objects
    }

    /// Object `index`, if there is one.
    pub fn object(&self, index: usize) -> Option<&Object> {
        self.objects.get(index)
    }
}

impl Object {
    /// An object of at least one patch, all planar curves that form a valid
    /// [`tracker::Chain`] or all surfaces that form a valid [`tracker::Shell`].
    pub fn new(
        name: impl Into<String>,
        material: Material,
        patches: Vec<Patch>,
    ) -> Result<Self, ObjectError> {
        if patches.is_empty() {
            return Err(ObjectError::NoPatches);
        }
        let object = Object {
            name: name.into(),
            material,
            patches,
            dynamics: None,
        };
        object.check_topology()?;
        Ok(object)
    }

    /// The object made deformable with `dynamics` (or rigid with `None`), checked: one patch
    /// only, fixed points that exist, valid parameters and a rest shape whose arc length or
    /// area is defined everywhere.
    pub fn with_dynamics(mut self, dynamics: Option<Params>) -> Result<Self, ObjectError> {
        self.dynamics = dynamics;
        if let Some(Err(e)) = self.body() {
            let surface = matches!(self.patches[0], Patch::Surface(_));
            let message = match e {
                DynamicsError::Param { .. } => format!("dynamics.{}", e.message(surface)),
                DynamicsError::FixedIndex { .. } | DynamicsError::FixedTwice { .. } => {
                    format!("dynamics.{e}")
                }
                e => format!("dynamics: {e}"),
            };
            return Err(ObjectError::Dynamics { message });
        }
        if self.dynamics.is_some() && self.patches.len() != 1 {
            return Err(ObjectError::Dynamics {
                message: format!(
                    "dynamics: only an object of one patch deforms, this one has {} (joined \
                     patches would have to share their end points as they move)",
                    self.patches.len()
                ),
            });
        }
        Ok(self)
    }

    /// The object with its first patch's Cartesian control points moved to `points` (weights,
    /// knots, material and dynamics kept): the shape of a deformable object at one instant,
    /// validated as any object is.
    pub fn reshaped(&self, points: &[[f64; 3]]) -> Result<Object, ObjectError> {
        self.reshaped_patch(0, points)
    }

    /// [`Object::reshaped`] for patch `index` (all its control points); no such patch is an
    /// error naming it.
    pub fn reshaped_patch(&self, index: usize, points: &[[f64; 3]]) -> Result<Object, ObjectError> {
        let Some(old) = self.patches.get(index) else {
            return Err(ObjectError::Patch {
                index,
                error: PatchError::Shape {
                    field: "points".to_owned(),
                    problem: format!("no patch {index}: the object has {}", self.patches.len()),
                },
            });
        };
        let expected = match old {
            Patch::Curve2(c) => c.points().len(),
            Patch::Curve3(c) => c.points().len(),
            Patch::Surface(s) => s.points().len(),
        };
        if points.len() != expected {
            return Err(ObjectError::Patch {
                index,
                error: PatchError::Shape {
                    field: "points".to_owned(),
                    problem: format!("{} control points for a patch of {expected}", points.len()),
                },
            });
        }
        let f = |p: &[f64; 3]| p.map(|x| x as f32);
        let patch = match old {
            Patch::Curve2(c) => {
                reshape_curve(c, points, |p| Vec2::new(f(p)[0], f(p)[1])).map(Patch::Curve2)
            }
            Patch::Curve3(c) => reshape_curve(c, points, |p| Vec3::from(f(p))).map(Patch::Curve3),
            Patch::Surface(s) => {
                let hom = s
                    .points()
                    .iter()
                    .zip(points)
                    .map(|(h, p)| Vec3::from(f(p)).weighted(h.w))
                    .collect();
                let (ku, kv) = s.knots();
                SurfaceBuf::new(s.degree(), (ku.to_vec(), kv.to_vec()), s.counts().1, hom)
                    .map(Patch::Surface)
            }
        }
        .map_err(|e| ObjectError::Patch {
            index,
            error: e.into(),
        })?;
        let mut patches = self.patches.clone();
        patches[index] = patch;
        let object = Object {
            name: self.name.clone(),
            material: self.material,
            patches,
            dynamics: self.dynamics.clone(),
        };
        object.check_topology()?;
        Ok(object)
    }

    /// The D-NURBS parameters, when the object deforms.
    pub fn dynamics(&self) -> Option<&Params> {
        self.dynamics.as_ref()
    }

    /// The deformable body of a deformable object (its first patch at rest), `None` when the
    /// object is rigid.
    pub fn body(&self) -> Option<Result<Body, DynamicsError>> {
        let params = self.dynamics.clone()?;
        let (shape, rest) = match &self.patches[0] {
            Patch::Curve2(c) => Shape::of_curve2(c),
            Patch::Curve3(c) => Shape::of_curve3(c),
            Patch::Surface(s) => Shape::of_surface(s),
        };
        Some(Body::new(shape, rest, params))
    }

    /// Name (free text, not necessarily unique).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Material.
    pub fn material(&self) -> &Material {
        &self.material
    }

    /// Patches (at least one).
    pub fn patches(&self) -> &[Patch] {
        &self.patches
    }

    /// Patch `index`, if there is one.
    pub fn patch(&self, index: usize) -> Option<&Patch> {
        self.patches.get(index)
    }

    /// Whether the object is a 2-D chain of planar curves or a 3-D shell of surfaces.
    pub fn space(&self) -> Space {
        match self.patches[0] {
            Patch::Surface(_) | Patch::Curve3(_) => Space::Spatial,
            Patch::Curve2(_) => Space::Planar,
        }
    }

    /// Views of the curves, for [`tracker::Chain::new`], when the object is planar.
    pub fn curve_views(&self) -> Option<Vec<Curve<'_, Vec2>>> {
        self.patches
            .iter()
            .map(|p| match p {
                Patch::Curve2(c) => Some(c.view()),
                _ => None,
            })
            .collect()
    }

    /// Views of the spatial curves, when the object is a wire.
    pub fn wire_views(&self) -> Option<Vec<Curve<'_, Vec3>>> {
        self.patches
            .iter()
            .map(|p| match p {
                Patch::Curve3(c) => Some(c.view()),
                _ => None,
            })
            .collect()
    }

    /// Views of the surfaces, for [`tracker::Shell::new`], when the object is spatial.
    pub fn surface_views(&self) -> Option<Vec<Surface<'_>>> {
        self.patches
            .iter()
            .map(|p| match p {
                Patch::Surface(s) => Some(s.view()),
                _ => None,
            })
            .collect()
    }

    /// Every patch of one kind, and a chain of planar curves or a shell of surfaces valid. An
    /// object of spatial curves (a wire) is valid scene content that `eval` evaluates; the
    /// haptic commands need a chain or a shell and say so.
    fn check_topology(&self) -> Result<(), ObjectError> {
        let first = &self.patches[0];
        for (index, patch) in self.patches.iter().enumerate() {
            let kind = |first| ObjectError::Kind {
                index,
                found: patch.kind(),
                first,
            };
            if std::mem::discriminant(patch) != std::mem::discriminant(first) {
                return Err(kind(Some(first.kind())));
            }
        }
        if let Some(curves) = self.curve_views() {
            Chain::new(&curves)?;
        } else if let Some(surfaces) = self.surface_views() {
            Shell::new(&surfaces)?;
        }
        Ok(())
    }
}

/// `c` with its Cartesian control points moved to `points` (as `P` by `point`), its weights
/// and knots kept.
fn reshape_curve<P: Point>(
    c: &CurveBuf<P>,
    points: &[[f64; 3]],
    point: impl Fn(&[f64; 3]) -> P,
) -> Result<CurveBuf<P>, NurbsError> {
    let hom = c
        .points()
        .iter()
        .zip(points)
        .map(|(&h, p)| point(p).weighted(P::split(h).1))
        .collect();
    CurveBuf::new(c.degree(), c.knots().to_vec(), hom)
}

/// Where an object or a trajectory lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Space {
    /// The plane (x, y): planar curves, 2-D trajectories.
    Planar,
    /// Space (x, y, z): surfaces, 3-D trajectories.
    Spatial,
}

impl Space {
    /// Number of coordinates, 2 or 3.
    pub fn dim(self) -> usize {
        match self {
            Space::Planar => 2,
            Space::Spatial => 3,
        }
    }
}

impl std::fmt::Display for Space {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Space::Planar => "2-D",
            Space::Spatial => "3-D",
        })
    }
}

impl Material {
    /// Validates a material of the four required values, with the defaults of
    /// [`FrictionMaterial::default`] for the rest: every value finite and >= 0,
    /// `mu_static >= mu_dynamic`.
    pub fn new(
        stiffness_n_per_m: f32,
        damping_ns_per_m: f32,
        mu_static: f32,
        mu_dynamic: f32,
    ) -> Result<Self, MaterialError> {
        Self::from_friction(FrictionMaterial {
            stiffness_n_per_m,
            damping_ns_per_m,
            mu_static,
            mu_dynamic,
            ..FrictionMaterial::default()
        })
    }

    /// Validates every field of a friction material (ranges in the module docs).
    pub fn from_friction(m: FrictionMaterial) -> Result<Self, MaterialError> {
        m.validate()?;
        Ok(Material { friction: m })
    }

    /// The parameters of the friction renderer.
    pub fn friction_material(&self) -> FrictionMaterial {
        self.friction
    }

    /// Contact stiffness, N/m.
    pub fn stiffness_n_per_m(&self) -> f32 {
        self.friction.stiffness_n_per_m
    }

    /// Contact damping, N·s/m.
    pub fn damping_ns_per_m(&self) -> f32 {
        self.friction.damping_ns_per_m
    }

    /// Static friction coefficient.
    pub fn mu_static(&self) -> f32 {
        self.friction.mu_static
    }

    /// Dynamic (sliding) friction coefficient, at most [`Material::mu_static`].
    pub fn mu_dynamic(&self) -> f32 {
        self.friction.mu_dynamic
    }
}

impl Patch {
    /// `"planar curve"`, `"spatial curve"` or `"surface"`.
    pub fn kind(&self) -> &'static str {
        match self {
            Patch::Curve2(_) => "planar curve",
            Patch::Curve3(_) => "spatial curve",
            Patch::Surface(_) => "surface",
        }
    }
}
