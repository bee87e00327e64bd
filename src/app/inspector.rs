//! The MAVLink Inspector (`4`), after QGroundControl's: every message heard, per source, with its
//! count, measured rate and age, and the last one's fields; and asking a component for a rate
//! (MAV_CMD_SET_MESSAGE_INTERVAL) from the screen.
//!
//! The store ([`MessageStore`]) is fed every frame the core handles (not our own echoes, not a
//! repeat, not a redundant link's copy). It is cheap on that path: one hash lookup, the arrival
//! time into a fixed ring; the payload is copied into a buffer that is reused only while the
//! screen is shown, else once a second per message ([`KEEP_EVERY`]), and decoded only when the
//! screen shows it. It is bounded: [`MAX_PER_SOURCE`] message ids per source and
//! [`MAX_ENTRIES`] in all, the longest silent evicted (and counted) to make room, so a flood of
//! spoofed sources cannot grow it.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use mavlink::Message;

use super::editor::{self, EditKind, Edited};
use super::flight::FlightAction;
use super::{App, Effect};
use crate::clock::{Micros, SECOND};
use crate::dialect::{MavCmd, MavMessage};
use crate::keymap::{Action, Key};
use crate::proto::vehicles::VehicleKey;
use crate::wire::frame::{Frame, Version};
use crate::wire::Severity;

/// Message ids kept per source (sysid, compid) at most.
pub const MAX_PER_SOURCE: usize = 128;
/// Entries kept in all at most.
pub const MAX_ENTRIES: usize = 2048;
/// Arrival times kept per entry, for the rate.
pub const TIMES: usize = 32;
/// The rate is measured over the arrivals of the last this long (and one just before).
pub const RATE_WINDOW: Micros = 5 * SECOND;
/// While the Inspector is not on screen, a message's payload is kept at most this often (the
/// screen opens on payloads at most this old; on screen, every one is kept).
pub const KEEP_EVERY: Micros = SECOND;

/// (sysid, compid, msgid) packed in a `u64`: the store's key.
#[inline]
fn pack(sysid: u8, compid: u8, msgid: u32) -> u64 {
    (sysid as u64) << 40 | (compid as u64) << 32 | msgid as u64
}

/// A message of a source, as the screen names it.
pub type MsgKey = (u8, u8, u32);

fn unpack(k: u64) -> MsgKey {
    ((k >> 40) as u8, (k >> 32) as u8, k as u32)
}

/// A hasher for the packed keys: one multiply, folded so the bucket index (low bits) depends on
/// every field. Keys are few (capped) and not chosen freely by a peer (ids must be in the
/// dialect), so a keyed hash buys nothing here.
#[derive(Default, Clone, Copy)]
pub struct KeyHasher(u64);

impl Hasher for KeyHasher {
    #[inline]
    fn finish(&self) -> u64 {
        self.0
    }
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(b as u64);
        }
    }
    #[inline]
    fn write_u64(&mut self, x: u64) {
        let h = (x ^ self.0.rotate_left(5)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        self.0 = h ^ (h >> 32);
    }
}

type KeyMap<V> = HashMap<u64, V, BuildHasherDefault<KeyHasher>>;

/// One message id of one source. In C order, what every frame touches first (one cache line
/// with the arrival time's slot of the ring).
#[derive(Debug, Clone)]
#[repr(C)]
pub struct MsgEntry {
    /// Frames heard.
    pub count: u64,
    pub last: Micros,
    /// When the payload kept came.
    kept: Micros,
    /// The version and payload as sent of the last frame kept (decoded when shown): every
    /// frame's while the Inspector is on screen, else one a second (the first at once).
    pub version: Version,
    payload: Vec<u8>,
    /// Its name in the dialect.
    pub name: &'static str,
    pub first: Micros,
    /// Its key in the store.
    key: u64,
    /// The last [`TIMES`] arrival times, a ring; `count` says how many are filled.
    times: [Micros; TIMES],
}

impl MsgEntry {
    fn new(key: u64, name: &'static str, now: Micros) -> Self {
        Self {
            key,
            name,
            count: 0,
            first: now,
            last: now,
            times: [0; TIMES],
            version: Version::V2,
            payload: Vec::new(),
            kept: now,
        }
    }

    /// A frame heard at `now`; `live`: the Inspector is on screen.
    #[inline]
    fn hear(&mut self, now: Micros, frame: &Frame, live: bool) {
        let first = self.count == 0;
        self.times[(self.count % TIMES as u64) as usize] = now;
        self.count += 1;
        self.last = now;
        if live || first || now.saturating_sub(self.kept) >= KEEP_EVERY {
            self.kept = now;
            self.version = frame.version;
            self.payload.clear();
            self.payload.extend_from_slice(frame.payload());
        }
    }

    /// The payload kept, as sent (MAVLink 2 cuts trailing zeros): the last frame's while the
    /// Inspector is on screen, else one at most [`KEEP_EVERY`] older ([`MsgEntry::kept`]).
    pub fn payload(&self) -> &[u8] {
        &self.payload
    }

    /// When the frame whose payload is kept came (the last one's time, `last`, once the
    /// Inspector has been on screen for a frame).
    pub fn kept(&self) -> Micros {
        self.kept
    }

    /// The arrival times kept, oldest first.
    fn arrivals(&self) -> impl Iterator<Item = Micros> + '_ {
        let n = (self.count as usize).min(TIMES);
        let start = (self.count as usize + TIMES - n) % TIMES;
        (0..n).map(move |i| self.times[(start + i) % TIMES])
    }

    /// Messages per second at `now`: the mean interval of the arrivals of the last
    /// [`RATE_WINDOW`] (with the one just before, so a slow message still has an interval).
    /// Once the silence since the last one is longer than that mean, it counts as an interval
    /// in progress, so the rate falls smoothly; with no arrival in the window it is 0.
    pub fn rate(&self, now: Micros) -> f64 {
        let from = now.saturating_sub(RATE_WINDOW);
        let mut oldest = None;
        let mut n = 0u32;
        let mut before = None;
        for t in self.arrivals() {
            if t >= from {
                if oldest.is_none() {
                    oldest = Some(before.unwrap_or(t));
                    if before.is_some() {
                        n += 1;
                    }
                }
                n += 1;
            } else {
                before = Some(t);
            }
        }
        let Some(oldest) = oldest else {
            return 0.0;
        };
        let newest = self.last;
        let intervals = n.saturating_sub(1) as f64;
        if intervals == 0.0 || newest <= oldest {
            return 0.0;
        }
        let span = (newest - oldest) as f64;
        let gap = now.saturating_sub(newest) as f64;
        if gap > span / intervals {
            (intervals + 1.0) * SECOND as f64 / (span + gap)
        } else {
            intervals * SECOND as f64 / span
        }
    }

    /// The last frame decoded, or why the dialect could not read it.
    pub fn decode(&self, msgid: u32) -> Result<MavMessage, String> {
        MavMessage::parse(self.version.to_mavlink(), msgid, &self.payload).map_err(|e| match e {
            mavlink::error::ParserError::InvalidEnum { enum_type, value } => {
                format!("{enum_type} has no value {value} in our dialect (the sender's is newer)")
            }
            other => other.to_string(),
        })
    }
}

/// [`MessageStore::hint`]: (key, place) in 256 slots; a key no message has (`u64::MAX`: its
/// msgid would be over 24 bits) marks an empty slot.
#[derive(Debug, Clone)]
struct Hint(Box<[(u64, u32); 256]>);

impl Default for Hint {
    fn default() -> Self {
        Hint(Box::new([(u64::MAX, 0); 256]))
    }
}

impl Hint {
    /// The slot of a key: the top byte of its hash.
    #[inline]
    fn slot(k: u64) -> usize {
        let mut h = KeyHasher::default();
        h.write_u64(k);
        (h.finish() >> 56) as usize
    }
}

/// Every message heard, per source, bounded.
#[derive(Debug, Clone, Default)]
pub struct MessageStore {
    /// The Inspector is on screen: every frame's payload is kept (else one a second).
    pub live: bool,
    /// Each key's place in `list`: the table stays small (an entry with its ring of times is a
    /// few hundred bytes), so finding one touches little memory.
    index: KeyMap<u32>,
    /// In front of `index`: the place of a key last found, in a slot picked by its hash (its top
    /// byte); so most frames find their entry with one load and one compare. Emptied when places
    /// move (an eviction).
    hint: Hint,
    list: Vec<MsgEntry>,
    /// Entries per source (sysid, compid).
    per_source: HashMap<(u8, u8), usize>,
    /// Entries evicted to stay within the caps.
    pub evicted: u64,
}

impl MessageStore {
    /// A frame of a known message id, handled by the core at `now`.
    #[inline]
    pub fn record(&mut self, now: Micros, frame: &Frame) {
        let k = pack(frame.sysid, frame.compid, frame.msgid);
        let slot = Hint::slot(k);
        let i = match self.hint.0[slot] {
            (key, i) if key == k => i,
            _ => match self.index.get(&k) {
                Some(&i) => {
                    self.hint.0[slot] = (k, i);
                    i
                }
                None => return self.insert(k, now, frame),
            },
        };
        self.list[i as usize].hear(now, frame, self.live);
    }

    #[cold]
    fn insert(&mut self, k: u64, now: Micros, frame: &Frame) {
        let name = match &frame.message {
            Some(m) => m.message_name(),
            None => match MavMessage::default_message_from_id(frame.msgid) {
                Some(m) => m.message_name(),
                None => return, // not in the dialect: no CRC was checked, nothing to show
            },
        };
        let source = (frame.sysid, frame.compid);
        if self.per_source.get(&source).copied().unwrap_or(0) >= MAX_PER_SOURCE {
            self.evict(|key| (key >> 32) as u16 == u16::from_be_bytes([source.0, source.1]));
        }
        if self.list.len() >= MAX_ENTRIES {
            self.evict(|_| true);
        }
        let mut e = MsgEntry::new(k, name, now);
        e.hear(now, frame, true);
        self.index.insert(k, self.list.len() as u32);
        self.list.push(e);
        *self.per_source.entry(source).or_default() += 1;
    }

    /// Drop the entry heard least recently among those `pick` chooses.
    fn evict(&mut self, pick: impl Fn(u64) -> bool) {
        let oldest = self
            .list
            .iter()
            .enumerate()
            .filter(|(_, e)| pick(e.key))
            .min_by_key(|(_, e)| (e.last, e.key))
            .map(|(i, _)| i);
        if let Some(i) = oldest {
            self.hint = Hint::default();
            let k = self.list.swap_remove(i).key;
            self.index.remove(&k);
            // The last entry moved into the hole.
            if let Some(moved) = self.list.get(i) {
                self.index.insert(moved.key, i as u32);
            }
            let (s, c, _) = unpack(k);
            if let Some(n) = self.per_source.get_mut(&(s, c)) {
                *n -= 1;
                if *n == 0 {
                    self.per_source.remove(&(s, c));
                }
            }
            self.evicted += 1;
        }
    }

    pub fn get(&self, key: MsgKey) -> Option<&MsgEntry> {
        let i = *self.index.get(&pack(key.0, key.1, key.2))?;
        self.list.get(i as usize)
    }

    pub fn len(&self) -> usize {
        self.list.len()
    }

    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    /// Sources heard.
    pub fn sources(&self) -> usize {
        self.per_source.len()
    }

    /// Every entry, in no order.
    pub fn iter(&self) -> impl Iterator<Item = (MsgKey, &MsgEntry)> {
        self.list.iter().map(|e| (unpack(e.key), e))
    }
}

/// What the text typed on the Inspector is for.
#[derive(Debug, Clone, PartialEq)]
pub enum InspectEdit {
    /// The filter on names.
    Filter,
    /// A rate for this message of this source.
    Rate(MsgKey),
}

/// The Inspector's view state.
#[derive(Debug, Clone, Default)]
pub struct InspectorView {
    /// The selected message (kept as rows come and go).
    pub sel: Option<MsgKey>,
    /// Names containing this (case-insensitive).
    pub filter: String,
    pub editing: Option<InspectEdit>,
    /// The keys scroll the fields instead of the list, and the fields show their raw values too.
    pub detail_focus: bool,
    /// Lines the fields are scrolled by.
    pub detail_scroll: usize,
}

/// The interval param2 of SET_MESSAGE_INTERVAL for a rate typed: Hz (`10`, `0.5`, `4hz`), `0` or
/// `default` for the default rate (0), `-1`, `off` or `stop` to stop it (-1).
pub fn parse_rate(text: &str) -> Result<f64, String> {
    let t = text.trim().to_ascii_lowercase();
    let t = t.strip_suffix("hz").unwrap_or(&t).trim();
    match t {
        "off" | "stop" | "-1" => return Ok(-1.0),
        "default" | "0" => return Ok(0.0),
        _ => {}
    }
    let bad = || {
        format!(
            "`{}`: a rate in Hz, 0 = default, -1 or off = stop",
            text.trim()
        )
    };
    let hz: f64 = t.parse().map_err(|_| bad())?;
    if hz == 0.0 {
        return Ok(0.0);
    }
    if hz == -1.0 {
        return Ok(-1.0);
    }
    if !hz.is_finite() || hz < 0.0 {
        return Err(bad());
    }
    let us = (1e6 / hz).round();
    if us < 1.0 {
        return Err(format!("{hz} Hz is faster than one per microsecond"));
    }
    if us > i32::MAX as f64 {
        return Err(format!("{hz} Hz is slower than the interval can say"));
    }
    Ok(us)
}

/// `10 Hz`, `default rate`, `off` for an interval param2.
pub fn interval_text(us: f64) -> String {
    if us < 0.0 {
        "off".into()
    } else if us == 0.0 {
        "default rate".into()
    } else {
        format!("{} Hz", hz_text(1e6 / us))
    }
}

/// A rate with one decimal below 100 Hz (`0.5`, `10.0`), whole above.
pub fn hz_text(hz: f64) -> String {
    if hz >= 99.95 {
        format!("{hz:.0}")
    } else {
        format!("{hz:.1}")
    }
}

/// A message's fields as `(name, value)`, read from the dialect's `Debug` text (the generated
/// code offers no other walk over the fields): enums and flags by name (`MAV_TYPE_QUADROTOR`,
/// `MAV_MODE_FLAG_SAFETY_ARMED | MAV_MODE_FLAG_CUSTOM_MODE_ENABLED`), char arrays as strings,
/// other arrays compact (runs as `0×14`). Text it cannot split comes back whole, as one field.
pub fn fields(msg: &MavMessage) -> Vec<(String, String)> {
    fields_of_debug(&format!("{msg:?}"))
}

/// A unit of the dialect shown scaled: (the dialect's unit, what a raw value is divided by, the
/// unit shown, decimals). Units not listed show as they are, after the raw value.
const SCALED: &[(&str, f64, &str, usize)] = &[
    ("degE7", 1e7, "deg", 7),
    ("degE5", 1e5, "deg", 5),
    ("cdeg", 100.0, "deg", 2),
    ("ddeg/s", 10.0, "deg/s", 1),
    ("deg/2", 0.5, "deg", 0),
    ("cm", 100.0, "m", 2),
    ("mm", 1000.0, "m", 3),
    ("dm", 10.0, "m", 1),
    ("dam", 0.1, "m", 0),
    ("cm/s", 100.0, "m/s", 2),
    ("mm/s", 1000.0, "m/s", 3),
    ("dm/s", 10.0, "m/s", 1),
    ("mV", 1000.0, "V", 3),
    ("cV", 100.0, "V", 2),
    ("mA", 1000.0, "A", 3),
    ("cA", 100.0, "A", 2),
    ("cdegC", 100.0, "degC", 2),
    ("mrad/s", 1000.0, "rad/s", 3),
    ("c%", 100.0, "%", 2),
    ("d%", 10.0, "%", 1),
    ("cs", 100.0, "s", 2),
    ("ds", 10.0, "s", 1),
];

/// One field's value in the unit its definition gives (`units="degE7"`): scaled to a unit an
/// operator reads (`-35.3632621 deg` for `-353632621`), or with its unit after it (`10000 ms`);
/// `unknown` for the field's `invalid` value. `None` when there is nothing to add to the raw
/// text (no unit, an enum, a string, an array).
pub fn in_units(value: &str, def: &crate::wire::mavlink_xml::FieldDef) -> Option<String> {
    if crate::wire::mavlink_xml::is_invalid(&def.invalid, value) {
        return Some("unknown".into());
    }
    if def.units.is_empty() || def.ty.contains('[') {
        return None;
    }
    let v: f64 = value.trim().parse().ok()?;
    Some(match SCALED.iter().find(|(u, ..)| *u == def.units) {
        Some((_, div, unit, decimals)) => format!("{:.*} {unit}", *decimals, v / div),
        None => format!("{value} {}", def.units),
    })
}

/// Whether [`in_units`] changed the number (scaled, or `unknown`), so the raw one is worth showing.
fn converted(def: &crate::wire::mavlink_xml::FieldDef, value: &str) -> bool {
    crate::wire::mavlink_xml::is_invalid(&def.invalid, value)
        || SCALED.iter().any(|(u, ..)| *u == def.units)
}

/// [`fields`] as the Inspector shows them: each value in the units of the dialect's definition
/// of the field ([`in_units`]); with `raw`, a value converted is followed by the raw one as sent
/// (`-35.3632621 deg  raw -353632621`).
pub fn fields_in_units(msg: &MavMessage, raw: bool) -> Vec<(String, String)> {
    let def = crate::wire::mavlink_xml::definitions().message(msg.message_name());
    let mut out = fields(msg);
    let Some(def) = def else {
        return out;
    };
    // (index, shown, raw): the raw ones lined up after the widest value shown.
    let mut done: Vec<(usize, String, Option<String>)> = Vec::new();
    for (i, (name, value)) in out.iter().enumerate() {
        let Some(f) = def.field(name) else {
            continue;
        };
        if let Some(shown) = in_units(value, f) {
            let raw = (raw && converted(f, value)).then(|| value.clone());
            done.push((i, shown, raw));
        }
    }
    let width = done
        .iter()
        .filter(|d| d.2.is_some())
        .map(|d| d.1.chars().count())
        .max()
        .unwrap_or(0);
    for (i, shown, raw) in done {
        out[i].1 = match raw {
            Some(raw) => format!("{shown:<width$}  raw {raw}"),
            None => shown,
        };
    }
    out
}

/// [`fields`] from a `NAME(NAME_DATA { a: 1, b: [2, 3] })` text.
pub fn fields_of_debug(text: &str) -> Vec<(String, String)> {
    let (Some(open), Some(close)) = (text.find('{'), text.rfind('}')) else {
        return vec![(String::new(), text.to_string())];
    };
    if close <= open {
        return vec![(String::new(), text.to_string())];
    }
    split_top(&text[open + 1..close])
        .into_iter()
        .filter(|p| !p.is_empty())
        .map(|part| match part.split_once(": ") {
            Some((name, value)) => (name.trim().to_string(), value_text(value.trim())),
            None => (String::new(), part.to_string()),
        })
        .collect()
}

/// `text` split at the commas outside brackets, each part trimmed.
fn split_top(text: &str) -> Vec<&str> {
    let mut parts = Vec::new();
    let mut depth = 0i32;
    let mut start = 0;
    for (i, c) in text.char_indices() {
        match c {
            '[' | '(' | '{' => depth += 1,
            ']' | ')' | '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(text[start..i].trim());
                start = i + 1;
            }
            _ => {}
        }
    }
    parts.push(text[start..].trim());
    parts
}

/// One field's `Debug` text as the Inspector shows it.
fn value_text(v: &str) -> String {
    if let Some(rest) = v.strip_prefix("CharArray {") {
        // `CharArray { data: [72, 73, 0], str_len: 2 }`: the bytes up to the first NUL.
        if let (Some(a), Some(b)) = (rest.find('['), rest.find(']')) {
            if a < b {
                let bytes: Vec<u8> = rest[a + 1..b]
                    .split(',')
                    .filter_map(|x| x.trim().parse::<u8>().ok())
                    .take_while(|b| *b != 0)
                    .collect();
                return quoted(&bytes);
            }
        }
        return v.to_string();
    }
    if let Some(inner) = v.strip_prefix('[').and_then(|x| x.strip_suffix(']')) {
        return array_text(&split_top(inner));
    }
    // Flags: `TypeName(A | B)`, `TypeName(0x0)`.
    if let (Some(open), true) = (v.find('('), v.ends_with(')')) {
        let ty = &v[..open];
        if ty.chars().next().is_some_and(|c| c.is_ascii_uppercase())
            && ty.chars().any(|c| c.is_ascii_lowercase())
            && ty.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        {
            let inner = &v[open + 1..v.len() - 1];
            return match inner {
                "0x0" => "0 (none)".into(),
                _ => inner.to_string(),
            };
        }
    }
    v.to_string()
}

/// A string in quotes, bytes that are not printable ASCII as `\xNN`.
fn quoted(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(bytes.len() + 2);
    s.push('"');
    for &b in bytes {
        match b {
            b'"' => s.push_str("\\\""),
            b'\\' => s.push_str("\\\\"),
            0x20..=0x7E => s.push(b as char),
            _ => s.push_str(&format!("\\x{b:02x}")),
        }
    }
    s.push('"');
    s
}

/// `[1, 2, 0×14]`: runs of three or more equal values counted.
fn array_text(items: &[&str]) -> String {
    let items: Vec<String> = items
        .iter()
        .filter(|x| !x.is_empty())
        .map(|x| value_text(x))
        .collect();
    let mut out: Vec<String> = Vec::new();
    let mut i = 0;
    while i < items.len() {
        let mut j = i + 1;
        while j < items.len() && items[j] == items[i] {
            j += 1;
        }
        if j - i >= 3 {
            out.push(format!("{}×{}", items[i], j - i));
        } else {
            out.extend(items[i..j].iter().cloned());
        }
        i = j;
    }
    format!("[{}]", out.join(", "))
}

/// `bytes` as hex, `per_line` to a line, each line starting with its offset: `00: fd 09 …`.
pub fn hex_lines(bytes: &[u8], per_line: usize) -> Vec<String> {
    let per_line = per_line.max(1);
    if bytes.is_empty() {
        return vec!["(empty)".into()];
    }
    bytes
        .chunks(per_line)
        .enumerate()
        .map(|(i, c)| {
            let hex: Vec<String> = c.iter().map(|b| format!("{b:02x}")).collect();
            format!("{:02x}: {}", i * per_line, hex.join(" "))
        })
        .collect()
}

/// The Inspector's rows and keys.
impl App {
    /// The messages listed, in order: by source, then by name; the filter applied.
    pub fn inspector_rows(&self) -> Vec<MsgKey> {
        let f = self.ui.inspector.filter.to_ascii_uppercase();
        let mut rows: Vec<(MsgKey, &'static str)> = self
            .inspector
            .iter()
            .filter(|(_, e)| f.is_empty() || e.name.contains(f.as_str()))
            .map(|(k, e)| (k, e.name))
            .collect();
        rows.sort_unstable_by(|a, b| (a.0 .0, a.0 .1, a.1).cmp(&(b.0 .0, b.0 .1, b.1)));
        rows.into_iter().map(|(k, _)| k).collect()
    }

    /// The selected row's index among `rows`: the message selected if listed, else the first.
    pub fn inspector_index(&self, rows: &[MsgKey]) -> usize {
        self.ui
            .inspector
            .sel
            .and_then(|s| rows.iter().position(|r| *r == s))
            .unwrap_or(0)
    }

    /// The message selected (the first listed when none is).
    pub fn inspector_selected(&self) -> Option<MsgKey> {
        let rows = self.inspector_rows();
        rows.get(self.inspector_index(&rows)).copied()
    }

    /// Up/down/page/top/bottom on the Inspector: through the list, or the fields when they
    /// have the keys.
    pub(super) fn move_inspector(&mut self, step: isize) {
        let v = &mut self.ui.inspector;
        if v.detail_focus {
            let n = self
                .inspector_selected()
                .and_then(|k| Some(self.inspector.get(k)?.decode(k.2)))
                .map_or(0, |d| d.map_or(20, |m| fields_in_units(&m, true).len()));
            let v = &mut self.ui.inspector;
            v.detail_scroll = (v.detail_scroll as isize + step).clamp(0, n as isize) as usize;
            return;
        }
        let rows = self.inspector_rows();
        if rows.is_empty() {
            return;
        }
        let i = self.inspector_index(&rows) as isize;
        let j = (i + step).clamp(0, rows.len() as isize - 1) as usize;
        if rows[j] != rows[i as usize] {
            self.ui.inspector.detail_scroll = 0;
        }
        self.ui.inspector.sel = Some(rows[j]);
    }

    /// `inspector_rate`, `inspector_filter`, `inspector_detail` (normal mode).
    pub(super) fn on_inspector_action(&mut self, action: Action) {
        let outcome: Result<Option<String>, String> = match action {
            Action::InspectorFilter => {
                editor::open(
                    &mut self.ui.edit,
                    &mut self.ui.mode,
                    &self.ui.inspector.filter,
                );
                self.ui.inspector.editing = Some(InspectEdit::Filter);
                Ok(None)
            }
            Action::InspectorRate => match self.inspector_selected() {
                None => Err("no message selected: none heard yet".into()),
                Some(k) => {
                    self.ui.inspector.sel = Some(k);
                    editor::open_empty(&mut self.ui.edit, &mut self.ui.mode);
                    self.ui.inspector.editing = Some(InspectEdit::Rate(k));
                    Ok(None)
                }
            },
            Action::InspectorDetail => {
                let v = &mut self.ui.inspector;
                v.detail_focus = !v.detail_focus;
                Ok(Some(
                    if v.detail_focus {
                        "keys scroll the fields, raw shown"
                    } else {
                        "the keys move through the list"
                    }
                    .into(),
                ))
            }
            _ => Ok(None),
        };
        self.ui.message = match outcome {
            Ok(t) => t.map(|t| (Severity::INFO, t)),
            Err(e) => Some((Severity::ERROR, e)),
        };
    }

    /// A key while the filter or a rate is typed on the Inspector: the shared edit line;
    /// `enter` sends the rate (checked by [`parse_rate`]).
    pub(super) fn on_inspector_edit_key(
        &mut self,
        key: Key,
        action: Option<Action>,
        fx: &mut Vec<Effect>,
    ) {
        self.ui.message = None;
        let Some(editing) = self.ui.inspector.editing.clone() else {
            return;
        };
        let filter = editing == InspectEdit::Filter;
        let kind = EditKind {
            filter,
            completes: false,
        };
        match editor::key(&mut self.ui.edit, &mut self.ui.mode, kind, key, action) {
            Edited::Submit(text) => {
                self.ui.inspector.editing = None;
                if filter {
                    self.ui.inspector.sel = self.inspector_selected();
                }
                if let (InspectEdit::Rate(k), Some(text)) = (editing, text) {
                    let outcome = self.set_message_rate(k, &text, fx);
                    self.ui.message = match outcome {
                        Ok(t) => t.map(|t| (Severity::INFO, t)),
                        Err(e) => Some((Severity::ERROR, e)),
                    };
                }
                return;
            }
            Edited::Cancel => {
                self.ui.inspector.editing = None;
                if filter {
                    // The message found stays selected in the whole list.
                    self.ui.inspector.sel = self.inspector_selected();
                    self.ui.inspector.filter.clear();
                } else {
                    self.ui.message =
                        Some((Severity::INFO, "rate not changed: nothing sent".into()));
                }
                return;
            }
            // While filtering, up/down move through what the filter leaves.
            Edited::Move(step) => self.move_inspector(step),
            Edited::Complete | Edited::Typed => {}
        }
        if filter && self.ui.inspector.filter != self.ui.edit.text {
            self.ui.inspector.filter = self.ui.edit.text.clone();
        }
    }

    /// Ask the source of `k` to send it at the rate typed: MAV_CMD_SET_MESSAGE_INTERVAL through
    /// the command queue of its system's autopilot.
    pub fn set_message_rate(
        &mut self,
        k: MsgKey,
        text: &str,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let (sysid, compid, msgid) = k;
        let name = self
            .inspector
            .get(k)
            .map_or_else(|| format!("message {msgid}"), |e| e.name.to_string());
        let interval = parse_rate(text).map_err(|e| format!("{name}: {e}"))?;
        let command = MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL as u16;
        let params = [msgid as f64, interval, 0., 0., 0., 0., 0.];
        let source = VehicleKey(sysid, compid);
        let since = self.ui.action_count;
        self.flight_to(source, FlightAction::Command { command, params }, fx)
            .map_err(|e| format!("{name}: {e}"))?;
        // The line is told in the Inspector's words: `ATTITUDE 10 Hz from 1:1: ACCEPTED`.
        let label = format!("{name} {} from {source}", interval_text(interval));
        self.name_action(since, &label);
        Ok(Some(format!("{label}: sent")))
    }

    /// The rate last asked of `k`'s source from here (its interval param2) and where the
    /// request stands (`ACCEPTED`, `waiting`…), from the command queue.
    pub fn inspector_requested(&self, k: MsgKey) -> Option<(f64, String)> {
        let session = self
            .sessions
            .get(&self.session_for(VehicleKey(k.0, k.1))?)?;
        let command = MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL as u16;
        session
            .commands
            .entries()
            .rev()
            .find(|e| {
                e.spec.command == command
                    && e.spec.target == (k.0, k.1)
                    && e.spec.params[0] == k.2 as f64
            })
            .map(|e| (e.spec.params[1], e.outcome()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dialect;
    use crate::wire::frame::{decode_one, encode, Header};

    fn frame(sysid: u8, compid: u8, msg: &MavMessage) -> Frame {
        let h = Header {
            sysid,
            compid,
            seq: 0,
        };
        decode_one(&encode(Version::V2, h, msg)).unwrap()
    }

    fn attitude() -> MavMessage {
        MavMessage::ATTITUDE(dialect::ATTITUDE_DATA {
            time_boot_ms: 1000,
            roll: 0.5,
            ..Default::default()
        })
    }

    #[test]
    fn payloads_are_kept_once_a_second_off_screen_and_every_one_on_it() {
        assert!(crate::app::screen::by_name(crate::app::INSPECTOR).is_some());
        let att = |roll: f32| {
            frame(
                1,
                1,
                &MavMessage::ATTITUDE(dialect::ATTITUDE_DATA {
                    roll,
                    ..Default::default()
                }),
            )
        };
        let roll = |s: &MessageStore| match s.get((1, 1, 30)).unwrap().decode(30) {
            Ok(MavMessage::ATTITUDE(a)) => a.roll,
            other => panic!("{other:?}"),
        };
        let mut s = MessageStore::default();
        // 10 Hz, off screen: the first kept at once, then the one a second after it.
        for i in 0..15u64 {
            s.record(i * 100_000, &att(i as f32));
            let kept = if i < 10 { 0.0 } else { 10.0 };
            assert_eq!(roll(&s), kept, "frame {i}");
        }
        assert_eq!(s.get((1, 1, 30)).unwrap().count, 15);
        // On screen: every one.
        s.live = true;
        for i in 15..20u64 {
            s.record(i * 100_000, &att(i as f32));
            assert_eq!(roll(&s), i as f32);
        }
    }

    #[test]
    fn counts_and_measures_the_rate_of_a_steady_stream() {
        let mut s = MessageStore::default();
        let f = frame(1, 1, &attitude());
        // 4 Hz for 10 s.
        for i in 0..40u64 {
            s.record(i * 250_000, &f);
        }
        let e = s.get((1, 1, 30)).unwrap();
        assert_eq!((e.count, e.name), (40, "ATTITUDE"));
        let now = 39 * 250_000 + 100_000;
        assert!((e.rate(now) - 4.0).abs() < 1e-9, "{}", e.rate(now));
        // Silence: the rate falls, then is 0 once nothing is left in the window.
        let later = 39 * 250_000 + 2 * SECOND;
        assert!(e.rate(later) < 4.0 && e.rate(later) > 0.0);
        assert_eq!(e.rate(39 * 250_000 + RATE_WINDOW + 1), 0.0);
        // Slow: 0.5 Hz still measured from the arrival just before the window.
        let mut s = MessageStore::default();
        for i in 0..10u64 {
            s.record(i * 2 * SECOND, &f);
        }
        let e = s.get((1, 1, 30)).unwrap();
        assert!((e.rate(18 * SECOND + 1) - 0.5).abs() < 1e-6);
        // One arrival: no rate yet.
        let mut s = MessageStore::default();
        s.record(0, &f);
        assert_eq!(s.get((1, 1, 30)).unwrap().rate(1), 0.0);
    }

    #[test]
    fn the_payload_buffer_is_reused_and_decodes_lazily() {
        let mut s = MessageStore::default();
        s.record(0, &frame(1, 1, &attitude()));
        let cap = s.get((1, 1, 30)).unwrap().payload.capacity();
        for i in 1..100 {
            s.record(i, &frame(1, 1, &attitude()));
        }
        let e = s.get((1, 1, 30)).unwrap();
        assert_eq!(e.payload.capacity(), cap);
        assert_eq!(e.decode(30).unwrap(), attitude());
    }

    #[test]
    fn bounded_per_source_and_in_all_evicting_the_longest_silent() {
        let mut s = MessageStore::default();
        // Every known id from one source: capped at MAX_PER_SOURCE.
        let mut t = 0;
        for id in 0..20_000u32 {
            if let Some(m) = MavMessage::default_message_from_id(id) {
                t += 1;
                s.record(t, &frame(1, 1, &m));
            }
        }
        assert_eq!(s.len(), MAX_PER_SOURCE);
        assert!(s.evicted > 0);
        // HEARTBEAT (id 0) was heard first: it went first.
        assert!(s.get((1, 1, 0)).is_none());
        // Many sources: capped in all.
        let hb = MavMessage::default_message_from_id(0).unwrap();
        for sys in 0..=255u8 {
            for comp in 0..20u8 {
                t += 1;
                s.record(t, &frame(sys, comp, &hb));
            }
        }
        assert_eq!(s.len(), MAX_ENTRIES);
        assert!(s.per_source.values().sum::<usize>() == MAX_ENTRIES);
        // The newest is there.
        assert!(s.get((255, 19, 0)).is_some());
        // After all that moving: every entry is found by its own key, and only there.
        assert_eq!(s.index.len(), s.list.len());
        for (k, e) in s.iter() {
            assert!(std::ptr::eq(s.get(k).unwrap(), e), "{k:?}");
        }
    }

    #[test]
    fn fields_by_name_with_enums_flags_strings_and_arrays() {
        let hb = MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
            custom_mode: 4,
            mavtype: dialect::MavType::MAV_TYPE_QUADROTOR,
            autopilot: dialect::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode: dialect::MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
                | dialect::MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED,
            system_status: dialect::MavState::MAV_STATE_ACTIVE,
            mavlink_version: 3,
        });
        let f = fields(&hb);
        let get = |n: &str| f.iter().find(|(k, _)| k == n).unwrap().1.clone();
        assert_eq!(get("custom_mode"), "4");
        assert_eq!(get("mavtype"), "MAV_TYPE_QUADROTOR");
        assert!(get("base_mode").contains("MAV_MODE_FLAG_SAFETY_ARMED"));
        assert!(!get("base_mode").contains("MavModeFlag"));
        let empty = MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
            base_mode: dialect::MavModeFlag::empty(),
            ..Default::default()
        });
        let f = fields(&empty);
        assert_eq!(
            f.iter().find(|(k, _)| k == "base_mode").unwrap().1,
            "0 (none)"
        );
        let st = MavMessage::STATUSTEXT(dialect::STATUSTEXT_DATA {
            severity: dialect::MavSeverity::MAV_SEVERITY_INFO,
            text: "Hello, \"world\"".into(),
            id: 0,
            chunk_seq: 0,
        });
        let f = fields(&st);
        assert_eq!(f[1], ("text".into(), "\"Hello, \\\"world\\\"\"".into()));
        assert_eq!(f[0].1, "MAV_SEVERITY_INFO");
        let rc = MavMessage::SERVO_OUTPUT_RAW(dialect::SERVO_OUTPUT_RAW_DATA {
            servo1_raw: 1500,
            ..Default::default()
        });
        assert!(fields(&rc)
            .iter()
            .any(|(k, v)| k == "servo1_raw" && v == "1500"));
        assert_eq!(
            array_text(&["1", "1", "0", "0", "0", "0", "7"]),
            "[1, 1, 0×4, 7]"
        );
        // Text that is not a struct comes back whole.
        assert_eq!(fields_of_debug("odd"), vec![(String::new(), "odd".into())]);
    }

    #[test]
    fn fields_in_the_units_of_the_dialect_and_raw_on_demand() {
        let gpi = MavMessage::GLOBAL_POSITION_INT(dialect::GLOBAL_POSITION_INT_DATA {
            time_boot_ms: 10_000,
            lat: -353_632_621,
            lon: 1_491_652_374,
            alt: 584_000,
            relative_alt: 10_250,
            vx: -150,
            vy: 0,
            vz: 0,
            hdg: u16::MAX,
        });
        let f = fields_in_units(&gpi, false);
        let get = |n: &str| f.iter().find(|(k, _)| k == n).unwrap().1.clone();
        // common.xml: degE7, mm, cm/s, cdeg with invalid="UINT16_MAX", ms.
        assert_eq!(get("lat"), "-35.3632621 deg");
        assert_eq!(get("lon"), "149.1652374 deg");
        assert_eq!(get("alt"), "584.000 m");
        assert_eq!(get("relative_alt"), "10.250 m");
        assert_eq!(get("vx"), "-1.50 m/s");
        assert_eq!(get("hdg"), "unknown");
        assert_eq!(get("time_boot_ms"), "10000 ms");
        let f = fields_in_units(&gpi, true);
        let get = |n: &str| f.iter().find(|(k, _)| k == n).unwrap().1.clone();
        assert_eq!(get("lat"), "-35.3632621 deg  raw -353632621");
        assert_eq!(get("hdg"), "unknown          raw 65535");
        // Nothing converted: no raw.
        assert_eq!(get("time_boot_ms"), "10000 ms");
        // Voltages and currents; enums and strings as they were.
        let st = MavMessage::SYS_STATUS(dialect::SYS_STATUS_DATA {
            voltage_battery: 12_600,
            current_battery: 50,
            ..Default::default()
        });
        let f = fields_in_units(&st, false);
        let get = |n: &str| f.iter().find(|(k, _)| k == n).unwrap().1.clone();
        assert_eq!(get("voltage_battery"), "12.600 V");
        assert_eq!(get("current_battery"), "0.50 A");
        let hb = MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA::default());
        assert_eq!(fields_in_units(&hb, true), fields(&hb));
    }

    #[test]
    fn rates_typed() {
        assert_eq!(parse_rate("10"), Ok(100_000.0));
        assert_eq!(parse_rate(" 4 Hz"), Ok(250_000.0));
        assert_eq!(parse_rate("0.5"), Ok(2_000_000.0));
        assert_eq!(parse_rate("0"), Ok(0.0));
        assert_eq!(parse_rate("default"), Ok(0.0));
        assert_eq!(parse_rate("-1"), Ok(-1.0));
        assert_eq!(parse_rate("OFF"), Ok(-1.0));
        assert!(parse_rate("-2").is_err());
        assert!(parse_rate("fast").is_err());
        assert!(parse_rate("nan").is_err());
        assert!(parse_rate("").is_err());
        assert_eq!(interval_text(100_000.0), "10.0 Hz");
        assert_eq!(interval_text(-1.0), "off");
        assert_eq!(interval_text(0.0), "default rate");
    }

    #[test]
    fn hex_dump() {
        assert_eq!(
            hex_lines(&[0xfd, 1, 2], 2),
            vec!["00: fd 01".to_string(), "02: 02".to_string()]
        );
    }
}
