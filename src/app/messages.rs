//! The Messages pane's view in the core: which messages it shows (a lowest severity and a
//! vehicle, cycled by keys while the pane has the focus) and whether it follows the newest.
//!
//! Following is the default: the newest line is always in view. Scrolling back (up, page up,
//! home) pauses it: `UiState::msg_scroll` counts the shown lines below the view, and a new line
//! that passes the filter adds one, so the lines in view stay put while messages come. `end`, or
//! scrolling down to the bottom, follows again. Changing a filter follows again too.

use super::notices::Notice;
use super::{App, Pane};
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
}

impl Default for MsgFilter {
    fn default() -> Self {
        MsgFilter {
            max_severity: Severity::DEBUG,
            vehicle: VehicleFilter::All,
        }
    }
}

impl MsgFilter {
    /// True when `n` is shown, `target` being the target vehicle.
    pub fn shows(&self, n: &Notice, target: Option<VehicleKey>) -> bool {
        if n.severity > self.max_severity {
            return false;
        }
        let sys = n.source.map(|s| s.0);
        match self.vehicle {
            VehicleFilter::All => true,
            VehicleFilter::Target => sys.is_some() && sys == target.map(|t| t.0),
            VehicleFilter::System(s) => sys == Some(s),
        }
    }

    /// True when something is filtered out.
    pub fn is_active(&self) -> bool {
        *self != MsgFilter::default()
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
        if !f.is_active() {
            return self.notices.iter().collect();
        }
        self.notices
            .iter()
            .filter(|n| f.shows(n, self.target))
            .collect()
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
