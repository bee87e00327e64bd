//! The command palette popup (`ctrl-p`): the search line and the matching MAV_CMDs, the one
//! chosen highlighted, with what each does; then the form of the command picked, each parameter
//! with its label, units and meaning (its enum's values, range and default under the fields for
//! the one typed in), the target, and the COMMAND_LONG that enter sends. Everything said of a
//! command comes from the dialect's XML definitions. Fits 80x24.

use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Clear, Paragraph};
use ratatui::Frame;

use super::inspector::wrap_words;
use super::{ellipsize, Theme};
use crate::app::input::TextLine;
use crate::app::palette::{wire_value, Palette, PaletteForm, FIELDS, TARGET};
use crate::app::App;
use crate::proto::ack::command_name;
use crate::proto::mav_cmds::{self, ParamInfo};

/// Width of a field's value box.
const VALUE_W: usize = 12;

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let Some(p) = &app.ui.palette else { return };
    let w = area.width.min(78);
    let h = match &p.form {
        None => area.height.min(20),
        Some(_) => area.height.min(21),
    };
    if w < 4 || h < 3 {
        return;
    }
    let inner_w = (w - 2) as usize;
    let body_h = (h - 2) as usize;
    let (title, lines, cursor) = match &p.form {
        None => list(p, inner_w, body_h, theme),
        Some(f) => form(p, f, inner_w, body_h, theme),
    };
    // The form as tall as what it shows.
    let h = if p.form.is_some() {
        h.min(lines.len() as u16 + 2).max(3)
    } else {
        h
    };
    let popup = Rect::new(
        area.x + (area.width - w) / 2,
        area.y + (area.height.saturating_sub(1) - h.min(area.height - 1)) / 2,
        w,
        h,
    );
    frame.render_widget(Clear, popup);
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
        let desc = mav_cmds::description(n);
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

/// A number as the about line shows it: `-2`, `0.5`, `nan`.
fn num(v: f64) -> String {
    wire_value(v)
}

/// The focused parameter's description, enum values, range and default, as one text.
fn about(f: &PaletteForm, infos: &[ParamInfo]) -> String {
    if f.focus == TARGET {
        return "target: SYSID:COMPID of the component the command goes to (a camera: 1:100)"
            .into();
    }
    let Some(p) = infos.get(f.focus) else {
        return String::new();
    };
    let units = if p.units.is_empty() {
        String::new()
    } else {
        format!(" ({})", p.units)
    };
    let mut parts = vec![format!("p{} {}{units}:", f.focus + 1, p.label)];
    if !p.used {
        parts.push("not used by this command.".into());
    } else if !p.description.is_empty() {
        let d = p.description.trim_end();
        parts.push(match d.ends_with(['.', '!', '?', ')']) {
            true => d.to_string(),
            false => format!("{d}."),
        });
    }
    if !p.enum_name.is_empty() {
        parts.push(format!("{}: {}.", p.enum_name, p.values));
    }
    let mut range = Vec::new();
    if let Some(v) = p.min {
        range.push(format!("min {}", num(v)));
    }
    if let Some(v) = p.max {
        range.push(format!("max {}", num(v)));
    }
    if let Some(v) = p.increment {
        range.push(format!("increment {}", num(v)));
    }
    range.push(format!("empty sends {}", num(p.default)));
    parts.push(range.join(", ") + ".");
    parts.join(" ")
}

/// The description, a row per field (an empty one shows, dimmed, the default it sends), the
/// focused field's documentation, the preview, and the error or a footer; cut to `body_h`
/// lines, the documentation first, then the description's second line.
fn form(p: &Palette, f: &PaletteForm, w: usize, body_h: usize, theme: &Theme) -> Drawn {
    let infos: Vec<ParamInfo> = (0..7).map(|i| mav_cmds::param_info(f.command, i)).collect();
    let labels: Vec<&str> = infos
        .iter()
        .map(|i| i.label.as_str())
        .chain(["target"])
        .collect();
    let label_w = labels
        .iter()
        .map(|l| l.chars().count())
        .max()
        .unwrap_or(0)
        .min(20);
    let desc = mav_cmds::description(f.command);
    let mut desc_lines = if desc.is_empty() {
        vec!["(the dialect does not describe this command)".to_string()]
    } else {
        wrap_words(desc, w)
    };
    // Fixed: the fields, the preview, the footer and a line of description. Then, as room
    // allows: a blank line, the focused field's documentation (4 lines at most), the
    // description's second line, a blank line after the documentation.
    let mut spare = body_h.saturating_sub(FIELDS + 2 + 1 + 1);
    let mut take = |want: usize| {
        let n = want.min(spare);
        spare -= n;
        n
    };
    let blank = take(1);
    let mut about_lines = wrap_words(&about(f, &infos), w);
    let about_n = take(about_lines.len().min(4));
    let desc_n = 1 + take(desc_lines.len().saturating_sub(1).min(1));
    let blank2 = if about_n > 0 { take(1) } else { 0 };
    for (text, n) in [(&mut desc_lines, desc_n), (&mut about_lines, about_n)] {
        if text.len() > n {
            text.truncate(n);
            if let Some(last) = text.last_mut() {
                *last = ellipsize(&format!("{last} …"), w);
            }
        }
    }
    let mut lines: Vec<Line<'static>> = desc_lines
        .into_iter()
        .map(|l| Line::styled(l, theme.dim()))
        .collect();
    let mut cursor = None;
    for (i, label) in labels.iter().enumerate().take(FIELDS) {
        let name = if i == TARGET {
            "  ".to_string()
        } else {
            format!("p{}", i + 1)
        };
        let head = format!("{name} {:<label_w$} ", ellipsize(label, label_w));
        let focused = i == f.focus;
        let (value, cur) = shown(&f.fields[i], VALUE_W);
        if focused {
            cursor = Some((head.chars().count() + 1 + cur, lines.len()));
        }
        let value_style = if focused {
            theme.selected()
        } else {
            Style::default()
        };
        // Empty: the default it sends, dimmed.
        let value_span = if i != TARGET && f.fields[i].text.trim().is_empty() {
            Span::styled(
                format!("{:<VALUE_W$}", wire_value(f.default(i))),
                value_style.patch(theme.dim()),
            )
        } else {
            Span::styled(format!("{value:<VALUE_W$}"), value_style)
        };
        let (units, hint, used) = match infos.get(i) {
            Some(p) => {
                let hint = if p.values.is_empty() {
                    p.description.as_str()
                } else {
                    p.values.as_str()
                };
                (p.units, hint, p.used)
            }
            None => ("", "SYSID:COMPID (a camera: 1:100)", true),
        };
        let tail = format!(" {units:<4} ");
        let room = w.saturating_sub(head.chars().count() + VALUE_W + 2 + tail.chars().count());
        lines.push(Line::from(vec![
            Span::styled(head, if used { theme.header() } else { theme.dim() }),
            Span::raw("["),
            value_span,
            Span::raw("]"),
            Span::raw(tail),
            Span::styled(ellipsize(hint, room), theme.dim()),
        ]));
    }
    if blank > 0 {
        lines.push(Line::raw(""));
    }
    lines.extend(about_lines.into_iter().map(Line::raw));
    if blank2 > 0 {
        lines.push(Line::raw(""));
    }
    for l in f.preview() {
        lines.push(Line::raw(ellipsize(&l, w)));
    }
    lines.push(match &p.error {
        Some(e) => Line::styled(ellipsize(e, w), theme.alert()),
        None => Line::styled(
            ellipsize(
                "empty = the default shown, nan ok  tab/up/down field  enter send  esc back",
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
