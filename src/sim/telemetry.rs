//! Building the messages a vehicle sends, from its state. Values are plausible for a small quad
//! at the SITL home; jitter comes from the vehicle's seeded RNG so output stays deterministic.

use super::params::{mav_type, ParamTable};
use super::streams::id;
use super::vehicle::{mode, Out, SimVehicle};
use crate::dialect::*;
use crate::wire::mavftp::FtpPacket;

/// What the banner calls the firmware: the ArduCopter version the parameter set comes from
/// ([`super::ARDUCOPTER_VERSION`]), "(sim)" where a real build puts its git hash.
pub const FIRMWARE_STRING: &str = concat!("ArduCopter V", arducopter_version!(), " (sim)");
/// flight_sw_version as that build sends it: major, minor, patch, then the version type
/// (FIRMWARE_VERSION_TYPE_DEV = 0 for a `-dev` build; the capture's AUTOPILOT_VERSION says
/// 0x04070000).
#[allow(clippy::identity_op)] // the fields spelled out, zeros too
pub const FLIGHT_SW_VERSION: u32 = (4 << 24) | (7 << 16) | (0 << 8) | FIRMWARE_VERSION_TYPE_DEV;
/// MAVLink's FIRMWARE_VERSION_TYPE_DEV.
const FIRMWARE_VERSION_TYPE_DEV: u32 = 0;
/// Unix time the simulated GPS reports at boot (2024-01-01T00:00:00Z), fixed for determinism.
pub const GPS_EPOCH_US: u64 = 1_704_067_200_000_000;

pub fn statustext(severity: MavSeverity, s: &str) -> MavMessage {
    MavMessage::STATUSTEXT(STATUSTEXT_DATA {
        severity,
        text: s.into(),
        id: 0,
        chunk_seq: 0,
    })
}

/// PARAM_VALUE for table entry `i`: the value C-cast to float, with its type, as ArduPilot sends
/// it, carrying `param_index` and `param_count` as given (65535 is ArduPilot's -1: a value sent
/// because it was set or asked for by name, not as part of the list).
pub fn param_value_indexed(
    params: &ParamTable,
    i: usize,
    param_index: u16,
    param_count: u16,
) -> MavMessage {
    let p = params.get(i).expect("index checked by caller");
    MavMessage::PARAM_VALUE(PARAM_VALUE_DATA {
        param_value: p.value as f32,
        param_count,
        param_index,
        param_id: p.name.as_str().into(),
        param_type: mav_type(p.ptype),
    })
}

/// `GCS::send_parameter_value` / `GCS_MAVLINK::send_parameter_value`: entry `i` with index -1
/// and the current parameter count.
pub fn param_value_notify(params: &ParamTable, i: usize) -> MavMessage {
    let count = params.len().min(u16::MAX as usize) as u16;
    param_value_indexed(params, i, u16::MAX, count)
}

pub fn ftp_message(to: (u8, u8), p: &FtpPacket) -> MavMessage {
    MavMessage::FILE_TRANSFER_PROTOCOL(FILE_TRANSFER_PROTOCOL_DATA {
        target_network: 0,
        target_system: to.0,
        target_component: to.1,
        payload: p.to_payload(),
    })
}

pub fn command_ack(command: MavCmd, result: MavResult, to: (u8, u8)) -> MavMessage {
    MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
        command,
        result,
        progress: 0,
        result_param2: 0,
        target_system: to.0,
        target_component: to.1,
    })
}

/// COMMAND_ACK for a command id the dialect's MavCmd cannot hold (ArduPilot acknowledges the
/// SET_MODE message with command = 11, its message id), built by hand.
pub(super) fn raw_command_ack(command: u16, result: MavResult, to: (u8, u8)) -> Out {
    // command u16, result u8, progress u8, result_param2 i32, target_system, target_component.
    let mut payload = Vec::with_capacity(10);
    payload.extend_from_slice(&command.to_le_bytes());
    payload.push(result as u8);
    payload.extend_from_slice(&[0, 0, 0, 0, 0, to.0, to.1]);
    Out::Raw {
        msgid: <COMMAND_ACK_DATA as mavlink::MessageData>::ID,
        payload,
    }
}

fn deg_e7(d: f64) -> i32 {
    (d * 1e7).round() as i32
}

impl SimVehicle {
    pub(super) fn time_boot_ms(&self) -> u32 {
        (self.now / 1000) as u32
    }

    /// Course over ground, degrees (0 when not moving).
    fn course_deg(&self) -> f64 {
        if self.vn != 0.0 || self.ve != 0.0 {
            self.ve.atan2(self.vn).to_degrees().rem_euclid(360.0)
        } else {
            0.0
        }
    }

    fn voltage(&self) -> f64 {
        let cap = self
            .params
            .value("BATT_CAPACITY")
            .unwrap_or(3300.0)
            .max(1.0);
        let frac = (1.0 - self.consumed_mah / cap).clamp(0.0, 1.0);
        let sag = if self.armed && !self.landed { 0.4 } else { 0.0 };
        10.5 + 2.1 * frac - sag
    }

    fn remaining_pct(&self) -> i8 {
        let cap = self
            .params
            .value("BATT_CAPACITY")
            .unwrap_or(3300.0)
            .max(1.0);
        ((1.0 - self.consumed_mah / cap) * 100.0)
            .clamp(0.0, 100.0)
            .round() as i8
    }

    fn current_ca(&self) -> i16 {
        match (self.armed, self.landed) {
            (false, _) => 50,
            (true, true) => 300,
            (true, false) => 1500,
        }
    }

    pub(super) fn heartbeat(&self) -> MavMessage {
        let mut base = MavModeFlag::MAV_MODE_FLAG_STABILIZE_ENABLED
            | MavModeFlag::MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
            | MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
        if mode::guided_flag(self.custom_mode) {
            base |= MavModeFlag::MAV_MODE_FLAG_GUIDED_ENABLED;
        }
        if self.armed {
            base |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
        }
        MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: self.custom_mode,
            mavtype: MavType::MAV_TYPE_QUADROTOR,
            autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode: base,
            // As the real ArduCopter capture shows: STANDBY until airborne, even when armed.
            system_status: if self.armed && !self.landed {
                MavState::MAV_STATE_ACTIVE
            } else {
                MavState::MAV_STATE_STANDBY
            },
            mavlink_version: 3,
        })
    }

    /// `GCS_MAVLINK_Copter::capabilities()` | `GCS_MAVLINK::capabilities()`: MISSION_FLOAT,
    /// MISSION_INT, COMMAND_INT, SET_POSITION_TARGET_LOCAL_NED and _GLOBAL_INT,
    /// FLIGHT_TERMINATION, SET_ATTITUDE_TARGET, TERRAIN while TERRAIN_ENABLE is set; PARAM_FLOAT,
    /// COMPASS_CALIBRATION, MAVLINK2 on a MAVLink2 port, MISSION_FENCE and MISSION_RALLY, FTP
    /// in a build with MAVFTP unless BRD_OPTIONS disables it. The real ArduCopter capture
    /// (tests/data/copter-flight.vehicle.tlog) announces exactly these: 64495. ArduPilot does not
    /// set PARAM_ENCODE_C_CAST (its common.xml lacks the flag) nor PARAM_ENCODE_BYTEWISE.
    #[allow(deprecated)]
    pub(super) fn capabilities(&self) -> MavProtocolCapability {
        use MavProtocolCapability as C;
        let mut caps = C::MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
            | C::MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
            | C::MAV_PROTOCOL_CAPABILITY_MISSION_INT
            | C::MAV_PROTOCOL_CAPABILITY_COMMAND_INT
            | C::MAV_PROTOCOL_CAPABILITY_SET_ATTITUDE_TARGET
            | C::MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
            | C::MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
            | C::MAV_PROTOCOL_CAPABILITY_FLIGHT_TERMINATION
            | C::MAV_PROTOCOL_CAPABILITY_COMPASS_CALIBRATION
            | C::MAV_PROTOCOL_CAPABILITY_MAVLINK2
            | C::MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
            | C::MAV_PROTOCOL_CAPABILITY_MISSION_RALLY;
        if self.params.value("TERRAIN_ENABLE").unwrap_or(1.0) != 0.0 {
            caps |= C::MAV_PROTOCOL_CAPABILITY_TERRAIN;
        }
        if self.ftp_enabled() {
            caps |= C::MAV_PROTOCOL_CAPABILITY_FTP;
        }
        caps
    }

    pub(super) fn autopilot_version(&self) -> MavMessage {
        let caps = self.capabilities();
        MavMessage::AUTOPILOT_VERSION(AUTOPILOT_VERSION_DATA {
            capabilities: caps,
            uid: 0x5349_4D00_0000_0000 | self.sysid as u64,
            flight_sw_version: FLIGHT_SW_VERSION,
            middleware_sw_version: 0,
            os_sw_version: 0,
            board_version: 0,
            vendor_id: 0x1209,
            product_id: 0x5740,
            flight_custom_version: *b"sim00000",
            middleware_custom_version: [0; 8],
            os_custom_version: [0; 8],
            uid2: [0; 18],
        })
    }

    pub(super) fn gps_global_origin(&self) -> MavMessage {
        MavMessage::GPS_GLOBAL_ORIGIN(GPS_GLOBAL_ORIGIN_DATA {
            latitude: deg_e7(self.origin.0),
            longitude: deg_e7(self.origin.1),
            altitude: (self.origin.2 * 1000.0).round() as i32,
            time_usec: self.now,
        })
    }

    pub(super) fn home_position(&self) -> MavMessage {
        MavMessage::HOME_POSITION(HOME_POSITION_DATA {
            latitude: deg_e7(self.home.0),
            longitude: deg_e7(self.home.1),
            altitude: (self.home.2 * 1000.0).round() as i32,
            q: [1.0, 0.0, 0.0, 0.0],
            time_usec: self.now,
            ..Default::default()
        })
    }

    /// Build message `msgid` from the current state, or `None` if the simulator does not
    /// produce it.
    pub(super) fn build(&mut self, msgid: u32) -> Option<MavMessage> {
        let t_ms = self.time_boot_ms();
        // ArduPilot's location: none (zeros) until the GPS has a fix, as in the real capture.
        let (lat, lon) = if self.gps_fix {
            self.lat_lon()
        } else {
            (0.0, 0.0)
        };
        let amsl = self.home.2 + self.alt;
        let loc_alt = if self.gps_fix { amsl } else { 0.0 };
        let groundspeed = self.vn.hypot(self.ve);
        let heading = self.yaw;
        let course = self.course_deg();
        let m = match msgid {
            id::GIMBAL_MANAGER_INFORMATION => self.mount.as_ref()?.information(t_ms),
            id::GIMBAL_MANAGER_STATUS => self.mount.as_ref()?.status(t_ms),
            id::GIMBAL_DEVICE_ATTITUDE_STATUS => self.mount.as_ref()?.attitude(t_ms),
            id::HEARTBEAT => self.heartbeat(),
            id::AUTOPILOT_VERSION => self.autopilot_version(),
            id::HOME_POSITION => {
                if !self.ekf_gps {
                    return None;
                }
                self.home_position()
            }
            id::GPS_GLOBAL_ORIGIN => {
                if !self.ekf_gps {
                    return None;
                }
                self.gps_global_origin()
            }
            id::SYS_STATUS => {
                let sensors = MavSysStatusSensor::from_bits_truncate(0x0120_FC2F);
                // `uncal=1`: the pre-arm bit, healthy when the checks pass (ArduPilot's
                // AP_Arming::get_pre_arm_check).
                let prearm = MavSysStatusSensor::MAV_SYS_STATUS_PREARM_CHECK;
                let (present, health) = match (self.cal.reports_prearm, self.prearm_passing()) {
                    (false, _) => (sensors, sensors),
                    (true, true) => (sensors | prearm, sensors | prearm),
                    (true, false) => (sensors | prearm, sensors),
                };
                MavMessage::SYS_STATUS(SYS_STATUS_DATA {
                    onboard_control_sensors_present: present,
                    onboard_control_sensors_enabled: present,
                    onboard_control_sensors_health: health,
                    load: 150,
                    voltage_battery: (self.voltage() * 1000.0) as u16,
                    current_battery: self.current_ca(),
                    battery_remaining: self.remaining_pct(),
                    ..Default::default()
                })
            }
            id::SYSTEM_TIME => MavMessage::SYSTEM_TIME(SYSTEM_TIME_DATA {
                time_unix_usec: if self.gps_fix {
                    GPS_EPOCH_US + self.now
                } else {
                    0
                },
                time_boot_ms: t_ms,
            }),
            id::GPS_RAW_INT => {
                let (glat, glon) = if self.gps_fix {
                    self.lat_lon()
                } else {
                    (0.0, 0.0)
                };
                MavMessage::GPS_RAW_INT(GPS_RAW_INT_DATA {
                    time_usec: self.now,
                    lat: deg_e7(glat),
                    lon: deg_e7(glon),
                    alt: if self.gps_fix {
                        (amsl * 1000.0) as i32
                    } else {
                        0
                    },
                    eph: if self.gps_fix { 121 } else { u16::MAX },
                    epv: if self.gps_fix { 200 } else { u16::MAX },
                    vel: (groundspeed * 100.0) as u16,
                    cog: (course * 100.0) as u16,
                    fix_type: if self.gps_fix {
                        GpsFixType::GPS_FIX_TYPE_3D_FIX
                    } else {
                        GpsFixType::GPS_FIX_TYPE_NO_GPS
                    },
                    satellites_visible: if self.gps_fix { 10 } else { 0 },
                    ..Default::default()
                })
            }
            id::GLOBAL_POSITION_INT => MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
                time_boot_ms: t_ms,
                lat: deg_e7(lat),
                lon: deg_e7(lon),
                alt: (loc_alt * 1000.0).round() as i32,
                relative_alt: (self.alt * 1000.0).round() as i32,
                vx: (self.vn * 100.0).round() as i16,
                vy: (self.ve * 100.0).round() as i16,
                vz: (-self.vu * 100.0).round() as i16,
                hdg: ((heading * 100.0).round() as u16) % 36000,
            }),
            id::LOCAL_POSITION_NED => MavMessage::LOCAL_POSITION_NED(LOCAL_POSITION_NED_DATA {
                time_boot_ms: t_ms,
                x: self.north as f32,
                y: self.east as f32,
                z: -self.alt as f32,
                vx: self.vn as f32,
                vy: self.ve as f32,
                vz: -self.vu as f32,
            }),
            id::ATTITUDE => {
                let a = if self.armed && !self.landed {
                    0.02
                } else {
                    0.002
                };
                MavMessage::ATTITUDE(ATTITUDE_DATA {
                    time_boot_ms: t_ms,
                    roll: self.rng.jitter(a) as f32,
                    pitch: (self.rng.jitter(a) - groundspeed * 0.02) as f32,
                    yaw: {
                        let y = heading.to_radians();
                        (if y > std::f64::consts::PI {
                            y - 2.0 * std::f64::consts::PI
                        } else {
                            y
                        }) as f32
                    },
                    rollspeed: self.rng.jitter(a) as f32,
                    pitchspeed: self.rng.jitter(a) as f32,
                    yawspeed: self.rng.jitter(a / 2.0) as f32,
                })
            }
            // ArduCopter's airspeed is the length of its (3D) airspeed estimate, so it includes
            // the climb rate; heading is the yaw; throttle about 35 % hovering (real capture).
            id::VFR_HUD => MavMessage::VFR_HUD(VFR_HUD_DATA {
                airspeed: groundspeed.hypot(self.vu) as f32,
                groundspeed: groundspeed as f32,
                alt: loc_alt as f32,
                climb: self.vu as f32,
                heading: heading.round() as i16 % 360,
                throttle: if self.armed && !self.landed { 35 } else { 0 },
            }),
            id::BATTERY_STATUS => {
                let mut voltages = [u16::MAX; 10];
                voltages[0] = (self.voltage() * 1000.0) as u16;
                MavMessage::BATTERY_STATUS(BATTERY_STATUS_DATA {
                    current_consumed: self.consumed_mah as i32,
                    energy_consumed: (self.consumed_mah * 11.1 * 36.0 / 1000.0 * 100.0) as i32,
                    temperature: i16::MAX,
                    voltages,
                    current_battery: self.current_ca(),
                    id: 0,
                    // GCS_MAVLINK::send_battery_status: function and type UNKNOWN.
                    battery_function: MavBatteryFunction::MAV_BATTERY_FUNCTION_UNKNOWN,
                    mavtype: MavBatteryType::MAV_BATTERY_TYPE_UNKNOWN,
                    battery_remaining: self.remaining_pct(),
                    charge_state: MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_OK,
                    ..Default::default()
                })
            }
            id::RAW_IMU => MavMessage::RAW_IMU(RAW_IMU_DATA {
                time_usec: self.now,
                xacc: self.rng.jitter(5.0) as i16,
                yacc: self.rng.jitter(5.0) as i16,
                zacc: -1000 + self.rng.jitter(5.0) as i16,
                xmag: 200,
                ymag: 50,
                zmag: -400,
                ..Default::default()
            }),
            id::SCALED_PRESSURE => MavMessage::SCALED_PRESSURE(SCALED_PRESSURE_DATA {
                time_boot_ms: t_ms,
                // ~0.12 hPa per metre near the ground.
                press_abs: (1013.25 - amsl * 0.12) as f32,
                press_diff: 0.0,
                temperature: 2500,
                temperature_press_diff: 0,
            }),
            id::POWER_STATUS => MavMessage::POWER_STATUS(POWER_STATUS_DATA {
                Vcc: 5000,
                Vservo: 0,
                flags: MavPowerStatus::empty(),
            }),
            id::MEMINFO => MavMessage::MEMINFO(MEMINFO_DATA {
                brkval: 0,
                freemem: u16::MAX,
                freemem32: 131_072,
            }),
            id::MISSION_CURRENT => self.mission_current(None),
            id::NAV_CONTROLLER_OUTPUT => {
                MavMessage::NAV_CONTROLLER_OUTPUT(NAV_CONTROLLER_OUTPUT_DATA {
                    alt_error: self.takeoff_target.map(|t| t - self.alt).unwrap_or(0.0) as f32,
                    nav_bearing: heading as i16,
                    target_bearing: heading as i16,
                    wp_dist: self.north.hypot(self.east) as u16,
                    ..Default::default()
                })
            }
            id::SERVO_OUTPUT_RAW => {
                let pwm = match (self.armed, self.landed) {
                    (false, _) => 1000,
                    (true, true) => 1100,
                    (true, false) => 1500,
                };
                MavMessage::SERVO_OUTPUT_RAW(SERVO_OUTPUT_RAW_DATA {
                    time_usec: (self.now % (u32::MAX as u64)) as u32,
                    servo1_raw: pwm,
                    servo2_raw: pwm,
                    servo3_raw: pwm,
                    servo4_raw: pwm,
                    ..Default::default()
                })
            }
            id::RC_CHANNELS => MavMessage::RC_CHANNELS(RC_CHANNELS_DATA {
                time_boot_ms: t_ms,
                chancount: 16,
                chan1_raw: 1500,
                chan2_raw: 1500,
                chan3_raw: 1000,
                chan4_raw: 1500,
                chan5_raw: 1800,
                chan6_raw: 1000,
                chan7_raw: 1000,
                chan8_raw: 1800,
                rssi: 255,
                ..Default::default()
            }),
            // GCS_MAVLINK::send_ahrs2: the secondary (DCM) attitude and position.
            id::AHRS2 => MavMessage::AHRS2(AHRS2_DATA {
                roll: self.rng.jitter(0.003) as f32,
                pitch: self.rng.jitter(0.003) as f32,
                yaw: {
                    let y = heading.to_radians();
                    (if y > std::f64::consts::PI {
                        y - 2.0 * std::f64::consts::PI
                    } else {
                        y
                    }) as f32
                },
                altitude: loc_alt as f32,
                lat: deg_e7(lat),
                lng: deg_e7(lon),
            }),
            id::AHRS => MavMessage::AHRS(AHRS_DATA {
                accel_weight: 0.0,
                renorm_val: 0.0,
                error_rp: 0.002,
                error_yaw: 0.001,
                ..Default::default()
            }),
            id::EKF_STATUS_REPORT => {
                use EkfStatusFlags as F;
                let mut flags = F::EKF_ATTITUDE
                    | F::EKF_VELOCITY_HORIZ
                    | F::EKF_VELOCITY_VERT
                    | F::EKF_POS_VERT_ABS;
                if self.ekf_gps {
                    flags |= F::EKF_POS_HORIZ_REL
                        | F::EKF_POS_HORIZ_ABS
                        | F::EKF_PRED_POS_HORIZ_REL
                        | F::EKF_PRED_POS_HORIZ_ABS;
                } else {
                    flags |= F::EKF_CONST_POS_MODE;
                }
                MavMessage::EKF_STATUS_REPORT(EKF_STATUS_REPORT_DATA {
                    velocity_variance: 0.02,
                    pos_horiz_variance: 0.01,
                    pos_vert_variance: 0.01,
                    compass_variance: 0.02,
                    terrain_alt_variance: 0.0,
                    flags,
                    airspeed_variance: 0.0,
                })
            }
            id::VIBRATION => MavMessage::VIBRATION(VIBRATION_DATA {
                time_usec: self.now,
                vibration_x: 0.01,
                vibration_y: 0.01,
                vibration_z: 0.02,
                ..Default::default()
            }),
            id::EXTENDED_SYS_STATE => MavMessage::EXTENDED_SYS_STATE(EXTENDED_SYS_STATE_DATA {
                vtol_state: MavVtolState::MAV_VTOL_STATE_UNDEFINED,
                landed_state: match (self.landed, self.vu) {
                    (true, _) => MavLandedState::MAV_LANDED_STATE_ON_GROUND,
                    (false, v) if v > 0.1 && self.takeoff_target.is_some() => {
                        MavLandedState::MAV_LANDED_STATE_TAKEOFF
                    }
                    (false, v) if v < -0.1 => MavLandedState::MAV_LANDED_STATE_LANDING,
                    _ => MavLandedState::MAV_LANDED_STATE_IN_AIR,
                },
            }),
            _ => return None,
        };
        Some(m)
    }
}
