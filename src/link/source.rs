//! In-process links: something that produces and consumes link bytes on a clock it is handed
//! (the simulated vehicle, a tlog replay). The same source runs on the virtual clock of headless
//! replay and, in real time, behind a link task for the terminal.

use std::io::{self, BufReader, Read};
use std::sync::Arc;

use chrono::{DateTime, Utc};

use super::spec::LinkSpec;
use super::tlog::{TlogError, TlogReader, TlogRecord};
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
    /// Bytes of its input the source passed over so far because they made no frames (a damaged
    /// tlog's garbage): the links count them with the parser's garbage bytes.
    fn skipped(&self) -> u64 {
        0
    }
}

/// Builds the source for an in-process link spec; the error is the link's "down" reason. Made by
/// the driver, which knows the simulator; links only run what it builds.
pub type SourceFactory =
    Arc<dyn Fn(&LinkSpec) -> Result<Box<dyn VirtualSource>, String> + Send + Sync>;

/// Replays a tlog, record times relative to the first record, streamed from its reader: only the
/// next record is held (read ahead to know when it is due), so a log of any size replays in
/// constant memory. What the reader skips ([`TlogReader`]) is counted ([`VirtualSource::skipped`]).
pub struct TlogSource {
    reader: TlogReader<Box<dyn Read + Send>>,
    /// The next record to emit; `None` once the log has ended.
    next: Option<TlogRecord>,
    t0: u64,
    /// Records emitted so far.
    emitted: u64,
}

impl std::fmt::Debug for TlogSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TlogSource")
            .field("next", &self.next)
            .field("t0", &self.t0)
            .field("emitted", &self.emitted)
            .field("skipped", &self.reader.skipped())
            .finish()
    }
}

/// Why a tlog replay could not start.
#[derive(Debug, thiserror::Error)]
pub enum TlogOpenError {
    #[error("{0}")]
    Io(#[from] io::Error),
    #[error("{0}")]
    Tlog(#[from] TlogError),
}

impl TlogSource {
    /// Replay the tlog at `path`, read through a buffer as it plays.
    pub fn open(path: impl AsRef<std::path::Path>) -> Result<Self, TlogOpenError> {
        let file = std::fs::File::open(path)?;
        Self::from_reader(BufReader::new(file))
    }

    /// Replay the tlog `r` yields. The first record is read now (its time is the replay's
    /// start); a stream with bytes but not one record is not a tlog ([`TlogError::NoRecords`]).
    pub fn from_reader(r: impl Read + Send + 'static) -> Result<Self, TlogOpenError> {
        let mut reader = TlogReader::new(Box::new(r) as Box<dyn Read + Send>);
        let next = reader.next().transpose()?;
        if next.is_none() && reader.offset() > 0 {
            return Err(TlogError::NoRecords {
                bytes: reader.offset(),
            }
            .into());
        }
        let t0 = next.as_ref().map_or(0, |r| r.time_us);
        Ok(Self {
            reader,
            next,
            t0,
            emitted: 0,
        })
    }

    /// Wall-clock time of the first record.
    pub fn start_time(&self) -> Option<DateTime<Utc>> {
        DateTime::<Utc>::from_timestamp_micros(self.t0 as i64)
            .filter(|_| self.next.is_some() || self.emitted > 0)
    }

    /// Records read from the log and not emitted yet: at most one, however long the log.
    pub fn buffered_records(&self) -> usize {
        usize::from(self.next.is_some())
    }

    /// Bytes of the log held in the reader's buffer.
    pub fn buffered_bytes(&self) -> usize {
        self.reader.buffered_bytes()
    }

    /// Records emitted so far.
    pub fn emitted(&self) -> u64 {
        self.emitted
    }

    /// Read the record after the one just emitted. A read error ends the replay there (the
    /// records before it were good), with a warning: a log on a failing disk plays what it can.
    fn advance(&mut self) {
        self.next = match self.reader.next() {
            Some(Ok(r)) => Some(r),
            Some(Err(e)) => {
                tracing::warn!(offset = self.reader.offset(), "tlog read: {e}");
                None
            }
            None => None,
        };
    }
}

impl VirtualSource for TlogSource {
    fn receive(&mut self, _now: Micros, _bytes: &[u8]) {}
    fn poll(&mut self, now: Micros) -> Vec<u8> {
        let mut out = Vec::new();
        while let Some(r) = &self.next {
            if r.time_us.saturating_sub(self.t0) > now {
                break;
            }
            out.extend_from_slice(&r.frame);
            self.emitted += 1;
            self.advance();
        }
        out
    }
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
    fn next_deadline(&self) -> Micros {
        self.next
            .as_ref()
            .map(|r| r.time_us.saturating_sub(self.t0))
            .unwrap_or(Micros::MAX)
    }
    fn skipped(&self) -> u64 {
        self.reader.skipped().bytes
    }
}
