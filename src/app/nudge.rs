//! Fly mode: velocity nudges of a GUIDED vehicle from the keyboard, sans-I/O.
//!
//! Fly mode is entered by a key (`fly`, `F` by default) and shown in the status bar; scrolling
//! keys never fly the vehicle outside it. While a direction key is held, SET_POSITION_TARGET_
//! LOCAL_NED in MAV_FRAME_BODY_OFFSET_NED with only the velocity and the yaw rate used
//! ([`TYPE_MASK`]) goes out at [`RATE_HZ`]; what is sent is the sum of the keys held (forward
//! and right at once fly diagonally). The deadman stops the vehicle (one zero-velocity target):
//! at once on a reported key release (terminals with the keyboard enhancement protocol), else
//! when no key of a direction has come for longer than the deadman time (terminal key repeats
//! keep it alive; 0.8 s default, `nudge_deadman`), when Fly mode is left, and when the vehicle
//! is lost. Nothing else is sent on its own.
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

use super::notices::{SEV_ERROR, SEV_INFO, SEV_WARNING};
use super::session::SessionOut;
use super::{App, Effect};

/// Velocity targets per second while a key is held.
pub const RATE_HZ: u64 = 10;
/// Between two velocity targets.
pub const PERIOD: Micros = 1_000_000 / RATE_HZ;
/// Default deadman: longer than a terminal's first key-repeat delay.
pub const DEADMAN: Micros = 800_000;
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

/// The Fly mode machine: keys and time in, messages out.
#[derive(Debug, Clone)]
pub struct Nudge {
    /// The vehicle flown, while in Fly mode.
    pub target: Option<VehicleKey>,
    pub speed: usize,
    pub deadman: Micros,
    /// Per axis (forward, right, up, yaw): the sign held and when its key last came.
    held: [Option<(f32, Micros)>; 4],
    /// When the next velocity target goes, while one is being streamed.
    next_send: Option<Micros>,
    /// A velocity was sent in this Fly mode: leaving sends zero.
    moved: bool,
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
            held: [None; 4],
            next_send: None,
            moved: false,
        }
    }

    pub fn active(&self) -> bool {
        self.target.is_some()
    }

    pub fn speed_ms(&self) -> f32 {
        SPEEDS[self.speed.min(SPEEDS.len() - 1)]
    }

    /// Enter Fly mode on `key`.
    pub fn enter(&mut self, key: VehicleKey) {
        *self = Self {
            target: Some(key),
            speed: self.speed,
            ..Self::new(self.deadman)
        };
    }

    /// Leave Fly mode: a zero velocity if anything was flown.
    pub fn leave(&mut self, now: Micros) -> Option<(VehicleKey, MavMessage)> {
        let key = self.target.take()?;
        let moved = self.moved;
        self.held = [None; 4];
        self.next_send = None;
        self.moved = false;
        moved.then(|| (key, velocity_message(key, now, [0.0; 4])))
    }

    /// The velocity (forward, right, down m/s; yaw rate rad/s) of the keys held.
    pub fn velocity(&self) -> [f32; 4] {
        let s = self.speed_ms();
        let v = |a: Axis| self.held[idx(a)].map_or(0.0, |(sign, _)| sign);
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
        self.held[idx(axis)] = Some((sign, now));
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
            Some((s, _)) if s == sign => self.held[idx(axis)] = None,
            _ => return None,
        }
        self.send(now, key)
    }

    /// A velocity target now: the keys held, or zero (and the stream ends) when none is.
    fn send(&mut self, now: Micros, key: VehicleKey) -> Option<(VehicleKey, MavMessage)> {
        let v = self.velocity();
        self.moved = true;
        self.next_send = self.moving().then_some(now + PERIOD);
        Some((key, velocity_message(key, now, v)))
    }

    /// Speed `i` of [`SPEEDS`]; a stream in progress takes it at its next send.
    pub fn set_speed(&mut self, i: usize) {
        self.speed = i.min(SPEEDS.len() - 1);
    }

    /// What is due at `now`: the next velocity target, or the deadman's (a direction whose key
    /// has not come for longer than the deadman time stops at once, not at the next send).
    pub fn poll(&mut self, now: Micros) -> Option<(VehicleKey, MavMessage)> {
        let key = self.target?;
        let mut expired = false;
        for h in &mut self.held {
            if h.is_some_and(|(_, t)| now.saturating_sub(t) > self.deadman) {
                *h = None;
                expired = true;
            }
        }
        if expired || self.next_send.is_some_and(|t| t <= now) {
            return self.send(now, key);
        }
        None
    }

    /// The next send, or the deadman of a key held, whichever is first.
    pub fn next_deadline(&self) -> Option<Micros> {
        let expiry = self
            .held
            .iter()
            .flatten()
            .map(|(_, t)| t + self.deadman + 1)
            .min();
        [self.next_send, expiry].into_iter().flatten().min()
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
            return Err(format!("{}:{} is not an autopilot", key.0, key.1));
        }
        self.nudge.enter(key);
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
            FlyKey::Other => Err("Fly mode: esc leaves it first".into()),
        };
        self.ui.message = match outcome {
            Ok(Some(t)) => Some((SEV_INFO, t)),
            Ok(None) => self.ui.message.take().filter(|(s, _)| *s != SEV_ERROR),
            Err(e) => Some((SEV_ERROR, e)),
        };
    }

    /// A key let go: in Fly mode, its direction stops at once.
    pub(super) fn on_key_release(&mut self, key: Key, fx: &mut Vec<Effect>) {
        if !self.nudge.active() {
            return;
        }
        if let FlyKey::Move(axis, sign) = fly_key(&key) {
            let out = self.nudge.release(self.now, axis, sign);
            self.nudge_send(out, fx);
            self.dirty = true;
        }
    }

    /// The 10 Hz stream and the deadman; Fly mode ends when its vehicle is gone.
    pub(super) fn poll_nudge(&mut self, fx: &mut Vec<Effect>) {
        let Some(key) = self.nudge.target else {
            return;
        };
        if !self.sessions.contains_key(&key) {
            self.nudge.leave(self.now);
            self.notice(SEV_WARNING, None, "Fly mode left: vehicle gone".into());
            return;
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
        Some(format!("FLY {dirs}{:.1} m/s", self.nudge.speed_ms()))
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
        let mut n = Nudge::new(800_000);
        assert!(n.press(0, Axis::Forward, 1.0).is_none(), "not in Fly mode");
        n.enter((1, 1));
        let (_, m) = n.press(0, Axis::Forward, 1.0).unwrap();
        assert_eq!(vel(&m), [2.0, 0.0, -0.0, 0.0]);
        // Repeats at 30 ms do not send more than 10 Hz.
        assert!(n.press(30_000, Axis::Forward, 1.0).is_none());
        assert_eq!(n.next_deadline(), Some(100_000));
        // Polled at its deadlines, the deadman stops it 0.8 s after the last key, not later.
        let mut m2 = n.clone();
        let mut last = None;
        while let Some(d) = m2.next_deadline() {
            if let Some((_, m)) = m2.poll(d) {
                last = Some((d, vel(&m)));
            }
        }
        assert_eq!(last, Some((830_001, [0.0; 4])));
        let mut sends = 1;
        let mut t = 100_000;
        let mut stopped_at = None;
        while t <= 3_000_000 {
            if let Some((_, m)) = n.poll(t) {
                sends += 1;
                if vel(&m)[0] == 0.0 {
                    stopped_at = Some(t);
                    break;
                }
            }
            t += 100_000;
        }
        // The last key at 30 ms: stopped at the first send more than 0.8 s after it.
        assert_eq!(stopped_at, Some(900_000));
        assert_eq!(sends, 10);
        assert_eq!(n.next_deadline(), None);
    }

    #[test]
    fn a_release_stops_at_once_and_leaving_sends_zero() {
        let mut n = Nudge::default();
        n.enter((1, 1));
        n.set_speed(2);
        n.press(0, Axis::Right, -1.0).unwrap();
        let (_, m) = n.release(50_000, Axis::Right, -1.0).unwrap();
        assert_eq!(vel(&m), [0.0, 0.0, -0.0, 0.0]);
        assert_eq!(n.next_deadline(), None);
        let (_, m) = n.leave(60_000).unwrap();
        assert_eq!(vel(&m), [0.0; 4]);
        assert!(!n.active());
    }
}
