//! The per-tick tracking of a shell: the active feature, the surface tracker on the active
//! patch and the switches between patches, edges and corners (Voronoi regions).

use super::*;

/// The per-tick state of tracking one shell: active feature and one surface tracker. Holds no
/// borrow.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShellTracker {
    feature: Feature,
    tracker: Tracker<Vec3, 2>,
    patch: usize,
    sliding: bool,
}

const MAX_SWITCHES: usize = 4;
/// Sides are tested when the closest point is within this fraction of the domain from them.
const NEAR_SIDE: f32 = 0.25;

enum Decision {
    Stay,
    Patch(usize, [f32; 2]),
    Edge(u16),
    Corner(u16),
}

impl ShellTracker {
    /// Starts on the patch nearest to `hip`.
    pub fn new<const K: usize, const P: usize>(
        shell: &Shell<K, P>,
        hip: Vec3,
        cfg: TrackerConfig,
    ) -> Self {
        let (i, t) = shell.nearest(hip);
        ShellTracker {
            feature: Feature::Patch(i as u16),
            tracker: shell.tracker_on(i, t, cfg),
            patch: i,
            sliding: false,
        }
    }

    /// Active feature.
    pub fn feature(&self) -> Feature {
        self.feature
    }

    /// The patch the tracker is on and its parameters.
    pub fn position(&self) -> (usize, [f32; 2]) {
        (self.patch, self.tracker.t())
    }

    /// The patch's jet at [`ShellTracker::position`] (the tracker's own evaluation).
    pub fn jet(&self) -> &crate::patch::Jet<Vec3, 2> {
        self.tracker.jet()
    }

    /// Sliding mode, as [`crate::ChainTracker::set_sliding`]: switch features only when the
    /// tracked point reaches a patch boundary.
    pub fn set_sliding(&mut self, sliding: bool) {
        self.sliding = sliding;
    }

    /// Re-evaluates the tracker on `shell` where it is, keeping the feature (as
    /// [`crate::ChainTracker::refresh`]).
    pub fn refresh<const K: usize, const P: usize>(&mut self, shell: &Shell<K, P>) {
        self.tracker.refresh(&shell.surface(self.patch));
    }

    /// Puts the tracker on patch `i` at `t`.
    pub fn reset<const K: usize, const P: usize>(
        &mut self,
        shell: &Shell<K, P>,
        i: usize,
        t: [f32; 2],
    ) {
        let i = i.min(shell.surface_count().saturating_sub(1));
        self.patch = i;
        self.feature = Feature::Patch(i as u16);
        self.tracker = shell.tracker_on(i, t, *self.tracker.config());
    }

    /// One tick, as [`crate::ChainTracker::update`] for 2-D objects.
    pub fn update<const K: usize, const P: usize>(
        &mut self,
        shell: &Shell<K, P>,
        hip: Vec3,
        period_s: f32,
        allow_switch: bool,
    ) -> Contact<Vec3> {
        let mut last = None;
        for _ in 0..MAX_SWITCHES {
            let s = shell.surface(self.patch);
            let tr = self.tracker.update(&s, hip, period_s);
            last = Some(tr);
            let at_boundary = tr.at_boundary.iter().any(|&b| b != 0);
            if !allow_switch
                || (self.sliding
                    && !at_boundary
                    && self.feature == Feature::Patch(self.patch as u16))
            {
                break;
            }
            let decision = match self.feature {
                Feature::Corner(c) => self.corner_decision(shell, usize::from(c), hip),
                _ => self.side_decision(shell, &s, &tr, hip),
            };
            match decision {
                Decision::Stay => break,
                Decision::Patch(j, t) => {
                    self.patch = j;
                    self.feature = Feature::Patch(j as u16);
                    self.tracker = shell.tracker_on(j, t, *self.tracker.config());
                }
                Decision::Edge(e) => {
                    if self.feature == Feature::Edge(e) {
                        break;
                    }
                    self.feature = Feature::Edge(e);
                }
                Decision::Corner(c) => {
                    if self.feature == Feature::Corner(c) {
                        break;
                    }
                    // Park the tracker on an incident patch corner.
                    let Some(&(p, k)) = shell
                        .corners()
                        .get(usize::from(c))
                        .and_then(|corner| corner.incident().first())
                    else {
                        break;
                    };
                    self.feature = Feature::Corner(c);
                    self.patch = usize::from(p);
                    let t = corner_param(&shell.surface(self.patch), usize::from(k));
                    self.tracker = shell.tracker_on(self.patch, t, *self.tracker.config());
                }
            }
        }
        let tr = match last {
            Some(tr) => tr,
            None => self
                .tracker
                .update(&shell.surface(self.patch), hip, period_s),
        };
        self.contact(shell, &tr, hip)
    }

    /// The side of patch `s` (the current one) nearest to the closest point, if near enough
    /// to matter.
    fn nearest_side(s: &Surface<'_>, t: [f32; 2]) -> Option<usize> {
        let [(u0, u1), (v0, v1)] = Patch::domain(s);
        let d = [
            (t[0] - u0) / (u1 - u0),
            (u1 - t[0]) / (u1 - u0),
            (t[1] - v0) / (v1 - v0),
            (v1 - t[1]) / (v1 - v0),
        ];
        let mut best = 0;
        for k in 1..4 {
            if d[k] < d[best] {
                best = k;
            }
        }
        (d[best] <= NEAR_SIDE).then_some(best)
    }

    /// Where the tracker goes from patch `sa_patch` (the current one, where `tr` left it).
    fn side_decision<const K: usize, const P: usize>(
        &self,
        shell: &Shell<K, P>,
        sa_patch: &Surface<'_>,
        tr: &Track<Vec3, 2>,
        hip: Vec3,
    ) -> Decision {
        let a = self.patch;
        // At a patch corner (both parameters clamped), hand over to the corner test.
        if tr.at_boundary[0] != 0 && tr.at_boundary[1] != 0 {
            let k = usize::from(tr.at_boundary[0] > 0) | (usize::from(tr.at_boundary[1] > 0) << 1);
            let c = shell.layout.corner_of.get(a).map_or(u16::MAX, |c| c[k & 3]);
            if c != u16::MAX {
                return match self.corner_decision(shell, usize::from(c), hip) {
                    Decision::Patch(j, _) if j == a => Decision::Stay,
                    d => d,
                };
            }
        }
        let stay = || {
            if matches!(self.feature, Feature::Edge(_)) {
                Decision::Patch(a, tr.t)
            } else {
                Decision::Stay
            }
        };
        let Some(side) = Self::nearest_side(sa_patch, tr.t) else {
            return stay();
        };
        let w = side_position(sa_patch, side, tr.t);
        let ta = side_param(sa_patch, side, w);
        let (e_pt, n_a, m_a, _) = side_frame(sa_patch, side, ta);
        let r = hip - e_pt;
        let on_a = r.dot(m_a) >= 0.0;
        match shell.sides(a).get(side).copied().unwrap_or(Side::Collapsed) {
            Side::Collapsed | Side::Periodic => stay(),
            Side::Open(e) => {
                if on_a {
                    stay()
                } else {
                    Decision::Edge(e)
                }
            }
            Side::Shared(e) => {
                let Some(edge) = shell.edges().get(usize::from(e)) else {
                    return stay();
                };
                let (b, sb) = if usize::from(edge.a.0) == a && usize::from(edge.a.1) == side {
                    match edge.b {
                        Some(x) => x,
                        None => return stay(),
                    }
                } else {
                    edge.a
                };
                let sb_patch = &shell.surface(usize::from(b));
                let wb = if edge.reversed { 1.0 - w } else { w };
                let tb = side_param(sb_patch, usize::from(sb), wb);
                let (_, n_b, m_b, _) = side_frame(sb_patch, usize::from(sb), tb);
                let on_b = r.dot(m_b) >= 0.0;
                let bend = n_a.dot(m_b);
                let smooth = bend.abs() <= 1e-4 && n_a.dot(n_b) > 0.0;
                match (on_a, on_b) {
                    (true, false) => stay(),
                    (false, true) => Decision::Patch(usize::from(b), tb),
                    (false, false) => {
                        if smooth {
                            Decision::Patch(usize::from(b), tb)
                        } else {
                            Decision::Edge(e)
                        }
                    }
                    (true, true) => {
                        let toward_a = r.dot(n_a - n_b);
                        let a_closer = if smooth {
                            true
                        } else if bend < 0.0 {
                            toward_a > 0.0
                        } else {
                            toward_a < 0.0
                        };
                        if a_closer {
                            stay()
                        } else {
                            Decision::Patch(usize::from(b), tb)
                        }
                    }
                }
            }
        }
    }

    fn corner_decision<const K: usize, const P: usize>(
        &self,
        shell: &Shell<K, P>,
        c: usize,
        hip: Vec3,
    ) -> Decision {
        let Some(corner) = shell.corners().get(c) else {
            return Decision::Stay;
        };
        let r = hip - corner.position;
        // A patch whose corner quadrant the HIP projects into.
        for &(p, k) in corner.incident() {
            let s = shell.surface(usize::from(p));
            let t = corner_param(&s, usize::from(k));
            let jet = s.jet(t, 1);
            let du = if k & 1 == 1 { -jet.d[0] } else { jet.d[0] };
            let dv = if k & 2 == 2 { -jet.d[1] } else { jet.d[1] };
            if r.dot(du) >= 0.0 && r.dot(dv) >= 0.0 {
                // Step slightly into the patch so the tracker starts off the corner.
                return Decision::Patch(usize::from(p), t);
            }
        }
        // An edge the HIP projects onto.
        for &(p, k) in corner.incident() {
            let s = shell.surface(usize::from(p));
            let t = corner_param(&s, usize::from(k));
            let jet = s.jet(t, 1);
            for (side, d) in [
                (
                    if k & 1 == 1 { 1 } else { 0 },
                    if k & 2 == 2 { -jet.d[1] } else { jet.d[1] },
                ),
                (
                    if k & 2 == 2 { 3 } else { 2 },
                    if k & 1 == 1 { -jet.d[0] } else { jet.d[0] },
                ),
            ] {
                if r.dot(d) > 0.0 {
                    match shell.sides(usize::from(p))[side] {
                        Side::Shared(e) | Side::Open(e) => return Decision::Edge(e),
                        _ => {}
                    }
                }
            }
        }
        Decision::Corner(c as u16)
    }

    fn contact<const K: usize, const P: usize>(
        &self,
        shell: &Shell<K, P>,
        tr: &Track<Vec3, 2>,
        hip: Vec3,
    ) -> Contact<Vec3> {
        let patch_contact = || Contact {
            feature: self.feature,
            patch: self.patch as u16,
            params: tr.t,
            point: tr.point,
            normal: tr.normal,
            depth: -tr.signed_distance,
            psi: tr.psi,
            inside: tr.signed_distance < 0.0,
        };
        match self.feature {
            Feature::Patch(_) => patch_contact(),
            Feature::Edge(_) | Feature::Corner(_) => {
                let point = match self.feature {
                    Feature::Corner(c) => shell
                        .corners()
                        .get(usize::from(c))
                        .map_or(tr.point, |c| c.position),
                    _ => tr.point,
                };
                let r = hip - point;
                // Inside a reflex edge the HIP is behind the patch normal.
                let inside = r.dot(tr.normal) < 0.0;
                let dist = nurbs::math::sqrt(r.length_squared());
                let dir = Point::try_normalize(r).unwrap_or(tr.normal);
                let (normal, depth) = if inside { (-dir, dist) } else { (dir, -dist) };
                Contact {
                    feature: self.feature,
                    patch: self.patch as u16,
                    params: tr.t,
                    point,
                    normal,
                    depth,
                    psi: tr.psi,
                    inside,
                }
            }
            Feature::Vertex(_) => patch_contact(),
        }
    }
}
