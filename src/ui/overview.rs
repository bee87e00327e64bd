//! The Overview screen (`1`): the target's flight telemetry on top, then the Vehicles, Links and
//! Messages panes stacked top to bottom. When the screen is too short, panes other than the
//! focused one collapse to a one-line title, and at the very smallest sizes are dropped; the
//! flight pane gives way first to its title line, then entirely.

use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::Paragraph;
use ratatui::Frame;

use super::{flight, links, messages, vehicles, Theme};
use crate::app::{App, Pane};

/// Draw the Overview in `body`.
pub fn render(app: &App, frame: &mut Frame, body: Rect, theme: &Theme) {
    let fh = flight_height(app, body.height);
    if fh > 0 {
        flight::render(app, frame, Rect { height: fh, ..body }, theme);
    }
    let body = Rect {
        y: body.y + fh,
        height: body.height - fh,
        ..body
    };
    for (pane, rect, full) in layout(app, body) {
        if full {
            match pane {
                Pane::Vehicles => vehicles::render(app, frame, rect, theme),
                Pane::Links => links::render(app, frame, rect, theme),
                Pane::Messages => messages::render(app, frame, rect, theme),
            }
        } else {
            collapsed(app, pane, frame, rect, theme);
        }
    }
}

/// Rows a pane would like, borders included: all its rows.
fn full_height(app: &App, pane: Pane) -> u16 {
    let rows = match pane {
        Pane::Vehicles => app.vehicles.len().max(1) + 1, // + header
        Pane::Links => {
            let sources: usize = app
                .links
                .iter()
                .filter(|l| l.expanded)
                .map(|l| l.sources.len())
                .sum();
            // The forwarding outputs, with their own header, below the links.
            let outputs = match app.outputs.list.len() {
                0 => 0,
                n => n + 1,
            };
            // + header, + the selected link's detail line.
            app.links.len().max(1) + sources + 2 + outputs
        }
        Pane::Messages => app.notices.len().max(1),
    };
    (rows.min(u16::MAX as usize / 2) as u16) + 2
}

/// Rows a list pane gets at first: all its rows, but at most ~40% of the body (the Messages
/// pane takes the rest, or what it leaves).
fn wanted_height(app: &App, pane: Pane, avail: u16) -> u16 {
    match pane {
        Pane::Messages => MIN_FULL,
        Pane::Vehicles => full_height(app, pane).min((avail * 2 / 5).max(MIN_FULL + 1)),
        // The links' share, and a line for the selected link's detail.
        Pane::Links => full_height(app, pane).min((avail * 2 / 5).max(MIN_FULL + 1) + 1),
    }
}

/// Smallest height a pane is drawn in full (borders and one row).
const MIN_FULL: u16 = 3;

/// Rows the other panes keep at least before the flight pane takes any: the focused pane in
/// full and the other two as title lines.
const MIN_REST: u16 = MIN_FULL + 2;

/// Rows of the flight pane in a body `avail` rows high: in full if the rest still fits, else its
/// title line, else none.
fn flight_height(app: &App, avail: u16) -> u16 {
    let want = flight::wanted_height(app);
    if avail >= want + MIN_REST {
        want
    } else if avail > MIN_REST {
        1
    } else {
        0
    }
}

/// Where each pane goes: (pane, rect, full) where `full == false` means a one-line title.
fn layout(app: &App, body: Rect) -> Vec<(Pane, Rect, bool)> {
    let avail = body.height;
    let focus = app.ui.focus;
    // (pane, height, full)
    let mut plan: Vec<(Pane, u16, bool)> = Pane::ALL
        .iter()
        .map(|&p| (p, wanted_height(app, p, avail).max(MIN_FULL), true))
        .collect();
    let total = |plan: &[(Pane, u16, bool)]| plan.iter().map(|x| x.1 as u32).sum::<u32>();
    // Unfocused panes give way, bottom first: first to a title line, then entirely.
    let victims: Vec<usize> = (0..plan.len())
        .rev()
        .filter(|&i| plan[i].0 != focus)
        .collect();
    for &i in &victims {
        if total(&plan) > avail as u32 {
            plan[i] = (plan[i].0, 1, false);
        }
    }
    for &i in &victims {
        if total(&plan) > avail as u32 {
            plan[i].1 = 0;
        }
    }
    // What the messages do not need goes to the lists short of their rows, in turn; whatever
    // is still left goes to messages if shown in full, else to the focused pane.
    let mut spare = (avail as u32).saturating_sub(total(&plan)) as u16;
    let msg_need = plan
        .iter()
        .find(|x| x.0 == Pane::Messages && x.2)
        .map_or(0, |x| full_height(app, Pane::Messages).saturating_sub(x.1));
    let mut give = spare.saturating_sub(msg_need);
    for x in plan.iter_mut().filter(|x| x.0 != Pane::Messages && x.2) {
        let more = full_height(app, x.0).saturating_sub(x.1).min(give);
        x.1 += more;
        give -= more;
        spare -= more;
    }
    let grow = plan
        .iter()
        .position(|x| x.0 == Pane::Messages && x.2)
        .or_else(|| plan.iter().position(|x| x.0 == focus));
    if let Some(i) = grow {
        plan[i].1 += spare;
    }
    let bottom = body.y + body.height;
    let mut y = body.y;
    let mut out = Vec::new();
    for (pane, h, full) in plan {
        let h = h.min(bottom.saturating_sub(y));
        if h == 0 {
            continue;
        }
        out.push((
            pane,
            Rect::new(body.x, y, body.width, h),
            full && h >= MIN_FULL,
        ));
        y += h;
    }
    out
}

/// A pane that did not fit: just its title on one line.
fn collapsed(app: &App, pane: Pane, frame: &mut Frame, rect: Rect, theme: &Theme) {
    let count = match pane {
        Pane::Vehicles => app.vehicles.len(),
        Pane::Links => app.links.len(),
        Pane::Messages => app.notices.len(),
    };
    let style = if app.ui.focus == pane {
        theme.focus_border()
    } else {
        theme.border()
    };
    let line = Line::from(vec![
        Span::styled(format!("─ {} ({count}) ", pane.title()), style),
        Span::styled("─".repeat(rect.width as usize), style),
    ]);
    frame.render_widget(Paragraph::new(line), rect);
}
