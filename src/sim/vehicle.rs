//! One simulated ArduCopter: state, a simple vertical/horizontal flight model, and the timeline
//! of its boot (GPS fix, EKF position estimate). Message handling lives in `handlers.rs`,
//! message building in `telemetry.rs`.
//!
//! Everything happens at times handed in; the vehicle never reads a clock.

use super::auto::AutoState;
use super::guided::GuidedVel;
use super::mavftp::{FtpOut, FtpServer};
use super::mission::MissionStore;
use super::param_send::{LinkModel, ParamSender, IO_TIMER_PERIOD, PARAM_SEND_INTERVAL};
use super::params::ParamTable;
use super::rng::Rng;
use super::streams::Streams;
use crate::clock::{Micros, SECOND};
use crate::dialect::{MavCmd, MavMessage, MavResult, MavSeverity};
use std::collections::{BTreeMap, VecDeque};
use std::path::PathBuf;

/// Physics and scheduling step. ArduPilot's main loop is faster, but 10 ms resolves every rate
/// a GCS asks for (up to 100 Hz) and keeps virtual-time runs cheap.
pub const TICK: Micros = 10_000;
/// GPS reports a 3D fix this long after boot.
pub const GPS_FIX_AT: Micros = 4 * SECOND;
/// The EKF starts using GPS (position estimate, home set, arming allowed) this long after boot.
pub const EKF_GPS_AT: Micros = 5 * SECOND;
/// BRD_OPTIONS bits (`AP_BoardConfig::board_options`): DISABLE_FTP and ALLOW_SET_INTERNAL_PARM.
pub const BRD_OPTION_DISABLE_FTP: u32 = 1 << 1;
pub const BRD_OPTION_ALLOW_SET_INTERNAL_PARM: u32 = 1 << 2;
/// Takeoff and RTL climb rate, m/s.
pub const CLIMB_RATE: f64 = 1.5;
/// RTL horizontal speed, m/s.
pub const RTL_SPEED: f64 = 5.0;
/// A repeated command with confirmation > 0 inside this window is a retransmission.
pub const RETRANSMIT_WINDOW: Micros = 3 * SECOND;
/// MAV_CMD_PREFLIGHT_CALIBRATION gyro (param1=1): ArduPilot calibrates synchronously in its main
/// loop (`AP_InertialSensor::calibrate_gyros`): passes of 50 samples 5 ms apart until two agree,
/// so about half a second during which the vehicle sends nothing, then one COMMAND_ACK.
pub const GYRO_CAL_TIME: Micros = 600_000;
/// Simple accel (param5=4) and level (param5=2) calibration, also synchronous: the same
/// averaging passes, then 0.5 s of samples thrown away while the filters settle.
pub const ACCEL_CAL_TIME: Micros = 1_100_000;
/// Airspeed calibration started by a baro calibration (param3=1) when an airspeed sensor is
/// enabled: `AP_Airspeed` averages for at least a second and 15 readings at 10 Hz.
pub const AIRSPEED_CAL_TIME: Micros = 1_500_000;

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

    /// Every mode number a quad build of ArduCopter has a mode object for
    /// (`Copter::mode_from_mode_num`): AUTOROTATE is heli-only, AUTO_RTL is AUTO in disguise and
    /// handled before the lookup, 8, 10 and 12 are unused.
    pub fn exists(m: u32) -> bool {
        matches!(m, 0..=7 | 9 | 11 | 13..=25 | 28)
    }

    /// The mode's `name()` as ArduCopter prints it in STATUSTEXTs.
    pub fn name(m: u32) -> &'static str {
        match m {
            STABILIZE => "STABILIZE",
            ACRO => "ACRO",
            ALT_HOLD => "ALT_HOLD",
            AUTO => "AUTO",
            GUIDED => "GUIDED",
            LOITER => "LOITER",
            RTL => "RTL",
            CIRCLE => "CIRCLE",
            LAND => "LAND",
            DRIFT => "DRIFT",
            SPORT => "SPORT",
            FLIP => "FLIP",
            AUTOTUNE => "AUTOTUNE",
            POSHOLD => "POSHOLD",
            BRAKE => "BRAKE",
            THROW => "THROW",
            AVOID_ADSB => "AVOID_ADSB",
            GUIDED_NOGPS => "GUIDED_NOGPS",
            SMART_RTL => "SMARTRTL",
            FLOWHOLD => "FLOWHOLD",
            FOLLOW => "FOLLOW",
            ZIGZAG => "ZIGZAG",
            SYSTEMID => "SYSTEMID",
            AUTOROTATE => "AUTOROTATE",
            AUTO_RTL => "AUTO RTL",
            TURTLE => "TURTLE",
            _ => "?",
        }
    }

    /// Bit of FLTMODE_GCSBLOCK that blocks mode `m` from the GCS (`Copter::gcs_mode_enabled`).
    pub fn gcs_block_bit(m: u32) -> Option<u32> {
        const LIST: [u32; 24] = [
            STABILIZE,
            ACRO,
            ALT_HOLD,
            AUTO,
            GUIDED,
            LOITER,
            CIRCLE,
            DRIFT,
            SPORT,
            FLIP,
            AUTOTUNE,
            POSHOLD,
            BRAKE,
            THROW,
            AVOID_ADSB,
            GUIDED_NOGPS,
            SMART_RTL,
            FLOWHOLD,
            FOLLOW,
            ZIGZAG,
            SYSTEMID,
            AUTOROTATE,
            AUTO_RTL,
            TURTLE,
        ];
        LIST.iter().position(|&x| x == m).map(|i| i as u32)
    }

    /// Modes that need a position estimate (ArduCopter `requires_GPS`).
    pub fn requires_position(m: u32) -> bool {
        matches!(
            m,
            AUTO | GUIDED
                | LOITER
                | RTL
                | CIRCLE
                | DRIFT
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

    /// Modes ArduCopter refuses to arm in (`allows_arming` false with default options).
    pub fn armable(m: u32) -> bool {
        !matches!(
            m,
            AUTO | RTL
                | CIRCLE
                | LAND
                | SMART_RTL
                | AUTO_RTL
                | FOLLOW
                | AUTOROTATE
                | AVOID_ADSB
                | BRAKE
                | FLIP
                | AUTOTUNE
        )
    }

    /// `Mode::has_user_takeoff(must_navigate)`: the modes NAV_TAKEOFF works in. `must_navigate`
    /// is NAV_TAKEOFF param3 == 0 (horizontal navigation by the pilot not acceptable).
    pub fn has_user_takeoff(m: u32, must_navigate: bool) -> bool {
        match m {
            GUIDED | LOITER | POSHOLD | ZIGZAG => true,
            ALT_HOLD | SPORT | FLOWHOLD => !must_navigate,
            _ => false,
        }
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

/// What a vehicle queues for the link.
// Nearly every item is a MavMessage; boxing them all to shrink the rare Raw is not worth it.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone)]
pub(super) enum Out {
    Msg(MavMessage),
    /// A message the dialect types cannot express (e.g. the COMMAND_ACK ArduPilot sends for
    /// SET_MODE, whose command is the message id 11): message id and MAVLink 2 payload.
    Raw {
        msgid: u32,
        payload: Vec<u8>,
    },
}

/// A message waiting while the vehicle is busy: decoded, or a mission protocol message kept as
/// its raw payload (those are read from the payload, see `mission.rs`).
#[derive(Debug, Clone)]
pub(super) enum Inbound {
    Msg(Box<MavMessage>),
    Raw { msgid: u32, payload: Vec<u8> },
}

/// A synchronous calibration in progress: until `until` the vehicle's main loop is busy, sends
/// nothing and reads nothing (what arrives waits in `queued_in`); then the ACK goes out.
#[derive(Debug, Clone)]
pub(super) struct Blocked {
    pub until: Micros,
    pub ack: (MavCmd, MavResult, (u8, u8)),
    /// Sent right after the ACK.
    pub then: Vec<Out>,
}

/// An airspeed calibration answered with MAV_RESULT_IN_PROGRESS (`GCS_MAVLINK_InProgress`).
#[derive(Debug, Clone)]
pub(super) struct AirspeedCal {
    pub started: Micros,
    pub to: (u8, u8),
    pub calibrated: bool,
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
    /// EKF origin (the first home); HOME moves to the vehicle when it arms.
    pub(super) origin: (f64, f64, f64),
    /// Heading, degrees 0..360 (the vehicle faces where it flies and keeps facing there).
    pub(super) yaw: f64,
    /// GUIDED destination (DO_REPOSITION, SET_POSITION_TARGET_*): metres north/east of home,
    /// metres above home.
    pub(super) guided_target: Option<(f64, f64, f64)>,
    /// GUIDED velocity target (SET_POSITION_TARGET_* velocities).
    pub(super) guided_vel: Option<GuidedVel>,
    /// Heading commanded with a GUIDED destination, degrees.
    pub(super) guided_yaw: Option<f64>,
    /// Mission, fence and rally stores and their transfers.
    pub(super) mission: MissionStore,
    /// The mission being flown (AP_Mission and ModeAuto state).
    pub(super) auto: AutoState,
    /// SmartRTL has a path (recorded from arming with a position estimate).
    pub(super) srtl_active: bool,
    pub(super) blocked: Option<Blocked>,
    /// Messages that arrived while blocked, handled when the block ends.
    pub(super) queued_in: VecDeque<((u8, u8), Inbound)>,
    pub(super) airspeed_cal: Option<AirspeedCal>,
    /// `drop_cmd`: copies of each command id still to drop.
    pub(super) drop_left: BTreeMap<u16, u32>,
    pub(super) commands_dropped: u64,
    /// `drop_ack`: ACKs of each command id still to lose.
    pub(super) drop_acks: BTreeMap<u16, u32>,
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
    /// The MAVLink port as GCS_MAVLINK sees it (bandwidth, flow control).
    pub(super) link: LinkModel,
    /// The onboard logs and their transfer ([`super::logs`]).
    pub logs: super::logs::SimLogs,
    /// Room in the UART's transmit buffer this tick (bytes), set by the simulator.
    pub(super) txspace: u64,
    /// PARAM_REQUEST_LIST download and PARAM_REQUEST_READ answers.
    pub(super) param_send: ParamSender,
    /// When `queued_param_send` (MSG_NEXT_PARAM) runs next.
    pub(super) next_param_run: Micros,
    /// When `AP_Baro::update_calibration` last sent the ground pressures (`_last_notify_ms`).
    pub(super) baro_notified: Micros,
    /// The calibration results the boot still has to save.
    pub(super) settle: super::params::BootSettle,
    /// The firmware has MAVFTP (`ftp=1`).
    pub(super) ftp_built: bool,
    pub(super) ftp: FtpServer,
    pub(super) last_command: Option<LastCommand>,
    pub(super) last_tick: Micros,
    pub(super) now: Micros,
    pub(super) out: Vec<Out>,
    /// What a command handler sends itself, ahead of its COMMAND_ACK.
    pub(super) immediate: Vec<Out>,
    /// The mount (`gimbal=1`): AP_Mount as gimbal manager on this component.
    pub(super) mount: Option<super::gimbal::SimMount>,
    /// Calibrations and pre-arm checks ([`super::calibration`]).
    pub(super) cal: super::calibration::SimCal,
}

impl SimVehicle {
    /// The mount (`gimbal=1`), as it stands.
    pub fn mount(&self) -> Option<&super::gimbal::SimMount> {
        self.mount.as_ref()
    }

    /// The vehicle's parameter table, as it stands (for tests to compare against).
    pub fn params(&self) -> &ParamTable {
        &self.params
    }

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
        // The stores start empty (they are not kept in the state file), and so their counts.
        for total in ["MIS_TOTAL", "FENCE_TOTAL", "RALLY_TOTAL"] {
            params.set(total, 0.0);
        }
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
            origin: home,
            yaw: 0.0,
            guided_target: None,
            guided_vel: None,
            guided_yaw: None,
            mission: MissionStore::default(),
            auto: AutoState::default(),
            srtl_active: false,
            blocked: None,
            queued_in: VecDeque::new(),
            airspeed_cal: None,
            drop_left: BTreeMap::new(),
            commands_dropped: 0,
            drop_acks: BTreeMap::new(),
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
            link: LinkModel::new(None),
            logs: super::logs::SimLogs::new(0, 0),
            txspace: 0,
            param_send: ParamSender::default(),
            next_param_run: 0,
            baro_notified: 0,
            settle: Default::default(),
            ftp_built: true,
            ftp: FtpServer::default(),
            last_command: None,
            last_tick: 0,
            now: 0,
            out: Vec::new(),
            immediate: Vec::new(),
            mount: None,
            cal: super::calibration::SimCal::default(),
        }
    }

    /// The link the vehicle's MAVLink port is on (`baud`) and whether the firmware has MAVFTP.
    pub(super) fn set_link(&mut self, baud: Option<u32>, ftp: bool) {
        self.link = LinkModel::new(baud);
        self.ftp_built = ftp;
        self.ftp =
            FtpServer::with_link((!self.link.flow_control).then_some(self.link.bytes_per_second));
    }

    /// MAVFTP answers: built in, and not switched off by BRD_OPTIONS DISABLE_FTP.
    pub(super) fn ftp_enabled(&self) -> bool {
        let options = self.params.value("BRD_OPTIONS").unwrap_or(0.0) as i64 as u32;
        self.ftp_built && options & BRD_OPTION_DISABLE_FTP == 0
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
    /// Heading, degrees.
    pub fn heading_deg(&self) -> f64 {
        self.yaw
    }
    /// Home: latitude, longitude (degrees), altitude AMSL (metres).
    pub fn home(&self) -> (f64, f64, f64) {
        self.home
    }
    /// Commands ignored because of `drop_cmd`.
    pub fn commands_dropped(&self) -> u64 {
        self.commands_dropped
    }
    /// True while a synchronous calibration keeps the vehicle silent.
    pub fn busy(&self) -> bool {
        self.blocked.is_some()
    }

    /// Take what the vehicle has to send.
    pub(super) fn drain(&mut self) -> Vec<Out> {
        std::mem::take(&mut self.out)
    }

    pub(super) fn push(&mut self, m: MavMessage) {
        self.out.push(Out::Msg(m));
    }

    pub(super) fn text(&mut self, severity: MavSeverity, s: &str) {
        self.push(super::telemetry::statustext(severity, s));
    }

    /// `drop_cmd`: true (and one fewer left) if this copy of `command` is to be dropped.
    pub(super) fn take_drop(&mut self, command: u16) -> bool {
        match self.drop_left.get_mut(&command) {
            Some(n) if *n > 0 => {
                *n -= 1;
                self.commands_dropped += 1;
                true
            }
            _ => false,
        }
    }

    /// The COMMAND_ACK of `command` to `to`, unless `drop_ack` loses it.
    pub(super) fn ack(&mut self, command: MavCmd, result: MavResult, to: (u8, u8)) {
        if let Some(n) = self
            .drop_acks
            .get_mut(&(command as u16))
            .filter(|n| **n > 0)
        {
            *n -= 1;
            return;
        }
        self.push(super::telemetry::command_ack(command, result, to));
    }

    /// HOME_POSITION and GPS_GLOBAL_ORIGIN, as ArduPilot sends them whenever home is set
    /// (`AP_AHRS::set_home`).
    pub(super) fn announce_home(&mut self) {
        let origin = self.gps_global_origin();
        self.push(origin);
        let home = self.home_position();
        self.push(home);
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
        if let Some(b) = &self.blocked {
            if now < b.until {
                // The main loop is busy calibrating: nothing is sent, nothing advances.
                return;
            }
            let b = self.blocked.take().expect("checked");
            self.now = now;
            let (command, result, to) = b.ack;
            self.ack(command, result, to);
            self.out.extend(b.then);
            while self.blocked.is_none() {
                let Some((from, msg)) = self.queued_in.pop_front() else {
                    break;
                };
                match msg {
                    Inbound::Msg(m) => self.handle(now, from, &m),
                    Inbound::Raw { msgid, payload } => self.handle_raw(now, from, msgid, &payload),
                }
            }
            if self.blocked.is_some() {
                return;
            }
        }
        let dt = now.saturating_sub(self.last_tick) as f64 / 1e6;
        self.last_tick = now;
        self.now = now;
        if !self.booted {
            self.booted = true;
            self.banner();
            self.text(MavSeverity::MAV_SEVERITY_INFO, "ArduPilot Ready");
        }
        for i in self.settle.settle(now, &mut self.params) {
            let m = super::telemetry::param_value_notify(&self.params, i);
            self.push(m);
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
            self.announce_home();
        }
        self.mission_tick(now);
        self.auto_update();
        self.step(now, dt);
        if let Some(m) = self.mount.as_mut() {
            m.step(dt);
        }
        self.airspeed_cal_tick(now);
        self.cal_tick(now);
        if now >= self.next_heartbeat {
            let hb = self.heartbeat();
            self.push(hb);
            self.next_heartbeat = now - now % SECOND + SECOND;
        }
        for msgid in self.streams.take_due(now) {
            if let Some(m) = self.build(msgid) {
                self.push(m);
            }
        }
        // The IO thread's param_io_timer, about once a millisecond since the last tick.
        self.param_send
            .io_timer(TICK / IO_TIMER_PERIOD, &self.params);
        if now >= self.next_param_run {
            let msgs = self.param_send.run(now, &self.params, &self.link);
            for m in msgs {
                self.push(m);
            }
            self.next_param_run = now - now % PARAM_SEND_INTERVAL + PARAM_SEND_INTERVAL;
        }
        let ftp = self.ftp.poll(now, &self.params);
        self.ftp_out(ftp);
        for m in self.logs.tick(self.txspace, self.link.flow_control) {
            self.push(m);
        }
    }

    /// Send what the FTP worker produced.
    pub(super) fn ftp_out(&mut self, out: Vec<FtpOut>) {
        for o in out {
            match o {
                FtpOut::Reply { to, packet } => {
                    let m = super::telemetry::ftp_message(to, &packet);
                    self.push(m);
                }
                FtpOut::Banner => self.banner(),
                FtpOut::Debug(t) => self.text(MavSeverity::MAV_SEVERITY_DEBUG, &t),
            }
        }
    }

    /// The earliest time after `after` at which this vehicle has something to do, given that it
    /// only acts on tick boundaries.
    pub(super) fn next_event(&self, after: Micros) -> Micros {
        let next_tick = after - after % TICK + TICK;
        if let Some(b) = &self.blocked {
            return (b.until.div_ceil(TICK) * TICK).max(next_tick);
        }
        let busy = self.logs.active()
            || self.param_send.io_pending()
            || self.airspeed_cal.is_some()
            || (self.armed && !self.landed)
            || (self.armed && self.armed_on_ground_since.is_some())
            || self.auto_busy()
            || !self.booted;
        if busy {
            return next_tick;
        }
        let mut t = self.next_heartbeat;
        if let Some(d) = self.streams.next_due() {
            t = t.min(d);
        }
        if self.param_send.busy() {
            t = t.min(self.next_param_run);
        }
        if let Some(d) = self.ftp.next_due() {
            t = t.min(d);
        }
        if let Some(d) = self.settle.next_due() {
            t = t.min(d);
        }
        if let Some(d) = self.mission.next_due() {
            t = t.min(d);
        }
        if !self.gps_fix {
            t = t.min(GPS_FIX_AT);
        }
        if !self.ekf_gps {
            t = t.min(EKF_GPS_AT);
        }
        if let Some(d) = self.cal_next_due() {
            t = t.min(d);
        }
        // Round up to a tick boundary, never before the next tick.
        let t = t.div_ceil(TICK) * TICK;
        t.max(next_tick)
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
            // (In AUTO the mission disarms: NAV_LAND on touchdown, the mission's end on the
            // ground.)
            if m == mode::LAND || m == mode::RTL || m == mode::SMART_RTL {
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
            mode::RTL => self.rtl_step(dt),
            mode::AUTO => self.auto_run(dt),
            // SmartRTL retraces its path; flown here as a straight line home, then a landing.
            mode::SMART_RTL => match self.rtl_phase {
                RtlPhase::Climb | RtlPhase::Return => {
                    if self.fly_home(dt) {
                        self.rtl_phase = RtlPhase::Descend;
                    }
                }
                RtlPhase::Descend => self.descend(dt),
            },
            m => {
                if let Some(target) = self.takeoff_target {
                    if self.alt < target {
                        self.climb_to(target, dt);
                    } else {
                        self.takeoff_target = None;
                    }
                } else if m == mode::GUIDED {
                    self.guided_run(dt);
                }
            }
        }
        if (self.vn != 0.0 || self.ve != 0.0) && !self.guided_heading_commanded() {
            self.yaw = self.ve.atan2(self.vn).to_degrees().rem_euclid(360.0);
        }
    }

    /// RTL (and RTL inside AUTO): climb to RTL_ALT, return at RTL_SPEED, land.
    pub(super) fn rtl_step(&mut self, dt: f64) {
        match self.rtl_phase {
            RtlPhase::Climb => {
                let target = self.rtl_alt();
                if self.alt < target {
                    self.climb_to(target, dt);
                } else {
                    self.rtl_phase = RtlPhase::Return;
                }
            }
            RtlPhase::Return => {
                if self.fly_home(dt) {
                    self.rtl_phase = RtlPhase::Descend;
                }
            }
            RtlPhase::Descend => self.descend(dt),
        }
    }

    /// RTL's return leg: towards home at RTL_SPEED; true once there.
    fn fly_home(&mut self, dt: f64) -> bool {
        let dist = self.north.hypot(self.east);
        let step = RTL_SPEED * dt;
        if dist <= step.max(0.05) {
            self.north = 0.0;
            self.east = 0.0;
            return true;
        }
        let (un, ue) = (-self.north / dist, -self.east / dist);
        self.north += un * step;
        self.east += ue * step;
        self.vn = un * RTL_SPEED;
        self.ve = ue * RTL_SPEED;
        false
    }

    /// Horizontal and vertical speed limits of GUIDED position control (WPNAV_SPEED,
    /// WPNAV_SPEED_UP, WPNAV_SPEED_DN, cm/s), m/s.
    pub(super) fn wpnav_speeds(&self) -> (f64, f64, f64) {
        let p = |n: &str, d: f64| (self.params.value(n).unwrap_or(d) / 100.0).clamp(0.1, 50.0);
        (
            p("WPNAV_SPEED", 1000.0),
            p("WPNAV_SPEED_UP", 250.0),
            p("WPNAV_SPEED_DN", 150.0),
        )
    }

    /// GUIDED towards a destination (north, east, up from home) in a straight line; it holds
    /// there once arrived. A destination at or below the ground is a landing.
    pub(super) fn fly_to(&mut self, target: (f64, f64, f64), dt: f64) {
        let speeds = self.nav_speeds();
        self.fly_to_at(target, speeds, dt);
    }

    /// `fly_to` at the given horizontal, up and down speeds (m/s).
    pub(super) fn fly_to_at(
        &mut self,
        (tn, te, ta): (f64, f64, f64),
        (h, up, down): (f64, f64, f64),
        dt: f64,
    ) {
        let (dn, de) = (tn - self.north, te - self.east);
        let dist = dn.hypot(de);
        let step = h * dt;
        if dist <= step.max(0.01) {
            self.north = tn;
            self.east = te;
        } else if dist > 0.0 {
            self.north += dn / dist * step;
            self.east += de / dist * step;
            self.vn = dn / dist * h;
            self.ve = de / dist * h;
        }
        let da = ta.max(0.0) - self.alt;
        let dz = if da > 0.0 {
            da.min(up * dt)
        } else {
            da.max(-down * dt)
        };
        self.alt += dz;
        self.vu = if dt > 0.0 { dz / dt } else { 0.0 };
        if self.alt <= 0.0 && ta <= 0.0 {
            self.alt = 0.0;
            self.vu = 0.0;
            self.landed = true;
            self.guided_target = None;
            self.armed_on_ground_since = Some(self.now);
        }
    }

    /// One second of `GCS_MAVLINK_InProgress::check_tasks` (it runs at most once a second):
    /// IN_PROGRESS while the airspeed calibration runs, then its result.
    fn airspeed_cal_tick(&mut self, now: Micros) {
        let Some(cal) = &mut self.airspeed_cal else {
            return;
        };
        let mut texts = Vec::new();
        if !cal.calibrated && now >= cal.started + AIRSPEED_CAL_TIME {
            cal.calibrated = true;
            texts.push("Airspeed 1 calibrated");
        }
        let (calibrated, started, to) = (cal.calibrated, cal.started, cal.to);
        for t in texts {
            self.text(MavSeverity::MAV_SEVERITY_INFO, t);
        }
        if !now.is_multiple_of(SECOND) || now <= started {
            return;
        }
        let cmd = MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION;
        if calibrated {
            self.airspeed_cal = None;
            self.push(super::telemetry::command_ack(
                cmd,
                MavResult::MAV_RESULT_ACCEPTED,
                to,
            ));
        } else {
            self.push(super::telemetry::command_ack(
                cmd,
                MavResult::MAV_RESULT_IN_PROGRESS,
                to,
            ));
        }
    }

    pub(super) fn climb_to(&mut self, target: f64, dt: f64) {
        let next = (self.alt + CLIMB_RATE * dt).min(target);
        self.vu = if dt > 0.0 {
            (next - self.alt) / dt
        } else {
            0.0
        };
        self.alt = next;
    }

    pub(super) fn descend(&mut self, dt: f64) {
        let v = self.land_speed();
        self.alt -= v * dt;
        self.vu = -v;
        if self.alt <= 0.0 {
            self.alt = 0.0;
            self.vu = 0.0;
            self.landed = true;
            self.takeoff_target = None;
            self.guided_target = None;
            self.armed_on_ground_since = Some(self.now);
        }
    }

    pub(super) fn disarm(&mut self, why: &str) {
        if self.armed {
            self.armed = false;
            self.armed_on_ground_since = None;
            self.takeoff_target = None;
            self.guided_target = None;
            self.guided_vel = None;
            self.guided_yaw = None;
            self.srtl_active = false;
            // AP_Arming_Copter::disarm resets the mission; auto-armed ends with the motors.
            self.auto.reset();
            self.auto.auto_armed = false;
            self.text(MavSeverity::MAV_SEVERITY_INFO, why);
        }
    }

    /// Enter a mode (already validated): the old mode's takeoff or destination is dropped,
    /// and ArduCopter sends a HEARTBEAT at once so the GCS sees the new mode.
    pub(super) fn enter_mode(&mut self, m: u32) {
        if m == self.custom_mode {
            return;
        }
        self.rtl_phase = if m == mode::SMART_RTL {
            RtlPhase::Return
        } else {
            RtlPhase::Climb
        };
        self.takeoff_target = None;
        self.guided_target = None;
        self.guided_vel = None;
        self.guided_yaw = None;
        if self.custom_mode == mode::AUTO {
            self.auto_exit();
        }
        // A new mode starts at the WPNAV speeds (DO_CHANGE_SPEED lasts until the mode ends).
        self.auto.speed_xy = None;
        self.auto.speed_up = None;
        self.auto.speed_down = None;
        self.custom_mode = m;
        if m == mode::AUTO {
            self.auto_enter();
        }
        let hb = self.heartbeat();
        self.push(hb);
    }

    /// Move home to the vehicle (DO_SET_HOME with "use current location").
    pub(super) fn set_home_here(&mut self) {
        let (lat, lon) = self.lat_lon();
        let amsl = self.home.2 + self.alt;
        self.set_home_at(lat, lon, amsl);
    }

    /// Move home; the vehicle stays where it is, so its home-relative position changes.
    pub(super) fn set_home_at(&mut self, lat: f64, lon: f64, amsl: f64) {
        let (vlat, vlon) = self.lat_lon();
        let vamsl = self.home.2 + self.alt;
        self.home = (lat, lon, amsl);
        (self.north, self.east) = self.ne_of(vlat, vlon);
        self.alt = vamsl - amsl;
        self.announce_home();
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
