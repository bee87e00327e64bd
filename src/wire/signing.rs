//! MAVLink 2 message signing, as the MAVLink developer guide defines it: pure, no clock, no I/O.
//!
//! A signed frame has the incompatibility flag 0x01 set and 13 bytes after its CRC: the link id
//! (1 byte), a timestamp (6 bytes, little-endian, 10 µs units since 2015-01-01 00:00 UTC) and the
//! signature, the first 6 bytes of SHA-256(secret key ‖ the frame from its magic byte to the end
//! of the timestamp). The CRC is computed first, with the flag set, and does not cover the 13
//! bytes.
//!
//! Here: the secret key and how operators give it ([`parse_key_spec`]: a passphrase hashed with
//! SHA-256 as MAVProxy and Mission Planner do, `hex:` 64 hex digits, or `file:PATH`), signing a
//! frame ([`sign_frame`]), checking one ([`verify`]), our outgoing timestamp ([`Clock`], which
//! never goes backwards), and the incoming streams (link id, sysid, compid) with their last
//! timestamps, the one-minute rule for new streams and the bound on timestamps from the future
//! ([`Streams`]). The caller passes the wall time in: this module never reads a clock.
//!
//! The guide raises our clock to every good incoming timestamp and never lowers it, so one
//! frame dated far ahead (a vehicle whose clock jumped, or anyone holding the key) would carry
//! our clock, and everything we sign after, to that date. Here a timestamp more than
//! [`FUTURE_MARGIN`] ahead of the wall clock is refused ([`Verdict::Future`]): it opens no
//! stream and never raises our clock.
//!
//! The `mavlink` crate's `SigningData` reads the system clock itself and keeps its state behind a
//! mutex, so it cannot live in a pure core; its signature computation is used in the tests as an
//! independent check of ours.

use std::collections::{BTreeMap, BTreeSet};

use sha2::{Digest, Sha256};

use super::frame::{frame_crc, IFLAG_SIGNED, MAGIC_V2, SIGNATURE_LEN};

/// Length of a secret key.
pub const KEY_LEN: usize = 32;
/// Length of the signature value (the last field of the 13 bytes).
pub const SIGNATURE_VALUE_LEN: usize = 6;
/// One minute in timestamp units (10 µs): a new stream's first timestamp may be at most this far
/// behind ours.
pub const ONE_MINUTE: u64 = 6_000_000;
/// How far ahead of our wall clock an incoming timestamp may be: one minute.
///
/// - It is the guide's own tolerance the other way: a new stream may be a minute behind.
/// - It holds what a sound peer can be ahead by: a ground station restarted after a crash starts
///   from its reservation (ours is 30 s, `app::signing::RESERVE`) and the vehicles it talks to
///   take its clock; that leaves 30 s for the clocks of two machines to disagree.
/// - Past it, following the vehicle is no cure: a vehicle more than a minute ahead refuses a
///   new stream of ours that keeps to the wall clock (the C library's one-minute rule), and
///   taking its clock is how one bad frame locked the link. A clock a minute off is broken:
///   the operator sets it right (ours), or `signing setup` gives the vehicle ours.
pub const FUTURE_MARGIN: u64 = ONE_MINUTE;
/// 2015-01-01 00:00:00 UTC in Unix seconds: the signing timestamp's epoch.
pub const EPOCH_UNIX_SECONDS: i64 = 1_420_070_400;
/// Largest timestamp that fits the 48-bit field.
pub const MAX_TIMESTAMP: u64 = (1 << 48) - 1;
/// Incoming streams remembered per link at most; past this the stream heard with the oldest
/// timestamp is forgotten (and counted). Only frames with a good signature make a stream, so only
/// a holder of the key can fill the table.
pub const MAX_STREAMS: usize = 256;
/// MAVLink 2 header length (magic to message id).
const HEADER_LEN: usize = 10;

/// A 32-byte signing key. Its `Debug` never shows the bytes.
#[derive(Clone, PartialEq, Eq)]
pub struct SecretKey([u8; KEY_LEN]);

impl std::fmt::Debug for SecretKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "SecretKey(id {})", self.id())
    }
}

impl SecretKey {
    pub fn from_bytes(bytes: [u8; KEY_LEN]) -> Self {
        SecretKey(bytes)
    }

    /// The key MAVProxy (`signing setup PASSPHRASE`) and Mission Planner make of a passphrase:
    /// SHA-256 of its UTF-8 bytes.
    pub fn from_passphrase(passphrase: &str) -> Self {
        SecretKey(Sha256::digest(passphrase.as_bytes()).into())
    }

    pub fn as_bytes(&self) -> &[u8; KEY_LEN] {
        &self.0
    }

    /// All zero: what SETUP_SIGNING sends to turn signing off; never a key to sign with.
    pub fn is_zero(&self) -> bool {
        self.0.iter().all(|&b| b == 0)
    }

    /// A short name for the key, safe to show: the first 3 bytes of SHA-256(key) in hex. Two
    /// ground stations with the same key show the same id; the id tells nothing of the key.
    pub fn id(&self) -> String {
        Sha256::digest(self.0)[..3]
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect()
    }
}

/// Why a key could not be read. Messages never contain the key or passphrase.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum KeyError {
    #[error("the signing passphrase is empty")]
    Empty,
    #[error("a hex: key is 64 hex digits (32 bytes); this one has {0} characters")]
    HexLength(usize),
    #[error("a hex: key is 64 hex digits; character {0} is not one")]
    HexDigit(usize),
    #[error("an all-zero key turns signing off; it cannot sign")]
    Zero,
    #[error("file: needs a path, e.g. file:~/.config/mavterm/signing.key")]
    NoPath,
}

/// How the operator gave the key: the key itself, or a file holding it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum KeySpec {
    Key(SecretKey),
    /// `file:PATH`: the file's first line is read as [`parse_key`] reads text.
    File(String),
}

/// `PASSPHRASE`, `hex:64HEX` or `file:PATH`.
pub fn parse_key_spec(s: &str) -> Result<KeySpec, KeyError> {
    match s.strip_prefix("file:") {
        Some("") => Err(KeyError::NoPath),
        Some(path) => Ok(KeySpec::File(path.to_string())),
        None => parse_key(s).map(KeySpec::Key),
    }
}

/// `hex:64HEX` (the raw key) or a passphrase (hashed with SHA-256).
pub fn parse_key(s: &str) -> Result<SecretKey, KeyError> {
    let key = match s.strip_prefix("hex:") {
        Some(hex) => {
            let hex = hex.trim();
            if hex.chars().count() != 2 * KEY_LEN {
                return Err(KeyError::HexLength(hex.chars().count()));
            }
            if let Some(i) = hex.chars().position(|c| !c.is_ascii_hexdigit()) {
                return Err(KeyError::HexDigit(i + 1));
            }
            let mut b = [0u8; KEY_LEN];
            for (i, out) in b.iter_mut().enumerate() {
                *out = u8::from_str_radix(&hex[2 * i..2 * i + 2], 16)
                    .map_err(|_| KeyError::HexDigit(2 * i + 1))?;
            }
            SecretKey(b)
        }
        None if s.is_empty() => return Err(KeyError::Empty),
        None => SecretKey::from_passphrase(s),
    };
    if key.is_zero() {
        return Err(KeyError::Zero);
    }
    Ok(key)
}

/// The signing timestamp of a wall-clock time (µs since the Unix epoch); 0 before 2015.
pub fn timestamp_from_unix_micros(us: i64) -> u64 {
    let since = us.saturating_sub(EPOCH_UNIX_SECONDS * 1_000_000);
    (since.max(0) as u64 / 10).min(MAX_TIMESTAMP)
}

/// The signature of a frame: `signed` is the frame from its magic byte to the end of the
/// timestamp (everything but the signature value itself).
pub fn signature(key: &SecretKey, signed: &[u8]) -> [u8; SIGNATURE_VALUE_LEN] {
    let mut h = Sha256::new();
    h.update(key.0);
    h.update(signed);
    let d = h.finalize();
    let mut out = [0u8; SIGNATURE_VALUE_LEN];
    out.copy_from_slice(&d[..SIGNATURE_VALUE_LEN]);
    out
}

/// Sign an unsigned MAVLink 2 frame in place: set the flag, recompute the CRC (`crc_extra` is
/// the message's), append link id, timestamp and signature. Anything else is left as it is
/// (MAVLink 1 cannot be signed; a signed frame is not signed twice); false then.
pub fn sign_frame(
    frame: &mut Vec<u8>,
    crc_extra: u8,
    key: &SecretKey,
    link_id: u8,
    timestamp: u64,
) -> bool {
    let n = frame.len();
    if n < HEADER_LEN + 2 || frame[0] != MAGIC_V2 || frame[2] & IFLAG_SIGNED != 0 {
        return false;
    }
    frame[2] |= IFLAG_SIGNED;
    let crc = frame_crc(&frame[1..n - 2], crc_extra);
    frame[n - 2..].copy_from_slice(&crc.to_le_bytes());
    frame.push(link_id);
    frame.extend_from_slice(&timestamp.to_le_bytes()[..6]);
    let sig = signature(key, frame);
    frame.extend_from_slice(&sig);
    true
}

/// The 13 signature bytes of a frame, read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SignatureFields {
    pub link_id: u8,
    pub timestamp: u64,
    pub value: [u8; SIGNATURE_VALUE_LEN],
}

/// The signature fields of a signed MAVLink 2 frame (its exact bytes), or `None`.
pub fn read_signature(raw: &[u8]) -> Option<SignatureFields> {
    let n = raw.len();
    if n < HEADER_LEN + 2 + SIGNATURE_LEN || raw[0] != MAGIC_V2 || raw[2] & IFLAG_SIGNED == 0 {
        return None;
    }
    let s = &raw[n - SIGNATURE_LEN..];
    let mut ts = [0u8; 8];
    ts[..6].copy_from_slice(&s[1..7]);
    let mut value = [0u8; SIGNATURE_VALUE_LEN];
    value.copy_from_slice(&s[7..]);
    Some(SignatureFields {
        link_id: s[0],
        timestamp: u64::from_le_bytes(ts),
        value,
    })
}

/// True when a signed frame's signature is right for `key` (timestamps aside).
pub fn verify(key: &SecretKey, raw: &[u8]) -> bool {
    match read_signature(raw) {
        Some(f) => signature(key, &raw[..raw.len() - SIGNATURE_VALUE_LEN]) == f.value,
        None => false,
    }
}

/// Our outgoing timestamp: the wall clock's, but never less than one more than the last one
/// used, nor than a good incoming one (the guide's rules).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Clock {
    last: u64,
}

impl Clock {
    /// A clock whose next timestamp is after `saved` (the last one used or reserved before).
    pub fn after(saved: u64) -> Self {
        Clock { last: saved }
    }

    /// The timestamp for the next frame we sign, at wall timestamp `wall`.
    pub fn next(&mut self, wall: u64) -> u64 {
        self.last = (self.last + 1).max(wall).min(MAX_TIMESTAMP);
        self.last
    }

    /// Our current timestamp (what new incoming streams are held against).
    pub fn current(&self, wall: u64) -> u64 {
        self.last.max(wall)
    }

    /// A correctly signed incoming frame's timestamp: ours is at least that from now on.
    pub fn observe(&mut self, timestamp: u64) {
        self.last = self.last.max(timestamp);
    }

    /// The last timestamp used (or observed).
    pub fn last(&self) -> u64 {
        self.last
    }
}

/// What became of a signed frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Good signature and a new timestamp for its stream (the timestamp).
    Good(u64),
    /// The signature does not match the frame and our key (a wrong key, or changed bytes).
    BadSignature,
    /// The timestamp is not after the last one of its stream: a replayed (or repeated) frame.
    Replayed,
    /// The first frame of a stream, more than a minute behind our timestamp.
    TooOld,
    /// Good signature, but a timestamp more than [`FUTURE_MARGIN`] ahead of the wall clock:
    /// refused, and neither its stream nor our clock moves. `first`: the first such frame of its
    /// stream (to name it once).
    Future {
        timestamp: u64,
        link_id: u8,
        first: bool,
    },
}

/// The incoming streams of one link: (link id, sysid, compid) → last good timestamp.
#[derive(Debug, Clone, Default)]
pub struct Streams {
    last: BTreeMap<(u8, u8, u8), u64>,
    /// Streams forgotten to stay within [`MAX_STREAMS`].
    pub evicted: u64,
    /// Streams told of a timestamp from the future (at most [`MAX_STREAMS`]).
    future_told: BTreeSet<(u8, u8, u8)>,
}

impl Streams {
    pub fn len(&self) -> usize {
        self.last.len()
    }

    pub fn is_empty(&self) -> bool {
        self.last.is_empty()
    }

    /// Check a signed frame (`raw`, its exact bytes, from `sysid`:`compid`) at our current
    /// timestamp `current` and wall timestamp `wall`. The signature is checked first, so a frame
    /// with a bad one changes nothing; a good one must not be more than [`FUTURE_MARGIN`] ahead
    /// of `wall` (else it changes nothing either), then must be newer than its stream's last, or,
    /// opening a stream, not more than a minute behind `current`.
    pub fn check(
        &mut self,
        key: &SecretKey,
        raw: &[u8],
        sysid: u8,
        compid: u8,
        current: u64,
        wall: u64,
    ) -> Verdict {
        let Some(sig) = read_signature(raw) else {
            return Verdict::BadSignature;
        };
        if signature(key, &raw[..raw.len() - SIGNATURE_VALUE_LEN]) != sig.value {
            return Verdict::BadSignature;
        }
        let stream = (sig.link_id, sysid, compid);
        if sig.timestamp > wall.saturating_add(FUTURE_MARGIN) {
            let first = self.future_told.len() < MAX_STREAMS && self.future_told.insert(stream);
            return Verdict::Future {
                timestamp: sig.timestamp,
                link_id: sig.link_id,
                first,
            };
        }
        match self.last.get_mut(&stream) {
            Some(last) if sig.timestamp <= *last => Verdict::Replayed,
            Some(last) => {
                *last = sig.timestamp;
                Verdict::Good(sig.timestamp)
            }
            None if sig.timestamp.saturating_add(ONE_MINUTE) < current => Verdict::TooOld,
            None => {
                if self.last.len() >= MAX_STREAMS {
                    self.evict();
                }
                self.last.insert(stream, sig.timestamp);
                Verdict::Good(sig.timestamp)
            }
        }
    }

    /// Forget the stream with the oldest timestamp.
    #[cold]
    fn evict(&mut self) {
        let oldest = self.last.iter().min_by_key(|(_, t)| **t).map(|(k, _)| *k);
        if let Some(k) = oldest {
            self.last.remove(&k);
            self.evicted += 1;
        }
    }
}

/// The wall-clock time (µs since the Unix epoch) of a signing timestamp.
pub fn unix_micros_of(timestamp: u64) -> i64 {
    EPOCH_UNIX_SECONDS * 1_000_000 + (timestamp.min(MAX_TIMESTAMP) * 10) as i64
}

/// A timestamp difference for people: `45 s`, `59 min`, `2 h 05 min`, `3 d 4 h`, `78 years`.
pub fn span_text(units: u64) -> String {
    // Whole seconds, rounded: 3599.9 s is an hour.
    let s = units.saturating_add(50_000) / 100_000;
    match s {
        0..=119 => format!("{s} s"),
        120..=3599 => format!("{} min", s / 60),
        3600..=172_799 => format!("{} h {:02} min", s / 3600, s / 60 % 60),
        172_800..=63_071_999 => format!("{} d {} h", s / 86_400, s / 3600 % 24),
        _ => format!("{} years", s / 31_557_600),
    }
}

/// The signing state file's contents: the timestamp to start after.
pub fn encode_state(timestamp: u64) -> Vec<u8> {
    format!("{{\"timestamp\": {timestamp}}}\n").into_bytes()
}

/// The timestamp of a signing state file, or why it is not one.
pub fn decode_state(bytes: &[u8]) -> Result<u64, String> {
    let v: serde_json::Value =
        serde_json::from_slice(bytes).map_err(|e| format!("not JSON ({e})"))?;
    v.get("timestamp")
        .and_then(|t| t.as_u64())
        .filter(|t| *t <= MAX_TIMESTAMP)
        .ok_or_else(|| "no \"timestamp\" (a 48-bit whole number) in it".to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dialect::{self, MavMessage};
    use crate::wire::frame::{decode_one, encode, Header, Version};

    fn heartbeat() -> MavMessage {
        MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
            custom_mode: 0,
            mavtype: dialect::MavType::MAV_TYPE_GCS,
            autopilot: dialect::MavAutopilot::MAV_AUTOPILOT_INVALID,
            base_mode: dialect::MavModeFlag::empty(),
            system_status: dialect::MavState::MAV_STATE_ACTIVE,
            mavlink_version: 3,
        })
    }

    fn signed_heartbeat(key: &SecretKey, link_id: u8, ts: u64) -> Vec<u8> {
        let mut f = encode(
            Version::V2,
            Header {
                sysid: 255,
                compid: 190,
                seq: 3,
            },
            &heartbeat(),
        );
        assert!(sign_frame(&mut f, 50, key, link_id, ts));
        f
    }

    #[test]
    fn passphrase_key_is_sha256_of_the_text() {
        // SHA-256("abc"), the FIPS 180-2 test vector.
        let want = "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad";
        let k = SecretKey::from_passphrase("abc");
        let hex: String = k.as_bytes().iter().map(|b| format!("{b:02x}")).collect();
        assert_eq!(hex, want);
        assert_eq!(parse_key(&format!("hex:{want}")).unwrap(), k);
        assert_eq!(parse_key("abc").unwrap(), k);
    }

    #[test]
    fn key_specs_and_their_errors() {
        assert_eq!(
            parse_key_spec("file:/etc/k").unwrap(),
            KeySpec::File("/etc/k".into())
        );
        assert_eq!(parse_key_spec("file:"), Err(KeyError::NoPath));
        assert_eq!(parse_key(""), Err(KeyError::Empty));
        assert_eq!(parse_key("hex:12"), Err(KeyError::HexLength(2)));
        let mut bad = "ab".repeat(32);
        bad.replace_range(9..10, "g");
        assert_eq!(
            parse_key(&format!("hex:{bad}")),
            Err(KeyError::HexDigit(10))
        );
        assert_eq!(
            parse_key(&format!("hex:{}", "0".repeat(64))),
            Err(KeyError::Zero)
        );
        // The key never shows in messages or debug output.
        let k = SecretKey::from_bytes([0xAB; 32]);
        assert!(!format!("{k:?}").to_lowercase().contains("abab"));
        assert_eq!(k.id().len(), 6);
    }

    #[test]
    fn timestamps_count_10us_since_2015() {
        assert_eq!(timestamp_from_unix_micros(0), 0);
        assert_eq!(
            timestamp_from_unix_micros(EPOCH_UNIX_SECONDS * 1_000_000),
            0
        );
        // One day after the epoch: 86400 s = 8.64e9 units of 10 µs.
        assert_eq!(
            timestamp_from_unix_micros((EPOCH_UNIX_SECONDS + 86_400) * 1_000_000 + 15),
            8_640_000_001
        );
    }

    #[test]
    fn signed_frame_layout() {
        let key = SecretKey::from_passphrase("secret");
        let unsigned = encode(
            Version::V2,
            Header {
                sysid: 255,
                compid: 190,
                seq: 3,
            },
            &heartbeat(),
        );
        let f = signed_heartbeat(&key, 7, 0x0102_0304_0506);
        assert_eq!(f.len(), unsigned.len() + SIGNATURE_LEN);
        assert_eq!(f[2], IFLAG_SIGNED);
        // Same header and payload; the CRC covers the flag, so it changed.
        assert_eq!(f[3..unsigned.len() - 2], unsigned[3..unsigned.len() - 2]);
        let n = unsigned.len();
        let crc = frame_crc(&f[1..n - 2], 50);
        assert_eq!(f[n - 2..n], crc.to_le_bytes());
        assert_eq!(f[n], 7, "link id");
        assert_eq!(f[n + 1..n + 7], [6, 5, 4, 3, 2, 1], "48-bit timestamp, LE");
        let parsed = decode_one(&f).expect("our parser takes it");
        assert!(parsed.is_signed());
        assert_eq!(parsed.message.as_deref(), Some(&heartbeat()));
        let s = read_signature(&f).unwrap();
        assert_eq!((s.link_id, s.timestamp), (7, 0x0102_0304_0506));
        assert!(verify(&key, &f));
        // Not twice, and never MAVLink 1.
        let mut again = f.clone();
        assert!(!sign_frame(&mut again, 50, &key, 7, 1));
        assert_eq!(again, f);
        let mut v1 = encode(
            Version::V1,
            Header {
                sysid: 1,
                compid: 1,
                seq: 0,
            },
            &heartbeat(),
        );
        assert!(!sign_frame(&mut v1, 50, &key, 0, 1));
    }

    #[test]
    fn signature_agrees_with_the_mavlink_crate() {
        // The crate's own sha256_48 over its raw frame, an implementation independent of ours.
        let key = SecretKey::from_bytes(core::array::from_fn(|i| i as u8 * 7 + 1));
        for (link, ts) in [(0u8, 1u64), (3, 123_456_789_012), (255, MAX_TIMESTAMP)] {
            let f = signed_heartbeat(&key, link, ts);
            let mut raw = mavlink::MAVLinkV2MessageRaw::new();
            raw.as_mut_slice()[..f.len()].copy_from_slice(&f);
            let mut theirs = [0u8; SIGNATURE_VALUE_LEN];
            raw.calculate_signature(key.as_bytes(), &mut theirs);
            assert_eq!(theirs[..], f[f.len() - 6..], "link {link} ts {ts}");
            assert_eq!(raw.signature_timestamp(), ts);
            assert_eq!(raw.signature_link_id(), link);
        }
    }

    #[test]
    fn tampering_or_another_key_fails() {
        let key = SecretKey::from_passphrase("secret");
        let f = signed_heartbeat(&key, 0, 1000);
        assert!(!verify(&SecretKey::from_passphrase("Secret"), &f));
        for i in 0..f.len() {
            let mut t = f.clone();
            t[i] ^= 0x10; // keeps the signed flag (0x01) of byte 2
            assert!(!verify(&key, &t), "byte {i} changed");
        }
    }

    #[test]
    fn clock_never_goes_back() {
        let mut c = Clock::after(1000);
        assert_eq!(c.next(0), 1001);
        assert_eq!(c.next(500), 1002, "the wall clock behind: one more");
        assert_eq!(c.next(5000), 5000, "the wall clock ahead: its time");
        assert_eq!(c.next(5000), 5001, "two frames in the same 10 µs");
        c.observe(9000);
        assert_eq!(c.current(6000), 9000);
        assert_eq!(c.next(6000), 9001, "after a good incoming timestamp");
        c.observe(10);
        assert_eq!(c.last(), 9001);
    }

    #[test]
    fn streams_reject_replays_and_stale_new_streams() {
        let key = SecretKey::from_passphrase("secret");
        let mut s = Streams::default();
        let now = 100 * ONE_MINUTE;
        let at = |link, ts| signed_heartbeat(&key, link, ts);
        assert_eq!(
            s.check(&key, &at(0, now), 255, 190, now, now),
            Verdict::Good(now)
        );
        assert_eq!(
            s.check(&key, &at(0, now), 255, 190, now, now),
            Verdict::Replayed
        );
        assert_eq!(
            s.check(&key, &at(0, now - 1), 255, 190, now, now),
            Verdict::Replayed
        );
        assert_eq!(
            s.check(&key, &at(0, now + 1), 255, 190, now, now),
            Verdict::Good(now + 1)
        );
        // A new stream (another link id) exactly a minute behind is taken, more is not.
        assert_eq!(
            s.check(&key, &at(1, now - ONE_MINUTE - 1), 255, 190, now, now),
            Verdict::TooOld
        );
        assert_eq!(
            s.check(&key, &at(1, now - ONE_MINUTE), 255, 190, now, now),
            Verdict::Good(now - ONE_MINUTE)
        );
        // A bad signature leaves the stream as it was.
        let mut t = at(1, now + 50);
        t[12] ^= 1;
        assert_eq!(s.check(&key, &t, 255, 190, now, now), Verdict::BadSignature);
        assert_eq!(
            s.check(&key, &at(1, now - ONE_MINUTE + 1), 255, 190, now, now),
            Verdict::Good(now - ONE_MINUTE + 1)
        );
        assert_eq!(s.len(), 2);
    }

    #[test]
    fn timestamps_from_the_future_are_refused_and_move_nothing() {
        let key = SecretKey::from_passphrase("secret");
        let mut s = Streams::default();
        let wall = 100 * ONE_MINUTE;
        let at = |link, ts| signed_heartbeat(&key, link, ts);
        // The largest timestamp the field holds: refused, and told once for its stream.
        let end = at(0, MAX_TIMESTAMP);
        let future = |first| Verdict::Future {
            timestamp: MAX_TIMESTAMP,
            link_id: 0,
            first,
        };
        assert_eq!(s.check(&key, &end, 1, 1, wall, wall), future(true));
        assert_eq!(s.check(&key, &end, 1, 1, wall, wall), future(false));
        assert!(s.is_empty(), "no stream opened");
        // Normal frames of the same stream after it are taken.
        assert_eq!(
            s.check(&key, &at(0, wall), 1, 1, wall, wall),
            Verdict::Good(wall)
        );
        // Exactly the margin ahead is taken, one more is not; held against the wall clock, not
        // against our clock (which a taken frame raised: no ratchet).
        assert_eq!(
            s.check(&key, &at(0, wall + FUTURE_MARGIN), 1, 1, wall, wall),
            Verdict::Good(wall + FUTURE_MARGIN)
        );
        let current = wall + FUTURE_MARGIN;
        assert!(matches!(
            s.check(&key, &at(0, wall + FUTURE_MARGIN + 1), 1, 1, current, wall),
            // This stream was named already.
            Verdict::Future { first: false, .. }
        ));
        // A bad signature is a bad signature, whatever its timestamp.
        let mut t = at(0, MAX_TIMESTAMP);
        t[12] ^= 1;
        assert_eq!(s.check(&key, &t, 1, 1, wall, wall), Verdict::BadSignature);
        // Another stream is named once of its own.
        assert!(matches!(
            s.check(&key, &at(4, MAX_TIMESTAMP), 1, 1, wall, wall),
            Verdict::Future {
                link_id: 4,
                first: true,
                ..
            }
        ));
    }

    #[test]
    fn timestamps_read_as_dates_and_spans() {
        // 2^48-1 units of 10 µs after 2015-01-01 (Python: datetime(2015,1,1) + timedelta(µs=(2**48-1)*10)).
        let us = unix_micros_of(MAX_TIMESTAMP);
        let date = chrono::DateTime::from_timestamp_micros(us).unwrap();
        assert_eq!(date.format("%Y-%m-%d").to_string(), "2104-03-13");
        assert_eq!(timestamp_from_unix_micros(us), MAX_TIMESTAMP);
        assert_eq!(span_text(45 * 100_000), "45 s");
        assert_eq!(span_text(3600 * 100_000), "1 h 00 min");
        assert_eq!(span_text(MAX_TIMESTAMP), "89 years");
    }

    #[test]
    fn stream_table_is_bounded() {
        let key = SecretKey::from_passphrase("k");
        let mut s = Streams::default();
        for i in 0..(MAX_STREAMS + 10) {
            let f = signed_heartbeat(&key, (i % 256) as u8, 1000 + i as u64);
            // Other senders: vary the sysid through the table key instead of the frame bytes.
            let v = s.check(&key, &f, (i / 256) as u8 + 1, 1, 1000, 1000);
            assert_eq!(v, Verdict::Good(1000 + i as u64));
        }
        assert_eq!(s.len(), MAX_STREAMS);
        assert_eq!(s.evicted, 10);
    }

    #[test]
    fn state_round_trips_and_bad_state_is_told() {
        assert_eq!(decode_state(&encode_state(123_456)).unwrap(), 123_456);
        assert!(decode_state(b"{}").unwrap_err().contains("timestamp"));
        assert!(decode_state(b"garbage").unwrap_err().contains("not JSON"));
    }
}
