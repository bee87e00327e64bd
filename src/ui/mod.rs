//! Rendering: panes drawn from `&App` only, so the terminal, headless replay and tests all show
//! exactly the same screen for the same state.
//!
//! Layout: the screen shown (`screens`, one file each; `1` is the Overview of `overview.rs`) above
//! a one-line status bar, which becomes the `:` prompt while a command is typed; the command
//! palette, the key help and a confirmation pop up over both. Nothing here can panic on any size:
//! every rectangle is clipped to the frame; below [`MIN_SIZE`] the screen just says it is too
//! small and what it needs.

pub mod confirm;
pub mod fast;
pub mod flight;
pub mod fmt;
pub mod help;
pub mod links;
pub mod messages;
pub mod mode_picker;
pub mod palette;
pub mod screens;
pub mod status;
pub mod theme;
pub mod vehicles;

// Every screen's module, `ui/NAME.rs`, named by the one screen list.
macro_rules! screen_modules {
    ($( $n:literal $name:ident $title:literal $what:literal
        $(select = $sel:ident)? $(note = $note:ident)? ;)*) => {
        $(pub mod $name;)*
    };
}
crate::for_each_screen!(screen_modules);

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::Frame;

use crate::app::{App, Pane};
use crate::keymap::Mode;
pub use theme::Theme;

/// Draw everything with the default (colour) theme.
pub fn render(app: &App, frame: &mut Frame) {
    render_with(app, frame, &Theme::default());
}

/// Draw everything with `theme` (chosen once at startup, e.g. [`Theme::from_env`]): the screen
/// shown, the status bar (or the prompt line while typing a command), and the key help on top.
pub fn render_with(app: &App, frame: &mut Frame, theme: &Theme) {
    let area = frame.area();
    if area.width == 0 || area.height == 0 {
        return;
    }
    if area.width < MIN_SIZE.0 || area.height < MIN_SIZE.1 {
        too_small(frame, area, theme);
        return;
    }
    let status_area = Rect {
        y: area.y + area.height - 1,
        height: 1,
        ..area
    };
    let mut body = Rect {
        height: area.height - 1,
        ..area
    };
    // Fly mode's keys, on the line above the status bar.
    if app.fly_text().is_some() {
        body.height -= 1;
        let hint = Rect {
            y: body.y + body.height,
            height: 1,
            ..body
        };
        status::render_fly_hint(frame, hint, theme);
    }
    // The target's state on top of every screen but the Overview (whose flight pane has it).
    if app.ui.screen != crate::app::screen::SCREENS[0].name {
        status::render_state(app, frame, Rect { height: 1, ..body }, theme);
        body.y += 1;
        body.height -= 1;
    }
    screens::render(app, frame, body, theme);
    status::render(app, frame, status_area, theme);
    palette::render(app, frame, area, theme);
    mode_picker::render(app, frame, area, theme);
    if app.ui.mode == Mode::Help {
        help::render(app, frame, area, theme);
    }
    confirm::render(app, frame, area, theme);
}

/// The smallest terminal (columns, rows) the screens are drawn in: below it, the Overview's
/// tables cannot show a vehicle's mode and arming state or a link's name and state, nor the
/// panes a row each. Smaller terminals get [`too_small`] instead of a garbled screen.
pub const MIN_SIZE: (u16, u16) = (60, 16);

/// `terminal too small: 50×14, need 60×16`, centred, wrapped to the width there is.
fn too_small(frame: &mut Frame, area: Rect, theme: &Theme) {
    let text = format!(
        "terminal too small: {}×{}, need {}×{}",
        area.width, area.height, MIN_SIZE.0, MIN_SIZE.1
    );
    let lines: Vec<ratatui::text::Line> = fmt::wrap(&text, area.width as usize)
        .into_iter()
        .map(|l| ratatui::text::Line::styled(l, theme.alert()).centered())
        .collect();
    let h = (lines.len() as u16).min(area.height);
    let at = Rect {
        y: area.y + (area.height - h) / 2,
        height: h,
        ..area
    };
    frame.render_widget(ratatui::widgets::Paragraph::new(lines), at);
}

/// The bordered block every pane sits in; the focused pane's border stands out (colour and a
/// `*` in the title, so focus is visible without colour too).
pub fn pane_block(app: &App, pane: Pane, extra: String, theme: &Theme) -> fast::PaneBlock {
    let focused = app.ui.focus == pane;
    let (style, mark) = if focused {
        (theme.focus_border(), "*")
    } else {
        (theme.border(), "")
    };
    fast::PaneBlock {
        style,
        thick: focused,
        title: format!(" {mark}{}{extra} ", pane.title()),
        bottom: None,
    }
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

/// Shorten `s` to at most `max` terminal columns, marking the cut with `…` ([`fmt::fit`],
/// owned).
pub fn ellipsize(s: &str, max: usize) -> String {
    fmt::fit(s, max).into_owned()
}
