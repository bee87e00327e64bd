//! STATUSTEXT, joined when it comes in chunks.
//!
//! A text longer than 50 bytes is sent as several STATUSTEXTs with the same non-zero `id` and
//! `chunk_seq` 0, 1, 2…; the last chunk is the one whose text ends before 50 bytes (a NUL inside
//! it). `id` 0 is a whole text on its own. A text whose last chunk never comes is shown after
//! [`CHUNK_TIMEOUT`] with `…` where chunks are missing, so nothing the vehicle said is lost.

use std::collections::BTreeMap;

use crate::clock::{Micros, SECOND};
use crate::dialect::{self, MavMessage};
use crate::proto::machine::{Ids, Incoming, Machine, MachineEvent, Out};
use crate::wire::Severity;
use mavlink::MessageData;

/// How long to wait for the rest of a chunked text.
pub const CHUNK_TIMEOUT: Micros = 2 * SECOND;
/// Chunked texts waiting at once, over all sources (a flood cannot grow this).
pub const MAX_PENDING: usize = 32;

/// A finished text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Text {
    pub source: (u8, u8),
    pub severity: Severity,
    pub text: String,
}

#[derive(Debug, Clone)]
struct Pending {
    severity: Severity,
    chunks: BTreeMap<u8, String>,
    started: Micros,
}

/// Joins chunked STATUSTEXTs per (source, id).
#[derive(Debug, Clone, Default)]
pub struct StatusTextJoiner {
    pending: BTreeMap<((u8, u8), u16), Pending>,
}

/// The text of one chunk up to its NUL, and whether it ended there (true: the last chunk).
fn chunk_text(bytes: &[u8]) -> (String, bool) {
    let end = bytes.iter().position(|&b| b == 0);
    let text = String::from_utf8_lossy(&bytes[..end.unwrap_or(bytes.len())]).into_owned();
    (text, end.is_some())
}

fn join(p: Pending, source: (u8, u8)) -> Text {
    let mut text = String::new();
    let mut expect = 0u8;
    for (seq, chunk) in p.chunks {
        if seq != expect {
            text.push('…');
        }
        text.push_str(&chunk);
        expect = seq.wrapping_add(1);
    }
    Text {
        source,
        severity: p.severity,
        text,
    }
}

impl StatusTextJoiner {
    /// One STATUSTEXT; returns the texts it completes: this one when whole, and a text pushed
    /// out unfinished when too many wait at once.
    pub fn push(
        &mut self,
        now: Micros,
        source: (u8, u8),
        severity: Severity,
        text: &[u8],
        id: u16,
        chunk_seq: u8,
    ) -> Vec<Text> {
        let (chunk, last) = chunk_text(text);
        if id == 0 {
            return vec![Text {
                source,
                severity,
                text: chunk,
            }];
        }
        let mut out = Vec::new();
        if self.pending.len() >= MAX_PENDING && !self.pending.contains_key(&(source, id)) {
            // Make room: the oldest waiting text is shown as far as it got.
            let oldest = self
                .pending
                .iter()
                .min_by_key(|(_, p)| p.started)
                .map(|(k, _)| *k);
            if let Some(p) = oldest.and_then(|k| self.pending.remove(&k).map(|p| (k, p))) {
                let mut t = join(p.1, (p.0).0);
                t.text.push('…');
                out.push(t);
            }
        }
        let p = self.pending.entry((source, id)).or_insert(Pending {
            severity,
            chunks: BTreeMap::new(),
            started: now,
        });
        p.chunks.insert(chunk_seq, chunk);
        if last {
            if let Some(p) = self.pending.remove(&(source, id)) {
                out.push(join(p, source));
            }
        }
        out
    }

    /// Texts whose last chunk did not come in time, as far as they got.
    pub fn poll(&mut self, now: Micros) -> Vec<Text> {
        let expired: Vec<_> = self
            .pending
            .iter()
            .filter(|(_, p)| now >= p.started + CHUNK_TIMEOUT)
            .map(|(k, _)| *k)
            .collect();
        expired
            .into_iter()
            .filter_map(|k| {
                let p = self.pending.remove(&k)?;
                let mut t = join(p, k.0);
                t.text.push('…');
                Some(t)
            })
            .collect()
    }

    pub fn next_deadline(&self) -> Option<Micros> {
        self.pending
            .values()
            .map(|p| p.started + CHUNK_TIMEOUT)
            .min()
    }
}

fn text_out(t: Text, late: bool) -> Out {
    Out::Event(MachineEvent::Text {
        from: t.source.into(),
        sev: t.severity,
        text: t.text,
        late,
    })
}

impl Machine for StatusTextJoiner {
    const IDS: Ids = Ids::Only(&[dialect::STATUSTEXT_DATA::ID]);

    /// A chunk: the texts it completes (a text pushed out unfinished to make room included).
    fn on_message(&mut self, m: &Incoming, out: &mut Vec<Out>) {
        let Some(MavMessage::STATUSTEXT(st)) = m.msg else {
            return;
        };
        let texts = self.push(
            m.now,
            m.from,
            st.severity.into(),
            &st.text[..],
            st.id,
            st.chunk_seq,
        );
        out.extend(texts.into_iter().map(|t| text_out(t, false)));
    }

    /// Texts whose last chunk did not come in time.
    fn poll(&mut self, now: Micros, out: &mut Vec<Out>) {
        let texts = StatusTextJoiner::poll(self, now);
        out.extend(texts.into_iter().map(|t| text_out(t, true)));
    }

    fn next_deadline(&self) -> Option<Micros> {
        StatusTextJoiner::next_deadline(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chunk(s: &str) -> [u8; 50] {
        let mut b = [0u8; 50];
        b[..s.len()].copy_from_slice(s.as_bytes());
        b
    }

    #[test]
    fn single_text_with_id_zero() {
        let mut j = StatusTextJoiner::default();
        let t = j.push(
            0,
            (1, 1),
            Severity(6),
            &chunk("PreArm: Need Position Estimate"),
            0,
            0,
        );
        assert_eq!(t[0].text, "PreArm: Need Position Estimate");
    }

    #[test]
    fn chunks_are_joined_in_order() {
        let a = "A".repeat(50);
        let b = "B".repeat(50);
        let mut j = StatusTextJoiner::default();
        assert!(j
            .push(0, (1, 1), Severity(4), a.as_bytes(), 7, 0)
            .is_empty());
        assert!(j
            .push(1, (1, 1), Severity(4), b.as_bytes(), 7, 1)
            .is_empty());
        let t = j
            .push(2, (1, 1), Severity(4), &chunk("end"), 7, 2)
            .remove(0);
        assert_eq!(t.text, format!("{a}{b}end"));
        assert_eq!(t.severity, Severity(4));
        assert_eq!(j.next_deadline(), None);
    }

    #[test]
    fn a_missing_chunk_is_marked_and_a_missing_end_times_out() {
        let a = "A".repeat(50);
        let mut j = StatusTextJoiner::default();
        j.push(0, (1, 1), Severity(4), a.as_bytes(), 3, 0);
        let t = j
            .push(10, (1, 1), Severity(4), &chunk("end"), 3, 2)
            .remove(0);
        assert_eq!(t.text, format!("{a}…end"));
        j.push(0, (1, 1), Severity(4), a.as_bytes(), 4, 0);
        assert!(j.poll(CHUNK_TIMEOUT - 1).is_empty());
        let t = j.poll(CHUNK_TIMEOUT);
        assert_eq!(t.len(), 1);
        assert_eq!(t[0].text, format!("{a}…"));
    }

    #[test]
    fn pending_texts_are_bounded() {
        let a = "A".repeat(50);
        let mut j = StatusTextJoiner::default();
        let mut shown = 0;
        for id in 1..=1000u16 {
            shown += j
                .push(id as u64, (1, 1), Severity(4), a.as_bytes(), id, 0)
                .len();
        }
        assert!(j.pending.len() <= MAX_PENDING);
        // Nothing is lost: every text pushed out early was shown.
        assert_eq!(shown + j.pending.len(), 1000);
    }
}
