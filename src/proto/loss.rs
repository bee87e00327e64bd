//! Packet loss from MAVLink sequence numbers, per source (sysid, compid) on one link.
//!
//! Every MAVLink frame carries an 8-bit sequence number that its sender increments per frame sent
//! (on that channel). The rule, for a frame with sequence `s` after the last in-order `last`:
//!
//! - `d = (s - last) mod 256`. `d == 1` is the next frame: nothing lost, however long the silence
//!   before it. Wrap 255 → 0 is `d == 1`.
//! - `d == 0`: the same frame again → a **duplicate**, not loss, however long the silence before it
//!   (a sender that never increments its sequence is one frame and its duplicates).
//! - After [`RESTART_SILENCE`] of silence (nothing heard from the source), any other jump `d` is
//!   judged against the sender's measured frame rate (below): over the time `t` since the frame
//!   that set `last`, the sequence should have moved by `n = rate × t`. The jump **fits** when
//!   `|d − n| ≤ n/2 + JUMP_SLACK` (4 frames), `d + 256` does not fit as well, and `n < 256` (after
//!   a lap or more the sequence cannot tell how many laps went by). A jump that fits is a forward
//!   gap: `d − 1` **lost**, pymavlink's `(s − (last + 1)) mod 256`, across the wrap or not. A jump
//!   that does not fit is a **restart** (vehicle reboot, another sender): the count restarts at
//!   `s`, nothing lost. Before the rate is known (one frame so far) `n = 0`, so only `d ≤ 4` fits.
//!   For example, at 50 Hz with `last = 200` and 3.02 s of silence, `n = 151`: `s = 95` (`d = 151`)
//!   is 150 lost; `s = 0` (`d = 56`) is a restart. A 0.4 Hz sender goes quiet for 2.5 s between
//!   frames; its 255 → 0 is `d == 1`, and 254 → 0 (`n = 2`, `d = 2`) is 1 lost.
//! - Without the silence, a small backward jump (`last - s` mod 256 within [`REORDER_WINDOW`] = 16)
//!   is a late frame that was earlier counted lost. It moves one count from lost to **reordered**,
//!   unless that sequence was already received, in which case it is a **duplicate**.
//! - Otherwise (no silence) a forward gap: `d - 1` frames **lost**. A larger backward jump is a
//!   forward gap too: the sequence cannot tell them apart, and a sender cannot reboot without
//!   going quiet.
//!
//! The rate is sequence steps per second over the last [`RATE_SECS`] seconds of the current count
//! (since its first frame or restart), up to the frame that set `last`. Each advancing frame's `d`
//! steps are spread evenly over the time since the previous one, so a slow sender's rate is as
//! exact as a fast one's. The busiest of those seconds is left out once the others cover at least
//! a second, so a single burst (a parameter download, a gap counted without silence) does not make
//! the sender look faster than it is.
//!
//! [`SeqTracker::restart_sequence`] (a link reconnected) makes the next frame start a fresh count,
//! like the very first frame: nothing lost, no restart.
//!
//! `received` counts distinct frames (duplicates excluded), so loss % = lost / (received + lost),
//! both since start and over a sliding 10 s window of one-second buckets.

use crate::clock::{Micros, SECOND};

/// How far back a late frame may be to count as reordered rather than a gap.
pub const REORDER_WINDOW: u8 = 16;
/// Silence after which a jump is judged against the sender's rate (loss or restart).
pub const RESTART_SILENCE: Micros = 2 * SECOND;
/// Frames of slack, on top of ±50 %, between the expected and the actual jump after a silence.
pub const JUMP_SLACK: f64 = 4.0;
/// Seconds of history the sender's frame rate is measured over.
pub const RATE_SECS: u64 = 10;
/// Length of the sliding loss window.
pub const WINDOW_SECS: u64 = 10;

/// What one frame did to the count.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SeqOutcome {
    First,
    InOrder,
    Gap(u8),
    Duplicate,
    Reordered,
    Restart,
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct Bucket {
    sec: u64,
    received: u64,
    lost: i64,
}

/// Sequence steps within one second, for the rate.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct RateBucket {
    sec: u64,
    steps: f64,
}

/// Sequence tracking and loss counters for one source on one link.
#[derive(Debug, Clone)]
pub struct SeqTracker {
    first: Option<u8>,
    last: Option<u8>,
    /// Time of the last frame of any kind (silence is measured from here).
    last_time: Micros,
    /// Time of the frame that set `last`.
    last_advance: Micros,
    /// Time of the first frame of the current count (first frame, restart or reconnect).
    count_start: Micros,
    /// Which of the 256 sequence numbers have been received in the current lap (bit per seq).
    seen: [u64; 4],
    pub received: u64,
    pub lost: u64,
    pub duplicates: u64,
    pub reordered: u64,
    pub restarts: u64,
    window: [Bucket; WINDOW_SECS as usize],
    rate: [RateBucket; RATE_SECS as usize],
    /// The second of the last advance, once its window and rate buckets are set: the next
    /// frame in order within that second is counted without dividing time again.
    same_second: Option<SameSecond>,
}

/// Where the counts of the second of the last advance go.
#[derive(Debug, Clone, Copy)]
struct SameSecond {
    start: Micros,
    window: usize,
    rate: usize,
}

impl Default for SeqTracker {
    fn default() -> Self {
        Self {
            first: None,
            last: None,
            last_time: 0,
            last_advance: 0,
            count_start: 0,
            seen: [0; 4],
            received: 0,
            lost: 0,
            duplicates: 0,
            reordered: 0,
            restarts: 0,
            window: [Bucket::default(); WINDOW_SECS as usize],
            rate: [RateBucket::default(); RATE_SECS as usize],
            same_second: None,
        }
    }
}

impl SeqTracker {
    pub fn new() -> Self {
        Self::default()
    }

    fn is_seen(&self, s: u8) -> bool {
        self.seen[(s >> 6) as usize] & (1 << (s & 63)) != 0
    }
    fn set_seen(&mut self, s: u8, v: bool) {
        let bit = 1u64 << (s & 63);
        if v {
            self.seen[(s >> 6) as usize] |= bit;
        } else {
            self.seen[(s >> 6) as usize] &= !bit;
        }
    }

    #[inline]
    fn bucket(&mut self, now: Micros) -> &mut Bucket {
        let sec = now / SECOND;
        let b = &mut self.window[(sec % WINDOW_SECS) as usize];
        if b.sec != sec {
            *b = Bucket {
                sec,
                received: 0,
                lost: 0,
            };
        }
        b
    }

    /// Start a new count at `seq` (first frame, restart, reconnect): no loss, fresh rate history.
    fn begin(&mut self, seq: u8, now: Micros) {
        self.first = Some(seq);
        self.last = Some(seq);
        self.seen = [0; 4];
        self.set_seen(seq, true);
        self.last_advance = now;
        self.count_start = now;
        self.rate = [RateBucket::default(); RATE_SECS as usize];
        self.same_second = None;
        self.received += 1;
        self.bucket(now).received += 1;
    }

    /// Move `last` forward by `d` to `seq`: `d - 1` lost.
    #[inline]
    fn advance(&mut self, seq: u8, d: u8, now: Micros) -> SeqOutcome {
        let last = self.last.unwrap_or(seq);
        let mut s = last;
        for _ in 1..d {
            s = s.wrapping_add(1);
            self.set_seen(s, false);
        }
        self.set_seen(seq, true);
        self.last = Some(seq);
        self.spread_steps(d, self.last_advance, now);
        self.last_advance = now;
        self.received += 1;
        let gap = d - 1;
        self.lost += gap as u64;
        let b = self.bucket(now);
        b.received += 1;
        b.lost += gap as i64;
        let sec = now / SECOND;
        self.rate_bucket(sec);
        self.same_second = Some(SameSecond {
            start: sec * SECOND,
            window: (sec % WINDOW_SECS) as usize,
            rate: (sec % RATE_SECS) as usize,
        });
        if gap == 0 {
            SeqOutcome::InOrder
        } else {
            SeqOutcome::Gap(gap)
        }
    }

    /// Add `steps` sequence steps to the rate history, spread evenly over `from..to`.
    #[inline]
    fn spread_steps(&mut self, steps: u8, from: Micros, to: Micros) {
        let to_sec = to / SECOND;
        if to <= from || from / SECOND == to_sec {
            // All in one second (the usual case): what the spreading below gives exactly, as
            // `steps * span / span` is `steps` for integers this small.
            self.rate_bucket(to_sec).steps += steps as f64;
        } else {
            self.spread_steps_over_seconds(steps, from, to);
        }
    }

    #[inline(never)]
    fn spread_steps_over_seconds(&mut self, steps: u8, from: Micros, to: Micros) {
        let to_sec = to / SECOND;
        let steps = steps as f64;
        let span = (to - from) as f64;
        for sec in (from / SECOND).max(to_sec.saturating_sub(RATE_SECS - 1))..=to_sec {
            let lo = from.max(sec * SECOND);
            let hi = to.min((sec + 1) * SECOND);
            if hi > lo {
                self.rate_bucket(sec).steps += steps * (hi - lo) as f64 / span;
            }
        }
    }

    #[inline]
    fn rate_bucket(&mut self, sec: u64) -> &mut RateBucket {
        let b = &mut self.rate[(sec % RATE_SECS) as usize];
        if b.sec != sec {
            *b = RateBucket { sec, steps: 0.0 };
        }
        b
    }

    /// The sender's frame rate (sequence steps per second) over the last [`RATE_SECS`] of the
    /// current count up to the frame that set `last`, without its busiest second once the others
    /// cover a second or more. `None` until the count has two frames at different times.
    pub fn rate(&self) -> Option<f64> {
        let (start, at) = (self.count_start, self.last_advance);
        if self.last.is_none() || at <= start {
            return None;
        }
        let at_sec = at / SECOND;
        let mut steps = 0.0;
        let mut covered: Micros = 0;
        // (rate, steps, covered) of the busiest second.
        let mut busiest = (-1.0, 0.0, 0);
        for sec in (start / SECOND).max(at_sec.saturating_sub(RATE_SECS - 1))..=at_sec {
            let lo = start.max(sec * SECOND);
            let hi = at.min((sec + 1) * SECOND);
            if hi <= lo {
                continue;
            }
            let b = self.rate[(sec % RATE_SECS) as usize];
            let s = if b.sec == sec { b.steps } else { 0.0 };
            let c = hi - lo;
            steps += s;
            covered += c;
            let r = s / c as f64;
            if r > busiest.0 {
                busiest = (r, s, c);
            }
        }
        if covered - busiest.2 >= SECOND {
            steps -= busiest.1;
            covered -= busiest.2;
        }
        Some(steps * SECOND as f64 / covered as f64)
    }

    /// Whether a jump of `d` after a silence is a forward gap (see the module doc).
    fn jump_fits(&self, d: u8, now: Micros) -> bool {
        let elapsed = now.saturating_sub(self.last_advance) as f64 / SECOND as f64;
        let n = self.rate().unwrap_or(0.0) * elapsed;
        let tol = n / 2.0 + JUMP_SLACK;
        let fits = |jump: f64| (jump - n).abs() <= tol;
        n < 256.0 && fits(d as f64) && !fits(d as f64 + 256.0)
    }

    /// Count a frame with sequence `seq` heard at `now`.
    pub fn record(&mut self, seq: u8, now: Micros) -> SeqOutcome {
        if self.last.is_some_and(|last| seq == last.wrapping_add(1)) {
            // The next frame, the usual case: what the rules below come to for `d == 1`.
            self.last_time = now;
            if let Some(same) = self
                .same_second
                .filter(|s| now >= s.start && now - s.start < SECOND)
            {
                // In the second of the last advance: `advance(seq, 1, now)` with its buckets
                // already found.
                self.set_seen(seq, true);
                self.last = Some(seq);
                self.rate[same.rate].steps += 1.0;
                self.last_advance = now;
                self.received += 1;
                self.window[same.window].received += 1;
                return SeqOutcome::InOrder;
            }
            return self.advance(seq, 1, now);
        }
        self.record_other(seq, now)
    }

    #[inline(never)]
    fn record_other(&mut self, seq: u8, now: Micros) -> SeqOutcome {
        let silence = now.saturating_sub(self.last_time);
        let outcome = match self.last {
            None => {
                self.begin(seq, now);
                SeqOutcome::First
            }
            Some(last) => {
                let d = seq.wrapping_sub(last);
                let back = last.wrapping_sub(seq);
                if d == 0 {
                    self.duplicates += 1;
                    SeqOutcome::Duplicate
                } else if silence >= RESTART_SILENCE && d != 1 {
                    if self.jump_fits(d, now) {
                        self.advance(seq, d, now)
                    } else {
                        // A jump the sender's rate cannot explain: it restarted.
                        self.restarts += 1;
                        self.begin(seq, now);
                        SeqOutcome::Restart
                    }
                } else if back <= REORDER_WINDOW {
                    if self.is_seen(seq) {
                        self.duplicates += 1;
                        SeqOutcome::Duplicate
                    } else {
                        self.set_seen(seq, true);
                        self.received += 1;
                        self.reordered += 1;
                        if self.lost > 0 {
                            self.lost -= 1;
                        }
                        let b = self.bucket(now);
                        b.received += 1;
                        b.lost -= 1;
                        SeqOutcome::Reordered
                    }
                } else {
                    self.advance(seq, d, now)
                }
            }
        };
        self.last_time = now;
        outcome
    }

    /// Make the next frame start a fresh count, as the first frame does: no loss and no restart
    /// counted for its jump (a link reconnected, e.g. a new TCP connection). Counters are kept.
    pub fn restart_sequence(&mut self) {
        self.last = None;
        self.seen = [0; 4];
    }

    /// Loss since start, in percent.
    pub fn loss_pct(&self) -> f64 {
        pct(self.lost, self.received)
    }

    /// (received, lost) over the last [`WINDOW_SECS`] seconds before `now`.
    pub fn window_counts(&self, now: Micros) -> (u64, u64) {
        let cur = now / SECOND;
        let mut rx = 0u64;
        let mut lost = 0i64;
        for b in &self.window {
            if b.sec + WINDOW_SECS > cur && b.sec <= cur && (b.received > 0 || b.lost != 0) {
                rx += b.received;
                lost += b.lost;
            }
        }
        (rx, lost.max(0) as u64)
    }

    /// Loss over the sliding window, in percent.
    pub fn window_loss_pct(&self, now: Micros) -> f64 {
        let (rx, lost) = self.window_counts(now);
        pct(lost, rx)
    }

    /// Sequence number of the newest in-order frame (`None` before the first frame and after
    /// [`SeqTracker::restart_sequence`] until the next one).
    pub fn last_seq(&self) -> Option<u8> {
        self.last
    }

    /// Sequence number of the first frame of the current count (after the last restart).
    pub fn first_seq(&self) -> Option<u8> {
        self.first
    }

    /// Time of the last frame.
    pub fn last_time(&self) -> Micros {
        self.last_time
    }
}

/// Loss percent: lost / (received + lost), 0 when nothing was expected.
pub fn pct(lost: u64, received: u64) -> f64 {
    if received + lost == 0 {
        0.0
    } else {
        100.0 * lost as f64 / (received + lost) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Feed `seqs` 10 ms apart starting at t=0.
    fn run(seqs: &[u8]) -> SeqTracker {
        let mut t = SeqTracker::new();
        for (i, s) in seqs.iter().enumerate() {
            t.record(*s, i as u64 * 10_000);
        }
        t
    }

    #[test]
    fn none_lost() {
        let seqs: Vec<u8> = (0..=255u8).chain(0..50).collect();
        let t = run(&seqs);
        assert_eq!(
            (t.received, t.lost, t.duplicates, t.reordered),
            (306, 0, 0, 0)
        );
        assert_eq!(t.loss_pct(), 0.0);
    }

    #[test]
    fn every_other_frame_lost_is_50_percent() {
        let seqs: Vec<u8> = (0..200u32).map(|i| (i * 2 % 256) as u8).collect();
        let t = run(&seqs);
        assert_eq!(t.received, 200);
        assert_eq!(t.lost, 199);
        assert!((t.loss_pct() - 49.87).abs() < 0.01, "{}", t.loss_pct());
    }

    #[test]
    fn wrap_is_not_a_gap_but_a_gap_across_wrap_is() {
        let t = run(&[253, 254, 255, 0, 1]);
        assert_eq!(t.lost, 0);
        let t = run(&[254, 255, 2, 3]); // 0 and 1 lost across the wrap
        assert_eq!(t.lost, 2);
    }

    #[test]
    fn duplicates_are_not_loss() {
        let t = run(&[1, 2, 2, 3, 3, 3, 4]);
        assert_eq!((t.received, t.lost, t.duplicates), (4, 0, 3));
        // An older frame repeated (already received) is a duplicate, not a reorder.
        let t = run(&[1, 2, 3, 4, 2]);
        assert_eq!(
            (t.received, t.lost, t.duplicates, t.reordered),
            (4, 0, 1, 0)
        );
    }

    #[test]
    fn reordered_frame_moves_from_lost_to_reordered() {
        let t = run(&[1, 2, 4, 3, 5]);
        assert_eq!(
            (t.received, t.lost, t.reordered, t.duplicates),
            (5, 0, 1, 0)
        );
        let t = run(&[10, 12, 13, 14, 11, 15]);
        assert_eq!((t.received, t.lost, t.reordered), (6, 0, 1));
    }

    #[test]
    fn restart_after_silence_is_not_loss() {
        let mut t = SeqTracker::new();
        for (i, s) in (100..200u8).enumerate() {
            t.record(s, i as u64 * 10_000);
        }
        // Reboot: 3 s of silence, then sequence starts again at 0.
        let t0 = 4 * SECOND;
        for (i, s) in (0..10u8).enumerate() {
            t.record(s, t0 + i as u64 * 10_000);
        }
        assert_eq!((t.lost, t.restarts, t.received), (0, 1, 110));
    }

    #[test]
    fn reboot_to_a_nearby_lower_seq_is_a_restart_not_a_reorder() {
        let mut t = SeqTracker::new();
        for (i, s) in (0..10u8).enumerate() {
            t.record(s, i as u64 * 10_000);
        }
        // Rebooted after 3 s: starts again at 0, only 9 below the last seq.
        assert_eq!(t.record(0, 3 * SECOND), SeqOutcome::Restart);
        assert_eq!(t.record(1, 3 * SECOND + 10_000), SeqOutcome::InOrder);
        assert_eq!(
            (t.lost, t.reordered, t.duplicates, t.restarts),
            (0, 0, 0, 1)
        );
    }

    #[test]
    fn backward_jump_without_silence_counts_as_gap() {
        // 100 then 50 straight away: that is a forward gap of 205 (seq wrapped past our view).
        let t = run(&[100, 50]);
        assert_eq!((t.lost, t.restarts), (205, 0));
    }

    /// 250 frames at 50 Hz from t = 0 ending at `last` = 200 (t = 4.98 s).
    fn fifty_hz_to_200() -> SeqTracker {
        let mut t = SeqTracker::new();
        for i in 0..250u64 {
            t.record(207u8.wrapping_add(i as u8), i * 20_000);
        }
        assert_eq!((t.last_seq(), t.last_time()), (Some(200), 4_980_000));
        t
    }

    #[test]
    fn slow_sender_wrapping_after_silence_is_neither_loss_nor_restart() {
        // 0.4 Hz: every frame follows 2.5 s of silence.
        let mut t = SeqTracker::new();
        let seqs = (250..=255u8).chain(0..=5);
        for (i, s) in seqs.enumerate() {
            t.record(s, i as u64 * 2_500_000);
        }
        assert_eq!((t.received, t.lost, t.restarts), (12, 0, 0));
        // One frame (255) lost across the wrap: 5 s at 0.4 Hz is n = 2 steps, d = 2.
        let mut t = SeqTracker::new();
        for (i, s) in (250..=254u8).enumerate() {
            t.record(s, i as u64 * 2_500_000);
        }
        assert_eq!(t.record(0, 15 * SECOND), SeqOutcome::Gap(1));
        assert_eq!(t.record(1, 17_500_000), SeqOutcome::InOrder);
        assert_eq!((t.received, t.lost, t.restarts), (7, 1, 0));
    }

    #[test]
    fn fast_stream_fading_across_the_wrap_is_loss() {
        // The 150 frames sent in the 3 s after 200 are lost; 95 arrives 3.02 s after 200.
        // pymavlink: (95 - (200 + 1)) mod 256 = 150.
        let mut t = fifty_hz_to_200();
        assert_eq!(t.record(95, 8 * SECOND), SeqOutcome::Gap(150));
        assert_eq!(t.record(96, 8 * SECOND + 20_000), SeqOutcome::InOrder);
        assert_eq!((t.received, t.lost, t.restarts), (252, 150, 0));
    }

    #[test]
    fn fast_stream_back_to_zero_after_silence_is_a_restart() {
        // 3.02 s at 50 Hz should move the sequence ~151, not 56 (200 -> 0).
        let mut t = fifty_hz_to_200();
        assert_eq!(t.record(0, 8 * SECOND), SeqOutcome::Restart);
        assert_eq!(t.record(1, 8 * SECOND + 20_000), SeqOutcome::InOrder);
        assert_eq!((t.received, t.lost, t.restarts), (252, 0, 1));
        assert_eq!(t.first_seq(), Some(0));
    }

    #[test]
    fn silence_longer_than_a_lap_is_a_restart() {
        // 6.02 s at 50 Hz is 301 steps: 200 -> 245 (d = 45, or 301?) cannot be told apart.
        let mut t = fifty_hz_to_200();
        assert_eq!(t.record(245, 11 * SECOND), SeqOutcome::Restart);
        assert_eq!((t.lost, t.restarts), (0, 1));
    }

    #[test]
    fn constant_sequence_sender_is_duplicates_not_restarts() {
        // 0.5 Hz, always sequence 7: every frame after the first follows 2 s of silence.
        let mut t = SeqTracker::new();
        assert_eq!(t.record(7, 0), SeqOutcome::First);
        for i in 1..10u64 {
            assert_eq!(t.record(7, i * 2 * SECOND), SeqOutcome::Duplicate);
        }
        assert_eq!((t.received, t.duplicates, t.lost, t.restarts), (1, 9, 0, 0));
    }

    #[test]
    fn a_burst_does_not_make_a_slow_sender_look_fast() {
        let mut t = SeqTracker::new();
        // 1 Hz: 0..=5 at 0..=5 s; a burst of 60 frames (6..=65) from 5.5 s, 1 ms apart; then
        // 66..=69 at 6..=9 s.
        for s in 0..=5u8 {
            t.record(s, s as u64 * SECOND);
        }
        for k in 0..60u64 {
            t.record(6 + k as u8, 5_500_000 + k * 1000);
        }
        for s in 66..=69u8 {
            t.record(s, (s as u64 - 60) * SECOND);
        }
        assert!((t.rate().unwrap() - 1.0).abs() < 1e-9, "{:?}", t.rate());
        // 70, 71, 72 lost; 73 after 4 s of silence: 3 lost, not a restart.
        assert_eq!(t.record(73, 13 * SECOND), SeqOutcome::Gap(3));
        assert_eq!((t.lost, t.restarts), (3, 0));
    }

    #[test]
    fn jump_after_silence_before_any_rate_is_known() {
        // One frame, then 3 s of silence: no rate yet, so only a jump of up to 4 is loss.
        let mut t = SeqTracker::new();
        t.record(10, 0);
        assert_eq!(t.rate(), None);
        assert_eq!(t.record(12, 3 * SECOND), SeqOutcome::Gap(1));
        let mut t = SeqTracker::new();
        t.record(10, 0);
        assert_eq!(t.record(100, 3 * SECOND), SeqOutcome::Restart);
        assert_eq!((t.lost, t.restarts), (0, 1));
    }

    #[test]
    fn restart_sequence_starts_a_fresh_count() {
        let mut t = run(&(0..=50).collect::<Vec<u8>>());
        t.restart_sequence();
        // A new connection: the sender's sequence is elsewhere, straight away.
        assert_eq!(t.record(200, 510_000), SeqOutcome::First);
        assert_eq!(t.record(201, 520_000), SeqOutcome::InOrder);
        assert_eq!(t.record(203, 530_000), SeqOutcome::Gap(1));
        assert_eq!((t.received, t.lost, t.restarts), (54, 1, 0));
        assert_eq!(t.first_seq(), Some(200));
    }

    #[test]
    fn sliding_window_forgets_old_loss() {
        let mut t = SeqTracker::new();
        // First 5 s: 50 % loss (every other seq), 10 frames/s.
        let mut seq = 0u8;
        for i in 0..50u64 {
            t.record(seq, i * 100_000);
            seq = seq.wrapping_add(2);
        }
        let now = 5 * SECOND;
        let (rx, lost) = t.window_counts(now);
        assert_eq!((rx, lost), (50, 49));
        // Next 12 s: no loss.
        for i in 50..170u64 {
            seq = seq.wrapping_add(1);
            t.record(seq, i * 100_000);
        }
        let now = 17 * SECOND - 1;
        let (rx, lost) = t.window_counts(now);
        assert_eq!(lost, 0);
        assert!(rx >= 90, "{rx}");
        assert_eq!(t.window_loss_pct(now), 0.0);
        assert!(t.loss_pct() > 20.0); // total still remembers
    }
}
