//! 2-D objects: chains of planar NURBS curves meeting at vertices, their Voronoi regions, and
//! the feature state machine that keeps one tracker on the right feature (thesis §2.1.4,
//! Fig. 2.1.4–2.1.5).
//!
//! # Regions
//!
//! At vertex `V` between curve `a` (ending there with unit tangent `t_in`, outward normal
//! `n_in`) and curve `b` (starting there with `t_out`, `n_out`), with `r = x − V`:
//!
//! - `x` projects onto `a` near `V` iff `r·t_in ≤ 0`, onto `b` iff `r·t_out ≥ 0`: the region
//!   boundaries are the normal lines at the end points, as in the thesis.
//! - Where only one holds, that curve's region. Where neither holds, the vertex's own wedge:
//!   external for a convex vertex (before contact), internal for a reflex one (after contact).
//! - Where both hold, the two regions overlap (inside a convex vertex, outside a reflex one)
//!   and the bisector of the tangent lines, `r·(n_in − n_out) = 0`, splits them: the internal
//!   Voronoi boundary of a convex corner and the external one of a reflex corner.
//!
//! A smooth (G¹) vertex has no wedge and no bisector; the normal line alone splits `a` from
//! `b`, so the contact normal, and with it the force, is continuous across it.
//!
//! The state machine only moves between neighbours (curve ↔ its end vertices ↔ next curve),
//! so a HIP pushed deep into a thin object never pops through to the far side.
//!
//! # Corners inside a curve
//!
//! A curve with an interior knot of full multiplicity (at least its degree; every interior
//! knot of a polyline) is only C⁰ there, and generally has a corner. The chain splits such a
//! curve at load where its one-sided tangents differ (windows onto the same data, no copy,
//! see `nurbs::Curve::c0_pieces`), so the corner is a vertex like any other, with its regions
//! and its place in the state machine; tangent-continuous joins such as the quarter points of
//! a rational circle stay inside one curve. Curve indices of the chain (features, contacts) count
//! these pieces; [`Chain::source_curve`] maps them back to the curves given.

use crate::contact::{Contact, Feature};
use crate::global::{GlobalConfig, closest_point};
use crate::patch::{Jet, Patch};
use crate::track::{PERIODIC_TOL, Tracker, TrackerConfig};
use nurbs::{Curve, Knots, Point, Vec2, Vec3};

/// Largest number of curves in a chain (fixed storage, no allocation).
pub const MAX_CHAIN_CURVES: usize = 32;

/// Consecutive curves must meet within this distance (metres).
pub const JOIN_TOL_M: f32 = 1e-5;

/// Why a chain was rejected.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ChainError {
    /// No curves.
    Empty,
    /// More than [`MAX_CHAIN_CURVES`] curves.
    TooManyCurves {
        /// Given count.
        count: usize,
    },
    /// More than [`MAX_CHAIN_CURVES`] pieces once the curves are split at their corners
    /// (interior knots of full multiplicity where they turn).
    TooManyPieces {
        /// Given count of curves.
        count: usize,
        /// Count of pieces.
        pieces: usize,
    },
    /// Curve `curve` does not start where curve `curve − 1` ends.
    Gap {
        /// Index of the curve whose start is off.
        curve: usize,
        /// Distance between the end and the start (metres).
        gap_m: f32,
    },
    /// A closed chain runs clockwise, so its normals `t × k̂` would point inward.
    Clockwise,
    /// The curves' knots or control points do not fit the chain's fixed storage.
    Capacity {
        /// Knots of all the curves together.
        knots: usize,
        /// Control points of all the curves together.
        points: usize,
        /// Knots the chain holds.
        knot_capacity: usize,
        /// Control points the chain holds.
        point_capacity: usize,
    },
}

impl core::fmt::Display for ChainError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            ChainError::Empty => write!(f, "patches: an object needs at least one curve"),
            ChainError::TooManyCurves { count } => write!(
                f,
                "patches: {count} curves, at most {MAX_CHAIN_CURVES} per object"
            ),
            ChainError::TooManyPieces { count, pieces } => write!(
                f,
                "patches: split at their corners (interior knots of full multiplicity), the {count} curve(s) make {pieces} curves, at most {MAX_CHAIN_CURVES} per object"
            ),
            ChainError::Gap { curve, gap_m } => write!(
                f,
                "patches[{curve}]: starts {gap_m} m away from where patch {} ends (curves of an object must join end to start, within {JOIN_TOL_M} m)",
                curve.wrapping_sub(1)
            ),
            ChainError::Clockwise => write!(
                f,
                "patches: the closed chain runs clockwise, so its normals point inward; reverse the order of the curves and of their points"
            ),
            ChainError::Capacity {
                knots,
                points,
                knot_capacity,
                point_capacity,
            } => write!(
                f,
                "patches: {knots} knots and {points} control points in all, at most {knot_capacity} and {point_capacity} per object"
            ),
        }
    }
}

impl core::error::Error for ChainError {}

/// How two curves meet at a vertex.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VertexKind {
    /// Tangent-continuous join: no vertex region.
    Smooth,
    /// Outer corner (turning counter-clockwise): an external vertex region.
    Convex,
    /// Inner corner (turning clockwise): an internal vertex region.
    Reflex,
    /// The free end of an open chain.
    End,
}

/// A vertex and the data of its Voronoi regions, computed once at load.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vertex {
    /// Position.
    pub position: Vec2,
    /// Curve ending here, if any.
    pub incoming: Option<u16>,
    /// Curve starting here, if any.
    pub outgoing: Option<u16>,
    /// Unit tangent of the incoming curve at its end.
    pub t_in: Vec2,
    /// Unit tangent of the outgoing curve at its start.
    pub t_out: Vec2,
    /// Kind of join.
    pub kind: VertexKind,
}

impl Vertex {
    fn n_in(&self) -> Vec2 {
        Vec2::new(self.t_in.y, -self.t_in.x)
    }
    fn n_out(&self) -> Vec2 {
        Vec2::new(self.t_out.y, -self.t_out.x)
    }

    /// The region of `x` among {incoming curve, vertex, outgoing curve} (see the module docs).
    pub fn region(&self, index: u16, x: Vec2) -> Feature {
        let r = x - self.position;
        let vertex = Feature::Vertex(index);
        match (self.incoming, self.outgoing) {
            (Some(a), Some(b)) => {
                let on_a = r.dot(self.t_in) <= 0.0;
                let on_b = r.dot(self.t_out) >= 0.0;
                match (on_a, on_b) {
                    (true, false) => Feature::Patch(a),
                    (false, true) => Feature::Patch(b),
                    (false, false) => match self.kind {
                        // No wedge at a smooth join: split along the shared normal line.
                        VertexKind::Smooth => Feature::Patch(b),
                        _ => vertex,
                    },
                    (true, true) => {
                        let toward_a = r.dot(self.n_in() - self.n_out());
                        let a_closer = match self.kind {
                            VertexKind::Convex => toward_a > 0.0,
                            VertexKind::Reflex => toward_a < 0.0,
                            VertexKind::Smooth | VertexKind::End => true,
                        };
                        if a_closer {
                            Feature::Patch(a)
                        } else {
                            Feature::Patch(b)
                        }
                    }
                }
            }
            (Some(a), None) => {
                if r.dot(self.t_in) <= 0.0 {
                    Feature::Patch(a)
                } else {
                    vertex
                }
            }
            (None, Some(b)) => {
                if r.dot(self.t_out) >= 0.0 {
                    Feature::Patch(b)
                } else {
                    vertex
                }
            }
            (None, None) => vertex,
        }
    }
}

/// Knot capacity of a [`Chain`] by default: the protocol's per-scene limit, so any object a
/// device takes fits.
pub const CHAIN_KNOTS: usize = 512;

/// Control-point capacity of a [`Chain`] by default (as [`CHAIN_KNOTS`]).
pub const CHAIN_POINTS: usize = 512;

/// Where one piece of a [`Chain`] lives in the chain's own storage: its curve's knots and
/// homogeneous control points (ranges of [`Chain`]'s arrays), and the piece's window onto those
/// knots ([`nurbs::Knots::bounds`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Piece {
    degree: u8,
    knots: (u16, u16),
    points: (u16, u16),
    window: (u16, u16),
}

impl Piece {
    const EMPTY: Piece = Piece {
        degree: 0,
        knots: (0, 0),
        points: (0, 0),
        window: (0, 0),
    };
}

/// A vertex slot no vertex fills yet.
const BLANK_VERTEX: Vertex = Vertex {
    position: Vec2::ZERO,
    incoming: None,
    outgoing: None,
    t_in: Vec2::X,
    t_out: Vec2::X,
    kind: VertexKind::End,
};

/// A vertex slot of [`Chain::EMPTY`]: all zero bits (as every field of it), so that a board's
/// static chain is zero-initialised (`.bss`, no flash image). No vertex is read past a
/// chain's vertex count.
const ZERO_VERTEX: Vertex = Vertex {
    position: Vec2::ZERO,
    incoming: None,
    outgoing: None,
    t_in: Vec2::ZERO,
    t_out: Vec2::ZERO,
    kind: VertexKind::Smooth,
};

/// A jet slot no curve end fills yet.
const ZERO_JET: Jet<Vec2, 1> = Jet {
    point: Vec2::ZERO,
    d: [Vec2::ZERO],
    dd: [[Vec2::ZERO]],
};

/// A validated chain of planar curves, oriented so that `n = t × k̂` points out of the object
/// (counter-clockwise when closed), with its vertex regions.
///
/// The chain owns its data: the curves' knots and control points are copied into
/// fixed-capacity arrays (`KNOTS` knots and `POINTS` control points for all its curves
/// together; no allocation, no borrow), and every piece is a window onto them, made into a
/// [`Curve`] view when it is evaluated ([`Chain::curve`]). So whoever holds a chain (a
/// controller, a loop thread, a board's tick) holds its scene, with nothing borrowed to keep
/// alive. A board gives it capacities its RAM affords; the defaults ([`CHAIN_KNOTS`],
/// [`CHAIN_POINTS`]) take any object of a scene the protocol carries.
#[derive(Clone, Copy, Debug)]
pub struct Chain<const KNOTS: usize = CHAIN_KNOTS, const POINTS: usize = CHAIN_POINTS> {
    /// The given curves' knot vectors, one after the other.
    knots: [f32; KNOTS],
    /// The given curves' homogeneous control points, one after the other.
    points: [Vec3; POINTS],
    /// The curves split at their corners (full-multiplicity interior knots), as windows.
    pieces: [Piece; MAX_CHAIN_CURVES],
    n_curves: usize,
    /// Index of the given curve each piece comes from.
    source: [u16; MAX_CHAIN_CURVES],
    /// Whether each curve closes on itself (a tracker wraps there), found once at load.
    periodic: [bool; MAX_CHAIN_CURVES],
    closed: bool,
    vertices: [Vertex; MAX_CHAIN_CURVES + 1],
    n_vertices: usize,
    /// Each curve's jet (order 2) at the start and the end of its domain: a tracker that
    /// switches onto a curve across a vertex starts there, and the jet is the dearest part of
    /// starting it.
    end_jets: [[Jet<Vec2, 1>; 2]; MAX_CHAIN_CURVES],
}

impl Chain {
    /// The chain of `given` at the default capacities ([`Chain::from_curves`]).
    pub fn new(given: &[Curve<'_, Vec2>]) -> Result<Self, ChainError> {
        Self::from_curves(given)
    }
}

impl<const KNOTS: usize, const POINTS: usize> Chain<KNOTS, POINTS> {
    /// Copies the curves' data into the chain, splits the curves at their corners (interior
    /// knots of full multiplicity), checks that consecutive curves join, detects whether the
    /// chain closes, checks the orientation of closed chains and computes the vertex regions.
    pub fn from_curves(given: &[Curve<'_, Vec2>]) -> Result<Self, ChainError> {
        let mut chain = Self::EMPTY;
        chain.rebuild(given)?;
        Ok(chain)
    }

    /// A chain of no curves, all of its storage zero: what a board's static chain slot starts
    /// as, to be [rebuilt](Chain::rebuild) in place. No object is made of it (every chain
    /// constructor refuses no curves, [`ChainError::Empty`]).
    pub const EMPTY: Self = Chain {
        knots: [0.0; KNOTS],
        points: [Vec3::ZERO; POINTS],
        pieces: [Piece::EMPTY; MAX_CHAIN_CURVES],
        n_curves: 0,
        source: [0; MAX_CHAIN_CURVES],
        periodic: [false; MAX_CHAIN_CURVES],
        closed: false,
        vertices: [ZERO_VERTEX; MAX_CHAIN_CURVES + 1],
        n_vertices: 0,
        end_jets: [[ZERO_JET; 2]; MAX_CHAIN_CURVES],
    };

    /// [`Chain::from_curves`] in place: this chain becomes the chain of `given`, its storage
    /// reused (no chain is built anywhere else: for a device whose stacks cannot hold one).
    /// On error the chain is left with no curves ([`Chain::curve_count`] 0) and must not be
    /// rendered until rebuilt.
    pub fn rebuild(&mut self, given: &[Curve<'_, Vec2>]) -> Result<(), ChainError> {
        let result = self.rebuild_from(given);
        if result.is_err() {
            self.n_curves = 0;
            self.n_vertices = 0;
            self.closed = false;
        }
        result
    }

    /// Whether there are curves, not too many, and their knots and control points fit this
    /// chain's capacities (the first checks, in the order [`Chain::from_curves`] reports them).
    fn check_capacity(given: &[Curve<'_, Vec2>]) -> Result<(), ChainError> {
        if given.is_empty() {
            return Err(ChainError::Empty);
        }
        if given.len() > MAX_CHAIN_CURVES {
            return Err(ChainError::TooManyCurves { count: given.len() });
        }
        let (n_knots, n_points) = given.iter().fold((0, 0), |(k, p), c| {
            (k + c.knots().as_slice().len(), p + c.points().len())
        });
        if n_knots > KNOTS || n_points > POINTS || n_knots > usize::from(u16::MAX) {
            return Err(ChainError::Capacity {
                knots: n_knots,
                points: n_points,
                knot_capacity: KNOTS,
                point_capacity: POINTS,
            });
        }
        Ok(())
    }

    fn rebuild_from(&mut self, given: &[Curve<'_, Vec2>]) -> Result<(), ChainError> {
        self.n_curves = 0;
        self.n_vertices = 0;
        self.closed = false;
        let chain = self;
        Self::check_capacity(given)?;
        let pieces = Pieces::of(given)?;
        // Each given curve's data, one after the other; where each curve's starts.
        let mut offsets = [(0u16, 0u16, 0u16, 0u16); MAX_CHAIN_CURVES];
        let (mut k0, mut p0) = (0, 0);
        for (c, at) in given.iter().zip(offsets.iter_mut()) {
            let (knots, points) = (c.knots().as_slice(), c.points());
            let (k1, p1) = (k0 + knots.len(), p0 + points.len());
            chain.knots[k0..k1].copy_from_slice(knots);
            chain.points[p0..p1].copy_from_slice(points);
            *at = (k0 as u16, k1 as u16, p0 as u16, p1 as u16);
            (k0, p0) = (k1, p1);
        }
        let n = pieces.n;
        for ((slot, source), (piece, &from)) in chain
            .pieces
            .iter_mut()
            .zip(chain.source.iter_mut())
            .zip(pieces.curves().zip(pieces.source.iter()))
        {
            let (first, last) = piece.knots().bounds();
            let (k0, k1, p0, p1) = offsets[usize::from(from).min(MAX_CHAIN_CURVES - 1)];
            *slot = Piece {
                degree: piece.degree() as u8,
                knots: (k0, k1),
                points: (p0, p1),
                window: (first as u16, last as u16),
            };
            *source = from;
        }
        chain.n_curves = n;
        let closed = pieces.closed;
        chain.closed = closed;
        let start = |c: &Curve<'_, Vec2>| c.point(c.domain().0);
        let end = |c: &Curve<'_, Vec2>| c.point(c.domain().1);
        chain.n_vertices = if closed { n } else { n + 1 };
        for i in 0..n {
            let c = chain.curve(i);
            let (a, b) = c.domain();
            let (periodic, jets) = (c.is_closed(PERIODIC_TOL), [c.jet([a], 2), c.jet([b], 2)]);
            chain.periodic[i] = periodic;
            chain.end_jets[i] = jets;
        }
        let this = &*chain;
        let tangent = |i: usize, at_end: bool| {
            let c = this.curve(i);
            let (a, b) = c.domain();
            c.frame(if at_end { b } else { a }).tangent
        };
        let point = |i: usize, at_end: bool| {
            let c = this.curve(i);
            if at_end { end(&c) } else { start(&c) }
        };
        let mut vertices = [BLANK_VERTEX; MAX_CHAIN_CURVES + 1];
        for (k, v) in vertices.iter_mut().enumerate().take(chain.n_vertices) {
            *v = vertex(k, n, closed, tangent, point);
        }
        chain.vertices = vertices;
        Ok(())
    }

    /// Piece `i` of the chain (the last one past the end): a view onto the chain's data.
    #[inline]
    pub fn curve(&self, i: usize) -> Curve<'_, Vec2> {
        let p = &self.pieces[i.min(self.n_curves.max(1) - 1)];
        let knots = &self.knots[usize::from(p.knots.0)..usize::from(p.knots.1)];
        let points = &self.points[usize::from(p.points.0)..usize::from(p.points.1)];
        let window = (usize::from(p.window.0), usize::from(p.window.1));
        Curve::from_knots_unchecked(
            Knots::window_unchecked(knots, usize::from(p.degree), window),
            points,
        )
    }

    /// The curves, split at their corners (see the module docs), in order.
    pub fn curves(&self) -> impl ExactSizeIterator<Item = Curve<'_, Vec2>> + '_ {
        (0..self.n_curves).map(|i| self.curve(i))
    }

    /// Number of curves (pieces) of the chain.
    pub fn curve_count(&self) -> usize {
        self.n_curves
    }

    /// Index of the curve given to [`Chain::new`] that curve `i` of the chain is a piece of.
    pub fn source_curve(&self, i: usize) -> usize {
        usize::from(self.source[i.min(MAX_CHAIN_CURVES - 1)])
    }

    /// A tracker on curve `i` at `u`, with the curve's closedness known from load.
    fn tracker_on(&self, i: usize, u: f32, cfg: TrackerConfig) -> Tracker<Vec2, 1> {
        let c = &self.curve(i);
        let (a, b) = c.domain();
        let topology = ([self.periodic[i]], [[false; 2]]);
        match self.end_jets.get(i) {
            Some(jets) if u == a => Tracker::with_jet(c, [a], jets[0], cfg, topology.0, topology.1),
            Some(jets) if u == b => Tracker::with_jet(c, [b], jets[1], cfg, topology.0, topology.1),
            _ => Tracker::with_topology(c, [u], cfg, topology.0, topology.1),
        }
    }

    /// Whether the last curve ends where the first starts.
    pub fn is_closed(&self) -> bool {
        self.closed
    }

    /// The vertices: vertex `k` is the start of curve `k` (and, for an open chain, the last one
    /// is the end of the last curve).
    pub fn vertices(&self) -> &[Vertex] {
        &self.vertices[..self.n_vertices]
    }

    /// Index of the vertex at the start (`end = false`) or end of curve `i`.
    fn vertex_of(&self, i: usize, end: bool) -> Option<usize> {
        let k = if end { i + 1 } else { i };
        if k < self.n_vertices {
            Some(k)
        } else if self.closed {
            Some(k % self.n_vertices)
        } else {
            None
        }
    }

    /// What a [`ChainTracker`] state of this chain depends on besides the geometry: the pieces
    /// (how many, which curve each comes from, their parameter domains, which close on
    /// themselves), whether the chain closes, and the kind of each vertex. Two chains with
    /// equal topologies take each other's states: the same feature indices name the same
    /// curves and vertices, with the same Voronoi regions around them (a convex vertex stays
    /// convex). A chain whose control points moved a little keeps its topology; one whose
    /// corner turned smooth, or whose curve gained a corner, does not.
    pub fn topology(&self) -> ChainTopology {
        let n = self.n_curves;
        let mut domains = [(0.0, 0.0); MAX_CHAIN_CURVES];
        for (d, c) in domains.iter_mut().zip(self.curves()) {
            *d = c.domain();
        }
        let mut kinds = [VertexKind::End; MAX_CHAIN_CURVES + 1];
        for (k, v) in kinds.iter_mut().zip(self.vertices()) {
            *k = v.kind;
        }
        ChainTopology {
            pieces: n as u8,
            closed: self.closed,
            source: self.source,
            periodic: self.periodic,
            domains,
            kinds,
        }
    }

    /// Moves the chain onto `given`, the curves it was built from with their control points
    /// moved (same degrees, same knots), in place: what depends on the geometry is computed
    /// again as [`Chain::new`] computes it (the pieces, each curve's jets at its ends, the
    /// vertices' positions, tangents and kinds, whether each curve closes on itself), so the
    /// chain becomes the one `Chain::new(given)` builds. Refused (`false`, the chain
    /// unchanged) when that chain would not have this one's [`Chain::topology`] (other pieces
    /// or domains, a vertex of another kind, a curve or the chain closing or opening) or its
    /// curves would not join. A first pass checks all that from the new pieces' end jets,
    /// holding one piece's at a time; the second writes the chain (the first pass's jets kept
    /// for the first few pieces): two to four evaluations per curve where `Chain::new` makes a
    /// dozen, and no second chain, for a device that moves its object between two ticks. It
    /// does not check again the orientation of a closed chain (`Chain::new`'s
    /// [`ChainError::Clockwise`], a sampling of the whole chain): a move that turns a closed
    /// chain inside out is the caller's to refuse (a device validates every update with
    /// `Chain::new` before it gets here).
    pub fn reshape(&mut self, given: &[Curve<'_, Vec2>]) -> bool {
        /// Pieces whose end jets the first pass keeps for the second.
        const KEPT: usize = 4;
        let n = self.n_curves;
        if given.is_empty() || given.len() > MAX_CHAIN_CURVES {
            return false;
        }
        let zero = Jet {
            point: Vec2::ZERO,
            d: [Vec2::ZERO],
            dd: [[Vec2::ZERO]],
        };
        let ends = |c: &Curve<'_, Vec2>| {
            let (a, b) = c.domain();
            [c.jet([a], 2), c.jet([b], 2)]
        };
        // A jet's point and derivatives at an end are `Curve::derivs(u, 2)` there, which give
        // the `Curve::point` and `Curve::frame` that `Chain::new` computes.
        let tangent_of = |c: &Curve<'_, Vec2>, j: &Jet<Vec2, 1>, at_end: bool| {
            let (a, b) = c.domain();
            let d = nurbs::CurveDerivs {
                point: j.point,
                du: j.d[0],
                duu: j.dd[0][0],
            };
            c.tangent_from(if at_end { b } else { a }, &d)
        };
        // The kind of a vertex between two curves: vertex 1 of an open chain of the two.
        let kind = |t_in: Vec2, t_out: Vec2| {
            vertex(1, 2, false, |i, _| [t_in, t_out][i], |_, _| Vec2::ZERO).kind
        };
        // First pass: the new pieces, one at a time, against this chain.
        let mut kept = [[zero; 2]; KEPT];
        let mut count = 0;
        let mut fits = true;
        let mut first_start: Option<(Curve<'_, Vec2>, Jet<Vec2, 1>)> = None;
        let mut last_end: Option<(Curve<'_, Vec2>, Jet<Vec2, 1>)> = None;
        for (i, c) in given.iter().enumerate() {
            crate::split::curve_pieces(c, |piece| {
                let k = count;
                count += 1;
                // The same storage: a curve of the same degree, knot count and point count.
                let same_storage = |p: &Piece| {
                    usize::from(p.degree) == c.degree()
                        && usize::from(p.knots.1 - p.knots.0) == c.knots().as_slice().len()
                        && usize::from(p.points.1 - p.points.0) == c.points().len()
                };
                if !fits
                    || k >= n
                    || usize::from(self.source[k]) != i
                    || !same_storage(&self.pieces[k])
                    || piece.domain() != self.curve(k).domain()
                {
                    fits = false;
                    return;
                }
                let j = ends(&piece);
                let gap = (j[0].point - j[1].point).length_squared();
                fits &= (gap <= PERIODIC_TOL * PERIODIC_TOL) == self.periodic[k];
                if let Some((prev, end)) = &last_end {
                    fits &= (j[0].point - end.point).length() <= JOIN_TOL_M;
                    let t_in = tangent_of(prev, end, true);
                    let t_out = tangent_of(&piece, &j[0], false);
                    fits &= kind(t_in, t_out) == self.vertices[k].kind;
                }
                if let Some(slot) = kept.get_mut(k) {
                    *slot = j;
                }
                first_start.get_or_insert((piece, j[0]));
                last_end = Some((piece, j[1]));
            });
        }
        let (Some((c0, start)), Some((cn, end))) = (first_start, last_end) else {
            return false;
        };
        let closed = (start.point - end.point).length() <= JOIN_TOL_M;
        if !fits || count != n || closed != self.closed {
            return false;
        }
        if closed {
            let t_in = tangent_of(&cn, &end, true);
            let t_out = tangent_of(&c0, &start, false);
            if kind(t_in, t_out) != self.vertices[0].kind {
                return false;
            }
        }
        // Second pass: the chain, as `Chain::new` fills it: each curve's data copied over its
        // own (the first pass checked the sizes), the pieces' windows, their end jets.
        let mut k = 0;
        for c in given {
            let p = self.pieces[k.min(n - 1)];
            let (k0, k1) = (usize::from(p.knots.0), usize::from(p.knots.1));
            let (p0, p1) = (usize::from(p.points.0), usize::from(p.points.1));
            self.knots[k0..k1].copy_from_slice(c.knots().as_slice());
            self.points[p0..p1].copy_from_slice(c.points());
            crate::split::curve_pieces(c, |piece| {
                if let Some(slot) = self.pieces.get_mut(k) {
                    let (first, last) = piece.knots().bounds();
                    slot.window = (first as u16, last as u16);
                    self.end_jets[k] = kept.get(k).copied().unwrap_or_else(|| ends(&piece));
                }
                k += 1;
            });
        }
        // The pieces' unit tangents at their ends, then the vertices from them (no copy of
        // the vertices: a device does this between two ticks).
        let mut tangents = [[Vec2::X; 2]; MAX_CHAIN_CURVES];
        for (i, t) in tangents.iter_mut().enumerate().take(n) {
            let (c, jets) = (self.curve(i), &self.end_jets[i]);
            *t = [
                tangent_of(&c, &jets[0], false),
                tangent_of(&c, &jets[1], true),
            ];
        }
        let jets = &self.end_jets;
        let point = |i: usize, at_end: bool| jets[i][usize::from(at_end)].point;
        let tangent = |i: usize, at_end: bool| tangents[i][usize::from(at_end)];
        for (k, v) in self.vertices.iter_mut().enumerate().take(self.n_vertices) {
            *v = vertex(k, n, closed, tangent, point);
        }
        true
    }

    /// Whether this chain's topology is `t`: `self.topology() == *t` without building one
    /// (a caller short of stack compares in place).
    pub fn has_topology(&self, t: &ChainTopology) -> bool {
        let n = self.n_curves;
        let nv = self.n_vertices;
        usize::from(t.pieces) == n
            && t.closed == self.closed
            && t.source == self.source
            && t.periodic == self.periodic
            && t.domains[..n]
                .iter()
                .zip(self.curves())
                .all(|(d, c)| *d == c.domain())
            && t.domains[n..].iter().all(|d| *d == (0.0, 0.0))
            && t.kinds[..nv]
                .iter()
                .zip(self.vertices())
                .all(|(k, v)| *k == v.kind)
            && t.kinds[nv..].iter().all(|k| *k == VertexKind::End)
    }

    /// The curve closest to `x` and the parameter there: the global search on every curve
    /// (used to start tracking from nothing).
    pub fn nearest(&self, x: Vec2) -> (usize, f32) {
        let cfg = GlobalConfig::default();
        let mut best = (0, 0.0, f32::INFINITY);
        for (i, c) in self.curves().enumerate() {
            let r = closest_point(&c, x, &cfg);
            if r.distance_squared < best.2 {
                best = (i, r.t[0], r.distance_squared);
            }
        }
        (best.0, best.1)
    }
}

/// Vertex `k` of a chain of `n` curves, closed or not, from the curves' unit tangents and
/// points at their ends (`tangent(i, at_end)`, `point(i, at_end)`): the one computation of a
/// vertex, [`Chain::new`]'s and [`Chain::reshape`]'s.
fn vertex(
    k: usize,
    n: usize,
    closed: bool,
    tangent: impl Fn(usize, bool) -> Vec2,
    point: impl Fn(usize, bool) -> Vec2,
) -> Vertex {
    let incoming = if k > 0 {
        Some(k - 1)
    } else if closed {
        Some(n - 1)
    } else {
        None
    };
    let outgoing = if k < n { Some(k) } else { None };
    let t_in = incoming.map(|a| tangent(a, true));
    let t_out = outgoing.map(|b| tangent(b, false));
    let position = match outgoing {
        Some(b) => point(b, false),
        None => point(n - 1, true),
    };
    let kind = match (t_in, t_out) {
        (Some(ti), Some(to)) => {
            let cross = ti.perp_dot(to);
            if cross.abs() <= 1e-4 && ti.dot(to) > 0.0 {
                VertexKind::Smooth
            } else if cross > 0.0 {
                VertexKind::Convex
            } else {
                VertexKind::Reflex
            }
        }
        _ => VertexKind::End,
    };
    Vertex {
        position,
        incoming: incoming.map(|i| i as u16),
        outgoing: outgoing.map(|i| i as u16),
        t_in: t_in.or(t_out).unwrap_or(Vec2::X),
        t_out: t_out.or(t_in).unwrap_or(Vec2::X),
        kind,
    }
}

/// The topology of a [`Chain`] ([`Chain::topology`]): compare two with `==`. Holds no borrow.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChainTopology {
    pieces: u8,
    closed: bool,
    source: [u16; MAX_CHAIN_CURVES],
    periodic: [bool; MAX_CHAIN_CURVES],
    domains: [(f32, f32); MAX_CHAIN_CURVES],
    kinds: [VertexKind; MAX_CHAIN_CURVES + 1],
}

impl ChainTopology {
    /// Number of pieces (curves split at their corners).
    pub fn pieces(&self) -> usize {
        usize::from(self.pieces)
    }

    /// Whether the chain closes.
    pub fn is_closed(&self) -> bool {
        self.closed
    }

    /// The kinds of the vertices.
    pub fn vertex_kinds(&self) -> &[VertexKind] {
        let n = usize::from(self.pieces) + usize::from(!self.closed);
        &self.kinds[..n.min(MAX_CHAIN_CURVES + 1)]
    }
}

/// Signed area of a closed chain, from a sampled polygon (positive counter-clockwise).
/// A chain's pieces (the given curves split at their corners) as views of the given curves,
/// nothing copied, after the checks every chain passes (no curves or too many, pieces that
/// do not join, a closed chain turning clockwise): what building a chain
/// ([`Chain::rebuild`]) and checking one ([`Chain::check`], [`Chain::topology_of`]) share.
struct Pieces<'c> {
    views: [Curve<'c, Vec2>; MAX_CHAIN_CURVES],
    source: [u16; MAX_CHAIN_CURVES],
    n: usize,
    closed: bool,
}

impl<'c> Pieces<'c> {
    fn of(given: &[Curve<'c, Vec2>]) -> Result<Self, ChainError> {
        let Some(&first) = given.first() else {
            return Err(ChainError::Empty);
        };
        if given.len() > MAX_CHAIN_CURVES {
            return Err(ChainError::TooManyCurves { count: given.len() });
        }
        let mut pieces = Pieces {
            views: [first; MAX_CHAIN_CURVES],
            source: [0; MAX_CHAIN_CURVES],
            n: 0,
            closed: false,
        };
        for (i, c) in given.iter().enumerate() {
            crate::split::curve_pieces(c, |piece| {
                if let Some(view) = pieces.views.get_mut(pieces.n) {
                    *view = piece;
                    pieces.source[pieces.n] = i as u16;
                }
                pieces.n += 1;
            });
        }
        let n = pieces.n;
        if n > MAX_CHAIN_CURVES {
            return Err(ChainError::TooManyPieces {
                count: given.len(),
                pieces: n,
            });
        }
        let start = |c: &Curve<'_, Vec2>| c.point(c.domain().0);
        let end = |c: &Curve<'_, Vec2>| c.point(c.domain().1);
        for (i, pair) in pieces.views[..n].windows(2).enumerate() {
            let gap = (start(&pair[1]) - end(&pair[0])).length();
            if gap > JOIN_TOL_M {
                return Err(ChainError::Gap {
                    curve: usize::from(pieces.source[i + 1]),
                    gap_m: gap,
                });
            }
        }
        let closed = (start(&pieces.views[0]) - end(&pieces.views[n - 1])).length() <= JOIN_TOL_M;
        if closed && signed_area(pieces.curves()) < 0.0 {
            return Err(ChainError::Clockwise);
        }
        pieces.closed = closed;
        Ok(pieces)
    }

    fn curves(&self) -> impl Iterator<Item = Curve<'c, Vec2>> + '_ {
        self.views[..self.n].iter().copied()
    }
}

impl<const KNOTS: usize, const POINTS: usize> Chain<KNOTS, POINTS> {
    /// Whether `given` makes a chain of these capacities (`Ok`), or the error
    /// [`Chain::from_curves`] would give, without building it (the curves are read in place:
    /// for a device's link, which validates a scene on a small stack).
    pub fn check(given: &[Curve<'_, Vec2>]) -> Result<(), ChainError> {
        Self::topology_of(given).map(drop)
    }

    /// The [`Chain::topology`] of the chain `given` makes, or the error
    /// [`Chain::from_curves`] would give, without building it.
    pub fn topology_of(given: &[Curve<'_, Vec2>]) -> Result<ChainTopology, ChainError> {
        Self::check_capacity(given)?;
        let pieces = Pieces::of(given)?;
        let (n, closed) = (pieces.n, pieces.closed);
        let mut topology = ChainTopology {
            pieces: n as u8,
            closed,
            source: pieces.source,
            periodic: [false; MAX_CHAIN_CURVES],
            domains: [(0.0, 0.0); MAX_CHAIN_CURVES],
            kinds: [VertexKind::End; MAX_CHAIN_CURVES + 1],
        };
        for ((c, periodic), domain) in pieces
            .curves()
            .zip(topology.periodic.iter_mut())
            .zip(topology.domains.iter_mut())
        {
            *periodic = c.is_closed(PERIODIC_TOL);
            *domain = c.domain();
        }
        let views = &pieces.views;
        let tangent = |i: usize, at_end: bool| {
            let c = &views[i.min(MAX_CHAIN_CURVES - 1)];
            let (a, b) = c.domain();
            c.frame(if at_end { b } else { a }).tangent
        };
        let point = |i: usize, at_end: bool| {
            let c = &views[i.min(MAX_CHAIN_CURVES - 1)];
            let (a, b) = c.domain();
            c.point(if at_end { b } else { a })
        };
        let n_vertices = if closed { n } else { n + 1 };
        for (k, kind) in topology.kinds.iter_mut().enumerate().take(n_vertices) {
            *kind = vertex(k, n, closed, tangent, point).kind;
        }
        Ok(topology)
    }
}

fn signed_area<'c>(curves: impl Iterator<Item = Curve<'c, Vec2>>) -> f32 {
    const SAMPLES: usize = 32;
    let mut area = 0.0;
    for c in curves {
        let (a, b) = c.domain();
        let mut prev = c.point(a);
        for s in 1..=SAMPLES {
            let p = c.point(a + (b - a) * s as f32 / SAMPLES as f32);
            area += prev.perp_dot(p);
            prev = p;
        }
    }
    0.5 * area
}

mod tracking;
pub use tracking::ChainTracker;
