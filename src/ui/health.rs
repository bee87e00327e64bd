//! The Health screen (`8`): what stands between the target and a flight, without scrolling.
//!
//! Top to bottom: the pre-arm reasons the vehicle gives now (one line each, with their age;
//! for a vehicle that repeats them every 30 s, a reason not repeated at its last report is
//! dimmed), every SYS_STATUS sensor (present, enabled, healthy), the EKF's flags and variances
//! against ArduPilot's thresholds, GPS, battery, vibration and clipping, the radio, failsafes,
//! and the calibration running (or the last one's result) with a bar per compass and the keys
//! that apply now. A line too long for the width wraps, under its label.
//!
//! When the screen is too short for everything, what matters first stays: the pre-arm head
//! line and the calibration with its keys always, then the reasons, then failsafes, sensors,
//! EKF, GPS, battery, vibration and radio, each whole or left out (the bottom border names
//! what was left out).

use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Paragraph};
use ratatui::Frame;

use super::{fmt, Theme};
use crate::app::session::Session;
use crate::app::App;
use crate::clock::{Micros, SECOND};
use crate::proto::calibration::Phase;
use crate::proto::health::{
    ekf_level, ekf_over_threshold, sensors, unhealthy, vibe_level, Level, EKF_THRESH,
};
use crate::proto::telemetry::{ekf_summary, fix_name, Timed};

/// A label column wide enough for every label.
const LABEL: usize = 10;

fn label(text: &str, theme: &Theme) -> Span<'static> {
    Span::styled(format!("{text:<LABEL$}"), theme.header())
}

fn level_style(l: Level, theme: &Theme) -> Style {
    match l {
        Level::Ok => theme.good(),
        Level::Warn => theme.severity(crate::wire::Severity::WARNING),
        Level::Bad => theme.alert(),
    }
}

/// ` (5s old)` once a value is stale.
fn age<T>(t: &Timed<T>, now: Micros) -> String {
    if t.is_stale(now) {
        format!(" ({} old)", fmt::duration(t.age(now) / SECOND))
    } else {
        String::new()
    }
}

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let block = Block::default()
        .borders(Borders::ALL)
        .border_style(theme.focus_border());
    let Some((key, s)) = app
        .target
        .and_then(|k| app.sessions.get(&k).map(|s| (k, s)))
    else {
        let text = match app.target {
            Some(k) => format!("{k} is not an autopilot"),
            None => "no target vehicle".into(),
        };
        frame.render_widget(
            Paragraph::new(Line::styled(text, theme.dim())).block(block.title(" Health ")),
            area,
        );
        return;
    };
    let armed = app.vehicles.get(key).is_some_and(|v| v.armed());
    let summary = summary(app, s, armed);
    let title = format!(" Health {key}: {summary} ");
    let width = area.width.saturating_sub(2) as usize;
    let budget = area.height.saturating_sub(2) as usize;
    let wrap = |lines: Vec<Line<'static>>| -> Vec<Line<'static>> {
        lines.into_iter().flat_map(|l| wrap_line(l, width)).collect()
    };
    let mut pre = Vec::new();
    prearm_lines(app, s, armed, theme, &mut pre);
    let head = wrap(vec![pre.remove(0)]);
    let reasons: Vec<Vec<Line<'static>>> = pre.into_iter().map(|l| wrap(vec![l])).collect();
    let mut sensors = Vec::new();
    sensor_lines(app, s, theme, &mut sensors);
    let mut ekf = Vec::new();
    ekf_lines(app, s, theme, &mut ekf);
    let mut others = Vec::new();
    other_lines(app, key, s, theme, &mut others);
    let mut cal = Vec::new();
    calibration_lines(app, s, width, theme, &mut cal);
    let mut sections: Vec<(&'static str, Vec<Line<'static>>)> =
        vec![("sensors", wrap(sensors)), ("EKF", wrap(ekf))];
    for (name, line) in ["GPS", "battery", "vibration", "radio", "failsafes"]
        .into_iter()
        .zip(others)
    {
        sections.push((name, wrap(vec![line])));
    }
    let cal = wrap(cal);
    let (lines, hidden) = fit(head, reasons, sections, cal, budget, theme);
    let mut block = block.title(title);
    if !hidden.is_empty() {
        block = block.title_bottom(Line::styled(
            format!(" not shown: {} (a taller terminal shows them) ", hidden.join(", ")),
            theme.dim(),
        ));
    }
    frame.render_widget(Paragraph::new(lines).block(block), area);
}

/// The lines that fit `budget` rows, in screen order, and the names of the sections left out:
/// the pre-arm head line and the calibration always; then as many reasons as fit (the last
/// row saying how many more when not all do); then, by importance, failsafes, sensors, EKF,
/// GPS, battery, vibration and radio, each whole or not at all.
fn fit(
    head: Vec<Line<'static>>,
    reasons: Vec<Vec<Line<'static>>>,
    mut sections: Vec<(&'static str, Vec<Line<'static>>)>,
    cal: Vec<Line<'static>>,
    budget: usize,
    theme: &Theme,
) -> (Vec<Line<'static>>, Vec<&'static str>) {
    let mut left = budget.saturating_sub(head.len() + cal.len());
    let all: usize = reasons.iter().map(Vec::len).sum();
    let mut shown = Vec::new();
    if all <= left {
        shown.extend(reasons.into_iter().flatten());
        left -= all;
    } else {
        // Room for the "more" line first.
        let mut room = left.saturating_sub(1);
        let total = reasons.len();
        let mut n = 0;
        for r in reasons {
            if r.len() > room {
                break;
            }
            room -= r.len();
            shown.extend(r);
            n += 1;
        }
        if left > 0 {
            shown.push(Line::styled(
                format!("  … {} more reason{}", total - n, if total - n == 1 { "" } else { "s" }),
                theme.alert(),
            ));
        }
        left = 0;
    }
    // Importance: failsafes, sensors, EKF, GPS, battery, vibration, radio.
    let order = [
        "failsafes",
        "sensors",
        "EKF",
        "GPS",
        "battery",
        "vibration",
        "radio",
    ];
    let mut keep = vec![false; sections.len()];
    let mut hidden = Vec::new();
    for name in order {
        if let Some(i) = sections.iter().position(|(n, _)| *n == name) {
            let h = sections[i].1.len();
            if h <= left {
                left -= h;
                keep[i] = true;
            } else {
                hidden.push(name);
            }
        }
    }
    let mut lines = head;
    lines.extend(shown);
    for ((_, l), k) in sections.drain(..).zip(keep) {
        if k {
            lines.extend(l);
        }
    }
    lines.extend(cal);
    // Screen order for the names.
    hidden.sort_by_key(|h| ["sensors", "EKF", "GPS", "battery", "vibration", "radio", "failsafes"]
        .iter()
        .position(|n| n == h));
    (lines, hidden)
}

/// `line` broken into rows of `width` columns at spaces, each row after the first indented
/// under the label column. A span with no space at either end (an item: `gyro ok`,
/// `vel 0.02 ok`) stays whole on a row when it can; other text breaks between words, and a
/// word wider than a row where the row ends.
fn wrap_line(line: Line<'static>, width: usize) -> Vec<Line<'static>> {
    let width = width.max(LABEL + 8);
    if line.width() <= width {
        return vec![line];
    }
    // Pieces: (text, style, is a space run).
    let mut pieces: Vec<(String, Style, bool)> = Vec::new();
    for span in line.spans {
        let text = span.content.to_string();
        let item = !text.starts_with(' ')
            && !text.ends_with(' ')
            && fmt::width(&text) <= width / 3;
        if item {
            pieces.push((text, span.style, false));
            continue;
        }
        let mut cur = String::new();
        let mut space = None;
        // A `quoted command` is one word.
        let mut quoted = false;
        for c in text.chars() {
            if c == '`' {
                quoted = !quoted;
            }
            let is = c == ' ' && !quoted;
            if space.is_some_and(|sp| sp != is) {
                pieces.push((std::mem::take(&mut cur), span.style, space == Some(true)));
            }
            space = Some(is);
            cur.push(c);
        }
        if !cur.is_empty() {
            pieces.push((cur, span.style, space == Some(true)));
        }
    }
    let mut rows: Vec<Vec<Span<'static>>> = vec![Vec::new()];
    let mut used = 0;
    let mut space: Option<(String, Style)> = None;
    for (text, style, is_space) in pieces {
        if is_space {
            space = Some((text, style));
            continue;
        }
        let w = fmt::width(&text);
        let sp = space.take();
        let sp_w = sp.as_ref().map_or(0, |(t, _)| fmt::width(t));
        let row = rows.last_mut().expect("never empty");
        if used + sp_w + w <= width {
            if let Some((t, st)) = sp {
                row.push(Span::styled(t, st));
            }
            row.push(Span::styled(text, style));
            used += sp_w + w;
            continue;
        }
        if used > LABEL && w <= width - LABEL {
            // On the next row, under the label column (the space between is dropped).
            rows.push(vec![Span::raw(" ".repeat(LABEL)), Span::styled(text, style)]);
            used = LABEL + w;
            continue;
        }
        // Wider than a row: as much as fits on each row.
        if let Some((t, st)) = sp.filter(|_| used + sp_w < width) {
            row.push(Span::styled(t, st));
            used += sp_w;
        }
        let mut rest = text;
        loop {
            let room = width.saturating_sub(used);
            if fmt::width(&rest) <= room {
                used += fmt::width(&rest);
                rows.last_mut()
                    .expect("never empty")
                    .push(Span::styled(rest, style));
                break;
            }
            let (a, b) = split_at_width(&rest, room);
            if !a.is_empty() {
                rows.last_mut()
                    .expect("never empty")
                    .push(Span::styled(a, style));
            }
            rows.push(vec![Span::raw(" ".repeat(LABEL))]);
            used = LABEL;
            rest = b;
        }
    }
    rows.into_iter().map(Line::from).collect()
}

/// `s` split after `cols` columns.
fn split_at_width(s: &str, cols: usize) -> (String, String) {
    let mut a = String::new();
    let mut used = 0;
    let mut chars = s.chars();
    for c in chars.by_ref() {
        let w = fmt::width(c.encode_utf8(&mut [0; 4]));
        if used + w > cols {
            let mut b = String::from(c);
            b.extend(chars);
            return (a, b);
        }
        used += w;
        a.push(c);
    }
    (a, String::new())
}

/// The Health screen in a few words, for its title: the [`concerns`], else `ready`-like words:
/// `armed`, `pre-arm checks pass`, `no health reported yet`.
pub fn summary(app: &App, s: &Session, armed: bool) -> String {
    let parts = concerns(app, s, armed);
    if !parts.is_empty() {
        return parts.join(", ");
    }
    if armed {
        return "armed".into();
    }
    match (s.prearm.passing, s.flight.sensors.is_some()) {
        (Some(true), _) => "pre-arm checks pass".into(),
        (Some(false), _) => "pre-arm checks fail (reasons not heard yet: c asks)".into(),
        (None, true) => "no pre-arm reason stated".into(),
        (None, false) => "no health reported yet".into(),
    }
}

/// What the Health screen would have the operator look at, for its title and the Overview:
/// `2 pre-arm reasons`, `baro unhealthy`, `EKF variance`, `compass calibration running`,
/// `reboot needed`. Empty when nothing is wrong.
pub fn concerns(app: &App, s: &Session, armed: bool) -> Vec<String> {
    let now = app.now;
    let mut parts = Vec::new();
    let n = s.prearm.len();
    if n > 0 && !armed {
        parts.push(format!(
            "{n} pre-arm reason{}",
            if n == 1 { "" } else { "s" }
        ));
    }
    if let Some(sens) = s.flight.sensors.as_ref().filter(|x| !x.is_stale(now)) {
        let bad: Vec<String> = unhealthy(&sens.value)
            .into_iter()
            .filter(|n| n != "pre-arm")
            .collect();
        if !bad.is_empty() {
            parts.push(format!("{} unhealthy", bad.join(" ")));
        }
    }
    if let Some(v) = s.flight.ekf_variances.filter(|x| !x.is_stale(now)) {
        if ekf_over_threshold(&v.value, ekf_thresh(s)) {
            parts.push("EKF variance".into());
        }
    }
    match s.calibration.run.as_ref() {
        Some(r) if r.phase == Phase::Accept => parts.push(format!("{} to accept", r.kind.name())),
        Some(r) if !r.finished() => parts.push(format!("{} running", r.kind.name())),
        Some(r) if r.reboot_needed => parts.push("reboot needed".into()),
        _ => {}
    }
    parts
}

fn prearm_lines(app: &App, s: &Session, armed: bool, theme: &Theme, lines: &mut Vec<Line<'static>>) {
    let now = app.now;
    let ago = |t: Micros| fmt::duration(now.saturating_sub(t) / SECOND);
    let asked = match (s.prearm.asking(), s.prearm.answered, s.prearm.unanswered) {
        (true, _, _) => "asking…".to_string(),
        // The last ask got no answer (it or its ACK lost).
        (false, a, Some(u)) if a.is_none_or(|a| a < u) => "no answer: c asks again".to_string(),
        (false, Some(t), _) => format!("asked {} ago", ago(t)),
        (false, None, _) => "c asks now".to_string(),
    };
    let head = match (armed, s.prearm.len(), s.prearm.passing) {
        (true, _, _) => Span::styled("armed".to_string(), theme.armed()),
        (false, 0, Some(true)) => Span::styled("checks pass".to_string(), theme.good()),
        (false, 0, _) => Span::styled("no reason stated".to_string(), theme.dim()),
        (false, n, _) => Span::styled(
            format!("{n} reason{} not to arm", if n == 1 { "" } else { "s" }),
            theme.alert(),
        ),
    };
    lines.push(Line::from(vec![
        label("PRE-ARM", theme),
        head,
        Span::styled(format!("  ({asked})"), theme.dim()),
    ]));
    for r in s.prearm.reasons() {
        let ago = now.saturating_sub(r.last);
        // Not repeated at the vehicle's last report: perhaps fixed (a vehicle that does not
        // repeat them, PX4, keeps them until cleared).
        let style = match s.prearm.period() {
            Some(p) if ago > p + 2 * SECOND => theme.dim(),
            _ => theme.alert(),
        };
        let times = if r.count > 1 {
            format!(" ×{}", r.count)
        } else {
            String::new()
        };
        lines.push(Line::from(vec![
            Span::raw("  "),
            Span::styled(r.line(), style),
            Span::styled(
                format!("  {} ago{times}", fmt::duration(ago / SECOND)),
                theme.dim(),
            ),
        ]));
    }
}

fn sensor_lines(app: &App, s: &Session, theme: &Theme, lines: &mut Vec<Line<'static>>) {
    let Some(sens) = s.flight.sensors.as_ref() else {
        lines.push(Line::from(vec![
            label("SENSORS", theme),
            Span::styled("no SYS_STATUS heard".to_string(), theme.dim()),
        ]));
        return;
    };
    let mut spans = vec![label("SENSORS", theme)];
    for x in sensors(&sens.value) {
        let (word, style) = match (x.enabled, x.healthy) {
            (false, _) => ("off", theme.dim()),
            (true, true) => ("ok", theme.good()),
            (true, false) => ("BAD", theme.alert()),
        };
        spans.push(Span::styled(format!("{} {word}", x.name), style));
        spans.push(Span::raw("  "));
    }
    spans.push(Span::styled(
        format!(
            "load {:.1}%{}",
            sens.value.load as f64 / 10.0,
            age(sens, app.now)
        ),
        theme.dim(),
    ));
    lines.push(Line::from(spans));
}

/// The vehicle's `FS_EKF_THRESH` once its parameters hold it (0 turns ArduCopter's EKF
/// failsafe off), else ArduCopter's default.
fn ekf_thresh(s: &Session) -> f32 {
    s.params
        .sets
        .get(&s.key.1)
        .and_then(|set| set.get("FS_EKF_THRESH"))
        .map_or(EKF_THRESH, |p| p.value as f32)
}

fn ekf_lines(app: &App, s: &Session, theme: &Theme, lines: &mut Vec<Line<'static>>) {
    let now = app.now;
    let (Some(flags), Some(v)) = (s.flight.ekf, s.flight.ekf_variances) else {
        lines.push(Line::from(vec![
            label("EKF", theme),
            Span::styled("no EKF_STATUS_REPORT heard".to_string(), theme.dim()),
        ]));
        return;
    };
    let word = ekf_summary(flags.value);
    let style = if word == "ok" {
        theme.good()
    } else {
        theme.alert()
    };
    lines.push(Line::from(vec![
        label("EKF", theme),
        Span::styled(word.to_string(), style),
        Span::styled(
            format!(
                "  {}{}",
                crate::proto::health::ekf_flag_names(flags.value).join(" "),
                age(&flags, now)
            ),
            theme.dim(),
        ),
    ]));
    let var = v.value;
    let mut spans = vec![Span::raw(" ".repeat(LABEL))];
    for (name, x) in [
        ("vel", var.velocity),
        ("pos", var.pos_horiz),
        ("hgt", var.pos_vert),
        ("mag", var.compass),
        ("terr", var.terrain_alt),
    ] {
        let l = ekf_level(x);
        spans.push(Span::styled(
            format!("{name} {x:.2} {}", l.word()),
            level_style(l, theme),
        ));
        spans.push(Span::raw("  "));
    }
    let thresh = ekf_thresh(s);
    let over = ekf_over_threshold(&var, thresh);
    spans.push(Span::styled(
        format!(
            "FS_EKF_THRESH {thresh}: {}",
            if over { "OVER" } else { "within" }
        ),
        if over { theme.alert() } else { theme.dim() },
    ));
    lines.push(Line::from(spans));
}

fn other_lines(
    app: &App,
    key: crate::proto::vehicles::VehicleKey,
    s: &Session,
    theme: &Theme,
    lines: &mut Vec<Line<'static>>,
) {
    let now = app.now;
    let t = &s.flight;
    let gps = match t.gps {
        Some(g) => {
            let v = g.value;
            let mut text = fix_name(v.fix_type);
            if let Some(n) = v.satellites.filter(|_| v.fix_type != 0) {
                text.push_str(&format!("  {n} sats"));
            }
            if let Some(h) = v.hdop_e2.filter(|_| v.fix_type != 0) {
                text.push_str(&format!("  HDOP {:.2}", h as f64 / 100.0));
            }
            let style = if v.fix_type >= 3 {
                theme.good()
            } else {
                theme.alert()
            };
            Span::styled(format!("{text}{}", age(&g, now)), style)
        }
        None => Span::styled("no GPS_RAW_INT heard".to_string(), theme.dim()),
    };
    lines.push(Line::from(vec![label("GPS", theme), gps]));
    let bat = match t.battery {
        Some(b) => {
            let v = b.value;
            let mut parts = Vec::new();
            if let Some(x) = v.volts() {
                parts.push(format!("{x:.2} V"));
            }
            if let Some(x) = v.amps() {
                parts.push(format!("{x:.1} A"));
            }
            if let Some(x) = v.remaining_pct {
                parts.push(format!("{x}%"));
            }
            Span::raw(format!("{}{}", parts.join("  "), age(&b, now)))
        }
        None => Span::styled("no battery heard".to_string(), theme.dim()),
    };
    lines.push(Line::from(vec![label("BATTERY", theme), bat]));
    let vib = match t.vibration {
        Some(v) => {
            let x = v.value;
            let worst = [x.x, x.y, x.z]
                .into_iter()
                .map(vibe_level)
                .max()
                .unwrap_or(Level::Ok);
            let clip = x.clipping.iter().any(|&c| c > 0);
            vec![
                Span::styled(
                    format!(
                        "x {:.1}  y {:.1}  z {:.1} m/s² {}",
                        x.x,
                        x.y,
                        x.z,
                        worst.word()
                    ),
                    level_style(worst, theme),
                ),
                Span::styled(
                    format!(
                        "  clipping {} {} {}{}",
                        x.clipping[0],
                        x.clipping[1],
                        x.clipping[2],
                        age(&v, now)
                    ),
                    if clip { theme.alert() } else { theme.dim() },
                ),
            ]
        }
        None => vec![Span::styled("no VIBRATION heard".to_string(), theme.dim())],
    };
    let mut l = vec![label("VIBRATION", theme)];
    l.extend(vib);
    lines.push(Line::from(l));
    // The radio on the link the target is routed on (a SiK radio speaks as system 51), else
    // one of the vehicle's own system.
    let radio = app
        .route(key)
        .and_then(|l| app.radio.get(&l))
        .or(t.radio.as_ref());
    let radio = match radio {
        Some(r) => {
            let x = r.value;
            Span::raw(format!(
                "rssi {}  remrssi {}  noise {}/{}  txbuf {}%  rxerrors {}  fixed {}{}",
                x.rssi,
                x.remrssi,
                x.noise,
                x.remnoise,
                x.txbuf,
                x.rxerrors,
                x.fixed,
                age(r, now)
            ))
        }
        None => Span::styled("no RADIO_STATUS heard".to_string(), theme.dim()),
    };
    lines.push(Line::from(vec![label("RADIO", theme), radio]));
    lines.push(Line::from(vec![label("FAILSAFE", theme), failsafes(app, key, s, theme)]));
}

/// What the vehicle shows of a failsafe: its state (CRITICAL or EMERGENCY), the RC receiver or
/// battery unhealthy, the EKF over its threshold.
fn failsafes(
    app: &App,
    key: crate::proto::vehicles::VehicleKey,
    s: &Session,
    theme: &Theme,
) -> Span<'static> {
    let now = app.now;
    let mut fs = Vec::new();
    if let Some(v) = app.vehicles.get(key) {
        use crate::dialect::MavState::*;
        if matches!(v.system_status, MAV_STATE_CRITICAL | MAV_STATE_EMERGENCY) {
            fs.push(format!("state {}", v.status_name()));
        }
    }
    if let Some(sens) = s.flight.sensors.as_ref().filter(|x| !x.is_stale(now)) {
        for name in unhealthy(&sens.value) {
            if name == "RC" {
                fs.push("RC (radio failsafe)".into());
            }
            if name == "battery" {
                fs.push("battery".into());
            }
        }
    }
    if let Some(v) = s.flight.ekf_variances.filter(|x| !x.is_stale(now)) {
        if ekf_over_threshold(&v.value, ekf_thresh(s)) {
            fs.push("EKF variance".into());
        }
    }
    if fs.is_empty() {
        Span::styled("none shown".to_string(), theme.good())
    } else {
        Span::styled(fs.join(", "), theme.alert())
    }
}

/// The keys that apply now, from the keymap in use: while the vehicle waits at an
/// accelerometer position, `enter` and cancel; while a compass calibration waits to be
/// accepted, accept and cancel; while one runs, cancel; else the pre-arm ask and every
/// calibration.
fn key_hints(app: &App, phase: Option<&Phase>) -> Vec<String> {
    use crate::keymap::{Action, Mode};
    let hint = |a: Action, what: &str| {
        app.keymap
            .keys_for(Mode::Normal, "health", a)
            .first()
            .map(|k| format!("{k} {what}"))
    };
    let hints = match phase {
        Some(Phase::Position(_)) => vec![
            hint(Action::CalNext, "placed"),
            hint(Action::CalCancel, "cancel"),
        ],
        Some(Phase::Accept) => vec![
            hint(Action::CalAccept, "accept"),
            hint(Action::CalCancel, "cancel"),
        ],
        Some(Phase::Done { .. }) | None => vec![
            hint(Action::HealthPrearm, "pre-arm"),
            hint(Action::CalGyro, "gyro"),
            hint(Action::CalBaro, "baro"),
            hint(Action::CalLevel, "level"),
            hint(Action::CalAccel, "accel"),
            hint(Action::CalSimpleAccel, "simple accel"),
            hint(Action::CalCompass, "compass"),
        ],
        Some(_) => vec![hint(Action::CalCancel, "cancel")],
    };
    hints.into_iter().flatten().collect()
}

/// The key hints as items (each stays whole when the line wraps), dim.
fn key_spans(keys: Vec<String>, theme: &Theme) -> Vec<Span<'static>> {
    let mut spans = Vec::new();
    for (i, k) in keys.into_iter().enumerate() {
        if i > 0 {
            spans.push(Span::raw("  "));
        }
        spans.push(Span::styled(k, theme.dim()));
    }
    spans
}

fn calibration_lines(
    app: &App,
    s: &Session,
    width: usize,
    theme: &Theme,
    lines: &mut Vec<Line<'static>>,
) {
    let Some(run) = s.calibration.run.as_ref() else {
        let mut spans = vec![label("CALIBRATE", theme)];
        spans.extend(key_spans(key_hints(app, None), theme));
        lines.push(Line::from(spans));
        return;
    };
    let keys = key_hints(app, Some(&run.phase));
    let style = match &run.phase {
        // Saved, but the offsets wait for a reboot: the operator has one more thing to do.
        Phase::Done { ok: true, .. } if run.reboot_needed => theme.selected(),
        Phase::Done { ok: true, .. } => theme.good(),
        Phase::Done { ok: false, .. } => theme.alert(),
        Phase::Position(_) | Phase::Accept => theme.selected(),
        _ => Style::default(),
    };
    lines.push(Line::from(vec![
        label("CALIBRATE", theme),
        Span::styled(run.status_line(), style),
    ]));
    // A bar of 20 cells where the line has room for it and the report, else 10.
    let w = if width >= LABEL + 90 { 20usize } else { 10 };
    for (id, p) in &run.compasses {
        let full = (p.pct as usize * w).div_ceil(100).min(w);
        let status = match run.reports.get(id) {
            Some(r) => vec![
                crate::proto::calibration::mag_status_name(r.status),
                format!("fitness {:.1}", r.fitness),
                format!(
                    "offsets {:.0} {:.0} {:.0}",
                    r.offsets[0], r.offsets[1], r.offsets[2]
                ),
            ],
            None => vec![
                crate::proto::calibration::mag_status_name(p.status),
                format!("attempt {}", p.attempt),
            ],
        };
        let mut spans = vec![
            Span::raw(format!("{:LABEL$}mag {id} ", "")),
            Span::styled("█".repeat(full), theme.good()),
            Span::styled("░".repeat(w - full), theme.dim()),
            Span::raw(format!(" {:>3}%", p.pct)),
        ];
        for item in status {
            spans.push(Span::raw("  "));
            spans.push(Span::raw(item));
        }
        lines.push(Line::from(spans));
    }
    let mut spans = vec![Span::raw(" ".repeat(LABEL))];
    spans.extend(key_spans(keys, theme));
    lines.push(Line::from(spans));
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(l: &Line) -> String {
        l.spans.iter().map(|s| s.content.as_ref()).collect()
    }

    fn texts(lines: &[Line]) -> Vec<String> {
        lines.iter().map(text).collect()
    }

    #[test]
    fn lines_wrap_under_the_label_keeping_items_whole() {
        let line = Line::from(vec![
            Span::raw("SENSORS   "),
            Span::raw("gyro ok"),
            Span::raw("  "),
            Span::raw("rate ctrl ok"),
            Span::raw("  "),
            Span::raw("attitude ok"),
        ]);
        assert_eq!(
            texts(&wrap_line(line, 40)),
            vec!["SENSORS   gyro ok  rate ctrl ok", "          attitude ok"]
        );
        // Text breaks between words; a `quoted command` is one.
        let line = Line::from(vec![
            Span::raw("CALIBRATE "),
            Span::raw("done; `cal accept` saves it"),
        ]);
        assert_eq!(
            texts(&wrap_line(line, 30)),
            vec!["CALIBRATE done; `cal accept`", "          saves it"]
        );
        // A word wider than a row breaks where each row ends.
        let line = Line::from(vec![Span::raw("EKF       "), Span::raw("x".repeat(50))]);
        assert_eq!(
            texts(&wrap_line(line, 30)),
            vec![
                format!("EKF       {}", "x".repeat(20)),
                format!("          {}", "x".repeat(20)),
                format!("          {}", "x".repeat(10)),
            ]
        );
        // What fits is left alone.
        let line = Line::from("GPS       3D  10 sats");
        assert_eq!(texts(&wrap_line(line, 30)), vec!["GPS       3D  10 sats"]);
    }

    #[test]
    fn what_does_not_fit_goes_by_importance_the_calibration_stays() {
        let one = |s: &str| vec![Line::from(s.to_string())];
        let head = one("PRE-ARM");
        let reasons = vec![one("r1"), one("r2"), one("r3")];
        let sections = || {
            vec![
                ("sensors", vec![Line::from("s1"), Line::from("s2")]),
                ("EKF", vec![Line::from("e1"), Line::from("e2")]),
                ("GPS", one("gps")),
                ("battery", one("bat")),
                ("vibration", one("vib")),
                ("radio", one("radio")),
                ("failsafes", one("fs")),
            ]
        };
        let cal = vec![Line::from("CAL"), Line::from("keys")];
        // Room for everything: screen order.
        let (lines, hidden) = fit(
            head.clone(),
            reasons.clone(),
            sections(),
            cal.clone(),
            30,
            &Theme::PLAIN,
        );
        assert_eq!(lines.len(), 1 + 3 + 9 + 2);
        assert!(hidden.is_empty());
        // 10 rows: head, 3 reasons, cal 2 leave 4: failsafes (1), sensors (2), then EKF (2)
        // does not fit, GPS (1) does.
        let (lines, hidden) = fit(
            head.clone(),
            reasons.clone(),
            sections(),
            cal.clone(),
            10,
            &Theme::PLAIN,
        );
        assert_eq!(
            texts(&lines),
            vec!["PRE-ARM", "r1", "r2", "r3", "s1", "s2", "gps", "fs", "CAL", "keys"]
        );
        assert_eq!(hidden, vec!["EKF", "battery", "vibration", "radio"]);
        // 5 rows: one reason and how many more; the calibration stays.
        let (lines, _) = fit(head, reasons, sections(), cal, 5, &Theme::PLAIN);
        assert_eq!(
            texts(&lines),
            vec!["PRE-ARM", "r1", "  … 2 more reasons", "CAL", "keys"]
        );
    }
}
