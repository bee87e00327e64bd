//! Issue #15 "First contact": the Overview and the lists at 60x20, 80x24 and 200x60: the
//! selected link in full, ports before what gets cut, `…` wherever text is cut, `N of M, ↓ K
//! more` on lists that do not fit (scrolling with the selection), the too-small message, and the
//! links' short names in the Vehicles pane.

mod ui_fixture;
use ui_fixture as common;

use mavterm::app::{App, Pane};
use mavterm::ui::{self, buffer_to_text};
use ratatui::backend::TestBackend;
use ratatui::Terminal;

const SIZES: [(u16, u16); 3] = [(60, 20), (80, 24), (200, 60)];

fn screen(app: &App, w: u16, h: u16) -> String {
    let mut t = Terminal::new(TestBackend::new(w, h)).unwrap();
    t.draw(|f| ui::render_with(app, f, &ui::Theme::PLAIN))
        .unwrap();
    buffer_to_text(t.backend().buffer())
}

/// The screen's words in order, borders dropped, so text wrapped over lines reads as one.
fn words(text: &str) -> String {
    text.lines()
        .map(|l| l.trim_matches(|c| "│┃".contains(c)))
        .flat_map(str::split_whitespace)
        .collect::<Vec<_>>()
        .join(" ")
}

/// The screen's text without borders or white space, so text broken anywhere reads as one.
fn compact(text: &str) -> String {
    text.lines()
        .map(|l| l.trim_matches(|c| "│┃".contains(c)))
        .flat_map(str::split_whitespace)
        .collect()
}

/// The first line holding `needle`.
fn line_with<'a>(text: &'a str, needle: &str) -> &'a str {
    text.lines()
        .find(|l| l.contains(needle))
        .unwrap_or_else(|| panic!("no line with {needle:?} in\n{text}"))
}

/// The fixture with the down TCP link selected in the focused Links pane.
fn tcp_selected() -> common::Drive {
    let mut d = common::first_contact();
    let t = d.app.now;
    d.key(t, "tab");
    d.key(t, "down");
    assert_eq!(d.app.ui.focus, Pane::Links);
    assert_eq!(d.app.ui.link_sel, 1);
    d
}

#[test]
fn overview_shows_the_selected_link_in_full_and_tells_links_apart() {
    let d = tcp_selected();
    for (w, h) in SIZES {
        let text = screen(&d.app, w, h);
        insta::assert_snapshot!(format!("overview_{w}x{h}"), text);
        // The detail line: the full spec, then the full state with its reason (wrapped when
        // narrow).
        assert!(
            words(&text).contains(&format!("» 1 tcp:127.0.0.1:5761 down: {}", common::REFUSED)),
            "{w}x{h}:\n{text}"
        );
        // The port comes right after the scheme, before the host that may be cut.
        assert!(
            line_with(&text, " 1 tcp:5761 ").contains("down: "),
            "{text}"
        );
        // The two simulators differ only in their seed, and so do their names.
        assert!(text.contains("+2 sim?seed=1 "), "{w}x{h}:\n{text}");
        assert!(line_with(&text, " 2:1 ").contains(" sim?seed=2 "), "{text}");
        if w >= 80 {
            assert!(text.contains("+3 sim?seed=2 "), "{w}x{h}:\n{text}");
        }
    }
    // Wide, the table itself holds the whole reason.
    let text = screen(&d.app, 200, 60);
    assert!(
        line_with(&text, " 1 tcp:5761 127.0.0.1").contains(common::REFUSED),
        "{text}"
    );
    // Narrow, the reason is cut in the table, and says so.
    let text = screen(&d.app, 80, 24);
    let row = line_with(&text, " 1 tcp:5761 ");
    assert!(row.contains("down: Con") && row.contains('…'), "{row}");
}

#[test]
fn cut_text_ends_with_an_ellipsis_at_every_width() {
    let d = common::first_contact();
    for w in 60..=140u16 {
        let text = screen(&d.app, w, 40);
        // Every word of a vehicle row that starts like a type, mode or arming state is the
        // whole word or a cut one that says so.
        for line in text
            .lines()
            .filter(|l| l.contains("2:1 ") || l.contains("4:1 "))
        {
            for word in line.split_whitespace() {
                for full in [
                    "QUADROTOR",
                    "FIXED_WING",
                    "STABILIZE",
                    "disarmed",
                    "STANDBY",
                    "ARDUPILOTMEGA",
                ] {
                    if word.len() >= 3 && full.starts_with(word.trim_end_matches('…')) {
                        assert!(
                            word == full || word.ends_with('…'),
                            "{w} columns: `{word}` cut silently in\n{line}"
                        );
                    }
                }
            }
        }
        // Link rows: the short name is never cut, the rest shows its cut.
        let row = line_with(&text, " 1 tcp:5761");
        let state = row.split("tcp:5761").nth(1).unwrap();
        assert!(
            state.contains(common::REFUSED) || state.contains('…'),
            "{w} columns: {row}"
        );
    }
    let text = screen(&d.app, 60, 20);
    insta::assert_snapshot!("ellipsis_60x20", text);
    assert!(text.contains("down: Connec…"), "{text}");
    assert!(text.contains("QUADROTOR"), "{text}");
}

#[test]
fn long_lists_say_how_many_more_and_scroll_with_the_selection() {
    let mut d = common::first_contact();
    let t = d.app.now;
    let text = screen(&d.app, 80, 24);
    assert!(text.contains("5 of 12, ↓ 7 more"), "{text}");
    let text = screen(&d.app, 60, 20);
    assert!(text.contains("4 of 12, ↓ 8 more"), "{text}");
    // Everything fits at 200x60: nothing to say.
    let text = screen(&d.app, 200, 60);
    assert!(!text.contains(" more "), "{text}");
    assert!(text.contains("12:1 "), "{text}");
    // Down past the last row shown: the list follows the selection.
    for _ in 0..5 {
        d.key(t, "down");
    }
    assert_eq!(d.app.ui.vehicle_sel, 5);
    for (w, h) in SIZES {
        insta::assert_snapshot!(format!("vehicles_scrolled_{w}x{h}"), screen(&d.app, w, h));
    }
    let text = screen(&d.app, 80, 24);
    assert!(text.contains("5 of 12, ↑ 1 more, ↓ 6 more"), "{text}");
    assert!(text.contains("6:1 "), "{text}");
    assert!(!text.contains("> 1:1 "), "{text}");
    d.key(t, "end");
    let text = screen(&d.app, 80, 24);
    assert!(text.contains("5 of 12, ↑ 7 more"), "{text}");
    assert!(text.contains("12:1 ") && !text.contains(" 7:1 "), "{text}");
}

#[test]
fn links_list_says_how_many_more() {
    let mut d = tcp_selected();
    let t = d.app.now;
    // 60x20: the reason takes two detail lines; three of the five links fit, the others are
    // reached by scrolling.
    let text = screen(&d.app, 60, 20);
    assert!(text.contains("3 of 5, ↓ 2 more"), "{text}");
    for _ in 0..3 {
        d.key(t, "down");
    }
    let text = screen(&d.app, 60, 20);
    insta::assert_snapshot!("links_scrolled_60x20", text);
    assert!(text.contains("3 of 5, ↑ 2 more"), "{text}");
    assert!(text.contains(" 4 serial:usb-"), "{text}");
    assert!(!text.contains(" 1 tcp:5761"), "{text}");
    // The detail line names the serial port in full, broken where the line ends.
    assert!(
        compact(&text).contains(
            "»4serial:/dev/serial/by-id/usb-ArduPilot_fmuv3_1E0042-if00:115200connecting"
        ),
        "{text}"
    );
}

#[test]
fn too_small_says_so_with_what_is_needed() {
    let d = common::first_contact();
    let text = screen(&d.app, 50, 14);
    insta::assert_snapshot!("too_small_50x14", text);
    assert!(
        text.contains("terminal too small: 50×14, need 60×16"),
        "{text}"
    );
    for (w, h) in [(59, 30), (100, 15), (20, 5)] {
        let text = words(&screen(&d.app, w, h));
        assert!(
            text.contains(&format!("terminal too small: {w}×{h}, need 60×16")),
            "{w}x{h}: {text}"
        );
    }
    let text = screen(&d.app, 60, 16);
    assert!(!text.contains("too small"), "{text}");
    assert!(text.contains("Vehicles (12)"), "{text}");
    // The headless replay renders the message too, at any size it is given.
    let text = mavterm::headless::replay::screen_text(&d.app, (40, 10), &ui::Theme::PLAIN);
    assert!(
        words(&text).contains("terminal too small: 40×10, need 60×16"),
        "{text}"
    );
}

#[test]
fn vehicles_link_column_shows_the_links_short_names() {
    let mut d = common::first_contact();
    // 1:1 is also heard on the UDP link.
    let t = d.app.now;
    d.send(t, 0, (1, 1), &common::copter(true, 4));
    for (w, h) in SIZES {
        let text = screen(&d.app, w, h);
        insta::assert_snapshot!(format!("vehicles_links_{w}x{h}"), text);
        // 1:1 on links 0 and 2, 2:1 on link 3, 3:1 on link 0 (sysid % 3 picks 0, 2, 3).
        let row = line_with(&text, "> 1:1 ");
        // In full when there is room, else cut where it shows.
        if w >= 200 {
            assert!(row.contains(" udpin:14550,sim?seed=1 "), "{w}x{h}: {row}");
        } else {
            let cell = row.split(" udpin:14550").nth(1).unwrap();
            assert!(
                cell.starts_with(",sim?se") || cell.starts_with('…'),
                "{row}"
            );
            assert!(cell.contains('…'), "{w}x{h}: {row}");
        }
        assert!(line_with(&text, " 2:1 ").contains(" sim?seed=2"), "{text}");
        assert!(line_with(&text, " 3:1 ").contains(" udpin:14550"), "{text}");
    }
}

#[test]
fn spare_height_goes_to_the_lists_that_have_rows() {
    // 20 vehicles on 3 links, and (notices cleared) nothing for the Messages pane to show.
    let mut d = common::many(20, 1);
    d.app.notices = Default::default();
    let text = screen(&d.app, 200, 60);
    insta::assert_snapshot!("many_vehicles_200x60", text);
    // The Vehicles pane's share (40% of the body, 19 rows) is short of 20 vehicles and a header;
    // what Messages does not need makes up for it.
    assert!(text.contains(" 20:1 "), "{text}");
    assert!(!text.contains("of 20"), "{text}");
    // At 80x24 too: more than the 5 rows of its share.
    let text = screen(&d.app, 80, 24);
    let shown = text.lines().filter(|l| l.contains("QUADROTOR")).count();
    assert!(shown > 5, "{shown} rows:\n{text}");
    assert!(
        text.contains(&format!("{shown} of 20, ↓ {} more", 20 - shown)),
        "{text}"
    );
}
