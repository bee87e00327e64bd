//! MAVLink 2 signing end to end: the mavterm binary with `--signing-key file:PATH` on a real UDP
//! link, and a pymavlink vehicle that signs with the same key. pymavlink must take every frame
//! mavterm sends (link id 0, timestamps increasing, after the one kept from the last run);
//! mavterm's report must count exactly the pattern the vehicle sent (good, tampered, wrong key,
//! replayed, unsigned, RADIO_STATUS), and keep its last timestamp for the next run. One frame
//! dated the end of time and a poisoned state file lock nothing. A key file others can read is
//! refused.

mod common;

use std::process::{Command, Stdio};

use serde_json::Value;

const PASS: &str = "mavterm interop passphrase";

/// The signing timestamp now (10 µs units since 2015-01-01, from the guide).
fn ts_now() -> u64 {
    let us = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_micros() as u64;
    (us - 1_420_070_400 * 1_000_000) / 10
}

fn key_hex() -> String {
    common::py_lines("signing.py", &["passphrase", PASS], &[]).remove(0)
}

fn source(report: &Value, sysid: u64, compid: u64) -> Option<&Value> {
    report["links"][0]["sources"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["sysid"] == sysid && s["compid"] == compid)
}

#[cfg(unix)]
fn private_file(path: &std::path::Path, text: &str, mode: u32) {
    use std::os::unix::fs::PermissionsExt;
    std::fs::write(path, text).unwrap();
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode)).unwrap();
}

/// What one run gave: the vehicle's JSON line, mavterm's report, the state file after it.
struct Run {
    py: Value,
    report: Value,
    saved: u64,
}

/// mavterm (`--signing-key file:PATH`, udpin, headless) with the state file holding `kept`
/// (written now), and `signed_vehicle.py` (`future`: its first frame dated 2^48-1) sending to it.
/// The vehicle loads pymavlink first and starts only once mavterm holds its port; mavterm runs
/// 10 s, the vehicle needs about 5 (its pattern, then three of our heartbeats).
#[cfg(unix)]
fn run(key: &str, kept: u64, future: bool) -> Run {
    use std::io::{BufRead, Write};
    let dir = tempfile::tempdir().unwrap();
    let key_file = dir.path().join("signing.key");
    private_file(&key_file, &format!("{PASS}\n"), 0o600);
    let data = dir.path().join("data");
    let state = data.join("mavterm").join("signing.json");
    std::fs::create_dir_all(state.parent().unwrap()).unwrap();
    std::fs::write(&state, format!("{{\"timestamp\": {kept}}}")).unwrap();

    let port = common::free_udp_port();
    let mut args = vec![port.to_string(), key.to_string()];
    if future {
        args.push("future".into());
    }
    let mut py = common::ChildGuard(
        Command::new(common::python())
            .arg(common::test_path("py/signed_vehicle.py"))
            .args(&args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap(),
    );
    let mut py_out = std::io::BufReader::new(py.0.stdout.take().unwrap());
    let mut line = String::new();
    py_out.read_line(&mut line).unwrap();
    assert_eq!(line.trim(), "ready", "signed_vehicle.py did not start");

    let mavterm = Command::new(common::mavterm())
        .args([
            "--link",
            &format!("udpin:127.0.0.1:{port}"),
            "--signing-key",
            &format!("file:{}", key_file.display()),
            "--headless",
            "--duration",
            "10",
            "--report",
            "json",
        ])
        .env("XDG_DATA_HOME", &data)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    common::wait_udp_bound(port);
    let mut stdin = py.0.stdin.take().unwrap();
    writeln!(stdin, "go").unwrap();
    drop(stdin);
    line.clear();
    py_out.read_line(&mut line).unwrap();
    let status = py.0.wait().unwrap();
    assert!(status.success(), "python failed");
    let py: Value = serde_json::from_str(&line).unwrap();
    let out = mavterm.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(!stderr.contains(PASS), "the passphrase never shows");
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    let saved: Value = serde_json::from_slice(&std::fs::read(&state).unwrap()).unwrap();
    Run {
        py,
        report,
        saved: saved["timestamp"].as_u64().unwrap(),
    }
}

/// What pymavlink read of mavterm's frames: all signed with the key, link id 0, timestamps
/// increasing; the timestamps.
fn taken_back(py: &Value) -> Vec<u64> {
    let back = py["back"].as_array().unwrap();
    assert!(back.len() >= 3, "{py}");
    assert!(back.iter().all(|b| b["sig_ok"] == true), "{py}");
    assert!(
        back.iter().all(|b| b["link_id"] == 0 && b["sysid"] == 255),
        "{py}"
    );
    assert_eq!(py["summary"]["badsig"], 0);
    let ts: Vec<u64> = back
        .iter()
        .map(|b| b["timestamp"].as_u64().unwrap())
        .collect();
    assert!(ts.windows(2).all(|w| w[0] < w[1]), "{ts:?}");
    ts
}

/// mavterm counted the vehicle's pattern, and read only what it took. (A few dozen datagrams
/// on loopback, far below a socket buffer: none is lost; the counts still only say what came.)
fn counted_the_pattern(report: &Value, sent: &Value) {
    let c = &source(report, 1, 1).expect("1:1")["signing"];
    assert_eq!(c["signed"], sent["good"], "{c}");
    assert_eq!(
        c["bad_signature"].as_u64().unwrap(),
        sent["tampered"].as_u64().unwrap() + sent["wrong_key"].as_u64().unwrap(),
        "{c}"
    );
    assert_eq!(c["replayed"], sent["replayed"], "{c}");
    assert_eq!(c["future"], sent["future"], "{c}");
    assert_eq!(
        c["rejected"].as_u64().unwrap(),
        c["bad_signature"].as_u64().unwrap()
            + c["replayed"].as_u64().unwrap()
            + c["future"].as_u64().unwrap()
    );
    let c2 = &source(report, 2, 1).expect("2:1")["signing"];
    assert_eq!(c2["unsigned"], sent["unsigned"], "{c2}");
    assert_eq!(c2["rejected"], sent["unsigned"], "{c2}");
    let radio = &source(report, 51, 68).expect("the radio")["signing"];
    assert_eq!(radio["unsigned"], sent["radio"], "{radio}");
    assert_eq!(radio["rejected"], 0, "{radio}");
    let vehicles: Vec<(u64, u64)> = report["vehicles"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| (v["sysid"].as_u64().unwrap(), v["compid"].as_u64().unwrap()))
        .collect();
    assert!(vehicles.contains(&(1, 1)), "{vehicles:?}");
    assert!(
        !vehicles.contains(&(2, 1)),
        "unsigned vehicle not taken: {vehicles:?}"
    );
    let v1 = report["vehicles"]
        .as_array()
        .unwrap()
        .iter()
        .find(|v| v["sysid"] == 1)
        .unwrap();
    assert_eq!(
        v1["custom_mode"], 4,
        "tampered, wrongly signed and end-of-time mode 6 never read"
    );
    assert_eq!(report["signing"]["key"], true);
}

#[cfg(unix)]
#[test]
fn a_signing_vehicle_and_mavterm_agree() {
    let key = key_hex(); // before the clock starts: it may have to make the venv
                         // The last run kept a timestamp 20 s ahead of the clock (as after a crash: the reservation):
                         // ours must come after it. (A vehicle more than a minute behind us would be refused.)
    let kept = ts_now() + 2_000_000;
    let r = run(&key, kept, false);
    let ts = taken_back(&r.py);
    assert!(ts[0] > kept, "{} after {kept}", ts[0]);
    counted_the_pattern(&r.report, &r.py["sent"]);
    assert_eq!(r.report["signing"]["state_repaired_from"], Value::Null);
    // The last timestamp is kept for the next run.
    assert!(r.saved >= *ts.last().unwrap());
}

/// The fault probe of issue 29, end to end: the state file poisoned with 2^48-1 by an earlier
/// run, and a vehicle whose first frame is dated 2^48-1. The file is repaired at start, the frame
/// is refused as from the future, the vehicle's normal frames are taken, and everything mavterm
/// signs (and keeps) stays with the wall clock.
#[cfg(unix)]
#[test]
fn one_frame_dated_the_end_of_time_does_not_lock_the_link() {
    let key = key_hex();
    const END: u64 = (1 << 48) - 1;
    let r = run(&key, END, true);
    assert_eq!(r.report["signing"]["state_repaired_from"], END);
    assert_eq!(r.py["sent"]["future"], 1);
    counted_the_pattern(&r.report, &r.py["sent"]);
    // pymavlink took ours, all within the minute of its own clock (and after its start, less
    // the second our heartbeat may have come before it).
    let ts = taken_back(&r.py);
    let (start, end) = (
        r.py["start_ts"].as_u64().unwrap(),
        r.py["end_ts"].as_u64().unwrap(),
    );
    for t in &ts {
        assert!(
            *t + 200_000 >= start && *t <= end + 6_000_000,
            "{t} outside {start}..{end}"
        );
    }
    assert!(r.saved >= *ts.last().unwrap());
    assert!(r.saved <= end + 6_000_000 + 3_000_000, "kept {}", r.saved);
}

#[cfg(unix)]
#[test]
fn a_key_file_others_can_read_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let key_file = dir.path().join("signing.key");
    private_file(&key_file, &format!("{PASS}\n"), 0o644);
    let out = Command::new(common::mavterm())
        .args([
            "--link",
            "sim://",
            "--signing-key",
            &format!("file:{}", key_file.display()),
            "--headless",
            "--duration",
            "1",
            "--report",
            "json",
        ])
        .env("XDG_DATA_HOME", dir.path())
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("can be read by others") && err.contains("chmod 600"),
        "{err}"
    );
    assert!(!err.contains(PASS), "{err}");
}
