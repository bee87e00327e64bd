//! End to end: `mavterm::sim::serve` on a free 127.0.0.1 port, driven by pymavlink
//! (`tests/py/sim_gcs.py`) as a real third-party GCS would.
//!
//! Needs a Python with pymavlink: `$MAVTERM_PYTHON`, else `target/venv/bin/python` (made by
//! `.ci/run`). Without either the test fails with instructions rather than skipping, so CI can
//! never pass without having run it.

use mavterm::link::LinkSpec;
use mavterm::sim::{serve, SimConfig};
use std::path::PathBuf;
use std::time::Duration;

fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("MAVTERM_PYTHON") {
        return PathBuf::from(p);
    }
    let venv = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/venv/bin/python");
    if venv.exists() {
        return venv;
    }
    panic!(
        "no Python with pymavlink: set MAVTERM_PYTHON or run `.ci/run` (it creates target/venv: \
         python3 -m venv target/venv && target/venv/bin/pip install pymavlink)"
    );
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn pymavlink_gcs_against_sim_server() {
    let python = python();
    let port = free_port();
    let spec: LinkSpec = format!("tcp:127.0.0.1:{port}").parse().unwrap();
    let server = tokio::spawn(async move { serve(&spec, SimConfig::default()).await });
    // Wait until it listens.
    let mut up = false;
    for _ in 0..100 {
        if tokio::net::TcpStream::connect(("127.0.0.1", port))
            .await
            .is_ok()
        {
            up = true;
            break;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    assert!(up, "sim server did not start listening on port {port}");
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/py/sim_gcs.py");
    let run = tokio::task::spawn_blocking(move || {
        std::process::Command::new(&python)
            .arg(&script)
            .arg(port.to_string())
            .output()
            .unwrap_or_else(|e| panic!("cannot run {}: {e}", python.display()))
    });
    let out = tokio::time::timeout(Duration::from_secs(90), run)
        .await
        .expect("pymavlink script took over 90 s")
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && stdout.contains("ALL OK"),
        "pymavlink script failed ({}):\n--- stdout\n{stdout}\n--- stderr\n{stderr}",
        out.status
    );
    assert!(!server.is_finished(), "server stopped: {:?}", server.await);
    server.abort();
}
