//! `--headless --logs-out DIR [--log-ids 1,3]`: download the first autopilot's onboard logs
//! (the newest by default) into DIR, and say on stderr how it goes. Done only when every log
//! asked for is whole.

use std::path::Path;

use crate::app::logs::Which;
use crate::app::App;
use crate::proto::logs::State;

/// How the downloads stand.
#[derive(Debug, Clone, PartialEq)]
pub enum Progress {
    NoVehicle,
    Running(String),
    /// Every log asked for saved: (id, path).
    Done(Vec<(u16, std::path::PathBuf)>),
    Failed(String),
}

/// Ask for the logs once the target is known (call after every step); the state.
pub fn drive(app: &mut App, dir: &Path, ids: &[u16], asked: &mut bool) -> Progress {
    let Some(key) = app.target.filter(|k| app.sessions.contains_key(k)) else {
        return Progress::NoVehicle;
    };
    if !*asked {
        *asked = true;
        if let Some(s) = app.sessions.get_mut(&key) {
            s.logs.dir = Some(dir.to_path_buf());
        }
        if ids.is_empty() {
            app.logs_request(key, Which::Latest, None);
        } else {
            for &id in ids {
                app.logs_request(key, Which::Id(id), None);
            }
        }
        return Progress::Running("asking for the list".into());
    }
    let s = &app.sessions[&key];
    if s.logs.route.is_none() {
        return Progress::Running(format!(
            "waiting: only a high-latency link reaches {key}, and logs never go there unasked"
        ));
    }
    let l = &s.logs.list;
    if let Some(why) = &l.failed {
        return Progress::Failed(format!("log list: {why}"));
    }
    if l.num_logs == Some(0) {
        return Progress::Failed("the vehicle has no log".into());
    }
    if !l.complete() {
        return Progress::Running(format!(
            "listing {}/{}",
            l.entries.len(),
            l.num_logs.map_or("?".into(), |n| n.to_string())
        ));
    }
    let want: Vec<u16> = if ids.is_empty() {
        s.logs.latest().into_iter().collect()
    } else {
        ids.to_vec()
    };
    if let Some(id) = want.iter().find(|id| !l.entries.contains_key(id)) {
        return Progress::Failed(format!("no log {id} on the vehicle"));
    }
    let mut done = Vec::new();
    for &id in &want {
        // On its way again (queued, or waiting for the vehicle to be heard): not failed yet.
        let again = s.logs.queue.iter().any(|q| q.id == id)
            || s.logs
                .transfer
                .as_ref()
                .is_some_and(|t| t.active() && t.entry.id == id);
        if again {
            continue;
        }
        match s.logs.history.iter().rev().find(|(e, _, _)| e.id == id) {
            Some((_, p, State::Done)) => done.push((id, p.clone())),
            Some((_, _, State::Failed(why))) => {
                return Progress::Failed(format!("log {id}: {why}"))
            }
            _ => {}
        }
    }
    if done.len() == want.len() {
        return Progress::Done(done);
    }
    match (&s.logs.transfer, crate::app::logs::status_text(s, app.now)) {
        (_, Some(t)) => Progress::Running(t),
        _ => Progress::Running(format!("{}/{} logs saved", done.len(), want.len())),
    }
}

impl Progress {
    pub fn ended(&self) -> bool {
        matches!(self, Progress::Done(_) | Progress::Failed(_))
    }
}

/// A real-time front end with no screen that ends the run when the downloads ended.
#[derive(Debug)]
pub struct StopWhenDone {
    pub dir: std::path::PathBuf,
    pub ids: Vec<u16>,
    pub asked: bool,
    pub last: String,
    pub progress: Option<Progress>,
}

impl crate::driver::real_time::Frontend for StopWhenDone {
    async fn next_input(&mut self) -> std::io::Result<Option<crate::app::Event>> {
        std::future::pending().await
    }
    fn wake_at(&self, _app: &App) -> Option<crate::clock::Micros> {
        None
    }
    fn after(&mut self, app: &mut App, _now: crate::clock::Micros) -> std::io::Result<()> {
        let p = drive(app, &self.dir, &self.ids, &mut self.asked);
        let line = format!("{p:?}");
        if line != self.last {
            eprintln!("{}", line);
            self.last = line;
        }
        if p.ended() {
            app.quit = true;
        }
        self.progress = Some(p);
        Ok(())
    }
}
