//! The Messages pane's view in the core: which messages it shows (a lowest severity and a
//! vehicle, cycled by keys while the pane has the focus) and whether it follows the newest.
//!
//! Following is the default: the newest line is always in view. Scrolling back (up, page up,
//! home) pauses it: `UiState::msg_scroll` counts the shown lines below the view, and a new line
//! that passes the filter adds one, so the lines in view stay put while messages come. `end`, or
//! scrolling down to the bottom, follows again. Changing a filter follows again too.
//!
//! DEBUG lines are hidden at first (`MsgFilter::hide_debug`, the title counts them): a vehicle's
//! debug chatter (`BARO1_GND_PRESS changed to …`) must not push what matters out of view. The
//! severity keys step from there as before (all, INFO+, NOTICE+, WARN+, ERROR+); once they have
//! been used, `all` means every line, DEBUG included.
//!
//! While it follows and lines do not all fit, warnings and worse (severity ≤ 4) of the last
//! [`KEEP_FOR`] stay in view: older lower-severity lines give way to them ([`in_view`]); the
//! newest line is always shown.

use super::notices::Notice;
use super::{App, Pane};
use crate::clock::{Micros, SECOND};
use crate::keymap::Action;
use crate::proto::vehicles::VehicleKey;
use crate::wire::Severity;

/// The severity filter's steps, from showing everything to errors and worse: the least serious
/// severity shown.
pub const SEVERITY_STEPS: [Severity; 5] = [
    Severity::DEBUG,
    Severity::INFO,
    Severity::NOTICE,
    Severity::WARNING,
    Severity::ERROR,
];

/// How long a warning or worse stays in view while newer, less severe lines come.
pub const KEEP_FOR: Micros = 60 * SECOND;

/// Whose messages are shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum VehicleFilter {
    /// Everything, mavterm's own notices included.
    #[default]
    All,
    /// The target's system (every component of it), whichever vehicle is the target.
    Target,
    /// One system id (every component of it).
    System(u8),
}

/// What the Messages pane shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MsgFilter {
    /// The least serious severity shown (DEBUG = all).
    pub max_severity: Severity,
    pub vehicle: VehicleFilter,
    /// DEBUG lines hidden although `max_severity` shows all: the default, until the severity
    /// keys are used.
    pub hide_debug: bool,
}

impl Default for MsgFilter {
    fn default() -> Self {
        MsgFilter {
            max_severity: Severity::DEBUG,
            vehicle: VehicleFilter::All,
            hide_debug: true,
        }
    }
}

impl MsgFilter {
    /// True when `n` is shown, `target` being the target vehicle.
    pub fn shows(&self, n: &Notice, target: Option<VehicleKey>) -> bool {
        if n.severity > self.max_severity || (self.hide_debug && n.severity >= Severity::DEBUG) {
            return false;
        }
        self.shows_vehicle(n, target)
    }

    /// True when the vehicle filter lets `n` through (whatever its severity).
    pub fn shows_vehicle(&self, n: &Notice, target: Option<VehicleKey>) -> bool {
        let sys = n.source.map(|s| s.0);
        match self.vehicle {
            VehicleFilter::All => true,
            VehicleFilter::Target => sys.is_some() && sys == target.map(|t| t.0),
            VehicleFilter::System(s) => sys == Some(s),
        }
    }

    /// True when something is filtered out by the operator's choice (the default DEBUG floor
    /// is not a choice: the title counts what it hides instead).
    pub fn is_active(&self) -> bool {
        self.max_severity < Severity::DEBUG || self.vehicle != VehicleFilter::All
    }

    /// `WARN+ sys 1`, `target 1`: the active filters, for the pane's title; empty for none.
    pub fn label(&self, target: Option<VehicleKey>) -> String {
        let mut parts = Vec::new();
        if self.max_severity < Severity::DEBUG {
            parts.push(format!("{}+", self.max_severity.name()));
        }
        match self.vehicle {
            VehicleFilter::All => {}
            VehicleFilter::Target => parts.push(match target {
                Some(t) => format!("target {}", t.0),
                None => "target none".into(),
            }),
            VehicleFilter::System(s) => parts.push(format!("sys {s}")),
        }
        parts.join(" ")
    }
}

impl App {
    /// The messages the Messages pane shows, oldest first.
    pub fn shown_notices(&self) -> Vec<&Notice> {
        let f = self.ui.msg_filter;
        if !f.is_active() && !f.hide_debug {
            return self.notices.iter().collect();
        }
        self.notices
            .iter()
            .filter(|n| f.shows(n, self.target))
            .collect()
    }

    /// DEBUG lines the default floor hides (those the vehicle filter would show), for the title;
    /// 0 once the severity keys have been used or a stricter severity is chosen.
    pub fn debug_hidden(&self) -> usize {
        let f = self.ui.msg_filter;
        if !f.hide_debug || f.max_severity < Severity::DEBUG {
            return 0;
        }
        self.notices
            .iter()
            .filter(|n| n.severity >= Severity::DEBUG && f.shows_vehicle(n, self.target))
            .count()
    }

    /// A vehicle's STATUSTEXT, from `source`, for the message log.
    pub(super) fn vehicle_notice(&mut self, severity: Severity, source: VehicleKey, text: String) {
        let n = Notice {
            t: self.now,
            at: self.shown_instant(),
            severity,
            source: Some(source),
            ours: false,
            text,
        };
        self.on_new_notice(&n);
        self.notices.push(n);
        self.dirty = true;
    }

    /// A new message: while the pane is paused, the lines in view stay in view.
    pub(super) fn on_new_notice(&mut self, n: &Notice) {
        if self.ui.msg_scroll > 0 && self.ui.msg_filter.shows(n, self.target) {
            self.ui.msg_scroll += 1;
        }
    }

    /// System ids the vehicle filter steps through: every one heard or named in a message.
    fn message_systems(&self) -> Vec<u8> {
        let mut ids: Vec<u8> = self
            .vehicles
            .iter()
            .map(|v| v.sysid)
            .chain(self.notices.iter().filter_map(|n| n.source.map(|s| s.0)))
            .collect();
        ids.sort_unstable();
        ids.dedup();
        ids
    }

    /// The Messages pane's filter keys; they work while the pane has the focus (else the key
    /// only says so).
    pub(super) fn on_message_filter(&mut self, action: Action) {
        if self.ui.focus != Pane::Messages {
            self.ui.message = Some((
                Severity::INFO,
                "message filters: focus the Messages pane first".into(),
            ));
            return;
        }
        let f = &mut self.ui.msg_filter;
        match action {
            Action::MsgSeverity | Action::MsgSeverityBack => {
                let n = SEVERITY_STEPS.len();
                let i = SEVERITY_STEPS
                    .iter()
                    .position(|s| *s == f.max_severity)
                    .unwrap_or(0);
                let i = if action == Action::MsgSeverity {
                    (i + 1) % n
                } else {
                    (i + n - 1) % n
                };
                f.max_severity = SEVERITY_STEPS[i];
                // The operator chooses now: `all` is every line from here on.
                f.hide_debug = false;
            }
            _ => {
                // All, the target, then each system id in turn.
                let mut steps = vec![VehicleFilter::All, VehicleFilter::Target];
                let systems = self.message_systems();
                steps.extend(systems.into_iter().map(VehicleFilter::System));
                let f = &mut self.ui.msg_filter;
                let n = steps.len();
                let i = steps.iter().position(|v| *v == f.vehicle).unwrap_or(0);
                let i = if action == Action::MsgVehicle {
                    (i + 1) % n
                } else {
                    (i + n - 1) % n
                };
                f.vehicle = steps[i];
            }
        }
        // What is shown changed: follow the newest again.
        self.ui.msg_scroll = 0;
    }

    /// Scroll the Messages pane: `step` lines down (negative = back in time). At the bottom it
    /// follows the newest again.
    pub(super) fn scroll_messages(&mut self, step: isize) {
        let max = self.shown_notices().len().saturating_sub(1);
        self.ui.msg_scroll = (self.ui.msg_scroll as isize - step).clamp(0, max as isize) as usize;
    }
}

/// Which of `shown` (oldest first) a following pane of `rows` rows shows at `now`, oldest
/// first: all of them when they fit; else the newest line, then the warnings and worse
/// (severity ≤ 4) younger than [`KEEP_FOR`], newest first, then the other lines newest first.
pub fn in_view<'a>(shown: &[&'a Notice], rows: usize, now: Micros) -> Vec<&'a Notice> {
    if shown.len() <= rows {
        return shown.to_vec();
    }
    if rows == 0 {
        return Vec::new();
    }
    let kept = |n: &Notice| n.severity <= Severity::WARNING && now.saturating_sub(n.t) < KEEP_FOR;
    let last = shown.len() - 1;
    let mut take = vec![false; shown.len()];
    take[last] = true;
    let mut left = rows - 1;
    for pass in [true, false] {
        for i in (0..last).rev() {
            if left == 0 {
                break;
            }
            if !take[i] && kept(shown[i]) == pass {
                take[i] = true;
                left -= 1;
            }
        }
    }
    shown
        .iter()
        .zip(take)
        .filter(|(_, t)| *t)
        .map(|(n, _)| *n)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn n(t: Micros, severity: u8) -> Notice {
        Notice {
            t,
            at: chrono::DateTime::UNIX_EPOCH,
            severity: Severity(severity),
            source: Some(VehicleKey(1, 1)),
            ours: false,
            text: format!("{severity}@{t}"),
        }
    }

    #[test]
    fn recent_warnings_stay_in_view_and_old_ones_give_way() {
        let now = 100 * SECOND;
        // An old error (70 s ago), a warning 30 s ago, then five INFO lines.
        let mut all = vec![n(30 * SECOND, 3), n(70 * SECOND, 4)];
        all.extend((0..5).map(|i| n(80 * SECOND + i, 6)));
        let shown: Vec<&Notice> = all.iter().collect();
        let view = in_view(&shown, 3, now);
        let got: Vec<(Micros, u8)> = view.iter().map(|n| (n.t, n.severity.0)).collect();
        assert_eq!(
            got,
            vec![(70 * SECOND, 4), (80 * SECOND + 3, 6), (80 * SECOND + 4, 6)]
        );
        // Everything fits: everything, in order.
        assert_eq!(in_view(&shown, 10, now).len(), 7);
        assert!(in_view(&shown, 0, now).is_empty());
        // One row: the newest line.
        assert_eq!(in_view(&shown, 1, now)[0].t, 80 * SECOND + 4);
    }
}
