//! The vehicle's mission, fence and rally stores and the MAVLink mission protocol as ArduCopter
//! runs it: `GCS_MAVLink/MissionItemProtocol*.cpp` for the transfer, `AP_Mission` for how a
//! mission item is stored (and so what a download gives back), `AC_PolyFence_loader` and
//! `AP_Rally` for the other two types.
//!
//! The protocol messages are read from their raw payloads, not from the dialect's types: a
//! command id, frame or mission type the dialect does not know must still get ArduPilot's answer
//! (MAV_MISSION_UNSUPPORTED, MAV_MISSION_UNSUPPORTED_FRAME, ...), not silence. What goes out is
//! built raw as well (`Out::Raw`), so an unknown mission type is echoed back as it came.
//!
//! ArduCopter's behaviour reproduced here:
//! - upload: MISSION_COUNT, then one MISSION_REQUEST (not `_INT`, even when answered with
//!   MISSION_ITEM_INT, as the real capture shows) per item, re-sent when no item came for more
//!   than a second, the upload abandoned (MAV_MISSION_OPERATION_CANCELLED and "Mission upload
//!   timeout") after 8 s without one; an item out of turn is answered
//!   MAV_MISSION_INVALID_SEQUENCE and the upload goes on; MISSION_ITEM is accepted (its float
//!   lat/lon multiplied by 1e7 in `f32`) with a one-time warning; the final MISSION_ACK is
//!   ACCEPTED (with "Flight plan received" for a mission) or an error.
//! - waypoint items are written straight into the stored mission as they arrive (the mission is
//!   first truncated to the new count), so an abandoned upload leaves a mixed mission, as on
//!   ArduPilot; fence items are staged and replace the fence only when all arrived and the fence
//!   validates; rally points are written as they arrive.
//! - what is stored is what `AP_Mission` keeps in its 15 bytes per item: a waypoint keeps its
//!   delay (param1, whole seconds) but not its yaw (param4), altitudes become centimetres,
//!   frames become GLOBAL / GLOBAL_RELATIVE_ALT / GLOBAL_TERRAIN_ALT, and a download gives back
//!   exactly that. Item 0 of the mission reads as the home position (zeros until home is set).
//! - a downloaded item has `current` = 1 when it is the navigation command being flown, as the
//!   MAVLink spec says (ArduPilot's `get_item` compares the command *id* with that index, which
//!   only matters when they happen to be equal; the sim does not copy that slip).
//! - MIS_TOTAL, FENCE_TOTAL and RALLY_TOTAL follow the stores and are notified (PARAM_VALUE
//!   index 65535) when they change, after the protocol message that caused it.
//! - MISSION_ACK and MISSION_COUNT carry no opaque id, and MISSION_CURRENT no mission, fence or
//!   rally id: ArduCopter 4.7 sends those fields as zero (the capture's payloads end before
//!   them), so the sim does too.

use super::vehicle::{Out, SimVehicle};
use crate::clock::{Micros, SECOND};
use crate::dialect::{MavMissionResult, MavSeverity};
use crate::wire::payload::Payload;

/// Message ids of the mission protocol.
pub mod msgid {
    use crate::dialect::*;
    use mavlink::MessageData;

    pub const MISSION_WRITE_PARTIAL_LIST: u32 = MISSION_WRITE_PARTIAL_LIST_DATA::ID;
    #[allow(deprecated)] // the float forms: older GCSs still use them
    pub const MISSION_ITEM: u32 = MISSION_ITEM_DATA::ID;
    #[allow(deprecated)]
    pub const MISSION_REQUEST: u32 = MISSION_REQUEST_DATA::ID;
    #[allow(deprecated)] // superseded by MAV_CMD_DO_SET_MISSION_CURRENT, still sent
    pub const MISSION_SET_CURRENT: u32 = MISSION_SET_CURRENT_DATA::ID;
    pub const MISSION_CURRENT: u32 = MISSION_CURRENT_DATA::ID;
    pub const MISSION_REQUEST_LIST: u32 = MISSION_REQUEST_LIST_DATA::ID;
    pub const MISSION_COUNT: u32 = MISSION_COUNT_DATA::ID;
    pub const MISSION_CLEAR_ALL: u32 = MISSION_CLEAR_ALL_DATA::ID;
    pub const MISSION_ITEM_REACHED: u32 = MISSION_ITEM_REACHED_DATA::ID;
    pub const MISSION_ACK: u32 = MISSION_ACK_DATA::ID;
    pub const MISSION_REQUEST_INT: u32 = MISSION_REQUEST_INT_DATA::ID;
    pub const MISSION_ITEM_INT: u32 = MISSION_ITEM_INT_DATA::ID;
}

/// True for the messages a GCS sends in the mission protocol (handled from their raw payload).
pub fn is_protocol_message(id: u32) -> bool {
    use msgid::*;
    matches!(
        id,
        MISSION_WRITE_PARTIAL_LIST
            | MISSION_ITEM
            | MISSION_REQUEST
            | MISSION_SET_CURRENT
            | MISSION_REQUEST_LIST
            | MISSION_COUNT
            | MISSION_CLEAR_ALL
            | MISSION_ACK
            | MISSION_REQUEST_INT
            | MISSION_ITEM_INT
    )
}

/// MAV_MISSION_TYPE values.
pub mod mission_type {
    pub const MISSION: u8 = 0;
    pub const FENCE: u8 = 1;
    pub const RALLY: u8 = 2;
}

/// MAV_CMD values, from the dialect.
pub use crate::wire::cmd;

/// MAV_FRAME values used by mission items.
pub mod frame {
    pub const GLOBAL: u8 = 0;
    pub const MISSION: u8 = 2;
    pub const GLOBAL_RELATIVE_ALT: u8 = 3;
    pub const GLOBAL_INT: u8 = 5;
    pub const GLOBAL_RELATIVE_ALT_INT: u8 = 6;
    pub const GLOBAL_TERRAIN_ALT: u8 = 10;
    pub const GLOBAL_TERRAIN_ALT_INT: u8 = 11;
}

/// Waypoint items the simulated storage holds (ArduPilot: `(storage size - 4) / 15`, which
/// depends on the board; this is the sim's board).
pub const MISSION_MAX_ITEMS: u16 = 700;
/// Bytes of fence storage (`AC_PolyFence_loader::fence_storage`); items at most a vertex each.
pub const FENCE_STORAGE_BYTES: u16 = 1024;
/// Rally points the simulated storage holds (`AP_Rally::get_rally_max`).
pub const RALLY_MAX_POINTS: u16 = 20;
/// `MissionItemProtocol::upload_timeout_ms`.
pub const UPLOAD_TIMEOUT: Micros = 8 * SECOND;
/// `MissionItemProtocol::update`: a request is re-sent after more than this without an item
/// (`1000 + stream_slowdown_ms`, no slowdown on the simulated link).
pub const REQUEST_RESEND: Micros = SECOND;
/// ArduPilot's LOCATION_ALT_MAX_M.
const LOCATION_ALT_MAX_M: f32 = 83_000.0;

/// One MISSION_ITEM_INT as it travels (MISSION_ITEM's float x/y already converted).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MissionItem {
    pub seq: u16,
    pub command: u16,
    pub frame: u8,
    pub current: u8,
    pub autocontinue: u8,
    pub params: [f32; 4],
    pub x: i32,
    pub y: i32,
    pub z: f32,
    pub mission_type: u8,
}

impl MissionItem {
    /// Latitude and longitude in degrees.
    pub fn lat_lon(&self) -> (f64, f64) {
        (self.x as f64 * 1e-7, self.y as f64 * 1e-7)
    }
}

/// A payload zero-extended to the message's full length (MAVLink 2 trims trailing zeros).
fn padded(payload: &[u8], len: usize) -> Vec<u8> {
    let mut p = payload.to_vec();
    if p.len() < len {
        p.resize(len, 0);
    }
    p
}

/// A mission protocol message from the GCS, read from its payload.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Incoming {
    Count {
        count: u16,
        ty: u8,
    },
    /// MISSION_ITEM_INT (`int`) or MISSION_ITEM; a MISSION_ITEM whose lat/lon cannot be
    /// converted carries the error to answer with.
    Item {
        item: MissionItem,
        int: bool,
        bad: Option<MavMissionResult>,
    },
    Request {
        seq: u16,
        ty: u8,
        int: bool,
    },
    RequestList {
        ty: u8,
    },
    ClearAll {
        ty: u8,
    },
    SetCurrent {
        seq: u16,
    },
    WritePartial {
        start: i16,
        end: i16,
        ty: u8,
    },
    Ack,
}

/// Commands whose MISSION_ITEM x/y are not a latitude/longitude
/// (`AP_Mission::convert_MISSION_ITEM_to_MISSION_ITEM_INT`).
fn xy_not_location(command: u16) -> bool {
    // DO_DIGICAM_CONFIGURE, DO_DIGICAM_CONTROL, NAV_ATTITUDE_TIME, DO_GIMBAL_MANAGER_PITCHYAW.
    matches!(
        command,
        cmd::DO_DIGICAM_CONFIGURE
            | cmd::DO_DIGICAM_CONTROL
            | cmd::NAV_ATTITUDE_TIME
            | cmd::DO_GIMBAL_MANAGER_PITCHYAW
    )
}

fn check_lat(lat_e7: i32) -> bool {
    lat_e7.unsigned_abs() <= 900_000_000
}
fn check_lng(lng_e7: i32) -> bool {
    lng_e7.unsigned_abs() <= 1_800_000_000
}

/// Read a mission protocol message: (target_system, target_component, message).
pub(super) fn parse(id: u32, payload: &[u8]) -> Option<(u8, u8, Incoming)> {
    use msgid::*;
    Some(match id {
        MISSION_ITEM_INT | MISSION_ITEM => {
            let p = padded(payload, 38);
            let command = Payload(&p).u16(30);
            let mut item = MissionItem {
                params: [
                    Payload(&p).f32(0),
                    Payload(&p).f32(4),
                    Payload(&p).f32(8),
                    Payload(&p).f32(12),
                ],
                x: Payload(&p).i32(16),
                y: Payload(&p).i32(20),
                z: Payload(&p).f32(24),
                seq: Payload(&p).u16(28),
                command,
                frame: p[34],
                current: p[35],
                autocontinue: p[36],
                mission_type: p[37],
            };
            let mut bad = None;
            if id == MISSION_ITEM {
                let (fx, fy) = (Payload(&p).f32(16), Payload(&p).f32(20));
                if xy_not_location(command) {
                    item.x = fx as i32;
                    item.y = fy as i32;
                } else if fx.is_nan() || fx.abs() > 90.0 {
                    bad = Some(MavMissionResult::MAV_MISSION_INVALID_PARAM5_X);
                } else if fy.is_nan() || fy.abs() > 180.0 {
                    bad = Some(MavMissionResult::MAV_MISSION_INVALID_PARAM6_Y);
                } else {
                    // `packet.x * 1.0e7f`: single precision, as ArduPilot computes it.
                    item.x = (fx * 1.0e7f32) as i32;
                    item.y = (fy * 1.0e7f32) as i32;
                }
            }
            (
                p[32],
                p[33],
                Incoming::Item {
                    item,
                    int: id == MISSION_ITEM_INT,
                    bad,
                },
            )
        }
        MISSION_REQUEST | MISSION_REQUEST_INT => {
            let p = padded(payload, 5);
            (
                p[2],
                p[3],
                Incoming::Request {
                    seq: Payload(&p).u16(0),
                    ty: p[4],
                    int: id == MISSION_REQUEST_INT,
                },
            )
        }
        MISSION_COUNT => {
            let p = padded(payload, 5);
            (
                p[2],
                p[3],
                Incoming::Count {
                    count: Payload(&p).u16(0),
                    ty: p[4],
                },
            )
        }
        MISSION_REQUEST_LIST => {
            let p = padded(payload, 3);
            (p[0], p[1], Incoming::RequestList { ty: p[2] })
        }
        MISSION_CLEAR_ALL => {
            let p = padded(payload, 3);
            (p[0], p[1], Incoming::ClearAll { ty: p[2] })
        }
        MISSION_SET_CURRENT => {
            let p = padded(payload, 4);
            (
                p[2],
                p[3],
                Incoming::SetCurrent {
                    seq: Payload(&p).u16(0),
                },
            )
        }
        MISSION_WRITE_PARTIAL_LIST => {
            let p = padded(payload, 7);
            (
                p[4],
                p[5],
                Incoming::WritePartial {
                    start: Payload(&p).i16(0),
                    end: Payload(&p).i16(2),
                    ty: p[6],
                },
            )
        }
        MISSION_ACK => {
            let p = padded(payload, 4);
            (p[0], p[1], Incoming::Ack)
        }
        _ => return None,
    })
}

/// MISSION_ITEM_INT (`int`) or MISSION_ITEM payload for `item` addressed to `to`.
pub(super) fn item_payload(item: &MissionItem, to: (u8, u8), int: bool) -> Vec<u8> {
    let mut p = Vec::with_capacity(38);
    for v in item.params {
        p.extend_from_slice(&v.to_le_bytes());
    }
    if int {
        p.extend_from_slice(&item.x.to_le_bytes());
        p.extend_from_slice(&item.y.to_le_bytes());
    } else {
        // `item_int.x * 1.0e-7f`, single precision.
        p.extend_from_slice(&(item.x as f32 * 1.0e-7f32).to_le_bytes());
        p.extend_from_slice(&(item.y as f32 * 1.0e-7f32).to_le_bytes());
    }
    p.extend_from_slice(&item.z.to_le_bytes());
    p.extend_from_slice(&item.seq.to_le_bytes());
    p.extend_from_slice(&item.command.to_le_bytes());
    p.extend_from_slice(&[
        to.0,
        to.1,
        item.frame,
        item.current,
        item.autocontinue,
        item.mission_type,
    ]);
    p
}

fn raw(msgid: u32, payload: Vec<u8>) -> Out {
    Out::Raw { msgid, payload }
}

pub(super) fn ack_out(to: (u8, u8), result: MavMissionResult, ty: u8) -> Out {
    // target_system, target_component, type, mission_type, opaque_id (0: not sent by 4.7).
    raw(msgid::MISSION_ACK, vec![to.0, to.1, result as u8, ty])
}

fn request_out(to: (u8, u8), seq: u16, ty: u8) -> Out {
    let s = seq.to_le_bytes();
    raw(msgid::MISSION_REQUEST, vec![s[0], s[1], to.0, to.1, ty])
}

fn count_out(to: (u8, u8), count: u16, ty: u8) -> Out {
    let c = count.to_le_bytes();
    raw(msgid::MISSION_COUNT, vec![c[0], c[1], to.0, to.1, ty])
}

/// MISSION_ITEM_REACHED.
pub(super) fn reached_out(seq: u16) -> Out {
    raw(msgid::MISSION_ITEM_REACHED, seq.to_le_bytes().to_vec())
}

// C conversions of a float parameter into the integer fields AP_Mission stores (a float that
// does not fit saturates, as the ARM conversion instruction does; NaN gives 0).
fn as_u8(v: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 255.0).trunc()
    }
}
fn as_i8(v: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(-128.0, 127.0).trunc()
    }
}
fn as_u16(v: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 65535.0).trunc()
    }
}
fn as_i16(v: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(-32768.0, 32767.0).trunc()
    }
}

/// `AP_Mission::sanity_check_params`: NaN only where the command allows it (param4 of
/// WAYPOINT, LAND and TAKEOFF), infinity nowhere.
fn sanity_check_params(it: &MissionItem) -> MavMissionResult {
    use MavMissionResult::*;
    let nan_ok_4 = matches!(
        it.command,
        cmd::NAV_WAYPOINT | cmd::NAV_LAND | cmd::NAV_TAKEOFF
    );
    let codes = [
        MAV_MISSION_INVALID_PARAM1,
        MAV_MISSION_INVALID_PARAM2,
        MAV_MISSION_INVALID_PARAM3,
        MAV_MISSION_INVALID_PARAM4,
    ];
    for (i, (&v, code)) in it.params.iter().zip(codes).enumerate() {
        if v.is_infinite() || (v.is_nan() && !(i == 3 && nan_ok_4)) {
            return code;
        }
    }
    MAV_MISSION_ACCEPTED
}

/// `AP_Mission::mavlink_int_to_mission_cmd` then `mission_cmd_to_mavlink_int` (ArduCopter
/// build): the waypoint item as it is stored, in the form a download gives it back (seq kept,
/// current 0, autocontinue 1, mission_type 0), or the error an upload of it gets.
pub fn store_mission_item(it: &MissionItem) -> Result<MissionItem, MavMissionResult> {
    use MavMissionResult::*;
    let check = sanity_check_params(it);
    if check != MAV_MISSION_ACCEPTED {
        return Err(check);
    }
    let [p1, p2, p3, p4] = it.params;
    let sign = |neg: bool| if neg { -1.0 } else { 1.0 };
    let xtrack = |v: f32| if v > 0.0 { 1.0 } else { 0.0 };
    // (params as stored, whether the item carries a location)
    let (params, location): ([f32; 4], bool) = match it.command {
        0 | 1 => return Err(MAV_MISSION_INVALID),
        // Copter keeps the delay (p1) only: acceptance radius, pass-by and yaw are dropped.
        cmd::NAV_WAYPOINT
        | cmd::NAV_TAKEOFF
        | cmd::NAV_CONTINUE_AND_CHANGE_ALT
        | cmd::NAV_SPLINE_WAYPOINT
        | cmd::NAV_GUIDED_ENABLE
        | cmd::DO_SET_HOME
        | cmd::DO_SET_ROI => ([as_u16(p1), 0.0, 0.0, 0.0], true),
        cmd::NAV_LOITER_UNLIM => {
            let r = as_u16(p3.abs());
            ([0.0, 0.0, r * sign(p3 < 0.0), 0.0], true)
        }
        cmd::NAV_LOITER_TURNS => {
            let turns = as_u8(p1.min(255.0));
            let a = p3.abs();
            let r = if a <= 255.0 {
                as_u8(a)
            } else {
                as_u8((a * 0.1).min(255.0)) * 10.0
            };
            ([turns, 0.0, r * sign(p3 < 0.0), xtrack(p4)], true)
        }
        cmd::NAV_LOITER_TIME => ([as_u16(p1), 0.0, sign(p3 < 0.0), xtrack(p4)], true),
        cmd::NAV_RETURN_TO_LAUNCH | cmd::DO_LAND_START | cmd::DO_GO_AROUND => {
            ([0.0; 4], it.command != cmd::NAV_RETURN_TO_LAUNCH)
        }
        cmd::NAV_LAND => {
            let ccw = !p4.is_nan() && p4 < 0.0;
            ([as_u16(p1), 0.0, 0.0, sign(ccw)], true)
        }
        cmd::NAV_LOITER_TO_ALT => {
            let r = as_u16(p2.abs());
            ([0.0, r * sign(p2 < 0.0), 0.0, xtrack(p4)], true)
        }
        cmd::NAV_DELAY => ([p1, as_i8(p2), as_i8(p3), as_i8(p4)], false),
        cmd::CONDITION_DELAY | cmd::CONDITION_DISTANCE => ([p1, 0.0, 0.0, 0.0], false),
        cmd::CONDITION_YAW => ([p1, p2, as_i8(p3), as_u8(p4)], false),
        cmd::DO_JUMP => ([as_u16(p1), as_i16(p2), 0.0, 0.0], false),
        cmd::DO_CHANGE_SPEED => ([as_u8(p1), p2, p3, 0.0], false),
        cmd::DO_SET_RELAY => ([as_u8(p1), as_i8(p2), 0.0, 0.0], false),
        cmd::DO_REPEAT_RELAY => ([as_u8(p1), as_i16(p2), p3, 0.0], false),
        cmd::DO_SET_SERVO => ([as_u8(p1), as_u16(p2), 0.0, 0.0], false),
        cmd::DO_REPEAT_SERVO => ([as_u8(p1), as_u16(p2), as_i16(p3), p4], false),
        cmd::DO_DIGICAM_CONTROL => ([as_u8(p1), as_u8(p2), as_i8(p3), as_u8(p4)], false),
        cmd::DO_MOUNT_CONTROL => ([p1, p2, p3, 0.0], false),
        cmd::DO_SET_CAM_TRIGG_DIST => ([p1, 0.0, as_u8(p3), 0.0], false),
        cmd::DO_FENCE_ENABLE | cmd::DO_PARACHUTE | cmd::DO_INVERTED_FLIGHT => {
            ([as_u16(p1), 0.0, 0.0, 0.0], false)
        }
        cmd::DO_GRIPPER => ([as_u8(p1), as_u8(p2), 0.0, 0.0], false),
        cmd::DO_GUIDED_LIMITS => ([as_u16(p1), p2, p3, p4], false),
        _ => return Err(MAV_MISSION_UNSUPPORTED),
    };
    let mut out = MissionItem {
        seq: it.seq,
        command: it.command,
        frame: frame::GLOBAL,
        current: 0,
        autocontinue: 1,
        params,
        x: 0,
        y: 0,
        z: 0.0,
        mission_type: mission_type::MISSION,
    };
    if it.command == cmd::DO_DIGICAM_CONTROL {
        // shooting_cmd and cmd_id are bytes.
        out.x = it.x.clamp(0, 255);
        out.y = it.y.clamp(0, 255);
    }
    if location {
        if !check_lat(it.x) {
            return Err(MAV_MISSION_INVALID_PARAM5_X);
        }
        if !check_lng(it.y) {
            return Err(MAV_MISSION_INVALID_PARAM6_Y);
        }
        if it.z.is_nan() || it.z.abs() >= LOCATION_ALT_MAX_M {
            return Err(MAV_MISSION_INVALID_PARAM7);
        }
        out.frame = match it.frame {
            frame::MISSION | frame::GLOBAL | frame::GLOBAL_INT => frame::GLOBAL,
            frame::GLOBAL_RELATIVE_ALT | frame::GLOBAL_RELATIVE_ALT_INT => {
                frame::GLOBAL_RELATIVE_ALT
            }
            frame::GLOBAL_TERRAIN_ALT | frame::GLOBAL_TERRAIN_ALT_INT => frame::GLOBAL_TERRAIN_ALT,
            _ => return Err(MAV_MISSION_UNSUPPORTED_FRAME),
        };
        out.x = it.x;
        out.y = it.y;
        // `alt = packet.z * 100.0f` into a 24-bit centimetre field, back with `* 0.01f`.
        let alt_cm = (it.z * 100.0f32) as i32;
        out.z = alt_cm as f32 * 0.01f32;
    }
    Ok(out)
}

/// `convert_MISSION_ITEM_INT_to_AC_PolyFenceItem` and back (`get_item_as_mission_item`): the
/// fence item as stored and downloaded (frame GLOBAL, z 0, autocontinue 0).
pub fn store_fence_item(it: &MissionItem) -> Result<MissionItem, MavMissionResult> {
    use MavMissionResult::*;
    if !matches!(
        it.frame,
        frame::GLOBAL
            | frame::GLOBAL_INT
            | frame::GLOBAL_RELATIVE_ALT
            | frame::GLOBAL_RELATIVE_ALT_INT
            | frame::GLOBAL_TERRAIN_ALT
            | frame::GLOBAL_TERRAIN_ALT_INT
    ) {
        return Err(MAV_MISSION_UNSUPPORTED_FRAME);
    }
    let p1 = match it.command {
        cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION | cmd::NAV_FENCE_POLYGON_VERTEX_EXCLUSION => {
            as_u8(it.params[0])
        }
        cmd::NAV_FENCE_RETURN_POINT => 0.0,
        cmd::NAV_FENCE_CIRCLE_INCLUSION | cmd::NAV_FENCE_CIRCLE_EXCLUSION => {
            let r = it.params[0];
            // Stored as an integer when within 0.001 of one, otherwise as a float.
            if r - ((r as i32) as f32) < 0.001 {
                (r as u32) as f32
            } else {
                r
            }
        }
        _ => return Err(MAV_MISSION_UNSUPPORTED),
    };
    Ok(MissionItem {
        seq: it.seq,
        command: it.command,
        frame: frame::GLOBAL,
        current: 0,
        autocontinue: 0,
        params: [p1, 0.0, 0.0, 0.0],
        x: it.x,
        y: it.y,
        z: 0.0,
        mission_type: mission_type::FENCE,
    })
}

/// `convert_MISSION_ITEM_INT_to_RallyLocation` and back: frame GLOBAL_RELATIVE_ALT, the
/// altitude whole metres (int16).
pub fn store_rally_item(it: &MissionItem) -> Result<MissionItem, MavMissionResult> {
    use MavMissionResult::*;
    if it.command != cmd::NAV_RALLY_POINT {
        return Err(MAV_MISSION_UNSUPPORTED);
    }
    if !matches!(
        it.frame,
        frame::GLOBAL_RELATIVE_ALT | frame::GLOBAL_RELATIVE_ALT_INT
    ) {
        return Err(MAV_MISSION_UNSUPPORTED_FRAME);
    }
    if !check_lat(it.x) {
        return Err(MAV_MISSION_INVALID_PARAM5_X);
    }
    if !check_lng(it.y) {
        return Err(MAV_MISSION_INVALID_PARAM6_Y);
    }
    if !(-32768.0..=32767.0).contains(&it.z) {
        return Err(MAV_MISSION_INVALID_PARAM7);
    }
    Ok(MissionItem {
        seq: it.seq,
        command: cmd::NAV_RALLY_POINT,
        frame: frame::GLOBAL_RELATIVE_ALT,
        current: 0,
        autocontinue: 0,
        params: [0.0; 4],
        x: it.x,
        y: it.y,
        z: (it.z as i16) as f32,
        mission_type: mission_type::RALLY,
    })
}

/// `AC_PolyFence_loader::validate_fence`: Err(the warning ArduPilot gives).
fn validate_fence(items: &[MissionItem]) -> Result<(), String> {
    let mut expecting: Option<u16> = None;
    let mut left = 0u32;
    let mut orig = 0u32;
    let mut seen_return = false;
    for it in items {
        match it.command {
            cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION | cmd::NAV_FENCE_POLYGON_VERTEX_EXCLUSION => {
                let n = it.params[0] as u32;
                if n < 3 {
                    return Err(format!("Invalid vertex count ({n})"));
                }
                if left == 0 {
                    left = n;
                    orig = n;
                    expecting = Some(it.command);
                } else if expecting != Some(it.command) {
                    return Err("Received incorrect vertex type".into());
                } else if n != orig {
                    return Err(format!("Unexpected vertex count want={orig} got={n}"));
                }
                left -= 1;
            }
            cmd::NAV_FENCE_CIRCLE_INCLUSION | cmd::NAV_FENCE_CIRCLE_EXCLUSION => {
                if left > 0 {
                    return Err("Received incorrect type".into());
                }
                if it.params[0].is_nan() || it.params[0] <= 0.0 {
                    return Err("Non-positive circle radius".into());
                }
            }
            _ => {
                if left > 0 {
                    return Err("Received incorrect type".into());
                }
                if seen_return {
                    return Err("Multiple return points".into());
                }
                seen_return = true;
            }
        }
        if !check_lat(it.x) || !check_lng(it.y) {
            return Err("Bad lat or lon".into());
        }
    }
    if left > 0 {
        return Err("Incorrect item count".into());
    }
    Ok(())
}

/// `fence_storage_space_required`: format header, then per polygon a type and count byte and 8
/// bytes a vertex, 13 bytes a circle, 9 a return point.
fn fence_storage_required(items: &[MissionItem]) -> u32 {
    let mut bytes = 4u32;
    let mut i = 0;
    while i < items.len() {
        bytes += 1;
        match items[i].command {
            cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION | cmd::NAV_FENCE_POLYGON_VERTEX_EXCLUSION => {
                let n = (items[i].params[0] as usize).max(1);
                bytes += 1 + 8 * n as u32;
                i += n - 1;
            }
            cmd::NAV_FENCE_CIRCLE_INCLUSION | cmd::NAV_FENCE_CIRCLE_EXCLUSION => bytes += 12,
            _ => bytes += 8,
        }
        i += 1;
    }
    bytes
}

/// FENCE_TOTAL after a write: the vertex count of the polygons plus one a circle, plus 2 (the
/// return point and closing point of the old FENCE_POINT protocol), or 0 below 3.
fn fence_total(items: &[MissionItem]) -> f64 {
    let n = items
        .iter()
        .filter(|i| {
            matches!(
                i.command,
                cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION
                    | cmd::NAV_FENCE_POLYGON_VERTEX_EXCLUSION
                    | cmd::NAV_FENCE_CIRCLE_INCLUSION
                    | cmd::NAV_FENCE_CIRCLE_EXCLUSION
            )
        })
        .count() as u8;
    if n < 3 {
        0.0
    } else {
        n as f64 + 2.0
    }
}

/// An upload in progress (`MissionItemProtocol::receiving`).
#[derive(Debug, Clone)]
struct Upload {
    dest: (u8, u8),
    request_i: u16,
    request_last: u16,
    last_receive: Micros,
    last_request: Micros,
    /// Fence items waiting for the end of the transfer.
    staged: Vec<Option<MissionItem>>,
}

/// One `MissionItemProtocol` object.
#[derive(Debug, Clone, Default)]
struct Protocol {
    upload: Option<Upload>,
    warned_request: bool,
    warned_item: bool,
}

/// The three stores and their protocol state.
#[derive(Debug, Clone, Default)]
pub struct MissionStore {
    /// AP_Mission's items: `len()` is MIS_TOTAL; item 0 is the home slot (reads give home).
    pub(super) mission: Vec<MissionItem>,
    pub(super) fence: Vec<MissionItem>,
    pub(super) rally: Vec<MissionItem>,
    protocols: [Protocol; 3],
    /// Before this time the mission storage is not initialised: `num_commands_max()` is 0 and
    /// an upload is refused with NO_SPACE ("Only 0 items are supported"), as ArduCopter does
    /// while it boots (`mission_boot_ms`).
    pub(super) ready_at: Micros,
}

impl MissionStore {
    /// True while an upload of type `ty` is in progress.
    pub fn receiving(&self, ty: u8) -> bool {
        self.protocols
            .get(ty as usize)
            .is_some_and(|p| p.upload.is_some())
    }

    /// The earliest time an upload needs attention (a re-request or its timeout).
    pub(super) fn next_due(&self) -> Option<Micros> {
        self.protocols
            .iter()
            .filter_map(|p| p.upload.as_ref())
            .map(|u| (u.last_request + REQUEST_RESEND + 1).min(u.last_receive + UPLOAD_TIMEOUT + 1))
            .min()
    }
}

impl SimVehicle {
    /// The stored items of `ty` as a download gives them (the mission's item 0 is home).
    pub fn stored_items(&self, ty: u8) -> Vec<MissionItem> {
        let n = self.item_count(ty);
        (0..n).filter_map(|s| self.get_item(ty, s).ok()).collect()
    }

    /// True while an upload of `ty` is in progress.
    pub fn mission_receiving(&self, ty: u8) -> bool {
        self.mission.receiving(ty)
    }

    /// `item_count()` of the protocol (the mission includes its home slot).
    fn item_count(&self, ty: u8) -> u16 {
        let n = match ty {
            mission_type::MISSION => self.mission.mission.len(),
            mission_type::FENCE => match &self.mission.protocols[1].upload {
                Some(u) => u.staged.len(),
                None => self.mission.fence.len(),
            },
            _ => self.mission.rally.len(),
        };
        n.min(u16::MAX as usize) as u16
    }

    fn max_items(&self, ty: u8) -> u16 {
        match ty {
            mission_type::MISSION if self.now < self.mission.ready_at => 0,
            mission_type::MISSION => MISSION_MAX_ITEMS,
            mission_type::FENCE => FENCE_STORAGE_BYTES / 8,
            _ => RALLY_MAX_POINTS,
        }
    }

    /// The home item: `AP::ahrs().get_home()` as a waypoint in frame GLOBAL (zeros until home
    /// is set).
    fn home_item(&self) -> MissionItem {
        let mut it = MissionItem {
            command: cmd::NAV_WAYPOINT,
            autocontinue: 1,
            ..Default::default()
        };
        if self.ekf_gps {
            it.x = (self.home.0 * 1e7).round() as i32;
            it.y = (self.home.1 * 1e7).round() as i32;
            let alt_cm = (self.home.2 * 100.0).round() as i32;
            it.z = alt_cm as f32 * 0.01f32;
        }
        it
    }

    /// `get_item(seq)` of the protocol for `ty`.
    fn get_item(&self, ty: u8, seq: u16) -> Result<MissionItem, MavMissionResult> {
        use MavMissionResult::*;
        let mut it = match ty {
            mission_type::MISSION => {
                if seq != 0 && seq as usize >= self.mission.mission.len() {
                    return Err(MAV_MISSION_INVALID_SEQUENCE);
                }
                let mut it = if seq == 0 {
                    self.home_item()
                } else {
                    self.mission.mission[seq as usize]
                };
                if Some(seq) == self.auto.nav_index() && seq != 0 {
                    it.current = 1;
                }
                it
            }
            mission_type::FENCE => {
                let n = self.mission.fence.len();
                if seq as usize > n {
                    return Err(MAV_MISSION_INVALID_SEQUENCE);
                }
                *self
                    .mission
                    .fence
                    .get(seq as usize)
                    .ok_or(MAV_MISSION_ERROR)?
            }
            _ => *self
                .mission
                .rally
                .get(seq as usize)
                .ok_or(MAV_MISSION_INVALID_SEQUENCE)?,
        };
        it.seq = seq;
        it.mission_type = ty;
        Ok(it)
    }

    /// Set a `*_TOTAL` parameter; a change is notified after the protocol message goes out.
    fn set_total(&mut self, name: &str, value: f64, notices: &mut Vec<Out>) {
        if self.params.value(name) == Some(value) {
            return;
        }
        self.params.set(name, value);
        if let Some(i) = self.params.index_of(name) {
            notices.push(Out::Msg(super::telemetry::param_value_notify(
                &self.params,
                i,
            )));
        }
    }

    /// A mission protocol message from `from` (raw payload of message `id`).
    pub(super) fn mission_message(&mut self, now: Micros, from: (u8, u8), id: u32, payload: &[u8]) {
        self.now = now;
        let Some((ts, tc, msg)) = parse(id, payload) else {
            return;
        };
        if !self.for_me(ts, tc) {
            return;
        }
        let mut notices = Vec::new();
        match msg {
            Incoming::Count { count, ty } => self.handle_count(now, from, count, ty, &mut notices),
            Incoming::Item { item, int, bad } => {
                self.handle_item(now, from, item, int, bad, &mut notices)
            }
            Incoming::Request { seq, ty, int } => self.handle_request(from, seq, ty, int),
            Incoming::RequestList { ty } => {
                if ty > mission_type::RALLY {
                    return;
                }
                if self.mission.receiving(ty) {
                    self.out
                        .push(ack_out(from, MavMissionResult::MAV_MISSION_DENIED, ty));
                    return;
                }
                let n = self.item_count(ty);
                self.out.push(count_out(from, n, ty));
            }
            Incoming::ClearAll { ty } => self.handle_clear_all(now, from, ty, &mut notices),
            Incoming::SetCurrent { seq } => {
                // GCS_MAVLINK::handle_mission_set_current: no ACK; MISSION_CURRENT echoes the
                // requested sequence number when the mission moved.
                if self.set_current_cmd(seq) {
                    let m = self.mission_current(Some(seq));
                    self.push(m);
                }
            }
            Incoming::WritePartial { start, end, ty } => {
                self.handle_write_partial(now, from, start, end, ty)
            }
            // The GCS's MISSION_ACK after a download needs no answer.
            Incoming::Ack => {}
        }
        self.out.extend(notices);
    }

    /// `cancel_upload`: true if no upload runs now (one from the same GCS is dropped).
    fn cancel_upload(&mut self, from: (u8, u8), ty: u8) -> bool {
        let p = &mut self.mission.protocols[ty as usize];
        if let Some(u) = &p.upload {
            if u.dest != from {
                self.out
                    .push(ack_out(from, MavMissionResult::MAV_MISSION_DENIED, ty));
                return false;
            }
            p.upload = None;
        }
        true
    }

    fn handle_count(
        &mut self,
        now: Micros,
        from: (u8, u8),
        count: u16,
        ty: u8,
        notices: &mut Vec<Out>,
    ) {
        if ty > mission_type::RALLY {
            self.out
                .push(ack_out(from, MavMissionResult::MAV_MISSION_UNSUPPORTED, ty));
            return;
        }
        if !self.cancel_upload(from, ty) {
            return;
        }
        let max = self.max_items(ty);
        if count > max {
            self.out
                .push(ack_out(from, MavMissionResult::MAV_MISSION_NO_SPACE, ty));
            self.text(
                MavSeverity::MAV_SEVERITY_WARNING,
                &format!("Only {max} items are supported"),
            );
            return;
        }
        // truncate(): the stored mission and rally points shrink to the new count now.
        match ty {
            mission_type::MISSION => {
                self.mission.mission.truncate(count as usize);
                let n = self.mission.mission.len() as f64;
                self.set_total("MIS_TOTAL", n, notices);
            }
            mission_type::RALLY => {
                self.mission.rally.truncate(count as usize);
                let n = self.mission.rally.len() as f64;
                self.set_total("RALLY_TOTAL", n, notices);
            }
            _ => {}
        }
        let staged = if ty == mission_type::FENCE {
            vec![None; count as usize]
        } else {
            Vec::new()
        };
        self.mission.protocols[ty as usize].upload = Some(Upload {
            dest: from,
            request_i: 0,
            request_last: count.saturating_sub(1),
            last_receive: now,
            last_request: now,
            staged,
        });
        if count == 0 {
            self.transfer_complete(from, ty, notices);
            return;
        }
        let p = &mut self.mission.protocols[ty as usize];
        p.warned_item = false;
        p.warned_request = false;
        self.out.push(request_out(from, 0, ty));
    }

    fn handle_write_partial(&mut self, now: Micros, from: (u8, u8), start: i16, end: i16, ty: u8) {
        if ty > mission_type::RALLY {
            self.out
                .push(ack_out(from, MavMissionResult::MAV_MISSION_UNSUPPORTED, ty));
            return;
        }
        if self.mission.receiving(ty) {
            self.out
                .push(ack_out(from, MavMissionResult::MAV_MISSION_DENIED, ty));
            return;
        }
        let n = self.item_count(ty) as i32;
        if start < 0 || end < 0 || start as i32 > n || end as i32 > n || end < start {
            self.text(
                MavSeverity::MAV_SEVERITY_WARNING,
                "Flight plan update rejected",
            );
            self.out
                .push(ack_out(from, MavMissionResult::MAV_MISSION_ERROR, ty));
            return;
        }
        let staged = if ty == mission_type::FENCE {
            vec![None; self.mission.fence.len()]
        } else {
            Vec::new()
        };
        self.mission.protocols[ty as usize] = Protocol {
            upload: Some(Upload {
                dest: from,
                request_i: start as u16,
                request_last: end as u16,
                last_receive: now,
                last_request: now,
                staged,
            }),
            warned_request: false,
            warned_item: false,
        };
        self.out.push(request_out(from, start as u16, ty));
    }

    fn handle_clear_all(&mut self, now: Micros, from: (u8, u8), ty: u8, notices: &mut Vec<Out>) {
        use MavMissionResult::*;
        if ty > mission_type::RALLY {
            self.out.push(ack_out(from, MAV_MISSION_UNSUPPORTED, ty));
            return;
        }
        if !self.cancel_upload(from, ty) {
            return;
        }
        match ty {
            mission_type::MISSION => {
                // AP_Mission::clear refuses while the mission runs.
                if self.auto.running() {
                    self.out.push(ack_out(from, MAV_MISSION_ERROR, ty));
                    return;
                }
                self.mission.mission.clear();
                self.auto.forget_commands();
                self.set_total("MIS_TOTAL", 0.0, notices);
            }
            mission_type::FENCE => {}
            _ => {
                self.mission.rally.clear();
                self.set_total("RALLY_TOTAL", 0.0, notices);
            }
        }
        // handle_mission_clear_all finishes through transfer_is_complete, so the type's
        // complete() runs on the now empty store (a mission says "Flight plan received").
        self.mission.protocols[ty as usize].upload = Some(Upload {
            dest: from,
            request_i: 0,
            request_last: 0,
            last_receive: now,
            last_request: now,
            staged: Vec::new(),
        });
        self.transfer_complete(from, ty, notices);
    }

    fn handle_request(&mut self, from: (u8, u8), seq: u16, ty: u8, int: bool) {
        use MavMissionResult::*;
        if ty > mission_type::RALLY {
            return;
        }
        // handle_mission_request_int refuses while an upload runs; the older MISSION_REQUEST
        // handler does not look.
        if int && self.mission.receiving(ty) {
            self.out.push(ack_out(from, MAV_MISSION_DENIED, ty));
            return;
        }
        match self.get_item(ty, seq) {
            Ok(item) => {
                if int {
                    self.out.push(raw(
                        msgid::MISSION_ITEM_INT,
                        item_payload(&item, from, true),
                    ));
                } else {
                    // convert_MISSION_ITEM_INT_to_MISSION_ITEM checks the converted lat/lon.
                    let (lat, lon) = (item.x as f32 * 1.0e-7f32, item.y as f32 * 1.0e-7f32);
                    if !xy_not_location(item.command) && (lat.is_nan() || lat.abs() > 90.0) {
                        self.out
                            .push(ack_out(from, MAV_MISSION_INVALID_PARAM5_X, ty));
                        return;
                    }
                    if !xy_not_location(item.command) && (lon.is_nan() || lon.abs() > 180.0) {
                        self.out
                            .push(ack_out(from, MAV_MISSION_INVALID_PARAM6_Y, ty));
                        return;
                    }
                    self.out
                        .push(raw(msgid::MISSION_ITEM, item_payload(&item, from, false)));
                    let p = &mut self.mission.protocols[ty as usize];
                    if !p.warned_request {
                        p.warned_request = true;
                        self.text(
                            MavSeverity::MAV_SEVERITY_WARNING,
                            "got MISSION_REQUEST; use MISSION_REQUEST_INT!",
                        );
                    }
                }
            }
            Err(e) => {
                if int && e == MAV_MISSION_INVALID_SEQUENCE {
                    // "try to educate the GCS on the actual size of the mission".
                    let n = self.item_count(ty);
                    self.out.push(count_out(from, n, ty));
                }
                self.out.push(ack_out(from, e, ty));
            }
        }
    }

    fn handle_item(
        &mut self,
        now: Micros,
        from: (u8, u8),
        item: MissionItem,
        int: bool,
        bad: Option<MavMissionResult>,
        notices: &mut Vec<Out>,
    ) {
        use MavMissionResult::*;
        let ty = item.mission_type;
        if let Some(e) = bad {
            self.out.push(ack_out(from, e, ty));
            return;
        }
        // current = 2: a GUIDED destination; 3: an altitude change (not mission items).
        if ty == mission_type::MISSION && (item.current == 2 || item.current == 3) {
            let result = match store_mission_item(&item) {
                Err(e) => e,
                Ok(stored) if item.current == 2 => {
                    if self.guided_request(&stored) {
                        MAV_MISSION_ACCEPTED
                    } else {
                        MAV_MISSION_ERROR
                    }
                }
                Ok(stored) => {
                    self.change_alt_request(&stored);
                    MAV_MISSION_ACCEPTED
                }
            };
            self.out.push(ack_out(from, result, ty));
            return;
        }
        if ty > mission_type::RALLY {
            self.out.push(ack_out(from, MAV_MISSION_UNSUPPORTED, ty));
            return;
        }
        if !int && !self.mission.protocols[ty as usize].warned_item {
            self.mission.protocols[ty as usize].warned_item = true;
            self.text(
                MavSeverity::MAV_SEVERITY_WARNING,
                "got MISSION_ITEM; GCS should send MISSION_ITEM_INT",
            );
        }
        let Some(up) = &self.mission.protocols[ty as usize].upload else {
            self.out.push(ack_out(from, MAV_MISSION_ERROR, ty));
            return;
        };
        if item.seq != up.request_i {
            self.out
                .push(ack_out(from, MAV_MISSION_INVALID_SEQUENCE, ty));
            return;
        }
        if from != up.dest {
            self.out.push(ack_out(from, MAV_MISSION_DENIED, ty));
            return;
        }
        let request_last = up.request_last;
        let result = self.put_item(ty, &item, request_last, notices);
        if result != MAV_MISSION_ACCEPTED {
            self.out.push(ack_out(from, result, ty));
            self.mission.protocols[ty as usize].upload = None;
            return;
        }
        let up = self.mission.protocols[ty as usize]
            .upload
            .as_mut()
            .expect("checked above");
        up.last_receive = now;
        up.request_i += 1;
        if up.request_i > up.request_last {
            self.transfer_complete(from, ty, notices);
            return;
        }
        up.last_request = now;
        let next = up.request_i;
        self.out.push(request_out(from, next, ty));
    }

    /// replace_item / append_item of the protocol for `ty`.
    fn put_item(
        &mut self,
        ty: u8,
        item: &MissionItem,
        request_last: u16,
        notices: &mut Vec<Out>,
    ) -> MavMissionResult {
        use MavMissionResult::*;
        let seq = item.seq as usize;
        match ty {
            mission_type::MISSION => {
                let stored = match store_mission_item(item) {
                    Ok(s) => s,
                    Err(e) => return e,
                };
                let count = self.mission.mission.len();
                if stored.command == cmd::DO_JUMP {
                    // A jump to item 0 or past the mission being uploaded.
                    let target = stored.params[0] as u16;
                    if (target as usize >= count && target > request_last) || target == 0 {
                        return MAV_MISSION_ERROR;
                    }
                }
                if seq < count {
                    self.mission.mission[seq] = stored;
                } else if seq == count {
                    if seq >= MISSION_MAX_ITEMS as usize {
                        return MAV_MISSION_ERROR;
                    }
                    self.mission.mission.push(stored);
                    self.set_total("MIS_TOTAL", (count + 1) as f64, notices);
                } else {
                    return MAV_MISSION_ERROR;
                }
            }
            mission_type::FENCE => {
                let stored = match store_fence_item(item) {
                    Ok(s) => s,
                    Err(e) => return e,
                };
                let up = self.mission.protocols[1]
                    .upload
                    .as_mut()
                    .expect("an upload runs");
                match up.staged.get_mut(seq) {
                    Some(slot) => *slot = Some(stored),
                    None => return MAV_MISSION_INVALID_SEQUENCE,
                }
            }
            _ => {
                let stored = match store_rally_item(item) {
                    Ok(s) => s,
                    Err(e) => return e,
                };
                let count = self.mission.rally.len();
                if seq < count {
                    self.mission.rally[seq] = stored;
                } else if seq == count && count < RALLY_MAX_POINTS as usize {
                    self.mission.rally.push(stored);
                    self.set_total("RALLY_TOTAL", (count + 1) as f64, notices);
                } else {
                    return MAV_MISSION_ERROR;
                }
            }
        }
        MAV_MISSION_ACCEPTED
    }

    /// `transfer_is_complete`: the type's complete(), then MISSION_ACK with its result.
    fn transfer_complete(&mut self, from: (u8, u8), ty: u8, notices: &mut Vec<Out>) {
        use MavMissionResult::*;
        let up = self.mission.protocols[ty as usize].upload.take();
        let mut texts: Vec<(MavSeverity, String)> = Vec::new();
        let result = match ty {
            mission_type::MISSION => {
                texts.push((
                    MavSeverity::MAV_SEVERITY_INFO,
                    "Flight plan received".into(),
                ));
                MAV_MISSION_ACCEPTED
            }
            mission_type::FENCE => {
                // Items not sent in a partial update keep their stored value.
                let staged = up.map(|u| u.staged).unwrap_or_default();
                let mut items = Vec::with_capacity(staged.len());
                let mut missing = None;
                for (i, s) in staged.into_iter().enumerate() {
                    match s.or_else(|| self.mission.fence.get(i).copied()) {
                        Some(it) => items.push(it),
                        None => {
                            missing = Some(i);
                            break;
                        }
                    }
                }
                if let Some(i) = missing {
                    texts.push((
                        MavSeverity::MAV_SEVERITY_INFO,
                        format!("Error replacing item ({i})"),
                    ));
                    MAV_MISSION_ERROR
                } else if let Err(why) = validate_fence(&items) {
                    texts.push((MavSeverity::MAV_SEVERITY_WARNING, why));
                    texts.push((
                        MavSeverity::MAV_SEVERITY_WARNING,
                        "Fence validation failed".into(),
                    ));
                    MAV_MISSION_ERROR
                } else if fence_storage_required(&items) > FENCE_STORAGE_BYTES as u32 {
                    texts.push((
                        MavSeverity::MAV_SEVERITY_WARNING,
                        "Fence exceeds storage size".into(),
                    ));
                    MAV_MISSION_ERROR
                } else {
                    for (i, it) in items.iter_mut().enumerate() {
                        it.seq = i as u16;
                    }
                    // SITL re-indexes the written fence and says so.
                    texts.push((MavSeverity::MAV_SEVERITY_DEBUG, "Fence Indexed OK".into()));
                    let total = fence_total(&items);
                    self.mission.fence = items;
                    self.set_total("FENCE_TOTAL", total, notices);
                    MAV_MISSION_ACCEPTED
                }
            }
            _ => MAV_MISSION_ACCEPTED,
        };
        self.out.push(ack_out(from, result, ty));
        for (sev, t) in texts {
            self.text(sev, &t);
        }
    }

    /// `MissionItemProtocol::update` for every type: re-send the request after a second
    /// without an item, give up after 8 s.
    pub(super) fn mission_tick(&mut self, now: Micros) {
        for ty in 0..3u8 {
            let Some(up) = &mut self.mission.protocols[ty as usize].upload else {
                continue;
            };
            if now.saturating_sub(up.last_receive) > UPLOAD_TIMEOUT {
                let dest = up.dest;
                self.mission.protocols[ty as usize].upload = None;
                let what = match ty {
                    mission_type::MISSION => "Mission",
                    mission_type::FENCE => "Fence",
                    _ => "Rally",
                };
                self.text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    &format!("{what} upload timeout"),
                );
                self.out.push(ack_out(
                    dest,
                    MavMissionResult::MAV_MISSION_OPERATION_CANCELLED,
                    ty,
                ));
                continue;
            }
            if now.saturating_sub(up.last_request) > REQUEST_RESEND {
                up.last_request = now;
                let (dest, seq) = (up.dest, up.request_i);
                self.out.push(request_out(dest, seq, ty));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wp(seq: u16, frame: u8, params: [f32; 4], x: i32, y: i32, z: f32) -> MissionItem {
        MissionItem {
            seq,
            command: cmd::NAV_WAYPOINT,
            frame,
            params,
            x,
            y,
            z,
            autocontinue: 1,
            ..Default::default()
        }
    }

    /// AP_Mission keeps a copter waypoint's delay (whole seconds) and location only; the frame
    /// comes back without `_INT`; altitudes go through centimetres.
    #[test]
    fn a_waypoint_is_stored_as_ap_mission_keeps_it() {
        let it = wp(
            3,
            frame::GLOBAL_RELATIVE_ALT_INT,
            [2.7, 5.0, 1.0, 90.0],
            1,
            2,
            12.345,
        );
        let s = store_mission_item(&it).unwrap();
        assert_eq!(s.params, [2.0, 0.0, 0.0, 0.0]);
        assert_eq!(s.frame, frame::GLOBAL_RELATIVE_ALT);
        assert_eq!((s.x, s.y, s.seq), (1, 2, 3));
        assert_eq!(s.z, 1234.0f32 * 0.01f32);
        // Yaw NaN is allowed on a waypoint, NaN elsewhere is not.
        let mut nan = wp(1, 3, [0.0, 0.0, 0.0, f32::NAN], 0, 0, 5.0);
        assert!(store_mission_item(&nan).is_ok());
        nan.params[1] = f32::NAN;
        assert_eq!(
            store_mission_item(&nan),
            Err(MavMissionResult::MAV_MISSION_INVALID_PARAM2)
        );
        let bad_frame = wp(1, 1, [0.0; 4], 0, 0, 5.0);
        assert_eq!(
            store_mission_item(&bad_frame),
            Err(MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME)
        );
        let far = wp(1, 3, [0.0; 4], 900_000_001, 0, 5.0);
        assert_eq!(
            store_mission_item(&far),
            Err(MavMissionResult::MAV_MISSION_INVALID_PARAM5_X)
        );
        let mut unknown = wp(1, 3, [0.0; 4], 0, 0, 5.0);
        unknown.command = 31000;
        assert_eq!(
            store_mission_item(&unknown),
            Err(MavMissionResult::MAV_MISSION_UNSUPPORTED)
        );
    }

    /// DO_CHANGE_SPEED carries no location: its frame comes back as GLOBAL (0) although it was
    /// uploaded as GLOBAL_RELATIVE_ALT, as in the real capture (item 3).
    #[test]
    fn a_command_without_location_comes_back_in_frame_global() {
        let it = MissionItem {
            seq: 3,
            command: cmd::DO_CHANGE_SPEED,
            frame: frame::GLOBAL_RELATIVE_ALT,
            params: [1.0, 4.0, -1.0, 0.0],
            autocontinue: 1,
            ..Default::default()
        };
        let s = store_mission_item(&it).unwrap();
        assert_eq!(s.frame, frame::GLOBAL);
        assert_eq!(s.params, [1.0, 4.0, -1.0, 0.0]);
    }

    #[test]
    fn fence_validation_as_ac_polyfence() {
        let v = |n: f32, cmdid: u16| MissionItem {
            command: cmdid,
            params: [n, 0.0, 0.0, 0.0],
            x: 1,
            y: 1,
            ..Default::default()
        };
        let inc = cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION;
        assert!(validate_fence(&[v(3.0, inc), v(3.0, inc), v(3.0, inc)]).is_ok());
        assert!(validate_fence(&[v(3.0, inc), v(3.0, inc)]).is_err());
        assert!(validate_fence(&[v(2.0, inc), v(2.0, inc)]).is_err());
        let circle = cmd::NAV_FENCE_CIRCLE_INCLUSION;
        assert!(validate_fence(&[v(30.0, circle)]).is_ok());
        assert!(validate_fence(&[v(0.0, circle)]).is_err());
        let rp = cmd::NAV_FENCE_RETURN_POINT;
        assert!(validate_fence(&[v(0.0, rp), v(0.0, rp)]).is_err());
        // The real capture: 4 inclusion vertices make FENCE_TOTAL 6.
        assert_eq!(fence_total(&[v(4.0, inc); 4]), 6.0);
        assert_eq!(fence_total(&[v(30.0, circle)]), 0.0);
    }

    #[test]
    fn rally_points_keep_whole_metres_and_need_a_relative_frame() {
        let it = MissionItem {
            command: cmd::NAV_RALLY_POINT,
            frame: frame::GLOBAL_RELATIVE_ALT_INT,
            x: 10,
            y: 20,
            z: 15.7,
            ..Default::default()
        };
        let s = store_rally_item(&it).unwrap();
        assert_eq!(
            (s.frame, s.z, s.autocontinue),
            (frame::GLOBAL_RELATIVE_ALT, 15.0, 0)
        );
        let abs = MissionItem {
            frame: frame::GLOBAL,
            ..it
        };
        assert_eq!(
            store_rally_item(&abs),
            Err(MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME)
        );
    }

    #[test]
    fn mission_item_float_lat_lon_is_converted_in_single_precision() {
        let mut p = vec![0u8; 38];
        p[16..20].copy_from_slice(&(-35.363_262_f32).to_le_bytes());
        p[20..24].copy_from_slice(&(149.165_24_f32).to_le_bytes());
        p[30..32].copy_from_slice(&16u16.to_le_bytes());
        p[32] = 1;
        p[33] = 1;
        let (_, _, m) = parse(msgid::MISSION_ITEM, &p).unwrap();
        let Incoming::Item { item, int, bad } = m else {
            panic!("an item")
        };
        assert!(!int && bad.is_none());
        assert_eq!(item.x, (-35.363_262_f32 * 1.0e7f32) as i32);
        assert_eq!(item.y, (149.165_24_f32 * 1.0e7f32) as i32);
        p[16..20].copy_from_slice(&91.0f32.to_le_bytes());
        let (_, _, m) = parse(msgid::MISSION_ITEM, &p).unwrap();
        assert!(matches!(
            m,
            Incoming::Item {
                bad: Some(MavMissionResult::MAV_MISSION_INVALID_PARAM5_X),
                ..
            }
        ));
    }
}
