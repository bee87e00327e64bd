//! A replay [`Driver`] over real links, in real time: `--headless --input` with serial, UDP or
//! TCP links. The script's times are seconds since start on the wall clock; the screens are
//! rendered from the same core as in the terminal.

use super::runner::Driver;
use crate::app::{App, AppConfig, Event};
use crate::clock::{Clock, Micros, RealClock};
use crate::keymap::Key;
use crate::link::manager::LinkManager;
use crate::link::transport::LinkIdentity;
use crate::link::LinkSpec;

/// The core on real links, driven by a replay script.
pub struct RealTimeRunner {
    rt: tokio::runtime::Handle,
    mgr: LinkManager,
    app: App,
    clock: RealClock,
}

impl RealTimeRunner {
    /// Start the links on `rt` (a runtime the caller keeps alive; not called from inside it).
    pub fn start(rt: tokio::runtime::Handle, specs: &[LinkSpec], mut cfg: AppConfig) -> Self {
        cfg.links = specs.iter().map(|s| s.to_string()).collect();
        cfg.epoch = chrono::Utc::now();
        let me = LinkIdentity {
            sysid: cfg.sysid,
            compid: cfg.compid,
        };
        let mgr = {
            let _in_rt = rt.enter();
            LinkManager::start(specs, me)
        };
        Self {
            rt,
            mgr,
            app: App::new(cfg),
            clock: RealClock::new(),
        }
    }

    pub fn app_mut(&mut self) -> &mut App {
        &mut self.app
    }
}

impl Driver for RealTimeRunner {
    fn advance_to(&mut self, t: Micros) {
        let Self {
            rt,
            mgr,
            app,
            clock,
        } = self;
        rt.block_on(crate::driver::run_until(mgr, app, clock, t));
    }

    fn key(&mut self, key: Key) {
        let fx = self.app.update(self.clock.now(), Event::Key(key));
        crate::driver::apply_sends(&self.mgr, fx);
    }

    fn now(&self) -> Micros {
        self.clock.now()
    }

    fn quit_requested(&self) -> bool {
        self.app.quit
    }

    fn app(&self) -> &App {
        &self.app
    }
}
