//! The target's onboard logs, the operator's side: `log list`, `log get ID|latest [FILE]`,
//! `log erase` (asks first, naming the vehicle), `log cancel`, the Logs screen's keys, and the
//! file work of downloads handed to the edge ([`Effect::LogFile`]).
//!
//! Nothing of it goes on a high-latency link unless the operator asks there explicitly
//! (`--hl`); one transfer per vehicle (a second `get` is queued); `log_rate` caps the rate.

use std::path::PathBuf;

use super::confirm::{Ask, Confirmed};
use super::session::Session;
use super::{App, Effect};
use crate::clock::Micros;
use crate::dialect::MavAutopilot;
use crate::keymap::Action;
use crate::proto::logs::{LogIoDone, State};
use crate::proto::vehicles::VehicleKey;
use crate::wire::Severity;

/// Which log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Which {
    Id(u16),
    Latest,
}

/// A `log` command.
#[derive(Debug, Clone, PartialEq)]
pub enum LogCmd {
    List {
        hl: bool,
    },
    Get {
        which: Which,
        file: Option<PathBuf>,
        hl: bool,
    },
    Erase {
        hl: bool,
    },
    Cancel,
}

pub const USAGE: &str =
    "usage: log list [--hl] | log get ID|latest [FILE] [--hl] | log erase [--hl] | log cancel";

/// `log …` after the word `log`.
pub fn parse(rest: &str) -> Result<LogCmd, String> {
    let mut words: Vec<&str> = rest.split_whitespace().collect();
    let hl = words.contains(&"--hl");
    words.retain(|w| *w != "--hl");
    match words.as_slice() {
        ["list"] | ["ls"] => Ok(LogCmd::List { hl }),
        ["erase"] => Ok(LogCmd::Erase { hl }),
        ["cancel"] => Ok(LogCmd::Cancel),
        ["get", which, file @ ..] if file.len() <= 1 => {
            let which = match *which {
                "latest" | "last" => Which::Latest,
                n => Which::Id(
                    n.parse::<u16>()
                        .map_err(|_| format!("`{n}` is not a log id (or `latest`)"))?,
                ),
            };
            Ok(LogCmd::Get {
                which,
                file: file.first().map(|f| crate::paths::expand_home(f)),
                hl,
            })
        }
        _ => Err(USAGE.into()),
    }
}

/// A download asked before the list was whole: started when it is.
#[derive(Debug, Clone, PartialEq)]
pub struct Pending {
    pub key: VehicleKey,
    pub which: Which,
    pub file: Option<PathBuf>,
    /// Asked on a high-latency link (`--hl`).
    pub hl: bool,
}

/// The Logs screen's state.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LogsView {
    /// The selected row (newest first).
    pub sel: usize,
    pub pending: Vec<Pending>,
    /// Lists asked when the screen was first shown, per vehicle.
    pub listed: std::collections::BTreeSet<VehicleKey>,
}

impl App {
    /// A new session's log machine: where its logs go, the rate cap, the file extension.
    pub(super) fn setup_logs(&self, s: &mut Session, autopilot: MavAutopilot) {
        s.logs.dir = self
            .cfg
            .logs_dir
            .as_ref()
            .map(|d| d.join("vehicle").join(s.key.0.to_string()));
        s.logs.rate_cap = self.cfg.log_rate;
        s.logs.ext = match autopilot {
            MavAutopilot::MAV_AUTOPILOT_PX4 => "ulg",
            _ => "bin",
        };
    }

    /// True when what goes to `key` would leave on a high-latency link.
    fn logs_on_hl(&self, key: VehicleKey) -> bool {
        self.route(key)
            .and_then(|l| self.links.get(l))
            .is_some_and(|l| l.profile.hl)
    }

    fn logs_target(&self, hl: bool) -> Result<VehicleKey, String> {
        let key = self.target.ok_or("no target vehicle")?;
        if !self.sessions.contains_key(&key) {
            return Err(format!("{key} is not an autopilot"));
        }
        if !hl && self.logs_on_hl(key) {
            return Err(format!(
                "{key} is reached on a high-latency link only: `log list --hl` / `log get ID --hl` to use it anyway"
            ));
        }
        Ok(key)
    }

    /// A `log` command.
    pub(super) fn run_log(
        &mut self,
        cmd: LogCmd,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let now = self.now;
        match cmd {
            LogCmd::List { hl } => {
                let key = self.logs_target(hl)?;
                self.ui.logs.listed.insert(key);
                self.logs_do(key, fx, |m, o| m.refresh(now, hl, o))?;
                let text = format!("asking {key} for its logs");
                self.log_list_action(key, false, &text);
                Ok(Some(text))
            }
            LogCmd::Get { which, file, hl } => {
                let key = self.logs_target(hl)?;
                self.log_get(key, which, file, hl, fx)
            }
            LogCmd::Cancel => {
                let key = self.target.ok_or("no target vehicle")?;
                self.ui.logs.pending.retain(|p| p.key != key);
                self.logs_do(key, fx, |m, o| m.cancel(now, o)).map(Some)
            }
            LogCmd::Erase { hl } => {
                let key = self.logs_target(hl)?;
                if self.sessions[&key]
                    .logs
                    .transfer
                    .as_ref()
                    .is_some_and(|t| t.active())
                {
                    return Err("a log download is running: cancel it first".into());
                }
                let n = self.sessions[&key].logs.list.entries.len();
                let count = if self.sessions[&key].logs.list.complete() {
                    format!("all {n} logs")
                } else {
                    "every log".to_string()
                };
                self.ask(Ask {
                    text: format!(
                        "ERASE {count} on {}? They cannot be downloaded afterwards. \
                         y = yes, any other key = no",
                        self.who_is(key)
                    ),
                    action: Confirmed::LogErase { hl },
                    target: key,
                });
                Ok(None)
            }
        }
    }

    /// The operator confirmed the erase.
    pub(super) fn carry_out_log_erase(
        &mut self,
        key: VehicleKey,
        hl: bool,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let now = self.now;
        self.logs_do(key, fx, |m, o| m.erase(now, hl, o))?;
        let text = format!("LOG_ERASE sent to {key}; listing again");
        self.log_list_action(key, true, &text);
        Ok(Some(text))
    }

    /// The list of `key` asked (after an erase, `erase`): the line follows it until it is whole
    /// (its count) or stops short.
    fn log_list_action(&mut self, key: VehicleKey, erase: bool, text: &str) {
        let kind = super::outcome::ActionKind::LogList {
            key,
            erase,
            at: self.now,
        };
        self.start_action(Some(key), Vec::new(), kind, text.to_string());
        self.follow_log_list();
    }

    fn log_get(
        &mut self,
        key: VehicleKey,
        which: Which,
        file: Option<PathBuf>,
        hl: bool,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let list = &self.sessions[&key].logs.list;
        let known = match which {
            Which::Latest => list.complete(),
            Which::Id(id) => list.entries.contains_key(&id),
        };
        if !known {
            // Asked once the list is whole (`follow_logs` asks for it).
            self.ui.logs.pending.push(Pending {
                key,
                which,
                file,
                hl,
            });
            self.follow_logs(fx);
            return Ok(Some(format!("asking {key} for its logs first")));
        }
        let r = self.log_get_now(key, which, file, hl)?;
        self.follow_logs(fx);
        Ok(Some(r))
    }

    /// Download `which` of `key` once its list is whole (the list is asked if it is not):
    /// headless `--logs-out` and `log get` before the list came.
    pub fn logs_request(&mut self, key: VehicleKey, which: Which, file: Option<PathBuf>) {
        self.ui.logs.pending.push(Pending {
            key,
            which,
            file,
            hl: false,
        });
    }

    /// Run `f` on `key`'s log machine; its output is sent and told.
    fn logs_do<T>(
        &mut self,
        key: VehicleKey,
        fx: &mut Vec<Effect>,
        f: impl FnOnce(
            &mut crate::proto::logs::LogMachine,
            &mut Vec<crate::proto::machine::Out>,
        ) -> Result<T, String>,
    ) -> Result<T, String> {
        let now = self.now;
        let s = self.sessions.get_mut(&key).ok_or("no such vehicle")?;
        let (r, out) = s.logs_do(now, f);
        self.session_out(key, out, fx);
        self.follow_logs(fx);
        r
    }

    /// After every update: file work to the edge, downloads waiting for their list started.
    pub(super) fn follow_logs(&mut self, fx: &mut Vec<Effect>) {
        if self.ui.screen == "logs" {
            self.logs_shown(fx);
        }
        let pending = std::mem::take(&mut self.ui.logs.pending);
        let now = self.now;
        for p in pending {
            let Some(s) = self.sessions.get_mut(&p.key) else {
                continue;
            };
            if !s.logs.list.wanted && !s.logs.busy() {
                self.ui.logs.listed.insert(p.key);
                let hl = p.hl;
                let (_, out) = s.logs_do(now, |m, o| m.refresh(now, hl, o));
                self.session_out(p.key, out, fx);
            }
            let Some(list) = self.sessions.get(&p.key).map(|s| &s.logs.list) else {
                continue;
            };
            let ready = match p.which {
                Which::Latest => list.complete(),
                Which::Id(id) => list.entries.contains_key(&id) || list.complete(),
            };
            let given_up = list.failed.is_some();
            if !ready && !given_up {
                self.ui.logs.pending.push(p);
                continue;
            }
            let r = self.log_get_now(p.key, p.which, p.file, p.hl);
            match r {
                Ok(text) => self.notice(Severity::INFO, Some(p.key), text),
                Err(e) => self.notice(Severity::ERROR, Some(p.key), e),
            }
        }
        for (key, s) in self.sessions.iter_mut() {
            for io in s.logs.take_io() {
                fx.push(Effect::LogFile { key: *key, io });
            }
        }
    }

    fn log_get_now(
        &mut self,
        key: VehicleKey,
        which: Which,
        file: Option<PathBuf>,
        hl: bool,
    ) -> Result<String, String> {
        let now = self.now;
        let s = self.sessions.get_mut(&key).ok_or("no such vehicle")?;
        let id = match which {
            Which::Id(id) => id,
            Which::Latest => s.logs.latest().ok_or_else(|| format!("{key} has no log"))?,
        };
        s.logs.get(now, id, file, hl)
    }

    /// What came of a log's file work.
    pub(super) fn on_log_file(&mut self, key: VehicleKey, done: LogIoDone, fx: &mut Vec<Effect>) {
        let now = self.now;
        let Some(s) = self.sessions.get_mut(&key) else {
            return;
        };
        let (_, out) = s.logs_do(now, |m, o| m.on_io(now, done, o));
        self.session_out(key, out, fx);
        self.dirty = true;
    }

    /// The Logs screen's keys.
    pub(super) fn on_log_action(&mut self, action: Action, fx: &mut Vec<Effect>) {
        let cmd = match action {
            Action::LogDownload => {
                let rows = self.log_rows();
                match rows.get(self.ui.logs.sel) {
                    Some(e) => LogCmd::Get {
                        which: Which::Id(e.id),
                        file: None,
                        hl: false,
                    },
                    None => {
                        self.ui.message = Some((Severity::WARNING, "no log selected".into()));
                        return;
                    }
                }
            }
            Action::LogLatest => LogCmd::Get {
                which: Which::Latest,
                file: None,
                hl: false,
            },
            Action::LogCancel => LogCmd::Cancel,
            Action::LogErase => LogCmd::Erase { hl: false },
            _ => LogCmd::List { hl: false },
        };
        let r = self.run_log(cmd, fx);
        self.ui.message = match r {
            Ok(Some(t)) => Some((Severity::INFO, t)),
            Ok(None) => None,
            Err(e) => Some((Severity::ERROR, e)),
        };
    }

    /// The target's logs, newest first.
    pub fn log_rows(&self) -> Vec<crate::proto::logs::LogEntry> {
        self.target
            .and_then(|k| self.sessions.get(&k))
            .map(|s| s.logs.list.newest_first())
            .unwrap_or_default()
    }

    /// The Logs screen's selection.
    pub(super) fn select_logs(&mut self, step: isize) {
        let n = self.log_rows().len();
        self.ui.logs.sel = clamp(self.ui.logs.sel, step, n);
    }

    /// The Logs screen was shown: the target's list is asked the first time (the operator
    /// opened it), never on a high-latency link.
    pub(super) fn logs_shown(&mut self, fx: &mut Vec<Effect>) {
        let Some(key) = self.target.filter(|k| self.sessions.contains_key(k)) else {
            return;
        };
        if self.ui.logs.listed.contains(&key) || self.logs_on_hl(key) {
            return;
        }
        self.ui.logs.listed.insert(key);
        let now = self.now;
        let _ = self.logs_do(key, fx, |m, o| m.refresh(now, false, o));
    }
}

fn clamp(v: usize, step: isize, len: usize) -> usize {
    if len == 0 {
        return 0;
    }
    (v as isize + step).clamp(0, len as isize - 1) as usize
}

/// The download of `s` as one line for the status bar at `now`, as on the Logs screen:
/// `log 3 12.3 kB/30.0 kB 41% 2.8 kB/s ETA 6 s retries 2 +1` (`+1`: one more queued);
/// `stalled 4 s` or `paused (high-latency link only)` stand for the rate and ETA when so, and
/// a download waiting for the vehicle to be heard again says so.
pub fn status_text(s: &Session, now: Micros) -> Option<String> {
    let m = &s.logs;
    let queued = if m.queue.is_empty() {
        String::new()
    } else {
        format!(" +{}", m.queue.len())
    };
    let Some(t) = m.transfer.as_ref().filter(|t| t.active()) else {
        let q = m.queue.front().filter(|_| m.waiting_for_link.is_some())?;
        let more = m.queue.len() - 1;
        let more = if more > 0 {
            format!(" +{more}")
        } else {
            String::new()
        };
        return Some(format!(
            "log {} waits for the vehicle to be heard{more}",
            q.id
        ));
    };
    let how = match t.state {
        State::Opening => "opening".to_string(),
        State::Finishing => "saving".to_string(),
        _ => t.progress_text(now),
    };
    Some(format!("log {} {how}{queued}", t.entry.id))
}

/// The log download of the status bar: the target's, else another vehicle's (named).
pub fn status_bar_text(app: &App) -> Option<String> {
    let target = app.target.and_then(|k| app.sessions.get(&k));
    if let Some(t) = target.and_then(|s| status_text(s, app.now)) {
        return Some(t);
    }
    app.sessions
        .iter()
        .filter(|(k, _)| Some(**k) != app.target)
        .find_map(|(k, s)| status_text(s, app.now).map(|t| format!("{k} {t}")))
}

pub use crate::proto::logs::{human_bytes, human_secs};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_log_command_parses() {
        assert_eq!(parse("list"), Ok(LogCmd::List { hl: false }));
        assert_eq!(
            parse("get 3 /tmp/x.bin"),
            Ok(LogCmd::Get {
                which: Which::Id(3),
                file: Some("/tmp/x.bin".into()),
                hl: false
            })
        );
        assert_eq!(
            parse("get latest --hl"),
            Ok(LogCmd::Get {
                which: Which::Latest,
                file: None,
                hl: true
            })
        );
        assert!(parse("get x").is_err());
        assert!(parse("get 1 a b").is_err());
        assert_eq!(parse("erase"), Ok(LogCmd::Erase { hl: false }));
        assert_eq!(parse("erase --hl"), Ok(LogCmd::Erase { hl: true }));
        assert_eq!(parse("cancel"), Ok(LogCmd::Cancel));
        assert_eq!(parse(""), Err(USAGE.into()));
    }
}
