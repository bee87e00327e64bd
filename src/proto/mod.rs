//! Sans-I/O protocol state machines: messages and time in, what to send out, and when each next
//! needs to be woken. Nothing here reads a clock or touches a socket.

pub mod ack;
pub mod adsb;
pub mod calibration;
pub mod camera;
pub mod commands;
pub mod comp_meta;
pub mod ftp_file;
pub mod geo;
pub mod gimbal;
pub mod health;
pub mod logs;
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
pub mod slot_map;
pub mod statustext;
pub mod streams;
pub mod telemetry;
pub mod vehicles;
