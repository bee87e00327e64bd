//! The help popup (`?`): every binding of the active keymap with its action's description,
//! generated from the keymap so it is never out of date.

use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Clear, Paragraph};
use ratatui::Frame;

use super::Theme;
use crate::app::App;
use crate::keymap::{Action, Mode};

/// (keys, description) for every bound action, in [`Action::ALL`] order.
pub fn help_rows(app: &App) -> Vec<(String, &'static str)> {
    Action::ALL
        .iter()
        .filter_map(|(a, _, desc)| {
            let keys = app.keymap.keys_for(Mode::Normal, "overview", *a);
            if keys.is_empty() {
                return None;
            }
            let names: Vec<String> = keys.iter().map(|k| k.to_string()).collect();
            Some((names.join(", "), *desc))
        })
        .collect()
}

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let rows = help_rows(app);
    let key_w = rows.iter().map(|r| r.0.chars().count()).max().unwrap_or(0);
    let desc_w = rows.iter().map(|r| r.1.len()).max().unwrap_or(0);
    let want_w = (key_w + desc_w + 2 + 2) as u16; // gap + borders
    let want_h = rows.len() as u16 + 3; // borders + footer
    let w = want_w.min(area.width);
    let h = want_h.min(area.height);
    let popup = Rect::new(
        area.x + (area.width - w) / 2,
        area.y + (area.height - h) / 2,
        w,
        h,
    );
    let mut lines: Vec<Line> = rows
        .into_iter()
        .map(|(keys, desc)| {
            Line::from(vec![
                Span::styled(format!("{keys:<key_w$}"), theme.header()),
                Span::raw("  "),
                Span::raw(desc),
            ])
        })
        .collect();
    lines.push(Line::styled("any key closes this help", theme.dim()));
    frame.render_widget(Clear, popup);
    let block = Block::default()
        .borders(Borders::ALL)
        .border_style(theme.focus_border())
        .title(" Keys ");
    frame.render_widget(Paragraph::new(lines).block(block), popup);
}
