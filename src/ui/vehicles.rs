//! The vehicles pane: one row per component heard by heartbeat.
//!
//! The target is marked `>`; lost components are dimmed with "lost Ns ago"; a sysid clash or a
//! component using our GCS sysid is flagged in red (and in words, for NO_COLOR). Narrow screens
//! drop the autopilot column and abbreviate flags.

use ratatui::layout::{Constraint, Rect};
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Cell, Paragraph, Row, Table, TableState};
use ratatui::Frame;

use super::{ellipsize, fmt, pane_block, selected_style, Theme};
use crate::app::{App, Pane};
use crate::proto::vehicles::Vehicle;

/// Inner width from which every column is shown.
const WIDE: u16 = 110;
/// Width of the LAST HB column.
const AGE_W: u16 = 12;
/// Width of the HZ column.
const HZ_W: u16 = 4;

/// "0.4s" while heard; "lost 12s ago" once lost, in at most `width` characters: longer ages
/// in larger units ("lost 10m40s ago"), without "ago" if that does not fit ("lost 10m40s").
pub fn age_text(v: &Vehicle, now: crate::clock::Micros, width: usize) -> String {
    let age = v.age_secs(now);
    let dur = fmt::duration(age.round() as u64);
    let candidates = if v.lost {
        vec![format!("lost {dur} ago"), format!("lost {dur}"), dur]
    } else {
        vec![format!("{age:.1}s"), dur]
    };
    let last = candidates.last().cloned().unwrap_or_default();
    candidates
        .into_iter()
        .find(|c| c.chars().count() <= width)
        .unwrap_or_else(|| ellipsize(&last, width))
}

/// What is wrong with a component, in words.
pub fn flags_text(v: &Vehicle, wide: bool) -> String {
    let mut f = Vec::new();
    if v.uses_gcs_sysid {
        f.push(if wide { "GCS SYSID!" } else { "GCSID!" }.to_string());
    }
    if let Some(c) = &v.conflict {
        f.push(if wide {
            format!("CLASH: {c}")
        } else {
            "CLASH!".to_string()
        });
    }
    f.join(" ")
}

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let block = pane_block(
        app,
        Pane::Vehicles,
        format!(" ({})", app.vehicles.len()),
        theme,
    );
    let inner = block.inner(area);
    frame.render_widget(block, area);
    if app.vehicles.is_empty() {
        let p = Paragraph::new(Line::styled("no vehicles heard yet", theme.dim()));
        frame.render_widget(p, inner);
        return;
    }
    let wide = inner.width >= WIDE;
    let links_w = if wide { 5 } else { 4 };
    // (header, width) of every column but the last (FLAGS), which takes what is left.
    let mut cols = vec![("", 1), ("ID", 7), ("TYPE", if wide { 12 } else { 10 })];
    if wide {
        cols.push(("AUTOPILOT", 13));
    }
    cols.extend([
        ("MODE", if wide { 12 } else { 9 }),
        ("ARMED", 8),
        ("STATUS", if wide { 11 } else { 8 }),
        ("LAST HB", AGE_W),
        ("HZ", HZ_W),
        (if wide { "LINKS" } else { "LINK" }, links_w),
    ]);
    let used: u16 = cols.iter().map(|c| c.1 + 1).sum();
    let flags_w = inner.width.saturating_sub(used).max(5) as usize;
    let mut header: Vec<&str> = cols.iter().map(|c| c.0).collect();
    header.push("FLAGS");
    let mut widths: Vec<Constraint> = cols.iter().map(|c| Constraint::Length(c.1)).collect();
    widths.push(Constraint::Min(5));

    let rows = app.vehicles.iter().map(|v| {
        let key = (v.sysid, v.compid);
        let is_target = app.target == Some(key);
        let base = if v.lost {
            theme.dim()
        } else {
            Style::default()
        };
        let mut cells: Vec<Cell> = vec![
            Cell::from(if is_target { ">" } else { " " }),
            Cell::from(format!("{}:{}", v.sysid, v.compid)),
            Cell::from(ellipsize(&v.type_name(), if wide { 12 } else { 10 })),
        ];
        if wide {
            cells.push(Cell::from(ellipsize(&v.autopilot_name(), 13)));
        }
        let armed = if v.armed() {
            Cell::from(Span::styled(
                "ARMED",
                if v.lost { base } else { theme.armed() },
            ))
        } else {
            Cell::from("disarmed")
        };
        cells.extend([
            Cell::from(ellipsize(&v.mode_name(), if wide { 12 } else { 9 })),
            armed,
            Cell::from(ellipsize(&v.status_name(), if wide { 11 } else { 8 })),
            Cell::from(age_text(v, app.now, AGE_W as usize)),
            Cell::from(fmt::real(v.heartbeat_hz(), 1, HZ_W as usize)),
        ]);
        let links: Vec<String> = v.links.iter().map(|l| l.to_string()).collect();
        cells.push(Cell::from(ellipsize(&links.join(","), links_w as usize)));
        cells.push(Cell::from(Span::styled(
            ellipsize(&flags_text(v, wide), flags_w),
            theme.alert(),
        )));
        let style = if is_target && !v.lost {
            base.add_modifier(ratatui::style::Modifier::BOLD)
        } else {
            base
        };
        Row::new(cells).style(style)
    });
    let table = Table::new(rows, widths)
        .header(Row::new(header).style(theme.header()))
        .column_spacing(1)
        .row_highlight_style(selected_style(app, Pane::Vehicles, theme));
    let mut state = TableState::default().with_selected(Some(app.ui.vehicle_sel));
    frame.render_stateful_widget(table, inner, &mut state);
}
