//! The simulator's ground truth against what a GCS measures: with `loss=0.2` the frames the sim
//! dropped per vehicle equal the sequence gaps a simple `(seq - last - 1) mod 256` counter
//! finds in its output. Virtual time, in process, public API only.

// REQUEST_DATA_STREAM is deprecated in MAVLink but is what ArduPilot GCSs send.
#![allow(deprecated)]

use mavterm::dialect::{MavDataStream, MavMessage, REQUEST_DATA_STREAM_DATA};
use mavterm::link::FrameParser;
use mavterm::sim::{Sim, SimConfig};
use mavterm::wire::frame::{encode, Header, Version};
use std::collections::BTreeMap;

#[allow(deprecated)]
fn request_all_streams(sysid: u8) -> Vec<u8> {
    encode(
        Version::V2,
        Header {
            sysid: 255,
            compid: 190,
            seq: sysid,
        },
        &MavMessage::REQUEST_DATA_STREAM(REQUEST_DATA_STREAM_DATA {
            req_message_rate: 10,
            target_system: sysid,
            target_component: 1,
            req_stream_id: MavDataStream::MAV_DATA_STREAM_ALL,
            start_stop: 1,
        }),
    )
}

#[test]
fn dropped_frames_equal_sequence_gaps() {
    let cfg = SimConfig::from_query("vehicles=2&sysid=1&loss=0.2&seed=12345").unwrap();
    let mut sim = Sim::new(cfg);
    let mut parser = FrameParser::new();
    let mut first: BTreeMap<u8, u8> = BTreeMap::new();
    let mut last: BTreeMap<u8, u8> = BTreeMap::new();
    let mut gaps: BTreeMap<u8, u64> = BTreeMap::new();
    let mut received: BTreeMap<u8, u64> = BTreeMap::new();
    sim.receive(0, &request_all_streams(1));
    sim.receive(0, &request_all_streams(2));
    let mut now = 0;
    while now < 60_000_000 {
        now = sim.next_deadline().clamp(now, 60_000_000);
        let bytes = sim.poll(now);
        parser.push(&bytes, |f| {
            first.entry(f.sysid).or_insert(f.seq);
            *received.entry(f.sysid).or_default() += 1;
            if let Some(l) = last.insert(f.sysid, f.seq) {
                *gaps.entry(f.sysid).or_default() += f.seq.wrapping_sub(l).wrapping_sub(1) as u64;
            }
        });
        if now == 60_000_000 {
            break;
        }
    }
    let truth = sim.truth();
    for sysid in [1u8, 2] {
        let t = truth.get(sysid);
        assert!(t.generated > 10_000, "streams ran: {t:?}");
        // Sequences start at 0, so drops before the first arrival show in its seq; drops after
        // the last arrival show against the last sequence number the vehicle used.
        let head = first[&sysid] as u64;
        let last_used = ((t.generated - 1) % 256) as u8;
        let tail = last_used.wrapping_sub(last[&sysid]) as u64;
        let measured = head + gaps[&sysid] + tail;
        assert_eq!(measured, t.dropped, "sysid {sysid}: {t:?}");
        assert_eq!(received[&sysid] + t.dropped, t.generated);
        let rate = t.dropped as f64 / t.generated as f64;
        assert!((0.18..=0.22).contains(&rate), "loss rate {rate}");
    }
    assert_eq!(parser.stats().crc_errors, 0);
}
