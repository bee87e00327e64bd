//! The Mission screen (`5`): the mission, the geofence or the rally points (a key switches), as
//! the vehicle holds them or as a loaded file has them (said in the title), with the current
//! item, the items reached, the distance to the current waypoint and a transfer's progress.

use ratatui::layout::{Constraint, Rect};
use ratatui::text::Line;
use ratatui::widgets::{Block, Borders, Paragraph, Row, Table};
use ratatui::Frame;

use super::Theme;
use crate::app::mission::Shown;
use crate::app::session::Session;
use crate::app::App;
use crate::keymap::{Action, Mode};
use crate::mission::{command_has_position, MissionItem, MissionType};
use crate::proto::telemetry::distance_bearing;

fn num(v: f64) -> String {
    if v.is_nan() {
        "nan".into()
    } else if v == v.trunc() && v.abs() < 1e9 {
        format!("{v:.0}")
    } else {
        format!("{v:.2}")
    }
}

/// `label=value` for the parameters 1-4 the command uses (the palette's labels); at 0, only those
/// of the commonly used commands.
fn params_text(i: &MissionItem) -> String {
    let mut out = Vec::new();
    for (n, p) in i.params.iter().enumerate() {
        let (label, units, _) = crate::proto::mav_cmds::param(i.command, n);
        if label == "(unused)" {
            continue;
        }
        if *p == 0.0 && !crate::proto::mav_cmds::is_common(i.command) {
            continue;
        }
        let short: String = label.split_whitespace().collect::<Vec<_>>().join(" ");
        out.push(format!("{short}={}{units}", num(*p as f64)));
    }
    out.join(" ")
}

/// The first key bound to `a` on the Mission screen, or nothing.
fn key(app: &App, a: Action) -> String {
    app.keymap
        .keys_for(Mode::Normal, "mission", a)
        .first()
        .map(|k| k.to_string())
        .unwrap_or_default()
}

/// The border's title: the lists (the shown one in brackets), where the rows come from, and
/// the keys that switch them.
fn title(app: &App, t: MissionType, session: Option<&Session>) -> String {
    let view = &app.ui.mission;
    let key = |a| key(app, a);
    let lists: Vec<String> = MissionType::ALL
        .iter()
        .map(|lt| {
            if *lt == t {
                format!("[{}]", lt.name())
            } else {
                lt.name().to_string()
            }
        })
        .collect();
    let source = match view.shown {
        Shown::File => match &view.files[t.index()] {
            Some(f) if !f.errors.is_empty() => {
                format!("file: {} ({} errors)", f.path, f.errors.len())
            }
            Some(f) if app.file_uploaded(t) => format!("file: {} (uploaded)", f.path),
            Some(f) => format!("file: {} (not uploaded)", f.path),
            None => "file: none loaded".into(),
        },
        Shown::Vehicle => match session.and_then(|s| s.mission.known(t)) {
            Some(k) if session.is_some_and(|s| s.mission.changed_on_vehicle(t)) => format!(
                "vehicle ({}, changed since)",
                if k.downloaded {
                    "downloaded"
                } else {
                    "uploaded"
                }
            ),
            Some(k) => format!(
                "vehicle ({})",
                if k.downloaded {
                    "downloaded"
                } else {
                    "uploaded"
                }
            ),
            None => "vehicle (not downloaded)".into(),
        },
    };
    format!(
        " {}  {}  {} list {} file/vehicle ",
        lists.join(" "),
        source,
        key(Action::MissionList),
        key(Action::MissionSource)
    )
}

/// The status line's parts: transfer, current item, distance to it, items reached, the last
/// refusal; the keys when there is nothing to say.
fn status(app: &App, session: Option<&Session>, t: MissionType, vehicle_home: bool) -> Vec<String> {
    let key = |a| key(app, a);
    let mut status = Vec::new();
    if let Some(s) = session {
        if let Some(p) = s.mission.progress() {
            let total = p.total.map_or("?".into(), |n| n.to_string());
            status.push(format!(
                "{} {}: {}/{}",
                p.mission_type.name(),
                p.op.name(),
                p.done,
                total
            ));
        }
        if t == MissionType::Mission {
            if let Some(c) = &s.mission.current {
                // MISSION_CURRENT's total: 0 is "not supported" (and what a MAVLink 1 frame,
                // which has no such field, reads as): the list's own length then, home not
                // counted, as the spec counts it; UINT16_MAX is "no mission".
                let total = match c.total {
                    0 => s.mission.known(t).map_or("?".to_string(), |k| {
                        let home = vehicle_home && !k.items.is_empty();
                        (k.items.len() - home as usize).to_string()
                    }),
                    u16::MAX => "none".to_string(),
                    n => n.to_string(),
                };
                status.push(format!("current {} of {total}", c.seq));
                let item = s
                    .mission
                    .known(t)
                    .and_then(|k| k.items.iter().find(|i| i.seq == c.seq));
                let pos = s.flight.position.as_ref().map(|p| p.value);
                if let (Some(i), Some(p)) = (item.filter(|_| !(vehicle_home && c.seq == 0)), pos) {
                    if command_has_position(i.command) && (i.x != 0 || i.y != 0) && p.is_known() {
                        let (d, b) = distance_bearing((p.lat(), p.lon()), (i.param5(), i.param6()));
                        status.push(format!("next wp {d:.0} m at {b:.0}°"));
                    }
                }
            }
            let reached: Vec<String> = s
                .mission
                .reached()
                .map(|(_, seq)| seq.to_string())
                .collect();
            if !reached.is_empty() {
                let tail = &reached[reached.len().saturating_sub(6)..];
                status.push(format!("reached {}", tail.join(",")));
            }
        }
        if let Some(r) = s.mission.last_refusal() {
            status.push(format!(
                "last refusal: {} {} {}",
                r.mission_type.name(),
                r.op.name(),
                crate::proto::mission::result_name(r.result)
            ));
        }
    } else {
        status.push("no target vehicle".into());
    }
    if status.is_empty() {
        status.push(format!(
            "{} download  {} upload  {} start  {} set current  {} goto",
            key(Action::MissionDownload),
            key(Action::MissionUpload),
            key(Action::MissionStart),
            key(Action::MissionSetCurrent),
            key(Action::MissionGoto)
        ));
    }
    status
}

/// A row's cells: its sequence number after its mark, command (`HOME` for home), position,
/// altitude with its frame, and the parameters it uses.
fn cells(i: &MissionItem, mark: &str, home: bool) -> [String; 6] {
    let name = if home {
        "HOME".into()
    } else {
        i.command_name()
    };
    let positioned = command_has_position(i.command) || home;
    let (lat, lon) = if positioned {
        (format!("{:.7}", i.param5()), format!("{:.7}", i.param6()))
    } else {
        (String::new(), String::new())
    };
    let alt = if i.has_altitude() || home {
        format!("{:.1} {}", i.z, i.alt_ref())
    } else {
        String::new()
    };
    [
        format!("{mark}{}", i.seq),
        name,
        lat,
        lon,
        alt,
        params_text(i),
    ]
}

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let view = &app.ui.mission;
    let t = view.mission_type();
    let session = app.target.and_then(|k| app.sessions.get(&k));
    // Item 0 is home in a file (WPL's first line, a plan's planned home) and on a vehicle whose
    // profile says its mission holds home (ArduPilot); elsewhere it is a real item.
    let vehicle_home = app
        .target
        .is_some_and(|k| app.profile(k).mission_home_item());
    let shown_home = match view.shown {
        Shown::File => true,
        Shown::Vehicle => vehicle_home,
    };
    let key = |a| key(app, a);
    // The title is cut with `…` to the border it sits on (corners kept).
    let title = super::ellipsize(
        &title(app, t, session),
        (area.width as usize).saturating_sub(2),
    );
    let mut block = Block::default()
        .borders(Borders::ALL)
        .border_style(theme.focus_border())
        .title(title);
    let inner = block.inner(area);
    // Below the status line and the column titles, the rows; the window follows the selection.
    let rows = app.mission_rows();
    let visible = inner.height.saturating_sub(2) as usize;
    let first = super::fmt::scroll_offset(view.sel, visible, rows.len());
    if let Some(more) = super::fmt::list_more(first, visible, rows.len()) {
        block = block.title_bottom(Line::from(format!(" {more} ")));
    }
    frame.render_widget(block, area);
    if inner.height == 0 {
        return;
    }
    let status = status(app, session, t, vehicle_home);
    frame.render_widget(
        Paragraph::new(Line::styled(
            super::ellipsize(&status.join("  "), inner.width as usize),
            theme.header(),
        )),
        Rect { height: 1, ..inner },
    );
    let table_area = Rect {
        y: inner.y + 1,
        height: inner.height.saturating_sub(1),
        ..inner
    };
    if rows.is_empty() {
        let hint = match view.shown {
            Shown::File => format!(
                ": then {} load FILE (WPL or .plan)",
                crate::app::mission::word(t)
            ),
            Shown::Vehicle => format!(
                "nothing yet: {} downloads, or : then {} download",
                key(Action::MissionDownload),
                crate::app::mission::word(t)
            ),
        };
        let hint = super::ellipsize(&hint, table_area.width as usize);
        frame.render_widget(Paragraph::new(Line::styled(hint, theme.dim())), table_area);
        return;
    }
    // The marks belong to the vehicle's list: shown, or the file uploaded to it.
    let live = t == MissionType::Mission && (view.shown == Shown::Vehicle || app.file_uploaded(t));
    // A file's rows count home as 0; a vehicle without a home item numbers its items from 0.
    let shift = u16::from(view.shown == Shown::File && !vehicle_home);
    let current = session.filter(|_| live).and_then(|s| {
        s.mission
            .current
            .as_ref()
            .map(|c| c.seq.saturating_add(shift))
    });
    let reached: Vec<u16> = session
        .filter(|_| live)
        .map(|s| {
            s.mission
                .reached()
                .map(|(_, q)| q.saturating_add(shift))
                .collect()
        })
        .unwrap_or_default();
    // Command names take the room there is once the row is wide (NAV_RETURN_TO_LAUNCH whole).
    let command_w = rows
        .iter()
        .map(|i| cells(i, " ", false)[1].chars().count())
        .max()
        .unwrap_or(0)
        .clamp(16, 32) as u16;
    let command_w = if table_area.width >= 5 + 11 + 12 + 11 + 10 + 6 + command_w {
        command_w
    } else {
        16
    };
    let widths = [
        Constraint::Length(5),
        Constraint::Length(command_w),
        Constraint::Length(11),
        Constraint::Length(12),
        Constraint::Length(11),
        Constraint::Min(10),
    ];
    // Cells fitted to their columns, so a cut shows (`…`).
    let cw = super::fmt::table_widths(&widths, table_area.width, 1);
    let table_rows: Vec<Row> = rows
        .iter()
        .enumerate()
        .skip(first)
        .take(visible.max(1))
        .map(|(n, i)| {
            let mark = if Some(i.seq) == current {
                ">"
            } else if reached.contains(&i.seq) {
                "✓"
            } else {
                " "
            };
            let home = t == MissionType::Mission && i.seq == 0 && shown_home;
            let cells = cells(i, mark, home);
            let row = Row::new(
                cells
                    .iter()
                    .zip(&cw)
                    .map(|(c, &w)| super::fmt::fit(c, w).into_owned()),
            );
            if n == view.sel {
                row.style(theme.selected())
            } else if Some(i.seq) == current {
                row.style(theme.good())
            } else {
                row
            }
        })
        .collect();
    let table = Table::new(table_rows, widths).header(
        Row::new(vec!["SEQ", "COMMAND", "LAT", "LON", "ALT", "PARAMS"]).style(theme.header()),
    );
    frame.render_widget(table, table_area);
}
