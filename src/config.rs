//! The config file: `config.toml` in mavterm's config directory (`~/.config/mavterm/`, or under
//! `$XDG_CONFIG_HOME`), or `--config FILE`. Every key is optional; `assets/config.example.toml`
//! lists them all with their defaults.
//!
//! Precedence: a command-line flag given explicitly beats the file, which beats the built-in
//! defaults (see `Cli::app_config` at the edge). Unknown keys and bad values are refused, every
//! one of them with its file, line and column.

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use mavlink::Message;
use toml::de::{DeString, DeTable, DeValue};
use toml::Spanned;

use crate::app::AppConfig;
use crate::clock::{Micros, SECOND};
use crate::dialect::MavMessage;
use crate::keymap::{LineIndex, Problem};
use crate::link::LinkSpec;
use crate::proto::rates::{self, StreamRates};

/// The shipped example: every key with its default, commented.
pub const EXAMPLE: &str = include_str!("../assets/config.example.toml");

/// The highest rate the file may ask for, in Hz.
pub const MAX_RATE_HZ: f32 = 50.0;
/// The highest take-off altitude, in metres above home (as `takeoff METRES` at the prompt).
pub const MAX_TAKEOFF_ALT: f64 = 10_000.0;

/// mavterm's config directory (see [`crate::paths::config_dir`]).
pub fn dir() -> Option<PathBuf> {
    crate::paths::config_dir()
}

/// Where the config file is read from when no `--config` is given.
pub fn default_path() -> Option<PathBuf> {
    Some(dir()?.join("config.toml"))
}

/// What a config file sets: `None` (or empty) for what it leaves to the defaults.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FileConfig {
    /// `sysid`: our MAVLink system id.
    pub sysid: Option<u8>,
    /// `compid`: our MAVLink component id.
    pub compid: Option<u8>,
    /// `lost_timeout`, in seconds.
    pub lost_timeout: Option<f64>,
    /// `takeoff_alt`, in metres above home.
    pub takeoff_alt: Option<f64>,
    /// `nudge_deadman`, in seconds: Fly mode stops a nudge when no key has come for this long.
    pub nudge_deadman: Option<f64>,
    /// `links`: opened when no `--link` is given.
    pub links: Option<Vec<LinkSpec>>,
    /// `[streams]`: ArduPilot stream group id → Hz, for the groups the file names.
    pub stream_groups: BTreeMap<u8, f32>,
    /// `[streams.messages]`: message id → Hz; `None` when the section is absent.
    pub stream_messages: Option<BTreeMap<u32, f32>>,
    /// `signing_key`: `file:PATH` only (a secret does not belong in a config file).
    pub signing_key: Option<String>,
    /// `signing_allow_unsigned_heartbeat`.
    pub signing_allow_unsigned_heartbeat: Option<bool>,
    /// `utc`: show times in UTC, not local time.
    pub utc: Option<bool>,
    /// `log_rate`: onboard log downloads at most this many bytes a second.
    pub log_rate: Option<u32>,
    /// `adsb_timeout`, seconds: ADS-B traffic not heard for this long leaves the map.
    pub adsb_timeout: Option<f64>,
    /// `adsb_warn_distance`, metres: traffic closer than this (and `adsb_warn_height`) warns.
    pub adsb_warn_distance: Option<f64>,
    /// `adsb_warn_height`, metres above or below the target.
    pub adsb_warn_height: Option<f64>,
}

impl FileConfig {
    /// `cfg` with what the file sets on top.
    pub fn apply(&self, cfg: &mut AppConfig) {
        if let Some(v) = self.sysid {
            cfg.sysid = v;
        }
        if let Some(v) = self.compid {
            cfg.compid = v;
        }
        if let Some(v) = self.lost_timeout {
            cfg.lost_timeout = seconds_to_micros(v);
        }
        if let Some(v) = self.takeoff_alt {
            cfg.takeoff_alt = v;
        }
        if let Some(v) = self.nudge_deadman {
            cfg.nudge_deadman = seconds_to_micros(v);
        }
        if let Some(v) = self.log_rate {
            cfg.log_rate = Some(v);
        }
        if let Some(v) = self.adsb_timeout {
            cfg.map.adsb_timeout = seconds_to_micros(v);
        }
        if let Some(v) = self.adsb_warn_distance {
            cfg.map.warn_distance = v;
        }
        if let Some(v) = self.adsb_warn_height {
            cfg.map.warn_height = v;
        }
        self.apply_streams(&mut cfg.streams);
    }

    /// `rates` with the file's `[streams]` on top: each group it names gets its rate; a
    /// `[streams.messages]` section replaces the message set asked of autopilots that only take
    /// SET_MESSAGE_INTERVAL (PX4) and is asked of ArduPilot on top of its groups.
    pub fn apply_streams(&self, rates: &mut StreamRates) {
        rates
            .groups
            .extend(self.stream_groups.iter().map(|(k, v)| (*k, *v)));
        if let Some(m) = &self.stream_messages {
            rates.messages = m.clone();
            rates.ardupilot_messages = m.clone();
        }
    }
}

/// Seconds to [`Micros`].
pub fn seconds_to_micros(s: f64) -> Micros {
    (s * SECOND as f64) as Micros
}

/// Why a config file was refused. Every message names the file.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read (a `--config FILE` that is not there, too).
    #[error("config {path}: {error}")]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    /// Not valid TOML, or unknown keys or bad values: every problem found, in file order.
    #[error("{0}")]
    Invalid(InvalidConfig),
}

/// The problems of a refused config file (a TOML syntax error is the only one reported).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InvalidConfig {
    /// The file as named in messages.
    pub origin: String,
    /// Top to bottom.
    pub problems: Vec<Problem>,
}

/// One `FILE:LINE:COL: message` per line.
impl fmt::Display for InvalidConfig {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, p) in self.problems.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{}:{}:{}: {}", self.origin, p.line, p.col, p.message)?;
        }
        Ok(())
    }
}

/// The config to run with: `explicit` (`--config FILE`, which must exist), else the file at
/// [`default_path`] when there is one, else nothing set.
pub fn load_user(explicit: Option<&Path>) -> Result<FileConfig, ConfigError> {
    match explicit {
        Some(p) => read(p),
        None => match default_path() {
            Some(p) if p.is_file() => read(&p),
            _ => Ok(FileConfig::default()),
        },
    }
}

/// Read and check the config file at `path`.
pub fn read(path: &Path) -> Result<FileConfig, ConfigError> {
    let text =
        crate::fsio::read_text(path, crate::fsio::MAX_READ).map_err(|error| ConfigError::Io {
            path: path.to_path_buf(),
            error,
        })?;
    load(path, &text)
}

type Entry<'d, 'i> = (&'d Spanned<DeString<'i>>, &'d Spanned<DeValue<'i>>);

/// A table's entries in file order (the parser sorts them by name).
fn by_pos<'d, 'i>(t: &'d DeTable<'i>) -> Vec<Entry<'d, 'i>> {
    let mut v: Vec<_> = t.iter().collect();
    v.sort_by_key(|(k, _)| k.span().start);
    v
}

/// A value as the file wrote it, for messages.
fn describe(v: &DeValue) -> String {
    match v {
        DeValue::Integer(i) => i.to_string(),
        DeValue::Float(f) => f.as_str().to_string(),
        DeValue::String(s) => format!("{s:?}"),
        other => format!("a {}", other.type_str()),
    }
}

fn integer(v: &DeValue) -> Option<i64> {
    let i = v.as_integer()?;
    i64::from_str_radix(i.as_str(), i.radix()).ok()
}

/// An integer or a float.
fn number(v: &DeValue) -> Option<f64> {
    match v {
        DeValue::Float(f) => f.as_str().parse().ok(),
        _ => integer(v).map(|i| i as f64),
    }
}

fn rate(v: &DeValue) -> Option<f32> {
    number(v)
        .filter(|r| r.is_finite() && (0.0..=MAX_RATE_HZ as f64).contains(r))
        .map(|r| r as f32)
}

/// What is wrong where, by byte offset.
#[derive(Default)]
struct Found(Vec<(usize, String)>);

impl Found {
    /// `f(value)`, or a problem `NAME: expected WHAT, found VALUE` at the value.
    fn check<'v, 'i, T>(
        &mut self,
        name: &str,
        value: &'v Spanned<DeValue<'i>>,
        what: &str,
        f: impl FnOnce(&'v DeValue<'i>) -> Option<T>,
    ) -> Option<T> {
        let r = f(value.get_ref());
        if r.is_none() {
            self.0.push((
                value.span().start,
                format!(
                    "{name}: expected {what}, found {}",
                    describe(value.get_ref())
                ),
            ));
        }
        r
    }

    fn add(&mut self, at: usize, message: String) {
        self.0.push((at, message));
    }
}

const KEYS: &str = "sysid, compid, lost_timeout, takeoff_alt, nudge_deadman, links, signing_key, \
                    signing_allow_unsigned_heartbeat, utc, log_rate, adsb_timeout, \
                    adsb_warn_distance, adsb_warn_height, [streams]";

/// Check a config file's `text`; `path` names it in errors. Every key is optional; unknown keys
/// and bad values are refused, all of them at once, each with its line and column.
pub fn load(path: &Path, text: &str) -> Result<FileConfig, ConfigError> {
    let origin = path.display().to_string();
    let index = LineIndex::new(text);
    let refuse = |mut found: Vec<(usize, String)>| {
        found.sort_by_key(|(at, _)| *at); // stable: the same place keeps the found order
        let problems = found
            .into_iter()
            .map(|(at, message)| {
                let (line, col) = index.line_col(at);
                Problem { line, col, message }
            })
            .collect();
        ConfigError::Invalid(InvalidConfig {
            origin: origin.clone(),
            problems,
        })
    };
    let doc = DeTable::parse(text).map_err(|e| {
        refuse(vec![(
            e.span().map_or(0, |s| s.start),
            e.message().trim().to_string(),
        )])
    })?;

    let mut found = Found::default();
    let mut cfg = FileConfig::default();
    for (key, value) in by_pos(doc.get_ref()) {
        let id = |v: &DeValue| {
            integer(v)
                .filter(|i| (1..=255).contains(i))
                .map(|i| i as u8)
        };
        match key.get_ref().as_ref() {
            "sysid" => cfg.sysid = found.check("sysid", value, "a system id from 1 to 255", id),
            "compid" => {
                cfg.compid = found.check("compid", value, "a component id from 1 to 255", id)
            }
            "lost_timeout" => {
                cfg.lost_timeout =
                    found.check("lost_timeout", value, "seconds from 0.1 to 3600", |v| {
                        number(v).filter(|s| s.is_finite() && (0.1..=3600.0).contains(s))
                    })
            }
            "takeoff_alt" => {
                cfg.takeoff_alt = found.check(
                    "takeoff_alt",
                    value,
                    "metres above home, more than 0 and at most 10000",
                    |v| number(v).filter(|a| a.is_finite() && *a > 0.0 && *a <= MAX_TAKEOFF_ALT),
                )
            }
            "nudge_deadman" => {
                cfg.nudge_deadman =
                    found.check("nudge_deadman", value, "seconds from 0.1 to 5", |v| {
                        number(v).filter(|s| s.is_finite() && (0.1..=5.0).contains(s))
                    })
            }
            "adsb_timeout" => {
                cfg.adsb_timeout =
                    found.check("adsb_timeout", value, "seconds from 1 to 3600", |v| {
                        number(v).filter(|s| s.is_finite() && (1.0..=3600.0).contains(s))
                    })
            }
            "adsb_warn_distance" => {
                cfg.adsb_warn_distance = found.check(
                    "adsb_warn_distance",
                    value,
                    "metres from 0 to 100000",
                    |v| number(v).filter(|m| m.is_finite() && (0.0..=100_000.0).contains(m)),
                )
            }
            "adsb_warn_height" => {
                cfg.adsb_warn_height =
                    found.check("adsb_warn_height", value, "metres from 0 to 10000", |v| {
                        number(v).filter(|m| m.is_finite() && (0.0..=10_000.0).contains(m))
                    })
            }
            "links" => cfg.links = links(value, &mut found),
            // Refused without showing the value: it may be a secret.
            "signing_key" => match value.get_ref().as_str() {
                Some(s) if s.len() > 5 && s.starts_with("file:") => {
                    cfg.signing_key = Some(s.to_string())
                }
                _ => found.add(
                    value.span().start,
                    "signing_key: expected \"file:PATH\", a key file only you can read (a \
                     passphrase or hex key does not belong in the config file)"
                        .into(),
                ),
            },
            "signing_allow_unsigned_heartbeat" => {
                cfg.signing_allow_unsigned_heartbeat = found.check(
                    "signing_allow_unsigned_heartbeat",
                    value,
                    "true or false",
                    |v| v.as_bool(),
                )
            }
            "utc" => cfg.utc = found.check("utc", value, "true or false", |v| v.as_bool()),
            "log_rate" => {
                cfg.log_rate = found.check(
                    "log_rate",
                    value,
                    "bytes a second from 100 to 100000000",
                    |v| {
                        integer(v)
                            .filter(|r| (100..=100_000_000).contains(r))
                            .map(|r| r as u32)
                    },
                )
            }
            "streams" => streams(value, &mut found, &mut cfg),
            other => found.add(
                key.span().start,
                format!("unknown key {other:?} (the keys are {KEYS})"),
            ),
        }
    }
    if found.0.is_empty() {
        Ok(cfg)
    } else {
        Err(refuse(found.0))
    }
}

/// `links = ["SPEC", ...]`.
fn links(value: &Spanned<DeValue>, found: &mut Found) -> Option<Vec<LinkSpec>> {
    let list = found.check(
        "links",
        value,
        "a list of link specs, e.g. links = [\"udpin:0.0.0.0:14550\"]",
        |v| v.as_array(),
    )?;
    let mut out = Vec::new();
    for item in list.iter() {
        let Some(s) = found.check("links", item, "a link spec in quotes", |v| v.as_str()) else {
            continue;
        };
        match s.parse::<LinkSpec>() {
            Ok(spec) => out.push(spec),
            Err(e) => found.add(item.span().start, format!("links: {e}")),
        }
    }
    Some(out)
}

/// `[streams]` and `[streams.messages]`.
fn streams(value: &Spanned<DeValue>, found: &mut Found, cfg: &mut FileConfig) {
    let Some(table) = found.check("streams", value, "a section, [streams]", |v| v.as_table())
    else {
        return;
    };
    let rate_hz = "a rate in Hz from 0 to 50";
    for (key, value) in by_pos(table) {
        let name = key.get_ref().as_ref();
        if name == "messages" {
            messages(value, found, cfg);
            continue;
        }
        let Some(group) = rates::group_id(name) else {
            let groups: Vec<&str> = rates::GROUPS.iter().map(|(_, n)| *n).collect();
            found.add(
                key.span().start,
                format!(
                    "unknown key \"streams.{name}\" (the stream groups are {}, and the section \
                     [streams.messages])",
                    groups.join(", ")
                ),
            );
            continue;
        };
        if let Some(r) = found.check(&format!("streams.{name}"), value, rate_hz, rate) {
            cfg.stream_groups.insert(group, r);
        }
    }
}

/// `[streams.messages]`: message name (any case) or id → Hz.
fn messages(value: &Spanned<DeValue>, found: &mut Found, cfg: &mut FileConfig) {
    let Some(table) = found.check(
        "streams.messages",
        value,
        "a section, [streams.messages]",
        |v| v.as_table(),
    ) else {
        return;
    };
    let mut set = BTreeMap::new();
    let mut seen: BTreeMap<u32, &str> = BTreeMap::new();
    for (key, value) in by_pos(table) {
        let name = key.get_ref().as_ref();
        let id = match name.parse::<u32>() {
            Ok(id) => Some(id).filter(|id| MavMessage::default_message_from_id(*id).is_some()),
            Err(_) => MavMessage::message_id_from_name(&name.to_ascii_uppercase()),
        };
        let Some(id) = id else {
            found.add(
                key.span().start,
                format!(
                    "streams.messages: unknown message {name:?} (a message name of the \
                     ardupilotmega dialect, e.g. ATTITUDE, or its id, e.g. 30)"
                ),
            );
            continue;
        };
        if let Some(first) = seen.insert(id, name) {
            found.add(
                key.span().start,
                format!("streams.messages: {name:?} is message {id}, already set as {first:?}"),
            );
            continue;
        }
        let what = format!("streams.messages.{name}");
        if let Some(r) = found.check(&what, value, "a rate in Hz from 0 to 50", rate) {
            set.insert(id, r);
        }
    }
    cfg.stream_messages = Some(set);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn problems(text: &str) -> Vec<(usize, usize, String)> {
        match load(Path::new("config.toml"), text) {
            Err(ConfigError::Invalid(i)) => i
                .problems
                .into_iter()
                .map(|p| (p.line, p.col, p.message))
                .collect(),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn the_example_is_the_defaults() {
        let file = load(Path::new("config.example.toml"), EXAMPLE).unwrap();
        let mut cfg = AppConfig::default();
        file.apply(&mut cfg);
        let d = AppConfig::default();
        assert_eq!(
            (cfg.sysid, cfg.compid, cfg.lost_timeout, cfg.takeoff_alt),
            (d.sysid, d.compid, d.lost_timeout, d.takeoff_alt)
        );
        assert_eq!(cfg.streams, d.streams);
        assert_eq!(file.links, Some(vec![]));
    }

    #[test]
    fn empty_file_sets_nothing() {
        assert_eq!(
            load(Path::new("c.toml"), "").unwrap(),
            FileConfig::default()
        );
    }

    #[test]
    fn messages_by_name_any_case_or_id() {
        let f = load(
            Path::new("c.toml"),
            "[streams.messages]\nattitude = 4\n33 = 2.5\n",
        )
        .unwrap();
        let want: BTreeMap<u32, f32> = [(30, 4.0), (33, 2.5)].into_iter().collect();
        assert_eq!(f.stream_messages.as_ref(), Some(&want));
        let mut r = StreamRates::default();
        f.apply_streams(&mut r);
        assert_eq!(
            (r.messages.clone(), r.ardupilot_messages),
            (want.clone(), want)
        );
        assert_eq!(r.groups, StreamRates::default().groups);
    }

    #[test]
    fn problems_are_located() {
        let p = problems("rate = 1\nsysid = 0\n[streams]\nposition = 300\nATTITUDE = 1\n");
        let at: Vec<(usize, usize)> = p.iter().map(|(l, c, _)| (*l, *c)).collect();
        assert_eq!(at, [(1, 1), (2, 9), (4, 12), (5, 1)], "{p:?}");
        assert!(p[0].2.starts_with("unknown key \"rate\""), "{p:?}");
        assert_eq!(p[1].2, "sysid: expected a system id from 1 to 255, found 0");
        assert_eq!(
            p[2].2,
            "streams.position: expected a rate in Hz from 0 to 50, found 300"
        );
        assert!(p[3].2.starts_with("unknown key \"streams.ATTITUDE\""));
    }

    #[test]
    fn signing_key_only_as_a_file() {
        let f = load(
            Path::new("c.toml"),
            "signing_key = \"file:~/.config/mavterm/signing.key\"\n\
             signing_allow_unsigned_heartbeat = true\n",
        )
        .unwrap();
        assert_eq!(
            f.signing_key.as_deref(),
            Some("file:~/.config/mavterm/signing.key")
        );
        assert_eq!(f.signing_allow_unsigned_heartbeat, Some(true));
        let p = problems("signing_key = \"my passphrase\"\n");
        assert_eq!((p[0].0, p[0].1), (1, 15), "{p:?}");
        assert!(p[0].2.contains("file:PATH"), "{p:?}");
        assert!(
            !p[0].2.contains("passphrase\""),
            "the value is not shown: {p:?}"
        );
        let p = problems("signing_allow_unsigned_heartbeat = 1\n");
        assert!(p[0].2.contains("true or false"), "{p:?}");
    }

    #[test]
    fn utc_is_true_or_false() {
        let f = load(Path::new("c.toml"), "utc = true\n").unwrap();
        assert_eq!(f.utc, Some(true));
        let p = problems("utc = \"yes\"\n");
        assert_eq!((p[0].0, p[0].1), (1, 7), "{p:?}");
        assert!(p[0].2.contains("utc: expected true or false"), "{p:?}");
    }

    #[test]
    fn syntax_errors_are_located() {
        let p = problems("sysid = 1\nsysid = 2\n");
        assert_eq!((p.len(), p[0].0), (1, 2), "{p:?}");
        let p = problems("links = [\n");
        assert_eq!(p.len(), 1, "{p:?}");
    }
}
