//! The pure core: [`App`] state, [`Event`]s in, [`Effect`]s out.
//!
//! No I/O and no clock in here: every event comes with the time, so the same events give the
//! same state and the same effects, in the terminal, in headless replay and in tests.

pub mod links;
pub mod notices;
pub mod report;

use std::collections::BTreeSet;

use chrono::{DateTime, Utc};

use crate::clock::{Micros, SECOND};
use crate::dialect::{self, MavMessage};
use crate::keymap::{Action, Key, Keymap, Mode};
use crate::link::{Frame, LinkId, ParserStats};
use crate::proto::loss::SeqOutcome;
use crate::proto::streams;
use crate::proto::vehicles::{Registry, VehicleEvent, VehicleKey, DEFAULT_LOST_TIMEOUT};
use links::{LinkState, LinkStatus};
use notices::{Notice, Notices, SEV_ERROR, SEV_INFO, SEV_NOTICE, SEV_WARNING};

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
    /// Ask vehicles for telemetry when first heard.
    pub request_streams: bool,
}

impl Default for AppConfig {
    fn default() -> Self {
        Self {
            sysid: 255,
            compid: 190,
            lost_timeout: DEFAULT_LOST_TIMEOUT,
            links: Vec::new(),
            epoch: DateTime::<Utc>::UNIX_EPOCH,
            request_streams: true,
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
    /// The screen changed size.
    Resize,
}

/// What the core wants done.
#[derive(Debug, Clone, PartialEq)]
#[allow(clippy::large_enum_variant)] // short-lived; boxing every message buys nothing
pub enum Effect {
    /// Send a message on one link, or on every link when `link` is `None`.
    Send {
        link: Option<LinkId>,
        msg: MavMessage,
    },
    /// Write a file (atomically: the edge writes a temp file and renames it).
    WriteFile {
        path: std::path::PathBuf,
        contents: Vec<u8>,
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
    /// Lines scrolled back from the newest message.
    pub msg_scroll: usize,
    pub help: bool,
}

impl Default for UiState {
    fn default() -> Self {
        Self {
            focus: Pane::Vehicles,
            link_sel: 0,
            vehicle_sel: 0,
            msg_scroll: 0,
            help: false,
        }
    }
}

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
    next_heartbeat: Micros,
    streams_requested: BTreeSet<VehicleKey>,
    dirty: bool,
    last_drawn_sec: u64,
    pub quit: bool,
}

impl App {
    pub fn new(cfg: AppConfig) -> Self {
        let links = cfg.links.iter().cloned().map(LinkStatus::new).collect();
        let vehicles = Registry::new((cfg.sysid, cfg.compid), cfg.lost_timeout);
        Self {
            cfg,
            now: 0,
            links,
            vehicles,
            notices: Notices::default(),
            target: None,
            ui: UiState::default(),
            keymap: Keymap::default(),
            next_heartbeat: 0,
            streams_requested: BTreeSet::new(),
            dirty: true,
            last_drawn_sec: 0,
            quit: false,
        }
    }

    /// Wall-clock time of a core time, for display.
    pub fn wall(&self, t: Micros) -> DateTime<Utc> {
        self.cfg.epoch + chrono::Duration::microseconds(t as i64)
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

    fn notice(&mut self, severity: u8, source: Option<(u8, u8)>, text: String) {
        self.notices.push(Notice {
            t: self.now,
            severity,
            source,
            text,
        });
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
            Event::Key(key) if key == Key::ctrl('c') => {
                // Ctrl-C always quits, whatever the keymap says: raw mode has turned off SIGINT.
                self.on_action(Action::Quit, &mut fx);
            }
            Event::Key(key) => match self.keymap.lookup(Mode::Normal, "overview", &key) {
                Some(action) => self.on_action(action, &mut fx),
                // Any key closes help, bound or not.
                None if self.ui.help => {
                    self.ui.help = false;
                    self.dirty = true;
                }
                None => {}
            },
            Event::Resize => self.dirty = true,
        }
        fx
    }

    /// Timers: the 1 Hz GCS heartbeat and vehicle timeouts.
    fn on_time(&mut self, fx: &mut Vec<Effect>) {
        if self.now >= self.next_heartbeat {
            fx.push(Effect::Send {
                link: None,
                msg: Self::gcs_heartbeat(),
            });
            self.next_heartbeat += SECOND;
            if self.next_heartbeat <= self.now {
                self.next_heartbeat = self.now + SECOND;
            }
        }
        let events = self.vehicles.tick(self.now);
        self.on_vehicle_events(events, fx);
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
                self.notice(SEV_INFO, None, format!("link {spec} up"))
            }
            LinkState::Down(reason) => {
                // A link retried with the same failure is told of once.
                if l.notified_down.as_ref() != Some(&reason) {
                    l.notified_down = Some(reason.clone());
                    self.notice(SEV_WARNING, None, format!("link {spec} down: {reason}"))
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
        l.rate.add(now, frames.len() as u64, stats.bytes);
        if l.state != LinkState::Up && !frames.is_empty() {
            self.on_link_state(link, LinkState::Up);
        }
        self.dirty = true;
        for frame in frames {
            let key = (frame.sysid, frame.compid);
            let (outcome, repeat) = {
                let src = self.links[link].sources.entry(key).or_default();
                src.frames += 1;
                src.last_heard = now;
                let repeat = src.same_as_before(frame.seq, frame.crc(), now);
                (src.seq.record(frame.seq, now), repeat)
            };
            if outcome == SeqOutcome::Restart {
                let ev = self.vehicles.on_sequence_restart(key);
                self.on_vehicle_events(ev, fx);
            }
            if outcome == SeqOutcome::Duplicate && repeat {
                continue; // the same frame again carries nothing new
            }
            let fallback;
            let msg = match &frame.message {
                Some(m) => m,
                None => match heartbeat_fallback(&frame) {
                    Some(m) => {
                        fallback = m;
                        &fallback
                    }
                    None => continue,
                },
            };
            match msg {
                MavMessage::HEARTBEAT(hb) => {
                    let ev = self
                        .vehicles
                        .on_heartbeat(link, key, hb, frame.version, now);
                    self.on_vehicle_events(ev, fx);
                }
                MavMessage::SYSTEM_TIME(st) => {
                    let ev = self.vehicles.on_system_time(key, st.time_boot_ms);
                    self.on_vehicle_events(ev, fx);
                }
                MavMessage::STATUSTEXT(st) => {
                    let end = st
                        .text
                        .iter()
                        .position(|&b| b == 0)
                        .unwrap_or(st.text.len());
                    let text = String::from_utf8_lossy(&st.text[..end]).into_owned();
                    self.notice(st.severity as u8, Some(key), text);
                }
                _ => {}
            }
        }
    }

    fn on_vehicle_events(&mut self, events: Vec<VehicleEvent>, fx: &mut Vec<Effect>) {
        for ev in events {
            match ev {
                VehicleEvent::Found(key) => {
                    let (desc, autopilot, link) = match self.vehicles.get(key) {
                        Some(v) => (
                            format!("{} {}", v.autopilot_name(), v.type_name()),
                            v.is_autopilot(),
                            v.links.iter().next().copied(),
                        ),
                        None => continue,
                    };
                    self.notice(
                        SEV_NOTICE,
                        Some(key),
                        format!("vehicle {}:{} found ({desc})", key.0, key.1),
                    );
                    if autopilot && self.target.is_none() {
                        self.target = Some(key);
                    }
                    if self.cfg.request_streams && autopilot && self.streams_requested.insert(key) {
                        if let Some(v) = self.vehicles.get(key) {
                            for msg in streams::initial_requests(v) {
                                fx.push(Effect::Send { link, msg });
                            }
                        }
                    }
                }
                VehicleEvent::Lost(key) => self.notice(
                    SEV_WARNING,
                    Some(key),
                    format!("vehicle {}:{} lost (no heartbeat)", key.0, key.1),
                ),
                VehicleEvent::Back(key) => self.notice(
                    SEV_NOTICE,
                    Some(key),
                    format!("vehicle {}:{} back", key.0, key.1),
                ),
                VehicleEvent::Rebooted(key, why) => {
                    self.notice(
                        SEV_WARNING,
                        Some(key),
                        format!("vehicle {}:{} rebooted ({why})", key.0, key.1),
                    );
                    // A rebooted autopilot forgets stream rates: ask again.
                    self.streams_requested.remove(&key);
                    if let Some(v) = self.vehicles.get(key) {
                        if self.cfg.request_streams && v.is_autopilot() {
                            let link = v.links.iter().next().copied();
                            self.streams_requested.insert(key);
                            for msg in streams::initial_requests(v) {
                                fx.push(Effect::Send { link, msg });
                            }
                        }
                    }
                }
                VehicleEvent::Conflict(key, detail) => {
                    self.notice(SEV_ERROR, Some(key), format!("sysid clash: {detail}"))
                }
                VehicleEvent::UsesGcsSysid(key) => self.notice(
                    SEV_ERROR,
                    Some(key),
                    format!(
                        "component {}:{} uses our GCS sysid {}",
                        key.0, key.1, self.cfg.sysid
                    ),
                ),
            }
        }
    }

    /// Vehicles that can be targeted, in registry order.
    pub fn targetable(&self) -> Vec<VehicleKey> {
        self.vehicles
            .iter()
            .filter(|v| v.is_autopilot())
            .map(|v| (v.sysid, v.compid))
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
    }

    /// Carry out a bound action.
    pub fn on_action(&mut self, action: Action, fx: &mut Vec<Effect>) {
        self.dirty = true;
        if self.ui.help && !matches!(action, Action::Quit) {
            // Any key closes help.
            self.ui.help = false;
            return;
        }
        let focus_idx = Pane::ALL
            .iter()
            .position(|p| *p == self.ui.focus)
            .unwrap_or(0);
        match action {
            Action::Quit => {
                self.quit = true;
                fx.push(Effect::Quit);
            }
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
            Action::ToggleExpand => {
                if self.ui.focus == Pane::Links {
                    if let Some(l) = self.links.get_mut(self.ui.link_sel) {
                        l.expanded = !l.expanded;
                    }
                } else if self.ui.focus == Pane::Vehicles {
                    let keys: Vec<VehicleKey> =
                        self.vehicles.iter().map(|v| (v.sysid, v.compid)).collect();
                    if let Some(k) = keys.get(self.ui.vehicle_sel) {
                        self.target = Some(*k);
                    }
                }
            }
            Action::NextVehicle => self.cycle_target(true),
            Action::PrevVehicle => self.cycle_target(false),
            Action::Help => self.ui.help = true,
            Action::Cancel => {}
            // Far enough to clamp at either end of any list.
            Action::Top => self.move_selection(-(1 << 30)),
            Action::Bottom => self.move_selection(1 << 30),
            _ => {} // prompt, screens and text-line actions: not wired up yet
        }
    }

    fn move_selection(&mut self, step: isize) {
        fn clamp(v: usize, step: isize, len: usize) -> usize {
            if len == 0 {
                return 0;
            }
            (v as isize + step).clamp(0, len as isize - 1) as usize
        }
        match self.ui.focus {
            Pane::Vehicles => {
                self.ui.vehicle_sel = clamp(self.ui.vehicle_sel, step, self.vehicles.len())
            }
            Pane::Links => self.ui.link_sel = clamp(self.ui.link_sel, step, self.links.len()),
            Pane::Messages => {
                // Up scrolls back in history.
                let max = self.notices.len().saturating_sub(1);
                self.ui.msg_scroll =
                    (self.ui.msg_scroll as isize - step).clamp(0, max as isize) as usize;
            }
        }
    }
}

/// A HEARTBEAT whose payload the dialect refused (an enum value newer than our dialect, from a
/// newer or third-party stack): read its nine bytes by hand, so the component is still listed.
/// Unknown type/autopilot/state become GENERIC/GENERIC/UNINIT.
fn heartbeat_fallback(frame: &Frame) -> Option<MavMessage> {
    use dialect::{MavAutopilot, MavModeFlag, MavState, MavType};
    use num_traits::FromPrimitive;
    if frame.msgid != 0 {
        return None;
    }
    let mut p = [0u8; 9];
    let payload = frame.payload();
    let n = payload.len().min(9);
    p[..n].copy_from_slice(&payload[..n]);
    Some(MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
        custom_mode: u32::from_le_bytes([p[0], p[1], p[2], p[3]]),
        mavtype: MavType::from_u8(p[4]).unwrap_or(MavType::MAV_TYPE_GENERIC),
        autopilot: MavAutopilot::from_u8(p[5]).unwrap_or(MavAutopilot::MAV_AUTOPILOT_GENERIC),
        base_mode: MavModeFlag::from_bits_truncate(p[6]),
        system_status: MavState::from_u8(p[7]).unwrap_or(MavState::MAV_STATE_UNINIT),
        mavlink_version: p[8],
    }))
}
