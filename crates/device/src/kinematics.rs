//! Kinematics of the planar five-bar pantograph (2 DoF).
//!
//! # Geometry and conventions
//!
//! Everything is in the device frame of `ARCHITECTURE.md`: metres, origin midway between the
//! two motor axes, x along the line through the motor axes, y away from the motors into the
//! workspace.
//!
//! ```text
//!                      E (HIP)
//!                     / \
//!            distal  /   \  distal
//!                   /     \
//!               P1 .       . P2        elbows
//!                   \     /
//!          proximal  \   /  proximal
//!                     A1 A2            motor axes, A1 = (−d/2, 0), A2 = (d/2, 0)
//! ```
//!
//! Joint 1 is the motor at `A1 = (−d/2, 0)` (left), joint 2 the one at `A2 = (d/2, 0)`
//! (right). The joint angle `θi` is the angle of the proximal link `Ai → Pi` from the +x axis,
//! counterclockwise positive, so `Pi = Ai + li (cos θi, sin θi)`. The distal links of lengths
//! `b1`, `b2` join the elbows to the end effector (the haptic interface point, HIP) `E`.
//!
//! # Branches
//!
//! - **Forward kinematics** (assembly mode): of the two intersections of the circles
//!   `|E − P1| = b1`, `|E − P2| = b2`, the one to the left of `P1 → P2`
//!   (`(P2 − P1) × (E − P1) > 0`), i.e. the one away from the motors while the elbows are
//!   apart in x.
//! - **Inverse kinematics** (working mode, "elbows out"): the left elbow lies to the left of
//!   `A1 → E` and the right elbow to the right of `A2 → E`, so
//!   `θ1 = atan2(E − A1) + α1`, `θ2 = atan2(E − A2) − α2` with `αi ∈ [0, π]` the angle at `Ai`
//!   of the triangle `Ai Pi E` (law of cosines). Angles are returned with `θ1 ∈ [0, 2π)` and
//!   `θ2 ∈ (−π, π]`, mirror images of each other (`θ1 ↔ π − θ2`), so neither wraps inside the
//!   working range. A target whose elbows-out configuration is not in the forward assembly
//!   mode is rejected ([`KinematicsError::OtherAssemblyMode`]), so that a successful inverse
//!   always round-trips through [`Pantograph::forward`].
//!
//! # Jacobian
//!
//! Differentiating the loop constraints `|E − Pi|² = bi²` gives, with `ri = E − Pi` and
//! `ti = ∂Pi/∂θi = perp(Pi − Ai)` (`perp(x, y) = (−y, x)`),
//!
//! ```text
//! ri · dE = (ri · ti) dθi        ⇒        J = R⁻¹ diag(r1·t1, r2·t2),   R = [r1ᵀ; r2ᵀ]
//! ```
//!
//! which needs no trigonometry once the elbows are known. `J` is singular where a proximal
//! link is aligned with its distal link (`ri · ti = 0`: the arm is stretched or folded, the
//! boundary of the workspace) or where the distal links are aligned (`det R = r1 × r2 = 0`:
//! the end effector gains a free direction). Both are detected by the relative, scale-free
//! measure `q = 2 |det J| / ‖J‖²_F = 2 / (κ + 1/κ)` (κ the 2-norm condition number), compared
//! with the limit set by [`Pantograph::max_condition`].
//!
//! # Cost per tick
//!
//! [`Pantograph::configuration`] needs `cos`/`sin` of each joint angle and one square root,
//! both from [`crate::math`] (single-precision polynomials and Newton steps, no `libm`
//! call; joint angles beyond [`crate::math::SIN_COS_MAX_ANGLE_RAD`] are refused as no pose);
//! the Jacobian needs one division; `τ = Jᵀ F` is four products. The tick solves the
//! configuration once and reuses it for `Jᵀ F` ([`Pantograph::joint_torques_at`]). Inverse
//! kinematics (`atan2`, `acos`) is for setup and tests, not the tick.

pub use crate::error::{KinematicsError, Singularity};
use crate::error::{SpecError, positive};
use crate::math;
use core::f32::consts::{PI, TAU};
use nurbs::Vec2;

/// Default largest condition number of the Jacobian accepted before a configuration counts
/// as singular.
pub const DEFAULT_MAX_CONDITION: f32 = 100.0;

/// Elbows closer than this fraction of the distal link lengths count as coincident.
const COINCIDENT_REL: f32 = 1e-6;

/// Link lengths and base separation of a five-bar pantograph, validated at construction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pantograph {
    base_separation_m: f32,
    proximal_m: [f32; 2],
    distal_m: [f32; 2],
    max_condition: f32,
    /// `2 / (κmax + 1/κmax)`, the smallest accepted `2 |det J| / ‖J‖²_F`.
    min_isotropy: f32,
}

/// A solved configuration: joint angles, elbows and HIP.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Configuration {
    /// Joint angles θ1, θ2 (rad).
    pub joints_rad: [f32; 2],
    /// Elbows P1, P2 in the device frame (m).
    pub elbows_in_device: [Vec2; 2],
    /// End effector (HIP) in the device frame (m).
    pub hip_in_device: Vec2,
}

/// The Jacobian `J = ∂(x, y)/∂(θ1, θ2)` (m/rad).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Jacobian {
    /// `m[row][column]`: rows x, y; columns θ1, θ2.
    pub m: [[f32; 2]; 2],
}

impl Jacobian {
    /// HIP velocity `J θ̇` (m/s) for joint rates `θ̇` (rad/s).
    pub fn velocity(&self, joint_rates_rad_per_s: [f32; 2]) -> Vec2 {
        let [a, b] = joint_rates_rad_per_s;
        Vec2::new(
            self.m[0][0] * a + self.m[0][1] * b,
            self.m[1][0] * a + self.m[1][1] * b,
        )
    }

    /// Joint torques `τ = Jᵀ F` (N·m) that produce the force `F` (N) at the HIP.
    pub fn torques(&self, force_n: Vec2) -> [f32; 2] {
        [
            self.m[0][0] * force_n.x + self.m[1][0] * force_n.y,
            self.m[0][1] * force_n.x + self.m[1][1] * force_n.y,
        ]
    }

    /// Determinant (m²/rad²).
    pub fn determinant(&self) -> f32 {
        self.m[0][0] * self.m[1][1] - self.m[0][1] * self.m[1][0]
    }

    /// `2 |det J| / ‖J‖²_F = 2 / (κ + 1/κ)`: 1 for an isotropic Jacobian, 0 for a singular
    /// one (0 for a zero matrix too).
    pub fn isotropy(&self) -> f32 {
        let frob2 = self.m[0][0] * self.m[0][0]
            + self.m[0][1] * self.m[0][1]
            + self.m[1][0] * self.m[1][0]
            + self.m[1][1] * self.m[1][1];
        if frob2 > 0.0 && frob2.is_finite() {
            (2.0 * self.determinant().abs() / frob2).min(1.0)
        } else {
            0.0
        }
    }

    /// 2-norm condition number `σmax / σmin` (infinite when singular). Uses a square root:
    /// meant for analysis, not for the tick.
    pub fn condition_number(&self) -> f32 {
        condition_from_isotropy(self.isotropy())
    }
}

fn condition_from_isotropy(q: f32) -> f32 {
    if q > 0.0 {
        let s2 = 1.0 - q * q;
        (1.0 + math::sqrt(if s2 > 0.0 { s2 } else { 0.0 })) / q
    } else {
        f32::INFINITY
    }
}

fn perp(v: Vec2) -> Vec2 {
    Vec2::new(-v.y, v.x)
}

fn cross(a: Vec2, b: Vec2) -> f32 {
    a.x * b.y - a.y * b.x
}

/// `(sin θ, cos θ)` of a finite joint angle, without `libm` ([`math::sin_cos`]).
fn joint_sin_cos(quantity: &'static str, theta_rad: f32) -> Result<(f32, f32), KinematicsError> {
    math::sin_cos(theta_rad).ok_or(KinematicsError::AngleOutOfRange {
        quantity,
        value_rad: theta_rad,
        max_rad: math::SIN_COS_MAX_ANGLE_RAD,
    })
}

fn check_finite(quantity: &'static str, value: f32) -> Result<(), KinematicsError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(KinematicsError::NonFinite { quantity, value })
    }
}

impl Pantograph {
    /// A pantograph with motor axes `base_separation_m` apart, proximal links
    /// `proximal_m = [l1, l2]` and distal links `distal_m = [b1, b2]` (metres), with the
    /// singularity limit [`DEFAULT_MAX_CONDITION`]. Every length must be finite and positive.
    pub fn new(
        base_separation_m: f32,
        proximal_m: [f32; 2],
        distal_m: [f32; 2],
    ) -> Result<Self, SpecError> {
        positive("base_separation_m", base_separation_m)?;
        positive("proximal_m[0]", proximal_m[0])?;
        positive("proximal_m[1]", proximal_m[1])?;
        positive("distal_m[0]", distal_m[0])?;
        positive("distal_m[1]", distal_m[1])?;
        Ok(Self {
            base_separation_m,
            proximal_m,
            distal_m,
            max_condition: DEFAULT_MAX_CONDITION,
            min_isotropy: isotropy_limit(DEFAULT_MAX_CONDITION),
        })
    }

    /// The same pantograph with another largest accepted Jacobian condition number
    /// (finite, ≥ 1).
    pub fn with_max_condition(self, max_condition: f32) -> Result<Self, SpecError> {
        if !max_condition.is_finite() {
            return Err(SpecError::NonFinite {
                field: "max_condition_number",
                value: max_condition,
            });
        }
        if max_condition < 1.0 {
            return Err(SpecError::OutOfRange {
                field: "max_condition_number",
                value: max_condition,
                requirement: "at least 1",
            });
        }
        Ok(Self {
            max_condition,
            min_isotropy: isotropy_limit(max_condition),
            ..self
        })
    }

    /// Distance between the motor axes (m).
    pub fn base_separation_m(&self) -> f32 {
        self.base_separation_m
    }

    /// Proximal link lengths `[l1, l2]` (m).
    pub fn proximal_m(&self) -> [f32; 2] {
        self.proximal_m
    }

    /// Distal link lengths `[b1, b2]` (m).
    pub fn distal_m(&self) -> [f32; 2] {
        self.distal_m
    }

    /// Largest accepted Jacobian condition number.
    pub fn max_condition(&self) -> f32 {
        self.max_condition
    }

    /// Motor axis of `joint` (0: left, 1: right) in the device frame; joints other than 0
    /// are taken as 1.
    pub fn motor_axis_in_device(&self, joint: usize) -> Vec2 {
        let half = 0.5 * self.base_separation_m;
        if joint == 0 {
            Vec2::new(-half, 0.0)
        } else {
            Vec2::new(half, 0.0)
        }
    }

    /// Forward kinematics with the elbows: joint angles (rad) → configuration.
    pub fn configuration(&self, joints_rad: [f32; 2]) -> Result<Configuration, KinematicsError> {
        check_finite("joint angle θ1", joints_rad[0])?;
        check_finite("joint angle θ2", joints_rad[1])?;
        let [l1, l2] = self.proximal_m;
        let [b1, b2] = self.distal_m;
        let (s1, c1) = joint_sin_cos("joint angle θ1", joints_rad[0])?;
        let (s2, c2) = joint_sin_cos("joint angle θ2", joints_rad[1])?;
        let p1 = self.motor_axis_in_device(0) + l1 * Vec2::new(c1, s1);
        let p2 = self.motor_axis_in_device(1) + l2 * Vec2::new(c2, s2);
        let u = p2 - p1;
        let d2 = u.dot(u);
        let tiny = COINCIDENT_REL * (b1 + b2);
        if d2 <= tiny * tiny {
            return Err(KinematicsError::ElbowsCoincide {
                elbow_distance_m: math::sqrt(d2),
            });
        }
        // Circle–circle intersection, in units of the elbow distance D:
        // E = P1 + (a/D) u + (h/D) perp(u), a = (b1² − b2² + D²) / (2D), h² = b1² − a².
        let a_rel = (b1 * b1 - b2 * b2 + d2) / (2.0 * d2);
        let h_rel2 = b1 * b1 / d2 - a_rel * a_rel;
        if h_rel2.is_nan() || h_rel2 < 0.0 {
            return Err(KinematicsError::DistalLinksApart {
                elbow_distance_m: math::sqrt(d2),
                min_m: (b1 - b2).abs(),
                max_m: b1 + b2,
            });
        }
        let hip = p1 + a_rel * u + math::sqrt(h_rel2) * perp(u);
        Ok(Configuration {
            joints_rad,
            elbows_in_device: [p1, p2],
            hip_in_device: hip,
        })
    }

    /// Forward kinematics: joint angles (rad) → HIP in the device frame (m).
    pub fn forward(&self, joints_rad: [f32; 2]) -> Result<Vec2, KinematicsError> {
        self.configuration(joints_rad).map(|c| c.hip_in_device)
    }

    /// The Jacobian at a solved configuration, or [`KinematicsError::Singular`] when its
    /// condition number exceeds [`Pantograph::max_condition`]. Algebraic: no trigonometry,
    /// one division.
    pub fn jacobian_at(&self, config: &Configuration) -> Result<Jacobian, KinematicsError> {
        let e = config.hip_in_device;
        let [p1, p2] = config.elbows_in_device;
        let r1 = e - p1;
        let r2 = e - p2;
        let d1 = r1.dot(perp(p1 - self.motor_axis_in_device(0)));
        let d2 = r2.dot(perp(p2 - self.motor_axis_in_device(1)));
        let det_r = cross(r1, r2);
        // q = 2|det J| / ‖J‖²_F with J = R⁻¹ diag(d1, d2), compared without dividing.
        let num = 2.0 * (d1 * d2 * det_r).abs();
        let den = d1 * d1 * r2.dot(r2) + d2 * d2 * r1.dot(r1);
        if !(num.is_finite() && den.is_finite()) {
            return Err(KinematicsError::NonFinite {
                quantity: "configuration",
                value: num + den,
            });
        }
        if num <= self.min_isotropy * den {
            let q = if den > 0.0 { num / den } else { 0.0 };
            return Err(KinematicsError::Singular {
                singularity: self.closest_singularity(d1, d2, det_r),
                condition: condition_from_isotropy(q),
                max_condition: self.max_condition,
            });
        }
        let inv = 1.0 / det_r;
        Ok(Jacobian {
            m: [
                [r2.y * d1 * inv, -r1.y * d2 * inv],
                [-r2.x * d1 * inv, r1.x * d2 * inv],
            ],
        })
    }

    fn closest_singularity(&self, d1: f32, d2: f32, det_r: f32) -> Singularity {
        let [l1, l2] = self.proximal_m;
        let [b1, b2] = self.distal_m;
        // Sines of the angles between the links that a singularity aligns.
        let sin_arm1 = d1.abs() / (l1 * b1);
        let sin_arm2 = d2.abs() / (l2 * b2);
        let sin_distal = det_r.abs() / (b1 * b2);
        if sin_distal <= sin_arm1 && sin_distal <= sin_arm2 {
            Singularity::DistalLinksAligned
        } else if sin_arm1 <= sin_arm2 {
            Singularity::ArmAligned { joint: 0 }
        } else {
            Singularity::ArmAligned { joint: 1 }
        }
    }

    /// The Jacobian at joint angles (rad).
    pub fn jacobian(&self, joints_rad: [f32; 2]) -> Result<Jacobian, KinematicsError> {
        self.jacobian_at(&self.configuration(joints_rad)?)
    }

    /// Joint torques `τ = Jᵀ F` (N·m) for the force `F` (N) at the HIP.
    pub fn joint_torques(
        &self,
        joints_rad: [f32; 2],
        force_n: Vec2,
    ) -> Result<[f32; 2], KinematicsError> {
        check_finite("force x", force_n.x)?;
        check_finite("force y", force_n.y)?;
        self.joint_torques_at(&self.configuration(joints_rad)?, force_n)
    }

    /// Joint torques `τ = Jᵀ F` (N·m) for the force `F` (N) at the HIP of a configuration
    /// already solved (the tick's own forward kinematics, not solved again).
    pub fn joint_torques_at(
        &self,
        config: &Configuration,
        force_n: Vec2,
    ) -> Result<[f32; 2], KinematicsError> {
        check_finite("force x", force_n.x)?;
        check_finite("force y", force_n.y)?;
        let tau = self.jacobian_at(config)?.torques(force_n);
        check_finite("torque τ1", tau[0])?;
        check_finite("torque τ2", tau[1])?;
        Ok(tau)
    }

    /// Inverse kinematics in the elbows-out working mode (see the module docs): HIP (m) →
    /// joint angles `[θ1 ∈ [0, 2π), θ2 ∈ (−π, π]]` (rad). Succeeds only where forward
    /// kinematics gives the target back and the Jacobian is well-conditioned. Joint end stops
    /// are not checked here (targets behind the motor axes can need crossed proximal links);
    /// [`crate::spec::DeviceSpec::validate`] checks them over the workspace box.
    pub fn inverse(&self, hip_in_device: Vec2) -> Result<[f32; 2], KinematicsError> {
        check_finite("hip x", hip_in_device.x)?;
        check_finite("hip y", hip_in_device.y)?;
        let mut joints = [0.0; 2];
        let mut elbows = [Vec2::ZERO; 2];
        for joint in 0..2 {
            let l = self.proximal_m[joint];
            let b = self.distal_m[joint];
            let axis = self.motor_axis_in_device(joint);
            let delta = hip_in_device - axis;
            let rho2 = delta.dot(delta);
            let max_m = l + b;
            let min_m = (l - b).abs();
            if rho2.is_nan() || rho2 > max_m * max_m {
                return Err(KinematicsError::TooFar {
                    joint,
                    distance_m: math::sqrt(rho2),
                    max_m,
                });
            }
            let tiny = COINCIDENT_REL * l;
            if rho2 < min_m * min_m || rho2 <= tiny * tiny {
                return Err(KinematicsError::TooClose {
                    joint,
                    distance_m: math::sqrt(rho2),
                    min_m,
                });
            }
            let rho = math::sqrt(rho2);
            // Law of cosines in the triangle Ai Pi E.
            let cos_alpha = ((l * l + rho2 - b * b) / (2.0 * l * rho)).clamp(-1.0, 1.0);
            let alpha = libm::acosf(cos_alpha);
            let phi = libm::atan2f(delta.y, delta.x);
            let theta = if joint == 0 {
                let t = phi + alpha;
                if t < 0.0 {
                    t + TAU
                } else if t >= TAU {
                    t - TAU
                } else {
                    t
                }
            } else {
                let t = phi - alpha;
                if t <= -PI { t + TAU } else { t }
            };
            let (s, c) = joint_sin_cos(["joint angle θ1", "joint angle θ2"][joint], theta)?;
            joints[joint] = theta;
            elbows[joint] = axis + l * Vec2::new(c, s);
        }
        let config = Configuration {
            joints_rad: joints,
            elbows_in_device: elbows,
            hip_in_device,
        };
        self.jacobian_at(&config)?;
        if cross(elbows[1] - elbows[0], hip_in_device - elbows[0]) <= 0.0 {
            return Err(KinematicsError::OtherAssemblyMode {
                x_m: hip_in_device.x,
                y_m: hip_in_device.y,
            });
        }
        Ok(joints)
    }
}

fn isotropy_limit(max_condition: f32) -> f32 {
    2.0 / (max_condition + 1.0 / max_condition)
}
