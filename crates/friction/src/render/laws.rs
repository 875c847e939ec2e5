//! The renderer with a velocity-based friction law (Coulomb–viscous, Karnopp, Dahl, LuGre,
//! `crate::models`) instead of Algorithm 1: a penalty normal force at the CP and the law's
//! friction there, no god-object.

use crate::models::{CoulombViscous, Dahl, FrictionLaw, Karnopp, LuGre, TangentialInput};
use nurbs::Point;
use nurbs::math::{self, sqrt};
use tracker::{Contact, Object};

use super::{FrictionOutput, FrictionRenderer, Mode, SwitchCause, square};

/// Per-model state of the velocity-based laws.
#[derive(Clone, Copy, Debug)]
pub(super) enum LawState<P> {
    StickSlip,
    Coulomb(CoulombViscous),
    Karnopp(Karnopp),
    Dahl(Dahl<P>),
    LuGre(LuGre<P>),
}

impl<P: Point> LawState<P> {
    /// Forgets the bristle state of the laws that have one (contact lost).
    pub(super) fn reset(&mut self) {
        match self {
            LawState::Dahl(l) => FrictionLaw::<P>::reset(l),
            LawState::LuGre(l) => FrictionLaw::<P>::reset(l),
            _ => {}
        }
    }
}

impl<O: Object> FrictionRenderer<O> {
    /// The velocity-based laws: penalty normal force at the CP, friction from the law.
    pub(super) fn velocity_law_tick(
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
        // Each edge with its own cause: whichever mode contact starts in, it is the contact.
        let moving = cp_velocity.length_squared() >= square(m.stop_speed_m_per_s);
        let (mode, cause) = match (self.mode, moving) {
            (Mode::Free, false) => (Mode::Stuck, SwitchCause::Contact),
            (Mode::Free, true) => (Mode::Slip, SwitchCause::Contact),
            (_, false) => (Mode::Stuck, SwitchCause::Stopped),
            (_, true) => (Mode::Slip, SwitchCause::Breakaway),
        };
        self.switch(mode, cause);
        self.prev_normal_force = f_n;
        let mu = if f_n > 0.0 {
            sqrt(friction.length_squared()) / f_n
        } else {
            0.0
        };
        self.at_cp(contact, (cp_patch, cp_params), &fr, f_n, friction, mu)
    }
}
