//! One simulated ArduCopter: state, a simple vertical/horizontal flight model, and the timeline
//! of its boot (GPS fix, EKF position estimate). Message handling lives in `handlers.rs`,
//! message building in `telemetry.rs`.
//!
//! Everything happens at times handed in; the vehicle never reads a clock.

use super::mavftp::FtpServer;
use super::params::ParamTable;
use super::rng::Rng;
use super::streams::Streams;
use crate::clock::{Micros, SECOND};
use crate::dialect::{MavMessage, MavSeverity};
use std::path::PathBuf;

/// Physics and scheduling step. ArduPilot's main loop is faster, but 10 ms resolves every rate
/// a GCS asks for (up to 100 Hz) and keeps virtual-time runs cheap.
pub const TICK: Micros = 10_000;
/// GPS reports a 3D fix this long after boot.
pub const GPS_FIX_AT: Micros = 4 * SECOND;
/// The EKF starts using GPS (position estimate, home set, arming allowed) this long after boot.
pub const EKF_GPS_AT: Micros = 5 * SECOND;
/// PARAM_VALUEs sent per tick during a list download (ArduPilot paces by link space; a fixed
/// budget of 500/s outruns a 57600 baud radio, as a real burst can).
pub const PARAMS_PER_TICK: usize = 5;
/// FTP burst packets per tick.
pub const FTP_PER_TICK: usize = 2;
/// Takeoff and RTL climb rate, m/s.
pub const CLIMB_RATE: f64 = 1.5;
/// RTL horizontal speed, m/s.
pub const RTL_SPEED: f64 = 5.0;
/// A repeated command with confirmation > 0 inside this window is a retransmission.
pub const RETRANSMIT_WINDOW: Micros = 3 * SECOND;

/// The SITL default home (ArduPilot's CMAC field, Canberra).
pub const HOME_LAT: f64 = -35.363_262_1;
pub const HOME_LON: f64 = 149.165_237_4;
pub const HOME_ALT_M: f64 = 584.0;

/// ArduCopter flight modes (custom_mode numbers).
pub mod mode {
    pub const STABILIZE: u32 = 0;
    pub const ACRO: u32 = 1;
    pub const ALT_HOLD: u32 = 2;
    pub const AUTO: u32 = 3;
    pub const GUIDED: u32 = 4;
    pub const LOITER: u32 = 5;
    pub const RTL: u32 = 6;
    pub const CIRCLE: u32 = 7;
    pub const LAND: u32 = 9;
    pub const DRIFT: u32 = 11;
    pub const SPORT: u32 = 13;
    pub const FLIP: u32 = 14;
    pub const AUTOTUNE: u32 = 15;
    pub const POSHOLD: u32 = 16;
    pub const BRAKE: u32 = 17;
    pub const THROW: u32 = 18;
    pub const AVOID_ADSB: u32 = 19;
    pub const GUIDED_NOGPS: u32 = 20;
    pub const SMART_RTL: u32 = 21;
    pub const FLOWHOLD: u32 = 22;
    pub const FOLLOW: u32 = 23;
    pub const ZIGZAG: u32 = 24;
    pub const SYSTEMID: u32 = 25;
    pub const AUTOROTATE: u32 = 26;
    pub const AUTO_RTL: u32 = 27;
    pub const TURTLE: u32 = 28;

    /// Every mode number ArduCopter knows.
    pub fn exists(m: u32) -> bool {
        matches!(m, 0..=7 | 9 | 11 | 13..=28)
    }

    /// Modes that need a position estimate (ArduCopter `requires_GPS`).
    pub fn requires_position(m: u32) -> bool {
        matches!(
            m,
            AUTO | GUIDED
                | LOITER
                | RTL
                | CIRCLE
                | POSHOLD
                | BRAKE
                | THROW
                | AVOID_ADSB
                | SMART_RTL
                | FOLLOW
                | ZIGZAG
                | AUTO_RTL
        )
    }

    /// Modes ArduCopter refuses to arm in.
    pub fn armable(m: u32) -> bool {
        !matches!(
            m,
            AUTO | RTL | CIRCLE | LAND | SMART_RTL | AUTO_RTL | FOLLOW | AUTOROTATE | AVOID_ADSB
        )
    }

    /// Modes that set MAV_MODE_FLAG_GUIDED_ENABLED in the heartbeat (ArduCopter `base_mode()`).
    pub fn guided_flag(m: u32) -> bool {
        matches!(
            m,
            AUTO | AUTO_RTL
                | RTL
                | LOITER
                | AVOID_ADSB
                | FOLLOW
                | GUIDED
                | CIRCLE
                | POSHOLD
                | BRAKE
                | SMART_RTL
        )
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum RtlPhase {
    Climb,
    Return,
    Descend,
}

/// The last command executed, to recognise retransmissions.
#[derive(Debug, Clone)]
pub(super) struct LastCommand {
    pub from: (u8, u8),
    pub command: u16,
    pub params: [u32; 7],
    pub result: crate::dialect::MavResult,
    pub at: Micros,
}

/// One simulated vehicle. Read-only from outside; driven by [`super::Sim`].
#[derive(Debug, Clone)]
pub struct SimVehicle {
    pub(super) sysid: u8,
    pub(super) compid: u8,
    pub(super) rng: Rng,
    pub(super) params: ParamTable,
    pub(super) state_path: Option<PathBuf>,
    /// The state file to write, and its contents, waiting for the edge.
    pub(super) pending_write: Option<(PathBuf, Vec<u8>)>,
    pub(super) armed: bool,
    pub(super) custom_mode: u32,
    pub(super) home: (f64, f64, f64),
    /// Metres north/east of home, metres above home (up), velocities m/s (north, east, up).
    pub(super) north: f64,
    pub(super) east: f64,
    pub(super) alt: f64,
    pub(super) vn: f64,
    pub(super) ve: f64,
    pub(super) vu: f64,
    pub(super) landed: bool,
    pub(super) takeoff_target: Option<f64>,
    pub(super) rtl_phase: RtlPhase,
    pub(super) armed_on_ground_since: Option<Micros>,
    pub(super) gps_fix: bool,
    pub(super) ekf_gps: bool,
    pub(super) consumed_mah: f64,
    pub(super) streams: Streams,
    pub(super) next_heartbeat: Micros,
    pub(super) booted: bool,
    pub(super) param_cursor: Option<usize>,
    pub(super) ftp: FtpServer,
    /// Who the FTP burst replies go to.
    pub(super) ftp_peer: (u8, u8),
    pub(super) last_command: Option<LastCommand>,
    pub(super) last_tick: Micros,
    pub(super) now: Micros,
    pub(super) out: Vec<MavMessage>,
}

impl SimVehicle {
    /// Vehicle `index` (0-based) of a fleet, with its own id, home offset and random stream.
    pub fn new(
        sysid: u8,
        index: usize,
        seed: u64,
        params: ParamTable,
        state_path: Option<PathBuf>,
    ) -> SimVehicle {
        // About 11 m apart so several vehicles are distinguishable on a map.
        let home = (
            HOME_LAT + index as f64 * 0.0001,
            HOME_LON + index as f64 * 0.0001,
            HOME_ALT_M,
        );
        let mut params = params;
        // ArduPilot names its own id MAV_SYSID (SYSID_THISMAV before 4.7).
        params.set("MAV_SYSID", sysid as f64);
        params.set("SYSID_THISMAV", sysid as f64);
        SimVehicle {
            sysid,
            compid: 1,
            rng: Rng::derive(seed, 0x5EED_0000 + sysid as u64),
            params,
            state_path,
            pending_write: None,
            armed: false,
            custom_mode: mode::STABILIZE,
            home,
            north: 0.0,
            east: 0.0,
            alt: 0.0,
            vn: 0.0,
            ve: 0.0,
            vu: 0.0,
            landed: true,
            takeoff_target: None,
            rtl_phase: RtlPhase::Climb,
            armed_on_ground_since: None,
            gps_fix: false,
            ekf_gps: false,
            consumed_mah: 0.0,
            streams: Streams::default(),
            next_heartbeat: 0,
            booted: false,
            param_cursor: None,
            ftp: FtpServer::default(),
            ftp_peer: (255, 0),
            last_command: None,
            last_tick: 0,
            now: 0,
            out: Vec::new(),
        }
    }

    pub fn sysid(&self) -> u8 {
        self.sysid
    }
    pub fn compid(&self) -> u8 {
        self.compid
    }
    pub fn armed(&self) -> bool {
        self.armed
    }
    /// ArduCopter mode number (see [`mode`]).
    pub fn custom_mode(&self) -> u32 {
        self.custom_mode
    }
    /// Height above home, metres.
    pub fn relative_alt_m(&self) -> f64 {
        self.alt
    }
    /// Climb rate, m/s (up positive).
    pub fn climb_rate(&self) -> f64 {
        self.vu
    }
    /// Metres north and east of home.
    pub fn position_ne(&self) -> (f64, f64) {
        (self.north, self.east)
    }
    pub fn landed(&self) -> bool {
        self.landed
    }
    pub fn gps_fix(&self) -> bool {
        self.gps_fix
    }
    /// True once arming checks on position pass.
    pub fn position_ok(&self) -> bool {
        self.ekf_gps
    }
    pub fn param(&self, name: &str) -> Option<f64> {
        self.params.value(name)
    }
    pub fn param_count(&self) -> usize {
        self.params.len()
    }
    /// Current stream interval of a message id, if streaming.
    pub fn message_interval(&self, msgid: u32) -> Option<Micros> {
        self.streams.interval(msgid)
    }

    /// Take what the vehicle has to send.
    pub(super) fn drain(&mut self) -> Vec<MavMessage> {
        std::mem::take(&mut self.out)
    }

    pub(super) fn text(&mut self, severity: MavSeverity, s: &str) {
        self.out.push(super::telemetry::statustext(severity, s));
    }

    /// The boot banner ArduPilot sends at start and again after every PARAM_REQUEST_LIST.
    pub(super) fn banner(&mut self) {
        self.text(
            MavSeverity::MAV_SEVERITY_INFO,
            super::telemetry::FIRMWARE_STRING,
        );
        self.text(
            MavSeverity::MAV_SEVERITY_INFO,
            "SIM 0 0 0 (simulated board)",
        );
        self.text(MavSeverity::MAV_SEVERITY_INFO, "Frame: QUAD/PLUS");
    }

    /// Advance to `now` (a tick boundary): boot events, flight model, then everything due.
    pub(super) fn tick(&mut self, now: Micros) {
        let dt = now.saturating_sub(self.last_tick) as f64 / 1e6;
        self.last_tick = now;
        self.now = now;
        if !self.booted {
            self.booted = true;
            self.banner();
            self.text(MavSeverity::MAV_SEVERITY_INFO, "ArduPilot Ready");
        }
        if !self.gps_fix && now >= GPS_FIX_AT {
            self.gps_fix = true;
            self.text(MavSeverity::MAV_SEVERITY_INFO, "GPS 1: detected u-blox");
        }
        if !self.ekf_gps && now >= EKF_GPS_AT {
            self.ekf_gps = true;
            self.text(MavSeverity::MAV_SEVERITY_INFO, "EKF3 IMU0 is using GPS");
            let field = format!("Field Elevation Set: {}m", self.home.2.round());
            self.text(MavSeverity::MAV_SEVERITY_INFO, &field);
        }
        self.step(now, dt);
        if now >= self.next_heartbeat {
            self.out.push(self.heartbeat());
            self.next_heartbeat = now - now % SECOND + SECOND;
        }
        for msgid in self.streams.take_due(now) {
            if let Some(m) = self.build(msgid) {
                self.out.push(m);
            }
        }
        self.send_param_burst();
        for _ in 0..FTP_PER_TICK {
            match self.ftp.next_burst_packet(now) {
                Some(p) => {
                    let m = super::telemetry::ftp_message(self.ftp_peer, &p);
                    self.out.push(m);
                }
                None => break,
            }
        }
    }

    /// The earliest time after `after` at which this vehicle has something to do, given that it
    /// only acts on tick boundaries.
    pub(super) fn next_event(&self, after: Micros) -> Micros {
        let next_tick = after - after % TICK + TICK;
        let busy = self.param_cursor.is_some()
            || self.ftp.bursting()
            || (self.armed && !self.landed)
            || (self.armed && self.armed_on_ground_since.is_some())
            || !self.booted;
        if busy {
            return next_tick;
        }
        let mut t = self.next_heartbeat;
        if let Some(d) = self.streams.next_due() {
            t = t.min(d);
        }
        if !self.gps_fix {
            t = t.min(GPS_FIX_AT);
        }
        if !self.ekf_gps {
            t = t.min(EKF_GPS_AT);
        }
        // Round up to a tick boundary, never before the next tick.
        let t = t.div_ceil(TICK) * TICK;
        t.max(next_tick)
    }

    fn send_param_burst(&mut self) {
        for _ in 0..PARAMS_PER_TICK {
            let Some(i) = self.param_cursor else { return };
            if i >= self.params.len() {
                self.param_cursor = None;
                return;
            }
            let m = super::telemetry::param_value(&self.params, i);
            self.out.push(m);
            self.param_cursor = Some(i + 1);
        }
        if self.param_cursor.is_some_and(|i| i >= self.params.len()) {
            self.param_cursor = None;
        }
    }

    fn land_speed(&self) -> f64 {
        let cms = self.params.value("LAND_SPEED").unwrap_or(50.0);
        (cms / 100.0).clamp(0.3, 2.0)
    }

    fn rtl_alt(&self) -> f64 {
        (self.params.value("RTL_ALT").unwrap_or(1500.0) / 100.0).clamp(2.0, 300.0)
    }

    /// Flight model for `dt` seconds.
    fn step(&mut self, now: Micros, dt: f64) {
        // Battery: idle draw disarmed, more on the ground armed, hover current in flight.
        let amps = match (self.armed, self.landed) {
            (false, _) => 0.5,
            (true, true) => 3.0,
            (true, false) => 15.0,
        };
        self.consumed_mah += amps * dt / 3.6;
        self.vn = 0.0;
        self.ve = 0.0;
        self.vu = 0.0;
        if !self.armed {
            return;
        }
        if self.landed {
            let m = self.custom_mode;
            if m == mode::LAND || m == mode::RTL {
                self.disarm("Disarming motors");
                return;
            }
            let delay = self.params.value("DISARM_DELAY").unwrap_or(10.0);
            if delay > 0.0 {
                let since = *self.armed_on_ground_since.get_or_insert(now);
                if now.saturating_sub(since) as f64 >= delay * 1e6 {
                    self.disarm("Disarming motors");
                }
            }
            return;
        }
        match self.custom_mode {
            mode::LAND => self.descend(dt),
            mode::RTL => match self.rtl_phase {
                RtlPhase::Climb => {
                    let target = self.rtl_alt();
                    if self.alt < target {
                        self.climb_to(target, dt);
                    } else {
                        self.rtl_phase = RtlPhase::Return;
                    }
                }
                RtlPhase::Return => {
                    let dist = self.north.hypot(self.east);
                    let step = RTL_SPEED * dt;
                    if dist <= step.max(0.05) {
                        self.north = 0.0;
                        self.east = 0.0;
                        self.rtl_phase = RtlPhase::Descend;
                    } else {
                        let (un, ue) = (-self.north / dist, -self.east / dist);
                        self.north += un * step;
                        self.east += ue * step;
                        self.vn = un * RTL_SPEED;
                        self.ve = ue * RTL_SPEED;
                    }
                }
                RtlPhase::Descend => self.descend(dt),
            },
            _ => {
                if let Some(target) = self.takeoff_target {
                    if self.alt < target {
                        self.climb_to(target, dt);
                    } else {
                        self.takeoff_target = None;
                    }
                }
            }
        }
    }

    fn climb_to(&mut self, target: f64, dt: f64) {
        let next = (self.alt + CLIMB_RATE * dt).min(target);
        self.vu = if dt > 0.0 {
            (next - self.alt) / dt
        } else {
            0.0
        };
        self.alt = next;
    }

    fn descend(&mut self, dt: f64) {
        let v = self.land_speed();
        self.alt -= v * dt;
        self.vu = -v;
        if self.alt <= 0.0 {
            self.alt = 0.0;
            self.vu = 0.0;
            self.landed = true;
            self.takeoff_target = None;
            self.armed_on_ground_since = Some(self.now);
        }
    }

    pub(super) fn disarm(&mut self, why: &str) {
        if self.armed {
            self.armed = false;
            self.armed_on_ground_since = None;
            self.takeoff_target = None;
            self.text(MavSeverity::MAV_SEVERITY_INFO, why);
        }
    }

    /// Enter a mode (already validated).
    pub(super) fn enter_mode(&mut self, m: u32) {
        if m == mode::RTL && self.custom_mode != mode::RTL {
            self.rtl_phase = RtlPhase::Climb;
        }
        if m != mode::GUIDED {
            self.takeoff_target = None;
        }
        self.custom_mode = m;
    }

    /// Latitude/longitude (degrees) of the current position (flat earth around home).
    pub(super) fn lat_lon(&self) -> (f64, f64) {
        let lat = self.home.0 + self.north / 111_319.5;
        let lon = self.home.1 + self.east / (111_319.5 * self.home.0.to_radians().cos());
        (lat, lon)
    }

    /// Queue the parameters for saving if a state file is configured; the edge writes them
    /// ([`super::Sim::take_writes`]), the state machine never touches the disk.
    pub(super) fn save_params(&mut self) {
        if let Some(path) = self.state_path.clone() {
            self.pending_write = Some((path, self.params.to_parm_text().into_bytes()));
        }
    }
}
