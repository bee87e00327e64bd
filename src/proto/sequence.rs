//! Command sequences that wait for the vehicle at each step: a mode change confirmed by the next
//! heartbeat (not only by its ACK), and ArduCopter's take-off (GUIDED if needed, then arm, then
//! NAV_TAKEOFF), each step waiting for the previous one's ACK and heartbeat and stopping with a
//! clear message at the first refusal.
//!
//! Sans-I/O: the session feeds it command outcomes and heartbeats; it says which command to
//! submit next.

use crate::clock::{Micros, SECOND};
use crate::proto::commands::CommandSpec;
use crate::proto::machine::{Ids, Incoming, Machine, MachineEvent, Out, Route};
use mavlink::MessageData;

/// How long after an accepted ACK the heartbeat may take to show the change.
pub const HEARTBEAT_WAIT: Micros = 3 * SECOND;

/// What the heartbeat must show before the next step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Until {
    /// Only the ACK.
    Ack,
    /// The heartbeat's custom mode is this.
    Mode(u32),
    /// The heartbeat says armed.
    Armed,
}

/// One step: a command and what shows it took effect.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    pub spec: CommandSpec,
    pub until: Until,
    /// For messages: `GUIDED`, `arm`, `takeoff to 10 m`.
    pub label: String,
    /// Sent instead when the vehicle answers the command UNSUPPORTED (SET_MODE for a vehicle
    /// that does not know DO_SET_MODE); the heartbeat then decides.
    pub fallback: Option<crate::dialect::MavMessage>,
}

#[derive(Debug, Clone, PartialEq)]
enum Phase {
    /// Submit step `i` next.
    Submit,
    /// Step's command (by queue id) sent; waiting for it to finish.
    Acking(u64),
    /// Accepted; waiting until `deadline` for the heartbeat to agree.
    Confirming(Micros),
}

/// What the sequence wants.
#[derive(Debug, Clone, PartialEq)]
#[allow(clippy::large_enum_variant)] // short-lived; boxing every message buys nothing
pub enum SeqOut {
    /// Send this message as it is (a fallback).
    Send(crate::dialect::MavMessage),
    Notice(crate::wire::Severity, String),
    /// Finished, well or not.
    Done,
}

/// A running sequence.
#[derive(Debug, Clone, PartialEq)]
pub struct Sequence {
    pub name: String,
    steps: Vec<Step>,
    i: usize,
    phase: Phase,
}

impl Sequence {
    pub fn new(name: impl Into<String>, steps: Vec<Step>) -> Self {
        Self {
            name: name.into(),
            steps,
            i: 0,
            phase: Phase::Submit,
        }
    }

    /// The step being worked on.
    pub fn current(&self) -> Option<&Step> {
        self.steps.get(self.i)
    }

    /// The next command to submit, if it is time (the caller submits it and calls `sent`).
    pub fn next_command(&self) -> Option<CommandSpec> {
        match (&self.phase, self.current()) {
            (Phase::Submit, Some(s)) => Some(s.spec.clone()),
            _ => None,
        }
    }

    /// The queue took the current step's command as `id`.
    pub fn sent(&mut self, id: u64) {
        self.phase = Phase::Acking(id);
    }

    /// The queue refused the step's command (e.g. the same command is still open).
    pub fn refused(&mut self, why: &str) -> Vec<SeqOut> {
        self.stop(format!("{}: {why}", self.label()))
    }

    fn label(&self) -> String {
        match self.current() {
            Some(s) if self.steps.len() > 1 => format!("{} ({})", self.name, s.label),
            _ => self.name.clone(),
        }
    }

    fn stop(&mut self, text: String) -> Vec<SeqOut> {
        self.i = self.steps.len();
        vec![
            SeqOut::Notice(crate::wire::Severity::WARNING, format!("{text}; stopped")),
            SeqOut::Done,
        ]
    }

    /// Command `id` finished: `accepted`, or with `outcome` (`FAILED (PreArm: …)`, `no ACK`).
    pub fn on_finished(
        &mut self,
        now: Micros,
        id: u64,
        accepted: bool,
        outcome: &str,
    ) -> Vec<SeqOut> {
        if self.phase != Phase::Acking(id) {
            return Vec::new();
        }
        if !accepted {
            let fallback = self.current().and_then(|s| s.fallback.clone());
            if let (Some(msg), true) = (fallback, outcome.starts_with("UNSUPPORTED")) {
                self.phase = Phase::Confirming(now + HEARTBEAT_WAIT);
                return vec![SeqOut::Send(msg)];
            }
            return self.stop(format!("{}: {outcome}", self.label()));
        }
        self.phase = Phase::Confirming(now + HEARTBEAT_WAIT);
        if self.current().is_some_and(|s| s.until == Until::Ack) {
            return self.advance();
        }
        Vec::new()
    }

    /// A heartbeat of the vehicle: does it show the step done?
    pub fn on_heartbeat(&mut self, custom_mode: u32, armed: bool) -> Vec<SeqOut> {
        let Phase::Confirming(_) = self.phase else {
            return Vec::new();
        };
        let done = match self.current().map(|s| s.until) {
            Some(Until::Mode(m)) => custom_mode == m,
            Some(Until::Armed) => armed,
            _ => true,
        };
        if done {
            self.advance()
        } else {
            Vec::new()
        }
    }

    fn advance(&mut self) -> Vec<SeqOut> {
        let label = self.label();
        self.i += 1;
        self.phase = Phase::Submit;
        if self.i >= self.steps.len() {
            let text = if self.steps.len() > 1 {
                format!("{}: done", self.name)
            } else {
                format!("{label}: confirmed by the vehicle")
            };
            return vec![
                SeqOut::Notice(crate::wire::Severity::INFO, text),
                SeqOut::Done,
            ];
        }
        Vec::new()
    }

    /// Timers: a heartbeat that never agreed.
    pub fn poll(&mut self, now: Micros) -> Vec<SeqOut> {
        match self.phase {
            Phase::Confirming(d) if now >= d => {
                let text = format!(
                    "{}: accepted, but the heartbeat does not show it",
                    self.label()
                );
                self.stop(text)
            }
            _ => Vec::new(),
        }
    }

    pub fn next_deadline(&self) -> Option<Micros> {
        match self.phase {
            Phase::Confirming(d) => Some(d),
            _ => None,
        }
    }

    pub fn finished(&self) -> bool {
        self.i >= self.steps.len()
    }
}

/// Sequence output in the one contract (its fallback messages go to the vehicle on its route).
/// A notice followed by `Done` is the sequence's last word.
pub fn to_out(outs: Vec<SeqOut>, out: &mut Vec<Out>) {
    let mut outs = outs.into_iter().peekable();
    while let Some(o) = outs.next() {
        match o {
            SeqOut::Send(m) => out.push(Out::send(Route::Vehicle, m)),
            SeqOut::Notice(s, t) if outs.peek() == Some(&SeqOut::Done) => {
                out.push(Out::Event(MachineEvent::SequenceDone { notice: (s, t) }))
            }
            SeqOut::Notice(s, t) => out.push(Out::notice(s, t)),
            SeqOut::Done => {}
        }
    }
}

impl Machine for Sequence {
    const IDS: Ids = Ids::Only(&[crate::dialect::HEARTBEAT_DATA::ID]);

    /// The vehicle's heartbeat: does it show the step done?
    fn on_message(&mut self, m: &Incoming, out: &mut Vec<Out>) {
        if let Some(hb) = m.heartbeat() {
            let armed = hb
                .base_mode
                .contains(crate::dialect::MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED);
            to_out(self.on_heartbeat(hb.custom_mode, armed), out);
        }
    }

    fn poll(&mut self, now: Micros, out: &mut Vec<Out>) {
        to_out(Sequence::poll(self, now), out);
    }

    fn next_deadline(&self) -> Option<Micros> {
        Sequence::next_deadline(self)
    }
}
