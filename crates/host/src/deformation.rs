//! The one lifecycle of a deformable object in a loop, whichever loop renders it: the planar
//! device in this process ([`crate::planar`]), the spatial hand ([`crate::spatial`]) and the
//! host of a device behind a link ([`crate::remote`]) each hold a [`Deformation`] and say only
//! how a control-point update reaches what they render (through the in-process device's
//! receiver, onto the hand's shell, or queued for the link).
//!
//! - Rigid, the object is at its rest shape where it is rendered; [`Deformation::start`]
//!   starts its dynamics ([`Deformer`]) from rest and publishes its shape ([`SharedShape`]).
//! - Every rendered tick [feeds](Deformation::feed) it; a tick that carries the contact's
//!   positions only (a device's telemetry) has its parameters
//!   [located](Deformation::locate_contact) first.
//! - [`Deformation::step`] steps it, publishes the shape when due, and every
//!   `update_every` steps hands the loop the [`PointsUpdate`] that moves the rendered object
//!   onto the new shape: the object the update names, each of its patches the body moves,
//!   whole, from its first control point.
//! - A step that fails, a shape that leaves the range of f32 or an update the loop cannot
//!   apply makes the object rigid again: [`Deformation::stop`] hands the loop the update back
//!   to the rest shape (the rest shape's f32 points: the points as uploaded, for polynomial
//!   patches bit for bit).

use std::marker::PhantomData;
use std::sync::Arc;

use nurbs::{Vec2, Vec3};

#[cfg(test)]
use crate::deform::ShapeFrame;
use crate::deform::{DeformChangeError, DeformError, DeformStatus, Deformer, SharedShape};
use crate::tick::Tick;
use crate::upload::PointsUpdate;

/// A control point as an update carries it: a planar curve's (x, y) or a surface's (x, y, z).
pub trait ShapePoint: Copy + core::fmt::Debug {
    /// The point at `p` (m; `z` dropped for a planar curve), in f32.
    fn from_m(p: [f64; 3]) -> Self;
}

impl ShapePoint for Vec2 {
    fn from_m(p: [f64; 3]) -> Self {
        Vec2::new(p[0] as f32, p[1] as f32)
    }
}

impl ShapePoint for Vec3 {
    fn from_m(p: [f64; 3]) -> Self {
        Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32)
    }
}

/// How a loop moves what it renders onto a new shape of the object.
pub type Apply<'a, P> = dyn FnMut(&PointsUpdate<P>) -> Result<(), DeformChangeError> + 'a;

/// A loop's deformable object: rigid (at rest) or deforming, and where its shape is published
/// (the same for the loop's whole life).
#[derive(Debug)]
pub struct Deformation<P = Vec2> {
    shape: Arc<SharedShape>,
    active: Option<Active>,
    update_every: u32,
    point: PhantomData<fn() -> P>,
}

/// A deforming object.
struct Active {
    deformer: Deformer,
    /// The object the updates name (its index where it is rendered).
    object: u8,
    /// Steps so far.
    steps: u32,
    /// Steps since the shape was last published.
    since_publish: u32,
}

impl std::fmt::Debug for Active {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Active")
            .field("scene_object", &self.deformer.index())
            .field("object", &self.object)
            .field("steps", &self.steps)
            .field("since_publish", &self.since_publish)
            .finish_non_exhaustive()
    }
}

impl<P: ShapePoint> Deformation<P> {
    /// A rigid object whose shape, once it deforms, reaches the rendering every
    /// `update_every` steps (at least every step).
    pub fn new(update_every: u32) -> Self {
        Deformation {
            shape: SharedShape::new(),
            active: None,
            update_every: update_every.max(1),
            point: PhantomData,
        }
    }

    /// Where the shape is published.
    pub fn shared_shape(&self) -> &Arc<SharedShape> {
        &self.shape
    }

    /// What a loop answers a [`crate::backend::LoopCommand::Deform`] it took.
    pub fn status(&self) -> DeformStatus {
        DeformStatus {
            deforming: self.deforming(),
            shape: Arc::clone(&self.shape),
        }
    }

    /// Whether the object deforms.
    pub fn deforming(&self) -> bool {
        self.active.is_some()
    }

    /// The object's dynamics, while it deforms.
    pub fn deformer(&self) -> Option<&Deformer> {
        self.active.as_ref().map(|a| &a.deformer)
    }

    /// Starts deforming from rest at the loop's time `t_s` with the dynamics `deformer`
    /// builds (asked only when the object is rigid: deforming already changes nothing), its
    /// updates naming object `object` (its index where it is rendered). The rendering is at
    /// rest already (a rigid object is), so nothing is applied. Refused, nothing changed, when
    /// `deformer` refuses.
    pub fn start(
        &mut self,
        deformer: impl FnOnce() -> Result<Deformer, DeformChangeError>,
        object: u8,
        t_s: f64,
    ) -> Result<(), DeformChangeError> {
        if self.active.is_some() {
            return Ok(());
        }
        let deformer = deformer()?;
        self.shape.start(&deformer, t_s);
        self.active = Some(Active {
            deformer,
            object,
            steps: 0,
            since_publish: 0,
        });
        Ok(())
    }

    /// Rigid again at `t_s`: the rendering is moved back onto the rest shape by `apply`.
    /// Rigid already, nothing happens. Rigid even when `apply` refuses (its error is
    /// returned: the rendering keeps the shape it had).
    pub fn stop(&mut self, t_s: f64, apply: &mut Apply<'_, P>) -> Result<(), DeformChangeError> {
        let Some(active) = self.active.take() else {
            return Ok(());
        };
        self.shape.stop(t_s);
        apply(&rest_update(&active))
    }

    /// Rigid again with the scene it belonged to gone (a swap): nothing to move back.
    pub fn forget(&mut self, t_s: f64) {
        if self.active.take().is_some() {
            self.shape.stop(t_s);
        }
    }

    /// A deforming object back at rest with the dynamics `deformer` builds (a material
    /// change): the rendering moved back onto the rest shape by `apply`, then deforming from
    /// rest. Rigid, nothing happens. On error the object is rigid, at rest if `apply` took
    /// the rest shape.
    pub fn restart(
        &mut self,
        deformer: impl FnOnce() -> Result<Deformer, DeformChangeError>,
        t_s: f64,
        apply: &mut Apply<'_, P>,
    ) -> Result<(), DeformChangeError> {
        let Some(object) = self.active.as_ref().map(|a| a.object) else {
            return Ok(());
        };
        self.stop(t_s, apply)?;
        self.start(deformer, object, t_s)
    }

    /// Fills in the CP's parameters of a tick from a device's telemetry frame, which gives
    /// the GO's (where the force acts) but has no room for the CP's
    /// ([`crate::remote::tick_of`]): the point of the object's current shape nearest the CP
    /// ([`Deformer::locate_cp`]), where [`Tick::deform`] is shown. A loop whose ticks come
    /// from its own renderer has both and skips this. Rigid, nothing happens.
    pub fn locate_contact(&mut self, tick: &mut Tick) {
        if let Some(a) = &mut self.active {
            a.deformer.locate_cp(tick);
        }
    }

    /// One rendered tick: while the object deforms its force loads it, and the tick records
    /// the object's displacement at the CP ([`Tick::deform`]).
    pub fn feed(&mut self, tick: &mut Tick) {
        if let Some(a) = &mut self.active {
            tick.deform = Some(a.deformer.feed(tick));
        }
    }

    /// One step of `dt_s` of a deforming object at the loop's time `t_s` (after it) under
    /// what the ticks since the last step fed it; the shape published when due
    /// ([`SharedShape::publish_when_due`]); every `update_every` steps the rendering moved
    /// onto the new shape by `apply`. A step that fails, a shape that leaves the range of
    /// f32, or an update `apply` refuses makes the object rigid again ([`Deformation::stop`]);
    /// then the returned message says why, for the loop's last error. Rigid, nothing
    /// happens.
    pub fn step(&mut self, dt_s: f64, t_s: f64, apply: &mut Apply<'_, P>) -> Option<String> {
        let a = self.active.as_mut()?;
        let moved = a
            .deformer
            .step(dt_s)
            .and_then(|()| in_f32(&a.deformer))
            .map_err(DeformChangeError::from)
            .and_then(|()| {
                a.steps = a.steps.wrapping_add(1);
                if a.steps.is_multiple_of(self.update_every) {
                    apply(&update(a, a.deformer.points()))
                } else {
                    Ok(())
                }
            });
        match moved {
            Ok(()) => {
                self.shape
                    .publish_when_due(&mut a.since_publish, &a.deformer, t_s);
                None
            }
            Err(e) => Some(match self.stop(t_s, apply) {
                Ok(()) => format!("{e}; the object is rigid again"),
                Err(again) => format!("{e}; {again}"),
            }),
        }
    }
}

/// Whether every control point of `deformer`'s shape is a finite f32 (what every rendering
/// takes), or why not: the object's own validation of the shape.
fn in_f32(deformer: &Deformer) -> Result<(), DeformError> {
    let finite = deformer
        .points()
        .iter()
        .all(|p| p.iter().all(|&c| (c as f32).is_finite()));
    if finite {
        return Ok(());
    }
    deformer.shape().map(drop)?;
    Err(DeformError::Dynamics {
        index: deformer.index(),
        message: "a control point left the range of f32".to_owned(),
    })
}

/// The update that moves `active`'s object onto `points` (the body's nodes, in
/// [`Deformer::patches`]' order): each patch the body moves, whole.
fn update<P: ShapePoint>(active: &Active, points: Vec<[f64; 3]>) -> PointsUpdate<P> {
    let mut nodes = points.into_iter();
    let patches = active
        .deformer
        .patches()
        .iter()
        .map(|&(patch, count)| {
            let points = nodes.by_ref().take(count).map(P::from_m).collect();
            // A patch index past u8 names no patch of a wire scene (at most 255): the
            // receiver refuses it, as it would any patch it does not have.
            (u8::try_from(patch).unwrap_or(u8::MAX), 0, points)
        })
        .collect();
    PointsUpdate {
        object: active.object,
        patches,
    }
}

/// The update back to `active`'s rest shape.
fn rest_update<P: ShapePoint>(active: &Active) -> PointsUpdate<P> {
    update(active, active.deformer.rest_points())
}

#[cfg(test)]
mod tests {
    use super::*;
    use scene::{Bundled, Patch, Scene};

    fn deformable() -> Scene {
        Bundled::find("deformable")
            .and_then(|b| b.scene().ok())
            .unwrap_or_else(|| panic!("the bundled deformable scene"))
    }

    /// Object 1 of `scene`'s patch 0 as the scene file wrote it: its homogeneous control
    /// points divided by their weights (all 1 on the drum, so exact in f32).
    fn drum_points(scene: &Scene) -> Vec<Vec3> {
        match &scene.objects()[1].patches()[0] {
            Patch::Surface(s) => s
                .points()
                .iter()
                .map(|h| {
                    assert_eq!(h.w, 1.0);
                    Vec3::new(h.x, h.y, h.z)
                })
                .collect(),
            other => panic!("{other:?}"),
        }
    }

    type Updates = Vec<PointsUpdate<Vec3>>;

    fn recorder(
        updates: &mut Updates,
    ) -> impl FnMut(&PointsUpdate<Vec3>) -> Result<(), DeformChangeError> + '_ {
        |u| {
            updates.push(u.clone());
            Ok(())
        }
    }

    /// The drum is object 1 of its scene: deforming, every `update_every`-th step hands the
    /// loop an update naming object 1 and its patch 0, whole (every control point of the
    /// scene's patch, from the first); stopped, the update back is the scene's points bit
    /// for bit, and stopping again sends nothing.
    #[test]
    fn updates_name_the_object_and_its_patch_and_end_at_rest() {
        let scene = deformable();
        let rest = drum_points(&scene);
        let mut d = Deformation::<Vec3>::new(2);
        let mut updates = Updates::new();
        d.start(|| Ok(Deformer::new(&scene, 1)?), 1, 0.0)
            .unwrap_or_else(|e| panic!("{e}"));
        // A press at the centre: 1 N down on the skin.
        let mut tick = Tick {
            patch: Some(0),
            cp_params: [0.5, 0.5],
            go_params: [0.5, 0.5],
            force: Vec3::new(0.0, 0.0, 1.0),
            ..Tick::idle(0.0)
        };
        for k in 0..5 {
            d.feed(&mut tick);
            let stopped = d.step(1e-3, f64::from(k + 1) * 1e-3, &mut recorder(&mut updates));
            assert!(stopped.is_none(), "{stopped:?}");
        }
        // Steps 2 and 4.
        assert_eq!(updates.len(), 2);
        for u in &updates {
            assert_eq!(u.object, 1);
            assert_eq!(u.patches.len(), 1);
            let (patch, first, points) = &u.patches[0];
            assert_eq!((*patch, *first, points.len()), (0, 0, rest.len()));
        }
        let last = &updates[1].patches[0].2;
        assert!(
            last.iter().zip(&rest).any(|(p, r)| p.z < r.z),
            "the press moved the skin down"
        );

        updates.clear();
        d.stop(0.01, &mut recorder(&mut updates))
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(!d.deforming());
        assert_eq!(updates.len(), 1);
        assert_eq!(updates[0].object, 1);
        assert_eq!(updates[0].patches, vec![(0, 0, rest)]);
        d.stop(0.02, &mut recorder(&mut updates))
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(updates.len(), 1);
    }

    /// A load that throws the string's control points past the range of f32 (a contact spring
    /// anchored at the largest f32 and the largest f32 force: the string's rest is 0.115 m
    /// away, so its swing towards them passes f32::MAX) makes the object rigid again: the step says why, the last update
    /// is the rest shape, the published shape is not deforming. An update the loop refuses
    /// does the same.
    #[test]
    fn leaving_f32_or_a_refused_update_is_back_at_rest() {
        let scene = deformable();
        let rest: Vec<Vec2> = Deformer::new(&scene, 0)
            .unwrap_or_else(|e| panic!("{e}"))
            .rest_points()
            .into_iter()
            .map(Vec2::from_m)
            .collect();
        let mut d = Deformation::<Vec2>::new(1);
        let mut updates = Vec::new();
        let mut apply = |u: &PointsUpdate| -> Result<(), DeformChangeError> {
            updates.push(u.clone());
            Ok(())
        };
        d.start(|| Ok(Deformer::new(&scene, 0)?), 0, 0.0)
            .unwrap_or_else(|e| panic!("{e}"));
        let mut tick = Tick {
            patch: Some(0),
            cp_params: [0.5, 0.0],
            go_params: [0.5, 0.0],
            hip: Vec3::new(0.0, f32::MAX, 0.0),
            go: Vec3::new(0.0, f32::MAX, 0.0),
            force: Vec3::new(0.0, -f32::MAX, 0.0),
            ..Tick::idle(0.0)
        };
        let mut why = None;
        for _ in 0..1000 {
            d.feed(&mut tick);
            why = d.step(1e-3, 0.0, &mut apply);
            if why.is_some() {
                break;
            }
        }
        let why = why.unwrap_or_else(|| panic!("the string stayed in f32"));
        assert!(why.ends_with("the object is rigid again"), "{why}");
        assert!(
            why.contains("the deformed shape is invalid") || why.contains("range of f32"),
            "{why}"
        );
        assert!(!d.deforming());
        assert_eq!(
            updates.last().map(|u| &u.patches),
            Some(&vec![(0, 0, rest.clone())])
        );
        let mut frame = ShapeFrame::default();
        assert!(d.shared_shape().read_into(&mut frame) && !frame.deforming);

        let mut refused = 0;
        d.start(|| Ok(Deformer::new(&scene, 0)?), 0, 0.0)
            .unwrap_or_else(|e| panic!("{e}"));
        let why = d.step(1e-3, 0.0, &mut |u| {
            refused += 1;
            if refused == 1 {
                Err(DeformChangeError::Update("no".into()))
            } else {
                assert_eq!(u.patches, vec![(0, 0, rest.clone())]);
                Ok(())
            }
        });
        assert_eq!(refused, 2);
        assert!(why.is_some_and(|w| w.contains("no")));
        assert!(!d.deforming());
    }
}
