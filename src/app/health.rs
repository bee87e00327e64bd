//! Before flight: the pre-arm checks asked (`prearm`, `c` on the Health screen), a refused
//! arm's or take-off's other reasons on the status bar, and the calibrations (`cal …`, the
//! Health screen's keys).
//!
//! Every calibration asks first (it changes the vehicle), is refused while the vehicle is
//! armed, and is followed on the status bar from its start to its result by the vehicle's
//! calibration machine (`proto::calibration`), not by its texts.

use super::confirm::{Ask, Confirmed};
use super::outcome::ActionKind;
use super::{App, Effect};
use crate::dialect::MavCmd;
use crate::keymap::Action;
use crate::proto::calibration::{Kind, Phase};
use crate::proto::commands::{CommandSpec, Form, State};
use crate::proto::vehicles::VehicleKey;
use crate::wire::Severity;

/// `cal …` at the prompt.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CalCmd {
    Start(Kind),
    /// The vehicle is at the accelerometer position it asked for.
    Next,
    Accept,
    Cancel,
}

/// `cal gyro|baro|level|accel|simple-accel|compass|compass-fixed YAW|next|accept|cancel`.
pub fn parse_cal(rest: &str) -> Result<CalCmd, String> {
    let usage = "usage: cal gyro|baro|level|accel|simple-accel|compass|compass-fixed YAW|next|accept|cancel";
    let mut words = rest.split_whitespace();
    let word = words.next().ok_or(usage)?;
    let arg = words.next();
    if words.next().is_some() {
        return Err(usage.into());
    }
    let none = |c: CalCmd| match arg {
        None => Ok(c),
        Some(_) => Err(format!("`cal {word}` takes no arguments")),
    };
    match word {
        "gyro" => none(CalCmd::Start(Kind::Gyro)),
        "baro" => none(CalCmd::Start(Kind::Baro)),
        "level" => none(CalCmd::Start(Kind::Level)),
        "accel" => none(CalCmd::Start(Kind::Accel)),
        "simple-accel" => none(CalCmd::Start(Kind::SimpleAccel)),
        "compass" => none(CalCmd::Start(Kind::Compass)),
        "compass-fixed" => {
            let yaw = arg
                .ok_or("usage: cal compass-fixed YAW (the heading the vehicle faces, 0 to 360°)")?;
            let yaw: f64 = yaw
                .parse()
                .ok()
                .filter(|y: &f64| (0.0..=360.0).contains(y))
                .ok_or_else(|| format!("`{yaw}` is not a heading from 0 to 360°"))?;
            Ok(CalCmd::Start(Kind::CompassFixed(yaw)))
        }
        "next" => none(CalCmd::Next),
        "accept" => none(CalCmd::Accept),
        "cancel" => none(CalCmd::Cancel),
        _ => Err(usage.into()),
    }
}

/// The status bar's line follows the vehicle's texts this long after the answer.
pub const NOTE_WINDOW: crate::clock::Micros = 3 * crate::clock::SECOND;
/// What starts the reasons added to a refusal's line.
const PREARM_NOTE: &str = "; pre-arm: ";

/// COMMAND_LONG `command` to `key`.
fn spec(key: VehicleKey, command: u16, params: [f64; 7]) -> CommandSpec {
    CommandSpec {
        target: key.into(),
        command,
        params,
        form: Form::Long,
    }
}

/// True for a command whose refusal the pre-arm reasons explain: an arm or a take-off.
fn explained_by_prearm(command: u16, params: &[f64; 7]) -> bool {
    (command == MavCmd::MAV_CMD_COMPONENT_ARM_DISARM as u16 && params[0] == 1.0)
        || command == MavCmd::MAV_CMD_NAV_TAKEOFF as u16
}

impl App {
    /// `prearm` and `c` on the Health screen: RUN_PREARM_CHECKS to the target; the vehicle
    /// states every failing check before its ACK.
    pub(super) fn run_prearm(&mut self, fx: &mut Vec<Effect>) -> Result<Option<String>, String> {
        let key = self.commandable()?;
        let now = self.now;
        let s = self.sessions.get_mut(&key).ok_or("no session")?;
        let spec = CommandSpec {
            target: key.into(),
            command: MavCmd::MAV_CMD_RUN_PREARM_CHECKS as u16,
            params: [0.; 7],
            form: Form::Long,
        };
        let (id, out) = s.submit(now, spec)?;
        s.prearm.asked(now);
        let text = "RUN_PREARM_CHECKS: sent".to_string();
        self.start_action(Some(key), vec![id], ActionKind::Command, text.clone());
        self.session_out(key, out, fx);
        Ok(Some(text))
    }

    /// `cal …`.
    pub(super) fn run_cal(
        &mut self,
        cmd: CalCmd,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let key = self.commandable()?;
        if !self.sessions.contains_key(&key) {
            return Err(format!("{key} is not an autopilot"));
        }
        let now = self.now;
        match cmd {
            CalCmd::Start(kind) => {
                self.refuse_start(key, kind)?;
                if let Some(r) = self.sessions[&key].calibration.run.as_ref() {
                    if !r.finished() {
                        return Err(format!(
                            "{} is still running: `cal cancel` first",
                            r.kind.name()
                        ));
                    }
                }
                let (command, params) = kind.command();
                let text = format!(
                    "{} of {}: send {} ({})? {}. y = yes, any other key = no",
                    kind.name().to_uppercase(),
                    self.who_is(key),
                    crate::proto::ack::command_name(command),
                    params
                        .iter()
                        .map(|p| format!("{p}"))
                        .collect::<Vec<_>>()
                        .join(", "),
                    kind.advice()
                );
                self.ask(Ask {
                    text,
                    action: Confirmed::Calibration(kind),
                    target: key,
                });
                Ok(None)
            }
            CalCmd::Next => {
                let s = self.sessions.get_mut(&key).ok_or("no session")?;
                // Checked first; the machine takes the position as placed only once the queue
                // has sent it.
                let (command, params) = s.calibration.placing()?;
                let n = params[0] as u8;
                // The vehicle asks for this position now: an answer to an earlier one still
                // waiting for its ACK (lost, or the vehicle moved on without it reaching us)
                // is stale, and does not hold this one back.
                let mut out = s.supersede(now, command);
                let sent = match s.submit(now, spec(key, command, params)) {
                    Ok((_, sent)) => {
                        out.extend(sent);
                        s.calibration.placed(now).map(|_| ())
                    }
                    Err(e) => Err(e),
                };
                self.session_out(key, out, fx);
                sent?;
                let (words, _) = crate::proto::calibration::position(n);
                Ok(Some(format!("accel cal {n}/6: {words}: sent")))
            }
            CalCmd::Accept => {
                let s = self.sessions.get_mut(&key).ok_or("no session")?;
                let (command, params) = s.calibration.accept(now)?;
                let (_, out) = s.submit(now, spec(key, command, params))?;
                self.session_out(key, out, fx);
                Ok(Some("DO_ACCEPT_MAG_CAL: sent".into()))
            }
            CalCmd::Cancel => {
                let s = self.sessions.get_mut(&key).ok_or("no session")?;
                match s.calibration.cancel(now)? {
                    Some((command, params)) => {
                        let (_, out) = s.submit(now, spec(key, command, params))?;
                        self.session_out(key, out, fx);
                        Ok(Some("DO_CANCEL_MAG_CAL: sent".into()))
                    }
                    None => {
                        self.follow_calibration(key);
                        Ok(Some(
                            "no longer followed (ArduPilot has no command to stop it)".into(),
                        ))
                    }
                }
            }
        }
    }

    /// A calibration is never started on an armed vehicle, nor one of ArduPilot's protocols
    /// on another autopilot (its profile says which it runs).
    fn refuse_start(&self, key: VehicleKey, kind: Kind) -> Result<(), String> {
        let v = self.vehicles.get(key);
        if v.is_some_and(|v| v.armed()) {
            return Err(format!("{key} is armed: no {} (disarm first)", kind.name()));
        }
        if let (Some(protocol), Some(v)) = (kind.ardupilot_protocol(), v) {
            let profile = crate::proto::profile::of(v.autopilot);
            if !profile.ardupilot_calibrations() {
                return Err(format!(
                    "{key} runs {}: the {} is ArduPilot's ({protocol}), not sent",
                    profile.name(),
                    kind.name()
                ));
            }
        }
        Ok(())
    }

    /// The confirmed calibration: checked again, then its start command sent.
    pub(super) fn carry_out_cal(
        &mut self,
        key: VehicleKey,
        kind: Kind,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        self.commandable_at(key)?;
        self.refuse_start(key, kind)?;
        let now = self.now;
        let s = self.sessions.get_mut(&key).ok_or("no session")?;
        let (command, params) = s.calibration.start(now, kind)?;
        let (id, out) = match s.submit(now, spec(key, command, params)) {
            Ok(r) => r,
            Err(e) => {
                s.calibration.run = None;
                return Err(e);
            }
        };
        let text = format!("{}: sent, {}", kind.name(), kind.advice());
        self.start_action(
            Some(key),
            vec![id],
            ActionKind::Calibration(key),
            text.clone(),
        );
        self.session_out(key, out, fx);
        Ok(Some(text))
    }

    /// The status bar follows the calibration of `key`: its phase, then its result.
    pub(super) fn follow_calibration(&mut self, key: VehicleKey) {
        let Some(a) = self
            .ui
            .action
            .as_ref()
            .filter(|a| !a.done && a.kind == ActionKind::Calibration(key))
        else {
            return;
        };
        let Some(run) = self
            .sessions
            .get(&key)
            .and_then(|s| s.calibration.run.as_ref())
        else {
            return;
        };
        // The start's own answer stands until the calibration says more.
        if run.phase == Phase::Starting {
            return;
        }
        // `enter` says "placed" on the Health screen; elsewhere it has other work.
        let mut text = run.status_line();
        if self.ui.screen != "health" {
            text = text.replace(", then enter", ", then :cal next (or enter on screen 8)");
        }
        let (sev, last) = match &run.phase {
            Phase::Done { ok: true, .. } => (Severity::INFO, true),
            Phase::Done { ok: false, .. } => (Severity::WARNING, true),
            _ => (Severity::INFO, false),
        };
        if a.text != text || last {
            self.action_moves(sev, text, last);
        }
    }

    /// After every update: the status bar follows the calibration running and the reasons of a
    /// refusal.
    pub(super) fn follow_before_flight(&mut self) {
        if let Some(ActionKind::Calibration(k)) = self.ui.action.as_ref().map(|a| a.kind.clone()) {
            self.follow_calibration(k);
        }
        self.follow_prearm();
    }

    /// The status bar's line of a refused arm or take-off (or of an answered
    /// RUN_PREARM_CHECKS) ends in the reasons the vehicle gives now. ArduPilot sends the ACK as
    /// its handler returns and its texts after it, so the line is brought up to date for
    /// [`NOTE_WINDOW`] after the answer, as the texts come.
    pub(super) fn follow_prearm(&mut self) {
        let Some(a) = self.ui.action.as_ref().filter(|a| a.done) else {
            return;
        };
        let (Some(key), Some(&id)) = (a.session, a.ids.last()) else {
            return;
        };
        let Some(s) = self.sessions.get(&key) else {
            return;
        };
        let Some(e) = s.commands.get(id) else {
            return;
        };
        if self.now.saturating_sub(e.changed) > NOTE_WINDOW {
            return;
        }
        let note = if e.spec.command == MavCmd::MAV_CMD_RUN_PREARM_CHECKS as u16 {
            if e.state != State::Done(0) {
                return;
            }
            let reasons = s.prearm.others(None);
            match reasons.len() {
                0 => ": no failing check stated".to_string(),
                n => format!(": {n} failing: {}", reasons.join("; ")),
            }
        } else {
            let refused = matches!(e.state, State::Done(r) if r != 0);
            if !refused || !explained_by_prearm(e.spec.command, &e.spec.params) {
                return;
            }
            // The refusal's own reason first (it comes with the texts, after the ACK).
            if e.reason.is_none()
                && self.now.saturating_sub(e.changed) <= crate::proto::commands::EXPLAIN_WINDOW
            {
                return;
            }
            let others = s.prearm.others(e.reason.as_deref());
            if others.is_empty() {
                String::new()
            } else {
                format!("{PREARM_NOTE}{} (screen 8)", others.join("; "))
            }
        };
        let Some(a) = self.ui.action.as_mut() else {
            return;
        };
        let base = a
            .text
            .find(PREARM_NOTE)
            .or_else(|| a.text.find(": no failing check stated"))
            .map_or(a.text.as_str(), |i| &a.text[..i]);
        let base = match base.find(": ACCEPTED: ") {
            Some(i) => &base[..i + ": ACCEPTED".len()],
            None => base,
        };
        let text = format!("{base}{note}");
        if text != a.text {
            a.text = text.clone();
            if let Some(last) = self.ui.outcomes.back_mut() {
                last.text = text;
            }
            self.dirty = true;
        }
    }

    /// RADIO_STATUS on `link`, from whichever system sent it.
    pub(super) fn on_radio_status(
        &mut self,
        link: crate::link::LinkId,
        r: &crate::dialect::RADIO_STATUS_DATA,
    ) {
        let value = crate::proto::telemetry::Radio {
            rssi: r.rssi,
            remrssi: r.remrssi,
            noise: r.noise,
            remnoise: r.remnoise,
            txbuf: r.txbuf,
            rxerrors: r.rxerrors,
            fixed: r.fixed,
        };
        self.radio.insert(
            link,
            crate::proto::telemetry::Timed {
                value,
                at: self.now,
            },
        );
        self.dirty = true;
    }

    /// The Health screen's keys.
    pub(super) fn on_health_action(&mut self, action: Action, fx: &mut Vec<Effect>) {
        let r = match action {
            Action::HealthPrearm => self.run_prearm(fx),
            Action::CalNext => self.run_cal(CalCmd::Next, fx),
            Action::CalGyro => self.run_cal(CalCmd::Start(Kind::Gyro), fx),
            Action::CalBaro => self.run_cal(CalCmd::Start(Kind::Baro), fx),
            Action::CalLevel => self.run_cal(CalCmd::Start(Kind::Level), fx),
            Action::CalAccel => self.run_cal(CalCmd::Start(Kind::Accel), fx),
            Action::CalSimpleAccel => self.run_cal(CalCmd::Start(Kind::SimpleAccel), fx),
            Action::CalCompass => self.run_cal(CalCmd::Start(Kind::Compass), fx),
            Action::CalAccept => self.run_cal(CalCmd::Accept, fx),
            Action::CalCancel => self.run_cal(CalCmd::Cancel, fx),
            _ => return,
        };
        self.ui.message = match r {
            Ok(Some(t)) => Some((Severity::INFO, t)),
            Ok(None) => None,
            Err(e) => Some((Severity::ERROR, e)),
        };
        self.dirty = true;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cal_words() {
        assert_eq!(parse_cal("gyro"), Ok(CalCmd::Start(Kind::Gyro)));
        assert_eq!(
            parse_cal("compass-fixed 271.5"),
            Ok(CalCmd::Start(Kind::CompassFixed(271.5)))
        );
        assert!(parse_cal("compass-fixed").is_err());
        assert!(parse_cal("compass-fixed 400").is_err());
        assert!(parse_cal("gyro now").is_err());
        assert!(parse_cal("").is_err());
        assert_eq!(parse_cal("accept"), Ok(CalCmd::Accept));
    }
}
