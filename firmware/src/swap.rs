//! The scene double buffer shared by the link task (which decodes an upload into one half)
//! and the tick (which renders the other), handed between them as ownership tokens.
//!
//! The controller holds its object as borrowed views of a store (`tracker::Chain<'s>`), and on
//! the board the tick and the link are separate interrupt handlers whose state must be
//! `'static`: a view the tick keeps must borrow a store for `'static`, yet after the next swap
//! the link task must write into that same memory again. Safe Rust cannot express "this
//! `'static` borrow ends at the swap", so this module holds the one `unsafe` step of it,
//! behind tokens that make every other step safe:
//!
//! - a [`Staging`] token is the only way to the `&mut` of its half; there is exactly one per
//!   half ([`SceneBuffers::split`] hands them out once), and it moves between tasks;
//! - [`Staging::publish`] turns it into a [`Published`] token, which hands out `&'static`
//!   shared references ([`Published::get`]) and no `&mut`;
//! - [`Published::reclaim`] (the `unsafe` step) turns it back into a [`Staging`]; its caller
//!   promises that every reference [`Published::get`] gave out is dead.
//!
//! So a half is either written through its one `Staging` or read through `&T`s, never both.
//!
//! The tick's side of it is [`TickScenes`]: the link task sends it committed stores as
//! `Staging` tokens; it publishes one, loads it into the [`App`] and hands back the store the
//! app rendered before (or the new one, when the app refused it) as a `Staging` again; it lends
//! the rendered store to one acquisition job at a time ([`AcquisitionJob`], [`JobDone`]). A
//! control-point update goes the same way ([`TickScenes::reshape_in`]): the link validates the
//! updated scene into its staging half, the tick publishes it and gives the controller its
//! object in place of the old one (`App::reshape`, which keeps the renderer), and hands the
//! old half back. It calls `reclaim` only where the views are provably gone: after a load or a
//! reshape replaced the controller's object, or after one that failed (which keeps no view of
//! the new half), and never while a job is out.

use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicBool, Ordering};

use device::controller::AcquisitionRequest;
use device::protocol::{SceneFault, SceneStore, SceneValidator, WireSceneError};

use crate::app::{AcquisitionJob, App, AppError, ChainAcquisition, JobDone};

/// Two stores and the flag that they were split into tokens.
pub struct SceneBuffers<T> {
    halves: [UnsafeCell<T>; 2],
    split: AtomicBool,
}

#[allow(unsafe_code)]
// SAFETY: the halves are reached only through the tokens: `&mut T` through the unique
// `Staging` of a half, `&T` through its `Published`, never both at once (`reclaim`'s
// contract). Sharing the buffers between tasks therefore shares `T` by `&` (needs `T: Sync`)
// and moves it between tasks by `&mut` (needs `T: Send`).
unsafe impl<T: Send + Sync> Sync for SceneBuffers<T> {}

impl<T> core::fmt::Debug for SceneBuffers<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("SceneBuffers")
            .field("split", &self.split.load(Ordering::Relaxed))
            .finish_non_exhaustive()
    }
}

impl<T> SceneBuffers<T> {
    /// The two halves (a `static` of empty stores is zero-initialised when `T`'s empty value
    /// is all zero bits).
    pub const fn new(a: T, b: T) -> Self {
        SceneBuffers {
            halves: [UnsafeCell::new(a), UnsafeCell::new(b)],
            split: AtomicBool::new(false),
        }
    }

    /// The two halves' tokens, the first time; `None` after that.
    pub fn split(&'static self) -> Option<[Staging<T>; 2]> {
        if self.split.swap(true, Ordering::AcqRel) {
            return None;
        }
        let [a, b] = &self.halves;
        Some([Staging { half: a }, Staging { half: b }])
    }
}

/// Write access to one half (unique).
pub struct Staging<T: 'static> {
    half: &'static UnsafeCell<T>,
}

#[allow(unsafe_code)]
// SAFETY: the token is the only access to its half while it exists (see the module docs);
// moving it to another task moves that access, which needs `T: Send`.
unsafe impl<T: Send> Send for Staging<T> {}

impl<T> core::fmt::Debug for Staging<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Staging")
            .field("half", &self.half.get())
            .finish()
    }
}

impl<T> Staging<T> {
    /// The half, to write.
    pub fn get_mut(&mut self) -> &mut T {
        #[allow(unsafe_code)]
        // SAFETY: this token is the half's only access (module docs): no `&T` from a
        // `Published` of it is alive (`reclaim`'s contract), and the `&mut` borrows the token.
        unsafe {
            &mut *self.half.get()
        }
    }

    /// Ends writing: from now on the half is only read.
    pub fn publish(self) -> Published<T> {
        Published { half: self.half }
    }
}

/// Read access to one half, shareable as `&'static T`.
pub struct Published<T: 'static> {
    half: &'static UnsafeCell<T>,
}

#[allow(unsafe_code)]
// SAFETY: a `Published` only hands out `&T` (nothing writes the half while it exists), so
// moving it between tasks shares `T` between them: `T: Send + Sync`.
unsafe impl<T: Send + Sync> Send for Published<T> {}

impl<T> core::fmt::Debug for Published<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Published")
            .field("half", &self.half.get())
            .finish()
    }
}

impl<T> Published<T> {
    /// The half, to read, for as long as the program runs (see [`Published::reclaim`]).
    pub fn get(&self) -> &'static T {
        #[allow(unsafe_code)]
        // SAFETY: no `&mut` of the half exists: its `Staging` was consumed by `publish`, and
        // a new one only comes from `reclaim`, whose caller guarantees this `&T` is dead by
        // then.
        unsafe {
            &*self.half.get()
        }
    }

    /// Back to write access.
    ///
    /// # Safety
    ///
    /// Every reference [`Published::get`] returned for this half, and everything borrowing
    /// from one (views such as `Curve`, `Chain`, a controller holding them), must be dead:
    /// the half is written through the returned [`Staging`].
    #[allow(unsafe_code)]
    pub unsafe fn reclaim(self) -> Staging<T> {
        Staging { half: self.half }
    }
}

/// The tick's side of the scene hand-over: the store it renders (published) and whether an
/// acquisition job reads it.
#[derive(Debug)]
pub struct TickScenes<T: 'static> {
    active: Option<Published<T>>,
    job_out: bool,
}

/// What [`TickScenes::swap_in`] did.
#[derive(Debug)]
pub struct Swapped<T: 'static> {
    /// The load's result; on error the scene before stays rendered.
    pub loaded: Result<(), AppError>,
    /// The store to hand back to the link task: the one rendered before the load, or the new
    /// one when the load failed; `None` after the first load.
    pub freed: Option<Staging<T>>,
}

impl<T> TickScenes<T> {
    /// No store rendered, no job out.
    ///
    /// # Safety
    ///
    /// The views of the stores the [`App`] given to [`TickScenes::swap_in`] is built on stay
    /// in that app's controller: the caller never copies a view out of it (a `tracker::Chain`
    /// from `App::controller`) to keep beyond the tick, nor loads that app with a store
    /// taken elsewhere from these halves. With that, a load that replaces the controller's
    /// scene ends every view of the store before, and the only other reader is the job this
    /// type counts.
    #[allow(unsafe_code)]
    pub const unsafe fn new() -> Self {
        TickScenes {
            active: None,
            job_out: false,
        }
    }

    /// Whether an acquisition job reads the rendered store (its [`JobDone`] not back yet).
    pub fn job_out(&self) -> bool {
        self.job_out
    }
}

/// Loads object 0 of `store`. Not inlined, so that its frame (the chain it builds) and the
/// tick's do not add up on the stack.
#[inline(never)]
fn load<const K: usize, const C: usize, const S: usize>(
    app: &mut App<K, C>,
    store: &'static SceneStore<K, C, S>,
) -> Result<(), AppError> {
    app.load(store, 0)
}

/// Moves the app's object onto object 0 of `store`, the same object reshaped
/// ([`App::reshape`]). Not inlined, as [`load`].
#[inline(never)]
fn reshape<const K: usize, const C: usize, const S: usize>(
    app: &mut App<K, C>,
    store: &'static SceneStore<K, C, S>,
) -> Result<(), AppError> {
    app.reshape(store, 0)
}

/// What a committed store is for: a new scene to load, or the scene with control points
/// moved, for the controller's object in place of its own.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Incoming {
    /// A scene upload: [`TickScenes::swap_in`].
    Scene,
    /// A control-point update: [`TickScenes::reshape_in`].
    Points,
}

/// The link task's validator on its staging half: decodes an upload or an updated scene
/// into the store when the task holds one and no store waits for the tick (`busy`); refuses
/// every scene as [`SceneFault::Busy`] otherwise (nothing changes; the host sends the frame
/// again).
#[derive(Debug)]
pub struct Validator<'a, T> {
    store: Option<&'a mut T>,
}

impl<'a, T> Validator<'a, T> {
    /// The validator of `staging` (`None`: both stores are with the tick), refusing all when
    /// `busy` (a store waits for the tick).
    pub fn new(staging: &'a mut Option<Staging<T>>, busy: bool) -> Self {
        Validator {
            store: staging.as_mut().filter(|_| !busy).map(Staging::get_mut),
        }
    }
}

const BUSY: WireSceneError = WireSceneError {
    object: None,
    patch: None,
    fault: SceneFault::Busy,
};

impl<const K: usize, const C: usize, const S: usize> SceneValidator
    for Validator<'_, SceneStore<K, C, S>>
{
    fn validate(&mut self, scene: &[u8]) -> Result<(), WireSceneError> {
        self.store.as_mut().ok_or(BUSY)?.decode(scene)
    }

    fn validate_reshape(
        &mut self,
        active: &[u8],
        reshaped: &[u8],
        object: u8,
    ) -> Result<(), WireSceneError> {
        self.store
            .as_mut()
            .ok_or(BUSY)?
            .decode_reshaped(active, reshaped, usize::from(object))
    }
}

impl<const K: usize, const C: usize, const S: usize> TickScenes<SceneStore<K, C, S>> {
    /// At a tick boundary with no job out: takes the next committed store from `next` (`None`:
    /// nothing to do) and loads object 0 of it into `app` (the renderer then waits for its
    /// acquisition). Does nothing, not even call `next`, while a job is out, so that the swap
    /// (which builds a chain) never waits on a job's store.
    pub fn swap_in(
        &mut self,
        app: &mut App<K, C>,
        next: impl FnOnce() -> Option<Staging<SceneStore<K, C, S>>>,
    ) -> Option<Swapped<SceneStore<K, C, S>>> {
        if self.job_out {
            return None;
        }
        let new = next()?.publish();
        match load(app, new.get()) {
            Ok(()) => {
                let freed = self.active.replace(new).map(|old| {
                    #[allow(unsafe_code)]
                    // SAFETY: the load replaced the controller's scene, dropping its views of
                    // `old` (`new`'s now); no job reads `old` (`job_out` is false); `new` was
                    // the half's only other `get` and went to the app; and the caller keeps no
                    // copy of a view (`new`'s contract).
                    unsafe {
                        old.reclaim()
                    }
                });
                Some(Swapped {
                    loaded: Ok(()),
                    freed,
                })
            }
            Err(e) => {
                #[allow(unsafe_code)]
                // SAFETY: `App::load` keeps no view of a store it refuses (the chain it built
                // is dropped, the controller's scene is the one before), and the `get` above was
                // the only one of this half since it was published here.
                let staging = unsafe { new.reclaim() };
                Some(Swapped {
                    loaded: Err(e),
                    freed: Some(staging),
                })
            }
        }
    }

    /// At a tick boundary with no job out: takes the next store from `next` (`None`: nothing
    /// to do), the rendered scene with control points of object 0 moved (validated with its
    /// topology by the link), and gives the app object 0 of it in place of its object
    /// ([`App::reshape`]: the renderer carries on). The store rendered before goes back (or
    /// the new one, when the app refused it: no scene loaded, or another topology). Does
    /// nothing, not even call `next`, while a job is out (it reads the store rendered now).
    pub fn reshape_in(
        &mut self,
        app: &mut App<K, C>,
        next: impl FnOnce() -> Option<Staging<SceneStore<K, C, S>>>,
    ) -> Option<Swapped<SceneStore<K, C, S>>> {
        if self.job_out {
            return None;
        }
        let new = next()?.publish();
        match reshape(app, new.get()) {
            Ok(()) => {
                let freed = self.active.replace(new).map(|old| {
                    #[allow(unsafe_code)]
                    // SAFETY: the reshape moved every view of the controller's chain onto
                    // `new` (`Chain::reshape` overwrites all of them, padding included), so
                    // none of `old` is left; no job reads `old` (`job_out` is false); `new`'s
                    // one `get` went to the app; the caller keeps no copy of a view (`new`'s
                    // contract).
                    unsafe {
                        old.reclaim()
                    }
                });
                Some(Swapped {
                    loaded: Ok(()),
                    freed,
                })
            }
            Err(e) => {
                #[allow(unsafe_code)]
                // SAFETY: `App::reshape` keeps no view of a store it refuses (a refused
                // `Chain::reshape` changes nothing: the chain views the store before), and
                // the `get` above was the only one of this half since it was published here.
                let staging = unsafe { new.reclaim() };
                Some(Swapped {
                    loaded: Err(e),
                    freed: Some(staging),
                })
            }
        }
    }

    /// [`TickScenes::swap_in`] or [`TickScenes::reshape_in`], as `incoming` says.
    pub fn take_in(
        &mut self,
        app: &mut App<K, C>,
        incoming: Incoming,
        next: impl FnOnce() -> Option<Staging<SceneStore<K, C, S>>>,
    ) -> Option<Swapped<SceneStore<K, C, S>>> {
        match incoming {
            Incoming::Scene => self.swap_in(app, next),
            Incoming::Points => self.reshape_in(app, next),
        }
    }

    /// The acquisition job for the controller's `request` on the rendered store, when there
    /// is a request and a store and no job is out; from now on the job is out. Give it to
    /// [`run_job`](crate::app::run_job) and its result to [`TickScenes::job_done`], or, if it
    /// could not be sent, back to [`TickScenes::job_refused`].
    pub fn lend_job(
        &mut self,
        request: Option<AcquisitionRequest>,
    ) -> Option<AcquisitionJob<SceneStore<K, C, S>>> {
        if self.job_out {
            return None;
        }
        let (request, active) = (request?, self.active.as_ref()?);
        self.job_out = true;
        Some(AcquisitionJob::new(active.get(), request))
    }

    /// A job [`TickScenes::lend_job`] gave that was never sent: no job is out.
    pub fn job_refused(&mut self, job: AcquisitionJob<SceneStore<K, C, S>>) {
        // Taking the job by value is the proof that no task holds it.
        let _ = job;
        self.job_out = false;
    }

    /// The lent job is over: its acquisition, for `Controller::complete_acquisition` (`None`
    /// when the job's object could not be built).
    pub fn job_done(&mut self, done: JobDone) -> Option<ChainAcquisition> {
        self.job_out = false;
        done.acquisition
    }
}
