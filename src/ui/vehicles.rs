//! The vehicles pane: one row per component heard by heartbeat.
//!
//! The target is marked `>`; lost components are dimmed with "lost Ns ago"; a sysid clash or a
//! component using our GCS sysid is flagged in red (and in words, for NO_COLOR). Text columns
//! get the width their text needs when there is room; text cut to fit ends with `…`. Narrow
//! screens drop the autopilot column, then the status and the rate, and abbreviate flags. LINK names the links
//! a component is heard on by the Links pane's short names; a list longer than the pane says so
//! in the bottom border (`5 of 12, ↓ 7 more`) and scrolls with the selection.

use ratatui::layout::{Constraint, Rect};
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Cell, Paragraph, Row, Table, TableState};
use ratatui::Frame;

use super::{ellipsize, fmt, links, pane_block, selected_style, Theme};
use crate::app::{App, Pane};
use crate::proto::vehicles::Vehicle;

/// Inner width from which every column is shown.
const WIDE: u16 = 110;
/// Inner width below which the STATUS and HZ columns are dropped.
const NARROW: u16 = 70;
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

/// From this inner width the columns are 3 apart instead of 1.
const SPREAD: u16 = 150;

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let mut block = pane_block(
        app,
        Pane::Vehicles,
        format!(" ({})", app.vehicles.len()),
        theme,
    );
    let inner = block.inner(area);
    if app.vehicles.is_empty() {
        frame.render_widget(block, area);
        let p = Paragraph::new(Line::styled("no vehicles heard yet", theme.dim()));
        frame.render_widget(p, inner);
        return;
    }
    let wide = inner.width >= WIDE;
    // Below this width the status and the rate go, to leave the other columns room.
    let narrow = inner.width < NARROW;
    let short = links::short_names(app);
    let vehicles: Vec<&Vehicle> = app.vehicles.iter().collect();
    let link_text = |v: &Vehicle| -> String {
        v.links
            .iter()
            .map(|&l| short.get(l).cloned().unwrap_or_else(|| l.to_string()))
            .collect::<Vec<_>>()
            .join(",")
    };
    let texts =
        |f: &dyn Fn(&Vehicle) -> String| -> Vec<String> { vehicles.iter().map(|v| f(v)).collect() };
    let (ids, types, autopilots, modes, statuses, link_names, flags) = (
        texts(&|v| v.key().to_string()),
        texts(&|v| v.type_name()),
        texts(&|v| v.autopilot_name()),
        texts(&|v| v.mode_name()),
        texts(&|v| v.status_name()),
        texts(&link_text),
        texts(&|v| flags_text(v, wide)),
    );
    let text_col = |min: usize, head: &str, t: &[String]| {
        fmt::Col::text(min, t.iter().map(|s| s.as_str()).chain([head]))
    };
    let link_head = if wide { "LINKS" } else { "LINK" };
    // Flags need room for at least an abbreviated one; none, just what is left.
    let any_flags = flags.iter().any(|f| !f.is_empty());
    let flags_col = text_col(if any_flags { 6 } else { 0 }, "FLAGS", &flags);
    // (column, header, texts); FLAGS takes what is left.
    let mut cols: Vec<(Column, &str, fmt::Col)> = vec![
        (Column::Mark, "", fmt::Col::fixed(1)),
        (Column::Id, "ID", text_col(2, "ID", &ids)),
        (Column::Type, "TYPE", text_col(4, "TYPE", &types)),
    ];
    if wide {
        cols.push((
            Column::Autopilot,
            "AUTOPILOT",
            text_col(4, "AUTOPILOT", &autopilots),
        ));
    }
    cols.extend([
        (Column::Mode, "MODE", text_col(4, "MODE", &modes)),
        (
            Column::Armed,
            "ARMED",
            fmt::Col {
                min: 5,
                want: 8,
                fill: false,
            },
        ),
    ]);
    if !narrow {
        cols.push((Column::Status, "STATUS", text_col(6, "STATUS", &statuses)));
    }
    // "lost 13s ago" when there is room, "lost 13s" (and the title) at least.
    let ages = texts(&|v| age_text(v, app.now, AGE_W as usize));
    let short_ages = texts(&|v| age_text(v, app.now, AGE_W as usize - 1));
    let age_min = short_ages.iter().map(|a| fmt::width(a)).max().unwrap_or(0);
    cols.push((
        Column::Age,
        "LAST HB",
        text_col(age_min.max(7), "LAST HB", &ages),
    ));
    if !narrow {
        cols.push((Column::Hz, "HZ", fmt::Col::fixed(HZ_W as usize)));
    }
    cols.extend([
        // At least a network link's short name (`udpin:14550`).
        (
            Column::Link,
            link_head,
            text_col(11, link_head, &link_names),
        ),
        (Column::Flags, "FLAGS", flags_col.fill()),
    ]);
    // Who gets room first when there is not enough: what an operator must see.
    let order = [
        Column::Id,
        Column::Mode,
        Column::Armed,
        Column::Type,
        Column::Status,
        Column::Link,
        Column::Age,
        Column::Hz,
        Column::Autopilot,
        Column::Flags,
    ];
    let priority: Vec<usize> = order
        .iter()
        .filter_map(|c| cols.iter().position(|x| x.0 == *c))
        .collect();
    let spec: Vec<fmt::Col> = cols.iter().map(|c| c.2).collect();
    // Wide, the columns spread out rather than leave the pane's right half empty.
    let gap = if inner.width >= SPREAD { 3 } else { 1 };
    let w = fmt::share(&spec, inner.width as usize, gap, &priority);
    let width_of = |c: Column| cols.iter().position(|x| x.0 == c).map_or(0, |i| w[i]);
    let header: Vec<Cell> = cols
        .iter()
        .zip(&w)
        .map(|(c, &cw)| match c.0 {
            // An empty column too narrow for its title: no title rather than `…`.
            Column::Flags if !any_flags && cw < fmt::width(c.1) => Cell::from(""),
            _ => Cell::from(fmt::fit(c.1, cw).into_owned()),
        })
        .collect();
    // The spread goes after each column but the selection mark, which stays next to the ID.
    let widths: Vec<Constraint> = w
        .iter()
        .zip(&cols)
        .enumerate()
        .map(|(i, (&x, c))| {
            let pad = if c.0 == Column::Mark || i + 1 == cols.len() {
                0
            } else {
                gap - 1
            };
            Constraint::Length((x + pad) as u16)
        })
        .collect();

    // The rows below the header; the list scrolls with the selection.
    let visible = inner.height.saturating_sub(1) as usize;
    let total = vehicles.len();
    let sel = app.ui.vehicle_sel.min(total - 1);
    let first = fmt::scroll_offset(sel, visible, total);
    let rows = vehicles.iter().enumerate().map(|(i, v)| {
        let key = v.key();
        let is_target = app.target == Some(key);
        let base = if v.lost {
            theme.dim()
        } else {
            Style::default()
        };
        let cut = |t: &str, c: Column| Cell::from(fmt::fit(t, width_of(c)).into_owned());
        let cells: Vec<Cell> = cols
            .iter()
            .map(|c| match c.0 {
                Column::Mark => Cell::from(if is_target { ">" } else { " " }),
                Column::Id => cut(&ids[i], Column::Id),
                Column::Type => cut(&types[i], Column::Type),
                Column::Autopilot => cut(&autopilots[i], Column::Autopilot),
                Column::Mode => cut(&modes[i], Column::Mode),
                Column::Armed if v.armed() => Cell::from(Span::styled(
                    fmt::fit("ARMED", width_of(Column::Armed)).into_owned(),
                    if v.lost { base } else { theme.armed() },
                )),
                Column::Armed => cut("disarmed", Column::Armed),
                Column::Status => cut(&statuses[i], Column::Status),
                Column::Age => Cell::from(age_text(v, app.now, width_of(Column::Age))),
                Column::Hz => Cell::from(fmt::real(v.heartbeat_hz(), 1, HZ_W as usize)),
                Column::Link => cut(&link_names[i], Column::Link),
                Column::Flags => {
                    let fw = width_of(Column::Flags);
                    // The words, cut if need be, when there is room to read them; else short.
                    let text = if fmt::width(&flags[i]) <= fw || fw >= 24 {
                        flags[i].clone()
                    } else {
                        flags_text(v, false)
                    };
                    Cell::from(Span::styled(
                        fmt::fit(&text, fw).into_owned(),
                        theme.alert(),
                    ))
                }
            })
            .collect();
        let style = if is_target && !v.lost {
            base.add_modifier(ratatui::style::Modifier::BOLD)
        } else {
            base
        };
        Row::new(cells).style(style)
    });
    if let Some(more) = fmt::list_more(first, visible, total) {
        block = block.title_bottom(Line::from(format!(" {more} ")));
    }
    frame.render_widget(block, area);
    let table = Table::new(rows, widths)
        .header(Row::new(header).style(theme.header()))
        .column_spacing(1)
        .row_highlight_style(selected_style(app, Pane::Vehicles, theme));
    let mut state = TableState::default()
        .with_offset(first)
        .with_selected(Some(sel));
    frame.render_stateful_widget(table, inner, &mut state);
}

/// The columns of the pane.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Column {
    Mark,
    Id,
    Type,
    Autopilot,
    Mode,
    Armed,
    Status,
    Age,
    Hz,
    Link,
    Flags,
}
