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
//! The transfer: requests of new data in windows that grow while little is lost and shrink
//! when much is; what the vehicle skipped (a later offset came first) is a gap, and gaps are
//! asked again with the next request, before new data, neighbouring gaps merged into one
//! request when what lies between them costs less to receive again than a round trip. Data is
//! kept in memory only beyond the contiguous prefix (bounded); the prefix goes to the file as
//! [`LogIo::Write`] (the driver writes it into `NAME.partial`), so what is on disk is always a
//! prefix of the log and a download resumes from its size. Done when the prefix is the size
//! LOG_ENTRY gave: the partial is renamed ([`LogIo::Finish`]).

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
/// Without any data for this long a download fails (it resumes from the disk when asked again).
pub const GIVE_UP: Micros = 60 * SECOND;
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
    /// one is cut); its directory is made.
    Open { partial: PathBuf, max: u64 },
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
    sent: Micros,
    /// The last chunk of it heard (time, end offset).
    last: Option<(Micros, u32)>,
    /// Asked again (a gap or a timed-out request).
    again: bool,
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
    /// Consecutive timeouts without data.
    silent: u32,
    pub started: Micros,
    pub finished: Option<Micros>,
    last_data: Micros,
    /// When the next request may go (the `log_rate` cap).
    next_allowed: Micros,
    /// The `log_rate` cap (bytes a second): windows of at most half a second of it.
    pub rate_cap: Option<u32>,
    /// Recent (time, bytes here) samples for the rate.
    samples: VecDeque<(Micros, u32)>,
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
            started: now,
            finished: None,
            last_data: now,
            next_allowed: now,
            rate_cap: None,
            samples: VecDeque::new(),
        }
    }

    /// Bytes here (written, and held ahead).
    pub fn got(&self) -> u32 {
        self.have.0.iter().map(|(a, b)| b - a).sum()
    }

    /// Bytes a second over the last few seconds (new bytes only).
    pub fn rate(&self) -> Option<f64> {
        let (t0, b0) = *self.samples.front()?;
        let (t1, b1) = *self.samples.back()?;
        if t1 <= t0 + SECOND / 4 {
            return None;
        }
        Some((b1 - b0) as f64 * 1e6 / (t1 - t0) as f64)
    }

    /// Seconds left at the current rate.
    pub fn eta(&self) -> Option<f64> {
        let r = self.rate().filter(|r| *r > 0.0)?;
        Some((self.entry.size - self.got().min(self.entry.size)) as f64 / r)
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

    /// The next request: gaps first (neighbours merged when what lies between costs less than
    /// a round trip), else a window of new data; `None` when nothing is left to ask.
    fn next_request(&self) -> Option<(u32, u32, bool)> {
        let size = self.entry.size;
        let holes = self.have.holes(self.written, self.high.min(size));
        if let Some(&(a, mut b)) = holes.first() {
            let rate = self.rate().unwrap_or(1000.0);
            let rtt = self.srtt.unwrap_or(100_000) as f64 / 1e6;
            let merge = (rate * rtt) as u32;
            let cap = self.window * CHUNK;
            for &(x, y) in &holes[1..] {
                if x - b > merge || y - a > cap {
                    break;
                }
                b = y;
            }
            return Some((a, b, true));
        }
        let from = self.high.max(self.written);
        if from >= size {
            return None;
        }
        if from - self.written >= MAX_AHEAD {
            return None;
        }
        let window = match self.rate_cap {
            Some(c) => self.window.min((c / 2 / CHUNK).max(MIN_WINDOW)),
            None => self.window,
        };
        let n = (window * CHUNK).min(size - from);
        Some((from, from + n, false))
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
    /// Downloads waiting: (id, where to; `None`: the default place).
    pub queue: VecDeque<(u16, Option<PathBuf>)>,
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
    /// A list asked again after an erase, at this time.
    relist_at: Option<Micros>,
    /// A poll is due now (a request to send).
    due: Option<Micros>,
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

    fn send(&self, msg: MavMessage, out: &mut Vec<Out>) {
        out.push(Out::send(Route::Vehicle, msg));
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
            out,
        );
    }

    /// The operator asks for the list (again): what was heard is kept, the whole is asked.
    pub fn refresh(&mut self, now: Micros, out: &mut Vec<Out>) -> Result<(), Refusal> {
        if self.transfer.as_ref().is_some_and(|t| t.active()) {
            return Err("a log download is running: the list is asked when it ends".into());
        }
        self.list = Listing {
            wanted: true,
            started: now,
            ..Listing::default()
        };
        self.list_request(now, 0, 0xFFFF, out);
        Ok(())
    }

    /// Download log `id` (or queue it behind the one running) into `path` (default place when
    /// `None`).
    pub fn get(&mut self, now: Micros, id: u16, path: Option<PathBuf>) -> Result<String, Refusal> {
        let Some(e) = self.list.entries.get(&id).copied() else {
            return Err(format!("no log {id} in the list (refresh it first)"));
        };
        if path.is_none() && self.dir.is_none() {
            return Err("no data directory: give a file".into());
        }
        if self.transfer.as_ref().is_some_and(|t| t.active()) {
            if self.transfer.as_ref().is_some_and(|t| t.entry.id == id)
                || self.queue.iter().any(|(q, _)| *q == id)
            {
                return Err(format!("log {id} is already on its way"));
            }
            self.queue.push_back((id, path));
            return Ok(format!("log {id} queued ({} waiting)", self.queue.len()));
        }
        self.start(now, e, path);
        Ok(format!("downloading log {id} ({} bytes)", e.size))
    }

    fn start(&mut self, now: Micros, e: LogEntry, path: Option<PathBuf>) {
        let Some(path) = path.or_else(|| self.default_path(&e)) else {
            return;
        };
        let mut t = Transfer::new(now, e, path);
        t.rate_cap = self.rate_cap.filter(|c| *c > 0);
        self.io.push(LogIo::Open {
            partial: t.partial.clone(),
            max: e.size as u64,
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

    /// LOG_ERASE: every log on the vehicle (the operator confirmed). The list is asked again.
    pub fn erase(&mut self, now: Micros, out: &mut Vec<Out>) -> Result<(), Refusal> {
        if self.transfer.as_ref().is_some_and(|t| t.active()) {
            return Err("a log download is running: cancel it first".into());
        }
        self.send(
            MavMessage::LOG_ERASE(LOG_ERASE_DATA {
                target_system: self.key.0,
                target_component: self.key.1,
            }),
            out,
        );
        self.list = Listing::default();
        self.relist_at = Some(now + SECOND);
        Ok(())
    }

    fn end_transfer(&mut self, out: &mut Vec<Out>) {
        self.send(
            MavMessage::LOG_REQUEST_END(LOG_REQUEST_END_DATA {
                target_system: self.key.0,
                target_component: self.key.1,
            }),
            out,
        );
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
        self.next_in_queue(now);
    }

    fn next_in_queue(&mut self, now: Micros) {
        while let Some((id, path)) = self.queue.pop_front() {
            if let Some(e) = self.list.entries.get(&id).copied() {
                self.start(now, e, path);
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
            t.finished = Some(now);
            self.io.push(LogIo::Finish {
                partial: t.partial.clone(),
                path: t.path.clone(),
                size: t.entry.size as u64,
            });
            self.send(
                MavMessage::LOG_REQUEST_END(LOG_REQUEST_END_DATA {
                    target_system: self.key.0,
                    target_component: self.key.1,
                }),
                out,
            );
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
        if let Some(mut r) = t.req {
            if ofs >= r.ofs && ofs < r.end.max(r.ofs + 1) {
                match r.last {
                    None if ofs == r.ofs && !r.again => {
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
        t.samples.push_back((now, got));
        while t
            .samples
            .front()
            .is_some_and(|(s, _)| *s + 3 * SECOND < now)
            && t.samples.len() > 2
        {
            t.samples.pop_front();
        }
        // The request's last chunk: the next goes at once.
        if t.req.is_some_and(|r| end >= r.end || ofs >= r.end) {
            let r = t.req.take().expect("checked");
            if !r.again {
                t.adapt(r.ofs, r.end);
            }
            self.due = Some(now);
        }
        self.check_complete(now, out);
    }
}

impl Transfer {
    /// A window of new data ended: grow when little of it was lost, shrink when much was.
    fn adapt(&mut self, a: u32, b: u32) {
        let lost = self.have.missing_in(a, b) as f64 / (b - a).max(1) as f64;
        if lost < 0.05 {
            self.window = (self.window * 2).min(MAX_WINDOW);
        } else if lost > 0.25 {
            self.window = (self.window / 2).max(MIN_WINDOW);
        }
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
        if self.relist_at.is_some_and(|t| now >= t) {
            self.relist_at = None;
            let _ = self.refresh(now, out);
        }
        self.poll_list(now, out);
        self.poll_transfer(now, out);
    }

    fn next_deadline(&self) -> Option<Micros> {
        let list = self
            .list
            .asked
            .filter(|_| !self.list.ended)
            .map(|(_, _, sent, last, _)| {
                // Entries come a few tens of ms apart; a second of silence ends a listing.
                sent.max(last) + SECOND
            });
        let list_more = (self.list.wanted
            && self.list.asked.is_none()
            && !self.list.complete()
            && self.list.failed.is_none()
            && self.list.num_logs.is_some())
        .then_some(self.list.started);
        let t = self.transfer.as_ref().filter(|t| t.state == State::Running);
        let tr = t.and_then(|t| match t.req {
            Some(_) => t.deadline(),
            None if t.next_request().is_some() => Some(t.next_allowed),
            None => None,
        });
        let give_up = t.map(|t| t.last_data + GIVE_UP);
        [self.due, self.relist_at, list, list_more, tr, give_up]
            .into_iter()
            .flatten()
            .min()
    }
}

impl LogMachine {
    fn poll_list(&mut self, now: Micros, out: &mut Vec<Out>) {
        let l = &self.list;
        if !l.wanted || l.failed.is_some() {
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
        let Some(&(a, b)) = self.list.missing().first() else {
            return;
        };
        // The same range again counts its tries (`list_request` compares with the last).
        self.list.retries += 1;
        self.list_request(now, a, b, out);
    }

    fn poll_transfer(&mut self, now: Micros, out: &mut Vec<Out>) {
        let cap = self.rate_cap;
        let key = self.key;
        let Some(t) = self.transfer.as_mut().filter(|t| t.state == State::Running) else {
            return;
        };
        if now >= t.last_data + GIVE_UP {
            let why = format!(
                "no data for {} s ({} of {} bytes kept in {})",
                GIVE_UP / SECOND,
                t.written,
                t.entry.size,
                t.partial.display()
            );
            self.fail(now, why, out);
            return;
        }
        if let Some(r) = t.req {
            if t.deadline().is_some_and(|d| now < d) {
                return;
            }
            // Timed out: its tail is lost (a gap now) or the request itself was.
            t.req = None;
            t.retries += 1;
            if r.last.is_none() {
                t.silent += 1;
                t.window = (t.window / 2).max(MIN_WINDOW);
            } else {
                t.high = t.high.max(r.end.min(t.entry.size));
                if !r.again {
                    t.adapt(r.ofs, r.end);
                }
            }
            // Asked again now: the same one when nothing came, else the gaps it left.
            if r.last.is_none() {
                return self.ask(now, r.ofs, r.end, true, cap, out);
            }
        }
        if now < t.next_allowed {
            return;
        }
        let _ = key;
        if let Some((a, b, again)) = t.next_request() {
            self.ask(now, a, b, again, cap, out);
        }
    }

    fn ask(
        &mut self,
        now: Micros,
        a: u32,
        b: u32,
        again: bool,
        cap: Option<u32>,
        out: &mut Vec<Out>,
    ) {
        let Some(t) = self.transfer.as_mut() else {
            return;
        };
        t.requests += 1;
        if again {
            t.retries += 1;
        }
        t.req = Some(Req {
            ofs: a,
            end: b,
            sent: now,
            last: None,
            again,
        });
        if let Some(c) = cap.filter(|c| *c > 0) {
            let span = (b - a) as u64 * SECOND / c as u64;
            t.next_allowed = t.next_allowed.max(now) + span;
        }
        let id = t.entry.id;
        self.send(
            MavMessage::LOG_REQUEST_DATA(LOG_REQUEST_DATA_DATA {
                ofs: a,
                count: b - a,
                id,
                target_system: self.key.0,
                target_component: self.key.1,
            }),
            out,
        );
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
        m.refresh(0, &mut out).unwrap();
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
        let mut m = LogMachine::new(VehicleKey(1, 1));
        m.dir = Some(PathBuf::from("/d"));
        m.list.entries.insert(
            2,
            LogEntry {
                id: 2,
                time_utc: 0,
                size: 900,
            },
        );
        let mut out = Vec::new();
        m.get(0, 2, None).unwrap();
        let io = m.take_io();
        assert_eq!(
            io,
            vec![LogIo::Open {
                partial: PathBuf::from("/d/log2_no-time.bin.partial"),
                max: 900
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
}
