//! The confirmation asked before a dangerous command: what, to whom, and which key goes ahead.
//! Under the question, its two choices: *No* (highlighted first) and *Yes*, the highlighted one
//! in brackets and in the selection style; left/right/tab move it, `enter` takes it, `y` is yes.

use ratatui::layout::{Alignment, Rect};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Clear, Paragraph, Wrap};
use ratatui::Frame;

use super::Theme;
use crate::app::App;

/// The choices row: `[ No ]   Yes ` or `  No   [ Yes ]`.
fn choices(yes: bool, theme: &Theme) -> Line<'static> {
    let choice = |label: &str, on: bool| {
        if on {
            Span::styled(format!("[ {label} ]"), theme.selected())
        } else {
            Span::styled(format!("  {label}  "), theme.header())
        }
    };
    Line::from(vec![
        choice("No", !yes),
        Span::raw(" "),
        choice("Yes", yes),
        Span::styled("  ←/→ enter", theme.dim()),
    ])
}

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let Some(c) = &app.ui.confirm else { return };
    let w = (c.text.chars().count() as u16 + 4).clamp(32, area.width.max(1));
    // As many columns on either side: the box sits centred between the panes' borders, not a
    // column off.
    let w = if (area.width - w) % 2 == 1 && w < area.width {
        w + 1
    } else {
        w
    };
    let inner = w.saturating_sub(2).max(1) as usize;
    let lines = c.text.chars().count().div_ceil(inner) as u16;
    let h = (lines + 3).min(area.height);
    let popup = Rect::new(
        area.x + (area.width - w) / 2,
        area.y + (area.height - h) / 2,
        w,
        h,
    );
    frame.render_widget(Clear, popup);
    let block = Block::default()
        .borders(Borders::ALL)
        .border_style(theme.alert())
        .title(" Confirm ");
    let text_area = block.inner(popup);
    frame.render_widget(block, popup);
    let question = Rect {
        height: text_area.height.saturating_sub(1),
        ..text_area
    };
    frame.render_widget(
        Paragraph::new(Line::styled(c.text.clone(), theme.header())).wrap(Wrap { trim: true }),
        question,
    );
    if text_area.height >= 2 {
        let row = Rect {
            y: text_area.y + text_area.height - 1,
            height: 1,
            ..text_area
        };
        frame.render_widget(
            Paragraph::new(choices(c.yes, theme)).alignment(Alignment::Center),
            row,
        );
    }
}
