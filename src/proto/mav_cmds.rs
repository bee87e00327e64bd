//! Every MAV_CMD of our dialect, by number and name, and what it and its parameters are (label,
//! units, enum, range, the value sent when left empty), from the MAVLink XML definitions the
//! dialect is generated from ([`crate::wire::mavlink_xml`]). The palette searches these and
//! labels its fields with them.

use std::sync::OnceLock;

use num_traits::FromPrimitive;

use crate::dialect::MavCmd;
use crate::wire::mavlink_xml::{self, EntryDef};

/// Every MAV_CMD the dialect knows: (number, name without `MAV_CMD_`), by number.
pub fn all() -> &'static [(u16, String)] {
    static ALL: OnceLock<Vec<(u16, String)>> = OnceLock::new();
    ALL.get_or_init(|| {
        (0..=u16::MAX)
            .filter_map(|n| MavCmd::from_u16(n).map(|_| (n, crate::proto::ack::command_name(n))))
            .collect()
    })
}

/// The commands commonly used from the palette: found first by its search.
pub const COMMON: &[MavCmd] = &[
    MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
    MavCmd::MAV_CMD_NAV_TAKEOFF,
    MavCmd::MAV_CMD_NAV_LAND,
    MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MavCmd::MAV_CMD_DO_SET_MODE,
    MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
    MavCmd::MAV_CMD_REQUEST_MESSAGE,
    MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION,
    MavCmd::MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN,
    MavCmd::MAV_CMD_DO_CHANGE_SPEED,
    MavCmd::MAV_CMD_DO_SET_HOME,
    MavCmd::MAV_CMD_DO_MOTOR_TEST,
    MavCmd::MAV_CMD_DO_REPOSITION,
    MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
    MavCmd::MAV_CMD_VIDEO_START_CAPTURE,
];

/// Whether `command` is one of [`COMMON`].
pub fn is_common(command: u16) -> bool {
    COMMON.iter().any(|c| *c as u16 == command)
}

/// What the XML leaves out for ArduPilot: (command, parameter index 1..=7, note).
const NOTES: &[(MavCmd, u8, &str)] = &[(MavCmd::MAV_CMD_NAV_TAKEOFF, 7, "ArduPilot: above home.")];

/// The definition of `command` in the dialect's XML.
pub fn def(command: u16) -> Option<&'static EntryDef> {
    mavlink_xml::definitions().command(command as u32)
}

/// What `command` does, from the XML (empty when it says nothing).
pub fn description(command: u16) -> &'static str {
    def(command).map_or("", |d| d.description.as_str())
}

/// One parameter of a command, as the palette shows it and sends it when left empty.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamInfo {
    /// `Throttle`; `param N` when the XML gives no label; `(unused)` when the command does not
    /// use it (reserved, `Empty` or not listed).
    pub label: String,
    pub units: &'static str,
    /// The XML's description of it, with a note of ours where the XML leaves something out.
    pub description: String,
    /// The enum its values are of (empty when none) and those values, `0 AIRSPEED, 1 …`.
    pub enum_name: &'static str,
    pub values: String,
    pub min: Option<f64>,
    pub max: Option<f64>,
    pub increment: Option<f64>,
    /// Sent when the field is left empty: the `default` attribute; else the value the
    /// description names for "no change" or "use the current/default" (`-1 indicates no
    /// change`, `NaN to use the current yaw`); else 0.
    pub default: f64,
    pub used: bool,
}

/// Parameter `i` (0-based) of `command`, from the XML.
pub fn param_info(command: u16, i: usize) -> ParamInfo {
    let index = i as u8 + 1;
    let mut info = ParamInfo {
        label: format!("param {index}"),
        units: "",
        description: String::new(),
        enum_name: "",
        values: String::new(),
        min: None,
        max: None,
        increment: None,
        default: 0.0,
        used: true,
    };
    let Some(d) = def(command) else {
        return info;
    };
    let Some(p) = d.param(index) else {
        // Not listed: not used.
        info.label = "(unused)".into();
        info.used = false;
        return info;
    };
    let empty = p.description.is_empty() || p.description.starts_with("Empty");
    if p.reserved || (p.label.is_empty() && empty) {
        info.label = "(unused)".into();
        info.used = false;
        info.default = p.default.unwrap_or(0.0);
        return info;
    }
    if !p.label.is_empty() {
        info.label = p.label.clone();
    }
    info.units = p.units.as_str();
    // COMMAND_LONG carries latitude and longitude as degrees (COMMAND_INT as degE7).
    if d.has_location && p.units.is_empty() && (index == 5 || index == 6) {
        info.units = "deg";
    }
    info.description = p.description.clone();
    if let Some((_, _, note)) = NOTES
        .iter()
        .find(|(c, n, _)| *c as u16 == command && *n == index)
    {
        info.description = format!("{note} {}", info.description);
    }
    info.enum_name = p.enum_name.as_str();
    info.values = enum_values(&p.enum_name);
    info.min = p.min;
    info.max = p.max;
    info.increment = p.increment;
    info.default = p
        .default
        .unwrap_or_else(|| described_default(&p.description));
    info
}

/// The value a parameter's description names for "leave it as it is": `-1 indicates no
/// change`, `NaN to use the current …`; 0 when it names none.
pub fn described_default(description: &str) -> f64 {
    let d = description.to_ascii_lowercase();
    const MINUS_ONE: &[&str] = &[
        "-1 indicates no change",
        "-1: leave unchanged",
        "-1 to ignore",
        "(-1) for default",
    ];
    const NAN: &[&str] = &[
        "nan for no change",
        "nan to use",
        "nan: use",
        "nan to ignore",
        "nan if unspecified",
        "nan if not known",
        "set to nan if",
        "sent as nan",
        "or nan if sent in command_long",
    ];
    if MINUS_ONE.iter().any(|p| d.contains(p)) {
        -1.0
    } else if NAN.iter().any(|p| d.contains(p)) {
        f64::NAN
    } else {
        0.0
    }
}

/// An enum's values as `0 NAME, 1 NAME`, the enum's common prefix left off.
fn enum_values(name: &str) -> String {
    let Some(e) = mavlink_xml::definitions().enum_def(name) else {
        return String::new();
    };
    let prefix = format!("{name}_");
    e.entries
        .iter()
        .map(|x| {
            let short = x.name.strip_prefix(&prefix).unwrap_or(&x.name);
            format!("{} {short}", x.value)
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Parameter `i` (0-based) of `command`: its label (`param N` when the XML gives none,
/// `(unused)` when the command does not use it), units and a hint (its values when it has an
/// enum, else its description).
pub fn param(command: u16, i: usize) -> (String, &'static str, String) {
    let p = param_info(command, i);
    let hint = if p.values.is_empty() {
        p.description
    } else {
        p.values
    };
    (p.label, p.units, hint)
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
    fn parameters_come_from_the_xml() {
        let speed = MavCmd::MAV_CMD_DO_CHANGE_SPEED as u16;
        let p = param_info(speed, 2);
        assert_eq!((p.label.as_str(), p.units), ("Throttle", "%"));
        // common.xml: "-1 indicates no change".
        assert_eq!(p.default, -1.0);
        assert_eq!(p.min, Some(-2.0));
        assert_eq!(param_info(speed, 1).default, -1.0);
        let t = param_info(speed, 0);
        assert_eq!(t.enum_name, "SPEED_TYPE");
        assert!(
            t.values.starts_with("0 AIRSPEED, 1 GROUNDSPEED"),
            "{}",
            t.values
        );
        assert!(!param_info(speed, 3).used);
        assert!(description(MavCmd::MAV_CMD_DO_SET_SERVO as u16).starts_with("Set a servo"));
        // Latitude in COMMAND_LONG: degrees.
        let takeoff = MavCmd::MAV_CMD_NAV_TAKEOFF as u16;
        assert_eq!(param(takeoff, 4).1, "deg");
        assert!(
            param_info(takeoff, 3).default.is_nan(),
            "NaN: the current yaw mode"
        );
        assert!(param_info(takeoff, 6)
            .description
            .starts_with("ArduPilot: above home."));
        assert!(param_info(2000, 6).default.is_nan());
        assert_eq!(param(400, 2).0, "(unused)");
        for c in COMMON {
            assert!(all().iter().any(|(n, _)| *n == *c as u16));
            assert!(!description(*c as u16).is_empty(), "{c:?}");
        }
    }
}
