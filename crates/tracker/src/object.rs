//! One interface over 2-D chains and 3-D shells, so the layers above (friction, the device's
//! controller) are written once for both.

use crate::chain::{Chain, ChainTracker};
use crate::contact::{Contact, Feature};
use crate::patch::Patch;
use crate::shell::{Shell, ShellTracker, Side};
use crate::track::TrackerConfig;
use nurbs::{Point, Vec2, Vec3};

/// A multi-patch object whose closest point can be tracked.
pub trait Object {
    /// The space it lives in.
    type P: Point;
    /// Per-tick tracking state (feature and tracker); `Copy`, holds no borrow.
    type State: Copy + core::fmt::Debug;

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
    fn state_frame(&self, state: &Self::State) -> Frame<Self::P>;

    /// Point, unit outward normal and unit tangent (along the first parameter) of `patch` at
    /// `params`.
    fn frame(&self, patch: usize, params: [f32; 2]) -> Frame<Self::P>;

    /// Parameters of the point reached by moving `displacement` (tangential, small) from
    /// `params` on `patch`: one Gauss–Newton step, clamped into the domain. `at` is the frame
    /// at `params` ([`Object::frame`]); the step takes its derivatives from it, so it costs no
    /// evaluation.
    fn offset(
        &self,
        patch: usize,
        params: [f32; 2],
        at: &Frame<Self::P>,
        displacement: Self::P,
    ) -> [f32; 2];

    /// Number of patches (pieces: patches are split at load at their corners and creases).
    fn patch_count(&self) -> usize;

    /// The same point on the neighbouring patch, where `params` lies on a boundary of `patch`
    /// that it shares with another patch (a chain's vertex, a shell's edge) and `toward` (a
    /// tangential direction) leads out through that boundary; `None` inside a patch, on a free
    /// end or rim, or when `toward` leads back into the patch. This is how a god-object
    /// sliding over the object finds the patch it crosses onto. `at` is the frame at `params`
    /// ([`Object::frame`]), whose tangents tell the way out.
    fn neighbour(
        &self,
        patch: usize,
        params: [f32; 2],
        at: &Frame<Self::P>,
        toward: Self::P,
    ) -> Option<(usize, [f32; 2])>;

    /// Index of the patch given at construction that patch `patch` is a piece of (see
    /// [`Chain::source_curve`], [`Shell::source_patch`]). Parameters are shared: a piece is a
    /// window onto its source patch's parameter domain.
    fn source_patch(&self, patch: usize) -> usize;
}

/// Whether `t` sits on the end `end` of `(a, b)`, within 1e-4 of the domain's size: a point
/// that slid along a boundary by Gauss–Newton steps drifts off it by f32 rounding of the steps.
fn at_end(t: f32, (a, b): (f32, f32), end: bool) -> bool {
    let tol = 1e-4 * nurbs::math::max(f32::MIN_POSITIVE, (b - a).abs());
    if end { t >= b - tol } else { t <= a + tol }
}

impl Object for Chain<'_> {
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

    fn frame(&self, patch: usize, params: [f32; 2]) -> Frame<Vec2> {
        let c = &self.curves()[patch.min(self.curves().len() - 1)];
        frame_of(c, [params[0]])
    }

    fn state_frame(&self, state: &ChainTracker) -> Frame<Vec2> {
        let (i, u) = state.position();
        let c = &self.curves()[i.min(self.curves().len() - 1)];
        frame_from(c, [u], state.jet())
    }

    fn offset(
        &self,
        patch: usize,
        params: [f32; 2],
        at: &Frame<Vec2>,
        displacement: Vec2,
    ) -> [f32; 2] {
        let c = &self.curves()[patch.min(self.curves().len() - 1)];
        let t = offset_on(c, [params[0]], at, displacement);
        [t[0], 0.0]
    }

    fn patch_count(&self) -> usize {
        self.curves().len()
    }

    fn neighbour(
        &self,
        patch: usize,
        params: [f32; 2],
        at: &Frame<Vec2>,
        toward: Vec2,
    ) -> Option<(usize, [f32; 2])> {
        let curves = self.curves();
        let c = curves.get(patch)?;
        let domain = c.domain();
        let tangent = at.tangent;
        for v in self.vertices() {
            let (this, other, leaving) =
                if at_end(params[0], domain, true) && v.incoming == Some(patch as u16) {
                    (true, v.outgoing, toward.dot(tangent) > 0.0)
                } else if at_end(params[0], domain, false) && v.outgoing == Some(patch as u16) {
                    (true, v.incoming, toward.dot(tangent) < 0.0)
                } else {
                    (false, None, false)
                };
            if !this || !leaving {
                continue;
            }
            let j = other? as usize;
            if j == patch {
                return None;
            }
            let (a, b) = curves[j].domain();
            let u = if v.outgoing == Some(j as u16) { a } else { b };
            return Some((j, [u, 0.0]));
        }
        None
    }

    fn source_patch(&self, patch: usize) -> usize {
        self.source_curve(patch)
    }
}

impl Object for Shell<'_> {
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

    fn frame(&self, patch: usize, params: [f32; 2]) -> Frame<Vec3> {
        let s = &self.patches()[patch.min(self.patches().len() - 1)];
        frame_of(s, params)
    }

    fn state_frame(&self, state: &ShellTracker) -> Frame<Vec3> {
        let (i, t) = state.position();
        let s = &self.patches()[i.min(self.patches().len() - 1)];
        frame_from(s, t, state.jet())
    }

    fn offset(
        &self,
        patch: usize,
        params: [f32; 2],
        at: &Frame<Vec3>,
        displacement: Vec3,
    ) -> [f32; 2] {
        let s = &self.patches()[patch.min(self.patches().len() - 1)];
        offset_on(s, params, at, displacement)
    }

    fn neighbour(
        &self,
        patch: usize,
        params: [f32; 2],
        at: &Frame<Vec3>,
        toward: Vec3,
    ) -> Option<(usize, [f32; 2])> {
        let s = self.patches().get(patch)?;
        let (du, dv) = s.domain();
        let fr = at;
        // Sides in the order of `Side`: u = u_min, u = u_max, v = v_min, v = v_max; the one
        // `toward` leaves through fastest.
        let on = [
            at_end(params[0], du, false) && toward.dot(fr.tangent) < 0.0,
            at_end(params[0], du, true) && toward.dot(fr.tangent) > 0.0,
            at_end(params[1], dv, false) && toward.dot(fr.bitangent) < 0.0,
            at_end(params[1], dv, true) && toward.dot(fr.bitangent) > 0.0,
        ];
        let speed = [
            -toward.dot(fr.tangent),
            toward.dot(fr.tangent),
            -toward.dot(fr.bitangent),
            toward.dot(fr.bitangent),
        ];
        let side = (0..4)
            .filter(|&k| on[k])
            .max_by(|&a, &b| speed[a].total_cmp(&speed[b]))?;
        let Side::Shared(e) = self.sides(patch)[side] else {
            return None;
        };
        let edge = *self.edges().get(e as usize)?;
        let (other, other_side) = if edge.a == (patch as u16, side as u8) {
            edge.b?
        } else {
            edge.a
        };
        let o = self.patches().get(other as usize)?;
        let (ou, ov) = o.domain();
        // Where along the side the point is, as a fraction, carried over to the other side.
        let (run, run_domain) = if side < 2 {
            (params[1], dv)
        } else {
            (params[0], du)
        };
        let mut f = (run - run_domain.0) / (run_domain.1 - run_domain.0);
        if edge.reversed {
            f = 1.0 - f;
        }
        let lerp = |(a, b): (f32, f32), f: f32| a + (b - a) * f.clamp(0.0, 1.0);
        let p = match other_side {
            0 => [ou.0, lerp(ov, f)],
            1 => [ou.1, lerp(ov, f)],
            2 => [lerp(ou, f), ov.0],
            _ => [lerp(ou, f), ov.1],
        };
        Some((other as usize, p))
    }

    fn patch_count(&self) -> usize {
        self.patches().len()
    }

    fn source_patch(&self, patch: usize) -> usize {
        Shell::source_patch(self, patch)
    }
}

/// Point, unit outward normal and unit tangent of a patch at a parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame<P> {
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

fn frame_of<S: Patch<N>, const N: usize>(s: &S, t: [f32; N]) -> Frame<S::P> {
    frame_from(s, t, &s.jet(t, 1))
}

/// The frame at `t` from the patch's jet there.
fn frame_from<S: Patch<N>, const N: usize>(
    s: &S,
    t: [f32; N],
    jet: &crate::patch::Jet<S::P, N>,
) -> Frame<S::P> {
    let normal = s.normal(t, jet);
    let in_plane = |d: S::P| {
        (d - normal * d.dot(normal))
            .try_normalize()
            .unwrap_or(normal)
    };
    let tangent = in_plane(jet.d[0]);
    Frame {
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
    at: &Frame<S::P>,
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
