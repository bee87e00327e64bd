//! Packet loss from MAVLink sequence numbers, per source (sysid, compid) on one link.
//!
//! Every MAVLink frame carries an 8-bit sequence number that its sender increments per frame sent
//! (on that channel). The rule, for a frame with sequence `s` after the last in-order `last`:
//!
//! - `d = (s - last) mod 256`. `d == 1` is the next frame: nothing lost. Wrap 255 → 0 is `d == 1`.
//! - `d == 0`: the same frame again → a **duplicate**, not loss.
//! - A small backward jump (`last - s` mod 256 within [`REORDER_WINDOW`] = 16): a late frame that
//!   was earlier counted lost. It moves one count from lost to **reordered**, unless that sequence
//!   was already received, in which case it is a **duplicate**.
//! - A larger jump backward (numerically lower `s`, or the same `s`) after [`RESTART_SILENCE`] of
//!   silence (vehicle reboot, new link): the count **restarts** at `s` instead of adding ~200 lost.
//!   Without the silence, the same jump is a forward gap: the sequence cannot tell them apart, and
//!   a sender cannot reboot without going quiet.
//! - Otherwise a forward gap: `d - 1` frames **lost**.
//!
//! `received` counts distinct frames (duplicates excluded), so loss % = lost / (received + lost),
//! both since start and over a sliding 10 s window of one-second buckets.

use crate::clock::{Micros, SECOND};

/// How far back a late frame may be to count as reordered rather than a restart or a gap.
pub const REORDER_WINDOW: u8 = 16;
/// Silence after which a backward jump is taken as a restart of the sender.
pub const RESTART_SILENCE: Micros = 2 * SECOND;
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

/// Sequence tracking and loss counters for one source on one link.
#[derive(Debug, Clone)]
pub struct SeqTracker {
    first: Option<u8>,
    last: Option<u8>,
    last_time: Micros,
    /// Which of the 256 sequence numbers have been received in the current lap (bit per seq).
    seen: [u64; 4],
    pub received: u64,
    pub lost: u64,
    pub duplicates: u64,
    pub reordered: u64,
    pub restarts: u64,
    window: [Bucket; WINDOW_SECS as usize],
}

impl Default for SeqTracker {
    fn default() -> Self {
        Self {
            first: None,
            last: None,
            last_time: 0,
            seen: [0; 4],
            received: 0,
            lost: 0,
            duplicates: 0,
            reordered: 0,
            restarts: 0,
            window: [Bucket::default(); WINDOW_SECS as usize],
        }
    }
}

impl SeqTracker {
    pub fn new() -> Self {
        Self::default()
    }

    /// Start a fresh count at the next frame, counting neither loss nor a restart (the link
    /// itself reconnected).
    pub fn restart_sequence(&mut self) {
        self.last = None;
        self.seen = [0; 4];
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

    /// Count a frame with sequence `seq` heard at `now`.
    pub fn record(&mut self, seq: u8, now: Micros) -> SeqOutcome {
        let silence = now.saturating_sub(self.last_time);
        let outcome = match self.last {
            None => {
                self.first = Some(seq);
                self.last = Some(seq);
                self.set_seen(seq, true);
                self.received += 1;
                self.bucket(now).received += 1;
                SeqOutcome::First
            }
            Some(last) => {
                let d = seq.wrapping_sub(last);
                let back = last.wrapping_sub(seq);
                if silence >= RESTART_SILENCE && (d == 0 || seq < last) {
                    // Backward (or same) after silence: the sender restarted.
                    self.restarts += 1;
                    self.first = Some(seq);
                    self.seen = [0; 4];
                    self.set_seen(seq, true);
                    self.last = Some(seq);
                    self.received += 1;
                    self.bucket(now).received += 1;
                    SeqOutcome::Restart
                } else if d == 0 {
                    self.duplicates += 1;
                    SeqOutcome::Duplicate
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
                    // Forward by d: d - 1 lost in between.
                    let mut s = last;
                    for _ in 1..d {
                        s = s.wrapping_add(1);
                        self.set_seen(s, false);
                    }
                    self.set_seen(seq, true);
                    self.last = Some(seq);
                    self.received += 1;
                    let gap = d - 1;
                    self.lost += gap as u64;
                    let b = self.bucket(now);
                    b.received += 1;
                    b.lost += gap as i64;
                    if gap == 0 {
                        SeqOutcome::InOrder
                    } else {
                        SeqOutcome::Gap(gap)
                    }
                }
            }
        };
        self.last_time = now;
        outcome
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

    /// Sequence number of the newest in-order frame.
    pub fn last_seq(&self) -> Option<u8> {
        self.last
    }

    /// Sequence number of the first frame heard (after the last restart).
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
