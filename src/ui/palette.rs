//! The command palette popup (`ctrl-p`): the search line and the matching MAV_CMDs, the one
//! chosen highlighted; then the form of the command picked, each parameter with its label, units
//! and meaning, the target, and the COMMAND_LONG that enter sends. Fits 80x24.

use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Clear, Paragraph};
use ratatui::Frame;

use super::{ellipsize, Theme};
use crate::app::input::TextLine;
use crate::app::palette::{Palette, PaletteForm, FIELDS, TARGET};
use crate::app::App;
use crate::proto::ack::command_name;
use crate::proto::mav_cmds;

/// Width of a field's value box.
const VALUE_W: usize = 12;

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let Some(p) = &app.ui.palette else { return };
    let w = area.width.min(78);
    let h = match &p.form {
        None => area.height.min(20),
        Some(_) => area.height.min(15),
    };
    if w < 4 || h < 3 {
        return;
    }
    let popup = Rect::new(
        area.x + (area.width - w) / 2,
        area.y + (area.height.saturating_sub(1) - h.min(area.height - 1)) / 2,
        w,
        h,
    );
    frame.render_widget(Clear, popup);
    let inner_w = (w - 2) as usize;
    let body_h = (h - 2) as usize;
    let (title, lines, cursor) = match &p.form {
        None => list(p, inner_w, body_h, theme),
        Some(f) => form(p, f, inner_w, theme),
    };
    let block = Block::default()
        .borders(Borders::ALL)
        .border_style(theme.focus_border())
        .title(title);
    frame.render_widget(Paragraph::new(lines).block(block), popup);
    if let Some((x, y)) = cursor {
        let x = (x as u16).min(w - 2);
        if (y as u16) < h - 2 {
            frame.set_cursor_position((popup.x + 1 + x, popup.y + 1 + y as u16));
        }
    }
}

/// The line typed, scrolled so the cursor shows, in `room` characters; and the cursor's column.
fn shown(line: &TextLine, room: usize) -> (String, usize) {
    let room = room.max(1);
    let skip = (line.cursor + 1).saturating_sub(room);
    let text: String = line.text.chars().skip(skip).take(room).collect();
    (text, line.cursor - skip)
}

type Drawn = (String, Vec<Line<'static>>, Option<(usize, usize)>);

/// The search line, the matches around the selection, and a footer.
fn list(p: &Palette, w: usize, body_h: usize, theme: &Theme) -> Drawn {
    let mut lines = Vec::new();
    let (q, cur) = shown(&p.query, w.saturating_sub(2));
    lines.push(Line::from(vec![
        Span::styled("> ", theme.header()),
        Span::raw(q),
    ]));
    let rows = body_h.saturating_sub(2);
    let start = p
        .sel
        .saturating_sub(rows.saturating_sub(1))
        .min(p.matches.len().saturating_sub(rows));
    for (i, &n) in p.matches.iter().enumerate().skip(start).take(rows) {
        let name = command_name(n);
        let desc = mav_cmds::doc(n).map_or("", |d| d.description);
        // `>` marks the selection without colour too.
        let mark = if i == p.sel { '>' } else { ' ' };
        let left = format!("{mark}{n:>5} {name:<28}");
        let room = w.saturating_sub(left.chars().count() + 1);
        let text = ellipsize(&format!("{left} {}", ellipsize(desc, room)), w);
        let text = format!("{text:<w$}");
        if i == p.sel {
            lines.push(Line::styled(text, theme.selected()));
        } else if desc.is_empty() {
            lines.push(Line::raw(text));
        } else {
            lines.push(Line::from(vec![
                Span::raw(left),
                Span::styled(format!(" {}", ellipsize(desc, room)), theme.dim()),
            ]));
        }
    }
    if p.matches.is_empty() {
        lines.push(Line::styled(" no MAV_CMD matches", theme.dim()));
    }
    while lines.len() < body_h.saturating_sub(1) {
        lines.push(Line::raw(""));
    }
    let count = format!("{} of {}", p.matches.len(), mav_cmds::all().len());
    lines.push(Line::styled(
        ellipsize(
            &format!("{count}  up/down choose  enter pick  esc close"),
            w,
        ),
        theme.dim(),
    ));
    (" Command palette ".into(), lines, Some((2 + cur, 0)))
}

/// The description, a row per field, the preview, and the error or a footer.
fn form(p: &Palette, f: &PaletteForm, w: usize, theme: &Theme) -> Drawn {
    let doc = mav_cmds::doc(f.command);
    let labels: Vec<(String, &str, &str)> = (0..7)
        .map(|i| mav_cmds::param(f.command, i))
        .chain([("target".to_string(), "", "SYSID:COMPID (a camera: 1:100)")])
        .collect();
    let label_w = labels
        .iter()
        .map(|l| l.0.chars().count())
        .max()
        .unwrap_or(0)
        .min(20);
    let mut lines = vec![Line::styled(
        ellipsize(
            doc.map_or("(no description: parameters as param N)", |d| d.description),
            w,
        ),
        theme.dim(),
    )];
    let mut cursor = None;
    for (i, (label, units, hint)) in labels.iter().enumerate().take(FIELDS) {
        let name = if i == TARGET {
            "  ".to_string()
        } else {
            format!("p{}", i + 1)
        };
        let head = format!("{name} {:<label_w$} ", ellipsize(label, label_w));
        let (value, cur) = shown(&f.fields[i], VALUE_W);
        let focused = i == f.focus;
        if focused {
            cursor = Some((head.chars().count() + 1 + cur, lines.len()));
        }
        let value_style = if focused {
            theme.selected()
        } else {
            Style::default()
        };
        let tail = format!(" {units:<4} ");
        let room = w.saturating_sub(head.chars().count() + VALUE_W + 2 + tail.chars().count());
        let unused = label == "(unused)";
        lines.push(Line::from(vec![
            Span::styled(head, if unused { theme.dim() } else { theme.header() }),
            Span::raw("["),
            Span::styled(format!("{value:<VALUE_W$}"), value_style),
            Span::raw("]"),
            Span::raw(tail),
            Span::styled(ellipsize(hint, room), theme.dim()),
        ]));
    }
    lines.push(Line::raw(""));
    for l in f.preview() {
        lines.push(Line::raw(ellipsize(&l, w)));
    }
    lines.push(match &p.error {
        Some(e) => Line::styled(ellipsize(e, w), theme.alert()),
        None => Line::styled(
            ellipsize(
                "empty = 0, nan allowed  tab/up/down field  enter send  esc back",
                w,
            ),
            theme.dim(),
        ),
    });
    let title = format!(" {} ({}) ", command_name(f.command), f.command);
    (title, lines, cursor)
}

#[cfg(test)]
mod tests {
    use crate::app::palette::{Palette, PaletteForm, TARGET};
    use crate::app::{App, AppConfig};
    use crate::ui::{buffer_to_text, render_to_buffer, Theme};

    #[test]
    fn no_panic_at_any_size_and_long_lines_scroll() {
        let mut app = App::new(AppConfig::default());
        let mut p = Palette::default();
        p.query.set(&"x".repeat(200));
        p.refilter();
        app.ui.palette = Some(p.clone());
        let mut form = PaletteForm::new(22, Some(crate::proto::vehicles::VehicleKey(1, 1)));
        form.fields[6].set(&"9".repeat(100));
        form.fields[TARGET].set("255:255");
        form.focus = 6;
        for open in [Some(Palette::default()), Some(p.clone())] {
            app.ui.palette = open;
            for w in 0..=82 {
                for h in 0..=25 {
                    render_to_buffer(&app, w, h, &Theme::PLAIN);
                }
            }
        }
        p.form = Some(form);
        p.error = Some("e".repeat(300));
        app.ui.palette = Some(p);
        for w in 0..=82 {
            for h in 0..=25 {
                render_to_buffer(&app, w, h, &Theme::PLAIN);
            }
        }
        let text = buffer_to_text(&render_to_buffer(&app, 80, 24, &Theme::PLAIN));
        assert!(text.contains("p7 Altitude"), "{text}");
        // The end of a long value shows, with room for the cursor after it.
        assert!(text.contains("[99999999999 ]"), "{text}");
        assert!(text.contains("NAV_TAKEOFF (22)"), "{text}");
    }
}
