//! The flight telemetry of one autopilot, as the Overview shows it: where it is, how it moves,
//! its battery, GPS and estimator, and where home is.
//!
//! Each value keeps the time it was heard, so it can be shown stale once older than
//! [`STALE_AFTER`]. The relative altitude is also kept once a second for the last minute
//! ([`History`]).
//!
//! Home comes unasked when the autopilot sets it (ArduPilot sends HOME_POSITION then), but a GCS
//! that connects later never hears it: until it is known, HOME_POSITION is asked for with
//! COMMAND_LONG MAV_CMD_REQUEST_MESSAGE (param1 = 242) every [`HOME_REQUEST_EVERY`]. The request
//! is safe to repeat: an autopilot without a home answers it and sends nothing.
//!
//! The `mavlink` crate refuses a whole message when an enum field holds a value newer than its
//! dialect (a GPS_RAW_INT with fix type 200). Of the messages read here only GPS_RAW_INT and
//! BATTERY_STATUS have enum fields; when they do not decode, the fields needed are read from the
//! payload bytes, numbers kept (as `proto::ack` does for COMMAND_ACK).
//!
//! Sans-I/O: messages and time in, what to send out of [`FlightTelemetry::poll`], and
//! [`FlightTelemetry::next_deadline`] for the one timer.

use std::collections::VecDeque;

use crate::clock::{Micros, SECOND};
use crate::dialect::{self, MavCmd, MavMessage};
use crate::proto::machine::Out;
use crate::proto::vehicles::VehicleKey;
use crate::wire::payload::Payload;

/// A value older than this is shown stale.
pub const STALE_AFTER: Micros = 3 * SECOND;
/// How often HOME_POSITION is asked for while home is unknown.
pub const HOME_REQUEST_EVERY: Micros = 5 * SECOND;
/// Seconds of history kept for the sparklines: a minute fits a row at 80 columns, wider
/// terminals show more of it.
pub const HISTORY_SECS: usize = 180;

/// Message ids read here.
pub mod id {
    use mavlink::MessageData;
    pub const SYS_STATUS: u32 = crate::dialect::SYS_STATUS_DATA::ID;
    pub const GPS_RAW_INT: u32 = crate::dialect::GPS_RAW_INT_DATA::ID;
    pub const GLOBAL_POSITION_INT: u32 = crate::dialect::GLOBAL_POSITION_INT_DATA::ID;
    pub const VFR_HUD: u32 = crate::dialect::VFR_HUD_DATA::ID;
    pub const BATTERY_STATUS: u32 = crate::dialect::BATTERY_STATUS_DATA::ID;
    pub const EKF_STATUS_REPORT: u32 = crate::dialect::EKF_STATUS_REPORT_DATA::ID;
    pub const HOME_POSITION: u32 = crate::dialect::HOME_POSITION_DATA::ID;
    pub const EXTENDED_SYS_STATE: u32 = crate::dialect::EXTENDED_SYS_STATE_DATA::ID;
    pub const VIBRATION: u32 = crate::dialect::VIBRATION_DATA::ID;
    pub const RADIO_STATUS: u32 = crate::dialect::RADIO_STATUS_DATA::ID;
    pub const HEARTBEAT: u32 = crate::dialect::HEARTBEAT_DATA::ID;
}

/// MAV_SYS_STATUS_PREARM_CHECK in SYS_STATUS's sensor bits.
pub const PREARM_CHECK: u32 = 0x1000_0000;

/// A value and when it was heard.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timed<T> {
    pub value: T,
    pub at: Micros,
}

impl<T> Timed<T> {
    pub fn age(&self, now: Micros) -> Micros {
        now.saturating_sub(self.at)
    }

    /// Older than [`STALE_AFTER`].
    pub fn is_stale(&self, now: Micros) -> bool {
        self.age(now) > STALE_AFTER
    }
}

/// GLOBAL_POSITION_INT, as sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Position {
    /// Degrees × 1e7.
    pub lat_e7: i32,
    pub lon_e7: i32,
    /// Above mean sea level, mm.
    pub alt_mm: i32,
    /// Above home, mm.
    pub relative_alt_mm: i32,
}

impl Position {
    pub fn lat(&self) -> f64 {
        self.lat_e7 as f64 / 1e7
    }
    pub fn lon(&self) -> f64 {
        self.lon_e7 as f64 / 1e7
    }
    /// Metres above mean sea level.
    pub fn alt_m(&self) -> f64 {
        self.alt_mm as f64 / 1000.0
    }
    /// Metres above home.
    pub fn relative_alt_m(&self) -> f64 {
        self.relative_alt_mm as f64 / 1000.0
    }
    /// False for 0, 0: what autopilots send before they know where they are.
    pub fn is_known(&self) -> bool {
        self.lat_e7 != 0 || self.lon_e7 != 0
    }
}

/// How the vehicle moves: VFR_HUD's, or (from a vehicle that sends no VFR_HUD) made from
/// GLOBAL_POSITION_INT's velocities and heading.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Motion {
    /// m/s.
    pub groundspeed: f32,
    /// m/s, up positive.
    pub climb: f32,
    /// Degrees, 0..360.
    pub heading: i16,
}

/// The main battery, from SYS_STATUS or BATTERY_STATUS (id 0): `None` where the autopilot says
/// it does not know.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Battery {
    pub voltage_mv: Option<u32>,
    /// Centiamperes.
    pub current_ca: Option<i32>,
    /// Percent.
    pub remaining_pct: Option<u8>,
}

impl Battery {
    pub fn volts(&self) -> Option<f64> {
        self.voltage_mv.map(|v| v as f64 / 1000.0)
    }
    pub fn amps(&self) -> Option<f64> {
        self.current_ca.map(|c| c as f64 / 100.0)
    }

    /// SYS_STATUS's battery fields (UINT16_MAX and -1 mean unknown).
    pub fn from_sys_status(voltage_mv: u16, current_ca: i16, remaining: i8) -> Battery {
        Battery {
            voltage_mv: (voltage_mv != u16::MAX).then_some(voltage_mv as u32),
            current_ca: (current_ca != -1).then_some(current_ca as i32),
            remaining_pct: u8::try_from(remaining).ok(),
        }
    }

    /// BATTERY_STATUS's fields: the total voltage is the sum of the cells that are set (UINT16_MAX
    /// marks an unused cell in `voltages`, 0 or UINT16_MAX one in `voltages_ext`).
    pub fn from_battery_status(
        voltages: &[u16; 10],
        voltages_ext: &[u16; 4],
        current_ca: i16,
        remaining: i8,
    ) -> Battery {
        let cells = voltages.iter().filter(|&&v| v != u16::MAX);
        let ext = voltages_ext.iter().filter(|&&v| v != 0 && v != u16::MAX);
        let mut n = 0;
        let mut sum = 0u32;
        for &v in cells.chain(ext) {
            n += 1;
            sum += v as u32;
        }
        Battery {
            voltage_mv: (n > 0).then_some(sum),
            current_ca: (current_ca != -1).then_some(current_ca as i32),
            remaining_pct: u8::try_from(remaining).ok(),
        }
    }

    /// `self`, with what it does not know taken from `older`.
    fn or(self, older: Battery) -> Battery {
        Battery {
            voltage_mv: self.voltage_mv.or(older.voltage_mv),
            current_ca: self.current_ca.or(older.current_ca),
            remaining_pct: self.remaining_pct.or(older.remaining_pct),
        }
    }
}

/// GPS_RAW_INT: fix type as sent (a number, so a value newer than our dialect survives).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Gps {
    pub fix_type: u8,
    /// `None` when the autopilot does not know (UINT8_MAX).
    pub satellites: Option<u8>,
    /// HDOP × 100 (`eph`); `None` when unknown (UINT16_MAX).
    pub hdop_e2: Option<u16>,
}

/// `3D`, `RTK fixed`, ... (GPS_FIX_TYPE); a value our dialect does not know stays a number.
pub fn fix_name(fix_type: u8) -> String {
    match fix_type {
        0 => "no GPS".into(),
        1 => "no fix".into(),
        2 => "2D".into(),
        3 => "3D".into(),
        4 => "DGPS".into(),
        5 => "RTK float".into(),
        6 => "RTK fixed".into(),
        7 => "static".into(),
        8 => "PPP".into(),
        n => format!("fix {n}"),
    }
}

/// EKF_STATUS_REPORT flags in a word: `ok` when attitude, velocity and absolute position are
/// all good; `glitch` when the EKF distrusts the GPS; `init` before it has an attitude; `nopos`
/// without an absolute position (constant position mode included); `bad` otherwise.
pub fn ekf_summary(flags: u16) -> &'static str {
    const ATTITUDE: u16 = 1;
    const VEL_HORIZ: u16 = 2;
    const VEL_VERT: u16 = 4;
    const POS_HORIZ_ABS: u16 = 16;
    const POS_VERT_ABS: u16 = 32;
    const CONST_POS_MODE: u16 = 128;
    const UNINITIALIZED: u16 = 1024;
    const GPS_GLITCHING: u16 = 32768;
    const GOOD: u16 = ATTITUDE | VEL_HORIZ | VEL_VERT | POS_HORIZ_ABS | POS_VERT_ABS;
    if flags & GPS_GLITCHING != 0 {
        "glitch"
    } else if flags & UNINITIALIZED != 0 || flags & ATTITUDE == 0 {
        "init"
    } else if flags & GOOD == GOOD {
        "ok"
    } else if flags & CONST_POS_MODE != 0 || flags & POS_HORIZ_ABS == 0 {
        "nopos"
    } else {
        "bad"
    }
}

/// SYS_STATUS's pre-arm check bit, when the autopilot reports it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Prearm {
    pub enabled: bool,
    /// The checks pass.
    pub healthy: bool,
}

/// HOME_POSITION.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Home {
    pub lat_e7: i32,
    pub lon_e7: i32,
    /// Above mean sea level, mm.
    pub alt_mm: i32,
}

/// Mean Earth radius, m.
pub const EARTH_RADIUS_M: f64 = 6_371_000.0;

/// Great-circle distance (m) and initial bearing (degrees, 0..360, 0 = north) from `from` to
/// `to`, both (lat, lon) in degrees.
pub fn distance_bearing(from: (f64, f64), to: (f64, f64)) -> (f64, f64) {
    let (p1, p2) = (from.0.to_radians(), to.0.to_radians());
    let dp = p2 - p1;
    let dl = (to.1 - from.1).to_radians();
    let a = (dp / 2.0).sin().powi(2) + p1.cos() * p2.cos() * (dl / 2.0).sin().powi(2);
    let d = 2.0 * EARTH_RADIUS_M * a.sqrt().min(1.0).asin();
    let y = dl.sin() * p2.cos();
    let x = p1.cos() * p2.sin() - p1.sin() * p2.cos() * dl.cos();
    let b = y.atan2(x).to_degrees().rem_euclid(360.0);
    (d, b)
}

/// One value per second for the last [`HISTORY_SECS`] seconds: the last value set in each
/// second, `None` for seconds without one. Bounded.
#[derive(Debug, Clone, Default)]
pub struct History {
    /// The second of the newest entry.
    last_sec: Option<u64>,
    values: VecDeque<Option<f32>>,
}

impl History {
    /// The value of the second `t` falls in (a later one in the same second replaces it).
    pub fn set(&mut self, t: Micros, v: f32) {
        let sec = t / SECOND;
        match self.last_sec {
            Some(last) if sec <= last => {
                // The same second (time never runs back in the core).
                if let Some(x) = self.values.back_mut() {
                    *x = Some(v);
                }
                return;
            }
            Some(last) => {
                let gap = (sec - last - 1).min(HISTORY_SECS as u64);
                for _ in 0..gap {
                    self.values.push_back(None);
                }
            }
            None => {}
        }
        self.values.push_back(Some(v));
        self.last_sec = Some(sec);
        while self.values.len() > HISTORY_SECS {
            self.values.pop_front();
        }
    }

    /// The `n` seconds ending with the second `end` falls in, oldest first (`None` where there
    /// is no value).
    pub fn recent(&self, end: Micros, n: usize) -> Vec<Option<f32>> {
        let end = end / SECOND;
        let Some(last) = self.last_sec else {
            return vec![None; n];
        };
        (0..n as u64)
            .rev()
            .map(|back| {
                let sec = end.checked_sub(back)?;
                let behind = last.checked_sub(sec)?;
                let i = (self.values.len() as u64).checked_sub(1 + behind)?;
                self.values[i as usize]
            })
            .collect()
    }
}

/// COMMAND_LONG MAV_CMD_REQUEST_MESSAGE for HOME_POSITION.
pub fn request_home(target: impl Into<VehicleKey>) -> MavMessage {
    let target = target.into();
    MavMessage::COMMAND_LONG(dialect::COMMAND_LONG_DATA {
        target_system: target.0,
        target_component: target.1,
        command: MavCmd::MAV_CMD_REQUEST_MESSAGE,
        confirmation: 0,
        param1: id::HOME_POSITION as f32,
        param2: 0.0,
        param3: 0.0,
        param4: 0.0,
        param5: 0.0,
        param6: 0.0,
        param7: 0.0,
    })
}

/// What one autopilot last told of its flight.
#[derive(Debug, Clone)]
pub struct FlightTelemetry {
    target: VehicleKey,
    /// Off when the operator asked mavterm not to request telemetry.
    request_home: bool,
    pub position: Option<Timed<Position>>,
    pub motion: Option<Timed<Motion>>,
    /// When VFR_HUD last came: while it is fresh, it gives the motion.
    vfr_hud_at: Option<Micros>,
    /// The profile's answer: VFR_HUD is expected to carry speed, climb and heading (else
    /// GLOBAL_POSITION_INT always gives them).
    vfr_hud_expected: bool,
    pub battery: Option<Timed<Battery>>,
    pub gps: Option<Timed<Gps>>,
    /// EKF_STATUS_REPORT flags.
    pub ekf: Option<Timed<u16>>,
    pub prearm: Option<Timed<Prearm>>,
    pub home: Option<Timed<Home>>,
    /// Relative altitude (m), once a second.
    pub altitude: History,
    /// When HOME_POSITION is next asked for: from when the vehicle is first heard until home is
    /// known.
    next_home_request: Option<Micros>,
    /// HOME_POSITION requests sent, all told.
    pub home_requests: u32,
    /// EXTENDED_SYS_STATE's `landed_state` (MAV_LANDED_STATE) and when it was heard.
    pub landed_state: Option<Timed<u8>>,
    /// SYS_STATUS's sensor bits, as sent (bits newer than the dialect kept).
    pub sensors: Option<Timed<Sensors>>,
    /// EKF_STATUS_REPORT's variances.
    pub ekf_variances: Option<Timed<EkfVariances>>,
    /// VIBRATION.
    pub vibration: Option<Timed<Vibration>>,
    /// RADIO_STATUS (from the radio, any component of the system).
    pub radio: Option<Timed<Radio>>,
}

/// SYS_STATUS's onboard control sensors: present, enabled and healthy bits (MAV_SYS_STATUS_SENSOR),
/// and the extended ones (MAV_SYS_STATUS_SENSOR_EXTENDED) when sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Sensors {
    pub present: u32,
    pub enabled: u32,
    pub health: u32,
    pub present_ext: u32,
    pub enabled_ext: u32,
    pub health_ext: u32,
    /// Communication drop rate, centi-percent, and errors (SYS_STATUS `drop_rate_comm`,
    /// `errors_comm`).
    pub drop_rate_comm: u16,
    pub errors_comm: u16,
    /// CPU load, per mille.
    pub load: u16,
}

impl Sensors {
    /// SYS_STATUS's payload. Wire order: present, enabled, health u32 (0, 4, 8), load u16 (12),
    /// voltage_battery u16, current_battery i16, drop_rate_comm u16 (18), errors_comm u16 (20),
    /// errors_count1..4, battery_remaining i8 (30); extensions: present, enabled, health
    /// extended u32 (31, 35, 39).
    pub fn from_payload(payload: &[u8]) -> Sensors {
        let p = crate::wire::payload::Payload(payload);
        Sensors {
            present: p.u32(0),
            enabled: p.u32(4),
            health: p.u32(8),
            load: p.u16(12),
            drop_rate_comm: p.u16(18),
            errors_comm: p.u16(20),
            present_ext: p.u32(31),
            enabled_ext: p.u32(35),
            health_ext: p.u32(39),
        }
    }
}

/// EKF_STATUS_REPORT's variances (as ArduPilot sends them: velocity, horizontal and vertical
/// position, the length of the compass variance, terrain altitude).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EkfVariances {
    pub velocity: f32,
    pub pos_horiz: f32,
    pub pos_vert: f32,
    pub compass: f32,
    pub terrain_alt: f32,
}

/// VIBRATION: the vibration levels (m/s²) and the accelerometer clipping counts.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Vibration {
    pub x: f32,
    pub y: f32,
    pub z: f32,
    pub clipping: [u32; 3],
}

/// RADIO_STATUS, as sent by a telemetry radio (SiK: RSSI and noise in its own units, 0..254;
/// `txbuf` the percentage of its buffer free; `rxerrors` and `fixed` counters).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Radio {
    pub rssi: u8,
    pub remrssi: u8,
    pub noise: u8,
    pub remnoise: u8,
    pub txbuf: u8,
    pub rxerrors: u16,
    pub fixed: u16,
}

impl FlightTelemetry {
    pub fn new(target: impl Into<VehicleKey>, request_home: bool) -> Self {
        Self {
            target: target.into(),
            request_home,
            position: None,
            motion: None,
            vfr_hud_at: None,
            vfr_hud_expected: true,
            battery: None,
            gps: None,
            ekf: None,
            prearm: None,
            home: None,
            altitude: History::default(),
            next_home_request: None,
            home_requests: 0,
            landed_state: None,
            sensors: None,
            ekf_variances: None,
            vibration: None,
            radio: None,
        }
    }

    /// Whether VFR_HUD is expected to carry the motion (the profile's answer).
    pub fn set_vfr_hud_expected(&mut self, expected: bool) {
        self.vfr_hud_expected = expected;
    }

    /// True once anything shown was heard.
    pub fn has_data(&self) -> bool {
        self.position.is_some()
            || self.motion.is_some()
            || self.battery.is_some()
            || self.gps.is_some()
            || self.ekf.is_some()
            || self.prearm.is_some()
            || self.home.is_some()
    }

    /// When the newest value was heard.
    pub fn last_heard(&self) -> Option<Micros> {
        [
            self.position.map(|x| x.at),
            self.motion.map(|x| x.at),
            self.battery.map(|x| x.at),
            self.gps.map(|x| x.at),
            self.ekf.map(|x| x.at),
            self.prearm.map(|x| x.at),
            self.home.map(|x| x.at),
        ]
        .into_iter()
        .flatten()
        .max()
    }

    /// Distance (m) and bearing (degrees) of the vehicle from home, when both are known.
    pub fn from_home(&self) -> Option<(f64, f64)> {
        let home = self.home?.value;
        let pos = self.position?.value;
        if !pos.is_known() {
            return None;
        }
        let h = (home.lat_e7 as f64 / 1e7, home.lon_e7 as f64 / 1e7);
        Some(distance_bearing(h, (pos.lat(), pos.lon())))
    }

    /// A message from the autopilot: its id and its payload as sent, read at the fields' wire
    /// offsets (sorted by size, as MAVLink sends them; a field MAVLink 2 cut reads as zero), so
    /// nothing is decoded and an enum value newer than the dialect is kept.
    pub fn on_message(&mut self, now: Micros, id: u32, payload: &[u8]) {
        if self.home.is_none() && self.next_home_request.is_none() {
            self.next_home_request = Some(now);
        }
        let p = Payload(payload);
        match id {
            // vtol_state, landed_state.
            id::EXTENDED_SYS_STATE => {
                self.landed_state = Some(Timed {
                    value: p.u8(1),
                    at: now,
                });
            }
            // time_boot_ms u32, lat, lon, alt, relative_alt i32 (4..20), vx, vy, vz i16 (20..26),
            // hdg u16 (26).
            id::GLOBAL_POSITION_INT => {
                let value = Position {
                    lat_e7: p.i32(4),
                    lon_e7: p.i32(8),
                    alt_mm: p.i32(12),
                    relative_alt_mm: p.i32(16),
                };
                self.altitude.set(now, value.relative_alt_m() as f32);
                self.position = Some(Timed { value, at: now });
                // No VFR_HUD (or none lately): GLOBAL_POSITION_INT carries the same: vx, vy
                // (north, east) and vz (down) in cm/s, hdg in centidegrees (UINT16_MAX unknown:
                // the course over ground then, when moving, else the heading last known).
                if !self.vfr_hud_expected
                    || self
                        .vfr_hud_at
                        .is_none_or(|t| now.saturating_sub(t) > STALE_AFTER)
                {
                    let (vx, vy) = (p.i16(20) as f64 / 100.0, p.i16(22) as f64 / 100.0);
                    let (vz, hdg) = (p.i16(24), p.u16(26));
                    let speed = vx.hypot(vy);
                    let heading = if hdg != u16::MAX {
                        (hdg / 100) as i16
                    } else if speed >= 0.5 {
                        vy.atan2(vx).to_degrees().rem_euclid(360.0).round() as i16 % 360
                    } else {
                        self.motion.map_or(0, |m| m.value.heading)
                    };
                    let value = Motion {
                        groundspeed: speed as f32,
                        climb: -(vz as f32) / 100.0,
                        heading,
                    };
                    self.motion = Some(Timed { value, at: now });
                }
            }
            // airspeed, groundspeed, alt, climb f32 (0..16), heading i16 (16), throttle u16.
            id::VFR_HUD => {
                let value = Motion {
                    groundspeed: p.f32(4),
                    climb: p.f32(12),
                    heading: p.i16(16),
                };
                self.motion = Some(Timed { value, at: now });
                self.vfr_hud_at = Some(now);
            }
            // time_usec u64, vibration_x, _y, _z f32 (8..20), clipping_0, _1, _2 u32 (20..32).
            id::VIBRATION => {
                let value = Vibration {
                    x: p.f32(8),
                    y: p.f32(12),
                    z: p.f32(16),
                    clipping: [p.u32(20), p.u32(24), p.u32(28)],
                };
                self.vibration = Some(Timed { value, at: now });
            }
            // rxerrors, fixed u16 (0, 2), rssi, remrssi, txbuf, noise, remnoise u8 (4..9).
            id::RADIO_STATUS => {
                let value = Radio {
                    rssi: p.u8(4),
                    remrssi: p.u8(5),
                    noise: p.u8(7),
                    remnoise: p.u8(8),
                    txbuf: p.u8(6),
                    rxerrors: p.u16(0),
                    fixed: p.u16(2),
                };
                self.radio = Some(Timed { value, at: now });
            }
            // The sensor bits (0..12; bits newer than the dialect are kept), load u16 (12),
            // voltage_battery u16 (14), current_battery i16 (16), ..., battery_remaining i8 (30).
            id::SYS_STATUS => {
                let sensors = Sensors::from_payload(payload);
                self.sensors = Some(Timed {
                    value: sensors,
                    at: now,
                });
                let b = Battery::from_sys_status(p.u16(14), p.i16(16), p.u8(30) as i8);
                self.set_battery(now, b);
                if sensors.present & PREARM_CHECK != 0 {
                    let value = Prearm {
                        enabled: sensors.enabled & PREARM_CHECK != 0,
                        healthy: sensors.health & PREARM_CHECK != 0,
                    };
                    self.prearm = Some(Timed { value, at: now });
                }
            }
            id::BATTERY_STATUS => {
                let (battery_id, b) = battery_status_from_payload(payload);
                if battery_id == 0 {
                    self.set_battery(now, b);
                }
            }
            id::GPS_RAW_INT => {
                self.gps = Some(Timed {
                    value: gps_from_payload(payload),
                    at: now,
                });
            }
            // velocity, pos_horiz, pos_vert, compass, terrain_alt variances f32 (0..20), flags
            // u16 (20).
            id::EKF_STATUS_REPORT => {
                self.ekf = Some(Timed {
                    value: p.u16(20),
                    at: now,
                });
                let value = EkfVariances {
                    velocity: p.f32(0),
                    pos_horiz: p.f32(4),
                    pos_vert: p.f32(8),
                    compass: p.f32(12),
                    terrain_alt: p.f32(16),
                };
                self.ekf_variances = Some(Timed { value, at: now });
            }
            // latitude, longitude, altitude i32 (0..12), ...
            id::HOME_POSITION => {
                let value = Home {
                    lat_e7: p.i32(0),
                    lon_e7: p.i32(4),
                    alt_mm: p.i32(8),
                };
                self.home = Some(Timed { value, at: now });
                self.next_home_request = None;
            }
            _ => {}
        }
    }

    fn set_battery(&mut self, now: Micros, b: Battery) {
        let b = match self.battery {
            Some(old) if !old.is_stale(now) => b.or(old.value),
            _ => b,
        };
        self.battery = Some(Timed { value: b, at: now });
    }

    /// What to send to the vehicle now: a HOME_POSITION request when one is due.
    pub fn poll(&mut self, now: Micros) -> Vec<MavMessage> {
        match self.next_deadline() {
            Some(t) if now >= t => {
                self.next_home_request = Some(now + HOME_REQUEST_EVERY);
                self.home_requests += 1;
                vec![request_home(self.target)]
            }
            _ => Vec::new(),
        }
    }

    /// When [`FlightTelemetry::poll`] next has something to send.
    pub fn next_deadline(&self) -> Option<Micros> {
        if !self.request_home || self.home.is_some() {
            return None;
        }
        self.next_home_request
    }
}

/// GPS_RAW_INT's fix type and satellites from its payload. Wire order: time_usec u64, lat,
/// lon, alt i32, eph (20), epv, vel, cog u16, fix_type u8, satellites_visible u8 (bytes 28 and 29).
fn gps_from_payload(payload: &[u8]) -> Gps {
    let p = crate::wire::payload::Payload(payload);
    let satellites = p.u8(29);
    let eph = p.u16(20);
    Gps {
        fix_type: p.u8(28),
        satellites: (satellites != u8::MAX).then_some(satellites),
        hdop_e2: (eph != u16::MAX).then_some(eph),
    }
}

/// BATTERY_STATUS's id and battery fields from its payload. Wire order: current_consumed,
/// energy_consumed i32, temperature i16, voltages [u16; 10] (bytes 10..30), current_battery i16
/// (30), id u8 (32), battery_function, type u8, battery_remaining i8 (35); extensions:
/// time_remaining i32, charge_state u8, voltages_ext [u16; 4] (bytes 41..49), ...
fn battery_status_from_payload(payload: &[u8]) -> (u8, Battery) {
    let p = crate::wire::payload::Payload(payload);
    let voltages: [u16; 10] = std::array::from_fn(|k| p.u16(10 + 2 * k));
    let ext: [u16; 4] = std::array::from_fn(|k| p.u16(41 + 2 * k));
    let current = p.i16(30);
    let remaining = p.u8(35) as i8;
    (
        p.u8(32),
        Battery::from_battery_status(&voltages, &ext, current, remaining),
    )
}

impl crate::proto::machine::Machine for FlightTelemetry {
    /// The messages it reads, and the heartbeat: the first one heard starts the HOME_POSITION
    /// requests.
    const IDS: crate::proto::machine::Ids = crate::proto::machine::Ids::Only(&[
        id::HEARTBEAT,
        id::EXTENDED_SYS_STATE,
        id::GLOBAL_POSITION_INT,
        id::VFR_HUD,
        id::VIBRATION,
        id::RADIO_STATUS,
        id::SYS_STATUS,
        id::BATTERY_STATUS,
        id::GPS_RAW_INT,
        id::EKF_STATUS_REPORT,
        id::HOME_POSITION,
    ]);
    /// None: every one is read from its payload.
    const DECODES: crate::proto::machine::Ids = crate::proto::machine::Ids::Only(&[]);

    fn on_message(&mut self, m: &crate::proto::machine::Incoming, _: &mut Vec<Out>) {
        FlightTelemetry::on_message(self, m.now, m.id, m.payload);
    }

    /// HOME_POSITION requests are mavterm's own: spared on high-latency links.
    fn poll(&mut self, now: Micros, out: &mut Vec<Out>) {
        for m in FlightTelemetry::poll(self, now) {
            out.push(Out::send(crate::proto::machine::Route::Auto, m));
        }
    }

    fn next_deadline(&self) -> Option<Micros> {
        FlightTelemetry::next_deadline(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::{frame, FrameParser, Header, Version};

    const KEY: (u8, u8) = (1, 1);

    /// `msg` through our encoder and parser: (id, decoded, payload).
    fn wire(msg: &MavMessage) -> crate::wire::Frame {
        let bytes = frame::encode(
            Version::V2,
            Header {
                sysid: 1,
                compid: 1,
                seq: 0,
            },
            msg,
        );
        FrameParser::new().parse_all(&bytes).remove(0)
    }

    fn feed(t: &mut FlightTelemetry, now: Micros, msg: &MavMessage) {
        let f = wire(msg);
        t.on_message(now, f.msgid, f.payload());
    }

    fn position(lat: f64, lon: f64, rel_m: f64) -> MavMessage {
        MavMessage::GLOBAL_POSITION_INT(dialect::GLOBAL_POSITION_INT_DATA {
            lat: (lat * 1e7).round() as i32,
            lon: (lon * 1e7).round() as i32,
            alt: ((584.0 + rel_m) * 1000.0) as i32,
            relative_alt: (rel_m * 1000.0) as i32,
            ..Default::default()
        })
    }

    fn home(lat: f64, lon: f64) -> MavMessage {
        MavMessage::HOME_POSITION(dialect::HOME_POSITION_DATA {
            latitude: (lat * 1e7).round() as i32,
            longitude: (lon * 1e7).round() as i32,
            altitude: 584_000,
            ..Default::default()
        })
    }

    #[test]
    fn values_are_kept_with_their_time_and_go_stale() {
        let mut t = FlightTelemetry::new(KEY, true);
        assert!(!t.has_data());
        feed(&mut t, SECOND, &position(-35.3632621, 149.1652374, 10.02));
        let p = t.position.unwrap();
        assert_eq!(p.value.lat_e7, -353_632_621);
        assert_eq!(p.value.lon_e7, 1_491_652_374);
        assert!((p.value.relative_alt_m() - 10.02).abs() < 1e-9);
        assert!((p.value.alt_m() - 594.02).abs() < 1e-9);
        assert!(!p.is_stale(SECOND + STALE_AFTER));
        assert!(p.is_stale(SECOND + STALE_AFTER + 1));
        assert_eq!(t.last_heard(), Some(SECOND));
    }

    #[test]
    fn battery_from_sys_status_and_battery_status_merges_what_each_knows() {
        let mut t = FlightTelemetry::new(KEY, true);
        feed(
            &mut t,
            0,
            &MavMessage::SYS_STATUS(dialect::SYS_STATUS_DATA {
                voltage_battery: 12_400,
                current_battery: 320,
                battery_remaining: -1,
                ..Default::default()
            }),
        );
        let b = t.battery.unwrap().value;
        assert_eq!(b.volts(), Some(12.4));
        assert_eq!(b.amps(), Some(3.2));
        assert_eq!(b.remaining_pct, None);
        // BATTERY_STATUS knows the remaining charge; the cells add up to the total voltage.
        let mut voltages = [u16::MAX; 10];
        voltages[..3].copy_from_slice(&[4100, 4100, 4150]);
        feed(
            &mut t,
            100_000,
            &MavMessage::BATTERY_STATUS(dialect::BATTERY_STATUS_DATA {
                voltages,
                current_battery: -1,
                battery_remaining: 87,
                ..Default::default()
            }),
        );
        let b = t.battery.unwrap().value;
        assert_eq!(b.voltage_mv, Some(12_350));
        assert_eq!(b.current_ca, Some(320), "kept from SYS_STATUS");
        assert_eq!(b.remaining_pct, Some(87));
        // Another battery is not the main one.
        feed(
            &mut t,
            200_000,
            &MavMessage::BATTERY_STATUS(dialect::BATTERY_STATUS_DATA {
                id: 1,
                voltages: [7000; 10],
                battery_remaining: 5,
                ..Default::default()
            }),
        );
        assert_eq!(t.battery.unwrap().value.remaining_pct, Some(87));
    }

    #[test]
    fn gps_and_battery_with_enum_values_newer_than_the_dialect_are_read_by_hand() {
        // GPS_RAW_INT with fix type 200, satellites 10: the payload as sent, CRC by our encoder
        // of a valid message, then the fix type byte changed (the parser checks the CRC, so
        // this goes through on_message directly).
        let ok = wire(&MavMessage::GPS_RAW_INT(dialect::GPS_RAW_INT_DATA {
            fix_type: dialect::GpsFixType::GPS_FIX_TYPE_3D_FIX,
            satellites_visible: 10,
            ..Default::default()
        }));
        let mut payload = ok.payload().to_vec();
        payload[28] = 200;
        let mut t = FlightTelemetry::new(KEY, true);
        t.on_message(0, id::GPS_RAW_INT, &payload);
        let g = t.gps.unwrap().value;
        assert_eq!((g.fix_type, g.satellites), (200, Some(10)));
        assert_eq!(fix_name(g.fix_type), "fix 200");
        // The message as the dialect encodes it.
        t.on_message(1, id::GPS_RAW_INT, ok.payload());
        let g = t.gps.unwrap().value;
        assert_eq!(
            (g.fix_type, g.satellites, g.hdop_e2),
            (3, Some(10), Some(0))
        );
        // BATTERY_STATUS with battery_function 200.
        let mut voltages = [u16::MAX; 10];
        voltages[0] = 16_800;
        let ok = wire(&MavMessage::BATTERY_STATUS(dialect::BATTERY_STATUS_DATA {
            voltages,
            current_battery: 1234,
            battery_remaining: 55,
            ..Default::default()
        }));
        let mut payload = ok.payload().to_vec();
        payload[33] = 200;
        t.on_message(2, id::BATTERY_STATUS, &payload);
        let b = t.battery.unwrap().value;
        assert_eq!(
            (b.voltage_mv, b.current_ca, b.remaining_pct),
            (Some(16_800), Some(1234), Some(55))
        );
    }

    /// Every field read from a payload, each message encoded by the dialect's own serializer
    /// (MAVLink 2: trailing zeros cut) with a distinct value in every field it has: read at the
    /// right offsets, signs and widths.
    #[test]
    fn every_field_is_read_at_its_wire_offset() {
        let mut t = FlightTelemetry::new(KEY, false);
        feed(
            &mut t,
            1,
            &MavMessage::GLOBAL_POSITION_INT(dialect::GLOBAL_POSITION_INT_DATA {
                time_boot_ms: 0xDEAD_BEEF,
                lat: -353_632_610,
                lon: 1_491_652_300,
                alt: 584_070,
                relative_alt: -1_234,
                vx: -300,
                vy: 400,
                vz: -250,
                hdg: 27_100,
            }),
        );
        let p = t.position.unwrap().value;
        assert_eq!(
            (p.lat_e7, p.lon_e7, p.alt_mm, p.relative_alt_mm),
            (-353_632_610, 1_491_652_300, 584_070, -1_234)
        );
        let m = t.motion.unwrap().value;
        assert_eq!((m.groundspeed, m.climb, m.heading), (5.0, 2.5, 271));
        feed(
            &mut t,
            2,
            &MavMessage::VFR_HUD(dialect::VFR_HUD_DATA {
                airspeed: 11.5,
                groundspeed: 12.25,
                alt: 99.0,
                climb: -1.5,
                heading: 359,
                throttle: 42,
            }),
        );
        let m = t.motion.unwrap().value;
        assert_eq!((m.groundspeed, m.climb, m.heading), (12.25, -1.5, 359));
        feed(
            &mut t,
            3,
            &MavMessage::VIBRATION(dialect::VIBRATION_DATA {
                time_usec: u64::MAX,
                vibration_x: 1.5,
                vibration_y: 2.5,
                vibration_z: 3.5,
                clipping_0: 7,
                clipping_1: 70_000,
                clipping_2: 9,
            }),
        );
        assert_eq!(
            t.vibration.unwrap().value,
            Vibration {
                x: 1.5,
                y: 2.5,
                z: 3.5,
                clipping: [7, 70_000, 9]
            }
        );
        feed(
            &mut t,
            4,
            &MavMessage::RADIO_STATUS(dialect::RADIO_STATUS_DATA {
                rssi: 201,
                remrssi: 202,
                txbuf: 93,
                noise: 44,
                remnoise: 45,
                rxerrors: 1_001,
                fixed: 2_002,
            }),
        );
        assert_eq!(
            t.radio.unwrap().value,
            Radio {
                rssi: 201,
                remrssi: 202,
                noise: 44,
                remnoise: 45,
                txbuf: 93,
                rxerrors: 1_001,
                fixed: 2_002
            }
        );
        feed(
            &mut t,
            5,
            &MavMessage::SYS_STATUS(dialect::SYS_STATUS_DATA {
                voltage_battery: 15_900,
                current_battery: -2,
                battery_remaining: 64,
                load: 500,
                ..Default::default()
            }),
        );
        let b = t.battery.unwrap().value;
        assert_eq!(
            (b.voltage_mv, b.current_ca, b.remaining_pct),
            (Some(15_900), Some(-2), Some(64))
        );
        feed(
            &mut t,
            6,
            &MavMessage::EKF_STATUS_REPORT(dialect::EKF_STATUS_REPORT_DATA {
                velocity_variance: 0.125,
                pos_horiz_variance: 0.25,
                pos_vert_variance: 0.375,
                compass_variance: 0.5,
                terrain_alt_variance: 0.625,
                flags: dialect::EkfStatusFlags::from_bits_truncate(0x3FF),
                ..Default::default()
            }),
        );
        assert_eq!(t.ekf.unwrap().value, 0x3FF);
        let v = t.ekf_variances.unwrap().value;
        assert_eq!(
            (
                v.velocity,
                v.pos_horiz,
                v.pos_vert,
                v.compass,
                v.terrain_alt
            ),
            (0.125, 0.25, 0.375, 0.5, 0.625)
        );
        feed(&mut t, 7, &home(-35.5, 149.25));
        let h = t.home.unwrap().value;
        assert_eq!(
            (h.lat_e7, h.lon_e7, h.alt_mm),
            (-355_000_000, 1_492_500_000, 584_000)
        );
    }

    #[test]
    fn prearm_and_ekf_are_reported_when_the_autopilot_sends_them() {
        use dialect::MavSysStatusSensor as S;
        let mut t = FlightTelemetry::new(KEY, true);
        feed(
            &mut t,
            0,
            &MavMessage::SYS_STATUS(dialect::SYS_STATUS_DATA::default()),
        );
        assert_eq!(t.prearm, None, "no pre-arm bit: not reported");
        feed(
            &mut t,
            1,
            &MavMessage::SYS_STATUS(dialect::SYS_STATUS_DATA {
                onboard_control_sensors_present: S::MAV_SYS_STATUS_PREARM_CHECK,
                onboard_control_sensors_enabled: S::MAV_SYS_STATUS_PREARM_CHECK,
                onboard_control_sensors_health: S::empty(),
                ..Default::default()
            }),
        );
        assert_eq!(
            t.prearm.unwrap().value,
            Prearm {
                enabled: true,
                healthy: false
            }
        );
        feed(
            &mut t,
            2,
            &MavMessage::EKF_STATUS_REPORT(dialect::EKF_STATUS_REPORT_DATA {
                flags: dialect::EkfStatusFlags::from_bits_retain(0x33F),
                ..Default::default()
            }),
        );
        assert_eq!(ekf_summary(t.ekf.unwrap().value), "ok");
        assert_eq!(ekf_summary(0x33F | 0x8000), "glitch");
        assert_eq!(ekf_summary(0x400), "init");
        assert_eq!(ekf_summary(1 | 2 | 128), "nopos");
    }

    #[test]
    fn distance_and_bearing_from_home_for_known_offsets() {
        // 30 m north and 40 m east of home: 50 m at atan2(40, 30) = 53.13°. At this scale the
        // Earth is flat: 1e-7 degree of latitude is R·π/180·1e-7 m, of longitude that times
        // cos(latitude).
        let (lat, lon) = (-35.3632621f64, 149.1652374f64);
        let m_per_deg = EARTH_RADIUS_M * std::f64::consts::PI / 180.0;
        let north = 30.0 / m_per_deg;
        let east = 40.0 / (m_per_deg * lat.to_radians().cos());
        let mut t = FlightTelemetry::new(KEY, true);
        feed(&mut t, 0, &home(lat, lon));
        assert_eq!(t.from_home(), None, "no position yet");
        feed(&mut t, 1, &position(lat + north, lon + east, 5.0));
        let (d, b) = t.from_home().unwrap();
        assert!((d - 50.0).abs() < 0.05, "{d}");
        assert!((b - 53.13).abs() < 0.05, "{b}");
        // Due south 1 km, due west 12 m.
        let (d, b) = distance_bearing((lat, lon), (lat - 1000.0 / m_per_deg, lon));
        assert!(
            (d - 1000.0).abs() < 0.01 && (b - 180.0).abs() < 1e-6,
            "{d} {b}"
        );
        let west = 12.0 / (m_per_deg * lat.to_radians().cos());
        let (d, b) = distance_bearing((lat, lon), (lat, lon - west));
        assert!(
            (d - 12.0).abs() < 0.01 && (b - 270.0).abs() < 0.01,
            "{d} {b}"
        );
        // Position 0, 0 is no position.
        feed(&mut t, 2, &position(0.0, 0.0, 0.0));
        assert_eq!(t.from_home(), None);
    }

    #[test]
    fn home_is_asked_for_every_few_seconds_until_known() {
        let mut t = FlightTelemetry::new(KEY, true);
        assert_eq!(t.next_deadline(), None, "nothing heard: nothing to ask");
        feed(&mut t, SECOND, &position(-35.0, 149.0, 0.0));
        assert_eq!(
            t.next_deadline(),
            Some(SECOND),
            "the first request is due at once"
        );
        let out = t.poll(SECOND);
        assert_eq!(out, vec![request_home(KEY)]);
        match &out[0] {
            MavMessage::COMMAND_LONG(c) => {
                assert_eq!(c.command, MavCmd::MAV_CMD_REQUEST_MESSAGE);
                assert_eq!(c.param1, 242.0);
                assert_eq!((c.target_system, c.target_component), KEY);
            }
            m => panic!("{m:?}"),
        }
        assert!(t.next_deadline() > Some(SECOND));
        assert_eq!(t.next_deadline(), Some(SECOND + HOME_REQUEST_EVERY));
        assert!(t.poll(SECOND + HOME_REQUEST_EVERY - 1).is_empty());
        assert_eq!(t.poll(SECOND + HOME_REQUEST_EVERY).len(), 1);
        assert_eq!(t.home_requests, 2);
        feed(&mut t, 7 * SECOND, &home(-35.0, 149.0));
        assert_eq!(t.next_deadline(), None);
        assert!(t.poll(100 * SECOND).is_empty());
        // Not asked at all when telemetry requests are off.
        let mut quiet = FlightTelemetry::new(KEY, false);
        feed(&mut quiet, 0, &position(-35.0, 149.0, 0.0));
        assert_eq!(quiet.next_deadline(), None);
        assert!(quiet.poll(10 * SECOND).is_empty());
    }

    #[test]
    fn history_keeps_one_value_a_second_for_three_minutes() {
        let mut h = History::default();
        assert_eq!(h.recent(5 * SECOND, 3), vec![None; 3]);
        h.set(0, 1.0);
        h.set(500_000, 2.0); // same second: replaces
        h.set(SECOND, 3.0);
        h.set(4 * SECOND + 1, 4.0); // seconds 2 and 3 missing
        assert_eq!(
            h.recent(5 * SECOND, 6),
            vec![Some(2.0), Some(3.0), None, None, Some(4.0), None]
        );
        assert_eq!(h.recent(4 * SECOND, 2), vec![None, Some(4.0)]);
        for s in 0..1000u64 {
            h.set(10 * SECOND + s * SECOND, s as f32);
        }
        assert!(h.values.len() <= HISTORY_SECS);
        let last = h.recent(1009 * SECOND, HISTORY_SECS);
        assert_eq!(last[HISTORY_SECS - 1], Some(999.0));
        assert_eq!(last[0], Some(820.0)); // 999 - 179
                                          // Asked for more than is kept: the rest is None, never a panic.
        assert_eq!(h.recent(1009 * SECOND, 200)[..20], vec![None; 20][..]);
        // A long silence then a value: bounded.
        h.set(1_000_000 * SECOND, 1.0);
        assert!(h.values.len() <= HISTORY_SECS);
        assert_eq!(h.recent(1_000_000 * SECOND, 1), vec![Some(1.0)]);
    }
}
