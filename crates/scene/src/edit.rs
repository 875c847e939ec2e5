//! Editing the planar curves of a scene: pure operations, each taking a [`Scene`] and
//! returning a new one, validated as a loaded scene is ([`Scene::new`], [`Object::new`] and
//! with it the tracker's [`tracker::Chain::new`]), or an [`EditError`] that names the object,
//! the patch and the field, leaving the scene given as it was. None of them panics.
//!
//! - [`move_point`] moves a control point. **Shared end points**: the knots are clamped, so a
//!   patch passes through its first and last control points, and a chain's consecutive patches
//!   meet there; moving one of these end points alone would open a gap the chain refuses. So
//!   moving an end control point moves every end control point of the same object that lies
//!   at the same place (within [`tracker::JOIN_TOL_M`]): the neighbour's start, the first
//!   patch's start when the last patch's end closes the chain, or the other end of a single
//!   closed patch. The chain stays connected (and closed when it was); interior control points
//!   move alone.
//! - [`set_weight`] sets a weight (finite, > 0, representable as a normal `f32`, within the
//!   patch's weight ratio; the shape moves towards the point as the weight grows).
//! - [`insert_knot`] and [`split_patch`] refine without changing the shape (Boehm's
//!   algorithm in homogeneous coordinates, `nurbs::CurveBuf::insert_knot` and `split_at`).
//! - [`join_next`] joins a patch with the next one (same degree, meeting within
//!   [`tracker::JOIN_TOL_M`]; no degree elevation).
//!
//! [`History`] keeps the scenes before each edit for undo and redo, bounded.

use std::collections::VecDeque;

use nurbs::{CurveBuf, RefineError, Vec2};
use tracker::JOIN_TOL_M;

use crate::{Material, Object, ObjectError, Patch, Scene};

/// A control point: object, patch and index in the patch's control polygon.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PointRef {
    /// Object index.
    pub object: usize,
    /// Patch index in the object.
    pub patch: usize,
    /// Control point index in the patch.
    pub index: usize,
}

impl PointRef {
    /// Control point `index` of patch `patch` of object `object`.
    pub fn new(object: usize, patch: usize, index: usize) -> Self {
        PointRef {
            object,
            patch,
            index,
        }
    }
}

/// Why an edit was refused; the message starts with where (object index and name, patch).
#[derive(Debug, thiserror::Error)]
#[error("{}{kind}", location(.object, .name, .patch))]
pub struct EditError {
    /// Object index.
    pub object: usize,
    /// The object's name (empty when there is no such object).
    pub name: String,
    /// Patch index, when the error is in one patch.
    pub patch: Option<usize>,
    /// What is wrong.
    pub kind: EditErrorKind,
}

fn location(object: &usize, name: &str, patch: &Option<usize>) -> String {
    let mut s = format!("object {object}");
    if !name.is_empty() {
        s += &format!(" ({name:?})");
    }
    if let Some(p) = patch {
        s += &format!(", patch {p}");
    }
    s + ": "
}

/// What is wrong with an edit.
#[derive(Debug, thiserror::Error)]
pub enum EditErrorKind {
    /// No object of that index.
    #[error("no such object, the scene has {count}")]
    NoObject {
        /// Objects in the scene.
        count: usize,
    },
    /// No patch of that index.
    #[error("no such patch, the object has {count}")]
    NoPatch {
        /// Patches in the object.
        count: usize,
    },
    /// The patch is not a planar curve.
    #[error("a {kind}; only planar curves are edited (in the 2-D view)")]
    NotPlanarCurve {
        /// [`Patch::kind`].
        kind: &'static str,
    },
    /// A weight that is not a finite, positive, normal `f32`.
    #[error("weights[{index}]: {value} must be a finite number > 0 that f32 represents (normal)")]
    Weight {
        /// Control point index.
        index: usize,
        /// The value given.
        value: f64,
    },
    /// A control point position that is not finite.
    #[error("points[{index}]: ({}, {}) is not a finite position", .to.x, .to.y)]
    Position {
        /// Control point index.
        index: usize,
        /// The position given.
        to: Vec2,
    },
    /// Joining the last patch: there is no next one.
    #[error("the last patch of the object: there is no next patch to join it with")]
    NoNext,
    /// The curve operation refused (the message names the field: `u`, `knots`, `points[i]`,
    /// `weights[i]`, `degree`).
    #[error(transparent)]
    Curve(#[from] RefineError),
    /// The edited object is not a valid chain or object (the message names the field).
    #[error(transparent)]
    Object(#[from] ObjectError),
}

/// The object and the planar curve an edit applies to.
fn curve_at(
    scene: &Scene,
    object: usize,
    patch: usize,
) -> Result<(&Object, &CurveBuf<Vec2>), EditError> {
    let fail = |name: &str, patch, kind| EditError {
        object,
        name: name.to_owned(),
        patch,
        kind,
    };
    let o = scene.object(object).ok_or_else(|| {
        fail(
            "",
            None,
            EditErrorKind::NoObject {
                count: scene.objects().len(),
            },
        )
    })?;
    match o.patch(patch) {
        Some(Patch::Curve2(c)) => Ok((o, c)),
        Some(p) => Err(fail(
            o.name(),
            Some(patch),
            EditErrorKind::NotPlanarCurve { kind: p.kind() },
        )),
        None => Err(fail(
            o.name(),
            Some(patch),
            EditErrorKind::NoPatch {
                count: o.patches().len(),
            },
        )),
    }
}

fn in_patch(scene: &Scene, object: usize, patch: usize, kind: EditErrorKind) -> EditError {
    EditError {
        object,
        name: scene
            .object(object)
            .map_or(String::new(), |o| o.name().to_owned()),
        patch: Some(patch),
        kind,
    }
}

/// `scene` with the patches of object `object` replaced, validated again; an error is
/// reported at `patch`.
fn with_patches(
    scene: &Scene,
    object: usize,
    patch: usize,
    patches: Vec<Patch>,
    material: Option<Material>,
) -> Result<Scene, EditError> {
    let old = &scene.objects()[object];
    let material = material.unwrap_or(*old.material());
    let edited = Object::new(old.name(), material, patches)
        .and_then(|o| o.with_dynamics(old.dynamics().cloned()))
        .map_err(|e| in_patch(scene, object, patch, EditErrorKind::Object(e)))?;
    let mut objects = scene.objects().to_vec();
    objects[object] = edited;
    // Never empty: it has the objects of a valid scene.
    Scene::new(objects).map_err(|_| EditError {
        object,
        name: old.name().to_owned(),
        patch: None,
        kind: EditErrorKind::NoObject { count: 0 },
    })
}

fn curve_error(scene: &Scene, object: usize, patch: usize) -> impl Fn(RefineError) -> EditError {
    move |e| in_patch(scene, object, patch, EditErrorKind::Curve(e))
}

/// Cartesian control point `index` of a curve.
fn cartesian(c: &CurveBuf<Vec2>, index: usize) -> Option<Vec2> {
    c.view().control_point(index).map(|(p, _)| p)
}

/// Moves control point `at` to `to` (m), with every end control point of its object at the
/// same place when it is an end point (see the module docs).
pub fn move_point(scene: &Scene, at: PointRef, to: Vec2) -> Result<Scene, EditError> {
    let (o, c) = curve_at(scene, at.object, at.patch)?;
    let count = c.points().len();
    let Some(from) = cartesian(c, at.index) else {
        return Err(in_patch(
            scene,
            at.object,
            at.patch,
            EditErrorKind::Curve(RefineError::PointIndex {
                index: at.index,
                count,
            }),
        ));
    };
    if !to.is_finite() {
        return Err(in_patch(
            scene,
            at.object,
            at.patch,
            EditErrorKind::Position {
                index: at.index,
                to,
            },
        ));
    }
    let is_end = |i: usize, n: usize| i == 0 || i + 1 == n;
    let mut patches = o.patches().to_vec();
    for (k, patch) in patches.iter_mut().enumerate() {
        let Patch::Curve2(curve) = patch else {
            continue;
        };
        let n = curve.points().len();
        let mut moved = curve.clone();
        for i in 0..n {
            let this = k == at.patch && i == at.index;
            let shared = is_end(at.index, count)
                && is_end(i, n)
                && cartesian(curve, i).is_some_and(|p| (p - from).length() <= JOIN_TOL_M);
            if this || shared {
                moved = moved
                    .with_point(i, to)
                    .map_err(curve_error(scene, at.object, k))?;
            }
        }
        *patch = Patch::Curve2(moved);
    }
    with_patches(scene, at.object, at.patch, patches, None)
}

/// Sets the weight of control point `at` to `weight` (the point stays where it is).
pub fn set_weight(scene: &Scene, at: PointRef, weight: f64) -> Result<Scene, EditError> {
    let (o, c) = curve_at(scene, at.object, at.patch)?;
    let w = weight as f32;
    if !(weight.is_finite() && weight > 0.0 && w.is_normal()) {
        return Err(in_patch(
            scene,
            at.object,
            at.patch,
            EditErrorKind::Weight {
                index: at.index,
                value: weight,
            },
        ));
    }
    let curve = c
        .with_weight(at.index, w)
        .map_err(curve_error(scene, at.object, at.patch))?;
    let mut patches = o.patches().to_vec();
    patches[at.patch] = Patch::Curve2(curve);
    with_patches(scene, at.object, at.patch, patches, None)
}

/// Inserts the knot `u` into patch `patch` of object `object` (the shape is unchanged).
pub fn insert_knot(scene: &Scene, object: usize, patch: usize, u: f32) -> Result<Scene, EditError> {
    let (o, c) = curve_at(scene, object, patch)?;
    let curve = c
        .insert_knot(u)
        .map_err(curve_error(scene, object, patch))?;
    let mut patches = o.patches().to_vec();
    patches[patch] = Patch::Curve2(curve);
    with_patches(scene, object, patch, patches, None)
}

/// Splits patch `patch` of object `object` at `u` into two consecutive patches (the shape is
/// unchanged; the new vertex between them is smooth where the curve was).
pub fn split_patch(scene: &Scene, object: usize, patch: usize, u: f32) -> Result<Scene, EditError> {
    let (o, c) = curve_at(scene, object, patch)?;
    let (left, right) = c.split_at(u).map_err(curve_error(scene, object, patch))?;
    let mut patches = o.patches().to_vec();
    patches[patch] = Patch::Curve2(left);
    patches.insert(patch + 1, Patch::Curve2(right));
    with_patches(scene, object, patch, patches, None)
}

/// Joins patch `patch` of object `object` with the next one into one patch.
pub fn join_next(scene: &Scene, object: usize, patch: usize) -> Result<Scene, EditError> {
    let (o, c) = curve_at(scene, object, patch)?;
    if patch + 1 >= o.patches().len() {
        return Err(in_patch(scene, object, patch, EditErrorKind::NoNext));
    }
    let (_, next) = curve_at(scene, object, patch + 1)?;
    let joined = c
        .join(next, JOIN_TOL_M)
        .map_err(curve_error(scene, object, patch))?;
    let mut patches = o.patches().to_vec();
    patches[patch] = Patch::Curve2(joined);
    patches.remove(patch + 1);
    with_patches(scene, object, patch, patches, None)
}

/// `scene` with the material of object `object` replaced.
pub fn set_material(scene: &Scene, object: usize, material: Material) -> Result<Scene, EditError> {
    let o = scene.object(object).ok_or_else(|| EditError {
        object,
        name: String::new(),
        patch: None,
        kind: EditErrorKind::NoObject {
            count: scene.objects().len(),
        },
    })?;
    with_patches(scene, object, 0, o.patches().to_vec(), Some(material))
}

/// The parameter that stands for control point `index` of `curve`, where knot insertion and
/// splitting "at the point" happen: its Greville abscissa `(u_{i+1} + … + u_{i+p}) / p`, the
/// parameter where `N_{i,p}` has its centre (where the curve is closest to being pulled by
/// the point). When that is an end of the domain or already a knot, the middle of the
/// longest knot span in the support of `N_{i,p}` instead. `None` for an index past the end.
pub fn parameter_of(curve: &CurveBuf<Vec2>, index: usize) -> Option<f32> {
    let p = curve.degree();
    let k = curve.knots();
    if index >= curve.points().len() {
        return None;
    }
    let greville = k[index + 1..=index + p]
        .iter()
        .map(|&x| f64::from(x))
        .sum::<f64>()
        / p as f64;
    let greville = greville as f32;
    let (a, b) = curve.view().domain();
    if greville > a && greville < b && !k.contains(&greville) {
        return Some(greville);
    }
    // Supports always contain a non-empty span (the knots are validated).
    (index..=index + p)
        .filter(|&s| k[s] < k[s + 1])
        .max_by(|&s, &t| (k[s + 1] - k[s]).total_cmp(&(k[t + 1] - k[t])))
        .map(|s| k[s] + (k[s + 1] - k[s]) * 0.5)
}

/// One undoable edit: the scene before it and what it did.
#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    /// What the edit did, e.g. "move point".
    pub label: String,
    /// The scene on the other side of the edit (before it on the undo stack, after it on
    /// the redo stack).
    pub scene: Scene,
}

/// Undo and redo of scene edits, the oldest forgotten beyond a capacity.
#[derive(Clone, Debug, PartialEq)]
pub struct History {
    undo: VecDeque<Entry>,
    redo: Vec<Entry>,
    capacity: usize,
}

impl Default for History {
    fn default() -> Self {
        History::new(History::DEFAULT_CAPACITY)
    }
}

impl History {
    /// Edits kept by [`History::default`].
    pub const DEFAULT_CAPACITY: usize = 100;

    /// An empty history keeping at most `capacity` edits (at least one).
    pub fn new(capacity: usize) -> Self {
        History {
            undo: VecDeque::new(),
            redo: Vec::new(),
            capacity: capacity.max(1),
        }
    }

    /// Records an edit labelled `label` made to `before`. What could be redone is forgotten,
    /// and the oldest edit when more than the capacity are kept.
    pub fn push(&mut self, before: Scene, label: &str) {
        self.redo.clear();
        if self.undo.len() == self.capacity {
            self.undo.pop_front();
        }
        self.undo.push_back(Entry {
            label: label.to_owned(),
            scene: before,
        });
    }

    /// The edit [`History::undo`] would undo.
    pub fn next_undo(&self) -> Option<&Entry> {
        self.undo.back()
    }

    /// The edit [`History::redo`] would redo.
    pub fn next_redo(&self) -> Option<&Entry> {
        self.redo.last()
    }

    /// Undoes the last edit: `current` (the scene after it) becomes redoable, and the scene
    /// before it is returned with its label.
    pub fn undo(&mut self, current: Scene) -> Option<Entry> {
        let entry = self.undo.pop_back()?;
        self.redo.push(Entry {
            label: entry.label.clone(),
            scene: current,
        });
        Some(entry)
    }

    /// Redoes the last undone edit: `current` becomes undoable again, the scene after the
    /// edit is returned with its label.
    pub fn redo(&mut self, current: Scene) -> Option<Entry> {
        let entry = self.redo.pop()?;
        self.undo.push_back(Entry {
            label: entry.label.clone(),
            scene: current,
        });
        Some(entry)
    }

    /// Edits that can be undone and redone.
    pub fn depth(&self) -> (usize, usize) {
        (self.undo.len(), self.redo.len())
    }

    /// Forgets everything (a new scene was opened).
    pub fn clear(&mut self) {
        self.undo.clear();
        self.redo.clear();
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn scene_of(name: &str) -> Scene {
        let json = match name {
            "thesis-2d" => include_str!("../../../scenes/thesis-2d.json"),
            "thesis-3d" => include_str!("../../../scenes/thesis-3d.json"),
            _ => include_str!("../../../scenes/examples.json"),
        };
        Scene::from_json_str(json).unwrap()
    }

    fn thesis() -> Scene {
        scene_of("thesis-2d")
    }

    fn curve(scene: &Scene, object: usize, patch: usize) -> &CurveBuf<Vec2> {
        match scene.object(object).and_then(|o| o.patch(patch)) {
            Some(Patch::Curve2(c)) => c,
            other => panic!("not a planar curve: {other:?}"),
        }
    }

    /// The apex of thesis-2d is the right arc's last point and the left arc's first: moving
    /// one moves both, the chain stays connected; an interior point moves alone.
    #[test]
    fn moving_a_shared_end_point_moves_both_patches() {
        let s = thesis();
        let apex = cartesian(curve(&s, 0, 0), 2).unwrap();
        let to = apex + Vec2::new(0.002, 0.003);
        let moved = move_point(&s, PointRef::new(0, 0, 2), to).unwrap();
        assert_eq!(cartesian(curve(&moved, 0, 0), 2), Some(to));
        assert_eq!(cartesian(curve(&moved, 0, 1), 0), Some(to));
        // The far ends stay.
        assert_eq!(
            cartesian(curve(&moved, 0, 0), 0),
            cartesian(curve(&s, 0, 0), 0)
        );
        assert_eq!(
            cartesian(curve(&moved, 0, 1), 2),
            cartesian(curve(&s, 0, 1), 2)
        );
        // From the other side too.
        let moved = move_point(&s, PointRef::new(0, 1, 0), to).unwrap();
        assert_eq!(cartesian(curve(&moved, 0, 0), 2), Some(to));
        // An interior point alone.
        let p1 = cartesian(curve(&s, 0, 0), 1).unwrap();
        let moved = move_point(&s, PointRef::new(0, 0, 1), p1 + Vec2::X * 0.001).unwrap();
        assert_eq!(curve(&moved, 0, 1), curve(&s, 0, 1));
        assert_eq!(
            cartesian(curve(&moved, 0, 0), 1),
            Some(p1 + Vec2::X * 0.001)
        );
    }

    /// The closed circle of examples: its first and last control points coincide and move
    /// together, so the chain stays closed.
    #[test]
    fn moving_the_seam_of_a_closed_patch_keeps_it_closed() {
        let s = scene_of("examples");
        let (object, patch) = s
            .objects()
            .iter()
            .enumerate()
            .find_map(|(i, o)| {
                o.patches()
                    .iter()
                    .position(|p| match p {
                        Patch::Curve2(c) => c.view().is_closed(1e-6),
                        _ => false,
                    })
                    .map(|k| (i, k))
            })
            .expect("examples has a closed curve");
        let c = curve(&s, object, patch);
        let last = c.points().len() - 1;
        let seam = cartesian(c, 0).unwrap();
        let to = seam + Vec2::new(0.001, 0.0);
        let moved = move_point(&s, PointRef::new(object, patch, 0), to).unwrap();
        let m = curve(&moved, object, patch);
        assert_eq!(cartesian(m, 0), Some(to));
        assert_eq!(cartesian(m, last), Some(to));
    }

    #[test]
    fn invalid_edits_name_the_field_and_leave_the_scene() {
        let s = thesis();
        let copy = s.clone();
        let e = move_point(&s, PointRef::new(0, 0, 7), Vec2::ZERO).unwrap_err();
        assert_eq!(
            e.to_string(),
            "object 0 (\"two curves meeting at a vertex (thesis Fig. 3.2.1)\"), patch 0: \
             points[7]: no such control point, the patch has 3"
        );
        let e = move_point(&s, PointRef::new(0, 5, 0), Vec2::ZERO).unwrap_err();
        assert!(
            e.to_string()
                .ends_with("patch 5: no such patch, the object has 2"),
            "{e}"
        );
        let e = move_point(&s, PointRef::new(3, 0, 0), Vec2::ZERO).unwrap_err();
        assert_eq!(e.to_string(), "object 3: no such object, the scene has 1");
        let e = move_point(&s, PointRef::new(0, 0, 1), Vec2::new(f32::NAN, 0.0)).unwrap_err();
        assert!(
            e.to_string()
                .ends_with("points[1]: (NaN, 0) is not a finite position"),
            "{e}"
        );
        for w in [0.0, -0.5, f64::NAN, f64::INFINITY, 1e40, 1e-40] {
            let e = set_weight(&s, PointRef::new(0, 0, 1), w).unwrap_err();
            assert!(
                matches!(e.kind, EditErrorKind::Weight { index: 1, .. }),
                "{w}: {e}"
            );
            assert!(e.to_string().contains("patch 0: weights[1]: "), "{e}");
        }
        // Valid alone, but a million times the others: the patch's weight ratio.
        let e = set_weight(&s, PointRef::new(0, 0, 1), 1e7).unwrap_err();
        assert!(
            e.to_string()
                .contains("weights[0]: weight 1e0 is less than"),
            "{e}"
        );
        let e = insert_knot(&s, 0, 1, 1.0).unwrap_err();
        assert!(
            e.to_string()
                .ends_with("patch 1: u: 1 is outside the open domain (0, 1) of the patch"),
            "{e}"
        );
        let e = split_patch(&s, 0, 0, -0.1).unwrap_err();
        assert!(e.to_string().contains("u: -0.1 is outside"), "{e}");
        let e = join_next(&s, 0, 1).unwrap_err();
        assert!(
            e.to_string().ends_with(
                "patch 1: the last patch of the object: there is no next patch to join it with"
            ),
            "{e}"
        );
        // Moving an end of the open chain's first patch far off keeps it connected (only the
        // free end moves), but moving the apex below the base makes the arch cross itself;
        // whatever the chain refuses is named.
        let far = move_point(&s, PointRef::new(0, 0, 0), Vec2::new(0.05, 0.0));
        assert!(far.is_ok());
        // thesis-3d: surfaces are not edited here.
        let e = move_point(&scene_of("thesis-3d"), PointRef::new(0, 0, 0), Vec2::ZERO).unwrap_err();
        assert!(
            e.to_string().contains("only planar curves are edited"),
            "{e}"
        );
        assert_eq!(s, copy);
    }

    /// Joining the two arcs of thesis-2d gives one patch with the shape of both, and splitting
    /// it at the joint gives two again; the chain's own checks apply to every edit, named by
    /// its message (here: too many curves, after splitting again and again).
    #[test]
    fn join_split_and_the_chain_limits() {
        let t = thesis();
        let joined = join_next(&t, 0, 0).unwrap();
        assert_eq!(joined.object(0).unwrap().patches().len(), 1);
        let j = curve(&joined, 0, 0).view();
        let (a, b) = (curve(&t, 0, 0).view(), curve(&t, 0, 1).view());
        // 1e-7 m: a few ulps of the 0.1 m coordinates.
        for i in 0..=100 {
            let u = i as f32 / 100.0;
            assert!((j.point(u) - a.point(u)).length() < 1e-7, "{u}");
            assert!((j.point(1.0 + u) - b.point(u)).length() < 1e-7, "{u}");
        }
        let back = split_patch(&joined, 0, 0, 1.0).unwrap();
        assert_eq!(back.object(0).unwrap().patches().len(), 2);

        let mut s = t.clone();
        let mut error = None;
        for _ in 0..40 {
            // The longest patch (in parameter), so that no domain gets shorter than f32
            // resolves.
            let n = s.object(0).unwrap().patches().len();
            let length = |k: usize| {
                let (a, b) = curve(&s, 0, k).view().domain();
                b - a
            };
            let k = (0..n)
                .max_by(|&i, &j| length(i).total_cmp(&length(j)))
                .unwrap();
            let (a, b) = curve(&s, 0, k).view().domain();
            match split_patch(&s, 0, k, 0.5 * (a + b)) {
                Ok(next) => s = next,
                Err(e) => {
                    error = Some(e);
                    break;
                }
            }
        }
        let e = error.expect("the chain refuses more than 32 curves");
        assert_eq!(
            s.object(0).unwrap().patches().len(),
            tracker::MAX_CHAIN_CURVES
        );
        assert!(
            e.to_string()
                .ends_with("patches: 33 curves, at most 32 per object"),
            "{e}"
        );
    }

    #[test]
    fn insert_and_split_keep_the_shape_and_the_chain() {
        let s = thesis();
        let c = curve(&s, 0, 0).view();
        let refined = insert_knot(&s, 0, 0, 0.3).unwrap();
        let r = curve(&refined, 0, 0);
        assert_eq!(r.points().len(), 4);
        let split = split_patch(&s, 0, 0, 0.5).unwrap();
        let o = split.object(0).unwrap();
        assert_eq!(o.patches().len(), 3);
        let (l, rr) = (curve(&split, 0, 0).view(), curve(&split, 0, 1).view());
        // Both pieces keep the parameters; 1e-7 m is a few ulps of the 0.1 m coordinates.
        for i in 0..=50 {
            let u = i as f32 / 100.0;
            assert!((r.view().point(u) - c.point(u)).length() < 1e-7, "{u}");
            assert!((l.point(u) - c.point(u)).length() < 1e-7, "{u}");
            assert!(
                (rr.point(0.5 + u) - c.point(0.5 + u)).length() < 1e-7,
                "{u}"
            );
        }
    }

    #[test]
    fn parameters_of_control_points() {
        let s = thesis();
        let c = curve(&s, 0, 0);
        // Quadratic Bézier: Greville abscissae 0, 1/2, 1; the ends fall back to the middle
        // of their (only) span.
        assert_eq!(parameter_of(c, 1), Some(0.5));
        assert_eq!(parameter_of(c, 0), Some(0.5));
        assert_eq!(parameter_of(c, 2), Some(0.5));
        assert_eq!(parameter_of(c, 3), None);
        let refined = c.insert_knot(0.5).unwrap();
        // Knots 0 0 0 .5 1 1 1: ξ = 0, .25, .75, 1; the first point's support is [0, .5].
        assert_eq!(parameter_of(&refined, 1), Some(0.25));
        assert_eq!(parameter_of(&refined, 2), Some(0.75));
        assert_eq!(parameter_of(&refined, 0), Some(0.25));
    }

    #[test]
    fn history_round_trips_and_is_bounded() {
        let s0 = thesis();
        let s1 = insert_knot(&s0, 0, 0, 0.5).unwrap();
        let s2 = insert_knot(&s1, 0, 1, 0.5).unwrap();
        let mut h = History::new(2);
        h.push(s0.clone(), "insert knot");
        h.push(s1.clone(), "insert knot 2");
        assert_eq!(h.depth(), (2, 0));
        let e = h.undo(s2.clone()).unwrap();
        assert_eq!((e.label.as_str(), &e.scene), ("insert knot 2", &s1));
        let e = h.undo(s1.clone()).unwrap();
        assert_eq!(e.scene, s0);
        assert!(h.undo(s0.clone()).is_none());
        assert_eq!(h.depth(), (0, 2));
        let e = h.redo(s0.clone()).unwrap();
        assert_eq!(e.scene, s1);
        let e = h.redo(s1.clone()).unwrap();
        assert_eq!(e.scene, s2);
        assert!(h.redo(s2.clone()).is_none());
        // A new edit forgets the redo stack; beyond the capacity the oldest goes.
        h.undo(s2.clone());
        h.push(s1.clone(), "other");
        assert_eq!(h.depth(), (2, 0));
        h.push(s2.clone(), "third");
        assert_eq!(h.depth(), (2, 0));
        assert_eq!(h.next_undo().map(|e| e.label.as_str()), Some("third"));
        h.clear();
        assert_eq!(h.depth(), (0, 0));
    }
}
