//! tlog replay as fast as possible (`tlog:FILE?speed=0`): a big log (the real ArduCopter flight
//! capture repeated end to end, ~500,000 frames, ~23 MB on disk) streamed from the file through
//! `TlogSource` and the frame parser, and through the whole core on the virtual clock (what
//! `--headless --report json` on a tlog link does). Throughput is in frames.

use std::hint::black_box;
use std::io::Write;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use mavterm::app::AppConfig;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::replay::ReplaySpeed;
use mavterm::link::source::{TlogSource, VirtualSource};
use mavterm::link::tlog::{read_tlog, write_record};
use mavterm::link::{FrameParser, LinkSpec};

const FRAMES: u64 = 500_000;

/// Write the big log; its path (in `dir`) and its frame count.
fn big_log(dir: &std::path::Path) -> (std::path::PathBuf, u64) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/copter-flight.vehicle.tlog"
    );
    let recs = read_tlog(&std::fs::read(path).unwrap()).unwrap();
    let t0 = recs[0].time_us;
    let span = recs.last().unwrap().time_us - t0 + 100_000;
    let out = dir.join("big.tlog");
    let mut f = std::io::BufWriter::new(std::fs::File::create(&out).unwrap());
    let mut buf = Vec::new();
    let mut n = 0u64;
    let mut lap = 0u64;
    while n < FRAMES {
        for r in &recs {
            buf.clear();
            write_record(&mut buf, r.time_us + lap * span, &r.frame);
            f.write_all(&buf).unwrap();
            n += 1;
        }
        lap += 1;
    }
    f.flush().unwrap();
    (out, n)
}

fn bench(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let (path, n) = big_log(dir.path());
    let mut g = c.benchmark_group("replay_speed0");
    g.throughput(Throughput::Elements(n));
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(20));

    g.bench_function("tlog_source_and_parser", |b| {
        b.iter(|| {
            let mut src = TlogSource::open(&path)
                .unwrap()
                .with_speed(ReplaySpeed::MAX);
            let mut p = FrameParser::new();
            let mut count = 0u64;
            while src.next_deadline() != u64::MAX {
                let bytes = src.poll(0);
                p.push(&bytes, |f| {
                    count += 1;
                    black_box(&f);
                });
            }
            assert_eq!(count, n);
        })
    });

    let spec: LinkSpec = format!("tlog:{}?speed=0", path.display()).parse().unwrap();
    g.bench_function("tlog_link_through_the_core", |b| {
        b.iter(|| {
            let mut r =
                VirtualRunner::from_specs(std::slice::from_ref(&spec), AppConfig::default())
                    .unwrap();
            assert!(r.run_to_end_of_replays(u64::MAX));
            assert_eq!(r.app.links[0].parser.frames, n);
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
