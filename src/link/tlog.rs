//! Telemetry logs (`.tlog`) as MAVProxy, QGroundControl and pymavlink write them: for each frame,
//! 8 bytes big-endian microseconds since the Unix epoch, then the raw frame.

use crate::wire::frame::{IFLAG_SIGNED, MAGIC_V1, MAGIC_V2, SIGNATURE_LEN};

/// One record: when it was logged and the frame's bytes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TlogRecord {
    pub time_us: u64,
    pub frame: Vec<u8>,
}

/// Why a tlog could not be read to the end.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TlogError {
    #[error(
        "tlog byte {offset}: expected a MAVLink magic byte after the timestamp, found {found:#04x}"
    )]
    BadMagic { offset: usize, found: u8 },
}

/// Length of the frame starting at `d[0]`, from its header; `None` if not enough bytes.
fn frame_len(d: &[u8]) -> Option<usize> {
    match *d.first()? {
        MAGIC_V1 => Some(6 + *d.get(1)? as usize + 2),
        MAGIC_V2 => {
            let plen = *d.get(1)? as usize;
            let flags = *d.get(2)?;
            let sig = if flags & IFLAG_SIGNED != 0 {
                SIGNATURE_LEN
            } else {
                0
            };
            Some(10 + plen + 2 + sig)
        }
        _ => None,
    }
}

/// Split a tlog into records. A record cut off at the end of the file is dropped (a log whose
/// writer died); a record that does not start with a magic byte is an error.
pub fn read_tlog(bytes: &[u8]) -> Result<Vec<TlogRecord>, TlogError> {
    let mut out = Vec::new();
    let mut i = 0;
    while i + 8 < bytes.len() {
        let time_us = u64::from_be_bytes(bytes[i..i + 8].try_into().expect("8 bytes"));
        let rest = &bytes[i + 8..];
        let b = rest[0];
        if b != MAGIC_V1 && b != MAGIC_V2 {
            return Err(TlogError::BadMagic {
                offset: i + 8,
                found: b,
            });
        }
        let Some(len) = frame_len(rest) else { break };
        if rest.len() < len {
            break;
        }
        out.push(TlogRecord {
            time_us,
            frame: rest[..len].to_vec(),
        });
        i += 8 + len;
    }
    Ok(out)
}

/// Append one record to a tlog buffer.
pub fn write_record(out: &mut Vec<u8>, time_us: u64, frame: &[u8]) {
    out.extend_from_slice(&time_us.to_be_bytes());
    out.extend_from_slice(frame);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_truncated_tail() {
        let mut buf = Vec::new();
        let f1 = vec![0xFD, 1, 0, 0, 0, 1, 1, 0, 0, 0, 7, 0xAA, 0xBB];
        let f2 = vec![0xFE, 0, 0, 1, 1, 0, 0x11, 0x22];
        write_record(&mut buf, 1, &f1);
        write_record(&mut buf, 2, &f2);
        write_record(&mut buf, 3, &f1[..5]);
        let recs = read_tlog(&buf).unwrap();
        assert_eq!(recs.len(), 2);
        assert_eq!(
            recs[1],
            TlogRecord {
                time_us: 2,
                frame: f2
            }
        );
    }

    #[test]
    fn bad_magic_is_an_error() {
        let mut buf = 5u64.to_be_bytes().to_vec();
        buf.extend([0x00, 1, 2, 3]);
        assert!(matches!(
            read_tlog(&buf),
            Err(TlogError::BadMagic { offset: 8, .. })
        ));
    }
}
