//! Fly mode: velocity nudges of a GUIDED vehicle from the keyboard, sans-I/O.
//!
//! Fly mode is entered by a key (`fly`, `F` by default) and shown in the status bar; scrolling
//! keys never fly the vehicle outside it. While a direction key is held, SET_POSITION_TARGET_
//! LOCAL_NED in MAV_FRAME_BODY_OFFSET_NED with only the velocity and the yaw rate used
//! ([`TYPE_MASK`]) goes out at [`RATE_HZ`]; what is sent is the sum of the keys held (forward
//! and right at once fly diagonally), armed and GUIDED checked before every send. A nudge
//! always ends in a stop (a zero velocity in the same frame and mask, sent [`STOP_SENDS`] times
//! [`PERIOD`] apart: it is never acknowledged): at once on a reported key release (terminals
//! with the keyboard enhancement protocol), else when no key of a direction has come for its
//! deadman ([`FIRST_REPEAT_WAIT`] until the key repeats, then `nudge_deadman`, [`DEADMAN`] by
//! default), and whenever Fly mode is left (esc, quit, the front end ending, the vehicle lost or
//! out of GUIDED or disarmed, the target changed, another screen or the prompt opened). Nothing
//! else is sent on its own.
//!
//! Keys in Fly mode: arrows forward/back/left/right, `w`/`s` up/down, `a`/`d` yaw left/right,
//! `1`/`2`/`3` speed 1, 2, 5 m/s, `r`/`f` altitude +/- [`ALT_STEP`] m (a DO_REPOSITION where
//! the vehicle is), `esc` leaves.

use crate::clock::Micros;
use crate::dialect::{
    MavFrame, MavMessage, PositionTargetTypemask, SET_POSITION_TARGET_LOCAL_NED_DATA,
};
use crate::keymap::{Key, KeyCode};
use crate::proto::vehicles::VehicleKey;

use super::session::SessionOut;
use super::{App, Effect};
use crate::wire::Severity;

/// Velocity targets per second while a key is held.
pub const RATE_HZ: u64 = 10;
/// Between two velocity targets.
pub const PERIOD: Micros = 1_000_000 / RATE_HZ;
/// Default deadman once a key repeats: the longest gap between two repeats of a held key in the
/// documented defaults ([`REPEAT_DEFAULTS`]) is the Linux console's 92 ms (10.9 per second),
/// so 0.3 s is three repeats missed or bunched by an SSH link, and the shortest that is not
/// fooled by them. `nudge_deadman` sets it.
pub const DEADMAN: Micros = 300_000;
/// Before a key's first repeat: the longest first delay among the documented defaults
/// ([`REPEAT_DEFAULTS`]) is X11's 660 ms, so a first press lasts this long at least.
pub const FIRST_REPEAT_WAIT: Micros = 700_000;
/// The documented key-repeat defaults (first delay, then the gap between repeats, in µs) that
/// [`DEADMAN`] and [`FIRST_REPEAT_WAIT`] are chosen to survive; a terminal passes on the
/// repeats of the system it runs on.
/// - X11 (Xorg's XKB): 660 ms, then every 40 ms (25 Hz): the server's `XkbDfltRepeatDelay` and
///   `XkbDfltRepeatInterval` (xserver `xkb/xkbAccessX.c`), what `xset r rate` with no values
///   puts back (xset(1)).
/// - Linux console: 250 ms, then 10.9 per second (92 ms), "the IBM defaults" kbdrate(8) resets.
/// - Windows (conhost and Windows Terminal get the system's repeats): `KeyboardDelay` 1 of 0–3
///   (0 ≈ 250 ms … 3 ≈ 1 s, so ≈ 500 ms, ±20 %: up to 600 ms) and `KeyboardSpeed` 31 (≈ 30 per
///   second, 33 ms): the defaults in the registry reference for `HKCU\Control Panel\Keyboard`
///   (SystemParametersInfo SPI_GETKEYBOARDDELAY / SPI_GETKEYBOARDSPEED give the same scales).
/// - macOS: `InitialKeyRepeat` / `KeyRepeat` count 15 ms units (15 = 225 ms and 2 = 30 ms are
///   the shortest its settings offer). Apple documents no default; the figures published are
///   25 (375 ms) and 2 (30 ms), or 68 (1020 ms) and 6 (90 ms). The first is survived; with the
///   second a held key's nudge stops once at 0.7 s and goes on at its first repeat (1.02 s).
pub const REPEAT_DEFAULTS: [(&str, Micros, Micros); 6] = [
    ("X11 (Xorg XKB)", 660_000, 40_000),
    ("Linux console (kbdrate)", 250_000, 91_743),
    (
        "Windows (KeyboardDelay 1, KeyboardSpeed 31)",
        500_000,
        33_333,
    ),
    ("Windows, delay 20 % long", 600_000, 33_333),
    ("macOS (InitialKeyRepeat 25, KeyRepeat 2)", 375_000, 30_000),
    ("macOS (KeyRepeat 6)", 375_000, 90_000),
];
/// A stop (zero velocity, never acknowledged) is sent this many times, [`PERIOD`] apart.
pub const STOP_SENDS: u8 = 3;
/// Speeds chosen by `1`, `2`, `3` (m/s).
pub const SPEEDS: [f32; 3] = [1.0, 2.0, 5.0];
/// Yaw rate of `a`/`d` (degrees per second).
pub const YAW_RATE_DEG: f32 = 30.0;
/// Altitude step of `r`/`f` (m).
pub const ALT_STEP: f64 = 1.0;

/// Position, acceleration and yaw ignored: velocity and yaw rate used (0x05C7).
pub fn type_mask() -> PositionTargetTypemask {
    use PositionTargetTypemask as M;
    M::POSITION_TARGET_TYPEMASK_X_IGNORE
        | M::POSITION_TARGET_TYPEMASK_Y_IGNORE
        | M::POSITION_TARGET_TYPEMASK_Z_IGNORE
        | M::POSITION_TARGET_TYPEMASK_AX_IGNORE
        | M::POSITION_TARGET_TYPEMASK_AY_IGNORE
        | M::POSITION_TARGET_TYPEMASK_AZ_IGNORE
        | M::POSITION_TARGET_TYPEMASK_YAW_IGNORE
}

/// `TYPE_MASK` as sent.
pub const TYPE_MASK: u16 = 0x05C7;

/// The axes a key moves on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    Forward,
    Right,
    Up,
    Yaw,
}

/// What a key means in Fly mode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FlyKey {
    /// A direction: axis and sign.
    Move(Axis, f32),
    Speed(usize),
    /// Altitude step up (+1) or down (-1).
    Alt(f64),
    Leave,
    Other,
}

/// The meaning of `key` in Fly mode.
pub fn fly_key(key: &Key) -> FlyKey {
    if key.ctrl || key.alt {
        return FlyKey::Other;
    }
    match key.code {
        KeyCode::Up => FlyKey::Move(Axis::Forward, 1.0),
        KeyCode::Down => FlyKey::Move(Axis::Forward, -1.0),
        KeyCode::Right => FlyKey::Move(Axis::Right, 1.0),
        KeyCode::Left => FlyKey::Move(Axis::Right, -1.0),
        KeyCode::Char('w') => FlyKey::Move(Axis::Up, 1.0),
        KeyCode::Char('s') => FlyKey::Move(Axis::Up, -1.0),
        KeyCode::Char('d') => FlyKey::Move(Axis::Yaw, 1.0),
        KeyCode::Char('a') => FlyKey::Move(Axis::Yaw, -1.0),
        KeyCode::Char('1') => FlyKey::Speed(0),
        KeyCode::Char('2') => FlyKey::Speed(1),
        KeyCode::Char('3') => FlyKey::Speed(2),
        KeyCode::Char('r') => FlyKey::Alt(ALT_STEP),
        KeyCode::Char('f') => FlyKey::Alt(-ALT_STEP),
        KeyCode::Esc => FlyKey::Leave,
        _ => FlyKey::Other,
    }
}

/// A direction key held: its sign, when its key last came, and whether it has repeated.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Held {
    sign: f32,
    last: Micros,
    repeated: bool,
}

/// The Fly mode machine: keys and time in, messages out.
#[derive(Debug, Clone)]
pub struct Nudge {
    /// The vehicle flown, while in Fly mode.
    pub target: Option<VehicleKey>,
    pub speed: usize,
    pub deadman: Micros,
    /// The screen Fly mode was entered on: another screen leaves it.
    pub screen: &'static str,
    /// The terminal reports key releases (one has come): they stop a nudge at once.
    pub releases: bool,
    /// Per axis (forward, right, up, yaw): the key held.
    held: [Option<Held>; 4],
    /// When the next velocity target goes, while one is being streamed.
    next_send: Option<Micros>,
    /// A velocity was sent in this Fly mode: leaving sends zero.
    moved: bool,
    /// A stop still to be sent again: (vehicle, copies left, when the next goes).
    stop: Option<(VehicleKey, u8, Micros)>,
}

impl Default for Nudge {
    fn default() -> Self {
        Self::new(DEADMAN)
    }
}

fn idx(a: Axis) -> usize {
    match a {
        Axis::Forward => 0,
        Axis::Right => 1,
        Axis::Up => 2,
        Axis::Yaw => 3,
    }
}

impl Nudge {
    pub fn new(deadman: Micros) -> Self {
        Self {
            target: None,
            speed: 1,
            deadman,
            screen: "",
            releases: false,
            held: [None; 4],
            next_send: None,
            moved: false,
            stop: None,
        }
    }

    pub fn active(&self) -> bool {
        self.target.is_some()
    }

    pub fn speed_ms(&self) -> f32 {
        SPEEDS[self.speed.min(SPEEDS.len() - 1)]
    }

    /// True while a stop is still to be sent again (the front end waits for it before exiting).
    pub fn stopping(&self) -> bool {
        self.stop.is_some()
    }

    /// True once a velocity was sent in this Fly mode.
    pub fn moved(&self) -> bool {
        self.moved
    }

    /// Enter Fly mode on `key`, from `screen`.
    pub fn enter(&mut self, key: VehicleKey, screen: &'static str) {
        *self = Self {
            target: Some(key),
            speed: self.speed,
            screen,
            releases: self.releases,
            stop: self.stop,
            ..Self::new(self.deadman)
        };
    }

    /// Leave Fly mode: a zero velocity if anything was flown (sent again twice, [`PERIOD`]
    /// apart, by [`Self::poll`]).
    pub fn leave(&mut self, now: Micros) -> Option<(VehicleKey, MavMessage)> {
        let key = self.target.take()?;
        let moved = self.moved;
        self.held = [None; 4];
        self.next_send = None;
        self.moved = false;
        moved.then(|| self.stop_now(now, key))
    }

    /// A zero velocity now, and its copies scheduled.
    fn stop_now(&mut self, now: Micros, key: VehicleKey) -> (VehicleKey, MavMessage) {
        self.stop = Some((key, STOP_SENDS - 1, now + PERIOD));
        (key, velocity_message(key, now, [0.0; 4]))
    }

    /// The velocity (forward, right, down m/s; yaw rate rad/s) of the keys held.
    pub fn velocity(&self) -> [f32; 4] {
        let s = self.speed_ms();
        let v = |a: Axis| self.held[idx(a)].map_or(0.0, |h| h.sign);
        [
            v(Axis::Forward) * s,
            v(Axis::Right) * s,
            -v(Axis::Up) * s,
            v(Axis::Yaw) * YAW_RATE_DEG.to_radians(),
        ]
    }

    /// True while a direction is held.
    pub fn moving(&self) -> bool {
        self.held.iter().any(|h| h.is_some())
    }

    /// A direction key came (pressed or repeated): the velocity goes at once when it changed,
    /// then at [`RATE_HZ`].
    pub fn press(
        &mut self,
        now: Micros,
        axis: Axis,
        sign: f32,
    ) -> Option<(VehicleKey, MavMessage)> {
        let key = self.target?;
        let before = self.velocity();
        let repeated = self.held[idx(axis)].is_some_and(|h| h.sign == sign);
        self.held[idx(axis)] = Some(Held {
            sign,
            last: now,
            repeated,
        });
        if self.next_send.is_none() || self.velocity() != before {
            return self.send(now, key);
        }
        None
    }

    /// A key was let go (reported by the terminal): its axis stops at once.
    pub fn release(
        &mut self,
        now: Micros,
        axis: Axis,
        sign: f32,
    ) -> Option<(VehicleKey, MavMessage)> {
        let key = self.target?;
        match self.held[idx(axis)] {
            Some(h) if h.sign == sign => self.held[idx(axis)] = None,
            _ => return None,
        }
        self.send(now, key)
    }

    /// A velocity target now: the keys held, or a stop (and the stream ends) when none is.
    fn send(&mut self, now: Micros, key: VehicleKey) -> Option<(VehicleKey, MavMessage)> {
        self.moved = true;
        if !self.moving() {
            self.next_send = None;
            return Some(self.stop_now(now, key));
        }
        self.stop = None;
        self.next_send = Some(now + PERIOD);
        Some((key, velocity_message(key, now, self.velocity())))
    }

    /// Speed `i` of [`SPEEDS`]; a stream in progress takes it at its next send.
    pub fn set_speed(&mut self, i: usize) {
        self.speed = i.min(SPEEDS.len() - 1);
    }

    /// The deadman of a key held: [`FIRST_REPEAT_WAIT`] until it repeats, then the deadman.
    fn deadman_of(&self, h: &Held) -> Micros {
        if h.repeated {
            self.deadman
        } else {
            self.deadman.max(FIRST_REPEAT_WAIT)
        }
    }

    /// What is due at `now`: a stop's next copy, the next velocity target, or the deadman's (a
    /// direction whose key has not come for longer than its deadman stops at once, not at the
    /// next send).
    pub fn poll(&mut self, now: Micros) -> Option<(VehicleKey, MavMessage)> {
        if let Some((key, left, at)) = self.stop {
            if at <= now {
                self.stop = (left > 1).then_some((key, left - 1, at + PERIOD));
                return Some((key, velocity_message(key, now, [0.0; 4])));
            }
        }
        let key = self.target?;
        let mut expired = false;
        for i in 0..self.held.len() {
            if let Some(h) = self.held[i] {
                if now.saturating_sub(h.last) > self.deadman_of(&h) {
                    self.held[i] = None;
                    expired = true;
                }
            }
        }
        if expired || self.next_send.is_some_and(|t| t <= now) {
            return self.send(now, key);
        }
        None
    }

    /// The next send, a stop's next copy, or the deadman of a key held, whichever is first.
    pub fn next_deadline(&self) -> Option<Micros> {
        let expiry = self
            .held
            .iter()
            .flatten()
            .map(|h| h.last + self.deadman_of(h) + 1)
            .min();
        let stop = self.stop.map(|(_, _, at)| at);
        [self.next_send, expiry, stop].into_iter().flatten().min()
    }

    /// What stops a nudge here: `release keys`, or the deadman (`deadman 0.3 s`).
    pub fn stop_mode(&self) -> String {
        if self.releases {
            "release keys".into()
        } else {
            format!("deadman {:.1} s", self.deadman as f64 / 1e6)
        }
    }
}

/// SET_POSITION_TARGET_LOCAL_NED in MAV_FRAME_BODY_OFFSET_NED: velocity (forward, right, down
/// m/s) and yaw rate (rad/s) used, the rest ignored.
#[allow(deprecated)] // BODY_OFFSET_NED: deprecated in MAVLink, what ArduCopter reads
pub fn velocity_message(key: VehicleKey, now: Micros, v: [f32; 4]) -> MavMessage {
    MavMessage::SET_POSITION_TARGET_LOCAL_NED(SET_POSITION_TARGET_LOCAL_NED_DATA {
        time_boot_ms: (now / 1000) as u32,
        target_system: key.0,
        target_component: key.1,
        coordinate_frame: MavFrame::MAV_FRAME_BODY_OFFSET_NED,
        type_mask: type_mask(),
        x: 0.0,
        y: 0.0,
        z: 0.0,
        vx: v[0],
        vy: v[1],
        vz: v[2],
        afx: 0.0,
        afy: 0.0,
        afz: 0.0,
        yaw: 0.0,
        yaw_rate: v[3],
    })
}

impl App {
    fn nudge_send(&mut self, out: Option<(VehicleKey, MavMessage)>, fx: &mut Vec<Effect>) {
        if let Some((key, msg)) = out {
            self.session_out(key, vec![SessionOut::Send(msg)], fx);
        }
    }

    /// Enter Fly mode on the target (`fly` key).
    pub(super) fn enter_fly(&mut self) -> Result<Option<String>, String> {
        let key = self.commandable()?;
        if !self.sessions.contains_key(&key) {
            return Err(format!("{key} is not an autopilot"));
        }
        self.nudge.enter(key, self.ui.screen);
        Ok(Some(
            "Fly mode: arrows move, w/s up/down, a/d yaw, 1/2/3 speed, r/f altitude, esc leaves"
                .into(),
        ))
    }

    /// Leave Fly mode (a zero velocity if anything was flown).
    pub(super) fn leave_fly(&mut self, fx: &mut Vec<Effect>) {
        let out = self.nudge.leave(self.now);
        self.nudge_send(out, fx);
    }

    /// A key in Fly mode.
    pub(super) fn on_fly_key(&mut self, key: Key, fx: &mut Vec<Effect>) {
        let Some(target) = self.nudge.target else {
            return;
        };
        let now = self.now;
        let outcome: Result<Option<String>, String> = match fly_key(&key) {
            FlyKey::Leave => {
                self.leave_fly(fx);
                Ok(Some("Fly mode left".into()))
            }
            FlyKey::Speed(i) => {
                self.nudge.set_speed(i);
                Ok(Some(format!(
                    "nudge speed {:.0} m/s",
                    self.nudge.speed_ms()
                )))
            }
            FlyKey::Move(axis, sign) => match self.guided_check(target, true, "nudge") {
                Ok(()) => {
                    let out = self.nudge.press(now, axis, sign);
                    self.nudge_send(out, fx);
                    Ok(None)
                }
                Err(e) => {
                    // A stream in progress stops too.
                    if self.nudge.moving() {
                        let out = self.nudge.release(now, axis, sign);
                        self.nudge_send(out, fx);
                    }
                    Err(e)
                }
            },
            FlyKey::Alt(step) => {
                let alt = self
                    .sessions
                    .get(&target)
                    .and_then(|s| s.flight.position.as_ref())
                    .map(|p| p.value.relative_alt_m());
                match alt {
                    Some(a) => {
                        let target_alt = (a + step).round();
                        self.run_mission(super::mission::MissionCmd::Alt(target_alt), fx)
                    }
                    None => Err("altitude not known yet".into()),
                }
            }
            FlyKey::Other => {
                // A key that opens something else (a screen, the prompt, the palette, the help)
                // or quits leaves Fly mode first, with a stop; other keys do nothing here.
                use crate::keymap::{Action, Mode};
                match self.keymap.lookup(Mode::Normal, self.ui.screen, &key) {
                    Some(
                        a @ (Action::Quit
                        | Action::Screen(_)
                        | Action::Prompt
                        | Action::Palette
                        | Action::Help
                        | Action::ModeMenu
                        | Action::Takeoff),
                    ) => {
                        self.leave_fly(fx);
                        self.notice(Severity::INFO, Some(target), "Fly mode left".into());
                        self.ui.message = Some((Severity::INFO, "Fly mode left".into()));
                        self.on_action(a, fx);
                        return;
                    }
                    _ => Err("Fly mode: esc leaves it first".into()),
                }
            }
        };
        self.ui.message = match outcome {
            Ok(Some(t)) => Some((Severity::INFO, t)),
            Ok(None) => self
                .ui
                .message
                .take()
                .filter(|(s, _)| *s != Severity::ERROR),
            Err(e) => Some((Severity::ERROR, e)),
        };
    }

    /// A key let go: in Fly mode, its direction stops at once.
    pub(super) fn on_key_release(&mut self, key: Key, fx: &mut Vec<Effect>) {
        self.nudge.releases = true;
        if !self.nudge.active() {
            return;
        }
        if let FlyKey::Move(axis, sign) = fly_key(&key) {
            let out = self.nudge.release(self.now, axis, sign);
            self.nudge_send(out, fx);
            self.dirty = true;
        }
    }

    /// Why Fly mode on `key` must end now, if it must: the vehicle gone or lost, the target
    /// changed, another screen, the prompt, a question or the palette open, or (once flown) the
    /// vehicle disarmed or out of GUIDED.
    fn fly_ends(&self, key: VehicleKey) -> Option<String> {
        if !self.sessions.contains_key(&key) {
            return Some("vehicle gone".into());
        }
        if self.vehicles.get(key).is_none_or(|v| v.lost) {
            return Some("vehicle lost".into());
        }
        if self.target != Some(key) {
            return Some("the target changed".into());
        }
        if self.ui.mode != crate::keymap::Mode::Normal
            || self.ui.screen != self.nudge.screen
            || self.ui.confirm.is_some()
            || self.ui.palette.is_some()
        {
            return Some("another screen opened".into());
        }
        if self.nudge.moved() {
            if let Err(e) = self.guided_check(key, true, "nudge") {
                return Some(e);
            }
        }
        None
    }

    /// The 10 Hz stream (armed and GUIDED checked before every send), the deadman, a stop's
    /// copies; Fly mode ends, with a stop, as soon as it must ([`Self::fly_ends`]).
    pub(super) fn poll_nudge(&mut self, fx: &mut Vec<Effect>) {
        if let Some(key) = self.nudge.target {
            if let Some(why) = self.fly_ends(key) {
                self.leave_fly(fx);
                self.notice(
                    Severity::WARNING,
                    Some(key),
                    format!("Fly mode left: {why}"),
                );
                self.dirty = true;
            }
        }
        let before = self.nudge.moving();
        let out = self.nudge.poll(self.now);
        self.nudge_send(out, fx);
        if before != self.nudge.moving() {
            self.dirty = true;
        }
    }

    /// `FLY ↑2.0 m/s`: Fly mode's state for the status bar.
    pub fn fly_text(&self) -> Option<String> {
        self.nudge.target?;
        let v = self.nudge.velocity();
        let mut dirs = String::new();
        for (val, pos, neg) in [
            (v[0], '↑', '↓'),
            (v[1], '→', '←'),
            (-v[2], '⤒', '⤓'),
            (v[3], '↻', '↺'),
        ] {
            if val > 0.0 {
                dirs.push(pos);
            } else if val < 0.0 {
                dirs.push(neg);
            }
        }
        Some(format!(
            "FLY {dirs}{:.1} m/s {}",
            self.nudge.speed_ms(),
            self.nudge.stop_mode()
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vel(m: &MavMessage) -> [f32; 4] {
        match m {
            MavMessage::SET_POSITION_TARGET_LOCAL_NED(d) => [d.vx, d.vy, d.vz, d.yaw_rate],
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn the_mask_is_velocity_and_yaw_rate() {
        assert_eq!(type_mask().bits(), TYPE_MASK);
    }

    #[test]
    fn a_held_key_streams_at_10_hz_and_the_deadman_stops_it() {
        let mut n = Nudge::new(300_000);
        assert!(n.press(0, Axis::Forward, 1.0).is_none(), "not in Fly mode");
        n.enter(VehicleKey(1, 1), "overview");
        let (_, m) = n.press(0, Axis::Forward, 1.0).unwrap();
        assert_eq!(vel(&m), [2.0, 0.0, -0.0, 0.0]);
        // Its first repeat 500 ms later, then every 30 ms: not more than 10 Hz.
        assert!(n.press(500_000, Axis::Forward, 1.0).is_none());
        assert!(n.press(530_000, Axis::Forward, 1.0).is_none());
        // Polled at its deadlines: sends every 100 ms, the deadman stops it 0.3 s after the
        // last repeat (530 ms), then the stop goes twice more 100 ms apart.
        let mut sent = Vec::new();
        let mut t = 100_000;
        while let Some(d) = n.next_deadline() {
            assert!(d >= t, "deadline {d} before {t}");
            t = d;
            if let Some((_, m)) = n.poll(d) {
                sent.push((d, vel(&m)[0]));
            }
        }
        let stops: Vec<_> = sent.iter().filter(|(_, v)| *v == 0.0).collect();
        assert_eq!(
            stops.iter().map(|(t, _)| *t).collect::<Vec<_>>(),
            vec![830_001, 930_001, 1_030_001]
        );
        assert_eq!(sent.iter().filter(|(_, v)| *v == 2.0).count(), 8);
        assert!(!n.stopping());
    }

    #[test]
    fn a_single_press_lasts_until_its_first_repeat_would_have_come() {
        let mut n = Nudge::new(300_000);
        n.enter(VehicleKey(1, 1), "overview");
        n.press(0, Axis::Right, 1.0).unwrap();
        let mut first_stop = None;
        let mut t = 0;
        while t < 2_000_000 && first_stop.is_none() {
            t += 10_000;
            if let Some((_, m)) = n.poll(t) {
                if vel(&m)[1] == 0.0 {
                    first_stop = Some(t);
                }
            }
        }
        // Not at 0.3 s (terminals wait up to 0.66 s before the first repeat): after 0.7 s.
        assert_eq!(first_stop, Some(710_000));
    }

    /// A key held from 0 to `hold` with the repeats of (`delay`, `gap`), driven as the driver
    /// does (each key at its time, the nudge polled at its deadlines): when each velocity target
    /// went and whether it moved, and the time of the last key.
    fn held_for(delay: Micros, gap: Micros, hold: Micros) -> (Vec<(Micros, bool)>, Micros) {
        let mut n = Nudge::default();
        n.enter(VehicleKey(1, 1), "overview");
        let mut keys = vec![0];
        let mut k = delay;
        while k <= hold {
            keys.push(k);
            k += gap;
        }
        let last = *keys.last().unwrap();
        let mut sent = Vec::new();
        let mut keys = keys.into_iter().peekable();
        loop {
            let key = keys.peek().copied();
            let due = n.next_deadline();
            let (t, m) = match (key, due) {
                (Some(k), d) if d.is_none_or(|d| k <= d) => {
                    keys.next();
                    (k, n.press(k, Axis::Forward, 1.0))
                }
                (_, Some(d)) => (d, n.poll(d)),
                _ => break,
            };
            if let Some((_, m)) = m {
                sent.push((t, vel(&m)[0] != 0.0));
            }
        }
        (sent, last)
    }

    #[test]
    fn a_key_held_at_every_documented_repeat_rate_never_stops_and_stops_after_its_release() {
        assert_eq!(DEADMAN, 300_000);
        for (name, delay, gap) in REPEAT_DEFAULTS {
            assert!(delay < FIRST_REPEAT_WAIT && gap < DEADMAN, "{name}");
            let (sent, last) = held_for(delay, gap, 3_000_000);
            // Held 3 s: every target until the last key moves, at 10 Hz.
            let moving: Vec<Micros> = sent.iter().filter(|s| s.1).map(|s| s.0).collect();
            assert!(
                sent.iter().filter(|s| s.0 <= last).all(|s| s.1),
                "{name}: a held key stopped: {sent:?}"
            );
            assert!(moving.len() >= 30, "{name}: {moving:?}");
            // Let go after `last`: the stop the deadman after it, three times 100 ms apart.
            let stops: Vec<Micros> = sent.iter().filter(|s| !s.1).map(|s| s.0).collect();
            let at = last + DEADMAN + 1;
            assert_eq!(stops, vec![at, at + PERIOD, at + 2 * PERIOD], "{name}");
            assert!(moving.iter().all(|&t| t < at), "{name}");
        }
        // A tap (let go before any repeat): it stops FIRST_REPEAT_WAIT after the press.
        let (sent, _) = held_for(1_000_000, 40_000, 0);
        let stop = sent.iter().find(|s| !s.1).map(|s| s.0);
        assert_eq!(stop, Some(FIRST_REPEAT_WAIT + 1));
    }

    #[test]
    fn a_release_stops_at_once_and_leaving_sends_zero() {
        let mut n = Nudge::default();
        n.enter(VehicleKey(1, 1), "overview");
        n.set_speed(2);
        n.press(0, Axis::Right, -1.0).unwrap();
        let (_, m) = n.release(50_000, Axis::Right, -1.0).unwrap();
        assert_eq!(vel(&m), [0.0, 0.0, -0.0, 0.0]);
        // The stop goes twice more, 100 ms apart; nothing after.
        assert_eq!(n.next_deadline(), Some(150_000));
        assert!(n.poll(149_999).is_none());
        assert_eq!(vel(&n.poll(150_000).unwrap().1), [0.0; 4]);
        assert_eq!(vel(&n.poll(250_000).unwrap().1), [0.0; 4]);
        assert_eq!(n.next_deadline(), None);
        let (_, m) = n.leave(260_000).unwrap();
        assert_eq!(vel(&m), [0.0; 4]);
        assert!(!n.active());
        assert!(n.stopping(), "its copies follow, out of Fly mode too");
        assert!(n.poll(360_000).is_some() && n.poll(460_000).is_some());
        assert!(!n.stopping());
    }
}
