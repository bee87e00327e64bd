//! Reading one file over MAVLink FTP, the GCS side: `@PARAM/param.pck` as MAVProxy and
//! QGroundControl read it from ArduPilot 4.1 on.
//!
//! The machine (sans-I/O: packets and time in, [`FtpOut`] out, [`FtpRead::next_deadline`]):
//! - **Open**: TerminateSession (a session left open by an earlier GCS run would make ArduPilot
//!   refuse the open), then OpenFileRO. No answer is retried; a NAK, or no answer after
//!   [`OPEN_TRIES`], fails the read (the caller falls back to the parameter protocol).
//! - **Burst**: one BurstReadFile from offset 0; the vehicle streams the file in blocks of
//!   [`BLOCK`] bytes. A short block or a NAK EOF tells where the file ends (the size in the open
//!   ACK is only an estimate on ArduPilot).
//! - **Gaps**: when the burst ends, or stalls (nothing for a gap adapted to the measured arrival
//!   rate), every missing block below the end is read with ReadFile, several in flight, each
//!   retried on a timeout adapted to the measured round trip. When the end is still unknown (a
//!   lost tail, or a vehicle that ends its bursts after a number of packets, as ArduPilot 4.x
//!   does after 100, flagging `burst_complete` on the last), the gaps are read first and then
//!   another burst goes on from the highest block received.
//! - **Done**: TerminateSession, and the whole file handed back. A `param.pck` whose blocks do
//!   not make a file is read again by the caller with a new read ([`pck_reread_path`]). A block that will not come after
//!   [`MAX_TRIES`] reads fails the transfer.
//! - **Left**: a read that failed, or that its caller gave up ([`FtpRead::abandon`]), sends
//!   TerminateSession; an open ACK that comes after that (the vehicle opened a session we no
//!   longer want) is answered with TerminateSession of that session, so none is left open.
//!
//! Blocks are aligned: the burst starts at 0 and every packet but the last carries a full block,
//! so a gap is always whole blocks, and ArduPilot's param.pck, padded so that no value straddles a
//! block boundary, is read with the one block size it was built for.

use std::collections::BTreeMap;

use crate::clock::{Micros, SECOND};

const MILLISECOND: Micros = 1_000;
use crate::wire::mavftp::{err, op, FtpPacket, DATA_LEN};

/// Block size asked for: the largest an FTP packet carries.
pub const BLOCK: usize = DATA_LEN;
/// OpenFileRO attempts before giving up on FTP, and when AUTOPILOT_VERSION announced FTP.
pub const OPEN_TRIES: u32 = 2;
pub const OPEN_TRIES_ANNOUNCED: u32 = 5;
/// Reads of one block before the transfer fails.
pub const MAX_TRIES: u32 = 6;
/// ReadFile requests in flight at once while filling gaps.
pub const WINDOW: usize = 6;
/// First answer timeout, before any round trip is measured.
const INITIAL_RTO: Micros = 1_000 * MILLISECOND;
const MIN_RTO: Micros = 150 * MILLISECOND;
const MAX_RTO: Micros = 4 * SECOND;
/// Bounds of the burst stall gap.
const MIN_STALL: Micros = 100 * MILLISECOND;
const MAX_STALL: Micros = 2 * SECOND;
/// No new block of the file for this long (duplicates, blocks beyond its end or unaligned do
/// not count) fails the read, whatever the vehicle keeps sending: the caller falls back.
pub const NO_PROGRESS: Micros = 10 * SECOND;
/// A file larger than this is refused (param.pck for 65,535 parameters stays far below).
pub const MAX_FILE: u32 = 4 * 1024 * 1024;

/// Reads of a `param.pck?withdefaults=1` that did not decode before it is read without its
/// defaults (see [`pck_reread_path`]).
pub const PCK_WITH_DEFAULTS_READS: u32 = 2;

/// What to read after `reads` complete reads of the parameter file `path` whose blocks did not
/// make a file, or `None` when nothing is left to try (the caller falls back to the parameter
/// protocol).
///
/// ArduPilot generates `param.pck` as it is read (`AP_Filesystem_Param::read`): a block read
/// again after a loss is packed from the first parameter with the values of that moment, and
/// with `withdefaults=1` a parameter's default is packed only while its value differs from it.
/// The calibrations of the first seconds after boot move values off their defaults, so blocks
/// read again after one do not join the blocks of the burst: the file does not decode, though
/// every block came. The file is then read again whole, with a new open (the end the first read
/// found is kept by the open file, and the file has grown since), as MAVProxy does, but at once
/// rather than at its next once-a-second check: by then the calibrations are over and the read
/// decodes. If the vehicle keeps moving values, the third read is of the file without defaults,
/// whose layout depends only on names and types: any mix of blocks joins, each value as it was
/// when its block was packed (and the vehicle notifies every value it saves since with
/// PARAM_VALUE).
pub fn pck_reread_path(path: &str, reads: u32) -> Option<&str> {
    let plain = path.split('?').next().unwrap_or(path);
    if plain == path {
        // Already without defaults: a file that does not decode is not a matter of timing.
        return None;
    }
    if reads < PCK_WITH_DEFAULTS_READS {
        Some(path)
    } else if reads == PCK_WITH_DEFAULTS_READS {
        Some(plain)
    } else {
        None
    }
}

#[derive(Debug, Clone, PartialEq)]
pub enum FtpOut {
    Send(FtpPacket),
    /// The whole file.
    Done(Vec<u8>),
    /// FTP did not work; why.
    Failed(String),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Opening,
    Bursting,
    Filling,
    Finished,
}

/// Counters, for the operator and the benchmark.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FtpStats {
    /// Requests sent, first tries and retries.
    pub requests: u32,
    pub retries: u32,
    /// File bytes received (duplicates included).
    pub bytes: u64,
}

/// One file read.
#[derive(Debug, Clone)]
pub struct FtpRead {
    path: String,
    phase: Phase,
    session: u8,
    seq: u16,
    blocks: BTreeMap<u32, Vec<u8>>,
    /// Where the file ends, once known.
    end: Option<u32>,
    /// Size announced by the open ACK (an estimate on ArduPilot).
    pub announced: Option<u32>,
    /// Offset → (sent at, tries) of ReadFile requests in flight; the open and bursts use
    /// `pending_since`.
    reads: BTreeMap<u32, (Micros, u32)>,
    tries: BTreeMap<u32, u32>,
    open_tries: u32,
    max_open_tries: u32,
    /// When the open or the current burst request went out (for the round trip and the stall).
    pending_since: Micros,
    last_rx: Micros,
    /// Smoothed round trip and its variation (RFC 6298), once measured.
    rtt: crate::proto::rtt::Rtt,
    /// Smoothed time between burst packets.
    interval: Option<Micros>,
    deadline: Option<Micros>,
    bursts: u32,
    /// When the last new block of the file came (or the read started).
    last_progress: Micros,
    pub stats: FtpStats,
}

impl FtpRead {
    /// Start reading `path`: returns the packets to send now.
    pub fn start(now: Micros, path: &str) -> (FtpRead, Vec<FtpOut>) {
        let mut r = FtpRead {
            path: path.to_string(),
            phase: Phase::Opening,
            session: 0,
            seq: 0,
            blocks: BTreeMap::new(),
            end: None,
            announced: None,
            reads: BTreeMap::new(),
            tries: BTreeMap::new(),
            open_tries: 0,
            max_open_tries: OPEN_TRIES,
            pending_since: now,
            last_rx: now,
            rtt: Default::default(),
            interval: None,
            deadline: None,
            bursts: 0,
            last_progress: now,
            stats: FtpStats::default(),
        };
        let out = r.open(now);
        (r, out)
    }

    /// Useful bytes received so far (each block of the file once, below its end) and the size
    /// expected (exact once the end is known); the bytes never exceed the size.
    pub fn progress(&self) -> (u64, Option<u32>) {
        let size = self.end.or(self.announced);
        let got: u64 = self.blocks.values().map(|b| b.len() as u64).sum();
        (size.map_or(got, |s| got.min(s as u64)), size)
    }

    /// A round trip measured by other traffic to the vehicle: used until one of ours is, and an
    /// open waiting on the blind first timeout is retried after it instead.
    pub fn rtt_hint(&mut self, rtt: Micros) {
        if self.rtt.is_measured() {
            return;
        }
        self.rtt.sample(rtt);
        if self.phase == Phase::Opening {
            let at = self.pending_since + self.rto();
            self.deadline = Some(self.deadline.map_or(at, |d| d.min(at)));
        }
    }

    /// How many times to try opening the file.
    pub fn set_open_tries(&mut self, n: u32) {
        self.max_open_tries = n;
    }

    /// The first block, once it came (param.pck's header is in it).
    pub fn head(&self) -> Option<&[u8]> {
        self.blocks.get(&0).map(|b| b.as_slice())
    }

    pub fn finished(&self) -> bool {
        self.phase == Phase::Finished
    }

    pub fn next_deadline(&self) -> Option<Micros> {
        match self.phase {
            Phase::Finished => return None,
            Phase::Opening => return self.deadline,
            _ => {}
        }
        let stuck = self.last_progress + NO_PROGRESS;
        Some(self.deadline.map_or(stuck, |d| d.min(stuck)))
    }

    /// The round-trip timeout.
    fn rto(&self) -> Micros {
        self.rtt.rto(INITIAL_RTO, MIN_RTO, MAX_RTO)
    }

    fn sample_rtt(&mut self, rtt: Micros) {
        self.rtt.sample(rtt);
    }

    fn packet(&mut self, opcode: u8, size: u8, offset: u32, data: Vec<u8>) -> FtpOut {
        let p = FtpPacket {
            seq: self.seq,
            session: self.session,
            opcode,
            size,
            req_opcode: 0,
            burst_complete: 0,
            offset,
            data,
        };
        self.seq = self.seq.wrapping_add(1);
        self.stats.requests += 1;
        FtpOut::Send(p)
    }

    fn open(&mut self, now: Micros) -> Vec<FtpOut> {
        self.open_tries += 1;
        if self.open_tries > 1 {
            self.stats.retries += 1;
        }
        self.pending_since = now;
        // A vehicle without FTP never answers: keep the wait short so the fallback is quick.
        self.deadline = Some(now + self.rto());
        let mut path = self.path.as_bytes().to_vec();
        path.truncate(DATA_LEN);
        let mut out = vec![self.packet(op::TERMINATE_SESSION, 0, 0, Vec::new())];
        let n = path.len() as u8;
        out.push(self.packet(op::OPEN_FILE_RO, n, 0, path));
        out
    }

    fn burst(&mut self, now: Micros, offset: u32) -> Vec<FtpOut> {
        self.phase = Phase::Bursting;
        self.bursts += 1;
        if self.bursts > 1 {
            self.stats.retries += 1;
        }
        self.pending_since = now;
        self.last_rx = now;
        self.deadline = Some(now + self.rto() + self.stall_gap());
        vec![self.packet(op::BURST_READ_FILE, BLOCK as u8, offset, Vec::new())]
    }

    /// How long a burst may go quiet before it counts as stalled: several times the measured
    /// gap between its packets.
    fn stall_gap(&self) -> Micros {
        match self.interval {
            Some(i) => (8 * i).clamp(MIN_STALL, MAX_STALL),
            None => 4 * MIN_STALL,
        }
    }

    /// The caller gives the read up (it fell back to another way): TerminateSession if a
    /// session may be open; a late open ACK is still closed ([`FtpRead::on_packet`]).
    pub fn abandon(&mut self) -> Vec<FtpOut> {
        if self.phase == Phase::Finished {
            return Vec::new();
        }
        let mut out = self.fail(String::new());
        out.retain(|o| !matches!(o, FtpOut::Failed(_)));
        out
    }

    fn fail(&mut self, why: String) -> Vec<FtpOut> {
        self.phase = Phase::Finished;
        self.deadline = None;
        let mut out = Vec::new();
        if self.session != 0 || self.open_tries > 0 {
            out.push(self.packet(op::TERMINATE_SESSION, 0, 0, Vec::new()));
        }
        out.push(FtpOut::Failed(why));
        out
    }

    /// Keep a block; true when it was new and in the file (useful progress).
    fn store(&mut self, now: Micros, offset: u32, data: &[u8]) -> bool {
        if !offset.is_multiple_of(BLOCK as u32) || offset >= MAX_FILE {
            return false; // not a block we asked for
        }
        if self.end.is_some_and(|e| offset >= e && !data.is_empty()) {
            return false; // beyond the end already known
        }
        if self
            .announced
            .is_some_and(|a| a > 0 && offset as u64 >= 2 * a as u64 + BLOCK as u64)
        {
            // Far beyond the size the open announced (an estimate, but not by half).
            return false;
        }
        self.stats.bytes += data.len() as u64;
        let mut useful = false;
        if data.len() < BLOCK {
            let end = offset + data.len() as u32;
            useful = self.end.is_none_or(|e| end < e);
            self.end = Some(self.end.map_or(end, |e| e.min(end)));
        }
        if !data.is_empty() && !self.blocks.contains_key(&offset) {
            self.blocks.insert(offset, data.to_vec());
            useful = true;
        }
        self.reads.remove(&offset);
        if useful {
            self.last_progress = now;
        }
        useful
    }

    /// Offsets of the blocks still missing below the end (all of them once the end is known;
    /// up to the highest block received otherwise).
    fn missing(&self) -> Vec<u32> {
        let limit = match self.end {
            Some(e) => e,
            None => self
                .blocks
                .keys()
                .next_back()
                .map_or(0, |&o| o + BLOCK as u32),
        };
        (0..limit)
            .step_by(BLOCK)
            .filter(|o| !self.blocks.contains_key(o))
            .collect()
    }

    /// A packet from the vehicle (already known to be for us and from the right component).
    pub fn on_packet(&mut self, now: Micros, p: &FtpPacket) -> Vec<FtpOut> {
        if self.phase == Phase::Finished {
            // A late open ACK: the vehicle holds a session nobody reads; close it.
            if p.opcode == op::ACK && p.req_opcode == op::OPEN_FILE_RO {
                self.session = p.session;
                return vec![self.packet(op::TERMINATE_SESSION, 0, 0, Vec::new())];
            }
            return Vec::new();
        }
        match (self.phase, p.opcode, p.req_opcode) {
            (Phase::Opening, op::ACK, op::OPEN_FILE_RO) => {
                self.sample_rtt(now.saturating_sub(self.pending_since));
                self.session = p.session;
                self.last_progress = now;
                if p.data.len() >= 4 {
                    let size = u32::from_le_bytes([p.data[0], p.data[1], p.data[2], p.data[3]]);
                    self.announced = Some(size);
                }
                self.burst(now, 0)
            }
            (Phase::Opening, op::NAK, op::OPEN_FILE_RO) => {
                let code = p.data.first().copied().unwrap_or(0);
                if code == err::FAIL && self.open_tries < self.max_open_tries {
                    // Likely our own earlier open whose ACK was lost: the terminate sent with
                    // the next try closes it.
                    return Vec::new();
                }
                self.fail(format!("MAVFTP open refused ({})", nak_name(code)))
            }
            (_, _, _) if p.session != self.session => Vec::new(),
            (Phase::Bursting | Phase::Filling, op::ACK, op::BURST_READ_FILE) => {
                let useful = self.store(now, p.offset, &p.data);
                if !useful && now >= self.last_progress + NO_PROGRESS {
                    return self.stuck();
                }
                if self.phase == Phase::Bursting && useful {
                    if self.last_rx > self.pending_since {
                        let gap = now.saturating_sub(self.last_rx);
                        self.interval = Some(match self.interval {
                            None => gap,
                            Some(i) => (7 * i + gap) / 8,
                        });
                    } else {
                        self.sample_rtt(now.saturating_sub(self.pending_since));
                    }
                }
                if p.burst_complete != 0 && self.phase == Phase::Bursting {
                    self.last_rx = now;
                    return self.after_burst(now);
                }
                if self.phase == Phase::Bursting {
                    // Only what the file is made of keeps the burst going: a stream of
                    // duplicates, of blocks beyond the end or unaligned, stalls it.
                    if useful {
                        self.last_rx = now;
                        self.deadline = Some(now + self.stall_gap());
                    }
                    Vec::new()
                } else {
                    self.fill(now)
                }
            }
            (Phase::Bursting, op::NAK, op::BURST_READ_FILE) => {
                self.last_rx = now;
                let code = p.data.first().copied().unwrap_or(0);
                if code == err::EOF {
                    // The offset of an EOF NAK is where the burst stood, the end of the file
                    // (blocks lost before it are read as gaps). An offset below what already
                    // came says nothing: the end is found by reading on.
                    let at = self
                        .blocks
                        .iter()
                        .next_back()
                        .map_or(0, |(o, b)| o + b.len() as u32);
                    if p.offset >= at && p.offset < MAX_FILE {
                        self.end = Some(self.end.map_or(p.offset, |e| e.min(p.offset)));
                    }
                    self.after_burst(now)
                } else {
                    self.fail(format!("MAVFTP burst read refused ({})", nak_name(code)))
                }
            }
            (Phase::Filling, op::ACK, op::READ_FILE) => {
                if let Some((sent, tries)) = self.reads.get(&p.offset).copied() {
                    if tries == 1 {
                        self.sample_rtt(now.saturating_sub(sent));
                    }
                }
                if !self.store(now, p.offset, &p.data) && now >= self.last_progress + NO_PROGRESS {
                    return self.stuck();
                }
                self.fill(now)
            }
            (Phase::Filling, op::NAK, op::READ_FILE) => {
                let code = p.data.first().copied().unwrap_or(0);
                if code == err::EOF && self.reads.contains_key(&p.offset) {
                    self.reads.remove(&p.offset);
                    self.end = Some(self.end.map_or(p.offset, |e| e.min(p.offset)));
                    self.fill(now)
                } else if self.reads.contains_key(&p.offset) {
                    self.fail(format!("MAVFTP read refused ({})", nak_name(code)))
                } else {
                    Vec::new()
                }
            }
            _ => Vec::new(),
        }
    }

    /// No useful progress for [`NO_PROGRESS`]: give up on FTP.
    fn stuck(&mut self) -> Vec<FtpOut> {
        self.fail(format!(
            "MAVFTP: no new data for {} s",
            NO_PROGRESS / SECOND
        ))
    }

    /// The burst ended (or stalled): read what is missing.
    fn after_burst(&mut self, now: Micros) -> Vec<FtpOut> {
        self.phase = Phase::Filling;
        self.fill(now)
    }

    /// Fill gaps: keep [`WINDOW`] reads in flight; finish when nothing is missing.
    fn fill(&mut self, now: Micros) -> Vec<FtpOut> {
        let missing = self.missing();
        if self.end.is_some() && missing.is_empty() {
            return self.finish();
        }
        if self.end.is_none() && missing.is_empty() {
            // The tail is lost and nothing below it: burst on from where we stand.
            let from = self
                .blocks
                .keys()
                .next_back()
                .map_or(0, |&o| o + BLOCK as u32);
            if self.reads.is_empty() {
                let t = self.tries.entry(from).or_insert(0);
                *t += 1;
                if *t > MAX_TRIES {
                    return self.fail(format!("MAVFTP: no data at offset {from}"));
                }
                return self.burst(now, from);
            }
        }
        let mut out = Vec::new();
        for o in missing {
            if self.reads.len() >= WINDOW {
                break;
            }
            if self.reads.contains_key(&o) {
                continue;
            }
            let t = self.tries.entry(o).or_insert(0);
            *t += 1;
            let tries = *t;
            if tries > MAX_TRIES {
                return self.fail(format!("MAVFTP: block at offset {o} never came"));
            }
            if tries > 1 {
                self.stats.retries += 1;
            }
            self.reads.insert(o, (now, tries));
            out.push(self.packet(op::READ_FILE, BLOCK as u8, o, Vec::new()));
            if tries > 1 {
                // Asked again: asked twice, so that one more loss does not cost a timeout.
                out.push(self.packet(op::READ_FILE, BLOCK as u8, o, Vec::new()));
            }
        }
        self.deadline = self
            .reads
            .values()
            .map(|(t, n)| t + backoff(self.rto(), *n))
            .min();
        out
    }

    fn finish(&mut self) -> Vec<FtpOut> {
        self.phase = Phase::Finished;
        self.deadline = None;
        let end = self.end.unwrap_or(0) as usize;
        let mut file = Vec::with_capacity(end);
        for (o, b) in &self.blocks {
            let o = *o as usize;
            if o >= end {
                break;
            }
            file.extend_from_slice(&b[..b.len().min(end - o)]);
        }
        let term = self.packet(op::TERMINATE_SESSION, 0, 0, Vec::new());
        vec![term, FtpOut::Done(file)]
    }

    /// Timers: an unanswered open, a stalled burst, reads that timed out.
    pub fn poll(&mut self, now: Micros) -> Vec<FtpOut> {
        if self.phase == Phase::Finished {
            return Vec::new();
        }
        if self.phase != Phase::Opening && now >= self.last_progress + NO_PROGRESS {
            return self.stuck();
        }
        if self.deadline.is_none_or(|d| now < d) {
            return Vec::new();
        }
        match self.phase {
            Phase::Opening => {
                if self.open_tries >= self.max_open_tries {
                    self.fail("no answer to MAVFTP".into())
                } else {
                    self.open(now)
                }
            }
            Phase::Bursting => {
                if self.blocks.is_empty() && self.end.is_none() {
                    // Nothing of the burst came: ask again.
                    let t = self.tries.entry(0).or_insert(0);
                    *t += 1;
                    if *t >= MAX_TRIES {
                        return self.fail("MAVFTP burst read went unanswered".into());
                    }
                    return self.burst(now, 0);
                }
                self.after_burst(now)
            }
            Phase::Filling => {
                let rto = self.rto();
                let due: Vec<u32> = self
                    .reads
                    .iter()
                    .filter(|(_, (t, n))| now >= t + backoff(rto, *n))
                    .map(|(o, _)| *o)
                    .collect();
                for o in due {
                    self.reads.remove(&o);
                }
                self.fill(now)
            }
            Phase::Finished => Vec::new(),
        }
    }
}

/// The wait for the `tries`-th read of a block: the timeout twice, then doubling (loss on a
/// link is mostly chance, so the first retry does not wait longer; a congested one is still
/// backed off).
fn backoff(rto: Micros, tries: u32) -> Micros {
    rto << tries.saturating_sub(2).min(3)
}

pub fn nak_name(code: u8) -> &'static str {
    match code {
        0 => "no error code",
        err::FAIL => "failed",
        2 => "failed with errno",
        err::INVALID_DATA_SIZE => "invalid data size",
        err::INVALID_SESSION => "invalid session",
        5 => "no sessions available",
        err::EOF => "end of file",
        err::UNKNOWN_COMMAND => "unknown command",
        8 => "file exists",
        9 => "file protected",
        err::FILE_NOT_FOUND => "file not found",
        _ => "unknown error",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A vehicle holding `file`, answering like ArduPilot, losing the packets `lose` picks.
    struct Vehicle {
        file: Vec<u8>,
        session_open: bool,
    }

    impl Vehicle {
        fn answer(&mut self, req: &FtpPacket) -> Vec<FtpPacket> {
            let mut r = FtpPacket::reply_to(req);
            match req.opcode {
                op::TERMINATE_SESSION => {
                    self.session_open = false;
                    vec![r]
                }
                op::OPEN_FILE_RO => {
                    if self.session_open {
                        return vec![r.nak(err::FAIL)];
                    }
                    self.session_open = true;
                    r.session = 0;
                    r.size = 4;
                    r.data = ((self.file.len() as u32) * 2).to_le_bytes().to_vec();
                    vec![r]
                }
                op::READ_FILE => {
                    let s = req.offset as usize;
                    if s >= self.file.len() {
                        return vec![r.nak(err::EOF)];
                    }
                    let e = (s + req.size as usize).min(self.file.len());
                    r.size = (e - s) as u8;
                    r.data = self.file[s..e].to_vec();
                    vec![r]
                }
                op::BURST_READ_FILE => {
                    let mut out = Vec::new();
                    let mut o = req.offset as usize;
                    let mut seq = req.seq;
                    loop {
                        seq = seq.wrapping_add(1);
                        let mut p = FtpPacket::reply_to(req);
                        p.seq = seq;
                        p.offset = o as u32;
                        if o >= self.file.len() {
                            p.burst_complete = 1;
                            out.push(p.nak(err::EOF));
                            break;
                        }
                        let e = (o + req.size as usize).min(self.file.len());
                        p.size = (e - o) as u8;
                        p.data = self.file[o..e].to_vec();
                        if e - o < req.size as usize {
                            p.burst_complete = 1;
                            out.push(p);
                            break;
                        }
                        out.push(p);
                        o = e;
                    }
                    out
                }
                _ => vec![r.nak(err::UNKNOWN_COMMAND)],
            }
        }
    }

    /// Run a transfer; `lose(n)` drops the n-th packet from the vehicle. Returns the file and
    /// the requests sent.
    fn run(file: &[u8], mut lose: impl FnMut(usize) -> bool) -> (Result<Vec<u8>, String>, u32) {
        let mut v = Vehicle {
            file: file.to_vec(),
            session_open: false,
        };
        let mut now = 0;
        let (mut r, mut out) = FtpRead::start(now, "@PARAM/param.pck");
        let mut n = 0;
        for _ in 0..10_000 {
            let mut replies = Vec::new();
            for o in out.drain(..) {
                match o {
                    FtpOut::Send(p) => replies.extend(v.answer(&p)),
                    FtpOut::Done(f) => return (Ok(f), r.stats.requests),
                    FtpOut::Failed(w) => return (Err(w), r.stats.requests),
                }
            }
            now += 10 * MILLISECOND;
            for p in replies {
                n += 1;
                if !lose(n) {
                    now += MILLISECOND;
                    out.extend(r.on_packet(now, &p));
                }
            }
            if out.is_empty() {
                now = r
                    .next_deadline()
                    .expect("a deadline while not done")
                    .max(now);
                out = r.poll(now);
            }
        }
        panic!("transfer never ended");
    }

    fn file(len: usize) -> Vec<u8> {
        (0..len).map(|i| (i * 7 % 251) as u8).collect()
    }

    #[test]
    fn clean_burst_reads_the_whole_file() {
        let f = file(BLOCK * 10 + 17);
        let (got, requests) = run(&f, |_| false);
        assert_eq!(got.unwrap(), f);
        // terminate + open + one burst + the final terminate
        assert_eq!(requests, 4);
    }

    #[test]
    fn exact_multiple_of_the_block_ends_at_the_eof_nak() {
        let f = file(BLOCK * 4);
        assert_eq!(run(&f, |_| false).0.unwrap(), f);
    }

    #[test]
    fn lost_blocks_and_a_lost_tail_are_read_again() {
        let f = file(BLOCK * 30 + 5);
        // Packet 1 = terminate ACK, 2 = open ACK, then the burst's 31 blocks (n = 3..=33, the
        // last one short): lose blocks 2, 3 and 9, and the last two, so the end is unknown.
        let (got, _) = run(&f, |n| [5, 6, 12, 32, 33].contains(&n));
        assert_eq!(got.unwrap(), f);
    }

    #[test]
    fn heavy_loss_still_completes() {
        let f = file(BLOCK * 70 + 100);
        let mut x = 12345u32;
        let (got, _) = run(&f, |_| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x % 10 < 4 // 40 % loss
        });
        assert_eq!(got.unwrap(), f);
    }

    #[test]
    fn a_refused_open_fails_at_once() {
        let mut v = Vehicle {
            file: vec![],
            session_open: false,
        };
        let (mut r, out) = FtpRead::start(0, "@PARAM/param.pck");
        let open = out
            .iter()
            .filter_map(|o| match o {
                FtpOut::Send(p) if p.opcode == op::OPEN_FILE_RO => Some(p.clone()),
                _ => None,
            })
            .next()
            .unwrap();
        assert_eq!(open.data, b"@PARAM/param.pck");
        assert_eq!(open.size as usize, open.data.len());
        let mut nak = v.answer(&open).remove(0).nak(err::FILE_NOT_FOUND);
        nak.req_opcode = op::OPEN_FILE_RO;
        let out = r.on_packet(5, &nak);
        assert!(matches!(out.last(), Some(FtpOut::Failed(w)) if w.contains("file not found")));
    }

    #[test]
    fn silence_fails_after_the_open_tries() {
        let (mut r, _) = FtpRead::start(0, "@PARAM/param.pck");
        let mut sends = 0;
        loop {
            let d = r.next_deadline().unwrap();
            let out = r.poll(d);
            if let Some(FtpOut::Failed(w)) = out.last() {
                assert_eq!(w, "no answer to MAVFTP");
                break;
            }
            sends += out.len();
        }
        // One more try of terminate + open.
        assert_eq!(sends, 2);
    }

    #[test]
    fn a_param_pck_that_does_not_decode_is_read_again_then_without_defaults() {
        let p = "@PARAM/param.pck?withdefaults=1";
        assert_eq!(pck_reread_path(p, 1), Some(p));
        assert_eq!(pck_reread_path(p, 2), Some("@PARAM/param.pck"));
        assert_eq!(pck_reread_path(p, 3), None);
        assert_eq!(pck_reread_path("@PARAM/param.pck", 1), None);
    }
}
