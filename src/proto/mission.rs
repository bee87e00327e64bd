// MISSION_SET_CURRENT is deprecated in favour of MAV_CMD_DO_SET_MISSION_CURRENT, which older
// ArduPilot does not know; both autopilots still answer it.
#![allow(deprecated)]
//! The mission protocol with one vehicle, after QGroundControl's `PlanManager` and the MAVLink
//! mission microservice (<https://mavlink.io/en/services/mission.html>), for the mission, the
//! geofence and the rally points (MAV_MISSION_TYPE 0, 1, 2).
//!
//! **Download**: MISSION_REQUEST_LIST → MISSION_COUNT → MISSION_REQUEST_INT(0) →
//! MISSION_ITEM_INT(0) → … → our MISSION_ACK. One item asked for at a time, in order. An item
//! that does not come in time is asked for again; an item not asked for (another seq, another
//! list's, a late copy) is ignored, as QGroundControl does. Legacy MISSION_ITEM is read too. The
//! MISSION_COUNT's `opaque_id` is kept. If the vehicle sends the last item again after we
//! finished (our ACK lost), the ACK is sent again.
//!
//! **Upload**: MISSION_COUNT, then each MISSION_REQUEST_INT — or the older MISSION_REQUEST,
//! which ArduPilot still sends — answered with MISSION_ITEM_INT (as QGroundControl does), a
//! request for the same item twice answered twice; then the vehicle's MISSION_ACK, whose
//! `opaque_id` is kept. MISSION_COUNT is sent again while no request comes; once requests have
//! started the vehicle drives, and silence for [`VEHICLE_WAIT`] ends the upload (when it comes
//! after the last item, the vehicle may or may not have taken the mission: that is what is
//! said). A refusal (an error in MISSION_ACK) ends it and is shown with its MAV_MISSION_RESULT,
//! except MAV_MISSION_NO_SPACE before any item was asked for: ArduPilot answers that while its
//! storage is not ready just after boot ("Only 0 items are supported"), so the upload is tried
//! again [`NO_SPACE_WAIT`] later, up to [`NO_SPACE_RETRIES`] times, each refusal shown.
//! MAV_MISSION_INVALID_SEQUENCE is ignored (ArduPilot sends it for a duplicated request; the
//! protocol counts out-of-sequence messages as recoverable).
//!
//! **Clear**: MISSION_CLEAR_ALL → MISSION_ACK, sent again on a timeout (clearing is the same
//! however often it is done). **Set current**: MISSION_SET_CURRENT, confirmed by a
//! MISSION_CURRENT with that seq (the protocol's answer); never sent again on its own: the
//! operator sees it did not take and decides.
//!
//! Timeouts and retries are the protocol's and QGroundControl's: [`ACK_TIMEOUT`] (1.5 s) for
//! the vehicle's answer to a request, [`ITEM_TIMEOUT`] (250 ms, longer on a link whose round
//! trip measures longer) for an item asked for, [`MAX_RETRIES`] (5) resends.
//!
//! One transfer at a time per vehicle; others wait their turn in a short queue (an operator who
//! asks for the mission, the fence and the rally points gets all three, one after the other).
//!
//! Always, not only during transfers: MISSION_CURRENT (the current item, the total, the plan ids
//! — a plan id that differs from the one we downloaded or uploaded means the plan on the vehicle
//! changed) and MISSION_ITEM_REACHED (kept; ArduPilot does not send one for every item).
//!
//! Messages are read from their payloads ([`MissionMsg::read`]), not the dialect's structs, so
//! an item with a command or frame our dialect does not know is still received and shown.
//!
//! Sans-I/O: payloads, requests and time in; [`MissionOut`] out; [`MissionMachine::next_deadline`].

use std::collections::VecDeque;

use num_traits::FromPrimitive;

use crate::clock::{Micros, SECOND};
use crate::dialect::{self, MavCmd, MavFrame, MavMessage, MavMissionResult, MavMissionType};
use crate::mission::{xy_to_wire, MissionItem, MissionType};
use crate::proto::machine::{Ids, Incoming, Machine, MachineEvent, Out, Route};
use crate::proto::vehicles::VehicleKey;
use crate::wire::Severity;
use mavlink::MessageData;

/// Wait for the vehicle's answer to MISSION_REQUEST_LIST, MISSION_COUNT, MISSION_CLEAR_ALL.
pub const ACK_TIMEOUT: Micros = 1_500_000;
/// Shortest wait for an item asked for.
pub const ITEM_TIMEOUT: Micros = 250_000;
/// Resends of a request before a transfer gives up.
pub const MAX_RETRIES: u32 = 5;
/// During an upload, the longest silence from the vehicle (it asks again on its own timer).
pub const VEHICLE_WAIT: Micros = 5 * SECOND;
/// Wait before an upload refused with NO_SPACE at its start is tried again.
pub const NO_SPACE_WAIT: Micros = 3 * SECOND;
/// Uploads tried again after NO_SPACE.
pub const NO_SPACE_RETRIES: u32 = 2;
/// How long after a download the vehicle's repeated last item gets our ACK again.
pub const LINGER: Micros = 3 * SECOND;
/// Wait for MISSION_CURRENT to show the item MISSION_SET_CURRENT asked for.
pub const SET_CURRENT_TIMEOUT: Micros = 3 * SECOND;
/// Transfers waiting behind the running one.
pub const QUEUE_MAX: usize = 6;
/// MISSION_ITEM_REACHED kept.
pub const REACHED_KEPT: usize = 64;
/// A STATUSTEXT this close to a refusal explains it.
pub const EXPLAIN_WINDOW: Micros = SECOND;

/// Message ids of the mission protocol.
pub mod id {
    use mavlink::MessageData;
    pub const MISSION_ITEM: u32 = crate::dialect::MISSION_ITEM_DATA::ID;
    pub const MISSION_REQUEST: u32 = crate::dialect::MISSION_REQUEST_DATA::ID;
    pub const MISSION_SET_CURRENT: u32 = crate::dialect::MISSION_SET_CURRENT_DATA::ID;
    pub const MISSION_CURRENT: u32 = crate::dialect::MISSION_CURRENT_DATA::ID;
    pub const MISSION_REQUEST_LIST: u32 = crate::dialect::MISSION_REQUEST_LIST_DATA::ID;
    pub const MISSION_COUNT: u32 = crate::dialect::MISSION_COUNT_DATA::ID;
    pub const MISSION_CLEAR_ALL: u32 = crate::dialect::MISSION_CLEAR_ALL_DATA::ID;
    pub const MISSION_ITEM_REACHED: u32 = crate::dialect::MISSION_ITEM_REACHED_DATA::ID;
    pub const MISSION_ACK: u32 = crate::dialect::MISSION_ACK_DATA::ID;
    pub const MISSION_REQUEST_INT: u32 = crate::dialect::MISSION_REQUEST_INT_DATA::ID;
    pub const MISSION_ITEM_INT: u32 = crate::dialect::MISSION_ITEM_INT_DATA::ID;
}

/// `MAV_MISSION_NO_SPACE` → `NO_SPACE`; a number the dialect does not know stays a number.
pub fn result_name(result: u8) -> String {
    match MavMissionResult::from_u8(result) {
        Some(r) => {
            let s = format!("{r:?}");
            s.strip_prefix("MAV_MISSION_").unwrap_or(&s).to_string()
        }
        None => format!("result {result}"),
    }
}

const ACCEPTED: u8 = 0;
const NO_SPACE: u8 = 4;
const INVALID_SEQUENCE: u8 = 13;

/// A mission message from a vehicle, read from its payload (zero-extended as MAVLink 2 cuts
/// trailing zeros).
#[derive(Debug, Clone, PartialEq)]
pub enum MissionMsg {
    Count {
        target: (u8, u8),
        count: u16,
        mission_type: u8,
        opaque_id: u32,
    },
    /// MISSION_ITEM_INT, or MISSION_ITEM (`legacy`, x/y as floats) converted to it.
    Item {
        target: (u8, u8),
        mission_type: u8,
        item: MissionItem,
        legacy: bool,
    },
    /// MISSION_REQUEST_INT, or MISSION_REQUEST (`legacy`).
    Request {
        target: (u8, u8),
        seq: u16,
        mission_type: u8,
        legacy: bool,
    },
    Ack {
        target: (u8, u8),
        result: u8,
        mission_type: u8,
        opaque_id: u32,
    },
    Current(Current),
    Reached(u16),
}

/// What MISSION_CURRENT says.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Current {
    pub seq: u16,
    /// Mission items (ArduPilot: not counting home).
    pub total: u16,
    /// MISSION_STATE (0 unknown, 1 no mission, 2 not started, 3 active, 4 paused, 5 complete).
    pub state: u8,
    /// 0 unknown, 1 in a mission mode, 2 suspended.
    pub mode: u8,
    /// Plan ids of the mission, fence and rally points (0: none, or not supported).
    pub ids: [u32; 3],
}

impl Current {
    pub fn state_name(&self) -> &'static str {
        match self.state {
            1 => "no mission",
            2 => "not started",
            3 => "active",
            4 => "paused",
            5 => "complete",
            _ => "unknown",
        }
    }
}

use crate::wire::payload::Payload;

impl MissionMsg {
    /// The mission message in frame `msgid` with `payload`, or `None` for another message.
    pub fn read(msgid: u32, payload: &[u8]) -> Option<MissionMsg> {
        let p = Payload(payload);
        Some(match msgid {
            id::MISSION_COUNT => MissionMsg::Count {
                count: p.u16(0),
                target: (p.u8(2), p.u8(3)),
                mission_type: p.u8(4),
                opaque_id: p.u32(5),
            },
            id::MISSION_ITEM_INT | id::MISSION_ITEM => {
                let legacy = msgid == id::MISSION_ITEM;
                let frame = p.u8(34);
                let mission_type = p.u8(37);
                let (x, y) = if legacy {
                    let w = |v: f32| xy_to_wire(frame, v as f64).unwrap_or(i32::MAX);
                    (w(p.f32(16)), w(p.f32(20)))
                } else {
                    (p.i32(16), p.i32(20))
                };
                MissionMsg::Item {
                    target: (p.u8(32), p.u8(33)),
                    mission_type,
                    legacy,
                    item: MissionItem {
                        seq: p.u16(28),
                        frame,
                        command: p.u16(30),
                        current: p.u8(35) != 0,
                        autocontinue: p.u8(36) != 0,
                        params: [p.f32(0), p.f32(4), p.f32(8), p.f32(12)],
                        x,
                        y,
                        z: p.f32(24),
                        mission_type: MissionType::from_code(mission_type)
                            .unwrap_or(MissionType::Mission),
                    },
                }
            }
            id::MISSION_REQUEST_INT | id::MISSION_REQUEST => MissionMsg::Request {
                seq: p.u16(0),
                target: (p.u8(2), p.u8(3)),
                mission_type: p.u8(4),
                legacy: msgid == id::MISSION_REQUEST,
            },
            id::MISSION_ACK => MissionMsg::Ack {
                target: (p.u8(0), p.u8(1)),
                result: p.u8(2),
                mission_type: p.u8(3),
                opaque_id: p.u32(4),
            },
            id::MISSION_CURRENT => MissionMsg::Current(Current {
                seq: p.u16(0),
                total: p.u16(2),
                state: p.u8(4),
                mode: p.u8(5),
                ids: [p.u32(6), p.u32(10), p.u32(14)],
            }),
            id::MISSION_ITEM_REACHED => MissionMsg::Reached(p.u16(0)),
            _ => return None,
        })
    }

    fn target(&self) -> Option<(u8, u8)> {
        match self {
            MissionMsg::Count { target, .. }
            | MissionMsg::Item { target, .. }
            | MissionMsg::Request { target, .. }
            | MissionMsg::Ack { target, .. } => Some(*target),
            MissionMsg::Current(_) | MissionMsg::Reached(_) => None,
        }
    }
}

/// What a transfer does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OpKind {
    Download,
    Upload,
    Clear,
}

impl OpKind {
    pub fn name(self) -> &'static str {
        match self {
            OpKind::Download => "download",
            OpKind::Upload => "upload",
            OpKind::Clear => "clear",
        }
    }
}

/// A transfer an operator asks for.
#[derive(Debug, Clone, PartialEq)]
pub enum Request {
    Download(MissionType),
    /// The items as the vehicle is to hold them (for an ArduPilot mission, home first).
    Upload(MissionType, Vec<MissionItem>),
    Clear(MissionType),
}

impl Request {
    pub fn kind(&self) -> OpKind {
        match self {
            Request::Download(_) => OpKind::Download,
            Request::Upload(..) => OpKind::Upload,
            Request::Clear(_) => OpKind::Clear,
        }
    }

    pub fn mission_type(&self) -> MissionType {
        match self {
            Request::Download(t) | Request::Upload(t, _) | Request::Clear(t) => *t,
        }
    }

    /// `mission upload`, `fence download`.
    pub fn name(&self) -> String {
        format!("{} {}", self.mission_type(), self.kind().name())
    }
}

/// Something the operator should know.
#[derive(Debug, Clone, PartialEq)]
pub enum MissionEvent {
    /// Waits behind `ahead` other transfers.
    Queued {
        op: OpKind,
        mission_type: MissionType,
        ahead: usize,
    },
    Started {
        op: OpKind,
        mission_type: MissionType,
    },
    /// Items transferred so far of `total`.
    Progress {
        op: OpKind,
        mission_type: MissionType,
        done: u16,
        total: u16,
    },
    Downloaded {
        mission_type: MissionType,
        items: Vec<MissionItem>,
        opaque_id: u32,
    },
    Uploaded {
        mission_type: MissionType,
        count: u16,
        opaque_id: u32,
    },
    Cleared {
        mission_type: MissionType,
    },
    /// The vehicle answered MISSION_ACK with an error (MAV_MISSION_RESULT `result`); tried again
    /// after `retry_in` when that is set.
    Refused {
        op: OpKind,
        mission_type: MissionType,
        result: u8,
        retry_in: Option<Micros>,
    },
    /// No answer, or an answer that makes no sense.
    Failed {
        op: OpKind,
        mission_type: MissionType,
        reason: String,
    },
    /// MISSION_CURRENT shows a new current item.
    Current {
        seq: u16,
        total: u16,
    },
    Reached {
        seq: u16,
    },
    /// MISSION_CURRENT shows the item MISSION_SET_CURRENT asked for.
    CurrentSet {
        seq: u16,
    },
    /// It did not, in time (`now_at`: the current item it shows).
    SetCurrentFailed {
        seq: u16,
        now_at: Option<u16>,
    },
    /// The vehicle's plan id for `mission_type` is not the one we downloaded or uploaded.
    PlanChanged {
        mission_type: MissionType,
        id: u32,
        ours: u32,
    },
}

/// An operator's request to the mission protocol, as its end names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MissionAsk {
    /// A transfer of one list.
    Transfer(OpKind, MissionType),
    /// MISSION_SET_CURRENT to this item.
    SetCurrent(u16),
}

impl MissionEvent {
    /// The request this event ends, and whether it was done: a transfer's last word (done,
    /// refused for good, failed) or MISSION_SET_CURRENT's (taken or not).
    pub fn ends(&self) -> Option<(MissionAsk, bool)> {
        use MissionAsk::*;
        Some(match self {
            MissionEvent::Downloaded { mission_type, .. } => {
                (Transfer(OpKind::Download, *mission_type), true)
            }
            MissionEvent::Uploaded { mission_type, .. } => {
                (Transfer(OpKind::Upload, *mission_type), true)
            }
            MissionEvent::Cleared { mission_type } => {
                (Transfer(OpKind::Clear, *mission_type), true)
            }
            MissionEvent::Refused {
                op,
                mission_type,
                retry_in: None,
                ..
            }
            | MissionEvent::Failed {
                op, mission_type, ..
            } => (Transfer(*op, *mission_type), false),
            MissionEvent::CurrentSet { seq } => (SetCurrent(*seq), true),
            MissionEvent::SetCurrentFailed { seq, .. } => (SetCurrent(*seq), false),
            _ => return None,
        })
    }

    /// (severity, text) to show the operator, for the events worth a line in the messages.
    pub fn notice(&self, key: VehicleKey) -> Option<(Severity, String)> {
        let v = key.to_string();
        let plural = |n: usize| if n == 1 { "" } else { "s" };
        Some(match self {
            MissionEvent::Queued {
                op,
                mission_type,
                ahead,
            } => (
                Severity::INFO,
                format!(
                    "{mission_type} {} for {v} queued behind {ahead} transfer{}",
                    op.name(),
                    plural(*ahead)
                ),
            ),
            MissionEvent::Downloaded {
                mission_type,
                items,
                ..
            } => (
                Severity::INFO,
                format!(
                    "{mission_type} downloaded from {v}: {} item{}",
                    items.len(),
                    plural(items.len())
                ),
            ),
            MissionEvent::Uploaded {
                mission_type,
                count,
                ..
            } => (
                Severity::INFO,
                format!(
                    "{mission_type} uploaded to {v}: {count} item{} accepted",
                    plural(*count as usize)
                ),
            ),
            MissionEvent::Cleared { mission_type } => {
                (Severity::INFO, format!("{mission_type} cleared on {v}"))
            }
            MissionEvent::Refused {
                op,
                mission_type,
                result,
                retry_in,
            } => (
                Severity::WARNING,
                format!(
                    "{mission_type} {} refused by {v}: {}{}",
                    op.name(),
                    result_name(*result),
                    match retry_in {
                        Some(t) => format!(", trying again in {:.0} s", *t as f64 / 1e6),
                        None => String::new(),
                    }
                ),
            ),
            MissionEvent::Failed {
                op,
                mission_type,
                reason,
            } => (
                Severity::WARNING,
                format!("{mission_type} {} with {v} failed: {reason}", op.name()),
            ),
            MissionEvent::CurrentSet { seq } => {
                (Severity::INFO, format!("{v} is now at mission item {seq}"))
            }
            MissionEvent::SetCurrentFailed { seq, now_at } => (
                Severity::WARNING,
                match now_at {
                    Some(at) => format!(
                        "mission item {seq} not taken by {v}: it is still at item {at} (not \
                         sent again)"
                    ),
                    None => format!("mission item {seq}: no MISSION_CURRENT from {v}"),
                },
            ),
            MissionEvent::PlanChanged {
                mission_type,
                id,
                ours,
            } => (
                Severity::NOTICE,
                format!(
                    "{mission_type} on {v} changed (plan id {id:#x}, ours {ours:#x}): download \
                     it to see it"
                ),
            ),
            MissionEvent::Started { .. }
            | MissionEvent::Progress { .. }
            | MissionEvent::Current { .. }
            | MissionEvent::Reached { .. } => return None,
        })
    }
}

/// What the machine wants done.
#[derive(Debug, Clone, PartialEq)]
#[allow(clippy::large_enum_variant)] // short-lived; boxing every message buys nothing
pub enum MissionOut {
    /// Send to the vehicle (already addressed to it).
    Send(MavMessage),
    Event(MissionEvent),
}

/// A list as it is on the vehicle, as far as we know.
#[derive(Debug, Clone, PartialEq)]
pub struct Known {
    /// Downloaded, or uploaded and accepted (the vehicle may have rounded or reframed some).
    pub items: Vec<MissionItem>,
    /// The plan id (0: none given).
    pub opaque_id: u32,
    pub downloaded: bool,
    pub at: Micros,
}

/// Where the running transfer stands, for a progress bar.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Progress {
    pub op: OpKind,
    pub mission_type: MissionType,
    pub done: u16,
    /// `None` until the vehicle said how many (download).
    pub total: Option<u16>,
}

/// The last refusal, with the vehicle's explanation if it gave one: a STATUSTEXT just after
/// it (ArduPilot queues its text before the MISSION_ACK, it arrives after), else one just
/// before.
#[derive(Debug, Clone, PartialEq)]
pub struct Refusal {
    pub op: OpKind,
    pub mission_type: MissionType,
    pub result: u8,
    pub at: Micros,
    pub reason: Option<String>,
    /// The reason came after the refusal: a later text does not replace it.
    explained_after: bool,
}

#[derive(Debug, Clone, PartialEq)]
enum Phase {
    /// Download: MISSION_REQUEST_LIST sent.
    List,
    /// Download: MISSION_REQUEST_INT for `items.len()` sent at `asked`.
    Items {
        count: u16,
        opaque_id: u32,
        items: Vec<MissionItem>,
        asked: Micros,
    },
    /// Upload: MISSION_COUNT sent, no request yet.
    Count,
    /// Upload: items being asked for; `asked` is the highest asked for so far.
    Answering { asked: u16 },
    /// Upload refused with NO_SPACE: MISSION_COUNT again at the deadline.
    RefusedWait,
    /// MISSION_CLEAR_ALL sent.
    Clear,
}

#[derive(Debug, Clone, PartialEq)]
struct Transfer {
    req: Request,
    phase: Phase,
    /// Resends of the current request so far.
    retries: u32,
    /// NO_SPACE refusals so far.
    refusals: u32,
    deadline: Micros,
}

/// The mission protocol with one vehicle.
#[derive(Debug, Clone)]
pub struct MissionMachine {
    key: VehicleKey,
    /// Our own ids: messages addressed to another system or component are not ours.
    pub gcs: (u8, u8),
    running: Option<Transfer>,
    queue: VecDeque<Request>,
    known: [Option<Known>; 3],
    /// Plan ids the vehicle streams in MISSION_CURRENT (0: none).
    vehicle_ids: [u32; 3],
    /// The changed id last said, so it is said once.
    said_changed: [u32; 3],
    pub current: Option<Current>,
    /// MISSION_ITEM_REACHED, oldest first: (time, seq).
    reached: VecDeque<(Micros, u16)>,
    /// MISSION_SET_CURRENT waiting for MISSION_CURRENT: (seq, deadline).
    set_current: Option<(u16, Micros)>,
    /// After a download: (type, last seq, until) to ACK a repeated last item again.
    linger: Option<(MissionType, u16, Micros)>,
    /// Smoothed round trip of item requests.
    srtt: Option<Micros>,
    last_refusal: Option<Refusal>,
    /// Recent texts from the vehicle: (time, text), for a refusal that follows them.
    texts: VecDeque<(Micros, String)>,
    rebooted: bool,
    /// Items asked for as MISSION_REQUEST_INT (else the older MISSION_REQUEST): the profile's
    /// answer until AUTOPILOT_VERSION's MAV_PROTOCOL_CAPABILITY_MISSION_INT bit says.
    int_items: bool,
}

/// AUTOPILOT_VERSION's MAV_PROTOCOL_CAPABILITY_MISSION_INT.
pub const CAP_MISSION_INT: u64 = 4;

fn mav_type(t: MissionType) -> MavMissionType {
    match t {
        MissionType::Mission => MavMissionType::MAV_MISSION_TYPE_MISSION,
        MissionType::Fence => MavMissionType::MAV_MISSION_TYPE_FENCE,
        MissionType::Rally => MavMissionType::MAV_MISSION_TYPE_RALLY,
    }
}

/// Why `items` cannot be sent as the `t` list, if they cannot.
pub fn check_items(t: MissionType, items: &[MissionItem]) -> Result<(), String> {
    if items.len() > u16::MAX as usize {
        return Err(format!("{} items: a list holds at most 65535", items.len()));
    }
    for (k, i) in items.iter().enumerate() {
        if i.seq as usize != k {
            return Err(format!("item {k} has sequence number {}", i.seq));
        }
        if MavCmd::from_u16(i.command).is_none() {
            return Err(format!(
                "item {k}: command {} is not in our MAVLink dialect, it cannot be sent",
                i.command
            ));
        }
        if MavFrame::from_u8(i.frame).is_none() {
            return Err(format!(
                "item {k}: frame {} is not in our MAVLink dialect, it cannot be sent",
                i.frame
            ));
        }
        if i.mission_type != t {
            return Err(format!(
                "item {k} is a {} item, not a {t} item",
                i.mission_type
            ));
        }
    }
    Ok(())
}

/// MISSION_ITEM_INT for `item` to `target` (checked by [`check_items`]).
pub fn item_message(target: (u8, u8), item: &MissionItem) -> MavMessage {
    MavMessage::MISSION_ITEM_INT(dialect::MISSION_ITEM_INT_DATA {
        param1: item.params[0],
        param2: item.params[1],
        param3: item.params[2],
        param4: item.params[3],
        x: item.x,
        y: item.y,
        z: item.z,
        seq: item.seq,
        command: MavCmd::from_u16(item.command).unwrap_or(MavCmd::MAV_CMD_NAV_WAYPOINT),
        target_system: target.0,
        target_component: target.1,
        frame: MavFrame::from_u8(item.frame).unwrap_or(MavFrame::MAV_FRAME_GLOBAL),
        current: item.current as u8,
        autocontinue: item.autocontinue as u8,
        mission_type: mav_type(item.mission_type),
    })
}

fn request_list(key: VehicleKey, t: MissionType) -> MavMessage {
    MavMessage::MISSION_REQUEST_LIST(dialect::MISSION_REQUEST_LIST_DATA {
        target_system: key.0,
        target_component: key.1,
        mission_type: mav_type(t),
    })
}

/// MISSION_REQUEST_INT for item `seq`, or MISSION_REQUEST where the vehicle said it has no INT
/// mission protocol (its answer, MISSION_ITEM, is read as well).
fn request_item(key: VehicleKey, t: MissionType, seq: u16, int: bool) -> MavMessage {
    if int {
        MavMessage::MISSION_REQUEST_INT(dialect::MISSION_REQUEST_INT_DATA {
            seq,
            target_system: key.0,
            target_component: key.1,
            mission_type: mav_type(t),
        })
    } else {
        #[allow(deprecated)] // the older request, for a vehicle without MISSION_INT
        MavMessage::MISSION_REQUEST(dialect::MISSION_REQUEST_DATA {
            seq,
            target_system: key.0,
            target_component: key.1,
            mission_type: mav_type(t),
        })
    }
}

fn count_message(key: VehicleKey, t: MissionType, n: u16) -> MavMessage {
    MavMessage::MISSION_COUNT(dialect::MISSION_COUNT_DATA {
        count: n,
        target_system: key.0,
        target_component: key.1,
        mission_type: mav_type(t),
        opaque_id: 0,
    })
}

fn ack_message(key: VehicleKey, t: MissionType) -> MavMessage {
    MavMessage::MISSION_ACK(dialect::MISSION_ACK_DATA {
        target_system: key.0,
        target_component: key.1,
        mavtype: MavMissionResult::MAV_MISSION_ACCEPTED,
        mission_type: mav_type(t),
        opaque_id: 0,
    })
}

fn clear_message(key: VehicleKey, t: MissionType) -> MavMessage {
    MavMessage::MISSION_CLEAR_ALL(dialect::MISSION_CLEAR_ALL_DATA {
        target_system: key.0,
        target_component: key.1,
        mission_type: mav_type(t),
    })
}

impl MissionMachine {
    pub fn new(key: VehicleKey) -> Self {
        Self {
            key,
            gcs: (255, 190),
            running: None,
            queue: VecDeque::new(),
            known: [None, None, None],
            vehicle_ids: [0; 3],
            said_changed: [0; 3],
            current: None,
            reached: VecDeque::new(),
            set_current: None,
            linger: None,
            srtt: None,
            last_refusal: None,
            texts: VecDeque::new(),
            rebooted: false,
            int_items: true,
        }
    }

    /// Ask items as MISSION_REQUEST_INT (`true`) or MISSION_REQUEST: the profile's default, then
    /// AUTOPILOT_VERSION's MAV_PROTOCOL_CAPABILITY_MISSION_INT once heard.
    pub fn set_int_items(&mut self, int: bool) {
        self.int_items = int;
    }

    /// AUTOPILOT_VERSION's capabilities: the MISSION_INT bit decides the item requests.
    pub fn on_capabilities(&mut self, caps: u64) {
        self.int_items = caps & CAP_MISSION_INT != 0;
    }

    /// The list `t` as it is on the vehicle, as far as we know.
    pub fn known(&self, t: MissionType) -> Option<&Known> {
        self.known[t.index()].as_ref()
    }

    /// The plan id the vehicle streams for `t` (0: none).
    pub fn vehicle_id(&self, t: MissionType) -> u32 {
        self.vehicle_ids[t.index()]
    }

    /// True when the vehicle's plan id for `t` is not the one of the list we know.
    pub fn changed_on_vehicle(&self, t: MissionType) -> bool {
        let v = self.vehicle_ids[t.index()];
        v != 0 && self.known(t).is_some_and(|k| k.opaque_id != v)
    }

    /// MISSION_ITEM_REACHED heard, oldest first: (time, seq).
    pub fn reached(&self) -> impl Iterator<Item = (Micros, u16)> + '_ {
        self.reached.iter().copied()
    }

    pub fn last_refusal(&self) -> Option<&Refusal> {
        self.last_refusal.as_ref()
    }

    /// True while a transfer runs or waits.
    pub fn busy(&self) -> bool {
        self.running.is_some()
    }

    /// The transfers waiting, next first.
    pub fn queued(&self) -> impl Iterator<Item = &Request> {
        self.queue.iter()
    }

    /// Where the running transfer stands.
    pub fn progress(&self) -> Option<Progress> {
        let t = self.running.as_ref()?;
        let (done, total) = match (&t.req, &t.phase) {
            (_, Phase::Items { count, items, .. }) => (items.len() as u16, Some(*count)),
            (Request::Upload(_, items), Phase::Answering { asked }) => {
                (*asked, Some(items.len() as u16))
            }
            (Request::Upload(_, items), _) => (0, Some(items.len() as u16)),
            _ => (0, None),
        };
        Some(Progress {
            op: t.req.kind(),
            mission_type: t.req.mission_type(),
            done,
            total,
        })
    }

    /// Start `req`, or queue it behind the running transfer.
    pub fn submit(&mut self, now: Micros, req: Request) -> Result<Vec<MissionOut>, String> {
        if let Request::Upload(t, items) = &req {
            check_items(*t, items)?;
        }
        let same = |r: &Request| r.kind() == req.kind() && r.mission_type() == req.mission_type();
        if let Some(t) = self.running.as_ref().filter(|t| same(&t.req)) {
            return Err(format!("a {} is already running", t.req.name()));
        }
        if self.queue.iter().any(same) {
            return Err(format!("a {} is already waiting", req.name()));
        }
        let mut out = Vec::new();
        if self.running.is_some() {
            if self.queue.len() >= QUEUE_MAX {
                return Err(format!(
                    "{} mission transfers are already waiting",
                    self.queue.len()
                ));
            }
            let ahead = self.queue.len() + 1;
            out.push(MissionOut::Event(MissionEvent::Queued {
                op: req.kind(),
                mission_type: req.mission_type(),
                ahead,
            }));
            self.queue.push_back(req);
        } else {
            self.start(now, req, &mut out);
        }
        Ok(out)
    }

    /// Ask the vehicle to make `seq` the current mission item (MISSION_SET_CURRENT).
    pub fn set_current(&mut self, now: Micros, seq: u16) -> Result<Vec<MissionOut>, String> {
        if let Some((s, _)) = self.set_current {
            return Err(format!(
                "mission item {s} was asked for and not yet confirmed"
            ));
        }
        self.set_current = Some((seq, now + SET_CURRENT_TIMEOUT));
        Ok(vec![MissionOut::Send(MavMessage::MISSION_SET_CURRENT(
            dialect::MISSION_SET_CURRENT_DATA {
                seq,
                target_system: self.key.0,
                target_component: self.key.1,
            },
        ))])
    }

    /// The wait for an item asked for: [`ITEM_TIMEOUT`], or three measured round trips if
    /// longer, at most [`ACK_TIMEOUT`].
    pub fn item_timeout(&self) -> Micros {
        self.srtt
            .map_or(ITEM_TIMEOUT, |r| (3 * r).clamp(ITEM_TIMEOUT, ACK_TIMEOUT))
    }

    fn start(&mut self, now: Micros, req: Request, out: &mut Vec<MissionOut>) {
        let t = req.mission_type();
        out.push(MissionOut::Event(MissionEvent::Started {
            op: req.kind(),
            mission_type: t,
        }));
        let (msg, phase) = match &req {
            Request::Download(_) => (request_list(self.key, t), Phase::List),
            Request::Upload(_, items) => {
                (count_message(self.key, t, items.len() as u16), Phase::Count)
            }
            Request::Clear(_) => (clear_message(self.key, t), Phase::Clear),
        };
        out.push(MissionOut::Send(msg));
        self.running = Some(Transfer {
            req,
            phase,
            retries: 0,
            refusals: 0,
            deadline: now + ACK_TIMEOUT,
        });
    }

    /// The running transfer ended: the next one starts.
    fn finish(&mut self, now: Micros, event: MissionEvent, out: &mut Vec<MissionOut>) {
        self.running = None;
        out.push(MissionOut::Event(event));
        if let Some(next) = self.queue.pop_front() {
            self.start(now, next, out);
        }
    }

    fn fail(&mut self, now: Micros, reason: String, out: &mut Vec<MissionOut>) {
        let Some(t) = self.running.as_ref() else {
            return;
        };
        let ev = MissionEvent::Failed {
            op: t.req.kind(),
            mission_type: t.req.mission_type(),
            reason,
        };
        self.finish(now, ev, out);
    }

    fn refused(&mut self, now: Micros, result: u8, out: &mut Vec<MissionOut>) {
        let Some(t) = self.running.as_mut() else {
            return;
        };
        let (op, mission_type) = (t.req.kind(), t.req.mission_type());
        let reason = self
            .texts
            .iter()
            .rev()
            .find(|(at, _)| now.saturating_sub(*at) <= EXPLAIN_WINDOW)
            .map(|(_, s)| s.clone());
        self.last_refusal = Some(Refusal {
            op,
            mission_type,
            result,
            at: now,
            reason,
            explained_after: false,
        });
        let retry = op == OpKind::Upload
            && t.phase == Phase::Count
            && result == NO_SPACE
            && t.refusals < NO_SPACE_RETRIES;
        if retry {
            t.refusals += 1;
            t.phase = Phase::RefusedWait;
            t.deadline = now + NO_SPACE_WAIT;
            out.push(MissionOut::Event(MissionEvent::Refused {
                op,
                mission_type,
                result,
                retry_in: Some(NO_SPACE_WAIT),
            }));
            return;
        }
        let ev = MissionEvent::Refused {
            op,
            mission_type,
            result,
            retry_in: None,
        };
        self.finish(now, ev, out);
    }

    /// A text the vehicle said (joined STATUSTEXT): it may explain a refusal.
    pub fn on_text(&mut self, now: Micros, text: &str) {
        if let Some(r) = self
            .last_refusal
            .as_mut()
            .filter(|r| !r.explained_after && now.saturating_sub(r.at) <= EXPLAIN_WINDOW)
        {
            r.reason = Some(text.to_string());
            r.explained_after = true;
            return;
        }
        if self.texts.len() == 8 {
            self.texts.pop_front();
        }
        self.texts.push_back((now, text.to_string()));
    }

    /// A mission message from the vehicle (its autopilot component).
    pub fn on_message(&mut self, now: Micros, msg: &MissionMsg) -> Vec<MissionOut> {
        let mut out = Vec::new();
        if let Some((s, c)) = msg.target() {
            if !(s == 0 || s == self.gcs.0) || !(c == 0 || c == self.gcs.1) {
                return out; // another GCS's exchange
            }
        }
        match msg {
            MissionMsg::Current(cur) => self.on_current(*cur, &mut out),
            MissionMsg::Reached(seq) => {
                if self.reached.len() == REACHED_KEPT {
                    self.reached.pop_front();
                }
                self.reached.push_back((now, *seq));
                out.push(MissionOut::Event(MissionEvent::Reached { seq: *seq }));
            }
            MissionMsg::Count {
                count,
                mission_type,
                opaque_id,
                ..
            } => self.on_count(now, *count, *mission_type, *opaque_id, &mut out),
            MissionMsg::Item {
                mission_type, item, ..
            } => self.on_item(now, *mission_type, item, &mut out),
            MissionMsg::Request {
                seq, mission_type, ..
            } => self.on_request(now, *seq, *mission_type, &mut out),
            MissionMsg::Ack {
                result,
                mission_type,
                opaque_id,
                ..
            } => self.on_ack(now, *result, *mission_type, *opaque_id, &mut out),
        }
        out
    }

    fn running_type(&self) -> Option<u8> {
        self.running.as_ref().map(|t| t.req.mission_type().code())
    }

    fn on_current(&mut self, cur: Current, out: &mut Vec<MissionOut>) {
        if self
            .current
            .is_none_or(|c| c.seq != cur.seq || c.total != cur.total)
        {
            out.push(MissionOut::Event(MissionEvent::Current {
                seq: cur.seq,
                total: cur.total,
            }));
        }
        self.current = Some(cur);
        if let Some((seq, _)) = self.set_current.filter(|(s, _)| *s == cur.seq) {
            self.set_current = None;
            out.push(MissionOut::Event(MissionEvent::CurrentSet { seq }));
        }
        for t in MissionType::ALL {
            let id = cur.ids[t.index()];
            if id == 0 {
                continue;
            }
            self.vehicle_ids[t.index()] = id;
            // Ids change while a list is being uploaded; judged once it is done.
            if self.running_type() == Some(t.code()) {
                continue;
            }
            if let Some(k) = self.known(t) {
                let ours = k.opaque_id;
                if ours != id && self.said_changed[t.index()] != id {
                    self.said_changed[t.index()] = id;
                    out.push(MissionOut::Event(MissionEvent::PlanChanged {
                        mission_type: t,
                        id,
                        ours,
                    }));
                }
            }
        }
    }

    fn on_count(
        &mut self,
        now: Micros,
        count: u16,
        mission_type: u8,
        opaque_id: u32,
        out: &mut Vec<MissionOut>,
    ) {
        let item_timeout = self.item_timeout();
        let Some(t) = self.running.as_mut() else {
            return;
        };
        let mt = t.req.mission_type();
        if mt.code() != mission_type || t.phase != Phase::List {
            return; // a late answer to an earlier request, or another list's
        }
        if count == 0 {
            let ack = ack_message(self.key, mt);
            out.push(MissionOut::Send(ack));
            self.downloaded(now, Vec::new(), opaque_id, out);
            return;
        }
        t.phase = Phase::Items {
            count,
            opaque_id,
            items: Vec::with_capacity(count as usize),
            asked: now,
        };
        t.retries = 0;
        t.deadline = now + item_timeout;
        out.push(MissionOut::Event(MissionEvent::Progress {
            op: OpKind::Download,
            mission_type: mt,
            done: 0,
            total: count,
        }));
        let m = request_item(self.key, mt, 0, self.int_items);
        out.push(MissionOut::Send(m));
    }

    fn downloaded(
        &mut self,
        now: Micros,
        items: Vec<MissionItem>,
        opaque_id: u32,
        out: &mut Vec<MissionOut>,
    ) {
        let Some(t) = self.running.as_ref() else {
            return;
        };
        let mt = t.req.mission_type();
        if let Some(last) = items.last() {
            self.linger = Some((mt, last.seq, now + LINGER));
        }
        self.known[mt.index()] = Some(Known {
            items: items.clone(),
            opaque_id,
            downloaded: true,
            at: now,
        });
        self.said_changed[mt.index()] = 0;
        let ev = MissionEvent::Downloaded {
            mission_type: mt,
            items,
            opaque_id,
        };
        self.finish(now, ev, out);
    }

    fn on_item(
        &mut self,
        now: Micros,
        mission_type: u8,
        item: &MissionItem,
        out: &mut Vec<MissionOut>,
    ) {
        // Our ACK of a finished download lost: the vehicle sends its last item again.
        if let Some((lt, seq, until)) = self.linger {
            if now > until {
                self.linger = None;
            } else if lt.code() == mission_type && seq == item.seq && self.running.is_none() {
                let ack = ack_message(self.key, lt);
                out.push(MissionOut::Send(ack));
                return;
            }
        }
        let Some(t) = self.running.as_mut() else {
            return;
        };
        let mt = t.req.mission_type();
        if mt.code() != mission_type {
            return;
        }
        let Phase::Items {
            count,
            opaque_id,
            items,
            asked,
        } = &mut t.phase
        else {
            return;
        };
        if item.seq as usize != items.len() {
            return; // not the one asked for: its request comes again on the timeout
        }
        if t.retries == 0 {
            let rtt = now.saturating_sub(*asked);
            self.srtt = Some(match self.srtt {
                None => rtt,
                Some(s) => (7 * s + rtt) / 8,
            });
        }
        let mut item = *item;
        item.mission_type = mt;
        items.push(item);
        let (done, total, opaque_id) = (items.len() as u16, *count, *opaque_id);
        out.push(MissionOut::Event(MissionEvent::Progress {
            op: OpKind::Download,
            mission_type: mt,
            done,
            total,
        }));
        if done == total {
            let items = std::mem::take(items);
            let ack = ack_message(self.key, mt);
            out.push(MissionOut::Send(ack));
            self.downloaded(now, items, opaque_id, out);
            return;
        }
        *asked = now;
        t.retries = 0;
        let timeout = self.item_timeout();
        if let Some(t) = self.running.as_mut() {
            t.deadline = now + timeout;
        }
        let m = request_item(self.key, mt, done, self.int_items);
        out.push(MissionOut::Send(m));
    }

    fn on_request(&mut self, now: Micros, seq: u16, mission_type: u8, out: &mut Vec<MissionOut>) {
        let Some(t) = self.running.as_mut() else {
            return;
        };
        let Request::Upload(mt, items) = &t.req else {
            return;
        };
        let mt = *mt;
        if mt.code() != mission_type {
            return;
        }
        let asked = match t.phase {
            Phase::Count => None,
            Phase::Answering { asked } => Some(asked),
            _ => return,
        };
        let n = items.len();
        let Some(item) = items.get(seq as usize).copied() else {
            let reason = format!("the vehicle asked for item {seq} of {n}");
            self.fail(now, reason, out);
            return;
        };
        let highest = asked.map_or(seq, |a| a.max(seq));
        t.phase = Phase::Answering { asked: highest };
        t.deadline = now + VEHICLE_WAIT;
        if asked.is_none_or(|a| seq > a) {
            out.push(MissionOut::Event(MissionEvent::Progress {
                op: OpKind::Upload,
                mission_type: mt,
                done: seq + 1,
                total: n as u16,
            }));
        }
        out.push(MissionOut::Send(item_message(self.key.into(), &item)));
    }

    fn on_ack(
        &mut self,
        now: Micros,
        result: u8,
        mission_type: u8,
        opaque_id: u32,
        out: &mut Vec<MissionOut>,
    ) {
        let Some(t) = self.running.as_ref() else {
            return;
        };
        let mt = t.req.mission_type();
        if mt.code() != mission_type || result == INVALID_SEQUENCE {
            return;
        }
        if t.phase == Phase::RefusedWait {
            return; // an echo of the refusal: the retry is already planned
        }
        if result != ACCEPTED {
            self.refused(now, result, out);
            return;
        }
        match (&t.req, &t.phase) {
            (Request::Upload(_, items), phase) => {
                let n = items.len() as u16;
                let all = match phase {
                    Phase::Answering { asked } => *asked + 1 == n,
                    _ => n == 0,
                };
                if !all {
                    let asked = match phase {
                        Phase::Answering { asked } => *asked as usize + 1,
                        _ => 0,
                    };
                    let reason = format!(
                        "the vehicle accepted after asking for {asked} of {n} items: download \
                         it to see what it holds"
                    );
                    self.fail(now, reason, out);
                    return;
                }
                self.known[mt.index()] = Some(Known {
                    items: items.clone(),
                    opaque_id,
                    downloaded: false,
                    at: now,
                });
                self.said_changed[mt.index()] = 0;
                let ev = MissionEvent::Uploaded {
                    mission_type: mt,
                    count: n,
                    opaque_id,
                };
                self.finish(now, ev, out);
            }
            (Request::Clear(_), Phase::Clear) => {
                self.known[mt.index()] = Some(Known {
                    items: Vec::new(),
                    opaque_id,
                    downloaded: false,
                    at: now,
                });
                self.finish(now, MissionEvent::Cleared { mission_type: mt }, out);
            }
            // An ACCEPTED while downloading is not an answer to anything we asked.
            _ => {}
        }
    }

    /// Timeouts and resends due at `now`.
    pub fn poll(&mut self, now: Micros) -> Vec<MissionOut> {
        let mut out = Vec::new();
        if std::mem::take(&mut self.rebooted) {
            self.queue.clear();
            self.set_current = None;
            self.linger = None;
            self.current = None;
            self.fail(now, "the vehicle rebooted".into(), &mut out);
        }
        if let Some((seq, deadline)) = self.set_current {
            if now >= deadline {
                self.set_current = None;
                out.push(MissionOut::Event(MissionEvent::SetCurrentFailed {
                    seq,
                    now_at: self.current.map(|c| c.seq),
                }));
            }
        }
        let item_timeout = self.item_timeout();
        let Some(t) = self.running.as_mut().filter(|t| now >= t.deadline) else {
            return out;
        };
        let mt = t.req.mission_type();
        let n_items = match &t.req {
            Request::Upload(_, items) => items.len() as u16,
            _ => 0,
        };
        // Answering: the vehicle drives; its silence ends the upload.
        if let Phase::Answering { asked } = t.phase {
            let reason = if asked + 1 == n_items {
                format!(
                    "no MISSION_ACK after the last item ({:.0} s): the vehicle may or may not \
                     have taken the {mt}; download it to see",
                    VEHICLE_WAIT as f64 / 1e6
                )
            } else {
                format!(
                    "the vehicle stopped asking for items after {} of {n_items}",
                    asked + 1
                )
            };
            self.fail(now, reason, &mut out);
            return out;
        }
        if t.phase == Phase::RefusedWait {
            t.phase = Phase::Count;
            t.retries = 0;
            t.deadline = now + ACK_TIMEOUT;
            let m = count_message(self.key, mt, n_items);
            out.push(MissionOut::Send(m));
            return out;
        }
        if t.retries >= MAX_RETRIES {
            let what = match &t.phase {
                Phase::List => "no MISSION_COUNT".to_string(),
                Phase::Items { items, count, .. } => {
                    format!("item {} of {count} never came", items.len())
                }
                Phase::Count => "no MISSION_REQUEST for MISSION_COUNT".to_string(),
                Phase::Clear => "no MISSION_ACK for MISSION_CLEAR_ALL".to_string(),
                Phase::Answering { .. } | Phase::RefusedWait => String::new(),
            };
            let reason = format!("{what} after {} sends", t.retries + 1);
            self.fail(now, reason, &mut out);
            return out;
        }
        t.retries += 1;
        let (msg, wait) = match &mut t.phase {
            Phase::List => (request_list(self.key, mt), ACK_TIMEOUT),
            Phase::Items { items, asked, .. } => {
                *asked = now;
                let seq = items.len() as u16;
                (
                    request_item(self.key, mt, seq, self.int_items),
                    item_timeout,
                )
            }
            Phase::Count => (count_message(self.key, mt, n_items), ACK_TIMEOUT),
            Phase::Clear => (clear_message(self.key, mt), ACK_TIMEOUT),
            Phase::Answering { .. } | Phase::RefusedWait => unreachable!("handled above"),
        };
        t.deadline = now + wait;
        out.push(MissionOut::Send(msg));
        out
    }

    /// The vehicle rebooted: what it was doing with us is forgotten on its side. The running
    /// transfer fails and the queue is dropped at the next [`MissionMachine::poll`].
    pub fn on_reboot(&mut self) {
        self.rebooted = true;
    }

    /// When it next needs a poll: a reboot heard is work for the poll at once (0).
    pub fn next_deadline(&self) -> Option<Micros> {
        [
            self.rebooted.then_some(0),
            self.running.as_ref().map(|t| t.deadline),
            self.set_current.map(|(_, d)| d),
        ]
        .into_iter()
        .flatten()
        .min()
    }
}

impl MissionMachine {
    /// Its output in the one contract: messages go to the vehicle on its route (the operator
    /// asked for every transfer), the events worth telling become notices.
    fn emit(&self, outs: Vec<MissionOut>, out: &mut Vec<Out>) {
        for o in outs {
            match o {
                MissionOut::Send(m) => out.push(Out::send(Route::Vehicle, m)),
                MissionOut::Event(e) => match (e.ends(), e.notice(self.key)) {
                    (Some((ask, done)), Some(notice)) => {
                        out.push(Out::Event(MachineEvent::MissionEnd { ask, done, notice }))
                    }
                    (_, Some((sev, text))) => out.push(Out::notice(sev, text)),
                    (_, None) => {}
                },
            }
        }
    }

    /// [`MissionMachine::submit`] in the one contract.
    pub fn submit_out(&mut self, now: Micros, req: Request) -> Result<Vec<Out>, String> {
        let o = self.submit(now, req)?;
        let mut out = Vec::new();
        self.emit(o, &mut out);
        Ok(out)
    }

    /// [`MissionMachine::set_current`] in the one contract.
    pub fn set_current_out(&mut self, now: Micros, seq: u16) -> Result<Vec<Out>, String> {
        let o = self.set_current(now, seq)?;
        let mut out = Vec::new();
        self.emit(o, &mut out);
        Ok(out)
    }
}

impl Machine for MissionMachine {
    const IDS: Ids = Ids::Only(&[
        id::MISSION_COUNT,
        id::MISSION_ITEM_INT,
        id::MISSION_ITEM,
        id::MISSION_REQUEST_INT,
        id::MISSION_REQUEST,
        id::MISSION_ACK,
        id::MISSION_CURRENT,
        id::MISSION_ITEM_REACHED,
        dialect::AUTOPILOT_VERSION_DATA::ID,
    ]);
    /// All read from their payloads.
    const DECODES: Ids = Ids::Only(&[]);

    fn on_message(&mut self, m: &Incoming, out: &mut Vec<Out>) {
        if m.id == dialect::AUTOPILOT_VERSION_DATA::ID {
            // Capabilities u64 first.
            self.on_capabilities(Payload(m.payload).u64(0));
            return;
        }
        if let Some(msg) = MissionMsg::read(m.id, m.payload) {
            let o = MissionMachine::on_message(self, m.now, &msg);
            self.emit(o, out);
        }
    }

    fn poll(&mut self, now: Micros, out: &mut Vec<Out>) {
        let o = MissionMachine::poll(self, now);
        self.emit(o, out);
    }

    fn next_deadline(&self) -> Option<Micros> {
        MissionMachine::next_deadline(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mission::{cmd, frame};

    const V: VehicleKey = VehicleKey(1, 1);
    const US: (u8, u8) = (255, 190);

    fn wp(seq: u16, z: f32) -> MissionItem {
        MissionItem::at(
            MissionType::Mission,
            seq,
            frame::GLOBAL_RELATIVE_ALT,
            cmd::NAV_WAYPOINT,
            -35.36,
            149.16,
            z,
        )
    }

    fn sends(out: &[MissionOut]) -> Vec<&MavMessage> {
        out.iter()
            .filter_map(|o| match o {
                MissionOut::Send(m) => Some(m),
                _ => None,
            })
            .collect()
    }

    fn events(out: &[MissionOut]) -> Vec<&MissionEvent> {
        out.iter()
            .filter_map(|o| match o {
                MissionOut::Event(e) => Some(e),
                _ => None,
            })
            .collect()
    }

    fn request(seq: u16, legacy: bool) -> MissionMsg {
        MissionMsg::Request {
            target: US,
            seq,
            mission_type: 0,
            legacy,
        }
    }

    fn ack(result: u8, t: u8) -> MissionMsg {
        MissionMsg::Ack {
            target: US,
            result,
            mission_type: t,
            opaque_id: 0,
        }
    }

    fn item_seq(m: &MavMessage) -> u16 {
        match m {
            MavMessage::MISSION_ITEM_INT(i) => i.seq,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn payloads_read_like_the_dialect_writes_them() {
        use mavlink::Message;
        let item = wp(3, 20.0);
        let m = item_message(V.into(), &item);
        let mut buf = [0u8; 255];
        let n = m.ser(mavlink::MavlinkVersion::V2, &mut buf);
        match MissionMsg::read(id::MISSION_ITEM_INT, &buf[..n]).unwrap() {
            MissionMsg::Item {
                target,
                item: got,
                mission_type,
                legacy,
            } => {
                assert_eq!((target, mission_type, legacy), (V.into(), 0, false));
                assert_eq!(got, item);
            }
            other => panic!("{other:?}"),
        }
        let c = MavMessage::MISSION_COUNT(dialect::MISSION_COUNT_DATA {
            count: 300,
            target_system: 255,
            target_component: 190,
            mission_type: MavMissionType::MAV_MISSION_TYPE_FENCE,
            opaque_id: 0xdead_beef,
        });
        let n = c.ser(mavlink::MavlinkVersion::V2, &mut buf);
        assert_eq!(
            MissionMsg::read(id::MISSION_COUNT, &buf[..n]),
            Some(MissionMsg::Count {
                target: US,
                count: 300,
                mission_type: 1,
                opaque_id: 0xdead_beef
            })
        );
        let cur = MavMessage::MISSION_CURRENT(dialect::MISSION_CURRENT_DATA {
            seq: 4,
            total: 5,
            mission_state: dialect::MissionState::MISSION_STATE_ACTIVE,
            mission_mode: 1,
            mission_id: 7,
            fence_id: 8,
            rally_points_id: 9,
        });
        let n = cur.ser(mavlink::MavlinkVersion::V2, &mut buf);
        assert_eq!(
            MissionMsg::read(id::MISSION_CURRENT, &buf[..n]),
            Some(MissionMsg::Current(Current {
                seq: 4,
                total: 5,
                state: 3,
                mode: 1,
                ids: [7, 8, 9]
            }))
        );
    }

    #[test]
    fn upload_answers_each_request_even_twice_and_legacy_ones_with_item_int() {
        let mut m = MissionMachine::new(V);
        let items = vec![wp(0, 584.0), wp(1, 15.0), wp(2, 20.0)];
        let out = m
            .submit(0, Request::Upload(MissionType::Mission, items.clone()))
            .unwrap();
        match sends(&out)[..] {
            [MavMessage::MISSION_COUNT(c)] => assert_eq!((c.count, c.target_system), (3, 1)),
            ref other => panic!("{other:?}"),
        }
        let mut answered = Vec::new();
        for (t, seq) in [(10, 0), (20, 1), (30, 1), (40, 2)] {
            let out = m.on_message(t, &request(seq, seq == 1));
            answered.extend(sends(&out).into_iter().map(item_seq));
        }
        assert_eq!(answered, [0, 1, 1, 2]);
        assert_eq!(
            m.progress(),
            Some(Progress {
                op: OpKind::Upload,
                mission_type: MissionType::Mission,
                done: 2,
                total: Some(3)
            })
        );
        let out = m.on_message(50, &ack(0, 0));
        assert!(matches!(
            events(&out)[..],
            [MissionEvent::Uploaded { count: 3, .. }]
        ));
        assert_eq!(m.known(MissionType::Mission).unwrap().items, items);
        assert_eq!(m.next_deadline(), None);
    }

    #[test]
    fn no_final_ack_is_a_failure_that_says_what_may_have_happened() {
        let mut m = MissionMachine::new(V);
        m.submit(0, Request::Upload(MissionType::Mission, vec![wp(0, 1.0)]))
            .unwrap();
        m.on_message(10, &request(0, false));
        assert!(m.poll(10 + VEHICLE_WAIT - 1).is_empty());
        let out = m.poll(10 + VEHICLE_WAIT);
        match events(&out)[..] {
            [MissionEvent::Failed { reason, .. }] => {
                assert!(
                    reason.contains("no MISSION_ACK after the last item"),
                    "{reason}"
                )
            }
            ref other => panic!("{other:?}"),
        }
        assert!(sends(&out).is_empty(), "nothing resent");
        assert!(!m.busy());
    }

    #[test]
    fn count_resent_until_requests_come_then_given_up() {
        let mut m = MissionMachine::new(V);
        // Items of another list are refused before anything is sent.
        let e = m
            .submit(0, Request::Upload(MissionType::Fence, vec![wp(0, 1.0)]))
            .unwrap_err();
        assert!(e.contains("not a fence item"), "{e}");
        let mut f = MissionItem::at(MissionType::Fence, 0, 0, 5001, 1.0, 2.0, 0.0);
        f.params[0] = 3.0;
        let fence: Vec<MissionItem> = (0..3).map(|s| MissionItem { seq: s, ..f }).collect();
        m.submit(0, Request::Upload(MissionType::Fence, fence))
            .unwrap();
        let mut counts = 1;
        let mut t;
        loop {
            t = m.next_deadline().unwrap();
            let out = m.poll(t);
            counts += sends(&out).len();
            if let [MissionEvent::Failed { reason, .. }] = events(&out)[..] {
                assert!(reason.contains("after 6 sends"), "{reason}");
                break;
            }
        }
        assert_eq!(counts, 6, "MISSION_COUNT sent 1 + MAX_RETRIES times");
        assert_eq!(t, 6 * ACK_TIMEOUT);
    }

    #[test]
    fn no_space_at_the_start_is_shown_and_tried_again() {
        let mut m = MissionMachine::new(V);
        m.submit(
            0,
            Request::Upload(MissionType::Mission, vec![wp(0, 1.0), wp(1, 2.0)]),
        )
        .unwrap();
        m.on_text(50, "Calibrating barometer");
        let out = m.on_message(100, &ack(NO_SPACE, 0));
        assert!(matches!(
            events(&out)[..],
            [MissionEvent::Refused {
                result: 4,
                retry_in: Some(NO_SPACE_WAIT),
                ..
            }]
        ));
        assert_eq!(
            m.last_refusal().unwrap().reason.as_deref(),
            Some("Calibrating barometer"),
            "a text just before, until one comes after"
        );
        m.on_text(110, "Only 0 items are supported");
        m.on_text(120, "Barometer 1 calibration complete");
        assert_eq!(
            m.last_refusal().unwrap().reason.as_deref(),
            Some("Only 0 items are supported")
        );
        assert_eq!(m.next_deadline(), Some(100 + NO_SPACE_WAIT));
        let out = m.poll(100 + NO_SPACE_WAIT);
        assert!(matches!(sends(&out)[..], [MavMessage::MISSION_COUNT(_)]));
        // Refused twice more: the third is final.
        m.on_message(200 + NO_SPACE_WAIT, &ack(NO_SPACE, 0));
        m.poll(200 + 2 * NO_SPACE_WAIT);
        let out = m.on_message(300 + 2 * NO_SPACE_WAIT, &ack(NO_SPACE, 0));
        assert!(matches!(
            events(&out)[..],
            [MissionEvent::Refused {
                result: 4,
                retry_in: None,
                ..
            }]
        ));
        assert!(!m.busy());
        let (sev, text) = events(&out)[0].notice(V).unwrap();
        assert_eq!(sev, Severity::WARNING);
        assert_eq!(text, "mission upload refused by 1:1: NO_SPACE");
    }

    #[test]
    fn autopilot_version_without_mission_int_downloads_with_mission_request() {
        use mavlink::Message;
        // The first request after MISSION_COUNT, as (message id, payload bytes).
        let first_request = |caps: Option<u64>| {
            let mut m = MissionMachine::new(V);
            if let Some(c) = caps {
                m.on_capabilities(c);
            }
            m.submit(0, Request::Download(MissionType::Mission))
                .unwrap();
            let out = m.on_message(
                10,
                &MissionMsg::Count {
                    target: US,
                    count: 2,
                    mission_type: 0,
                    opaque_id: 0,
                },
            );
            let msg = sends(&out)[0].clone();
            let mut buf = [0u8; 255];
            let n = msg.ser(mavlink::MavlinkVersion::V2, &mut buf);
            (msg.message_id(), buf[..n].to_vec())
        };
        // The spec: MISSION_REQUEST is id 40, MISSION_REQUEST_INT id 51; both seq (u16),
        // target system, target component, mission type (its zero cut by MAVLink 2).
        assert_eq!(first_request(Some(0)), (40, vec![0, 0, 1, 1]));
        // The bit announced, or nothing heard (the profile: INT).
        assert_eq!(first_request(Some(CAP_MISSION_INT)), (51, vec![0, 0, 1, 1]));
        assert_eq!(first_request(None), (51, vec![0, 0, 1, 1]));
        // MISSION_ITEM's answer is taken: the next request follows it in the same form.
        let mut m = MissionMachine::new(V);
        m.on_capabilities(0);
        m.submit(0, Request::Download(MissionType::Mission))
            .unwrap();
        m.on_message(
            10,
            &MissionMsg::Count {
                target: US,
                count: 2,
                mission_type: 0,
                opaque_id: 0,
            },
        );
        let out = m.on_message(
            20,
            &MissionMsg::Item {
                target: US,
                mission_type: 0,
                item: wp(0, 0.0),
                legacy: true,
            },
        );
        #[allow(deprecated)]
        let next = matches!(sends(&out)[..], [MavMessage::MISSION_REQUEST(r)] if r.seq == 1);
        assert!(next, "{out:?}");
    }

    #[test]
    fn download_re_requests_a_lost_item_and_ignores_unrequested_ones() {
        let mut m = MissionMachine::new(V);
        let out = m
            .submit(0, Request::Download(MissionType::Mission))
            .unwrap();
        assert!(matches!(
            sends(&out)[..],
            [MavMessage::MISSION_REQUEST_LIST(_)]
        ));
        let out = m.on_message(
            10,
            &MissionMsg::Count {
                target: US,
                count: 3,
                mission_type: 0,
                opaque_id: 77,
            },
        );
        assert!(matches!(sends(&out)[..], [MavMessage::MISSION_REQUEST_INT(r)] if r.seq == 0));
        let item = |seq, t: u8| MissionMsg::Item {
            target: US,
            mission_type: t,
            item: wp(seq, seq as f32),
            legacy: false,
        };
        // Item 1 (not asked for) and a fence item 0: ignored.
        assert!(m.on_message(20, &item(1, 0)).is_empty());
        assert!(m.on_message(21, &item(0, 1)).is_empty());
        let out = m.on_message(22, &item(0, 0));
        assert!(matches!(sends(&out)[..], [MavMessage::MISSION_REQUEST_INT(r)] if r.seq == 1));
        // Item 1 lost: asked for again after the item timeout.
        let t = m.next_deadline().unwrap();
        assert_eq!(t, 22 + ITEM_TIMEOUT);
        let out = m.poll(t);
        assert!(matches!(sends(&out)[..], [MavMessage::MISSION_REQUEST_INT(r)] if r.seq == 1));
        m.on_message(t + 5, &item(1, 0));
        let out = m.on_message(t + 6, &item(2, 0));
        assert!(
            matches!(sends(&out)[..], [MavMessage::MISSION_ACK(a)] if a.mission_type == MavMissionType::MAV_MISSION_TYPE_MISSION)
        );
        match events(&out)[..] {
            [_, MissionEvent::Downloaded {
                items,
                opaque_id: 77,
                ..
            }] => {
                assert_eq!(items.iter().map(|i| i.seq).collect::<Vec<_>>(), [0, 1, 2])
            }
            ref other => panic!("{other:?}"),
        }
        // Our ACK lost: the vehicle sends the last item again, and gets the ACK again.
        let out = m.on_message(t + 100, &item(2, 0));
        assert!(matches!(sends(&out)[..], [MavMessage::MISSION_ACK(_)]));
        assert!(m.on_message(t + 100 + LINGER + 1, &item(2, 0)).is_empty());
    }

    #[test]
    fn transfers_queue_one_at_a_time() {
        let mut m = MissionMachine::new(V);
        m.submit(0, Request::Download(MissionType::Mission))
            .unwrap();
        let out = m.submit(1, Request::Download(MissionType::Fence)).unwrap();
        assert!(sends(&out).is_empty());
        assert!(matches!(
            events(&out)[..],
            [MissionEvent::Queued { ahead: 1, .. }]
        ));
        assert!(m.submit(2, Request::Download(MissionType::Fence)).is_err());
        assert!(m
            .submit(2, Request::Download(MissionType::Mission))
            .is_err());
        let out = m.on_message(
            10,
            &MissionMsg::Count {
                target: US,
                count: 0,
                mission_type: 0,
                opaque_id: 0,
            },
        );
        // The empty mission acknowledged, the fence download started.
        let s = sends(&out);
        assert!(matches!(s[0], MavMessage::MISSION_ACK(_)));
        assert!(
            matches!(s[1], MavMessage::MISSION_REQUEST_LIST(r) if r.mission_type == MavMissionType::MAV_MISSION_TYPE_FENCE)
        );
    }

    #[test]
    fn another_gcss_exchange_is_not_ours() {
        let mut m = MissionMachine::new(V);
        m.submit(0, Request::Upload(MissionType::Mission, vec![wp(0, 1.0)]))
            .unwrap();
        let other = MissionMsg::Request {
            target: (254, 190),
            seq: 0,
            mission_type: 0,
            legacy: false,
        };
        assert!(m.on_message(5, &other).is_empty());
    }

    #[test]
    fn current_item_set_and_plan_changes_seen() {
        let mut m = MissionMachine::new(V);
        let out = m.set_current(0, 3).unwrap();
        assert!(
            matches!(sends(&out)[..], [MavMessage::MISSION_SET_CURRENT(s)] if s.seq == 3 && s.target_system == 1)
        );
        let cur = |seq, ids| {
            MissionMsg::Current(Current {
                seq,
                total: 5,
                state: 3,
                mode: 1,
                ids,
            })
        };
        m.on_message(10, &cur(1, [0; 3]));
        let out = m.on_message(20, &cur(3, [0; 3]));
        assert!(events(&out).contains(&&MissionEvent::CurrentSet { seq: 3 }));
        // Not taken: said once, not resent.
        m.set_current(30, 4).unwrap();
        let out = m.poll(30 + SET_CURRENT_TIMEOUT);
        assert_eq!(
            events(&out),
            [&MissionEvent::SetCurrentFailed {
                seq: 4,
                now_at: Some(3)
            }]
        );
        assert!(sends(&out).is_empty());
        // A plan id differing from the one downloaded: said once.
        m.submit(100, Request::Download(MissionType::Mission))
            .unwrap();
        m.on_message(
            110,
            &MissionMsg::Count {
                target: US,
                count: 0,
                mission_type: 0,
                opaque_id: 5,
            },
        );
        assert!(!m.changed_on_vehicle(MissionType::Mission));
        assert!(events(&m.on_message(120, &cur(3, [5, 0, 0])))
            .iter()
            .all(|e| !matches!(e, MissionEvent::PlanChanged { .. })));
        let out = m.on_message(130, &cur(3, [6, 0, 0]));
        assert!(events(&out).contains(&&MissionEvent::PlanChanged {
            mission_type: MissionType::Mission,
            id: 6,
            ours: 5
        }));
        assert!(m.on_message(140, &cur(3, [6, 0, 0])).is_empty());
        assert!(m.changed_on_vehicle(MissionType::Mission));
    }

    #[test]
    fn items_the_dialect_cannot_carry_are_refused_before_anything_is_sent() {
        let mut m = MissionMachine::new(V);
        let mut odd = wp(1, 1.0);
        odd.command = 31_999;
        let e = m
            .submit(
                0,
                Request::Upload(MissionType::Mission, vec![wp(0, 1.0), odd]),
            )
            .unwrap_err();
        assert!(e.contains("command 31999"), "{e}");
        let e = m
            .submit(0, Request::Upload(MissionType::Mission, vec![wp(1, 1.0)]))
            .unwrap_err();
        assert!(e.contains("sequence number 1"), "{e}");
        assert!(!m.busy());
    }
}
