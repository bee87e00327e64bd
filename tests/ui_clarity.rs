//! Operator clarity on every screen: the target's mode, arming, altitude and battery always in
//! view (the state strip above every screen but the Overview, the status bar keeping them
//! whatever the notice), the mode picker (`M`) listing every mode of the target, `tab` cycling
//! the modes at the prompt, Fly mode's keys in the help and on a line of their own, and cut
//! text ending in `…` at every width from 60 to 220 columns.

mod ui_fixture;
use ui_fixture as common;

use mavterm::app::{App, AppConfig, Effect, Event};
use mavterm::clock::{Micros, SECOND};
use mavterm::dialect::MavMessage;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::keymap::Mode;
use mavterm::link::LinkSpec;
use mavterm::ui::{self, buffer_to_text, Theme};

/// Mid-flight in the ArduCopter capture: hovering 10 m above home, armed in GUIDED, the
/// battery at 12.6 V and 97 % (SYS_STATUS of the capture, as pymavlink reads it).
const MID_FLIGHT: Micros = 56 * SECOND;

fn replay() -> VirtualRunner {
    let spec: LinkSpec = "tlog:tests/data/copter-flight.vehicle.tlog"
        .parse()
        .unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    r.advance_to(MID_FLIGHT);
    r
}

fn screen(app: &App, w: u16, h: u16) -> String {
    buffer_to_text(&ui::render_to_buffer(app, w, h, &Theme::PLAIN))
}

fn key(app: &mut App, k: &str) -> Vec<Effect> {
    let t = app.now;
    app.update(t, Event::Key(k.parse().unwrap()))
}

fn sent(fx: &[Effect]) -> Vec<MavMessage> {
    fx.iter()
        .filter_map(|e| match e {
            Effect::Send { msg, .. } => Some(msg.clone()),
            _ => None,
        })
        .collect()
}

fn names() -> Vec<&'static str> {
    mavterm::app::screen::SCREENS
        .iter()
        .map(|s| s.name)
        .collect()
}

#[test]
fn every_screen_at_every_width_keeps_the_state_and_the_width() {
    let mut r = replay();
    for name in names() {
        r.app.ui.screen = name;
        for w in 60..=220u16 {
            for h in [16u16, 24, 60] {
                let text = screen(&r.app, w, h);
                for line in text.lines() {
                    assert!(
                        line.chars().count() <= w as usize,
                        "{name} {w}x{h}: too long: {line}"
                    );
                }
                let lines: Vec<&str> = text.lines().collect();
                // The status bar: mode and arming, always.
                assert!(
                    lines[h as usize - 1].contains("1:1 GUIDED ARMED"),
                    "{name} {w}x{h}: {}",
                    lines[h as usize - 1]
                );
                if name == "overview" {
                    continue;
                }
                // The state strip on top: mode, arming, then altitude and battery whole.
                let strip = lines[0];
                assert!(
                    strip.starts_with("1:1 GUIDED ARMED"),
                    "{name} {w}x{h}: {strip}"
                );
                assert!(
                    strip.contains("ALT 10.0 m (rel)"),
                    "{name} {w}x{h}: {strip}"
                );
                assert!(strip.contains("BAT 12.6 V 97%"), "{name} {w}x{h}: {strip}");
            }
        }
    }
}

#[test]
fn state_strip_on_the_mission_screen() {
    let mut r = replay();
    r.app.ui.screen = "mission";
    let small = screen(&r.app, 80, 24);
    insta::assert_snapshot!("state_strip_mission_80x24", small);
    let big = screen(&r.app, 200, 60);
    insta::assert_snapshot!("state_strip_mission_200x60", big);
    assert_eq!(
        small.lines().next().unwrap(),
        "1:1 GUIDED ARMED  ALT 10.0 m (rel)  BAT 12.6 V 97%"
    );
}

#[test]
fn the_overview_says_which_altitude_is_which() {
    let r = replay();
    let text = screen(&r.app, 80, 24);
    let alt = text.lines().find(|l| l.starts_with("ALT")).unwrap();
    assert!(alt.starts_with("ALT 10.0 m (rel) 594.1 m AMSL"), "{alt}");
}

#[test]
fn a_long_notice_is_cut_never_the_state() {
    let mut d = common::scene();
    let long = "x".repeat(300);
    d.app.ui.message = Some((mavterm::wire::Severity::INFO, long));
    for w in [60u16, 80, 120, 200] {
        let text = screen(&d.app, w, 24);
        let bar = text.lines().last().unwrap();
        assert!(bar.contains("1:1 GUIDED ARMED"), "{w}: {bar}");
        assert!(bar.ends_with('…'), "{w}: {bar}");
    }
}

#[test]
fn mode_picker_lists_every_mode_filters_and_picks() {
    let mut d = common::scene();
    key(&mut d.app, "M");
    assert_eq!(d.app.ui.mode, Mode::Edit);
    let rows = d.app.mode_picker_rows();
    // ArduCopter's mode.h: every mode, loiter, RTL and land among them.
    for m in [
        "stabilize",
        "guided",
        "loiter",
        "rtl",
        "land",
        "smart_rtl",
        "turtle",
    ] {
        assert!(rows.iter().any(|r| r == m), "{m} in {rows:?}");
    }
    insta::assert_snapshot!("mode_picker_80x24", screen(&d.app, 80, 24));
    insta::assert_snapshot!("mode_picker_200x60", screen(&d.app, 200, 60));
    // Arrows move.
    key(&mut d.app, "down");
    key(&mut d.app, "down");
    assert_eq!(d.app.ui.mode_picker.as_ref().unwrap().sel, 2);
    key(&mut d.app, "up");
    assert_eq!(d.app.ui.mode_picker.as_ref().unwrap().sel, 1);
    // Typing filters, from the first match.
    for c in ["l", "o", "i"] {
        key(&mut d.app, c);
    }
    assert_eq!(d.app.mode_picker_rows(), ["loiter"]);
    assert_eq!(d.app.ui.mode_picker.as_ref().unwrap().sel, 0);
    let text = screen(&d.app, 80, 24);
    assert!(text.contains("> loi"), "{text}");
    assert!(text.contains("> loiter"), "{text}");
    // Enter asks for LOITER (5 in ArduCopter's mode.h) through the `mode` command.
    let fx = key(&mut d.app, "enter");
    assert!(d.app.ui.mode_picker.is_none());
    assert_eq!(d.app.ui.mode, Mode::Normal);
    let asked = sent(&fx).iter().any(|m| match m {
        MavMessage::COMMAND_LONG(c) => {
            c.command == mavterm::dialect::MavCmd::MAV_CMD_DO_SET_MODE && c.param2 == 5.0
        }
        _ => false,
    });
    assert!(asked, "{fx:?}");
    // Esc leaves without asking anything.
    key(&mut d.app, "M");
    let fx = key(&mut d.app, "esc");
    assert!(d.app.ui.mode_picker.is_none());
    assert_eq!(d.app.ui.mode, Mode::Normal);
    assert!(sent(&fx).is_empty(), "{fx:?}");
}

#[test]
fn tab_on_an_empty_mode_word_cycles_the_modes() {
    let mut d = common::scene();
    key(&mut d.app, ":");
    for c in "mode".chars() {
        key(&mut d.app, &c.to_string());
    }
    key(&mut d.app, "space");
    key(&mut d.app, "tab");
    assert_eq!(d.app.ui.prompt.line.text, "mode stabilize");
    let listed = &d.app.ui.message.as_ref().unwrap().1;
    assert!(
        listed.contains("loiter") && listed.contains("land"),
        "{listed}"
    );
    key(&mut d.app, "tab");
    assert_eq!(d.app.ui.prompt.line.text, "mode acro");
    // A started word still completes.
    key(&mut d.app, "ctrl-u");
    for c in "mode lo".chars() {
        key(
            &mut d.app,
            &if c == ' ' {
                "space".into()
            } else {
                c.to_string()
            },
        );
    }
    key(&mut d.app, "tab");
    assert_eq!(d.app.ui.prompt.line.text, "mode loiter ");
}

#[test]
fn help_lists_fly_mode_keys() {
    let mut d = common::scene();
    key(&mut d.app, "?");
    let lines = ui::help::help_lines(&d.app, 78);
    let at = lines
        .iter()
        .position(|l| l.0.starts_with("In Fly mode"))
        .expect("Fly mode keys in the help");
    let text: String = lines[at..at + 4]
        .iter()
        .map(|l| l.0.clone() + " ")
        .collect();
    for k in ["up/down", "w/s", "a/d", "1/2/3", "r/f", "esc leaves"] {
        assert!(text.contains(k), "{k}: {text}");
    }
    d.app.ui.help_scroll = at.saturating_sub(8);
    insta::assert_snapshot!("help_fly_keys_80x24", screen(&d.app, 80, 24));
    d.app.ui.help_scroll = 0;
    insta::assert_snapshot!("help_fly_keys_200x60", screen(&d.app, 200, 60));
}

#[test]
fn fly_mode_shows_its_keys_on_a_line_that_fits_80_columns() {
    let mut d = common::scene();
    key(&mut d.app, "F");
    assert!(d.app.fly_text().is_some(), "{:?}", d.app.ui.message);
    let text = screen(&d.app, 80, 24);
    let lines: Vec<&str> = text.lines().collect();
    let hint = lines[22];
    assert_eq!(
        hint,
        "FLY ←↑↓→ move  w/s up/down  a/d yaw  1/2/3 speed  r/f alt ±1 m  esc leaves"
    );
    assert!(lines[23].contains("1:1 GUIDED ARMED"), "{}", lines[23]);
}

#[test]
fn the_mission_title_is_cut_with_an_ellipsis() {
    let mut r = replay();
    r.app.ui.screen = "mission";
    let text = screen(&r.app, 60, 20);
    let title = text.lines().nth(1).unwrap();
    assert!(title.ends_with("…┐"), "{title}");
    assert_eq!(title.chars().count(), 60, "{title}");
}

#[test]
fn mission_command_names_take_the_room_there_is() {
    let mut r = replay();
    r.app.ui.screen = "mission";
    let line = ":wp load tests/data/missions/mission-planner.waypoints";
    for c in line.chars() {
        let k = if c == ' ' {
            "space".to_string()
        } else {
            c.to_string()
        };
        r.key(k.parse().unwrap());
    }
    r.key("enter".parse().unwrap());
    r.advance_to(MID_FLIGHT + SECOND);
    // Item 7 of the file is NAV_RETURN_TO_LAUNCH (20): whole where the row has room for it
    // and the other columns, cut with `…` where not.
    for w in [80, 200] {
        let text = screen(&r.app, w, 24);
        assert!(text.contains(" NAV_RETURN_TO_LAUNCH "), "{text}");
    }
    let narrow = screen(&r.app, 60, 24);
    let row = narrow.lines().find(|l| l.contains(" 7    NAV_")).unwrap();
    assert!(row.contains("NAV_RETUR") && row.contains('…'), "{narrow}");
}

/// STATUSTEXT `text` from 1:1 in chunks of 50 bytes (id 7), as ArduPilot sends a long text.
fn long_statustext(d: &mut common::Drive, t: Micros, text: &str) {
    let bytes = text.as_bytes();
    for (i, chunk) in bytes.chunks(50).enumerate() {
        let msg = MavMessage::STATUSTEXT(mavterm::dialect::STATUSTEXT_DATA {
            severity: mavterm::dialect::MavSeverity::MAV_SEVERITY_WARNING,
            text: std::str::from_utf8(chunk).unwrap().into(),
            id: 7,
            chunk_seq: i as u8,
        });
        d.send(t + i as u64 * 1000, 0, (1, 1), &msg);
    }
}

/// The row of the Messages pane holding `start`, at `w`x24.
fn message_row(app: &App, w: u16, start: &str) -> String {
    let text = screen(app, w, 24);
    text.lines()
        .find(|l| l.contains(start))
        .unwrap_or_else(|| panic!("no {start:?} at {w}:\n{text}"))
        .to_string()
}

#[test]
fn a_long_message_row_is_cut_with_an_ellipsis() {
    let mut d = common::Drive::new(&["udpin:0.0.0.0:14550"]);
    d.link_state(0, 0, mavterm::link::LinkState::Up);
    d.send(0, 0, (1, 1), &common::copter(false, 0));
    // 120 characters: more than a row of 80 columns holds after time, severity and source.
    let long = "PreArm: Compass not calibrated, Accels inconsistent by 1.25 m/s/s, \
                Gyros inconsistent by 5 deg/s, Check mag field (xy diff)";
    assert!(long.len() > 100 && long.len() < 150);
    long_statustext(&mut d, SECOND, long);
    d.tick(2 * SECOND);
    let row = message_row(&d.app, 80, "PreArm: Compass");
    assert_eq!(row.chars().count(), 80, "{row}");
    // `│12:00:01 WARN   1:1     ` takes 25 columns and the border 1: 53 of the text, then `…`.
    let shown: String = long.chars().take(80 - 24 - 2 - 1).collect();
    assert!(row.ends_with(&format!("{shown}…│")), "{row}");
    // Where it fits, it is whole.
    let wide = message_row(&d.app, 200, "PreArm: Compass");
    assert!(
        wide.contains(&format!("{long} ")) && !wide.contains('…'),
        "{wide}"
    );
    // Wide characters take two columns: the row still fits, and the cut shows.
    // Chunks of 50 bytes that end between characters: `0:` and 16 three-byte characters.
    let wide_text: String = (0..3)
        .map(|k| format!("{k}:高度センサー異常気圧計距離計値確"))
        .chain(["end".to_string()])
        .collect();
    assert_eq!(wide_text.len(), 153);
    long_statustext(&mut d, 3 * SECOND, &wide_text);
    d.tick(4 * SECOND);
    // (The text of a screen has one character a cell: a wide character's second cell is a
    // space.)
    let row = message_row(&d.app, 80, "0:高");
    assert_eq!(row.chars().count(), 80, "{row}");
    assert!(row.contains("1:高"), "{row}");
    assert!(row.trim_end_matches('│').trim_end().ends_with('…'), "{row}");
    assert!(!row.contains("2:高"), "{row}");
}
