//! The link manager: starts one task per link, turns their reports into core events, and carries
//! the core's `Send` effects to the right links.

use std::time::Duration;

use tokio::sync::mpsc;

use super::transport::{spawn_link, LinkEvent, LinkHandle, LinkIdentity};
use super::{LinkId, LinkSpec};
use crate::app::{App, AppConfig, Effect, Event};
use crate::clock::{Clock, RealClock};

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

    /// The next report from any link, as a core event.
    pub async fn next_event(&mut self) -> Option<Event> {
        let (link, ev) = self.events.recv().await?;
        Some(match ev {
            LinkEvent::Frames { frames, stats } => Event::Frames {
                link,
                frames,
                stats,
            },
            LinkEvent::State(state) => Event::LinkState { link, state },
        })
    }

    /// Carry out the `Send` effects; returns the others for the caller.
    pub fn apply(&self, fx: Vec<Effect>) -> Vec<Effect> {
        let mut rest = Vec::new();
        for e in fx {
            match e {
                Effect::Send { link: None, msg } => {
                    for h in &self.handles {
                        h.send(msg.clone());
                    }
                }
                Effect::Send { link: Some(i), msg } => {
                    if let Some(h) = self.handles.get(i) {
                        h.send(msg);
                    }
                }
                other => rest.push(other),
            }
        }
        rest
    }
}

/// Run the core on real links for `duration`, headless, and return its final state.
pub async fn run_for(specs: &[LinkSpec], mut cfg: AppConfig, duration: Duration) -> App {
    cfg.links = specs.iter().map(|s| s.to_string()).collect();
    cfg.epoch = chrono::Utc::now();
    let me = LinkIdentity {
        sysid: cfg.sysid,
        compid: cfg.compid,
    };
    let clock = RealClock::new();
    let mut app = App::new(cfg);
    let mut mgr = LinkManager::start(specs, me);
    let mut tick = tokio::time::interval(Duration::from_millis(100));
    let end = tokio::time::sleep(duration);
    tokio::pin!(end);
    loop {
        let ev = tokio::select! {
            _ = &mut end => break,
            _ = tick.tick() => Event::Tick,
            ev = mgr.next_event() => match ev {
                Some(ev) => ev,
                None => break,
            },
        };
        let fx = app.update(clock.now(), ev);
        mgr.apply(fx);
    }
    // One last tick so time-based state (lost vehicles, windows) is current.
    let fx = app.update(clock.now(), Event::Tick);
    mgr.apply(fx);
    app
}
