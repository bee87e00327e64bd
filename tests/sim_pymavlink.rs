//! End to end: `mavterm sim --listen tcp:127.0.0.1:PORT` (the real binary) driven by pymavlink
//! as a third-party GCS would. `tests/py/sim_gcs.py`: heartbeat, the full parameter list,
//! PARAM_SET's PARAM_VALUE echo (index 65535), AUTOPILOT_VERSION and FTP, SET_MESSAGE_INTERVAL at
//! 5 Hz, GUIDED + arm + NAV_TAKEOFF to 10 m. `tests/py/sim_link.py`: `ftp=0` (no FTP answer, no
//! FTP capability) and `baud=57600` (the list download paced as ArduPilot paces it).

mod common;

use std::process::{Command, Output};

/// Run a pymavlink script against a server started with `options`; its stdout on success.
fn run(script: &str, args: &[&str], options: &str) -> String {
    let python = common::python();
    let port = common::free_tcp_port();
    let mut server = common::sim_server(port, options);
    let port = port.to_string();
    let out: Output = Command::new(&python)
        .arg(common::test_path(script))
        .args(args)
        .arg(&port)
        .output()
        .unwrap_or_else(|e| panic!("cannot run {}: {e}", python.display()));
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && stdout.contains("ALL OK"),
        "pymavlink {script} {args:?} against `{options}` failed ({}):\n--- stdout\n{stdout}\n--- stderr\n{stderr}",
        out.status
    );
    assert!(
        server.0.try_wait().unwrap().is_none(),
        "server stopped early"
    );
    stdout
}

#[test]
fn pymavlink_gcs_against_sim_server() {
    run("py/sim_gcs.py", &[], "");
}

/// `ftp=0`: a firmware built without MAVFTP ignores FILE_TRANSFER_PROTOCOL and does not
/// announce MAV_PROTOCOL_CAPABILITY_FTP.
#[test]
fn pymavlink_ftp_off() {
    run("py/sim_link.py", &["ftp_off"], "ftp=0");
}

/// `baud=57600`: ArduPilot's `queued_param_send` gives parameters at most 30 % of the link:
/// `bw_in_bytes_per_second * dt_ms / 3333` bytes a run, at 57600 baud 5760 B/s, so 1728 B/s for
/// PARAM_VALUEs of 37 bytes (25 of payload, 12 of MAVLink 2 framing). 1,354 of them are 50,098
/// bytes: at least 29.0 s. (The integer rule, 4 a 100 ms run, makes it 33.9 s.) Asserted with
/// slack below and a generous ceiling.
#[test]
fn pymavlink_param_list_at_57600_baud() {
    let floor = 1354.0 * 37.0 / (5760.0 * 0.3);
    assert!((28.9..29.1).contains(&floor));
    let out = run("py/sim_link.py", &["slow_list"], "baud=57600");
    let took: f64 = out
        .lines()
        .find_map(|l| l.strip_prefix("took "))
        .and_then(|t| t.trim().parse().ok())
        .unwrap_or_else(|| panic!("no time in:\n{out}"));
    assert!(
        took >= floor - 2.0,
        "1354 PARAM_VALUE at 57600 baud in {took:.1} s, under the {floor:.1} s floor"
    );
    assert!(took < 90.0, "{took:.1} s");
}

/// The mission protocol against pymavlink as the GCS: a mission built with `mavwp`, a fence and
/// a rally point uploaded with MISSION_ITEM_INT and downloaded back item by item; the vehicle
/// asks with MISSION_REQUEST as ArduCopter does; an old MISSION_REQUEST gets a MISSION_ITEM.
#[test]
fn pymavlink_mission_fence_rally_round_trips() {
    run("py/sim_mission.py", &[], "");
}
