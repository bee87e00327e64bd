//! The driver: feeds link reports and keys into the core and carries out its effects, for every
//! front end.

use std::time::Duration;

use crate::app::{App, AppConfig, Effect, Event};
use crate::clock::{Clock, Micros, RealClock};
use crate::link::manager::LinkManager;
use crate::link::transport::{LinkEvent, LinkIdentity};
use crate::link::{LinkId, LinkSpec};

/// A link's report as a core event.
pub fn link_event(link: LinkId, ev: LinkEvent) -> Event {
    match ev {
        LinkEvent::Frames { frames, stats } => Event::Frames {
            link,
            frames,
            stats,
        },
        LinkEvent::State(state) => Event::LinkState { link, state },
    }
}

/// Carry out the `Send` effects on `mgr`; returns the others for the caller.
pub fn apply_sends(mgr: &LinkManager, fx: Vec<Effect>) -> Vec<Effect> {
    let mut rest = Vec::new();
    for e in fx {
        match e {
            Effect::Send { link, msg } => mgr.send(link, msg),
            other => rest.push(other),
        }
    }
    rest
}

/// Feed link reports and a 100 ms tick into `app` until `clock` reaches `deadline`, carrying
/// out the sends; ends with one more tick so time-based state is current.
pub async fn run_until(mgr: &mut LinkManager, app: &mut App, clock: &impl Clock, deadline: Micros) {
    let end = tokio::time::sleep(Duration::from_micros(deadline.saturating_sub(clock.now())));
    tokio::pin!(end);
    let mut tick = tokio::time::interval(Duration::from_millis(100));
    loop {
        let ev = tokio::select! {
            _ = &mut end => break,
            _ = tick.tick() => Event::Tick,
            ev = mgr.next_event() => match ev {
                Some((link, ev)) => link_event(link, ev),
                None => break,
            },
        };
        let fx = app.update(clock.now(), ev);
        apply_sends(mgr, fx);
    }
    let fx = app.update(clock.now(), Event::Tick);
    apply_sends(mgr, fx);
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
    run_until(
        &mut mgr,
        &mut app,
        &clock,
        clock.now() + duration.as_micros() as Micros,
    )
    .await;
    app
}
