//! The message log: STATUSTEXT from vehicles and mavterm's own notices, newest last.

use std::collections::VecDeque;

use crate::clock::Micros;
use crate::proto::vehicles::VehicleKey;
use crate::wire::Severity;

/// How many messages are kept.
pub const MAX_NOTICES: usize = 1000;

/// One line in the message log.
#[derive(Debug, Clone, PartialEq)]
pub struct Notice {
    pub t: Micros,
    /// The time shown for it: the wall clock's, or during a replay the recording's.
    pub at: chrono::DateTime<chrono::Utc>,
    pub severity: Severity,
    /// The sender for STATUSTEXT; for mavterm's own notices the vehicle they are about, or
    /// `None`.
    pub source: Option<VehicleKey>,
    /// mavterm's own notice (not a vehicle's STATUSTEXT): shown as `mavterm`, whatever vehicle
    /// it is about.
    pub ours: bool,
    pub text: String,
}

/// Bounded log of notices.
#[derive(Debug, Clone, Default)]
pub struct Notices {
    items: VecDeque<Notice>,
    /// Total ever pushed (so views can tell something new arrived).
    pub total: u64,
}

impl Notices {
    pub fn push(&mut self, n: Notice) {
        if self.items.len() == MAX_NOTICES {
            self.items.pop_front();
        }
        self.items.push_back(n);
        self.total += 1;
    }
    pub fn iter(&self) -> impl DoubleEndedIterator<Item = &Notice> + ExactSizeIterator {
        self.items.iter()
    }
    pub fn len(&self) -> usize {
        self.items.len()
    }
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }
}
