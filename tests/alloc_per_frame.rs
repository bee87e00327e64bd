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

use mavterm::app::{App, AppConfig, Event};
use mavterm::link::tlog::read_tlog;
use mavterm::link::{FrameParser, ParserStats};

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
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/copter-flight.vehicle.tlog"
    );
    let bytes: Vec<u8> = read_tlog(&std::fs::read(path).unwrap())
        .unwrap()
        .into_iter()
        .flat_map(|r| r.frame.to_vec())
        .collect();
    let mut app = App::new(AppConfig {
        links: vec!["capture".into()],
        ..AppConfig::default()
    });
    let mut p = FrameParser::new();
    let mut reported = ParserStats::default();
    let mut t = 0u64;
    let mut pass = |app: &mut App| -> (u64, u64, u64) {
        let (a0, f0) = (
            ALLOCATIONS.load(Ordering::Relaxed),
            app.links[0].parser.frames,
        );
        let mut batches = 0;
        for chunk in bytes.chunks(4096) {
            let mut frames = p.frame_vec(chunk.len());
            p.push_into(chunk, &mut frames);
            let total = *p.stats();
            let stats = total.since(&reported);
            reported = total;
            t += 1_000;
            let fx = app.update(
                t,
                Event::Frames {
                    link: 0,
                    frames,
                    stats,
                },
            );
            drop(fx);
            batches += 1;
        }
        (
            ALLOCATIONS.load(Ordering::Relaxed) - a0,
            app.links[0].parser.frames - f0,
            batches,
        )
    };
    let (first, frames, _) = pass(&mut app);
    assert_eq!(
        frames, 11_648,
        "the capture's frames (pymavlink counts 11,648)"
    );
    let (steady, frames, batches) = pass(&mut app);
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
