//! Before flight: what the Health screen (`8`) reads of a vehicle beyond its flight telemetry.
//!
//! - [`PrearmReasons`]: the pre-arm and arm failures the vehicle states in STATUSTEXT, one line
//!   per reason, aged. ArduPilot runs its pre-arm checks once a second and, while disarmed and
//!   failing, states each failure as `PreArm: …` every 30 s (`AP_Arming::update`,
//!   `PREARM_DISPLAY_PERIOD`); a refused arm states them as `Arm: …`; MAV_CMD_RUN_PREARM_CHECKS
//!   (401) makes it state them at once: its handler queues the texts and returns, so the ACK
//!   leaves first and the texts follow it (`handle_command_run_prearm_checks`). A reason not
//!   repeated within [`KEEP`] is dropped; after an accepted RUN_PREARM_CHECKS, the reasons the
//!   vehicle did not state again by [`SETTLE`] after its ACK are dropped. An ask whose ACK never
//!   comes stops waiting after [`ASK_TIMEOUT`]. They are all dropped when the vehicle arms or
//!   its SYS_STATUS says the pre-arm checks pass. PX4 states its failed checks as
//!   `Preflight Fail: …` (and a refused arm as `Arming denied…`): the same list holds them, but
//!   PX4 does not repeat them on ArduPilot's cadence, so for a vehicle whose profile has no
//!   repeat period ([`PrearmReasons::with_period`]) a reason stays until one of those clears it.
//! - The names of SYS_STATUS's sensor bits ([`sensor_name`]): the main bits by our short names;
//!   the extended ones (`onboard_control_sensors_*_extended`) by the dialect's
//!   MAV_SYS_STATUS_SENSOR_EXTENDED (`recovery`, `leak`, `gyro 3`, …), and a bit newer than the
//!   dialect by its number.
//! - ArduPilot's thresholds: the EKF variances against `FS_EKF_THRESH` (default 0.8, as
//!   `Copter::ekf_over_threshold` counts them), and the vibration levels of ArduPilot's guide
//!   (below 30 m/s² fine, above 60 m/s² a problem).

use std::collections::VecDeque;

use crate::clock::{Micros, SECOND};
use crate::dialect::{MavCmd, MavModeFlag, MavResult};
use crate::proto::machine::{Ids, Incoming, Machine, Out};
use crate::proto::telemetry::{EkfVariances, Sensors, PREARM_CHECK};
use mavlink::MessageData;

/// How often ArduPilot states its failing pre-arm checks while disarmed.
pub const PREARM_PERIOD: Micros = 30 * SECOND;
/// A reason not stated again in this long is dropped: two periods and a margin, so one lost
/// repetition does not drop it.
pub const KEEP: Micros = 2 * PREARM_PERIOD + 5 * SECOND;
/// How long after RUN_PREARM_CHECKS's ACK its texts may still come.
pub const SETTLE: Micros = SECOND;
/// An ask (RUN_PREARM_CHECKS, sent once: it is not resent) with no ACK by then is given up:
/// the command queue's longest wait for an ACK and a margin.
pub const ASK_TIMEOUT: Micros = crate::proto::commands::MAX_TIMEOUT + SECOND;
/// Reasons kept at most (a vehicle stating more is counted, not stored).
pub const MAX_REASONS: usize = 32;
/// What starts a pre-arm or arm failure: ArduPilot's, then PX4's.
pub const PREFIXES: &[&str] = &[
    "PreArm: ",
    "Arm: ",
    "Preflight Fail: ",
    "Arming denied: ",
    "Arming denied! ",
];

/// ArduCopter's `FS_EKF_THRESH` default.
pub const EKF_THRESH: f32 = 0.8;
/// Mission Planner's EKF window turns a variance amber from here (and red at the threshold).
pub const EKF_WARN: f32 = 0.5;
/// ArduPilot's vibration guide: below this fine (m/s²).
pub const VIBE_WARN: f32 = 30.0;
/// ... above this a problem.
pub const VIBE_BAD: f32 = 60.0;

/// One reason the vehicle gave.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Reason {
    /// `PreArm`, `Arm`, `Preflight Fail`, ... (the prefix without its separator).
    pub prefix: String,
    /// The reason itself (`3D Accel calibration needed`).
    pub text: String,
    pub first: Micros,
    pub last: Micros,
    /// Times stated.
    pub count: u32,
}

impl Reason {
    /// `PreArm: 3D Accel calibration needed`.
    pub fn line(&self) -> String {
        format!("{}: {}", self.prefix, self.text)
    }
}

/// A pre-arm or arm failure in `text`: (prefix, reason).
pub fn reason_of(text: &str) -> Option<(&str, &str)> {
    PREFIXES.iter().find_map(|p| {
        let rest = text.strip_prefix(p)?.trim();
        (!rest.is_empty()).then(|| (p.trim_end_matches([' ', ':', '!']), rest))
    })
}

/// The reasons one vehicle gives now for not arming.
#[derive(Debug, Clone)]
pub struct PrearmReasons {
    reasons: VecDeque<Reason>,
    /// How often the vehicle repeats them on its own (ArduPilot's 30 s), if it does.
    period: Option<Micros>,
    /// When RUN_PREARM_CHECKS was last sent, until its ACK (or [`ASK_TIMEOUT`]).
    asked: Option<Micros>,
    /// When the vehicle last answered one (accepted).
    pub answered: Option<Micros>,
    /// When the last ask was given up: no ACK within [`ASK_TIMEOUT`].
    pub unanswered: Option<Micros>,
    /// Reasons not stored: the list was full.
    pub overflow: u64,
    /// The pre-arm checks pass by SYS_STATUS (when the vehicle reports the bit).
    pub passing: Option<bool>,
    /// After an answered ask: at `.0`, the reasons not stated since `.1` go.
    drop_at: Option<(Micros, Micros)>,
}

/// ArduPilot's: repeated every [`PREARM_PERIOD`].
impl Default for PrearmReasons {
    fn default() -> Self {
        Self::with_period(Some(PREARM_PERIOD))
    }
}

impl PrearmReasons {
    /// For a vehicle that repeats its reasons every `period` (its profile's
    /// `prearm_period`), or never (`None`: they are kept until cleared).
    pub fn with_period(period: Option<Micros>) -> Self {
        Self {
            reasons: VecDeque::new(),
            period,
            asked: None,
            answered: None,
            unanswered: None,
            overflow: 0,
            passing: None,
            drop_at: None,
        }
    }

    /// How often the vehicle repeats its reasons on its own, if it does.
    pub fn period(&self) -> Option<Micros> {
        self.period
    }

    /// How long a reason not stated again is kept: two periods and a margin ([`KEEP`] for
    /// ArduPilot), so one lost repetition does not drop it; `None` without a period.
    pub fn keep(&self) -> Option<Micros> {
        self.period.map(|p| 2 * p + 5 * SECOND)
    }

    /// The reasons, oldest first.
    pub fn reasons(&self) -> impl Iterator<Item = &Reason> {
        self.reasons.iter()
    }

    pub fn is_empty(&self) -> bool {
        self.reasons.is_empty()
    }

    pub fn len(&self) -> usize {
        self.reasons.len()
    }

    /// A text the vehicle said: kept when it is a pre-arm or arm failure.
    pub fn on_text(&mut self, now: Micros, text: &str) {
        let Some((prefix, reason)) = reason_of(text) else {
            return;
        };
        // `PreArm: X` and `Arm: X` are the same check failing.
        if let Some(r) = self.reasons.iter_mut().find(|r| r.text == reason) {
            r.last = now;
            r.count += 1;
            r.prefix = prefix.to_string();
            return;
        }
        if self.reasons.len() == MAX_REASONS {
            self.overflow += 1;
            return;
        }
        self.reasons.push_back(Reason {
            prefix: prefix.to_string(),
            text: reason.to_string(),
            first: now,
            last: now,
            count: 1,
        });
    }

    /// RUN_PREARM_CHECKS is on its way.
    pub fn asked(&mut self, now: Micros) {
        self.asked = Some(now);
        self.unanswered = None;
    }

    /// True while an ask is waiting for its answer.
    pub fn asking(&self) -> bool {
        self.asked.is_some()
    }

    /// Reasons not stated since `since` go.
    fn drop_before(&mut self, since: Micros) {
        self.reasons.retain(|r| r.last >= since);
    }

    /// The reasons other than `except` (a refusal's own reason), one line each.
    pub fn others(&self, except: Option<&str>) -> Vec<String> {
        self.reasons
            .iter()
            .filter(|r| except.is_none_or(|e| !e.ends_with(r.text.as_str())))
            .map(Reason::line)
            .collect()
    }

    fn expire(&mut self, now: Micros) {
        if let Some(keep) = self.keep() {
            self.reasons.retain(|r| now.saturating_sub(r.last) < keep);
        }
    }
}

impl Machine for PrearmReasons {
    const IDS: Ids = Ids::Only(&[
        crate::dialect::HEARTBEAT_DATA::ID,
        crate::dialect::SYS_STATUS_DATA::ID,
        crate::dialect::COMMAND_ACK_DATA::ID,
    ]);
    /// Only the heartbeat is read decoded; SYS_STATUS from its payload, the ACK as
    /// [`Incoming::ack`].
    const DECODES: Ids = Ids::Only(&[crate::dialect::HEARTBEAT_DATA::ID]);

    fn on_message(&mut self, m: &Incoming, _: &mut Vec<Out>) {
        if let Some(hb) = m.heartbeat() {
            if hb
                .base_mode
                .contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED)
            {
                self.reasons.clear();
            }
            return;
        }
        if m.id == crate::dialect::SYS_STATUS_DATA::ID {
            let s = Sensors::from_payload(m.payload);
            if s.present & PREARM_CHECK != 0 && s.enabled & PREARM_CHECK != 0 {
                let ok = s.health & PREARM_CHECK != 0;
                self.passing = Some(ok);
                if ok {
                    self.reasons.clear();
                }
            }
            return;
        }
        if let (Some(ack), Some(asked)) = (m.ack, self.asked) {
            if ack.command == MavCmd::MAV_CMD_RUN_PREARM_CHECKS as u16 {
                self.asked = None;
                if ack.result == MavResult::MAV_RESULT_ACCEPTED as u8 {
                    // The vehicle states every failing check as it answers (ArduPilot queues
                    // the texts in the handler and sends them after the ACK): those not
                    // stated again by SETTLE after the ACK go.
                    self.answered = Some(m.now);
                    self.drop_at = Some((m.now + SETTLE, asked));
                }
            }
        }
    }

    fn poll(&mut self, now: Micros, _: &mut Vec<Out>) {
        if self
            .asked
            .is_some_and(|t| now.saturating_sub(t) >= ASK_TIMEOUT)
        {
            // The ask or its ACK was lost: nothing more is coming of it.
            self.asked = None;
            self.unanswered = Some(now);
        }
        if let Some((at, since)) = self.drop_at {
            if now >= at {
                self.drop_at = None;
                self.drop_before(since);
            }
        }
        self.expire(now);
    }

    fn next_deadline(&self) -> Option<Micros> {
        let expiry = self
            .keep()
            .and_then(|keep| self.reasons.iter().map(|r| r.last + keep).min());
        [
            expiry,
            self.drop_at.map(|d| d.0),
            self.asked.map(|t| t + ASK_TIMEOUT),
        ]
        .into_iter()
        .flatten()
        .min()
    }
}

/// The short names of MAV_SYS_STATUS_SENSOR's bits, lowest first.
const SENSOR_NAMES: [&str; 32] = [
    "gyro",
    "accel",
    "mag",
    "baro",
    "airspeed",
    "GPS",
    "optical flow",
    "vision",
    "laser",
    "ground truth",
    "rate ctrl",
    "attitude",
    "yaw",
    "alt ctrl",
    "pos ctrl",
    "motors",
    "RC",
    "gyro 2",
    "accel 2",
    "mag 2",
    "geofence",
    "AHRS",
    "terrain",
    "reverse motor",
    "logging",
    "battery",
    "proximity",
    "satcom",
    "pre-arm",
    "avoidance",
    "propulsion",
    "extended",
];

/// Our short names of the extended bits (MAV_SYS_STATUS_SENSOR_EXTENDED), lowest first.
const EXT_SENSOR_NAMES: [(&str, &str); 6] = [
    ("MAV_SYS_STATUS_RECOVERY_SYSTEM", "recovery"),
    ("MAV_SYS_STATUS_SENSOR_LEAK", "leak"),
    ("MAV_SYS_STATUS_SENSOR_3D_GYRO3", "gyro 3"),
    ("MAV_SYS_STATUS_SENSOR_3D_ACCEL3", "accel 3"),
    ("MAV_SYS_STATUS_SENSOR_3D_GYRO4", "gyro 4"),
    ("MAV_SYS_STATUS_SENSOR_3D_ACCEL4", "accel 4"),
];

/// The dialect's name of extended sensor bit `bit`, if it has one.
fn ext_dialect_name(bit: u32) -> Option<&'static str> {
    use crate::dialect::MavSysStatusSensorExtended as Ext;
    let flag = Ext::from_bits(1u32.checked_shl(bit)?)?;
    Ext::all()
        .iter_names()
        .find(|(_, f)| *f == flag)
        .map(|(n, _)| n)
}

/// The name of SYS_STATUS sensor bit `bit` (0..32), or of an extended one (`ext`): an extended
/// bit by the dialect (our short name for those we know, else the dialect's own without its
/// `MAV_SYS_STATUS_` prefix, in lower case), and one newer than the dialect by its number.
pub fn sensor_name(bit: u32, ext: bool) -> String {
    if ext {
        return match ext_dialect_name(bit) {
            Some(d) => EXT_SENSOR_NAMES
                .iter()
                .find(|(n, _)| *n == d)
                .map(|(_, short)| (*short).to_string())
                .unwrap_or_else(|| {
                    let s = d.trim_start_matches("MAV_SYS_STATUS_");
                    s.trim_start_matches("SENSOR_")
                        .to_lowercase()
                        .replace('_', " ")
                }),
            None => format!("ext bit {bit}"),
        };
    }
    match SENSOR_NAMES.get(bit as usize) {
        Some(n) => (*n).into(),
        None => format!("bit {bit}"),
    }
}

/// One sensor's state as SYS_STATUS tells it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SensorState {
    pub name: String,
    pub enabled: bool,
    pub healthy: bool,
}

/// The sensors present, lowest bit first, then the extended ones (the EXTENSION_USED bit
/// itself left out).
pub fn sensors(s: &Sensors) -> Vec<SensorState> {
    let mut out = Vec::new();
    for bit in 0..32u32 {
        let m = 1u32 << bit;
        if s.present & m == 0 || bit == 31 {
            continue;
        }
        out.push(SensorState {
            name: sensor_name(bit, false),
            enabled: s.enabled & m != 0,
            healthy: s.health & m != 0,
        });
    }
    for bit in 0..32u32 {
        let m = 1u32 << bit;
        if s.present_ext & m == 0 {
            continue;
        }
        out.push(SensorState {
            name: sensor_name(bit, true),
            enabled: s.enabled_ext & m != 0,
            healthy: s.health_ext & m != 0,
        });
    }
    out
}

/// The enabled sensors that are not healthy, by name.
pub fn unhealthy(s: &Sensors) -> Vec<String> {
    sensors(s)
        .into_iter()
        .filter(|x| x.enabled && !x.healthy)
        .map(|x| x.name)
        .collect()
}

/// How a value stands against its thresholds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    Ok,
    Warn,
    Bad,
}

impl Level {
    pub fn word(self) -> &'static str {
        match self {
            Level::Ok => "ok",
            Level::Warn => "warn",
            Level::Bad => "BAD",
        }
    }
}

/// One EKF variance against [`EKF_WARN`] and [`EKF_THRESH`].
pub fn ekf_level(v: f32) -> Level {
    if v >= EKF_THRESH {
        Level::Bad
    } else if v >= EKF_WARN {
        Level::Warn
    } else {
        Level::Ok
    }
}

/// `Copter::ekf_over_threshold` with `FS_EKF_THRESH` = `thresh`: two of compass, velocity and
/// position over it, or the velocity over twice it (no optical flow), trigger the EKF
/// failsafe.
pub fn ekf_over_threshold(v: &EkfVariances, thresh: f32) -> bool {
    if thresh <= 0.0 {
        return false;
    }
    let mut over = 0;
    if v.compass >= thresh {
        over += 1;
    }
    if v.velocity >= 2.0 * thresh {
        over += 2;
    } else if v.velocity >= thresh {
        over += 1;
    }
    if v.pos_horiz >= thresh {
        over += 1;
    }
    over >= 2
}

/// A vibration level (m/s²) against ArduPilot's guide.
pub fn vibe_level(v: f32) -> Level {
    if v > VIBE_BAD {
        Level::Bad
    } else if v >= VIBE_WARN {
        Level::Warn
    } else {
        Level::Ok
    }
}

/// The EKF_STATUS_REPORT flags set, by short name (EKF_STATUS_FLAGS).
pub fn ekf_flag_names(flags: u16) -> Vec<&'static str> {
    const NAMES: [&str; 16] = [
        "att",
        "vel-h",
        "vel-v",
        "pos-h-rel",
        "pos-h-abs",
        "pos-v-abs",
        "pos-v-agl",
        "const-pos",
        "pred-h-rel",
        "pred-h-abs",
        "uninit",
        "bit11",
        "bit12",
        "bit13",
        "bit14",
        "gps-glitch",
    ];
    (0..16)
        .filter(|b| flags & (1 << b) != 0)
        .map(|b| NAMES[b as usize])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reasons_are_gathered_once_each_and_age_out() {
        let mut p = PrearmReasons::default();
        p.on_text(0, "PreArm: 3D Accel calibration needed");
        p.on_text(0, "PreArm: Compass not calibrated");
        p.on_text(SECOND, "EKF3 IMU0 is using GPS");
        p.on_text(2 * SECOND, "Arm: 3D Accel calibration needed");
        let lines: Vec<String> = p.reasons().map(Reason::line).collect();
        assert_eq!(
            lines,
            vec![
                "Arm: 3D Accel calibration needed",
                "PreArm: Compass not calibrated"
            ]
        );
        assert_eq!(p.next_deadline(), Some(KEEP));
        p.poll(KEEP - 1, &mut Vec::new());
        assert_eq!(p.len(), 2);
        p.poll(KEEP, &mut Vec::new());
        assert_eq!(p.others(None), vec!["Arm: 3D Accel calibration needed"]);
        p.poll(2 * SECOND + KEEP, &mut Vec::new());
        assert!(p.is_empty());
        assert_eq!(p.next_deadline(), None);
    }

    /// `msg` through our encoder and parser, to `p`.
    fn feed(p: &mut PrearmReasons, now: Micros, msg: &crate::dialect::MavMessage) {
        crate::proto::machine::received(now, msg, |m| p.on_message(m, &mut Vec::new()));
    }

    fn prearm_ack(result: MavResult) -> crate::dialect::MavMessage {
        crate::dialect::MavMessage::COMMAND_ACK(crate::dialect::COMMAND_ACK_DATA {
            command: MavCmd::MAV_CMD_RUN_PREARM_CHECKS,
            result,
            ..Default::default()
        })
    }

    #[test]
    fn an_ask_whose_ack_is_lost_stops_waiting() {
        let mut p = PrearmReasons::default();
        p.asked(0);
        assert!(p.asking());
        assert_eq!(p.next_deadline(), Some(ASK_TIMEOUT));
        p.poll(ASK_TIMEOUT - 1, &mut Vec::new());
        assert!(p.asking());
        p.poll(ASK_TIMEOUT, &mut Vec::new());
        assert!(!p.asking(), "given up");
        assert_eq!(p.unanswered, Some(ASK_TIMEOUT));
        assert_eq!(p.next_deadline(), None);
        // A late ACK changes nothing; a new ask waits again.
        feed(
            &mut p,
            ASK_TIMEOUT + 1,
            &prearm_ack(MavResult::MAV_RESULT_ACCEPTED),
        );
        assert_eq!(p.answered, None);
        p.asked(20 * SECOND);
        assert_eq!(p.unanswered, None);
        feed(
            &mut p,
            21 * SECOND,
            &prearm_ack(MavResult::MAV_RESULT_ACCEPTED),
        );
        assert!(!p.asking());
        assert_eq!(p.answered, Some(21 * SECOND));
    }

    #[test]
    fn without_a_repeat_period_reasons_stay_until_cleared() {
        // PX4: no 30 s repeats, so no aging.
        let mut p = PrearmReasons::with_period(None);
        assert_eq!(p.keep(), None);
        p.on_text(0, "Preflight Fail: Accel Sensor 0 missing");
        p.on_text(0, "Preflight Fail: ekf2 missing data");
        assert_eq!(p.next_deadline(), None);
        p.poll(10 * KEEP, &mut Vec::new());
        assert_eq!(p.len(), 2);
        // An answered ask drops the reason not stated again after it.
        p.asked(10 * KEEP);
        feed(
            &mut p,
            10 * KEEP + SECOND,
            &prearm_ack(MavResult::MAV_RESULT_ACCEPTED),
        );
        p.on_text(10 * KEEP + SECOND + 1, "Preflight Fail: ekf2 missing data");
        p.poll(10 * KEEP + SECOND + SETTLE, &mut Vec::new());
        assert_eq!(p.others(None), vec!["Preflight Fail: ekf2 missing data"]);
        // SYS_STATUS's pre-arm check healthy clears them.
        let healthy =
            crate::dialect::MavMessage::SYS_STATUS(crate::dialect::SYS_STATUS_DATA {
                onboard_control_sensors_present:
                    crate::dialect::MavSysStatusSensor::from_bits_truncate(PREARM_CHECK),
                onboard_control_sensors_enabled:
                    crate::dialect::MavSysStatusSensor::from_bits_truncate(PREARM_CHECK),
                onboard_control_sensors_health:
                    crate::dialect::MavSysStatusSensor::from_bits_truncate(PREARM_CHECK),
                ..Default::default()
            });
        feed(&mut p, 11 * KEEP, &healthy);
        assert!(p.is_empty());
        assert_eq!(p.passing, Some(true));
        // ArduPilot's: aged out after KEEP.
        let mut p = PrearmReasons::default();
        assert_eq!(p.keep(), Some(KEEP));
        p.on_text(0, "PreArm: Compass not calibrated");
        p.poll(KEEP, &mut Vec::new());
        assert!(p.is_empty());
    }

    #[test]
    fn px4_texts_are_reasons_too() {
        assert_eq!(
            reason_of("Preflight Fail: Accel Sensor 0 missing"),
            Some(("Preflight Fail", "Accel Sensor 0 missing"))
        );
        assert_eq!(reason_of("PreArm: "), None);
        assert_eq!(reason_of("Arming motors"), None);
    }

    #[test]
    fn ekf_threshold_counts_as_arducopter_does() {
        let v = |vel, pos, mag| EkfVariances {
            velocity: vel,
            pos_horiz: pos,
            compass: mag,
            ..Default::default()
        };
        assert!(!ekf_over_threshold(&v(0.79, 0.79, 0.79), 0.8));
        assert!(ekf_over_threshold(&v(0.8, 0.0, 0.8), 0.8));
        assert!(
            ekf_over_threshold(&v(1.6, 0.0, 0.0), 0.8),
            "twice: counts 2"
        );
        assert!(!ekf_over_threshold(&v(1.59, 0.0, 0.0), 0.8));
        assert!(ekf_over_threshold(&v(0.0, 0.8, 0.8), 0.8));
        assert!(!ekf_over_threshold(&v(9.0, 9.0, 9.0), 0.0), "disabled");
        assert_eq!(ekf_level(0.49), Level::Ok);
        assert_eq!(ekf_level(0.5), Level::Warn);
        assert_eq!(ekf_level(0.8), Level::Bad);
        assert_eq!(vibe_level(29.9), Level::Ok);
        assert_eq!(vibe_level(30.0), Level::Warn);
        assert_eq!(vibe_level(60.1), Level::Bad);
    }

    #[test]
    fn sensors_by_name_and_newer_bits_by_number() {
        let s = Sensors {
            present: 0b1011 | PREARM_CHECK | 0x8000_0000,
            enabled: 0b1011 | PREARM_CHECK,
            health: 0b0011,
            // recovery, leak, and bit 9 (newer than the dialect).
            present_ext: 0b10_0000_0011,
            enabled_ext: 0b10_0000_0011,
            health_ext: 0b00_0000_0001,
            ..Default::default()
        };
        let names: Vec<String> = sensors(&s).into_iter().map(|x| x.name).collect();
        assert_eq!(
            names,
            vec![
                "gyro",
                "accel",
                "baro",
                "pre-arm",
                "recovery",
                "leak",
                "ext bit 9"
            ]
        );
        assert_eq!(unhealthy(&s), vec!["baro", "pre-arm", "leak", "ext bit 9"]);
        // Every extended bit the dialect names (MAV_SYS_STATUS_SENSOR_EXTENDED), by name.
        let ext: Vec<String> = (0..6).map(|b| sensor_name(b, true)).collect();
        assert_eq!(
            ext,
            vec!["recovery", "leak", "gyro 3", "accel 3", "gyro 4", "accel 4"]
        );
        assert_eq!(sensor_name(6, true), "ext bit 6");
        assert_eq!(sensor_name(31, true), "ext bit 31");
        assert_eq!(sensor_name(40, true), "ext bit 40");
        assert_eq!(sensor_name(40, false), "bit 40");
        assert_eq!(ekf_flag_names(0x8001), vec!["att", "gps-glitch"]);
    }
}
