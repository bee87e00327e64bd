//! The render benchmark's 200x60 frame (10 vehicles, 3 links), drawn a given number of times,
//! for instruction counts: `valgrind --tool=callgrind target/release/examples/render_profile 100`
//! (and 300); instructions per frame are the difference over the difference in frames (this
//! leaves out building the scene).

#[path = "../tests/ui_fixture/mod.rs"]
mod ui_fixture;

use mavterm::ui::{self, Theme};
use ratatui::backend::TestBackend;
use ratatui::Terminal;

fn main() {
    let n: u32 = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(100);
    let d = ui_fixture::many(10, 20);
    let mut term = Terminal::new(TestBackend::new(200, 60)).unwrap();
    let theme = Theme::default();
    for _ in 0..n {
        term.draw(|f| ui::render_with(&d.app, f, &theme)).unwrap();
    }
    println!("{n} frames at 200x60");
}
