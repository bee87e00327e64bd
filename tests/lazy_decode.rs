//! A link's parser decodes nothing (`FrameParser::lazy`); the core decodes only the messages it
//! reads decoded. Against the same core fed by a parser that decodes every frame: the real
//! ArduCopter captures (a flight, a mission session, a MAVFTP parameter download) leave the same
//! report and the same screens; a message whose enum value is newer than the dialect is counted
//! as a decode error when the core reads it (a HEARTBEAT, still listed from its bytes) and not
//! when nothing does.

use mavterm::app::screen::SCREENS;
use mavterm::app::{App, AppConfig, Event};
use mavterm::dialect::{self, MavMessage};
use mavterm::link::tlog::read_tlog;
use mavterm::link::{FrameParser, ParserStats};
use mavterm::proto::vehicles::VehicleKey;
use mavterm::ui::{buffer_to_text, render_to_buffer, Theme};
use mavterm::wire::frame::{crc_extra, encode, frame_crc, Header, Version};

fn core() -> App {
    App::new(AppConfig {
        links: vec!["capture".into()],
        ..AppConfig::default()
    })
}

/// The capture's frames, each record at its time (from the first), through `parser`.
fn feed_capture(app: &mut App, parser: &mut FrameParser, name: &str) {
    let path = format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
    let recs = read_tlog(&std::fs::read(path).unwrap()).unwrap();
    let t0 = recs[0].time_us;
    let mut reported = ParserStats::default();
    for r in &recs {
        let mut frames = Vec::new();
        parser.push_into(&r.frame, &mut frames);
        let total = *parser.stats();
        let stats = total.since(&reported);
        reported = total;
        app.update(
            1 + r.time_us - t0,
            Event::Frames {
                link: 0,
                frames,
                stats,
            },
        );
    }
}

/// Every screen's text at 120x40, and the report.
fn seen(app: &mut App) -> (Vec<String>, serde_json::Value) {
    let mut screens = Vec::new();
    for s in SCREENS {
        app.ui.screen = s.name;
        let text = buffer_to_text(&render_to_buffer(app, 120, 40, &Theme::PLAIN));
        screens.push(format!("== {}\n{text}", s.name));
    }
    app.ui.screen = SCREENS[0].name;
    (screens, app.report())
}

#[test]
fn the_captures_look_the_same_decoded_lazily_or_not() {
    for name in [
        "copter-flight.vehicle.tlog",
        "copter-mission.vehicle.tlog",
        "copter-mavftp-params.vehicle.tlog",
    ] {
        let (mut eager, mut lazy) = (core(), core());
        feed_capture(&mut eager, &mut FrameParser::new(), name);
        feed_capture(&mut lazy, &mut FrameParser::lazy(), name);
        let (eager_screens, eager_report) = seen(&mut eager);
        let (lazy_screens, lazy_report) = seen(&mut lazy);
        assert!(
            eager.links[0].parser.frames > 100,
            "{name}: {} frames",
            eager.links[0].parser.frames
        );
        assert!(!eager.vehicles.is_empty(), "{name}: a vehicle was heard");
        for (e, l) in eager_screens.iter().zip(&lazy_screens) {
            assert_eq!(e, l, "{name}");
        }
        // The captures hold no message our dialect cannot decode: the counters agree too.
        assert_eq!(eager.links[0].parser.decode_errors, 0, "{name}");
        assert_eq!(eager_report, lazy_report, "{name}");
    }
}

/// `msg` from 1:1, with payload byte `at` changed to `value` and the CRC made good again.
fn patched(msg: &MavMessage, seq: u8, at: usize, value: u8) -> Vec<u8> {
    let h = Header {
        sysid: 1,
        compid: 1,
        seq,
    };
    let mut bytes = encode(Version::V2, h, msg);
    bytes[10 + at] = value;
    let n = bytes.len();
    let id = u32::from_le_bytes([bytes[7], bytes[8], bytes[9], 0]);
    let crc = frame_crc(&bytes[1..n - 2], crc_extra(id).unwrap());
    bytes[n - 2..].copy_from_slice(&crc.to_le_bytes());
    bytes
}

#[test]
fn a_message_the_core_reads_that_does_not_decode_is_counted_and_one_it_does_not_read_is_not() {
    // A quadrotor's heartbeat with MAV_TYPE 200 (beyond the dialect's); wire order: custom_mode
    // u32, type, autopilot, base_mode, system_status, mavlink_version.
    let hb = MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: dialect::MavType::MAV_TYPE_QUADROTOR,
        autopilot: dialect::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode: dialect::MavModeFlag::from_bits_truncate(1),
        system_status: dialect::MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
    });
    let odd_heartbeat = patched(&hb, 0, 4, 200);
    // HIGH_LATENCY2 (nothing in the core reads it) with MAV_TYPE 200 too; wire order:
    // timestamp u32, latitude i32, longitude i32, custom_mode u16, altitude i16,
    // target_altitude i16, target_distance u16, wp_num u16, failure_flags u16, type u8.
    let hl2 = MavMessage::HIGH_LATENCY2(dialect::HIGH_LATENCY2_DATA {
        mavtype: dialect::MavType::MAV_TYPE_QUADROTOR,
        ..Default::default()
    });
    let odd_hl2 = patched(&hl2, 1, 24, 200);
    // Both are frames whose payload the dialect refuses.
    for bytes in [&odd_heartbeat, &odd_hl2] {
        let mut eager = FrameParser::new();
        let f = eager.parse_all(bytes);
        assert_eq!(f.len(), 1);
        assert!(f[0].message.is_none());
        assert_eq!(eager.stats().decode_errors, 1);
    }

    let mut app = core();
    let mut parser = FrameParser::lazy();
    let mut bytes = odd_heartbeat.clone();
    bytes.extend_from_slice(&odd_hl2);
    let frames = parser.parse_all(&bytes);
    assert_eq!(frames.len(), 2);
    assert!(frames.iter().all(|f| f.message.is_none() && f.lazy));
    assert_eq!(
        parser.stats().decode_errors,
        0,
        "a lazy parser decodes nothing"
    );
    let stats = *parser.stats();
    app.update(
        1,
        Event::Frames {
            link: 0,
            frames,
            stats,
        },
    );
    // The heartbeat is read: its failure counted, and the vehicle still listed from its bytes.
    assert_eq!(app.links[0].parser.decode_errors, 1);
    assert_eq!(app.links[0].parser.frames, 2);
    let v = app.vehicles.get(VehicleKey(1, 1)).expect("listed");
    assert_eq!(
        v.autopilot,
        dialect::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA
    );
}
