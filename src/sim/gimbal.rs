//! The simulated mount (`sim://?gimbal=1`, on by default with `camera=1`): ArduCopter's AP_Mount
//! with one gimbal (MNT1_TYPE set, instance 0), acting as gimbal manager on the autopilot's own
//! component id, as ArduPilot does.
//!
//! - REQUEST_MESSAGE 280 → GIMBAL_MANAGER_INFORMATION (`AP_Mount_Backend::
//!   send_gimbal_manager_information`): gimbal_device_id = instance + 1 = 1, the capability
//!   flags ArduPilot derives from the angle limits, limits in radians (MNT1_ defaults: roll
//!   -30..30°, pitch -90..20°, yaw -180..180°).
//! - GIMBAL_MANAGER_STATUS (281) is in no stream group: sent when asked (REQUEST_MESSAGE or
//!   SET_MESSAGE_INTERVAL) and when primary control changes. GIMBAL_DEVICE_ATTITUDE_STATUS (285)
//!   is in the EXTRA3 group (`STREAM_EXTRA3_msgs`).
//! - MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW (`AP_Mount::handle_command_do_gimbal_manager_pitchyaw`):
//!   param7 picks the gimbal (0 = primary, N = instance N-1; none → FAILED); RETRACT / NEUTRAL
//!   flags switch mode; angles (both set) are clamped to the limits (`set_angle_target`: yaw only
//!   in the body frame) and ACCEPTED; rates (both set) start a rate target; all four NaN set the
//!   yaw lock; anything else FAILED. ArduPilot does not refuse an angle beyond the limits: it
//!   clamps it. The gimbal slews to the target at [`SLEW_DEG_S`].
//! - MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE (`handle_command_do_gimbal_manager_configure`): -1
//!   leaves, -2 takes for the sender, -3 releases if the sender has it, else sysid/compid.

use crate::clock::{Micros, SECOND};
use crate::dialect::*;

/// How fast the simulated gimbal turns, degrees per second.
pub const SLEW_DEG_S: f64 = 60.0;
/// MNT1_ROLL/PITCH/YAW_MIN/MAX defaults (AP_Mount_Params), degrees.
pub const ROLL_LIMITS: (f64, f64) = (-30.0, 30.0);
pub const PITCH_LIMITS: (f64, f64) = (-90.0, 20.0);
pub const YAW_LIMITS: (f64, f64) = (-180.0, 180.0);

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MountMode {
    Retract,
    Neutral,
    /// MAVLink targeting (angle).
    Angle,
    /// MAVLink targeting (rate, deg/s).
    Rate(f64, f64),
}

#[derive(Debug, Clone)]
pub struct SimMount {
    /// Current body-frame angles, degrees.
    pub pitch: f64,
    pub yaw: f64,
    /// Target body-frame pitch and yaw, degrees.
    pub target: (f64, f64),
    pub mode: MountMode,
    pub yaw_lock: bool,
    /// Primary control (sysid, compid), (0, 0) for none.
    pub control: (u8, u8),
}

impl Default for SimMount {
    fn default() -> Self {
        SimMount {
            pitch: 0.0,
            yaw: 0.0,
            target: (0.0, 0.0),
            mode: MountMode::Angle,
            yaw_lock: false,
            control: (0, 0),
        }
    }
}

fn clamp((lo, hi): (f64, f64), v: f64) -> f64 {
    v.clamp(lo, hi)
}

/// ArduPilot's `Quaternion::from_euler` (radians), as [w, x, y, z].
pub fn quaternion_from_euler(roll: f64, pitch: f64, yaw: f64) -> [f32; 4] {
    let (cr, sr) = ((roll / 2.0).cos(), (roll / 2.0).sin());
    let (cp, sp) = ((pitch / 2.0).cos(), (pitch / 2.0).sin());
    let (cy, sy) = ((yaw / 2.0).cos(), (yaw / 2.0).sin());
    [
        (cr * cp * cy + sr * sp * sy) as f32,
        (sr * cp * cy - cr * sp * sy) as f32,
        (cr * sp * cy + sr * cp * sy) as f32,
        (cr * cp * sy - sr * sp * cy) as f32,
    ]
}

fn move_toward(from: f64, to: f64, max: f64) -> f64 {
    if (to - from).abs() <= max {
        to
    } else {
        from + max.copysign(to - from)
    }
}

impl SimMount {
    /// Advance by `dt` seconds.
    pub fn step(&mut self, dt: f64) {
        let (tp, ty) = match self.mode {
            MountMode::Retract => (0.0, 0.0),
            MountMode::Neutral => (0.0, 0.0),
            MountMode::Angle => self.target,
            MountMode::Rate(pr, yr) => {
                self.target = (
                    clamp(PITCH_LIMITS, self.target.0 + pr * dt),
                    clamp(YAW_LIMITS, self.target.1 + yr * dt),
                );
                self.target
            }
        };
        let max = SLEW_DEG_S * dt;
        self.pitch = move_toward(self.pitch, tp, max);
        self.yaw = move_toward(self.yaw, ty, max);
    }

    /// `get_gimbal_manager_capability_flags` for a mount with roll, pitch and yaw ranges.
    pub fn cap_flags() -> GimbalManagerCapFlags {
        use GimbalManagerCapFlags as F;
        F::GIMBAL_MANAGER_CAP_FLAGS_HAS_RETRACT
            | F::GIMBAL_MANAGER_CAP_FLAGS_HAS_NEUTRAL
            | F::GIMBAL_MANAGER_CAP_FLAGS_HAS_RC_INPUTS
            | F::GIMBAL_MANAGER_CAP_FLAGS_CAN_POINT_LOCATION_LOCAL
            | F::GIMBAL_MANAGER_CAP_FLAGS_CAN_POINT_LOCATION_GLOBAL
            | F::GIMBAL_MANAGER_CAP_FLAGS_HAS_ROLL_AXIS
            | F::GIMBAL_MANAGER_CAP_FLAGS_HAS_ROLL_FOLLOW
            | F::GIMBAL_MANAGER_CAP_FLAGS_HAS_ROLL_LOCK
            | F::GIMBAL_MANAGER_CAP_FLAGS_HAS_PITCH_AXIS
            | F::GIMBAL_MANAGER_CAP_FLAGS_HAS_PITCH_FOLLOW
            | F::GIMBAL_MANAGER_CAP_FLAGS_HAS_PITCH_LOCK
            | F::GIMBAL_MANAGER_CAP_FLAGS_HAS_YAW_AXIS
            | F::GIMBAL_MANAGER_CAP_FLAGS_HAS_YAW_FOLLOW
            | F::GIMBAL_MANAGER_CAP_FLAGS_HAS_YAW_LOCK
    }

    pub fn information(&self, t_ms: u32) -> MavMessage {
        let r = |v: f64| v.to_radians() as f32;
        MavMessage::GIMBAL_MANAGER_INFORMATION(GIMBAL_MANAGER_INFORMATION_DATA {
            time_boot_ms: t_ms,
            cap_flags: Self::cap_flags(),
            roll_min: r(ROLL_LIMITS.0),
            roll_max: r(ROLL_LIMITS.1),
            pitch_min: r(PITCH_LIMITS.0),
            pitch_max: r(PITCH_LIMITS.1),
            yaw_min: r(YAW_LIMITS.0),
            yaw_max: r(YAW_LIMITS.1),
            gimbal_device_id: 1,
        })
    }

    pub fn status(&self, t_ms: u32) -> MavMessage {
        let mut flags = GimbalManagerFlags::GIMBAL_MANAGER_FLAGS_ROLL_LOCK
            | GimbalManagerFlags::GIMBAL_MANAGER_FLAGS_PITCH_LOCK;
        if self.yaw_lock {
            flags |= GimbalManagerFlags::GIMBAL_MANAGER_FLAGS_YAW_LOCK;
        }
        MavMessage::GIMBAL_MANAGER_STATUS(GIMBAL_MANAGER_STATUS_DATA {
            time_boot_ms: t_ms,
            flags,
            gimbal_device_id: 1,
            primary_control_sysid: self.control.0,
            primary_control_compid: self.control.1,
            secondary_control_sysid: 0,
            secondary_control_compid: 0,
        })
    }

    pub fn attitude(&self, t_ms: u32) -> MavMessage {
        use GimbalDeviceFlags as F;
        let mut flags = F::GIMBAL_DEVICE_FLAGS_ROLL_LOCK
            | F::GIMBAL_DEVICE_FLAGS_PITCH_LOCK
            | F::GIMBAL_DEVICE_FLAGS_YAW_IN_VEHICLE_FRAME;
        match self.mode {
            MountMode::Retract => flags |= F::GIMBAL_DEVICE_FLAGS_RETRACT,
            MountMode::Neutral => flags |= F::GIMBAL_DEVICE_FLAGS_NEUTRAL,
            _ => {}
        }
        MavMessage::GIMBAL_DEVICE_ATTITUDE_STATUS(GIMBAL_DEVICE_ATTITUDE_STATUS_DATA {
            time_boot_ms: t_ms,
            q: quaternion_from_euler(0.0, self.pitch.to_radians(), self.yaw.to_radians()),
            angular_velocity_x: f32::NAN,
            angular_velocity_y: f32::NAN,
            angular_velocity_z: f32::NAN,
            failure_flags: GimbalDeviceErrorFlags::empty(),
            flags,
            target_system: 0,
            target_component: 0,
            delta_yaw: f32::NAN,
            delta_yaw_velocity: f32::NAN,
            gimbal_device_id: 1,
        })
    }

    /// DO_GIMBAL_MANAGER_PITCHYAW: params 1–4, the flags (x) and the gimbal (z); `heading`: the
    /// vehicle's, for an earth-frame yaw.
    pub fn pitchyaw(&mut self, p: [f32; 7], flags: u32, device: f32, heading: f64) -> MavResult {
        use MavResult::*;
        // mount_device_from_mavlink_gimbal_id: 0 = primary, 1 = the first (and only) mount.
        if device as i32 != 0 && device as i32 != 1 {
            return MAV_RESULT_FAILED;
        }
        if flags & 1 != 0 {
            self.mode = MountMode::Retract;
            return MAV_RESULT_ACCEPTED;
        }
        if flags & 2 != 0 {
            self.mode = MountMode::Neutral;
            return MAV_RESULT_ACCEPTED;
        }
        let lock = flags & 16 != 0;
        let nan = |v: f32| v.is_nan();
        if !nan(p[0]) && !nan(p[1]) {
            let pitch = clamp(PITCH_LIMITS, p[0] as f64);
            let mut yaw = p[1] as f64;
            if lock {
                // Earth-frame yaw: the servo can only reach it within its body-frame range.
                yaw = (yaw - heading + 540.0).rem_euclid(360.0) - 180.0;
            } else if yaw > 180.0 {
                yaw -= 360.0;
            }
            self.target = (pitch, clamp(YAW_LIMITS, yaw));
            self.mode = MountMode::Angle;
            return MAV_RESULT_ACCEPTED;
        }
        if !nan(p[2]) && !nan(p[3]) {
            self.target = (self.pitch, self.yaw);
            self.mode = MountMode::Rate(p[2] as f64, p[3] as f64);
            return MAV_RESULT_ACCEPTED;
        }
        if nan(p[0]) && nan(p[1]) && nan(p[2]) && nan(p[3]) {
            self.yaw_lock = lock;
            return MAV_RESULT_ACCEPTED;
        }
        MAV_RESULT_FAILED
    }

    /// DO_GIMBAL_MANAGER_CONFIGURE from `from`; true when control changed (ArduPilot then sends
    /// GIMBAL_MANAGER_STATUS).
    pub fn configure(&mut self, p: [f32; 7], from: (u8, u8)) -> (MavResult, bool) {
        if p[0] < -3.0 || p[0] > 255.0 || p[1] < -3.0 || p[1] > 255.0 {
            return (MavResult::MAV_RESULT_FAILED, false);
        }
        if p[6] as i32 != 0 && p[6] as i32 != 1 {
            return (MavResult::MAV_RESULT_FAILED, false);
        }
        let before = self.control;
        match p[0] as i16 {
            -1 => {}
            -2 => self.control = from,
            -3 => {
                if self.control == from {
                    self.control = (0, 0);
                }
            }
            _ => self.control = (p[0] as u8, p[1] as u8),
        }
        (MavResult::MAV_RESULT_ACCEPTED, before != self.control)
    }
}

/// A tick's length in seconds for [`SimMount::step`].
pub fn dt(tick: Micros) -> f64 {
    tick as f64 / SECOND as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slews_at_a_finite_rate_and_clamps_to_the_limits() {
        let mut m = SimMount::default();
        let nan = f32::NAN;
        let r = m.pitchyaw([-45.0, 30.0, nan, nan, 44.0, 0.0, 1.0], 44, 1.0, 0.0);
        assert_eq!(r, MavResult::MAV_RESULT_ACCEPTED);
        m.step(0.5);
        assert_eq!((m.pitch, m.yaw), (-30.0, 30.0));
        m.step(0.5);
        assert_eq!((m.pitch, m.yaw), (-45.0, 30.0));
        // Beyond MNT1_PITCH_MAX: accepted and clamped, as ArduPilot does.
        let r = m.pitchyaw([60.0, 0.0, nan, nan, 44.0, 0.0, 1.0], 44, 1.0, 0.0);
        assert_eq!(r, MavResult::MAV_RESULT_ACCEPTED);
        assert_eq!(m.target, (20.0, 0.0));
        // No such gimbal.
        let r = m.pitchyaw([0.0, 0.0, nan, nan, 44.0, 0.0, 2.0], 44, 2.0, 0.0);
        assert_eq!(r, MavResult::MAV_RESULT_FAILED);
        // Only one of the angles: neither angles, rates nor all-NaN.
        let r = m.pitchyaw([0.0, nan, nan, nan, 44.0, 0.0, 1.0], 44, 1.0, 0.0);
        assert_eq!(r, MavResult::MAV_RESULT_FAILED);
    }

    #[test]
    fn configure_takes_and_releases_control() {
        let mut m = SimMount::default();
        let nan = f32::NAN;
        assert_eq!(
            m.configure([255.0, 190.0, -1.0, -1.0, nan, nan, 1.0], (255, 190)),
            (MavResult::MAV_RESULT_ACCEPTED, true)
        );
        assert_eq!(m.control, (255, 190));
        // Release by another: not theirs to release.
        m.configure([-3.0, -3.0, -1.0, -1.0, nan, nan, 1.0], (254, 190));
        assert_eq!(m.control, (255, 190));
        m.configure([-3.0, -3.0, -1.0, -1.0, nan, nan, 1.0], (255, 190));
        assert_eq!(m.control, (0, 0));
    }
}
