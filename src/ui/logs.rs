//! The Logs screen (`7`): the target's onboard logs, newest first (id, time in the zone times
//! are shown in, size, and what is on disk of it), how the list was got, the download running
//! (bytes, rate, ETA, retries, window, round trip) and the queue, and the downloads finished.

use ratatui::layout::Rect;
use ratatui::text::Line;
use ratatui::widgets::{Block, Borders, Paragraph};
use ratatui::Frame;

use super::Theme;
use crate::app::logs::human_bytes;
use crate::app::App;
use crate::proto::logs::State;

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let block = Block::default()
        .borders(Borders::ALL)
        .border_style(theme.focus_border());
    let Some(s) = app.target.and_then(|k| app.sessions.get(&k)) else {
        frame.render_widget(
            Paragraph::new(Line::styled("no target vehicle", theme.dim()))
                .block(block.title(" Logs ")),
            area,
        );
        return;
    };
    let l = &s.logs.list;
    let mut lines: Vec<Line> = Vec::new();
    let head = match (l.num_logs, l.done, &l.failed) {
        (_, _, Some(why)) => format!(
            "{} of {} logs listed: {why}",
            l.entries.len(),
            l.num_logs.map_or("?".into(), |n| n.to_string())
        ),
        (Some(0), _, _) => "no log on the vehicle".into(),
        (Some(n), Some(t), _) => format!(
            "{n} logs, listed in {:.1} s ({} requests, {} again)",
            (t.saturating_sub(l.started)) as f64 / 1e6,
            l.requests,
            l.retries
        ),
        (Some(n), None, _) => format!("listing: {}/{n}", l.entries.len()),
        (None, _, _) if l.wanted => "asking for the list…".into(),
        (None, _, _) => "the list was not asked yet".into(),
    };
    lines.push(Line::styled(head, theme.header()));
    // The download running (or the last one), in full.
    if let Some(t) = &s.logs.transfer {
        let state = match &t.state {
            State::Opening => "opening the file".to_string(),
            State::Running => "downloading".into(),
            State::Finishing => "saving".into(),
            State::Done => "saved".into(),
            State::Cancelled => "cancelled".into(),
            State::Failed(why) => format!("failed: {why}"),
        };
        let style = match t.state {
            State::Failed(_) => theme.alert(),
            State::Done => theme.good(),
            _ if t.paused.is_some() || t.stalled(app.now).is_some() => theme.alert(),
            _ => theme.header(),
        };
        // A download that ended shows how it stood then.
        let at = match t.finished {
            Some(f) if !t.active() => f,
            _ => app.now,
        };
        lines.push(Line::styled(
            format!("log {} {state}: {}", t.entry.id, t.progress_text(at)),
            style,
        ));
        let resumed = if t.resumed > 0 {
            format!("  resumed at {}", human_bytes(t.resumed as u64))
        } else {
            String::new()
        };
        lines.push(Line::styled(
            format!(
                "  window {} B  rtt {}  requests {}{resumed}  → {}",
                t.window * crate::proto::logs::CHUNK,
                t.srtt
                    .map_or("–".into(), |r| format!("{} ms", r / 1000)),
                t.requests,
                t.path.display()
            ),
            theme.dim(),
        ));
    }
    if !s.logs.queue.is_empty() {
        let ids: Vec<String> = s.logs.queue.iter().map(|q| q.id.to_string()).collect();
        let why = if s.logs.waiting_for_link.is_some() {
            " (waiting for the vehicle to be heard again)"
        } else {
            ""
        };
        lines.push(Line::styled(
            format!("queued: {}{why}", ids.join(", ")),
            theme.dim(),
        ));
    }
    let rows = app.log_rows();
    let room = (area.height as usize).saturating_sub(lines.len() + 3);
    let sel = app.ui.logs.sel.min(rows.len().saturating_sub(1));
    let first = sel.saturating_sub(room.saturating_sub(1));
    let shown: Vec<_> = rows.iter().enumerate().skip(first).take(room).collect();
    let times: Vec<String> = shown
        .iter()
        .map(|(_, e)| {
            if e.time_utc == 0 {
                return "(no time)".to_string();
            }
            chrono::DateTime::from_timestamp(e.time_utc as i64, 0)
                .map(|t| {
                    format!(
                        "{} {}",
                        app.cfg.zone.at(t).format("%Y-%m-%d %H:%M:%S"),
                        app.cfg.zone.label
                    )
                })
                .unwrap_or_default()
        })
        .collect();
    // The time column as wide as its widest entry (the zone's label varies).
    let tw = times
        .iter()
        .map(|t| super::fmt::width(t))
        .max()
        .unwrap_or(0)
        .max(4);
    lines.push(Line::styled(
        format!("{:>5}  {:<tw$} {:>10}  {}", "id", "time", "size", "here"),
        theme.border(),
    ));
    for ((i, e), time) in shown.into_iter().zip(times) {
        let here = match &s.logs.transfer {
            Some(t) if t.entry.id == e.id && t.active() => "downloading".to_string(),
            _ => match s.logs.history.iter().rev().find(|(h, _, _)| h.id == e.id) {
                Some((_, _, State::Done)) => "saved".into(),
                Some((_, _, State::Cancelled)) => "partial".into(),
                Some((_, _, State::Failed(_))) => "failed".into(),
                _ if s.logs.queue.iter().any(|q| q.id == e.id) => "queued".into(),
                _ => String::new(),
            },
        };
        let mark = if i == sel { ">" } else { " " };
        let style = if i == sel {
            theme.selected()
        } else {
            theme.border()
        };
        lines.push(Line::styled(
            format!(
                "{mark}{:>4}  {time:<tw$} {:>10}  {here}",
                e.id,
                human_bytes(e.size as u64)
            ),
            style,
        ));
    }
    let title = format!(" Logs of {} ", s.key);
    frame.render_widget(Paragraph::new(lines).block(block.title(title)), area);
}
