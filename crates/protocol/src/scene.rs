//! The compact binary scene (`scene/1` on the wire) and its fixed-capacity, validated storage.

use friction::FrictionMaterial;
use nurbs::{Curve, NurbsError, Surface, Vec2, Vec3, Vec4};
use tracker::{
    CHAIN_KNOTS, CHAIN_POINTS, Chain, ChainError, ChainTopology, MAX_CHAIN_CURVES,
    MAX_SHELL_PATCHES, SHELL_KNOTS, SHELL_POINTS, Shell, ShellError, ShellTopology,
};

use super::wire::{MATERIAL_LEN, Reader, get_material};
use super::{ErrorCode, ScenePoints};

/// First bytes of a wire scene.
pub const SCENE_MAGIC: [u8; 4] = *b"NRBS";
/// Version of the wire scene format.
pub const SCENE_VERSION: u8 = 1;
/// Most objects in a scene.
pub const MAX_OBJECTS: usize = 8;
/// Most patches in a scene (all objects together).
pub const MAX_PATCHES: usize = 32;
/// Most knots in a scene (all knot vectors together) in the default [`SceneStore`]: what a
/// default chain and shell hold ([`tracker::CHAIN_KNOTS`], [`tracker::SHELL_KNOTS`]), so any
/// object of a scene makes one.
pub const MAX_KNOTS: usize = SHELL_KNOTS;
/// Most control points of planar curves in a scene in the default [`SceneStore`]: what a
/// default chain holds ([`tracker::CHAIN_POINTS`]).
pub const MAX_CURVE_POINTS: usize = CHAIN_POINTS;
/// Most control points of surfaces in a scene in the default [`SceneStore`]: what a default
/// shell holds ([`tracker::SHELL_POINTS`]).
pub const MAX_SURFACE_POINTS: usize = SHELL_POINTS;
const _: () = assert!(
    MAX_KNOTS <= CHAIN_KNOTS,
    "a default chain holds a scene's knots"
);

/// Patch kind byte: a planar curve.
pub const KIND_CURVE2: u8 = 1;
/// Patch kind byte: a surface.
pub const KIND_SURFACE: u8 = 2;

/// The kind of a patch, and of an object (all its patches have one kind).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PatchKind {
    /// A planar curve; an object of them is a [`tracker::Chain`].
    Curve2,
    /// A surface; an object of them is a [`tracker::Shell`].
    Surface,
}

/// What is wrong with a scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SceneFault {
    /// Not the wire scene format: see [`ErrorCode::SceneFormat`].
    Format,
    /// Larger than the fixed storage ([`MAX_OBJECTS`], [`MAX_PATCHES`], and the store's
    /// knot, curve point and surface point capacities, by default [`MAX_KNOTS`],
    /// [`MAX_CURVE_POINTS`], [`MAX_SURFACE_POINTS`]; u8/u16 counts on the wire).
    Capacity,
    /// A material out of range or with an unknown tag.
    Material(ErrorCode),
    /// A patch fails NURBS validation.
    Patch(NurbsError),
    /// An object mixes planar curves and surfaces.
    MixedKinds,
    /// An object's curves do not form a chain.
    Chain(ChainError),
    /// An object's surfaces do not form a shell.
    Shell(ShellError),
    /// A control-point update changed the object's topology ([`tracker::Object::topology`]).
    TopologyChanged,
    /// The device has no store free to validate into: the scene or update before is not in
    /// use yet (a board's tick takes it at its next boundary). Nothing changed; send the
    /// frame again.
    Busy,
}

/// Why a scene was rejected, and where.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WireSceneError {
    /// Object index, if the fault is in one object.
    pub object: Option<u8>,
    /// Patch index within the object, if the fault is in one patch.
    pub patch: Option<u8>,
    /// What.
    pub fault: SceneFault,
}

impl WireSceneError {
    fn at(object: usize, patch: Option<usize>, fault: SceneFault) -> Self {
        WireSceneError {
            object: u8::try_from(object).ok(),
            patch: patch.and_then(|p| u8::try_from(p).ok()),
            fault,
        }
    }

    fn whole(fault: SceneFault) -> Self {
        WireSceneError {
            object: None,
            patch: None,
            fault,
        }
    }

    /// The nack code.
    pub fn code(&self) -> ErrorCode {
        match self.fault {
            SceneFault::Format => ErrorCode::SceneFormat,
            SceneFault::Capacity => ErrorCode::SceneCapacity,
            SceneFault::Material(code) => code,
            SceneFault::Patch(_) => ErrorCode::ScenePatch,
            SceneFault::MixedKinds | SceneFault::Chain(_) | SceneFault::Shell(_) => {
                ErrorCode::SceneTopology
            }
            SceneFault::TopologyChanged => ErrorCode::TopologyChanged,
            SceneFault::Busy => ErrorCode::StagingBusy,
        }
    }
}

impl core::fmt::Display for WireSceneError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        if let Some(o) = self.object {
            write!(f, "object {o}, ")?;
        }
        if let Some(p) = self.patch {
            write!(f, "patch {p}: ")?;
        }
        match &self.fault {
            SceneFault::Patch(e) => write!(f, "{e}"),
            SceneFault::Chain(e) => write!(f, "{e}"),
            SceneFault::Shell(e) => write!(f, "{e}"),
            SceneFault::MixedKinds => write!(f, "mixes planar curves and surfaces"),
            SceneFault::Material(code) => write!(f, "material: {code}"),
            SceneFault::Format
            | SceneFault::Capacity
            | SceneFault::TopologyChanged
            | SceneFault::Busy => {
                write!(f, "{}", self.code())
            }
        }
    }
}

impl core::error::Error for WireSceneError {}

/// One object. Integers only, so that the empty record (and with it the empty store) is all
/// zero bits: a `static` store then lives in `.bss`, not in a `.data` image in flash.
#[derive(Clone, Copy, Debug)]
struct ObjectRecord {
    /// The material as on the wire (validated when the scene was decoded).
    material: [u8; MATERIAL_LEN],
    first_patch: usize,
    n_patches: usize,
    /// [`KIND_CURVE2`] or [`KIND_SURFACE`]; 0 for no object.
    kind: u8,
}

impl ObjectRecord {
    const EMPTY: ObjectRecord = ObjectRecord {
        material: [0; MATERIAL_LEN],
        first_patch: 0,
        n_patches: 0,
        kind: 0,
    };

    fn kind(&self) -> Option<PatchKind> {
        match self.kind {
            KIND_CURVE2 => Some(PatchKind::Curve2),
            KIND_SURFACE => Some(PatchKind::Surface),
            _ => None,
        }
    }
}

fn kind_byte(kind: PatchKind) -> u8 {
    match kind {
        PatchKind::Curve2 => KIND_CURVE2,
        PatchKind::Surface => KIND_SURFACE,
    }
}

#[derive(Clone, Copy, Debug, Default)]
struct PatchRecord {
    degree: (u8, u8),
    knots: usize,
    n_knots: (u16, u16),
    points: usize,
    counts: (u16, u16),
}

/// A decoded, validated scene in fixed-capacity storage (no allocation): knots and
/// homogeneous control points in flat arrays, views built on demand.
///
/// The capacities are const parameters: `KNOTS` knots (all knot vectors together),
/// `CURVE_POINTS` control points of planar curves and `SURFACE_POINTS` of surfaces. The
/// defaults ([`MAX_KNOTS`], [`MAX_CURVE_POINTS`], [`MAX_SURFACE_POINTS`]) make about 17.5 KiB,
/// what the host uses (in a `Box`); a board picks smaller ones (`SURFACE_POINTS = 0` refuses
/// every surface as [`SceneFault::Capacity`] and leaves the shell's validation out). The empty store
/// ([`SceneStore::empty`]) is all zero bits, so a `static` one is zero-initialised (`.bss`).
#[derive(Clone, Debug)]
pub struct SceneStore<
    const KNOTS: usize = MAX_KNOTS,
    const CURVE_POINTS: usize = MAX_CURVE_POINTS,
    const SURFACE_POINTS: usize = MAX_SURFACE_POINTS,
> {
    objects: [ObjectRecord; MAX_OBJECTS],
    n_objects: usize,
    patches: [PatchRecord; MAX_PATCHES],
    n_patches: usize,
    knots: [f32; KNOTS],
    n_knots: usize,
    curve_points: [Vec3; CURVE_POINTS],
    n_curve_points: usize,
    surface_points: [Vec4; SURFACE_POINTS],
    n_surface_points: usize,
}

impl<const K: usize, const C: usize, const S: usize> Default for SceneStore<K, C, S> {
    fn default() -> Self {
        Self::empty()
    }
}

impl SceneStore {
    /// An empty store of the default capacity (no objects).
    pub const fn new() -> Self {
        Self::empty()
    }
}

impl<const K: usize, const C: usize, const S: usize> SceneStore<K, C, S> {
    /// Knots the store holds (all knot vectors together).
    pub const KNOT_CAPACITY: usize = K;
    /// Control points of planar curves the store holds.
    pub const CURVE_POINT_CAPACITY: usize = C;
    /// Control points of surfaces the store holds.
    pub const SURFACE_POINT_CAPACITY: usize = S;

    /// An empty store (no objects), all zero bits.
    pub const fn empty() -> Self {
        SceneStore {
            objects: [ObjectRecord::EMPTY; MAX_OBJECTS],
            n_objects: 0,
            patches: [PatchRecord {
                degree: (0, 0),
                knots: 0,
                n_knots: (0, 0),
                points: 0,
                counts: (0, 0),
            }; MAX_PATCHES],
            n_patches: 0,
            knots: [0.0; K],
            n_knots: 0,
            curve_points: [Vec3::ZERO; C],
            n_curve_points: 0,
            surface_points: [Vec4::ZERO; S],
            n_surface_points: 0,
        }
    }

    fn clear(&mut self) {
        self.n_objects = 0;
        self.n_patches = 0;
        self.n_knots = 0;
        self.n_curve_points = 0;
        self.n_surface_points = 0;
        self.objects = [ObjectRecord::EMPTY; MAX_OBJECTS];
    }

    /// Number of objects (0 when empty or after a failed decode).
    pub fn object_count(&self) -> usize {
        self.n_objects
    }

    fn object(&self, object: usize) -> Option<&ObjectRecord> {
        self.objects.get(object).filter(|o| o.kind().is_some())
    }

    /// Material of `object`.
    pub fn material(&self, object: usize) -> Option<FrictionMaterial> {
        // Validated when the scene was decoded, so this decodes.
        self.object(object)
            .and_then(|o| get_material(&mut Reader::new(&o.material)).ok())
    }

    /// Kind of `object`'s patches.
    pub fn kind(&self, object: usize) -> Option<PatchKind> {
        self.object(object).and_then(ObjectRecord::kind)
    }

    /// Number of patches of `object`.
    pub fn patch_count(&self, object: usize) -> Option<usize> {
        self.object(object).map(|o| o.n_patches)
    }

    fn patch_record(&self, object: usize, patch: usize, kind: PatchKind) -> Option<&PatchRecord> {
        let o = self.object(object)?;
        if o.kind() != Some(kind) || patch >= o.n_patches {
            return None;
        }
        self.patches.get(o.first_patch + patch)
    }

    fn knot_slices(&self, p: &PatchRecord) -> Option<(&[f32], &[f32])> {
        let (nu, nv) = (usize::from(p.n_knots.0), usize::from(p.n_knots.1));
        let u = self.knots.get(p.knots..p.knots + nu)?;
        let v = self.knots.get(p.knots + nu..p.knots + nu + nv)?;
        Some((u, v))
    }

    /// Patch `patch` of `object` when that object is a chain of planar curves. The view is
    /// not validated again ([`Curve::new_unchecked`]): the store holds only what
    /// [`SceneStore::decode`] validated with [`Curve::new`], and nothing else writes it. So a
    /// view costs no validation pass, which matters to a device that builds views between two
    /// ticks (a control-point update's, `Chain::reshape`).
    pub fn curve(&self, object: usize, patch: usize) -> Option<Curve<'_, Vec2>> {
        let p = self.patch_record(object, patch, PatchKind::Curve2)?;
        let (knots, _) = self.knot_slices(p)?;
        let points = self
            .curve_points
            .get(p.points..p.points + usize::from(p.counts.0))?;
        Some(Curve::new_unchecked(usize::from(p.degree.0), knots, points))
    }

    /// Patch `patch` of `object` when that object is a shell of surfaces. Builds the view
    /// with [`Surface::new`], so it costs one validation pass: build views once, at load.
    pub fn surface(&self, object: usize, patch: usize) -> Option<Surface<'_>> {
        let p = self.patch_record(object, patch, PatchKind::Surface)?;
        let knots = self.knot_slices(p)?;
        let n = usize::from(p.counts.0) * usize::from(p.counts.1);
        let points = self.surface_points.get(p.points..p.points + n)?;
        let degree = (usize::from(p.degree.0), usize::from(p.degree.1));
        Surface::new(degree, knots, usize::from(p.counts.1), points).ok()
    }

    /// Parses and validates a wire scene into this store, replacing its contents. On error
    /// the store is left empty (no objects), never half-filled.
    ///
    /// Validation is the host's: every material (the `scene/1` ranges), every patch with
    /// [`Curve::new`] / [`Surface::new`], every object with [`Chain::new`] / [`Shell::new`].
    pub fn decode(&mut self, bytes: &[u8]) -> Result<(), WireSceneError> {
        self.clear();
        let result = self.parse(bytes).and_then(|()| self.check_topology());
        if result.is_err() {
            self.clear();
        }
        result
    }

    /// Validates `reshaped`, the wire scene `active` with control points of object `object`
    /// moved, into this store ([`SceneStore::decode`]), and checks that the move kept the
    /// object's topology: `active` is decoded first and the object's topology
    /// ([`Chain::topology`], [`Shell::topology`]) compared with the reshaped one's
    /// ([`SceneFault::TopologyChanged`]). On success the store holds `reshaped`; on error it
    /// is empty. Two decodes: the cost of two commits' validation. Not inlined, and its own
    /// frame holds one topology: the chains are built further down, one at a time, so its
    /// deepest stack is a commit's validation and a topology.
    #[inline(never)]
    pub fn decode_reshaped(
        &mut self,
        active: &[u8],
        reshaped: &[u8],
        object: usize,
    ) -> Result<(), WireSceneError> {
        let changed = WireSceneError::at(object, None, SceneFault::TopologyChanged);
        self.decode(active)?;
        let kept = match self.kind(object) {
            Some(PatchKind::Curve2) => match self.chain_topology(object) {
                Ok(before) => {
                    self.decode(reshaped)?;
                    self.chain_topology(object).ok() == Some(before)
                }
                Err(_) => false,
            },
            Some(PatchKind::Surface) if S > 0 => self.shell_reshaped(reshaped, object)?,
            _ => false,
        };
        if !kept {
            self.clear();
            return Err(changed);
        }
        Ok(())
    }

    /// Object `object` as a chain of planar curves, holding its own copy of the object's
    /// data at the store's capacities (so any object of the store fits): the one conversion
    /// from a store to what a controller renders. Refused with the fault that says why: no
    /// such object, an object of surfaces, curves that do not make a chain.
    pub fn chain(&self, object: usize) -> Result<Chain<K, C>, WireSceneError> {
        self.with_curves(object, Chain::from_curves)?
            .map_err(|e| WireSceneError::at(object, None, SceneFault::Chain(e)))
    }

    /// [`SceneStore::chain`] in place: `chain` becomes object `object`'s chain, its storage
    /// reused ([`Chain::rebuild`]: no chain built on the stack). On error `chain` has no
    /// curves.
    pub fn rebuild_chain(
        &self,
        object: usize,
        chain: &mut Chain<K, C>,
    ) -> Result<(), WireSceneError> {
        self.with_curves(object, |curves| chain.rebuild(curves))?
            .map_err(|e| WireSceneError::at(object, None, SceneFault::Chain(e)))
    }

    /// `f` of object `object`'s curves as views of the store (a chain's worth of views, no
    /// chain built, built in place: no array of views copied out): what [`Chain::reshape`]
    /// takes to move a chain onto this store's shape of the object.
    pub fn with_curves<R>(
        &self,
        object: usize,
        f: impl FnOnce(&[Curve<'_, Vec2>]) -> R,
    ) -> Result<R, WireSceneError> {
        let at = |fault| WireSceneError::at(object, None, fault);
        let rec = self.object(object).ok_or(at(SceneFault::Format))?;
        if rec.kind() != Some(PatchKind::Curve2) {
            return Err(at(SceneFault::MixedKinds));
        }
        let count = rec.n_patches;
        if count > MAX_CHAIN_CURVES {
            return Err(at(SceneFault::Chain(ChainError::TooManyCurves { count })));
        }
        let patch = |p: usize| {
            // Every patch was validated while parsing, so each is a curve.
            self.curve(object, p)
                .ok_or(WireSceneError::at(object, Some(p), SceneFault::Format))
        };
        let first = patch(0)?;
        let mut curves = [first; MAX_CHAIN_CURVES];
        for (p, c) in curves.iter_mut().enumerate().take(count).skip(1) {
            *c = patch(p)?;
        }
        Ok(f(&curves[..count]))
    }

    /// Whether `object` makes a chain ([`SceneStore::chain`] would build it), checked on the
    /// store's views ([`SceneStore::chain_topology`]): no chain built.
    fn check_chain(&self, object: usize) -> Result<(), WireSceneError> {
        self.chain_topology(object).map(drop)
    }

    /// The topology of `object`'s chain ([`Chain::topology_of`] on the store's views: no
    /// chain built), or why it is not one. Not inlined, as [`SceneStore::check_chain`], which
    /// is it (one copy of the views' setup in a board's flash).
    #[inline(never)]
    fn chain_topology(&self, object: usize) -> Result<ChainTopology, WireSceneError> {
        self.with_curves(object, Chain::<K, C>::topology_of)?
            .map_err(|e| WireSceneError::at(object, None, SceneFault::Chain(e)))
    }

    /// Object `object` as a shell of surfaces, holding its own copy of the object's data at
    /// the store's capacities (so any object of the store fits), as [`SceneStore::chain`]
    /// for a chain. Refused with the fault that says why: no such object, an object of
    /// curves, surfaces that do not make a shell.
    pub fn shell(&self, object: usize) -> Result<Shell<K, S>, WireSceneError> {
        self.with_surfaces(object, Shell::from_surfaces)?
            .map_err(|e| WireSceneError::at(object, None, SceneFault::Shell(e)))
    }

    /// [`SceneStore::shell`] in place: `shell` becomes object `object`'s shell, its storage
    /// reused ([`Shell::rebuild`]: no shell built on the stack). On error `shell` has no
    /// patches.
    pub fn rebuild_shell(
        &self,
        object: usize,
        shell: &mut Shell<K, S>,
    ) -> Result<(), WireSceneError> {
        self.with_surfaces(object, |surfaces| shell.rebuild(surfaces))?
            .map_err(|e| WireSceneError::at(object, None, SceneFault::Shell(e)))
    }

    /// `f` of object `object`'s surfaces as views of the store (a shell's worth of views, no
    /// shell built), as [`SceneStore::with_curves`] for curves.
    pub fn with_surfaces<R>(
        &self,
        object: usize,
        f: impl FnOnce(&[Surface<'_>]) -> R,
    ) -> Result<R, WireSceneError> {
        let at = |fault| WireSceneError::at(object, None, fault);
        let rec = self.object(object).ok_or(at(SceneFault::Format))?;
        if rec.kind() != Some(PatchKind::Surface) {
            return Err(at(SceneFault::MixedKinds));
        }
        let count = rec.n_patches;
        if count > MAX_SHELL_PATCHES {
            return Err(at(SceneFault::Shell(ShellError::TooManyPatches { count })));
        }
        let patch = |p: usize| {
            // Every patch was validated while parsing, so each is a surface.
            self.surface(object, p)
                .ok_or(WireSceneError::at(object, Some(p), SceneFault::Format))
        };
        let first = patch(0)?;
        let mut surfaces = [first; MAX_SHELL_PATCHES];
        for (p, s) in surfaces.iter_mut().enumerate().take(count).skip(1) {
            *s = patch(p)?;
        }
        Ok(f(&surfaces[..count]))
    }

    /// Whether `object` makes a shell ([`Shell::check`]: no shell built). Not inlined, as
    /// [`SceneStore::check_chain`].
    #[inline(never)]
    fn check_shell(&self, object: usize) -> Result<(), WireSceneError> {
        self.with_surfaces(object, Shell::<K, S>::check)?
            .map_err(|e| WireSceneError::at(object, None, SceneFault::Shell(e)))
    }

    /// The topology of `object`'s shell ([`Shell::topology_of`]: no shell built), `None`
    /// when it is not one.
    #[inline(never)]
    fn shell_topology(&self, object: usize) -> Option<ShellTopology> {
        self.with_surfaces(object, Shell::<K, S>::topology_of)
            .ok()?
            .ok()
    }

    /// The surface half of [`SceneStore::decode_reshaped`] (the active scene decoded): decodes
    /// `reshaped` and says whether `object` kept its topology. Apart, so that a store without
    /// surfaces links none of it.
    #[inline(never)]
    fn shell_reshaped(&mut self, reshaped: &[u8], object: usize) -> Result<bool, WireSceneError> {
        let Some(before) = self.shell_topology(object) else {
            return Ok(false);
        };
        self.decode(reshaped)?;
        Ok(self.shell_topology(object) == Some(before))
    }

    fn parse(&mut self, bytes: &[u8]) -> Result<(), WireSceneError> {
        let format = || WireSceneError::whole(SceneFault::Format);
        let r = &mut Reader::new(bytes);
        if r.take(4) != Some(&SCENE_MAGIC[..]) || r.u8() != Some(SCENE_VERSION) {
            return Err(format());
        }
        let n_objects = usize::from(r.u8().ok_or_else(format)?);
        if r.u16() != Some(0) || n_objects == 0 {
            return Err(format());
        }
        if n_objects > MAX_OBJECTS {
            return Err(WireSceneError::whole(SceneFault::Capacity));
        }
        for o in 0..n_objects {
            let format = || WireSceneError::at(o, None, SceneFault::Format);
            let mut at_material = *r;
            get_material(r).map_err(|code| WireSceneError::at(o, None, material_fault(code)))?;
            let mut material = [0; MATERIAL_LEN];
            material.copy_from_slice(at_material.take(MATERIAL_LEN).ok_or_else(format)?);
            let n_patches = usize::from(r.u8().ok_or_else(format)?);
            if n_patches == 0 {
                return Err(format());
            }
            let first_patch = self.n_patches;
            let mut kind = None;
            for p in 0..n_patches {
                let k = self
                    .parse_patch(r)
                    .map_err(|fault| WireSceneError::at(o, Some(p), fault))?;
                if kind.is_some_and(|kind| kind != k) {
                    return Err(WireSceneError::at(o, Some(p), SceneFault::MixedKinds));
                }
                kind = Some(k);
            }
            self.objects[o] = kind.map_or(ObjectRecord::EMPTY, |kind| ObjectRecord {
                material,
                first_patch,
                n_patches,
                kind: kind_byte(kind),
            });
            self.n_objects = o + 1;
        }
        if r.remaining() != 0 {
            return Err(format());
        }
        Ok(())
    }

    fn parse_patch(&mut self, r: &mut Reader<'_>) -> Result<PatchKind, SceneFault> {
        let f = SceneFault::Format;
        if self.n_patches >= MAX_PATCHES {
            return Err(SceneFault::Capacity);
        }
        let kind = match r.u8().ok_or(f)? {
            KIND_CURVE2 => PatchKind::Curve2,
            KIND_SURFACE => PatchKind::Surface,
            _ => return Err(f),
        };
        let mut rec = PatchRecord::default();
        match kind {
            PatchKind::Curve2 => {
                rec.degree = (r.u8().ok_or(f)?, 0);
                rec.n_knots = (r.u16().ok_or(f)?, 0);
                rec.counts = (r.u16().ok_or(f)?, 1);
            }
            PatchKind::Surface => {
                rec.degree = (r.u8().ok_or(f)?, r.u8().ok_or(f)?);
                rec.n_knots = (r.u16().ok_or(f)?, r.u16().ok_or(f)?);
                rec.counts = (r.u16().ok_or(f)?, r.u16().ok_or(f)?);
            }
        }
        let n_knots = usize::from(rec.n_knots.0) + usize::from(rec.n_knots.1);
        let n_points = usize::from(rec.counts.0) * usize::from(rec.counts.1);
        let coords: usize = match kind {
            PatchKind::Curve2 => 3,
            PatchKind::Surface => 4,
        };
        // Check the bytes are there before the capacity, so truncation is a format error
        // whatever the counts.
        let bytes = n_knots
            .saturating_add(coords.saturating_mul(n_points))
            .saturating_mul(4);
        if r.remaining() < bytes {
            return Err(f);
        }
        let (knot_room, point_room) = match kind {
            PatchKind::Curve2 => (K - self.n_knots, C - self.n_curve_points),
            // A store without room for surface points takes no surface, not even one of no
            // points: said before anything is built, so that such a store (a board's) links
            // none of the surfaces' validation (about 5 KB of flash).
            PatchKind::Surface if S == 0 => return Err(SceneFault::Capacity),
            PatchKind::Surface => (K - self.n_knots, S - self.n_surface_points),
        };
        if n_knots > knot_room || n_points > point_room {
            return Err(SceneFault::Capacity);
        }
        rec.knots = self.n_knots;
        let knots = self
            .knots
            .get_mut(rec.knots..rec.knots + n_knots)
            .ok_or(SceneFault::Capacity)?;
        for k in knots {
            *k = r.f32().ok_or(f)?;
        }
        self.n_knots += n_knots;
        match kind {
            PatchKind::Curve2 => {
                rec.points = self.n_curve_points;
                let points = self
                    .curve_points
                    .get_mut(rec.points..rec.points + n_points)
                    .ok_or(SceneFault::Capacity)?;
                for p in points {
                    *p = Vec3::new(r.f32().ok_or(f)?, r.f32().ok_or(f)?, r.f32().ok_or(f)?);
                }
                self.n_curve_points += n_points;
            }
            PatchKind::Surface => {
                rec.points = self.n_surface_points;
                let points = self
                    .surface_points
                    .get_mut(rec.points..rec.points + n_points)
                    .ok_or(SceneFault::Capacity)?;
                for p in points {
                    *p = Vec4::new(
                        r.f32().ok_or(f)?,
                        r.f32().ok_or(f)?,
                        r.f32().ok_or(f)?,
                        r.f32().ok_or(f)?,
                    );
                }
                self.n_surface_points += n_points;
            }
        }
        self.patches[self.n_patches] = rec;
        self.n_patches += 1;
        let result = match kind {
            PatchKind::Curve2 => {
                let (knots, _) = self.knot_slices(&rec).ok_or(SceneFault::Capacity)?;
                let points = &self.curve_points[rec.points..rec.points + n_points];
                Curve::<Vec2>::new(usize::from(rec.degree.0), knots, points).map(|_| ())
            }
            PatchKind::Surface => {
                let knots = self.knot_slices(&rec).ok_or(SceneFault::Capacity)?;
                let points = &self.surface_points[rec.points..rec.points + n_points];
                let degree = (usize::from(rec.degree.0), usize::from(rec.degree.1));
                Surface::new(degree, knots, usize::from(rec.counts.1), points).map(|_| ())
            }
        };
        result.map_err(SceneFault::Patch)?;
        Ok(kind)
    }

    fn check_topology(&self) -> Result<(), WireSceneError> {
        for o in 0..self.n_objects {
            let Some(rec) = self.object(o) else {
                return Err(WireSceneError::at(o, None, SceneFault::Format));
            };
            match rec.kind() {
                None => return Err(WireSceneError::at(o, None, SceneFault::Format)),
                Some(PatchKind::Curve2) => self.check_chain(o)?,
                // A store without room for surface points never holds a surface object (its
                // patches were refused while parsing); said here too, so that such a store
                // does not link the shell's validation at all.
                Some(PatchKind::Surface) if S == 0 => {
                    return Err(WireSceneError::at(o, None, SceneFault::Capacity));
                }
                Some(PatchKind::Surface) => self.check_shell(o)?,
            }
        }
        Ok(())
    }
}

fn material_fault(code: ErrorCode) -> SceneFault {
    match code {
        // A material cut short is a truncated scene.
        ErrorCode::BadPayloadLength => SceneFault::Format,
        code => SceneFault::Material(code),
    }
}

/// Where the control points of one patch lie in a wire scene ([`patch_points`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PointSpan {
    /// Byte offset of the first homogeneous control point.
    pub offset: usize,
    /// Number of control points.
    pub count: usize,
    /// The patch's kind: a planar curve's points are `(w·x, w·y, w)`, 12 bytes; a surface's
    /// `(w·x, w·y, w·z, w)`, 16.
    pub kind: PatchKind,
}

impl PointSpan {
    /// Bytes per homogeneous point.
    pub fn stride(&self) -> usize {
        match self.kind {
            PatchKind::Curve2 => 12,
            PatchKind::Surface => 16,
        }
    }
}

/// Where the control points of patch `patch` of object `object` lie in the wire scene
/// `scene`: walks the headers (the layout in the module docs of `protocol`), reading no
/// float. `None` when the scene has no such object or patch, or is cut short. Total: any
/// bytes give an answer, never a panic.
pub fn patch_points(scene: &[u8], object: usize, patch: usize) -> Option<PointSpan> {
    let r = &mut Reader::new(scene);
    if r.take(4)? != &SCENE_MAGIC[..] || r.u8()? != SCENE_VERSION {
        return None;
    }
    let n_objects = usize::from(r.u8()?);
    r.u16()?;
    if object >= n_objects {
        return None;
    }
    for o in 0..=object {
        r.take(MATERIAL_LEN)?;
        let n_patches = usize::from(r.u8()?);
        for p in 0..n_patches {
            let (kind, knots, points) = match r.u8()? {
                KIND_CURVE2 => {
                    r.u8()?;
                    let m = usize::from(r.u16()?);
                    let n = usize::from(r.u16()?);
                    (PatchKind::Curve2, m, n)
                }
                KIND_SURFACE => {
                    r.u16()?;
                    let m = usize::from(r.u16()?) + usize::from(r.u16()?);
                    let n = usize::from(r.u16()?) * usize::from(r.u16()?);
                    (PatchKind::Surface, m, n)
                }
                _ => return None,
            };
            r.take(4 * knots)?;
            let span = PointSpan {
                offset: scene.len() - r.remaining(),
                count: points,
                kind,
            };
            r.take(span.stride().checked_mul(points)?)?;
            if o == object && p == patch {
                return Some(span);
            }
        }
        if o == object {
            return None;
        }
    }
    None
}

/// Where the points of the update `p` go in the wire scene `scene`: the span of its patch,
/// checked against it. [`ErrorCode::NoSuchPatch`] when the scene has no such object or patch
/// (or is not a wire scene), [`ErrorCode::PointsKind`] for planar points on a surface or
/// spatial ones on a curve, [`ErrorCode::PointsPastPatch`] when they run past the patch's.
pub fn points_span(scene: &[u8], p: &ScenePoints) -> Result<PointSpan, ErrorCode> {
    let span = patch_points(scene, usize::from(p.object), usize::from(p.patch))
        .ok_or(ErrorCode::NoSuchPatch)?;
    if (span.kind == PatchKind::Surface) != p.is_spatial() {
        return Err(ErrorCode::PointsKind);
    }
    if usize::from(p.first) + p.len() > span.count {
        return Err(ErrorCode::PointsPastPatch);
    }
    Ok(span)
}

/// Writes the points of `p` into the wire scene `scene` in place, each as `(w·x, w·y, w)` (a
/// surface's `(w·x, w·y, w·z, w)`) with the weight `w` the scene holds for it: what the
/// device's receiver does to its staged copy of the active scene, and what a host does to its
/// own copy to know the scene (and its CRC-32) the device will have. Errors as
/// [`points_span`], with `scene` unchanged. Validates nothing else: the result may not be a
/// valid scene (the device checks that before it applies an update).
pub fn write_points(scene: &mut [u8], p: &ScenePoints) -> Result<(), ErrorCode> {
    let span = points_span(scene, p)?;
    let dims = p.dims();
    let stride = span.stride();
    for (i, coords) in p.coords().chunks_exact(dims).enumerate() {
        let at = span.offset + (usize::from(p.first) + i) * stride;
        // Inside the scene: the span was read from it.
        let bytes = scene
            .get_mut(at..at + stride)
            .ok_or(ErrorCode::PointsPastPatch)?;
        let (xyz, w) = bytes.split_at_mut(4 * dims);
        let w = f32::from_le_bytes([w[0], w[1], w[2], w[3]]);
        for (dst, &c) in xyz.chunks_exact_mut(4).zip(coords) {
            dst.copy_from_slice(&(c * w).to_le_bytes());
        }
    }
    Ok(())
}

/// Parses and validates a wire scene into `store` (see [`SceneStore::decode`]).
pub fn decode_scene<const K: usize, const C: usize, const S: usize>(
    bytes: &[u8],
    store: &mut SceneStore<K, C, S>,
) -> Result<(), WireSceneError> {
    store.decode(bytes)
}

#[cfg(feature = "std")]
pub use host::{WireObject, WirePatch, encode_scene};

#[cfg(feature = "std")]
mod host {
    use super::*;
    use crate::wire::{Sink, put_material};

    /// One patch to encode: a borrowed view (from `CurveBuf::view` / `SurfaceBuf::view`).
    #[derive(Clone, Copy, Debug)]
    pub enum WirePatch<'a> {
        /// A planar curve.
        Curve(Curve<'a, Vec2>),
        /// A surface.
        Surface(Surface<'a>),
    }

    /// One object to encode.
    #[derive(Clone, Copy, Debug)]
    pub struct WireObject<'a> {
        /// Its material.
        pub material: FrictionMaterial,
        /// Its patches, in chain / shell order.
        pub patches: &'a [WirePatch<'a>],
    }

    /// Encodes a scene in the wire format and checks it the way the device will
    /// ([`SceneStore::decode`]): a scene this returns is one the device accepts.
    pub fn encode_scene(objects: &[WireObject<'_>]) -> Result<Vec<u8>, WireSceneError> {
        let cap = |o, p| WireSceneError::at(o, p, SceneFault::Capacity);
        let count16 = |n: usize, o, p| u16::try_from(n).map_err(|_| cap(o, Some(p)));
        let mut out = Vec::new();
        out.put(&SCENE_MAGIC);
        out.u8(SCENE_VERSION);
        out.u8(
            u8::try_from(objects.len()).map_err(|_| WireSceneError::whole(SceneFault::Capacity))?
        );
        out.u16(0);
        for (o, obj) in objects.iter().enumerate() {
            put_material(&mut out, &obj.material);
            out.u8(u8::try_from(obj.patches.len()).map_err(|_| cap(o, None))?);
            for (p, patch) in obj.patches.iter().enumerate() {
                match patch {
                    WirePatch::Curve(c) => {
                        let knots = c.knots().as_slice();
                        out.u8(KIND_CURVE2);
                        out.u8(u8::try_from(c.degree()).map_err(|_| cap(o, Some(p)))?);
                        out.u16(count16(knots.len(), o, p)?);
                        out.u16(count16(c.points().len(), o, p)?);
                        for &k in knots {
                            out.f32(k);
                        }
                        for h in c.points() {
                            for v in h.to_array() {
                                out.f32(v);
                            }
                        }
                    }
                    WirePatch::Surface(s) => {
                        let (ku, kv) = s.knots();
                        let (ku, kv) = (ku.as_slice(), kv.as_slice());
                        let (p_u, p_v) = s.degree();
                        let (n_u, n_v) = s.counts();
                        out.u8(KIND_SURFACE);
                        out.u8(u8::try_from(p_u).map_err(|_| cap(o, Some(p)))?);
                        out.u8(u8::try_from(p_v).map_err(|_| cap(o, Some(p)))?);
                        out.u16(count16(ku.len(), o, p)?);
                        out.u16(count16(kv.len(), o, p)?);
                        out.u16(count16(n_u, o, p)?);
                        out.u16(count16(n_v, o, p)?);
                        for &k in ku.iter().chain(kv) {
                            out.f32(k);
                        }
                        for h in s.points() {
                            for v in h.to_array() {
                                out.f32(v);
                            }
                        }
                    }
                }
            }
        }
        let mut store = Box::new(SceneStore::new());
        store.decode(&out)?;
        Ok(out)
    }
}
