//! The Commands screen (`3`): every command sent to the target vehicle, newest first, with its
//! time, every field, what became of it and the round trip.

use ratatui::layout::{Constraint, Rect};
use ratatui::text::Line;
use ratatui::widgets::{Block, Borders, Paragraph, Row, Table};
use ratatui::Frame;

use super::Theme;
use crate::app::App;
use crate::proto::commands::{Entry, Form, State};

fn param(p: f64) -> String {
    if p.is_nan() {
        "nan".into()
    } else if p == p.trunc() && p.abs() < 1e9 {
        format!("{p:.0}")
    } else {
        format!("{p}")
    }
}

fn style(e: &Entry, theme: &Theme) -> ratatui::style::Style {
    match e.state {
        State::Done(0) => theme.good(),
        State::Waiting | State::InProgress(_) => theme.header(),
        _ => theme.alert(),
    }
}

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let session = app.target.and_then(|k| app.sessions.get(&k));
    let key = |a| {
        app.keymap
            .keys_for(crate::keymap::Mode::Normal, "commands", a)
            .first()
            .map(|k| k.to_string())
            .unwrap_or_default()
    };
    let title = match app.target {
        Some(k) => format!(
            " Commands to {k}  {} send again  {} cancel ",
            key(crate::keymap::Action::Reissue),
            key(crate::keymap::Action::CancelCommand)
        ),
        None => " Commands (no target) ".to_string(),
    };
    let block = Block::default()
        .borders(Borders::ALL)
        .border_style(theme.focus_border())
        .title(title);
    let Some(s) = session.filter(|s| s.commands.entries().len() > 0) else {
        let text = "none sent yet: `:` then arm, takeoff 10, mode guided, long CMD …";
        frame.render_widget(
            Paragraph::new(Line::styled(text, theme.dim())).block(block),
            area,
        );
        return;
    };
    let wide = area.width >= 120;
    let header = Row::new(if wide {
        vec![
            "TIME", "COMMAND", "FORM", "PARAMS", "SENDS", "RESULT", "RTT",
        ]
    } else {
        vec!["TIME", "COMMAND", "PARAMS", "RESULT", "RTT"]
    })
    .style(theme.header());
    // Inside the borders, under the column titles; the window follows the selection.
    let total = s.commands.entries().len();
    let visible = area.height.saturating_sub(3) as usize;
    let first = super::fmt::scroll_offset(app.ui.cmd_sel, visible, total);
    let block = match super::fmt::list_more(first, visible, total) {
        Some(more) => block.title_bottom(Line::from(format!(" {more} "))),
        None => block,
    };
    // Wide, the command column is as wide as its longest name (up to 40).
    let name_w = s
        .commands
        .entries()
        .map(|e| e.spec.name().chars().count())
        .max()
        .unwrap_or(0)
        .clamp(26, 40) as u16;
    let widths: Vec<Constraint> = if wide {
        vec![
            Constraint::Length(8),
            Constraint::Length(name_w),
            Constraint::Length(6),
            Constraint::Min(30),
            Constraint::Length(5),
            Constraint::Min(20),
            Constraint::Length(7),
        ]
    } else {
        vec![
            Constraint::Length(8),
            Constraint::Length(20),
            Constraint::Min(14),
            Constraint::Min(14),
            Constraint::Length(6),
        ]
    };
    // Cells fitted to their columns, so a cut shows (`…`).
    let cw = super::fmt::table_widths(&widths, area.width.saturating_sub(2), 1);
    let rows: Vec<Row> = s
        .commands
        .entries()
        .rev()
        .enumerate()
        .skip(first)
        .take(visible.max(1))
        .map(|(i, e)| {
            let t = app.wall(e.first_sent).format("%H:%M:%S").to_string();
            let params = e
                .spec
                .params
                .iter()
                .map(|p| param(*p))
                .collect::<Vec<_>>()
                .join(" ");
            let mut result = e.outcome();
            if let Some(r) = &e.reason {
                result = format!("{result}: {r}");
            }
            let rtt = e
                .rtt
                .map(|r| format!("{}ms", r / 1000))
                .unwrap_or_else(|| "-".into());
            let form = match e.spec.form {
                Form::Long => "LONG".to_string(),
                Form::Int(f) => format!("INT {f:?}"),
            };
            let cells = if wide {
                vec![
                    t,
                    e.spec.name(),
                    form,
                    params,
                    e.sends.to_string(),
                    result,
                    rtt,
                ]
            } else {
                vec![t, e.spec.name(), params, result, rtt]
            };
            let cells: Vec<String> = cells
                .iter()
                .zip(&cw)
                .map(|(c, &w)| super::fmt::fit(c, w).into_owned())
                .collect();
            let row = Row::new(cells).style(style(e, theme));
            if i == app.ui.cmd_sel {
                row.style(style(e, theme).patch(theme.selected()))
            } else {
                row
            }
        })
        .collect();
    frame.render_widget(Table::new(rows, widths).header(header).block(block), area);
}
