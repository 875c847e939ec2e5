//! The board's one scene store, handed between the link task (which decodes an upload or an
//! update into it) and the tick (which rebuilds its chain from it), as a unique reference.
//!
//! The store is a static the board's `init` takes once (`&'static mut SceneStore`). The link
//! task holds it while it validates; a committed store goes to the tick through a queue, and
//! the tick, at a tick boundary, rebuilds the app's chain from it in place ([`App::load`]) or
//! moves the chain onto its updated points ([`App::reshape`]), then sends it back. The chain
//! owns its data, so nothing of the store is kept: the link may write the next upload into it
//! at once. Moving the reference is safe Rust (no `unsafe` here, nothing copied), and while
//! the store is with the tick the link has none to write into, so it refuses a commit as
//! [`SceneFault::Busy`] (the host sends it again).

use protocol::{SceneFault, SceneStore, SceneValidator, WireSceneError};

use crate::app::{App, AppError};

/// What a committed store is for: a new scene to load, or the scene with control points
/// moved, for the controller's object in place of its own.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Incoming {
    /// A scene upload: [`App::load`].
    Scene,
    /// A control-point update: [`App::reshape`].
    Points,
}

/// The link task's validator on its store: decodes an upload or an updated scene into the
/// store when the task holds it and no store waits for the tick (`busy`); refuses every
/// scene as [`SceneFault::Busy`] otherwise (nothing changes; the host sends the frame again).
#[derive(Debug)]
pub struct Validator<'a, T> {
    store: Option<&'a mut T>,
}

impl<'a, T> Validator<'a, T> {
    /// The validator of `store` (`None`: it is with the tick), refusing all when `busy` (a
    /// store waits for the tick).
    pub fn new<'s: 'a>(store: &'a mut Option<&'s mut T>, busy: bool) -> Self {
        Validator {
            store: store.as_deref_mut().filter(|_| !busy),
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

/// At a tick boundary: gives the app object 0 of the committed `store`, as a new scene
/// ([`App::load`]) or as its object with control points moved ([`App::reshape`], the
/// renderer carried on). `None` (the store not taken: call again at a later boundary) while
/// the app's object is out with an acquisition job.
pub fn take_in<const K: usize, const C: usize, const S: usize>(
    app: &mut App<'_, K, C>,
    incoming: Incoming,
    store: &SceneStore<K, C, S>,
) -> Option<Result<(), AppError>> {
    if app.job_out() {
        return None;
    }
    Some(match incoming {
        Incoming::Scene => load(app, store),
        Incoming::Points => reshape(app, store),
    })
}

/// [`App::load`] of object 0, not inlined: its frame (the views it rebuilds the chain from)
/// and the tick's do not add up.
#[inline(never)]
fn load<const K: usize, const C: usize, const S: usize>(
    app: &mut App<'_, K, C>,
    store: &SceneStore<K, C, S>,
) -> Result<(), AppError> {
    app.load(store, 0)
}

/// [`App::reshape`] of object 0, not inlined, as [`load`].
#[inline(never)]
fn reshape<const K: usize, const C: usize, const S: usize>(
    app: &mut App<'_, K, C>,
    store: &SceneStore<K, C, S>,
) -> Result<(), AppError> {
    app.reshape(store, 0)
}
