//! Missions, geofence and rally points at the prompt and on the Mission screen, and guided
//! go-to / altitude commands.
//!
//! `wp`/`fence`/`rally` `load FILE` read a QGC WPL 110 file or a QGroundControl `.plan` (by
//! extension, else by content: a `{` first) through [`Effect::ReadFile`]; `save FILE` writes the
//! vehicle's list (else the loaded file's) atomically through [`Effect::WriteFile`]; `upload`
//! sends the loaded file's list — refused while the file has errors, asked first when
//! [`upload_warnings`] finds something (altitudes in mixed frames, AMSL below home); `download`,
//! `clear` (asked first), `set N` and `start` (asked first: mode AUTO, then MISSION_START) work
//! on the vehicle. `start` on a disarmed vehicle names what it takes (the profile's
//! `start_disarmed`: ArduCopter GUIDED, arm, take off to the first item's altitude, AUTO,
//! MISSION_START) and asks for it all at once; with no mission known it is refused. A `.plan`
//! fills all three lists.
//!
//! `goto LAT LON [ALT]` sends DO_REPOSITION as COMMAND_INT (frame GLOBAL_RELATIVE_ALT, lat/lon
//! ×1e7, altitude above home; speed -1 = default; yaw NaN = keep), through the command queue so
//! its ACK is shown; `alt N` is the same at the vehicle's current position. Both need the
//! target armed and, on ArduPilot, in GUIDED (the flag that lets DO_REPOSITION change the mode
//! is not set: the operator chooses GUIDED); PX4 switches to its hold mode on a reposition by
//! itself, so there the flag is set and only armed is needed.

use std::path::PathBuf;

pub use super::confirm::MissionAction;
use super::confirm::{Ask, Confirmed, FlightAction};
use super::files::FileUse;
use super::{App, Effect};
use crate::dialect::{MavAutopilot, MavCmd};
use crate::mission::{self, plan, upload_warnings, wpl, MissionItem, MissionType};
use crate::proto::commands::CommandSpec;
use crate::proto::mission::Request;
use crate::proto::sequence::{Sequence, Step, Until};
use crate::proto::vehicles::VehicleKey;
use crate::wire::Severity;

/// What a `wp`/`fence`/`rally` command asks.
#[derive(Debug, Clone, PartialEq)]
pub enum MissionOp {
    Load(String),
    Save(String),
    Upload,
    Download,
    Clear,
    SetCurrent(u16),
    Start,
}

/// A mission command at the prompt.
#[derive(Debug, Clone, PartialEq)]
pub enum MissionCmd {
    List(MissionType, MissionOp),
    /// Fly to (lat, lon) degrees, at this altitude above home (else the current one).
    Goto(f64, f64, Option<f64>),
    /// Climb or descend to this altitude above home where the vehicle is.
    Alt(f64),
}

/// A list read from a file.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadedList {
    pub path: String,
    /// As in the file (the mission with home as item 0).
    pub items: Vec<MissionItem>,
    /// What was wrong in the file (line or JSON path first); a list with errors is not uploaded.
    pub errors: Vec<String>,
}

/// Which list the Mission screen shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Shown {
    /// The vehicle's, as last downloaded or uploaded.
    #[default]
    Vehicle,
    /// The loaded file's.
    File,
}

/// The Mission screen's state.
#[derive(Debug, Clone, Default)]
pub struct MissionView {
    /// 0 mission, 1 fence, 2 rally ([`MissionType::index`]).
    pub list: usize,
    pub sel: usize,
    pub shown: Shown,
    /// Per list, the file last loaded.
    pub files: [Option<LoadedList>; 3],
}

impl MissionView {
    pub fn mission_type(&self) -> MissionType {
        MissionType::ALL[self.list.min(2)]
    }
}

/// Usage of the list commands.
pub fn usage(word: &str) -> String {
    format!(
        "usage: {word} load FILE | save FILE | upload | download | clear{}",
        if word == "wp" { " | set N | start" } else { "" }
    )
}

/// Parse the words after `wp`, `fence` or `rally`.
pub fn parse(word: &str, rest: &str) -> Result<MissionCmd, String> {
    let t = match word {
        "fence" => MissionType::Fence,
        "rally" => MissionType::Rally,
        _ => MissionType::Mission,
    };
    let (sub, arg) = rest.split_once(' ').unwrap_or((rest, ""));
    let arg = arg.trim();
    let none = |op: MissionOp| {
        if arg.is_empty() {
            Ok(MissionCmd::List(t, op))
        } else {
            Err(usage(word))
        }
    };
    let file = |f: fn(String) -> MissionOp| {
        if arg.is_empty() {
            Err(usage(word))
        } else {
            Ok(MissionCmd::List(t, f(arg.to_string())))
        }
    };
    match sub {
        "load" => file(MissionOp::Load),
        "save" => file(MissionOp::Save),
        "upload" => none(MissionOp::Upload),
        "download" => none(MissionOp::Download),
        "clear" => none(MissionOp::Clear),
        "set" if t == MissionType::Mission => arg
            .parse::<u16>()
            .map(|n| MissionCmd::List(t, MissionOp::SetCurrent(n)))
            .map_err(|_| "usage: wp set N (the item to fly next)".to_string()),
        "start" if t == MissionType::Mission => none(MissionOp::Start),
        _ => Err(usage(word)),
    }
}

/// Parse `goto LAT LON [ALT]`.
pub fn parse_goto(rest: &str) -> Result<MissionCmd, String> {
    let usage = || "usage: goto LAT LON [ALT] (degrees; metres above home)".to_string();
    let w: Vec<&str> = rest.split_whitespace().collect();
    if !(2..=3).contains(&w.len()) {
        return Err(usage());
    }
    let num = |s: &str| s.parse::<f64>().ok().filter(|v| v.is_finite());
    let lat = num(w[0]).filter(|v| v.abs() <= 90.0).ok_or_else(usage)?;
    let lon = num(w[1]).filter(|v| v.abs() <= 180.0).ok_or_else(usage)?;
    let alt = match w.get(2) {
        Some(a) => Some(num(a).ok_or_else(usage)?),
        None => None,
    };
    Ok(MissionCmd::Goto(lat, lon, alt))
}

/// Parse `alt N`.
pub fn parse_alt(rest: &str) -> Result<MissionCmd, String> {
    rest.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite() && (-1000.0..=10_000.0).contains(v))
        .map(MissionCmd::Alt)
        .ok_or_else(|| "usage: alt METRES (above home)".into())
}

/// Read a mission file's text: a `.plan` (by extension, or JSON content) gives all three lists,
/// anything else is WPL for list `t`.
pub fn read_file(path: &str, text: &str, t: MissionType) -> Vec<(MissionType, LoadedList)> {
    let is_plan =
        path.to_ascii_lowercase().ends_with(".plan") || text.trim_start().starts_with('{');
    if is_plan {
        let f = plan::parse(text);
        let errors: Vec<String> = f.errors.iter().map(|e| e.to_string()).collect();
        MissionType::ALL
            .iter()
            .map(|&lt| {
                (
                    lt,
                    LoadedList {
                        path: path.to_string(),
                        items: f.plan.list(lt).to_vec(),
                        errors: errors.clone(),
                    },
                )
            })
            .collect()
    } else {
        let f = wpl::parse(text, t);
        vec![(
            t,
            LoadedList {
                path: path.to_string(),
                items: f.items,
                errors: f.errors.iter().map(|e| e.to_string()).collect(),
            },
        )]
    }
}

impl App {
    fn mission_target(&self) -> Result<VehicleKey, String> {
        let key = self.commandable()?;
        if !self.sessions.contains_key(&key) {
            return Err(format!("{key} is not an autopilot"));
        }
        Ok(key)
    }

    /// Armed in its family's mission mode (ArduPilot AUTO, PX4 MISSION): flying its mission. A
    /// family with no known mission mode counts as flying it whenever it is armed (asking is safer).
    pub(super) fn flies_its_mission(&self, key: VehicleKey) -> bool {
        let profile = self.profile(key);
        self.vehicles.get(key).is_some_and(|v| {
            v.armed()
                && profile.mission_mode().is_none_or(|m| {
                    crate::proto::modes::mode_name(v.autopilot, v.mavtype, v.custom_mode)
                        .eq_ignore_ascii_case(m)
                })
        })
    }

    /// The profile of `key`'s autopilot (generic MAVLink when the vehicle is not known).
    pub fn profile(&self, key: VehicleKey) -> &'static dyn crate::proto::profile::Profile {
        crate::proto::profile::of(
            self.vehicles
                .get(key)
                .map_or(MavAutopilot::MAV_AUTOPILOT_GENERIC, |v| v.autopilot),
        )
    }

    /// The items of list `t` as this vehicle takes them from a file's list (home first): only
    /// ArduPilot holds a home item (its profile says).
    pub fn items_for_vehicle(
        &self,
        key: VehicleKey,
        t: MissionType,
        items: &[MissionItem],
    ) -> Vec<MissionItem> {
        if t == MissionType::Mission && !self.profile(key).mission_home_item() && !items.is_empty()
        {
            mission::without_home(items)
        } else {
            items.to_vec()
        }
    }

    /// The vehicle's sequence number of mission row `seq` as shown: a file's rows count home as
    /// 0, and so does a vehicle whose profile holds home (ArduPilot); another vehicle's items
    /// are one lower (QGroundControl's `setCurrentMissionSequence` does the same).
    pub fn vehicle_seq(&self, seq: u16) -> Result<u16, String> {
        let home_held = self
            .target
            .is_some_and(|k| self.profile(k).mission_home_item());
        if self.ui.mission.shown == Shown::Vehicle || home_held {
            return Ok(seq);
        }
        seq.checked_sub(1)
            .ok_or_else(|| "home is not a mission item on this vehicle".to_string())
    }

    /// True when the loaded file of list `t` is what the vehicle was last given by us.
    pub fn file_uploaded(&self, t: MissionType) -> bool {
        let (Some(key), Some(f)) = (self.target, self.ui.mission.files[t.index()].as_ref()) else {
            return false;
        };
        let want = self.items_for_vehicle(key, t, &f.items);
        self.sessions
            .get(&key)
            .and_then(|s| s.mission.known(t))
            .is_some_and(|k| !k.downloaded && k.items == want)
    }

    pub(super) fn run_mission(
        &mut self,
        cmd: MissionCmd,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        match cmd {
            MissionCmd::List(t, op) => self.run_list(t, op, fx),
            MissionCmd::Goto(lat, lon, alt) => self.goto(lat, lon, alt, fx),
            MissionCmd::Alt(alt) => {
                let key = self.mission_target()?;
                let p = self.sessions[&key]
                    .flight
                    .position
                    .as_ref()
                    .map(|p| p.value)
                    .filter(|p| p.is_known())
                    .ok_or("position not known yet: no GLOBAL_POSITION_INT")?;
                self.goto(p.lat(), p.lon(), Some(alt), fx)
            }
        }
    }

    fn run_list(
        &mut self,
        t: MissionType,
        op: MissionOp,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let name = t.name();
        match op {
            MissionOp::Load(path) => Ok(Some(self.read_file(
                PathBuf::from(&path),
                FileUse::Mission(t),
                fx,
            ))),
            MissionOp::Save(path) => self.save_list(t, &path, fx),
            MissionOp::Download => {
                let key = self.mission_target()?;
                let text = format!("downloading the {name} of {key}");
                self.mission_action(key, Request::Download(t), &text, fx)?;
                self.ui.mission.list = t.index();
                self.ui.mission.shown = Shown::Vehicle;
                Ok(Some(text))
            }
            MissionOp::Upload => {
                let key = self.mission_target()?;
                let f = self.ui.mission.files[t.index()]
                    .as_ref()
                    .ok_or_else(|| format!("no {name} file loaded ({} load FILE)", word(t)))?;
                if !f.errors.is_empty() {
                    return Err(format!(
                        "{} has {} error(s), not uploaded: {}",
                        f.path,
                        f.errors.len(),
                        f.errors[0]
                    ));
                }
                // Files hold the mission with home as item 0, whatever the autopilot.
                let home = self.sessions[&key].home_amsl();
                let warnings = upload_warnings(&f.items, home, t == MissionType::Mission);
                let items = self.items_for_vehicle(key, t, &f.items);
                let path = f.path.clone();
                let armed = self.vehicles.get(key).is_some_and(|v| v.armed());
                if !warnings.is_empty() || armed {
                    let replaced = match self.sessions[&key].mission.known(t) {
                        Some(k) => format!("the {} {name} items on it", k.items.len()),
                        None => format!("its {name}"),
                    };
                    let mut why = warnings.clone();
                    if armed {
                        why.insert(0, format!("it is ARMED; this replaces {replaced}"));
                    }
                    self.ask(Ask {
                        text: format!(
                            "UPLOAD {} {name} items of {path} to {}: {}. Upload anyway? y = yes, any other key = no",
                            items.len(),
                            self.who_is(key),
                            why.join("; ")
                        ),
                        action: Confirmed::Mission(MissionAction::Upload(t, items)),
                        target: key,
                    });
                    return Ok(None);
                }
                self.carry_out_mission(key, MissionAction::Upload(t, items), fx)
            }
            MissionOp::Clear => {
                let key = self.mission_target()?;
                self.ask(Ask {
                    text: format!("CLEAR the {name} of {key}? y = yes, any other key = no"),
                    action: Confirmed::Mission(MissionAction::Clear(t)),
                    target: key,
                });
                Ok(None)
            }
            MissionOp::SetCurrent(seq) => {
                let key = self.mission_target()?;
                if self.flies_its_mission(key) {
                    self.ask(Ask {
                        text: format!(
                            "JUMP to mission item {seq} on {}, which is flying its mission (the \
                             item it flies now is replaced)? y = yes, any other key = no",
                            self.who_is(key)
                        ),
                        action: Confirmed::Mission(MissionAction::SetCurrent(seq)),
                        target: key,
                    });
                    return Ok(None);
                }
                self.carry_out_mission(key, MissionAction::SetCurrent(seq), fx)
            }
            MissionOp::Start => {
                let key = self.mission_target()?;
                if !self.vehicles.get(key).is_some_and(|v| v.armed()) {
                    // What it takes, asked as one action.
                    let (_, labels) = self.start_disarmed_steps(key)?;
                    self.ask(Ask {
                        text: format!(
                            "{}:{} is disarmed: {}? y/n",
                            key.0,
                            key.1,
                            labels.join(", ")
                        ),
                        action: Confirmed::Mission(MissionAction::StartDisarmed),
                        target: key,
                    });
                    return Ok(None);
                }
                self.ask(Ask {
                    text: format!(
                        "START the mission on {key} ({}MISSION_START)? y = yes, any other key = no",
                        self.profile(key)
                            .mission_mode()
                            .map_or(String::new(), |m| format!("mode {m}, then "))
                    ),
                    action: Confirmed::Mission(MissionAction::Start),
                    target: key,
                });
                Ok(None)
            }
        }
    }

    /// The items of the mission the vehicle holds (home, ArduPilot's item 0, left out):
    /// refused, saying why, when none is known or it is empty.
    fn held_mission(&self, key: VehicleKey) -> Result<Vec<&MissionItem>, String> {
        let who = format!("{}:{}", key.0, key.1);
        let s = self.sessions.get(&key).ok_or("no session")?;
        let known = s.mission.known(MissionType::Mission).ok_or_else(|| {
            format!(
                "no mission known on {who}: download it (wp download), or load and upload one \
                 (wp load FILE, wp upload), first"
            )
        })?;
        let home_item = self.profile(key).mission_home_item();
        let items: Vec<&MissionItem> = known
            .items
            .iter()
            .filter(|i| !(home_item && i.seq == 0))
            .collect();
        if items.is_empty() {
            return Err(format!(
                "{who} has no mission: load and upload one first (wp load FILE, wp upload)"
            ));
        }
        Ok(items)
    }

    /// The altitude (metres above home) of the mission's first navigation item: what a
    /// take-off before the mission climbs to.
    fn first_item_alt(&self, key: VehicleKey, items: &[&MissionItem]) -> Result<f64, String> {
        let who = format!("{}:{}", key.0, key.1);
        // MAV_CMD_NAV_*: 16 ..= 95 (common.xml's NAV_LAST).
        let nav = items
            .iter()
            .find(|i| (16..=95).contains(&i.command))
            .ok_or_else(|| format!("{who}'s mission has no navigation item to take off to"))?;
        let z = nav.z as f64;
        // MAV_FRAME_GLOBAL (0) and GLOBAL_INT (5) are above mean sea level; the others above
        // home (relative, terrain).
        let alt = if matches!(nav.frame, 0 | 5) {
            let home = self
                .sessions
                .get(&key)
                .and_then(|s| s.home_amsl())
                .ok_or("home altitude not known yet: wait for GLOBAL_POSITION_INT")?;
            z - home
        } else {
            z
        };
        if !alt.is_finite() || alt <= 0.0 {
            return Err(format!(
                "{who}'s first mission item is at {alt:.1} m above home: nothing to take off to"
            ));
        }
        // Whole decimetres are enough, and read well in the question.
        Ok((alt * 10.0).round() / 10.0)
    }

    /// The steps that start the mission on the disarmed `key` (its profile's
    /// `start_disarmed`; a mode it is already in is skipped), and their names for the question.
    fn start_disarmed_steps(&self, key: VehicleKey) -> Result<(Vec<Step>, Vec<String>), String> {
        use crate::proto::profile::StartStep;
        let (autopilot, mavtype, mut mode) = {
            let v = self.vehicles.get(key).ok_or("vehicle gone")?;
            (v.autopilot, v.mavtype, v.custom_mode)
        };
        // Nothing to start without a mission, whatever the family.
        let items = self.held_mission(key)?;
        let mut steps = Vec::new();
        let mut labels = Vec::new();
        for step in self.profile(key).start_disarmed(mavtype) {
            match *step {
                StartStep::Mode(m) => {
                    let number = crate::proto::modes::mode_number(autopilot, mavtype, m)
                        .ok_or_else(|| format!("this vehicle has no {m} mode"))?;
                    if number == mode {
                        continue;
                    }
                    mode = number;
                    steps.push(self.mode_step(key, autopilot, mavtype, m)?);
                    labels.push(m.to_ascii_uppercase());
                }
                StartStep::Arm => {
                    steps.push(Self::arm_step(key));
                    labels.push("arm".into());
                }
                StartStep::Takeoff => {
                    let alt = self.first_item_alt(key, &items)?;
                    steps.push(self.takeoff_step(key, alt)?);
                    labels.push(format!("take off to {alt} m"));
                }
                StartStep::MissionStart => {
                    steps.push(Self::mission_start_step(key));
                    labels.push("start mission".into());
                }
            }
        }
        Ok((steps, labels))
    }

    /// MAV_CMD_MISSION_START, done at its ACK.
    fn mission_start_step(key: VehicleKey) -> Step {
        Step {
            spec: CommandSpec::long(key.into(), MavCmd::MAV_CMD_MISSION_START, [0.0; 7]),
            until: Until::Ack,
            label: "mission start".into(),
            fallback: None,
        }
    }

    /// A transfer the operator asked for: its line follows it to its end (with its figure: the
    /// items downloaded), or to why it stopped.
    fn mission_action(
        &mut self,
        key: VehicleKey,
        req: Request,
        text: &str,
        fx: &mut Vec<Effect>,
    ) -> Result<(), String> {
        let ask = crate::proto::mission::MissionAsk::Transfer(req.kind(), req.mission_type());
        let kind = super::outcome::ActionKind::Mission { key, ask };
        // Set first: the transfer's end may come with its first answer.
        let before = self.ui.action.clone();
        self.start_action(Some(key), Vec::new(), kind, text.to_string());
        if let Err(e) = self.mission_request(key, req, fx) {
            self.ui.action = before;
            return Err(e);
        }
        Ok(())
    }

    fn mission_request(
        &mut self,
        key: VehicleKey,
        req: Request,
        fx: &mut Vec<Effect>,
    ) -> Result<(), String> {
        let now = self.now;
        let out = self
            .sessions
            .get_mut(&key)
            .ok_or("no session")?
            .mission_submit(now, req)?;
        self.session_out(key, out, fx);
        Ok(())
    }

    /// What a mission confirmation let go ahead.
    pub(super) fn carry_out_mission(
        &mut self,
        key: VehicleKey,
        action: MissionAction,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        match action {
            MissionAction::Upload(t, items) => {
                let n = items.len();
                let text = format!("uploading {n} {} items to {key}", t.name());
                let kind = super::outcome::ActionKind::MissionUpload {
                    key,
                    t,
                    count: n,
                    at: self.now,
                };
                // Set first: the transfer's end may come with its first answer.
                self.start_action(Some(key), Vec::new(), kind, text.clone());
                if let Err(e) = self.mission_request(key, Request::Upload(t, items), fx) {
                    self.ui.action = None;
                    return Err(e);
                }
                self.ui.mission.list = t.index();
                Ok(Some(text))
            }
            MissionAction::SetCurrent(seq) => {
                let now = self.now;
                let out = self
                    .sessions
                    .get_mut(&key)
                    .ok_or("no session")?
                    .mission_set_current(now, seq)?;
                let text = format!("current item {seq}: sent");
                let ask = crate::proto::mission::MissionAsk::SetCurrent(seq);
                let kind = super::outcome::ActionKind::Mission { key, ask };
                self.start_action(Some(key), Vec::new(), kind, text.clone());
                self.session_out(key, out, fx);
                Ok(Some(text))
            }
            MissionAction::Clear(t) => {
                let text = format!("clearing the {} of {key}", t.name());
                self.mission_action(key, Request::Clear(t), &text, fx)?;
                Ok(Some(text))
            }
            MissionAction::Start => {
                let (autopilot, mavtype) = {
                    let v = self.vehicles.get(key).ok_or("vehicle gone")?;
                    (v.autopilot, v.mavtype)
                };
                // ArduPilot flies it in AUTO, PX4 in MISSION; others need only MISSION_START.
                let mut steps = Vec::new();
                if let Some(auto) = crate::proto::profile::of(autopilot).mission_mode() {
                    steps.push(self.mode_step(key, autopilot, mavtype, auto)?);
                }
                steps.push(Self::mission_start_step(key));
                let text = "mission start: sent".to_string();
                self.start_mission_sequence(key, steps, &text, fx)?;
                Ok(Some(text))
            }
            MissionAction::StartDisarmed => {
                let (steps, labels) = self.start_disarmed_steps(key)?;
                let text = format!("mission start: {}: started", labels.join(", "));
                self.start_mission_sequence(key, steps, &text, fx)?;
                Ok(Some(text))
            }
        }
    }

    /// Start the mission's sequence on `key`; the status bar follows it from `text` on.
    fn start_mission_sequence(
        &mut self,
        key: VehicleKey,
        steps: Vec<Step>,
        text: &str,
        fx: &mut Vec<Effect>,
    ) -> Result<(), String> {
        let now = self.now;
        let s = self.sessions.get_mut(&key).ok_or("no session")?;
        let out = s.start_sequence(now, Sequence::new("mission start", steps))?;
        let kind = super::outcome::ActionKind::Sequence(key);
        self.start_action(Some(key), Vec::new(), kind, text.to_string());
        self.session_out(key, out, fx);
        Ok(())
    }

    fn save_list(
        &mut self,
        t: MissionType,
        path: &str,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let key = self.target;
        let session = key.and_then(|k| self.sessions.get(&k));
        // The vehicle's lists as a file holds them (the mission with home first).
        let vehicle_list = |lt: MissionType| -> Option<Vec<MissionItem>> {
            let k = session?.mission.known(lt)?;
            let items = k.items.clone();
            if lt == MissionType::Mission
                && key.is_some_and(|k| !self.profile(k).mission_home_item())
            {
                let home = self.home_item(key?);
                Some(mission::with_home(home, &items))
            } else {
                Some(items)
            }
        };
        let file_list = |lt: MissionType| {
            self.ui.mission.files[lt.index()]
                .as_ref()
                .map(|f| f.items.clone())
        };
        let list = |lt: MissionType| vehicle_list(lt).or_else(|| file_list(lt));
        let (text, what) = if path.to_ascii_lowercase().ends_with(".plan") {
            let (fw, vt) = match key.and_then(|k| self.vehicles.get(k)) {
                Some(v) => (v.autopilot as u64, Some(v.mavtype as u64)),
                // No vehicle known: nothing says whose the plan is (QGroundControl's generic
                // firmware type), rather than claiming ArduPilot.
                None => (MavAutopilot::MAV_AUTOPILOT_GENERIC as u64, None),
            };
            let p = plan::Plan::new(
                list(MissionType::Mission).unwrap_or_default(),
                list(MissionType::Fence).unwrap_or_default(),
                list(MissionType::Rally).unwrap_or_default(),
                fw,
                vt,
            );
            (
                p.to_json()?,
                "the mission, fence and rally points".to_string(),
            )
        } else {
            let items = list(t).ok_or_else(|| {
                format!(
                    "no {} to save: download it ({} download) or load a file",
                    t.name(),
                    word(t)
                )
            })?;
            let n = items.len();
            (
                wpl::write(&items, &Default::default()),
                format!("{n} {} items", t.name()),
            )
        };
        fx.push(Effect::WriteFile {
            path: PathBuf::from(path),
            contents: text.into_bytes(),
        });
        let text = format!("saving {what} to {path}");
        let kind = super::outcome::ActionKind::Save {
            path: PathBuf::from(path),
            what,
        };
        self.start_action(None, Vec::new(), kind, text.clone());
        Ok(Some(text))
    }

    /// Home as a mission item 0 (for a PX4 mission saved to a file).
    fn home_item(&self, key: VehicleKey) -> MissionItem {
        let mut h = MissionItem::new(
            MissionType::Mission,
            0,
            0,
            MavCmd::MAV_CMD_NAV_WAYPOINT as u16,
        );
        if let Some(home) = self.sessions.get(&key).and_then(|s| s.flight.home.as_ref()) {
            h.x = home.value.lat_e7;
            h.y = home.value.lon_e7;
            h.z = home.value.alt_mm as f32 / 1000.0;
        }
        h
    }

    /// A mission file came (or did not).
    pub(super) fn on_mission_file(
        &mut self,
        path: PathBuf,
        t: MissionType,
        result: Result<Vec<u8>, String>,
    ) {
        let Some((shown, text)) = self.file_text(&path, result) else {
            return;
        };
        let lists = read_file(&shown, &text, t);
        let errors = lists.first().map_or(0, |(_, l)| l.errors.len());
        let first_error = lists
            .first()
            .and_then(|(_, l)| l.errors.first().cloned())
            .unwrap_or_default();
        let counts: Vec<String> = lists
            .iter()
            .map(|(lt, l)| format!("{} {}", l.items.len(), lt.name()))
            .collect();
        for (lt, l) in lists {
            self.ui.mission.files[lt.index()] = Some(l);
        }
        self.ui.mission.list = t.index();
        self.ui.mission.shown = Shown::File;
        self.ui.mission.sel = 0;
        // The action's line: the figure, or the first error and where it is, first (the path
        // is what an 80-column bar cuts).
        let (sev, text, line) = if errors > 0 {
            (
                Severity::ERROR,
                format!("{shown}: {errors} error(s), it will not be uploaded: {first_error}"),
                format!("{first_error} in {shown} ({errors} error(s): not uploaded)"),
            )
        } else {
            (
                Severity::INFO,
                format!("loaded {shown}: {} items (not uploaded)", counts.join(", ")),
                format!("{} items loaded from {shown}", counts.join(", ")),
            )
        };
        self.read_outcome(&path, sev, line);
        self.notice(sev, None, text);
    }

    /// DO_REPOSITION to (lat, lon) at `alt` metres above home (else the current altitude).
    pub(super) fn goto(
        &mut self,
        lat: f64,
        lon: f64,
        alt: Option<f64>,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let key = self.mission_target()?;
        let profile = self.profile(key);
        self.guided_check(key, profile.guided_mode().is_some(), "goto")?;
        let alt = match alt {
            Some(a) => a,
            None => self.sessions[&key]
                .flight
                .position
                .as_ref()
                .map(|p| p.value.relative_alt_m())
                .ok_or("altitude not known yet: give one (goto LAT LON ALT)")?,
        };
        // MAV_DO_REPOSITION_FLAGS_CHANGE_MODE only where the autopilot needs it to act (PX4).
        let flags = if profile.reposition_changes_mode() {
            1.0
        } else {
            0.0
        };
        let params = [-1.0, flags, 0.0, f64::NAN, lat, lon, alt];
        self.flight(
            FlightAction::Command {
                command: MavCmd::MAV_CMD_DO_REPOSITION as u16,
                params,
            },
            fx,
        )
        .map(|_| Some(format!("goto {lat:.7} {lon:.7} at {alt:.1} m: sent")))
    }

    /// Refuse unless `key` is armed and (when `guided`) in GUIDED.
    pub(super) fn guided_check(
        &self,
        key: VehicleKey,
        guided: bool,
        what: &str,
    ) -> Result<(), String> {
        let v = self.vehicles.get(key).ok_or("vehicle gone")?;
        if !v.armed() {
            return Err(format!("{what} refused: {key} is not armed"));
        }
        if guided {
            let Some(m) = v.profile().guided_mode() else {
                return Err(format!(
                    "{what} refused: {} has no guided mode mavterm knows",
                    v.profile().name()
                ));
            };
            let g = crate::proto::modes::mode_number(v.autopilot, v.mavtype, m);
            if g != Some(v.custom_mode) {
                return Err(format!(
                    "{what} refused: {key} is in {}, not {m} (mode {})",
                    crate::proto::modes::mode_name(v.autopilot, v.mavtype, v.custom_mode),
                    m.to_ascii_lowercase()
                ));
            }
        }
        Ok(())
    }

    /// The rows the Mission screen shows: the file's or the vehicle's list.
    pub fn mission_rows(&self) -> Vec<MissionItem> {
        let t = self.ui.mission.mission_type();
        match self.ui.mission.shown {
            Shown::File => self.ui.mission.files[t.index()]
                .as_ref()
                .map(|f| f.items.clone())
                .unwrap_or_default(),
            Shown::Vehicle => self
                .target
                .and_then(|k| self.sessions.get(&k))
                .and_then(|s| s.mission.known(t))
                .map(|k| k.items.clone())
                .unwrap_or_default(),
        }
    }

    /// Keys of the Mission screen.
    pub(super) fn on_mission_action(
        &mut self,
        action: crate::keymap::Action,
        fx: &mut Vec<Effect>,
    ) {
        use crate::keymap::Action::*;
        let t = self.ui.mission.mission_type();
        let sel = self.mission_rows().get(self.ui.mission.sel).copied();
        let outcome = match action {
            MissionList => {
                self.ui.mission.list = (self.ui.mission.list + 1) % 3;
                self.ui.mission.sel = 0;
                Ok(None)
            }
            MissionSource => {
                self.ui.mission.shown = match self.ui.mission.shown {
                    Shown::Vehicle => Shown::File,
                    Shown::File => Shown::Vehicle,
                };
                self.ui.mission.sel = 0;
                Ok(None)
            }
            MissionDownload => self.run_list(t, MissionOp::Download, fx),
            MissionUpload => self.run_list(t, MissionOp::Upload, fx),
            MissionStart => self.run_list(MissionType::Mission, MissionOp::Start, fx),
            MissionSetCurrent => match sel {
                Some(i) if t == MissionType::Mission => match self.vehicle_seq(i.seq) {
                    Ok(seq) => self.run_list(t, MissionOp::SetCurrent(seq), fx),
                    Err(e) => Err(e),
                },
                _ => Err("select a mission item first".into()),
            },
            MissionGoto => match sel {
                Some(i) if mission::command_has_position(i.command) && (i.x != 0 || i.y != 0) => {
                    let alt = match i.alt_ref() {
                        mission::AltRef::Rel => Some(i.z as f64),
                        _ => None,
                    };
                    self.goto(i.param5(), i.param6(), alt, fx)
                }
                _ => Err("select an item with a position first".into()),
            },
            _ => Ok(None),
        };
        self.ui.message = match outcome {
            Ok(Some(t)) => Some((Severity::INFO, t)),
            Ok(None) => None,
            Err(e) => Some((Severity::ERROR, e)),
        };
    }
}

/// The prompt word of list `t`.
pub fn word(t: MissionType) -> &'static str {
    match t {
        MissionType::Mission => "wp",
        MissionType::Fence => "fence",
        MissionType::Rally => "rally",
    }
}
