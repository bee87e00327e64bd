//! The last action the operator started, and what came of it: the status bar shows its line
//! from *sent* to its result (accepted, refused with the vehicle's reason, no answer, done with
//! its figure) until the next action; `:messages` lists the results, newest last.
//!
//! An action is known by what identifies it: the command queue's id, the vehicle running a
//! sequence (each step's command, then the sequence's last word), the file a parameter save
//! writes. Texts are never matched.

use super::App;
use crate::clock::Micros;
use crate::mission::MissionType;
use crate::proto::commands::State;
use crate::proto::vehicles::VehicleKey;
use crate::wire::Severity;
use std::path::PathBuf;

/// Results kept for `:messages`.
pub const HISTORY: usize = 50;

/// What the action is, to know its result when it comes.
#[derive(Debug, Clone, PartialEq)]
pub enum ActionKind {
    /// A command of the queue.
    Command,
    /// A sequence (take-off, mode change) on this vehicle: its steps' commands, then its end.
    Sequence(VehicleKey),
    /// `param save`: `count` parameters into `path`.
    ParamSave { path: PathBuf, count: usize },
    /// A calibration of this vehicle: its start command, then the calibration's own result.
    Calibration(VehicleKey),
    /// An upload of `count` items of list `t` to vehicle `key`, asked at `at`.
    MissionUpload {
        key: VehicleKey,
        t: MissionType,
        count: usize,
        at: Micros,
    },
}

/// The last action and where it stands.
#[derive(Debug, Clone, PartialEq)]
pub struct ActionLine {
    /// The command queue's ids that belong to it (a sequence's steps add theirs).
    pub ids: Vec<u64>,
    pub kind: ActionKind,
    pub sev: Severity,
    /// What the status bar shows.
    pub text: String,
    /// False while the result is awaited.
    pub done: bool,
    /// The session whose queue runs its commands.
    pub session: Option<VehicleKey>,
    /// The vehicle's reason for a refusal is in the text already.
    pub reason_shown: bool,
}

/// A result, for `:messages`.
#[derive(Debug, Clone, PartialEq)]
pub struct OutcomeEntry {
    pub t: Micros,
    pub sev: Severity,
    pub text: String,
}

impl App {
    /// An action was started: its line replaces the last one.
    pub(super) fn start_action(
        &mut self,
        session: Option<VehicleKey>,
        ids: Vec<u64>,
        kind: ActionKind,
        text: String,
    ) {
        self.ui.action = Some(ActionLine {
            ids,
            kind,
            sev: Severity::INFO,
            text,
            done: false,
            session,
            reason_shown: false,
        });
        self.dirty = true;
    }

    /// The action's line moves on to `text`; `last` ends it (and records it).
    pub(super) fn action_moves(&mut self, sev: Severity, text: String, last: bool) {
        let Some(a) = self.ui.action.as_mut() else {
            return;
        };
        a.sev = sev;
        a.text = text.clone();
        a.done = last;
        // A reason known when the answer came is in the answer's text.
        let known = a.session.zip(a.ids.last()).is_none_or(|(k, id)| {
            self.sessions
                .get(&k)
                .and_then(|s| s.commands.get(*id))
                .is_none_or(|e| e.reason.is_some() || e.state == State::Done(0))
        });
        a.reason_shown = known;
        // The line replaces what the key that started it showed; while a line is typed, its
        // completions stay.
        if self.ui.mode == crate::keymap::Mode::Normal {
            self.ui.message = None;
        }
        if last {
            self.ui.outcomes.push_back(OutcomeEntry {
                t: self.now,
                sev,
                text,
            });
            while self.ui.outcomes.len() > HISTORY {
                self.ui.outcomes.pop_front();
            }
        }
        self.dirty = true;
    }

    /// Command `id` of the queue finished with this notice.
    pub(super) fn command_outcome(&mut self, id: u64, sev: Severity, text: &str) {
        let Some(a) = self.ui.action.as_ref().filter(|a| !a.done) else {
            return;
        };
        if !a.ids.contains(&id) {
            return;
        }
        // A sequence goes on after a step's answer, a calibration after its start's; their end
        // is their own word.
        let last = !matches!(a.kind, ActionKind::Sequence(_) | ActionKind::Calibration(_));
        self.action_moves(sev, text.to_string(), last);
    }

    /// The sequence of vehicle `key` ended, well (`ok`) or not, with this notice.
    pub(super) fn sequence_outcome(&mut self, key: VehicleKey, sev: Severity, text: &str) {
        if self
            .ui
            .action
            .as_ref()
            .is_some_and(|a| !a.done && a.kind == ActionKind::Sequence(key))
        {
            self.action_moves(sev, text.to_string(), true);
        }
    }

    /// The reason the vehicle gave (STATUSTEXT) for refusing the action's last command, when
    /// it came after the answer: added to the line and to its result in `:messages`.
    pub(super) fn follow_reason(&mut self) {
        let Some(a) = self
            .ui
            .action
            .as_ref()
            .filter(|a| a.done && !a.reason_shown)
        else {
            return;
        };
        let (Some(key), Some(id)) = (a.session, a.ids.last()) else {
            return;
        };
        let reason = self
            .sessions
            .get(&key)
            .and_then(|s| s.commands.get(*id))
            .and_then(|e| e.reason.clone());
        let Some(reason) = reason else {
            return;
        };
        if let Some(a) = self.ui.action.as_mut() {
            a.reason_shown = true;
            a.text = format!("{} ({reason})", a.text);
            if let Some(last) = self.ui.outcomes.back_mut() {
                last.text = a.text.clone();
            }
        }
        self.dirty = true;
    }

    /// The sequence of `key` submitted its next step: that command belongs to the action.
    pub(super) fn follow_sequence(&mut self, key: VehicleKey) {
        let Some(a) = self
            .ui
            .action
            .as_mut()
            .filter(|a| !a.done && a.kind == ActionKind::Sequence(key))
        else {
            return;
        };
        let Some(s) = self.sessions.get(&key) else {
            return;
        };
        let Some(step) = s.sequence.as_ref().and_then(|q| q.current()) else {
            return;
        };
        let spec = &step.spec;
        let open =
            s.commands.entries().rev().find(|e| {
                e.open() && e.spec.target == spec.target && e.spec.command == spec.command
            });
        if let Some(e) = open {
            if !a.ids.contains(&e.id) {
                a.ids.push(e.id);
            }
        }
    }

    /// The mission upload of `key` ended: the vehicle accepted the list (it is known as
    /// uploaded since the upload was asked), or the transfer stopped without it.
    pub(super) fn follow_mission(&mut self, key: VehicleKey) {
        let Some(ActionLine {
            kind:
                ActionKind::MissionUpload {
                    key: k,
                    t,
                    count,
                    at,
                },
            done: false,
            ..
        }) = self.ui.action.as_ref()
        else {
            return;
        };
        let (t, count, at) = (*t, *count, *at);
        let Some(m) = self
            .sessions
            .get(k)
            .filter(|_| *k == key)
            .map(|s| &s.mission)
        else {
            return;
        };
        let uploaded = m.known(t).is_some_and(|k| !k.downloaded && k.at >= at);
        let waiting = m.busy() || m.queued().next().is_some();
        let (sev, text) = if uploaded {
            (
                Severity::INFO,
                format!("{count} {} items uploaded", t.name()),
            )
        } else if !waiting {
            (
                Severity::WARNING,
                format!("{count} {} items not uploaded (see the messages)", t.name()),
            )
        } else {
            return;
        };
        self.action_moves(sev, text, true);
    }

    /// A file was written (or not): the parameter save that wrote it is done.
    pub(super) fn file_outcome(&mut self, path: &std::path::Path, error: Option<&str>) {
        let Some(ActionLine {
            kind: ActionKind::ParamSave { path: p, count },
            done: false,
            ..
        }) = self.ui.action.as_ref()
        else {
            return;
        };
        if p != path {
            return;
        }
        let (sev, text) = match error {
            None => (
                Severity::INFO,
                format!("{count} parameters saved to {}", path.display()),
            ),
            Some(e) => (
                Severity::ERROR,
                format!("could not save {}: {e}", path.display()),
            ),
        };
        self.action_moves(sev, text, true);
    }

    /// The action's line as the status bar shows it: a take-off of the action's sequence adds
    /// its climb (`NAV_TAKEOFF to 1:1: ACCEPTED; climbing: 4.3 m of 10.0 m`), and a take-off done on the way
    /// (the mission's start goes on) shows `take-off: 10.0 m reached` until the next step's
    /// answer.
    pub fn action_text(&self) -> Option<(Severity, String)> {
        let a = self.ui.action.as_ref()?;
        let running = match (&a.kind, a.done) {
            (ActionKind::Sequence(key), false) => {
                self.sessions.get(key).and_then(|s| s.sequence.as_ref())
            }
            _ => None,
        };
        if let Some(seq) = running {
            if let Some(c) = seq.climb() {
                let climb = match c.alt_m {
                    Some(h) => format!("climbing: {h:.1} m of {:.1} m", c.target_m),
                    None => format!("climbing to {:.1} m", c.target_m),
                };
                return Some((a.sev, format!("{}; {climb}", a.text)));
            }
            if let Some(r) = seq.reached() {
                return Some((Severity::INFO, r.to_string()));
            }
        }
        Some((a.sev, a.text.clone()))
    }

    /// `:messages`: the results so far, newest last.
    pub(super) fn open_outcomes(&mut self) {
        self.ui.show_outcomes = true;
        // The newest at the bottom, in view.
        self.ui.help_scroll = usize::MAX / 2;
        self.ui.mode = crate::keymap::Mode::Help;
    }
}
