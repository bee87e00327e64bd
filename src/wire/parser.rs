//! Finding MAVLink frames in a byte stream, with per-link counters.
//!
//! The frames found are a function of the bytes alone, never of where reads split them: a
//! candidate frame is decided only once enough bytes are there to decide it the same way whatever
//! comes after (or at the end of a datagram, which [`FrameParser::end_of_datagram`] marks). So
//! `push(a); push(b)` finds exactly what `push(a ++ b)` finds, counters included.
//!
//! Rules, for a candidate starting at a magic byte (0xFE MAVLink 1, 0xFD MAVLink 2):
//! - Bytes before a magic byte are skipped and counted as garbage.
//! - Not a frame for us (skipped as one garbage byte): a MAVLink 2 incompatibility flag we do not
//!   understand (the spec says drop such frames), or a message id the dialect knows with a payload
//!   longer than its definition allows: the base fields for MAVLink 1, which never carries
//!   extension fields, and base plus extension fields for MAVLink 2 (whose payloads may also be
//!   shorter, trailing zeros being truncated).
//! - A known id is decided once the whole frame (signature included) is there: a good CRC makes it
//!   a frame; a bad CRC moves the parser one byte on, so a real frame that starts inside the
//!   rejected bytes is still found. The failure is counted as `truncated` when a frame is then
//!   accepted that starts inside the rejected span (the sender was cut off), else as `crc_errors`.
//! - A message id the dialect does not know has no CRC_EXTRA, so its CRC cannot be checked. Such a
//!   frame is accepted (counted in `unknown_ids`, handed on with `message: None`) only when the byte
//!   after it is a magic byte or the datagram ends there, and no CRC-valid known frame starts inside
//!   it; it is decided only once the bytes are there to tell whether one does. Otherwise random
//!   garbage after a stray magic byte would be taken for a frame and swallow real ones.
//! - At the end of a datagram, candidates cut off by it are skipped a byte at a time like bad ones:
//!   each one that a later frame of the datagram starts inside counts as `truncated`, and any
//!   others together as one truncated frame.
//! - A frame whose payload does not decode (e.g. an enum value newer than our dialect) is still a
//!   frame: counted in `decode_errors`, handed on with `message: None`.
//! - A lazy parser ([`FrameParser::lazy`], the core's links) decodes nothing: every frame is handed
//!   on with `message: None`, and its reader decodes the messages it reads (and counts those that
//!   do not decode).
//!
//! Work per byte is bounded whatever the input: each position is checked at most once (a CRC of at
//! most one frame), and the bytes held back never exceed two frames' worth.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, VecDeque};
use std::sync::OnceLock;

use super::frame::{
    frame_crc_in, Frame, RawBytes, Version, IFLAG_SIGNED, MAGIC_V1, MAGIC_V2, MAX_FRAME_LEN,
    SIGNATURE_LEN,
};
use crate::dialect::MavMessage;
use mavlink::{MavlinkVersion, Message};

/// Counters of what the parser saw on one link.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct ParserStats {
    /// Bytes fed in.
    pub bytes: u64,
    /// Frames accepted (known and unknown ids).
    pub frames: u64,
    /// Candidate frames with a known id whose CRC did not match.
    pub crc_errors: u64,
    /// Frames cut off by the start of another frame, or by the end of a datagram.
    pub truncated: u64,
    /// Frames accepted whose message id the dialect does not know.
    pub unknown_ids: u64,
    /// Frames with a good CRC whose payload did not decode.
    pub decode_errors: u64,
    /// Bytes skipped while looking for a frame.
    pub garbage_bytes: u64,
    /// Accepted MAVLink 1 frames.
    pub v1_frames: u64,
    /// Accepted MAVLink 2 frames.
    pub v2_frames: u64,
    /// Accepted MAVLink 2 frames carrying a signature.
    pub signed_frames: u64,
}

impl ParserStats {
    /// Add counter increases to a running total.
    pub fn add(&mut self, d: &ParserStats) {
        self.bytes += d.bytes;
        self.frames += d.frames;
        self.crc_errors += d.crc_errors;
        self.truncated += d.truncated;
        self.unknown_ids += d.unknown_ids;
        self.decode_errors += d.decode_errors;
        self.garbage_bytes += d.garbage_bytes;
        self.v1_frames += d.v1_frames;
        self.v2_frames += d.v2_frames;
        self.signed_frames += d.signed_frames;
    }

    /// The increase of the counters from `before` to `self`.
    pub fn since(&self, before: &ParserStats) -> ParserStats {
        ParserStats {
            bytes: self.bytes - before.bytes,
            frames: self.frames - before.frames,
            crc_errors: self.crc_errors - before.crc_errors,
            truncated: self.truncated - before.truncated,
            unknown_ids: self.unknown_ids - before.unknown_ids,
            decode_errors: self.decode_errors - before.decode_errors,
            garbage_bytes: self.garbage_bytes - before.garbage_bytes,
            v1_frames: self.v1_frames - before.v1_frames,
            v2_frames: self.v2_frames - before.v2_frames,
            signed_frames: self.signed_frames - before.signed_frames,
        }
    }
}

/// What the dialect says about one message id: its CRC_EXTRA and the longest payload it may have.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MsgLimits {
    pub crc_extra: u8,
    /// Payload length of the base fields: the only length a MAVLink 1 frame may carry.
    pub max_len_v1: u8,
    /// Payload length with the extension fields: the most a MAVLink 2 frame may carry.
    pub max_len_v2: u8,
    /// The message has a target_system or target_component field.
    pub targeted: bool,
}

/// [`MsgLimits`] of every id the dialect knows, computed once from the generated code: ids below
/// 65,536 (all of ardupilotmega's) in a two-level table, others asked for on the spot.
struct MsgTable {
    /// Page of each high byte of a 16-bit id; page 0 is all unknown.
    index: [u16; 256],
    pages: Vec<[Option<MsgLimits>; 256]>,
}

impl MsgTable {
    fn build() -> MsgTable {
        let mut t = MsgTable {
            index: [0; 256],
            pages: vec![[None; 256]],
        };
        for id in 0..=0xFFFFu32 {
            if let Some(l) = limits_from_dialect(id) {
                let hi = (id >> 8) as usize;
                if t.index[hi] == 0 {
                    t.index[hi] = t.pages.len() as u16;
                    t.pages.push([None; 256]);
                }
                t.pages[t.index[hi] as usize][(id & 0xFF) as usize] = Some(l);
            }
        }
        t
    }

    #[inline]
    fn get(&self, msgid: u32) -> Option<MsgLimits> {
        if msgid <= 0xFFFF {
            self.pages[self.index[(msgid >> 8) as usize] as usize][(msgid & 0xFF) as usize]
        } else {
            limits_from_dialect(msgid)
        }
    }
}

fn table() -> &'static MsgTable {
    static TABLE: OnceLock<MsgTable> = OnceLock::new();
    TABLE.get_or_init(MsgTable::build)
}

/// CRC_EXTRA and payload limits of a message id, or `None` if the dialect does not know it.
pub fn msg_limits(msgid: u32) -> Option<MsgLimits> {
    table().get(msgid)
}

/// Ask the generated dialect code. The MAVLink 1 serializer writes exactly the base fields; the
/// MAVLink 2 one writes all fields and then reports a length with trailing zeros cut, so its full
/// length is read off the buffer instead: the last byte it wrote, over two fills of the buffer
/// (a written byte equals at most one of the two fill values).
fn limits_from_dialect(msgid: u32) -> Option<MsgLimits> {
    let msg = MavMessage::default_message_from_id(msgid)?;
    let mut buf = [0u8; 255];
    let base = msg.ser(MavlinkVersion::V1, &mut buf);
    let mut full = base;
    for fill in [0xAA, 0x55] {
        buf = [fill; 255];
        msg.ser(MavlinkVersion::V2, &mut buf);
        if let Some(last) = buf.iter().rposition(|&b| b != fill) {
            full = full.max(last + 1);
        }
    }
    Some(MsgLimits {
        crc_extra: MavMessage::extra_crc(msgid),
        max_len_v1: base as u8,
        max_len_v2: full as u8,
        targeted: msg.target_system_id().is_some() || msg.target_component_id().is_some(),
    })
}

/// Streaming frame parser. Feed it bytes with [`FrameParser::push`]; it calls back once per frame.
pub struct FrameParser {
    /// Bytes held back, undecided: `buf[0]` is at stream position `pos`.
    buf: Vec<u8>,
    /// Stream position (bytes since the start, or since the last datagram) of the next byte to
    /// decide.
    pos: u64,
    stats: ParserStats,
    /// Rejected candidates whose counter waits on whether a frame is accepted inside them, by
    /// the end of their span: a bad CRC counts as `truncated` if one is, else as `crc_errors`;
    /// an unknown id rejected counts as `truncated` if one is, else as nothing.
    pending: BinaryHeap<Reverse<(u64, Rejected)>>,
    /// Candidates cut off by the end of the datagram being flushed.
    cut_off: u64,
    /// Look-ahead for "does a CRC-valid frame start inside this unknown-id candidate": no
    /// position in (`pos`, `probe`) starts one, except `found` if set.
    probe: u64,
    found: Option<(u64, usize)>,
    /// Bad CRCs the look-ahead met, (position, length), so the CRC is not computed twice.
    ahead: VecDeque<(u64, usize)>,
    table: &'static MsgTable,
    /// Decode each known frame's message (else [`FrameParser::lazy`]: never).
    decode: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Rejected {
    BadCrc,
    UnknownId,
}

impl Default for FrameParser {
    fn default() -> Self {
        FrameParser {
            buf: Vec::new(),
            pos: 0,
            stats: ParserStats::default(),
            pending: BinaryHeap::new(),
            cut_off: 0,
            probe: 0,
            found: None,
            ahead: VecDeque::new(),
            table: table(),
            decode: true,
        }
    }
}

impl std::fmt::Debug for FrameParser {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FrameParser")
            .field("pending_bytes", &self.buf.len())
            .field("pos", &self.pos)
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

/// What the bytes at a magic byte are, from those bytes alone.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Candidate {
    /// Not enough bytes yet to decide.
    NeedMore,
    /// Not a frame for us: skip one byte.
    Reject,
    /// A known-id frame with a bad CRC, `len` bytes long.
    BadCrc(usize),
    /// A frame with a good CRC, `len` bytes long.
    Good(usize),
    /// An unknown-id frame, `len` bytes long, still to be confirmed by its surroundings.
    Unknown(usize),
}

#[inline]
fn is_magic(b: u8) -> bool {
    b == MAGIC_V1 || b == MAGIC_V2
}

impl FrameParser {
    pub fn new() -> Self {
        Self::default()
    }

    /// A parser that frames and checks but decodes nothing: every frame comes with
    /// `message: None`, for a reader that decodes only the messages it reads (the core decodes
    /// perhaps half of what a vehicle streams) and counts those that fail.
    pub fn lazy() -> Self {
        FrameParser {
            decode: false,
            ..Self::default()
        }
    }

    pub fn stats(&self) -> &ParserStats {
        &self.stats
    }

    /// Bytes held back waiting for the rest of a frame (never more than two frames' worth).
    pub fn pending(&self) -> usize {
        self.buf.len()
    }

    /// An empty Vec with room for the frames `len` more bytes probably hold (from the bytes per
    /// frame seen so far, plus a quarter), so collecting them seldom has to grow it.
    pub fn frame_vec(&self, len: usize) -> Vec<Frame> {
        const FIRST_GUESS: u64 = 32;
        let per_frame = match self.stats.frames {
            0 => FIRST_GUESS,
            n => (self.stats.bytes / n).max(8),
        } as usize;
        let n = len / per_frame;
        Vec::with_capacity(n + n / 4 + 4)
    }

    /// Feed bytes from a stream; `emit` is called for each complete frame, in order.
    pub fn push(&mut self, bytes: &[u8], emit: impl FnMut(Frame)) {
        self.push_to(bytes, &mut Emit(emit));
    }

    /// [`FrameParser::push`] appending the frames to `frames` (each decoded where it lies).
    pub fn push_into(&mut self, bytes: &[u8], frames: &mut Vec<Frame>) {
        self.push_to(bytes, frames);
    }

    /// [`FrameParser::end_of_datagram`] appending the frames to `frames`.
    pub fn end_of_datagram_into(&mut self, frames: &mut Vec<Frame>) {
        self.end_of_datagram_to(frames);
    }

    fn push_to(&mut self, bytes: &[u8], emit: &mut impl Sink) {
        self.stats.bytes += bytes.len() as u64;
        let base = self.pos;
        if self.buf.is_empty() {
            // Nothing held back: parse the caller's bytes in place, keep only the undecided tail.
            self.scan(bytes, base, false, emit);
            let used = (self.pos - base) as usize;
            self.buf.extend_from_slice(&bytes[used..]);
        } else {
            // The bytes held back and the start of these, enough to end any frame that began
            // in the held bytes: once past them, the rest is parsed in place (not copied).
            let held = self.buf.len();
            let head = bytes.len().min(2 * MAX_FRAME_LEN);
            let mut buf = std::mem::take(&mut self.buf);
            buf.extend_from_slice(&bytes[..head]);
            self.scan(&buf, base, false, emit);
            let used = (self.pos - base) as usize;
            if used >= held && head < bytes.len() {
                buf.clear();
                self.buf = buf;
                let rest = &bytes[used - held..];
                let base = self.pos;
                self.scan(rest, base, false, emit);
                let used = (self.pos - base) as usize;
                self.buf.extend_from_slice(&rest[used..]);
            } else {
                // Still in the held bytes (a look-ahead needs more), or every byte taken:
                // what is left and the rest of these, parsed together.
                buf.drain(..used);
                if head < bytes.len() {
                    buf.extend_from_slice(&bytes[head..]);
                    let base = self.pos;
                    self.scan(&buf, base, false, emit);
                    buf.drain(..(self.pos - base) as usize);
                }
                self.buf = buf;
            }
            if self.buf.capacity() > 64 * 1024 {
                // A huge read arrived while bytes were held back: do not keep its room.
                self.buf.shrink_to(4 * MAX_FRAME_LEN);
            }
        }
    }

    /// A datagram (UDP packet) ended here: a frame cannot continue into the next one. Decides
    /// everything held back, and starts afresh.
    pub fn end_of_datagram(&mut self, emit: impl FnMut(Frame)) {
        self.end_of_datagram_to(&mut Emit(emit));
    }

    fn end_of_datagram_to(&mut self, emit: &mut impl Sink) {
        let buf = std::mem::take(&mut self.buf);
        self.scan(&buf, self.pos, true, emit);
        while let Some(Reverse((_, why))) = self.pending.pop() {
            if why == Rejected::BadCrc {
                self.stats.crc_errors += 1;
            }
        }
        if self.cut_off > 0 {
            self.stats.truncated += 1;
        }
        self.cut_off = 0;
        self.found = None;
        self.ahead.clear();
        self.pos = 0;
        self.probe = 0;
        self.buf = buf;
        self.buf.clear();
    }

    /// Convenience: parse a whole buffer (e.g. a file of frames) and collect the frames.
    pub fn parse_all(&mut self, bytes: &[u8]) -> Vec<Frame> {
        let mut out = Vec::new();
        self.push_into(bytes, &mut out);
        self.end_of_datagram_into(&mut out);
        out
    }

    /// Decide as many positions as the bytes allow. `d` holds the stream from position `base`
    /// (`<= self.pos`) to its end; `at_end` says nothing follows it.
    fn scan(&mut self, d: &[u8], base: u64, at_end: bool, emit: &mut impl Sink) {
        let end = base + d.len() as u64;
        loop {
            let i = (self.pos - base) as usize;
            let Some(n) = d[i..].iter().position(|&b| is_magic(b)) else {
                self.stats.garbage_bytes += (d.len() - i) as u64;
                self.advance_to(end);
                return;
            };
            if n > 0 {
                self.stats.garbage_bytes += n as u64;
                self.advance_to(self.pos + n as u64);
            }
            let s = self.pos;
            let here = &d[i + n..];
            match self.candidate_at(s, here) {
                Candidate::NeedMore if !at_end => return,
                Candidate::NeedMore => self.cut_off_here(),
                Candidate::Reject => self.skip_one(),
                Candidate::BadCrc(len) => {
                    self.pending
                        .push(Reverse((s + len as u64, Rejected::BadCrc)));
                    self.skip_one();
                }
                Candidate::Good(len) => self.accept(here, len, true, emit),
                Candidate::Unknown(len) => {
                    let e = s + len as u64;
                    // The byte after it must be a magic byte, or the datagram end there.
                    let followed = if e < end {
                        is_magic(d[(e - base) as usize])
                    } else if !at_end {
                        return;
                    } else if e == end {
                        true
                    } else {
                        self.cut_off_here();
                        continue;
                    };
                    let confirmed = followed
                        && match self.good_frame_inside(d, base, s, e, at_end) {
                            None => return,
                            Some(inside) => !inside,
                        };
                    if confirmed {
                        self.accept(here, len, false, emit);
                    } else {
                        self.pending.push(Reverse((e, Rejected::UnknownId)));
                        self.skip_one();
                    }
                }
            }
        }
    }

    /// The candidate at stream position `s`, whose bytes start `here`; reuses what the look-ahead
    /// already worked out.
    #[inline]
    fn candidate_at(&mut self, s: u64, here: &[u8]) -> Candidate {
        if let Some((f, len)) = self.found {
            if f == s {
                return Candidate::Good(len);
            }
        }
        while let Some(&(p, len)) = self.ahead.front() {
            if p > s {
                break;
            }
            self.ahead.pop_front();
            if p == s {
                return Candidate::BadCrc(len);
            }
        }
        check(here, self.table)
    }

    /// Does a CRC-valid known frame start strictly inside (`s`, `e`)? `None`: not enough bytes
    /// yet to tell. Each position is looked at once however often this is asked.
    fn good_frame_inside(
        &mut self,
        d: &[u8],
        base: u64,
        s: u64,
        e: u64,
        at_end: bool,
    ) -> Option<bool> {
        if let Some((f, _)) = self.found {
            if f > s {
                return Some(f < e);
            }
            self.found = None;
        }
        let end = base + d.len() as u64;
        let mut p = self.probe.max(s + 1);
        while p < e {
            if p >= end {
                self.probe = p;
                return if at_end { Some(false) } else { None };
            }
            let j = (p - base) as usize;
            let stop = (e.min(end) - base) as usize;
            match d[j..stop].iter().position(|&b| is_magic(b)) {
                None => {
                    p = base + stop as u64;
                    continue;
                }
                Some(k) => p += k as u64,
            }
            match check(&d[(p - base) as usize..], self.table) {
                Candidate::NeedMore if !at_end => {
                    self.probe = p;
                    return None;
                }
                Candidate::Good(len) => {
                    self.found = Some((p, len));
                    self.probe = p + 1;
                    return Some(true);
                }
                Candidate::BadCrc(len) => self.ahead.push_back((p, len)),
                _ => {}
            }
            p += 1;
        }
        self.probe = p;
        Some(false)
    }

    /// Skip the magic byte at `pos`: it does not start a frame.
    #[inline]
    fn skip_one(&mut self) {
        self.stats.garbage_bytes += 1;
        self.advance_to(self.pos + 1);
    }

    /// The candidate at `pos` runs past the end of the datagram.
    fn cut_off_here(&mut self) {
        self.cut_off += 1;
        self.skip_one();
    }

    /// Move on to `to` without accepting a frame: rejected candidates that end by then had no
    /// frame start inside them.
    #[inline]
    fn advance_to(&mut self, to: u64) {
        self.pos = to;
        while let Some(&Reverse((e, why))) = self.pending.peek() {
            if e > to {
                break;
            }
            self.pending.pop();
            if why == Rejected::BadCrc {
                self.stats.crc_errors += 1;
            }
        }
    }

    /// Accept the frame of `len` bytes at the start of `d` (stream position `pos`).
    fn accept(&mut self, d: &[u8], len: usize, known: bool, emit: &mut impl Sink) {
        // Every candidate still pending ends after this frame's start: it was cut off by it.
        if !self.pending.is_empty() || self.cut_off > 0 {
            self.stats.truncated += self.pending.len() as u64 + self.cut_off;
            self.pending.clear();
            self.cut_off = 0;
        }
        self.pos += len as u64;
        let raw = &d[..len];
        let (version, seq, sysid, compid, msgid, iflags, cflags, hlen) = header_of(raw);
        self.stats.frames += 1;
        match version {
            Version::V1 => self.stats.v1_frames += 1,
            Version::V2 => self.stats.v2_frames += 1,
        }
        if version == Version::V2 && iflags & IFLAG_SIGNED != 0 {
            self.stats.signed_frames += 1;
        }
        if !known {
            self.stats.unknown_ids += 1;
        }
        let lazy = !self.decode;
        let frame = || Frame {
            raw: RawBytes::first(d, len),
            version,
            seq,
            sysid,
            compid,
            msgid,
            incompat_flags: iflags,
            compat_flags: cflags,
            message: None,
            lazy,
        };
        let stats = &mut self.stats;
        let decode = known && self.decode;
        emit.put(frame, |message| {
            if decode {
                let payload = &raw[hlen..hlen + raw[1] as usize];
                match MavMessage::parse(version.to_mavlink(), msgid, payload) {
                    Ok(m) => *message = Some(Box::new(m)),
                    Err(_) => stats.decode_errors += 1,
                }
            }
        });
    }
}

/// Where accepted frames go: a frame is handed over with its message still `None`, and decoded
/// where it then lies.
trait Sink {
    /// `frame` makes the frame (built where it is to lie, not moved there).
    fn put(
        &mut self,
        frame: impl FnOnce() -> Frame,
        decode: impl FnOnce(&mut Option<Box<MavMessage>>),
    );
}

/// A callback taking each frame.
struct Emit<F>(F);

impl<F: FnMut(Frame)> Sink for Emit<F> {
    #[inline]
    fn put(
        &mut self,
        frame: impl FnOnce() -> Frame,
        decode: impl FnOnce(&mut Option<Box<MavMessage>>),
    ) {
        let mut frame = frame();
        decode(&mut frame.message);
        (self.0)(frame)
    }
}

impl Sink for Vec<Frame> {
    #[inline]
    fn put(
        &mut self,
        frame: impl FnOnce() -> Frame,
        decode: impl FnOnce(&mut Option<Box<MavMessage>>),
    ) {
        self.reserve(1);
        // Built where it is to lie: a frame made on the stack and copied in is read back a word
        // at a time over the bytes just stored one by one (its header fields), which the CPU
        // cannot forward from its store buffer and waits for.
        let len = self.len();
        let last = self.spare_capacity_mut()[0].write(frame());
        decode(&mut last.message);
        // SAFETY: the slot after the last was just written with a frame.
        unsafe { self.set_len(len + 1) };
    }
}

/// (version, seq, sysid, compid, msgid, incompat, compat, header length) of a frame starting at 0.
#[allow(clippy::type_complexity)]
#[inline(always)]
fn header_of(d: &[u8]) -> (Version, u8, u8, u8, u32, u8, u8, usize) {
    if d[0] == MAGIC_V1 {
        (Version::V1, d[2], d[3], d[4], d[5] as u32, 0, 0, 6)
    } else {
        let msgid = u32::from_le_bytes([d[7], d[8], d[9], 0]);
        (Version::V2, d[4], d[5], d[6], msgid, d[2], d[3], 10)
    }
}

/// Classify the candidate at `d[0]` (a magic byte) from its bytes alone. The answer never changes
/// as bytes are added after `d`, except from `NeedMore`.
#[inline]
fn check(d: &[u8], table: &MsgTable) -> Candidate {
    let v2 = d[0] == MAGIC_V2;
    if v2 {
        match d.get(2) {
            None => return Candidate::NeedMore,
            // An incompatibility flag we do not understand: by the spec, not a frame for us.
            Some(&iflags) if iflags & !IFLAG_SIGNED != 0 => return Candidate::Reject,
            Some(_) => {}
        }
    }
    let hlen = if v2 { 10 } else { 6 };
    if d.len() < hlen {
        return Candidate::NeedMore;
    }
    let plen = d[1] as usize;
    let mut len = hlen + plen + 2;
    if v2 && d[2] & IFLAG_SIGNED != 0 {
        len += SIGNATURE_LEN;
    }
    let msgid = if v2 {
        u32::from_le_bytes([d[7], d[8], d[9], 0])
    } else {
        d[5] as u32
    };
    let Some(limits) = table.get(msgid) else {
        return Candidate::Unknown(len);
    };
    let max = if v2 {
        limits.max_len_v2
    } else {
        limits.max_len_v1
    };
    if plen > max as usize {
        return Candidate::Reject;
    }
    if d.len() < len {
        return Candidate::NeedMore;
    }
    let crc = frame_crc_in(&d[1..], hlen + plen - 1, limits.crc_extra);
    if crc.to_le_bytes() != [d[hlen + plen], d[hlen + plen + 1]] {
        return Candidate::BadCrc(len);
    }
    Candidate::Good(len)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dialect as apm;
    use crate::wire::frame::{encode, frame_crc, Header};

    fn hb(seq: u8, version: Version) -> Vec<u8> {
        let msg = MavMessage::HEARTBEAT(apm::HEARTBEAT_DATA {
            custom_mode: 5,
            mavtype: apm::MavType::MAV_TYPE_QUADROTOR,
            autopilot: apm::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode: apm::MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
            system_status: apm::MavState::MAV_STATE_STANDBY,
            mavlink_version: 3,
        });
        encode(
            version,
            Header {
                sysid: 1,
                compid: 1,
                seq,
            },
            &msg,
        )
    }

    fn seqs(frames: &[Frame]) -> Vec<u8> {
        frames.iter().map(|f| f.seq).collect()
    }

    #[test]
    fn garbage_between_frames_is_skipped() {
        let mut bytes = b"hello".to_vec();
        bytes.extend(hb(1, Version::V2));
        bytes.extend([0u8, 1, 2, 3, 0x55]);
        bytes.extend(hb(2, Version::V1));
        bytes.extend([9u8; 7]);
        let mut p = FrameParser::new();
        let frames = p.parse_all(&bytes);
        assert_eq!(seqs(&frames), vec![1, 2]);
        let s = p.stats();
        assert_eq!((s.frames, s.crc_errors, s.garbage_bytes), (2, 0, 5 + 5 + 7));
        assert_eq!((s.v1_frames, s.v2_frames), (1, 1));
        assert_eq!(s.bytes, bytes.len() as u64);
    }

    #[test]
    fn byte_at_a_time_gives_the_same_frames() {
        let mut bytes = Vec::new();
        for i in 0..10 {
            bytes.extend(hb(i, if i % 2 == 0 { Version::V1 } else { Version::V2 }));
            bytes.extend([0x00, 0xFD, 0x33]); // a stray magic byte in the garbage
        }
        let mut p = FrameParser::new();
        let mut frames = Vec::new();
        for b in &bytes {
            p.push(std::slice::from_ref(b), |f| frames.push(f));
        }
        assert_eq!(seqs(&frames), (0..10).collect::<Vec<_>>());
    }

    #[test]
    fn bad_crc_is_counted_and_next_frame_found() {
        let mut bad = hb(1, Version::V2);
        let n = bad.len();
        bad[n - 1] ^= 0xFF;
        let mut bytes = bad;
        bytes.extend(hb(2, Version::V2));
        let mut p = FrameParser::new();
        let frames = p.parse_all(&bytes);
        assert_eq!(seqs(&frames), vec![2]);
        assert_eq!(p.stats().crc_errors, 1);
        assert_eq!(p.stats().truncated, 0);
    }

    #[test]
    fn truncated_frame_does_not_hide_the_next_one() {
        let mut bytes = hb(1, Version::V2);
        bytes.truncate(8); // cut off inside the header/payload
        bytes.extend(hb(2, Version::V2));
        bytes.extend(hb(3, Version::V1));
        let mut p = FrameParser::new();
        let frames = p.parse_all(&bytes);
        assert_eq!(seqs(&frames), vec![2, 3]);
        assert_eq!(p.stats().truncated, 1);
        assert_eq!(p.stats().crc_errors, 0);
    }

    #[test]
    fn truncated_at_end_of_datagram() {
        let mut bytes = hb(1, Version::V2);
        bytes.extend(&hb(2, Version::V2)[..12]);
        let mut p = FrameParser::new();
        let frames = p.parse_all(&bytes);
        assert_eq!(seqs(&frames), vec![1]);
        assert_eq!(p.stats().truncated, 1);
    }

    #[test]
    fn unknown_id_counts_and_keeps_raw() {
        // A v2 frame with msgid 0x00BEEF (not in the dialect), 3 payload bytes, arbitrary CRC.
        let unk = vec![
            0xFD, 3, 0, 0, 42, 1, 1, 0xEF, 0xBE, 0x00, 1, 2, 3, 0xAA, 0xBB,
        ];
        let mut bytes = hb(41, Version::V2);
        bytes.extend(&unk);
        bytes.extend(hb(43, Version::V2));
        let mut p = FrameParser::new();
        let frames = p.parse_all(&bytes);
        assert_eq!(seqs(&frames), vec![41, 42, 43]);
        assert_eq!(frames[1].message, None);
        assert_eq!(frames[1].msgid, 0xBEEF);
        assert_eq!(frames[1].raw, unk);
        assert_eq!(p.stats().unknown_ids, 1);
        // The same frame alone in a datagram is confirmed by the datagram's end.
        let mut p = FrameParser::new();
        assert_eq!(p.parse_all(&unk).len(), 1);
    }

    #[test]
    fn stray_magic_with_unknown_id_is_not_a_frame() {
        // 0xFD followed by noise that parses as an unknown id, then a real frame inside its span.
        let mut bytes = vec![0xFD, 20, 0, 0, 9, 9, 9, 0x11, 0x22, 0x33];
        bytes.extend(hb(5, Version::V2));
        bytes.extend(hb(6, Version::V2));
        let mut p = FrameParser::new();
        let frames = p.parse_all(&bytes);
        assert_eq!(seqs(&frames), vec![5, 6]);
        assert_eq!(p.stats().unknown_ids, 0);
        // Indistinguishable from a frame cut off by the next one.
        assert_eq!(p.stats().truncated, 1);
    }

    #[test]
    fn signed_frame_keeps_its_signature() {
        let mut f = hb(9, Version::V2);
        f[2] = IFLAG_SIGNED;
        // CRC does not cover the flags' meaning but does cover the byte: recompute.
        let n = f.len();
        let crc = frame_crc(&f[1..n - 2], 50);
        f[n - 2..].copy_from_slice(&crc.to_le_bytes());
        let sig: Vec<u8> = (1..=13).collect();
        f.extend(&sig);
        let mut bytes = f.clone();
        bytes.extend(hb(10, Version::V2));
        let mut p = FrameParser::new();
        let frames = p.parse_all(&bytes);
        assert_eq!(seqs(&frames), vec![9, 10]);
        assert!(frames[0].is_signed());
        assert_eq!(frames[0].signature(), Some(&sig[..]));
        assert!(frames[0].message.is_some());
        assert_eq!(p.stats().signed_frames, 1);
    }

    /// Tiny deterministic generator for the garbage tests.
    fn xorshift(state: &mut u64) -> u64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        *state
    }

    #[test]
    fn random_garbage_never_hides_a_real_frame() {
        let mut rng = 0x9E37_79B9_7F4A_7C15u64;
        for round in 0..200 {
            let mut bytes = Vec::new();
            let mut expect = Vec::new();
            for i in 0..20u8 {
                let n = (xorshift(&mut rng) % 40) as usize;
                for _ in 0..n {
                    // Plenty of magic bytes in the garbage.
                    let b = match xorshift(&mut rng) % 6 {
                        0 => MAGIC_V2,
                        1 => MAGIC_V1,
                        _ => xorshift(&mut rng) as u8,
                    };
                    bytes.push(b);
                }
                let v = if i % 3 == 0 { Version::V1 } else { Version::V2 };
                bytes.extend(hb(i, v));
                expect.push(i);
            }
            let mut p = FrameParser::new();
            let mut got = Vec::new();
            // Odd chunk sizes, as a serial port delivers.
            let chunk = 1 + (round % 17);
            for c in bytes.chunks(chunk) {
                p.push(c, |f| got.push(f));
            }
            p.end_of_datagram(|f| got.push(f));
            let real: Vec<u8> = got
                .iter()
                .filter(|f| f.message.is_some())
                .map(|f| f.seq)
                .collect();
            assert_eq!(real, expect, "round {round}");
        }
    }

    #[test]
    fn push_into_gives_what_push_gives() {
        // Frames held inline and on the heap (a long STATUSTEXT), one whose payload does not
        // decode, an unknown id, garbage with magic bytes, cut at every sort of boundary.
        let text = MavMessage::STATUSTEXT(apm::STATUSTEXT_DATA {
            severity: apm::MavSeverity::MAV_SEVERITY_INFO,
            text: [b'x'; 50].into(),
            id: 7,
            chunk_seq: 1,
        });
        let text = encode(
            Version::V2,
            Header {
                sysid: 1,
                compid: 1,
                seq: 200,
            },
            &text,
        );
        assert!(text.len() > RawBytes::INLINE);
        let mut bad_enum = hb(9, Version::V2);
        bad_enum[14] = 250; // MAV_TYPE 250 does not exist
        let n = bad_enum.len();
        let crc = frame_crc(&bad_enum[1..n - 2], 50);
        bad_enum[n - 2..].copy_from_slice(&crc.to_le_bytes());
        let mut unknown = vec![MAGIC_V2, 1, 0, 0, 3, 1, 1, 0xEF, 0xBE, 0x00, 42];
        unknown.extend([0x12, 0x34]);
        let mut rng = 0x0123_4567_89AB_CDEFu64;
        let mut bytes = Vec::new();
        for i in 0..60u8 {
            match i % 5 {
                0 => bytes.extend(&text),
                1 => bytes.extend(&bad_enum),
                2 => bytes.extend(&unknown),
                _ => bytes.extend(hb(i, Version::V1)),
            }
            for _ in 0..xorshift(&mut rng) % 5 {
                bytes.push(if xorshift(&mut rng) & 1 == 0 {
                    MAGIC_V2
                } else {
                    xorshift(&mut rng) as u8
                });
            }
        }
        for chunk in [1, 7, 61, 62, 63, 4096] {
            let mut a = FrameParser::new();
            let mut by_push = Vec::new();
            let mut b = FrameParser::new();
            let mut by_push_into = b.frame_vec(0);
            for c in bytes.chunks(chunk) {
                a.push(c, |f| by_push.push(f));
                b.push_into(c, &mut by_push_into);
            }
            a.end_of_datagram(|f| by_push.push(f));
            b.end_of_datagram_into(&mut by_push_into);
            assert_eq!(by_push, by_push_into, "chunks of {chunk}");
            assert_eq!(a.stats(), b.stats(), "chunks of {chunk}");
            assert!(a.stats().decode_errors > 0 && a.stats().unknown_ids > 0);
            assert!(by_push.iter().any(|f| f.raw == text));
        }
    }

    /// Payload lengths and CRC_EXTRA from the message definitions (common.xml, as listed on
    /// mavlink.io): base fields only for MAVLink 1, with extension fields for MAVLink 2.
    #[test]
    fn limits_follow_the_message_definitions() {
        let l = |id| msg_limits(id).map(|l| (l.crc_extra, l.max_len_v1, l.max_len_v2));
        assert_eq!(l(0), Some((50, 9, 9))); // HEARTBEAT
        assert_eq!(l(1), Some((124, 31, 43))); // SYS_STATUS: 3 u32 extensions
        assert_eq!(l(22), Some((220, 25, 25))); // PARAM_VALUE
        assert_eq!(l(24), Some((24, 30, 52))); // GPS_RAW_INT: 5 u32 + u16 extensions
        assert_eq!(l(30), Some((39, 28, 28))); // ATTITUDE
        assert_eq!(l(110), Some((84, 254, 254))); // FILE_TRANSFER_PROTOCOL
        assert_eq!(l(193), Some((71, 22, 26))); // EKF_STATUS_REPORT (ardupilotmega)
        assert_eq!(l(253), Some((83, 51, 54))); // STATUSTEXT: id u16 + chunk_seq u8
        assert_eq!(l(0xBEEF), None);
        assert_eq!(l(0x00AB_CDEF), None);
    }

    /// A SYS_STATUS of `plen` payload bytes, CRC correct.
    fn sys_status(version: Version, plen: usize) -> Vec<u8> {
        let mut f = match version {
            Version::V1 => vec![MAGIC_V1, plen as u8, 3, 1, 1, 1],
            Version::V2 => vec![MAGIC_V2, plen as u8, 0, 0, 3, 1, 1, 1, 0, 0],
        };
        f.extend((0..plen).map(|i| i as u8 + 1));
        let crc = frame_crc(&f[1..], 124);
        f.extend(crc.to_le_bytes());
        f
    }

    #[test]
    fn payload_longer_than_the_definition_is_not_a_frame() {
        // MAVLink 1 carries the 31 base bytes only; MAVLink 2 up to the 43 with extensions.
        let ok = |f: Vec<u8>| FrameParser::new().parse_all(&f).len() == 1;
        assert!(ok(sys_status(Version::V1, 31)));
        assert!(!ok(sys_status(Version::V1, 32)));
        assert!(!ok(sys_status(Version::V1, 43)));
        assert!(ok(sys_status(Version::V2, 31)));
        assert!(ok(sys_status(Version::V2, 43)));
        assert!(!ok(sys_status(Version::V2, 44)));
        // Truncated MAVLink 2 payloads are fine.
        assert!(ok(sys_status(Version::V2, 5)));
        let mut p = FrameParser::new();
        p.parse_all(&sys_status(Version::V2, 44));
        assert_eq!((p.stats().frames, p.stats().crc_errors), (0, 0));
        assert_eq!(p.stats().garbage_bytes, 10 + 44 + 2);
    }

    #[test]
    fn counters_do_not_depend_on_read_boundaries() {
        // A bad CRC cut off by a real frame, an unknown id, garbage with stray magic bytes.
        let mut bytes = hb(1, Version::V2);
        bytes.truncate(15);
        bytes.extend(hb(2, Version::V2));
        bytes.extend([
            0xFD, 3, 0, 0, 42, 1, 1, 0xEF, 0xBE, 0x00, 1, 2, 3, 0xAA, 0xBB,
        ]);
        bytes.extend([0xFE, 0x00, 0xFD, 0x55]);
        let mut bad = hb(3, Version::V1);
        let n = bad.len();
        bad[n - 2] ^= 0x40;
        bytes.extend(bad);
        bytes.extend(hb(4, Version::V1));
        let mut whole = FrameParser::new();
        let all = whole.parse_all(&bytes);
        assert_eq!(seqs(&all), vec![2, 42, 4]);
        let s = *whole.stats();
        assert_eq!((s.truncated, s.crc_errors, s.unknown_ids), (1, 1, 1));
        for cut in 0..bytes.len() {
            let mut p = FrameParser::new();
            let mut got = Vec::new();
            p.push(&bytes[..cut], |f| got.push(f));
            p.push(&bytes[cut..], |f| got.push(f));
            p.end_of_datagram(|f| got.push(f));
            assert_eq!(got, all, "split at {cut}");
            assert_eq!(*p.stats(), s, "split at {cut}");
        }
    }

    #[test]
    fn unsupported_incompat_flag_is_rejected() {
        let mut f = hb(9, Version::V2);
        f[2] = 0x02;
        let mut p = FrameParser::new();
        assert!(p.parse_all(&f).is_empty());
    }
}
