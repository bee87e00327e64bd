//! COMMAND_ACK read with its numbers kept.
//!
//! The `mavlink` crate refuses a whole message when an enum field holds a value newer than its
//! dialect (a new MAV_RESULT or MAV_CMD from a newer autopilot). An acknowledgement must never be
//! lost that way, so COMMAND_ACK is read from its payload bytes: command and result stay numbers,
//! named when the dialect knows them.

use num_traits::FromPrimitive;

use crate::dialect::MavResult;
use crate::wire::Frame;

/// COMMAND_ACK's message id.
pub const MSG_ID: u32 = <crate::dialect::COMMAND_ACK_DATA as mavlink::MessageData>::ID;

/// A COMMAND_ACK, numbers as sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CommandAck {
    pub command: u16,
    pub result: u8,
    /// Extension fields (0 when absent): progress for IN_PROGRESS, extra result detail, and
    /// whom the ACK is for.
    pub progress: u8,
    pub result_param2: i32,
    pub target_system: u8,
    pub target_component: u8,
}

impl CommandAck {
    /// Read a COMMAND_ACK from a frame (decoded by the dialect or not). `None` for other ids.
    pub fn from_frame(frame: &Frame) -> Option<CommandAck> {
        if frame.msgid != MSG_ID {
            return None;
        }
        // Wire order: command u16, result u8, progress u8, result_param2 i32, target_system u8,
        // target_component u8. MAVLink 2 drops trailing zeros, so pad to the full length.
        let mut p = [0u8; 10];
        let payload = frame.payload();
        let n = payload.len().min(p.len());
        p[..n].copy_from_slice(&payload[..n]);
        Some(CommandAck {
            command: u16::from_le_bytes([p[0], p[1]]),
            result: p[2],
            progress: p[3],
            result_param2: i32::from_le_bytes([p[4], p[5], p[6], p[7]]),
            target_system: p[8],
            target_component: p[9],
        })
    }

    pub fn command_name(&self) -> String {
        command_name(self.command)
    }

    pub fn result_name(&self) -> String {
        result_name(self.result)
    }
}

/// `MAV_CMD_NAV_TAKEOFF` → `NAV_TAKEOFF`; a number the dialect does not know stays a number.
pub use crate::mission::command_name;

/// `MAV_RESULT_DENIED` → `DENIED`; a number the dialect does not know stays a number.
pub fn result_name(result: u8) -> String {
    match MavResult::from_u8(result) {
        Some(r) => {
            let s = format!("{r:?}");
            s.strip_prefix("MAV_RESULT_").unwrap_or(&s).to_string()
        }
        None => format!("result {result}"),
    }
}
