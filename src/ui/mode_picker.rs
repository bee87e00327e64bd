//! The mode picker (`M`): the target's modes from its profile's mode table, filtered by what is
//! typed, the selected one highlighted; enter asks for it through the `mode` command (a
//! dangerous change still asks first), esc leaves.

use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Clear, Paragraph};
use ratatui::Frame;

use super::{ellipsize, Theme};
use crate::app::App;
use crate::keymap::{Action, Mode};

/// `↑↓ move  enter picks  esc leaves` from the `[edit]` keys in use.
pub fn hint(app: &App) -> String {
    let key = |a| {
        app.keymap
            .keys_for(Mode::Edit, app.ui.screen, a)
            .into_iter()
            .next()
            .map(|k| k.to_string())
    };
    let mut parts = Vec::new();
    if let (Some(u), Some(d)) = (key(Action::HistoryPrev), key(Action::HistoryNext)) {
        parts.push(format!("{u}/{d} move"));
    }
    if let Some(k) = key(Action::Submit) {
        parts.push(format!("{k} picks"));
    }
    if let Some(k) = key(Action::Cancel) {
        parts.push(format!("{k} leaves"));
    }
    parts.push("typing filters".to_string());
    parts.join("  ")
}

/// The popup's lines for `w` columns and `rows` list rows: the filter line, then the modes
/// around the selection (the current mode marked `•`), then `N of M` when some are not shown.
pub fn lines(app: &App, w: usize, rows: usize) -> Vec<(String, bool)> {
    let Some(p) = &app.ui.mode_picker else {
        return Vec::new();
    };
    let modes = app.mode_picker_rows();
    let now = app
        .target
        .and_then(|k| app.vehicles.get(k))
        .map(|v| v.mode_name().to_ascii_lowercase());
    let mut out = vec![(ellipsize(&format!("> {}", p.query.text), w), false)];
    if modes.is_empty() {
        out.push(("no mode matches".into(), false));
        return out;
    }
    let sel = p.sel.min(modes.len() - 1);
    let start = sel
        .saturating_sub(rows.saturating_sub(1))
        .min(modes.len().saturating_sub(rows));
    for (i, m) in modes.iter().enumerate().skip(start).take(rows) {
        let mark = if i == sel { ">" } else { " " };
        let cur = if now.as_deref() == Some(m.as_str()) {
            " • now"
        } else {
            ""
        };
        out.push((ellipsize(&format!("{mark} {m}{cur}"), w), i == sel));
    }
    if modes.len() > rows {
        out.push((
            ellipsize(
                &format!(
                    "{}-{} of {}",
                    start + 1,
                    (start + rows).min(modes.len()),
                    modes.len()
                ),
                w,
            ),
            false,
        ));
    }
    out
}

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    if app.ui.mode_picker.is_none() {
        return;
    }
    let w = area.width.min(36);
    let h = area.height.saturating_sub(1).min(22);
    if w < 8 || h < 5 {
        return;
    }
    let inner_w = (w - 2) as usize;
    // The filter line and the `N of M` line around the list.
    let rows = (h as usize).saturating_sub(4).max(1);
    let lines = lines(app, inner_w, rows);
    let h = (lines.len() as u16 + 2).min(h);
    let popup = Rect::new(
        area.x + (area.width - w) / 2,
        area.y + (area.height.saturating_sub(1) - h) / 2,
        w,
        h,
    );
    frame.render_widget(Clear, popup);
    let title = match app.target {
        Some(k) => format!(" Mode of {}:{} ", k.0, k.1),
        None => " Mode ".into(),
    };
    let shown: Vec<Line> = lines
        .into_iter()
        .map(|(t, sel)| {
            if sel {
                Line::from(Span::styled(t, theme.selected()))
            } else {
                Line::raw(t)
            }
        })
        .collect();
    let block = Block::default()
        .borders(Borders::ALL)
        .border_style(theme.focus_border())
        .title(ellipsize(&title, inner_w));
    frame.render_widget(Paragraph::new(shown).block(block), popup);
}
