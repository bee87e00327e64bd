//! The driver: one way to run the core, for every front end.
//!
//! [`step`] feeds events into [`App::update`] and carries out every [`Effect`] the same way,
//! whatever the clock: frames go to a [`Links`] implementation, files are written atomically
//! (and the outcome is told back to the core), new links are opened. Two runtimes use it:
//! [`virtual_time::VirtualRunner`] steps in-process links and the core on a virtual clock
//! (headless replay, tests, reports on `sim://`/`tlog:`), and [`real_time`] runs it on the wall
//! clock over real transports (the terminal, headless reports and replay on real links). Both
//! wake the core exactly at [`App::next_deadline`], a frame, or a key: never on a fixed tick.
//!
//! Every frame a link hears and every frame the core sends passes a tap on the way
//! ([`Links::heard`], [`Links::sending`]): the telemetry log ([`record`]) and forwarding to other
//! ground stations ([`forward`]) happen there, at the edge, and report to the core as events.

pub mod fetch;
pub mod forward;
pub mod logfile;
pub mod real_time;
pub mod record;
pub mod virtual_time;

use std::path::PathBuf;
use std::sync::Arc;

use crate::app::{App, Effect, Event};
use crate::clock::Micros;
use crate::link::replay::ReplayCmd;
use crate::link::source::{SourceFactory, TlogSource, VirtualSource};
use crate::link::transport::LinkEvent;
use crate::link::{Frame, LinkId, LinkSpec};
use crate::sim::{Sim, SimConfig};

/// Where the core's frames and new links go: virtual sources or real link tasks.
pub trait Links {
    /// Queue `frame` on `link`; false when it was dropped (full queue, no such link).
    fn send(&mut self, now: Micros, link: LinkId, frame: Vec<u8>) -> bool;
    /// Start link `link` (the next id) on `spec`; failures are reported as the link's state.
    fn open(&mut self, now: Micros, link: LinkId, spec: LinkSpec);
    /// Write a file atomically; the outcome comes back as [`Event::FileWritten`], now or later.
    fn write_file(&mut self, path: PathBuf, contents: Vec<u8>);
    /// Read a file; its bytes come back as [`Event::FileRead`], now or later.
    fn read_file(&mut self, path: PathBuf, purpose: crate::app::files::FileUse);
    /// Download parameter metadata ([`fetch::fetch_param_meta`]); the outcome comes back as
    /// [`Event::ParamMeta`], now or later.
    fn fetch_param_meta(&mut self, urls: Vec<String>, cache_path: PathBuf);
    /// Read cached parameter metadata ([`fetch::read_param_meta`]): [`Event::ParamMeta`], now or
    /// later (`MetaOrigin::Missing` when there is no such file).
    fn read_param_meta(&mut self, path: PathBuf);
    /// Pass a replay control to link `link`'s source; what changes comes back as
    /// [`Event::ReplayStatus`], now or later.
    fn replay_control(&mut self, now: Micros, link: LinkId, cmd: ReplayCmd);
    /// Frames `link` heard, before the core has them (recording, forwarding); `wall` is the
    /// time, µs since the Unix epoch.
    fn heard(&mut self, _wall: u64, _link: LinkId, _frames: &[Frame]) {}
    /// A frame the core is sending on `link` (recording).
    fn sending(&mut self, _wall: u64, _link: LinkId, _frame: &[u8]) {}
    /// After a step: hand on what the tap gathered, and say what the core should be told
    /// (the log's size, outputs' counters), as events.
    fn end_step(&mut self, _now: Micros) -> Vec<Event> {
        Vec::new()
    }
}

/// Wall-clock µs since the Unix epoch of core time `now` (`cfg.epoch + now`: on the virtual
/// clock too, so a headless run logs the same times every run).
pub fn wall_us(app: &App, now: Micros) -> u64 {
    (app.cfg.epoch.timestamp_micros().max(0) as u64).saturating_add(now)
}

/// A link's report as a core event.
pub fn link_event(link: LinkId, ev: LinkEvent) -> Event {
    match ev {
        LinkEvent::Frames { frames, stats } => Event::Frames {
            link,
            frames,
            stats,
        },
        LinkEvent::State(state) => Event::LinkState { link, state },
        LinkEvent::Dropped(frames) => Event::Dropped { link, frames },
        LinkEvent::Replay(status) => Event::ReplayStatus { link, status },
    }
}

/// Feed `ev` into `app` at `now` and carry out its effects on `links`. Frames a link could not
/// take are told back to the core as [`Event::Dropped`]; what the tap has to tell follows.
pub fn step(app: &mut App, links: &mut impl Links, now: Micros, ev: Event) {
    run_events(app, links, now, vec![ev]);
}

/// Feed the core only what the tap has to tell (after the edge did something on its own, e.g.
/// forwarded an output's frames).
pub fn step_edge(app: &mut App, links: &mut impl Links, now: Micros) {
    run_events(app, links, now, Vec::new());
}

fn run_events(app: &mut App, links: &mut impl Links, now: Micros, mut queue: Vec<Event>) {
    loop {
        while let Some(ev) = queue.pop() {
            let wall = wall_us(app, now);
            if let Event::Frames { link, frames, .. } = &ev {
                links.heard(wall, *link, frames);
            }
            let mut log_done = Vec::new();
            for e in app.update(now, ev) {
                match e {
                    Effect::Send { link, frame, .. } => {
                        links.sending(wall, link, &frame);
                        if !links.send(now, link, frame) {
                            queue.push(Event::Dropped { link, frames: 1 });
                        }
                    }
                    Effect::WriteFile { path, contents } => links.write_file(path, contents),
                    Effect::ReadFile { path, purpose } => links.read_file(path, purpose),
                    Effect::FetchParamMeta { urls, cache_path } => {
                        links.fetch_param_meta(urls, cache_path)
                    }
                    Effect::ReadParamMeta { path } => links.read_param_meta(path),
                    Effect::OpenLink { link, spec } => links.open(now, link, spec),
                    Effect::ReplayControl { link, cmd } => links.replay_control(now, link, cmd),
                    // In order, here: a write is small, and the rename must follow the writes.
                    Effect::LogFile { key, io } => {
                        if let Some(done) = logfile::carry_out(io) {
                            log_done.push(Event::LogFile { key, done });
                        }
                    }
                    Effect::Quit => {}
                }
            }
            queue.extend(log_done.into_iter().rev());
        }
        queue = links.end_step(now);
        queue.reverse(); // taken from the back: in the order given
        if queue.is_empty() {
            return;
        }
    }
}

/// Open the log for `target`, its new file named after the local time now; the error is the
/// event that tells the core why not.
pub fn open_recorder(target: &record::TlogTarget) -> Result<record::Recorder, Event> {
    record::Recorder::start(target, chrono::Local::now().naive_local()).map_err(Event::Recording)
}

pub use crate::fsio::{read_bounded, write_atomic};

/// Build the in-process source a spec names: the simulated vehicle or a tlog replay.
pub fn local_source(spec: &LinkSpec) -> Result<Box<dyn VirtualSource>, String> {
    match spec {
        LinkSpec::Tlog { path, speed } => {
            let src = TlogSource::open(path).map_err(|e| format!("{path}: {e}"))?;
            Ok(Box::new(src.with_speed(*speed)))
        }
        LinkSpec::Sim { query } => {
            let cfg = SimConfig::from_query(query).map_err(|e| format!("sim: {e}"))?;
            Ok(Box::new(SimSource::new(cfg)))
        }
        other => Err(format!("`{other}` is not an in-process link")),
    }
}

/// The factory link tasks use for `sim://` and `tlog:`.
pub fn local_sources() -> SourceFactory {
    Arc::new(local_source)
}

/// The simulated vehicle as a link source; its state file is written here, at the edge.
pub struct SimSource {
    pub sim: Sim,
}

impl SimSource {
    pub fn new(cfg: SimConfig) -> Self {
        Self {
            sim: crate::sim::open(cfg),
        }
    }
    fn flush_writes(&mut self) {
        crate::sim::save_pending(&mut self.sim);
    }
}

impl VirtualSource for SimSource {
    fn receive(&mut self, now: Micros, bytes: &[u8]) {
        self.sim.receive(now, bytes);
        self.flush_writes();
    }
    fn poll(&mut self, now: Micros) -> Vec<u8> {
        self.sim.poll(now)
    }
    fn next_deadline(&self) -> Micros {
        self.sim.next_deadline()
    }
    fn as_any(&self) -> &dyn std::any::Any {
        &self.sim
    }
}
