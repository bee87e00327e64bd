//! The flight pane and the telemetry behind it: the real ArduCopter flight capture replayed on a
//! virtual clock (values checked against pymavlink's reading of the same frames and against
//! expected.json), and frames packed by pymavlink (a fix type newer than our dialect, HOME_POSITION
//! asked for until it comes).

mod common;

use mavterm::app::{App, AppConfig, Effect, Event};
use mavterm::clock::{Micros, SECOND};
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::tlog::read_tlog;
use mavterm::link::{FrameParser, LinkSpec};
use mavterm::proto::telemetry::{FlightTelemetry, STALE_AFTER};
use mavterm::proto::vehicles::VehicleKey;
use mavterm::ui::{self, buffer_to_text, Theme};
use serde_json::{json, Value};

const CAPTURE: &str = "data/copter-flight.vehicle.tlog";
/// Mid-flight: hovering at the 10 m of the takeoff, armed, home set.
const MID_FLIGHT: Micros = 56 * SECOND;

fn replay() -> VirtualRunner {
    // Relative to the package root, where tests run: the same on every checkout, on screen too.
    let spec: LinkSpec = format!("tlog:tests/{CAPTURE}").parse().unwrap();
    VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap()
}

fn flight(r: &VirtualRunner) -> &FlightTelemetry {
    &r.app.sessions[&VehicleKey(1, 1)].flight
}

fn screen(app: &App, w: u16, h: u16) -> String {
    buffer_to_text(&ui::render_to_buffer(app, w, h, &Theme::PLAIN))
}

/// The flight pane's rows of a screen (its first four).
fn flight_lines(screen: &str) -> String {
    screen.lines().take(4).collect::<Vec<_>>().join("\n")
}

/// pymavlink's reading of the last frame of each of `ids` that the replay delivered by `t`.
fn last_frames_by_pymavlink(t: Micros, ids: &[u32]) -> Vec<Value> {
    let bytes = std::fs::read(common::test_path(CAPTURE)).unwrap();
    let recs = read_tlog(&bytes).unwrap();
    let t0 = recs[0].time_us;
    let mut last = vec![None; ids.len()];
    for r in recs.iter().take_while(|r| r.time_us - t0 <= t) {
        let msgid = FrameParser::new().parse_all(&r.frame)[0].msgid;
        if let Some(i) = ids.iter().position(|&id| id == msgid) {
            last[i] = Some(r.frame.clone());
        }
    }
    let frames: Vec<Vec<u8>> = last
        .into_iter()
        .map(|f| f.expect("every message was sent by then"))
        .collect();
    common::pymavlink_decode(&frames)
}

#[test]
fn capture_mid_flight_values_are_pymavlinks() {
    let mut r = replay();
    r.advance_to(MID_FLIGHT);
    let f = flight(&r);
    let [gpi, gps, hud, sys, home, ekf]: [Value; 6] =
        last_frames_by_pymavlink(MID_FLIGHT, &[33, 24, 74, 1, 242, 193])
            .try_into()
            .unwrap();
    let p = f.position.unwrap().value;
    assert_eq!(
        (p.lat_e7, p.lon_e7, p.alt_mm, p.relative_alt_mm),
        (
            gpi["lat"].as_i64().unwrap() as i32,
            gpi["lon"].as_i64().unwrap() as i32,
            gpi["alt"].as_i64().unwrap() as i32,
            gpi["relative_alt"].as_i64().unwrap() as i32
        )
    );
    // Hovering after the takeoff to 10 m.
    assert!((p.relative_alt_m() - 10.0).abs() < 0.1, "{p:?}");
    let g = f.gps.unwrap().value;
    assert_eq!(g.fix_type as u64, gps["fix_type"].as_u64().unwrap());
    assert_eq!(
        g.satellites.map(u64::from),
        gps["satellites_visible"].as_u64()
    );
    // What the capture says: SITL's GPS reports RTK fixed with 10 satellites.
    assert_eq!((g.fix_type, g.satellites), (6, Some(10)));
    let m = f.motion.unwrap().value;
    assert_eq!(m.groundspeed as f64, hud["groundspeed"].as_f64().unwrap());
    assert_eq!(m.climb as f64, hud["climb"].as_f64().unwrap());
    assert_eq!(m.heading as i64, hud["heading"].as_i64().unwrap());
    let b = f.battery.unwrap().value;
    assert_eq!(
        b.voltage_mv.map(u64::from),
        sys["voltage_battery"].as_u64(),
        "{b:?}"
    );
    assert_eq!(
        b.remaining_pct.map(u64::from),
        sys["battery_remaining"].as_u64()
    );
    let h = f.home.unwrap().value;
    assert_eq!(
        (h.lat_e7 as i64, h.lon_e7 as i64, h.alt_mm as i64),
        (
            home["latitude"].as_i64().unwrap(),
            home["longitude"].as_i64().unwrap(),
            home["altitude"].as_i64().unwrap()
        )
    );
    assert_eq!(f.ekf.unwrap().value as u64, ekf["flags"].as_u64().unwrap());
    let prearm_bit = 0x1000_0000u64;
    let healthy = sys["onboard_control_sensors_health"].as_u64().unwrap() & prearm_bit != 0;
    assert_eq!(f.prearm.unwrap().value.healthy, healthy);
    // What the pane says.
    let text = screen(&r.app, 80, 24);
    let alt = format!(
        "ALT {:.1} m (rel) {:.1} m AMSL",
        gpi["relative_alt"].as_f64().unwrap() / 1000.0,
        gpi["alt"].as_f64().unwrap() / 1000.0
    );
    assert!(text.contains(&alt), "{alt}\n{text}");
    let pos = format!(
        "POS {:.7} {:.7}",
        gpi["lat"].as_f64().unwrap() / 1e7,
        gpi["lon"].as_f64().unwrap() / 1e7
    );
    assert!(text.contains(&pos), "{pos}\n{text}");
    assert!(text.contains("GPS RTK fixed 10 sats"), "{text}");
    assert!(text.contains("EKF ok  PRE ok"), "{text}");
    assert!(text.contains("LOSS 0.0% ▁▁▁"), "{text}");
    assert!(
        !flight_lines(&text).contains('?'),
        "nothing is stale mid-flight\n{text}"
    );
}

#[test]
fn capture_highest_relative_altitude_is_expected_jsons() {
    let exp: Value = serde_json::from_str(
        &std::fs::read_to_string(common::test_path("data/expected.json")).unwrap(),
    )
    .unwrap();
    let want = exp["copter-flight.vehicle.tlog"]["max_relative_alt_m"]
        .as_f64()
        .unwrap();
    let mut r = replay();
    let mut highest = f64::MIN;
    // GLOBAL_POSITION_INT comes at 10 Hz: steps of 10 ms see every one.
    for step in 0..8_300u64 {
        r.advance_to(step * 10_000);
        if let Some(p) = r
            .app
            .sessions
            .get(&VehicleKey(1, 1))
            .and_then(|s| s.flight.position)
        {
            highest = highest.max(p.value.relative_alt_m());
        }
    }
    // expected.json has it to the centimetre.
    assert!((highest - want).abs() < 0.01, "{highest} vs {want}");
    // The altitude history of the last minute (22 s to 82 s) holds the flight, one value a
    // second, the highest within the highest heard.
    let hist = flight(&r).altitude.recent(r.now(), 60);
    let top = hist.iter().flatten().fold(f32::MIN, |a, &b| a.max(b)) as f64;
    assert!(top <= highest + 1e-6 && top > want - 0.2, "{top}");
    assert!(
        hist.iter().filter(|v| v.is_some()).count() >= 55,
        "{hist:?}"
    );
}

#[test]
fn overview_with_the_flight_pane_mid_flight() {
    let mut r = replay();
    r.advance_to(MID_FLIGHT);
    insta::assert_snapshot!("flight_overview_80x24", screen(&r.app, 80, 24));
    insta::assert_snapshot!("flight_overview_200x60", screen(&r.app, 200, 60));
    // At 80x24 the other panes still show their rows.
    let text = screen(&r.app, 80, 24);
    assert!(text.contains("> 1:1 QUADROTOR"), "{text}");
    assert!(text.contains("+0 tlog copter-flight.…"), "{text}");
    assert!(
        text.contains("» 0 tlog:tests/data/copter-flight.vehicle.tlog  up"),
        "{text}"
    );
    // The capture's 41 texts, the vehicle found, 16 values the vehicle changed (calibrations at
    // boot, the mission count), told at DEBUG; nothing of ours: a replay link is asked for no
    // streams and no parameters (it could not answer).
    assert!(text.contains("Messages (58)"), "{text}");
}

#[test]
fn telemetry_goes_stale_after_silence() {
    let mut r = replay();
    // The capture ends at 81.8 s.
    r.advance_to(82 * SECOND);
    let last = flight(&r).last_heard().unwrap();
    let pane = |r: &VirtualRunner| flight_lines(&screen(&r.app, 80, 24));
    assert!(!pane(&r).contains('?'), "{}", pane(&r));
    // Each value by its own age: the position goes stale 3 s after the last GLOBAL_POSITION_INT.
    let pos_at = flight(&r).position.unwrap().at;
    r.advance_to(pos_at + STALE_AFTER);
    assert!(!pane(&r).contains("AMSL?"), "{}", pane(&r));
    r.advance_to(pos_at + STALE_AFTER + 1);
    assert!(pane(&r).contains("AMSL?"), "{}", pane(&r));
    // Everything, 3 s after the last message.
    r.advance_to(last + STALE_AFTER + 1);
    let text = pane(&r);
    for item in [
        "AMSL?",
        "GS 0.0 m/s?",
        "HDG 352°?",
        "HOME 0 m?",
        "EKF ok?",
        "PRE ok?",
    ] {
        assert!(text.contains(item), "{item}\n{text}");
    }
    assert!(text.contains("BAT 12.6 V 0.0 A 92%?"), "{text}");
    assert!(text.contains("GPS RTK fixed 10 sats?"), "{text}");
    r.advance_to(last + 12 * SECOND);
    let text = screen(&r.app, 80, 24);
    assert!(text.contains("─ Flight 1:1 (12s old) ─"), "{text}");
    insta::assert_snapshot!("flight_overview_stale_80x24", text);
    // Dim, and not only by colour: the `?` is there without it.
    let buf = ui::render_to_buffer(&r.app, 80, 24, &Theme::PLAIN);
    let row = (0..24)
        .find(|&y| {
            buffer_to_text(&buf)
                .lines()
                .nth(y)
                .unwrap()
                .starts_with("ALT")
        })
        .unwrap() as u16;
    assert!(buf[(5, row)]
        .modifier
        .contains(ratatui::style::Modifier::DIM));
}

#[test]
fn narrow_screens_drop_whole_items_never_cut_numbers() {
    let mut r = replay();
    r.advance_to(MID_FLIGHT);
    let spark = |c: char| "▁▂▃▄▅▆▇█".contains(c);
    let items = |line: &str| -> Vec<String> {
        line.split("  ")
            .map(|s| s.trim_matches(|c: char| spark(c) || c == ' ').to_string())
            .filter(|s| !s.is_empty())
            .collect()
    };
    let full: Vec<String> = ui::flight::lines(&r.app, 400, &Theme::PLAIN)
        .iter()
        .flat_map(|l| items(&l.to_string()))
        .collect();
    assert_eq!(full.len(), 11, "{full:?}");
    for w in 0..=120usize {
        for line in ui::flight::lines(&r.app, w, &Theme::PLAIN) {
            let s = line.to_string();
            assert!(s.chars().count() <= w, "{w}: {s}");
            for item in items(&s) {
                assert!(full.contains(&item), "{w}: {item:?} cut in {s:?}");
            }
        }
    }
    // No panic at any small size of the whole screen, either.
    for w in 0..=40 {
        for h in 0..=12 {
            screen(&r.app, w, h);
        }
    }
}

/// An app with one link and request_streams on, fed frames packed by pymavlink.
struct Core {
    app: App,
    fx: Vec<Effect>,
}

impl Core {
    fn new() -> Self {
        let mut app = App::new(AppConfig {
            links: vec!["test0".into()],
            fetch_params: false,
            ..AppConfig::default()
        });
        let fx = app.update(
            0,
            Event::LinkState {
                link: 0,
                state: mavterm::link::LinkState::Up,
            },
        );
        Core { app, fx }
    }

    fn feed(&mut self, t: Micros, bytes: &[u8]) {
        let frames = FrameParser::new().parse_all(bytes);
        let fx = self.app.update(
            t,
            Event::Frames {
                link: 0,
                frames,
                stats: Default::default(),
            },
        );
        self.fx.extend(fx);
    }

    /// Timers up to `until`, as a front end wakes the core.
    fn run_to(&mut self, until: Micros) {
        while self.app.next_deadline() <= until {
            let t = self.app.next_deadline().max(self.app.now);
            let fx = self.app.update(t, Event::Tick);
            self.fx.extend(fx);
            if self.app.next_deadline() <= t {
                break;
            }
        }
        let fx = self.app.update(until, Event::Tick);
        self.fx.extend(fx);
    }

    /// The HOME_POSITION requests sent so far, read by pymavlink: (time order) each one's fields.
    fn home_requests(&self) -> Vec<Value> {
        let frames: Vec<Vec<u8>> = self
            .fx
            .iter()
            .filter_map(|e| match e {
                Effect::Send { frame, .. } => Some(frame.clone()),
                _ => None,
            })
            .collect();
        common::pymavlink_decode(&frames)
            .into_iter()
            .filter(|m| m["name"] == "COMMAND_LONG" && m["command"] == 512)
            // The gimbal discovery's GIMBAL_MANAGER_INFORMATION requests are not home's.
            .filter(|m| m["param1"] != 280.0)
            .collect()
    }
}

fn request(seq: u8, msg: &str, fields: Value) -> Value {
    json!({"sysid": 1, "compid": 1, "seq": seq, "msg": msg, "fields": fields})
}

fn packed(seq: u8, msg: &str, fields: Value) -> Vec<u8> {
    common::pymavlink_encode(&[request(seq, msg, fields)]).remove(0)
}

/// ArduCopter heartbeats from 1:1 with seq 0..n, packed in one pymavlink run.
fn heartbeats(n: u8) -> Vec<Vec<u8>> {
    let reqs: Vec<Value> = (0..n)
        .map(|seq| {
            request(
                seq,
                "HEARTBEAT",
                json!({"type": 2, "autopilot": 3, "base_mode": 1, "custom_mode": 0,
                    "system_status": 3, "mavlink_version": 3}),
            )
        })
        .collect();
    common::pymavlink_encode(&reqs)
}

#[test]
fn home_is_asked_for_every_few_seconds_until_it_comes() {
    let hb = heartbeats(41);
    let mut c = Core::new();
    for s in 0..12u64 {
        c.run_to(s * SECOND);
        c.feed(s * SECOND, &hb[s as usize]);
    }
    let reqs = c.home_requests();
    // At 0 s, 5 s and 10 s: MAV_CMD_REQUEST_MESSAGE for HOME_POSITION (242), to 1:1.
    assert_eq!(reqs.len(), 3, "{reqs:?}");
    for r in &reqs {
        assert_eq!(r["param1"], 242.0);
        assert_eq!(
            (r["target_system"].as_u64(), r["target_component"].as_u64()),
            (Some(1), Some(1))
        );
        assert_eq!(
            (r["sysid"].as_u64(), r["compid"].as_u64()),
            (Some(255), Some(190))
        );
    }
    let home = packed(
        12,
        "HOME_POSITION",
        json!({"latitude": -353632621, "longitude": 1491652374, "altitude": 584000,
            "x": 0.0, "y": 0.0, "z": 0.0, "q": [1.0, 0.0, 0.0, 0.0],
            "approach_x": 0.0, "approach_y": 0.0, "approach_z": 0.0}),
    );
    c.feed(12 * SECOND, &home);
    let f = &c.app.sessions[&VehicleKey(1, 1)].flight;
    assert_eq!(f.home.unwrap().value.lat_e7, -353632621);
    // Known now: not asked again.
    for s in 13..40u64 {
        c.run_to(s * SECOND);
        c.feed(s * SECOND, &hb[s as usize]);
    }
    assert_eq!(c.home_requests().len(), 3);
}

#[test]
fn a_gps_fix_type_newer_than_our_dialect_shows_as_a_number() {
    let mut c = Core::new();
    c.feed(0, &heartbeats(1)[0]);
    let gps = packed(
        1,
        "GPS_RAW_INT",
        json!({"time_usec": 0, "fix_type": 200, "lat": 0, "lon": 0, "alt": 0, "eph": 0,
            "epv": 0, "vel": 0, "cog": 0, "satellites_visible": 13}),
    );
    assert!(FrameParser::new().parse_all(&gps)[0].message.is_none());
    c.feed(100_000, &gps);
    let g = c.app.sessions[&VehicleKey(1, 1)].flight.gps.unwrap().value;
    assert_eq!((g.fix_type, g.satellites), (200, Some(13)));
    let text = screen(&c.app, 80, 24);
    assert!(text.contains("GPS fix 200 13 sats"), "{text}");
    // What was never heard shows `--`, not a made-up value.
    assert!(text.contains("ALT --"), "{text}");
    assert!(text.contains("HOME --"), "{text}");
    // EKF and pre-arm state are shown only once reported.
    assert!(!text.contains("EKF") && !text.contains("PRE"), "{text}");
}

#[test]
fn without_target_or_telemetry_the_pane_is_one_line() {
    let mut c = Core::new();
    let text = screen(&c.app, 80, 24);
    assert!(text.starts_with("─ Flight: no target ─"), "{text}");
    assert!(
        text.lines().nth(1).unwrap().starts_with("┏ *Vehicles"),
        "{text}"
    );
    c.feed(0, &heartbeats(1)[0]);
    let text = screen(&c.app, 80, 24);
    assert!(text.starts_with("─ Flight 1:1: no telemetry ─"), "{text}");
    assert!(
        text.lines().nth(1).unwrap().starts_with("┏ *Vehicles"),
        "{text}"
    );
}

/// A vehicle that sends no VFR_HUD: speed, climb and heading from GLOBAL_POSITION_INT (packed by
/// pymavlink): vx, vy north and east and vz down in cm/s, hdg in centidegrees, UINT16_MAX for
/// unknown (the course over ground then). A VFR_HUD, once it comes, is what is shown.
#[test]
fn speed_climb_and_heading_come_from_global_position_int_without_vfr_hud() {
    let mut c = Core::new();
    c.feed(0, &heartbeats(1)[0]);
    let gpi = |seq: u8, vx: i16, vy: i16, vz: i16, hdg: u16| {
        packed(
            seq,
            "GLOBAL_POSITION_INT",
            json!({"time_boot_ms": 1000, "lat": -353632621, "lon": 1491652374,
                "alt": 594000, "relative_alt": 10000, "vx": vx, "vy": vy, "vz": vz, "hdg": hdg}),
        )
    };
    assert!(c.app.sessions[&VehicleKey(1, 1)].flight.motion.is_none());
    c.feed(100_000, &gpi(1, 300, 400, -150, 9000));
    let text = screen(&c.app, 100, 24);
    let lines = flight_lines(&text);
    assert!(lines.contains("GS 5.0 m/s"), "{lines}");
    assert!(lines.contains("CLB +1.5 m/s"), "{lines}");
    assert!(lines.contains("HDG 090°"), "{lines}");
    // Heading unknown: the course, 2 m/s west.
    c.feed(200_000, &gpi(2, 0, -200, 0, u16::MAX));
    let lines = flight_lines(&screen(&c.app, 100, 24));
    assert!(lines.contains("HDG 270°"), "{lines}");
    assert!(lines.contains("GS 2.0 m/s"), "{lines}");
    // VFR_HUD comes: it wins.
    let hud = packed(
        3,
        "VFR_HUD",
        json!({"airspeed": 0.0, "groundspeed": 0.7, "heading": 12, "throttle": 0,
            "alt": 594.0, "climb": 0.0}),
    );
    c.feed(300_000, &hud);
    c.feed(400_000, &gpi(4, 300, 400, -150, 9000));
    let lines = flight_lines(&screen(&c.app, 100, 24));
    assert!(
        lines.contains("GS 0.7 m/s") && lines.contains("HDG 012°"),
        "{lines}"
    );
}
