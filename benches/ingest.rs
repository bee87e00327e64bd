//! Ingest throughput: a capture of ~100,000 mixed frames (the real ArduCopter flight capture,
//! repeated) through mavterm's framing, decode, statistics and vehicle registry, beside the bare
//! `mavlink` crate reader on the same bytes.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use mavterm::app::{App, AppConfig, Event};
use mavterm::dialect::MavMessage;
use mavterm::link::tlog::read_tlog;
use mavterm::link::{FrameParser, ParserStats};

fn capture() -> (Vec<u8>, u64) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/copter-flight.vehicle.tlog"
    );
    let recs = read_tlog(&std::fs::read(path).unwrap()).unwrap();
    let mut bytes = Vec::new();
    let mut n = 0u64;
    while n < 100_000 {
        for r in &recs {
            bytes.extend_from_slice(&r.frame);
            n += 1;
        }
    }
    (bytes, n)
}

fn bench(c: &mut Criterion) {
    let (bytes, n) = capture();
    let mut g = c.benchmark_group("ingest");
    g.throughput(Throughput::Elements(n));
    g.sample_size(10);

    g.bench_function("mavterm_framing_decode", |b| {
        b.iter(|| {
            let mut p = FrameParser::new();
            let mut count = 0u64;
            for chunk in bytes.chunks(4096) {
                p.push(chunk, |f| {
                    count += 1;
                    black_box(&f);
                });
            }
            assert_eq!(count, n);
        })
    });

    g.bench_function("mavterm_full_pipeline", |b| {
        b.iter(|| {
            let mut app = App::new(AppConfig {
                links: vec!["bench".into()],
                ..AppConfig::default()
            });
            let mut p = FrameParser::new();
            let mut reported = ParserStats::default();
            let mut t = 0u64;
            for chunk in bytes.chunks(4096) {
                let mut frames = Vec::new();
                p.push(chunk, |f| frames.push(f));
                let total = *p.stats();
                let stats = total.since(&reported);
                reported = total;
                t += 1_000;
                black_box(app.update(
                    t,
                    Event::Frames {
                        link: 0,
                        frames,
                        stats,
                    },
                ));
            }
            assert_eq!(app.links[0].parser.frames, n);
        })
    });

    g.bench_function("mavlink_crate_reader", |b| {
        b.iter(|| {
            let mut r = mavlink::MavlinkReader::new(&bytes[..]);
            let mut count = 0u64;
            while let Ok((h, m)) = r.read_any_message::<MavMessage>() {
                black_box((h, m));
                count += 1;
            }
            assert_eq!(count, n);
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
