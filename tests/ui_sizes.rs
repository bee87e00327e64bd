//! Issue #15 "First contact": the Overview and the lists at 60x20, 80x24 and 200x60.

mod ui_fixture;
use ui_fixture as common;

use mavterm::app::App;
use mavterm::ui::{self, buffer_to_text};
use ratatui::backend::TestBackend;
use ratatui::Terminal;

fn screen(app: &App, w: u16, h: u16) -> String {
    let mut t = Terminal::new(TestBackend::new(w, h)).unwrap();
    t.draw(|f| ui::render_with(app, f, &ui::Theme::PLAIN)).unwrap();
    buffer_to_text(t.backend().buffer())
}

#[test]
fn scratch() {
    let d = common::first_contact();
    for (w, h) in [(60, 20), (80, 24), (200, 60), (60, 16)] {
        println!("{}", screen(&d.app, w, h));
    }
}
