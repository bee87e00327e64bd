//! The simulated vehicle's calibrations and pre-arm checks, as ArduCopter runs them.
//!
//! - Pre-arm (`AP_Arming::update`, once a second while disarmed): the failures are stated as
//!   `PreArm: …` (CRITICAL) when 30 s passed since the last statement, or 4 s once the checks
//!   went from passing to failing; MAV_CMD_RUN_PREARM_CHECKS states them at once, before its
//!   ACK (TEMPORARILY_REJECTED while armed). Checks simulated: accelerometers calibrated (`3D
//!   Accel calibration needed`), compasses (`Compass calibration running`, `Compass
//!   calibrated requires reboot`, `Compass not calibrated`), and a position estimate for a mode
//!   that needs one (`AHRS: waiting for home`). The simulated vehicle starts calibrated unless
//!   `uncal=1`; then its SYS_STATUS reports the pre-arm bit (present, enabled, healthy when
//!   passing).
//! - Accelerometer, six positions (`AP_AccelCal::update`): after the gyro calibration of
//!   PREFLIGHT_CALIBRATION param5 = 1, each position is asked with COMMAND_LONG
//!   MAV_CMD_ACCELCAL_VEHICLE_POS (param1 = the position) to the GCS every second, and announced
//!   once (`Place vehicle level and press any key.`, CRITICAL) until the GCS first answers with
//!   ACCELCAL_VEHICLE_POS (`gcs_vehicle_position` clears `_use_gcs_snoop`: from then on the
//!   command alone asks); the GCS's ACCELCAL_VEHICLE_POS with the position asked is ACCEPTED
//!   and the vehicle samples ([`SAMPLE_TIME`], asking nothing meanwhile), any other FAILED.
//!   After the sixth: `Calibration successful` and ACCELCAL_VEHICLE_POS_SUCCESS, repeated every
//!   second from then on (as ArduPilot keeps reporting its last result).
//! - Compass (`AP_Compass_Calibration.cpp`): DO_START_MAG_CAL (FAILED while armed, with
//!   `Disarm to allow compass calibration`) starts both compasses: WAITING_TO_START for the
//!   delay asked, RUNNING_STEP_ONE to 33 %, RUNNING_STEP_TWO to 100 %, then SUCCESS (no
//!   rotation is simulated: the vehicle is "rotated" at a steady pace). MAG_CAL_PROGRESS is sent
//!   for each compass running and MAG_CAL_REPORT for each finished one, twice a second, until
//!   accepted (DO_ACCEPT_MAG_CAL saves and stops them; FAILED for a compass not successful) or
//!   cancelled (DO_CANCEL_MAG_CAL). With autosave the result is saved when it is reached. Once
//!   a calibration started, the pre-arm checks say the vehicle needs a reboot.
//! - Large vehicle (FIXED_MAG_CAL_YAW): ACCEPTED with a position (GPS fix), else `Mag: no
//!   position available` and FAILED.

use super::handlers::Command;
use super::vehicle::SimVehicle;
use crate::clock::{Micros, SECOND};
use crate::dialect::*;

/// How long the vehicle samples one accelerometer position.
pub const SAMPLE_TIME: Micros = 500_000;
/// AP_ACCELCAL_POSITION_REQUEST_INTERVAL_MS.
pub const POSITION_EVERY: Micros = SECOND;
/// MAG_CAL_PROGRESS / MAG_CAL_REPORT rate.
pub const MAG_EVERY: Micros = 500_000;
/// Compass calibration: step one, then step two (each compass; compass 1 a little slower).
pub const MAG_STEP_ONE: Micros = 3 * SECOND;
pub const MAG_STEP_TWO: Micros = 6 * SECOND;
/// PREARM_DISPLAY_PERIOD.
pub const PREARM_PERIOD: Micros = 30 * SECOND;

/// ACCELCAL_VEHICLE_POS_SUCCESS and _FAILED.
const POS_SUCCESS: f32 = 16_777_215.0;
const POS_FAILED: f32 = 16_777_216.0;

/// A six-position calibration running.
#[derive(Debug, Clone, PartialEq)]
pub struct AccelRun {
    /// Requests start from here (after the gyro calibration).
    pub from: Micros,
    /// The position waited for (1..6); 0 before the first.
    pub step: u8,
    /// Sampling until then.
    pub sampling: Option<Micros>,
    pub last_request: Option<Micros>,
    /// `_use_gcs_snoop`: the positions are announced in texts too, until the GCS first
    /// answers with ACCELCAL_VEHICLE_POS.
    pub snoop: bool,
}

/// One compass calibrating.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MagOne {
    pub start: Micros,
    /// MAG_CAL_STATUS.
    pub status: u8,
    pub pct: u8,
    pub saved: bool,
    pub fitness: f32,
    pub ofs: [f32; 3],
}

/// The calibration state of one simulated vehicle.
#[derive(Debug, Clone, PartialEq)]
pub struct SimCal {
    pub accel_calibrated: bool,
    pub compass_calibrated: bool,
    /// `_cal_requires_reboot`: a compass calibration ran since boot.
    pub needs_reboot: bool,
    /// SYS_STATUS carries the pre-arm bit (`uncal=1`).
    pub reports_prearm: bool,
    pub accel: Option<AccelRun>,
    /// The last six-position result, repeated every second: (success, last sent).
    pub accel_last: Option<(bool, Micros)>,
    pub mag: Vec<MagOne>,
    pub mag_autosave: bool,
    pub mag_last: Micros,
    /// AP_Arming::update's state.
    last_display: Micros,
    report_immediately: bool,
    last_passed: bool,
}

impl Default for SimCal {
    fn default() -> Self {
        SimCal {
            accel_calibrated: true,
            compass_calibrated: true,
            needs_reboot: false,
            reports_prearm: false,
            accel: None,
            accel_last: None,
            mag: Vec::new(),
            mag_autosave: false,
            mag_last: 0,
            last_display: 0,
            report_immediately: false,
            last_passed: true,
        }
    }
}

impl SimCal {
    /// A vehicle fresh from the box (`uncal=1`).
    pub fn uncalibrated() -> Self {
        SimCal {
            accel_calibrated: false,
            compass_calibrated: false,
            reports_prearm: true,
            ..SimCal::default()
        }
    }

    fn mag_running(&self) -> bool {
        self.mag.iter().any(|m| (1..=3).contains(&m.status))
    }
}

fn position_request(pos: f32) -> MavMessage {
    // GCS_MAVLINK::send_accelcal_vehicle_position: to system 0, component 0.
    MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
        target_system: 0,
        target_component: 0,
        command: MavCmd::MAV_CMD_ACCELCAL_VEHICLE_POS,
        confirmation: 0,
        param1: pos,
        ..Default::default()
    })
}

impl SimVehicle {
    /// The pre-arm checks that fail now, in ArduPilot's order.
    pub(super) fn prearm_failures(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.armed {
            return out;
        }
        if super::vehicle::mode::requires_position(self.custom_mode) && !self.ekf_gps {
            out.push("AHRS: waiting for home".to_string());
        }
        if !self.cal.accel_calibrated {
            out.push("3D Accel calibration needed".to_string());
        }
        if self.cal.mag_running() {
            out.push("Compass calibration running".to_string());
        } else if self.cal.needs_reboot {
            out.push("Compass calibrated requires reboot".to_string());
        } else if !self.cal.compass_calibrated {
            out.push("Compass not calibrated".to_string());
        }
        out
    }

    /// The pre-arm checks pass (SYS_STATUS's pre-arm health bit).
    pub(super) fn prearm_passing(&self) -> bool {
        self.prearm_failures().is_empty()
    }

    fn state_prearm(&mut self, failing: &[String]) {
        for why in failing {
            self.text(
                MavSeverity::MAV_SEVERITY_CRITICAL,
                &format!("PreArm: {why}"),
            );
        }
    }

    /// PREFLIGHT_CALIBRATION param5 = 1 accepted: positions are asked from `from` on.
    pub(super) fn accel_cal_start(&mut self, from: Micros) {
        if self.cal.accel.is_some() {
            return; // AP_AccelCal::start: already started
        }
        self.cal.accel = Some(AccelRun {
            from,
            step: 0,
            sampling: None,
            last_request: None,
            snoop: true,
        });
        self.cal.accel_last = None;
    }

    /// The calibration and pre-arm commands.
    pub(super) fn cal_command(&mut self, cmd: &Command) -> MavResult {
        use MavResult::*;
        let p = cmd.p;
        match cmd.command {
            MavCmd::MAV_CMD_RUN_PREARM_CHECKS => {
                if self.armed {
                    return MAV_RESULT_TEMPORARILY_REJECTED;
                }
                let failing = self.prearm_failures();
                self.state_prearm(&failing);
                MAV_RESULT_ACCEPTED
            }
            MavCmd::MAV_CMD_ACCELCAL_VEHICLE_POS => {
                // AP_AccelCal::gcs_vehicle_position.
                let Some(run) = self.cal.accel.as_mut() else {
                    return MAV_RESULT_FAILED;
                };
                // The GCS answers by command: no more texts asking.
                run.snoop = false;
                if run.sampling.is_none() && run.step >= 1 && p[0] == run.step as f32 {
                    run.sampling = Some(self.now + SAMPLE_TIME);
                    MAV_RESULT_ACCEPTED
                } else {
                    MAV_RESULT_FAILED
                }
            }
            MavCmd::MAV_CMD_DO_START_MAG_CAL => {
                if self.armed {
                    self.text(
                        MavSeverity::MAV_SEVERITY_NOTICE,
                        "Disarm to allow compass calibration",
                    );
                    return MAV_RESULT_FAILED;
                }
                if !(0.0..=255.0).contains(&p[0]) {
                    return MAV_RESULT_FAILED;
                }
                let mask = p[0] as u8;
                let delay = (p[3].max(0.0) as f64 * 1e6) as Micros;
                self.cal.mag_autosave = p[2] != 0.0;
                self.cal.mag.clear();
                for i in 0..2u8 {
                    if mask != 0 && mask & (1 << i) == 0 {
                        continue;
                    }
                    self.cal.mag.push(MagOne {
                        start: self.now + delay,
                        status: 1,
                        pct: 0,
                        saved: false,
                        fitness: 0.0,
                        ofs: [0.0; 3],
                    });
                }
                if self.cal.mag.is_empty() {
                    return MAV_RESULT_FAILED;
                }
                self.cal.needs_reboot = true;
                self.cal.mag_last = 0;
                MAV_RESULT_ACCEPTED
            }
            MavCmd::MAV_CMD_DO_ACCEPT_MAG_CAL => {
                if !(0.0..=255.0).contains(&p[0]) {
                    return MAV_RESULT_FAILED;
                }
                let mut ok = true;
                for m in &mut self.cal.mag {
                    match m.status {
                        4 => m.saved = true,
                        0 => {}
                        _ => ok = false,
                    }
                    m.status = 0;
                }
                if self.cal.mag.iter().any(|m| m.saved) {
                    self.cal.compass_calibrated = true;
                }
                if ok {
                    MAV_RESULT_ACCEPTED
                } else {
                    MAV_RESULT_FAILED
                }
            }
            MavCmd::MAV_CMD_DO_CANCEL_MAG_CAL => {
                if !(0.0..=255.0).contains(&p[0]) {
                    return MAV_RESULT_FAILED;
                }
                for m in &mut self.cal.mag {
                    m.status = 0;
                }
                MAV_RESULT_ACCEPTED
            }
            MavCmd::MAV_CMD_FIXED_MAG_CAL_YAW => {
                if !self.gps_fix {
                    self.text(
                        MavSeverity::MAV_SEVERITY_ERROR,
                        "Mag: no position available",
                    );
                    return MAV_RESULT_FAILED;
                }
                self.cal.compass_calibrated = true;
                MAV_RESULT_ACCEPTED
            }
            _ => MAV_RESULT_UNSUPPORTED,
        }
    }

    /// Everything of the calibrations and pre-arm checks due at `now`.
    pub(super) fn cal_tick(&mut self, now: Micros) {
        self.accel_tick(now);
        self.mag_tick(now);
        self.prearm_tick(now);
    }

    fn accel_tick(&mut self, now: Micros) {
        if let Some((ok, last)) = self.cal.accel_last {
            if now.saturating_sub(last) > POSITION_EVERY {
                self.cal.accel_last = Some((ok, now));
                self.push(position_request(if ok { POS_SUCCESS } else { POS_FAILED }));
            }
        }
        let Some(mut run) = self.cal.accel.take() else {
            return;
        };
        if now < run.from {
            self.cal.accel = Some(run);
            return;
        }
        let step = match run.sampling {
            Some(until) if now < until => {
                self.cal.accel = Some(run);
                return;
            }
            Some(_) if run.step == 6 => {
                // The six samples fitted and saved.
                self.text(MavSeverity::MAV_SEVERITY_CRITICAL, "Calibration successful");
                self.cal.accel_calibrated = true;
                self.cal.accel_last = Some((true, now));
                self.push(position_request(POS_SUCCESS));
                return;
            }
            Some(_) => run.step + 1,
            None => run.step.max(1),
        };
        run.sampling = None;
        if step != run.step {
            // WAITING_FOR_ORIENTATION on a new step: announced once, while the GCS has not
            // answered by command.
            run.step = step;
            let words = match step {
                1 => "level",
                2 => "on its LEFT side",
                3 => "on its RIGHT side",
                4 => "nose DOWN",
                5 => "nose UP",
                _ => "on its BACK",
            };
            if run.snoop {
                self.text(
                    MavSeverity::MAV_SEVERITY_CRITICAL,
                    &format!("Place vehicle {words} and press any key."),
                );
            }
        }
        if run
            .last_request
            .is_none_or(|t| now.saturating_sub(t) > POSITION_EVERY)
        {
            run.last_request = Some(now);
            self.push(position_request(run.step as f32));
        }
        self.cal.accel = Some(run);
    }

    fn mag_tick(&mut self, now: Micros) {
        if self.cal.mag.is_empty() {
            return;
        }
        let autosave = self.cal.mag_autosave;
        for (i, m) in self.cal.mag.iter_mut().enumerate() {
            if !(1..=3).contains(&m.status) || now < m.start {
                continue;
            }
            // Compass 1 takes a fifth longer.
            let slow = 1.0 + 0.2 * i as f64;
            let t = (now - m.start) as f64 / slow;
            let one = MAG_STEP_ONE as f64;
            let two = MAG_STEP_TWO as f64;
            if t < one {
                m.status = 2;
                m.pct = (33.0 * t / one) as u8;
            } else if t < one + two {
                m.status = 3;
                m.pct = (33.0 + 67.0 * (t - one) / two).min(99.0) as u8;
            } else {
                m.status = 4;
                m.pct = 100;
                m.fitness = 6.5 + 2.0 * i as f32;
                m.ofs = [35.0 - 20.0 * i as f32, -12.0, 48.0 + 5.0 * i as f32];
                if autosave {
                    m.saved = true;
                }
            }
        }
        if autosave && self.cal.mag.iter().all(|m| m.status == 4 || m.status == 0) {
            self.cal.compass_calibrated = true;
        }
        if now.saturating_sub(self.cal.mag_last) < MAG_EVERY {
            return;
        }
        self.cal.mag_last = now;
        let mask = self
            .cal
            .mag
            .iter()
            .enumerate()
            .filter(|(_, m)| m.status != 0)
            .fold(0u8, |a, (i, _)| a | 1 << i);
        let mut msgs = Vec::new();
        for (i, m) in self.cal.mag.iter().enumerate() {
            let status = match m.status {
                1 => MagCalStatus::MAG_CAL_WAITING_TO_START,
                2 => MagCalStatus::MAG_CAL_RUNNING_STEP_ONE,
                3 => MagCalStatus::MAG_CAL_RUNNING_STEP_TWO,
                4 => MagCalStatus::MAG_CAL_SUCCESS,
                _ => continue,
            };
            if m.status <= 3 {
                msgs.push(MavMessage::MAG_CAL_PROGRESS(MAG_CAL_PROGRESS_DATA {
                    compass_id: i as u8,
                    cal_mask: mask,
                    cal_status: status,
                    attempt: 1,
                    completion_pct: m.pct,
                    ..Default::default()
                }));
            } else {
                msgs.push(MavMessage::MAG_CAL_REPORT(MAG_CAL_REPORT_DATA {
                    compass_id: i as u8,
                    cal_mask: mask,
                    cal_status: status,
                    autosaved: m.saved as u8,
                    fitness: m.fitness,
                    ofs_x: m.ofs[0],
                    ofs_y: m.ofs[1],
                    ofs_z: m.ofs[2],
                    diag_x: 1.0,
                    diag_y: 1.0,
                    diag_z: 1.0,
                    scale_factor: 1.0,
                    ..Default::default()
                }));
            }
        }
        for m in msgs {
            self.push(m);
        }
    }

    /// AP_Arming::update, once a second.
    fn prearm_tick(&mut self, now: Micros) {
        if self.armed {
            self.cal.last_passed = true;
            return;
        }
        let failing = self.prearm_failures();
        let passed = failing.is_empty();
        if self.cal.last_passed && !passed {
            self.cal.report_immediately = true;
        }
        self.cal.last_passed = passed;
        if passed {
            return;
        }
        let since = now.saturating_sub(self.cal.last_display);
        if (self.cal.report_immediately && since > 4 * SECOND) || since > PREARM_PERIOD {
            self.cal.report_immediately = false;
            self.cal.last_display = now;
            self.state_prearm(&failing);
        }
    }

    /// When the calibrations or pre-arm checks next have something to do.
    pub(super) fn cal_next_due(&self) -> Option<Micros> {
        let mut t: Option<Micros> = None;
        let mut at = |x: Micros| t = Some(t.map_or(x, |t: Micros| t.min(x)));
        if let Some((_, last)) = self.cal.accel_last {
            at(last + POSITION_EVERY + 1);
        }
        if let Some(run) = &self.cal.accel {
            match (run.sampling, run.last_request) {
                (Some(until), _) => at(until),
                (None, Some(last)) => at(last + POSITION_EVERY + 1),
                (None, None) => at(run.from),
            }
        }
        if self.cal.mag.iter().any(|m| m.status != 0) {
            at(self.cal.mag_last + MAG_EVERY);
        }
        if !self.armed && !self.prearm_passing() {
            let wait = if self.cal.report_immediately {
                4 * SECOND
            } else {
                PREARM_PERIOD
            };
            at(self.cal.last_display + wait + 1);
        }
        t
    }
}

#[cfg(test)]
mod tests {
    //! The sequences as ArduPilot's code runs them (see the module doc), frame by frame.

    use super::super::{Sim, SimConfig};
    use crate::clock::{Micros, SECOND};
    use crate::dialect::*;
    use crate::wire::frame::{encode, Frame, Header, Version};
    use crate::wire::parser::FrameParser;
    use mavlink::MessageData;

    struct Gcs {
        sim: Sim,
        now: Micros,
        parser: FrameParser,
        frames: Vec<(Micros, Frame)>,
    }

    impl Gcs {
        fn new(q: &str) -> Gcs {
            Gcs {
                sim: Sim::new(SimConfig::from_query(q).unwrap()),
                now: 0,
                parser: FrameParser::new(),
                frames: Vec::new(),
            }
        }
        fn run_until(&mut self, until: Micros) {
            loop {
                let next = self.sim.next_deadline().min(until);
                self.now = next.max(self.now);
                let out = self.sim.poll(self.now);
                let now = self.now;
                let frames = &mut self.frames;
                self.parser.push(&out, |f| frames.push((now, f)));
                if self.now >= until {
                    break;
                }
            }
        }
        fn long(&mut self, command: MavCmd, p1: f32, p5: f32) {
            let msg = MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
                param1: p1,
                param5: p5,
                command,
                target_system: 1,
                target_component: 1,
                ..Default::default()
            });
            let h = Header {
                sysid: 255,
                compid: 190,
                seq: 0,
            };
            self.sim.receive(self.now, &encode(Version::V2, h, &msg));
        }
        /// What came since `from`: ACKs as (command, result), texts, position requests.
        fn since(&self, from: Micros) -> Vec<String> {
            self.frames
                .iter()
                .filter(|(t, _)| *t >= from)
                .filter_map(|(_, f)| match f.message.as_deref() {
                    Some(MavMessage::COMMAND_ACK(a)) => {
                        Some(format!("ack {} {}", a.command as u32, a.result as u8))
                    }
                    Some(MavMessage::STATUSTEXT(t)) => {
                        Some(t.text.to_str().unwrap_or("").to_string())
                    }
                    Some(MavMessage::COMMAND_LONG(c)) => Some(format!(
                        "pos {} to {}:{}",
                        c.param1, c.target_system, c.target_component
                    )),
                    _ => None,
                })
                .collect()
        }
    }

    #[test]
    fn prearm_failures_are_stated_4_s_after_they_start_then_every_30_s_and_when_asked() {
        let mut g = Gcs::new("uncal=1");
        g.run_until(40 * SECOND);
        let at = |g: &Gcs, text: &str| -> Vec<Micros> {
            g.frames
                .iter()
                .filter(|(_, f)| {
                    matches!(f.message.as_deref(), Some(MavMessage::STATUSTEXT(t))
                        if t.text.to_str().unwrap_or("") == text
                            && t.severity == MavSeverity::MAV_SEVERITY_CRITICAL)
                })
                .map(|(t, _)| *t / (SECOND / 10))
                .collect()
        };
        // Failing from the first check at boot: reported once 4 s passed, then 30 s later.
        assert_eq!(at(&g, "PreArm: 3D Accel calibration needed"), vec![40, 340]);
        assert_eq!(at(&g, "PreArm: Compass not calibrated"), vec![40, 340]);
        let from = g.now;
        g.long(MavCmd::MAV_CMD_RUN_PREARM_CHECKS, 0.0, 0.0);
        g.run_until(from + SECOND);
        assert_eq!(
            g.since(from),
            vec![
                "ack 401 0",
                "PreArm: 3D Accel calibration needed",
                "PreArm: Compass not calibrated"
            ]
        );
        // A calibrated vehicle states nothing.
        let mut g = Gcs::new("seed=1");
        g.run_until(70 * SECOND);
        assert!(!g.since(0).iter().any(|t| t.starts_with("PreArm")));
    }

    #[test]
    fn six_positions_as_ap_accelcal_asks_them() {
        let mut g = Gcs::new("uncal=1");
        g.run_until(6 * SECOND);
        let from = g.now;
        g.long(MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION, 0.0, 1.0);
        g.run_until(from + 2 * SECOND + SECOND / 2);
        // The gyros first (the vehicle quiet), ACCEPTED, then position 1 every second.
        assert_eq!(
            g.since(from),
            vec![
                "ack 241 0",
                "Place vehicle level and press any key.",
                "pos 1 to 0:0",
                "pos 1 to 0:0",
            ]
        );
        // Not the position asked: FAILED.
        let from = g.now;
        g.long(MavCmd::MAV_CMD_ACCELCAL_VEHICLE_POS, 2.0, 0.0);
        g.run_until(from + SECOND / 10);
        assert_eq!(g.since(from), vec!["ack 42429 4"]);
        for n in 1..=6 {
            let from = g.now;
            g.long(MavCmd::MAV_CMD_ACCELCAL_VEHICLE_POS, n as f32, 0.0);
            g.run_until(from + SECOND);
            let got = g.since(from);
            assert_eq!(got[0], "ack 42429 0", "{n}: {got:?}");
            if n < 6 {
                // The GCS answered by command (the FAILED one above): the vehicle no longer
                // says where to put it, it only asks.
                assert!(
                    !got.iter().any(|t| t.starts_with("Place vehicle")),
                    "{got:?}"
                );
                assert!(got.contains(&format!("pos {} to 0:0", n + 1)), "{got:?}");
            } else {
                assert_eq!(
                    &got[1..],
                    &["Calibration successful", "pos 16777215 to 0:0"]
                );
            }
        }
        // The result is repeated every second, and the accelerometers no longer fail.
        let from = g.now;
        g.run_until(from + 2 * SECOND + SECOND / 2);
        assert_eq!(
            g.since(from)
                .iter()
                .filter(|t| *t == "pos 16777215 to 0:0")
                .count(),
            2
        );
        let from = g.now;
        g.long(MavCmd::MAV_CMD_RUN_PREARM_CHECKS, 0.0, 0.0);
        g.run_until(from + SECOND / 10);
        // (The success is still repeated every second; it may fall in this window.)
        let got: Vec<String> = g
            .since(from)
            .into_iter()
            .filter(|t| t != "pos 16777215 to 0:0")
            .collect();
        assert_eq!(got, vec!["ack 401 0", "PreArm: Compass not calibrated"]);
    }

    #[test]
    fn compass_progress_reports_accept_and_the_reboot_it_needs() {
        let mut g = Gcs::new("uncal=1");
        g.run_until(6 * SECOND);
        let from = g.now;
        g.long(MavCmd::MAV_CMD_DO_START_MAG_CAL, 0.0, 0.0);
        g.run_until(from + 14 * SECOND);
        let progress: Vec<(u8, u8, u8)> = g
            .frames
            .iter()
            .filter_map(|(_, f)| match f.message.as_deref() {
                Some(MavMessage::MAG_CAL_PROGRESS(p)) => {
                    Some((p.compass_id, p.cal_status as u8, p.completion_pct))
                }
                _ => None,
            })
            .collect();
        assert!(progress.iter().any(|p| p.0 == 0) && progress.iter().any(|p| p.0 == 1));
        let pct0: Vec<u8> = progress.iter().filter(|p| p.0 == 0).map(|p| p.2).collect();
        assert!(pct0.windows(2).all(|w| w[0] <= w[1]), "{pct0:?}");
        let reports: Vec<(u8, u8, u8)> = g
            .frames
            .iter()
            .filter_map(|(_, f)| match f.message.as_deref() {
                Some(MavMessage::MAG_CAL_REPORT(r)) => {
                    Some((r.compass_id, r.cal_status as u8, r.autosaved))
                }
                _ => None,
            })
            .collect();
        assert!(
            reports.contains(&(0, 4, 0)) && reports.contains(&(1, 4, 0)),
            "{reports:?}"
        );
        let from = g.now;
        g.long(MavCmd::MAV_CMD_DO_ACCEPT_MAG_CAL, 0.0, 0.0);
        g.run_until(from + 2 * SECOND);
        let got = g.since(from);
        assert_eq!(got[0], "ack 42425 0");
        let after = g
            .frames
            .iter()
            .filter(|(t, f)| *t > from + SECOND / 10 && f.msgid == MAG_CAL_REPORT_DATA::ID)
            .count();
        assert_eq!(after, 0, "reports stop once accepted");
        let from = g.now;
        g.long(MavCmd::MAV_CMD_RUN_PREARM_CHECKS, 0.0, 0.0);
        g.run_until(from + SECOND / 10);
        assert_eq!(
            g.since(from),
            vec![
                "ack 401 0",
                "PreArm: 3D Accel calibration needed",
                "PreArm: Compass calibrated requires reboot"
            ]
        );
    }

    #[test]
    fn refused_as_arducopter_refuses() {
        // Fixed-yaw before a GPS fix: no position.
        let mut g = Gcs::new("seed=1");
        g.run_until(SECOND);
        let from = g.now;
        g.long(MavCmd::MAV_CMD_FIXED_MAG_CAL_YAW, 90.0, 0.0);
        g.run_until(from + SECOND / 10);
        assert_eq!(
            g.since(from),
            vec!["ack 42006 4", "Mag: no position available"]
        );
        // Arm refused with every failing check as "Arm: ".
        let mut g = Gcs::new("uncal=1");
        g.run_until(6 * SECOND);
        let from = g.now;
        g.long(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, 1.0, 0.0);
        g.run_until(from + SECOND / 10);
        assert_eq!(
            g.since(from),
            vec![
                "ack 400 4",
                "Arm: 3D Accel calibration needed",
                "Arm: Compass not calibrated"
            ]
        );
    }
}
