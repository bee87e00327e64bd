//! The last action the operator started, and what came of it: the status bar shows its line
//! from *sent* to its result (accepted, refused with the vehicle's reason, no answer, done with
//! its figure) until the next action; `:messages` lists the results, newest last.
//!
//! An action is known by what identifies it: the command queue's id, the vehicle running a
//! sequence (each step's command, then the sequence's last word), the file a save writes or a
//! load reads, the (component, name) of each parameter written, the mission request (list and
//! transfer, or the item made current), the camera and its image indices, the log list asked
//! at a time. Texts are never matched.

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
    /// A command of the queue under the operator's wording (`camera 1:100 zoom 50%`, `gimbal
    /// 1:1/1 pitch -90° yaw 0°`, the Inspector's `ATTITUDE 10 Hz from 1:1`): the line is
    /// `LABEL: RESULT`.
    Named(String),
    /// A capture of images: the command's result, then the images the camera reports.
    Capture(Capture),
    /// A file written (`param save`, `wp save`): `what` (`1354 parameters`) into `path`.
    Save { path: PathBuf, what: String },
    /// A file read (`wp load`, `param load`, `param diff`).
    Read(PathBuf),
    /// Parameter writes to `key`: each (component, name) until its echo, refusal or silence.
    ParamWrite {
        key: VehicleKey,
        waiting: Vec<(u8, String)>,
        total: usize,
        confirmed: usize,
    },
    /// A mission request to `key`: a transfer, or the item made current.
    Mission {
        key: VehicleKey,
        ask: crate::proto::mission::MissionAsk,
    },
    /// The log list of `key` asked at `at` (by `log list`, or after `log erase`).
    LogList {
        key: VehicleKey,
        erase: bool,
        at: Micros,
    },
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

/// A capture of `count` images by camera `compid` of `key`, told as `label`.
#[derive(Debug, Clone, PartialEq)]
pub struct Capture {
    pub key: VehicleKey,
    pub compid: u8,
    pub label: String,
    pub count: u32,
    /// Seconds between images.
    pub interval: f64,
    /// The highest image index heard, and the camera's count, when it was asked.
    pub from_index: Option<i32>,
    pub from_count: Option<i32>,
    /// Accepted by the camera: the images are counted from then on.
    pub accepted: bool,
    /// Images taken so far, and when the last one was heard (or the command accepted).
    pub taken: u32,
    pub last_at: Micros,
}

/// Images a capture waits for past its interval before it is told as stopped short.
const CAPTURE_SLACK: Micros = 5 * crate::clock::SECOND;

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
        self.ui.action_count += 1;
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
        let entry = a
            .session
            .and_then(|k| self.sessions.get(&k))
            .and_then(|s| s.commands.get(id));
        let accepted = entry.is_some_and(|e| e.state == State::Done(0));
        let result = entry.map_or_else(|| text.to_string(), |e| e.outcome_with_reason());
        match &a.kind {
            // A sequence goes on after a step's answer, a calibration after its start's; their
            // end is their own word.
            ActionKind::Sequence(_) | ActionKind::Calibration(_) => {
                self.action_moves(sev, text.to_string(), false)
            }
            ActionKind::Named(label) => {
                let text = format!("{label}: {result}");
                self.action_moves(sev, text, true)
            }
            // Accepted, the images are counted; else that is its end.
            ActionKind::Capture(c) => {
                let text = format!("{}: {result}", c.label);
                if accepted {
                    let now = self.now;
                    if let Some(ActionLine {
                        kind: ActionKind::Capture(c),
                        ..
                    }) = self.ui.action.as_mut()
                    {
                        c.accepted = true;
                        c.last_at = now;
                    }
                    self.action_moves(sev, text, false);
                    self.follow_capture();
                } else {
                    self.action_moves(sev, text, true);
                }
            }
            _ => self.action_moves(sev, text.to_string(), true),
        }
    }

    /// The images of the capture asked: counted from the camera's reports (the images heard
    /// since, or its image count), done when all are taken; told as stopped short when none
    /// came for an interval and [`CAPTURE_SLACK`].
    pub(super) fn follow_capture(&mut self) {
        let Some(ActionLine {
            kind: ActionKind::Capture(c),
            done: false,
            ..
        }) = self.ui.action.as_ref()
        else {
            return;
        };
        if !c.accepted {
            return;
        }
        let Some(cam) = self
            .sessions
            .get(&c.key)
            .and_then(|s| s.cameras.cameras.get(&c.compid))
        else {
            return;
        };
        let heard = match c.from_index {
            Some(i) => cam.images.range(i.saturating_add(1)..).count(),
            None => cam.images.len(),
        } as u32;
        let counted = match (cam.status, c.from_count) {
            (Some(st), Some(from)) => st.image_count.saturating_sub(from).max(0) as u32,
            _ => 0,
        };
        let taken = heard.max(counted).min(c.count);
        let (label, count, interval) = (c.label.clone(), c.count, c.interval);
        let images = |n: u32| format!("{n} image{}", if n == 1 { "" } else { "s" });
        let now = self.now;
        let mut last_at = c.last_at;
        if taken > c.taken {
            last_at = now;
        }
        let quiet = (interval.max(0.0) * 1e6) as Micros + CAPTURE_SLACK;
        let (sev, text, last) = if taken >= count {
            (
                Severity::INFO,
                format!("{label}: {} taken", images(count)),
                true,
            )
        } else if now >= last_at + quiet {
            let said = match taken {
                0 => format!("{label}: ACCEPTED; no image reported"),
                n => format!("{label}: {n} of {} taken; no more reported", images(count)),
            };
            (Severity::WARNING, said, true)
        } else if taken > c.taken {
            (
                Severity::INFO,
                format!("{label}: {taken} of {} taken", images(count)),
                false,
            )
        } else {
            return;
        };
        if let Some(ActionLine {
            kind: ActionKind::Capture(c),
            ..
        }) = self.ui.action.as_mut()
        {
            c.taken = taken;
            c.last_at = last_at;
        }
        self.action_moves(sev, text, last);
    }

    /// When a capture's images are next looked at for silence.
    pub(super) fn capture_deadline(&self) -> Option<Micros> {
        match self.ui.action.as_ref()? {
            ActionLine {
                kind: ActionKind::Capture(c),
                done: false,
                ..
            } if c.accepted => {
                Some(c.last_at + (c.interval.max(0.0) * 1e6) as Micros + CAPTURE_SLACK)
            }
            _ => None,
        }
    }

    /// The outcome of a write of parameter `name` of component `comp` of `key` (confirmed by
    /// its echo, refused, unanswered): one write's line is its outcome; several count up.
    pub(super) fn param_outcome(
        &mut self,
        key: VehicleKey,
        comp: u8,
        name: &str,
        confirmed: bool,
        sev: Severity,
        text: &str,
    ) {
        let Some(ActionLine {
            kind:
                ActionKind::ParamWrite {
                    key: k,
                    waiting,
                    total,
                    confirmed: ok,
                },
            done: false,
            ..
        }) = self.ui.action.as_mut()
        else {
            return;
        };
        let Some(i) = waiting.iter().position(|(c, n)| *c == comp && n == name) else {
            return;
        };
        if *k != key {
            return;
        }
        waiting.remove(i);
        *ok += confirmed as usize;
        let (total, ok, left) = (*total, *ok, waiting.len());
        let (sev, text, last) = if total == 1 {
            (sev, text.to_string(), true)
        } else if left > 0 {
            (
                Severity::INFO,
                format!("{total} parameters sent: {ok} confirmed, {left} waiting"),
                false,
            )
        } else if ok == total {
            (
                Severity::INFO,
                format!("{total} parameters set, each confirmed by its echo"),
                true,
            )
        } else {
            (
                Severity::WARNING,
                format!(
                    "{ok} of {total} parameters confirmed, {} not (see the messages)",
                    total - ok
                ),
                true,
            )
        };
        self.action_moves(sev, text, last);
    }

    /// An operator's mission request to `key` ended, done or not, with this notice.
    pub(super) fn mission_outcome(
        &mut self,
        key: VehicleKey,
        ask: crate::proto::mission::MissionAsk,
        sev: Severity,
        text: &str,
    ) {
        if self
            .ui
            .action
            .as_ref()
            .is_some_and(|a| !a.done && a.kind == ActionKind::Mission { key, ask })
        {
            self.action_moves(sev, text.to_string(), true);
        }
    }

    /// A file asked for was read: the action reading it is done with what was read, or the
    /// error (with its place: the file, its line).
    pub(super) fn read_outcome(&mut self, path: &std::path::Path, sev: Severity, text: String) {
        if self
            .ui
            .action
            .as_ref()
            .is_some_and(|a| !a.done && a.kind == ActionKind::Read(path.to_path_buf()))
        {
            self.action_moves(sev, text, true);
        }
    }

    /// The log list asked: done when it is whole (its count), or when it stopped short.
    pub(super) fn follow_log_list(&mut self) {
        let Some(ActionLine {
            kind: ActionKind::LogList { key, erase, at },
            done: false,
            ..
        }) = self.ui.action.as_ref()
        else {
            return;
        };
        let (key, erase, at) = (*key, *erase, *at);
        let Some(list) = self.sessions.get(&key).map(|s| &s.logs.list) else {
            return;
        };
        if !list.wanted || list.started < at {
            return;
        }
        let n = list.entries.len();
        let logs = if n == 1 { "log" } else { "logs" };
        let (sev, text) = if list.complete() {
            match erase {
                true if n == 0 => (Severity::INFO, format!("logs erased on {key}: none left")),
                true => (
                    Severity::WARNING,
                    format!("log erase on {key}: {n} {logs} still listed"),
                ),
                false => (Severity::INFO, format!("{key} has {n} {logs}")),
            }
        } else if let Some(why) = &list.failed {
            (
                Severity::WARNING,
                format!("log list of {key} incomplete: {why}"),
            )
        } else {
            return;
        };
        self.action_moves(sev, text, true);
    }

    /// Relabel the action started since the count was `since` (a command of the queue) with
    /// the operator's wording.
    pub(super) fn name_action(&mut self, since: u64, label: &str) {
        if self.ui.action_count == since {
            return;
        }
        if let Some(a) = self
            .ui
            .action
            .as_mut()
            .filter(|a| !a.done && a.kind == ActionKind::Command)
        {
            a.kind = ActionKind::Named(label.to_string());
            a.text = format!("{label}: sent");
        }
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

    /// A file was written (or not): the save that wrote it is done.
    pub(super) fn file_outcome(&mut self, path: &std::path::Path, error: Option<&str>) {
        let Some(ActionLine {
            kind: ActionKind::Save { path: p, what },
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
                format!("{what} saved to {}", path.display()),
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
