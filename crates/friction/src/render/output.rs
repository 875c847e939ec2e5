//! What a renderer's tick reports: its mode and why it changed, the output (forces, the GO,
//! the contact), and the points under what rides on the surface.

use tracker::Contact;

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
    /// Stuck → transition: `|F_T| > μ_s F_N`; for the velocity-based laws, stuck → slip.
    Breakaway,
    /// Transition → slip: μ reached μ_d (the GO is within `converge_tol_m` of its slip
    /// position).
    Converged,
    /// Dynamic → stuck: the GO's slip speed fell below the stop speed (the hand stopped or
    /// pressed in); for the velocity-based laws, the CP's speed did.
    Stopped,
    /// Dynamic → stuck: the HIP's step went back towards the GO.
    Reversed,
    /// Dynamic → stuck: the normal force jumped, `μ_d F_N[k] > μ_s F_N[k−1]`.
    NormalForceJump,
    /// Contact → free: the HIP left the object (or, as [`SwitchCause::or_carried`] reports
    /// it, the contact ended with the renderer: a material change, a lost pose).
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

    /// The cause to report with `mode` when the tick's source named `self`, given the
    /// (mode, cause) reported the tick before. A source that names no cause (a renderer
    /// restarted or not running, a stateless penalty baseline) still switches: into contact
    /// by [`SwitchCause::Contact`], out of it by [`SwitchCause::Released`]; with the mode
    /// unchanged the earlier cause stays (it is why the mode last changed).
    pub fn or_carried(self, mode: Mode, previous: (Mode, SwitchCause)) -> SwitchCause {
        match (self, previous) {
            (SwitchCause::None, (before, cause)) if before == mode => cause,
            (SwitchCause::None, _) if mode == Mode::Free => SwitchCause::Released,
            (SwitchCause::None, _) => SwitchCause::Contact,
            (cause, _) => cause,
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
    /// The GO's slip speed (m/s, low-passed over [`FrictionMaterial::transition_time_s`](crate::FrictionMaterial::transition_time_s)): a
    /// dynamic mode sticks once it falls below the stop speed.
    pub slip_speed_m_per_s: f32,
}

/// The points of an object under what rides on its surface ([`FrictionRenderer::anchors`](super::FrictionRenderer::anchors)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Anchors<P> {
    /// The point under the CP tracker.
    pub cp: P,
    /// The point under the GO, `None` when free.
    pub go: Option<P>,
}
