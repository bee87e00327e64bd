//! The Parameters screen (`2`): the target's parameters, filtered, with their values, units and
//! marks, and the selected one explained below.
//!
//! The list's title is the header: the vehicle and component, the download's progress (a gauge
//! and `1187/1354`, MAVFTP or the parameter protocol) or `1354 parameters`, how many the filter
//! shows, the filter (`/ATC_`) and the file loaded. Each row has three mark columns, then the
//! name, the value (`3 (Stabilize)` when the metadata names it, `1 (All)` for a bitmask's bits),
//! the units and the parameter's human name:
//!
//! - `*` changed since the download,
//! - `≠` differs from the file loaded (`param load`/`param diff`),
//! - `…` edit sent and waiting for the echo, `✓` confirmed by the vehicle, `✗` failed.
//!
//! The detail pane below holds the human name, value, default, range, step, type and index,
//! reboot-required and read-only, the edit's outcome, the enumeration's values or the bitmask's
//! bits (the current value and the bits set in `[brackets]`), then the description, cut to fit.
//! While a value is edited it is typed in its row. Numbers are never cut; names may end in `…`.

use ratatui::layout::Rect;
use ratatui::style::{Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Paragraph};
use ratatui::Frame;

use super::{ellipsize, Theme};
use crate::app::params::ParamEdit;
use crate::app::App;
use crate::params::meta::ParamMeta;
use crate::params::value;
use crate::proto::params::{EditState, Method, Param};

/// Longest parameter name shown whole (MAVLink's `param_id` is 16 characters).
const NAME_MAX: usize = 16;

/// Width of the marks before the name: `*≠✓` and a space.
const MARKS: usize = 4;

/// The value as the list shows it: the number, and the enumeration's name or the names of the
/// bits set, in brackets, when the metadata has them.
pub fn value_text(p: &Param, meta: Option<&ParamMeta>) -> (String, Option<String>) {
    let number = p.text();
    let named = meta.and_then(|m| {
        if let Some(n) = m.value_name(p.value) {
            return Some(n.to_string());
        }
        if !m.bits.is_empty() {
            let set = m.bits_set(p.value);
            return (!set.is_empty()).then(|| set.join("+"));
        }
        None
    });
    (number, named)
}

/// `number (name)` in `width` at most, the name cut first; the number is never cut.
fn fit_value(number: &str, named: Option<&str>, width: usize) -> String {
    match named {
        Some(n) => {
            let room = width.saturating_sub(number.chars().count() + 3);
            if room >= 2 {
                format!("{number} ({})", ellipsize(n, room))
            } else {
                number.to_string()
            }
        }
        None => number.to_string(),
    }
}

fn pad(s: &str, width: usize) -> String {
    let n = s.chars().count();
    if n >= width {
        s.to_string()
    } else {
        format!("{s}{}", " ".repeat(width - n))
    }
}

/// `▕████░░░░▏` of `width` characters in all.
fn gauge(got: usize, total: usize, width: usize) -> String {
    let inner = width.saturating_sub(2);
    let full = (got.min(total) * inner).checked_div(total).unwrap_or(0);
    format!("▕{}{}▏", "█".repeat(full), "░".repeat(inner - full))
}

/// The header's parts, most important first: (text, style).
fn header(app: &App, shown: usize, theme: &Theme, width: usize) -> Vec<(String, Style)> {
    let mut parts = Vec::new();
    let Ok((key, comp)) = app.param_target() else {
        parts.push((" Parameters (no target) ".to_string(), theme.focus_border()));
        return parts;
    };
    let who = if comp == key.1 {
        format!(" Parameters {key} ")
    } else {
        format!(" Parameters {key} component {comp} ")
    };
    parts.push((who, theme.focus_border()));
    let session = app.sessions.get(&key);
    let set = app.param_set();
    let running = session
        .and_then(|s| s.params.downloading())
        .filter(|d| d.0 == comp);
    let total = set.map_or(0, |s| s.params.len());
    match (running, set) {
        (Some((_, got, count, method)), _) => {
            let of = count.map_or("?".to_string(), |c| c.to_string());
            let bar = gauge(got, count.unwrap_or(0) as usize, (width / 4).clamp(6, 30));
            parts.push((
                format!(" {} {got}/{of} {bar} ", method.name()),
                theme.header(),
            ));
        }
        (None, Some(s)) => {
            let (got, count) = s.progress();
            let text = match count {
                Some(c) if got < c as usize => {
                    format!(" {got}/{c} parameters ({} missing) ", c as usize - got)
                }
                _ => format!(" {total} parameters "),
            };
            let style = if s.complete() {
                theme.good()
            } else {
                theme.alert()
            };
            parts.push((text, style));
        }
        (None, None) => parts.push((" no parameters yet ".into(), theme.dim())),
    }
    let p = &app.ui.params;
    let filtering = p.editing == Some(ParamEdit::Filter);
    if !p.filter.is_empty() || filtering {
        parts.push((format!(" /{} ", p.filter), theme.header()));
    }
    if !p.filter.is_empty() || p.only_diff {
        parts.push((format!(" {shown} shown "), Style::default()));
    }
    if p.only_diff {
        parts.push((" ≠ only ".into(), theme.header()));
    }
    if let Some(f) = &app.param_file {
        let name = std::path::Path::new(&f.path)
            .file_name()
            .map_or(f.path.clone(), |n| n.to_string_lossy().into_owned());
        parts.push((format!(" file {name} "), Style::default()));
    }
    if running.is_none() {
        if let Some(last) = session
            .and_then(|s| s.params.last.as_ref())
            .filter(|l| l.component == comp)
        {
            if let Some(end) = last.finished {
                let secs = end.saturating_sub(last.started) as f64 / 1e6;
                let how = match last.method {
                    Method::Ftp => "MAVFTP",
                    Method::List => "param protocol",
                };
                parts.push((format!(" via {how} in {secs:.1} s "), theme.dim()));
            }
        }
    }
    parts
}

/// The header parts that fit in `width`, in order; the file's name is cut before it is dropped.
fn fit_header(parts: Vec<(String, Style)>, width: usize) -> Line<'static> {
    let mut used = 0;
    let mut spans = Vec::new();
    for (text, style) in parts {
        let n = text.chars().count();
        if used + n <= width {
            used += n;
            spans.push(Span::styled(text, style));
        } else if text.starts_with(" file ") && width.saturating_sub(used) >= 12 {
            let t = format!("{} ", ellipsize(text.trim_end(), width - used - 1));
            used += t.chars().count();
            spans.push(Span::styled(t, style));
        }
    }
    Line::from(spans)
}

/// Lines of `items` separated by two spaces, filling `width`; an item too long for a line is cut.
fn flow(items: Vec<(String, Style)>, width: usize) -> Vec<Vec<(String, Style)>> {
    let mut lines: Vec<Vec<(String, Style)>> = Vec::new();
    let mut cur: Vec<(String, Style)> = Vec::new();
    let mut used = 0;
    for (text, style) in items {
        let n = text.chars().count();
        let sep = if cur.is_empty() { 0 } else { 2 };
        if !cur.is_empty() && used + sep + n > width {
            lines.push(std::mem::take(&mut cur));
            used = 0;
        }
        if !cur.is_empty() {
            cur.push(("  ".into(), Style::default()));
            used += 2;
        }
        let text = ellipsize(&text, width.max(1));
        used += text.chars().count();
        cur.push((text, style));
    }
    if !cur.is_empty() {
        lines.push(cur);
    }
    lines
}

/// Keep `max` lines; when some are left out, the last kept one ends in `…`.
fn cut(mut lines: Vec<Vec<(String, Style)>>, max: usize, width: usize) -> Vec<Line<'static>> {
    let over = lines.len() > max;
    lines.truncate(max);
    if over {
        if let Some(last) = lines.last_mut() {
            let used: usize = last.iter().map(|(t, _)| t.chars().count()).sum();
            if used + 2 <= width {
                last.push((" …".into(), Style::default()));
            } else if let Some((t, _)) = last.last_mut() {
                let n = t.chars().count();
                *t = ellipsize(&format!("{t}…"), n);
            }
        }
    }
    lines
        .into_iter()
        .map(|l| {
            Line::from(
                l.into_iter()
                    .map(|(t, s)| Span::styled(t, s))
                    .collect::<Vec<_>>(),
            )
        })
        .collect()
}

/// Words of `text` wrapped to `width`.
fn wrap(text: &str, width: usize) -> Vec<Vec<(String, Style)>> {
    let mut lines = Vec::new();
    let mut cur = String::new();
    for word in text.split_whitespace() {
        let n = cur.chars().count();
        if n > 0 && n + 1 + word.chars().count() > width {
            lines.push(vec![(std::mem::take(&mut cur), Style::default())]);
        }
        if !cur.is_empty() {
            cur.push(' ');
        }
        cur.push_str(word);
        if cur.chars().count() > width {
            lines.push(vec![(ellipsize(&cur, width), Style::default())]);
            cur.clear();
        }
    }
    if !cur.is_empty() {
        lines.push(vec![(cur, Style::default())]);
    }
    lines
}

/// The detail pane's lines for `name`.
fn detail(
    app: &App,
    name: &str,
    p: &Param,
    width: usize,
    height: usize,
    theme: &Theme,
) -> Vec<Line<'static>> {
    let meta = app.param_meta(name);
    let mut out: Vec<Line<'static>> = Vec::new();
    out.push(match meta.and_then(|m| m.human_name.clone()) {
        Some(h) => Line::styled(ellipsize(&h, width), theme.header()),
        None if meta.is_some() => Line::styled(ellipsize(name, width), theme.header()),
        None => Line::styled(
            ellipsize(
                "no metadata: :param meta fetch, or --param-meta FILE",
                width,
            ),
            theme.dim(),
        ),
    });
    // Value, default, range, step, type, index, flags.
    let units = meta.and_then(|m| m.units.clone());
    let with_units = |v: String| match &units {
        Some(u) => format!("{v} {u}"),
        None => v,
    };
    let (number, named) = value_text(p, meta);
    let mut facts: Vec<(String, Style)> = Vec::new();
    let shown = match &named {
        Some(n) => format!("{number} ({n})"),
        None => number,
    };
    facts.push((format!("value {}", with_units(shown)), Style::default()));
    if p.changed_since_fetch() {
        if let Some(f) = p.fetched {
            facts.push((
                format!("*was {}", value::format(f, p.ptype)),
                theme.header(),
            ));
        }
    }
    if let Some(f) = app
        .param_file
        .as_ref()
        .and_then(|l| l.values.get(name))
        .filter(|v| !value::same(**v, p.value, p.ptype))
    {
        facts.push((
            format!("≠file {}", value::format(*f, p.ptype)),
            theme.header(),
        ));
    }
    if let Some(d) = p.default.or(meta.and_then(|m| m.default)) {
        facts.push((
            format!("default {}", value::format(d, p.ptype)),
            Style::default(),
        ));
    }
    if let Some((lo, hi)) = meta.and_then(|m| m.range) {
        let side = |x: f64| {
            if x.is_finite() {
                value::fmt_plain(x)
            } else {
                "…".into()
            }
        };
        facts.push((
            format!("range {} to {}", side(lo), with_units(side(hi))),
            Style::default(),
        ));
    }
    if let Some(i) = meta.and_then(|m| m.increment) {
        facts.push((format!("step {}", value::fmt_plain(i)), Style::default()));
    }
    facts.push((p.ptype.name().to_string(), theme.dim()));
    if let Some(i) = p.index {
        facts.push((format!("index {i}"), theme.dim()));
    }
    if meta.is_some_and(|m| m.reboot_required) {
        facts.push(("reboot required".into(), theme.alert()));
    }
    if meta.is_some_and(|m| m.read_only) {
        facts.push(("read-only".into(), theme.alert()));
    }
    let mut head = cut(flow(facts, width), 2, width);
    if let Some(e) = &p.edit {
        let v = value::format(e.value, p.ptype);
        let (text, style) = match &e.state {
            EditState::Pending => (format!("… {v} sent, waiting for the echo"), theme.header()),
            EditState::Confirmed => (format!("✓ {v} confirmed by the vehicle"), theme.good()),
            EditState::Failed(why) => (format!("✗ {v} failed: {why}"), theme.alert()),
        };
        head.push(Line::styled(ellipsize(&text, width), style));
    }
    out.extend(head);
    let remaining = height.saturating_sub(out.len());
    // The enumeration or the bits, then the description.
    let mut choices: Vec<(String, Style)> = Vec::new();
    if let Some(m) = meta {
        let current = Style::default().add_modifier(Modifier::BOLD);
        if !m.values.is_empty() {
            choices.push(("values:".into(), theme.dim()));
            for (c, n) in &m.values {
                let item = format!("{} {n}", value::fmt_plain(*c));
                if *c == p.value {
                    choices.push((format!("[{item}]"), current));
                } else {
                    choices.push((item, Style::default()));
                }
            }
        } else if !m.bits.is_empty() {
            choices.push(("bits:".into(), theme.dim()));
            let set = if p.value.is_finite() {
                p.value as i64 as u64
            } else {
                0
            };
            for (b, n) in &m.bits {
                let item = format!("{b} {n}");
                if *b < 64 && set >> b & 1 == 1 {
                    choices.push((format!("[{item}]"), current));
                } else {
                    choices.push((item, Style::default()));
                }
            }
        }
    }
    // A description that only repeats the human name is left out.
    let description = meta.map_or(String::new(), |m| {
        let same = m.human_name.as_deref().is_some_and(|h| {
            h.trim().trim_end_matches('.') == m.description.trim().trim_end_matches('.')
        });
        if same {
            String::new()
        } else {
            m.description.clone()
        }
    });
    let desc = wrap(&description, width);
    let choices = flow(choices, width);
    let desc_min = desc.len().min((remaining / 3).max(1));
    let choice_lines = choices.len().min(remaining.saturating_sub(desc_min)).max(
        // With no description the choices take every line left.
        if desc.is_empty() {
            remaining.min(choices.len())
        } else {
            0
        },
    );
    out.extend(cut(choices, choice_lines, width));
    let left = height.saturating_sub(out.len());
    out.extend(cut(desc, left, width));
    out.truncate(height);
    out
}

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let area = area.intersection(frame.area());
    if area.width == 0 || area.height == 0 {
        return;
    }
    let rows = app.param_rows();
    let sel = app.ui.params.sel.min(rows.len().saturating_sub(1));
    let width = area.width as usize;
    let inner_w = width.saturating_sub(2);
    let set = app.param_set();
    let selected = rows.get(sel).and_then(|n| Some((n, set?.params.get(n.as_str())?)));
    // The detail pane below the list, when a row is selected: a third of the height, 7 rows
    // at 24.
    let detail_h: u16 = match area.height {
        _ if selected.is_none() => 0,
        h if h >= 14 => (h / 3).clamp(7, 16),
        h if h >= 9 => 4,
        _ => 0,
    };
    let list_area = Rect {
        height: area.height - detail_h,
        ..area
    };
    let detail_area = Rect {
        y: area.y + list_area.height,
        height: detail_h,
        ..area
    };
    let head = fit_header(
        header(app, rows.len(), theme, width),
        inner_w.saturating_sub(2),
    );
    let mut block = Block::default()
        .borders(Borders::ALL)
        .border_style(theme.focus_border())
        .title(head);
    // Values whose name is not a parameter name, refused and counted: said, not hidden.
    if let Some(n) = set.map(|s| s.refused).filter(|n| *n > 0) {
        block = block.title_bottom(Line::from(Span::styled(
            format!(" {n} names refused "),
            theme.alert(),
        )));
    }
    if !rows.is_empty() {
        // A line of column titles above the rows.
        let list_h = block.inner(list_area).height.saturating_sub(1) as usize;
        let first = super::fmt::centred_offset(sel, list_h, rows.len());
        if let Some(more) = super::fmt::list_more(first, list_h, rows.len()) {
            block = block.title_bottom(Line::from(format!(" {more} ")));
        }
        block =
            block.title_bottom(Line::from(format!(" {}/{} ", sel + 1, rows.len())).right_aligned());
    }
    let inner = block.inner(list_area);
    frame.render_widget(block, list_area);
    if rows.is_empty() || set.is_none() {
        let p = &app.ui.params;
        let fetch_key = app
            .keymap
            .keys_for(
                crate::keymap::Mode::Normal,
                "parameters",
                crate::keymap::Action::ParamFetch,
            )
            .first()
            .map_or("`:param fetch`".to_string(), |k| k.to_string());
        let text = if app.target.is_none() {
            "no target: parameters show once an autopilot is heard".to_string()
        } else if set.is_none_or(|s| s.params.is_empty()) {
            match app
                .target
                .and_then(|k| app.sessions.get(&k))
                .and_then(|s| s.params.downloading())
            {
                Some((_, _, _, Method::Ftp)) => {
                    "downloading over MAVFTP: the list fills once the whole file is in".to_string()
                }
                Some(_) => "downloading…".to_string(),
                None => format!("no parameters yet: {fetch_key} downloads them"),
            }
        } else if p.only_diff && p.filter.is_empty() {
            "no parameter differs from the file".to_string()
        } else {
            format!("no parameter matches /{} (esc clears the filter)", p.filter)
        };
        frame.render_widget(
            Paragraph::new(Line::styled(
                ellipsize(&text, inner.width as usize),
                theme.dim(),
            )),
            inner,
        );
    } else if let Some(set) = set {
        render_list(app, frame, inner, theme, &rows, sel, set);
    }
    if detail_h == 0 {
        return;
    }
    let title = selected.map_or(String::new(), |(n, _)| format!(" {n} "));
    let block = Block::default()
        .borders(Borders::ALL)
        .border_style(theme.border())
        .title(Span::styled(title, theme.header()));
    let inner = block.inner(detail_area);
    frame.render_widget(block, detail_area);
    if let Some((name, p)) = selected {
        let lines = detail(
            app,
            name,
            p,
            inner.width as usize,
            inner.height as usize,
            theme,
        );
        frame.render_widget(Paragraph::new(lines), inner);
    }
}

/// The documentation `doc`, its spaces made single, without a first sentence that only says
/// the human `name` again (ArduPilot's often start so: `Roll axis rate controller P gain.
/// Corrects …`); empty when that is all it says.
fn after_name(name: &str, doc: &str) -> String {
    let doc = doc.split_whitespace().collect::<Vec<_>>().join(" ");
    let name = name.split_whitespace().collect::<Vec<_>>().join(" ");
    if name.is_empty() {
        return doc;
    }
    match doc.strip_prefix(&name) {
        Some(rest) if rest.is_empty() || rest == "." => String::new(),
        Some(rest) if rest.starts_with(". ") => rest[2..].to_string(),
        _ => doc,
    }
}

/// From this width of the description column it also holds the documentation.
const WIDE_DESC: usize = 60;

/// From this width of the list the units and description columns do not come and go with the
/// rows in view.
const WIDE_LIST: usize = 120;

fn render_list(
    app: &App,
    frame: &mut Frame,
    area: Rect,
    theme: &Theme,
    rows: &[String],
    sel: usize,
    set: &crate::proto::params::ParamSet,
) {
    let w = area.width as usize;
    let h = area.height as usize;
    if w == 0 || h == 0 {
        return;
    }
    // One line of column titles, then the rows; the selection kept in the middle.
    let list_h = h.saturating_sub(1);
    let offset = super::fmt::centred_offset(sel, list_h, rows.len());
    let visible: Vec<(&String, &Param, Option<&ParamMeta>)> = rows
        .iter()
        .skip(offset)
        .take(list_h)
        .filter_map(|n| Some((n, set.params.get(n.as_str())?, app.param_meta(n))))
        .collect();
    let edit = match &app.ui.params.editing {
        Some(ParamEdit::Value(_, n)) if app.ui.mode == crate::keymap::Mode::Edit => {
            Some(n.as_str())
        }
        _ => None,
    };
    // Columns: the value wide enough for every number shown (and most names), then the name
    // (up to 16), the units, and what is left for the human name.
    let value_cap = (w / 3).clamp(10, 30);
    let mut num_w = 5;
    let mut full_w = 5;
    let mut units_w = 0;
    for (_, p, m) in &visible {
        let (number, named) = value_text(p, *m);
        let n = number.chars().count();
        num_w = num_w.max(n);
        full_w = full_w.max(n + named.map_or(0, |s| s.chars().count() + 3));
        units_w = units_w.max(
            m.and_then(|m| m.units.as_ref())
                .map_or(0, |u| u.chars().count()),
        );
    }
    // Wide, the units column is there for every row the filter keeps, not only those in
    // view: value, units and description stay side by side, in place, while scrolling.
    if w >= WIDE_LIST && units_w == 0 {
        units_w = rows
            .iter()
            .filter_map(|n| app.param_meta(n)?.units.as_ref())
            .map(|u| u.chars().count())
            .max()
            .unwrap_or(0);
    }
    if edit.is_some() {
        full_w = full_w.max(app.ui.edit.text.chars().count() + 1).max(12);
    }
    // Wide enough for the column titles, and steady for most values.
    let units_w = if units_w > 0 { units_w.clamp(5, 10) } else { 0 };
    let mut value_w = num_w.max(full_w.max(10).min(value_cap));
    let name_full = rows
        .iter()
        .map(|n| n.chars().count())
        .max()
        .unwrap_or(4)
        .clamp(4, NAME_MAX);
    let units_block = if units_w > 0 { units_w + 1 } else { 0 };
    let mut name_w = name_full.min(w.saturating_sub(MARKS + 1 + value_w + units_block));
    if name_w < 6 {
        // Narrow: the value takes what the name cannot spare.
        name_w = 6.min(w.saturating_sub(MARKS + 1 + num_w));
        value_w = num_w.max(
            w.saturating_sub(MARKS + 1 + name_w + units_block)
                .min(value_w),
        );
    }
    let units_w = if MARKS + name_w + 1 + value_w + units_block <= w {
        units_w
    } else {
        0
    };
    let used = MARKS + name_w + 1 + value_w + if units_w > 0 { units_w + 1 } else { 0 };
    let desc_w = w.saturating_sub(used + 1);
    let named = |m: Option<&ParamMeta>| m.is_some_and(|m| m.human_name.is_some());
    let show_desc = desc_w >= 8
        && (visible.iter().any(|(_, _, m)| named(*m))
            || (w >= WIDE_LIST && rows.iter().any(|n| named(app.param_meta(n)))));
    let mut lines: Vec<Line> = Vec::with_capacity(h);
    let mut title = format!(
        "{}{} {}",
        " ".repeat(MARKS),
        pad("NAME", name_w),
        pad("VALUE", value_w)
    );
    if units_w > 0 {
        title.push(' ');
        title.push_str(&pad("UNITS", units_w));
    }
    if show_desc {
        title.push_str(" DESCRIPTION");
    }
    lines.push(Line::styled(ellipsize(&title, w), theme.header()));
    let mut cursor = None;
    for (i, (name, p, meta)) in visible.iter().enumerate() {
        let row = offset + i;
        let selected = row == sel;
        let changed = if p.changed_since_fetch() { "*" } else { " " };
        let differs = app
            .param_file
            .as_ref()
            .and_then(|l| l.values.get(*name))
            .is_some_and(|v| !value::same(*v, p.value, p.ptype));
        let (edit_mark, edit_style) = match p.edit.as_ref().map(|e| &e.state) {
            Some(EditState::Pending) => ("…", theme.header()),
            Some(EditState::Confirmed) => ("✓", theme.good()),
            Some(EditState::Failed(_)) => ("✗", theme.alert()),
            None => (" ", Style::default()),
        };
        let base = if selected {
            theme.selected()
        } else {
            Style::default()
        };
        let mut spans = vec![
            Span::styled(changed, theme.header().patch(base)),
            Span::styled(if differs { "≠" } else { " " }, theme.header().patch(base)),
            Span::styled(edit_mark, edit_style.patch(base)),
            Span::styled(" ", base),
            Span::styled(pad(&ellipsize(name, name_w), name_w) + " ", base),
        ];
        if edit == Some(name.as_str()) && selected {
            // The value being typed, in its cell, scrolled to keep the cursor in view.
            let line = &app.ui.edit;
            let room = value_w.saturating_sub(1).max(1);
            let skip = line.cursor.saturating_sub(room);
            let shown: String = line.text.chars().skip(skip).take(room).collect();
            let x = MARKS + name_w + 1 + line.cursor - skip;
            if x < w {
                cursor = Some((area.x + x as u16, area.y + 1 + i as u16));
            }
            spans.push(Span::styled(
                pad(&shown, value_w),
                Style::default().add_modifier(Modifier::UNDERLINED | Modifier::BOLD),
            ));
        } else {
            let (number, named) = value_text(p, *meta);
            spans.push(Span::styled(
                pad(&fit_value(&number, named.as_deref(), value_w), value_w),
                base,
            ));
        }
        if units_w > 0 {
            let u = meta.and_then(|m| m.units.as_deref()).unwrap_or("");
            spans.push(Span::styled(
                format!(" {}", pad(&ellipsize(u, units_w), units_w)),
                base,
            ));
        }
        if show_desc {
            let d = meta.and_then(|m| m.human_name.as_deref()).unwrap_or("");
            // Wide, the documentation follows the human name, on the row, without saying the
            // name again.
            let d = match meta.map(|m| after_name(d, &m.description)) {
                Some(doc) if desc_w >= WIDE_DESC && !doc.is_empty() => format!("{d}: {doc}"),
                _ => d.to_string(),
            };
            spans.push(Span::styled(
                format!(" {}", ellipsize(&d, desc_w)),
                theme.dim().patch(base),
            ));
        }
        if selected {
            super::fmt::pad_row(&mut spans, w, base);
        }
        lines.push(Line::from(spans));
    }
    frame.render_widget(Paragraph::new(lines), area);
    if let Some(c) = cursor {
        frame.set_cursor_position(c);
    }
}
