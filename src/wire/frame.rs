//! MAVLink frames as bytes: our own framing, so the raw bytes (and our own sequence numbers) survive.
//!
//! The `mavlink` crate's connection objects rewrite outgoing sequence numbers, accept only MAVLink 2
//! by default and drop frames whose message id the dialect does not know. A ground station that
//! counts loss from sequence gaps and forwards frames unchanged cannot live with any of that, so
//! framing (finding frames in a byte stream, checking the CRC) is done here, and only the payload
//! decode is handed to the crate's generated dialect code.

use crate::dialect::MavMessage;
use mavlink::{MavlinkVersion, Message};

/// Start byte of a MAVLink 1 frame.
pub const MAGIC_V1: u8 = 0xFE;
/// Start byte of a MAVLink 2 frame.
pub const MAGIC_V2: u8 = 0xFD;
/// MAVLink 2 incompatibility flag: the frame carries a 13-byte signature after the CRC.
pub const IFLAG_SIGNED: u8 = 0x01;
/// Length of a MAVLink 2 signature (link id, 48-bit timestamp, 48-bit signature).
pub const SIGNATURE_LEN: usize = 13;
/// Largest possible frame: v2 header (10) + payload (255) + CRC (2) + signature (13).
pub const MAX_FRAME_LEN: usize = 10 + 255 + 2 + SIGNATURE_LEN;

/// CRC-16/MCRF4XX (the "X.25" accumulate of the MAVLink C library), seed 0xFFFF.
#[inline]
pub fn crc_accumulate(crc: u16, byte: u8) -> u16 {
    let mut tmp = byte ^ (crc as u8);
    tmp ^= tmp << 4;
    let tmp = tmp as u16;
    (crc >> 8) ^ (tmp << 8) ^ (tmp << 3) ^ (tmp >> 4)
}

/// Lookup tables for [`frame_crc`], 16 bytes at a time ("slicing by 16"): `CRC_TABLES[0][i]` is
/// the CRC register after feeding byte `i` into a zero register; `CRC_TABLES[k][i]` the same
/// followed by `k` zero bytes. Built at compile time from [`crc_accumulate`]'s polynomial
/// (0x1021 reflected: 0x8408).
static CRC_TABLES: [[u16; 256]; 16] = crc_tables();

const fn crc_tables() -> [[u16; 256]; 16] {
    let mut t = [[0u16; 256]; 16];
    let mut i = 0;
    while i < 256 {
        let mut crc = i as u16;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0x8408
            } else {
                crc >> 1
            };
            bit += 1;
        }
        t[0][i] = crc;
        i += 1;
    }
    let mut k = 1;
    while k < 16 {
        let mut i = 0;
        while i < 256 {
            let prev = t[k - 1][i];
            t[k][i] = (prev >> 8) ^ t[0][(prev & 0xFF) as usize];
            i += 1;
        }
        k += 1;
    }
    t
}

/// [`crc_accumulate`] over a run of bytes, table-driven; same result, several times faster.
#[inline]
pub fn crc_update(mut crc: u16, data: &[u8]) -> u16 {
    let t = &CRC_TABLES;
    let mut chunks = data.chunks_exact(16);
    for c in &mut chunks {
        // The 14 bytes the register does not reach first, so only two lookups wait on it.
        let mut rest = 0;
        for k in 2..16 {
            rest ^= t[15 - k][c[k] as usize];
        }
        let lo = c[0] ^ crc as u8;
        let hi = c[1] ^ (crc >> 8) as u8;
        crc = rest ^ (t[15][lo as usize] ^ t[14][hi as usize]);
    }
    crc_tail(crc, chunks.remainder())
}

/// [`crc_update`] over fewer than 16 bytes: 8, 4 and 2 at a time, then one, so the register
/// waits on as few lookups as it can.
#[inline(always)]
#[allow(clippy::reversed_empty_ranges)] // the 2-byte step has no bytes beyond the first two
fn crc_tail(mut crc: u16, mut rest: &[u8]) -> u16 {
    let t = &CRC_TABLES;
    // `n` bytes at once: the register reaches the first two, the others are looked up apart.
    macro_rules! step {
        ($n:literal) => {
            if rest.len() >= $n {
                let c = &rest[..$n];
                let mut x = 0;
                for k in 2..$n {
                    x ^= t[$n - 1 - k][c[k] as usize];
                }
                let lo = c[0] ^ crc as u8;
                let hi = c[1] ^ (crc >> 8) as u8;
                crc = x ^ (t[$n - 1][lo as usize] ^ t[$n - 2][hi as usize]);
                rest = &rest[$n..];
            }
        };
    }
    step!(8);
    step!(4);
    step!(2);
    if let Some(&b) = rest.first() {
        crc = (crc >> 8) ^ t[0][((crc ^ b as u16) & 0xFF) as usize];
    }
    crc
}

/// CRC over `data` followed by the message's CRC_EXTRA byte, as MAVLink defines it. The bytes
/// after the last whole 16 go with CRC_EXTRA through one short tail.
#[inline]
pub fn frame_crc(data: &[u8], crc_extra: u8) -> u16 {
    frame_crc_in(data, data.len(), crc_extra)
}

/// [`frame_crc`] of `buf[..len]`; `buf` may go on past `len` (a parser's buffer holding the CRC
/// and what follows), and then the tail is taken as one fixed 16-byte copy, the bytes past it
/// never used.
#[inline]
pub fn frame_crc_in(buf: &[u8], len: usize, crc_extra: u8) -> u16 {
    let whole = len - len % 16;
    let crc = crc_update(0xFFFF, &buf[..whole]);
    let n = len - whole;
    let mut tail = match buf[whole..].first_chunk::<16>() {
        Some(block) => *block,
        None => {
            let mut t = [0u8; 16];
            t[..n].copy_from_slice(&buf[whole..len]);
            t
        }
    };
    tail[n] = crc_extra;
    crc_update(crc, &tail[..n + 1])
}

/// The CRC_EXTRA byte of a message id in our dialect (ardupilotmega, which includes common),
/// or `None` if the dialect does not know the id.
pub fn crc_extra(msgid: u32) -> Option<u8> {
    // The generated `extra_crc` answers 0 for unknown ids; a few real messages could in
    // principle have extra 0, so ask the dialect whether the id exists.
    let extra = MavMessage::extra_crc(msgid);
    if extra != 0 || MavMessage::default_message_from_id(msgid).is_some() {
        Some(extra)
    } else {
        None
    }
}

/// Protocol version of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
pub enum Version {
    V1,
    V2,
}

impl Version {
    pub fn to_mavlink(self) -> MavlinkVersion {
        match self {
            Version::V1 => MavlinkVersion::V1,
            Version::V2 => MavlinkVersion::V2,
        }
    }
}

/// The bytes of one frame: held inline when they fit (almost every frame does), so taking a
/// frame off the wire allocates nothing; on the heap otherwise. Reads as a `[u8]`.
#[derive(Clone)]
pub struct RawBytes(RawRepr);

#[derive(Clone)]
enum RawRepr {
    Inline {
        len: u8,
        bytes: [u8; RawBytes::INLINE],
    },
    Heap(Box<[u8]>),
}

impl RawBytes {
    /// Frames up to this long are held inline (the type is then 64 bytes, like a cache line).
    pub const INLINE: usize = 62;

    pub fn new(bytes: &[u8]) -> RawBytes {
        if bytes.len() <= Self::INLINE {
            let mut raw = RawBytes(RawRepr::Inline {
                len: bytes.len() as u8,
                bytes: [0; Self::INLINE],
            });
            if let RawRepr::Inline { bytes: inline, .. } = &mut raw.0 {
                inline[..bytes.len()].copy_from_slice(bytes);
            }
            raw
        } else {
            RawBytes(RawRepr::Heap(bytes.into()))
        }
    }

    /// The first `len` bytes of `bytes`. When `bytes` goes on long enough, a whole inline
    /// buffer's worth is copied (a fixed-size copy is a few instructions; the bytes past `len`
    /// are never read).
    #[inline]
    pub fn first(bytes: &[u8], len: usize) -> RawBytes {
        match bytes.first_chunk::<{ Self::INLINE }>() {
            Some(block) if len <= Self::INLINE => RawBytes(RawRepr::Inline {
                len: len as u8,
                bytes: *block,
            }),
            _ => RawBytes::new(&bytes[..len]),
        }
    }

    #[inline]
    pub fn as_slice(&self) -> &[u8] {
        match &self.0 {
            RawRepr::Inline { len, bytes } => &bytes[..*len as usize],
            RawRepr::Heap(b) => b,
        }
    }
}

impl std::ops::Deref for RawBytes {
    type Target = [u8];
    #[inline]
    fn deref(&self) -> &[u8] {
        self.as_slice()
    }
}

impl AsRef<[u8]> for RawBytes {
    fn as_ref(&self) -> &[u8] {
        self.as_slice()
    }
}

impl std::borrow::Borrow<[u8]> for RawBytes {
    fn borrow(&self) -> &[u8] {
        self.as_slice()
    }
}

impl From<&[u8]> for RawBytes {
    fn from(bytes: &[u8]) -> RawBytes {
        RawBytes::new(bytes)
    }
}

impl From<RawBytes> for Vec<u8> {
    fn from(raw: RawBytes) -> Vec<u8> {
        raw.to_vec()
    }
}

impl std::fmt::Debug for RawBytes {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.as_slice().fmt(f)
    }
}

impl PartialEq for RawBytes {
    fn eq(&self, other: &RawBytes) -> bool {
        self.as_slice() == other.as_slice()
    }
}

impl Eq for RawBytes {}

impl PartialEq<[u8]> for RawBytes {
    fn eq(&self, other: &[u8]) -> bool {
        self.as_slice() == other
    }
}

impl PartialEq<Vec<u8>> for RawBytes {
    fn eq(&self, other: &Vec<u8>) -> bool {
        self.as_slice() == &other[..]
    }
}

impl PartialEq<RawBytes> for Vec<u8> {
    fn eq(&self, other: &RawBytes) -> bool {
        &self[..] == other.as_slice()
    }
}

/// One frame as it came off the wire: its exact bytes, the header fields, and the decoded
/// message when the dialect knows the id.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// The frame exactly as received, magic byte to the end of the signature.
    pub raw: RawBytes,
    pub version: Version,
    pub seq: u8,
    pub sysid: u8,
    pub compid: u8,
    pub msgid: u32,
    pub incompat_flags: u8,
    pub compat_flags: u8,
    /// `Some` only for known message ids whose payload decoded. Boxed, so a frame is small (88
    /// bytes, where the largest message is 280) and a batch of them stays in the cache; the
    /// core's parsers are lazy and decode only what is read ([`Frame::decode`]), with no box.
    pub message: Option<Box<MavMessage>>,
    /// From a lazy parser ([`crate::wire::FrameParser::lazy`]): `message` is `None` because
    /// nothing decoded it; its reader decodes what it reads ([`Frame::decode`]).
    pub lazy: bool,
}

impl Frame {
    /// The message decoded from the payload; an error when the dialect does not know the id or
    /// cannot read it (an enum value newer than the dialect's). Returned as the dialect gives
    /// it, so the message is built where the caller keeps it (it is a few hundred bytes).
    pub fn decode(&self) -> Result<MavMessage, mavlink::error::ParserError> {
        use mavlink::Message;
        MavMessage::parse(self.version.to_mavlink(), self.msgid, self.payload())
    }

    /// Length of the payload as sent (MAVLink 2 truncates trailing zeros).
    pub fn payload_len(&self) -> usize {
        self.raw[1] as usize
    }

    /// The payload bytes as sent.
    pub fn payload(&self) -> &[u8] {
        let start = self.header_len();
        &self.raw[start..start + self.payload_len()]
    }

    fn header_len(&self) -> usize {
        match self.version {
            Version::V1 => 6,
            Version::V2 => 10,
        }
    }

    /// True when a MAVLink 2 frame carries a signature.
    #[inline]
    pub fn is_signed(&self) -> bool {
        self.version == Version::V2 && self.incompat_flags & IFLAG_SIGNED != 0
    }

    /// The 13 signature bytes (link id, timestamp, signature), kept for later verification.
    pub fn signature(&self) -> Option<&[u8]> {
        if self.is_signed() {
            Some(&self.raw[self.raw.len() - SIGNATURE_LEN..])
        } else {
            None
        }
    }

    /// The frame's CRC as sent (two bytes before any signature).
    #[inline]
    pub fn crc(&self) -> u16 {
        let raw = self.raw.as_slice();
        let end = raw.len() - if self.is_signed() { SIGNATURE_LEN } else { 0 };
        u16::from_le_bytes([raw[end - 2], raw[end - 1]])
    }

    /// Name of the message, or `UNKNOWN_<id>` for ids the dialect does not know.
    pub fn name(&self) -> String {
        match self.message.as_deref() {
            Some(m) => m.message_name().to_string(),
            None => format!("UNKNOWN_{}", self.msgid),
        }
    }
}

/// Header fields of a frame we send.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Header {
    pub sysid: u8,
    pub compid: u8,
    pub seq: u8,
}

/// Serialize `msg` into a complete frame with exactly the header given (our own sequence).
/// MAVLink 2 payloads have trailing zeros removed (keeping at least one byte), as the spec says.
pub fn encode(version: Version, header: Header, msg: &MavMessage) -> Vec<u8> {
    // The crate's own serializers (payload, MAVLink 2 zero truncation, CRC with CRC_EXTRA), with
    // our header: our sequence numbers survive.
    let h = mavlink::MavHeader {
        system_id: header.sysid as u32,
        component_id: header.compid,
        sequence: header.seq,
    };
    match version {
        Version::V1 if msg.message_id() <= 255 => {
            let mut raw = mavlink::MAVLinkV1MessageRaw::new();
            raw.serialize_message(h, msg);
            raw.raw_bytes().to_vec()
        }
        _ => {
            let mut raw = mavlink::MAVLinkV2MessageRaw::new();
            raw.serialize_message(h, msg);
            raw.raw_bytes().to_vec()
        }
    }
}

/// Decode a frame's bytes on their own (exactly one whole frame). Convenience for tests and tools.
pub fn decode_one(bytes: &[u8]) -> Option<Frame> {
    let mut p = crate::wire::parser::FrameParser::new();
    let mut out = None;
    p.push(bytes, |f| {
        if out.is_none() {
            out = Some(f)
        }
    });
    p.end_of_datagram(|f| {
        if out.is_none() {
            out = Some(f)
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dialect as apm;

    fn gcs_heartbeat() -> MavMessage {
        MavMessage::HEARTBEAT(apm::HEARTBEAT_DATA {
            custom_mode: 0,
            mavtype: apm::MavType::MAV_TYPE_GCS,
            autopilot: apm::MavAutopilot::MAV_AUTOPILOT_INVALID,
            base_mode: apm::MavModeFlag::empty(),
            system_status: apm::MavState::MAV_STATE_ACTIVE,
            mavlink_version: 3,
        })
    }

    /// A link hands the core its frames in batches of about a hundred: a frame holds its message
    /// boxed, so the batch is a few kilobytes (not the 280 bytes of the largest message each).
    #[test]
    fn a_frame_is_small() {
        assert!(std::mem::size_of::<MavMessage>() >= 200);
        assert!(
            std::mem::size_of::<Frame>() <= 96,
            "{}",
            std::mem::size_of::<Frame>()
        );
    }

    #[test]
    fn crc_matches_known_check_value() {
        // CRC-16/MCRF4XX check value for "123456789" is 0x6F91.
        let mut crc = 0xFFFFu16;
        for b in b"123456789" {
            crc = crc_accumulate(crc, *b);
        }
        assert_eq!(crc, 0x6F91);
    }

    #[test]
    fn table_crc_matches_the_bytewise_definition() {
        // The published check value first, then random runs of every length against the
        // byte-at-a-time accumulate the MAVLink C library defines.
        assert_eq!(crc_update(0xFFFF, b"123456789"), 0x6F91);
        let mut x = 0x1234_5678_9ABC_DEF0u64;
        let mut data = Vec::new();
        for len in 0..300 {
            data.clear();
            for _ in 0..len {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                data.push(x as u8);
            }
            let seed = x as u16;
            let bytewise = data.iter().fold(seed, |c, &b| crc_accumulate(c, b));
            assert_eq!(crc_update(seed, &data), bytewise, "length {len}");
            // A frame's CRC: from 0xFFFF over the bytes, then CRC_EXTRA.
            let extra = (x >> 16) as u8;
            let framed = crc_accumulate(
                data.iter().fold(0xFFFF, |c, &b| crc_accumulate(c, b)),
                extra,
            );
            assert_eq!(frame_crc(&data, extra), framed, "frame of {len} bytes");
            // Within a longer buffer (what follows is not read into it).
            let mut longer = data.clone();
            longer.extend_from_slice(&[0xA5; 20]);
            assert_eq!(frame_crc_in(&longer, len, extra), framed, "{len} of more");
        }
    }

    #[test]
    fn heartbeat_v2_is_byte_exact() {
        let bytes = encode(
            Version::V2,
            Header {
                sysid: 255,
                compid: 190,
                seq: 7,
            },
            &gcs_heartbeat(),
        );
        // Payload: custom_mode u32=0, type=6 (GCS), autopilot=8 (INVALID), base_mode=0,
        // system_status=4 (ACTIVE), mavlink_version=3. CRC_EXTRA of HEARTBEAT is 50.
        let mut expect = vec![
            0xFD, 9, 0, 0, 7, 255, 190, 0, 0, 0, 0, 0, 0, 0, 6, 8, 0, 4, 3,
        ];
        let crc = frame_crc(&expect[1..], 50);
        expect.extend_from_slice(&crc.to_le_bytes());
        assert_eq!(bytes, expect);
    }

    #[test]
    fn heartbeat_v1_round_trips() {
        let h = Header {
            sysid: 1,
            compid: 1,
            seq: 200,
        };
        let bytes = encode(Version::V1, h, &gcs_heartbeat());
        assert_eq!(bytes[0], MAGIC_V1);
        assert_eq!(bytes.len(), 6 + 9 + 2);
        let f = decode_one(&bytes).expect("decodes");
        assert_eq!((f.sysid, f.compid, f.seq, f.msgid), (1, 1, 200, 0));
        assert_eq!(f.message.as_deref(), Some(&gcs_heartbeat()));
        assert_eq!(f.raw, bytes);
    }

    #[test]
    fn v2_truncates_trailing_zeros_but_keeps_one_byte() {
        let msg = MavMessage::PARAM_REQUEST_LIST(apm::PARAM_REQUEST_LIST_DATA {
            target_system: 0,
            target_component: 0,
        });
        let bytes = encode(
            Version::V2,
            Header {
                sysid: 1,
                compid: 1,
                seq: 0,
            },
            &msg,
        );
        assert_eq!(bytes[1], 1, "payload length");
        assert_eq!(decode_one(&bytes).unwrap().message.as_deref(), Some(&msg));
    }

    #[test]
    fn raw_bytes_read_as_the_bytes_given() {
        let bytes: Vec<u8> = (0..=255u8).collect();
        for len in [
            0,
            1,
            17,
            RawBytes::INLINE - 1,
            RawBytes::INLINE,
            RawBytes::INLINE + 1,
            255,
        ] {
            let want = &bytes[..len];
            let made = RawBytes::new(want);
            // From a longer buffer (a whole block copied) and from one that ends with the frame.
            let within = RawBytes::first(&bytes, len);
            let at_end = RawBytes::first(want, len);
            for r in [&made, &within, &at_end] {
                assert_eq!(&r[..], want);
                assert_eq!(r.len(), len);
                assert_eq!(*r, want.to_vec());
                assert_eq!(format!("{r:?}"), format!("{want:?}"));
                assert_eq!(r.clone(), made);
            }
        }
        assert_ne!(RawBytes::new(&[1, 2]), RawBytes::new(&[1, 2, 0]));
    }

    #[test]
    fn unknown_id_has_no_crc_extra() {
        assert_eq!(crc_extra(0), Some(50));
        assert_eq!(crc_extra(0x00ABCDEF), None);
    }
}
