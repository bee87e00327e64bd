//! The link manager: starts one task per link, hands on their reports, and carries messages to
//! the right links.

use tokio::sync::mpsc;

use super::transport::{spawn_link, LinkEvent, LinkHandle, LinkIdentity};
use super::{LinkId, LinkSpec};
use crate::dialect::MavMessage;

/// All running links.
pub struct LinkManager {
    handles: Vec<LinkHandle>,
    events: mpsc::UnboundedReceiver<(LinkId, LinkEvent)>,
}

impl LinkManager {
    /// Start a task for every spec; link ids are the specs' positions.
    pub fn start(specs: &[LinkSpec], me: LinkIdentity) -> Self {
        let (tx, events) = mpsc::unbounded_channel();
        let handles = specs
            .iter()
            .enumerate()
            .map(|(i, s)| spawn_link(i, s.clone(), me, tx.clone()))
            .collect();
        Self { handles, events }
    }

    /// The next report from any link.
    pub async fn next_event(&mut self) -> Option<(LinkId, LinkEvent)> {
        self.events.recv().await
    }

    /// Queue `msg` on one link, or on every link when `link` is `None`.
    pub fn send(&self, link: Option<LinkId>, msg: MavMessage) {
        match link {
            None => {
                for h in &self.handles {
                    h.send(msg.clone());
                }
            }
            Some(i) => {
                if let Some(h) = self.handles.get(i) {
                    h.send(msg);
                }
            }
        }
    }
}
