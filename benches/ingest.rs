//! Ingest throughput: a capture of ~100,000 mixed frames (the real ArduCopter flight capture,
//! repeated) through mavterm's framing, decode, statistics and vehicle registry, beside the bare
//! `mavlink` crate reader on the same bytes; and the parser alone on adversarial input (garbage
//! one bad peer could send), which must not cost more than a bounded amount of work per byte.

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use mavterm::app::AppConfig;
use mavterm::dialect::MavMessage;
use mavterm::link::FrameParser;

#[path = "../tests/ingest_fixture/mod.rs"]
mod ingest_fixture;
use ingest_fixture::{capture, Pipeline};

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
            let mut p = Pipeline::new(AppConfig::default());
            p.feed(&bytes);
            assert_eq!(p.frames(), n);
        })
    });

    // The same messages as signed MAVLink 2 frames, through a core holding the key: every
    // signature checked (SHA-256 per frame) and every stream's timestamp kept.
    let key = mavterm::wire::signing::SecretKey::from_passphrase("bench");
    let (signed, signed_n) = signed_capture(&bytes, &key);
    g.bench_function("mavterm_full_pipeline_signed", |b| {
        b.iter(|| {
            let mut p = Pipeline::new(AppConfig {
                signing: Some(mavterm::app::signing::SigningConfig {
                    key: key.clone(),
                    allow_unsigned_heartbeat: false,
                    state_path: None,
                    saved_timestamp: 0,
                    saved_at: None,
                }),
                ..AppConfig::default()
            });
            p.feed(&signed);
            assert_eq!(p.frames(), signed_n);
            let app = &p.app;
            let rejected: u64 = app.links[0]
                .sources
                .values()
                .map(|s| s.signing.rejected)
                .sum();
            assert_eq!(rejected, 0);
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

/// Every frame of `bytes` as a signed MAVLink 2 frame (same header, same message), timestamps
/// counting up from 1.
fn signed_capture(bytes: &[u8], key: &mavterm::wire::signing::SecretKey) -> (Vec<u8>, u64) {
    use mavlink::Message;
    use mavterm::wire::frame::{encode, Header, Version};
    let mut out = Vec::new();
    let mut ts = 0u64;
    let mut p = FrameParser::new();
    p.push(bytes, |f| {
        let Some(msg) = f.message.as_ref() else {
            return;
        };
        let header = Header {
            sysid: f.sysid,
            compid: f.compid,
            seq: f.seq,
        };
        let mut frame = encode(Version::V2, header, msg);
        ts += 1;
        let extra = MavMessage::extra_crc(msg.message_id());
        mavterm::wire::signing::sign_frame(&mut frame, extra, key, 0, ts);
        out.extend_from_slice(&frame);
    });
    (out, ts)
}

/// Repeat `unit` to `len` bytes.
fn repeat(unit: &[u8], len: usize) -> Vec<u8> {
    unit.iter().copied().cycle().take(len).collect()
}

/// Inputs a broken or hostile peer can send, each 64 KiB.
fn adversarial() -> Vec<(&'static str, Vec<u8>)> {
    const LEN: usize = 64 * 1024;
    // Random bytes, a third of them magic bytes.
    let mut rng = 0x2545_F491_4F6C_DD1Du64;
    let mut random = Vec::with_capacity(LEN);
    while random.len() < LEN {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        random.push(match rng % 3 {
            0 => 0xFD,
            1 => 0xFE,
            _ => (rng >> 32) as u8,
        });
    }
    vec![
        ("all_fe", vec![0xFE; LEN]),
        ("all_fd", vec![0xFD; LEN]),
        // MAVLink 1 FILE_TRANSFER_PROTOCOL headers (254-byte payload, the largest a v1 frame of
        // a known id can carry) every 6 bytes: each claims a 262-byte frame whose CRC fails.
        (
            "fake_v1_ftp_headers",
            repeat(&[0xFE, 254, 0, 1, 1, 110], LEN),
        ),
        // The densest known-id candidates with long payloads: at every other byte a MAVLink 1
        // V2_EXTENSION (id 248, up to 254 bytes) claiming 248 bytes, each CRC failing.
        ("fake_v1_headers_every_2_bytes", repeat(&[0xFE, 248], LEN)),
        // MAVLink 2 headers of an unknown id claiming a 255-byte payload, every 10 bytes.
        (
            "fake_v2_unknown_headers",
            repeat(&[0xFD, 255, 0, 0, 0, 1, 1, 0xEF, 0xBE, 0x00], LEN),
        ),
        // MAVLink 2 HEARTBEAT-sized frames with a wrong CRC, back to back.
        (
            "bad_crc_heartbeats",
            repeat(
                &[
                    0xFD, 9, 0, 0, 0, 1, 1, 0, 0, 0, 0, 0, 0, 0, 2, 3, 81, 3, 3, 0xAA, 0xBB,
                ],
                LEN,
            ),
        ),
        ("random_magic_rich", random),
    ]
}

fn bench_adversarial(c: &mut Criterion) {
    let mut g = c.benchmark_group("ingest_garbage");
    g.sample_size(10);
    g.warm_up_time(Duration::from_millis(500));
    g.measurement_time(Duration::from_secs(2));
    for (name, bytes) in adversarial() {
        g.throughput(Throughput::Bytes(bytes.len() as u64));
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut p = FrameParser::new();
                let mut count = 0u64;
                for chunk in bytes.chunks(4096) {
                    p.push(chunk, |f| {
                        count += 1;
                        black_box(&f);
                    });
                }
                p.end_of_datagram(|_| count += 1);
                black_box(count)
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench, bench_adversarial);
criterion_main!(benches);
