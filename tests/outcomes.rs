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
    tail(&r.app)
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

/// Arm 1:1 at 1 s; its COMMAND_ACK with `result` comes at 1.7 s.
fn arm_answered(app: &mut App, result: dialect::MavResult) {
    arm(app, SECOND);
    hear(
        app,
        1_700_000,
        &ack(dialect::MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, result),
    );
}

/// `:messages` typed at `now`: the screen with the list.
fn messages(app: &mut App, now: u64) -> String {
    run(app, now, "messages");
    screen(app)
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
    arm_answered(&mut app, dialect::MavResult::MAV_RESULT_FAILED);
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
    let s = messages(&mut app, 2 * SECOND);
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
    screen(&r.app)
}

/// `line` typed at the prompt (its question answered `y` when `confirm`), then `secs` of
/// virtual time: the status bar's action line right after it, and after the wait.
fn act(r: &mut VirtualRunner, line: &str, confirm: bool, secs: f64) -> (String, String) {
    command(r, line);
    if confirm {
        common::yes(r);
    }
    let sent = runner_tail(r);
    wait(r, secs);
    (sent, runner_tail(r))
}

#[test]
fn on_the_sim_a_refused_take_off_then_an_accepted_arm_then_a_saved_parameter_file() {
    let mut r = sim_runner();
    // Before home, GUIDED's arming check refuses: the take-off stops at its arm step, with the
    // vehicle's reason.
    let (started, done) = act(&mut r, "takeoff 10", true, 3.0);
    assert_eq!(started, "takeoff to 10 m: started");
    let stopped = "takeoff 10 m (arm): FAILED; stopped (Arm: AHRS: waiting for home)";
    assert_eq!(done, stopped);
    // After the fix: arming is accepted.
    wait(&mut r, 6.0);
    assert_eq!(runner_tail(&r), stopped, "no action since: the line stays");
    let (sent, done) = act(&mut r, "arm", true, 2.0);
    assert_eq!(sent, "COMPONENT_ARM_DISARM: sent");
    let armed = "COMPONENT_ARM_DISARM to 1:1: ACCEPTED";
    assert_eq!(done, armed);
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
    arm_answered(&mut app, dialect::MavResult::MAV_RESULT_ACCEPTED);
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

/// sim:// with its camera (1:100) and gimbal (AP_Mount on 1:1), 6 s in: both discovered.
fn camera_runner() -> VirtualRunner {
    let spec: LinkSpec = "sim://?camera=1".parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    r.advance_to(6 * SECOND);
    r
}

/// `:messages` on the runner: each of `lines` listed, in this order (a long one wraps in the
/// popup: its rows are read joined).
fn listed_in_order(r: &mut VirtualRunner, lines: &[&str]) {
    command(r, "messages");
    let s = runner_screen(r);
    let rows: Vec<Vec<char>> = s.lines().map(|l| l.chars().collect()).collect();
    let top = rows
        .iter()
        .position(|l| l.iter().collect::<String>().contains("┌ Outcomes"))
        .unwrap_or_else(|| panic!("no Outcomes popup:\n{s}"));
    let line: String = rows[top].iter().collect();
    let left = line[..line.find("┌ Outcomes").unwrap()].chars().count();
    let right = left
        + 1
        + rows[top][left + 1..]
            .iter()
            .position(|&c| c == '┐')
            .unwrap();
    let text = rows[top + 1..]
        .iter()
        .take_while(|l| l.get(left) == Some(&'│'))
        .map(|l| {
            l[left + 1..right]
                .iter()
                .collect::<String>()
                .trim()
                .to_string()
        })
        .collect::<Vec<_>>()
        .join(" ");
    let at = |needle: &str| {
        text.find(needle)
            .unwrap_or_else(|| panic!("{needle:?} not listed:\n{s}"))
    };
    for w in lines.windows(2) {
        assert!(at(w[0]) < at(w[1]), "{:?} before {:?}:\n{s}", w[0], w[1]);
    }
    common::keys(r, &["esc"]);
}

#[test]
fn camera_and_gimbal_commands_end_accepted_refused_or_with_their_images() {
    let mut r = camera_runner();
    let (sent, done) = act(&mut r, "camera mode video", false, 1.0);
    assert_eq!(sent, "camera 1:100 mode video: sent");
    let video = "camera 1:100 mode video: ACCEPTED";
    assert_eq!(done, video);
    let (_, done) = act(&mut r, "camera mode image", false, 1.0);
    assert_eq!(done, "camera 1:100 mode image: ACCEPTED");

    // A capture of three: accepted, then counted to its figure.
    let (sent, tail) = act(&mut r, "camera shoot 3 1", false, 1.5);
    assert_eq!(sent, "camera 1:100 shoot 3 every 1 s: sent");
    assert!(
        tail.starts_with("camera 1:100 shoot 3 every 1 s: ")
            && tail.ends_with(" of 3 images taken"),
        "{tail}"
    );
    wait(&mut r, 3.0);
    let three = "camera 1:100 shoot 3 every 1 s: 3 images taken";
    assert_eq!(runner_tail(&r), three);

    // Refused by the camera: a mode change while it takes images.
    let (_, done) = act(&mut r, "camera shoot 0 1", false, 1.0);
    let endless = "camera 1:100 shoot every 1 s until stopped: ACCEPTED";
    assert_eq!(done, endless);
    let (_, done) = act(&mut r, "camera mode video", false, 1.0);
    let refused = "camera 1:100 mode video: TEMPORARILY_REJECTED";
    assert_eq!(done, refused);
    // Keys that start nothing leave it.
    common::keys(&mut r, &["j", "k"]);
    assert_eq!(runner_tail(&r), refused);
    let (_, done) = act(&mut r, "camera stop", false, 1.0);
    assert_eq!(done, "camera 1:100 stop images: ACCEPTED");

    // The gimbal: pointed, accepted by its manager.
    let (sent, done) = act(&mut r, "gimbal -45 0", false, 1.0);
    assert_eq!(sent, "gimbal 1:1/1 pitch -45° yaw 0°: sent");
    let pointed = "gimbal 1:1/1 pitch -45° yaw 0°: ACCEPTED";
    assert_eq!(done, pointed);

    listed_in_order(&mut r, &[video, three, endless, refused, pointed]);
}

/// The sim after its parameters are in.
fn downloaded_sim() -> VirtualRunner {
    common::downloaded(sim_runner())
}

#[test]
fn a_parameter_edit_and_param_set_end_confirmed_by_the_echo() {
    let mut r = downloaded_sim();
    // On the Parameters screen: the value typed in place.
    common::keys(&mut r, &["2", "/", "ctrl-u"]);
    common::typed(&mut r, "PILOT_TKOFF_ALT");
    common::keys(&mut r, &["enter", "enter", "ctrl-u"]);
    common::typed(&mut r, "250");
    common::keys(&mut r, &["enter"]);
    assert_eq!(
        runner_tail(&r),
        "PILOT_TKOFF_ALT = 250: sent, waiting for the echo"
    );
    wait(&mut r, 1.0);
    let edited = "PILOT_TKOFF_ALT = 250 confirmed";
    assert_eq!(runner_tail(&r), edited);
    // It stays through keys that start nothing.
    common::keys(&mut r, &["j", "k"]);
    assert_eq!(runner_tail(&r), edited);
    // At the prompt.
    let (sent, done) = act(&mut r, "param set RTL_ALT 3000", false, 1.0);
    assert_eq!(sent, "RTL_ALT = 3000: sent, waiting for the echo");
    let set = "RTL_ALT = 3000 confirmed";
    assert_eq!(done, set);
    listed_in_order(&mut r, &[edited, set]);
}

#[test]
fn wp_download_set_current_and_clear_end_with_what_the_vehicle_did() {
    let mut r = sim_runner();
    wait(&mut r, 6.0);
    // Paths as typed, relative to where mavterm runs (the package, under cargo).
    let (_, done) = act(
        &mut r,
        "wp load tests/data/missions/square.waypoints",
        false,
        0.2,
    );
    let loaded = "6 mission items loaded from tests/data/missions/square.waypoints";
    assert_eq!(done, loaded);
    command(&mut r, "wp upload");
    if r.app.ui.confirm.is_some() {
        common::yes(&mut r);
    }
    wait(&mut r, 5.0);
    assert_eq!(runner_tail(&r), "6 mission items uploaded");

    let (sent, done) = act(&mut r, "wp download", false, 3.0);
    assert_eq!(sent, "downloading the mission of 1:1");
    let downloaded = "mission downloaded from 1:1: 6 items";
    assert_eq!(done, downloaded);

    let (sent, done) = act(&mut r, "wp set 2", false, 3.0);
    assert_eq!(sent, "current item 2: sent");
    let current = "1:1 is now at mission item 2";
    assert_eq!(done, current);

    let (sent, done) = act(&mut r, "wp clear", true, 3.0);
    assert_eq!(sent, "clearing the mission of 1:1");
    let cleared = "mission cleared on 1:1";
    assert_eq!(done, cleared);
    common::keys(&mut r, &["j", "k"]);
    assert_eq!(runner_tail(&r), cleared);

    listed_in_order(&mut r, &[loaded, downloaded, current, cleared]);
}

#[test]
fn a_file_read_ends_with_what_was_read_or_the_error_and_where() {
    let mut r = sim_runner();
    wait(&mut r, 4.0);
    // A mission file with bad lines: the first, by its line, and how many.
    let (_, done) = act(
        &mut r,
        "wp load tests/data/missions/bad-line.waypoints",
        false,
        0.2,
    );
    let bad_line = "line 4: 10 fields where 12 were expected in \
                    tests/data/missions/bad-line.waypoints (3 error(s): not uploaded)";
    assert_eq!(done, bad_line);
    // A file that is not there: why, and which.
    let (_, done) = act(&mut r, "param load /nonexistent/dir/x.parm", false, 0.2);
    let missing = "could not read /nonexistent/dir/x.parm: No such file or directory (os error 2)";
    assert_eq!(done, missing);
    // A parameter file compared: what it holds against the vehicle.
    wait(&mut r, 20.0);
    let (_, diffed) = act(
        &mut r,
        "param diff tests/data/copter-params.parm",
        false,
        0.2,
    );
    assert!(
        diffed.starts_with("tests/data/copter-params.parm: ") && diffed.contains(" changed, "),
        "{diffed}"
    );
    listed_in_order(&mut r, &[bad_line, missing, &diffed]);
}

#[test]
fn after_a_passing_message_a_key_shows_the_latest_actions_line() {
    let mut app = app();
    arm_answered(&mut app, dialect::MavResult::MAV_RESULT_ACCEPTED);
    assert_eq!(tail(&app), "COMPONENT_ARM_DISARM to 1:1: ACCEPTED");
    // A later action (a file read), done.
    run(&mut app, 2 * SECOND, "wp load /x/a.waypoints");
    assert_eq!(tail(&app), "reading /x/a.waypoints");
    app.update(
        2_100_000,
        Event::FileRead {
            path: "/x/a.waypoints".into(),
            purpose: mavterm::app::files::FileUse::Mission(mavterm::mission::MissionType::Mission),
            result: Err("No such file or directory (os error 2)".into()),
        },
    );
    let read = "could not read /x/a.waypoints: No such file or directory (os error 2)";
    assert_eq!(tail(&app), read);
    // A message that is no action passes with the next key; the line is the latest action's.
    run(&mut app, 3 * SECOND, "param encoding");
    assert_ne!(tail(&app), read);
    key(&mut app, 4 * SECOND, Key::ch('j'));
    assert_eq!(tail(&app), read);
}

#[test]
fn log_list_and_erase_end_with_the_logs_listed() {
    let mut r = sim_runner();
    let (sent, done) = act(&mut r, "log list", false, 3.0);
    assert_eq!(sent, "asking 1:1 for its logs");
    let listed = "1:1 has 3 logs";
    assert_eq!(done, listed);
    let (sent, done) = act(&mut r, "log erase", true, 5.0);
    assert_eq!(sent, "LOG_ERASE sent to 1:1; listing again");
    let erased = "logs erased on 1:1: none left";
    assert_eq!(done, erased);
    listed_in_order(&mut r, &[listed, erased]);
}
