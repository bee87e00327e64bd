//! Command-line options.

use std::path::PathBuf;

use clap::{Parser, Subcommand, ValueEnum};

use crate::app::AppConfig;
use crate::config::{seconds_to_micros, FileConfig};
use crate::link::LinkSpec;

/// A terminal ground-control station for MAVLink vehicles.
#[derive(Debug, Parser)]
#[command(name = "mavterm", version, about)]
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
    /// asked to the link.
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
    #[arg(long, value_name = "SECONDS", value_parser = parse_duration)]
    pub lost_timeout: Option<f64>,

    /// Run without a terminal.
    #[arg(long)]
    pub headless: bool,

    /// Headless: how long to run before reporting [default: to the end of the tlog: replays,
    /// else 10 s].
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

    /// Parameter metadata: ArduPilot's `apm.pdef.xml` or PX4's `parameters.xml` (default:
    /// `param-meta.xml` in mavterm's config directory, when there is one).
    #[arg(long, value_name = "FILE")]
    pub param_meta: Option<PathBuf>,

    /// Headless: replay recorded input (keys, snapshots) from FILE.
    #[arg(long, value_name = "FILE")]
    pub input: Option<PathBuf>,

    /// Headless: screen size for replay, WIDTHxHEIGHT.
    #[arg(long, value_name = "WxH", default_value = "120x40", value_parser = parse_size)]
    pub size: (u16, u16),

    /// Headless: directory for `snapshot NAME` screens (default: stdout).
    #[arg(long, value_name = "DIR")]
    pub screens: Option<PathBuf>,

    /// Key bindings to layer over the defaults.
    #[arg(long, value_name = "FILE")]
    pub keymap: Option<PathBuf>,

    /// Highest redraw rate of the terminal UI.
    #[arg(long, default_value_t = 10)]
    pub fps: u32,

    /// Terminal UI: record the keys typed, in the replay format, to FILE.
    #[arg(long, value_name = "FILE")]
    pub record: Option<PathBuf>,

    /// Write the log (tracing) to FILE.
    #[arg(long, value_name = "FILE")]
    pub log: Option<PathBuf>,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Serve simulated vehicle(s) to any GCS, in real time, until Ctrl-C.
    Sim {
        /// Where to serve: tcp:ADDR:PORT (listen), udpin:ADDR:PORT, udpout:HOST:PORT.
        #[arg(long, value_parser = parse_spec)]
        listen: LinkSpec,
        /// Number of vehicles (sysid 1, 2, ...).
        #[arg(long)]
        vehicles: Option<u8>,
        /// More sim options, as in sim://?OPTIONS (e.g. "loss=0.1&seed=7").
        #[arg(long, default_value = "")]
        options: String,
    },
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
            cfg.lost_timeout = seconds_to_micros(s.max(0.1));
        }
        cfg
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

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ReportFormat {
    Json,
}

fn parse_spec(s: &str) -> Result<LinkSpec, String> {
    s.parse::<LinkSpec>().map_err(|e| e.to_string())
}

/// Seconds: a finite number from 0 to a year.
fn parse_duration(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && (0.0..=31_536_000.0).contains(&v) => Ok(v),
        _ => Err(format!(
            "`{s}` is not a number of seconds from 0 to 31536000"
        )),
    }
}

fn parse_size(s: &str) -> Result<(u16, u16), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("size `{s}`: expected WIDTHxHEIGHT, e.g. 120x40"))?;
    let w: u16 = w
        .parse()
        .map_err(|_| format!("size `{s}`: width `{w}` is not a number"))?;
    let h: u16 = h
        .parse()
        .map_err(|_| format!("size `{s}`: height `{h}` is not a number"))?;
    if w == 0 || h == 0 {
        return Err(format!("size `{s}`: width and height must be at least 1"));
    }
    Ok((w, h))
}
