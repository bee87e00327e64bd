//! Sans-I/O protocol state machines: messages and time in, what to send out, and when each next
//! needs to be woken. Nothing here reads a clock or touches a socket.

pub mod ack;
pub mod camera;
pub mod commands;
pub mod gimbal;
pub mod loss;
pub mod machine;
pub mod mav_cmds;
pub mod mission;
pub mod modes;
pub mod param_ftp;
pub mod params;
pub mod profile;
pub mod rates;
pub mod rtt;
pub mod sequence;
pub mod statustext;
pub mod streams;
pub mod telemetry;
pub mod vehicles;

/// MAVLink severities (RFC-5424, as in STATUSTEXT): 0 = EMERGENCY … 7 = DEBUG.
pub mod severity {
    pub const ERROR: u8 = 3;
    pub const WARNING: u8 = 4;
    pub const NOTICE: u8 = 5;
    pub const INFO: u8 = 6;
    pub const DEBUG: u8 = 7;
}
