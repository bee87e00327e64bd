//! The messages pane: STATUSTEXT and mavterm's own notices, oldest at the top, newest at the
//! bottom. Each line: `HH:MM:SS SEVERITY source text` (the time in the zone the status bar
//! names; a replay's messages at the recording's time), coloured by severity (the label is there
//! for NO_COLOR). Only the messages passing the pane's filters are shown, the filters named in
//! the title. It follows the newest unless scrolled back (`msg_scroll` lines below the view,
//! applied only to lines that do not fit); the title then says `paused` and how many are below.
//! DEBUG lines are hidden by default, the title counting them (`12 debug hidden`); mavterm's own
//! notices show `mavterm` as their source, in their own colour. While following, recent
//! warnings and worse stay in view when lines do not fit (see `app::messages::in_view`). A text
//! wider than the pane is cut and ends with `…` (by display width).

use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::Frame;

use super::{fast, fmt, pane_block, Theme};
use crate::app::notices::Notice;
use crate::app::{App, Pane};

/// One message as plain text.
pub fn notice_text(app: &App, n: &Notice) -> (String, String, String, String) {
    let time = app.cfg.zone.at(n.at).format("%H:%M:%S").to_string();
    let source = match n.source {
        Some(key) if !n.ours => key.to_string(),
        _ => "mavterm".to_string(),
    };
    (time, n.severity.name().to_string(), source, n.text.clone())
}

/// The title's counts and state: ` (17)`, ` (17) 12 debug hidden`, ` (5 of 17) WARN+ sys 1`,
/// and while scrolled back ` paused ↓ 3 newer` (the lines below the view; `end` follows the
/// newest again).
pub fn title_text(app: &App, shown: usize, below: usize) -> String {
    let total = app.notices.len();
    let f = &app.ui.msg_filter;
    let mut t = if f.is_active() {
        format!(" ({shown} of {total}) {}", f.label(app.target))
    } else {
        format!(" ({total})")
    };
    match app.debug_hidden() {
        0 => {}
        n if f.is_active() => t += &format!(", {n} debug hidden"),
        n => t += &format!(" {n} debug hidden"),
    }
    if below > 0 {
        t += &format!(" paused ↓ {below} newer");
    }
    t
}

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let notices = app.shown_notices();
    let len = notices.len();
    let visible = pane_block(app, Pane::Messages, String::new(), theme)
        .inner(area)
        .height as usize;
    // Scrolling back only applies to lines that do not fit: when everything fits, the newest
    // stays in view; and the window never scrolls past the oldest line at the top.
    let scroll = app.ui.msg_scroll.min(len.saturating_sub(visible.max(1)));
    let block = pane_block(app, Pane::Messages, title_text(app, len, scroll), theme);
    let inner = block.inner(area);
    let buf = frame.buffer_mut();
    block.render(buf, area);
    if visible == 0 {
        return;
    }
    if len == 0 {
        let empty = if app.notices.is_empty() {
            "no messages"
        } else {
            "no messages pass the filter"
        };
        fast::line(buf, inner, &[(empty, theme.dim())]);
        return;
    }
    // Following: the newest lines, recent warnings kept; scrolled back: the window as it is.
    let in_view = if scroll == 0 {
        crate::app::messages::in_view(&notices, visible, app.now)
    } else {
        let end = len - scroll;
        notices[end.saturating_sub(visible)..end].to_vec()
    };
    for (n, y) in in_view.iter().zip(inner.top()..inner.bottom()) {
        let (time, sev, source, text) = notice_text(app, n);
        let style = theme.severity(n.severity);
        let source_style = if n.ours || n.source.is_none() {
            theme.ours()
        } else {
            theme.dim()
        };
        let (sev, source) = (format!("{sev:<6}"), format!("{source:<7}"));
        // A text wider than what the columns before it leave is cut with `…`.
        let room = (inner.width as usize)
            .saturating_sub(fmt::width(&time) + fmt::width(&sev) + fmt::width(&source) + 3);
        let text = fmt::fit(&text, room);
        let plain = Style::default();
        let row = Rect {
            y,
            height: 1,
            ..inner
        };
        fast::line(
            buf,
            row,
            &[
                (&time, theme.dim()),
                (" ", plain),
                (&sev, style),
                (" ", plain),
                (&source, source_style),
                (" ", plain),
                (&text, style),
            ],
        );
    }
}
