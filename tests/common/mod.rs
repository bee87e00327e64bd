//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

/// The Python with pymavlink: `$MAVTERM_PYTHON`, else a venv under target/ that is made (with
/// pymavlink from PyPI) the first time a test needs it, so `cargo test` works on a fresh clone.
pub fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("MAVTERM_PYTHON") {
        return PathBuf::from(p);
    }
    static VENV: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    VENV.get_or_init(ensure_venv).clone()
}

fn ensure_venv() -> PathBuf {
    let target = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target");
    let py = target.join("venv/bin/python");
    let ok = |py: &PathBuf| {
        py.exists()
            && std::process::Command::new(py)
                .args(["-c", "import pymavlink"])
                .output()
                .map(|o| o.status.success())
                .unwrap_or(false)
    };
    if ok(&py) {
        return py;
    }
    // Test binaries run in parallel: one makes the venv, the others wait for it.
    std::fs::create_dir_all(&target).unwrap();
    let lock = target.join("venv.lock");
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(300);
    loop {
        match std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&lock)
        {
            Ok(_) => break,
            Err(_) if std::time::Instant::now() < deadline => {
                std::thread::sleep(std::time::Duration::from_millis(200));
                if ok(&py) {
                    return py;
                }
            }
            Err(e) => panic!("waiting for {}: {e}", lock.display()),
        }
    }
    let run = |args: &[&str]| {
        let st = std::process::Command::new(args[0])
            .args(&args[1..])
            .status()
            .unwrap_or_else(|e| panic!("{args:?}: {e}"));
        assert!(
            st.success(),
            "{args:?} failed: install python3 with venv support, or set MAVTERM_PYTHON"
        );
    };
    let venv = target.join("venv");
    let result = std::panic::catch_unwind(|| {
        if !py.exists() {
            run(&["python3", "-m", "venv", venv.to_str().unwrap()]);
        }
        let pip = venv.join("bin/pip");
        run(&[
            pip.to_str().unwrap(),
            "install",
            "--quiet",
            "--disable-pip-version-check",
            "pymavlink==2.4.50",
        ]);
    });
    let _ = std::fs::remove_file(&lock);
    if let Err(e) = result {
        std::panic::resume_unwind(e);
    }
    py
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

/// Wait until another process holds UDP `port` (our own bind then fails).
pub fn wait_udp_bound(port: u16) {
    let start = std::time::Instant::now();
    while std::net::UdpSocket::bind(("127.0.0.1", port)).is_ok() {
        assert!(
            // Only against a hang: a loaded machine starts mavterm slowly.
            start.elapsed() < std::time::Duration::from_secs(30),
            "nothing bound UDP port {port}"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

/// The mavterm binary built for these tests.
pub fn mavterm() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_mavterm"))
}

/// A child process killed when the test ends, pass or fail.
pub struct ChildGuard(pub std::process::Child);

impl Drop for ChildGuard {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Start `mavterm sim --listen tcp:127.0.0.1:PORT` and wait until it listens.
pub fn sim_server(port: u16, options: &str) -> ChildGuard {
    let mut child = ChildGuard(
        std::process::Command::new(mavterm())
            .args([
                "sim",
                "--listen",
                &format!("tcp:127.0.0.1:{port}"),
                "--options",
                options,
            ])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap(),
    );
    let start = std::time::Instant::now();
    while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(
            start.elapsed() < std::time::Duration::from_secs(30),
            "sim server did not start listening on port {port}"
        );
        assert!(child.0.try_wait().unwrap().is_none(), "sim server exited");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child
}

/// A HEARTBEAT frame of an ArduCopter (STANDBY) from `sysid`:1 with `custom_mode`.
pub fn copter_heartbeat(sysid: u8, seq: u8, custom_mode: u32) -> Vec<u8> {
    copter_heartbeat_from(sysid, 1, seq, custom_mode)
}

/// A HEARTBEAT frame of an ArduCopter (STANDBY) from `sysid`:`compid` with `custom_mode`.
pub fn copter_heartbeat_from(sysid: u8, compid: u8, seq: u8, custom_mode: u32) -> Vec<u8> {
    use mavterm::dialect::{self, MavMessage};
    use mavterm::wire::frame::{encode, Header, Version};
    let msg = MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
        custom_mode,
        mavtype: dialect::MavType::MAV_TYPE_QUADROTOR,
        autopilot: dialect::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode: dialect::MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
        system_status: dialect::MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
    });
    encode(Version::V2, Header { sysid, compid, seq }, &msg)
}

/// Make a FIFO at `path` with `mkfifo`.
#[cfg(unix)]
pub fn mkfifo(path: &std::path::Path) {
    assert!(std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .unwrap()
        .success());
}

/// Run `tests/py/frames.py MODE` on `lines` (one per line in, one per line out).
fn pymavlink_frames(mode: &str, lines: &[String]) -> Vec<String> {
    py_lines("frames.py", &[mode], lines)
}

/// Run the pymavlink script `tests/py/SCRIPT ARGS` with `lines` on its stdin; its stdout lines.
pub fn py_lines(script: &str, args: &[&str], lines: &[String]) -> Vec<String> {
    use std::io::Write;
    let mut child = std::process::Command::new(python())
        .arg(test_path(&format!("py/{script}")))
        .args(args)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    {
        let mut stdin = child.stdin.take().unwrap();
        for l in lines {
            writeln!(stdin, "{l}").unwrap();
        }
    }
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{script} {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect()
}

/// pymavlink's reading of each frame (header and fields as JSON; `error` when it refused one).
pub fn pymavlink_decode(frames: &[Vec<u8>]) -> Vec<serde_json::Value> {
    let hex: Vec<String> = frames
        .iter()
        .map(|f| f.iter().map(|b| format!("{b:02x}")).collect())
        .collect();
    pymavlink_frames("decode", &hex)
        .iter()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

/// Frames packed by pymavlink: each request is
/// `{"sysid", "compid", "seq", "msg": "HEARTBEAT", "fields": {...}}` (`"v1": true` for MAVLink 1).
pub fn pymavlink_encode(requests: &[serde_json::Value]) -> Vec<Vec<u8>> {
    let lines: Vec<String> = requests.iter().map(|r| r.to_string()).collect();
    pymavlink_frames("encode", &lines)
        .iter()
        .map(|h| {
            (0..h.len())
                .step_by(2)
                .map(|i| u8::from_str_radix(&h[i..i + 2], 16).unwrap())
                .collect()
        })
        .collect()
}

/// Press keys by name (`"enter"`, `"ctrl-p"`, `"y"`) on a virtual runner.
pub fn keys(r: &mut mavterm::driver::virtual_time::VirtualRunner, names: &[&str]) {
    for n in names {
        r.key(n.parse::<mavterm::keymap::Key>().unwrap());
    }
}

/// Answer the question on screen with `y`, the way an operator does: after reading it (a `y`
/// sooner than 0.3 s after the question does not count).
pub fn yes(r: &mut mavterm::driver::virtual_time::VirtualRunner) {
    wait(r, 0.5);
    keys(r, &["y"]);
}

/// Type text, one key per character.
pub fn typed(r: &mut mavterm::driver::virtual_time::VirtualRunner, text: &str) {
    for c in text.chars() {
        r.key(mavterm::keymap::Key::ch(c));
    }
}

/// The screen as plain text at `w`x`h`.
pub fn screen(r: &mavterm::driver::virtual_time::VirtualRunner, w: u16, h: u16) -> String {
    use mavterm::ui::{buffer_to_text, render_to_buffer, Theme};
    buffer_to_text(&render_to_buffer(&r.app, w, h, &Theme::PLAIN))
}

/// The relative altitude the Overview's flight pane shows (`ALT 10.0 m rel`).
pub fn shown_altitude(screen: &str) -> Option<f64> {
    let at = screen.find("ALT ")?;
    let rest = &screen[at + 4..];
    let end = rest.find(" m (rel)")?;
    rest[..end].trim().parse().ok()
}

/// Start a pymavlink stand-in `script` (under tests/py) with `args`; returns it once it prints
/// `listening` on stdout.
pub fn stand_in(script: &str, args: &[std::ffi::OsString]) -> ChildGuard {
    use std::io::BufRead;
    let mut child = std::process::Command::new(python())
        .arg(test_path(&format!("py/{script}")))
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::inherit())
        .spawn()
        .unwrap();
    let mut line = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    assert_eq!(line.trim(), "listening", "{script} did not start");
    ChildGuard(child)
}

/// Type `line` at the `:` prompt and press enter.
pub fn command(r: &mut mavterm::driver::virtual_time::VirtualRunner, line: &str) {
    keys(r, &[":"]);
    typed(r, line);
    keys(r, &["enter"]);
}

/// Let `secs` seconds of virtual time pass.
pub fn wait(r: &mut mavterm::driver::virtual_time::VirtualRunner, secs: f64) {
    let t = r.now() + (secs * 1_000_000.0) as u64;
    r.advance_to(t);
}

/// Run `r` until 1:1's parameters are all in (at most a minute of virtual time).
pub fn downloaded(
    mut r: mavterm::driver::virtual_time::VirtualRunner,
) -> mavterm::driver::virtual_time::VirtualRunner {
    for _ in 0..120 {
        wait(&mut r, 0.5);
        let done = r
            .app
            .sessions
            .get(&mavterm::proto::vehicles::VehicleKey(1, 1))
            .is_some_and(|s| {
                s.params.downloading().is_none()
                    && s.params.autopilot().is_some_and(|p| p.complete())
            });
        if done {
            return r;
        }
    }
    panic!("the download did not finish");
}

/// The frames the core sent in `fx`.
pub fn sent_frames(fx: &[mavterm::app::Effect]) -> Vec<Vec<u8>> {
    fx.iter()
        .filter_map(|e| match e {
            mavterm::app::Effect::Send { frame, .. } => Some(frame.clone()),
            _ => None,
        })
        .collect()
}

/// The messages the core sent in `fx`.
pub fn sent_messages(fx: &[mavterm::app::Effect]) -> Vec<mavterm::dialect::MavMessage> {
    fx.iter()
        .filter_map(|e| match e {
            mavterm::app::Effect::Send { msg, .. } => Some(msg.clone()),
            _ => None,
        })
        .collect()
}

/// Run the `mavterm` binary headless on `tcp:127.0.0.1:PORT`, replaying `script` (`--input`),
/// with `extra` arguments after; it must succeed. Returns its output.
pub fn headless_tcp<S: AsRef<std::ffi::OsStr>>(
    port: u16,
    script: &std::path::Path,
    extra: impl IntoIterator<Item = S>,
) -> std::process::Output {
    let mut cmd = std::process::Command::new(mavterm());
    cmd.args([
        "--link",
        &format!("tcp:127.0.0.1:{port}"),
        "--headless",
        "--input",
    ])
    .arg(script)
    .args(extra);
    succeed(&mut cmd)
}

/// Run `cmd` to its end; it must succeed (its stderr says why not). Returns its output.
pub fn succeed(cmd: &mut std::process::Command) -> std::process::Output {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// The simulator behind link 0.
pub fn sim(r: &mavterm::driver::virtual_time::VirtualRunner) -> &mavterm::sim::Sim {
    r.source(0)
        .unwrap()
        .as_any()
        .downcast_ref::<mavterm::sim::Sim>()
        .unwrap()
}

/// `msg` from 1:1 on link 0 of a core, at `now`: what the core does with it.
pub fn hear(
    app: &mut mavterm::app::App,
    now: u64,
    msg: &mavterm::dialect::MavMessage,
) -> Vec<mavterm::app::Effect> {
    use mavterm::wire::frame::{decode_one, encode, Header, Version};
    let h = Header {
        sysid: 1,
        compid: 1,
        seq: 0,
    };
    let frame = decode_one(&encode(Version::V2, h, msg)).unwrap();
    app.update(
        now,
        mavterm::app::Event::Frames {
            link: 0,
            frames: vec![frame],
            stats: mavterm::link::ParserStats::default(),
        },
    )
}

/// A STATUSTEXT of `severity` saying `text`, in one chunk.
pub fn statustext(
    severity: mavterm::dialect::MavSeverity,
    text: &str,
) -> mavterm::dialect::MavMessage {
    mavterm::dialect::MavMessage::STATUSTEXT(mavterm::dialect::STATUSTEXT_DATA {
        severity,
        text: text.into(),
        id: 0,
        chunk_seq: 0,
    })
}

/// The message id of a MAVLink 1 or 2 frame (`u32::MAX` for what is neither).
pub fn frame_msgid(frame: &[u8]) -> u32 {
    match frame.first() {
        Some(0xFD) if frame.len() >= 10 => u32::from_le_bytes([frame[7], frame[8], frame[9], 0]),
        Some(0xFE) if frame.len() >= 6 => frame[5] as u32,
        _ => u32::MAX,
    }
}

/// The operator's frames among `frames` (those whose id is in `ids`), as pymavlink reads them;
/// mavterm's automatic requests (SET_MESSAGE_INTERVAL, REQUEST_MESSAGE, capabilities, streams)
/// left out.
pub fn operator_messages(frames: &[Vec<u8>], ids: &[u32]) -> Vec<serde_json::Value> {
    let mine: Vec<Vec<u8>> = frames
        .iter()
        .filter(|f| ids.contains(&frame_msgid(f)))
        .cloned()
        .collect();
    if mine.is_empty() {
        return Vec::new();
    }
    pymavlink_decode(&mine)
        .into_iter()
        .inspect(|v| assert!(v.get("error").is_none(), "pymavlink: {v}"))
        .filter(|v| {
            let c = v["command"].as_u64().unwrap_or(0);
            !(v["name"] == "COMMAND_LONG" && matches!(c, 511 | 512 | 520 | 2504 | 2505 | 1000))
        })
        .collect()
}
