//! Redraw only on change: an idle screen writes no bytes to the terminal.

mod ui_fixture;

use std::io::Write;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

use mavterm::clock::SECOND;
use mavterm::tui::draw_if_dirty;
use mavterm::ui::Theme;
use ratatui::backend::CrosstermBackend;
use ratatui::layout::Rect;
use ratatui::{Terminal, TerminalOptions, Viewport};

#[derive(Clone, Default)]
struct Counting(Arc<AtomicUsize>);

impl Write for Counting {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.0.fetch_add(b.len(), Ordering::SeqCst);
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[test]
fn idle_screen_writes_nothing_until_something_changes() {
    let mut d = ui_fixture::scene();
    let out = Counting::default();
    let mut term = Terminal::with_options(
        CrosstermBackend::new(out.clone()),
        TerminalOptions {
            viewport: Viewport::Fixed(Rect::new(0, 0, 80, 24)),
        },
    )
    .unwrap();
    let t0 = 22 * SECOND; // nothing times out in this second
    d.tick(t0);
    assert!(draw_if_dirty(&mut term, &mut d.app, &Theme::default()).unwrap());
    let after_first = out.0.load(Ordering::SeqCst);
    assert!(after_first > 80 * 24 / 2, "first frame paints the screen");
    for i in 1..10 {
        d.tick(t0 + i * SECOND / 10);
        assert!(!draw_if_dirty(&mut term, &mut d.app, &Theme::default()).unwrap());
    }
    assert_eq!(out.0.load(Ordering::SeqCst), after_first, "idle: no bytes");
    // The next second only the clock and ages change: a small diff, not a repaint.
    d.tick(t0 + SECOND);
    assert!(draw_if_dirty(&mut term, &mut d.app, &Theme::default()).unwrap());
    let diff = out.0.load(Ordering::SeqCst) - after_first;
    assert!(
        diff > 0 && diff < after_first / 4,
        "{diff} bytes vs {after_first}"
    );
}
