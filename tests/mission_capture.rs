//! The real ArduCopter mission session (tests/data/copter-mission.{gcs,vehicle}.tlog, from
//! shared/captures) replayed through the mission machine: the capture's GCS asked for three
//! uploads and three downloads; the machine is asked for the same, the vehicle's recorded frames
//! are its replies at their recorded times. What the machine sends must be what the capture's
//! GCS sent, and what it reads what the vehicle sent, both as pymavlink decoded them
//! (expected.json): the upload refused with NO_SPACE right after boot and tried again 3 s
//! later, MISSION_REQUEST (not _INT) answered with MISSION_ITEM_INT, six mission items, four
//! fence vertices and a rally point read back. And the core keeps both of the GCS side's frames
//! that carry sequence number 14.

use mavlink::Message;
use mavterm::app::{App, AppConfig, Event};
use mavterm::clock::{Micros, SECOND};
use mavterm::dialect::MavMessage;
use mavterm::link::tlog::read_tlog;
use mavterm::link::{Frame, FrameParser, ParserStats};
use mavterm::mission::{upload_warnings, MissionItem, MissionType};
use mavterm::proto::mission::{MissionEvent, MissionMachine, MissionMsg, MissionOut, Request};
use mavterm::proto::vehicles::VehicleKey;
use serde_json::{json, Value};

fn data(name: &str) -> String {
    format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn expected() -> Value {
    serde_json::from_str(&std::fs::read_to_string(data("expected.json")).unwrap()).unwrap()
}

/// Each record of a tlog: its time and its frame.
fn records(name: &str) -> Vec<(u64, Frame)> {
    let bytes = std::fs::read(data(name)).unwrap();
    read_tlog(&bytes)
        .unwrap()
        .iter()
        .map(|r| {
            let mut f = FrameParser::new().parse_all(&r.frame);
            assert_eq!(f.len(), 1, "{name}: one frame per record");
            (r.time_us, f.remove(0))
        })
        .collect()
}

/// One of our messages as expected.json lists a mission message.
fn entry(m: &MavMessage) -> Option<Value> {
    Some(match m {
        MavMessage::MISSION_COUNT(c) => json!({"type": "MISSION_COUNT", "count": c.count,
            "mission_type": c.mission_type as u8}),
        MavMessage::MISSION_ITEM_INT(i) => json!({"type": "MISSION_ITEM_INT", "seq": i.seq,
            "command": i.command as u16, "frame": i.frame as u8, "z": i.z as f64,
            "mission_type": i.mission_type as u8}),
        MavMessage::MISSION_REQUEST_LIST(r) => json!({"type": "MISSION_REQUEST_LIST",
            "mission_type": r.mission_type as u8}),
        MavMessage::MISSION_REQUEST_INT(r) => json!({"type": "MISSION_REQUEST_INT", "seq": r.seq,
            "mission_type": r.mission_type as u8}),
        MavMessage::MISSION_ACK(a) => json!({"type": "MISSION_ACK", "result": a.mavtype as u8,
            "mission_type": a.mission_type as u8}),
        _ => return None,
    })
}

struct Replay {
    m: MissionMachine,
    sent: Vec<(Micros, MavMessage)>,
    events: Vec<(Micros, MissionEvent)>,
}

impl Replay {
    fn take(&mut self, now: Micros, out: Vec<MissionOut>) {
        for o in out {
            match o {
                MissionOut::Send(m) => self.sent.push((now, m)),
                MissionOut::Event(e) => self.events.push((now, e)),
            }
        }
    }

    fn poll_until(&mut self, now: Micros) {
        while let Some(d) = self.m.next_deadline().filter(|d| *d <= now) {
            let out = self.m.poll(d);
            self.take(d, out);
        }
    }
}

#[test]
fn the_real_arducopter_mission_session_replays_through_the_machine() {
    let gcs = records("copter-mission.gcs.tlog");
    let vehicle = records("copter-mission.vehicle.tlog");
    let t0 = gcs[0].0.min(vehicle[0].0);
    // What the capture's GCS uploaded, per list, and when it began.
    let mut uploads: [Vec<MissionItem>; 3] = Default::default();
    for (_, f) in &gcs {
        if let Some(MissionMsg::Item { item, .. }) = MissionMsg::read(f.msgid, f.payload()) {
            let list = &mut uploads[item.mission_type.index()];
            if item.seq as usize == list.len() {
                list.push(item);
            }
        }
    }
    assert_eq!(uploads.each_ref().map(Vec::len), [6, 4, 1]);
    let start = gcs.iter().find(|(_, f)| f.msgid == 44).unwrap().0 - t0;

    let mut r = Replay {
        m: MissionMachine::new(VehicleKey(1, 1)),
        sent: Vec::new(),
        events: Vec::new(),
    };
    let [mission, fence, rally] = uploads.clone();
    for req in [
        Request::Upload(MissionType::Mission, mission),
        Request::Upload(MissionType::Fence, fence),
        Request::Upload(MissionType::Rally, rally),
        Request::Download(MissionType::Mission),
        Request::Download(MissionType::Fence),
        Request::Download(MissionType::Rally),
    ] {
        let out = r.m.submit(start, req).unwrap();
        r.take(start, out);
    }
    let mut first_request = None;
    for (t, f) in &vehicle {
        let now = t - t0;
        r.poll_until(now);
        if (f.sysid, f.compid) != (1, 1) {
            continue;
        }
        if let Some(MavMessage::STATUSTEXT(st)) = f.message.as_deref() {
            let end = st.text.iter().position(|&b| b == 0).unwrap_or(50);
            r.m.on_text(now, &String::from_utf8_lossy(&st.text[..end]));
        }
        if let Some(msg) = MissionMsg::read(f.msgid, f.payload()) {
            if matches!(msg, MissionMsg::Request { .. }) {
                first_request.get_or_insert(now);
            }
            let out = r.m.on_message(now, &msg);
            r.take(now, out);
        }
    }
    let end = vehicle.last().unwrap().0 - t0 + 10 * SECOND;
    r.poll_until(end);

    // What we sent is what the capture's GCS sent, message for message.
    let exp = expected();
    let ours: Vec<Value> = r.sent.iter().filter_map(|(_, m)| entry(m)).collect();
    let theirs = exp["copter-mission.gcs.tlog"]["mission_protocol_in_order"]
        .as_array()
        .unwrap();
    assert_eq!(ours.len(), theirs.len());
    for (k, (a, b)) in ours.iter().zip(theirs).enumerate() {
        assert_eq!(a, b, "message {k}");
    }

    // The refusal, shown with its reason, then the upload tried again 3 s later, in time for the
    // vehicle's first MISSION_REQUEST.
    let (t_refused, refused) = &r
        .events
        .iter()
        .find(|(_, e)| matches!(e, MissionEvent::Refused { .. }))
        .unwrap();
    assert_eq!(
        refused,
        &MissionEvent::Refused {
            op: mavterm::proto::mission::OpKind::Upload,
            mission_type: MissionType::Mission,
            result: 4,
            retry_in: Some(3 * SECOND)
        }
    );
    let (_, text) = refused.notice(VehicleKey(1, 1)).unwrap();
    assert_eq!(
        text,
        "mission upload refused by 1:1: NO_SPACE, trying again in 3 s"
    );
    assert_eq!(
        r.m.last_refusal().unwrap().reason.as_deref(),
        Some("Only 0 items are supported")
    );
    let counts: Vec<Micros> = r
        .sent
        .iter()
        .filter(|(_, m)| matches!(m, MavMessage::MISSION_COUNT(c) if c.mission_type as u8 == 0))
        .map(|(t, _)| *t)
        .collect();
    assert_eq!(counts, [start, t_refused + 3 * SECOND]);
    assert!(counts[1] < first_request.unwrap());

    // Every transfer done, none failed.
    let done: Vec<String> = r
        .events
        .iter()
        .filter_map(|(_, e)| match e {
            MissionEvent::Uploaded {
                mission_type,
                count,
                ..
            } => Some(format!("up {mission_type} {count}")),
            MissionEvent::Downloaded {
                mission_type,
                items,
                ..
            } => Some(format!("down {mission_type} {}", items.len())),
            MissionEvent::Failed { reason, .. } => Some(format!("failed: {reason}")),
            _ => None,
        })
        .collect();
    assert_eq!(
        done,
        [
            "up mission 6",
            "up fence 4",
            "up rally 1",
            "down mission 6",
            "down fence 4",
            "down rally 1"
        ]
    );

    // What we read is what the vehicle sent, as pymavlink decoded it.
    let vehicle_items: Vec<Value> = exp["copter-mission.vehicle.tlog"]["mission_protocol_in_order"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|e| e["type"] == "MISSION_ITEM_INT")
        .cloned()
        .collect();
    let mut read: Vec<Value> = Vec::new();
    for t in MissionType::ALL {
        let k = r.m.known(t).unwrap();
        assert!(k.downloaded);
        for i in &k.items {
            read.push(
                json!({"type": "MISSION_ITEM_INT", "seq": i.seq, "command": i.command,
                "frame": i.frame, "z": i.z as f64, "mission_type": t.code()}),
            );
        }
    }
    assert_eq!(read, vehicle_items);
    // The positions ArduPilot gives back are the ones uploaded (home aside: not set yet).
    for t in MissionType::ALL {
        let back = &r.m.known(t).unwrap().items;
        for (u, d) in uploads[t.index()]
            .iter()
            .zip(back)
            .skip((t == MissionType::Mission) as usize)
        {
            assert_eq!((u.x, u.y), (d.x, d.y), "{t} item {}", u.seq);
        }
    }
    // Frames shown beside altitudes: the DO_CHANGE_SPEED (frame 0 on the way back) has none.
    let m = &r.m.known(MissionType::Mission).unwrap().items;
    let shown: Vec<Option<String>> = m.iter().map(|i| i.altitude_text()).collect();
    assert_eq!(
        shown,
        [
            Some("0.0 m AMSL".to_string()),
            Some("15.0 m REL".to_string()),
            Some("20.0 m REL".to_string()),
            None,
            Some("25.0 m REL".to_string()),
            Some("606.0 m AMSL".to_string()),
        ]
    );
    // The capture's mission mixes frames: an upload of it asks for a confirmation that says so.
    assert_eq!(
        upload_warnings(&uploads[0], Some(584.0), true),
        ["altitudes in mixed frames: AMSL (item 5), REL (items 1-2, 4)"]
    );

    // Items reached (ArduPilot sends no MISSION_ITEM_REACHED for some), and where it ended.
    let reached: Vec<u64> = r.m.reached().map(|(_, s)| s as u64).collect();
    let exp_reached: Vec<u64> = exp["copter-mission.vehicle.tlog"]["mission_items_reached"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap())
        .collect();
    assert_eq!(reached, exp_reached);
    let cur = r.m.current.unwrap();
    assert_eq!((cur.seq, cur.total, cur.state_name()), (0, 5, "complete"));
    assert!(!r.m.busy());
    assert_eq!(r.m.next_deadline(), None);
}

#[test]
fn both_gcs_frames_with_sequence_14_are_kept_by_the_core() {
    let gcs = records("copter-mission.gcs.tlog");
    // The capture's GCS used two threads: a HEARTBEAT and a MISSION_COUNT both carry 14.
    let fourteen: Vec<&str> = gcs
        .windows(2)
        .find(|w| w[0].1.seq == 14 && w[1].1.seq == 14)
        .map(|w| {
            w.iter()
                .map(|(_, f)| f.message.as_deref().map_or("?", |m| m.message_name()))
                .collect()
        })
        .unwrap();
    assert_eq!(fourteen, ["HEARTBEAT", "MISSION_COUNT"]);
    // Heard by a core with another id (so 255:190 is another GCS, not an echo of ours).
    let mut app = App::new(AppConfig {
        sysid: 254,
        links: vec!["capture".into()],
        request_streams: false,
        fetch_params: false,
        ..AppConfig::default()
    });
    let t0 = gcs[0].0;
    for (t, f) in &gcs {
        app.update(
            t - t0,
            Event::Frames {
                link: 0,
                frames: vec![f.clone()],
                stats: ParserStats::default(),
            },
        );
    }
    let exp = expected();
    for (name, n) in exp["copter-mission.gcs.tlog"]["types"].as_object().unwrap() {
        let id = mavterm::dialect::MavMessage::message_id_from_name(name).unwrap();
        let got = app.inspector.get((255, 190, id)).map_or(0, |e| e.count);
        assert_eq!(got, n.as_u64().unwrap(), "{name}");
    }
}
