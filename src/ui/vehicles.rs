//! The vehicles pane: one row per component heard by heartbeat.
//!
//! The target is marked `>`; lost components are dimmed with "lost Ns ago"; a sysid clash or a
//! component using our GCS sysid is flagged in red (and in words, for NO_COLOR). Text columns
//! get the width their text needs when there is room; text cut to fit ends with `…`. Narrow
//! screens drop the autopilot column, then the status and the rate, and abbreviate flags. LINK names the links
//! a component is heard on by the Links pane's short names; a list longer than the pane says so
//! in the bottom border (`5 of 12, ↓ 7 more`) and scrolls with the selection.

use std::borrow::Cow;

use ratatui::layout::{Constraint, Rect};
use ratatui::style::Style;
use ratatui::Frame;

use super::{ellipsize, fast, fmt, links, pane_block, selected_style, Theme};
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
        let buf = frame.buffer_mut();
        block.render(buf, area);
        fast::line(buf, inner, &[("no vehicles heard yet", theme.dim())]);
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
    let header = cols.iter().zip(&w).map(|(c, &cw)| match c.0 {
        // An empty column too narrow for its title: no title rather than `…`.
        Column::Flags if !any_flags && cw < fmt::width(c.1) => Cow::Borrowed(""),
        _ => fmt::fit(c.1, cw),
    });
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
    if let Some(more) = fmt::list_more(first, visible, total) {
        block.bottom = Some(format!(" {more} "));
    }
    let buf = frame.buffer_mut();
    block.render(buf, area);
    let table = fast::Table::new(inner, &widths, 1);
    if table.is_empty() {
        return;
    }
    let header: Vec<Cow<str>> = header.collect();
    table.header(buf, theme.header(), header.iter().map(|h| h.as_ref()));
    let highlight = selected_style(app, Pane::Vehicles, theme);
    let (start, end) = table.visible(first, Some(sel), total);
    for (k, i) in (start..end).enumerate() {
        let v = vehicles[i];
        let y = table.row_y(k);
        let key = v.key();
        let is_target = app.target == Some(key);
        let base = if v.lost {
            theme.dim()
        } else {
            Style::default()
        };
        let style = if is_target && !v.lost {
            base.add_modifier(ratatui::style::Modifier::BOLD)
        } else {
            base
        };
        table.patch_row(buf, y, style);
        for (col, c) in cols.iter().enumerate() {
            let cw = w[col];
            let cut = |t| fmt::fit(t, cw);
            match c.0 {
                Column::Mark => table.raw(buf, y, col, if is_target { ">" } else { " " }),
                Column::Id => table.raw(buf, y, col, &cut(&ids[i])),
                Column::Type => table.raw(buf, y, col, &cut(&types[i])),
                Column::Autopilot => table.raw(buf, y, col, &cut(&autopilots[i])),
                Column::Mode => table.raw(buf, y, col, &cut(&modes[i])),
                Column::Armed if v.armed() => table.span(
                    buf,
                    y,
                    col,
                    &cut("ARMED"),
                    if v.lost { base } else { theme.armed() },
                ),
                Column::Armed => table.raw(buf, y, col, &cut("disarmed")),
                Column::Status => table.raw(buf, y, col, &cut(&statuses[i])),
                Column::Age => table.raw(buf, y, col, &age_text(v, app.now, cw)),
                Column::Hz => {
                    table.raw(buf, y, col, &fmt::real(v.heartbeat_hz(), 1, HZ_W as usize))
                }
                Column::Link => table.raw(buf, y, col, &cut(&link_names[i])),
                Column::Flags => {
                    // The words, cut if need be, when there is room to read them; else short.
                    let short;
                    let text = if fmt::width(&flags[i]) <= cw || cw >= 24 {
                        &flags[i]
                    } else {
                        short = flags_text(v, false);
                        &short
                    };
                    table.span(buf, y, col, &cut(text), theme.alert());
                }
            }
        }
        if i == sel {
            table.patch_row(buf, y, highlight);
        }
    }
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
