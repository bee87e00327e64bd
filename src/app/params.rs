//! Parameters at the prompt and on the Parameters screen: fetch, set (checked against the type
//! and the metadata), save, load and diff a file, apply a file's changes after a confirmation.
//!
//! Files are read and written at the edge: `param load`/`param diff` ask for the file with
//! [`Effect::ReadFile`] and go on when [`Event::FileRead`](super::Event::FileRead) brings it;
//! `param save` hands the text to [`Effect::WriteFile`] (atomic).

use std::collections::BTreeMap;
use std::path::PathBuf;

use super::confirm::{Ask, Confirmed};
use super::editor::{self, EditKind, Edited};
pub use super::files::FileUse;
use super::{App, Effect};
use crate::keymap::{Action, Key};
use crate::params::file::{self, Format, Header, ParamFile, Saved};
use crate::params::meta::{ParamMeta, Variant};
use crate::params::value;
use crate::proto::params::ParamSet;
use crate::proto::vehicles::VehicleKey;
use crate::wire::Severity;

/// A `param` command.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamCmd {
    Fetch,
    /// Work on this component of the target's system (`None`: its autopilot).
    Component(Option<u8>),
    Set(String, String),
    /// Read and write integers this way on the target (`None`: say which is in use).
    Encoding(Option<value::Encoding>),
    Save(String),
    Load(String),
    Diff(String),
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

/// Whether `name` passes the Parameters screen's filter: a case-insensitive substring, except
/// that a filter ending in `_` (`ATC_`) is a group prefix: the names starting with it.
pub fn filter_matches(filter: &str, name: &str) -> bool {
    if filter.is_empty() {
        return true;
    }
    let (f, n) = (filter.to_ascii_uppercase(), name.to_ascii_uppercase());
    if f.ends_with('_') {
        n.starts_with(&f)
    } else {
        n.contains(&f)
    }
}

/// The enumeration value after `current` (a value name or a number, matched case-insensitively)
/// in `values`, round the end; the first when `current` is none of them.
pub fn next_value_name<'a>(values: &'a [(f64, String)], current: &str) -> Option<&'a str> {
    let t = current.trim();
    let at = values.iter().position(|(c, n)| {
        n.trim().eq_ignore_ascii_case(t) || t.parse::<f64>().is_ok_and(|v| v == *c)
    });
    let next = at.map_or(0, |i| (i + 1) % values.len());
    values.get(next).map(|(_, n)| n.as_str())
}

/// Usage of `param`.
pub const USAGE: &str = "usage: param fetch | param set NAME VALUE | param save FILE | param load FILE | param diff FILE | param comp COMPID | param encoding [bytewise|ccast]";

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
        "comp" if arg.is_empty() || arg == "auto" => Ok(ParamCmd::Component(None)),
        "comp" => arg
            .parse::<u8>()
            .map(|c| ParamCmd::Component(Some(c)))
            .map_err(|_| {
                "usage: param comp COMPID (a component of the target's system), or param comp auto"
                    .into()
            }),
        "set" => {
            let mut w = arg.split_whitespace();
            match (w.next(), w.next(), w.next()) {
                (Some(n), Some(v), None) => Ok(ParamCmd::Set(n.to_string(), v.to_string())),
                _ => Err("usage: param set NAME VALUE".into()),
            }
        }
        "encoding" => match arg.to_ascii_lowercase().as_str() {
            "" => Ok(ParamCmd::Encoding(None)),
            "bytewise" => Ok(ParamCmd::Encoding(Some(value::Encoding::Bytewise))),
            "ccast" | "c-cast" => Ok(ParamCmd::Encoding(Some(value::Encoding::CCast))),
            _ => Err("usage: param encoding [bytewise|ccast]".into()),
        },
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
            return Err(format!("{key} has no session"));
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
        let filter = self.ui.params.filter.trim();
        let loaded = self.param_file.as_ref();
        set.params
            .iter()
            .filter(|(n, _)| filter_matches(filter, n))
            .filter(|(n, p)| {
                !self.ui.params.only_diff
                    || loaded
                        .and_then(|l| l.values.get(n.as_str()))
                        .is_some_and(|v| !value::same(*v, p.value, p.ptype))
            })
            .map(|(n, _)| n.to_string())
            .collect()
    }

    pub(super) fn run_param(
        &mut self,
        cmd: ParamCmd,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let (key, comp) = self.param_target()?;
        match cmd {
            ParamCmd::Component(c) => {
                self.ui.params.comp = c.filter(|c| *c != key.1);
                self.ui.params.sel = 0;
                let c = c.unwrap_or(key.1);
                let have = self.sessions[&key].params.sets.contains_key(&c);
                Ok(Some(if have {
                    format!("parameters of {}", VehicleKey(key.0, c))
                } else {
                    format!(
                        "parameters of {}: none yet (param fetch asks for them)",
                        VehicleKey(key.0, c)
                    )
                }))
            }
            ParamCmd::Fetch => {
                self.commandable_at(VehicleKey(key.0, comp))?;
                let now = self.now;
                let s = self.sessions.get_mut(&key).ok_or("no session")?;
                let out = s.params_fetch(now, comp);
                self.session_out(key, out, fx);
                Ok(Some(format!(
                    "fetching the parameters of {}",
                    VehicleKey(key.0, comp)
                )))
            }
            ParamCmd::Set(name, text) => self.set_param(key, comp, &name, &text, fx),
            ParamCmd::Encoding(choice) => {
                let m = &mut self.sessions.get_mut(&key).ok_or("no session")?.params;
                if let Some(e) = choice {
                    m.choose_encoding(e);
                }
                Ok(Some(format!(
                    "parameters of {}: integers read {} (chosen by {})",
                    key.0,
                    m.encoding.name(),
                    m.encoding_by.name()
                )))
            }
            ParamCmd::Save(path) => {
                let set = self
                    .sessions
                    .get(&key)
                    .and_then(|s| s.params.sets.get(&comp))
                    .filter(|s| !s.params.is_empty())
                    .ok_or_else(|| format!("no parameters of {} yet", VehicleKey(key.0, comp)))?;
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
                let text = match count {
                    Some(c) if (got as u16) < c => format!(
                        "saving {n} parameters to {path} ({format}): the download is incomplete ({got}/{c})",
                        format = format.name()
                    ),
                    _ => format!("saving {n} parameters to {path} ({})", format.name()),
                };
                self.start_action(
                    None,
                    Vec::new(),
                    super::outcome::ActionKind::Save {
                        path: PathBuf::from(&path),
                        what: format!("{n} parameters"),
                    },
                    text.clone(),
                );
                Ok(Some(text))
            }
            ParamCmd::Load(path) | ParamCmd::Diff(path) if path.is_empty() => Err(USAGE.into()),
            ParamCmd::Load(path) => Ok(Some(self.read_file(
                PathBuf::from(&path),
                FileUse::Load,
                fx,
            ))),
            ParamCmd::Diff(path) => Ok(Some(self.read_file(
                PathBuf::from(&path),
                FileUse::Diff,
                fx,
            ))),
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
            .ok_or_else(|| format!("no parameters of {} yet", VehicleKey(key.0, comp)))?;
        let name = if set.params.contains_key(name) {
            name.to_string()
        } else {
            let up = name.to_ascii_uppercase();
            if !set.params.contains_key(up.as_str()) {
                return Err(format!(
                    "no parameter {name} on {}",
                    VehicleKey(key.0, comp)
                ));
            }
            up
        };
        let p = &set.params[name.as_str()];
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
        // What the vehicle's encoding cannot carry exactly is refused before it is sent.
        value::carry_check(v, p.ptype, self.sessions[&key].params.encoding)?;
        if meta.is_some_and(|m| m.read_only) {
            return Err(format!("{name} is read-only"));
        }
        let old = p.value;
        let change = vec![(comp, name.clone(), v)];
        self.commandable_at(VehicleKey(key.0, comp))?;
        let mut why = Vec::new();
        if let Some(e) = meta.and_then(|m| m.check_range(v).err()) {
            why.push(e);
        }
        // A value changed while armed: asked (the vehicle may be flying on it).
        if v != old && self.vehicles.get(key).is_some_and(|v| v.armed()) {
            why.push(format!(
                "{} is ARMED, {name} is {} now",
                self.who_is(key),
                value::fmt_plain(old)
            ));
        }
        if !why.is_empty() {
            self.ask(Ask {
                text: format!(
                    "{name} = {}: {}. Send to {} anyway? y = yes, any other key = no",
                    value::fmt_plain(v),
                    why.join("; "),
                    VehicleKey(key.0, comp),
                ),
                action: Confirmed::Params(change),
                target: key,
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
        // Every component written to is heard and not lost.
        for (comp, _, _) in &changes {
            self.commandable_at(VehicleKey(key.0, *comp))?;
        }
        let now = self.now;
        let n = changes.len();
        let mut out = Vec::new();
        let mut errors = Vec::new();
        let mut waiting = Vec::new();
        let s = self.sessions.get_mut(&key).ok_or("vehicle gone")?;
        for (comp, name, v) in &changes {
            match s.params_set(now, *comp, name, *v) {
                Ok(o) => {
                    out.extend(o);
                    waiting.push((*comp, name.clone()));
                }
                Err(e) => errors.push(format!("{name}: {e}")),
            }
        }
        let text = if n == 1 {
            let (_, name, v) = &changes[0];
            format!(
                "{name} = {}: sent, waiting for the echo",
                value::fmt_plain(*v)
            )
        } else {
            format!("{n} parameters sent, waiting for their echoes")
        };
        // Each write is followed until its echo, refusal or silence.
        if !waiting.is_empty() {
            let kind = super::outcome::ActionKind::ParamWrite {
                key,
                total: waiting.len(),
                waiting,
                confirmed: 0,
            };
            self.start_action(Some(key), Vec::new(), kind, text.clone());
        }
        self.session_out(key, out, fx);
        if !errors.is_empty() {
            return Err(errors.join("; "));
        }
        Ok(Some(text))
    }

    /// A file asked for by `param load`/`param diff` came (or did not).
    pub(super) fn on_file_read(
        &mut self,
        path: PathBuf,
        purpose: FileUse,
        result: Result<Vec<u8>, String>,
    ) {
        let Some((shown, text)) = self.file_text(&path, result) else {
            return;
        };
        let parsed = file::parse(&text);
        let Ok((key, comp)) = self.param_target() else {
            let text = format!("{shown}: no target vehicle");
            self.read_outcome(&path, Severity::ERROR, text.clone());
            self.notice(Severity::ERROR, None, text);
            return;
        };
        let Some(set) = self.param_set() else {
            let text = format!("{shown}: no parameters of {} yet", VehicleKey(key.0, comp));
            self.read_outcome(&path, Severity::ERROR, text.clone());
            self.notice(Severity::ERROR, None, text);
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
            self.notice(Severity::WARNING, None, format!("{shown}: {e}"));
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
        self.notice(Severity::INFO, None, summary.clone());
        // The action's line: what was read, and the first bad line where it is.
        let (sev, mut said) = match parsed.errors.first() {
            None => (Severity::INFO, summary.clone()),
            Some(e) => (Severity::WARNING, format!("{summary}; {e}")),
        };
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
        if purpose == FileUse::Diff {
            self.read_outcome(&path, sev, said);
            return;
        }
        // Values out of range for their type, or that the float cannot carry exactly under the
        // vehicle's encoding (C-cast beyond ±2^24), are never sent: told before the question.
        let encoding = self.sessions[&key].params.encoding;
        let mut ok = Vec::new();
        let mut bad = Vec::new();
        for (c, n, v) in changes {
            let ptype = self.sessions[&key].params.sets[&c].params[n.as_str()].ptype;
            match ptype.check(v) {
                Err(_) => bad.push(format!(
                    "{shown}: {n} = {} is out of range for its type: not sent",
                    value::fmt_plain(v)
                )),
                Ok(()) => match value::carry_check(v, ptype, encoding) {
                    Err(e) => bad.push(format!("{shown}: {n} = {e}: not sent")),
                    Ok(()) => ok.push((c, n, v)),
                },
            }
        }
        for text in bad {
            self.notice(Severity::WARNING, None, text);
        }
        if ok.is_empty() {
            said.push_str("; nothing to change");
        }
        self.read_outcome(&path, sev, said);
        if ok.is_empty() {
            return;
        }
        let mut list: Vec<String> = ok
            .iter()
            .take(8)
            .map(|(c, n, v)| {
                let p = &self.sessions[&key].params.sets[c].params[n.as_str()];
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
        self.ask(Ask {
            text: format!(
                "{warn}Apply {} change{} from {shown} to {}? {} (y/n)",
                ok.len(),
                if ok.len() == 1 { "" } else { "s" },
                VehicleKey(key.0, comp),
                list.join(", ")
            ),
            action: Confirmed::Params(ok),
            target: key,
        });
    }
}

/// The Parameters screen's keys.
impl App {
    /// The name of the selected row (the selection clamped to the rows there are).
    pub fn param_selected(&self) -> Option<String> {
        let rows = self.param_rows();
        let last = rows.len().checked_sub(1)?;
        rows.into_iter().nth(self.ui.params.sel.min(last))
    }

    /// `param_filter`, `param_edit`, `param_fetch`, `param_only_diff` (normal mode).
    pub(super) fn on_param_action(&mut self, action: Action, fx: &mut Vec<Effect>) {
        let outcome: Result<Option<String>, String> = match action {
            Action::ParamFilter => {
                editor::open(&mut self.ui.edit, &mut self.ui.mode, &self.ui.params.filter);
                self.ui.params.editing = Some(ParamEdit::Filter);
                Ok(None)
            }
            Action::ParamEdit => self.start_param_edit(),
            Action::ParamFetch => self.run_param(ParamCmd::Fetch, fx),
            Action::ParamOnlyDiff => match &self.param_file {
                None if !self.ui.params.only_diff => Err(
                    "no file loaded to compare with: `:param diff FILE` or `:param load FILE`"
                        .into(),
                ),
                _ => {
                    let keep = self.param_selected();
                    self.ui.params.only_diff = !self.ui.params.only_diff;
                    self.reselect(keep);
                    Ok(Some(if self.ui.params.only_diff {
                        match self.param_rows().len() {
                            1 => "1 parameter differs from the file".to_string(),
                            n => format!("{n} parameters differ from the file"),
                        }
                    } else {
                        "showing every parameter".into()
                    }))
                }
            },
            _ => Ok(None),
        };
        self.ui.message = match outcome {
            Ok(t) => t.map(|t| (Severity::INFO, t)),
            Err(e) => Some((Severity::ERROR, e)),
        };
    }

    /// Select `name` if it is among the rows, else keep the selection within them.
    fn reselect(&mut self, name: Option<String>) {
        let rows = self.param_rows();
        self.ui.params.sel = name
            .and_then(|n| rows.iter().position(|r| *r == n))
            .unwrap_or(self.ui.params.sel)
            .min(rows.len().saturating_sub(1));
    }

    /// Open the edit line on the selected parameter, holding its value.
    fn start_param_edit(&mut self) -> Result<Option<String>, String> {
        let (key, comp) = self.param_target()?;
        let name = self
            .param_selected()
            .ok_or_else(|| format!("no parameters of {} to edit", VehicleKey(key.0, comp)))?;
        let p = self
            .param_set()
            .and_then(|s| s.params.get(name.as_str()))
            .ok_or("no such parameter")?;
        if self.param_meta(&name).is_some_and(|m| m.read_only) {
            return Err(format!("{name} is read-only"));
        }
        let text = p.text();
        editor::open(&mut self.ui.edit, &mut self.ui.mode, &text);
        self.ui.params.editing = Some(ParamEdit::Value(comp, name));
        Ok(None)
    }

    /// A key while the filter or a value is typed on the Parameters screen: the shared edit
    /// line; `enter` sends the value (checked against its type and metadata), tab completes a
    /// value's name from the metadata.
    pub(super) fn on_param_edit_key(
        &mut self,
        key: Key,
        action: Option<Action>,
        fx: &mut Vec<Effect>,
    ) {
        self.ui.message = None;
        let Some(editing) = self.ui.params.editing.clone() else {
            return;
        };
        let filter = editing == ParamEdit::Filter;
        let kind = EditKind {
            filter,
            completes: true,
        };
        match editor::key(&mut self.ui.edit, &mut self.ui.mode, kind, key, action) {
            Edited::Submit(text) => {
                self.ui.params.editing = None;
                if let (ParamEdit::Value(comp, name), Some(text)) = (editing, text) {
                    let outcome = match self.param_target() {
                        Ok((key, _)) => self.set_param(key, comp, &name, &text, fx),
                        Err(e) => Err(e),
                    }
                    .map_err(|e| match e.contains(&name) {
                        true => e,
                        false => format!("{name}: {e}"),
                    });
                    self.ui.message = match outcome {
                        Ok(t) => t.map(|t| (Severity::INFO, t)),
                        Err(e) => Some((Severity::ERROR, e)),
                    };
                }
                return;
            }
            Edited::Cancel => {
                self.ui.params.editing = None;
                if filter {
                    // The parameter found stays selected in the whole list.
                    let keep = self.param_selected();
                    self.ui.params.filter.clear();
                    self.reselect(keep);
                } else {
                    self.ui.message = Some((Severity::INFO, "edit cancelled: nothing sent".into()));
                }
                return;
            }
            // While filtering, up/down move through what the filter leaves.
            Edited::Move(step) => self.move_param_sel(step),
            Edited::Complete => {
                if let ParamEdit::Value(_, name) = &editing {
                    let next = self
                        .param_meta(name)
                        .and_then(|m| next_value_name(&m.values, &self.ui.edit.text))
                        .map(str::to_string);
                    if let Some(n) = next {
                        self.ui.edit.set(&n);
                    }
                }
            }
            Edited::Typed => {}
        }
        if filter && self.ui.params.filter != self.ui.edit.text {
            self.ui.params.filter = self.ui.edit.text.clone();
            self.ui.params.sel = 0;
        }
    }

    fn move_param_sel(&mut self, step: isize) {
        let n = self.param_rows().len() as isize;
        self.ui.params.sel = (self.ui.params.sel as isize + step).clamp(0, (n - 1).max(0)) as usize;
    }
}
