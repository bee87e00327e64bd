//! MAVLink 2 signing end to end: the mavterm binary with `--signing-key file:PATH` on a real UDP
//! link, and a pymavlink vehicle that signs with the same key. pymavlink must take every frame
//! mavterm sends (link id 0, timestamps increasing, after the one kept from the last run);
//! mavterm's report must count exactly the pattern the vehicle sent (good, tampered, wrong key,
//! replayed, unsigned, RADIO_STATUS), and keep its last timestamp for the next run. A key file
//! others can read is refused.

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

#[cfg(unix)]
#[test]
fn a_signing_vehicle_and_mavterm_agree() {
    let key = key_hex(); // before the clock starts: it may have to make the venv
    let dir = tempfile::tempdir().unwrap();
    let key_file = dir.path().join("signing.key");
    private_file(&key_file, &format!("{PASS}\n"), 0o600);
    // The last run kept a timestamp 20 s ahead of the clock (as after a crash: the reservation):
    // ours must come after it. (A vehicle more than a minute behind us would be refused.)
    let data = dir.path().join("data");
    let state = data.join("mavterm").join("signing.json");
    std::fs::create_dir_all(state.parent().unwrap()).unwrap();
    let kept = ts_now() + 2_000_000;
    std::fs::write(&state, format!("{{\"timestamp\": {kept}}}")).unwrap();

    let port = common::free_udp_port();
    let mavterm = Command::new(common::mavterm())
        .args([
            "--link",
            &format!("udpin:127.0.0.1:{port}"),
            "--signing-key",
            &format!("file:{}", key_file.display()),
            "--headless",
            "--duration",
            "5",
            "--report",
            "json",
        ])
        .env("XDG_DATA_HOME", &data)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    common::wait_udp_bound(port);
    let py = Command::new(common::python())
        .arg(common::test_path("py/signed_vehicle.py"))
        .args([port.to_string(), key.clone()])
        .output()
        .unwrap();
    assert!(
        py.status.success(),
        "python: {}",
        String::from_utf8_lossy(&py.stderr)
    );
    let py: Value = serde_json::from_slice(&py.stdout).unwrap();
    let out = mavterm.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(!stderr.contains(PASS), "the passphrase never shows");
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();

    // pymavlink took every frame mavterm sent: signed with the key, link id 0, increasing
    // timestamps after the one kept.
    let back = py["back"].as_array().unwrap();
    assert!(back.len() >= 2, "{py}");
    assert!(back.iter().all(|b| b["sig_ok"] == true), "{py}");
    assert!(
        back.iter().all(|b| b["link_id"] == 0 && b["sysid"] == 255),
        "{py}"
    );
    let ts: Vec<u64> = back
        .iter()
        .map(|b| b["timestamp"].as_u64().unwrap())
        .collect();
    assert!(ts[0] > kept, "{} after {kept}", ts[0]);
    assert!(ts.windows(2).all(|w| w[0] < w[1]), "{ts:?}");
    assert_eq!(py["summary"]["badsig"], 0);

    // mavterm counted the pattern, and read only what it took.
    let sent = &py["sent"];
    let c = &source(&report, 1, 1).expect("1:1")["signing"];
    assert_eq!(c["signed"], sent["good"], "{c}");
    assert_eq!(
        c["bad_signature"].as_u64().unwrap(),
        sent["tampered"].as_u64().unwrap() + sent["wrong_key"].as_u64().unwrap(),
        "{c}"
    );
    assert_eq!(c["replayed"], sent["replayed"], "{c}");
    assert_eq!(
        c["rejected"].as_u64().unwrap(),
        c["bad_signature"].as_u64().unwrap() + c["replayed"].as_u64().unwrap()
    );
    let c2 = &source(&report, 2, 1).expect("2:1")["signing"];
    assert_eq!(c2["unsigned"], sent["unsigned"], "{c2}");
    assert_eq!(c2["rejected"], sent["unsigned"], "{c2}");
    let radio = &source(&report, 51, 68).expect("the radio")["signing"];
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
        "tampered and wrongly signed mode 6 never read"
    );
    assert_eq!(report["signing"]["key"], true);

    // The last timestamp is kept for the next run.
    let saved: Value = serde_json::from_slice(&std::fs::read(&state).unwrap()).unwrap();
    assert!(saved["timestamp"].as_u64().unwrap() >= *ts.last().unwrap());
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
