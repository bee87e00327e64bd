//! Command sequences that wait for the vehicle at each step: a mode change confirmed by the next
//! heartbeat (not only by its ACK), and ArduCopter's take-off (GUIDED if needed, then arm, then
//! NAV_TAKEOFF, done when the altitude is reached), each step waiting for the previous one's ACK
//! and heartbeat and stopping with a clear message at the first refusal.
//!
//! A take-off's step ([`Until::Altitude`]) is done when GLOBAL_POSITION_INT's `relative_alt`
//! comes within [`altitude_tolerance_m`] of the target (5 % of it, at least 0.5 m: DroneKit's
//! `arm_and_takeoff` waits for 95 %, PX4 accepts a multicopter's altitude within NAV_MC_ALT_RAD,
//! 0.8 m by default). It fails, saying so, when the vehicle disarms, leaves the take-off's mode,
//! reports LANDING (EXTENDED_SYS_STATE), is back on the ground after leaving it, or has not
//! reached it within [`climb_timeout`]; nothing is ever resent, the vehicle is only no longer
//! waited for.
//!
//! Sans-I/O: the session feeds it command outcomes, heartbeats, positions and landed states; it
//! says which command to submit next.

use crate::clock::{Micros, SECOND};
use crate::proto::commands::CommandSpec;
use crate::proto::machine::{Ids, Incoming, Machine, MachineEvent, Out, Route};
use mavlink::MessageData;

/// How long after an accepted ACK the heartbeat may take to show the change.
pub const HEARTBEAT_WAIT: Micros = 3 * SECOND;

/// How far below a take-off's target altitude counts as reached: 5 % of the target, at least
/// 0.5 m (0.5 m at 10 m; 5 m at 100 m). A vehicle above it has reached it too.
pub fn altitude_tolerance_m(target_m: f64) -> f64 {
    (target_m.abs() * 0.05).max(0.5)
}

/// How long a take-off may climb before it is no longer waited for: 10 s, and 2 s a metre
/// (0.5 m/s, a quarter of ArduCopter's default take-off climb of about 2 m/s: 30 s for 10 m).
pub fn climb_timeout(target_m: f64) -> Micros {
    let metres = if target_m.is_finite() {
        target_m.clamp(0.0, 10_000.0)
    } else {
        0.0
    };
    10 * SECOND + (metres * 2.0 * SECOND as f64) as Micros
}

/// MAV_LANDED_STATE values (EXTENDED_SYS_STATE.landed_state).
const ON_GROUND: u8 = crate::dialect::MavLandedState::MAV_LANDED_STATE_ON_GROUND as u8;
const IN_AIR: u8 = crate::dialect::MavLandedState::MAV_LANDED_STATE_IN_AIR as u8;
const TAKEOFF: u8 = crate::dialect::MavLandedState::MAV_LANDED_STATE_TAKEOFF as u8;
const LANDING: u8 = crate::dialect::MavLandedState::MAV_LANDED_STATE_LANDING as u8;

/// What the heartbeat must show before the next step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Until {
    /// Only the ACK.
    Ack,
    /// The heartbeat's custom mode is this.
    Mode(u32),
    /// The heartbeat says armed.
    Armed,
    /// A take-off: the ACK, then GLOBAL_POSITION_INT's `relative_alt` within
    /// [`altitude_tolerance_m`] of `target_mm` (millimetres above home), the vehicle staying
    /// armed, off the ground once it left it, not landing, and in `mode` if given (ArduPilot
    /// climbs in GUIDED; PX4 changes mode itself, to TAKEOFF and then HOLD, so `None`).
    Altitude { target_mm: i32, mode: Option<u32> },
}

impl Until {
    /// A take-off to `target_m` metres above home, flown in `mode` (if it must stay in one).
    pub fn altitude(target_m: f64, mode: Option<u32>) -> Until {
        let mm = (target_m * 1000.0).round();
        Until::Altitude {
            target_mm: mm.clamp(i32::MIN as f64, i32::MAX as f64) as i32,
            mode,
        }
    }
}

/// A take-off climbing: its target and the last altitude heard (metres above home).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Climb {
    pub target_m: f64,
    pub alt_m: Option<f64>,
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
    /// A take-off accepted: climbing until `deadline`; the last relative altitude heard (mm)
    /// and whether the vehicle said it left the ground.
    Climbing {
        deadline: Micros,
        since: Micros,
        alt_mm: Option<i32>,
        left_ground: bool,
    },
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
    /// The last take-off step's `take-off: 10.0 m reached`, until the next step's command is
    /// answered (for the status bar while the next step goes).
    reached: Option<String>,
}

impl Sequence {
    pub fn new(name: impl Into<String>, steps: Vec<Step>) -> Self {
        Self {
            name: name.into(),
            steps,
            i: 0,
            phase: Phase::Submit,
            reached: None,
        }
    }

    /// The take-off climbing now, if any.
    pub fn climb(&self) -> Option<Climb> {
        match (&self.phase, self.current().map(|s| s.until)) {
            (Phase::Climbing { alt_mm, .. }, Some(Until::Altitude { target_mm, .. })) => {
                Some(Climb {
                    target_m: target_mm as f64 / 1000.0,
                    alt_m: alt_mm.map(|a| a as f64 / 1000.0),
                })
            }
            _ => None,
        }
    }

    /// `take-off: 10.0 m reached` of a take-off step done, until the next step is answered.
    pub fn reached(&self) -> Option<&str> {
        self.reached.as_deref()
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
        self.fail(format!("{text}; stopped"))
    }

    /// The sequence ends with this warning, as it is.
    fn fail(&mut self, text: String) -> Vec<SeqOut> {
        self.i = self.steps.len();
        self.phase = Phase::Submit;
        vec![
            SeqOut::Notice(crate::wire::Severity::WARNING, text),
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
        self.reached = None;
        if !accepted {
            let fallback = self.current().and_then(|s| s.fallback.clone());
            if let (Some(msg), true) = (fallback, outcome.starts_with("UNSUPPORTED")) {
                self.phase = Phase::Confirming(now + HEARTBEAT_WAIT);
                return vec![SeqOut::Send(msg)];
            }
            return self.stop(format!("{}: {outcome}", self.label()));
        }
        self.phase = Phase::Confirming(now + HEARTBEAT_WAIT);
        match self.current().map(|s| s.until) {
            Some(Until::Ack) => return self.advance(),
            Some(Until::Altitude { target_mm, .. }) => {
                // Only positions heard from now on count: the one before is on the ground.
                self.phase = Phase::Climbing {
                    deadline: now + climb_timeout(target_mm as f64 / 1000.0),
                    since: now,
                    alt_mm: None,
                    left_ground: false,
                };
            }
            _ => {}
        }
        Vec::new()
    }

    /// ` at 3.2 m` (the last altitude heard while climbing), or nothing.
    fn at(&self) -> String {
        match self.climb().and_then(|c| c.alt_m) {
            Some(a) => format!(" at {a:.1} m"),
            None => String::new(),
        }
    }

    /// `10.0 m`: the climb's target.
    fn target(&self) -> String {
        self.climb()
            .map_or(String::new(), |c| format!("{:.1} m", c.target_m))
    }

    /// What a climb's failure names: `take-off to 10.0 m`, within its sequence when more
    /// follows (`mission start (take-off to 20.0 m)`).
    fn climb_label(&self) -> String {
        let what = format!("take-off to {}", self.target());
        if self.i + 1 < self.steps.len() {
            format!("{} ({what})", self.name)
        } else {
            what
        }
    }

    /// A heartbeat of the vehicle: does it show the step done? While a take-off climbs: is it
    /// still armed, and in the take-off's mode (`mode_name`: the heartbeat's, for the message)?
    pub fn on_heartbeat(&mut self, custom_mode: u32, armed: bool, mode_name: &str) -> Vec<SeqOut> {
        let until = self.current().map(|s| s.until);
        if let (Some(_), Some(Until::Altitude { mode, .. })) = (self.climb(), until) {
            let why = if !armed {
                format!("disarmed{}", self.at())
            } else if mode.is_some_and(|m| m != custom_mode) {
                format!("mode changed to {mode_name}{}", self.at())
            } else {
                return Vec::new();
            };
            return self.stop(format!("{}: {why}", self.climb_label()));
        }
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

    /// GLOBAL_POSITION_INT's `relative_alt` (mm above home): has the take-off reached its
    /// altitude?
    pub fn on_position(&mut self, relative_alt_mm: i32) -> Vec<SeqOut> {
        let Some(Climb { target_m, .. }) = self.climb() else {
            return Vec::new();
        };
        if let Phase::Climbing { alt_mm, .. } = &mut self.phase {
            *alt_mm = Some(relative_alt_mm);
        }
        let alt = relative_alt_mm as f64 / 1000.0;
        if alt < target_m - altitude_tolerance_m(target_m) {
            return Vec::new();
        }
        let text = format!("take-off: {target_m:.1} m reached");
        self.reached = Some(text.clone());
        self.advance_with(text)
    }

    /// EXTENDED_SYS_STATE's `landed_state` while a take-off climbs: LANDING, or on the ground
    /// again after it left it, ends the wait.
    pub fn on_landed_state(&mut self, state: u8) -> Vec<SeqOut> {
        let Phase::Climbing { left_ground, .. } = &mut self.phase else {
            return Vec::new();
        };
        let why = match state {
            IN_AIR | TAKEOFF => {
                *left_ground = true;
                return Vec::new();
            }
            LANDING => format!("landing{}", self.at()),
            ON_GROUND if *left_ground => "back on the ground".to_string(),
            _ => return Vec::new(),
        };
        self.stop(format!("{}: {why}", self.climb_label()))
    }

    fn advance(&mut self) -> Vec<SeqOut> {
        let text = if self.steps.len() > 1 {
            format!("{}: done", self.name)
        } else {
            format!("{}: confirmed by the vehicle", self.label())
        };
        self.advance_with(text)
    }

    /// The current step is done; `last_word` is the sequence's if it was the last.
    fn advance_with(&mut self, last_word: String) -> Vec<SeqOut> {
        let climbed = matches!(self.phase, Phase::Climbing { .. });
        self.i += 1;
        self.phase = Phase::Submit;
        if self.i >= self.steps.len() {
            return vec![
                SeqOut::Notice(crate::wire::Severity::INFO, last_word),
                SeqOut::Done,
            ];
        }
        // A take-off on the way (the mission's start goes on): said as it happens.
        if climbed {
            return vec![SeqOut::Notice(crate::wire::Severity::INFO, last_word)];
        }
        Vec::new()
    }

    /// Timers: a heartbeat that never agreed, a climb that did not reach its altitude.
    pub fn poll(&mut self, now: Micros) -> Vec<SeqOut> {
        match self.phase {
            Phase::Climbing {
                deadline, since, ..
            } if now >= deadline => {
                let secs = (now - since) / SECOND;
                let at = match self.climb().and_then(|c| c.alt_m) {
                    Some(a) => format!(" (at {a:.1} m)"),
                    None => " (no altitude heard)".to_string(),
                };
                let text = format!(
                    "{}: not reached after {secs} s{at}; no longer waited for, nothing resent \
                     (watch the vehicle)",
                    self.climb_label(),
                );
                self.fail(text)
            }
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
            Phase::Confirming(d) | Phase::Climbing { deadline: d, .. } => Some(d),
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
    const IDS: Ids = Ids::Only(&[
        crate::dialect::HEARTBEAT_DATA::ID,
        crate::dialect::GLOBAL_POSITION_INT_DATA::ID,
        crate::dialect::EXTENDED_SYS_STATE_DATA::ID,
    ]);
    /// GLOBAL_POSITION_INT's height and EXTENDED_SYS_STATE's landed state are read from their
    /// payloads.
    const DECODES: Ids = Ids::Only(&[crate::dialect::HEARTBEAT_DATA::ID]);

    /// The vehicle's heartbeat: does it show the step done? Its position and landed state:
    /// has a take-off reached its altitude, or given up?
    fn on_message(&mut self, m: &Incoming, out: &mut Vec<Out>) {
        if let Some(hb) = m.heartbeat() {
            let armed = hb
                .base_mode
                .contains(crate::dialect::MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED);
            let name = crate::proto::modes::mode_name(hb.autopilot, hb.mavtype, hb.custom_mode);
            to_out(self.on_heartbeat(hb.custom_mode, armed, &name), out);
            return;
        }
        match m.id {
            // relative_alt i32 at byte 16 (after time_boot_ms, lat, lon, alt).
            crate::dialect::GLOBAL_POSITION_INT_DATA::ID => {
                let relative_alt = crate::wire::payload::Payload(m.payload).i32(16);
                to_out(self.on_position(relative_alt), out)
            }
            // landed_state is the second byte (a trailing zero may be cut by MAVLink 2).
            crate::dialect::EXTENDED_SYS_STATE_DATA::ID => {
                let state = m.payload.get(1).copied().unwrap_or(0);
                to_out(self.on_landed_state(state), out)
            }
            _ => {}
        }
    }

    fn poll(&mut self, now: Micros, out: &mut Vec<Out>) {
        to_out(Sequence::poll(self, now), out);
    }

    fn next_deadline(&self) -> Option<Micros> {
        Sequence::next_deadline(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dialect::MavCmd;
    use crate::wire::Severity;

    const GUIDED: u32 = 4;
    const LAND: u32 = 9;

    fn takeoff(alt: f64) -> Step {
        Step {
            spec: CommandSpec::long((1, 1), MavCmd::MAV_CMD_NAV_TAKEOFF, [0.0; 7]),
            until: Until::altitude(alt, Some(GUIDED)),
            label: format!("take off to {alt} m"),
            fallback: None,
        }
    }

    fn auto() -> Step {
        Step {
            spec: CommandSpec::long(
                (1, 1),
                MavCmd::MAV_CMD_DO_SET_MODE,
                [1.0, 3.0, 0., 0., 0., 0., 0.],
            ),
            until: Until::Mode(3),
            label: "AUTO".into(),
            fallback: None,
        }
    }

    /// A one-step take-off to `alt`, its NAV_TAKEOFF (id 7) accepted at 1 s.
    fn climbing(alt: f64) -> Sequence {
        let mut s = Sequence::new(format!("takeoff {alt} m"), vec![takeoff(alt)]);
        assert!(s.next_command().is_some());
        s.sent(7);
        assert_eq!(s.on_finished(SECOND, 7, true, "ACCEPTED"), Vec::new());
        s
    }

    fn last_word(out: &[SeqOut]) -> Option<&str> {
        match out {
            [SeqOut::Notice(_, t), SeqOut::Done] => Some(t),
            _ => None,
        }
    }

    #[test]
    fn tolerance_is_five_percent_and_at_least_half_a_metre() {
        assert_eq!(altitude_tolerance_m(10.0), 0.5);
        assert_eq!(altitude_tolerance_m(5.0), 0.5);
        assert_eq!(altitude_tolerance_m(100.0), 5.0);
        assert_eq!(climb_timeout(10.0), 30 * SECOND);
        assert_eq!(climb_timeout(f64::NAN), 10 * SECOND);
    }

    #[test]
    fn the_ack_is_not_the_end_the_altitude_is() {
        let mut s = climbing(10.0);
        assert!(!s.finished());
        assert_eq!(
            s.climb(),
            Some(Climb {
                target_m: 10.0,
                alt_m: None
            })
        );
        // Still armed in GUIDED, climbing: nothing yet.
        assert_eq!(s.on_heartbeat(GUIDED, true, "GUIDED"), Vec::new());
        assert_eq!(s.on_position(4_300), Vec::new());
        assert_eq!(s.climb().unwrap().alt_m, Some(4.3));
        // 9.49 m is outside 0.5 m of 10 m; 9.5 m is in.
        assert_eq!(s.on_position(9_490), Vec::new());
        let out = s.on_position(9_500);
        assert_eq!(last_word(&out), Some("take-off: 10.0 m reached"));
        assert!(s.finished());
        // The deadline went with it.
        assert_eq!(s.next_deadline(), None);
    }

    #[test]
    fn a_disarm_a_mode_change_a_landing_or_the_ground_again_end_the_wait() {
        let mut s = climbing(10.0);
        s.on_position(3_200);
        let out = s.on_heartbeat(GUIDED, false, "GUIDED");
        assert_eq!(
            last_word(&out),
            Some("take-off to 10.0 m: disarmed at 3.2 m; stopped")
        );
        assert!(matches!(out[0], SeqOut::Notice(Severity::WARNING, _)));
        assert!(s.finished());

        let mut s = climbing(10.0);
        let out = s.on_heartbeat(LAND, true, "LAND");
        assert_eq!(
            last_word(&out),
            Some("take-off to 10.0 m: mode changed to LAND; stopped")
        );

        let mut s = climbing(10.0);
        s.on_position(6_000);
        let out = s.on_landed_state(LANDING);
        assert_eq!(
            last_word(&out),
            Some("take-off to 10.0 m: landing at 6.0 m; stopped")
        );

        // On the ground at the ACK is the start; on the ground after leaving it is the end.
        let mut s = climbing(10.0);
        assert_eq!(s.on_landed_state(ON_GROUND), Vec::new());
        assert_eq!(s.on_landed_state(TAKEOFF), Vec::new());
        assert_eq!(s.on_landed_state(IN_AIR), Vec::new());
        let out = s.on_landed_state(ON_GROUND);
        assert_eq!(
            last_word(&out),
            Some("take-off to 10.0 m: back on the ground; stopped")
        );
    }

    #[test]
    fn a_climb_that_takes_too_long_is_no_longer_waited_for() {
        let mut s = climbing(10.0);
        s.on_position(6_300);
        assert_eq!(s.next_deadline(), Some(31 * SECOND));
        assert_eq!(s.poll(31 * SECOND - 1), Vec::new());
        let out = s.poll(31 * SECOND);
        assert_eq!(
            last_word(&out),
            Some(
                "take-off to 10.0 m: not reached after 30 s (at 6.3 m); no longer waited for, \
                 nothing resent (watch the vehicle)"
            )
        );
        // Nothing is sent: only the notice and the end.
        assert!(!out.iter().any(|o| matches!(o, SeqOut::Send(_))));
        assert!(s.finished());
    }

    #[test]
    fn in_a_longer_sequence_the_take_off_is_said_and_the_next_step_waits_for_it() {
        let mut s = Sequence::new("mission start", vec![takeoff(10.0), auto()]);
        s.sent(1);
        assert_eq!(s.on_finished(SECOND, 1, true, "ACCEPTED"), Vec::new());
        // AUTO is not submitted during the climb.
        assert_eq!(s.next_command(), None);
        s.on_position(5_000);
        assert_eq!(s.next_command(), None);
        let out = s.on_position(9_800);
        assert_eq!(
            out,
            vec![SeqOut::Notice(
                Severity::INFO,
                "take-off: 10.0 m reached".into()
            )]
        );
        assert_eq!(s.reached(), Some("take-off: 10.0 m reached"));
        assert_eq!(
            s.next_command().map(|c| c.command),
            Some(MavCmd::MAV_CMD_DO_SET_MODE as u16)
        );
        // Positions no longer matter; AUTO's answer clears the note.
        assert_eq!(s.on_position(2_000), Vec::new());
        s.sent(2);
        s.on_finished(2 * SECOND, 2, true, "ACCEPTED");
        assert_eq!(s.reached(), None);
        let out = s.on_heartbeat(3, true, "AUTO");
        assert_eq!(last_word(&out), Some("mission start: done"));
    }

    #[test]
    fn without_a_mode_to_keep_a_mode_change_is_part_of_the_take_off() {
        // PX4 goes to TAKEOFF, then HOLD, on its own.
        let mut step = takeoff(5.0);
        step.until = Until::altitude(5.0, None);
        let mut s = Sequence::new("takeoff 5 m", vec![step]);
        s.sent(3);
        s.on_finished(0, 3, true, "ACCEPTED");
        assert_eq!(s.on_heartbeat(0x0203_0000, true, "TAKEOFF"), Vec::new());
        let out = s.on_position(4_600);
        assert_eq!(last_word(&out), Some("take-off: 5.0 m reached"));
    }
}
