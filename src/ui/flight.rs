//! The flight pane of the Overview: the target's telemetry in a title line and three lines,
//! readable at 80 columns.
//!
//! ```text
//! ─ Flight 1:1 ──────────────────────────────────────────────────────────────────
//! ALT 10.0 m (rel) 594.0 m AMSL ▁▂▄▆██████  GS 0.2 m/s  CLB +1.4 m/s  HDG 353°
//! POS -35.3632621 149.1652374  HOME 12 m 045°  EKF ok  PRE ok
//! BAT 12.4 V 3.2 A 87%  GPS 3D 10 sats  LOSS 0.0% ▁▁▁▁▁▁▁▁▁▁▁▁▁▁▁▁▁▁▁▁▁▁▁▁▁▁▁▁▁
//! ```
//!
//! HOME is the distance and bearing of the vehicle from home (`HOME --` until home is known).
//! The sparklines show a value a second over the last minute, and up to three minutes of a long
//! flight, as much of it as the line has room for, the newest on the right: the relative altitude
//! (from 0 or the lowest value, whichever is lower, to the highest) and the loss on the link the
//! target is routed on (0 to 100 %, any loss at least one step up; LOSS itself is over the last 10
//! s). A blank is a second without data.
//!
//! A value older than [`STALE_AFTER`] is dimmed and ends in `?`; one never heard shows `--`
//! (EKF and PRE, which not every autopilot reports, are left out until they are).
//! Items are whole or absent: a line too narrow drops its last items, never cuts a number.
//! With no target, or nothing heard yet, the pane is its title line alone. The title row also
//! carries the Health screen's summary when something there needs a look (pre-arm reasons,
//! unhealthy sensors, the EKF over its threshold, a calibration running or a reboot it needs),
//! in the room the rule leaves: `─ Flight 1:1 ─ 2 pre-arm reasons, mag unhealthy (screen 8) ─`.

use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::Paragraph;
use ratatui::Frame;

use super::{ellipsize, fmt, Theme};
use crate::app::links::loss_pct;
use crate::app::App;
use crate::clock::{Micros, SECOND};
use crate::proto::telemetry::{ekf_summary, fix_name, FlightTelemetry, HISTORY_SECS, STALE_AFTER};
use crate::proto::vehicles::VehicleKey;

/// Rows of the pane in full: the title and three lines.
pub const FULL_HEIGHT: u16 = 4;
/// Columns between items.
const SEP: usize = 2;
/// A sparkline narrower than this is left out.
const MIN_SPARK: usize = 4;
/// Sparkline levels, lowest first.
const LEVELS: [char; 8] = ['▁', '▂', '▃', '▄', '▅', '▆', '▇', '█'];

/// The target and its telemetry, once anything was heard.
fn telemetry(app: &App) -> Option<(VehicleKey, &FlightTelemetry)> {
    let key = app.target?;
    let t = &app.sessions.get(&key)?.flight;
    t.has_data().then_some((key, t))
}

/// Rows the pane would like: [`FULL_HEIGHT`] with telemetry, else the title line alone.
pub fn wanted_height(app: &App) -> u16 {
    if telemetry(app).is_some() {
        FULL_HEIGHT
    } else {
        1
    }
}

/// The title: `Flight 1:1`, `Flight 1:1 (12s old)` when nothing was heard for a while,
/// `Flight 1:1: no telemetry`, `Flight: no target`.
pub fn title(app: &App) -> String {
    match (app.target, telemetry(app)) {
        (None, _) => "Flight: no target".into(),
        (Some(k), None) => format!("Flight {k}: no telemetry"),
        (Some(k), Some((_, t))) => {
            let age = t.last_heard().map_or(0, |at| app.now.saturating_sub(at));
            if age > STALE_AFTER {
                let old = fmt::duration(age / SECOND);
                format!("Flight {k} ({old} old)")
            } else {
                format!("Flight {k}")
            }
        }
    }
}

/// Draw the pane in `area`: the title on the first row, then as many lines as fit.
pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    if area.height == 0 || area.width == 0 {
        return;
    }
    let width = area.width as usize;
    let title = format!("─ {} ", ellipsize(&title(app), width.saturating_sub(3)));
    let mut used = title.chars().count();
    let mut spans = vec![Span::styled(title, theme.border())];
    // The Health screen's concerns, in the room the rule leaves (whole words or ellipsized,
    // never pushing a row off).
    let concerns = health_summary(app);
    let room = width.saturating_sub(used + 2);
    if !concerns.is_empty() && room >= MIN_HEALTH {
        let text = format!("{} ", ellipsize(&concerns, room - 1));
        used += 2 + text.chars().count();
        spans.push(Span::styled("─ ", theme.border()));
        spans.push(Span::styled(text, theme.alert()));
    }
    spans.push(Span::styled(
        "─".repeat(width.saturating_sub(used)),
        theme.border(),
    ));
    let head = Line::from(spans);
    frame.render_widget(Paragraph::new(head), Rect { height: 1, ..area });
    let lines = lines(app, width, theme);
    for (i, line) in lines.into_iter().enumerate() {
        let y = area.y + 1 + i as u16;
        if y >= area.y + area.height {
            break;
        }
        let row = Rect {
            y,
            height: 1,
            ..area
        };
        frame.render_widget(Paragraph::new(line), row);
    }
}

/// Columns the health summary needs on the title row to be shown at all.
const MIN_HEALTH: usize = 16;

/// The Health screen's summary of the target when something needs a look (`2 pre-arm
/// reasons, baro unhealthy (screen 8)`), else empty: [`super::health::concerns`].
pub fn health_summary(app: &App) -> String {
    let Some((key, s)) = app
        .target
        .and_then(|k| app.sessions.get(&k).map(|s| (k, s)))
    else {
        return String::new();
    };
    let armed = app.vehicles.get(key).is_some_and(|v| v.armed());
    let parts = super::health::concerns(app, s, armed);
    if parts.is_empty() {
        String::new()
    } else {
        format!("{} (screen 8)", parts.join(", "))
    }
}

/// The three lines of telemetry in `width` columns (none without telemetry).
pub fn lines(app: &App, width: usize, theme: &Theme) -> Vec<Line<'static>> {
    let Some((key, t)) = telemetry(app) else {
        return Vec::new();
    };
    let now = app.now;
    let it = Items { now, theme };
    let pos = t.position;
    let motion = t.motion;

    let alt = it.value(
        "ALT",
        pos.map(|p| {
            let v = p.value;
            let text = format!(
                "{} m (rel) {} m AMSL",
                dec1(v.relative_alt_m()),
                dec1(v.alt_m())
            );
            (text, p.at)
        }),
    );
    // Up to this second if it has a value yet, else up to the one before.
    let end = match t.altitude.recent(now, 1)[0] {
        Some(_) => now,
        None => now.saturating_sub(SECOND),
    };
    let alt_spark = Part::Spark(
        spark_values(t.altitude.recent(end, HISTORY_SECS)),
        Scale::FromZero,
    );
    let gs = it.value(
        "GS",
        motion.map(|m| (format!("{} m/s", dec1(m.value.groundspeed as f64)), m.at)),
    );
    let climb = it.value(
        "CLB",
        motion.map(|m| (format!("{} m/s", signed1(m.value.climb as f64)), m.at)),
    );
    let hdg = it.value(
        "HDG",
        motion.map(|m| (format!("{:03}°", m.value.heading.rem_euclid(360)), m.at)),
    );

    let where_ = it.value(
        "POS",
        pos.map(|p| {
            let v = p.value;
            let text = if v.is_known() {
                format!("{:.7} {:.7}", v.lat(), v.lon())
            } else {
                "none".into()
            };
            (text, p.at)
        }),
    );
    let home = match (t.home, t.from_home(), pos) {
        (Some(_), Some((d, b)), Some(p)) => {
            // Within a metre the bearing means nothing.
            let text = if d < 1.0 {
                metres(d)
            } else {
                format!("{} {:03.0}°", metres(d), b.round().rem_euclid(360.0))
            };
            it.value("HOME", Some((text, p.at)))
        }
        // Home is known but not where the vehicle is.
        (Some(_), _, _) => it.value("HOME", Some(("set".into(), now))),
        (None, _, _) => it.value("HOME", None),
    };
    // EKF_STATUS_REPORT is ArduPilot's, and the pre-arm bit not every autopilot's: each is
    // shown once reported.
    let ekf = t
        .ekf
        .map(|e| it.value("EKF", Some((ekf_summary(e.value).into(), e.at))));
    // The reasons the vehicle gives now for not arming (the Health screen lists them).
    let reasons = app.sessions.get(&key).map_or(0, |s| s.prearm.len());
    let why = |word: &str| match reasons {
        0 => word.to_string(),
        n => format!("{word} ({n}, screen 8)"),
    };
    let prearm = match t.prearm {
        Some(p) => {
            let word = match (p.value.enabled, p.value.healthy) {
                (false, _) => "off",
                (true, true) => "ok",
                (true, false) => "FAIL",
            };
            Some(it.value("PRE", Some((why(word), p.at))))
        }
        None if reasons > 0 => Some(it.value("PRE", Some((why("FAIL"), now)))),
        None => None,
    };

    let bat = it.value(
        "BAT",
        t.battery.map(|b| {
            let v = b.value;
            let mut parts = Vec::new();
            if let Some(x) = v.volts() {
                parts.push(format!("{x:.1} V"));
            }
            if let Some(x) = v.amps() {
                parts.push(format!("{x:.1} A"));
            }
            if let Some(x) = v.remaining_pct {
                parts.push(format!("{x}%"));
            }
            if parts.is_empty() {
                parts.push("--".into());
            }
            (parts.join(" "), b.at)
        }),
    );
    let gps = it.value(
        "GPS",
        t.gps.map(|g| {
            let v = g.value;
            // Satellites of a receiver that is not there (fix type 0) mean nothing.
            let text = match v.satellites {
                Some(n) if v.fix_type != 0 => format!("{} {n} sats", fix_name(v.fix_type)),
                _ => fix_name(v.fix_type),
            };
            (text, g.at)
        }),
    );
    let route = app
        .route(key)
        .and_then(|l| app.links.get(l).map(|s| (l, s)));
    let label = match route {
        Some((l, _)) if app.links.len() > 1 => format!("LINK {l} LOSS"),
        _ => "LOSS".to_string(),
    };
    let loss = it.value(
        &label,
        route.map(|(_, s)| (pct(loss_pct(s.window_totals(now))), now)),
    );
    let loss_spark = route.map(|(_, s)| {
        // The newest complete second: the current one is still being counted.
        let end = now.saturating_sub(SECOND);
        Part::Spark(
            spark_values(s.loss_history.recent(end, HISTORY_SECS)),
            Scale::Percent,
        )
    });

    let mut l1 = vec![alt, alt_spark, gs, climb, hdg];
    let mut l2 = vec![where_, home];
    l2.extend(ekf);
    l2.extend(prearm);
    let mut l3 = vec![bat, gps, loss];
    l3.extend(loss_spark);
    [&mut l1, &mut l2, &mut l3]
        .into_iter()
        .map(|parts| compose(std::mem::take(parts), width))
        .collect()
}

/// Seconds a sparkline always spans (blank where nothing was heard yet).
const SPARK_MIN_SECS: usize = 60;

/// The history a sparkline may show: always its last minute, and before that only from the first
/// value heard, so a wide terminal shows more of a long flight but no blank run before a short one.
fn spark_values(mut values: Vec<Option<f32>>) -> Vec<Option<f32>> {
    let first = values
        .iter()
        .position(Option::is_some)
        .unwrap_or(values.len());
    let start = first.min(values.len().saturating_sub(SPARK_MIN_SECS));
    values.drain(..start);
    values
}

/// One piece of a line: a fixed item (its spans), or a sparkline that takes the room left.
enum Part {
    Item(Vec<Span<'static>>),
    Spark(Vec<Option<f32>>, Scale),
}

/// How sparkline values map to levels.
#[derive(Clone, Copy)]
enum Scale {
    /// From 0 (or the lowest value if below) to the highest value (at least 1 above).
    FromZero,
    /// 0 to 100, any value above 0 at least one level up.
    Percent,
}

/// Builds items, stale or not, against the time now.
struct Items<'a> {
    now: Micros,
    theme: &'a Theme,
}

impl Items<'_> {
    /// `LABEL value`; dim with a trailing `?` when the value was heard more than
    /// [`STALE_AFTER`] ago; `LABEL --` when never heard.
    fn value(&self, label: &str, v: Option<(String, Micros)>) -> Part {
        let spans = match v {
            None => vec![
                Span::styled(format!("{label} "), self.theme.dim()),
                Span::styled("--", self.theme.dim()),
            ],
            Some((text, at)) if self.now.saturating_sub(at) > STALE_AFTER => vec![
                Span::styled(format!("{label} "), self.theme.dim()),
                Span::styled(format!("{text}?"), self.theme.dim()),
            ],
            Some((text, _)) => vec![
                Span::styled(format!("{label} "), self.theme.header()),
                Span::styled(text, Style::default()),
            ],
        };
        Part::Item(spans)
    }
}

fn width_of(spans: &[Span]) -> usize {
    spans.iter().map(|s| s.content.chars().count()).sum()
}

/// Lay `parts` out in `width` columns: items in order, each whole or left out when it does not
/// fit; then a sparkline gets the room left over (up to its length), if that is enough for one.
fn compose(parts: Vec<Part>, width: usize) -> Line<'static> {
    // Which items fit, in order.
    let mut used = 0;
    let mut keep = vec![false; parts.len()];
    for (i, p) in parts.iter().enumerate() {
        if let Part::Item(spans) = p {
            let w = width_of(spans) + if used == 0 { 0 } else { SEP };
            if used + w <= width {
                used += w;
                keep[i] = true;
            }
        }
    }
    // A sparkline follows the item before it after one space.
    let mut spark_w = 0;
    for (i, p) in parts.iter().enumerate() {
        if let Part::Spark(values, _) = p {
            let room = width.saturating_sub(used + 1);
            if room >= MIN_SPARK && keep[..i].iter().any(|&k| k) {
                spark_w = room.min(values.len());
                keep[i] = true;
            }
            break;
        }
    }
    let mut spans: Vec<Span<'static>> = Vec::new();
    let mut first = true;
    for (p, k) in parts.into_iter().zip(keep) {
        if !k {
            continue;
        }
        match p {
            Part::Item(s) => {
                if !first {
                    spans.push(Span::raw(" ".repeat(SEP)));
                }
                spans.extend(s);
            }
            Part::Spark(values, scale) => {
                let shown = &values[values.len() - spark_w..];
                spans.push(Span::raw(format!(" {}", sparkline(shown, scale))));
            }
        }
        first = false;
    }
    Line::from(spans)
}

/// One character per value: a level of [`LEVELS`], a blank for `None`.
fn sparkline(values: &[Option<f32>], scale: Scale) -> String {
    let known = values.iter().flatten().copied();
    let (lo, hi) = match scale {
        Scale::Percent => (0.0, 100.0),
        Scale::FromZero => {
            let lo = known.clone().fold(0.0f32, f32::min);
            let hi = known.fold(lo + 1.0, f32::max);
            (lo, hi)
        }
    };
    let top = (LEVELS.len() - 1) as f32;
    values
        .iter()
        .map(|v| match v {
            None => ' ',
            Some(v) if !v.is_finite() => ' ',
            Some(v) => {
                let x = ((v - lo) / (hi - lo)).clamp(0.0, 1.0) * top;
                let level = match scale {
                    Scale::Percent if *v > 0.0 => x.ceil().max(1.0),
                    _ => x.round(),
                };
                LEVELS[level as usize]
            }
        })
        .collect()
}

/// One decimal, without `-0.0`.
fn dec1(x: f64) -> String {
    let s = format!("{x:.1}");
    if s == "-0.0" {
        "0.0".into()
    } else {
        s
    }
}

/// One decimal with its sign (`+1.4`, `-0.3`, `+0.0`).
fn signed1(x: f64) -> String {
    let s = format!("{x:+.1}");
    if s == "-0.0" {
        "+0.0".into()
    } else {
        s
    }
}

/// `12 m`, `1.23 km`, `123 km`.
fn metres(d: f64) -> String {
    if d < 1000.0 {
        format!("{d:.0} m")
    } else if d < 100_000.0 {
        format!("{:.2} km", d / 1000.0)
    } else {
        format!("{:.0} km", d / 1000.0)
    }
}

/// Loss percent as the links pane shows it (`0.0%`, `12%`).
fn pct(p: f64) -> String {
    if p >= 9.95 {
        format!("{p:.0}%")
    } else {
        format!("{p:.1}%")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(line: &Line) -> String {
        line.spans.iter().map(|s| s.content.as_ref()).collect()
    }

    fn item(s: &str) -> Part {
        Part::Item(vec![Span::raw(s.to_string())])
    }

    #[test]
    fn items_are_whole_or_absent_and_the_sparkline_takes_what_is_left() {
        let spark = || Part::Spark(vec![Some(0.0), Some(5.0), Some(10.0)], Scale::FromZero);
        let parts = || {
            vec![
                item("ALT 10.0 m"),
                spark(),
                item("GS 0.2 m/s"),
                item("HDG 353°"),
            ]
        };
        // Everything fits, the sparkline at its full length.
        assert_eq!(
            text(&compose(parts(), 80)),
            "ALT 10.0 m ▁▅█  GS 0.2 m/s  HDG 353°"
        );
        // 32 columns: items first (10 + 12 + 10 = 32), no room for the sparkline.
        assert_eq!(
            text(&compose(parts(), 32)),
            "ALT 10.0 m  GS 0.2 m/s  HDG 353°"
        );
        // 30: HDG does not fit whole, so it is left out and the sparkline gets the room.
        assert_eq!(text(&compose(parts(), 30)), "ALT 10.0 m ▁▅█  GS 0.2 m/s");
        // Narrower than the first item: nothing rather than a cut number.
        assert_eq!(text(&compose(parts(), 5)), "");
    }

    #[test]
    fn a_sparkline_spans_its_last_minute_and_before_that_only_what_was_heard() {
        let history = |first_heard: usize| -> Vec<Option<f32>> {
            (0..180)
                .map(|i| (i >= first_heard).then_some(i as f32))
                .collect()
        };
        // Heard for 30 s: the last minute, the first half blank (as at 80 columns before).
        let v = spark_values(history(150));
        assert_eq!(v.len(), 60);
        assert_eq!(v[..30], vec![None; 30][..]);
        // Heard for 160 s: all of it, from the first value, for a wide terminal.
        let v = spark_values(history(20));
        assert_eq!(v.len(), 160);
        assert_eq!(v[0], Some(20.0));
        assert_eq!(spark_values(history(0)).len(), 180);
        assert_eq!(spark_values(vec![None; 180]).len(), 60);
        // At 200 columns a long flight's altitude line is mostly sparkline.
        let line = compose(
            vec![
                Part::Item(vec![Span::raw("ALT 10.0 m")]),
                Part::Spark(spark_values(history(20)), Scale::FromZero),
            ],
            200,
        );
        assert_eq!(width_of(&line.spans), 10 + 1 + 160);
    }

    #[test]
    fn sparklines_scale() {
        let v = |xs: &[f32]| xs.iter().map(|&x| Some(x)).collect::<Vec<_>>();
        assert_eq!(sparkline(&v(&[0.0, 5.0, 10.0]), Scale::FromZero), "▁▅█");
        // Flat at 0: the bottom, not noise blown up to full height.
        assert_eq!(sparkline(&v(&[0.0, 0.01, 0.0]), Scale::FromZero), "▁▁▁");
        // Below zero: from the lowest.
        assert_eq!(sparkline(&v(&[-1.0, 0.0]), Scale::FromZero), "▁█");
        // Any loss shows; 100 % is the top; no data is a blank.
        assert_eq!(
            sparkline(
                &[Some(0.0), Some(0.5), Some(50.0), Some(100.0), None],
                Scale::Percent
            ),
            "▁▂▅█ "
        );
    }

    #[test]
    fn numbers() {
        assert_eq!(dec1(-0.04), "0.0");
        assert_eq!(dec1(594.02), "594.0");
        assert_eq!(signed1(1.38), "+1.4");
        assert_eq!(signed1(-0.01), "+0.0");
        assert_eq!(signed1(-0.3), "-0.3");
        assert_eq!(metres(12.4), "12 m");
        assert_eq!(metres(1234.0), "1.23 km");
        assert_eq!(metres(123_456.0), "123 km");
    }
}
