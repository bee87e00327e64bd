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
    #[inline]
    pub fn from_frame(frame: &Frame) -> Option<CommandAck> {
        if frame.msgid != MSG_ID {
            return None;
        }
        Self::read(frame)
    }

    #[inline(never)]
    fn read(frame: &Frame) -> Option<CommandAck> {
        // Wire order: command u16, result u8, progress u8, result_param2 i32, target_system u8,
        // target_component u8 (MAVLink 2 drops trailing zeros: they read as zero).
        let p = crate::wire::payload::Payload(frame.payload());
        Some(CommandAck {
            command: p.u16(0),
            result: p.u8(2),
            progress: p.u8(3),
            result_param2: p.i32(4),
            target_system: p.u8(8),
            target_component: p.u8(9),
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
