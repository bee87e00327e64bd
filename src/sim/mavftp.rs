//! The vehicle side of MAVLink FTP (FILE_TRANSFER_PROTOCOL, id 110) as ArduPilot 4.5/4.6 runs it
//! (`GCS_MAVLINK::ftp_worker` in `libraries/GCS_MAVLink/GCS_FTP.cpp`), over a filesystem that holds
//! one file, `@PARAM/param.pck` (`AP_Filesystem_Param`). The packet codec is in `wire::mavftp`.
//!
//! What ArduPilot does, and so does this server:
//! - One worker and one open file (`ftp.fd`), owned by the session that opened it
//!   (`ftp.current_session`). A request from another session while that file is open and has
//!   seen traffic in the last 3 s (`FTP_SESSION_TIMEOUT`) is refused with InvalidSession; after
//!   that the old file is closed and the request is served. TerminateSession and ResetSessions
//!   from another session are acknowledged without closing anything.
//! - The last reply is kept: a request from the same peer and session whose sequence number is
//!   one below it is a retransmission and gets that reply again, without running the operation.
//! - BurstReadFile sends up to 500 ACKs of `size` bytes (239 when 0) back to back, each with the
//!   next sequence number; the one shorter than asked (the end of the file) and the 500th are
//!   flagged `burst_complete`; at the end of the file a NAK EndOfFile follows, still flagged
//!   when the last data was short. On a link without hardware flow control each packet is
//!   followed by `3000 * packet_size / bytes_per_second` ms of silence, keeping the burst to a
//!   third of the link. Meanwhile the worker is busy: at most 5 requests wait, more are lost.
//! - ReadFile reads `size` bytes at any offset (the way a GCS fills the gaps of a burst).
//! - `param.pck` takes one read size per open (another size fails with EINVAL); the padding that
//!   keeps values inside one read block depends on it. `?withdefaults=1` adds the default of
//!   every parameter not at it (magic 0x671C); `?start=N&count=C` sends part of the table.
//! - `param.pck` is generated as it is read (`AP_Filesystem_Param::read`): each read packs the
//!   parameters as they are at that moment, going on from one of two cursors, or from the first
//!   parameter when the read goes back, as a block read again after a loss does. With
//!   `withdefaults=1` a value that leaves its default (the calibrations of the first seconds
//!   after boot) moves every later entry, so such a block comes from a later layout than its
//!   neighbours. The end found by the first read that reached it is kept for the open file.
//! - Opening `@PARAM/param.pck` makes the vehicle send its banner after the ACK.
//! - NAKs carry GCS_FTP's codes: Fail, FailErrno (+ errno; ENOENT becomes FileNotFound),
//!   InvalidDataSize, InvalidSession, EndOfFile; unknown opcodes are Fail (4.5/4.6; later
//!   versions say UnknownCommand) with a debug STATUSTEXT "Unsupported FTP: N".
//!
//! The simulated vehicle has no writable storage: opening for writing, creating, removing and
//! renaming fail with Fail, after the same request checks ArduPilot makes first.

use super::params::ParamTable;
use crate::clock::Micros;
use crate::wire::mavftp::{err, op, FtpPacket, DATA_LEN, PAYLOAD_LEN};
use crate::wire::param_pck;
use std::collections::VecDeque;

/// `FTP_SESSION_TIMEOUT`: a session idle this long may be replaced.
pub const SESSION_TIMEOUT_MS: u64 = 3_000;
/// Packets in one BurstReadFile (`transfer_size` in ArduPilot 4.5/4.6).
pub const BURST_PACKETS: u32 = 500;
/// `ftp.requests`: requests waiting for the worker.
pub const REQUEST_QUEUE: usize = 5;
/// Spacing of burst packets on a link with flow control (no burst delay): the worker sends as
/// fast as the port takes them; the real SITL capture shows one every ~5.8 ms.
pub const FAST_BURST_INTERVAL: Micros = 5_000;

/// GCS_FTP opcodes that `wire::mavftp::op` does not name.
mod opx {
    pub const CREATE_FILE: u8 = 6;
    pub const WRITE_FILE: u8 = 7;
    pub const REMOVE_FILE: u8 = 8;
    pub const CREATE_DIRECTORY: u8 = 9;
    pub const REMOVE_DIRECTORY: u8 = 10;
    pub const OPEN_FILE_WO: u8 = 11;
    pub const RENAME: u8 = 13;
}

/// `FTP_ERROR::FailErrno`: the second data byte is the errno.
pub const FAIL_ERRNO: u8 = 2;
/// `FTP_ERROR::FileExists`.
pub const FILE_EXISTS: u8 = 8;
const ENOENT: u8 = 2;
const EEXIST: u8 = 17;
pub const EINVAL: u8 = 22;

/// A request as `handle_file_transfer_protocol` queues it: header, sender and all 239 data bytes
/// (paths are read with `strnlen` over the whole field, not just `size`).
#[derive(Debug, Clone)]
pub struct Request {
    pub from: (u8, u8),
    pub seq: u16,
    pub session: u8,
    pub opcode: u8,
    pub size: u8,
    pub offset: u32,
    pub data: [u8; DATA_LEN],
}

impl Request {
    pub fn parse(from: (u8, u8), p: &[u8; PAYLOAD_LEN]) -> Request {
        let mut data = [0u8; DATA_LEN];
        data.copy_from_slice(&p[12..12 + DATA_LEN]);
        Request {
            from,
            seq: u16::from_le_bytes([p[0], p[1]]),
            session: p[2],
            opcode: p[3],
            size: p[4],
            offset: u32::from_le_bytes([p[8], p[9], p[10], p[11]]),
            data,
        }
    }

    /// `check_name_len`: the name fills `size` bytes, or `size` counts its terminating NUL too.
    fn name_ok(&self) -> bool {
        let len = self.data.iter().position(|&b| b == 0).unwrap_or(DATA_LEN);
        let size = self.size as usize;
        size != 0 && (len == size || (size == len + 1 && self.data[DATA_LEN - 1] == 0))
    }

    /// The path, with the last data byte forced to NUL as ArduPilot does.
    fn path(&self) -> Vec<u8> {
        let mut d = self.data;
        d[DATA_LEN - 1] = 0;
        let len = d.iter().position(|&b| b == 0).unwrap_or(DATA_LEN);
        d[..len].to_vec()
    }
}

/// What the server sends.
#[derive(Debug, Clone, PartialEq)]
pub enum FtpOut {
    /// A FILE_TRANSFER_PROTOCOL to a peer.
    Reply { to: (u8, u8), packet: FtpPacket },
    /// The vehicle's banner (after opening `@PARAM/param.pck`).
    Banner,
    /// A MAV_SEVERITY_DEBUG STATUSTEXT.
    Debug(String),
}

/// ArduPilot's `pending_ftp` reply: the whole data field travels, whatever `size` says.
#[derive(Debug, Clone)]
struct Reply {
    to: (u8, u8),
    seq: u16,
    session: u8,
    opcode: u8,
    size: u8,
    req_opcode: u8,
    burst_complete: bool,
    offset: u32,
    data: [u8; DATA_LEN],
}

impl Reply {
    /// `setup_reply`: same session and peer, the next sequence number, everything else zero.
    fn to(req: &Request) -> Reply {
        Reply {
            to: req.from,
            seq: req.seq.wrapping_add(1),
            session: req.session,
            opcode: 0,
            size: 0,
            req_opcode: req.opcode,
            burst_complete: false,
            offset: 0,
            data: [0; DATA_LEN],
        }
    }

    fn ack(&mut self) {
        self.opcode = op::ACK;
    }

    /// `ftp_error`.
    fn nak(&mut self, code: u8) {
        self.opcode = op::NAK;
        self.data[0] = code;
        self.size = 1;
    }

    /// `ftp_error(FailErrno)` with its errno translation.
    fn nak_errno(&mut self, errno: u8) {
        self.opcode = op::NAK;
        self.size = 1;
        self.data[0] = match errno {
            ENOENT => err::FILE_NOT_FOUND,
            EEXIST => FILE_EXISTS,
            _ => {
                self.data[1] = errno;
                self.size = 2;
                FAIL_ERRNO
            }
        };
    }

    fn packet(&self) -> FtpPacket {
        let used = self
            .data
            .iter()
            .rposition(|&b| b != 0)
            .map_or(0, |i| i + 1)
            .max(self.size as usize)
            .min(DATA_LEN);
        FtpPacket {
            seq: self.seq,
            session: self.session,
            opcode: self.opcode,
            size: self.size,
            req_opcode: self.req_opcode,
            burst_complete: self.burst_complete as u8,
            offset: self.offset,
            data: self.data[..used].to_vec(),
        }
    }
}

/// `AP_Filesystem_Param::open`'s view of a path: `Ok` for `param.pck` (query parsed), `Err(errno)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
struct PckQuery {
    start: u16,
    count: u16,
    with_defaults: bool,
}

/// C `strtoul` on the start of `s` (sign allowed, no digits gives 0), saturating.
fn strtoul(s: &[u8]) -> u64 {
    let mut i = s.iter().take_while(|b| b.is_ascii_whitespace()).count();
    let neg = match s.get(i) {
        Some(b'-') => {
            i += 1;
            true
        }
        Some(b'+') => {
            i += 1;
            false
        }
        _ => false,
    };
    let mut v: u64 = 0;
    while let Some(d) = s.get(i).filter(|b| b.is_ascii_digit()) {
        v = v.saturating_mul(10).saturating_add((d - b'0') as u64);
        i += 1;
    }
    if neg && v != 0 {
        u64::MAX
    } else {
        v
    }
}

/// Route a path as `AP_Filesystem` does (leading slashes ignored, `@PARAM/` to the parameter
/// backend, whose only file is `param.pck`, optionally followed by `?` and arguments).
fn open_param(path: &[u8]) -> Result<PckQuery, u8> {
    let p = {
        let n = path.iter().take_while(|&&b| b == b'/').count();
        &path[n..]
    };
    let rest = p.strip_prefix(b"@PARAM/").ok_or(ENOENT)?;
    let name = b"param.pck";
    if !rest.starts_with(name) || !matches!(rest.get(name.len()), None | Some(b'?')) {
        return Err(ENOENT);
    }
    let mut q = PckQuery::default();
    let Some(mut c) = rest.iter().position(|&b| b == b'?') else {
        return Ok(q);
    };
    // The scan of AP_Filesystem_Param::open: step one byte, try each argument name, jump to
    // the next '&' after a match; unknown arguments are skipped over.
    while c < rest.len() {
        c += 1;
        let s = &rest[c..];
        let arg = [&b"start="[..], b"count=", b"withdefaults="]
            .into_iter()
            .position(|a| s.starts_with(a));
        let Some(arg) = arg else { continue };
        let v = strtoul(&s[if arg == 2 { 13 } else { 6 }..]);
        match arg {
            0 if v >= u16::MAX as u64 => return Err(EINVAL),
            0 => q.start = v as u16,
            1 if v >= u16::MAX as u64 => return Err(EINVAL),
            1 => q.count = v as u16,
            _ if v > 1 => return Err(EINVAL),
            _ => q.with_defaults = v == 1,
        }
        c += 6;
        match rest[c..].iter().position(|&b| b == b'&') {
            Some(j) => c += j,
            None => break,
        }
    }
    Ok(q)
}

/// The packed file for a query at a read size, as `AP_Filesystem_Param::read` produces it.
fn pck_file(params: &ParamTable, q: PckQuery, read_size: usize) -> Vec<u8> {
    let all = params.to_pck_with(q.with_defaults);
    let s = (q.start as usize).min(all.len());
    let e = if q.count > 0 {
        (s + q.count as usize).min(all.len())
    } else {
        all.len()
    };
    let total = params.len().min(u16::MAX as usize) as u16;
    let mut b = param_pck::encode(&all[s..e], total, read_size);
    if q.with_defaults {
        b[..2].copy_from_slice(&param_pck::MAGIC_WITH_DEFAULTS.to_le_bytes());
    }
    b
}

/// ArduPilot's `crc_crc32`: the reflected 0xEDB88320 CRC, no initial or final inversion.
pub fn crc_crc32(mut crc: u32, buf: &[u8]) -> u32 {
    for &b in buf {
        let mut c = (crc ^ b as u32) & 0xFF;
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
        crc = c ^ (crc >> 8);
    }
    crc
}

/// `AP_Filesystem_Param`'s cursors per open file (`num_cursors`).
const NUM_CURSORS: usize = 2;
/// The packed header: magic, num_params, total_params.
const HEADER_LEN: u32 = 6;

/// `AP_Filesystem_Param::cursor`: where a pass over the table stands, in the table and in the
/// file (data offsets, the header not counted).
#[derive(Debug, Clone, Default)]
struct Cursor {
    /// Table index of the parameter packed last (`c.token`).
    token: usize,
    /// Parameters packed since the first (`c.idx`).
    idx: usize,
    token_ofs: u32,
    last_name: String,
    /// The part of the last packed entry that did not fit the read before.
    trailer: Vec<u8>,
}

/// The open `param.pck`, generated as it is read, like ArduPilot's: each read packs parameters
/// with their values at that moment, going on from the cursor nearest below it, or from the
/// first parameter when the read goes back (a block read again after a loss). A parameter's
/// default is packed only while its value differs from it, so a value leaving its default moves
/// every later entry: a block read again after that comes from a later layout than the blocks
/// read before it.
#[derive(Debug, Clone)]
struct OpenFile {
    query: PckQuery,
    /// Fixed by the first read (`r.read_size`).
    read_size: Option<usize>,
    /// Where the file ended when a read first reached its end (`r.file_size`): later reads stop
    /// there, even if the file has grown since.
    file_size: Option<u32>,
    cursors: [Cursor; NUM_CURSORS],
}

impl OpenFile {
    fn new(query: PckQuery) -> OpenFile {
        OpenFile {
            query,
            read_size: None,
            file_size: None,
            cursors: Default::default(),
        }
    }

    /// `pack_param`: the next entry of cursor `c`, `None` past the last one.
    fn pack(&self, params: &ParamTable, c: &mut Cursor, read_size: usize) -> Option<Vec<u8>> {
        if c.token_ofs == 0 {
            c.idx = 0;
            c.token = self.query.start as usize;
            c.last_name.clear();
        } else {
            c.idx += 1;
            c.token += 1;
        }
        if self.query.count > 0 && c.idx >= self.query.count as usize {
            return None;
        }
        let p = params.pck_entry(c.token, self.query.with_defaults)?;
        let mut b = Vec::with_capacity(32);
        let at = (c.token_ofs + HEADER_LEN) as usize;
        param_pck::encode_entry(&p, &c.last_name, at, read_size, &mut b);
        c.last_name = p.name;
        Some(b)
    }

    /// `token_seek`: bring cursor `c` to data offset `to`, from the start if it is beyond.
    fn seek(&self, params: &ParamTable, c: &mut Cursor, to: u32, read_size: usize) -> bool {
        if to == 0 || c.token_ofs > to {
            *c = Cursor::default();
        }
        if !c.trailer.is_empty() {
            let n = c.trailer.len().min((to - c.token_ofs) as usize);
            c.trailer.drain(..n);
            c.token_ofs += n as u32;
        }
        while c.token_ofs != to {
            let available = (to - c.token_ofs) as usize;
            let Some(b) = self.pack(params, c, read_size) else {
                break;
            };
            let n = b.len().min(available);
            if b.len() > available {
                c.trailer = b[n..].to_vec();
            }
            c.token_ofs += n as u32;
        }
        c.token_ofs == to
    }

    /// `AP_Filesystem_Param::read` of `count` bytes at `ofs` (after GCS_FTP's `lseek`): the
    /// bytes, or an errno.
    fn read(&mut self, params: &ParamTable, ofs: u32, count: usize) -> Result<Vec<u8>, u8> {
        if self.read_size.is_none() && count > 0 {
            self.read_size = Some(count);
        }
        if self.read_size.is_some_and(|r| r != count) {
            return Err(EINVAL);
        }
        let read_size = count;
        let mut count = count as u32;
        if let Some(size) = self.file_size {
            count = if ofs > size { 0 } else { count.min(size - ofs) };
        }
        let mut out = Vec::with_capacity(count as usize);
        let mut file_ofs = ofs;
        if file_ofs < HEADER_LEN {
            let total = params.len().min(u16::MAX as usize) as u16;
            if total <= self.query.start {
                return Err(EINVAL);
            }
            let mut num = total - self.query.start;
            if self.query.count > 0 && num > self.query.count {
                num = self.query.count;
            }
            let magic = if self.query.with_defaults {
                param_pck::MAGIC_WITH_DEFAULTS
            } else {
                param_pck::MAGIC
            };
            let mut hdr = Vec::with_capacity(6);
            hdr.extend_from_slice(&magic.to_le_bytes());
            hdr.extend_from_slice(&num.to_le_bytes());
            hdr.extend_from_slice(&total.to_le_bytes());
            let n = (HEADER_LEN - file_ofs).min(count);
            out.extend_from_slice(&hdr[file_ofs as usize..(file_ofs + n) as usize]);
            count -= n;
            file_ofs += n;
            if count == 0 {
                return Ok(out);
            }
        }
        let data_ofs = file_ofs - HEADER_LEN;
        // "find the first cursor that is positioned after the file offset", as ArduPilot
        // does it: cursor 0 unless another stands at or after the offset, before cursor 0.
        let mut best = 0;
        let mut best_ofs = self.cursors[0].token_ofs;
        for (i, c) in self.cursors.iter().enumerate().skip(1) {
            if c.token_ofs >= data_ofs && c.token_ofs < best_ofs {
                best = i;
                best_ofs = c.token_ofs;
            }
        }
        let mut c = std::mem::take(&mut self.cursors[best]);
        let result = self.read_from(params, &mut c, data_ofs, count, read_size, file_ofs, out);
        self.cursors[best] = c;
        Ok(result)
    }

    /// The data part of [`OpenFile::read`], with cursor `c` taken out of the file.
    #[allow(clippy::too_many_arguments)]
    fn read_from(
        &mut self,
        params: &ParamTable,
        c: &mut Cursor,
        data_ofs: u32,
        mut count: u32,
        read_size: usize,
        file_ofs: u32,
        mut out: Vec<u8>,
    ) -> Vec<u8> {
        if data_ofs != c.token_ofs && !self.seek(params, c, data_ofs, read_size) {
            return out; // must be EOF
        }
        if count == 0 {
            return out;
        }
        let mut total = 0u32;
        if !c.trailer.is_empty() {
            let n = c.trailer.len().min(count as usize);
            out.extend(c.trailer.drain(..n));
            count -= n as u32;
            total += n as u32;
            c.token_ofs += n as u32;
        }
        while count > 0 {
            let Some(b) = self.pack(params, c, read_size) else {
                // No more parameters: later reads end here.
                let size = file_ofs + total;
                self.file_size = Some(self.file_size.map_or(size, |s| s.min(size)));
                break;
            };
            let n = b.len().min(count as usize);
            if b.len() > count as usize {
                c.trailer = b[n..].to_vec();
            }
            out.extend_from_slice(&b[..n]);
            count -= n as u32;
            total += n as u32;
            c.token_ofs += n as u32;
        }
        out
    }
}

/// A BurstReadFile in progress.
#[derive(Debug, Clone)]
struct Burst {
    reply: Reply,
    req_offset: u32,
    /// Where the next read starts.
    pos: u32,
    max_read: u32,
    i: u32,
    next_at: Micros,
    interval: Micros,
}

/// One vehicle's FTP worker.
#[derive(Debug, Clone)]
pub struct FtpServer {
    file: Option<OpenFile>,
    /// `ftp.current_session` (`None` is -1).
    current_session: Option<u8>,
    /// `ftp.last_send_ms`: when the last reply went out (0 after a TerminateSession reply).
    last_send_ms: u64,
    /// The worker's last reply, for retransmitted requests.
    reply: Option<Reply>,
    burst: Option<Burst>,
    queue: VecDeque<Request>,
    banner_pending: bool,
    /// Bytes per second of a link without flow control, whose bursts are paced.
    no_flow_control_bw: Option<u32>,
}

impl FtpServer {
    /// A server on a link without hardware flow control of `Some(bytes_per_second)` (bursts
    /// paced by [`burst_delay_ms`]), or on one with flow control (`None`).
    pub fn with_link(no_flow_control_bw: Option<u32>) -> FtpServer {
        FtpServer {
            file: None,
            current_session: None,
            last_send_ms: 0,
            reply: None,
            burst: None,
            queue: VecDeque::new(),
            banner_pending: false,
            no_flow_control_bw,
        }
    }

    /// True while a burst is being sent.
    pub fn bursting(&self) -> bool {
        self.burst.is_some()
    }

    /// When the next burst packet is due.
    pub fn next_due(&self) -> Option<Micros> {
        self.burst.as_ref().map(|b| b.next_at)
    }

    /// A request arrives at `now`. While a burst runs the worker is busy: the request waits
    /// (at most [`REQUEST_QUEUE`], later ones are lost). Returns what goes out now.
    pub fn receive(&mut self, now: Micros, req: Request, params: &ParamTable) -> Vec<FtpOut> {
        let mut out = Vec::new();
        if self.burst.is_some() {
            if self.queue.len() < REQUEST_QUEUE {
                self.queue.push_back(req);
            }
            return out;
        }
        self.process(now, req, params, &mut out);
        self.poll_into(now, params, &mut out);
        out
    }

    /// Send the burst packets due by `now`, then serve the requests that waited for it.
    pub fn poll(&mut self, now: Micros, params: &ParamTable) -> Vec<FtpOut> {
        let mut out = Vec::new();
        self.poll_into(now, params, &mut out);
        out
    }

    fn poll_into(&mut self, now: Micros, params: &ParamTable, out: &mut Vec<FtpOut>) {
        loop {
            while self.burst.as_ref().is_some_and(|b| b.next_at <= now) {
                self.burst_step(now, params, out);
            }
            if self.burst.is_some() {
                return;
            }
            let Some(req) = self.queue.pop_front() else {
                return;
            };
            self.process(now, req, params, out);
        }
    }

    /// `ftp_push_replies`.
    fn push(&mut self, now: Micros, reply: &Reply, out: &mut Vec<FtpOut>) {
        self.last_send_ms = now / 1000;
        out.push(FtpOut::Reply {
            to: reply.to,
            packet: reply.packet(),
        });
        if reply.req_opcode == op::TERMINATE_SESSION {
            self.last_send_ms = 0;
        }
        if std::mem::take(&mut self.banner_pending) {
            out.push(FtpOut::Banner);
        }
    }

    fn close(&mut self) {
        self.file = None;
        self.current_session = None;
    }

    /// One pass of `ftp_worker`'s loop for `req`.
    fn process(&mut self, now: Micros, req: Request, params: &ParamTable, out: &mut Vec<FtpOut>) {
        let now_ms = now / 1000;
        if let Some(r) = &self.reply {
            if r.to == req.from && r.session == req.session && req.seq as u32 + 1 == r.seq as u32 {
                let r = r.clone();
                self.push(now, &r, out);
                return;
            }
        }
        let mut reply = Reply::to(&req);
        if req.size as usize > DATA_LEN {
            reply.nak(err::INVALID_DATA_SIZE);
            self.reply = Some(reply.clone());
            self.push(now, &reply, out);
            return;
        }
        let idle = now_ms.saturating_sub(self.last_send_ms);
        let other = self.current_session != Some(req.session);
        let mut debug = None;
        if other && matches!(req.opcode, op::TERMINATE_SESSION | op::RESET_SESSIONS) {
            // Terminating a different session: just ACK.
            reply.ack();
        } else if self.file.is_some() && other && idle < SESSION_TIMEOUT_MS {
            reply.nak(err::INVALID_SESSION);
        } else {
            if self.file.is_some() && other {
                // The old session has been idle for the timeout: force it closed.
                self.close();
            }
            match req.opcode {
                op::NONE => reply.ack(),
                op::TERMINATE_SESSION | op::RESET_SESSIONS => {
                    self.close();
                    reply.ack();
                }
                op::LIST_DIRECTORY => {
                    reply.offset = req.offset;
                    if req.name_ok() {
                        // No directory here has entries to list.
                        reply.nak(err::EOF);
                    } else {
                        reply.nak(err::INVALID_DATA_SIZE);
                    }
                }
                op::OPEN_FILE_RO => self.open_ro(now_ms, &req, &mut reply, params),
                op::READ_FILE => match &mut self.file {
                    None => reply.nak(err::FILE_NOT_FOUND),
                    Some(f) => {
                        let count = (req.size as usize).min(DATA_LEN);
                        match f.read(params, req.offset, count) {
                            Err(e) => reply.nak_errno(e),
                            Ok(b) if b.is_empty() => reply.nak(err::EOF),
                            Ok(b) => {
                                reply.ack();
                                reply.offset = req.offset;
                                reply.size = b.len() as u8;
                                reply.data[..b.len()].copy_from_slice(&b);
                            }
                        }
                    }
                },
                // Eaten: nothing is sent (and this request's reply setup is what is kept).
                op::ACK | op::NAK => {
                    self.reply = Some(reply);
                    return;
                }
                op::BURST_READ_FILE => {
                    if self.file.is_none() {
                        reply.nak(err::FILE_NOT_FOUND);
                    } else {
                        let max_read = if req.size == 0 {
                            DATA_LEN as u32
                        } else {
                            req.size as u32
                        };
                        let interval = match self.no_flow_control_bw {
                            // Never faster than the worker on a fast link.
                            Some(bw) => (burst_delay_ms(max_read, bw) as Micros * 1000)
                                .max(FAST_BURST_INTERVAL),
                            None => FAST_BURST_INTERVAL,
                        };
                        self.burst = Some(Burst {
                            reply,
                            req_offset: req.offset,
                            pos: req.offset,
                            max_read,
                            i: 0,
                            next_at: now,
                            interval,
                        });
                        return;
                    }
                }
                op::CALC_FILE_CRC32 => {
                    if !req.name_ok() {
                        reply.nak(err::INVALID_DATA_SIZE);
                    } else {
                        // AP_Filesystem::crc32: its own open, read 64 bytes at a time.
                        match open_param(&req.path()) {
                            Err(e) => reply.nak_errno(e),
                            Ok(q) if params.len() <= q.start as usize => reply.nak_errno(EINVAL),
                            Ok(q) => {
                                let crc = crc_crc32(0, &pck_file(params, q, 64));
                                reply.size = 4;
                                reply.data[..4].copy_from_slice(&crc.to_le_bytes());
                                reply.ack();
                            }
                        }
                    }
                }
                opx::CREATE_FILE | opx::OPEN_FILE_WO => {
                    if self.file.is_some() {
                        reply.nak(err::FAIL);
                    } else if !req.name_ok() {
                        reply.nak(err::INVALID_DATA_SIZE);
                    } else {
                        reply.nak(err::FAIL);
                    }
                }
                opx::WRITE_FILE => {
                    if self.file.is_none() {
                        reply.nak(err::FILE_NOT_FOUND);
                    } else {
                        // The open file is in read mode.
                        reply.nak(err::FAIL);
                    }
                }
                opx::CREATE_DIRECTORY | opx::REMOVE_DIRECTORY | opx::REMOVE_FILE | opx::RENAME => {
                    if req.name_ok() {
                        reply.nak(err::FAIL);
                    } else {
                        reply.nak(err::INVALID_DATA_SIZE);
                    }
                }
                other => {
                    debug = Some(format!("Unsupported FTP: {other}"));
                    reply.nak(err::FAIL);
                }
            }
        }
        self.reply = Some(reply.clone());
        self.push(now, &reply, out);
        if let Some(d) = debug {
            out.push(FtpOut::Debug(d));
        }
    }

    fn open_ro(&mut self, now_ms: u64, req: &Request, reply: &mut Reply, params: &ParamTable) {
        if self.file.is_some() && now_ms.saturating_sub(self.last_send_ms) > SESSION_TIMEOUT_MS {
            // No activity for 3 s: the client timed out waiting for the open reply.
            self.close();
        }
        if self.file.is_some() {
            reply.nak(err::FAIL);
            return;
        }
        if !req.name_ok() {
            reply.nak(err::INVALID_DATA_SIZE);
            return;
        }
        let path = req.path();
        match open_param(&path) {
            Err(e) => reply.nak_errno(e),
            Ok(query) => {
                self.file = Some(OpenFile::new(query));
                self.current_session = Some(req.session);
                reply.ack();
                reply.size = 4;
                // AP_Filesystem_Param::stat: an estimate, 12 bytes a parameter.
                let estimate = (params.len() as u32).wrapping_mul(12);
                reply.data[..4].copy_from_slice(&estimate.to_le_bytes());
                if path.starts_with(b"@PARAM/param.pck") {
                    self.banner_pending = true;
                }
            }
        }
    }

    /// One turn of BurstReadFile's loop.
    fn burst_step(&mut self, now: Micros, params: &ParamTable, out: &mut Vec<FtpOut>) {
        let Some(mut b) = self.burst.take() else {
            return;
        };
        let count = b.max_read.min(DATA_LEN as u32) as usize;
        let read = match &mut self.file {
            Some(f) => f.read(params, b.pos, count),
            None => Ok(Vec::new()),
        };
        let done = match read {
            Err(e) => {
                b.reply.nak_errno(e);
                true
            }
            Ok(d) if d.is_empty() => {
                b.reply.data = [0; DATA_LEN];
                b.reply.nak(err::EOF);
                true
            }
            Ok(d) => {
                let n = d.len() as u32;
                b.reply.data = [0; DATA_LEN];
                b.reply.data[..d.len()].copy_from_slice(&d);
                b.reply.ack();
                b.reply.offset = b.req_offset.wrapping_add(b.i.wrapping_mul(b.max_read));
                b.reply.burst_complete = n < b.max_read || b.i == BURST_PACKETS - 1;
                b.reply.size = n as u8;
                let r = b.reply.clone();
                self.push(now, &r, out);
                if n < b.max_read {
                    // So that the NAK which comes next is at the right offset.
                    b.reply.offset = b.reply.offset.wrapping_add(n);
                }
                b.reply.seq = b.reply.seq.wrapping_add(1);
                b.pos = b.pos.wrapping_add(n);
                b.i += 1;
                b.next_at += b.interval;
                b.i == BURST_PACKETS
            }
        };
        if !done {
            self.burst = Some(b);
            return;
        }
        if b.reply.opcode == op::NAK {
            let r = b.reply.clone();
            self.push(now, &r, out);
        }
        self.reply = Some(b.reply);
    }
}

impl Default for FtpServer {
    fn default() -> Self {
        FtpServer::with_link(None)
    }
}

/// GCS_FTP's burst delay on a link without flow control: `3000 * pkt_size / bw` ms, where the
/// packet is a whole FILE_TRANSFER_PROTOCOL frame (12 bytes of MAVLink 2 overhead + 254) less
/// the data bytes not read, and `bw` the port's bytes per second.
pub fn burst_delay_ms(max_read: u32, bytes_per_second: u32) -> u32 {
    if bytes_per_second == 0 {
        return 0;
    }
    let pkt_size = 12 + 254 - (DATA_LEN as u32 - max_read.min(DATA_LEN as u32));
    3000 * pkt_size / bytes_per_second
}

#[cfg(test)]
mod tests {
    use super::*;

    const GCS: (u8, u8) = (255, 190);
    const PCK: &[u8] = b"@PARAM/param.pck";

    fn req(seq: u16, session: u8, opcode: u8, size: u8, offset: u32, data: &[u8]) -> Request {
        let mut d = [0u8; DATA_LEN];
        d[..data.len()].copy_from_slice(data);
        Request {
            from: GCS,
            seq,
            session,
            opcode,
            size,
            offset,
            data: d,
        }
    }

    fn open(seq: u16, session: u8, path: &[u8]) -> Request {
        req(seq, session, op::OPEN_FILE_RO, path.len() as u8, 0, path)
    }

    /// The FTP packets of `out` (to the GCS).
    fn packets(out: &[FtpOut]) -> Vec<FtpPacket> {
        out.iter()
            .filter_map(|o| match o {
                FtpOut::Reply { to, packet } => {
                    assert_eq!(*to, GCS);
                    Some(packet.clone())
                }
                _ => None,
            })
            .collect()
    }

    fn one(out: &[FtpOut]) -> FtpPacket {
        let p = packets(out);
        assert_eq!(p.len(), 1, "{out:?}");
        p[0].clone()
    }

    fn nak_code(p: &FtpPacket) -> (u8, Vec<u8>) {
        assert_eq!(p.opcode, op::NAK, "{p:?}");
        (p.size, p.data[..p.size as usize].to_vec())
    }

    /// Run a burst to its end; returns its packets.
    fn drain(ftp: &mut FtpServer, params: &ParamTable, mut out: Vec<FtpOut>) -> Vec<FtpPacket> {
        let mut t = 0;
        while ftp.bursting() {
            t = ftp.next_due().unwrap();
            out.extend(ftp.poll(t, params));
        }
        let _ = t;
        packets(&out)
    }

    #[test]
    fn burst_download_decodes_to_the_table() {
        let params = ParamTable::copter(0);
        let mut ftp = FtpServer::default();
        let out = ftp.receive(0, open(0, 7, PCK), &params);
        // ACK first, then the banner (GCS_FTP sends it after the reply).
        assert!(matches!(out.last(), Some(FtpOut::Banner)), "{out:?}");
        let r = one(&out);
        assert_eq!((r.opcode, r.seq, r.size, r.session), (op::ACK, 1, 4, 7));
        assert_eq!((r.req_opcode, r.offset), (op::OPEN_FILE_RO, 0));
        // AP_Filesystem_Param::stat: 12 bytes a parameter, an estimate.
        assert_eq!(r.data, (1354u32 * 12).to_le_bytes());
        let out = ftp.receive(0, req(1, 7, op::BURST_READ_FILE, 239, 0, &[]), &params);
        let burst = drain(&mut ftp, &params, out);
        let (nak, data) = burst.split_last().unwrap();
        let mut file = Vec::new();
        for (k, p) in data.iter().enumerate() {
            assert_eq!((p.opcode, p.req_opcode, p.seq), (op::ACK, 15, 2 + k as u16));
            assert_eq!(p.offset as usize, file.len());
            let last = k == data.len() - 1;
            assert_eq!(p.burst_complete == 1, last, "only the short one is flagged");
            assert_eq!(p.size < 239, last);
            file.extend_from_slice(&p.data[..p.size as usize]);
        }
        // NAK EndOfFile at the end of the file, next sequence number, still flagged.
        assert_eq!(nak_code(nak), (1, vec![err::EOF]));
        assert_eq!(
            (nak.seq as usize, nak.offset as usize, nak.burst_complete),
            (2 + data.len(), file.len(), 1)
        );
        let f = param_pck::decode(&file).unwrap();
        assert_eq!(f.magic, param_pck::MAGIC);
        assert_eq!(f.params, params.to_pck());
        assert_eq!(file, pck_file(&params, PckQuery::default(), 239));
    }

    #[test]
    fn read_fills_gaps_at_any_offset_with_the_burst_size() {
        let params = ParamTable::copter(0);
        let mut ftp = FtpServer::default();
        ftp.receive(0, open(0, 1, PCK), &params);
        let file = pck_file(&params, PckQuery::default(), 239);
        for (seq, ofs) in [(1u16, 478u32), (3, 0), (5, 14818), (7, 239 * 3 + 5)] {
            let r = one(&ftp.receive(0, req(seq, 1, op::READ_FILE, 239, ofs, &[]), &params));
            assert_eq!((r.opcode, r.seq, r.offset), (op::ACK, seq + 1, ofs));
            let end = (ofs as usize + 239).min(file.len());
            assert_eq!(&r.data[..r.size as usize], &file[ofs as usize..end]);
        }
        // At and past the end: EndOfFile.
        let r = one(&ftp.receive(0, req(9, 1, op::READ_FILE, 239, 15024, &[]), &params));
        assert_eq!(nak_code(&r), (1, vec![err::EOF]));
        // Another read size on the same open file: EINVAL (FailErrno + errno).
        let r = one(&ftp.receive(0, req(11, 1, op::READ_FILE, 100, 0, &[]), &params));
        assert_eq!(nak_code(&r), (2, vec![FAIL_ERRNO, EINVAL]));
    }

    #[test]
    fn a_retransmitted_request_gets_the_last_reply_again() {
        let params = ParamTable::copter(0);
        let mut ftp = FtpServer::default();
        let first = one(&ftp.receive(0, open(0, 4, PCK), &params));
        // The same open again (our ACK was lost): the same ACK, not "already open" (Fail), and
        // no second banner.
        let out = ftp.receive(100_000, open(0, 4, PCK), &params);
        assert_eq!(out.len(), 1, "{out:?}");
        assert_eq!(one(&out), first);
        let read = one(&ftp.receive(0, req(1, 4, op::READ_FILE, 239, 239, &[]), &params));
        assert_eq!(
            one(&ftp.receive(0, req(1, 4, op::READ_FILE, 239, 239, &[]), &params)),
            read
        );
        // Not a retransmission: another sequence number, another session or another peer.
        let r = one(&ftp.receive(0, open(2, 4, PCK), &params));
        assert_eq!(
            nak_code(&r),
            (1, vec![err::FAIL]),
            "a new open: the file is open"
        );
        let mut other = open(2, 4, PCK);
        other.from = (250, 1);
        match &ftp.receive(0, other, &params)[..] {
            [FtpOut::Reply { to, packet }] => {
                assert_eq!(*to, (250, 1));
                assert_eq!(nak_code(packet), (1, vec![err::FAIL]));
            }
            out => panic!("{out:?}"),
        }
    }

    #[test]
    fn sessions_as_ardupilot_keeps_them() {
        let params = ParamTable::copter(0);
        let mut ftp = FtpServer::default();
        // Nothing open: a read finds no file.
        let r = one(&ftp.receive(0, req(0, 1, op::READ_FILE, 239, 0, &[]), &params));
        assert_eq!(nak_code(&r), (1, vec![err::FILE_NOT_FOUND]));
        ftp.receive(0, open(1, 1, PCK), &params);
        // Another session while the file is in use: InvalidSession.
        let r = one(&ftp.receive(1_000_000, req(10, 2, op::READ_FILE, 239, 0, &[]), &params));
        assert_eq!(nak_code(&r), (1, vec![err::INVALID_SESSION]));
        // Terminate or reset of another session: ACK, and the file stays open.
        for opc in [op::TERMINATE_SESSION, op::RESET_SESSIONS] {
            let r = one(&ftp.receive(1_000_000, req(20 + opc as u16, 2, opc, 0, 0, &[]), &params));
            assert_eq!((r.opcode, r.req_opcode), (op::ACK, opc));
        }
        let r = one(&ftp.receive(1_000_000, req(30, 1, op::READ_FILE, 239, 0, &[]), &params));
        assert_eq!(r.opcode, op::ACK);
        // 3 s without traffic: another session takes over (the old file is closed).
        let r = one(&ftp.receive(4_100_000, req(40, 2, op::READ_FILE, 239, 0, &[]), &params));
        assert_eq!(nak_code(&r), (1, vec![err::FILE_NOT_FOUND]));
        let r = one(&ftp.receive(4_100_000, open(41, 2, PCK), &params));
        assert_eq!(r.opcode, op::ACK);
        // Own terminate closes.
        let r = one(&ftp.receive(
            4_200_000,
            req(43, 2, op::TERMINATE_SESSION, 0, 0, &[]),
            &params,
        ));
        assert_eq!(r.opcode, op::ACK);
        let r = one(&ftp.receive(4_200_000, req(45, 2, op::READ_FILE, 239, 0, &[]), &params));
        assert_eq!(nak_code(&r), (1, vec![err::FILE_NOT_FOUND]));
        // Own reset closes too; an open idle for 3 s is closed by a new open.
        ftp.receive(4_300_000, open(50, 3, PCK), &params);
        let r = one(&ftp.receive(4_300_000, open(52, 3, PCK), &params));
        assert_eq!(nak_code(&r), (1, vec![err::FAIL]));
        let r = one(&ftp.receive(7_400_000, open(54, 3, PCK), &params));
        assert_eq!(r.opcode, op::ACK);
        let r = one(&ftp.receive(
            7_500_000,
            req(56, 3, op::RESET_SESSIONS, 0, 0, &[]),
            &params,
        ));
        assert_eq!(r.opcode, op::ACK);
        let r = one(&ftp.receive(7_500_000, open(58, 4, PCK), &params));
        assert_eq!(
            r.opcode,
            op::ACK,
            "the reset closed it: another session can open"
        );
    }

    #[test]
    fn naks_carry_gcs_ftp_codes() {
        let params = ParamTable::copter(10);
        let mut ftp = FtpServer::default();
        let mut seq = 0;
        let mut ask = |ftp: &mut FtpServer, mut r: Request| {
            seq += 2;
            r.seq = seq;
            ftp.receive(0, r, &params)
        };
        let nak = |out: Vec<FtpOut>| nak_code(&one(&out));
        assert_eq!(
            nak(ask(&mut ftp, open(0, 1, b"/etc/passwd"))),
            (1, vec![err::FILE_NOT_FOUND])
        );
        assert_eq!(
            nak(ask(&mut ftp, open(0, 1, b"@PARAM/param.pckx"))),
            (1, vec![err::FILE_NOT_FOUND])
        );
        // The name must fill `size` (or `size` may count its NUL).
        assert_eq!(
            nak(ask(&mut ftp, req(0, 1, op::OPEN_FILE_RO, 0, 0, PCK))),
            (1, vec![err::INVALID_DATA_SIZE])
        );
        assert_eq!(
            nak(ask(&mut ftp, req(0, 1, op::OPEN_FILE_RO, 10, 0, PCK))),
            (1, vec![err::INVALID_DATA_SIZE])
        );
        assert_eq!(
            nak(ask(&mut ftp, req(0, 1, op::READ_FILE, 240, 0, &[]))),
            (1, vec![err::INVALID_DATA_SIZE])
        );
        // A bad argument: EINVAL from AP_Filesystem_Param::open.
        for bad in [
            &b"@PARAM/param.pck?withdefaults=2"[..],
            b"@PARAM/param.pck?start=70000",
            b"@PARAM/param.pck?count=-1",
        ] {
            assert_eq!(
                nak(ask(&mut ftp, open(0, 1, bad))),
                (2, vec![FAIL_ERRNO, EINVAL]),
                "{}",
                String::from_utf8_lossy(bad)
            );
        }
        // Unknown opcodes: Fail, and a debug text.
        let out = ask(&mut ftp, req(0, 1, 77, 0, 0, &[]));
        assert_eq!(nak_code(&one(&out)), (1, vec![err::FAIL]));
        assert_eq!(
            out.last(),
            Some(&FtpOut::Debug("Unsupported FTP: 77".into()))
        );
        assert_eq!(
            nak(ask(&mut ftp, req(0, 1, 12, 0, 0, &[]))),
            (1, vec![err::FAIL]),
            "TruncateFile"
        );
        // No writable storage.
        assert_eq!(
            nak(ask(&mut ftp, req(0, 1, opx::CREATE_FILE, 3, 0, b"/ab"))),
            (1, vec![err::FAIL])
        );
        assert_eq!(
            nak(ask(&mut ftp, req(0, 1, opx::WRITE_FILE, 3, 0, b"abc"))),
            (1, vec![err::FILE_NOT_FOUND])
        );
        assert_eq!(
            nak(ask(&mut ftp, req(0, 1, op::LIST_DIRECTORY, 1, 0, b"/"))),
            (1, vec![err::EOF])
        );
        // ACK and NAK from a GCS are eaten.
        assert!(ask(&mut ftp, req(0, 1, op::ACK, 0, 0, &[])).is_empty());
        assert!(ask(&mut ftp, req(0, 1, op::NAK, 0, 0, &[])).is_empty());
        // A name sent with its NUL counted opens too.
        let mut with_nul = PCK.to_vec();
        with_nul.push(0);
        let r = one(&ask(
            &mut ftp,
            req(0, 1, op::OPEN_FILE_RO, 17, 0, &with_nul),
        ));
        assert_eq!(r.opcode, op::ACK);
    }

    #[test]
    fn queries_select_defaults_and_ranges() {
        let mut params = ParamTable::copter(0);
        assert_eq!(
            open_param(b"/@PARAM/param.pck?withdefaults=1&start=5"),
            Ok(PckQuery {
                start: 5,
                count: 0,
                with_defaults: true
            })
        );
        assert_eq!(
            open_param(b"@PARAM/param.pck?foo=1&count=3").unwrap().count,
            3
        );
        assert_eq!(
            open_param(b"@PARAM/param.pck?withdefaults=0"),
            Ok(PckQuery::default())
        );
        assert_eq!(open_param(b"@SYS/threads.txt"), Err(ENOENT));
        // withdefaults=1: magic 0x671C and the default of each parameter not at it.
        params.set("RTL_ALT", 2500.0);
        let mut ftp = FtpServer::default();
        ftp.receive(0, open(0, 1, b"@PARAM/param.pck?withdefaults=1"), &params);
        let out = ftp.receive(0, req(1, 1, op::BURST_READ_FILE, 0, 0, &[]), &params);
        let burst = drain(&mut ftp, &params, out);
        let file: Vec<u8> = burst
            .iter()
            .filter(|p| p.opcode == op::ACK)
            .flat_map(|p| p.data[..p.size as usize].to_vec())
            .collect();
        let f = param_pck::decode(&file).unwrap();
        assert_eq!(f.magic, param_pck::MAGIC_WITH_DEFAULTS);
        let rtl = f.params.iter().find(|p| p.name == "RTL_ALT").unwrap();
        assert_eq!((rtl.value, rtl.default), (2500.0, Some(1500.0)));
        assert_eq!(f.params.iter().filter(|p| p.default.is_some()).count(), 31);
        // start and count: part of the table, total_params still all of it.
        let mut ftp = FtpServer::default();
        ftp.receive(
            0,
            open(0, 1, b"@PARAM/param.pck?start=100&count=10"),
            &params,
        );
        let r = one(&ftp.receive(0, req(1, 1, op::READ_FILE, 239, 0, &[]), &params));
        let f = param_pck::decode(&r.data[..r.size as usize]).unwrap();
        assert_eq!((f.num_params, f.total_params), (10, 1354));
        assert_eq!(f.params[0].name, params.get(100).unwrap().name);
        // start past the table: EINVAL at the header.
        let mut ftp = FtpServer::default();
        ftp.receive(0, open(0, 1, b"@PARAM/param.pck?start=2000"), &params);
        let r = one(&ftp.receive(0, req(1, 1, op::READ_FILE, 239, 0, &[]), &params));
        assert_eq!(nak_code(&r), (2, vec![FAIL_ERRNO, EINVAL]));
    }

    #[test]
    fn burst_of_500_then_the_next_burst_continues() {
        let params = ParamTable::copter(0);
        let mut ftp = FtpServer::default();
        ftp.receive(0, open(0, 1, PCK), &params);
        let out = ftp.receive(0, req(1, 1, op::BURST_READ_FILE, 10, 0, &[]), &params);
        let burst = drain(&mut ftp, &params, out);
        assert_eq!(burst.len(), 500, "no NAK after a full burst");
        assert!(burst[..499]
            .iter()
            .all(|p| p.burst_complete == 0 && p.size == 10));
        assert_eq!((burst[499].burst_complete, burst[499].offset), (1, 4990));
        let out = ftp.receive(0, req(502, 1, op::BURST_READ_FILE, 10, 5000, &[]), &params);
        let next = drain(&mut ftp, &params, out);
        assert_eq!((next[0].seq, next[0].offset), (503, 5000));
    }

    #[test]
    fn bursts_are_paced_on_a_link_without_flow_control() {
        // 57600 baud: 3000 * 266 / 5760 = 138 ms after each 239-byte packet.
        assert_eq!(burst_delay_ms(239, 5760), 138);
        assert_eq!(burst_delay_ms(100, 5760), 66);
        let params = ParamTable::copter(0);
        let mut ftp = FtpServer::with_link(Some(5760));
        ftp.receive(0, open(0, 1, PCK), &params);
        let out = ftp.receive(0, req(1, 1, op::BURST_READ_FILE, 239, 0, &[]), &params);
        assert_eq!(packets(&out).len(), 1, "the first at once");
        assert_eq!(ftp.next_due(), Some(138_000));
        assert!(packets(&ftp.poll(137_000, &params)).is_empty());
        assert_eq!(packets(&ftp.poll(138_000, &params)).len(), 1);
        // The worker is busy: requests wait (5 at most) and are served after the burst.
        for k in 0..7 {
            assert!(ftp
                .receive(140_000, req(100 + 2 * k, 1, op::NONE, 0, 0, &[]), &params)
                .is_empty());
        }
        let mut rest = Vec::new();
        let mut t = 0;
        while ftp.bursting() {
            t = ftp.next_due().unwrap();
            rest.extend(ftp.poll(t, &params));
        }
        let rest = packets(&rest);
        // 63 data packets and the NAK: 64 sends 138 ms apart.
        assert_eq!(t, 63 * 138_000);
        let after: Vec<u16> = rest
            .iter()
            .filter(|p| p.req_opcode == op::NONE)
            .map(|p| p.seq)
            .collect();
        assert_eq!(
            after,
            vec![101, 103, 105, 107, 109],
            "5 waited, 2 were lost"
        );
    }

    #[test]
    fn crc32_of_the_parameter_file() {
        let params = ParamTable::copter(0);
        let mut ftp = FtpServer::default();
        let r = one(&ftp.receive(0, req(0, 1, op::CALC_FILE_CRC32, 16, 0, PCK), &params));
        let crc = u32::from_le_bytes(r.data[..4].try_into().unwrap());
        assert_eq!((r.opcode, r.size), (op::ACK, 4));
        assert_eq!(
            crc,
            crc_crc32(0, &pck_file(&params, PckQuery::default(), 64))
        );
        // The table-free CRC agrees with the standard table's first entries.
        assert_eq!(crc_crc32(0, &[1]), 0x7707_3096);
        let r = one(&ftp.receive(0, req(2, 1, op::CALC_FILE_CRC32, 4, 0, b"/foo"), &params));
        assert_eq!(nak_code(&r), (1, vec![err::FILE_NOT_FOUND]));
    }

    /// ReadFile of `ofs` on session 1 with sequence `seq`: the data.
    fn read_at(ftp: &mut FtpServer, params: &ParamTable, seq: u16, ofs: u32) -> Vec<u8> {
        let r = one(&ftp.receive(0, req(seq, 1, op::READ_FILE, 239, ofs, &[]), params));
        assert_eq!(r.opcode, op::ACK, "{r:?}");
        r.data[..r.size as usize].to_vec()
    }

    const WITH_DEFAULTS: &[u8] = b"@PARAM/param.pck?withdefaults=1";

    #[test]
    fn blocks_read_in_any_order_make_the_file_while_nothing_changes() {
        let params = ParamTable::copter(0);
        let q = open_param(WITH_DEFAULTS).unwrap();
        let whole = pck_file(&params, q, 239);
        let mut ftp = FtpServer::default();
        ftp.receive(0, open(0, 1, WITH_DEFAULTS), &params);
        let blocks = whole.len().div_ceil(239);
        // Backwards, then every third, then the rest: each read goes back or skips ahead.
        let mut order: Vec<usize> = (0..blocks).rev().collect();
        order.extend((0..blocks).step_by(3));
        let mut file = vec![0u8; whole.len()];
        for (k, b) in order.into_iter().chain(0..blocks).enumerate() {
            let got = read_at(&mut ftp, &params, 2 * k as u16 + 1, (b * 239) as u32);
            file[b * 239..b * 239 + got.len()].copy_from_slice(&got);
        }
        assert_eq!(file, whole);
    }

    #[test]
    fn a_block_read_again_after_a_value_left_its_default_comes_from_the_later_layout() {
        let mut params = ParamTable::copter(0);
        let q = open_param(WITH_DEFAULTS).unwrap();
        let mut ftp = FtpServer::default();
        ftp.receive(0, open(0, 1, WITH_DEFAULTS), &params);
        let out = ftp.receive(0, req(1, 1, op::BURST_READ_FILE, 239, 0, &[]), &params);
        let burst: Vec<u8> = drain(&mut ftp, &params, out)
            .iter()
            .filter(|p| p.opcode == op::ACK)
            .flat_map(|p| p.data[..p.size as usize].to_vec())
            .collect();
        let before = pck_file(&params, q, 239);
        assert_eq!(burst, before, "one pass: the file as it stood");
        // The gyro calibration at boot: INS_GYROFFS_X (offset ~1574) leaves its default 0, so
        // the file gains its default (4 bytes) and every later entry moves.
        params.set("INS_GYROFFS_X", 2.3449767468264326e-05);
        let after = pck_file(&params, q, 239);
        assert!(after.len() > before.len());
        let ofs = 239 * 20;
        let again = read_at(&mut ftp, &params, 600, ofs);
        assert_eq!(again, after[ofs as usize..ofs as usize + 239]);
        assert_ne!(again, before[ofs as usize..ofs as usize + 239]);
        // Joined to the blocks of the burst, it does not make a file.
        let mut mixed = before.clone();
        mixed[ofs as usize..ofs as usize + 239].copy_from_slice(&again);
        assert!(
            param_pck::decode(&mixed).is_err()
                || param_pck::decode(&mixed) != param_pck::decode(&before)
        );
        // A block before the change is as it was.
        assert_eq!(read_at(&mut ftp, &params, 602, 239 * 2), before[478..717]);
        // The end the burst found stays the end of this open file: the last block read again
        // stops there, though the file has grown since.
        let last = (before.len() / 239 * 239) as u32;
        let tail = read_at(&mut ftp, &params, 604, last);
        assert_eq!(last as usize + tail.len(), before.len());
        assert_eq!(tail, after[last as usize..before.len()]);
        // A new open reads the file as it is now.
        ftp.receive(0, req(606, 1, op::TERMINATE_SESSION, 0, 0, &[]), &params);
        ftp.receive(0, open(608, 1, WITH_DEFAULTS), &params);
        let out = ftp.receive(0, req(609, 1, op::BURST_READ_FILE, 239, 0, &[]), &params);
        let fresh: Vec<u8> = drain(&mut ftp, &params, out)
            .iter()
            .filter(|p| p.opcode == op::ACK)
            .flat_map(|p| p.data[..p.size as usize].to_vec())
            .collect();
        assert_eq!(fresh, after);
    }

    #[test]
    fn without_defaults_a_change_keeps_the_layout() {
        let mut params = ParamTable::copter(0);
        let q = PckQuery::default();
        let mut ftp = FtpServer::default();
        ftp.receive(0, open(0, 1, PCK), &params);
        let first = read_at(&mut ftp, &params, 1, 239 * 20);
        params.set("INS_GYROFFS_X", 2.3449767468264326e-05);
        let again = read_at(&mut ftp, &params, 3, 239 * 20);
        assert_eq!(first, again);
        assert_eq!(
            pck_file(&params, q, 239).len(),
            pck_file(&ParamTable::copter(0), q, 239).len()
        );
    }
}
