//! Flying from the keyboard on the simulated ArduCopter (virtual clock): mode, arm and take-off
//! from the prompt and from keys, confirmations, the command queue's answers, the Commands
//! screen; and pymavlink's reading of the commands we send.

mod common;

use common::{command, sim, wait};

use mavterm::app::{App, AppConfig, Effect, Event};
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::keymap::Key;
use mavterm::link::{FrameParser, LinkSpec, ParserStats};
use mavterm::proto::vehicles::VehicleKey;
use serde_json::json;

const SECOND: u64 = 1_000_000;

fn runner(query: &str) -> VirtualRunner {
    let spec: LinkSpec = format!("sim://?{query}").parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    // The sim's EKF uses GPS from 5 s: arming is allowed after that.
    r.advance_to(6 * SECOND);
    r
}

/// Guided, armed, at 10 m: on the sim and on our screen.
fn assert_flying_at_10m(r: &VirtualRunner) {
    let v = sim(r).vehicle(1).unwrap();
    assert!(v.armed());
    assert_eq!(v.custom_mode(), 4, "GUIDED");
    let alt = v.relative_alt_m();
    assert!((alt - 10.0).abs() <= 0.5, "altitude {alt}");
    let ours = r.app.vehicles.get(VehicleKey(1, 1)).unwrap();
    assert!(ours.armed());
    assert_eq!(ours.mode_name(), "GUIDED");
    let s = common::screen(r, 80, 24);
    assert!(s.contains("GUIDED") && s.contains("ARMED"), "{s}");
    // And the Overview's flight pane says so.
    let shown = common::shown_altitude(&s).unwrap_or_else(|| panic!("{s}"));
    assert!((shown - 10.0).abs() <= 0.5, "{shown}: {s}");
}

#[test]
fn guided_arm_takeoff_from_the_prompt() {
    let mut r = runner("");
    command(&mut r, "mode guided");
    wait(&mut r, 2.0);
    assert_eq!(sim(&r).vehicle(1).unwrap().custom_mode(), 4);
    assert!(r
        .app
        .notices
        .iter()
        .any(|n| n.text.contains("GUIDED: confirmed by the vehicle")));
    command(&mut r, "arm");
    // Asked first: nothing sent until `y`.
    assert!(r.app.ui.confirm.is_some());
    let s = common::screen(&r, 80, 24);
    assert!(s.contains("ARM 1:1") && s.contains("y = yes"), "{s}");
    insta::assert_snapshot!("confirm_arm_80x24", s);
    common::yes(&mut r);
    wait(&mut r, 2.0);
    assert!(sim(&r).vehicle(1).unwrap().armed());
    command(&mut r, "takeoff 10");
    common::yes(&mut r);
    wait(&mut r, 12.0);
    assert_flying_at_10m(&r);
    // The Commands screen lists what was sent and what became of it.
    common::keys(&mut r, &["3"]);
    let s = common::screen(&r, 80, 24);
    for want in [
        "DO_SET_MODE",
        "COMPONENT_ARM_DISARM",
        "NAV_TAKEOFF",
        "ACCEPTED",
    ] {
        assert!(s.contains(want), "{want}: {s}");
    }
    insta::assert_snapshot!("commands_80x24", s);
}

#[test]
fn guided_arm_takeoff_by_keys_in_one_sequence() {
    let mut r = runner("");
    // `T` asks the altitude (prompt with `takeoff 10`), enter, then `y`: GUIDED, arm, take off.
    common::keys(&mut r, &["T"]);
    assert_eq!(r.app.ui.prompt.line.text, "takeoff 10");
    common::keys(&mut r, &["enter"]);
    let s = common::screen(&r, 80, 24);
    assert!(s.contains("TAKE OFF to 10 m 1:1"), "{s}");
    common::yes(&mut r);
    wait(&mut r, 15.0);
    assert_flying_at_10m(&r);
    assert!(r
        .app
        .notices
        .iter()
        .any(|n| n.text == "take-off: 10.0 m reached"));
}

#[test]
fn without_the_confirmation_key_nothing_is_sent() {
    let mut r = runner("");
    common::keys(&mut r, &["A"]);
    assert!(r.app.ui.confirm.is_some());
    wait(&mut r, 0.5);
    common::keys(&mut r, &["n"]);
    wait(&mut r, 3.0);
    assert!(!sim(&r).vehicle(1).unwrap().armed());
    assert_eq!(
        r.app.sessions[&VehicleKey(1, 1)].commands.entries().len(),
        0
    );
    assert!(common::screen(&r, 80, 24).contains("cancelled: nothing sent"));
    // The key that asked never answers: `A` again, however late, cancels.
    common::keys(&mut r, &["A"]);
    wait(&mut r, 0.5);
    common::keys(&mut r, &["A"]);
    wait(&mut r, 2.0);
    assert!(!sim(&r).vehicle(1).unwrap().armed());
    assert!(r.app.ui.confirm.is_none());
    assert_eq!(
        r.app.sessions[&VehicleKey(1, 1)].commands.entries().len(),
        0
    );
}

#[test]
fn a_refused_arm_shows_the_vehicles_reason_and_the_sequence_stops() {
    let spec: LinkSpec = "sim://".parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    r.advance_to(2 * SECOND); // before the GPS fix: ArduCopter refuses to arm
    command(&mut r, "takeoff 5");
    common::yes(&mut r);
    wait(&mut r, 5.0);
    assert!(!sim(&r).vehicle(1).unwrap().armed());
    let texts: Vec<&str> = r.app.notices.iter().map(|n| n.text.as_str()).collect();
    let stop = texts
        .iter()
        .find(|t| t.contains("stopped"))
        .unwrap_or_else(|| panic!("{texts:?}"));
    assert!(stop.contains("(arm)") && stop.contains("FAILED"), "{stop}");
    // The vehicle's reason is shown with the refusal.
    let arm = r.app.sessions[&VehicleKey(1, 1)]
        .commands
        .entries()
        .find(|e| e.spec.name() == "COMPONENT_ARM_DISARM")
        .unwrap();
    assert!(
        arm.reason.as_deref().unwrap_or("").starts_with("Arm: "),
        "{arm:?}"
    );
    // No take-off was sent after the refusal.
    let sent: Vec<String> = r.app.sessions[&VehicleKey(1, 1)]
        .commands
        .entries()
        .map(|e| e.spec.name())
        .collect();
    assert!(!sent.contains(&"NAV_TAKEOFF".to_string()), "{sent:?}");
}

#[test]
fn a_second_arm_while_the_first_is_pending_is_refused_locally() {
    // The first arm is lost on the way: it waits for its ACK while the second is asked.
    let mut r = runner("drop_cmd=400:1");
    command(&mut r, "arm");
    common::yes(&mut r);
    command(&mut r, "arm");
    common::yes(&mut r);
    let (_, msg) = r.app.ui.message.clone().unwrap();
    assert!(msg.contains("still waiting"), "{msg}");
    assert_eq!(
        r.app.sessions[&VehicleKey(1, 1)].commands.entries().len(),
        1
    );
}

#[test]
fn commands_to_a_lost_or_unheard_vehicle_are_refused_locally() {
    let mut a = App::new(AppConfig {
        links: vec!["x".into()],
        ..AppConfig::default()
    });
    a.update(0, Event::Key(Key::ch(':')));
    for c in "land".chars() {
        a.update(0, Event::Key(Key::ch(c)));
    }
    a.update(0, Event::Key("enter".parse().unwrap()));
    let (_, msg) = a.ui.message.clone().unwrap();
    assert!(msg.contains("no target"), "{msg}");
}

/// The frames the core sends for `line` to an ArduCopter (1:1) or PX4 (1:1) vehicle it heard,
/// as pymavlink reads them.
fn sent_for(autopilot: u64, line: &str) -> Vec<serde_json::Value> {
    let mut a = App::new(AppConfig {
        links: vec!["x".into()],
        ..AppConfig::default()
    });
    let frames = common::pymavlink_encode(&[
        json!({"sysid": 1, "compid": 1, "seq": 0, "msg": "HEARTBEAT", "fields": {
            "type": 2, "autopilot": autopilot, "base_mode": 1, "custom_mode": 0,
            "system_status": 3, "mavlink_version": 3}}),
        json!({"sysid": 1, "compid": 1, "seq": 1, "msg": "GLOBAL_POSITION_INT", "fields": {
            "time_boot_ms": 1000, "lat": -353632621, "lon": 1491652374, "alt": 584000,
            "relative_alt": 0, "vx": 0, "vy": 0, "vz": 0, "hdg": 0}}),
    ]);
    for f in &frames {
        a.update(
            0,
            Event::Frames {
                link: 0,
                frames: FrameParser::new().parse_all(f),
                stats: ParserStats::default(),
            },
        );
    }
    let mut fx = Vec::new();
    for k in [":"].iter().map(|k| k.parse::<Key>().unwrap()) {
        fx.extend(a.update(1000, Event::Key(k)));
    }
    for c in line.chars() {
        fx.extend(a.update(1000, Event::Key(Key::ch(c))));
    }
    fx.extend(a.update(1000, Event::Key("enter".parse().unwrap())));
    if a.ui.confirm.is_some() {
        fx.extend(a.update(600_000, Event::Key(Key::ch('y'))));
    }
    let sent: Vec<Vec<u8>> = fx
        .iter()
        .filter_map(|e| match e {
            Effect::Send { frame, .. } => Some(frame.clone()),
            _ => None,
        })
        .collect();
    common::pymavlink_decode(&sent)
        .into_iter()
        .filter(|v| v["name"] != "HEARTBEAT" && v["name"] != "REQUEST_DATA_STREAM")
        .filter(|v| !(v["name"] == "COMMAND_LONG" && v["command"] == 511))
        .collect()
}

#[test]
fn pymavlink_reads_our_takeoff_and_mode_commands() {
    // ArduCopter, already armed in GUIDED? No: from STABILIZE the sequence starts with the mode.
    let d = sent_for(3, "mode guided");
    assert_eq!(d.len(), 1, "{d:?}");
    let m = &d[0];
    assert_eq!(m["name"], "COMMAND_LONG");
    assert_eq!(m["command"], 176); // MAV_CMD_DO_SET_MODE
    assert_eq!(m["confirmation"], 0);
    assert_eq!(m["param1"], 1.0); // MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert_eq!(m["param2"], 4.0); // GUIDED
    assert_eq!(
        (m["target_system"].as_u64(), m["target_component"].as_u64()),
        (Some(1), Some(1))
    );
    let d = sent_for(3, "long NAV_TAKEOFF 0 0 0 0 0 0 10");
    let t = &d[0];
    assert_eq!(t["command"], 22);
    assert_eq!(t["confirmation"], 0);
    assert_eq!(t["param7"], 10.0);
    // PX4: arm first (the vehicle is disarmed), its take-off waits for the heartbeat.
    let d = sent_for(12, "takeoff 10");
    assert_eq!(d[0]["command"], 400);
    assert_eq!(d[0]["param1"], 1.0);
}

#[test]
fn px4_takeoff_is_encoded_the_px4_way() {
    use mavterm::proto::commands::CommandSpec;
    // What the PX4 take-off step sends (home 584 m AMSL, 10 m up), read by pymavlink.
    let spec = CommandSpec::long(
        (1, 1),
        mavterm::dialect::MavCmd::MAV_CMD_NAV_TAKEOFF,
        [-1.0, 0., 0., f64::NAN, f64::NAN, f64::NAN, 594.0],
    );
    let msg = spec.message(0).unwrap();
    let bytes = mavterm::wire::frame::encode(
        mavterm::wire::Version::V2,
        mavterm::wire::Header {
            sysid: 255,
            compid: 190,
            seq: 0,
        },
        &msg,
    );
    let d = common::pymavlink_decode(&[bytes]).remove(0);
    assert_eq!(d["command"], 22);
    assert_eq!(d["param1"], -1.0);
    assert_eq!(d["param7"], 594.0);
    for p in ["param4", "param5", "param6"] {
        assert_eq!(d[p], "nan", "{d}");
    }
}

#[test]
fn a_request_dropped_twice_is_resent_and_the_third_is_acked_and_shown_once() {
    // SET_MESSAGE_INTERVAL (GLOBAL_POSITION_INT at 5 Hz) is safe to repeat. (REQUEST_MESSAGE is
    // too, but the flight telemetry asks for HOME_POSITION with it on its own.)
    let mut r = runner("drop_cmd=511:2");
    command(&mut r, "long SET_MESSAGE_INTERVAL 33 200000");
    wait(&mut r, 20.0);
    let e = r.app.sessions[&VehicleKey(1, 1)]
        .commands
        .entries()
        .find(|e| e.spec.name() == "SET_MESSAGE_INTERVAL")
        .unwrap()
        .clone();
    assert_eq!(e.sends, 3, "{e:?}");
    assert_eq!(e.outcome(), "ACCEPTED");
    let shown = r
        .app
        .notices
        .iter()
        .filter(|n| n.text.starts_with("SET_MESSAGE_INTERVAL to 1:1"))
        .count();
    assert_eq!(shown, 1);
    // The vehicle executed it once: the third copy carried confirmation 2 (what pymavlink
    // reads of our third send is checked in the unit tests of the queue).
}

#[test]
fn an_arm_whose_ack_is_lost_is_not_resent_and_is_reissued_with_one_key() {
    let mut r = runner("drop_cmd=400:1");
    command(&mut r, "arm");
    common::yes(&mut r);
    wait(&mut r, 15.0);
    let s = &r.app.sessions[&VehicleKey(1, 1)];
    let arm: Vec<_> = s.commands.entries().collect();
    assert_eq!(arm.len(), 1);
    assert_eq!(arm[0].sends, 1, "never resent on its own");
    assert_eq!(arm[0].outcome(), "no ACK");
    assert!(!sim(&r).vehicle(1).unwrap().armed());
    assert!(r
        .app
        .notices
        .iter()
        .any(|n| n.text.contains("COMPONENT_ARM_DISARM to 1:1: no ACK")));
    // On the Commands screen, enter sends it again (after the confirmation).
    common::keys(&mut r, &["3", "enter"]);
    assert!(r.app.ui.confirm.is_some());
    common::yes(&mut r);
    wait(&mut r, 2.0);
    assert!(sim(&r).vehicle(1).unwrap().armed());
}

#[test]
fn a_vehicle_that_never_answers_shows_a_timeout() {
    // Drop every copy of DO_SET_MODE (it is resent: all three get no answer).
    let mut r = runner("drop_cmd=176:100");
    command(&mut r, "mode loiter");
    wait(&mut r, 30.0);
    let e = r.app.sessions[&VehicleKey(1, 1)]
        .commands
        .entries()
        .next()
        .unwrap()
        .clone();
    assert_eq!(e.outcome(), "no ACK");
    assert_eq!(e.sends, 3);
    assert!(r
        .app
        .notices
        .iter()
        .any(|n| n.text.contains("no ACK after 3 sends")));
}

#[test]
fn positional_commands_go_as_command_int_with_an_explicit_frame() {
    let d = sent_for(
        3,
        "long DO_REPOSITION -1 1 0 nan -35.3632621 149.1652374 20",
    );
    assert_eq!(d.len(), 1, "{d:?}");
    let m = &d[0];
    assert_eq!(m["name"], "COMMAND_INT");
    assert_eq!(m["command"], 192);
    assert_eq!(m["frame"], 3); // MAV_FRAME_GLOBAL_RELATIVE_ALT
    assert_eq!(m["x"], -353632621);
    assert_eq!(m["y"], 1491652374);
    assert_eq!(m["z"], 20.0);
    assert_eq!(m["param4"], "nan");
}
