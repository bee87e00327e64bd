// REQUEST_DATA_STREAM is marked deprecated in common.xml, yet it is what ArduPilot honours.
#![allow(deprecated)]
//! Asking a vehicle for telemetry, the way its autopilot understands.
//!
//! ArduPilot honours REQUEST_DATA_STREAM (stream groups at a rate); it also takes
//! SET_MESSAGE_INTERVAL from 4.0 on, but the group request works on every version, so it is what
//! we send first. PX4 ignores REQUEST_DATA_STREAM and only takes MAV_CMD_SET_MESSAGE_INTERVAL.
//! Neither sets the capability bit that would tell us, so the choice is made on the HEARTBEAT's
//! autopilot field.

use crate::dialect::{self, MavAutopilot, MavCmd, MavDataStream, MavMessage};
use crate::proto::vehicles::Vehicle;

/// Rate asked of ArduPilot for all stream groups.
pub const DEFAULT_STREAM_HZ: u16 = 4;

/// Messages asked of autopilots that only know SET_MESSAGE_INTERVAL, with their rates in Hz.
pub const INTERVAL_MESSAGES: &[(u32, f32)] = &[
    (1, 1.0),   // SYS_STATUS
    (2, 0.5),   // SYSTEM_TIME
    (24, 1.0),  // GPS_RAW_INT
    (30, 4.0),  // ATTITUDE
    (33, 4.0),  // GLOBAL_POSITION_INT
    (74, 4.0),  // VFR_HUD
    (147, 1.0), // BATTERY_STATUS
];

/// REQUEST_DATA_STREAM for one stream group.
pub fn request_data_stream(
    target: (u8, u8),
    stream: MavDataStream,
    hz: u16,
    start: bool,
) -> MavMessage {
    MavMessage::REQUEST_DATA_STREAM(dialect::REQUEST_DATA_STREAM_DATA {
        req_message_rate: hz,
        target_system: target.0,
        target_component: target.1,
        req_stream_id: stream,
        start_stop: start as u8,
    })
}

/// COMMAND_LONG MAV_CMD_SET_MESSAGE_INTERVAL (param2 in µs; -1 disables, 0 default rate).
pub fn set_message_interval(target: (u8, u8), msgid: u32, interval_us: f32) -> MavMessage {
    MavMessage::COMMAND_LONG(dialect::COMMAND_LONG_DATA {
        target_system: target.0,
        target_component: target.1,
        command: MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
        confirmation: 0,
        param1: msgid as f32,
        param2: interval_us,
        param3: 0.0,
        param4: 0.0,
        param5: 0.0,
        param6: 0.0,
        param7: 0.0,
    })
}

/// What to send when an autopilot is first heard (or has rebooted).
pub fn initial_requests(v: &Vehicle) -> Vec<MavMessage> {
    let target = (v.sysid, v.compid);
    match v.autopilot {
        MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA => vec![request_data_stream(
            target,
            MavDataStream::MAV_DATA_STREAM_ALL,
            DEFAULT_STREAM_HZ,
            true,
        )],
        _ => INTERVAL_MESSAGES
            .iter()
            .map(|&(id, hz)| set_message_interval(target, id, 1e6 / hz))
            .collect(),
    }
}
