//! Headless replay: run a [`Script`] against the core on a virtual clock and save screens.
//!
//! Screens are rendered with ratatui's `TestBackend` at a fixed size, so the same links and the
//! same script give byte-identical screens on any machine (the clock shown comes from
//! `app.wall`, whose epoch the runner fixes). That makes UI behaviour testable end to end and
//! bug reports reproducible.

use std::io::Write;
use std::path::PathBuf;

use super::script::{format_secs, Script, Step};
use crate::app::{App, AppConfig};
use crate::clock::Micros;
use crate::driver::virtual_time::{Driver, RunnerError, VirtualRunner};
use crate::keymap::{Key, KeyCode};
use crate::link::LinkSpec;
use crate::ui::{buffer_to_text, render_to_buffer, Theme};

/// Screen size when none is given.
pub const DEFAULT_SIZE: (u16, u16) = (120, 40);

/// How to replay.
#[derive(Debug, Clone)]
pub struct ReplayOptions {
    /// (width, height) of the virtual screen.
    pub size: (u16, u16),
    /// Write each snapshot to `DIR/NAME.txt`; `None` writes them to `out` with a header line.
    pub screens_dir: Option<PathBuf>,
    pub theme: Theme,
}

impl Default for ReplayOptions {
    fn default() -> Self {
        Self {
            size: DEFAULT_SIZE,
            screens_dir: None,
            theme: Theme::PLAIN,
        }
    }
}

/// How a replay went.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReplayOutcome {
    /// Every step of the script ran. False when the app quit (a bound quit key) before the end:
    /// the caller should exit non-zero, the screens after that point were never made.
    pub completed: bool,
    /// Steps run.
    pub steps_run: usize,
    /// Snapshot names written, in order.
    pub snapshots: Vec<String>,
    /// Virtual time at the end.
    pub end: Micros,
}

#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    #[error("writing screen {path}: {source}")]
    Screen {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("writing replay output: {0}")]
    Output(#[from] std::io::Error),
    #[error("replay links: {0}")]
    Runner(#[from] RunnerError),
}

/// The screen as plain text right now.
pub fn screen_text(app: &App, size: (u16, u16), theme: &Theme) -> String {
    buffer_to_text(&render_to_buffer(app, size.0, size.1, theme))
}

/// A character typed as a key (what `text "..."` sends).
fn char_key(c: char) -> Key {
    match c {
        '\n' => Key::plain(KeyCode::Enter),
        '\t' => Key::plain(KeyCode::Tab),
        c => Key::ch(c),
    }
}

/// Run `script` on `runner`. Returns once the script ends (last step, or `quit`) or the app
/// quits. Snapshots go to `opts.screens_dir` or to `out`.
pub fn run_script(
    script: &Script,
    runner: &mut impl Driver,
    opts: &ReplayOptions,
    out: &mut dyn Write,
) -> Result<ReplayOutcome, ReplayError> {
    if let Some(dir) = &opts.screens_dir {
        std::fs::create_dir_all(dir).map_err(|source| ReplayError::Screen {
            path: dir.clone(),
            source,
        })?;
    }
    let mut size = opts.size;
    let mut outcome = ReplayOutcome {
        completed: false,
        steps_run: 0,
        snapshots: Vec::new(),
        end: runner.now(),
    };
    for timed in &script.steps {
        if runner.quit_requested() {
            outcome.end = runner.now();
            return Ok(outcome);
        }
        runner.advance_to(timed.t);
        match &timed.step {
            Step::Key(k) => runner.key(*k),
            Step::Release(k) => runner.release(*k),
            Step::Text(s) => {
                for c in s.chars() {
                    runner.key(char_key(c));
                }
            }
            Step::Resize(w, h) => size = (*w, *h),
            Step::Snapshot(name) => {
                let text = screen_text(runner.app(), size, &opts.theme);
                match &opts.screens_dir {
                    Some(dir) => {
                        let path = dir.join(format!("{name}.txt"));
                        crate::fsio::write_atomic(&path, text.as_bytes())
                            .map_err(|source| ReplayError::Screen { path, source })?;
                    }
                    None => {
                        let (w, h) = size;
                        writeln!(
                            out,
                            "=== snapshot {name} at {}s ({w}x{h}) ===",
                            format_secs(timed.t)
                        )?;
                        out.write_all(text.as_bytes())?;
                    }
                }
                outcome.snapshots.push(name.clone());
            }
            Step::Quit => {
                outcome.steps_run += 1;
                break;
            }
        }
        outcome.steps_run += 1;
    }
    outcome.completed = outcome.steps_run == script.steps.len();
    outcome.end = runner.now();
    out.flush()?;
    Ok(outcome)
}

/// Convenience for the CLI: build a [`VirtualRunner`] on `specs` (sim:// and tlog: only) and run
/// `script` on it; returns the outcome and the final state (for a report).
pub fn run_script_on_specs(
    script: &Script,
    specs: &[LinkSpec],
    cfg: AppConfig,
    opts: &ReplayOptions,
    out: &mut dyn Write,
) -> Result<(ReplayOutcome, App), ReplayError> {
    let mut runner = VirtualRunner::from_specs(specs, cfg)?;
    let outcome = run_script(script, &mut runner, opts, out)?;
    Ok((outcome, runner.app))
}
