//! Pane snapshots and layout robustness, with an `App` driven by real encoded frames.

mod ui_fixture;
use ui_fixture as common;

use mavterm::app::{App, Pane};
use mavterm::keymap::Mode;
use mavterm::proto::vehicles::VehicleKey;
use mavterm::ui::{self, buffer_to_text, Theme};
use ratatui::backend::TestBackend;
use ratatui::layout::Rect;
use ratatui::{Frame, Terminal};

type PaneFn = fn(&App, &mut Frame, Rect, &Theme);

fn draw(app: &App, w: u16, h: u16, f: impl Fn(&App, &mut Frame)) -> String {
    let mut t = Terminal::new(TestBackend::new(w, h)).unwrap();
    t.draw(|frame| f(app, frame)).unwrap();
    buffer_to_text(t.backend().buffer())
}

fn pane(app: &App, w: u16, h: u16, p: PaneFn) -> String {
    draw(app, w, h, |a, f| p(a, f, f.area(), &Theme::PLAIN))
}

const SIZES: [(u16, u16); 2] = [(80, 24), (200, 60)];

#[test]
fn vehicles_pane() {
    let d = common::scene();
    for (w, h) in SIZES {
        insta::assert_snapshot!(
            format!("vehicles_{w}x{h}"),
            pane(&d.app, w, h, ui::vehicles::render)
        );
    }
}

#[test]
fn links_pane() {
    let d = common::scene();
    for (w, h) in SIZES {
        insta::assert_snapshot!(
            format!("links_{w}x{h}"),
            pane(&d.app, w, h, ui::links::render)
        );
    }
}

#[test]
fn messages_pane() {
    let d = common::scene();
    for (w, h) in SIZES {
        insta::assert_snapshot!(
            format!("messages_{w}x{h}"),
            pane(&d.app, w, h, ui::messages::render)
        );
    }
}

#[test]
fn status_bar() {
    let d = common::scene();
    for (w, h) in SIZES {
        insta::assert_snapshot!(
            format!("status_{w}x{h}"),
            pane(&d.app, w, 1.min(h), ui::status::render)
        );
    }
    let empty = common::Drive::new(&common::LINKS);
    let text = pane(&empty.app, 80, 1, ui::status::render);
    assert!(text.contains("no target"), "{text}");
}

#[test]
fn full_screen() {
    let d = common::scene();
    for (w, h) in SIZES {
        insta::assert_snapshot!(format!("screen_{w}x{h}"), draw(&d.app, w, h, ui::render));
    }
}

/// The help's text at 80 columns, its lines joined with single spaces (wrapped descriptions
/// whole again).
fn help_text(app: &App) -> String {
    let lines = ui::help::help_lines(app, 78);
    let words: Vec<&str> = lines.iter().flat_map(|l| l.0.split_whitespace()).collect();
    words.join(" ")
}

#[test]
fn help_popup_lists_every_binding_of_the_active_keymap() {
    let mut d = common::scene();
    d.key(21 * mavterm::clock::SECOND, "?");
    assert_eq!(d.app.ui.mode, Mode::Help);
    for (w, h) in ISSUE_SIZES {
        insta::assert_snapshot!(format!("help_{w}x{h}"), draw(&d.app, w, h, ui::render));
    }
    let text = help_text(&d.app);
    for (action, _, desc) in mavterm::keymap::Action::ALL {
        // The replay keys are listed only while there is a replay link (none here).
        if action.is_replay() {
            assert!(!text.contains(desc), "{desc} listed");
            continue;
        }
        if let mavterm::keymap::Action::Screen(i) = action {
            // Only the screens this build has are listed.
            if mavterm::app::screen::by_action_index(*i as usize).is_none() {
                assert!(!text.contains(desc), "{desc} listed");
                continue;
            }
        }
        for key in d.app.keymap.keys_for(Mode::Normal, "overview", *action) {
            assert!(text.contains(&key.to_string()), "{key} missing");
        }
        let bound = !d
            .app
            .keymap
            .keys_for(Mode::Normal, "overview", *action)
            .is_empty();
        assert!(!bound || text.contains(desc), "{desc} missing");
    }
    // The popup follows the keymap in use.
    let vim =
        mavterm::keymap::Keymap::from_toml(include_str!("../keymaps/vim.toml"), "vim").unwrap();
    d.app.keymap = mavterm::keymap::Keymap::default().with_overrides(&vim);
    let text = help_text(&d.app);
    assert!(text.contains("k, up"), "{text}");
}

#[test]
fn no_panic_at_any_small_size() {
    let mut d = common::scene();
    for focus in Pane::ALL {
        d.app.ui.focus = focus;
        for help in [false, true] {
            d.app.ui.mode = if help { Mode::Help } else { Mode::Normal };
            for w in 0..=40 {
                for h in 0..=20 {
                    let mut t = Terminal::new(TestBackend::new(w, h)).unwrap();
                    t.draw(|f| ui::render(&d.app, f)).unwrap();
                }
            }
        }
    }
}

#[test]
fn focused_pane_survives_when_space_is_short() {
    let mut d = common::scene();
    d.app.ui.focus = Pane::Messages;
    // The Overview alone, 7 rows high (a terminal this small gets the too-small message).
    let text = pane(&d.app, 80, 7, ui::overview::render);
    assert!(text.contains("*Messages"), "{text}");
    assert!(text.contains("Crash: Disarming"), "{text}");
    // The others are reduced to a title line.
    assert!(text.contains("─ Vehicles (5)"), "{text}");
}

#[test]
fn no_color_theme_emits_no_colour() {
    use ratatui::style::Color;
    let d = common::scene();
    let mut t = Terminal::new(TestBackend::new(120, 40)).unwrap();
    t.draw(|f| ui::render_with(&d.app, f, &Theme::PLAIN))
        .unwrap();
    let buf = t.backend().buffer();
    assert!(buf
        .content()
        .iter()
        .all(|c| c.fg == Color::Reset && c.bg == Color::Reset));
    t.draw(|f| ui::render_with(&d.app, f, &Theme::default()))
        .unwrap();
    assert!(t
        .backend()
        .buffer()
        .content()
        .iter()
        .any(|c| c.fg != Color::Reset));
    assert_eq!(Theme::from_no_color(Some("1".into())), Theme::PLAIN);
    assert_eq!(Theme::from_no_color(Some("".into())), Theme::default());
    assert_eq!(Theme::from_no_color(None), Theme::default());
}

#[test]
fn idle_app_is_not_dirty_after_a_draw_within_the_same_second() {
    let mut d = common::scene();
    // The start of a second in which nothing times out (3:1 is lost at 21.04 s, the rest at 25 s),
    // so every step below stays within it.
    let t0 = 22 * mavterm::clock::SECOND;
    d.tick(t0);
    assert!(d.app.take_dirty(), "fresh state must be drawn");
    d.tick(t0 + 100_000);
    assert!(!d.app.take_dirty(), "nothing changed within the second");
    d.key(t0 + 200_000, "tab");
    assert!(d.app.take_dirty(), "a key changes the screen");
    d.tick(t0 + 300_000);
    assert!(!d.app.take_dirty());
    d.tick(t0 + mavterm::clock::SECOND);
    assert!(d.app.take_dirty(), "the clock on screen moved");
}

#[test]
fn scrolling_messages_moves_the_window() {
    let mut d = common::scene();
    d.app.ui.focus = Pane::Messages;
    let before = pane(&d.app, 80, 5, ui::messages::render);
    assert!(before.contains("Crash: Disarming"), "{before}");
    d.key(d.app.now, "up");
    d.key(d.app.now, "up");
    let after = pane(&d.app, 80, 5, ui::messages::render);
    assert!(!after.contains("Crash: Disarming"), "{after}");
    assert!(after.contains("paused ↓ 2 newer"), "{after}");
}

#[test]
fn any_key_closes_help_q_included() {
    let mut d = common::scene();
    let t = d.app.now;
    d.key(t, "?");
    assert_eq!(d.app.ui.mode, Mode::Help);
    d.key(t, "x"); // unbound
    assert_eq!(d.app.ui.mode, Mode::Normal);
    d.key(t, "?");
    d.key(t, "tab"); // bound: closes help, does not move focus
    assert_eq!(d.app.ui.mode, Mode::Normal);
    assert_eq!(d.app.ui.focus, Pane::Vehicles);
    // `q` closes the help and does not quit from it; the next `q` quits (1:1 is armed: after
    // its question's `y`).
    d.key(t, "?");
    d.key(t, "q");
    assert_eq!(d.app.ui.mode, Mode::Normal);
    assert!(!d.app.quit);
    d.key(t, "q");
    d.key(t + 500_000, "y");
    assert!(d.app.quit);
}

#[test]
fn home_and_end_jump_to_either_end() {
    let mut d = common::scene();
    let t = d.app.now;
    d.key(t, "end");
    assert_eq!(d.app.ui.vehicle_sel, d.app.vehicles.len() - 1);
    d.key(t, "home");
    assert_eq!(d.app.ui.vehicle_sel, 0);
    d.app.ui.focus = Pane::Messages;
    d.key(t, "home"); // oldest message
    assert_eq!(d.app.ui.msg_scroll, d.app.notices.len() - 1);
    let text = pane(&d.app, 80, 5, ui::messages::render);
    assert!(text.contains("link udpin:0.0.0.0:14550 up"), "{text}");
    d.key(t, "end");
    assert_eq!(d.app.ui.msg_scroll, 0);
}

/// The whitespace-separated cells of the first line containing `start`, borders dropped.
fn cells<'a>(text: &'a str, start: &str) -> Vec<&'a str> {
    let line = text
        .lines()
        .find(|l| l.contains(start))
        .unwrap_or_else(|| panic!("no line with {start:?} in\n{text}"));
    line.trim_matches(|c| c == '│' || c == '┃')
        .split_whitespace()
        .collect()
}

/// The scene after a long, lossy session: link 0 (expanded) with counters in the millions, a
/// CRC storm and 24,874 frames (12.3 MB) a second.
fn big_numbers() -> common::Drive {
    let mut d = common::scene();
    let l = &mut d.app.links[0];
    l.parser.crc_errors = 123_456;
    // The three whole seconds before now (20.9 s) that the rates average over.
    l.rate = Default::default();
    for s in 17..20 {
        l.rate.add(s * mavterm::clock::SECOND, 24_874, 12_345_678);
    }
    let s = &mut l.sources.get_mut(&VehicleKey(1, 1)).unwrap().seq;
    (s.received, s.lost, s.duplicates, s.reordered) = (1_234_567, 24_874, 12_345, 99_999);
    let s = &mut l.sources.get_mut(&VehicleKey(1, 154)).unwrap().seq;
    (s.received, s.lost, s.duplicates, s.reordered) = (98_765, 100_000, 0, 0);
    d
}

#[test]
fn links_pane_abbreviates_numbers_that_do_not_fit() {
    let d = big_numbers();
    for (w, h) in SIZES {
        insta::assert_snapshot!(
            format!("links_big_numbers_{w}x{h}"),
            pane(&d.app, w, h, ui::links::render)
        );
    }
    // 80 columns: numbers that fit are exact (LOST 24874, not `2487`); the others are
    // abbreviated, never cut. Loss: 124,874 / (1,333,332 + 124,874) = 8.6 %;
    // 24,874 / 1,259,441 = 2.0 %; 100,000 / 198,765 = 50 %.
    let text = pane(&d.app, 80, 24, ui::links::render);
    let row = cells(&text, "-0 udpin");
    // F/S B/S L10s LOSS CRC RX LOST DUP REO
    assert_eq!(
        row[row.len() - 9..],
        ["25k", "12.3M", "1.6%", "8.6%", "123k", "1.3M", "125k", "12k", "100k"],
        "{text}"
    );
    let row = cells(&text, "└ 1:1 ");
    assert_eq!(
        row[row.len() - 6..],
        ["1.9%", "2.0%", "1.2M", "24874", "12k", "100k"],
        "{text}"
    );
    let row = cells(&text, "└ 1:154");
    assert_eq!(
        row[row.len() - 6..],
        ["0.0%", "50%", "98765", "100k", "0", "0"],
        "{text}"
    );
    assert!(text.contains("12.3M"), "{text}");
    // Truncated text shows where it was cut.
    assert!(text.contains("-0 udpin:14550 …"), "{text}");
    assert!(text.contains("down: No su…"), "{text}");
    // 200 columns: wider columns, more numbers exact.
    let text = pane(&d.app, 200, 60, ui::links::render);
    let row = cells(&text, "-0 udpin");
    assert_eq!(
        row[row.len() - 9..],
        ["24874", "12.3M", "1.6%", "8.6%", "123k", "1333332", "125k", "12k", "99999"],
        "{text}"
    );
}

/// The scene 640 s later: everything long lost; 1:1 also heard on links 1 and 2; 255:1 both on
/// our GCS sysid and in a clash.
fn long_ago() -> common::Drive {
    let mut d = common::scene();
    let t = 21 * mavterm::clock::SECOND;
    d.send(t, 1, (1, 1), &common::copter(true, 4));
    d.send(t, 2, (1, 1), &common::copter(true, 4));
    d.send(t + 10_000, 1, (255, 1), &common::plane(false, 0));
    d.tick(t + 640 * mavterm::clock::SECOND);
    d
}

#[test]
fn vehicles_pane_fits_long_ages_and_marks_cut_text() {
    let d = long_ago();
    for (w, h) in SIZES {
        insta::assert_snapshot!(
            format!("vehicles_long_ago_{w}x{h}"),
            pane(&d.app, w, h, ui::vehicles::render)
        );
    }
    let text = pane(&d.app, 80, 24, ui::vehicles::render);
    // LAST HB HZ LINK FLAGS: 640 s is `10m40s`, never `lost 640s ag`.
    let row = cells(&text, "1:1 ");
    assert_eq!(
        row[row.len() - 4..],
        ["lost", "10m40s", "1.0", "udpin:1455…"],
        "{text}"
    );
    // 2:1 was last heard at 8.02 s: 652.98 s ago.
    assert!(text.contains("lost 10m53s"), "{text}");
    assert!(text.contains("GCSID…"), "{text}");
    let text = pane(&d.app, 200, 60, ui::vehicles::render);
    let row = cells(&text, "1:1 ");
    assert_eq!(
        row[row.len() - 4..],
        [
            "lost",
            "10m40s",
            "1.0",
            "udpin:14550,tcp:5760,serial:ttyUSB0"
        ],
        "{text}"
    );
    assert!(text.contains("GCS SYSID! CLASH: 255:1 heard as"), "{text}");
}

#[test]
fn scrolling_back_does_not_hide_the_newest_when_all_messages_fit() {
    let mut d = common::scene();
    d.app.ui.focus = Pane::Messages;
    let len = d.app.notices.len();
    let before = pane(&d.app, 80, 24, ui::messages::render);
    d.key(d.app.now, "up");
    d.key(d.app.now, "up");
    assert_eq!(d.app.ui.msg_scroll, 2);
    // All 17 fit in 22 rows: nothing to scroll, the pane is unchanged.
    assert!(len <= 22, "{len}");
    let after = pane(&d.app, 80, 24, ui::messages::render);
    assert_eq!(after, before);
    assert!(after.contains("Crash: Disarming"), "{after}");
    assert!(!after.contains("paused"), "{after}");
    // One row short of fitting: scrolling goes back by at most that one line.
    let h = len as u16 + 1; // borders + all but one line
    let text = pane(&d.app, 80, h, ui::messages::render);
    assert!(text.contains("paused ↓ 1 newer"), "{text}");
    assert!(!text.contains("Crash: Disarming"), "{text}");
    assert!(text.contains("link udpin:0.0.0.0:14550 up"), "{text}");
    d.key(d.app.now, "end");
    let text = pane(&d.app, 80, h, ui::messages::render);
    assert!(text.contains("Crash: Disarming"), "{text}");
    assert!(!text.contains("link udpin:0.0.0.0:14550 up"), "{text}");
}

const ISSUE_SIZES: [(u16, u16); 3] = [(60, 20), (80, 24), (200, 60)];

/// The scene with the Messages pane focused by its keys.
fn messages_focused() -> common::Drive {
    let mut d = common::scene();
    let t = d.app.now;
    d.key(t, "tab");
    d.key(t, "tab");
    assert_eq!(d.app.ui.focus, Pane::Messages);
    d
}

/// The text lines of the Messages pane (`HH:MM:SS SEV source text`), borders dropped.
fn message_lines(text: &str) -> Vec<String> {
    text.lines()
        .map(|l| l.trim_matches(|c| c == '│' || c == '┃' || c == ' '))
        .filter(|l| l.len() > 9 && l.as_bytes()[2] == b':' && l.as_bytes()[5] == b':')
        .map(str::to_string)
        .collect()
}

#[test]
fn messages_filter_by_severity_from_keys() {
    let mut d = messages_focused();
    let t = d.app.now;
    // all -> INFO+ -> NOTICE+ -> WARN+: of the scene's 17 messages, 7 are WARN or worse
    // (RFC-5424 severities 0 to 4): EMERG, CRIT, ERROR x2, WARN x3.
    for _ in 0..3 {
        d.key(t, "s");
    }
    for (w, h) in ISSUE_SIZES {
        insta::assert_snapshot!(
            format!("messages_warn_{w}x{h}"),
            draw(&d.app, w, h, ui::render)
        );
    }
    let text = pane(&d.app, 80, 24, ui::messages::render);
    let lines = message_lines(&text);
    assert!(text.contains("Messages (7 of 17) WARN+"), "{text}");
    assert_eq!(lines.len(), 7, "{text}");
    for l in &lines {
        let sev = l.split_whitespace().nth(1).unwrap();
        assert!(
            ["EMERG", "ALERT", "CRIT", "ERROR", "WARN"].contains(&sev),
            "{l}"
        );
    }
    // ERROR+ drops the warnings; once more wraps round to all; `S` steps back.
    d.key(t, "s");
    let text = pane(&d.app, 80, 24, ui::messages::render);
    assert!(text.contains("(4 of 17) ERROR+"), "{text}");
    assert!(!text.contains("Battery 1 is low"), "{text}");
    d.key(t, "s");
    assert!(pane(&d.app, 80, 24, ui::messages::render).contains("Messages (17) "));
    d.key(t, "S");
    assert!(pane(&d.app, 80, 24, ui::messages::render).contains("(4 of 17) ERROR+"));
}

#[test]
fn messages_filter_by_vehicle_from_keys() {
    let mut d = messages_focused();
    let t = d.app.now;
    // all -> the target's (1:1, so system 1: the copter and its gimbal 1:154).
    d.key(t, "v");
    for (w, h) in ISSUE_SIZES {
        insta::assert_snapshot!(
            format!("messages_target_{w}x{h}"),
            draw(&d.app, w, h, ui::render)
        );
    }
    let text = pane(&d.app, 80, 24, ui::messages::render);
    assert!(text.contains("target 1"), "{text}");
    let lines = message_lines(&text);
    assert_eq!(lines.len(), 8, "{text}");
    // A vehicle's own lines name it as their source; mavterm's own about it say `mavterm`.
    let about = |l: &str, sys: &str| {
        let src = l.split_whitespace().nth(2).unwrap();
        src.starts_with(&format!("{sys}:")) || (src == "mavterm" && l.contains(&format!("{sys}:")))
    };
    for l in &lines {
        assert!(about(l, "1"), "{l}");
    }
    // The target filter follows the target: on 2:1 it shows system 2's.
    d.key(t, "n");
    let text = pane(&d.app, 80, 24, ui::messages::render);
    assert!(text.contains("target 2"), "{text}");
    assert!(message_lines(&text).iter().all(|l| about(l, "2")));
    // Then each system id heard (1, 2, 3, 255), then all again; `V` steps back.
    for sys in ["1", "2", "3", "255"] {
        d.key(t, "v");
        let text = pane(&d.app, 80, 24, ui::messages::render);
        assert!(text.contains(&format!(" sys {sys} ")), "{text}");
        assert!(message_lines(&text).iter().all(|l| about(l, sys)));
    }
    d.key(t, "v");
    assert!(pane(&d.app, 80, 24, ui::messages::render).contains("Messages (17) "));
    d.key(t, "V");
    assert!(pane(&d.app, 80, 24, ui::messages::render).contains(" sys 255 "));
    // Both filters at once.
    d.key(t, "s");
    d.key(t, "s");
    d.key(t, "s");
    let text = pane(&d.app, 80, 24, ui::messages::render);
    assert!(text.contains("(1 of 17) WARN+ sys 255"), "{text}");
}

#[test]
fn message_filter_keys_need_the_messages_pane_focused() {
    let mut d = common::scene();
    let t = d.app.now;
    assert_eq!(d.app.ui.focus, Pane::Vehicles);
    d.key(t, "s");
    d.key(t, "v");
    let text = pane(&d.app, 80, 24, ui::messages::render);
    assert!(text.contains("Messages (17) "), "{text}");
    let status = pane(&d.app, 80, 1, ui::status::render);
    assert!(status.contains("focus the Messages pane"), "{status}");
}

#[test]
fn messages_follow_the_newest_until_scrolled_back_and_end_follows_again() {
    use mavterm::dialect::MavSeverity::*;
    let mut d = messages_focused();
    let h = 8; // 6 lines of 17
    let newest = |text: &str| message_lines(text).last().cloned().unwrap();
    let text = pane(&d.app, 80, h, ui::messages::render);
    assert!(newest(&text).contains("Crash: Disarming"), "{text}");
    // A new message while following: it is the bottom line.
    let mut t = d.app.now + 1000;
    d.send(t, 0, (1, 1), &common::statustext(MAV_SEVERITY_INFO, "one"));
    let text = pane(&d.app, 80, h, ui::messages::render);
    assert!(newest(&text).ends_with("one"), "{text}");
    assert!(!text.contains("paused"), "{text}");
    // Scrolled back two lines: the view stays on the same lines while messages come.
    d.key(t, "up");
    d.key(t, "up");
    let paused = pane(&d.app, 80, h, ui::messages::render);
    assert!(paused.contains("paused ↓ 2 newer"), "{paused}");
    let view = message_lines(&paused);
    for text in ["two", "three"] {
        t += 1000;
        d.send(t, 0, (1, 1), &common::statustext(MAV_SEVERITY_INFO, text));
    }
    let text = pane(&d.app, 80, h, ui::messages::render);
    assert_eq!(message_lines(&text), view, "{text}");
    assert!(text.contains("paused ↓ 4 newer"), "{text}");
    for (w, hh) in ISSUE_SIZES {
        // The 200x60 pane holds every message: nothing to scroll back there, so it follows.
        insta::assert_snapshot!(
            format!("messages_paused_{w}x{hh}"),
            draw(&d.app, w, hh, ui::render)
        );
    }
    // A message the filter hides does not count.
    t += 1000;
    d.send(
        t,
        0,
        (1, 1),
        &common::statustext(MAV_SEVERITY_DEBUG, "hidden"),
    );
    d.key(t, "s"); // INFO+: a new filter follows the newest again
    let text = pane(&d.app, 80, h, ui::messages::render);
    assert!(newest(&text).ends_with("three"), "{text}");
    d.key(t, "up");
    t += 1000;
    d.send(
        t,
        0,
        (1, 1),
        &common::statustext(MAV_SEVERITY_DEBUG, "hidden too"),
    );
    let text = pane(&d.app, 80, h, ui::messages::render);
    assert!(text.contains("paused ↓ 1 newer"), "{text}");
    // `end` follows again: the newest is the bottom line.
    d.key(t, "end");
    let text = pane(&d.app, 80, h, ui::messages::render);
    assert!(newest(&text).ends_with("three"), "{text}");
    assert!(!text.contains("paused"), "{text}");
    // Scrolling down to the bottom follows again too.
    d.key(t, "pageup");
    d.key(t, "down");
    assert!(pane(&d.app, 80, h, ui::messages::render).contains("paused"));
    d.key(t, "pagedown");
    t += 1000;
    d.send(t, 0, (1, 1), &common::statustext(MAV_SEVERITY_INFO, "four"));
    let text = pane(&d.app, 80, h, ui::messages::render);
    assert!(newest(&text).ends_with("four"), "{text}");
    assert!(!text.contains("paused"), "{text}");
}

/// Every screen's help, for every width from 20 to 200 columns.
#[test]
fn every_help_line_fits_and_nothing_is_cut() {
    let mut d = common::scene();
    for screen in mavterm::keymap::SCREENS {
        d.app.ui.screen = mavterm::app::screen::by_name(screen).unwrap().name;
        for inner in [18, 38, 58, 78] {
            let lines = ui::help::help_lines(&d.app, inner);
            for (l, _) in &lines {
                assert!(l.chars().count() <= inner, "{screen} at {inner}: {l:?}");
                // No `…` but the Parameters marks' own and the commands' `ARGS …`.
                let own = l.contains("… edit sent") || l.contains(" …");
                assert!(!l.contains('…') || own, "{l:?}");
            }
            // Every description is there in full, its words in order.
            // (A word longer than the column is cut in pieces: compared without spaces.)
            let all: String = lines.iter().flat_map(|l| l.0.split_whitespace()).collect();
            for g in ui::help::help_groups(&d.app) {
                for (keys, desc) in &g.rows {
                    if inner >= 38 {
                        let want: String = desc.split_whitespace().collect();
                        assert!(all.contains(&want), "{screen} at {inner}: {desc}");
                        let keys: String = keys.split_whitespace().collect();
                        assert!(all.contains(&keys), "{screen}: {keys}");
                    }
                }
            }
        }
        // Drawn at 80 columns and wider, the popup is at most 80 wide: no line is cut at 80.
        for w in [80u16, 120, 200] {
            d.app.ui.mode = Mode::Help;
            let text = draw(&d.app, w, 60, ui::render);
            let top = text.lines().find(|l| l.contains("┌ Keys")).unwrap();
            let popup: String = top[top.find("┌ Keys").unwrap()..]
                .chars()
                .scan(false, |done, c| {
                    let keep = !*done;
                    *done |= c == '┐';
                    keep.then_some(c)
                })
                .collect();
            assert!(popup.ends_with('┐'), "{popup}");
            assert!(popup.chars().count() <= 80, "{screen} at {w}: {popup}");
        }
    }
}

#[test]
fn help_lists_keys_everywhere_first_then_the_screen_then_flight() {
    let d = common::scene();
    let groups = ui::help::help_groups(&d.app);
    let headings: Vec<&str> = groups.iter().map(|g| g.heading.as_str()).collect();
    assert_eq!(
        headings,
        [
            "Everywhere",
            "Overview screen",
            "Flying the target",
            "Commands (: opens the prompt)"
        ]
    );
    let descs = |i: usize| -> Vec<&str> { groups[i].rows.iter().map(|r| r.1).collect() };
    let everywhere = descs(0);
    assert_eq!(everywhere[0], "show the overview screen");
    assert_eq!(everywhere.last(), Some(&"quit mavterm"));
    let pos = |d: &str| everywhere.iter().position(|x| *x == d).unwrap();
    assert!(pos("show the camera screen") < pos("move the selection up"));
    assert!(pos("move the selection up") < pos("open the : command line"));
    assert!(pos("open the : command line") < pos("show/hide key help"));
    let overview: Vec<&str> = groups[1].rows.iter().map(|r| r.0.as_str()).collect();
    assert_eq!(
        overview,
        ["tab", "backtab", "enter, space", "s", "S", "v", "V"]
    );
    let flight: Vec<&str> = groups[2].rows.iter().map(|r| r.0.as_str()).collect();
    assert_eq!(flight, ["A", "D", "T", "L", "R", "M", "F"]);
}

#[test]
fn help_footer_names_the_scroll_keys_and_any_other_key_closes() {
    let mut d = common::scene();
    let t = d.app.now;
    d.key(t, "?");
    let text = draw(&d.app, 80, 24, ui::render);
    assert!(
        text.contains("up down pageup pagedown home end scroll; other keys close"),
        "{text}"
    );
    // A scroll key scrolls and keeps the help open; esc, ?, q, a letter all close it.
    d.key(t, "pagedown");
    assert_eq!(d.app.ui.mode, Mode::Help);
    assert!(draw(&d.app, 80, 24, ui::render).contains("┌ Keys (11/"));
    d.key(t, "esc");
    assert_eq!(d.app.ui.mode, Mode::Normal);
    for k in ["?", "q", "z", "enter", "1", "tab"] {
        d.key(t, "?");
        assert_eq!(d.app.ui.mode, Mode::Help);
        d.key(t, k);
        assert_eq!(d.app.ui.mode, Mode::Normal, "{k}");
        assert!(!d.app.quit, "{k}");
        assert_eq!(d.app.ui.screen, "overview", "{k}");
    }
}

/// Where `needle` starts on screen: (column, row) of its first character.
fn find(buf: &ratatui::buffer::Buffer, needle: &str) -> (u16, u16) {
    for y in 0..buf.area.height {
        let row: Vec<char> = (0..buf.area.width)
            .map(|x| buf[(x, y)].symbol().chars().next().unwrap_or(' '))
            .collect();
        let want: Vec<char> = needle.chars().collect();
        if let Some(x) = row.windows(want.len()).position(|w| w == want.as_slice()) {
            return (x as u16, y);
        }
    }
    panic!("{needle:?} not on screen");
}

/// The panes' colours and attributes, cell by cell: headers, the selected row's highlight over
/// the whole row, row styles (the target in bold, a lost vehicle and a link's sources dimmed),
/// cell styles (ARMED, a link's state, a message's severity) and the focused pane's border.
#[test]
fn panes_keep_their_styles() {
    use ratatui::style::{Color, Modifier};
    let mut d = common::scene();
    d.app.ui.focus = Pane::Vehicles;
    d.app.ui.vehicle_sel = 0;
    let theme = Theme::default();
    let buf = ui::render_to_buffer(&d.app, 100, 40, &theme);
    let at = |needle: &str| {
        let (x, y) = find(&buf, needle);
        buf[(x, y)].clone()
    };
    let fg_mod = |c: &ratatui::buffer::Cell| (c.fg, c.modifier);

    // Vehicles, focused: a thick cyan border, a bold yellow header.
    let (bx, by) = find(&buf, "┏ *Vehicles");
    assert_eq!(fg_mod(&buf[(bx, by)]), (Color::Cyan, Modifier::BOLD));
    let head = at("TYPE");
    assert_eq!(fg_mod(&head), (Color::Yellow, Modifier::BOLD));
    // The selected row (the target, armed): reversed from edge to edge inside the border, in
    // bold; ARMED red on top.
    let (_, sel_y) = find(&buf, "> 1:1");
    for x in bx + 1..bx + 99 {
        let c = &buf[(x, sel_y)];
        assert!(
            c.modifier.contains(Modifier::REVERSED | Modifier::BOLD),
            "{x}: {c:?}"
        );
    }
    assert!(!buf[(bx, sel_y)].modifier.contains(Modifier::REVERSED));
    let armed = at("ARMED ");
    assert_eq!(armed.fg, Color::Yellow, "the header's ARMED comes first");
    let (ax, _) = find(&buf, "ARMED ");
    let armed_row = &buf[(ax, sel_y)];
    assert_eq!(armed_row.symbol(), "A");
    assert_eq!(armed_row.fg, Color::Red);
    assert!(armed_row
        .modifier
        .contains(Modifier::REVERSED | Modifier::BOLD));
    // A lost vehicle's row is dim, not highlighted.
    let (lx, ly) = find(&buf, "lost 13s");
    assert_eq!(fg_mod(&buf[(lx, ly)]), (Color::DarkGray, Modifier::empty()));
    assert_eq!(buf[(bx + 1, ly)].fg, Color::DarkGray);

    // Links, not focused: a plain grey border, no highlight, a source row dimmed, a link up in
    // green, down in bold red.
    let (lbx, lby) = find(&buf, "┌ Links");
    assert_eq!(
        fg_mod(&buf[(lbx, lby)]),
        (Color::DarkGray, Modifier::empty())
    );
    assert_eq!(fg_mod(&at("STATE")), (Color::Yellow, Modifier::BOLD));
    let (sx, sy) = find(&buf, "└ 1:154");
    assert_eq!(buf[(sx, sy)].fg, Color::DarkGray);
    assert_eq!(buf[(lbx + 1, sy)].fg, Color::DarkGray);
    assert_eq!(fg_mod(&at("up ")), (Color::Green, Modifier::empty()));
    assert_eq!(fg_mod(&at("down: ")), (Color::Red, Modifier::BOLD));
    let (_, link0) = find(&buf, "-0 udpin");
    assert!(!buf[(lbx + 1, link0)].modifier.contains(Modifier::REVERSED));

    // Messages: the time dim, the severity's colour on its label and text, ours in light blue.
    let (px, py) = find(&buf, "CRIT   1:1     PreArm");
    assert_eq!(fg_mod(&buf[(px, py)]), (Color::Magenta, Modifier::BOLD));
    assert_eq!(buf[(px - 2, py)].fg, Color::DarkGray);
    assert_eq!(
        buf[(px + 6, py)].fg,
        Color::Reset,
        "the space between is unstyled"
    );
    let (tx, _) = find(&buf, "PreArm");
    assert_eq!(fg_mod(&buf[(tx, py)]), (Color::Magenta, Modifier::BOLD));
    assert_eq!(
        fg_mod(&at("mavterm link")),
        (Color::LightBlue, Modifier::empty())
    );
}
