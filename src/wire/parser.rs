//! Finding MAVLink frames in a byte stream, with per-link counters.
//!
//! Rules:
//! - Bytes before a magic byte (0xFE / 0xFD) are skipped and counted as garbage.
//! - A candidate frame whose CRC fails is not consumed: the parser moves one byte on and looks for
//!   the next magic byte, so a real frame that starts inside the rejected bytes is still found.
//!   The failure is counted as `truncated` when a valid frame starts inside the rejected span
//!   (the sender was cut off), else as `crc_errors`.
//! - A message id the dialect does not know has no CRC_EXTRA, so its CRC cannot be checked. Such a
//!   frame is accepted (and counted in `unknown_ids`, and handed on for sequence tracking) only when
//!   its header is plausible and the byte after it is a magic byte or a datagram ends there;
//!   otherwise random garbage after a stray 0xFD would be taken for frames and swallow real ones.
//! - A frame whose payload does not decode (e.g. an enum value newer than our dialect) is still a
//!   frame: counted in `decode_errors`, handed on with `message: None`.

use super::frame::{
    crc_extra, frame_crc, Frame, Version, IFLAG_SIGNED, MAGIC_V1, MAGIC_V2, SIGNATURE_LEN,
};
use crate::dialect::MavMessage;
use mavlink::Message;

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

/// Streaming frame parser. Feed it bytes with [`FrameParser::push`]; it calls back once per frame.
#[derive(Debug, Default)]
pub struct FrameParser {
    buf: Vec<u8>,
    start: usize,
    stats: ParserStats,
}

enum Candidate {
    /// Not enough bytes yet to decide.
    NeedMore,
    /// Not a frame here: skip one byte.
    Reject,
    /// A known-id frame with a bad CRC, `len` bytes long.
    BadCrc(usize),
    /// A frame with a good CRC, `len` bytes long.
    Good(usize),
    /// An unknown-id frame, `len` bytes long, still to be confirmed by what follows.
    Unknown(usize),
}

impl FrameParser {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn stats(&self) -> &ParserStats {
        &self.stats
    }

    /// Bytes held back waiting for the rest of a frame.
    pub fn pending(&self) -> usize {
        self.buf.len() - self.start
    }

    /// Feed bytes from a stream; `emit` is called for each complete frame, in order.
    pub fn push(&mut self, bytes: &[u8], mut emit: impl FnMut(Frame)) {
        self.stats.bytes += bytes.len() as u64;
        if self.start > 0 && self.start == self.buf.len() {
            self.buf.clear();
            self.start = 0;
        }
        self.buf.extend_from_slice(bytes);
        self.scan(false, &mut emit);
        if self.start > 4096 || (self.start > 0 && self.start * 2 > self.buf.len()) {
            self.buf.drain(..self.start);
            self.start = 0;
        }
    }

    /// A datagram (UDP packet) ended here: a frame cannot continue into the next one. Confirms a
    /// pending unknown-id frame and counts any partial frame left over as truncated.
    pub fn end_of_datagram(&mut self, mut emit: impl FnMut(Frame)) {
        self.scan(true, &mut emit);
        let rest = self.buf.len() - self.start;
        if rest > 0 {
            if self.buf[self.start] == MAGIC_V1 || self.buf[self.start] == MAGIC_V2 {
                self.stats.truncated += 1;
            } else {
                self.stats.garbage_bytes += rest as u64;
            }
        }
        self.buf.clear();
        self.start = 0;
    }

    /// Convenience: parse a whole buffer (e.g. a file of frames) and collect the frames.
    pub fn parse_all(&mut self, bytes: &[u8]) -> Vec<Frame> {
        let mut out = Vec::new();
        self.push(bytes, |f| out.push(f));
        self.end_of_datagram(|f| out.push(f));
        out
    }

    fn scan(&mut self, at_boundary: bool, emit: &mut impl FnMut(Frame)) {
        loop {
            // Skip to the next magic byte.
            let data = &self.buf[self.start..];
            match data.iter().position(|&b| b == MAGIC_V1 || b == MAGIC_V2) {
                Some(0) => {}
                Some(n) => {
                    self.stats.garbage_bytes += n as u64;
                    self.start += n;
                }
                None => {
                    self.stats.garbage_bytes += data.len() as u64;
                    self.start = self.buf.len();
                    return;
                }
            }
            let data = &self.buf[self.start..];
            match check(data) {
                Candidate::NeedMore => {
                    // At the end of a datagram nothing more will come: if a real frame starts
                    // inside what this candidate claims, the candidate was garbage.
                    if at_boundary && valid_frame_starts_inside(data, data.len()) {
                        self.stats.garbage_bytes += 1;
                        self.start += 1;
                        continue;
                    }
                    return;
                }
                Candidate::Reject => {
                    self.stats.garbage_bytes += 1;
                    self.start += 1;
                }
                Candidate::BadCrc(len) => {
                    if cut_off_by_a_frame(data, len) {
                        self.stats.truncated += 1;
                    } else {
                        self.stats.crc_errors += 1;
                    }
                    self.stats.garbage_bytes += 1;
                    self.start += 1;
                }
                Candidate::Good(len) => {
                    let frame = self.build(len, true);
                    self.start += len;
                    emit(frame);
                }
                Candidate::Unknown(len) => {
                    let followed_by_frame = match data.get(len) {
                        Some(&b) => b == MAGIC_V1 || b == MAGIC_V2,
                        None if at_boundary => true,
                        None => return, // wait for the next byte
                    };
                    // A checkable frame starting inside the span wins over an uncheckable one.
                    let confirmed = followed_by_frame && !valid_frame_starts_inside(data, len);
                    if confirmed {
                        let frame = self.build(len, false);
                        self.start += len;
                        emit(frame);
                    } else {
                        if valid_frame_starts_inside(data, len) {
                            self.stats.truncated += 1;
                        }
                        self.stats.garbage_bytes += 1;
                        self.start += 1;
                    }
                }
            }
        }
    }

    fn build(&mut self, len: usize, known: bool) -> Frame {
        let raw = self.buf[self.start..self.start + len].to_vec();
        let (version, seq, sysid, compid, msgid, iflags, cflags, hlen) = header_of(&raw);
        let plen = raw[1] as usize;
        self.stats.frames += 1;
        match version {
            Version::V1 => self.stats.v1_frames += 1,
            Version::V2 => self.stats.v2_frames += 1,
        }
        if version == Version::V2 && iflags & IFLAG_SIGNED != 0 {
            self.stats.signed_frames += 1;
        }
        let message = if known {
            match MavMessage::parse(version.to_mavlink(), msgid, &raw[hlen..hlen + plen]) {
                Ok(m) => Some(m),
                Err(_) => {
                    self.stats.decode_errors += 1;
                    None
                }
            }
        } else {
            self.stats.unknown_ids += 1;
            None
        };
        Frame {
            raw,
            version,
            seq,
            sysid,
            compid,
            msgid,
            incompat_flags: iflags,
            compat_flags: cflags,
            message,
        }
    }
}

/// (version, seq, sysid, compid, msgid, incompat, compat, header length) of a frame starting at 0.
#[allow(clippy::type_complexity)]
fn header_of(d: &[u8]) -> (Version, u8, u8, u8, u32, u8, u8, usize) {
    if d[0] == MAGIC_V1 {
        (Version::V1, d[2], d[3], d[4], d[5] as u32, 0, 0, 6)
    } else {
        let msgid = u32::from_le_bytes([d[7], d[8], d[9], 0]);
        (Version::V2, d[4], d[5], d[6], msgid, d[2], d[3], 10)
    }
}

fn check(d: &[u8]) -> Candidate {
    let hlen = if d[0] == MAGIC_V1 { 6 } else { 10 };
    if d.len() < hlen {
        return Candidate::NeedMore;
    }
    let plen = d[1] as usize;
    let mut len = hlen + plen + 2;
    if d[0] == MAGIC_V2 {
        let iflags = d[2];
        if iflags & !IFLAG_SIGNED != 0 {
            // An incompatibility flag we do not understand: by the spec, not a frame for us.
            return Candidate::Reject;
        }
        if iflags & IFLAG_SIGNED != 0 {
            len += SIGNATURE_LEN;
        }
    }
    let (_, _, _, _, msgid, _, _, _) = header_of(d);
    let extra = crc_extra(msgid);
    if d.len() < hlen + plen + 2 {
        return Candidate::NeedMore;
    }
    let Some(extra) = extra else {
        if d.len() < len {
            return Candidate::NeedMore;
        }
        return Candidate::Unknown(len);
    };
    let crc = frame_crc(&d[1..hlen + plen], extra);
    let got = u16::from_le_bytes([d[hlen + plen], d[hlen + plen + 1]]);
    if crc != got {
        return Candidate::BadCrc(len);
    }
    if d.len() < len {
        return Candidate::NeedMore;
    }
    Candidate::Good(len)
}

/// True when a complete known-id frame with a good CRC starts at one of the first `tries` magic
/// bytes inside the first `span` bytes of `d` (after the first byte).
fn frame_starts_inside(d: &[u8], span: usize, tries: usize) -> bool {
    let end = span.min(d.len());
    (1..end)
        .filter(|&i| d[i] == MAGIC_V1 || d[i] == MAGIC_V2)
        .take(tries)
        .any(|i| matches!(check(&d[i..]), Candidate::Good(_)))
}

/// Deciding whether to accept bytes as a frame: every magic byte inside is tried, so a real
/// frame is never lost to garbage in front of it.
fn valid_frame_starts_inside(d: &[u8], span: usize) -> bool {
    frame_starts_inside(d, span, usize::MAX)
}

/// Only naming a rejection (cut off, or bad CRC): a cut-off frame is followed by the next one at
/// its first magic byte or so, and garbage full of magic bytes must not cost hundreds of CRCs
/// per rejected byte just for a counter's name.
fn cut_off_by_a_frame(d: &[u8], span: usize) -> bool {
    frame_starts_inside(d, span, 4)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dialect as apm;
    use crate::wire::frame::{encode, Header};

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
    fn unsupported_incompat_flag_is_rejected() {
        let mut f = hb(9, Version::V2);
        f[2] = 0x02;
        let mut p = FrameParser::new();
        assert!(p.parse_all(&f).is_empty());
    }
}
