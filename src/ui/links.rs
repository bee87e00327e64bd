//! The links pane: one row per link (state, rates, loss over the 10 s window and since start,
//! CRC errors, sequence counters); an expanded link adds one row per source sysid:compid, and
//! under it a line of MAVLink signing counts (signed, unsigned, bad signature, replayed,
//! timestamps from the future, rejected) when we sign or the source does. Below them, the forwarding outputs (`--out`), when
//! there are any: state, frames sent to the ground station there, frames it sent, frames dropped.

use ratatui::buffer::Buffer;
use ratatui::layout::{Constraint, Rect};
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::Frame;

use super::{ellipsize, fast, fmt, pane_block, selected_style, Theme};
use crate::app::links::{loss_pct, LinkState, LinkStatus, SourceStats};
use crate::app::signing::SigningCounts;
use crate::app::{App, Pane};
use crate::link::LinkSpec;
use crate::proto::vehicles::VehicleKey;

/// The signing line under a source row: `signing: signed 120 · unsigned 5 · bad sig 3 ·
/// replayed 1 · future 1 · rejected 10` with a key (the `signing:` label when `width` has room
/// for it); without one, signed frames are unchecked.
fn signing_line<'a>(c: &SigningCounts, key: bool, width: u16, theme: &Theme) -> Line<'a> {
    let dim = theme.dim();
    let n = |label: &'static str, v: u64, bad: bool| -> Vec<Span<'a>> {
        let style = if bad && v > 0 { theme.alert() } else { dim };
        vec![
            Span::styled(format!("{label} "), dim),
            Span::styled(v.to_string(), style),
        ]
    };
    let sep = || Span::styled(" · ", dim);
    let mut spans = vec![Span::styled("     signing: ", dim)];
    if key {
        // The counts fit 80 columns; the label only when there is room beside them.
        let counts = [
            c.signed,
            c.unsigned,
            c.bad_signature,
            c.replayed + c.too_old,
            c.future,
            c.rejected,
        ];
        let digits: usize = counts.iter().map(|v| v.to_string().len()).sum();
        // "     signing: " + labels, spaces and separators.
        if 14 + 64 + digits > width as usize {
            spans[0] = Span::styled("     ", dim);
        }
        spans.extend(n("signed", c.signed, false));
        spans.push(sep());
        spans.extend(n("unsigned", c.unsigned, false));
        spans.push(sep());
        spans.extend(n("bad sig", c.bad_signature, true));
        spans.push(sep());
        spans.extend(n("replayed", c.replayed + c.too_old, true));
        spans.push(sep());
        spans.extend(n("future", c.future, true));
        spans.push(sep());
        spans.extend(n("rejected", c.rejected, true));
    } else {
        spans.extend(n("signed", c.unchecked + c.signed, false));
        spans.push(Span::styled(" unchecked (no key)", theme.alert()));
        spans.push(sep());
        spans.extend(n("unsigned", c.unsigned, false));
    }
    Line::from(spans)
}

/// A frame or byte rate in `width` columns: one decimal below 100 unless whole, abbreviated
/// (`12.3M`) rather than cut when too wide.
fn rate(x: f64, width: u16) -> String {
    let decimals = if x < 100.0 && x != x.trunc() { 1 } else { 0 };
    fmt::real(x, decimals, width as usize)
}

/// (header, width) of the numeric columns: full names when wide, terse when not. Every width is
/// at least 4, in which any number fits abbreviated (see [`fmt`]); LOST gets 5 so that tens of
/// thousands lost stay exact.
fn columns(wide: bool) -> [(&'static str, u16); 9] {
    if wide {
        [
            ("FR/S", 5),
            ("B/S", 6),
            ("LOSS10s", 7),
            ("LOSS", 6),
            ("CRC", 4),
            ("RX", 7),
            ("LOST", 5),
            ("DUP", 4),
            ("REORD", 5),
        ]
    } else {
        [
            ("F/S", 4),
            ("B/S", 5),
            ("L10s", 4),
            ("LOSS", 4),
            ("CRC", 4),
            ("RX", 6),
            ("LOST", 5),
            ("DUP", 4),
            ("REO", 4),
        ]
    }
}

/// Loss percent in at most 4 characters (`100%`, `9.9%`).
fn pct(p: f64) -> String {
    if p >= 9.95 {
        format!("{p:.0}%")
    } else {
        format!("{p:.1}%")
    }
}

/// Widths of the numeric columns, in order.
type Widths = [u16; 9];

/// A table cell: its text, and its style when it is a styled `Span` (else plain text).
type Cell = (String, Option<Style>);

/// The counter cells shared by link and source rows: CRC, RX, LOST, DUP, REO.
fn counts(w: &Widths, crc: Cell, rx: u64, lost: u64, dup: u64, reord: u64) -> [Cell; 5] {
    let n = |v: u64, i: usize| (fmt::count(v, w[i] as usize), None);
    [crc, n(rx, 5), n(lost, 6), n(dup, 7), n(reord, 8)]
}

fn link_row(
    l: &LinkStatus,
    now: u64,
    theme: &Theme,
    (name, name_w, state_w): (&str, usize, usize),
    w: &Widths,
) -> Vec<Cell> {
    let (fps, bps) = l.rate.rates(now);
    let (dup, reord) = l.sources.values().fold((0, 0), |(d, r), s| {
        (d + s.seq.duplicates, r + s.seq.reordered)
    });
    let totals = l.totals();
    let crc_style = if l.parser.crc_errors > 0 {
        theme.alert()
    } else {
        Style::default()
    };
    let crc = (
        fmt::count(l.parser.crc_errors, w[4] as usize),
        Some(crc_style),
    );
    let mut cells = vec![
        (fmt::fit(name, name_w).into_owned(), None),
        (
            fmt::fit(&l.state.label(), state_w).into_owned(),
            Some(state_style(&l.state, theme)),
        ),
        (rate(fps, w[0]), None),
        (rate(bps, w[1]), None),
        (pct(loss_pct(l.window_totals(now))), None),
        (pct(loss_pct(totals)), None),
    ];
    cells.extend(counts(w, crc, totals.0, totals.1, dup, reord));
    cells
}

fn state_style(state: &LinkState, theme: &Theme) -> Style {
    match state {
        LinkState::Up => theme.good(),
        LinkState::Connecting => theme.dim(),
        LinkState::Down(_) => theme.alert(),
    }
}

/// A link's name in two parts: a short one that comes first and is never the part cut (the
/// scheme and port of a network link, `serial:` and the device's file name, `sim`, `tlog:` and
/// `tlog`), and the rest of the spec (host, baud, options, file name), which may be.
fn name_parts(spec: &str) -> (String, String, bool) {
    let base = |p: &str| p.rsplit('/').next().unwrap_or(p).to_string();
    match spec.parse::<LinkSpec>() {
        Ok(LinkSpec::UdpIn { addr, port, .. }) => (format!("udpin:{port}"), addr, true),
        Ok(LinkSpec::UdpOut { host, port, .. }) => (format!("udpout:{port}"), host, true),
        Ok(LinkSpec::TcpClient { host, port, .. }) => (format!("tcp:{port}"), host, true),
        Ok(LinkSpec::TcpServer { addr, port, .. }) => (format!("tcpin:{port}"), addr, true),
        Ok(LinkSpec::Serial { path, baud, .. }) => (
            format!("serial:{}", base(&path)),
            baud.map_or(String::new(), |b| b.to_string()),
            false,
        ),
        Ok(LinkSpec::Sim { query }) => ("sim".into(), query, false),
        Ok(LinkSpec::Tlog { path, .. }) => ("tlog".into(), base(&path), false),
        Err(_) => (spec.to_string(), String::new(), false),
    }
}

/// Each link's short name, as the Links and Vehicles panes show it, telling the links apart:
/// `udpin:14550`, `tcp:5760` (with `@HOST` when two links share scheme and port),
/// `serial:ttyUSB0`, `tlog`, `sim` (with the options that differ when there are several:
/// `sim?seed=2`); a name still shared (two tlogs, two identical sims) gets `#ID`: `tlog#3`.
pub fn short_names(app: &App) -> Vec<String> {
    let parts: Vec<(String, String, bool)> =
        app.links.iter().map(|l| name_parts(&l.spec)).collect();
    let opts = |q: &str| -> Vec<String> {
        q.split('&')
            .filter(|o| !o.is_empty())
            .map(str::to_string)
            .collect()
    };
    let sims: Vec<Vec<String>> = parts
        .iter()
        .filter(|p| p.0 == "sim")
        .map(|p| opts(&p.1))
        .collect();
    let mut names: Vec<String> = parts
        .iter()
        .map(|(short, rest, _)| {
            if short != "sim" || sims.len() < 2 {
                return short.clone();
            }
            let differ: Vec<String> = opts(rest)
                .into_iter()
                .filter(|o| !sims.iter().all(|s| s.contains(o)))
                .collect();
            if differ.is_empty() {
                short.clone()
            } else {
                format!("sim?{}", differ.join("&"))
            }
        })
        .collect();
    let shared = |names: &[String], i: usize| names.iter().filter(|n| **n == names[i]).count() > 1;
    let with_host: Vec<bool> = (0..names.len())
        .map(|i| parts[i].2 && shared(&names, i))
        .collect();
    for (i, host) in with_host.into_iter().enumerate() {
        if host {
            names[i] = format!("{}@{}", names[i], parts[i].1);
        }
    }
    let with_id: Vec<bool> = (0..names.len()).map(|i| shared(&names, i)).collect();
    for (i, id) in with_id.into_iter().enumerate() {
        if id {
            names[i] = format!("{}#{i}", names[i]);
        }
    }
    names
}

/// The LINK cell's text: expand mark, id, short name, then the rest of the spec when the short
/// name does not already say it.
fn link_name(id: usize, l: &LinkStatus, short: &str) -> String {
    let mark = if l.sources.is_empty() {
        " "
    } else if l.expanded {
        "-"
    } else {
        "+"
    };
    let (base, rest, net) = name_parts(&l.spec);
    let spec: Option<LinkSpec> = l.spec.parse().ok();
    let mut options = Vec::new();
    if spec.as_ref().is_some_and(|s| s.high_latency()) {
        options.push("hl=1");
    }
    if spec.as_ref().is_some_and(|s| s.secure()) {
        options.push("secure=1");
    }
    let mut text = format!("{mark}{id} {short}");
    // A name made distinct (`tcp:5760@HOST`, `sim?seed=2`) already says the rest.
    let said = short != base && (net || base == "sim");
    if !rest.is_empty() && !said {
        // `sim?vehicles=2&seed=7`, `tcp:5760 127.0.0.1`.
        text.push(if base == "sim" { '?' } else { ' ' });
        text.push_str(&rest);
    }
    if !options.is_empty() {
        text.push_str(&format!(" ?{}", options.join("&")));
    }
    text
}

/// The selected link in full, under the table: `» 1 tcp:127.0.0.1:5761  down: Connection refused
/// (os error 111) …`, wrapped in at most `max_lines` lines of `width`; the last ends with `…` when
/// even those are not enough.
fn detail_lines<'a>(
    id: usize,
    l: &LinkStatus,
    width: usize,
    max_lines: usize,
    theme: &Theme,
) -> Vec<Line<'a>> {
    let text = format!("» {id} {}  {}", l.spec, l.state.label());
    let mut lines = fmt::wrap(&text, width);
    if lines.len() > max_lines {
        let rest = lines.split_off(max_lines.saturating_sub(1));
        let last = fmt::fit(&rest.join(" "), width).into_owned();
        lines.push(last);
        lines.truncate(max_lines);
    }
    let style = match l.state {
        LinkState::Down(_) => theme.alert(),
        _ => Style::default(),
    };
    lines.into_iter().map(|t| Line::styled(t, style)).collect()
}

/// Inner width below which the 10 s loss and the LOST, DUP and REO counts are left out, so that
/// the link's name and state keep room.
const NARROW: u16 = 70;

/// Numeric columns shown narrow: F/S, B/S, LOSS, CRC, RX.
const NARROW_SHOWN: [bool; 9] = [true, true, false, true, true, true, false, false, false];

/// From this inner width the columns spread into the room left over.
const SPREAD: u16 = 150;

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let key = app.signing.key.is_some();
    let title = if key {
        format!(" ({}) · signing on", app.links.len())
    } else {
        format!(" ({})", app.links.len())
    };
    let mut block = pane_block(app, Pane::Links, title, theme);
    let mut inner = block.inner(area);
    let outputs = &app.outputs.list;
    let mut outputs_area = None;
    if !outputs.is_empty() && inner.height >= 4 {
        // The outputs' header and rows below the links, which keep their header and a row.
        let want = (outputs.len() as u16).saturating_add(1);
        let h = want.min(inner.height - 2);
        outputs_area = Some(Rect {
            y: inner.y + inner.height - h,
            height: h,
            ..inner
        });
        inner.height -= h;
    }
    // The selected link in full under the table, when the table keeps its header and a row.
    let sel_link = app.ui.link_sel.min(app.links.len().saturating_sub(1));
    let mut detail = None;
    if let Some(l) = app.links.get(sel_link) {
        let room = inner.height.saturating_sub(2) as usize;
        let lines = detail_lines(sel_link, l, inner.width as usize, room.min(2), theme);
        let h = (lines.len() as u16).min(room as u16);
        let at = Rect {
            y: inner.y + inner.height - h,
            height: h,
            ..inner
        };
        inner.height -= h;
        detail = Some((lines, at));
    }
    let narrow = inner.width < NARROW;
    let cols = columns(inner.width >= 120);
    let w: Widths = cols.map(|c| c.1);
    let shown: Vec<bool> = (0..9).map(|i| !narrow || NARROW_SHOWN[i]).collect();
    let short = short_names(app);
    let names: Vec<String> = app
        .links
        .iter()
        .enumerate()
        .map(|(i, l)| link_name(i, l, &short[i]))
        .collect();
    let states: Vec<String> = app.links.iter().map(|l| l.state.label()).collect();
    // The name and the state take what the numbers leave: first the short names (up to 16
    // columns) and 10 of the state (`down: Con…`), then all of the state, then all of the name.
    let heads: Vec<String> = app
        .links
        .iter()
        .enumerate()
        .map(|(i, _)| format!("  {i} {}", short[i]))
        .collect();
    let head_w = heads.iter().map(|h| fmt::width(h)).max().unwrap_or(0);
    let name_col = fmt::Col::text(4, names.iter().map(|s| s.as_str()).chain(["LINK"]));
    let state_col = fmt::Col::text(5, states.iter().map(|s| s.as_str()).chain(["STATE"]));
    let mut spec: Vec<fmt::Col> = vec![
        fmt::Col {
            min: head_w.clamp(4, 16).min(name_col.want),
            ..name_col
        },
        fmt::Col {
            min: state_col.want.min(10),
            ..state_col
        },
    ];
    spec.extend(
        cols.iter()
            .zip(&shown)
            .filter(|c| *c.1)
            .map(|c| fmt::Col::fixed(c.0 .1 as usize)),
    );
    let sw = fmt::share(&spec, inner.width as usize, 1, &[1, 0]);
    let (name_w, state_w) = (sw[0], sw[1]);
    // Wide, what the columns leave spreads them out (up to 3 apart), after the name and state
    // have all they want.
    let used: usize = sw.iter().sum::<usize>() + sw.len().saturating_sub(1);
    let pad = if inner.width >= SPREAD && sw.len() > 1 {
        ((inner.width as usize).saturating_sub(used) / (sw.len() - 1)).min(2)
    } else {
        0
    };
    let widths: Vec<Constraint> = sw
        .iter()
        .enumerate()
        .map(|(i, &x)| Constraint::Length((x + if i + 1 < sw.len() { pad } else { 0 }) as u16))
        .collect();
    let mut header = vec![
        fmt::fit("LINK", name_w).into_owned(),
        fmt::fit("STATE", state_w).into_owned(),
    ];
    header.extend(
        cols.iter()
            .zip(&shown)
            .filter(|c| *c.1)
            .map(|c| c.0 .0.to_string()),
    );

    let now = app.now;
    // The table's rows; the cells of those shown are made when drawn.
    let mut rows = Vec::new();
    // Table row index of each link, for the selection highlight.
    let mut sel_row = 0;
    for (i, l) in app.links.iter().enumerate() {
        if i == sel_link {
            sel_row = rows.len();
        }
        rows.push(TableRow::Link(i));
        if !l.expanded {
            continue;
        }
        for (src, s) in &l.sources {
            rows.push(TableRow::Source(src, s));
            // Text wider than a column, drawn across the row.
            if key || s.signing.any_signing() {
                rows.push(TableRow::Signing(&s.signing));
            }
        }
    }
    if app.links.is_empty() {
        rows.push(TableRow::Empty);
    }
    // Every row is one line high, under a one-line header; the window follows the selection.
    let visible = inner.height.saturating_sub(1) as usize;
    let total = rows.len();
    let first = fmt::scroll_offset(sel_row, visible, total);
    if let Some(more) = fmt::list_more(first, visible, total) {
        block.bottom = Some(format!(" {more} "));
    }
    let buf = frame.buffer_mut();
    block.render(buf, area);
    if let Some(bottom) = outputs_area {
        render_outputs(app, buf, bottom, theme);
    }
    if let Some((lines, at)) = detail {
        for (l, y) in lines.iter().zip(at.top()..at.bottom()) {
            fast::paragraph_line(buf, Rect { y, height: 1, ..at }, l);
        }
    }
    let table = fast::Table::new(inner, &widths, 1);
    if table.is_empty() {
        return;
    }
    table.header(buf, theme.header(), header.iter().map(String::as_str));
    let selected = (!app.links.is_empty()).then_some(sel_row);
    let highlight = selected_style(app, Pane::Links, theme);
    // Only the cells of the columns shown, in order.
    let draw = |buf: &mut Buffer, y: u16, cells: Vec<Cell>| {
        let kept = cells
            .into_iter()
            .enumerate()
            .filter(|(i, _)| *i < 2 || shown[*i - 2])
            .map(|c| c.1);
        for (col, (text, style)) in kept.enumerate() {
            match style {
                Some(style) => table.span(buf, y, col, &text, style),
                None => table.raw(buf, y, col, &text),
            }
        }
    };
    let (start, end) = table.visible(first, selected, total);
    for (k, row) in rows[start..end].iter().enumerate() {
        let y = table.row_y(k);
        match *row {
            TableRow::Link(i) => {
                draw(
                    buf,
                    y,
                    link_row(&app.links[i], now, theme, (&names[i], name_w, state_w), &w),
                );
            }
            TableRow::Source(src, s) => {
                table.patch_row(buf, y, theme.dim());
                let q = &s.seq;
                let blank = || (String::new(), None);
                let mut cells = vec![
                    (fmt::fit(&format!("   └ {src}"), name_w).into_owned(), None),
                    blank(),
                    blank(),
                    blank(),
                    (pct(q.window_loss_pct(now)), None),
                    (pct(q.loss_pct()), None),
                ];
                cells.extend(counts(
                    &w,
                    blank(),
                    q.received,
                    q.lost,
                    q.duplicates,
                    q.reordered,
                ));
                draw(buf, y, cells);
            }
            TableRow::Signing(c) => {
                let line = signing_line(c, key, inner.width, theme);
                fast::paragraph_line(buf, table.row_area(y), &line);
            }
            TableRow::Empty => table.span(buf, y, 0, "no links", theme.dim()),
        }
        if selected == Some(start + k) {
            table.patch_row(buf, y, highlight);
        }
    }
}

/// A row of the links' table.
enum TableRow<'a> {
    Link(usize),
    Source(&'a VehicleKey, &'a SourceStats),
    /// The signing counts under a source, drawn across the row.
    Signing(&'a SigningCounts),
    /// There are no links.
    Empty,
}

/// The outputs' table: where frames are forwarded, its state, frames sent there, frames it sent
/// (carried to the vehicles), frames dropped.
fn render_outputs(app: &App, buf: &mut Buffer, area: Rect, theme: &Theme) {
    const NUM_W: u16 = 8;
    let fixed = 3 * (NUM_W + 1) + 1;
    let rest = area.width.saturating_sub(fixed) as usize;
    let state_w = (rest * 2 / 5).clamp(4, 40);
    let spec_w = rest.saturating_sub(state_w).clamp(4, 48);
    let widths = [
        Constraint::Length(spec_w as u16),
        Constraint::Length(state_w as u16),
        Constraint::Length(NUM_W),
        Constraint::Length(NUM_W),
        Constraint::Length(NUM_W),
    ];
    let table = fast::Table::new(area, &widths, 1);
    if table.is_empty() {
        return;
    }
    table.header(
        buf,
        theme.header(),
        ["OUTPUT", "STATE", "SENT", "RECEIVED", "DROPPED"],
    );
    let list = &app.outputs.list;
    let n = |v: u64| fmt::count(v, NUM_W as usize);
    let (start, end) = table.visible(0, None, list.len());
    for (k, i) in (start..end).enumerate() {
        let o = &list[i];
        let y = table.row_y(k);
        let state_style = match o.state {
            LinkState::Up => theme.good(),
            LinkState::Connecting => theme.dim(),
            LinkState::Down(_) => theme.alert(),
        };
        let drop_style = if o.dropped > 0 {
            theme.alert()
        } else {
            Style::default()
        };
        table.raw(buf, y, 0, &ellipsize(&format!(" {i} {}", o.spec), spec_w));
        table.span(
            buf,
            y,
            1,
            &ellipsize(&o.state.label(), state_w),
            state_style,
        );
        table.raw(buf, y, 2, &n(o.sent));
        table.raw(buf, y, 3, &n(o.received));
        table.span(buf, y, 4, &n(o.dropped), drop_style);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::app::AppConfig;

    fn names(links: &[&str]) -> Vec<String> {
        let app = App::new(AppConfig {
            links: links.iter().map(|s| s.to_string()).collect(),
            ..AppConfig::default()
        });
        short_names(&app)
    }

    #[test]
    fn short_names_put_the_port_first_and_tell_links_apart() {
        assert_eq!(
            names(&[
                "udpin:0.0.0.0:14550",
                "tcp:127.0.0.1:5760",
                "serial:/dev/ttyUSB0:57600",
                "tlog:logs/flight.tlog",
                "sim://",
            ]),
            ["udpin:14550", "tcp:5760", "serial:ttyUSB0", "tlog", "sim"]
        );
        // Same scheme and port: the host tells them apart.
        assert_eq!(
            names(&[
                "tcp:10.0.0.1:5760",
                "tcp:10.0.0.2:5760",
                "udpout:10.0.0.1:5760"
            ]),
            ["tcp:5760@10.0.0.1", "tcp:5760@10.0.0.2", "udpout:5760"]
        );
        // Simulators: the options that differ; none differ: the link id.
        assert_eq!(
            names(&["sim://?vehicles=1&seed=1", "sim://?vehicles=1&seed=2"]),
            ["sim?seed=1", "sim?seed=2"]
        );
        assert_eq!(
            names(&[
                "sim://?seed=1",
                "sim://?seed=1",
                "tlog:a.tlog",
                "tlog:b.tlog"
            ]),
            ["sim#0", "sim#1", "tlog#2", "tlog#3"]
        );
    }
}
