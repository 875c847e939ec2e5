//! The per-tick tracking of a chain: the active feature, the tracker on the active curve and
//! the switches between curves and vertices (Voronoi regions, thesis §2.2).

use super::*;

/// The per-tick state of tracking one chain: the active feature and the tracker on the
/// active curve. Holds no borrow, so it can live in a `static`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChainTracker {
    feature: Feature,
    tracker: Tracker<Vec2, 1>,
    curve: usize,
    sliding: bool,
    /// A switch decided on the last tick, taken on this one (the feature across vertex `.1`).
    pending: Option<(Feature, u16)>,
}

/// Most feature switches in one tick (enough to cross a vertex into the next curve).
const MAX_SWITCHES: usize = 4;

impl ChainTracker {
    /// Starts on the curve nearest to `hip` (found by the global search).
    pub fn new<const K: usize, const P: usize>(
        chain: &Chain<K, P>,
        hip: Vec2,
        cfg: TrackerConfig,
    ) -> Self {
        let (i, u) = chain.nearest(hip);
        ChainTracker {
            feature: Feature::Patch(i as u16),
            tracker: chain.tracker_on(i, u, cfg),
            curve: i,
            sliding: false,
            pending: None,
        }
    }

    /// Active feature.
    pub fn feature(&self) -> Feature {
        self.feature
    }

    /// In sliding mode the tracked point moves over the object like a point on its surface:
    /// it changes curve only when it reaches a vertex (its parameter clamps at the end), never
    /// by jumping across a region boundary. That is how a god-object moves.
    pub fn set_sliding(&mut self, sliding: bool) {
        self.sliding = sliding;
        // A sliding point goes over only where it comes to its curve's end, never on a
        // region test's pending switch.
        if sliding {
            self.pending = None;
        }
    }

    /// The curve the tracker is on and its parameter.
    pub fn position(&self) -> (usize, f32) {
        (self.curve, self.tracker.t()[0])
    }

    /// The curve's jet at [`ChainTracker::position`] (the tracker's own evaluation).
    pub fn jet(&self) -> &crate::patch::Jet<Vec2, 1> {
        self.tracker.jet()
    }

    /// Re-evaluates the tracker on `chain` where it is, keeping the feature (see
    /// [`Tracker::refresh`]): `chain` is the one the state was made on with its control
    /// points moved ([`Chain::topology`] unchanged).
    pub fn refresh<const K: usize, const P: usize>(&mut self, chain: &Chain<K, P>) {
        let i = self.curve.min(chain.n_curves - 1);
        self.tracker.refresh(&chain.curve(i));
    }

    /// Puts the tracker on curve `i` at parameter `u` (e.g. to pin a god-object).
    pub fn reset<const K: usize, const P: usize>(&mut self, chain: &Chain<K, P>, i: usize, u: f32) {
        let i = i.min(chain.n_curves - 1);
        self.curve = i;
        self.feature = Feature::Patch(i as u16);
        self.tracker = chain.tracker_on(i, u, *self.tracker.config());
        self.pending = None;
    }

    /// One tick: track the closest point to `hip` and switch features as the HIP crosses
    /// region boundaries (unless `allow_switch` is false, as during static friction at a
    /// corner, when the tracker stays on its curve and clamps at its ends).
    pub fn update<const K: usize, const P: usize>(
        &mut self,
        chain: &Chain<K, P>,
        hip: Vec2,
        period_s: f32,
        allow_switch: bool,
    ) -> Contact<Vec2> {
        if let Some((next, k)) = self.pending.take() {
            // The switch decided on the last tick, if the HIP is still across the boundary:
            // onto the next curve at its end (the vertex), where the tracker stands this tick,
            // the contact from the curve's end jet (the chain's, no evaluation: the depth under
            // the new curve's tangent at the vertex, right to first order); it closes in on its
            // closest point from the next. So no tick evaluates two curves.
            let v = chain.vertices[usize::from(k).min(chain.n_vertices - 1)];
            if allow_switch && v.region(k, hip) == next {
                self.enter(chain, next, &v);
                if matches!(next, Feature::Patch(_)) {
                    return self.here(chain, hip);
                }
            }
        }
        for _ in 0..MAX_SWITCHES {
            match self.feature {
                Feature::Vertex(k) => {
                    let v = chain.vertices[k as usize];
                    let next = v.region(k, hip);
                    if next == self.feature || !allow_switch {
                        return vertex_contact(
                            &v,
                            self.feature,
                            self.curve,
                            self.tracker.t()[0],
                            hip,
                        );
                    }
                    self.enter(chain, next, &v);
                }
                _ => {
                    let c = &chain.curve(self.curve);
                    let tr = self.tracker.update(c, hip, period_s);
                    if allow_switch && (!self.sliding || tr.at_boundary[0] != 0) {
                        // The vertex at the end the closest point is nearer to (the region
                        // tests are local to a vertex: a far vertex's normal line can cross
                        // the whole object): its normal lines and, inside a corner, its
                        // bisector decide whether the HIP has left this curve's region.
                        let (a, b) = c.domain();
                        let near_end = tr.t[0] >= 0.5 * (a + b);
                        let mut switched = false;
                        for end in [near_end] {
                            if let Some(k) = chain.vertex_of(self.curve, end) {
                                let v = chain.vertices[k];
                                let next = v.region(k as u16, hip);
                                if next != Feature::Patch(self.curve as u16) {
                                    if !self.sliding
                                        && matches!(next, Feature::Patch(_))
                                        && v.kind != VertexKind::Smooth
                                    {
                                        // Across a corner to the next curve (the closest
                                        // point jumps there anyway): taken on the next tick,
                                        // this one having evaluated this curve already. Across
                                        // a smooth join the closest point moves on
                                        // continuously and the tracker follows at once.
                                        self.pending = Some((next, k as u16));
                                        break;
                                    }
                                    self.enter(chain, next, &v);
                                    switched = true;
                                    break;
                                }
                            }
                        }
                        if switched && self.sliding && matches!(self.feature, Feature::Patch(_)) {
                            // Sliding, the point has come to its curve's end and goes on from
                            // the same point of the next, standing there this tick (the end
                            // jet, no evaluation), as a point on the surface does.
                            return self.here(chain, hip);
                        }
                        if switched {
                            continue;
                        }
                    }
                    let inside = tr.signed_distance < 0.0;
                    return Contact {
                        feature: Feature::Patch(self.curve as u16),
                        patch: self.curve as u16,
                        params: [tr.t[0], 0.0],
                        point: tr.point,
                        normal: tr.normal,
                        depth: -tr.signed_distance,
                        psi: [tr.psi[0], 0.0],
                        inside,
                    };
                }
            }
        }
        // Out of switches this tick: report where we are without moving further.
        self.here(chain, hip)
    }

    /// The contact where the tracker stands, from its own jet there (no evaluation).
    fn here<const K: usize, const P: usize>(
        &self,
        chain: &Chain<K, P>,
        hip: Vec2,
    ) -> Contact<Vec2> {
        let c = &chain.curve(self.curve);
        let jet = self.tracker.jet();
        let n = c.normal(self.tracker.t(), jet);
        let depth = (jet.point - hip).dot(n);
        Contact {
            feature: self.feature,
            patch: self.curve as u16,
            params: [self.tracker.t()[0], 0.0],
            point: jet.point,
            normal: n,
            depth,
            psi: [jet.psi(jet.point - hip)[0], 0.0],
            inside: depth > 0.0,
        }
    }

    /// Switches to `next`, a neighbour across vertex `v`, initialising the tracker at the
    /// matching end of the new curve.
    fn enter<const K: usize, const P: usize>(
        &mut self,
        chain: &Chain<K, P>,
        next: Feature,
        v: &Vertex,
    ) {
        match next {
            Feature::Patch(i) => {
                let (a, b) = chain.curve(i as usize).domain();
                let u = if Some(i) == v.outgoing { a } else { b };
                self.curve = i as usize;
                self.tracker = chain.tracker_on(self.curve, u, *self.tracker.config());
            }
            Feature::Vertex(_) => {
                // Stay on the curve the vertex was reached from, parked at that end.
                let (i, u) = match v.incoming {
                    Some(a) if a as usize == self.curve => (a, chain.curve(a as usize).domain().1),
                    _ => match v.outgoing {
                        Some(b) => (b, chain.curve(b as usize).domain().0),
                        None => (self.curve as u16, self.tracker.t()[0]),
                    },
                };
                self.curve = i as usize;
                self.tracker = chain.tracker_on(self.curve, u, *self.tracker.config());
            }
            _ => {}
        }
        self.feature = next;
    }
}

/// Contact with a vertex: the closest point is the vertex itself and the normal runs along
/// `x − V`, outward (external wedge of a convex vertex) or inward (internal wedge of a reflex
/// one).
fn vertex_contact(v: &Vertex, feature: Feature, curve: usize, u: f32, hip: Vec2) -> Contact<Vec2> {
    let r = hip - v.position;
    let inside = v.kind == VertexKind::Reflex;
    let dist = nurbs::math::sqrt(r.length_squared());
    let dir = Point::try_normalize(r).unwrap_or((v.n_in() + v.n_out()).normalize_or(Vec2::Y));
    let (normal, depth) = if inside { (-dir, dist) } else { (dir, -dist) };
    Contact {
        feature,
        patch: curve as u16,
        params: [u, 0.0],
        point: v.position,
        normal,
        depth,
        psi: [0.0, 0.0],
        inside,
    }
}
