//! The sending side of one link: our own sequence numbers, the MAVLink version the far end
//! speaks, and the signature when we sign.

use super::frame::{encode, Header, Version};
use super::parser::ParserStats;
use super::signing::{sign_frame, SecretKey};
use crate::dialect::MavMessage;

/// What signing a frame takes: the key, the link id put in the signature, and the timestamp.
#[derive(Debug, Clone, Copy)]
pub struct Sign<'a> {
    pub key: &'a SecretKey,
    pub link_id: u8,
    pub timestamp: u64,
}

/// Encodes outgoing messages for one link.
#[derive(Debug, Clone)]
pub struct LinkTx {
    sysid: u8,
    compid: u8,
    seq: u8,
    /// Send MAVLink 1 when everything heard on the link so far was MAVLink 1.
    v1_only_peer: bool,
}

impl LinkTx {
    pub fn new(sysid: u8, compid: u8) -> Self {
        Self {
            sysid,
            compid,
            seq: 0,
            v1_only_peer: false,
        }
    }

    /// Learn the far end's version from what the parser has accepted (totals for the link).
    pub fn observe(&mut self, totals: &ParserStats) {
        self.v1_only_peer = totals.v1_frames > 0 && totals.v2_frames == 0;
    }

    pub fn version(&self) -> Version {
        if self.v1_only_peer {
            Version::V1
        } else {
            Version::V2
        }
    }

    /// The next frame's bytes; sequence numbers increase per link and wrap at 255.
    /// Messages with ids above 255 cannot go in MAVLink 1 and are sent as MAVLink 2.
    pub fn encode(&mut self, msg: &MavMessage) -> Vec<u8> {
        use mavlink::Message;
        let mut version = self.version();
        if msg.message_id() > 255 {
            version = Version::V2;
        }
        let bytes = encode(
            version,
            Header {
                sysid: self.sysid,
                compid: self.compid,
                seq: self.seq,
            },
            msg,
        );
        self.seq = self.seq.wrapping_add(1);
        bytes
    }

    /// The next frame, signed: always MAVLink 2 (MAVLink 1 has no signature), with the same
    /// sequence numbering as [`LinkTx::encode`].
    pub fn encode_signed(&mut self, msg: &MavMessage, sign: Sign) -> Vec<u8> {
        use mavlink::Message;
        let mut bytes = encode(
            Version::V2,
            Header {
                sysid: self.sysid,
                compid: self.compid,
                seq: self.seq,
            },
            msg,
        );
        self.seq = self.seq.wrapping_add(1);
        let extra = MavMessage::extra_crc(msg.message_id());
        sign_frame(&mut bytes, extra, sign.key, sign.link_id, sign.timestamp);
        bytes
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::frame::decode_one;

    #[test]
    fn sequence_increases_and_wraps() {
        let mut tx = LinkTx::new(255, 190);
        let seqs: Vec<u8> = (0..300)
            .map(|_| {
                decode_one(&tx.encode(&MavMessage::HEARTBEAT(Default::default())))
                    .unwrap()
                    .seq
            })
            .collect();
        assert_eq!(seqs[0], 0);
        assert_eq!(seqs[255], 255);
        assert_eq!(seqs[256], 0);
        assert_eq!(seqs[299], 43);
    }

    #[test]
    fn signed_frames_are_v2_whatever_the_peer_speaks() {
        use crate::wire::signing::{read_signature, verify};
        let key = SecretKey::from_passphrase("k");
        let mut tx = LinkTx::new(255, 190);
        tx.observe(&ParserStats {
            v1_frames: 3,
            ..Default::default()
        });
        let sign = Sign {
            key: &key,
            link_id: 2,
            timestamp: 77,
        };
        let b = tx.encode_signed(&MavMessage::HEARTBEAT(Default::default()), sign);
        let f = decode_one(&b).unwrap();
        assert_eq!((f.version, f.seq, f.is_signed()), (Version::V2, 0, true));
        assert!(verify(&key, &b));
        let s = read_signature(&b).unwrap();
        assert_eq!((s.link_id, s.timestamp), (2, 77));
        // The sequence goes on across signed and unsigned frames.
        assert_eq!(
            decode_one(&tx.encode(&MavMessage::HEARTBEAT(Default::default())))
                .unwrap()
                .seq,
            1
        );
    }

    #[test]
    fn speaks_v1_only_to_a_v1_only_peer() {
        let mut tx = LinkTx::new(255, 190);
        assert_eq!(
            tx.encode(&MavMessage::HEARTBEAT(Default::default()))[0],
            0xFD
        );
        tx.observe(&ParserStats {
            v1_frames: 3,
            ..Default::default()
        });
        let f = decode_one(&tx.encode(&MavMessage::HEARTBEAT(Default::default()))).unwrap();
        assert_eq!((f.version, f.sysid, f.compid), (Version::V1, 255, 190));
        tx.observe(&ParserStats {
            v1_frames: 3,
            v2_frames: 1,
            ..Default::default()
        });
        assert_eq!(tx.version(), Version::V2);
    }
}
