// REQUEST_DATA_STREAM is marked deprecated in common.xml, yet it is what ArduPilot honours.
#![allow(deprecated)]
//! Asking a vehicle for telemetry, the way its autopilot understands, on every link it is heard
//! on, and checking that it came.
//!
//! ArduPilot honours REQUEST_DATA_STREAM (stream groups at a rate), and keeps the rates per
//! serial port: a vehicle heard on two links is asked on both. It also takes
//! SET_MESSAGE_INTERVAL from 4.0 on, but the group request works on every version, so it is what
//! we send. PX4 ignores REQUEST_DATA_STREAM and only takes MAV_CMD_SET_MESSAGE_INTERVAL. Neither
//! sets a capability bit that would tell us, so the choice is made on the HEARTBEAT's autopilot.
//!
//! The machine, per link:
//! - **Ask** when the vehicle is first heard on the link, after a reboot, and after the link
//!   reconnects; then **check** [`CHECK_AFTER`] later that telemetry (one of [`TELEMETRY_IDS`])
//!   arrived on that link.
//! - No telemetry by then while heartbeats still arrive: ask again, up to [`MAX_ATTEMPTS`] times
//!   with the wait doubling, then tell the operator and stop asking on that link until something
//!   changes (a reboot, a reconnect, or telemetry).
//! - The link silent (no heartbeat either): nothing to do until it is heard again; asking a
//!   link that hears nothing only fills a radio's queue.
//! - Telemetry that flowed and stopped while heartbeats go on (a reboot nobody could see:
//!   ArduPilot sends SYSTEM_TIME only in a stream, and a rebooted one sends nothing but
//!   heartbeats until asked): ask again. A fade (everything stops, then everything resumes) asks
//!   nothing.
//!
//! Sans-I/O: messages and time in, [`StreamOut`] out, [`StreamMachine::next_deadline`] for the
//! one timer.

use std::collections::BTreeMap;

use crate::clock::{Micros, SECOND};
use crate::dialect::{self, MavAutopilot, MavCmd, MavDataStream, MavMessage, MavResult};
use crate::proto::severity;

/// Rate asked of ArduPilot for all stream groups.
pub const DEFAULT_STREAM_HZ: u16 = 4;

/// Messages asked of autopilots that only know SET_MESSAGE_INTERVAL, with their rates in Hz.
pub const INTERVAL_MESSAGES: &[(u32, f32)] = &[
    (1, 1.0),   // SYS_STATUS
    (2, 0.5),   // SYSTEM_TIME
    (24, 1.0),  // GPS_RAW_INT
    (30, 4.0),  // ATTITUDE
    (33, 4.0),  // GLOBAL_POSITION_INT
    (74, 4.0),  // VFR_HUD
    (147, 1.0), // BATTERY_STATUS
];

/// Messages whose arrival shows that the streams we asked for flow: each is in ArduPilot's
/// stream groups and in [`INTERVAL_MESSAGES`]. (STATUSTEXT, PARAM_VALUE or COMMAND_ACK come
/// unasked and prove nothing.)
pub const TELEMETRY_IDS: &[u32] = &[1, 24, 30, 33, 74];

/// How long after asking we check that telemetry came.
pub const CHECK_AFTER: Micros = 3 * SECOND;
/// Requests per link before we stop asking and say so.
pub const MAX_ATTEMPTS: u32 = 4;
/// Telemetry silent this long while heartbeats arrive means the streams stopped.
pub const STALE_AFTER: Micros = 4 * SECOND;
/// A link whose last heartbeat is older than this is silent: not worth asking on.
pub const SILENT_AFTER: Micros = 3 * SECOND;

/// REQUEST_DATA_STREAM for one stream group.
pub fn request_data_stream(
    target: (u8, u8),
    stream: MavDataStream,
    hz: u16,
    start: bool,
) -> MavMessage {
    MavMessage::REQUEST_DATA_STREAM(dialect::REQUEST_DATA_STREAM_DATA {
        req_message_rate: hz,
        target_system: target.0,
        target_component: target.1,
        req_stream_id: stream,
        start_stop: start as u8,
    })
}

/// COMMAND_LONG MAV_CMD_SET_MESSAGE_INTERVAL (param2 in µs; -1 disables, 0 default rate).
pub fn set_message_interval(target: (u8, u8), msgid: u32, interval_us: f32) -> MavMessage {
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

/// What to send to ask `target` (an autopilot of kind `autopilot`) for telemetry.
pub fn requests_for(target: (u8, u8), autopilot: MavAutopilot) -> Vec<MavMessage> {
    match autopilot {
        MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA => vec![request_data_stream(
            target,
            MavDataStream::MAV_DATA_STREAM_ALL,
            DEFAULT_STREAM_HZ,
            true,
        )],
        _ => INTERVAL_MESSAGES
            .iter()
            .map(|&(id, hz)| set_message_interval(target, id, 1e6 / hz))
            .collect(),
    }
}

/// What the machine wants done.
#[derive(Debug, Clone, PartialEq)]
#[allow(clippy::large_enum_variant)] // short-lived; boxing every message buys nothing
pub enum StreamOut {
    /// Send on this link (stream rates are per link).
    SendOn(usize, MavMessage),
    /// Tell the operator (severity, text).
    Notice(u8, String),
}

/// Where one link stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinkStreamState {
    /// Needs a request at the next poll.
    Due,
    /// Asked at `asked`; checked at `check`.
    Asked { attempt: u32, check: Micros },
    /// Telemetry arrives.
    Flowing,
    /// Asked [`MAX_ATTEMPTS`] times without telemetry.
    GaveUp,
}

#[derive(Debug, Clone, Copy)]
struct LinkStreams {
    state: LinkStreamState,
    last_heartbeat: Micros,
    last_telemetry: Option<Micros>,
    /// Since when heartbeats have arrived without a gap and without telemetry.
    quiet_since: Option<Micros>,
    /// Requests sent on this link, all told.
    requests: u32,
}

/// Stream requests for one autopilot, per link.
#[derive(Debug, Clone)]
pub struct StreamMachine {
    target: (u8, u8),
    autopilot: MavAutopilot,
    /// Off when the operator asked mavterm not to request streams.
    enabled: bool,
    links: BTreeMap<usize, LinkStreams>,
}

impl StreamMachine {
    pub fn new(target: (u8, u8), autopilot: MavAutopilot, enabled: bool) -> Self {
        Self {
            target,
            autopilot,
            enabled,
            links: BTreeMap::new(),
        }
    }

    /// The state on each link heard.
    pub fn link_states(&self) -> impl Iterator<Item = (usize, LinkStreamState)> + '_ {
        self.links.iter().map(|(l, s)| (*l, s.state))
    }

    /// Requests sent on `link`, all told.
    pub fn requests_sent(&self, link: usize) -> u32 {
        self.links.get(&link).map_or(0, |s| s.requests)
    }

    /// A frame from the target component heard on `link`: its message id, and the heartbeat
    /// when it is one. Telemetry is told by its id alone, so a message our dialect cannot decode
    /// (an enum value newer than ours) still shows that streams flow.
    pub fn on_message(
        &mut self,
        now: Micros,
        link: usize,
        id: u32,
        heartbeat: Option<&dialect::HEARTBEAT_DATA>,
    ) {
        let entry = self.links.entry(link).or_insert(LinkStreams {
            state: LinkStreamState::Due,
            last_heartbeat: now,
            last_telemetry: None,
            quiet_since: None,
            requests: 0,
        });
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
            let stale = entry
                .quiet_since
                .is_some_and(|t| now.saturating_sub(t) >= STALE_AFTER);
            if entry.state == LinkStreamState::Flowing && stale {
                entry.state = LinkStreamState::Due;
            }
        } else if TELEMETRY_IDS.contains(&id) {
            entry.last_telemetry = Some(now);
            entry.quiet_since = None;
            entry.state = LinkStreamState::Flowing;
        }
    }

    /// A COMMAND_ACK from the target: a refusal of SET_MESSAGE_INTERVAL is shown.
    pub fn on_ack(&mut self, command: u16, result: u8) -> Vec<StreamOut> {
        if command != MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL as u16
            || result == MavResult::MAV_RESULT_ACCEPTED as u8
        {
            return Vec::new();
        }
        vec![StreamOut::Notice(
            severity::WARNING,
            format!(
                "{}:{} refused SET_MESSAGE_INTERVAL: {}",
                self.target.0,
                self.target.1,
                crate::proto::ack::result_name(result)
            ),
        )]
    }

    /// The vehicle rebooted: ask again on every link.
    pub fn on_reboot(&mut self) {
        for s in self.links.values_mut() {
            s.state = LinkStreamState::Due;
            s.last_telemetry = None;
        }
    }

    /// `link` reconnected: ask again on it.
    pub fn on_link_reconnected(&mut self, link: usize) {
        if let Some(s) = self.links.get_mut(&link) {
            s.state = LinkStreamState::Due;
            s.last_telemetry = None;
        }
    }

    /// Send what is due at `now`.
    pub fn poll(&mut self, now: Micros) -> Vec<StreamOut> {
        let mut out = Vec::new();
        if !self.enabled {
            return out;
        }
        for (&link, s) in self.links.iter_mut() {
            let attempt = match s.state {
                LinkStreamState::Due => 1,
                LinkStreamState::Asked { attempt, check } if now >= check => {
                    if now.saturating_sub(s.last_heartbeat) >= SILENT_AFTER {
                        // Nothing heard at all: wait for the link to come back.
                        s.state = LinkStreamState::Due;
                        continue;
                    }
                    if attempt >= MAX_ATTEMPTS {
                        s.state = LinkStreamState::GaveUp;
                        out.push(StreamOut::Notice(
                            severity::WARNING,
                            format!(
                                "no telemetry from {}:{} on link {link} after {attempt} requests",
                                self.target.0, self.target.1
                            ),
                        ));
                        continue;
                    }
                    attempt + 1
                }
                _ => continue,
            };
            if attempt == 1 && now.saturating_sub(s.last_heartbeat) >= SILENT_AFTER {
                continue; // due, but the link hears nothing: ask when it does
            }
            for msg in requests_for(self.target, self.autopilot) {
                out.push(StreamOut::SendOn(link, msg));
            }
            s.requests += 1;
            s.state = LinkStreamState::Asked {
                attempt,
                check: now + (CHECK_AFTER << (attempt - 1)),
            };
        }
        out
    }

    /// When [`StreamMachine::poll`] next has something to do.
    pub fn next_deadline(&self) -> Option<Micros> {
        if !self.enabled {
            return None;
        }
        self.links
            .values()
            .filter_map(|s| match s.state {
                LinkStreamState::Asked { check, .. } => Some(check),
                _ => None,
            })
            .min()
    }

    /// True when some link is waiting for a request at the next poll.
    pub fn due(&self) -> bool {
        self.enabled && self.links.values().any(|s| s.state == LinkStreamState::Due)
    }
}
