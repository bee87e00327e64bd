//! The MAVLink Inspector (`4`) on the simulated ArduCopter (virtual clock): every message heard
//! with its measured rate against what the sim sends, the selected message's fields against the
//! sim's state, a rate asked from the screen (10 Hz, the default, off) honoured by the sim and
//! measured, its COMMAND_ACK shown; a frame with an enum value newer than our dialect shown in
//! hex with the reason; and the screen at every size.

mod common;

use mavterm::app::inspector::{fields, MsgKey};
use mavterm::app::{App, AppConfig, Event};
use mavterm::clock::Micros;
use mavterm::dialect::{self, MavMessage};
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::keymap::{Key, Mode};
use mavterm::link::{FrameParser, LinkSpec, ParserStats};
use mavterm::proto::vehicles::VehicleKey;
use mavterm::sim::Sim;
use mavterm::ui::{buffer_to_text, render_to_buffer, Theme};
use mavterm::wire::frame::{crc_extra, encode, frame_crc, Header, Version};

const SECOND: u64 = 1_000_000;

const HEARTBEAT: u32 = 0;
const SYS_STATUS: u32 = 1;
const ATTITUDE: u32 = 30;
const GLOBAL_POSITION_INT: u32 = 33;
const VFR_HUD: u32 = 74;

fn runner() -> VirtualRunner {
    let spec: LinkSpec = "sim://".parse().unwrap();
    let cfg = AppConfig {
        // The list without the parameter download's traffic.
        fetch_params: false,
        ..AppConfig::default()
    };
    VirtualRunner::from_specs(&[spec], cfg).unwrap()
}

fn wait(r: &mut VirtualRunner, secs: f64) {
    let t = r.now() + (secs * SECOND as f64) as u64;
    r.advance_to(t);
}

fn sim(r: &VirtualRunner) -> &Sim {
    r.source(0).unwrap().as_any().downcast_ref::<Sim>().unwrap()
}

/// The rate the sim sends `msgid` at, in Hz (its heartbeat is 1 Hz).
fn sim_hz(r: &VirtualRunner, msgid: u32) -> Option<f64> {
    if msgid == HEARTBEAT {
        return Some(1.0);
    }
    let us = sim(r).vehicle(1).unwrap().message_interval(msgid)?;
    Some(1e6 / us as f64)
}

fn measured(r: &VirtualRunner, msgid: u32) -> f64 {
    r.app
        .inspector
        .get((1, 1, msgid))
        .unwrap_or_else(|| panic!("message {msgid} not heard"))
        .rate(r.app.now)
}

fn screen(r: &VirtualRunner) -> String {
    common::screen(r, 80, 24)
}

/// The value shown after `name =` on the screen.
fn shown_field(screen: &str, name: &str) -> Option<String> {
    let words: Vec<&str> = screen
        .split_whitespace()
        .map(|w| w.trim_matches('│'))
        .collect();
    words
        .windows(3)
        .find(|w| w[0] == name && w[1] == "=")
        .map(|w| w[2].to_string())
}

/// `/NAME`, esc: the first message whose name contains NAME is selected in the whole list.
fn select(r: &mut VirtualRunner, name: &str) -> MsgKey {
    common::keys(r, &["/", "ctrl-u"]);
    common::typed(r, name);
    common::keys(r, &["esc"]);
    assert!(r.app.ui.inspector.filter.is_empty());
    let k = r.app.inspector_selected().unwrap();
    assert_eq!(r.app.inspector.get(k).unwrap().name, name);
    k
}

/// `r`, the rate typed, enter.
fn set_rate(r: &mut VirtualRunner, text: &str) {
    common::keys(r, &["r"]);
    assert_eq!(r.app.ui.mode, Mode::Edit);
    common::typed(r, text);
    common::keys(r, &["enter"]);
    assert_eq!(r.app.ui.mode, Mode::Normal);
}

fn last_line(s: &str) -> &str {
    s.lines().last().unwrap_or("")
}

#[test]
fn the_list_shows_every_message_with_the_rate_the_sim_sends() {
    let mut r = runner();
    wait(&mut r, 12.0);
    common::keys(&mut r, &["4"]);
    assert_eq!(r.app.ui.screen, "inspector");
    for id in [
        HEARTBEAT,
        SYS_STATUS,
        ATTITUDE,
        GLOBAL_POSITION_INT,
        VFR_HUD,
    ] {
        let want = sim_hz(&r, id).unwrap_or_else(|| panic!("the sim does not send {id}"));
        let got = measured(&r, id);
        assert!(
            (got - want).abs() <= want * 0.1,
            "message {id}: measured {got} Hz, the sim sends {want} Hz"
        );
    }
    let s = screen(&r);
    for name in ["HEARTBEAT", "GLOBAL_POSITION_INT", "ATTITUDE"] {
        assert!(s.contains(name), "{name}\n{s}");
    }
    // Listed by name within the source; further down, by scrolling.
    let names: Vec<&str> = r
        .app
        .inspector_rows()
        .iter()
        .map(|k| r.app.inspector.get(*k).unwrap().name)
        .collect();
    assert!(
        names.contains(&"SYS_STATUS") && names.contains(&"VFR_HUD"),
        "{names:?}"
    );
    assert!(names.windows(2).all(|w| w[0] < w[1]), "{names:?}");
    // Grouped per source: the source on the first row; the heartbeat at 1 Hz.
    assert!(s.contains("1:1"), "{s}");
    let hb = s.lines().find(|l| l.contains("HEARTBEAT")).unwrap();
    assert!(hb.contains("1.0 Hz"), "{hb}");
    // Our own heartbeats are not listed: only the vehicle's source.
    assert_eq!(r.app.inspector.sources(), 1);
    insta::assert_snapshot!("inspector_list_80x24", s);
    // Moving: down, end, home; the selection follows the key, not the row number.
    common::keys(&mut r, &["down", "down"]);
    let rows = r.app.inspector_rows();
    assert_eq!(r.app.inspector_selected(), Some(rows[2]));
    common::keys(&mut r, &["end"]);
    assert_eq!(r.app.inspector_selected(), rows.last().copied());
    common::keys(&mut r, &["pageup", "home"]);
    assert_eq!(r.app.inspector_selected(), Some(rows[0]));
    // The key help of this screen names its keys.
    common::keys(&mut r, &["?"]);
    let s = common::screen(&r, 80, 40);
    assert!(s.contains("ask for the selected message at a rate"), "{s}");
    assert!(s.contains("filter messages by name"), "{s}");
}

#[test]
fn the_selected_message_shows_its_fields_as_the_sim_sent_them() {
    let mut r = runner();
    wait(&mut r, 10.0);
    common::keys(&mut r, &["4"]);
    select(&mut r, "GLOBAL_POSITION_INT");
    // On screen every frame's payload is kept (off it, one a second): a second later the last
    // frame is the one shown.
    wait(&mut r, 1.0);
    let s = screen(&r);
    assert!(!s.contains(" older"), "{s}");
    let v = sim(&r).vehicle(1).unwrap();
    let (lat, lon, _) = v.home();
    let num = |n: &str| -> f64 {
        shown_field(&s, n)
            .unwrap_or_else(|| panic!("no {n}\n{s}"))
            .parse()
            .unwrap()
    };
    // Landed at home: latitude and longitude in degrees (sent in 1e-7 degrees), altitude 0 m
    // above home (sent in mm).
    assert!((num("lat") - lat).abs() <= 1e-6, "{s}");
    assert!((num("lon") - lon).abs() <= 1e-6, "{s}");
    assert!(s.contains(" deg "), "{s}");
    assert!(
        (num("relative_alt") - v.relative_alt_m()).abs() < 0.001,
        "{s}"
    );
    for f in ["time_boot_ms", "alt", "vx", "vy", "vz", "hdg"] {
        assert!(shown_field(&s, f).is_some(), "{f}\n{s}");
    }
    assert!(s.contains("GLOBAL_POSITION_INT #33 from 1:1"), "{s}");
    insta::assert_snapshot!("inspector_fields_80x24", s);
    // Enums by name, flags by name: the heartbeat.
    select(&mut r, "HEARTBEAT");
    let s = screen(&r);
    assert_eq!(
        shown_field(&s, "autopilot").as_deref(),
        Some("MAV_AUTOPILOT_ARDUPILOTMEGA")
    );
    assert_eq!(
        shown_field(&s, "mavtype").as_deref(),
        Some("MAV_TYPE_QUADROTOR")
    );
    assert!(s.contains("MAV_MODE_FLAG_CUSTOM_MODE_ENABLED"), "{s}");
    insta::assert_snapshot!("inspector_heartbeat_80x24", s);
    // enter: the keys scroll the fields (8 lines, 6 shown), not the list; esc gives them back.
    let hb = r.app.inspector_selected();
    common::keys(&mut r, &["enter", "down", "down", "down"]);
    assert_eq!(r.app.inspector_selected(), hb);
    let s = screen(&r);
    assert!(s.contains(" 3-8/8 ") && !s.contains("custom_mode"), "{s}");
    assert!(s.contains("mavlink_version = 3"), "{s}");
    common::keys(&mut r, &["esc", "down"]);
    assert_ne!(r.app.inspector_selected(), hb);
    // The filter: no match says so; esc clears it.
    common::keys(&mut r, &["/"]);
    common::typed(&mut r, "nothing_like_it");
    let s = screen(&r);
    assert!(s.contains("no message matches /nothing_like_it"), "{s}");
    common::keys(&mut r, &["esc"]);
    assert!(r.app.ui.inspector.filter.is_empty());
    assert!(r.app.inspector_rows().len() > 5);
}

#[test]
fn a_rate_asked_from_the_inspector_is_honoured_and_measured() {
    let mut r = runner();
    wait(&mut r, 10.0);
    common::keys(&mut r, &["4"]);
    let k = select(&mut r, "GLOBAL_POSITION_INT");
    let before = sim_hz(&r, GLOBAL_POSITION_INT).unwrap();
    assert!(
        (before - 10.0).abs() > 1.0,
        "pick another rate: the sim sends {before}"
    );
    // Typed in the row.
    common::keys(&mut r, &["r"]);
    common::typed(&mut r, "10");
    let s = screen(&r);
    assert!(
        last_line(&s).starts_with("GLOBAL_POSITION_INT (1:1) Hz, 0 default, -1 off: enter sends"),
        "{s}"
    );
    insta::assert_snapshot!("inspector_rate_typed_80x24", s);
    common::keys(&mut r, &["enter"]);
    let s = screen(&r);
    assert!(
        last_line(&s).contains("GLOBAL_POSITION_INT 10.0 Hz from 1:1: sent"),
        "{s}"
    );
    // The ACK: in the status bar, in the fields' summary, on the Commands screen.
    wait(&mut r, 1.0);
    let s = screen(&r);
    assert!(
        last_line(&s).contains("GLOBAL_POSITION_INT 10.0 Hz from 1:1: ACCEPTED"),
        "{s}"
    );
    assert!(s.contains("asked 10.0 Hz: ACCEPTED"), "{s}");
    assert_eq!(
        sim(&r)
            .vehicle(1)
            .unwrap()
            .message_interval(GLOBAL_POSITION_INT),
        Some(100_000)
    );
    let entry = r.app.sessions[&VehicleKey(1, 1)]
        .commands
        .entries()
        .last()
        .unwrap()
        .clone();
    assert_eq!(entry.spec.command, 511);
    assert_eq!(entry.spec.params[0], GLOBAL_POSITION_INT as f64);
    assert_eq!(entry.spec.params[1], 100_000.0);
    assert_eq!(entry.outcome(), "ACCEPTED");
    // Measured at 10 Hz once the window has only the new rate.
    wait(&mut r, 6.0);
    let got = measured(&r, GLOBAL_POSITION_INT);
    assert!((got - 10.0).abs() <= 1.0, "measured {got} Hz");
    insta::assert_snapshot!("inspector_rate_10hz_80x24", screen(&r));
    // 0: the sim's default rate.
    set_rate(&mut r, "0");
    wait(&mut r, 7.0);
    let want = sim_hz(&r, GLOBAL_POSITION_INT).unwrap();
    let got = measured(&r, GLOBAL_POSITION_INT);
    assert!(
        (got - want).abs() <= want * 0.1,
        "measured {got}, sent {want}"
    );
    // -1: stopped; the rate falls to 0 and the entry goes stale.
    set_rate(&mut r, "-1");
    wait(&mut r, 1.0);
    assert!(
        last_line(&screen(&r)).contains("GLOBAL_POSITION_INT off from 1:1: ACCEPTED"),
        "{}",
        screen(&r)
    );
    assert_eq!(
        sim(&r)
            .vehicle(1)
            .unwrap()
            .message_interval(GLOBAL_POSITION_INT),
        None
    );
    let count = r.app.inspector.get(k).unwrap().count;
    wait(&mut r, 6.0);
    assert_eq!(measured(&r, GLOBAL_POSITION_INT), 0.0);
    assert_eq!(r.app.inspector.get(k).unwrap().count, count);
    let s = screen(&r);
    let row = s
        .lines()
        .find(|l| l.contains("GLOBAL_POSITION_INT "))
        .unwrap();
    assert!(row.contains("0.0 Hz"), "{row}");
    assert!(s.contains("asked off: ACCEPTED"), "{s}");
    // Something that is not a rate is refused, nothing sent.
    let sent = r.app.sessions[&VehicleKey(1, 1)].commands.entries().len();
    set_rate(&mut r, "fast");
    assert!(
        last_line(&screen(&r)).contains("a rate in Hz"),
        "{}",
        screen(&r)
    );
    assert_eq!(
        r.app.sessions[&VehicleKey(1, 1)].commands.entries().len(),
        sent
    );
    // esc leaves the rate alone.
    common::keys(&mut r, &["r", "5", "esc"]);
    assert_eq!(
        r.app.sessions[&VehicleKey(1, 1)].commands.entries().len(),
        sent
    );
}

/// EXTENDED_SYS_STATE from 1:1 with `landed_state`.
fn extended_sys_state(landed_state: u8) -> Vec<u8> {
    let msg = MavMessage::EXTENDED_SYS_STATE(dialect::EXTENDED_SYS_STATE_DATA {
        vtol_state: dialect::MavVtolState::MAV_VTOL_STATE_MC,
        landed_state: dialect::MavLandedState::MAV_LANDED_STATE_ON_GROUND,
    });
    let h = Header {
        sysid: 1,
        compid: 1,
        seq: 3,
    };
    let mut bytes = encode(Version::V2, h, &msg);
    // Payload: vtol_state, landed_state; then the CRC again over the changed bytes.
    assert_eq!(bytes[1], 2);
    bytes[11] = landed_state;
    let n = bytes.len();
    let crc = frame_crc(&bytes[1..n - 2], crc_extra(245).unwrap());
    bytes[n - 2..].copy_from_slice(&crc.to_le_bytes());
    bytes
}

fn feed(app: &mut App, now: u64, bytes: &[u8]) {
    let frames = FrameParser::new().parse_all(bytes);
    app.update(
        now,
        Event::Frames {
            link: 0,
            frames,
            stats: ParserStats::default(),
        },
    );
}

fn app_screen(app: &App) -> String {
    buffer_to_text(&render_to_buffer(app, 80, 24, &Theme::PLAIN))
}

#[test]
fn an_enum_value_newer_than_the_dialect_shows_the_payload_in_hex() {
    let mut app = App::new(AppConfig {
        links: vec!["test".into()],
        fetch_params: false,
        ..AppConfig::default()
    });
    feed(&mut app, SECOND, &common::copter_heartbeat(1, 0, 0));
    // A known value first: decoded.
    feed(&mut app, SECOND + 10, &extended_sys_state(1));
    app.update(SECOND + 20, Event::Key(Key::ch('4')));
    for c in "/extended\n".chars() {
        let key = if c == '\n' {
            "enter".parse().unwrap()
        } else {
            Key::ch(c)
        };
        app.update(SECOND + 30, Event::Key(key));
    }
    assert_eq!(app.inspector_selected(), Some((1, 1, 245)));
    let s = app_screen(&app);
    assert_eq!(
        shown_field(&s, "landed_state").as_deref(),
        Some("MAV_LANDED_STATE_ON_GROUND"),
        "{s}"
    );
    // MAV_LANDED_STATE has no 9 (yet): the dialect refuses the whole message.
    feed(&mut app, 2 * SECOND, &extended_sys_state(9));
    let e = app.inspector.get((1, 1, 245)).unwrap();
    assert_eq!(e.count, 2);
    assert!(e.decode(245).is_err());
    let s = app_screen(&app);
    assert!(
        s.contains("not decoded: MavLandedState has no value 9 in our dialect"),
        "{s}"
    );
    assert!(s.contains("00: 03 09"), "{s}");
    insta::assert_snapshot!("inspector_hex_80x24", s);
}

#[test]
fn the_screen_never_panics_at_any_size() {
    let mut r = runner();
    wait(&mut r, 8.0);
    common::keys(&mut r, &["4"]);
    let mut states = Vec::new();
    states.push(r.app.clone());
    select(&mut r, "HEARTBEAT");
    common::keys(&mut r, &["enter", "down", "down"]);
    states.push(r.app.clone());
    common::keys(&mut r, &["enter", "r"]);
    common::typed(&mut r, "123.456");
    states.push(r.app.clone());
    let empty = App::new(AppConfig::default());
    let mut inspector_empty = empty.clone();
    inspector_empty.update(0, Event::Key(Key::ch('4')));
    states.push(inspector_empty);
    for app in &states {
        for w in (0..=150u16).step_by(3) {
            for h in (0..=40u16).step_by(2) {
                let _ = render_to_buffer(app, w.max(1), h.max(1), &Theme::PLAIN);
            }
        }
    }
    // Wide: the fields beside the list.
    let app = &states[0];
    let s = buffer_to_text(&render_to_buffer(app, 160, 30, &Theme::PLAIN));
    // Below the state strip.
    let first = s.lines().nth(1).unwrap();
    assert!(
        first.contains("MAVLink Inspector") && first.contains(" from 1:1"),
        "{s}"
    );
    // Every field's name = value pairs come from the dialect's own reading.
    let k = app.inspector_selected().unwrap();
    let msg = app.inspector.get(k).unwrap().decode(k.2).unwrap();
    assert!(!fields(&msg).is_empty());
}

/// Mid-flight in the real capture: hovering at the 10 m of the takeoff.
const MID_FLIGHT: Micros = 56 * SECOND;

#[test]
fn the_capture_shows_latitude_in_degrees_and_on_enter_the_raw_value() {
    let spec: LinkSpec = "tlog:tests/data/copter-flight.vehicle.tlog"
        .parse()
        .unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    r.advance_to(MID_FLIGHT);
    common::keys(&mut r, &["4"]);
    let k = select(&mut r, "GLOBAL_POSITION_INT");
    let Ok(MavMessage::GLOBAL_POSITION_INT(m)) = r.app.inspector.get(k).unwrap().decode(k.2) else {
        panic!("not decoded")
    };
    // common.xml: lat, lon in degE7; relative_alt in mm; vx in cm/s; hdg in cdeg.
    let s = screen(&r);
    let deg = format!("{:.7}", m.lat as f64 / 1e7);
    assert_eq!(shown_field(&s, "lat").as_deref(), Some(deg.as_str()), "{s}");
    assert!(s.contains(&format!("lat          = {deg} deg")), "{s}");
    let lon = format!("{:.7}", m.lon as f64 / 1e7);
    assert_eq!(shown_field(&s, "lon").as_deref(), Some(lon.as_str()), "{s}");
    let rel = format!("{:.3}", m.relative_alt as f64 / 1000.0);
    assert!(s.contains(&format!("= {rel} m")), "{s}");
    assert!(
        (m.relative_alt as f64 / 1000.0 - 10.0).abs() < 1.5,
        "hovering at 10 m"
    );
    let hdg = format!("{:.2}", m.hdg as f64 / 100.0);
    assert_eq!(shown_field(&s, "hdg").as_deref(), Some(hdg.as_str()), "{s}");
    assert!(!s.contains(&m.lat.to_string()), "{s}");
    insta::assert_snapshot!("inspector_units_80x24", s);
    // enter: the raw values as sent beside the converted ones.
    common::keys(&mut r, &["enter"]);
    let s = screen(&r);
    let line = s
        .lines()
        .find(|l| l.contains(&format!("lat          = {deg} deg ")))
        .unwrap_or_else(|| panic!("{s}"));
    assert!(line.contains(&format!(" raw {} ", m.lat)), "{s}");
    insta::assert_snapshot!("inspector_units_raw_80x24", s);
    common::keys(&mut r, &["enter"]);
    assert!(!screen(&r).contains(&format!("raw {}", m.lat)));
}
