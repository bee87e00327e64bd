//! The MAVLink Inspector (`4`): every message id heard, grouped per source (`1:1 HEARTBEAT
//! 1.0 Hz 112 0.3s`: source, name, measured rate, count, time since the last), and below it (beside
//! it when wide) the selected one's last fields, `name = value`, in as many columns as fit, each
//! value in the units the dialect defines for it (`lat = -35.3632621 deg`); while the fields have
//! the keys (`enter`), a value converted shows the raw one as sent too.
//!
//! A message the dialect could not read (an enum value newer than our dialect) shows why and its
//! payload in hex. A message not heard for the whole rate window is dimmed. While a rate is typed
//! (`r`), it is typed in the row's rate column; the rate asked from here and its ACK show in the
//! fields' summary line.

use ratatui::layout::Rect;
use ratatui::style::{Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Paragraph};
use ratatui::Frame;

use super::{ellipsize, Theme};
use crate::app::inspector::{
    fields_in_units, hex_lines, hz_text, interval_text, InspectEdit, MsgEntry, MsgKey, RATE_WINDOW,
};
use crate::app::App;
use crate::clock::SECOND;
use crate::keymap::{Action, Mode};
use crate::proto::vehicles::VehicleKey;

/// Widths of the list's columns: source, rate, count, age.
const SRC_W: usize = 7;
const RATE_W: usize = 9;
const COUNT_W: usize = 8;
const AGE_W: usize = 6;
/// Narrowest the name gets before the age and count columns go.
const NAME_MIN: usize = 12;

/// Narrowest the list is beside the fields.
const SIDE_LIST_W: u16 = 64;

fn pad(s: &str, width: usize) -> String {
    let n = s.chars().count();
    if n >= width {
        s.to_string()
    } else {
        format!("{s}{}", " ".repeat(width - n))
    }
}

fn rpad(s: &str, width: usize) -> String {
    let n = s.chars().count();
    if n >= width {
        s.to_string()
    } else {
        format!("{}{s}", " ".repeat(width - n))
    }
}

/// `0.3s`, `12s`, `4m05s`.
pub fn age_text(micros: u64) -> String {
    if micros < 10 * SECOND {
        format!("{:.1}s", micros as f64 / SECOND as f64)
    } else {
        super::fmt::duration(micros / SECOND)
    }
}

/// Not heard for the whole rate window.
fn stale(app: &App, e: &MsgEntry) -> bool {
    app.now.saturating_sub(e.last) > RATE_WINDOW
}

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let area = area.intersection(frame.area());
    if area.width == 0 || area.height == 0 {
        return;
    }
    let rows = app.inspector_rows();
    let sel = app.inspector_index(&rows);
    let selected = rows.get(sel).copied();
    // Side by side when wide; else the fields below the list, two fifths of the height (9 rows
    // of 23: 7 lines of fields, in columns).
    let (list_area, detail_area) = if area.width >= 2 * SIDE_LIST_W && area.height >= 6 {
        let list_w = SIDE_LIST_W.max(area.width * 2 / 5);
        (
            Rect {
                width: list_w,
                ..area
            },
            Rect {
                x: area.x + list_w,
                width: area.width - list_w,
                ..area
            },
        )
    } else {
        let detail_h = if area.height >= 10 {
            // Counted with the state strip's row, which the list gives up.
            ((area.height + 1) * 2 / 5).max(5)
        } else {
            0
        };
        (
            Rect {
                height: area.height - detail_h,
                ..area
            },
            Rect {
                y: area.y + area.height - detail_h,
                height: detail_h,
                ..area
            },
        )
    };
    render_list(app, frame, list_area, theme, &rows, sel);
    if detail_area.width > 0 && detail_area.height > 0 {
        render_detail(app, frame, detail_area, theme, selected);
    }
}

/// The list's title: what is heard, the filter, evictions; as much as fits.
fn title(app: &App, rows: usize, width: usize, theme: &Theme) -> Line<'static> {
    let v = &app.ui.inspector;
    let store = &app.inspector;
    let mut parts: Vec<(String, Style)> =
        vec![(" MAVLink Inspector ".into(), theme.focus_border())];
    let sources = store.sources();
    parts.push((
        format!(
            " {} message{} from {sources} source{} ",
            store.len(),
            if store.len() == 1 { "" } else { "s" },
            if sources == 1 { "" } else { "s" }
        ),
        Style::default(),
    ));
    let filtering = v.editing == Some(InspectEdit::Filter);
    if !v.filter.is_empty() || filtering {
        parts.push((format!(" /{} ", v.filter), theme.header()));
        parts.push((format!(" {rows} shown "), Style::default()));
    }
    if store.evicted > 0 {
        parts.push((format!(" {} evicted ", store.evicted), theme.alert()));
    }
    let mut used = 0;
    let mut spans = Vec::new();
    for (text, style) in parts {
        let n = text.chars().count();
        if used + n > width {
            break;
        }
        used += n;
        spans.push(Span::styled(text, style));
    }
    Line::from(spans)
}

fn render_list(
    app: &App,
    frame: &mut Frame,
    area: Rect,
    theme: &Theme,
    rows: &[MsgKey],
    sel: usize,
) {
    if area.width == 0 || area.height == 0 {
        return;
    }
    let border = if app.ui.inspector.detail_focus {
        theme.border()
    } else {
        theme.focus_border()
    };
    let mut block = Block::default()
        .borders(Borders::ALL)
        .border_style(border)
        .title(title(
            app,
            rows.len(),
            (area.width as usize).saturating_sub(4),
            theme,
        ));
    if !rows.is_empty() {
        // A line of column titles above the rows.
        let list_h = block.inner(area).height.saturating_sub(1) as usize;
        let first = super::fmt::centred_offset(sel, list_h, rows.len());
        if let Some(more) = super::fmt::list_more(first, list_h, rows.len()) {
            block = block.title_bottom(Line::from(format!(" {more} ")));
        }
        block =
            block.title_bottom(Line::from(format!(" {}/{} ", sel + 1, rows.len())).right_aligned());
    }
    let inner = block.inner(area);
    frame.render_widget(block, area);
    let (w, h) = (inner.width as usize, inner.height as usize);
    if w == 0 || h == 0 {
        return;
    }
    if rows.is_empty() {
        let v = &app.ui.inspector;
        let text = if !v.filter.is_empty() {
            format!("no message matches /{} (esc clears the filter)", v.filter)
        } else {
            "no messages heard yet".to_string()
        };
        frame.render_widget(
            Paragraph::new(Line::styled(ellipsize(&text, w), theme.dim())),
            inner,
        );
        return;
    }
    // Columns: the name takes what the numbers leave; narrow, the age then the count go.
    let base_w = SRC_W + 1 + NAME_MIN + RATE_W;
    let (show_count, show_age) = (
        w >= base_w + (1 + COUNT_W),
        w >= base_w + (1 + COUNT_W) + (1 + AGE_W),
    );
    let fixed = SRC_W
        + 1
        + RATE_W
        + 1
        + if show_count { COUNT_W + 1 } else { 0 }
        + if show_age { AGE_W + 1 } else { 0 };
    let name_w = w.saturating_sub(fixed).max(4);
    let mut head = format!(
        "{} {} {}",
        pad("SOURCE", SRC_W),
        pad("MESSAGE", name_w),
        rpad("RATE", RATE_W)
    );
    if show_count {
        head.push_str(&format!(" {}", rpad("COUNT", COUNT_W)));
    }
    if show_age {
        head.push_str(&format!(" {}", rpad("LAST", AGE_W)));
    }
    let mut lines = vec![Line::styled(ellipsize(&head, w), theme.header())];
    let list_h = h - 1;
    let offset = super::fmt::centred_offset(sel, list_h, rows.len());
    let editing = match &app.ui.inspector.editing {
        Some(InspectEdit::Rate(k)) if app.ui.mode == Mode::Edit => Some(*k),
        _ => None,
    };
    let mut cursor = None;
    for (i, k) in rows.iter().enumerate().skip(offset).take(list_h) {
        let Some(e) = app.inspector.get(*k) else {
            continue;
        };
        let selected = i == sel;
        let base = if selected {
            theme.selected()
        } else if stale(app, e) {
            theme.dim()
        } else {
            Style::default()
        };
        // The source on the first row of each group, and on the first row shown.
        let first = i == offset || rows[i - 1].0 != k.0 || rows[i - 1].1 != k.1;
        let src = if first {
            VehicleKey(k.0, k.1).to_string()
        } else {
            String::new()
        };
        let mut spans = vec![
            Span::styled(pad(&src, SRC_W) + " ", theme.header().patch(base)),
            Span::styled(pad(&ellipsize(e.name, name_w), name_w) + " ", base),
        ];
        if editing == Some(*k) && selected {
            let line = &app.ui.edit;
            let room = RATE_W.saturating_sub(1).max(1);
            let skip = line.cursor.saturating_sub(room);
            let shown: String = line.text.chars().skip(skip).take(room).collect();
            let x = SRC_W + 1 + name_w + 1 + line.cursor - skip;
            if x < w {
                cursor = Some((inner.x + x as u16, inner.y + 1 + (i - offset) as u16));
            }
            spans.push(Span::styled(
                pad(&shown, RATE_W),
                Style::default().add_modifier(Modifier::UNDERLINED | Modifier::BOLD),
            ));
        } else {
            let hz = format!("{} Hz", hz_text(e.rate(app.now)));
            spans.push(Span::styled(rpad(&hz, RATE_W), base));
        }
        if show_count {
            spans.push(Span::styled(
                format!(" {}", rpad(&super::fmt::count(e.count, COUNT_W), COUNT_W)),
                base,
            ));
        }
        if show_age {
            let age = age_text(app.now.saturating_sub(e.last));
            spans.push(Span::styled(format!(" {}", rpad(&age, AGE_W)), base));
        }
        if selected {
            super::fmt::pad_row(&mut spans, w, base);
        }
        lines.push(Line::from(spans));
    }
    frame.render_widget(Paragraph::new(lines), inner);
    if let Some(c) = cursor {
        frame.set_cursor_position(c);
    }
}

/// The fields as lines of `width`: `name = value`, names padded to one width, in columns
/// (down, then across) when every field fits half the width; else one a line, a long value
/// (flags, arrays) wrapped after its `|` or `,` onto lines under its start.
fn field_lines(fields: &[(String, String)], width: usize) -> Vec<String> {
    let name_w = fields
        .iter()
        .map(|(n, _)| n.chars().count())
        .max()
        .unwrap_or(0);
    let item = |n: &str, v: &str| {
        if n.is_empty() {
            v.to_string()
        } else {
            format!("{} = {v}", pad(n, name_w))
        }
    };
    let col_w = fields
        .iter()
        .map(|(n, v)| item(n, v).chars().count())
        .max()
        .unwrap_or(0);
    if col_w > 0 && col_w * 2 + 2 <= width {
        let cols = ((width + 2) / (col_w + 2)).max(1);
        let rows = fields.len().div_ceil(cols);
        return (0..rows)
            .map(|r| {
                let mut line = String::new();
                for c in 0..cols {
                    if let Some((n, v)) = fields.get(c * rows + r) {
                        if c > 0 {
                            line.push_str("  ");
                        }
                        line.push_str(&pad(&item(n, v), col_w));
                    }
                }
                line.trim_end().to_string()
            })
            .collect();
    }
    let indent = if name_w + 3 <= width / 2 {
        name_w + 3
    } else {
        2
    };
    let mut out = Vec::new();
    for (n, v) in fields {
        let first = item(n, "");
        let first_room = width.saturating_sub(first.chars().count()).max(1);
        let rest_room = width.saturating_sub(indent).max(1);
        for (i, piece) in wrap_value(v, first_room, rest_room).into_iter().enumerate() {
            if i == 0 {
                out.push(format!("{first}{piece}"));
            } else {
                out.push(format!("{}{piece}", " ".repeat(indent)));
            }
        }
    }
    out
}

/// `text` in lines of `width`, broken between words (a word longer than a line is cut).
pub(super) fn wrap_words(text: &str, width: usize) -> Vec<String> {
    let width = width.max(1);
    let mut lines = Vec::new();
    let mut cur = String::new();
    for word in text.split_whitespace() {
        let n = cur.chars().count();
        if n > 0 && n + 1 + word.chars().count() > width {
            lines.push(std::mem::take(&mut cur));
        }
        if !cur.is_empty() {
            cur.push(' ');
        }
        cur.push_str(word);
        while cur.chars().count() > width {
            lines.push(cur.chars().take(width).collect());
            cur = cur.chars().skip(width).collect();
        }
    }
    if !cur.is_empty() {
        lines.push(cur);
    }
    lines
}

/// `value` in lines of `first` characters, then `rest`: broken after a ` | ` or `, ` where it
/// can, else cut.
fn wrap_value(value: &str, first: usize, rest: usize) -> Vec<String> {
    let mut tokens: Vec<String> = Vec::new();
    let mut cur = String::new();
    let chars: Vec<char> = value.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        cur.push(chars[i]);
        let at_sep = (chars[i] == '|' || chars[i] == ',') && chars.get(i + 1) == Some(&' ');
        if at_sep {
            cur.push(' ');
            i += 1;
            tokens.push(std::mem::take(&mut cur));
        }
        i += 1;
    }
    if !cur.is_empty() {
        tokens.push(cur);
    }
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for t in tokens {
        let room = if lines.is_empty() { first } else { rest };
        if !line.is_empty() && line.chars().count() + t.trim_end().chars().count() > room {
            lines.push(std::mem::take(&mut line).trim_end().to_string());
        }
        line.push_str(&t);
        // A token longer than a whole line is cut into lines.
        loop {
            let room = if lines.is_empty() { first } else { rest };
            if line.trim_end().chars().count() <= room {
                break;
            }
            let head: String = line.chars().take(room).collect();
            let tail: String = line.chars().skip(room).collect();
            lines.push(head);
            line = tail;
        }
    }
    let last = line.trim_end();
    if !last.is_empty() || lines.is_empty() {
        lines.push(last.to_string());
    }
    lines
}

fn render_detail(app: &App, frame: &mut Frame, area: Rect, theme: &Theme, sel: Option<MsgKey>) {
    let v = &app.ui.inspector;
    let border = if v.detail_focus {
        theme.focus_border()
    } else {
        theme.border()
    };
    let entry = sel.and_then(|k| Some((k, app.inspector.get(k)?)));
    let title = match entry {
        Some((k, e)) => format!(" {} #{} from {} ", e.name, k.2, VehicleKey(k.0, k.1)),
        None => " Fields ".to_string(),
    };
    let mut block = Block::default()
        .borders(Borders::ALL)
        .border_style(border)
        .title(Span::styled(
            ellipsize(&title, (area.width as usize).saturating_sub(2)),
            theme.header(),
        ));
    let inner = block.inner(area);
    let (w, h) = (inner.width as usize, inner.height as usize);
    let Some((k, e)) = entry else {
        frame.render_widget(block, area);
        return;
    };
    if w == 0 || h == 0 {
        frame.render_widget(block, area);
        return;
    }
    let mut lines: Vec<Line> = Vec::new();
    // Summary: rate, count, age, version and length; the rate asked from here and its outcome.
    let mut summary = vec![Span::raw(format!(
        "{} Hz  {} heard  last {} ago  v{} {} bytes",
        hz_text(e.rate(app.now)),
        e.count,
        age_text(app.now.saturating_sub(e.last)),
        match e.version {
            crate::wire::frame::Version::V1 => 1,
            crate::wire::frame::Version::V2 => 2,
        },
        e.payload().len()
    ))];
    // Off screen a payload is kept once a second: until the next frame, the fields shown are
    // of an earlier one, and say so.
    if e.kept() < e.last {
        summary.push(Span::raw(format!(
            "  fields {} older",
            age_text(e.last - e.kept())
        )));
    }
    if let Some((us, outcome)) = app.inspector_requested(k) {
        let style = match outcome.as_str() {
            "ACCEPTED" => theme.good(),
            "waiting" => theme.header(),
            _ => theme.alert(),
        };
        summary.push(Span::styled(
            format!("  asked {}: {outcome}", interval_text(us)),
            style,
        ));
    } else if let Some(hz) = auto_requested(app, k) {
        // The rate the stream machine asked of this autopilot on the link it is reached by.
        summary.push(Span::raw(format!("  requested {hz} Hz")));
    }
    let summary_text: String = summary.iter().map(|s| s.content.as_ref()).collect();
    if summary_text.chars().count() > w {
        lines.push(Line::raw(ellipsize(&summary_text, w)));
    } else {
        lines.push(Line::from(summary));
    }
    let body_h = h.saturating_sub(1);
    match e.decode(k.2) {
        Ok(msg) => {
            let body = field_lines(&fields_in_units(&msg, v.detail_focus), w);
            let max_scroll = body.len().saturating_sub(body_h);
            let scroll = v.detail_scroll.min(max_scroll);
            for l in body.iter().skip(scroll).take(body_h) {
                lines.push(Line::raw(ellipsize(l, w)));
            }
            if max_scroll > 0 {
                block = block.title_bottom(
                    Line::from(format!(
                        " {}-{}/{} ",
                        scroll + 1,
                        (scroll + body_h).min(body.len()),
                        body.len()
                    ))
                    .right_aligned(),
                );
            }
        }
        Err(why) => {
            let why = wrap_words(&format!("not decoded: {why}; the payload as sent:"), w);
            for l in why.into_iter().take(body_h.saturating_sub(1).max(1)) {
                lines.push(Line::styled(l, theme.alert()));
            }
            let per_line = if w >= 4 + 16 * 3 { 16 } else { 8 };
            let hex = hex_lines(e.payload(), per_line);
            let room = h.saturating_sub(lines.len());
            let scroll = v.detail_scroll.min(hex.len().saturating_sub(room));
            for l in hex.iter().skip(scroll).take(room) {
                lines.push(Line::styled(ellipsize(l, w), theme.dim()));
            }
        }
    }
    lines.truncate(h);
    frame.render_widget(block, area);
    frame.render_widget(Paragraph::new(lines), inner);
}

/// The status bar while a rate is typed: what for, what it is now, the keys.
pub fn rate_prompt(app: &App, k: MsgKey) -> String {
    let name = app.inspector.get(k).map_or("message", |e| e.name);
    let keys: Vec<String> = [(Action::Submit, "sends"), (Action::Cancel, "cancels")]
        .iter()
        .filter_map(|(a, word)| {
            let key = app
                .keymap
                .keys_for(Mode::Edit, app.ui.screen, *a)
                .into_iter()
                .next()?;
            Some(format!("{key} {word}"))
        })
        .collect();
    format!(
        "{name} ({}) Hz, 0 default, -1 off: {}",
        VehicleKey(k.0, k.1),
        keys.join("  ")
    )
}

/// The rate mavterm asked automatically for message `k.2` of autopilot `k.0:k.1`, on the link
/// its commands go by.
fn auto_requested(app: &App, k: (u8, u8, u32)) -> Option<f32> {
    let key = VehicleKey(k.0, k.1);
    let s = app.sessions.get(&key)?;
    let link = app.route(key)?;
    s.streams
        .requested(link)
        .find(|(id, _)| *id == k.2)
        .map(|(_, hz)| hz)
}
