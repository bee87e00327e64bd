//! Onboard logs (DataFlash `.bin`, ULog `.ulg`) over the MAVLink log protocol: the list
//! (LOG_REQUEST_LIST → LOG_ENTRY), downloads (LOG_REQUEST_DATA → LOG_DATA, LOG_REQUEST_END)
//! and erase (LOG_ERASE), sans I/O.
//!
//! How the vehicle answers (ArduPilot `AP_Logger_MAVLinkLogTransfer.cpp`):
//! - A list request (`start`, `end`) is answered with one LOG_ENTRY per id from `start` (at
//!   least 1) to `end` (at most the number of logs), each carrying `num_logs` and
//!   `last_log_num` (the last id of that listing); no log at all is one LOG_ENTRY with id 0 and
//!   `num_logs` 0. PX4 numbers its logs from 0: the first id is `last_log_num + 1 - num_logs`
//!   for both.
//! - A data request (`id`, `ofs`, `count`) is answered with LOG_DATA of 90 bytes (`count` is
//!   less only at the end of the log: 0 past it) from `ofs` until `count` bytes went out; a
//!   request that comes while one is being answered is dropped ("Log download in progress"),
//!   so this machine has one request out at a time and asks the next the moment the last chunk
//!   of the one before arrives (or, when that chunk was lost, after the wait the measured round
//!   trip and rate give).
//! - LOG_REQUEST_END ends the transfer; ArduPilot does not log while a download runs.
//!
//! The transfer: requests of new data in windows that grow while the loss they see stays at
//! what the link usually loses and shrink when it jumps above that (the radio's buffer
//! overflowing) or passes half ([`Transfer::adapt`]); what the vehicle skipped (a later
//! offset came first) is a gap, and gaps are asked again with the next request, before new
//! data, neighbouring gaps (and the new window after them) merged into one request when what
//! lies between them costs less to receive again, at the pace the vehicle sends, than a round
//! trip. A request's wait is its measured round trip (smoothed, with its variation, backed off
//! while nothing comes) until its first chunk, then the measured time per chunk for the rest
//! ([`Transfer::deadline`]). Data is
//! kept in memory only beyond the contiguous prefix (bounded); the prefix goes to the file as
//! [`LogIo::Write`] (the driver writes it into `NAME.partial`), so what is on disk is always a
//! prefix of the log and a download resumes from its size. Done when the prefix is the size
//! LOG_ENTRY gave: the partial is renamed ([`LogIo::Finish`]). The partial belongs to one log:
//! its identity (vehicle, id, time, size) is kept beside it ([`LogIo::Open`]'s `tag`), and a
//! partial of another log (the same id after an erase) is started over, never appended to.
//!
//! Routes: what the operator asked on a high-latency link (`--hl`) goes on the vehicle's route
//! ([`Route::Vehicle`]); everything else only on links that are not high-latency
//! ([`Route::Auto`]). When no such link is up ([`LogMachine::set_route`]) the list and the
//! download pause, and go on when one is back. A download that got nothing for [`GIVE_UP`]
//! while the vehicle was not heard either (the link is gone) fails and starts again, from the
//! disk, once the vehicle is heard again.

use std::collections::{BTreeMap, VecDeque};
use std::path::PathBuf;

use crate::clock::{Micros, SECOND};
use crate::dialect::{
    MavMessage, LOG_DATA_DATA, LOG_ENTRY_DATA, LOG_ERASE_DATA, LOG_REQUEST_DATA_DATA,
    LOG_REQUEST_END_DATA, LOG_REQUEST_LIST_DATA,
};
use crate::proto::machine::{Ids, Incoming, Machine, Out, Route};
use crate::proto::vehicles::VehicleKey;
use crate::wire::Severity;
use mavlink::MessageData;

/// Bytes of one LOG_DATA.
pub const CHUNK: u32 = 90;
/// The smallest and largest window of new data asked in one request, in chunks.
pub const MIN_WINDOW: u32 = 16;
pub const MAX_WINDOW: u32 = 512;
/// The window a download starts with, in chunks.
pub const START_WINDOW: u32 = 64;
/// Data held beyond the written prefix, at most (bytes): nothing further is asked past it.
pub const MAX_AHEAD: u32 = 2 * MAX_WINDOW * CHUNK;
/// A request of at least this many chunks of which nothing came is silence (the window is
/// halved and the wait doubled); a smaller one only when the one before got nothing either
/// (a single chunk lost on a lossy link is no silence).
pub const SILENCE_CHUNKS: u32 = 4;
/// A window of new data shorter than this (chunks: the new part of a request that asked gaps
/// first) says too little of the loss to set the window by.
pub const ADAPT_CHUNKS: u32 = 8;
/// Without any data for this long a download fails (it resumes from the disk when asked again,
/// or by itself once the vehicle is heard again when it was not heard either).
pub const GIVE_UP: Micros = 60 * SECOND;
/// Not heard for this long when a download gives up: the link is gone (not the vehicle's
/// refusal), and the download starts again once the vehicle is heard.
pub const UNHEARD: Micros = 5 * SECOND;
/// No new byte for this long: the download shows as stalled (no rate, no ETA).
pub const STALLED: Micros = 2 * SECOND;
/// The rate shown is over this much of the recent past.
pub const RATE_WINDOW: Micros = 3 * SECOND;
/// Missing ids at most this far apart are asked again in one list request (the entries between
/// heard again: 26 bytes each, less than a round trip).
pub const LIST_MERGE: u16 = 32;
/// A list request unanswered this many times in a row: the list stays as far as it got.
pub const LIST_TRIES: u32 = 8;

/// A log the vehicle has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LogEntry {
    pub id: u16,
    /// UTC seconds since 1970 (0: the vehicle did not know the time).
    pub time_utc: u32,
    pub size: u32,
}

/// File work for the driver; what came of it returns as [`LogIoDone`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LogIo {
    /// How many bytes `partial` holds (0 when there is none), made at most `max` long (a longer
    /// one is cut); its directory is made. `tag` names the log (vehicle, id, time, size): kept
    /// in [`info_of`] `partial`, and a partial whose info is missing or another is started
    /// over (emptied) rather than resumed.
    Open {
        partial: PathBuf,
        max: u64,
        tag: String,
    },
    /// Write `bytes` at `ofs` of `partial` (always right after what is there).
    Write {
        partial: PathBuf,
        ofs: u64,
        bytes: Vec<u8>,
    },
    /// `partial` is complete: check it is `size` long, sync it, rename it to `path`.
    Finish {
        partial: PathBuf,
        path: PathBuf,
        size: u64,
    },
}

/// What came of a [`LogIo`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LogIoDone {
    /// The partial holds `have` bytes.
    Opened { partial: PathBuf, have: u64 },
    /// Renamed to `path`.
    Finished { path: PathBuf },
    /// Why the file work failed (the download stops).
    Failed { path: PathBuf, error: String },
}

/// `NAME.partial` beside `path`.
pub fn partial_of(path: &std::path::Path) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".partial");
    PathBuf::from(s)
}

/// `NAME.partial.info` beside `partial`: which log the partial is a prefix of.
pub fn info_of(partial: &std::path::Path) -> PathBuf {
    let mut s = partial.as_os_str().to_owned();
    s.push(".info");
    PathBuf::from(s)
}

/// What a partial of log `e` of vehicle `key` is tagged with ([`LogIo::Open`]).
pub fn tag_of(key: VehicleKey, e: &LogEntry) -> String {
    format!(
        "mavterm onboard log\nvehicle {}:{}\nid {}\ntime_utc {}\nsize {}\n",
        key.0, key.1, e.id, e.time_utc, e.size
    )
}

/// A download asked for: the log, where it goes (`None`: the default place), and whether the
/// operator asked it on a high-latency link (`--hl`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Queued {
    pub id: u16,
    pub path: Option<PathBuf>,
    pub hl: bool,
}

/// Sorted, disjoint half-open ranges.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Ranges(pub Vec<(u32, u32)>);

impl Ranges {
    pub fn insert(&mut self, a: u32, b: u32) {
        if a >= b {
            return;
        }
        let (mut a, mut b) = (a, b);
        let mut out = Vec::with_capacity(self.0.len() + 1);
        let mut placed = false;
        for &(x, y) in &self.0 {
            if y < a {
                out.push((x, y));
            } else if x > b {
                if !placed {
                    out.push((a, b));
                    placed = true;
                }
                out.push((x, y));
            } else {
                a = a.min(x);
                b = b.max(y);
            }
        }
        if !placed {
            out.push((a, b));
        }
        self.0 = out;
    }
    /// Bytes of `[a, b)` not covered.
    pub fn missing_in(&self, a: u32, b: u32) -> u32 {
        let covered: u32 = self
            .0
            .iter()
            .map(|&(x, y)| y.min(b).saturating_sub(x.max(a)))
            .sum();
        (b - a).saturating_sub(covered)
    }
    /// The holes in `[a, b)`.
    pub fn holes(&self, a: u32, b: u32) -> Vec<(u32, u32)> {
        let mut out = Vec::new();
        let mut at = a;
        for &(x, y) in &self.0 {
            if y <= at {
                continue;
            }
            if x >= b {
                break;
            }
            if x > at {
                out.push((at, x.min(b)));
            }
            at = at.max(y);
        }
        if at < b {
            out.push((at, b));
        }
        out
    }
}

/// The log list and how it was got.
#[derive(Debug, Clone, Default)]
pub struct Listing {
    pub entries: BTreeMap<u16, LogEntry>,
    /// `num_logs` as the vehicle last said.
    pub num_logs: Option<u16>,
    /// The first and last id of the vehicle's logs.
    pub first: u16,
    pub last: u16,
    /// A request out: (start, end, sent at, last entry heard at, tries).
    asked: Option<(u16, u16, Micros, Micros, u32)>,
    /// The list is wanted (the operator asked): requests go on until it is whole.
    pub wanted: bool,
    pub started: Micros,
    /// When it became whole.
    pub done: Option<Micros>,
    /// Requests sent again for missing ids.
    pub retries: u32,
    pub requests: u32,
    /// Why it stopped short.
    pub failed: Option<String>,
    /// The listing asked ended (its last id came): what is missing is asked at once.
    ended: bool,
    /// Asked on a high-latency link (`--hl`): its requests may go there.
    pub hl: bool,
}

impl Listing {
    /// Ids said to exist and not heard.
    pub fn missing(&self) -> Vec<(u16, u16)> {
        let Some(n) = self.num_logs.filter(|&n| n > 0) else {
            return Vec::new();
        };
        let _ = n;
        let mut out: Vec<(u16, u16)> = Vec::new();
        for id in self.first..=self.last {
            if self.entries.contains_key(&id) {
                continue;
            }
            match out.last_mut() {
                Some((_, e)) if *e + 1 == id => *e = id,
                _ => out.push((id, id)),
            }
        }
        out
    }
    pub fn complete(&self) -> bool {
        self.num_logs.is_some() && self.missing().is_empty()
    }
    /// Newest first (highest id).
    pub fn newest_first(&self) -> Vec<LogEntry> {
        self.entries.values().rev().copied().collect()
    }
}

/// How a download stands.
#[derive(Debug, Clone, PartialEq)]
pub enum State {
    /// Waiting for the size of what is on disk.
    Opening,
    Running,
    /// Every byte is here: waiting for the rename.
    Finishing,
    Done,
    Cancelled,
    Failed(String),
}

/// One request out.
#[derive(Debug, Clone, Copy)]
struct Req {
    ofs: u32,
    end: u32,
    /// Where the data never asked before starts in it (`end`: none).
    new_from: u32,
    sent: Micros,
    /// The last chunk of it heard (time, end offset).
    last: Option<(Micros, u32)>,
    /// The same request sent again because nothing of it came: its first chunk may answer
    /// the one before, so no round trip is measured on it.
    repeat: bool,
}

/// One log's download.
#[derive(Debug, Clone)]
pub struct Transfer {
    pub entry: LogEntry,
    pub path: PathBuf,
    pub partial: PathBuf,
    pub state: State,
    /// Bytes written to the partial (a prefix of the log).
    pub written: u32,
    /// Bytes on disk when it started (resumed from).
    pub resumed: u32,
    /// Chunks beyond the prefix, by offset.
    ahead: BTreeMap<u32, Vec<u8>>,
    /// What is here: the prefix and the chunks ahead.
    have: Ranges,
    /// The highest end heard.
    high: u32,
    req: Option<Req>,
    /// Window of new data, in chunks.
    pub window: u32,
    /// Smoothed round trip and its variation (µs): request out → its first chunk.
    pub srtt: Option<Micros>,
    rttvar: Micros,
    /// Measured time per chunk while a request streams (µs).
    per_chunk: Option<Micros>,
    /// Requests and retries (requests for what was asked before), duplicates received.
    pub requests: u32,
    pub retries: u32,
    pub dups: u32,
    /// Consecutive timeouts without data that count as silence (see [`SILENCE_CHUNKS`]).
    silent: u32,
    /// Consecutive requests of which nothing came.
    misses: u32,
    pub started: Micros,
    pub finished: Option<Micros>,
    last_data: Micros,
    /// When the next request may go (the `log_rate` cap).
    next_allowed: Micros,
    /// The `log_rate` cap (bytes a second): windows of at most half a second of it.
    pub rate_cap: Option<u32>,
    /// Recent (time, bytes here) samples for the rate: the first at or before
    /// [`RATE_WINDOW`] ago, then every one since.
    samples: VecDeque<(Micros, u32)>,
    /// The smoothed loss of the windows of new data (fraction); `None` before the first ended.
    pub loss: Option<f64>,
    /// Asked on a high-latency link (`--hl`): its requests may go there.
    pub hl: bool,
    /// Paused since then: no link but high-latency ones reaches the vehicle.
    pub paused: Option<Micros>,
    /// The last new byte (for the stall shown).
    last_new: Micros,
}

impl Transfer {
    fn new(now: Micros, entry: LogEntry, path: PathBuf) -> Transfer {
        Transfer {
            entry,
            partial: partial_of(&path),
            path,
            state: State::Opening,
            written: 0,
            resumed: 0,
            ahead: BTreeMap::new(),
            have: Ranges::default(),
            high: 0,
            req: None,
            window: START_WINDOW,
            srtt: None,
            rttvar: 0,
            per_chunk: None,
            requests: 0,
            retries: 0,
            dups: 0,
            silent: 0,
            misses: 0,
            started: now,
            finished: None,
            last_data: now,
            next_allowed: now,
            rate_cap: None,
            samples: VecDeque::new(),
            loss: None,
            hl: false,
            paused: None,
            last_new: now,
        }
    }

    /// Bytes here (written, and held ahead).
    pub fn got(&self) -> u32 {
        self.have.0.iter().map(|(a, b)| b - a).sum()
    }

    /// Bytes a second over the last [`RATE_WINDOW`] up to `now` (new bytes only): it falls
    /// while nothing comes. `None` during the first quarter second.
    pub fn rate(&self, now: Micros) -> Option<f64> {
        let (t0, b0) = *self
            .samples
            .iter()
            .rev()
            .find(|(t, _)| *t + RATE_WINDOW <= now)
            .or(self.samples.front())?;
        let (_, b1) = *self.samples.back()?;
        if now <= t0 + SECOND / 4 {
            return None;
        }
        Some(b1.saturating_sub(b0) as f64 * 1e6 / (now - t0) as f64)
    }

    /// Seconds left at the rate of `now`; `None` while stalled or paused.
    pub fn eta(&self, now: Micros) -> Option<f64> {
        if self.stalled(now).is_some() || self.paused.is_some() {
            return None;
        }
        let r = self.rate(now).filter(|r| *r > 0.0)?;
        Some((self.entry.size - self.got().min(self.entry.size)) as f64 / r)
    }

    /// How long no new byte came, once that is [`STALLED`] or more (a running download that is
    /// not paused).
    pub fn stalled(&self, now: Micros) -> Option<Micros> {
        let quiet = now.saturating_sub(self.last_new);
        (self.state == State::Running && self.paused.is_none() && quiet >= STALLED).then_some(quiet)
    }

    /// Progress in one line: `12.3 kB/30.0 kB 41% 2.8 kB/s ETA 6 s retries 2`, with
    /// `stalled 4 s` or `paused (high-latency link only)` for the rate and ETA when so.
    pub fn progress_text(&self, now: Micros) -> String {
        let size = self.entry.size;
        let got = self.got().min(size);
        let pct = got as u64 * 100 / size.max(1) as u64;
        let how = if self.paused.is_some() {
            "paused (high-latency link only)".to_string()
        } else if let Some(q) = self.stalled(now) {
            format!("stalled {}", human_secs(q as f64 / 1e6))
        } else {
            let rate = self
                .rate(now)
                .map_or("–".into(), |r| format!("{}/s", human_bytes(r as u64)));
            let eta = self.eta(now).map_or("–".into(), human_secs);
            format!("{rate} ETA {eta}")
        };
        format!(
            "{}/{} {pct}% {how} retries {}",
            human_bytes(got as u64),
            human_bytes(size as u64),
            self.retries
        )
    }

    pub fn active(&self) -> bool {
        matches!(
            self.state,
            State::Opening | State::Running | State::Finishing
        )
    }

    /// The wait for a request's next chunk: its round trip before the first, the measured time
    /// per chunk (for what is still to come) after.
    fn deadline(&self) -> Option<Micros> {
        let r = self.req?;
        let rtt = self.srtt.unwrap_or(SECOND);
        let rto = (rtt + 4 * self.rttvar).clamp(100_000, 3 * SECOND);
        let backoff = rto.saturating_mul(1 << self.silent.min(4)).min(5 * SECOND);
        Some(match r.last {
            None => r.sent + backoff,
            Some((t, at)) => {
                let per = self.per_chunk.unwrap_or(20_000);
                let left = (r.end.saturating_sub(at)).div_ceil(CHUNK) as u64;
                // The rest at the measured pace, and slack of a few chunks and the jitter.
                t + per * left + (4 * per).max(4 * self.rttvar).max(100_000)
            }
        })
    }

    fn rtt_sample(&mut self, s: Micros) {
        match self.srtt {
            None => {
                self.srtt = Some(s);
                self.rttvar = s / 2;
            }
            Some(r) => {
                let d = r.abs_diff(s);
                self.rttvar = (3 * self.rttvar + d) / 4;
                self.srtt = Some((7 * r + s) / 8);
            }
        }
    }

    /// The vehicle's pace while a request streams, in µs a chunk (20 ms until measured).
    fn pace(&self) -> Micros {
        self.per_chunk.unwrap_or(20_000).max(1)
    }

    /// Bytes worth receiving again rather than spending a round trip on another request: what
    /// the vehicle sends, at its measured pace, in one round trip.
    fn merge_bytes(&self) -> u32 {
        let rtt = self.srtt.unwrap_or(100_000);
        (rtt.saturating_mul(CHUNK as u64) / self.pace()).min(u32::MAX as u64) as u32
    }

    /// The next request: the first gap, merged with the gaps after it (and the next window of
    /// new data after them) while what lies between two costs less to receive again than a
    /// round trip ([`Self::merge_bytes`]) and the whole stays within a window; else a window of
    /// new data. `(from, to)`; `None` when nothing is left to ask.
    fn next_request(&self) -> Option<(u32, u32)> {
        let size = self.entry.size;
        let from = self.high.max(self.written);
        let window = match self.rate_cap {
            Some(c) => self.window.min((c / 2 / CHUNK).max(MIN_WINDOW)),
            None => self.window,
        };
        let mut gaps = self.have.holes(self.written, self.high.min(size));
        let new_data = from < size && from - self.written < MAX_AHEAD;
        if new_data {
            gaps.push((from, from + (window * CHUNK).min(size - from)));
        }
        let &(a, mut b) = gaps.first()?;
        let (merge, cap) = (self.merge_bytes(), window * CHUNK);
        let last = a.saturating_add(cap).max(b);
        for &(x, y) in &gaps[1..] {
            if x - b > merge || x >= last {
                break;
            }
            // What does not fit stays a gap (or new data) for the request after.
            b = y.min(last);
            if b < y {
                break;
            }
        }
        Some((a, b))
    }
}

/// Why an operator's request is refused.
pub type Refusal = String;

/// The log machine of one vehicle: its list, the download running and the queue.
#[derive(Debug, Clone)]
pub struct LogMachine {
    key: VehicleKey,
    pub list: Listing,
    pub transfer: Option<Transfer>,
    /// Downloads waiting.
    pub queue: VecDeque<Queued>,
    /// File work for the driver.
    io: Vec<LogIo>,
    /// Bytes a second at most (`log_rate`); `None`: as fast as the link goes.
    pub rate_cap: Option<u32>,
    /// Where logs go by default (`…/logs/vehicle/SYSID/`); `None`: a path must be given.
    pub dir: Option<PathBuf>,
    /// The extension of the vehicle's logs (`bin`, `ulg`).
    pub ext: &'static str,
    /// Downloads finished (done, failed, cancelled) in this session, newest last.
    pub history: Vec<(LogEntry, PathBuf, State)>,
    /// Downloads saved in this session: (id, bytes, µs from start to saved, requests,
    /// retries).
    pub stats: Vec<(u16, u32, Micros, u32, u32)>,
    /// A list asked again after an erase, at this time (and whether on a high-latency link).
    relist_at: Option<(Micros, bool)>,
    /// A poll is due now (a request to send).
    due: Option<Micros>,
    /// A link that is not high-latency is up and the vehicle was heard on it (last at this
    /// time): see [`Self::set_route`]. `None`: only high-latency links reach it.
    pub route: Option<Micros>,
    /// A download failed because nothing came and the vehicle was not heard either (failed
    /// then): it is first in the queue, and the queue starts again once the vehicle is heard.
    pub waiting_for_link: Option<Micros>,
}

impl LogMachine {
    pub fn new(key: VehicleKey) -> LogMachine {
        LogMachine {
            key,
            list: Listing::default(),
            transfer: None,
            queue: VecDeque::new(),
            io: Vec::new(),
            rate_cap: None,
            dir: None,
            ext: "bin",
            history: Vec::new(),
            stats: Vec::new(),
            relist_at: None,
            due: None,
            route: Some(0),
            waiting_for_link: None,
        }
    }

    /// File work waiting for the driver.
    pub fn take_io(&mut self) -> Vec<LogIo> {
        std::mem::take(&mut self.io)
    }

    /// True while a list or a download runs.
    pub fn busy(&self) -> bool {
        self.transfer.as_ref().is_some_and(|t| t.active()) || self.list.asked.is_some()
    }

    /// The default file of log `e`: named by its time (UTC), or by its id when the vehicle did
    /// not know the time.
    pub fn default_path(&self, e: &LogEntry) -> Option<PathBuf> {
        let dir = self.dir.as_ref()?;
        let name = match chrono::DateTime::from_timestamp(e.time_utc as i64, 0) {
            Some(t) if e.time_utc > 0 => {
                format!("{}_log{}.{}", t.format("%Y-%m-%d_%H-%M-%S"), e.id, self.ext)
            }
            _ => format!("log{}_no-time.{}", e.id, self.ext),
        };
        Some(dir.join(name))
    }

    /// Send `msg`: on the vehicle's route when the operator asked on a high-latency link
    /// (`hl`), else never on one.
    fn send(&self, msg: MavMessage, hl: bool, out: &mut Vec<Out>) {
        let route = if hl { Route::Vehicle } else { Route::Auto };
        out.push(Out::send(route, msg));
    }

    /// Where the vehicle can be reached, told after every update: `Some(t)` when a link that is
    /// not high-latency is up and the vehicle was heard on one last at `t`; `None` when only
    /// high-latency links are left. What was not asked on a high-latency link pauses while
    /// `None`, and goes on when one is back; a download that failed for silence while the
    /// vehicle was not heard starts again once it is heard (later than the failure).
    pub fn set_route(&mut self, now: Micros, route: Option<Micros>, out: &mut Vec<Out>) {
        self.route = route;
        if let Some(t) = self.transfer.as_mut().filter(|t| t.state == State::Running) {
            match (route, t.paused) {
                (None, None) if !t.hl => {
                    t.paused = Some(now);
                    out.push(Out::notice(
                        Severity::WARNING,
                        format!(
                            "log {}: paused at {}/{} bytes: only a high-latency link reaches \
                             {} (goes on when another link is back; `log get {} --hl` goes on over it)",
                            t.entry.id, t.written, t.entry.size, self.key, t.entry.id
                        ),
                    ));
                }
                (Some(_), Some(since)) => {
                    t.paused = None;
                    // The time paused is no silence of the vehicle's.
                    t.last_data = t.last_data.max(now);
                    t.last_new = t.last_new.max(now);
                    t.silent = 0;
                    let asked = t.req.take().is_some();
                    let text = format!(
                        "log {}: going on at {}/{} bytes (paused {})",
                        t.entry.id,
                        t.written,
                        t.entry.size,
                        human_secs(now.saturating_sub(since) as f64 / 1e6)
                    );
                    out.push(Out::notice(Severity::INFO, text));
                    if asked {
                        // The vehicle may still be sending the request of before into the link
                        // that went: END stops it, so the next request is not dropped.
                        self.send(self.end_msg(), false, out);
                    }
                    self.due = Some(now);
                }
                _ => {}
            }
        }
        if let (Some(heard), Some(failed)) = (route, self.waiting_for_link) {
            if heard > failed && !self.transfer.as_ref().is_some_and(|t| t.active()) {
                self.waiting_for_link = None;
                if let Some(q) = self.queue.front() {
                    out.push(Out::notice(
                        Severity::INFO,
                        format!("{} heard again: log {} goes on", self.key, q.id),
                    ));
                }
                self.next_in_queue(now);
            }
        }
    }

    /// Requests of the list may go now.
    fn list_may_send(&self) -> bool {
        self.list.hl || self.route.is_some()
    }

    fn list_request(&mut self, now: Micros, start: u16, end: u16, out: &mut Vec<Out>) {
        let tries = match self.list.asked {
            Some((s, e, _, _, t)) if s == start && e == end => t + 1,
            _ => 1,
        };
        self.list.asked = Some((start, end, now, now, tries));
        self.list.ended = false;
        self.list.requests += 1;
        self.send(
            MavMessage::LOG_REQUEST_LIST(LOG_REQUEST_LIST_DATA {
                start,
                end,
                target_system: self.key.0,
                target_component: self.key.1,
            }),
            self.list.hl,
            out,
        );
    }

    /// The operator asks for the list (again), on a high-latency link too when `hl`: what was
    /// heard is kept, the whole is asked.
    pub fn refresh(&mut self, now: Micros, hl: bool, out: &mut Vec<Out>) -> Result<(), Refusal> {
        if self.transfer.as_ref().is_some_and(|t| t.active()) {
            return Err("a log download is running: the list is asked when it ends".into());
        }
        self.list = Listing {
            wanted: true,
            started: now,
            hl,
            ..Listing::default()
        };
        self.list_request(now, 0, 0xFFFF, out);
        Ok(())
    }

    /// Download log `id` (or queue it behind the one running) into `path` (default place when
    /// `None`), on a high-latency link too when `hl`.
    pub fn get(
        &mut self,
        now: Micros,
        id: u16,
        path: Option<PathBuf>,
        hl: bool,
    ) -> Result<String, Refusal> {
        let Some(e) = self.list.entries.get(&id).copied() else {
            return Err(format!("no log {id} in the list (refresh it first)"));
        };
        if path.is_none() && self.dir.is_none() {
            return Err("no data directory: give a file".into());
        }
        // Asked again while it waits for the link: now, and out of the queue.
        self.queue
            .retain(|q| !(q.id == id && self.waiting_for_link.is_some()));
        if let Some(t) = self.transfer.as_mut().filter(|t| t.active()) {
            if t.entry.id == id && hl && !t.hl {
                // Asked again on the high-latency link: it goes on there.
                t.hl = true;
                if t.paused.take().is_some() {
                    t.last_data = t.last_data.max(now);
                    t.req = None;
                    self.due = Some(now);
                }
                return Ok(format!("log {id} goes on over the high-latency link too"));
            }
            if t.entry.id == id || self.queue.iter().any(|q| q.id == id) {
                return Err(format!("log {id} is already on its way"));
            }
            self.queue.push_back(Queued { id, path, hl });
            return Ok(format!("log {id} queued ({} waiting)", self.queue.len()));
        }
        // The operator's own request goes now; the queue follows it as usual.
        self.waiting_for_link = None;
        self.start(now, e, path, hl);
        Ok(format!("downloading log {id} ({} bytes)", e.size))
    }

    fn start(&mut self, now: Micros, e: LogEntry, path: Option<PathBuf>, hl: bool) {
        let Some(path) = path.or_else(|| self.default_path(&e)) else {
            return;
        };
        let mut t = Transfer::new(now, e, path);
        t.rate_cap = self.rate_cap.filter(|c| *c > 0);
        t.hl = hl;
        self.io.push(LogIo::Open {
            partial: t.partial.clone(),
            max: e.size as u64,
            tag: tag_of(self.key, &e),
        });
        self.transfer = Some(t);
    }

    /// The newest log's id.
    pub fn latest(&self) -> Option<u16> {
        self.list.entries.keys().next_back().copied()
    }

    /// Stop the download (and the queue): LOG_REQUEST_END; the partial stays for a resume.
    pub fn cancel(&mut self, now: Micros, out: &mut Vec<Out>) -> Result<String, Refusal> {
        let queued = self.queue.len();
        self.queue.clear();
        self.waiting_for_link = None;
        let Some(t) = self.transfer.as_mut().filter(|t| t.active()) else {
            if queued > 0 {
                return Ok(format!("{queued} queued logs dropped"));
            }
            return Err("no log download to cancel".into());
        };
        t.state = State::Cancelled;
        t.finished = Some(now);
        t.req = None;
        let text = format!(
            "log {} cancelled at {}/{} bytes (kept in {} for a resume)",
            t.entry.id,
            t.written,
            t.entry.size,
            t.partial.display()
        );
        self.end_transfer(out);
        Ok(text)
    }

    /// mavterm ends (quit, a headless run's time is up): a download running is cancelled, so
    /// the vehicle gets LOG_REQUEST_END and logs again; the partial stays for a resume. True
    /// when there was one.
    pub fn on_exit(&mut self, now: Micros, out: &mut Vec<Out>) -> bool {
        if !self.transfer.as_ref().is_some_and(|t| t.active()) {
            return false;
        }
        let _ = self.cancel(now, out);
        true
    }

    /// LOG_ERASE: every log on the vehicle (the operator confirmed), on a high-latency link
    /// too when `hl`. The list is asked again.
    pub fn erase(&mut self, now: Micros, hl: bool, out: &mut Vec<Out>) -> Result<(), Refusal> {
        if self.transfer.as_ref().is_some_and(|t| t.active()) {
            return Err("a log download is running: cancel it first".into());
        }
        self.send(
            MavMessage::LOG_ERASE(LOG_ERASE_DATA {
                target_system: self.key.0,
                target_component: self.key.1,
            }),
            hl,
            out,
        );
        self.list = Listing::default();
        self.relist_at = Some((now + SECOND, hl));
        Ok(())
    }

    fn end_msg(&self) -> MavMessage {
        MavMessage::LOG_REQUEST_END(LOG_REQUEST_END_DATA {
            target_system: self.key.0,
            target_component: self.key.1,
        })
    }

    fn end_transfer(&mut self, out: &mut Vec<Out>) {
        let hl = self.transfer.as_ref().is_some_and(|t| t.hl);
        self.send(self.end_msg(), hl, out);
        if let Some(t) = &self.transfer {
            if !t.active() {
                self.history
                    .push((t.entry, t.path.clone(), t.state.clone()));
            }
        }
    }

    fn fail(&mut self, now: Micros, why: String, out: &mut Vec<Out>) {
        if let Some(t) = self.transfer.as_mut() {
            t.state = State::Failed(why.clone());
            t.finished = Some(now);
            t.req = None;
            out.push(Out::notice(
                Severity::ERROR,
                format!("log {} failed: {why}", t.entry.id),
            ));
        }
        self.end_transfer(out);
        if self.waiting_for_link.is_none() {
            self.next_in_queue(now);
        }
    }

    fn next_in_queue(&mut self, now: Micros) {
        while let Some(q) = self.queue.pop_front() {
            if let Some(e) = self.list.entries.get(&q.id).copied() {
                self.start(now, e, q.path, q.hl);
                return;
            }
        }
    }

    /// What came of file work.
    pub fn on_io(&mut self, now: Micros, done: LogIoDone, out: &mut Vec<Out>) {
        let Some(t) = self.transfer.as_mut() else {
            return;
        };
        match done {
            LogIoDone::Opened { partial, have } if partial == t.partial => {
                if t.state != State::Opening {
                    return;
                }
                let have = (have.min(t.entry.size as u64)) as u32;
                t.written = have;
                t.resumed = have;
                t.high = have;
                t.have = Ranges::default();
                t.have.insert(0, have);
                t.state = State::Running;
                t.last_data = now;
                t.last_new = now;
                t.samples.push_back((now, have));
                if have > 0 {
                    out.push(Out::notice(
                        Severity::INFO,
                        format!(
                            "log {}: resuming at {have}/{} bytes from {}",
                            t.entry.id,
                            t.entry.size,
                            t.partial.display()
                        ),
                    ));
                }
                if self.route.is_none() && !t.hl {
                    // Only a high-latency link: waits for another (set_route says so).
                    let r = self.route;
                    self.set_route(now, r, out);
                }
                self.due = Some(now);
                self.check_complete(now, out);
            }
            LogIoDone::Finished { path } if path == t.path => {
                t.state = State::Done;
                t.finished = Some(now);
                let secs = (now - t.started) as f64 / 1e6;
                let text = format!(
                    "log {} saved to {} ({} bytes in {secs:.1} s, {} retries)",
                    t.entry.id,
                    t.path.display(),
                    t.entry.size,
                    t.retries
                );
                self.history.push((t.entry, t.path.clone(), State::Done));
                self.stats.push((
                    t.entry.id,
                    t.entry.size - t.resumed,
                    now - t.started,
                    t.requests,
                    t.retries,
                ));
                out.push(Out::notice(Severity::INFO, text));
                self.next_in_queue(now);
            }
            LogIoDone::Failed { path, error }
                if (path == t.path || path == t.partial) && t.active() =>
            {
                self.fail(now, format!("{}: {error}", path.display()), out);
            }
            _ => {}
        }
    }

    fn check_complete(&mut self, now: Micros, out: &mut Vec<Out>) {
        let Some(t) = self.transfer.as_mut() else {
            return;
        };
        if t.state == State::Running && t.written >= t.entry.size {
            t.state = State::Finishing;
            t.req = None;
            t.paused = None;
            t.finished = Some(now);
            let hl = t.hl;
            self.io.push(LogIo::Finish {
                partial: t.partial.clone(),
                path: t.path.clone(),
                size: t.entry.size as u64,
            });
            self.send(self.end_msg(), hl, out);
        }
    }

    fn on_entry(&mut self, now: Micros, m: &LOG_ENTRY_DATA, out: &mut Vec<Out>) {
        let l = &mut self.list;
        if !l.wanted {
            return;
        }
        if m.num_logs == 0 {
            l.num_logs = Some(0);
            l.entries.clear();
            l.asked = None;
            l.done.get_or_insert(now);
            return;
        }
        l.num_logs = Some(m.num_logs);
        // ArduPilot's ids run 1..=num_logs, PX4's 0..num_logs; `last_log_num` is the last id
        // of this listing, the last of all when the whole list was asked.
        if let Some((0, 0xFFFF, ..)) = l.asked {
            l.last = m.last_log_num;
            l.first = (m.last_log_num + 1).saturating_sub(m.num_logs);
        } else if l.last == 0 && l.first == 0 {
            l.last = m.last_log_num.max(m.id);
            l.first = (l.last + 1).saturating_sub(m.num_logs);
        }
        if m.id < l.first || m.id > l.last {
            return;
        }
        l.entries.insert(
            m.id,
            LogEntry {
                id: m.id,
                time_utc: m.time_utc,
                size: m.size,
            },
        );
        if let Some(a) = l.asked.as_mut() {
            a.3 = now;
            if m.id >= a.1.min(l.last) {
                // The last of that listing: anything missing is asked at once (the request
                // stays known, for counting the tries of the same range).
                l.ended = true;
                self.due = Some(now);
            }
        }
        if self.list.complete() {
            self.list.asked = None;
            if self.list.done.is_none() {
                self.list.done = Some(now);
                out.push(Out::notice(
                    Severity::INFO,
                    format!("{} logs listed", self.list.entries.len()),
                ));
            }
        }
    }

    fn on_data(&mut self, now: Micros, m: &LOG_DATA_DATA, out: &mut Vec<Out>) {
        let Some(t) = self.transfer.as_mut().filter(|t| t.state == State::Running) else {
            return;
        };
        if m.id != t.entry.id || m.count as u32 > CHUNK {
            return;
        }
        let size = t.entry.size;
        let (ofs, n) = (m.ofs, m.count as u32);
        if n < CHUNK && ofs.saturating_add(n) < size {
            let why = format!(
                "the vehicle ended the log at {} bytes, its LOG_ENTRY said {size}",
                ofs + n
            );
            self.fail(now, why, out);
            return;
        }
        let end = ofs.saturating_add(n).min(size);
        t.last_data = now;
        t.silent = 0;
        t.misses = 0;
        if let Some(mut r) = t.req {
            if ofs >= r.ofs && ofs < r.end.max(r.ofs + 1) {
                match r.last {
                    None if ofs == r.ofs && !r.repeat => {
                        let s = now - r.sent;
                        t.rtt_sample(s);
                    }
                    Some((tp, at)) if ofs >= at => {
                        let chunks = ((ofs - at) / CHUNK + 1) as u64;
                        let per = (now - tp) / chunks;
                        t.per_chunk = Some(match t.per_chunk {
                            None => per,
                            Some(p) => (7 * p + per) / 8,
                        });
                    }
                    _ => {}
                }
                r.last = Some((now, end.max(ofs + 1)));
                t.req = Some(r);
            }
        }
        if end > ofs {
            if t.have.missing_in(ofs, end) == 0 {
                t.dups += 1;
            } else {
                t.have.insert(ofs, end);
                t.ahead.insert(ofs, m.data[..(end - ofs) as usize].to_vec());
                t.high = t.high.max(end);
                t.last_new = now;
            }
        }
        // The contiguous prefix to the file.
        let mut bytes = Vec::new();
        let start = t.written;
        while let Some((&o, _)) = t.ahead.range(..=t.written).next_back() {
            let c = t.ahead.remove(&o).expect("found");
            let e = o + c.len() as u32;
            if e > t.written {
                bytes.extend_from_slice(&c[(t.written - o) as usize..]);
                t.written = e;
            }
        }
        // Chunks wholly inside the prefix are done with.
        while let Some((&o, c)) = t.ahead.iter().next() {
            if o + c.len() as u32 <= t.written {
                t.ahead.remove(&o);
            } else {
                break;
            }
        }
        if !bytes.is_empty() {
            self.io.push(LogIo::Write {
                partial: t.partial.clone(),
                ofs: start as u64,
                bytes,
            });
        }
        let got = t.got();
        if t.samples.back().is_none_or(|(_, b)| *b != got) {
            t.samples.push_back((now, got));
        }
        // Kept: the last sample at or before the rate's window, and every one since.
        while t.samples.len() > 2 && t.samples[1].0 + RATE_WINDOW <= now {
            t.samples.pop_front();
        }
        // The request's last chunk: the next goes at once.
        if t.req.is_some_and(|r| end >= r.end || ofs >= r.end) {
            let r = t.req.take().expect("checked");
            if r.new_from < r.end {
                t.adapt(r.new_from, r.end);
            }
            self.due = Some(now);
        }
        self.check_complete(now, out);
    }
}

impl Transfer {
    /// A window of new data `[a, b)` ended (its last chunk came, or its wait ran out): the
    /// window is set by the loss `l` it saw against the loss the link usually shows (`L`, the
    /// smoothed loss of the windows before: `L ← (3L + l) / 4`, the first window's own):
    /// halved (at least [`MIN_WINDOW`]) when `l > 1/2`, or when `l` jumped above `L` by more
    /// than 15 points (more data asked at once overflowed a buffer); doubled (at most
    /// [`MAX_WINDOW`]) when `l < 5 %` or `l` is within 5 points of `L` (the link's own loss,
    /// which a smaller window would not lessen, only pay more round trips for); else kept.
    /// Windows shorter than [`ADAPT_CHUNKS`] chunks change nothing.
    fn adapt(&mut self, a: u32, b: u32) {
        if b.saturating_sub(a) < ADAPT_CHUNKS * CHUNK {
            return;
        }
        let l = self.have.missing_in(a, b) as f64 / (b - a).max(1) as f64;
        let base = self.loss.unwrap_or(l);
        if l > 0.5 || l > base + 0.15 {
            self.window = (self.window / 2).max(MIN_WINDOW);
        } else if l < 0.05 || l <= base + 0.05 {
            self.window = (self.window * 2).min(MAX_WINDOW);
        }
        self.loss = Some(match self.loss {
            None => l,
            Some(x) => (3.0 * x + l) / 4.0,
        });
    }
}

impl Machine for LogMachine {
    const IDS: Ids = Ids::Only(&[LOG_ENTRY_DATA::ID, LOG_DATA_DATA::ID]);

    fn on_message(&mut self, m: &Incoming, out: &mut Vec<Out>) {
        if m.from.1 != self.key.1 {
            return;
        }
        match m.msg {
            Some(MavMessage::LOG_ENTRY(e)) => self.on_entry(m.now, e, out),
            Some(MavMessage::LOG_DATA(d)) => self.on_data(m.now, d, out),
            _ => {}
        }
    }

    fn poll(&mut self, now: Micros, out: &mut Vec<Out>) {
        self.due = None;
        if let Some((_, hl)) = self.relist_at.filter(|(t, _)| now >= *t) {
            self.relist_at = None;
            let _ = self.refresh(now, hl, out);
        }
        self.poll_list(now, out);
        self.poll_transfer(now, out);
    }

    fn next_deadline(&self) -> Option<Micros> {
        let may_list = self.list_may_send();
        let list = self
            .list
            .asked
            .filter(|_| !self.list.ended && may_list)
            .map(|(_, _, sent, last, _)| {
                // Entries come a few tens of ms apart; a second of silence ends a listing.
                sent.max(last) + SECOND
            });
        let list_more = (self.list.wanted
            && may_list
            && self.list.asked.is_none()
            && !self.list.complete()
            && self.list.failed.is_none()
            && self.list.num_logs.is_some())
        .then_some(self.list.started);
        let t = self
            .transfer
            .as_ref()
            .filter(|t| t.state == State::Running && t.paused.is_none());
        let tr = t.and_then(|t| match t.req {
            Some(_) => t.deadline(),
            None if t.next_request().is_some() => Some(t.next_allowed),
            None => None,
        });
        let give_up = t.map(|t| t.last_data + GIVE_UP);
        [
            self.due,
            self.relist_at.map(|(t, _)| t),
            list,
            list_more,
            tr,
            give_up,
        ]
        .into_iter()
        .flatten()
        .min()
    }
}

impl LogMachine {
    fn poll_list(&mut self, now: Micros, out: &mut Vec<Out>) {
        let l = &self.list;
        if !l.wanted || l.failed.is_some() || !self.list_may_send() {
            return;
        }
        if let Some((s, e, sent, last, tries)) = l.asked {
            if now < sent.max(last) + SECOND && !l.ended {
                return;
            }
            // Silence: the listing ended, or it (or its request) was lost.
            if tries >= LIST_TRIES {
                self.list.asked = None;
                let why = match self.list.num_logs {
                    None => "no LOG_ENTRY came".to_string(),
                    Some(_) => format!("ids {s}..{e} never came"),
                };
                out.push(Out::notice(
                    Severity::WARNING,
                    format!("{}: log list incomplete: {why}", self.key),
                ));
                self.list.failed = Some(why);
                return;
            }
            if self.list.num_logs.is_none() {
                self.list.retries += 1;
                self.list_request(now, s, e, out);
                return;
            }
        }
        if self.list.complete() {
            self.list.asked = None;
            return;
        }
        // The missing ids from the first, ranges less than LIST_MERGE apart in one request:
        // entries heard again cost less than another round trip.
        let missing = self.list.missing();
        let Some(&(a, mut b)) = missing.first() else {
            return;
        };
        for &(x, y) in &missing[1..] {
            if x - b > LIST_MERGE {
                break;
            }
            b = y;
        }
        // The same range again counts its tries (`list_request` compares with the last).
        self.list.retries += 1;
        self.list_request(now, a, b, out);
    }

    fn poll_transfer(&mut self, now: Micros, out: &mut Vec<Out>) {
        let cap = self.rate_cap;
        let heard = self.route;
        let Some(t) = self
            .transfer
            .as_mut()
            .filter(|t| t.state == State::Running && t.paused.is_none())
        else {
            return;
        };
        if now >= t.last_data + GIVE_UP {
            let id = t.entry.id;
            let kept = format!(
                "{} of {} bytes kept in {}",
                t.written,
                t.entry.size,
                t.partial.display()
            );
            let unheard = heard.is_none_or(|h| h + UNHEARD <= now);
            let why = if unheard {
                // The link is gone: the log goes on by itself once the vehicle is heard.
                self.waiting_for_link = Some(now);
                let path = Some(t.path.clone());
                self.queue.push_front(Queued { id, path, hl: t.hl });
                format!(
                    "no data for {} s and the vehicle is not heard ({kept}): it goes on by \
                     itself once the vehicle is heard again (`log cancel` to stop)",
                    GIVE_UP / SECOND
                )
            } else {
                format!(
                    "no data for {} s though the vehicle is heard ({kept}): `log get {id}` \
                     resumes from it",
                    GIVE_UP / SECOND
                )
            };
            self.fail(now, why, out);
            return;
        }
        if let Some(r) = t.req {
            if t.deadline().is_some_and(|d| now < d) {
                return;
            }
            // Timed out: its tail is lost (a gap now) or the request itself was.
            t.req = None;
            if r.last.is_none() {
                // Silence (the window halved, the wait doubled) when losing every chunk of it
                // by chance is unlikely: it asked for several, or it is the second in a row.
                t.misses += 1;
                if r.end - r.ofs >= SILENCE_CHUNKS * CHUNK || t.misses >= 2 {
                    t.silent += 1;
                    t.window = (t.window / 2).max(MIN_WINDOW);
                }
                // Asked again now, as it was.
                let again = Req { repeat: true, ..r };
                return self.ask(now, again, cap, out);
            }
            t.high = t.high.max(r.end.min(t.entry.size));
            if r.new_from < r.end {
                t.adapt(r.new_from, r.end);
            }
        }
        if now < t.next_allowed {
            return;
        }
        if let Some((a, b)) = t.next_request() {
            let new_from = t.high.max(t.written).clamp(a, b);
            let r = Req {
                ofs: a,
                end: b,
                new_from,
                sent: now,
                last: None,
                repeat: false,
            };
            self.ask(now, r, cap, out);
        }
    }

    /// Send request `r`: a retry when it is a repeat or asks again what was asked before.
    fn ask(&mut self, now: Micros, mut r: Req, cap: Option<u32>, out: &mut Vec<Out>) {
        let Some(t) = self.transfer.as_mut() else {
            return;
        };
        t.requests += 1;
        if r.repeat || r.ofs < r.new_from {
            t.retries += 1;
        }
        r.sent = now;
        r.last = None;
        t.req = Some(r);
        if let Some(c) = cap.filter(|c| *c > 0) {
            let span = (r.end - r.ofs) as u64 * SECOND / c as u64;
            t.next_allowed = t.next_allowed.max(now) + span;
        }
        let (id, hl) = (t.entry.id, t.hl);
        self.send(
            MavMessage::LOG_REQUEST_DATA(LOG_REQUEST_DATA_DATA {
                ofs: r.ofs,
                count: r.end - r.ofs,
                id,
                target_system: self.key.0,
                target_component: self.key.1,
            }),
            hl,
            out,
        );
    }
}

/// `812 B`, `4.2 kB`, `1.3 MB` (powers of 1000).
pub fn human_bytes(b: u64) -> String {
    match b {
        0..1000 => format!("{b} B"),
        1000..1_000_000 => format!("{:.1} kB", b as f64 / 1e3),
        _ => format!("{:.1} MB", b as f64 / 1e6),
    }
}

/// `42 s`, `3 min 5 s`, `2 h 4 min`.
pub fn human_secs(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    match s {
        0..60 => format!("{s} s"),
        60..3600 => format!("{} min {} s", s / 60, s % 60),
        _ => format!("{} h {} min", s / 3600, (s % 3600) / 60),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_merge_and_give_holes() {
        let mut r = Ranges::default();
        r.insert(0, 90);
        r.insert(180, 270);
        r.insert(360, 450);
        assert_eq!(r.holes(0, 450), vec![(90, 180), (270, 360)]);
        r.insert(90, 180);
        assert_eq!(r.0, vec![(0, 270), (360, 450)]);
        assert_eq!(r.missing_in(0, 500), 140);
        assert_eq!(r.holes(100, 400), vec![(270, 360)]);
    }

    use crate::link::LinkId;
    use crate::proto::machine::LinkProfile;

    fn incoming(now: Micros, msg: &MavMessage) -> Incoming<'_> {
        Incoming {
            now,
            from: (1, 1),
            link: 0 as LinkId,
            profile: LinkProfile::default(),
            id: 0,
            payload: &[],
            msg: Some(msg),
            ack: None,
        }
    }

    fn sends(out: &mut Vec<Out>) -> Vec<MavMessage> {
        out.drain(..)
            .filter_map(|o| match o {
                Out::Send { msg, .. } => Some(msg),
                _ => None,
            })
            .collect()
    }

    fn entry(id: u16, num: u16, last: u16) -> MavMessage {
        MavMessage::LOG_ENTRY(LOG_ENTRY_DATA {
            time_utc: 0,
            size: 900,
            id,
            num_logs: num,
            last_log_num: last,
        })
    }

    fn data(ofs: u32, n: u8) -> MavMessage {
        MavMessage::LOG_DATA(LOG_DATA_DATA {
            ofs,
            id: 2,
            count: n,
            data: [7; 90],
        })
    }

    #[test]
    fn a_lost_entry_is_asked_by_its_range_when_the_listing_ends() {
        let mut m = LogMachine::new(VehicleKey(1, 1));
        let mut out = Vec::new();
        m.refresh(0, false, &mut out).unwrap();
        assert!(
            matches!(&sends(&mut out)[..], [MavMessage::LOG_REQUEST_LIST(l)] if l.start == 0 && l.end == 0xFFFF)
        );
        for id in [1, 3] {
            m.on_message(&incoming(10_000, &entry(id, 3, 3)), &mut out);
        }
        // The last id came: the missing one at once, not after a silence.
        assert_eq!(m.next_deadline(), Some(10_000));
        m.poll(10_000, &mut out);
        assert!(
            matches!(&sends(&mut out)[..], [MavMessage::LOG_REQUEST_LIST(l)] if l.start == 2 && l.end == 2)
        );
        m.on_message(&incoming(20_000, &entry(2, 3, 2)), &mut out);
        assert!(m.list.complete());
        assert_eq!(
            m.list
                .newest_first()
                .iter()
                .map(|e| e.id)
                .collect::<Vec<_>>(),
            vec![3, 2, 1]
        );
    }

    #[test]
    fn a_gap_is_asked_as_soon_as_the_request_ends_and_the_file_is_a_prefix() {
        let mut m = with_log_2(900);
        let mut out = Vec::new();
        m.get(0, 2, None, false).unwrap();
        let io = m.take_io();
        assert_eq!(
            io,
            vec![LogIo::Open {
                partial: PathBuf::from("/d/log2_no-time.bin.partial"),
                max: 900,
                tag: "mavterm onboard log\nvehicle 1:1\nid 2\ntime_utc 0\nsize 900\n".into(),
            }]
        );
        m.on_io(
            0,
            LogIoDone::Opened {
                partial: PathBuf::from("/d/log2_no-time.bin.partial"),
                have: 0,
            },
            &mut out,
        );
        m.poll(0, &mut out);
        assert!(
            matches!(&sends(&mut out)[..], [MavMessage::LOG_REQUEST_DATA(r)] if r.id == 2 && r.ofs == 0 && r.count == 900 && r.target_system == 1)
        );
        // 90..180 lost.
        for k in (0..10).filter(|k| *k != 1) {
            m.on_message(&incoming(1000 * k as u64, &data(90 * k, 90)), &mut out);
        }
        // Only the prefix before the gap is written.
        let io = m.take_io();
        assert!(matches!(&io[..], [LogIo::Write { ofs: 0, bytes, .. }] if bytes.len() == 90));
        assert!(m.next_deadline().is_some_and(|d| d <= 9000));
        m.poll(9000, &mut out);
        assert!(
            matches!(&sends(&mut out)[..], [MavMessage::LOG_REQUEST_DATA(r)] if r.ofs == 90 && r.count == 90)
        );
        m.on_message(&incoming(20_000, &data(90, 90)), &mut out);
        let io = m.take_io();
        assert!(matches!(&io[0], LogIo::Write { ofs: 90, bytes, .. } if bytes.len() == 810));
        assert!(matches!(&io[1], LogIo::Finish { size: 900, .. }));
        assert!(matches!(
            &sends(&mut out)[..],
            [MavMessage::LOG_REQUEST_END(_)]
        ));
        assert_eq!(m.transfer.as_ref().unwrap().retries, 1);
    }

    /// A machine of 1:1 saving into `/d` whose list holds log 2 (`size` bytes, no time).
    fn with_log_2(size: u32) -> LogMachine {
        let mut m = LogMachine::new(VehicleKey(1, 1));
        m.dir = Some(PathBuf::from("/d"));
        m.list.entries.insert(
            2,
            LogEntry {
                id: 2,
                time_utc: 0,
                size,
            },
        );
        m
    }

    /// A machine downloading log 2 (`size` bytes, no time) into `/d`, its partial opened empty
    /// at `now`, with `route` as where the vehicle is reached.
    fn downloading(size: u32, now: Micros, route: Option<Micros>) -> (LogMachine, Vec<Out>) {
        let mut m = with_log_2(size);
        let mut out = Vec::new();
        m.set_route(now, route, &mut out);
        m.get(now, 2, None, false).unwrap();
        m.take_io();
        let partial = m.transfer.as_ref().unwrap().partial.clone();
        m.on_io(now, LogIoDone::Opened { partial, have: 0 }, &mut out);
        out.clear();
        (m, out)
    }

    fn data_requests(out: &mut Vec<Out>) -> Vec<(u32, u32)> {
        sends(out)
            .into_iter()
            .filter_map(|m| match m {
                MavMessage::LOG_REQUEST_DATA(r) => Some((r.ofs, r.count)),
                _ => None,
            })
            .collect()
    }

    /// A window of `n` chunks from chunk `at` ended with every `every`th chunk of it lost
    /// (`every` 0: none lost).
    fn window_ends(t: &mut Transfer, at: u32, n: u32, every: u32) {
        for k in 0..n {
            if every == 0 || k % every != every - 1 {
                t.have.insert((at + k) * CHUNK, (at + k + 1) * CHUNK);
            }
        }
        t.adapt(at * CHUNK, (at + n) * CHUNK);
    }

    #[test]
    fn the_window_grows_with_the_links_own_loss_and_shrinks_when_loss_jumps() {
        let mut t = Transfer::new(
            0,
            LogEntry {
                id: 2,
                time_utc: 0,
                size: 10_000_000,
            },
            "/d/x".into(),
        );
        assert_eq!(t.window, START_WINDOW);
        // Nothing lost: doubled each window, up to the largest.
        window_ends(&mut t, 0, 64, 0);
        assert_eq!((t.window, t.loss), (128, Some(0.0)));
        // A quarter lost where none was: a jump of more than 15 points, halved.
        window_ends(&mut t, 64, 128, 4);
        assert_eq!(t.window, 64);
        // L = (3·0 + 0.25) / 4 = 0.0625; a quarter again is 18.75 points above: halved again.
        window_ends(&mut t, 192, 64, 4);
        assert_eq!(t.window, 32);
        // L = (3·0.0625 + 0.25) / 4 = 0.109375; a quarter is within 15 points, beyond 5: kept.
        window_ends(&mut t, 256, 32, 4);
        assert_eq!(t.window, 32);
        // The same quarter lost, window after window: L comes up to it (0.145, 0.171, 0.191,
        // 0.206); once the loss is within 5 points of L (0.25 ≤ 0.206 + 0.05) it is the link's
        // own: doubled.
        for w in [32, 32, 32, 64] {
            window_ends(&mut t, 1000, 32, 4);
            assert_eq!(t.window, w, "loss {:?}", t.loss);
        }
        // Steady at that loss: grows to the largest, and stays there.
        for w in [128, 256, 512, 512] {
            window_ends(&mut t, 2000, 32, 4);
            assert_eq!(t.window, w);
        }
        // Two thirds lost where the link usually loses 60 %: more than half, halved.
        t.loss = Some(0.6);
        window_ends(&mut t, 3000, 60, 3);
        assert!(t.window == 512 && t.loss.is_some());
        t.loss = Some(0.6);
        let mut u = t.clone();
        for k in 0..64 {
            if k % 3 == 0 {
                u.have.insert((4000 + k) * CHUNK, (4001 + k) * CHUNK);
            }
        }
        u.adapt(4000 * CHUNK, 4064 * CHUNK);
        assert_eq!(u.window, 256);
        // Never below the smallest.
        let mut v = t.clone();
        v.window = MIN_WINDOW;
        v.loss = Some(0.0);
        window_ends(&mut v, 5000, 64, 2);
        assert_eq!(v.window, MIN_WINDOW);
    }

    #[test]
    fn the_wait_follows_the_measured_round_trip_and_pace_and_backs_off_on_silence() {
        // 20 chunks: one request of all of them (the first window is 64).
        let size = 20 * CHUNK;
        let (mut m, mut out) = downloading(size, 0, Some(0));
        m.poll(0, &mut out);
        assert_eq!(data_requests(&mut out), vec![(0, size)]);
        // Before anything came: the wait of an unknown round trip, 1 s (+ 4 × 0 variation).
        assert_eq!(m.next_deadline(), Some(SECOND));
        // The first chunk after 200 ms: SRTT 200 ms, RTTVAR 100 ms; the second 10 ms later.
        m.on_message(&incoming(200_000, &data2(0)), &mut out);
        m.on_message(&incoming(210_000, &data2(CHUNK)), &mut out);
        let t = m.transfer.as_ref().unwrap();
        assert_eq!(
            (t.srtt, t.rttvar, t.per_chunk),
            (Some(200_000), 100_000, Some(10_000))
        );
        // Streaming: the 18 chunks left at 10 ms each after the last, and slack of
        // max(4 × 10 ms, 4 × RTTVAR, 100 ms) = 400 ms.
        assert_eq!(m.next_deadline(), Some(210_000 + 180_000 + 400_000));
        // Nothing more came: the rest is a gap, asked at once in one request.
        m.poll(790_000, &mut out);
        assert_eq!(data_requests(&mut out), vec![(2 * CHUNK, 18 * CHUNK)]);
        assert_eq!(m.transfer.as_ref().unwrap().retries, 1);
        // Its wait: SRTT + 4 × RTTVAR = 600 ms.
        assert_eq!(m.next_deadline(), Some(790_000 + 600_000));
        // Nothing at all: the same request again, the window halved (it was halved already
        // when the first window ended with 18 of its 20 chunks lost, more than half), the wait
        // doubled.
        m.poll(1_390_000, &mut out);
        assert_eq!(data_requests(&mut out), vec![(2 * CHUNK, 18 * CHUNK)]);
        let t = m.transfer.as_ref().unwrap();
        assert_eq!((t.window, t.retries), (START_WINDOW / 4, 2));
        assert_eq!(m.next_deadline(), Some(1_390_000 + 1_200_000));
        // Its answer measures no round trip (it may answer the one before).
        m.on_message(&incoming(1_500_000, &data2(2 * CHUNK)), &mut out);
        assert_eq!(m.transfer.as_ref().unwrap().srtt, Some(200_000));
        // Silence again: the wait doubles each time, up to 5 s.
        let mut m2 = m.clone();
        let mut at = 1_500_000;
        m2.poll(at + 2 * SECOND, &mut out);
        at += 2 * SECOND;
        let mut waits = Vec::new();
        for _ in 0..5 {
            let d = m2.next_deadline().unwrap();
            waits.push(d - at);
            m2.poll(d, &mut out);
            at = d;
        }
        assert_eq!(
            waits,
            vec![600_000, 1_200_000, 2_400_000, 4_800_000, 5 * SECOND]
        );
    }

    fn data2(ofs: u32) -> MavMessage {
        MavMessage::LOG_DATA(LOG_DATA_DATA {
            ofs,
            id: 2,
            count: 90,
            data: [7; 90],
        })
    }

    #[test]
    fn a_gap_and_the_new_window_after_it_go_in_one_request_when_a_round_trip_costs_more() {
        let (mut m, mut out) = downloading(1000 * CHUNK, 0, Some(0));
        {
            let t = m.transfer.as_mut().unwrap();
            // RTT 100 ms, the vehicle sending a chunk every 10 ms: 10 chunks' worth of merging.
            t.srtt = Some(100_000);
            t.per_chunk = Some(10_000);
            t.window = 64;
            t.have.insert(0, 10 * CHUNK);
            t.have.insert(11 * CHUNK, 20 * CHUNK);
            t.have.insert(40 * CHUNK, 50 * CHUNK);
            t.written = 10 * CHUNK;
            t.high = 50 * CHUNK;
        }
        let t = m.transfer.as_ref().unwrap();
        assert_eq!(t.merge_bytes(), 10 * CHUNK);
        // Gaps 10..11 and 20..40 are 9 chunks apart: one request; the new window after 50 is
        // 10 chunks from 40: merged too, up to 64 chunks from the first gap.
        assert_eq!(t.next_request(), Some((10 * CHUNK, 74 * CHUNK)));
        // A slower round trip against the pace merges less: 50 ms = 5 chunks.
        let mut t = t.clone();
        t.srtt = Some(50_000);
        assert_eq!(t.next_request(), Some((10 * CHUNK, 11 * CHUNK)));
        m.poll(0, &mut out);
        assert_eq!(data_requests(&mut out), vec![(10 * CHUNK, 64 * CHUNK)]);
        // Re-asked data: a retry.
        assert_eq!(m.transfer.as_ref().unwrap().retries, 1);
    }

    #[test]
    fn a_download_with_no_data_and_no_vehicle_heard_gives_up_and_goes_on_when_heard_again() {
        let (mut m, mut out) = downloading(100 * CHUNK, 0, Some(0));
        m.poll(0, &mut out);
        assert_eq!(data_requests(&mut out).len(), 1);
        // Nothing for GIVE_UP, the vehicle last heard at 0: the link is gone.
        let mut at = 0;
        while let Some(d) = m.next_deadline().filter(|d| *d < GIVE_UP) {
            m.poll(d, &mut out);
            at = d;
        }
        assert!(at < GIVE_UP);
        assert_eq!(m.next_deadline(), Some(GIVE_UP));
        out.clear();
        m.poll(GIVE_UP, &mut out);
        let t = m.transfer.as_ref().unwrap();
        assert!(
            matches!(&t.state, State::Failed(w) if w.contains("not heard") && w.contains("heard again")),
            "{:?}",
            t.state
        );
        assert!(sends(&mut out)
            .iter()
            .any(|m| matches!(m, MavMessage::LOG_REQUEST_END(_))));
        assert_eq!(m.waiting_for_link, Some(GIVE_UP));
        assert_eq!(m.queue.front().map(|q| q.id), Some(2));
        // Heard before the failure only: still waiting; heard after it: started again.
        m.set_route(GIVE_UP + SECOND, Some(GIVE_UP), &mut out);
        assert!(m.take_io().is_empty());
        m.set_route(GIVE_UP + 2 * SECOND, Some(GIVE_UP + SECOND), &mut out);
        assert!(
            matches!(&m.take_io()[..], [LogIo::Open { max, .. }] if *max == 100 * CHUNK as u64)
        );
        assert_eq!(m.transfer.as_ref().unwrap().state, State::Opening);
        assert!(m.queue.is_empty() && m.waiting_for_link.is_none());
    }

    #[test]
    fn a_download_with_no_data_while_the_vehicle_is_heard_fails_and_the_next_goes() {
        let (mut m, mut out) = downloading(100 * CHUNK, 0, Some(0));
        m.list.entries.insert(
            3,
            LogEntry {
                id: 3,
                time_utc: 0,
                size: 500,
            },
        );
        m.get(0, 3, None, false).unwrap();
        m.poll(0, &mut out);
        m.set_route(GIVE_UP - SECOND, Some(GIVE_UP - SECOND), &mut out);
        m.poll(GIVE_UP, &mut out);
        let failed = &m.history.last().unwrap().2;
        assert!(
            matches!(failed, State::Failed(w) if w.contains("though the vehicle is heard") && w.contains("`log get 2`")),
            "{failed:?}"
        );
        assert!(m.waiting_for_link.is_none());
        // The queue goes on: log 3.
        assert_eq!(m.transfer.as_ref().unwrap().entry.id, 3);
    }

    #[test]
    fn nothing_goes_on_a_high_latency_link_unless_asked_there_and_a_download_pauses() {
        let (mut m, mut out) = downloading(100 * CHUNK, 0, Some(0));
        m.poll(0, &mut out);
        assert!(out.iter().all(|o| matches!(
            o,
            Out::Send {
                route: Route::Auto,
                ..
            }
        )));
        out.clear();
        // Only the high-latency link is left: paused; no request, no give-up.
        m.set_route(SECOND, None, &mut out);
        assert!(m.transfer.as_ref().unwrap().paused.is_some());
        assert!(sends(&mut out).is_empty());
        assert_eq!(m.next_deadline(), None);
        m.poll(100 * SECOND, &mut out);
        assert!(sends(&mut out).is_empty());
        assert_eq!(m.transfer.as_ref().unwrap().state, State::Running);
        // Back: END (the vehicle may be sending the old request into the lost link), then
        // the rest asked at once.
        m.set_route(101 * SECOND, Some(101 * SECOND), &mut out);
        assert!(m.next_deadline().unwrap() <= 101 * SECOND, "due at once");
        m.poll(101 * SECOND, &mut out);
        let sent = sends(&mut out);
        assert!(matches!(
            &sent[..],
            [MavMessage::LOG_REQUEST_END(_), MavMessage::LOG_REQUEST_DATA(r)] if r.ofs == 0
        ));
        // Asked with `--hl`: on the vehicle's route, and never paused.
        let (mut h, mut out) = downloading(100 * CHUNK, 0, None);
        h.transfer.as_mut().unwrap().paused = None;
        h.cancel(0, &mut out).unwrap();
        out.clear();
        h.get(0, 2, None, true).unwrap();
        let partial = h.transfer.as_ref().unwrap().partial.clone();
        h.on_io(0, LogIoDone::Opened { partial, have: 0 }, &mut out);
        h.poll(0, &mut out);
        assert!(h.transfer.as_ref().unwrap().paused.is_none());
        assert!(matches!(
            &out[..],
            [Out::Send {
                route: Route::Vehicle,
                msg: MavMessage::LOG_REQUEST_DATA(_)
            }]
        ));
    }

    #[test]
    fn the_rate_falls_and_the_download_shows_stalled_while_nothing_comes() {
        let (mut m, mut out) = downloading(1000 * CHUNK, 0, Some(0));
        m.poll(0, &mut out);
        // 10 chunks a second for 4 s: 900 B/s.
        for k in 0..40u32 {
            m.on_message(
                &incoming(100_000 * (k as u64 + 1), &data2(k * CHUNK)),
                &mut out,
            );
        }
        let t = m.transfer.as_ref().unwrap();
        let now = 4 * SECOND;
        assert_eq!(t.rate(now).map(|r| r.round()), Some(900.0));
        assert_eq!(
            t.eta(now).map(|e| e.round()),
            Some(((1000 - 40) as f64 * 90.0 / 900.0).round())
        );
        assert_eq!(t.stalled(now + STALLED - 1), None);
        // Nothing for 2 s: 1 s of the last 3 had data (10 chunks): 300 B/s; no ETA, stalled.
        let later = now + 2 * SECOND;
        assert_eq!(t.rate(later).map(|r| r.round()), Some(300.0));
        assert_eq!(t.eta(later), None);
        assert_eq!(t.stalled(later), Some(2 * SECOND));
        assert_eq!(
            t.progress_text(later),
            "3.6 kB/90.0 kB 4% stalled 2 s retries 0"
        );
        // Nothing for 3 s: none in the last 3 s.
        assert_eq!(t.rate(now + 3 * SECOND), Some(0.0));
        // While it streams: the rate and the ETA.
        assert_eq!(
            t.progress_text(now),
            "3.6 kB/90.0 kB 4% 900 B/s ETA 1 min 36 s retries 0"
        );
    }
}
