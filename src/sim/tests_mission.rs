//! The mission protocol, AUTO and GUIDED targets of the simulated vehicle, on a virtual clock.
//!
//! Expected values come from ArduPilot's code (cited where used) or from the real ArduCopter
//! capture `assets/sim/testdata/copter-mission.*` (copied from the shared captures: the GCS
//! side whole, the vehicle side filtered to its MISSION_*, STATUSTEXT, PARAM_VALUE and
//! COMMAND_ACK frames, bytes unchanged).

use super::mission::{cmd, frame, item_payload, mission_type, msgid, parse, Incoming, MissionItem};
use super::vehicle::mode;
use super::*;
use crate::clock::SECOND;
use crate::dialect::*;
use crate::wire::frame::Frame;

const GCS: (u8, u8) = (255, 190);

/// A GCS on a virtual clock: what it sends goes straight to the sim, every frame the sim emits
/// is kept with the time it came out.
struct Bench {
    sim: Sim,
    now: Micros,
    parser: FrameParser,
    frames: Vec<(Micros, Frame)>,
    seq: u8,
}

impl Bench {
    fn new(query: &str) -> Bench {
        Bench {
            sim: Sim::new(SimConfig::from_query(query).unwrap()),
            now: 0,
            parser: FrameParser::new(),
            frames: Vec::new(),
            seq: 0,
        }
    }

    fn header(&mut self) -> Header {
        let h = Header {
            sysid: GCS.0,
            compid: GCS.1,
            seq: self.seq,
        };
        self.seq = self.seq.wrapping_add(1);
        h
    }

    fn send(&mut self, msg: MavMessage) {
        let h = self.header();
        let bytes = encode(Version::V2, h, &msg);
        self.sim.receive(self.now, &bytes);
    }

    fn send_raw(&mut self, id: u32, payload: &[u8]) {
        let h = self.header();
        let bytes = encode_raw(h, id, payload);
        self.sim.receive(self.now, &bytes);
    }

    fn run_until(&mut self, until: Micros) {
        loop {
            let next = self.sim.next_deadline().min(until);
            self.now = next;
            let out = self.sim.poll(self.now);
            let now = self.now;
            let frames = &mut self.frames;
            self.parser.push(&out, |f| frames.push((now, f)));
            if self.now >= until {
                break;
            }
        }
    }

    fn run_for(&mut self, d: Micros) {
        self.run_until(self.now + d);
    }

    fn v(&self) -> &SimVehicle {
        self.sim.vehicle(1).unwrap()
    }

    fn long(&mut self, command: MavCmd, p: [f32; 7]) -> MavResult {
        let from = self.frames.len();
        self.send(MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            param1: p[0],
            param2: p[1],
            param3: p[2],
            param4: p[3],
            param5: p[4],
            param6: p[5],
            param7: p[6],
            command,
            target_system: 1,
            target_component: 1,
            confirmation: 0,
        }));
        self.run_for(20_000);
        self.frames[from..]
            .iter()
            .find_map(|(_, f)| match f.message.as_deref() {
                Some(MavMessage::COMMAND_ACK(a)) if a.command == command => Some(a.result),
                _ => None,
            })
            .expect("a COMMAND_ACK")
    }

    fn set_mode(&mut self, m: u32) -> MavResult {
        self.long(
            MavCmd::MAV_CMD_DO_SET_MODE,
            [1.0, m as f32, 0.0, 0.0, 0.0, 0.0, 0.0],
        )
    }

    /// GUIDED, wait for the EKF, arm; optionally take off to `alt` and wait until there.
    fn guided_armed(&mut self, takeoff: Option<f32>) {
        self.run_until(super::vehicle::EKF_GPS_AT + 100_000);
        assert_eq!(self.set_mode(mode::GUIDED), MavResult::MAV_RESULT_ACCEPTED);
        let arm = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert_eq!(
            self.long(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, arm),
            MavResult::MAV_RESULT_ACCEPTED
        );
        if let Some(alt) = takeoff {
            let p = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, alt];
            assert_eq!(
                self.long(MavCmd::MAV_CMD_NAV_TAKEOFF, p),
                MavResult::MAV_RESULT_ACCEPTED
            );
            while self.v().relative_alt_m() < alt as f64 - 0.01 {
                self.run_for(100_000);
            }
        }
    }

    /// MISSION_CURRENT every `interval` µs (SET_MESSAGE_INTERVAL).
    fn stream_mission_current(&mut self, interval: u32) {
        self.send(MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            command: MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
            param1: msgid::MISSION_CURRENT as f32,
            param2: interval as f32,
            target_system: 1,
            target_component: 1,
            ..Default::default()
        }));
    }

    /// Texts since frame `from`.
    fn texts_since(&self, from: usize) -> Vec<String> {
        self.frames[from..]
            .iter()
            .filter_map(|(_, f)| match f.message.as_deref() {
                Some(MavMessage::STATUSTEXT(t)) => Some(t.text.to_str().unwrap_or("").to_string()),
                _ => None,
            })
            .collect()
    }

    /// MISSION_ITEM_REACHED seqs since frame `from`.
    fn reached_since(&self, from: usize) -> Vec<u16> {
        self.frames[from..]
            .iter()
            .filter(|(_, f)| f.msgid == msgid::MISSION_ITEM_REACHED)
            .map(|(_, f)| {
                let p = f.payload();
                u16::from_le_bytes([p[0], p.get(1).copied().unwrap_or(0)])
            })
            .collect()
    }

    /// MISSION_CURRENT (seq, total, state, mode) since frame `from`, consecutive repeats merged.
    fn mission_current_since(&self, from: usize) -> Vec<(u16, u16, u8, u8)> {
        let mut out: Vec<(u16, u16, u8, u8)> = Vec::new();
        for (_, f) in &self.frames[from..] {
            if let Some(MavMessage::MISSION_CURRENT(m)) = f.message.as_deref() {
                let k = (m.seq, m.total, m.mission_state as u8, m.mission_mode);
                if out.last() != Some(&k) {
                    out.push(k);
                }
            }
        }
        out
    }
}

/// A vehicle-sent mission protocol message, as (kind, fields) for comparing sequences.
#[derive(Debug, Clone, PartialEq)]
enum Proto {
    Request { seq: u16, ty: u8, int: bool },
    Ack { result: u8, ty: u8 },
    Count { count: u16, ty: u8 },
    Item { item: MissionItem, int: bool },
}

fn proto_of(f: &Frame) -> Option<Proto> {
    let p = f.payload();
    Some(match f.msgid {
        msgid::MISSION_ACK => {
            let mut b = p.to_vec();
            b.resize(4, 0);
            Proto::Ack {
                result: b[2],
                ty: b[3],
            }
        }
        msgid::MISSION_REQUEST | msgid::MISSION_REQUEST_INT => match parse(f.msgid, p)?.2 {
            Incoming::Request { seq, ty, int } => Proto::Request { seq, ty, int },
            _ => return None,
        },
        msgid::MISSION_COUNT => match parse(f.msgid, p)?.2 {
            Incoming::Count { count, ty } => Proto::Count { count, ty },
            _ => return None,
        },
        msgid::MISSION_ITEM_INT | msgid::MISSION_ITEM => match parse(f.msgid, p)?.2 {
            Incoming::Item { item, int, .. } => Proto::Item { item, int },
            _ => return None,
        },
        _ => return None,
    })
}

fn protos(frames: &[(Micros, Frame)]) -> Vec<(Micros, Proto)> {
    frames
        .iter()
        .filter_map(|(t, f)| proto_of(f).map(|p| (*t, p)))
        .collect()
}

/// The frames of a tlog (8-byte time, then a MAVLink 2 frame), with their times.
fn tlog_frames(bytes: &[u8]) -> Vec<(u64, Frame)> {
    let mut out = Vec::new();
    let mut parser = FrameParser::new();
    let mut pos = 0;
    while pos + 8 < bytes.len() {
        let t = u64::from_be_bytes(bytes[pos..pos + 8].try_into().unwrap());
        pos += 8;
        let len = bytes[pos + 1] as usize;
        let signed = bytes[pos + 2] & 1 != 0;
        let flen = 12 + len + if signed { 13 } else { 0 };
        for f in parser.parse_all(&bytes[pos..pos + flen]) {
            out.push((t, f));
        }
        pos += flen;
    }
    out
}

const CAPTURE_GCS: &[u8] = include_bytes!("../../assets/sim/testdata/copter-mission.gcs.tlog");
const CAPTURE_VEHICLE: &[u8] =
    include_bytes!("../../assets/sim/testdata/copter-mission.vehicle-mission.tlog");

fn item(seq: u16, command: u16, fr: u8, params: [f32; 4], x: i32, y: i32, z: f32) -> MissionItem {
    MissionItem {
        seq,
        command,
        frame: fr,
        current: 0,
        autocontinue: 1,
        params,
        x,
        y,
        z,
        mission_type: mission_type::MISSION,
    }
}

fn send_item(b: &mut Bench, it: &MissionItem) {
    let p = item_payload(it, (1, 1), true);
    b.send_raw(msgid::MISSION_ITEM_INT, &p);
}

fn send_count(b: &mut Bench, count: u16, ty: u8) {
    let c = count.to_le_bytes();
    b.send_raw(msgid::MISSION_COUNT, &[c[0], c[1], 1, 1, ty]);
}

fn send_request(b: &mut Bench, seq: u16, ty: u8, int: bool) {
    let s = seq.to_le_bytes();
    let id = if int {
        msgid::MISSION_REQUEST_INT
    } else {
        msgid::MISSION_REQUEST
    };
    b.send_raw(id, &[s[0], s[1], 1, 1, ty]);
}

/// How a scripted upload ended.
#[derive(Debug, PartialEq)]
enum Upload {
    Accepted,
    /// An ACK that is not ACCEPTED after the last item was sent: the ACCEPTED was lost and a
    /// resent last item was refused (the download tells whether it arrived).
    AfterLast(u8),
    Failed(u8),
}

/// A minimal GCS upload: COUNT, then each requested item; resend COUNT (nothing heard yet) or
/// the last item after 1.5 s of silence. Returns the outcome and the number of resends.
fn upload(b: &mut Bench, items: &[MissionItem], ty: u8) -> (Upload, u32) {
    let n = items.len() as u16;
    send_count(b, n, ty);
    let mut seen = b.frames.len();
    let mut last_tx = b.now;
    let mut last_sent: Option<u16> = None;
    let mut resends = 0;
    let deadline = b.now + 300 * SECOND;
    while b.now < deadline {
        b.run_for(10_000);
        let new: Vec<Proto> = b.frames[seen..]
            .iter()
            .filter_map(|(_, f)| proto_of(f))
            .collect();
        seen = b.frames.len();
        for p in new {
            match p {
                Proto::Request { seq, ty: t, .. } if t == ty && seq < n => {
                    send_item(b, &items[seq as usize]);
                    last_sent = Some(seq);
                    last_tx = b.now;
                }
                Proto::Ack { result: 0, ty: t } if t == ty => return (Upload::Accepted, resends),
                // An item resent after its request was lost arrives out of turn.
                Proto::Ack { result: 13, .. } => {}
                Proto::Ack { result, ty: t } if t == ty => {
                    return if last_sent == Some(n - 1) {
                        (Upload::AfterLast(result), resends)
                    } else {
                        (Upload::Failed(result), resends)
                    };
                }
                _ => {}
            }
        }
        if b.now - last_tx > 1_500_000 {
            resends += 1;
            match last_sent {
                None => send_count(b, n, ty),
                Some(s) => send_item(b, &items[s as usize]),
            }
            last_tx = b.now;
        }
    }
    panic!("upload did not finish");
}

/// A minimal GCS download with MISSION_REQUEST_INT, resending after 1.5 s without an answer.
fn download(b: &mut Bench, ty: u8) -> Vec<MissionItem> {
    let mut seen = b.frames.len();
    let mut count = None;
    let mut items: Vec<MissionItem> = Vec::new();
    let mut last_tx = b.now;
    b.send_raw(msgid::MISSION_REQUEST_LIST, &[1, 1, ty]);
    let deadline = b.now + 300 * SECOND;
    while b.now < deadline {
        b.run_for(10_000);
        let new: Vec<Proto> = b.frames[seen..]
            .iter()
            .filter_map(|(_, f)| proto_of(f))
            .collect();
        seen = b.frames.len();
        for p in new {
            match p {
                Proto::Count { count: c, ty: t } if t == ty && count.is_none() => {
                    count = Some(c);
                    if c > 0 {
                        send_request(b, 0, ty, true);
                    }
                    last_tx = b.now;
                }
                Proto::Item { item, .. }
                    if item.mission_type == ty && item.seq as usize == items.len() =>
                {
                    items.push(item);
                    if items.len() < count.unwrap_or(0) as usize {
                        send_request(b, items.len() as u16, ty, true);
                    }
                    last_tx = b.now;
                }
                _ => {}
            }
        }
        match count {
            Some(c) if items.len() == c as usize => {
                b.send_raw(msgid::MISSION_ACK, &[1, 1, 0, ty]);
                return items;
            }
            _ => {}
        }
        if b.now - last_tx > 1_500_000 {
            match count {
                None => b.send_raw(msgid::MISSION_REQUEST_LIST, &[1, 1, ty]),
                Some(_) => send_request(b, items.len() as u16, ty, true),
            }
            last_tx = b.now;
        }
    }
    panic!("download did not finish");
}

/// Home, a takeoff, `n - 2` waypoints on a 100 m grid north-east of home, an RTL: integer
/// altitudes and delays, so the stored items equal the uploaded ones (AP_Mission keeps a
/// waypoint's delay and location, and whole metres survive the centimetre round trip).
fn grid_mission(n: u16) -> Vec<MissionItem> {
    let (lat0, lon0) = (-353_632_621, 1_491_652_374);
    let mut v = vec![item(
        0,
        cmd::NAV_WAYPOINT,
        frame::GLOBAL,
        [0.0; 4],
        lat0,
        lon0,
        584.0,
    )];
    v.push(item(
        1,
        cmd::NAV_TAKEOFF,
        frame::GLOBAL_RELATIVE_ALT,
        [0.0; 4],
        0,
        0,
        20.0,
    ));
    for i in 2..n - 1 {
        let (r, c) = ((i - 2) / 8, (i - 2) % 8);
        v.push(item(
            i,
            cmd::NAV_WAYPOINT,
            frame::GLOBAL_RELATIVE_ALT,
            [(i % 3) as f32, 0.0, 0.0, 0.0],
            lat0 + r as i32 * 9_000,
            lon0 + c as i32 * 11_000,
            20.0 + (i % 7) as f32,
        ));
    }
    v.push(item(
        n - 1,
        cmd::NAV_RETURN_TO_LAUNCH,
        frame::GLOBAL,
        [0.0; 4],
        0,
        0,
        0.0,
    ));
    v
}

/// A 50-item mission uploaded and downloaded item by item by a minimal GCS, on a clean link
/// and with 30 % of the frames lost each way: the vehicle asks with MISSION_REQUEST, re-asks
/// on its own after a second, and the download equals the upload (item 0 reads as home).
#[test]
fn fifty_items_up_and_down_clean_and_at_30_percent_loss() {
    let items = grid_mission(50);
    for (query, lossy) in [("", false), ("loss=0.3&impair_in=1&seed=7", true)] {
        let mut b = Bench::new(query);
        b.run_until(super::vehicle::EKF_GPS_AT + 100_000);
        let from = b.frames.len();
        let (outcome, resends) = upload(&mut b, &items, mission_type::MISSION);
        assert!(
            matches!(outcome, Upload::Accepted | Upload::AfterLast(_)),
            "{query}: {outcome:?}"
        );
        let got = download(&mut b, mission_type::MISSION);
        assert_eq!(got.len(), 50, "{query}");
        for (up, down) in items.iter().zip(&got).skip(1) {
            assert_eq!(up, down, "{query}: item {}", up.seq);
        }
        // Item 0 is home (HOME_POSITION: the SITL home, AMSL).
        let home = b.v().home();
        assert_eq!(got[0].x, (home.0 * 1e7).round() as i32);
        assert_eq!(got[0].z, 584.0);
        assert_eq!(b.v().param("MIS_TOTAL"), Some(50.0));
        let requests: Vec<(u16, bool)> = protos(&b.frames[from..])
            .into_iter()
            .filter_map(|(_, p)| match p {
                Proto::Request { seq, ty: 0, int } => Some((seq, int)),
                _ => None,
            })
            .collect();
        // ArduCopter asks with MISSION_REQUEST, never _INT.
        assert!(requests.iter().all(|(_, int)| !int));
        if lossy {
            let truth = b.sim.truth().get(1);
            assert!(truth.dropped > 0 && truth.inbound_dropped > 0, "{truth:?}");
            // The vehicle's own re-requests: some sequence number asked more than once.
            let mut asked = std::collections::BTreeMap::<u16, u32>::new();
            for (s, _) in &requests {
                *asked.entry(*s).or_default() += 1;
            }
            assert!(asked.values().any(|&n| n > 1), "no request repeated");
            assert!(resends > 0, "the GCS never had to resend");
        } else {
            assert_eq!(
                requests.iter().map(|r| r.0).collect::<Vec<_>>(),
                (0..50).collect::<Vec<_>>()
            );
            assert_eq!(resends, 0);
        }
    }
}

/// The GCS side of the real capture replayed at its own times into a sim that refuses uploads
/// for the first 2 s: the vehicle answers exactly what ArduCopter answered — NO_SPACE first,
/// then MISSION_REQUESTs, ACKs, the three counts and every downloaded item field for field
/// (item 0 zeros because home is not set yet, DO_CHANGE_SPEED back in frame GLOBAL, fence
/// items with autocontinue 0, the rally point in GLOBAL_RELATIVE_ALT).
#[test]
fn the_capture_replayed_gets_the_real_copters_answers() {
    let gcs = tlog_frames(CAPTURE_GCS);
    let t0 = gcs[0].0;
    let mut b = Bench::new("mission_boot_ms=2000");
    for (t, f) in &gcs {
        if !super::mission::is_protocol_message(f.msgid) {
            continue;
        }
        b.run_until(t - t0);
        b.send_raw(f.msgid, f.payload());
    }
    b.run_for(SECOND);
    let got: Vec<Proto> = protos(&b.frames).into_iter().map(|(_, p)| p).collect();
    let want: Vec<Proto> = tlog_frames(CAPTURE_VEHICLE)
        .iter()
        .filter_map(|(_, f)| proto_of(f))
        .collect();
    assert_eq!(want.len(), 29, "the capture's protocol messages");
    assert_eq!(got, want);
    let texts = b.texts_since(0);
    for t in [
        "Only 0 items are supported",
        "Flight plan received",
        "Fence Indexed OK",
    ] {
        assert!(texts.iter().any(|x| x == t), "{t} in {texts:?}");
    }
    assert_eq!(b.v().param("MIS_TOTAL"), Some(6.0));
    // The capture's FENCE_TOTAL and RALLY_TOTAL notifications.
    for (name, value) in [("FENCE_TOTAL", 6.0), ("RALLY_TOTAL", 1.0)] {
        let notified = b.frames.iter().any(|(_, f)| {
            matches!(f.message.as_deref(), Some(MavMessage::PARAM_VALUE(p))
                if p.param_id.to_str().unwrap_or("") == name && p.param_value == value && p.param_index == u16::MAX)
        });
        assert!(notified, "{name} {value}");
    }
}

/// Fence (4 inclusion vertices and a return point) and rally (one point) round trips; a fence
/// that does not validate is refused whole and the stored one stays.
#[test]
fn fence_and_rally_round_trips() {
    let mut b = Bench::new("");
    b.run_for(SECOND);
    let corners = [
        (-353_650_576, 1_491_630_269),
        (-353_605_660, 1_491_630_269),
        (-353_605_660, 1_491_685_346),
        (-353_650_576, 1_491_685_346),
    ];
    let mut fence: Vec<MissionItem> = corners
        .iter()
        .enumerate()
        .map(|(i, &(x, y))| MissionItem {
            mission_type: mission_type::FENCE,
            ..item(
                i as u16,
                cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                frame::GLOBAL,
                [4.0, 0.0, 0.0, 0.0],
                x,
                y,
                0.0,
            )
        })
        .collect();
    fence.push(MissionItem {
        mission_type: mission_type::FENCE,
        ..item(
            4,
            cmd::NAV_FENCE_RETURN_POINT,
            frame::GLOBAL_RELATIVE_ALT,
            [0.0; 4],
            -353_632_621,
            1_491_652_374,
            0.0,
        )
    });
    assert_eq!(
        upload(&mut b, &fence, mission_type::FENCE).0,
        Upload::Accepted
    );
    let got = download(&mut b, mission_type::FENCE);
    assert_eq!(got.len(), 5);
    for (up, down) in fence.iter().zip(&got) {
        // AC_PolyFence keeps command, param1 and lat/lon; frame GLOBAL, autocontinue 0.
        assert_eq!(
            (down.command, down.params[0], down.x, down.y),
            (up.command, up.params[0], up.x, up.y)
        );
        assert_eq!(
            (down.frame, down.autocontinue, down.z),
            (frame::GLOBAL, 0, 0.0)
        );
    }
    assert_eq!(b.v().param("FENCE_TOTAL"), Some(6.0));
    // Three vertices announced as four: "Incorrect item count", ERROR, the old fence stays.
    let bad: Vec<MissionItem> = fence[..3].to_vec();
    let from = b.frames.len();
    assert_eq!(
        upload(&mut b, &bad, mission_type::FENCE).0,
        Upload::AfterLast(1)
    );
    let texts = b.texts_since(from);
    assert!(
        texts.contains(&"Incorrect item count".to_string()),
        "{texts:?}"
    );
    assert!(
        texts.contains(&"Fence validation failed".to_string()),
        "{texts:?}"
    );
    assert_eq!(b.v().stored_items(mission_type::FENCE).len(), 5);

    let rally = [MissionItem {
        mission_type: mission_type::RALLY,
        ..item(
            0,
            cmd::NAV_RALLY_POINT,
            frame::GLOBAL_RELATIVE_ALT_INT,
            [0.0; 4],
            -353_635_304,
            1_491_654_503,
            15.0,
        )
    }];
    assert_eq!(
        upload(&mut b, &rally, mission_type::RALLY).0,
        Upload::Accepted
    );
    let got = download(&mut b, mission_type::RALLY);
    assert_eq!(got.len(), 1);
    assert_eq!(
        (got[0].frame, got[0].x, got[0].y, got[0].z),
        (
            frame::GLOBAL_RELATIVE_ALT,
            -353_635_304,
            1_491_654_503,
            15.0
        )
    );
    assert_eq!(b.v().param("RALLY_TOTAL"), Some(1.0));
    // A rally point must be relative to home.
    let abs = [MissionItem {
        frame: frame::GLOBAL,
        ..rally[0]
    }];
    assert_eq!(
        upload(&mut b, &abs, mission_type::RALLY).0,
        Upload::AfterLast(2)
    );

    // MISSION_CLEAR_ALL per type.
    let from = b.frames.len();
    b.send_raw(msgid::MISSION_CLEAR_ALL, &[1, 1, mission_type::RALLY]);
    b.run_for(20_000);
    assert_eq!(
        protos(&b.frames[from..])
            .into_iter()
            .map(|p| p.1)
            .collect::<Vec<_>>(),
        vec![Proto::Ack {
            result: 0,
            ty: mission_type::RALLY
        }]
    );
    assert!(b.v().stored_items(mission_type::RALLY).is_empty());
    assert_eq!(b.v().stored_items(mission_type::FENCE).len(), 5);
}

/// A request asked twice is answered twice; an item sent twice is refused the second time with
/// INVALID_SEQUENCE and the upload goes on; a second GCS is DENIED while one uploads; a
/// download is DENIED during an upload.
#[test]
fn duplicates_and_interleavings() {
    let mut b = Bench::new("");
    b.run_for(SECOND);
    let items = grid_mission(4);
    assert_eq!(upload(&mut b, &items, 0).0, Upload::Accepted);
    let from = b.frames.len();
    send_request(&mut b, 2, 0, true);
    send_request(&mut b, 2, 0, true);
    b.run_for(20_000);
    let answers: Vec<Proto> = protos(&b.frames[from..]).into_iter().map(|p| p.1).collect();
    let want = Proto::Item {
        item: items[2],
        int: true,
    };
    assert_eq!(answers, vec![want.clone(), want]);

    // Upload with a duplicated item.
    let from = b.frames.len();
    send_count(&mut b, 4, 0);
    b.run_for(20_000);
    send_item(&mut b, &items[0]);
    send_item(&mut b, &items[0]);
    b.run_for(20_000);
    // Another GCS tries to upload meanwhile; a download is refused too.
    let h = Header {
        sysid: 200,
        compid: 1,
        seq: 0,
    };
    b.sim.receive(
        b.now,
        &encode_raw(h, msgid::MISSION_COUNT, &[2, 0, 1, 1, 0]),
    );
    b.send_raw(msgid::MISSION_REQUEST_LIST, &[1, 1, 0]);
    b.run_for(20_000);
    let got: Vec<Proto> = protos(&b.frames[from..]).into_iter().map(|p| p.1).collect();
    assert_eq!(
        got,
        vec![
            Proto::Request {
                seq: 0,
                ty: 0,
                int: false
            },
            Proto::Request {
                seq: 1,
                ty: 0,
                int: false
            },
            Proto::Ack {
                result: MavMissionResult::MAV_MISSION_INVALID_SEQUENCE as u8,
                ty: 0
            },
            Proto::Ack {
                result: MavMissionResult::MAV_MISSION_DENIED as u8,
                ty: 0
            },
            Proto::Ack {
                result: MavMissionResult::MAV_MISSION_DENIED as u8,
                ty: 0
            },
        ]
    );
    assert!(b.v().mission_receiving(0));
}

/// MissionItemProtocol::update: with no item the request is re-sent each time more than a
/// second has passed, and after more than 8 s the upload is cancelled ("Mission upload
/// timeout", MAV_MISSION_OPERATION_CANCELLED). What arrived stays written (ArduPilot writes
/// waypoints as they come): the mission is now home and one item.
#[test]
fn re_requests_each_second_then_cancels_after_eight() {
    let mut b = Bench::new("");
    b.run_for(SECOND);
    let items = grid_mission(5);
    send_count(&mut b, 5, 0);
    b.run_for(20_000);
    send_item(&mut b, &items[0]);
    send_item(&mut b, &items[1]);
    let t_item = b.now;
    let from = b.frames.len();
    b.run_for(10 * SECOND);
    let got = protos(&b.frames[from..]);
    let requests: Vec<Micros> = got
        .iter()
        .filter(|(_, p)| matches!(p, Proto::Request { seq: 2, .. }))
        .map(|(t, _)| t - t_item)
        .collect();
    // Immediately, then at the first 10 ms tick more than 1 s after the previous.
    assert_eq!(
        requests,
        vec![0, 1_010_000, 2_020_000, 3_030_000, 4_040_000, 5_050_000, 6_060_000, 7_070_000]
    );
    let cancel: Vec<(Micros, Proto)> = got
        .into_iter()
        .filter(|(_, p)| matches!(p, Proto::Ack { .. }))
        .collect();
    assert_eq!(
        cancel,
        vec![(t_item + 8_010_000, Proto::Ack { result: 15, ty: 0 })]
    );
    assert!(b
        .texts_since(from)
        .contains(&"Mission upload timeout".to_string()));
    assert_eq!(b.v().stored_items(0).len(), 2);
    assert!(!b.v().mission_receiving(0));
}

/// MISSION_ITEM (float lat/lon) upload and MISSION_REQUEST download work, each with
/// ArduPilot's one-time warning; lat/lon go through single precision.
#[test]
fn the_float_messages_work_with_a_warning() {
    let mut b = Bench::new("");
    b.run_for(SECOND);
    let mut it = item(
        1,
        cmd::NAV_WAYPOINT,
        frame::GLOBAL_RELATIVE_ALT,
        [0.0; 4],
        0,
        0,
        30.0,
    );
    send_count(&mut b, 2, 0);
    b.run_for(20_000);
    send_item(&mut b, &grid_mission(3)[0]);
    b.run_for(20_000);
    let from = b.frames.len();
    let mut p = item_payload(&it, (1, 1), false);
    p[16..20].copy_from_slice(&(-35.36f32).to_le_bytes());
    p[20..24].copy_from_slice(&(149.17f32).to_le_bytes());
    b.send_raw(msgid::MISSION_ITEM, &p);
    b.run_for(20_000);
    assert!(b
        .texts_since(from)
        .contains(&"got MISSION_ITEM; GCS should send MISSION_ITEM_INT".to_string()));
    it.x = (-35.36f32 * 1.0e7f32) as i32;
    it.y = (149.17f32 * 1.0e7f32) as i32;
    assert_eq!(b.v().stored_items(0)[1], it);
    let from = b.frames.len();
    send_request(&mut b, 1, 0, false);
    send_request(&mut b, 1, 0, false);
    b.run_for(20_000);
    let got: Vec<Proto> = protos(&b.frames[from..]).into_iter().map(|p| p.1).collect();
    assert_eq!(got.len(), 2);
    let Proto::Item {
        item: back,
        int: false,
    } = &got[0]
    else {
        panic!("{got:?}")
    };
    assert_eq!(back.x, (it.x as f32 * 1.0e-7f32 * 1.0e7f32) as i32);
    let warnings = b.texts_since(from);
    assert_eq!(
        warnings,
        vec!["got MISSION_REQUEST; use MISSION_REQUEST_INT!".to_string()]
    );
    // Beyond the end: MISSION_COUNT to educate the GCS, then INVALID_SEQUENCE.
    let from = b.frames.len();
    send_request(&mut b, 7, 0, true);
    b.run_for(20_000);
    let got: Vec<Proto> = protos(&b.frames[from..]).into_iter().map(|p| p.1).collect();
    assert_eq!(
        got,
        vec![
            Proto::Count { count: 2, ty: 0 },
            Proto::Ack { result: 13, ty: 0 }
        ]
    );
    // An unknown mission type is refused, echoing the type.
    let from = b.frames.len();
    send_count(&mut b, 1, 9);
    b.run_for(20_000);
    let got: Vec<Proto> = protos(&b.frames[from..]).into_iter().map(|p| p.1).collect();
    assert_eq!(got, vec![Proto::Ack { result: 3, ty: 9 }]);
}

/// The mission the real capture flew, flown as the capture's GCS flew it: GUIDED takeoff to
/// 10 m, AUTO + MISSION_START, then the same texts in the same order, MISSION_ITEM_REACHED for
/// 1, 3, 4 and 5 only, and the same MISSION_CURRENT progression; at the end the vehicle holds
/// in AUTO (mission COMPLETE), GUIDED leaves it COMPLETE with mission_mode 0, RTL lands and
/// the disarm resets it to seq 0.
#[test]
fn the_capture_mission_flies_like_the_real_copter() {
    let gcs = tlog_frames(CAPTURE_GCS);
    let vehicle = tlog_frames(CAPTURE_VEHICLE);
    let mut b = Bench::new("");
    b.run_for(SECOND);
    // Upload the capture's mission exactly as its GCS sent it.
    let items: Vec<MissionItem> = gcs
        .iter()
        .filter(|(_, f)| f.msgid == msgid::MISSION_ITEM_INT)
        .filter_map(|(_, f)| match parse(f.msgid, f.payload())?.2 {
            Incoming::Item { item, .. } if item.mission_type == 0 => Some(item),
            _ => None,
        })
        .collect();
    assert_eq!(items.len(), 6);
    assert_eq!(upload(&mut b, &items, 0).0, Upload::Accepted);
    b.stream_mission_current(250_000);
    b.guided_armed(Some(10.0));
    // The capture's GCS sent AUTO and MISSION_START together (one loop handles both).
    let from = b.frames.len();
    b.send(MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
        command: MavCmd::MAV_CMD_DO_SET_MODE,
        param1: 1.0,
        param2: mode::AUTO as f32,
        target_system: 1,
        target_component: 1,
        ..Default::default()
    }));
    assert_eq!(
        b.long(MavCmd::MAV_CMD_MISSION_START, [0.0; 7]),
        MavResult::MAV_RESULT_ACCEPTED
    );
    let mut max_alt = 0.0f64;
    while b.v().auto.state != super::auto::RunState::Complete {
        b.run_for(10_000);
        max_alt = max_alt.max(b.v().relative_alt_m());
        assert!(b.now < 200 * SECOND, "mission not complete");
    }
    // The capture's GCS took over in GUIDED as soon as WP 5 was reached.
    assert_eq!(b.set_mode(mode::GUIDED), MavResult::MAV_RESULT_ACCEPTED);
    b.run_for(SECOND);
    assert_eq!(b.set_mode(mode::RTL), MavResult::MAV_RESULT_ACCEPTED);
    while b.v().armed() {
        b.run_for(SECOND);
        assert!(b.now < 400 * SECOND, "RTL did not land");
    }
    b.run_for(SECOND);

    let mission_texts = |t: &str| t.starts_with("Mission:") || t.starts_with("Reached command");
    let want_texts: Vec<String> = vehicle
        .iter()
        .filter_map(|(_, f)| match f.message.as_deref() {
            Some(MavMessage::STATUSTEXT(t)) => Some(t.text.to_str().unwrap_or("").to_string()),
            _ => None,
        })
        .filter(|t| mission_texts(t))
        .collect();
    assert_eq!(want_texts.len(), 9, "{want_texts:?}");
    assert_eq!(want_texts[3], "Reached command #2");
    let got_texts: Vec<String> = b
        .texts_since(from)
        .into_iter()
        .filter(|t| mission_texts(t))
        .collect();
    assert_eq!(got_texts, want_texts);

    let want_reached: Vec<u16> = vehicle
        .iter()
        .filter(|(_, f)| f.msgid == msgid::MISSION_ITEM_REACHED)
        .map(|(_, f)| {
            u16::from_le_bytes([f.payload()[0], f.payload().get(1).copied().unwrap_or(0)])
        })
        .collect();
    assert_eq!(want_reached, vec![1, 3, 4, 5]);
    assert_eq!(b.reached_since(from), want_reached);

    // The capture's MISSION_CURRENT from AUTO on (the stream, repeats merged).
    let mut want_mc: Vec<(u16, u16, u8, u8)> = Vec::new();
    for (_, f) in &vehicle {
        if let Some(MavMessage::MISSION_CURRENT(m)) = f.message.as_deref() {
            let k = (m.seq, m.total, m.mission_state as u8, m.mission_mode);
            if want_mc.last() != Some(&k) {
                want_mc.push(k);
            }
        }
    }
    let start = want_mc.iter().position(|k| k.3 == 1).unwrap();
    assert_eq!(want_mc.len() - start, 6, "{want_mc:?}");
    assert_eq!(b.mission_current_since(from), want_mc[start..].to_vec());
    // The highest point is WP 4 at 25 m, as in the capture (max_relative_alt_m 25.0).
    assert!((max_alt - 25.0).abs() < 0.05, "{max_alt}");
}

/// The last item done in the air: AUTO holds where it is (`exit_mission` → `loiter_start`),
/// armed, mission COMPLETE, still in AUTO.
#[test]
fn a_mission_ending_in_the_air_holds_in_auto() {
    let mut b = Bench::new("");
    b.run_for(SECOND);
    let (lat0, lon0) = (-353_632_621, 1_491_652_374);
    let items = vec![
        item(0, cmd::NAV_WAYPOINT, frame::GLOBAL, [0.0; 4], 0, 0, 0.0),
        item(
            1,
            cmd::NAV_TAKEOFF,
            frame::GLOBAL_RELATIVE_ALT,
            [0.0; 4],
            0,
            0,
            10.0,
        ),
        item(
            2,
            cmd::NAV_WAYPOINT,
            frame::GLOBAL_RELATIVE_ALT,
            [0.0; 4],
            lat0 + 2_700,
            lon0,
            12.0,
        ),
    ];
    assert_eq!(upload(&mut b, &items, 0).0, Upload::Accepted);
    b.stream_mission_current(500_000);
    b.guided_armed(None);
    assert_eq!(
        b.long(MavCmd::MAV_CMD_MISSION_START, [0.0; 7]),
        MavResult::MAV_RESULT_ACCEPTED
    );
    while b.v().auto.state != super::auto::RunState::Complete {
        b.run_for(100_000);
        assert!(b.now < 60 * SECOND, "mission not complete");
    }
    let done = (b.v().position_ne(), b.v().relative_alt_m());
    // 30 m north, 12 m up, reached within WPNAV_RADIUS (2 m).
    assert!(
        (done.0 .0 - 30.0).abs() < 2.1 && (done.1 - 12.0).abs() < 2.1,
        "{done:?}"
    );
    let from = b.frames.len();
    b.run_for(20 * SECOND);
    assert_eq!((b.v().position_ne(), b.v().relative_alt_m()), done);
    assert!(b.v().armed() && b.v().custom_mode() == mode::AUTO);
    assert_eq!(b.mission_current_since(from), vec![(2, 2, 5, 1)]);
}

/// Takeoff, four waypoints 60 m apart and a landing from the ground: MISSION_START in GUIDED
/// takes off (auto-armed), every waypoint is reached and reported, MISSION_CURRENT counts up,
/// the speed never exceeds WPNAV_SPEED (10 m/s), each leg takes at least distance / speed, the
/// landing disarms on touchdown and the mission resets to seq 0.
#[test]
fn takeoff_four_waypoints_and_land_from_the_ground() {
    let mut b = Bench::new("");
    b.run_for(SECOND);
    let (lat0, lon0) = (-353_632_621, 1_491_652_374);
    let d = 5_390; // 60 m north in 1e-7 degrees
    let e = 6_620; // about 60 m east at this latitude
    let corners = [
        (lat0 + d, lon0),
        (lat0 + d, lon0 + e),
        (lat0, lon0 + e),
        (lat0, lon0),
    ];
    let mut items = vec![item(
        0,
        cmd::NAV_WAYPOINT,
        frame::GLOBAL,
        [0.0; 4],
        0,
        0,
        0.0,
    )];
    items.push(item(
        1,
        cmd::NAV_TAKEOFF,
        frame::GLOBAL_RELATIVE_ALT,
        [0.0; 4],
        0,
        0,
        15.0,
    ));
    for (i, (x, y)) in corners.iter().enumerate() {
        items.push(item(
            2 + i as u16,
            cmd::NAV_WAYPOINT,
            frame::GLOBAL_RELATIVE_ALT,
            [0.0; 4],
            *x,
            *y,
            15.0,
        ));
    }
    items.push(item(
        6,
        cmd::NAV_LAND,
        frame::GLOBAL_RELATIVE_ALT,
        [0.0; 4],
        0,
        0,
        0.0,
    ));
    assert_eq!(upload(&mut b, &items, 0).0, Upload::Accepted);
    b.stream_mission_current(200_000);
    b.guided_armed(None);
    // Arming in AUTO is refused (AUTO_OPTIONS 0), so MISSION_START from GUIDED on the ground.
    let from = b.frames.len();
    assert_eq!(
        b.long(MavCmd::MAV_CMD_MISSION_START, [0.0; 7]),
        MavResult::MAV_RESULT_ACCEPTED
    );
    let mut reached_at: Vec<(u16, Micros)> = Vec::new();
    let mut max_speed = 0.0f64;
    let mut last = (b.now, b.v().position_ne());
    while b.v().armed() {
        b.run_for(100_000);
        let p = b.v().position_ne();
        let dt = (b.now - last.0) as f64 / 1e6;
        max_speed = max_speed.max((p.0 - last.1 .0).hypot(p.1 - last.1 .1) / dt);
        last = (b.now, p);
        for s in b.reached_since(from) {
            if !reached_at.iter().any(|r| r.0 == s) {
                reached_at.push((s, b.now));
            }
        }
        assert!(b.now < 120 * SECOND, "still flying");
    }
    b.run_for(SECOND);
    assert_eq!(
        reached_at.iter().map(|r| r.0).collect::<Vec<_>>(),
        vec![1, 2, 3, 4, 5]
    );
    assert!(max_speed <= 10.0 + 1e-6, "{max_speed}");
    for w in reached_at.windows(2).skip(1) {
        // 60 m legs at 10 m/s, reached within WPNAV_RADIUS (2 m): at least 5.8 s each.
        assert!(w[1].1 - w[0].1 >= 5_800_000, "{reached_at:?}");
    }
    let texts = b.texts_since(from);
    for t in [
        "Mission: 1 Takeoff",
        "Mission: 2 WP",
        "Reached command #5",
        "Mission: 6 Land",
        "Disarming motors",
    ] {
        assert!(texts.contains(&t.to_string()), "{t} in {texts:?}");
    }
    // The disarm resets the mission (seq 0) and AUTO, still running it, starts it over at
    // item 1, which waits for the next arming (ArduCopter runs the mission disarmed too).
    let mc: Vec<u16> = b.mission_current_since(from).iter().map(|k| k.0).collect();
    assert_eq!(mc[..6], [1, 2, 3, 4, 5, 6], "{mc:?}");
    assert_eq!(mc.last(), Some(&1), "{mc:?}");
    assert!(mc[6..].iter().all(|s| *s <= 1), "{mc:?}");
    let disarmed = texts.iter().position(|t| t == "Disarming motors").unwrap();
    assert!(texts[disarmed..].contains(&"Mission: 1 Takeoff".to_string()));
    let (n, e_) = b.v().position_ne();
    assert!(n.hypot(e_) < 2.5, "landed near home: {n} {e_}");
    assert!(b.v().landed() && !b.v().armed());
}

/// MISSION_SET_CURRENT moves a stopped mission and echoes MISSION_CURRENT at once with the
/// asked seq; DO_SET_MISSION_CURRENT is ACKed (FAILED beyond the end); MISSION_CLEAR_ALL is
/// refused while the mission runs. AUTO needs a mission when armed.
#[test]
fn set_current_and_clear_all() {
    let mut b = Bench::new("");
    b.run_for(SECOND);
    let items = grid_mission(6);
    assert_eq!(upload(&mut b, &items, 0).0, Upload::Accepted);
    let from = b.frames.len();
    b.send_raw(msgid::MISSION_SET_CURRENT, &[3, 0, 1, 1]);
    b.run_for(20_000);
    assert_eq!(b.mission_current_since(from), vec![(3, 5, 2, 0)]);
    let p = [4.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    assert_eq!(
        b.long(MavCmd::MAV_CMD_DO_SET_MISSION_CURRENT, p),
        MavResult::MAV_RESULT_ACCEPTED
    );
    assert_eq!(b.v().auto.nav_index(), Some(4));
    let p = [9.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    assert_eq!(
        b.long(MavCmd::MAV_CMD_DO_SET_MISSION_CURRENT, p),
        MavResult::MAV_RESULT_FAILED
    );
    // The downloaded current item carries current = 1.
    assert_eq!(b.v().stored_items(0)[4].current, 1);

    b.guided_armed(Some(10.0));
    assert_eq!(b.set_mode(mode::AUTO), MavResult::MAV_RESULT_ACCEPTED);
    b.run_for(SECOND);
    assert!(b.v().auto.running());
    let from = b.frames.len();
    b.send_raw(msgid::MISSION_CLEAR_ALL, &[1, 1, 0]);
    b.run_for(20_000);
    assert_eq!(
        protos(&b.frames[from..])
            .into_iter()
            .map(|p| p.1)
            .collect::<Vec<_>>(),
        vec![Proto::Ack { result: 1, ty: 0 }]
    );
    // Out of AUTO the mission stops (NOT_STARTED), and can be cleared.
    assert_eq!(b.set_mode(mode::GUIDED), MavResult::MAV_RESULT_ACCEPTED);
    let from = b.frames.len();
    b.send_raw(msgid::MISSION_CLEAR_ALL, &[1, 1, 0]);
    b.run_for(20_000);
    assert_eq!(
        protos(&b.frames[from..])
            .into_iter()
            .map(|p| p.1)
            .collect::<Vec<_>>(),
        vec![Proto::Ack { result: 0, ty: 0 }]
    );
    assert!(b
        .texts_since(from)
        .contains(&"Flight plan received".to_string()));
    assert_eq!(b.v().param("MIS_TOTAL"), Some(0.0));
    // Armed, with no mission, AUTO is refused.
    assert_eq!(b.set_mode(mode::AUTO), MavResult::MAV_RESULT_FAILED);
}

/// DO_JUMP repeats: a jump back to item 2 twice flies 2, 3, 2, 3, 2, 3, then 5.
#[test]
fn do_jump_repeats_the_given_number_of_times() {
    let mut b = Bench::new("");
    b.run_for(SECOND);
    let (lat0, lon0) = (-353_632_621, 1_491_652_374);
    let items = vec![
        item(0, cmd::NAV_WAYPOINT, frame::GLOBAL, [0.0; 4], 0, 0, 0.0),
        item(
            1,
            cmd::NAV_TAKEOFF,
            frame::GLOBAL_RELATIVE_ALT,
            [0.0; 4],
            0,
            0,
            5.0,
        ),
        item(
            2,
            cmd::NAV_WAYPOINT,
            frame::GLOBAL_RELATIVE_ALT,
            [0.0; 4],
            lat0 + 300,
            lon0,
            5.0,
        ),
        item(
            3,
            cmd::NAV_WAYPOINT,
            frame::GLOBAL_RELATIVE_ALT,
            [0.0; 4],
            lat0,
            lon0,
            5.0,
        ),
        item(
            4,
            cmd::DO_JUMP,
            frame::GLOBAL,
            [2.0, 2.0, 0.0, 0.0],
            0,
            0,
            0.0,
        ),
        item(
            5,
            cmd::NAV_LAND,
            frame::GLOBAL_RELATIVE_ALT,
            [0.0; 4],
            0,
            0,
            0.0,
        ),
    ];
    assert_eq!(upload(&mut b, &items, 0).0, Upload::Accepted);
    b.guided_armed(None);
    let from = b.frames.len();
    assert_eq!(
        b.long(MavCmd::MAV_CMD_MISSION_START, [0.0; 7]),
        MavResult::MAV_RESULT_ACCEPTED
    );
    while b.v().armed() {
        b.run_for(SECOND);
        assert!(b.now < 120 * SECOND);
    }
    let started: Vec<String> = b
        .texts_since(from)
        .into_iter()
        .filter(|t| t.starts_with("Mission:"))
        .collect();
    // Takeoff twice (MISSION_START starts it, AUTO's first run resumes it); after the landing
    // disarms, the reset mission starts again in AUTO and waits for the next arming.
    assert_eq!(
        started,
        [
            "Mission: 1 Takeoff",
            "Mission: 1 Takeoff",
            "Mission: 2 WP",
            "Mission: 3 WP",
            "Mission: 4 Jump 1/2",
            "Mission: 2 WP",
            "Mission: 3 WP",
            "Mission: 4 Jump 2/2",
            "Mission: 2 WP",
            "Mission: 3 WP",
            "Mission: 5 Land",
            "Mission: 1 Takeoff",
        ]
    );
}

fn velocity(b: &mut Bench, fr: MavFrame, v: (f32, f32, f32), yaw_rate: Option<f32>) {
    let mut mask = PositionTargetTypemask::POSITION_TARGET_TYPEMASK_X_IGNORE
        | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_Y_IGNORE
        | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_Z_IGNORE
        | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_AX_IGNORE
        | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_AY_IGNORE
        | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_AZ_IGNORE
        | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_YAW_IGNORE;
    if yaw_rate.is_none() {
        mask |= PositionTargetTypemask::POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE;
    }
    b.send(MavMessage::SET_POSITION_TARGET_LOCAL_NED(
        SET_POSITION_TARGET_LOCAL_NED_DATA {
            time_boot_ms: 0,
            vx: v.0,
            vy: v.1,
            vz: v.2,
            yaw_rate: yaw_rate.unwrap_or(0.0),
            type_mask: mask,
            target_system: 1,
            target_component: 1,
            coordinate_frame: fr,
            ..Default::default()
        },
    ));
}

/// A body-frame velocity nudge as the capture's GCS sent them (10 Hz, velocity and yaw rate
/// only): the vehicle moves at the velocity, keeps it until GUID_TIMEOUT (3 s) after the last
/// message, then stops and stays; a yaw rate turns the heading, and the next body-frame
/// velocity follows the new heading.
#[test]
#[allow(deprecated)]
fn a_velocity_nudge_moves_it_and_stops_after_the_timeout() {
    let mut b = Bench::new("");
    b.guided_armed(Some(10.0));
    let start = b.v().position_ne();
    assert_eq!(b.v().heading_deg(), 0.0);
    // One second of 2 m/s forward (north, heading 0).
    for _ in 0..10 {
        velocity(
            &mut b,
            MavFrame::MAV_FRAME_BODY_OFFSET_NED,
            (2.0, 0.0, 0.0),
            None,
        );
        b.run_for(100_000);
    }
    let p = b.v().position_ne();
    assert!(
        (p.0 - start.0 - 2.0).abs() < 0.05 && (p.1 - start.1).abs() < 1e-6,
        "{p:?}"
    );
    // No more messages: 3 s more at 2 m/s, then it stops.
    b.run_for(2_900_000);
    assert!(b.v().guided_velocity().unwrap().0 > 1.9);
    b.run_for(200_000);
    assert_eq!(b.v().guided_velocity(), Some((0.0, 0.0, 0.0)));
    // 2 m/s from the first message until 3 s after the last (0.9 s later): 7.8 m.
    let stopped = b.v().position_ne();
    assert!((stopped.0 - start.0 - 7.8).abs() < 0.05, "{stopped:?}");
    b.run_for(5 * SECOND);
    assert_eq!(b.v().position_ne(), stopped);
    assert_eq!(b.v().relative_alt_m(), 10.0);
    // Turn right at 45 deg/s for 2 s (no translation).
    for _ in 0..20 {
        velocity(
            &mut b,
            MavFrame::MAV_FRAME_BODY_OFFSET_NED,
            (0.0, 0.0, 0.0),
            Some(45f32.to_radians()),
        );
        b.run_for(100_000);
    }
    assert!(
        (b.v().heading_deg() - 90.0).abs() < 0.1,
        "{}",
        b.v().heading_deg()
    );
    // Forward now means east; a climb in NED is negative z.
    let before = b.v().position_ne();
    for _ in 0..10 {
        velocity(&mut b, MavFrame::MAV_FRAME_BODY_NED, (3.0, 0.0, -1.0), None);
        b.run_for(100_000);
    }
    let after = b.v().position_ne();
    assert!(
        (after.1 - before.1 - 3.0).abs() < 0.05 && (after.0 - before.0).abs() < 0.05,
        "{before:?} {after:?}"
    );
    assert!((b.v().relative_alt_m() - 11.0).abs() < 0.05);
    // LOCAL_NED velocities are north/east whatever the heading.
    let before = b.v().position_ne();
    for _ in 0..10 {
        velocity(
            &mut b,
            MavFrame::MAV_FRAME_LOCAL_NED,
            (-1.0, 0.0, 0.0),
            None,
        );
        b.run_for(100_000);
    }
    let after = b.v().position_ne();
    assert!(
        (after.0 - before.0 + 1.0).abs() < 0.05,
        "{before:?} {after:?}"
    );
}

fn global_target(b: &mut Bench, fr: MavFrame, lat: i32, lon: i32, alt: f32) {
    let mask = PositionTargetTypemask::POSITION_TARGET_TYPEMASK_VX_IGNORE
        | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_VY_IGNORE
        | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_VZ_IGNORE
        | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_AX_IGNORE
        | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_AY_IGNORE
        | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_AZ_IGNORE
        | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_YAW_IGNORE
        | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE;
    b.send(MavMessage::SET_POSITION_TARGET_GLOBAL_INT(
        SET_POSITION_TARGET_GLOBAL_INT_DATA {
            lat_int: lat,
            lon_int: lon,
            alt,
            type_mask: mask,
            target_system: 1,
            target_component: 1,
            coordinate_frame: fr,
            ..Default::default()
        },
    ));
}

/// SET_POSITION_TARGET_GLOBAL_INT: a position 50 m north at 20 m above home is flown to at
/// WPNAV_SPEED and held (no timeout for positions); an AMSL altitude is converted with home's.
#[test]
#[allow(deprecated)]
fn a_global_position_target_moves_it() {
    let mut b = Bench::new("");
    b.guided_armed(Some(10.0));
    let (lat, lon) = (b.v().home().0, b.v().home().1);
    let north_50 = ((lat + 50.0 / 111_319.5) * 1e7).round() as i32;
    let lon_e7 = (lon * 1e7).round() as i32;
    global_target(
        &mut b,
        MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        north_50,
        lon_e7,
        20.0,
    );
    b.run_for(4 * SECOND);
    // 10 m/s: 40 m after 4 s.
    let p = b.v().position_ne();
    assert!((p.0 - 40.0).abs() < 0.2, "{p:?}");
    b.run_for(10 * SECOND);
    let p = b.v().position_ne();
    assert!((p.0 - 50.0).abs() < 0.05 && p.1.abs() < 0.05, "{p:?}");
    assert!((b.v().relative_alt_m() - 20.0).abs() < 0.01);
    // AMSL: 604 m is 20 m below... 20 m above the 584 m home.
    global_target(&mut b, MavFrame::MAV_FRAME_GLOBAL, north_50, lon_e7, 599.0);
    b.run_for(10 * SECOND);
    assert!(
        (b.v().relative_alt_m() - 15.0).abs() < 0.01,
        "{}",
        b.v().relative_alt_m()
    );
    // A frame ArduCopter has no altitude for stops the vehicle where it is.
    global_target(&mut b, MavFrame::MAV_FRAME_LOCAL_NED, lon_e7, lon_e7, 50.0);
    b.run_for(SECOND);
    assert_eq!(b.v().guided_destination().map(|d| d.2), Some(15.0));
}

/// Targets outside GUIDED are ignored (here LOITER, flying); in GUIDED but disarmed the
/// vehicle does not move.
#[test]
#[allow(deprecated)]
fn targets_are_ignored_unless_guided_and_do_nothing_disarmed() {
    let mut b = Bench::new("");
    b.run_until(super::vehicle::EKF_GPS_AT + 100_000);
    assert_eq!(b.set_mode(mode::GUIDED), MavResult::MAV_RESULT_ACCEPTED);
    for _ in 0..10 {
        velocity(
            &mut b,
            MavFrame::MAV_FRAME_LOCAL_NED,
            (3.0, 0.0, -1.0),
            None,
        );
        b.run_for(100_000);
    }
    assert_eq!(b.v().position_ne(), (0.0, 0.0));
    assert!(b.v().landed());
    let lat = ((b.v().home().0 + 0.0005) * 1e7) as i32;
    let lon = (b.v().home().1 * 1e7) as i32;
    global_target(
        &mut b,
        MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
        lat,
        lon,
        10.0,
    );
    b.run_for(3 * SECOND);
    assert_eq!(b.v().position_ne(), (0.0, 0.0));

    let arm = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    assert_eq!(
        b.long(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, arm),
        MavResult::MAV_RESULT_ACCEPTED
    );
    let p = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 10.0];
    assert_eq!(
        b.long(MavCmd::MAV_CMD_NAV_TAKEOFF, p),
        MavResult::MAV_RESULT_ACCEPTED
    );
    b.run_for(10 * SECOND);
    assert_eq!(b.set_mode(mode::LOITER), MavResult::MAV_RESULT_ACCEPTED);
    let here = b.v().position_ne();
    for _ in 0..20 {
        velocity(&mut b, MavFrame::MAV_FRAME_LOCAL_NED, (3.0, 0.0, 0.0), None);
        global_target(
            &mut b,
            MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
            lat,
            lon,
            30.0,
        );
        b.run_for(100_000);
    }
    assert_eq!(b.v().position_ne(), here);
    assert_eq!(b.v().guided_velocity(), None);
    assert_eq!(b.v().relative_alt_m(), 10.0);
}

/// A mission ending with NAV_RETURN_TO_LAUNCH: RTL climbs to RTL_ALT (15 m), returns and lands;
/// on the ground the RTL item completes (reported), the mission is COMPLETE and the vehicle
/// disarms (`exit_mission` on the ground); being complete, it does not start over.
#[test]
fn a_mission_ending_with_rtl_lands_and_disarms_complete() {
    let mut b = Bench::new("");
    b.run_for(SECOND);
    let (lat0, lon0) = (-353_632_621, 1_491_652_374);
    let items = vec![
        item(0, cmd::NAV_WAYPOINT, frame::GLOBAL, [0.0; 4], 0, 0, 0.0),
        item(
            1,
            cmd::NAV_TAKEOFF,
            frame::GLOBAL_RELATIVE_ALT,
            [0.0; 4],
            0,
            0,
            10.0,
        ),
        item(
            2,
            cmd::NAV_WAYPOINT,
            frame::GLOBAL_RELATIVE_ALT,
            [0.0; 4],
            lat0 + 1_800,
            lon0,
            10.0,
        ),
        item(
            3,
            cmd::NAV_RETURN_TO_LAUNCH,
            frame::GLOBAL,
            [0.0; 4],
            0,
            0,
            0.0,
        ),
    ];
    assert_eq!(upload(&mut b, &items, 0).0, Upload::Accepted);
    b.stream_mission_current(500_000);
    b.guided_armed(None);
    let from = b.frames.len();
    assert_eq!(
        b.long(MavCmd::MAV_CMD_MISSION_START, [0.0; 7]),
        MavResult::MAV_RESULT_ACCEPTED
    );
    let mut max_alt = 0.0f64;
    while b.v().armed() {
        b.run_for(100_000);
        max_alt = max_alt.max(b.v().relative_alt_m());
        assert!(b.now < 120 * SECOND, "still flying");
    }
    b.run_for(2 * SECOND);
    assert!((max_alt - 15.0).abs() < 0.01, "RTL_ALT 15 m: {max_alt}");
    assert_eq!(b.reached_since(from), vec![1, 2, 3]);
    assert_eq!(b.v().auto.state, super::auto::RunState::Complete);
    let mc = b.mission_current_since(from);
    assert_eq!(mc.last(), Some(&(0, 3, 5, 1)), "{mc:?}");
    let texts = b.texts_since(from);
    let disarmed = texts.iter().position(|t| t == "Disarming motors").unwrap();
    assert!(
        !texts[disarmed..].iter().any(|t| t.starts_with("Mission:")),
        "{texts:?}"
    );
    let (n, e) = b.v().position_ne();
    assert!(n.hypot(e) < 0.1 && b.v().landed());
}
