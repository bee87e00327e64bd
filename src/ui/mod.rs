//! Rendering: panes drawn from `&App` only, so the terminal, headless replay and tests all show
//! exactly the same screen for the same state.
//!
//! Layout: the panes stack top to bottom (vehicles, links, messages) above a one-line status bar.
//! When the screen is too short, panes other than the focused one collapse to a one-line title,
//! and at the very smallest sizes are dropped. Nothing here can panic on any size: every
//! rectangle is clipped to the frame.

pub mod fmt;
pub mod help;
pub mod links;
pub mod messages;
pub mod status;
pub mod theme;
pub mod vehicles;

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Paragraph};
use ratatui::Frame;

use crate::app::{App, Pane};
pub use theme::Theme;

/// Draw everything with the default (colour) theme.
pub fn render(app: &App, frame: &mut Frame) {
    render_with(app, frame, &Theme::default());
}

/// Draw everything with `theme` (chosen once at startup, e.g. [`Theme::from_env`]).
pub fn render_with(app: &App, frame: &mut Frame, theme: &Theme) {
    let area = frame.area();
    if area.width == 0 || area.height == 0 {
        return;
    }
    let status_area = Rect {
        y: area.y + area.height - 1,
        height: 1,
        ..area
    };
    let body = Rect {
        height: area.height - 1,
        ..area
    };
    for (pane, rect, full) in layout(app, body) {
        if full {
            match pane {
                Pane::Vehicles => vehicles::render(app, frame, rect, theme),
                Pane::Links => links::render(app, frame, rect, theme),
                Pane::Messages => messages::render(app, frame, rect, theme),
            }
        } else {
            collapsed(app, pane, frame, rect, theme);
        }
    }
    status::render(app, frame, status_area, theme);
    if app.ui.help {
        help::render(app, frame, area, theme);
    }
}

/// Rows a fixed-size pane would like, borders included: its rows, but at most ~40% of the body.
fn wanted_height(app: &App, pane: Pane, avail: u16) -> u16 {
    let rows = match pane {
        Pane::Vehicles => app.vehicles.len().max(1) + 1, // + header
        Pane::Links => {
            let sources: usize = app
                .links
                .iter()
                .filter(|l| l.expanded)
                .map(|l| l.sources.len())
                .sum();
            app.links.len().max(1) + sources + 1
        }
        Pane::Messages => 1,
    };
    let rows = rows.min(u16::MAX as usize / 2) as u16;
    (rows + 2).min((avail * 2 / 5).max(MIN_FULL + 1))
}

/// Smallest height a pane is drawn in full (borders and one row).
const MIN_FULL: u16 = 3;

/// Where each pane goes: (pane, rect, full) where `full == false` means a one-line title.
fn layout(app: &App, body: Rect) -> Vec<(Pane, Rect, bool)> {
    let avail = body.height;
    let focus = app.ui.focus;
    // (pane, height, full)
    let mut plan: Vec<(Pane, u16, bool)> = Pane::ALL
        .iter()
        .map(|&p| (p, wanted_height(app, p, avail).max(MIN_FULL), true))
        .collect();
    let total = |plan: &[(Pane, u16, bool)]| plan.iter().map(|x| x.1 as u32).sum::<u32>();
    // Unfocused panes give way, bottom first: first to a title line, then entirely.
    let victims: Vec<usize> = (0..plan.len())
        .rev()
        .filter(|&i| plan[i].0 != focus)
        .collect();
    for &i in &victims {
        if total(&plan) > avail as u32 {
            plan[i] = (plan[i].0, 1, false);
        }
    }
    for &i in &victims {
        if total(&plan) > avail as u32 {
            plan[i].1 = 0;
        }
    }
    // Whatever is left over goes to messages if shown in full, else to the focused pane.
    let spare = (avail as u32).saturating_sub(total(&plan)) as u16;
    let grow = plan
        .iter()
        .position(|x| x.0 == Pane::Messages && x.2)
        .or_else(|| plan.iter().position(|x| x.0 == focus));
    if let Some(i) = grow {
        plan[i].1 += spare;
    }
    let bottom = body.y + body.height;
    let mut y = body.y;
    let mut out = Vec::new();
    for (pane, h, full) in plan {
        let h = h.min(bottom.saturating_sub(y));
        if h == 0 {
            continue;
        }
        out.push((
            pane,
            Rect::new(body.x, y, body.width, h),
            full && h >= MIN_FULL,
        ));
        y += h;
    }
    out
}

/// A pane that did not fit: just its title on one line.
fn collapsed(app: &App, pane: Pane, frame: &mut Frame, rect: Rect, theme: &Theme) {
    let count = match pane {
        Pane::Vehicles => app.vehicles.len(),
        Pane::Links => app.links.len(),
        Pane::Messages => app.notices.len(),
    };
    let style = if app.ui.focus == pane {
        theme.focus_border()
    } else {
        theme.border()
    };
    let line = Line::from(vec![
        Span::styled(format!("─ {} ({count}) ", pane.title()), style),
        Span::styled("─".repeat(rect.width as usize), style),
    ]);
    frame.render_widget(Paragraph::new(line), rect);
}

/// The bordered block every pane sits in; the focused pane's border stands out (colour and a
/// `*` in the title, so focus is visible without colour too).
pub fn pane_block<'a>(app: &App, pane: Pane, extra: String, theme: &Theme) -> Block<'a> {
    let focused = app.ui.focus == pane;
    let (style, mark) = if focused {
        (theme.focus_border(), "*")
    } else {
        (theme.border(), "")
    };
    Block::default()
        .borders(Borders::ALL)
        .border_style(style)
        .border_type(if focused {
            ratatui::widgets::BorderType::Thick
        } else {
            ratatui::widgets::BorderType::Plain
        })
        .title(Span::styled(
            format!(" {mark}{}{extra} ", pane.title()),
            style,
        ))
}

/// Highlight style for the selected row; only loud in the focused pane.
pub fn selected_style(app: &App, pane: Pane, theme: &Theme) -> Style {
    if app.ui.focus == pane {
        theme.selected()
    } else {
        Style::default()
    }
}

/// The screen as plain text: one line per row, trailing spaces trimmed, `\n` after each line.
pub fn buffer_to_text(buf: &Buffer) -> String {
    let area = buf.area;
    let mut out = String::with_capacity((area.width as usize + 1) * area.height as usize);
    for y in area.y..area.y + area.height {
        let mut line = String::with_capacity(area.width as usize);
        for x in area.x..area.x + area.width {
            line.push_str(buf[(x, y)].symbol());
        }
        out.push_str(line.trim_end());
        out.push('\n');
    }
    out
}

/// Render `app` into an off-screen buffer of `width` x `height` (headless replay, tests, benches).
pub fn render_to_buffer(app: &App, width: u16, height: u16, theme: &Theme) -> Buffer {
    let mut terminal = ratatui::Terminal::new(ratatui::backend::TestBackend::new(width, height))
        .expect("infallible");
    terminal
        .draw(|f| render_with(app, f, theme))
        .expect("TestBackend cannot fail");
    terminal.backend().buffer().clone()
}

/// Shorten `s` to at most `max` characters, marking the cut with `…`.
pub fn ellipsize(s: &str, max: usize) -> String {
    if s.chars().count() <= max {
        return s.to_string();
    }
    if max == 0 {
        return String::new();
    }
    let mut t: String = s.chars().take(max - 1).collect();
    t.push('…');
    t
}
