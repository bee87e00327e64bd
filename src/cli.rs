//! Command-line options.

use std::path::PathBuf;

use clap::{Parser, Subcommand, ValueEnum};

use chrono::{DateTime, Offset, TimeZone, Utc};

use crate::app::AppConfig;
use crate::clock::DisplayZone;
use crate::config::{seconds_to_micros, FileConfig};
use crate::driver::record::TlogTarget;
use crate::link::LinkSpec;

/// A terminal ground-control station for MAVLink vehicles.
#[derive(Debug, Parser)]
#[command(name = "mavterm", version, about, after_help = after_help())]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,

    /// Settings file (default: `config.toml` in mavterm's config directory,
    /// ~/.config/mavterm/, when there is one). Flags given here win over it.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,

    /// A link to open (repeatable). Default: the config file's `links`, else `sim://`, the
    /// embedded simulated vehicle.
    /// Forms: udpin:ADDR:PORT, udpout:HOST:PORT, tcp:HOST:PORT, tcpin:ADDR:PORT,
    /// serial:PATH[:BAUD], PATH,BAUD, udp://[HOST]:PORT, udpout://HOST:PORT, tcp://HOST:PORT,
    /// serial://PATH[:BAUD], sim://[?options], tlog:PATH. Network and serial links take `?hl=1`
    /// for a high-latency or low-bandwidth link: nothing automatic is sent on it (no stream
    /// requests, no parameter download). A serial baud given explicitly fits the telemetry rates
    /// asked to the link. `?secure=1` marks a USB cable or a wire: `signing setup` sends the
    /// signing key only on such a link, and unsigned frames are taken on it.
    #[arg(long = "link", value_name = "SPEC", value_parser = parse_spec)]
    pub links: Vec<LinkSpec>,

    /// Our MAVLink system id [default: the config file's `sysid`, else 255].
    #[arg(long, value_parser = clap::value_parser!(u8).range(1..))]
    pub sysid: Option<u8>,

    /// Our MAVLink component id [default: the config file's `compid`, else 190].
    #[arg(long, value_parser = clap::value_parser!(u8).range(1..))]
    pub compid: Option<u8>,

    /// Seconds without a heartbeat before a vehicle is shown lost [default: the config file's
    /// `lost_timeout`, else 5].
    #[arg(long, value_name = "SECONDS", value_parser = parse_lost_timeout)]
    pub lost_timeout: Option<f64>,

    /// Run without a terminal.
    #[arg(long)]
    pub headless: bool,

    /// Headless: how long to run, in seconds [default: 10; with --params-out, 300; with only
    /// tlog: replays (and sim://), to the end of the logs].
    #[arg(long, value_name = "SECONDS", value_parser = parse_duration)]
    pub duration: Option<f64>,

    /// Headless: print a report at the end.
    #[arg(long, value_enum)]
    pub report: Option<ReportFormat>,

    /// Headless: download every parameter of the first autopilot and write them to FILE
    /// (`.params` = QGroundControl's format, anything else MAVProxy's `.parm`); exits 0 only
    /// when the set is complete. `--duration` limits the wait (default 300 s).
    #[arg(long, value_name = "FILE")]
    pub params_out: Option<PathBuf>,

    /// Headless: download the first autopilot's onboard logs into DIR (the newest, or those of
    /// --log-ids), named by their time; exits 0 only when every one is whole. `--duration`
    /// limits the wait (default 3600 s).
    #[arg(long, value_name = "DIR")]
    pub logs_out: Option<PathBuf>,

    /// Headless, with --logs-out: the ids of the logs to download (comma-separated).
    #[arg(long, value_name = "IDS", value_delimiter = ',', requires = "logs_out")]
    pub log_ids: Vec<u16>,

    /// Parameter metadata: ArduPilot's `apm.pdef.xml` or PX4's `parameters.xml` (default:
    /// `param-meta.xml` in mavterm's config directory, when there is one).
    #[arg(long, value_name = "FILE")]
    pub param_meta: Option<PathBuf>,

    /// Headless: replay recorded input (keys, snapshots) from FILE.
    #[arg(long, value_name = "FILE")]
    pub input: Option<PathBuf>,

    /// Headless: screen size for replay, WIDTHxHEIGHT, each from 1 to 1000 [default: the
    /// script's `# size` line (as --record writes it), else 120x40].
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub size: Option<(u16, u16)>,

    /// Headless: directory for `snapshot NAME` screens (default: stdout).
    #[arg(long, value_name = "DIR")]
    pub screens: Option<PathBuf>,

    /// Key bindings to layer over the defaults.
    #[arg(long, value_name = "FILE")]
    pub keymap: Option<PathBuf>,

    /// Highest redraw rate of the terminal UI, in frames a second (1 to 120).
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..=120))]
    pub fps: u32,

    /// Terminal UI: record the session to FILE as a replay script (`# link` and `# size` header
    /// lines, the keys pressed and let go, resizes, then `snapshot final` and `quit`);
    /// `--headless --input FILE` replays it on those links at that size.
    #[arg(long, value_name = "FILE")]
    pub record: Option<PathBuf>,

    /// Write the log (tracing) to FILE.
    #[arg(long, value_name = "FILE")]
    pub log: Option<PathBuf>,

    /// Sign with MAVLink 2 signing and reject what is not signed with this key: a PASSPHRASE
    /// (hashed with SHA-256, as MAVProxy and Mission Planner do), hex:64HEX, or file:PATH (a
    /// file only you can read, holding either). [default: the config file's `signing_key`]
    #[arg(long, value_name = "KEY")]
    pub signing_key: Option<String>,

    /// With a signing key, take unsigned HEARTBEATs too (components that cannot sign stay
    /// listed). RADIO_STATUS from SiK radios is always taken.
    #[arg(long)]
    pub signing_allow_unsigned_heartbeat: bool,
    /// Record every frame heard and sent, on every link, to the telemetry log FILE (`.tlog`, as
    /// MAVProxy, QGroundControl and pymavlink read; an existing FILE is appended to). Default:
    /// the terminal UI records to a new file named after the start time in mavterm's data
    /// directory (`~/.local/share/mavterm/logs/`, or under `$XDG_DATA_HOME`); headless runs,
    /// and sessions whose links are all `tlog:` replays, record only when given FILE.
    #[arg(long, value_name = "FILE")]
    pub tlog: Option<PathBuf>,

    /// Record no telemetry log.
    #[arg(long, conflicts_with = "tlog")]
    pub no_tlog: bool,

    /// Show times (status bar, messages, replays) in UTC, not in the local time zone
    /// [default: the config file's `utc`, else local time].
    #[arg(long)]
    pub utc: bool,
    /// Forward every frame heard, unchanged, to another ground station, and what it sends to
    /// the vehicles, as MAVProxy's --out (repeatable). The forms of --link; `udpout:HOST:PORT`
    /// and `tcpin:ADDR:PORT` are typical.
    #[arg(long = "out", value_name = "SPEC", value_parser = parse_out_spec)]
    pub outs: Vec<LinkSpec>,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Serve simulated vehicle(s) to any GCS, in real time, until Ctrl-C.
    #[command(after_help = crate::sim::config::options_help())]
    Sim {
        /// Where to serve: tcp:ADDR:PORT (listen), udpin:ADDR:PORT, udpout:HOST:PORT.
        #[arg(long, value_parser = parse_spec)]
        listen: LinkSpec,
        /// Number of vehicles, 1 to 250 (sysid 1, 2, ...).
        #[arg(long, value_parser = clap::value_parser!(u8).range(1..=250))]
        vehicles: Option<u8>,
        /// More sim options, as in sim://?OPTIONS (e.g. "loss=0.1&seed=7"); listed below.
        #[arg(long, default_value = "")]
        options: String,
    },
}

/// What `mavterm --help` shows after the options: examples, where the files are, the
/// environment. The paths are this machine's (`$XDG_CONFIG_HOME` and `$XDG_DATA_HOME` move them).
pub fn after_help() -> String {
    let show = |p: Option<PathBuf>, fallback: &str| {
        p.map_or_else(|| fallback.to_string(), |p| p.display().to_string())
    };
    let config = crate::paths::config_dir();
    let in_config = |name: &str| {
        show(
            config.as_ref().map(|d| d.join(name)),
            &format!("$XDG_CONFIG_HOME/mavterm/{name}"),
        )
    };
    format!(
        "Examples:
  mavterm --link /dev/ttyUSB0,57600
      a serial telemetry radio (SiK) at 57600 baud
  mavterm --link tcp:127.0.0.1:5760
      ArduPilot SITL (sim_vehicle.py serves MAVLink on TCP port 5760)
  mavterm --link udpin:0.0.0.0:14550
      what is sent to UDP port 14550 (a companion computer, MAVProxy, PX4 SITL)
  mavterm --link udpin:0.0.0.0:14550 --headless --duration 10 --report json
      no terminal: listen for 10 s, then print a JSON report on stdout
  mavterm --link tlog:flight.tlog
      replay a telemetry log
  mavterm
      the built-in simulated vehicle, sim:// (its options: mavterm sim --help)

Files:
  settings    {settings}  (or --config FILE)
  keys        {keymap}  (or --keymap FILE)
  metadata    {meta}  (or --param-meta FILE)
  flight logs {logs}
  ($XDG_CONFIG_HOME and $XDG_DATA_HOME move them.)

Environment:
  NO_COLOR    set and not empty: the terminal UI has no colours
  RUST_LOG    what --log FILE records (default: info)",
        settings = in_config("config.toml"),
        keymap = in_config("keymap.toml"),
        meta = in_config("param-meta.xml"),
        logs = show(crate::paths::logs_dir(), "$XDG_DATA_HOME/mavterm/logs"),
    )
}

impl Cli {
    /// The core's settings: each flag given explicitly, else the config `file`'s value, else the
    /// built-in default. (`param_meta` is left for the caller to load.)
    pub fn app_config(&self, file: &FileConfig) -> AppConfig {
        let mut cfg = AppConfig::default();
        file.apply(&mut cfg);
        if let Some(v) = self.sysid {
            cfg.sysid = v;
        }
        if let Some(v) = self.compid {
            cfg.compid = v;
        }
        if let Some(s) = self.lost_timeout {
            cfg.lost_timeout = seconds_to_micros(s);
        }
        cfg
    }

    /// Times shown in UTC: `--utc`, else the config file's `utc`.
    pub fn wants_utc(&self, file: &FileConfig) -> bool {
        self.utc || file.utc == Some(true)
    }

    /// The zone times are shown in: UTC with `--utc` or the config file's `utc = true`, else the
    /// local zone (`chrono::Local`: `TZ`, else /etc/localtime) as it is at `at`.
    pub fn display_zone(&self, file: &FileConfig, at: DateTime<Utc>) -> DisplayZone {
        if self.wants_utc(file) {
            DisplayZone::utc()
        } else {
            local_zone(at)
        }
    }

    /// Where to record the telemetry log, if anywhere (see `--tlog`): `Err` when the default
    /// applies but there is no data directory to put it in.
    pub fn tlog_target(&self, links: &[LinkSpec]) -> Result<Option<TlogTarget>, String> {
        if self.no_tlog {
            return Ok(None);
        }
        if let Some(f) = &self.tlog {
            return Ok(Some(TlogTarget::File(f.clone())));
        }
        let replay_only = links.iter().all(|l| matches!(l, LinkSpec::Tlog { .. }));
        if self.headless || replay_only || self.command.is_some() {
            return Ok(None);
        }
        match crate::paths::logs_dir() {
            Some(dir) => Ok(Some(TlogTarget::NewIn(dir))),
            None => Err("no home directory for the telemetry log (give --tlog FILE)".into()),
        }
    }

    /// The links to open: `--link`s if any, else the config file's `links` if any, else
    /// `sim://`.
    pub fn links(&self, file: &FileConfig) -> Vec<LinkSpec> {
        if !self.links.is_empty() {
            return self.links.clone();
        }
        match &file.links {
            Some(links) if !links.is_empty() => links.clone(),
            _ => vec![LinkSpec::Sim {
                query: String::new(),
            }],
        }
    }
}

/// The local time zone (`chrono::Local`) as it is at `at` (its offset then, daylight saving
/// time included), labelled with that offset.
pub fn local_zone(at: DateTime<Utc>) -> DisplayZone {
    DisplayZone::fixed(
        chrono::Local
            .offset_from_utc_datetime(&at.naive_utc())
            .fix(),
    )
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ReportFormat {
    Json,
}

/// Clap's message shows the value already (`invalid value 'X' for '--link <SPEC>': ...`): the
/// spec error's own `link spec `X`: ` is left out.
fn parse_spec(s: &str) -> Result<LinkSpec, String> {
    s.parse::<LinkSpec>().map_err(|e| {
        let e = e.to_string();
        match e.strip_prefix(&format!("link spec `{s}`: ")) {
            Some(rest) => rest.to_string(),
            None => e,
        }
    })
}

/// An output: a link spec that reaches another ground station (not the sim nor a replay).
fn parse_out_spec(s: &str) -> Result<LinkSpec, String> {
    match parse_spec(s)? {
        LinkSpec::Sim { .. } | LinkSpec::Tlog { .. } => {
            Err("an output is a network or serial link (e.g. udpout:127.0.0.1:14550)".into())
        }
        spec => Ok(spec),
    }
}

/// Seconds: a finite number from 0 to a year.
fn parse_duration(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && (0.0..=31_536_000.0).contains(&v) => Ok(v),
        _ => Err("expected seconds from 0 to 31536000".into()),
    }
}

/// `--lost-timeout`: seconds from 0.1 to 3600, as the config file's `lost_timeout`.
fn parse_lost_timeout(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && (0.1..=3600.0).contains(&v) => Ok(v),
        _ => Err("expected seconds from 0.1 to 3600".into()),
    }
}

/// The largest `--size` side: a screen bigger than any terminal is a typo.
pub const MAX_SIZE: u16 = 1000;

/// `--size WIDTHxHEIGHT`, each side from 1 to [`MAX_SIZE`]. (Clap's message shows the value.)
fn parse_size(s: &str) -> Result<(u16, u16), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| "expected WIDTHxHEIGHT, e.g. 120x40".to_string())?;
    let side = |name: &str, v: &str| -> Result<u16, String> {
        if v.is_empty() {
            return Err(format!("{name} is missing"));
        }
        if !v.bytes().all(|b| b.is_ascii_digit()) {
            return Err(format!("{name} `{v}` is not a whole number"));
        }
        // All digits: only too many of them can fail to parse.
        match v.parse::<u64>() {
            Ok(0) => Err(format!("{name} must be at least 1")),
            Ok(n) if n <= u64::from(MAX_SIZE) => Ok(n as u16),
            _ => Err(format!("{name} {v} is over {MAX_SIZE}")),
        }
    };
    Ok((side("width", w)?, side("height", h)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn size_sides_are_1_to_1000_and_say_what_is_wrong() {
        assert_eq!(parse_size("120x40"), Ok((120, 40)));
        assert_eq!(parse_size("1000X1"), Ok((1000, 1)));
        for (arg, says) in [
            ("70000x10", "width 70000 is over 1000"),
            ("10x1001", "height 1001 is over 1000"),
            ("99999999999999999999999x1", "is over 1000"),
            ("0x5", "width must be at least 1"),
            ("12x", "height is missing"),
            ("ax5", "width `a` is not a whole number"),
            ("-1x5", "not a whole number"),
            ("120", "expected WIDTHxHEIGHT"),
        ] {
            let e = parse_size(arg).unwrap_err();
            assert!(e.contains(says), "{arg}: {e}");
        }
    }

    #[test]
    fn values_that_cannot_work_are_refused_by_flag() {
        let parse = |args: &[&str]| {
            Cli::try_parse_from(std::iter::once("mavterm").chain(args.iter().copied()))
                .map_err(|e| e.to_string())
        };
        for (args, says) in [
            (&["--fps", "0"][..], "1..=120"),
            (&["--fps", "121"], "1..=120"),
            (
                &["--lost-timeout", "0"],
                "expected seconds from 0.1 to 3600",
            ),
            (&["--lost-timeout", "3601"], "from 0.1 to 3600"),
            (&["--sysid", "0"], "1..=255"),
            (&["--compid", "0"], "1..=255"),
            (&["--size", "70000x10"], "width 70000 is over 1000"),
            (
                &["sim", "--listen", "tcp:127.0.0.1:5760", "--vehicles", "300"],
                "1..=250",
            ),
            (
                &["sim", "--listen", "tcp:127.0.0.1:5760", "--vehicles", "0"],
                "1..=250",
            ),
        ] {
            let e = parse(args).unwrap_err();
            let flag = args.iter().rev().nth(1).unwrap();
            assert!(e.contains(flag) && e.contains(says), "{args:?}: {e}");
        }
        let c = parse(&[
            "--fps",
            "120",
            "--lost-timeout",
            "0.1",
            "--size",
            "1000x1000",
        ])
        .unwrap();
        assert_eq!(
            (c.fps, c.lost_timeout, c.size),
            (120, Some(0.1), Some((1000, 1000)))
        );
        let cfg = c.app_config(&FileConfig::default());
        assert_eq!(cfg.lost_timeout, 100_000);
    }
}
