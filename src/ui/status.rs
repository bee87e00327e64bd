//! The status bar: clock, target vehicle, and key hints read from the active keymap (so a
//! remapped key shows its new name).

use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::Paragraph;
use ratatui::Frame;

use super::Theme;
use crate::app::App;
use crate::keymap::Action;

/// Actions worth a hint, with the short word shown.
const HINTS: &[(Action, &str)] = &[
    (Action::Quit, "quit"),
    (Action::FocusNext, "focus"),
    (Action::NextVehicle, "target"),
    (Action::ToggleExpand, "expand"),
    (Action::Help, "help"),
];

/// `target 1:1 STABILIZE disarmed`, `target 1:1 (lost)` or `no target`.
pub fn target_text(app: &App) -> String {
    match app.target {
        None => "no target".into(),
        Some(key) => match app.vehicles.get(key) {
            None => format!("target {}:{}", key.0, key.1),
            Some(v) => format!(
                "target {}:{} {} {}{}",
                key.0,
                key.1,
                v.mode_name(),
                if v.armed() { "ARMED" } else { "disarmed" },
                if v.lost { " (lost)" } else { "" }
            ),
        },
    }
}

/// `q quit  tab focus  ? help` from the keymap in use.
pub fn hints_text(app: &App) -> String {
    HINTS
        .iter()
        .filter_map(|(a, word)| {
            app.keymap
                .keys_for(*a)
                .first()
                .map(|k| format!("{k} {word}"))
        })
        .collect::<Vec<_>>()
        .join("  ")
}

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let clock = app.wall(app.now).format("%H:%M:%S").to_string();
    let target_style = match app.target.and_then(|k| app.vehicles.get(k)) {
        Some(v) if v.lost => theme.alert(),
        Some(v) if v.armed() => theme.armed(),
        Some(_) => theme.good(),
        None => theme.dim(),
    };
    let line = Line::from(vec![
        Span::styled(clock, theme.header()),
        Span::raw("  "),
        Span::styled(target_text(app), target_style),
        Span::raw("  │ "),
        Span::styled(hints_text(app), theme.dim()),
    ]);
    frame.render_widget(Paragraph::new(line), area);
}
