//! Parameters of one vehicle: the complete set downloaded fast and surely, kept per component,
//! and edits confirmed by the vehicle's echo.
//!
//! **Download** ([`ParamMachine::fetch`], on the first heartbeat and on demand):
//! - MAVFTP first: `@PARAM/param.pck` read by [`FtpRead`] (burst, gaps re-read). Used unless
//!   AUTOPILOT_VERSION says the vehicle has no FTP; a NAK or a timeout falls back to the
//!   parameter protocol. A file whose blocks do not join (packed at different moments while the
//!   vehicle's values settle after boot) is read again at once, then without defaults
//!   ([`crate::proto::param_ftp::pck_reread_path`]), before falling back. PARAM_VALUEs heard
//!   during the read are applied over the file.
//! - The parameter protocol: PARAM_REQUEST_LIST, PARAM_VALUE collected by `param_index`. When
//!   new indices stop arriving for a gap adapted to their measured arrival rate, the missing ones
//!   are asked for with PARAM_REQUEST_READ, [`READ_WINDOW`] in flight, each retried on a timeout
//!   from the measured round trip, or at once when a read sent after it is answered first (the
//!   vehicle answers reads in order), up to [`READ_TRIES`] times. A `param_count` that changes
//!   resizes the set; duplicates only refresh a value; PARAM_VALUE with index 65535 (ArduPilot's
//!   answer to PARAM_SET and its notice of a value changed by anyone) updates by name.
//!
//! **Values**: integer types ride in the float either C-cast (ArduPilot) or bytewise (the
//! protocol's default: PX4 and everyone else), see [`crate::params::value`]. The encoding is the
//! HEARTBEAT autopilot's profile's unless AUTOPILOT_VERSION announces PARAM_ENCODE_BYTEWISE or
//! PARAM_ENCODE_C_CAST, or the operator chose one (`param encoding`); the float as received is
//! kept so a later choice can re-read every value. A float that cannot be an integer sent so
//! (C-cast: NaN, infinite, a fraction, a denormal) is told once: the encoding looks wrong.
//!
//! **Edits** ([`ParamMachine::set`]): PARAM_SET with the parameter's type and encoding; a value
//! the encoding cannot carry exactly is refused before it is sent. The vehicle answers with
//! PARAM_VALUE even when it refused the write, so an edit is confirmed only by an echo whose
//! float has the very bits sent (not only a value that decodes the same). No echo: resent up to [`SET_RESENDS`] times. An echo of another
//! value: resent once (it may have been a stale PARAM_VALUE already on its way), then failed.
//!
//! Sans-I/O: payloads and time in, [`ParamOut`] out, [`ParamMachine::next_deadline`].

use std::collections::BTreeMap;

use crate::clock::{Micros, SECOND};
use crate::dialect::{self, MavAutopilot, MavMessage, MavParamType};
use crate::params::value::{self, Encoding, ParamType};
use crate::proto::machine::{Ids, Incoming, Machine, Out};
use crate::proto::param_ftp::{FtpOut, FtpRead};
use crate::proto::vehicles::VehicleKey;
use crate::wire::mavftp::{FtpPacket, PAYLOAD_LEN};
use crate::wire::param_pck::{self, PckType};
use crate::wire::payload::Payload;
use crate::wire::Severity;
use mavlink::MessageData;

/// What is read over MAVFTP from ArduPilot (its profile's parameter file).
pub const PCK_PATH: &str = crate::proto::profile::ARDUPILOT_PARAM_FILE;
/// PARAM_REQUEST_READs in flight at once while filling gaps.
pub const READ_WINDOW: usize = 12;
/// Reads of one index before the download gives up on it.
pub const READ_TRIES: u32 = 10;
/// PARAM_REQUEST_LIST attempts when nothing at all comes back.
pub const LIST_TRIES: u32 = 3;
/// PARAM_SET resends when no echo comes.
pub const SET_RESENDS: u32 = 3;
/// PARAM_SETs waiting for their echo at once; more wait their turn (a file applied at once
/// must not flood a radio).
pub const SET_WINDOW: usize = 8;
/// Refused parameter names told per component; the rest are counted ([`ParamSet::refused`]).
pub const MAX_REFUSED_TOLD: u64 = 3;
/// MAV_PROTOCOL_CAPABILITY bits read from AUTOPILOT_VERSION.
pub const CAP_PARAM_ENCODE_BYTEWISE: u64 = 16;
pub const CAP_FTP: u64 = 32;
pub const CAP_PARAM_ENCODE_C_CAST: u64 = 131_072;

const MS: Micros = 1_000;
const LIST_WAIT: Micros = 1_500 * MS;
const INITIAL_RTO: Micros = 1_000 * MS;
const MIN_RTO: Micros = 200 * MS;
const MAX_RTO: Micros = 4 * SECOND;
const MIN_GAP: Micros = 150 * MS;
const MAX_GAP: Micros = 2 * SECOND;

/// An edit of one parameter and how it stands.
#[derive(Debug, Clone, PartialEq)]
pub struct Edit {
    pub value: f64,
    pub state: EditState,
    /// The float of the last PARAM_SET sent, bit for bit: the echo must carry these bits (not
    /// a re-encoding under the encoding known when the echo comes).
    sent: Option<f32>,
    sends: u32,
    mismatch_resent: bool,
    sent_at: Micros,
}

#[derive(Debug, Clone, PartialEq)]
pub enum EditState {
    Pending,
    Confirmed,
    Failed(String),
}

/// A parameter's name as the key of [`ParamSet::params`]: at most 16 bytes of UTF-8 without NUL
/// (the most PARAM_VALUE's `param_id` and param.pck carry), held in place (no allocation, 17
/// bytes, so a search of the map reads few cache lines). Ordered exactly as its string, so it is
/// looked up by `&str` too; its bytes compare as one number.
#[derive(Clone, Copy)]
pub struct ParamName {
    len: u8,
    /// The name, zero-padded.
    bytes: [u8; 16],
}

impl ParamName {
    /// The key of a name; `None` for one longer than 16 bytes or holding a NUL (no parameter
    /// can have it).
    pub fn new(name: &str) -> Option<ParamName> {
        Self::of_text(name.as_bytes())
    }

    /// The key of a name's bytes: `None` unless they are a name [`ParamName::new`] takes.
    pub fn probe_bytes(name: &[u8]) -> Option<ParamName> {
        // Names are ASCII: one pass says it is text without NUL.
        if !name.iter().all(|&b| (1..0x80).contains(&b)) {
            std::str::from_utf8(name).ok()?;
        }
        Self::of_text(name)
    }

    /// `name` is UTF-8.
    fn of_text(name: &[u8]) -> Option<ParamName> {
        if name.len() > 16 || name.contains(&0) {
            return None;
        }
        let mut bytes = [0u8; 16];
        bytes[..name.len()].copy_from_slice(name);
        Some(ParamName {
            len: name.len() as u8,
            bytes,
        })
    }

    pub fn as_str(&self) -> &str {
        let b = &self.bytes[..self.len as usize];
        // SAFETY: made only of a `&str` or of bytes checked to be UTF-8 (`new`, `probe_bytes`).
        unsafe { std::str::from_utf8_unchecked(b) }
    }

    /// The bytes as one number: with no NUL in a name, its zero padding sorts as the end of the
    /// string does, so the numbers order as the strings (and are equal only for equal strings).
    #[inline]
    fn number(&self) -> u128 {
        u128::from_be_bytes(self.bytes)
    }
}

impl Ord for ParamName {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        // Equal numbers are equal names (no NUL in a name, so the padding starts at its end).
        self.number().cmp(&other.number())
    }
}

impl PartialOrd for ParamName {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl PartialEq for ParamName {
    fn eq(&self, other: &Self) -> bool {
        self.len == other.len && self.bytes == other.bytes
    }
}

impl Eq for ParamName {}

impl std::hash::Hash for ParamName {
    fn hash<H: std::hash::Hasher>(&self, h: &mut H) {
        self.as_str().hash(h)
    }
}

impl std::borrow::Borrow<str> for ParamName {
    fn borrow(&self) -> &str {
        self.as_str()
    }
}

impl std::ops::Deref for ParamName {
    type Target = str;
    fn deref(&self) -> &str {
        self.as_str()
    }
}

impl std::fmt::Display for ParamName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Display::fmt(self.as_str(), f)
    }
}

impl std::fmt::Debug for ParamName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Debug::fmt(self.as_str(), f)
    }
}

/// One parameter as the vehicle last told it.
#[derive(Debug, Clone, PartialEq)]
pub struct Param {
    pub value: f64,
    pub ptype: ParamType,
    /// The float as received (re-read if the encoding turns out otherwise); `None` for a value
    /// MAVFTP's param.pck gave, typed and exact whatever the encoding.
    raw: Option<f32>,
    pub index: Option<u16>,
    /// The value when the set was downloaded, for the changed-since-download mark.
    pub fetched: Option<f64>,
    /// The default, when MAVFTP's param.pck carried it.
    pub default: Option<f64>,
    /// Boxed: few parameters have one, and every parameter is smaller without it in place.
    pub edit: Option<Box<Edit>>,
}

impl Param {
    pub fn changed_since_fetch(&self) -> bool {
        self.fetched
            .is_some_and(|f| !value::same(f, self.value, self.ptype))
    }

    pub fn text(&self) -> String {
        value::format(self.value, self.ptype)
    }
}

/// Parameters by name, each at a slot a value heard by index finds again.
pub type ParamMap = super::slot_map::SlotMap<ParamName, Param>;

/// The parameters of one component.
#[derive(Debug, Clone, Default)]
pub struct ParamSet {
    /// By name (the order people look them up in).
    pub params: ParamMap,
    /// Name at each index (empty: a name refused); as long as the count.
    names: Vec<Option<ParamName>>,
    /// The slot in `params` of the name last heard at each index (checked when used; `u32::MAX`:
    /// none yet), so a value heard by index finds its parameter without a search. As long as
    /// `names`.
    slots: Vec<u32>,
    /// How many the component says it has.
    pub count: Option<u16>,
    received: usize,
    /// Values refused for their name (not 1–16 printable ASCII without spaces, `#` or `,`):
    /// their index counts as received, so a download does not wait for them.
    pub refused: u64,
}

impl ParamSet {
    /// Parameters received of those the component has.
    pub fn progress(&self) -> (usize, Option<u16>) {
        (self.received, self.count)
    }

    pub fn complete(&self) -> bool {
        self.count.is_some_and(|c| self.received >= c as usize)
    }

    /// Indices not yet received.
    pub fn missing(&self) -> impl Iterator<Item = u16> + '_ {
        self.names
            .iter()
            .enumerate()
            .filter(|(_, n)| n.is_none())
            .map(|(i, _)| i as u16)
    }

    pub fn get(&self, name: &str) -> Option<&Param> {
        self.params.get(name)
    }

    fn resize(&mut self, count: u16) {
        if self.count == Some(count) {
            return;
        }
        let n = count as usize;
        self.slots.resize(n, u32::MAX);
        if n < self.names.len() {
            for name in self.names.drain(n..).flatten() {
                if self.params.get(&name).is_some_and(|p| p.index.is_some()) {
                    self.params.remove(&name);
                }
                self.received -= 1;
            }
        } else {
            self.names.resize(n, None);
        }
        self.count = Some(count);
    }

    /// Record a value at `index` (or by name only when `index` is `None`). Returns the value it
    /// had, if it had one. A name no parameter can have (over 16 bytes, a NUL) is not recorded.
    fn record(
        &mut self,
        name: &str,
        index: Option<u16>,
        ptype: ParamType,
        raw: Option<f32>,
        v: f64,
        download: bool,
    ) -> Option<f64> {
        let key = ParamName::new(name)?;
        if !self.note_index(key, index) {
            return None;
        }
        let slot = self.place(key, index, || Param::heard(ptype, raw, index, v));
        self.params
            .at_mut(slot)
            .apply(index, ptype, raw, v, download)
    }

    /// The slot of `key`, heard at `index`: found by the slot that index had (no search) when
    /// that still holds it, else by name; made with `heard` when new. The slot is remembered for
    /// the index.
    fn place(&mut self, key: ParamName, index: Option<u16>, heard: impl FnOnce() -> Param) -> u32 {
        let at = index.map(|i| i as usize).filter(|&i| i < self.slots.len());
        let hint = at.map(|i| self.slots[i]).filter(|&s| s != u32::MAX);
        let slot = match self.params.slot(&key, hint) {
            Some(s) => s,
            None => self.params.insert_at(key, heard()),
        };
        if let Some(i) = at {
            self.slots[i] = slot;
        }
        slot
    }

    /// `name` heard at `index`: the index taken (another name there before is gone). False when
    /// the index is beyond the count (nothing is recorded then).
    fn note_index(&mut self, name: ParamName, index: Option<u16>) -> bool {
        let Some(i) = index else {
            return true;
        };
        let i = i as usize;
        if i >= self.names.len() {
            return false;
        }
        match self.names[i] {
            Some(old) if old == name => {}
            Some(old) => {
                // Another name at this index (the set changed): the old one is gone.
                self.params.remove(&old);
                self.names[i] = Some(name);
            }
            None => {
                self.names[i] = Some(name);
                self.received += 1;
            }
        }
        true
    }
}

impl Param {
    /// A parameter first heard with this value.
    fn heard(ptype: ParamType, raw: Option<f32>, index: Option<u16>, v: f64) -> Param {
        Param {
            value: v,
            ptype,
            raw,
            index,
            fetched: None,
            default: None,
            edit: None,
        }
    }

    /// Take a value heard (at `index`, or by name only); the value it had, if it had one.
    fn apply(
        &mut self,
        index: Option<u16>,
        ptype: ParamType,
        raw: Option<f32>,
        v: f64,
        download: bool,
    ) -> Option<f64> {
        let before = self.value;
        let had = self.fetched.is_some() || self.edit.is_some() || index.is_none();
        self.value = v;
        self.ptype = ptype;
        self.raw = raw;
        if index.is_some() {
            self.index = index;
        }
        if download && self.fetched.is_none() {
            self.fetched = Some(v);
        }
        had.then_some(before)
    }
}

/// How a download went, for the operator and the benchmark.
#[derive(Debug, Clone, PartialEq)]
pub struct DownloadStats {
    pub component: u8,
    pub method: Method,
    pub started: Micros,
    pub finished: Option<Micros>,
    /// Requests sent (FTP packets, PARAM_REQUEST_LIST and PARAM_REQUEST_READ), retries included.
    pub requests: u32,
    pub retries: u32,
    /// Why MAVFTP was left for the parameter protocol.
    pub fallback: Option<String>,
    /// Parameters still missing when it gave up (0 when complete).
    pub missing: usize,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    Ftp,
    List,
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::Ftp => "MAVFTP",
            Method::List => "parameter protocol",
        }
    }
}

#[derive(Debug, Clone)]
enum Phase {
    Ftp(Box<FtpRead>),
    List(ListDownload),
}

#[derive(Debug, Clone, Default)]
struct ListDownload {
    list_sent: Micros,
    list_tries: u32,
    /// When a new index last arrived, and the smoothed time between new indices.
    last_new: Option<Micros>,
    interval: Option<Micros>,
    filling: bool,
    /// Index → (sent at, tries, order sent) of PARAM_REQUEST_READs in flight.
    reads: BTreeMap<u16, (Micros, u32, u64)>,
    sent: u64,
    tries: BTreeMap<u16, u32>,
    /// This list pass: when its first new index came, and how many new ones came.
    pass_start: Option<Micros>,
    pass_new: usize,
    /// List passes asked for (the first included).
    passes: u32,
    /// Reads: when filling started and how many were answered, for their rate.
    fill_start: Option<Micros>,
    fill_answered: usize,
    /// The list stream (arrivals that answer no read): when it last brought a new index, and
    /// the highest index it brought.
    last_stream: Option<Micros>,
    stream_front: Option<u16>,
}

/// PARAM_VALUEs kept while MAVFTP reads (a vehicle notifies what it saves: a few dozen at boot).
const MAX_HEARD: usize = 4096;

/// List passes at most (the first and two more).
pub const LIST_PASSES: u32 = 3;
/// Reads answered per second before any is measured: ArduPilot answers at most 5 per 100 ms.
const READ_RATE_GUESS: f64 = 50.0;

impl ListDownload {
    /// Whether asking for the whole list again is faster than reading `missing` one by one:
    /// a pass takes `count` at the rate the list came; reads come at their own rate (ArduPilot
    /// caps them at 50/s whatever the link; on a slow radio both share the link).
    fn relist_is_faster(&self, now: Micros, missing: usize, count: usize) -> bool {
        if self.passes >= LIST_PASSES || missing * 4 < count / 10 {
            return false;
        }
        let (Some(start), Some(last)) = (self.pass_start, self.last_new) else {
            return false;
        };
        if self.pass_new < 20 || last <= start {
            return false;
        }
        let list_rate = self.pass_new as f64 / ((last - start) as f64 / SECOND as f64);
        let read_rate = match self.fill_start {
            Some(f) if self.fill_answered >= 10 && now > f => {
                self.fill_answered as f64 / ((now - f) as f64 / SECOND as f64)
            }
            _ => READ_RATE_GUESS,
        };
        count as f64 / list_rate < missing as f64 / read_rate
    }
}

#[derive(Debug, Clone)]
struct Download {
    comp: u8,
    phase: Phase,
    stats: DownloadStats,
    /// The MAVFTP file being read, and the complete reads of it that did not decode.
    ftp_path: &'static str,
    ftp_reads: u32,
    /// PARAM_VALUEs heard while MAVFTP reads (values the vehicle saved meanwhile, newer than the
    /// file's blocks packed before): applied over the file once it decodes.
    heard: Vec<(String, ParamType, f32, f64)>,
}

/// What the machine wants done.
#[derive(Debug, Clone, PartialEq)]
#[allow(clippy::large_enum_variant)]
pub enum ParamOut {
    Send(MavMessage),
    Notice(Severity, String),
    /// The outcome of an edit of `name` of component `comp`, and its notice.
    Set {
        comp: u8,
        name: String,
        confirmed: bool,
        notice: (Severity, String),
    },
}

/// A PARAM_VALUE read from its payload (so a type code newer than the dialect still reads).
#[derive(Debug, Clone, PartialEq)]
pub struct ParamValueMsg<'a> {
    pub raw: f32,
    pub count: u16,
    pub index: u16,
    /// The name's bytes as sent, to the first zero (borrowed from the payload).
    pub id: &'a [u8],
    pub type_code: u8,
    /// The name is not a parameter name: [`ParamValueMsg::name`] shows its bytes escaped.
    pub refused: bool,
    /// The name as a key, when it is not refused.
    pub key: Option<ParamName>,
}

/// The bytes [`crate::wire::param_pck::name_byte_ok`] takes, as the bits of a number (none is
/// above 127).
const NAME_BYTES: u128 = {
    let mut bits = 0u128;
    let mut b = 0;
    while b < 128 {
        if crate::wire::param_pck::name_byte_ok(b as u8) {
            bits |= 1 << b;
        }
        b += 1;
    }
    bits
};

/// [`crate::wire::param_pck::name_byte_ok`] by one shift.
#[inline]
fn name_byte(b: u8) -> bool {
    b < 128 && NAME_BYTES >> b & 1 == 1
}

/// Where the first zero byte is in `bytes` (16 when none is): eight bytes at a time.
#[inline]
fn first_zero(bytes: &[u8; 16]) -> usize {
    const ONES: u64 = 0x0101_0101_0101_0101;
    const HIGHS: u64 = 0x8080_8080_8080_8080;
    for (i, word) in bytes.chunks_exact(8).enumerate() {
        let w = u64::from_le_bytes(word.try_into().expect("8 bytes"));
        // The lowest flagged byte is the first zero (flags above it may be false).
        let zeros = w.wrapping_sub(ONES) & !w & HIGHS;
        if zeros != 0 {
            return i * 8 + zeros.trailing_zeros() as usize / 8;
        }
    }
    16
}

impl<'a> ParamValueMsg<'a> {
    /// Wire order: param_value f32, param_count u16, param_index u16, param_id char[16],
    /// param_type u8; MAVLink 2 may have cut trailing zeros. A name that is not a parameter
    /// name ([`crate::wire::param_pck::name_ok`]) is still read, `refused`.
    pub fn parse(payload: &'a [u8]) -> Option<ParamValueMsg<'a>> {
        let p = Payload(payload);
        // The name's bytes as sent (MAVLink 2 may have cut its trailing zeros), to the first
        // zero, found a word at a time; each byte checked without stopping early.
        let sent = payload.get(8..payload.len().min(24)).unwrap_or(&[]);
        let mut padded = [0u8; 16];
        match sent.try_into() {
            // All 16 sent (the usual case: param_type follows, and it is never 0).
            Ok(all) => padded = all,
            Err(_) => padded[..sent.len()].copy_from_slice(sent),
        }
        let len = first_zero(&padded);
        let id = &sent[..len];
        let bad = id.iter().fold(false, |bad, &b| bad | !name_byte(b));
        let refused = bad || id.is_empty();
        // What follows the first zero is not the name: the key is zero-padded from there.
        let keep = u128::MAX.checked_shr(128 - 8 * len as u32).unwrap_or(0);
        let padded = (u128::from_le_bytes(padded) & keep).to_le_bytes();
        Some(ParamValueMsg {
            raw: p.f32(0),
            count: p.u16(4),
            index: p.u16(6),
            id,
            type_code: p.u8(24),
            refused,
            key: (!refused).then_some(ParamName {
                len: len as u8,
                bytes: padded,
            }),
        })
    }

    /// The name: a parameter name as it is (printable ASCII), a refused one's bytes quoted and
    /// escaped for the operator.
    pub fn name(&self) -> std::borrow::Cow<'a, str> {
        match std::str::from_utf8(self.id) {
            Ok(name) if !self.refused => std::borrow::Cow::Borrowed(name),
            _ => std::borrow::Cow::Owned(escaped(self.id)),
        }
    }
}

/// Bytes as a quoted string, those that are not printable ASCII as `\n`, `\t` or `\xNN`.
pub fn escaped(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(bytes.len() + 2);
    s.push('"');
    for &b in bytes {
        match b {
            b'\n' => s.push_str("\\n"),
            b'\t' => s.push_str("\\t"),
            b'"' | b'\\' => {
                s.push('\\');
                s.push(b as char);
            }
            0x20..=0x7e => s.push(b as char),
            _ => s.push_str(&format!("\\x{b:02x}")),
        }
    }
    s.push('"');
    s
}

/// The parameter machines of one vehicle (its autopilot and the components of its system).
#[derive(Debug, Clone)]
pub struct ParamMachine {
    key: VehicleKey,
    pub encoding: Encoding,
    /// Who chose the encoding.
    pub encoding_by: EncodingBy,
    /// The first value that could not be what the vehicle holds under the encoding, told once
    /// (until the encoding changes): `NAME: why; ENCODING it would be V`.
    pub encoding_suspect: Option<String>,
    /// The MAVFTP file holding the whole set, if the autopilot's family serves one.
    param_file: Option<&'static str>,
    /// The last MAVFTP read once it is over (finished, failed or given up): a late open ACK
    /// still gets its session closed.
    ftp_closed: Option<(u8, Box<FtpRead>)>,
    /// Whether AUTOPILOT_VERSION said FTP is there, once it said anything.
    ftp_capable: Option<bool>,
    pub sets: BTreeMap<u8, ParamSet>,
    download: Option<Download>,
    /// The last download that ended.
    pub last: Option<DownloadStats>,
    /// Fetch on the first poll (the first heartbeat).
    auto: bool,
    /// The first fetch waits: the vehicle is heard on no link that may carry automatic traffic
    /// (only on high-latency ones).
    auto_held: bool,
    /// The running (or last) download was started by the machine, not by the operator: its
    /// traffic is automatic.
    auto_started: bool,
    /// REQUEST_MESSAGE(AUTOPILOT_VERSION) sent, and when to ask again if it does not come.
    version_asked: u32,
    version_retry: Option<Micros>,
    /// When the first request for AUTOPILOT_VERSION went, for a first round trip.
    version_sent: Option<Micros>,
    /// Smoothed round trip of reads and edits (RFC 6298).
    rtt: crate::proto::rtt::Rtt,
    /// Pending edit deadlines come from `Edit::sent_at`.
    edits_pending: usize,
}

/// Who chose how integer parameters are read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EncodingBy {
    /// The autopilot family's default.
    Profile,
    /// AUTOPILOT_VERSION's PARAM_ENCODE_* bit.
    Capability,
    /// The operator, at the prompt.
    Operator,
}

impl EncodingBy {
    pub fn name(self) -> &'static str {
        match self {
            EncodingBy::Profile => "the autopilot's default",
            EncodingBy::Capability => "AUTOPILOT_VERSION",
            EncodingBy::Operator => "the operator",
        }
    }
}

fn pck_type(t: PckType) -> ParamType {
    match t {
        PckType::Int8 => ParamType::Int8,
        PckType::Int16 => ParamType::Int16,
        PckType::Int32 => ParamType::Int32,
        PckType::Float => ParamType::Real32,
    }
}

fn param_id(name: &str) -> mavlink::types::CharArray<16> {
    name.into()
}

impl ParamMachine {
    pub fn new(key: VehicleKey, autopilot: MavAutopilot, auto_fetch: bool) -> Self {
        let profile = crate::proto::profile::of(autopilot);
        Self {
            key,
            encoding: profile.param_encoding(),
            encoding_by: EncodingBy::Profile,
            encoding_suspect: None,
            param_file: profile.param_file(),
            ftp_closed: None,
            ftp_capable: None,
            sets: BTreeMap::new(),
            download: None,
            last: None,
            auto: auto_fetch,
            auto_held: false,
            auto_started: false,
            version_asked: 0,
            version_retry: None,
            version_sent: None,
            rtt: Default::default(),
            edits_pending: 0,
        }
    }

    /// The autopilot's set, if any came.
    pub fn autopilot(&self) -> Option<&ParamSet> {
        self.sets.get(&self.key.1)
    }

    /// The running download: (component, received, count, method).
    pub fn downloading(&self) -> Option<(u8, usize, Option<u16>, Method)> {
        let d = self.download.as_ref()?;
        let (got, count) = self
            .sets
            .get(&d.comp)
            .map(|s| s.progress())
            .unwrap_or((0, None));
        if let Phase::Ftp(f) = &d.phase {
            // Over MAVFTP parameters come all at once at the end: show the bytes' share.
            let (bytes, size) = f.progress();
            // Never more than the file can hold: a record is at least 4 bytes after the
            // header's 6 (a count in a hostile header says nothing).
            let total = count.or(self.ftp_total(f)).map(|t| match size {
                Some(s) => t.min((s.saturating_sub(6) / 4).min(u16::MAX as u32) as u16),
                None => t,
            });
            let shown = match (total, size) {
                (Some(t), Some(s)) if s > 0 => {
                    ((bytes as f64 / s as f64).min(1.0) * t as f64) as usize
                }
                _ => 0,
            };
            return Some((
                d.comp,
                shown.min(total.map_or(0, |t| t as usize)),
                total,
                Method::Ftp,
            ));
        }
        Some((d.comp, got, count, d.stats.method))
    }

    fn ftp_total(&self, f: &FtpRead) -> Option<u16> {
        f.head()
            .filter(|h| h.len() >= 6)
            .map(|h| u16::from_le_bytes([h[4], h[5]]))
    }

    fn rto(&self) -> Micros {
        self.rtt.rto(INITIAL_RTO, MIN_RTO, MAX_RTO)
    }

    fn sample_rtt(&mut self, rtt: Micros) {
        self.rtt.sample(rtt);
    }

    /// Hold (or release) the download that starts on its own: held while the vehicle is heard
    /// only on high-latency links.
    pub fn hold_auto(&mut self, held: bool) {
        self.auto_held = held;
    }

    /// True while the download the machine started on its own runs (its traffic is automatic:
    /// never on a high-latency link).
    pub fn auto_download(&self) -> bool {
        self.auto_started && self.download.is_some()
    }

    /// True while a download runs or an edit waits for its echo.
    pub fn busy(&self) -> bool {
        self.download.is_some() || self.edits_pending > 0
    }

    /// Start (or start over) downloading component `comp`'s parameters.
    pub fn fetch(&mut self, now: Micros, comp: u8) -> Vec<ParamOut> {
        self.auto = false;
        self.auto_started = false;
        let mut out = self.leave_ftp();
        if self.version_asked == 0 {
            self.version_asked = 1;
            self.version_retry = Some(now + SECOND);
            self.version_sent = Some(now);
            out.push(ParamOut::Send(request_autopilot_version(self.key)));
        }
        let mut stats = DownloadStats {
            component: comp,
            method: Method::Ftp,
            started: now,
            finished: None,
            requests: 0,
            retries: 0,
            fallback: None,
            missing: 0,
        };
        // Only the autopilot serves param.pck; a component answers the parameter protocol.
        let file = self.param_file.filter(|_| comp == self.key.1);
        let try_ftp = file.is_some() && self.ftp_capable != Some(false);
        let ftp_path = file.unwrap_or_default();
        let phase = if let Some(path) = file.filter(|_| try_ftp) {
            let (f, o) = FtpRead::start(now, path);
            out.extend(self.ftp_out(comp, o));
            Phase::Ftp(Box::new(f))
        } else {
            stats.method = Method::List;
            if file.is_some() {
                stats.fallback = Some("AUTOPILOT_VERSION announces no MAVFTP".into());
            }
            out.push(self.list_request(comp));
            Phase::List(ListDownload {
                list_sent: now,
                list_tries: 1,
                passes: 1,
                ..Default::default()
            })
        };
        if let Phase::List(_) = phase {
            stats.requests += 1;
        }
        self.sets.entry(comp).or_default();
        self.download = Some(Download {
            comp,
            phase,
            stats,
            ftp_path,
            ftp_reads: 0,
            heard: Vec::new(),
        });
        out
    }

    fn list_request(&self, comp: u8) -> ParamOut {
        ParamOut::Send(MavMessage::PARAM_REQUEST_LIST(
            dialect::PARAM_REQUEST_LIST_DATA {
                target_system: self.key.0,
                target_component: comp,
            },
        ))
    }

    fn ftp_out(&self, comp: u8, o: Vec<FtpOut>) -> Vec<ParamOut> {
        o.into_iter()
            .filter_map(|o| match o {
                FtpOut::Send(p) => Some(ParamOut::Send(MavMessage::FILE_TRANSFER_PROTOCOL(
                    dialect::FILE_TRANSFER_PROTOCOL_DATA {
                        target_network: 0,
                        target_system: self.key.0,
                        target_component: comp,
                        payload: p.to_payload(),
                    },
                ))),
                _ => None,
            })
            .collect()
    }

    /// Hand FTP output on; a finished transfer is decoded, a failed one falls back.
    fn on_ftp_out(&mut self, now: Micros, o: Vec<FtpOut>) -> Vec<ParamOut> {
        let Some(d) = self.download.as_ref() else {
            return Vec::new();
        };
        let comp = d.comp;
        let mut out = self.ftp_out(comp, o.clone());
        for r in o {
            match r {
                FtpOut::Send(_) => {}
                FtpOut::Done(bytes) => match param_pck::decode(&bytes) {
                    Ok(file) if file.num_params == file.total_params => {
                        self.take_ftp_stats();
                        let heard = self
                            .download
                            .as_mut()
                            .map(|d| std::mem::take(&mut d.heard))
                            .unwrap_or_default();
                        let set = self.sets.entry(comp).or_default();
                        *set = ParamSet::default();
                        set.resize(file.total_params);
                        for (i, p) in file.params.iter().enumerate() {
                            let t = pck_type(p.ptype);
                            set.record(&p.name, Some(i as u16), t, None, p.value, true);
                            if let Some(prm) = set.params.get_mut(p.name.as_str()) {
                                prm.default = p.default;
                            }
                        }
                        for (name, t, raw, v) in heard {
                            if set.params.contains_key(name.as_str()) {
                                set.record(&name, None, t, Some(raw), v, false);
                            }
                        }
                        out.extend(self.check_done(now));
                    }
                    Ok(file) => {
                        let why = format!(
                            "param.pck holds {} of {} parameters",
                            file.num_params, file.total_params
                        );
                        out.extend(self.fall_back(now, why));
                    }
                    Err(e) => out.extend(self.read_pck_again(now, e.to_string())),
                },
                FtpOut::Failed(why) => out.extend(self.fall_back(now, why)),
            }
        }
        out
    }

    fn take_ftp_stats(&mut self) {
        if let Some(d) = self.download.as_mut() {
            if let Phase::Ftp(f) = &d.phase {
                d.stats.requests += f.stats.requests;
                d.stats.retries += f.stats.retries;
            }
        }
    }

    /// The running download's MAVFTP read is over: closed (TerminateSession unless it closed
    /// itself) and kept to close a session a late open ACK reports.
    fn leave_ftp(&mut self) -> Vec<ParamOut> {
        let Some(d) = self.download.as_mut() else {
            return Vec::new();
        };
        let comp = d.comp;
        let Phase::Ftp(f) = &mut d.phase else {
            return Vec::new();
        };
        let o = f.abandon();
        let f = f.clone();
        self.ftp_closed = Some((comp, f));
        self.ftp_out(comp, o)
    }

    /// Every block of param.pck came but they do not make a file (blocks packed at different
    /// moments, see [`crate::proto::param_ftp::pck_reread_path`]): read it again, or fall back.
    fn read_pck_again(&mut self, now: Micros, why: String) -> Vec<ParamOut> {
        let Some(d) = self.download.as_mut() else {
            return Vec::new();
        };
        d.ftp_reads += 1;
        let Some(path) = crate::proto::param_ftp::pck_reread_path(d.ftp_path, d.ftp_reads) else {
            return self.fall_back(now, why);
        };
        self.take_ftp_stats();
        let Some(d) = self.download.as_mut() else {
            return Vec::new();
        };
        d.ftp_path = path;
        d.stats.retries += 1;
        let comp = d.comp;
        let (mut f, o) = FtpRead::start(now, path);
        f.set_open_tries(crate::proto::param_ftp::OPEN_TRIES_ANNOUNCED);
        d.phase = Phase::Ftp(Box::new(f));
        tracing::debug!("parameters: {why}; reading {path} again");
        self.ftp_out(comp, o)
    }

    /// MAVFTP did not work: the parameter protocol.
    fn fall_back(&mut self, now: Micros, why: String) -> Vec<ParamOut> {
        self.take_ftp_stats();
        let mut out = self.leave_ftp();
        let Some(d) = self.download.as_mut() else {
            return Vec::new();
        };
        d.stats.method = Method::List;
        d.stats.fallback = Some(why.clone());
        d.stats.requests += 1;
        d.phase = Phase::List(ListDownload {
            list_sent: now,
            list_tries: 1,
            passes: 1,
            ..Default::default()
        });
        let comp = d.comp;
        out.push(ParamOut::Notice(
            Severity::INFO,
            format!("parameters: {why}; using the parameter protocol"),
        ));
        out.push(self.list_request(comp));
        out
    }

    /// AUTOPILOT_VERSION's capability bits (the first 8 bytes of its payload).
    /// An answer to our first AUTOPILOT_VERSION request (its COMMAND_ACK or the message) came:
    /// the first round trip, before any parameter traffic was answered. MAVFTP's open is retried
    /// after a few of them rather than after a blind second.
    pub fn on_version_answer(&mut self, now: Micros) {
        let Some(sent) = self.version_sent.take() else {
            return;
        };
        if self.version_asked != 1 {
            return; // asked again: which request this answers is unknown (Karn)
        }
        let rtt = now.saturating_sub(sent);
        if !self.rtt.is_measured() {
            self.sample_rtt(rtt);
        }
        if let Some(Download {
            phase: Phase::Ftp(f),
            ..
        }) = self.download.as_mut()
        {
            f.rtt_hint(rtt);
        }
    }

    pub fn on_autopilot_version(&mut self, now: Micros, caps: u64) -> Vec<ParamOut> {
        self.on_version_answer(now);
        let enc = if caps & CAP_PARAM_ENCODE_C_CAST != 0 {
            Some(Encoding::CCast)
        } else if caps & CAP_PARAM_ENCODE_BYTEWISE != 0 {
            Some(Encoding::Bytewise)
        } else {
            None
        };
        if let Some(e) = enc.filter(|_| self.encoding_by != EncodingBy::Operator) {
            self.encoding_by = EncodingBy::Capability;
            self.reread(e);
        }
        let ftp = caps & CAP_FTP != 0;
        self.ftp_capable = Some(ftp);
        self.version_retry = None;
        // A vehicle that says it has FTP is worth more tries to open the file.
        if let Some(Download {
            phase: Phase::Ftp(f),
            ..
        }) = self.download.as_mut()
        {
            if ftp {
                f.set_open_tries(crate::proto::param_ftp::OPEN_TRIES_ANNOUNCED);
            }
        }
        // Still waiting for an FTP answer from a vehicle that says it has no FTP: stop waiting.
        let waiting = self.download.as_ref().is_some_and(|d| match &d.phase {
            Phase::Ftp(f) => f.progress().0 == 0 && !f.finished(),
            _ => false,
        });
        if !ftp && waiting {
            return self.fall_back(now, "AUTOPILOT_VERSION announces no MAVFTP".into());
        }
        Vec::new()
    }

    /// Read integers `e`'s way from now on; every value already heard is re-read from the float
    /// as it came.
    fn reread(&mut self, e: Encoding) {
        if e == self.encoding {
            return;
        }
        self.encoding = e;
        self.encoding_suspect = None;
        for set in self.sets.values_mut() {
            for p in set.params.values_mut() {
                let Some(raw) = p.raw else {
                    continue; // from param.pck: exact already
                };
                let v = value::decode(raw, p.ptype, e);
                if let Some(f) = p.fetched.as_mut().filter(|f| **f == p.value) {
                    *f = v;
                }
                p.value = v;
            }
        }
    }

    /// The operator's choice of encoding (`param encoding`): it stands over AUTOPILOT_VERSION
    /// and the profile.
    pub fn choose_encoding(&mut self, e: Encoding) {
        self.encoding_by = EncodingBy::Operator;
        self.reread(e);
    }

    /// A FILE_TRANSFER_PROTOCOL payload from component `from`.
    pub fn on_ftp(&mut self, now: Micros, from: u8, payload: &[u8]) -> Vec<ParamOut> {
        let mut p = [0u8; PAYLOAD_LEN];
        let n = payload.len().min(PAYLOAD_LEN);
        p[..n].copy_from_slice(&payload[..n]);
        let packet = FtpPacket::parse(&p);
        let running = self
            .download
            .as_mut()
            .filter(|d| d.comp == from)
            .and_then(|d| match &mut d.phase {
                Phase::Ftp(f) => Some(f),
                Phase::List(_) => None,
            });
        if let Some(f) = running {
            let o = f.on_packet(now, &packet);
            return self.on_ftp_out(now, o);
        }
        // A read that is over: only a late open ACK matters (its session is closed).
        match self.ftp_closed.as_mut().filter(|(c, _)| *c == from) {
            Some((_, f)) => {
                let o = f.on_packet(now, &packet);
                self.ftp_out(from, o)
            }
            None => Vec::new(),
        }
    }

    /// A PARAM_VALUE payload from component `from`.
    pub fn on_param_value(&mut self, now: Micros, from: u8, payload: &[u8]) -> Vec<ParamOut> {
        let Some(m) = ParamValueMsg::parse(payload) else {
            return Vec::new();
        };
        let Some(ptype) = ParamType::from_code(m.type_code) else {
            return vec![ParamOut::Notice(
                Severity::WARNING,
                format!("{}: unknown parameter type {}", m.name(), m.type_code),
            )];
        };
        let enc = self.encoding;
        let v = value::decode(m.raw, ptype, enc);
        let mut out = Vec::new();
        if self.encoding_suspect.is_none() && !m.refused {
            if let Some(why) = value::implausible(m.raw, ptype, enc) {
                let other = enc.other();
                let would = value::format(value::decode(m.raw, ptype, other), ptype);
                let text = format!(
                    "{}: {why}, which no {} sent {} can be; {} it would be {would}",
                    m.name(),
                    ptype.name(),
                    enc.name(),
                    other.name()
                );
                out.push(ParamOut::Notice(
                    Severity::WARNING,
                    format!(
                        "parameters of {}:{from}: the encoding looks wrong ({text}): `param encoding {}` switches",
                        self.key.0,
                        other.cli_name()
                    ),
                ));
                self.encoding_suspect = Some(text);
            }
        }
        let downloading = self
            .download
            .as_ref()
            .is_some_and(|d| d.comp == from && matches!(d.phase, Phase::List(_)));
        if let Some(d) = self
            .download
            .as_mut()
            .filter(|d| d.comp == from && matches!(d.phase, Phase::Ftp(_)) && !m.refused)
        {
            if d.heard.len() < MAX_HEARD {
                d.heard.push((m.name().into_owned(), ptype, m.raw, v));
            }
        }
        let set = self.sets.entry(from).or_default();
        let index = (m.index != u16::MAX).then_some(m.index);
        if index.is_some() && m.count != u16::MAX {
            let before = set.count;
            set.resize(m.count);
            if before.is_some_and(|b| b != m.count) {
                out.push(ParamOut::Notice(
                    Severity::NOTICE,
                    format!(
                        "{} now has {} parameters (was {})",
                        VehicleKey(self.key.0, from),
                        m.count,
                        before.unwrap_or(0)
                    ),
                ));
            }
        }
        let new_index = index
            .is_some_and(|i| (i as usize) < set.names.len() && set.names[i as usize].is_none());
        if m.refused {
            set.refused += 1;
            if new_index {
                // Taken as heard (under no name): the download does not wait for it.
                if let Some(i) = index {
                    set.names[i as usize] = ParamName::new("");
                    set.received += 1;
                }
            }
            if set.refused <= MAX_REFUSED_TOLD {
                out.push(ParamOut::Notice(
                    Severity::WARNING,
                    format!(
                        "{}:{from} parameter name refused (not 1-16 printable ASCII without \
                         spaces, # or ,): {}{}",
                        self.key.0,
                        m.name(),
                        if set.refused == MAX_REFUSED_TOLD {
                            " (further ones counted only)"
                        } else {
                            ""
                        }
                    ),
                ));
            }
            out.extend(self.after_value(now, from, index, new_index));
            return out;
        }
        // A name not refused is 1–16 printable ASCII: always a key.
        let Some(key) = m.key else {
            return out;
        };
        // Recorded, and the parameter found for what follows: by the slot its index had (no
        // search) when that still holds it.
        let recorded = set.note_index(key, index);
        let slot = if recorded {
            Some(set.place(key, index, || Param::heard(ptype, Some(m.raw), index, v)))
        } else {
            set.params.slot(&key, None)
        };
        let Some(slot) = slot else {
            return out;
        };
        let p = set.params.at_mut(slot);
        let before = recorded
            .then(|| p.apply(index, ptype, Some(m.raw), v, downloading))
            .flatten();
        // An edit waiting for its echo.
        let mut resend = None;
        let mut rtt_sample = None;
        if let Some(e) = p
            .edit
            .as_mut()
            .filter(|e| e.state == EditState::Pending && e.sends > 0)
        {
            // The float's very bits as sent: a value that only decodes the same is not what
            // was sent.
            let sent = e
                .sent
                .unwrap_or_else(|| value::encode(e.value, ptype, enc))
                .to_bits();
            if m.raw.to_bits() == sent {
                e.state = EditState::Confirmed;
                self.edits_pending -= 1;
                if e.sends == 1 {
                    rtt_sample = Some(now.saturating_sub(e.sent_at));
                }
                out.push(ParamOut::Set {
                    comp: from,
                    name: m.name().into_owned(),
                    confirmed: true,
                    notice: (
                        Severity::INFO,
                        format!("{} = {} confirmed", m.name(), value::format(v, ptype)),
                    ),
                });
            } else if !e.mismatch_resent {
                e.mismatch_resent = true;
                e.sends += 1;
                e.sent_at = now;
                let f = value::encode(e.value, ptype, enc);
                e.sent = Some(f);
                resend = Some((f, ptype));
            } else {
                let why = if value::same(v, e.value, ptype) {
                    format!(
                        "not confirmed: the echo's float {:#010x} is not the {:#010x} sent",
                        m.raw.to_bits(),
                        sent
                    )
                } else {
                    format!("refused: the vehicle kept {}", value::format(v, ptype))
                };
                out.push(ParamOut::Set {
                    comp: from,
                    name: m.name().into_owned(),
                    confirmed: false,
                    notice: (
                        Severity::ERROR,
                        format!("{} = {} {why}", m.name(), value::format(e.value, ptype)),
                    ),
                });
                e.state = EditState::Failed(why);
                self.edits_pending -= 1;
            }
        } else if index.is_none() && !m.id.starts_with(b"STAT_") {
            // A change nobody here asked for: another GCS, or the vehicle itself (calibration
            // offsets, ground pressure, counters: ArduPilot sends many at boot and after
            // calibrations, so they are told at DEBUG; the Parameters screen marks them, and
            // STAT_ statistics, which change all flight long, are left out).
            if let Some(b) = before.filter(|b| !value::same(*b, v, ptype)) {
                out.push(ParamOut::Notice(
                    Severity::DEBUG,
                    format!(
                        "{} changed to {} (was {})",
                        m.name(),
                        value::format(v, ptype),
                        value::format(b, ptype)
                    ),
                ));
            }
        }
        if let Some(rtt) = rtt_sample {
            self.sample_rtt(rtt);
        }
        if let Some((val, t)) = resend {
            out.push(ParamOut::Send(self.param_set(from, &m.name(), val, t)));
        }
        out.extend(self.send_queued(now));
        out.extend(self.after_value(now, from, index, new_index));
        out
    }

    /// The download after a value at `index` of `from` (`new_index`: not heard before): a read
    /// answered, the arrival rate, completion.
    fn after_value(
        &mut self,
        now: Micros,
        from: u8,
        index: Option<u16>,
        new_index: bool,
    ) -> Vec<ParamOut> {
        let mut out = Vec::new();
        let mut rtt_read = None;
        if let Some(d) = self.download.as_mut().filter(|d| d.comp == from) {
            if let (Phase::List(l), Some(i)) = (&mut d.phase, index) {
                let answered_read = l.reads.contains_key(&i);
                if !answered_read && new_index {
                    l.last_stream = Some(now);
                    l.stream_front = Some(l.stream_front.map_or(i, |f| f.max(i)));
                }
                if let Some((sent, tries, order)) = l.reads.remove(&i) {
                    // Only a read asked once says which request this answers (Karn): then its
                    // round trip counts, and the reads sent before it that are still
                    // unanswered were lost (the vehicle answers in order): asked again now.
                    if tries == 1 {
                        rtt_read = Some(now.saturating_sub(sent));
                        l.reads.retain(|_, r| r.2 > order);
                    }
                }
                if new_index {
                    l.pass_start.get_or_insert(now);
                    l.pass_new += 1;
                    if l.filling {
                        l.fill_answered += 1;
                    }
                    if let Some(last) = l.last_new {
                        let gap = now.saturating_sub(last);
                        l.interval = Some(match l.interval {
                            None => gap,
                            Some(iv) => (7 * iv + gap) / 8,
                        });
                    }
                    l.last_new = Some(now);
                }
            }
            if let Some(rtt) = rtt_read {
                self.sample_rtt(rtt);
            }
            out.extend(self.check_done(now));
            if let Some(Download {
                phase: Phase::List(l),
                ..
            }) = &self.download
            {
                if l.filling {
                    out.extend(self.fill(now));
                }
            }
        }
        out
    }

    /// Finish the download when its set is whole.
    fn check_done(&mut self, now: Micros) -> Vec<ParamOut> {
        let Some(d) = self.download.as_ref() else {
            return Vec::new();
        };
        let Some(set) = self.sets.get(&d.comp) else {
            return Vec::new();
        };
        if !set.complete() {
            return Vec::new();
        }
        let count = set.count.unwrap_or(0);
        let mut d = self.download.take().expect("checked above");
        d.stats.finished = Some(now);
        let secs = (now - d.stats.started) as f64 / SECOND as f64;
        let text = format!(
            "parameters of {}: {count}/{count} in {secs:.1} s by {}",
            VehicleKey(self.key.0, d.comp),
            d.stats.method.name()
        );
        self.last = Some(d.stats);
        vec![ParamOut::Notice(Severity::INFO, text)]
    }

    /// Ask for missing indices, [`READ_WINDOW`] in flight.
    fn fill(&mut self, now: Micros) -> Vec<ParamOut> {
        let sys = self.key.0;
        let Some(d) = self.download.as_mut() else {
            return Vec::new();
        };
        let comp = d.comp;
        let Phase::List(l) = &mut d.phase else {
            return Vec::new();
        };
        let Some(set) = self.sets.get(&comp) else {
            return Vec::new();
        };
        let mut out = Vec::new();
        let mut gave_up = false;
        // What the list has passed and not brought was lost: read at once. What lies ahead of
        // its front is on its way while the list may still be coming (a slow radio's queue
        // holds it back now and then; reading ahead would only take the vehicle's budget from
        // the list): read only once the list has been silent for a while.
        let streaming = l
            .last_stream
            .is_some_and(|t| now < t + ahead_wait(l.interval));
        let front = l.stream_front.filter(|_| streaming);
        for i in set.missing() {
            if l.reads.len() >= READ_WINDOW || front.is_some_and(|f| i > f) {
                break;
            }
            if l.reads.contains_key(&i) {
                continue;
            }
            let t = l.tries.entry(i).or_insert(0);
            if *t >= READ_TRIES {
                gave_up = true;
                continue;
            }
            *t += 1;
            if *t > 1 {
                d.stats.retries += 1;
            }
            d.stats.requests += 1;
            l.sent += 1;
            l.reads.insert(i, (now, *t, l.sent));
            out.push(ParamOut::Send(MavMessage::PARAM_REQUEST_READ(
                dialect::PARAM_REQUEST_READ_DATA {
                    param_index: i as i16,
                    target_system: sys,
                    target_component: comp,
                    param_id: param_id(""),
                },
            )));
        }
        if gave_up && l.reads.is_empty() {
            let missing = set.missing().count();
            let count = set.count.unwrap_or(0);
            let mut d = self.download.take().expect("checked above");
            d.stats.missing = missing;
            d.stats.finished = Some(now);
            self.last = Some(d.stats);
            out.push(ParamOut::Notice(
                Severity::ERROR,
                format!(
                    "parameters of {}:{comp}: {} of {count} never came ({} asked {READ_TRIES} times)",
                    sys,
                    missing,
                    if missing == 1 { "it was" } else { "each" }
                ),
            ));
        }
        out
    }

    /// Set `name` of component `comp` to `v`.
    pub fn set(
        &mut self,
        now: Micros,
        comp: u8,
        name: &str,
        v: f64,
    ) -> Result<Vec<ParamOut>, String> {
        let set = self
            .sets
            .get_mut(&comp)
            .ok_or_else(|| format!("no parameters of {}:{comp} yet", self.key.0))?;
        let p = set
            .params
            .get_mut(name)
            .ok_or_else(|| format!("no parameter {name}"))?;
        p.ptype.check(v)?;
        value::carry_check(v, p.ptype, self.encoding)?;
        if p.edit
            .as_ref()
            .is_some_and(|e| e.state == EditState::Pending)
        {
            self.edits_pending -= 1;
        }
        p.edit = Some(Box::new(Edit {
            value: v,
            state: EditState::Pending,
            sent: None,
            sends: 0,
            mismatch_resent: false,
            sent_at: now,
        }));
        self.edits_pending += 1;
        Ok(self.send_queued(now))
    }

    /// Edits in flight (sent, no echo yet).
    fn edits_in_flight(&self) -> usize {
        self.sets
            .values()
            .flat_map(|s| s.params.values())
            .filter_map(|p| p.edit.as_ref())
            .filter(|e| e.state == EditState::Pending && e.sends > 0)
            .count()
    }

    /// Send edits waiting their turn while fewer than [`SET_WINDOW`] are in flight.
    fn send_queued(&mut self, now: Micros) -> Vec<ParamOut> {
        if self.edits_pending == 0 {
            return Vec::new();
        }
        let mut room = SET_WINDOW.saturating_sub(self.edits_in_flight());
        let enc = self.encoding;
        let mut go = Vec::new();
        for (comp, s) in self.sets.iter_mut() {
            for (name, p) in s.params.iter_mut() {
                if room == 0 {
                    break;
                }
                let t = p.ptype;
                if let Some(e) = p
                    .edit
                    .as_mut()
                    .filter(|e| e.state == EditState::Pending && e.sends == 0)
                {
                    e.sends = 1;
                    e.sent_at = now;
                    let f = value::encode(e.value, t, enc);
                    e.sent = Some(f);
                    room -= 1;
                    go.push((*comp, *name, f, t));
                }
            }
        }
        go.into_iter()
            .map(|(c, n, v, t)| ParamOut::Send(self.param_set(c, &n, v, t)))
            .collect()
    }

    /// PARAM_SET of `name` carrying the float `f` (the value already encoded).
    fn param_set(&self, comp: u8, name: &str, f: f32, t: ParamType) -> MavMessage {
        use num_traits::FromPrimitive;
        MavMessage::PARAM_SET(dialect::PARAM_SET_DATA {
            param_value: f,
            target_system: self.key.0,
            target_component: comp,
            param_id: param_id(name),
            param_type: MavParamType::from_u8(t.code())
                .unwrap_or(MavParamType::MAV_PARAM_TYPE_REAL32),
        })
    }

    pub fn next_deadline(&self) -> Option<Micros> {
        if self.auto && !self.auto_held {
            return Some(0);
        }
        let rto = self.rto();
        let mut t: Option<Micros> = None;
        let mut at = |d: Micros| t = Some(t.map_or(d, |x| x.min(d)));
        if let Some(v) = self.version_retry {
            at(v);
        }
        if let Some(d) = &self.download {
            match &d.phase {
                Phase::Ftp(f) => {
                    if let Some(x) = f.next_deadline() {
                        at(x)
                    }
                }
                Phase::List(l) => {
                    if l.last_new.is_none()
                        && self.sets.get(&d.comp).is_none_or(|s| s.count.is_none())
                    {
                        at(l.list_sent + (LIST_WAIT << (l.list_tries - 1).min(3)));
                    } else if !l.filling {
                        at(l.last_new.unwrap_or(l.list_sent) + gap(l.interval));
                    } else if let (Some(t), Some(front)) = (l.last_stream, l.stream_front) {
                        // Reads ahead of the list's front wait for its silence.
                        let ahead = self
                            .sets
                            .get(&d.comp)
                            .is_some_and(|s| s.missing().any(|i| i > front));
                        if ahead && l.reads.is_empty() {
                            at(t + ahead_wait(l.interval));
                        }
                    }
                    for (sent, tries, _) in l.reads.values() {
                        at(sent + (rto << (tries - 1).min(3)));
                    }
                }
            }
        }
        if self.edits_pending > 0 {
            for s in self.sets.values() {
                for p in s.params.values() {
                    if let Some(e) = p
                        .edit
                        .as_ref()
                        .filter(|e| e.state == EditState::Pending && e.sends > 0)
                    {
                        at(e.sent_at + rto.max(SECOND));
                    }
                }
            }
        }
        t
    }

    pub fn poll(&mut self, now: Micros) -> Vec<ParamOut> {
        let mut out = Vec::new();
        if self.auto && !self.auto_held {
            out.extend(self.fetch(now, self.key.1));
            self.auto_started = true;
        }
        let rto = self.rto();
        if self.version_retry.is_some_and(|v| now >= v) {
            // AUTOPILOT_VERSION did not come: ask again, three times in all.
            self.version_asked += 1;
            self.version_retry = (self.version_asked < 3).then_some(now + 2 * SECOND);
            out.push(ParamOut::Send(request_autopilot_version(self.key)));
        }
        // Edits without an echo.
        if self.edits_pending > 0 {
            let enc = self.encoding;
            let mut resend = Vec::new();
            for (comp, s) in self.sets.iter_mut() {
                for (name, p) in s.params.iter_mut() {
                    let t = p.ptype;
                    let Some(e) = p
                        .edit
                        .as_mut()
                        .filter(|e| e.state == EditState::Pending && e.sends > 0)
                    else {
                        continue;
                    };
                    if now < e.sent_at + rto.max(SECOND) {
                        continue;
                    }
                    if e.sends > SET_RESENDS {
                        let why = format!("no answer after {} tries", e.sends);
                        out.push(ParamOut::Set {
                            comp: *comp,
                            name: name.to_string(),
                            confirmed: false,
                            notice: (
                                Severity::ERROR,
                                format!("{name} = {}: {why}", value::format(e.value, t)),
                            ),
                        });
                        e.state = EditState::Failed(why);
                        self.edits_pending -= 1;
                    } else {
                        e.sends += 1;
                        e.sent_at = now;
                        let f = value::encode(e.value, t, enc);
                        e.sent = Some(f);
                        resend.push((*comp, *name, f, t));
                    }
                }
            }
            for (comp, name, v, t) in resend {
                out.push(ParamOut::Send(self.param_set(comp, &name, v, t)));
            }
            out.extend(self.send_queued(now));
        }
        let Some(d) = self.download.as_mut() else {
            return out;
        };
        let comp = d.comp;
        match &mut d.phase {
            Phase::Ftp(f) => {
                let o = f.poll(now);
                out.extend(self.on_ftp_out(now, o));
            }
            Phase::List(l) => {
                let got_any =
                    l.last_new.is_some() || self.sets.get(&comp).is_some_and(|s| s.count.is_some());
                if !got_any {
                    if now >= l.list_sent + (LIST_WAIT << (l.list_tries - 1).min(3)) {
                        if l.list_tries >= LIST_TRIES {
                            let d = self.download.take().expect("present");
                            let mut stats = d.stats;
                            stats.finished = Some(now);
                            self.last = Some(stats);
                            out.push(ParamOut::Notice(
                                Severity::ERROR,
                                format!(
                                    "parameters of {}:{comp}: no answer to PARAM_REQUEST_LIST",
                                    self.key.0
                                ),
                            ));
                            return out;
                        }
                        l.list_tries += 1;
                        l.list_sent = now;
                        d.stats.requests += 1;
                        d.stats.retries += 1;
                        out.push(self.list_request(comp));
                    }
                    return out;
                }
                // Reads that timed out go again.
                l.reads
                    .retain(|_, (sent, tries, _)| now < *sent + (rto << (*tries - 1).min(3)));
                if !l.filling && now >= l.last_new.unwrap_or(l.list_sent) + gap(l.interval) {
                    let (missing, count) = self.sets.get(&comp).map_or((0, 0), |s| {
                        (s.missing().count(), s.count.unwrap_or(0) as usize)
                    });
                    if l.relist_is_faster(now, missing, count) {
                        // Many missing on a fast link: another pass of the list.
                        l.passes += 1;
                        l.list_sent = now;
                        l.last_new = Some(now);
                        l.pass_start = None;
                        l.pass_new = 0;
                        d.stats.requests += 1;
                        d.stats.retries += 1;
                        out.push(self.list_request(comp));
                        return out;
                    }
                    l.filling = true;
                    l.fill_start = Some(now);
                }
                if l.filling {
                    out.extend(self.fill(now));
                }
            }
        }
        out
    }
}

/// How long the list must be silent before the indices ahead of its front are read.
fn ahead_wait(interval: Option<Micros>) -> Micros {
    (4 * gap(interval)).max(SECOND)
}

/// How long without a new index before the list is taken as ended: several times the measured
/// time between indices.
fn gap(interval: Option<Micros>) -> Micros {
    match interval {
        Some(i) => (10 * i).clamp(MIN_GAP, MAX_GAP),
        None => 4 * MIN_GAP,
    }
}

/// MAV_CMD_REQUEST_MESSAGE for AUTOPILOT_VERSION (148).
fn request_autopilot_version(key: VehicleKey) -> MavMessage {
    MavMessage::COMMAND_LONG(dialect::COMMAND_LONG_DATA {
        param1: 148.0,
        param2: 0.0,
        param3: 0.0,
        param4: 0.0,
        param5: 0.0,
        param6: 0.0,
        param7: 0.0,
        command: dialect::MavCmd::MAV_CMD_REQUEST_MESSAGE,
        target_system: key.0,
        target_component: key.1,
        confirmation: 0,
    })
}

impl ParamMachine {
    /// Its output in the one contract: what belongs to a download it started on its own is
    /// automatic traffic; an edit (PARAM_SET) is always the operator's.
    pub fn out(&self, o: ParamOut) -> Out {
        use crate::proto::machine::{MachineEvent, Route};
        match o {
            ParamOut::Send(m @ MavMessage::PARAM_SET(_)) => Out::send(Route::Vehicle, m),
            ParamOut::Send(m) if self.auto_download() => Out::send(Route::Auto, m),
            ParamOut::Send(m) => Out::send(Route::Vehicle, m),
            ParamOut::Notice(s, t) => Out::notice(s, t),
            ParamOut::Set {
                comp,
                name,
                confirmed,
                notice: (s, t),
            } => Out::Event(MachineEvent::ParamSet {
                comp,
                name,
                confirmed,
                notice: (s, t),
            }),
        }
    }

    fn emit(&self, o: ParamOut, out: &mut Vec<Out>) {
        out.push(self.out(o));
    }
}

impl Machine for ParamMachine {
    const IDS: Ids = Ids::Only(&[
        dialect::PARAM_VALUE_DATA::ID,
        dialect::FILE_TRANSFER_PROTOCOL_DATA::ID,
        dialect::AUTOPILOT_VERSION_DATA::ID,
        dialect::COMMAND_ACK_DATA::ID,
    ]);
    /// PARAM_VALUE, FILE_TRANSFER_PROTOCOL and AUTOPILOT_VERSION are read from their payloads,
    /// the ACK as [`Incoming::ack`].
    const DECODES: Ids = Ids::Only(&[]);

    /// Parameters are kept per component of the system; AUTOPILOT_VERSION (and the ACK of our
    /// request for it) only from the autopilot.
    fn on_message(&mut self, m: &Incoming, out: &mut Vec<Out>) {
        let (now, from) = (m.now, m.from.1);
        let o = match m.id {
            dialect::PARAM_VALUE_DATA::ID => self.on_param_value(now, from, m.payload),
            // target_network, target_system, target_component, then the FTP payload.
            dialect::FILE_TRANSFER_PROTOCOL_DATA::ID if m.payload.len() > 3 => {
                self.on_ftp(now, from, &m.payload[3..])
            }
            // Capabilities u64 first.
            dialect::AUTOPILOT_VERSION_DATA::ID if from == self.key.1 => {
                self.on_autopilot_version(now, Payload(m.payload).u64(0))
            }
            _ => Vec::new(),
        };
        for o in o {
            self.emit(o, out);
        }
        // The COMMAND_ACK of our AUTOPILOT_VERSION request: a first round trip.
        if m.ack.is_some_and(|a| {
            from == self.key.1 && a.command == dialect::MavCmd::MAV_CMD_REQUEST_MESSAGE as u16
        }) {
            self.on_version_answer(now);
        }
    }

    fn poll(&mut self, now: Micros, out: &mut Vec<Out>) {
        for o in ParamMachine::poll(self, now) {
            self.emit(o, out);
        }
    }

    fn next_deadline(&self) -> Option<Micros> {
        ParamMachine::next_deadline(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const KEY: VehicleKey = VehicleKey(1, 1);

    /// A PARAM_VALUE payload as it goes on the wire (MAVLink 2 trailing zeros cut).
    fn pv(name: &str, raw: f32, t: u8, count: u16, index: u16) -> Vec<u8> {
        let mut p = Vec::new();
        p.extend_from_slice(&raw.to_le_bytes());
        p.extend_from_slice(&count.to_le_bytes());
        p.extend_from_slice(&index.to_le_bytes());
        let mut id = [0u8; 16];
        id[..name.len()].copy_from_slice(name.as_bytes());
        p.extend_from_slice(&id);
        p.push(t);
        while p.last() == Some(&0) {
            p.pop();
        }
        p
    }

    fn sends(out: &[ParamOut]) -> Vec<&MavMessage> {
        out.iter()
            .filter_map(|o| match o {
                ParamOut::Send(m) => Some(m),
                _ => None,
            })
            .collect()
    }

    /// A machine past MAVFTP (the vehicle said it has none), listing.
    fn listing() -> ParamMachine {
        let mut m = ParamMachine::new(KEY, MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA, true);
        m.poll(0);
        let out = m.on_autopilot_version(1_000, 8192);
        assert!(sends(&out)
            .iter()
            .any(|s| matches!(s, MavMessage::PARAM_REQUEST_LIST(_))));
        m
    }

    #[test]
    fn parse_reads_a_cut_payload() {
        let payload = pv("ABC", 0.0, 9, 5, 0);
        let m = ParamValueMsg::parse(&payload).unwrap();
        assert_eq!(
            (m.name().as_ref(), m.count, m.index, m.type_code),
            ("ABC", 5, 0, 9)
        );
        // No name at all is refused, not dropped.
        assert!(ParamValueMsg::parse(&[]).unwrap().refused);
    }

    #[test]
    fn a_gap_is_asked_for_by_index_and_in_order_loss_is_resent_at_once() {
        let mut m = listing();
        let mut t = 10_000;
        // 0..10 of 12 arrive except 3 and 7, 20 ms apart; 10 and 11 never do.
        for i in (0..10).filter(|i| *i != 3 && *i != 7) {
            m.on_param_value(t, 1, &pv(&format!("P{i}"), i as f32, 9, 12, i));
            t += 20_000;
        }
        let d = m.next_deadline().unwrap();
        // The gap adapts to the 20 ms between arrivals: 10 × 20 ms.
        assert_eq!(d, t - 20_000 + 200_000);
        let out = m.poll(d);
        let reads: Vec<i16> = sends(&out)
            .iter()
            .filter_map(|s| match s {
                MavMessage::PARAM_REQUEST_READ(r) => Some(r.param_index),
                _ => None,
            })
            .collect();
        // The holes the list passed; 10 and 11, ahead of its front, may still be coming.
        assert_eq!(reads, vec![3, 7]);
        // 7 answered before 3: 3's request or answer was lost, and is asked again at once.
        let out = m.on_param_value(d + 5_000, 1, &pv("P7", 7.0, 9, 12, 7));
        let again: Vec<i16> = sends(&out)
            .iter()
            .filter_map(|s| match s {
                MavMessage::PARAM_REQUEST_READ(r) => Some(r.param_index),
                _ => None,
            })
            .collect();
        assert_eq!(again, vec![3]);
        m.on_param_value(d + 6_000, 1, &pv("P3", 3.0, 9, 12, 3));
        // Once the list has been silent for a while, what lies ahead of it is read too.
        let d2 = m.next_deadline().unwrap();
        assert!(d2 >= t - 20_000 + SECOND, "{d2}");
        let out = m.poll(d2);
        let ahead: Vec<i16> = sends(&out)
            .iter()
            .filter_map(|s| match s {
                MavMessage::PARAM_REQUEST_READ(r) => Some(r.param_index),
                _ => None,
            })
            .collect();
        assert_eq!(ahead, vec![10, 11]);
        for i in [10u16, 11] {
            m.on_param_value(d2 + 6_000, 1, &pv(&format!("P{i}"), i as f32, 9, 12, i));
        }
        let set = m.autopilot().unwrap();
        assert!(set.complete());
        assert_eq!(m.last.as_ref().unwrap().missing, 0);
        assert_eq!(m.last.as_ref().unwrap().retries, 1);
    }

    #[test]
    fn count_changes_resize_and_shrink_drops_the_tail() {
        let mut m = listing();
        m.on_param_value(10, 1, &pv("A", 1.0, 9, 3, 0));
        m.on_param_value(20, 1, &pv("B", 1.0, 9, 3, 1));
        m.on_param_value(30, 1, &pv("C", 1.0, 9, 3, 2));
        assert!(m.last.is_some());
        // The vehicle now says 2: C is gone.
        let out = m.on_param_value(40, 1, &pv("A", 1.0, 9, 2, 0));
        assert!(out.iter().any(
            |o| matches!(o, ParamOut::Notice(_, t) if t.contains("now has 2 parameters (was 3)"))
        ));
        let set = m.autopilot().unwrap();
        assert_eq!(set.progress(), (2, Some(2)));
        assert!(set.get("C").is_none());
    }

    #[test]
    fn unsolicited_changes_update_by_name_and_are_told() {
        let mut m = listing();
        m.on_param_value(10, 1, &pv("A", 1.0, 9, 2, 0));
        m.on_param_value(20, 1, &pv("STAT_RUNTIME", 5.0, 6, 2, 1));
        let out = m.on_param_value(30, 1, &pv("A", 2.5, 9, 2, 65535));
        assert!(out
            .iter()
            .any(|o| matches!(o, ParamOut::Notice(_, t) if t == "A changed to 2.5 (was 1)")));
        let p = m.autopilot().unwrap().get("A").unwrap();
        assert_eq!((p.value, p.index, p.fetched), (2.5, Some(0), Some(1.0)));
        assert!(p.changed_since_fetch());
        // Statistics change all flight long: kept quiet.
        let out = m.on_param_value(40, 1, &pv("STAT_RUNTIME", 6.0, 6, 2, 65535));
        assert!(out.is_empty());
    }

    #[test]
    fn edits_wait_their_turn_eight_at_a_time() {
        let mut m = listing();
        for i in 0..20u16 {
            m.on_param_value(10, 1, &pv(&format!("P{i:02}"), 0.0, 2, 20, i));
        }
        let mut sent = 0;
        for i in 0..20 {
            sent += sends(&m.set(100, 1, &format!("P{i:02}"), 1.0).unwrap()).len();
        }
        assert_eq!(sent, SET_WINDOW);
        // One echo lets one more go.
        let out = m.on_param_value(200, 1, &pv("P00", 1.0, 2, 20, 65535));
        assert_eq!(sends(&out).len(), 1);
        assert_eq!(
            m.autopilot()
                .unwrap()
                .get("P00")
                .unwrap()
                .edit
                .as_ref()
                .unwrap()
                .state,
            EditState::Confirmed
        );
        // Out of range for INT8: refused before sending.
        assert!(m.set(300, 1, "P01", 128.0).is_err());
    }

    #[test]
    fn bytewise_values_are_reread_when_autopilot_version_says_so() {
        let mut m = ParamMachine::new(KEY, MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA, false);
        m.on_param_value(10, 1, &pv("I", f32::from_bits(123_456_789), 6, 1, 0));
        // C-cast first (ArduPilot heartbeat): the float's tiny value truncates to 0.
        assert_eq!(m.autopilot().unwrap().get("I").unwrap().value, 0.0);
        m.on_autopilot_version(20, CAP_PARAM_ENCODE_BYTEWISE);
        let p = m.autopilot().unwrap().get("I").unwrap();
        assert_eq!(p.value, 123_456_789.0);
        // The edit goes bytewise too.
        let out = m.set(30, 1, "I", -1.0).unwrap();
        match sends(&out)[0] {
            MavMessage::PARAM_SET(s) => {
                assert_eq!(s.param_value.to_bits(), u32::MAX);
                assert_eq!(s.param_type, MavParamType::MAV_PARAM_TYPE_INT32);
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn no_answer_to_the_list_ends_incomplete() {
        let mut m = listing();
        let mut now = 1_000;
        for _ in 0..10 {
            let Some(d) = m.next_deadline() else { break };
            now = d.max(now);
            m.poll(now);
        }
        let last = m.last.as_ref().unwrap();
        // MAVFTP's terminate and open, then the list asked LIST_TRIES times.
        assert_eq!(last.requests, 2 + LIST_TRIES);
        assert_eq!(last.retries, LIST_TRIES - 1);
        assert!(!m.autopilot().unwrap().complete());
    }

    #[test]
    fn the_echo_is_checked_against_the_bits_sent_across_an_encoding_switch() {
        // C-cast (ArduPilot heartbeat): INT32 7 goes out as the float 7.0 (0x40e00000).
        let mut m = ParamMachine::new(KEY, MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA, false);
        m.on_param_value(10, 1, &pv("I", 5.0, 6, 1, 0));
        let out = m.set(20, 1, "I", 7.0).unwrap();
        let sent = match sends(&out)[0] {
            MavMessage::PARAM_SET(s) => s.param_value.to_bits(),
            other => panic!("{other:?}"),
        };
        assert_eq!(sent, 0x40e0_0000);
        // AUTOPILOT_VERSION then says bytewise: the echo of what was sent is still ours.
        m.on_autopilot_version(30, CAP_PARAM_ENCODE_BYTEWISE);
        let out = m.on_param_value(40, 1, &pv("I", f32::from_bits(0x40e0_0000), 6, 1, 0));
        assert!(sends(&out).is_empty(), "no resend: {out:?}");
        assert_eq!(
            m.autopilot()
                .unwrap()
                .get("I")
                .unwrap()
                .edit
                .as_ref()
                .unwrap()
                .state,
            EditState::Confirmed
        );
        // The other way: an echo carrying the bytewise re-encoding (0x00000007) of the same
        // value is not the float sent: it is sent again.
        let mut m = ParamMachine::new(KEY, MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA, false);
        m.on_param_value(10, 1, &pv("I", 5.0, 6, 1, 0));
        m.set(20, 1, "I", 7.0).unwrap();
        m.on_autopilot_version(30, CAP_PARAM_ENCODE_BYTEWISE);
        let out = m.on_param_value(40, 1, &pv("I", f32::from_bits(7), 6, 1, 0));
        assert_eq!(sends(&out).len(), 1, "{out:?}");
    }

    /// The name read from every kind of `param_id` (cut short, zero-terminated with bytes after
    /// the zero, bytes no name may hold, 16 bytes with no zero): refused exactly when the bytes to
    /// the first zero are not a name by [`crate::wire::param_pck::name_ok`], and keyed as
    /// [`ParamName::new`] keys them.
    #[test]
    fn param_value_names_are_read_to_the_first_zero_and_checked() {
        let mut rng = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            rng
        };
        let pick = b"AZaz09_.-#, \x7f\x80\xff\x00\x00";
        for _ in 0..20_000 {
            let sent = (next() % 17) as usize;
            let id: Vec<u8> = (0..sent)
                .map(|_| pick[(next() % pick.len() as u64) as usize])
                .collect();
            let mut payload = vec![0u8; 8];
            payload.extend_from_slice(&id);
            if sent == 16 {
                payload.push(9);
            }
            let m = ParamValueMsg::parse(&payload).unwrap();
            let name = &id[..id.iter().position(|&b| b == 0).unwrap_or(id.len())];
            assert_eq!(m.id, name, "{id:?}");
            let ok = crate::wire::param_pck::name_ok(name);
            assert_eq!(m.refused, !ok, "{id:?}");
            let want = ok.then(|| ParamName::new(std::str::from_utf8(name).unwrap()).unwrap());
            assert_eq!(m.key, want, "{id:?}");
        }
    }

    #[test]
    fn param_name_orders_as_its_string() {
        let names = [
            "",
            "A",
            "AB",
            "A_B",
            "ABCDEFGHIJKLMNOP",
            "ABCDEFGHIJKLMNOQ",
            "B",
            "Z_LONG_NAME_16CH",
            "a",
            "\u{e9}t\u{e9}",
            "~",
        ];
        for a in names {
            for b in names {
                let (ka, kb) = (ParamName::new(a).unwrap(), ParamName::new(b).unwrap());
                assert_eq!(ka.cmp(&kb), a.cmp(b), "{a:?} {b:?}");
                assert_eq!(ka == kb, a == b, "{a:?} {b:?}");
                let p = ParamName::probe_bytes(a.as_bytes()).unwrap();
                assert_eq!(p.cmp(&kb), a.cmp(b), "probe {a:?} {b:?}");
            }
        }
        let mut set = ParamSet::default();
        for n in names.iter().rev() {
            set.params.insert(
                ParamName::new(n).unwrap(),
                Param::heard(ParamType::Int8, None, None, 1.0),
            );
        }
        let order: Vec<&str> = set.params.keys().map(|k| k.as_str()).collect();
        let mut sorted = names.to_vec();
        sorted.sort();
        assert_eq!(order, sorted);
        for n in names {
            assert!(set.params.contains_key(n), "{n:?}");
        }
        // No parameter can have these names: over 16 bytes, a NUL, bytes that are not UTF-8.
        assert!(ParamName::new("ABCDEFGHIJKLMNOPQ").is_none());
        assert!(ParamName::new("A\0B").is_none());
        assert!(ParamName::probe_bytes(&[0x41, 0xFF]).is_none());
        assert!(!set.params.contains_key("ABCDEFGHIJKLMNOPQ"));
    }
}
