//! Nothing is allocated per frame: the real flight capture through the whole pipeline (framing,
//! decode, counting, routing, every machine of the vehicle's session), counted by a counting
//! global allocator. The first pass learns the vehicle (its session, its 1,397 parameter values,
//! its message table); the second pass of the same frames is the steady state, where what is
//! allocated is per batch (the batch's frame vector, the core's effects), per STATUSTEXT (its
//! notice) and per heartbeat, never per frame.
//!
//! The only test in this binary, so no other test allocates while it counts.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicU64, Ordering};

use mavterm::app::AppConfig;

mod ingest_fixture;
use ingest_fixture::Pipeline;

struct Counting;

static ALLOCATIONS: AtomicU64 = AtomicU64::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn the_steady_state_allocates_per_batch_not_per_frame() {
    let (bytes, _) = ingest_fixture::flight();
    let mut p = Pipeline::new(AppConfig::default());
    let pass = |p: &mut Pipeline| -> (u64, u64, u64) {
        let (a0, f0, b0) = (ALLOCATIONS.load(Ordering::Relaxed), p.frames(), p.batches);
        p.feed(&bytes);
        (
            ALLOCATIONS.load(Ordering::Relaxed) - a0,
            p.frames() - f0,
            p.batches - b0,
        )
    };
    let (first, frames, _) = pass(&mut p);
    assert_eq!(
        frames, 11_648,
        "the capture's frames (pymavlink counts 11,648)"
    );
    let (steady, frames, batches) = pass(&mut p);
    assert_eq!(frames, 11_648);
    // What may allocate in the steady state: each batch (its frame vector and a few effects),
    // each STATUSTEXT (41: its notice and its line) and each HEARTBEAT (88). Allowing 8 a
    // batch and 8 for each of those still fails at one allocation per frame.
    let statustexts = 41;
    let heartbeats = 88;
    let allowed = 8 * (batches + statustexts + heartbeats);
    assert!(
        steady <= allowed && allowed < frames,
        "{steady} allocations for {frames} frames in {batches} batches (first pass {first})"
    );
    println!("steady state: {steady} allocations for {frames} frames in {batches} batches; first pass {first}");
}
