//! The vehicle side of MAVLink FTP (FILE_TRANSFER_PROTOCOL, id 110), enough of ArduPilot's
//! `GCS_FTP` to serve `@PARAM/param.pck`: OpenFileRO, ReadFile, BurstReadFile, TerminateSession,
//! ResetSessions; every other operation is refused with a NAK and an error code. The packet codec
//! is in `wire::mavftp`.

use super::params::ParamTable;
use crate::clock::Micros;
use crate::wire::mavftp::{err, op, FtpPacket, DATA_LEN};
use crate::wire::param_pck;

/// ArduPilot closes an open file after this long without traffic.
pub const SESSION_TIMEOUT: Micros = 3_000_000;

#[derive(Debug, Clone)]
struct OpenFile {
    session: u8,
    /// Built at the first read, because the padding depends on the read size.
    bytes: Option<Vec<u8>>,
    read_size: Option<usize>,
    last_activity: Micros,
}

#[derive(Debug, Clone)]
struct Burst {
    session: u8,
    seq: u16,
    offset: u32,
    chunk: usize,
    done: bool,
}

/// One vehicle's FTP server: a single open file, like ArduPilot.
#[derive(Debug, Clone, Default)]
pub struct FtpServer {
    open: Option<OpenFile>,
    burst: Option<Burst>,
}

fn is_param_pck(path: &[u8]) -> bool {
    let path = path.split(|&b| b == 0).next().unwrap_or(&[]);
    let Ok(s) = std::str::from_utf8(path) else {
        return false;
    };
    let s = s.strip_prefix('/').unwrap_or(s);
    let base = s.split('?').next().unwrap_or("");
    base == "@PARAM/param.pck"
}

impl FtpServer {
    /// Handle one request; returns the immediate replies. A BurstReadFile starts a burst whose
    /// packets come from [`FtpServer::next_burst_packet`], so the caller can pace them.
    pub fn handle(&mut self, now: Micros, req: &FtpPacket, params: &ParamTable) -> Vec<FtpPacket> {
        if let Some(f) = &self.open {
            if now.saturating_sub(f.last_activity) > SESSION_TIMEOUT && self.burst.is_none() {
                self.open = None;
            }
        }
        let mut reply = FtpPacket::reply_to(req);
        match req.opcode {
            op::NONE => {}
            op::TERMINATE_SESSION | op::RESET_SESSIONS => {
                self.open = None;
                self.burst = None;
            }
            op::OPEN_FILE_RO => {
                if self.open.is_some() {
                    return vec![reply.nak(err::FAIL)];
                }
                if req.size == 0 || req.data.is_empty() {
                    return vec![reply.nak(err::INVALID_DATA_SIZE)];
                }
                if !is_param_pck(&req.data) {
                    return vec![reply.nak(err::FILE_NOT_FOUND)];
                }
                self.open = Some(OpenFile {
                    session: req.session,
                    bytes: None,
                    read_size: None,
                    last_activity: now,
                });
                // ArduPilot reports an estimate (12 bytes per parameter), not the exact size;
                // the transfer ends at EOF.
                let estimate = (params.len() as u32) * 12;
                reply.offset = 0;
                reply.size = 4;
                reply.data = estimate.to_le_bytes().to_vec();
            }
            op::READ_FILE | op::BURST_READ_FILE => {
                let Some(f) = self.open.as_mut().filter(|f| f.session == req.session) else {
                    return vec![reply.nak(err::INVALID_SESSION)];
                };
                f.last_activity = now;
                let chunk = match req.size as usize {
                    0 => DATA_LEN,
                    n => n.min(DATA_LEN),
                };
                // param.pck allows one read size per open file (see param_pck docs).
                match f.read_size {
                    None => f.read_size = Some(chunk),
                    Some(s) if s != chunk => return vec![reply.nak(err::FAIL)],
                    Some(_) => {}
                }
                let bytes = f.bytes.get_or_insert_with(|| {
                    param_pck::encode(
                        &params.to_pck(),
                        params.len().min(u16::MAX as usize) as u16,
                        chunk,
                    )
                });
                if req.opcode == op::BURST_READ_FILE {
                    self.burst = Some(Burst {
                        session: req.session,
                        seq: req.seq.wrapping_add(1),
                        offset: req.offset,
                        chunk,
                        done: false,
                    });
                    return Vec::new();
                }
                let start = req.offset as usize;
                if start >= bytes.len() {
                    return vec![reply.nak(err::EOF)];
                }
                let end = (start + chunk).min(bytes.len());
                reply.size = (end - start) as u8;
                reply.data = bytes[start..end].to_vec();
            }
            op::LIST_DIRECTORY => return vec![reply.nak(err::EOF)],
            _ => return vec![reply.nak(err::UNKNOWN_COMMAND)],
        }
        vec![reply]
    }

    /// True while a burst still has packets to send.
    pub fn bursting(&self) -> bool {
        self.burst.as_ref().is_some_and(|b| !b.done)
    }

    /// The next packet of a running burst: data chunks, the last (short) one flagged
    /// `burst_complete`, then a NAK EOF also flagged, as ArduPilot sends them.
    pub fn next_burst_packet(&mut self, now: Micros) -> Option<FtpPacket> {
        let b = self.burst.as_mut().filter(|b| !b.done)?;
        let Some(f) = self.open.as_mut().filter(|f| f.session == b.session) else {
            self.burst = None;
            return None;
        };
        f.last_activity = now;
        let bytes = f.bytes.as_deref().unwrap_or(&[]);
        let mut p = FtpPacket {
            seq: b.seq,
            session: b.session,
            opcode: op::ACK,
            size: 0,
            req_opcode: op::BURST_READ_FILE,
            burst_complete: 0,
            offset: b.offset,
            data: Vec::new(),
        };
        b.seq = b.seq.wrapping_add(1);
        let start = b.offset as usize;
        if start >= bytes.len() {
            b.done = true;
            p.burst_complete = 1;
            return Some(p.nak(err::EOF));
        }
        let end = (start + b.chunk).min(bytes.len());
        p.size = (end - start) as u8;
        p.data = bytes[start..end].to_vec();
        if end - start < b.chunk {
            p.burst_complete = 1;
        }
        b.offset = end as u32;
        Some(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn req(seq: u16, opcode: u8, size: u8, offset: u32, data: &[u8]) -> FtpPacket {
        FtpPacket {
            seq,
            session: 7,
            opcode,
            size,
            req_opcode: 0,
            burst_complete: 0,
            offset,
            data: data.to_vec(),
        }
    }

    #[test]
    fn payload_round_trip() {
        let p = req(0x1234, op::READ_FILE, 3, 0xABCDEF, &[1, 2, 3]);
        assert_eq!(FtpPacket::parse(&p.to_payload()), p);
    }

    #[test]
    fn burst_download_decodes_to_the_table() {
        let params = ParamTable::copter(0);
        let mut ftp = FtpServer::default();
        let path = b"@PARAM/param.pck";
        let r = ftp.handle(
            0,
            &req(0, op::OPEN_FILE_RO, path.len() as u8, 0, path),
            &params,
        );
        assert_eq!(r.len(), 1);
        assert_eq!((r[0].opcode, r[0].seq, r[0].size), (op::ACK, 1, 4));
        assert_eq!(r[0].data, (1354u32 * 12).to_le_bytes());
        assert!(ftp
            .handle(0, &req(1, op::BURST_READ_FILE, 239, 0, &[]), &params)
            .is_empty());
        let mut file = Vec::new();
        let mut last = None;
        let mut n = 0;
        while let Some(p) = ftp.next_burst_packet(0) {
            assert_eq!(p.seq, 2 + n);
            n += 1;
            if p.opcode == op::NAK {
                assert_eq!((p.data[0], p.burst_complete), (err::EOF, 1));
                assert_eq!(p.offset as usize, file.len());
                break;
            }
            assert_eq!(p.offset as usize, file.len());
            file.extend_from_slice(&p.data);
            last = Some(p);
        }
        assert_eq!(last.unwrap().burst_complete, 1);
        let f = param_pck::decode(&file).unwrap();
        assert_eq!(f.params, params.to_pck());
        // ReadFile of the same file at the same size, past EOF: NAK EOF.
        let r = ftp.handle(0, &req(9, op::READ_FILE, 239, 239, &[]), &params);
        assert_eq!(r[0].data, file[239..478]);
        let r = ftp.handle(0, &req(10, op::READ_FILE, 239, 1_000_000, &[]), &params);
        assert_eq!((r[0].opcode, r[0].data[0]), (op::NAK, err::EOF));
        // A different read size on the same open file is refused.
        let r = ftp.handle(0, &req(11, op::READ_FILE, 100, 0, &[]), &params);
        assert_eq!((r[0].opcode, r[0].data[0]), (op::NAK, err::FAIL));
        // A second open while one is active fails; terminate then open works.
        let r = ftp.handle(0, &req(12, op::OPEN_FILE_RO, 16, 0, path), &params);
        assert_eq!((r[0].opcode, r[0].data[0]), (op::NAK, err::FAIL));
        let r = ftp.handle(0, &req(13, op::TERMINATE_SESSION, 0, 0, &[]), &params);
        assert_eq!(r[0].opcode, op::ACK);
        let r = ftp.handle(0, &req(14, op::OPEN_FILE_RO, 16, 0, path), &params);
        assert_eq!(r[0].opcode, op::ACK);
    }

    #[test]
    fn naks_for_everything_else() {
        let params = ParamTable::copter(10);
        let mut ftp = FtpServer::default();
        let nak = |ftp: &mut FtpServer, r: FtpPacket| {
            let out = ftp.handle(0, &r, &params);
            assert_eq!(out[0].opcode, op::NAK, "{r:?}");
            out[0].data[0]
        };
        assert_eq!(
            nak(&mut ftp, req(0, op::OPEN_FILE_RO, 9, 0, b"/etc/pass")),
            err::FILE_NOT_FOUND
        );
        assert_eq!(
            nak(&mut ftp, req(0, op::OPEN_FILE_RO, 0, 0, b"")),
            err::INVALID_DATA_SIZE
        );
        assert_eq!(
            nak(&mut ftp, req(0, op::READ_FILE, 10, 0, b"")),
            err::INVALID_SESSION
        );
        assert_eq!(
            nak(&mut ftp, req(0, op::CALC_FILE_CRC32, 0, 0, b"")),
            err::UNKNOWN_COMMAND
        );
        assert_eq!(nak(&mut ftp, req(0, 77, 0, 0, b"")), err::UNKNOWN_COMMAND);
        assert_eq!(
            nak(&mut ftp, req(0, op::LIST_DIRECTORY, 1, 0, b"/")),
            err::EOF
        );
        // Idle sessions time out, so a new open after 3 s succeeds.
        let p = b"@PARAM/param.pck?withdefaults=1";
        assert_eq!(
            ftp.handle(0, &req(0, op::OPEN_FILE_RO, p.len() as u8, 0, p), &params)[0].opcode,
            op::ACK
        );
        assert_eq!(
            nak(&mut ftp, req(0, op::OPEN_FILE_RO, p.len() as u8, 0, p)),
            err::FAIL
        );
        let r = ftp.handle(
            SESSION_TIMEOUT + 1,
            &req(0, op::OPEN_FILE_RO, p.len() as u8, 0, p),
            &params,
        );
        assert_eq!(r[0].opcode, op::ACK);
    }
}
