//! Forwarding (`--out`), as MAVProxy's `--out`: every frame heard on the vehicles' links goes,
//! unchanged (sequence numbers, signatures), to every output; what an output's ground station
//! sends goes to the vehicles' links: to the links its target system was heard on, or to every
//! link when it names no target or one not heard yet (MAVProxy sends it to the link of its
//! target, else the first). Nothing goes back where it came from, nor from one output to
//! another (MAVProxy does not either), and SETUP_SIGNING (the secret key) goes nowhere.
//!
//! Outputs are link tasks of their own ([`crate::link::transport`]: bounded queues, a failed
//! output retried), numbered apart from the vehicles' links so the core never mistakes them: the
//! core neither sees their frames nor counts them as vehicles'. A frame for an output that is
//! down, or whose queue is full, is dropped and counted there; the vehicles' links never wait.
//!
//! [`Forwarder`] decides and counts; its callers move the bytes.

use crate::app::tap::OutputStatus;
use crate::clock::{Micros, SECOND};
use crate::link::{Frame, LinkId, LinkSpec, LinkState};

use super::record::carries_secret;

/// The fewest core µs between two reports of an output's counters (state changes go at once).
const REPORT_EVERY: Micros = SECOND;

/// One output's state and counters.
#[derive(Debug, Clone)]
struct Output {
    status: OutputStatus,
    /// What the core was last told (`None`: nothing yet).
    reported: Option<OutputStatus>,
}

/// Where frames go between the vehicles' links and the outputs, with the counts.
#[derive(Debug, Clone)]
pub struct Forwarder {
    outs: Vec<Output>,
    /// Per vehicle link, the system ids heard on it (a bit each), to route targeted frames.
    heard: Vec<[u64; 4]>,
    reported_at: Micros,
}

impl Forwarder {
    pub fn new(specs: &[LinkSpec]) -> Self {
        let outs = specs
            .iter()
            .map(|s| Output {
                status: OutputStatus {
                    spec: s.to_string(),
                    state: LinkState::Connecting,
                    sent: 0,
                    received: 0,
                    dropped: 0,
                },
                reported: None,
            })
            .collect();
        Self {
            outs,
            heard: Vec::new(),
            reported_at: 0,
        }
    }

    pub fn len(&self) -> usize {
        self.outs.len()
    }

    pub fn is_empty(&self) -> bool {
        self.outs.is_empty()
    }

    /// Frames heard on vehicle link `link`: each to every output not down, through `send`
    /// (output number, bytes; false when its queue is full). An output still connecting queues
    /// them (its queue is bounded), so a ground station misses nothing of the start.
    pub fn from_vehicles(
        &mut self,
        link: LinkId,
        frames: &[Frame],
        mut send: impl FnMut(usize, Vec<u8>) -> bool,
    ) {
        if self.heard.len() <= link {
            self.heard.resize(link + 1, [0; 4]);
        }
        let heard = &mut self.heard[link];
        for f in frames {
            heard[(f.sysid / 64) as usize] |= 1 << (f.sysid % 64);
        }
        for (i, o) in self.outs.iter_mut().enumerate() {
            let st = &mut o.status;
            for f in frames {
                if carries_secret(&f.raw) {
                    continue;
                }
                let down = matches!(st.state, LinkState::Down(_));
                if !down && send(i, f.raw.to_vec()) {
                    st.sent += 1;
                } else {
                    st.dropped += 1;
                }
            }
        }
    }

    /// Frames from output `out`'s ground station: each to the vehicle links (of `links` in all)
    /// its target was heard on, else to all of them, through `send` (link, bytes; false when
    /// the link's queue is full, counted by the caller on the link). `forwarded` sees each frame
    /// that went (for the log).
    pub fn from_output(
        &mut self,
        out: usize,
        frames: &[Frame],
        links: usize,
        mut send: impl FnMut(LinkId, Vec<u8>) -> bool,
        mut forwarded: impl FnMut(&[u8]),
    ) {
        let Some(o) = self.outs.get_mut(out) else {
            return;
        };
        for f in frames {
            o.status.received += 1;
            if carries_secret(&f.raw) {
                o.status.dropped += 1;
                continue;
            }
            // A link's parser decodes nothing: a message naming a target is decoded here.
            let target = match f.message.as_deref() {
                Some(m) => mavlink::Message::target_system_id(m),
                None if f.lazy
                    && crate::wire::parser::msg_limits(f.msgid).is_some_and(|l| l.targeted) =>
                {
                    f.decode()
                        .ok()
                        .as_ref()
                        .and_then(mavlink::Message::target_system_id)
                }
                None => None,
            }
            .filter(|t| *t != 0);
            let heard_on = |l: LinkId| {
                target.is_some_and(|t| {
                    self.heard
                        .get(l)
                        .is_some_and(|h| h[(t / 64) as usize] & (1 << (t % 64)) != 0)
                })
            };
            let routed = (0..links).any(heard_on);
            for l in 0..links {
                if !routed || heard_on(l) {
                    send(l, f.raw.to_vec());
                }
            }
            forwarded(&f.raw);
        }
    }

    /// Output `out`'s task reported a new state.
    pub fn output_state(&mut self, out: usize, state: LinkState) {
        if let Some(o) = self.outs.get_mut(out) {
            o.status.state = state;
        }
    }

    /// Output `out` dropped frames (a client not reading, a queue full).
    pub fn output_dropped(&mut self, out: usize, frames: u64) {
        if let Some(o) = self.outs.get_mut(out) {
            o.status.dropped += frames;
        }
    }

    /// What the core should be told at `now`: every output whose state changed, and, at most
    /// once a second, those whose counters did.
    pub fn reports(&mut self, now: Micros) -> Vec<(usize, OutputStatus)> {
        let counters_due = now >= self.reported_at + REPORT_EVERY;
        let mut out = Vec::new();
        for (i, o) in self.outs.iter_mut().enumerate() {
            let due = match &o.reported {
                None => true,
                Some(r) if r.state != o.status.state => true,
                Some(r) => counters_due && *r != o.status,
            };
            if due {
                o.reported = Some(o.status.clone());
                out.push((i, o.status.clone()));
            }
        }
        if counters_due && !out.is_empty() {
            self.reported_at = now;
        }
        out
    }

    /// Every change not yet reported, due or not (at the end of a run).
    pub fn final_reports(&mut self) -> Vec<(usize, OutputStatus)> {
        let at = self.reported_at;
        let out = self.reports(Micros::MAX);
        self.reported_at = at;
        out
    }

    /// When counters not yet reported are due to be.
    pub fn next_report_at(&self) -> Option<Micros> {
        self.outs
            .iter()
            .any(|o| o.reported.as_ref() != Some(&o.status))
            .then_some(self.reported_at + REPORT_EVERY)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dialect::{self, MavMessage};
    use crate::wire::frame::{encode, Header, Version};
    use crate::wire::FrameParser;

    fn parse(bytes: &[u8]) -> Vec<Frame> {
        let mut out = Vec::new();
        FrameParser::lazy().push(bytes, |f| out.push(f));
        out
    }

    fn frame(sysid: u8, seq: u8, msg: &MavMessage) -> Vec<u8> {
        let h = Header {
            sysid,
            compid: 1,
            seq,
        };
        encode(Version::V2, h, msg)
    }

    fn heartbeat() -> MavMessage {
        crate::app::App::gcs_heartbeat()
    }

    fn command(target: u8) -> MavMessage {
        MavMessage::COMMAND_LONG(dialect::COMMAND_LONG_DATA {
            target_system: target,
            target_component: 1,
            command: dialect::MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            param1: 1.0,
            ..Default::default()
        })
    }

    fn setup_signing() -> MavMessage {
        MavMessage::SETUP_SIGNING(dialect::SETUP_SIGNING_DATA {
            initial_timestamp: 1,
            target_system: 1,
            target_component: 1,
            secret_key: [7; 32],
        })
    }

    fn outputs(n: usize) -> Forwarder {
        let specs: Vec<LinkSpec> = (0..n)
            .map(|i| format!("udpout:127.0.0.1:{}", 14550 + i).parse().unwrap())
            .collect();
        let mut f = Forwarder::new(&specs);
        for i in 0..n {
            f.output_state(i, LinkState::Up);
        }
        f
    }

    #[test]
    fn vehicle_frames_go_to_every_output_unchanged_but_the_key_never() {
        let mut f = outputs(2);
        let mut bytes = frame(1, 10, &heartbeat());
        bytes.extend(frame(1, 11, &setup_signing()));
        bytes.extend(frame(2, 200, &heartbeat()));
        let frames = parse(&bytes);
        assert_eq!(frames.len(), 3);
        let mut got: Vec<(usize, Vec<u8>)> = Vec::new();
        f.from_vehicles(0, &frames, |o, b| {
            got.push((o, b));
            true
        });
        let want: Vec<(usize, Vec<u8>)> = [0, 1]
            .into_iter()
            .flat_map(|o| {
                [
                    (o, frame(1, 10, &heartbeat())),
                    (o, frame(2, 200, &heartbeat())),
                ]
            })
            .collect();
        assert_eq!(got, want);
        let r = f.reports(0);
        assert_eq!(r.len(), 2);
        assert_eq!((r[0].1.sent, r[0].1.dropped), (2, 0));
    }

    #[test]
    fn a_down_or_full_output_drops_and_counts_alone() {
        let mut f = outputs(3);
        f.output_state(1, LinkState::Down("refused".into()));
        let frames = parse(&frame(1, 0, &heartbeat()).repeat(1));
        let mut to = Vec::new();
        for _ in 0..5 {
            // Output 2's queue is full.
            f.from_vehicles(0, &frames, |o, _| {
                to.push(o);
                o != 2
            });
        }
        assert_eq!(to, [0, 2].repeat(5));
        let r = f.reports(0);
        let counts: Vec<(u64, u64)> = r.iter().map(|(_, s)| (s.sent, s.dropped)).collect();
        assert_eq!(counts, [(5, 0), (0, 5), (0, 5)]);
    }

    #[test]
    fn gcs_frames_go_to_the_links_of_their_target_else_to_all() {
        let mut f = outputs(2);
        // System 1 is heard on link 0, system 2 on links 1 and 2.
        f.from_vehicles(0, &parse(&frame(1, 0, &heartbeat())), |_, _| true);
        f.from_vehicles(1, &parse(&frame(2, 0, &heartbeat())), |_, _| true);
        f.from_vehicles(2, &parse(&frame(2, 1, &heartbeat())), |_, _| true);
        let mut gcs = frame(250, 5, &command(2));
        gcs.extend(frame(250, 6, &command(1)));
        gcs.extend(frame(250, 7, &command(9))); // not heard: everywhere
        gcs.extend(frame(250, 8, &heartbeat())); // no target: everywhere
        gcs.extend(frame(250, 9, &setup_signing())); // nowhere
        let frames = parse(&gcs);
        let mut sent: Vec<(LinkId, u8)> = Vec::new();
        let mut logged = Vec::new();
        f.from_output(
            1,
            &frames,
            3,
            |l, b| {
                assert!(frames.iter().any(|f| *f.raw == b[..]), "unchanged bytes");
                sent.push((l, b[4]));
                true
            },
            |b| logged.push(b[4]),
        );
        assert_eq!(
            sent,
            [
                (1, 5),
                (2, 5),
                (0, 6),
                (0, 7),
                (1, 7),
                (2, 7),
                (0, 8),
                (1, 8),
                (2, 8)
            ]
        );
        assert_eq!(logged, [5, 6, 7, 8]);
        let st = &f.reports(0)[1].1;
        assert_eq!((st.received, st.dropped, st.sent), (5, 1, 3));
    }

    #[test]
    fn reports_states_at_once_and_counters_once_a_second() {
        let mut f = outputs(1);
        assert_eq!(f.reports(0).len(), 1);
        assert_eq!(f.next_report_at(), None);
        let frames = parse(&frame(1, 0, &heartbeat()));
        f.from_vehicles(0, &frames, |_, _| true);
        assert!(f.reports(SECOND / 2).is_empty());
        assert_eq!(f.next_report_at(), Some(SECOND));
        assert_eq!(f.reports(SECOND)[0].1.sent, 1);
        f.from_vehicles(0, &frames, |_, _| true);
        f.output_state(0, LinkState::Down("gone".into()));
        let r = f.reports(SECOND + 1);
        assert_eq!(
            (r[0].1.sent, &r[0].1.state),
            (2, &LinkState::Down("gone".into()))
        );
    }
}
