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

/// The whole friction renderer for one object: CP tracker, GO tracker and state machine.
#[derive(Clone, Copy, Debug)]
pub struct FrictionRenderer<O: Object> {
    material: FrictionMaterial,
    cp: O::State,
    go: O::State,
    mode: Mode,
    law: LawState<O::P>,
    /// The point of application (the GO the spring pulls to): patch and parameters.
    pa: (usize, [f32; 2]),
    /// Where the GO was at the end of the last tick.
    pa_point: O::P,
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
            pa: (0, [0.0; 2]),
            pa_point: O::P::ZERO,
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
            self.pa = (cp_patch, cp_params);
        }

        // Dynamic → stuck when the CP stops or reverses, or the normal force jumps
        // (μ_d F_N[k] > μ_s F_N[k−1]). The GO stays where it is, so the spring, and with it the
        // force, carries on unchanged.
        if matches!(self.mode, Mode::Transition | Mode::Slip) {
            let fn_now = (k * contact.depth + damping(contact.normal)).max(0.0);
            let reversed = cp_velocity.dot(self.prev_velocity) < 0.0;
            let stopped =
                cp_velocity.length_squared() < m.stop_speed_m_per_s * m.stop_speed_m_per_s;
            // A relative margin keeps f32 noise from firing it when μ_s = μ_d.
            let jump =
                m.mu_dynamic * fn_now > m.mu_static * self.prev_normal_force * (1.0 + 1e-4) + 1e-6;
            if reversed || stopped || jump {
                self.mode = Mode::Stuck;
            }
        }

        let mut mu = m.mu_static;
        let mut psi = contact.psi[0];
        match self.mode {
            Mode::Transition => {
                // The thesis's GO, released at breakaway, converges to the CP; its projection
                // error sets μ.
                let g = object.track(&mut self.go, hip, period_s, true);
                let psi_go = sqrt(g.psi[0] * g.psi[0] + g.psi[1] * g.psi[1]);
                if self.psi0 <= 0.0 {
                    self.psi0 = psi_go.max(f32::MIN_POSITIVE);
                }
                // Caught up: within the distance tolerance, or μ within 1 % of its way to μ_d;
                // the last 1 % is snapped, so this tick already renders slip.
                let gap = g.point - contact.point;
                let caught_up = gap.length_squared() <= m.converge_tol_m * m.converge_tol_m
                    || psi_go <= 0.01 * self.psi0;
                mu = if caught_up {
                    self.mode = Mode::Slip;
                    m.mu_dynamic
                } else {
                    m.stribeck.mu(m.mu_static, m.mu_dynamic, psi_go / self.psi0)
                };
                psi = psi_go;
                self.pa = self.tow(object, &contact, hip, cp_velocity, mu);
            }
            Mode::Slip => {
                mu = m.mu_dynamic;
                self.pa = self.tow(object, &contact, hip, cp_velocity, mu);
            }
            Mode::Stuck | Mode::Free => {}
        }

        // The force is the spring from the HIP to the point of application (the GO).
        let (pa_patch, pa_params) = self.pa;
        let fr = object.frame(pa_patch, pa_params);
        let f = (fr.point - hip) * k;
        let normal_force = (f.dot(fr.normal) + damping(fr.normal)).max(0.0);
        let mut friction = tangential(f, fr.normal);
        if self.mode == Mode::Stuck {
            let limit = m.mu_static * normal_force;
            if friction.length_squared() > limit * limit {
                // Breakaway: the GO moves to the static limit (continuous: the spring was just
                // past it) and the thesis's GO tracker is released from the stuck point.
                self.mode = Mode::Transition;
                self.psi0 = 0.0;
                object.place(&mut self.go, pa_patch, pa_params);
                let behind = friction.try_normalize().unwrap_or(O::P::ZERO);
                self.pa = self.lag_point(object, &contact, hip, behind, m.mu_static, f32::INFINITY);
                friction = behind * limit;
            }
        }
        self.prev_velocity = cp_velocity;
        self.prev_normal_force = normal_force;
        self.prev_friction = friction;
        // After a breakaway the GO moved this tick; otherwise `fr` is already its frame.
        let go = if self.pa == (pa_patch, pa_params) {
            fr
        } else {
            object.frame(self.pa.0, self.pa.1)
        };
        self.pa_point = go.point;
        let total = fr.normal * normal_force + friction;
        FrictionOutput {
            mode: self.mode,
            contact,
            go: go.point,
            go_patch: self.pa.0 as u16,
            go_params: self.pa.1,
            point_of_application: go.point,
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

    /// Moves the GO (the point of application) while sliding: it is towed behind the CP like a
    /// trailer, keeping its bearing from the CP, at the distance where the spring to the HIP
    /// carries `μ F_N` (see [`Self::lag_point`]), but never further from the CP than it already
    /// is. So the GO only ever moves towards the HIP (friction can only dissipate), a turn of
    /// the HIP swings it round smoothly (the force direction never jumps), and a GO that is
    /// closer than the target distance (the HIP pressed deeper) waits for the spring to
    /// stretch, as when stuck.
    fn tow(
        &self,
        object: &O,
        contact: &Contact<O::P>,
        hip: O::P,
        cp_velocity: O::P,
        mu: f32,
    ) -> (usize, [f32; 2]) {
        let offset = tangential(self.pa_point - contact.point, contact.normal);
        let dist2 = offset.length_squared();
        let behind = offset
            .try_normalize()
            .unwrap_or_else(|| -cp_velocity.try_normalize().unwrap_or(O::P::ZERO));
        self.lag_point(object, contact, hip, behind, mu, sqrt(dist2))
    }

    /// The surface point behind the CP (in the tangential direction `behind`), at most
    /// `max_lag_m` from it, where the spring to the HIP carries a friction force `μ F_N`, both
    /// measured at that point. On a flat surface that is `μ · depth` from the CP; on a curved
    /// one the tilt of the normal changes the split by about `κ · depth`, so two secant
    /// corrections of the distance follow.
    fn lag_point(
        &self,
        object: &O,
        contact: &Contact<O::P>,
        hip: O::P,
        behind: O::P,
        mu: f32,
        max_lag_m: f32,
    ) -> (usize, [f32; 2]) {
        let (patch, params) = O::position(&self.cp);
        let mut lag_m = mu * contact.depth.max(0.0);
        let mut at = object.offset(patch, params, behind * lag_m.min(max_lag_m));
        for _ in 0..2 {
            let fr = object.frame(patch, at);
            let d = fr.point - hip;
            let f_n = d.dot(fr.normal);
            let f_t = sqrt(tangential(d, fr.normal).length_squared());
            if f_t <= f32::MIN_POSITIVE || f_n <= 0.0 {
                break;
            }
            lag_m *= mu * f_n / f_t;
            at = object.offset(patch, params, behind * lag_m.min(max_lag_m));
        }
        (patch, at)
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
