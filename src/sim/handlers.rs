//! What a vehicle does with each message from the GCS: parameters, streams, MAVFTP, modes and
//! commands (COMMAND_LONG / COMMAND_INT → COMMAND_ACK), following ArduCopter's behaviour.

use super::streams::{self, id, DEFAULT_INTERVAL};
use super::telemetry::{command_ack, param_value};
use super::vehicle::{mode, LastCommand, SimVehicle};
use crate::clock::Micros;
use crate::dialect::*;
use crate::wire::mavftp::FtpPacket;

/// ArduPilot's magic param2 that skips arming checks / allows disarm in flight.
pub const FORCE_MAGIC: f32 = 21196.0;

/// A COMMAND_LONG or COMMAND_INT reduced to what the handler needs.
#[derive(Debug, Clone)]
pub(super) struct Command {
    pub command: MavCmd,
    /// param1..param7 (COMMAND_INT x, y as numbers, z as param7).
    pub p: [f32; 7],
    pub confirmation: u8,
    pub from: (u8, u8),
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
        self.now = now;
        match msg {
            MavMessage::PARAM_REQUEST_LIST(m)
                if self.for_me(m.target_system, m.target_component) =>
            {
                // ArduPilot resends its banner so a GCS that connects late still sees it.
                self.banner();
                self.param_cursor = Some(0);
            }
            MavMessage::PARAM_REQUEST_READ(m)
                if self.for_me(m.target_system, m.target_component) =>
            {
                let index = if m.param_index >= 0 {
                    Some(m.param_index as usize).filter(|&i| i < self.params.len())
                } else {
                    m.param_id
                        .to_str()
                        .ok()
                        .and_then(|n| self.params.index_of(n))
                };
                if let Some(i) = index {
                    self.out.push(param_value(&self.params, i));
                }
            }
            MavMessage::PARAM_SET(m) if self.for_me(m.target_system, m.target_component) => {
                let Ok(name) = m.param_id.to_str() else {
                    return;
                };
                if let Some(i) = self.params.set(name, m.param_value as f64) {
                    self.out.push(param_value(&self.params, i));
                    self.save_params();
                }
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
            MavMessage::SET_MODE(m) if m.target_system == self.sysid => {
                let result = self.set_mode_from(m.base_mode.bits() as f32, m.custom_mode as f32);
                self.out
                    .push(command_ack(MavCmd::MAV_CMD_DO_SET_MODE, result, from));
            }
            MavMessage::FILE_TRANSFER_PROTOCOL(m)
                if self.for_me(m.target_system, m.target_component) =>
            {
                let req = FtpPacket::parse(&m.payload);
                self.ftp_peer = from;
                for r in self.ftp.handle(now, &req, &self.params) {
                    self.out.push(super::telemetry::ftp_message(from, &r));
                }
            }
            MavMessage::COMMAND_LONG(m) if self.for_me(m.target_system, m.target_component) => {
                let cmd = Command {
                    command: m.command,
                    p: [
                        m.param1, m.param2, m.param3, m.param4, m.param5, m.param6, m.param7,
                    ],
                    confirmation: m.confirmation,
                    from,
                };
                self.command(now, cmd);
            }
            MavMessage::COMMAND_INT(m) if self.for_me(m.target_system, m.target_component) => {
                let cmd = Command {
                    command: m.command,
                    p: [
                        m.param1, m.param2, m.param3, m.param4, m.x as f32, m.y as f32, m.z,
                    ],
                    confirmation: 0,
                    from,
                };
                self.command(now, cmd);
            }
            _ => {}
        }
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
                    self.out.push(command_ack(cmd.command, result, cmd.from));
                    return;
                }
            }
        }
        let mut after = Vec::new();
        let result = self.execute(&cmd, &mut after);
        self.out.push(command_ack(cmd.command, result, cmd.from));
        self.out.extend(after);
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
        match cmd.command {
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM => {
                let force = p[1] == FORCE_MAGIC;
                if p[0] == 1.0 {
                    self.arm(force)
                } else if p[0] == 0.0 {
                    if !self.armed {
                        return MAV_RESULT_ACCEPTED;
                    }
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
            MavCmd::MAV_CMD_DO_SET_MODE => self.set_mode_from(p[0], p[1]),
            MavCmd::MAV_CMD_NAV_TAKEOFF => {
                // ArduCopter: only in a mode that supports user takeoff (GUIDED here), armed, and
                // on the ground.
                if self.custom_mode != mode::GUIDED || !self.armed || !self.landed {
                    return MAV_RESULT_FAILED;
                }
                let target = p[6] as f64;
                if !target.is_finite() || target <= 0.0 {
                    return MAV_RESULT_FAILED;
                }
                self.landed = false;
                self.takeoff_target = Some(target.min(1000.0));
                self.armed_on_ground_since = None;
                MAV_RESULT_ACCEPTED
            }
            MavCmd::MAV_CMD_NAV_LAND => self.try_mode(mode::LAND),
            MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH => self.try_mode(mode::RTL),
            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL => {
                let msgid = p[0];
                if !(0.0..=16_777_215.0).contains(&msgid) || !streams::streamable(msgid as u32) {
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
            MavCmd::MAV_CMD_REQUEST_MESSAGE => {
                let msgid = p[0];
                if !(0.0..=16_777_215.0).contains(&msgid) {
                    return MAV_RESULT_FAILED;
                }
                let msgid = msgid as u32;
                if msgid == id::HOME_POSITION && !self.ekf_gps {
                    return MAV_RESULT_FAILED;
                }
                match self.build(msgid) {
                    Some(m) => {
                        after.push(m);
                        MAV_RESULT_ACCEPTED
                    }
                    None => MAV_RESULT_UNSUPPORTED,
                }
            }
            MavCmd::MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES => {
                after.push(self.autopilot_version());
                MAV_RESULT_ACCEPTED
            }
            MavCmd::MAV_CMD_GET_HOME_POSITION => {
                if !self.ekf_gps {
                    return MAV_RESULT_FAILED;
                }
                after.push(self.home_position());
                MAV_RESULT_ACCEPTED
            }
            _ => MAV_RESULT_UNSUPPORTED,
        }
    }

    fn arm(&mut self, force: bool) -> MavResult {
        if self.armed {
            return MavResult::MAV_RESULT_ACCEPTED;
        }
        if !force {
            if !mode::armable(self.custom_mode) {
                self.text(
                    MavSeverity::MAV_SEVERITY_CRITICAL,
                    "PreArm: Mode not armable",
                );
                return MavResult::MAV_RESULT_FAILED;
            }
            if !self.ekf_gps {
                self.text(
                    MavSeverity::MAV_SEVERITY_CRITICAL,
                    "PreArm: Need Position Estimate",
                );
                return MavResult::MAV_RESULT_FAILED;
            }
        }
        self.armed = true;
        self.landed = true;
        self.armed_on_ground_since = Some(self.now);
        self.text(MavSeverity::MAV_SEVERITY_INFO, "Arming motors");
        MavResult::MAV_RESULT_ACCEPTED
    }

    /// DO_SET_MODE / SET_MODE: `base` must carry MAV_MODE_FLAG_CUSTOM_MODE_ENABLED; `custom` is
    /// the ArduCopter mode number.
    fn set_mode_from(&mut self, base: f32, custom: f32) -> MavResult {
        let base = if base.is_finite() && base >= 0.0 {
            base as u32
        } else {
            0
        };
        if base & MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED.bits() as u32 == 0 {
            return MavResult::MAV_RESULT_FAILED;
        }
        if !custom.is_finite() || custom < 0.0 || custom.fract() != 0.0 {
            return MavResult::MAV_RESULT_FAILED;
        }
        self.try_mode(custom as u32)
    }

    fn try_mode(&mut self, m: u32) -> MavResult {
        if !mode::exists(m) {
            return MavResult::MAV_RESULT_FAILED;
        }
        // ArduCopter skips the position requirement while disarmed.
        if self.armed && mode::requires_position(m) && !self.ekf_gps {
            return MavResult::MAV_RESULT_FAILED;
        }
        self.enter_mode(m);
        MavResult::MAV_RESULT_ACCEPTED
    }
}
