//! Reading one whole file over MAVLink FTP, the GCS side, for any path (the component metadata
//! files PX4 serves from `etc/extras/`). Sans-I/O: packets and time in, [`FileOut`] out,
//! [`FileRead::next_deadline`].
//!
//! Made for PX4's server (`src/modules/mavlink/mavlink_ftp.cpp`), which ArduPilot's follows:
//! - **One session.** An OpenFileRO while a session is open is refused (`NoSessionsAvailable`);
//!   so the open goes out behind a TerminateSession of session 0 (a session an earlier GCS run
//!   left open). The open ACK's session and its 4-byte file size (exact on PX4: `stat`) are kept.
//! - **Burst.** BurstReadFile from an offset: the server streams ACKs of up to 239 bytes, each
//!   with the offset it read at; it stops after ~35 kB with `burst_complete` set, or at the end of
//!   the file with a NAK EOF whose offset is the file size. The read keeps the bytes that follow
//!   on from what it has (a packet at another offset is dropped); a burst that ends, completes or
//!   stalls is followed by another from where the file stands, so a lost packet costs one burst
//!   restart. The file ends at a NAK EOF at its end, at a short block, or at the announced size.
//! - **ReadFile** is used instead when the server refuses the burst (`UnknownCommand`): one block
//!   at a time, each retried on a timeout.
//! - **Bounded.** A file larger than the limit given (announced, or as it comes) fails the read;
//!   nothing is kept beyond it.
//! - **Done** or **failed**: TerminateSession of the open session, so none is left open.

use crate::clock::{Micros, SECOND};
use crate::wire::mavftp::{err, op, FtpPacket, DATA_LEN};

/// OpenFileRO attempts before the read fails.
pub const OPEN_TRIES: u32 = 3;
/// Bursts (or reads of one block) in a row that bring nothing new before the read fails.
pub const MAX_TRIES: u32 = 5;
/// Wait for an answer to an open or a ReadFile.
pub const ANSWER_TIMEOUT: Micros = SECOND;
/// A burst quiet for this long has stalled: another one goes on from where the file stands.
pub const STALL: Micros = SECOND;

#[derive(Debug, Clone, PartialEq)]
pub enum FileOut {
    Send(FtpPacket),
    /// The whole file.
    Done(Vec<u8>),
    /// Why the file could not be read.
    Failed(String),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Opening,
    Bursting,
    Reading,
    Finished,
}

/// One file being read.
#[derive(Debug, Clone)]
pub struct FileRead {
    path: String,
    phase: Phase,
    session: u8,
    /// Sequence number of the next request.
    seq: u16,
    /// Sequence number of the open (its ACK carries the next one).
    open_seq: u16,
    data: Vec<u8>,
    /// The size the open ACK announced.
    pub size: Option<u32>,
    max: usize,
    open_tries: u32,
    /// Requests in a row that brought nothing new.
    tries: u32,
    deadline: Option<Micros>,
    /// Requests sent (retries included).
    pub requests: u32,
}

impl FileRead {
    /// Start reading `path` (at most `max` bytes), numbering requests from `seq` (go on from
    /// the last read's [`FileRead::seq`]: PX4 answers a request whose number follows its last
    /// answer's with that answer again, so a new read must not start over at 0): the packets to
    /// send now.
    pub fn start(now: Micros, path: &str, max: usize, seq: u16) -> (FileRead, Vec<FileOut>) {
        let mut r = FileRead {
            path: path.to_string(),
            phase: Phase::Opening,
            session: 0,
            seq,
            open_seq: 0,
            data: Vec::new(),
            size: None,
            max,
            open_tries: 0,
            tries: 0,
            deadline: None,
            requests: 0,
        };
        let out = r.open(now);
        (r, out)
    }

    /// The sequence number of the next request.
    pub fn seq(&self) -> u16 {
        self.seq
    }

    pub fn path(&self) -> &str {
        &self.path
    }

    pub fn finished(&self) -> bool {
        self.phase == Phase::Finished
    }

    /// Bytes received so far, and the size announced.
    pub fn progress(&self) -> (usize, Option<u32>) {
        (self.data.len(), self.size)
    }

    pub fn next_deadline(&self) -> Option<Micros> {
        self.deadline
    }

    fn packet(&mut self, opcode: u8, offset: u32, data: Vec<u8>) -> FileOut {
        let size = match opcode {
            op::BURST_READ_FILE | op::READ_FILE => DATA_LEN as u8,
            _ => data.len().min(DATA_LEN) as u8,
        };
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
        self.requests += 1;
        FileOut::Send(p)
    }

    fn open(&mut self, now: Micros) -> Vec<FileOut> {
        self.open_tries += 1;
        self.deadline = Some(now + ANSWER_TIMEOUT);
        let mut path = self.path.as_bytes().to_vec();
        path.truncate(DATA_LEN);
        self.session = 0;
        let term = self.packet(op::TERMINATE_SESSION, 0, Vec::new());
        self.open_seq = self.seq;
        let open = self.packet(op::OPEN_FILE_RO, 0, path);
        vec![term, open]
    }

    fn burst(&mut self, now: Micros) -> Vec<FileOut> {
        self.phase = Phase::Bursting;
        self.deadline = Some(now + STALL);
        let at = self.data.len() as u32;
        vec![self.packet(op::BURST_READ_FILE, at, Vec::new())]
    }

    fn read(&mut self, now: Micros) -> Vec<FileOut> {
        self.phase = Phase::Reading;
        self.deadline = Some(now + ANSWER_TIMEOUT);
        let at = self.data.len() as u32;
        vec![self.packet(op::READ_FILE, at, Vec::new())]
    }

    /// The caller no longer wants the file: TerminateSession if one may be open.
    pub fn abandon(&mut self) -> Vec<FileOut> {
        if self.phase == Phase::Finished {
            return Vec::new();
        }
        let mut out = self.fail(String::new());
        out.retain(|o| !matches!(o, FileOut::Failed(_)));
        out
    }

    fn fail(&mut self, why: String) -> Vec<FileOut> {
        self.phase = Phase::Finished;
        self.deadline = None;
        self.data = Vec::new();
        let term = self.packet(op::TERMINATE_SESSION, 0, Vec::new());
        vec![term, FileOut::Failed(why)]
    }

    fn finish(&mut self) -> Vec<FileOut> {
        self.phase = Phase::Finished;
        self.deadline = None;
        let term = self.packet(op::TERMINATE_SESSION, 0, Vec::new());
        vec![term, FileOut::Done(std::mem::take(&mut self.data))]
    }

    fn too_large(&mut self, n: u64) -> Vec<FileOut> {
        self.fail(format!(
            "{} is larger than {} kB ({} bytes or more): refused",
            self.path,
            self.max / 1024,
            n
        ))
    }

    /// Bytes read at `offset`: kept when they follow on from what the file has. True when
    /// they did.
    fn take(&mut self, offset: u32, bytes: &[u8]) -> bool {
        if offset as usize != self.data.len() || bytes.is_empty() {
            return false;
        }
        self.data.extend_from_slice(bytes);
        self.tries = 0;
        true
    }

    /// Whether the file is whole: at the announced size, or after a short block.
    fn whole(&self, last: usize) -> bool {
        last < DATA_LEN
            || self
                .size
                .is_some_and(|s| self.data.len() as u64 >= s as u64)
    }

    /// A packet from the server (already known to be from the component read from).
    pub fn on_packet(&mut self, now: Micros, p: &FtpPacket) -> Vec<FileOut> {
        // The next request is numbered past every answer heard: PX4 keeps its last small
        // answer (a burst's closing NAK EOF too) and answers a request numbered right before it
        // with it again instead of carrying the request out.
        if p.seq.wrapping_sub(self.seq) < 0x8000 {
            self.seq = p.seq.wrapping_add(1);
        }
        let nak = p.opcode == op::NAK;
        let code = p.data.first().copied().unwrap_or(0);
        match (self.phase, p.req_opcode) {
            (Phase::Opening, op::OPEN_FILE_RO) if p.seq == self.open_seq.wrapping_add(1) => {
                if nak {
                    if matches!(code, err::FAIL | NO_SESSIONS) && self.open_tries < OPEN_TRIES {
                        // A session still open (ours, its ACK lost): the terminate that goes
                        // with the next try closes it.
                        return Vec::new();
                    }
                    return self.fail(format!(
                        "MAVFTP open of {} refused ({})",
                        self.path,
                        nak_name(code)
                    ));
                }
                self.session = p.session;
                if p.data.len() >= 4 {
                    let size = u32::from_le_bytes([p.data[0], p.data[1], p.data[2], p.data[3]]);
                    if size as usize > self.max {
                        return self.too_large(size as u64);
                    }
                    self.size = Some(size);
                }
                self.burst(now)
            }
            (Phase::Bursting, op::BURST_READ_FILE) if p.session == self.session => {
                if nak {
                    if code == err::EOF && p.offset as usize <= self.data.len() {
                        return self.finish();
                    }
                    if code == err::EOF {
                        // The end is further on: packets before it were lost.
                        return self.again(now);
                    }
                    if code == err::UNKNOWN_COMMAND && self.data.is_empty() {
                        return self.read(now);
                    }
                    return self.fail(format!(
                        "MAVFTP burst read of {} refused ({})",
                        self.path,
                        nak_name(code)
                    ));
                }
                let fresh = self.take(p.offset, &p.data);
                if self.data.len() > self.max {
                    return self.too_large(self.data.len() as u64);
                }
                if fresh && self.whole(p.data.len()) {
                    return self.finish();
                }
                if fresh {
                    self.deadline = Some(now + STALL);
                }
                if p.burst_complete != 0 {
                    return self.again(now);
                }
                Vec::new()
            }
            (Phase::Reading, op::READ_FILE) if p.session == self.session => {
                if p.offset as usize != self.data.len() {
                    return Vec::new(); // an answer to an earlier try
                }
                if nak {
                    if code == err::EOF {
                        return self.finish();
                    }
                    return self.fail(format!(
                        "MAVFTP read of {} refused ({})",
                        self.path,
                        nak_name(code)
                    ));
                }
                let n = p.data.len();
                if n == 0 {
                    return self.finish();
                }
                self.take(p.offset, &p.data);
                if self.data.len() > self.max {
                    return self.too_large(self.data.len() as u64);
                }
                if self.whole(n) {
                    return self.finish();
                }
                self.read(now)
            }
            _ => Vec::new(),
        }
    }

    /// Another burst from where the file stands, unless too many in a row brought nothing.
    fn again(&mut self, now: Micros) -> Vec<FileOut> {
        self.tries += 1;
        if self.tries > MAX_TRIES {
            let at = self.data.len();
            return self.fail(format!(
                "MAVFTP: no data of {} at offset {at} after {MAX_TRIES} tries",
                self.path
            ));
        }
        self.burst(now)
    }

    /// Timers: an open unanswered, a burst stalled, a read unanswered.
    pub fn poll(&mut self, now: Micros) -> Vec<FileOut> {
        if self.deadline.is_none_or(|d| now < d) {
            return Vec::new();
        }
        match self.phase {
            Phase::Opening if self.open_tries >= OPEN_TRIES => self.fail(format!(
                "no answer to MAVFTP (OpenFileRO {}, {OPEN_TRIES} tries)",
                self.path
            )),
            Phase::Opening => self.open(now),
            Phase::Bursting => self.again(now),
            Phase::Reading => {
                self.tries += 1;
                if self.tries > MAX_TRIES {
                    let at = self.data.len();
                    return self.fail(format!(
                        "MAVFTP: no answer to ReadFile of {} at offset {at}",
                        self.path
                    ));
                }
                self.read(now)
            }
            Phase::Finished => Vec::new(),
        }
    }
}

/// NAK `NoSessionsAvailable`.
const NO_SESSIONS: u8 = 5;

/// The name of a NAK's error code (MAVLink FTP spec).
pub fn nak_name(code: u8) -> &'static str {
    match code {
        0 => "no error code",
        err::FAIL => "failed",
        2 => "failed with errno",
        err::INVALID_DATA_SIZE => "invalid data size",
        err::INVALID_SESSION => "invalid session",
        NO_SESSIONS => "no sessions available",
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

    /// A server holding `file` as PX4's mavlink_ftp.cpp answers: one session, bursts of at most
    /// `chunk` bytes ending in `burst_complete`, a NAK EOF at the end.
    struct Px4 {
        file: Vec<u8>,
        open: bool,
        chunk: usize,
        burst: bool,
        opens: Vec<Vec<u8>>,
        /// PX4's last small answer's number, and the requests numbered right before it.
        last_small: Option<u16>,
        collisions: u32,
    }

    impl Px4 {
        fn new(file: Vec<u8>) -> Px4 {
            Px4 {
                file,
                open: false,
                chunk: 35_000,
                burst: true,
                opens: Vec::new(),
                last_small: None,
                collisions: 0,
            }
        }

        fn answer(&mut self, req: &FtpPacket) -> Vec<FtpPacket> {
            if self.last_small == Some(req.seq.wrapping_add(1)) {
                self.collisions += 1;
            }
            let out = self.carry_out(req);
            if let Some(p) = out.iter().rev().find(|p| p.data.len() <= 4) {
                self.last_small = Some(p.seq);
            }
            out
        }

        fn carry_out(&mut self, req: &FtpPacket) -> Vec<FtpPacket> {
            let mut r = FtpPacket::reply_to(req);
            match req.opcode {
                op::TERMINATE_SESSION if self.open && req.session == 0 => {
                    self.open = false;
                    vec![r]
                }
                op::TERMINATE_SESSION => vec![r.nak(err::INVALID_SESSION)],
                op::OPEN_FILE_RO => {
                    self.opens.push(req.data.clone());
                    if self.open {
                        return vec![r.nak(NO_SESSIONS)];
                    }
                    self.open = true;
                    r.size = 4;
                    r.data = (self.file.len() as u32).to_le_bytes().to_vec();
                    vec![r]
                }
                op::READ_FILE if self.open => {
                    let s = req.offset as usize;
                    if s >= self.file.len() {
                        return vec![r.nak(err::EOF)];
                    }
                    let e = (s + DATA_LEN).min(self.file.len());
                    r.size = (e - s) as u8;
                    r.data = self.file[s..e].to_vec();
                    vec![r]
                }
                op::BURST_READ_FILE if !self.burst => vec![r.nak(err::UNKNOWN_COMMAND)],
                op::BURST_READ_FILE if self.open => {
                    let mut out = Vec::new();
                    let mut o = req.offset as usize;
                    let mut sent = 0;
                    let mut seq = req.seq;
                    loop {
                        seq = seq.wrapping_add(1);
                        let mut p = FtpPacket::reply_to(req);
                        p.seq = seq;
                        p.offset = o as u32;
                        if o >= self.file.len() {
                            out.push(p.nak(err::EOF));
                            break;
                        }
                        let e = (o + DATA_LEN).min(self.file.len());
                        p.size = (e - o) as u8;
                        p.data = self.file[o..e].to_vec();
                        sent += e - o;
                        o = e;
                        if sent > self.chunk {
                            p.burst_complete = 1;
                            out.push(p);
                            break;
                        }
                        out.push(p);
                    }
                    out
                }
                _ => vec![r.nak(err::INVALID_SESSION)],
            }
        }
    }

    /// Run a read against `v`; `lose(n)` drops the n-th packet from the server.
    fn run(
        v: &mut Px4,
        max: usize,
        mut lose: impl FnMut(usize) -> bool,
    ) -> (Result<Vec<u8>, String>, u32) {
        let mut now = 0;
        let (mut r, mut out) = FileRead::start(now, "etc/extras/parameters.json.xz", max, 0);
        let mut n = 0;
        for _ in 0..100_000 {
            let mut replies = Vec::new();
            for o in out.drain(..) {
                match o {
                    FileOut::Send(p) => replies.extend(v.answer(&p)),
                    FileOut::Done(f) => return (Ok(f), r.requests),
                    FileOut::Failed(w) => return (Err(w), r.requests),
                }
            }
            now += 10_000;
            for p in replies {
                n += 1;
                if !lose(n) {
                    now += 1_000;
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
        panic!("the read never ended");
    }

    fn file(len: usize) -> Vec<u8> {
        (0..len).map(|i| (i * 31 % 253) as u8).collect()
    }

    #[test]
    fn a_clean_burst_reads_the_file_in_px4s_chunks() {
        let f = file(100_000);
        let mut v = Px4::new(f.clone());
        let (got, requests) = run(&mut v, 1 << 20, |_| false);
        assert_eq!(got.unwrap(), f);
        // terminate + open, three bursts (35 kB each, the last ends at the size), terminate.
        assert_eq!(requests, 6);
        assert!(
            v.collisions == 0,
            "no request numbered right before PX4's last answer"
        );
        assert_eq!(v.opens, vec![b"etc/extras/parameters.json.xz".to_vec()]);
        assert!(!v.open, "the session is closed");
    }

    #[test]
    fn an_exact_multiple_of_the_block_ends_at_the_size() {
        let f = file(DATA_LEN * 5);
        assert_eq!(
            run(&mut Px4::new(f.clone()), 1 << 20, |_| false).0.unwrap(),
            f
        );
        assert_eq!(
            run(&mut Px4::new(Vec::new()), 1 << 20, |_| false)
                .0
                .unwrap(),
            b""
        );
    }

    #[test]
    fn lost_packets_are_read_again() {
        let f = file(20_000);
        let mut x = 7u32;
        let (got, _) = run(&mut Px4::new(f.clone()), 1 << 20, |_| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x % 10 < 2
        });
        assert_eq!(got.unwrap(), f);
    }

    #[test]
    fn without_burst_it_reads_block_by_block() {
        let f = file(DATA_LEN * 3 + 10);
        let mut v = Px4::new(f.clone());
        v.burst = false;
        let (got, requests) = run(&mut v, 1 << 20, |_| false);
        assert_eq!(got.unwrap(), f);
        // terminate + open, the refused burst, four reads, terminate.
        assert_eq!(requests, 8);
    }

    #[test]
    fn a_file_larger_than_the_limit_is_refused_at_the_open() {
        let mut v = Px4::new(file(5000));
        let (got, _) = run(&mut v, 4096, |_| false);
        let e = got.unwrap_err();
        assert!(e.contains("larger than 4 kB"), "{e}");
        assert!(!v.open, "the session is closed");
    }

    #[test]
    fn a_missing_file_is_its_nak() {
        let (mut r, out) = FileRead::start(0, "etc/nope", 100, 7);
        let FileOut::Send(open) = &out[1] else {
            panic!()
        };
        assert_eq!(open.opcode, op::OPEN_FILE_RO);
        assert_eq!(open.seq, 8, "numbered on from the start given");
        assert_eq!(open.data, b"etc/nope");
        assert_eq!(open.size, 8);
        let nak = FtpPacket::reply_to(open).nak(err::FILE_NOT_FOUND);
        let mut nak = nak;
        nak.req_opcode = op::OPEN_FILE_RO;
        let out = r.on_packet(5, &nak);
        assert!(
            matches!(out.last(), Some(FileOut::Failed(w)) if w == "MAVFTP open of etc/nope refused (file not found)"),
            "{out:?}"
        );
    }

    #[test]
    fn silence_fails_after_the_open_tries() {
        let (mut r, _) = FileRead::start(0, "x", 100, 0);
        let mut sends = 0;
        loop {
            let d = r.next_deadline().unwrap();
            let out = r.poll(d);
            if let Some(FileOut::Failed(w)) = out.last() {
                assert_eq!(w, "no answer to MAVFTP (OpenFileRO x, 3 tries)");
                break;
            }
            sends += out.len();
        }
        assert_eq!(sends, 4, "two more tries of terminate + open");
        assert_eq!(r.next_deadline(), None);
    }
}
