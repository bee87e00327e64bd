//! Recording and forwarding throughput: ~100,000 parsed frames (the real ArduCopter flight
//! capture, repeated, in the batches a link hands on per 4 KiB read) through the driver's tap,
//! as the real-time loop runs it: every frame appended to the tlog batch and forwarded to two
//! outputs (their bounded queues drained as the output tasks would), each batch handed to the
//! tlog writer thread. Apart: the writer thread's own work (the batches written to a file) and
//! the whole path end to end (the tap, then waiting until the writer has written and flushed
//! everything). Sockets are left out: the output tasks' writes are the kernel's cost.

use std::hint::black_box;
use std::io::Write;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use mavterm::driver::forward::Forwarder;
use mavterm::driver::record::{Recorder, TlogTarget};
use mavterm::link::tlog::{read_tlog, write_record};
use mavterm::link::transport::OUT_QUEUE;
use mavterm::link::{Frame, FrameParser, LinkSpec, LinkState};

/// The capture's frames, repeated to at least 100,000, in per-read batches.
fn batches() -> (Vec<Vec<Frame>>, u64) {
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
    let mut p = FrameParser::new();
    let mut out = Vec::new();
    for chunk in bytes.chunks(4096) {
        let mut frames = Vec::new();
        p.push_into(chunk, &mut frames);
        out.push(frames);
    }
    let total = out.iter().map(Vec::len).sum::<usize>() as u64;
    assert_eq!(total, n);
    (out, n)
}

/// An output task's queue: the forwarder's end and the task's.
type Queue = (
    tokio::sync::mpsc::Sender<Vec<u8>>,
    tokio::sync::mpsc::Receiver<Vec<u8>>,
);

/// Two outputs that are up, with the queues their tasks read from.
struct Outputs {
    fwd: Forwarder,
    queues: Vec<Queue>,
}

impl Outputs {
    fn new() -> Self {
        let specs: Vec<LinkSpec> = ["udpout:127.0.0.1:14550", "tcpin:0.0.0.0:5760"]
            .iter()
            .map(|s| s.parse().unwrap())
            .collect();
        let mut fwd = Forwarder::new(&specs);
        for i in 0..specs.len() {
            fwd.output_state(i, LinkState::Up);
        }
        let queues = specs
            .iter()
            .map(|_| tokio::sync::mpsc::channel(OUT_QUEUE))
            .collect();
        Self { fwd, queues }
    }

    /// One link read's frames to every output; then the output tasks take what is queued.
    fn forward(&mut self, frames: &[Frame]) {
        let queues = &self.queues;
        self.fwd
            .from_vehicles(0, frames, |o, bytes| queues[o].0.try_send(bytes).is_ok());
        for (_, rx) in &mut self.queues {
            while let Ok(b) = rx.try_recv() {
                black_box(b);
            }
        }
    }
}

/// The tap's work on the loop thread for every batch: record, forward, hand the batch on.
fn tap(rec: &mut Recorder, outs: &mut Outputs, batches: &[Vec<Frame>]) {
    let mut wall = 1_767_268_800_000_000u64;
    for frames in batches {
        wall += 1_000;
        for f in frames {
            rec.record(wall, &f.raw);
        }
        outs.forward(frames);
        // A step a millisecond: batches go as they are due (a quarter second or 16 KiB).
        rec.end_step(wall);
    }
    rec.hand_over();
}

/// A recorder on an empty `path` (the last iteration's log removed: the disk stays free).
fn fresh(path: &std::path::Path, start: chrono::NaiveDateTime) -> Recorder {
    let _ = std::fs::remove_file(path);
    Recorder::start(&TlogTarget::File(path.into()), start).unwrap()
}

fn bench(c: &mut Criterion) {
    let (batches, n) = batches();
    let dir = tempfile::tempdir().unwrap();
    let start = chrono::NaiveDate::from_ymd_opt(2026, 1, 1)
        .unwrap()
        .and_hms_opt(0, 0, 0)
        .unwrap();
    let log = dir.path().join("bench.tlog");
    let mut g = c.benchmark_group("record_forward");
    g.throughput(Throughput::Elements(n));
    g.sample_size(10);

    // The loop thread's part. The writer thread, on the other core, may fall behind a loop
    // running this fast and lose batches (counted); the loop's cost is the same either way.
    g.bench_function("tap_record_and_forward_to_2", |b| {
        let mut outs = Outputs::new();
        b.iter_batched(
            || fresh(&log, start),
            |mut rec| {
                tap(&mut rec, &mut outs, &batches);
                rec
            },
            BatchSize::PerIteration,
        )
    });

    // The writer thread's part: the batches written to a file through its buffer.
    let written: Vec<Vec<u8>> = batches
        .iter()
        .map(|frames| {
            let mut b = Vec::new();
            for f in frames {
                write_record(&mut b, 1, &f.raw);
            }
            b
        })
        .collect();
    g.bench_function("writer_to_file", |b| {
        let path = dir.path().join("writer.tlog");
        b.iter(|| {
            let f = std::fs::File::create(&path).unwrap();
            let mut w = std::io::BufWriter::with_capacity(64 * 1024, f);
            for batch in &written {
                w.write_all(batch).unwrap();
            }
            w.flush().unwrap();
        })
    });

    // Both, end to end: the tap, then the writer done (everything written and flushed).
    g.bench_function("end_to_end_until_flushed", |b| {
        let mut outs = Outputs::new();
        b.iter_batched(
            || fresh(&log, start),
            |mut rec| {
                tap(&mut rec, &mut outs, &batches);
                let st = rec.finish();
                assert_eq!(st.error, None);
                black_box(st.dropped);
                rec
            },
            BatchSize::PerIteration,
        )
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
