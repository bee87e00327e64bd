//! Gimbals of one system (MAVLink Gimbal Protocol v2), sans-I/O.
//!
//! A gimbal is addressed through its *gimbal manager*: a component (ArduPilot's AP_Mount answers
//! on the autopilot's own component id; PX4 likewise; a smart gimbal may be its own manager) that
//! answers MAV_CMD_REQUEST_MESSAGE for GIMBAL_MANAGER_INFORMATION (280) with one message per
//! gimbal device it runs (`gimbal_device_id`: the device's component id, or 1–6 for a gimbal
//! that is not a MAVLink component, ArduPilot's `instance + 1`).
//!
//! - Discovery, after QGroundControl's GimbalController: a component is asked when it shows it
//!   may be a manager: its HEARTBEAT says MAV_TYPE_GIMBAL, or it sends GIMBAL_MANAGER_STATUS, or
//!   GIMBAL_DEVICE_ATTITUDE_STATUS for a device 1–6 (which names it the manager: ArduPilot with a
//!   mount streams that in EXTRA3, which mavterm asks for). A device that is its own component
//!   (id 0 in the attitude) gets the autopilot asked; so does the operator pointing while no
//!   manager is known. An autopilot without any sign of a gimbal is not asked (most have none;
//!   QGroundControl asks every component). A request that finishes without the information is
//!   asked again after [`INFO_RETRY`], [`INFO_TRIES`] times in all (an autopilot without a mount
//!   answers ACCEPTED and sends nothing).
//! - Status: GIMBAL_MANAGER_STATUS says who has control; ArduPilot sends it only when asked or
//!   when control changes, so when none came [`STATUS_WAIT`] after the information it is asked
//!   for with SET_MESSAGE_INTERVAL at 1 Hz (an explicit interval: ArduPilot has no default rate
//!   for it, which is why QGroundControl falls back to one). GIMBAL_DEVICE_ATTITUDE_STATUS is in
//!   ArduPilot's EXTRA3 stream; when none comes it is asked for the same way at 2 Hz. Each ask
//!   at most [`STREAM_TRIES`] times.
//! - Messages are read from their payloads (zeros MAVLink 2 cut restored): flag bits newer than
//!   our dialect are kept and shown by number.
//! - Pointing: [`GimbalSet::point`] builds MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW for the manager's
//!   component, or says why not (no manager discovered, an angle beyond the manager's limits,
//!   another controller holds primary control).
//!
//! Requests go out through the vehicle's command queue: the set holds them until
//! [`GimbalSet::sent`].

use std::collections::{BTreeMap, VecDeque};

use crate::clock::{Micros, SECOND};
use crate::dialect::{self, MavCmd};
pub use crate::proto::camera::names;
use crate::proto::machine::{Ids, Incoming, Machine, Out, Request, Requests};
use crate::wire::payload::Payload as P;
use mavlink::MessageData;

pub const GIMBAL_MANAGER_INFORMATION: u32 = crate::dialect::GIMBAL_MANAGER_INFORMATION_DATA::ID;
pub const GIMBAL_MANAGER_STATUS: u32 = crate::dialect::GIMBAL_MANAGER_STATUS_DATA::ID;
pub const GIMBAL_DEVICE_ATTITUDE_STATUS: u32 =
    crate::dialect::GIMBAL_DEVICE_ATTITUDE_STATUS_DATA::ID;

/// MAV_TYPE_GIMBAL.
pub const MAV_TYPE_GIMBAL: u8 = 26;

/// Times GIMBAL_MANAGER_INFORMATION is asked of one component.
pub const INFO_TRIES: u32 = 3;
/// The wait after a request finished without the information before asking again.
pub const INFO_RETRY: Micros = 3 * SECOND;
/// The wait after the information for GIMBAL_MANAGER_STATUS / the attitude before asking for it.
pub const STATUS_WAIT: Micros = 2 * SECOND;
/// Times each stream is asked for.
pub const STREAM_TRIES: u32 = 2;
/// GIMBAL_MANAGER_STATUS asked at 1 Hz, GIMBAL_DEVICE_ATTITUDE_STATUS at 2 Hz.
pub const STATUS_INTERVAL_US: f64 = 1_000_000.0;
pub const ATTITUDE_INTERVAL_US: f64 = 500_000.0;

/// GIMBAL_MANAGER_FLAGS (and GIMBAL_DEVICE_FLAGS: the same bits).
pub const FLAG_RETRACT: u32 = 1;
pub const FLAG_NEUTRAL: u32 = 2;
pub const FLAG_ROLL_LOCK: u32 = 4;
pub const FLAG_PITCH_LOCK: u32 = 8;
pub const FLAG_YAW_LOCK: u32 = 16;
pub const FLAG_YAW_IN_VEHICLE_FRAME: u32 = 32;
pub const FLAG_YAW_IN_EARTH_FRAME: u32 = 64;

/// The flags mavterm points with: roll and pitch held to the horizon, yaw relative to the
/// vehicle's nose ("follow", no YAW_LOCK), as QGroundControl's `sendPitchBodyYaw`. Yaw in the
/// vehicle frame is what a step left/right means to the operator, and it is the frame in which
/// ArduPilot clamps yaw to MNTx_YAW_MIN/MAX (its earth-frame limits are backend specific), so
/// the limits shown are the ones that apply.
pub const POINT_FLAGS: u32 = FLAG_ROLL_LOCK | FLAG_PITCH_LOCK | FLAG_YAW_IN_VEHICLE_FRAME;

/// GIMBAL_MANAGER_CAP_FLAGS, bit by bit, as the common dialect names them.
pub const CAP_FLAGS: &[(u32, &str)] = &[
    (1, "HAS_RETRACT"),
    (2, "HAS_NEUTRAL"),
    (4, "HAS_ROLL_AXIS"),
    (8, "HAS_ROLL_FOLLOW"),
    (16, "HAS_ROLL_LOCK"),
    (32, "HAS_PITCH_AXIS"),
    (64, "HAS_PITCH_FOLLOW"),
    (128, "HAS_PITCH_LOCK"),
    (256, "HAS_YAW_AXIS"),
    (512, "HAS_YAW_FOLLOW"),
    (1024, "HAS_YAW_LOCK"),
    (2048, "SUPPORTS_INFINITE_YAW"),
    (4096, "SUPPORTS_YAW_IN_EARTH_FRAME"),
    (8192, "HAS_RC_INPUTS"),
    (65536, "CAN_POINT_LOCATION_LOCAL"),
    (131072, "CAN_POINT_LOCATION_GLOBAL"),
];
pub const CAP_HAS_PITCH_AXIS: u32 = 32;
pub const CAP_HAS_YAW_AXIS: u32 = 256;

/// GIMBAL_MANAGER_FLAGS / GIMBAL_DEVICE_FLAGS by name.
pub const MANAGER_FLAGS: &[(u32, &str)] = &[
    (1, "RETRACT"),
    (2, "NEUTRAL"),
    (4, "ROLL_LOCK"),
    (8, "PITCH_LOCK"),
    (16, "YAW_LOCK"),
    (32, "YAW_IN_VEHICLE_FRAME"),
    (64, "YAW_IN_EARTH_FRAME"),
    (128, "ACCEPTS_YAW_IN_EARTH_FRAME"),
    (256, "RC_EXCLUSIVE"),
    (512, "RC_MIXED"),
];

/// A quaternion (w, x, y, z; Hamilton, as MAVLink's `mavlink_quaternion_to_euler`) as roll,
/// pitch, yaw in degrees (Tait–Bryan ZYX).
pub fn quaternion_to_euler_deg(q: [f32; 4]) -> (f32, f32, f32) {
    let [w, x, y, z] = q;
    let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
    let pitch = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0).asin();
    let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
    (roll.to_degrees(), pitch.to_degrees(), yaw.to_degrees())
}

/// GIMBAL_MANAGER_INFORMATION, limits in degrees (NaN: unknown).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Info {
    pub cap_flags: u32,
    pub roll: (f32, f32),
    pub pitch: (f32, f32),
    pub yaw: (f32, f32),
}

impl Info {
    /// Payload: time_boot_ms u32, cap_flags u32, roll/pitch/yaw min/max f32 (rad), device u8.
    pub fn read(payload: &[u8]) -> (u8, Info) {
        let p = P(payload);
        let deg = |o| p.f32(o).to_degrees();
        (
            p.u8(32),
            Info {
                cap_flags: p.u32(4),
                roll: (deg(8), deg(12)),
                pitch: (deg(16), deg(20)),
                yaw: (deg(24), deg(28)),
            },
        )
    }
}

/// GIMBAL_MANAGER_STATUS.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Status {
    pub flags: u32,
    /// Primary and secondary control (sysid, compid); (0, 0) for none.
    pub primary: (u8, u8),
    pub secondary: (u8, u8),
}

/// GIMBAL_DEVICE_ATTITUDE_STATUS, in degrees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Attitude {
    pub roll: f32,
    pub pitch: f32,
    pub yaw: f32,
    /// GIMBAL_DEVICE_FLAGS.
    pub flags: u16,
    /// The component the message came from.
    pub from: u8,
}

impl Attitude {
    /// Yaw relative to the vehicle (else to north), as the flags say; for devices that set
    /// neither frame flag, YAW_LOCK means earth frame (the protocol's older rule).
    pub fn yaw_in_vehicle_frame(&self) -> bool {
        let f = self.flags as u32;
        if f & FLAG_YAW_IN_VEHICLE_FRAME != 0 {
            true
        } else if f & FLAG_YAW_IN_EARTH_FRAME != 0 {
            false
        } else {
            f & FLAG_YAW_LOCK == 0
        }
    }
}

/// One gimbal device, by its manager.
#[derive(Debug, Clone, PartialEq)]
pub struct Gimbal {
    /// The manager's component id: where commands go.
    pub manager: u8,
    /// `gimbal_device_id`: the device's component id, or 1–6.
    pub device: u8,
    pub info: Option<Info>,
    pub status: Option<Status>,
    pub attitude: Option<Attitude>,
    /// The last pitch and yaw (degrees, yaw in the vehicle frame) sent to it.
    pub commanded: Option<(f64, f64)>,
    /// GIMBAL_MANAGER_STATUS and attitude asks: how often, and when to look next.
    status_ask: (u32, Option<Micros>),
    attitude_ask: (u32, Option<Micros>),
}

impl Gimbal {
    fn new(manager: u8, device: u8) -> Gimbal {
        Gimbal {
            manager,
            device,
            info: None,
            status: None,
            attitude: None,
            commanded: None,
            status_ask: (0, None),
            attitude_ask: (0, None),
        }
    }

    /// `1:1/1`: system, manager component, device.
    pub fn name(&self, sysid: u8) -> String {
        format!("{sysid}:{}/{}", self.manager, self.device)
    }

    /// The pitch and yaw keys step from: the last sent, else the attitude (yaw only when it is
    /// in the vehicle frame), else level and ahead.
    pub fn base(&self) -> (f64, f64) {
        if let Some(c) = self.commanded {
            return c;
        }
        match self.attitude {
            Some(a) if a.yaw_in_vehicle_frame() => (a.pitch.round() as f64, a.yaw.round() as f64),
            Some(a) => (a.pitch.round() as f64, 0.0),
            None => (0.0, 0.0),
        }
    }

    /// The component to ask for the device's attitude: the device itself when it is a MAVLink
    /// component, else the manager.
    fn attitude_source(&self) -> u8 {
        if self.device <= 6 {
            self.manager
        } else {
            self.device
        }
    }
}

/// A component that may be a gimbal manager.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Candidate {
    /// Requests sent so far.
    tries: u32,
    /// When to ask next (`None`: a request is out, or no more).
    next: Option<Micros>,
    found: bool,
    /// It sent GIMBAL_MANAGER_STATUS (or device 1–6 attitude): asked afresh once.
    evidence: bool,
}

/// The gimbals of one system, by (manager component, device id).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GimbalSet {
    pub gimbals: BTreeMap<(u8, u8), Gimbal>,
    candidates: BTreeMap<u8, Candidate>,
    /// Requests waiting for the command queue: (component, command, params).
    pending: VecDeque<(u8, u16, [f64; 7])>,
    /// The autopilot's component id (the usual manager).
    pub autopilot: u8,
    /// A request may wait for the queue since this time (a command of the system finished,
    /// the autopilot was asked for): the next poll has it offered again.
    offer: Option<Micros>,
}

/// A request the discovery sends on its own (GIMBAL_MANAGER_INFORMATION asked, the status and
/// attitude streams asked for).
pub fn is_discovery(command: u16, params: &[f64; 7]) -> bool {
    (command == (MavCmd::MAV_CMD_REQUEST_MESSAGE as u16)
        && params[0] == GIMBAL_MANAGER_INFORMATION as f64)
        || (command == (MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL as u16)
            && (params[0] == GIMBAL_MANAGER_STATUS as f64
                || params[0] == GIMBAL_DEVICE_ATTITUDE_STATUS as f64))
}

fn request(id: u32) -> [f64; 7] {
    [id as f64, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
}

fn interval(id: u32, us: f64) -> [f64; 7] {
    [id as f64, us, 0.0, 0.0, 0.0, 0.0, 0.0]
}

/// Gimbals kept per system at most: a flood of spoofed device ids cannot grow the set.
const MAX_GIMBALS: usize = 16;

impl GimbalSet {
    /// The gimbal (manager component, device id), made when new unless the set is full.
    fn entry(&mut self, key: (u8, u8)) -> Option<&mut Gimbal> {
        if self.gimbals.len() >= MAX_GIMBALS && !self.gimbals.contains_key(&key) {
            return None;
        }
        Some(
            self.gimbals
                .entry(key)
                .or_insert_with(|| Gimbal::new(key.0, key.1)),
        )
    }

    fn push(&mut self, r: (u8, u16, [f64; 7])) {
        if !self.pending.contains(&r) {
            self.pending.push_back(r);
        }
    }

    /// `compid` may be a gimbal manager: ask it (now) unless it is known or being asked.
    fn candidate(&mut self, now: Micros, compid: u8, evidence: bool) {
        let c = self.candidates.entry(compid).or_insert(Candidate {
            tries: 0,
            next: Some(now),
            found: false,
            evidence: false,
        });
        if evidence && !c.evidence && !c.found {
            c.evidence = true;
            if c.tries >= INFO_TRIES {
                // Asked in vain before it showed it is a manager: one more round.
                c.tries = 0;
                c.next = Some(now);
            }
        }
    }

    /// A message of component `from` of this system; `hb_type`: its HEARTBEAT's MAV_TYPE;
    /// `autopilot`: the system's autopilot component. Returns notices to show.
    pub fn on_message(
        &mut self,
        now: Micros,
        from: u8,
        id: u32,
        hb_type: Option<u8>,
        autopilot: u8,
        payload: &[u8],
    ) -> Vec<(crate::wire::Severity, String)> {
        let mut notes = Vec::new();
        if hb_type == Some(MAV_TYPE_GIMBAL) {
            self.candidate(now, from, false);
        }
        match id {
            GIMBAL_MANAGER_INFORMATION => {
                let (device, info) = Info::read(payload);
                if device == 0 {
                    // Not a device id (QGroundControl ignores it too).
                    return notes;
                }
                let c = self.candidates.entry(from).or_insert(Candidate {
                    tries: 0,
                    next: None,
                    found: true,
                    evidence: true,
                });
                c.found = true;
                c.next = None;
                let Some(g) = self.entry((from, device)) else {
                    return notes;
                };
                if g.info.is_none() {
                    notes.push((
                        crate::wire::Severity::INFO,
                        format!(
                            "gimbal {from}/{device}: pitch {:.0}..{:.0}°, yaw {:.0}..{:.0}°",
                            info.pitch.0, info.pitch.1, info.yaw.0, info.yaw.1
                        ),
                    ));
                    if g.status.is_none() {
                        g.status_ask.1 = Some(now + STATUS_WAIT);
                    }
                    if g.attitude.is_none() {
                        g.attitude_ask.1 = Some(now + STATUS_WAIT);
                    }
                }
                g.info = Some(info);
            }
            GIMBAL_MANAGER_STATUS => {
                let p = P(payload);
                let device = p.u8(8);
                if device == 0 {
                    return notes;
                }
                self.candidate(now, from, true);
                let Some(g) = self.entry((from, device)) else {
                    return notes;
                };
                g.status = Some(Status {
                    flags: p.u32(4),
                    primary: (p.u8(9), p.u8(10)),
                    secondary: (p.u8(11), p.u8(12)),
                });
            }
            GIMBAL_DEVICE_ATTITUDE_STATUS => {
                let p = P(payload);
                let q = [p.f32(4), p.f32(8), p.f32(12), p.f32(16)];
                let (roll, pitch, yaw) = quaternion_to_euler_deg(q);
                let att = Attitude {
                    roll,
                    pitch,
                    yaw,
                    flags: p.u16(36),
                    from,
                };
                let device = p.u8(48);
                let key = match device {
                    // The device is the sending component: its manager is the one that named it
                    // (until one does, the autopilot is the likely manager).
                    0 => {
                        let k = self.gimbals.keys().find(|(_, d)| *d == from).copied();
                        if k.is_none() {
                            self.candidate(now, autopilot, true);
                        }
                        k
                    }
                    1..=6 => {
                        self.candidate(now, from, true);
                        Some((from, device))
                    }
                    _ => None,
                };
                let Some(key) = key else {
                    return notes;
                };
                if let Some(g) = self.entry(key) {
                    g.attitude = Some(att);
                }
            }
            _ => {}
        }
        notes
    }

    /// A command to component `compid` finished (`accepted` or not).
    pub fn on_finished(&mut self, now: Micros, compid: u8, command: u16, params: &[f64; 7]) {
        self.offer = Some(self.offer.map_or(now, |t| t.min(now)));
        if command == (MavCmd::MAV_CMD_REQUEST_MESSAGE as u16)
            && params[0] == GIMBAL_MANAGER_INFORMATION as f64
        {
            if let Some(c) = self.candidates.get_mut(&compid) {
                if !c.found {
                    c.next = (c.tries < INFO_TRIES).then_some(now + INFO_RETRY);
                }
            }
        }
        if command == (MavCmd::MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE as u16) {
            // Who has control now.
            self.push((
                compid,
                (MavCmd::MAV_CMD_REQUEST_MESSAGE as u16),
                request(GIMBAL_MANAGER_STATUS),
            ));
        }
    }

    /// Due work: information asked again, streams asked for.
    pub fn poll(&mut self, now: Micros) {
        let due: Vec<u8> = self
            .candidates
            .iter()
            .filter(|(_, c)| !c.found && c.tries < INFO_TRIES && c.next.is_some_and(|t| now >= t))
            .map(|(id, _)| *id)
            .collect();
        for id in due {
            if let Some(c) = self.candidates.get_mut(&id) {
                c.tries += 1;
                c.next = None;
            }
            self.push((
                id,
                (MavCmd::MAV_CMD_REQUEST_MESSAGE as u16),
                request(GIMBAL_MANAGER_INFORMATION),
            ));
        }
        let mut asks = Vec::new();
        for g in self.gimbals.values_mut() {
            if let Some(t) = g.status_ask.1.filter(|t| now >= *t) {
                let _ = t;
                if g.status.is_none() && g.status_ask.0 < STREAM_TRIES {
                    g.status_ask.0 += 1;
                    g.status_ask.1 = Some(now + STATUS_WAIT);
                    asks.push((
                        g.manager,
                        (MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL as u16),
                        interval(GIMBAL_MANAGER_STATUS, STATUS_INTERVAL_US),
                    ));
                } else {
                    g.status_ask.1 = None;
                }
            }
            if let Some(t) = g.attitude_ask.1.filter(|t| now >= *t) {
                let _ = t;
                if g.attitude.is_none() && g.attitude_ask.0 < STREAM_TRIES {
                    g.attitude_ask.0 += 1;
                    g.attitude_ask.1 = Some(now + STATUS_WAIT);
                    asks.push((
                        g.attitude_source(),
                        (MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL as u16),
                        interval(GIMBAL_DEVICE_ATTITUDE_STATUS, ATTITUDE_INTERVAL_US),
                    ));
                } else {
                    g.attitude_ask.1 = None;
                }
            }
        }
        for a in asks {
            self.push(a);
        }
    }

    pub fn next_deadline(&self) -> Option<Micros> {
        let asks = self
            .gimbals
            .values()
            .flat_map(|g| [g.status_ask.1, g.attitude_ask.1]);
        self.candidates
            .values()
            .filter(|c| !c.found && c.tries < INFO_TRIES)
            .map(|c| c.next)
            .chain(asks)
            .flatten()
            .min()
    }

    /// The requests waiting: the first of each component.
    pub fn heads(&self) -> Vec<(u8, u16, [f64; 7])> {
        let mut seen = Vec::new();
        let mut out = Vec::new();
        for r in &self.pending {
            if !seen.contains(&r.0) {
                seen.push(r.0);
                out.push(*r);
            }
        }
        out
    }

    /// Request `r` went out.
    pub fn sent(&mut self, r: &(u8, u16, [f64; 7])) {
        if let Some(i) = self.pending.iter().position(|p| p == r) {
            self.pending.remove(i);
        }
    }

    /// The operator wants a gimbal and none is known: ask the autopilot (`compid`), unless it is
    /// being asked. Returns true when it is (or was already) being asked.
    pub fn ask_autopilot(&mut self, now: Micros, compid: u8) -> bool {
        let fresh = !self.candidates.contains_key(&compid);
        self.candidate(now, compid, true);
        self.poll(now);
        self.offer = Some(self.offer.map_or(now, |t| t.min(now)));
        fresh
            || self
                .candidates
                .get(&compid)
                .is_some_and(|c| !c.found && c.tries < INFO_TRIES || c.next.is_some())
    }

    /// Gimbals whose manager told its limits (the ones that can be pointed), in order.
    pub fn usable(&self) -> Vec<&Gimbal> {
        self.gimbals.values().filter(|g| g.info.is_some()).collect()
    }

    /// The `sel`th usable gimbal (clamped).
    pub fn pick(&self, sel: usize) -> Option<&Gimbal> {
        let u = self.usable();
        u.get(sel.min(u.len().saturating_sub(1))).copied()
    }

    /// The `sel`th usable gimbal's name on system `sysid` (empty when there is none).
    pub fn name(&self, sel: usize, sysid: u8) -> String {
        self.pick(sel).map(|g| g.name(sysid)).unwrap_or_default()
    }

    /// MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW for the `sel`th gimbal: (manager component, command,
    /// params), or why it is not sent. `us`: our (sysid, compid).
    pub fn point(
        &self,
        sel: usize,
        pitch: f64,
        yaw: f64,
        us: (u8, u8),
    ) -> Result<(u8, u16, [f64; 7]), String> {
        let g = self.pick(sel).ok_or_else(|| {
            let waiting = self
                .candidates
                .values()
                .any(|c| !c.found && c.tries < INFO_TRIES);
            if waiting {
                "no gimbal manager discovered yet (GIMBAL_MANAGER_INFORMATION asked): not sent"
                    .to_string()
            } else {
                "no gimbal manager discovered (no GIMBAL_MANAGER_INFORMATION): not sent".to_string()
            }
        })?;
        let info = g.info.expect("usable");
        let within = |v: f64, (lo, hi): (f32, f32)| {
            (lo.is_nan() || v >= lo as f64 - 1e-3) && (hi.is_nan() || v <= hi as f64 + 1e-3)
        };
        if !within(pitch, info.pitch) {
            return Err(format!(
                "pitch {pitch}° is beyond gimbal {}'s limits {:.0}..{:.0}°: not sent",
                g.manager, info.pitch.0, info.pitch.1
            ));
        }
        if !within(yaw, info.yaw) {
            return Err(format!(
                "yaw {yaw}° is beyond gimbal {}'s limits {:.0}..{:.0}°: not sent",
                g.manager, info.yaw.0, info.yaw.1
            ));
        }
        if let Some(s) = g.status {
            if s.primary != (0, 0) && s.primary != us {
                return Err(format!(
                    "gimbal {} is controlled by {}: `gimbal control` takes it (not sent)",
                    g.manager,
                    crate::proto::vehicles::VehicleKey::from(s.primary)
                ));
            }
        }
        Ok((
            g.manager,
            (MavCmd::MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW as u16),
            [
                pitch,
                yaw,
                f64::NAN,
                f64::NAN,
                POINT_FLAGS as f64,
                0.0,
                g.device as f64,
            ],
        ))
    }

    /// MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE for the `sel`th gimbal: take primary control for
    /// `us`, or give it up (`take` false: -3, "release if we have it"); secondary unchanged.
    pub fn configure(
        &self,
        sel: usize,
        take: bool,
        us: (u8, u8),
    ) -> Result<(u8, u16, [f64; 7]), String> {
        let g = self
            .pick(sel)
            .ok_or("no gimbal manager discovered: not sent")?;
        let (a, b) = if take {
            (us.0 as f64, us.1 as f64)
        } else {
            (-3.0, -3.0)
        };
        Ok((
            g.manager,
            (MavCmd::MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE as u16),
            [a, b, -1.0, -1.0, f64::NAN, f64::NAN, g.device as f64],
        ))
    }

    /// A pointing command went to gimbal (manager, device): keys step from it next.
    pub fn pointed(&mut self, manager: u8, device: u8, pitch: f64, yaw: f64) {
        if let Some(g) = self.gimbals.get_mut(&(manager, device)) {
            g.commanded = Some((pitch, yaw));
        }
    }
}

impl Machine for GimbalSet {
    /// Heartbeats (a gimbal announces itself) and the gimbal manager protocol's messages.
    const IDS: Ids = Ids::Only(&[
        dialect::HEARTBEAT_DATA::ID,
        dialect::GIMBAL_MANAGER_INFORMATION_DATA::ID,
        dialect::GIMBAL_MANAGER_STATUS_DATA::ID,
        dialect::GIMBAL_MANAGER_SET_ATTITUDE_DATA::ID,
        dialect::GIMBAL_DEVICE_INFORMATION_DATA::ID,
        dialect::GIMBAL_DEVICE_SET_ATTITUDE_DATA::ID,
        dialect::GIMBAL_DEVICE_ATTITUDE_STATUS_DATA::ID,
    ]);
    /// Only the heartbeat is read decoded; the rest from their payloads.
    const DECODES: Ids = Ids::Only(&[dialect::HEARTBEAT_DATA::ID]);

    /// The autopilot and any gimbal component may be a gimbal manager.
    fn on_message(&mut self, m: &Incoming, out: &mut Vec<Out>) {
        let hb_type = m.heartbeat().map(|hb| hb.mavtype as u8);
        let ap = self.autopilot;
        let notes = GimbalSet::on_message(self, m.now, m.from.1, m.id, hb_type, ap, m.payload);
        GimbalSet::poll(self, m.now);
        crate::proto::camera::notes_out(notes, out);
    }

    fn poll(&mut self, now: Micros, _: &mut Vec<Out>) {
        self.offer = None;
        GimbalSet::poll(self, now);
    }

    fn next_deadline(&self) -> Option<Micros> {
        GimbalSet::next_deadline(self)
            .into_iter()
            .chain(self.offer)
            .min()
    }
}

impl Requests for GimbalSet {
    fn requests(&self) -> Vec<Request> {
        self.heads()
    }

    fn taken(&mut self, r: &Request) {
        self.sent(r);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn info(device: u8, pitch: (f32, f32), yaw: (f32, f32)) -> Vec<u8> {
        let mut p = vec![0u8; 33];
        p[4..8].copy_from_slice(&(32u32 | 256 | (1 << 20)).to_le_bytes());
        for (i, v) in [-30f32, 30.0, pitch.0, pitch.1, yaw.0, yaw.1]
            .iter()
            .enumerate()
        {
            p[8 + 4 * i..12 + 4 * i].copy_from_slice(&v.to_radians().to_le_bytes());
        }
        p[32] = device;
        p
    }

    const ASK_280: (u8, u16, [f64; 7]) = (1, 512, [280.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);

    #[test]
    fn a_manager_is_asked_three_times_then_left_alone() {
        let mut s = GimbalSet::default();
        // Heartbeats of the autopilot and a camera are no reason to ask.
        s.on_message(0, 1, 0, Some(2), 1, &[]);
        s.on_message(0, 100, 0, Some(30), 1, &[]);
        s.poll(0);
        assert!(s.heads().is_empty());
        assert_eq!(s.next_deadline(), None);
        // An attitude of device 1 from the autopilot: it is that gimbal's manager.
        let mut att = vec![0u8; 49];
        att[4..8].copy_from_slice(&1f32.to_le_bytes());
        att[48] = 1;
        s.on_message(0, 1, 285, None, 1, &att);
        s.poll(0);
        assert_eq!(s.heads(), vec![ASK_280]);
        let mut t = 0;
        for n in 1..=INFO_TRIES {
            s.sent(&ASK_280);
            assert!(s.heads().is_empty());
            // Accepted, nothing came: asked again after INFO_RETRY, not before.
            t += SECOND;
            s.on_finished(t, 1, 512, &ASK_280.2);
            if n == INFO_TRIES {
                break;
            }
            assert_eq!(s.next_deadline(), Some(t + INFO_RETRY));
            s.poll(t + INFO_RETRY - 1);
            assert!(s.heads().is_empty());
            t += INFO_RETRY;
            s.poll(t);
            assert_eq!(s.heads(), vec![ASK_280], "try {}", n + 1);
        }
        assert_eq!(s.next_deadline(), None, "three tries, then idle");
        s.poll(t + 60 * SECOND);
        assert!(s.heads().is_empty());
        // A gimbal component's heartbeat: that one is asked.
        s.on_message(t, 154, 0, Some(MAV_TYPE_GIMBAL), 1, &[]);
        s.poll(t);
        assert_eq!(s.heads(), vec![(154, 512, ASK_280.2)]);
    }

    #[test]
    fn information_status_and_attitude_make_a_gimbal_that_can_be_pointed() {
        let mut s = GimbalSet::default();
        assert!(
            s.ask_autopilot(0, 1),
            "the operator pointed: the autopilot is asked"
        );
        assert_eq!(s.heads(), vec![ASK_280]);
        s.sent(&ASK_280);
        let notes = s.on_message(
            SECOND,
            1,
            280,
            None,
            1,
            &info(1, (-90.0, 20.0), (-180.0, 180.0)),
        );
        assert_eq!(notes.len(), 1);
        s.on_finished(SECOND, 1, 512, &ASK_280.2);
        assert_eq!(s.next_deadline(), Some(SECOND + STATUS_WAIT));
        let g = &s.gimbals[&(1, 1)];
        let i = g.info.unwrap();
        assert!((i.pitch.0 + 90.0).abs() < 1e-3 && (i.pitch.1 - 20.0).abs() < 1e-3);
        assert_eq!(
            names(CAP_FLAGS, i.cap_flags),
            ["HAS_PITCH_AXIS", "HAS_YAW_AXIS", "BIT20"]
        );
        // No status came: asked for at 1 Hz; the attitude likewise at 2 Hz.
        s.poll(SECOND + STATUS_WAIT);
        assert_eq!(
            s.heads(),
            vec![(1, 511, [281.0, 1e6, 0.0, 0.0, 0.0, 0.0, 0.0])]
        );
        s.sent(&(1, 511, [281.0, 1e6, 0.0, 0.0, 0.0, 0.0, 0.0]));
        assert_eq!(
            s.heads(),
            vec![(1, 511, [285.0, 5e5, 0.0, 0.0, 0.0, 0.0, 0.0])]
        );
        // Pointing: within the limits, to the manager, device id in param7.
        let us = (255, 190);
        let (to, cmd, p) = s.point(0, -45.0, 10.0, us).unwrap();
        assert_eq!((to, cmd), (1, 1000));
        assert_eq!(&p[..2], &[-45.0, 10.0]);
        assert!(p[2].is_nan() && p[3].is_nan());
        assert_eq!(&p[4..], &[44.0, 0.0, 1.0]);
        let e = s.point(0, 25.0, 0.0, us).unwrap_err();
        assert!(e.contains("beyond") && e.contains("-90..20"), "{e}");
        // Another ground station in control: refused until `gimbal control`.
        let mut status = vec![0u8; 13];
        status[4] = 12;
        status[8] = 1;
        status[9] = 254;
        status[10] = 190;
        s.on_message(4 * SECOND, 1, 281, None, 1, &status);
        let e = s.point(0, 0.0, 0.0, us).unwrap_err();
        assert!(e.contains("254:190"), "{e}");
        let (_, cmd, p) = s.configure(0, true, us).unwrap();
        assert_eq!(cmd, 1001);
        assert_eq!(&p[..4], &[255.0, 190.0, -1.0, -1.0]);
        assert_eq!(p[6], 1.0);
    }

    #[test]
    fn quaternions_read_as_known_angles() {
        // Pitch -30°, yaw 45° (ZYX): q = qz(45°) * qy(-30°).
        let (p, y) = ((-30f32).to_radians() / 2.0, 45f32.to_radians() / 2.0);
        let q = [
            p.cos() * y.cos(),
            -p.sin() * y.sin(),
            p.sin() * y.cos(),
            p.cos() * y.sin(),
        ];
        let (r, pi, ya) = quaternion_to_euler_deg(q);
        assert!(r.abs() < 0.01 && (pi + 30.0).abs() < 0.01 && (ya - 45.0).abs() < 0.01);
        // Identity; a quarter turn of roll alone (w = x = √½); straight down (pitch -90).
        assert_eq!(
            quaternion_to_euler_deg([1.0, 0.0, 0.0, 0.0]),
            (0.0, 0.0, 0.0)
        );
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let (r, pi, ya) = quaternion_to_euler_deg([h, h, 0.0, 0.0]);
        assert!((r - 90.0).abs() < 0.01 && pi.abs() < 0.01 && ya.abs() < 0.01);
        // (asin is steep at ±1: f32 rounding of √½² costs a few hundredths of a degree.)
        let (_, pi, _) = quaternion_to_euler_deg([h, 0.0, -h, 0.0]);
        assert!((pi + 90.0).abs() < 0.05, "{pi}");
        // An attitude from a device 1–6 on the autopilot: yaw in the vehicle frame by its flags.
        let mut s = GimbalSet::default();
        let mut payload = vec![0u8; 49];
        for (i, v) in q.iter().enumerate() {
            payload[4 + 4 * i..8 + 4 * i].copy_from_slice(&v.to_le_bytes());
        }
        payload[36] = (FLAG_ROLL_LOCK | FLAG_PITCH_LOCK | FLAG_YAW_IN_VEHICLE_FRAME) as u8;
        payload[48] = 1;
        s.on_message(0, 1, 285, None, 1, &payload);
        let a = s.gimbals[&(1, 1)].attitude.unwrap();
        assert!(a.yaw_in_vehicle_frame());
        assert!((a.pitch + 30.0).abs() < 0.01 && (a.yaw - 45.0).abs() < 0.01);
        assert_eq!(s.gimbals[&(1, 1)].base(), (-30.0, 45.0));
    }
}
