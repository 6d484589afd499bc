//! The counting global allocator: per thread, the bytes allocated and their
//! peak, and a cap on single allocations on fuzzing threads.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

/// The system allocator, counting per thread the bytes allocated and their
/// peak (const-initialised `Cell`s: no allocation, no destructor).
struct CountingAllocator;

thread_local! {
    static CURRENT: Cell<isize> = const { Cell::new(0) };
    static PEAK: Cell<isize> = const { Cell::new(0) };
    /// Set on fuzzing threads: single allocations above `ONE_ALLOCATION_CAP`
    /// are refused there.
    static GUARDED: Cell<bool> = const { Cell::new(false) };
}

const ONE_ALLOCATION_CAP: usize = 1 << 30;

fn note(delta: isize) {
    let _ = CURRENT.try_with(|current| {
        let now = current.get() + delta;
        current.set(now);
        let _ = PEAK.try_with(|peak| peak.set(peak.get().max(now)));
    });
}

fn refused(size: usize) -> bool {
    if size <= ONE_ALLOCATION_CAP || !GUARDED.try_with(Cell::get).unwrap_or(false) {
        return false;
    }
    let message: &[u8] = b"fuzz_readers: a reader asked for more than 1 GiB in one allocation; its input is the \
        case file in the newest penumbra-fuzz-* folder of the temporary directory\n";
    let _ = std::io::Write::write_all(&mut std::io::stderr(), message);
    true
}

// SAFETY: every call is forwarded to `System` unchanged (or refused with a
// null pointer, which `GlobalAlloc` allows); the bookkeeping allocates nothing.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if refused(layout.size()) {
            return std::ptr::null_mut();
        }
        // SAFETY: the caller's contract, forwarded.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            note(layout.size() as isize);
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if refused(layout.size()) {
            return std::ptr::null_mut();
        }
        // SAFETY: the caller's contract, forwarded.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            note(layout.size() as isize);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: the caller's contract, forwarded.
        unsafe { System.dealloc(ptr, layout) };
        note(-(layout.size() as isize));
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if refused(new_size) {
            return std::ptr::null_mut();
        }
        // SAFETY: the caller's contract, forwarded.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            // Counted as a move: old and new block at once.
            note(new_size as isize);
            note(-(layout.size() as isize));
        }
        p
    }
}

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

/// `f`'s result and the peak bytes this thread held above its level at the
/// start while `f` ran.
pub fn measured<R>(f: impl FnOnce() -> R) -> (R, usize) {
    let base = CURRENT.with(Cell::get);
    PEAK.with(|peak| peak.set(base));
    let result = f();
    let peak = PEAK.with(Cell::get) - base;
    (result, peak.max(0) as usize)
}

/// Marks this thread as a fuzzing thread: single allocations above
/// `ONE_ALLOCATION_CAP` are refused on it.
pub fn guard_this_thread() {
    GUARDED.with(|g| g.set(true));
}
