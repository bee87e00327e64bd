//! Running the core on a virtual clock with in-process links (`sim://`, `tlog:`): no TTY, no
//! sockets, no wall clock, so the same input gives the same frames and the same screens, and a
//! minute of flight replays in milliseconds.
//!
//! Time jumps from deadline to deadline: the earliest of every source's next emission and the
//! core's own [`App::next_deadline`]. There is no fixed tick.

use std::path::PathBuf;

use chrono::{DateTime, TimeZone, Utc};

use super::record::{Recorder, TlogTarget};
use super::{local_source, step, step_edge, write_atomic, Links};
use crate::app::{App, AppConfig, Event};
use crate::clock::Micros;
use crate::keymap::Key;
use crate::link::replay::ReplayCmd;
use crate::link::source::{TlogSource, VirtualSource};
use crate::link::{Frame, FrameParser, LinkId, LinkSpec, LinkState, ParserStats};

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
    /// A key let go now.
    fn release(&mut self, key: Key);
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
    fn release(&mut self, key: Key) {
        self.step(Event::KeyRelease(key));
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

/// One in-process link on the virtual clock.
struct VLink {
    /// `None` for a link that could not open (its state says why).
    src: Option<Box<dyn VirtualSource>>,
    parser: FrameParser,
    reported: ParserStats,
    /// The source's skipped bytes already reported as garbage.
    skipped_reported: u64,
}

/// The virtual links: frames the core sends go straight into the sources.
struct VLinks {
    links: Vec<VLink>,
    /// Events the links produced while carrying out effects (a link opened or failed, a file
    /// written), fed to the core next.
    pending: Vec<Event>,
    /// The telemetry log, when recording.
    recorder: Option<Recorder>,
    /// Every frame the core sent (time, link, bytes), once asked for ([`VirtualRunner::capture_sent`]).
    sent: Option<Vec<(Micros, LinkId, Vec<u8>)>>,
}

impl Links for VLinks {
    fn send(&mut self, now: Micros, link: LinkId, frame: Vec<u8>) -> bool {
        if let Some(s) = self.sent.as_mut() {
            s.push((now, link, frame.clone()));
        }
        // A link that could not open discards what is sent to it, as a down link task does.
        if let Some(src) = self.links.get_mut(link).and_then(|l| l.src.as_mut()) {
            src.receive(now, &frame);
        }
        true
    }

    fn open(&mut self, _now: Micros, link: LinkId, spec: LinkSpec) {
        let (src, state) = match local_source(&spec) {
            Ok(src) => (Some(src), LinkState::Up),
            Err(e) => (None, LinkState::Down(e)),
        };
        while self.links.len() < link {
            self.links.push(VLink::new(None));
        }
        self.links.push(VLink::new(src));
        self.pending.push(Event::LinkState { link, state });
    }

    fn write_file(&mut self, path: PathBuf, contents: Vec<u8>) {
        let error = write_atomic(&path, &contents).err().map(|e| e.to_string());
        self.pending.push(Event::FileWritten { path, error });
    }

    fn read_file(&mut self, path: PathBuf, purpose: crate::app::files::FileUse) {
        let result = super::read_bounded(&path);
        self.pending.push(Event::FileRead {
            path,
            purpose,
            result,
        });
    }

    fn fetch_param_meta(&mut self, urls: Vec<String>, cache_path: PathBuf) {
        // In place: virtual time stands still while the download runs.
        self.pending
            .push(super::fetch::fetch_param_meta(urls, cache_path));
    }

    fn read_param_meta(&mut self, path: PathBuf) {
        self.pending.extend(super::fetch::read_param_meta(path));
    }

    fn heard(&mut self, wall: u64, _link: LinkId, frames: &[Frame]) {
        if let Some(r) = self.recorder.as_mut() {
            r.record_frames(wall, frames);
        }
    }

    fn sending(&mut self, wall: u64, _link: LinkId, frame: &[u8]) {
        if let Some(r) = self.recorder.as_mut() {
            r.record(wall, frame);
        }
    }

    fn end_step(&mut self, now: Micros) -> Vec<Event> {
        let report = self.recorder.as_mut().and_then(|r| r.after_step(now));
        report.map(Event::Recording).into_iter().collect()
    }
    fn replay_control(&mut self, now: Micros, link: LinkId, cmd: ReplayCmd) {
        if let Some(src) = self.links.get_mut(link).and_then(|l| l.src.as_mut()) {
            src.control(now, cmd);
            // Told before the frames that follow, so a seek's jump is known when they come.
            if let Some(status) = src.take_status(now) {
                self.pending.push(Event::ReplayStatus { link, status });
            }
        }
    }
}

impl VLink {
    fn new(src: Option<Box<dyn VirtualSource>>) -> Self {
        Self {
            src,
            parser: FrameParser::lazy(),
            reported: ParserStats::default(),
            skipped_reported: 0,
        }
    }
    fn deadline(&self) -> Micros {
        self.src.as_ref().map_or(Micros::MAX, |s| s.next_deadline())
    }
}

/// The core plus its virtual links, stepped by [`VirtualRunner::advance_to`].
pub struct VirtualRunner {
    pub app: App,
    links: VLinks,
    now: Micros,
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
        Self::with_links(cfg, sources.into_iter().map(Ok).collect())
    }

    /// A runner over sources, or for each that could not open why: that link is down from the
    /// start (the run goes on, and its report says why).
    fn with_links(cfg: AppConfig, sources: Vec<Result<Box<dyn VirtualSource>, String>>) -> Self {
        let states: Vec<LinkState> = sources
            .iter()
            .map(|s| match s {
                Ok(_) => LinkState::Up,
                Err(why) => LinkState::Down(why.clone()),
            })
            .collect();
        let links = sources.into_iter().map(|s| VLink::new(s.ok())).collect();
        let mut r = Self {
            app: App::new(cfg),
            links: VLinks {
                links,
                pending: Vec::new(),
                recorder: None,
                sent: None,
            },
            now: 0,
        };
        for (link, state) in states.into_iter().enumerate() {
            r.step(Event::LinkState { link, state });
        }
        r
    }

    /// Build sources from link specs. The epoch shown is the first tlog's start, else fixed. A
    /// tlog that cannot be replayed (missing, not a regular file, no MAVLink records) is a link
    /// down from the start, its reason the error: the run and its report go on.
    pub fn from_specs(specs: &[LinkSpec], mut cfg: AppConfig) -> Result<Self, RunnerError> {
        let mut sources: Vec<Result<Box<dyn VirtualSource>, String>> = Vec::new();
        let mut epoch = None;
        for spec in specs {
            match spec {
                LinkSpec::Tlog { path, speed } => match TlogSource::open(path) {
                    Ok(src) => {
                        epoch = epoch.or(src.start_time());
                        sources.push(Ok(Box::new(src.with_speed(*speed))));
                    }
                    Err(e) => sources.push(Err(format!("{path}: {e}"))),
                },
                LinkSpec::Sim { .. } => {
                    sources.push(Ok(local_source(spec).map_err(RunnerError::Sim)?));
                }
                other => return Err(RunnerError::NotVirtual(other.to_string())),
            }
        }
        cfg.links = specs.iter().map(|s| s.to_string()).collect();
        cfg.epoch = epoch.unwrap_or_else(virtual_epoch);
        Ok(Self::with_links(cfg, sources))
    }

    pub fn now(&self) -> Micros {
        self.now
    }

    /// Record every frame heard and sent from now on to `target`, stamped with the virtual
    /// clock's wall time (`cfg.epoch + now`); the core is told where (or why not).
    pub fn record(&mut self, target: &TlogTarget) {
        match super::open_recorder(target) {
            Ok(r) => {
                self.links.recorder = Some(r);
                step_edge(&mut self.app, &mut self.links, self.now);
            }
            Err(ev) => self.step(ev),
        }
    }

    /// End the recording: everything written and flushed; the core gets the final size.
    pub fn finish_recording(&mut self) {
        if let Some(mut r) = self.links.recorder.take() {
            let st = r.finish();
            self.step(Event::Recording(st));
        }
    }

    /// The source behind link `i`.
    pub fn source(&self, i: usize) -> Option<&dyn VirtualSource> {
        self.links.links.get(i).and_then(|l| l.src.as_deref())
    }

    pub fn quit_requested(&self) -> bool {
        self.app.quit
    }

    /// Feed one event at the current time, then whatever the links produced meanwhile.
    fn step(&mut self, ev: Event) {
        step(&mut self.app, &mut self.links, self.now, ev);
        while !self.links.pending.is_empty() {
            for ev in std::mem::take(&mut self.links.pending) {
                step(&mut self.app, &mut self.links, self.now, ev);
            }
        }
    }

    /// Poll link `i`'s source and hand what it emitted to the core; false when it emitted
    /// nothing.
    fn deliver(&mut self, i: usize) -> bool {
        let now = self.now;
        let l = &mut self.links.links[i];
        let Some(src) = l.src.as_mut() else {
            return false;
        };
        let bytes = src.poll(now);
        let status = src.take_status(now);
        // What the source passed over (a tlog's garbage) is garbage on the link, as if the
        // parser had skipped it.
        let skipped = src.skipped();
        let new_skipped = skipped.saturating_sub(l.skipped_reported);
        let progress = !bytes.is_empty() || new_skipped > 0;
        if progress {
            l.skipped_reported = skipped;
            let mut frames = Vec::new();
            l.parser.push(&bytes, |f| frames.push(f));
            let total = *l.parser.stats();
            let mut stats = total.since(&l.reported);
            stats.garbage_bytes += new_skipped;
            l.reported = total;
            self.step(Event::Frames {
                link: i,
                frames,
                stats,
            });
        }
        if let Some(status) = status {
            self.step(Event::ReplayStatus { link: i, status });
        }
        progress
    }

    /// True when there is a replay link and every replay has handed on its last record.
    pub fn replays_ended(&self) -> bool {
        let mut any = false;
        for l in &self.links.links {
            if let Some(st) = l.src.as_ref().and_then(|s| s.replay_status()) {
                if !st.ended {
                    return false;
                }
                any = true;
            }
        }
        any
    }

    /// Run until every replay link has ended (other links run alongside), or `limit`, or
    /// nothing more can come (a replay paused). False if there is no replay link.
    pub fn run_to_end_of_replays(&mut self, limit: Micros) -> bool {
        let any = self
            .links
            .links
            .iter()
            .any(|l| l.src.as_ref().is_some_and(|s| s.replay_status().is_some()));
        if !any {
            return false;
        }
        while !self.replays_ended() && self.now < limit {
            // A paused replay would wait for ever.
            let playing = self.links.links.iter().any(|l| {
                l.src
                    .as_ref()
                    .and_then(|s| s.replay_status())
                    .is_some_and(|st| !st.ended && !st.paused)
            });
            let next = self
                .links
                .links
                .iter()
                .map(VLink::deadline)
                .min()
                .unwrap_or(Micros::MAX);
            if !playing || next == Micros::MAX {
                break;
            }
            self.advance_to(next.max(self.now).min(limit));
        }
        true
    }

    /// Run links and core up to virtual time `t`, in time order, links in index order.
    pub fn advance_to(&mut self, t: Micros) {
        let mut spins = 0u32;
        loop {
            let next_src = self
                .links
                .links
                .iter()
                .map(VLink::deadline)
                .min()
                .unwrap_or(Micros::MAX);
            let next_core = self.app.next_deadline();
            let mut next = next_src.min(next_core).max(self.now);
            // Something that stays due without progress must not stall virtual time. A source
            // that emits each time (a replay as fast as possible) is progress.
            spins = if next == self.now { spins + 1 } else { 0 };
            if spins > 64 {
                next = self.now + 1;
                spins = 0;
            }
            if next > t {
                break;
            }
            self.now = next;
            for i in 0..self.links.links.len() {
                if self.links.links[i].deadline() <= self.now && self.deliver(i) {
                    spins = 0;
                }
            }
            if self.app.next_deadline() <= self.now {
                self.step(Event::Tick);
            }
        }
        self.now = self.now.max(t);
        self.step(Event::Tick);
    }

    /// Keep every frame the core sends from now on, for [`Self::take_sent`].
    pub fn capture_sent(&mut self) {
        self.links.sent.get_or_insert_with(Vec::new);
    }

    /// The frames sent since the last call (time, link, bytes as they left).
    pub fn take_sent(&mut self) -> Vec<(Micros, LinkId, Vec<u8>)> {
        self.links
            .sent
            .as_mut()
            .map(std::mem::take)
            .unwrap_or_default()
    }

    /// A key pressed at the current virtual time.
    pub fn key(&mut self, key: Key) {
        self.step(Event::Key(key));
    }

    /// Feed any event at the current virtual time (tests: what another part of the edge would
    /// report).
    pub fn event(&mut self, ev: Event) {
        self.step(ev);
    }
}
