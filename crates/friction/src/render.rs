//! The friction renderer: contact tracking, the stick–slip state machine of Algorithm 1 with
//! its god-object (GO), and the alternative friction laws, all producing one force per tick.
//!
//! # Algorithm 1, as implemented
//!
//! The force is always the spring `K (GO − HIP)` from the HIP to the god-object (GO, the point
//! of application), split at the GO into the normal force `F_N` and the friction `F_T`.
//!
//! - **Free → stuck**: on contact the GO is pinned at the closest point (CP).
//! - **Stuck**: the GO stays pinned; friction `F_T` while `|F_T| ≤ μ_s F_N`. The CP tracker's
//!   feature switch is inhibited (static friction at a corner, §3.1.2).
//! - **Breakaway → transition**: the thesis's GO tracker is released from the stuck point and
//!   converges to the CP under the feedback law (normalised, with feed-forward of the HIP's
//!   motion, time constant [`FrictionMaterial::transition_time_s`]); its projection error sets
//!   μ, falling from μ_s to μ_d ([`crate::Stribeck`]).
//! - **Slip**: μ = μ_d.
//! - **Dynamic → stuck** when the CP stops or reverses, or when `μ_d F_N[k] > μ_s F_N[k−1]`
//!   (the normal force jumps): the GO is pinned where it is.
//!
//! In the transition and in slip the GO is towed behind the CP at the distance where the
//! spring carries exactly `μ F_N` (`μ · depth` on a flat surface). This is where the
//! implementation departs from a literal reading of the thesis, which keeps the GO on the CP
//! while slipping (friction `μ_d F_N` added as a separate vector) and, on slip → stuck, "resets
//! the GO to a location that ensures force continuity" (Algorithm 1 writes it as an offset
//! added to `F_T`). That reset stretches the spring out of nothing: it injects `½ F_f² / K` of
//! energy each time, and a HIP going back and forth gains energy from friction, which a user
//! feels as an active, buzzing surface. Keeping the GO where the spring already carries the
//! friction gives the same forces (μ_d F_N in slip, continuity at every switch) while friction
//! can only dissipate: the GO only ever moves towards the HIP. The GO is therefore
//! `μ_d · depth` behind the CP in slip rather than on it.

use crate::material::{FrictionMaterial, ModelKind};
use crate::models::{CoulombViscous, Dahl, FrictionLaw, Karnopp, LuGre, TangentialInput};
use nurbs::Point;
use tracker::{Contact, Frame, Law, Object, TrackerConfig};

/// Friction mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// No contact.
    Free,
    /// Static friction, GO pinned.
    Stuck,
    /// Stuck → slip: GO converging to CP, μ modulated.
    Transition,
    /// Dynamic friction, GO = CP.
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
}

/// Everything one tick produced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrictionOutput<P> {
    /// Friction mode after this tick.
    pub mode: Mode,
    /// Contact geometry at the closest point.
    pub contact: Contact<P>,
    /// The god-object (equal to the CP except while stuck or in transition).
    pub go: P,
    /// The GO's patch and parameters.
    pub go_patch: u16,
    /// The GO's parameters.
    pub go_params: [f32; 2],
    /// Where the force acts (the GO).
    pub point_of_application: P,
    /// Unit normal at the point of application.
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
    /// Projection error of the GO in the transition, of the CP otherwise.
    pub psi: f32,
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

/// The whole friction renderer for one object: CP tracker, GO tracker and state machine.
#[derive(Clone, Copy, Debug)]
pub struct FrictionRenderer<O: Object> {
    material: FrictionMaterial,
    cp: O::State,
    go: O::State,
    mode: Mode,
    law: LawState<O::P>,
    /// The transition's projection-error ratio Ψ/Ψ₀ (1 at breakaway).
    s: f32,
    /// Correction of the GO's distance for the surface's curvature (1 on a flat surface).
    lag_gain: f32,
    /// The GO's target last tick (rate-limited), and the HIP last tick.
    prev_target: Option<O::P>,
    prev_hip: Option<O::P>,
    prev_cp: Option<O::P>,
    prev_velocity: O::P,
    prev_normal_force: f32,
    prev_friction: O::P,
}

/// The CP tracker's settings: one Gauss–Newton step per tick.
pub fn cp_config() -> TrackerConfig {
    TrackerConfig::default()
}

/// The GO tracker's settings: it slides towards its target (the point behind the CP where the
/// spring carries the friction force) half the way each tick; the residual lag of a moving
/// target is taken up by the curvature correction of the GO's distance.
fn go_config() -> TrackerConfig {
    TrackerConfig {
        law: Law::Normalized { alpha: 0.5 },
        ..TrackerConfig::default()
    }
}

impl<O: Object> FrictionRenderer<O> {
    /// A renderer for `object` with `material`, starting from a HIP at `hip`, ticking every
    /// `period_s`.
    pub fn new(object: &O, material: FrictionMaterial, hip: O::P, period_s: f32) -> Self {
        let cp = object.start(hip, cp_config());
        let mut go = object.start(hip, go_config());
        let _ = period_s;
        O::set_sliding(&mut go, true);
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
            go,
            mode: Mode::Free,
            law,
            s: 0.0,
            lag_gain: 1.0,
            prev_target: None,
            prev_hip: None,
            prev_cp: None,
            prev_velocity: O::P::ZERO,
            prev_normal_force: 0.0,
            prev_friction: O::P::ZERO,
        }
    }

    /// Current mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The material.
    pub fn material(&self) -> &FrictionMaterial {
        &self.material
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
        let allow_switch = self.mode != Mode::Stuck;
        let contact = object.track(&mut self.cp, hip, period_s, allow_switch);
        // CP velocity, tangential part.
        let cp_velocity = match self.prev_cp {
            Some(p) if period_s > 0.0 => {
                let v = (contact.point - p) * (1.0 / period_s);
                v - contact.normal * v.dot(contact.normal)
            }
            _ => O::P::ZERO,
        };
        self.prev_cp = Some(contact.point);
        let (cp_patch, cp_params) = O::position(&self.cp);

        if !contact.inside {
            self.mode = Mode::Free;
            self.prev_target = None;
            self.prev_hip = Some(hip);
            self.prev_normal_force = 0.0;
            self.prev_friction = O::P::ZERO;
            self.prev_velocity = cp_velocity;
            self.law.reset();
            let frame = object.frame(cp_patch, cp_params);
            return at_cp(
                Mode::Free,
                contact,
                (cp_patch, cp_params),
                &frame,
                0.0,
                O::P::ZERO,
                0.0,
            );
        }

        let damping = |n: O::P| -m.damping_ns_per_m * hip_velocity.dot(n);

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

        if self.mode == Mode::Free {
            self.mode = Mode::Stuck;
            object.place(&mut self.go, cp_patch, cp_params);
        }

        // Dynamic → stuck when the CP stops or reverses, or the normal force jumps
        // (μ_d F_N[k] > μ_s F_N[k−1]). The GO stays where it is, so the spring, and with it the
        // force, carries on unchanged.
        if matches!(self.mode, Mode::Transition | Mode::Slip) {
            let fn_now = (k * contact.depth + damping(contact.normal)).max(0.0);
            let slow = |v: O::P| v.length_squared() < square(m.stop_speed_m_per_s);
            let stopped = slow(cp_velocity);
            // A reversal is a real change of direction, not rounding noise around standstill.
            let reversed =
                cp_velocity.dot(self.prev_velocity) < 0.0 && !stopped && !slow(self.prev_velocity);
            // A relative margin keeps f32 noise from firing it when μ_s = μ_d.
            let jump =
                m.mu_dynamic * fn_now > m.mu_static * self.prev_normal_force * (1.0 + 1e-4) + 1e-6;
            // Sticking needs a spring that static friction can hold; a GO still catching up
            // (the HIP stopped while it lagged) slides on until it can.
            let (p, t) = O::position(&self.go);
            let at = object.frame(p, t);
            let spring = (at.point - hip) * k;
            let holds = tangential(spring, at.normal).length_squared()
                <= square(m.mu_static * spring.dot(at.normal).max(0.0));
            // A transition runs its course while the CP stands still (the HIP pulled straight
            // out, or pressed straight in): stopping only ends a slip. Otherwise unloading
            // would chatter between stuck and transition every few ticks.
            let stopped = stopped && self.mode == Mode::Slip;
            if (reversed || stopped || jump) && holds {
                self.mode = Mode::Stuck;
            }
        }

        let mut mu = m.mu_static;
        let mut psi = contact.psi[0];
        if matches!(self.mode, Mode::Transition | Mode::Slip) {
            let go_now = object
                .frame(O::position(&self.go).0, O::position(&self.go).1)
                .point;
            let offset = tangential(go_now - contact.point, contact.normal);
            let dist = sqrt(offset.length_squared());
            let behind = offset
                .try_normalize()
                .unwrap_or_else(|| -cp_velocity.try_normalize().unwrap_or(O::P::ZERO));
            let mut lag = if self.mode == Mode::Transition {
                // The thesis's transition: the GO's projection error decays under the
                // normalised law, `Ψ/Ψ₀ = (1 − T/τ)ᵏ`, and sets μ through the Stribeck curve.
                self.s *= 1.0 - (period_s / m.transition_time_s.max(period_s)).min(1.0);
                if self.s <= 0.01 {
                    // The last 1 % of μ's way is snapped: this tick already renders slip.
                    self.mode = Mode::Slip;
                    mu = m.mu_dynamic;
                } else {
                    mu = m.stribeck.mu(m.mu_static, m.mu_dynamic, self.s);
                }
                psi = self.s;
                mu * contact.depth.max(0.0) * self.lag_gain
            } else {
                mu = m.mu_dynamic;
                mu * contact.depth.max(0.0) * self.lag_gain
            };
            // Never pushed away from the CP: a GO closer than its slip distance (the HIP pressed
            // deeper) waits for the spring to stretch, as when stuck.
            lag = lag.min(dist);
            // The GO slides over the surface (changing patch only at a boundary) half the way
            // each tick towards a target `lag` behind the CP. The target itself moves no faster
            // than the HIP (plus the Stribeck relaxation): where it would jump, because the CP
            // crossed a sharp corner and the depth now counts from the other patch, the force
            // falls steeply but continuously (thesis Fig. 3.2.2, interval 12 → 13).
            let raw = contact.point + behind * lag;
            let hip_step = sqrt((hip - self.prev_hip.unwrap_or(hip)).length_squared());
            let rate = (period_s / m.transition_time_s.max(period_s)).min(1.0);
            let target = match self.prev_target {
                Some(prev) => {
                    let step = raw - prev;
                    let len = sqrt(step.length_squared());
                    // With the HIP, plus the rest of the way at the transition's rate (1/τ).
                    let reach = 1.5 * hip_step + rate * len + 1e-7;
                    if len > reach {
                        prev + step * (reach / len)
                    } else {
                        raw
                    }
                }
                None => raw,
            };
            self.prev_target = Some(target);
            object.track(&mut self.go, target, period_s, true);
        }

        // The force is the spring from the HIP to the god-object.
        let (go_patch, go_params) = O::position(&self.go);
        let fr = object.frame(go_patch, go_params);
        let f = (fr.point - hip) * k;
        let normal_force = (f.dot(fr.normal) + damping(fr.normal)).max(0.0);
        let mut friction = tangential(f, fr.normal);
        let f_t = sqrt(friction.length_squared());
        match self.mode {
            Mode::Stuck => {
                let limit = m.mu_static * normal_force;
                if f_t > limit {
                    // Breakaway: friction at the static limit this tick, then the transition,
                    // whose target starts at the GO.
                    self.mode = Mode::Transition;
                    self.s = 1.0;
                    self.prev_target = Some(fr.point);
                    friction = friction * (limit / f_t);
                }
            }
            Mode::Transition | Mode::Slip => {
                // While the GO catches up with a target that moved away (the HIP let go, or the
                // depth reference changed at a corner) the spring can exceed μ F_N for a few
                // ticks: the rendered friction never does.
                let limit = mu * normal_force;
                if f_t > limit {
                    friction = friction * (limit / f_t);
                }
                // On a curved surface the tilt of the normal between CP and GO changes the
                // split of the spring by about κ·depth: adjust the GO's distance over the next
                // ticks so that |F_T| = μ F_N.
                if f_t > f32::MIN_POSITIVE && normal_force > 0.0 {
                    let ratio = (mu * normal_force / f_t).clamp(0.5, 2.0);
                    self.lag_gain = (self.lag_gain * (1.0 + 0.5 * (ratio - 1.0))).clamp(0.5, 2.0);
                }
            }
            Mode::Free => {}
        }
        if self.mode == Mode::Stuck {
            self.prev_target = None;
        }
        self.prev_hip = Some(hip);
        self.prev_velocity = cp_velocity;
        self.prev_normal_force = normal_force;
        self.prev_friction = friction;
        let total = fr.normal * normal_force + friction;
        FrictionOutput {
            mode: self.mode,
            contact,
            go: fr.point,
            go_patch: go_patch as u16,
            go_params,
            point_of_application: fr.point,
            normal: fr.normal,
            tangent: reference(&fr, friction),
            normal_force_n: normal_force,
            friction_force_n: signed_along(friction, reference(&fr, friction)),
            friction,
            total,
            mu,
            psi,
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
        let fr = object.frame(cp_patch, cp_params);
        let f_n = (m.stiffness_n_per_m * contact.depth
            - m.damping_ns_per_m * hip_velocity.dot(contact.normal))
        .max(0.0);
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
        self.mode = if cp_velocity.length_squared() < m.stop_speed_m_per_s * m.stop_speed_m_per_s {
            Mode::Stuck
        } else {
            Mode::Slip
        };
        self.prev_friction = friction;
        self.prev_normal_force = f_n;
        self.prev_velocity = cp_velocity;
        let mu = if f_n > 0.0 {
            sqrt(friction.length_squared()) / f_n
        } else {
            0.0
        };
        at_cp(
            self.mode,
            contact,
            (cp_patch, cp_params),
            &fr,
            f_n,
            friction,
            mu,
        )
    }
}

/// The output when the force acts at the closest point (free, and the velocity-based laws).
fn at_cp<P: Point>(
    mode: Mode,
    contact: Contact<P>,
    (patch, params): (usize, [f32; 2]),
    frame: &Frame<P>,
    normal_force_n: f32,
    friction: P,
    mu: f32,
) -> FrictionOutput<P> {
    let tangent = reference(frame, friction);
    FrictionOutput {
        mode,
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

#[inline]
fn sqrt(x: f32) -> f32 {
    libm::sqrtf(x)
}
