//! Calibrations of one vehicle, driven by what the vehicle sends (its ACKs, its position
//! requests, its MAG_CAL_PROGRESS and MAG_CAL_REPORT), never by a text alone.
//!
//! ArduPilot's sequences (`GCS_Common.cpp`, `AP_AccelCal.cpp`, `AP_Compass_Calibration.cpp`):
//! - Gyro (PREFLIGHT_CALIBRATION param1 = 1), level (param5 = 2) and simple accelerometer
//!   (param5 = 4) run in the handler: the vehicle goes quiet and its ACK is the result. Baro
//!   (param3 = 1) is ACCEPTED at once, or IN_PROGRESS then ACCEPTED with an airspeed sensor.
//! - Accelerometer, six positions (param5 = 1): the gyros are calibrated first, then ACCEPTED;
//!   while waiting for a position the vehicle says `Place vehicle … and press any key.` once and
//!   sends COMMAND_LONG MAV_CMD_ACCELCAL_VEHICLE_POS (param1 = the position, 1..6) to the GCS
//!   every second; the GCS answers with the same command and position when the vehicle is
//!   placed (ACCEPTED if it is the position asked, else FAILED); after the sixth the vehicle
//!   sends ACCELCAL_VEHICLE_POS_SUCCESS (16777215) or _FAILED (16777216), again every second.
//!   A SUCCESS or FAILED counts only after a position of this run was asked: the vehicle keeps
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
/// A text this close before an ACK explains it.
pub const EXPLAIN: Micros = SECOND;
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

    /// `enter` at an accelerometer position: the command telling the vehicle it is placed.
    pub fn placed(&mut self, now: Micros) -> Result<(u16, [f64; 7]), String> {
        let run = self
            .run
            .as_mut()
            .filter(|r| !r.finished())
            .ok_or("no calibration running")?;
        let Phase::Position(n) = run.phase else {
            return Err(match run.phase {
                Phase::Placed(n) => format!("position {n} is being sampled: wait for the next"),
                _ => "the vehicle has not asked for a position yet".into(),
            });
        };
        let command = MavCmd::MAV_CMD_ACCELCAL_VEHICLE_POS as u16;
        let params = [n as f64, 0., 0., 0., 0., 0., 0.];
        run.phase = Phase::Placed(n);
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

    /// A text the vehicle said: kept a moment to explain a refusal, or the reason of the one
    /// that just came.
    pub fn on_text(&mut self, now: Micros, text: &str) {
        if let Some(run) = self.run.as_mut() {
            if let (Some(at), Phase::Done { ok: false, text: t }) = (run.refused_at, &mut run.phase)
            {
                run.refused_at = None;
                if now.saturating_sub(at) <= EXPLAIN {
                    t.push_str(&format!(" ({text})"));
                    return;
                }
            }
        }
        if self.texts.len() == 8 {
            self.texts.pop_front();
        }
        self.texts.push_back((now, text.to_string()));
    }

    fn reason(&self, now: Micros) -> Option<String> {
        self.texts
            .iter()
            .rev()
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
                let text = format!("{name} accepted: reboot the vehicle to use the new offsets");
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
            let text = format!("{name} saved: reboot the vehicle to use the new offsets");
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
        [resend, quiet].into_iter().flatten().min()
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
