//! AUTO: the stored mission flown as ArduCopter flies it. `AP_Mission` (which command is
//! current, DO_JUMP counting, start / resume / set-current, completion) is followed closely,
//! because that is what a GCS sees in MISSION_CURRENT, MISSION_ITEM_REACHED and the texts;
//! `ModeAuto` (what each command does to the vehicle) is a simple flight model: straight lines
//! at WPNAV_SPEED (or the DO_CHANGE_SPEED speed), climbs and descents at the sim's rates.
//!
//! What a GCS can rely on, as on ArduCopter:
//! - AUTO starts the mission when entered (`waiting_to_start`, then `start_or_resume` with
//!   MIS_RESTART); MAV_CMD_MISSION_START also switches to AUTO, sets "auto armed" (which lets
//!   a landed, armed vehicle take off) and starts or resumes the mission if it is not running.
//!   ArduCopter refuses to arm in AUTO, so a flight from the ground is: GUIDED, arm,
//!   MISSION_START. Switching to AUTO while flying resumes the mission.
//! - every command started says "Mission: N Name"; a waypoint, loiter-time or spline reached
//!   says "Reached command #N" after its delay.
//! - MISSION_ITEM_REACHED is sent for each command `ModeAuto::verify_command` completes, but
//!   it is a deferred message holding one index: when a waypoint and the DO command after it
//!   complete in the same loop only the later index goes out. So the capture's mission
//!   (takeoff, WP, DO_CHANGE_SPEED, WP, WP) reports 1, 3, 4, 5 and never 2. DO commands that
//!   `AP_Mission` verifies itself (servo, relay, camera, gripper, parachute) report nothing.
//! - the mission ends: in the air the vehicle holds where it is (AUTO's loiter), on the ground
//!   it disarms. A NAV_LAND disarms on touchdown and leaves the mission at that item; RTL
//!   flies the sim's RTL (climb to RTL_ALT, return, land) and the mission ends on the ground.
//! - disarming resets the mission to its start (the state stays, so MISSION_CURRENT shows
//!   seq 0); leaving AUTO stops a running mission (NOT_STARTED, resumed on return).
//!
//! Simplifications: no acceleration or S-curves (a waypoint is "reached" inside WPNAV_RADIUS,
//! checked in 3D), LOITER_TURNS flies to the centre and counts as reached there, terrain
//! altitudes are taken as above home (flat terrain), CONDITION_YAW turns at once.

use super::mission::{cmd, frame, MissionItem};
use super::vehicle::{mode, SimVehicle};
use crate::clock::{Micros, SECOND};
use crate::dialect::{MavMessage, MavSeverity, MissionState, MISSION_CURRENT_DATA};

/// `AP_MISSION_MAX_NUM_DO_JUMP_COMMANDS` on boards with enough memory.
const MAX_JUMP_COMMANDS: usize = 100;

/// `AP_Mission::mission_state`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RunState {
    #[default]
    Stopped,
    Running,
    Complete,
}

/// What ModeAuto is doing (`SubMode`), with its target in metres north/east/up of home.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(super) enum Sub {
    /// Hold at a point (also after the mission ends in the air).
    #[default]
    Loiter,
    Takeoff {
        alt: f64,
    },
    /// Fly to a point (waypoint, spline, loiter commands).
    Wp,
    /// NAV_LAND: fly to the point at the current altitude, then descend.
    LandFlyTo,
    LandDescend,
    Rtl,
    /// NAV_GUIDED_ENABLE: GUIDED targets steer the vehicle inside AUTO.
    NavGuided,
}

/// AP_Mission's and ModeAuto's state.
#[derive(Debug, Clone, Default)]
pub struct AutoState {
    pub(super) state: RunState,
    nav: Option<MissionItem>,
    nav_index: Option<u16>,
    nav_loaded: bool,
    do_cmd: Option<MissionItem>,
    do_index: Option<u16>,
    do_loaded: bool,
    do_all_done: bool,
    jumps: Vec<(u16, i16)>,
    pub(super) waiting_to_start: bool,
    pub(super) sub: Sub,
    /// Destination of Wp / LandFlyTo / Loiter (north, east, up from home).
    pub(super) dest: (f64, f64, f64),
    /// `wp_nav->reached_wp_destination()`.
    reached_dest: bool,
    /// When the waypoint was reached (its delay runs from then), and the delay in seconds.
    loiter_time: Option<Micros>,
    loiter_time_max: u32,
    /// NAV_DELAY / CONDITION_DELAY end, CONDITION_DISTANCE metres.
    nav_delay_until: Option<Micros>,
    condition_until: Option<Micros>,
    condition_distance: f64,
    /// DO_CHANGE_SPEED overrides (m/s): horizontal, up, down.
    pub(super) speed_xy: Option<f64>,
    pub(super) speed_up: Option<f64>,
    pub(super) speed_down: Option<f64>,
    /// `copter.ap.auto_armed`: set by MISSION_START and a user takeoff, cleared by disarming.
    pub(super) auto_armed: bool,
    /// The deferred MISSION_ITEM_REACHED (one index, the latest wins).
    reached: Option<u16>,
}

impl AutoState {
    /// `get_current_nav_index`: the current (or last) navigation command.
    pub fn nav_index(&self) -> Option<u16> {
        self.nav_index
    }

    pub fn running(&self) -> bool {
        self.state == RunState::Running
    }

    /// `AP_Mission::reset`: back to the first command, jump counters cleared.
    pub(super) fn reset(&mut self) {
        self.nav_loaded = false;
        self.do_loaded = false;
        self.do_all_done = false;
        self.nav_index = None;
        self.do_index = None;
        self.jumps.clear();
    }

    /// What `AP_Mission::clear` does besides emptying the store.
    pub(super) fn forget_commands(&mut self) {
        self.nav_index = None;
        self.do_index = None;
        self.nav_loaded = false;
        self.do_loaded = false;
    }

    /// The DO_CHANGE_SPEED horizontal speed in force (m/s), if any.
    pub fn speed_override(&self) -> Option<f64> {
        self.speed_xy
    }
}

/// `Mission_Command::type()`.
fn type_name(id: u16) -> &'static str {
    match id {
        cmd::NAV_WAYPOINT => "WP",
        cmd::NAV_SPLINE_WAYPOINT => "SplineWP",
        cmd::NAV_RETURN_TO_LAUNCH => "RTL",
        cmd::NAV_LOITER_UNLIM => "LoitUnlim",
        cmd::NAV_LOITER_TIME => "LoitTime",
        cmd::NAV_GUIDED_ENABLE => "GuidedEnable",
        cmd::NAV_LOITER_TURNS => "LoitTurns",
        cmd::NAV_LOITER_TO_ALT => "LoitAltitude",
        cmd::CONDITION_DELAY => "CondDelay",
        cmd::CONDITION_DISTANCE => "CondDist",
        cmd::DO_CHANGE_SPEED => "ChangeSpeed",
        cmd::DO_SET_HOME => "SetHome",
        cmd::DO_SET_SERVO => "SetServo",
        cmd::DO_SET_RELAY => "SetRelay",
        cmd::DO_REPEAT_SERVO => "RepeatServo",
        cmd::DO_REPEAT_RELAY => "RepeatRelay",
        cmd::DO_DIGICAM_CONTROL => "DigiCamCtrl",
        cmd::DO_SET_CAM_TRIGG_DIST => "SetCamTrigDst",
        cmd::DO_SET_ROI => "SetROI",
        cmd::DO_GUIDED_LIMITS => "GuidedLimits",
        cmd::NAV_TAKEOFF => "Takeoff",
        cmd::NAV_LAND => "Land",
        cmd::NAV_CONTINUE_AND_CHANGE_ALT => "ContinueAndChangeAlt",
        cmd::DO_INVERTED_FLIGHT => "InvertedFlight",
        cmd::DO_FENCE_ENABLE => "FenceEnable",
        cmd::CONDITION_YAW => "CondYaw",
        cmd::DO_LAND_START => "LandStart",
        cmd::NAV_DELAY => "Delay",
        cmd::DO_GRIPPER => "Gripper",
        cmd::DO_PARACHUTE => "Parachute",
        cmd::DO_MOUNT_CONTROL => "MountControl",
        cmd::DO_JUMP => "Jump",
        cmd::DO_GO_AROUND => "Go Around",
        _ => "?",
    }
}

/// `AP_Mission::is_nav_cmd`.
fn is_nav(c: &MissionItem) -> bool {
    c.command <= cmd::NAV_LAST
}

/// DO commands `AP_Mission::verify_command` completes itself, without MISSION_ITEM_REACHED.
fn verified_by_mission(id: u16) -> bool {
    matches!(
        id,
        cmd::DO_GRIPPER
            | cmd::DO_SET_SERVO
            | cmd::DO_SET_RELAY
            | cmd::DO_REPEAT_SERVO
            | cmd::DO_REPEAT_RELAY
            | cmd::DO_DIGICAM_CONTROL
            | cmd::DO_SET_CAM_TRIGG_DIST
            | cmd::DO_PARACHUTE
    )
}

impl SimVehicle {
    /// Whether the stored mission is stopped (not started), running or complete.
    pub fn mission_run_state(&self) -> RunState {
        self.auto.state
    }

    /// The mission's current (or last) navigation command, as MISSION_CURRENT reports it.
    pub fn mission_current_seq(&self) -> Option<u16> {
        self.auto.nav_index
    }

    /// North/east of home (metres) of a latitude/longitude in degrees (flat earth).
    pub(super) fn ne_of(&self, lat: f64, lon: f64) -> (f64, f64) {
        let north = (lat - self.home.0) * 111_319.5;
        let east = (lon - self.home.1) * 111_319.5 * self.home.0.to_radians().cos();
        (north, east)
    }

    /// Metres above home of an altitude in `frame` (terrain taken as level with home).
    pub(super) fn up_of(&self, frame_id: u8, z: f64) -> f64 {
        match frame_id {
            frame::GLOBAL | frame::GLOBAL_INT | frame::MISSION => z - self.home.2,
            _ => z,
        }
    }

    /// MISSION_CURRENT: the current navigation command (or `seq` when answering
    /// MISSION_SET_CURRENT), the item count without home, the mission state, and whether the
    /// mode flies the mission. The id fields stay 0, as ArduCopter 4.7 sends them.
    pub(super) fn mission_current(&self, seq: Option<u16>) -> MavMessage {
        let n = self.mission.mission.len();
        let state = if n <= 1 {
            MissionState::MISSION_STATE_NO_MISSION
        } else {
            match self.auto.state {
                RunState::Stopped => MissionState::MISSION_STATE_NOT_STARTED,
                RunState::Running => MissionState::MISSION_STATE_ACTIVE,
                RunState::Complete => MissionState::MISSION_STATE_COMPLETE,
            }
        };
        MavMessage::MISSION_CURRENT(MISSION_CURRENT_DATA {
            seq: seq.unwrap_or(self.auto.nav_index.unwrap_or(0)),
            total: n.saturating_sub(1).min(u16::MAX as usize) as u16,
            mission_state: state,
            mission_mode: (self.custom_mode == mode::AUTO) as u8,
            mission_id: 0,
            fence_id: 0,
            rally_points_id: 0,
        })
    }

    /// `ModeAuto::init`: a mission (unless disarmed), and a takeoff first when armed on the
    /// ground.
    pub(super) fn auto_init(&mut self, ignore_checks: bool) -> bool {
        if !(self.mission.mission.len() > 1 || ignore_checks) {
            return false;
        }
        if self.armed && self.landed && !self.starts_with_takeoff() {
            self.text(
                MavSeverity::MAV_SEVERITY_CRITICAL,
                "Auto: Missing Takeoff Cmd",
            );
            return false;
        }
        true
    }

    /// Entering AUTO (after init succeeded): hold, and start the mission on the next run.
    pub(super) fn auto_enter(&mut self) {
        self.auto.sub = Sub::Loiter;
        self.auto.dest = (self.north, self.east, self.alt);
        self.auto.waiting_to_start = true;
        self.auto.speed_xy = None;
        self.auto.speed_up = None;
        self.auto.speed_down = None;
    }

    /// `ModeAuto::exit`: a running mission stops.
    pub(super) fn auto_exit(&mut self) {
        if self.auto.state == RunState::Running {
            self.auto.state = RunState::Stopped;
        }
    }

    /// `AP_Mission::starts_with_takeoff_cmd`.
    fn starts_with_takeoff(&mut self) -> bool {
        let restart = self.params.value("MIS_RESTART").unwrap_or(0.0) != 0.0;
        let mut i = if restart {
            1
        } else {
            self.auto.nav_index.unwrap_or(1)
        };
        for _ in 0..16 {
            let Some(c) = self.next_nav_cmd(i) else {
                return false;
            };
            match c.command {
                cmd::NAV_TAKEOFF => return true,
                cmd::NAV_DELAY => i = c.seq + 1,
                _ => return false,
            }
        }
        false
    }

    /// `get_next_nav_cmd`: the first navigation command at or after `start` (jumps followed,
    /// not counted).
    fn next_nav_cmd(&mut self, start: u16) -> Option<MissionItem> {
        let mut i = start;
        while (i as usize) < self.mission.mission.len() {
            let c = self.next_cmd(i, false)?;
            if is_nav(&c) {
                return Some(c);
            }
            i = c.seq + 1;
        }
        None
    }

    fn jump_times_run(&mut self, c: &MissionItem) -> i16 {
        if let Some((_, n)) = self.auto.jumps.iter().find(|(i, _)| *i == c.seq) {
            return *n;
        }
        if self.auto.jumps.len() < MAX_JUMP_COMMANDS {
            self.auto.jumps.push((c.seq, 0));
            return 0;
        }
        i16::MAX
    }

    /// `AP_Mission::get_next_cmd`: the first command at or after `start` that is not a
    /// DO_JUMP, following jumps (counting them when `count`).
    fn next_cmd(&mut self, start: u16, count: bool) -> Option<MissionItem> {
        let total = self.mission.mission.len();
        let mut i = start as usize;
        let mut jump_index: Option<usize> = None;
        let mut max_loops = 64;
        while i < total {
            let c = self.mission.mission[i];
            if c.command != cmd::DO_JUMP {
                let mut c = c;
                c.seq = i as u16;
                return Some(c);
            }
            if max_loops == 0 {
                return None;
            }
            max_loops -= 1;
            let target = c.params[0] as usize;
            let times = c.params[1] as i16;
            if target >= total || target == 0 {
                return None;
            }
            if !count && jump_index == Some(i) {
                return None;
            }
            jump_index.get_or_insert(i);
            let mut jc = c;
            jc.seq = i as u16;
            if times == -1 {
                i = target;
            } else {
                let run = self.jump_times_run(&jc);
                if run < times {
                    if count {
                        if let Some(e) = self.auto.jumps.iter_mut().find(|(j, _)| *j == jc.seq) {
                            e.1 += 1;
                            let t = format!("Mission: {} Jump {}/{}", jc.seq, e.1, times);
                            self.text(MavSeverity::MAV_SEVERITY_INFO, &t);
                        }
                    }
                    i = target;
                } else {
                    i += 1;
                }
            }
        }
        None
    }

    /// `AP_Mission::start`.
    fn mission_start(&mut self) {
        self.auto.state = RunState::Running;
        self.auto.reset();
        if !self.advance_nav(None) {
            self.mission_complete();
        }
    }

    /// `AP_Mission::resume`.
    fn mission_resume(&mut self) {
        match self.auto.state {
            RunState::Complete => return self.mission_start(),
            RunState::Stopped => {
                self.auto.state = RunState::Running;
                if self.auto.nav_index.is_none() {
                    return self.mission_start();
                }
            }
            RunState::Running => {}
        }
        let Some(nav) = self.auto.nav_index else {
            return self.mission_start();
        };
        if nav as usize >= self.mission.mission.len() {
            return self.mission_start();
        }
        if self.auto.do_loaded {
            if let Some(d) = self.auto.do_index {
                self.set_current_cmd(d);
                return;
            }
        }
        if self.auto.nav_loaded {
            self.set_current_cmd(nav);
        }
    }

    /// `AP_Mission::start_or_resume` (MIS_RESTART).
    pub(super) fn mission_start_or_resume(&mut self) {
        if self.params.value("MIS_RESTART").unwrap_or(0.0) != 0.0 {
            self.mission_start();
        } else {
            self.mission_resume();
        }
    }

    /// `AP_Mission::set_current_cmd` (MISSION_SET_CURRENT, DO_SET_MISSION_CURRENT).
    pub(super) fn set_current_cmd(&mut self, index: u16) -> bool {
        let total = self.mission.mission.len();
        if index as usize >= total || total == 1 {
            return false;
        }
        let mut index = index;
        self.auto.do_index = None;
        self.auto.do_loaded = false;
        self.auto.do_all_done = false;
        self.auto.nav_loaded = false;
        if index == 0 || self.auto.state == RunState::Complete {
            self.auto.jumps.clear();
            if index == 0 {
                index = 1;
            }
        }
        if self.auto.state != RunState::Running {
            // Move the current command without starting anything; a resume starts there.
            while !self.auto.nav_loaded {
                let Some(c) = self.next_cmd(index, true) else {
                    self.auto.nav_index = None;
                    return false;
                };
                if is_nav(&c) {
                    self.auto.nav = Some(c);
                    self.auto.nav_index = Some(c.seq);
                    self.auto.nav_loaded = true;
                } else if !self.auto.do_loaded {
                    self.auto.do_cmd = Some(c);
                    self.auto.do_index = Some(c.seq);
                    self.auto.do_loaded = true;
                }
                index = c.seq + 1;
            }
            if !self.auto.do_loaded {
                self.auto.do_all_done = true;
            }
            self.auto.state = RunState::Stopped;
            return true;
        }
        if !self.advance_nav(Some(index)) {
            self.mission_complete();
            return false;
        }
        true
    }

    /// `AP_Mission::advance_current_nav_cmd`.
    fn advance_nav(&mut self, starting: Option<u16>) -> bool {
        if self.auto.state != RunState::Running || self.auto.nav_loaded {
            return false;
        }
        self.auto.do_index = None;
        self.auto.do_loaded = false;
        self.auto.do_all_done = false;
        let mut i = match starting {
            Some(s) if s > 0 => s,
            _ => self.auto.nav_index.map_or(1, |n| n + 1),
        };
        let mut loops = 255;
        while !self.auto.nav_loaded {
            if loops == 0 {
                return false;
            }
            loops -= 1;
            let Some(c) = self.next_cmd(i, true) else {
                return false;
            };
            if is_nav(&c) {
                self.auto.nav = Some(c);
                self.auto.nav_index = Some(c.seq);
                if self.start_command(&c) {
                    self.auto.nav_loaded = true;
                }
            } else if !self.auto.do_loaded {
                self.auto.do_cmd = Some(c);
                self.auto.do_index = Some(c.seq);
                self.auto.do_loaded = true;
                self.start_command(&c);
            }
            i = c.seq + 1;
        }
        if !self.auto.do_loaded {
            self.auto.do_all_done = true;
        }
        true
    }

    /// `AP_Mission::advance_current_do_cmd`.
    fn advance_do(&mut self) {
        if self.auto.state != RunState::Running || self.auto.do_all_done {
            return;
        }
        let start = self.auto.do_index.map_or(1, |d| d + 1);
        let next = if (start as usize) < self.mission.mission.len() {
            self.next_cmd(start, false).filter(|c| !is_nav(c))
        } else {
            None
        };
        match next {
            Some(c) => {
                self.auto.do_cmd = Some(c);
                self.auto.do_index = Some(c.seq);
                self.auto.do_loaded = true;
                self.start_command(&c);
            }
            None => self.auto.do_all_done = true,
        }
    }

    /// `AP_Mission::complete` and `ModeAuto::exit_mission`.
    fn mission_complete(&mut self) {
        self.auto.state = RunState::Complete;
        if self.custom_mode != mode::AUTO {
            return;
        }
        if !self.landed {
            self.auto.sub = Sub::Loiter;
            self.auto.dest = (self.north, self.east, self.alt);
        } else {
            self.disarm("Disarming motors");
        }
    }

    /// `AP_Mission::update`, run by ModeAuto every loop.
    fn mission_update(&mut self) {
        if self.auto.state != RunState::Running || self.mission.mission.is_empty() {
            return;
        }
        if !self.auto.nav_loaded || self.auto.nav_index.is_none() {
            if !self.advance_nav(None) {
                self.mission_complete();
                return;
            }
        } else if let Some(nav) = self.auto.nav {
            if self.verify_command(&nav) {
                self.auto.nav_loaded = false;
                if !self.advance_nav(None) {
                    self.mission_complete();
                    return;
                }
            }
        }
        if !self.auto.do_loaded {
            self.advance_do();
        } else if let Some(d) = self.auto.do_cmd {
            if self.verify_command(&d) {
                self.auto.do_loaded = false;
            }
        }
    }

    /// A command's location as north/east/up of home; zero lat/lon or altitude take the
    /// default's (`ModeAuto::loc_from_cmd`).
    fn loc_from_cmd(&self, c: &MissionItem, default: (f64, f64, f64)) -> (f64, f64, f64) {
        let (mut n, mut e) = (default.0, default.1);
        if !(c.x == 0 && c.y == 0) {
            let (lat, lon) = c.lat_lon();
            (n, e) = self.ne_of(lat, lon);
        }
        let up = if c.z == 0.0 {
            default.2
        } else {
            self.up_of(c.frame, c.z as f64)
        };
        (n, e, up)
    }

    /// Where a new waypoint defaults to: the last destination once reached, else here.
    fn default_loc(&self) -> (f64, f64, f64) {
        if matches!(self.auto.sub, Sub::Wp) && self.auto.reached_dest {
            self.auto.dest
        } else {
            (self.north, self.east, self.alt)
        }
    }

    fn wp_start(&mut self, dest: (f64, f64, f64)) {
        self.auto.sub = Sub::Wp;
        self.auto.dest = dest;
        self.auto.reached_dest = false;
        self.auto.loiter_time = None;
    }

    /// `AP_Mission::start_command` and `ModeAuto::start_command`: false for a command AUTO
    /// cannot run (a navigation command like that is skipped).
    fn start_command(&mut self, c: &MissionItem) -> bool {
        let t = format!("Mission: {} {}", c.seq, type_name(c.command));
        self.text(MavSeverity::MAV_SEVERITY_INFO, &t);
        if verified_by_mission(c.command) {
            return true;
        }
        let [p1, p2, _, _] = c.params;
        match c.command {
            cmd::NAV_TAKEOFF => {
                // Above home: the command's altitude, at least 1 m above the ground if landed.
                let target = self.up_of(c.frame, c.z as f64);
                let min = self.alt + if self.landed { 1.0 } else { 0.0 };
                self.auto.sub = Sub::Takeoff {
                    alt: target.max(min),
                };
            }
            cmd::NAV_WAYPOINT
            | cmd::NAV_SPLINE_WAYPOINT
            | cmd::NAV_LOITER_TIME
            | cmd::NAV_LOITER_UNLIM
            | cmd::NAV_LOITER_TURNS
            | cmd::NAV_LOITER_TO_ALT => {
                let dest = self.loc_from_cmd(c, self.default_loc());
                self.wp_start(dest);
                self.auto.loiter_time_max = match c.command {
                    cmd::NAV_WAYPOINT | cmd::NAV_SPLINE_WAYPOINT | cmd::NAV_LOITER_TIME => {
                        p1 as u32
                    }
                    _ => 0,
                };
            }
            cmd::NAV_LAND => {
                if c.x != 0 || c.y != 0 {
                    let (n, e) = self.ne_of(c.lat_lon().0, c.lat_lon().1);
                    self.auto.sub = Sub::LandFlyTo;
                    self.auto.dest = (n, e, self.alt);
                    self.auto.reached_dest = false;
                } else {
                    self.auto.sub = Sub::LandDescend;
                }
            }
            cmd::NAV_RETURN_TO_LAUNCH => {
                self.auto.sub = Sub::Rtl;
                self.rtl_phase = super::vehicle::RtlPhase::Climb;
            }
            cmd::NAV_GUIDED_ENABLE => {
                if p1 > 0.0 {
                    self.auto.sub = Sub::NavGuided;
                    self.guided_target = None;
                    self.guided_vel = None;
                }
            }
            cmd::NAV_DELAY => {
                let secs = p1.max(0.0) as u64;
                self.auto.nav_delay_until = Some(self.now + secs * SECOND);
                self.text(
                    MavSeverity::MAV_SEVERITY_INFO,
                    &format!("Delaying {secs} sec"),
                );
            }
            cmd::CONDITION_DELAY => {
                self.auto.condition_until = Some(self.now + (p1.max(0.0) as f64 * 1e6) as Micros);
            }
            cmd::CONDITION_DISTANCE => self.auto.condition_distance = p1 as f64,
            cmd::CONDITION_YAW => {
                let angle = p1 as f64;
                self.yaw = if c.params[3] > 0.0 {
                    let dir = if c.params[2] < 0.0 { -1.0 } else { 1.0 };
                    (self.yaw + dir * angle).rem_euclid(360.0)
                } else {
                    angle.rem_euclid(360.0)
                };
            }
            cmd::DO_CHANGE_SPEED => {
                if p2 > 0.0 {
                    match p1 as u8 {
                        2 => self.auto.speed_up = Some(p2 as f64),
                        3 => self.auto.speed_down = Some(p2 as f64),
                        _ => self.auto.speed_xy = Some(p2 as f64),
                    }
                }
            }
            cmd::DO_SET_HOME => {
                if p1 == 1.0 || (c.x == 0 && c.y == 0 && c.z == 0.0) {
                    self.set_home_here();
                } else {
                    let (lat, lon) = c.lat_lon();
                    let amsl = match c.frame {
                        frame::GLOBAL => c.z as f64,
                        _ => self.home.2 + c.z as f64,
                    };
                    self.set_home_at(lat, lon, amsl);
                }
            }
            cmd::DO_SET_ROI
            | cmd::DO_MOUNT_CONTROL
            | cmd::DO_GUIDED_LIMITS
            | cmd::DO_LAND_START => {}
            _ => return false,
        }
        true
    }

    /// `ModeAuto::verify_command` (and AP_Mission's own do-command verification): true when
    /// the command is done; sets the deferred MISSION_ITEM_REACHED.
    fn verify_command(&mut self, c: &MissionItem) -> bool {
        if verified_by_mission(c.command) {
            return true;
        }
        if self.custom_mode != mode::AUTO {
            return false;
        }
        let done = match c.command {
            cmd::NAV_TAKEOFF => match self.auto.sub {
                Sub::Takeoff { alt } => !self.landed && self.alt >= alt - 0.01,
                _ => true,
            },
            cmd::NAV_WAYPOINT | cmd::NAV_SPLINE_WAYPOINT | cmd::NAV_LOITER_TIME => {
                self.verify_wp(c)
            }
            cmd::NAV_LOITER_TURNS | cmd::NAV_LOITER_TO_ALT => self.auto.reached_dest,
            cmd::NAV_LOITER_UNLIM => false,
            cmd::NAV_LAND => {
                if self.auto.sub == Sub::LandFlyTo && self.auto.reached_dest {
                    self.auto.sub = Sub::LandDescend;
                }
                if self.auto.sub == Sub::LandDescend && self.landed && self.armed {
                    // Stop the mission on this item: disarm, which resets it.
                    self.disarm("Disarming motors");
                }
                false
            }
            cmd::NAV_RETURN_TO_LAUNCH => self.landed,
            cmd::NAV_GUIDED_ENABLE => c.params[0] <= 0.0,
            cmd::NAV_DELAY => match self.auto.nav_delay_until {
                Some(t) if self.now > t => {
                    self.auto.nav_delay_until = None;
                    true
                }
                None => true,
                _ => false,
            },
            cmd::CONDITION_DELAY => match self.auto.condition_until {
                Some(t) if self.now > t => {
                    self.auto.condition_until = None;
                    true
                }
                None => true,
                _ => false,
            },
            cmd::CONDITION_DISTANCE => {
                let (n, e, _) = self.auto.dest;
                if (n - self.north).hypot(e - self.east) < self.auto.condition_distance.max(0.0) {
                    self.auto.condition_distance = 0.0;
                    true
                } else {
                    false
                }
            }
            cmd::CONDITION_YAW
            | cmd::DO_CHANGE_SPEED
            | cmd::DO_SET_HOME
            | cmd::DO_SET_ROI
            | cmd::DO_MOUNT_CONTROL
            | cmd::DO_GUIDED_LIMITS
            | cmd::DO_FENCE_ENABLE
            | cmd::DO_LAND_START => true,
            other => {
                self.text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    &format!("Skipping invalid cmd #{other}"),
                );
                true
            }
        };
        if done {
            self.auto.reached = Some(c.seq);
        }
        done
    }

    /// `verify_nav_wp` / `verify_loiter_time`: reached, then the delay in whole seconds.
    fn verify_wp(&mut self, c: &MissionItem) -> bool {
        if !self.auto.reached_dest {
            return false;
        }
        let since = *self.auto.loiter_time.get_or_insert(self.now);
        if (self.now - since) / SECOND >= self.auto.loiter_time_max as u64 {
            self.text(
                MavSeverity::MAV_SEVERITY_INFO,
                &format!("Reached command #{}", c.seq),
            );
            return true;
        }
        false
    }

    /// ModeAuto::run's mission part, each loop in AUTO: start a waiting mission once the EKF
    /// has an origin, else advance it. The deferred MISSION_ITEM_REACHED goes out ahead of the
    /// loop's texts (texts are queued, the message is sent from the deferred queue first).
    pub(super) fn auto_update(&mut self) {
        if self.custom_mode != mode::AUTO {
            return;
        }
        let mark = self.out.len();
        if self.auto.waiting_to_start {
            if self.ekf_gps {
                self.mission_start_or_resume();
                self.auto.waiting_to_start = false;
            }
        } else {
            self.mission_update();
        }
        // auto_takeoff.run: an armed vehicle on the ground lifts off once auto armed.
        if matches!(self.auto.sub, Sub::Takeoff { .. })
            && self.armed
            && self.landed
            && self.auto.auto_armed
        {
            self.landed = false;
            self.armed_on_ground_since = None;
        }
        if let Some(seq) = self.auto.reached.take() {
            self.out.insert(mark, super::mission::reached_out(seq));
        }
    }

    /// Horizontal, up and down speeds of AUTO and GUIDED (WPNAV_* or DO_CHANGE_SPEED), m/s.
    pub(super) fn nav_speeds(&self) -> (f64, f64, f64) {
        let (h, up, down) = self.wpnav_speeds();
        (
            self.auto.speed_xy.unwrap_or(h),
            self.auto.speed_up.unwrap_or(up),
            self.auto.speed_down.unwrap_or(down),
        )
    }

    /// WPNAV_RADIUS in metres (at least 5 cm).
    fn wp_radius(&self) -> f64 {
        (self.params.value("WPNAV_RADIUS").unwrap_or(200.0) / 100.0).max(0.05)
    }

    /// AUTO's flight model for `dt` seconds (armed and in the air).
    pub(super) fn auto_run(&mut self, dt: f64) {
        match self.auto.sub {
            Sub::Takeoff { alt } => {
                if self.alt < alt {
                    self.climb_to(alt, dt);
                }
            }
            Sub::Wp | Sub::LandFlyTo | Sub::Loiter => {
                let speeds = self.nav_speeds();
                self.fly_to_at(self.auto.dest, speeds, dt);
                let (n, e, u) = self.auto.dest;
                let d = (n - self.north)
                    .hypot(e - self.east)
                    .hypot(u.max(0.0) - self.alt);
                if d <= self.wp_radius() {
                    self.auto.reached_dest = true;
                }
            }
            Sub::LandDescend => self.descend(dt),
            Sub::Rtl => self.rtl_step(dt),
            Sub::NavGuided => self.guided_run(dt),
        }
    }

    /// True when AUTO has something to do on every tick.
    pub(super) fn auto_busy(&self) -> bool {
        self.custom_mode == mode::AUTO
            && (self.auto.waiting_to_start || (self.auto.state == RunState::Running && self.armed))
    }
}
