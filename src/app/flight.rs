//! Flying the target vehicle: arm, disarm, take-off, land, RTL, mode changes, reboot and any
//! MAV_CMD, from keys, the prompt or the palette alike.
//!
//! Every action goes to a heard, not-lost autopilot through its session's command queue.
//! Dangerous ones (arm, take-off, force-disarm, disarm while flying, reboot, motor test, flight
//! termination) first ask a confirmation that names the action and the vehicle: `y`, or the same
//! key again, goes ahead; any other key cancels and nothing is sent.

use super::notices::{SEV_INFO, SEV_WARNING};
use super::{App, Effect};
use crate::dialect::{MavAutopilot, MavCmd, MavMessage, MavModeFlag, MavState};
use crate::keymap::Key;
use crate::proto::commands::CommandSpec;
use crate::proto::modes;
use crate::proto::sequence::{Sequence, Step, Until};
use crate::proto::vehicles::VehicleKey;

/// `param2` of COMPONENT_ARM_DISARM that forces a disarm (ArduPilot and PX4).
pub const FORCE_DISARM: f64 = 21196.0;

/// What the operator asked the target to do.
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

/// A question waiting for `y`.
#[derive(Debug, Clone, PartialEq)]
pub struct Confirm {
    pub text: String,
    pub action: Confirmed,
    pub target: VehicleKey,
    /// The key that asked: pressing it again confirms too.
    pub key: Option<Key>,
}

/// What a confirmation lets go ahead.
#[derive(Debug, Clone, PartialEq)]
pub enum Confirmed {
    Flight(FlightAction),
    /// Parameter writes: (component, name, value).
    Params(Vec<(u8, String, f64)>),
    /// `signing setup` or `signing off`.
    Signing(super::signing::SigningAction),
    /// A camera action that destroys something (storage format): the camera's component id.
    Camera(u8, crate::proto::camera::CameraAction),
    /// A mission upload with warnings, a clear, a mission start.
    Mission(super::mission::MissionAction),
}

/// Commands that need a confirmation whatever sends them.
fn dangerous_command(command: u16) -> bool {
    use num_traits::FromPrimitive;
    matches!(
        MavCmd::from_u16(command),
        Some(
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM
                | MavCmd::MAV_CMD_NAV_TAKEOFF
                | MavCmd::MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN
                | MavCmd::MAV_CMD_DO_MOTOR_TEST
                | MavCmd::MAV_CMD_DO_FLIGHTTERMINATION
        )
    )
}

impl App {
    /// The target, if it can be commanded now.
    pub(super) fn commandable(&self) -> Result<VehicleKey, String> {
        let key = self.target.ok_or("no target vehicle: none heard yet")?;
        self.commandable_at(key)
    }

    /// `key`, if it can be commanded now: heard (compid 0, every component of the system: its
    /// autopilot heard) and not lost, with an autopilot of its system to route by.
    fn commandable_at(&self, key: VehicleKey) -> Result<VehicleKey, String> {
        let session = self.session_for(key);
        let heard = match key.1 {
            0 => session.and_then(|s| self.vehicles.get(s)),
            _ => self.vehicles.get(key),
        };
        let v = heard.ok_or_else(|| format!("{}:{} has not been heard", key.0, key.1))?;
        if v.lost {
            return Err(format!("{}:{} is lost: not sent", key.0, key.1));
        }
        if session.is_none() {
            return Err(format!(
                "{}:{} is not an autopilot, and no autopilot of system {} is heard to reach it by",
                key.0, key.1, key.0
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
            .range((key.0, 0)..=(key.0, u8::MAX))
            .map(|(k, _)| *k)
            .next()
    }

    /// True when the target is flying (armed and not on the ground), as far as we can tell.
    fn airborne(&self, key: VehicleKey) -> bool {
        self.vehicles
            .get(key)
            .is_some_and(|v| v.armed() && v.system_status == MavState::MAV_STATE_ACTIVE)
    }

    /// The confirmation question for `action` on `key`, if it needs one.
    fn question(&self, key: VehicleKey, action: &FlightAction) -> Option<String> {
        let who = match self.vehicles.get(key) {
            Some(v) => format!(
                "{}:{} ({} {})",
                key.0,
                key.1,
                v.autopilot_name(),
                v.type_name()
            ),
            None => format!("{}:{}", key.0, key.1),
        };
        let what = match action {
            FlightAction::Arm => "ARM".to_string(),
            FlightAction::Takeoff(alt) => format!("TAKE OFF to {alt} m"),
            FlightAction::Disarm { force: true } => {
                "FORCE-DISARM (motors stop, even in flight)".into()
            }
            FlightAction::Disarm { force: false } if self.airborne(key) => {
                "DISARM while flying".into()
            }
            FlightAction::Reboot => "REBOOT".into(),
            FlightAction::Command { command, params } if dangerous_command(*command) => {
                format!(
                    "send {} ({})",
                    crate::proto::ack::command_name(*command),
                    params
                        .iter()
                        .map(|p| format!("{p}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            }
            _ => return None,
        };
        Some(format!("{what} {who}? y = yes, any other key = no"))
    }

    /// Ask for `action` on the target: carried out now, or after a confirmation.
    pub fn flight(
        &mut self,
        action: FlightAction,
        key: Option<Key>,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let target = self.commandable()?;
        self.ask_or_carry_out(target, action, key, fx)
    }

    /// Ask for `action` on `target`, which need not be the app's target (the palette's
    /// `SYSID:COMPID`): the same checks and confirmation as [`App::flight`]. Only a
    /// [`FlightAction::Command`] may go to a component that is not an autopilot.
    pub fn flight_to(
        &mut self,
        target: VehicleKey,
        action: FlightAction,
        key: Option<Key>,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let target = self.commandable_at(target)?;
        self.ask_or_carry_out(target, action, key, fx)
    }

    fn ask_or_carry_out(
        &mut self,
        target: VehicleKey,
        action: FlightAction,
        key: Option<Key>,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let any = matches!(action, FlightAction::Command { .. });
        if !any && !self.sessions.contains_key(&target) {
            return Err(format!("{}:{} is not an autopilot", target.0, target.1));
        }
        if let Some(text) = self.question(target, &action) {
            self.ui.confirm = Some(Confirm {
                text,
                action: Confirmed::Flight(action),
                target,
                key,
            });
            return Ok(None);
        }
        self.carry_out(target, action, fx)
    }

    /// A key while a confirmation is asked: `y` or the same key again goes ahead.
    pub(super) fn on_confirm_key(&mut self, key: Key, fx: &mut Vec<Effect>) {
        let Some(c) = self.ui.confirm.take() else {
            return;
        };
        if key == Key::ch('y') || key == Key::ch('Y') || Some(key) == c.key {
            let outcome = match c.action {
                Confirmed::Flight(a) => self.carry_out(c.target, a, fx),
                Confirmed::Params(p) => self.write_params(c.target, p, fx),
                Confirmed::Signing(a) => self.carry_out_signing(c.target, a, fx),
                Confirmed::Mission(a) => self.carry_out_mission(c.target, a, fx),
                Confirmed::Camera(compid, a) => self.camera_act(c.target, compid, a, fx),
            };
            self.ui.message = match outcome {
                Ok(Some(t)) => Some((SEV_INFO, t)),
                Ok(None) => None,
                Err(e) => Some((super::notices::SEV_ERROR, e)),
            };
        } else {
            self.ui.message = Some((SEV_WARNING, "cancelled: nothing sent".into()));
        }
    }

    /// Send what `action` means for this vehicle.
    fn carry_out(
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
        let long = |cmd: MavCmd, p: [f64; 7]| CommandSpec::long(key, cmd, p);
        let nan = f64::NAN;
        let single = |spec: CommandSpec| -> Result<(CommandSpec, String), String> {
            let name = spec.name();
            Ok((spec, name))
        };
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
                target: key,
                command,
                params,
                form: crate::proto::commands::form_for(command),
            })?,
            FlightAction::Mode(name) => {
                let step = self.mode_step(key, autopilot, mavtype, &name)?;
                let seq = Sequence::new(format!("mode {}", step.label), vec![step]);
                return self
                    .start(key, seq, fx)
                    .map(|()| Some(format!("mode {name}: sent")));
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
                    steps.push(Step {
                        spec: long(
                            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                            [1.0, 0., 0., 0., 0., 0., 0.],
                        ),
                        until: Until::Armed,
                        label: "arm".into(),
                        fallback: None,
                    });
                }
                // ArduPilot: param7 above home; PX4 and the spec: above mean sea level.
                let home = self.sessions.get(&key).and_then(|s| s.home_amsl());
                let params = profile.takeoff_params(alt, home)?;
                steps.push(Step {
                    spec: long(MavCmd::MAV_CMD_NAV_TAKEOFF, params),
                    until: Until::Ack,
                    label: format!("take off to {alt} m"),
                    fallback: None,
                });
                let seq = Sequence::new(format!("takeoff {alt} m"), steps);
                return self
                    .start(key, seq, fx)
                    .map(|()| Some(format!("takeoff to {alt} m: started")));
            }
        };
        let now = self.now;
        let s = self.sessions.get_mut(&via).ok_or("no session")?;
        let (_, out) = s.submit(now, spec)?;
        self.session_out(via, out, fx);
        Ok(Some(format!("{label}: sent")))
    }

    fn start(
        &mut self,
        key: VehicleKey,
        seq: Sequence,
        fx: &mut Vec<Effect>,
    ) -> Result<(), String> {
        let now = self.now;
        let s = self.sessions.get_mut(&key).ok_or("no session")?;
        let out = s.start_sequence(now, seq)?;
        self.session_out(key, out, fx);
        Ok(())
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
            spec: CommandSpec::long(key, MavCmd::MAV_CMD_DO_SET_MODE, params),
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

    /// The Commands screen's selected entry (newest first) of the target.
    fn selected_command(&self) -> Result<(VehicleKey, crate::proto::commands::Entry), String> {
        let key = self.target.ok_or("no target vehicle")?;
        let s = self.sessions.get(&key).ok_or("no commands sent")?;
        let e = s
            .commands
            .entries()
            .rev()
            .nth(self.ui.cmd_sel)
            .ok_or("no command selected")?;
        Ok((key, e.clone()))
    }

    /// Send the selected command again, as the operator's own decision (a missing ACK of a
    /// flight-critical command is never resent on its own): asks first if dangerous.
    pub(super) fn reissue_selected(
        &mut self,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let (_, e) = self.selected_command()?;
        if e.open() {
            return Err(format!("{} is still {}", e.spec.name(), e.outcome()));
        }
        self.ui.cmd_sel = 0;
        self.flight(
            FlightAction::Command {
                command: e.spec.command,
                params: e.spec.params,
            },
            None,
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
