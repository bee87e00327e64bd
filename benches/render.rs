//! Rendering cost: time per full frame at 200x60 (10 vehicles, 3 links), and the bytes the
//! terminal receives per second at 80x24 with one vehicle streaming at 10 Hz when redrawing only
//! on change at 10 fps (a measurement, printed, not asserted).

#[path = "../tests/ui_fixture/mod.rs"]
mod ui_fixture;

use criterion::{criterion_group, Criterion};
use mavterm::clock::SECOND;
use mavterm::tui::draw_if_dirty;
use mavterm::ui::{self, Theme};
use ratatui::backend::TestBackend;
use ratatui::Terminal;

fn render_frame(c: &mut Criterion) {
    let d = ui_fixture::many(10, 20);
    let mut term = Terminal::new(TestBackend::new(200, 60)).unwrap();
    let theme = Theme::default();
    c.bench_function("render 200x60, 10 vehicles, 3 links", |b| {
        b.iter(|| {
            term.draw(|f| ui::render_with(&d.app, f, &theme)).unwrap();
        })
    });
}

/// One copter at 10 Hz (1 Hz heartbeat) for 60 s of virtual time, drawn at most 10 times a
/// second and only when dirty, into a crossterm backend that counts bytes.
fn bytes_per_second() {
    const SECS: u64 = 60;
    let (mut term, out) = ui_fixture::counting_terminal(80, 24);
    let mut d = ui_fixture::Drive::new(&ui_fixture::LINKS[..1]);
    d.link_state(0, 0, mavterm::app::links::LinkState::Up);
    let theme = Theme::default();
    let (mut draws, mut first) = (0u64, 0u64);
    for k in 0..SECS * 10 {
        let t = k * SECOND / 10;
        // Telemetry lands between frames.
        if k % 10 == 0 {
            d.send(t + 37_000, 0, (1, 1), &ui_fixture::copter(false, 0));
        }
        d.send(t + 41_000, 0, (1, 1), &ui_fixture::attitude());
        // The frame tick at 10 fps.
        d.tick(t + 100_000);
        if draw_if_dirty(&mut term, &mut d.app, &theme).unwrap() {
            draws += 1;
        }
        if k == 0 {
            first = out.bytes();
        }
    }
    let total = out.bytes();
    println!(
        "terminal output at 80x24, 1 vehicle at 10 Hz, fps 10, {SECS} s: {total} bytes \
         ({:.0} bytes/s; first frame {first} bytes; {draws} redraws = {:.1}/s)",
        (total - first) as f64 / (SECS as f64 - 0.1),
        draws as f64 / SECS as f64
    );
}

criterion_group!(benches, render_frame);

fn main() {
    bytes_per_second();
    benches();
    Criterion::default().configure_from_args().final_summary();
}
