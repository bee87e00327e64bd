//! Running the core on a virtual clock with in-process links (`sim://`, `tlog:`): no TTY, no
//! sockets, no wall clock, so the same input gives the same frames and the same screens, and a
//! minute of flight replays in milliseconds.

use chrono::{DateTime, TimeZone, Utc};

use crate::app::{App, AppConfig, Effect, Event};
use crate::clock::Micros;
use crate::keymap::Key;
use crate::link::tlog::{read_tlog, TlogRecord};
use crate::link::{FrameParser, LinkSpec, ParserStats};
use crate::sim::{Sim, SimConfig};
use crate::wire::tx::LinkTx;

/// How often the core gets a `Tick` in virtual time.
pub const TICK: Micros = 100_000;

/// The wall-clock time shown for virtual time zero when nothing better is known.
pub fn virtual_epoch() -> DateTime<Utc> {
    Utc.with_ymd_and_hms(2026, 1, 1, 12, 0, 0)
        .single()
        .expect("valid date")
}

/// What a replay script drives: the core with its links, on a virtual or a real clock.
pub trait Driver {
    /// Run links and core up to time `t` (µs since start).
    fn advance_to(&mut self, t: Micros);
    /// A key pressed now.
    fn key(&mut self, key: Key);
    fn now(&self) -> Micros;
    fn quit_requested(&self) -> bool;
    fn app(&self) -> &App;
}

impl Driver for VirtualRunner {
    fn advance_to(&mut self, t: Micros) {
        VirtualRunner::advance_to(self, t)
    }
    fn key(&mut self, key: Key) {
        VirtualRunner::key(self, key)
    }
    fn now(&self) -> Micros {
        self.now
    }
    fn quit_requested(&self) -> bool {
        self.app.quit
    }
    fn app(&self) -> &App {
        &self.app
    }
}

/// Something that produces and consumes link bytes on a virtual clock.
pub trait VirtualSource {
    /// Bytes sent to the source at `now`.
    fn receive(&mut self, now: Micros, bytes: &[u8]);
    /// Bytes the source emits that are due by `now`.
    fn poll(&mut self, now: Micros) -> Vec<u8>;
    /// When the source next has something to emit (`Micros::MAX` for never).
    fn next_deadline(&self) -> Micros;
    /// For tests that look at a source's own truth (e.g. the sim's impairment counts).
    fn as_any(&self) -> &dyn std::any::Any;
}

/// Replays a tlog on the virtual clock, record times relative to the first record.
#[derive(Debug)]
pub struct TlogSource {
    records: Vec<TlogRecord>,
    next: usize,
    t0: u64,
}

impl TlogSource {
    pub fn new(records: Vec<TlogRecord>) -> Self {
        let t0 = records.first().map(|r| r.time_us).unwrap_or(0);
        Self {
            records,
            next: 0,
            t0,
        }
    }
    /// Wall-clock time of the first record.
    pub fn start_time(&self) -> Option<DateTime<Utc>> {
        DateTime::<Utc>::from_timestamp_micros(self.t0 as i64).filter(|_| !self.records.is_empty())
    }
}

impl VirtualSource for TlogSource {
    fn receive(&mut self, _now: Micros, _bytes: &[u8]) {}
    fn poll(&mut self, now: Micros) -> Vec<u8> {
        let mut out = Vec::new();
        while let Some(r) = self.records.get(self.next) {
            if r.time_us.saturating_sub(self.t0) > now {
                break;
            }
            out.extend_from_slice(&r.frame);
            self.next += 1;
        }
        out
    }
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
    fn next_deadline(&self) -> Micros {
        self.records
            .get(self.next)
            .map(|r| r.time_us.saturating_sub(self.t0))
            .unwrap_or(Micros::MAX)
    }
}

impl VirtualSource for Sim {
    fn receive(&mut self, now: Micros, bytes: &[u8]) {
        Sim::receive(self, now, bytes)
    }
    fn poll(&mut self, now: Micros) -> Vec<u8> {
        Sim::poll(self, now)
    }
    fn next_deadline(&self) -> Micros {
        Sim::next_deadline(self)
    }
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

/// Why a virtual run could not start.
#[derive(Debug, thiserror::Error)]
pub enum RunnerError {
    #[error("link `{0}` cannot run on a virtual clock (only sim:// and tlog: can)")]
    NotVirtual(String),
    #[error("{path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}: {source}")]
    Tlog {
        path: String,
        source: crate::link::tlog::TlogError,
    },
    #[error("{0}")]
    Sim(String),
}

struct VLink {
    src: Box<dyn VirtualSource>,
    parser: FrameParser,
    reported: ParserStats,
    tx: LinkTx,
}

/// The core plus its virtual links, stepped by [`VirtualRunner::advance_to`].
pub struct VirtualRunner {
    pub app: App,
    links: Vec<VLink>,
    now: Micros,
    next_tick: Micros,
}

/// True when every spec can run on a virtual clock.
pub fn all_virtual(specs: &[LinkSpec]) -> bool {
    specs
        .iter()
        .all(|s| matches!(s, LinkSpec::Sim { .. } | LinkSpec::Tlog { .. }))
}

impl VirtualRunner {
    /// A runner over ready-made sources; `cfg.links` names them in order.
    pub fn new(cfg: AppConfig, sources: Vec<Box<dyn VirtualSource>>) -> Self {
        let (sysid, compid) = (cfg.sysid, cfg.compid);
        let links = sources
            .into_iter()
            .map(|src| VLink {
                src,
                parser: FrameParser::new(),
                reported: ParserStats::default(),
                tx: LinkTx::new(sysid, compid),
            })
            .collect();
        let mut r = Self {
            app: App::new(cfg),
            links,
            now: 0,
            next_tick: 0,
        };
        for i in 0..r.links.len() {
            let fx = r.app.update(
                0,
                Event::LinkState {
                    link: i,
                    state: crate::app::links::LinkState::Up,
                },
            );
            r.apply(fx);
        }
        r
    }

    /// Build sources from link specs. The epoch shown is the first tlog's start, else fixed.
    pub fn from_specs(specs: &[LinkSpec], mut cfg: AppConfig) -> Result<Self, RunnerError> {
        let mut sources: Vec<Box<dyn VirtualSource>> = Vec::new();
        let mut epoch = None;
        for spec in specs {
            match spec {
                LinkSpec::Tlog { path } => {
                    let bytes = std::fs::read(path).map_err(|source| RunnerError::Io {
                        path: path.clone(),
                        source,
                    })?;
                    let recs = read_tlog(&bytes).map_err(|source| RunnerError::Tlog {
                        path: path.clone(),
                        source,
                    })?;
                    let src = TlogSource::new(recs);
                    epoch = epoch.or(src.start_time());
                    sources.push(Box::new(src));
                }
                LinkSpec::Sim { query } => {
                    let cfg = SimConfig::from_query(query)
                        .map_err(|e| RunnerError::Sim(e.to_string()))?;
                    sources.push(Box::new(Sim::new(cfg)));
                }
                other => return Err(RunnerError::NotVirtual(other.to_string())),
            }
        }
        cfg.links = specs.iter().map(|s| s.to_string()).collect();
        cfg.epoch = epoch.unwrap_or_else(virtual_epoch);
        Ok(Self::new(cfg, sources))
    }

    pub fn now(&self) -> Micros {
        self.now
    }

    /// The source behind link `i`.
    pub fn source(&self, i: usize) -> Option<&dyn VirtualSource> {
        self.links.get(i).map(|l| l.src.as_ref())
    }

    pub fn quit_requested(&self) -> bool {
        self.app.quit
    }

    fn apply(&mut self, fx: Vec<Effect>) {
        for e in fx {
            match e {
                Effect::Send { link, msg } => {
                    for (i, l) in self.links.iter_mut().enumerate() {
                        if link.is_none() || link == Some(i) {
                            let bytes = l.tx.encode(&msg);
                            l.src.receive(self.now, &bytes);
                        }
                    }
                }
                Effect::WriteFile { .. } | Effect::Quit => {}
            }
        }
    }

    fn deliver(&mut self, i: usize) {
        let bytes = self.links[i].src.poll(self.now);
        if bytes.is_empty() {
            return;
        }
        let l = &mut self.links[i];
        let mut frames = Vec::new();
        l.parser.push(&bytes, |f| frames.push(f));
        let total = *l.parser.stats();
        let stats = total.since(&l.reported);
        l.reported = total;
        l.tx.observe(&total);
        let fx = self.app.update(
            self.now,
            Event::Frames {
                link: i,
                frames,
                stats,
            },
        );
        self.apply(fx);
    }

    /// Run links and core up to virtual time `t`, in time order, links in index order.
    pub fn advance_to(&mut self, t: Micros) {
        loop {
            let next_src = self
                .links
                .iter()
                .map(|l| l.src.next_deadline())
                .min()
                .unwrap_or(Micros::MAX);
            let step = next_src.min(self.next_tick).max(self.now);
            if step > t {
                break;
            }
            self.now = step;
            for i in 0..self.links.len() {
                if self.links[i].src.next_deadline() <= self.now {
                    self.deliver(i);
                }
            }
            if self.now >= self.next_tick {
                let fx = self.app.update(self.now, Event::Tick);
                self.apply(fx);
                self.next_tick = self.now + TICK;
            }
        }
        self.now = self.now.max(t);
        let fx = self.app.update(self.now, Event::Tick);
        self.apply(fx);
    }

    /// A key pressed at the current virtual time.
    pub fn key(&mut self, key: Key) {
        let fx = self.app.update(self.now, Event::Key(key));
        self.apply(fx);
    }
}
