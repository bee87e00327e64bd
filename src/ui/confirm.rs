//! The confirmation asked before a dangerous command: what, to whom, and which key goes ahead.

use ratatui::layout::Rect;
use ratatui::text::Line;
use ratatui::widgets::{Block, Borders, Clear, Paragraph, Wrap};
use ratatui::Frame;

use super::Theme;
use crate::app::App;

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let Some(c) = &app.ui.confirm else { return };
    let w = (c.text.chars().count() as u16 + 4).clamp(20, area.width.max(1));
    let inner = w.saturating_sub(2).max(1) as usize;
    let lines = c.text.chars().count().div_ceil(inner) as u16;
    let h = (lines + 2).min(area.height);
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
    frame.render_widget(
        Paragraph::new(Line::styled(c.text.clone(), theme.header()))
            .wrap(Wrap { trim: true })
            .block(block),
        popup,
    );
}
