//! Issue #15, items 15–18, from the outside: `mavterm sim --listen` binds before it says it
//! serves and names the address it could not take; the sim introduces itself as the ArduCopter
//! version of the captures; `--record` writes a script that replays (its `# link` and `# size`
//! lines used when the command line gives none); Ctrl-Z suspends to a job-control shell and `fg`
//! brings the screen back.
//!
//! The terminal tests run mavterm under a pseudo-terminal made by util-linux `script` (as
//! tests/tui_pty.rs does), reading everything it writes to the tty.

mod common;

use std::io::{Read, Write};
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::{free_tcp_port, mavterm, test_path, ChildGuard};

const ENTER_ALT: &str = "\x1b[?1049h";
const LEAVE_ALT: &str = "\x1b[?1049l";

/// The version the real captures' banner names ("ArduCopter V4.7.0-dev" from "ArduCopter
/// V4.7.0-dev (2598e9d4)"), read from tests/data/expected.json.
fn captured_version() -> String {
    let text = std::fs::read_to_string(test_path("data/expected.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let mut found = None;
    let mut stack = vec![&json];
    while let Some(v) = stack.pop() {
        match v {
            serde_json::Value::String(s) if s.starts_with("ArduCopter V") => {
                found = Some(s.split(" (").next().unwrap().to_string());
            }
            serde_json::Value::Array(a) => stack.extend(a),
            serde_json::Value::Object(o) => stack.extend(o.values()),
            _ => {}
        }
    }
    found.expect("a banner in expected.json")
}

/// Wait for `child` to exit, at most `secs`.
fn wait_exit(child: &mut std::process::Child, secs: u64) -> Option<std::process::ExitStatus> {
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(secs) {
        if let Some(st) = child.try_wait().unwrap() {
            return Some(st);
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    None
}

#[test]
fn sim_listen_on_a_busy_port_names_the_address_and_fails() {
    let held = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = held.local_addr().unwrap().port();
    let spec = format!("tcp:127.0.0.1:{port}");
    let mut child = ChildGuard(
        Command::new(mavterm())
            .args(["sim", "--listen", &spec])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let status = wait_exit(&mut child.0, 10).expect("mavterm sim kept running on a busy port");
    let mut err = String::new();
    child
        .0
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    assert!(!status.success(), "{err}");
    assert!(
        err.contains(&format!("cannot listen on {spec}")),
        "the error names the address: {err}"
    );
    assert!(!err.contains("serving"), "{err}");
    drop(held);
}

#[test]
fn sim_listen_says_serving_and_the_arducopter_version() {
    let port = free_tcp_port();
    let mut child = ChildGuard(
        Command::new(mavterm())
            .args(["sim", "--listen", &format!("tcp:127.0.0.1:{port}")])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let mut stderr = std::io::BufReader::new(child.0.stderr.take().unwrap());
    let mut line = String::new();
    std::io::BufRead::read_line(&mut stderr, &mut line).unwrap();
    assert!(line.contains("serving"), "{line}");
    assert!(line.contains(&captured_version()), "{line}");
    // Said once the socket is there: it takes a connection at once.
    std::net::TcpStream::connect(("127.0.0.1", port)).expect("listening when it says so");
}

/// The sim's parameters are the 4.7 set of the captures: the system id is `MAV_SYSID`, not the
/// `SYSID_THISMAV` of ArduCopter 4.6 and before. Downloaded as a GCS would.
#[test]
fn sim_parameters_name_mav_sysid_as_the_capture() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim.parm");
    let st = Command::new(mavterm())
        .args(["--headless", "--link", "sim://", "--params-out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let names = |text: &str| -> Vec<String> {
        text.lines()
            .filter_map(|l| l.split([' ', ',', '\t']).next())
            .map(str::to_string)
            .collect()
    };
    let ours = names(&std::fs::read_to_string(&out).unwrap());
    let captured = names(&std::fs::read_to_string(test_path("data/copter-params.parm")).unwrap());
    for set in [&ours, &captured] {
        assert!(set.iter().any(|n| n == "MAV_SYSID"));
        assert!(!set.iter().any(|n| n == "SYSID_THISMAV"));
    }
}

/// `# link` and `# size` lines choose the links and the screen when the command line does not;
/// the command line wins when it does.
#[test]
fn replay_uses_the_scripts_links_and_size_unless_given() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("session.txt");
    std::fs::write(
        &script,
        "# mavterm 0.1.0 recording\n# link sim://?vehicles=2&seed=3\n# size 70x20\n\
         3 snapshot final\n3 quit\n",
    )
    .unwrap();
    let run = |extra: &[&str]| {
        let out = Command::new(mavterm())
            .args(["--headless", "--input"])
            .arg(&script)
            .args(extra)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
        assert!(
            out.status.success(),
            "{stdout}{}",
            String::from_utf8_lossy(&out.stderr)
        );
        stdout
    };
    let own = run(&[]);
    assert!(
        own.contains("=== snapshot final at 3s (70x20) ==="),
        "{own}"
    );
    let screen: Vec<&str> = own.lines().skip(1).collect();
    assert_eq!(screen.len(), 20, "{own}");
    let widest = screen.iter().map(|l| l.chars().count()).max();
    assert_eq!(widest, Some(70), "{own}");
    assert!(
        own.contains("Vehicles (2)"),
        "both vehicles of the header's link: {own}"
    );

    let given = run(&["--size", "90x25", "--link", "sim://?seed=3"]);
    assert!(given.contains("(90x25) ==="), "{given}");
    assert!(given.contains("Vehicles (1)"), "{given}");

    // A header link that does not parse is an error naming the line.
    std::fs::write(&script, "# link nonsense:x\n1 quit\n").unwrap();
    let out = Command::new(mavterm())
        .args(["--headless", "--input"])
        .arg(&script)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("line 1") && err.contains("nonsense:x"),
        "{err}"
    );
}

/// mavterm (or a shell running it) under a pseudo-terminal: everything written to the tty is
/// collected as it comes.
struct Pty {
    child: ChildGuard,
    input: std::process::ChildStdin,
    out: Arc<Mutex<Vec<u8>>>,
}

impl Pty {
    /// `cmd` run by `script` in a 100x30 pty, with a home of its own (no user config).
    fn spawn(cmd: &str, home: &Path) -> Pty {
        let mut child = ChildGuard(
            Command::new("script")
                .args([
                    "-qec",
                    &format!("stty cols 100 rows 30; {cmd}"),
                    "/dev/null",
                ])
                .env("TERM", "xterm-256color")
                .env("HOME", home)
                .env("XDG_CONFIG_HOME", home.join("config"))
                .env("XDG_DATA_HOME", home.join("data"))
                .stdin(Stdio::piped())
                .stdout(Stdio::piped())
                .stderr(Stdio::null())
                .spawn()
                .expect("util-linux `script` is needed for the pty tests"),
        );
        let input = child.0.stdin.take().unwrap();
        let mut stdout = child.0.stdout.take().unwrap();
        let out = Arc::new(Mutex::new(Vec::new()));
        let sink = Arc::clone(&out);
        std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while let Ok(n) = stdout.read(&mut buf) {
                if n == 0 {
                    break;
                }
                sink.lock().unwrap().extend_from_slice(&buf[..n]);
            }
        });
        Pty { child, input, out }
    }

    fn text(&self) -> String {
        String::from_utf8_lossy(&self.out.lock().unwrap()).into_owned()
    }

    fn len(&self) -> usize {
        self.text().len()
    }

    /// Wait until the output after byte `from` holds `needle`; its position.
    fn wait_for(&self, from: usize, needle: &str) -> usize {
        let start = Instant::now();
        loop {
            let text = self.text();
            if let Some(i) = text.get(from..).and_then(|t| t.find(needle)) {
                return from + i;
            }
            assert!(
                start.elapsed() < Duration::from_secs(30),
                "no {needle:?} after byte {from}: {:?}",
                text.get(from..).unwrap_or(&text)
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    fn send(&mut self, bytes: &[u8]) {
        self.input.write_all(bytes).unwrap();
        self.input.flush().unwrap();
    }

    fn wait_exit(&mut self) -> std::process::ExitStatus {
        wait_exit(&mut self.child.0, 30).unwrap_or_else(|| panic!("hung: {:?}", self.text()))
    }
}

/// A terminal session recorded with `--record` replays headless: the file has the header, the
/// keys (not the quit key), and ends with `snapshot final` + `quit`; the replay runs on the
/// header's link and size to the end, and its final screen is the one the operator left: the
/// overview, the Links pane focused, the vehicle listed.
#[test]
fn recorded_session_replays_to_the_same_screen() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("session.txt");
    let cmd = format!(
        "exec {} --link 'sim://?seed=1' --no-tlog --record {}",
        mavterm().display(),
        rec.display()
    );
    let mut pty = Pty::spawn(&cmd, dir.path());
    let mut at = pty.wait_for(0, ENTER_ALT);
    at = pty.wait_for(at, "1:1"); // the vehicle is there: keys are taken from now on
    pty.send(b"2");
    at = pty.wait_for(at, "Parameters");
    pty.send(b"1");
    at = pty.wait_for(at, "Vehicles");
    pty.send(b"\t");
    at = pty.wait_for(at, "*Links");
    std::thread::sleep(Duration::from_millis(300));
    pty.send(b"q");
    let st = pty.wait_exit();
    assert!(st.success(), "{:?}", pty.text());
    let tail = &pty.text()[at..];
    assert!(tail.contains(LEAVE_ALT), "{tail:?}");

    let text = std::fs::read_to_string(&rec).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert!(
        lines[0].starts_with("# mavterm ") && lines[0].contains("recording"),
        "{text}"
    );
    assert_eq!(lines[1], "# link sim://?seed=1", "{text}");
    assert_eq!(lines[2], "# size 100x30", "{text}");
    let events: Vec<&str> = lines[3..]
        .iter()
        .map(|l| l.split_once(' ').unwrap().1)
        .collect();
    assert_eq!(
        events,
        ["key 2", "key 1", "key tab", "snapshot final", "quit"],
        "{text}"
    );

    let out = Command::new(mavterm())
        .args(["--headless", "--input"])
        .arg(&rec)
        .env("HOME", dir.path())
        .env("XDG_CONFIG_HOME", dir.path().join("config"))
        .output()
        .unwrap();
    let screen = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{screen}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(screen.contains("(100x30) ==="), "{screen}");
    for want in [
        "Vehicles (1)",
        "*Links",
        "1:1",
        "QUADROTOR",
        "sim://?seed=1",
    ] {
        assert!(screen.contains(want), "{want} missing: {screen}");
    }
    assert!(
        !screen.contains("*Vehicles") && !screen.contains("Parameters"),
        "{screen}"
    );
}

/// The pid of the process whose command line holds `marker`.
fn pid_of(marker: &str) -> u32 {
    let start = Instant::now();
    loop {
        for e in std::fs::read_dir("/proc").unwrap().flatten() {
            let Ok(pid) = e.file_name().to_string_lossy().parse::<u32>() else {
                continue;
            };
            let cmdline = std::fs::read(e.path().join("cmdline")).unwrap_or_default();
            let cmdline = String::from_utf8_lossy(&cmdline);
            if cmdline.starts_with(&*mavterm().to_string_lossy()) && cmdline.contains(marker) {
                return pid;
            }
        }
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "no process with {marker}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// The state letter of `pid` (`T` stopped, `S` sleeping, `R` running).
fn proc_state(pid: u32) -> String {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap();
    let state = stat.rsplit_once(") ").unwrap().1.split(' ').next().unwrap();
    state.to_string()
}

/// mavterm run by a job-control shell (interactive bash) in a pty; `stop` suspends it (Ctrl-Z
/// typed, or a SIGTSTP from outside). It must give the terminal back (leave the alternate screen)
/// and stop (state T); the shell's `fg` continues it, and it takes the screen again and draws it
/// all; `q` then quits with status 0.
fn suspend_and_fg(stop: impl FnOnce(&mut Pty, u32)) {
    let dir = tempfile::tempdir().unwrap();
    let job = dir.path().join("job.sh");
    let marker = dir.path().join("suspend.log");
    std::fs::write(
        &job,
        format!(
            "{} --link 'sim://?seed=1' --no-tlog --log {}\necho STOPPED; jobs -p\nread _\nfg\necho FG-STATUS=$?\n",
            mavterm().display(),
            marker.display()
        ),
    )
    .unwrap();
    let cmd = format!("exec bash --norc --noprofile -i {}", job.display());
    let mut pty = Pty::spawn(&cmd, dir.path());
    let mut at = pty.wait_for(0, ENTER_ALT);
    at = pty.wait_for(at, "1:1");
    let pid = pid_of(&marker.to_string_lossy());
    stop(&mut pty, pid);
    let stopped = pty.wait_for(at, "STOPPED");
    let left = pty.text()[at..stopped].rfind(LEAVE_ALT);
    assert!(
        left.is_some(),
        "the screen was given back first: {:?}",
        &pty.text()[at..]
    );
    // The shell's job is this mavterm, and it is stopped.
    let pid_line = pty.wait_for(stopped, "\n");
    let pid_end = pty.wait_for(pid_line + 1, "\n");
    let job_pid = pty.text()[pid_line + 1..pid_end].trim().to_string();
    assert_eq!(job_pid, pid.to_string(), "{:?}", &pty.text()[stopped..]);
    assert_eq!(proc_state(pid), "T");

    let before_fg = pty.len();
    pty.send(b"\n"); // `read` returns, the shell runs `fg`
    let back = pty.wait_for(before_fg, ENTER_ALT);
    // Everything drawn again, not only what changed: the pane titles come back.
    pty.wait_for(back, "Vehicles");
    pty.wait_for(back, "Messages");
    assert_ne!(proc_state(pid), "T");
    std::thread::sleep(Duration::from_millis(300));
    let before_q = pty.len();
    pty.send(b"q");
    pty.wait_for(before_q, "FG-STATUS=0");
    pty.wait_exit();
}

#[test]
fn ctrl_z_suspends_and_fg_restores_the_screen() {
    suspend_and_fg(|pty, _| pty.send(&[0x1a]));
}

/// `kill -TSTP` from outside (raw mode means the terminal never sends it) suspends the same way.
#[test]
fn sigtstp_from_outside_suspends_the_same_way() {
    suspend_and_fg(|_, pid| {
        let st = Command::new("kill")
            .args(["-TSTP", &pid.to_string()])
            .status()
            .unwrap();
        assert!(st.success());
    });
}
