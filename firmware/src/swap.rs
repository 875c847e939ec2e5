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
//!   promises that every reference [`Published::get`] gave out is dead. The board's tick calls
//!   it only after the controller dropped its views (a new scene was loaded in its place) and
//!   no other task holds one (no acquisition on that store is in flight).
//!
//! So a half is either written through its one `Staging` or read through `&T`s, never both.

use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicBool, Ordering};

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
