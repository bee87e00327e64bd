//! Telemetry logs (`.tlog`) as MAVProxy, QGroundControl and pymavlink write them: for each frame,
//! 8 bytes big-endian microseconds since the Unix epoch, then the raw frame.
//!
//! Logs get damaged: a writer killed mid-record, two sessions appended to one file, a bad disk
//! block. [`TlogReader`] keeps going: where the bytes stop making records it skips ahead to the
//! next record that parses and counts what it passed over ([`Skipped`]), so a link can say so.
//!
//! While in step (each record starting where the last one ended, as from the start of the file)
//! a record is taken when its framing (a magic byte and a length that fits) is followed by
//! another record's framing, or its frame checks out: so a frame with a bad CRC, or from another
//! dialect, still reaches the link's parser and is counted there. After garbage, only a frame of
//! our dialect whose CRC checks out brings the reader back in step, so garbage is not mistaken
//! for records.

use std::io::{self, Read};

use crate::wire::frame::{
    crc_extra, frame_crc, IFLAG_SIGNED, MAGIC_V1, MAGIC_V2, MAX_FRAME_LEN, SIGNATURE_LEN,
};

/// Bytes of the timestamp before each frame.
const TS_LEN: usize = 8;
/// Enough bytes to decide whether a record starts here (a record and the next one's header).
const LOOKAHEAD: usize = 2 * (TS_LEN + MAX_FRAME_LEN);
/// How much the streaming reader asks for at a time.
const CHUNK: usize = 64 * 1024;
/// A run of this many bytes holding no record ends the reading there, as the end of the file
/// would ([`TlogReader::ended_in_gap`]): however large a file of garbage is, one read of it is
/// bounded (a replay's `--duration` is checked between reads), and no real log holds a gap
/// of this size.
pub const MAX_GAP: u64 = 64 * 1024 * 1024;

/// One record: when it was logged and the frame's bytes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TlogRecord {
    pub time_us: u64,
    pub frame: Vec<u8>,
}

/// Why a tlog could not be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TlogError {
    /// Not one record in the whole file: not a tlog at all.
    #[error("no MAVLink records in {bytes} bytes (not a tlog file?)")]
    NoRecords { bytes: u64 },
}

/// What a reader passed over: bytes that belong to no record, and in how many separate
/// stretches ("gaps"). A record cut off at the end of the file counts as a gap.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Skipped {
    pub bytes: u64,
    pub gaps: u64,
}

impl Skipped {
    pub fn is_empty(&self) -> bool {
        self.bytes == 0
    }
}

impl std::fmt::Display for Skipped {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = if self.gaps == 1 { "" } else { "s" };
        write!(f, "{} bytes skipped in {} gap{s}", self.bytes, self.gaps)
    }
}

/// Length of the frame starting at `d[0]`, from its header; `None` if not a magic byte or not
/// enough bytes for the header.
pub(crate) fn frame_len(d: &[u8]) -> Option<usize> {
    match *d.first()? {
        MAGIC_V1 => Some(6 + *d.get(1)? as usize + 2),
        MAGIC_V2 => {
            let plen = *d.get(1)? as usize;
            let flags = *d.get(2)?;
            let sig = if flags & IFLAG_SIGNED != 0 {
                SIGNATURE_LEN
            } else {
                0
            };
            Some(10 + plen + 2 + sig)
        }
        _ => None,
    }
}

/// True if `f` (exactly one frame) is a message of our dialect with a correct CRC and no
/// incompatibility flag we do not know.
fn frame_checks_out(f: &[u8]) -> bool {
    let (hlen, msgid) = match f[0] {
        MAGIC_V1 => (6, f[5] as u32),
        _ => {
            if f[2] & !IFLAG_SIGNED != 0 {
                return false;
            }
            (10, u32::from_le_bytes([f[7], f[8], f[9], 0]))
        }
    };
    let plen = f[1] as usize;
    let Some(extra) = crc_extra(msgid) else {
        return false;
    };
    let got = u16::from_le_bytes([f[hlen + plen], f[hlen + plen + 1]]);
    frame_crc(&f[1..hlen + plen], extra) == got
}

/// What the framing says about a place: a whole record of this length, one cut off by the end of
/// the data, or nothing.
enum Framing {
    Record(usize),
    Truncated,
    Bad,
}

/// The framing at `d[0]` (a timestamp, then a magic byte and a frame length that fits). `d` runs
/// to the end of the buffered data: the end of the stream when `eof`.
fn framing(d: &[u8], eof: bool) -> Framing {
    let cut = if eof {
        Framing::Truncated
    } else {
        Framing::Bad // not reached: the reader keeps LOOKAHEAD bytes buffered
    };
    let Some(f) = d.get(TS_LEN..).filter(|f| !f.is_empty()) else {
        return cut;
    };
    if f[0] != MAGIC_V1 && f[0] != MAGIC_V2 {
        return Framing::Bad;
    }
    match frame_len(f) {
        Some(len) if len <= f.len() => Framing::Record(TS_LEN + len),
        _ => cut,
    }
}

/// True if the framing at `d[0]` is a whole record and another record's framing follows it, or
/// the end of the stream (a log may end mid-record).
fn followed_by_record(d: &[u8], eof: bool) -> bool {
    let Framing::Record(n) = framing(d, eof) else {
        return false;
    };
    if n == d.len() && eof {
        return true;
    }
    !matches!(framing(&d[n..], eof), Framing::Bad)
}

/// Length of the record (timestamp + frame) starting at `d[0]`, if one does: its frame checks
/// out ([`frame_checks_out`]), or, while in step, its framing is followed by another record's.
fn record_at(d: &[u8], in_step: bool, eof: bool) -> Option<usize> {
    let Framing::Record(n) = framing(d, eof) else {
        return None;
    };
    if frame_checks_out(&d[TS_LEN..n]) || (in_step && followed_by_record(d, eof)) {
        return Some(n);
    }
    None
}

/// Reads tlog records from any byte stream, a buffer at a time (a log need not fit in memory),
/// skipping what is not a record; see the module docs.
pub struct TlogReader<R> {
    inner: R,
    buf: Vec<u8>,
    /// Start of the unread part of `buf`.
    pos: usize,
    eof: bool,
    /// The last thing read was a record (or this is the start): take the next on its framing.
    in_step: bool,
    /// Bytes are being skipped (a gap is open).
    in_gap: bool,
    /// After an I/O error the iterator ends.
    failed: bool,
    skipped: Skipped,
    offset: u64,
    /// The furthest offset read so far: bytes before it that are read again (after a seek back)
    /// are not counted as skipped twice.
    high_water: u64,
    /// The open gap has been counted.
    gap_counted: bool,
    /// Give up (end, as at the end of the file) once this many bytes are read with no record.
    give_up_after: Option<u64>,
    /// Offset where the open gap began.
    gap_from: u64,
    /// Reading ended on a gap of [`MAX_GAP`] bytes.
    ended_in_gap: bool,
}

impl<R: Read> TlogReader<R> {
    /// End (as at the end of the file) once `bytes` are read without a record: a file that is
    /// not a tlog is not read whole to find out. `None` reads on.
    pub fn give_up_after(&mut self, bytes: Option<u64>) {
        self.give_up_after = bytes;
    }

    pub fn new(inner: R) -> Self {
        TlogReader {
            inner,
            buf: Vec::with_capacity(CHUNK + LOOKAHEAD),
            pos: 0,
            eof: false,
            in_step: true,
            in_gap: false,
            failed: false,
            give_up_after: None,
            gap_from: 0,
            ended_in_gap: false,
            skipped: Skipped::default(),
            offset: 0,
            high_water: 0,
            gap_counted: false,
        }
    }

    /// A reader of `inner` positioned at `offset` of its stream somewhere in the middle, where a
    /// record may not start: only a frame whose CRC checks out is taken as the first record.
    pub fn resync(inner: R, offset: u64) -> Self {
        let mut r = Self::new(inner);
        r.offset = offset;
        r.high_water = offset;
        r.in_step = false;
        r
    }

    /// The stream read from, to move it (then [`TlogReader::restart_at`]).
    pub fn get_mut(&mut self) -> &mut R {
        &mut self.inner
    }

    /// Read on from `offset`, the start of a record, where the stream was moved to: what was
    /// buffered is dropped. What is skipped again before [`TlogReader::offset`]'s furthest point
    /// is not counted again.
    pub fn restart_at(&mut self, offset: u64) {
        self.buf.clear();
        self.pos = 0;
        self.eof = false;
        self.failed = false;
        self.in_step = true;
        self.in_gap = false;
        self.ended_in_gap = false;
        self.offset = offset;
    }

    /// Reading ended because [`MAX_GAP`] bytes in a row held no record (not at the end of the
    /// stream).
    pub fn ended_in_gap(&self) -> bool {
        self.ended_in_gap
    }

    /// What has been skipped so far.
    pub fn skipped(&self) -> Skipped {
        self.skipped
    }

    /// Bytes of the stream held in memory (the read-ahead buffer's size): bounded by a few
    /// chunks, however long the stream.
    pub fn buffered_bytes(&self) -> usize {
        self.buf.capacity()
    }

    /// Offset in the stream of the next unread byte.
    pub fn offset(&self) -> u64 {
        self.offset
    }

    /// Make `want` bytes available after `pos`, unless the stream ends first.
    fn fill(&mut self, want: usize) -> io::Result<()> {
        while !self.eof && self.buf.len() - self.pos < want {
            if self.pos > 0 && self.pos >= self.buf.len() / 2 {
                self.buf.drain(..self.pos);
                self.pos = 0;
            }
            let old = self.buf.len();
            self.buf.resize(old + CHUNK, 0);
            let n = loop {
                match self.inner.read(&mut self.buf[old..]) {
                    Ok(n) => break Ok(n),
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                    Err(e) => break Err(e),
                }
            };
            match n {
                Ok(n) => {
                    self.buf.truncate(old + n);
                    self.eof = n == 0;
                }
                Err(e) => {
                    self.buf.truncate(old);
                    return Err(e);
                }
            }
        }
        Ok(())
    }

    fn skip(&mut self, n: usize) {
        if !self.in_gap {
            self.in_gap = true;
            self.gap_counted = false;
            self.gap_from = self.offset;
        }
        let end = self.offset + n as u64;
        let fresh = end.saturating_sub(self.offset.max(self.high_water));
        if fresh > 0 && !self.gap_counted {
            self.gap_counted = true;
            self.skipped.gaps += 1;
        }
        self.in_step = false;
        self.pos += n;
        self.offset = end;
        self.high_water = self.high_water.max(end);
        self.skipped.bytes += fresh;
    }
}

impl<R: Read> Iterator for TlogReader<R> {
    type Item = io::Result<TlogRecord>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed || self.ended_in_gap {
            return None;
        }
        loop {
            if let Err(e) = self.fill(LOOKAHEAD) {
                self.failed = true;
                return Some(Err(e));
            }
            let d = &self.buf[self.pos..];
            if d.is_empty() {
                return None;
            }
            if let Some(n) = record_at(d, self.in_step, self.eof) {
                let time_us = u64::from_be_bytes(d[..TS_LEN].try_into().expect("8 bytes"));
                let frame = d[TS_LEN..n].to_vec();
                self.pos += n;
                self.offset += n as u64;
                self.high_water = self.high_water.max(self.offset);
                self.in_step = true;
                self.in_gap = false;
                return Some(Ok(TlogRecord { time_us, frame }));
            }
            if self.give_up_after.is_some_and(|max| self.offset >= max) {
                return None;
            }
            if self.in_gap && self.offset - self.gap_from >= MAX_GAP {
                self.ended_in_gap = true;
                return None;
            }
            // Not a record: skip to the next place whose frame would start with a magic byte
            // (or, with none in sight, to the last few bytes, which may be a timestamp).
            let next = d
                .iter()
                .skip(TS_LEN + 1)
                .position(|b| *b == MAGIC_V1 || *b == MAGIC_V2)
                .map(|i| i + 1);
            let n = match next {
                Some(n) => n,
                None if self.eof => d.len(),
                None => (d.len() - TS_LEN).max(1),
            };
            self.skip(n);
        }
    }
}

/// Split a whole tlog into records, skipping what is not one, and say what was skipped. An
/// empty file has no records; a non-empty one without a single record is an error.
pub fn read_tlog_counted(bytes: &[u8]) -> Result<(Vec<TlogRecord>, Skipped), TlogError> {
    let mut reader = TlogReader::new(bytes);
    let records: Vec<TlogRecord> = reader
        .by_ref()
        .map(|r| r.expect("reading from memory cannot fail"))
        .collect();
    if records.is_empty() && !bytes.is_empty() {
        return Err(TlogError::NoRecords {
            bytes: bytes.len() as u64,
        });
    }
    Ok((records, reader.skipped()))
}

/// Split a whole tlog into records (see [`read_tlog_counted`]). A record cut off at the end of
/// the file is dropped (a log whose writer died); garbage part-way is skipped.
pub fn read_tlog(bytes: &[u8]) -> Result<Vec<TlogRecord>, TlogError> {
    read_tlog_counted(bytes).map(|(records, _)| records)
}

/// Append one record to a tlog buffer.
/// The longest prefix of `records` (whole records, as [`write_record`] writes them) that ends
/// on a record's end and is at most `n` bytes.
pub fn whole_records(records: &[u8], n: usize) -> usize {
    let mut at = 0;
    while at + TS_LEN < records.len() {
        let Some(len) = frame_len(&records[at + TS_LEN..]) else {
            break;
        };
        let end = at + TS_LEN + len;
        if end > n || end > records.len() {
            break;
        }
        at = end;
    }
    at
}

pub fn write_record(out: &mut Vec<u8>, time_us: u64, frame: &[u8]) {
    out.extend_from_slice(&time_us.to_be_bytes());
    out.extend_from_slice(frame);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dialect::{self as apm, MavMessage};
    use crate::wire::frame::{encode, Header, Version};

    fn heartbeat(version: Version, seq: u8) -> Vec<u8> {
        let msg = MavMessage::HEARTBEAT(apm::HEARTBEAT_DATA {
            custom_mode: 4,
            mavtype: apm::MavType::MAV_TYPE_QUADROTOR,
            autopilot: apm::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode: apm::MavModeFlag::empty(),
            system_status: apm::MavState::MAV_STATE_ACTIVE,
            mavlink_version: 3,
        });
        let h = Header {
            sysid: 1,
            compid: 1,
            seq,
        };
        encode(version, h, &msg)
    }

    /// A log of `n` heartbeats (v2 and v1 alternating) at t = 1000, 2000, ...; and the records.
    fn log(n: usize) -> (Vec<u8>, Vec<TlogRecord>) {
        let mut buf = Vec::new();
        let mut recs = Vec::new();
        for i in 0..n {
            let v = if i % 2 == 0 { Version::V2 } else { Version::V1 };
            let f = heartbeat(v, i as u8);
            let t = 1000 * (i as u64 + 1);
            write_record(&mut buf, t, &f);
            recs.push(TlogRecord {
                time_us: t,
                frame: f,
            });
        }
        (buf, recs)
    }

    #[test]
    fn a_gap_of_max_gap_bytes_ends_the_reading_there() {
        // A record, MAX_GAP + 1 MiB of zeros (no magic byte), a record: the reading ends in
        // the gap, bounded, and says so; a gap just under the limit is read through.
        let (one, recs) = log(1);
        for (gap, records, ended) in [
            (MAX_GAP + (1 << 20), 1, true),
            (MAX_GAP - (1 << 20), 2, false),
        ] {
            let mut buf = one.clone();
            buf.resize(buf.len() + gap as usize, 0);
            buf.extend_from_slice(&one);
            let mut r = TlogReader::new(&buf[..]);
            let got: Vec<TlogRecord> = r.by_ref().map(|x| x.unwrap()).collect();
            assert_eq!(got.len(), records, "gap {gap}");
            assert_eq!(got[0], recs[0]);
            assert_eq!(r.ended_in_gap(), ended, "gap {gap}");
            if ended {
                assert!(r.offset() < one.len() as u64 + MAX_GAP + (1 << 17));
            }
        }
    }

    #[test]
    fn round_trip_and_truncated_tail() {
        let mut buf = Vec::new();
        // Framing is all that counts while in step: these CRCs are wrong, and kept.
        let f1 = vec![0xFD, 1, 0, 0, 0, 1, 1, 0, 0, 0, 7, 0xAA, 0xBB];
        let f2 = vec![0xFE, 0, 0, 1, 1, 0, 0x11, 0x22];
        write_record(&mut buf, 1, &f1);
        write_record(&mut buf, 2, &f2);
        write_record(&mut buf, 3, &f1[..5]);
        let (recs, skipped) = read_tlog_counted(&buf).unwrap();
        assert_eq!(recs.len(), 2);
        assert_eq!(
            recs[1],
            TlogRecord {
                time_us: 2,
                frame: f2
            }
        );
        // The cut-off record: 8 + 5 bytes in one gap.
        assert_eq!(skipped, Skipped { bytes: 13, gaps: 1 });
    }

    #[test]
    fn garbage_part_way_is_skipped_and_counted() {
        let (good, recs) = log(6);
        // After 3 records: a v2 heartbeat is 10 + 9 + 2 = 21 bytes, a v1 one 6 + 9 + 2 = 17.
        let cut = 3 * 8 + 2 * 21 + 17;
        assert_eq!(good.len(), 6 * 8 + 3 * 21 + 3 * 17);
        let mut buf = good[..cut].to_vec();
        buf.extend([0x42u8; 100]); // no magic byte in it
        buf.extend(&good[cut..]);
        let (got, skipped) = read_tlog_counted(&buf).unwrap();
        assert_eq!(got, recs);
        assert_eq!(
            skipped,
            Skipped {
                bytes: 100,
                gaps: 1
            }
        );
    }

    #[test]
    fn garbage_full_of_magic_bytes_is_not_taken_for_records() {
        let (good, recs) = log(4);
        let mut buf: Vec<u8> = Vec::new();
        // Before the first record, and between the 2nd and 3rd: magic bytes with lengths that
        // fit, but no CRC that checks out.
        let junk: Vec<u8> = (0..300u32)
            .map(|i| [0xFD, 0xFE, 3, 0, 9, 0xFD, 0x01][(i % 7) as usize])
            .collect();
        let second_end = 2 * 8 + 21 + 17;
        buf.extend(&junk[..50]);
        buf.extend(&good[..second_end]);
        buf.extend(&junk);
        buf.extend(&good[second_end..]);
        let (got, skipped) = read_tlog_counted(&buf).unwrap();
        assert_eq!(got, recs);
        assert_eq!(
            skipped,
            Skipped {
                bytes: 350,
                gaps: 2
            }
        );
        assert_eq!(skipped.gaps, 2);
    }

    #[test]
    fn streaming_matches_whole_buffer_reads() {
        /// Hands out one byte per read, and sometimes an `Interrupted`.
        struct Trickle<'a>(&'a [u8], usize);
        impl Read for Trickle<'_> {
            fn read(&mut self, out: &mut [u8]) -> io::Result<usize> {
                self.1 += 1;
                if self.1.is_multiple_of(5) {
                    return Err(io::ErrorKind::Interrupted.into());
                }
                match (self.0.split_first(), out.first_mut()) {
                    (Some((b, rest)), Some(o)) => {
                        *o = *b;
                        self.0 = rest;
                        Ok(1)
                    }
                    _ => Ok(0),
                }
            }
        }
        let (good, recs) = log(40);
        let mut buf = vec![7u8; 33];
        buf.extend(&good);
        buf.extend([1, 2, 3]);
        let mut r = TlogReader::new(Trickle(&buf, 0));
        let got: Vec<TlogRecord> = r.by_ref().map(|x| x.unwrap()).collect();
        assert_eq!(got, recs);
        assert_eq!(r.skipped(), Skipped { bytes: 36, gaps: 2 });
        assert_eq!(r.offset(), buf.len() as u64);
    }

    #[test]
    fn read_errors_end_the_stream() {
        struct Broken;
        impl Read for Broken {
            fn read(&mut self, _: &mut [u8]) -> io::Result<usize> {
                Err(io::Error::other("disk on fire"))
            }
        }
        let mut r = TlogReader::new(Broken);
        let e = r.next().unwrap().unwrap_err();
        assert_eq!(e.to_string(), "disk on fire");
        assert!(r.next().is_none());
    }

    #[test]
    fn no_records_at_all_is_an_error() {
        let mut buf = 5u64.to_be_bytes().to_vec();
        buf.extend([0x00, 1, 2, 3]);
        assert_eq!(read_tlog(&buf), Err(TlogError::NoRecords { bytes: 12 }));
        assert_eq!(read_tlog(&[]), Ok(vec![]));
    }

    #[test]
    fn frames_with_bad_crc_or_unknown_ids_are_kept_while_in_step() {
        let (good, mut recs) = log(3);
        let mut buf = good.clone();
        // A record whose CRC is wrong, then one with message id 0xBEEF (not in the dialect).
        let mut bad_crc = heartbeat(Version::V2, 9);
        let n = bad_crc.len();
        bad_crc[n - 1] ^= 0xFF;
        let unknown = vec![0xFD, 2, 0, 0, 5, 1, 1, 0xEF, 0xBE, 0x00, 7, 8, 0x12, 0x34];
        for (t, f) in [(7000, &bad_crc), (8000, &unknown)] {
            write_record(&mut buf, t, f);
            recs.push(TlogRecord {
                time_us: t,
                frame: f.clone(),
            });
        }
        let (got, skipped) = read_tlog_counted(&buf).unwrap();
        assert_eq!(got, recs);
        assert!(skipped.is_empty());
        // After garbage, though, only a frame that checks out counts: the bad one is skipped.
        let mut buf = good.clone();
        buf.extend([0u8; 10]);
        write_record(&mut buf, 7000, &bad_crc);
        write_record(&mut buf, 7500, &heartbeat(Version::V1, 10));
        let (got, skipped) = read_tlog_counted(&buf).unwrap();
        assert_eq!(got.len(), 4);
        assert_eq!(got[3].time_us, 7500);
        assert_eq!(
            skipped,
            Skipped {
                bytes: 10 + 8 + 21,
                gaps: 1
            }
        );
    }
}
