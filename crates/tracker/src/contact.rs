//! What the tracking layer hands to the force layers each tick: the contact geometry and the
//! penalty force (thesis eq. 2.17).

use nurbs::Point;

/// A feature of a multi-patch object: the thing the closest point currently lies on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Feature {
    /// The interior of patch `i` (a curve of a 2-D chain or a surface of a 3-D shell).
    Patch(u16),
    /// Vertex `k` of a 2-D chain (where curve `k − 1` ends and curve `k` starts).
    Vertex(u16),
    /// Edge `e` of a 3-D shell, shared by two patches.
    Edge(u16),
    /// Corner `c` of a 3-D shell, where edges meet.
    Corner(u16),
}

impl Feature {
    /// The patch index, for [`Feature::Patch`].
    pub fn patch(self) -> Option<usize> {
        match self {
            Feature::Patch(i) => Some(i as usize),
            _ => None,
        }
    }
}

/// Contact geometry for one tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact<P> {
    /// Active feature.
    pub feature: Feature,
    /// The patch whose tracker produced the closest point (for vertices, edges and corners:
    /// the patch the tracker stays on).
    pub patch: u16,
    /// Parameters of the closest point on that patch (`[u, 0]` on curves).
    pub params: [f32; 2],
    /// Closest point.
    pub point: P,
    /// Unit outward normal at the contact (at vertices, edges and corners: along the line from
    /// the closest point to the HIP, oriented outward).
    pub normal: P,
    /// Signed penetration depth `(point − HIP)·normal`: positive inside, negative outside.
    pub depth: f32,
    /// Projection error `Ψ` of the tracker (`[Ψ_u, 0]` on curves).
    pub psi: [f32; 2],
    /// Whether the HIP is inside the object.
    pub inside: bool,
}

/// Penalty parameters of a material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Penalty {
    /// Stiffness `k` (N/m).
    pub stiffness_n_per_m: f32,
    /// Damping `b` on the normal velocity (N·s/m).
    pub damping_ns_per_m: f32,
}

impl<P: Point> Contact<P> {
    /// Normal force magnitude `k·depth − b·(v·n)` (thesis eq. 2.17 plus damping), zero when
    /// not in contact and never negative: a penalty pushes the HIP out, it never pulls it in
    /// (damping while leaving the surface would otherwise make it sticky).
    #[inline]
    pub fn normal_force(&self, penalty: &Penalty, hip_velocity: P) -> f32 {
        if self.depth <= 0.0 {
            return 0.0;
        }
        let f = penalty.stiffness_n_per_m * self.depth
            - penalty.damping_ns_per_m * hip_velocity.dot(self.normal);
        nurbs::math::max(0.0, f)
    }

    /// The penalty force vector `normal_force · n`.
    #[inline]
    pub fn penalty_force(&self, penalty: &Penalty, hip_velocity: P) -> P {
        self.normal * self.normal_force(penalty, hip_velocity)
    }
}
