//! Flight-mode names from HEARTBEAT `custom_mode`, for ArduPilot (Copter, Plane, Rover, Sub) and
//! PX4 (main mode and sub mode packed into the upper bytes).
//!
//! The tables follow ArduPilot's `mode.h` numbering and PX4's `px4_custom_mode.h`.

use crate::dialect::{MavAutopilot, MavType};

pub use crate::proto::profile::ModeTable;

pub const COPTER_MODES: &[(u32, &str)] = &[
    (0, "STABILIZE"),
    (1, "ACRO"),
    (2, "ALT_HOLD"),
    (3, "AUTO"),
    (4, "GUIDED"),
    (5, "LOITER"),
    (6, "RTL"),
    (7, "CIRCLE"),
    (9, "LAND"),
    (11, "DRIFT"),
    (13, "SPORT"),
    (14, "FLIP"),
    (15, "AUTOTUNE"),
    (16, "POSHOLD"),
    (17, "BRAKE"),
    (18, "THROW"),
    (19, "AVOID_ADSB"),
    (20, "GUIDED_NOGPS"),
    (21, "SMART_RTL"),
    (22, "FLOWHOLD"),
    (23, "FOLLOW"),
    (24, "ZIGZAG"),
    (25, "SYSTEMID"),
    (26, "AUTOROTATE"),
    (27, "AUTO_RTL"),
    (28, "TURTLE"),
];

pub const PLANE_MODES: &[(u32, &str)] = &[
    (0, "MANUAL"),
    (1, "CIRCLE"),
    (2, "STABILIZE"),
    (3, "TRAINING"),
    (4, "ACRO"),
    (5, "FBWA"),
    (6, "FBWB"),
    (7, "CRUISE"),
    (8, "AUTOTUNE"),
    (10, "AUTO"),
    (11, "RTL"),
    (12, "LOITER"),
    (13, "TAKEOFF"),
    (14, "AVOID_ADSB"),
    (15, "GUIDED"),
    (16, "INITIALISING"),
    (17, "QSTABILIZE"),
    (18, "QHOVER"),
    (19, "QLOITER"),
    (20, "QLAND"),
    (21, "QRTL"),
    (22, "QAUTOTUNE"),
    (23, "QACRO"),
    (24, "THERMAL"),
    (25, "LOITER_ALT_QLAND"),
    (26, "AUTOLAND"),
];

pub const ROVER_MODES: &[(u32, &str)] = &[
    (0, "MANUAL"),
    (1, "ACRO"),
    (3, "STEERING"),
    (4, "HOLD"),
    (5, "LOITER"),
    (6, "FOLLOW"),
    (7, "SIMPLE"),
    (8, "DOCK"),
    (9, "CIRCLE"),
    (10, "AUTO"),
    (11, "RTL"),
    (12, "SMART_RTL"),
    (15, "GUIDED"),
    (16, "INITIALISING"),
];

pub const SUB_MODES: &[(u32, &str)] = &[
    (0, "STABILIZE"),
    (1, "ACRO"),
    (2, "ALT_HOLD"),
    (3, "AUTO"),
    (4, "GUIDED"),
    (7, "CIRCLE"),
    (9, "SURFACE"),
    (16, "POSHOLD"),
    (19, "MANUAL"),
    (20, "MOTOR_DETECT"),
    (21, "SURFTRAK"),
];

/// PX4 modes as (main_mode, sub_mode, name), QGroundControl's names in upper case.
pub const PX4_MODES: &[(u8, u8, &str)] = &[
    (1, 0, "MANUAL"),
    (2, 0, "ALTCTL"),
    (3, 0, "POSCTL"),
    (3, 1, "ORBIT"),
    (4, 1, "AUTO_READY"),
    (4, 2, "TAKEOFF"),
    (4, 3, "HOLD"),
    (4, 4, "MISSION"),
    (4, 5, "RTL"),
    (4, 6, "LAND"),
    (4, 8, "FOLLOW_ME"),
    (4, 9, "PRECLAND"),
    (4, 10, "VTOL_TAKEOFF"),
    (5, 0, "ACRO"),
    (6, 0, "OFFBOARD"),
    (7, 0, "STABILIZED"),
    (8, 0, "RATTITUDE"),
    (9, 0, "SIMPLE"),
    (10, 0, "TERMINATION"),
];

/// The mode table for a vehicle's autopilot and type: the autopilot's profile says.
pub fn table_for(autopilot: MavAutopilot, mavtype: MavType) -> ModeTable {
    crate::proto::profile::of(autopilot).mode_table(mavtype)
}

fn lookup(table: &[(u32, &'static str)], mode: u32) -> Option<&'static str> {
    table.iter().find(|(n, _)| *n == mode).map(|(_, s)| *s)
}

fn ardupilot_table(t: ModeTable) -> Option<&'static [(u32, &'static str)]> {
    match t {
        ModeTable::ArduCopter => Some(COPTER_MODES),
        ModeTable::ArduPlane => Some(PLANE_MODES),
        ModeTable::ArduRover => Some(ROVER_MODES),
        ModeTable::ArduSub => Some(SUB_MODES),
        _ => None,
    }
}

/// The name of `custom_mode` for this vehicle, or `MODE(n)` when the number is not in its table.
pub fn mode_name(autopilot: MavAutopilot, mavtype: MavType, custom_mode: u32) -> String {
    let table = table_for(autopilot, mavtype);
    if let Some(t) = ardupilot_table(table) {
        return lookup(t, custom_mode)
            .map(str::to_string)
            .unwrap_or_else(|| format!("MODE({custom_mode})"));
    }
    if table == ModeTable::Px4 {
        let main = ((custom_mode >> 16) & 0xFF) as u8;
        let sub = ((custom_mode >> 24) & 0xFF) as u8;
        if let Some((_, _, name)) = PX4_MODES
            .iter()
            .find(|(m, s, _)| *m == main && (*s == sub || (*s == 0 && main != 4 && sub == 0)))
        {
            return name.to_string();
        }
        return format!("PX4({main}/{sub})");
    }
    format!("MODE({custom_mode})")
}

/// The `custom_mode` number for a mode name (case-insensitive), for DO_SET_MODE.
pub fn mode_number(autopilot: MavAutopilot, mavtype: MavType, name: &str) -> Option<u32> {
    let name = name.to_ascii_uppercase();
    let table = table_for(autopilot, mavtype);
    if let Some(t) = ardupilot_table(table) {
        return t.iter().find(|(_, s)| *s == name).map(|(n, _)| *n);
    }
    if table == ModeTable::Px4 {
        return PX4_MODES
            .iter()
            .find(|(_, _, s)| *s == name)
            .map(|(m, s, _)| ((*m as u32) << 16) | ((*s as u32) << 24));
    }
    None
}

/// All mode names for this vehicle, in number order (for menus and completion).
pub fn mode_names(autopilot: MavAutopilot, mavtype: MavType) -> Vec<&'static str> {
    let table = table_for(autopilot, mavtype);
    if let Some(t) = ardupilot_table(table) {
        return t.iter().map(|(_, s)| *s).collect();
    }
    if table == ModeTable::Px4 {
        return PX4_MODES.iter().map(|(_, _, s)| *s).collect();
    }
    Vec::new()
}

#[cfg(test)]
mod tests {
    use super::*;
    use MavAutopilot::*;
    use MavType::*;

    #[test]
    fn ardupilot_modes_by_vehicle_type() {
        let ap = MAV_AUTOPILOT_ARDUPILOTMEGA;
        assert_eq!(mode_name(ap, MAV_TYPE_QUADROTOR, 4), "GUIDED");
        assert_eq!(mode_name(ap, MAV_TYPE_QUADROTOR, 9), "LAND");
        assert_eq!(mode_name(ap, MAV_TYPE_FIXED_WING, 10), "AUTO");
        assert_eq!(mode_name(ap, MAV_TYPE_VTOL_TILTROTOR, 19), "QLOITER");
        assert_eq!(mode_name(ap, MAV_TYPE_GROUND_ROVER, 4), "HOLD");
        assert_eq!(mode_name(ap, MAV_TYPE_SUBMARINE, 19), "MANUAL");
        assert_eq!(mode_name(ap, MAV_TYPE_QUADROTOR, 99), "MODE(99)");
    }

    #[test]
    fn px4_main_and_sub_modes() {
        let px4 = MAV_AUTOPILOT_PX4;
        // AUTO (4) / MISSION (4): 0x04040000.
        assert_eq!(mode_name(px4, MAV_TYPE_QUADROTOR, 0x0404_0000), "MISSION");
        assert_eq!(mode_name(px4, MAV_TYPE_QUADROTOR, 0x0304_0000), "HOLD");
        assert_eq!(mode_name(px4, MAV_TYPE_QUADROTOR, 0x0003_0000), "POSCTL");
        assert_eq!(mode_name(px4, MAV_TYPE_QUADROTOR, 0x0006_0000), "OFFBOARD");
        assert_eq!(
            mode_number(px4, MAV_TYPE_QUADROTOR, "rtl"),
            Some(0x0504_0000)
        );
    }

    #[test]
    fn names_round_trip_to_numbers() {
        let ap = MAV_AUTOPILOT_ARDUPILOTMEGA;
        for name in mode_names(ap, MAV_TYPE_QUADROTOR) {
            let n = mode_number(ap, MAV_TYPE_QUADROTOR, name).unwrap();
            assert_eq!(mode_name(ap, MAV_TYPE_QUADROTOR, n), name);
        }
        assert_eq!(
            mode_number(MAV_AUTOPILOT_GENERIC, MAV_TYPE_QUADROTOR, "GUIDED"),
            None
        );
    }

    #[test]
    fn tables_cover_every_mode_of_the_dialect() {
        use crate::dialect::{CopterMode, PlaneMode, RoverMode, SubMode};
        use num_traits::FromPrimitive;
        let check = |table: &[(u32, &str)], known: &dyn Fn(u32) -> Option<String>| {
            for n in 0..=255u32 {
                if let Some(name) = known(n) {
                    assert!(
                        table.iter().any(|(m, _)| *m == n),
                        "{name} ({n}) is missing"
                    );
                }
            }
        };
        check(COPTER_MODES, &|n| {
            CopterMode::from_u32(n).map(|m| format!("{m:?}"))
        });
        check(PLANE_MODES, &|n| {
            PlaneMode::from_u32(n).map(|m| format!("{m:?}"))
        });
        check(ROVER_MODES, &|n| {
            RoverMode::from_u32(n).map(|m| format!("{m:?}"))
        });
        check(SUB_MODES, &|n| {
            SubMode::from_u32(n).map(|m| format!("{m:?}"))
        });
    }
}
