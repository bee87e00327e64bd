//! Questions: whatever needs the operator's yes before it leaves (flight actions, mission
//! uploads, clears, jumps and starts, parameter writes and file loads, signing setup and off, a
//! camera's storage format) is asked here, one question at a time, the others queued.
//!
//! Only `y`, or `enter` on a highlighted *Yes* (the highlight starts on *No*; left, right and tab
//! move it), answers a question, and only [`CONFIRM_GUARD`] after it appeared and after the key
//! before it (key repeats and keys typed ahead never do); `n`, esc, `enter` on *No* or any other
//! key cancels and nothing is sent. A question expires ([`CONFIRM_EXPIRY`], the vehicle lost, the
//! target or the vehicle's armed state, mode or mission changed); a queued one gets a fresh guard
//! when it comes on screen; the checks are made again before anything confirmed leaves.
//!
//! The actions a question lets go ahead ([`Confirmed`]) are defined here, so the modules that ask
//! (flight, mission, params, signing, camera) depend on this one and not on each other.

use super::{App, Effect};
use crate::clock::{Micros, SECOND};
use crate::dialect::MavAutopilot;
use crate::keymap::{Key, KeyCode};
use crate::link::LinkId;
use crate::mission::{MissionItem, MissionType};
use crate::proto::camera::CameraAction;
use crate::proto::vehicles::VehicleKey;
use crate::wire::Severity;

/// What the operator asked the target to do (carried out by `App::flight`, in `flight`).
#[derive(Debug, Clone, PartialEq)]
pub enum FlightAction {
    Arm,
    Disarm {
        force: bool,
    },
    /// Take off to this many metres above home.
    Takeoff(f64),
    Land,
    Rtl,
    Mode(String),
    Reboot,
    /// Any command (the palette's and `long`'s); the target is filled in when sent.
    Command {
        command: u16,
        params: [f64; 7],
    },
}

/// What a mission confirmation lets go ahead.
#[derive(Debug, Clone, PartialEq)]
pub enum MissionAction {
    Upload(MissionType, Vec<MissionItem>),
    Clear(MissionType),
    Start,
    /// `wp start` on a disarmed vehicle: the whole way there (the profile's
    /// `start_disarmed`: modes, arm, a take-off), one sequence.
    StartDisarmed,
    /// `wp set N` while the vehicle flies its mission.
    SetCurrent(u16),
}

/// What a confirmed `signing` command does, and on which link.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SigningAction {
    Setup { link: LinkId },
    Off { link: LinkId },
}

/// A key this soon after the question (or after the key before it) does not answer it: key
/// repeats and keys typed ahead never confirm.
pub const CONFIRM_GUARD: Micros = 300_000;
/// A question not answered in this long expires and sends nothing.
pub const CONFIRM_EXPIRY: Micros = 10 * SECOND;

/// A question waiting for `y`.
#[derive(Debug, Clone, PartialEq)]
pub struct Confirm {
    pub text: String,
    pub action: Confirmed,
    pub target: VehicleKey,
    /// When it was put on screen.
    pub asked: Micros,
    /// The last key that came while it was open (or the one that asked).
    pub last_key: Micros,
    /// The choice highlighted in the box: *Yes* (true) or *No* (false, where it starts);
    /// left/right/tab move it, `enter` takes it.
    pub yes: bool,
    /// What it was asked in: it expires when that changes.
    context: Context,
}

impl Confirm {
    /// A question about `action` on `target`; [`App::ask`] puts it on screen.
    pub fn new(text: String, action: Confirmed, target: VehicleKey) -> Self {
        Self {
            text,
            action,
            target,
            asked: 0,
            last_key: 0,
            yes: false,
            context: Context::default(),
        }
    }
}

/// A question as its asker words it: what, and to whom.
#[derive(Debug, Clone, PartialEq)]
pub struct Ask {
    pub text: String,
    pub action: Confirmed,
    pub target: VehicleKey,
}

impl From<Ask> for Confirm {
    fn from(a: Ask) -> Self {
        Confirm::new(a.text, a.action, a.target)
    }
}

/// The state a question was asked in: the app's target, and the vehicle's identity, armed state,
/// mode and mission.
#[derive(Debug, Clone, Default, PartialEq)]
struct Context {
    app_target: Option<VehicleKey>,
    identity: Option<(MavAutopilot, crate::dialect::MavType)>,
    armed: Option<bool>,
    mode: Option<u32>,
    mission: Option<MissionMark>,
}

/// The vehicle's plan id, and the mission we know it holds: (plan id, items, when learnt).
type MissionMark = (u32, Option<(u32, usize, Micros)>);

/// What a confirmation lets go ahead.
#[derive(Debug, Clone, PartialEq)]
pub enum Confirmed {
    Flight(FlightAction),
    /// Parameter writes: (component, name, value).
    Params(Vec<(u8, String, f64)>),
    /// `signing setup` or `signing off`.
    Signing(SigningAction),
    /// A camera action that destroys something (storage format): the camera's component id.
    Camera(u8, CameraAction),
    /// A mission upload with warnings, a clear, a mission start.
    Mission(MissionAction),
    /// Quitting while a vehicle is armed (the question names them; `target` is the first).
    Quit,
    /// LOG_ERASE: every onboard log of the target.
    LogErase {
        hl: bool,
    },
    /// A calibration of the target.
    Calibration(crate::proto::calibration::Kind),
}

/// A second Ctrl-C this soon after the quit question appeared quits without an answer.
pub const FORCE_QUIT_WITHIN: Micros = 2 * SECOND;

impl App {
    /// Put `c` on screen, or queue it behind the question already there (one at a time).
    pub(super) fn ask(&mut self, c: impl Into<Confirm>) {
        let mut c = c.into();
        if self.ui.confirm.is_some() {
            self.ui.confirm_queue.push_back(c);
            return;
        }
        c.asked = self.now;
        c.last_key = self.now;
        c.context = self.confirm_context(c.target);
        self.ui.confirm = Some(c);
        self.dirty = true;
    }

    /// Whether any autopilot says it is armed (lost ones included), without collecting them.
    pub fn any_armed(&self) -> bool {
        self.sessions
            .keys()
            .any(|k| self.vehicles.get(*k).is_some_and(|v| v.armed()))
    }

    /// The autopilots that say they are armed (lost ones included: one may still be flying),
    /// in key order.
    pub(super) fn armed_vehicles(&self) -> Vec<VehicleKey> {
        let mut keys: Vec<VehicleKey> = self
            .sessions
            .keys()
            .copied()
            .filter(|k| self.vehicles.get(*k).is_some_and(|v| v.armed()))
            .collect();
        keys.sort_unstable();
        keys
    }

    /// `q` and `:quit`: a nudge in progress ends in its stop first; then, while any vehicle is
    /// armed, a question naming them (`y` quits), else quit at once. `ctrl_c`: the question
    /// takes the screen from any other (which sends nothing), and a second Ctrl-C within
    /// [`FORCE_QUIT_WITHIN`] of it quits without an answer.
    pub(super) fn quit_or_ask(&mut self, ctrl_c: bool, fx: &mut Vec<Effect>) {
        self.leave_fly(fx);
        let on_screen = self.ui.confirm.as_ref();
        let asked_quit = on_screen
            .filter(|c| c.action == Confirmed::Quit)
            .map(|c| c.asked);
        if ctrl_c && asked_quit.is_some_and(|at| self.now < at + FORCE_QUIT_WITHIN) {
            self.quit_now(fx);
            return;
        }
        let armed = self.armed_vehicles();
        let Some(first) = armed.first().copied() else {
            self.quit_now(fx);
            return;
        };
        if ctrl_c && on_screen.is_some() && asked_quit.is_none() {
            // The operator wants out: the question on screen goes, nothing sent.
            self.ui.confirm = None;
        }
        if asked_quit.is_some() {
            return;
        }
        let names: Vec<String> = armed.iter().map(|k| format!("{}:{}", k.0, k.1)).collect();
        let (list, verb) = match names.split_last() {
            Some((last, [])) => (last.clone(), "is"),
            Some((last, rest)) => (format!("{} and {last}", rest.join(", ")), "are"),
            None => return self.quit_now(fx),
        };
        self.ask(Ask {
            text: format!(
                "quit while {list} {verb} armed? y/n (ctrl-c twice or :quit! quits at once)"
            ),
            action: Confirmed::Quit,
            target: first,
        });
    }

    /// Quit now: a nudge in progress ends in its stop first.
    pub(super) fn quit_now(&mut self, fx: &mut Vec<Effect>) {
        self.leave_fly(fx);
        self.end_log_transfers(fx);
        self.ui.confirm = None;
        self.quit = true;
        fx.push(Effect::Quit);
    }

    /// The next queued question, once the one on screen is gone.
    fn next_question(&mut self) {
        if self.ui.confirm.is_none() {
            if let Some(c) = self.ui.confirm_queue.pop_front() {
                self.ask(c);
            }
        }
    }

    fn confirm_context(&self, target: VehicleKey) -> Context {
        let via = self.session_for(target);
        let v = via.and_then(|k| self.vehicles.get(k));
        let mission = via.and_then(|k| self.sessions.get(&k)).map(|s| {
            let t = crate::mission::MissionType::Mission;
            let known = s
                .mission
                .known(t)
                .map(|k| (k.opaque_id, k.items.len(), k.at));
            (s.mission.vehicle_id(t), known)
        });
        Context {
            app_target: self.target,
            identity: v.map(|v| (v.autopilot, v.mavtype)),
            armed: v.map(|v| v.armed()),
            mode: v.map(|v| v.custom_mode),
            mission,
        }
    }

    /// Why the question on screen no longer holds, if it does not.
    fn expired(&self, c: &Confirm) -> Option<String> {
        if self.now >= c.asked + CONFIRM_EXPIRY {
            return Some("not answered in 10 s".into());
        }
        // Quitting concerns mavterm, not the vehicle: only time ends the question.
        if c.action == Confirmed::Quit {
            return None;
        }
        if self.target != c.context.app_target {
            return Some("the target changed".into());
        }
        if let Err(e) = self.commandable_at(c.target) {
            return Some(e);
        }
        let now = self.confirm_context(c.target);
        if now.identity != c.context.identity {
            return Some("another vehicle answers at that id".into());
        }
        if now.armed != c.context.armed {
            return Some("the vehicle was armed or disarmed meanwhile".into());
        }
        if now.mode != c.context.mode {
            return Some("the vehicle's mode changed meanwhile".into());
        }
        if now.mission != c.context.mission {
            return Some("the mission on the vehicle changed meanwhile".into());
        }
        None
    }

    /// A question that no longer holds goes, saying so; nothing is sent.
    pub(super) fn poll_confirm(&mut self) {
        let Some(why) = self.ui.confirm.as_ref().and_then(|c| self.expired(c)) else {
            return;
        };
        let c = self.ui.confirm.take();
        let target = c.map(|c| c.target);
        let text = format!("question expired ({why}): nothing sent");
        self.notice(Severity::WARNING, target, text.clone());
        self.ui.message = Some((Severity::WARNING, text));
        self.next_question();
    }

    /// When the question on screen expires on its own.
    pub(super) fn confirm_deadline(&self) -> Option<Micros> {
        self.ui.confirm.as_ref().map(|c| c.asked + CONFIRM_EXPIRY)
    }

    /// A key while a confirmation is asked: only `y`, or `enter` on a highlighted *Yes*, goes
    /// ahead, and only pressed at least [`CONFIRM_GUARD`] after the question appeared and after
    /// the key before it (a key repeat — `repeat`, or a key that comes in a repeat's rhythm —
    /// and a key typed ahead are ignored, but `n` and esc always cancel). Left, right, tab and
    /// backtab move the highlight between *No* (where it starts) and *Yes* and send nothing;
    /// `enter` on *No* and any other key cancel. The checks are made again before anything
    /// leaves.
    pub(super) fn on_confirm_key(&mut self, key: Key, repeat: bool, fx: &mut Vec<Effect>) {
        let now = self.now;
        let Some(c) = self.ui.confirm.as_mut() else {
            return;
        };
        let early = repeat || now < c.asked + CONFIRM_GUARD || now < c.last_key + CONFIRM_GUARD;
        c.last_key = now;
        let plain = !key.ctrl && !key.alt;
        // Moving the highlight sends nothing, early or not; it is a key like any other for the
        // guard, so an `enter` hard on its heels does not answer.
        if plain
            && matches!(
                key.code,
                KeyCode::Left | KeyCode::Right | KeyCode::Tab | KeyCode::BackTab
            )
        {
            c.yes = !c.yes;
            return;
        }
        // `n` and esc say no at once: a no never sends anything.
        let no = key == Key::ch('n') || key == Key::ch('N') || key.code == KeyCode::Esc;
        if early && !no {
            self.ui.message = Some((
                Severity::WARNING,
                "a key held or typed ahead does not answer: let go, then y or n".into(),
            ));
            return;
        }
        let Some(c) = self.ui.confirm.take() else {
            return;
        };
        let yes = key == Key::ch('y')
            || key == Key::ch('Y')
            || (plain && key.code == KeyCode::Enter && c.yes);
        if yes {
            let outcome = match self.expired(&c) {
                Some(why) => Err(format!("question expired ({why}): nothing sent")),
                None => match c.action {
                    Confirmed::Flight(a) => self.carry_out(c.target, a, fx),
                    Confirmed::Params(p) => self.write_params(c.target, p, fx),
                    Confirmed::Signing(a) => self.carry_out_signing(c.target, a, fx),
                    Confirmed::Mission(a) => self.carry_out_mission(c.target, a, fx),
                    Confirmed::Camera(compid, a) => self.camera_act(c.target, compid, a, fx),
                    Confirmed::LogErase { hl } => self.carry_out_log_erase(c.target, hl, fx),
                    Confirmed::Calibration(k) => self.carry_out_cal(c.target, k, fx),
                    Confirmed::Quit => {
                        self.quit_now(fx);
                        Ok(None)
                    }
                },
            };
            self.ui.message = match outcome {
                Ok(Some(t)) => Some((Severity::INFO, t)),
                Ok(None) => None,
                Err(e) => Some((Severity::ERROR, e)),
            };
        } else {
            self.ui.message = Some((Severity::WARNING, "cancelled: nothing sent".into()));
        }
        self.next_question();
    }
}

#[cfg(test)]
mod tests {
    use super::super::{AppConfig, Event};
    use super::*;
    use crate::dialect::{self, MavMessage};
    use crate::link::{Frame, ParserStats};
    use crate::wire::frame::{decode_one, encode, Header, Version};

    const S: Micros = SECOND;

    /// ArduCopter 1:1's HEARTBEAT, disarmed or armed, in STABILIZE.
    fn heartbeat(armed: bool) -> Frame {
        let msg = MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
            mavtype: dialect::MavType::MAV_TYPE_QUADROTOR,
            autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode: dialect::MavModeFlag::from_bits_truncate(if armed { 129 } else { 1 }),
            system_status: dialect::MavState::MAV_STATE_STANDBY,
            mavlink_version: 3,
            custom_mode: 0,
        });
        let h = Header {
            sysid: 1,
            compid: 1,
            seq: 0,
        };
        decode_one(&encode(Version::V2, h, &msg)).unwrap()
    }

    fn hear(app: &mut App, now: Micros, armed: bool) -> Vec<Effect> {
        app.update(
            now,
            Event::Frames {
                link: 0,
                frames: vec![heartbeat(armed)],
                stats: ParserStats::default(),
            },
        )
    }

    /// An app that has heard 1:1 (disarmed) at 0 and asks to arm it at `at`.
    /// What the status bar says.
    fn said(app: &App) -> String {
        app.ui
            .message
            .as_ref()
            .map(|m| m.1.clone())
            .unwrap_or_default()
    }

    fn asked_to_arm(at: Micros) -> App {
        let mut app = App::new(AppConfig {
            links: vec!["x".into()],
            request_streams: false,
            fetch_params: false,
            ..AppConfig::default()
        });
        hear(&mut app, 0, false);
        app.update(at, Event::Tick);
        let mut fx = Vec::new();
        assert_eq!(app.flight(FlightAction::Arm, &mut fx), Ok(None));
        assert!(fx.is_empty(), "nothing leaves before the answer");
        assert!(app.ui.confirm.is_some());
        app
    }

    /// The ARM commands (COMMAND_LONG ARM_DISARM, param1 = 1) among `fx`.
    fn arms(fx: &[Effect]) -> usize {
        fx.iter()
            .filter(|e| {
                matches!(e, Effect::Send { msg: MavMessage::COMMAND_LONG(c), .. }
                    if c.command == dialect::MavCmd::MAV_CMD_COMPONENT_ARM_DISARM
                        && c.param1 == 1.0)
            })
            .count()
    }

    fn key(app: &mut App, now: Micros, k: Key) -> Vec<Effect> {
        app.update(now, Event::Key(k))
    }

    #[test]
    fn only_y_after_the_guard_confirms() {
        let mut app = asked_to_arm(S);
        // Too soon after the question: ignored, the question stays.
        assert_eq!(arms(&key(&mut app, S + 100_000, Key::ch('y'))), 0);
        assert!(app.ui.confirm.is_some());
        // Too soon after that key, although long after the question.
        assert_eq!(arms(&key(&mut app, S + 350_000, Key::ch('y'))), 0);
        assert!(app.ui.confirm.is_some());
        assert_eq!(arms(&key(&mut app, S + 700_000, Key::ch('y'))), 1);
        assert!(app.ui.confirm.is_none());
        // A key repeat never answers.
        let mut app = asked_to_arm(S);
        let fx = app.update(2 * S, Event::KeyRepeat(Key::ch('y')));
        assert_eq!((arms(&fx), app.ui.confirm.is_some()), (0, true));
    }

    #[test]
    fn enter_takes_the_highlight_which_starts_on_no() {
        let enter = Key {
            code: KeyCode::Enter,
            ..Key::ch('x')
        };
        let tab = Key {
            code: KeyCode::Tab,
            ..Key::ch('x')
        };
        let mut app = asked_to_arm(S);
        assert_eq!(arms(&key(&mut app, 2 * S, enter)), 0);
        assert!(app.ui.confirm.is_none(), "enter on No cancels");
        let mut app = asked_to_arm(S);
        key(&mut app, 2 * S, tab);
        assert!(app.ui.confirm.as_ref().is_some_and(|c| c.yes));
        // Hard on the heels of the tab: not an answer.
        assert_eq!(arms(&key(&mut app, 2 * S + 100_000, enter)), 0);
        assert_eq!(arms(&key(&mut app, 3 * S, enter)), 1);
    }

    #[test]
    fn n_and_other_keys_cancel_at_once() {
        for k in [Key::ch('n'), Key::ch('q')] {
            let mut app = asked_to_arm(S);
            // `n` even inside the guard; any other key once past it.
            let at = if k == Key::ch('n') { S + 1 } else { 2 * S };
            assert_eq!(arms(&key(&mut app, at, k)), 0);
            assert!(app.ui.confirm.is_none());
            assert_eq!(arms(&key(&mut app, 3 * S, Key::ch('y'))), 0);
        }
    }

    #[test]
    fn a_question_expires_after_10_s_and_when_the_vehicle_is_armed_meanwhile() {
        let mut app = asked_to_arm(S);
        // Heard meanwhile: it is the time that ends the question, not the vehicle's loss.
        for t in 1..=5 {
            hear(&mut app, 2 * t * S, false);
        }
        app.update(S + CONFIRM_EXPIRY, Event::Tick);
        assert!(app.ui.confirm.is_none());
        let said = said(&app);
        assert!(said.contains("not answered in 10 s"), "{said}");

        let mut app = asked_to_arm(S);
        hear(&mut app, 2 * S, true);
        assert_eq!(arms(&key(&mut app, 3 * S, Key::ch('y'))), 0);
        assert!(app.ui.confirm.is_none());
    }

    #[test]
    fn one_question_at_a_time_and_the_next_gets_a_fresh_guard() {
        let mut app = asked_to_arm(S);
        let mut fx = Vec::new();
        app.flight(FlightAction::Arm, &mut fx).unwrap();
        assert_eq!(app.ui.confirm_queue.len(), 1);
        assert_eq!(arms(&key(&mut app, 3 * S, Key::ch('y'))), 1);
        // The queued question is on screen now, asked at 3 s: a `y` right after is too soon.
        assert_eq!(app.ui.confirm.as_ref().map(|c| c.asked), Some(3 * S));
        assert_eq!(arms(&key(&mut app, 3 * S + 100_000, Key::ch('y'))), 0);
        assert!(app.ui.confirm.is_some());
    }

    #[test]
    fn a_question_expires_when_its_vehicle_is_lost_or_the_target_changes() {
        let mut app = asked_to_arm(S);
        let lost = app.cfg.lost_timeout + S;
        assert_eq!(arms(&key(&mut app, lost, Key::ch('y'))), 0);
        assert!(app.ui.confirm.is_none());
        let said = said(&app);
        assert!(said.contains("lost"), "{said}");

        let mut app = asked_to_arm(S);
        app.target = None;
        assert_eq!(arms(&key(&mut app, 2 * S, Key::ch('y'))), 0);
        assert!(app.ui.confirm.is_none());
    }
}
