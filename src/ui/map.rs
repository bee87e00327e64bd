//! The Map screen (`9`): a local tangent plane around the view's centre (the target, unless
//! panned or fitted), drawn in braille dots with symbols on top: every vehicle's arrow (its
//! heading) and track, homes `H`, the target's mission (numbered waypoints, legs, the current one
//! marked), geofence (inclusion and exclusion polygons and circles), rally points `R`, the last
//! go-to's target `G`, and ADS-B traffic `✈` (stale ones dimmed) with its course for the next
//! minute. A scale bar in metres at the bottom left, a compass rose (N, E, S and W, turned with
//! the map when the heading is up) at the top right; the nearest traffic listed beside the map
//! when there is room; the cursor's place (or the next waypoint) in the footer.
//!
//! Small terminals keep the vehicle and the next waypoint: the side list goes first, and a
//! waypoint off the map is pointed at from its edge. Without colour ([`Theme::PLAIN`]) every
//! layer is told apart by its symbol or line pattern (legs solid, tracks a dot a second, the
//! inclusion fence dashed, the exclusion fence dotted with `×` marks, traffic's course sparsely
//! dotted); the target and the current waypoint by reverse video.

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
    // Metres: a braille dot is about as wide as tall, a cell twice as tall as wide. The pane's
    // shape is kept for the keys that leave a fitted view (the same scale goes on).
    let aspect = body.width as f64 / (2.0 * body.height.max(1) as f64);
    v.aspect.set(Some(aspect));
    let hh = v.half_height(aspect);
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
    render_rose(frame, body, view.up, theme);
}

/// Line patterns, in dots along the line: (on, off). Each line layer has its own, so the layers
/// are told apart without colour: mission legs solid, tracks a dot a second, the inclusion fence
/// dashed, the exclusion fence dotted (and `×` at its corners and centres), traffic's course
/// sparsely dotted.
pub const INCLUSION_DASH: (usize, usize) = (4, 2);
pub const EXCLUSION_DASH: (usize, usize) = (1, 1);
pub const COURSE_DASH: (usize, usize) = (1, 2);
/// The exclusion fence's mark at its corners and circles' centres.
pub const EXCLUSION_MARK: &str = "×";

/// The fractions (from, to) of the way from `a` to `b` that lie within the view (Liang–Barsky).
fn clip(view: &View, a: (f64, f64), b: (f64, f64)) -> Option<(f64, f64)> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, a.0 + view.hw),
        (dx, view.hw - a.0),
        (-dy, a.1 + view.hh),
        (dy, view.hh - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    (t0 <= t1).then_some((t0, t1))
}

/// A patterned line through `pts` (closed back to the first when `closed`): a point every `dot`
/// metres where `pattern` is on, the pattern running on from one segment to the next. Only the
/// parts within the view are sampled.
fn patterned(
    view: &View,
    dot: f64,
    pts: &[(f64, f64)],
    closed: bool,
    (on, off): (usize, usize),
) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    if pts.len() < 2 || !dot.is_finite() || dot <= 0.0 {
        return out;
    }
    let period = (on + off).max(1) as i64;
    let n = if closed { pts.len() } else { pts.len() - 1 };
    // Metres along the line at the segment's start.
    let mut along = 0.0;
    for i in 0..n {
        let (a, b) = (pts[i], pts[(i + 1) % pts.len()]);
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let len = dx.hypot(dy);
        if !len.is_finite() {
            return out;
        }
        if len > 0.0 {
            if let Some((t0, t1)) = clip(view, a, b) {
                let k0 = ((along + t0 * len) / dot).ceil() as i64;
                let end = (along + t1 * len) / dot;
                // A corner is the next segment's start: not drawn twice.
                let shared = t1 >= 1.0 && (closed || i + 1 < n);
                let k1 = if shared { end.ceil() - 1.0 } else { end.floor() } as i64;
                for k in k0..=k1 {
                    if k.rem_euclid(period) < on as i64 {
                        let t = (k as f64 * dot - along) / len;
                        out.push((a.0 + dx * t, a.1 + dy * t));
                    }
                }
            }
        }
        along += len;
    }
    out
}

/// Where to print a label so that it lands in the cell holding the dot of `p` (the canvas puts
/// labels on a grid of its own, one cell coarser than its dots'). A point off the map stays off.
fn label_at(view: &View, area: Rect, p: (f64, f64)) -> (f64, f64) {
    if area.width < 2 || area.height < 2 || !view.inside(p) {
        return p;
    }
    let (w, h) = (area.width as f64, area.height as f64);
    // The dot as the canvas rounds it (a hair towards the far side, so that a point on the
    // centre line is not split by rounding noise), then its cell.
    let dot = |frac: f64, dots: f64| (frac * (dots - 1.0) + 1e-6).round();
    let col = (dot((p.0 + view.hw) / (2.0 * view.hw), 2.0 * w) / 2.0).floor();
    let row = (dot((view.hh - p.1) / (2.0 * view.hh), 4.0 * h) / 4.0).floor();
    let x = (-view.hw + (col + 0.5) * 2.0 * view.hw / (w - 1.0)).min(view.hw);
    let y = (view.hh - (row + 0.5) * 2.0 * view.hh / (h - 1.0)).max(-view.hh);
    (x, y)
}

/// Everything on the canvas, least important first (later labels cover earlier ones).
fn paint(app: &App, ctx: &mut Context, view: &View, area: Rect, theme: &Theme) {
    let cell_m = 2.0 * view.hw / area.width.max(1) as f64;
    // A braille dot: half a cell wide, a quarter tall (the same metres both ways).
    let dot = cell_m / 2.0;
    // Fence: inclusion dashed, exclusion dotted with its corners and centres marked.
    let mut marks: Vec<(f64, f64)> = Vec::new();
    for shape in fence_shapes(&app.map_list(MissionType::Fence)) {
        let (inclusion, pts) = match shape {
            FenceShape::Polygon { inclusion, points } => {
                let pts: Vec<(f64, f64)> = points.iter().map(|p| view.xy(*p)).collect();
                if !inclusion {
                    marks.extend(&pts);
                }
                (inclusion, pts)
            }
            FenceShape::Circle {
                inclusion,
                centre,
                radius,
            } => {
                let (cx, cy) = view.xy(centre);
                if !inclusion {
                    marks.push((cx, cy));
                }
                // About a chord every two dots of its edge, within reason.
                let n = ((std::f64::consts::TAU * radius / dot / 2.0) as usize).clamp(24, 720);
                let pts = (0..n)
                    .map(|k| {
                        let a = k as f64 / n as f64 * std::f64::consts::TAU;
                        (cx + radius * a.cos(), cy + radius * a.sin())
                    })
                    .collect();
                (inclusion, pts)
            }
        };
        let (c, pattern) = if inclusion {
            (Color::Green, INCLUSION_DASH)
        } else {
            (Color::Red, EXCLUSION_DASH)
        };
        let dots = patterned(view, dot, &pts, true, pattern);
        ctx.draw(&Points::new(&dots, colour(theme, c)));
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
            let dots = patterned(view, dot, &[(x, y), (x + dx, y + dy)], false, COURSE_DASH);
            ctx.draw(&Points::new(&dots, colour(theme, Color::Magenta)));
        }
    }
    ctx.layer();
    // Labels from here on, each in the cell of its point's dot.
    let at = |p: (f64, f64)| label_at(view, area, p);
    for p in marks {
        let (x, y) = at(p);
        ctx.print(
            x,
            y,
            Span::styled(EXCLUSION_MARK, Style::default().fg(colour(theme, Color::Red))),
        );
    }
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
        let mut text = TRAFFIC_MARK.to_string();
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
    // The next waypoint off the map: pointed at from the edge (below the compass rose).
    if let Some((seq, p)) = app.next_waypoint() {
        let xy = view.xy(p);
        if !view.inside(xy) {
            let k = (view.hw * 0.95 / xy.0.abs()).min(view.hh * 0.9 / xy.1.abs());
            let (x, mut y) = (xy.0 * k, xy.1 * k);
            let bearing = geo::wrap_360(xy.0.atan2(xy.1).to_degrees());
            let text = format!("{}{seq}", geo::arrow(bearing));
            let x = x.clamp(-view.hw, view.hw - 3.0 * cell_m);
            let cell_h = 2.0 * view.hh / area.height.max(1) as f64;
            let (rw, rh) = ROSE;
            if x > view.hw - (rw as f64 + 3.0) * cell_m && y > view.hh - rh as f64 * cell_h {
                y = view.hh - (rh as f64 + 0.5) * cell_h;
            }
            ctx.print(x, y, Span::styled(text, theme.selected()));
        }
    }
    if let Some(c) = app.ui.map.cursor {
        let (x, y) = at(view.xy(c));
        ctx.print(x, y, Span::styled("X", theme.selected()));
    }
    // The scale bar at the bottom left (the compass rose is drawn over the top right).
    let (bar, cells) = scale(2.0 * view.hw, area.width);
    let text = format!(
        "├{}┤ {}",
        "─".repeat(cells.saturating_sub(2)),
        geo::distance_text(bar)
    );
    ctx.print(-view.hw, -view.hh, Span::styled(text, theme.header()));
}

/// The traffic's symbol on the map (and in the list beside it).
pub const TRAFFIC_MARK: &str = "✈";

/// The compass rose's size, cells: N, E, S and W around a dot.
pub const ROSE: (u16, u16) = (5, 3);

/// The cells (column, row) of the compass rose's N, E, S and W within its box, for a map with
/// bearing `up` up: each letter where its bearing points on the screen, to the nearest eighth.
pub fn rose_letters(up: f64) -> [(char, u16, u16); 4] {
    // Clockwise from the top: the box's middle top, its corners and the middles of its sides.
    const AT: [(u16, u16); 8] = [(2, 0), (4, 0), (4, 1), (4, 2), (2, 2), (0, 2), (0, 1), (0, 0)];
    let mut out = [(' ', 0, 0); 4];
    for (i, c) in ['N', 'E', 'S', 'W'].into_iter().enumerate() {
        let on_screen = geo::wrap_360(i as f64 * 90.0 - up);
        let k = (on_screen / 45.0 + 0.5).floor() as usize % 8;
        out[i] = (c, AT[k].0, AT[k].1);
    }
    out
}

/// The compass rose at the top right of the map: N, E, S and W turned with the map (`up` is the
/// bearing up); on a map too small for it, `N` and an arrow.
fn render_rose(frame: &mut Frame, body: Rect, up: f64, theme: &Theme) {
    let (rw, rh) = ROSE;
    let buf = frame.buffer_mut();
    if body.width < 4 * rw || body.height < 2 * rh {
        if body.width >= 3 && body.height >= 1 {
            let text = format!("N{}", geo::arrow(-up));
            buf.set_string(body.right() - 3, body.y, text, theme.header());
        }
        return;
    }
    let (x0, y0) = (body.right() - rw, body.y);
    for y in y0..y0 + rh {
        for x in x0..x0 + rw {
            buf[(x, y)].reset();
        }
    }
    buf[(x0 + rw / 2, y0 + rh / 2)].set_char('·');
    for (c, dx, dy) in rose_letters(up) {
        let style = if c == 'N' {
            theme.header()
        } else {
            Style::default()
        };
        buf[(x0 + dx, y0 + dy)].set_char(c).set_style(style);
    }
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
        let first = format!("{TRAFFIC_MARK} {} {course} {height}", a.name());
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

    fn view(hw: f64, hh: f64) -> View {
        View {
            plane: Plane::new(LatLon::new(0.0, 0.0)),
            up: 0.0,
            hw,
            hh,
        }
    }

    #[test]
    fn the_rose_turns_with_the_map() {
        let at = |up: f64| rose_letters(up).map(|(c, x, y)| (c, x, y));
        assert_eq!(
            at(0.0),
            [('N', 2, 0), ('E', 4, 1), ('S', 2, 2), ('W', 0, 1)]
        );
        // Heading east: north on the left.
        assert_eq!(
            at(90.0),
            [('N', 0, 1), ('E', 2, 0), ('S', 4, 1), ('W', 2, 2)]
        );
        // Heading north-east: north up left.
        assert_eq!(
            at(45.0),
            [('N', 0, 0), ('E', 4, 0), ('S', 4, 2), ('W', 0, 2)]
        );
        // To the nearest eighth, never two letters in one cell.
        for up in (0..360).map(|d| d as f64 + 0.5) {
            let cells: std::collections::BTreeSet<(u16, u16)> =
                at(up).iter().map(|(_, x, y)| (*x, *y)).collect();
            assert_eq!(cells.len(), 4, "{up}");
        }
    }

    #[test]
    fn patterns_run_on_along_the_line_and_stop_at_the_edge() {
        let v = view(100.0, 50.0);
        // Ten dots of 1 m, every other one: 0, 2, ... 10.
        let pts = patterned(&v, 1.0, &[(0.0, 0.0), (10.0, 0.0)], false, (1, 1));
        let xs: Vec<f64> = pts.iter().map(|p| p.0).collect();
        assert_eq!(xs, [0.0, 2.0, 4.0, 6.0, 8.0, 10.0]);
        // The pattern goes on round a corner: 3 m then 3 m up, (2, 1) dashes.
        let pts = patterned(&v, 1.0, &[(0.0, 0.0), (3.0, 0.0), (3.0, 3.0)], false, (2, 1));
        assert_eq!(pts, [(0.0, 0.0), (1.0, 0.0), (3.0, 0.0), (3.0, 1.0), (3.0, 3.0)]);
        // Only what is on the map: a line from far outside starts at the edge.
        let pts = patterned(&v, 1.0, &[(-1e6, 0.0), (0.0, 0.0)], false, (1, 0));
        assert_eq!(pts.len(), 101);
        assert!(pts.iter().all(|p| v.inside(*p)));
        assert!(patterned(&v, 1.0, &[(-1e6, 60.0), (1e6, 60.0)], false, (1, 0)).is_empty());
        // Closed: round to the first point, each corner once (16 m, a dot a metre).
        let sq = [(0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0)];
        let pts = patterned(&v, 1.0, &sq, true, (1, 0));
        assert_eq!(pts.len(), 16);
        assert_eq!(pts[15], (0.0, 1.0));
    }

    #[test]
    fn scale_bars_are_round() {
        assert_eq!(scale(1000.0, 100), (200.0, 20));
        assert_eq!(scale(740.0, 74), (100.0, 10));
        assert_eq!(scale(30_000.0, 60), (5000.0, 10));
    }
}
