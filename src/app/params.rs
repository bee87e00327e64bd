//! Parameters at the prompt and on the Parameters screen: fetch, set (checked against the type
//! and the metadata), save, load and diff a file, apply a file's changes after a confirmation.
//!
//! Files are read and written at the edge: `param load`/`param diff` ask for the file with
//! [`Effect::ReadFile`] and go on when [`Event::FileRead`](super::Event::FileRead) brings it;
//! `param save` hands the text to [`Effect::WriteFile`] (atomic).

use std::collections::BTreeMap;
use std::path::PathBuf;

use super::flight::{Confirm, Confirmed};
use super::notices::{SEV_ERROR, SEV_INFO, SEV_WARNING};
use super::{App, Effect};
use crate::params::file::{self, Format, Header, ParamFile, Saved};
use crate::params::meta::{ParamMeta, Variant};
use crate::params::value;
use crate::proto::params::ParamSet;
use crate::proto::vehicles::VehicleKey;

/// A `param` command.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamCmd {
    Fetch,
    Set(String, String),
    Save(String),
    Load(String),
    Diff(String),
}

/// Why a file is being read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileUse {
    /// Compare, then offer to apply the differences.
    Load,
    /// Compare only.
    Diff,
}

/// A file loaded or compared: its values mark the parameters that differ from it.
#[derive(Debug, Clone)]
pub struct LoadedFile {
    pub path: String,
    pub file: ParamFile,
    pub diff: file::Diff,
    /// By name, the file's value.
    pub values: BTreeMap<String, f64>,
}

/// What the text being typed on the Parameters screen is for.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamEdit {
    /// The incremental filter.
    Filter,
    /// A new value for this parameter of this component.
    Value(u8, String),
}

/// The Parameters screen's state.
#[derive(Debug, Clone, Default)]
pub struct ParamView {
    /// Substring filter (case-insensitive); `ATC_` style prefixes group.
    pub filter: String,
    /// Selected row among the filtered parameters.
    pub sel: usize,
    /// The component shown (the target's autopilot when `None`).
    pub comp: Option<u8>,
    /// What the edit line is for, while typing on this screen.
    pub editing: Option<ParamEdit>,
    /// Show only the parameters that differ from the loaded file.
    pub only_diff: bool,
}

/// Usage of `param`.
pub const USAGE: &str =
    "usage: param fetch | param set NAME VALUE | param save FILE | param load FILE | param diff FILE";

/// Parse the words after `param`.
pub fn parse(rest: &str) -> Result<ParamCmd, String> {
    let mut words = rest.splitn(2, ' ');
    let sub = words.next().unwrap_or("");
    let arg = words.next().unwrap_or("").trim();
    let file_arg = |f: fn(String) -> ParamCmd| {
        if arg.is_empty() {
            Err(USAGE.to_string())
        } else {
            Ok(f(arg.to_string()))
        }
    };
    match sub {
        "fetch" if arg.is_empty() => Ok(ParamCmd::Fetch),
        "set" => {
            let mut w = arg.split_whitespace();
            match (w.next(), w.next(), w.next()) {
                (Some(n), Some(v), None) => Ok(ParamCmd::Set(n.to_string(), v.to_string())),
                _ => Err("usage: param set NAME VALUE".into()),
            }
        }
        "save" => file_arg(ParamCmd::Save),
        "load" => file_arg(ParamCmd::Load),
        "diff" => file_arg(ParamCmd::Diff),
        _ => Err(USAGE.into()),
    }
}

/// The parameters of a set, as files take them.
fn saved<'a>(comp: u8, set: &'a ParamSet) -> impl Iterator<Item = Saved<'a>> {
    set.params.iter().map(move |(name, p)| Saved {
        name,
        value: p.value,
        ptype: p.ptype,
        component: comp,
    })
}

impl App {
    /// The vehicle and component whose parameters the Parameters screen and `param` work on.
    pub fn param_target(&self) -> Result<(VehicleKey, u8), String> {
        let key = self.target.ok_or("no target vehicle")?;
        if !self.sessions.contains_key(&key) {
            return Err(format!("{}:{} has no session", key.0, key.1));
        }
        Ok((key, self.ui.params.comp.unwrap_or(key.1)))
    }

    /// The set shown and worked on.
    pub fn param_set(&self) -> Option<&ParamSet> {
        let (key, comp) = self.param_target().ok()?;
        self.sessions.get(&key)?.params.sets.get(&comp)
    }

    /// The metadata of `name` for the target's kind of vehicle.
    pub fn param_meta(&self, name: &str) -> Option<&ParamMeta> {
        let meta = self.cfg.param_meta.as_ref()?;
        let variant = self
            .target
            .and_then(|k| self.vehicles.get(k))
            .map_or(Variant::Unknown, |v| {
                Variant::from_mav_type(v.mavtype as u8)
            });
        meta.get(name, variant)
    }

    /// Names of the shown set passing the screen's filter, in order.
    pub fn param_rows(&self) -> Vec<String> {
        let Some(set) = self.param_set() else {
            return Vec::new();
        };
        let f = self.ui.params.filter.to_ascii_uppercase();
        let loaded = self.param_file.as_ref();
        set.params
            .iter()
            .filter(|(n, _)| f.is_empty() || n.to_ascii_uppercase().contains(&f))
            .filter(|(n, p)| {
                !self.ui.params.only_diff
                    || loaded
                        .and_then(|l| l.values.get(*n))
                        .is_some_and(|v| !value::same(*v, p.value, p.ptype))
            })
            .map(|(n, _)| n.clone())
            .collect()
    }

    pub(super) fn run_param(
        &mut self,
        cmd: ParamCmd,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let (key, comp) = self.param_target()?;
        match cmd {
            ParamCmd::Fetch => {
                let now = self.now;
                let s = self.sessions.get_mut(&key).ok_or("no session")?;
                let out = s.params.fetch(now, comp);
                let out = out.into_iter().map(super::session::pmap).collect();
                self.session_out(key, out, fx);
                Ok(Some(format!("fetching the parameters of {}:{comp}", key.0)))
            }
            ParamCmd::Set(name, text) => self.set_param(key, comp, &name, &text, fx),
            ParamCmd::Save(path) => {
                let set = self
                    .sessions
                    .get(&key)
                    .and_then(|s| s.params.sets.get(&comp))
                    .filter(|s| !s.params.is_empty())
                    .ok_or_else(|| format!("no parameters of {}:{comp} yet", key.0))?;
                let format = file::format_for_path(std::path::Path::new(&path));
                let params: Vec<Saved> = match format {
                    Format::Parm => saved(comp, set).collect(),
                    // QGroundControl's file holds every component.
                    Format::Qgc => self.sessions[&key]
                        .params
                        .sets
                        .iter()
                        .flat_map(|(c, s)| saved(*c, s))
                        .collect(),
                };
                let header = self.file_header(key);
                let text = file::write(format, &params, &header);
                let (got, count) = set.progress();
                fx.push(Effect::WriteFile {
                    path: PathBuf::from(&path),
                    contents: text.into_bytes(),
                });
                let n = params.len();
                Ok(Some(match count {
                    Some(c) if (got as u16) < c => format!(
                        "saving {n} parameters to {path} ({format}): the download is incomplete ({got}/{c})",
                        format = format.name()
                    ),
                    _ => format!("saving {n} parameters to {path} ({})", format.name()),
                }))
            }
            ParamCmd::Load(path) | ParamCmd::Diff(path) if path.is_empty() => Err(USAGE.into()),
            ParamCmd::Load(path) => {
                fx.push(Effect::ReadFile {
                    path: PathBuf::from(&path),
                    purpose: FileUse::Load,
                });
                Ok(Some(format!("reading {path}")))
            }
            ParamCmd::Diff(path) => {
                fx.push(Effect::ReadFile {
                    path: PathBuf::from(&path),
                    purpose: FileUse::Diff,
                });
                Ok(Some(format!("reading {path}")))
            }
        }
    }

    fn file_header(&self, key: VehicleKey) -> Header {
        let (stack, vehicle) = match self.vehicles.get(key) {
            Some(v) => (v.autopilot_name().to_string(), v.type_name().to_string()),
            None => (String::new(), String::new()),
        };
        Header {
            sysid: key.0,
            stack,
            vehicle,
            ..Header::default()
        }
    }

    /// A value typed for `name`: a number, or an enum value's or bits' names when the metadata
    /// has them; checked against the type (refused) and the metadata's range (asked).
    pub(super) fn set_param(
        &mut self,
        key: VehicleKey,
        comp: u8,
        name: &str,
        text: &str,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let set = self
            .sessions
            .get(&key)
            .and_then(|s| s.params.sets.get(&comp))
            .ok_or_else(|| format!("no parameters of {}:{comp} yet", key.0))?;
        let name = if set.params.contains_key(name) {
            name.to_string()
        } else {
            let up = name.to_ascii_uppercase();
            if !set.params.contains_key(&up) {
                return Err(format!("no parameter {name} on {}:{comp}", key.0));
            }
            up
        };
        let p = &set.params[&name];
        let meta = self.param_meta(&name);
        let v = match text.trim().parse::<f64>() {
            Ok(v) => v,
            Err(_) => meta
                .and_then(|m| m.parse_value(text))
                .ok_or_else(|| match meta {
                    Some(m) if !m.values.is_empty() || !m.bits.is_empty() => {
                        format!("`{text}` is not a number nor one of {name}'s value names")
                    }
                    _ => format!("`{text}` is not a number"),
                })?,
        };
        p.ptype.check(v)?;
        if meta.is_some_and(|m| m.read_only) {
            return Err(format!("{name} is read-only"));
        }
        let change = vec![(comp, name.clone(), v)];
        if let Some(why) = meta.and_then(|m| m.check_range(v).err()) {
            self.ui.confirm = Some(Confirm {
                text: format!(
                    "{name} = {}: {why}. Send anyway? (y/n)",
                    value::fmt_plain(v)
                ),
                action: Confirmed::Params(change),
                target: key,
                key: None,
            });
            return Ok(None);
        }
        self.write_params(key, change, fx)
    }

    /// Send parameter writes (already checked).
    pub(super) fn write_params(
        &mut self,
        key: VehicleKey,
        changes: Vec<(u8, String, f64)>,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let now = self.now;
        let n = changes.len();
        let mut out = Vec::new();
        let mut errors = Vec::new();
        let s = self.sessions.get_mut(&key).ok_or("vehicle gone")?;
        for (comp, name, v) in &changes {
            match s.params.set(now, *comp, name, *v) {
                Ok(o) => out.extend(o.into_iter().map(super::session::pmap)),
                Err(e) => errors.push(format!("{name}: {e}")),
            }
        }
        self.session_out(key, out, fx);
        if !errors.is_empty() {
            return Err(errors.join("; "));
        }
        Ok(Some(if n == 1 {
            let (_, name, v) = &changes[0];
            format!(
                "{name} = {}: sent, waiting for the echo",
                value::fmt_plain(*v)
            )
        } else {
            format!("{n} parameters sent, waiting for their echoes")
        }))
    }

    /// A file asked for by `param load`/`param diff` came (or did not).
    pub(super) fn on_file_read(
        &mut self,
        path: PathBuf,
        purpose: FileUse,
        result: Result<Vec<u8>, String>,
    ) {
        let shown = path.display().to_string();
        let bytes = match result {
            Ok(b) => b,
            Err(e) => {
                self.notice(SEV_ERROR, None, format!("could not read {shown}: {e}"));
                return;
            }
        };
        let text = String::from_utf8_lossy(&bytes);
        let parsed = file::parse(&text);
        let Ok((key, comp)) = self.param_target() else {
            self.notice(SEV_ERROR, None, format!("{shown}: no target vehicle"));
            return;
        };
        let Some(set) = self.param_set() else {
            self.notice(
                SEV_ERROR,
                None,
                format!("{shown}: no parameters of {}:{comp} yet", key.0),
            );
            return;
        };
        let vehicle: Vec<Saved> = saved(comp, set).collect();
        let diff = file::diff(&vehicle, &parsed);
        let values = parsed
            .params
            .iter()
            .filter(|p| p.component.is_none_or(|c| c == comp))
            .map(|p| (p.name.clone(), p.value))
            .collect();
        for e in parsed.errors.iter().take(20) {
            self.notice(SEV_WARNING, None, format!("{shown}: {e}"));
        }
        let summary = format!(
            "{shown}: {} changed, {} only on the vehicle, {} only in the file{}",
            diff.changed.len(),
            diff.only_vehicle.len(),
            diff.only_file.len(),
            match parsed.errors.len() {
                0 => String::new(),
                1 => ", 1 bad line".into(),
                n => format!(", {n} bad lines"),
            }
        );
        self.notice(SEV_INFO, None, summary.clone());
        let changes: Vec<(u8, String, f64)> = diff
            .changed
            .iter()
            .map(|c| (c.component, c.name.clone(), c.file))
            .collect();
        let errors = parsed.errors.len();
        let first_error = parsed.errors.first().map(|e| e.to_string());
        self.param_file = Some(LoadedFile {
            path: shown.clone(),
            file: parsed,
            diff,
            values,
        });
        self.ui.message = Some((SEV_INFO, summary));
        if purpose == FileUse::Diff {
            return;
        }
        // Values out of range for their type are never sent.
        let (ok, bad): (Vec<_>, Vec<_>) = changes.into_iter().partition(|(c, n, v)| {
            self.sessions[&key].params.sets[c].params[n]
                .ptype
                .check(*v)
                .is_ok()
        });
        for (_, n, v) in &bad {
            self.notice(
                SEV_WARNING,
                None,
                format!(
                    "{shown}: {n} = {} is out of range for its type: not sent",
                    value::fmt_plain(*v)
                ),
            );
        }
        if ok.is_empty() {
            self.ui.message = Some((SEV_INFO, format!("{shown}: nothing to change")));
            return;
        }
        let mut list: Vec<String> = ok
            .iter()
            .take(8)
            .map(|(c, n, v)| {
                let p = &self.sessions[&key].params.sets[c].params[n];
                format!("{n} {} → {}", p.text(), value::format(*v, p.ptype))
            })
            .collect();
        if ok.len() > 8 {
            list.push(format!("and {} more", ok.len() - 8));
        }
        let warn = match (errors, first_error) {
            (0, _) | (_, None) => String::new(),
            (n, Some(e)) => format!(
                "The file has {n} bad line{} ({e}); only its valid lines are used. ",
                if n == 1 { "" } else { "s" }
            ),
        };
        self.ui.confirm = Some(Confirm {
            text: format!(
                "{warn}Apply {} change{} from {shown} to {}:{comp}? {} (y/n)",
                ok.len(),
                if ok.len() == 1 { "" } else { "s" },
                key.0,
                list.join(", ")
            ),
            action: Confirmed::Params(ok),
            target: key,
            key: None,
        });
    }
}
