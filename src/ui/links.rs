//! The links pane: one row per link (state, rates, loss over the 10 s window and since start,
//! CRC errors, sequence counters); an expanded link adds one row per source sysid:compid, and
//! under it a line of MAVLink signing counts (signed, unsigned, bad signature, replayed,
//! rejected) when we sign or the source does. Below them, the forwarding outputs (`--out`), when
//! there are any: state, frames sent to the ground station there, frames it sent, frames dropped.

use ratatui::layout::{Constraint, Rect};
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Cell, Paragraph, Row, Table, TableState};
use ratatui::Frame;

use super::{ellipsize, fmt, pane_block, selected_style, Theme};
use crate::app::links::{loss_pct, LinkState, LinkStatus};
use crate::app::signing::SigningCounts;
use crate::app::{App, Pane};

/// The signing line under a source row: `signed 120 · unsigned 5 · bad sig 3 · replayed 1 ·
/// rejected 9` with a key; without one, signed frames are unchecked.
fn signing_line<'a>(c: &SigningCounts, key: bool, theme: &Theme) -> Line<'a> {
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
        spans.extend(n("signed", c.signed, false));
        spans.push(sep());
        spans.extend(n("unsigned", c.unsigned, false));
        spans.push(sep());
        spans.extend(n("bad sig", c.bad_signature, true));
        spans.push(sep());
        spans.extend(n("replayed", c.replayed + c.too_old, true));
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

/// The counter cells shared by link and source rows: CRC, RX, LOST, DUP, REO.
fn counts<'a>(
    w: &Widths,
    crc: Cell<'a>,
    rx: u64,
    lost: u64,
    dup: u64,
    reord: u64,
) -> [Cell<'a>; 5] {
    let n = |v: u64, i: usize| Cell::from(fmt::count(v, w[i] as usize));
    [crc, n(rx, 5), n(lost, 6), n(dup, 7), n(reord, 8)]
}

fn link_row<'a>(
    id: usize,
    l: &LinkStatus,
    now: u64,
    theme: &Theme,
    (spec_w, state_w): (usize, usize),
    w: &Widths,
) -> Row<'a> {
    let (fps, bps) = l.rate.rates(now);
    let (dup, reord) = l.sources.values().fold((0, 0), |(d, r), s| {
        (d + s.seq.duplicates, r + s.seq.reordered)
    });
    let totals = l.totals();
    let mark = if l.sources.is_empty() {
        " "
    } else if l.expanded {
        "-"
    } else {
        "+"
    };
    let state_style = match l.state {
        LinkState::Up => theme.good(),
        LinkState::Connecting => theme.dim(),
        LinkState::Down(_) => theme.alert(),
    };
    let crc_style = if l.parser.crc_errors > 0 {
        theme.alert()
    } else {
        Style::default()
    };
    let crc = Cell::from(Span::styled(
        fmt::count(l.parser.crc_errors, w[4] as usize),
        crc_style,
    ));
    let mut cells = vec![
        Cell::from(ellipsize(&format!("{mark}{id} {}", l.spec), spec_w)),
        Cell::from(Span::styled(
            ellipsize(&l.state.label(), state_w),
            state_style,
        )),
        Cell::from(rate(fps, w[0])),
        Cell::from(rate(bps, w[1])),
        Cell::from(pct(loss_pct(l.window_totals(now)))),
        Cell::from(pct(loss_pct(totals))),
    ];
    cells.extend(counts(w, crc, totals.0, totals.1, dup, reord));
    Row::new(cells)
}

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let key = app.signing.key.is_some();
    let title = if key {
        format!(" ({}) · signing on", app.links.len())
    } else {
        format!(" ({})", app.links.len())
    };
    let block = pane_block(app, Pane::Links, title, theme);
    let mut inner = block.inner(area);
    frame.render_widget(block, area);
    let outputs = &app.outputs.list;
    if !outputs.is_empty() && inner.height >= 4 {
        // The outputs' header and rows below the links, which keep their header and a row.
        let want = (outputs.len() as u16).saturating_add(1);
        let h = want.min(inner.height - 2);
        let bottom = Rect {
            y: inner.y + inner.height - h,
            height: h,
            ..inner
        };
        inner.height -= h;
        render_outputs(app, frame, bottom, theme);
    }
    let cols = columns(inner.width >= 120);
    let w: Widths = cols.map(|c| c.1);
    let fixed: u16 = cols.iter().map(|c| c.1 + 1).sum::<u16>() + 1;
    let rest = inner.width.saturating_sub(fixed) as usize;
    // Spec and state share what the numbers leave; the spec gets more.
    let state_w = (rest * 2 / 5).clamp(4, 40);
    let spec_w = rest.saturating_sub(state_w).clamp(4, 48);
    let mut widths = vec![
        Constraint::Length(spec_w as u16),
        Constraint::Length(state_w as u16),
    ];
    widths.extend(cols.iter().map(|c| Constraint::Length(c.1)));
    let mut header = vec!["LINK", "STATE"];
    header.extend(cols.iter().map(|c| c.0));

    let now = app.now;
    let mut rows = Vec::new();
    // Lines drawn over the table after it: (row index, line), for text wider than a column.
    let mut overlays = Vec::new();
    // Table row index of each link, for the selection highlight.
    let mut sel_row = 0;
    for (i, l) in app.links.iter().enumerate() {
        if i == app.ui.link_sel {
            sel_row = rows.len();
        }
        rows.push(link_row(i, l, now, theme, (spec_w, state_w), &w));
        if !l.expanded {
            continue;
        }
        for ((sys, comp), s) in &l.sources {
            let q = &s.seq;
            let mut cells = vec![
                Cell::from(ellipsize(&format!("   └ {sys}:{comp}"), spec_w)),
                Cell::from(""),
                Cell::from(""),
                Cell::from(""),
                Cell::from(pct(q.window_loss_pct(now))),
                Cell::from(pct(q.loss_pct())),
            ];
            cells.extend(counts(
                &w,
                Cell::from(""),
                q.received,
                q.lost,
                q.duplicates,
                q.reordered,
            ));
            rows.push(Row::new(cells).style(theme.dim()));
            if key || s.signing.any_signing() {
                overlays.push((rows.len(), signing_line(&s.signing, key, theme)));
                rows.push(Row::new(vec![Cell::from("")]));
            }
        }
    }
    if app.links.is_empty() {
        rows.push(Row::new(vec![Cell::from(Span::styled(
            "no links",
            theme.dim(),
        ))]));
    }
    let table = Table::new(rows, widths)
        .header(Row::new(header).style(theme.header()))
        .column_spacing(1)
        .row_highlight_style(selected_style(app, Pane::Links, theme));
    let mut state = TableState::default().with_selected((!app.links.is_empty()).then_some(sel_row));
    frame.render_stateful_widget(table, inner, &mut state);
    // Every row is one line high, under a one-line header.
    let first = state.offset();
    for (row, line) in overlays {
        let Some(y) = row
            .checked_sub(first)
            .and_then(|r| u16::try_from(r + 1).ok())
            .filter(|&dy| dy < inner.height)
        else {
            continue;
        };
        let at = Rect {
            y: inner.y + y,
            height: 1,
            ..inner
        };
        frame.render_widget(Paragraph::new(line), at);
    }
}

/// The outputs' table: where frames are forwarded, its state, frames sent there, frames it sent
/// (carried to the vehicles), frames dropped.
fn render_outputs(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
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
    let n = |v: u64| Cell::from(fmt::count(v, NUM_W as usize));
    let rows: Vec<Row> = app
        .outputs
        .list
        .iter()
        .enumerate()
        .map(|(i, o)| {
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
            Row::new(vec![
                Cell::from(ellipsize(&format!(" {i} {}", o.spec), spec_w)),
                Cell::from(Span::styled(
                    ellipsize(&o.state.label(), state_w),
                    state_style,
                )),
                n(o.sent),
                n(o.received),
                Cell::from(Span::styled(
                    fmt::count(o.dropped, NUM_W as usize),
                    drop_style,
                )),
            ])
        })
        .collect();
    let header =
        Row::new(vec!["OUTPUT", "STATE", "SENT", "RECEIVED", "DROPPED"]).style(theme.header());
    let table = Table::new(rows, widths).header(header).column_spacing(1);
    frame.render_widget(table, area);
}
