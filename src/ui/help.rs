//! The key help (`?`): every binding of normal mode on the current screen with its action's
//! description, generated from the keymap so it is never out of date, then the prompt's
//! commands. Any key closes it, `q` and `esc` included; only its scroll keys (the `[help]`
//! section's up, down, page and home/end keys, named in its last line) scroll it instead.
//!
//! Order: the keys that work everywhere (the screens' number keys, moving around, the target, the prompt and
//! the palette, help, quit), then the current screen's own keys, then flying the target and Fly
//! mode's own keys, then
//! the replay keys (while replaying), then anything else bound, then the commands. The popup is
//! at most 80 columns wide: a description that does not fit is wrapped, never cut.

use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Clear, Paragraph};
use ratatui::Frame;

use super::inspector::wrap_words as wrap;
use super::Theme;
use crate::app::input::COMMANDS;
use crate::app::screen::SCREENS;
use crate::app::App;
use crate::keymap::{Action, Mode};

/// The widest the popup gets, borders included.
pub const MAX_WIDTH: u16 = 80;

/// Widest key or command kept on one line with its description.
const KEY_COLUMN_MAX: usize = 24;

/// The keys that work on every screen, in the order listed, after the screens' number keys.
const GLOBAL: &[Action] = &[
    Action::Up,
    Action::Down,
    Action::PageUp,
    Action::PageDown,
    Action::Top,
    Action::Bottom,
    Action::NextVehicle,
    Action::PrevVehicle,
    Action::Prompt,
    Action::Palette,
    Action::Outcomes,
    Action::Cancel,
    Action::Help,
    Action::Suspend,
    Action::Quit,
];

/// Flying the target vehicle, in the order listed.
const FLIGHT: &[Action] = &[
    Action::Arm,
    Action::Disarm,
    Action::Takeoff,
    Action::Land,
    Action::Rtl,
    Action::ModeMenu,
    Action::Fly,
];

/// Fly mode's own keys (fixed: [`crate::app::nudge::fly_key`]): the note below the flight keys.
pub const FLY_NOTE: &str = "In Fly mode: up/down forward/back, left/right sideways (held: moves, \
     let go: stops), w/s climb/descend, a/d yaw, 1/2/3 speed 1/2/5 m/s, r/f altitude +/-1 m, \
     esc leaves (other keys leave it first or do nothing)";

/// A group of the help: a heading and its (keys, description) rows.
pub struct HelpGroup {
    pub heading: String,
    pub rows: Vec<(String, &'static str)>,
    /// A note below the rows.
    pub note: Option<&'static str>,
}

/// The help's groups for normal mode on the current screen, in the order shown (see the module
/// doc). The replay keys only while there is a replay link; number keys of screens this build
/// does not have are left out.
pub fn help_groups(app: &App) -> Vec<HelpGroup> {
    let replaying = !app.replay_links().is_empty();
    let screen = app.ui.screen;
    let bound: Vec<(Action, String)> = app
        .keymap
        .bindings(Mode::Normal, screen)
        .into_iter()
        .filter(|(_, keys)| !keys.is_empty())
        .filter(|(a, _)| match a {
            Action::Screen(i) => crate::app::screen::by_action_index(*i as usize).is_some(),
            a => replaying || !a.is_replay(),
        })
        .map(|(a, keys)| {
            let names: Vec<String> = keys.iter().map(|k| k.to_string()).collect();
            (a, names.join(", "))
        })
        .collect();
    let mut taken = vec![false; bound.len()];
    let mut take = |pick: &dyn Fn(Action) -> bool, order: Option<&[Action]>| {
        let mut idx: Vec<usize> = (0..bound.len())
            .filter(|&i| !taken[i] && pick(bound[i].0))
            .collect();
        if let Some(order) = order {
            idx.sort_by_key(|&i| order.iter().position(|a| *a == bound[i].0));
        }
        idx.into_iter()
            .map(|i| {
                taken[i] = true;
                (bound[i].1.clone(), bound[i].0.description())
            })
            .collect::<Vec<_>>()
    };
    let shown = crate::app::screen::by_name(screen);
    let on_screen: Vec<Action> = shown
        .map(|s| {
            app.keymap
                .section(s.section())
                .into_iter()
                .map(|(_, a)| a)
                .collect()
        })
        .unwrap_or_default();
    let title = shown.map_or(screen, |s| s.title);
    let global: Vec<Action> = SCREENS
        .iter()
        .map(|s| s.action())
        .chain(GLOBAL.iter().copied())
        .collect();
    let fly_bound = bound.iter().any(|(a, _)| *a == Action::Fly);
    let mut groups = vec![
        HelpGroup {
            heading: "Everywhere".into(),
            rows: take(&|a| global.contains(&a), Some(&global)),
            note: None,
        },
        HelpGroup {
            heading: format!("{title} screen"),
            rows: take(&|a| on_screen.contains(&a), None),
            note: shown.and_then(|s| s.help_note),
        },
        HelpGroup {
            heading: "Flying the target".into(),
            rows: take(&|a| FLIGHT.contains(&a), Some(FLIGHT)),
            note: fly_bound.then_some(FLY_NOTE),
        },
        HelpGroup {
            heading: "Replay (tlog: links)".into(),
            rows: take(&|a| a.is_replay(), None),
            note: None,
        },
    ];
    groups.push(HelpGroup {
        heading: "Other keys".into(),
        rows: take(&|_| true, None),
        note: None,
    });
    groups.retain(|g| !g.rows.is_empty());
    groups.push(HelpGroup {
        heading: "Commands (: opens the prompt)".into(),
        rows: COMMANDS
            .iter()
            .filter(|(name, _, _)| replaying || *name != "replay")
            .map(|(name, args, what)| (format!(":{name} {args}").trim_end().to_string(), *what))
            .collect(),
        note: None,
    });
    groups
}

/// What a help line is, for its style.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LineKind {
    Heading,
    /// A row: its first `n` characters are keys.
    Row(usize),
    Note,
}

/// The help's lines for a popup `inner_w` columns wide inside its borders: every line at most
/// `inner_w` characters, nothing cut (descriptions wrap under their own column).
pub fn help_lines(app: &App, inner_w: usize) -> Vec<(String, LineKind)> {
    let groups = help_groups(app);
    // One key column for the keys, another for the commands (the last group).
    let column = |gs: &[HelpGroup]| {
        gs.iter()
            .flat_map(|g| &g.rows)
            .map(|r| r.0.chars().count())
            .filter(|n| *n <= KEY_COLUMN_MAX)
            .max()
            .unwrap_or(0)
            .min(inner_w / 3)
    };
    let (key_groups, command_group) = groups.split_at(groups.len().saturating_sub(1));
    let (keys_w, commands_w) = (column(key_groups), column(command_group));
    let mut out = Vec::new();
    for (i, g) in groups.iter().enumerate() {
        let key_w = if i + 1 == groups.len() {
            commands_w
        } else {
            keys_w
        };
        let indent = key_w + 2;
        // Too narrow for two columns: each description goes under its keys.
        let two_columns = inner_w >= indent + 16;
        if i > 0 {
            out.push((String::new(), LineKind::Note));
        }
        for l in wrap(&g.heading, inner_w) {
            out.push((l, LineKind::Heading));
        }
        for (keys, desc) in &g.rows {
            let n = keys.chars().count();
            if two_columns && n <= key_w {
                for (j, d) in wrap(desc, inner_w - indent).into_iter().enumerate() {
                    if j == 0 {
                        out.push((format!("{keys:<key_w$}  {d}"), LineKind::Row(n)));
                    } else {
                        out.push((format!("{:indent$}{d}", ""), LineKind::Row(0)));
                    }
                }
                continue;
            }
            for k in wrap(keys, inner_w) {
                let n = k.chars().count();
                out.push((k, LineKind::Row(n)));
            }
            let (pad, room) = if two_columns {
                (indent, inner_w - indent)
            } else {
                (2.min(inner_w / 4), inner_w - 2.min(inner_w / 4))
            };
            for d in wrap(desc, room) {
                out.push((format!("{:pad$}{d}", ""), LineKind::Row(0)));
            }
        }
        if let Some(note) = g.note {
            for l in wrap(note, inner_w) {
                out.push((l, LineKind::Note));
            }
        }
    }
    out
}

/// `:messages`: the actions' results, newest last, with the time shown for each; the one still
/// awaited last of all.
pub fn outcome_lines(app: &App, inner_w: usize) -> Vec<(String, LineKind)> {
    let mut out = vec![(
        "results of actions, newest last".to_string(),
        LineKind::Heading,
    )];
    if app.ui.outcomes.is_empty() {
        out.push(("none yet".into(), LineKind::Note));
    }
    for o in &app.ui.outcomes {
        let t = app.wall(o.t).format("%H:%M:%S").to_string();
        for (i, l) in wrap(&format!("{t}  {}", o.text), inner_w)
            .into_iter()
            .enumerate()
        {
            let n = if i == 0 { t.len() } else { 0 };
            out.push((l, LineKind::Row(n)));
        }
    }
    if let Some(a) = app.ui.action.as_ref().filter(|a| !a.done) {
        for l in wrap(&format!("awaited: {}", a.text), inner_w) {
            out.push((l, LineKind::Note));
        }
    }
    out
}

/// The last line's text: which keys scroll the help (those of the `[help]` section), and that
/// any other key closes it (`q` too: it does not quit from here).
pub fn footer_text(app: &App) -> String {
    let scroll: Vec<String> = Action::SCROLL
        .iter()
        .flat_map(|a| app.keymap.keys_for(Mode::Help, app.ui.screen, *a))
        .map(|k| k.to_string())
        .collect();
    if scroll.is_empty() {
        "any key closes this help".into()
    } else {
        format!("{} scroll; other keys close", scroll.join(" "))
    }
}

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let max_w = area.width.min(MAX_WIDTH);
    let inner_w = (max_w as usize).saturating_sub(2);
    let mut lines = if app.ui.show_outcomes {
        outcome_lines(app, inner_w)
    } else {
        help_lines(app, inner_w)
    };
    // As narrow as the text allows.
    let text_w = lines.iter().map(|l| l.0.chars().count()).max().unwrap_or(0);
    let footer = wrap(&footer_text(app), inner_w);
    let footer_w = footer.iter().map(|l| l.chars().count()).max().unwrap_or(0);
    let w = ((text_w.max(footer_w) + 2) as u16).min(max_w);
    let body_rows = (area.height as usize).saturating_sub(2 + footer.len());
    let max_scroll = lines.len().saturating_sub(body_rows);
    let scroll = app.ui.help_scroll.min(max_scroll);
    let h = ((lines.len().min(body_rows) + footer.len() + 2) as u16).min(area.height);
    let style = |kind: LineKind, text: String| -> Line {
        match kind {
            LineKind::Heading => Line::styled(text, theme.header()),
            LineKind::Note => Line::styled(text, theme.dim()),
            LineKind::Row(n) => {
                let keys: String = text.chars().take(n).collect();
                let rest: String = text.chars().skip(n).collect();
                Line::from(vec![Span::styled(keys, theme.header()), Span::raw(rest)])
            }
        }
    };
    let mut shown: Vec<Line> = lines
        .drain(..)
        .skip(scroll)
        .take(body_rows)
        .map(|(t, k)| style(k, t))
        .collect();
    shown.extend(footer.into_iter().map(|l| Line::styled(l, theme.dim())));
    let popup = Rect::new(
        area.x + (area.width - w) / 2,
        area.y + (area.height - h) / 2,
        w,
        h,
    );
    frame.render_widget(Clear, popup);
    let name = if app.ui.show_outcomes {
        "Outcomes"
    } else {
        "Keys"
    };
    let title = if max_scroll > 0 {
        format!(" {name} ({}/{}) ", scroll + 1, max_scroll + 1)
    } else {
        format!(" {name} ")
    };
    let block = Block::default()
        .borders(Borders::ALL)
        .border_style(theme.focus_border())
        .title(title);
    frame.render_widget(Paragraph::new(shown).block(block), popup);
}
