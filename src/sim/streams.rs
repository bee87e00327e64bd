//! Which telemetry messages a vehicle sends, and when: ArduPilot's stream groups
//! (REQUEST_DATA_STREAM) and per-message intervals (MAV_CMD_SET_MESSAGE_INTERVAL).
//!
//! Everything starts off, as on ArduPilot with SRx_ rates at 0: a GCS must ask.

use crate::clock::Micros;
use std::collections::BTreeMap;

/// Message ids the simulator can stream.
pub mod id {
    use crate::dialect::*;
    use mavlink::MessageData;

    pub const HEARTBEAT: u32 = HEARTBEAT_DATA::ID;
    pub const SYS_STATUS: u32 = SYS_STATUS_DATA::ID;
    pub const SYSTEM_TIME: u32 = SYSTEM_TIME_DATA::ID;
    pub const GPS_RAW_INT: u32 = GPS_RAW_INT_DATA::ID;
    pub const RAW_IMU: u32 = RAW_IMU_DATA::ID;
    pub const SCALED_PRESSURE: u32 = SCALED_PRESSURE_DATA::ID;
    pub const GPS_GLOBAL_ORIGIN: u32 = GPS_GLOBAL_ORIGIN_DATA::ID;
    pub const ATTITUDE: u32 = ATTITUDE_DATA::ID;
    pub const LOCAL_POSITION_NED: u32 = LOCAL_POSITION_NED_DATA::ID;
    pub const GLOBAL_POSITION_INT: u32 = GLOBAL_POSITION_INT_DATA::ID;
    pub const RC_CHANNELS: u32 = RC_CHANNELS_DATA::ID;
    pub const SERVO_OUTPUT_RAW: u32 = SERVO_OUTPUT_RAW_DATA::ID;
    pub const MISSION_CURRENT: u32 = MISSION_CURRENT_DATA::ID;
    pub const NAV_CONTROLLER_OUTPUT: u32 = NAV_CONTROLLER_OUTPUT_DATA::ID;
    pub const VFR_HUD: u32 = VFR_HUD_DATA::ID;
    pub const POWER_STATUS: u32 = POWER_STATUS_DATA::ID;
    pub const BATTERY_STATUS: u32 = BATTERY_STATUS_DATA::ID;
    pub const AUTOPILOT_VERSION: u32 = AUTOPILOT_VERSION_DATA::ID;
    pub const MEMINFO: u32 = MEMINFO_DATA::ID;
    pub const AHRS: u32 = AHRS_DATA::ID;
    pub const AHRS2: u32 = AHRS2_DATA::ID;
    pub const EKF_STATUS_REPORT: u32 = EKF_STATUS_REPORT_DATA::ID;
    pub const VIBRATION: u32 = VIBRATION_DATA::ID;
    pub const HOME_POSITION: u32 = HOME_POSITION_DATA::ID;
    pub const EXTENDED_SYS_STATE: u32 = EXTENDED_SYS_STATE_DATA::ID;
    pub const GIMBAL_MANAGER_INFORMATION: u32 = GIMBAL_MANAGER_INFORMATION_DATA::ID;
    pub const GIMBAL_MANAGER_STATUS: u32 = GIMBAL_MANAGER_STATUS_DATA::ID;
    pub const GIMBAL_DEVICE_ATTITUDE_STATUS: u32 = GIMBAL_DEVICE_ATTITUDE_STATUS_DATA::ID;
}

/// ArduCopter's MAV_DATA_STREAM groups (GCS_Mavlink.cpp `STREAM_*` tables), restricted to the
/// messages the simulator implements (one IMU and one barometer; no SIMSTATE, which only SITL
/// sends; no PID_TUNING, off with the default GCS_PID_MASK).
pub fn stream_group(stream_id: u8) -> &'static [u32] {
    use id::*;
    match stream_id {
        1 => &[RAW_IMU, SCALED_PRESSURE],
        2 => &[
            SYS_STATUS,
            POWER_STATUS,
            MEMINFO,
            MISSION_CURRENT,
            GPS_RAW_INT,
            NAV_CONTROLLER_OUTPUT,
        ],
        3 => &[SERVO_OUTPUT_RAW, RC_CHANNELS],
        6 => &[GLOBAL_POSITION_INT, LOCAL_POSITION_NED],
        10 => &[ATTITUDE, AHRS2],
        11 => &[VFR_HUD],
        12 => &[
            AHRS,
            SYSTEM_TIME,
            EKF_STATUS_REPORT,
            VIBRATION,
            BATTERY_STATUS,
            // Only with a mount (nothing is sent without one).
            GIMBAL_DEVICE_ATTITUDE_STATUS,
        ],
        _ => &[],
    }
}

/// All stream groups, for MAV_DATA_STREAM_ALL (0).
pub const ALL_GROUPS: [u8; 7] = [1, 2, 3, 6, 10, 11, 12];

/// Messages in no stream group that a GCS can still ask for by SET_MESSAGE_INTERVAL (ArduPilot's
/// MSG_HOME and MSG_ORIGIN are sent only once home is set; EXTENDED_SYS_STATE; the mount's
/// GIMBAL_MANAGER_STATUS, which ArduPilot otherwise sends only when control changes).
pub const INTERVAL_ONLY: [u32; 4] = [
    id::EXTENDED_SYS_STATE,
    id::HOME_POSITION,
    id::GPS_GLOBAL_ORIGIN,
    id::GIMBAL_MANAGER_STATUS,
];

/// True when the simulator can produce message `msgid` on request or on a stream.
pub fn streamable(msgid: u32) -> bool {
    ALL_GROUPS.iter().any(|g| stream_group(*g).contains(&msgid)) || INTERVAL_ONLY.contains(&msgid)
}

/// Per-message intervals and due times. BTreeMap keeps emission order deterministic.
#[derive(Debug, Clone, Default)]
pub struct Streams {
    interval: BTreeMap<u32, Micros>,
    due: BTreeMap<u32, Micros>,
}

/// Interval used for "default rate" (SET_MESSAGE_INTERVAL param2 = 0): 4 Hz, the rate
/// GCSs usually request.
pub const DEFAULT_INTERVAL: Micros = 250_000;

impl Streams {
    /// Set (`Some`) or stop (`None`) a message; the first one goes out at the next tick.
    pub fn set_interval(&mut self, now: Micros, msgid: u32, interval: Option<Micros>) {
        match interval {
            Some(i) if i > 0 => {
                self.interval.insert(msgid, i);
                self.due.insert(msgid, now);
            }
            _ => {
                self.interval.remove(&msgid);
                self.due.remove(&msgid);
            }
        }
    }

    pub fn interval(&self, msgid: u32) -> Option<Micros> {
        self.interval.get(&msgid).copied()
    }

    /// REQUEST_DATA_STREAM: a rate for a whole group (0 = all groups); rate 0 or stop clears.
    pub fn request_stream(&mut self, now: Micros, stream_id: u8, rate_hz: u16, start: bool) {
        let groups: Vec<u8> = if stream_id == 0 {
            ALL_GROUPS.to_vec()
        } else {
            vec![stream_id]
        };
        let interval = (start && rate_hz > 0).then(|| 1_000_000 / rate_hz as Micros);
        for g in groups {
            for &m in stream_group(g) {
                self.set_interval(now, m, interval);
            }
        }
    }

    /// Messages due at `now`, in id order; each is rescheduled one interval later (or from
    /// `now` if it fell more than an interval behind, so a stall does not cause a burst).
    pub fn take_due(&mut self, now: Micros) -> Vec<u32> {
        let mut out = Vec::new();
        for (&m, due) in self.due.iter_mut() {
            if *due <= now {
                out.push(m);
                let i = self.interval[&m];
                *due += i;
                if *due <= now {
                    *due = now + i;
                }
            }
        }
        out
    }

    /// Earliest due time of any stream.
    pub fn next_due(&self) -> Option<Micros> {
        self.due.values().copied().min()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn off_until_asked_then_at_rate() {
        let mut s = Streams::default();
        assert!(s.take_due(0).is_empty());
        s.request_stream(0, 6, 4, true);
        let mut n = 0;
        for t in (0..1_000_000).step_by(10_000) {
            n += s
                .take_due(t)
                .iter()
                .filter(|&&m| m == id::GLOBAL_POSITION_INT)
                .count();
        }
        assert_eq!(n, 4);
        s.request_stream(1_000_000, 6, 4, false);
        assert_eq!(s.next_due(), None);
    }

    #[test]
    fn all_and_interval_override() {
        let mut s = Streams::default();
        s.request_stream(0, 0, 2, true);
        for g in ALL_GROUPS {
            for m in stream_group(g) {
                assert_eq!(s.interval(*m), Some(500_000));
            }
        }
        s.set_interval(0, id::ATTITUDE, Some(50_000));
        assert_eq!(s.interval(id::ATTITUDE), Some(50_000));
        s.set_interval(0, id::ATTITUDE, None);
        assert_eq!(s.interval(id::ATTITUDE), None);
        assert!(streamable(id::BATTERY_STATUS));
        assert!(!streamable(id::HEARTBEAT));
    }
}
