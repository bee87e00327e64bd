//! The status bar: clock, target vehicle, and key hints read from the active keymap (so a
//! remapped key shows its new name).

use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::Paragraph;
use ratatui::Frame;

use super::{ellipsize, Theme};
use crate::app::input::TextLine;
use crate::app::inspector::InspectEdit;
use crate::app::params::ParamEdit;
use crate::app::App;
use crate::keymap::{Action, Mode};

/// Actions worth a hint, with the short word shown, most important first: when the bar is
/// short the last ones are dropped. Shown in this order too.
const HINTS: &[(Action, &str)] = &[
    (Action::Quit, "quit"),
    (Action::Help, "help"),
    (Action::ParamFilter, "filter"),
    (Action::InspectorFilter, "filter"),
    (Action::ParamEdit, "edit"),
    (Action::InspectorRate, "rate"),
    (Action::InspectorDetail, "fields"),
    (Action::ParamFetch, "fetch"),
    (Action::FocusNext, "focus"),
    (Action::NextVehicle, "target"),
    (Action::ToggleExpand, "expand"),
];

/// `target 1:1 STABILIZE disarmed`, `target 1:1 (lost)` or `no target`.
pub fn target_text(app: &App) -> String {
    match app.target {
        None => "no target".into(),
        Some(key) => match app.vehicles.get(key) {
            None => format!("target {key}"),
            Some(v) => format!(
                "target {key} {} {}{}",
                v.mode_name(),
                if v.armed() { "ARMED" } else { "disarmed" },
                if v.lost { " (lost)" } else { "" }
            ),
        },
    }
}

/// The target's state for the strip on top of every screen but the Overview: `1:1 GUIDED
/// ARMED`, then its altitude above home and its battery (`ALT 10.0 m (rel)`, `BAT 12.4 V 87%`,
/// `--` until heard), each whole or left out when the line is short.
pub fn state_items(app: &App) -> Vec<String> {
    let Some(key) = app.target else {
        return vec!["no target".into()];
    };
    let mut out = vec![target_text(app)
        .strip_prefix("target ")
        .map(str::to_string)
        .unwrap_or_else(|| target_text(app))];
    let flight = app.sessions.get(&key).map(|s| &s.flight);
    let alt = flight
        .and_then(|f| f.position.as_ref())
        .map_or("--".into(), |p| {
            format!("{:.1} m (rel)", p.value.relative_alt_m())
        });
    out.push(format!("ALT {alt}"));
    let bat = flight
        .and_then(|f| f.battery.as_ref())
        .map(|b| {
            let v = b.value;
            let mut parts = Vec::new();
            if let Some(x) = v.volts() {
                parts.push(format!("{x:.1} V"));
            }
            if let Some(x) = v.remaining_pct {
                parts.push(format!("{x}%"));
            }
            parts.join(" ")
        })
        .filter(|t| !t.is_empty())
        .unwrap_or_else(|| "--".into());
    out.push(format!("BAT {bat}"));
    out
}

/// The state strip's text in `width` columns: [`state_items`], the last ones left out where
/// they do not fit, the first cut with `…` only when it alone is too long.
pub fn state_text(app: &App, width: usize) -> String {
    let mut out = String::new();
    for (i, item) in state_items(app).into_iter().enumerate() {
        let sep = if i == 0 { "" } else { "  " };
        if i > 0 && out.chars().count() + sep.len() + item.chars().count() > width {
            break;
        }
        out.push_str(sep);
        out.push_str(&item);
    }
    ellipsize(&out, width)
}

/// The state strip: the target's mode, arming, altitude and battery on one line.
pub fn render_state(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let style = match app.target.and_then(|k| app.vehicles.get(k)) {
        Some(v) if v.lost => theme.alert(),
        Some(v) if v.armed() => theme.armed(),
        Some(_) => theme.good(),
        None => theme.dim(),
    };
    let line = Line::styled(state_text(app, area.width as usize), style);
    frame.render_widget(Paragraph::new(line), area);
}

/// Fly mode's keys, in the line above the status bar while it is on (fits 80 columns).
pub const FLY_HINT: &str =
    "FLY ←↑↓→ move  w/s up/down  a/d yaw  1/2/3 speed  r/f alt ±1 m  esc leaves";

/// The Fly-mode hint line.
pub fn render_fly_hint(frame: &mut Frame, area: Rect, theme: &Theme) {
    let line = Line::styled(ellipsize(FLY_HINT, area.width as usize), theme.armed());
    frame.render_widget(Paragraph::new(line), area);
}

/// The first replay link's state: `replay 00:12/01:22 ×2 paused`, `replay 01:22/01:22 end`
/// (hours shown once the log is an hour long; no duration for a stream).
pub fn replay_text(app: &App) -> Option<String> {
    use crate::link::replay::{clock_text, speed_text};
    let v = app.replay_view()?;
    let st = &v.status;
    let pos = v.position(app.now);
    let long = st.duration.unwrap_or(pos).max(pos) >= 3600 * crate::clock::SECOND;
    let mut t = format!("replay {}", clock_text(pos, long));
    if let Some(d) = st.duration {
        t += &format!("/{}", clock_text(d, long));
    }
    if st.ended {
        t += " end";
    } else {
        t += &format!(" {}", speed_text(st.speed));
        if st.paused {
            t += " paused";
        }
    }
    Some(t)
}

/// `14:03:27 UTC`, `14:03:27 +05:30`: the time shown as now (during a tlog replay the
/// recording's) in the zone times are shown in, and that zone.
pub fn clock_text(app: &App) -> String {
    format!(
        "{} {}",
        app.shown_time().format("%H:%M:%S"),
        app.cfg.zone.label
    )
}

/// `q quit  ? help  tab focus ...` from the keymap in use on the screen shown, as many as fit
/// in `width`.
pub fn hints_text(app: &App, width: usize) -> String {
    let mut out = String::new();
    for (a, word) in HINTS {
        let Some(k) = app
            .keymap
            .keys_for(Mode::Normal, app.ui.screen, *a)
            .into_iter()
            .next()
        else {
            continue;
        };
        let hint = format!("{k} {word}");
        let sep = if out.is_empty() { "" } else { "  " };
        if out.chars().count() + sep.len() + hint.chars().count() > width {
            break;
        }
        out.push_str(sep);
        out.push_str(&hint);
    }
    out
}

/// The status bar; while a command or a value is typed, the line being typed with its cursor.
pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    match app.ui.mode {
        Mode::Prompt => {
            let hint = app.ui.message.as_ref().map(|m| m.1.as_str());
            return text_line(frame, area, ":", &app.ui.prompt.line, hint, theme);
        }
        // The palette shows what is typed in its popup.
        Mode::Edit if app.ui.mode_picker.is_some() => {}
        Mode::Edit if app.ui.palette.is_none() && app.ui.inspector.editing.is_some() => {
            return match &app.ui.inspector.editing {
                Some(InspectEdit::Rate(k)) => {
                    let text = super::inspector::rate_prompt(app, *k);
                    let line = Line::styled(ellipsize(&text, area.width as usize), theme.header());
                    frame.render_widget(Paragraph::new(line), area);
                }
                _ => {
                    let hint = edit_hint(
                        app,
                        &[(Action::Submit, "keeps"), (Action::Cancel, "clears")],
                    );
                    text_line(frame, area, "/", &app.ui.edit, Some(&hint), theme)
                }
            };
        }
        Mode::Edit if app.ui.palette.is_none() => {
            return match &app.ui.params.editing {
                Some(ParamEdit::Filter) => {
                    let hint = edit_hint(
                        app,
                        &[(Action::Submit, "keeps"), (Action::Cancel, "clears")],
                    );
                    text_line(frame, area, "/", &app.ui.edit, Some(&hint), theme)
                }
                // Typed in its row on the Parameters screen: here, what the keys do.
                Some(ParamEdit::Value(_, name)) => {
                    let mut keys = vec![(Action::Submit, "sends"), (Action::Cancel, "cancels")];
                    if app.param_meta(name).is_some_and(|m| !m.values.is_empty()) {
                        keys.push((Action::Complete, "next value name"));
                    }
                    let was = app
                        .param_set()
                        .and_then(|s| s.params.get(name.as_str()))
                        .map_or(String::new(), |p| format!(" (now {})", p.text()));
                    let text = format!("editing {name}{was}: {}", edit_hint(app, &keys));
                    let line = Line::styled(ellipsize(&text, area.width as usize), theme.header());
                    frame.render_widget(Paragraph::new(line), area);
                }
                None => text_line(frame, area, "= ", &app.ui.edit, None, theme),
            };
        }
        _ => {}
    }
    let clock = clock_text(app);
    let target_style = match app.target.and_then(|k| app.vehicles.get(k)) {
        Some(v) if v.lost => theme.alert(),
        Some(v) if v.armed() => theme.armed(),
        Some(_) => theme.good(),
        None => theme.dim(),
    };
    // A parameter download of the target shows on every screen.
    let progress = app
        .target
        .and_then(|k| app.sessions.get(&k))
        .and_then(|s| s.params.downloading())
        .map(|(_, got, count, _)| {
            let of = count.map_or("?".into(), |c| c.to_string());
            format!("  params {got}/{of}")
        })
        .unwrap_or_default()
        + &crate::app::logs::status_bar_text(app)
            .map(|t| format!("  {t}"))
            .unwrap_or_default();
    let mut target = target_text(app) + &progress;
    // Fly mode stands first, loud: the keys fly the vehicle.
    let fly = app.fly_text().map(|f| f + "  ").unwrap_or_default();
    // Traffic near the target stands next, as loud (the Map screen's proximity warning).
    let fly = fly + &app.traffic_alert().map(|t| t + "  ").unwrap_or_default();
    let replay = fly.clone() + &replay_text(app).map(|r| r + "  ").unwrap_or_default();
    // The telemetry log, when there is one: name and size; shortened, then left out, when the
    // bar is short.
    let (mut log, log_style) = log_text(app, theme);
    let width = area.width as usize;
    let used = |target: &str, log: &str| {
        let log_w = if log.is_empty() {
            0
        } else {
            log.chars().count() + 2
        };
        clock.len() + 2 + replay.chars().count() + target.chars().count() + log_w + 4
    };
    if !log.is_empty() && width.saturating_sub(used(&target, &log)) < MIN_TAIL {
        log = app.recording.as_ref().map_or(String::new(), short_log_text);
        if width.saturating_sub(used(&target, &log)) < MIN_TAIL {
            log.clear();
        }
    }
    let room_for = |target: &str| width.saturating_sub(used(target, &log));
    // A message that does not fit gets the room of the word `target`, then is cut: the
    // target's mode and state stay. Where the state strip shows them (every screen but the
    // Overview), the message gets their room too.
    let mut room = room_for(&target);
    // The last key's message, else the last action's line (until the next action).
    let message = app.ui.message.clone().or_else(|| {
        app.action_text()
            .filter(|_| app.ui.mode_picker.is_none() && app.ui.palette.is_none())
    });
    let long = message
        .as_ref()
        .is_some_and(|(_, text)| text.chars().count() > room);
    if long || room < MIN_TAIL / 3 {
        if let Some(short) = target.strip_prefix("target ") {
            target = short.to_string();
            room = room_for(&target);
        }
    }
    let strip = app.ui.screen != crate::app::screen::SCREENS[0].name;
    if let (Some((_, text)), Some(key), true) = (&message, app.target, strip) {
        if text.chars().count() > room {
            target = format!("{key}{progress}");
            room = room_for(&target);
        }
    }
    if room == 0 {
        target = ellipsize(&target, width.saturating_sub(used("", &log)));
    }
    // The last command's outcome stands where the hints are, until the next key.
    let tail = match &message {
        Some((sev, text)) => Span::styled(ellipsize(text, room), theme.severity(*sev)),
        None if app.ui.mode_picker.is_some() => {
            Span::styled(ellipsize(&super::mode_picker::hint(app), room), theme.dim())
        }
        None if app.ui.palette.is_some() => {
            Span::styled(ellipsize("palette: esc goes back", room), theme.dim())
        }
        None => Span::styled(hints_text(app, room), theme.dim()),
    };
    let mut spans = vec![
        Span::styled(clock, theme.header()),
        Span::raw("  "),
        Span::styled(fly.clone(), theme.armed()),
        Span::styled(replay[fly.len()..].to_string(), theme.header()),
        Span::styled(target, target_style),
    ];
    if !log.is_empty() {
        spans.push(Span::raw("  "));
        spans.push(Span::styled(log, log_style));
    }
    spans.push(Span::raw("  │ "));
    spans.push(tail);
    frame.render_widget(Paragraph::new(Line::from(spans)), area);
}

/// The fewest columns left for hints or a message before the log's part is shortened.
const MIN_TAIL: usize = 24;

/// `log NAME SIZE` while recording, `log NAME stopped` after an error, `no log` when it never
/// started; empty when not recording at all.
fn log_text(app: &App, theme: &Theme) -> (String, ratatui::style::Style) {
    let Some(r) = &app.recording else {
        return (String::new(), theme.dim());
    };
    match &r.error {
        None => (
            format!("log {} {}", r.name(), super::fmt::size(r.bytes)),
            theme.dim(),
        ),
        Some(_) if r.path.as_os_str().is_empty() => ("no log".into(), theme.alert()),
        Some(_) => (format!("log {} stopped", r.name()), theme.alert()),
    }
}

/// The log's part without its name: `log SIZE`, `log stopped`.
fn short_log_text(r: &crate::app::tap::RecordingStatus) -> String {
    match &r.error {
        None => format!("log {}", super::fmt::size(r.bytes)),
        Some(_) => "log stopped".into(),
    }
}

/// `enter sends  esc cancels` from the `[edit]` keys in use.
fn edit_hint(app: &App, actions: &[(Action, &str)]) -> String {
    actions
        .iter()
        .filter_map(|(a, word)| {
            let k = app
                .keymap
                .keys_for(Mode::Edit, app.ui.screen, *a)
                .into_iter()
                .next()?;
            Some(format!("{k} {word}"))
        })
        .collect::<Vec<_>>()
        .join("  ")
}

/// `PREFIX text` with the cursor placed in it; the start scrolls out of view on a long line.
/// `hint` (completions) follows the text, dim, where there is room.
fn text_line(
    frame: &mut Frame,
    area: Rect,
    prefix: &str,
    line: &TextLine,
    hint: Option<&str>,
    theme: &Theme,
) {
    let width = area.width as usize;
    let prefix_w = prefix.chars().count();
    let room = width.saturating_sub(prefix_w + 1).max(1);
    let skip = line.cursor.saturating_sub(room);
    let shown: String = line.text.chars().skip(skip).take(room).collect();
    let used = prefix_w + shown.chars().count();
    let mut spans = vec![
        Span::styled(prefix.to_string(), theme.header()),
        Span::raw(shown),
    ];
    if let Some(h) = hint {
        let room = width.saturating_sub(used + 4);
        if room > 8 {
            spans.push(Span::raw("    "));
            spans.push(Span::styled(ellipsize(h, room), theme.dim()));
        }
    }
    let text = Line::from(spans);
    frame.render_widget(Paragraph::new(text), area);
    let x = area.x + (prefix_w + line.cursor - skip).min(width.saturating_sub(1)) as u16;
    frame.set_cursor_position((x, area.y));
}
