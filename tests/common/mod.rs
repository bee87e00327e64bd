//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

/// The Python with pymavlink: `$MAVTERM_PYTHON`, else the venv `.ci/run` makes under target/.
/// Missing Python is a failure with instructions, never a silent skip.
pub fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("MAVTERM_PYTHON") {
        return PathBuf::from(p);
    }
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/venv/bin/python");
    assert!(
        p.exists(),
        "{} not found: run `bash .ci/run` once (it creates the venv with pymavlink), \
         or set MAVTERM_PYTHON to a Python that has pymavlink",
        p.display()
    );
    p
}

/// A path under tests/.
pub fn test_path(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join(rel)
}

/// A free localhost port (bound and released; good enough for tests on one machine).
pub fn free_udp_port() -> u16 {
    std::net::UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

pub fn free_tcp_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// The mavterm binary built for these tests.
pub fn mavterm() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_mavterm"))
}
