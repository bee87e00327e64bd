//! The ingest benchmark's three workloads, run a given number of times, for instruction counts:
//! `valgrind --tool=callgrind target/release/examples/ingest_profile full 3` (or `crate`,
//! `framing`). Instructions per frame: the difference between two repeat counts over the
//! difference in frames (this leaves out loading the capture). It also prints the fastest pass's
//! time; `compare N` alternates the full pipeline and the crate reader N times and gives the
//! ratio of their fastest passes.

use std::hint::black_box;

use mavterm::app::AppConfig;
use mavterm::dialect::MavMessage;
use mavterm::link::FrameParser;

#[path = "../tests/ingest_fixture/mod.rs"]
mod ingest_fixture;
use ingest_fixture::{capture, Pipeline};

fn full(bytes: &[u8], n: u64) {
    let mut p = Pipeline::new(AppConfig::default());
    p.feed(bytes);
    assert_eq!(p.frames(), n);
}

fn framing(bytes: &[u8], n: u64) {
    let mut p = FrameParser::new();
    let mut count = 0u64;
    for chunk in bytes.chunks(4096) {
        p.push(chunk, |f| {
            count += 1;
            black_box(&f);
        });
    }
    assert_eq!(count, n);
}

fn crate_reader(bytes: &[u8], n: u64) {
    let mut r = mavlink::MavlinkReader::new(bytes);
    let mut count = 0u64;
    while let Ok((h, m)) = r.read_any_message::<MavMessage>() {
        black_box((h, m));
        count += 1;
    }
    assert_eq!(count, n);
}

/// The full pipeline and the crate reader in alternate passes (so a machine whose speed drifts
/// slows both alike): each one's fastest pass, and their ratio.
fn compare(bytes: &[u8], n: u64, times: u32) {
    let (mut full_best, mut crate_best) = (f64::MAX, f64::MAX);
    for _ in 0..times {
        let t = std::time::Instant::now();
        full(bytes, n);
        full_best = full_best.min(t.elapsed().as_secs_f64());
        let t = std::time::Instant::now();
        crate_reader(bytes, n);
        crate_best = crate_best.min(t.elapsed().as_secs_f64());
    }
    println!(
        "fastest of {times}: full pipeline {:.2} ms, crate reader {:.2} ms: {:.2}x the crate's pace",
        full_best * 1e3,
        crate_best * 1e3,
        crate_best / full_best
    );
}

fn main() {
    let mut args = std::env::args().skip(1);
    let what = args.next().unwrap_or_else(|| "full".into());
    let times: u32 = args.next().map_or(1, |s| s.parse().unwrap());
    let (bytes, n) = capture();
    if what == "compare" {
        compare(&bytes, n, times);
        return;
    }
    let run: fn(&[u8], u64) = match what.as_str() {
        "full" => full,
        "framing" => framing,
        "crate" => crate_reader,
        other => panic!("unknown workload {other}"),
    };
    // The fastest pass, for a quick comparison between builds (criterion gives the spread).
    let mut best = std::time::Duration::MAX;
    let start = std::time::Instant::now();
    for _ in 0..times {
        let t = std::time::Instant::now();
        run(&bytes, n);
        best = best.min(t.elapsed());
        if std::env::var_os("PASSES").is_some() {
            eprint!("{:.1} ", t.elapsed().as_secs_f64() * 1e3);
        }
    }
    println!(
        "{what}: {times} x {n} frames, fastest {:.2} ms, mean {:.2} ms",
        best.as_secs_f64() * 1e3,
        start.elapsed().as_secs_f64() * 1e3 / times.max(1) as f64
    );
}
