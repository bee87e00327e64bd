//! The core on the wall clock over real transports (and in-process links in real time): the
//! terminal, and headless reports and replays on real links.
//!
//! One loop: it sleeps until the core's next deadline, a link report, a finished file write, or
//! the front end's next input (keys, resizes, signals), whichever comes first, and redraws
//! through the front end only when the core says something changed. An idle mavterm wakes only
//! for the core's own timers (the 1 Hz heartbeat) and the front end's (the clock on screen).

use std::path::PathBuf;
use std::time::Duration;

use tokio::sync::mpsc;

use super::forward::Forwarder;
use super::record::{Recorder, TlogTarget};
use super::virtual_time::Driver;
use super::{link_event, local_sources, step, step_edge, wall_us, write_atomic, Links};
use crate::app::{App, AppConfig, Event};
use crate::clock::{Clock, Micros, RealClock};
use crate::keymap::Key;
use crate::link::manager::LinkManager;
use crate::link::replay::ReplayCmd;
use crate::link::transport::LinkEvent;
use crate::link::{Frame, LinkId, LinkSpec};

/// What a front end adds to the loop.
pub trait Frontend {
    /// The next input (key, resize) as a core event; `Ok(None)` when input ended (quit), an
    /// error ends the run. Front ends without input never resolve.
    fn next_input(
        &mut self,
    ) -> impl std::future::Future<Output = std::io::Result<Option<Event>>> + Send;
    /// When the front end itself needs waking (e.g. to draw a change it held back to keep under
    /// its frame rate), in core time.
    fn wake_at(&self, app: &App) -> Option<Micros>;
    /// After the core handled something: draw if it changed.
    fn after(&mut self, app: &mut App, now: Micros) -> std::io::Result<()>;
}

/// A front end with no input and no screen: headless reports and replays.
pub struct NoFrontend;

impl Frontend for NoFrontend {
    async fn next_input(&mut self) -> std::io::Result<Option<Event>> {
        std::future::pending().await
    }
    fn wake_at(&self, _app: &App) -> Option<Micros> {
        None
    }
    fn after(&mut self, _app: &mut App, _now: Micros) -> std::io::Result<()> {
        Ok(())
    }
}

/// Real link tasks, and file writes off the async workers; the tap: the log, the outputs.
struct RealLinks {
    mgr: LinkManager,
    done: mpsc::UnboundedSender<Event>,
    recorder: Option<Recorder>,
    outputs: Option<Outputs>,
    /// Events the edge made on its own (frames an output's queue could not take), for the core.
    pending: Vec<Event>,
}

/// The forwarding outputs: link tasks in an id space of their own, and the forwarder.
struct Outputs {
    mgr: LinkManager,
    fwd: Forwarder,
}

impl RealLinks {
    /// Output `out` reported: its frames go to the vehicles' links (and the log), its state and
    /// drops are counted.
    fn on_output(&mut self, wall: u64, out: usize, ev: LinkEvent) {
        let Some(o) = self.outputs.as_mut() else {
            return;
        };
        match ev {
            LinkEvent::Frames { frames, .. } => {
                let (mgr, pending, recorder) = (&self.mgr, &mut self.pending, &mut self.recorder);
                o.fwd.from_output(
                    out,
                    &frames,
                    mgr.len(),
                    |link, bytes| {
                        let ok = mgr.send(link, bytes);
                        if !ok {
                            match pending.last_mut() {
                                Some(Event::Dropped { link: l, frames }) if *l == link => {
                                    *frames += 1
                                }
                                _ => pending.push(Event::Dropped { link, frames: 1 }),
                            }
                        }
                        ok
                    },
                    |raw| {
                        if let Some(r) = recorder.as_mut() {
                            r.record(wall, raw);
                        }
                    },
                );
            }
            LinkEvent::State(state) => o.fwd.output_state(out, state),
            LinkEvent::Dropped(n) => o.fwd.output_dropped(out, n),
            // Outputs are never replays (`--out tlog:` is refused).
            LinkEvent::Replay(_) => {}
        }
    }

    /// When the tap next has something to tell the core.
    fn next_report_at(&self) -> Option<Micros> {
        let r = self.recorder.as_ref().and_then(Recorder::next_report_at);
        let o = self.outputs.as_ref().and_then(|o| o.fwd.next_report_at());
        r.into_iter().chain(o).min()
    }
}

/// The next report of any output; never, without outputs.
async fn next_output(outputs: &mut Option<Outputs>) -> Option<(usize, LinkEvent)> {
    match outputs {
        Some(o) => o.mgr.next_event().await,
        None => std::future::pending().await,
    }
}

impl Links for RealLinks {
    fn send(&mut self, _now: Micros, link: LinkId, frame: Vec<u8>) -> bool {
        self.mgr.send(link, frame)
    }
    fn open(&mut self, _now: Micros, link: LinkId, spec: LinkSpec) {
        self.mgr.open(link, spec);
    }
    fn replay_control(&mut self, _now: Micros, link: LinkId, cmd: ReplayCmd) {
        // A full control queue (keys held down faster than the link takes them) drops the
        // press, as a terminal does when it cannot keep up.
        self.mgr.control(link, cmd);
    }
    fn write_file(&mut self, path: PathBuf, contents: Vec<u8>) {
        let done = self.done.clone();
        tokio::task::spawn_blocking(move || {
            let error = write_atomic(&path, &contents).err().map(|e| e.to_string());
            let _ = done.send(Event::FileWritten { path, error });
        });
    }
    fn read_file(&mut self, path: PathBuf, purpose: crate::app::files::FileUse) {
        let done = self.done.clone();
        tokio::task::spawn_blocking(move || {
            let result = super::read_bounded(&path);
            let _ = done.send(Event::FileRead {
                path,
                purpose,
                result,
            });
        });
    }
    fn fetch_param_meta(&mut self, urls: Vec<String>, cache_path: PathBuf) {
        let done = self.done.clone();
        tokio::task::spawn_blocking(move || {
            let _ = done.send(super::fetch::fetch_param_meta(urls, cache_path));
        });
    }
    fn read_param_meta(&mut self, path: PathBuf) {
        let done = self.done.clone();
        tokio::task::spawn_blocking(move || {
            if let Some(ev) = super::fetch::read_param_meta(path) {
                let _ = done.send(ev);
            }
        });
    }
    fn heard(&mut self, wall: u64, link: LinkId, frames: &[Frame]) {
        if let Some(r) = self.recorder.as_mut() {
            r.record_frames(wall, frames);
        }
        if let Some(o) = self.outputs.as_mut() {
            let mgr = &o.mgr;
            o.fwd
                .from_vehicles(link, frames, |out, bytes| mgr.send(out, bytes));
        }
    }
    fn sending(&mut self, wall: u64, _link: LinkId, frame: &[u8]) {
        if let Some(r) = self.recorder.as_mut() {
            r.record(wall, frame);
        }
    }
    fn end_step(&mut self, now: Micros) -> Vec<Event> {
        let mut out = std::mem::take(&mut self.pending);
        if let Some(r) = self.recorder.as_mut() {
            out.extend(r.after_step(now).map(Event::Recording));
        }
        if let Some(o) = self.outputs.as_mut() {
            let reports = o.fwd.reports(now);
            out.extend(
                reports
                    .into_iter()
                    .map(|(out, status)| Event::Output { out, status }),
            );
        }
        out
    }
}

/// The core on real links and the wall clock (`C` is the clock; tests may wrap it).
pub struct RealTime<C: Clock = RealClock> {
    pub app: App,
    links: RealLinks,
    done: mpsc::UnboundedReceiver<Event>,
    clock: C,
}

/// Why a real-time run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ended {
    /// The time asked for was reached.
    Deadline,
    /// The core quit (a quit key or command).
    Quit,
    /// The front end's input ended.
    InputClosed,
}

impl RealTime {
    /// Start the links; call within a tokio runtime.
    pub fn start(specs: &[LinkSpec], cfg: AppConfig) -> Self {
        Self::start_with_clock(specs, cfg, RealClock::new())
    }
}

impl<C: Clock + Clone> RealTime<C> {
    /// Start the links with core time read from `clock`; call within a tokio runtime.
    pub fn start_with_clock(specs: &[LinkSpec], mut cfg: AppConfig, clock: C) -> Self {
        cfg.links = specs.iter().map(|s| s.to_string()).collect();
        cfg.epoch = chrono::Utc::now();
        let (tx, done) = mpsc::unbounded_channel();
        Self {
            app: App::new(cfg),
            links: RealLinks {
                mgr: LinkManager::start(specs, local_sources()),
                done: tx,
                recorder: None,
                outputs: None,
                pending: Vec::new(),
            },
            done,
            clock,
        }
    }

    pub fn now(&self) -> Micros {
        self.clock.now()
    }

    /// The clock core time is read from.
    pub fn clock(&self) -> C {
        self.clock.clone()
    }

    /// Feed one event now.
    pub fn step(&mut self, ev: Event) {
        step(&mut self.app, &mut self.links, self.clock.now(), ev);
    }

    /// Record every frame heard and sent from now on to `target`; the core is told where (or
    /// why not).
    pub fn record(&mut self, target: &TlogTarget) {
        match super::open_recorder(target) {
            Ok(r) => {
                self.links.recorder = Some(r);
                step_edge(&mut self.app, &mut self.links, self.clock.now());
            }
            Err(ev) => self.step(ev),
        }
    }

    /// Forward every frame heard to `outputs` (other ground stations), and theirs to the
    /// vehicles; call within a tokio runtime. The outputs show in the core's Links pane.
    pub fn forward(&mut self, outputs: &[LinkSpec]) {
        if outputs.is_empty() {
            return;
        }
        self.links.outputs = Some(Outputs {
            mgr: LinkManager::start_queued(
                outputs,
                local_sources(),
                crate::link::manager::OUTPUT_QUEUE,
            ),
            fwd: Forwarder::new(outputs),
        });
        step_edge(&mut self.app, &mut self.links, self.clock.now());
    }

    /// At the end of a run: the recording ended (everything written and flushed) and the core
    /// told its final size, and the outputs' last counters.
    pub fn finish(&mut self) {
        if let Some(mut r) = self.links.recorder.take() {
            let st = r.finish();
            self.step(Event::Recording(st));
        }
        let reports = self
            .links
            .outputs
            .as_mut()
            .map(|o| o.fwd.final_reports())
            .unwrap_or_default();
        for (out, status) in reports {
            self.step(Event::Output { out, status });
        }
    }

    /// Run until core time `until` (if given), the core quits, or the front end's input ends.
    /// However the session ends but at `until` (the quit key, the input closed by a signal, an
    /// error, a panic), a Fly mode nudge in progress ends in its stop, sent in full
    /// ([`Self::wind_down`]) before this returns (or the panic goes on).
    pub async fn run(
        &mut self,
        until: Option<Micros>,
        front: &mut impl Frontend,
    ) -> std::io::Result<Ended> {
        use futures_util::FutureExt;
        let run = std::panic::AssertUnwindSafe(self.run_loop(until, front)).catch_unwind();
        match run.await {
            Ok(Ok(Ended::Deadline)) => {
                // A headless run's time is up: a log download still running is ended with
                // LOG_REQUEST_END (the vehicle logs again), sent before this returns.
                let logs = self
                    .app
                    .sessions
                    .values()
                    .any(|s| s.logs.transfer.as_ref().is_some_and(|t| t.active()));
                if logs {
                    self.wind_down().await;
                }
                Ok(Ended::Deadline)
            }
            Ok(r) => {
                self.wind_down().await;
                r
            }
            Err(panic) => {
                let _ = std::panic::AssertUnwindSafe(self.wind_down())
                    .catch_unwind()
                    .await;
                std::panic::resume_unwind(panic)
            }
        }
    }

    /// The session is ending: a nudge in progress stops (its zero velocity and the two copies
    /// 100 ms apart go out), with a moment for the link tasks to write them. Nothing to stop:
    /// nothing waits.
    async fn wind_down(&mut self) {
        self.step(Event::Ending);
        if !self.app.nudge.stopping() {
            if self.app.log_end_on_exit {
                // LOG_REQUEST_END is on its way to the link tasks: a moment to write it.
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
            return;
        }
        let give_up = self.clock.now() + 500_000;
        while self.app.nudge.stopping() && self.clock.now() < give_up {
            let wake = self.app.next_deadline().min(give_up);
            let now = self.clock.now();
            tokio::time::sleep(Duration::from_micros(wake.saturating_sub(now))).await;
            self.step(Event::Tick);
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }

    async fn run_loop(
        &mut self,
        until: Option<Micros>,
        front: &mut impl Frontend,
    ) -> std::io::Result<Ended> {
        front.after(&mut self.app, self.clock.now())?;
        // One timer for the loop, moved only when the wake-up time changes: each timer made (or
        // moved earlier) is taken in by the runtime's timer driver (a wake-up of the thread
        // parked on it, when that is another), and frames come many times between two changes
        // of the wake-up time.
        let mut sleep = std::pin::pin!(tokio::time::sleep(Duration::ZERO));
        let mut armed: Option<Micros> = None;
        loop {
            if self.app.quit {
                return Ok(Ended::Quit);
            }
            let now = self.clock.now();
            if until.is_some_and(|u| now >= u) {
                self.step(Event::Tick);
                return Ok(Ended::Deadline);
            }
            let mut wake = self.app.next_deadline();
            if let Some(w) = front.wake_at(&self.app) {
                wake = wake.min(w);
            }
            if let Some(w) = self.links.next_report_at() {
                wake = wake.min(w);
            }
            if let Some(u) = until {
                wake = wake.min(u);
            }
            if armed != Some(wake) {
                let after = Duration::from_micros(wake.saturating_sub(now));
                sleep.as_mut().reset(tokio::time::Instant::now() + after);
                armed = Some(wake);
            }
            let mut output = None;
            let ev = tokio::select! {
                ev = self.links.mgr.next_event() => ev.map(|(link, ev)| link_event(link, ev)),
                Some(o) = next_output(&mut self.links.outputs) => {
                    output = Some(o);
                    None
                }
                Some(ev) = self.done.recv() => Some(ev),
                input = front.next_input() => match input? {
                    Some(ev) => Some(ev),
                    None => return Ok(Ended::InputClosed),
                },
                _ = &mut sleep => {
                    armed = None;
                    Some(Event::Tick)
                }
            };
            if let Some(ev) = ev {
                self.step(ev);
            }
            if let Some((out, ev)) = output {
                let now = self.clock.now();
                self.links.on_output(wall_us(&self.app, now), out, ev);
                step_edge(&mut self.app, &mut self.links, now);
            }
            front.after(&mut self.app, self.clock.now())?;
        }
    }
}

/// A replay script's [`Driver`] over real links in real time: `--headless --input` with serial,
/// UDP or TCP links. The script's times are seconds since start on the wall clock.
pub struct RealTimeRunner {
    rt: tokio::runtime::Handle,
    pub inner: RealTime,
}

impl RealTimeRunner {
    /// Start the links on `rt` (a runtime the caller keeps alive; not called from inside it). It
    /// must have worker threads: the runner steps it by `Handle::block_on`, which drives the
    /// links' I/O and timers only on such a runtime.
    pub fn start(rt: tokio::runtime::Handle, specs: &[LinkSpec], cfg: AppConfig) -> Self {
        let inner = {
            let _in_rt = rt.enter();
            RealTime::start(specs, cfg)
        };
        Self { rt, inner }
    }

    pub fn app_mut(&mut self) -> &mut App {
        &mut self.inner.app
    }
}

impl Driver for RealTimeRunner {
    fn advance_to(&mut self, t: Micros) {
        let Self { rt, inner } = self;
        let _ = rt.block_on(inner.run(Some(t), &mut NoFrontend));
    }
    fn key(&mut self, key: Key) {
        let _in_rt = self.rt.enter();
        self.inner.step(Event::Key(key));
    }
    fn release(&mut self, key: Key) {
        let _in_rt = self.rt.enter();
        self.inner.step(Event::KeyRelease(key));
    }
    fn now(&self) -> Micros {
        self.inner.now()
    }
    fn quit_requested(&self) -> bool {
        self.inner.app.quit
    }
    fn app(&self) -> &App {
        &self.inner.app
    }
}

/// Run the core on real links for `duration`, headless, and return its final state.
pub async fn run_for(specs: &[LinkSpec], cfg: AppConfig, duration: Duration) -> App {
    run_for_with(specs, cfg, duration, |_| {}).await
}

/// [`run_for`], with the runtime set up by `setup` first (recording, forwarding). A recording
/// is finished (flushed) before the state is returned.
pub async fn run_for_with(
    specs: &[LinkSpec],
    cfg: AppConfig,
    duration: Duration,
    setup: impl FnOnce(&mut RealTime),
) -> App {
    let mut rt = RealTime::start(specs, cfg);
    setup(&mut rt);
    let until = rt.now() + duration.as_micros() as Micros;
    let _ = rt.run(Some(until), &mut NoFrontend).await;
    rt.finish();
    rt.app
}
