//! One interface over 2-D chains and 3-D shells, so the layers above (friction, the device's
//! controller) are written once for both.

use crate::chain::{Chain, ChainTopology, ChainTracker};
use crate::contact::{Contact, Feature};
use crate::patch::Patch;
use crate::shell::{Shell, ShellTopology, ShellTracker};
use crate::track::TrackerConfig;
use nurbs::{Point, Vec2, Vec3};

/// A multi-patch object whose closest point can be tracked.
pub trait Object {
    /// The space it lives in.
    type P: Point;
    /// Per-tick tracking state (feature and tracker); `Copy`, holds no borrow.
    type State: Copy + core::fmt::Debug;
    /// What a [`Object::State`] of the object depends on besides its geometry (pieces,
    /// features and their kinds, parameter domains; [`Chain::topology`],
    /// [`Shell::topology`]). Two objects with equal topologies take each other's states:
    /// one whose control points moved, for instance, as long as that changed no kind.
    type Topology: Copy + PartialEq + core::fmt::Debug;

    /// Starts tracking from nothing at `hip` (nearest feature by search).
    fn start(&self, hip: Self::P, cfg: TrackerConfig) -> Self::State;

    /// One tick of tracking (see [`ChainTracker::update`]).
    fn track(
        &self,
        state: &mut Self::State,
        hip: Self::P,
        period_s: f32,
        allow_switch: bool,
    ) -> Contact<Self::P>;

    /// The active feature of a state.
    fn feature(state: &Self::State) -> Feature;

    /// Makes a state's tracker slide over the object (switch only at patch boundaries), as a
    /// god-object does; see [`ChainTracker::set_sliding`].
    fn set_sliding(state: &mut Self::State, sliding: bool);

    /// Where a state's tracker is: patch and parameters (`[u, 0]` on curves).
    fn position(state: &Self::State) -> (usize, [f32; 2]);

    /// Puts a state's tracker on `patch` at `params`.
    fn place(&self, state: &mut Self::State, patch: usize, params: [f32; 2]);

    /// [`Object::frame`] at a state's position ([`Object::position`]), from the evaluation
    /// its tracker already made: no evaluation.
    fn state_frame(&self, state: &Self::State) -> PatchFrame<Self::P>;

    /// Point, unit outward normal and unit tangent (along the first parameter) of `patch` at
    /// `params`.
    fn frame(&self, patch: usize, params: [f32; 2]) -> PatchFrame<Self::P>;

    /// Parameters of the point reached by moving `displacement` (tangential, small) from
    /// `params` on `patch`: one Gauss–Newton step, clamped into the domain. `at` is the frame
    /// at `params` ([`Object::frame`]); the step takes its derivatives from it, so it costs no
    /// evaluation.
    fn offset(
        &self,
        patch: usize,
        params: [f32; 2],
        at: &PatchFrame<Self::P>,
        displacement: Self::P,
    ) -> [f32; 2];

    /// Number of patches (pieces: patches are split at load at their corners and creases).
    fn patch_count(&self) -> usize;

    /// Index of the patch given at construction that patch `patch` is a piece of (see
    /// [`Chain::source_curve`], [`Shell::source_patch`]). Parameters are shared: a piece is a
    /// window onto its source patch's parameter domain.
    fn source_patch(&self, patch: usize) -> usize;

    /// The object's topology ([`Object::Topology`]).
    fn topology(&self) -> Self::Topology;

    /// The point of `patch` at `params` (`[u, 0]` on curves), clamped into its domain.
    fn point(&self, patch: usize, params: [f32; 2]) -> Self::P;

    /// The point a state's tracker stands on, from its last evaluation (the object's point at
    /// [`Object::position`], not evaluated again).
    fn state_point(state: &Self::State) -> Self::P;

    /// The partial derivatives `∂S/∂u`, `∂S/∂v` where a state's tracker stands (`∂C/∂u` twice
    /// on curves), from its last evaluation: [`PatchFrame::derivatives`] without the frame's
    /// normalisations.
    fn state_derivatives(state: &Self::State) -> [Self::P; 2];

    /// Re-evaluates a state's tracker on this object where it stands (same patch, same
    /// parameters, same feature): for a state made on an object of the same topology whose
    /// control points have since moved, so that its next step starts from this geometry.
    /// One evaluation.
    fn refresh(&self, state: &mut Self::State);
}

impl<const K: usize, const P: usize> Object for Chain<K, P> {
    type P = Vec2;
    type State = ChainTracker;

    fn start(&self, hip: Vec2, cfg: TrackerConfig) -> ChainTracker {
        ChainTracker::new(self, hip, cfg)
    }

    fn track(
        &self,
        state: &mut ChainTracker,
        hip: Vec2,
        period_s: f32,
        allow_switch: bool,
    ) -> Contact<Vec2> {
        state.update(self, hip, period_s, allow_switch)
    }

    fn feature(state: &ChainTracker) -> Feature {
        state.feature()
    }

    fn set_sliding(state: &mut ChainTracker, sliding: bool) {
        state.set_sliding(sliding);
    }

    fn position(state: &ChainTracker) -> (usize, [f32; 2]) {
        let (i, u) = state.position();
        (i, [u, 0.0])
    }

    fn place(&self, state: &mut ChainTracker, patch: usize, params: [f32; 2]) {
        state.reset(self, patch, params[0]);
    }

    fn frame(&self, patch: usize, params: [f32; 2]) -> PatchFrame<Vec2> {
        let c = &self.curve(patch);
        frame_of(c, [params[0]])
    }

    fn state_frame(&self, state: &ChainTracker) -> PatchFrame<Vec2> {
        let (i, u) = state.position();
        let c = &self.curve(i);
        frame_from(c, [u], state.jet())
    }

    fn offset(
        &self,
        patch: usize,
        params: [f32; 2],
        at: &PatchFrame<Vec2>,
        displacement: Vec2,
    ) -> [f32; 2] {
        let c = &self.curve(patch);
        let t = offset_on(c, [params[0]], at, displacement);
        [t[0], 0.0]
    }

    fn patch_count(&self) -> usize {
        self.curve_count()
    }

    fn source_patch(&self, patch: usize) -> usize {
        self.source_curve(patch)
    }

    type Topology = ChainTopology;

    fn topology(&self) -> ChainTopology {
        Chain::topology(self)
    }

    fn point(&self, patch: usize, params: [f32; 2]) -> Vec2 {
        // Evaluation clamps into the domain itself (NaN to its start).
        self.curve(patch).point(params[0])
    }

    fn state_point(state: &ChainTracker) -> Vec2 {
        state.jet().point
    }

    fn state_derivatives(state: &ChainTracker) -> [Vec2; 2] {
        let d = state.jet().d[0];
        [d, d]
    }

    fn refresh(&self, state: &mut ChainTracker) {
        state.refresh(self);
    }
}

/// An object held by a unique reference is that object: a device keeps its chain in a static
/// slot and gives the controller `&'static mut Chain` (moved between tasks as a pointer, and
/// lent to the acquisition task whole, with nothing copied).
impl<O: Object + ?Sized> Object for &mut O {
    type P = O::P;
    type State = O::State;
    type Topology = O::Topology;

    #[inline]
    fn start(&self, hip: Self::P, cfg: TrackerConfig) -> Self::State {
        (**self).start(hip, cfg)
    }

    #[inline]
    fn track(
        &self,
        state: &mut Self::State,
        hip: Self::P,
        period_s: f32,
        allow_switch: bool,
    ) -> Contact<Self::P> {
        (**self).track(state, hip, period_s, allow_switch)
    }

    #[inline]
    fn feature(state: &Self::State) -> Feature {
        O::feature(state)
    }

    #[inline]
    fn set_sliding(state: &mut Self::State, sliding: bool) {
        O::set_sliding(state, sliding);
    }

    #[inline]
    fn position(state: &Self::State) -> (usize, [f32; 2]) {
        O::position(state)
    }

    #[inline]
    fn place(&self, state: &mut Self::State, patch: usize, params: [f32; 2]) {
        (**self).place(state, patch, params);
    }

    #[inline]
    fn state_frame(&self, state: &Self::State) -> PatchFrame<Self::P> {
        (**self).state_frame(state)
    }

    #[inline]
    fn frame(&self, patch: usize, params: [f32; 2]) -> PatchFrame<Self::P> {
        (**self).frame(patch, params)
    }

    #[inline]
    fn offset(
        &self,
        patch: usize,
        params: [f32; 2],
        at: &PatchFrame<Self::P>,
        displacement: Self::P,
    ) -> [f32; 2] {
        (**self).offset(patch, params, at, displacement)
    }

    #[inline]
    fn patch_count(&self) -> usize {
        (**self).patch_count()
    }

    #[inline]
    fn source_patch(&self, patch: usize) -> usize {
        (**self).source_patch(patch)
    }

    #[inline]
    fn topology(&self) -> Self::Topology {
        (**self).topology()
    }

    #[inline]
    fn point(&self, patch: usize, params: [f32; 2]) -> Self::P {
        (**self).point(patch, params)
    }

    #[inline]
    fn state_point(state: &Self::State) -> Self::P {
        O::state_point(state)
    }

    #[inline]
    fn state_derivatives(state: &Self::State) -> [Self::P; 2] {
        O::state_derivatives(state)
    }

    #[inline]
    fn refresh(&self, state: &mut Self::State) {
        (**self).refresh(state);
    }
}

impl<const K: usize, const P: usize> Object for Shell<K, P> {
    type P = Vec3;
    type State = ShellTracker;

    fn start(&self, hip: Vec3, cfg: TrackerConfig) -> ShellTracker {
        ShellTracker::new(self, hip, cfg)
    }

    fn track(
        &self,
        state: &mut ShellTracker,
        hip: Vec3,
        period_s: f32,
        allow_switch: bool,
    ) -> Contact<Vec3> {
        state.update(self, hip, period_s, allow_switch)
    }

    fn feature(state: &ShellTracker) -> Feature {
        state.feature()
    }

    fn set_sliding(state: &mut ShellTracker, sliding: bool) {
        state.set_sliding(sliding);
    }

    fn position(state: &ShellTracker) -> (usize, [f32; 2]) {
        state.position()
    }

    fn place(&self, state: &mut ShellTracker, patch: usize, params: [f32; 2]) {
        state.reset(self, patch, params);
    }

    fn frame(&self, patch: usize, params: [f32; 2]) -> PatchFrame<Vec3> {
        frame_of(&self.surface(patch), params)
    }

    fn state_frame(&self, state: &ShellTracker) -> PatchFrame<Vec3> {
        let (i, t) = state.position();
        frame_from(&self.surface(i), t, state.jet())
    }

    fn offset(
        &self,
        patch: usize,
        params: [f32; 2],
        at: &PatchFrame<Vec3>,
        displacement: Vec3,
    ) -> [f32; 2] {
        offset_on(&self.surface(patch), params, at, displacement)
    }

    fn patch_count(&self) -> usize {
        self.surface_count()
    }

    fn source_patch(&self, patch: usize) -> usize {
        Shell::source_patch(self, patch)
    }

    type Topology = ShellTopology;

    fn topology(&self) -> ShellTopology {
        Shell::topology(self)
    }

    fn point(&self, patch: usize, params: [f32; 2]) -> Vec3 {
        self.surface(patch).point(params[0], params[1])
    }

    fn state_point(state: &ShellTracker) -> Vec3 {
        state.jet().point
    }

    fn state_derivatives(state: &ShellTracker) -> [Vec3; 2] {
        state.jet().d
    }

    fn refresh(&self, state: &mut ShellTracker) {
        state.refresh(self);
    }
}

/// Point, unit outward normal and unit tangent of a patch at a parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchFrame<P> {
    /// The point.
    pub point: P,
    /// Unit outward normal.
    pub normal: P,
    /// Unit tangent along the first parameter (orthogonal to the normal).
    pub tangent: P,
    /// Unit tangent along the second parameter, orthogonalised against the normal (equal to
    /// `tangent` on curves).
    pub bitangent: P,
    /// The partial derivatives `∂S/∂u`, `∂S/∂v` there (`∂C/∂u` twice on curves): what a
    /// Gauss–Newton step from the point needs ([`Object::offset`]).
    pub derivatives: [P; 2],
}

fn frame_of<S: Patch<N>, const N: usize>(s: &S, t: [f32; N]) -> PatchFrame<S::P> {
    frame_from(s, t, &s.jet(t, 1))
}

/// The frame at `t` from the patch's jet there.
fn frame_from<S: Patch<N>, const N: usize>(
    s: &S,
    t: [f32; N],
    jet: &crate::patch::Jet<S::P, N>,
) -> PatchFrame<S::P> {
    let normal = s.normal(t, jet);
    let in_plane = |d: S::P| {
        (d - normal * d.dot(normal))
            .try_normalize()
            .unwrap_or(normal)
    };
    let tangent = in_plane(jet.d[0]);
    PatchFrame {
        point: jet.point,
        normal,
        tangent,
        bitangent: if N > 1 {
            in_plane(jet.d[N - 1])
        } else {
            tangent
        },
        derivatives: [jet.d[0], jet.d[N - 1]],
    }
}

fn offset_on<S: Patch<N>, const N: usize>(
    s: &S,
    t: [f32; N],
    at: &PatchFrame<S::P>,
    displacement: S::P,
) -> [f32; N] {
    let jet = crate::patch::Jet {
        point: at.point,
        d: core::array::from_fn(|i| at.derivatives[i.min(1)]),
        dd: [[S::P::ZERO; N]; N],
    };
    let step = crate::track::gauss_newton_step(&jet.metric(), &jet.psi(-displacement));
    let domain = s.domain();
    let mut out = t;
    for i in 0..N {
        out[i] = crate::track::clamp(t[i] + step[i], domain[i]);
    }
    out
}
