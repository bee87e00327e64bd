//! End to end: `mavterm sim --listen tcp:127.0.0.1:PORT` (the real binary) driven by pymavlink
//! (`tests/py/sim_gcs.py`) as a third-party GCS would: heartbeat, the full parameter list,
//! SET_MESSAGE_INTERVAL at 5 Hz, GUIDED + arm + NAV_TAKEOFF to 10 m.

mod common;

use std::process::Command;

#[test]
fn pymavlink_gcs_against_sim_server() {
    let python = common::python();
    let port = common::free_tcp_port();
    let mut server = common::sim_server(port, "");
    let out = Command::new(&python)
        .arg(common::test_path("py/sim_gcs.py"))
        .arg(port.to_string())
        .output()
        .unwrap_or_else(|e| panic!("cannot run {}: {e}", python.display()));
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && stdout.contains("ALL OK"),
        "pymavlink script failed ({}):\n--- stdout\n{stdout}\n--- stderr\n{stderr}",
        out.status
    );
    assert!(
        server.0.try_wait().unwrap().is_none(),
        "server stopped early"
    );
}
