//! Keys: what each one does in each input mode, and the prompt's commands.
//!
//! Normal mode looks keys up in the screen's keymap section, then `[normal]`; help mode closes on
//! any key but its scrolling ones; the text modes (prompt, edit) type printable keys that are not
//! bound. Ctrl-C quits from every mode (raw mode has turned off SIGINT); while a vehicle is
//! armed, `q`, `:quit` and Ctrl-C ask first, and a second Ctrl-C or `:quit!` quits at once.

use super::flight::FlightAction;
use super::input::{parse_command, Command, COMMANDS};
use super::{links::LinkStatus, screen, App, Effect, Pane};
use crate::keymap::{Action, Key, KeyCode, Mode};
use crate::link::replay::ReplayCmd;
use crate::link::LinkSpec;
use crate::proto::vehicles::VehicleKey;
use crate::wire::Severity;

impl App {
    /// A key pressed.
    /// `repeat`: the terminal said the key repeats while held.
    pub(super) fn on_key(&mut self, key: Key, repeat: bool, fx: &mut Vec<Effect>) {
        self.dirty = true;
        if key == Key::ctrl('c') {
            self.quit_or_ask(true, fx);
            return;
        }
        if self.ui.confirm.is_some() {
            self.on_confirm_key(key, repeat, fx);
            return;
        }
        if self.nudge.active() && self.ui.mode == Mode::Normal {
            // The suspend key (Ctrl-Z) leaves Fly mode with its stop, then suspends.
            if self.keymap.lookup(Mode::Normal, self.ui.screen, &key) == Some(Action::Suspend) {
                self.notice(Severity::INFO, self.nudge.target, "Fly mode left".into());
                self.on_action(Action::Suspend, fx);
                return;
            }
            self.on_fly_key(key, fx);
            return;
        }
        let action = self.keymap.lookup(self.ui.mode, self.ui.screen, &key);
        if self.ui.palette.is_some() && self.ui.mode == Mode::Edit {
            self.on_palette_key(key, action, fx);
            return;
        }
        if self.ui.mode_picker.is_some() && self.ui.mode == Mode::Edit {
            self.on_mode_picker_key(key, action, fx);
            return;
        }
        if self.ui.params.editing.is_some() && self.ui.mode == Mode::Edit {
            self.on_param_edit_key(key, action, fx);
            return;
        }
        if self.ui.inspector.editing.is_some() && self.ui.mode == Mode::Edit {
            self.on_inspector_edit_key(key, action, fx);
            return;
        }
        match self.ui.mode {
            Mode::Normal => {
                self.ui.message = None;
                if let Some(a) = action {
                    self.on_action(a, fx);
                }
            }
            Mode::Help => match action {
                Some(a @ (Action::Up | Action::Down | Action::PageUp | Action::PageDown)) => {
                    let step: isize = match a {
                        Action::Up => -1,
                        Action::Down => 1,
                        Action::PageUp => -10,
                        _ => 10,
                    };
                    self.ui.help_scroll = (self.ui.help_scroll as isize + step).max(0) as usize;
                }
                Some(Action::Top) => self.ui.help_scroll = 0,
                Some(Action::Bottom) => self.ui.help_scroll = usize::MAX / 2,
                // Any other key closes the help, `q` included: it does not quit from here.
                _ => {
                    self.ui.mode = Mode::Normal;
                    self.ui.show_outcomes = false;
                }
            },
            Mode::Prompt | Mode::Edit => self.on_text_key(key, action, fx),
        }
    }

    /// Open the prompt with `text` typed; with `list`, show its completions at once.
    fn open_prompt_with(&mut self, text: &str, list: bool) {
        self.ui.prompt.open();
        self.ui.prompt.line.set(text);
        self.ui.mode = Mode::Prompt;
        if list {
            let candidates = self.completions();
            let several = self.ui.prompt.complete(&candidates);
            self.ui.message = (!several.is_empty()).then(|| (Severity::INFO, several.join("  ")));
        }
    }

    fn open_help(&mut self) {
        self.ui.help_scroll = 0;
        self.ui.show_outcomes = false;
        self.ui.mode = Mode::Help;
    }

    /// Show screen `i` (0 = `screen_1`) if this build has it.
    fn show_screen(&mut self, i: usize) {
        match screen::by_action_index(i) {
            Some(s) => self.ui.screen = s.name,
            None => {
                let name = crate::keymap::SCREENS.get(i).copied().unwrap_or("?");
                self.ui.message = Some((
                    Severity::WARNING,
                    format!("no {name} screen in this build yet"),
                ))
            }
        }
    }

    /// A key in a text mode: editing actions, or a printable character typed.
    fn on_text_key(&mut self, key: Key, action: Option<Action>, fx: &mut Vec<Effect>) {
        self.ui.message = None; // completions shown for the line as it was
        let prompt = self.ui.mode == Mode::Prompt;
        if prompt && action == Some(Action::Complete) && self.cycle_mode_word() {
            return;
        }
        let line = if prompt {
            &mut self.ui.prompt.line
        } else {
            &mut self.ui.edit
        };
        match action {
            Some(Action::Submit) => {
                self.ui.mode = Mode::Normal;
                if prompt {
                    let text = self.ui.prompt.submit();
                    if !text.is_empty() {
                        self.run_line(&text, fx);
                    }
                }
            }
            Some(Action::Cancel) => {
                self.ui.mode = Mode::Normal;
                self.ui.message = None;
            }
            Some(Action::CursorLeft) => line.left(),
            Some(Action::CursorRight) => line.right(),
            Some(Action::LineStart) => line.home(),
            Some(Action::LineEnd) => line.end(),
            Some(Action::DeleteBack) => line.backspace(),
            Some(Action::DeleteForward) => line.delete(),
            Some(Action::DeleteWord) => line.delete_word(),
            Some(Action::ClearLine) => line.clear(),
            Some(Action::HistoryPrev) if prompt => self.ui.prompt.history_prev(),
            Some(Action::HistoryNext) if prompt => self.ui.prompt.history_next(),
            Some(Action::Complete) if prompt => {
                let candidates = self.completions();
                let several = self.ui.prompt.complete(&candidates);
                self.ui.message =
                    (!several.is_empty()).then(|| (Severity::INFO, several.join("  ")));
            }
            Some(_) => {}
            None => {
                if let (KeyCode::Char(c), false, false) = (key.code, key.ctrl, key.alt) {
                    line.insert(c);
                }
            }
        }
    }

    /// The target's mode names (its profile's mode table), lower case as `mode` takes them.
    pub fn target_modes(&self) -> Vec<String> {
        self.target
            .and_then(|k| self.vehicles.get(k))
            .map(|v| crate::proto::modes::mode_names(v.autopilot, v.mavtype))
            .unwrap_or_default()
            .into_iter()
            .map(|m| m.to_ascii_lowercase())
            .collect()
    }

    /// The modes the open picker lists: the target's modes containing what is typed.
    pub fn mode_picker_rows(&self) -> Vec<String> {
        let query = self
            .ui
            .mode_picker
            .as_ref()
            .map_or(String::new(), |p| p.query.text.trim().to_ascii_lowercase());
        self.target_modes()
            .into_iter()
            .filter(|m| m.contains(&query))
            .collect()
    }

    /// `M`: the mode picker, listing every mode of the target.
    fn open_mode_picker(&mut self) {
        if self.target_modes().is_empty() {
            self.ui.message = Some((
                Severity::ERROR,
                match self.target {
                    None => "no target vehicle".into(),
                    Some(_) => "no modes known for the target".into(),
                },
            ));
            return;
        }
        self.ui.mode_picker = Some(super::ModePicker::default());
        self.ui.mode = Mode::Edit;
    }

    /// A key while the mode picker is open: arrows move, typing filters, enter asks for the
    /// selected mode through the `mode` command (its questions unchanged), esc leaves.
    fn on_mode_picker_key(&mut self, key: Key, action: Option<Action>, fx: &mut Vec<Effect>) {
        self.ui.message = None;
        let rows = self.mode_picker_rows();
        let n = rows.len();
        let Some(p) = self.ui.mode_picker.as_mut() else {
            return;
        };
        let typed = match (key.code, key.ctrl, key.alt, action) {
            (KeyCode::Char(c), false, false, None) => Some(c),
            _ => None,
        };
        match action {
            Some(Action::Submit | Action::Complete) => match rows.get(p.sel).cloned() {
                Some(m) => {
                    self.ui.mode_picker = None;
                    self.ui.mode = Mode::Normal;
                    self.run_line(&format!("mode {m}"), fx);
                }
                None => self.ui.message = Some((Severity::ERROR, "no mode matches".into())),
            },
            Some(Action::Cancel) => {
                self.ui.mode_picker = None;
                self.ui.mode = Mode::Normal;
            }
            Some(Action::HistoryPrev) => p.sel = clamp(p.sel, -1, n),
            Some(Action::HistoryNext) => p.sel = clamp(p.sel, 1, n),
            Some(a) => {
                if p.query.edit(a) {
                    p.sel = 0;
                }
            }
            None => match (key.code, typed) {
                (_, Some(c)) => {
                    p.query.insert(c);
                    p.sel = 0;
                }
                (KeyCode::Up, _) => p.sel = clamp(p.sel, -1, n),
                (KeyCode::Down, _) => p.sel = clamp(p.sel, 1, n),
                (KeyCode::PageUp, _) => p.sel = clamp(p.sel, -10, n),
                (KeyCode::PageDown, _) => p.sel = clamp(p.sel, 10, n),
                _ => {}
            },
        }
    }

    /// `tab` on the prompt's `mode` word when it is empty or a whole mode name: the next of
    /// the target's modes, all of them listed. False when the line is anything else.
    fn cycle_mode_word(&mut self) -> bool {
        let line = &self.ui.prompt.line;
        if line.cursor != line.text.chars().count() {
            return false;
        }
        let Some(word) = line.text.strip_prefix("mode ") else {
            return false;
        };
        let word = word.to_string();
        let modes = self.target_modes();
        if modes.is_empty() || word.contains(' ') {
            return false;
        }
        let next = match modes.iter().position(|m| *m == word) {
            Some(i) => (i + 1) % modes.len(),
            None if word.is_empty() => 0,
            None => return false,
        };
        self.ui.prompt.line.set(&format!("mode {}", modes[next]));
        self.ui.prompt.line.end();
        self.ui.message = Some((Severity::INFO, modes.join("  ")));
        true
    }

    /// Whole-line completions for the prompt: command names for the first word, then each
    /// command's arguments.
    fn completions(&self) -> Vec<String> {
        let line = &self.ui.prompt.line;
        let before: String = line.text.chars().take(line.cursor).collect();
        if !before.contains(' ') {
            return COMMANDS.iter().map(|c| c.0.to_string()).collect();
        }
        let mut out = Vec::new();
        for k in self.targetable() {
            out.push(format!("target {k}"));
        }
        if let Some(v) = self.target.and_then(|k| self.vehicles.get(k)) {
            for m in crate::proto::modes::mode_names(v.autopilot, v.mavtype) {
                out.push(format!("mode {}", m.to_ascii_lowercase()));
            }
        }
        out.push("disarm force".into());
        out.extend(self.more_completions());
        out.push("signing setup".into());
        out.push("signing off".into());
        if !self.replay_links().is_empty() {
            for sub in [
                "pause", "resume", "step", "seek -10", "seek +10", "speed 1", "speed 0", "faster",
                "slower",
            ] {
                out.push(format!("replay {sub}"));
            }
        }
        for w in ["wp", "fence", "rally"] {
            for sub in ["load ", "save ", "upload", "download", "clear"] {
                out.push(format!("{w} {sub}"));
            }
        }
        out.push("wp set ".into());
        out.push("wp start".into());
        out.push("route auto".into());
        for i in 0..self.links.len() {
            out.push(format!("route {i}"));
        }
        for scheme in [
            "udpin:", "udpout:", "tcp:", "tcpin:", "serial:", "sim://", "tlog:",
        ] {
            out.push(format!("link {scheme}"));
        }
        out
    }

    /// Run a prompt line; its outcome is shown in the status bar.
    fn run_line(&mut self, line: &str, fx: &mut Vec<Effect>) {
        // `:quit!` quits without asking, armed or not.
        if matches!(line.trim(), "quit!" | "q!" | "exit!") {
            self.ui.message = None;
            self.quit_now(fx);
            return;
        }
        let outcome = match parse_command(line, self.cfg.takeoff_alt) {
            Err(e) => Err(e),
            Ok(cmd) => self.run_command(cmd, fx),
        };
        self.ui.message = match outcome {
            Ok(Some(text)) => Some((Severity::INFO, text)),
            Ok(None) => None,
            Err(e) => Some((Severity::ERROR, e)),
        };
    }

    /// Carry out a command: `Ok(Some(text))` to tell the operator what happened.
    fn run_command(
        &mut self,
        cmd: Command,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        match cmd {
            Command::Help => {
                self.open_help();
                Ok(None)
            }
            Command::Messages => {
                self.open_outcomes();
                Ok(None)
            }
            Command::Quit => {
                self.on_action(Action::Quit, fx);
                Ok(None)
            }
            Command::Target(sysid, compid) => {
                let key = self.autopilot(sysid, compid)?;
                self.target = Some(key);
                self.target_held = true;
                Ok(Some(format!("target {key}")))
            }
            Command::Link(text) => {
                let spec: LinkSpec = text.parse().map_err(|e| format!("{e}"))?;
                let link = self.links.len();
                let name = spec.to_string();
                self.links.push(LinkStatus::new(
                    name.clone(),
                    self.cfg.sysid,
                    self.cfg.compid,
                ));
                self.cfg.links.push(name.clone());
                fx.push(Effect::OpenLink { link, spec });
                Ok(Some(format!("link {link}: opening {name}")))
            }
            Command::Flight(action) => self.flight(action, fx),
            Command::Replay(cmd) => self.replay_control(cmd, fx).map(Some),
            Command::Param(cmd) => self.run_param(cmd, fx),
            Command::Mission(cmd) => self.run_mission(cmd, fx),
            Command::Signing(cmd) => self.run_signing(cmd),
            Command::Camera(cmd) => self.run_camera(cmd, fx),
            Command::Log(cmd) => self.run_log(cmd, fx),
            Command::ParamMeta(cmd) => self.run_param_meta(cmd, fx),
            Command::ModeNumber(n) => self.run_mode_number(n, fx),
            Command::Prearm => self.run_prearm(fx),
            Command::Cal(cmd) => self.run_cal(cmd, fx),
            Command::Route(link) => {
                let key = self.target.ok_or("no target vehicle")?;
                if let Some(l) = link.filter(|&l| l >= self.links.len()) {
                    return Err(format!("no link {l} (links 0 to {})", self.links.len() - 1));
                }
                let s = self
                    .sessions
                    .get_mut(&key)
                    .ok_or_else(|| format!("{key} has no session"))?;
                s.pinned = link;
                Ok(Some(match link {
                    Some(l) => format!("{key} goes by link {l}"),
                    None => format!("{key} goes by the link heard last"),
                }))
            }
        }
    }

    /// The autopilot `sysid[:compid]` names, or why none does.
    fn autopilot(&self, sysid: u8, compid: Option<u8>) -> Result<VehicleKey, String> {
        let found = self
            .vehicles
            .iter()
            .filter(|v| v.sysid == sysid && compid.is_none_or(|c| c == v.compid))
            .find(|v| v.is_autopilot() || self.sessions.contains_key(&v.key()));
        match found {
            Some(v) => Ok(v.key()),
            None => {
                let heard: Vec<String> = self.targetable().iter().map(|k| k.to_string()).collect();
                let what = match compid {
                    Some(c) => VehicleKey(sysid, c).to_string(),
                    None => format!("{sysid}"),
                };
                Err(if heard.is_empty() {
                    format!("no autopilot {what} heard (none heard yet)")
                } else {
                    format!(
                        "no autopilot {what} heard (autopilots: {})",
                        heard.join(", ")
                    )
                })
            }
        }
    }

    /// Vehicles that can be targeted, in registry order.
    pub fn targetable(&self) -> Vec<VehicleKey> {
        // Autopilots, and payloads alone on their system (they have a session of their own).
        self.vehicles
            .iter()
            .filter(|v| v.is_autopilot() || self.sessions.contains_key(&v.key()))
            .map(|v| v.key())
            .collect()
    }

    fn cycle_target(&mut self, forward: bool) {
        let keys = self.targetable();
        if keys.is_empty() {
            return;
        }
        let pos = self.target.and_then(|t| keys.iter().position(|k| *k == t));
        let next = match (pos, forward) {
            (None, _) => 0,
            (Some(i), true) => (i + 1) % keys.len(),
            (Some(i), false) => (i + keys.len() - 1) % keys.len(),
        };
        self.target = Some(keys[next]);
        self.target_held = true;
    }

    /// Carry out an action bound in normal mode: each group of actions has its own handler.
    pub fn on_action(&mut self, action: Action, fx: &mut Vec<Effect>) {
        self.dirty = true;
        match action {
            // A nudge in progress ends in a stop before anything else; while a vehicle is
            // armed, asks first.
            Action::Quit => self.quit_or_ask(false, fx),
            // The terminal front end stops the process (headless runs have nothing to suspend),
            // once a nudge in progress has ended in its stop, sent three times.
            Action::Suspend => {
                self.leave_fly(fx);
                self.suspend = true;
            }
            Action::FocusNext
            | Action::FocusPrev
            | Action::Up
            | Action::Down
            | Action::PageUp
            | Action::PageDown
            | Action::Top
            | Action::Bottom
            | Action::ToggleExpand
            | Action::NextVehicle
            | Action::PrevVehicle
            | Action::Screen(_)
            | Action::Cancel => self.on_navigation_action(action),
            Action::MsgSeverity
            | Action::MsgSeverityBack
            | Action::MsgVehicle
            | Action::MsgVehicleBack => self.on_message_filter(action),
            Action::Help => self.open_help(),
            Action::Prompt => {
                self.ui.prompt.open();
                self.ui.mode = Mode::Prompt;
            }
            Action::Palette => self.open_palette(),
            Action::Outcomes => self.open_outcomes(),
            Action::Arm
            | Action::Disarm
            | Action::Land
            | Action::Rtl
            | Action::Takeoff
            | Action::ModeMenu
            | Action::Fly
            | Action::Reissue
            | Action::CancelCommand => self.on_flight_action(action, fx),
            Action::ParamFilter
            | Action::ParamEdit
            | Action::ParamFetch
            | Action::ParamOnlyDiff => self.on_param_action(action, fx),
            Action::InspectorRate | Action::InspectorFilter | Action::InspectorDetail => {
                self.on_inspector_action(action)
            }
            Action::CameraShoot
            | Action::CameraVideo
            | Action::CameraMode
            | Action::CameraNext
            | Action::CameraZoomIn
            | Action::CameraZoomOut
            | Action::CameraFocusFar
            | Action::CameraFocusNear
            | Action::GimbalUp
            | Action::GimbalDown
            | Action::GimbalLeft
            | Action::GimbalRight
            | Action::GimbalCenter => self.on_camera_action(action, fx),
            Action::LogDownload
            | Action::LogLatest
            | Action::LogCancel
            | Action::LogErase
            | Action::LogRefresh => self.on_log_action(action, fx),
            Action::HealthPrearm
            | Action::CalNext
            | Action::CalGyro
            | Action::CalBaro
            | Action::CalLevel
            | Action::CalAccel
            | Action::CalSimpleAccel
            | Action::CalCompass
            | Action::CalAccept
            | Action::CalCancel => self.on_health_action(action, fx),
            Action::MissionList
            | Action::MissionSource
            | Action::MissionDownload
            | Action::MissionUpload
            | Action::MissionStart
            | Action::MissionSetCurrent
            | Action::MissionGoto => self.on_mission_action(action, fx),
            Action::ReplaySlower | Action::ReplayFaster if self.map_takes_speed_keys() => {
                self.on_map_action(action, fx)
            }
            Action::MissionAddAtCursor
            | Action::MapZoomIn
            | Action::MapZoomOut
            | Action::MapLeft
            | Action::MapRight
            | Action::MapCentre
            | Action::MapFit
            | Action::MapHeadingUp
            | Action::MapCursor
            | Action::MapGoto => self.on_map_action(action, fx),
            Action::ReplayPause
            | Action::ReplayStep
            | Action::ReplayBack
            | Action::ReplayForward
            | Action::ReplaySlower
            | Action::ReplayFaster => self.on_replay_action(action, fx),
            // Text-line actions belong to the prompt and edit modes.
            Action::Submit
            | Action::CursorLeft
            | Action::CursorRight
            | Action::LineStart
            | Action::LineEnd
            | Action::DeleteBack
            | Action::DeleteForward
            | Action::DeleteWord
            | Action::ClearLine
            | Action::HistoryPrev
            | Action::HistoryNext
            | Action::Complete => {}
        }
    }

    /// Focus, selection, expanding a row, the target, the screen shown.
    fn on_navigation_action(&mut self, action: Action) {
        let focus_idx = Pane::ALL
            .iter()
            .position(|p| *p == self.ui.focus)
            .unwrap_or(0);
        match action {
            Action::FocusNext => self.ui.focus = Pane::ALL[(focus_idx + 1) % Pane::ALL.len()],
            Action::FocusPrev => {
                self.ui.focus = Pane::ALL[(focus_idx + Pane::ALL.len() - 1) % Pane::ALL.len()]
            }
            Action::Up | Action::Down | Action::PageUp | Action::PageDown => {
                let step: isize = match action {
                    Action::Up => -1,
                    Action::Down => 1,
                    Action::PageUp => -10,
                    _ => 10,
                };
                self.move_selection(step);
            }
            // Far enough to clamp at either end of any list.
            Action::Top => self.move_selection(-(1 << 30)),
            Action::Bottom => self.move_selection(1 << 30),
            Action::ToggleExpand => {
                if self.ui.focus == Pane::Links {
                    if let Some(l) = self.links.get_mut(self.ui.link_sel) {
                        l.expanded = !l.expanded;
                    }
                } else if self.ui.focus == Pane::Vehicles {
                    // Only an autopilot (or a payload alone on its system) can be the target;
                    // other gimbals, cameras and ground stations are reached through their
                    // autopilot, from their own screens.
                    let v = self.vehicles.iter().nth(self.ui.vehicle_sel);
                    let sessions = &self.sessions;
                    if let Some(v) =
                        v.filter(|v| v.is_autopilot() || sessions.contains_key(&v.key()))
                    {
                        self.target = Some(v.key());
                        self.target_held = true;
                    }
                }
            }
            Action::NextVehicle => self.cycle_target(true),
            Action::PrevVehicle => self.cycle_target(false),
            Action::Screen(i) => self.show_screen(i as usize),
            // On the Inspector, esc gives the keys back to the list.
            Action::Cancel => self.ui.inspector.detail_focus = false,
            _ => {}
        }
    }

    /// Flying the target: arm, disarm, land, RTL at once (or after a question), take-off and
    /// mode through the prompt, Fly mode, and the Commands screen's re-issue and cancel.
    fn on_flight_action(&mut self, action: Action, fx: &mut Vec<Effect>) {
        let outcome = match action {
            Action::Arm | Action::Disarm | Action::Land | Action::Rtl => {
                let what = match action {
                    Action::Arm => FlightAction::Arm,
                    Action::Disarm => FlightAction::Disarm { force: false },
                    Action::Land => FlightAction::Land,
                    _ => FlightAction::Rtl,
                };
                self.flight(what, fx)
            }
            Action::Takeoff => {
                let line = format!("takeoff {}", self.cfg.takeoff_alt);
                self.open_prompt_with(&line, false);
                return;
            }
            Action::ModeMenu => {
                self.open_mode_picker();
                return;
            }
            Action::Fly => self.enter_fly(),
            Action::Reissue => self.reissue_selected(fx),
            Action::CancelCommand => self.cancel_selected(fx),
            _ => return,
        };
        self.ui.message = match outcome {
            Ok(t) => t.map(|t| (Severity::INFO, t)),
            Err(e) => Some((Severity::ERROR, e)),
        };
    }

    /// Pause, step, seek and change the speed of the replay.
    fn on_replay_action(&mut self, action: Action, fx: &mut Vec<Effect>) {
        let step = super::replay::SEEK_STEP * crate::clock::SECOND as i64;
        let cmd = match action {
            Action::ReplayPause => ReplayCmd::TogglePause,
            Action::ReplayStep => ReplayCmd::Step(1),
            Action::ReplayBack => ReplayCmd::Seek(-step),
            Action::ReplayForward => ReplayCmd::Seek(step),
            Action::ReplaySlower => ReplayCmd::Slower,
            Action::ReplayFaster => ReplayCmd::Faster,
            _ => return,
        };
        // What it did shows in the status bar's replay state; only a refusal is told.
        if let Err(e) = self.replay_control(cmd, fx) {
            self.ui.message = Some((Severity::ERROR, e));
        }
    }

    fn move_selection(&mut self, step: isize) {
        if let Some(select) = screen::by_name(self.ui.screen).and_then(|s| s.select) {
            select(self, step);
            return;
        }
        match self.ui.focus {
            Pane::Vehicles => {
                self.ui.vehicle_sel = clamp(self.ui.vehicle_sel, step, self.vehicles.len())
            }
            Pane::Links => self.ui.link_sel = clamp(self.ui.link_sel, step, self.links.len()),
            Pane::Messages => self.scroll_messages(step),
        }
    }

    /// The Parameters screen's selection ([`screen::Screen::select`]).
    pub(super) fn select_parameters(&mut self, step: isize) {
        let n = self.param_rows().len();
        self.ui.params.sel = clamp(self.ui.params.sel, step, n);
    }

    /// The MAVLink Inspector's selection.
    pub(super) fn select_inspector(&mut self, step: isize) {
        self.move_inspector(step);
    }

    /// The Mission screen's selection.
    pub(super) fn select_mission(&mut self, step: isize) {
        let n = self.mission_rows().len();
        self.ui.mission.sel = clamp(self.ui.mission.sel, step, n);
    }

    /// The Commands screen's selection: kept on its command by queue id.
    pub(super) fn select_commands(&mut self, step: isize) {
        let n = self
            .target
            .and_then(|k| self.sessions.get(&k))
            .map_or(0, |s| s.commands.entries().len());
        self.ui.cmd_sel = clamp(self.ui.cmd_sel, step, n);
        self.ui.cmd_sel_id = self.command_id_at(self.ui.cmd_sel);
    }
}

/// `v` moved by `step`, clamped to a list of `len` rows.
fn clamp(v: usize, step: isize, len: usize) -> usize {
    if len == 0 {
        return 0;
    }
    (v as isize + step).clamp(0, len as isize - 1) as usize
}
