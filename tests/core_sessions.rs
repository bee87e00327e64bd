//! What the core sends, and to whom: the GCS heartbeat on every link, stream requests per
//! autopilot and per link (each ArduPilot group at its rate, SET_MESSAGE_INTERVAL one at a time,
//! checked, retried, asked again after a reboot but not after a fade, nothing on a high-latency
//! link), routing over two links, frames that are not ours or not for us. Vehicle frames are packed by
//! pymavlink and everything the core sends is read back by pymavlink: the expected values are
//! pymavlink's and the spec's, not our encoder's.

mod common;

use std::sync::OnceLock;

use mavterm::app::links::LinkState;
use mavterm::app::{App, AppConfig, Effect, Event};
use mavterm::clock::{Micros, SECOND};
use mavterm::link::{FrameParser, LinkId, ParserStats};
use mavterm::proto::rates::StreamRates;
use mavterm::proto::vehicles::VehicleKey;
use serde_json::{json, Value};

/// MAV_AUTOPILOT values (common.xml).
const ARDUPILOT: u64 = 3;
const PX4: u64 = 12;

fn app(links: usize) -> App {
    App::new(AppConfig {
        links: (0..links).map(|i| format!("test{i}")).collect(),
        // Streams and commands only: the parameter download is tested on its own.
        fetch_params: false,
        ..AppConfig::default()
    })
}

/// ArduPilot asked for EXTRA1 (ATTITUDE) only, at 10 Hz, and others ATTITUDE at 10 Hz: the
/// flying tests send ATTITUDE, and one request per ask is easy to count.
fn attitude_only(links: usize) -> App {
    App::new(AppConfig {
        links: (0..links).map(|i| format!("test{i}")).collect(),
        fetch_params: false,
        streams: StreamRates {
            groups: [(10, 10.0)].into_iter().collect(),
            messages: [(30, 10.0)].into_iter().collect(),
            ardupilot_messages: Default::default(),
        },
        ..AppConfig::default()
    })
}

/// A frame packed by pymavlink.
fn packed(req: Value) -> Vec<u8> {
    common::pymavlink_encode(&[req]).remove(0)
}

fn heartbeat_req(sysid: u8, seq: u8, autopilot: u64) -> Value {
    json!({"sysid": sysid, "compid": 1, "seq": seq, "msg": "HEARTBEAT", "fields": {
        "type": 2, "autopilot": autopilot, "base_mode": 1, "custom_mode": 0,
        "system_status": 3, "mavlink_version": 3}})
}

fn attitude_req(sysid: u8, seq: u8) -> Value {
    json!({"sysid": sysid, "compid": 1, "seq": seq, "msg": "ATTITUDE", "fields": {
        "time_boot_ms": 1000, "roll": 0.0, "pitch": 0.0, "yaw": 0.0,
        "rollspeed": 0.0, "pitchspeed": 0.0, "yawspeed": 0.0}})
}

/// Every seq of the frames the flying tests use, packed by pymavlink in one run:
/// ArduPilot heartbeats and ATTITUDE from 1:1, PX4 heartbeats from 7:1.
fn table() -> &'static Vec<Vec<u8>> {
    static TABLE: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut reqs = Vec::new();
        for seq in 0..=255u8 {
            reqs.push(heartbeat_req(1, seq, ARDUPILOT));
            reqs.push(attitude_req(1, seq));
            reqs.push(heartbeat_req(7, seq, PX4));
        }
        common::pymavlink_encode(&reqs)
    })
}

fn heartbeat(sysid: u8, seq: u8, autopilot: u64) -> Vec<u8> {
    match (sysid, autopilot) {
        (1, ARDUPILOT) => table()[seq as usize * 3].clone(),
        (7, PX4) => table()[seq as usize * 3 + 2].clone(),
        _ => packed(heartbeat_req(sysid, seq, autopilot)),
    }
}

fn attitude(sysid: u8, seq: u8) -> Vec<u8> {
    assert_eq!(sysid, 1);
    table()[seq as usize * 3 + 1].clone()
}

/// Feed `bytes` as read on `link` at `now`; returns the effects.
fn feed(app: &mut App, now: Micros, link: LinkId, bytes: &[u8]) -> Vec<Effect> {
    let frames = FrameParser::new().parse_all(bytes);
    app.update(
        now,
        Event::Frames {
            link,
            frames,
            stats: ParserStats::default(),
        },
    )
}

/// Step the core's own timers up to `until`, exactly at its deadlines.
fn run_timers(app: &mut App, until: Micros) -> Vec<Effect> {
    let mut fx = Vec::new();
    while app.next_deadline() <= until {
        let t = app.next_deadline().max(app.now);
        fx.extend(app.update(t, Event::Tick));
        if app.next_deadline() <= t {
            break;
        }
    }
    fx.extend(app.update(until, Event::Tick));
    fx
}

/// (link, frame) of every Send.
fn sends(fx: &[Effect]) -> Vec<(LinkId, Vec<u8>)> {
    fx.iter()
        .filter_map(|e| match e {
            Effect::Send { link, frame, .. } => Some((*link, frame.clone())),
            _ => None,
        })
        .collect()
}

/// True for the flight telemetry's HOME_POSITION request (COMMAND_LONG REQUEST_MESSAGE 242),
/// which tests/flight.rs checks.
fn home_request(v: &Value) -> bool {
    v["name"] == "COMMAND_LONG" && v["command"] == 512 && v["param1"] == 242.0
}

/// pymavlink's reading of what was sent, with the link each went on, heartbeats and HOME_POSITION
/// requests left out.
fn decoded(fx: &[Effect]) -> Vec<(LinkId, Value)> {
    let s = sends(fx);
    let frames: Vec<Vec<u8>> = s.iter().map(|(_, f)| f.clone()).collect();
    let d = common::pymavlink_decode(&frames);
    s.iter()
        .map(|(l, _)| *l)
        .zip(d)
        .inspect(|(_, v)| assert!(v.get("error").is_none(), "pymavlink refused: {v}"))
        .filter(|(_, v)| v["name"] != "HEARTBEAT" && !home_request(v))
        .collect()
}

fn count_stream_requests(fx: &[Effect]) -> usize {
    decoded(fx)
        .iter()
        .filter(|(_, v)| v["name"] == "REQUEST_DATA_STREAM" || v["name"] == "COMMAND_LONG")
        .count()
}

#[test]
fn gcs_heartbeat_once_a_second_on_every_link() {
    let mut a = app(3);
    let fx = run_timers(&mut a, 3 * SECOND + SECOND / 2);
    let s = sends(&fx);
    let frames: Vec<Vec<u8>> = s.iter().map(|(_, f)| f.clone()).collect();
    let d = common::pymavlink_decode(&frames);
    for link in 0..3 {
        let mine: Vec<&Value> = s
            .iter()
            .zip(&d)
            .filter(|((l, _), _)| *l == link)
            .map(|(_, v)| v)
            .collect();
        // t = 0, 1, 2, 3 s: four heartbeats, each link counting its own sequence from 0.
        assert_eq!(mine.len(), 4, "link {link}: {mine:?}");
        for (i, v) in mine.iter().enumerate() {
            assert_eq!(v["name"], "HEARTBEAT", "{v}");
            assert_eq!(
                (v["sysid"].as_u64(), v["compid"].as_u64()),
                (Some(255), Some(190))
            );
            assert_eq!(v["seq"].as_u64(), Some(i as u64));
            assert_eq!(v["type"].as_u64(), Some(6)); // MAV_TYPE_GCS
            assert_eq!(v["autopilot"].as_u64(), Some(8)); // MAV_AUTOPILOT_INVALID
        }
    }
}

#[test]
fn ardupilot_is_asked_for_each_group_at_its_rate_on_every_link_it_is_heard_on() {
    let mut a = app(3);
    let mut fx = Vec::new();
    // Heard on links 0 and 1 (the same frames, as through two radios), never on link 2.
    for i in 0..3u8 {
        let t = i as Micros * SECOND;
        fx.extend(feed(&mut a, t, 0, &heartbeat(1, i, ARDUPILOT)));
        fx.extend(feed(&mut a, t + 20_000, 1, &heartbeat(1, i, ARDUPILOT)));
    }
    let reqs = decoded(&fx);
    // The defaults (QGroundControl's): RAW_SENSORS 2, EXTENDED_STATUS 2, RC_CHANNELS 2,
    // POSITION 3, EXTRA1 10, EXTRA2 10, EXTRA3 3 Hz.
    let want = vec![(1, 2), (2, 2), (3, 2), (6, 3), (10, 10), (11, 10), (12, 3)];
    for link in 0..3 {
        let mut got = Vec::new();
        for (_, v) in reqs.iter().filter(|(l, _)| *l == link) {
            assert_eq!(v["name"], "REQUEST_DATA_STREAM", "{v}");
            assert_eq!(v["target_system"], 1);
            assert_eq!(v["target_component"], 1);
            assert_eq!(v["start_stop"], 1);
            got.push((
                v["req_stream_id"].as_u64().unwrap(),
                v["req_message_rate"].as_u64().unwrap(),
            ));
        }
        if link == 2 {
            assert!(got.is_empty(), "never heard on link 2: {got:?}");
        } else {
            assert_eq!(got, want, "link {link}");
        }
    }
    // One vehicle, heard on both links; its heartbeats are not counted twice.
    let v = a.vehicles.get(VehicleKey(1, 1)).unwrap();
    assert_eq!(v.links.iter().copied().collect::<Vec<_>>(), vec![0, 1]);
    assert_eq!(a.sessions.len(), 1);
}

/// A COMMAND_ACK of SET_MESSAGE_INTERVAL from `sysid`:1 with `result`.
fn interval_ack(sysid: u8, seq: u8, result: u64) -> Vec<u8> {
    packed(
        json!({"sysid": sysid, "compid": 1, "seq": seq, "msg": "COMMAND_ACK", "fields": {
        "command": 511, "result": result, "progress": 0, "result_param2": 0,
        "target_system": 255, "target_component": 190}}),
    )
}

#[test]
fn px4_is_asked_with_set_message_interval_only_one_at_a_time() {
    let mut a = app(1);
    let mut fx = feed(&mut a, 0, 0, &heartbeat(7, 0, PX4));
    let mut ids = Vec::new();
    // Each ACK lets the next one go; never two waiting.
    for seq in 1..20u8 {
        let t = 50_000 * seq as Micros;
        let reqs = decoded(&fx);
        assert!(reqs.len() <= 1, "one at a time: {reqs:?}");
        let Some((_, v)) = reqs.first() else { break };
        assert_eq!(v["name"], "COMMAND_LONG", "{v}");
        assert_eq!(v["command"], 511); // MAV_CMD_SET_MESSAGE_INTERVAL
        assert_eq!(v["target_system"], 7);
        assert_eq!(v["target_component"], 1);
        assert_eq!(v["confirmation"], 0);
        let id = v["param1"].as_f64().unwrap() as u32;
        let interval = v["param2"].as_f64().unwrap();
        ids.push((id, (1e6 / interval * 100.0).round() / 100.0));
        fx = feed(&mut a, t, 0, &interval_ack(7, seq, 0));
    }
    // The defaults for SET_MESSAGE_INTERVAL, in id order.
    assert_eq!(
        ids,
        vec![
            (1, 1.0),
            (2, 0.5),
            (24, 1.0),
            (30, 4.0),
            (33, 4.0),
            (74, 4.0),
            (147, 1.0)
        ]
    );
    assert!(!a.notices.iter().any(|n| n.severity.0 <= 4), "all accepted");
}

#[test]
fn the_operators_set_message_interval_and_ours_keep_their_own_acks() {
    use mavterm::dialect::MavCmd;
    use mavterm::proto::commands::{CommandSpec, State};
    let mut a = app(1);
    let fx = feed(&mut a, 0, 0, &heartbeat(7, 0, PX4));
    assert_eq!(decoded(&fx).len(), 1, "ours waits for its ACK");
    // The operator's own, while ours waits: it goes (the queue knows nothing of ours)...
    let spec = CommandSpec::long(
        (7, 1),
        MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
        [33.0, 200_000.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    );
    let s = a.sessions.get_mut(&VehicleKey(7, 1)).unwrap();
    let (id, out) = s.submit(1_000, spec).unwrap();
    assert_eq!(out.len(), 1);
    // ... the first ACK is ours (sent first) and the next one goes out only after the
    // operator's is answered.
    let fx = feed(&mut a, 50_000, 0, &interval_ack(7, 1, 0));
    assert!(decoded(&fx).is_empty(), "held while the operator's waits");
    let s = &a.sessions[&VehicleKey(7, 1)];
    assert_eq!(s.commands.get(id).unwrap().state, State::Waiting);
    let fx = feed(&mut a, 60_000, 0, &interval_ack(7, 2, 0));
    assert_eq!(
        a.sessions[&VehicleKey(7, 1)]
            .commands
            .get(id)
            .unwrap()
            .state,
        State::Done(0)
    );
    let reqs = decoded(&fx);
    assert_eq!(reqs.len(), 1, "{reqs:?}");
    assert_eq!(reqs[0].1["param1"], 2.0, "ours goes on with SYSTEM_TIME");
}

#[test]
fn a_high_latency_link_carries_nothing_but_our_heartbeat() {
    let mut a = App::new(AppConfig {
        links: vec!["tcp:127.0.0.1:5760?hl=1".into(), "test1".into()],
        ..AppConfig::default() // parameters fetched too
    });
    let mut fx = Vec::new();
    for i in 0..20u8 {
        let t = i as Micros * SECOND;
        fx.extend(run_timers(&mut a, t));
        fx.extend(feed(&mut a, t, 0, &heartbeat(1, i, ARDUPILOT)));
    }
    let s = sends(&fx);
    let d = common::pymavlink_decode(&s.iter().map(|(_, f)| f.clone()).collect::<Vec<_>>());
    assert!(!d.is_empty());
    for v in &d {
        assert_eq!(v["name"], "HEARTBEAT", "only our heartbeat: {v}");
    }
    // Heard on a normal link too: everything automatic goes there, and only there.
    let mut fx = Vec::new();
    for i in 20..30u8 {
        let t = i as Micros * SECOND;
        fx.extend(run_timers(&mut a, t));
        fx.extend(feed(&mut a, t, 0, &heartbeat(1, i, ARDUPILOT)));
        fx.extend(feed(&mut a, t + 1000, 1, &heartbeat(1, i, ARDUPILOT)));
    }
    let s = sends(&fx);
    let d = common::pymavlink_decode(&s.iter().map(|(_, f)| f.clone()).collect::<Vec<_>>());
    let mut names = std::collections::BTreeSet::new();
    for ((link, _), v) in s.iter().zip(&d) {
        if *link == 0 {
            assert_eq!(v["name"], "HEARTBEAT", "{v}");
        } else {
            names.insert(v["name"].as_str().unwrap().to_string());
        }
    }
    assert!(names.contains("REQUEST_DATA_STREAM"), "{names:?}");
    assert!(names.contains("COMMAND_LONG"), "{names:?}"); // HOME_POSITION, AUTOPILOT_VERSION
}

#[test]
fn components_that_are_not_autopilots_are_not_asked() {
    let mut a = app(1);
    // A gimbal (MAV_TYPE_GIMBAL, MAV_AUTOPILOT_INVALID) alone on its system, and another GCS.
    // The GCS gets nothing. The gimbal, a payload with no autopilot to reach it through, gets a
    // session of its own (it can be the target and be pointed) but no stream requests, no
    // parameter download and no HOME_POSITION: only the Gimbal Protocol's discovery
    // (REQUEST_MESSAGE GIMBAL_MANAGER_INFORMATION, 280, to it).
    let gimbal = packed(
        json!({"sysid": 1, "compid": 154, "seq": 0, "msg": "HEARTBEAT",
        "fields": {"type": 26, "autopilot": 8, "base_mode": 0, "custom_mode": 0,
        "system_status": 4, "mavlink_version": 3}}),
    );
    let gcs = packed(
        json!({"sysid": 255, "compid": 230, "seq": 0, "msg": "HEARTBEAT",
        "fields": {"type": 6, "autopilot": 8, "base_mode": 0, "custom_mode": 0,
        "system_status": 4, "mavlink_version": 3}}),
    );
    let mut fx = feed(&mut a, 0, 0, &gimbal);
    fx.extend(feed(&mut a, 1000, 0, &gcs));
    fx.extend(run_timers(&mut a, 10 * SECOND));
    let sent = decoded(&fx);
    assert!(
        !sent.iter().any(|(_, v)| v["name"] == "REQUEST_DATA_STREAM"
            || v["name"] == "PARAM_REQUEST_LIST"
            || v["name"] == "FILE_TRANSFER_PROTOCOL"
            || (v["name"] == "COMMAND_LONG" && v["param1"] != 280.0)),
        "{sent:?}"
    );
    assert!(sent
        .iter()
        .all(|(_, v)| v["target_system"] == 1 && v["target_component"] == 154));
    assert!(!sent.iter().any(|(_, v)| home_request(v)));
    assert_eq!(
        a.sessions.keys().copied().collect::<Vec<_>>(),
        vec![VehicleKey(1, 154)]
    );
    assert_eq!(a.target, Some(VehicleKey(1, 154)));
    // MAVProxy beside us at 255:230 is listed as a GCS and is no error.
    assert!(a.vehicles.get(VehicleKey(255, 230)).unwrap().is_gcs());
    assert!(
        !a.notices.iter().any(|n| n.severity.0 <= 3),
        "{:?}",
        a.notices.iter().collect::<Vec<_>>()
    );
}

/// A vehicle at 1 Hz heartbeat; with `telemetry`, ATTITUDE at 10 Hz. Returns the effects.
fn fly(a: &mut App, from: Micros, to: Micros, seq: &mut u8, telemetry: bool) -> Vec<Effect> {
    let mut fx = Vec::new();
    let mut t = from;
    while t < to {
        fx.extend(run_timers(a, t));
        if t.is_multiple_of(SECOND) {
            fx.extend(feed(a, t, 0, &heartbeat(1, *seq, ARDUPILOT)));
            *seq = seq.wrapping_add(1);
        }
        if telemetry {
            fx.extend(feed(a, t, 0, &attitude(1, *seq)));
            *seq = seq.wrapping_add(1);
        }
        t += 100_000;
    }
    fx
}

#[test]
fn streams_are_asked_again_until_telemetry_comes_then_left_alone() {
    let mut a = attitude_only(1);
    let mut seq = 0;
    // Heartbeats only: asked at 0 and again when checked 3 s later.
    let fx = fly(&mut a, 0, 4 * SECOND, &mut seq, false);
    assert_eq!(count_stream_requests(&fx), 2, "asked at 0 s and 3 s");
    // Telemetry arrives: no more requests.
    let fx = fly(&mut a, 4 * SECOND, 60 * SECOND, &mut seq, true);
    assert_eq!(count_stream_requests(&fx), 0);
    let s = &a.sessions[&VehicleKey(1, 1)].streams;
    let measured = s.measured(a.now, 0, 30).unwrap();
    assert!((measured - 10.0).abs() < 0.5, "{measured}");
}

#[test]
fn a_group_that_never_comes_is_asked_by_set_message_interval_then_given_up() {
    let mut a = attitude_only(1);
    let mut seq = 0;
    let fx = fly(&mut a, 0, 12 * SECOND, &mut seq, false);
    let reqs = decoded(&fx);
    let names: Vec<&str> = reqs
        .iter()
        .map(|(_, v)| v["name"].as_str().unwrap())
        .collect();
    // REQUEST_DATA_STREAM twice, then SET_MESSAGE_INTERVAL ATTITUDE, sent three times without
    // an answer.
    assert_eq!(
        names,
        vec![
            "REQUEST_DATA_STREAM",
            "REQUEST_DATA_STREAM",
            "COMMAND_LONG",
            "COMMAND_LONG",
            "COMMAND_LONG"
        ],
        "{reqs:?}"
    );
    assert!(reqs[2..].iter().all(|(_, v)| v["param1"] == 30.0));
    let texts: Vec<&str> = a.notices.iter().map(|n| n.text.as_str()).collect();
    assert!(
        texts
            .iter()
            .any(|t| t.contains("no ATTITUDE from 1:1 on link 0")),
        "{texts:?}"
    );
    let fx = fly(&mut a, 12 * SECOND, 60 * SECOND, &mut seq, false);
    assert_eq!(count_stream_requests(&fx), 0, "left alone");
}

#[test]
fn streams_are_asked_again_after_a_reboot_but_not_after_a_fade() {
    let mut a = attitude_only(1);
    let mut seq = 0;
    let fx = fly(&mut a, 0, 10 * SECOND, &mut seq, true);
    assert_eq!(count_stream_requests(&fx), 1);
    // A fade: the radio hears nothing for 4 s, then everything comes back.
    let fx = fly(&mut a, 14 * SECOND, 30 * SECOND, &mut seq, true);
    assert_eq!(count_stream_requests(&fx), 0, "a fade asks nothing");
    // A reboot nobody announced: heartbeats come back (sequence from 0) but no telemetry.
    let mut seq = 0;
    let fx = fly(&mut a, 36 * SECOND, 44 * SECOND, &mut seq, false);
    assert!(
        count_stream_requests(&fx) >= 1,
        "asked again after the reboot"
    );
    let reboots: Vec<_> = a
        .notices
        .iter()
        .filter(|n| n.text.contains("rebooted"))
        .collect();
    assert_eq!(reboots.len(), 1, "{reboots:?}");
}

#[test]
fn routing_follows_the_most_recent_link_and_switches_when_one_goes_down() {
    let mut a = app(2);
    for l in 0..2 {
        a.update(
            0,
            Event::LinkState {
                link: l,
                state: LinkState::Up,
            },
        );
    }
    feed(&mut a, SECOND, 0, &heartbeat(1, 0, ARDUPILOT));
    assert_eq!(a.route(VehicleKey(1, 1)), Some(0));
    // Heard later on link 1 (another radio): commands go there.
    feed(&mut a, 2 * SECOND, 1, &heartbeat(1, 1, ARDUPILOT));
    assert_eq!(a.route(VehicleKey(1, 1)), Some(1));
    // Link 1 goes down: back to link 0, though 1 was heard last.
    a.update(
        3 * SECOND,
        Event::LinkState {
            link: 1,
            state: LinkState::Down("gone".into()),
        },
    );
    assert_eq!(a.route(VehicleKey(1, 1)), Some(0));
    // The operator pins link 1: used as soon as it is up again.
    a.sessions.get_mut(&VehicleKey(1, 1)).unwrap().pinned = Some(1);
    assert_eq!(a.route(VehicleKey(1, 1)), Some(0));
    a.update(
        4 * SECOND,
        Event::LinkState {
            link: 1,
            state: LinkState::Up,
        },
    );
    assert_eq!(a.route(VehicleKey(1, 1)), Some(1));
}

#[test]
fn a_statustext_over_two_links_is_shown_once_and_chunks_are_joined() {
    let mut a = app(2);
    let text = packed(
        json!({"sysid": 1, "compid": 1, "seq": 9, "msg": "STATUSTEXT",
        "fields": {"severity": 4, "text": "PreArm: Need Position Estimate", "id": 0, "chunk_seq": 0}}),
    );
    feed(&mut a, 0, 0, &text);
    feed(&mut a, 30_000, 1, &text);
    let shown = a
        .notices
        .iter()
        .filter(|n| n.text == "PreArm: Need Position Estimate")
        .count();
    assert_eq!(shown, 1);
    assert_eq!(
        a.links[1].sources[&VehicleKey(1, 1)].frames,
        1,
        "counted on link 1 too"
    );
    // 70 characters in two chunks with id 5.
    let long = "A".repeat(50);
    let c0 = packed(
        json!({"sysid": 1, "compid": 1, "seq": 10, "msg": "STATUSTEXT",
        "fields": {"severity": 6, "text": long, "id": 5, "chunk_seq": 0}}),
    );
    let c1 = packed(
        json!({"sysid": 1, "compid": 1, "seq": 11, "msg": "STATUSTEXT",
        "fields": {"severity": 6, "text": "B".repeat(20), "id": 5, "chunk_seq": 1}}),
    );
    feed(&mut a, SECOND, 0, &c0);
    feed(&mut a, SECOND + 1000, 0, &c1);
    let want = format!("{}{}", "A".repeat(50), "B".repeat(20));
    assert_eq!(a.notices.iter().filter(|n| n.text == want).count(), 1);
}

#[test]
fn acknowledgements_with_newer_enum_values_are_kept_and_only_ours_are_read() {
    let mut a = app(1);
    feed(&mut a, 0, 0, &heartbeat(7, 0, PX4));
    // COMMAND_ACK for SET_MESSAGE_INTERVAL with a MAV_RESULT newer than the dialect (200),
    // first addressed to another GCS (255:191), then to us.
    let ack = |seq: u8, comp: u8| {
        packed(
            json!({"sysid": 7, "compid": 1, "seq": seq, "msg": "COMMAND_ACK", "fields": {
            "command": 511, "result": 200, "progress": 0, "result_param2": 0,
            "target_system": 255, "target_component": comp}}),
        )
    };
    feed(&mut a, 1000, 0, &ack(1, 191));
    assert!(!a
        .notices
        .iter()
        .any(|n| n.text.contains("SET_MESSAGE_INTERVAL")));
    feed(&mut a, 2000, 0, &ack(2, 190));
    let n = a
        .notices
        .iter()
        .find(|n| n.text.contains("SET_MESSAGE_INTERVAL"))
        .expect("the refusal is shown");
    assert!(n.text.contains("result 200"), "{}", n.text);
    // A COMMAND_ACK of a command the dialect has never heard of is no crash and no loss.
    let odd = packed(
        json!({"sysid": 7, "compid": 1, "seq": 3, "msg": "COMMAND_ACK", "fields": {
        "command": 65000, "result": 0, "progress": 0, "result_param2": 0,
        "target_system": 255, "target_component": 190}}),
    );
    feed(&mut a, 3000, 0, &odd);
    assert_eq!(a.links[0].sources[&VehicleKey(7, 1)].seq.received, 4);
}

#[test]
fn our_echo_is_ignored_but_another_gcs_at_our_id_is_shown() {
    let mut a = app(1);
    let fx = run_timers(&mut a, 0);
    let (_, ours) = sends(&fx).remove(0);
    // A router sends our own heartbeat back: not a vehicle, not a source.
    feed(&mut a, 1000, 0, &ours);
    assert!(a.vehicles.is_empty());
    assert_eq!(a.links[0].echoes, 1);
    // QGroundControl at 255:190 too: listed as a GCS, with a warning.
    let qgc = packed(
        json!({"sysid": 255, "compid": 190, "seq": 77, "msg": "HEARTBEAT",
        "fields": {"type": 6, "autopilot": 8, "base_mode": 192, "custom_mode": 0,
        "system_status": 4, "mavlink_version": 3}}),
    );
    feed(&mut a, 2000, 0, &qgc);
    assert!(a.vehicles.get(VehicleKey(255, 190)).unwrap().is_gcs());
    assert!(a
        .notices
        .iter()
        .any(|n| n.text.contains("another GCS uses our id")));
}

#[test]
fn frames_of_unknown_ids_make_no_source_and_no_loss() {
    let mut a = app(1);
    feed(&mut a, 0, 0, &heartbeat(1, 0, ARDUPILOT));
    // An id no dialect has (0xABCDE), claiming to be from 1:1 with seq 100, and a phantom 9:9.
    let unknown = |sysid: u8, seq: u8| {
        let mut f = vec![0xFD, 2, 0, 0, seq, sysid, sysid, 0xDE, 0xBC, 0x0A, 1, 2];
        f.extend_from_slice(&[0x12, 0x34]);
        f
    };
    let mut bytes = unknown(1, 100);
    bytes.extend(unknown(9, 0));
    bytes.extend(heartbeat(1, 1, ARDUPILOT));
    feed(&mut a, SECOND, 0, &bytes);
    let src = &a.links[0].sources[&VehicleKey(1, 1)];
    assert_eq!((src.seq.received, src.seq.lost), (2, 0));
    assert!(!a.links[0].sources.contains_key(&VehicleKey(9, 9)));
}

#[test]
fn a_link_that_reconnects_counts_afresh_and_asks_for_streams_again() {
    let mut a = attitude_only(1);
    let up = |a: &mut App, t| {
        a.update(
            t,
            Event::LinkState {
                link: 0,
                state: LinkState::Up,
            },
        )
    };
    up(&mut a, 0);
    let mut seq = 0;
    let fx = fly(&mut a, 0, 5 * SECOND, &mut seq, true);
    assert_eq!(count_stream_requests(&fx), 1);
    // A 0.2 s outage: the TCP connection drops and comes back; the vehicle's sequence goes on
    // from wherever it is (frames sent during the outage were never ours to receive).
    a.update(
        5 * SECOND,
        Event::LinkState {
            link: 0,
            state: LinkState::Down("connection closed".into()),
        },
    );
    let mut fx = up(&mut a, 5 * SECOND + 200_000);
    seq = seq.wrapping_add(40);
    fx.extend(fly(&mut a, 6 * SECOND, 8 * SECOND, &mut seq, true));
    assert_eq!(a.links[0].sources[&VehicleKey(1, 1)].seq.lost, 0);
    assert_eq!(
        count_stream_requests(&fx),
        1,
        "asked again on the new connection"
    );
}

#[test]
fn telemetry_our_dialect_cannot_decode_still_shows_streams_flow() {
    // EXTENDED_STATUS only, whose GPS_RAW_INT is checked.
    let mut a = App::new(AppConfig {
        links: vec!["test0".into()],
        fetch_params: false,
        streams: StreamRates {
            groups: [(2, 10.0)].into_iter().collect(),
            ..StreamRates::default()
        },
        ..AppConfig::default()
    });
    // GPS_RAW_INT with a fix type newer than the dialect (200): the crate refuses the payload.
    let gps: Vec<Vec<u8>> = common::pymavlink_encode(
        &(0..=255u8)
            .map(|seq| {
                json!({"sysid": 1, "compid": 1, "seq": seq, "msg": "GPS_RAW_INT", "fields": {
                "time_usec": 0, "fix_type": 200, "lat": 0, "lon": 0, "alt": 0, "eph": 0, "epv": 0,
                "vel": 0, "cog": 0, "satellites_visible": 10}})
            })
            .collect::<Vec<_>>(),
    );
    assert!(FrameParser::new().parse_all(&gps[0])[0].message.is_none());
    let mut fx = Vec::new();
    let mut seq = 0u8;
    for i in 0..200u64 {
        let t = i * 100_000;
        fx.extend(run_timers(&mut a, t));
        if t.is_multiple_of(SECOND) {
            fx.extend(feed(&mut a, t, 0, &heartbeat(1, seq, ARDUPILOT)));
            seq = seq.wrapping_add(1);
        }
        fx.extend(feed(&mut a, t, 0, &gps[seq as usize]));
        seq = seq.wrapping_add(1);
    }
    assert_eq!(count_stream_requests(&fx), 1, "asked once, and it flows");
}
