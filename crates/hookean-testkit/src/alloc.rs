//! A counting global allocator for "allocates nothing" tests.
//!
//! A test binary installs it and counts the allocations of a closure:
//!
//! ```
//! use hookean_testkit::alloc::{Counting, allocations};
//!
//! #[global_allocator]
//! static GLOBAL: Counting = Counting;
//!
//! fn main() {
//!     let (count, v) = allocations(|| vec![0u8; 8]);
//!     assert_eq!((count, v.len()), (1, 8));
//!     let (count, ()) = allocations(|| ());
//!     assert_eq!(count, 0);
//! }
//! ```
//!
//! The count is per thread, so tests running in parallel do not disturb
//! each other.

// A global allocator needs unsafe; this one only forwards to `System`.
#![allow(unsafe_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

/// Forwards to [`System`] and counts `alloc` and `realloc` calls of the
/// current thread.
pub struct Counting;

thread_local! {
    static COUNT: Cell<usize> = const { Cell::new(0) };
}

// SAFETY: every method forwards to `System` with the caller's arguments;
// counting touches only a thread-local `Cell`, which does not allocate.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        COUNT.with(|c| c.set(c.get() + 1));
        // SAFETY: the caller's contract for `alloc` is passed on unchanged.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System` through this allocator.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        COUNT.with(|c| c.set(c.get() + 1));
        // SAFETY: as for `dealloc`, and the caller's contract for `realloc`.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Runs `f` and returns how many allocations it made on this thread (0
/// unless [`Counting`] is the global allocator) with its result.
pub fn allocations<R>(f: impl FnOnce() -> R) -> (usize, R) {
    let before = COUNT.with(|c| c.get());
    let r = f();
    (COUNT.with(|c| c.get()) - before, r)
}
