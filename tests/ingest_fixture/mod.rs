//! The ingest workload shared by `benches/ingest.rs`, `examples/ingest_profile.rs` and
//! `tests/alloc_per_frame.rs`: the real flight capture's frames, and the core fed them as a link
//! task hands them over (4 KiB reads, each one `Event::Frames` a millisecond after the last).

#![allow(dead_code)] // each user takes what it needs

use mavterm::app::{App, AppConfig, Event};
use mavterm::link::tlog::read_tlog;
use mavterm::link::{FrameParser, ParserStats};

/// The bytes of the real ArduCopter flight capture's frames, once, and how many frames.
pub fn flight() -> (Vec<u8>, u64) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/copter-flight.vehicle.tlog"
    );
    let recs = read_tlog(&std::fs::read(path).unwrap()).unwrap();
    let bytes = recs.iter().flat_map(|r| r.frame.iter().copied()).collect();
    (bytes, recs.len() as u64)
}

/// The flight repeated to at least 100,000 frames, and how many that is.
pub fn capture() -> (Vec<u8>, u64) {
    let (once, per) = flight();
    let (mut bytes, mut n) = (Vec::new(), 0u64);
    while n < 100_000 {
        bytes.extend_from_slice(&once);
        n += per;
    }
    (bytes, n)
}

/// The core on one link, fed bytes as its link task would.
pub struct Pipeline {
    pub app: App,
    parser: FrameParser,
    reported: ParserStats,
    t: u64,
    /// `Event::Frames` handed to the core so far.
    pub batches: u64,
}

impl Pipeline {
    pub fn new(cfg: AppConfig) -> Self {
        Pipeline {
            app: App::new(AppConfig {
                links: vec!["capture".into()],
                ..cfg
            }),
            parser: FrameParser::lazy(),
            reported: ParserStats::default(),
            t: 0,
            batches: 0,
        }
    }

    /// `bytes` in 4 KiB reads, each read's frames one `Event::Frames`.
    pub fn feed(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(4096) {
            let mut frames = self.parser.frame_vec(chunk.len());
            self.parser.push_into(chunk, &mut frames);
            let total = *self.parser.stats();
            let stats = total.since(&self.reported);
            self.reported = total;
            self.t += 1_000;
            std::hint::black_box(self.app.update(
                self.t,
                Event::Frames {
                    link: 0,
                    frames,
                    stats,
                },
            ));
            self.batches += 1;
        }
    }

    /// Frames the link has counted.
    pub fn frames(&self) -> u64 {
        self.app.links[0].parser.frames
    }
}
