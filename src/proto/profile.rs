//! What differs between autopilot families, in one place: one profile per family, as
//! QGroundControl's firmware plugins (`FirmwarePlugin`, `APMFirmwarePlugin`,
//! `PX4FirmwarePlugin`) are. Everything else in mavterm asks the profile of the vehicle's
//! HEARTBEAT autopilot instead of testing `MAV_AUTOPILOT_*` itself; a new family is one more
//! `impl Profile` and one more arm in [`of`].
//!
//! [`Profile`]'s default methods are generic MAVLink: what the MAVLink specification says when
//! an autopilot says nothing more (bytewise parameters, no home item in the mission, COMMAND_LONG
//! altitudes above mean sea level, SET_MESSAGE_INTERVAL). ArduPilot and PX4 override what they do
//! otherwise. AUTOPILOT_VERSION's capability bits, where they speak (PARAM_ENCODE_*, FTP), are
//! applied by the machines over the profile's default.

use crate::dialect::{MavAutopilot, MavModeFlag, MavType};
use crate::params::value::Encoding;

/// Which flight-mode table a vehicle uses (the tables are in `proto::modes`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModeTable {
    ArduCopter,
    ArduPlane,
    ArduRover,
    ArduSub,
    Px4,
    None,
}

/// One step of starting a mission on a disarmed vehicle ([`Profile::start_disarmed`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StartStep {
    /// Switch to this mode (skipped when the vehicle is in it already).
    Mode(&'static str),
    Arm,
    /// Take off to the mission's first item's altitude.
    Takeoff,
    /// MAV_CMD_MISSION_START.
    MissionStart,
}

/// One autopilot family's ways.
pub trait Profile: Sync + std::fmt::Debug {
    /// The family's name, for people.
    fn name(&self) -> &'static str;

    /// How integer parameters ride in PARAM_VALUE / PARAM_SET's float when AUTOPILOT_VERSION
    /// announces neither PARAM_ENCODE_BYTEWISE nor PARAM_ENCODE_C_CAST. The parameter protocol's
    /// default is bytewise.
    fn param_encoding(&self) -> Encoding {
        Encoding::Bytewise
    }

    /// Whether mission items are asked for as MISSION_REQUEST_INT when AUTOPILOT_VERSION is not
    /// heard (where it is, its MAV_PROTOCOL_CAPABILITY_MISSION_INT bit decides). ArduPilot, PX4
    /// and the spec's current protocol all use the INT forms.
    fn mission_int(&self) -> bool {
        true
    }

    /// Whether VFR_HUD is expected to carry speed, climb and heading; without it (or while it is
    /// not fresh) GLOBAL_POSITION_INT's velocities and heading stand in.
    fn vfr_hud_motion(&self) -> bool {
        true
    }

    /// Whether the vehicle's mission holds home as item 0 (real items from 1). The mission
    /// protocol does not reserve seq 0; only ArduPilot does.
    fn mission_home_item(&self) -> bool {
        false
    }

    /// The flight-mode table for a vehicle of this type.
    fn mode_table(&self, _mavtype: MavType) -> ModeTable {
        ModeTable::None
    }

    /// Whether HEARTBEAT `custom_mode` is the mode even without MAV_MODE_FLAG_CUSTOM_MODE_ENABLED.
    fn custom_mode_always(&self) -> bool {
        false
    }

    /// DO_SET_MODE's parameters for `custom_mode`: the spec's param2 = custom mode.
    fn set_mode_params(&self, custom_mode: u32) -> [f64; 7] {
        [custom_base(), custom_mode as f64, 0., 0., 0., 0., 0.]
    }

    /// The mode a take-off must be made in (switched to first), if any.
    fn takeoff_mode(&self) -> Option<&'static str> {
        None
    }

    /// MAV_CMD_NAV_TAKEOFF's parameters for `alt` metres above home, given home's altitude
    /// above mean sea level when known. The spec: param7 is the altitude in the command's frame,
    /// which for COMMAND_LONG is global (above mean sea level); yaw unset.
    fn takeoff_params(&self, alt: f64, home_amsl: Option<f64>) -> Result<[f64; 7], String> {
        let home = home_amsl.ok_or("home altitude not known yet: wait for GLOBAL_POSITION_INT")?;
        let nan = f64::NAN;
        Ok([-1.0, 0., 0., nan, nan, nan, home + alt])
    }

    /// The mode a mission is flown in (switched to before MISSION_START), if any.
    fn mission_mode(&self) -> Option<&'static str> {
        None
    }

    /// How a disarmed vehicle of type `mavtype` is started on its mission, in order. The spec:
    /// arm, then MAV_CMD_MISSION_START.
    fn start_disarmed(&self, _mavtype: MavType) -> &'static [StartStep] {
        &[StartStep::Arm, StartStep::MissionStart]
    }

    /// The mode that guided commands (goto, nudges) need, checked before they are sent.
    fn guided_mode(&self) -> Option<&'static str> {
        None
    }

    /// Whether DO_REPOSITION carries MAV_DO_REPOSITION_FLAGS_CHANGE_MODE (the vehicle acts on it
    /// only then).
    fn reposition_changes_mode(&self) -> bool {
        true
    }

    /// Whether telemetry is asked by REQUEST_DATA_STREAM groups first (then SET_MESSAGE_INTERVAL
    /// for what the groups do not bring) and with the family's own list of messages.
    fn stream_groups(&self) -> bool {
        false
    }

    /// Whether a message that does not come by SET_MESSAGE_INTERVAL is asked by its
    /// REQUEST_DATA_STREAM group instead (the older protocol, which the spec deprecates but many
    /// stacks still serve).
    fn group_fallback(&self) -> bool {
        true
    }

    /// The MAVFTP file the whole parameter set is read from, if the family serves one.
    fn param_file(&self) -> Option<&'static str> {
        None
    }

    /// Whether parameter metadata is asked of the vehicle by the component metadata protocol
    /// as soon as it is heard (`proto::comp_meta`), as QGroundControl does at connect.
    fn component_metadata(&self) -> bool {
        false
    }

    /// Whether the vehicle runs ArduPilot's calibration protocols: the six-position
    /// accelerometer calibration driven by MAV_CMD_ACCELCAL_VEHICLE_POS (`AP_AccelCal`), the
    /// onboard compass calibration (DO_START_MAG_CAL, MAG_CAL_PROGRESS / REPORT, DO_ACCEPT /
    /// DO_CANCEL_MAG_CAL) and FIXED_MAG_CAL_YAW. Elsewhere they are refused before anything is
    /// sent (PX4 drives its own accelerometer and compass calibrations by STATUSTEXT).
    fn ardupilot_calibrations(&self) -> bool {
        false
    }

    /// How often the vehicle states its failing pre-arm checks on its own while disarmed, if
    /// it does: a reason not stated again within two periods is dropped. `None`: a reason
    /// stays until the vehicle arms, its SYS_STATUS says the checks pass, or an answered
    /// RUN_PREARM_CHECKS leaves it out.
    fn prearm_period(&self) -> Option<crate::clock::Micros> {
        None
    }
}

fn custom_base() -> f64 {
    MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED.bits() as f64
}

/// What the MAVLink specification says, for an autopilot we know nothing more of.
#[derive(Debug)]
pub struct Generic;

/// ArduPilot (Copter, Plane, Rover, Sub).
#[derive(Debug)]
pub struct ArduPilot;

/// PX4.
#[derive(Debug)]
pub struct Px4;

impl Profile for Generic {
    fn name(&self) -> &'static str {
        "generic MAVLink"
    }
}

/// What is read over MAVFTP (with defaults, as MAVProxy asks, so non-default values can be
/// told apart).
pub const ARDUPILOT_PARAM_FILE: &str = "@PARAM/param.pck?withdefaults=1";

impl Profile for ArduPilot {
    fn name(&self) -> &'static str {
        "ArduPilot"
    }
    /// ArduPilot casts the value into the float (`AP_Param`), and says so in AUTOPILOT_VERSION
    /// (PARAM_ENCODE_C_CAST) since 4.x; QGroundControl's APM plugin and MAVSDK assume it.
    fn param_encoding(&self) -> Encoding {
        Encoding::CCast
    }
    fn mission_home_item(&self) -> bool {
        true
    }
    fn mode_table(&self, mavtype: MavType) -> ModeTable {
        match ArduVehicle::of(mavtype) {
            Some(ArduVehicle::Copter) => ModeTable::ArduCopter,
            Some(ArduVehicle::Plane) => ModeTable::ArduPlane,
            Some(ArduVehicle::Rover) => ModeTable::ArduRover,
            Some(ArduVehicle::Sub) => ModeTable::ArduSub,
            _ => ModeTable::None,
        }
    }
    fn custom_mode_always(&self) -> bool {
        true
    }
    /// ArduPilot takes off only in GUIDED.
    fn takeoff_mode(&self) -> Option<&'static str> {
        Some("GUIDED")
    }
    /// ArduPilot: param7 is metres above home; the rest zero.
    fn takeoff_params(&self, alt: f64, _home_amsl: Option<f64>) -> Result<[f64; 7], String> {
        Ok([0., 0., 0., 0., 0., 0., alt])
    }
    fn mission_mode(&self) -> Option<&'static str> {
        Some("AUTO")
    }
    fn guided_mode(&self) -> Option<&'static str> {
        Some("GUIDED")
    }
    /// ArduCopter does not arm in AUTO by default (AUTO_OPTIONS) nor take off from it: GUIDED,
    /// arm, NAV_TAKEOFF, then AUTO and MISSION_START. Plane, Rover and Sub: arm, AUTO, then
    /// MISSION_START.
    fn start_disarmed(&self, mavtype: MavType) -> &'static [StartStep] {
        use StartStep::*;
        match self.mode_table(mavtype) {
            ModeTable::ArduCopter => &[Mode("GUIDED"), Arm, Takeoff, Mode("AUTO"), MissionStart],
            _ => &[Arm, Mode("AUTO"), MissionStart],
        }
    }
    /// ArduPilot repositions in GUIDED without the flag (and refuses it outside GUIDED).
    fn reposition_changes_mode(&self) -> bool {
        false
    }
    /// ArduPilot honours REQUEST_DATA_STREAM per serial port.
    fn stream_groups(&self) -> bool {
        true
    }
    fn param_file(&self) -> Option<&'static str> {
        Some(ARDUPILOT_PARAM_FILE)
    }
    fn ardupilot_calibrations(&self) -> bool {
        true
    }
    /// `AP_Arming::update`: every 30 s (PREARM_DISPLAY_PERIOD) while disarmed and failing.
    fn prearm_period(&self) -> Option<crate::clock::Micros> {
        Some(crate::proto::health::PREARM_PERIOD)
    }
}

impl Profile for Px4 {
    fn name(&self) -> &'static str {
        "PX4"
    }
    fn mode_table(&self, _mavtype: MavType) -> ModeTable {
        ModeTable::Px4
    }
    /// PX4: main mode in param2, sub mode in param3 (`px4_custom_mode.h`).
    fn set_mode_params(&self, custom_mode: u32) -> [f64; 7] {
        [
            custom_base(),
            ((custom_mode >> 16) & 0xFF) as f64,
            (custom_mode >> 24) as f64,
            0.,
            0.,
            0.,
            0.,
        ]
    }
    fn mission_mode(&self) -> Option<&'static str> {
        Some("MISSION")
    }
    /// PX4 starts the mission itself once armed in MISSION mode.
    fn start_disarmed(&self, _mavtype: MavType) -> &'static [StartStep] {
        &[StartStep::Arm, StartStep::Mode("MISSION")]
    }
    /// PX4 serves SET_MESSAGE_INTERVAL only.
    fn group_fallback(&self) -> bool {
        false
    }
    /// PX4 announces COMPONENT_METADATA (`streams/COMPONENT_METADATA.hpp`).
    fn component_metadata(&self) -> bool {
        true
    }
}

static GENERIC: Generic = Generic;
static ARDUPILOT: ArduPilot = ArduPilot;
static PX4: Px4 = Px4;

/// The profile of a HEARTBEAT's autopilot.
pub fn of(autopilot: MavAutopilot) -> &'static dyn Profile {
    match autopilot {
        MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA => &ARDUPILOT,
        MavAutopilot::MAV_AUTOPILOT_PX4 => &PX4,
        _ => &GENERIC,
    }
}

/// ArduPilot's firmware families, by the HEARTBEAT type each runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ArduVehicle {
    Copter,
    Plane,
    Rover,
    Sub,
    Tracker,
    Blimp,
}

impl ArduVehicle {
    /// The firmware an ArduPilot vehicle of type `mavtype` runs, if any.
    pub fn of(mavtype: MavType) -> Option<Self> {
        use MavType::*;
        Some(match mavtype {
            MAV_TYPE_QUADROTOR | MAV_TYPE_HEXAROTOR | MAV_TYPE_OCTOROTOR | MAV_TYPE_TRICOPTER
            | MAV_TYPE_COAXIAL | MAV_TYPE_HELICOPTER | MAV_TYPE_DODECAROTOR
            | MAV_TYPE_DECAROTOR => ArduVehicle::Copter,
            MAV_TYPE_FIXED_WING
            | MAV_TYPE_VTOL_TAILSITTER_DUOROTOR
            | MAV_TYPE_VTOL_TAILSITTER_QUADROTOR
            | MAV_TYPE_VTOL_TILTROTOR
            | MAV_TYPE_VTOL_FIXEDROTOR
            | MAV_TYPE_VTOL_TAILSITTER
            | MAV_TYPE_VTOL_TILTWING
            | MAV_TYPE_VTOL_RESERVED5 => ArduVehicle::Plane,
            MAV_TYPE_GROUND_ROVER | MAV_TYPE_SURFACE_BOAT => ArduVehicle::Rover,
            MAV_TYPE_SUBMARINE => ArduVehicle::Sub,
            MAV_TYPE_ANTENNA_TRACKER => ArduVehicle::Tracker,
            MAV_TYPE_AIRSHIP => ArduVehicle::Blimp,
            _ => return None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use MavAutopilot::*;

    #[test]
    fn only_ardupilot_is_c_cast_and_holds_home() {
        // MAVLink parameter protocol: bytewise unless the autopilot says (or is known) otherwise.
        for a in [
            MAV_AUTOPILOT_GENERIC,
            MAV_AUTOPILOT_PX4,
            MAV_AUTOPILOT_SLUGS,
            MAV_AUTOPILOT_INVALID,
        ] {
            assert_eq!(of(a).param_encoding(), Encoding::Bytewise, "{a:?}");
            assert!(!of(a).mission_home_item(), "{a:?}");
        }
        assert_eq!(
            of(MAV_AUTOPILOT_ARDUPILOTMEGA).param_encoding(),
            Encoding::CCast
        );
        assert!(of(MAV_AUTOPILOT_ARDUPILOTMEGA).mission_home_item());
    }

    #[test]
    fn takeoff_altitudes_per_family() {
        // ArduPilot: above home. PX4 and the spec: above mean sea level.
        let ap = of(MAV_AUTOPILOT_ARDUPILOTMEGA)
            .takeoff_params(10.0, None)
            .unwrap();
        assert_eq!(ap[6], 10.0);
        let px4 = of(MAV_AUTOPILOT_PX4)
            .takeoff_params(10.0, Some(488.0))
            .unwrap();
        assert_eq!(px4[6], 498.0);
        assert!(of(MAV_AUTOPILOT_GENERIC)
            .takeoff_params(10.0, None)
            .is_err());
    }

    #[test]
    fn starting_a_mission_from_disarmed_per_family() {
        use StartStep::*;
        assert_eq!(
            of(MAV_AUTOPILOT_ARDUPILOTMEGA).start_disarmed(MavType::MAV_TYPE_QUADROTOR),
            &[Mode("GUIDED"), Arm, Takeoff, Mode("AUTO"), MissionStart]
        );
        assert_eq!(
            of(MAV_AUTOPILOT_PX4).start_disarmed(MavType::MAV_TYPE_QUADROTOR),
            &[Arm, Mode("MISSION")]
        );
        assert_eq!(
            of(MAV_AUTOPILOT_GENERIC).start_disarmed(MavType::MAV_TYPE_QUADROTOR),
            &[Arm, MissionStart]
        );
    }

    #[test]
    fn px4_mode_goes_in_param2_and_param3() {
        // AUTO (4) / MISSION (4): 0x04040000.
        let p = of(MAV_AUTOPILOT_PX4).set_mode_params(0x0404_0000);
        assert_eq!((p[0], p[1], p[2]), (1.0, 4.0, 4.0));
        let p = of(MAV_AUTOPILOT_ARDUPILOTMEGA).set_mode_params(4);
        assert_eq!((p[0], p[1], p[2]), (1.0, 4.0, 0.0));
    }

    #[test]
    fn ardupilot_calibrations_and_prearm_repeats_are_ardupilots_alone() {
        let ap = of(MAV_AUTOPILOT_ARDUPILOTMEGA);
        assert!(ap.ardupilot_calibrations());
        assert_eq!(ap.prearm_period(), Some(30 * crate::clock::SECOND));
        for a in [MAV_AUTOPILOT_PX4, MAV_AUTOPILOT_GENERIC] {
            assert!(!of(a).ardupilot_calibrations(), "{a:?}");
            assert_eq!(of(a).prearm_period(), None, "{a:?}");
        }
    }
}
