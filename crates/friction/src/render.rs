//! The friction renderer: contact tracking, the stick–slip state machine of Algorithm 1 with
//! its god-object (GO), and the alternative friction laws, all producing one force per tick.
//!
//! # Algorithm 1, as implemented: a god-object on the surface
//!
//! Two trackers ride on the object. The closest point (CP) is tracked with feature switching
//! always on: it says whether the HIP is inside, and how deep. The *proxy* is a tracker in
//! sliding mode ([`Object::set_sliding`]): it moves over the surface from where the GO is, and
//! changes patch only where it reaches a patch's end, never by jumping across a Voronoi
//! boundary; it is the frictionless god-object of Zilles & Salisbury, the local closest point
//! of the patch the contact is on. Where the CP is on the GO's patch the proxy is the CP (the
//! same local closest point, no second evaluation); past a vertex it takes its own step.
//!
//! The GO is the anchor of a spring from the HIP, and the whole elastic force is that spring,
//! split about the normal `n` of the GO's patch (the proxy's normal where the GO was put, the
//! CP's while the CP is on that patch):
//!
//! `F_N = max(0, K a − b v·n)`, `a = (GO − HIP)·n`;  `F_T = K t`, `t` the spring's tangential
//! part;  `F = F_N n + F_T`;  `v` the HIP's velocity low-passed over 5 ms (an encoder's count at
//! 10 kHz is a 0.2 m/s step of a backward difference).
//!
//! The friction cone is `|F_T| ≤ μ F_N`, the damping's share of `F_N` included. Each tick
//! first decides the state machine's edge from the spring as the HIP left it (one match arm
//! per mode, each edge with its [`SwitchCause`]), then moves the GO as the new mode says, then
//! advances the frictional memory.
//!
//! - **Free → stuck** on contact ([`SwitchCause::Contact`]): the GO is put at the HIP's foot in
//!   the CP's tangent plane, the proxy at the CP.
//! - **Stuck**: the GO stays where it is, so the force is a plain spring to a fixed point. The
//!   CP keeps switching Voronoi regions; the GO and its patch (the interaction surface) stay,
//!   so static friction holds across a convex vertex's bisector (§3.1.2) for as long as the
//!   spring lies in that patch's cone, and the force is continuous there.
//! - **Stuck → transition** when the spring leaves the cone, `|t| > μ_s a_n + h`
//!   ([`SwitchCause::Breakaway`]; `h` the HIP's resolution, [`FrictionRenderer::set_resolution`]).
//! - **Transition and slip**: while the spring lies outside the cone of the mode's μ, the GO
//!   slides: the proxy `P` (normal `n_P`, depth `a_P` under its tangent plane) is where it is
//!   going, and the GO goes back from the HIP's foot in P's tangent plane towards where it was,
//!   to the cone's edge: `GO = HIP + a n_P + μ (F_N/K a) a t̂`, at the true depth `a = a_P`, or,
//!   where the spring before was shorter than that edge, at the old spring's length (turned
//!   about the HIP onto the edge). Either way the friction is `μ F_N` and the spring is never
//!   longer than before. The GO stays over the proxy's patch (a back-off towards a GO beyond a
//!   valley's vertex stops at the vertex). At a valley's vertex or edge, where the proxy sits on
//!   the feature itself, the GO is the feature's point: the feature's normal cone (between its
//!   faces' normals) holds any spring there with no friction needed. With `μ = 0` the GO is the
//!   proxy and the force is the god-object's wall: the penalty wall `K d n` on smooth geometry
//!   and away from vertices, the entry face's wall across a convex vertex's bisector.
//! - **The transition** (§3.1.1) lowers μ from `μ_s` to `μ_d` along the material's Stribeck
//!   shape ([`crate::Stribeck`]) as it progresses, and it progresses at `min(1, v/v_s)/τ`, with
//!   `v` the contact's sliding speed over the object (the CP's, low-passed over 5 ms so that an
//!   encoder's count-at-a-time steps at 10 kHz do not slow it), `v_s` the Stribeck speed and τ
//!   `transition_time_s`: a slide at or above `v_s` takes τ to reach μ_d, a slower one
//!   `τ v_s / v`. So a faster hand loses static friction sooner, and μ never rises again while
//!   sliding.
//! - **Transition → slip** once the GO at μ sits within `converge_tol_m` of its slip position at
//!   μ_d, `(μ − μ_d) d ≤ converge_tol_m` ([`SwitchCause::Converged`]); slip renders `μ_d`.
//! - **Dynamic → stuck** (transition or slip, Algorithm 1's DYNAMIC state), each only where the
//!   spring already lies in the cone the new mode holds, so the force carries on unchanged:
//!   when the normal force jumps, `μ_d (F_N[k] − K h) > μ_s F_N[k−1]`
//!   ([`SwitchCause::NormalForceJump`]); when the HIP's step moves back towards the GO (in the
//!   tangent plane, faster than the stop speed) and the spring has relaxed a tenth, and `2 h`,
//!   inside the cone ([`SwitchCause::Reversed`]); or when the GO has travelled less than the stop
//!   speed's worth in the last 5 ms ([`SwitchCause::Stopped`]): a stop is read from the GO's own
//!   motion, so a tick labelled slip or transition is one within 5 ms of the GO sliding.
//! - **Contact lost → free** once the HIP is out of the object by more than `h`
//!   ([`SwitchCause::Released`]).
//!
//! # Why this design: passive by construction at every feature
//!
//! The storage function is the spring's energy with the normal part that would pull left out,
//!
//! `E = ½ K (|t|² + max(0, a)²)`,
//!
//! whose gradient in the HIP, with the GO and `n` fixed, is exactly `−(F_N n + F_T)` without
//! damping; the damping only takes energy out (`F_N` never below zero, the damping opposing the
//! normal velocity, and where it lowers `F_N` the cone, and with it `F_T`, shrinks by a slide,
//! not by scaling the force). While the GO stands still (stuck, or dynamic with the spring in
//! the cone) the force is conservative; every GO move — a slide, a patch change, the turn onto
//! the cone's edge, the GO put on a valley's vertex — is checked never to raise `E` beyond the
//! rounding of an f32 surface point (two ulps, 3e-8 m of length: at most `K |v| 3e-8` a tick,
//! 0.15 µJ at 5 mm and 1000 N/m, with no sign), and where a move would raise it the GO is taken
//! back along the spring. So over any stretch of the HIP's path the work done on the hand is at
//! most `E(start) − E(end)`; a contact starts at `½ K d²` of a HIP barely inside and ends at
//! zero, and a closed path from free space to free space does no positive work, in every mode,
//! at convex and concave vertices, C⁰ knots, valleys, shell edges, curved chains and shells,
//! for every μ, at 1 and 10 kHz. The cone's normal may change between ticks (it turns with the
//! CP): that changes how the spring is split, never `|GO − HIP|`, and the split only decides
//! when the GO moves.
//!
//! This closes the single spring's pump at concave vertices: there the cone was about the CP's
//! normal, which in a valley's internal wedge is the line from the vertex to the HIP; a slide
//! parked the GO on that line's perpendicular, inside the object, and the next breakaway moved
//! it out to the true depth, lengthening the spring (+157 µJ a lap on the loop).
//!
//! # Where the force may jump
//!
//! Only where the stored energy falls: where the HIP leaves the GO's patch's reach (past the
//! end of a face at a convex vertex the proxy goes over to the next face and the GO with it,
//! the spring getting shorter: the god-object's wall turns from one face's to the other's), and
//! where contact ends (the force drops to zero). Across a convex vertex's bisector and a C⁰
//! knot, within both faces' reach, the force changes per tick by `K |ΔHIP|` plus what the cone
//! and μ change (measured: at most `K |ΔHIP|`, 0.010 N at 10 µm steps, on roofs 60°–120° and
//! thesis-2d's arcs at 1–4 mm, where the single spring turned by the whole angle between the
//! normals, 4–7 N at 4 mm).
//!
//! # Where this departs from a literal reading of the thesis
//!
//! - The thesis keeps the GO on the CP while slipping and adds `μ_d F_N` as a separate vector;
//!   on slip → stuck it "resets the GO to a location that ensures force continuity" (an offset
//!   added to `F_T`). That reset stretches the spring out of nothing and injects `½ F_f² / K`
//!   of energy each time. Here the GO stays where the spring already carries the friction, which
//!   gives the same forces with friction that can only dissipate.
//! - The thesis's transition modulates μ by the GO's speed; a μ that follows a falling
//!   μ(speed) curve in steady sliding is velocity-weakening, which makes a steady slide between
//!   `τ v_s² / ((μ_s − μ_d) d)` and `v_s` judder (stick–slip at 7–8 Hz, measured). Here the speed
//!   sets how fast the transition runs, and slip is μ_d as in the thesis's Fig. 3.1.1(b): the
//!   steady friction is a function of the present mode, not of how the slide was reached.
//! - The stuck self-transition of Fig. 3.1.2 (reset the GO to the CP when the CP stops or
//!   reverses while stuck) is not implemented. It would drop the friction force to zero in one
//!   tick, a step of up to `μ_s F_N`, and the thesis's own Fig. 3.2.2 contradicts it: in 4 → 5
//!   and 10 → 11 the HIP presses along the normal (the CP stands still) while stuck and "the
//!   friction force is kept still".
//! - The thesis inhibits the CP's Voronoi switching while stuck (§3.1.2) to keep the interaction
//!   surface; here the CP keeps switching (its depth stays the object's true depth) and the
//!   interaction surface is kept by the GO's own patch and the proxy, stuck or sliding.
//! - The thesis's Fig. 3.1.2, its text and Algorithm 1 state the normal-force test three ways;
//!   Algorithm 1's `μ_d F_N[k] > μ_s F_N[k−1]` is used (the text's ratio, read literally, would
//!   fire on a fall of the normal force, contradicting its own "sudden increase").

mod laws;
mod output;

pub use output::{Anchors, FrictionOutput, Mode, SwitchCause};

use crate::material::{FrictionMaterial, ModelKind};
use crate::models::{CoulombViscous, Dahl, Karnopp, LuGre};
use laws::LawState;
use nurbs::Point;
use nurbs::math::{self, sqrt};
use tracker::{Contact, Feature, Object, PatchFrame};

/// How far the spring must relax inside the cone of the dynamic mode's μ (as a fraction of
/// `μ F_N`), with the HIP moving back towards the GO, before the motion counts as reversed: the
/// jitter of a handle held by a compliant hand does not.
const REVERSAL_HYSTERESIS: f32 = 0.1;

/// The GO's slip speed is low-passed over this share of `transition_time_s`: long enough that a
/// tick or two without a slide (the jitter of a compliant hand) does not stop a slide, short
/// enough that a hand that stops is stuck again within `ln(v / v_stop) τ / 3`, 80 ms after a
/// 20 mm/s slide at the default τ = 60 ms.
const SLIP_SPEED_MEMORY: f32 = 1.0 / 3.0;

/// A dynamic mode sticks once the GO has travelled less than the stop speed's worth over this
/// long (s), with the spring inside the cone: a stop is read from the GO's own motion, and 5 ms
/// of it, so that a stick is never undone by the next encoder count of a slow slide within
/// 5 ms (one count of 19.6 µm every 5 ms is 4 mm/s, which keeps the GO sliding).
const STOP_HOLD_S: f32 = 5e-3;

/// The rounding of an f32 point of the surface in a workspace within 0.25 m (m): two ulps of
/// 1.5e-8 m. A slide may lengthen the spring by this much (rounding, not geometry: no sign, so
/// no systematic gain), at most `K |GO − HIP| × 3e-8` of storage, 0.15 µJ at 5 mm and
/// 1000 N/m.
const ROUNDING_M: f32 = 3e-8;

/// Relative f32 slack of the cone test on `|F_T|²` (1e-5 on `|F_T|`): a spring the GO was just
/// put on the edge of counts as inside.
const CONE_SLACK: f32 = 2e-5;

/// The whole friction renderer for one object: CP tracker, GO and state machine.
#[derive(Clone, Copy, Debug)]
pub struct FrictionRenderer<O: Object> {
    material: FrictionMaterial,
    cp: O::State,
    /// The proxy: a tracker in sliding mode, the point of the surface the GO slides about (the
    /// frictionless god-object: the local closest point reached by sliding over the surface
    /// from where the GO was, never by jumping across a Voronoi boundary).
    proxy: O::State,
    /// The GO: the anchor of the friction spring, in the proxy's tangent plane where it was
    /// put.
    go: O::P,
    /// The patch and parameters under the GO (one Gauss–Newton step from the proxy it was put
    /// beside), and that proxy's frame: the cone's normal and the sign reference of the
    /// friction.
    go_patch: usize,
    go_params: [f32; 2],
    go_frame: PatchFrame<O::P>,
    /// The position resolution of the HIP (m, the encoder quantum at the handle; 0 for exact
    /// positions): the hysteresis of the mode decisions.
    resolution_m: f32,
    /// Time since the GO last slid (s): since the GO's travel last reached the stop speed
    /// times [`STOP_HOLD_S`].
    since_slide_s: f32,
    /// The GO's travel since then (m).
    held_travel_m: f32,
    /// The CP's feature on the last tick.
    cp_feature: Feature,
    /// The HIP's velocity (m/s), low-passed over [`STOP_HOLD_S`]: the damping's.
    hip_velocity: O::P,
    /// The CP's velocity over the object (m/s), low-passed over [`STOP_HOLD_S`]: the
    /// transition's pace.
    cp_velocity: O::P,
    /// Whether the proxy (and the GO with it) is on a feature of its own, a valley's vertex or
    /// edge: its normal is then the line from the HIP to it, whatever the HIP's place in the
    /// feature's normal cone (the feature holds any force there, with no friction needed).
    go_on_feature: bool,
    mode: Mode,
    cause: SwitchCause,
    law: LawState<O::P>,
    /// The GO's slip speed (m/s), low-passed over `transition_time_s`.
    slip_speed: f32,
    /// How far the transition has run, 0 at breakaway to 1 at μ_d.
    progress: f32,
    prev_cp: Option<O::P>,
    prev_hip: Option<O::P>,
    prev_normal_force: f32,
}

/// The CP tracker's settings: one Gauss–Newton step per tick.
pub fn cp_config() -> tracker::TrackerConfig {
    tracker::TrackerConfig::default()
}

/// The spring from the HIP to the GO, split about the GO's normal `n`: its tangential part `t`,
/// and the normal force it carries with the damping, as a length: `a_n = F_N / K =
/// max(0, a − (b/K) v·n)`, `a` its normal part (m, positive when the GO is outward of the HIP).
#[derive(Clone, Copy, Debug)]
struct Spring<P> {
    t: P,
    a_n: f32,
}

impl<P: Point> Spring<P> {
    /// `damping_m` is `(b/K) v·n`, the damping's share of the normal force as a length.
    fn new(go: P, hip: P, n: P, damping_m: f32) -> Self {
        let v = go - hip;
        let a = v.dot(n);
        Spring {
            t: v - n * a,
            a_n: math::max(0.0, a - damping_m),
        }
    }

    /// Whether the force lies outside the cone `|F_T| ≤ μ F_N` widened by `margin_m` of
    /// tangential stretch (`|t| > μ a_n + margin`): a spring that pulls, or whose damping
    /// takes its normal force to zero, is outside unless it has no tangential part.
    fn outside(&self, mu: f32, margin_m: f32) -> bool {
        self.t.length_squared() > square(mu * self.a_n + margin_m) * (1.0 + CONE_SLACK)
    }

    /// Whether it lies inside the cone of `μ` shrunk by the fraction `fraction` and by
    /// `margin_m` of tangential stretch.
    fn inside(&self, mu: f32, fraction: f32, margin_m: f32) -> bool {
        let edge = (1.0 - fraction) * mu * self.a_n - margin_m;
        edge >= 0.0 && self.t.length_squared() <= square(edge) * (1.0 + CONE_SLACK)
    }
}

impl<O: Object> FrictionRenderer<O> {
    /// A renderer for `object` with `material`, starting from a HIP at `hip`.
    ///
    /// This runs the object's global closest-point search ([`Object::start`]), far dearer than
    /// a tick; a loop with a deadline runs the search elsewhere and hands its result to
    /// [`FrictionRenderer::from_tracking`].
    pub fn new(object: &O, material: FrictionMaterial, hip: O::P) -> Self {
        Self::from_tracking(object, material, object.start(hip, cp_config()))
    }

    /// A renderer for `object` with `material` whose CP tracker starts from `cp` (a state of
    /// [`Object::start`] with [`cp_config`], possibly found for an earlier HIP: the tracker's
    /// feedback follows the HIP from there). Costs one frame evaluation, no search. The tick's
    /// period is each [`FrictionRenderer::tick`]'s own.
    pub fn from_tracking(object: &O, material: FrictionMaterial, cp: O::State) -> Self {
        let (go_patch, go_params) = O::position(&cp);
        let law = match material.model {
            ModelKind::StickSlip => LawState::StickSlip,
            ModelKind::CoulombViscous => LawState::Coulomb(CoulombViscous {
                mu: material.mu_dynamic,
                viscous_ns_per_m: material.viscous_ns_per_m,
            }),
            ModelKind::Karnopp => LawState::Karnopp(Karnopp {
                mu_static: material.mu_static,
                mu_dynamic: material.mu_dynamic,
                viscous_ns_per_m: material.viscous_ns_per_m,
                band_m_per_s: material.karnopp_band_m_per_s,
            }),
            ModelKind::Dahl => LawState::Dahl(Dahl {
                mu: material.mu_dynamic,
                sigma0_n_per_m: material.bristle_stiffness_n_per_m,
                state: O::P::ZERO,
            }),
            ModelKind::LuGre => LawState::LuGre(LuGre {
                mu_static: material.mu_static,
                mu_dynamic: material.mu_dynamic,
                sigma0_n_per_m: material.bristle_stiffness_n_per_m,
                sigma1_ns_per_m: material.bristle_damping_ns_per_m,
                sigma2_ns_per_m: material.viscous_ns_per_m,
                stribeck_speed_m_per_s: material.stribeck_speed_m_per_s,
                z: O::P::ZERO,
            }),
        };
        let go_frame = object.frame(go_patch, go_params);
        let mut proxy = cp;
        O::set_sliding(&mut proxy, true);
        FrictionRenderer {
            material,
            cp,
            proxy,
            go: go_frame.point,
            go_patch,
            go_params,
            go_frame,
            resolution_m: 0.0,
            since_slide_s: 0.0,
            held_travel_m: 0.0,
            cp_feature: O::feature(&cp),
            hip_velocity: O::P::ZERO,
            cp_velocity: O::P::ZERO,
            go_on_feature: false,
            mode: Mode::Free,
            cause: SwitchCause::None,
            law,
            slip_speed: 0.0,
            progress: 0.0,
            prev_cp: None,
            prev_hip: None,
            prev_normal_force: 0.0,
        }
    }

    /// The renderer carried from `old` onto `new`, the same object with its control points
    /// moved: [`FrictionRenderer::follow_reshape`] on a renderer taken by value.
    pub fn reshape(mut self, old: &O, new: &O) -> Self {
        self.follow_reshape(old, new);
        self
    }

    /// Carries the renderer from `old` onto `new`, the same object with its control points
    /// moved (equal [`Object::topology`]: the caller checks it), between two ticks: mode,
    /// friction memory, material and the CP tracker's feature stay; no search, no restart.
    /// The next tick is `new`'s.
    ///
    /// What rides on the surface moves with it. The GO is a material point of the object
    /// while stuck (the finger stuck to a surface goes where the surface goes), so it is
    /// displaced by `new(go) − old(go)` at its patch and parameters, and with it the spring:
    /// the force changes by `K` times that displacement, which is at most the largest
    /// control-point move (a NURBS point with its weights unchanged is a convex combination
    /// of the control points, `ΔS(u) = Σ Rᵢ(u) ΔPᵢ`, `Rᵢ ≥ 0`, `Σ Rᵢ = 1`). The last tick's
    /// CP and HIP are displaced with the surface under them too, so the next tick's CP speed
    /// and HIP step are measured against the object, not against the room: a surface that
    /// moves under a still hand does not read as a slide. The CP tracker is re-evaluated where
    /// it stands ([`Object::refresh`]). Three evaluations (one when free).
    pub fn follow_reshape<O2: Object<P = O::P, State = O::State>>(&mut self, old: &O, new: &O2) {
        let anchors = self.anchors(old);
        self.follow_anchors(anchors, new);
    }

    /// Where what rides on the surface is on `object` ([`FrictionRenderer::follow_reshape`]):
    /// the points of the surface under the CP and under the GO. Take them before the object
    /// moves when it moves in place, and give them to [`FrictionRenderer::follow_anchors`]
    /// after.
    pub fn anchors(&self, object: &O) -> Anchors<O::P> {
        Anchors {
            // The tracker's own evaluation of `object` where it stands.
            cp: O::state_point(&self.cp),
            // Free, the GO is the CP and is put anew on contact.
            go: (self.mode != Mode::Free).then(|| object.point(self.go_patch, self.go_params)),
        }
    }

    /// The second half of [`FrictionRenderer::follow_reshape`]: `before` are the
    /// [`anchors`](FrictionRenderer::anchors) on the object before it moved, `new` the object
    /// now.
    pub fn follow_anchors<O2: Object<P = O::P, State = O::State>>(
        &mut self,
        before: Anchors<O::P>,
        new: &O2,
    ) {
        // The proxy is not evaluated again: its next step starts from its old jet and evaluates
        // the new shape where it lands (one evaluation fewer at the tick boundary).
        new.refresh(&mut self.cp);
        let cp_shift = O2::state_point(&self.cp) - before.cp;
        let go_shift = match before.go {
            Some(go) => new.point(self.go_patch, self.go_params) - go,
            None => cp_shift,
        };
        if let Some(p) = self.prev_cp.as_mut() {
            *p += cp_shift;
        }
        self.go += go_shift;
        self.go_frame.point += go_shift;
        if let Some(p) = self.prev_hip.as_mut() {
            *p += go_shift;
        }
    }

    /// Sets the HIP's position resolution (m): the encoder quantum at the handle of the device
    /// whose positions reach [`FrictionRenderer::tick`] (0, the default, for exact positions).
    /// Every mode decision gets that much hysteresis: a breakaway needs the spring `h` past
    /// the static cone, a reversal `2 h` back inside the dynamic one, a normal-force jump
    /// `K h` more than Algorithm 1's, and contact ends `h` outside the object, so that a
    /// one-count step cannot flip a mode and the next undo it. Negative or non-finite: 0.
    pub fn set_resolution(&mut self, resolution_m: f32) {
        self.resolution_m = if resolution_m.is_finite() {
            math::max(0.0, resolution_m)
        } else {
            0.0
        };
    }

    /// Current mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Why the mode last changed.
    pub fn cause(&self) -> SwitchCause {
        self.cause
    }

    /// The material.
    pub fn material(&self) -> &FrictionMaterial {
        &self.material
    }

    fn switch(&mut self, mode: Mode, cause: SwitchCause) {
        if self.mode != mode {
            self.mode = mode;
            self.cause = cause;
        }
    }

    /// μ of the transition at its present progress: μ_s at breakaway, μ_d at the end, along the
    /// Stribeck shape.
    fn transition_mu(&self) -> f32 {
        let m = &self.material;
        m.stribeck
            .mu(m.mu_static, m.mu_dynamic, 1.0 - self.progress)
    }

    /// The state machine's edge this tick (Fig. 3.1.2), decided from the spring as the HIP left
    /// it, before the GO moves: the new mode and its cause, or `None` to stay. Each decision
    /// has a hysteresis of [`FrictionRenderer::set_resolution`]'s quantum, so that a one-count
    /// step of an encoder cannot undo it.
    fn edge(
        &self,
        spring: &Spring<O::P>,
        depth: f32,
        hip_step: O::P,
        period_s: f32,
    ) -> Option<(Mode, SwitchCause)> {
        let m = &self.material;
        let k = m.stiffness_n_per_m;
        let h = self.resolution_m;
        let normal_force = k * spring.a_n;
        match self.mode {
            Mode::Free => Some((Mode::Stuck, SwitchCause::Contact)),
            Mode::Stuck => spring
                .outside(m.mu_static, h)
                .then_some((Mode::Transition, SwitchCause::Breakaway)),
            Mode::Transition | Mode::Slip => {
                let mu = if self.mode == Mode::Slip {
                    m.mu_dynamic
                } else {
                    self.transition_mu()
                };
                // Algorithm 1: μ_d F_N[k] > μ_s F_N[k−1]; a relative margin keeps f32 noise from
                // firing it when μ_s = μ_d, and the HIP's resolution (K h of normal force) one
                // encoder count at light contact.
                let jump = m.mu_dynamic * (normal_force - k * h)
                    > m.mu_static * self.prev_normal_force * (1.0 + 1e-4) + 1e-6;
                // The HIP's step back towards the GO, in the tangent plane, faster than the
                // stop speed.
                let back_m = hip_step.dot(spring.t);
                let back = back_m > 0.0
                    && square(back_m)
                        > square(m.stop_speed_m_per_s * period_s) * spring.t.length_squared();
                if jump && spring.inside(m.mu_static, 0.0, 0.0) {
                    Some((Mode::Stuck, SwitchCause::NormalForceJump))
                } else if back && spring.inside(mu, REVERSAL_HYSTERESIS, 2.0 * h) {
                    Some((Mode::Stuck, SwitchCause::Reversed))
                } else if self.since_slide_s >= STOP_HOLD_S - 0.5 * period_s
                    && spring.inside(mu, 0.0, 0.0)
                {
                    Some((Mode::Stuck, SwitchCause::Stopped))
                } else if self.mode == Mode::Transition
                    && (mu - m.mu_dynamic) * depth <= m.converge_tol_m
                {
                    Some((Mode::Slip, SwitchCause::Converged))
                } else {
                    None
                }
            }
        }
    }

    /// The stop hold starts again: the GO has just slid (or started to).
    fn restart_stop_clock(&mut self) {
        self.since_slide_s = 0.0;
        self.held_travel_m = 0.0;
    }

    /// Puts the GO on the proxy (on contact): the proxy is the CP's tracker, sliding.
    fn place_go_on_cp(&mut self, object: &O, contact: &Contact<O::P>, hip: O::P) {
        self.proxy = self.cp;
        O::set_sliding(&mut self.proxy, true);
        let (patch, params) = O::position(&self.proxy);
        self.go_frame = object.state_frame(&self.proxy);
        // The HIP's foot in the CP's tangent plane: no tangential spring from the tracker's
        // residual.
        self.go_on_feature = !matches!(contact.feature, Feature::Patch(_));
        if self.go_on_feature {
            self.go_frame.normal = contact.normal;
        }
        let n = self.go_frame.normal;
        self.go = hip + n * (self.go_frame.point - hip).dot(n);
        self.go_patch = patch;
        self.go_params = params;
    }

    /// The slide (Transition and Slip, spring outside the cone of `mu`) towards the proxy's
    /// contact `pc` this tick: the GO goes back from the HIP's foot in the proxy's tangent
    /// plane towards where it was, onto the edge of the cone of `mu` about the proxy's normal
    /// (see the module docs), never farther from the HIP than before beyond rounding. Returns
    /// the distance the GO moved.
    fn slide(
        &mut self,
        object: &O,
        pc: Contact<O::P>,
        hip: O::P,
        hip_velocity: O::P,
        mu: f32,
    ) -> f32 {
        let m = &self.material;
        let damping_per_k = m.damping_ns_per_m / m.stiffness_n_per_m;
        // At a valley's vertex the proxy's normal runs along the HIP's line to it (the
        // vertex's normal cone holds the spring, with no friction needed).
        let n = pc.normal;
        let p = pc.point;
        let on_feature = !matches!(pc.feature, Feature::Patch(_));
        // The HIP's foot in the proxy's tangent plane: the GO goes back from it, so that the
        // spring's tangential part is exactly the slide's (the proxy's own residual, a tracker
        // step from converged, does not add friction).
        let a_p = (p - hip).dot(n);
        let foot = hip + n * a_p;
        let a_n = math::max(0.0, a_p - damping_per_k * hip_velocity.dot(n));
        let back = tangential(self.go - foot, n);
        let back_sq = back.length_squared();
        // The storage is ½ K (|t|² + max(0, a)²) (a spring that would pull renders no normal
        // force); as lengths²: before, and its bound on |GO − HIP|² after (the GO in the
        // proxy's tangent plane has the proxy's a).
        let before = self.go - hip;
        let a_before = before.dot(self.go_frame.normal);
        let old_sq = math::max(
            0.0,
            before.length_squared() - square(math::min(0.0, a_before)),
        ) + square(math::min(0.0, a_p));
        let (unit, back_len) = if back_sq > f32::MIN_POSITIVE && !on_feature {
            let len = sqrt(back_sq);
            (back * (1.0 / len), len)
        } else {
            (O::P::ZERO, 0.0)
        };
        // What f32 rounding of a surface point can add to the spring's length², allowed: a
        // GO held off the surface by every tick's rounding would ratchet into the object
        // (1 µm in 5,000 ticks of a withdrawing hand, measured), and rounding has no sign.
        let slack_sq = ROUNDING_M * (2.0 * sqrt(old_sq) + ROUNDING_M);
        let mut go = if a_p <= 0.0 {
            // The HIP is out of the proxy's tangent plane (within the contact's hysteresis):
            // the spring goes slack.
            hip
        } else {
            // On the cone's edge, `a n + s t̂` from the HIP with `s = (μ F_N / K a) a`, at the
            // true depth `a = a_p` where the spring before was at least that long; where it
            // was shorter (the GO below the proxy's tangent plane, as a GO stuck on a convex
            // patch is once the hand has moved on, or left inside the object), at the old
            // spring's length: turned about the HIP onto the cone's edge, the storage
            // unchanged. Either way the force lies on the edge of the cone (friction μ F_N)
            // and the spring is never longer than before; it climbs back to the true depth as
            // the hand draws it out.
            let slope = mu * a_n / a_p;
            let edge_sq = a_p * a_p * (1.0 + slope * slope);
            let a = if edge_sq <= old_sq + slack_sq {
                a_p
            } else {
                sqrt(old_sq / (1.0 + slope * slope))
            };
            hip + n * a + unit * math::min(slope * a, back_len)
        };
        // The GO stays over the proxy's patch: a back-off past the patch's end (towards a
        // GO that was on the far side of a valley's vertex) stops at the end, not in the
        // tangent plane's extension inside the object.
        let (patch, params) = O::position(&self.proxy);
        // The proxy's frame from its own evaluation, the normal its contact's (no second
        // normalisation of the normal).
        let derivatives = O::state_derivatives(&self.proxy);
        let in_plane = |d: O::P| Point::try_normalize(d - n * d.dot(n)).unwrap_or(n);
        let tangent = in_plane(derivatives[0]);
        let frame = PatchFrame {
            point: p,
            normal: n,
            tangent,
            bitangent: if derivatives[1] == derivatives[0] {
                tangent
            } else {
                in_plane(derivatives[1])
            },
            derivatives,
        };
        let go_params = if on_feature {
            params
        } else {
            // (The clamp is on the tangential part; the GO keeps its height over the plane.)
            let q = object.offset(patch, params, &frame, go - p);
            go = p
                + n * (go - p).dot(n)
                + frame.derivatives[0] * (q[0] - params[0])
                + frame.derivatives[1] * (q[1] - params[1]);
            q
        };
        // Anything beyond rounding is taken off along the spring: the storage never rises.
        let go_sq = (go - hip).length_squared();
        if go_sq > old_sq + slack_sq {
            go = hip + (go - hip) * sqrt(old_sq / go_sq);
        }
        let moved = sqrt((go - self.go).length_squared());
        self.go_params = go_params;
        self.go_patch = patch;
        self.go_frame = frame;
        self.go = go;
        self.go_on_feature = on_feature;
        moved
    }

    /// One tick for a HIP at `hip` moving at `hip_velocity`, `period_s` after the last.
    pub fn tick(
        &mut self,
        object: &O,
        hip: O::P,
        hip_velocity: O::P,
        period_s: f32,
    ) -> FrictionOutput<O::P> {
        let m = self.material;
        let k = m.stiffness_n_per_m;
        let contact = object.track(&mut self.cp, hip, period_s, true);
        // CP velocity, tangential part.
        let cp_velocity = match self.prev_cp {
            Some(p) if period_s > 0.0 => {
                let v = (contact.point - p) * (1.0 / period_s);
                tangential(v, contact.normal)
            }
            _ => O::P::ZERO,
        };
        self.prev_cp = Some(contact.point);
        let hip_step = self.prev_hip.map_or(O::P::ZERO, |p| hip - p);
        self.prev_hip = Some(hip);
        // (Every tick, free too: contact starts with the hand's recent velocity.)
        self.hip_velocity += (hip_velocity - self.hip_velocity) * per_tau(period_s, STOP_HOLD_S);

        // Contact ends once the HIP is out of the object by more than its resolution (one
        // encoder count of noise does not end it; while it lasts the spring, pulling, renders
        // no normal force and slides to nothing).
        let released = if self.mode == Mode::Free || !matches!(self.law, LawState::StickSlip) {
            !contact.inside
        } else {
            !contact.inside && contact.depth < -self.resolution_m
        };
        if released {
            self.switch(Mode::Free, SwitchCause::Released);
            self.prev_normal_force = 0.0;
            self.slip_speed = 0.0;
            self.law.reset();
            let frame = object.state_frame(&self.cp);
            return self.at_cp(contact, O::position(&self.cp), &frame, 0.0, O::P::ZERO, 0.0);
        }

        if !matches!(self.law, LawState::StickSlip) {
            return self.velocity_law_tick(
                object,
                contact,
                cp_velocity,
                hip,
                hip_velocity,
                period_s,
            );
        }

        let depth = math::max(0.0, contact.depth);
        // The damping acts on the normal velocity alone (it only dissipates), as a length, on
        // the HIP's velocity low-passed over the stop hold: at 10 kHz a backward difference of
        // encoder counts is a 0.2 m/s step a count, which through B = 1 N·s/m would swing F_N,
        // and with it the cone, by 0.2 N a tick (a lagged damping B / (1 + iωτ) still only
        // dissipates: its real part is positive at every frequency).
        let hip_velocity = self.hip_velocity;
        let damping_per_k = m.damping_ns_per_m / k;
        let spring_at =
            |go: O::P, n: O::P| Spring::new(go, hip, n, damping_per_k * hip_velocity.dot(n));
        // The proxy this tick (in contact): the CP itself where the CP is on the GO's own
        // patch (it is where the proxy would slide to, the patch's local closest point, and
        // its normal is the interaction surface's under the hand: the proxy takes it,
        // converged, no evaluation, and the cone turns with it, so that a breakaway after a
        // long stick on a curved patch neither starts the proxy from where the GO was put nor
        // turns the force by the arc between the two); elsewhere (the CP past a vertex, the
        // GO on a valley's feature) one step of its own, every tick, so that it is never
        // stale when the GO slides.
        let mut proxy_contact = None;
        let cp_switched = self.cp_feature != contact.feature;
        self.cp_feature = contact.feature;
        if self.mode != Mode::Free {
            let same_patch = matches!(contact.feature,
                Feature::Patch(i) if usize::from(i) == O::position(&self.proxy).0);
            if same_patch && !self.go_on_feature {
                self.proxy = self.cp;
                O::set_sliding(&mut self.proxy, true);
                // (The frame's tangents, the friction's sign reference only, stay the GO's.)
                self.go_frame.normal = contact.normal;
                proxy_contact = Some(if cp_switched {
                    // The CP has just gone over to this patch and stands at its end this tick
                    // (no evaluation): the proxy takes its own step from there.
                    object.track(&mut self.proxy, hip, period_s, true)
                } else {
                    contact
                });
            } else {
                let pc = object.track(&mut self.proxy, hip, period_s, true);
                if self.go_on_feature && !matches!(pc.feature, Feature::Patch(_)) {
                    // On a valley's feature the normal follows the HIP while the HIP stays
                    // in the feature's region; once it leaves, the normal stays the region
                    // boundary's (the face's), and the face's cone decides from there.
                    self.go_frame.normal = pc.normal;
                }
                proxy_contact = Some(pc);
            }
        }
        let mut spring = spring_at(self.go, self.go_frame.normal);

        // 1. The edge, from the spring as the HIP left it.
        if let Some((mode, cause)) = self.edge(&spring, depth, hip_step, period_s) {
            match cause {
                SwitchCause::Contact => {
                    self.place_go_on_cp(object, &contact, hip);
                    spring = spring_at(self.go, self.go_frame.normal);
                    self.slip_speed = 0.0;
                    self.cp_velocity = cp_velocity;
                    self.restart_stop_clock();
                }
                SwitchCause::Breakaway => {
                    // The contact starts sliding at the CP's speed; at least twice the stop
                    // speed (what the slip speed reports while it catches up).
                    self.slip_speed = math::max(
                        2.0 * m.stop_speed_m_per_s,
                        sqrt(cp_velocity.length_squared()),
                    );
                    self.progress = 0.0;
                    self.restart_stop_clock();
                }
                _ => {}
            }
            self.switch(mode, cause);
        }

        // 2. The GO moves as the mode says: stuck it stays; dynamic it slides over the surface
        // wherever the spring lies outside the cone, never lengthening it.
        let mu = match self.mode {
            Mode::Transition => self.transition_mu(),
            Mode::Slip => m.mu_dynamic,
            _ => m.mu_static,
        };
        let mut slide = 0.0;
        // (A dynamic mode is only reached in contact, where the proxy has its contact.)
        if let Some(pc) = proxy_contact
            && matches!(self.mode, Mode::Transition | Mode::Slip)
            && spring.outside(mu, 0.0)
        {
            slide = self.slide(object, pc, hip, hip_velocity, mu);
            spring = spring_at(self.go, self.go_frame.normal);
        }
        // A stop is the GO's own: less than the stop speed's worth of travel over the hold
        // (a GO creeping by nanometres as μ falls in a transition under a still hand is
        // stopped; one that keeps up with a slow hand is not).
        self.held_travel_m += slide;
        if self.held_travel_m > m.stop_speed_m_per_s * STOP_HOLD_S {
            self.restart_stop_clock();
        } else {
            self.since_slide_s = math::min(self.since_slide_s + period_s, 1.0);
        }

        // 3. Frictional memory: the transition runs at min(1, v/v_s)/τ, and the slip speed
        // follows the GO's over a third of τ.
        let rate = per_tau(period_s, m.transition_time_s);
        let go_speed = if period_s > 0.0 {
            slide / period_s
        } else {
            0.0
        };
        self.slip_speed += per_tau(period_s, m.transition_time_s * SLIP_SPEED_MEMORY)
            * (go_speed - self.slip_speed);
        // The contact's velocity over the object (the CP's), low-passed over the stop hold: at
        // 10 kHz an encoder reports a slow hand's motion a count at a time (a 19.6 µm step
        // every tenth tick at 19.6 mm/s), and the pace's cap at v_s, applied to those bursts
        // one tick at a time, would run the transition at a tenth of its rate.
        self.cp_velocity += (cp_velocity - self.cp_velocity) * per_tau(period_s, STOP_HOLD_S);
        if self.mode == Mode::Transition {
            // The pace is the contact's speed, not the GO's: the spring's own unloading as μ
            // falls would otherwise speed the transition up and snap every slide through it
            // at full pace.
            let vs = m.stribeck_speed_m_per_s;
            let v_sq = self.cp_velocity.length_squared();
            let pace = if v_sq < vs * vs { sqrt(v_sq) / vs } else { 1.0 };
            self.progress = math::min(1.0, self.progress + rate * pace);
        }

        let n = self.go_frame.normal;
        if spring.a_n <= 0.0 && spring.t != O::P::ZERO {
            // No normal force (the HIP out of the GO's tangent plane within the contact's
            // hysteresis, or the damping taking it all while the hand withdraws): no friction
            // either. The GO goes slack over the HIP, which takes the tangential part out of
            // the storage rather than out of the force alone.
            self.go = hip + n * (self.go - hip).dot(n);
            spring = spring_at(self.go, n);
        }
        let normal_force = k * spring.a_n;
        self.prev_normal_force = normal_force;
        // (What f32 leaves of the tangential part of a slack spring, a nanometre, is not
        // rendered: no normal force, no force.)
        let friction = if spring.a_n > 0.0 {
            spring.t * k
        } else {
            O::P::ZERO
        };
        let total = n * normal_force + friction;
        let tangent = reference(&self.go_frame, friction);
        FrictionOutput {
            mode: self.mode,
            cause: self.cause,
            contact,
            go: self.go,
            go_patch: self.go_patch as u16,
            go_params: self.go_params,
            point_of_application: self.go,
            normal: n,
            tangent,
            normal_force_n: normal_force,
            friction_force_n: signed_along(friction, tangent),
            friction,
            total,
            mu,
            psi: contact.psi[0],
            slip_speed_m_per_s: self.slip_speed,
        }
    }

    /// The output when the force acts at the closest point (free, and the velocity-based laws).
    fn at_cp(
        &self,
        contact: Contact<O::P>,
        (patch, params): (usize, [f32; 2]),
        frame: &PatchFrame<O::P>,
        normal_force_n: f32,
        friction: O::P,
        mu: f32,
    ) -> FrictionOutput<O::P> {
        let tangent = reference(frame, friction);
        FrictionOutput {
            mode: self.mode,
            cause: self.cause,
            contact,
            go: contact.point,
            go_patch: patch as u16,
            go_params: params,
            point_of_application: contact.point,
            normal: contact.normal,
            tangent,
            normal_force_n,
            friction_force_n: signed_along(friction, tangent),
            friction,
            total: contact.normal * normal_force_n + friction,
            mu,
            psi: contact.psi[0],
            slip_speed_m_per_s: 0.0,
        }
    }
}

/// The sign reference for a friction force: the frame's tangent or bitangent, whichever `f`
/// lies closer to.
#[inline]
fn reference<P: Point>(fr: &PatchFrame<P>, f: P) -> P {
    if f.dot(fr.bitangent).abs() > f.dot(fr.tangent).abs() {
        fr.bitangent
    } else {
        fr.tangent
    }
}

/// A first-order low-pass's gain per tick of `period_s` for a time constant `time_s` (one
/// Euler step, capped at taking the new value whole).
#[inline]
fn per_tau(period_s: f32, time_s: f32) -> f32 {
    if time_s > period_s {
        period_s / time_s
    } else {
        1.0
    }
}

#[inline]
fn square(x: f32) -> f32 {
    x * x
}

/// The part of `v` orthogonal to the unit normal `n`.
#[inline]
fn tangential<P: Point>(v: P, n: P) -> P {
    v - n * v.dot(n)
}

/// `|f|` signed by its component along `t`.
#[inline]
fn signed_along<P: Point>(f: P, t: P) -> f32 {
    let mag = sqrt(f.length_squared());
    if f.dot(t) < 0.0 { -mag } else { mag }
}
