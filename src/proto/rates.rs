//! The telemetry rates mavterm asks of autopilots: per ArduPilot stream group and per message.
//! Shared by the stream machine (which asks) and the config file (which sets them).

use std::collections::BTreeMap;

use mavlink::MessageData;

use crate::dialect::{
    ATTITUDE_DATA, BATTERY_STATUS_DATA, GLOBAL_POSITION_INT_DATA, GPS_RAW_INT_DATA,
    SYSTEM_TIME_DATA, SYS_STATUS_DATA, VFR_HUD_DATA,
};

/// ArduPilot's REQUEST_DATA_STREAM groups (MAV_DATA_STREAM ids) that mavterm asks for.
pub const GROUPS: &[(u8, &str)] = &[
    (1, "raw_sensors"),
    (2, "extended_status"),
    (3, "rc_channels"),
    (6, "position"),
    (10, "extra1"),
    (11, "extra2"),
    (12, "extra3"),
];

/// Rates to ask for, in Hz.
#[derive(Debug, Clone, PartialEq)]
pub struct StreamRates {
    /// ArduPilot stream group id → Hz (0 = do not ask for this group).
    pub groups: BTreeMap<u8, f32>,
    /// Message id → Hz, asked with SET_MESSAGE_INTERVAL: the whole set for autopilots that
    /// only know it (PX4), and on top of the groups for ArduPilot.
    pub messages: BTreeMap<u32, f32>,
    /// Messages asked of ArduPilot by SET_MESSAGE_INTERVAL in addition to its groups (empty by
    /// default: the groups cover what the screens show).
    pub ardupilot_messages: BTreeMap<u32, f32>,
}

impl Default for StreamRates {
    /// Close to QGroundControl's rates for ArduPilot (RAW_SENSORS 2, EXTENDED_STATUS 2,
    /// RC_CHANNELS 2, POSITION 3, EXTRA1 10, EXTRA2 10, EXTRA3 3 Hz), and for autopilots that
    /// take SET_MESSAGE_INTERVAL only, the messages the screens use.
    fn default() -> Self {
        Self {
            groups: [
                (1, 2.0),
                (2, 2.0),
                (3, 2.0),
                (6, 3.0),
                (10, 10.0),
                (11, 10.0),
                (12, 3.0),
            ]
            .into_iter()
            .collect(),
            messages: [
                (SYS_STATUS_DATA::ID, 1.0),
                (SYSTEM_TIME_DATA::ID, 0.5),
                (GPS_RAW_INT_DATA::ID, 1.0),
                (ATTITUDE_DATA::ID, 4.0),
                (GLOBAL_POSITION_INT_DATA::ID, 4.0),
                (VFR_HUD_DATA::ID, 4.0),
                (BATTERY_STATUS_DATA::ID, 1.0),
            ]
            .into_iter()
            .collect(),
            ardupilot_messages: BTreeMap::new(),
        }
    }
}

/// The group id of a name from [`GROUPS`] (as the config file writes it).
pub fn group_id(name: &str) -> Option<u8> {
    GROUPS
        .iter()
        .find(|(_, n)| n.eq_ignore_ascii_case(name))
        .map(|(id, _)| *id)
}
