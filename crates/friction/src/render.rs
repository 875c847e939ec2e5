//! The friction renderer: contact tracking, the stick–slip state machine of Algorithm 1 with
//! its god-object (GO), and the alternative friction laws, all producing one force per tick.
//!
//! # Algorithm 1, as implemented
//!
//! The closest point (CP) is tracked with feature switching always on, so the penetration depth
//! is the object's true depth wherever the GO is. The GO is a point on the object's surface that
//! moves only when friction cannot hold it: the force is
//!
//! `F = F_N n + F_T`,  `F_N = K·depth − b·v·n_CP` (≥ 0),  `F_T = K·(GO − HIP)` tangential to `n`,
//!
//! with `n` the normal at the GO and `|F_T| ≤ μ F_N` (the friction cone).
//!
//! - **Free → stuck** on contact ([`SwitchCause::Contact`]): the GO is put at the CP.
//! - **Stuck**: the GO stays where it is; friction is the tangential spring. Leaving the CP's
//!   Voronoi region does not move the GO, so static friction holds at a corner (§3.1.2).
//! - **Stuck → transition** when `|F_T| > μ_s F_N` ([`SwitchCause::Breakaway`]).
//! - **Transition and slip**: each tick the GO slides towards the HIP just far enough that the
//!   spring carries `μ F_N` (the cone's surface): friction opposes the slide and only ever
//!   dissipates. In the transition μ follows the Stribeck curve of the GO's slip speed
//!   ([`crate::Stribeck`]): `μ_s` at breakaway, `μ_d` at and above the Stribeck speed, so a
//!   faster hand loses static friction sooner (§3.1.1). The slip speed is the GO's speed
//!   low-passed, and μ lags the curve, both over `transition_time_s` (frictional memory): μ
//!   falls by at most `(μ_s − μ_d) T/τ` per tick, and the jitter of a handle held by a
//!   compliant hand does not make μ chatter.
//! - **Transition → slip** once μ has reached μ_d and the GO sits within `converge_tol_m` of
//!   its slip position ([`SwitchCause::Converged`]); slip renders `μ_d F_N`.
//! - **Dynamic → stuck** (transition or slip, Algorithm 1's DYNAMIC state): when the normal
//!   force jumps, `μ_d F_N[k] > μ_s F_N[k−1]` ([`SwitchCause::NormalForceJump`]); when the
//!   CP moves back towards the GO faster than the stop speed ([`SwitchCause::Reversed`]); or
//!   when the GO's slip speed has fallen below the stop speed ([`SwitchCause::Stopped`]). The
//!   GO stays where it is, so the force carries on unchanged (force continuity).
//! - **Contact lost → free** ([`SwitchCause::Released`]).
//!
//! Where the GO slides onto a neighbouring patch across a crease (a sharp vertex of a chain, an
//! edge of a shell), it stops on the crease while its normal turns from one patch's normal to
//! the other's over a slide of `depth × |n₁ − n₀|`: the crease is felt as if rounded to the
//! depth of penetration, so the force turns by about `K` times the hand's step per tick instead
//! of jumping by `|F|·|n₁ − n₀|`.
//!
//! # Where this departs from a literal reading of the thesis
//!
//! - The thesis keeps the GO on the CP while slipping and adds `μ_d F_N` as a separate vector;
//!   on slip → stuck it "resets the GO to a location that ensures force continuity" (an offset
//!   added to `F_T`). That reset stretches the spring out of nothing and injects `½ F_f² / K`
//!   of energy each time. Here the GO stays where the spring already carries the friction, which
//!   gives the same forces with friction that can only dissipate.
//! - The stuck self-transition of Fig. 3.1.2 (reset the GO to the CP when the CP stops or
//!   reverses while stuck) is not implemented. It would drop the friction force to zero in one
//!   tick, a step of up to `μ_s F_N`, and the thesis's own Fig. 3.2.2 contradicts it: in 4 → 5
//!   and 10 → 11 the HIP presses along the normal (the CP stands still) while stuck and "the
//!   friction force is kept still".
//! - The thesis inhibits the CP's Voronoi switching while stuck (§3.1.2) because its GO is
//!   derived from the CP; here the GO is pinned on its own, so the CP keeps switching and the
//!   depth stays the object's true depth (the inhibited CP measured it against the first
//!   curve's end tangent: 1.6 mm where the truth was 0.5 mm).
//! - The thesis's Fig. 3.1.2, its text and Algorithm 1 state the normal-force test three ways;
//!   Algorithm 1's `μ_d F_N[k] > μ_s F_N[k−1]` is used (the text's ratio, read literally, would
//!   fire on a fall of the normal force, contradicting its own "sudden increase").

use crate::material::{FrictionMaterial, ModelKind};
use crate::models::{CoulombViscous, Dahl, FrictionLaw, Karnopp, LuGre, TangentialInput};
use nurbs::Point;
use nurbs::math::{self, sqrt};
use tracker::{Contact, Frame, Object};

/// Friction mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// No contact.
    Free,
    /// Static friction, GO pinned.
    Stuck,
    /// Stuck → slip: the GO slides, μ falls along the Stribeck curve.
    Transition,
    /// Dynamic friction: the GO slides at μ_d.
    Slip,
}

impl Mode {
    /// Lower-case name used in run logs.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Free => "free",
            Mode::Stuck => "stuck",
            Mode::Transition => "transition",
            Mode::Slip => "slip",
        }
    }

    /// Every mode, in the order of its wire code.
    pub const ALL: [Mode; 4] = [Mode::Free, Mode::Stuck, Mode::Transition, Mode::Slip];
}

/// Why the renderer last changed mode (each edge of the state machine of Fig. 3.1.2 has its
/// own cause).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SwitchCause {
    /// No switch yet.
    None,
    /// Free → stuck: the HIP entered the object.
    Contact,
    /// Stuck → transition: `|F_T| > μ_s F_N`.
    Breakaway,
    /// Transition → slip: μ reached μ_d and the GO converged to its slip position.
    Converged,
    /// Dynamic → stuck: the GO's slip speed fell below the stop speed (the CP stopped).
    Stopped,
    /// Dynamic → stuck: the CP reversed, moving back towards the GO.
    Reversed,
    /// Dynamic → stuck: the normal force jumped, `μ_d F_N[k] > μ_s F_N[k−1]`.
    NormalForceJump,
    /// Contact → free: the HIP left the object.
    Released,
}

impl SwitchCause {
    /// Lower-case name used in run logs.
    pub fn name(self) -> &'static str {
        match self {
            SwitchCause::None => "none",
            SwitchCause::Contact => "contact",
            SwitchCause::Breakaway => "breakaway",
            SwitchCause::Converged => "converged",
            SwitchCause::Stopped => "stopped",
            SwitchCause::Reversed => "reversed",
            SwitchCause::NormalForceJump => "normal_force_jump",
            SwitchCause::Released => "released",
        }
    }

    /// Every cause, in the order of its wire code.
    pub const ALL: [SwitchCause; 8] = [
        SwitchCause::None,
        SwitchCause::Contact,
        SwitchCause::Breakaway,
        SwitchCause::Converged,
        SwitchCause::Stopped,
        SwitchCause::Reversed,
        SwitchCause::NormalForceJump,
        SwitchCause::Released,
    ];
}

/// Everything one tick produced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrictionOutput<P> {
    /// Friction mode after this tick.
    pub mode: Mode,
    /// Why the mode last changed (this tick or earlier).
    pub cause: SwitchCause,
    /// Contact geometry at the closest point.
    pub contact: Contact<P>,
    /// The god-object (equal to the CP when free).
    pub go: P,
    /// The GO's patch.
    pub go_patch: u16,
    /// The GO's parameters.
    pub go_params: [f32; 2],
    /// Where the force acts (the GO).
    pub point_of_application: P,
    /// Unit normal at the point of application (turning across a crease).
    pub normal: P,
    /// Unit tangent at the point of application, the sign reference of `friction_force_n`:
    /// the curve's tangent in 2-D; in 3-D whichever parameter direction (u or v) the friction
    /// lies closer to.
    pub tangent: P,
    /// Normal force (N), ≥ 0.
    pub normal_force_n: f32,
    /// Friction force (N): its magnitude, signed by its component along `tangent`.
    pub friction_force_n: f32,
    /// Friction force vector (N).
    pub friction: P,
    /// Total force on the HIP (N).
    pub total: P,
    /// The friction coefficient in use.
    pub mu: f32,
    /// The CP tracker's projection error Ψ (thesis eq. 2.8, `[Ψ_u]` on curves): 0 once the
    /// closest point has converged.
    pub psi: f32,
    /// The GO's slip speed that sets μ in the transition (m/s, filtered over
    /// [`FrictionMaterial::transition_time_s`]).
    pub slip_speed_m_per_s: f32,
}

/// Per-model state of the velocity-based laws.
#[derive(Clone, Copy, Debug)]
enum LawState<P> {
    StickSlip,
    Coulomb(CoulombViscous),
    Karnopp(Karnopp),
    Dahl(Dahl<P>),
    LuGre(LuGre<P>),
}

impl<P: Point> LawState<P> {
    /// Forgets the bristle state of the laws that have one (contact lost).
    fn reset(&mut self) {
        match self {
            LawState::Dahl(l) => FrictionLaw::<P>::reset(l),
            LawState::LuGre(l) => FrictionLaw::<P>::reset(l),
            _ => {}
        }
    }
}

/// A GO stopped on a crease: the patch across it, the same point's parameters there, that
/// patch's normal, the directions of travel over the crease, and how far the GO's normal has
/// turned towards the next patch's (0 → 1).
#[derive(Clone, Copy, Debug)]
struct Crease<P> {
    patch: usize,
    params: [f32; 2],
    normal: P,
    /// The unit tangent leaving the GO's patch through the crease, and entering the next one.
    out_of: P,
    into: P,
    turned: f32,
}

/// Normals closer than this (chord of unit vectors, about 0.06°) meet smoothly: no crease.
const SMOOTH_CHORD: f32 = 1e-3;

/// How far the friction force must fall below `μ_d F_N` (as a fraction) with the CP moving back
/// towards the GO before a dynamic mode counts the motion as reversed.
const REVERSAL_HYSTERESIS: f32 = 0.1;

/// The smallest radius a crease is rounded to (m), so that a crease met at zero depth still
/// turns over a few micrometres of slide rather than in one step.
const MIN_ROUNDING_M: f32 = 1e-5;

/// The whole friction renderer for one object: CP tracker, GO and state machine.
#[derive(Clone, Copy, Debug)]
pub struct FrictionRenderer<O: Object> {
    material: FrictionMaterial,
    cp: O::State,
    go_patch: usize,
    go_params: [f32; 2],
    /// The GO's frame (evaluated where it moved; reused while it stands still).
    go_frame: Frame<O::P>,
    crease: Option<Crease<O::P>>,
    mode: Mode,
    cause: SwitchCause,
    law: LawState<O::P>,
    /// The GO's slip speed (m/s), low-passed over `transition_time_s`.
    slip_speed: f32,
    /// μ in the transition: follows the Stribeck curve of the slip speed with the lag
    /// `transition_time_s`.
    mu: f32,
    prev_cp: Option<O::P>,
    prev_hip: Option<O::P>,
    prev_normal_force: f32,
}

/// The CP tracker's settings: one Gauss–Newton step per tick.
pub fn cp_config() -> tracker::TrackerConfig {
    tracker::TrackerConfig::default()
}

impl<O: Object> FrictionRenderer<O> {
    /// A renderer for `object` with `material`, starting from a HIP at `hip`, ticking every
    /// `period_s`.
    ///
    /// This runs the object's global closest-point search ([`Object::start`]), far dearer than
    /// a tick; a loop with a deadline runs the search elsewhere and hands its result to
    /// [`FrictionRenderer::from_tracking`].
    pub fn new(object: &O, material: FrictionMaterial, hip: O::P, period_s: f32) -> Self {
        Self::from_tracking(object, material, object.start(hip, cp_config()), period_s)
    }

    /// A renderer for `object` with `material` whose CP tracker starts from `cp` (a state of
    /// [`Object::start`] with [`cp_config`], possibly found for an earlier HIP: the tracker's
    /// feedback follows the HIP from there), ticking every `period_s`. Costs one frame
    /// evaluation, no search.
    pub fn from_tracking(
        object: &O,
        material: FrictionMaterial,
        cp: O::State,
        period_s: f32,
    ) -> Self {
        let _ = period_s;
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
        FrictionRenderer {
            material,
            cp,
            go_patch,
            go_params,
            go_frame: object.frame(go_patch, go_params),
            crease: None,
            mode: Mode::Free,
            cause: SwitchCause::None,
            law,
            slip_speed: 0.0,
            mu: material.mu_static,
            prev_cp: None,
            prev_hip: None,
            prev_normal_force: 0.0,
        }
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

    /// The GO's unit normal: its patch's, or across a crease turned part of the way towards
    /// the next patch's.
    fn go_normal(&self) -> O::P {
        match self.crease {
            Some(c) => blend(self.go_frame.normal, c.normal, c.turned),
            None => self.go_frame.normal,
        }
    }

    /// Puts the GO at `(patch, params)`, off any crease.
    fn place_go(&mut self, object: &O, patch: usize, params: [f32; 2]) {
        self.go_patch = patch;
        self.go_params = params;
        self.go_frame = object.frame(patch, params);
        self.crease = None;
    }

    /// Slides the GO by the tangential displacement `d` over the surface: within its patch by
    /// one Gauss–Newton step, onto the next patch where it leaves through a shared boundary
    /// (after turning its normal over the rounding of a crease, `radius` = the depth, by at
    /// most `crease_step` of that rounding's arc per tick: the normal force, `K · radius`,
    /// then turns by at most `K · crease_step`).
    fn slide_go(&mut self, object: &O, d: O::P, radius: f32, crease_step: f32) {
        if let Some(mut c) = self.crease {
            let n0 = self.go_frame.normal;
            let chord_sq = (c.normal - n0).length_squared();
            // Forward over the rounding: from leaving the first patch to entering the next, for a
            // ridge and a valley alike.
            let forward = c.out_of * (1.0 - c.turned) + c.into * c.turned;
            let len_sq = forward.length_squared();
            if len_sq <= f32::MIN_POSITIVE || chord_sq <= f32::MIN_POSITIVE {
                self.place_go(object, c.patch, c.params);
                return;
            }
            let dir = forward * (1.0 / sqrt(len_sq));
            let along = d.dot(dir);
            // The rounding's arc: radius × the angle, the chord standing in for the angle.
            c.turned += along.clamp(-crease_step, crease_step)
                / (math::max(MIN_ROUNDING_M, radius) * sqrt(chord_sq));
            // Along the crease (an edge of a shell): slide on the patch it belongs to, and find
            // the next patch's point and normal again there.
            let rest = tangential(d - dir * along, n0);
            // A step that would leave the crease (f32 rounding of the Gauss–Newton step drifts
            // off the boundary) is not taken.
            if rest.length_squared() > square(1e-9) {
                let params = object.offset(self.go_patch, self.go_params, &self.go_frame, rest);
                let at = object.frame(self.go_patch, params);
                if let Some((patch, across)) =
                    object.neighbour(self.go_patch, params, &at, c.out_of)
                {
                    self.go_params = params;
                    self.go_frame = at;
                    c.patch = patch;
                    c.params = across;
                    c.normal = object.frame(patch, across).normal;
                }
            }
            if c.turned >= 1.0 {
                self.place_go(object, c.patch, c.params);
            } else if c.turned <= 0.0 {
                self.crease = None;
            } else {
                self.crease = Some(c);
            }
            return;
        }
        let before = self.go_frame.point;
        let params = object.offset(self.go_patch, self.go_params, &self.go_frame, d);
        self.go_params = params;
        self.go_frame = object.frame(self.go_patch, params);
        let moved = self.go_frame.point - before;
        let rest = tangential(d - moved, self.go_frame.normal);
        let rest_sq = rest.length_squared();
        if rest_sq <= square(1e-3) * d.length_squared() || rest_sq <= f32::MIN_POSITIVE {
            return;
        }
        if let Some((patch, params)) =
            object.neighbour(self.go_patch, self.go_params, &self.go_frame, rest)
        {
            let across = object.frame(patch, params);
            if (across.normal - self.go_frame.normal).length_squared() <= square(SMOOTH_CHORD) {
                self.place_go(object, patch, params);
                let p = object.offset(patch, params, &self.go_frame, rest);
                self.go_params = p;
                self.go_frame = object.frame(patch, p);
            } else {
                let out_of = rest * (1.0 / sqrt(rest_sq));
                let into = tangential(out_of, across.normal);
                let into_sq = into.length_squared();
                let into = if into_sq > f32::MIN_POSITIVE {
                    into * (1.0 / sqrt(into_sq))
                } else {
                    out_of
                };
                self.crease = Some(Crease {
                    patch,
                    params,
                    normal: across.normal,
                    out_of,
                    into,
                    turned: 0.0,
                });
            }
        }
    }

    /// One tick for a HIP at `hip` moving at `hip_velocity`.
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

        if !contact.inside {
            self.switch(Mode::Free, SwitchCause::Released);
            self.prev_normal_force = 0.0;
            self.prev_hip = Some(hip);
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

        // The normal force from the object's true penetration (thesis eq. 2.10, with damping).
        let normal_force = math::max(
            0.0,
            k * contact.depth - m.damping_ns_per_m * hip_velocity.dot(contact.normal),
        );

        if self.mode == Mode::Free {
            // The GO starts at the CP, whose frame the tracker has just evaluated.
            let (p, t) = O::position(&self.cp);
            self.go_patch = p;
            self.go_params = t;
            self.go_frame = object.state_frame(&self.cp);
            self.crease = None;
            self.slip_speed = 0.0;
            self.switch(Mode::Stuck, SwitchCause::Contact);
        } else if matches!(self.mode, Mode::Transition | Mode::Slip)
            && m.mu_dynamic * normal_force
                > m.mu_static * self.prev_normal_force * (1.0 + 1e-4) + 1e-6
        {
            // Algorithm 1: μ_d F_N[k] > μ_s F_N[k−1]; a relative margin keeps f32 noise from
            // firing it when μ_s = μ_d.
            self.switch(Mode::Stuck, SwitchCause::NormalForceJump);
        }

        let mut n = self.go_normal();
        let mut friction = tangential((self.go_frame.point - hip) * k, n);
        let mut mu = m.mu_static;
        if self.mode == Mode::Stuck
            && friction.length_squared() > square(m.mu_static * normal_force)
        {
            // At breakaway the contact slides at the CP's speed; at least twice the stop speed,
            // so that the slip speed's lag keeps the transition going for τ·ln 2 or more before
            // a stop can end it (no stuck ↔ transition chatter of a creeping hand).
            self.slip_speed = math::max(
                2.0 * m.stop_speed_m_per_s,
                sqrt(cp_velocity.length_squared()),
            );
            self.mu = m.mu_static;
            self.switch(Mode::Transition, SwitchCause::Breakaway);
        }
        // Frictional memory: μ and the slip speed follow the GO's motion with the material's
        // time constant (no clock sets them: a GO that does not slide keeps its μ).
        let rate = math::min(1.0, period_s / math::max(period_s, m.transition_time_s));
        if matches!(self.mode, Mode::Transition | Mode::Slip) {
            mu = match self.mode {
                Mode::Transition => {
                    let target = m.stribeck.mu_at_speed(
                        m.mu_static,
                        m.mu_dynamic,
                        self.slip_speed,
                        m.stribeck_speed_m_per_s,
                    );
                    self.mu += rate * (target - self.mu);
                    self.mu
                }
                _ => m.mu_dynamic,
            };
            // The friction cone: the GO slides towards the HIP just far enough that the spring
            // carries μ F_N.
            let limit = mu * normal_force;
            let f_t_sq = friction.length_squared();
            let mut slide = 0.0;
            if f_t_sq > square(limit) && f_t_sq > f32::MIN_POSITIVE {
                let f_t = sqrt(f_t_sq);
                // The GO keeps up with the hand (twice its step covers the CP's faster motion
                // on a convex curve) and takes the rest of its way at the frictional memory's
                // rate T/τ: where the cone jumps away (μ fell, the GO is behind on another
                // patch) the force turns over several ticks instead of in one. Across a crease
                // it turns the GO's normal by no more than the hand's step allows (below).
                let excess = (f_t - limit) / k;
                let hip_step = self
                    .prev_hip
                    .map_or(0.0, |p| sqrt((hip - p).length_squared()));
                let keep_up = 2.0 * (hip_step + m.stop_speed_m_per_s * period_s);
                slide = math::min(excess, keep_up + rate * excess);
                let d = friction * (-slide / f_t);
                self.slide_go(object, d, math::max(0.0, contact.depth), keep_up);
                n = self.go_normal();
                friction = tangential((self.go_frame.point - hip) * k, n);
            }
            let go_speed = if period_s > 0.0 {
                slide / period_s
            } else {
                0.0
            };
            self.slip_speed += rate * (go_speed - self.slip_speed);
            if slide < m.stop_speed_m_per_s * period_s {
                // The GO did not need to move: the hand stopped, reversed, or pressed in. A
                // reversal is the HIP moving back towards the GO (in the GO's tangent plane,
                // faster than the stop speed) with the spring relaxed a tenth below the
                // dynamic load μ_d F_N (the hand came back by a tenth of μ_d·depth): the jitter
                // of a handle held by a compliant hand does not count.
                let step = self.prev_hip.map_or(O::P::ZERO, |p| hip - p);
                let back_m = tangential(step, n).dot(friction);
                let back = back_m > 0.0
                    && square(back_m)
                        > square(m.stop_speed_m_per_s * period_s) * friction.length_squared();
                let relaxed = friction.length_squared()
                    < square((1.0 - REVERSAL_HYSTERESIS) * m.mu_dynamic * normal_force);
                if back && relaxed {
                    self.switch(Mode::Stuck, SwitchCause::Reversed);
                } else if self.slip_speed < m.stop_speed_m_per_s {
                    self.switch(Mode::Stuck, SwitchCause::Stopped);
                }
            }
            // μ has come within 1 % of its way to μ_d (the lag only reaches it asymptotically;
            // the last 1 % is a step of 0.01 (μ_s − μ_d) F_N).
            if self.mode == Mode::Transition
                && mu - m.mu_dynamic <= 0.01 * (m.mu_static - m.mu_dynamic)
                && friction.length_squared()
                    <= square(m.mu_dynamic * normal_force + k * m.converge_tol_m)
            {
                self.switch(Mode::Slip, SwitchCause::Converged);
                mu = m.mu_dynamic;
            }
        }
        // What the friction renders: the spring, never beyond the cone of the mode's μ (it can
        // exceed it for a tick where the GO stopped on a boundary it cannot leave).
        let limit = if self.mode == Mode::Stuck {
            m.mu_static
        } else {
            mu
        } * normal_force;
        let f_t_sq = friction.length_squared();
        if f_t_sq > square(limit) {
            friction = friction * (limit / sqrt(f_t_sq));
        }
        self.prev_normal_force = normal_force;
        self.prev_hip = Some(hip);
        let total = n * normal_force + friction;
        let tangent = reference(&self.go_frame, friction);
        FrictionOutput {
            mode: self.mode,
            cause: self.cause,
            contact,
            go: self.go_frame.point,
            go_patch: self.go_patch as u16,
            go_params: self.go_params,
            point_of_application: self.go_frame.point,
            normal: n,
            tangent,
            normal_force_n: normal_force,
            friction_force_n: signed_along(friction, tangent),
            friction,
            total,
            mu: if self.mode == Mode::Stuck {
                m.mu_static
            } else {
                mu
            },
            psi: contact.psi[0],
            slip_speed_m_per_s: self.slip_speed,
        }
    }

    /// The velocity-based laws: penalty normal force at the CP, friction from the law.
    fn velocity_law_tick(
        &mut self,
        object: &O,
        contact: Contact<O::P>,
        cp_velocity: O::P,
        hip: O::P,
        hip_velocity: O::P,
        period_s: f32,
    ) -> FrictionOutput<O::P> {
        let m = self.material;
        let (cp_patch, cp_params) = O::position(&self.cp);
        let fr = object.state_frame(&self.cp);
        let f_n = math::max(
            0.0,
            m.stiffness_n_per_m * contact.depth
                - m.damping_ns_per_m * hip_velocity.dot(contact.normal),
        );
        // The user's tangential push, for Karnopp: the tangential part of the hand's motion
        // against the surface stiffness is not observable in a position-input device, so
        // the HIP's tangential offset from the CP stands in for it.
        let offset = hip - contact.point;
        let applied = (offset - contact.normal * offset.dot(contact.normal)) * m.stiffness_n_per_m;
        let input = TangentialInput {
            velocity: cp_velocity,
            normal_force_n: f_n,
            applied,
            period_s,
        };
        let friction = match &mut self.law {
            LawState::Coulomb(l) => l.force(&input),
            LawState::Karnopp(l) => l.force(&input),
            LawState::Dahl(l) => l.force(&input),
            LawState::LuGre(l) => l.force(&input),
            LawState::StickSlip => O::P::ZERO,
        };
        if cp_velocity.length_squared() < square(m.stop_speed_m_per_s) {
            let cause = if self.mode == Mode::Free {
                SwitchCause::Contact
            } else {
                SwitchCause::Stopped
            };
            self.switch(Mode::Stuck, cause);
        } else {
            self.switch(Mode::Slip, SwitchCause::Breakaway);
        }
        self.prev_normal_force = f_n;
        let mu = if f_n > 0.0 {
            sqrt(friction.length_squared()) / f_n
        } else {
            0.0
        };
        self.at_cp(contact, (cp_patch, cp_params), &fr, f_n, friction, mu)
    }

    /// The output when the force acts at the closest point (free, and the velocity-based laws).
    fn at_cp(
        &self,
        contact: Contact<O::P>,
        (patch, params): (usize, [f32; 2]),
        frame: &Frame<O::P>,
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

/// `normalize((1 − s) a + s b)`: the unit vector a fraction `s` of the way from `a` to `b`.
#[inline]
fn blend<P: Point>(a: P, b: P, s: f32) -> P {
    let v = a * (1.0 - s) + b * s;
    let len_sq = v.length_squared();
    if len_sq > f32::MIN_POSITIVE {
        v * (1.0 / sqrt(len_sq))
    } else {
        a
    }
}

/// The sign reference for a friction force: the frame's tangent or bitangent, whichever `f`
/// lies closer to.
#[inline]
fn reference<P: Point>(fr: &Frame<P>, f: P) -> P {
    if f.dot(fr.bitangent).abs() > f.dot(fr.tangent).abs() {
        fr.bitangent
    } else {
        fr.tangent
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
