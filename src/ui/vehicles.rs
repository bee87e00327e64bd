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

use super::{ellipsize, pane_block, selected_style, Theme};
use crate::app::{App, Pane};
use crate::proto::vehicles::Vehicle;

/// Inner width from which every column is shown.
const WIDE: u16 = 110;

/// "0.4s" while heard; "lost 12s ago" once lost.
pub fn age_text(v: &Vehicle, now: crate::clock::Micros) -> String {
    let age = v.age_secs(now);
    if v.lost {
        format!("lost {age:.0}s ago")
    } else {
        format!("{age:.1}s")
    }
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
    let mut header = vec!["", "ID", "TYPE"];
    let mut widths = vec![
        Constraint::Length(1),
        Constraint::Length(7),
        Constraint::Length(if wide { 12 } else { 10 }),
    ];
    if wide {
        header.push("AUTOPILOT");
        widths.push(Constraint::Length(13));
    }
    header.extend(["MODE", "ARMED", "STATUS", "LAST HB", "HZ"]);
    widths.extend([
        Constraint::Length(if wide { 12 } else { 9 }),
        Constraint::Length(8),
        Constraint::Length(if wide { 11 } else { 8 }),
        Constraint::Length(12),
        Constraint::Length(4),
    ]);
    header.push(if wide { "LINKS" } else { "LINK" });
    widths.push(Constraint::Length(if wide { 5 } else { 4 }));
    header.push("FLAGS");
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
            Cell::from(age_text(v, app.now)),
            Cell::from(format!("{:.1}", v.heartbeat_hz())),
        ]);
        let links: Vec<String> = v.links.iter().map(|l| l.to_string()).collect();
        cells.push(Cell::from(links.join(",")));
        cells.push(Cell::from(Span::styled(flags_text(v, wide), theme.alert())));
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
