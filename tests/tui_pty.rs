//! The real terminal path under a pseudo-terminal (util-linux `script`): run_terminal enters the
//! alternate screen and raw mode, and leaves them on quit, on panic, and on SIGHUP, SIGQUIT,
//! SIGTERM and SIGINT (which end the session normally).
//!
//! The parent test re-runs this test binary's ignored `child_*` tests inside `script`, so the
//! child's stdout is a real tty, then inspects everything the child wrote to it.
//!
//! A Fly mode nudge in progress ends in its stop however the session ends (the quit key,
//! Ctrl-C, SIGHUP, SIGTERM, a panic in the UI loop): the child flies a stand-in vehicle on UDP, which writes down every frame it
//! is sent; pymavlink reads them.

mod common;

use std::io::Write;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Once};
use std::time::{Duration, Instant};

use mavterm::app::AppConfig;
use mavterm::clock::{Clock, Micros, RealClock};
use mavterm::driver::real_time::RealTime;
use mavterm::tui::{run_terminal, TuiOptions};

const ENTER_ALT: &str = "\x1b[?1049h";
const LEAVE_ALT: &str = "\x1b[?1049l";
const SHOW_CURSOR: &str = "\x1b[?25h";

/// A real clock that panics on its `n`th reading: a panic in the middle of the UI loop.
#[derive(Clone)]
struct PanicClock(RealClock, Arc<AtomicU32>, u32);

impl Clock for PanicClock {
    fn now(&self) -> Micros {
        if self.1.fetch_add(1, Ordering::SeqCst) + 1 == self.2 {
            panic!("clock exploded");
        }
        self.0.now()
    }
}

/// A real clock that, the first time the UI loop reads it (the terminal is set up and the signal
/// handlers are in place by then), has `kill` send `signal` to this process a moment later: the
/// signal arrives while the session runs, from outside, as from a shell or sshd.
#[derive(Clone)]
struct SignalClock {
    clock: RealClock,
    signal: &'static str,
    sent: Arc<Once>,
    after: Duration,
}

impl SignalClock {
    fn new(signal: &'static str) -> Self {
        Self::after(signal, Duration::from_millis(300))
    }

    fn after(signal: &'static str, after: Duration) -> Self {
        SignalClock {
            clock: RealClock::new(),
            signal,
            sent: Arc::new(Once::new()),
            after,
        }
    }
}

impl Clock for SignalClock {
    fn now(&self) -> Micros {
        let (signal, after) = (self.signal, self.after);
        self.sent.call_once(|| {
            std::thread::spawn(move || {
                std::thread::sleep(after);
                let status = Command::new("kill")
                    .args([format!("-{signal}"), std::process::id().to_string()])
                    .status()
                    .expect("kill(1)");
                assert!(status.success(), "kill -{signal} failed");
            });
        });
        self.clock.now()
    }
}

/// Run the terminal until it ends: by the quit key, or (`by_quit` false) by a signal.
fn run_child_until(clock: impl Clock + Clone + Send + 'static, by_quit: bool) {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let app = rt
        .block_on(async {
            let core = RealTime::start_with_clock(&[], AppConfig::default(), clock);
            run_terminal(core, TuiOptions::default()).await
        })
        .unwrap();
    assert_eq!(app.quit, by_quit);
    println!("CHILD-DONE");
}

fn run_child(clock: impl Clock + Clone + Send + 'static) {
    run_child_until(clock, true);
}

#[test]
#[ignore = "run by pty tests inside a pseudo-terminal"]
fn child_quits_on_q() {
    run_child(RealClock::new());
}

#[test]
#[ignore = "run by pty tests inside a pseudo-terminal"]
fn child_panics() {
    run_child(PanicClock(RealClock::new(), Arc::new(AtomicU32::new(0)), 5));
}

#[test]
#[ignore = "run by pty tests inside a pseudo-terminal"]
fn child_gets_sighup() {
    run_child_until(SignalClock::new("HUP"), false);
}

#[test]
#[ignore = "run by pty tests inside a pseudo-terminal"]
fn child_gets_sigquit() {
    run_child_until(SignalClock::new("QUIT"), false);
}

#[test]
#[ignore = "run by pty tests inside a pseudo-terminal"]
fn child_gets_sigterm() {
    run_child_until(SignalClock::new("TERM"), false);
}

#[test]
#[ignore = "run by pty tests inside a pseudo-terminal"]
fn child_gets_sigint() {
    run_child_until(SignalClock::new("INT"), false);
}

/// Where the child entered the alternate screen and where it last left it, in its output.
fn alternate_screen(out: &str) -> (usize, usize) {
    let enter = out
        .find(ENTER_ALT)
        .unwrap_or_else(|| panic!("never entered: {out:?}"));
    let leave = out
        .rfind(LEAVE_ALT)
        .unwrap_or_else(|| panic!("never left: {out:?}"));
    (enter, leave)
}

/// Run `child` under `script`, typing `input` until it exits; returns (success, output).
fn under_pty(child: &str, input: &[u8]) -> (bool, String) {
    under_pty_with(child, Typing::Repeat(input), &[])
}

/// What the parent types into the pty.
enum Typing<'a> {
    /// The same bytes every half second until the child exits.
    Repeat(&'a [u8]),
    /// Once `ready` has a line (the child's link heard its vehicle and answered it), each step
    /// at its time (ms after that).
    Once {
        ready: &'a std::path::Path,
        steps: &'a [(u64, Step<'a>)],
    },
}

/// One thing the parent does to the child.
enum Step<'a> {
    Type(&'a [u8]),
    /// `kill -SIG` the child (its pid from `ready` + `.pid`), as sshd does when the session drops.
    Signal(&'a str),
}
/// Start this test binary's ignored test `child` under util-linux `script` (a pty of 100x30,
/// TERM xterm-256color, `env` added), its stdio piped.
fn spawn_under_script(child: &str, env: &[(&str, String)]) -> std::process::Child {
    let exe = std::env::current_exe().unwrap();
    // The pty has no size until told; 0x0 would draw nothing.
    let cmd = format!(
        "stty cols 100 rows 30; {} --ignored --exact --nocapture {child}",
        exe.display()
    );
    Command::new("script")
        .args(["-qec", &cmd, "/dev/null"])
        .envs(env.iter().map(|(k, v)| (*k, v.as_str())))
        .env("TERM", "xterm-256color")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("util-linux `script` is needed for the pty tests")
}

/// Close the child's stdin and wait for it: (success, stdout then stderr).
fn finish(p: std::process::Child, stdin: std::process::ChildStdin) -> (bool, String) {
    drop(stdin);
    let out = p.wait_with_output().unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    (out.status.success(), text)
}

fn under_pty_with(child: &str, typing: Typing, env: &[(&str, String)]) -> (bool, String) {
    let mut p = spawn_under_script(child, env);
    let mut stdin = p.stdin.take().unwrap();
    // Type `input` every half second until the child exits: a slow machine may not be in raw
    // mode yet the first time.
    let start = Instant::now();
    let mut next_type = start + Duration::from_millis(500);
    let mut step = 0;
    let mut ready_at: Option<Instant> = None;
    while p.try_wait().unwrap().is_none() {
        assert!(start.elapsed() < Duration::from_secs(30), "{child} hung");
        match typing {
            Typing::Repeat(input) if !input.is_empty() && Instant::now() >= next_type => {
                let _ = stdin.write_all(input).and_then(|()| stdin.flush());
                next_type += Duration::from_millis(500);
            }
            Typing::Once { ready, steps } => {
                let heard = std::fs::read_to_string(ready).is_ok_and(|t| !t.is_empty());
                match (ready_at, heard) {
                    (None, true) => ready_at = Some(Instant::now()),
                    (Some(at), _) => {
                        if let Some((ms, what)) = steps.get(step) {
                            if at.elapsed() >= Duration::from_millis(*ms) {
                                match what {
                                    Step::Type(bytes) => {
                                        let _ = stdin.write_all(bytes).and_then(|()| stdin.flush());
                                    }
                                    Step::Signal(sig) => {
                                        let pid_file = ready.with_extension("pid");
                                        let pid = std::fs::read_to_string(pid_file).unwrap();
                                        let st = Command::new("kill")
                                            .args([format!("-{sig}"), pid.trim().to_string()])
                                            .status()
                                            .unwrap();
                                        assert!(st.success());
                                    }
                                }
                                step += 1;
                            }
                        }
                    }
                    _ => {}
                }
            }
            _ => {}
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    finish(p, stdin)
}

#[test]
fn quit_key_restores_the_terminal() {
    let (ok, out) = under_pty("child_quits_on_q", b"q");
    assert!(ok, "{out}");
    let (enter, leave) = alternate_screen(&out);
    assert!(enter < leave);
    // Something was drawn in between, and the test harness printed after the restore.
    assert!(out[enter..leave].contains("Vehicles"), "{out:?}");
    assert!(out[leave..].contains("CHILD-DONE"), "{out:?}");
}

#[test]
fn panic_restores_the_terminal_before_the_message() {
    let (ok, out) = under_pty("child_panics", b"");
    assert!(!ok, "the child panicked: {out}");
    let leave = out
        .rfind(LEAVE_ALT)
        .unwrap_or_else(|| panic!("never left: {out:?}"));
    let msg = out
        .find("clock exploded")
        .unwrap_or_else(|| panic!("no message: {out:?}"));
    assert!(
        leave < msg,
        "restore must come before the panic message: {out:?}"
    );
    // Raw mode was off when the message printed: the tty turned its `\n` into `\r\n` (raw
    // mode disables that output processing).
    let nl = msg + out[msg..].find('\n').unwrap();
    assert_eq!(&out[nl - 1..nl], "\r", "raw mode still on: {out:?}");
    assert!(!out.contains("CHILD-DONE"));
}

/// The child got a signal mid-session: it left the alternate screen it entered, showed the
/// cursor, turned raw mode off, and then ended normally (exit 0, its last line printed).
fn signal_restores_the_terminal(child: &str) {
    let (ok, out) = under_pty(child, b"");
    assert!(ok, "{child} must exit 0 after the signal: {out:?}");
    let (enter, leave) = alternate_screen(&out);
    assert!(enter < leave, "{out:?}");
    // It was running (had drawn) when the signal came.
    assert!(out[enter..leave].contains("Vehicles"), "{out:?}");
    let after = &out[leave..];
    let show = after
        .find(SHOW_CURSOR)
        .unwrap_or_else(|| panic!("cursor not shown after leaving: {out:?}"));
    let done = after
        .find("CHILD-DONE")
        .unwrap_or_else(|| panic!("child did not finish: {out:?}"));
    assert!(show < done, "{out:?}");
    // Raw mode off: the tty turns the line's `\n` into `\r\n` again.
    assert!(
        after[done..].starts_with("CHILD-DONE\r\n"),
        "raw mode still on: {out:?}"
    );
}

#[test]
fn sighup_restores_the_terminal() {
    signal_restores_the_terminal("child_gets_sighup");
}

#[test]
fn sigquit_restores_the_terminal() {
    signal_restores_the_terminal("child_gets_sigquit");
}

#[test]
fn sigterm_restores_the_terminal() {
    signal_restores_the_terminal("child_gets_sigterm");
}

#[test]
fn sigint_restores_the_terminal() {
    signal_restores_the_terminal("child_gets_sigint");
}

/// A real clock that, the first time the UI loop reads it, has the terminal made 120x40
/// (`stty` on the controlling tty: the kernel sends SIGWINCH, as a window resize does), then
/// ends the session with SIGTERM a moment later.
#[derive(Clone)]
struct ResizeClock {
    clock: RealClock,
    started: Arc<Once>,
}

impl Clock for ResizeClock {
    fn now(&self) -> Micros {
        self.started.call_once(|| {
            std::thread::spawn(|| {
                std::thread::sleep(Duration::from_millis(300));
                let tty = std::fs::File::open("/dev/tty").expect("a controlling tty");
                let status = Command::new("stty")
                    .args(["cols", "120", "rows", "40"])
                    .stdin(tty)
                    .status()
                    .expect("stty(1)");
                assert!(status.success(), "stty failed");
                std::thread::sleep(Duration::from_millis(1200));
                let status = Command::new("kill")
                    .args(["-TERM".to_string(), std::process::id().to_string()])
                    .status()
                    .expect("kill(1)");
                assert!(status.success(), "kill -TERM failed");
            });
        });
        self.clock.now()
    }
}

#[test]
#[ignore = "run by pty tests inside a pseudo-terminal"]
fn child_is_resized() {
    run_child_until(
        ResizeClock {
            clock: RealClock::new(),
            started: Arc::new(Once::new()),
        },
        false,
    );
}

/// The largest column and row the child moved the cursor to (1-based, from `ESC [ row ; col H`)
/// between entering and leaving the alternate screen.
fn furthest_cursor(out: &str) -> (u32, u32) {
    let (mut col, mut row) = (0, 0);
    for part in out.split("\x1b[").skip(1) {
        let Some(end) = part.find('H') else { continue };
        if let Some((r, c)) = part[..end].split_once(';') {
            if let (Ok(r), Ok(c)) = (r.parse::<u32>(), c.parse::<u32>()) {
                row = row.max(r);
                col = col.max(c);
            }
        }
    }
    (col, row)
}

/// The screen follows a resize: drawn within 100x30 first, then out to 120x40 once the
/// terminal says it is larger (the viewport is fixed between resize events, so a draw does not
/// ask the terminal its size).
#[test]
fn a_resize_redraws_at_the_new_size() {
    let (ok, out) = under_pty("child_is_resized", b"");
    assert!(ok, "child must exit 0 after the signal: {out:?}");
    let (enter, leave) = alternate_screen(&out);
    let screen = &out[enter..leave];
    let (col, row) = furthest_cursor(screen);
    assert!(
        (101..=120).contains(&col) && (31..=40).contains(&row),
        "drawn out to column {col}, row {row}: {out:?}"
    );
    // Before the resize, within 100x30.
    let first = screen.find("Vehicles").expect("drawn");
    let (col0, row0) = furthest_cursor(&screen[..first]);
    assert!(col0 <= 100 && row0 <= 30, "{col0}x{row0}");
}

/// A stand-in ArduCopter 1:1 on UDP, armed in GUIDED: its heartbeat goes to the GCS's port
/// every 200 ms, and every datagram the GCS sends it is appended to `path` (hex, one a line)
/// as it comes, so nothing is lost when the process ends.
fn stand_in_vehicle(gcs_port: u16, path: std::path::PathBuf) {
    use mavterm::dialect::{self, MavMessage};
    let sock = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    let tx = sock.try_clone().unwrap();
    std::thread::spawn(move || {
        for seq in 0u8.. {
            let hb = MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
                custom_mode: 4, // GUIDED
                mavtype: dialect::MavType::MAV_TYPE_QUADROTOR,
                autopilot: dialect::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
                base_mode: dialect::MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED
                    | dialect::MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                system_status: dialect::MavState::MAV_STATE_ACTIVE,
                mavlink_version: 3,
            });
            let header = mavterm::wire::Header {
                sysid: 1,
                compid: 1,
                seq,
            };
            let frame = mavterm::wire::frame::encode(mavterm::wire::Version::V2, header, &hb);
            let _ = tx.send_to(&frame, ("127.0.0.1", gcs_port));
            std::thread::sleep(Duration::from_millis(200));
        }
    });
    std::thread::spawn(move || {
        let mut file = std::fs::File::create(&path).unwrap();
        let mut buf = [0u8; 2048];
        while let Ok(n) = sock.recv(&mut buf) {
            let hex: String = buf[..n].iter().map(|b| format!("{b:02x}")).collect();
            writeln!(file, "{hex}").unwrap();
            file.flush().unwrap();
        }
    });
}

/// The nudge children: the terminal on a UDP link to the stand-in vehicle (port and capture
/// file from the parent), a deadman longer than the session so only the way it ends stops
/// the nudge.
fn run_nudge_child(clock: impl Clock + Clone + Send + 'static, by_quit: bool) {
    let port: u16 = std::env::var("MAVTERM_PTY_PORT").unwrap().parse().unwrap();
    let path = std::path::PathBuf::from(std::env::var("MAVTERM_PTY_CAPTURE").unwrap());
    std::fs::write(path.with_extension("pid"), std::process::id().to_string()).unwrap();
    stand_in_vehicle(port, path);
    // As mavterm runs: the link tasks on their own workers.
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    let spec: mavterm::link::LinkSpec = format!("udpin:127.0.0.1:{port}").parse().unwrap();
    let cfg = AppConfig {
        nudge_deadman: 20_000_000,
        fetch_params: false,
        ..AppConfig::default()
    };
    let app = rt
        .block_on(async {
            let core = RealTime::start_with_clock(&[spec], cfg, clock);
            run_terminal(core, TuiOptions::default()).await
        })
        .unwrap();
    assert_eq!(app.quit, by_quit);
    println!("CHILD-DONE");
}

#[test]
#[ignore = "run by pty tests inside a pseudo-terminal"]
fn child_nudges_then_quits() {
    run_nudge_child(RealClock::new(), true);
}

#[test]
#[ignore = "run by pty tests inside a pseudo-terminal"]
fn child_nudges_then_gets_a_signal() {
    run_nudge_child(RealClock::new(), false);
}

/// A real clock that panics once, the first time the UI thread (the one that made it) reads it
/// after the vehicle has been sent three velocity targets (SET_POSITION_TARGET_LOCAL_NED, id 84,
/// in the capture file): a panic in the middle of the UI loop while a nudge streams. Other
/// threads (the link tasks) and later readings get the time, so what the panic leaves to do can
/// still be done.
#[derive(Clone)]
struct PanicMidNudge {
    clock: RealClock,
    capture: std::path::PathBuf,
    ui: std::thread::ThreadId,
    fired: Arc<std::sync::atomic::AtomicBool>,
}

impl Clock for PanicMidNudge {
    fn now(&self) -> Micros {
        if std::thread::current().id() == self.ui && !self.fired.load(Ordering::SeqCst) {
            let nudges = std::fs::read_to_string(&self.capture)
                .unwrap_or_default()
                .lines()
                .filter(|l| l.starts_with("fd") && l.get(14..20) == Some("540000"))
                .count();
            if nudges >= 3 && !self.fired.swap(true, Ordering::SeqCst) {
                panic!("clock exploded mid-nudge");
            }
        }
        self.clock.now()
    }
}

#[test]
#[ignore = "run by pty tests inside a pseudo-terminal"]
#[should_panic(expected = "clock exploded mid-nudge")]
fn child_nudges_then_panics() {
    let capture = std::path::PathBuf::from(std::env::var("MAVTERM_PTY_CAPTURE").unwrap());
    let clock = PanicMidNudge {
        clock: RealClock::new(),
        capture,
        ui: std::thread::current().id(),
        fired: Arc::new(std::sync::atomic::AtomicBool::new(false)),
    };
    run_nudge_child(clock, false);
}

/// Run a nudge child typing `typing`: what it sent the vehicle, read by pymavlink, and its
/// SET_POSITION_TARGET_LOCAL_NEDs.
fn nudge_session(child: &str, steps: &[(u64, Step)]) -> Vec<serde_json::Value> {
    nudge_session_ending(child, steps, "CHILD-DONE")
}

/// [`nudge_session`], the child's output showing `ends` (how it ended).
fn nudge_session_ending(child: &str, steps: &[(u64, Step)], ends: &str) -> Vec<serde_json::Value> {
    let port = std::net::UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sent.hex");
    let env = [
        ("MAVTERM_PTY_PORT", port.to_string()),
        ("MAVTERM_PTY_CAPTURE", path.display().to_string()),
    ];
    let typing = Typing::Once {
        ready: &path,
        steps,
    };
    let (ok, out) = under_pty_with(child, typing, &env);
    assert!(ok, "{child}: {out:?}");
    assert!(out.contains(ends), "{out:?}");
    let text = std::fs::read_to_string(&path).unwrap();
    // One frame a datagram, or several back to back (MAVLink 2: 12 + payload + 13 if signed).
    let mut frames = Vec::new();
    for line in text.lines() {
        let bytes: Vec<u8> = (0..line.len())
            .step_by(2)
            .map(|i| u8::from_str_radix(&line[i..i + 2], 16).unwrap())
            .collect();
        let mut at = 0;
        while at + 12 <= bytes.len() && bytes[at] == 0xFD {
            let len = 12 + bytes[at + 1] as usize + if bytes[at + 2] & 1 == 1 { 13 } else { 0 };
            frames.push(bytes[at..(at + len).min(bytes.len())].to_vec());
            at += len;
        }
    }
    common::pymavlink_decode(&frames)
        .into_iter()
        .filter(|v| v["name"] == "SET_POSITION_TARGET_LOCAL_NED")
        .collect()
}

/// The nudge flew (a velocity went), and what came after the last velocity is its stop: zero
/// velocity and yaw rate, in the same frame and with the same mask, three times.
fn ends_in_a_stop(targets: &[serde_json::Value]) {
    let moving = |v: &serde_json::Value| v["vx"] != 0.0 || v["vy"] != 0.0 || v["vz"] != 0.0;
    let last = targets
        .iter()
        .rposition(moving)
        .unwrap_or_else(|| panic!("no nudge flown: {targets:?}"));
    let stops = &targets[last + 1..];
    assert!(stops.len() >= 3, "{stops:?}");
    for s in stops {
        assert_eq!(s["yaw_rate"], 0.0, "{s}");
        assert_eq!(
            s["coordinate_frame"], targets[last]["coordinate_frame"],
            "{s}"
        );
        assert_eq!(s["coordinate_frame"], 9, "MAV_FRAME_BODY_OFFSET_NED: {s}");
        assert_eq!(s["type_mask"], targets[last]["type_mask"], "{s}");
        assert_eq!(s["type_mask"], 0x05C7, "{s}");
        assert_eq!(
            (s["target_system"].as_u64(), s["target_component"].as_u64()),
            (Some(1), Some(1))
        );
    }
}

const FLY: Step = Step::Type(b"F");
const UP: Step = Step::Type(b"\x1b[A");

#[test]
fn quitting_during_a_nudge_sends_the_stop() {
    // The stand-in is armed: `q` asks, `y` answers.
    let steps = [
        (300, FLY),
        (600, UP),
        (1100, Step::Type(b"q")),
        (1600, Step::Type(b"y")),
    ];
    ends_in_a_stop(&nudge_session("child_nudges_then_quits", &steps));
}

#[test]
fn ctrl_c_during_a_nudge_sends_the_stop() {
    // The stand-in is armed: the first Ctrl-C asks, the second forces.
    let steps = [
        (300, FLY),
        (600, UP),
        (1100, Step::Type(b"\x03")),
        (1400, Step::Type(b"\x03")),
    ];
    ends_in_a_stop(&nudge_session("child_nudges_then_quits", &steps));
}

#[test]
fn sighup_during_a_nudge_sends_the_stop() {
    let steps = [(300, FLY), (600, UP), (1100, Step::Signal("HUP"))];
    ends_in_a_stop(&nudge_session("child_nudges_then_gets_a_signal", &steps));
}

#[test]
fn sigterm_during_a_nudge_sends_the_stop() {
    let steps = [(300, FLY), (600, UP), (1100, Step::Signal("TERM"))];
    ends_in_a_stop(&nudge_session("child_nudges_then_gets_a_signal", &steps));
}

#[test]
fn a_panic_during_a_nudge_sends_the_stop_before_the_process_ends() {
    // The child panics on its own once three velocity targets have gone (no key ends it): the
    // stop goes out before the panic ends the process, and the panic is the one reported.
    let steps = [(300, FLY), (600, UP)];
    let targets = nudge_session_ending(
        "child_nudges_then_panics",
        &steps,
        "clock exploded mid-nudge",
    );
    ends_in_a_stop(&targets);
}

/// Run `child` under `script`, writing `chunks` 300 ms apart (over again until it exits, a slow
/// machine may not be in raw mode the first time); returns (success, output).
fn under_pty_chunks(child: &str, chunks: &[Vec<u8>]) -> (bool, String) {
    let mut p = spawn_under_script(child, &[]);
    let mut stdin = p.stdin.take().unwrap();
    let start = Instant::now();
    let mut next = start + Duration::from_millis(500);
    let mut i = 0;
    while p.try_wait().unwrap().is_none() {
        assert!(start.elapsed() < Duration::from_secs(30), "{child} hung");
        if Instant::now() >= next {
            let _ = stdin
                .write_all(&chunks[i % chunks.len()])
                .and_then(|()| stdin.flush());
            i += 1;
            next += Duration::from_millis(300);
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    finish(p, stdin)
}

/// Item 7 (issue 30): ~1 kB pasted into the `:` prompt, bracketed as a terminal pastes it, is one
/// event: `esc` then `q` after it still close the prompt and quit. The terminal is asked for
/// bracketed paste on entry and told to stop on leaving.
#[test]
fn keys_after_a_paste_into_the_prompt_still_work() {
    let mut paste = b"\x1b[200~".to_vec();
    paste.extend(std::iter::repeat_n(b'x', 1100));
    paste.extend(b"\x1b[201~");
    let (ok, out) = under_pty_chunks(
        "child_quits_on_q",
        &[b":".to_vec(), paste, b"\x1b".to_vec(), b"q".to_vec()],
    );
    assert!(ok, "{out}");
    assert!(out.contains("\x1b[?2004h"), "bracketed paste never enabled");
    assert!(out.rfind("\x1b[?2004l") > out.rfind("\x1b[?2004h"));
    assert!(out.contains("CHILD-DONE"), "{out:?}");
}

/// The same paste without brackets (a terminal that does not bracket it) arrives as keys: the
/// line stops at its bound and `esc`, `q` after it still work.
#[test]
fn keys_after_an_unbracketed_paste_still_work() {
    let paste = vec![b'y'; 1100];
    let (ok, out) = under_pty_chunks(
        "child_quits_on_q",
        &[b":".to_vec(), paste, b"\x1b".to_vec(), b"q".to_vec()],
    );
    assert!(ok, "{out}");
    assert!(out.contains("CHILD-DONE"), "{out:?}");
}
