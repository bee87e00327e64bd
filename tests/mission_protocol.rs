//! The mission protocol machine against vehicles made of pymavlink frames: one that asks only
//! with the old MISSION_REQUEST, one that asks for an item twice, one that never sends
//! MISSION_ACK, one that answers a download with a lost item and items not asked for, one that
//! answers with legacy MISSION_ITEM. Every frame the vehicle sends is packed by pymavlink;
//! every message we send is read back by pymavlink, whose field values are the ones asserted.

mod common;

use mavterm::clock::Micros;
use mavterm::dialect::MavMessage;
use mavterm::link::FrameParser;
use mavterm::mission::{cmd, frame, MissionItem, MissionType};
use mavterm::proto::mission::{
    MissionEvent, MissionMachine, MissionMsg, MissionOut, Request, ACK_TIMEOUT, ITEM_TIMEOUT,
    NO_SPACE_WAIT, VEHICLE_WAIT,
};
use mavterm::proto::vehicles::VehicleKey;
use mavterm::wire::frame::{encode, Header, Version};
use serde_json::{json, Value};

const V: VehicleKey = VehicleKey(1, 1);

fn from_vehicle(msg: &str, fields: Value) -> Value {
    json!({"sysid": 1, "compid": 1, "msg": msg, "fields": fields})
}

/// Frames packed by pymavlink, read as our machine reads them.
fn vehicle_frames(reqs: &[Value]) -> Vec<MissionMsg> {
    let reqs: Vec<Value> = reqs
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let mut r = r.clone();
            r["seq"] = json!(i % 256);
            r
        })
        .collect();
    common::pymavlink_encode(&reqs)
        .iter()
        .map(|bytes| {
            let frames = FrameParser::new().parse_all(bytes);
            assert_eq!(frames.len(), 1);
            MissionMsg::read(frames[0].msgid, frames[0].payload()).expect("a mission message")
        })
        .collect()
}

/// pymavlink's reading of what we sent.
fn as_pymavlink_reads(sent: &[MavMessage]) -> Vec<Value> {
    let frames: Vec<Vec<u8>> = sent
        .iter()
        .enumerate()
        .map(|(i, m)| {
            encode(
                Version::V2,
                Header {
                    sysid: 255,
                    compid: 190,
                    seq: i as u8,
                },
                m,
            )
        })
        .collect();
    let d = common::pymavlink_decode(&frames);
    for v in &d {
        assert!(v.get("error").is_none(), "{v}");
    }
    d
}

/// A machine with what it sent and said, on a clock.
struct Run {
    m: MissionMachine,
    now: Micros,
    sent: Vec<MavMessage>,
    events: Vec<MissionEvent>,
}

impl Run {
    fn new() -> Self {
        Self {
            m: MissionMachine::new(V),
            now: 0,
            sent: Vec::new(),
            events: Vec::new(),
        }
    }

    fn take(&mut self, out: Vec<MissionOut>) {
        for o in out {
            match o {
                MissionOut::Send(m) => self.sent.push(m),
                MissionOut::Event(e) => self.events.push(e),
            }
        }
    }

    fn submit(&mut self, req: Request) {
        let out = self.m.submit(self.now, req).unwrap();
        self.take(out);
    }

    /// `msg` from the vehicle 10 ms later, after whatever fell due before.
    fn hear(&mut self, msg: &MissionMsg) {
        self.wait(10_000);
        let out = self.m.on_message(self.now, msg);
        self.take(out);
    }

    /// Let `dt` pass, polling at every deadline on the way.
    fn wait(&mut self, dt: Micros) {
        let until = self.now + dt;
        while let Some(d) = self.m.next_deadline().filter(|d| *d <= until) {
            self.now = d;
            let out = self.m.poll(d);
            self.take(out);
        }
        self.now = until;
    }

    fn names(&self) -> Vec<&'static str> {
        use mavlink::Message;
        self.sent.iter().map(|m| m.message_name()).collect()
    }
}

fn items() -> Vec<MissionItem> {
    let t = MissionType::Mission;
    let mut home = MissionItem::at(
        t,
        0,
        frame::GLOBAL,
        cmd::NAV_WAYPOINT,
        -35.3632621,
        149.1652374,
        584.07,
    );
    home.current = true;
    let takeoff = MissionItem::at(
        t,
        1,
        frame::GLOBAL_RELATIVE_ALT,
        cmd::NAV_TAKEOFF,
        0.0,
        0.0,
        15.0,
    );
    let mut wp = MissionItem::at(
        t,
        2,
        frame::GLOBAL_RELATIVE_ALT_INT,
        cmd::NAV_WAYPOINT,
        47.3977419,
        8.5455938,
        30.5,
    );
    wp.params = [2.5, 0.0, 0.0, f32::NAN];
    let mut speed = MissionItem::new(t, 3, frame::MISSION, cmd::DO_CHANGE_SPEED);
    speed.params = [1.0, 4.5, -1.0, 0.0];
    let land = MissionItem::at(
        t,
        4,
        frame::GLOBAL_TERRAIN_ALT,
        cmd::NAV_LAND,
        -35.36,
        149.16,
        0.0,
    );
    vec![home, takeoff, wp, speed, land]
}

/// The fields pymavlink reads in MISSION_ITEM_INT `seq` of [`items`], from the test's own
/// numbers: degrees ×1e7 for x/y, NaN as "nan".
fn expected_item(seq: u64) -> Value {
    let base = json!({"name": "MISSION_ITEM_INT", "target_system": 1, "target_component": 1,
                      "seq": seq, "mission_type": 0, "autocontinue": 1});
    let mut e = base.as_object().unwrap().clone();
    let more = match seq {
        0 => json!({"frame": 0, "command": 16, "current": 1, "x": -353_632_621, "y": 1_491_652_374,
                    "z": 584.07f32 as f64, "param1": 0.0, "param4": 0.0}),
        1 => json!({"frame": 3, "command": 22, "current": 0, "x": 0, "y": 0, "z": 15.0}),
        2 => json!({"frame": 6, "command": 16, "current": 0, "x": 473_977_419, "y": 85_455_938,
                    "z": 30.5, "param1": 2.5, "param4": "nan"}),
        3 => json!({"frame": 2, "command": 178, "current": 0, "x": 0, "y": 0, "z": 0.0,
                    "param1": 1.0, "param2": 4.5, "param3": -1.0}),
        4 => {
            json!({"frame": 10, "command": 21, "current": 0, "x": -353_600_000, "y": 1_491_600_000,
                    "z": 0.0})
        }
        _ => unreachable!(),
    };
    e.extend(more.as_object().unwrap().clone());
    Value::Object(e)
}

fn assert_fields(got: &Value, want: &Value) {
    for (k, v) in want.as_object().unwrap() {
        assert_eq!(&got[k], v, "{k} in {got}");
    }
}

fn requests(seqs: &[u16], legacy: bool) -> Vec<Value> {
    let name = if legacy {
        "MISSION_REQUEST"
    } else {
        "MISSION_REQUEST_INT"
    };
    seqs.iter()
        .map(|s| {
            from_vehicle(
                name,
                json!({"target_system": 255, "target_component": 190, "seq": s, "mission_type": 0}),
            )
        })
        .collect()
}

fn mission_ack(result: u8, mission_type: u8) -> Value {
    from_vehicle(
        "MISSION_ACK",
        json!({"target_system": 255, "target_component": 190, "type": result, "mission_type": mission_type}),
    )
}

#[test]
fn a_vehicle_asking_only_with_mission_request_gets_mission_item_int() {
    let mut reqs = requests(&[0, 1, 2, 3, 4], true);
    reqs.push(mission_ack(0, 0));
    let vehicle = vehicle_frames(&reqs);
    let mut r = Run::new();
    r.submit(Request::Upload(MissionType::Mission, items()));
    for m in &vehicle {
        r.hear(m);
    }
    let read = as_pymavlink_reads(&r.sent);
    assert_fields(
        &read[0],
        &json!({"name": "MISSION_COUNT", "count": 5, "target_system": 1, "target_component": 1, "mission_type": 0}),
    );
    assert_eq!(read.len(), 6);
    for (k, got) in read[1..].iter().enumerate() {
        assert_fields(got, &expected_item(k as u64));
    }
    assert!(matches!(
        r.events.last(),
        Some(MissionEvent::Uploaded {
            mission_type: MissionType::Mission,
            count: 5,
            ..
        })
    ));
    assert!(!r.m.busy());
}

#[test]
fn a_vehicle_asking_for_an_item_twice_gets_it_twice() {
    let mut reqs = requests(&[0, 1, 1, 2, 3, 3, 4], false);
    reqs.push(mission_ack(0, 0));
    let mut r = Run::new();
    r.submit(Request::Upload(MissionType::Mission, items()));
    for m in &vehicle_frames(&reqs) {
        r.hear(m);
    }
    let read = as_pymavlink_reads(&r.sent);
    let seqs: Vec<u64> = read[1..]
        .iter()
        .map(|v| v["seq"].as_u64().unwrap())
        .collect();
    assert_eq!(seqs, [0, 1, 1, 2, 3, 3, 4]);
    for got in &read[1..] {
        assert_fields(got, &expected_item(got["seq"].as_u64().unwrap()));
    }
    assert!(matches!(
        r.events.last(),
        Some(MissionEvent::Uploaded { count: 5, .. })
    ));
}

#[test]
fn a_vehicle_that_never_acks_gets_every_item_and_the_failure_is_shown() {
    let mut r = Run::new();
    r.submit(Request::Upload(MissionType::Mission, items()));
    for m in &vehicle_frames(&requests(&[0, 1, 2, 3, 4], false)) {
        r.hear(m);
    }
    let last = r.now;
    r.wait(VEHICLE_WAIT + ACK_TIMEOUT);
    let read = as_pymavlink_reads(&r.sent);
    assert_eq!(read.len(), 6, "COUNT and the five items, nothing resent");
    for (k, got) in read[1..].iter().enumerate() {
        assert_fields(got, &expected_item(k as u64));
    }
    let failed: Vec<&MissionEvent> = r
        .events
        .iter()
        .filter(|e| matches!(e, MissionEvent::Failed { .. }))
        .collect();
    assert_eq!(failed.len(), 1);
    let (_, text) = failed[0].notice(V).unwrap();
    assert_eq!(
        text,
        "mission upload with 1:1 failed: no MISSION_ACK after the last item (5 s): the vehicle \
         may or may not have taken the mission; download it to see"
    );
    assert_eq!(
        r.m.known(MissionType::Mission),
        None,
        "not taken as on the vehicle"
    );
    assert!(r.now >= last + VEHICLE_WAIT);
}

#[test]
fn a_refusal_is_shown_with_its_result_and_no_space_tried_again() {
    let acks = vehicle_frames(&[mission_ack(4, 0), mission_ack(3, 0)]);
    let mut r = Run::new();
    r.submit(Request::Upload(MissionType::Mission, items()));
    r.hear(&acks[0]);
    assert!(matches!(
        r.events.last(),
        Some(MissionEvent::Refused {
            result: 4,
            retry_in: Some(NO_SPACE_WAIT),
            ..
        })
    ));
    r.wait(NO_SPACE_WAIT);
    assert_eq!(r.names(), ["MISSION_COUNT", "MISSION_COUNT"]);
    // Refused for another reason: final, shown by name.
    r.hear(&acks[1]);
    let (_, text) = r.events.last().unwrap().notice(V).unwrap();
    assert_eq!(text, "mission upload refused by 1:1: UNSUPPORTED");
    assert!(!r.m.busy());
}

fn fence_item(seq: u16, lat: i32, lon: i32, mission_type: u8) -> Value {
    from_vehicle(
        "MISSION_ITEM_INT",
        json!({"target_system": 255, "target_component": 190, "seq": seq, "frame": 0,
               "command": 5001, "current": 0, "autocontinue": 0, "param1": 3.0, "param2": 0.0,
               "param3": 0.0, "param4": 0.0, "x": lat, "y": lon, "z": 0.0,
               "mission_type": mission_type}),
    )
}

#[test]
fn a_download_asks_again_for_a_lost_item_and_ignores_what_it_did_not_ask_for() {
    let coords = [
        (-353_650_576, 1_491_630_269),
        (-353_605_660, 1_491_630_269),
        (-353_605_660, 1_491_685_346),
    ];
    let frames = vehicle_frames(&[
        from_vehicle(
            "MISSION_COUNT",
            json!({"target_system": 255, "target_component": 190, "count": 3, "mission_type": 1}),
        ),
        fence_item(0, coords[0].0, coords[0].1, 1),
        fence_item(2, coords[2].0, coords[2].1, 1), // not asked for yet
        fence_item(1, 1, 2, 0),                     // a mission item, not a fence item
        fence_item(1, coords[1].0, coords[1].1, 1),
        fence_item(2, coords[2].0, coords[2].1, 1),
    ]);
    let mut r = Run::new();
    r.submit(Request::Download(MissionType::Fence));
    r.hear(&frames[0]); // COUNT -> REQUEST_INT 0
    r.hear(&frames[1]); // item 0 -> REQUEST_INT 1
    r.hear(&frames[2]); // item 2: ignored
    r.hear(&frames[3]); // mission item 1: ignored
                        // Item 1 lost: asked for again.
    r.wait(ITEM_TIMEOUT);
    r.hear(&frames[4]); // item 1 -> REQUEST_INT 2
    r.hear(&frames[5]); // item 2 -> ACK
    let read = as_pymavlink_reads(&r.sent);
    let summary: Vec<(String, Option<u64>)> = read
        .iter()
        .map(|v| {
            let name = v["name"].as_str().unwrap().to_string();
            // "seq" is the item's in a request, the frame's sequence number otherwise.
            let seq = v["seq"].as_u64().filter(|_| name == "MISSION_REQUEST_INT");
            (name, seq)
        })
        .collect();
    let s = |n: &str, q: Option<u64>| (n.to_string(), q);
    assert_eq!(
        summary,
        [
            s("MISSION_REQUEST_LIST", None),
            s("MISSION_REQUEST_INT", Some(0)),
            s("MISSION_REQUEST_INT", Some(1)),
            s("MISSION_REQUEST_INT", Some(1)),
            s("MISSION_REQUEST_INT", Some(2)),
            s("MISSION_ACK", None),
        ]
    );
    for v in &read {
        assert_fields(
            v,
            &json!({"target_system": 1, "target_component": 1, "mission_type": 1}),
        );
    }
    assert_eq!(read[5]["type"], 0, "MAV_MISSION_ACCEPTED");
    let Some(MissionEvent::Downloaded { items, .. }) = r.events.last() else {
        panic!("{:?}", r.events);
    };
    let got: Vec<(u16, u16, i32, i32, f32)> = items
        .iter()
        .map(|i| (i.seq, i.command, i.x, i.y, i.params[0]))
        .collect();
    assert_eq!(
        got,
        [
            (0, 5001, coords[0].0, coords[0].1, 3.0),
            (1, 5001, coords[1].0, coords[1].1, 3.0),
            (2, 5001, coords[2].0, coords[2].1, 3.0),
        ]
    );
    assert!(items.iter().all(|i| i.mission_type == MissionType::Fence));
}

#[test]
fn a_download_answered_with_legacy_mission_item_is_read() {
    let item = |seq: u16, x: f64, y: f64, z: f64| {
        from_vehicle(
            "MISSION_ITEM",
            json!({"target_system": 255, "target_component": 190, "seq": seq, "frame": 3,
                   "command": 16, "current": 0, "autocontinue": 1, "param1": 0.0, "param2": 0.0,
                   "param3": 0.0, "param4": 0.0, "x": x, "y": y, "z": z, "mission_type": 0}),
        )
    };
    let frames = vehicle_frames(&[
        from_vehicle(
            "MISSION_COUNT",
            json!({"target_system": 255, "target_component": 190, "count": 2, "mission_type": 0}),
        ),
        item(0, -35.3632621, 149.1652374, 584.0),
        item(1, -35.36, 149.16, 20.0),
    ]);
    let mut r = Run::new();
    r.submit(Request::Download(MissionType::Mission));
    for f in &frames {
        r.hear(f);
    }
    let Some(MissionEvent::Downloaded { items, .. }) = r.events.last() else {
        panic!("{:?}", r.events);
    };
    // MISSION_ITEM carries float32 degrees: the nearest 1e-7° of that float.
    let e7 = |v: f64| ((v as f32) as f64 * 1e7).round() as i32;
    assert_eq!((items[0].x, items[0].y), (e7(-35.3632621), e7(149.1652374)));
    assert_eq!(
        (items[1].x, items[1].y, items[1].z),
        (e7(-35.36), e7(149.16), 20.0)
    );
}

#[test]
fn clear_and_set_current_as_pymavlink_reads_them() {
    let mut r = Run::new();
    r.submit(Request::Clear(MissionType::Rally));
    // No answer: sent again after the ACK timeout; then the ACK.
    r.wait(ACK_TIMEOUT);
    r.hear(&vehicle_frames(&[mission_ack(0, 2)])[0]);
    assert_eq!(
        r.events.last(),
        Some(&MissionEvent::Cleared {
            mission_type: MissionType::Rally
        })
    );
    let out = r.m.set_current(r.now, 3).unwrap();
    r.take(out);
    let read = as_pymavlink_reads(&r.sent);
    for v in &read[..2] {
        assert_fields(
            v,
            &json!({"name": "MISSION_CLEAR_ALL", "target_system": 1, "target_component": 1, "mission_type": 2}),
        );
    }
    assert_fields(
        &read[2],
        &json!({"name": "MISSION_SET_CURRENT", "seq": 3, "target_system": 1, "target_component": 1}),
    );
}

/// A frame from the vehicle 1:1, packed by our encoder.
fn vehicle_frame(seq: u8, m: &MavMessage) -> Vec<u8> {
    encode(
        Version::V2,
        Header {
            sysid: 1,
            compid: 1,
            seq,
        },
        m,
    )
}

fn feed(app: &mut mavterm::app::App, now: Micros, bytes: &[u8]) -> Vec<mavterm::app::Effect> {
    app.update(
        now,
        mavterm::app::Event::Frames {
            link: 0,
            frames: FrameParser::new().parse_all(bytes),
            stats: mavterm::link::ParserStats::default(),
        },
    )
}

/// Mission messages among the effects.
fn mission_sends(fx: &[mavterm::app::Effect]) -> Vec<MavMessage> {
    use mavlink::Message;
    fx.iter()
        .filter_map(|e| match e {
            mavterm::app::Effect::Send { msg, .. } if msg.message_name().starts_with("MISSION") => {
                Some(msg.clone())
            }
            _ => None,
        })
        .collect()
}

#[test]
fn the_session_routes_the_vehicles_mission_messages_and_its_timeouts() {
    use mavterm::dialect::{self, MavMissionType};
    let mut app = mavterm::app::App::new(mavterm::app::AppConfig {
        sysid: 250,
        compid: 191,
        links: vec!["test".into()],
        request_streams: false,
        fetch_params: false,
        ..Default::default()
    });
    feed(&mut app, 0, &common::copter_heartbeat(1, 0, 0));
    let s = app.sessions.get_mut(&V).expect("a session");
    let out = s
        .mission_submit(1_000, Request::Download(MissionType::Rally))
        .unwrap();
    assert!(matches!(
        &out[..],
        [mavterm::app::session::SessionOut::Send(
            MavMessage::MISSION_REQUEST_LIST(_)
        )]
    ));
    let count = |ts: u8, tc: u8| {
        MavMessage::MISSION_COUNT(dialect::MISSION_COUNT_DATA {
            count: 1,
            target_system: ts,
            target_component: tc,
            mission_type: MavMissionType::MAV_MISSION_TYPE_RALLY,
            opaque_id: 0,
        })
    };
    // Addressed to another GCS: not ours.
    assert!(mission_sends(&feed(&mut app, 10_000, &vehicle_frame(1, &count(255, 190)))).is_empty());
    // Ours: item 0 asked for, on the link, addressed to the vehicle.
    let sent = mission_sends(&feed(&mut app, 20_000, &vehicle_frame(2, &count(250, 191))));
    assert!(matches!(&sent[..], [MavMessage::MISSION_REQUEST_INT(r)]
        if r.seq == 0 && VehicleKey(r.target_system, r.target_component) == V
            && r.mission_type == MavMissionType::MAV_MISSION_TYPE_RALLY));
    // The core wakes for the item timeout and asks again.
    let due = app.next_deadline();
    assert!(due <= 20_000 + ITEM_TIMEOUT, "{due}");
    let sent = mission_sends(&app.update(20_000 + ITEM_TIMEOUT, mavterm::app::Event::Tick));
    assert!(matches!(&sent[..], [MavMessage::MISSION_REQUEST_INT(r)] if r.seq == 0));
    let item = MavMessage::MISSION_ITEM_INT(dialect::MISSION_ITEM_INT_DATA {
        seq: 0,
        command: dialect::MavCmd::MAV_CMD_NAV_RALLY_POINT,
        target_system: 250,
        target_component: 191,
        frame: dialect::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
        x: -353_635_304,
        y: 1_491_654_503,
        z: 15.0,
        mission_type: MavMissionType::MAV_MISSION_TYPE_RALLY,
        ..Default::default()
    });
    let sent = mission_sends(&feed(&mut app, 300_000, &vehicle_frame(3, &item)));
    assert!(
        matches!(&sent[..], [MavMessage::MISSION_ACK(a)] if a.mission_type == MavMissionType::MAV_MISSION_TYPE_RALLY)
    );
    let known = app.sessions[&V].mission.known(MissionType::Rally).unwrap();
    assert_eq!((known.items[0].x, known.items[0].z), (-353_635_304, 15.0));
    assert!(app
        .notices
        .iter()
        .any(|n| n.text == "rally downloaded from 1:1: 1 item"));
}
