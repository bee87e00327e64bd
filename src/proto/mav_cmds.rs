//! Every MAV_CMD of our dialect, by number and name, and what the parameters of the commonly used
//! ones mean (label, units, a hint), after the MAVLink `common.xml` definitions that the dialect
//! is generated from. The palette searches these and labels its fields with them.

use std::sync::OnceLock;

use num_traits::FromPrimitive;

use crate::dialect::MavCmd;

/// Every MAV_CMD the dialect knows: (number, name without `MAV_CMD_`), by number.
pub fn all() -> &'static [(u16, String)] {
    static ALL: OnceLock<Vec<(u16, String)>> = OnceLock::new();
    ALL.get_or_init(|| {
        (0..=u16::MAX)
            .filter_map(|n| MavCmd::from_u16(n).map(|_| (n, crate::proto::ack::command_name(n))))
            .collect()
    })
}

/// One parameter of a command: what it is called, its units (may be empty), and what its values
/// mean (may be empty). A label of `""` marks a parameter the command does not use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ParamDoc {
    pub label: &'static str,
    pub units: &'static str,
    pub hint: &'static str,
}

/// What a command does and what its seven parameters are.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CmdDoc {
    pub command: MavCmd,
    pub description: &'static str,
    pub params: [ParamDoc; 7],
}

const fn p(label: &'static str, units: &'static str, hint: &'static str) -> ParamDoc {
    ParamDoc { label, units, hint }
}

/// A parameter the command does not use (empty or reserved in common.xml).
const UNUSED: ParamDoc = p("", "", "");
// COMMAND_LONG carries latitude and longitude as degrees (COMMAND_INT as degE7).
const LAT: ParamDoc = p("Latitude", "deg", "");
const LON: ParamDoc = p("Longitude", "deg", "");
const REQ: &str = "0 unless the message defines it";
const RESPONSE: ParamDoc = p(
    "Response Target",
    "",
    "0 flight-stack default, 1 requester, 2 broadcast",
);
const REBOOT: &str = "0 none, 1 reboot, 2 shutdown, 3 bootloader";

/// The commands whose parameters we describe; every other one shows `param N`.
pub const DOCS: &[CmdDoc] = &[
    CmdDoc {
        command: MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
        description: "Arms / disarms a component",
        params: [
            p("Arm", "", "1 arm, 0 disarm"),
            p("Force", "", "0 with safety checks, 21196 force"),
            UNUSED,
            UNUSED,
            UNUSED,
            UNUSED,
            UNUSED,
        ],
    },
    CmdDoc {
        command: MavCmd::MAV_CMD_NAV_TAKEOFF,
        description: "Take off from ground / hand",
        params: [
            p("Pitch", "deg", "minimum pitch (planes)"),
            UNUSED,
            p("Flags", "", "1 horizontal position not required"),
            p("Yaw", "deg", "nan: current yaw mode"),
            LAT,
            LON,
            p("Altitude", "m", "ArduPilot: above home"),
        ],
    },
    CmdDoc {
        command: MavCmd::MAV_CMD_NAV_LAND,
        description: "Land at location",
        params: [
            p("Abort Alt", "m", "0: system default"),
            p("Land Mode", "", "precision: 0 off, 1 opportunistic, 2 on"),
            UNUSED,
            p("Yaw Angle", "deg", "nan: current yaw mode"),
            LAT,
            LON,
            p("Altitude", "m", "ground level in current frame"),
        ],
    },
    CmdDoc {
        command: MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH,
        description: "Return to launch location",
        params: [UNUSED; 7],
    },
    CmdDoc {
        command: MavCmd::MAV_CMD_DO_SET_MODE,
        description: "Set system mode",
        params: [
            p("Mode", "", "MAV_MODE_FLAG bits: 1 custom mode"),
            p("Custom Mode", "", "autopilot-specific mode number"),
            p("Custom Submode", "", "autopilot-specific"),
            UNUSED,
            UNUSED,
            UNUSED,
            UNUSED,
        ],
    },
    CmdDoc {
        command: MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
        description: "Set the interval between messages of one id",
        params: [
            p("Message ID", "", "the MAVLink message id"),
            p("Interval", "us", "-1 disable, 0 default rate"),
            p("Req Param 3", "", REQ),
            p("Req Param 4", "", REQ),
            p("Req Param 5", "", REQ),
            p("Req Param 6", "", REQ),
            RESPONSE,
        ],
    },
    CmdDoc {
        command: MavCmd::MAV_CMD_REQUEST_MESSAGE,
        description: "Request one instance of a message",
        params: [
            p("Message ID", "", "the MAVLink message id"),
            p("Req Param 1", "", "index id if needed, else 0"),
            p("Req Param 2", "", REQ),
            p("Req Param 3", "", REQ),
            p("Req Param 4", "", REQ),
            p("Req Param 5", "", REQ),
            RESPONSE,
        ],
    },
    CmdDoc {
        command: MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION,
        description: "Trigger calibration (pre-flight only; one sensor at a time)",
        params: [
            p("Gyro Temperature", "", "1 gyro, 3 gyro temperature"),
            p("Magnetometer", "", "1 start, 76 force save"),
            p("Ground Pressure", "", "1 ground pressure"),
            p("Remote Control", "", "1 RC, 2 RC trim"),
            p("Accelerometer", "", "1 accel, 2 level, 3 temp, 4 simple"),
            p("Compmot or Airspeed", "", "1 compass/motor, 2 airspeed"),
            p("ESC or Baro", "", "1 ESC, 3 baro temperature"),
        ],
    },
    CmdDoc {
        command: MavCmd::MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN,
        description: "Reboot or shut down system components",
        params: [
            p("Autopilot", "", REBOOT),
            p("Companion", "", REBOOT),
            p("Component Action", "", REBOOT),
            p("Component ID", "", "component for param3 (0 all)"),
            UNUSED,
            p("Conditions", "", "0 only when safe, 20190226 force"),
            p("ID", "", "WIP: e.g. camera id, -1 all"),
        ],
    },
    CmdDoc {
        command: MavCmd::MAV_CMD_DO_CHANGE_SPEED,
        description: "Change speed and/or throttle set points",
        params: [
            p("Speed Type", "", "0 air, 1 ground, 2 climb, 3 descent"),
            p("Speed", "m/s", "-1 no change, -2 default"),
            p("Throttle", "%", "-1 no change, -2 default"),
            UNUSED,
            UNUSED,
            UNUSED,
            UNUSED,
        ],
    },
    CmdDoc {
        command: MavCmd::MAV_CMD_DO_SET_HOME,
        description: "Set home to the current or a given position",
        params: [
            p("Use Current", "", "1 current position, 0 the one given"),
            p("Roll", "deg", "of the surface; 0/nan not set"),
            p("Pitch", "deg", "of the surface; 0/nan not set"),
            p("Yaw", "deg", "nan: default heading"),
            LAT,
            LON,
            p("Altitude", "m", ""),
        ],
    },
    CmdDoc {
        command: MavCmd::MAV_CMD_DO_MOTOR_TEST,
        description: "Spin motors for a test",
        params: [
            p("Instance", "", "motor number from 1"),
            p(
                "Throttle Type",
                "",
                "0 percent, 1 PWM, 2 pilot, 3 compass cal",
            ),
            p("Throttle", "", "value in the throttle type"),
            p("Timeout", "s", "between tests in sequence"),
            p("Motor Count", "", "motors to test in sequence"),
            p("Test Order", "", "0 default, 1 sequence, 2 board"),
            UNUSED,
        ],
    },
    CmdDoc {
        command: MavCmd::MAV_CMD_DO_REPOSITION,
        description: "Go to a global position (guided)",
        params: [
            p("Speed", "m/s", "ground speed, -1 default"),
            p("Bitmask", "", "1 change mode, 2 relative yaw"),
            p("Radius", "m", "loiter radius (planes)"),
            p("Yaw", "rad", "nan: current yaw mode"),
            LAT,
            LON,
            p("Altitude", "m", ""),
        ],
    },
    CmdDoc {
        command: MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
        description: "Start capturing images",
        params: [
            p(
                "Target Camera ID",
                "",
                "0 all, 1-6 autopilot's, 7-255 component",
            ),
            p("Interval", "s", "between two pictures"),
            p("Total Images", "", "0 until stopped"),
            p("Sequence Number", "", "from 1 for single captures, else 0"),
            UNUSED,
            UNUSED,
            UNUSED,
        ],
    },
    CmdDoc {
        command: MavCmd::MAV_CMD_VIDEO_START_CAPTURE,
        description: "Start recording video",
        params: [
            p("Stream ID", "", "0 all streams"),
            p(
                "Status Frequency",
                "Hz",
                "CAMERA_CAPTURE_STATUS rate, 0 none",
            ),
            p(
                "Target Camera ID",
                "",
                "0 all, 1-6 autopilot's, 7-255 component",
            ),
            UNUSED,
            UNUSED,
            UNUSED,
            UNUSED,
        ],
    },
];

/// What we know of `command`, if it is one of [`DOCS`].
pub fn doc(command: u16) -> Option<&'static CmdDoc> {
    DOCS.iter().find(|d| d.command as u16 == command)
}

/// Parameter `i` (0-based) of `command`: its label (`param N` when undocumented, `(unused)` when
/// the command does not use it), units and hint.
pub fn param(command: u16, i: usize) -> (String, &'static str, &'static str) {
    match doc(command).and_then(|d| d.params.get(i)) {
        Some(p) if p.label.is_empty() => ("(unused)".into(), "", ""),
        Some(p) => (p.label.to_string(), p.units, p.hint),
        None => (format!("param {}", i + 1), "", ""),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_command_is_listed_once_by_number() {
        let all = all();
        assert!(all.len() > 100, "{}", all.len());
        assert!(all.windows(2).all(|w| w[0].0 < w[1].0));
        assert!(all.contains(&(22, "NAV_TAKEOFF".to_string())));
        assert!(all.contains(&(400, "COMPONENT_ARM_DISARM".to_string())));
    }

    #[test]
    fn documented_commands_are_in_the_dialect() {
        for d in DOCS {
            assert!(all().iter().any(|(n, _)| *n == d.command as u16));
        }
        assert_eq!(DOCS.len(), 15);
    }
}
