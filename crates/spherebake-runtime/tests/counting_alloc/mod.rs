//! The counting global allocator of the allocation tests (`light_alloc`, `shadow_alloc`), one copy.
//!
//! It counts the allocations (and reallocations) of the *calling thread* only. A process-wide
//! counter flakes: the test harness runs tests on worker threads while its main thread allocates
//! (it records each spawned test, collects results and prints), so under load another thread's
//! allocation can land between a test's `before` and `after` (issue 16: `shadow_alloc` failed in
//! full-workspace runs and passed alone). The runtime spawns no threads (no `rayon`, no std
//! threads: see docs/ARCHITECTURE.md), so everything a runtime call allocates is allocated on the
//! thread that calls it, and a per-thread count misses nothing it must see.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;

thread_local! {
    // `const` and no destructor: reading it never allocates, and it is valid at any time.
    static ALLOCS: Cell<usize> = const { Cell::new(0) };
}

fn count() {
    // `try_with`: the slot may be gone while a thread is torn down.
    let _ = ALLOCS.try_with(|c| c.set(c.get() + 1));
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Allocations made so far by the calling thread.
pub fn allocs() -> usize {
    ALLOCS.with(Cell::get)
}

#[test]
fn the_counter_sees_this_threads_allocations_and_only_those() {
    // The zero counts of the tests mean something: an allocation, a zeroed allocation and a
    // growth of this thread are each seen ...
    let before = allocs();
    let mut v: Vec<u64> = std::hint::black_box(Vec::with_capacity(7));
    assert_eq!(allocs(), before + 1);
    v.reserve_exact(1000);
    assert_eq!(allocs(), before + 2);
    let z: Vec<u8> = std::hint::black_box(vec![0u8; 4096]);
    assert_eq!(allocs(), before + 3);
    drop((v, z));
    // ... and another thread's allocations are not (what made the process-wide counter flaky).
    let before = allocs();
    let other = std::thread::spawn(|| {
        let start = allocs();
        let b: Vec<Box<u32>> = (0..100).map(Box::new).collect();
        std::hint::black_box(&b);
        allocs() - start
    });
    let theirs = other.join().unwrap();
    assert!(theirs >= 101, "the other thread counted {theirs} of its own allocations");
    // Spawning and joining allocate a few on this thread (the handle); a process-wide count
    // would add the other thread's on top.
    let mine = allocs() - before;
    assert!(mine < theirs, "{mine} allocations counted on this thread, {theirs} on the other");
}
