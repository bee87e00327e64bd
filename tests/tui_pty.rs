//! The real terminal path under a pseudo-terminal (util-linux `script`): run_terminal enters the
//! alternate screen and raw mode, and leaves them on quit, on panic, and on SIGHUP, SIGQUIT,
//! SIGTERM and SIGINT (which end the session normally).
//!
//! The parent test re-runs this test binary's ignored `child_*` tests inside `script`, so the
//! child's stdout is a real tty, then inspects everything the child wrote to it.

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
}

impl SignalClock {
    fn new(signal: &'static str) -> Self {
        SignalClock {
            clock: RealClock::new(),
            signal,
            sent: Arc::new(Once::new()),
        }
    }
}

impl Clock for SignalClock {
    fn now(&self) -> Micros {
        let signal = self.signal;
        self.sent.call_once(|| {
            std::thread::spawn(move || {
                std::thread::sleep(Duration::from_millis(300));
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

/// Run `child` under `script`, typing `input` until it exits; returns (success, output).
fn under_pty(child: &str, input: &[u8]) -> (bool, String) {
    let exe = std::env::current_exe().unwrap();
    // The pty has no size until told; 0x0 would draw nothing.
    let cmd = format!(
        "stty cols 100 rows 30; {} --ignored --exact --nocapture {child}",
        exe.display()
    );
    let mut p = Command::new("script")
        .args(["-qec", &cmd, "/dev/null"])
        .env("TERM", "xterm-256color")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("util-linux `script` is needed for the pty tests");
    let mut stdin = p.stdin.take().unwrap();
    // Type `input` every half second until the child exits: a slow machine may not be in raw
    // mode yet the first time.
    let start = Instant::now();
    let mut next_type = start + Duration::from_millis(500);
    while p.try_wait().unwrap().is_none() {
        assert!(start.elapsed() < Duration::from_secs(30), "{child} hung");
        if !input.is_empty() && Instant::now() >= next_type {
            let _ = stdin.write_all(input).and_then(|()| stdin.flush());
            next_type += Duration::from_millis(500);
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    drop(stdin);
    let out = p.wait_with_output().unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    (out.status.success(), text)
}

#[test]
fn quit_key_restores_the_terminal() {
    let (ok, out) = under_pty("child_quits_on_q", b"q");
    assert!(ok, "{out}");
    let enter = out
        .find(ENTER_ALT)
        .unwrap_or_else(|| panic!("never entered: {out:?}"));
    let leave = out
        .rfind(LEAVE_ALT)
        .unwrap_or_else(|| panic!("never left: {out:?}"));
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
    let enter = out
        .find(ENTER_ALT)
        .unwrap_or_else(|| panic!("never entered: {out:?}"));
    let leave = out
        .rfind(LEAVE_ALT)
        .unwrap_or_else(|| panic!("never left: {out:?}"));
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

/// Run `child` under `script`, writing `chunks` 300 ms apart (over again until it exits, a slow
/// machine may not be in raw mode the first time); returns (success, output).
fn under_pty_chunks(child: &str, chunks: &[Vec<u8>]) -> (bool, String) {
    let exe = std::env::current_exe().unwrap();
    let cmd = format!(
        "stty cols 100 rows 30; {} --ignored --exact --nocapture {child}",
        exe.display()
    );
    let mut p = Command::new("script")
        .args(["-qec", &cmd, "/dev/null"])
        .env("TERM", "xterm-256color")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("util-linux `script` is needed for the pty tests");
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
    drop(stdin);
    let out = p.wait_with_output().unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    (out.status.success(), text)
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
