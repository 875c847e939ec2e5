//! 3-D objects: shells of NURBS surface patches meeting at edges and corners, their Voronoi
//! regions and the feature state machine (thesis §2.1.4 extended to surfaces).
//!
//! # Topology (computed once at load)
//!
//! Every side of every patch (`u = u₀`, `u = u₁`, `v = v₀`, `v = v₁`) is classified by sampling:
//! *collapsed* (a pole, e.g. of a sphere of revolution), *periodic* (it meets the opposite side
//! of the same patch: the tracker wraps there), *shared* with a side of another patch (an
//! edge, possibly with reversed direction), or *open* (the rim of an open shell). Patch
//! corners that coincide are merged into corners.
//!
//! # Regions
//!
//! At a point `E` of an edge shared by patches `a` and `b`, with outward normals `n_a`, `n_b`
//! and inward conormals `m_a`, `m_b` (tangent to the patch, orthogonal to the edge, pointing
//! into it), and `r = x − E`:
//!
//! - `x` projects into `a` iff `r·m_a ≥ 0` (the edge's normal plane of `a` is the region
//!   boundary, as the end-point normals are in 2-D), into `b` iff `r·m_b ≥ 0`;
//! - neither: the edge's own wedge, external for a convex edge (`n_a·m_b < 0`), internal for a
//!   reflex one;
//! - both: the bisector plane `r·(n_a − n_b) = 0` splits them (inside a convex edge, outside a
//!   reflex one); a smooth (G¹) edge has neither wedge nor bisector.
//!
//! At a corner `K`, `x` belongs to an incident patch when it projects into that patch's corner
//! quadrant (`r` has non-negative components along both inward side directions), to an
//! incident edge when it projects onto the edge (`r·d ≥ 0` along the edge direction from `K`)
//! but into neither of its patches, and to the corner otherwise.
//!
//! These tests use the tangent planes at the edge or corner, so they are exact for flat
//! patches and first-order accurate near the feature for curved ones, which is where they
//! decide anything: the state machine only tests the side nearest to the closest point, and
//! only moves between neighbours (patch ↔ edge ↔ corner ↔ patch), so a HIP pushed deep never
//! pops through to the far side of a thin object.
//!
//! Edge parameters are carried from one patch to the other by their relative position along
//! the side; for sides parametrised differently the tracker corrects the remaining offset in
//! its next updates.
//!
//! # Creases inside a patch
//!
//! A patch with an interior knot of full multiplicity (at least the degree in that direction;
//! every interior knot of a bilinear patch) is only C⁰ along that knot line, and generally has
//! a crease there. The shell splits such a patch at load along the lines where its one-sided
//! normals differ (windows onto the patch's data, which the shell copies once, see
//! `nurbs::Surface::c0_pieces`; tangent-continuous lines such as the quarter meridians of a
//! surface of revolution stay inside one patch), so each crease is an edge like any other,
//! found by the side matching above, with its regions and its place in the state machine.
//! Patch indices of the shell (features, contacts) count these pieces;
//! [`Shell::source_patch`] maps them back to the patches given.

use crate::contact::{Contact, Feature};
use crate::global::{GlobalConfig, closest_point};
use crate::patch::Patch;
use crate::track::{Track, Tracker, TrackerConfig};
use nurbs::{Knots, Point, Surface, Vec3, Vec4};

/// Largest number of patches in a shell (fixed storage, no allocation).
pub const MAX_SHELL_PATCHES: usize = 16;
/// Largest number of edges (shared or open sides).
pub const MAX_SHELL_EDGES: usize = 4 * MAX_SHELL_PATCHES;
/// Largest number of corners.
pub const MAX_SHELL_CORNERS: usize = 4 * MAX_SHELL_PATCHES;
/// Largest number of patch corners meeting at one corner.
pub const MAX_CORNER_VALENCE: usize = 8;
/// Sides and corners must meet within this distance (metres).
pub const SHELL_JOIN_TOL_M: f32 = 1e-5;

/// Why a shell was rejected.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ShellError {
    /// No patches.
    Empty,
    /// More than [`MAX_SHELL_PATCHES`] patches.
    TooManyPatches {
        /// Given count.
        count: usize,
    },
    /// More than [`MAX_SHELL_PATCHES`] pieces once the patches are split at their creases
    /// (interior knot lines of full multiplicity where they turn).
    TooManyPieces {
        /// Given count of patches.
        count: usize,
        /// Count of pieces.
        pieces: usize,
    },
    /// A side matches more than one other side.
    NonManifold {
        /// Patch index.
        patch: usize,
        /// Side index (0: u = u₀, 1: u = u₁, 2: v = v₀, 3: v = v₁).
        side: usize,
    },
    /// More than [`MAX_CORNER_VALENCE`] patch corners at one corner.
    CornerValence {
        /// Patch index of the corner that overflowed.
        patch: usize,
    },
    /// A closed shell whose normals point inward (negative enclosed volume).
    InwardNormals,
    /// The patches' knots or control points do not fit the shell's fixed storage.
    Capacity {
        /// Knots of all the patches together (u and v knot vectors).
        knots: usize,
        /// Control points of all the patches together.
        points: usize,
        /// Knots the shell holds.
        knot_capacity: usize,
        /// Control points the shell holds.
        point_capacity: usize,
    },
}

impl core::fmt::Display for ShellError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            ShellError::Empty => write!(f, "patches: an object needs at least one surface"),
            ShellError::TooManyPatches { count } => write!(
                f,
                "patches: {count} surfaces, at most {MAX_SHELL_PATCHES} per object"
            ),
            ShellError::TooManyPieces { count, pieces } => write!(
                f,
                "patches: split at their creases (interior knot lines of full multiplicity), the {count} surface(s) make {pieces} surfaces, at most {MAX_SHELL_PATCHES} per object"
            ),
            ShellError::NonManifold { patch, side } => write!(
                f,
                "patches[{patch}]: side {} is shared by more than two patches",
                SIDE_NAMES[side]
            ),
            ShellError::CornerValence { patch } => write!(
                f,
                "patches[{patch}]: more than {MAX_CORNER_VALENCE} patch corners meet at one of its corners"
            ),
            ShellError::InwardNormals => write!(
                f,
                "patches: the closed shell's normals S_u × S_v point inward; swap u and v (or reverse one direction) in every patch"
            ),
            ShellError::Capacity {
                knots,
                points,
                knot_capacity,
                point_capacity,
            } => write!(
                f,
                "patches: {knots} knots (u and v) and {points} control points in all, at most {knot_capacity} and {point_capacity} per object"
            ),
        }
    }
}

impl core::error::Error for ShellError {}

const SIDE_NAMES: [&str; 4] = ["u = u_min", "u = u_max", "v = v_min", "v = v_max"];

/// What lies across one side of a patch.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// Nothing: the rim of an open shell (an edge with one patch).
    Open(u16),
    /// The side collapses to a point (a pole).
    Collapsed,
    /// The side meets the opposite side of the same patch.
    Periodic,
    /// Edge `e`, shared with another patch.
    Shared(u16),
}

/// An edge: a side of patch `a`, and possibly the matching side of patch `b`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Edge {
    /// First patch and its side.
    pub a: (u16, u8),
    /// Second patch and its side (`None` on the rim of an open shell).
    pub b: Option<(u16, u8)>,
    /// Whether the two sides run in opposite directions.
    pub reversed: bool,
}

/// A corner where patch corners meet.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Corner {
    /// Position.
    pub position: Vec3,
    /// Incident patch corners: `(patch, corner)` with corner bits `(v_max << 1) | u_max`.
    incident: [(u16, u8); MAX_CORNER_VALENCE],
    n_incident: u8,
}

impl Corner {
    /// Incident patch corners `(patch, corner)`, corner = `(v_is_max << 1) | u_is_max`.
    pub fn incident(&self) -> &[(u16, u8)] {
        self.incident
            .get(..usize::from(self.n_incident))
            .unwrap_or(&[])
    }
}

/// Knot capacity of a [`Shell`] by default (the u and v knot vectors of all its patches
/// together): the protocol's per-scene limit, so any object a device takes fits.
pub const SHELL_KNOTS: usize = 512;

/// Control-point capacity of a [`Shell`] by default (as [`SHELL_KNOTS`]).
pub const SHELL_POINTS: usize = 512;

/// Where one piece of a [`Shell`] lives in the shell's own storage: its patch's u and v knot
/// vectors and homogeneous control net (ranges of [`Shell`]'s arrays; the net's size follows
/// from the knot vectors and the degrees), and the piece's windows onto those knots
/// ([`nurbs::Knots::bounds`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Piece {
    degree: (u8, u8),
    knots_u: (u16, u16),
    knots_v: (u16, u16),
    points: (u16, u16),
    window_u: (u16, u16),
    window_v: (u16, u16),
}

impl Piece {
    const EMPTY: Piece = Piece {
        degree: (0, 0),
        knots_u: (0, 0),
        knots_v: (0, 0),
        points: (0, 0),
        window_u: (0, 0),
        window_v: (0, 0),
    };
}

const BLANK_EDGE: Edge = Edge {
    a: (0, 0),
    b: None,
    reversed: false,
};

const BLANK_CORNER: Corner = Corner {
    position: Vec3::ZERO,
    incident: [(0, 0); MAX_CORNER_VALENCE],
    n_incident: 0,
};

/// What a shell's pieces make together, found once at load from their views: where each
/// piece comes from, what lies across each side, the edges and corners, whether the shell
/// closes. What building a shell ([`Shell::rebuild`]) and checking one ([`Shell::check`],
/// [`Shell::topology_of`]) share.
#[derive(Clone, Copy, Debug)]
struct Layout {
    n_patches: usize,
    /// Index of the given patch each piece comes from.
    source: [u16; MAX_SHELL_PATCHES],
    sides: [[Side; 4]; MAX_SHELL_PATCHES],
    edges: [Edge; MAX_SHELL_EDGES],
    n_edges: usize,
    corners: [Corner; MAX_SHELL_CORNERS],
    n_corners: usize,
    corner_of: [[u16; 4]; MAX_SHELL_PATCHES],
    closed: bool,
}

impl Layout {
    /// No pieces, every slot zero (as far as the compiler lays the enums out that way: a
    /// `Side::Open(0)` is a first variant of payload 0), so that an empty shell is made by
    /// zeroing rather than copied from a 4 KB constant in flash. [`Layout::find`] writes
    /// every slot it reads.
    const EMPTY: Layout = Layout {
        n_patches: 0,
        source: [0; MAX_SHELL_PATCHES],
        sides: [[Side::Open(0); 4]; MAX_SHELL_PATCHES],
        edges: [BLANK_EDGE; MAX_SHELL_EDGES],
        n_edges: 0,
        corners: [BLANK_CORNER; MAX_SHELL_CORNERS],
        n_corners: 0,
        corner_of: [[0; 4]; MAX_SHELL_PATCHES],
        closed: false,
    };

    /// No pieces (what a failed build leaves).
    fn clear(&mut self) {
        self.n_patches = 0;
        self.n_edges = 0;
        self.n_corners = 0;
        self.closed = false;
    }

    /// Classifies every side of `pieces`, finds edges and corners, and checks the orientation
    /// of a closed shell, in place (a failed one leaves it to be [cleared](Layout::clear)).
    /// Errors name patches by their index in the given patches.
    fn find(&mut self, pieces: &Pieces<'_>) -> Result<(), ShellError> {
        let n = pieces.n;
        let patches = pieces.views();
        let source = pieces.source;
        let src = |i: usize| usize::from(source[i]);
        self.clear();
        self.source = source;
        self.sides = [[Side::Collapsed; 4]; MAX_SHELL_PATCHES];
        self.edges = [BLANK_EDGE; MAX_SHELL_EDGES];
        let (sides, edges) = (&mut self.sides, &mut self.edges);
        let mut n_edges = 0;
        let mut assigned = [[false; 4]; MAX_SHELL_PATCHES];
        for i in 0..n {
            for s in 0..4 {
                if assigned[i][s] {
                    continue;
                }
                let pts = side_points(&patches[i], s);
                if pts.iter().all(|&p| within(p, pts[0])) {
                    sides[i][s] = Side::Collapsed;
                    assigned[i][s] = true;
                    continue;
                }
                let opposite = s ^ 1;
                let opp = side_points(&patches[i], opposite);
                if pts.iter().zip(opp.iter()).all(|(&p, &q)| within(p, q)) {
                    sides[i][s] = Side::Periodic;
                    sides[i][opposite] = Side::Periodic;
                    assigned[i][s] = true;
                    assigned[i][opposite] = true;
                    continue;
                }
                let mut found: Option<(usize, usize, bool)> = None;
                for j in (i + 1)..n {
                    for s2 in 0..4 {
                        let q = side_points(&patches[j], s2);
                        let fwd = pts.iter().zip(q.iter()).all(|(&p, &q)| within(p, q));
                        let rev = pts.iter().zip(q.iter().rev()).all(|(&p, &q)| within(p, q));
                        if fwd || rev {
                            if found.is_some() || assigned[j][s2] {
                                return Err(ShellError::NonManifold {
                                    patch: src(i),
                                    side: s,
                                });
                            }
                            found = Some((j, s2, !fwd));
                        }
                    }
                }
                let e = n_edges as u16;
                edges[n_edges] = Edge {
                    a: (i as u16, s as u8),
                    b: found.map(|(j, s2, _)| (j as u16, s2 as u8)),
                    reversed: found.is_some_and(|f| f.2),
                };
                n_edges += 1;
                assigned[i][s] = true;
                match found {
                    Some((j, s2, _)) => {
                        sides[i][s] = Side::Shared(e);
                        sides[j][s2] = Side::Shared(e);
                        assigned[j][s2] = true;
                    }
                    None => sides[i][s] = Side::Open(e),
                }
            }
        }
        // Corners: merge coincident patch corners.
        self.corners = [BLANK_CORNER; MAX_SHELL_CORNERS];
        self.corner_of = [[u16::MAX; 4]; MAX_SHELL_PATCHES];
        let (corners, corner_of) = (&mut self.corners, &mut self.corner_of);
        let mut n_corners = 0;
        for i in 0..n {
            for k in 0..4 {
                let t = corner_param(&patches[i], k);
                let p = patches[i].point(t[0], t[1]);
                let idx = match corners[..n_corners]
                    .iter()
                    .position(|c| within(c.position, p))
                {
                    Some(c) => c,
                    None => {
                        corners[n_corners].position = p;
                        n_corners += 1;
                        n_corners - 1
                    }
                };
                let c = &mut corners[idx];
                if c.n_incident as usize >= MAX_CORNER_VALENCE {
                    return Err(ShellError::CornerValence { patch: src(i) });
                }
                c.incident[c.n_incident as usize] = (i as u16, k as u8);
                c.n_incident += 1;
                corner_of[i][k] = idx as u16;
            }
        }
        let closed = self.sides[..n]
            .iter()
            .all(|s| s.iter().all(|x| !matches!(x, Side::Open(_))));
        if closed && enclosed_volume(patches) < 0.0 {
            return Err(ShellError::InwardNormals);
        }
        self.n_patches = n;
        self.n_edges = n_edges;
        self.n_corners = n_corners;
        self.closed = closed;
        Ok(())
    }

    /// The [`ShellTopology`] of these pieces, of parameter domains `domains` (in order).
    fn topology(&self, domains: impl Iterator<Item = [(f32, f32); 2]>) -> ShellTopology {
        let mut d = [[(0.0, 0.0); 2]; MAX_SHELL_PATCHES];
        for (d, domain) in d.iter_mut().zip(domains).take(self.n_patches) {
            *d = domain;
        }
        let mut corners = [([(0, 0); MAX_CORNER_VALENCE], 0); MAX_SHELL_CORNERS];
        for (c, corner) in corners.iter_mut().zip(&self.corners).take(self.n_corners) {
            *c = (corner.incident, corner.n_incident);
        }
        ShellTopology {
            pieces: self.n_patches as u8,
            closed: self.closed,
            source: self.source,
            domains: d,
            sides: self.sides,
            edges: self.edges,
            n_edges: self.n_edges as u8,
            corners,
            n_corners: self.n_corners as u8,
            corner_of: self.corner_of,
        }
    }
}

/// A shell's pieces (the given patches split at their creases) as views of the given
/// patches, nothing copied, after the counts every shell passes (no patches or too many, too
/// many pieces).
struct Pieces<'s> {
    views: [Surface<'s>; MAX_SHELL_PATCHES],
    source: [u16; MAX_SHELL_PATCHES],
    n: usize,
}

impl<'s> Pieces<'s> {
    fn of(given: &[Surface<'s>]) -> Result<Self, ShellError> {
        let Some(&first) = given.first() else {
            return Err(ShellError::Empty);
        };
        if given.len() > MAX_SHELL_PATCHES {
            return Err(ShellError::TooManyPatches { count: given.len() });
        }
        let mut pieces = Pieces {
            views: [first; MAX_SHELL_PATCHES],
            source: [0; MAX_SHELL_PATCHES],
            n: 0,
        };
        for (i, s) in given.iter().enumerate() {
            crate::split::surface_pieces::<{ 2 * MAX_SHELL_PATCHES }>(s, |piece| {
                if let (Some(view), Some(source)) = (
                    pieces.views.get_mut(pieces.n),
                    pieces.source.get_mut(pieces.n),
                ) {
                    *view = piece;
                    *source = i as u16;
                }
                pieces.n += 1;
            });
        }
        if pieces.n > MAX_SHELL_PATCHES {
            return Err(ShellError::TooManyPieces {
                count: given.len(),
                pieces: pieces.n,
            });
        }
        Ok(pieces)
    }

    fn views(&self) -> &[Surface<'s>] {
        &self.views[..self.n]
    }
}

/// A validated shell of surface patches with its topology.
///
/// The shell owns its data, as [`crate::Chain`] does: the patches' knot vectors and
/// homogeneous control nets are copied into fixed-capacity arrays (`KNOTS` knots, u and v
/// vectors of all its patches together, and `POINTS` control points; no allocation, no
/// borrow), and every piece is a pair of windows onto them, made into a [`Surface`] view when
/// it is evaluated ([`Shell::surface`]). So whoever holds a shell (a loop thread, a
/// deforming object's simulation, a board) holds its scene, with nothing borrowed to keep
/// alive. The defaults ([`SHELL_KNOTS`], [`SHELL_POINTS`]) take any object of a scene the
/// protocol carries.
#[derive(Clone, Copy, Debug)]
pub struct Shell<const KNOTS: usize = SHELL_KNOTS, const POINTS: usize = SHELL_POINTS> {
    /// The given patches' knot vectors, u then v, one patch after the other.
    knots: [f32; KNOTS],
    /// The given patches' homogeneous control nets, one after the other.
    points: [Vec4; POINTS],
    /// The patches split at their creases (full-multiplicity interior knot lines), as
    /// windows.
    pieces: [Piece; MAX_SHELL_PATCHES],
    layout: Layout,
}

/// Parameters of the point at relative position `w ∈ [0, 1]` along side `side` of `s`.
fn side_param(s: &Surface<'_>, side: usize, w: f32) -> [f32; 2] {
    let [(u0, u1), (v0, v1)] = Patch::domain(s);
    match side {
        0 => [u0, v0 + (v1 - v0) * w],
        1 => [u1, v0 + (v1 - v0) * w],
        2 => [u0 + (u1 - u0) * w, v0],
        _ => [u0 + (u1 - u0) * w, v1],
    }
}

/// Relative position along side `side` of the parameters `t`.
fn side_position(s: &Surface<'_>, side: usize, t: [f32; 2]) -> f32 {
    let [(u0, u1), (v0, v1)] = Patch::domain(s);
    let w = if side < 2 {
        (t[1] - v0) / (v1 - v0)
    } else {
        (t[0] - u0) / (u1 - u0)
    };
    w.clamp(0.0, 1.0)
}

/// Parameters of corner `k` (bits `(v_max << 1) | u_max`).
fn corner_param(s: &Surface<'_>, k: usize) -> [f32; 2] {
    let [(u0, u1), (v0, v1)] = Patch::domain(s);
    [
        if k & 1 == 1 { u1 } else { u0 },
        if k & 2 == 2 { v1 } else { v0 },
    ]
}

const SIDE_SAMPLES: usize = 5;

fn side_points(s: &Surface<'_>, side: usize) -> [Vec3; SIDE_SAMPLES] {
    let mut p = [Vec3::ZERO; SIDE_SAMPLES];
    for (k, q) in p.iter_mut().enumerate() {
        let t = side_param(s, side, k as f32 / (SIDE_SAMPLES - 1) as f32);
        *q = s.point(t[0], t[1]);
    }
    p
}

fn within(a: Vec3, b: Vec3) -> bool {
    (a - b).length_squared() <= SHELL_JOIN_TOL_M * SHELL_JOIN_TOL_M
}

/// Volume enclosed by `patches`, `⅓ ∮ x·n dA` by the midpoint rule on a 24×24 grid per
/// patch: positive when the normals point outward.
fn enclosed_volume(patches: &[Surface<'_>]) -> f32 {
    const G: usize = 24;
    let mut vol = 0.0;
    for s in patches {
        let [(u0, u1), (v0, v1)] = Patch::domain(s);
        let (du, dv) = ((u1 - u0) / G as f32, (v1 - v0) / G as f32);
        for i in 0..G {
            for j in 0..G {
                let d = s.derivs(u0 + (i as f32 + 0.5) * du, v0 + (j as f32 + 0.5) * dv, 1);
                vol += d.point.dot(d.du.cross(d.dv)) * du * dv;
            }
        }
    }
    vol / 3.0
}

impl Shell {
    /// The shell of `given` at the default capacities ([`Shell::from_surfaces`]).
    pub fn new(given: &[Surface<'_>]) -> Result<Self, ShellError> {
        Self::from_surfaces(given)
    }
}

impl<const KNOTS: usize, const POINTS: usize> Shell<KNOTS, POINTS> {
    /// Copies the patches' data into the shell, splits the patches at their creases
    /// (interior knot lines of full multiplicity), classifies every side, finds edges and
    /// corners, and checks the orientation of a closed shell. Errors name patches by their
    /// index in `given`.
    pub fn from_surfaces(given: &[Surface<'_>]) -> Result<Self, ShellError> {
        let mut shell = Self::EMPTY;
        shell.rebuild(given)?;
        Ok(shell)
    }

    /// A shell of no patches: what a shell slot starts as, to be [rebuilt](Shell::rebuild)
    /// in place. No object is made of it (every shell constructor refuses no patches,
    /// [`ShellError::Empty`]).
    pub const EMPTY: Self = Shell {
        knots: [0.0; KNOTS],
        points: [Vec4::ZERO; POINTS],
        pieces: [Piece::EMPTY; MAX_SHELL_PATCHES],
        layout: Layout::EMPTY,
    };

    /// [`Shell::from_surfaces`] in place: this shell becomes the shell of `given`, its
    /// storage reused. On error the shell is left with no patches
    /// ([`Shell::surface_count`] 0) and must not be rendered until rebuilt.
    pub fn rebuild(&mut self, given: &[Surface<'_>]) -> Result<(), ShellError> {
        let result = self.rebuild_from(given);
        if result.is_err() {
            self.layout.clear();
        }
        result
    }

    /// Whether there are patches, not too many, and their knots and control points fit this
    /// shell's capacities (the first checks, in the order [`Shell::from_surfaces`] reports
    /// them).
    fn check_capacity(given: &[Surface<'_>]) -> Result<(), ShellError> {
        if given.is_empty() {
            return Err(ShellError::Empty);
        }
        if given.len() > MAX_SHELL_PATCHES {
            return Err(ShellError::TooManyPatches { count: given.len() });
        }
        let (n_knots, n_points) = given.iter().fold((0, 0), |(k, p), s| {
            let (ku, kv) = s.knots();
            (
                k + ku.as_slice().len() + kv.as_slice().len(),
                p + s.points().len(),
            )
        });
        let most = usize::from(u16::MAX);
        if n_knots > KNOTS || n_points > POINTS || n_knots > most || n_points > most {
            return Err(ShellError::Capacity {
                knots: n_knots,
                points: n_points,
                knot_capacity: KNOTS,
                point_capacity: POINTS,
            });
        }
        Ok(())
    }

    fn rebuild_from(&mut self, given: &[Surface<'_>]) -> Result<(), ShellError> {
        self.layout.clear();
        Self::check_capacity(given)?;
        let pieces = Pieces::of(given)?;
        self.layout.find(&pieces)?;
        // Each given patch's data, one after the other; where each patch's starts.
        let mut offsets = [Piece::EMPTY; MAX_SHELL_PATCHES];
        let (mut k0, mut p0) = (0, 0);
        for (s, at) in given.iter().zip(offsets.iter_mut()) {
            let (ku, kv) = s.knots();
            let (ku, kv, points) = (ku.as_slice(), kv.as_slice(), s.points());
            let (k1, k2, p1) = (k0 + ku.len(), k0 + ku.len() + kv.len(), p0 + points.len());
            self.knots[k0..k1].copy_from_slice(ku);
            self.knots[k1..k2].copy_from_slice(kv);
            self.points[p0..p1].copy_from_slice(points);
            let degree = s.degree();
            *at = Piece {
                degree: (degree.0 as u8, degree.1 as u8),
                knots_u: (k0 as u16, k1 as u16),
                knots_v: (k1 as u16, k2 as u16),
                points: (p0 as u16, p1 as u16),
                ..Piece::EMPTY
            };
            (k0, p0) = (k2, p1);
        }
        for (slot, (piece, &from)) in self
            .pieces
            .iter_mut()
            .zip(pieces.views().iter().zip(pieces.source.iter()))
        {
            let (ku, kv) = piece.knots();
            let (u, v) = (ku.bounds(), kv.bounds());
            *slot = Piece {
                window_u: (u.0 as u16, u.1 as u16),
                window_v: (v.0 as u16, v.1 as u16),
                ..offsets[usize::from(from).min(MAX_SHELL_PATCHES - 1)]
            };
        }
        Ok(())
    }

    /// Whether `given` makes a shell of these capacities (`Ok`), or the error
    /// [`Shell::from_surfaces`] would give, without building it (the patches are read in
    /// place: for a device's link, which validates a scene on a small stack).
    pub fn check(given: &[Surface<'_>]) -> Result<(), ShellError> {
        Self::check_capacity(given)?;
        let pieces = Pieces::of(given)?;
        let mut layout = Layout::EMPTY;
        layout.find(&pieces)
    }

    /// The [`Shell::topology`] of the shell `given` makes, or the error
    /// [`Shell::from_surfaces`] would give, without building it.
    pub fn topology_of(given: &[Surface<'_>]) -> Result<ShellTopology, ShellError> {
        Self::check_capacity(given)?;
        let pieces = Pieces::of(given)?;
        let mut layout = Layout::EMPTY;
        layout.find(&pieces)?;
        Ok(layout.topology(pieces.views().iter().map(Patch::domain)))
    }

    /// Piece `i` of the shell (the last one past the end): a view onto the shell's data.
    #[inline]
    pub fn surface(&self, i: usize) -> Surface<'_> {
        let last = self.layout.n_patches.clamp(1, MAX_SHELL_PATCHES) - 1;
        let p = &self.pieces[i.min(last)];
        let range = |(a, b): (u16, u16)| usize::from(a)..usize::from(b);
        let window = |(a, b): (u16, u16)| (usize::from(a), usize::from(b));
        let (du, dv) = (usize::from(p.degree.0), usize::from(p.degree.1));
        Surface::from_knots_unchecked(
            Knots::window_unchecked(&self.knots[range(p.knots_u)], du, window(p.window_u)),
            Knots::window_unchecked(&self.knots[range(p.knots_v)], dv, window(p.window_v)),
            &self.points[range(p.points)],
        )
    }

    /// The patches, split at their creases (see the module docs), in order.
    pub fn surfaces(&self) -> impl ExactSizeIterator<Item = Surface<'_>> + '_ {
        (0..self.layout.n_patches).map(|i| self.surface(i))
    }

    /// Number of patches (pieces) of the shell.
    pub fn surface_count(&self) -> usize {
        self.layout.n_patches
    }

    /// Index of the patch given to [`Shell::new`] that patch `i` of the shell is a piece of.
    pub fn source_patch(&self, i: usize) -> usize {
        usize::from(self.layout.source[i.min(MAX_SHELL_PATCHES - 1)])
    }

    /// A tracker on patch `i` at `t`, with the patch's periodic and collapsed sides known from
    /// the classification at load.
    fn tracker_on(&self, i: usize, t: [f32; 2], cfg: TrackerConfig) -> Tracker<Vec3, 2> {
        let sides = self.sides(i);
        let periodic = [sides[0] == Side::Periodic, sides[2] == Side::Periodic];
        let collapsed = [
            [sides[0] == Side::Collapsed, sides[1] == Side::Collapsed],
            [sides[2] == Side::Collapsed, sides[3] == Side::Collapsed],
        ];
        Tracker::with_topology(&self.surface(i), t, cfg, periodic, collapsed)
    }

    /// What lies across each side of patch `i` (`[u₀, u₁, v₀, v₁]`).
    pub fn sides(&self, i: usize) -> [Side; 4] {
        self.layout.sides[i.min(MAX_SHELL_PATCHES - 1)]
    }

    /// The edges.
    pub fn edges(&self) -> &[Edge] {
        self.layout.edges.get(..self.layout.n_edges).unwrap_or(&[])
    }

    /// The corners.
    pub fn corners(&self) -> &[Corner] {
        self.layout
            .corners
            .get(..self.layout.n_corners)
            .unwrap_or(&[])
    }

    /// Whether every side is shared, periodic or collapsed (a closed surface).
    pub fn is_closed(&self) -> bool {
        self.layout.closed
    }

    /// What a [`ShellTracker`] state of this shell depends on besides the geometry (as
    /// [`Chain::topology`](crate::Chain::topology)): the pieces (how many, their source
    /// patches and parameter domains), what lies across each side, the edges, which patch
    /// corners meet at each corner, and whether the shell closes.
    pub fn topology(&self) -> ShellTopology {
        self.layout
            .topology(self.surfaces().map(|s| Patch::domain(&s)))
    }

    /// The patch and parameters nearest to `x`: the global search on every patch (used to
    /// start tracking from nothing).
    pub fn nearest(&self, x: Vec3) -> (usize, [f32; 2]) {
        let cfg = GlobalConfig::default();
        let mut best = (0, [0.0; 2], f32::INFINITY);
        for (i, s) in self.surfaces().enumerate() {
            let r = closest_point(&s, x, &cfg);
            if r.distance_squared < best.2 {
                best = (i, r.t, r.distance_squared);
            }
        }
        (best.0, best.1)
    }
}

/// The topology of a [`Shell`] ([`Shell::topology`]): compare two with `==`. Holds no borrow.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShellTopology {
    pieces: u8,
    closed: bool,
    source: [u16; MAX_SHELL_PATCHES],
    domains: [[(f32, f32); 2]; MAX_SHELL_PATCHES],
    sides: [[Side; 4]; MAX_SHELL_PATCHES],
    edges: [Edge; MAX_SHELL_EDGES],
    n_edges: u8,
    corners: [([(u16, u8); MAX_CORNER_VALENCE], u8); MAX_SHELL_CORNERS],
    n_corners: u8,
    corner_of: [[u16; 4]; MAX_SHELL_PATCHES],
}

impl ShellTopology {
    /// Number of pieces (patches split at their creases).
    pub fn pieces(&self) -> usize {
        usize::from(self.pieces)
    }
}

/// Geometry of patch `s` at a point of its side `side`: point, unit outward normal, unit
/// inward conormal and unit edge tangent (direction of increasing side parameter).
fn side_frame(s: &Surface<'_>, side: usize, t: [f32; 2]) -> (Vec3, Vec3, Vec3, Vec3) {
    let jet = s.jet(t, 1);
    let n = Patch::normal(s, t, &jet);
    let (along, across, sign) = match side {
        0 => (jet.d[1], jet.d[0], 1.0),
        1 => (jet.d[1], jet.d[0], -1.0),
        2 => (jet.d[0], jet.d[1], 1.0),
        _ => (jet.d[0], jet.d[1], -1.0),
    };
    let tangent = Point::try_normalize(along).unwrap_or_else(|| n.any_orthonormal_vector());
    // Inward conormal: in the tangent plane, orthogonal to the edge.
    let m = Point::try_normalize(n.cross(tangent) * sign)
        .map(|m| if m.dot(across * sign) < 0.0 { -m } else { m })
        .unwrap_or(across * sign);
    (jet.point, n, m, tangent)
}

mod tracking;
pub use tracking::ShellTracker;
