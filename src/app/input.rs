//! Typed input: a text line with a cursor, the `:` prompt around it (history, completion), and
//! the commands the prompt runs.
//!
//! Commands are words: the first names the command, the rest are its arguments. A later feature
//! adds its commands to [`COMMANDS`] and a branch in `App::run_command`.

/// Characters a line holds at most (a long path fits; a runaway paste stops here).
pub const MAX_LINE: usize = 4096;

/// A line of text with a cursor (a char index, 0..=len), at most [`MAX_LINE`] characters.
/// Typing at the end (what typing and pasting do) is O(1) amortised: the length in characters
/// is kept, and an ASCII line's char index is its byte index.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct TextLine {
    pub text: String,
    pub cursor: usize,
    /// `text` in characters.
    chars: usize,
}

impl TextLine {
    fn byte(&self, char_idx: usize) -> usize {
        if char_idx >= self.chars {
            return self.text.len();
        }
        if self.chars == self.text.len() {
            return char_idx;
        }
        self.text
            .char_indices()
            .nth(char_idx)
            .map_or(self.text.len(), |(b, _)| b)
    }
    fn len(&self) -> usize {
        self.chars
    }
    pub fn set(&mut self, text: &str) {
        self.text = text.chars().take(MAX_LINE).collect();
        self.chars = self.text.chars().count();
        self.cursor = self.chars;
    }
    /// Take the text out, leaving the line empty.
    pub fn take(&mut self) -> String {
        self.chars = 0;
        self.cursor = 0;
        std::mem::take(&mut self.text)
    }
    /// True when the line holds [`MAX_LINE`] characters: nothing more is typed.
    pub fn full(&self) -> bool {
        self.chars >= MAX_LINE
    }
    /// Type `c` at the cursor (nothing when the line is full).
    pub fn insert(&mut self, c: char) {
        if self.full() {
            return;
        }
        let b = self.byte(self.cursor);
        if b == self.text.len() {
            self.text.push(c);
        } else {
            self.text.insert(b, c);
        }
        self.chars += 1;
        self.cursor += 1;
    }
    /// Paste `text` at the cursor, as one edit: line breaks and tabs become spaces (a pasted
    /// newline never runs the line), other control characters are left out. False when the
    /// line filled before the paste ended.
    pub fn paste(&mut self, text: &str) -> bool {
        self.cursor = self.cursor.min(self.chars);
        let b = self.byte(self.cursor);
        let tail = self.text.split_off(b);
        let tail_chars = self.chars - self.cursor;
        self.chars = self.cursor;
        let mut whole = true;
        for c in text.chars() {
            let c = match c {
                '\n' | '\r' | '\t' => ' ',
                c if c.is_control() => continue,
                c => c,
            };
            if self.chars + tail_chars >= MAX_LINE {
                whole = false;
                break;
            }
            self.text.push(c);
            self.chars += 1;
        }
        self.cursor = self.chars;
        self.text.push_str(&tail);
        self.chars += tail_chars;
        whole
    }
    pub fn left(&mut self) {
        self.cursor = self.cursor.saturating_sub(1);
    }
    pub fn right(&mut self) {
        self.cursor = (self.cursor + 1).min(self.len());
    }
    pub fn home(&mut self) {
        self.cursor = 0;
    }
    pub fn end(&mut self) {
        self.cursor = self.len();
    }
    pub fn backspace(&mut self) {
        if self.cursor > 0 {
            self.cursor -= 1;
            let b = self.byte(self.cursor);
            self.text.remove(b);
            self.chars -= 1;
        }
    }
    pub fn delete(&mut self) {
        if self.cursor < self.len() {
            let b = self.byte(self.cursor);
            self.text.remove(b);
            self.chars -= 1;
        }
    }
    /// Delete the word before the cursor (and the spaces after it), like a shell's ctrl-w.
    pub fn delete_word(&mut self) {
        let chars: Vec<char> = self.text.chars().collect();
        let mut start = self.cursor;
        while start > 0 && chars[start - 1] == ' ' {
            start -= 1;
        }
        while start > 0 && chars[start - 1] != ' ' {
            start -= 1;
        }
        let (a, b) = (self.byte(start), self.byte(self.cursor));
        self.text.replace_range(a..b, "");
        self.chars -= self.cursor - start;
        self.cursor = start;
    }
    pub fn clear(&mut self) {
        self.text.clear();
        self.chars = 0;
        self.cursor = 0;
    }

    /// Apply a line-editing action; false for an action that is not one.
    pub fn edit(&mut self, action: crate::keymap::Action) -> bool {
        use crate::keymap::Action::*;
        match action {
            CursorLeft => self.left(),
            CursorRight => self.right(),
            LineStart => self.home(),
            LineEnd => self.end(),
            DeleteBack => self.backspace(),
            DeleteForward => self.delete(),
            DeleteWord => self.delete_word(),
            ClearLine => self.clear(),
            _ => return false,
        }
        true
    }
}

/// Lines kept in the prompt's history.
pub const HISTORY: usize = 100;

/// The `:` command line.
#[derive(Debug, Clone, Default)]
pub struct Prompt {
    pub line: TextLine,
    history: Vec<String>,
    /// Position while browsing history (`None`: editing a new line).
    browsing: Option<usize>,
    /// The line being typed before history browsing began.
    draft: String,
}

impl Prompt {
    /// Start a new line.
    pub fn open(&mut self) {
        self.line.clear();
        self.browsing = None;
    }

    /// Take the line for running, remembering it in the history.
    pub fn submit(&mut self) -> String {
        let text = self.line.take().trim().to_string();
        self.browsing = None;
        if !text.is_empty() && self.history.last() != Some(&text) {
            if self.history.len() == HISTORY {
                self.history.remove(0);
            }
            self.history.push(text.clone());
        }
        text
    }

    pub fn history_prev(&mut self) {
        let i = match self.browsing {
            None if self.history.is_empty() => return,
            None => {
                self.draft = self.line.text.clone();
                self.history.len() - 1
            }
            Some(0) => 0,
            Some(i) => i - 1,
        };
        self.browsing = Some(i);
        self.line.set(&self.history[i]);
    }

    pub fn history_next(&mut self) {
        match self.browsing {
            None => {}
            Some(i) if i + 1 < self.history.len() => {
                self.browsing = Some(i + 1);
                self.line.set(&self.history[i + 1]);
            }
            Some(_) => {
                self.browsing = None;
                let draft = std::mem::take(&mut self.draft);
                self.line.set(&draft);
            }
        }
    }

    pub fn history(&self) -> &[String] {
        &self.history
    }

    /// Complete the word under the cursor from `candidates` (whole replacements for the line's
    /// text before the cursor). One match is taken with a space after it; several complete to
    /// their common prefix and are returned so the caller can show them.
    pub fn complete(&mut self, candidates: &[String]) -> Vec<String> {
        let before: String = self.line.text.chars().take(self.line.cursor).collect();
        let matches: Vec<String> = candidates
            .iter()
            .filter(|c| c.starts_with(&before))
            .cloned()
            .collect();
        let after: String = self.line.text.chars().skip(self.line.cursor).collect();
        match matches.len() {
            0 => Vec::new(),
            1 => {
                let done = format!("{} ", matches[0]);
                self.line.set(&format!("{done}{after}"));
                self.line.cursor = done.chars().count();
                Vec::new()
            }
            _ => {
                let mut prefix = matches[0].clone();
                for m in &matches[1..] {
                    let common = prefix
                        .chars()
                        .zip(m.chars())
                        .take_while(|(a, b)| a == b)
                        .count();
                    prefix = prefix.chars().take(common).collect();
                }
                self.line.set(&format!("{prefix}{after}"));
                self.line.cursor = prefix.chars().count();
                matches
            }
        }
    }
}

/// The prompt's commands: (name, arguments, what it does), in the order `help` lists them.
pub const COMMANDS: &[(&str, &str, &str)] = &[
    ("arm", "[throttle]", "arm the target (asks first)"),
    (
        "disarm",
        "[force]",
        "disarm the target; force even in flight (asks first)",
    ),
    (
        "takeoff",
        "[METRES]",
        "GUIDED, arm, take off (10 m above home by default)",
    ),
    ("land", "", "land"),
    (
        "prearm",
        "",
        "ask the target for its pre-arm checks now (reasons on screen 8)",
    ),
    (
        "cal",
        "KIND|next|accept|cancel",
        "calibrate: gyro, baro, level, accel, simple-accel, compass, compass-fixed YAW",
    ),
    (
        "goto",
        "LAT LON [ALT]",
        "GUIDED: fly to a point (DO_REPOSITION; ALT above home, default current)",
    ),
    (
        "alt",
        "METRES",
        "GUIDED: climb/descend to METRES above home where it is",
    ),
    (
        "wp",
        "SUB …",
        "mission: load, save FILE (WPL or .plan); upload, download (list), clear, set N, start",
    ),
    (
        "fence",
        "SUB …",
        "geofence: load, save FILE; upload, download, clear",
    ),
    (
        "rally",
        "SUB …",
        "rally points: load, save FILE; upload, download, clear",
    ),
    ("rtl", "", "return to launch"),
    (
        "mode",
        "NAME|NUMBER",
        "change flight mode (tab lists the modes)",
    ),
    (
        "long",
        "CMD [P1..P7]",
        "any MAV_CMD by name or number (empty = 0, nan allowed)",
    ),
    ("reboot", "", "reboot the autopilot (asks first)"),
    (
        "param",
        "SUB …",
        "fetch; show, set NAME; save, load, diff FILE (.params: QGC's); encoding; meta fetch",
    ),
    (
        "camera",
        "SUB …",
        "mode, shoot [N [S]], stop, video start|stop, zoom, focus, format",
    ),
    (
        "log",
        "SUB …",
        "onboard logs: list; get ID|latest [FILE] [--hl]; erase; cancel",
    ),
    (
        "gimbal",
        "PITCH YAW",
        "point the gimbal (degrees; DO_GIMBAL_MANAGER_PITCHYAW)",
    ),
    ("help", "", "show the keys of this screen"),
    (
        "messages",
        "",
        "the results of the last 50 actions, newest last",
    ),
    (
        "link",
        "SPEC",
        "open another link (udpin:0.0.0.0:14550, tcp:HOST:PORT, …)",
    ),
    ("quit", "", "quit mavterm"),
    (
        "replay",
        "pause|resume|step|seek ±S|speed N",
        "control tlog: replays (seek -10, seek 1:30, speed 0 = max)",
    ),
    (
        "route",
        "LINK|auto",
        "send to the target on this link, or the most recent",
    ),
    (
        "signing",
        "[setup|off]",
        "signing state; send our key to the target, or turn it off (USB)",
    ),
    ("target", "SYSID[:COMPID]", "make this autopilot the target"),
];

/// What a parsed prompt line asks for.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    Help,
    /// List the actions' results, newest last.
    Messages,
    Quit,
    /// Make (sysid, compid) the target; compid `None`: the system's autopilot.
    Target(u8, Option<u8>),
    /// Open a link on this spec (parsed when run, so its error names the spec).
    Link(String),
    /// Pin the target's route to a link, or `None` for automatic.
    Route(Option<usize>),
    /// Fly the target.
    Flight(super::flight::FlightAction),
    /// Parameters of the target.
    Param(super::params::ParamCmd),
    /// MAVLink 2 signing: state, or set up / turn off on the target.
    Signing(super::signing::SigningCmd),
    /// Control the replay links.
    Replay(crate::link::replay::ReplayCmd),
    /// Operate the target's camera or gimbal.
    Camera(super::camera::CameraCmd),
    /// The target's onboard logs.
    Log(super::logs::LogCmd),
    /// Missions, fence, rally points; guided go-to and altitude.
    Mission(super::mission::MissionCmd),
    /// Change to the flight mode of this number in the target's mode table (`mode 4`).
    ModeNumber(u32),
    /// Parameter metadata and lookups: `param show`, `param meta fetch`.
    ParamMeta(super::param_meta::MetaCmd),
    /// Ask the target for its pre-arm checks now (RUN_PREARM_CHECKS).
    Prearm,
    /// Calibrations of the target.
    Cal(super::health::CalCmd),
}

/// Completions of the aliases and the `param` words, offered after the first word (with the
/// target's parameter names after `param show ` and `param set `).
pub const MORE_COMPLETIONS: &[&str] = &[
    "arm throttle",
    "param fetch",
    "param show",
    "param set",
    "param save",
    "param load",
    "param diff",
    "param meta fetch",
    "wp list",
];

/// A MAV_CMD by name (`NAV_TAKEOFF`, `mav_cmd_nav_takeoff`, `takeoff` when only one matches
/// as a whole word) or number.
pub fn parse_mav_cmd(word: &str) -> Result<u16, String> {
    use crate::dialect::MavCmd;
    use num_traits::FromPrimitive;
    if let Ok(n) = word.parse::<u16>() {
        return MavCmd::from_u16(n)
            .map(|_| n)
            .ok_or_else(|| format!("no MAV_CMD {n} in our dialect"));
    }
    let want = word.to_ascii_uppercase();
    let want = want.strip_prefix("MAV_CMD_").unwrap_or(&want).to_string();
    let mut hits = Vec::new();
    for n in 0..=u16::MAX {
        if let Some(c) = MavCmd::from_u16(n) {
            let name = format!("{c:?}");
            let short = name.strip_prefix("MAV_CMD_").unwrap_or(&name).to_string();
            if short == want {
                return Ok(n);
            }
            if short.split('_').any(|w| w == want) {
                hits.push((n, short));
            }
        }
    }
    // `takeoff` means NAV_TAKEOFF rather than NAV_VTOL_TAKEOFF: the name after its category.
    let exact: Vec<&(u16, String)> = hits
        .iter()
        .filter(|(_, s)| s.split_once('_').is_some_and(|(_, rest)| rest == want))
        .collect();
    if let [(n, _)] = exact.as_slice() {
        return Ok(*n);
    }
    match hits.as_slice() {
        [(n, _)] => Ok(*n),
        [] => Err(format!("no MAV_CMD called `{word}`")),
        many => Err(format!(
            "`{word}` could be {}",
            many.iter()
                .map(|h| h.1.as_str())
                .take(6)
                .collect::<Vec<_>>()
                .join(", ")
        )),
    }
}

/// A parameter value: a number, `nan`, or empty/`-` for 0.
pub fn parse_param(s: &str) -> Result<f64, String> {
    match s.to_ascii_lowercase().as_str() {
        "nan" => Ok(f64::NAN),
        "-" | "" => Ok(0.0),
        _ => s
            .parse::<f64>()
            .map_err(|_| format!("`{s}` is not a number (use a number, or nan)")),
    }
}

use super::flight::FlightAction;

/// Parse a prompt line; the error says what is wrong and what would be right. `takeoff_alt` is
/// the altitude of a `takeoff` without one ([`super::AppConfig::takeoff_alt`]).
pub fn parse_command(line: &str, takeoff_alt: f64) -> Result<Command, String> {
    let line = line.trim();
    let (word, rest) = line.split_once(char::is_whitespace).unwrap_or((line, ""));
    let rest = rest.trim();
    let no_args = |c: Command| {
        if rest.is_empty() {
            Ok(c)
        } else {
            Err(format!("`{word}` takes no arguments"))
        }
    };
    match word {
        "" => Err("type a command (tab lists them)".into()),
        "help" | "?" => no_args(Command::Help),
        "messages" => no_args(Command::Messages),
        "quit" | "q" | "exit" => no_args(Command::Quit),
        "target" => {
            let usage = || "usage: target SYSID[:COMPID], e.g. target 1 or target 1:1".to_string();
            let (s, c) = match rest.split_once(':') {
                Some((s, c)) => (s, Some(c)),
                None => (rest, None),
            };
            let sysid = s.parse::<u8>().map_err(|_| usage())?;
            let compid = match c {
                Some(c) => Some(c.parse::<u8>().map_err(|_| usage())?),
                None => None,
            };
            Ok(Command::Target(sysid, compid))
        }
        "link" if rest.is_empty() => Err("usage: link SPEC, e.g. link udpin:0.0.0.0:14550".into()),
        "link" => Ok(Command::Link(rest.to_string())),
        "route" => match rest {
            "auto" => Ok(Command::Route(None)),
            n => n
                .parse::<usize>()
                .map(|n| Command::Route(Some(n)))
                .map_err(|_| {
                    "usage: route LINK (its number in the Links pane) or route auto".into()
                }),
        },
        // `arm throttle`: MAVProxy's spelling.
        "arm" => match rest {
            "" | "throttle" => Ok(Command::Flight(FlightAction::Arm)),
            _ => Err("usage: arm, or arm throttle".into()),
        },
        "disarm" => match rest {
            "" => Ok(Command::Flight(FlightAction::Disarm { force: false })),
            "force" => Ok(Command::Flight(FlightAction::Disarm { force: true })),
            _ => Err("usage: disarm, or disarm force".into()),
        },
        "takeoff" => {
            let alt = if rest.is_empty() {
                takeoff_alt
            } else {
                rest.parse::<f64>()
                    .ok()
                    .filter(|a| a.is_finite() && *a > 0.0 && *a <= 10_000.0)
                    .ok_or_else(|| {
                        format!("usage: takeoff METRES (above home, e.g. takeoff 10), not `{rest}`")
                    })?
            };
            Ok(Command::Flight(FlightAction::Takeoff(alt)))
        }
        "land" => no_args(Command::Flight(FlightAction::Land)),
        "rtl" => no_args(Command::Flight(FlightAction::Rtl)),
        "reboot" => no_args(Command::Flight(FlightAction::Reboot)),
        "prearm" => no_args(Command::Prearm),
        "cal" => super::health::parse_cal(rest).map(Command::Cal),
        "param" => match super::param_meta::parse(rest) {
            Some(r) => r.map(Command::ParamMeta),
            None => super::params::parse(rest).map(Command::Param).map_err(|e| {
                if e == super::params::USAGE {
                    format!("{e} | param show NAME|GLOB | param meta fetch")
                } else {
                    e
                }
            }),
        },
        // `wp list`: MAVProxy's name for downloading the mission.
        "wp" if rest == "list" => super::mission::parse(word, "download").map(Command::Mission),
        "wp" | "fence" | "rally" => super::mission::parse(word, rest).map(Command::Mission),
        "goto" => super::mission::parse_goto(rest).map(Command::Mission),
        "alt" => super::mission::parse_alt(rest).map(Command::Mission),
        "signing" => {
            use super::signing::SigningCmd;
            match rest {
                "" | "status" => Ok(Command::Signing(SigningCmd::Status)),
                "setup" => Ok(Command::Signing(SigningCmd::Setup)),
                "off" | "remove" => Ok(Command::Signing(SigningCmd::Off)),
                _ => Err(
                    "usage: signing, signing setup (send our key to the target), or signing off"
                        .into(),
                ),
            }
        }
        "replay" => super::replay::parse(rest).map(Command::Replay),
        "camera" => super::camera::parse(rest).map(Command::Camera),
        "log" => super::logs::parse(rest).map(Command::Log),
        "gimbal" => super::camera::parse_gimbal(rest).map(Command::Camera),
        "mode" if rest.is_empty() || rest.contains(' ') => Err(
            "usage: mode NAME or NUMBER, e.g. mode guided or mode 4 (tab lists the modes)".into(),
        ),
        "mode" if rest.bytes().all(|b| b.is_ascii_digit()) => rest
            .parse::<u32>()
            .map(Command::ModeNumber)
            .map_err(|_| format!("no mode number {rest}")),
        "mode" => Ok(Command::Flight(FlightAction::Mode(rest.to_string()))),
        "long" => {
            let mut words = rest.split_whitespace();
            let cmd = words.next().ok_or(
                "usage: long MAV_CMD_NAME|NUMBER [P1 .. P7], e.g. long NAV_TAKEOFF 0 0 0 0 0 0 10",
            )?;
            let command = parse_mav_cmd(cmd)?;
            let mut params = [0.0f64; 7];
            for (i, w) in words.enumerate() {
                if i >= 7 {
                    return Err("at most 7 parameters".into());
                }
                params[i] = parse_param(w)?;
            }
            Ok(Command::Flight(FlightAction::Command { command, params }))
        }
        other => {
            let names: Vec<&str> = COMMANDS.iter().map(|c| c.0).collect();
            Err(format!(
                "unknown command `{other}` (commands: {})",
                names.join(", ")
            ))
        }
    }
}

impl super::App {
    /// [`MORE_COMPLETIONS`], and the target's parameter names once `param show ` or
    /// `param set ` is typed.
    pub(super) fn more_completions(&self) -> Vec<String> {
        let mut out: Vec<String> = MORE_COMPLETIONS.iter().map(|c| c.to_string()).collect();
        let line = &self.ui.prompt.line.text;
        for sub in ["param show ", "param set "] {
            if line.starts_with(sub) {
                if let Some(set) = self.param_set() {
                    out.extend(set.params.keys().map(|n| format!("{sub}{n}")));
                }
            }
        }
        out
    }

    /// `mode NUMBER`: the mode of that number in the target's mode table, changed to exactly as
    /// `mode NAME` would.
    pub(super) fn run_mode_number(
        &mut self,
        number: u32,
        fx: &mut Vec<super::Effect>,
    ) -> Result<Option<String>, String> {
        use crate::proto::modes;
        let key = self.target.ok_or("no target vehicle")?;
        let v = self.vehicles.get(key).ok_or("no target vehicle")?;
        let (autopilot, mavtype) = (v.autopilot, v.mavtype);
        let name = modes::mode_name(autopilot, mavtype, number);
        if modes::mode_number(autopilot, mavtype, &name) != Some(number) {
            return Err(format!(
                "no mode number {number} on this vehicle (tab lists the modes by name)"
            ));
        }
        self.flight(FlightAction::Mode(name.to_ascii_lowercase()), fx)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_line_edits_at_the_cursor() {
        let mut l = TextLine::default();
        for c in "targt 1".chars() {
            l.insert(c);
        }
        for _ in 0..3 {
            l.left();
        }
        l.insert('e');
        assert_eq!(l.text, "target 1");
        l.end();
        l.delete_word();
        assert_eq!((l.text.as_str(), l.cursor), ("target ", 7));
        l.home();
        l.delete();
        assert_eq!(l.text, "arget ");
        l.backspace(); // nothing before the cursor
        assert_eq!(l.text, "arget ");
        let mut u = TextLine::default();
        for c in "ñé°".chars() {
            u.insert(c);
        }
        u.left();
        u.backspace();
        assert_eq!(u.text, "ñ°");
    }

    #[test]
    fn history_walks_back_and_returns_to_the_draft() {
        let mut p = Prompt::default();
        for cmd in ["target 1", "link tcp:a:1"] {
            p.open();
            p.line.set(cmd);
            p.submit();
        }
        p.open();
        p.line.set("dra");
        p.history_prev();
        assert_eq!(p.line.text, "link tcp:a:1");
        p.history_prev();
        assert_eq!(p.line.text, "target 1");
        p.history_prev();
        assert_eq!(p.line.text, "target 1");
        p.history_next();
        p.history_next();
        assert_eq!(p.line.text, "dra");
    }

    #[test]
    fn completion_takes_one_match_and_the_common_prefix_of_several() {
        let mut p = Prompt::default();
        p.line.set("ta");
        let c = vec!["target".to_string(), "link".to_string()];
        assert!(p.complete(&c).is_empty());
        assert_eq!(p.line.text, "target ");
        p.line.set("target ");
        let c = vec!["target 1:1".to_string(), "target 12:1".to_string()];
        assert_eq!(p.complete(&c).len(), 2);
        assert_eq!(p.line.text, "target 1");
    }

    #[test]
    fn commands_parse_with_clear_errors() {
        let parse = |line| parse_command(line, 10.0);
        assert_eq!(parse(" quit "), Ok(Command::Quit));
        assert_eq!(parse("target 1"), Ok(Command::Target(1, None)));
        assert_eq!(parse("target 2:1"), Ok(Command::Target(2, Some(1))));
        assert_eq!(
            parse("link udpin:0.0.0.0:14550"),
            Ok(Command::Link("udpin:0.0.0.0:14550".into()))
        );
        assert_eq!(parse("route auto"), Ok(Command::Route(None)));
        assert_eq!(parse("route 2"), Ok(Command::Route(Some(2))));
        assert!(parse("target 300").unwrap_err().contains("usage"));
        assert!(parse("quit now").unwrap_err().contains("no arguments"));
        let e = parse("jump").unwrap_err();
        assert!(
            e.contains("unknown command `jump`") && e.contains("target"),
            "{e}"
        );
        assert_eq!(
            parse("takeoff"),
            Ok(Command::Flight(FlightAction::Takeoff(10.0)))
        );
        assert_eq!(
            parse_command("takeoff", 15.0),
            Ok(Command::Flight(FlightAction::Takeoff(15.0)))
        );
        assert!(parse("takeoff high").unwrap_err().contains("METRES"));
        assert_eq!(
            parse("disarm force"),
            Ok(Command::Flight(FlightAction::Disarm { force: true }))
        );
        match parse("long NAV_TAKEOFF 0 - 0 nan 0 0 12.5") {
            Ok(Command::Flight(FlightAction::Command { command, params })) => {
                assert_eq!(command, 22);
                assert_eq!(params[6], 12.5);
                assert!(params[3].is_nan());
            }
            other => panic!("{other:?}"),
        }
        assert!(parse("long 400 x").unwrap_err().contains("not a number"));
        assert_eq!(parse_mav_cmd("takeoff"), Ok(22));
        assert_eq!(parse_mav_cmd("mav_cmd_component_arm_disarm"), Ok(400));
        assert_eq!(parse_mav_cmd("511"), Ok(511));
        assert!(parse_mav_cmd("nosuch").is_err());
    }

    #[test]
    fn mavproxy_aliases_parse_to_the_same_commands() {
        use super::super::mission::{MissionCmd, MissionOp};
        use super::super::param_meta::MetaCmd;
        use crate::mission::MissionType;
        let parse = |line| parse_command(line, 10.0);
        assert_eq!(parse("arm throttle"), parse("arm"));
        assert!(parse("arm now").unwrap_err().contains("arm throttle"));
        assert_eq!(parse("mode 4"), Ok(Command::ModeNumber(4)));
        assert_eq!(
            parse("mode guided"),
            Ok(Command::Flight(FlightAction::Mode("guided".into())))
        );
        assert!(parse("mode 99999999999").is_err());
        assert_eq!(
            parse("wp list"),
            Ok(Command::Mission(MissionCmd::List(
                MissionType::Mission,
                MissionOp::Download
            )))
        );
        assert_eq!(parse("wp list"), parse("wp download"));
        assert!(
            parse("fence list").is_err(),
            "MAVProxy's fence list is not ours"
        );
        assert_eq!(
            parse("param show BATT_*"),
            Ok(Command::ParamMeta(MetaCmd::Show("BATT_*".into())))
        );
        assert_eq!(
            parse("param meta fetch"),
            Ok(Command::ParamMeta(MetaCmd::Fetch))
        );
        assert!(matches!(
            parse("param set RTL_ALT 1500"),
            Ok(Command::Param(_))
        ));
        assert_eq!(parse("rtl"), Ok(Command::Flight(FlightAction::Rtl)));
        assert_eq!(parse("land"), Ok(Command::Flight(FlightAction::Land)));
        assert_eq!(
            parse("takeoff 15"),
            Ok(Command::Flight(FlightAction::Takeoff(15.0)))
        );
        assert_eq!(
            parse("disarm"),
            Ok(Command::Flight(FlightAction::Disarm { force: false }))
        );
    }
}
