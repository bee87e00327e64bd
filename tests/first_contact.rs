//! A first contact with the command line (issue #15): values that cannot work are refused with
//! the flag and the range, the report says which mavterm made it and when, a run where no link
//! ever came up fails and says why, a closed stdout ends quietly, errors are printed once, and
//! the keymap is checked where it matters. Every test runs the built binary.

mod common;

use std::io::Read;
use std::path::PathBuf;
use std::process::{Command, Output, Stdio};

use common::{free_tcp_port, mavterm, test_path};

/// A home of its own: no config file or keymap of the machine's is read.
struct Home {
    dir: tempfile::TempDir,
}

impl Home {
    fn new() -> Home {
        Home {
            dir: tempfile::tempdir().unwrap(),
        }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    /// Write `text` to `name` in the home.
    fn file(&self, name: &str, text: &str) -> PathBuf {
        let p = self.path(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(&p, text).unwrap();
        p
    }

    /// mavterm's config directory here (`$XDG_CONFIG_HOME/mavterm`).
    fn config_dir(&self) -> PathBuf {
        self.path("config/mavterm")
    }

    fn command(&self, args: &[&str]) -> Command {
        let mut c = Command::new(mavterm());
        c.args(args)
            .env("HOME", self.dir.path())
            .env("XDG_CONFIG_HOME", self.path("config"))
            .env("XDG_DATA_HOME", self.path("data"))
            .stdin(Stdio::null());
        c
    }

    fn run(&self, args: &[&str]) -> Output {
        self.command(args).output().unwrap()
    }
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn report(o: &Output) -> serde_json::Value {
    let out = stdout(o);
    serde_json::from_str(out.trim()).unwrap_or_else(|e| panic!("{e}: {out:?}"))
}

#[test]
fn values_that_cannot_work_are_refused_with_the_flag_and_the_range() {
    let home = Home::new();
    for (args, says) in [
        (
            &["--fps", "0"][..],
            "invalid value '0' for '--fps <FPS>': 0 is not in 1..=120",
        ),
        (
            &["--lost-timeout", "0"],
            "invalid value '0' for '--lost-timeout <SECONDS>': expected seconds from 0.1 to 3600",
        ),
        (&["--sysid", "0"], "'--sysid <SYSID>': 0 is not in 1..=255"),
        (
            &["--size", "70000x10"],
            "invalid value '70000x10' for '--size <WxH>': width 70000 is over 1000",
        ),
        (&["--size", "80x1001"], "height 1001 is over 1000"),
        (
            &["sim", "--listen", "tcp:127.0.0.1:5760", "--vehicles", "300"],
            "'--vehicles <VEHICLES>': 300 is not in 1..=250",
        ),
    ] {
        let o = home.run(args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(!err.contains("not a number\n"), "{args:?}: {err}");
        assert!(stdout(&o).is_empty());
    }
}

#[test]
fn config_file_values_that_cannot_work_are_refused_where_they_are() {
    let home = Home::new();
    let cfg = home.file("c.toml", "lost_timeout = 0\nsysid = 0\n");
    let o = home.run(&[
        "--config",
        cfg.to_str().unwrap(),
        "--headless",
        "--report",
        "json",
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    let c = cfg.display();
    assert!(
        err.contains(&format!(
            "{c}:1:16: lost_timeout: expected seconds from 0.1 to 3600, found 0"
        )),
        "{err}"
    );
    assert!(
        err.contains(&format!(
            "{c}:2:9: sysid: expected a system id from 1 to 255, found 0"
        )),
        "{err}"
    );
    assert_eq!(err.matches("lost_timeout").count(), 1, "once: {err}");
    assert!(stdout(&o).is_empty(), "no report");
}

#[test]
fn a_replay_time_over_a_day_is_refused_with_its_line() {
    let home = Home::new();
    let script = home.file("s.txt", "0.5 key tab\n90000 quit\n");
    let o = home.run(&["--headless", "--input", script.to_str().unwrap()]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("script line 2: time 90000 s is over a day (86400 s)"),
        "{err}"
    );
}

#[test]
fn the_report_says_which_mavterm_made_it_when_and_for_how_long() {
    let home = Home::new();
    // A replay: the run starts at the log's first record (8 bytes, big-endian µs since 1970).
    let log = test_path("data/copter-flight.vehicle.tlog");
    let first = std::fs::read(&log).unwrap();
    let t0 = u64::from_be_bytes(first[..8].try_into().unwrap());
    let spec = format!("tlog:{}", log.display());
    let o = home.run(&[
        "--link",
        &spec,
        "--headless",
        "--report",
        "json",
        "--duration",
        "3",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = report(&o);
    assert_eq!(r["version"], env!("CARGO_PKG_VERSION"));
    let start = chrono::DateTime::parse_from_rfc3339(r["start"].as_str().unwrap()).unwrap();
    assert_eq!(start.timestamp_micros(), t0 as i64, "{}", r["start"]);
    assert_eq!(r["duration_s"], 3.0);
    // The simulated vehicle, for the default 10 s.
    let o = home.run(&["--headless", "--report", "json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = report(&o);
    assert_eq!(r["duration_s"], 10.0);
    assert!(chrono::DateTime::parse_from_rfc3339(r["start"].as_str().unwrap()).is_ok());
    assert_eq!(r["links"][0]["state"], "up");
}

#[test]
fn a_report_where_every_link_stayed_down_fails_and_says_why() {
    let home = Home::new();
    let port = free_tcp_port(); // released: nothing listens there
    let spec = format!("tcp:127.0.0.1:{port}");
    let o = home.run(&[
        "--link",
        &spec,
        "--headless",
        "--report",
        "json",
        "--duration",
        "1",
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    // The report is printed all the same, with the reason in it.
    let r = report(&o);
    assert_eq!(r["links"][0]["spec"], spec.as_str());
    assert_eq!(r["links"][0]["state"], "down", "{r}");
    let reason = r["links"][0]["reason"].as_str().unwrap().to_string();
    assert!(reason.to_lowercase().contains("refused"), "{reason}");
    assert_eq!(
        err.trim(),
        format!("Error: all links stayed down: {spec} ({reason})"),
    );
    // A parameter download says so too.
    let out = home.path("p.parm");
    let o = home.run(&[
        "--link",
        &spec,
        "--headless",
        "--params-out",
        out.to_str().unwrap(),
        "--duration",
        "1",
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains(&format!(
            "Error: no autopilot heard: all links stayed down: {spec} ({reason})"
        )),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn a_closed_stdout_ends_the_run_quietly() {
    let home = Home::new();
    // Screens to stdout, far more than a pipe holds: mavterm writes on after the reader left.
    let mut script = String::new();
    for i in 0..300 {
        script.push_str(&format!("{}.1 snapshot s{i}\n", i / 10));
    }
    let script = home.file("s.txt", &script);
    let mut child = home
        .command(&[
            "--headless",
            "--input",
            script.to_str().unwrap(),
            "--size",
            "200x60",
            "--report",
            "json",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut out = child.stdout.take().unwrap();
    let mut first = [0u8; 64];
    out.read_exact(&mut first).unwrap();
    assert!(
        first.starts_with(b"=== snapshot s0 at 0.1s"),
        "{:?}",
        String::from_utf8_lossy(&first)
    );
    drop(out); // as `| head -1` does
    let o = child.wait_with_output().unwrap();
    let err = stderr(&o);
    assert!(o.status.success(), "{:?}: {err}", o.status);
    assert!(err.is_empty(), "nothing to say: {err}");
}

#[test]
fn errors_are_printed_once() {
    let home = Home::new();
    let script = home.file("s.txt", "0.5 key tab\n");
    let s = script.to_str().unwrap();
    let missing = home.path("nope.toml");
    let m = missing.to_str().unwrap();
    for (args, reason) in [
        (
            vec!["--headless", "--input", s, "--keymap", m],
            "No such file or directory",
        ),
        (
            vec!["--headless", "--input", m],
            "No such file or directory",
        ),
        (
            vec!["--headless", "--report", "json", "--config", m],
            "No such file or directory",
        ),
        (
            vec!["--link", "tcp:nowhere", "--headless", "--report", "json"],
            "tcp:nowhere",
        ),
        (
            vec!["--out", "sim://", "--headless", "--report", "json"],
            "sim://",
        ),
    ] {
        let o = home.run(&args);
        let err = stderr(&o);
        assert!(!o.status.success(), "{args:?}");
        assert_eq!(err.matches(reason).count(), 1, "{args:?}: {err}");
        assert!(err.contains("nope.toml") || !args.contains(&m), "{err}");
    }
}

#[test]
fn a_broken_user_keymap_is_a_warning_where_no_key_is_read() {
    let home = Home::new();
    let keymap = home.file("config/mavterm/keymap.toml", "[normal]\nquit = [\"q\"\n");
    assert_eq!(keymap.parent().unwrap(), home.config_dir());
    let place = format!("keymap {}:2:", keymap.display());
    // A headless report reads no keys: the run goes on, with a warning.
    let o = home.run(&["--headless", "--report", "json", "--duration", "1"]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.starts_with(&format!("warning: {place}")), "{err}");
    assert_eq!(report(&o)["duration_s"], 1.0);
    // A replay of keys needs them: an error, and nothing runs.
    let script = home.file("s.txt", "0.5 key tab\n");
    let o = home.run(&["--headless", "--input", script.to_str().unwrap()]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.starts_with(&format!("Error: {place}")), "{err}");
    assert!(!err.contains("warning"), "{err}");
}

fn keymap_error(home: &Home, text: &str) -> (PathBuf, String) {
    let keymap = home.file("k.toml", text);
    let script = home.file("s.txt", "0.5 key tab\n");
    let o = home.run(&[
        "--headless",
        "--input",
        script.to_str().unwrap(),
        "--keymap",
        keymap.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    (keymap, stderr(&o))
}

#[test]
fn keymap_clashes_and_unknown_names_are_errors_that_teach() {
    let home = Home::new();
    // The default binds `n` to next_vehicle in [normal].
    let (path, err) = keymap_error(&home, "[normal]\nquit = [\"n\"]\n");
    assert!(
        err.starts_with(&format!(
            "Error: keymap {}:2:9: key `n` is bound to `quit` here and to `next_vehicle` by the \
             default keymap in [normal]: on every screen both would apply",
            path.display()
        )),
        "{err}"
    );
    assert_eq!(err.matches("key `n`").count(), 1, "{err}");
    // Unknown names: the valid ones are listed.
    let (_, err) = keymap_error(&home, "[normal]\ndive = [\"x\"]\nquit = [\"hyper-q\"]\n");
    assert!(
        err.contains(":2:1: unknown action `dive` in [normal]"),
        "{err}"
    );
    assert!(err.contains(":3:9: unknown key `hyper-q`"), "{err}");
    assert!(
        err.contains("\nthe actions of [normal] and [normal.SCREEN]: arm, bottom,"),
        "{err}"
    );
    assert!(
        err.contains("\nkey names: a character (a, A, ?, 1), space, enter,"),
        "{err}"
    );
}

/// The help teaches: examples, the defaults, the files, NO_COLOR; `sim --help` lists every
/// option `sim://` takes.
#[test]
fn help_shows_examples_files_and_the_sim_options() {
    let home = Home::new();
    let o = home.run(&["--help"]);
    assert!(o.status.success());
    let help = stdout(&o);
    for needle in [
        "mavterm --link /dev/ttyUSB0,57600",
        "mavterm --link tcp:127.0.0.1:5760",
        "mavterm --link udpin:0.0.0.0:14550",
        "mavterm --link udpin:0.0.0.0:14550 --headless --duration 10 --report json",
        "mavterm --link tlog:flight.tlog",
        "[default: 10; with --params-out, 300;",
        "NO_COLOR",
    ] {
        assert!(help.contains(needle), "{needle}: {help}");
    }
    // The files, where they are for this user.
    let dir = home.config_dir();
    for name in ["config.toml", "keymap.toml", "param-meta.xml"] {
        let p = dir.join(name);
        assert!(help.contains(&p.display().to_string()), "{name}: {help}");
    }
    let o = home.run(&["sim", "--help"]);
    let help = stdout(&o);
    for key in [
        "vehicles",
        "sysid",
        "loss",
        "dup",
        "reorder",
        "corrupt",
        "latency_ms",
        "seed",
        "params",
        "baud",
        "state",
        "impair_in",
        "drop_cmd",
        "ftp",
        "mission_boot_ms",
        "camera",
        "camera_drop",
    ] {
        assert!(help.contains(&format!("\n  {key}=")), "{key}: {help}");
    }
    // An unknown option names the same set.
    let o = home.run(&["--link", "sim://?wind=3", "--headless", "--report", "json"]);
    assert!(
        stderr(&o).contains("known options: vehicles, sysid, loss"),
        "{}",
        stderr(&o)
    );
}
