//! Keys and the actions they are bound to.
//!
//! The core never sees terminal events: front ends turn them into [`Key`], the keymap turns a
//! key into an [`Action`] for the core's input [`Mode`] and screen (one of [`SCREENS`]), and the
//! core matches on the action. Keymap files have a section per mode and per screen; see
//! [`Keymap::from_toml`] and [`Keymap::lookup`].

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// A key as the core sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Key {
    pub code: KeyCode,
    pub ctrl: bool,
    pub alt: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum KeyCode {
    Char(char),
    Enter,
    Esc,
    Tab,
    BackTab,
    Backspace,
    Delete,
    Up,
    Down,
    Left,
    Right,
    PageUp,
    PageDown,
    Home,
    End,
    F(u8),
}

impl Key {
    pub const fn plain(code: KeyCode) -> Self {
        Key {
            code,
            ctrl: false,
            alt: false,
        }
    }
    pub const fn ch(c: char) -> Self {
        Key::plain(KeyCode::Char(c))
    }
    pub const fn ctrl(c: char) -> Self {
        Key {
            code: KeyCode::Char(c),
            ctrl: true,
            alt: false,
        }
    }
}

impl fmt::Display for Key {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.ctrl {
            write!(f, "ctrl-")?;
        }
        if self.alt {
            write!(f, "alt-")?;
        }
        match self.code {
            KeyCode::Char(' ') => write!(f, "space"),
            KeyCode::Char(c) => write!(f, "{c}"),
            KeyCode::Enter => write!(f, "enter"),
            KeyCode::Esc => write!(f, "esc"),
            KeyCode::Tab => write!(f, "tab"),
            KeyCode::BackTab => write!(f, "backtab"),
            KeyCode::Backspace => write!(f, "backspace"),
            KeyCode::Delete => write!(f, "delete"),
            KeyCode::Up => write!(f, "up"),
            KeyCode::Down => write!(f, "down"),
            KeyCode::Left => write!(f, "left"),
            KeyCode::Right => write!(f, "right"),
            KeyCode::PageUp => write!(f, "pageup"),
            KeyCode::PageDown => write!(f, "pagedown"),
            KeyCode::Home => write!(f, "home"),
            KeyCode::End => write!(f, "end"),
            KeyCode::F(n) => write!(f, "f{n}"),
        }
    }
}

/// The input modes of the core. Each has its own keymap section; see [`Keymap::lookup`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Mode {
    /// Browsing a screen: `[normal]` plus `[normal.SCREEN]`.
    Normal,
    /// The `?` key help is open: `[help]`.
    Help,
    /// The `:` command line: `[prompt]`. Unbound printable characters are typed as text.
    Prompt,
    /// Editing a value in place: `[edit]`. Unbound printable characters are typed as text.
    Edit,
}

impl Mode {
    pub const ALL: [Mode; 4] = [Mode::Normal, Mode::Help, Mode::Prompt, Mode::Edit];

    /// The section name in keymap files.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Normal => "normal",
            Mode::Help => "help",
            Mode::Prompt => "prompt",
            Mode::Edit => "edit",
        }
    }
}

/// Expands the screen list ([`crate::screen_list`]) into the keymap's part of it: the section
/// names and the `screen_N` actions.
macro_rules! keymap_screens {
    ($( $n:literal $name:ident $title:literal $what:literal
        $(select = $sel:ident)? $(note = $note:ident)? ;)*) => {
        /// The full screens, in number-key order (`screen_1` shows the first). Each may have a
        /// `[normal.NAME]` keymap section.
        pub const SCREENS: &[&str] = &[$(stringify!($name)),*];

        /// The `screen_N` actions, with their names and descriptions.
        const SCREEN_ACTIONS: &[(Action, &str, &str)] =
            &[$((Action::Screen($n - 1), concat!("screen_", $n), $what)),*];
    };
}
crate::for_each_screen!(keymap_screens);

/// A section of a keymap file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Section {
    /// `[normal]` (or the legacy `[bindings]`): normal mode on every screen.
    Normal,
    /// `[normal.NAME]`: normal mode on screen `SCREENS[i]` only.
    Screen(usize),
    /// `[help]`.
    Help,
    /// `[prompt]`.
    Prompt,
    /// `[edit]`.
    Edit,
}

impl fmt::Display for Section {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Section::Normal => write!(f, "[normal]"),
            Section::Screen(i) => write!(f, "[normal.{}]", SCREENS.get(*i).unwrap_or(&"?")),
            Section::Help => write!(f, "[help]"),
            Section::Prompt => write!(f, "[prompt]"),
            Section::Edit => write!(f, "[edit]"),
        }
    }
}

impl Section {
    /// The input mode this section's bindings apply in.
    pub fn mode(self) -> Mode {
        match self {
            Section::Normal | Section::Screen(_) => Mode::Normal,
            Section::Help => Mode::Help,
            Section::Prompt => Mode::Prompt,
            Section::Edit => Mode::Edit,
        }
    }
}

/// Everything a key can be bound to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Action {
    Quit,
    /// Give the terminal back and stop (as Ctrl-Z does in a shell); `fg` resumes.
    Suspend,
    FocusNext,
    FocusPrev,
    Up,
    Down,
    PageUp,
    PageDown,
    /// Expand or collapse the selected link's per-source rows.
    ToggleExpand,
    NextVehicle,
    PrevVehicle,
    Help,
    Cancel,
    /// Jump to the first row (oldest message).
    Top,
    /// Jump to the last row (newest message).
    Bottom,
    /// Open the `:` command line.
    Prompt,
    /// Show screen N of [`SCREENS`] (`Screen(0)` is `screen_1`, the overview).
    Screen(u8),
    // Text-line editing, for `[prompt]` and `[edit]`.
    Submit,
    CursorLeft,
    CursorRight,
    LineStart,
    LineEnd,
    DeleteBack,
    DeleteForward,
    DeleteWord,
    ClearLine,
    HistoryPrev,
    HistoryNext,
    Complete,
    // Flying the target vehicle.
    Arm,
    Disarm,
    /// Opens the prompt with `takeoff 10` to edit the altitude.
    Takeoff,
    Land,
    Rtl,
    /// Opens the prompt with `mode ` and the target's modes listed.
    ModeMenu,
    /// Commands screen: send the selected command again.
    Reissue,
    /// Commands screen: abort the selected command in progress (COMMAND_CANCEL).
    CancelCommand,
    /// The command palette: any MAV_CMD, searched, its parameters filled in, previewed, sent.
    Palette,
    /// The results of the last actions, newest last (`:messages`).
    Outcomes,
    /// Parameters screen: type a filter (names containing it; `ATC_` = names starting with it).
    ParamFilter,
    /// Parameters screen: edit the selected parameter's value in place.
    ParamEdit,
    /// Parameters screen: download the parameters again (`param fetch`).
    ParamFetch,
    /// Parameters screen: show only the parameters that differ from the loaded file.
    ParamOnlyDiff,
    /// Inspector: ask the selected message's source for a rate (MAV_CMD_SET_MESSAGE_INTERVAL).
    InspectorRate,
    /// Inspector: type a filter on message names.
    InspectorFilter,
    /// Inspector: the keys scroll the selected message's fields, or the list again.
    InspectorDetail,
    /// Enter Fly mode (keyboard velocity nudges; esc leaves).
    Fly,
    /// Mission screen: show the next list (mission, fence, rally).
    MissionList,
    /// Mission screen: show the vehicle's list or the loaded file's.
    MissionSource,
    MissionDownload,
    MissionUpload,
    /// Start the mission (asks first).
    MissionStart,
    /// Make the selected item the current one.
    MissionSetCurrent,
    /// Fly to the selected item's position (GUIDED).
    MissionGoto,
    // Replay links (`tlog:`), on every screen.
    /// Pause or resume.
    ReplayPause,
    /// While paused, hand on the next frame.
    ReplayStep,
    /// Seek 10 s back.
    ReplayBack,
    /// Seek 10 s forward.
    ReplayForward,
    /// Half the speed.
    ReplaySlower,
    /// Double the speed (past ×64: as fast as possible).
    ReplayFaster,
    /// Camera screen: take one image (`camera shoot`).
    CameraShoot,
    /// Camera screen: start or stop recording video.
    CameraVideo,
    /// Camera screen: switch between image and video mode.
    CameraMode,
    /// Camera screen: select the next camera.
    CameraNext,
    /// Camera screen: zoom in / out, focus farther / nearer by 10 % of the range (cameras with
    /// CAMERA_CAP_FLAGS_HAS_BASIC_ZOOM / HAS_BASIC_FOCUS).
    CameraZoomIn,
    CameraZoomOut,
    CameraFocusFar,
    CameraFocusNear,
    /// Camera screen: point the gimbal 5° up, down, left, right, or back to level and ahead.
    GimbalUp,
    GimbalDown,
    GimbalLeft,
    GimbalRight,
    GimbalCenter,
    /// Logs screen: download the selected log (queued behind the one running).
    LogDownload,
    /// Logs screen: download the newest log.
    LogLatest,
    /// Logs screen: cancel the download and the queue (LOG_REQUEST_END).
    LogCancel,
    /// Logs screen: erase every log on the vehicle (asks first; LOG_ERASE).
    LogErase,
    /// Logs screen: ask the vehicle for its list again.
    LogRefresh,
    /// Messages pane: show only more severe messages (all, INFO+, NOTICE+, WARN+, ERROR+).
    MsgSeverity,
    /// Messages pane: the severity filter's step back.
    MsgSeverityBack,
    /// Messages pane: show one vehicle's messages (all, the target's, each system id).
    MsgVehicle,
    /// Messages pane: the vehicle filter's step back.
    MsgVehicleBack,
    /// Health screen: ask the vehicle to run its pre-arm checks now (RUN_PREARM_CHECKS).
    HealthPrearm,
    /// Health screen: the vehicle is at the accelerometer position it asked for.
    CalNext,
    /// Health screen: start a calibration (each asks first).
    CalGyro,
    CalBaro,
    CalLevel,
    CalAccel,
    CalSimpleAccel,
    CalCompass,
    /// Health screen: accept (save) a finished compass calibration, or cancel the running one.
    CalAccept,
    CalCancel,
    /// Mission screen, file list: a waypoint at the map's cursor.
    MissionAddAtCursor,
    /// Map screen: zoom in / out (twice / half the scale).
    MapZoomIn,
    MapZoomOut,
    /// Map screen: the view (or the cursor) left / right; up and down move it with `up`/`down`.
    MapLeft,
    MapRight,
    /// Map screen: follow the target again.
    MapCentre,
    /// Map screen: fit the mission, fence, rally points, homes and vehicles.
    MapFit,
    /// Map screen: the target's heading up, or north up.
    MapHeadingUp,
    /// Map screen: show / hide the cursor.
    MapCursor,
    /// Map screen: GUIDED: fly to the cursor (DO_REPOSITION, as `goto`).
    MapGoto,
}

impl Action {
    /// The actions listed before the `screen_N` ones.
    const BEFORE_SCREENS: &'static [(Action, &'static str, &'static str)] = &[
        (Action::Quit, "quit", "quit mavterm"),
        (
            Action::Suspend,
            "suspend",
            "suspend mavterm to the shell (fg resumes it)",
        ),
        (Action::Help, "help", "show/hide key help"),
        (
            Action::Cancel,
            "cancel",
            "close the dialog or leave the line",
        ),
        (Action::Prompt, "prompt", "open the : command line"),
    ];

    /// The actions listed after the `screen_N` ones.
    const AFTER_SCREENS: &'static [(Action, &'static str, &'static str)] = &[
        (Action::Up, "up", "move the selection up"),
        (Action::Down, "down", "move the selection down"),
        (Action::PageUp, "page_up", "scroll up a page"),
        (Action::PageDown, "page_down", "scroll down a page"),
        (Action::Top, "top", "jump to the first row"),
        (Action::Bottom, "bottom", "jump to the last row"),
        (Action::FocusNext, "focus_next", "focus the next pane"),
        (Action::FocusPrev, "focus_prev", "focus the previous pane"),
        (
            Action::ToggleExpand,
            "toggle_expand",
            "expand/collapse the selected link, or target the selected vehicle",
        ),
        (
            Action::NextVehicle,
            "next_vehicle",
            "target the next vehicle",
        ),
        (
            Action::PrevVehicle,
            "prev_vehicle",
            "target the previous vehicle",
        ),
        (
            Action::Submit,
            "submit",
            "run the command / accept the value",
        ),
        (Action::CursorLeft, "cursor_left", "move the cursor left"),
        (Action::CursorRight, "cursor_right", "move the cursor right"),
        (
            Action::LineStart,
            "line_start",
            "move the cursor to the start",
        ),
        (Action::LineEnd, "line_end", "move the cursor to the end"),
        (
            Action::DeleteBack,
            "delete_back",
            "delete the character before the cursor",
        ),
        (
            Action::DeleteForward,
            "delete_forward",
            "delete the character under the cursor",
        ),
        (
            Action::DeleteWord,
            "delete_word",
            "delete the word before the cursor",
        ),
        (Action::ClearLine, "clear_line", "clear the line"),
        (
            Action::HistoryPrev,
            "history_prev",
            "previous line from history",
        ),
        (
            Action::HistoryNext,
            "history_next",
            "next line from history",
        ),
        (
            Action::Complete,
            "complete",
            "complete the word at the cursor",
        ),
        (Action::Arm, "arm", "arm the target (asks first)"),
        (Action::Disarm, "disarm", "disarm the target"),
        (
            Action::Takeoff,
            "takeoff",
            "take off: asks the altitude, then confirmation",
        ),
        (Action::Land, "land", "land the target"),
        (Action::Rtl, "rtl", "return to launch"),
        (
            Action::ModeMenu,
            "mode",
            "change the target's flight mode (lists its modes)",
        ),
        (
            Action::Reissue,
            "reissue",
            "send the selected command again (asks first if dangerous)",
        ),
        (
            Action::CancelCommand,
            "cancel_command",
            "abort the selected command in progress",
        ),
        (
            Action::Palette,
            "palette",
            "command palette: any MAV_CMD, with its parameters",
        ),
        (
            Action::Outcomes,
            "messages",
            "the results of the last actions, newest last (:messages)",
        ),
        (
            Action::ParamFilter,
            "param_filter",
            "filter parameters by name (ATC_ = the ATC_ group; enter keeps, esc clears)",
        ),
        (
            Action::ParamEdit,
            "param_edit",
            "edit the selected parameter (enter sends, esc cancels, tab value names)",
        ),
        (
            Action::ParamFetch,
            "param_fetch",
            "download the parameters again (param fetch)",
        ),
        (
            Action::ParamOnlyDiff,
            "param_only_diff",
            "show only parameters that differ from the loaded file (≠)",
        ),
        (
            Action::InspectorRate,
            "inspector_rate",
            "ask for the selected message at a rate: Hz, 0 = default, -1 = off",
        ),
        (
            Action::InspectorFilter,
            "inspector_filter",
            "filter messages by name (enter keeps, esc clears)",
        ),
        (
            Action::InspectorDetail,
            "inspector_detail",
            "the keys scroll the fields / the list",
        ),
        (
            Action::Fly,
            "fly",
            "Fly mode: nudge a GUIDED vehicle with the keys (esc leaves)",
        ),
        (
            Action::MissionList,
            "mission_list",
            "show the next list: mission, fence, rally",
        ),
        (
            Action::MissionSource,
            "mission_source",
            "show the vehicle's list or the loaded file's",
        ),
        (
            Action::MissionDownload,
            "mission_download",
            "download the list shown from the vehicle",
        ),
        (
            Action::MissionUpload,
            "mission_upload",
            "upload the loaded file's list (asks first if it warns)",
        ),
        (
            Action::MissionStart,
            "mission_start",
            "start the mission: AUTO, then MISSION_START (asks first)",
        ),
        (
            Action::MissionSetCurrent,
            "mission_set_current",
            "make the selected item the current one",
        ),
        (
            Action::MissionGoto,
            "mission_goto",
            "GUIDED: fly to the selected item (DO_REPOSITION)",
        ),
        (
            Action::ReplayPause,
            "replay_pause",
            "replay (tlog:): pause / resume",
        ),
        (
            Action::ReplayStep,
            "replay_step",
            "replay: pause, then the next frame at each press",
        ),
        (Action::ReplayBack, "replay_back", "replay: seek 10 s back"),
        (
            Action::ReplayForward,
            "replay_forward",
            "replay: seek 10 s forward (skipped frames are not loss)",
        ),
        (
            Action::ReplaySlower,
            "replay_slower",
            "replay: half the speed",
        ),
        (
            Action::ReplayFaster,
            "replay_faster",
            "replay: double the speed (past ×64: as fast as possible)",
        ),
        (
            Action::CameraShoot,
            "camera_shoot",
            "camera: take one image (if its mode allows)",
        ),
        (
            Action::CameraVideo,
            "camera_video",
            "camera: start / stop recording video",
        ),
        (
            Action::CameraMode,
            "camera_mode",
            "camera: switch image / video mode",
        ),
        (Action::CameraNext, "camera_next", "select the next camera"),
        (
            Action::CameraZoomIn,
            "camera_zoom_in",
            "camera: zoom in 10 %",
        ),
        (
            Action::CameraZoomOut,
            "camera_zoom_out",
            "camera: zoom out 10 %",
        ),
        (
            Action::CameraFocusFar,
            "camera_focus_far",
            "camera: focus 10 % farther",
        ),
        (
            Action::CameraFocusNear,
            "camera_focus_near",
            "camera: focus 10 % nearer",
        ),
        (
            Action::GimbalUp,
            "gimbal_up",
            "gimbal: pitch 5° up (within its limits)",
        ),
        (Action::GimbalDown, "gimbal_down", "gimbal: pitch 5° down"),
        (Action::GimbalLeft, "gimbal_left", "gimbal: yaw 5° left"),
        (Action::GimbalRight, "gimbal_right", "gimbal: yaw 5° right"),
        (
            Action::GimbalCenter,
            "gimbal_center",
            "gimbal: level, straight ahead",
        ),
        (
            Action::LogDownload,
            "log_download",
            "logs: download the selected log (queued behind the one running)",
        ),
        (
            Action::LogLatest,
            "log_latest",
            "logs: download the newest log",
        ),
        (
            Action::LogCancel,
            "log_cancel",
            "logs: cancel the download and the queue (LOG_REQUEST_END)",
        ),
        (
            Action::LogErase,
            "log_erase",
            "logs: erase every log on the vehicle (asks first)",
        ),
        (
            Action::LogRefresh,
            "log_refresh",
            "logs: ask the vehicle for its list again",
        ),
        (
            Action::MsgSeverity,
            "msg_severity",
            "messages: only more severe (all, INFO+, NOTICE+, WARN+, ERROR+)",
        ),
        (
            Action::MsgSeverityBack,
            "msg_severity_back",
            "messages: less severe too (the step back)",
        ),
        (
            Action::MsgVehicle,
            "msg_vehicle",
            "messages: one vehicle's (all, the target's, each sysid)",
        ),
        (
            Action::MsgVehicleBack,
            "msg_vehicle_back",
            "messages: the vehicle filter's step back",
        ),
        (
            Action::HealthPrearm,
            "health_prearm",
            "health: ask the vehicle for its pre-arm checks now",
        ),
        (
            Action::CalNext,
            "cal_next",
            "calibration: the vehicle is at the position asked",
        ),
        (
            Action::CalGyro,
            "cal_gyro",
            "calibrate the gyros (asks first)",
        ),
        (
            Action::CalBaro,
            "cal_baro",
            "calibrate the barometer (asks first)",
        ),
        (
            Action::CalLevel,
            "cal_level",
            "calibrate level (asks first)",
        ),
        (
            Action::CalAccel,
            "cal_accel",
            "calibrate the accelerometers, 6 positions (asks first)",
        ),
        (
            Action::CalSimpleAccel,
            "cal_simple_accel",
            "simple accelerometer calibration (asks first)",
        ),
        (
            Action::CalCompass,
            "cal_compass",
            "calibrate the compasses onboard (asks first)",
        ),
        (
            Action::CalAccept,
            "cal_accept",
            "calibration: accept (save) the compass result",
        ),
        (
            Action::CalCancel,
            "cal_cancel",
            "calibration: cancel the one running",
        ),
        (
            Action::MissionAddAtCursor,
            "mission_add_at_cursor",
            "file list: add a waypoint at the map's cursor",
        ),
        (
            Action::MapZoomIn,
            "map_zoom_in",
            "map: zoom in (+ too, without a replay)",
        ),
        (
            Action::MapZoomOut,
            "map_zoom_out",
            "map: zoom out (- too, without a replay)",
        ),
        (
            Action::MapLeft,
            "map_left",
            "map: move the view or the cursor left",
        ),
        (
            Action::MapRight,
            "map_right",
            "map: move the view or the cursor right",
        ),
        (
            Action::MapCentre,
            "map_centre",
            "map: follow the target again",
        ),
        (
            Action::MapFit,
            "map_fit",
            "map: fit the mission, fence, rally, homes and vehicles",
        ),
        (
            Action::MapHeadingUp,
            "map_heading_up",
            "map: heading up / north up",
        ),
        (
            Action::MapCursor,
            "map_cursor",
            "map: show / hide the cursor",
        ),
        (
            Action::MapGoto,
            "map_goto",
            "map: GUIDED: fly to the cursor (DO_REPOSITION, as goto)",
        ),
    ];

    /// Every bindable action with its name in keymap files and a one-line description, in the
    /// order the help popup lists them.
    pub const ALL: &'static [(Action, &'static str, &'static str)] = &ALL_ACTIONS;

    /// The actions of the text line (`[prompt]` and `[edit]`).
    const TEXT_LINE: &'static [Action] = &[
        Action::Submit,
        Action::Cancel,
        Action::CursorLeft,
        Action::CursorRight,
        Action::LineStart,
        Action::LineEnd,
        Action::DeleteBack,
        Action::DeleteForward,
        Action::DeleteWord,
        Action::ClearLine,
        Action::HistoryPrev,
        Action::HistoryNext,
        Action::Complete,
    ];

    /// The actions of the key help (`[help]`): scrolling, and closing it.
    const HELP: &'static [Action] = &[Action::Help, Action::Cancel];

    /// The actions that scroll a list or the help, in the order listed.
    pub const SCROLL: &'static [Action] = &[
        Action::Up,
        Action::Down,
        Action::PageUp,
        Action::PageDown,
        Action::Top,
        Action::Bottom,
    ];

    /// The names of the actions that do something in `mode`, sorted: what an unknown action's
    /// message lists.
    pub fn names_for(mode: Mode) -> Vec<&'static str> {
        let mut names: Vec<&'static str> = Action::ALL
            .iter()
            .filter(|(a, _, _)| match mode {
                Mode::Help => Action::HELP.contains(a) || Action::SCROLL.contains(a),
                Mode::Prompt | Mode::Edit => Action::TEXT_LINE.contains(a),
                Mode::Normal => *a == Action::Cancel || !Action::TEXT_LINE.contains(a),
            })
            .map(|(_, n, _)| *n)
            .collect();
        names.sort_unstable();
        names
    }

    /// True for the actions that control replay links.
    pub fn is_replay(self) -> bool {
        matches!(
            self,
            Action::ReplayPause
                | Action::ReplayStep
                | Action::ReplayBack
                | Action::ReplayForward
                | Action::ReplaySlower
                | Action::ReplayFaster
        )
    }

    pub fn name(self) -> &'static str {
        Action::ALL
            .iter()
            .find(|(a, _, _)| *a == self)
            .map(|(_, n, _)| *n)
            .unwrap_or("?")
    }

    /// The action called `name` in keymap files.
    pub fn from_name(name: &str) -> Option<Action> {
        Action::ALL
            .iter()
            .find(|(_, n, _)| *n == name)
            .map(|(a, _, _)| *a)
    }

    /// One-line description for the help popup.
    pub fn description(self) -> &'static str {
        Action::ALL
            .iter()
            .find(|(a, _, _)| *a == self)
            .map(|(_, _, d)| *d)
            .unwrap_or("")
    }
}

const ALL_LEN: usize =
    Action::BEFORE_SCREENS.len() + SCREEN_ACTIONS.len() + Action::AFTER_SCREENS.len();

/// [`Action::ALL`]: the actions before the screens, the screens', the rest.
const ALL_ACTIONS: [(Action, &str, &str); ALL_LEN] = {
    let mut out = [(Action::Quit, "", ""); ALL_LEN];
    let parts = [
        Action::BEFORE_SCREENS,
        SCREEN_ACTIONS,
        Action::AFTER_SCREENS,
    ];
    let (mut p, mut at) = (0, 0);
    while p < parts.len() {
        let mut i = 0;
        while i < parts[p].len() {
            out[at] = parts[p][i];
            at += 1;
            i += 1;
        }
        p += 1;
    }
    out
};

/// A key name that means nothing to us.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown key `{0}` (key names: {KEY_NAMES})")]
pub struct KeyParseError(pub String);

/// What a key may be called, for messages.
pub const KEY_NAMES: &str = "a character (a, A, ?, 1), space, enter, esc, tab, backtab, \
     backspace, delete, up, down, left, right, pageup, pagedown, home, end, f1 to f24; with \
     ctrl- or alt- before (ctrl-x, alt-x, alt-up), or shift- before a letter or tab";

impl FromStr for Key {
    type Err = KeyParseError;

    /// Parses the names [`Key`]'s `Display` writes, plus a few aliases (`shift-tab`, `return`,
    /// `escape`, `del`, `pgup`, `pgdn`). Single characters are case-sensitive; names are not.
    /// `ctrl-` with a letter is normalised to lower case: terminals cannot tell them apart.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let err = || KeyParseError(s.to_string());
        let (mut ctrl, mut alt, mut shift) = (false, false, false);
        let mut rest = s;
        loop {
            // Compare the prefix only: lower-casing all of `rest` each round is quadratic.
            let strip = |p: &str| {
                rest.len() > p.len()
                    && rest.as_bytes()[..p.len()].eq_ignore_ascii_case(p.as_bytes())
            };
            if strip("ctrl-") {
                ctrl = true;
                rest = &rest[5..];
            } else if strip("alt-") {
                alt = true;
                rest = &rest[4..];
            } else if strip("shift-") {
                shift = true;
                rest = &rest[6..];
            } else {
                break;
            }
        }
        let mut chars = rest.chars();
        let code = match (chars.next(), chars.next()) {
            (None, _) => return Err(err()),
            (Some(c), None) => {
                let c = if ctrl { c.to_ascii_lowercase() } else { c };
                if shift {
                    if !c.is_alphabetic() || ctrl {
                        return Err(err());
                    }
                    shift = false;
                    KeyCode::Char(c.to_uppercase().next().unwrap_or(c))
                } else {
                    KeyCode::Char(c)
                }
            }
            _ => {
                let name = rest.to_ascii_lowercase();
                match name.as_str() {
                    "tab" if shift => {
                        shift = false;
                        KeyCode::BackTab
                    }
                    "tab" => KeyCode::Tab,
                    "backtab" => KeyCode::BackTab,
                    "enter" | "return" => KeyCode::Enter,
                    "esc" | "escape" => KeyCode::Esc,
                    "space" => KeyCode::Char(' '),
                    "backspace" => KeyCode::Backspace,
                    "delete" | "del" => KeyCode::Delete,
                    "up" => KeyCode::Up,
                    "down" => KeyCode::Down,
                    "left" => KeyCode::Left,
                    "right" => KeyCode::Right,
                    "pageup" | "pgup" => KeyCode::PageUp,
                    "pagedown" | "pgdn" => KeyCode::PageDown,
                    "home" => KeyCode::Home,
                    "end" => KeyCode::End,
                    f if f.starts_with('f') => match f[1..].parse::<u8>() {
                        Ok(n @ 1..=24) => KeyCode::F(n),
                        _ => return Err(err()),
                    },
                    _ => return Err(err()),
                }
            }
        };
        if shift {
            return Err(err()); // shift only combines with letters and tab
        }
        Ok(Key { code, ctrl, alt })
    }
}

/// The built-in keymap, in the same format users write.
pub const DEFAULT_KEYMAP: &str = include_str!("../keymaps/default.toml");

/// At most this many problems are listed in a [`KeymapError::Invalid`]; the rest are counted.
pub const MAX_PROBLEMS: usize = 50;

/// One problem in a keymap file, where it is (1-based line and column, in characters).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Problem {
    pub line: usize,
    pub col: usize,
    pub message: String,
}

/// Why a keymap file was refused. Every message names the file.
#[derive(Debug, thiserror::Error)]
pub enum KeymapError {
    #[error("keymap {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// The file is not valid TOML.
    #[error("keymap {origin}:{line}:{col}: {message}")]
    Syntax {
        origin: String,
        line: usize,
        col: usize,
        message: String,
    },
    /// Valid TOML, but naming sections, actions or keys that do not exist, in the wrong shape, or
    /// binding one key twice.
    #[error("{0}")]
    Invalid(Box<InvalidKeymap>),
}

/// Every problem of a keymap file that is valid TOML (up to [`MAX_PROBLEMS`] located, the rest
/// counted), not just the first, so one edit fixes the file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InvalidKeymap {
    pub origin: String,
    /// Every unknown action name, in file order.
    pub unknown_actions: Vec<String>,
    /// Every unknown key name, in file order.
    pub unknown_keys: Vec<String>,
    /// Keys bound to more than one action, as `key (action, action)`, with ` in [SECTION]`
    /// appended unless the clash is in `[normal]`.
    pub duplicate_keys: Vec<String>,
    /// The first [`MAX_PROBLEMS`] problems, top to bottom.
    pub problems: Vec<Problem>,
    /// How many more problems there were.
    pub more: usize,
    /// The names that would have been right, for unknown actions and keys: one paragraph each,
    /// shown once after the problems.
    pub hints: Vec<String>,
}

/// One problem: `keymap FILE:LINE:COL: message`. Several: a count, then one `FILE:LINE:COL:
/// message` per line, then `… and N more` past [`MAX_PROBLEMS`].
impl fmt::Display for InvalidKeymap {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let origin = &self.origin;
        if let ([p], 0) = (self.problems.as_slice(), self.more) {
            write!(f, "keymap {origin}:{}:{}: {}", p.line, p.col, p.message)?;
        } else {
            let total = self.problems.len() + self.more;
            write!(f, "keymap {origin}: {total} problems:")?;
            for p in &self.problems {
                write!(f, "\n  {origin}:{}:{}: {}", p.line, p.col, p.message)?;
            }
            if self.more > 0 {
                write!(f, "\n  … and {} more", self.more)?;
            }
        }
        for hint in &self.hints {
            write!(f, "\n{hint}")?;
        }
        Ok(())
    }
}

/// Byte offsets to line and column, in O(log lines) each after one pass over the text.
pub(crate) struct LineIndex<'a> {
    text: &'a str,
    /// Byte offset where each line starts.
    starts: Vec<usize>,
}

impl<'a> LineIndex<'a> {
    pub(crate) fn new(text: &'a str) -> Self {
        let mut starts = vec![0];
        starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        LineIndex { text, starts }
    }

    /// 1-based line and column (in characters) of byte `offset`.
    pub(crate) fn line_col(&self, offset: usize) -> (usize, usize) {
        let offset = offset.min(self.text.len());
        let line = self.starts.partition_point(|&s| s <= offset); // >= 1: starts[0] == 0
        let start = self.starts[line - 1];
        let col = self
            .text
            .get(start..offset)
            .map_or(offset - start, |s| s.chars().count());
        (line, col + 1)
    }
}

/// The bindings of one section.
#[derive(Debug, Clone, Default)]
struct Bindings {
    keys: BTreeMap<Key, Action>,
    /// Actions the source file listed (even with no keys): when layered on top of another keymap
    /// these replace that keymap's keys for the action, so `help = []` unbinds.
    listed: BTreeSet<Action>,
    /// Every bound key once, in the order the file listed them: the first key of an action is
    /// its hint.
    order: Vec<Key>,
    /// Where the file bound each key (1-based line and column), for layering errors.
    at: BTreeMap<Key, (usize, usize)>,
}

impl Bindings {
    fn remove_where(&mut self, mut drop: impl FnMut(&Key, &Action) -> bool) {
        self.keys.retain(|k, a| !drop(k, a));
        let keys = &self.keys;
        self.order.retain(|k| keys.contains_key(k));
    }
}

/// Key → action bindings, per [`Section`]. `keymaps/default.toml` documents the file format.
#[derive(Debug, Clone)]
pub struct Keymap {
    sections: BTreeMap<Section, Bindings>,
}

impl Default for Keymap {
    /// The built-in keymap: parsed once per process, copied for each core that asks.
    fn default() -> Self {
        static DEFAULT: std::sync::OnceLock<Keymap> = std::sync::OnceLock::new();
        DEFAULT
            .get_or_init(|| {
                // A unit test parses the shipped file, so this cannot fail in a released binary.
                Keymap::from_toml(DEFAULT_KEYMAP, "<built-in default>")
                    .expect("built-in keymap is valid")
            })
            .clone()
    }
}

/// Problems found while reading one file, with their byte offsets.
struct Collector {
    problems: Vec<(usize, String)>,
    unknown_actions: Vec<String>,
    unknown_keys: Vec<String>,
    /// (section the clash is in, key) → actions.
    clashes: BTreeMap<(Section, Key), BTreeSet<Action>>,
    /// The modes of the sections unknown actions were found in.
    unknown_action_modes: BTreeSet<Mode>,
}

impl Collector {
    fn add(&mut self, offset: usize, message: String) {
        self.problems.push((offset, message));
    }
}

/// A binding as read: its section, action name and value.
type Entry<'d, 'i> = (
    Section,
    &'d toml::Spanned<toml::de::DeString<'i>>,
    &'d toml::Spanned<toml::de::DeValue<'i>>,
);

impl Collector {
    /// The bindings of every section, `[normal.SCREEN]` included, in file order; what is not a
    /// known section or screen is a problem.
    fn entries<'d, 'i>(&mut self, doc: &'d toml::de::DeTable<'i>) -> Vec<Entry<'d, 'i>> {
        let mut entries: Vec<Entry> = Vec::new();
        for (name, value) in by_pos(doc) {
            let section = match name.get_ref().as_ref() {
                "normal" | "bindings" => Section::Normal,
                "help" => Section::Help,
                "prompt" => Section::Prompt,
                "edit" => Section::Edit,
                other => {
                    let message = if Action::from_name(other).is_some() {
                        format!("`{other}` is outside any section: put it under [normal]")
                    } else {
                        format!(
                            "unknown section `{other}` (normal, normal.SCREEN, help, prompt, edit)"
                        )
                    };
                    self.add(name.span().start, message);
                    continue;
                }
            };
            let Some(table) = value.get_ref().as_table() else {
                self.add(
                    value.span().start,
                    format!(
                        "`{}` must be a section, e.g. [{}]",
                        name.get_ref(),
                        name.get_ref()
                    ),
                );
                continue;
            };
            for (k, v) in by_pos(table) {
                if let Some(sub) = v.get_ref().as_table() {
                    let screen = SCREENS.iter().position(|s| *s == k.get_ref().as_ref());
                    match (section, screen) {
                        (Section::Normal, Some(i)) => {
                            for (k2, v2) in by_pos(sub) {
                                if v2.get_ref().is_table() {
                                    self.add(
                                        k2.span().start,
                                        format!(
                                            "[normal.{}] has no sub-sections, found `{}`",
                                            SCREENS[i],
                                            k2.get_ref()
                                        ),
                                    );
                                } else {
                                    entries.push((Section::Screen(i), k2, v2));
                                }
                            }
                        }
                        (Section::Normal, None) => self.add(
                            k.span().start,
                            format!(
                                "unknown screen `{}` in [normal.SCREEN] (screens: {})",
                                k.get_ref(),
                                screen_list()
                            ),
                        ),
                        _ => self.add(
                            k.span().start,
                            format!("{section} has no sub-sections, found `{}`", k.get_ref()),
                        ),
                    }
                } else {
                    entries.push((section, k, v));
                }
            }
        }
        entries.sort_by_key(|(_, k, _)| k.span().start);

        entries
    }

    /// The keymap the entries bind, and where each (section, key) was first bound.
    fn bind(
        &mut self,
        entries: Vec<Entry>,
        index: &LineIndex,
    ) -> (Keymap, BTreeMap<(Section, Key), usize>) {
        let mut km = Keymap::empty();
        // Where each (section, key) was first bound, for clash messages.
        let mut first_at: BTreeMap<(Section, Key), usize> = BTreeMap::new();
        for (section, name, value) in entries {
            let action = Action::from_name(name.get_ref());
            let bindings = km.sections.entry(section).or_default();
            match action {
                Some(a) => {
                    bindings.listed.insert(a);
                }
                None => {
                    self.unknown_actions.push(name.get_ref().to_string());
                    self.unknown_action_modes.insert(section.mode());
                    self.add(
                        name.span().start,
                        format!("unknown action `{}` in {section}", name.get_ref()),
                    );
                }
            }
            let Some(list) = value.get_ref().as_array() else {
                self.add(
                    value.span().start,
                    format!(
                        "expected a list of key names, e.g. {} = [\"x\"], found a {}",
                        name.get_ref(),
                        value.get_ref().type_str()
                    ),
                );
                continue;
            };
            for item in list.iter() {
                let Some(kname) = item.get_ref().as_str() else {
                    self.add(
                        item.span().start,
                        format!(
                            "expected a key name in quotes, found a {}",
                            item.get_ref().type_str()
                        ),
                    );
                    continue;
                };
                let key = match kname.parse::<Key>() {
                    Ok(key) => key,
                    Err(_) => {
                        // The key names are listed once, after the problems.
                        self.unknown_keys.push(kname.to_string());
                        self.add(item.span().start, format!("unknown key `{kname}`"));
                        continue;
                    }
                };
                let Some(action) = action else { continue };
                let at = item.span().start;
                match bindings.keys.get(&key) {
                    None => {
                        bindings.keys.insert(key, action);
                        bindings.order.push(key);
                        first_at.insert((section, key), at);
                    }
                    Some(prev) if *prev == action => {} // the same key twice is harmless
                    Some(prev) => {
                        let set = self.clashes.entry((section, key)).or_default();
                        set.insert(*prev);
                        set.insert(action);
                        self.add(
                            at,
                            format!("key `{key}` is already bound to `{}`", prev.name()),
                        );
                    }
                }
            }
        }
        for ((section, key), at) in &first_at {
            if let Some(b) = km.sections.get_mut(section) {
                b.at.insert(*key, index.line_col(*at));
            }
        }
        (km, first_at)
    }

    /// Normal mode on a screen sees `[normal]` and `[normal.SCREEN]` together: a key bound to
    /// different actions in both is a problem.
    fn screen_clashes(
        &mut self,
        km: &Keymap,
        first_at: &BTreeMap<(Section, Key), usize>,
        index: &LineIndex,
    ) {
        if let Some(normal) = km.sections.get(&Section::Normal) {
            for (section, b) in &km.sections {
                let Section::Screen(i) = *section else {
                    continue;
                };
                for key in &b.order {
                    let (Some(here), Some(there)) = (b.keys.get(key), normal.keys.get(key)) else {
                        continue;
                    };
                    if here == there {
                        continue;
                    }
                    let at_here = first_at[&(*section, *key)];
                    let at_there = first_at[&(Section::Normal, *key)];
                    let (later, earlier_action, earlier_section, earlier_at) = if at_here > at_there
                    {
                        (at_here, there, Section::Normal, at_there)
                    } else {
                        (at_there, here, *section, at_here)
                    };
                    let (l, col) = index.line_col(earlier_at);
                    let set = self.clashes.entry((*section, *key)).or_default();
                    set.insert(*here);
                    set.insert(*there);
                    self.add(
                        later,
                        format!(
                            "key `{key}` is already bound to `{}` in {earlier_section} \
                             (line {l}, column {col}); on the {} screen both apply",
                            earlier_action.name(),
                            SCREENS[i]
                        ),
                    );
                }
            }
        }
    }

    /// The error of a file with problems.
    fn into_error(mut self, index: &LineIndex, origin: &str) -> KeymapError {
        self.problems.sort_by_key(|(at, _)| *at); // stable: same place keeps the found order
        let more = self.problems.len().saturating_sub(MAX_PROBLEMS);
        let problems = self
            .problems
            .into_iter()
            .take(MAX_PROBLEMS)
            .map(|(at, message)| {
                let (line, col) = index.line_col(at);
                Problem { line, col, message }
            })
            .collect();
        let duplicate_keys = self
            .clashes
            .iter()
            .map(|((section, k), acts)| {
                let names: Vec<&str> = acts.iter().map(|a| a.name()).collect();
                match section {
                    Section::Normal => format!("{k} ({})", names.join(", ")),
                    s => format!("{k} ({}) in {s}", names.join(", ")),
                }
            })
            .collect();
        let hints = hints(&self.unknown_action_modes, !self.unknown_keys.is_empty());
        KeymapError::Invalid(Box::new(InvalidKeymap {
            origin: origin.to_string(),
            unknown_actions: self.unknown_actions,
            unknown_keys: self.unknown_keys,
            duplicate_keys,
            problems,
            more,
            hints,
        }))
    }
}

type DeEntry<'d, 'i> = (
    &'d toml::Spanned<toml::de::DeString<'i>>,
    &'d toml::Spanned<toml::de::DeValue<'i>>,
);

/// A table's entries in file order (the parser sorts them by name).
fn by_pos<'d, 'i>(t: &'d toml::de::DeTable<'i>) -> Vec<DeEntry<'d, 'i>> {
    let mut v: Vec<_> = t.iter().collect();
    v.sort_by_key(|(k, _)| k.span().start);
    v
}

fn screen_list() -> String {
    SCREENS.join(", ")
}

/// `text` in lines of at most [`HINT_WIDTH`] characters (longer words stay whole), each after
/// the first indented by four spaces.
fn wrap(text: &str) -> String {
    let mut out = String::new();
    let mut col = 0;
    for word in text.split(' ').filter(|w| !w.is_empty()) {
        let n = word.chars().count();
        if col > 0 && col + 1 + n > HINT_WIDTH {
            out.push_str("\n   ");
            col = 3;
        }
        if col > 0 {
            out.push(' ');
            col += 1;
        }
        out.push_str(word);
        col += n;
    }
    out
}

/// The width hints are wrapped to.
const HINT_WIDTH: usize = 96;

/// The hints for a file's unknown actions (by the modes they were in) and keys.
fn hints(unknown_action_modes: &BTreeSet<Mode>, unknown_keys: bool) -> Vec<String> {
    let mut out: Vec<String> = unknown_action_modes
        .iter()
        .filter(|m| **m != Mode::Edit || !unknown_action_modes.contains(&Mode::Prompt))
        .map(|m| {
            let sections = match m {
                Mode::Normal => "[normal] and [normal.SCREEN]",
                Mode::Help => "[help]",
                Mode::Prompt | Mode::Edit => "[prompt] and [edit]",
            };
            wrap(&format!(
                "the actions of {sections}: {}",
                Action::names_for(*m).join(", ")
            ))
        })
        .collect();
    if unknown_keys {
        out.push(wrap(&format!("key names: {KEY_NAMES}")));
    }
    out
}

impl Keymap {
    /// A keymap with no bindings at all.
    pub fn empty() -> Keymap {
        Keymap {
            sections: BTreeMap::new(),
        }
    }

    /// Parse a keymap file. `origin` names it in errors (usually the path).
    ///
    /// Sections: `[normal]` (legacy name `[bindings]`), `[normal.SCREEN]` for each of
    /// [`SCREENS`], `[help]`, `[prompt]`, `[edit]`; each maps action names to lists of key
    /// names. Within `[normal]` ∪ `[normal.SCREEN]`, and within each other section, a key may be
    /// bound to one action only.
    pub fn from_toml(text: &str, origin: &str) -> Result<Keymap, KeymapError> {
        let index = LineIndex::new(text);
        let doc = toml::de::DeTable::parse(text).map_err(|e| {
            let (line, col) = index.line_col(e.span().map_or(0, |s| s.start));
            KeymapError::Syntax {
                origin: origin.to_string(),
                line,
                col,
                message: e.message().trim().to_string(),
            }
        })?;
        let mut c = Collector {
            problems: Vec::new(),
            unknown_actions: Vec::new(),
            unknown_keys: Vec::new(),
            clashes: BTreeMap::new(),
            unknown_action_modes: BTreeSet::new(),
        };
        let entries = c.entries(doc.get_ref());
        let (km, first_at) = c.bind(entries, &index);
        c.screen_clashes(&km, &first_at, &index);
        if c.problems.is_empty() {
            return Ok(km);
        }
        Err(c.into_error(&index, origin))
    }

    /// Read a keymap file (no layering).
    pub fn from_file(path: &Path) -> Result<Keymap, KeymapError> {
        let text = crate::fsio::read_text(path, crate::fsio::MAX_READ).map_err(|source| {
            KeymapError::Io {
                path: path.to_path_buf(),
                source,
            }
        })?;
        Keymap::from_toml(&text, &path.display().to_string())
    }

    /// The default keymap with the user's file at `path` layered on top (see
    /// [`Keymap::layered`]).
    pub fn load(path: &Path) -> Result<Keymap, KeymapError> {
        Keymap::default().layered(&Keymap::from_file(path)?, &path.display().to_string())
    }

    /// `self` (the default keymap) with the user's file `over` on top, as
    /// [`Keymap::with_overrides`] layers them, refusing every key that would then do two things:
    /// one `over` binds to an action while `self` binds it, in the same mode and on the same
    /// screen, to another action that `over` does not list (`quit = ["n"]` over the default
    /// `next_vehicle = ["n"]`). `origin` names `over` in the errors, which point at its lines.
    pub fn layered(self, over: &Keymap, origin: &str) -> Result<Keymap, KeymapError> {
        let empty = Bindings::default();
        let over_normal = over.sections.get(&Section::Normal).unwrap_or(&empty);
        // What stays of `self`: the actions `over` lists lose their keys here (the way to move
        // or unbind a default key).
        let mut base = self.clone();
        for (section, mine) in base.sections.iter_mut() {
            let theirs = over.sections.get(section).unwrap_or(&empty);
            let inherited = matches!(section, Section::Screen(_));
            mine.remove_where(|_, a| {
                theirs.listed.contains(a) || (inherited && over_normal.listed.contains(a))
            });
        }
        // The sections seen together: normal mode on each screen, and each other mode.
        let contexts: Vec<(Vec<Section>, Option<&str>)> = SCREENS
            .iter()
            .enumerate()
            .map(|(i, s)| (vec![Section::Screen(i), Section::Normal], Some(*s)))
            .chain(
                [Section::Help, Section::Prompt, Section::Edit]
                    .into_iter()
                    .map(|s| (vec![s], None)),
            )
            .collect();
        // (their section, key, our section, our action) → (their action, screens).
        type Clash<'s> = BTreeMap<(Section, Key, Section, Action), (Action, Vec<&'s str>)>;
        let mut clashes: Clash = BTreeMap::new();
        for (chain, screen) in &contexts {
            for theirs_at in chain {
                let Some(theirs) = over.sections.get(theirs_at) else {
                    continue;
                };
                for (key, action) in &theirs.keys {
                    for ours_at in chain {
                        let Some(ours) = base.sections.get(ours_at).and_then(|b| b.keys.get(key))
                        else {
                            continue;
                        };
                        if ours != action {
                            let e = clashes
                                .entry((*theirs_at, *key, *ours_at, *ours))
                                .or_insert((*action, Vec::new()));
                            e.1.extend(*screen);
                        }
                    }
                }
            }
        }
        if clashes.is_empty() {
            return Ok(self.with_overrides(over));
        }
        let mut problems = Vec::new();
        let mut duplicate_keys = Vec::new();
        for ((theirs_at, key, ours_at, ours), (theirs, screens)) in clashes {
            let (line, col) = over
                .sections
                .get(&theirs_at)
                .and_then(|b| b.at.get(&key))
                .copied()
                .unwrap_or((1, 1));
            let (ours, theirs) = (ours.name(), theirs.name());
            let context = match theirs_at.mode() {
                Mode::Normal if screens.len() == SCREENS.len() => "on every screen".to_string(),
                Mode::Normal => format!("on the {} screen", screens.join(", ")),
                _ => format!("in {theirs_at}"),
            };
            problems.push(Problem {
                line,
                col,
                message: format!(
                    "key `{key}` is bound to `{theirs}` here and to `{ours}` by the default \
                     keymap in {ours_at}: {context} both would apply; give `{ours}` other keys \
                     (or none: `{ours} = []`) in {ours_at} of this file"
                ),
            });
            duplicate_keys.push(match theirs_at {
                Section::Normal => format!("{key} ({theirs}, {ours})"),
                s => format!("{key} ({theirs}, {ours}) in {s}"),
            });
        }
        problems.sort_by_key(|p| (p.line, p.col));
        let more = problems.len().saturating_sub(MAX_PROBLEMS);
        problems.truncate(MAX_PROBLEMS);
        Err(KeymapError::Invalid(Box::new(InvalidKeymap {
            origin: origin.to_string(),
            unknown_actions: Vec::new(),
            unknown_keys: Vec::new(),
            duplicate_keys,
            problems,
            more,
            hints: Vec::new(),
        })))
    }

    /// The keymap to run with: `explicit` (`--keymap FILE`, must exist) or else the user's
    /// `keymap.toml` in mavterm's config directory ([`crate::paths::config_dir`]) if present, layered
    /// on the default.
    pub fn load_user(explicit: Option<&Path>) -> Result<Keymap, KeymapError> {
        if let Some(p) = explicit {
            return Keymap::load(p);
        }
        match Keymap::user_path() {
            Some(p) if p.is_file() => Keymap::load(&p),
            _ => Ok(Keymap::default()),
        }
    }

    /// Where the user's keymap lives by default: `~/.config/mavterm/keymap.toml` (or under
    /// `$XDG_CONFIG_HOME`).
    pub fn user_path() -> Option<PathBuf> {
        Some(crate::paths::config_dir()?.join("keymap.toml"))
    }

    /// `self` with `over` on top, section by section: each action `over` lists in a section
    /// loses its keys in that section here and gets `over`'s; a key `over` binds in a section is
    /// taken from whatever action had it there. `[normal]` covers every screen, so what `over`
    /// lists or binds in `[normal]` is also removed from this keymap's `[normal.SCREEN]`
    /// sections (a legacy `[bindings]` file naming `toggle_expand` replaces its keys on the
    /// overview too). A key `over` binds in `[normal.SCREEN]` shadows this keymap's `[normal]`
    /// binding of that key on that screen only.
    pub fn with_overrides(mut self, over: &Keymap) -> Keymap {
        let empty = Bindings::default();
        let over_normal = over.sections.get(&Section::Normal).unwrap_or(&empty);
        for (section, mine) in self.sections.iter_mut() {
            let theirs = over.sections.get(section).unwrap_or(&empty);
            let inherited = matches!(section, Section::Screen(_));
            mine.remove_where(|k, a| {
                theirs.listed.contains(a)
                    || theirs.keys.contains_key(k)
                    || (inherited
                        && (over_normal.listed.contains(a) || over_normal.keys.contains_key(k)))
            });
        }
        for (section, theirs) in &over.sections {
            let mine = self.sections.entry(*section).or_default();
            mine.keys.extend(theirs.keys.iter().map(|(k, a)| (*k, *a)));
            mine.listed.extend(theirs.listed.iter().copied());
            // Theirs first (their first key is the hint), then ours; every key once.
            let mut order = theirs.order.clone();
            order.extend(mine.order.iter().filter(|k| !theirs.keys.contains_key(k)));
            mine.order = order;
        }
        self
    }

    /// The sections that apply in `mode` on `screen`, most specific first.
    fn chain(mode: Mode, screen: &str) -> Vec<Section> {
        match mode {
            Mode::Normal => SCREENS
                .iter()
                .position(|s| *s == screen)
                .map(Section::Screen)
                .into_iter()
                .chain([Section::Normal])
                .collect(),
            Mode::Help => vec![Section::Help],
            Mode::Prompt => vec![Section::Prompt],
            Mode::Edit => vec![Section::Edit],
        }
    }

    /// The action `key` does in `mode` on `screen` (one of [`SCREENS`]): in normal mode
    /// `[normal.SCREEN]`, then `[normal]`; in the other modes their own section only. `None`
    /// for an unbound key (in prompt and edit mode the core types it, if printable).
    pub fn lookup(&self, mode: Mode, screen: &str, key: &Key) -> Option<Action> {
        Keymap::chain(mode, screen)
            .into_iter()
            .find_map(|s| self.sections.get(&s)?.keys.get(key).copied())
    }

    /// Keys that do `action` in `mode` on `screen`, in the order the keymap file lists them
    /// (screen section first; the first key makes the hint).
    pub fn keys_for(&self, mode: Mode, screen: &str, action: Action) -> Vec<Key> {
        let mut keys: Vec<Key> = Vec::new();
        for section in Keymap::chain(mode, screen) {
            let Some(b) = self.sections.get(&section) else {
                continue;
            };
            for k in &b.order {
                if b.keys.get(k) == Some(&action)
                    && self.lookup(mode, screen, k) == Some(action)
                    && !keys.contains(k)
                {
                    keys.push(*k);
                }
            }
        }
        keys
    }

    /// Every action bound in `mode` on `screen` with its keys, in [`Action::ALL`] order: what
    /// the help popup lists.
    pub fn bindings(&self, mode: Mode, screen: &str) -> Vec<(Action, Vec<Key>)> {
        Action::ALL
            .iter()
            .filter_map(|(a, _, _)| {
                let keys = self.keys_for(mode, screen, *a);
                (!keys.is_empty()).then_some((*a, keys))
            })
            .collect()
    }

    /// The keys bound in one section of this keymap (no inheritance), in file order.
    pub fn section(&self, section: Section) -> Vec<(Key, Action)> {
        self.sections.get(&section).map_or_else(Vec::new, |b| {
            b.order
                .iter()
                .filter_map(|k| Some((*k, *b.keys.get(k)?)))
                .collect()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_keymaps_parse_and_bind_every_action() {
        for (name, text) in [
            ("default.toml", DEFAULT_KEYMAP),
            ("vim.toml", include_str!("../keymaps/vim.toml")),
        ] {
            let km = Keymap::from_toml(text, name).unwrap_or_else(|e| panic!("{e}"));
            for (action, aname, _) in Action::ALL {
                let bound = Mode::ALL.iter().any(|m| {
                    SCREENS
                        .iter()
                        .any(|s| !km.keys_for(*m, s, *action).is_empty())
                });
                assert!(bound, "{name}: `{aname}` unbound");
            }
        }
    }

    #[test]
    fn default_keeps_the_original_bindings() {
        let km = Keymap::default();
        let ov = |k: Key| km.lookup(Mode::Normal, "overview", &k);
        for (k, a) in [
            (Key::ch('q'), Action::Quit),
            (Key::ctrl('c'), Action::Quit),
            (Key::plain(KeyCode::Tab), Action::FocusNext),
            (Key::plain(KeyCode::BackTab), Action::FocusPrev),
            (Key::plain(KeyCode::Enter), Action::ToggleExpand),
            (Key::ch(' '), Action::ToggleExpand),
            (Key::ch('n'), Action::NextVehicle),
            (Key::ch('p'), Action::PrevVehicle),
            (Key::ch('?'), Action::Help),
            (Key::plain(KeyCode::F(1)), Action::Help),
            (Key::plain(KeyCode::Esc), Action::Cancel),
            (Key::plain(KeyCode::Home), Action::Top),
            (Key::plain(KeyCode::End), Action::Bottom),
            (Key::ch(':'), Action::Prompt),
            (Key::ch('1'), Action::Screen(0)),
            (Key::ch('6'), Action::Screen(5)),
        ] {
            assert_eq!(ov(k), Some(a), "{k}");
        }
        assert_eq!(
            km.keys_for(Mode::Normal, "overview", Action::Quit),
            vec![Key::ch('q'), Key::ctrl('c')]
        );
    }

    #[test]
    fn line_index_counts_from_one_in_characters() {
        let ix = LineIndex::new("ab\ncd\n\u{e9}x");
        assert_eq!(ix.line_col(0), (1, 1));
        assert_eq!(ix.line_col(2), (1, 3)); // the newline itself
        assert_eq!(ix.line_col(4), (2, 2));
        assert_eq!(ix.line_col(6), (3, 1));
        assert_eq!(ix.line_col(8), (3, 2)); // after the two-byte é
        assert_eq!(ix.line_col(999), (3, 3)); // clamped to the end
    }
}
