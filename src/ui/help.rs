//! The key help (`?`): every binding of the current mode and screen with its action's
//! description, generated from the keymap so it is never out of date, then the prompt's
//! commands. Scrolls when it does not fit; any other key closes it.

use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Clear, Paragraph};
use ratatui::Frame;

use super::{ellipsize, Theme};
use crate::app::input::COMMANDS;
use crate::app::App;
use crate::keymap::{Action, Mode};

/// (keys, description) for every bound action of normal mode on the current screen, in the
/// keymap's order (the replay keys only while there is a replay link).
pub fn help_rows(app: &App) -> Vec<(String, &'static str)> {
    let replaying = !app.replay_links().is_empty();
    app.keymap
        .bindings(Mode::Normal, app.ui.screen)
        .into_iter()
        .filter(|(_, keys)| !keys.is_empty())
        .filter(|(a, _)| match a {
            // Number keys of screens this build does not have yet are not worth a line.
            Action::Screen(i) => crate::keymap::SCREENS
                .get(*i as usize)
                .is_some_and(|n| crate::app::screen::by_name(n).is_some()),
            a => replaying || !a.is_replay(),
        })
        .map(|(a, keys)| {
            let names: Vec<String> = keys.iter().map(|k| k.to_string()).collect();
            (names.join(", "), a.description())
        })
        .collect()
}

/// The Parameters screen's marks, below its keys.
const PARAM_MARKS: [&str; 2] = [
    "marks: * changed since the download  ≠ differs from the loaded file",
    "       … edit sent  ✓ confirmed by the vehicle  ✗ failed (why: in the detail pane)",
];

/// Widest key or command kept on one line with its description.
const KEY_COLUMN_MAX: usize = 32;

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let rows = help_rows(app);
    let replaying = !app.replay_links().is_empty();
    let commands: Vec<(String, &str)> = COMMANDS
        .iter()
        .filter(|(name, _, _)| replaying || *name != "replay")
        .map(|(name, args, what)| (format!(":{name} {args}").trim_end().to_string(), *what))
        .collect();
    // A key column as wide as the keys and most commands; a longer command (`:param ...`) has
    // its description on the line below.
    let key_w = rows
        .iter()
        .chain(&commands)
        .map(|r| r.0.chars().count())
        .filter(|n| *n <= KEY_COLUMN_MAX)
        .max()
        .unwrap_or(0);
    let desc_w = rows
        .iter()
        .chain(&commands)
        .map(|r| r.1.chars().count())
        .max()
        .unwrap_or(0);
    let long_w = rows
        .iter()
        .chain(&commands)
        .map(|r| r.0.chars().count())
        .max()
        .unwrap_or(0);
    let want_w = (key_w + desc_w + 2).max(long_w) as u16 + 2; // gap, borders
    let w = want_w.min(area.width);
    let inner_w = (w as usize).saturating_sub(2);
    let line = |keys: &str, desc: &str| {
        let desc_room = inner_w.saturating_sub(key_w + 2);
        if keys.chars().count() > key_w {
            return vec![
                Line::styled(ellipsize(keys, inner_w), theme.header()),
                Line::from(vec![
                    Span::raw(" ".repeat(key_w + 2)),
                    Span::raw(ellipsize(desc, desc_room)),
                ]),
            ];
        }
        vec![Line::from(vec![
            Span::styled(format!("{keys:<key_w$}"), theme.header()),
            Span::raw("  "),
            Span::raw(ellipsize(desc, desc_room)),
        ])]
    };
    let mut lines: Vec<Line> = rows.iter().flat_map(|(k, d)| line(k, d)).collect();
    if app.ui.screen == "parameters" {
        for l in PARAM_MARKS {
            lines.push(Line::styled(ellipsize(l, inner_w), theme.dim()));
        }
    }
    lines.push(Line::styled("commands (: opens the prompt)", theme.dim()));
    lines.extend(commands.iter().flat_map(|(k, d)| line(k, d)));
    let footer = Line::styled("any other key closes this help", theme.dim());
    let h = (lines.len() as u16 + 3).min(area.height);
    let body_rows = (h as usize).saturating_sub(3);
    let max_scroll = lines.len().saturating_sub(body_rows);
    let scroll = app.ui.help_scroll.min(max_scroll);
    let mut shown: Vec<Line> = lines.into_iter().skip(scroll).take(body_rows).collect();
    shown.push(footer);
    let popup = Rect::new(
        area.x + (area.width - w) / 2,
        area.y + (area.height - h) / 2,
        w,
        h,
    );
    frame.render_widget(Clear, popup);
    let title = if max_scroll > 0 {
        format!(" Keys ({}/{}) ", scroll + 1, max_scroll + 1)
    } else {
        " Keys ".to_string()
    };
    let block = Block::default()
        .borders(Borders::ALL)
        .border_style(theme.focus_border())
        .title(title);
    frame.render_widget(Paragraph::new(shown).block(block), popup);
}
