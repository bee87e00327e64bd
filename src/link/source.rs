//! In-process links: something that produces and consumes link bytes on a clock it is handed
//! (the simulated vehicle, a tlog replay). The same source runs on the virtual clock of headless
//! replay and, in real time, behind a link task for the terminal.

use std::sync::Arc;

use chrono::{DateTime, Utc};

use super::spec::LinkSpec;
use super::tlog::TlogRecord;
use crate::clock::Micros;

/// Produces and consumes link bytes on a clock it is handed.
pub trait VirtualSource: Send {
    /// Bytes sent to the source at `now`.
    fn receive(&mut self, now: Micros, bytes: &[u8]);
    /// Bytes the source emits that are due by `now`.
    fn poll(&mut self, now: Micros) -> Vec<u8>;
    /// When the source next has something to emit (`Micros::MAX` for never).
    fn next_deadline(&self) -> Micros;
    /// For tests that look at a source's own truth (e.g. the sim's impairment counts).
    fn as_any(&self) -> &dyn std::any::Any;
}

/// Builds the source for an in-process link spec; the error is the link's "down" reason. Made by
/// the driver, which knows the simulator; links only run what it builds.
pub type SourceFactory =
    Arc<dyn Fn(&LinkSpec) -> Result<Box<dyn VirtualSource>, String> + Send + Sync>;

/// Replays a tlog, record times relative to the first record.
#[derive(Debug)]
pub struct TlogSource {
    records: Vec<TlogRecord>,
    next: usize,
    t0: u64,
}

impl TlogSource {
    pub fn new(records: Vec<TlogRecord>) -> Self {
        let t0 = records.first().map(|r| r.time_us).unwrap_or(0);
        Self {
            records,
            next: 0,
            t0,
        }
    }
    /// Wall-clock time of the first record.
    pub fn start_time(&self) -> Option<DateTime<Utc>> {
        DateTime::<Utc>::from_timestamp_micros(self.t0 as i64).filter(|_| !self.records.is_empty())
    }
}

impl VirtualSource for TlogSource {
    fn receive(&mut self, _now: Micros, _bytes: &[u8]) {}
    fn poll(&mut self, now: Micros) -> Vec<u8> {
        let mut out = Vec::new();
        while let Some(r) = self.records.get(self.next) {
            if r.time_us.saturating_sub(self.t0) > now {
                break;
            }
            out.extend_from_slice(&r.frame);
            self.next += 1;
        }
        out
    }
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
    fn next_deadline(&self) -> Micros {
        self.records
            .get(self.next)
            .map(|r| r.time_us.saturating_sub(self.t0))
            .unwrap_or(Micros::MAX)
    }
}
