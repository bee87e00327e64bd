//! The pure core: [`App`] state, [`Event`]s in, [`Effect`]s out.
//!
//! No I/O and no clock in here: every event comes with the time, so the same events give the
//! same state and the same effects, in the terminal, in headless replay and in tests.

pub mod camera;
mod confirm;
mod editor;
pub mod files;
mod flight;
pub mod health;
pub mod input;
pub mod inspector;
mod keys;
pub mod links;
pub mod logs;
pub mod map;
pub mod messages;
pub mod mission;
pub mod notices;
pub mod nudge;
pub mod outcome;
pub mod palette;
pub mod param_meta;
pub mod params;
pub mod replay;
pub mod report;
pub mod screen;
pub mod session;
pub mod signing;
pub mod tap;

use std::collections::BTreeMap;

use chrono::{DateTime, Utc};

use crate::clock::{Micros, SECOND};
use crate::dialect::{self, MavMessage};
use crate::keymap::{Key, Keymap, Mode};
use crate::link::replay::{ReplayCmd, ReplayStatus};
use crate::link::{Frame, LinkId, LinkSpec, ParserStats};
use crate::proto::ack::CommandAck;
use crate::proto::loss::SeqOutcome;
use crate::proto::machine::{Incoming, Machine, MachineEvent, Out};
use crate::proto::statustext::StatusTextJoiner;
use crate::proto::vehicles::{Registry, VehicleEvent, VehicleKey, DEFAULT_LOST_TIMEOUT};
use crate::wire::Severity;
use links::{LinkState, LinkStatus};
use notices::{Notice, Notices};
use session::{Session, SessionOut};

/// Settings the core starts with.
#[derive(Debug, Clone)]
pub struct AppConfig {
    /// Our system id (255 is the convention for a GCS).
    pub sysid: u8,
    /// Our component id (190 = MAV_COMP_ID_MISSIONPLANNER, what GCSs use).
    pub compid: u8,
    pub lost_timeout: Micros,
    /// Link specs as given, in link-id order.
    pub links: Vec<String>,
    /// Wall-clock time at `now == 0`, for display only.
    pub epoch: DateTime<Utc>,
    /// The zone times are shown in (status bar, messages): UTC unless the edge resolved the
    /// local one (`--utc` keeps UTC).
    pub zone: crate::clock::DisplayZone,
    /// Ask vehicles for telemetry when first heard.
    pub request_streams: bool,
    /// Download an autopilot's parameters when first heard.
    pub fetch_params: bool,
    /// Telemetry rates to ask autopilots for (config file `[streams]`).
    pub streams: crate::proto::rates::StreamRates,
    /// Default take-off altitude in metres above home (`takeoff` without a number, `T`).
    pub takeoff_alt: f64,
    /// Parameter metadata (`--param-meta`), shared read-only.
    pub param_meta: Option<std::sync::Arc<crate::params::meta::MetaSet>>,
    /// Where downloaded parameter metadata is kept (`mavterm` in the user's cache directory);
    /// `None`: `param meta fetch` is refused and nothing is read from a cache.
    pub param_meta_cache: Option<std::path::PathBuf>,
    /// The published metadata's base URL (`MAVTERM_PARAM_META_URL`); `None`:
    /// [`param_meta::DEFAULT_URL`].
    pub param_meta_url: Option<String>,
    /// MAVLink 2 signing (`--signing-key`); `None`: we do not sign, and take every frame.
    pub signing: Option<signing::SigningConfig>,
    /// Fly mode's deadman: a nudge stops when no key of it has come for this long
    /// (config `nudge_deadman`, seconds).
    pub nudge_deadman: Micros,
    /// Where onboard logs go (`logs` in mavterm's data directory); `None`: `log get` needs a
    /// file.
    pub logs_dir: Option<std::path::PathBuf>,
    /// Onboard log downloads at most this many bytes a second (config `log_rate`); `None`: as
    /// fast as the link goes.
    pub log_rate: Option<u32>,
    /// The map's traffic settings (config `adsb_timeout`, `adsb_warn_distance`,
    /// `adsb_warn_height`).
    pub map: map::MapConfig,
}

impl Default for AppConfig {
    fn default() -> Self {
        Self {
            sysid: 255,
            compid: 190,
            lost_timeout: DEFAULT_LOST_TIMEOUT,
            links: Vec::new(),
            epoch: DateTime::<Utc>::UNIX_EPOCH,
            zone: crate::clock::DisplayZone::utc(),
            request_streams: true,
            fetch_params: true,
            streams: crate::proto::rates::StreamRates::default(),
            takeoff_alt: 10.0,
            param_meta: None,
            param_meta_cache: None,
            param_meta_url: None,
            signing: None,
            nudge_deadman: nudge::DEADMAN,
            logs_dir: None,
            log_rate: None,
            map: map::MapConfig::default(),
        }
    }
}

/// Something that happened, with the time it happened passed beside it to [`App::update`].
#[derive(Debug, Clone)]
pub enum Event {
    /// Time passed.
    Tick,
    /// A link read some bytes: the frames found and the parser counters' increase.
    Frames {
        link: LinkId,
        frames: Vec<Frame>,
        stats: ParserStats,
    },
    LinkState {
        link: LinkId,
        state: LinkState,
    },
    Key(Key),
    /// A key repeated by the terminal while held (terminals that report event kinds): flies
    /// like a press, never answers a question.
    KeyRepeat(Key),
    /// The front end is about to end (quit, its input closed, a signal, a panic): a nudge in
    /// progress ends in a stop.
    Ending,
    /// The process is asked to stop (a `kill -TSTP`): as the suspend key, Fly mode is left
    /// (its stop sent in full) before the front end suspends.
    Suspend,
    /// Text pasted into the terminal (bracketed paste): one event, typed into the line being
    /// edited, if any; keys after it work as ever.
    Paste(String),
    /// A key was let go (terminals that report releases; `release KEY` in replay scripts).
    KeyRelease(Key),
    /// The screen changed size.
    Resize,
    /// A link (or the queue between it and the core) dropped frames it could not hand on.
    Dropped {
        link: LinkId,
        frames: u64,
    },
    /// A file the core asked for ([`Effect::WriteFile`]) was written, or why not.
    FileWritten {
        path: std::path::PathBuf,
        error: Option<String>,
    },
    /// A file the core asked for ([`Effect::ReadFile`]): its bytes, or why not.
    FileRead {
        path: std::path::PathBuf,
        purpose: files::FileUse,
        result: Result<Vec<u8>, String>,
    },
    /// Parameter metadata the core asked for ([`Effect::FetchParamMeta`],
    /// [`Effect::ReadParamMeta`]): its bytes, or why not.
    ParamMeta {
        origin: param_meta::MetaOrigin,
        cache_path: std::path::PathBuf,
        result: Result<Vec<u8>, String>,
    },
    /// The telemetry log the edge records: started, grown (at most once a second), or stopped.
    Recording(tap::RecordingStatus),
    /// A forwarding output (`--out`, numbered in the order given): its state changed, or its
    /// counters did (at most once a second).
    Output {
        out: usize,
        status: tap::OutputStatus,
    },
    /// Where a replay link is (`tlog:`): sent when that changes, in order with its frames.
    ReplayStatus {
        link: LinkId,
        status: ReplayStatus,
    },
    /// What came of an onboard log's file work ([`Effect::LogFile`]).
    LogFile {
        key: VehicleKey,
        done: crate::proto::logs::LogIoDone,
    },
}

/// What the core wants done.
#[derive(Debug, Clone, PartialEq)]
#[allow(clippy::large_enum_variant)] // short-lived; boxing every message buys nothing
pub enum Effect {
    /// Send a frame on a link: `frame` is `msg` encoded with that link's own sequence number.
    Send {
        link: LinkId,
        frame: Vec<u8>,
        msg: MavMessage,
    },
    /// Write a file (atomically: the edge writes a temp file and renames it).
    WriteFile {
        path: std::path::PathBuf,
        contents: Vec<u8>,
    },
    /// Read a file; the bytes come back as [`Event::FileRead`].
    ReadFile {
        path: std::path::PathBuf,
        purpose: files::FileUse,
    },
    /// Download parameter metadata: the first of `urls` that answers; the bytes (or why none
    /// did) come back as [`Event::ParamMeta`]. The edge makes `cache_path`'s directory; the
    /// core writes the file ([`Effect::WriteFile`]) once the bytes parse.
    FetchParamMeta {
        urls: Vec<String>,
        cache_path: std::path::PathBuf,
    },
    /// Read cached parameter metadata; the bytes come back as [`Event::ParamMeta`].
    ReadParamMeta {
        path: std::path::PathBuf,
    },
    /// File work of an onboard log download of vehicle `key` (the edge carries it out in
    /// order); what came of it returns as [`Event::LogFile`].
    LogFile {
        key: VehicleKey,
        io: crate::proto::logs::LogIo,
    },
    /// Open another link, whose id is `link` (the next free one).
    OpenLink {
        link: LinkId,
        spec: LinkSpec,
    },
    /// Pause, step, seek or change the speed of a replay link.
    ReplayControl {
        link: LinkId,
        cmd: ReplayCmd,
    },
    Quit,
}

/// Which pane has the keyboard.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pane {
    Vehicles,
    Links,
    Messages,
}

impl Pane {
    pub const ALL: [Pane; 3] = [Pane::Vehicles, Pane::Links, Pane::Messages];
    pub fn title(self) -> &'static str {
        match self {
            Pane::Vehicles => "Vehicles",
            Pane::Links => "Links",
            Pane::Messages => "Messages",
        }
    }
}

/// View state: what is focused and selected. Lives in the core so replays reproduce it.
#[derive(Debug, Clone)]
pub struct UiState {
    pub focus: Pane,
    /// Selected row in the links pane.
    pub link_sel: usize,
    /// Selected row in the vehicles pane.
    pub vehicle_sel: usize,
    /// Messages shown below the Messages pane's view: 0 = following the newest (see
    /// [`messages`]).
    pub msg_scroll: usize,
    /// Which messages the Messages pane shows.
    pub msg_filter: messages::MsgFilter,
    /// What keys do now: browse (normal), read the key help, type a command or a value.
    pub mode: Mode,
    /// The screen shown: a name from [`screen::SCREENS`].
    pub screen: &'static str,
    /// The `:` command line.
    pub prompt: input::Prompt,
    /// The value being edited in place ([`Mode::Edit`]).
    pub edit: input::TextLine,
    /// The outcome of the last command, or completions, shown in the status bar until the
    /// next key: (severity, text).
    pub message: Option<(Severity, String)>,
    /// Lines scrolled in the key help.
    pub help_scroll: usize,
    /// A dangerous action waiting for `y`.
    pub confirm: Option<confirm::Confirm>,
    /// Questions that came while one was open (a file that finished loading): asked in turn.
    pub confirm_queue: std::collections::VecDeque<confirm::Confirm>,
    /// Selected row of the Commands screen (0 = newest).
    pub cmd_sel: usize,
    /// The command selected there, by its queue id: rows added meanwhile move it down, they
    /// never put another command under the cursor.
    pub cmd_sel_id: Option<u64>,
    /// The command palette, while open (typed in [`Mode::Edit`]).
    pub palette: Option<palette::Palette>,
    /// The Parameters screen.
    pub params: params::ParamView,
    /// The MAVLink Inspector.
    pub inspector: inspector::InspectorView,
    /// The Camera screen's selected camera (row among the target's cameras).
    pub camera_sel: usize,
    /// The Logs screen's selection (a row of the list, newest first).
    pub logs: logs::LogsView,
    /// The gimbal the gimbal keys and `gimbal` point (index among the target's gimbals).
    pub gimbal_sel: usize,
    /// The Mission screen and the mission files loaded.
    pub mission: mission::MissionView,
    /// The mode picker (`M`), while open (its filter typed in [`Mode::Edit`]).
    pub mode_picker: Option<ModePicker>,
    /// The last action and where it stands: the status bar shows it when no message does,
    /// until the next action.
    pub action: Option<outcome::ActionLine>,
    /// Actions started so far (a key that started one shows its line, not its own message).
    pub action_count: u64,
    /// The actions' results, newest last (at most [`outcome::HISTORY`]).
    pub outcomes: std::collections::VecDeque<outcome::OutcomeEntry>,
    /// The help popup lists the results instead of the keys (`:messages`).
    pub show_outcomes: bool,
    /// The Map screen's view.
    pub map: map::MapView,
}

/// The mode picker: the target's modes, filtered by what is typed; enter asks for the one
/// selected through the `mode` command.
#[derive(Debug, Clone, Default)]
pub struct ModePicker {
    /// What is typed: modes containing it (case ignored) are listed.
    pub query: input::TextLine,
    /// Selected row among the modes listed.
    pub sel: usize,
}

impl Default for UiState {
    fn default() -> Self {
        Self {
            focus: Pane::Vehicles,
            link_sel: 0,
            vehicle_sel: 0,
            msg_scroll: 0,
            msg_filter: messages::MsgFilter::default(),
            mode: Mode::Normal,
            screen: screen::SCREENS[0].name,
            prompt: input::Prompt::default(),
            edit: input::TextLine::default(),
            message: None,
            help_scroll: 0,
            confirm: None,
            confirm_queue: Default::default(),
            cmd_sel: 0,
            cmd_sel_id: None,
            palette: None,
            params: params::ParamView::default(),
            inspector: inspector::InspectorView::default(),
            camera_sel: 0,
            logs: logs::LogsView::default(),
            gimbal_sel: 0,
            mission: mission::MissionView::default(),
            mode_picker: None,
            action: None,
            action_count: 0,
            outcomes: std::collections::VecDeque::new(),
            show_outcomes: false,
            map: map::MapView::default(),
        }
    }
}

/// Autopilots that get automatic starts (streams, parameter download) without a budget.
pub const AUTO_FREE: usize = 8;
/// Beyond [`AUTO_FREE`] autopilots: automatic starts allowed per [`AUTO_WINDOW`].
pub const AUTO_BUDGET: usize = 4;
pub const AUTO_WINDOW: Micros = 60 * crate::clock::SECOND;

/// The whole state of mavterm.
#[derive(Debug, Clone)]
pub struct App {
    pub cfg: AppConfig,
    pub now: Micros,
    pub links: Vec<LinkStatus>,
    pub vehicles: Registry,
    pub notices: Notices,
    /// The vehicle commands go to: shown everywhere as the target.
    pub target: Option<VehicleKey>,
    pub ui: UiState,
    pub keymap: Keymap,
    /// One session per autopilot heard, holding its protocol machines.
    pub sessions: BTreeMap<VehicleKey, Session>,
    /// The parameter file last loaded or compared.
    pub param_file: Option<params::LoadedFile>,
    /// Fly mode: keyboard velocity nudges of a GUIDED vehicle.
    pub nudge: nudge::Nudge,
    /// Every message heard, per source: the Inspector's.
    pub inspector: inspector::MessageStore,
    /// Our signing key, timestamp clock and what `signing setup` waits for.
    pub signing: signing::SigningState,
    /// The telemetry log being recorded, as the edge last reported it.
    pub recording: Option<tap::RecordingStatus>,
    /// Where frames are forwarded (`--out`), as the edge last reported them.
    pub outputs: tap::Outputs,
    statustext: StatusTextJoiner,
    next_heartbeat: Micros,
    dirty: bool,
    last_drawn_sec: u64,
    pub quit: bool,
    /// LOG_REQUEST_END went to a vehicle because mavterm ends ([`App::end_log_transfers`]): the
    /// edge gives the links a moment to send it.
    pub log_end_on_exit: bool,
    /// A target was chosen (the first autopilot heard, or by the operator): no automatic pick
    /// after that.
    target_held: bool,
    /// Parameter metadata fetched or read from the cache.
    pub meta: param_meta::MetaState,
    /// Automatic starts for new autopilots within the last [`AUTO_WINDOW`], beyond [`AUTO_FREE`].
    auto_starts: std::collections::VecDeque<Micros>,
    /// New autopilots whose automatic starts the budget held back.
    pub auto_held: u64,
    /// The operator asked to suspend (Ctrl-Z): the terminal front end takes it, gives the
    /// terminal back and stops the process until `fg`.
    pub suspend: bool,
    /// RADIO_STATUS heard on each link (a telemetry radio speaks as its own system).
    pub radio: BTreeMap<LinkId, crate::proto::telemetry::Timed<crate::proto::telemetry::Radio>>,
    /// ADS-B traffic, the vehicles' tracks and the proximity warning (the Map screen's).
    pub air: map::Air,
}

impl App {
    pub fn new(cfg: AppConfig) -> Self {
        let links = cfg
            .links
            .iter()
            .map(|s| LinkStatus::new(s.clone(), cfg.sysid, cfg.compid))
            .collect();
        let vehicles = Registry::new(VehicleKey(cfg.sysid, cfg.compid), cfg.lost_timeout);
        let signing = signing::SigningState::new(cfg.signing.as_ref());
        let nudge = nudge::Nudge::new(cfg.nudge_deadman);
        let air = map::Air::new(cfg.map);
        let mut app = Self {
            cfg,
            now: 0,
            links,
            vehicles,
            notices: Notices::default(),
            target: None,
            ui: UiState::default(),
            keymap: Keymap::default(),
            sessions: BTreeMap::new(),
            param_file: None,
            nudge,
            inspector: inspector::MessageStore::default(),
            signing,
            recording: None,
            outputs: tap::Outputs::default(),
            statustext: StatusTextJoiner::default(),
            next_heartbeat: 0,
            dirty: true,
            last_drawn_sec: 0,
            quit: false,
            log_end_on_exit: false,
            target_held: false,
            meta: param_meta::MetaState::default(),
            auto_starts: std::collections::VecDeque::new(),
            auto_held: 0,
            suspend: false,
            radio: BTreeMap::new(),
            air,
        };
        app.signing_start();
        app
    }

    /// Wall-clock time of a core time, in the zone times are shown in.
    pub fn wall(&self, t: Micros) -> DateTime<chrono::FixedOffset> {
        self.cfg.zone.at(self.instant(t))
    }

    /// The instant of a core time: `epoch + t`.
    fn instant(&self, t: Micros) -> DateTime<Utc> {
        self.cfg.epoch + chrono::Duration::microseconds(t as i64)
    }

    /// The time shown as now: during a tlog replay the recording's own time (the replay's log
    /// time on the clock of the recording), else the wall clock.
    pub fn shown_instant(&self) -> DateTime<Utc> {
        self.replay_view()
            .and_then(|v| {
                let start = v.status.start?;
                let at = start.saturating_add(v.position(self.now));
                DateTime::<Utc>::from_timestamp_micros(at.min(i64::MAX as u64) as i64)
            })
            .unwrap_or_else(|| self.instant(self.now))
    }

    /// [`Self::shown_instant`] in the zone times are shown in.
    pub fn shown_time(&self) -> DateTime<chrono::FixedOffset> {
        self.cfg.zone.at(self.shown_instant())
    }

    /// True when something on screen changed and has not been drawn (without clearing it).
    pub fn is_dirty(&self) -> bool {
        self.dirty || self.now / SECOND != self.last_drawn_sec
    }

    /// True (once) when something on screen changed since the last call.
    pub fn take_dirty(&mut self) -> bool {
        let sec = self.now / SECOND;
        if sec != self.last_drawn_sec {
            // The clock, ages and rates on screen change every second.
            self.last_drawn_sec = sec;
            self.dirty = true;
        }
        std::mem::take(&mut self.dirty)
    }

    /// When the core next needs to be woken with [`Event::Tick`] if nothing else happens: the
    /// GCS heartbeat, a vehicle's lost timeout, a protocol machine's retry. Front ends sleep until
    /// then (or a key, or a frame).
    pub fn next_deadline(&self) -> Micros {
        let mut t = self.next_heartbeat;
        let mut at = |d: Option<Micros>| {
            if let Some(d) = d {
                t = t.min(d);
            }
        };
        at(self.vehicles.next_deadline());
        at(Machine::next_deadline(&self.statustext));
        at(self.signing_deadline());
        for s in self.sessions.values() {
            at(s.next_deadline());
        }
        at(self.nudge.next_deadline());
        at(self.confirm_deadline());
        at(self.map_deadline());
        at(self.capture_deadline());
        t
    }

    /// Queue `msg` on `link`, encoded with that link's sequence number (and signed, when we
    /// sign).
    fn send(&mut self, link: LinkId, msg: MavMessage, fx: &mut Vec<Effect>) {
        let wall = match self.signing.key {
            Some(_) => self.signing_wall(),
            None => 0,
        };
        if let Some(l) = self.links.get_mut(link) {
            let frame = l.encode(&msg, self.signing.next_sign(link, wall));
            fx.push(Effect::Send { link, frame, msg });
        }
    }

    /// Queue `msg` on every link.
    fn send_all(&mut self, msg: &MavMessage, fx: &mut Vec<Effect>) {
        for link in 0..self.links.len() {
            self.send(link, msg.clone(), fx);
        }
    }

    fn link_up(&self, link: LinkId) -> bool {
        self.links
            .get(link)
            .is_some_and(|l| l.state == LinkState::Up)
    }

    /// The link a message for `key` goes out on (see [`Session::route`]).
    pub fn route(&self, key: VehicleKey) -> Option<LinkId> {
        self.sessions
            .get(&key)
            .and_then(|s| s.route(|l| self.link_up(l)))
    }

    /// Carry out what a session asked for.
    fn session_out(&mut self, key: VehicleKey, out: Vec<SessionOut>, fx: &mut Vec<Effect>) {
        for o in out {
            match o {
                SessionOut::Send(msg) => match self.route(key) {
                    Some(link) => self.send(link, msg, fx),
                    None => self.notice(
                        Severity::WARNING,
                        Some(key),
                        format!("no link to {key}: not sent"),
                    ),
                },
                // Nothing automatic on high-latency links, nor when only those reach the vehicle.
                SessionOut::SendAuto(msg) => {
                    let link = self
                        .sessions
                        .get(&key)
                        .and_then(|s| s.route_auto(|l| self.link_up(l)));
                    if let Some(link) = link {
                        self.send(link, msg, fx);
                    }
                }
                SessionOut::SendOn(link, msg) => {
                    if !self.links.get(link).is_some_and(|l| l.profile.hl) {
                        self.send(link, msg, fx)
                    }
                }
                SessionOut::Notice(sev, text) => self.notice(sev, Some(key), text),
                SessionOut::ParamSet {
                    comp,
                    name,
                    confirmed,
                    sev,
                    text,
                } => {
                    self.param_outcome(key, comp, &name, confirmed, sev, &text);
                    self.notice(sev, Some(key), text)
                }
                SessionOut::MissionEnd { ask, sev, text, .. } => {
                    self.mission_outcome(key, ask, sev, &text);
                    self.notice(sev, Some(key), text)
                }
                SessionOut::Command { id, sev, text, .. } => {
                    self.command_outcome(id, sev, &text);
                    self.notice(sev, Some(key), text)
                }
                SessionOut::SequenceDone { sev, text } => {
                    self.sequence_outcome(key, sev, &text);
                    self.notice(sev, Some(key), text)
                }
                SessionOut::CompMeta(e) => self.on_comp_meta(key, e, fx),
            }
        }
        self.follow_sequence(key);
        self.follow_mission(key);
        self.follow_calibration(key);
    }

    /// Poll the sessions that have work due at `now`.
    fn poll_sessions(&mut self, fx: &mut Vec<Effect>) {
        let now = self.now;
        self.follow_log_routes(fx);
        let due: Vec<VehicleKey> = self
            .sessions
            .iter()
            .filter(|(_, s)| s.next_deadline().is_some_and(|d| d <= now))
            .map(|(k, _)| *k)
            .collect();
        for key in due {
            let out = match self.sessions.get_mut(&key) {
                Some(s) => s.poll(now),
                None => continue,
            };
            self.session_out(key, out, fx);
        }
    }

    /// Tell each log machine whether a link that is not high-latency reaches its vehicle (and
    /// when it was last heard on one): log traffic never goes on a high-latency link unless the
    /// operator asked there.
    fn follow_log_routes(&mut self, fx: &mut Vec<Effect>) {
        let now = self.now;
        let normal: Vec<bool> = self
            .links
            .iter()
            .map(|l| l.state == LinkState::Up && !l.profile.hl)
            .collect();
        let mut changed = Vec::new();
        for (key, s) in self.sessions.iter_mut() {
            let route = s.last_heard_on(|l| normal.get(l).copied().unwrap_or(false));
            if route.is_some() != s.logs.route.is_some() || s.logs.waiting_for_link.is_some() {
                changed.push((*key, route));
            } else {
                s.logs.route = route;
            }
        }
        for (key, route) in changed {
            let Some(s) = self.sessions.get_mut(&key) else {
                continue;
            };
            let (_, out) = s.logs_do(now, |m, o| m.set_route(now, route, o));
            self.session_out(key, out, fx);
        }
    }

    /// mavterm ends: every log download running is cancelled with LOG_REQUEST_END (the vehicle
    /// logs again); their partials stay for a resume.
    pub fn end_log_transfers(&mut self, fx: &mut Vec<Effect>) {
        let now = self.now;
        let keys: Vec<VehicleKey> = self.sessions.keys().copied().collect();
        for key in keys {
            let Some(s) = self.sessions.get_mut(&key) else {
                continue;
            };
            let (ended, out) = s.logs_do(now, |m, o| m.on_exit(now, o));
            self.session_out(key, out, fx);
            self.log_end_on_exit |= ended;
        }
    }

    /// Our own GCS heartbeat (MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID).
    pub fn gcs_heartbeat() -> MavMessage {
        MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
            custom_mode: 0,
            mavtype: dialect::MavType::MAV_TYPE_GCS,
            autopilot: dialect::MavAutopilot::MAV_AUTOPILOT_INVALID,
            base_mode: dialect::MavModeFlag::empty(),
            system_status: dialect::MavState::MAV_STATE_ACTIVE,
            mavlink_version: 3,
        })
    }

    /// A file the edge read for us: its name as shown and its text, or `None` after telling the
    /// operator why it could not be read.
    fn file_text(
        &mut self,
        path: &std::path::Path,
        result: Result<Vec<u8>, String>,
    ) -> Option<(String, String)> {
        let shown = path.display().to_string();
        match result {
            Ok(b) => Some((shown, String::from_utf8_lossy(&b).into_owned())),
            Err(e) => {
                let text = format!("could not read {shown}: {e}");
                self.read_outcome(path, Severity::ERROR, text.clone());
                self.notice(Severity::ERROR, None, text);
                None
            }
        }
    }

    fn notice(&mut self, severity: Severity, source: Option<VehicleKey>, text: String) {
        let n = Notice {
            t: self.now,
            at: self.shown_instant(),
            severity,
            source,
            ours: true,
            text,
        };
        self.on_new_notice(&n);
        self.notices.push(n);
        self.dirty = true;
    }

    /// Apply one event at time `now`; returns what should be done.
    pub fn update(&mut self, now: Micros, event: Event) -> Vec<Effect> {
        self.now = self.now.max(now);
        let mut fx = Vec::new();
        self.on_time(&mut fx);
        match event {
            Event::Tick => {}
            Event::Frames {
                link,
                frames,
                stats,
            } => self.on_frames(link, frames, stats, &mut fx),
            Event::LinkState { link, state } => self.on_link_state(link, state),
            Event::Key(key) => self.on_key(key, false, &mut fx),
            Event::KeyRepeat(key) => self.on_key(key, true, &mut fx),
            Event::Paste(text) => self.on_paste(&text),
            Event::KeyRelease(key) => self.on_key_release(key, &mut fx),
            Event::Ending => {
                self.leave_fly(&mut fx);
                self.end_log_transfers(&mut fx);
            }
            Event::Suspend => self.on_action(crate::keymap::Action::Suspend, &mut fx),
            Event::Resize => self.dirty = true,
            Event::FileWritten { path, error } if self.signing.is_state_file(&path) => {
                self.signing_file_written(error)
            }
            Event::FileWritten { path, error } => {
                self.file_outcome(&path, error.as_deref());
                match error {
                    None => self.notice(Severity::INFO, None, format!("saved {}", path.display())),
                    Some(e) => self.notice(
                        Severity::ERROR,
                        None,
                        format!("could not save {}: {e}", path.display()),
                    ),
                }
            }
            Event::FileRead {
                path,
                purpose: files::FileUse::Mission(t),
                result,
            } => self.on_mission_file(path, t, result),
            Event::FileRead {
                path,
                purpose,
                result,
            } => self.on_file_read(path, purpose, result),
            Event::Dropped { link, frames } => {
                if let Some(l) = self.links.get_mut(link) {
                    l.dropped += frames;
                    self.dirty = true;
                }
            }
            Event::ParamMeta {
                origin,
                cache_path,
                result,
            } => self.on_param_meta(origin, cache_path, result, &mut fx),
            Event::Recording(st) => self.on_recording(st),
            Event::Output { out, status } => self.on_output(out, status),
            Event::ReplayStatus { link, status } => self.on_replay_status(link, status),
            Event::LogFile { key, done } => self.on_log_file(key, done, &mut fx),
        }
        self.poll_confirm();
        self.poll_nudge(&mut fx);
        self.poll_sessions(&mut fx);
        self.follow_reason();
        self.follow_before_flight();
        self.poll_param_meta(&mut fx);
        self.follow_selected_command();
        self.follow_logs(&mut fx);
        self.follow_log_list();
        self.follow_capture();
        fx
    }

    /// Pasted text: into the `:` line or the value being edited; elsewhere nothing (a paste
    /// never runs commands or presses keys).
    fn on_paste(&mut self, text: &str) {
        let edit = self.ui.mode == crate::keymap::Mode::Edit;
        let whole = match self.ui.palette.as_mut() {
            // The palette's search or the field typed into.
            Some(p) if edit => {
                p.error = None;
                match p.form.as_mut() {
                    None => {
                        let whole = p.query.paste(text);
                        p.refilter();
                        whole
                    }
                    Some(form) => form.fields[form.focus].paste(text),
                }
            }
            _ => {
                let line = match self.ui.mode {
                    crate::keymap::Mode::Prompt => &mut self.ui.prompt.line,
                    crate::keymap::Mode::Edit => &mut self.ui.edit,
                    _ => return,
                };
                let whole = line.paste(text);
                // The parameter search follows its line, as it does for typed keys.
                if edit
                    && self.ui.params.editing == Some(params::ParamEdit::Filter)
                    && self.ui.params.filter != self.ui.edit.text
                {
                    self.ui.params.filter = self.ui.edit.text.clone();
                    self.ui.params.sel = 0;
                }
                whole
            }
        };
        if !whole {
            self.ui.message = Some((
                Severity::WARNING,
                format!(
                    "line full: {} characters at most",
                    crate::app::input::MAX_LINE
                ),
            ));
        }
        self.dirty = true;
    }

    /// Timers: the 1 Hz GCS heartbeat and vehicle timeouts.
    fn on_time(&mut self, fx: &mut Vec<Effect>) {
        if self.now >= self.next_heartbeat {
            self.send_all(&Self::gcs_heartbeat(), fx);
            self.next_heartbeat += SECOND;
            if self.next_heartbeat <= self.now {
                self.next_heartbeat = self.now + SECOND;
            }
        }
        for l in &mut self.links {
            l.sample_loss(self.now);
        }
        let events = self.vehicles.tick(self.now);
        self.on_vehicle_events(events, fx);
        let mut texts = Vec::new();
        Machine::poll(&mut self.statustext, self.now, &mut texts);
        self.on_texts(texts);
        self.signing_time(fx);
        self.map_time();
    }

    fn on_link_state(&mut self, link: LinkId, state: LinkState) {
        let Some(l) = self.links.get_mut(link) else {
            return;
        };
        if l.state == state {
            return;
        }
        let spec = l.spec.clone();
        l.state = state.clone();
        match state {
            LinkState::Up => {
                l.notified_down = None;
                if std::mem::replace(&mut l.was_up, true) {
                    // A reconnect (a new TCP connection, a serial port back): every sender's
                    // count starts afresh, so the outage is not loss, and streams are asked for
                    // again on this link.
                    for s in l.sources.values_mut() {
                        s.seq.restart_sequence();
                    }
                    for s in self.sessions.values_mut() {
                        s.on_link_reconnected(link);
                    }
                }
                self.notice(Severity::INFO, None, format!("link {spec} up"))
            }
            LinkState::Down(reason) => {
                // A link retried with the same failure is told of once.
                if l.notified_down.as_ref() != Some(&reason) {
                    l.notified_down = Some(reason.clone());
                    self.notice(
                        Severity::WARNING,
                        None,
                        format!("link {spec} down: {reason}"),
                    )
                }
                self.dirty = true;
            }
            LinkState::Connecting => self.dirty = true,
        }
    }

    fn on_frames(
        &mut self,
        link: LinkId,
        frames: Vec<Frame>,
        stats: ParserStats,
        fx: &mut Vec<Effect>,
    ) {
        let now = self.now;
        let Some(l) = self.links.get_mut(link) else {
            return;
        };
        l.parser.add(&stats);
        l.tx.observe(&l.parser);
        l.rate.add(now, frames.len() as u64, stats.bytes);
        if l.state != LinkState::Up && !frames.is_empty() {
            self.on_link_state(link, LinkState::Up);
        }
        self.dirty = true;
        // The Inspector keeps every payload only while it is on screen.
        self.inspector.live = self.ui.screen == INSPECTOR;
        // By reference: a frame is 88 bytes to move.
        for frame in &frames {
            self.on_frame(link, frame, fx);
        }
        self.sample_tracks();
    }

    /// One frame from `link`: counted on the link, then handled once however many links carry it.
    fn on_frame(&mut self, link: LinkId, frame: &Frame, fx: &mut Vec<Effect>) {
        let now = self.now;
        let key = VehicleKey(frame.sysid, frame.compid);
        // An id our dialect does not know has no CRC we could check: counted on the link only
        // (the parser did), never a source, never loss.
        let Some(limits) = crate::wire::parser::msg_limits(frame.msgid) else {
            return;
        };
        let crc = frame.crc();
        // Our own frame coming back through a router: not another GCS, not a source.
        if key == VehicleKey(self.cfg.sysid, self.cfg.compid)
            && self.links[link].sent_by_us(frame.seq, crc)
        {
            self.links[link].echoes += 1;
            return;
        }
        // Signing decides before anything reads the frame: a rejected one is only counted.
        let checked = self.check_signing(link, frame);
        if !checked.accepted {
            self.signing_rejected(link, frame, checked);
            return;
        }
        // The same frame on a second link (redundant radios): counted on this link below, and
        // it tells us the vehicle is heard here, but its content was handled when it first came.
        // With one link there is no other link for it to have come on.
        let copy = self.links.len() > 1
            && self.links.iter().enumerate().any(|(i, other)| {
                i != link
                    && other
                        .sources
                        .get(&key)
                        .is_some_and(|s| s.recent.has(frame.seq, frame.msgid, crc, now))
            });
        let (outcome, repeat, first) = {
            let src = self.links[link].source(key);
            let first = src.signing.count(checked);
            src.frames += 1;
            src.last_heard = now;
            let same = src.same_as_before(frame.seq, crc, now);
            let outcome = src.seq.record(frame.seq, now);
            // The same frame again carries nothing new.
            let repeat = outcome == SeqOutcome::Duplicate && same;
            if !copy && !repeat {
                src.recent.push(frame.seq, frame.msgid, crc, now);
            }
            (outcome, repeat, first)
        };
        if first || self.signing.watch.is_some() {
            self.signing_accepted(link, key, checked, first);
        }
        if outcome == SeqOutcome::Restart && self.vehicles.get(key).is_some() {
            let ev = self.vehicles.on_sequence_restart(key, now);
            self.on_vehicle_events(ev, fx);
        }
        if repeat {
            return;
        }
        if !copy {
            self.inspector.record(now, frame);
        }
        // The message, decoded here when the link's parser left it (it decodes nothing) and
        // something reads this id; one that does not decode is counted on the link.
        let decoded;
        let fallback;
        let msg = match frame.message.as_deref() {
            Some(m) => Some(m),
            None if frame.lazy && reads(frame.msgid, limits.targeted) => {
                decoded = frame.decode();
                match &decoded {
                    Ok(m) => Some(m),
                    Err(_) => {
                        self.links[link].parser.decode_errors += 1;
                        None
                    }
                }
            }
            None => None,
        };
        let msg = match msg {
            Some(m) => Some(m),
            None => {
                fallback = heartbeat_fallback(frame);
                fallback.as_ref()
            }
        };
        let ack = CommandAck::from_frame(frame).filter(|_| !copy);
        match msg {
            Some(MavMessage::HEARTBEAT(hb)) => {
                self.on_heartbeat_frame(link, key, hb, frame, fx);
            }
            _ if copy => {}
            // time_boot_ms u32 at byte 8 (after time_unix_usec), from the payload.
            _ if frame.msgid == <dialect::SYSTEM_TIME_DATA as mavlink::MessageData>::ID => {
                let boot_ms = crate::wire::payload::Payload(frame.payload()).u32(8);
                let ev = self.vehicles.on_system_time(key, boot_ms, now);
                self.on_vehicle_events(ev, fx);
            }
            Some(MavMessage::STATUSTEXT(_)) => {
                self.on_statustext_frame(link, frame, msg);
            }
            Some(MavMessage::RADIO_STATUS(r)) => self.on_radio_status(link, r),
            Some(MavMessage::ADSB_VEHICLE(_)) => self.on_adsb_frame(link, frame, msg),
            _ => {}
        }
        if self.for_us(limits.targeted, msg, ack.as_ref()) {
            self.hand_to_sessions(link, frame, msg, ack.as_ref(), fx);
        }
    }

    /// A heartbeat: the vehicle table, room made when it is full, and a session for a new
    /// autopilot (or a payload alone on its system).
    fn on_heartbeat_frame(
        &mut self,
        link: LinkId,
        key: VehicleKey,
        hb: &dialect::HEARTBEAT_DATA,
        frame: &Frame,
        fx: &mut Vec<Effect>,
    ) {
        let now = self.now;
        if self.vehicles.full_for(key) {
            // A full table makes room: never at the cost of the target or of a vehicle
            // with work in flight.
            // Work in flight: a busy session, the target of every open command and
            // the component whose parameters are downloading.
            let mut kept = Vec::new();
            for (k, s) in &self.sessions {
                if s.busy() {
                    kept.push(*k);
                }
                kept.extend(
                    s.commands
                        .entries()
                        .filter(|e| e.open())
                        .map(|e| VehicleKey::from(e.spec.target)),
                );
                if let Some((comp, ..)) = s.params.downloading() {
                    kept.push(VehicleKey(k.0, comp));
                }
            }
            kept.extend(self.target);
            kept.extend(self.nudge.target);
            self.vehicles.keep(kept);
        }
        let ev = self
            .vehicles
            .on_heartbeat(link, key, hb, frame.version, now);
        self.on_vehicle_events(ev, fx);
        let autopilot = self.vehicles.get(key).is_some_and(|v| v.is_autopilot());
        // A camera or gimbal alone on its system (no autopilot heard there) gets a
        // session of its own, so it can be targeted and operated; an autopilot of the
        // system heard later takes over (the payload is reached through it).
        let flood = self.vehicles.get(key).is_some_and(|v| v.flood);
        let alone = !autopilot
            && !flood
            && self.vehicles.get(key).is_some_and(|v| v.is_payload())
            && self
                .sessions
                .range(VehicleKey(key.0, 0)..=VehicleKey(key.0, u8::MAX))
                .next()
                .is_none();
        if !self.sessions.contains_key(&key) && (autopilot || alone) {
            if autopilot {
                self.drop_payload_sessions(key.0);
            }
            // Found during a heartbeat flood: nothing starts on its own (the operator
            // can still ask). Beyond AUTO_FREE autopilots, automatic starts are held to
            // AUTO_BUDGET a minute, so a trickle of new ids below the flood threshold
            // cannot start unbounded downloads.
            let auto = autopilot && !flood && self.auto_budget(now);
            let mut s = Session::new(
                key,
                hb.autopilot,
                self.cfg.request_streams && auto,
                self.cfg.fetch_params && auto,
                self.cfg.streams.clone(),
            );
            s.mission.gcs = (self.cfg.sysid, self.cfg.compid);
            self.setup_logs(&mut s, hb.autopilot);
            self.sessions.insert(key, s);
            if alone && self.target.is_none() && !self.target_held {
                self.target = Some(key);
                self.target_held = true;
            }
        }
    }

    /// A STATUSTEXT chunk, to the joiner.
    fn on_statustext_frame(&mut self, link: LinkId, frame: &Frame, msg: Option<&MavMessage>) {
        let incoming = Incoming {
            now: self.now,
            from: (frame.sysid, frame.compid),
            link,
            profile: self.links[link].profile,
            id: frame.msgid,
            payload: frame.payload(),
            msg,
            ack: None,
        };
        let mut texts = Vec::new();
        Machine::on_message(&mut self.statustext, &incoming, &mut texts);
        self.on_texts(texts);
    }

    /// The joiner's texts: each is told, and handed to the sessions of its system (a refusal's
    /// reason), unless its last chunk never came.
    fn on_texts(&mut self, texts: Vec<Out>) {
        let now = self.now;
        for o in texts {
            let Out::Event(MachineEvent::Text {
                from,
                sev,
                text,
                late,
            }) = o
            else {
                continue;
            };
            if !late {
                // A vehicle's reason for refusing a command comes as text.
                let keys: Vec<VehicleKey> = self
                    .sessions
                    .range(VehicleKey(from.0, 0)..=VehicleKey(from.0, u8::MAX))
                    .map(|(k, _)| *k)
                    .collect();
                for k in keys {
                    if let Some(s) = self.sessions.get_mut(&k) {
                        s.on_text(now, &text);
                    }
                }
            }
            self.vehicle_notice(sev, from, text);
        }
    }

    /// A message for us (or broadcast) handed to every session of the sender's system.
    fn hand_to_sessions(
        &mut self,
        link: LinkId,
        frame: &Frame,
        msg: Option<&MavMessage>,
        ack: Option<&CommandAck>,
        fx: &mut Vec<Effect>,
    ) {
        let (now, key) = (self.now, VehicleKey(frame.sysid, frame.compid));
        // Every session of the sender's system (almost always one) is handed the message, then
        // what they ask for is carried out, in key order. A session's own state is all
        // `on_message` touches, so this is the same as doing each in turn. Few sessions are
        // looked through faster than a range is found.
        let incoming = Incoming {
            now,
            from: key.into(),
            link,
            profile: self.links[link].profile,
            id: frame.msgid,
            payload: frame.payload(),
            msg,
            ack,
        };
        let mut outs = Vec::new();
        // Only a component found during a heartbeat flood is quiet: none, no lookup.
        let quiet =
            self.vehicles.flood_found > 0 && self.vehicles.get(key).is_some_and(|v| v.flood);
        let mut handle = |k: &VehicleKey, s: &mut Session| {
            if quiet && s.quiet.len() < 256 {
                s.quiet.insert(key.1);
            }
            let mut out = Vec::new();
            s.on_message(&incoming, &mut out);
            if !out.is_empty() {
                outs.push((*k, out));
            }
        };
        if self.sessions.len() == 1 {
            if let Some(mut only) = self.sessions.first_entry() {
                let k = *only.key();
                if k.0 == key.0 {
                    handle(&k, only.get_mut());
                }
            }
        } else if self.sessions.len() <= 8 {
            for (k, s) in self.sessions.iter_mut() {
                if k.0 == key.0 {
                    handle(k, s);
                }
            }
        } else {
            for (k, s) in self
                .sessions
                .range_mut(VehicleKey(key.0, 0)..=VehicleKey(key.0, u8::MAX))
            {
                handle(k, s);
            }
        }
        if !outs.is_empty() {
            for (k, out) in outs {
                self.session_out(k, out, fx);
            }
        }
    }

    /// True for a message that names no target, or names us or everyone (0); `targeted`: its
    /// id has target fields (the dialect's table).
    fn for_us(&self, targeted: bool, msg: Option<&MavMessage>, ack: Option<&CommandAck>) -> bool {
        use mavlink::Message;
        let (sys, comp) = match (msg, ack) {
            (_, Some(a)) => (Some(a.target_system), Some(a.target_component)),
            // Most messages have no target field: the dialect's table says so without asking
            // the message.
            (Some(_), None) if !targeted => (None, None),
            (Some(m), None) => (m.target_system_id(), m.target_component_id()),
            (None, None) => (None, None),
        };
        let ok = |t: Option<u8>, us: u8| t.is_none_or(|t| t == 0 || t == us);
        ok(sys, self.cfg.sysid) && ok(comp, self.cfg.compid)
    }

    /// The sessions of stand-alone payloads of system `sysid`: an autopilot of it was heard.
    /// The target's session stays (the autopilot heard may be spoofed; only the operator moves
    /// the target).
    fn drop_payload_sessions(&mut self, sysid: u8) {
        let payloads: Vec<VehicleKey> = self
            .sessions
            .range(VehicleKey(sysid, 0)..=VehicleKey(sysid, u8::MAX))
            .map(|(k, _)| *k)
            .filter(|k| !self.vehicles.get(*k).is_some_and(|v| v.is_autopilot()))
            .filter(|k| self.target != Some(*k) && self.nudge.target != Some(*k))
            .collect();
        for k in payloads {
            self.sessions.remove(&k);
        }
    }

    /// Whether an automatic start (stream setup, parameter download) for a newly heard
    /// autopilot fits the budget: always while at most [`AUTO_FREE`] autopilots are known,
    /// beyond that [`AUTO_BUDGET`] per [`AUTO_WINDOW`]. Counts what it allows.
    fn auto_budget(&mut self, now: Micros) -> bool {
        let autopilots = self
            .sessions
            .keys()
            .filter(|k| self.vehicles.get(**k).is_some_and(|v| v.is_autopilot()))
            .count();
        if autopilots <= AUTO_FREE {
            return true;
        }
        while self
            .auto_starts
            .front()
            .is_some_and(|&t| now.saturating_sub(t) >= AUTO_WINDOW)
        {
            self.auto_starts.pop_front();
        }
        if self.auto_starts.len() >= AUTO_BUDGET {
            self.auto_held += 1;
            return false;
        }
        self.auto_starts.push_back(now);
        true
    }

    fn on_vehicle_events(&mut self, events: Vec<VehicleEvent>, fx: &mut Vec<Effect>) {
        for ev in events {
            match ev {
                VehicleEvent::Found(key) => {
                    let (desc, autopilot) = match self.vehicles.get(key) {
                        // Found in a flood: listed and counted, told of once for all.
                        Some(v) if v.flood => continue,
                        Some(v) => (
                            format!("{} {}", v.autopilot_name(), v.type_name()),
                            v.is_autopilot(),
                        ),
                        None => continue,
                    };
                    self.notice(
                        Severity::NOTICE,
                        Some(key),
                        format!("vehicle {key} found ({desc})"),
                    );
                    // The first autopilot heard becomes the target; after that only the
                    // operator changes it.
                    if autopilot && self.target.is_none() && !self.target_held {
                        self.target = Some(key);
                        self.target_held = true;
                    }
                }
                VehicleEvent::Lost(key) | VehicleEvent::Back(key)
                    if self.vehicles.get(key).is_some_and(|v| v.flood) => {}
                VehicleEvent::Flood(n) => self.notice(
                    Severity::ERROR,
                    None,
                    format!(
                        "heartbeat flood: {n} new ids within {} s; new vehicles are listed \
                         without notices or automatic downloads, the target stays",
                        crate::proto::vehicles::FLOOD_WINDOW / crate::clock::SECOND
                    ),
                ),
                VehicleEvent::Lost(key) => {
                    self.notice(
                        Severity::WARNING,
                        Some(key),
                        format!("vehicle {key} lost (no heartbeat)"),
                    );
                    if self.nudge.target == Some(key) {
                        self.leave_fly(fx);
                        self.notice(
                            Severity::WARNING,
                            Some(key),
                            "Fly mode left: vehicle lost".into(),
                        );
                    }
                }
                VehicleEvent::Back(key) => {
                    self.notice(Severity::NOTICE, Some(key), format!("vehicle {key} back"))
                }
                VehicleEvent::Rebooted(key, why) => {
                    self.notice(
                        Severity::WARNING,
                        Some(key),
                        format!("vehicle {key} rebooted ({why})"),
                    );
                    // A rebooted autopilot forgets what it was asked: its machines start over.
                    if let Some(s) = self.sessions.get_mut(&key) {
                        let out = s.on_reboot(self.now);
                        self.session_out(key, out, fx);
                    }
                }
                VehicleEvent::Conflict(key, detail) => {
                    self.notice(Severity::ERROR, Some(key), format!("sysid clash: {detail}"))
                }
                VehicleEvent::UsesGcsSysid(key) => {
                    let text = if key == VehicleKey(self.cfg.sysid, self.cfg.compid) {
                        format!("another GCS uses our id {key}: replies may go to either")
                    } else {
                        format!("component {key} uses our GCS sysid {}", self.cfg.sysid)
                    };
                    self.notice(Severity::ERROR, Some(key), text)
                }
                VehicleEvent::Evicted(key) => {
                    self.sessions.remove(&key);
                    if self.target == Some(key) {
                        self.target = None;
                    }
                }
            }
        }
    }
}

/// The Inspector's screen name.
pub(crate) const INSPECTOR: &str = "inspector";

/// The message ids the core reads decoded, beyond the sessions' machines: handled here
/// ([`App::on_frame`]).
const APP_READS: [u32; 4] = [
    <dialect::HEARTBEAT_DATA as mavlink::MessageData>::ID,
    <dialect::STATUSTEXT_DATA as mavlink::MessageData>::ID,
    <dialect::RADIO_STATUS_DATA as mavlink::MessageData>::ID,
    <dialect::ADSB_VEHICLE_DATA as mavlink::MessageData>::ID,
];

/// Whether the core reads message `id` decoded: a session's machine reads it decoded
/// ([`session::DECODES`]), the core itself does (`APP_READS`), or it names a target
/// (`targeted`, from the dialect's table: the target says whether it is for us). The rest (more than half of what a vehicle streams, and
/// PARAM_VALUE, read from its payload) are counted, measured and recorded from their bytes.
#[inline]
pub fn reads(id: u32, targeted: bool) -> bool {
    let set = READS.get_or_init(ReadSet::build);
    let named = match set.small.get((id / 64) as usize) {
        Some(w) => w & (1 << (id % 64)) != 0,
        None => set.large.binary_search(&id).is_ok(),
    };
    named || targeted
}

static READS: std::sync::OnceLock<ReadSet> = std::sync::OnceLock::new();

/// The ids read decoded by name (not for their target): a bit each below 512, the rest sorted.
struct ReadSet {
    small: [u64; 8],
    large: Vec<u32>,
}

impl ReadSet {
    fn build() -> ReadSet {
        use crate::proto::machine::Ids;
        let mut ids = APP_READS.to_vec();
        for decodes in session::DECODES {
            match decodes {
                Ids::Only(some) => ids.extend_from_slice(some),
                // A machine reading every message decoded: every id the dialect knows.
                Ids::All => ids.extend(
                    (0..=u32::from(u16::MAX))
                        .filter(|&id| crate::wire::parser::msg_limits(id).is_some()),
                ),
            }
        }
        let mut set = ReadSet {
            small: [0; 8],
            large: Vec::new(),
        };
        for id in ids {
            match set.small.get_mut((id / 64) as usize) {
                Some(w) => *w |= 1 << (id % 64),
                None => set.large.push(id),
            }
        }
        set.large.sort_unstable();
        set.large.dedup();
        set
    }
}

/// A HEARTBEAT whose payload the dialect refused (an enum value newer than our dialect, from a
/// newer or third-party stack): read its nine bytes by hand, so the component is still listed.
/// Unknown type/autopilot/state become GENERIC/GENERIC/UNINIT.
fn heartbeat_fallback(frame: &Frame) -> Option<MavMessage> {
    use dialect::{MavAutopilot, MavModeFlag, MavState, MavType};
    use num_traits::FromPrimitive;
    if frame.msgid != <dialect::HEARTBEAT_DATA as mavlink::MessageData>::ID {
        return None;
    }
    let p = crate::wire::payload::Payload(frame.payload());
    Some(MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
        custom_mode: p.u32(0),
        mavtype: MavType::from_u8(p.u8(4)).unwrap_or(MavType::MAV_TYPE_GENERIC),
        autopilot: MavAutopilot::from_u8(p.u8(5)).unwrap_or(MavAutopilot::MAV_AUTOPILOT_GENERIC),
        base_mode: MavModeFlag::from_bits_truncate(p.u8(6)),
        system_status: MavState::from_u8(p.u8(7)).unwrap_or(MavState::MAV_STATE_UNINIT),
        mavlink_version: p.u8(8),
    }))
}
