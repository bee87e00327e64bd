//! The one contract of every protocol machine: a message in ([`Incoming`]), time in
//! ([`Machine::poll`]), what to send and what happened out ([`Out`]), and when to be woken next
//! ([`Machine::next_deadline`]).
//!
//! A machine says which of the dialect's messages it reads ([`Machine::IDS`]); the session
//! builds its dispatch table from those once. Work that is not on a timer (a download to start,
//! a request to send) is a deadline at the time it became due: the poll at that deadline does
//! it, so a deadline in the past never stays (the driver would never sleep).

use crate::clock::Micros;
use crate::dialect::MavMessage;
use crate::link::LinkId;
use crate::proto::ack::CommandAck;
use crate::wire::Severity;

/// `msg` from 1:1 at `now`, through our encoder and parser as a machine receives it: what `f`
/// makes of it (for tests of the machines).
#[cfg(test)]
pub(crate) fn received<R>(now: Micros, msg: &MavMessage, f: impl FnOnce(&Incoming<'_>) -> R) -> R {
    use crate::wire::{frame, FrameParser, Header, Version};
    let h = Header {
        sysid: 1,
        compid: 1,
        seq: 0,
    };
    let bytes = frame::encode(Version::V2, h, msg);
    let parsed = FrameParser::new().parse_all(&bytes).remove(0);
    let ack = CommandAck::from_frame(&parsed);
    f(&Incoming {
        now,
        from: (1, 1),
        link: 0,
        profile: Default::default(),
        id: parsed.msgid,
        payload: parsed.payload(),
        msg: parsed.message.as_deref(),
        ack: ack.as_ref(),
    })
}

/// What a link is, as far as asking for telemetry goes.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LinkProfile {
    /// High latency or low bandwidth (`?hl=1`), or a tlog replay: nothing automatic is sent on
    /// it.
    pub hl: bool,
    /// The baud rate given on a serial spec (unknown otherwise).
    pub baud: Option<u32>,
}

/// A message of the session's system, for us or broadcast, as a machine sees it.
#[derive(Debug, Clone, Copy)]
pub struct Incoming<'a> {
    pub now: Micros,
    /// The sender (sysid, compid).
    pub from: (u8, u8),
    /// The link it came on, and what kind of link that is.
    pub link: LinkId,
    pub profile: LinkProfile,
    /// The message id.
    pub id: u32,
    /// The payload as sent (MAVLink 2 cuts trailing zeros), for fields read by hand with
    /// [`crate::wire::payload::Payload`].
    pub payload: &'a [u8],
    /// The message, when the dialect could read it.
    pub msg: Option<&'a MavMessage>,
    /// The COMMAND_ACK, already read (from the dialect or by hand), if this is one.
    pub ack: Option<&'a CommandAck>,
}

impl<'a> Incoming<'a> {
    /// The heartbeat, if this is one.
    pub fn heartbeat(&self) -> Option<&'a crate::dialect::HEARTBEAT_DATA> {
        match self.msg {
            Some(MavMessage::HEARTBEAT(hb)) => Some(hb),
            _ => None,
        }
    }
}

/// Where a message goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Route {
    /// To the vehicle on the operator's route (the link it was heard on last, or the pinned
    /// one): the operator asked for it.
    Vehicle,
    /// Sent by mavterm on its own: on the vehicle's route among the links that are not
    /// high-latency, or not at all.
    Auto,
    /// On this link (stream rates are per link); never on a high-latency one.
    Link(LinkId),
}

/// What the component metadata machine (`proto::comp_meta`) has to tell, for the core.
#[derive(Debug, Clone, PartialEq)]
pub enum CompMetaEvent {
    /// The vehicle announced its general metadata file.
    Announced { crc: u32, uri: String },
    /// The parameter metadata file as it came from `source` (its URI), maybe xz-compressed;
    /// `crc` is the general file's.
    ParamFile {
        crc: u32,
        source: String,
        bytes: Vec<u8>,
    },
    /// The parameter metadata is on the web: the first of `urls` that answers.
    Fetch { crc: u32, urls: Vec<String> },
    /// Nothing to be had, and why. `operator`: the operator asked (else it was automatic).
    Failed { why: String, operator: bool },
}

/// What happened, typed, for the session to route (to another machine, or to the UI).
#[derive(Debug, Clone, PartialEq)]
pub enum MachineEvent {
    /// Tell the operator.
    Notice(Severity, String),
    /// Command `id` of the queue finished (ACK, no ACK, cancelled, superseded), with what to
    /// tell of it.
    CommandDone {
        id: u64,
        notice: Option<(Severity, String)>,
    },
    /// The outcome of an edit of parameter `name` of component `comp` (confirmed by the echo,
    /// refused, unanswered), with what to tell of it.
    ParamSet {
        comp: u8,
        name: String,
        confirmed: bool,
        notice: (Severity, String),
    },
    /// The running sequence ended (done, or stopped), with what to tell of it.
    SequenceDone { notice: (Severity, String) },
    /// An operator's mission request ended, `done` or not, with what to tell of it.
    MissionEnd {
        ask: crate::proto::mission::MissionAsk,
        done: bool,
        notice: (Severity, String),
    },
    /// The component metadata machine's news (parameter metadata from the vehicle).
    CompMeta(CompMetaEvent),
    /// A text the vehicle said (STATUSTEXT, joined): from component `from`. `late`: its last
    /// chunk never came (shown as far as it got, not read as a refusal's reason).
    Text {
        from: crate::proto::vehicles::VehicleKey,
        sev: Severity,
        text: String,
        late: bool,
    },
}

/// What a machine wants done.
#[derive(Debug, Clone, PartialEq)]
#[allow(clippy::large_enum_variant)] // short-lived; boxing every message buys nothing
pub enum Out {
    Send { route: Route, msg: MavMessage },
    Event(MachineEvent),
}

impl Out {
    pub fn notice(sev: impl Into<Severity>, text: String) -> Out {
        Out::Event(MachineEvent::Notice(sev.into(), text))
    }
    pub fn send(route: Route, msg: MavMessage) -> Out {
        Out::Send { route, msg }
    }
}

/// The message ids a machine reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ids {
    /// Every message (a machine measuring arrivals).
    All,
    /// These ids only.
    Only(&'static [u32]),
}

impl Ids {
    pub fn contains(self, id: u32) -> bool {
        match self {
            Ids::All => true,
            Ids::Only(ids) => ids.contains(&id),
        }
    }
}

/// A protocol machine: messages and time in, [`Out`] out, and its next deadline.
pub trait Machine {
    /// The dialect's messages it reads (`*_DATA::ID`).
    const IDS: Ids;
    /// Those of [`Machine::IDS`] it reads decoded ([`Incoming::msg`]); the others it reads from
    /// the payload alone, so the core need not decode them for it (a link's parser decodes
    /// nothing: the core decodes what some reader reads decoded).
    const DECODES: Ids = Self::IDS;
    /// A message it reads; what to do is pushed on `out`.
    fn on_message(&mut self, m: &Incoming, out: &mut Vec<Out>);
    /// Whatever is due at `now`.
    fn poll(&mut self, now: Micros, out: &mut Vec<Out>);
    /// When it next needs a poll (untimed work: the time it became due).
    fn next_deadline(&self) -> Option<Micros>;
    /// True when `m` is this machine's alone, asked before it is handed the message: the
    /// machines that would read it too (the command queue, for a COMMAND_ACK answering a
    /// command this machine sent itself) are not handed it.
    fn claims(&self, _m: &Incoming) -> bool {
        false
    }
}

/// A command a machine wants sent through the session's command queue, to component `.0` of
/// its system: (component, command, params). Asked on its own: mavterm's own traffic.
pub type Request = (u8, u16, [f64; 7]);

/// A machine whose commands go through the session's command queue (one command of a kind per
/// target open at a time). It keeps its requests until the queue takes them; the session offers
/// them after every message and poll, through one path for every such machine, and a refused
/// one is offered again then (the machine's deadline wakes the session when a command of its
/// system finished).
pub trait Requests {
    /// The requests the queue may take now, in order (each component's first).
    fn requests(&self) -> Vec<Request>;
    /// The queue took `r`: it is on its way.
    fn taken(&mut self, r: &Request);
}
