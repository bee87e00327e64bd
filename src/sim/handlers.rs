//! What a vehicle does with each message from the GCS: parameters, streams, MAVFTP, modes and
//! commands (COMMAND_LONG / COMMAND_INT → COMMAND_ACK), following ArduCopter's behaviour.
//!
//! ArduPilot sends a command's COMMAND_ACK as soon as the handler returns, and the STATUSTEXTs
//! the handler wrote go out later from its text queue: a refusal is ACK first, then its reason
//! (the real capture shows `COMMAND_ACK 400 FAILED` then `Arm: ...`). So does the simulator.

use super::mavftp::Request as FtpRequest;
use super::streams::{self, id, DEFAULT_INTERVAL};
use super::telemetry::{param_value_notify, raw_command_ack};
use super::vehicle::{
    mode, AirspeedCal, Blocked, Inbound, LastCommand, SimVehicle, ACCEL_CAL_TIME, GYRO_CAL_TIME,
};
use crate::clock::Micros;
use crate::dialect::*;

/// ArduPilot's magic param2 that skips arming checks / allows disarm in flight.
pub const FORCE_MAGIC: f32 = 21196.0;
/// ArduPilot's other magic param2: force arming (but not disarming).
pub const FORCE_ARM_MAGIC: f32 = 2989.0;
/// Message id of SET_MODE, which ArduPilot puts in the `command` of the ACK it answers with.
#[allow(deprecated)] // superseded by MAV_CMD_DO_SET_MODE, still sent by GCSs
const SET_MODE_ID: u16 = <SET_MODE_DATA as mavlink::MessageData>::ID as u16;
/// MAV_MODE_FLAG_CUSTOM_MODE_ENABLED and MAV_MODE_FLAG_DECODE_POSITION_SAFETY.
const CUSTOM_MODE_ENABLED: u32 = 1;
const DECODE_POSITION_SAFETY: u32 = 128;
/// MAV_DO_REPOSITION_FLAGS_CHANGE_MODE.
const REPOSITION_CHANGE_MODE: i32 = 1;
/// ArduPilot's LOCATION_ALT_MAX_M: altitudes a Location can hold.
const LOCATION_ALT_MAX_M: f32 = 83_000.0;

/// A COMMAND_LONG or COMMAND_INT reduced to what the handler needs.
#[derive(Debug, Clone)]
pub(super) struct Command {
    pub command: MavCmd,
    /// param1..param7 (COMMAND_INT x, y as numbers, z as param7).
    pub p: [f32; 7],
    /// COMMAND_INT's frame, x and y as sent; `None` for COMMAND_LONG.
    pub int: Option<(MavFrame, i32, i32)>,
    pub confirmation: u8,
    pub from: (u8, u8),
}

impl Command {
    /// x and y as ArduPilot's COMMAND_LONG → COMMAND_INT conversion gives them for a command
    /// that carries no location: param5 and param6 truncated to integers.
    fn xy(&self) -> (i32, i32) {
        match self.int {
            Some((_, x, y)) => (x, y),
            None => (f32_as_i32(self.p[4]), f32_as_i32(self.p[5])),
        }
    }
}

/// A PARAM_* name field: up to 16 bytes, ended by the first NUL.
fn param_name(b: &[u8]) -> String {
    let n = b.iter().position(|&c| c == 0).unwrap_or(b.len()).min(16);
    String::from_utf8_lossy(&b[..n]).into_owned()
}

fn f32_as_i32(v: f32) -> i32 {
    if v.is_nan() {
        0
    } else {
        v as i32
    }
}

/// A C cast of a float parameter to an unsigned integer (NaN and negatives give 0).
fn f32_as_u32(v: f32) -> u32 {
    if v.is_nan() {
        0
    } else {
        v as u32
    }
}

impl SimVehicle {
    pub(super) fn for_me(&self, target_system: u8, target_component: u8) -> bool {
        (target_system == 0 || target_system == self.sysid)
            && (target_component == 0 || target_component == self.compid)
    }

    /// Handle one decoded message from `from` (sysid, compid) at `now`.
    // REQUEST_DATA_STREAM, SET_MODE and GET_MESSAGE_INTERVAL are deprecated in MAVLink but
    // ArduPilot and most GCSs still use them.
    #[allow(deprecated)]
    pub(super) fn handle(&mut self, now: Micros, from: (u8, u8), msg: &MavMessage) {
        if self.blocked.is_some() {
            // A synchronous calibration holds the main loop: read it afterwards.
            self.queued_in
                .push_back((from, Inbound::Msg(Box::new(msg.clone()))));
            return;
        }
        self.now = now;
        match msg {
            MavMessage::PARAM_REQUEST_LIST(m)
                if self.for_me(m.target_system, m.target_component) =>
            {
                // ArduPilot resends its banner so a GCS that connects late still sees it.
                self.banner();
                self.param_send.request_list(now, &self.params);
            }
            // handle_param_request_read: queued, answered from the parameter send schedule.
            MavMessage::PARAM_REQUEST_READ(m)
                if self.for_me(m.target_system, m.target_component) =>
            {
                let name = param_name(&m.param_id[..]);
                self.param_send.request_read(m.param_index, name);
            }
            MavMessage::PARAM_SET(m) if self.for_me(m.target_system, m.target_component) => {
                self.param_set(&param_name(&m.param_id[..]), m.param_value);
            }
            MavMessage::REQUEST_DATA_STREAM(m)
                if self.for_me(m.target_system, m.target_component) =>
            {
                self.streams.request_stream(
                    now,
                    m.req_stream_id as u8,
                    m.req_message_rate,
                    m.start_stop != 0,
                );
            }
            // GCS_MAVLINK::handle_set_mode: the same checks as DO_SET_MODE, acknowledged with a
            // COMMAND_ACK whose command is SET_MODE's message id, 11.
            MavMessage::SET_MODE(m) if m.target_system == self.sysid => {
                let mark = self.out.len();
                let result = self.set_mode_common(m.base_mode.bits() as u32, m.custom_mode);
                let texts = self.out.split_off(mark);
                self.out.push(raw_command_ack(SET_MODE_ID, result, from));
                self.out.extend(texts);
            }
            // A build without MAVFTP has no handler: the message is ignored.
            MavMessage::FILE_TRANSFER_PROTOCOL(m)
                if self.ftp_built && self.for_me(m.target_system, m.target_component) =>
            {
                if !self.ftp_enabled() {
                    // GCS_MAVLINK::ftp_init with BRD_OPTIONS DISABLE_FTP: no worker, every
                    // request dropped with this warning.
                    self.text(
                        MavSeverity::MAV_SEVERITY_WARNING,
                        "failed to initialize MAVFTP",
                    );
                    return;
                }
                let out = self
                    .ftp
                    .receive(now, FtpRequest::parse(from, &m.payload), &self.params);
                self.ftp_out(out);
            }
            MavMessage::COMMAND_LONG(m) if self.for_me(m.target_system, m.target_component) => {
                if self.take_drop(m.command as u16) {
                    return;
                }
                let cmd = Command {
                    command: m.command,
                    p: [
                        m.param1, m.param2, m.param3, m.param4, m.param5, m.param6, m.param7,
                    ],
                    int: None,
                    confirmation: m.confirmation,
                    from,
                };
                self.command(now, cmd);
            }
            MavMessage::COMMAND_INT(m) if self.for_me(m.target_system, m.target_component) => {
                if self.take_drop(m.command as u16) {
                    return;
                }
                let cmd = Command {
                    command: m.command,
                    p: [
                        m.param1, m.param2, m.param3, m.param4, m.x as f32, m.y as f32, m.z,
                    ],
                    int: Some((m.frame, m.x, m.y)),
                    confirmation: 0,
                    from,
                };
                self.command(now, cmd);
            }
            MavMessage::SET_POSITION_TARGET_LOCAL_NED(m) => self.set_position_target_local_ned(m),
            MavMessage::SET_POSITION_TARGET_GLOBAL_INT(m) => self.set_position_target_global_int(m),
            MavMessage::LOG_REQUEST_LIST(m) if self.for_me(m.target_system, m.target_component) => {
                self.log_message(msg)
            }
            MavMessage::LOG_REQUEST_DATA(m) if self.for_me(m.target_system, m.target_component) => {
                self.log_message(msg)
            }
            MavMessage::LOG_ERASE(m) if self.for_me(m.target_system, m.target_component) => {
                self.log_message(msg)
            }
            MavMessage::LOG_REQUEST_END(m) if self.for_me(m.target_system, m.target_component) => {
                self.log_message(msg)
            }
            // ArduPilot has no handler for COMMAND_CANCEL (GCS_MAVLINK::handle_message has no
            // case for it): it is ignored, nothing is cancelled, nothing is acknowledged.
            MavMessage::COMMAND_CANCEL(_) => {}
            _ => {}
        }
    }

    /// `AP_Logger::handle_log_message`: refused while armed, with the reason once.
    fn log_message(&mut self, msg: &MavMessage) {
        if let Err(text) = self.logs.handle(self.armed, msg) {
            let sev = if text.starts_with("Disarm") {
                MavSeverity::MAV_SEVERITY_ERROR
            } else {
                MavSeverity::MAV_SEVERITY_INFO
            };
            self.text(sev, text);
        }
    }

    /// A message handled from its raw payload (the mission protocol, see `mission.rs`).
    pub(super) fn handle_raw(&mut self, now: Micros, from: (u8, u8), msgid: u32, payload: &[u8]) {
        if self.blocked.is_some() {
            let payload = payload.to_vec();
            self.queued_in
                .push_back((from, Inbound::Raw { msgid, payload }));
            return;
        }
        self.mission_message(now, from, msgid, payload);
    }

    /// GCS_MAVLINK::handle_param_set: an unknown name, NaN or infinity is ignored (nothing is
    /// sent). A parameter MAVLink may not set (`allow_set_via_mavlink`) stays as it is; the
    /// refusal sends its current value to this GCS (index -1) and warns "Param write denied".
    /// Otherwise the value is set (`set_float`) and saved, and saving notifies every GCS with
    /// PARAM_VALUE index -1 carrying the value as stored, changed or not.
    fn param_set(&mut self, name: &str, value: f32) {
        let Some(i) = self.params.index_of(name) else {
            return;
        };
        if !value.is_finite() {
            return;
        }
        let internal = self.params.get(i).is_some_and(|p| p.internal);
        let options = self.params.value("BRD_OPTIONS").unwrap_or(0.0) as i64 as u32;
        if internal && options & super::vehicle::BRD_OPTION_ALLOW_SET_INTERNAL_PARM == 0 {
            self.push(param_value_notify(&self.params, i));
            self.text(
                MavSeverity::MAV_SEVERITY_WARNING,
                &format!("Param write denied ({name})"),
            );
            return;
        }
        self.params.set(name, value as f64);
        self.push(param_value_notify(&self.params, i));
        self.save_params();
    }

    fn command(&mut self, now: Micros, cmd: Command) {
        let key: [u32; 7] = cmd.p.map(f32::to_bits);
        let command_id = cmd.command as u16;
        if cmd.confirmation > 0 {
            if let Some(last) = &self.last_command {
                if last.from == cmd.from
                    && last.command == command_id
                    && last.params == key
                    && now.saturating_sub(last.at) <= super::vehicle::RETRANSMIT_WINDOW
                {
                    // A retransmission: our ACK was lost. Acknowledge again, do not repeat.
                    let result = last.result;
                    self.ack(cmd.command, result, cmd.from);
                    return;
                }
            }
        }
        let mark = self.out.len();
        let mut after = Vec::new();
        let result = self.execute(&cmd, &mut after);
        let mut then = self.out.split_off(mark);
        then.extend(after.into_iter().map(super::vehicle::Out::Msg));
        // Sent by the handler itself, before its ACK (PARAM_VALUE notifications).
        let immediate = std::mem::take(&mut self.immediate);
        self.out.extend(immediate);
        match &mut self.blocked {
            // A synchronous calibration: the ACK comes when it is over.
            Some(b) => b.then.extend(then),
            None => {
                self.ack(cmd.command, result, cmd.from);
                self.out.extend(then);
            }
        }
        self.last_command = Some(LastCommand {
            from: cmd.from,
            command: command_id,
            params: key,
            result,
            at: now,
        });
    }

    #[allow(deprecated)]
    fn execute(&mut self, cmd: &Command, after: &mut Vec<MavMessage>) -> MavResult {
        use MavResult::*;
        let p = cmd.p;
        let ok = |b: bool| {
            if b {
                MAV_RESULT_ACCEPTED
            } else {
                MAV_RESULT_FAILED
            }
        };
        match cmd.command {
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM => {
                if p[0] == 1.0 {
                    self.arm(p[1])
                } else if p[0] == 0.0 {
                    if !self.armed {
                        return MAV_RESULT_ACCEPTED;
                    }
                    let force = p[1] == FORCE_MAGIC;
                    if !self.landed && !force {
                        return MAV_RESULT_FAILED;
                    }
                    if !self.landed {
                        // Forced disarm in the air: the motors stop, the vehicle falls.
                        self.alt = 0.0;
                        self.landed = true;
                    }
                    self.disarm("Disarming motors");
                    MAV_RESULT_ACCEPTED
                } else {
                    MAV_RESULT_UNSUPPORTED
                }
            }
            // GCS_MAVLINK::handle_command_do_set_mode: base mode and custom mode, C-cast.
            MavCmd::MAV_CMD_DO_SET_MODE => {
                self.set_mode_common(f32_as_u32(p[0]) & 0xFF, f32_as_u32(p[1]))
            }
            MavCmd::MAV_CMD_NAV_TAKEOFF => self.takeoff(cmd),
            MavCmd::MAV_CMD_NAV_LAND => ok(self.set_mode(mode::LAND)),
            MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH => ok(self.set_mode(mode::RTL)),
            MavCmd::MAV_CMD_NAV_LOITER_UNLIM => ok(self.set_mode(mode::LOITER)),
            MavCmd::MAV_CMD_DO_REPOSITION => self.reposition(cmd),
            // GCS_MAVLINK_Copter::handle_MAV_CMD_MISSION_START: AUTO, auto-armed, and the
            // mission started or resumed unless it already runs. First/last item not supported.
            MavCmd::MAV_CMD_MISSION_START => {
                if p[0] != 0.0 || p[1] != 0.0 {
                    return MAV_RESULT_DENIED;
                }
                if !self.set_mode(mode::AUTO) {
                    return MAV_RESULT_FAILED;
                }
                self.auto.auto_armed = true;
                if !self.auto.running() {
                    self.mission_start_or_resume();
                }
                MAV_RESULT_ACCEPTED
            }
            // GCS_MAVLINK::handle_command_do_set_mission_current: param2 = 1 resets the
            // mission (jump counters) first; MISSION_CURRENT follows.
            MavCmd::MAV_CMD_DO_SET_MISSION_CURRENT => {
                if p[1] as i8 == 1 {
                    self.auto.reset();
                }
                let seq = f32_as_u32(p[0]).min(u16::MAX as u32) as u16;
                if !self.set_current_cmd(seq) {
                    return MAV_RESULT_FAILED;
                }
                after.push(self.mission_current(None));
                MAV_RESULT_ACCEPTED
            }
            // handle_MAV_CMD_DO_CHANGE_SPEED: in AUTO and GUIDED (the modes with set_speed_*).
            MavCmd::MAV_CMD_DO_CHANGE_SPEED => {
                if p[1].is_nan() || p[1] <= 0.0 {
                    return MAV_RESULT_FAILED;
                }
                if self.custom_mode != mode::AUTO && self.custom_mode != mode::GUIDED {
                    return MAV_RESULT_FAILED;
                }
                let v = Some(p[1] as f64);
                match p[0] as u8 {
                    2 => self.auto.speed_up = v,
                    3 => self.auto.speed_down = v,
                    _ => self.auto.speed_xy = v,
                }
                MAV_RESULT_ACCEPTED
            }
            MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION => self.preflight_calibration(cmd),
            MavCmd::MAV_CMD_ACCELCAL_VEHICLE_POS
            | MavCmd::MAV_CMD_DO_START_MAG_CAL
            | MavCmd::MAV_CMD_DO_ACCEPT_MAG_CAL
            | MavCmd::MAV_CMD_DO_CANCEL_MAG_CAL
            | MavCmd::MAV_CMD_FIXED_MAG_CAL_YAW
            | MavCmd::MAV_CMD_RUN_PREARM_CHECKS => self.cal_command(cmd),
            // GCS_MAVLINK::set_message_interval: FAILED for an id with no ap_message, which
            // set_mavlink_message_id_interval tells the GCS of in a STATUSTEXT.
            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL => {
                let msgid = p[0];
                if !(0.0..=16_777_215.0).contains(&msgid) || !streams::streamable(msgid as u32) {
                    let text = format!("No ap_message for mavlink id ({})", msgid as u32);
                    self.text(MavSeverity::MAV_SEVERITY_INFO, &text);
                    return MAV_RESULT_FAILED;
                }
                let interval = p[1];
                let iv = if interval < 0.0 {
                    None
                } else if interval == 0.0 {
                    Some(DEFAULT_INTERVAL)
                } else {
                    Some(interval as Micros)
                };
                self.streams.set_interval(self.now, msgid as u32, iv);
                MAV_RESULT_ACCEPTED
            }
            MavCmd::MAV_CMD_GET_MESSAGE_INTERVAL => {
                let msgid = p[0];
                if !(0.0..=65_535.0).contains(&msgid) {
                    return MAV_RESULT_FAILED;
                }
                let msgid = msgid as u32;
                let interval_us = match (msgid, self.streams.interval(msgid)) {
                    (id::HEARTBEAT, _) => 1_000_000,
                    (_, Some(i)) => i.min(i32::MAX as u64) as i32,
                    (m, None) if streams::streamable(m) => -1,
                    _ => 0,
                };
                after.push(MavMessage::MESSAGE_INTERVAL(MESSAGE_INTERVAL_DATA {
                    interval_us,
                    message_id: msgid as u16,
                }));
                MAV_RESULT_ACCEPTED
            }
            // GCS_MAVLINK::handle_command_request_message: FAILED for an id it has no message
            // for; otherwise ACCEPTED and the message queued, which for HOME_POSITION and
            // GPS_GLOBAL_ORIGIN sends nothing while home is not set.
            MavCmd::MAV_CMD_REQUEST_MESSAGE => {
                let msgid = p[0];
                if !(0.0..=16_777_215.0).contains(&msgid) {
                    return MAV_RESULT_FAILED;
                }
                let msgid = msgid as u32;
                // The gimbal messages map to ap_messages whether or not a mount is configured
                // (HAL_MOUNT_ENABLED): without one, ACCEPTED and nothing sent.
                if matches!(
                    msgid,
                    id::HOME_POSITION
                        | id::GPS_GLOBAL_ORIGIN
                        | id::GIMBAL_MANAGER_INFORMATION
                        | id::GIMBAL_MANAGER_STATUS
                        | id::GIMBAL_DEVICE_ATTITUDE_STATUS
                ) {
                    after.extend(self.build(msgid));
                    return MAV_RESULT_ACCEPTED;
                }
                match self.build(msgid) {
                    Some(m) => {
                        after.push(m);
                        MAV_RESULT_ACCEPTED
                    }
                    None => MAV_RESULT_FAILED,
                }
            }
            // handle_command_request_autopilot_capabilities: only param1 = 1 asks.
            MavCmd::MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES => {
                if p[0] != 1.0 {
                    return MAV_RESULT_FAILED;
                }
                after.push(self.autopilot_version());
                MAV_RESULT_ACCEPTED
            }
            MavCmd::MAV_CMD_GET_HOME_POSITION => {
                if !self.ekf_gps {
                    return MAV_RESULT_FAILED;
                }
                after.push(self.home_position());
                after.push(self.gps_global_origin());
                MAV_RESULT_ACCEPTED
            }
            // AP_Mount::handle_command: FAILED without a mount (no backend).
            MavCmd::MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW => {
                let heading = self.yaw;
                let (x, _) = cmd.xy();
                match self.mount.as_mut() {
                    Some(m) => m.pitchyaw(p, x as u32, p[6], heading),
                    None => MAV_RESULT_FAILED,
                }
            }
            MavCmd::MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE => {
                let t_ms = self.time_boot_ms();
                match self.mount.as_mut() {
                    Some(m) => {
                        let (r, changed) = m.configure(p, cmd.from);
                        if changed {
                            after.push(m.status(t_ms));
                        }
                        r
                    }
                    None => MAV_RESULT_FAILED,
                }
            }
            _ => MAV_RESULT_UNSUPPORTED,
        }
    }

    /// AP_Arming::arm from MAVLink: the pre-arm and arm checks, reported with the "Arm: "
    /// prefix while arming; param2 = 2989 or 21196 forces, leaving only the mandatory checks.
    fn arm(&mut self, p2: f32) -> MavResult {
        if self.armed {
            return MavResult::MAV_RESULT_ACCEPTED;
        }
        let forced = p2 == FORCE_MAGIC || p2 == FORCE_ARM_MAGIC;
        let needs_gps = mode::requires_position(self.custom_mode);
        let refuse = |v: &mut SimVehicle, why: &str| {
            v.text(MavSeverity::MAV_SEVERITY_CRITICAL, &format!("Arm: {why}"));
            MavResult::MAV_RESULT_FAILED
        };
        if forced {
            // AP_Arming_Copter::mandatory_gps_checks still runs.
            if needs_gps && !self.ekf_gps {
                return refuse(self, "Need Position Estimate");
            }
        } else {
            // The GPS checks run only for a mode that needs GPS; home is set in the same
            // moment the simulated EKF starts using GPS, so before it "waiting for home".
            if needs_gps && !self.ekf_gps {
                return refuse(self, "AHRS: waiting for home");
            }
            if !mode::armable(self.custom_mode) {
                let why = format!("{} mode not armable", mode::name(self.custom_mode));
                return refuse(self, &why);
            }
            // The pre-arm checks, each failure stated with the "Arm: " prefix.
            let failing = self.prearm_failures();
            if let Some((last, first)) = failing.split_last() {
                for why in first {
                    self.text(MavSeverity::MAV_SEVERITY_CRITICAL, &format!("Arm: {why}"));
                }
                return refuse(self, last);
            }
        }
        self.armed = true;
        self.landed = true;
        self.armed_on_ground_since = Some(self.now);
        self.srtl_active = self.ekf_gps;
        self.text(MavSeverity::MAV_SEVERITY_INFO, "Arming motors");
        if self.ekf_gps {
            // ArduCopter moves home to where it arms (unless home is locked) and announces it.
            let (lat, lon) = self.lat_lon();
            self.home = (lat, lon, self.home.2);
            self.north = 0.0;
            self.east = 0.0;
            self.announce_home();
        }
        MavResult::MAV_RESULT_ACCEPTED
    }

    /// GCS_MAVLINK::_set_mode_common (DO_SET_MODE and SET_MODE).
    fn set_mode_common(&mut self, base: u32, custom: u32) -> MavResult {
        use MavResult::*;
        if base & CUSTOM_MODE_ENABLED != 0 {
            // Copter::set_mode takes the mode number as a uint8_t.
            return if self.set_mode(custom & 0xFF) {
                MAV_RESULT_ACCEPTED
            } else {
                MAV_RESULT_FAILED
            };
        }
        if base == DECODE_POSITION_SAFETY {
            // The safety switch: 0 off, 1 on (the simulated board has no switch to refuse).
            return match custom {
                0 | 1 => MAV_RESULT_ACCEPTED,
                _ => MAV_RESULT_DENIED,
            };
        }
        // "Command is invalid (is supported but has invalid parameters)".
        MAV_RESULT_DENIED
    }

    /// Copter::set_mode(mode, GCS_COMMAND): true if the vehicle is (now) in mode `m`. A refusal
    /// says why in a WARNING STATUSTEXT, as ArduCopter does.
    pub(super) fn set_mode(&mut self, m: u32) -> bool {
        if m == self.custom_mode {
            return true;
        }
        if let Some(bit) = mode::gcs_block_bit(m) {
            let block = self.params.value("FLTMODE_GCSBLOCK").unwrap_or(0.0) as u32;
            if block & (1 << bit) != 0 {
                if mode::exists(m) {
                    self.mode_change_failed(m, "GCS entry disabled (FLTMODE_GCSBLOCK)");
                } else {
                    self.no_such_mode(m);
                }
                return false;
            }
        }
        if m == mode::AUTO_RTL {
            // AUTO in disguise: it needs a mission with a return path or a landing sequence,
            // and the simulated vehicle has no mission.
            self.text(
                MavSeverity::MAV_SEVERITY_WARNING,
                "Mode change to AUTO RTL failed: No return path or landing sequence found",
            );
            return false;
        }
        if !mode::exists(m) {
            self.no_such_mode(m);
            return false;
        }
        // "allow switching to any mode if disarmed. We rely on the arming check to perform".
        let ignore_checks = !self.armed;
        if !ignore_checks && mode::requires_position(m) && !self.ekf_gps {
            self.mode_change_failed(m, "requires position");
            return false;
        }
        if !self.mode_init(m, ignore_checks) {
            self.mode_change_failed(m, "init failed");
            return false;
        }
        self.enter_mode(m);
        true
    }

    /// The modes' `init(ignore_checks)` where it can fail on this vehicle.
    fn mode_init(&mut self, m: u32, ignore_checks: bool) -> bool {
        match m {
            // ModeAuto::init: a mission of more than the home item, unless disarmed, and a
            // takeoff first when armed on the ground.
            mode::AUTO => self.auto_init(ignore_checks),
            // ModeSmartRTL::init: only with a recorded path, which starts at arming.
            mode::SMART_RTL => self.srtl_active,
            // ModeThrow::init: never when already armed.
            mode::THROW => !self.armed,
            mode::FOLLOW => {
                if self.params.value("FOLL_ENABLE").unwrap_or(0.0) == 0.0 {
                    self.text(MavSeverity::MAV_SEVERITY_WARNING, "Set FOLL_ENABLE = 1");
                    return false;
                }
                true
            }
            // No optical flow sensor (FLOWHOLD), no system-id axis (SYSTEMID), no reversible
            // DShot motors (TURTLE); FLIP needs to be flying with throttle (not simulated).
            mode::FLOWHOLD | mode::SYSTEMID | mode::TURTLE | mode::FLIP => false,
            _ => true,
        }
    }

    fn mode_change_failed(&mut self, m: u32, reason: &str) {
        let t = format!("Mode change to {} failed: {reason}", mode::name(m));
        self.text(MavSeverity::MAV_SEVERITY_WARNING, &t);
    }

    fn no_such_mode(&mut self, m: u32) {
        self.text(
            MavSeverity::MAV_SEVERITY_WARNING,
            &format!("No such mode {m}"),
        );
    }

    /// GCS_MAVLINK_Copter::handle_MAV_CMD_NAV_TAKEOFF and Mode::do_user_takeoff.
    fn takeoff(&mut self, cmd: &Command) -> MavResult {
        // COMMAND_LONG is converted with frame GLOBAL_RELATIVE_ALT; a COMMAND_INT must say so.
        if let Some((frame, _, _)) = cmd.int {
            if frame != MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT {
                return MavResult::MAV_RESULT_DENIED;
            }
        }
        let must_navigate = cmd.p[2] == 0.0;
        let target = cmd.p[6] as f64;
        if !self.armed
            || !self.landed
            || !mode::has_user_takeoff(self.custom_mode, must_navigate)
            || !target.is_finite()
            || target <= self.alt
        {
            return MavResult::MAV_RESULT_FAILED;
        }
        self.landed = false;
        // Mode::do_user_takeoff sets auto-armed.
        self.auto.auto_armed = true;
        self.takeoff_target = Some(target.min(1000.0));
        self.guided_target = None;
        self.guided_vel = None;
        self.guided_yaw = None;
        self.armed_on_ground_since = None;
        MavResult::MAV_RESULT_ACCEPTED
    }

    /// GCS_MAVLINK_Copter::handle_command_int_do_reposition: GUIDED flies to the location.
    // The *_INT frames are deprecated synonyms, still sent by GCSs (the real capture's is one).
    #[allow(deprecated)]
    fn reposition(&mut self, cmd: &Command) -> MavResult {
        use MavResult::*;
        // A location command without a frame: ArduPilot has no frame to assume for it.
        let Some((frame, x, y)) = cmd.int else {
            return MAV_RESULT_UNSUPPORTED;
        };
        let change_modes = f32_as_i32(cmd.p[1]) & REPOSITION_CHANGE_MODE != 0;
        if self.custom_mode != mode::GUIDED && !change_modes {
            return MAV_RESULT_DENIED;
        }
        if x.unsigned_abs() > 900_000_000 || y.unsigned_abs() > 1_800_000_000 {
            return MAV_RESULT_DENIED;
        }
        let z = cmd.p[6];
        if z.is_nan() || z.abs() > LOCATION_ALT_MAX_M {
            return MAV_RESULT_DENIED;
        }
        use MavFrame::*;
        let relative = match frame {
            MAV_FRAME_GLOBAL | MAV_FRAME_GLOBAL_INT => false,
            MAV_FRAME_GLOBAL_RELATIVE_ALT
            | MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
            | MAV_FRAME_GLOBAL_TERRAIN_ALT
            | MAV_FRAME_GLOBAL_TERRAIN_ALT_INT => true,
            _ => return MAV_RESULT_DENIED,
        };
        // Location::sanitize: lat/lon 0 or relative altitude 0 ("here"), or more than 500 km
        // away, is not a location to fly to.
        if (x == 0 && y == 0) || (relative && z == 0.0) {
            return MAV_RESULT_DENIED;
        }
        let (lat, lon) = (x as f64 * 1e-7, y as f64 * 1e-7);
        let north = (lat - self.home.0) * 111_319.5;
        let east = (lon - self.home.1) * 111_319.5 * self.home.0.to_radians().cos();
        let (cn, ce) = (self.north, self.east);
        if (north - cn).hypot(east - ce) > 500_000.0 {
            return MAV_RESULT_DENIED;
        }
        // ModeGuided::set_destination needs the EKF origin.
        if !self.ekf_gps {
            return MAV_RESULT_FAILED;
        }
        let up = if relative {
            z as f64
        } else {
            z as f64 - self.home.2
        };
        if self.custom_mode != mode::GUIDED && !self.set_mode(mode::GUIDED) {
            return MAV_RESULT_FAILED;
        }
        self.guided_target = Some((north, east, up));
        if !self.landed {
            self.takeoff_target = None;
        }
        MAV_RESULT_ACCEPTED
    }

    /// GCS_MAVLINK::handle_command_preflight_calibration and its Copter override. Gyro, simple
    /// accel and level calibrations run synchronously: the vehicle goes quiet and answers when
    /// done. Baro calibration with an airspeed sensor enabled answers IN_PROGRESS, then
    /// IN_PROGRESS once a second, then ACCEPTED (`GCS_MAVLINK_InProgress`); the simulator
    /// takes ARSPD_ENABLE=1 to mean a sensor is fitted. Progress is 0 in all of them, as
    /// ArduPilot sends it.
    fn preflight_calibration(&mut self, cmd: &Command) -> MavResult {
        use MavResult::*;
        if self.armed {
            // "*preflight*, remember?"
            self.text(
                MavSeverity::MAV_SEVERITY_NOTICE,
                "Disarm to allow calibration",
            );
            return MAV_RESULT_FAILED;
        }
        let p = cmd.p;
        let (x, y) = cmd.xy();
        if y == 1 {
            // CompassMot: needs the motors run by the pilot; not simulated.
            return MAV_RESULT_UNSUPPORTED;
        }
        if p[0] == 1.0 {
            self.block(GYRO_CAL_TIME, cmd, MAV_RESULT_ACCEPTED);
            return MAV_RESULT_ACCEPTED;
        }
        if p[2] == 1.0 {
            self.text(
                MavSeverity::MAV_SEVERITY_INFO,
                "Updating barometer calibration",
            );
            self.baro_update_calibration();
            self.text(
                MavSeverity::MAV_SEVERITY_INFO,
                "Barometer calibration complete",
            );
            if self.params.value("ARSPD_ENABLE").unwrap_or(0.0) == 0.0 {
                return MAV_RESULT_ACCEPTED;
            }
            if self.airspeed_cal.as_ref().is_some_and(|c| c.to == cmd.from) {
                // GCS_MAVLINK_InProgress::get_task: one task per command and requester.
                return MAV_RESULT_TEMPORARILY_REJECTED;
            }
            self.airspeed_cal = Some(AirspeedCal {
                started: self.now,
                to: cmd.from,
                calibrated: false,
            });
            self.text(
                MavSeverity::MAV_SEVERITY_INFO,
                "Airspeed 1 calibration started",
            );
            return MAV_RESULT_IN_PROGRESS;
        }
        match x {
            // The six-position accel calibration: the gyros first (in the handler), then
            // AP_AccelCal asks for each position (the calibration module).
            1 => {
                self.block(GYRO_CAL_TIME, cmd, MAV_RESULT_ACCEPTED);
                self.accel_cal_start(self.now + GYRO_CAL_TIME);
                MAV_RESULT_ACCEPTED
            }
            2 | 4 => {
                self.block(ACCEL_CAL_TIME, cmd, MAV_RESULT_ACCEPTED);
                MAV_RESULT_ACCEPTED
            }
            // Force-save of an existing accel calibration.
            76 => MAV_RESULT_ACCEPTED,
            _ if p[1] == 76.0 => MAV_RESULT_ACCEPTED,
            _ => MAV_RESULT_UNSUPPORTED,
        }
    }

    /// AP_Baro::update_calibration: the ground pressures are reset (here: kept) and each
    /// barometer's BAROn_GND_PRESS is notified to every GCS (PARAM_VALUE index -1), at once,
    /// but not within 10 s of the last notification ("don't notify the GCS too rapidly"; the
    /// clock starts at boot, so not in the first 10 s either). A barometer is fitted when its
    /// BAROn_DEVID is set.
    fn baro_update_calibration(&mut self) {
        let now_ms = self.now / 1000;
        if now_ms.saturating_sub(self.baro_notified / 1000) <= 10_000 {
            return;
        }
        self.baro_notified = self.now;
        for n in 1..=3 {
            if self.params.value(&format!("BARO{n}_DEVID")).unwrap_or(0.0) == 0.0 {
                continue;
            }
            if let Some(i) = self.params.index_of(&format!("BARO{n}_GND_PRESS")) {
                let m = param_value_notify(&self.params, i);
                self.immediate.push(super::vehicle::Out::Msg(m));
            }
        }
    }

    fn block(&mut self, d: Micros, cmd: &Command, result: MavResult) {
        self.blocked = Some(Blocked {
            until: self.now + d,
            ack: (cmd.command, result, cmd.from),
            then: Vec::new(),
        });
    }
}
