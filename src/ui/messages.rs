//! The messages pane: STATUSTEXT and mavterm's own notices, oldest at the top, newest at the
//! bottom. Each line: `HH:MM:SS SEVERITY source text`, coloured by severity (the label is there
//! for NO_COLOR). `msg_scroll` lines back from the newest, applied only to lines that do not fit
//! (at most `len - visible`); the title says when scrolled.

use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::Paragraph;
use ratatui::Frame;

use super::{pane_block, Theme};
use crate::app::notices::Notice;
use crate::app::{App, Pane};

/// One message as plain text.
pub fn notice_text(app: &App, n: &Notice) -> (String, String, String, String) {
    let time = app.wall(n.t).format("%H:%M:%S").to_string();
    let source = match n.source {
        Some((s, c)) => format!("{s}:{c}"),
        None => "mavterm".to_string(),
    };
    (time, n.severity_name().to_string(), source, n.text.clone())
}

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let len = app.notices.len();
    let visible = pane_block(app, Pane::Messages, String::new(), theme)
        .inner(area)
        .height as usize;
    // Scrolling back only applies to lines that do not fit: when everything fits, the newest
    // stays in view; and the window never scrolls past the oldest line at the top.
    let scroll = app.ui.msg_scroll.min(len.saturating_sub(visible.max(1)));
    let extra = if scroll > 0 {
        format!(" ({len}, {scroll} newer below)")
    } else {
        format!(" ({len})")
    };
    let block = pane_block(app, Pane::Messages, extra, theme);
    let inner = block.inner(area);
    frame.render_widget(block, area);
    if visible == 0 {
        return;
    }
    if len == 0 {
        frame.render_widget(
            Paragraph::new(Line::styled("no messages", theme.dim())),
            inner,
        );
        return;
    }
    let end = len - scroll;
    let start = end.saturating_sub(visible);
    let lines: Vec<Line> = app
        .notices
        .iter()
        .skip(start)
        .take(end - start)
        .map(|n| {
            let (time, sev, source, text) = notice_text(app, n);
            let style = theme.severity(n.severity);
            Line::from(vec![
                Span::styled(time, theme.dim()),
                Span::raw(" "),
                Span::styled(format!("{sev:<6}"), style),
                Span::raw(" "),
                Span::styled(format!("{source:<7}"), theme.dim()),
                Span::raw(" "),
                Span::styled(text, style),
            ])
        })
        .collect();
    frame.render_widget(Paragraph::new(lines), inner);
}
