//! The `hookean` binary's global allocator: [`System`], counting the bytes
//! live, so `hookean bench` can report what each preconditioner keeps after
//! its set-up exactly (the resident set cannot tell: the C allocator keeps
//! freed memory for reuse). Two relaxed atomic additions per allocation;
//! the solvers' hot loops do not allocate.
//!
//! A global allocator needs `unsafe`; this one only forwards to `System`.
#![allow(unsafe_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Forwards to [`System`] and counts the bytes live.
pub struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
/// Set once [`Counting`] has served an allocation: the counts mean something.
static ACTIVE: AtomicBool = AtomicBool::new(false);

// SAFETY: every method forwards to `System` with the caller's arguments;
// the bookkeeping touches only atomics and never allocates.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's contract for `alloc` is passed on unchanged.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            LIVE.fetch_add(layout.size(), Ordering::Relaxed);
            ACTIVE.store(true, Ordering::Relaxed);
        }
        p
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: as for `alloc`.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            LIVE.fetch_add(layout.size(), Ordering::Relaxed);
            ACTIVE.store(true, Ordering::Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System` through this allocator.
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: as for `dealloc`, and the caller's contract for `realloc`.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            LIVE.fetch_add(new_size, Ordering::Relaxed);
            LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        }
        p
    }
}

/// The bytes live on the heap, when [`Counting`] is the global allocator
/// (the `hookean` binary); `None` otherwise (e.g. in unit tests).
pub fn live_bytes() -> Option<usize> {
    ACTIVE
        .load(Ordering::Relaxed)
        .then(|| LIVE.load(Ordering::Relaxed))
}
