//! The operator always knows what happened: the Messages pane keeps what matters in view (DEBUG
//! hidden and counted, mavterm's own notices marked as ours, recent warnings kept above older
//! lines), quitting asks while a vehicle is armed, and `wp start` on a disarmed vehicle says
//! what it takes and does it as one confirmed action. Read on the screen (TestBackend text) and
//! on the wire (pymavlink).

mod common;

use common::{command, hear, keys, statustext, wait};

use mavterm::app::{App, AppConfig, Effect, Event};
use mavterm::dialect::{self, MavMessage};
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::keymap::Key;
use mavterm::link::LinkSpec;
use mavterm::ui::{buffer_to_text, render_to_buffer, Theme};
use serde_json::Value;

const SECOND: u64 = 1_000_000;

/// ArduCopter 1:1's HEARTBEAT in STABILIZE (0), disarmed or armed.
fn heartbeat(armed: bool) -> MavMessage {
    MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
        mavtype: dialect::MavType::MAV_TYPE_QUADROTOR,
        autopilot: dialect::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        // MAV_MODE_FLAG_SAFETY_ARMED (128) | CUSTOM_MODE_ENABLED (1).
        base_mode: dialect::MavModeFlag::from_bits_truncate(if armed { 129 } else { 1 }),
        system_status: dialect::MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
        custom_mode: 0,
    })
}

/// An app on one link that has heard 1:1 at 0 s, armed or not.
fn app_with(armed: bool) -> App {
    let mut app = App::new(AppConfig {
        links: vec!["x".into()],
        request_streams: false,
        fetch_params: false,
        ..AppConfig::default()
    });
    hear(&mut app, 0, &heartbeat(armed));
    app
}

fn screen(app: &App) -> String {
    buffer_to_text(&render_to_buffer(app, 80, 24, &Theme::PLAIN))
}

/// The Messages pane's title line.
fn messages_title(text: &str) -> String {
    text.lines()
        .find(|l| l.contains("Messages ("))
        .unwrap_or_else(|| panic!("no Messages title: {text}"))
        .to_string()
}

#[test]
fn debug_lines_are_hidden_and_counted_in_the_title() {
    let mut app = app_with(false);
    use dialect::MavSeverity::*;
    for i in 0..12 {
        let text = format!("BARO1_GND_PRESS changed to 9{i}");
        hear(
            &mut app,
            SECOND + i * 1000,
            &statustext(MAV_SEVERITY_DEBUG, &text),
        );
    }
    hear(
        &mut app,
        2 * SECOND,
        &statustext(MAV_SEVERITY_INFO, "EKF3 IMU0 is using GPS"),
    );
    let text = screen(&app);
    let title = messages_title(&text);
    assert!(title.contains("12 debug hidden"), "{title}");
    assert!(!text.contains("BARO1_GND_PRESS"), "{text}");
    assert!(text.contains("EKF3 IMU0 is using GPS"), "{text}");
}

#[test]
fn our_own_notices_say_mavterm_and_the_vehicles_say_their_key() {
    let mut app = app_with(false);
    hear(
        &mut app,
        SECOND,
        &statustext(dialect::MavSeverity::MAV_SEVERITY_INFO, "Arming motors"),
    );
    let text = screen(&app);
    let found = text
        .lines()
        .find(|l| l.contains("vehicle 1:1 found"))
        .unwrap_or_else(|| panic!("{text}"));
    assert!(found.contains(" mavterm "), "{found}");
    let arming = text
        .lines()
        .find(|l| l.contains("Arming motors"))
        .unwrap_or_else(|| panic!("{text}"));
    assert!(arming.contains(" 1:1 "), "{arming}");
    assert!(!arming.contains("mavterm"), "{arming}");
}

#[test]
fn a_warning_of_30_s_ago_stays_in_view_after_20_info_lines() {
    let mut app = app_with(false);
    use dialect::MavSeverity::*;
    hear(
        &mut app,
        10 * SECOND,
        &statustext(MAV_SEVERITY_WARNING, "PreArm: Battery 1 low"),
    );
    for i in 0..20 {
        hear(&mut app, 40 * SECOND + i * 1000, &heartbeat(false));
        let text = format!("MIS_TOTAL changed to {i}");
        hear(
            &mut app,
            40 * SECOND + i * 1000 + 1,
            &statustext(MAV_SEVERITY_INFO, &text),
        );
    }
    let text = screen(&app);
    assert!(text.contains("PreArm: Battery 1 low"), "{text}");
    // The newest line is in view, the oldest INFO lines gave way.
    assert!(text.contains("MIS_TOTAL changed to 19"), "{text}");
    assert!(!text.contains("MIS_TOTAL changed to 0 "), "{text}");
    // 70 s after it, the warning gives way too.
    hear(&mut app, 80 * SECOND, &heartbeat(false));
    hear(
        &mut app,
        80 * SECOND + 1,
        &statustext(MAV_SEVERITY_INFO, "Mission: 1 WP"),
    );
    let text = screen(&app);
    assert!(!text.contains("PreArm: Battery 1 low"), "{text}");
}

fn quits(fx: &[Effect]) -> bool {
    fx.iter().any(|e| matches!(e, Effect::Quit))
}

/// COMMAND_LONG, COMMAND_INT, SET_MODE or a velocity target among `fx`.
fn operator_sends(fx: &[Effect]) -> usize {
    common::sent_messages(fx)
        .iter()
        .filter(|m| {
            matches!(
                m,
                MavMessage::COMMAND_LONG(_)
                    | MavMessage::COMMAND_INT(_)
                    | MavMessage::SET_POSITION_TARGET_LOCAL_NED(_)
            )
        })
        .count()
}

fn key(app: &mut App, now: u64, k: Key) -> Vec<Effect> {
    app.update(now, Event::Key(k))
}

#[test]
fn q_while_armed_asks_and_only_y_after_the_guard_quits() {
    let mut app = app_with(true);
    // What keeps the terminal redrawing at the full rate while nobody types.
    assert!(app.any_armed());
    let fx = key(&mut app, SECOND, Key::ch('q'));
    assert!(!quits(&fx) && !app.quit);
    assert_eq!(operator_sends(&fx), 0);
    let q = app.ui.confirm.clone().expect("asked");
    assert!(q.text.contains("quit while 1:1 is armed?"), "{}", q.text);
    // Too soon after the question: not an answer.
    let fx = key(&mut app, SECOND + 100_000, Key::ch('y'));
    assert!(!quits(&fx) && !app.quit);
    let fx = key(&mut app, SECOND + 500_000, Key::ch('y'));
    assert!(quits(&fx) && app.quit);
    assert_eq!(operator_sends(&fx), 0);

    // `n` stays.
    let mut app = app_with(true);
    key(&mut app, SECOND, Key::ch('q'));
    let fx = key(&mut app, SECOND + 500_000, Key::ch('n'));
    assert!(!quits(&fx) && !app.quit && app.ui.confirm.is_none());

    // `:quit` asks too; `:quit!` does not.
    let mut app = app_with(true);
    for k in ":quit".chars() {
        key(&mut app, SECOND, Key::ch(k));
    }
    let enter: Key = "enter".parse().unwrap();
    let fx = key(&mut app, SECOND, enter);
    assert!(!quits(&fx) && app.ui.confirm.is_some());
    let mut app = app_with(true);
    for k in ":quit!".chars() {
        key(&mut app, SECOND, Key::ch(k));
    }
    assert!(quits(&key(&mut app, SECOND, enter)));
}

#[test]
fn q_while_disarmed_quits_at_once() {
    let mut app = app_with(false);
    assert!(!app.any_armed());
    let fx = key(&mut app, SECOND, Key::ch('q'));
    assert!(quits(&fx) && app.quit);
    assert!(app.ui.confirm.is_none());
}

#[test]
fn ctrl_c_twice_within_2_s_forces() {
    let mut app = app_with(true);
    let fx = key(&mut app, SECOND, Key::ctrl('c'));
    assert!(!quits(&fx) && app.ui.confirm.is_some());
    let fx = key(&mut app, SECOND + 500_000, Key::ctrl('c'));
    assert!(quits(&fx) && app.quit);
    // More than 2 s apart: the second one does not force (the question is still there).
    let mut app = app_with(true);
    key(&mut app, SECOND, Key::ctrl('c'));
    let fx = key(&mut app, 3 * SECOND + 500_000, Key::ctrl('c'));
    assert!(!quits(&fx) && !app.quit);
    // Disarmed: one Ctrl-C quits, as ever.
    let mut app = app_with(false);
    assert!(quits(&key(&mut app, SECOND, Key::ctrl('c'))));
}

/// sim:// (ArduCopter) after its GPS fix and home (6 s).
fn runner() -> VirtualRunner {
    let spec: LinkSpec = "sim://?sysid=1".parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    r.advance_to(6 * SECOND);
    r
}

/// Message ids of what an operator sends: COMMAND_INT, COMMAND_LONG, SET_MODE.
const OPERATOR_IDS: [u32; 3] = [75, 76, 11];

/// The operator's commands sent since the last call, read by pymavlink (automatic requests —
/// message intervals, REQUEST_MESSAGE, capabilities, streams — left out).
fn sent(r: &mut VirtualRunner) -> Vec<Value> {
    let frames: Vec<Vec<u8>> = r.take_sent().into_iter().map(|(_, _, f)| f).collect();
    common::operator_messages(&frames, &OPERATOR_IDS)
}

/// Home, a take-off to 20 m (relative frame 3) and two waypoints at 25 m.
const MISSION: &str = "QGC WPL 110\n\
0\t1\t0\t16\t0\t0\t0\t0\t-35.3632621\t149.1652374\t584\t1\n\
1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t20\t1\n\
2\t0\t3\t16\t0\t0\t0\t0\t-35.3622621\t149.1652374\t25\t1\n\
3\t0\t3\t16\t0\t0\t0\t0\t-35.3622621\t149.1662374\t25\t1\n";

#[test]
fn wp_start_disarmed_asks_once_then_guided_arm_takeoff_auto_start() {
    let mut r = runner();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.waypoints");
    std::fs::write(&path, MISSION).unwrap();
    command(&mut r, &format!("wp load {}", path.display()));
    wait(&mut r, 0.1);
    command(&mut r, "wp upload");
    wait(&mut r, 3.0);
    let known = r.app.sessions[&mavterm::proto::vehicles::VehicleKey(1, 1)]
        .mission
        .known(mavterm::mission::MissionType::Mission)
        .map(|k| k.items.len());
    assert_eq!(known, Some(4), "uploaded: {:?}", r.app.ui.message);
    r.capture_sent();
    command(&mut r, "wp start");
    let q = r
        .app
        .ui
        .confirm
        .clone()
        .unwrap_or_else(|| panic!("not asked: {:?}", r.app.ui.message));
    assert_eq!(
        q.text,
        "1:1 is disarmed: GUIDED, arm, take off to 20 m, AUTO, start mission? y/n"
    );
    wait(&mut r, 0.5);
    assert!(sent(&mut r).is_empty(), "nothing before the answer");
    keys(&mut r, &["y"]);
    wait(&mut r, 20.0);
    let out = sent(&mut r);
    let cmds: Vec<&Value> = out
        .iter()
        .filter(|m| m["name"] == "COMMAND_LONG" || m["name"] == "COMMAND_INT")
        .collect();
    let seen: Vec<(u64, f64, f64, f64)> = cmds
        .iter()
        .map(|m| {
            (
                m["command"].as_u64().unwrap(),
                m["param1"].as_f64().unwrap(),
                m["param2"].as_f64().unwrap(),
                m["param7"].as_f64().unwrap_or(0.0),
            )
        })
        .collect();
    // MAV_CMD_DO_SET_MODE 176 (param1 MAV_MODE_FLAG_CUSTOM_MODE_ENABLED = 1, param2 the custom
    // mode: ArduCopter GUIDED = 4, AUTO = 3), COMPONENT_ARM_DISARM 400 (param1 1 = arm),
    // NAV_TAKEOFF 22 (param7 the altitude), MISSION_START 300.
    let order: Vec<u64> = seen.iter().map(|s| s.0).collect();
    assert_eq!(order, vec![176, 400, 22, 176, 300], "{out:?}");
    assert_eq!((seen[0].1, seen[0].2), (1.0, 4.0), "GUIDED: {out:?}");
    assert_eq!(seen[1].1, 1.0, "arm: {out:?}");
    assert_eq!(seen[2].3, 20.0, "take-off altitude: {out:?}");
    assert_eq!((seen[3].1, seen[3].2), (1.0, 3.0), "AUTO: {out:?}");
    assert!(out.iter().all(|m| m["name"] != "SET_MODE"), "{out:?}");
}

#[test]
fn wp_start_disarmed_without_a_mission_is_refused() {
    let mut r = runner();
    r.capture_sent();
    command(&mut r, "wp start");
    assert!(r.app.ui.confirm.is_none(), "{:?}", r.app.ui.confirm);
    let said = r.app.ui.message.clone().map(|m| m.1).unwrap_or_default();
    assert!(said.contains("no mission"), "{said}");
    wait(&mut r, 1.0);
    assert!(sent(&mut r).is_empty());
}

#[test]
fn our_own_notices_have_their_own_colour_in_the_source_column() {
    use ratatui::style::{Color, Modifier};
    let mut app = app_with(false);
    hear(
        &mut app,
        SECOND,
        &statustext(dialect::MavSeverity::MAV_SEVERITY_INFO, "Arming motors"),
    );
    // The cells of the source column (`word`) on the Messages row holding `needle`.
    let source = |theme: &Theme, needle: &str, word: &str| {
        let buf = render_to_buffer(&app, 80, 24, theme);
        let text = buffer_to_text(&buf);
        let (y, line) = text
            .lines()
            .enumerate()
            .find(|(_, l)| l.contains(needle))
            .unwrap_or_else(|| panic!("no {needle:?}:\n{text}"));
        let at = line
            .find(&format!(" {word} "))
            .unwrap_or_else(|| panic!("no {word:?} in {line:?}"));
        let x = line[..at].chars().count() + 1;
        (x..x + word.chars().count())
            .map(|x| buf[(x as u16, y as u16)].clone())
            .collect::<Vec<_>>()
    };
    // In colour: ours light blue, a vehicle's key dimmed grey.
    let colour = Theme::default();
    let ours = source(&colour, "vehicle 1:1 found", "mavterm");
    assert!(ours.iter().all(|c| c.fg == Color::LightBlue), "{ours:?}");
    let theirs = source(&colour, "Arming motors", "1:1");
    assert!(theirs.iter().all(|c| c.fg == Color::DarkGray), "{theirs:?}");
    // Under NO_COLOR: ours in italics, no colour; a vehicle's never in italics.
    let plain = Theme::from_no_color(Some("1".into()));
    let ours = source(&plain, "vehicle 1:1 found", "mavterm");
    assert!(
        ours.iter()
            .all(|c| c.modifier.contains(Modifier::ITALIC) && c.fg == Color::Reset),
        "{ours:?}"
    );
    let theirs = source(&plain, "Arming motors", "1:1");
    assert!(
        theirs
            .iter()
            .all(|c| !c.modifier.contains(Modifier::ITALIC) && c.fg == Color::Reset),
        "{theirs:?}"
    );
}

/// PX4 1:1, a quadrotor in HOLD (main mode 4 AUTO, sub mode 3 LOITER), or in `custom_mode`;
/// armed or not.
fn px4_heartbeat(armed: bool, custom_mode: u32) -> MavMessage {
    MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
        mavtype: dialect::MavType::MAV_TYPE_QUADROTOR,
        autopilot: dialect::MavAutopilot::MAV_AUTOPILOT_PX4,
        base_mode: dialect::MavModeFlag::from_bits_truncate(if armed { 129 } else { 1 }),
        system_status: dialect::MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
        custom_mode,
    })
}

const PX4_HOLD: u32 = 0x0304_0000;
const PX4_MISSION: u32 = 0x0404_0000;

/// The commands (id, param1, param2, param3) among what the core sent.
fn commands_sent(fx: &[Effect]) -> Vec<(u16, f32, f32, f32)> {
    common::sent_messages(fx)
        .into_iter()
        .filter_map(|m| match m {
            MavMessage::COMMAND_LONG(c) => Some((c.command as u16, c.param1, c.param2, c.param3)),
            MavMessage::COMMAND_INT(c) => Some((c.command as u16, c.param1, c.param2, c.param3)),
            _ => None,
        })
        .collect()
}

#[test]
fn wp_start_on_a_disarmed_px4_arms_then_switches_to_mission_mode() {
    use dialect::{MavCmd, MavResult};
    let mut app = App::new(AppConfig {
        links: vec!["x".into()],
        request_streams: false,
        fetch_params: false,
        ..AppConfig::default()
    });
    hear(&mut app, 0, &px4_heartbeat(false, PX4_HOLD));
    // The vehicle's mission, downloaded: two waypoints (PX4 holds no home item).
    let type_line = |app: &mut App, t: u64, line: &str| {
        let mut fx = app.update(t, Event::Key(Key::ch(':')));
        for c in line.chars() {
            fx.extend(app.update(t, Event::Key(Key::ch(c))));
        }
        fx.extend(app.update(t, Event::Key("enter".parse().unwrap())));
        fx
    };
    type_line(&mut app, SECOND, "wp download");
    hear(
        &mut app,
        SECOND + 100_000,
        &MavMessage::MISSION_COUNT(dialect::MISSION_COUNT_DATA {
            count: 2,
            target_system: 255,
            target_component: 190,
            ..Default::default()
        }),
    );
    for seq in 0..2u16 {
        hear(
            &mut app,
            SECOND + 200_000 + seq as u64 * 100_000,
            &MavMessage::MISSION_ITEM_INT(dialect::MISSION_ITEM_INT_DATA {
                seq,
                command: MavCmd::MAV_CMD_NAV_WAYPOINT,
                frame: dialect::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
                x: -353_632_621 + seq as i32 * 1000,
                y: 1_491_652_374,
                z: 20.0,
                autocontinue: 1,
                target_system: 255,
                target_component: 190,
                ..Default::default()
            }),
        );
    }
    let known = app.sessions[&mavterm::proto::vehicles::VehicleKey(1, 1)]
        .mission
        .known(mavterm::mission::MissionType::Mission)
        .map(|k| k.items.len());
    assert_eq!(known, Some(2), "{:?}", app.ui.action);
    hear(&mut app, 2 * SECOND, &px4_heartbeat(false, PX4_HOLD));

    // Asked once, naming PX4's way: arm, then MISSION mode (it starts the mission itself).
    let fx = type_line(&mut app, 2 * SECOND, "wp start");
    assert!(commands_sent(&fx).is_empty(), "nothing before the answer");
    let q = app.ui.confirm.clone().expect("asked");
    assert_eq!(q.text, "1:1 is disarmed: arm, MISSION? y/n");
    let fx = app.update(2 * SECOND + SECOND / 2, Event::Key(Key::ch('y')));
    // COMPONENT_ARM_DISARM (400), param1 1 = arm; nothing else yet.
    assert_eq!(commands_sent(&fx), vec![(400, 1.0, 0.0, 0.0)]);
    let mut fx = hear(
        &mut app,
        2_700_000,
        &MavMessage::COMMAND_ACK(dialect::COMMAND_ACK_DATA {
            command: MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            result: MavResult::MAV_RESULT_ACCEPTED,
            ..Default::default()
        }),
    );
    assert!(
        commands_sent(&fx).is_empty(),
        "the mode waits for the heartbeat: {fx:?}"
    );
    // Armed: then DO_SET_MODE (176) with PX4's encoding: param1 MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    // (1), param2 the main mode (4 AUTO), param3 the sub mode (4 MISSION).
    fx = hear(&mut app, 3 * SECOND, &px4_heartbeat(true, PX4_HOLD));
    assert_eq!(commands_sent(&fx), vec![(176, 1.0, 4.0, 4.0)]);
    hear(
        &mut app,
        3_100_000,
        &MavMessage::COMMAND_ACK(dialect::COMMAND_ACK_DATA {
            command: MavCmd::MAV_CMD_DO_SET_MODE,
            result: MavResult::MAV_RESULT_ACCEPTED,
            ..Default::default()
        }),
    );
    let fx = hear(&mut app, 4 * SECOND, &px4_heartbeat(true, PX4_MISSION));
    // No MISSION_START: PX4 flies the mission once armed in MISSION.
    assert!(commands_sent(&fx).is_empty(), "{fx:?}");
    let done = app.action_text().map(|(_, t)| t);
    assert_eq!(done.as_deref(), Some("mission start: done"));
    assert!(app.ui.action.as_ref().is_some_and(|a| a.done));
}
