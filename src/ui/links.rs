//! The links pane: one row per link (state, rates, loss over the 10 s window and since start,
//! CRC errors, sequence counters); an expanded link adds one row per source sysid:compid.

use ratatui::layout::{Constraint, Rect};
use ratatui::style::Style;
use ratatui::text::Span;
use ratatui::widgets::{Cell, Row, Table, TableState};
use ratatui::Frame;

use super::{ellipsize, pane_block, selected_style, Theme};
use crate::app::links::{loss_pct, LinkState, LinkStatus};
use crate::app::{App, Pane};

/// `1.2k` style numbers so rates fit narrow columns.
pub fn human(n: f64) -> String {
    if n >= 10_000_000.0 {
        format!("{:.0}M", n / 1e6)
    } else if n >= 10_000.0 {
        format!("{:.0}k", n / 1e3)
    } else if n >= 100.0 || n == n.trunc() {
        format!("{n:.0}")
    } else {
        format!("{n:.1}")
    }
}

/// (header, width) of the numeric columns: full names when wide, terse when not.
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
            ("L10s", 5),
            ("LOSS", 5),
            ("CRC", 3),
            ("RX", 6),
            ("LOST", 4),
            ("DUP", 3),
            ("REO", 3),
        ]
    }
}

/// Loss percent in at most 5 characters.
fn pct(p: f64) -> String {
    if p >= 9.95 {
        format!("{p:.0}%")
    } else {
        format!("{p:.1}%")
    }
}

fn link_row<'a>(
    id: usize,
    l: &LinkStatus,
    now: u64,
    theme: &Theme,
    spec_w: usize,
    state_w: usize,
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
    Row::new(vec![
        Cell::from(ellipsize(&format!("{mark}{id} {}", l.spec), spec_w)),
        Cell::from(Span::styled(
            ellipsize(&l.state.label(), state_w),
            state_style,
        )),
        Cell::from(human(fps)),
        Cell::from(human(bps)),
        Cell::from(pct(loss_pct(l.window_totals(now)))),
        Cell::from(pct(loss_pct(totals))),
        Cell::from(Span::styled(l.parser.crc_errors.to_string(), crc_style)),
        Cell::from(totals.0.to_string()),
        Cell::from(totals.1.to_string()),
        Cell::from(dup.to_string()),
        Cell::from(reord.to_string()),
    ])
}

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let block = pane_block(app, Pane::Links, format!(" ({})", app.links.len()), theme);
    let inner = block.inner(area);
    frame.render_widget(block, area);
    let cols = columns(inner.width >= 120);
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
    // Table row index of each link, for the selection highlight.
    let mut sel_row = 0;
    for (i, l) in app.links.iter().enumerate() {
        if i == app.ui.link_sel {
            sel_row = rows.len();
        }
        rows.push(link_row(i, l, now, theme, spec_w, state_w));
        if !l.expanded {
            continue;
        }
        for ((sys, comp), s) in &l.sources {
            let q = &s.seq;
            rows.push(
                Row::new(vec![
                    Cell::from(format!("   └ {sys}:{comp}")),
                    Cell::from(""),
                    Cell::from(""),
                    Cell::from(""),
                    Cell::from(pct(q.window_loss_pct(now))),
                    Cell::from(pct(q.loss_pct())),
                    Cell::from(""),
                    Cell::from(q.received.to_string()),
                    Cell::from(q.lost.to_string()),
                    Cell::from(q.duplicates.to_string()),
                    Cell::from(q.reordered.to_string()),
                ])
                .style(theme.dim()),
            );
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
}
