//! `sim://?key=value&...` options, parsed into a [`SimConfig`].

use std::collections::BTreeMap;
use std::path::PathBuf;

/// Why the simulator could not be configured or served. Each message names the offending part.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    #[error("sim option `{key}`: unknown option; known options: {}", known_keys())]
    UnknownKey { key: String },
    #[error("sim option `{key}`: bad value `{value}`: {why}")]
    BadValue {
        key: String,
        value: String,
        why: String,
    },
    #[error("sim server: cannot listen on `{0}`: use tcp:ADDR:PORT, tcpin:ADDR:PORT, udpin:ADDR:PORT or udpout:HOST:PORT")]
    UnsupportedListen(String),
    #[error("sim server: cannot listen on {spec}: {source}")]
    Listen {
        spec: String,
        source: std::io::Error,
    },
    #[error("sim server: {0}")]
    Io(#[from] std::io::Error),
}

/// Every `sim://?` option: its name, an example value, and what it does. Listed by the
/// unknown-option error and by `mavterm sim --help`; a unit test parses every example.
pub const OPTIONS: &[(&str, &str, &str)] = &[
    (
        "vehicles",
        "3",
        "vehicles, 1 to 250, system ids sysid, sysid+1, ... [default: 1]",
    ),
    (
        "sysid",
        "10",
        "system id of the first vehicle, 1 to 254 [default: 1]",
    ),
    (
        "loss",
        "0.1",
        "probability (0 to 1) that a frame sent is lost",
    ),
    ("dup", "0.01", "probability that a frame sent is sent twice"),
    (
        "reorder",
        "0.02",
        "probability that a frame sent swaps with the next",
    ),
    (
        "corrupt",
        "0.001",
        "probability that a frame sent has a bit flipped (a CRC error)",
    ),
    ("latency_ms", "50", "one-way delay of every frame, in ms"),
    ("seed", "7", "seed of every random choice [default: 1]"),
    (
        "params",
        "1300",
        "parameters, 0 to 65534 [default: 0, the real ArduCopter set of 1,354]",
    ),
    (
        "baud",
        "57600",
        "a radio link: paces bytes, PARAM_VALUE and MAVFTP as on a UART",
    ),
    (
        "state",
        "FILE",
        "parameter store, loaded at start and rewritten after each PARAM_SET",
    ),
    (
        "impair_in",
        "1",
        "apply loss and corruption to the bytes from the GCS too",
    ),
    (
        "drop_cmd",
        "512:2,400:1",
        "ignore the first N copies of command ID (ID:N,...): tests resends",
    ),
    (
        "drop_ack",
        "42429:1",
        "lose the ACKs of the first N copies of command ID (it still acts)",
    ),
    ("ftp", "0", "a firmware without MAVFTP"),
    (
        "mission_boot_ms",
        "2000",
        "refuse mission uploads for the first MS ms, as a booting ArduCopter",
    ),
    (
        "camera",
        "1",
        "a camera on each vehicle (compid 100: image, video, survey; a gimbal)",
    ),
    (
        "camera_drop",
        "3",
        "lose the camera's first CAMERA_IMAGE_CAPTURED for image N",
    ),
    (
        "gimbal",
        "0",
        "ArduPilot's mount on each autopilot, device 1 [default: as camera]",
    ),
    (
        "logs",
        "5",
        "onboard logs each vehicle has, 0 to 500 [default: 3]",
    ),
    (
        "log_size",
        "200000",
        "bytes of the newest onboard log (older ones smaller) [default: 60000]",
    ),
    (
        "sr",
        "4",
        "streams from boot, every group at N Hz, unasked (SRn_ set) [default: 0]",
    ),
    (
        "uncal",
        "1",
        "accelerometers and compasses not calibrated: pre-arm fails until they are",
    ),
    (
        "adsb",
        "3",
        "ADS-B aircraft on straight tracks, 0 to 50 (SIM_ADSB_COUNT) [default: 0]",
    ),
    (
        "adsb_radius",
        "5000",
        "metres from home they fly within (SIM_ADSB_RADIUS) [default: 10000]",
    ),
    (
        "adsb_alt",
        "300",
        "their altitude above home, metres (SIM_ADSB_ALT) [default: 1000]",
    ),
];

/// The option names, comma-separated, for messages.
pub fn known_keys() -> String {
    OPTIONS
        .iter()
        .map(|(k, _, _)| *k)
        .collect::<Vec<_>>()
        .join(", ")
}

/// `mavterm sim --help`'s list of options: `NAME=EXAMPLE`, then what it does on the next line
/// (short enough for an 80-column terminal).
pub fn options_help() -> String {
    let mut out = String::from("Options (--options, or sim://?NAME=VALUE&...):\n");
    for (k, v, what) in OPTIONS {
        out.push_str(&format!("  {k}={v}\n      {what}\n"));
    }
    out.push_str(
        "\nExamples:\n  mavterm sim --listen tcp:127.0.0.1:5760\n  \
         mavterm sim --listen udpout:127.0.0.1:14550 --vehicles 3 --options \"loss=0.1&seed=7\"\n  \
         mavterm --link \"sim://?vehicles=2&camera=1\"",
    );
    out
}

/// How many vehicles, which ids, and how bad the simulated link is.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// Number of vehicles, 1..=250; vehicle i has sysid `sysid + i`.
    pub vehicles: u8,
    /// System id of the first vehicle.
    pub sysid: u8,
    /// Probability that an outgoing frame is dropped.
    pub loss: f64,
    /// Probability that an outgoing frame is sent twice.
    pub dup: f64,
    /// Probability that an outgoing frame is swapped with the one after it.
    pub reorder: f64,
    /// Probability that one bit of an outgoing frame is flipped (the receiver sees a CRC error).
    pub corrupt: f64,
    /// One-way delay added to every frame.
    pub latency_ms: u64,
    /// Seed of every random choice the simulator makes.
    pub seed: u64,
    /// Parameter count: 0 = the real ArduCopter set; more pads with extra names, fewer truncates.
    pub params: usize,
    /// Radio byte rate (10 bits per byte); `None` = unlimited.
    pub baud: Option<u32>,
    /// Parameter store: loaded at start if present, rewritten after each PARAM_SET.
    pub state: Option<PathBuf>,
    /// Also apply loss/corruption to bytes coming from the GCS.
    pub impair_in: bool,
    /// `drop_cmd=ID:N,...`: each vehicle silently ignores (no ACK, no effect) the first N
    /// COMMAND_LONG / COMMAND_INT it receives with command id ID, as if they were lost on the
    /// way, so a GCS's resends can be tested deterministically.
    pub drop_cmd: BTreeMap<u16, u32>,
    /// `drop_ack=ID:N,...`: each vehicle carries out the first N COMMAND_LONG / COMMAND_INT
    /// with command id ID but their COMMAND_ACKs are lost on the way back, so a GCS's handling
    /// of a lost answer can be tested deterministically.
    pub drop_ack: BTreeMap<u16, u32>,
    /// `ftp=0`: a firmware built without MAVFTP (`AP_MAVLINK_FTP_ENABLED` 0): FILE_TRANSFER_PROTOCOL
    /// goes unanswered and AUTOPILOT_VERSION does not announce MAV_PROTOCOL_CAPABILITY_FTP.
    pub ftp: bool,
    /// `mission_boot_ms=N`: for the first N ms after boot the mission storage is not ready, so
    /// a mission upload is refused with MISSION_ACK NO_SPACE and "Only 0 items are supported",
    /// as a real ArduCopter answers a GCS that uploads while it is still booting. 0 (default):
    /// the simulated boot is instantaneous, so no such window.
    pub mission_boot_ms: u64,
    /// `camera=1`: each vehicle has a camera component (compid 100, [`super::camera`]).
    pub camera: bool,
    /// `camera_drop=N`: the camera's first CAMERA_IMAGE_CAPTURED of image N is lost.
    pub camera_drop: Option<i32>,
    /// `gimbal=1`: each autopilot has a mount (AP_Mount, gimbal manager on its own component,
    /// [`super::gimbal`]); `None`: as `camera` (a camera on a gimbal), `gimbal=0` none.
    pub gimbal: Option<bool>,
    /// `logs=N`: onboard logs each vehicle has ([`super::logs`]).
    pub logs: u16,
    /// `log_size=BYTES`: the newest log's size; log `i` of `n` is `i/n` of it.
    pub log_size: u32,
    /// `sr=N`: every stream group at N Hz from boot without being asked, as ArduPilot does with
    /// its `SRn_` rates set (0: off until a GCS asks, the default).
    pub sr: u16,
    /// `uncal=1`: a vehicle fresh from the box: its accelerometers and compasses are not
    /// calibrated, so its pre-arm checks fail (and SYS_STATUS reports the pre-arm bit) until
    /// they are ([`super::calibration`]).
    pub uncal: bool,
    /// `adsb=N`: N ADS-B aircraft ([`super::adsb`]), forwarded by the first vehicle.
    pub adsb: u8,
    /// `adsb_radius=M`: they fly within M metres of home.
    pub adsb_radius: f64,
    /// `adsb_alt=M`: their altitude above home.
    pub adsb_alt: f64,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            vehicles: 1,
            sysid: 1,
            loss: 0.0,
            dup: 0.0,
            reorder: 0.0,
            corrupt: 0.0,
            latency_ms: 0,
            seed: 1,
            params: 0,
            baud: None,
            state: None,
            impair_in: false,
            drop_cmd: BTreeMap::new(),
            drop_ack: BTreeMap::new(),
            ftp: true,
            mission_boot_ms: 0,
            camera: false,
            camera_drop: None,
            gimbal: None,
            logs: 3,
            log_size: 60_000,
            sr: 0,
            uncal: false,
            adsb: 0,
            adsb_radius: super::adsb::DEFAULT_RADIUS_M,
            adsb_alt: super::adsb::DEFAULT_ALT_M,
        }
    }
}

fn bad(key: &str, value: &str, why: impl Into<String>) -> SimError {
    SimError::BadValue {
        key: key.to_string(),
        value: value.to_string(),
        why: why.into(),
    }
}

fn prob(key: &str, value: &str) -> Result<f64, SimError> {
    let p: f64 = value
        .parse()
        .map_err(|_| bad(key, value, "expected a probability from 0 to 1"))?;
    if !(0.0..=1.0).contains(&p) {
        return Err(bad(key, value, "expected a probability from 0 to 1"));
    }
    Ok(p)
}

/// `drop_cmd=ID:N[,ID:N...]` (and `drop_ack`): command id (0..=65535) and how many of its
/// first copies (or their ACKs) to drop (1 or more); each id at most once.
fn drop_list(key: &str, value: &str) -> Result<BTreeMap<u16, u32>, SimError> {
    const SYNTAX: &str = "expected COMMAND_ID:COUNT[,COMMAND_ID:COUNT...], e.g. 512:2,400:1";
    let mut map = BTreeMap::new();
    if value.is_empty() {
        return Err(bad(key, value, SYNTAX));
    }
    for item in value.split(',') {
        let Some((id, n)) = item.split_once(':') else {
            return Err(bad(key, value, format!("`{item}`: {SYNTAX}")));
        };
        let id: u16 = id.trim().parse().map_err(|_| {
            bad(
                key,
                value,
                format!("`{item}`: command id must be a number from 0 to 65535"),
            )
        })?;
        let n: u32 = n.trim().parse().map_err(|_| {
            bad(
                key,
                value,
                format!("`{item}`: count must be a whole number from 1"),
            )
        })?;
        if n == 0 {
            return Err(bad(
                key,
                value,
                format!("`{item}`: count must be a whole number from 1"),
            ));
        }
        if map.insert(id, n).is_some() {
            return Err(bad(key, value, format!("command {id} listed twice")));
        }
    }
    Ok(map)
}

fn flag(key: &str, value: &str) -> Result<bool, SimError> {
    match value {
        "" | "1" | "true" | "yes" => Ok(true),
        "0" | "false" | "no" => Ok(false),
        _ => Err(bad(key, value, "expected true or false")),
    }
}

fn num<T: std::str::FromStr>(key: &str, value: &str, what: &str) -> Result<T, SimError> {
    value
        .parse()
        .map_err(|_| bad(key, value, format!("expected {what}")))
}

impl SimConfig {
    /// Parse the text after `sim://?`. An empty string gives the defaults. A leading `?` is
    /// tolerated. Keys may repeat; the last one wins.
    pub fn from_query(q: &str) -> Result<SimConfig, SimError> {
        let mut c = SimConfig::default();
        let q = q.strip_prefix('?').unwrap_or(q);
        for part in q.split('&').filter(|p| !p.is_empty()) {
            let (key, value) = part.split_once('=').unwrap_or((part, ""));
            match key {
                "vehicles" => {
                    let n: u8 = num(key, value, "a number of vehicles from 1 to 250")?;
                    if n == 0 || n > 250 {
                        return Err(bad(
                            key,
                            value,
                            "expected a number of vehicles from 1 to 250",
                        ));
                    }
                    c.vehicles = n;
                }
                "sysid" => {
                    let n: u8 = num(key, value, "a system id from 1 to 254")?;
                    if n == 0 || n == 255 {
                        return Err(bad(key, value, "expected a system id from 1 to 254"));
                    }
                    c.sysid = n;
                }
                "loss" => c.loss = prob(key, value)?,
                "dup" => c.dup = prob(key, value)?,
                "reorder" => c.reorder = prob(key, value)?,
                "corrupt" => c.corrupt = prob(key, value)?,
                "latency_ms" => c.latency_ms = num(key, value, "milliseconds (a whole number)")?,
                "seed" => c.seed = num(key, value, "an unsigned 64-bit number")?,
                "params" => {
                    let n: usize = num(key, value, "a parameter count from 0 to 65534")?;
                    if n > 65_534 {
                        return Err(bad(
                            key,
                            value,
                            "expected a parameter count from 0 to 65534",
                        ));
                    }
                    c.params = n;
                }
                "baud" => {
                    let b: u32 = num(key, value, "a positive baud rate")?;
                    if b == 0 {
                        return Err(bad(key, value, "expected a positive baud rate"));
                    }
                    c.baud = Some(b);
                }
                "state" => {
                    if value.is_empty() {
                        return Err(bad(key, value, "expected a file path"));
                    }
                    c.state = Some(PathBuf::from(value));
                }
                "drop_cmd" => c.drop_cmd = drop_list(key, value)?,
                "drop_ack" => c.drop_ack = drop_list(key, value)?,
                "impair_in" => c.impair_in = flag(key, value)?,
                "ftp" => c.ftp = flag(key, value)?,
                "mission_boot_ms" => {
                    c.mission_boot_ms = num(key, value, "milliseconds (a whole number)")?
                }
                "camera" => c.camera = flag(key, value)?,
                "logs" => {
                    let n: u16 = num(key, value, "a log count from 0 to 500")?;
                    if n > 500 {
                        return Err(bad(key, value, "expected a log count from 0 to 500"));
                    }
                    c.logs = n;
                }
                "log_size" => c.log_size = num(key, value, "bytes (a whole number)")?,
                "adsb" => {
                    let n: u8 = num(key, value, "a number of aircraft from 0 to 50")?;
                    if n > super::adsb::MAX {
                        return Err(bad(
                            key,
                            value,
                            "expected a number of aircraft from 0 to 50",
                        ));
                    }
                    c.adsb = n;
                }
                "adsb_radius" => {
                    let m: f64 = num(key, value, "metres from 100 to 100000")?;
                    if !(100.0..=100_000.0).contains(&m) {
                        return Err(bad(key, value, "expected metres from 100 to 100000"));
                    }
                    c.adsb_radius = m;
                }
                "adsb_alt" => {
                    let m: f64 = num(key, value, "metres from -500 to 20000")?;
                    if !(-500.0..=20_000.0).contains(&m) {
                        return Err(bad(key, value, "expected metres from -500 to 20000"));
                    }
                    c.adsb_alt = m;
                }
                "gimbal" => c.gimbal = Some(flag(key, value)?),
                "sr" => {
                    let hz: u16 = num(key, value, "a rate in Hz from 0 to 50")?;
                    if hz > 50 {
                        return Err(bad(key, value, "expected a rate in Hz from 0 to 50"));
                    }
                    c.sr = hz;
                }
                "uncal" => c.uncal = flag(key, value)?,
                "camera_drop" => {
                    c.camera_drop = Some(
                        value
                            .parse::<u16>()
                            .map_err(|_| bad(key, value, "expected an image index (0 to 65535)"))?
                            as i32,
                    )
                }
                _ => {
                    return Err(SimError::UnknownKey {
                        key: key.to_string(),
                    })
                }
            }
        }
        if c.sysid as usize + c.vehicles as usize - 1 > 254 {
            return Err(bad(
                "vehicles",
                &c.vehicles.to_string(),
                format!(
                    "sysid {} + {} vehicles would pass system id 254",
                    c.sysid, c.vehicles
                ),
            ));
        }
        Ok(c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_listed_option_parses_its_example_and_changes_the_config() {
        for (key, example, _) in OPTIONS {
            let c = SimConfig::from_query(&format!("{key}={example}"))
                .unwrap_or_else(|e| panic!("{key}={example}: {e}"));
            assert_ne!(c, SimConfig::default(), "{key}={example} changes nothing");
        }
        let e = SimConfig::from_query("wind=3").unwrap_err().to_string();
        assert!(e.contains("`wind`"), "{e}");
        for (key, _, _) in OPTIONS {
            assert!(e.contains(key), "{key} not listed: {e}");
        }
        let help = options_help();
        for (key, example, what) in OPTIONS {
            assert!(
                help.contains(&format!("\n  {key}={example}\n      {what}\n")),
                "{help}"
            );
            assert!(6 + what.chars().count() <= 80, "{key}: fits 80 columns");
        }
    }

    #[test]
    fn empty_query_is_default() {
        assert_eq!(SimConfig::from_query("").unwrap(), SimConfig::default());
        assert_eq!(SimConfig::from_query("?").unwrap(), SimConfig::default());
    }

    #[test]
    fn full_query_parses() {
        let c = SimConfig::from_query(
            "vehicles=3&sysid=1&loss=0.1&dup=0.01&reorder=0.02&corrupt=0.001&latency_ms=50&seed=7&params=1300&baud=57600&state=/tmp/x.parm",
        )
        .unwrap();
        assert_eq!(c.vehicles, 3);
        assert_eq!(c.loss, 0.1);
        assert_eq!(c.dup, 0.01);
        assert_eq!(c.reorder, 0.02);
        assert_eq!(c.corrupt, 0.001);
        assert_eq!(c.latency_ms, 50);
        assert_eq!(c.seed, 7);
        assert_eq!(c.params, 1300);
        assert_eq!(c.baud, Some(57600));
        assert_eq!(c.state, Some(PathBuf::from("/tmp/x.parm")));
    }

    #[test]
    fn drop_cmd_parses_ids_and_counts() {
        let c = SimConfig::from_query("drop_cmd=512:2,400:1&drop_ack=42429:1").unwrap();
        assert_eq!(c.drop_cmd, BTreeMap::from([(512, 2), (400, 1)]));
        assert_eq!(c.drop_ack, BTreeMap::from([(42429, 1)]));
        assert!(SimConfig::default().drop_cmd.is_empty());
        let e = SimConfig::from_query("drop_cmd=512")
            .unwrap_err()
            .to_string();
        assert!(e.contains("COMMAND_ID:COUNT"), "{e}");
        let e = SimConfig::from_query("drop_cmd=512:2,x:1")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`x:1`") && e.contains("command id"), "{e}");
        let e = SimConfig::from_query("drop_cmd=400:0")
            .unwrap_err()
            .to_string();
        assert!(e.contains("count"), "{e}");
    }

    #[test]
    fn ftp_switch() {
        assert!(SimConfig::default().ftp);
        assert!(!SimConfig::from_query("ftp=0").unwrap().ftp);
        assert!(!SimConfig::from_query("ftp=false").unwrap().ftp);
        assert!(SimConfig::from_query("ftp=1").unwrap().ftp);
        assert!(SimConfig::from_query("ftp=0&ftp=yes").unwrap().ftp);
        let e = SimConfig::from_query("ftp=2").unwrap_err().to_string();
        assert!(e.contains("`ftp`") && e.contains("true or false"), "{e}");
        let e = SimConfig::from_query("ftpx=0").unwrap_err().to_string();
        assert!(e.contains("ftp"), "known keys listed: {e}");
    }

    #[test]
    fn mission_boot_window() {
        assert_eq!(SimConfig::default().mission_boot_ms, 0);
        let c = SimConfig::from_query("mission_boot_ms=2500").unwrap();
        assert_eq!(c.mission_boot_ms, 2500);
    }

    #[test]
    fn errors_name_the_key() {
        for (q, key) in [
            ("bogus=1", "bogus"),
            ("loss=2", "loss"),
            ("loss=abc", "loss"),
            ("vehicles=0", "vehicles"),
            ("vehicles=999", "vehicles"),
            ("sysid=255", "sysid"),
            ("baud=0", "baud"),
            ("seed=-1", "seed"),
            ("latency_ms=1.5", "latency_ms"),
            ("sysid=250&vehicles=10", "vehicles"),
            ("state=", "state"),
            ("drop_cmd=", "drop_cmd"),
            ("drop_cmd=512", "drop_cmd"),
            ("drop_cmd=512:", "drop_cmd"),
            ("drop_cmd=abc:1", "drop_cmd"),
            ("drop_cmd=70000:1", "drop_cmd"),
            ("drop_cmd=512:0", "drop_cmd"),
            ("drop_cmd=512:-1", "drop_cmd"),
            ("drop_cmd=512:1,,400:1", "drop_cmd"),
            ("drop_cmd=512:1,512:2", "drop_cmd"),
            ("ftp=2", "ftp"),
            ("ftp=off", "ftp"),
            ("mission_boot_ms=-1", "mission_boot_ms"),
            ("mission_boot_ms=1.5", "mission_boot_ms"),
        ] {
            let e = SimConfig::from_query(q).unwrap_err().to_string();
            assert!(e.contains(&format!("`{key}`")), "{q}: {e}");
        }
    }
}
