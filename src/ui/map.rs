//! The Map screen (`9`): a local tangent plane around the view's centre (the target, unless
//! panned or fitted), drawn in braille dots with symbols on top: every vehicle's arrow (its
//! heading) and track, homes `H`, the target's mission (numbered waypoints, legs, the current one
//! marked), geofence (inclusion and exclusion polygons and circles), rally points `R`, the last
//! go-to's target `G`, and ADS-B traffic `✈` (stale ones dimmed) with its course for the next
//! minute. A scale bar in metres at the bottom left, the compass at the top right; the nearest
//! traffic listed beside the map when there is room; the cursor's place (or the next waypoint)
//! in the footer.
//!
//! Small terminals keep the vehicle and the next waypoint: the side list goes first, and a
//! waypoint off the map is pointed at from its edge. Without colour ([`Theme::PLAIN`]) every
//! layer is told apart by its symbol; the target by reverse video.

use ratatui::layout::Rect;
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::canvas::{Canvas, Context, Line as CLine, Points};
use ratatui::widgets::{Block, Borders, Paragraph};
use ratatui::Frame;

use super::Theme;
use crate::app::map::{fence_shapes, item_pos, FenceShape};
use crate::app::App;
use crate::keymap::{Action, Mode};
use crate::mission::MissionType;
use crate::proto::geo::{self, LatLon, Plane};

/// The side list's width range, and the narrowest map that gets one.
const SIDE_MIN: u16 = 26;
const SIDE_MAX: u16 = 40;
const SIDE_FROM_WIDTH: u16 = 76;
/// Seconds of course drawn ahead of each aircraft.
const COURSE_AHEAD_S: f64 = 60.0;

/// How the map turns places into canvas coordinates: metres right and up of the centre.
struct View {
    plane: Plane,
    up: f64,
    /// Half width and half height, metres.
    hw: f64,
    hh: f64,
}

impl View {
    fn xy(&self, p: LatLon) -> (f64, f64) {
        let (e, n) = self.plane.to_en(p);
        geo::rotate(e, n, self.up)
    }

    fn inside(&self, (x, y): (f64, f64)) -> bool {
        x.abs() <= self.hw && y.abs() <= self.hh
    }
}

fn colour(theme: &Theme, c: Color) -> Color {
    if theme.color {
        c
    } else {
        Color::Reset
    }
}

/// The first key bound to `a` on the map.
fn key(app: &App, a: Action) -> String {
    app.keymap
        .keys_for(Mode::Normal, "map", a)
        .first()
        .map(|k| k.to_string())
        .unwrap_or_default()
}

/// Draw the Map in `area`.
pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let v = &app.ui.map;
    let how = if v.fit.is_some() {
        "fitted".to_string()
    } else if v.follow && app.target_pos().is_some() {
        format!("following {}", app.target.map_or("?".into(), |k| k.to_string()))
    } else {
        "panned".to_string()
    };
    let up = if v.heading_up {
        format!("heading up {:03.0}°", app.map_up())
    } else {
        "north up".into()
    };
    let title = format!(" Map: {how}, {up} ");
    let block = Block::default()
        .borders(Borders::ALL)
        .border_style(theme.border())
        .title(Span::styled(title, theme.header()));
    let inner = block.inner(area);
    frame.render_widget(block, area);
    if inner.width < 10 || inner.height < 3 {
        return;
    }
    let Some(centre) = app.map_centre() else {
        let text = match app.target {
            None => "no vehicle heard yet: nothing to put on the map".to_string(),
            Some(k) => format!("no position yet: waiting for {k}'s GLOBAL_POSITION_INT"),
        };
        let at = Rect {
            y: inner.y + inner.height / 2,
            height: 1,
            ..inner
        };
        frame.render_widget(
            Paragraph::new(Line::styled(text, theme.dim()).centered()),
            at,
        );
        return;
    };
    let footer = Rect {
        y: inner.y + inner.height - 1,
        height: 1,
        ..inner
    };
    let mut body = Rect {
        height: inner.height - 1,
        ..inner
    };
    if inner.width >= SIDE_FROM_WIDTH {
        let w = (inner.width / 4).clamp(SIDE_MIN, SIDE_MAX);
        let side = Rect {
            x: body.x + body.width - w,
            width: w,
            ..body
        };
        body.width -= w + 1;
        render_side(app, frame, side, theme);
    }
    render_footer(app, frame, footer, theme);
    // Metres: a braille dot is about as wide as tall, a cell twice as tall as wide.
    let aspect = body.width as f64 / (2.0 * body.height.max(1) as f64);
    let hh = match v.fit {
        Some((fw, fh)) => fh.max(fw / aspect),
        None => v.radius_m,
    };
    let view = View {
        plane: Plane::new(centre),
        up: app.map_up(),
        hw: hh * aspect,
        hh,
    };
    let canvas = Canvas::default()
        .x_bounds([-view.hw, view.hw])
        .y_bounds([-view.hh, view.hh])
        .paint(|ctx| paint(app, ctx, &view, body, theme));
    frame.render_widget(canvas, body);
}

/// Everything on the canvas, least important first (later labels cover earlier ones).
fn paint(app: &App, ctx: &mut Context, view: &View, area: Rect, theme: &Theme) {
    let cell_m = 2.0 * view.hw / area.width.max(1) as f64;
    // Fence.
    for shape in fence_shapes(&app.map_list(MissionType::Fence)) {
        match shape {
            FenceShape::Polygon { inclusion, points } => {
                let c = colour(theme, if inclusion { Color::Green } else { Color::Red });
                let pts: Vec<(f64, f64)> = points.iter().map(|p| view.xy(*p)).collect();
                for i in 0..pts.len() {
                    let (a, b) = (pts[i], pts[(i + 1) % pts.len()]);
                    ctx.draw(&CLine::new(a.0, a.1, b.0, b.1, c));
                }
            }
            FenceShape::Circle {
                inclusion,
                centre,
                radius,
            } => {
                let c = colour(theme, if inclusion { Color::Green } else { Color::Red });
                let (cx, cy) = view.xy(centre);
                const N: usize = 48;
                for k in 0..N {
                    let a0 = k as f64 / N as f64 * std::f64::consts::TAU;
                    let a1 = (k + 1) as f64 / N as f64 * std::f64::consts::TAU;
                    ctx.draw(&CLine::new(
                        cx + radius * a0.cos(),
                        cy + radius * a0.sin(),
                        cx + radius * a1.cos(),
                        cy + radius * a1.sin(),
                        c,
                    ));
                }
            }
        }
    }
    // Tracks.
    for veh in app.map_vehicles() {
        let pts: Vec<(f64, f64)> = app.track(veh.key).iter().map(|p| view.xy(*p)).collect();
        let c = if veh.target { Color::Cyan } else { Color::Blue };
        ctx.draw(&Points::new(&pts, colour(theme, c)));
    }
    // Mission legs.
    let path = app.map_path();
    let pts: Vec<(u16, (f64, f64))> = path.iter().map(|(s, p)| (*s, view.xy(*p))).collect();
    let leg = colour(theme, Color::Yellow);
    for w in pts.windows(2) {
        let (a, b) = (w[0].1, w[1].1);
        ctx.draw(&CLine::new(a.0, a.1, b.0, b.1, leg));
    }
    // Traffic courses.
    for a in app.air.traffic.aircraft() {
        let (x, y) = view.xy(a.pos);
        let (ve, vn) = a.velocity_en();
        if ve != 0.0 || vn != 0.0 {
            let (dx, dy) = geo::rotate(ve * COURSE_AHEAD_S, vn * COURSE_AHEAD_S, view.up);
            ctx.draw(&CLine::new(x, y, x + dx, y + dy, colour(theme, Color::Magenta)));
        }
    }
    ctx.layer();
    // Labels from here on. Half a cell left, so a symbol stands on its point.
    let at = |p: (f64, f64)| (p.0 - cell_m / 2.0, p.1);
    let current = app.map_current_seq();
    for (seq, p) in &pts {
        let style = if Some(*seq) == current {
            theme.selected().add_modifier(Modifier::BOLD)
        } else {
            Style::default().fg(colour(theme, Color::Yellow))
        };
        let (x, y) = at(*p);
        ctx.print(x, y, Span::styled(seq.to_string(), style));
    }
    for r in app.map_list(MissionType::Rally).iter().filter_map(item_pos) {
        let (x, y) = at(view.xy(r));
        ctx.print(x, y, Span::styled("R", Style::default().fg(colour(theme, Color::Green))));
    }
    if let Some(g) = app.guided_target() {
        let (x, y) = at(view.xy(g));
        ctx.print(x, y, Span::styled("G", theme.header()));
    }
    // Traffic.
    let wide = area.width >= 50;
    for a in app.air.traffic.aircraft() {
        let (x, y) = at(view.xy(a.pos));
        let near = app.air.near.contains(&a.icao);
        let style = if near {
            theme.alert()
        } else if a.is_stale(app.now) {
            theme.dim()
        } else {
            Style::default().fg(colour(theme, Color::Magenta))
        };
        let mut text = "✈".to_string();
        if wide {
            text.push_str(&a.name());
        }
        ctx.print(x, y, Span::styled(text, style));
    }
    // Vehicles and their homes, the target last (on top).
    let vehicles = app.map_vehicles();
    for veh in vehicles.iter().rev() {
        if let Some(h) = veh.home {
            let (x, y) = at(view.xy(h));
            ctx.print(x, y, Span::styled("H", theme.header()));
        }
    }
    for veh in vehicles.iter().rev() {
        let arrow = veh.heading.map_or('●', |h| geo::arrow(h - view.up));
        let (x, y) = at(view.xy(veh.pos));
        let (text, style) = if veh.target {
            (
                arrow.to_string(),
                theme.selected().add_modifier(Modifier::BOLD),
            )
        } else if veh.lost {
            (format!("{arrow}{}", veh.key.0), theme.dim())
        } else {
            (
                format!("{arrow}{}", veh.key.0),
                Style::default().fg(colour(theme, Color::Cyan)),
            )
        };
        ctx.print(x, y, Span::styled(text, style));
    }
    // The next waypoint off the map: pointed at from the edge.
    if let Some((seq, p)) = app.next_waypoint() {
        let xy = view.xy(p);
        if !view.inside(xy) {
            let k = (view.hw * 0.95 / xy.0.abs()).min(view.hh * 0.9 / xy.1.abs());
            let (x, y) = (xy.0 * k, xy.1 * k);
            let bearing = geo::wrap_360(xy.0.atan2(xy.1).to_degrees());
            let text = format!("{}{seq}", geo::arrow(bearing));
            let (x, y) = (x.clamp(-view.hw, view.hw - 3.0 * cell_m), y);
            ctx.print(x, y, Span::styled(text, theme.selected()));
        }
    }
    if let Some(c) = app.ui.map.cursor {
        let (x, y) = at(view.xy(c));
        ctx.print(x, y, Span::styled("X", theme.selected()));
    }
    // The compass at the top right, the scale bar at the bottom left.
    let north = geo::arrow(-view.up);
    ctx.print(
        view.hw - 3.0 * cell_m,
        view.hh,
        Span::styled(format!("N{north}"), theme.header()),
    );
    let (bar, cells) = scale(2.0 * view.hw, area.width);
    let text = format!(
        "├{}┤ {}",
        "─".repeat(cells.saturating_sub(2)),
        geo::distance_text(bar)
    );
    ctx.print(-view.hw, -view.hh, Span::styled(text, theme.header()));
}

/// A round length (1, 2 or 5 × 10ⁿ metres) near a fifth of the map's `width_m` and the cells it
/// takes of `cells` columns.
pub fn scale(width_m: f64, cells: u16) -> (f64, usize) {
    let target = (width_m / 5.0).max(1.0);
    let p = 10f64.powf(target.log10().floor());
    let m = [5.0, 2.0, 1.0]
        .into_iter()
        .map(|k| k * p)
        .find(|v| *v <= target)
        .unwrap_or(p);
    let n = (m / width_m * cells as f64).round() as usize;
    (m, n.max(2))
}

/// The footer: the cursor (and `g`), else the next waypoint from the target.
fn render_footer(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let text = match app.cursor_text() {
        Some(c) => format!(
            "{c}   {} go-to, {} hides",
            key(app, Action::MapGoto),
            key(app, Action::MapCursor)
        ),
        None => {
            let own = app.target_pos();
            let wp = app.next_waypoint().map(|(seq, p)| match own {
                Some(o) => format!(
                    "next wp {seq}: {} at {:03.0}°",
                    geo::distance_text(geo::distance_m(o, p)),
                    geo::bearing_deg(o, p)
                ),
                None => format!("next wp {seq}"),
            });
            let mut parts: Vec<String> = Vec::new();
            if own.is_none() {
                if let Some(k) = app.target {
                    parts.push(format!("{k}: no position yet"));
                }
            }
            parts.push(wp.unwrap_or_else(|| {
                if app.map_path().is_empty() {
                    "no mission".into()
                } else {
                    "no waypoint ahead".into()
                }
            }));
            if !app.air.traffic.is_empty() {
                parts.push(format!("traffic {}", app.air.traffic.len()));
            }
            parts.push(format!("{} cursor", key(app, Action::MapCursor)));
            parts.join("  ·  ")
        }
    };
    frame.render_widget(
        Paragraph::new(Line::styled(
            super::ellipsize(&text, area.width as usize),
            theme.dim(),
        )),
        area,
    );
}

/// The nearest traffic: two lines each.
fn render_side(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let w = area.width as usize;
    let traffic = app.traffic_from_target();
    let mut lines = vec![Line::styled(
        format!("Traffic {}", traffic.len()),
        theme.header(),
    )];
    if traffic.is_empty() {
        lines.push(Line::styled("no ADS-B traffic heard", theme.dim()));
    }
    let room = (area.height as usize).saturating_sub(1) / 2;
    for (a, r) in traffic.iter().take(room) {
        let near = app.air.near.contains(&a.icao);
        let style = if near {
            theme.alert()
        } else if a.is_stale(app.now) {
            theme.dim()
        } else {
            Style::default()
        };
        let course = a.heading.map_or(' ', geo::arrow);
        let height = match r.and_then(|r| r.height) {
            Some(h) => format!("{h:+.0} m"),
            None => a.alt_m.map_or("alt ?".into(), |x| format!("{x:.0} m AMSL")),
        };
        let first = format!("✈ {} {course} {height}", a.name());
        let age = a.age(app.now) / crate::clock::SECOND;
        let second = match r {
            Some(r) => format!(
                "  {} {:03.0}° {:+.0} m/s {age} s",
                geo::distance_text(r.distance),
                r.bearing,
                r.closing
            ),
            None => format!("  {age} s"),
        };
        lines.push(Line::styled(super::ellipsize(&first, w), style));
        lines.push(Line::styled(super::ellipsize(&second, w), style));
    }
    if traffic.len() > room && room > 0 {
        lines.truncate(1 + 2 * room.saturating_sub(1));
        lines.push(Line::styled(
            format!("… {} more", traffic.len() - (room - 1)),
            theme.dim(),
        ));
    }
    frame.render_widget(Paragraph::new(lines), area);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scale_bars_are_round() {
        assert_eq!(scale(1000.0, 100), (200.0, 20));
        assert_eq!(scale(740.0, 74), (100.0, 10));
        assert_eq!(scale(30_000.0, 60), (5000.0, 10));
    }
}
