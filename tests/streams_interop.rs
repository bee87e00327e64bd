//! Telemetry stream requests against pymavlink stand-in vehicles (tests/py/fake_stream_vehicle.py)
//! over TCP, in real time, through the `mavterm` binary (`--headless --report json`), and against
//! the embedded ArduCopter sim on a virtual clock. What the vehicle was asked is the stand-in's
//! record; what came is mavterm's report, measured against what the stand-in was told to send.

mod common;

use std::path::Path;
use std::process::Command;

use common::ChildGuard;
use mavterm::app::AppConfig;
use mavterm::clock::SECOND;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::LinkSpec;
use mavterm::proto::rates::StreamRates;
use mavterm::proto::streams::{ItemState, LinkStreamState, Method};
use mavterm::proto::vehicles::VehicleKey;
use serde_json::Value;

/// QGroundControl's ArduPilot rates, mavterm's defaults: (group, Hz).
const DEFAULT_GROUPS: [(u64, u64); 7] =
    [(1, 2), (2, 2), (3, 2), (6, 3), (10, 10), (11, 10), (12, 3)];

/// Start the stand-in on `ports` with `args`; returns it once it listens.
fn stand_in(ports: &[u16], dir: &Path, args: &[&str]) -> ChildGuard {
    let mut a: Vec<std::ffi::OsString> = Vec::new();
    for p in ports {
        a.extend(["--port".into(), p.to_string().into()]);
    }
    a.extend(["--log-out".into(), dir.join("log.json").into()]);
    // Past any test here: the stand-in is killed when the test ends.
    a.extend(["--duration".into(), "300".into()]);
    a.extend(args.iter().map(|s| s.into()));
    common::stand_in("fake_stream_vehicle.py", &a)
}

/// Run mavterm on `links` for `secs` seconds; its JSON report, and the wall-clock time (Unix
/// seconds) it had exited by.
fn mavterm(links: &[String], secs: u32) -> Value {
    let mut cmd = Command::new(common::mavterm());
    for l in links {
        cmd.args(["--link", l]);
    }
    let run = cmd
        .args(["--headless", "--report", "json", "--duration"])
        .arg(secs.to_string())
        .output()
        .unwrap();
    let ended = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_secs_f64();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let mut report: Value = serde_json::from_slice(&run.stdout).unwrap();
    report["test_ended_unix"] = ended.into();
    report
}

/// What the stand-in says it sent on a port: message id → its wall-clock send times.
type Sent = std::collections::BTreeMap<u64, Vec<f64>>;

/// The stand-in's record of port `port` once mavterm has exited: (message ids received,
/// requests, overlaps). The stand-in is asked to read its sockets to the end and write its log
/// (`log.json.flush`); its answer, the log marked with the token asked, is waited for.
fn record(dir: &Path, port: u16) -> (Vec<u64>, Vec<Value>, u64) {
    let (received, requests, overlaps, _) = record_sent(dir, port);
    (received, requests, overlaps)
}

/// [`record`], and what the stand-in sent ([`Sent`]).
fn record_sent(dir: &Path, port: u16) -> (Vec<u64>, Vec<Value>, u64, Sent) {
    static TOKEN: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    let token = TOKEN
        .fetch_add(1, std::sync::atomic::Ordering::Relaxed)
        .to_string();
    let log = dir.join("log.json");
    let flush = dir.join("log.json.flush");
    let tmp = dir.join("log.json.flush.tmp");
    std::fs::write(&tmp, &token).unwrap();
    std::fs::rename(&tmp, &flush).unwrap();
    let start = std::time::Instant::now();
    let v = loop {
        let v: Option<Value> = std::fs::read_to_string(&log)
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok());
        match v {
            Some(v) if v["flushed"] == token.as_str() => break v,
            _ => {
                // A bound on a hung stand-in only, far past any load.
                assert!(
                    start.elapsed() < std::time::Duration::from_secs(60),
                    "the stand-in never answered the flush"
                );
                std::thread::sleep(std::time::Duration::from_millis(20));
            }
        }
    };
    let p = &v[port.to_string()];
    (
        p["received"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_u64().unwrap())
            .collect(),
        p["requests"].as_array().unwrap().clone(),
        p["overlaps"].as_u64().unwrap(),
        p["sent"]
            .as_object()
            .unwrap()
            .iter()
            .map(|(m, ts)| {
                let ts = ts.as_array().unwrap().iter();
                (
                    m.parse().unwrap(),
                    ts.map(|t| t.as_f64().unwrap()).collect(),
                )
            })
            .collect(),
    )
}

/// (group, Hz) of the REQUEST_DATA_STREAMs received.
fn groups(reqs: &[Value]) -> Vec<(u64, u64)> {
    reqs.iter()
        .filter(|r| r[1] == "group")
        .map(|r| (r[2].as_u64().unwrap(), r[3].as_u64().unwrap()))
        .collect()
}

/// (message id, Hz) of the SET_MESSAGE_INTERVALs received.
fn intervals(reqs: &[Value]) -> Vec<(u64, f64)> {
    reqs.iter()
        .filter(|r| r[1] == "interval")
        .map(|r| (r[2].as_u64().unwrap(), r[3].as_f64().unwrap()))
        .collect()
}

/// The report's streams of 1:1 on link `link`.
fn streams(report: &Value, link: u64) -> &Value {
    let s = report["streams"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["sysid"] == 1 && s["compid"] == 1)
        .unwrap_or_else(|| panic!("no streams of 1:1: {report}"));
    s["links"]
        .as_array()
        .unwrap()
        .iter()
        .find(|l| l["link"] == link)
        .unwrap_or_else(|| panic!("1:1 not on link {link}: {s}"))
}

/// Every message asked on the link flows, at the rate the stand-in was asked, and mavterm
/// measures what came: within `tol` of the rate of the stand-in's own sends in the 10 s before
/// mavterm ended (mavterm's window). Held against the traffic, not the rate asked, since a
/// stand-in on a loaded machine sends late; the rate asked is checked in the requests.
fn all_flowing(report: &Value, link: u64, sent: &Sent, tol: f64) {
    let l = streams(report, link);
    assert_eq!(l["state"], "flowing", "{l}");
    let end = report["test_ended_unix"].as_f64().unwrap();
    for m in l["messages"].as_array().unwrap() {
        assert_eq!(m["state"], "flowing", "{m}");
        let id = m["id"].as_u64().unwrap();
        let got = m["measured_hz"].as_f64().unwrap();
        let times: Vec<f64> = sent
            .get(&id)
            .unwrap_or_else(|| panic!("{id} never sent: {m}"))
            .iter()
            .copied()
            .filter(|t| *t > end - 10.0 && *t <= end)
            .collect();
        assert!(times.len() >= 2, "{id}: {times:?}");
        let came = (times.len() - 1) as f64 / (times[times.len() - 1] - times[0]);
        assert!(
            (got - came).abs() <= tol * came,
            "{id}: mavterm measured {got} Hz, the stand-in sent {came:.2} Hz: {m}"
        );
    }
}

fn tcp(port: u16) -> String {
    format!("tcp:127.0.0.1:{port}")
}

#[test]
fn ardupilot_is_asked_for_each_group_on_each_of_two_links() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (common::free_tcp_port(), common::free_tcp_port());
    let _v = stand_in(&[a, b], dir.path(), &[]);
    let report = mavterm(&[tcp(a), tcp(b)], 12);
    for (i, port) in [a, b].into_iter().enumerate() {
        let (_, reqs, _, sent) = record_sent(dir.path(), port);
        assert_eq!(groups(&reqs), DEFAULT_GROUPS, "port {port}: {reqs:?}");
        assert!(intervals(&reqs).is_empty(), "{reqs:?}");
        all_flowing(&report, i as u64, &sent, 0.15);
        assert_eq!(streams(&report, i as u64)["requests"], 7);
    }
    // One vehicle, on both links.
    assert_eq!(report["vehicles"].as_array().unwrap().len(), 1, "{report}");
    assert_eq!(report["vehicles"][0]["links"], serde_json::json!([0, 1]));
}

#[test]
fn px4_gets_set_message_interval_only_and_one_at_a_time() {
    let dir = tempfile::tempdir().unwrap();
    let port = common::free_tcp_port();
    let _v = stand_in(
        &[port],
        dir.path(),
        &["--autopilot", "px4", "--ack-delay", "0.3"],
    );
    let report = mavterm(&[tcp(port)], 16);
    let (_, reqs, overlaps, sent) = record_sent(dir.path(), port);
    assert!(groups(&reqs).is_empty(), "{reqs:?}");
    assert_eq!(
        overlaps, 0,
        "a second SET_MESSAGE_INTERVAL before the ACK: {reqs:?}"
    );
    let want: Vec<(u64, f64)> = StreamRates::default()
        .messages
        .into_iter()
        .map(|(m, hz)| (m as u64, hz as f64))
        .collect();
    assert_eq!(intervals(&reqs), want);
    // Each after the previous one's ACK, 0.3 s later.
    let times: Vec<f64> = reqs.iter().map(|r| r[0].as_f64().unwrap()).collect();
    for w in times.windows(2) {
        assert!(w[1] - w[0] >= 0.29, "{times:?}");
    }
    all_flowing(&report, 0, &sent, 0.15);
}

#[test]
fn ardupilot_ignoring_group_requests_gets_its_streams_by_interval() {
    let dir = tempfile::tempdir().unwrap();
    let port = common::free_tcp_port();
    let _v = stand_in(&[port], dir.path(), &["--groups", "ignore"]);
    let report = mavterm(&[tcp(port)], 20);
    let (_, reqs, overlaps, sent) = record_sent(dir.path(), port);
    // Asked twice by group, then each group's main messages by interval at its rate.
    let mut twice = DEFAULT_GROUPS.to_vec();
    twice.extend(DEFAULT_GROUPS);
    assert_eq!(groups(&reqs), twice);
    let mut got = intervals(&reqs);
    got.sort_by_key(|x| x.0);
    let want = vec![
        (1, 2.0),   // SYS_STATUS, EXTENDED_STATUS
        (2, 3.0),   // SYSTEM_TIME, EXTRA3
        (24, 2.0),  // GPS_RAW_INT
        (27, 2.0),  // RAW_IMU, RAW_SENSORS
        (29, 2.0),  // SCALED_PRESSURE
        (30, 10.0), // ATTITUDE, EXTRA1
        (33, 3.0),  // GLOBAL_POSITION_INT, POSITION
        (36, 2.0),  // SERVO_OUTPUT_RAW, RC_CHANNELS
        (65, 2.0),  // RC_CHANNELS
        (74, 10.0), // VFR_HUD, EXTRA2
        (147, 3.0), // BATTERY_STATUS
        (193, 3.0), // EKF_STATUS_REPORT
    ];
    assert_eq!(got, want, "{reqs:?}");
    assert_eq!(overlaps, 0);
    let link = streams(&report, 0);
    all_flowing(&report, 0, &sent, 0.15);
    for m in link["messages"].as_array().unwrap() {
        assert_eq!(m["method"], "SET_MESSAGE_INTERVAL", "{m}");
    }
}

#[test]
fn a_vehicle_that_reboots_is_asked_again() {
    let dir = tempfile::tempdir().unwrap();
    let port = common::free_tcp_port();
    let _v = stand_in(&[port], dir.path(), &["--reboot-at", "9"]);
    let report = mavterm(&[tcp(port)], 16);
    let (_, reqs, _, sent) = record_sent(dir.path(), port);
    let mut twice = DEFAULT_GROUPS.to_vec();
    twice.extend(DEFAULT_GROUPS);
    assert_eq!(groups(&reqs), twice, "{reqs:?}");
    // The second round after the reboot.
    assert!(reqs[7][0].as_f64().unwrap() >= 9.0, "{reqs:?}");
    assert_eq!(report["vehicles"][0]["reboots"], 1, "{report}");
    all_flowing(&report, 0, &sent, 0.15);
}

#[test]
fn a_vehicle_that_fades_and_comes_back_is_not_asked_again() {
    let dir = tempfile::tempdir().unwrap();
    let port = common::free_tcp_port();
    let _v = stand_in(&[port], dir.path(), &["--fade-at", "7", "--fade-for", "5"]);
    let report = mavterm(&[tcp(port)], 18);
    let (_, reqs, _, sent) = record_sent(dir.path(), port);
    assert_eq!(groups(&reqs), DEFAULT_GROUPS, "{reqs:?}");
    assert_eq!(report["vehicles"][0]["reboots"], 0, "{report}");
    all_flowing(&report, 0, &sent, 0.15);
}

#[test]
fn a_high_latency_link_carries_nothing_but_our_heartbeat() {
    let dir = tempfile::tempdir().unwrap();
    let port = common::free_tcp_port();
    let _v = stand_in(&[port], dir.path(), &[]);
    let report = mavterm(&[format!("tcp:127.0.0.1:{port}?hl=1")], 8);
    let (received, reqs, _) = record(dir.path(), port);
    assert_eq!(received, vec![0], "only HEARTBEAT: {reqs:?}");
    assert!(reqs.is_empty());
    assert_eq!(streams(&report, 0)["state"], "high-latency");
    assert_eq!(
        report["links"][0]["spec"],
        format!("tcp:127.0.0.1:{port}?hl=1")
    );
}

/// The embedded ArduCopter on a virtual clock: what is asked after connecting arrives at the
/// rates asked, within 10 %.
#[test]
fn sim_streams_arrive_at_the_rates_asked() {
    let spec: LinkSpec = "sim://".parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    r.advance_to(40 * SECOND);
    let s = &r.app.sessions[&VehicleKey(1, 1)].streams;
    assert_eq!(s.link_state(0), Some(LinkStreamState::Flowing));
    assert_eq!(s.requests_sent(0), 7, "asked once, every group");
    let report = s.report(r.now(), 0);
    assert_eq!(report.len(), 12, "{report:?}");
    for m in &report {
        assert_eq!(m.state, ItemState::Flowing, "{m:?}");
        assert!(matches!(m.method, Method::Group(_)));
        let asked = m.requested_hz as f64;
        assert!(
            (m.measured_hz - asked).abs() <= 0.1 * asked,
            "{}: {} Hz asked {asked}",
            m.msgid,
            m.measured_hz
        );
    }
    // The groups at the configured rates.
    let asked: Vec<(u32, f32)> = s.requested(0).collect();
    assert!(asked.contains(&(30, 10.0)) && asked.contains(&(33, 3.0)) && asked.contains(&(2, 3.0)));
}

/// Other rates from the config, and messages asked by interval on top of the groups.
#[test]
fn sim_streams_at_configured_rates_and_extra_messages() {
    let spec: LinkSpec = "sim://".parse().unwrap();
    let rates = StreamRates {
        groups: [(2, 1.0), (6, 5.0), (10, 4.0), (12, 0.5)]
            .into_iter()
            .collect(),
        ardupilot_messages: [(245, 2.0), (193, 5.0)].into_iter().collect(),
        ..StreamRates::default()
    };
    let cfg = AppConfig {
        streams: rates,
        ..AppConfig::default()
    };
    let mut r = VirtualRunner::from_specs(&[spec], cfg).unwrap();
    r.advance_to(40 * SECOND);
    let s = &r.app.sessions[&VehicleKey(1, 1)].streams;
    assert_eq!(s.link_state(0), Some(LinkStreamState::Flowing));
    let mut asked: Vec<(u32, f32)> = s.requested(0).collect();
    asked.sort_by_key(|x| x.0);
    // EXTRA3 at 0.5 Hz is asked at 1 Hz (whole Hz); EKF_STATUS_REPORT by interval at 5 Hz.
    assert_eq!(
        asked,
        vec![
            (1, 1.0),
            (2, 1.0),
            (24, 1.0),
            (30, 4.0),
            (33, 5.0),
            (147, 1.0),
            (193, 5.0),
            (245, 2.0)
        ]
    );
    for m in s.report(r.now(), 0) {
        let asked = m.requested_hz as f64;
        assert_eq!(m.state, ItemState::Flowing, "{m:?}");
        assert!((m.measured_hz - asked).abs() <= 0.1 * asked, "{m:?}");
    }
}
