//! Interop with pymavlink over real loopback sockets: pymavlink encodes HEARTBEATs from three
//! systems (MAVLink 2, MAVLink 1, and signed MAVLink 2) with a known pattern of skipped, repeated
//! and swapped sequence numbers; mavterm's headless report must show exactly those counts, and
//! pymavlink must decode mavterm's own heartbeat.

mod common;

use std::io::{BufRead, Read, Write};
use std::process::{Command, Stdio};

use serde_json::Value;

fn source(report: &Value, sysid: u64) -> &Value {
    report["links"][0]["sources"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["sysid"] == sysid)
        .unwrap_or_else(|| panic!("no source {sysid} in {report}"))
}

#[test]
fn pymavlink_sequence_pattern_and_our_heartbeat() {
    let python = common::python(); // before the clock starts: it may have to make the venv
    let port = common::free_udp_port();
    // The stand-in loads pymavlink and makes its frames first, then sends once mavterm holds the
    // port: mavterm's 8 s are for the traffic (about a second of it), not for Python's start.
    let mut child = common::ChildGuard(
        Command::new(python)
            .arg(common::test_path("py/udp_pattern.py"))
            .arg(port.to_string())
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let mut py_out = std::io::BufReader::new(child.0.stdout.take().unwrap());
    let mut line = String::new();
    py_out.read_line(&mut line).unwrap();
    assert_eq!(line.trim(), "ready", "udp_pattern.py did not start");
    let mavterm = Command::new(common::mavterm())
        .args([
            "--link",
            &format!("udpin:127.0.0.1:{port}"),
            "--headless",
            "--duration",
            "8",
            "--report",
            "json",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    common::wait_udp_bound(port);
    let mut stdin = child.0.stdin.take().unwrap();
    writeln!(stdin, "go").unwrap();
    drop(stdin);
    line.clear();
    py_out.read_line(&mut line).unwrap();
    let status = child.0.wait().unwrap();
    let mut err = String::new();
    child
        .0
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    assert!(status.success(), "python failed: {err}");
    let py: Value = serde_json::from_str(&line).unwrap();
    let out = mavterm.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();

    // pymavlink decoded our heartbeat: good CRC, our ids, GCS type.
    let hb = &py["heartbeat"];
    assert_eq!(hb["sysid"], 255, "{py}");
    assert_eq!(hb["compid"], 190);
    assert_eq!(hb["type"], 6, "MAV_TYPE_GCS");
    assert_eq!(hb["autopilot"], 8, "MAV_AUTOPILOT_INVALID");
    assert_eq!(py["bad"], 0);

    let link = &report["links"][0];
    assert_eq!(link["state"], "up");
    assert_eq!(link["crc_errors"], 0);
    assert_eq!(link["unknown_ids"], 0);
    assert_eq!(link["signed_frames"], 20);
    assert_eq!(link["v1_frames"], py["sent"]["2"]);

    let s1 = source(&report, 1);
    assert_eq!(
        (
            &s1["received"],
            &s1["lost"],
            &s1["duplicates"],
            &s1["reordered"]
        ),
        (
            &Value::from(97),
            &Value::from(3),
            &Value::from(1),
            &Value::from(1)
        ),
        "{s1}"
    );
    assert_eq!(s1["loss_pct"], 3.0);
    let s2 = source(&report, 2);
    assert_eq!(
        (
            &s2["received"],
            &s2["lost"],
            &s2["duplicates"],
            &s2["reordered"]
        ),
        (
            &Value::from(75),
            &Value::from(24),
            &Value::from(2),
            &Value::from(0)
        ),
        "{s2}"
    );
    let s3 = source(&report, 3);
    assert_eq!(
        (&s3["received"], &s3["lost"]),
        (&Value::from(20), &Value::from(0))
    );

    let vehicles = report["vehicles"].as_array().unwrap();
    assert_eq!(vehicles.len(), 3);
    for v in vehicles {
        assert_eq!(v["type"], "QUADROTOR");
        assert_eq!(v["mode"], "GUIDED");
        assert_eq!(v["armed"], false);
        assert_eq!(v["system_status"], "STANDBY");
    }
}
