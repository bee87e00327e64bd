//! One session per autopilot heard: its protocol machines and how to reach it.
//!
//! The session is where a protocol machine lives (streams now; parameters, commands, mission and
//! camera each in their own module later). It is handed the messages of its system that are for
//! us (or broadcast), the time, and the link each came on; it returns what to send and what to
//! tell the operator, and says when it next needs waking ([`Session::next_deadline`]).
//!
//! Adding a machine: give it `on_message(now, link, ...)`, `poll(now) -> Vec<Out>` and
//! `next_deadline() -> Option<Micros>`, hold it here, call it from the three methods below, and
//! map its output to [`SessionOut`].

use std::collections::BTreeMap;

use crate::clock::Micros;
use crate::dialect::{MavAutopilot, MavMessage};
use crate::link::LinkId;
use crate::proto::ack::CommandAck;
use crate::proto::streams::{StreamMachine, StreamOut};
use crate::proto::telemetry::FlightTelemetry;
use crate::proto::vehicles::VehicleKey;

/// What a session wants done.
#[derive(Debug, Clone, PartialEq)]
#[allow(clippy::large_enum_variant)] // short-lived; boxing every message buys nothing
pub enum SessionOut {
    /// Send to the vehicle on its route (the link it was heard on most recently, or the one the
    /// operator pinned).
    Send(MavMessage),
    /// Send on this link (stream rates are per link).
    SendOn(LinkId, MavMessage),
    /// Tell the operator (severity, text).
    Notice(u8, String),
}

/// The protocol machines for one autopilot.
#[derive(Debug, Clone)]
pub struct Session {
    pub key: VehicleKey,
    /// The link the operator chose for this vehicle (`link` at the prompt), if any.
    pub pinned: Option<LinkId>,
    /// When anything of this system was last heard on each link.
    heard: BTreeMap<LinkId, Micros>,
    pub streams: StreamMachine,
    /// What the autopilot tells of its flight (position, battery, GPS, home...).
    pub flight: FlightTelemetry,
}

impl Session {
    pub fn new(key: VehicleKey, autopilot: MavAutopilot, request_streams: bool) -> Self {
        Self {
            key,
            pinned: None,
            heard: BTreeMap::new(),
            streams: StreamMachine::new(key, autopilot, request_streams),
            flight: FlightTelemetry::new(key, request_streams),
        }
    }

    /// Where to send: the pinned link if it is up, else the link this system was heard on most
    /// recently among those up, else the most recent of any.
    pub fn route(&self, is_up: impl Fn(LinkId) -> bool) -> Option<LinkId> {
        if let Some(p) = self.pinned.filter(|&p| is_up(p)) {
            return Some(p);
        }
        let newest = |up_only: bool| {
            self.heard
                .iter()
                .filter(|(l, _)| !up_only || is_up(**l))
                .max_by_key(|(l, t)| (**t, std::cmp::Reverse(**l)))
                .map(|(l, _)| *l)
        };
        newest(true).or_else(|| newest(false))
    }

    /// Links this system has been heard on.
    pub fn links(&self) -> impl Iterator<Item = LinkId> + '_ {
        self.heard.keys().copied()
    }

    /// A frame of this system, for us or broadcast, heard on `link`: its source component, its
    /// message id, and the message when the dialect could read it (or read it by hand), and its
    /// payload as sent (for fields of messages the dialect could not read).
    pub fn on_message(
        &mut self,
        now: Micros,
        link: LinkId,
        (from, id): (u8, u32),
        msg: Option<&MavMessage>,
        ack: Option<&CommandAck>,
        payload: &[u8],
    ) -> Vec<SessionOut> {
        self.heard.insert(link, now);
        let mut out = Vec::new();
        if from != self.key.1 {
            return out;
        }
        let hb = match msg {
            Some(MavMessage::HEARTBEAT(hb)) => Some(hb),
            _ => None,
        };
        self.streams.on_message(now, link, id, hb);
        self.flight.on_message(now, id, msg, payload);
        if let Some(a) = ack {
            out.extend(
                self.streams
                    .on_ack(a.command, a.result)
                    .into_iter()
                    .map(map),
            );
        }
        out
    }

    /// The vehicle rebooted: every machine starts over where it must.
    pub fn on_reboot(&mut self) {
        self.streams.on_reboot();
    }

    /// `link` came back after being down.
    pub fn on_link_reconnected(&mut self, link: LinkId) {
        self.streams.on_link_reconnected(link);
    }

    /// Whatever is due at `now`.
    pub fn poll(&mut self, now: Micros) -> Vec<SessionOut> {
        let mut out: Vec<SessionOut> = self.streams.poll(now).into_iter().map(map).collect();
        out.extend(self.flight.poll(now).into_iter().map(SessionOut::Send));
        out
    }

    /// True when a poll now would do something (a machine has work that is not on a timer).
    pub fn due(&self) -> bool {
        self.streams.due() || self.flight.due()
    }

    /// When the session next needs a poll.
    pub fn next_deadline(&self) -> Option<Micros> {
        [self.streams.next_deadline(), self.flight.next_deadline()]
            .into_iter()
            .flatten()
            .min()
    }
}

fn map(o: StreamOut) -> SessionOut {
    match o {
        StreamOut::SendOn(l, m) => SessionOut::SendOn(l, m),
        StreamOut::Notice(s, t) => SessionOut::Notice(s, t),
    }
}
