//! Replays the real ArduCopter captures (tests/data, from shared/captures) through our framing,
//! decoding, loss counting and vehicle registry, and compares with the counts a correct decoder
//! (pymavlink 2.4.50) finds, as recorded in expected.json.

use std::collections::BTreeMap;

use mavlink::Message;
use mavterm::app::AppConfig;
use mavterm::dialect::MavMessage;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::tlog::read_tlog;
use mavterm::link::{Frame, FrameParser, LinkSpec};
use mavterm::proto::loss::SeqTracker;
use mavterm::proto::modes::mode_name;
use mavterm::proto::vehicles::VehicleKey;
use serde_json::Value;

fn data(name: &str) -> String {
    format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn expected() -> Value {
    serde_json::from_str(&std::fs::read_to_string(data("expected.json")).unwrap()).unwrap()
}

/// Frames of a tlog, record by record, through the streaming parser.
fn frames_of(name: &str) -> (Vec<Frame>, mavterm::link::ParserStats) {
    let bytes = std::fs::read(data(name)).unwrap();
    let recs = read_tlog(&bytes).unwrap();
    let mut p = FrameParser::new();
    let mut frames = Vec::new();
    for r in &recs {
        p.push(&r.frame, |f| frames.push(f));
    }
    assert_eq!(recs.len(), frames.len(), "{name}: one frame per record");
    (frames, *p.stats())
}

#[test]
fn every_capture_decodes_exactly_like_pymavlink() {
    let exp = expected();
    for (name, e) in exp.as_object().unwrap() {
        let (frames, stats) = frames_of(name);
        assert_eq!(
            frames.len() as u64,
            e["frames"].as_u64().unwrap(),
            "{name} frames"
        );
        let decoded = frames.iter().filter(|f| f.message.is_some()).count() as u64;
        assert_eq!(
            decoded,
            e["decoded_by_pymavlink"].as_u64().unwrap(),
            "{name} decoded"
        );
        assert_eq!(
            stats.crc_errors + stats.truncated + stats.garbage_bytes,
            0,
            "{name}"
        );

        // Sources and sequence gaps.
        let mut trackers: BTreeMap<String, SeqTracker> = BTreeMap::new();
        let mut sources: BTreeMap<String, u64> = BTreeMap::new();
        // pymavlink's rule: each frame adds (seq - previous seq - 1) mod 256 for its source.
        let mut previous: BTreeMap<String, u8> = BTreeMap::new();
        let mut pymavlink_gaps = 0u64;
        for (i, f) in frames.iter().enumerate() {
            let src = VehicleKey(f.sysid, f.compid).to_string();
            trackers
                .entry(src.clone())
                .or_default()
                .record(f.seq, i as u64 * 1000);
            *sources.entry(src.clone()).or_default() += 1;
            if let Some(p) = previous.insert(src, f.seq) {
                pymavlink_gaps += f.seq.wrapping_sub(p).wrapping_sub(1) as u64;
            }
        }
        let exp_sources: BTreeMap<String, u64> = e["sources"]
            .as_object()
            .unwrap()
            .iter()
            .map(|(k, v)| (k.clone(), v.as_u64().unwrap()))
            .collect();
        assert_eq!(sources, exp_sources, "{name} sources");
        assert_eq!(
            pymavlink_gaps,
            e["sequence_gaps"].as_u64().unwrap(),
            "{name} gaps"
        );
        let lost: u64 = trackers.values().map(|t| t.lost).sum();
        let dups: u64 = trackers.values().map(|t| t.duplicates).sum();
        if name == "copter-mission.gcs.tlog" {
            // Its sender's two threads both used 14 and none 15: pymavlink's rule counts a lap
            // (255) plus one; we count what happened, one number used twice and one skipped.
            assert_eq!((lost, dups), (1, 1), "{name}");
        } else {
            assert_eq!((lost, dups), (pymavlink_gaps, 0), "{name} gaps");
        }

        // Counts per message type.
        let mut types: BTreeMap<String, u64> = BTreeMap::new();
        for f in &frames {
            *types.entry(f.name()).or_default() += 1;
        }
        let exp_types: BTreeMap<String, u64> = e["types"]
            .as_object()
            .unwrap()
            .iter()
            .map(|(k, v)| (k.clone(), v.as_u64().unwrap()))
            .collect();
        assert_eq!(types, exp_types, "{name} types");
    }
}

#[test]
fn vehicle_capture_semantics() {
    let exp = expected();
    for name in [
        "copter-flight.vehicle.tlog",
        "copter-mavftp-params.vehicle.tlog",
        "copter-mission.vehicle.tlog",
    ] {
        let e = &exp[name];
        let (frames, _) = frames_of(name);
        let mut modes: Vec<String> = Vec::new();
        let mut texts: Vec<(u64, String)> = Vec::new();
        let mut acks: Vec<(u64, u64)> = Vec::new();
        let mut max_alt_mm = 0i32;
        for f in &frames {
            match f.message.as_deref().unwrap() {
                MavMessage::HEARTBEAT(hb) => {
                    let m = mode_name(hb.autopilot, hb.mavtype, hb.custom_mode);
                    if modes.last() != Some(&m) {
                        modes.push(m);
                    }
                }
                MavMessage::STATUSTEXT(st) => {
                    let end = st.text.iter().position(|&b| b == 0).unwrap_or(50);
                    texts.push((
                        st.severity as u64,
                        String::from_utf8_lossy(&st.text[..end]).into_owned(),
                    ));
                }
                MavMessage::COMMAND_ACK(a) => acks.push((a.command as u64, a.result as u64)),
                MavMessage::GLOBAL_POSITION_INT(p) => max_alt_mm = max_alt_mm.max(p.relative_alt),
                m => {
                    let _ = m.message_name();
                }
            }
        }
        let exp_modes: Vec<String> = e["heartbeat_modes_in_order"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap().to_string())
            .collect();
        assert_eq!(modes, exp_modes, "{name} modes");
        let exp_texts: Vec<(u64, String)> = e["statustext"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| (v[0].as_u64().unwrap(), v[1].as_str().unwrap().to_string()))
            .collect();
        assert_eq!(texts, exp_texts, "{name} statustext");
        let alt = max_alt_mm as f64 / 1000.0;
        assert!(
            (alt - e["max_relative_alt_m"].as_f64().unwrap()).abs() < 0.01,
            "{name} alt {alt}"
        );
        if let Some(exp_acks) = e.get("command_acks") {
            let exp_acks: Vec<(u64, u64)> = exp_acks
                .as_array()
                .unwrap()
                .iter()
                .map(|v| (v[0].as_u64().unwrap(), v[1].as_u64().unwrap()))
                .collect();
            assert_eq!(acks, exp_acks, "{name} acks");
        }
    }
}

#[test]
fn headless_report_on_flight_capture() {
    let spec: LinkSpec = format!("tlog:{}", data("copter-flight.vehicle.tlog"))
        .parse()
        .unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    r.advance_to(30_000_000);
    // Mid-flight: the vehicle is there and not lost.
    let rep = r.app.report();
    assert_eq!(rep["vehicles"][0]["lost"], false);
    r.advance_to(82_000_000);
    let rep = r.app.report();
    let link = &rep["links"][0];
    assert_eq!(link["frames"], 11648);
    assert_eq!(link["crc_errors"], 0);
    assert_eq!(link["unknown_ids"], 0);
    let src = &link["sources"][0];
    assert_eq!(
        (src["sysid"].as_u64(), src["compid"].as_u64()),
        (Some(1), Some(1))
    );
    assert_eq!(src["received"], 11648);
    assert_eq!(src["lost"], 0);
    assert_eq!(src["loss_pct"], 0.0);
    let v = &rep["vehicles"][0];
    assert_eq!(v["type"], "QUADROTOR");
    assert_eq!(v["autopilot"], "ARDUPILOTMEGA");
    assert_eq!(v["mode"], "LAND");
    assert_eq!(v["armed"], false);
    assert_eq!(v["heartbeats"], 88);
    // 41 STATUSTEXTs from the vehicle plus our own notices: the vehicle found, parameters
    // downloaded (the capture holds the original GCS's MAVFTP transfer, addressed to 255:190,
    // which we are too), values the vehicle changed during the flight, and stream requests a
    // replay cannot answer (the capture's VFR_HUD comes slower than the 10 Hz asked).
    let ours = |t: &str| {
        t.starts_with("vehicle ")
            || t.starts_with("parameters of ")
            || t.contains(" changed to ")
            || t.contains("REQUEST_DATA_STREAM")
            || t.contains("SET_MESSAGE_INTERVAL")
    };
    let texts = r
        .app
        .notices
        .iter()
        .filter(|n| n.source == Some(VehicleKey(1, 1)) && !ours(&n.text))
        .count();
    assert_eq!(texts, 41);
    // Lost 5 s after the last heartbeat.
    r.advance_to(90_000_000);
    assert_eq!(r.app.report()["vehicles"][0]["lost"], true);
}
