//! The config file (`~/.config/mavterm/config.toml` or `--config FILE`): the shipped example is the
//! defaults, every problem is reported with its line and column, the values reach the core (the
//! take-off altitude asked by `:takeoff` and `T`), and flags given explicitly beat the file.

mod common;

use std::path::Path;

use clap::Parser;
use mavterm::app::AppConfig;
use mavterm::cli::Cli;
use mavterm::config::{self, ConfigError, FileConfig};
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::LinkSpec;
use mavterm::proto::rates::StreamRates;
use mavterm::sim::Sim;

const SECOND: u64 = 1_000_000;

fn example_path() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/config.example.toml")
}

fn cli(args: &[&str]) -> Cli {
    Cli::try_parse_from(std::iter::once("mavterm").chain(args.iter().copied())).unwrap()
}

/// A config file in a temporary directory.
fn file_with(text: &str) -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("config.toml");
    std::fs::write(&path, text).unwrap();
    (dir, path)
}

fn assert_same(a: &AppConfig, b: &AppConfig) {
    assert_eq!(a.sysid, b.sysid);
    assert_eq!(a.compid, b.compid);
    assert_eq!(a.lost_timeout, b.lost_timeout);
    assert_eq!(a.takeoff_alt, b.takeoff_alt);
    assert_eq!(a.map, b.map);
    assert_eq!(a.streams, b.streams);
}

#[test]
fn the_example_loads_and_is_the_defaults() {
    let path = example_path();
    let c = cli(&["--config", path.to_str().unwrap()]);
    let file = config::load_user(c.config.as_deref()).unwrap();
    assert_same(&c.app_config(&file), &AppConfig::default());
    assert_eq!(
        c.links(&file),
        [LinkSpec::Sim {
            query: String::new()
        }]
    );
    // And it is the copy built into the library.
    assert_eq!(std::fs::read_to_string(&path).unwrap(), config::EXAMPLE);
}

#[test]
fn the_examples_commented_message_set_is_the_default_set() {
    // Uncomment `#[streams.messages]` and the `#NAME = HZ` lines under it.
    let text: String = config::EXAMPLE
        .lines()
        .map(|l| match l.strip_prefix('#') {
            Some(rest) if rest.starts_with(|c: char| c == '[' || c.is_ascii_uppercase()) => rest,
            _ => l,
        })
        .collect::<Vec<_>>()
        .join("\n");
    assert!(
        text.contains("\n[streams.messages]\nSYS_STATUS = 1\n"),
        "{text}"
    );
    let file = config::load(Path::new("example"), &text).unwrap();
    let mut rates = StreamRates::default();
    file.apply_streams(&mut rates);
    let default = StreamRates::default();
    assert_eq!(rates.groups, default.groups);
    assert_eq!(rates.messages, default.messages);
    // Given, the set is asked of ArduPilot too.
    assert_eq!(rates.ardupilot_messages, default.messages);
}

#[test]
fn every_problem_is_reported_with_its_line_and_column() {
    let text = r#"sysid = 0
compid = 190
rate = 4
lost_timeout = "5"
takeoff_alt = -1
links = ["udpin:0.0.0.0:14550", "tcp:nowhere", 7]

[streams]
position = 300
extra9 = 1

[streams.messages]
ATTITUDE = 4
NO_SUCH_MESSAGE = 1
30 = 2
GLOBAL_POSITION_INT = nan
"#;
    let err = config::load(Path::new("config.toml"), text).unwrap_err();
    let ConfigError::Invalid(invalid) = &err else {
        panic!("{err:?}")
    };
    let at: Vec<(usize, usize)> = invalid.problems.iter().map(|p| (p.line, p.col)).collect();
    assert_eq!(
        at,
        [
            (1, 9),
            (3, 1),
            (4, 16),
            (5, 15),
            (6, 33),
            (6, 48),
            (9, 12),
            (10, 1),
            (14, 1),
            (15, 1),
            (16, 23)
        ],
        "{err}"
    );
    let lines: Vec<String> = err.to_string().lines().map(String::from).collect();
    assert_eq!(lines.len(), 11, "{err}");
    let want_starts = [
        "config.toml:1:9: sysid: expected a system id from 1 to 255, found 0",
        "config.toml:3:1: unknown key \"rate\" (the keys are sysid, compid, lost_timeout, \
         takeoff_alt, nudge_deadman, links, signing_key, signing_allow_unsigned_heartbeat, utc, \
         log_rate, adsb_timeout, adsb_warn_distance, adsb_warn_height, [streams])",
        "config.toml:4:16: lost_timeout: expected seconds from 0.1 to 3600, found \"5\"",
        "config.toml:5:15: takeoff_alt: expected metres above home, more than 0 and at most \
         10000, found -1",
        "config.toml:6:33: links: link spec `tcp:nowhere`: missing `:PORT`",
        "config.toml:6:48: links: expected a link spec in quotes, found 7",
        "config.toml:9:12: streams.position: expected a rate in Hz from 0 to 50, found 300",
        "config.toml:10:1: unknown key \"streams.extra9\" (the stream groups are raw_sensors, \
         extended_status, rc_channels, position, extra1, extra2, extra3",
        "config.toml:14:1: streams.messages: unknown message \"NO_SUCH_MESSAGE\"",
        "config.toml:15:1: streams.messages: \"30\" is message 30, already set as \"ATTITUDE\"",
        "config.toml:16:23: streams.messages.GLOBAL_POSITION_INT: expected a rate in Hz from 0 \
         to 50, found nan",
    ];
    for (line, want) in lines.iter().zip(want_starts) {
        assert!(
            line.starts_with(want),
            "\n{line}\nshould start with\n{want}"
        );
    }
}

#[test]
fn toml_syntax_errors_are_located() {
    let err = config::load(Path::new("c.toml"), "sysid = 255\ntakeoff_alt = 10 m\n").unwrap_err();
    assert!(err.to_string().starts_with("c.toml:2:"), "{err}");
    let err = config::load(Path::new("c.toml"), "sysid = 255\n\nsysid = 1\n").unwrap_err();
    assert!(err.to_string().starts_with("c.toml:3:1: "), "{err}");
}

#[test]
fn a_missing_config_file_given_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("nope.toml");
    let err = config::load_user(Some(&path)).unwrap_err();
    assert!(matches!(err, ConfigError::Io { .. }), "{err:?}");
    assert!(err.to_string().contains("nope.toml"), "{err}");
}

#[test]
fn an_empty_file_changes_nothing() {
    let (_dir, path) = file_with("# nothing set\n");
    let c = cli(&["--config", path.to_str().unwrap()]);
    let file = config::load_user(c.config.as_deref()).unwrap();
    assert_eq!(file, FileConfig::default());
    assert_same(&c.app_config(&file), &AppConfig::default());
}

#[test]
fn values_reach_the_core() {
    let (_dir, path) = file_with(
        "sysid = 42\ncompid = 191\nlost_timeout = 2.5\ntakeoff_alt = 15\n\
         links = [\"udpin:0.0.0.0:14550\", \"tcp:127.0.0.1:5760\"]\n\
         [streams]\nposition = 5\nextra3 = 0\n[streams.messages]\nATTITUDE = 8\n",
    );
    let c = cli(&["--config", path.to_str().unwrap()]);
    let file = config::load_user(c.config.as_deref()).unwrap();
    let cfg = c.app_config(&file);
    assert_eq!((cfg.sysid, cfg.compid), (42, 191));
    assert_eq!(cfg.lost_timeout, 2_500_000);
    assert_eq!(cfg.takeoff_alt, 15.0);
    assert_eq!(cfg.streams.groups[&6], 5.0);
    assert_eq!(cfg.streams.groups[&12], 0.0);
    assert_eq!(
        cfg.streams.groups[&10], 10.0,
        "a group not named keeps its rate"
    );
    let attitude: std::collections::BTreeMap<u32, f32> = [(30, 8.0)].into_iter().collect();
    assert_eq!(cfg.streams.messages, attitude);
    assert_eq!(cfg.streams.ardupilot_messages, attitude);
    let links: Vec<String> = c.links(&file).iter().map(|l| l.to_string()).collect();
    assert_eq!(links, ["udpin:0.0.0.0:14550", "tcp:127.0.0.1:5760"]);
}

fn sim(r: &VirtualRunner) -> &Sim {
    r.source(0).unwrap().as_any().downcast_ref::<Sim>().unwrap()
}

#[test]
fn takeoff_alt_from_the_file_is_what_takeoff_and_t_ask_for() {
    let (_dir, path) = file_with("takeoff_alt = 15\nlinks = [\"sim://\"]\n");
    let c = cli(&["--config", path.to_str().unwrap()]);
    let file = config::load_user(c.config.as_deref()).unwrap();
    let mut r = VirtualRunner::from_specs(&c.links(&file), c.app_config(&file)).unwrap();
    r.advance_to(6 * SECOND); // the sim's EKF takes GPS from 5 s

    // `T` opens the prompt with the file's altitude.
    common::keys(&mut r, &["T"]);
    assert_eq!(r.app.ui.prompt.line.text, "takeoff 15");
    common::keys(&mut r, &["esc"]);

    // `:takeoff` without a number asks for it too, and the vehicle climbs to it.
    common::keys(&mut r, &[":"]);
    common::typed(&mut r, "takeoff");
    common::keys(&mut r, &["enter"]);
    let text = r.app.ui.confirm.as_ref().map(|c| c.text.clone());
    assert!(
        text.as_deref()
            .is_some_and(|t| t.starts_with("TAKE OFF to 15 m 1:1")),
        "{text:?}"
    );
    common::yes(&mut r);
    r.advance_to(r.now() + 20 * SECOND);
    let alt = sim(&r).vehicle(1).unwrap().relative_alt_m();
    assert!((alt - 15.0).abs() <= 0.5, "altitude {alt}");
}

#[test]
fn flags_given_beat_the_file() {
    let (_dir, path) = file_with(
        "sysid = 42\ncompid = 191\nlost_timeout = 2.5\nlinks = [\"tcp:127.0.0.1:5760\"]\n",
    );
    let p = path.to_str().unwrap();
    let c = cli(&[
        "--config",
        p,
        "--sysid",
        "7",
        "--lost-timeout",
        "9",
        "--link",
        "udpin:0.0.0.0:14551",
    ]);
    let file = config::load_user(c.config.as_deref()).unwrap();
    let cfg = c.app_config(&file);
    assert_eq!(cfg.sysid, 7, "--sysid beats the file");
    assert_eq!(cfg.compid, 191, "the file beats the default");
    assert_eq!(cfg.lost_timeout, 9 * SECOND);
    let links: Vec<String> = c.links(&file).iter().map(|l| l.to_string()).collect();
    assert_eq!(links, ["udpin:0.0.0.0:14551"]);
    // A flag given with the default's value still beats the file.
    let c = cli(&["--config", p, "--sysid", "255"]);
    assert_eq!(c.app_config(&file).sysid, 255);
}

#[test]
fn sysid_zero_is_refused_on_the_command_line_too() {
    assert!(Cli::try_parse_from(["mavterm", "--sysid", "0"]).is_err());
}
