//! Parameter metadata without hunting for it, and parameter look-ups at the prompt.
//!
//! `param meta fetch` downloads the target's published metadata (ArduPilot's `apm.pdef.xml` for
//! its vehicle type, the release's own when the autopilot reported an official version, else the
//! latest) through [`Effect::FetchParamMeta`]; the edge does the download and brings the bytes
//! back as [`Event::ParamMeta`](super::Event::ParamMeta). What parses is used at once and kept
//! in the cache directory ([`AppConfig::param_meta_cache`](super::AppConfig::param_meta_cache));
//! later, a vehicle of that type heard with no metadata loaded gets it from there
//! ([`Effect::ReadParamMeta`]).
//!
//! `param show NAME` (or a glob: `param show BATT_*`) lists values in the message log.

use std::path::PathBuf;
use std::sync::Arc;

use super::{App, Effect};
use crate::dialect::{MavAutopilot, MavMessage, MavType};
use crate::params::meta::MetaSet;
use crate::proto::vehicles::VehicleKey;
use crate::wire::Severity;

/// ArduPilot's published metadata, one tree per vehicle type (and a `versioned/` tree per
/// release).
pub const DEFAULT_URL: &str = "https://autotest.ardupilot.org/Parameters";

/// Values `param show` lists in the message log at most (the rest are counted).
pub const SHOW_MAX: usize = 40;

/// Metadata files are a few MB (Copter's is ~2.5 MB); more than this is not one.
pub const MAX_BYTES: u64 = 32 * 1024 * 1024;

/// A `param` command of this module.
#[derive(Debug, Clone, PartialEq)]
pub enum MetaCmd {
    /// `param meta fetch`.
    Fetch,
    /// `param show NAME|GLOB`.
    Show(String),
}

/// Where metadata bytes came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MetaOrigin {
    /// Downloaded from this URL (the one that answered).
    Url(String),
    /// Read from the cache.
    Cache,
}

/// The metadata loaded automatically or fetched, and the cache files already tried.
#[derive(Debug, Clone, Default)]
pub struct MetaState {
    /// The vehicle name (`ArduCopter`) of the metadata in use, when it came from here (not
    /// from `--param-meta`).
    pub loaded_for: Option<&'static str>,
    /// Each vehicle type's metadata read or fetched this run (at most one per type), so a
    /// target of another type switches to its own.
    sets: Vec<(&'static str, Arc<MetaSet>)>,
    /// Cache files asked for (each once a run).
    tried: Vec<&'static str>,
    /// A download is under way.
    pub fetching: bool,
}

/// Parse the words after `param` that this module takes (`None`: not one of them).
pub fn parse(rest: &str) -> Option<Result<MetaCmd, String>> {
    let mut words = rest.split_whitespace();
    match words.next()? {
        "show" => {
            let args: Vec<&str> = words.collect();
            Some(match args.as_slice() {
                [name] => Ok(MetaCmd::Show(name.to_string())),
                _ => Err("usage: param show NAME, or a pattern: param show BATT_*".into()),
            })
        }
        "meta" => Some(match words.collect::<Vec<_>>().as_slice() {
            ["fetch"] => Ok(MetaCmd::Fetch),
            _ => Err("usage: param meta fetch (download the target's parameter metadata)".into()),
        }),
        _ => None,
    }
}

/// Whether `name` matches `pattern`, case-insensitively: `*` any run, `?` one character; a
/// pattern without either is the whole name.
pub fn glob_matches(pattern: &str, name: &str) -> bool {
    let p: Vec<char> = pattern.to_ascii_uppercase().chars().collect();
    let n: Vec<char> = name.to_ascii_uppercase().chars().collect();
    // Iterative matcher with one backtrack point: linear in practice, never exponential.
    let (mut pi, mut ni) = (0, 0);
    let mut star: Option<(usize, usize)> = None;
    while ni < n.len() {
        if pi < p.len() && (p[pi] == '?' || p[pi] == n[ni]) {
            pi += 1;
            ni += 1;
        } else if pi < p.len() && p[pi] == '*' {
            star = Some((pi, ni));
            pi += 1;
        } else if let Some((sp, sn)) = star {
            pi = sp + 1;
            ni = sn + 1;
            star = Some((sp, sn + 1));
        } else {
            return false;
        }
    }
    p[pi..].iter().all(|c| *c == '*')
}

/// The firmware names [`ardupilot_vehicle`] gives.
const VEHICLES: [&str; 6] = [
    "ArduCopter",
    "ArduPlane",
    "Rover",
    "ArduSub",
    "AntennaTracker",
    "Blimp",
];

/// ArduPilot's name of a vehicle type's firmware, as its metadata tree names it
/// (`Parameters/ArduCopter/`), and as its `versioned/` tree does (`versioned/Copter/`).
pub fn ardupilot_vehicle(mavtype: MavType) -> Option<(&'static str, &'static str)> {
    use crate::proto::profile::ArduVehicle;
    Some(match ArduVehicle::of(mavtype)? {
        ArduVehicle::Copter => ("ArduCopter", "Copter"),
        ArduVehicle::Plane => ("ArduPlane", "Plane"),
        ArduVehicle::Rover => ("Rover", "Rover"),
        ArduVehicle::Sub => ("ArduSub", "Sub"),
        ArduVehicle::Tracker => ("AntennaTracker", "Tracker"),
        ArduVehicle::Blimp => ("Blimp", "Blimp"),
    })
}

/// The URLs to try for a vehicle's metadata, best first: the release's own (an official
/// `flight_sw_version` from AUTOPILOT_VERSION), then the latest. `base` is [`DEFAULT_URL`] or
/// its replacement.
pub fn metadata_urls(
    base: &str,
    vehicle: (&str, &str),
    flight_sw_version: Option<u32>,
) -> Vec<String> {
    let base = base.trim_end_matches('/');
    let mut out = Vec::new();
    // Major, minor, patch, then the version type: 255 is FIRMWARE_VERSION_TYPE_OFFICIAL.
    if let Some(v) = flight_sw_version.filter(|v| v & 0xFF == 255) {
        out.push(format!(
            "{base}/versioned/{}/stable-{}.{}.{}/apm.pdef.xml",
            vehicle.1,
            v >> 24,
            (v >> 16) & 0xFF,
            (v >> 8) & 0xFF
        ));
    }
    out.push(format!("{base}/{}/apm.pdef.xml", vehicle.0));
    out
}

/// The cache file of a vehicle's metadata in the cache directory.
pub fn cache_file(dir: &std::path::Path, vehicle: &str) -> PathBuf {
    dir.join("param-meta")
        .join(format!("{vehicle}.apm.pdef.xml"))
}

impl App {
    /// The target's autopilot, type and ArduPilot vehicle name.
    fn meta_vehicle(&self) -> Result<(MavAutopilot, (&'static str, &'static str)), String> {
        let key = self.target.ok_or("no target vehicle")?;
        let v = self.vehicles.get(key).ok_or("no target vehicle")?;
        match v.autopilot {
            MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA => ardupilot_vehicle(v.mavtype)
                .map(|n| (v.autopilot, n))
                .ok_or_else(|| {
                    format!(
                        "param meta fetch: ArduPilot publishes no metadata for a {}",
                        v.type_name()
                    )
                }),
            MavAutopilot::MAV_AUTOPILOT_PX4 => Err(
                "param meta fetch: PX4's metadata (component information) is not supported yet; use --param-meta FILE (PX4's parameters.xml)"
                    .into(),
            ),
            _ => Err(format!(
                "param meta fetch: no published metadata for a {} autopilot; use --param-meta FILE",
                v.autopilot_name()
            )),
        }
    }

    /// The target's official firmware version, from its AUTOPILOT_VERSION, if heard.
    fn target_sw_version(&self) -> Option<u32> {
        let key = self.target?;
        let e = self.inspector.get((key.0, key.1, 148))?;
        match e.decode(148).ok()? {
            MavMessage::AUTOPILOT_VERSION(a) => Some(a.flight_sw_version),
            _ => None,
        }
    }

    pub(super) fn run_param_meta(
        &mut self,
        cmd: MetaCmd,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        match cmd {
            MetaCmd::Show(pattern) => self.param_show(&pattern),
            MetaCmd::Fetch => {
                let (_, vehicle) = self.meta_vehicle()?;
                let dir = self
                    .cfg
                    .param_meta_cache
                    .clone()
                    .ok_or("param meta fetch: no cache directory (no home directory)")?;
                if self.meta.fetching {
                    return Err("param meta fetch: a download is under way".into());
                }
                let base = self
                    .cfg
                    .param_meta_url
                    .clone()
                    .unwrap_or_else(|| DEFAULT_URL.to_string());
                let urls = metadata_urls(&base, vehicle, self.target_sw_version());
                let shown = urls.first().cloned().unwrap_or_default();
                self.meta.fetching = true;
                fx.push(Effect::FetchParamMeta {
                    urls,
                    cache_path: cache_file(&dir, vehicle.0),
                });
                Ok(Some(format!("param meta fetch: downloading {shown}")))
            }
        }
    }

    /// `param show`: the target's values whose names match, in the message log.
    fn param_show(&mut self, pattern: &str) -> Result<Option<String>, String> {
        let (key, comp) = self.param_target()?;
        let set = self
            .param_set()
            .filter(|s| !s.params.is_empty())
            .ok_or_else(|| {
                format!(
                    "no parameters of {}:{comp} yet (param fetch asks for them)",
                    key.0
                )
            })?;
        let hits: Vec<String> = set
            .params
            .iter()
            .filter(|(n, _)| glob_matches(pattern, n))
            .map(|(n, p)| format!("{n} = {}", p.text()))
            .collect();
        if hits.is_empty() {
            return Err(format!("no parameter matches `{pattern}`"));
        }
        let source = Some(VehicleKey(key.0, comp));
        for h in hits.iter().take(SHOW_MAX) {
            self.notice(Severity::INFO, source, h.clone());
        }
        Ok(Some(match hits.len() {
            1 => hits[0].clone(),
            n if n > SHOW_MAX => {
                format!("{n} parameters match `{pattern}`: the first {SHOW_MAX} in the messages")
            }
            n => format!("{n} parameters match `{pattern}` (in the messages)"),
        }))
    }

    /// Metadata bytes the edge brought: used when they parse, and a download is kept in the
    /// cache.
    pub(super) fn on_param_meta(
        &mut self,
        origin: MetaOrigin,
        cache_path: PathBuf,
        result: Result<Vec<u8>, String>,
        fx: &mut Vec<Effect>,
    ) {
        if matches!(origin, MetaOrigin::Url(_)) {
            self.meta.fetching = false;
        }
        let vehicle = cache_path
            .file_name()
            .and_then(|n| n.to_str())
            .and_then(|n| n.strip_suffix(".apm.pdef.xml"))
            .and_then(|n| VEHICLES.iter().copied().find(|v| *v == n));
        let parsed = result.and_then(|bytes| {
            let meta = MetaSet::parse(&String::from_utf8_lossy(&bytes))
                .map_err(|e| format!("not parameter metadata: {e}"))?;
            Ok((meta, bytes))
        });
        let (severity, text) = match (origin, parsed) {
            (MetaOrigin::Url(url), Ok((meta, bytes))) => {
                let n = meta.len();
                self.use_meta(vehicle, meta);
                fx.push(Effect::WriteFile {
                    path: cache_path,
                    contents: bytes,
                });
                (
                    Severity::INFO,
                    format!("param meta fetch: {n} parameters described, from {url}"),
                )
            }
            (MetaOrigin::Url(_), Err(e)) => (Severity::ERROR, format!("param meta fetch: {e}")),
            (MetaOrigin::Cache, Ok((meta, _))) => {
                let n = meta.len();
                self.use_meta(vehicle, meta);
                (
                    Severity::INFO,
                    format!(
                        "parameter metadata: {n} parameters, from {}",
                        cache_path.display()
                    ),
                )
            }
            (MetaOrigin::Cache, Err(e)) => (
                Severity::ERROR,
                format!(
                    "parameter metadata {}: {e} (param meta fetch downloads it again)",
                    cache_path.display()
                ),
            ),
        };
        self.ui.message = Some((severity, text.clone()));
        self.notice(severity, None, text);
        self.dirty = true;
    }

    /// Use `meta` from now on, as `vehicle`'s.
    fn use_meta(&mut self, vehicle: Option<&'static str>, meta: MetaSet) {
        let meta = Arc::new(meta);
        self.cfg.param_meta = Some(meta.clone());
        self.meta.loaded_for = vehicle;
        if let Some(v) = vehicle {
            self.meta.sets.retain(|(n, _)| *n != v);
            self.meta.sets.push((v, meta));
        }
    }

    /// The target's cached metadata, asked for once when none is in use (or another vehicle
    /// type's cached one is) and `--param-meta` gave none.
    pub(super) fn poll_param_meta(&mut self, fx: &mut Vec<Effect>) {
        let Some(dir) = self.cfg.param_meta_cache.as_ref() else {
            return;
        };
        if self.cfg.param_meta.is_some() && self.meta.loaded_for.is_none() {
            return; // --param-meta, or the config directory's file
        }
        let Some(v) = self.target.and_then(|k| self.vehicles.get(k)) else {
            return;
        };
        if v.autopilot != MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA {
            return;
        }
        let Some((name, _)) = ardupilot_vehicle(v.mavtype) else {
            return;
        };
        if self.meta.loaded_for == Some(name) {
            return;
        }
        if let Some((_, set)) = self.meta.sets.iter().find(|(n, _)| *n == name) {
            self.cfg.param_meta = Some(set.clone());
            self.meta.loaded_for = Some(name);
            self.dirty = true;
            return;
        }
        if self.meta.tried.contains(&name) {
            return;
        }
        let path = cache_file(dir, name);
        self.meta.tried.push(name);
        fx.push(Effect::ReadParamMeta { path });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn globs_match_like_mavproxy() {
        assert!(glob_matches("BATT_*", "BATT_CAPACITY"));
        assert!(glob_matches("batt_*", "BATT_MONITOR"));
        assert!(!glob_matches("BATT_*", "BATT2_MONITOR"));
        assert!(glob_matches("BATT?_*", "BATT2_MONITOR"));
        assert!(glob_matches("*_P", "ATC_RAT_RLL_P"));
        assert!(glob_matches("ATC*RLL*", "ATC_RAT_RLL_P"));
        assert!(glob_matches("FRAME_CLASS", "frame_class"));
        assert!(!glob_matches("FRAME", "FRAME_CLASS"));
        assert!(glob_matches("*", "X"));
    }

    #[test]
    fn urls_follow_ardupilots_trees() {
        let base = "http://h/P/";
        let copter = ardupilot_vehicle(MavType::MAV_TYPE_QUADROTOR).unwrap();
        assert_eq!(
            metadata_urls(base, copter, None),
            ["http://h/P/ArduCopter/apm.pdef.xml"]
        );
        // 4.5.7 official: 0x040507FF.
        assert_eq!(
            metadata_urls(base, copter, Some(0x0405_07FF)),
            [
                "http://h/P/versioned/Copter/stable-4.5.7/apm.pdef.xml",
                "http://h/P/ArduCopter/apm.pdef.xml"
            ]
        );
        // A development build (type 0) has no versioned tree.
        assert_eq!(metadata_urls(base, copter, Some(0x0407_0000)).len(), 1);
        assert_eq!(
            ardupilot_vehicle(MavType::MAV_TYPE_GROUND_ROVER),
            Some(("Rover", "Rover"))
        );
        assert_eq!(
            ardupilot_vehicle(MavType::MAV_TYPE_SUBMARINE),
            Some(("ArduSub", "Sub"))
        );
        assert_eq!(ardupilot_vehicle(MavType::MAV_TYPE_GCS), None);
    }

    #[test]
    fn param_words_parse() {
        assert_eq!(
            parse("show BATT_*"),
            Some(Ok(MetaCmd::Show("BATT_*".into())))
        );
        assert_eq!(parse("meta fetch"), Some(Ok(MetaCmd::Fetch)));
        assert!(parse("meta").unwrap().is_err());
        assert!(parse("show").unwrap().is_err());
        assert_eq!(parse("fetch"), None);
        assert_eq!(parse("set A 1"), None);
    }
}
