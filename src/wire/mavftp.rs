//! The MAVLink FTP payload (FILE_TRANSFER_PROTOCOL, id 110): opcodes, NAK codes, and the packet
//! codec, shared by the GCS side and the simulated vehicle's server.
//!
//! Payload (251 bytes): `seq u16, session u8, opcode u8, size u8, req_opcode u8,
//! burst_complete u8, padding u8, offset u32, data[239]`, little-endian.

pub const PAYLOAD_LEN: usize = 251;
pub const DATA_LEN: usize = 239;

/// FTP opcodes (MAVLink FTP spec).
pub mod op {
    pub const NONE: u8 = 0;
    pub const TERMINATE_SESSION: u8 = 1;
    pub const RESET_SESSIONS: u8 = 2;
    pub const LIST_DIRECTORY: u8 = 3;
    pub const OPEN_FILE_RO: u8 = 4;
    pub const READ_FILE: u8 = 5;
    pub const CALC_FILE_CRC32: u8 = 14;
    pub const BURST_READ_FILE: u8 = 15;
    pub const ACK: u8 = 128;
    pub const NAK: u8 = 129;
}

/// FTP NAK error codes (first data byte of a NAK).
pub mod err {
    pub const FAIL: u8 = 1;
    pub const INVALID_DATA_SIZE: u8 = 3;
    pub const INVALID_SESSION: u8 = 4;
    pub const EOF: u8 = 6;
    pub const UNKNOWN_COMMAND: u8 = 7;
    pub const FILE_NOT_FOUND: u8 = 10;
}

/// The header fields of an FTP payload plus its data.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FtpPacket {
    pub seq: u16,
    pub session: u8,
    pub opcode: u8,
    pub size: u8,
    pub req_opcode: u8,
    pub burst_complete: u8,
    pub offset: u32,
    pub data: Vec<u8>,
}

impl FtpPacket {
    /// Parse a payload. `data` holds `size` bytes (capped at 239).
    pub fn parse(p: &[u8; PAYLOAD_LEN]) -> FtpPacket {
        let size = p[4];
        let n = (size as usize).min(DATA_LEN);
        FtpPacket {
            seq: u16::from_le_bytes([p[0], p[1]]),
            session: p[2],
            opcode: p[3],
            size,
            req_opcode: p[5],
            burst_complete: p[6],
            offset: u32::from_le_bytes([p[8], p[9], p[10], p[11]]),
            data: p[12..12 + n].to_vec(),
        }
    }

    pub fn to_payload(&self) -> [u8; PAYLOAD_LEN] {
        let mut p = [0u8; PAYLOAD_LEN];
        p[0..2].copy_from_slice(&self.seq.to_le_bytes());
        p[2] = self.session;
        p[3] = self.opcode;
        p[4] = self.size;
        p[5] = self.req_opcode;
        p[6] = self.burst_complete;
        p[8..12].copy_from_slice(&self.offset.to_le_bytes());
        let n = self.data.len().min(DATA_LEN);
        p[12..12 + n].copy_from_slice(&self.data[..n]);
        p
    }

    /// An ACK answering `req` (same session and offset, next sequence).
    pub fn reply_to(req: &FtpPacket) -> FtpPacket {
        FtpPacket {
            seq: req.seq.wrapping_add(1),
            session: req.session,
            opcode: op::ACK,
            size: 0,
            req_opcode: req.opcode,
            burst_complete: 0,
            offset: req.offset,
            data: Vec::new(),
        }
    }

    /// This packet turned into a NAK carrying `code`.
    pub fn nak(mut self, code: u8) -> FtpPacket {
        self.opcode = op::NAK;
        self.size = 1;
        self.data = vec![code];
        self
    }
}
