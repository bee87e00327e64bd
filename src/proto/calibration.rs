//! Calibrations of one vehicle, driven by what the vehicle sends (its ACKs, its position
//! requests, its MAG_CAL_PROGRESS and MAG_CAL_REPORT), never by a text alone.
//!
//! ArduPilot's sequences (`GCS_Common.cpp`, `AP_AccelCal.cpp`, `AP_Compass_Calibration.cpp`):
//! - Gyro (PREFLIGHT_CALIBRATION param1 = 1), level (param5 = 2) and simple accelerometer
//!   (param5 = 4) run in the handler: the vehicle goes quiet and its ACK is the result. Baro
//!   (param3 = 1) is ACCEPTED at once, or IN_PROGRESS then ACCEPTED with an airspeed sensor.
//! - Accelerometer, six positions (param5 = 1): the gyros are calibrated first, then ACCEPTED;
//!   while waiting for a position the vehicle sends COMMAND_LONG MAV_CMD_ACCELCAL_VEHICLE_POS
//!   (param1 = the position, 1..6) to the GCS every second (and says `Place vehicle … and press
//!   any key.` once per position until the GCS first answers with the command:
//!   `AP_AccelCal::gcs_vehicle_position` clears `_use_gcs_snoop`); the GCS answers with the
//!   same command and position when the vehicle is placed (ACCEPTED if it is the position
//!   asked, else FAILED); after the sixth the vehicle sends ACCELCAL_VEHICLE_POS_SUCCESS
//!   (16777215) or _FAILED (16777216, after `Calibration FAILED`), again every second. A
//!   SUCCESS or FAILED counts only after a position of this run was asked: the vehicle keeps
//!   repeating the last run's.
//! - Compass (DO_START_MAG_CAL, all compasses, retry, no autosave): ACCEPTED, then
//!   MAG_CAL_PROGRESS per compass while running and MAG_CAL_REPORT per compass once done
//!   (both repeated); DO_ACCEPT_MAG_CAL saves the offsets, DO_CANCEL_MAG_CAL stops. The new
//!   offsets are used after a reboot ("Compass calibrated requires reboot").
//! - Large vehicle (FIXED_MAG_CAL_YAW, the heading the vehicle faces, every compass, at its
//!   own position): the ACK is the result.
//!
//! Lost frames: a lost progress message is nothing (the next one comes); a lost ACK of a start
//! is recovered from the first position request or MAG_CAL_PROGRESS; a command with neither
//! its ACK nor any sign of it is sent again, [`MAX_SENDS`] in all, [`RESEND_AFTER`] apart
//! (calibrations are refused while armed and run again harmlessly), through the command queue.
//! A vehicle gone silent is not: an accelerometer or compass calibration with no word from
//! the vehicle (no position request, no MAG_CAL_PROGRESS or REPORT, no ACK) for
//! [`STALL_AFTER`] ends as failed, and one running when the vehicle reboots ends at once
//! ([`Calibration::on_reboot`], which also clears the reboot a compass calibration needed).

use std::collections::{BTreeMap, VecDeque};

use crate::clock::{Micros, SECOND};
use crate::dialect::{MavCmd, MavMessage, MavResult};
use crate::proto::ack::result_name;
use crate::proto::machine::{Ids, Incoming, Machine, Out, Request, Requests};
use crate::proto::vehicles::VehicleKey;
use crate::wire::payload::Payload;
use crate::wire::Severity;
use mavlink::MessageData;

/// A command with neither its ACK nor a sign of it is sent again after this long.
pub const RESEND_AFTER: Micros = 4 * SECOND;
/// Sends of one command, all told: at 20 % loss each way a send and its ACK both get through
/// 64 % of the time, so five sends all fail 0.6 % of the time (three: 4.7 %).
pub const MAX_SENDS: u32 = 5;
/// An IN_PROGRESS calibration with no word for this long has stopped answering.
pub const PROGRESS_TIMEOUT: Micros = 20 * SECOND;
/// An accelerometer or compass calibration with no word from the vehicle for this long has
/// stalled (the vehicle asks for a position every second and streams MAG_CAL_PROGRESS a few
/// times a second: this is many of them lost in a row, or a vehicle gone).
pub const STALL_AFTER: Micros = 15 * SECOND;
/// A text this close before an ACK explains it.
pub const EXPLAIN: Micros = SECOND;
/// What a saved compass calibration asks of the operator (the new offsets are used from the
/// next boot); the prompt's `reboot` asks first, then sends PREFLIGHT_REBOOT_SHUTDOWN.
pub const REBOOT_ADVICE: &str = "`reboot` the vehicle (asks first) to use the new offsets";
/// ACCELCAL_VEHICLE_POS_SUCCESS and _FAILED.
pub const POS_SUCCESS: f32 = 16_777_215.0;
pub const POS_FAILED: f32 = 16_777_216.0;

/// A calibration the operator can run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kind {
    Gyro,
    Baro,
    Level,
    Accel,
    SimpleAccel,
    Compass,
    /// ArduPilot's large-vehicle compass calibration, facing this heading (degrees).
    CompassFixed(f64),
}

impl Kind {
    /// The command that starts it: (MAV_CMD, params).
    pub fn command(self) -> (u16, [f64; 7]) {
        let pc = MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION as u16;
        match self {
            Kind::Gyro => (pc, [1., 0., 0., 0., 0., 0., 0.]),
            Kind::Baro => (pc, [0., 0., 1., 0., 0., 0., 0.]),
            Kind::Level => (pc, [0., 0., 0., 0., 2., 0., 0.]),
            Kind::Accel => (pc, [0., 0., 0., 0., 1., 0., 0.]),
            Kind::SimpleAccel => (pc, [0., 0., 0., 0., 4., 0., 0.]),
            // Every compass, retry a failed one, no autosave (the operator accepts), no delay,
            // no automatic reboot.
            Kind::Compass => (
                MavCmd::MAV_CMD_DO_START_MAG_CAL as u16,
                [0., 1., 0., 0., 0., 0., 0.],
            ),
            // Every compass, at the vehicle's own position (latitude and longitude 0).
            Kind::CompassFixed(yaw) => (
                MavCmd::MAV_CMD_FIXED_MAG_CAL_YAW as u16,
                [yaw, 0., 0., 0., 0., 0., 0.],
            ),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Kind::Gyro => "gyro calibration",
            Kind::Baro => "barometer calibration",
            Kind::Level => "level calibration",
            Kind::Accel => "accelerometer calibration",
            Kind::SimpleAccel => "simple accelerometer calibration",
            Kind::Compass => "compass calibration",
            Kind::CompassFixed(_) => "large-vehicle compass calibration",
        }
    }

    /// What the operator must do while it runs.
    pub fn advice(self) -> &'static str {
        match self {
            Kind::Gyro | Kind::Baro | Kind::SimpleAccel => "keep the vehicle still",
            Kind::Level => "keep the vehicle level and still",
            Kind::Accel => "place the vehicle as it asks, enter at each position",
            Kind::Compass => "rotate the vehicle about every axis",
            Kind::CompassFixed(_) => "the vehicle must face the heading given",
        }
    }

    /// The ArduPilot protocol it needs, for a calibration only ArduPilot runs this way (the
    /// profile's `ardupilot_calibrations`); `None` for PREFLIGHT_CALIBRATION's own.
    pub fn ardupilot_protocol(self) -> Option<&'static str> {
        match self {
            Kind::Accel => Some("ACCELCAL_VEHICLE_POS"),
            Kind::Compass => Some("DO_START_MAG_CAL"),
            Kind::CompassFixed(_) => Some("FIXED_MAG_CAL_YAW"),
            _ => None,
        }
    }

    /// Its result is its ACK (the vehicle runs it in the command handler).
    fn by_ack(self) -> bool {
        !matches!(self, Kind::Accel | Kind::Compass)
    }
}

/// The accelerometer position `n` (1..6): (as ArduPilot words it, which face is down).
pub fn position(n: u8) -> (&'static str, &'static str) {
    match n {
        1 => ("level", "bottom down"),
        2 => ("on its LEFT side", "left side down"),
        3 => ("on its RIGHT side", "right side down"),
        4 => ("nose DOWN", "nose down"),
        5 => ("nose UP", "tail down"),
        6 => ("on its BACK", "top down"),
        _ => ("?", "?"),
    }
}

/// Where a calibration stands.
#[derive(Debug, Clone, PartialEq)]
pub enum Phase {
    /// Sent; no answer yet.
    Starting,
    /// The vehicle runs it.
    Running,
    /// Accelerometer: the vehicle asks for position `n`; `enter` when it is there.
    Position(u8),
    /// Accelerometer: the operator placed it at `n`; the vehicle samples.
    Placed(u8),
    /// Compass: every compass reported success; accept or cancel.
    Accept,
    /// Over: `ok`, with the result's words.
    Done { ok: bool, text: String },
}

/// MAG_CAL_PROGRESS of one compass.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MagProgress {
    pub pct: u8,
    /// MAG_CAL_STATUS as sent.
    pub status: u8,
    pub attempt: u8,
    pub at: Micros,
}

/// MAG_CAL_REPORT of one compass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MagReport {
    /// MAG_CAL_STATUS as sent (4 success).
    pub status: u8,
    pub autosaved: bool,
    /// RMS milligauss residuals.
    pub fitness: f32,
    pub offsets: [f32; 3],
    pub at: Micros,
}

/// `SUCCESS`, `FAILED_RADIUS`, ... (MAG_CAL_STATUS); a newer value stays a number.
pub fn mag_status_name(s: u8) -> String {
    match s {
        0 => "NOT_STARTED".into(),
        1 => "WAITING_TO_START".into(),
        2 => "RUNNING_STEP_ONE".into(),
        3 => "RUNNING_STEP_TWO".into(),
        4 => "SUCCESS".into(),
        5 => "FAILED".into(),
        6 => "BAD_ORIENTATION".into(),
        7 => "BAD_RADIUS".into(),
        8 => "BAD_OFFSETS".into(),
        9 => "BAD_DIAG_SCALING".into(),
        10 => "RESIDUALS_HIGH".into(),
        n => format!("status {n}"),
    }
}

/// A command of the run waiting for its answer.
#[derive(Debug, Clone, PartialEq)]
struct Pending {
    command: u16,
    params: [f64; 7],
    sent: Micros,
    sends: u32,
    /// An answer (ACK or a sign of it) came.
    answered: bool,
    /// Waiting for the queue to take a resend.
    resend: bool,
}

/// One calibration, from its start to its result.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    pub kind: Kind,
    pub phase: Phase,
    pub started: Micros,
    /// When the vehicle last gave a sign of it.
    pub heard: Micros,
    /// IN_PROGRESS's progress, when it gives one.
    pub progress: Option<u8>,
    pub compasses: BTreeMap<u8, MagProgress>,
    pub reports: BTreeMap<u8, MagReport>,
    /// Accelerometer: positions the vehicle asked for in this run.
    pub asked: u32,
    /// The new offsets wait for a reboot.
    pub reboot_needed: bool,
    /// Sends of the commands of this run, all told (starts, resends, positions, accept).
    pub sends: u32,
    pending: Option<Pending>,
    /// Refused at this time, its reason not heard yet (ArduPilot sends it after the ACK).
    refused_at: Option<Micros>,
}

impl Run {
    pub fn finished(&self) -> bool {
        matches!(self.phase, Phase::Done { .. })
    }

    /// One line: what it is doing, or its result.
    pub fn status_line(&self) -> String {
        let name = self.kind.name();
        match &self.phase {
            Phase::Starting => format!("{name}: sent, {}", self.kind.advice()),
            Phase::Running => match (self.kind, self.progress) {
                (Kind::Compass, _) if !self.compasses.is_empty() => {
                    let bars: Vec<String> = self
                        .compasses
                        .iter()
                        .map(|(id, p)| format!("mag {id} {}%", p.pct))
                        .collect();
                    format!("{name}: {}; {}", bars.join(" "), self.kind.advice())
                }
                (_, Some(p)) if p <= 100 => format!("{name}: running {p}%"),
                _ => format!("{name}: running, {}", self.kind.advice()),
            },
            Phase::Position(n) => {
                let (words, face) = position(*n);
                format!("accel cal {n}/6: place the vehicle {words} ({face}), then enter")
            }
            Phase::Placed(n) => {
                let (words, _) = position(*n);
                format!("accel cal {n}/6: sampling {words}, keep it still")
            }
            Phase::Accept => {
                let fit: Vec<String> = self
                    .reports
                    .iter()
                    .map(|(id, r)| format!("mag {id} fitness {:.1}", r.fitness))
                    .collect();
                format!(
                    "{name} done: {}; `cal accept` saves it, `cal cancel` drops it",
                    fit.join(", ")
                )
            }
            Phase::Done { text, .. } => text.clone(),
        }
    }

    /// An accelerometer or compass calibration the vehicle runs (started, not over): the
    /// vehicle's steady word about it is expected, and its silence for [`STALL_AFTER`] ends it.
    fn stalls(&self) -> bool {
        matches!(self.kind, Kind::Accel | Kind::Compass)
            && matches!(
                self.phase,
                Phase::Running | Phase::Position(_) | Phase::Placed(_) | Phase::Accept
            )
    }

    fn done(&mut self, ok: bool, text: String, out: &mut Vec<Out>) {
        self.pending = None;
        let sev = if ok {
            Severity::INFO
        } else {
            Severity::WARNING
        };
        out.push(Out::notice(sev, text.clone()));
        self.phase = Phase::Done { ok, text };
    }
}

/// The calibrations of one vehicle: the one running (or the last one, with its result).
#[derive(Debug, Clone)]
pub struct Calibration {
    target: VehicleKey,
    pub run: Option<Run>,
    /// The vehicle's recent texts (time, text), to explain a refusal.
    texts: VecDeque<(Micros, String)>,
    /// Messages read that were not for a run (a stale position report, a progress with no
    /// calibration started here).
    pub ignored: u64,
    /// The time of the last message or poll (a resend taken goes out then).
    now: Micros,
}

impl Calibration {
    pub fn new(target: VehicleKey) -> Self {
        Self {
            target,
            run: None,
            texts: VecDeque::new(),
            ignored: 0,
            now: 0,
        }
    }

    /// True while a calibration runs.
    pub fn running(&self) -> bool {
        self.run.as_ref().is_some_and(|r| !r.finished())
    }

    /// The operator starts `kind` (its command is submitted by the caller): (command, params).
    pub fn start(&mut self, now: Micros, kind: Kind) -> Result<(u16, [f64; 7]), String> {
        if let Some(r) = self.run.as_ref().filter(|r| !r.finished()) {
            return Err(format!(
                "{} is still running: `cal cancel` first",
                r.kind.name()
            ));
        }
        let (command, params) = kind.command();
        self.run = Some(Run {
            kind,
            phase: Phase::Starting,
            started: now,
            heard: now,
            progress: None,
            compasses: BTreeMap::new(),
            reports: BTreeMap::new(),
            asked: 0,
            reboot_needed: false,
            sends: 1,
            pending: Some(Pending {
                command,
                params,
                sent: now,
                sends: 1,
                answered: false,
                resend: false,
            }),
            refused_at: None,
        });
        Ok((command, params))
    }

    /// The command `enter` would send at an accelerometer position (the vehicle is placed),
    /// without changing anything: the caller sends it, then calls [`Calibration::placed`].
    pub fn placing(&self) -> Result<(u16, [f64; 7]), String> {
        let run = self
            .run
            .as_ref()
            .filter(|r| !r.finished())
            .ok_or("no calibration running")?;
        let Phase::Position(n) = run.phase else {
            return Err(match run.phase {
                Phase::Placed(n) => format!("position {n} is being sampled: wait for the next"),
                _ => "the vehicle has not asked for a position yet".into(),
            });
        };
        let command = MavCmd::MAV_CMD_ACCELCAL_VEHICLE_POS as u16;
        Ok((command, [n as f64, 0., 0., 0., 0., 0., 0.]))
    }

    /// `enter` at an accelerometer position, its command sent: the vehicle samples it.
    pub fn placed(&mut self, now: Micros) -> Result<(u16, [f64; 7]), String> {
        let (command, params) = self.placing()?;
        let run = self.run.as_mut().ok_or("no calibration running")?;
        run.phase = Phase::Placed(params[0] as u8);
        run.sends += 1;
        run.pending = Some(Pending {
            command,
            params,
            sent: now,
            sends: 1,
            answered: false,
            resend: false,
        });
        Ok((command, params))
    }

    /// `cal accept`: DO_ACCEPT_MAG_CAL for every compass.
    pub fn accept(&mut self, now: Micros) -> Result<(u16, [f64; 7]), String> {
        let run = self
            .run
            .as_mut()
            .filter(|r| r.phase == Phase::Accept)
            .ok_or("no compass calibration waiting to be accepted")?;
        let command = MavCmd::MAV_CMD_DO_ACCEPT_MAG_CAL as u16;
        let params = [0.; 7];
        run.sends += 1;
        run.pending = Some(Pending {
            command,
            params,
            sent: now,
            sends: 1,
            answered: false,
            resend: false,
        });
        Ok((command, params))
    }

    /// `cal cancel`: DO_CANCEL_MAG_CAL for a compass calibration (`Some`); any other is only
    /// no longer followed (ArduPilot has no command to stop it: it ends on its own).
    pub fn cancel(&mut self, now: Micros) -> Result<Option<(u16, [f64; 7])>, String> {
        let run = self
            .run
            .as_mut()
            .filter(|r| !r.finished())
            .ok_or("no calibration running")?;
        if run.kind != Kind::Compass {
            let text = format!("{}: no longer followed", run.kind.name());
            run.pending = None;
            run.phase = Phase::Done { ok: false, text };
            return Ok(None);
        }
        let command = MavCmd::MAV_CMD_DO_CANCEL_MAG_CAL as u16;
        let params = [0.; 7];
        run.sends += 1;
        run.pending = Some(Pending {
            command,
            params,
            sent: now,
            sends: 1,
            answered: false,
            resend: false,
        });
        Ok(Some((command, params)))
    }

    /// The vehicle rebooted: a calibration it was running is over (it forgot it), and the
    /// reboot a compass calibration needed has happened.
    pub fn on_reboot(&mut self, now: Micros, out: &mut Vec<Out>) {
        self.now = now;
        let Some(run) = self.run.as_mut() else {
            return;
        };
        if !run.finished() {
            let text = format!("{} FAILED: the vehicle rebooted", run.kind.name());
            run.done(false, text, out);
        } else if run.reboot_needed {
            run.reboot_needed = false;
            if let Phase::Done { text, .. } = &mut run.phase {
                *text = format!(
                    "{}: the vehicle rebooted, new offsets in use",
                    run.kind.name()
                );
            }
            out.push(Out::notice(Severity::INFO, run.status_line()));
        }
    }

    /// A text the vehicle said: kept a moment to explain a refusal, or the reason of the one
    /// that just came.
    pub fn on_text(&mut self, now: Micros, text: &str) {
        if let Some(run) = self.run.as_mut() {
            if let (Some(at), Phase::Done { ok: false, text: t }) = (run.refused_at, &mut run.phase)
            {
                if crate::proto::health::reason_of(text).is_some() {
                    // A pre-arm statement explains no calibration: keep waiting.
                } else if now.saturating_sub(at) <= EXPLAIN {
                    run.refused_at = None;
                    t.push_str(&format!(" ({text})"));
                    return;
                } else {
                    run.refused_at = None;
                }
            }
        }
        if self.texts.len() == 8 {
            self.texts.pop_front();
        }
        self.texts.push_back((now, text.to_string()));
    }

    /// The text that explains an answer at `now`: the latest of the last [`EXPLAIN`], a
    /// pre-arm statement (`PreArm: …`, repeated on its own every 30 s) left out.
    fn reason(&self, now: Micros) -> Option<String> {
        self.texts
            .iter()
            .rev()
            .filter(|(_, s)| crate::proto::health::reason_of(s).is_none())
            .find(|(t, _)| now.saturating_sub(*t) <= EXPLAIN)
            .map(|(_, s)| s.clone())
    }

    fn on_ack(&mut self, now: Micros, command: u16, result: u8, progress: u8, out: &mut Vec<Out>) {
        let reason = self.reason(now);
        let Some(run) = self.run.as_mut().filter(|r| !r.finished()) else {
            return;
        };
        let Some(p) = run.pending.as_mut().filter(|p| p.command == command) else {
            return;
        };
        p.answered = true;
        run.heard = now;
        let accepted = result == MavResult::MAV_RESULT_ACCEPTED as u8;
        let in_progress = result == MavResult::MAV_RESULT_IN_PROGRESS as u8;
        let why = reason.map(|r| format!(" ({r})")).unwrap_or_default();
        let name = run.kind.name();
        let accelpos = MavCmd::MAV_CMD_ACCELCAL_VEHICLE_POS as u16;
        let accept = MavCmd::MAV_CMD_DO_ACCEPT_MAG_CAL as u16;
        let cancel = MavCmd::MAV_CMD_DO_CANCEL_MAG_CAL as u16;
        if command == accelpos {
            if !accepted {
                // Not the position the vehicle waits for (it moved on, or our answer was
                // stale): it asks again.
                if let Phase::Placed(n) = run.phase {
                    run.phase = Phase::Position(n);
                }
            }
            run.pending = None;
            return;
        }
        if command == accept {
            if accepted {
                run.reboot_needed = true;
                let text = format!("{name} accepted: {REBOOT_ADVICE}");
                run.done(true, text, out);
            } else {
                let text = format!("{name}: accept {}{why}", result_name(result));
                run.done(false, text, out);
                run.refused_at = why.is_empty().then_some(now);
            }
            return;
        }
        if command == cancel {
            let text = if accepted {
                format!("{name} cancelled")
            } else {
                format!("{name}: cancel {}{why}", result_name(result))
            };
            run.done(false, text, out);
            return;
        }
        // The start's answer.
        if in_progress {
            run.progress = Some(progress);
            run.phase = Phase::Running;
            return;
        }
        if !accepted {
            let text = format!("{name} refused: {}{why}", result_name(result));
            run.done(false, text, out);
            run.refused_at = why.is_empty().then_some(now);
            return;
        }
        if run.kind.by_ack() {
            let text = format!("{name}: done");
            run.done(true, text, out);
            return;
        }
        run.pending = None;
        if run.phase == Phase::Starting {
            run.phase = Phase::Running;
            out.push(Out::notice(
                Severity::INFO,
                format!("{name} started: {}", run.kind.advice()),
            ));
        }
    }

    /// The vehicle asks for accelerometer position `pos` (or tells the result).
    fn on_position(&mut self, now: Micros, pos: f32, out: &mut Vec<Out>) {
        let reason = self.reason(now);
        let Some(run) = self
            .run
            .as_mut()
            .filter(|r| !r.finished() && r.kind == Kind::Accel)
        else {
            self.ignored += 1;
            return;
        };
        if pos == POS_SUCCESS || pos == POS_FAILED {
            if run.asked == 0 {
                // The last run's result, repeated: not this one's.
                self.ignored += 1;
                return;
            }
            run.heard = now;
            if pos == POS_SUCCESS {
                run.done(true, format!("{}: successful", run.kind.name()), out);
            } else {
                let why = reason.map(|r| format!(" ({r})")).unwrap_or_default();
                run.done(false, format!("{} FAILED{why}", run.kind.name()), out);
            }
            return;
        }
        if !(1.0..=6.0).contains(&pos) || pos.fract() != 0.0 {
            self.ignored += 1;
            return;
        }
        let n = pos as u8;
        run.heard = now;
        run.asked += 1;
        // The start was heard, whether or not its ACK was.
        if let Some(p) = run.pending.as_mut() {
            if p.command == MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION as u16 {
                run.pending = None;
            } else if p.command == MavCmd::MAV_CMD_ACCELCAL_VEHICLE_POS as u16
                && p.params[0] as u8 != n
            {
                // The vehicle moved on: our answer arrived.
                run.pending = None;
            }
        }
        match run.phase {
            // Still asking for the one placed: our answer may be on its way, or lost (the
            // resend timer decides).
            Phase::Placed(m) if m == n => {}
            Phase::Position(m) if m == n => {}
            _ => {
                let (words, face) = position(n);
                out.push(Out::notice(
                    Severity::INFO,
                    format!("accel cal {n}/6: place the vehicle {words} ({face}), then enter"),
                ));
                run.phase = Phase::Position(n);
            }
        }
    }

    fn on_mag_progress(&mut self, now: Micros, payload: &[u8], out: &mut Vec<Out>) {
        let p = Payload(payload);
        let Some(run) = self
            .run
            .as_mut()
            .filter(|r| !r.finished() && r.kind == Kind::Compass)
        else {
            self.ignored += 1;
            return;
        };
        let id = p.u8(12);
        let prog = MagProgress {
            status: p.u8(14),
            attempt: p.u8(15),
            pct: p.u8(16).min(100),
            at: now,
        };
        run.heard = now;
        // Running again (a retry): its old report no longer stands.
        run.reports.remove(&id);
        run.compasses.insert(id, prog);
        if let Some(pd) = run.pending.as_ref() {
            if pd.command == MavCmd::MAV_CMD_DO_START_MAG_CAL as u16 {
                run.pending = None;
            }
        }
        if matches!(run.phase, Phase::Starting | Phase::Accept) {
            if run.phase == Phase::Starting {
                out.push(Out::notice(
                    Severity::INFO,
                    format!("{} started: {}", run.kind.name(), run.kind.advice()),
                ));
            }
            run.phase = Phase::Running;
        }
    }

    fn on_mag_report(&mut self, now: Micros, payload: &[u8], out: &mut Vec<Out>) {
        let p = Payload(payload);
        let Some(run) = self
            .run
            .as_mut()
            .filter(|r| !r.finished() && r.kind == Kind::Compass)
        else {
            self.ignored += 1;
            return;
        };
        let id = p.u8(40);
        let report = MagReport {
            fitness: p.f32(0),
            offsets: [p.f32(4), p.f32(8), p.f32(12)],
            status: p.u8(42),
            autosaved: p.u8(43) != 0,
            at: now,
        };
        run.heard = now;
        if let Some(pd) = run.pending.as_ref() {
            if pd.command == MavCmd::MAV_CMD_DO_START_MAG_CAL as u16 {
                run.pending = None;
            }
        }
        run.reports.insert(id, report);
        if let Some(c) = run.compasses.get_mut(&id) {
            c.pct = 100;
            c.status = report.status;
        } else {
            run.compasses.insert(
                id,
                MagProgress {
                    pct: 100,
                    status: report.status,
                    attempt: 0,
                    at: now,
                },
            );
        }
        // Over when every compass heard of has reported.
        if run.phase == Phase::Accept || run.compasses.keys().any(|k| !run.reports.contains_key(k))
        {
            return;
        }
        let failed: Vec<String> = run
            .reports
            .iter()
            .filter(|(_, r)| r.status != 4)
            .map(|(id, r)| {
                format!(
                    "mag {id} {} fitness {:.1}",
                    mag_status_name(r.status),
                    r.fitness
                )
            })
            .collect();
        let name = run.kind.name();
        if !failed.is_empty() {
            run.done(false, format!("{name} FAILED: {}", failed.join(", ")), out);
        } else if run.reports.values().all(|r| r.autosaved) {
            run.reboot_needed = true;
            let text = format!("{name} saved: {REBOOT_ADVICE}");
            run.done(true, text, out);
        } else {
            run.phase = Phase::Accept;
            out.push(Out::notice(Severity::INFO, run.status_line()));
        }
    }
}

impl Machine for Calibration {
    const IDS: Ids = Ids::Only(&[
        crate::dialect::COMMAND_ACK_DATA::ID,
        crate::dialect::COMMAND_LONG_DATA::ID,
        crate::dialect::MAG_CAL_PROGRESS_DATA::ID,
        crate::dialect::MAG_CAL_REPORT_DATA::ID,
    ]);
    /// The compass reports are read from their payloads, the ACK as [`Incoming::ack`].
    const DECODES: Ids = Ids::Only(&[crate::dialect::COMMAND_LONG_DATA::ID]);

    fn on_message(&mut self, m: &Incoming, out: &mut Vec<Out>) {
        self.now = m.now;
        if let Some(ack) = m.ack {
            self.on_ack(m.now, ack.command, ack.result, ack.progress, out);
            return;
        }
        match m.id {
            id if id == crate::dialect::MAG_CAL_PROGRESS_DATA::ID => {
                self.on_mag_progress(m.now, m.payload, out)
            }
            id if id == crate::dialect::MAG_CAL_REPORT_DATA::ID => {
                self.on_mag_report(m.now, m.payload, out)
            }
            _ => {
                if let Some(MavMessage::COMMAND_LONG(c)) = m.msg {
                    if c.command == MavCmd::MAV_CMD_ACCELCAL_VEHICLE_POS {
                        self.on_position(m.now, c.param1, out);
                    }
                }
            }
        }
    }

    fn poll(&mut self, now: Micros, out: &mut Vec<Out>) {
        self.now = now;
        let Some(run) = self.run.as_mut().filter(|r| !r.finished()) else {
            return;
        };
        if run.phase == Phase::Running
            && run.progress.is_some()
            && now.saturating_sub(run.heard) >= PROGRESS_TIMEOUT
        {
            let text = format!("{}: the vehicle stopped answering", run.kind.name());
            run.done(false, text, out);
            return;
        }
        if run.stalls() && now.saturating_sub(run.heard) >= STALL_AFTER {
            let what = match run.kind {
                Kind::Accel => "no position request",
                _ => "no MAG_CAL_PROGRESS or REPORT",
            };
            let text = format!(
                "{} FAILED: no word from the vehicle for {} s ({what}): is it still there? \
                 start again",
                run.kind.name(),
                STALL_AFTER / SECOND
            );
            run.done(false, text, out);
            return;
        }
        let Some(p) = run.pending.as_mut() else {
            return;
        };
        if p.answered || p.resend || now < p.sent + RESEND_AFTER {
            return;
        }
        if p.sends >= MAX_SENDS {
            let what = crate::proto::ack::command_name(p.command);
            let text = format!(
                "{}: no answer from the vehicle to {what} after {} sends",
                run.kind.name(),
                p.sends
            );
            run.done(false, text, out);
            return;
        }
        p.resend = true;
    }

    fn next_deadline(&self) -> Option<Micros> {
        let run = self.run.as_ref().filter(|r| !r.finished())?;
        let p = run.pending.as_ref();
        let resend = p
            .filter(|p| !p.answered && !p.resend)
            .map(|p| p.sent + RESEND_AFTER);
        let quiet = (run.phase == Phase::Running && run.progress.is_some())
            .then_some(run.heard + PROGRESS_TIMEOUT);
        let stall = run.stalls().then_some(run.heard + STALL_AFTER);
        [resend, quiet, stall].into_iter().flatten().min()
    }
}

impl Requests for Calibration {
    /// The command to send again, when one is due.
    fn requests(&self) -> Vec<Request> {
        self.run
            .as_ref()
            .and_then(|r| r.pending.as_ref())
            .filter(|p| p.resend)
            .map(|p| vec![(self.target.1, p.command, p.params)])
            .unwrap_or_default()
    }

    fn taken(&mut self, _: &Request) {
        let now = self.now;
        if let Some(run) = self.run.as_mut() {
            if let Some(p) = run.pending.as_mut() {
                p.resend = false;
                p.sends += 1;
                p.sent = now;
            }
            run.sends += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    //! The machine fed ArduPilot's messages as `GCS_Common.cpp`, `AP_AccelCal.cpp` and
    //! `AP_Compass_Calibration.cpp` send them, through our encoder and parser.

    use super::*;
    use crate::dialect::{self, MagCalStatus};
    use crate::proto::machine::received;

    const KEY: VehicleKey = VehicleKey(1, 1);
    const S: Micros = SECOND;

    fn feed(c: &mut Calibration, now: Micros, msg: &MavMessage) -> Vec<Out> {
        let mut out = Vec::new();
        received(now, msg, |m| c.on_message(m, &mut out));
        out
    }

    fn ack(command: MavCmd, result: MavResult) -> MavMessage {
        MavMessage::COMMAND_ACK(dialect::COMMAND_ACK_DATA {
            command,
            result,
            target_system: 255,
            target_component: 190,
            ..Default::default()
        })
    }

    /// `send_accelcal_vehicle_position`: COMMAND_LONG to 0:0.
    fn pos(p: f32) -> MavMessage {
        MavMessage::COMMAND_LONG(dialect::COMMAND_LONG_DATA {
            command: MavCmd::MAV_CMD_ACCELCAL_VEHICLE_POS,
            param1: p,
            ..Default::default()
        })
    }

    fn progress(id: u8, status: MagCalStatus, pct: u8) -> MavMessage {
        MavMessage::MAG_CAL_PROGRESS(dialect::MAG_CAL_PROGRESS_DATA {
            compass_id: id,
            cal_mask: 1,
            cal_status: status,
            attempt: 1,
            completion_pct: pct,
            ..Default::default()
        })
    }

    fn report(id: u8, status: MagCalStatus) -> MavMessage {
        MavMessage::MAG_CAL_REPORT(dialect::MAG_CAL_REPORT_DATA {
            compass_id: id,
            cal_mask: 1,
            cal_status: status,
            fitness: 4.5,
            ofs_x: 30.0,
            ofs_y: -20.0,
            ofs_z: 55.0,
            ..Default::default()
        })
    }

    fn phase(c: &Calibration) -> Phase {
        c.run.as_ref().unwrap().phase.clone()
    }

    fn done(ok: bool, text: &str) -> Phase {
        Phase::Done {
            ok,
            text: text.into(),
        }
    }

    /// [`compass_running`] ended SUCCESS at 1 s and accepted at 2 s (the vehicle's ACK in).
    fn compass_accepted() -> Calibration {
        let mut c = compass_running();
        feed(&mut c, S, &report(0, MagCalStatus::MAG_CAL_SUCCESS));
        c.accept(2 * S).unwrap();
        feed(
            &mut c,
            2 * S,
            &ack(
                MavCmd::MAV_CMD_DO_ACCEPT_MAG_CAL,
                MavResult::MAV_RESULT_ACCEPTED,
            ),
        );
        c
    }

    /// A compass calibration started at 0, the vehicle's ACK with `result` in at 0.1 s.
    fn compass_started(result: MavResult) -> Calibration {
        let mut c = Calibration::new(KEY);
        c.start(0, Kind::Compass).unwrap();
        feed(
            &mut c,
            S / 10,
            &ack(MavCmd::MAV_CMD_DO_START_MAG_CAL, result),
        );
        c
    }

    /// A compass calibration running from its ACK, compass 0 at 40 %.
    fn compass_running() -> Calibration {
        let mut c = compass_started(MavResult::MAV_RESULT_ACCEPTED);
        feed(
            &mut c,
            S / 2,
            &progress(0, MagCalStatus::MAG_CAL_RUNNING_STEP_ONE, 40),
        );
        assert_eq!(phase(&c), Phase::Running);
        c
    }

    /// An accelerometer calibration at position 2 (position 1 placed and accepted).
    fn accel_at_two() -> Calibration {
        let mut c = Calibration::new(KEY);
        c.start(0, Kind::Accel).unwrap();
        let cal = MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION;
        feed(&mut c, 3 * S, &ack(cal, MavResult::MAV_RESULT_ACCEPTED));
        feed(&mut c, 3 * S, &pos(1.0));
        assert_eq!(phase(&c), Phase::Position(1));
        c.placed(4 * S).unwrap();
        let p = MavCmd::MAV_CMD_ACCELCAL_VEHICLE_POS;
        feed(&mut c, 4 * S, &ack(p, MavResult::MAV_RESULT_ACCEPTED));
        feed(&mut c, 5 * S, &pos(2.0));
        assert_eq!(phase(&c), Phase::Position(2));
        c
    }

    /// `AP_AccelCal::fail`: `Calibration FAILED`, then ACCELCAL_VEHICLE_POS_FAILED (and again
    /// every second): the run fails with the vehicle's words.
    #[test]
    fn accel_failed_after_positions_of_this_run() {
        let mut c = accel_at_two();
        c.on_text(5 * S + S / 2, "Calibration FAILED");
        let out = feed(&mut c, 6 * S, &pos(POS_FAILED));
        assert_eq!(
            phase(&c),
            done(
                false,
                "accelerometer calibration FAILED (Calibration FAILED)"
            )
        );
        assert_eq!(out.len(), 1, "told once");
        // Its repeats are nothing more.
        feed(&mut c, 7 * S, &pos(POS_FAILED));
        assert_eq!(c.ignored, 1);
        assert_eq!(c.next_deadline(), None);
    }

    /// The last run's SUCCESS, repeated every second until `AP_AccelCal::start`, is not this
    /// run's result; the first position request then shows the start was heard though its ACK
    /// was lost.
    #[test]
    fn a_stale_success_of_the_last_run_is_ignored() {
        let mut c = Calibration::new(KEY);
        c.start(0, Kind::Accel).unwrap();
        feed(&mut c, S / 2, &pos(POS_SUCCESS));
        assert_eq!(phase(&c), Phase::Starting);
        assert_eq!(c.ignored, 1);
        // The ACK lost; position 1 asked: started, nothing to resend.
        feed(&mut c, 3 * S, &pos(1.0));
        assert_eq!(phase(&c), Phase::Position(1));
        c.poll(3 * S + RESEND_AFTER, &mut Vec::new());
        assert!(c.requests().is_empty());
        // A SUCCESS once a position of this run was asked ends it.
        feed(&mut c, 20 * S, &pos(POS_SUCCESS));
        assert_eq!(
            phase(&c),
            done(true, "accelerometer calibration: successful")
        );
    }

    /// `Compass::_accept_calibration` fails for a compass not SUCCESS, with no text: the
    /// refusal stands alone, and a pre-arm statement near it is not taken for its reason.
    #[test]
    fn a_refused_accept() {
        let mut c = compass_running();
        feed(&mut c, S, &report(0, MagCalStatus::MAG_CAL_SUCCESS));
        assert_eq!(phase(&c), Phase::Accept);
        let (command, params) = c.accept(2 * S).unwrap();
        assert_eq!((command, params), (42425, [0.; 7]));
        c.on_text(2 * S + S / 10, "PreArm: Compass calibration running");
        feed(
            &mut c,
            2 * S + S / 5,
            &ack(
                MavCmd::MAV_CMD_DO_ACCEPT_MAG_CAL,
                MavResult::MAV_RESULT_FAILED,
            ),
        );
        assert_eq!(phase(&c), done(false, "compass calibration: accept FAILED"));
        c.on_text(2 * S + S / 2, "PreArm: Compass calibration running");
        c.on_text(4 * S, "EKF3 IMU0 is using GPS");
        assert_eq!(phase(&c), done(false, "compass calibration: accept FAILED"));
        assert!(!c.run.as_ref().unwrap().reboot_needed);
        // Accepted: saved, the reboot it needs said.
        let c = compass_accepted();
        assert_eq!(
            phase(&c),
            done(
                true,
                &format!("compass calibration accepted: {REBOOT_ADVICE}")
            )
        );
        assert!(c.run.as_ref().unwrap().reboot_needed);
    }

    /// A refusal's reason is the text ArduPilot sends after its ACK, within EXPLAIN.
    #[test]
    fn a_refused_start_takes_the_text_after_it() {
        let mut c = compass_started(MavResult::MAV_RESULT_FAILED);
        c.on_text(S / 5, "Disarm to allow compass calibration");
        assert_eq!(
            phase(&c),
            done(
                false,
                "compass calibration refused: FAILED (Disarm to allow compass calibration)"
            )
        );
    }

    /// Barometer with an airspeed sensor (`GCS_MAVLINK_InProgress`): IN_PROGRESS, again every
    /// second, then ACCEPTED.
    #[test]
    fn baro_in_progress_then_accepted() {
        let mut c = Calibration::new(KEY);
        let (command, params) = c.start(0, Kind::Baro).unwrap();
        assert_eq!((command, params[2]), (241, 1.0));
        let cal = MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION;
        feed(&mut c, S / 10, &ack(cal, MavResult::MAV_RESULT_IN_PROGRESS));
        assert_eq!(phase(&c), Phase::Running);
        let run = c.run.as_ref().unwrap();
        assert_eq!(run.status_line(), "barometer calibration: running 0%");
        for t in 1..8 {
            feed(&mut c, t * S, &ack(cal, MavResult::MAV_RESULT_IN_PROGRESS));
        }
        // Nothing resent while it runs.
        c.poll(7 * S + RESEND_AFTER, &mut Vec::new());
        assert!(c.requests().is_empty());
        assert_eq!(phase(&c), Phase::Running);
        feed(&mut c, 8 * S, &ack(cal, MavResult::MAV_RESULT_ACCEPTED));
        assert_eq!(phase(&c), done(true, "barometer calibration: done"));
        // Silent after IN_PROGRESS for PROGRESS_TIMEOUT: stopped answering.
        let mut c = Calibration::new(KEY);
        c.start(0, Kind::Baro).unwrap();
        feed(&mut c, S, &ack(cal, MavResult::MAV_RESULT_IN_PROGRESS));
        assert_eq!(c.next_deadline(), Some(S + PROGRESS_TIMEOUT));
        c.poll(S + PROGRESS_TIMEOUT, &mut Vec::new());
        assert_eq!(
            phase(&c),
            done(
                false,
                "barometer calibration: the vehicle stopped answering"
            )
        );
    }

    /// DO_CANCEL_MAG_CAL for every compass (mask 0), ACCEPTED: cancelled.
    #[test]
    fn a_compass_calibration_cancelled() {
        let mut c = compass_running();
        let (command, params) = c.cancel(S).unwrap().unwrap();
        assert_eq!((command, params), (42426, [0.; 7]));
        // Progress still in flight changes nothing.
        feed(
            &mut c,
            S + S / 10,
            &progress(0, MagCalStatus::MAG_CAL_RUNNING_STEP_ONE, 45),
        );
        feed(
            &mut c,
            S + S / 5,
            &ack(
                MavCmd::MAV_CMD_DO_CANCEL_MAG_CAL,
                MavResult::MAV_RESULT_ACCEPTED,
            ),
        );
        assert_eq!(phase(&c), done(false, "compass calibration cancelled"));
        // Any other is only no longer followed (nothing to send).
        let mut c = accel_at_two();
        assert_eq!(c.cancel(6 * S), Ok(None));
        assert_eq!(
            phase(&c),
            done(false, "accelerometer calibration: no longer followed")
        );
    }

    /// A vehicle gone silent: no position request or MAG_CAL_PROGRESS for STALL_AFTER ends
    /// the calibration as failed, with the reason.
    #[test]
    fn a_silent_vehicle_ends_it_after_the_stall_time() {
        let mut c = accel_at_two();
        assert_eq!(c.next_deadline(), Some(5 * S + STALL_AFTER));
        // Asked every second: not stalled however long the operator takes.
        for t in 6..40 {
            feed(&mut c, t * S, &pos(2.0));
        }
        c.poll(39 * S + STALL_AFTER - 1, &mut Vec::new());
        assert_eq!(phase(&c), Phase::Position(2));
        let mut out = Vec::new();
        c.poll(39 * S + STALL_AFTER, &mut out);
        assert_eq!(
            phase(&c),
            done(
                false,
                "accelerometer calibration FAILED: no word from the vehicle for 15 s (no \
                 position request): is it still there? start again"
            )
        );
        assert_eq!(out.len(), 1);
        // Placed, then nothing (its last word, position 2 asked, at 5 s): resent meanwhile,
        // then given up.
        let mut c = accel_at_two();
        c.placed(6 * S).unwrap();
        c.poll(6 * S + RESEND_AFTER, &mut Vec::new());
        assert_eq!(c.requests().len(), 1, "the answer sent again");
        c.poll(5 * S + STALL_AFTER - 1, &mut Vec::new());
        assert!(c.running());
        c.poll(5 * S + STALL_AFTER, &mut Vec::new());
        assert!(!c.running());
        // Compass.
        let mut c = compass_running();
        c.poll(S / 2 + STALL_AFTER, &mut Vec::new());
        assert!(
            matches!(&phase(&c), Phase::Done { ok: false, text }
                if text.contains("no MAG_CAL_PROGRESS or REPORT")),
            "{:?}",
            phase(&c)
        );
        // Gyro, level, simple accel and baro are the ACK's alone: no stall.
        let mut c = Calibration::new(KEY);
        c.start(0, Kind::Gyro).unwrap();
        c.poll(STALL_AFTER, &mut Vec::new());
        assert!(c.running());
    }

    /// A reboot ends a calibration running, and is the one an accepted compass calibration
    /// needed.
    #[test]
    fn a_reboot_ends_a_run_and_clears_the_reboot_needed() {
        let mut c = compass_running();
        let mut out = Vec::new();
        c.on_reboot(2 * S, &mut out);
        assert_eq!(
            phase(&c),
            done(false, "compass calibration FAILED: the vehicle rebooted")
        );
        let mut c = compass_accepted();
        let mut out = Vec::new();
        c.on_reboot(9 * S, &mut out);
        let run = c.run.as_ref().unwrap();
        assert!(!run.reboot_needed);
        assert_eq!(
            run.phase,
            done(
                true,
                "compass calibration: the vehicle rebooted, new offsets in use"
            )
        );
        assert_eq!(out.len(), 1);
        // Again: nothing more.
        let mut out = Vec::new();
        c.on_reboot(20 * S, &mut out);
        assert!(out.is_empty());
    }

    /// `placing` tells what enter would send without taking it as sent.
    #[test]
    fn placing_changes_nothing() {
        let mut c = accel_at_two();
        let before = c.run.clone();
        assert_eq!(c.placing(), Ok((42429, [2., 0., 0., 0., 0., 0., 0.])));
        assert_eq!(c.run, before);
        c.placed(6 * S).unwrap();
        assert_eq!(phase(&c), Phase::Placed(2));
        assert!(c.placing().unwrap_err().contains("being sampled"));
    }
}
