//! Every action's line on the status bar goes from *sent* to what came of it (accepted,
//! refused with the vehicle's reason, no answer, done with its figure) and stays until the next
//! action; `:messages` lists the results, newest last. Read on the screen (TestBackend text).

mod common;

use common::{command, hear, statustext, wait};

use mavterm::app::{App, AppConfig, Event};
use mavterm::dialect::{self, MavMessage};
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::keymap::Key;
use mavterm::link::LinkSpec;
use mavterm::ui::{buffer_to_text, render_to_buffer, Theme};

const SECOND: u64 = 1_000_000;

/// ArduCopter 1:1's HEARTBEAT in STABILIZE (0), disarmed.
fn heartbeat() -> MavMessage {
    MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
        mavtype: dialect::MavType::MAV_TYPE_QUADROTOR,
        autopilot: dialect::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode: dialect::MavModeFlag::from_bits_truncate(1),
        system_status: dialect::MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
        custom_mode: 0,
    })
}

/// An app on one link that has heard 1:1 (disarmed) at 0 s.
fn app() -> App {
    let mut app = App::new(AppConfig {
        links: vec!["x".into()],
        request_streams: false,
        fetch_params: false,
        ..AppConfig::default()
    });
    hear(&mut app, 0, &heartbeat());
    app
}

fn key(app: &mut App, now: u64, k: Key) {
    app.update(now, Event::Key(k));
}

/// Type `line` at the prompt at `now`.
fn run(app: &mut App, now: u64, line: &str) {
    key(app, now, Key::ch(':'));
    for c in line.chars() {
        key(app, now, Key::ch(c));
    }
    key(app, now, "enter".parse().unwrap());
}

fn screen(app: &App) -> String {
    buffer_to_text(&render_to_buffer(app, 160, 30, &Theme::PLAIN))
}

/// The status bar: the last line.
fn status(app: &App) -> String {
    screen(app)
        .lines()
        .last()
        .unwrap_or("")
        .trim_end()
        .to_string()
}

/// The status bar's part after the separator.
fn tail(app: &App) -> String {
    let s = status(app);
    s.split_once('│')
        .map_or(s.clone(), |(_, t)| t.trim().to_string())
}

fn runner_tail(r: &VirtualRunner) -> String {
    let s = buffer_to_text(&render_to_buffer(&r.app, 160, 30, &Theme::PLAIN));
    let s = s.lines().last().unwrap_or("").trim_end().to_string();
    s.split_once('│')
        .map_or(s.clone(), |(_, t)| t.trim().to_string())
}

/// A COMMAND_ACK from 1:1.
fn ack(command: dialect::MavCmd, result: dialect::MavResult) -> MavMessage {
    MavMessage::COMMAND_ACK(dialect::COMMAND_ACK_DATA {
        command,
        result,
        ..Default::default()
    })
}

/// Arm 1:1 from the prompt at `t`, answering its question 0.5 s later.
fn arm(app: &mut App, t: u64) {
    run(app, t, "arm");
    key(app, t + SECOND / 2, Key::ch('y'));
}

#[test]
fn a_refused_arm_shows_failed_with_the_vehicles_reason_until_the_next_action() {
    let mut app = app();
    arm(&mut app, SECOND);
    assert_eq!(tail(&app), "COMPONENT_ARM_DISARM: sent");
    // A key that starts nothing: the line waits on.
    key(&mut app, 1_600_000, Key::ch('j'));
    assert_eq!(tail(&app), "COMPONENT_ARM_DISARM: sent");
    hear(
        &mut app,
        1_700_000,
        &statustext(
            dialect::MavSeverity::MAV_SEVERITY_CRITICAL,
            "PreArm: Throttle below failsafe",
        ),
    );
    hear(
        &mut app,
        1_750_000,
        &ack(
            dialect::MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            dialect::MavResult::MAV_RESULT_FAILED,
        ),
    );
    let refused = "COMPONENT_ARM_DISARM to 1:1: FAILED (PreArm: Throttle below failsafe)";
    assert_eq!(tail(&app), refused);
    // It stays through keys that start nothing.
    key(&mut app, 2 * SECOND, Key::ch('j'));
    key(&mut app, 2 * SECOND, Key::ch('k'));
    assert_eq!(tail(&app), refused);
}

#[test]
fn a_reason_that_comes_after_the_refusal_joins_the_line() {
    let mut app = app();
    arm(&mut app, SECOND);
    hear(
        &mut app,
        1_700_000,
        &ack(
            dialect::MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            dialect::MavResult::MAV_RESULT_FAILED,
        ),
    );
    assert_eq!(tail(&app), "COMPONENT_ARM_DISARM to 1:1: FAILED");
    hear(
        &mut app,
        1_800_000,
        &statustext(
            dialect::MavSeverity::MAV_SEVERITY_CRITICAL,
            "Arm: AHRS: waiting for home",
        ),
    );
    let refused = "COMPONENT_ARM_DISARM to 1:1: FAILED (Arm: AHRS: waiting for home)";
    assert_eq!(tail(&app), refused);
    run(&mut app, 2 * SECOND, "messages");
    let s = screen(&app);
    assert!(s.contains("Outcomes"), "{s}");
    assert!(s.contains(&format!("00:00:01 {refused}")), "{s}");
}

#[test]
fn an_unanswered_arm_says_so() {
    let mut app = app();
    arm(&mut app, SECOND);
    // The vehicle stays in view but never answers.
    for i in 2..15 {
        hear(&mut app, i * SECOND, &heartbeat());
        app.update(i * SECOND + SECOND / 2, Event::Tick);
    }
    assert_eq!(
        tail(&app),
        "COMPONENT_ARM_DISARM to 1:1: no ACK (not resent: re-issue it if still wanted)"
    );
}

/// sim:// (ArduCopter), 2 s in: no GPS fix, no home yet (they come at 6 s).
fn sim_runner() -> VirtualRunner {
    let spec: LinkSpec = "sim://?sysid=1".parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    r.advance_to(2 * SECOND);
    r
}

fn runner_screen(r: &VirtualRunner) -> String {
    buffer_to_text(&render_to_buffer(&r.app, 160, 30, &Theme::PLAIN))
}

#[test]
fn on_the_sim_a_refused_take_off_then_an_accepted_arm_then_a_saved_parameter_file() {
    let mut r = sim_runner();
    // Before home, GUIDED's arming check refuses: the take-off stops at its arm step, with the
    // vehicle's reason.
    command(&mut r, "takeoff 10");
    common::yes(&mut r);
    assert_eq!(runner_tail(&r), "takeoff to 10 m: started");
    wait(&mut r, 3.0);
    let stopped = "takeoff 10 m (arm): FAILED; stopped (Arm: AHRS: waiting for home)";
    assert_eq!(runner_tail(&r), stopped);
    // After the fix: arming is accepted.
    wait(&mut r, 6.0);
    assert_eq!(runner_tail(&r), stopped, "no action since: the line stays");
    command(&mut r, "arm");
    common::yes(&mut r);
    assert_eq!(runner_tail(&r), "COMPONENT_ARM_DISARM: sent");
    wait(&mut r, 2.0);
    let armed = "COMPONENT_ARM_DISARM to 1:1: ACCEPTED";
    assert_eq!(runner_tail(&r), armed);
    // The parameters downloaded meanwhile: a save ends with the count and the file.
    wait(&mut r, 20.0);
    let p = std::env::temp_dir().join(format!("outcomes-{}.parm", std::process::id()));
    command(&mut r, &format!("param save {}", p.display()));
    wait(&mut r, 1.0);
    let text = std::fs::read_to_string(&p).unwrap();
    let n = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .count();
    assert_eq!(n, 1354, "the sim's parameters, one a line");
    let saved = format!("1354 parameters saved to {}", p.display());
    assert_eq!(runner_tail(&r), saved);
    std::fs::remove_file(&p).ok();
    // `:messages`: the results, newest last.
    command(&mut r, "messages");
    let s = runner_screen(&r);
    let at = |needle: &str| {
        s.find(needle)
            .unwrap_or_else(|| panic!("{needle:?} not listed:\n{s}"))
    };
    assert!(s.contains(" Outcomes "), "{s}");
    assert!(at(stopped) < at(armed) && at(armed) < at(&saved), "{s}");
    // Any key closes it.
    common::keys(&mut r, &["j"]);
    assert!(!runner_screen(&r).contains(" Outcomes "));
}

#[test]
fn a_mission_upload_ends_with_the_items_uploaded() {
    let mut r = sim_runner();
    wait(&mut r, 6.0);
    let path = common::test_path("data/missions/square.waypoints");
    command(&mut r, &format!("wp load {}", path.display()));
    command(&mut r, "wp upload");
    if r.app.ui.confirm.is_some() {
        common::yes(&mut r);
    }
    // The file's six lines (home and five items) go.
    assert_eq!(runner_tail(&r), "uploading 6 mission items to 1:1");
    wait(&mut r, 5.0);
    assert_eq!(runner_tail(&r), "6 mission items uploaded");
    command(&mut r, "messages");
    assert!(runner_screen(&r).contains("6 mission items uploaded"));
}

/// The whole screen at a size where the help fits unscrolled.
fn tall_screen(app: &App) -> String {
    buffer_to_text(&render_to_buffer(app, 200, 200, &Theme::PLAIN))
}

#[test]
fn messages_is_listed_in_help_completes_on_tab_and_has_a_key() {
    let mut app = app();
    arm(&mut app, SECOND);
    hear(
        &mut app,
        1_700_000,
        &ack(
            dialect::MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            dialect::MavResult::MAV_RESULT_ACCEPTED,
        ),
    );
    let accepted = "COMPONENT_ARM_DISARM to 1:1: ACCEPTED";
    assert_eq!(tail(&app), accepted);
    // `?` lists the command and its key.
    key(&mut app, 2 * SECOND, Key::ch('?'));
    let help = tall_screen(&app);
    // A row of the popup: its text inside the borders, by what it starts with.
    let row = |start: &str| {
        help.lines()
            .filter_map(|l| l.split('│').nth(2))
            .find(|l| l.starts_with(start))
            .unwrap_or_else(|| panic!("no row {start:?} in the help:\n{help}"))
            .to_string()
    };
    assert!(
        row(":messages ").contains("the results of the last 50 actions, newest last"),
        "{help}"
    );
    assert!(
        row("O ").contains("the results of the last actions, newest last (:messages)"),
        "{help}"
    );
    key(&mut app, 2 * SECOND, "esc".parse().unwrap());
    assert!(!tall_screen(&app).contains(" Keys "));
    // Tab completes the first word.
    key(&mut app, 3 * SECOND, Key::ch(':'));
    for c in "mess".chars() {
        key(&mut app, 3 * SECOND, Key::ch(c));
    }
    key(&mut app, 3 * SECOND, "tab".parse().unwrap());
    assert_eq!(app.ui.prompt.line.text, "messages ");
    assert!(status(&app).contains(":messages"), "{}", status(&app));
    key(&mut app, 3 * SECOND, "enter".parse().unwrap());
    let s = screen(&app);
    assert!(s.contains(" Outcomes "), "{s}");
    assert!(s.contains(&format!("00:00:01 {accepted}")), "{s}");
    key(&mut app, 4 * SECOND, Key::ch('j'));
    assert!(!screen(&app).contains(" Outcomes "));
    // `O` opens the same list, on any screen.
    for screen_key in ['1', '2', '3', '5'] {
        key(&mut app, 5 * SECOND, Key::ch(screen_key));
        key(&mut app, 5 * SECOND, Key::ch('O'));
        let s = screen(&app);
        assert!(s.contains(" Outcomes "), "screen {screen_key}: {s}");
        assert!(s.contains(&format!("00:00:01 {accepted}")), "{s}");
        key(&mut app, 5 * SECOND, "esc".parse().unwrap());
    }
}
