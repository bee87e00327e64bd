//! `--headless --params-out FILE`: download every parameter of the first autopilot heard, write
//! them, and say on stderr how it goes.

use std::path::Path;

use crate::app::App;
use crate::params::file::{self, Format, Saved};
use crate::proto::params::Method;

/// How the download of the target's parameters stands.
#[derive(Debug, Clone, PartialEq)]
pub enum Progress {
    /// No autopilot heard yet.
    NoVehicle,
    Running {
        got: usize,
        count: Option<u16>,
        method: Method,
    },
    /// Ended: complete when `missing` is 0.
    Ended {
        count: usize,
        missing: usize,
        method: Method,
        secs: f64,
        requests: u32,
        retries: u32,
        fallback: Option<String>,
    },
}

/// Where the first autopilot's download stands.
pub fn progress(app: &App) -> Progress {
    let Some(s) = app.target.and_then(|k| app.sessions.get(&k)) else {
        return Progress::NoVehicle;
    };
    if let Some((_, got, count, method)) = s.params.downloading() {
        return Progress::Running { got, count, method };
    }
    match &s.params.last {
        Some(st) => {
            let set = s.params.autopilot();
            let count = set.and_then(|p| p.count).map_or(0, |c| c as usize);
            // Complete only when the vehicle's whole set is here (a download that got no
            // answer at all is not a complete empty set).
            let missing = match set {
                Some(p) if p.complete() => 0,
                Some(p) if p.count.is_some() => count.saturating_sub(p.progress().0).max(1),
                _ => st.missing.max(1),
            };
            Progress::Ended {
                count,
                missing,
                method: st.method,
                secs: st.finished.map_or(0.0, |f| (f - st.started) as f64 / 1e6),
                requests: st.requests,
                retries: st.retries,
                fallback: st.fallback.clone(),
            }
        }
        None => Progress::Running {
            got: 0,
            count: None,
            method: Method::Ftp,
        },
    }
}

impl Progress {
    pub fn ended(&self) -> bool {
        matches!(self, Progress::Ended { .. })
    }

    /// One line for stderr.
    pub fn line(&self) -> String {
        match self {
            Progress::NoVehicle => "waiting for an autopilot's heartbeat".into(),
            Progress::Running { got, count, method } => match count {
                Some(c) => format!("parameters {got}/{c} ({})", method.name()),
                None => format!("parameters: asking ({})", method.name()),
            },
            Progress::Ended {
                count,
                missing,
                method,
                secs,
                requests,
                retries,
                fallback,
            } => {
                let fb = fallback
                    .as_ref()
                    .map(|f| format!(", MAVFTP left: {f}"))
                    .unwrap_or_default();
                if *count == 0 {
                    return format!(
                        "no parameter came in {secs:.2} s by {} ({requests} requests, {retries} retries{fb})",
                        method.name()
                    );
                }
                format!(
                    "parameters {}/{count} in {secs:.2} s by {} ({requests} requests, {retries} retries{fb})",
                    count.saturating_sub(*missing),
                    method.name()
                )
            }
        }
    }
}

/// The text of the file: the target autopilot's parameters (every component's for `.params`).
pub fn file_text(app: &App, path: &Path) -> Option<String> {
    let key = app.target?;
    let s = app.sessions.get(&key)?;
    let format = file::format_for_path(path);
    let params: Vec<Saved> = s
        .params
        .sets
        .iter()
        .filter(|(c, _)| format == Format::Qgc || **c == key.1)
        .flat_map(|(c, set)| {
            set.params.iter().map(move |(name, p)| Saved {
                name,
                value: p.value,
                ptype: p.ptype,
                component: *c,
            })
        })
        .collect();
    let (stack, vehicle) = app
        .vehicles
        .get(key)
        .map(|v| (v.autopilot_name().to_string(), v.type_name().to_string()))
        .unwrap_or_default();
    let header = file::Header {
        sysid: key.0,
        stack,
        vehicle,
        ..Default::default()
    };
    Some(file::write(format, &params, &header))
}

/// A real-time front end with no screen that ends the run when the download has ended, and
/// prints its progress to stderr as it changes.
#[derive(Debug, Default)]
pub struct StopWhenDone {
    last: String,
}

impl crate::driver::real_time::Frontend for StopWhenDone {
    async fn next_input(&mut self) -> std::io::Result<Option<crate::app::Event>> {
        std::future::pending().await
    }
    fn wake_at(&self, _app: &App) -> Option<crate::clock::Micros> {
        None
    }
    fn after(&mut self, app: &mut App, _now: crate::clock::Micros) -> std::io::Result<()> {
        let p = progress(app);
        let line = p.line();
        if line != self.last {
            // Progress every tenth of the set, not every parameter.
            let step = match (&p, &self.last) {
                (
                    Progress::Running {
                        got,
                        count: Some(c),
                        ..
                    },
                    _,
                ) => (*got * 10 / (*c as usize).max(1)).to_string(),
                _ => line.clone(),
            };
            if step != self.last {
                eprintln!("{line}");
                self.last = step;
            }
        }
        if p.ended() {
            app.quit = true;
        }
        Ok(())
    }
}
