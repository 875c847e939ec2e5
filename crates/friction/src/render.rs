//! The friction renderer: contact tracking, the stick–slip state machine of Algorithm 1 with
//! its god-object (GO), and the alternative friction laws, all producing one force per tick.
//!
//! # Algorithm 1, as implemented
//!
//! - **Free → stuck**: on contact the GO is pinned at the closest point (CP).
//! - **Stuck**: the GO stays pinned; `F = K (GO − HIP)` split at the GO (the point of
//!   application) into `F_N` along the normal and `F_T` in the tangent plane. The friction is
//!   `F_T` while `|F_T| ≤ μ_s F_N`. The CP tracker's feature switch is inhibited (static
//!   friction at a corner, §3.1.2).
//! - **Breakaway → transition**: the GO is released and converges to the CP under the
//!   feedback law (normalised, with feed-forward of the HIP's motion, time constant
//!   [`FrictionMaterial::transition_time_s`]); μ falls from μ_s to μ_d with the GO's
//!   projection error ([`crate::Stribeck`]); friction `μ F_N` along `F_T`.
//! - **Slip**: GO = CP; friction `μ_d F_N` against the CP's tangential velocity.
//! - **Slip → stuck** when the CP stops or reverses, or when `μ_d F_N[k] > μ_s F_N[k−1]`
//!   (the normal force jumps). The GO is then reset to the surface point `F_f / K` ahead of
//!   the CP, so the spring reproduces the friction force of the previous tick: the force is
//!   continuous. This is the thesis's "GO is reset to a location that ensures force
//!   continuity" (§3.1.1); Algorithm 1 writes the same thing as a scalar offset added to
//!   `F_T`. Doing it with the GO's position keeps one formula for the stuck force and makes
//!   the offset decay the right way when the HIP reverses.
//!
//! Two readings of the thesis that differ from a literal transcription, and why:
//! - Algorithm 1 adds the offset again in the dynamic state (`F_f = F_offset + μ F_N`), which
//!   would count the friction twice right after breakaway; here the dynamic friction is
//!   `μ F_N`, which equals `|F_T|` at breakaway, so the force stays continuous.
//! - Fig. 3.1.2 also shows a self-transition in the stuck state that resets the GO to the CP
//!   when the CP reverses; Algorithm 1 does not have it and it would drop the friction force
//!   to zero in one tick, so it is left out.

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

/// The whole friction renderer for one object: CP tracker, GO tracker and state machine.
#[derive(Clone, Copy, Debug)]
pub struct FrictionRenderer<O: Object> {
    material: FrictionMaterial,
    cp: O::State,
    go: O::State,
    mode: Mode,
    law: LawState<O::P>,
    prev_cp: Option<O::P>,
    prev_velocity: O::P,
    prev_normal_force: f32,
    prev_friction: O::P,
    psi0: f32,
}

/// The CP tracker's settings: one Gauss–Newton step per tick.
pub fn cp_config() -> TrackerConfig {
    TrackerConfig::default()
}

/// The GO tracker's settings for the transition: each tick closes `T/τ` of the gap and follows
/// the HIP's motion by feed-forward.
fn go_config(material: &FrictionMaterial, period_s: f32) -> TrackerConfig {
    let alpha = (period_s / material.transition_time_s.max(period_s)).clamp(0.0, 1.0);
    TrackerConfig {
        law: Law::Normalized { alpha },
        feedforward: true,
        convergence_radius: f32::INFINITY,
        ..TrackerConfig::default()
    }
}

impl<O: Object> FrictionRenderer<O> {
    /// A renderer for `object` with `material`, starting from a HIP at `hip`, ticking every
    /// `period_s`.
    pub fn new(object: &O, material: FrictionMaterial, hip: O::P, period_s: f32) -> Self {
        let cp = object.start(hip, cp_config());
        let mut go = object.start(hip, go_config(&material, period_s));
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
            prev_cp: None,
            prev_velocity: O::P::ZERO,
            prev_normal_force: 0.0,
            prev_friction: O::P::ZERO,
            psi0: 0.0,
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
            self.prev_normal_force = 0.0;
            self.prev_friction = O::P::ZERO;
            self.prev_velocity = cp_velocity;
            if let LawState::Dahl(d) = &mut self.law {
                FrictionLaw::<O::P>::reset(d);
            }
            if let LawState::LuGre(l) = &mut self.law {
                FrictionLaw::<O::P>::reset(l);
            }
            let frame = object.frame(cp_patch, cp_params);
            return FrictionOutput {
                mode: Mode::Free,
                contact,
                go: contact.point,
                go_patch: cp_patch as u16,
                go_params: cp_params,
                point_of_application: contact.point,
                normal: contact.normal,
                tangent: frame.tangent,
                normal_force_n: 0.0,
                friction_force_n: 0.0,
                friction: O::P::ZERO,
                total: O::P::ZERO,
                mu: 0.0,
                psi: contact.psi[0],
            };
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

        let mut mu = m.mu_static;
        let mut psi = contact.psi[0];

        // Slip: check the exits first, with this tick's normal force.
        if self.mode == Mode::Slip {
            let fn_now = (k * contact.depth + damping(contact.normal)).max(0.0);
            let reversed = cp_velocity.dot(self.prev_velocity) < 0.0;
            let stopped =
                cp_velocity.length_squared() < m.stop_speed_m_per_s * m.stop_speed_m_per_s;
            let jump = m.mu_dynamic * fn_now > m.mu_static * self.prev_normal_force;
            if reversed || stopped || jump {
                // Stuck again, with the GO placed where its spring carries the friction force
                // of the previous tick.
                self.mode = Mode::Stuck;
                let params = object.offset(cp_patch, cp_params, self.prev_friction * (1.0 / k));
                object.place(&mut self.go, cp_patch, params);
            }
        }

        let (go_patch, go_params, go_point, normal, tangent, normal_force, friction);
        match self.mode {
            Mode::Stuck | Mode::Free => {
                let (p, t) = O::position(&self.go);
                let fr = object.frame(p, t);
                let f = (fr.point - hip) * k;
                let f_n = (f.dot(fr.normal) + damping(fr.normal)).max(0.0);
                let f_t = f - fr.normal * f.dot(fr.normal);
                let limit = m.mu_static * f_n;
                if f_t.length_squared() <= limit * limit {
                    friction = f_t;
                    mu = m.mu_static;
                } else {
                    // Breakaway: friction at its static limit this tick, GO released.
                    friction = f_t.try_normalize().unwrap_or(O::P::ZERO) * limit;
                    self.mode = Mode::Transition;
                    self.psi0 = 0.0;
                }
                (go_patch, go_params, go_point, normal, tangent, normal_force) =
                    (p, t, fr.point, fr.normal, reference(&fr, friction), f_n);
            }
            Mode::Transition => {
                let g = object.track(&mut self.go, hip, period_s, true);
                let (p, t) = O::position(&self.go);
                let fr = object.frame(p, t);
                let f = (g.point - hip) * k;
                let f_n = (f.dot(fr.normal) + damping(fr.normal)).max(0.0);
                let f_t = f - fr.normal * f.dot(fr.normal);
                let psi_go = sqrt(g.psi[0] * g.psi[0] + g.psi[1] * g.psi[1]);
                if self.psi0 <= 0.0 {
                    self.psi0 = psi_go.max(f32::MIN_POSITIVE);
                }
                mu = m.stribeck.mu(m.mu_static, m.mu_dynamic, psi_go / self.psi0);
                let dir = f_t
                    .try_normalize()
                    .unwrap_or_else(|| -cp_velocity.try_normalize().unwrap_or(O::P::ZERO));
                friction = dir * (mu * f_n);
                psi = psi_go;
                // Caught up: within the distance tolerance, or μ within 1 % of its way to μ_d.
                let gap2 = (g.point - contact.point).length_squared();
                if gap2 <= m.converge_tol_m * m.converge_tol_m || psi_go <= 0.01 * self.psi0 {
                    self.mode = Mode::Slip;
                }
                (go_patch, go_params, go_point, normal, tangent, normal_force) =
                    (p, t, g.point, fr.normal, reference(&fr, friction), f_n);
            }
            Mode::Slip => {
                object.place(&mut self.go, cp_patch, cp_params);
                let fr = object.frame(cp_patch, cp_params);
                let f_n = (k * contact.depth + damping(contact.normal)).max(0.0);
                mu = m.mu_dynamic;
                let dir = -cp_velocity.try_normalize().unwrap_or(O::P::ZERO);
                friction = dir * (mu * f_n);
                (go_patch, go_params, go_point, normal, tangent, normal_force) = (
                    cp_patch,
                    cp_params,
                    contact.point,
                    contact.normal,
                    reference(&fr, friction),
                    f_n,
                );
            }
        }
        self.prev_velocity = cp_velocity;
        self.prev_normal_force = normal_force;
        self.prev_friction = friction;
        let total = normal * normal_force + friction;
        FrictionOutput {
            mode: self.mode,
            contact,
            go: go_point,
            go_patch: go_patch as u16,
            go_params,
            point_of_application: go_point,
            normal,
            tangent,
            normal_force_n: normal_force,
            friction_force_n: signed_along(friction, tangent),
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
        FrictionOutput {
            mode: self.mode,
            contact,
            go: contact.point,
            go_patch: cp_patch as u16,
            go_params: cp_params,
            point_of_application: contact.point,
            normal: contact.normal,
            tangent: reference(&fr, friction),
            normal_force_n: f_n,
            friction_force_n: signed_along(friction, reference(&fr, friction)),
            friction,
            total: contact.normal * f_n + friction,
            mu,
            psi: contact.psi[0],
        }
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
