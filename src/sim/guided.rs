//! GUIDED targets besides DO_REPOSITION: SET_POSITION_TARGET_LOCAL_NED and
//! SET_POSITION_TARGET_GLOBAL_INT as `GCS_MAVLINK_Copter::handle_message_set_position_target_*`
//! read them, and a MISSION_ITEM with current = 2 / 3 (a GUIDED destination / altitude).
//!
//! As on ArduCopter:
//! - the messages are only read in GUIDED (or AUTO inside a NAV_GUIDED_ENABLE item); in any
//!   other mode they are ignored. Disarmed or on the ground the target is kept but the vehicle
//!   does not move (and a velocity target has timed out long before it could).
//! - `type_mask` decides: position only (a destination, flown as DO_REPOSITION is), velocity
//!   only (with yaw or yaw rate), position and velocity (flown as a destination), acceleration
//!   only (the sim has no acceleration model: it stops). A mask that fits none of these, an
//!   unsupported frame, FORCE_SET with acceleration, or a NaN / over 1000 m/s velocity stop
//!   the vehicle (`mode_guided.init(true)`).
//! - a velocity in a body frame (BODY_NED, BODY_OFFSET_NED) is turned into north/east with the
//!   heading when the message arrives, as `rotate_body_frame_to_NE` does; with a yaw rate the
//!   heading turns, so a stream of body-frame messages curves the path.
//! - velocity (and acceleration) targets time out: after GUID_TIMEOUT (3 s) without a new one
//!   the vehicle stops and the yaw rate ends. Position targets do not time out.
//! - LOCAL_NED positions are metres from the EKF origin (the first home), LOCAL_OFFSET_NED and
//!   the body frames from the vehicle; GLOBAL_INT altitudes are AMSL (GLOBAL, GLOBAL_INT) or
//!   above home (RELATIVE_ALT, and TERRAIN_ALT taken as level with home).
//! - speeds are limited to WPNAV_SPEED, WPNAV_SPEED_UP and WPNAV_SPEED_DN.

use super::vehicle::{mode, SimVehicle};
use crate::clock::Micros;
use crate::dialect::{
    MavFrame, PositionTargetTypemask, SET_POSITION_TARGET_GLOBAL_INT_DATA,
    SET_POSITION_TARGET_LOCAL_NED_DATA,
};

/// What the heading does while a GUIDED target is flown.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum YawCmd {
    /// Face the direction of travel.
    #[default]
    Default,
    /// Hold this heading, degrees.
    Heading(f64),
    /// Turn at this rate, degrees per second (clockwise positive).
    Rate(f64),
}

/// A GUIDED velocity target (north, east, up m/s) and when it was last refreshed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GuidedVel {
    pub vel: (f64, f64, f64),
    pub yaw: YawCmd,
    pub updated: Micros,
}

/// The decoded parts of a SET_POSITION_TARGET_* message.
struct Target {
    pos: Option<(f64, f64, f64)>,
    vel: Option<(f64, f64, f64)>,
    acc: bool,
    yaw: YawCmd,
}

const POS_IGNORE: u16 = 0b111;
const VEL_IGNORE: u16 = 0b111 << 3;
const ACC_IGNORE: u16 = 0b111 << 6;
const FORCE_SET: u16 = 1 << 9;
const YAW_IGNORE: u16 = 1 << 10;
const YAW_RATE_IGNORE: u16 = 1 << 11;

/// `sane_vel_or_acc_vector`.
fn sane(v: (f32, f32, f32)) -> bool {
    [v.0, v.1, v.2]
        .iter()
        .all(|c| !c.is_nan() && c.abs() <= 1000.0)
}

fn mask(m: PositionTargetTypemask) -> u16 {
    m.bits()
}

impl SimVehicle {
    /// `in_guided_mode()`: GUIDED, or AUTO running a NAV_GUIDED_ENABLE item.
    pub fn in_guided_mode(&self) -> bool {
        self.custom_mode == mode::GUIDED
            || (self.custom_mode == mode::AUTO && self.auto.sub == super::auto::Sub::NavGuided)
    }

    /// The GUIDED velocity target in force, if any (north, east, up m/s).
    pub fn guided_velocity(&self) -> Option<(f64, f64, f64)> {
        self.guided_vel.map(|v| v.vel)
    }

    /// The GUIDED destination, if any (metres north/east of home, metres above home).
    pub fn guided_destination(&self) -> Option<(f64, f64, f64)> {
        self.guided_target
    }

    /// `mode_guided.init(true)`: stop and hold here.
    fn guided_stop(&mut self) {
        self.guided_vel = None;
        self.guided_yaw = None;
        self.guided_target = Some((self.north, self.east, self.alt));
    }

    /// Rotate a body-frame (forward, right) vector to (north, east) with the heading.
    fn body_to_ne(&self, x: f64, y: f64) -> (f64, f64) {
        let (s, c) = self.yaw.to_radians().sin_cos();
        (x * c - y * s, x * s + y * c)
    }

    /// The EKF origin as metres north/east/up of home.
    fn origin_offset(&self) -> (f64, f64, f64) {
        let (n, e) = self.ne_of(self.origin.0, self.origin.1);
        (n, e, self.origin.2 - self.home.2)
    }

    fn yaw_from(&self, type_mask: u16, yaw: f32, yaw_rate: f32, relative: bool) -> YawCmd {
        if type_mask & YAW_IGNORE == 0 {
            let mut deg = (yaw as f64).to_degrees();
            if relative {
                deg += self.yaw;
            }
            YawCmd::Heading(deg.rem_euclid(360.0))
        } else if type_mask & YAW_RATE_IGNORE == 0 {
            YawCmd::Rate((yaw_rate as f64).to_degrees())
        } else {
            YawCmd::Default
        }
    }

    /// SET_POSITION_TARGET_LOCAL_NED.
    // BODY_NED and BODY_OFFSET_NED are deprecated in MAVLink but what ArduCopter reads (and the
    // real capture's GCS sends).
    #[allow(deprecated)]
    pub(super) fn set_position_target_local_ned(&mut self, m: &SET_POSITION_TARGET_LOCAL_NED_DATA) {
        if !self.for_me(m.target_system, m.target_component) || !self.in_guided_mode() {
            return;
        }
        use MavFrame::*;
        let body = matches!(
            m.coordinate_frame,
            MAV_FRAME_BODY_NED | MAV_FRAME_BODY_OFFSET_NED
        );
        let offset = body || m.coordinate_frame == MAV_FRAME_LOCAL_OFFSET_NED;
        if !(offset || m.coordinate_frame == MAV_FRAME_LOCAL_NED) {
            return self.guided_stop();
        }
        let tm = mask(m.type_mask);
        if tm & FORCE_SET != 0 && tm & ACC_IGNORE == 0 {
            return self.guided_stop();
        }
        let pos = if tm & POS_IGNORE == 0 {
            let (mut n, mut e) = (m.x as f64, m.y as f64);
            let mut up = -(m.z as f64);
            if body {
                (n, e) = self.body_to_ne(n, e);
            }
            if offset {
                n += self.north;
                e += self.east;
                up += self.alt;
            } else {
                let (on, oe, ou) = self.origin_offset();
                n += on;
                e += oe;
                up += ou;
            }
            Some((n, e, up))
        } else {
            None
        };
        let vel = if tm & VEL_IGNORE == 0 {
            if !sane((m.vx, m.vy, m.vz)) {
                return self.guided_stop();
            }
            let (mut n, mut e) = (m.vx as f64, m.vy as f64);
            if body {
                (n, e) = self.body_to_ne(n, e);
            }
            Some((n, e, -(m.vz as f64)))
        } else {
            None
        };
        let yaw = self.yaw_from(tm, m.yaw, m.yaw_rate, body);
        let acc = tm & ACC_IGNORE == 0;
        self.guided_apply(Target { pos, vel, acc, yaw });
    }

    /// SET_POSITION_TARGET_GLOBAL_INT.
    // The *_INT frames are deprecated synonyms, still sent by GCSs.
    #[allow(deprecated)]
    pub(super) fn set_position_target_global_int(
        &mut self,
        m: &SET_POSITION_TARGET_GLOBAL_INT_DATA,
    ) {
        if !self.for_me(m.target_system, m.target_component) || !self.in_guided_mode() {
            return;
        }
        let tm = mask(m.type_mask);
        if tm & FORCE_SET != 0 && tm & ACC_IGNORE == 0 {
            return self.guided_stop();
        }
        use MavFrame::*;
        let pos = if tm & POS_IGNORE == 0 {
            if m.lat_int.unsigned_abs() > 900_000_000 || m.lon_int.unsigned_abs() > 1_800_000_000 {
                return self.guided_stop();
            }
            let terrain = matches!(
                m.coordinate_frame,
                MAV_FRAME_GLOBAL_TERRAIN_ALT | MAV_FRAME_GLOBAL_TERRAIN_ALT_INT
            );
            let up = match m.coordinate_frame {
                MAV_FRAME_GLOBAL | MAV_FRAME_GLOBAL_INT => m.alt as f64 - self.home.2,
                MAV_FRAME_GLOBAL_RELATIVE_ALT | MAV_FRAME_GLOBAL_RELATIVE_ALT_INT => m.alt as f64,
                _ if terrain => m.alt as f64,
                _ => return self.guided_stop(),
            };
            // The position-and-velocity controller takes no terrain altitudes.
            if terrain && tm & VEL_IGNORE == 0 {
                return self.guided_stop();
            }
            let (n, e) = self.ne_of(m.lat_int as f64 * 1e-7, m.lon_int as f64 * 1e-7);
            Some((n, e, up))
        } else {
            None
        };
        let vel = if tm & VEL_IGNORE == 0 {
            if !sane((m.vx, m.vy, m.vz)) {
                return self.guided_stop();
            }
            Some((m.vx as f64, m.vy as f64, -(m.vz as f64)))
        } else {
            None
        };
        let yaw = self.yaw_from(tm, m.yaw, m.yaw_rate, false);
        let acc = tm & ACC_IGNORE == 0;
        self.guided_apply(Target { pos, vel, acc, yaw });
    }

    /// The controller `ModeGuided` picks for the fields given.
    fn guided_apply(&mut self, t: Target) {
        let now = self.now;
        match (t.pos, t.vel, t.acc) {
            // set_destination / set_destination_posvel: flown as a destination.
            (Some(p), _, _) if t.vel.is_some() || !t.acc => {
                self.guided_vel = None;
                self.guided_target = Some(p);
                self.guided_yaw = match t.yaw {
                    YawCmd::Heading(h) => Some(h),
                    _ => None,
                };
                if !self.landed {
                    self.takeoff_target = None;
                }
            }
            // set_velaccel.
            (None, Some(v), _) => {
                self.guided_target = None;
                self.guided_yaw = None;
                self.guided_vel = Some(GuidedVel {
                    vel: v,
                    yaw: t.yaw,
                    updated: now,
                });
            }
            // set_accel: no acceleration model, so no motion, with the same timeout.
            (None, None, true) => {
                self.guided_target = None;
                self.guided_yaw = None;
                self.guided_vel = Some(GuidedVel {
                    vel: (0.0, 0.0, 0.0),
                    yaw: t.yaw,
                    updated: now,
                });
            }
            _ => self.guided_stop(),
        }
    }

    /// `handle_guided_request` (MISSION_ITEM with current = 2): a waypoint becomes the GUIDED
    /// destination, CONDITION_YAW turns; only in GUIDED.
    pub(super) fn guided_request(&mut self, it: &super::mission::MissionItem) -> bool {
        use super::mission::cmd;
        if !self.in_guided_mode() {
            return false;
        }
        match it.command {
            cmd::NAV_WAYPOINT => {
                let (lat, lon) = it.lat_lon();
                let (n, e) = self.ne_of(lat, lon);
                let up = self.up_of(it.frame, it.z as f64);
                self.guided_vel = None;
                self.guided_yaw = None;
                self.guided_target = Some((n, e, up));
                true
            }
            cmd::CONDITION_YAW => {
                self.yaw = (it.params[0] as f64).rem_euclid(360.0);
                true
            }
            _ => false,
        }
    }

    /// `handle_change_alt_request` (MISSION_ITEM with current = 3): a new altitude for the
    /// GUIDED destination.
    pub(super) fn change_alt_request(&mut self, it: &super::mission::MissionItem) {
        if !self.in_guided_mode() {
            return;
        }
        let up = self.up_of(it.frame, it.z as f64);
        let (n, e, _) = self
            .guided_target
            .unwrap_or((self.north, self.east, self.alt));
        self.guided_vel = None;
        self.guided_target = Some((n, e, up));
    }

    /// True when the heading is commanded (not the direction of travel).
    pub(super) fn guided_heading_commanded(&self) -> bool {
        if !self.in_guided_mode() {
            return false;
        }
        match self.guided_vel {
            Some(v) => v.yaw != YawCmd::Default,
            None => self.guided_yaw.is_some() && self.guided_target.is_some(),
        }
    }

    /// GUIDED's flight model for `dt` seconds (armed and in the air).
    pub(super) fn guided_run(&mut self, dt: f64) {
        if let Some(mut v) = self.guided_vel {
            let timeout = self.params.value("GUID_TIMEOUT").unwrap_or(3.0).max(0.1);
            if self.now.saturating_sub(v.updated) as f64 > timeout * 1e6 {
                // velaccel_control_run: no update for GUID_TIMEOUT, so stop and stop turning.
                v.vel = (0.0, 0.0, 0.0);
                if matches!(v.yaw, YawCmd::Rate(_)) {
                    v.yaw = YawCmd::Heading(self.yaw);
                }
                self.guided_vel = Some(v);
            }
            let (h, up, down) = self.wpnav_speeds();
            let (mut vn, mut ve, vu) = v.vel;
            let hs = vn.hypot(ve);
            if hs > h {
                vn *= h / hs;
                ve *= h / hs;
            }
            let vu = vu.clamp(-down, up);
            self.north += vn * dt;
            self.east += ve * dt;
            self.alt += vu * dt;
            self.vn = vn;
            self.ve = ve;
            self.vu = vu;
            match v.yaw {
                YawCmd::Heading(hd) => self.yaw = hd,
                YawCmd::Rate(r) => self.yaw = (self.yaw + r * dt).rem_euclid(360.0),
                YawCmd::Default => {}
            }
            if self.alt <= 0.0 {
                self.alt = 0.0;
                self.vu = 0.0;
                if vu < 0.0 {
                    self.landed = true;
                    self.armed_on_ground_since = Some(self.now);
                }
            }
        } else if let Some(target) = self.guided_target {
            self.fly_to(target, dt);
            if let Some(h) = self.guided_yaw {
                self.yaw = h;
            }
        }
    }
}
