// Older request commands (superseded by REQUEST_MESSAGE) are still what some vehicles answer.
#![allow(deprecated)]
//! The command queue of one vehicle, after QGroundControl's `MavCommandQueue`.
//!
//! - A command goes out as COMMAND_LONG (`confirmation` 0), or COMMAND_INT with an explicit frame
//!   for positional commands.
//! - One outstanding instance per (target, command): a second is refused with a clear message.
//! - COMMAND_ACK is matched by command and source, and shown with its MAV_RESULT (numbers the
//!   dialect does not know are kept); a STATUSTEXT from the vehicle within [`EXPLAIN_WINDOW`] of a
//!   refusal is attached as its reason ("PreArm: …").
//! - The wait for an ACK adapts to the measured round trip. Requests that are safe to repeat
//!   ([`safe_to_resend`]) are sent again with `confirmation` incremented, up to [`MAX_SENDS`];
//!   everything else (arm, takeoff, land, reboot, …) is never resent on its own: the missing ACK
//!   is shown and the operator decides.
//! - IN_PROGRESS keeps the entry open, with its progress, for [`IN_PROGRESS_TIMEOUT`] between
//!   updates; COMMAND_CANCEL aborts it.
//!
//! Sans-I/O: commands, ACKs, texts and time in; messages and outcomes out.

use std::collections::VecDeque;

use crate::clock::{Micros, SECOND};
use crate::dialect::{self, MavCmd, MavFrame, MavMessage, MavResult};
use crate::proto::ack::{command_name, result_name, CommandAck};
use crate::proto::machine::{Ids, Incoming, Machine, MachineEvent, Out, Route};
use crate::proto::vehicles::VehicleKey;
use mavlink::MessageData;
use num_traits::FromPrimitive;

/// Most sends of a command that is safe to repeat.
pub const MAX_SENDS: u32 = 3;
/// Shortest and longest wait for an ACK per send.
pub const MIN_TIMEOUT: Micros = SECOND;
pub const MAX_TIMEOUT: Micros = 5 * SECOND;
/// Wait between progress reports of a command IN_PROGRESS.
pub const IN_PROGRESS_TIMEOUT: Micros = 15 * SECOND;
/// A STATUSTEXT this close to a refusal explains it.
pub const EXPLAIN_WINDOW: Micros = SECOND;
/// Entries kept in the history.
pub const HISTORY: usize = 200;

/// How a command travels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Form {
    Long,
    /// COMMAND_INT in this frame; params 5 and 6 are latitude/longitude in degrees (sent ×1e7).
    Int(MavFrame),
}

/// A command as the operator (or a sequence) asked for it.
#[derive(Debug, Clone, PartialEq)]
pub struct CommandSpec {
    pub target: (u8, u8),
    pub command: u16,
    /// param1..param7; for COMMAND_INT, 5 and 6 are latitude and longitude in degrees.
    pub params: [f64; 7],
    pub form: Form,
}

impl CommandSpec {
    pub fn long(target: (u8, u8), command: MavCmd, params: [f64; 7]) -> Self {
        Self {
            target,
            command: command as u16,
            params,
            form: Form::Long,
        }
    }

    pub fn name(&self) -> String {
        command_name(self.command)
    }

    /// The target, as a key.
    pub fn key(&self) -> VehicleKey {
        self.target.into()
    }

    /// The message for send number `confirmation` (0 first).
    pub fn message(&self, confirmation: u8) -> Option<MavMessage> {
        let command = MavCmd::from_u16(self.command)?;
        let p = self.params;
        Some(match self.form {
            Form::Long => MavMessage::COMMAND_LONG(dialect::COMMAND_LONG_DATA {
                target_system: self.target.0,
                target_component: self.target.1,
                command,
                confirmation,
                param1: p[0] as f32,
                param2: p[1] as f32,
                param3: p[2] as f32,
                param4: p[3] as f32,
                param5: p[4] as f32,
                param6: p[5] as f32,
                param7: p[6] as f32,
            }),
            Form::Int(frame) => MavMessage::COMMAND_INT(dialect::COMMAND_INT_DATA {
                target_system: self.target.0,
                target_component: self.target.1,
                frame,
                command,
                current: 0,
                autocontinue: 0,
                param1: p[0] as f32,
                param2: p[1] as f32,
                param3: p[2] as f32,
                param4: p[3] as f32,
                x: (p[4] * 1e7).round() as i32,
                y: (p[5] * 1e7).round() as i32,
                z: p[6] as f32,
            }),
        })
    }
}

/// How a command goes: positional commands (a latitude and longitude in params 5 and 6) as
/// COMMAND_INT with an explicit frame, altitude above home, so the position is not rounded to a
/// float and the frame is never implicit; everything else as COMMAND_LONG.
pub fn form_for(command: u16) -> Form {
    use MavCmd::*;
    match MavCmd::from_u16(command) {
        Some(MAV_CMD_DO_REPOSITION | MAV_CMD_DO_SET_ROI_LOCATION | MAV_CMD_DO_SET_HOME) => {
            Form::Int(MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT)
        }
        _ => Form::Long,
    }
}

/// Commands that only ask for information or set a rate: repeating them is harmless.
pub fn safe_to_resend(command: u16) -> bool {
    use MavCmd::*;
    matches!(
        MavCmd::from_u16(command),
        Some(
            MAV_CMD_REQUEST_MESSAGE
                | MAV_CMD_SET_MESSAGE_INTERVAL
                | MAV_CMD_GET_MESSAGE_INTERVAL
                | MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES
                | MAV_CMD_GET_HOME_POSITION
                | MAV_CMD_REQUEST_PROTOCOL_VERSION
                | MAV_CMD_REQUEST_CAMERA_INFORMATION
                | MAV_CMD_REQUEST_CAMERA_SETTINGS
                | MAV_CMD_REQUEST_STORAGE_INFORMATION
                | MAV_CMD_REQUEST_CAMERA_CAPTURE_STATUS
                | MAV_CMD_REQUEST_FLIGHT_INFORMATION
                | MAV_CMD_DO_SET_MODE
        )
    )
}

/// Where a command stands.
#[derive(Debug, Clone, PartialEq)]
pub enum State {
    /// Sent, waiting for its ACK.
    Waiting,
    /// Acknowledged IN_PROGRESS, with the last progress (0–100, 255 unknown).
    InProgress(u8),
    /// Finished with this MAV_RESULT (its number).
    Done(u8),
    /// No ACK: never resent (flight-critical), or every resend used.
    NoAck,
    /// Cancelled by the operator before it finished.
    Cancelled,
    /// A newer request of the same kind (a mode change) took its place: it is not waited for
    /// and never resent.
    Superseded,
}

/// One command sent, as the Commands screen lists it.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    pub id: u64,
    pub spec: CommandSpec,
    pub first_sent: Micros,
    pub last_sent: Micros,
    /// Sends so far (the next resend carries this as `confirmation`).
    pub sends: u32,
    pub state: State,
    /// When the current state began (ACK time for a finished command).
    pub changed: Micros,
    /// First ACK's round trip.
    pub rtt: Option<Micros>,
    /// The vehicle's explanation (STATUSTEXT) of a refusal.
    pub reason: Option<String>,
    deadline: Micros,
    /// Not resent even if it is safe to repeat (the vehicle's state moved on since it was sent).
    held: bool,
}

impl Entry {
    pub fn open(&self) -> bool {
        matches!(self.state, State::Waiting | State::InProgress(_))
    }

    /// `ACCEPTED`, `IN_PROGRESS 40%`, `no ACK`, …
    pub fn outcome(&self) -> String {
        match &self.state {
            State::Waiting => "waiting".into(),
            State::InProgress(p) if *p <= 100 => format!("IN_PROGRESS {p}%"),
            State::InProgress(_) => "IN_PROGRESS".into(),
            State::Done(r) => result_name(*r),
            State::NoAck => "no ACK".into(),
            State::Cancelled => "CANCELLED by operator".into(),
            State::Superseded => "superseded".into(),
        }
    }

    /// [`Entry::outcome`] with the vehicle's reason when it gave one: `FAILED (PreArm: …)`.
    pub fn outcome_with_reason(&self) -> String {
        match &self.reason {
            Some(r) => format!("{} ({r})", self.outcome()),
            None => self.outcome(),
        }
    }
}

/// What the queue wants done.
#[derive(Debug, Clone, PartialEq)]
#[allow(clippy::large_enum_variant)] // short-lived; boxing every message buys nothing
pub enum CmdOut {
    Send(MavMessage),
    /// Tell the operator (severity, text).
    Notice(crate::wire::Severity, String),
    /// Command `id` finished (ACK, no ACK, cancelled): sequences waiting on it go on.
    Finished(u64),
}

/// The queue for one vehicle.
#[derive(Debug, Clone, Default)]
pub struct CommandQueue {
    entries: VecDeque<Entry>,
    next_id: u64,
    /// Smoothed round trip of ACKs, for the timeout.
    srtt: Option<Micros>,
    /// Recent STATUSTEXTs (time, system, text), to explain a refusal that follows them.
    texts: VecDeque<(Micros, u8, String)>,
}

fn refused(e: &Entry) -> bool {
    matches!(e.state, State::Done(r) if r != MavResult::MAV_RESULT_ACCEPTED as u8)
}

impl CommandQueue {
    /// Every command sent, oldest first.
    pub fn entries(&self) -> impl DoubleEndedIterator<Item = &Entry> + ExactSizeIterator {
        self.entries.iter()
    }

    pub fn get(&self, id: u64) -> Option<&Entry> {
        self.entries.iter().find(|e| e.id == id)
    }

    /// True while `command` to `target` waits for its answer.
    pub fn is_open(&self, target: VehicleKey, command: u16) -> bool {
        self.entries
            .iter()
            .any(|e| e.open() && e.spec.key() == target && e.spec.command == command)
    }

    /// The wait for an ACK: four round trips, within [`MIN_TIMEOUT`]..[`MAX_TIMEOUT`]; the
    /// longest until one is measured.
    pub fn timeout(&self) -> Micros {
        self.srtt
            .map_or(MAX_TIMEOUT / 2, |r| (4 * r).clamp(MIN_TIMEOUT, MAX_TIMEOUT))
    }

    /// Send `spec` now; refused when the same command to the same target is still open.
    pub fn submit(&mut self, now: Micros, spec: CommandSpec) -> Result<(u64, Vec<CmdOut>), String> {
        if let Some(e) = self
            .entries
            .iter()
            .find(|e| e.open() && e.spec.target == spec.target && e.spec.command == spec.command)
        {
            return Err(format!(
                "{} to {} is still {}: not sent again",
                e.spec.name(),
                spec.key(),
                e.outcome()
            ));
        }
        let msg = spec
            .message(0)
            .ok_or_else(|| format!("command {} is not in our dialect", spec.command))?;
        self.next_id += 1;
        let id = self.next_id;
        if self.entries.len() == HISTORY {
            // Forget the oldest finished one (open ones are few: one per command).
            if let Some(i) = self.entries.iter().position(|e| !e.open()) {
                self.entries.remove(i);
            }
        }
        self.entries.push_back(Entry {
            id,
            spec,
            first_sent: now,
            last_sent: now,
            sends: 1,
            state: State::Waiting,
            changed: now,
            rtt: None,
            reason: None,
            deadline: now + self.timeout(),
            held: false,
        });
        Ok((id, vec![CmdOut::Send(msg)]))
    }

    /// A COMMAND_ACK from `from` (already known to be for us).
    pub fn on_ack(&mut self, now: Micros, from: (u8, u8), ack: &CommandAck) -> Vec<CmdOut> {
        let Some(e) = self.entries.iter_mut().find(|e| {
            e.open() && e.spec.command == ack.command && e.spec.target == from
                || e.open()
                    && e.spec.command == ack.command
                    && e.spec.target.1 == 0
                    && e.spec.target.0 == from.0
        }) else {
            return Vec::new(); // someone else's, or a late duplicate
        };
        let rtt = now.saturating_sub(e.last_sent);
        if e.rtt.is_none() {
            e.rtt = Some(now.saturating_sub(e.first_sent));
            self.srtt = Some(match self.srtt {
                None => rtt,
                Some(s) => (7 * s + rtt) / 8,
            });
        }
        let name = e.spec.name();
        let target = e.spec.key();
        if ack.result == MavResult::MAV_RESULT_IN_PROGRESS as u8 {
            e.state = State::InProgress(ack.progress);
            e.changed = now;
            e.deadline = now + IN_PROGRESS_TIMEOUT;
            return Vec::new();
        }
        e.state = State::Done(ack.result);
        e.changed = now;
        let id = e.id;
        let ok = ack.result == MavResult::MAV_RESULT_ACCEPTED as u8;
        if !ok {
            e.reason = self
                .texts
                .iter()
                .rev()
                .find(|(t, s, _)| *s == from.0 && now.saturating_sub(*t) <= EXPLAIN_WINDOW)
                .map(|(_, _, text)| text.clone());
        }
        let reason = e.reason.clone();
        let sev = if ok {
            crate::wire::Severity::INFO
        } else {
            crate::wire::Severity::WARNING
        };
        vec![
            CmdOut::Notice(
                sev,
                format!(
                    "{name} to {target}: {}{}",
                    result_name(ack.result),
                    reason.map(|r| format!(" ({r})")).unwrap_or_default()
                ),
            ),
            CmdOut::Finished(id),
        ]
    }

    /// A STATUSTEXT from system `from`: the reason for a refusal that came moments before, or
    /// kept for one that comes moments after.
    pub fn on_statustext(&mut self, now: Micros, from: u8, text: &str) {
        if let Some(e) = self.entries.iter_mut().rev().find(|e| {
            e.spec.target.0 == from
                && e.reason.is_none()
                && refused(e)
                && now.saturating_sub(e.changed) <= EXPLAIN_WINDOW
        }) {
            e.reason = Some(text.to_string());
            return;
        }
        if self.texts.len() == 8 {
            self.texts.pop_front();
        }
        self.texts.push_back((now, from, text.to_string()));
    }

    /// Timeouts and resends due at `now`.
    pub fn poll(&mut self, now: Micros) -> Vec<CmdOut> {
        let timeout = self.timeout();
        let mut out = Vec::new();
        for e in self
            .entries
            .iter_mut()
            .filter(|e| e.open() && now >= e.deadline)
        {
            let name = e.spec.name();
            let (s, c) = e.spec.target;
            if let State::InProgress(_) = e.state {
                e.state = State::NoAck;
                e.changed = now;
                out.push(CmdOut::Notice(
                    crate::wire::Severity::WARNING,
                    format!("{name} to {s}:{c}: no progress report, given up"),
                ));
                out.push(CmdOut::Finished(e.id));
            } else if safe_to_resend(e.spec.command) && !e.held && e.sends < MAX_SENDS {
                if let Some(m) = e.spec.message(e.sends.min(255) as u8) {
                    out.push(CmdOut::Send(m));
                }
                e.sends += 1;
                e.last_sent = now;
                e.deadline = now + timeout;
            } else {
                e.state = State::NoAck;
                e.changed = now;
                let why = if e.held {
                    "no ACK (not resent: the vehicle's mode changed since it was sent)".to_string()
                } else if safe_to_resend(e.spec.command) {
                    format!("no ACK after {} sends", e.sends)
                } else {
                    "no ACK (not resent: re-issue it if still wanted)".to_string()
                };
                out.push(CmdOut::Notice(
                    crate::wire::Severity::WARNING,
                    format!("{name} to {s}:{c}: {why}"),
                ));
                out.push(CmdOut::Finished(e.id));
            }
        }
        out
    }

    /// Abort command `id` if it is in progress: COMMAND_CANCEL.
    pub fn cancel(&mut self, now: Micros, id: u64) -> Result<Vec<CmdOut>, String> {
        let e = self
            .entries
            .iter_mut()
            .find(|e| e.id == id)
            .ok_or("no such command")?;
        if !e.open() {
            return Err(format!("{} has finished: {}", e.spec.name(), e.outcome()));
        }
        e.state = State::Cancelled;
        e.changed = now;
        Ok(vec![
            CmdOut::Send(MavMessage::COMMAND_CANCEL(dialect::COMMAND_CANCEL_DATA {
                command: MavCmd::from_u16(e.spec.command).unwrap_or(MavCmd::MAV_CMD_NAV_WAYPOINT),
                target_system: e.spec.target.0,
                target_component: e.spec.target.1,
            })),
            CmdOut::Finished(e.id),
        ])
    }

    /// Command `id` is not sent again on its own, whatever its kind.
    pub fn hold_resends(&mut self, id: u64) {
        if let Some(e) = self.entries.iter_mut().find(|e| e.id == id) {
            e.held = true;
        }
    }

    /// Every open `command` to `target` is superseded by a newer request: finished at once,
    /// not resent, its late ACK ignored. Returns what finished.
    pub fn supersede(&mut self, now: Micros, target: VehicleKey, command: u16) -> Vec<CmdOut> {
        let mut out = Vec::new();
        for e in self
            .entries
            .iter_mut()
            .filter(|e| e.open() && e.spec.key() == target && e.spec.command == command)
        {
            e.state = State::Superseded;
            e.changed = now;
            out.push(CmdOut::Finished(e.id));
        }
        out
    }

    pub fn next_deadline(&self) -> Option<Micros> {
        self.entries
            .iter()
            .filter(|e| e.open())
            .map(|e| e.deadline)
            .min()
    }
}

/// Queue output in the one contract: sends go on `route` (the vehicle's, or mavterm's own for a
/// request it makes on its own), and each finished command is one event with what to tell of it.
pub fn to_out(outs: Vec<CmdOut>, route: Route, out: &mut Vec<Out>) {
    let mut told: Option<(crate::wire::Severity, String)> = None;
    for o in outs {
        if let Some((s, t)) = told.take() {
            match &o {
                CmdOut::Finished(_) => told = Some((s, t)),
                _ => out.push(Out::notice(s, t)),
            }
        }
        match o {
            CmdOut::Send(m) => out.push(Out::send(route, m)),
            CmdOut::Notice(s, t) => told = Some((s, t)),
            CmdOut::Finished(id) => out.push(Out::Event(MachineEvent::CommandDone {
                id,
                notice: told.take(),
            })),
        }
    }
    if let Some((s, t)) = told {
        out.push(Out::notice(s, t));
    }
}

impl Machine for CommandQueue {
    const IDS: Ids = Ids::Only(&[dialect::COMMAND_ACK_DATA::ID]);
    /// The ACK is read as [`Incoming::ack`].
    const DECODES: Ids = Ids::Only(&[]);

    /// The ACKs of the commands sent to any component of the system.
    fn on_message(&mut self, m: &Incoming, out: &mut Vec<Out>) {
        if let Some(a) = m.ack {
            to_out(self.on_ack(m.now, m.from, a), Route::Vehicle, out);
        }
    }

    fn poll(&mut self, now: Micros, out: &mut Vec<Out>) {
        to_out(CommandQueue::poll(self, now), Route::Vehicle, out);
    }

    fn next_deadline(&self) -> Option<Micros> {
        CommandQueue::next_deadline(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const V: (u8, u8) = (1, 1);

    fn ack(command: MavCmd, result: MavResult, progress: u8) -> CommandAck {
        CommandAck {
            command: command as u16,
            result: result as u8,
            progress,
            result_param2: 0,
            target_system: 255,
            target_component: 190,
        }
    }

    fn arm() -> CommandSpec {
        CommandSpec::long(
            V,
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            [1.0, 0., 0., 0., 0., 0., 0.],
        )
    }

    fn confirmation(o: &CmdOut) -> u8 {
        match o {
            CmdOut::Send(MavMessage::COMMAND_LONG(c)) => c.confirmation,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn one_outstanding_per_command_and_target() {
        let mut q = CommandQueue::default();
        let (id, out) = q.submit(0, arm()).unwrap();
        assert_eq!(confirmation(&out[0]), 0);
        let e = q.submit(10, arm()).unwrap_err();
        assert!(e.contains("still waiting"), "{e}");
        // Another command, or the same one to another vehicle, goes.
        let mut other = arm();
        other.target = (2, 1);
        assert!(q.submit(20, other).is_ok());
        let out = q.on_ack(
            30,
            V,
            &ack(
                MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                MavResult::MAV_RESULT_ACCEPTED,
                0,
            ),
        );
        assert!(out.contains(&CmdOut::Finished(id)));
        assert_eq!(q.get(id).unwrap().state, State::Done(0));
        assert_eq!(q.get(id).unwrap().rtt, Some(30));
        assert!(q.submit(40, arm()).is_ok(), "free again once answered");
    }

    #[test]
    fn an_ack_from_another_vehicle_or_for_another_command_is_not_ours() {
        let mut q = CommandQueue::default();
        let (id, _) = q.submit(0, arm()).unwrap();
        q.on_ack(
            5,
            (2, 1),
            &ack(
                MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                MavResult::MAV_RESULT_ACCEPTED,
                0,
            ),
        );
        q.on_ack(
            6,
            V,
            &ack(MavCmd::MAV_CMD_NAV_LAND, MavResult::MAV_RESULT_ACCEPTED, 0),
        );
        assert_eq!(q.get(id).unwrap().state, State::Waiting);
    }

    #[test]
    fn safe_requests_are_resent_with_confirmation_counting_up() {
        let mut q = CommandQueue::default();
        let spec = CommandSpec::long(
            V,
            MavCmd::MAV_CMD_REQUEST_MESSAGE,
            [242.0, 0., 0., 0., 0., 0., 0.],
        );
        let (id, _) = q.submit(0, spec).unwrap();
        let t1 = q.next_deadline().unwrap();
        let out = q.poll(t1);
        assert_eq!(confirmation(&out[0]), 1);
        let t2 = q.next_deadline().unwrap();
        let out = q.poll(t2);
        assert_eq!(confirmation(&out[0]), 2);
        // The third is answered: shown once.
        let out = q.on_ack(
            t2 + 100,
            V,
            &ack(
                MavCmd::MAV_CMD_REQUEST_MESSAGE,
                MavResult::MAV_RESULT_ACCEPTED,
                0,
            ),
        );
        assert_eq!(
            out.iter()
                .filter(|o| matches!(o, CmdOut::Notice(..)))
                .count(),
            1
        );
        let e = q.get(id).unwrap();
        assert_eq!((e.sends, e.state.clone()), (3, State::Done(0)));
        // A late ACK of an earlier copy changes nothing and says nothing.
        assert!(q
            .on_ack(
                t2 + 200,
                V,
                &ack(
                    MavCmd::MAV_CMD_REQUEST_MESSAGE,
                    MavResult::MAV_RESULT_ACCEPTED,
                    0
                )
            )
            .is_empty());
        assert_eq!(q.next_deadline(), None);
    }

    #[test]
    fn flight_critical_commands_are_never_resent() {
        let mut q = CommandQueue::default();
        let (id, _) = q.submit(0, arm()).unwrap();
        let t = q.next_deadline().unwrap();
        let out = q.poll(t);
        assert!(!out.iter().any(|o| matches!(o, CmdOut::Send(_))), "{out:?}");
        assert!(out
            .iter()
            .any(|o| matches!(o, CmdOut::Notice(_, m) if m.contains("no ACK"))));
        assert_eq!(q.get(id).unwrap().state, State::NoAck);
        assert_eq!(q.get(id).unwrap().sends, 1);
        assert!(q.poll(t + 60 * SECOND).is_empty());
    }

    #[test]
    fn in_progress_stays_open_with_its_progress_and_can_be_cancelled() {
        let mut q = CommandQueue::default();
        let spec = CommandSpec::long(
            V,
            MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION,
            [0., 0., 0., 0., 4., 0., 0.],
        );
        let (id, _) = q.submit(0, spec).unwrap();
        q.on_ack(
            100,
            V,
            &ack(
                MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION,
                MavResult::MAV_RESULT_IN_PROGRESS,
                40,
            ),
        );
        let e = q.get(id).unwrap();
        assert_eq!(e.outcome(), "IN_PROGRESS 40%");
        assert!(
            q.poll(100 + MAX_TIMEOUT).is_empty(),
            "the longer wait applies"
        );
        let out = q.cancel(200, id).unwrap();
        match &out[0] {
            CmdOut::Send(MavMessage::COMMAND_CANCEL(c)) => {
                assert_eq!(c.command, MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION);
                assert_eq!((c.target_system, c.target_component), V);
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(q.get(id).unwrap().state, State::Cancelled);
        assert!(q.cancel(300, id).is_err());
    }

    #[test]
    fn a_refusal_carries_the_text_that_explains_it() {
        let mut q = CommandQueue::default();
        let (id, _) = q.submit(0, arm()).unwrap();
        q.on_statustext(50_000, 1, "PreArm: Need Position Estimate");
        let out = q.on_ack(
            60_000,
            V,
            &ack(
                MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                MavResult::MAV_RESULT_FAILED,
                0,
            ),
        );
        assert_eq!(
            q.get(id).unwrap().reason.as_deref(),
            Some("PreArm: Need Position Estimate")
        );
        assert!(out
            .iter()
            .any(|o| matches!(o, CmdOut::Notice(_, m) if m.contains("FAILED (PreArm"))));
        // And after the ACK, within the window.
        let (id, _) = q.submit(2 * SECOND, arm()).unwrap();
        q.on_ack(
            2 * SECOND + 10,
            V,
            &ack(
                MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                MavResult::MAV_RESULT_FAILED,
                0,
            ),
        );
        q.on_statustext(2 * SECOND + 500_000, 1, "PreArm: Throttle below failsafe");
        assert_eq!(
            q.get(id).unwrap().reason.as_deref(),
            Some("PreArm: Throttle below failsafe")
        );
    }

    #[test]
    fn an_unknown_result_is_kept_as_a_number() {
        let mut q = CommandQueue::default();
        let (id, _) = q.submit(0, arm()).unwrap();
        let mut a = ack(
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            MavResult::MAV_RESULT_ACCEPTED,
            0,
        );
        a.result = 200;
        q.on_ack(10, V, &a);
        assert_eq!(q.get(id).unwrap().outcome(), "result 200");
    }

    #[test]
    fn the_wait_follows_the_measured_round_trip() {
        let mut q = CommandQueue::default();
        assert_eq!(q.timeout(), MAX_TIMEOUT / 2);
        for i in 0..20u64 {
            let t = i * 10 * SECOND;
            q.submit(t, arm()).unwrap();
            q.on_ack(
                t + 400_000,
                V,
                &ack(
                    MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                    MavResult::MAV_RESULT_ACCEPTED,
                    0,
                ),
            );
        }
        assert_eq!(q.timeout(), 1_600_000);
    }

    #[test]
    fn command_int_carries_the_frame_and_scaled_position() {
        let spec = CommandSpec {
            target: V,
            command: MavCmd::MAV_CMD_DO_REPOSITION as u16,
            params: [-1.0, 1.0, 0.0, f64::NAN, -35.3632621, 149.1652374, 20.0],
            form: Form::Int(MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT),
        };
        match spec.message(0).unwrap() {
            MavMessage::COMMAND_INT(c) => {
                assert_eq!(c.frame, MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT);
                assert_eq!((c.x, c.y, c.z), (-353_632_621, 1_491_652_374, 20.0));
            }
            other => panic!("{other:?}"),
        }
    }
}
