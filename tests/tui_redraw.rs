//! Redraw only on change: an idle screen writes no bytes to the terminal.

mod ui_fixture;

use mavterm::clock::SECOND;
use mavterm::tui::draw_if_dirty;
use mavterm::ui::Theme;

#[test]
fn idle_screen_writes_nothing_until_something_changes() {
    let mut d = ui_fixture::scene();
    let (mut term, out) = ui_fixture::counting_terminal(80, 24);
    let t0 = 22 * SECOND; // nothing times out in this second
    d.tick(t0);
    assert!(draw_if_dirty(&mut term, &mut d.app, &Theme::default()).unwrap());
    let after_first = out.bytes();
    assert!(after_first > 80 * 24 / 2, "first frame paints the screen");
    for i in 1..10 {
        d.tick(t0 + i * SECOND / 10);
        assert!(!draw_if_dirty(&mut term, &mut d.app, &Theme::default()).unwrap());
    }
    assert_eq!(out.bytes(), after_first, "idle: no bytes");
    // The next second only the clock and ages change: a small diff, not a repaint.
    d.tick(t0 + SECOND);
    assert!(draw_if_dirty(&mut term, &mut d.app, &Theme::default()).unwrap());
    let diff = out.bytes() - after_first;
    assert!(
        diff > 0 && diff < after_first / 4,
        "{diff} bytes vs {after_first}"
    );
}
