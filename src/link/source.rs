//! In-process links: something that produces and consumes link bytes on a clock it is handed
//! (the simulated vehicle, a tlog replay). The same source runs on the virtual clock of headless
//! replay and, in real time, behind a link task for the terminal.

use std::io::{self, BufReader, Read, Seek, SeekFrom};
use std::sync::Arc;

use chrono::{DateTime, Utc};

use super::replay::{ReplayCmd, ReplaySpeed, ReplayStatus};
use super::spec::LinkSpec;
use super::tlog::{TlogError, TlogReader, TlogRecord};
use crate::clock::{Micros, SECOND};

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
    /// A replay control from the operator, at `now`. Sources that are not replays ignore it.
    fn control(&mut self, _now: Micros, _cmd: ReplayCmd) {}
    /// Where the replay is, when that changed since the last call (see [`ReplayStatus`]);
    /// always `None` for sources that are not replays.
    fn take_status(&mut self, _now: Micros) -> Option<ReplayStatus> {
        None
    }
    /// Where the replay is now; `None` for sources that are not replays.
    fn replay_status(&self) -> Option<ReplayStatus> {
        None
    }
    /// True when nothing the source emits may be dropped: a replay waits for the core instead
    /// (a live source, like a real vehicle, loses what a full queue cannot take).
    fn lossless(&self) -> bool {
        false
    }
}

/// Builds the source for an in-process link spec; the error is the link's "down" reason. Made by
/// the driver, which knows the simulator; links only run what it builds.
pub type SourceFactory =
    Arc<dyn Fn(&LinkSpec) -> Result<Box<dyn VirtualSource>, String> + Send + Sync>;

/// Bytes of frames a replay hands on at most per [`VirtualSource::poll`]: as fast as possible,
/// a log goes by in pieces of this size, so what waits for the core stays small.
pub const REPLAY_CHUNK: usize = 16 * 1024;
/// Bytes at the end of a log read on opening to find its last record (its duration).
const TAIL: u64 = 64 * 1024;
/// Entries the seek index keeps at most: past this, every other one goes and the spacing
/// doubles, so a log of any length is indexed in bounded memory.
pub const SEEK_INDEX_MAX: usize = 4096;

/// A jump in log time longer than this between two records (forward, or back by more than a
/// second: a flipped bit in a timestamp, two sessions in one file) is skipped: the replay takes
/// the next record [`GAP_SHOWN`] after the one before, so no gap is waited for and a replay's
/// cost does not grow with a gap's size.
pub const GAP_SKIP: Micros = 60 * SECOND;
/// How far apart two records across a skipped gap are replayed.
pub const GAP_SHOWN: Micros = SECOND;

/// Where a replay reads from: a file can move (seek back), a stream cannot.
pub trait TlogInput: Read + Send {
    /// Move to `offset`; a stream says it cannot.
    fn seek_to(&mut self, _offset: u64) -> io::Result<()> {
        Err(io::Error::new(
            io::ErrorKind::Unsupported,
            "this replay is a stream, not a file",
        ))
    }
}

struct Seekable<R>(R);
impl<R: Read> Read for Seekable<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        self.0.read(buf)
    }
}
impl<R: Read + Seek + Send> TlogInput for Seekable<R> {
    fn seek_to(&mut self, offset: u64) -> io::Result<()> {
        self.0.seek(SeekFrom::Start(offset)).map(|_| ())
    }
}

struct Stream<R>(R);
impl<R: Read> Read for Stream<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        self.0.read(buf)
    }
}
impl<R: Read + Send> TlogInput for Stream<R> {}

/// Log times and file offsets of records, about one a second of log time at first (sparser as
/// the log gets long): where to start reading to reach a log time.
#[derive(Debug, Clone)]
pub struct SeekIndex {
    /// (log time, offset of the record), both increasing.
    entries: Vec<(Micros, u64)>,
    every: Micros,
}

impl Default for SeekIndex {
    fn default() -> Self {
        Self {
            entries: Vec::new(),
            every: SECOND,
        }
    }
}

impl SeekIndex {
    /// Note the record at `offset`, at log time `t`, read in file order.
    fn add(&mut self, t: Micros, offset: u64) {
        if let Some(&(lt, lo)) = self.entries.last() {
            if offset <= lo || t < lt + self.every {
                return;
            }
        }
        self.entries.push((t, offset));
        if self.entries.len() > SEEK_INDEX_MAX {
            let mut i = 0;
            self.entries.retain(|_| {
                i += 1;
                i % 2 == 1
            });
            self.every *= 2;
        }
    }

    /// The last entry at or before log time `t` (the first one if none is).
    fn before(&self, t: Micros) -> Option<(Micros, u64)> {
        let i = self.entries.partition_point(|e| e.0 <= t);
        self.entries.get(i.saturating_sub(1)).copied()
    }

    pub fn len(&self) -> usize {
        self.entries.len()
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

/// Replays a tlog, streamed from its reader: only the next record is held (read ahead to know
/// when it is due), so a log of any size replays in constant memory. What the reader skips
/// ([`TlogReader`]) is counted ([`VirtualSource::skipped`]).
///
/// Its clock is the log's (record times since the first record), mapped onto the clock it is
/// polled with by an anchor (a core time and the log time then) and a speed; see
/// [`ReplayCmd`] for what moves it. A file is indexed as it is read ([`SeekIndex`]), so a seek
/// back rereads from a second or so before the target; a stream cannot seek back.
pub struct TlogSource {
    reader: TlogReader<Box<dyn TlogInput>>,
    /// The next record to emit; `None` once the log has ended.
    next: Option<TlogRecord>,
    /// Offset in the file of `next`.
    next_offset: u64,
    t0: u64,
    /// Records emitted so far.
    emitted: u64,
    /// Log time of the last record, when known.
    duration: Option<Micros>,
    index: SeekIndex,
    speed: ReplaySpeed,
    paused: bool,
    /// (core time, log time then); `None` until first polled.
    anchor: Option<(Micros, Micros)>,
    /// The time of the last poll or control.
    last_now: Micros,
    /// Log time of the last record emitted, or where a seek landed.
    position: Micros,
    /// Records still to hand on while paused (step).
    steps: u32,
    seeks: u32,
    note: Option<String>,
    /// The status last reported and when, and whether the position moved by a jump since.
    reported: Option<(Micros, ReplayStatus)>,
    jumped: bool,
    /// Log time of `next` (gaps skipped: see [`GAP_SKIP`]).
    next_t: Micros,
    /// Log time taken out by the gaps skipped so far (negative: a jump back taken out).
    skew: i128,
    /// The raw log time (since the first record) of the last record read.
    last_raw: Micros,
    /// After a seek back by the index: the log time the next record read is at.
    resync: Option<Micros>,
    /// Gaps skipped.
    pub gaps_skipped: u64,
}

impl std::fmt::Debug for TlogSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TlogSource")
            .field("next", &self.next)
            .field("t0", &self.t0)
            .field("emitted", &self.emitted)
            .field("skipped", &self.reader.skipped())
            .field("speed", &self.speed)
            .field("paused", &self.paused)
            .field("position", &self.position)
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

/// The time of the last record in the last [`TAIL`] bytes of `file`.
fn last_record_time(file: &mut std::fs::File) -> io::Result<Option<u64>> {
    let len = file.metadata()?.len();
    let start = len.saturating_sub(TAIL);
    file.seek(SeekFrom::Start(start))?;
    let tail = Read::take(&mut *file, TAIL);
    let reader = if start == 0 {
        TlogReader::new(tail)
    } else {
        TlogReader::resync(tail, start)
    };
    let mut last = None;
    for r in reader {
        last = Some(r?.time_us);
    }
    file.seek(SeekFrom::Start(0))?;
    Ok(last)
}

/// A log whose first this many bytes hold no record is refused at open ([`TlogError::NoRecords`]).
pub const OPEN_GIVE_UP: u64 = 4 * 1024 * 1024;

impl TlogSource {
    /// Replay the tlog at `path`, read through a buffer as it plays, at real time.
    ///
    /// Only a regular file is replayed: a device (`/dev/zero` would be garbage for ever) or a
    /// FIFO is refused before it is opened.
    pub fn open(path: impl AsRef<std::path::Path>) -> Result<Self, TlogOpenError> {
        if !std::fs::metadata(path.as_ref())?.is_file() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                "not a regular file (a device, FIFO, socket or directory): refused",
            )
            .into());
        }
        let mut file = std::fs::File::open(path)?;
        let last = last_record_time(&mut file)?;
        let input: Box<dyn TlogInput> = Box::new(Seekable(BufReader::new(file)));
        let mut src = Self::from_input(input)?;
        src.duration = last.map(|l| l.saturating_sub(src.t0));
        Ok(src)
    }

    /// Replay the tlog `r` yields, at real time: a stream, which cannot seek back nor tell its
    /// duration. The first record is read now (its time is the replay's start); a stream with
    /// bytes but not one record is not a tlog ([`TlogError::NoRecords`]).
    pub fn from_reader(r: impl Read + Send + 'static) -> Result<Self, TlogOpenError> {
        Self::from_input(Box::new(Stream(r)))
    }

    fn from_input(input: Box<dyn TlogInput>) -> Result<Self, TlogOpenError> {
        let mut reader = TlogReader::new(input);
        // A file that starts with OPEN_GIVE_UP bytes holding no record is not a tlog.
        reader.give_up_after(Some(OPEN_GIVE_UP));
        let next = reader.next().transpose()?;
        reader.give_up_after(None);
        if next.is_none() && reader.offset() > 0 {
            return Err(TlogError::NoRecords {
                bytes: reader.offset(),
            }
            .into());
        }
        let t0 = next.as_ref().map_or(0, |r| r.time_us);
        let next_offset = next
            .as_ref()
            .map_or(0, |r| reader.offset() - (8 + r.frame.len()) as u64);
        let mut index = SeekIndex::default();
        if next.is_some() {
            index.add(0, next_offset);
        }
        Ok(Self {
            reader,
            next,
            next_offset,
            t0,
            emitted: 0,
            duration: None,
            index,
            speed: ReplaySpeed::REAL_TIME,
            paused: false,
            anchor: None,
            last_now: 0,
            position: 0,
            steps: 0,
            seeks: 0,
            note: None,
            reported: None,
            jumped: false,
            next_t: 0,
            skew: 0,
            last_raw: 0,
            resync: None,
            gaps_skipped: 0,
        })
    }

    /// The same replay at `speed`.
    pub fn with_speed(mut self, speed: ReplaySpeed) -> Self {
        self.speed = speed;
        self
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

    /// The seek index (its size is bounded by [`SEEK_INDEX_MAX`]).
    pub fn index(&self) -> &SeekIndex {
        &self.index
    }

    /// Log time of a record, gaps skipped so far taken out.
    fn rel(&self, r: &TlogRecord) -> Micros {
        (r.time_us.saturating_sub(self.t0) as i128 - self.skew).clamp(0, Micros::MAX as i128)
            as Micros
    }

    /// Take out of the log's time the gap before `r`, if it is one to skip, and note its time.
    fn skip_gap(&mut self, r: &TlogRecord) {
        let raw = r.time_us.saturating_sub(self.t0);
        if let Some(t) = self.resync.take() {
            self.skew = raw as i128 - t as i128;
        } else {
            let step = raw as i128 - self.last_raw as i128;
            if step > GAP_SKIP as i128 || step < -(SECOND as i128) {
                self.skew += step - GAP_SHOWN as i128;
                self.gaps_skipped += 1;
                self.note = Some(format!(
                    "skipped a jump of {:.0} s in the log's time",
                    step as f64 / SECOND as f64
                ));
            }
        }
        self.last_raw = raw;
        self.next_t = self.rel(r);
    }

    /// Read the record after the one just emitted or passed over. A read error ends the replay
    /// there (the records before it were good), with a note: a log on a failing disk plays
    /// what it can.
    fn advance(&mut self) {
        let at = self.reader.offset();
        self.next = match self.reader.next() {
            Some(Ok(r)) => {
                self.next_offset = self.reader.offset() - (8 + r.frame.len()) as u64;
                self.skip_gap(&r);
                self.index.add(self.next_t, self.next_offset);
                Some(r)
            }
            Some(Err(e)) => {
                tracing::warn!(offset = at, "tlog read: {e}");
                self.note = Some(format!(
                    "read error at byte {at}: {e}; the replay ends there"
                ));
                None
            }
            None => {
                if self.reader.ended_in_gap() {
                    self.note = Some(format!(
                        "no record in the {} MiB after byte {at}: the replay ends there",
                        super::tlog::MAX_GAP >> 20
                    ));
                }
                if self.gaps_skipped > 0 {
                    // The log's length, gaps skipped (the last record's time said more).
                    self.duration = Some(self.next_t);
                }
                None
            }
        };
    }

    /// Log time at core time `now`: where the replay is (at the end, the last record's time).
    fn log_now(&self, now: Micros) -> Micros {
        match self.anchor {
            None => 0,
            _ if self.next.is_none() => self.position,
            Some((_, l)) if self.paused => l,
            _ if self.speed.is_max() => self.position,
            Some((c, l)) => l + (now.saturating_sub(c) as f64 * self.speed.get()) as Micros,
        }
    }

    /// Core time at which log time `t` is due.
    fn due_at(&self, t: Micros) -> Micros {
        if self.steps > 0 {
            return self.last_now;
        }
        if self.paused {
            return Micros::MAX;
        }
        match self.anchor {
            None => 0,
            _ if self.speed.is_max() => self.last_now,
            Some((c, l)) if t <= l => c,
            Some((c, l)) => c.saturating_add(((t - l) as f64 / self.speed.get()).ceil() as Micros),
        }
    }

    /// Start the clock at the first call.
    fn touch(&mut self, now: Micros) {
        self.last_now = self.last_now.max(now);
        if self.anchor.is_none() {
            self.anchor = Some((now, 0));
        }
    }

    /// Go to log time `target`, handing on nothing on the way.
    fn seek_to(&mut self, now: Micros, target: Micros) {
        let here = self.log_now(now);
        if self.next.is_none() && target >= here {
            self.note = Some("end of log".into());
            return;
        }
        let back = target < here || self.next.is_none();
        let mark = self.index.before(target);
        // Read from the index's mark when going back, or when it is ahead of where we are.
        let jump = mark.filter(|&(_, off)| back || off > self.next_offset);
        if back && jump.is_none() {
            self.note = Some("cannot seek back: nothing indexed".into());
            return;
        }
        if let Some((t, off)) = jump {
            if let Err(e) = self.reader.get_mut().seek_to(off) {
                self.note = Some(format!("cannot seek: {e}"));
                return;
            }
            self.reader.restart_at(off);
            // The record there is at the log time the index gave it (gaps skipped before it).
            self.resync = Some(t);
            self.advance();
        }
        while self.next.is_some() {
            if self.next_t >= target {
                break;
            }
            self.advance();
        }
        self.position = match &self.next {
            Some(_) => target,
            None => self.duration.unwrap_or(target).min(target),
        };
        self.anchor = Some((now, self.position));
        self.steps = 0;
        self.seeks += 1;
        self.jumped = true;
    }

    fn status(&self, now: Micros) -> ReplayStatus {
        ReplayStatus {
            position: self.log_now(now),
            start: (self.next.is_some() || self.emitted > 0).then_some(self.t0),
            duration: self.duration,
            speed: self.speed,
            paused: self.paused,
            ended: self.next.is_none(),
            seeks: self.seeks,
            note: self.note.clone(),
        }
    }
}

impl VirtualSource for TlogSource {
    fn receive(&mut self, _now: Micros, _bytes: &[u8]) {}
    fn poll(&mut self, now: Micros) -> Vec<u8> {
        self.touch(now);
        let mut out = Vec::new();
        while let Some(r) = &self.next {
            let t = self.next_t;
            if self.due_at(t) > now || out.len() >= REPLAY_CHUNK {
                break;
            }
            out.extend_from_slice(&r.frame);
            self.emitted += 1;
            if self.steps > 0 {
                self.steps -= 1;
                self.anchor = Some((now, t));
                self.jumped = true;
            }
            self.position = t;
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
            .map_or(Micros::MAX, |_| self.due_at(self.next_t))
    }
    fn skipped(&self) -> u64 {
        self.reader.skipped().bytes
    }
    fn control(&mut self, now: Micros, cmd: ReplayCmd) {
        self.touch(now);
        let here = self.log_now(now);
        match cmd {
            ReplayCmd::TogglePause if self.paused => self.control(now, ReplayCmd::Resume),
            ReplayCmd::TogglePause | ReplayCmd::Pause => {
                if !self.paused {
                    self.anchor = Some((now, here));
                    self.paused = true;
                }
            }
            ReplayCmd::Resume => {
                if self.paused {
                    self.anchor = Some((now, here));
                    self.paused = false;
                    self.steps = 0;
                }
            }
            ReplayCmd::Step(n) => {
                if self.next.is_none() {
                    self.note = Some("end of log: nothing to step to".into());
                }
                if !self.paused {
                    self.anchor = Some((now, here));
                    self.paused = true;
                }
                self.steps = self.steps.saturating_add(n);
            }
            ReplayCmd::Seek(d) => {
                let target = if d < 0 {
                    here.saturating_sub(d.unsigned_abs())
                } else {
                    here.saturating_add(d as u64)
                };
                self.seek_to(now, target)
            }
            ReplayCmd::SeekTo(t) => self.seek_to(now, t),
            ReplayCmd::Speed(s) => {
                self.anchor = Some((now, here));
                self.speed = s;
            }
            ReplayCmd::Faster | ReplayCmd::Slower => {
                let s = if cmd == ReplayCmd::Faster {
                    self.speed.faster()
                } else {
                    self.speed.slower()
                };
                self.anchor = Some((now, here));
                self.speed = s;
            }
        }
    }
    fn take_status(&mut self, now: Micros) -> Option<ReplayStatus> {
        let st = self.status(now);
        let send = match &self.reported {
            None => true,
            Some((at, last)) => {
                self.jumped
                    || st.note.is_some()
                    || (st.duration, st.speed, st.paused, st.ended, st.seeks)
                        != (last.duration, last.speed, last.paused, last.ended, last.seeks)
                    // As fast as possible the position cannot be foreseen: about once a second.
                    || (st.speed.is_max() && st.position != last.position && now >= at + SECOND)
            }
        };
        if !send {
            return None;
        }
        self.jumped = false;
        self.note = None;
        self.reported = Some((now, st.clone()));
        Some(st)
    }
    fn replay_status(&self) -> Option<ReplayStatus> {
        Some(self.status(self.last_now))
    }
    fn lossless(&self) -> bool {
        true
    }
}
