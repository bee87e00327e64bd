//! The terminal front end: crossterm input, ratatui output, the core in between.
//!
//! The terminal is put back (alternate screen left, cursor shown, raw mode off) on every way
//! out: normal return, error, Ctrl-C, SIGTERM, SIGHUP, SIGQUIT, SIGINT, and panic (a panic hook
//! restores first, then runs the previous hook so the message lands on a sane screen). Redraws
//! happen only when the core says something changed (`App::take_dirty`), at most `fps` times a
//! second, so an idle screen writes nothing between clock ticks; the loop itself is the driver's
//! (`driver::real_time`), woken by keys, frames and the core's deadlines, never by polling.

use std::fs::File;
use std::io::{self, Write};
use std::panic::PanicHookInfo;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use crossterm::event::{self as ct, KeyEventKind, KeyModifiers};
use crossterm::terminal::{
    disable_raw_mode, enable_raw_mode, EnterAlternateScreen, LeaveAlternateScreen,
};
use ratatui::backend::{Backend, CrosstermBackend};
use ratatui::Terminal;

use crate::app::{App, Event};
use crate::clock::{Clock, Micros, SECOND};
use crate::driver::real_time::{Frontend, RealTime};
use crate::headless::script::key_line;
use crate::keymap::{Key, KeyCode};
use crate::ui::{self, Theme};

/// Front-end settings.
#[derive(Debug, Clone)]
pub struct TuiOptions {
    /// Most redraws per second.
    pub fps: u32,
    /// Append the operator's keys to this file in the replay script format.
    pub record: Option<PathBuf>,
    pub theme: Theme,
}

impl Default for TuiOptions {
    fn default() -> Self {
        Self {
            fps: 10,
            record: None,
            theme: Theme::default(),
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum TuiError {
    #[error("terminal: {0}")]
    Terminal(#[from] io::Error),
    #[error("key recording {path}: {source}")]
    Record { path: PathBuf, source: io::Error },
}

/// A crossterm key event as a core [`Key`]; `None` for releases and keys we have no name for.
pub fn key_from_crossterm(ev: ct::KeyEvent) -> Option<Key> {
    if ev.kind == KeyEventKind::Release {
        return None;
    }
    let ctrl = ev.modifiers.contains(KeyModifiers::CONTROL);
    let alt = ev.modifiers.contains(KeyModifiers::ALT);
    let shift = ev.modifiers.contains(KeyModifiers::SHIFT);
    let code = match ev.code {
        // Shift is already in the character ('G'); ctrl letters are lower case in keymaps.
        ct::KeyCode::Char(c) if ctrl => KeyCode::Char(c.to_ascii_lowercase()),
        ct::KeyCode::Char(c) => KeyCode::Char(c),
        ct::KeyCode::Enter => KeyCode::Enter,
        ct::KeyCode::Esc => KeyCode::Esc,
        ct::KeyCode::Tab if shift => KeyCode::BackTab,
        ct::KeyCode::Tab => KeyCode::Tab,
        ct::KeyCode::BackTab => KeyCode::BackTab,
        ct::KeyCode::Backspace => KeyCode::Backspace,
        ct::KeyCode::Delete => KeyCode::Delete,
        ct::KeyCode::Up => KeyCode::Up,
        ct::KeyCode::Down => KeyCode::Down,
        ct::KeyCode::Left => KeyCode::Left,
        ct::KeyCode::Right => KeyCode::Right,
        ct::KeyCode::PageUp => KeyCode::PageUp,
        ct::KeyCode::PageDown => KeyCode::PageDown,
        ct::KeyCode::Home => KeyCode::Home,
        ct::KeyCode::End => KeyCode::End,
        ct::KeyCode::F(n) => KeyCode::F(n),
        _ => return None,
    };
    Some(Key { code, ctrl, alt })
}

/// Redraw if the core says the screen changed. Returns whether it drew. Shared by the terminal
/// loop and the benchmark, so what is measured is what runs.
pub fn draw_if_dirty<B: Backend>(
    terminal: &mut Terminal<B>,
    app: &mut App,
    theme: &Theme,
) -> Result<bool, B::Error> {
    if !app.take_dirty() {
        return Ok(false);
    }
    terminal.draw(|f| ui::render_with(app, f, theme))?;
    Ok(true)
}

type PanicHook = dyn Fn(&PanicHookInfo<'_>) + Sync + Send + 'static;

struct GuardState {
    out: Box<dyn Write + Send>,
    raw: bool,
    active: bool,
    /// Key releases asked for (keyboard enhancement flags pushed): popped on restore.
    enhanced: bool,
}

impl GuardState {
    fn restore(&mut self) -> io::Result<()> {
        if !std::mem::take(&mut self.active) {
            return Ok(());
        }
        // Raw mode first: even if the writes fail the shell gets its line discipline back.
        let raw = if self.raw { disable_raw_mode() } else { Ok(()) };
        if std::mem::take(&mut self.enhanced) {
            let _ = crossterm::execute!(self.out, ct::PopKeyboardEnhancementFlags);
        }
        crossterm::execute!(self.out, LeaveAlternateScreen, crossterm::cursor::Show)?;
        self.out.flush()?;
        raw
    }
}

/// Owns the terminal's modes while alive; puts them back on drop and on panic.
pub struct TerminalGuard {
    state: Arc<Mutex<GuardState>>,
    prev_hook: Arc<PanicHook>,
}

impl TerminalGuard {
    /// Raw mode + alternate screen + hidden cursor on stdout.
    pub fn enter() -> io::Result<TerminalGuard> {
        TerminalGuard::enter_with(Box::new(io::stdout()), true)
    }

    /// The same on any writer; `raw_mode: false` leaves the tty's mode alone (for tests).
    pub fn enter_with(out: Box<dyn Write + Send>, raw_mode: bool) -> io::Result<TerminalGuard> {
        let prev_hook: Arc<PanicHook> = Arc::from(std::panic::take_hook());
        let state = Arc::new(Mutex::new(GuardState {
            out,
            raw: raw_mode,
            active: true,
            enhanced: false,
        }));
        {
            let state = Arc::clone(&state);
            let prev = Arc::clone(&prev_hook);
            let ui_thread = std::thread::current().id();
            std::panic::set_hook(Box::new(move |info| {
                // try_lock: a panic while the state is held must not deadlock the hook.
                let restored = match state.try_lock() {
                    Ok(mut s) => {
                        let was_active = s.active;
                        let _ = s.restore();
                        was_active
                    }
                    Err(_) => false,
                };
                prev(info);
                // A panic on another thread (a link task) would leave the UI drawing on a
                // terminal we just gave back: end the program instead, with the message shown.
                if restored && std::thread::current().id() != ui_thread {
                    std::process::exit(101);
                }
            }));
        }
        let guard = TerminalGuard { state, prev_hook };
        {
            let mut s = guard.lock();
            if raw_mode {
                enable_raw_mode()?; // on error, drop restores what was done
            }
            crossterm::execute!(
                s.out,
                EnterAlternateScreen,
                crossterm::terminal::Clear(crossterm::terminal::ClearType::All),
                crossterm::cursor::Hide
            )?;
            // Key releases, where the terminal can report them (the kitty keyboard protocol):
            // Fly mode stops a nudge the moment its key is let go.
            if raw_mode && crossterm::terminal::supports_keyboard_enhancement().unwrap_or(false) {
                crossterm::execute!(
                    s.out,
                    ct::PushKeyboardEnhancementFlags(
                        ct::KeyboardEnhancementFlags::DISAMBIGUATE_ESCAPE_CODES
                            | ct::KeyboardEnhancementFlags::REPORT_EVENT_TYPES
                    )
                )?;
                s.enhanced = true;
            }
        }
        Ok(guard)
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, GuardState> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Put the terminal back now (idempotent); reports errors that `Drop` would swallow.
    pub fn restore(&self) -> io::Result<()> {
        self.lock().restore()
    }
}

impl Drop for TerminalGuard {
    fn drop(&mut self) {
        let _ = self.lock().restore();
        // The hook cannot be changed while panicking (that would abort); ours is harmless then.
        if !std::thread::panicking() {
            let prev = Arc::clone(&self.prev_hook);
            std::panic::set_hook(Box::new(move |info| prev(info)));
        }
    }
}

/// Writes the operator's keys as a replay script.
struct Recorder {
    path: PathBuf,
    file: File,
}

impl Recorder {
    fn create(path: &Path) -> Result<Recorder, TuiError> {
        let err = |source| TuiError::Record {
            path: path.to_path_buf(),
            source,
        };
        let mut file = File::create(path).map_err(err)?;
        writeln!(
            file,
            "# mavterm key recording: replay with --headless --input FILE"
        )
        .map_err(err)?;
        Ok(Recorder {
            path: path.to_path_buf(),
            file,
        })
    }

    fn key(&mut self, t: Micros, key: Key) -> Result<(), TuiError> {
        // Line by line, so a crash keeps everything typed before it.
        writeln!(self.file, "{}", key_line(t, key)).map_err(|source| TuiError::Record {
            path: self.path.clone(),
            source,
        })
    }
}

/// The terminal as the driver's front end: keys and resizes from crossterm's event stream (no
/// polling), signals that end the session, and drawing at most `fps` times a second, only when
/// the core changed something.
struct TerminalFrontend<B: Backend, C: Clock> {
    terminal: Terminal<B>,
    events: crossterm::event::EventStream,
    signals: Signals,
    recorder: Option<Recorder>,
    theme: Theme,
    clock: C,
    period: Micros,
    last_draw: Option<Micros>,
}

/// The signals that end a session with the terminal restored: SIGTERM, SIGHUP (the SSH
/// connection dropped), SIGQUIT and SIGINT (raw mode turns Ctrl-C into a key; a `kill -INT`
/// still arrives as a signal).
struct Signals {
    #[cfg(unix)]
    all: Vec<tokio::signal::unix::Signal>,
}

impl Signals {
    fn new() -> io::Result<Signals> {
        #[cfg(unix)]
        {
            use tokio::signal::unix::{signal, SignalKind};
            let kinds = [
                SignalKind::terminate(),
                SignalKind::hangup(),
                SignalKind::quit(),
                SignalKind::interrupt(),
            ];
            let all = kinds.into_iter().map(signal).collect::<io::Result<_>>()?;
            Ok(Signals { all })
        }
        #[cfg(not(unix))]
        Ok(Signals {})
    }

    /// Resolves when any of the signals arrives.
    async fn recv(&mut self) {
        #[cfg(unix)]
        {
            let futs = self.all.iter_mut().map(|s| Box::pin(s.recv()));
            let _ = futures_util::future::select_all(futs).await;
        }
        #[cfg(not(unix))]
        {
            let _ = tokio::signal::ctrl_c().await;
        }
    }
}

impl<B: Backend + Send, C: Clock + Send> Frontend for TerminalFrontend<B, C>
where
    B::Error: Into<io::Error>,
{
    async fn next_input(&mut self) -> io::Result<Option<Event>> {
        use futures_util::StreamExt;
        loop {
            let ev = tokio::select! {
                ev = self.events.next() => ev,
                _ = self.signals.recv() => return Ok(None),
            };
            match ev {
                Some(Ok(ct::Event::Key(k))) if k.kind == KeyEventKind::Release => {
                    let pressed = ct::KeyEvent::new(k.code, k.modifiers);
                    if let Some(key) = key_from_crossterm(pressed) {
                        return Ok(Some(Event::KeyRelease(key)));
                    }
                }
                Some(Ok(ct::Event::Key(k))) => {
                    if let Some(key) = key_from_crossterm(k) {
                        if let Some(r) = self.recorder.as_mut() {
                            r.key(self.clock.now(), key).map_err(io::Error::other)?;
                        }
                        return Ok(Some(Event::Key(key)));
                    }
                }
                Some(Ok(ct::Event::Resize(..))) => return Ok(Some(Event::Resize)),
                Some(Ok(_)) => {}
                Some(Err(e)) => return Err(e),
                None => return Ok(None),
            }
        }
    }

    fn wake_at(&self, app: &App) -> Option<Micros> {
        // A change held back by the frame-rate cap, and the clock on screen (whole seconds).
        let next_second = (app.now / SECOND + 1) * SECOND;
        match (app.is_dirty(), self.last_draw) {
            (true, Some(t)) => Some((t + self.period).min(next_second)),
            _ => Some(next_second),
        }
    }

    fn after(&mut self, app: &mut App, now: Micros) -> io::Result<()> {
        if self.last_draw.is_some_and(|t| now < t + self.period) && app.is_dirty() {
            return Ok(()); // drawn moments ago: draw at wake_at
        }
        if draw_if_dirty(&mut self.terminal, app, &self.theme).map_err(Into::into)? {
            self.last_draw = Some(now);
        }
        Ok(())
    }
}

/// Run the terminal UI on `rt` (the core and its links) until the operator quits, the input ends
/// or a signal (SIGTERM, SIGHUP, SIGQUIT, SIGINT) arrives, returning the final state. The
/// terminal is restored on every way out.
pub async fn run_terminal<C: Clock + Clone + Send>(
    mut rt: RealTime<C>,
    opts: TuiOptions,
) -> Result<App, TuiError> {
    let recorder = opts.record.as_deref().map(Recorder::create).transpose()?;
    let guard = TerminalGuard::enter()?;
    // No `terminal.clear()`: it asks the terminal for the cursor position, which fails (times
    // out) on terminals that do not answer; the guard already cleared the alternate screen.
    let terminal = Terminal::new(CrosstermBackend::new(io::stdout()))?;
    let mut front = TerminalFrontend {
        terminal,
        events: crossterm::event::EventStream::new(),
        signals: Signals::new()?,
        recorder,
        theme: opts.theme,
        clock: rt.clock(),
        period: SECOND / u64::from(opts.fps.clamp(1, 120)),
        last_draw: None,
    };
    let result = rt.run(None, &mut front).await;
    drop(front);
    let restored = guard.restore();
    // The telemetry log written out and flushed, whichever way the loop ended (an error too).
    rt.finish();
    restored?;
    result?;
    Ok(rt.app)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recording_is_a_replayable_script() {
        use crate::headless::script::{Script, Step};
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("keys.txt");
        let mut r = Recorder::create(&path).unwrap();
        let keys = ["tab", "ctrl-p", "#", "space", "?", "backtab"];
        for (i, k) in keys.iter().enumerate() {
            r.key(520_000 + i as u64 * 1_000, k.parse().unwrap())
                .unwrap();
        }
        drop(r);
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.contains("\n0.52 key tab\n"), "{text}");
        let script = Script::load(&path).unwrap();
        let back: Vec<(Micros, Step)> = script.steps.into_iter().map(|s| (s.t, s.step)).collect();
        let want: Vec<(Micros, Step)> = keys
            .iter()
            .enumerate()
            .map(|(i, k)| (520_000 + i as u64 * 1_000, Step::Key(k.parse().unwrap())))
            .collect();
        assert_eq!(back, want);
        assert!(matches!(
            Recorder::create(&dir.path().join("no/such/dir.txt")),
            Err(TuiError::Record { .. })
        ));
    }

    fn ev(code: ct::KeyCode, m: KeyModifiers) -> ct::KeyEvent {
        ct::KeyEvent::new(code, m)
    }

    #[test]
    fn crossterm_keys_become_keymap_keys() {
        let k = |code, m| key_from_crossterm(ev(code, m)).map(|k| k.to_string());
        assert_eq!(
            k(ct::KeyCode::Char('q'), KeyModifiers::NONE).as_deref(),
            Some("q")
        );
        assert_eq!(
            k(ct::KeyCode::Char('G'), KeyModifiers::SHIFT).as_deref(),
            Some("G")
        );
        assert_eq!(
            k(ct::KeyCode::Char('C'), KeyModifiers::CONTROL).as_deref(),
            Some("ctrl-c")
        );
        assert_eq!(
            k(ct::KeyCode::Tab, KeyModifiers::SHIFT).as_deref(),
            Some("backtab")
        );
        assert_eq!(
            k(ct::KeyCode::BackTab, KeyModifiers::SHIFT).as_deref(),
            Some("backtab")
        );
        assert_eq!(
            k(ct::KeyCode::Char(' '), KeyModifiers::NONE).as_deref(),
            Some("space")
        );
        assert_eq!(
            k(ct::KeyCode::F(5), KeyModifiers::ALT).as_deref(),
            Some("alt-f5")
        );
        assert_eq!(k(ct::KeyCode::CapsLock, KeyModifiers::NONE), None);
        let mut release = ev(ct::KeyCode::Char('q'), KeyModifiers::NONE);
        release.kind = KeyEventKind::Release;
        assert_eq!(key_from_crossterm(release), None);
    }
}
