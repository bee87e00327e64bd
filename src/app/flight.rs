//! Flying the target vehicle: arm, disarm, take-off, land, RTL, mode changes, reboot and any
//! MAV_CMD, from keys, the prompt or the palette alike.
//!
//! Every action goes to a heard, not-lost autopilot through its session's command queue.
//! Dangerous ones ([`danger`]: one list for every entry point) first ask a question that names
//! the action and the vehicle (see `confirm`: what answers it, when it expires).
//!
//! A mode request, LAND or RTL supersedes a mode change still pending and abandons a take-off
//! in progress (see `Session::supersede_mode`).

pub use super::confirm::FlightAction;
use super::confirm::{Confirm, Confirmed};
use super::outcome::ActionKind;
use super::{App, Effect};
use crate::dialect::{MavAutopilot, MavCmd, MavMessage, MavModeFlag};
use crate::proto::commands::CommandSpec;
use crate::proto::modes;
use crate::proto::sequence::{Sequence, Step, Until};
use crate::proto::vehicles::VehicleKey;

/// `param2` of COMPONENT_ARM_DISARM that forces a disarm (ArduPilot and PX4).
pub const FORCE_DISARM: f64 = 21196.0;

/// What a command means when it needs a confirmation, whatever sends it (keys, the prompt, the
/// palette, the Commands screen's re-issue, the Mission, Parameters and Camera screens): `None`
/// when it goes without one. `flying`: the vehicle is armed and not on the ground.
pub fn danger(command: u16, params: &[f64; 7], flying: bool) -> Option<&'static str> {
    use num_traits::FromPrimitive;
    use MavCmd::*;
    Some(match MavCmd::from_u16(command)? {
        MAV_CMD_COMPONENT_ARM_DISARM if params[0] != 0.0 => "ARM",
        MAV_CMD_COMPONENT_ARM_DISARM if params[1] == FORCE_DISARM => {
            "FORCE-DISARM (motors stop, even in flight)"
        }
        MAV_CMD_COMPONENT_ARM_DISARM if flying => "DISARM while flying",
        MAV_CMD_NAV_TAKEOFF => "TAKE OFF",
        MAV_CMD_NAV_VTOL_TAKEOFF => "VTOL TAKE OFF",
        MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN => "REBOOT or SHUT DOWN",
        MAV_CMD_DO_MOTOR_TEST => "MOTOR TEST",
        MAV_CMD_DO_FLIGHTTERMINATION => "FLIGHT TERMINATION",
        MAV_CMD_PREFLIGHT_STORAGE => "PARAMETER STORAGE (param1 = 2 resets every parameter)",
        MAV_CMD_DO_PARACHUTE => "PARACHUTE",
        MAV_CMD_MISSION_START => "MISSION START",
        MAV_CMD_DO_SET_SERVO | MAV_CMD_DO_REPEAT_SERVO => "SERVO output",
        MAV_CMD_DO_AUX_FUNCTION => "AUX FUNCTION",
        MAV_CMD_DO_GRIPPER => "GRIPPER",
        MAV_CMD_DO_WINCH => "WINCH",
        MAV_CMD_DO_SET_HOME => "SET HOME",
        MAV_CMD_STORAGE_FORMAT => "FORMAT STORAGE",
        MAV_CMD_PREFLIGHT_CALIBRATION => "CALIBRATION",
        MAV_CMD_DO_START_MAG_CAL => "COMPASS CALIBRATION",
        _ => return None,
    })
}

/// The command a flight action sends first (a mode change: none that needs asking).
fn action_command(action: &FlightAction) -> Option<(u16, [f64; 7])> {
    let c = |c: MavCmd| c as u16;
    Some(match action {
        FlightAction::Arm => (
            c(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM),
            [1., 0., 0., 0., 0., 0., 0.],
        ),
        FlightAction::Disarm { force } => {
            let p2 = if *force { FORCE_DISARM } else { 0.0 };
            (
                c(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM),
                [0., p2, 0., 0., 0., 0., 0.],
            )
        }
        FlightAction::Takeoff(alt) => (
            c(MavCmd::MAV_CMD_NAV_TAKEOFF),
            [0., 0., 0., 0., 0., 0., *alt],
        ),
        FlightAction::Reboot => (
            c(MavCmd::MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN),
            [1., 0., 0., 0., 0., 0., 0.],
        ),
        FlightAction::Command { command, params } => (*command, *params),
        FlightAction::Land | FlightAction::Rtl | FlightAction::Mode(_) => return None,
    })
}

/// MAV_LANDED_STATE_ON_GROUND.
const LANDED_ON_GROUND: u8 = crate::dialect::MavLandedState::MAV_LANDED_STATE_ON_GROUND as u8;
/// Above this height over home an armed vehicle without EXTENDED_SYS_STATE counts as flying.
const FLYING_ABOVE_M: f64 = 1.0;

impl App {
    /// The target, if it can be commanded now.
    pub(super) fn commandable(&self) -> Result<VehicleKey, String> {
        let key = self.target.ok_or("no target vehicle: none heard yet")?;
        self.commandable_at(key)
    }

    /// `key`, if it can be commanded now: heard (compid 0, every component of the system: its
    /// autopilot heard) and not lost, with an autopilot of its system to route by.
    pub(super) fn commandable_at(&self, key: VehicleKey) -> Result<VehicleKey, String> {
        let session = self.session_for(key);
        let heard = match key.1 {
            0 => session.and_then(|s| self.vehicles.get(s)),
            _ => self.vehicles.get(key),
        };
        let v = heard.ok_or_else(|| format!("{key} has not been heard"))?;
        if v.lost {
            return Err(format!("{key} is lost: not sent"));
        }
        if session.is_none() {
            return Err(format!(
                "{key} is not an autopilot, and no autopilot of system {} is heard to reach it by",
                key.0
            ));
        }
        Ok(key)
    }

    /// The session commands to `key` go through: its own (an autopilot), else that of an
    /// autopilot of the same system (a camera or gimbal is reached through its vehicle).
    pub(super) fn session_for(&self, key: VehicleKey) -> Option<VehicleKey> {
        if self.sessions.contains_key(&key) {
            return Some(key);
        }
        self.sessions
            .range(VehicleKey(key.0, 0)..=VehicleKey(key.0, u8::MAX))
            .map(|(k, _)| *k)
            .next()
    }

    /// True when `key` (or its system's autopilot) is armed and not on the ground: by
    /// EXTENDED_SYS_STATE's `landed_state` while fresh (within STALE_AFTER), else by the height
    /// above home while fresh (an armed vehicle whose state and height are unknown or stale
    /// counts as flying). Not by `system_status`, which
    /// is CRITICAL during a failsafe.
    pub(super) fn airborne(&self, key: VehicleKey) -> bool {
        let via = self.session_for(key).unwrap_or(key);
        let Some(v) = self.vehicles.get(via) else {
            return false;
        };
        if !v.armed() {
            return false;
        }
        // Either only while fresh: a state or height heard long ago tells nothing now.
        let now = self.now;
        let flight = self.sessions.get(&via).map(|s| &s.flight);
        if let Some(l) = flight
            .and_then(|f| f.landed_state)
            .filter(|l| l.value != 0 && !l.is_stale(now))
        {
            return l.value != LANDED_ON_GROUND;
        }
        flight
            .and_then(|f| f.position.as_ref())
            .filter(|p| !p.is_stale(now))
            .is_none_or(|p| p.value.relative_alt_m() > FLYING_ABOVE_M)
    }

    /// `1:1 (ArduPilot Quadrotor)`: how a question names a vehicle.
    pub(super) fn who_is(&self, key: VehicleKey) -> String {
        match self.vehicles.get(key) {
            Some(v) => format!("{key} ({} {})", v.autopilot_name(), v.type_name()),
            None => key.to_string(),
        }
    }

    /// The confirmation question for `action` on `key`, if it needs one.
    fn question(&self, key: VehicleKey, action: &FlightAction) -> Option<String> {
        let (command, params) = action_command(action)?;
        // A jump in the mission the vehicle is flying asks, as `wp set N` does.
        let jump = command == MavCmd::MAV_CMD_DO_SET_MISSION_CURRENT as u16
            && self.flies_its_mission(self.session_for(key).unwrap_or(key));
        let what = match danger(command, &params, self.airborne(key)) {
            Some(what) => what,
            None if jump => "JUMP in the mission it is flying",
            None => return None,
        };
        let what = match action {
            FlightAction::Takeoff(alt) => format!("TAKE OFF to {alt} m"),
            FlightAction::Arm | FlightAction::Disarm { .. } | FlightAction::Reboot => what.into(),
            _ => format!(
                "{what}: send {} ({})",
                crate::proto::ack::command_name(command),
                params
                    .iter()
                    .map(|p| format!("{p}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        };
        Some(format!(
            "{what} {}? y = yes, any other key = no",
            self.who_is(key)
        ))
    }

    /// Ask for `action` on the target: carried out now, or after a confirmation.
    pub fn flight(
        &mut self,
        action: FlightAction,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let target = self.commandable()?;
        self.ask_or_carry_out(target, action, fx)
    }

    /// Ask for `action` on `target`, which need not be the app's target (the palette's
    /// `SYSID:COMPID`): the same checks and confirmation as [`App::flight`]. Only a
    /// [`FlightAction::Command`] may go to a component that is not an autopilot.
    pub fn flight_to(
        &mut self,
        target: VehicleKey,
        action: FlightAction,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let target = self.commandable_at(target)?;
        self.ask_or_carry_out(target, action, fx)
    }

    fn ask_or_carry_out(
        &mut self,
        target: VehicleKey,
        action: FlightAction,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let any = matches!(action, FlightAction::Command { .. });
        if !any && !self.sessions.contains_key(&target) {
            return Err(format!("{target} is not an autopilot"));
        }
        if let Some(text) = self.question(target, &action) {
            self.ask(Confirm::new(text, Confirmed::Flight(action), target));
            return Ok(None);
        }
        self.carry_out(target, action, fx)
    }

    /// Send what `action` means for this vehicle.
    pub(super) fn carry_out(
        &mut self,
        key: VehicleKey,
        action: FlightAction,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        // A component that is not an autopilot is reached through its system's autopilot.
        let via = self.session_for(key).ok_or("no session")?;
        let (autopilot, mavtype, mode, armed) = {
            let v = self.vehicles.get(via).ok_or("vehicle gone")?;
            (v.autopilot, v.mavtype, v.custom_mode, v.armed())
        };
        let profile = crate::proto::profile::of(autopilot);
        let long = |cmd: MavCmd, p: [f64; 7]| CommandSpec::long(key.into(), cmd, p);
        let nan = f64::NAN;
        let single = |spec: CommandSpec| -> Result<(CommandSpec, String), String> {
            let name = spec.name();
            Ok((spec, name))
        };
        // A mode request, LAND or RTL (from a key, the prompt, the palette, `long` or a re-issue):
        // whatever mode change, LAND, RTL or take-off is still running gives way to it at once.
        // The request is resolved first: one that will not be sent cancels nothing.
        let mode_step = match &action {
            FlightAction::Mode(name) => Some(self.mode_step(key, autopilot, mavtype, name)?),
            _ => None,
        };
        let by = match &action {
            FlightAction::Mode(m) => Some(format!("mode {m}")),
            FlightAction::Land => Some("LAND".into()),
            FlightAction::Rtl => Some("RTL".into()),
            FlightAction::Command { command, params } if is_mode_request(*command) => Some(
                CommandSpec {
                    target: key.into(),
                    command: *command,
                    params: *params,
                    form: crate::proto::commands::form_for(*command),
                }
                .name(),
            ),
            _ => None,
        };
        if let Some(by) = by {
            let now = self.now;
            if let Some(s) = self.sessions.get_mut(&via) {
                let out = s.supersede_mode(now, &by);
                self.session_out(via, out, fx);
            }
        }
        let (spec, label) = match action {
            FlightAction::Arm => single(long(
                MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                [1.0, 0., 0., 0., 0., 0., 0.],
            ))?,
            FlightAction::Disarm { force } => {
                let p2 = if force { FORCE_DISARM } else { 0.0 };
                single(long(
                    MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                    [0.0, p2, 0., 0., 0., 0., 0.],
                ))?
            }
            FlightAction::Land => single(long(
                MavCmd::MAV_CMD_NAV_LAND,
                [0., 0., 0., nan, nan, nan, 0.],
            ))?,
            FlightAction::Rtl => single(long(MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH, [0.; 7]))?,
            FlightAction::Reboot => single(long(
                MavCmd::MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN,
                [1.0, 0., 0., 0., 0., 0., 0.],
            ))?,
            FlightAction::Command { command, params } => single(CommandSpec {
                target: key.into(),
                command,
                params,
                form: crate::proto::commands::form_for(command),
            })?,
            FlightAction::Mode(name) => {
                let step = mode_step.ok_or("no mode step")?;
                let seq = Sequence::new(format!("mode {}", step.label), vec![step]);
                let text = format!("mode {name}: sent");
                return self.start(key, seq, &text, fx).map(|()| Some(text));
            }
            FlightAction::Takeoff(alt) => {
                let mut steps = Vec::new();
                // ArduPilot takes off only in GUIDED; PX4 switches to its take-off mode itself.
                if let Some(m) = profile.takeoff_mode() {
                    let number = modes::mode_number(autopilot, mavtype, m)
                        .ok_or_else(|| format!("this vehicle has no {m} mode"))?;
                    if mode != number {
                        steps.push(self.mode_step(key, autopilot, mavtype, m)?);
                    }
                }
                if !armed {
                    steps.push(Self::arm_step(key));
                }
                steps.push(self.takeoff_step(key, alt)?);
                let seq = Sequence::new(format!("takeoff {alt} m"), steps);
                let text = format!("takeoff to {alt} m: started");
                return self.start(key, seq, &text, fx).map(|()| Some(text));
            }
        };
        let now = self.now;
        let s = self.sessions.get_mut(&via).ok_or("no session")?;
        let (id, out) = s.submit(now, spec)?;
        let text = format!("{label}: sent");
        self.start_action(Some(via), vec![id], ActionKind::Command, text.clone());
        self.session_out(via, out, fx);
        Ok(Some(text))
    }

    /// Start `seq` on `key`; the status bar follows it from `text` on.
    fn start(
        &mut self,
        key: VehicleKey,
        seq: Sequence,
        text: &str,
        fx: &mut Vec<Effect>,
    ) -> Result<(), String> {
        let now = self.now;
        let s = self.sessions.get_mut(&key).ok_or("no session")?;
        let out = s.start_sequence(now, seq)?;
        // Its first step's command is in the queue now: the line follows it.
        self.start_action(
            Some(key),
            Vec::new(),
            ActionKind::Sequence(key),
            text.to_string(),
        );
        self.session_out(key, out, fx);
        Ok(())
    }

    /// COMPONENT_ARM_DISARM (arm), done when the heartbeat says armed.
    pub(super) fn arm_step(key: VehicleKey) -> Step {
        Step {
            spec: CommandSpec::long(
                key.into(),
                MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                [1.0, 0., 0., 0., 0., 0., 0.],
            ),
            until: Until::Armed,
            label: "arm".into(),
            fallback: None,
        }
    }

    /// NAV_TAKEOFF to `alt` metres above home (ArduPilot: param7 above home; PX4 and the spec:
    /// above mean sea level, from home's altitude), done when the vehicle is there
    /// ([`Until::Altitude`]: GLOBAL_POSITION_INT's height above home), staying in the profile's
    /// take-off mode (ArduPilot: GUIDED) where it has one.
    pub(super) fn takeoff_step(&self, key: VehicleKey, alt: f64) -> Result<Step, String> {
        let home = self.sessions.get(&key).and_then(|s| s.home_amsl());
        let profile = self.profile(key);
        let params = profile.takeoff_params(alt, home)?;
        let mode = match (profile.takeoff_mode(), self.vehicles.get(key)) {
            (Some(m), Some(v)) => modes::mode_number(v.autopilot, v.mavtype, m),
            _ => None,
        };
        Ok(Step {
            spec: CommandSpec::long(key.into(), MavCmd::MAV_CMD_NAV_TAKEOFF, params),
            until: Until::altitude(alt, mode),
            label: format!("take off to {alt} m"),
            fallback: None,
        })
    }

    /// DO_SET_MODE to mode `name` (SET_MODE if the vehicle says DO_SET_MODE is UNSUPPORTED),
    /// done when the heartbeat shows it.
    pub(super) fn mode_step(
        &self,
        key: VehicleKey,
        autopilot: MavAutopilot,
        mavtype: crate::dialect::MavType,
        name: &str,
    ) -> Result<Step, String> {
        let number = modes::mode_number(autopilot, mavtype, name).ok_or_else(|| {
            format!(
                "no mode `{name}` on this vehicle (modes: {})",
                modes::mode_names(autopilot, mavtype)
                    .join(" ")
                    .to_lowercase()
            )
        })?;
        // PX4: main mode in param2, sub mode in param3; others: the custom mode in param2.
        let params = crate::proto::profile::of(autopilot).set_mode_params(number);
        Ok(Step {
            spec: CommandSpec::long(key.into(), MavCmd::MAV_CMD_DO_SET_MODE, params),
            until: Until::Mode(number),
            label: name.to_ascii_uppercase(),
            fallback: Some(Self::set_mode_message(key, number)),
        })
    }

    #[allow(deprecated)] // superseded by DO_SET_MODE, which is why it is only the fallback
    /// SET_MODE, the older way, for a vehicle that refused DO_SET_MODE as UNSUPPORTED.
    pub fn set_mode_message(key: VehicleKey, custom_mode: u32) -> MavMessage {
        MavMessage::SET_MODE(crate::dialect::SET_MODE_DATA {
            custom_mode,
            target_system: key.0,
            base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
        })
    }

    /// The id of the Commands screen's row `i` (newest first) of the target.
    pub(super) fn command_id_at(&self, i: usize) -> Option<u64> {
        let s = self.target.and_then(|k| self.sessions.get(&k))?;
        s.commands.entries().rev().nth(i).map(|e| e.id)
    }

    /// Keep the Commands screen's cursor on the command it was put on (by id) as rows come;
    /// on that screen, the row under the cursor is pinned as soon as it is shown.
    pub(super) fn follow_selected_command(&mut self) {
        if self.ui.screen != "commands" {
            return;
        }
        let Some(s) = self.target.and_then(|k| self.sessions.get(&k)) else {
            return;
        };
        match self.ui.cmd_sel_id {
            Some(id) => match s.commands.entries().rev().position(|e| e.id == id) {
                Some(i) => self.ui.cmd_sel = i,
                None => self.ui.cmd_sel_id = self.command_id_at(self.ui.cmd_sel),
            },
            None => self.ui.cmd_sel_id = self.command_id_at(self.ui.cmd_sel),
        }
    }

    /// The Commands screen's selected entry of the target: the one under the cursor, by id.
    fn selected_command(&self) -> Result<(VehicleKey, crate::proto::commands::Entry), String> {
        let key = self.target.ok_or("no target vehicle")?;
        let s = self.sessions.get(&key).ok_or("no commands sent")?;
        let id = self
            .ui
            .cmd_sel_id
            .or_else(|| self.command_id_at(self.ui.cmd_sel))
            .ok_or("no command selected")?;
        let e = s.commands.get(id).ok_or("no command selected")?;
        Ok((key, e.clone()))
    }

    /// Send the selected command again, to that command's own target (a camera, a gimbal, the
    /// autopilot), as the operator's own decision (a missing ACK of a flight-critical command is
    /// never resent on its own): asks first if dangerous, like every other entry point.
    pub(super) fn reissue_selected(
        &mut self,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let (_, e) = self.selected_command()?;
        if e.open() {
            return Err(format!("{} is still {}", e.spec.name(), e.outcome()));
        }
        self.ui.cmd_sel = 0;
        self.ui.cmd_sel_id = None;
        self.flight_to(
            e.spec.target.into(),
            FlightAction::Command {
                command: e.spec.command,
                params: e.spec.params,
            },
            fx,
        )
    }

    /// Abort the selected command if it is in progress (COMMAND_CANCEL).
    pub(super) fn cancel_selected(
        &mut self,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let (key, e) = self.selected_command()?;
        let now = self.now;
        let s = self.sessions.get_mut(&key).ok_or("no session")?;
        let out = s.cancel(now, e.id)?;
        self.session_out(key, out, fx);
        Ok(Some(format!("{}: cancel sent", e.spec.name())))
    }
}

/// DO_SET_MODE, NAV_LAND, NAV_RETURN_TO_LAUNCH: a mode request, which never waits behind another.
pub fn is_mode_request(command: u16) -> bool {
    command == MavCmd::MAV_CMD_DO_SET_MODE as u16
        || command == MavCmd::MAV_CMD_NAV_LAND as u16
        || command == MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH as u16
}
