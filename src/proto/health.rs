//! Before flight: what the Health screen (`8`) reads of a vehicle beyond its flight telemetry.
//!
//! - [`PrearmReasons`]: the pre-arm and arm failures the vehicle states in STATUSTEXT, one line
//!   per reason, aged. ArduPilot runs its pre-arm checks once a second and, while disarmed and
//!   failing, states each failure as `PreArm: …` every 30 s (`AP_Arming::update`,
//!   `PREARM_DISPLAY_PERIOD`); a refused arm states them as `Arm: …`; MAV_CMD_RUN_PREARM_CHECKS
//!   (401) makes it state them at once, before its ACK (`handle_command_run_prearm_checks`). A
//!   reason not repeated within [`KEEP`] is dropped; after an accepted RUN_PREARM_CHECKS, the
//!   reasons the vehicle did not state again before its ACK are dropped at once. They are all
//!   dropped when the vehicle arms or its SYS_STATUS says the pre-arm checks pass. PX4 states
//!   its failed checks as `Preflight Fail: …` (and a refused arm as `Arming denied…`): the same
//!   list holds them.
//! - The names of SYS_STATUS's sensor bits ([`sensor_name`]): a bit newer than our table is
//!   named by the dialect, and one newer than the dialect by its number.
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
#[derive(Debug, Clone, Default)]
pub struct PrearmReasons {
    reasons: VecDeque<Reason>,
    /// When RUN_PREARM_CHECKS was last sent, until its ACK.
    asked: Option<Micros>,
    /// When the vehicle last answered one (accepted).
    pub answered: Option<Micros>,
    /// Reasons not stored: the list was full.
    pub overflow: u64,
    /// The pre-arm checks pass by SYS_STATUS (when the vehicle reports the bit).
    pub passing: Option<bool>,
    /// After an answered ask: at `.0`, the reasons not stated since `.1` go.
    drop_at: Option<(Micros, Micros)>,
}

impl PrearmReasons {
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
        self.reasons.retain(|r| now.saturating_sub(r.last) < KEEP);
    }
}

impl Machine for PrearmReasons {
    const IDS: Ids = Ids::Only(&[
        crate::dialect::HEARTBEAT_DATA::ID,
        crate::dialect::SYS_STATUS_DATA::ID,
        crate::dialect::COMMAND_ACK_DATA::ID,
    ]);

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
        if let Some((at, since)) = self.drop_at {
            if now >= at {
                self.drop_at = None;
                self.drop_before(since);
            }
        }
        self.expire(now);
    }

    fn next_deadline(&self) -> Option<Micros> {
        let expiry = self.reasons.iter().map(|r| r.last + KEEP).min();
        [expiry, self.drop_at.map(|d| d.0)]
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

/// The name of SYS_STATUS sensor bit `bit` (0..32), or of an extended one (`ext`).
pub fn sensor_name(bit: u32, ext: bool) -> String {
    if ext {
        return match bit {
            0 => "recovery".into(),
            n => format!("ext bit {n}"),
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
            present_ext: 0b11,
            enabled_ext: 0b01,
            health_ext: 0b01,
            ..Default::default()
        };
        let names: Vec<String> = sensors(&s).into_iter().map(|x| x.name).collect();
        assert_eq!(
            names,
            vec!["gyro", "accel", "baro", "pre-arm", "recovery", "ext bit 1"]
        );
        assert_eq!(unhealthy(&s), vec!["baro", "pre-arm"]);
        assert_eq!(sensor_name(40, false), "bit 40");
        assert_eq!(ekf_flag_names(0x8001), vec!["att", "gps-glitch"]);
    }
}
