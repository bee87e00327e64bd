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
//! **PX4** (and any autopilot that is not ArduPilot) says where its metadata is itself, by the
//! component metadata protocol ([`crate::proto::comp_meta`]): automatically once a PX4 vehicle
//! is heard (as QGroundControl does at connect), and on `param meta fetch`. The vehicle's
//! COMPONENT_METADATA carries the CRC of its general metadata file, which keys the cache
//! (`component-CRC.parameters.json`, the inflated `parameters.json`): a vehicle whose CRC has a
//! cached file is not read again. Otherwise its files come over MAVLink FTP (or HTTPS where the
//! general file says so), are inflated (xz, bounded by [`MAX_JSON`]) and read
//! ([`MetaSet::parse_px4_json`]) into the same metadata ArduPilot's XML gives.
//!
//! `param show NAME` (or a glob: `param show BATT_*`) lists values in the message log.

use std::path::PathBuf;
use std::sync::Arc;

use super::{App, Effect};
use crate::dialect::{MavAutopilot, MavMessage, MavType};
use crate::params::meta::{inflate, MetaSet, MAX_JSON};
use crate::proto::comp_meta::CompMetaEvent;
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
    /// The cache has no such file.
    Missing,
}

/// Which metadata a set is: an ArduPilot vehicle's (`ArduCopter`), or the one a vehicle
/// announced by the component metadata protocol (its general file's CRC).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MetaKey {
    ArduPilot(&'static str),
    Component(u32),
}

/// The metadata loaded automatically or fetched, and the cache files already tried.
#[derive(Debug, Clone, Default)]
pub struct MetaState {
    /// Which metadata is in use, when it came from here (not from `--param-meta`).
    pub loaded_for: Option<MetaKey>,
    /// Each vehicle type's metadata read or fetched this run (at most one per type), so a
    /// target of another type switches to its own.
    sets: Vec<(MetaKey, Arc<MetaSet>)>,
    /// Cache files asked for (each once a run).
    tried: Vec<&'static str>,
    /// A download is under way.
    pub fetching: bool,
    /// The general file CRC each vehicle announced (component metadata).
    announced: Vec<(VehicleKey, u32)>,
    /// Cache reads of component metadata under way: for which vehicle, which CRC.
    comp_reads: Vec<(VehicleKey, u32)>,
    /// The vehicle whose component metadata the operator asked for (`param meta fetch`).
    comp_fetch: Option<VehicleKey>,
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

/// The cache file of the parameter metadata a vehicle announced with this general file CRC
/// (a bare name when there is no cache directory: then it is never written).
pub fn component_cache_file(dir: Option<&std::path::Path>, crc: u32) -> PathBuf {
    let name = format!("component-{crc:08x}.parameters.json");
    match dir {
        Some(d) => d.join("param-meta").join(name),
        None => PathBuf::from(name),
    }
}

/// The CRC a [`component_cache_file`] is named after.
pub fn component_crc(path: &std::path::Path) -> Option<u32> {
    let n = path.file_name()?.to_str()?;
    let hex = n
        .strip_prefix("component-")?
        .strip_suffix(".parameters.json")?;
    (hex.len() == 8).then(|| u32::from_str_radix(hex, 16).ok())?
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
            _ => Err(format!(
                "param meta fetch: no published metadata for a {} autopilot; use --param-meta FILE",
                v.autopilot_name()
            )),
        }
    }

    /// `param meta fetch` for an autopilot that is not ArduPilot: ask it by the component
    /// metadata protocol.
    fn fetch_component_meta(&mut self, fx: &mut Vec<Effect>) -> Result<Option<String>, String> {
        let key = self.target.ok_or("no target vehicle")?;
        let now = self.now;
        let s = self
            .sessions
            .get_mut(&key)
            .ok_or_else(|| format!("{key} has no session"))?;
        s.comp_meta
            .start(true)
            .map_err(|e| format!("param meta fetch: {e}"))?;
        self.meta.comp_fetch = Some(key);
        let out = s.poll(now);
        self.session_out(key, out, fx);
        Ok(Some(format!(
            "param meta fetch: asking {key} for its parameter metadata (component metadata protocol)"
        )))
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
                let autopilot = self
                    .target
                    .and_then(|k| self.vehicles.get(k))
                    .map(|v| v.autopilot)
                    .ok_or("no target vehicle")?;
                if autopilot != MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA {
                    return self.fetch_component_meta(fx);
                }
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
        if let Some(crc) = component_crc(&cache_path) {
            return self.on_component_bytes(origin, crc, cache_path, result, fx);
        }
        if origin == MetaOrigin::Missing {
            return; // no cached copy: nothing to tell
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
                self.use_meta(vehicle.map(MetaKey::ArduPilot), meta);
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
            (MetaOrigin::Cache | MetaOrigin::Missing, Ok((meta, _))) => {
                let n = meta.len();
                self.use_meta(vehicle.map(MetaKey::ArduPilot), meta);
                (
                    Severity::INFO,
                    format!(
                        "parameter metadata: {n} parameters, from {}",
                        cache_path.display()
                    ),
                )
            }
            (MetaOrigin::Cache | MetaOrigin::Missing, Err(e)) => (
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
    fn use_meta(&mut self, vehicle: Option<MetaKey>, meta: MetaSet) {
        let meta = Arc::new(meta);
        self.cfg.param_meta = Some(meta.clone());
        self.meta.loaded_for = vehicle;
        if let Some(v) = vehicle {
            self.meta.sets.retain(|(n, _)| *n != v);
            self.meta.sets.push((v, meta));
        }
    }

    /// Tell of component metadata: on the status bar when the operator asked for it (or it
    /// failed), always in the messages.
    fn comp_notice(&mut self, key: VehicleKey, severity: Severity, text: String, status: bool) {
        if status {
            self.ui.message = Some((severity, text.clone()));
        }
        self.notice(severity, Some(key), text);
        self.dirty = true;
    }

    /// The session of `key` reads its announced metadata from the vehicle after all.
    fn comp_download(&mut self, key: VehicleKey, fx: &mut Vec<Effect>) {
        let now = self.now;
        let Some(s) = self.sessions.get_mut(&key) else {
            return;
        };
        let mut buf = Vec::new();
        s.comp_meta.download(now, &mut buf);
        let mut out = Vec::new();
        s.deliver(now, &mut buf, &mut out);
        self.session_out(key, out, fx);
    }

    fn comp_finish(&mut self, key: VehicleKey) {
        if let Some(s) = self.sessions.get_mut(&key) {
            s.comp_meta.finish();
        }
    }

    /// What the component metadata machine of `key` has to tell.
    pub(super) fn on_comp_meta(&mut self, key: VehicleKey, e: CompMetaEvent, fx: &mut Vec<Effect>) {
        let asked = self.meta.comp_fetch == Some(key);
        match e {
            CompMetaEvent::Announced { crc, uri } => {
                self.meta.announced.retain(|(k, _)| *k != key);
                self.meta.announced.push((key, crc));
                if !asked && self.cfg.param_meta.is_some() && self.meta.loaded_for.is_none() {
                    // --param-meta (or the configuration's file) stands.
                    return self.comp_finish(key);
                }
                if let Some((_, set)) = self
                    .meta
                    .sets
                    .iter()
                    .find(|(k, _)| *k == MetaKey::Component(crc))
                {
                    let (set, n) = (set.clone(), set.len());
                    if self.target == Some(key) {
                        self.cfg.param_meta = Some(set);
                        self.meta.loaded_for = Some(MetaKey::Component(crc));
                    }
                    self.comp_finish(key);
                    if asked {
                        self.meta.comp_fetch = None;
                        self.comp_notice(
                            key,
                            Severity::INFO,
                            format!("param meta fetch: {n} parameters described (loaded already; {key}'s metadata CRC {crc:08x} is unchanged)"),
                            true,
                        );
                    }
                    return;
                }
                match self.cfg.param_meta_cache.clone() {
                    Some(dir) => {
                        self.meta.comp_reads.retain(|(k, _)| *k != key);
                        self.meta.comp_reads.push((key, crc));
                        fx.push(Effect::ReadParamMeta {
                            path: component_cache_file(Some(&dir), crc),
                        });
                    }
                    None => self.comp_download(key, fx),
                }
                if asked {
                    self.ui.message = Some((
                        Severity::INFO,
                        format!("param meta fetch: {key} announces {uri}"),
                    ));
                }
            }
            CompMetaEvent::ParamFile { crc, source, bytes } => {
                let parsed = inflate(&source, &bytes, MAX_JSON)
                    .and_then(|json| MetaSet::parse_px4_json(&json).map(|m| (m, json)));
                self.meta.comp_fetch = self.meta.comp_fetch.filter(|k| *k != key);
                match parsed {
                    Ok((meta, json)) => self.comp_loaded(key, crc, meta, json, &source, asked, fx),
                    Err(e) => self.comp_notice(
                        key,
                        Severity::ERROR,
                        format!("parameter metadata from {key}: {e}"),
                        true,
                    ),
                }
            }
            CompMetaEvent::Fetch { crc, urls } => {
                let dir = self.cfg.param_meta_cache.clone();
                self.meta.fetching = true;
                let shown = urls.first().cloned().unwrap_or_default();
                fx.push(Effect::FetchParamMeta {
                    urls,
                    cache_path: component_cache_file(dir.as_deref(), crc),
                });
                self.meta.comp_reads.retain(|(k, _)| *k != key);
                self.meta.comp_reads.push((key, crc));
                if asked {
                    self.ui.message = Some((
                        Severity::INFO,
                        format!("param meta fetch: downloading {shown}"),
                    ));
                }
            }
            CompMetaEvent::Failed { why, operator } => {
                self.meta.comp_fetch = self.meta.comp_fetch.filter(|k| *k != key);
                if operator {
                    self.comp_notice(
                        key,
                        Severity::ERROR,
                        format!("param meta fetch: {why}; --param-meta FILE loads a file instead"),
                        true,
                    );
                } else {
                    self.comp_notice(
                        key,
                        Severity::WARNING,
                        format!("parameter metadata from the vehicle: {why} (param meta fetch tries again)"),
                        false,
                    );
                }
            }
        }
    }

    /// Component metadata read and parsed: used, and kept in the cache.
    #[allow(clippy::too_many_arguments)]
    fn comp_loaded(
        &mut self,
        key: VehicleKey,
        crc: u32,
        meta: MetaSet,
        json: Vec<u8>,
        source: &str,
        asked: bool,
        fx: &mut Vec<Effect>,
    ) {
        let n = meta.len();
        let dir = self.cfg.param_meta_cache.clone();
        if self.target == Some(key) || self.cfg.param_meta.is_none() {
            self.use_meta(Some(MetaKey::Component(crc)), meta);
        } else {
            self.meta
                .sets
                .retain(|(k, _)| *k != MetaKey::Component(crc));
            self.meta
                .sets
                .push((MetaKey::Component(crc), Arc::new(meta)));
        }
        if let Some(dir) = dir {
            fx.push(Effect::WriteFile {
                path: component_cache_file(Some(&dir), crc),
                contents: json,
            });
        }
        let text = if asked {
            format!("param meta fetch: {n} parameters described, from {source}")
        } else {
            format!("parameter metadata: {n} parameters described, from {key}'s {source}")
        };
        self.comp_notice(key, Severity::INFO, text, true);
    }

    /// Component metadata bytes the edge brought: the cached copy (or none), or a download.
    fn on_component_bytes(
        &mut self,
        origin: MetaOrigin,
        crc: u32,
        cache_path: PathBuf,
        result: Result<Vec<u8>, String>,
        fx: &mut Vec<Effect>,
    ) {
        let Some(i) = self.meta.comp_reads.iter().position(|(_, c)| *c == crc) else {
            return;
        };
        let (key, _) = self.meta.comp_reads.remove(i);
        let asked = self.meta.comp_fetch == Some(key);
        match origin {
            MetaOrigin::Missing => self.comp_download(key, fx),
            MetaOrigin::Cache => {
                let parsed = result.and_then(|b| MetaSet::parse_px4_json(&b));
                match parsed {
                    Ok(meta) => {
                        let n = meta.len();
                        if self.target == Some(key) || self.cfg.param_meta.is_none() {
                            self.use_meta(Some(MetaKey::Component(crc)), meta);
                        } else {
                            self.meta
                                .sets
                                .push((MetaKey::Component(crc), Arc::new(meta)));
                        }
                        self.comp_finish(key);
                        self.meta.comp_fetch = self.meta.comp_fetch.filter(|k| *k != key);
                        let text = if asked {
                            format!(
                                "param meta fetch: {n} parameters described, from the cache ({key}'s metadata CRC {crc:08x} is unchanged)"
                            )
                        } else {
                            format!(
                                "parameter metadata: {n} parameters, from {}",
                                cache_path.display()
                            )
                        };
                        self.comp_notice(key, Severity::INFO, text, asked);
                    }
                    Err(e) => {
                        self.comp_notice(
                            key,
                            Severity::WARNING,
                            format!(
                                "parameter metadata {}: {e}; reading it from {key} again",
                                cache_path.display()
                            ),
                            asked,
                        );
                        self.comp_download(key, fx);
                    }
                }
            }
            MetaOrigin::Url(url) => {
                self.meta.comp_fetch = self.meta.comp_fetch.filter(|k| *k != key);
                let parsed = result.and_then(|bytes| {
                    let json = inflate(&url, &bytes, MAX_JSON)?;
                    MetaSet::parse_px4_json(&json).map(|m| (m, json))
                });
                match parsed {
                    Ok((meta, json)) => self.comp_loaded(key, crc, meta, json, &url, asked, fx),
                    Err(e) => self.comp_notice(
                        key,
                        Severity::ERROR,
                        format!("parameter metadata of {key}: {e}"),
                        true,
                    ),
                }
            }
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
            // Its announced metadata, if read this run.
            let key = self.target.map(|k| (k.0, k.1));
            let crc = self
                .meta
                .announced
                .iter()
                .find(|(k, _)| Some((k.0, k.1)) == key)
                .map(|(_, c)| MetaKey::Component(*c));
            if let Some(want) = crc.filter(|w| self.meta.loaded_for != Some(*w)) {
                if let Some((_, set)) = self.meta.sets.iter().find(|(n, _)| *n == want) {
                    self.cfg.param_meta = Some(set.clone());
                    self.meta.loaded_for = Some(want);
                    self.dirty = true;
                }
            }
            return;
        }
        let Some((name, _)) = ardupilot_vehicle(v.mavtype) else {
            return;
        };
        let want = MetaKey::ArduPilot(name);
        if self.meta.loaded_for == Some(want) {
            return;
        }
        if let Some((_, set)) = self.meta.sets.iter().find(|(n, _)| *n == want) {
            self.cfg.param_meta = Some(set.clone());
            self.meta.loaded_for = Some(want);
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
