//! The Health screen (`8`): what stands between the target and a flight, without scrolling.
//!
//! Top to bottom: the pre-arm reasons the vehicle gives now (one line each, with their age;
//! a reason not repeated at the vehicle's last 30 s report is dimmed), every SYS_STATUS sensor
//! (present, enabled, healthy), the EKF's flags and variances against ArduPilot's thresholds,
//! GPS, battery, vibration and clipping, the radio, failsafes, and the calibration running (or
//! the last one's result) with a bar per compass. A line too long for the width wraps.

use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Paragraph, Wrap};
use ratatui::Frame;

use super::{fmt, Theme};
use crate::app::session::Session;
use crate::app::App;
use crate::clock::{Micros, SECOND};
use crate::proto::calibration::Phase;
use crate::proto::health::{
    ekf_level, ekf_over_threshold, sensors, unhealthy, vibe_level, Level, EKF_THRESH,
    PREARM_PERIOD,
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
    let mut lines = Vec::new();
    prearm_lines(app, s, armed, theme, &mut lines);
    sensor_lines(app, s, theme, &mut lines);
    ekf_lines(app, s, theme, &mut lines);
    other_lines(app, key, s, theme, &mut lines);
    calibration_lines(app, s, theme, &mut lines);
    frame.render_widget(
        Paragraph::new(lines)
            .block(block.title(title))
            .wrap(Wrap { trim: false }),
        area,
    );
}

/// The Health screen in a few words, for its title and the Overview: `ready`, `armed`,
/// `2 pre-arm reasons, baro unhealthy`, `no health reported yet`.
pub fn summary(app: &App, s: &Session, armed: bool) -> String {
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
        if ekf_over_threshold(&v.value, EKF_THRESH) {
            parts.push("EKF variance".into());
        }
    }
    if let Some(r) = s.calibration.run.as_ref().filter(|r| !r.finished()) {
        parts.push(format!("{} running", r.kind.name()));
    }
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

fn prearm_lines(app: &App, s: &Session, armed: bool, theme: &Theme, lines: &mut Vec<Line<'static>>) {
    let now = app.now;
    let asked = match (s.prearm.asking(), s.prearm.answered) {
        (true, _) => "asking…".to_string(),
        (false, Some(t)) => format!("asked {} ago", fmt::duration(now.saturating_sub(t) / SECOND)),
        (false, None) => "c asks now".to_string(),
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
        // Not repeated at the vehicle's last report: perhaps fixed.
        let style = if ago > PREARM_PERIOD + 2 * SECOND {
            theme.dim()
        } else {
            theme.alert()
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
    let over = ekf_over_threshold(&var, EKF_THRESH);
    spans.push(Span::styled(
        format!(
            "FS_EKF_THRESH {EKF_THRESH}: {}",
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
        if ekf_over_threshold(&v.value, EKF_THRESH) {
            fs.push("EKF variance".into());
        }
    }
    if fs.is_empty() {
        Span::styled("none shown".to_string(), theme.good())
    } else {
        Span::styled(fs.join(", "), theme.alert())
    }
}

/// `c pre-arm  g gyro  …` from the keymap in use.
fn key_hints(app: &App) -> String {
    use crate::keymap::{Action, Mode};
    let hint = |a: Action, what: &str| {
        app.keymap
            .keys_for(Mode::Normal, "health", a)
            .first()
            .map(|k| format!("{k} {what}"))
    };
    [
        hint(Action::HealthPrearm, "pre-arm"),
        hint(Action::CalGyro, "gyro"),
        hint(Action::CalBaro, "baro"),
        hint(Action::CalLevel, "level"),
        hint(Action::CalAccel, "accel"),
        hint(Action::CalSimpleAccel, "simple accel"),
        hint(Action::CalCompass, "compass"),
        hint(Action::CalAccept, "accept"),
        hint(Action::CalCancel, "cancel"),
    ]
    .into_iter()
    .flatten()
    .collect::<Vec<_>>()
    .join("  ")
}

fn calibration_lines(app: &App, s: &Session, theme: &Theme, lines: &mut Vec<Line<'static>>) {
    let keys = key_hints(app);
    let Some(run) = s.calibration.run.as_ref() else {
        lines.push(Line::from(vec![
            label("CALIBRATE", theme),
            Span::styled(keys, theme.dim()),
        ]));
        return;
    };
    let style = match &run.phase {
        Phase::Done { ok: true, .. } => theme.good(),
        Phase::Done { ok: false, .. } => theme.alert(),
        Phase::Position(_) | Phase::Accept => theme.selected(),
        _ => Style::default(),
    };
    lines.push(Line::from(vec![
        label("CALIBRATE", theme),
        Span::styled(run.status_line(), style),
    ]));
    for (id, p) in &run.compasses {
        let w = 20usize;
        let full = (p.pct as usize * w).div_ceil(100).min(w);
        let status = match run.reports.get(id) {
            Some(r) => format!(
                "{}  fitness {:.1}  offsets {:.0} {:.0} {:.0}",
                crate::proto::calibration::mag_status_name(r.status),
                r.fitness,
                r.offsets[0],
                r.offsets[1],
                r.offsets[2]
            ),
            None => format!(
                "{} attempt {}",
                crate::proto::calibration::mag_status_name(p.status),
                p.attempt
            ),
        };
        lines.push(Line::from(vec![
            Span::raw(format!("{:LABEL$}mag {id} ", "")),
            Span::styled("█".repeat(full), theme.good()),
            Span::styled("░".repeat(w - full), theme.dim()),
            Span::raw(format!(" {:>3}%  {status}", p.pct)),
        ]));
    }
    lines.push(Line::from(vec![
        Span::raw(" ".repeat(LABEL)),
        Span::styled(keys, theme.dim()),
    ]));
}
