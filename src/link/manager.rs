//! The link manager: starts one task per link, turns their reports into core events, and carries
//! the core's `Send` effects to the right links.

use std::time::Duration;

use tokio::sync::mpsc;

use super::transport::{spawn_link, LinkEvent, LinkHandle, LinkIdentity};
use super::{LinkId, LinkSpec};
use crate::app::{App, AppConfig, Effect, Event};
use crate::clock::{Clock, Micros, RealClock};

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

    /// Feed link reports and a 100 ms tick into `app` until `clock` reaches `deadline`, carrying
    /// out the sends; ends with one more tick so time-based state is current.
    pub async fn run_until(&mut self, app: &mut App, clock: &impl Clock, deadline: Micros) {
        let end = tokio::time::sleep(Duration::from_micros(deadline.saturating_sub(clock.now())));
        tokio::pin!(end);
        let mut tick = tokio::time::interval(Duration::from_millis(100));
        loop {
            let ev = tokio::select! {
                _ = &mut end => break,
                _ = tick.tick() => Event::Tick,
                ev = self.next_event() => match ev {
                    Some(ev) => ev,
                    None => break,
                },
            };
            let fx = app.update(clock.now(), ev);
            self.apply(fx);
        }
        let fx = app.update(clock.now(), Event::Tick);
        self.apply(fx);
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
    mgr.run_until(
        &mut app,
        &clock,
        clock.now() + duration.as_micros() as Micros,
    )
    .await;
    app
}
