// REQUEST_DATA_STREAM is marked deprecated in common.xml, yet it is what ArduPilot honours.
#![allow(deprecated)]
//! Asking an autopilot for telemetry, the way it understands, on every link it is heard on, and
//! checking that what was asked arrives at the rate asked.
//!
//! **What is asked** ([`StreamRates`], from the config):
//! - ArduPilot keeps its stream rates per serial port (`SRn_*`, one `GCS_MAVLINK` instance per
//!   port), so a vehicle heard on two links is asked on both. It gets one REQUEST_DATA_STREAM per
//!   group in [`StreamRates::groups`] (the rate is a u16 in Hz: rounded up, at least 1 for a rate
//!   that is not 0), then MAV_CMD_SET_MESSAGE_INTERVAL for each of
//!   [`StreamRates::ardupilot_messages`] (after the groups: a group request resets the intervals
//!   of its messages, `GCS_MAVLINK::initialise_message_intervals_for_stream`).
//! - PX4 ignores REQUEST_DATA_STREAM; it and every other autopilot get SET_MESSAGE_INTERVAL for
//!   each of [`StreamRates::messages`]. Neither autopilot sets a capability bit that would tell,
//!   so the choice is made on the HEARTBEAT's autopilot.
//! - When: the first time the autopilot is heard on a link, after a reboot, after the link
//!   reconnects, and when its streams stop while its heartbeats go on (a reboot nobody could see:
//!   ArduPilot sends SYSTEM_TIME only in a stream, and a rebooted one sends nothing but
//!   heartbeats until asked). A fade (everything stops, then everything resumes) asks nothing.
//!   Nothing is asked on a link that hears nothing (it would only fill a radio's queue).
//!
//! **One SET_MESSAGE_INTERVAL at a time**: COMMAND_ACK names the command, not the message it
//! answers, so the machine has at most one waiting for its ACK (all links together: a router may
//! hand the same ACK to two links). The wait adapts to the measured round trip (four of them,
//! [`MIN_ACK_WAIT`]..[`MAX_ACK_WAIT`], one second until measured); unanswered, it is sent again,
//! [`INTERVAL_SENDS`] times in all. While the operator's own SET_MESSAGE_INTERVAL waits in the
//! command queue ([`StreamMachine::hold_intervals`]) the machine sends none, and an ACK while
//! none of ours waits is the queue's ([`StreamMachine::on_ack`] returns `None`).
//!
//! **Checked**: every request is followed by a count of what it asked for, per link: after
//! [`CHECK_AFTER`] (or three intervals of a slow stream) at least half the messages due must have
//! come ([`FLOWING_SHARE`]). A group counts as arriving when any of its main messages
//! ([`GROUPS`]: the ones a GCS shows, sent by every ArduCopter) does. A stream that does not
//! arrive is asked again ([`ASKS`] requests in all), then by the other method:
//! - a group ArduPilot ignores (a port with `MAVn_OPTIONS` NOSTREAMOVERRIDE, formerly
//!   `SERIALn_OPTIONS` bit 12 "don't allow GCS to override streamrates", or an `SRn_` rate the
//!   operator cannot change) is asked message by message with SET_MESSAGE_INTERVAL, its main
//!   messages at the group's rate;
//! - a message asked by SET_MESSAGE_INTERVAL that is refused (ArduPilot answers FAILED, with
//!   "No ap_message for mavlink id (N)", for an id it cannot schedule,
//!   `GCS_MAVLINK::set_message_interval`; other versions and autopilots DENIED or UNSUPPORTED),
//!   unanswered, or accepted but never sent, is asked by the ArduPilot group that holds it,
//!   unless the autopilot is PX4, which has no groups.
//! - When both fail the operator is told and that stream is left alone until something changes.
//!
//! A refusal (DENIED, UNSUPPORTED, FAILED, ...) is always shown. Every requested message's rate as
//! asked and as measured on each link is kept ([`StreamMachine::requested`],
//! [`StreamMachine::measured`], [`StreamMachine::report`]).
//!
//! **Links**: a link marked high-latency (`?hl=1`) gets nothing at all. A serial link whose baud
//! was given has its rates scaled so that the telemetry expected fits [`LINK_SHARE`] of it
//! ([`fit_to_link`]).
//!
//! Sans-I/O: messages, ACKs and time in, [`StreamOut`] out, [`StreamMachine::next_deadline`] for
//! the timers.

use std::collections::{BTreeMap, VecDeque};

use num_traits::FromPrimitive;

use crate::clock::{Micros, SECOND};
use crate::dialect::{self, MavAutopilot, MavCmd, MavDataStream, MavMessage, MavResult};
use crate::proto::machine::{Ids, Incoming, Machine, Out, Route};
use crate::proto::rates::StreamRates;
use crate::proto::vehicles::VehicleKey;
use crate::wire::Severity;

/// Shortest wait before a request is checked.
pub const CHECK_AFTER: Micros = 3 * SECOND;
/// Requests of a stream by one method before the other is tried.
pub const ASKS: u32 = 2;
/// Sends of one SET_MESSAGE_INTERVAL without an ACK before it counts as unanswered.
pub const INTERVAL_SENDS: u32 = 3;
/// The wait for a SET_MESSAGE_INTERVAL's ACK: four round trips within these bounds.
pub const MIN_ACK_WAIT: Micros = 300_000;
pub const MAX_ACK_WAIT: Micros = 3 * SECOND;
/// The wait for an ACK before a round trip is measured.
pub const FIRST_ACK_WAIT: Micros = SECOND;
/// A stream arrives when at least this share of the messages due since the request came.
pub const FLOWING_SHARE: f64 = 0.5;
/// Streams silent this long (or three of their intervals) while heartbeats arrive have stopped.
pub const STALE_AFTER: Micros = 4 * SECOND;
/// A link whose last heartbeat is older than this is silent: not worth asking on.
pub const SILENT_AFTER: Micros = 3 * SECOND;
/// Arrivals older than this are not in a measured rate.
pub const MEASURE_WINDOW: Micros = 10 * SECOND;

/// The share of a serial link's bytes that telemetry may take when its baud is known.
///
/// Half. ArduPilot's own parameter download takes up to 30 % of a port's bandwidth
/// (`GCS_Param.cpp`, `queued_param_send`: `bytes_allowed = bw * dt / 3333`), so telemetry at
/// half leaves the parameters their share, and the last fifth for commands, mission transfers,
/// heartbeats and the radio's own framing and retransmissions (a SiK radio at 57600 baud on
/// the serial side is slower than that on the air once its ECC and duty cycle are counted,
/// and a serial port without flow control drops what overflows). The estimate below is the
/// largest each message can be, so the share holds with room to spare.
pub const LINK_SHARE: f64 = 0.5;

/// Bytes MAVLink 2 adds to a payload (10 header, 2 CRC; no signature).
pub const FRAME_OVERHEAD: u32 = 12;

/// One of ArduPilot's REQUEST_DATA_STREAM groups as ArduCopter fills it
/// (`ArduCopter/GCS_Mavlink.cpp`, `STREAM_*_msgs`).
#[derive(Debug, Clone, Copy)]
pub struct Group {
    /// MAV_DATA_STREAM id.
    pub id: u8,
    pub name: &'static str,
    /// Messages that every ArduCopter sends in this group, that a GCS shows: the group counts as
    /// arriving when one of them does, and they are what SET_MESSAGE_INTERVAL asks for when the
    /// group request is ignored.
    pub main: &'static [u32],
    /// What a Cube-class ArduCopter (three IMUs, two barometers, one GPS, a battery monitor)
    /// sends in one round of the group, for the bandwidth estimate. Left out: messages sent
    /// only with hardware most copters lack (RTK, a second GPS, rangefinder, ESC telemetry,
    /// gimbal), in some modes only (POSITION_TARGET_GLOBAL_INT), or in SITL (SIMSTATE).
    pub content: &'static [u32],
}

mod id {
    pub const SYS_STATUS: u32 = 1;
    pub const SYSTEM_TIME: u32 = 2;
    pub const GPS_RAW_INT: u32 = 24;
    pub const RAW_IMU: u32 = 27;
    pub const SCALED_PRESSURE: u32 = 29;
    pub const ATTITUDE: u32 = 30;
    pub const LOCAL_POSITION_NED: u32 = 32;
    pub const GLOBAL_POSITION_INT: u32 = 33;
    pub const SERVO_OUTPUT_RAW: u32 = 36;
    pub const MISSION_CURRENT: u32 = 42;
    pub const NAV_CONTROLLER_OUTPUT: u32 = 62;
    pub const RC_CHANNELS: u32 = 65;
    pub const VFR_HUD: u32 = 74;
    pub const SCALED_IMU2: u32 = 116;
    pub const POWER_STATUS: u32 = 125;
    pub const SCALED_IMU3: u32 = 129;
    pub const SCALED_PRESSURE2: u32 = 137;
    pub const BATTERY_STATUS: u32 = 147;
    pub const MEMINFO: u32 = 152;
    pub const AHRS: u32 = 163;
    pub const AHRS2: u32 = 178;
    pub const EKF_STATUS_REPORT: u32 = 193;
    pub const VIBRATION: u32 = 241;
}

/// ArduPilot's stream groups that mavterm asks for (the ids of [`crate::proto::rates::GROUPS`]).
pub const GROUPS: &[Group] = {
    use id::*;
    &[
        Group {
            id: 1,
            name: "RAW_SENSORS",
            main: &[RAW_IMU, SCALED_PRESSURE],
            content: &[
                RAW_IMU,
                SCALED_IMU2,
                SCALED_IMU3,
                SCALED_PRESSURE,
                SCALED_PRESSURE2,
            ],
        },
        Group {
            id: 2,
            name: "EXTENDED_STATUS",
            main: &[SYS_STATUS, GPS_RAW_INT],
            content: &[
                SYS_STATUS,
                POWER_STATUS,
                MEMINFO,
                MISSION_CURRENT,
                GPS_RAW_INT,
                NAV_CONTROLLER_OUTPUT,
            ],
        },
        Group {
            id: 3,
            name: "RC_CHANNELS",
            main: &[SERVO_OUTPUT_RAW, RC_CHANNELS],
            content: &[SERVO_OUTPUT_RAW, RC_CHANNELS],
        },
        Group {
            id: 6,
            name: "POSITION",
            // LOCAL_POSITION_NED only once the EKF has an origin.
            main: &[GLOBAL_POSITION_INT],
            content: &[GLOBAL_POSITION_INT, LOCAL_POSITION_NED],
        },
        Group {
            id: 10,
            name: "EXTRA1",
            main: &[ATTITUDE],
            content: &[ATTITUDE, AHRS2],
        },
        Group {
            id: 11,
            name: "EXTRA2",
            main: &[VFR_HUD],
            content: &[VFR_HUD],
        },
        Group {
            id: 12,
            name: "EXTRA3",
            main: &[SYSTEM_TIME, EKF_STATUS_REPORT, BATTERY_STATUS],
            content: &[
                AHRS,
                SYSTEM_TIME,
                BATTERY_STATUS,
                EKF_STATUS_REPORT,
                VIBRATION,
            ],
        },
    ]
};

/// The group with MAV_DATA_STREAM id `id`.
pub fn group(id: u8) -> Option<&'static Group> {
    GROUPS.iter().find(|g| g.id == id)
}

/// The group whose main messages hold `msgid`, else the one whose content does.
pub fn group_of(msgid: u32) -> Option<&'static Group> {
    GROUPS
        .iter()
        .find(|g| g.main.contains(&msgid))
        .or_else(|| GROUPS.iter().find(|g| g.content.contains(&msgid)))
}

/// The largest a frame of `msgid` can be (every extension field present), MAVLink 2 unsigned.
pub fn frame_bytes(msgid: u32) -> u32 {
    crate::wire::parser::msg_limits(msgid).map_or(255, |l| l.max_len_v2 as u32) + FRAME_OVERHEAD
}

/// Bytes of one round of group `g` ([`Group::content`]).
pub fn group_bytes(g: &Group) -> u32 {
    g.content.iter().map(|&m| frame_bytes(m)).sum()
}

/// A message's name, or its number.
pub fn msg_name(msgid: u32) -> String {
    use mavlink::Message;
    MavMessage::default_message_from_id(msgid)
        .map(|m| m.message_name().to_string())
        .unwrap_or_else(|| format!("message {msgid}"))
}

/// REQUEST_DATA_STREAM's rate for `hz`: whole Hz, rounded up, at least 1 unless 0.
pub fn group_rate(hz: f32) -> u16 {
    if hz.is_nan() || hz <= 0.0 {
        0
    } else {
        hz.ceil().min(u16::MAX as f32) as u16
    }
}

/// Rates fitted to a link: whole Hz per group, Hz per message.
#[derive(Debug, Clone, PartialEq)]
pub struct Fitted {
    pub groups: Vec<(u8, u16)>,
    pub messages: Vec<(u32, f32)>,
    /// Bytes per second expected at the fitted rates.
    pub bytes_per_second: f64,
    /// The budget when the link's baud is known: [`LINK_SHARE`] of `baud / 10` bytes/s.
    pub budget: Option<f64>,
}

/// The rates to ask on a link: as configured (groups rounded up to whole Hz), and on a serial
/// link whose baud was given, scaled down when the telemetry expected would not fit
/// [`LINK_SHARE`] of it.
///
/// Scaling: messages asked by interval are multiplied by `budget / expected`. Group rates are
/// whole Hz: each starts at its share rounded down (at least 1 Hz, REQUEST_DATA_STREAM cannot
/// ask for less); while that is still too much, 1 Hz is taken from the group closest to its
/// configured rate (relative to it); then the budget left is handed back 1 Hz at a time to the
/// group furthest below its configured rate whose next Hz still fits, up to its configured
/// rate. A link too slow for every group at 1 Hz keeps them at 1 Hz.
pub fn fit_to_link(groups: &[(u8, f32)], messages: &[(u32, f32)], baud: Option<u32>) -> Fitted {
    let gbytes = |g: u8| group(g).map_or(0, group_bytes) as f64;
    let mut gs: Vec<(u8, u16)> = groups
        .iter()
        .map(|&(g, hz)| (g, group_rate(hz)))
        .filter(|&(_, r)| r > 0)
        .collect();
    let mut ms: Vec<(u32, f32)> = messages
        .iter()
        .copied()
        .filter(|&(_, hz)| hz > 0.0 && hz.is_finite())
        .collect();
    let bytes = |gs: &[(u8, u16)], ms: &[(u32, f32)]| {
        gs.iter().map(|&(g, r)| r as f64 * gbytes(g)).sum::<f64>()
            + ms.iter()
                .map(|&(m, hz)| hz as f64 * frame_bytes(m) as f64)
                .sum::<f64>()
    };
    let expected = bytes(&gs, &ms);
    let budget = baud.map(|b| b as f64 / 10.0 * LINK_SHARE);
    let Some(budget) = budget.filter(|&b| expected > b) else {
        return Fitted {
            groups: gs,
            messages: ms,
            bytes_per_second: expected,
            budget,
        };
    };
    let k = budget / expected;
    for m in ms.iter_mut() {
        m.1 = (m.1 as f64 * k) as f32;
    }
    let want: Vec<u16> = gs.iter().map(|&(_, r)| r).collect();
    for (_, r) in gs.iter_mut() {
        *r = ((*r as f64 * k).floor() as u16).max(1);
    }
    // Rounding down to 1 Hz may still be too much: take from the group served best.
    while bytes(&gs, &ms) > budget {
        let most = gs
            .iter()
            .enumerate()
            .filter(|(_, (_, r))| *r > 1)
            .max_by(|(i, (_, a)), (j, (_, b))| {
                let x = *a as f64 / want[*i] as f64;
                let y = *b as f64 / want[*j] as f64;
                x.total_cmp(&y).then(j.cmp(i))
            })
            .map(|(i, _)| i);
        let Some(i) = most else { break };
        gs[i].1 -= 1;
    }
    let mut left = budget - bytes(&gs, &ms);
    loop {
        let next = gs
            .iter()
            .enumerate()
            .filter(|(i, (g, r))| *r < want[*i] && gbytes(*g) <= left)
            .min_by(|(i, (_, a)), (j, (_, b))| {
                let x = *a as f64 / want[*i] as f64;
                let y = *b as f64 / want[*j] as f64;
                x.total_cmp(&y)
            })
            .map(|(i, _)| i);
        let Some(i) = next else { break };
        gs[i].1 += 1;
        left -= gbytes(gs[i].0);
    }
    let total = bytes(&gs, &ms);
    Fitted {
        groups: gs,
        messages: ms,
        bytes_per_second: total,
        budget: Some(budget),
    }
}

/// REQUEST_DATA_STREAM for one stream group.
pub fn request_data_stream(
    target: impl Into<VehicleKey>,
    stream: MavDataStream,
    hz: u16,
    start: bool,
) -> MavMessage {
    let target = target.into();
    MavMessage::REQUEST_DATA_STREAM(dialect::REQUEST_DATA_STREAM_DATA {
        req_message_rate: hz,
        target_system: target.0,
        target_component: target.1,
        req_stream_id: stream,
        start_stop: start as u8,
    })
}

/// COMMAND_LONG MAV_CMD_SET_MESSAGE_INTERVAL (param2 in µs; -1 disables, 0 default rate).
pub fn set_message_interval(
    target: impl Into<VehicleKey>,
    msgid: u32,
    interval_us: f32,
) -> MavMessage {
    let target = target.into();
    MavMessage::COMMAND_LONG(dialect::COMMAND_LONG_DATA {
        target_system: target.0,
        target_component: target.1,
        command: MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
        confirmation: 0,
        param1: msgid as f32,
        param2: interval_us,
        param3: 0.0,
        param4: 0.0,
        param5: 0.0,
        param6: 0.0,
        param7: 0.0,
    })
}

/// What the machine wants done.
#[derive(Debug, Clone, PartialEq)]
#[allow(clippy::large_enum_variant)] // short-lived; boxing every message buys nothing
pub enum StreamOut {
    /// Send on this link (stream rates are per link).
    SendOn(usize, MavMessage),
    /// Tell the operator (severity, text).
    Notice(Severity, String),
}

pub use super::machine::LinkProfile;

/// How a stream is asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// REQUEST_DATA_STREAM of this ArduPilot group.
    Group(u8),
    /// MAV_CMD_SET_MESSAGE_INTERVAL, message by message.
    Interval,
}

impl Method {
    pub fn name(self) -> String {
        match self {
            Method::Group(g) => match group(g) {
                Some(g) => format!("REQUEST_DATA_STREAM {}", g.name),
                None => format!("REQUEST_DATA_STREAM {g}"),
            },
            Method::Interval => "SET_MESSAGE_INTERVAL".into(),
        }
    }
}

/// Where one request stands.
#[derive(Debug, Clone, PartialEq)]
pub enum ItemState {
    /// Its request waits to go out (SET_MESSAGE_INTERVALs go one at a time, and nothing goes on
    /// a silent link).
    Queued,
    /// SET_MESSAGE_INTERVALs sent, waiting for their ACKs.
    Answering,
    /// Asked; counted at `check`.
    Asked { check: Micros },
    /// Arrives at (at least half) the rate asked.
    Flowing,
    /// Neither method brought it; why.
    Failed(String),
}

impl ItemState {
    pub fn name(&self) -> &'static str {
        match self {
            ItemState::Queued => "queued",
            ItemState::Answering => "answering",
            ItemState::Asked { .. } => "asked",
            ItemState::Flowing => "flowing",
            ItemState::Failed(_) => "failed",
        }
    }
}

/// One request on one link: a group, or messages asked one by one at a rate.
#[derive(Debug, Clone)]
struct Item {
    /// The messages it brings that are checked (a group's main ones, or one message).
    msgs: Vec<u32>,
    /// Rate asked, Hz (whole for a group).
    hz: f32,
    /// The group that holds these messages, for a fallback to it (never for PX4).
    group: Option<u8>,
    method: Method,
    state: ItemState,
    /// Requests by the current method.
    asks: u32,
    /// The other method has been tried.
    switched: bool,
    /// This round's SET_MESSAGE_INTERVAL answers: (message, accepted) once answered.
    answers: Vec<(u32, Option<bool>)>,
    /// Why the last answers refused, for the final notice.
    refusal: Option<String>,
    /// When the current request was made (arrivals counted from then).
    since: Micros,
}

/// Arrival times of one message on one link, to measure its rate.
#[derive(Debug, Clone, Default)]
struct Meter {
    times: [Micros; Meter::N],
    len: u8,
    next: u8,
    /// Arrivals since the request that asked for it.
    count: u32,
}

impl Meter {
    const N: usize = 16;

    fn push(&mut self, t: Micros) {
        self.times[self.next as usize] = t;
        self.next = ((self.next as usize + 1) % Self::N) as u8;
        self.len = (self.len + 1).min(Self::N as u8);
        self.count = self.count.saturating_add(1);
    }

    /// Arrivals per second: from the spacing of the last arrivals within [`MEASURE_WINDOW`]; once
    /// the silence since the last one passes two intervals, no more than one per that silence.
    /// 0 with fewer than two.
    fn hz(&self, now: Micros) -> f64 {
        let n = self.len as usize;
        let mut first = None;
        let mut last = 0;
        let mut k = 0u32;
        for i in 0..n {
            let t = self.times[(self.next as usize + Self::N - n + i) % Self::N];
            if t + MEASURE_WINDOW < now {
                continue;
            }
            first.get_or_insert(t);
            last = t;
            k += 1;
        }
        let Some(first) = first.filter(|_| k >= 2) else {
            return 0.0;
        };
        let span = last.saturating_sub(first).max(1) as f64;
        let mean = span / (k - 1) as f64;
        let since = now.saturating_sub(last) as f64;
        let hz = 1e6 / mean;
        if since > 2.0 * mean {
            // Silent for more than two intervals: no faster than one in the silence so far.
            hz.min(1e6 / since)
        } else {
            hz
        }
    }
}

/// A message asked for on a link: the rate asked, and its arrivals.
#[derive(Debug, Clone)]
struct Watch {
    msgid: u32,
    hz: f32,
    meter: Meter,
}

/// Where one link stands, for a screen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinkStreamState {
    /// High latency: nothing is asked.
    HighLatency,
    /// Asked (again) at the next poll when the link is heard.
    Due,
    /// Requests out or being checked.
    Asking,
    /// Everything asked arrives (or failed for good, and something arrives).
    Flowing,
    /// Nothing asked arrives, by either method.
    Failed,
}

impl LinkStreamState {
    pub fn name(self) -> &'static str {
        match self {
            LinkStreamState::HighLatency => "high-latency",
            LinkStreamState::Due => "due",
            LinkStreamState::Asking => "asking",
            LinkStreamState::Flowing => "flowing",
            LinkStreamState::Failed => "failed",
        }
    }
}

#[derive(Debug, Clone)]
struct LinkStreams {
    profile: LinkProfile,
    /// Ask everything afresh at the next poll.
    due: bool,
    last_heartbeat: Micros,
    /// Since when heartbeats have arrived without a gap and without telemetry.
    quiet_since: Option<Micros>,
    items: Vec<Item>,
    watch: Vec<Watch>,
    /// For each id below 512, its place in `watch` plus one (0: not watched); the ids above
    /// are looked for in `watch`.
    watch_at: [u8; 512],
    /// SET_MESSAGE_INTERVALs waiting their turn: (item, message).
    queue: VecDeque<(usize, u32)>,
    /// Requests sent on this link, all told.
    requests: u32,
    /// The fitted rates' expected bytes per second, and the link's budget.
    load: (f64, Option<f64>),
}

impl LinkStreams {
    /// Where message `id` is in `watch`, if it is watched.
    #[inline]
    fn watched(&self, id: u32) -> Option<usize> {
        match self.watch_at.get(id as usize) {
            Some(0) => None,
            Some(&at)
                if (at as usize) <= self.watch.len() && self.watch[at as usize - 1].msgid == id =>
            {
                Some(at as usize - 1)
            }
            _ => self.watch.iter().position(|w| w.msgid == id),
        }
    }
}

/// The one SET_MESSAGE_INTERVAL waiting for its ACK.
#[derive(Debug, Clone, Copy)]
struct Pending {
    link: usize,
    item: usize,
    msgid: u32,
    interval_us: f32,
    sent: Micros,
    sends: u32,
}

/// One requested message on one link, for a screen or a report.
#[derive(Debug, Clone, PartialEq)]
pub struct StreamInfo {
    pub msgid: u32,
    pub requested_hz: f32,
    pub measured_hz: f64,
    pub method: Method,
    pub state: ItemState,
}

/// Stream requests for one autopilot, per link.
#[derive(Debug, Clone)]
pub struct StreamMachine {
    target: VehicleKey,
    autopilot: MavAutopilot,
    /// Off when the operator asked mavterm not to request streams.
    enabled: bool,
    rates: StreamRates,
    links: BTreeMap<usize, LinkStreams>,
    pending: Option<Pending>,
    /// The operator's SET_MESSAGE_INTERVAL waits in the command queue: send none of ours.
    held: bool,
    /// The last time the machine saw (a message, an ACK, a poll).
    seen: Micros,
    /// Smoothed ACK round trip.
    srtt: Option<Micros>,
}

impl StreamMachine {
    pub fn new(
        target: impl Into<VehicleKey>,
        autopilot: MavAutopilot,
        enabled: bool,
        rates: StreamRates,
    ) -> Self {
        Self {
            target: target.into(),
            autopilot,
            enabled,
            rates,
            links: BTreeMap::new(),
            pending: None,
            held: false,
            seen: 0,
            srtt: None,
        }
    }

    /// How this autopilot's family takes stream requests.
    fn profile(&self) -> &'static dyn crate::proto::profile::Profile {
        crate::proto::profile::of(self.autopilot)
    }

    /// The state on each link heard.
    pub fn link_states(&self) -> impl Iterator<Item = (usize, LinkStreamState)> + '_ {
        self.links.iter().map(|(l, s)| (*l, link_state(s)))
    }

    /// The state on `link`, if heard.
    pub fn link_state(&self, link: usize) -> Option<LinkStreamState> {
        self.links.get(&link).map(link_state)
    }

    /// Requests sent on `link`, all told (each REQUEST_DATA_STREAM and each send of a
    /// SET_MESSAGE_INTERVAL).
    pub fn requests_sent(&self, link: usize) -> u32 {
        self.links.get(&link).map_or(0, |s| s.requests)
    }

    /// The messages asked for on `link` and the rate asked for each, Hz.
    pub fn requested(&self, link: usize) -> impl Iterator<Item = (u32, f32)> + '_ {
        self.links
            .get(&link)
            .into_iter()
            .flat_map(|s| s.watch.iter().map(|w| (w.msgid, w.hz)))
    }

    /// The measured rate of `msgid` on `link`, Hz, if it was asked for there.
    pub fn measured(&self, now: Micros, link: usize, msgid: u32) -> Option<f64> {
        let s = self.links.get(&link)?;
        s.watch
            .iter()
            .find(|w| w.msgid == msgid)
            .map(|w| w.meter.hz(now))
    }

    /// Every message asked for on `link`: rate asked and measured, how, and how it stands.
    pub fn report(&self, now: Micros, link: usize) -> Vec<StreamInfo> {
        let Some(s) = self.links.get(&link) else {
            return Vec::new();
        };
        s.watch
            .iter()
            .map(|w| {
                let item = s.items.iter().rev().find(|i| i.msgs.contains(&w.msgid));
                StreamInfo {
                    msgid: w.msgid,
                    requested_hz: w.hz,
                    measured_hz: w.meter.hz(now),
                    method: item.map_or(Method::Interval, |i| i.method),
                    state: item.map_or(ItemState::Queued, |i| i.state.clone()),
                }
            })
            .collect()
    }

    /// The telemetry expected on `link` at the rates asked (bytes/s), and the budget of a link
    /// whose baud is known.
    pub fn load(&self, link: usize) -> Option<(f64, Option<f64>)> {
        self.links.get(&link).map(|s| s.load)
    }

    /// The operator's own SET_MESSAGE_INTERVAL to this autopilot waits for its ACK: send none of
    /// ours until it is answered (the ACK could not be told apart).
    pub fn hold_intervals(&mut self, held: bool) {
        self.held = held;
    }

    /// A frame from the target component heard on `link` (a link of kind `profile`): its message
    /// id, and the heartbeat when it is one. Telemetry is told by its id alone, so a message our
    /// dialect cannot decode (an enum value newer than ours) still counts.
    pub fn on_message(
        &mut self,
        now: Micros,
        link: usize,
        profile: LinkProfile,
        id: u32,
        heartbeat: Option<&dialect::HEARTBEAT_DATA>,
    ) {
        self.seen = self.seen.max(now);
        // A link heard before (every message after its first) is found without an entry.
        let entry = match self.links.get_mut(&link) {
            Some(e) => e,
            None => self.links.entry(link).or_insert_with(|| LinkStreams {
                profile,
                due: !profile.hl,
                last_heartbeat: now,
                quiet_since: None,
                items: Vec::new(),
                watch: Vec::new(),
                watch_at: [0; 512],
                queue: VecDeque::new(),
                requests: 0,
                load: (0.0, None),
            }),
        };
        if let Some(hb) = heartbeat {
            self.autopilot = hb.autopilot;
            // Heartbeats with no telemetry, without the link going silent in between (a fade
            // stops both, and what resumes together asks nothing).
            let gap = now.saturating_sub(entry.last_heartbeat) >= SILENT_AFTER;
            if gap || entry.quiet_since.is_none() {
                entry.quiet_since = Some(now);
            }
            entry.last_heartbeat = now;
            // Streams that stopped while heartbeats go on: the vehicle forgot them.
            let fastest = entry
                .items
                .iter()
                .filter(|i| i.state == ItemState::Flowing && !i.msgs.is_empty())
                .map(|i| i.hz)
                .fold(0.0f32, f32::max);
            if fastest > 0.0 {
                let stale = STALE_AFTER.max((3e6 / fastest as f64) as Micros);
                if entry
                    .quiet_since
                    .is_some_and(|t| now.saturating_sub(t) >= stale)
                {
                    entry.due = true;
                }
            }
        } else if let Some(w) = entry.watched(id) {
            let w = &mut entry.watch[w];
            w.meter.push(now);
            entry.quiet_since = None;
        }
    }

    /// A message `id` on `link`, not a heartbeat or an ACK: counted against its rate when it is
    /// one this machine measures there (`Some(true)`), passed by when not (`Some(false)`);
    /// `None` for a link not heard yet, which [`StreamMachine::on_message`] must meet (the
    /// session hands it any message of such a link). One lookup.
    #[inline]
    pub fn count(&mut self, now: Micros, link: usize, id: u32) -> Option<bool> {
        let entry = self.links.get_mut(&link)?;
        let Some(w) = entry.watched(id) else {
            return Some(false);
        };
        self.seen = self.seen.max(now);
        entry.watch[w].meter.push(now);
        entry.quiet_since = None;
        Some(true)
    }

    /// A COMMAND_ACK of MAV_CMD_SET_MESSAGE_INTERVAL from the target: `None` when none of ours
    /// waits (it is the command queue's), else what follows from it.
    pub fn on_ack(&mut self, now: Micros, command: u16, result: u8) -> Option<Vec<StreamOut>> {
        self.seen = self.seen.max(now);
        if command != MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL as u16 {
            return None;
        }
        let p = self.pending?;
        if result == MavResult::MAV_RESULT_IN_PROGRESS as u8 {
            return Some(Vec::new()); // the final answer follows
        }
        self.pending = None;
        if p.sends == 1 {
            let rtt = now.saturating_sub(p.sent);
            self.srtt = Some(self.srtt.map_or(rtt, |s| (7 * s + rtt) / 8));
        }
        let mut out = Vec::new();
        let accepted = result == MavResult::MAV_RESULT_ACCEPTED as u8;
        if !accepted {
            let why = crate::proto::ack::result_name(result);
            out.push(StreamOut::Notice(
                Severity::WARNING,
                format!(
                    "{} refused SET_MESSAGE_INTERVAL {} at {} Hz on link {}: {why}",
                    self.target,
                    msg_name(p.msgid),
                    hz_text(1e6 / p.interval_us as f64),
                    p.link
                ),
            ));
            if let Some(item) = self.item_mut(p.link, p.item) {
                item.refusal = Some(why);
            }
        }
        self.answered(now, p.link, p.item, p.msgid, accepted, &mut out);
        Some(out)
    }

    fn item_mut(&mut self, link: usize, item: usize) -> Option<&mut Item> {
        self.links.get_mut(&link)?.items.get_mut(item)
    }

    /// The answer (or the lack of one) to the SET_MESSAGE_INTERVAL of `msgid` for `item`.
    fn answered(
        &mut self,
        now: Micros,
        link: usize,
        item: usize,
        msgid: u32,
        accepted: bool,
        out: &mut Vec<StreamOut>,
    ) {
        let Some(it) = self.item_mut(link, item) else {
            return;
        };
        if it.state != ItemState::Answering || it.method != Method::Interval {
            return; // asked afresh since
        }
        if let Some(a) = it.answers.iter_mut().find(|(m, _)| *m == msgid) {
            a.1 = Some(accepted);
        }
        if it.answers.iter().any(|(_, a)| a.is_none()) {
            return;
        }
        if it.answers.iter().any(|(_, a)| *a == Some(true)) {
            let check = now + check_wait(it.hz);
            it.state = ItemState::Asked { check };
            it.since = now;
            let msgs = it.msgs.clone();
            self.reset_counts(link, &msgs);
        } else {
            // Every message refused or unanswered: the other method, if there is one.
            self.switch_or_fail(link, item, out);
        }
    }

    fn reset_counts(&mut self, link: usize, msgs: &[u32]) {
        if let Some(s) = self.links.get_mut(&link) {
            for w in s.watch.iter_mut().filter(|w| msgs.contains(&w.msgid)) {
                w.meter.count = 0;
            }
        }
    }

    /// The vehicle rebooted: ask again on every link.
    pub fn on_reboot(&mut self) {
        self.pending = None;
        for s in self.links.values_mut() {
            s.due = !s.profile.hl;
        }
    }

    /// `link` reconnected: ask again on it.
    pub fn on_link_reconnected(&mut self, link: usize) {
        if self.pending.is_some_and(|p| p.link == link) {
            self.pending = None;
        }
        if let Some(s) = self.links.get_mut(&link) {
            s.due = !s.profile.hl;
        }
    }

    fn ack_wait(&self) -> Micros {
        self.srtt.map_or(FIRST_ACK_WAIT, |r| {
            (4 * r).clamp(MIN_ACK_WAIT, MAX_ACK_WAIT)
        })
    }

    /// What to ask on a link of kind `profile`: the requests, and the messages to watch.
    fn plan(&self, profile: LinkProfile) -> (Vec<Item>, (f64, Option<f64>)) {
        // ArduPilot: its groups first and its own message list; others by interval.
        let ardupilot = self.profile().stream_groups();
        let by_interval: Vec<(u32, f32)> = if ardupilot {
            self.rates
                .ardupilot_messages
                .iter()
                .map(|(m, h)| (*m, *h))
                .collect()
        } else {
            self.rates.messages.iter().map(|(m, h)| (*m, *h)).collect()
        };
        let groups: Vec<(u8, f32)> = if ardupilot {
            self.rates
                .groups
                .iter()
                .filter(|(g, _)| MavDataStream::from_u8(**g).is_some())
                .map(|(g, h)| (*g, *h))
                .collect()
        } else {
            Vec::new()
        };
        let fitted = fit_to_link(&groups, &by_interval, profile.baud);
        let item = |msgs: Vec<u32>, hz: f32, group: Option<u8>, method: Method| Item {
            msgs,
            hz,
            group,
            method,
            state: ItemState::Queued,
            asks: 0,
            switched: false,
            answers: Vec::new(),
            refusal: None,
            since: 0,
        };
        let mut items = Vec::new();
        for &(g, rate) in &fitted.groups {
            // A message also asked by interval is that request's to check.
            let msgs = group(g)
                .map(|g| g.main.to_vec())
                .unwrap_or_default()
                .into_iter()
                .filter(|m| !fitted.messages.iter().any(|(x, _)| x == m))
                .collect();
            items.push(item(msgs, rate as f32, Some(g), Method::Group(g)));
        }
        for &(m, hz) in &fitted.messages {
            let g = if !self.profile().group_fallback() {
                None
            } else {
                group_of(m).map(|g| g.id)
            };
            items.push(item(vec![m], hz, g, Method::Interval));
        }
        (items, (fitted.bytes_per_second, fitted.budget))
    }

    /// Ask `item` of `link` (again) by its current method.
    fn ask(&mut self, link: usize, index: usize) {
        let Some(s) = self.links.get_mut(&link) else {
            return;
        };
        let it = &mut s.items[index];
        it.asks += 1;
        it.state = ItemState::Queued;
        if it.method == Method::Interval {
            it.answers = it.msgs.iter().map(|&m| (m, None)).collect();
            it.refusal = None;
            for &m in &it.msgs {
                s.queue.push_back((index, m));
            }
            if it.msgs.is_empty() {
                it.state = ItemState::Flowing;
            } else {
                it.state = ItemState::Answering;
            }
        }
    }

    /// `item` did not come by its method: the other one, or give up and say so.
    fn switch_or_fail(&mut self, link: usize, index: usize, out: &mut Vec<StreamOut>) {
        let no_groups = !self.profile().group_fallback();
        let target = self.target;
        let Some(s) = self.links.get_mut(&link) else {
            return;
        };
        let it = &mut s.items[index];
        let names = it
            .msgs
            .iter()
            .map(|&m| msg_name(m))
            .collect::<Vec<_>>()
            .join(", ");
        let other = match it.method {
            Method::Group(_) => Some(Method::Interval),
            Method::Interval => it.group.filter(|_| !no_groups).map(Method::Group),
        };
        let Some(m) = other.filter(|_| !it.switched) else {
            let why = match &it.refusal {
                Some(r) => format!("refused ({r})"),
                None => "not arriving".into(),
            };
            let how = if it.switched {
                "by REQUEST_DATA_STREAM and SET_MESSAGE_INTERVAL"
            } else {
                match it.method {
                    Method::Group(_) => "by REQUEST_DATA_STREAM",
                    Method::Interval => "by SET_MESSAGE_INTERVAL",
                }
            };
            out.push(StreamOut::Notice(
                Severity::WARNING,
                format!(
                    "no {names} from {target} on link {link}: asked at {} Hz {how}, {why}",
                    hz_text(it.hz as f64)
                ),
            ));
            it.state = ItemState::Failed(why);
            return;
        };
        out.push(StreamOut::Notice(
            Severity::NOTICE,
            format!(
                "{target} on link {link}: {names} not arriving by {}; asking by {}",
                it.method.name(),
                m.name()
            ),
        ));
        if let Method::Group(_) = m {
            it.hz = group_rate(it.hz) as f32;
        }
        it.method = m;
        it.switched = true;
        it.asks = 0;
        let (msgs, hz) = (it.msgs.clone(), it.hz);
        for w in s.watch.iter_mut().filter(|w| msgs.contains(&w.msgid)) {
            w.hz = hz;
        }
        self.ask(link, index);
    }

    /// Send what is due at `now`.
    pub fn poll(&mut self, now: Micros) -> Vec<StreamOut> {
        self.seen = self.seen.max(now);
        let mut out = Vec::new();
        if !self.enabled {
            return out;
        }
        let target = self.target;
        let links: Vec<usize> = self.links.keys().copied().collect();
        for link in links {
            let silent = {
                let s = &self.links[&link];
                if s.profile.hl {
                    continue;
                }
                now.saturating_sub(s.last_heartbeat) >= SILENT_AFTER
            };
            if silent {
                // A check that falls while nothing is heard says nothing: everything is asked
                // again when the link is heard.
                let s = self.links.get_mut(&link).expect("present");
                if s.items
                    .iter()
                    .any(|i| matches!(i.state, ItemState::Asked { check } if check <= now))
                {
                    s.due = true;
                    for i in s.items.iter_mut() {
                        i.state = ItemState::Queued;
                    }
                }
                continue;
            }
            if self.links[&link].due {
                let profile = self.links[&link].profile;
                let (items, load) = self.plan(profile);
                if self.pending.is_some_and(|p| p.link == link) {
                    self.pending = None;
                }
                let s = self.links.get_mut(&link).expect("present");
                s.due = false;
                s.quiet_since = None;
                s.load = load;
                s.queue.clear();
                // Arrivals measured before stay: a rate that did not change is still known.
                let old: Vec<Watch> = std::mem::take(&mut s.watch);
                for it in &items {
                    for &m in &it.msgs {
                        let meter = old
                            .iter()
                            .find(|w| w.msgid == m)
                            .map(|w| w.meter.clone())
                            .unwrap_or_default();
                        s.watch.push(Watch {
                            msgid: m,
                            hz: it.hz,
                            meter,
                        });
                    }
                }
                s.watch_at = [0; 512];
                for (i, w) in s.watch.iter().enumerate() {
                    if let (Some(at), Ok(i)) =
                        (s.watch_at.get_mut(w.msgid as usize), u8::try_from(i + 1))
                    {
                        *at = i;
                    }
                }
                s.items = items;
                for i in 0..self.links[&link].items.len() {
                    self.ask(link, i);
                }
            }
            // Checks that are due.
            for i in 0..self.links[&link].items.len() {
                let s = &self.links[&link];
                let it = &s.items[i];
                let ItemState::Asked { check } = it.state else {
                    continue;
                };
                if now < check {
                    continue;
                }
                let elapsed = now.saturating_sub(it.since) as f64 / 1e6;
                let need = ((FLOWING_SHARE * it.hz as f64 * elapsed).floor() as u32).max(1);
                let came = s
                    .watch
                    .iter()
                    .filter(|w| it.msgs.contains(&w.msgid))
                    .any(|w| w.meter.count >= need);
                let asks = it.asks;
                if came {
                    self.links.get_mut(&link).expect("present").items[i].state = ItemState::Flowing;
                } else if asks < ASKS {
                    self.ask(link, i);
                } else {
                    self.switch_or_fail(link, i, &mut out);
                }
            }
            // Group requests go at once (ArduPilot does not acknowledge them).
            let s = self.links.get_mut(&link).expect("present");
            for it in s.items.iter_mut() {
                let (Method::Group(g), ItemState::Queued) = (it.method, &it.state) else {
                    continue;
                };
                let Some(stream) = MavDataStream::from_u8(g) else {
                    it.state = ItemState::Failed("unknown group".into());
                    continue;
                };
                out.push(StreamOut::SendOn(
                    link,
                    request_data_stream(target, stream, group_rate(it.hz), true),
                ));
                s.requests += 1;
                it.since = now;
                it.state = if it.msgs.is_empty() {
                    ItemState::Flowing // nothing of it to count
                } else {
                    ItemState::Asked {
                        check: now + check_wait(it.hz),
                    }
                };
                for w in s.watch.iter_mut().filter(|w| it.msgs.contains(&w.msgid)) {
                    w.meter.count = 0;
                }
            }
        }
        self.poll_interval(now, &mut out);
        out
    }

    /// The SET_MESSAGE_INTERVAL in flight: resent or given up when unanswered; the next one
    /// sent when none is.
    fn poll_interval(&mut self, now: Micros, out: &mut Vec<StreamOut>) {
        let wait = self.ack_wait();
        if let Some(p) = self.pending {
            if now < p.sent + wait {
                return;
            }
            let silent = self
                .links
                .get(&p.link)
                .is_none_or(|s| now.saturating_sub(s.last_heartbeat) >= SILENT_AFTER);
            if silent {
                // Nothing heard: it goes again, uncounted, when the link is.
                self.pending = None;
                if let Some(s) = self.links.get_mut(&p.link) {
                    s.queue.push_front((p.item, p.msgid));
                }
            } else if p.sends < INTERVAL_SENDS {
                self.send_interval(now, p, out);
            } else {
                self.pending = None;
                out.push(StreamOut::Notice(
                    Severity::WARNING,
                    format!(
                        "no answer from {} to SET_MESSAGE_INTERVAL {} on link {} ({} sends)",
                        self.target,
                        msg_name(p.msgid),
                        p.link,
                        p.sends
                    ),
                ));
                if let Some(item) = self.item_mut(p.link, p.item) {
                    item.refusal = Some("no answer".into());
                }
                self.answered(now, p.link, p.item, p.msgid, false, out);
            }
            if self.pending.is_some() {
                return;
            }
        }
        if self.held {
            return;
        }
        // The next one: the first link heard with one waiting.
        let next = self.links.iter_mut().find_map(|(&link, s)| {
            if now.saturating_sub(s.last_heartbeat) >= SILENT_AFTER {
                return None;
            }
            loop {
                let (item, msgid) = s.queue.pop_front()?;
                let it = &s.items[item];
                if it.state == ItemState::Answering && it.method == Method::Interval {
                    return Some(Pending {
                        link,
                        item,
                        msgid,
                        interval_us: (1e6 / it.hz as f64) as f32,
                        sent: now,
                        sends: 0,
                    });
                }
            }
        });
        if let Some(p) = next {
            self.send_interval(now, p, out);
        }
    }

    fn send_interval(&mut self, now: Micros, mut p: Pending, out: &mut Vec<StreamOut>) {
        p.sends += 1;
        p.sent = now;
        out.push(StreamOut::SendOn(
            p.link,
            set_message_interval(self.target, p.msgid, p.interval_us),
        ));
        if let Some(s) = self.links.get_mut(&p.link) {
            s.requests += 1;
        }
        self.pending = Some(p);
    }

    /// When [`StreamMachine::poll`] next has something to do.
    pub fn next_deadline(&self) -> Option<Micros> {
        if !self.enabled {
            return None;
        }
        let checks = self.links.values().flat_map(|s| {
            s.items.iter().filter_map(|i| match i.state {
                ItemState::Asked { check } => Some(check),
                _ => None,
            })
        });
        let ack = self.pending.map(|p| p.sent + self.ack_wait());
        checks.chain(ack).chain(self.untimed()).min()
    }

    /// Work that is not on a timer (a link to set up, group requests, the next
    /// SET_MESSAGE_INTERVAL): due at the last time the machine saw, for the links a poll then
    /// acts on (heard lately; not high-latency for setups and groups; the queue while none is
    /// in flight or held), so a poll always takes it and it never stays in the past.
    fn untimed(&self) -> Option<Micros> {
        if !self.enabled {
            return None;
        }
        let heard = |s: &&LinkStreams| self.seen.saturating_sub(s.last_heartbeat) < SILENT_AFTER;
        let setup = self
            .links
            .values()
            .filter(heard)
            .filter(|s| !s.profile.hl)
            .any(|s| {
                s.due
                    || s.items
                        .iter()
                        .any(|i| i.state == ItemState::Queued && i.method != Method::Interval)
            });
        let queue = self.pending.is_none()
            && !self.held
            && self
                .links
                .values()
                .filter(heard)
                .any(|s| !s.queue.is_empty());
        (setup || queue).then_some(self.seen)
    }
}

impl StreamMachine {
    /// Work waiting that is not on a timer, whether a poll can take it now or not.
    #[cfg(test)]
    fn waiting(&self) -> bool {
        self.enabled
            && (self.links.values().any(|s| {
                s.due
                    || s.items
                        .iter()
                        .any(|i| i.state == ItemState::Queued && i.method != Method::Interval)
            }) || (self.pending.is_none() && self.links.values().any(|s| !s.queue.is_empty())))
    }

    fn emit(outs: Vec<StreamOut>, out: &mut Vec<Out>) {
        out.extend(outs.into_iter().map(|o| match o {
            StreamOut::SendOn(l, m) => Out::send(Route::Link(l), m),
            StreamOut::Notice(s, t) => Out::notice(s, t),
        }));
    }
}

impl Machine for StreamMachine {
    /// Heartbeats and ACKs; the messages whose arrivals are counted against the rates asked
    /// come by [`StreamMachine::count`], per link.
    const IDS: Ids = Ids::Only(&[
        <dialect::HEARTBEAT_DATA as mavlink::MessageData>::ID,
        <dialect::COMMAND_ACK_DATA as mavlink::MessageData>::ID,
    ]);
    /// Only the heartbeat is read decoded, the ACK as [`Incoming::ack`].
    const DECODES: Ids = Ids::Only(&[<dialect::HEARTBEAT_DATA as mavlink::MessageData>::ID]);

    /// Every message; a COMMAND_ACK of MAV_CMD_SET_MESSAGE_INTERVAL while one of its own waits
    /// is its answer (see [`Machine::claims`]).
    fn on_message(&mut self, m: &Incoming, out: &mut Vec<Out>) {
        StreamMachine::on_message(self, m.now, m.link, m.profile, m.id, m.heartbeat());
        if let Some(o) = m.ack.and_then(|a| self.on_ack(m.now, a.command, a.result)) {
            Self::emit(o, out);
        }
    }

    /// The ACK of its own SET_MESSAGE_INTERVAL: one waits (it went before any of the
    /// operator's: the machine sends none while one of those is open).
    fn claims(&self, m: &Incoming) -> bool {
        m.ack.is_some_and(|a| {
            a.command == MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL as u16 && self.pending.is_some()
        })
    }

    fn poll(&mut self, now: Micros, out: &mut Vec<Out>) {
        let o = StreamMachine::poll(self, now);
        Self::emit(o, out);
    }

    fn next_deadline(&self) -> Option<Micros> {
        StreamMachine::next_deadline(self)
    }
}

fn link_state(s: &LinkStreams) -> LinkStreamState {
    if s.profile.hl {
        return LinkStreamState::HighLatency;
    }
    if s.due || s.items.is_empty() {
        return LinkStreamState::Due;
    }
    let flowing = s.items.iter().any(|i| i.state == ItemState::Flowing);
    let settled = s
        .items
        .iter()
        .all(|i| matches!(i.state, ItemState::Flowing | ItemState::Failed(_)));
    match (settled, flowing) {
        (true, true) => LinkStreamState::Flowing,
        (true, false) => LinkStreamState::Failed,
        _ => LinkStreamState::Asking,
    }
}

/// How long after a request at `hz` it is counted: [`CHECK_AFTER`], or three intervals.
fn check_wait(hz: f32) -> Micros {
    let three = if hz > 0.0 {
        (3e6 / hz as f64) as Micros
    } else {
        0
    };
    CHECK_AFTER.max(three)
}

fn hz_text(hz: f64) -> String {
    if (hz - hz.round()).abs() < 1e-3 {
        format!("{}", hz.round())
    } else {
        format!("{hz:.2}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dialect::{MavModeFlag, MavState, MavType};

    const T: (u8, u8) = (1, 1);
    const AP: MavAutopilot = MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA;
    const PX4: MavAutopilot = MavAutopilot::MAV_AUTOPILOT_PX4;
    const NET: LinkProfile = LinkProfile {
        hl: false,
        baud: None,
    };
    const ACCEPTED: u8 = MavResult::MAV_RESULT_ACCEPTED as u8;
    const DENIED: u8 = MavResult::MAV_RESULT_DENIED as u8;
    const SMI: u16 = MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL as u16;

    fn hb(autopilot: MavAutopilot) -> dialect::HEARTBEAT_DATA {
        dialect::HEARTBEAT_DATA {
            custom_mode: 0,
            mavtype: MavType::MAV_TYPE_QUADROTOR,
            autopilot,
            base_mode: MavModeFlag::empty(),
            system_status: MavState::MAV_STATE_STANDBY,
            mavlink_version: 3,
        }
    }

    /// What was sent: a group request (link, group, Hz) or an interval (link, msgid, Hz).
    #[derive(Debug, Clone, Copy, PartialEq)]
    enum Req {
        Group(usize, u8, u16),
        Interval(usize, u32, f32),
    }

    fn req(link: usize, m: &MavMessage) -> Req {
        match m {
            MavMessage::REQUEST_DATA_STREAM(d) => {
                assert_eq!((d.target_system, d.target_component), T);
                assert_eq!(d.start_stop, 1);
                Req::Group(link, d.req_stream_id as u8, d.req_message_rate)
            }
            MavMessage::COMMAND_LONG(c) => {
                assert_eq!(c.command, MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL);
                assert_eq!((c.target_system, c.target_component), T);
                Req::Interval(link, c.param1 as u32, (1e6 / c.param2 as f64) as f32)
            }
            other => panic!("unexpected {other:?}"),
        }
    }

    /// A vehicle as the machine sees it: it honours group requests or not, answers intervals
    /// with `ack` (or not at all), sends what it was asked at the rate asked, per link, and
    /// heartbeats every second.
    struct Rig {
        m: StreamMachine,
        autopilot: MavAutopilot,
        now: Micros,
        links: Vec<(usize, LinkProfile)>,
        groups: bool,
        intervals: bool,
        /// Interval answer; `None` = never answer.
        ack: Option<u8>,
        /// ACK round trip.
        rtt: Micros,
        acks_due: Vec<(Micros, u8)>,
        /// (link, msgid) → (interval, next due).
        streaming: BTreeMap<(usize, u32), (Micros, Micros)>,
        /// Everything asked, in order, with the time.
        asked: Vec<(Micros, Req)>,
        notices: Vec<(Severity, String)>,
        /// Intervals sent while another waited for its ACK.
        overlaps: u32,
        waiting: bool,
        /// Nothing at all comes (a fade) while true.
        silent: bool,
        /// Heartbeats only (streams forgotten) while true.
        forgot: bool,
    }

    impl Rig {
        fn new(autopilot: MavAutopilot, rates: StreamRates) -> Rig {
            Rig {
                m: StreamMachine::new(T, autopilot, true, rates),
                autopilot,
                now: 0,
                links: vec![(0, NET)],
                groups: true,
                intervals: true,
                ack: Some(ACCEPTED),
                rtt: 50_000,
                acks_due: Vec::new(),
                streaming: BTreeMap::new(),
                asked: Vec::new(),
                notices: Vec::new(),
                overlaps: 0,
                waiting: false,
                silent: false,
                forgot: false,
            }
        }

        fn take(&mut self, out: Vec<StreamOut>) {
            for o in out {
                match o {
                    StreamOut::SendOn(link, m) => {
                        let r = req(link, &m);
                        self.asked.push((self.now, r));
                        if self.silent {
                            continue;
                        }
                        match r {
                            Req::Group(l, g, hz) if self.groups => {
                                for &msg in group(g).unwrap().content {
                                    let iv = 1_000_000 / hz as Micros;
                                    self.streaming.insert((l, msg), (iv, self.now));
                                }
                            }
                            Req::Interval(l, msg, hz) => {
                                if self.waiting {
                                    self.overlaps += 1;
                                }
                                if let Some(a) = self.ack {
                                    self.waiting = true;
                                    self.acks_due.push((self.now + self.rtt, a));
                                }
                                if self.intervals && self.ack == Some(ACCEPTED) {
                                    let iv = (1e6 / hz as f64) as Micros;
                                    self.streaming.insert((l, msg), (iv, self.now));
                                }
                            }
                            _ => {}
                        }
                    }
                    StreamOut::Notice(s, t) => self.notices.push((s, t)),
                }
            }
        }

        /// Run to `until` in 10 ms steps.
        fn run(&mut self, until: Micros) {
            while self.now < until {
                self.now += 10_000;
                let now = self.now;
                if !self.silent {
                    if now.is_multiple_of(SECOND) {
                        let h = hb(self.autopilot);
                        for &(l, p) in &self.links.clone() {
                            self.m.on_message(now, l, p, 0, Some(&h));
                        }
                    }
                    let due: Vec<(Micros, u8)> = self
                        .acks_due
                        .iter()
                        .copied()
                        .filter(|a| a.0 <= now)
                        .collect();
                    self.acks_due.retain(|a| a.0 > now);
                    for (_, a) in due {
                        self.waiting = false;
                        let o = self.m.on_ack(now, SMI, a).unwrap_or_default();
                        self.take(o);
                    }
                    if !self.forgot {
                        let profiles: BTreeMap<usize, LinkProfile> =
                            self.links.iter().copied().collect();
                        for (&(l, msg), (iv, next)) in self.streaming.iter_mut() {
                            if *next <= now {
                                *next += *iv;
                                if let Some(&p) = profiles.get(&l) {
                                    self.m.on_message(now, l, p, msg, None);
                                }
                            }
                        }
                    }
                }
                let o = self.m.poll(now);
                self.take(o);
            }
        }

        fn groups_asked(&self, link: usize) -> Vec<(u8, u16)> {
            self.asked
                .iter()
                .filter_map(|(_, r)| match *r {
                    Req::Group(l, g, hz) if l == link => Some((g, hz)),
                    _ => None,
                })
                .collect()
        }

        fn intervals_asked(&self) -> Vec<(u32, f32)> {
            self.asked
                .iter()
                .filter_map(|(_, r)| match *r {
                    Req::Interval(_, m, hz) => Some((m, hz)),
                    _ => None,
                })
                .collect()
        }

        fn notice(&self, text: &str) -> bool {
            self.notices.iter().any(|(_, t)| t.contains(text))
        }
    }

    fn defaults() -> StreamRates {
        StreamRates::default()
    }

    #[test]
    fn ardupilot_gets_each_group_at_its_rate_then_its_extra_messages_by_interval() {
        let mut rates = defaults();
        rates.groups.insert(1, 0.5); // rounded up to 1 Hz
        rates.groups.insert(3, 0.0); // not asked
        rates.groups.insert(6, 2.2); // 3 Hz
        rates.ardupilot_messages.insert(245, 1.0); // EXTENDED_SYS_STATE
        rates.ardupilot_messages.insert(242, 0.2); // HOME_POSITION
        let mut r = Rig::new(AP, rates);
        r.run(100_000);
        // Heard at 0? The first heartbeat is at 1 s.
        assert!(r.asked.is_empty());
        r.run(SECOND + 10_000);
        assert_eq!(
            r.groups_asked(0),
            vec![(1, 1), (2, 2), (6, 3), (10, 10), (11, 10), (12, 3)]
        );
        // Groups first, then one interval at a time, in id order.
        let firsts: Vec<(Micros, Req)> = r.asked.iter().copied().take(7).collect();
        assert!(
            matches!(firsts[6].1, Req::Interval(0, 242, _)),
            "{firsts:?}"
        );
        r.run(3 * SECOND);
        let iv = r.intervals_asked();
        assert_eq!(iv.len(), 2, "{iv:?}");
        assert_eq!(iv[0].0, 242);
        assert!((iv[0].1 - 0.2).abs() < 1e-3);
        assert_eq!(iv[1], (245, 1.0));
        assert_eq!(r.overlaps, 0);
        // Everything flows: nothing more is asked.
        r.run(30 * SECOND);
        assert_eq!(r.asked.len(), 8, "{:?}", r.asked);
        assert_eq!(r.m.link_state(0), Some(LinkStreamState::Flowing));
        assert!(r.notices.is_empty(), "{:?}", r.notices);
    }

    #[test]
    fn px4_gets_set_message_interval_only_one_at_a_time() {
        let mut r = Rig::new(PX4, defaults());
        r.rtt = 300_000;
        r.run(SECOND + 10_000);
        assert_eq!(r.intervals_asked().len(), 1, "one, then wait for its ACK");
        r.run(10 * SECOND);
        assert!(r.groups_asked(0).is_empty());
        let asked = r.intervals_asked();
        let want: Vec<(u32, f32)> = defaults().messages.into_iter().collect();
        assert_eq!(asked, want);
        assert_eq!(r.overlaps, 0);
        // Each went a round trip after the previous one.
        let times: Vec<Micros> = r.asked.iter().map(|(t, _)| *t).collect();
        for w in times.windows(2) {
            assert!(w[1] - w[0] >= 300_000, "{times:?}");
        }
        r.run(20 * SECOND);
        assert_eq!(r.m.link_state(0), Some(LinkStreamState::Flowing));
        // What a screen shows: asked and measured, per message.
        for (id, hz) in r.m.requested(0).collect::<Vec<_>>() {
            let got = r.m.measured(r.now, 0, id).unwrap();
            assert!(
                (got - hz as f64).abs() / (hz as f64) < 0.1,
                "{id}: {got} vs {hz}"
            );
        }
    }

    #[test]
    fn an_unanswered_interval_is_sent_again_then_reported() {
        let mut r = Rig::new(PX4, defaults());
        r.ack = None;
        r.run(SECOND + 10_000);
        r.run(SECOND + 10_000 + 3 * FIRST_ACK_WAIT + 20_000);
        let iv = r.intervals_asked();
        // SYS_STATUS three times a second apart, then the next message.
        assert_eq!(iv.iter().filter(|(m, _)| *m == 1).count(), 3, "{iv:?}");
        assert_eq!(iv.last().unwrap().0, 2);
        assert!(r.notice("no answer from 1:1 to SET_MESSAGE_INTERVAL SYS_STATUS on link 0"));
        // PX4 has no groups to fall back to: given up, said so, never REQUEST_DATA_STREAM.
        r.run(60 * SECOND);
        assert!(r.groups_asked(0).is_empty());
        assert!(
            r.notice("no SYS_STATUS from 1:1 on link 0"),
            "{:?}",
            r.notices
        );
        assert_eq!(r.m.link_state(0), Some(LinkStreamState::Failed));
        let before = r.asked.len();
        r.run(120 * SECOND);
        assert_eq!(r.asked.len(), before, "left alone once failed");
    }

    #[test]
    fn a_vehicle_on_two_links_is_asked_on_both() {
        let mut r = Rig::new(AP, defaults());
        r.links = vec![(0, NET), (1, NET)];
        r.run(2 * SECOND);
        assert_eq!(r.groups_asked(0).len(), 7);
        assert_eq!(r.groups_asked(1), r.groups_asked(0));
        r.run(20 * SECOND);
        assert_eq!(r.m.link_state(0), Some(LinkStreamState::Flowing));
        assert_eq!(r.m.link_state(1), Some(LinkStreamState::Flowing));
        assert_eq!(r.asked.len(), 14);
    }

    #[test]
    fn ardupilot_ignoring_group_requests_gets_its_messages_by_interval() {
        let mut r = Rig::new(AP, defaults());
        r.groups = false; // a port with NOSTREAMOVERRIDE
        r.run(SECOND + 10_000);
        assert_eq!(r.groups_asked(0).len(), 7);
        // Checked 3 s later (6 s for nothing slower than 1 Hz): asked again, once.
        r.run(5 * SECOND);
        assert_eq!(r.groups_asked(0).len(), 14);
        assert!(r.intervals_asked().is_empty());
        // Then by SET_MESSAGE_INTERVAL, each group's main messages at its rate.
        r.run(30 * SECOND);
        assert_eq!(r.groups_asked(0).len(), 14, "no more group requests");
        let iv = r.intervals_asked();
        let mut want = Vec::new();
        for g in GROUPS {
            let hz = defaults().groups[&g.id].ceil();
            for &m in g.main {
                want.push((m, hz));
            }
        }
        let mut got = iv.clone();
        got.sort_by_key(|x| x.0);
        want.sort_by_key(|x| x.0);
        assert_eq!(got, want);
        assert_eq!(r.overlaps, 0);
        assert!(r.notice(
            "ATTITUDE not arriving by REQUEST_DATA_STREAM EXTRA1; asking by SET_MESSAGE_INTERVAL"
        ));
        r.run(40 * SECOND);
        assert_eq!(r.m.link_state(0), Some(LinkStreamState::Flowing));
        let att =
            r.m.report(r.now, 0)
                .into_iter()
                .find(|s| s.msgid == 30)
                .unwrap();
        assert_eq!(att.method, Method::Interval);
        assert_eq!(att.requested_hz, 10.0);
        assert!((att.measured_hz - 10.0).abs() < 0.5, "{att:?}");
    }

    #[test]
    fn a_refused_interval_is_shown_and_ardupilot_falls_back_to_the_group() {
        let mut rates = defaults();
        rates.groups.clear();
        rates.ardupilot_messages.insert(30, 20.0); // ATTITUDE, of EXTRA1
        let mut r = Rig::new(AP, rates);
        r.ack = Some(DENIED);
        r.run(SECOND + 200_000);
        assert_eq!(r.intervals_asked(), vec![(30, 20.0)]);
        assert!(
            r.notice("1:1 refused SET_MESSAGE_INTERVAL ATTITUDE at 20 Hz on link 0: DENIED"),
            "{:?}",
            r.notices
        );
        assert_eq!(r.groups_asked(0), vec![(10, 20)]);
        r.run(20 * SECOND);
        assert_eq!(r.m.link_state(0), Some(LinkStreamState::Flowing));
        assert_eq!(r.m.requested(0).collect::<Vec<_>>(), vec![(30, 20.0)]);
    }

    #[test]
    fn px4_refusing_an_interval_is_told_and_never_asked_by_group() {
        let mut rates = defaults();
        rates.messages = [(30, 4.0)].into_iter().collect();
        let mut r = Rig::new(PX4, rates);
        r.ack = Some(MavResult::MAV_RESULT_UNSUPPORTED as u8);
        r.run(10 * SECOND);
        assert!(r.notice("refused SET_MESSAGE_INTERVAL ATTITUDE at 4 Hz on link 0: UNSUPPORTED"));
        assert!(r.notice("no ATTITUDE from 1:1 on link 0: asked at 4 Hz by SET_MESSAGE_INTERVAL, refused (UNSUPPORTED)"), "{:?}", r.notices);
        assert!(r.groups_asked(0).is_empty());
        assert_eq!(r.intervals_asked().len(), 1);
    }

    #[test]
    fn an_interval_accepted_but_never_sent_is_asked_again_then_by_group() {
        let mut rates = defaults();
        rates.messages = [(74, 4.0)].into_iter().collect(); // VFR_HUD, of EXTRA2
        let mut r = Rig::new(MavAutopilot::MAV_AUTOPILOT_GENERIC, rates);
        r.intervals = false; // says yes, sends nothing
        r.run(SECOND + 100_000);
        assert_eq!(r.intervals_asked().len(), 1);
        r.run(5 * SECOND);
        assert_eq!(r.intervals_asked().len(), 2, "asked again");
        assert!(r.groups_asked(0).is_empty());
        r.run(9 * SECOND);
        assert_eq!(r.groups_asked(0), vec![(11, 4)]);
        assert!(r.notice(
            "VFR_HUD not arriving by SET_MESSAGE_INTERVAL; asking by REQUEST_DATA_STREAM EXTRA2"
        ));
        r.run(20 * SECOND);
        assert_eq!(r.m.link_state(0), Some(LinkStreamState::Flowing));
    }

    #[test]
    fn the_operators_interval_command_holds_ours_and_keeps_its_ack() {
        let mut r = Rig::new(PX4, defaults());
        // None of ours waits: the ACK is the queue's.
        assert_eq!(r.m.on_ack(0, SMI, ACCEPTED), None);
        r.m.hold_intervals(true);
        r.run(3 * SECOND);
        assert!(r.intervals_asked().is_empty());
        assert!(r.m.waiting(), "waits to send");
        r.m.hold_intervals(false);
        r.run(3 * SECOND + 20_000);
        assert_eq!(r.intervals_asked().len(), 1);
        // Other commands' ACKs are never ours.
        assert_eq!(r.m.on_ack(r.now, 512, ACCEPTED), None);
    }

    #[test]
    fn measured_rates_follow_arrivals_and_fall_when_they_stop() {
        let mut r = Rig::new(AP, defaults());
        r.run(20 * SECOND);
        let hz = |r: &Rig, id| r.m.measured(r.now, 0, id).unwrap();
        assert!((hz(&r, 30) - 10.0).abs() < 0.2, "{}", hz(&r, 30));
        assert!((hz(&r, 33) - 3.0).abs() < 0.1, "{}", hz(&r, 33));
        assert!((hz(&r, 2) - 3.0).abs() < 0.1);
        assert_eq!(r.m.measured(r.now, 0, 999), None);
        r.forgot = true;
        r.run(21 * SECOND);
        assert!(hz(&r, 30) < 2.0, "{}", hz(&r, 30));
        r.silent = true;
        r.run(32 * SECOND);
        assert_eq!(hz(&r, 30), 0.0);
    }

    #[test]
    fn a_reboot_asks_again_a_fade_does_not() {
        let mut r = Rig::new(AP, defaults());
        r.run(20 * SECOND);
        assert_eq!(r.asked.len(), 7);
        // A fade: nothing at all for 5 s, then everything again.
        r.silent = true;
        r.run(25 * SECOND);
        r.silent = false;
        r.run(40 * SECOND);
        assert_eq!(r.asked.len(), 7, "a fade asks nothing: {:?}", r.asked);
        // A reboot the registry saw (SYSTEM_TIME went back): asked again at once.
        r.m.on_reboot();
        r.run(40 * SECOND + 20_000);
        assert_eq!(r.asked.len(), 14);
        r.run(60 * SECOND);
        assert_eq!(r.asked.len(), 14);
        // A reboot nobody saw: heartbeats go on, telemetry stopped.
        r.forgot = true;
        r.streaming.clear();
        r.run(66 * SECOND);
        r.forgot = false;
        assert_eq!(r.asked.len(), 21, "asked again after the streams stopped");
        // A reconnect asks again on that link.
        r.run(80 * SECOND);
        r.m.on_link_reconnected(0);
        r.run(80 * SECOND + 20_000);
        assert_eq!(r.asked.len(), 28);
    }

    #[test]
    fn high_latency_links_get_nothing() {
        let hl = LinkProfile {
            hl: true,
            baud: None,
        };
        let mut r = Rig::new(AP, defaults());
        r.links = vec![(0, hl)];
        r.run(30 * SECOND);
        assert!(r.asked.is_empty());
        assert_eq!(r.m.link_state(0), Some(LinkStreamState::HighLatency));
        assert_eq!(r.m.next_deadline(), None);
        assert!(!r.m.waiting());
        r.m.on_reboot();
        r.m.on_link_reconnected(0);
        r.run(40 * SECOND);
        assert!(r.asked.is_empty());
        // The same vehicle heard on a normal link too: asked there only.
        r.links = vec![(0, hl), (1, NET)];
        r.run(50 * SECOND);
        assert_eq!(r.groups_asked(1).len(), 7);
        assert!(r.asked.iter().all(|(_, q)| !matches!(q, Req::Group(0, ..))));
    }

    #[test]
    fn nothing_is_asked_on_a_silent_link_and_no_timer_spins() {
        let mut m = StreamMachine::new(T, AP, true, defaults());
        m.on_message(0, 0, NET, 0, Some(&hb(AP)));
        let out = m.poll(0);
        assert_eq!(out.len(), 7);
        // Nothing heard since: the check finds the link silent and waits for it.
        let d = m.next_deadline().unwrap();
        assert!(m.poll(d).is_empty());
        assert_eq!(m.next_deadline(), None);
        assert_eq!(m.link_state(0), Some(LinkStreamState::Due));
        assert!(m.poll(d + 60 * SECOND).is_empty());
        // Heard again: asked again.
        m.on_message(d + 61 * SECOND, 0, NET, 0, Some(&hb(AP)));
        assert_eq!(m.poll(d + 61 * SECOND).len(), 7);
    }

    #[test]
    fn disabled_asks_nothing() {
        let mut m = StreamMachine::new(T, AP, false, defaults());
        m.on_message(0, 0, NET, 0, Some(&hb(AP)));
        assert!(m.poll(0).is_empty());
        assert!(!m.waiting());
        assert_eq!(m.next_deadline(), None);
    }

    #[test]
    fn bytes_of_the_default_rates_and_what_fits_a_known_baud() {
        let groups: Vec<(u8, f32)> = defaults().groups.into_iter().collect();
        let per_group: Vec<(u8, u32)> = GROUPS.iter().map(|g| (g.id, group_bytes(g))).collect();
        // MAVLink 2 frames with every extension field: what ArduCopter sends in one round.
        assert_eq!(
            per_group,
            vec![
                (1, 169),
                (2, 225),
                (3, 103),
                (6, 80),
                (10, 76),
                (11, 32),
                (12, 212)
            ]
        );
        let frames: u32 = groups
            .iter()
            .map(|&(g, hz)| group(g).unwrap().content.len() as u32 * group_rate(hz) as u32)
            .sum();
        assert_eq!(frames, 77);
        // Unknown speed (network, USB, a serial spec without a baud): as configured.
        let f = fit_to_link(&groups, &[], None);
        assert_eq!(
            f.groups,
            vec![(1, 2), (2, 2), (3, 2), (6, 3), (10, 10), (11, 10), (12, 3)]
        );
        assert_eq!(f.bytes_per_second.round(), 2950.0);
        assert_eq!(f.budget, None);
        // 115200 baud: 5760 bytes/s for telemetry, enough.
        let f = fit_to_link(&groups, &[], Some(115_200));
        assert_eq!(f.groups[4], (10, 10));
        assert_eq!(f.budget, Some(5760.0));
        // 57600 baud: 2880 bytes/s, 70 short: EXTRA1 goes to 9 Hz.
        let f = fit_to_link(&groups, &[], Some(57_600));
        assert_eq!(
            f.groups,
            vec![(1, 2), (2, 2), (3, 2), (6, 3), (10, 9), (11, 10), (12, 3)]
        );
        assert_eq!(f.bytes_per_second, 2874.0);
        // 19200 baud: 960 bytes/s.
        let f = fit_to_link(&groups, &[], Some(19_200));
        assert_eq!(
            f.groups,
            vec![(1, 1), (2, 1), (3, 1), (6, 1), (10, 1), (11, 2), (12, 1)]
        );
        assert_eq!(f.bytes_per_second, 929.0);
        // Messages by interval scale in proportion.
        let px4: Vec<(u32, f32)> = defaults().messages.into_iter().collect();
        let f = fit_to_link(&[], &px4, Some(9_600));
        let k = f.messages[0].1 / px4[0].1;
        assert!(k < 1.0);
        for (a, b) in f.messages.iter().zip(&px4) {
            assert!((a.1 / b.1 - k).abs() < 1e-4);
        }
        assert!((f.bytes_per_second - 480.0).abs() < 0.5, "{f:?}");
        // Slower than every group at 1 Hz: 1 Hz each, REQUEST_DATA_STREAM goes no lower.
        let f = fit_to_link(&groups, &[], Some(1_200));
        assert!(f.groups.iter().all(|&(_, r)| r == 1));
    }

    #[test]
    fn rates_asked_on_a_link_with_a_known_baud_are_fitted() {
        let mut r = Rig::new(AP, defaults());
        r.links = vec![(
            0,
            LinkProfile {
                hl: false,
                baud: Some(19_200),
            },
        )];
        r.run(SECOND + 10_000);
        assert_eq!(
            r.groups_asked(0),
            vec![(1, 1), (2, 1), (3, 1), (6, 1), (10, 1), (11, 2), (12, 1)]
        );
        let (bytes, budget) = r.m.load(0).unwrap();
        assert_eq!(budget, Some(960.0));
        assert!(bytes <= 960.0);
        r.run(20 * SECOND);
        assert_eq!(r.m.link_state(0), Some(LinkStreamState::Flowing));
    }

    #[test]
    fn group_rates_are_whole_hz_rounded_up() {
        assert_eq!(group_rate(0.0), 0);
        assert_eq!(group_rate(-1.0), 0);
        assert_eq!(group_rate(f32::NAN), 0);
        assert_eq!(group_rate(0.1), 1);
        assert_eq!(group_rate(2.0), 2);
        assert_eq!(group_rate(2.01), 3);
        assert_eq!(group_rate(1e9), u16::MAX);
    }
}
