//! Headless replay against the simulated vehicle on the virtual clock.

mod common;

use mavterm::app::{AppConfig, Pane};
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::headless::replay::{run_script, run_script_on_specs, ReplayError, ReplayOptions};
use mavterm::headless::script::Script;
use mavterm::link::LinkSpec;

fn runner(query: &str) -> VirtualRunner {
    let spec: LinkSpec = format!("sim://?{query}").parse().unwrap();
    VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap()
}

const SCRIPT: &str = "\
# focus the links pane, expand the link, look around
1.0 snapshot start
2.5 key tab
2.6 key enter
5 snapshot links-expanded
5.5 key ?
6 snapshot help
6.5 key esc
8 text \"n\"
10 snapshot end
12 quit
";

fn replay(query: &str, size: (u16, u16)) -> (String, mavterm::headless::replay::ReplayOutcome) {
    let script = Script::parse(SCRIPT).unwrap();
    let mut r = runner(query);
    let mut out = Vec::new();
    let opts = ReplayOptions {
        size,
        ..ReplayOptions::default()
    };
    let outcome = run_script(&script, &mut r, &opts, &mut out).unwrap();
    assert_eq!(r.app.ui.focus, Pane::Links);
    (String::from_utf8(out).unwrap(), outcome)
}

#[test]
fn replay_is_byte_identical_and_runs_to_the_end() {
    let (a, outcome) = replay("seed=7&loss=0.05", (120, 40));
    let (b, _) = replay("seed=7&loss=0.05", (120, 40));
    assert_eq!(a, b, "same input must give the same screens");
    assert!(outcome.completed);
    assert_eq!(outcome.steps_run, 10);
    assert_eq!(
        outcome.snapshots,
        ["start", "links-expanded", "help", "end"]
    );
    assert_eq!(outcome.end, 12_000_000);
    // Four headers, each followed by 40 screen lines.
    assert_eq!(a.matches("=== snapshot ").count(), 4);
    assert_eq!(a.lines().count(), 4 * 41);
    assert!(a.contains("=== snapshot help at 6s (120x40) ==="), "{a}");
    let help = a.split("=== snapshot").nth(3).unwrap();
    assert!(help.contains("show/hide key help"), "{help}");
    let end = a.split("=== snapshot").nth(4).unwrap();
    assert!(
        !end.contains("show/hide key help"),
        "esc closed help: {end}"
    );
    assert!(end.contains("*Links"), "{end}");
    assert!(
        a.lines().all(|l| !l.ends_with(' ')),
        "trailing spaces trimmed"
    );
    // A different seed gives a different run (the screens really depend on the input).
    let (c, _) = replay("seed=8&loss=0.05", (120, 40));
    assert_ne!(a, c);
}

#[test]
fn snapshots_go_to_files_at_the_requested_size() {
    let dir = tempfile::tempdir().unwrap();
    let script = Script::parse("1 snapshot one\n2 snapshot two\n").unwrap();
    let mut r = runner("seed=1");
    let opts = ReplayOptions {
        size: (80, 24),
        screens_dir: Some(dir.path().join("screens")),
        ..ReplayOptions::default()
    };
    let mut out = Vec::new();
    let outcome = run_script(&script, &mut r, &opts, &mut out).unwrap();
    assert!(outcome.completed);
    assert!(out.is_empty());
    let one = std::fs::read_to_string(dir.path().join("screens/one.txt")).unwrap();
    assert_eq!(one.lines().count(), 24);
    assert!(one.lines().all(|l| l.chars().count() <= 80));
    assert!(one.contains("Vehicles"), "{one}");
    assert!(dir.path().join("screens/two.txt").exists());
}

#[test]
fn quitting_early_is_not_a_complete_run() {
    let script = Script::parse("1 key q\n2 snapshot never\n").unwrap();
    let mut r = runner("seed=1");
    let outcome = run_script(&script, &mut r, &ReplayOptions::default(), &mut Vec::new()).unwrap();
    assert!(!outcome.completed);
    assert_eq!(outcome.steps_run, 1);
    assert!(outcome.snapshots.is_empty());
    // A quit key as the last step is the script running to its end.
    let script = Script::parse("1 snapshot s\n2 key q\n").unwrap();
    let mut r = runner("seed=1");
    let outcome = run_script(&script, &mut r, &ReplayOptions::default(), &mut Vec::new()).unwrap();
    assert!(outcome.completed);
}

#[test]
fn replay_on_specs_builds_the_runner_and_refuses_real_links() {
    let script = Script::parse("1 key tab\n2 snapshot s\n").unwrap();
    let specs: Vec<LinkSpec> = vec!["sim://?seed=2".parse().unwrap()];
    let mut out = Vec::new();
    let (outcome, app) = run_script_on_specs(
        &script,
        &specs,
        AppConfig::default(),
        &ReplayOptions::default(),
        &mut out,
    )
    .unwrap();
    assert!(outcome.completed);
    assert_eq!(app.ui.focus, Pane::Links);
    assert_eq!(app.vehicles.len(), 1);
    let udp: Vec<LinkSpec> = vec!["udpin:0.0.0.0:14550".parse().unwrap()];
    let e = run_script_on_specs(
        &script,
        &udp,
        AppConfig::default(),
        &ReplayOptions::default(),
        &mut out,
    )
    .unwrap_err();
    assert!(matches!(e, ReplayError::Runner(_)), "{e}");
}

/// The last line (the status bar) of each snapshot the binary prints, run headless at 80x24
/// with `script` on `link`, `args` added and `TZ` set to `tz` (a POSIX TZ string, which needs
/// no time-zone database).
fn status_lines(link: &str, args: &[&str], tz: &str, script: &str) -> Vec<String> {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("script.txt");
    std::fs::write(&input, script).unwrap();
    let out = std::process::Command::new(common::mavterm())
        .args(["--link", link, "--headless", "--size", "80x24", "--input"])
        .arg(&input)
        .args(args)
        .env("TZ", tz)
        .env("XDG_CONFIG_HOME", dir.path()) // no user config file
        .output()
        .unwrap();
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
        .split("=== snapshot ")
        .skip(1)
        .map(|s| s.trim_end().lines().last().unwrap_or("").to_string())
        .collect()
}

#[test]
fn the_clock_shows_local_time_with_its_offset_unless_utc() {
    // The virtual clock starts at 2026-01-01 12:00:00 UTC.
    let at_1s = "1 snapshot s\n2 quit\n";
    let ist = status_lines("sim://?seed=1", &[], "IST-5:30", at_1s);
    assert!(ist[0].starts_with("17:30:01 +05:30  "), "{ist:?}");
    let utc = status_lines("sim://?seed=1", &["--utc"], "IST-5:30", at_1s);
    assert!(utc[0].starts_with("12:00:01 UTC  "), "{utc:?}");
    // The config file's `utc = true` does the same.
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("config.toml");
    std::fs::write(&config, "utc = true\n").unwrap();
    let args = ["--config", config.to_str().unwrap()];
    let from_file = status_lines("sim://?seed=1", &args, "IST-5:30", at_1s);
    assert!(from_file[0].starts_with("12:00:01 UTC  "), "{from_file:?}");
    // West of Greenwich; and the offset of the day shown: January is winter time in New York.
    let ny = status_lines("sim://?seed=1", &[], "EST5EDT,M3.2.0,M11.1.0", at_1s);
    assert!(ny[0].starts_with("07:00:01 -05:00  "), "{ny:?}");
}

#[test]
fn a_replay_shows_the_recordings_own_time_in_the_zone_of_its_day() {
    // The log's first record, from its tlog timestamp (8 bytes big-endian µs since 1970).
    let path = common::test_path("data/copter-flight.vehicle.tlog");
    let head = std::fs::read(&path).unwrap();
    let t0 = u64::from_be_bytes(head[..8].try_into().unwrap());
    let link = format!("tlog:{}", path.display());
    let when = |off_s: i64, offset_h: i64| {
        let t = chrono::DateTime::from_timestamp_micros(t0 as i64).unwrap()
            + chrono::Duration::seconds(off_s + offset_h * 3600);
        t.format("%H:%M:%S").to_string()
    };
    // One second in, then 10 s further on (`]` seeks): the recording's time moves with the log.
    let script = "1 snapshot a\n1.5 key ]\n2 snapshot b\n3 quit\n";
    let utc = status_lines(&link, &["--utc"], "UTC0", script);
    assert!(
        utc[0].starts_with(&format!("{} UTC  ", when(1, 0))),
        "{utc:?}"
    );
    assert!(utc[0].contains("replay 00:01/"), "{utc:?}");
    assert!(
        utc[1].starts_with(&format!("{} UTC  ", when(12, 0))),
        "{utc:?}"
    );
    assert!(utc[1].contains("replay 00:12/"), "{utc:?}");
    // Sydney: the log (late November) is in daylight saving time, +11:00.
    let syd = status_lines(&link, &[], "AEST-10AEDT,M10.1.0,M4.1.0/3", script);
    assert!(
        syd[0].starts_with(&format!("{} +11:00  ", when(1, 11))),
        "{syd:?}"
    );
}
