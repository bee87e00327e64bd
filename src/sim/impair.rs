//! The simulated link on the way out: loss, duplication, reordering, bit-flip corruption,
//! latency and a radio-like byte-rate queue, with ground-truth counters per vehicle so tests
//! can check what a GCS measures against what really happened.

use super::rng::Rng;
use crate::clock::Micros;
use std::collections::{BTreeMap, VecDeque};

/// What happened to one vehicle's frames. `dropped` includes frames lost to a full radio queue
/// (also counted in `queue_overflow`): to the receiver both are missing sequence numbers.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct LinkTruth {
    /// Frames the vehicle sent (each consumed a sequence number).
    pub generated: u64,
    pub dropped: u64,
    pub duplicated: u64,
    pub reordered: u64,
    pub corrupted: u64,
    pub queue_overflow: u64,
    /// Frames from the GCS to this vehicle thrown away by `impair_in`.
    pub inbound_dropped: u64,
}

/// Ground truth of the impairments, per vehicle sysid.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize)]
pub struct SimTruth {
    pub per_sysid: BTreeMap<u8, LinkTruth>,
}

impl SimTruth {
    /// Counters for one vehicle (all zero if it sent nothing).
    pub fn get(&self, sysid: u8) -> LinkTruth {
        self.per_sysid.get(&sysid).copied().unwrap_or_default()
    }
}

/// Knobs, copied from the config.
#[derive(Debug, Clone, Copy, Default)]
pub struct ImpairConfig {
    pub loss: f64,
    pub dup: f64,
    pub reorder: f64,
    pub corrupt: f64,
    pub latency: Micros,
    pub baud: Option<u32>,
}

/// Header length of a MAVLink 2 frame: corruption flips bits after it.
const V2_HEADER: usize = 10;

#[derive(Debug, Clone)]
pub struct Impairer {
    cfg: ImpairConfig,
    rng: Rng,
    held: Option<(u8, Vec<u8>)>,
    queue: VecDeque<(Micros, Vec<u8>)>,
    busy_until: Micros,
    truth: SimTruth,
}

impl Impairer {
    pub fn new(cfg: ImpairConfig, rng: Rng) -> Impairer {
        Impairer {
            cfg,
            rng,
            held: None,
            queue: VecDeque::new(),
            busy_until: 0,
            truth: SimTruth::default(),
        }
    }

    pub fn truth(&self) -> &SimTruth {
        &self.truth
    }

    pub fn truth_mut(&mut self) -> &mut SimTruth {
        &mut self.truth
    }

    /// A frame from vehicle `sysid`, generated at `t` (non-decreasing between calls).
    pub fn push(&mut self, t: Micros, sysid: u8, mut frame: Vec<u8>) {
        let c = self.cfg;
        let truth = self.truth.per_sysid.entry(sysid).or_default();
        truth.generated += 1;
        if self.rng.chance(c.loss) {
            truth.dropped += 1;
            return;
        }
        if self.rng.chance(c.corrupt) && frame.len() > V2_HEADER {
            // Only payload and CRC bytes: the receiver then sees exactly one CRC failure. A flip
            // in the length byte would make it swallow the next frame too, muddling the count.
            let span = (frame.len() - V2_HEADER) as u64;
            let i = V2_HEADER + self.rng.below(span) as usize;
            frame[i] ^= 1 << self.rng.below(8);
            truth.corrupted += 1;
        }
        let copies = if self.rng.chance(c.dup) {
            truth.duplicated += 1;
            2
        } else {
            1
        };
        for _ in 0..copies {
            if let Some((held_sysid, held)) = self.held.take() {
                self.enqueue(t, sysid, frame.clone());
                self.enqueue(t, held_sysid, held);
                continue;
            }
            if self.rng.chance(c.reorder) {
                self.truth.per_sysid.entry(sysid).or_default().reordered += 1;
                self.held = Some((sysid, frame.clone()));
                continue;
            }
            self.enqueue(t, sysid, frame.clone());
        }
    }

    /// Radio queue: frames leave one after another at `baud` (10 bits per byte, as on a UART).
    /// A frame that would wait longer than half a second is dropped, like a full radio buffer.
    fn enqueue(&mut self, t: Micros, sysid: u8, frame: Vec<u8>) {
        let release = t.saturating_add(self.cfg.latency);
        let due = match self.cfg.baud {
            None => release,
            Some(baud) => {
                let start = release.max(self.busy_until);
                if start - release > 500_000 {
                    let truth = self.truth.per_sysid.entry(sysid).or_default();
                    truth.dropped += 1;
                    truth.queue_overflow += 1;
                    return;
                }
                let dur = (frame.len() as u64 * 10 * 1_000_000).div_ceil(baud as u64);
                self.busy_until = start.saturating_add(dur);
                self.busy_until
            }
        };
        self.queue.push_back((due, frame));
    }

    /// Send a frame held back for reordering now, instead of after the next frame.
    pub fn flush_held(&mut self, t: Micros) {
        if let Some((sysid, f)) = self.held.take() {
            self.enqueue(t, sysid, f);
        }
    }

    /// Bytes of every frame due by `now`, in order.
    pub fn take_due(&mut self, now: Micros) -> Vec<u8> {
        let mut out = Vec::new();
        while let Some((due, _)) = self.queue.front() {
            if *due > now {
                break;
            }
            let (_, f) = self.queue.pop_front().expect("front checked");
            out.extend_from_slice(&f);
        }
        out
    }

    /// When the radio has sent everything queued (the UART's backlog ends).
    pub fn busy_until(&self) -> Micros {
        self.busy_until
    }

    /// When the next queued frame is due.
    pub fn next_due(&self) -> Option<Micros> {
        self.queue.front().map(|(d, _)| *d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(seq: u8) -> Vec<u8> {
        let mut f = vec![0xFD, 9, 0, 0, seq, 1, 1, 0, 0, 0];
        f.extend_from_slice(&[seq; 11]);
        f
    }

    #[test]
    fn clean_link_passes_everything_in_order() {
        let mut im = Impairer::new(ImpairConfig::default(), Rng::new(1));
        for s in 0..10 {
            im.push(s as u64, 1, frame(s));
        }
        let out = im.take_due(100);
        assert_eq!(out.len(), 10 * 21);
        assert_eq!(im.truth().get(1).generated, 10);
        assert_eq!(im.truth().get(1).dropped, 0);
    }

    #[test]
    fn counts_match_what_comes_out() {
        let cfg = ImpairConfig {
            loss: 0.1,
            dup: 0.1,
            reorder: 0.1,
            corrupt: 0.1,
            ..Default::default()
        };
        let mut im = Impairer::new(cfg, Rng::new(9));
        let n = 5000;
        for i in 0..n {
            im.push(i, 1, frame(i as u8));
        }
        im.flush_held(n);
        let out = im.take_due(u64::MAX);
        let t = im.truth().get(1);
        assert_eq!(t.generated, n);
        let frames_out = (out.len() / 21) as u64;
        assert_eq!(frames_out, n - t.dropped + t.duplicated);
        for (name, v) in [
            ("dropped", t.dropped),
            ("dup", t.duplicated),
            ("reorder", t.reordered),
            ("corrupt", t.corrupted),
        ] {
            assert!((350..650).contains(&v), "{name} = {v}");
        }
        // Corruption never touches the header.
        for f in out.chunks(21) {
            assert_eq!(&f[..4], &[0xFD, 9, 0, 0]);
        }
    }

    #[test]
    fn latency_and_baud_delay_and_overflow() {
        let cfg = ImpairConfig {
            latency: 50_000,
            baud: Some(2100), // 210 bytes/s: one 21-byte frame per 100 ms
            ..Default::default()
        };
        let mut im = Impairer::new(cfg, Rng::new(1));
        im.push(0, 1, frame(0));
        im.push(0, 1, frame(1));
        assert!(im.take_due(149_999).is_empty());
        assert_eq!(im.take_due(150_000).len(), 21);
        assert_eq!(im.next_due(), Some(250_000));
        for s in 0..20 {
            im.push(200_000, 1, frame(s));
        }
        let t = im.truth().get(1);
        assert!(
            t.queue_overflow > 0 && t.dropped == t.queue_overflow,
            "{t:?}"
        );
    }
}
