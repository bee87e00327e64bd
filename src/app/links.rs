//! What the core knows about each link: state, parser counters, per-source sequence statistics,
//! and frame/byte rates.

use std::collections::BTreeMap;

use std::collections::VecDeque;

use crate::clock::{Micros, SECOND};
pub use crate::link::LinkState;
use crate::link::ParserStats;
use crate::proto::loss::SeqTracker;
use crate::proto::streams::LinkProfile;
use crate::proto::telemetry::History;
use crate::proto::vehicles::VehicleKey;
use crate::wire::tx::LinkTx;

/// How soon a repeated frame must follow the original to be a duplicate (radios and routers
/// repeat within milliseconds).
pub const DUPLICATE_WINDOW: Micros = 500_000;

/// Statistics for one source (sysid, compid) on one link.
#[derive(Debug, Clone, Default)]
pub struct SourceStats {
    pub seq: SeqTracker,
    /// CRC and time of the last frame heard with each sequence number: the same CRC again within
    /// [`DUPLICATE_WINDOW`] is a true duplicate; anything else is new content from a sender that
    /// does not count its sequence (some do not), and must still be read.
    crcs: Vec<Option<(u16, Micros)>>,
    /// Every frame heard, duplicates included.
    pub frames: u64,
    pub last_heard: Micros,
    /// The last frames of this source handled from this link: the same frame arriving on another
    /// link soon after is a copy (redundant radios), whose content was handled already.
    pub(crate) recent: RecentFrames,
    /// Signed, unsigned, bad-signature, replayed and rejected frames.
    pub signing: super::signing::SigningCounts,
}

/// Frames remembered per source and link to know their copies on other links.
pub const RECENT_PER_SOURCE: usize = 16;

/// A frame remembered to recognise its copy on another link.
#[derive(Debug, Clone, Copy, Default)]
struct RecentFrame {
    seq: u8,
    crc: u16,
    msgid: u32,
    t: Micros,
}

/// The last [`RECENT_PER_SOURCE`] frames of a source on a link, oldest overwritten.
#[derive(Debug, Clone, Default)]
pub(crate) struct RecentFrames {
    frames: [RecentFrame; RECENT_PER_SOURCE],
    /// Slot the next frame goes in; slots from here on are unused until the ring is full.
    next: u8,
    full: bool,
}

impl RecentFrames {
    pub(crate) fn push(&mut self, seq: u8, msgid: u32, crc: u16, t: Micros) {
        self.frames[self.next as usize] = RecentFrame { seq, crc, msgid, t };
        self.next += 1;
        if self.next as usize == RECENT_PER_SOURCE {
            self.next = 0;
            self.full = true;
        }
    }

    /// True when the frame (seq, id, CRC) is here, heard within [`DUPLICATE_WINDOW`] of `now`.
    pub(crate) fn has(&self, seq: u8, msgid: u32, crc: u16, now: Micros) -> bool {
        let n = if self.full {
            RECENT_PER_SOURCE
        } else {
            self.next as usize
        };
        self.frames[..n].iter().any(|r| {
            r.seq == seq && r.msgid == msgid && r.crc == crc && now < r.t + DUPLICATE_WINDOW
        })
    }
}

impl SourceStats {
    /// Start afresh after a jump in the link's time (a replay's seek): the next frame starts a
    /// new count, as after a reconnect, and nothing before it makes a duplicate or a copy.
    pub fn restart(&mut self) {
        self.seq.restart_sequence();
        self.crcs.clear();
        self.recent = RecentFrames::default();
    }

    /// Remember `crc` for `seq` at `now`; true if the last frame with that seq was the same
    /// frame, heard within [`DUPLICATE_WINDOW`].
    #[inline]
    pub fn same_as_before(&mut self, seq: u8, crc: u16, now: Micros) -> bool {
        if self.crcs.is_empty() {
            self.crcs = vec![None; 256];
        }
        matches!(
            self.crcs[seq as usize].replace((crc, now)),
            Some((c, t)) if c == crc && now < t + DUPLICATE_WINDOW
        )
    }
}

/// Frames and bytes per second over the last few whole seconds.
#[derive(Debug, Clone, Default)]
pub struct RateMeter {
    /// (second, frames, bytes) for the last [`RateMeter::SECONDS`] seconds.
    buckets: [(u64, u64, u64); 4],
}

impl RateMeter {
    const SECONDS: u64 = 4;

    pub fn add(&mut self, now: Micros, frames: u64, bytes: u64) {
        let sec = now / SECOND;
        let b = &mut self.buckets[(sec % Self::SECONDS) as usize];
        if b.0 != sec {
            *b = (sec, 0, 0);
        }
        b.1 += frames;
        b.2 += bytes;
    }

    /// (frames/s, bytes/s) over the completed seconds before `now`.
    pub fn rates(&self, now: Micros) -> (f64, f64) {
        let cur = now / SECOND;
        let span = (Self::SECONDS - 1).min(cur);
        if span == 0 {
            return (0.0, 0.0);
        }
        let (mut f, mut b) = (0, 0);
        for &(sec, frames, bytes) in &self.buckets {
            if sec < cur && sec + span >= cur {
                f += frames;
                b += bytes;
            }
        }
        (f as f64 / span as f64, b as f64 / span as f64)
    }
}

/// Where a replay link is, as it last said, and when (core time) it said so.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayView {
    pub status: crate::link::replay::ReplayStatus,
    pub at: Micros,
}

impl ReplayView {
    /// Log time at core time `now`.
    pub fn position(&self, now: Micros) -> Micros {
        self.status.position_at(self.at, now)
    }
}

/// Frames we sent that are remembered per link, to know our own frames when a router echoes them.
pub const SENT_MEMORY: usize = 64;
/// Sources tracked per link at most; past this the longest silent is evicted and counted.
pub const MAX_SOURCES: usize = 256;

/// One link as the core tracks it.
#[derive(Debug, Clone)]
pub struct LinkStatus {
    pub spec: String,
    /// What the spec says of the link for automatic traffic: high-latency, a known baud.
    pub profile: LinkProfile,
    pub state: LinkState,
    /// Our sending side: sequence numbers and the version the far end speaks.
    pub tx: LinkTx,
    /// (seq, crc) of the frames we sent most recently.
    sent: VecDeque<(u8, u16)>,
    /// Has been up at least once (so a later `up` is a reconnect).
    pub was_up: bool,
    /// Our own frames heard back (a router echoing them).
    pub echoes: u64,
    /// Frames and bytes we sent on this link.
    pub sent_frames: u64,
    pub sent_bytes: u64,
    /// Frames the link or the core's queues dropped because the other side could not keep up.
    pub dropped: u64,
    /// Sources evicted to keep the table within [`MAX_SOURCES`].
    pub evicted_sources: u64,
    pub parser: ParserStats,
    pub sources: BTreeMap<VehicleKey, SourceStats>,
    pub rate: RateMeter,
    /// Per-source rows shown in the links pane.
    pub expanded: bool,
    /// The last "down" reason the operator was told of, so retries do not repeat it.
    pub notified_down: Option<String>,
    /// Loss (percent, all sources) of each second of the last minute.
    pub loss_history: History,
    /// Marked `?secure=1`: SETUP_SIGNING may go on it, and unsigned frames are taken.
    pub secure: bool,
    /// Secure, or in-process (`sim://`, `tlog:`): no frame is rejected for its signing.
    pub trusted: bool,
    /// Incoming signing streams and their last timestamps.
    pub signing_streams: crate::wire::signing::Streams,
    /// A replay's last status and the core time it came (`tlog:` links).
    pub replay: Option<ReplayView>,
    /// The second the loss history was last sampled in, and the totals then.
    loss_mark: (u64, (u64, u64)),
}

impl LinkStatus {
    pub fn new(spec: String, sysid: u8, compid: u8) -> Self {
        let parsed = spec.parse::<crate::link::LinkSpec>().ok();
        let profile = parsed
            .as_ref()
            .map(|l| LinkProfile {
                // A replay cannot answer: nothing automatic goes to it (no stream requests, no
                // parameter download), as QGroundControl treats its log replay links.
                hl: l.high_latency() || matches!(l, crate::link::LinkSpec::Tlog { .. }),
                baud: l.explicit_baud(),
            })
            .unwrap_or_default();
        let secure = parsed.as_ref().is_some_and(|l| l.secure());
        let trusted = secure || parsed.as_ref().is_some_and(|l| l.in_process());
        Self {
            secure,
            trusted,
            signing_streams: Default::default(),
            profile,
            spec,
            state: LinkState::Connecting,
            tx: LinkTx::new(sysid, compid),
            sent: VecDeque::with_capacity(SENT_MEMORY),
            was_up: false,
            echoes: 0,
            sent_frames: 0,
            sent_bytes: 0,
            dropped: 0,
            evicted_sources: 0,
            parser: ParserStats::default(),
            sources: BTreeMap::new(),
            rate: RateMeter::default(),
            expanded: false,
            notified_down: None,
            loss_history: History::default(),
            loss_mark: (0, (0, 0)),
            replay: None,
        }
    }

    /// Encode `msg` for this link (signed when `sign` is given) and remember it, to know it if
    /// it comes back.
    pub fn encode(
        &mut self,
        msg: &crate::dialect::MavMessage,
        sign: Option<crate::wire::tx::Sign>,
    ) -> Vec<u8> {
        use crate::wire::frame::{IFLAG_SIGNED, MAGIC_V1, SIGNATURE_LEN};
        let bytes = match sign {
            Some(s) => self.tx.encode_signed(msg, s),
            None => self.tx.encode(msg),
        };
        self.sent_frames += 1;
        self.sent_bytes += bytes.len() as u64;
        // Seq at byte 2 (v1) or 4 (v2); the CRC in the two bytes before any signature.
        let (seq, signed) = if bytes[0] == MAGIC_V1 {
            (bytes[2], false)
        } else {
            (bytes[4], bytes[2] & IFLAG_SIGNED != 0)
        };
        let n = bytes.len() - if signed { SIGNATURE_LEN } else { 0 };
        let crc = u16::from_le_bytes([bytes[n - 2], bytes[n - 1]]);
        if self.sent.len() == SENT_MEMORY {
            self.sent.pop_front();
        }
        self.sent.push_back((seq, crc));
        bytes
    }

    /// True when `frame` is one we sent on this link.
    pub fn sent_by_us(&self, seq: u8, crc: u16) -> bool {
        self.sent.contains(&(seq, crc))
    }

    /// The per-source statistics for `key`, made if new; a full table first evicts the source
    /// heard least recently.
    pub fn source(&mut self, key: VehicleKey) -> &mut SourceStats {
        use std::collections::btree_map::Entry;
        if self.sources.len() >= MAX_SOURCES && !self.sources.contains_key(&key) {
            self.evict_source();
        }
        // One search, the common case being a source heard before.
        match self.sources.entry(key) {
            Entry::Occupied(e) => e.into_mut(),
            Entry::Vacant(e) => e.insert(SourceStats::default()),
        }
    }

    /// Make room for a new source: evict the one heard least recently.
    #[cold]
    fn evict_source(&mut self) {
        let oldest = self
            .sources
            .iter()
            .min_by_key(|(_, s)| s.last_heard)
            .map(|(k, _)| *k);
        if let Some(k) = oldest {
            self.sources.remove(&k);
            self.evicted_sources += 1;
        }
    }

    /// (received, lost) summed over all sources, since start.
    pub fn totals(&self) -> (u64, u64) {
        self.sources
            .values()
            .fold((0, 0), |(r, l), s| (r + s.seq.received, l + s.seq.lost))
    }

    /// (received, lost) summed over all sources in the sliding window.
    pub fn window_totals(&self, now: Micros) -> (u64, u64) {
        self.sources.values().fold((0, 0), |(r, l), s| {
            let (wr, wl) = s.seq.window_counts(now);
            (r + wr, l + wl)
        })
    }
}

impl LinkStatus {
    /// Called from the core's timers: on the first call in a new second, the loss of the frames
    /// counted since the last sample goes into [`LinkStatus::loss_history`] as the previous
    /// second's. A second without frames has no value.
    pub fn sample_loss(&mut self, now: Micros) {
        let sec = now / SECOND;
        if sec <= self.loss_mark.0 {
            return;
        }
        let totals = self.totals();
        let (r0, l0) = self.loss_mark.1;
        // Totals can shrink (a source evicted, a late frame un-counting a loss): no negatives.
        let (rx, lost) = (totals.0.saturating_sub(r0), totals.1.saturating_sub(l0));
        if rx + lost > 0 {
            self.loss_history
                .set((sec - 1) * SECOND, loss_pct((rx, lost)) as f32);
        }
        self.loss_mark = (sec, totals);
    }
}

/// Loss percent from (received, lost).
pub fn loss_pct((received, lost): (u64, u64)) -> f64 {
    crate::proto::loss::pct(lost, received)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rate_meter_averages_completed_seconds() {
        let mut r = RateMeter::default();
        for s in 0..5u64 {
            for i in 0..10u64 {
                r.add(s * SECOND + i * 100_000, 1, 20);
            }
        }
        let (f, b) = r.rates(5 * SECOND + 1);
        assert_eq!((f, b), (10.0, 200.0));
        // Silence: rates fall to zero once the window has passed.
        assert_eq!(r.rates(20 * SECOND), (0.0, 0.0));
    }

    #[test]
    fn loss_history_has_one_value_per_second_with_frames() {
        let mut l = LinkStatus::new("test".into(), 255, 190);
        // Second 0: 10 frames, none lost. Second 1: 8 frames after 2 lost. Second 2: silent.
        let mut seq = 0u8;
        for (sec, frames, skip) in [(0u64, 10u8, 0u8), (1, 8, 2)] {
            l.sample_loss(sec * SECOND);
            for i in 0..frames {
                if i == 1 {
                    seq = seq.wrapping_add(skip);
                }
                l.source(VehicleKey(1, 1))
                    .seq
                    .record(seq, sec * SECOND + i as u64 * 1000);
                seq = seq.wrapping_add(1);
            }
        }
        l.sample_loss(2 * SECOND);
        l.sample_loss(2 * SECOND + 500_000); // the same second: nothing more
        l.sample_loss(3 * SECOND);
        assert_eq!(
            l.loss_history.recent(2 * SECOND, 3),
            vec![Some(0.0), Some(20.0), None]
        );
    }
}
