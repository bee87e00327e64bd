//! The terminal front end: crossterm input, ratatui output, the core in between.
//!
//! The terminal is put back (alternate screen left, cursor shown, raw mode off) on every way
//! out: normal return, error, Ctrl-C, SIGTERM, SIGHUP, SIGQUIT, SIGINT, and panic (a panic hook
//! restores first, then runs the previous hook so the message lands on a sane screen). Ctrl-Z (the
//! `suspend` action; raw mode turns it into a key) and a `kill -TSTP` give the terminal back and
//! stop the process as a shell expects; `fg` (SIGCONT) takes it again and redraws it all. Redraws
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
use crate::headless::script::{format_secs, key_line};
use crate::keymap::{Key, KeyCode};
use crate::ui::{self, Theme};

/// Front-end settings.
#[derive(Debug, Clone)]
pub struct TuiOptions {
    /// Most redraws per second.
    pub fps: u32,
    /// Write the operator's keys to this file in the replay script format.
    pub record: Option<PathBuf>,
    /// The links of the session, for the recording's `# link` lines.
    pub links: Vec<String>,
    pub theme: Theme,
}

impl Default for TuiOptions {
    fn default() -> Self {
        Self {
            fps: 10,
            record: None,
            links: Vec::new(),
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
    /// The terminal reports key releases: asked for again when the terminal is taken back.
    can_enhance: bool,
}

impl GuardState {
    /// Raw mode, the alternate screen cleared, the cursor hidden, key releases asked for where
    /// the terminal reports them.
    fn enter(&mut self) -> io::Result<()> {
        self.active = true;
        if self.raw {
            enable_raw_mode()?; // on error, drop restores what was done
        }
        crossterm::execute!(
            self.out,
            EnterAlternateScreen,
            crossterm::terminal::Clear(crossterm::terminal::ClearType::All),
            crossterm::cursor::Hide,
            // A paste comes as one event, not as keys (which it could be taken for).
            ct::EnableBracketedPaste
        )?;
        if self.can_enhance {
            self.enhance()?;
        }
        Ok(())
    }

    /// Key releases, where the terminal can report them (the kitty keyboard protocol): Fly mode
    /// stops a nudge the moment its key is let go.
    fn enhance(&mut self) -> io::Result<()> {
        crossterm::execute!(
            self.out,
            ct::PushKeyboardEnhancementFlags(
                ct::KeyboardEnhancementFlags::DISAMBIGUATE_ESCAPE_CODES
                    | ct::KeyboardEnhancementFlags::REPORT_EVENT_TYPES
            )
        )?;
        self.enhanced = true;
        Ok(())
    }

    fn restore(&mut self) -> io::Result<()> {
        if !std::mem::take(&mut self.active) {
            return Ok(());
        }
        // Raw mode first: even if the writes fail the shell gets its line discipline back.
        let raw = if self.raw { disable_raw_mode() } else { Ok(()) };
        if std::mem::take(&mut self.enhanced) {
            let _ = crossterm::execute!(self.out, ct::PopKeyboardEnhancementFlags);
        }
        crossterm::execute!(
            self.out,
            ct::DisableBracketedPaste,
            LeaveAlternateScreen,
            crossterm::cursor::Show
        )?;
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
            can_enhance: false,
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
                // terminal we just gave back: the session ends instead (the UI draws no more),
                // through the wind-down, so a nudge in progress ends in its stop on the links
                // still up; then the program exits with 101. A UI that does not get there
                // within a second is ended regardless.
                if restored && std::thread::current().id() != ui_thread {
                    LINK_PANICKED.store(true, std::sync::atomic::Ordering::SeqCst);
                    link_panic().notify_one();
                    std::thread::spawn(|| {
                        std::thread::sleep(std::time::Duration::from_secs(1));
                        std::process::exit(101);
                    });
                }
            }));
        }
        let guard = TerminalGuard { state, prev_hook };
        {
            let mut s = guard.lock();
            s.enter()?;
            if raw_mode && crossterm::terminal::supports_keyboard_enhancement().unwrap_or(false) {
                s.can_enhance = true;
                s.enhance()?;
            }
        }
        Ok(guard)
    }

    /// A handle the front end keeps to suspend and refresh the terminal this guard owns.
    fn handle(&self) -> GuardHandle {
        GuardHandle(Arc::clone(&self.state))
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, GuardState> {
        lock_state(&self.state)
    }

    /// Put the terminal back now (idempotent); reports errors that `Drop` would swallow.
    pub fn restore(&self) -> io::Result<()> {
        self.lock().restore()
    }
}

fn lock_state(state: &Mutex<GuardState>) -> std::sync::MutexGuard<'_, GuardState> {
    state.lock().unwrap_or_else(|p| p.into_inner())
}

/// Give the terminal back, stop the process as Ctrl-Z in a shell does (SIGTSTP), and once
/// continued (`fg`) take the terminal again. The caller redraws everything afterwards.
fn suspend_state(state: &Mutex<GuardState>) -> io::Result<()> {
    let was_active = {
        let mut s = lock_state(state);
        let was = s.active;
        s.restore()?;
        was
    };
    stop_self();
    if was_active {
        lock_state(state).enter()?;
    }
    Ok(())
}

/// Stop this process with SIGTSTP's default action (a handler for an outside `kill -TSTP` is set
/// aside for the moment and put back), returning once it is continued. In an orphaned process
/// group (no job-control shell above us) the kernel discards the signal and this returns at once.
#[cfg(unix)]
fn stop_self() {
    // SAFETY: plain libc calls on this process's own signal disposition, with initialised
    // `sigaction` values; the previous disposition is put back before returning.
    unsafe {
        let mut dfl: libc::sigaction = std::mem::zeroed();
        dfl.sa_sigaction = libc::SIG_DFL;
        libc::sigemptyset(&mut dfl.sa_mask);
        let mut old: libc::sigaction = std::mem::zeroed();
        let saved = libc::sigaction(libc::SIGTSTP, &dfl, &mut old) == 0;
        libc::raise(libc::SIGTSTP);
        if saved {
            libc::sigaction(libc::SIGTSTP, &old, std::ptr::null_mut());
        }
    }
}

#[cfg(not(unix))]
fn stop_self() {}

/// The guard's state, for the front end: suspend (Ctrl-Z, SIGTSTP) and take the terminal back
/// after an outside stop (SIGCONT).
struct GuardHandle(Arc<Mutex<GuardState>>);

impl GuardHandle {
    fn suspend(&self) -> io::Result<()> {
        suspend_state(&self.0)
    }

    /// After a stop we did not see coming (`kill -STOP`): the shell may have put the tty back in
    /// cooked mode and drawn on the screen; raw mode and the alternate screen again.
    fn retake(&self) -> io::Result<()> {
        let mut s = lock_state(&self.0);
        if !s.active {
            return Ok(());
        }
        if s.raw {
            // crossterm skips enabling when it believes raw mode is on: off, then on again.
            let _ = disable_raw_mode();
            enable_raw_mode()?;
        }
        crossterm::execute!(s.out, EnterAlternateScreen, crossterm::cursor::Hide)
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

/// Writes the session as a replay script: a header naming the links and the terminal size
/// (which `--headless --input` uses when none are given), the keys pressed and let go, the
/// terminal's resizes, and at the end a `snapshot final` then `quit`, so that replaying it shows
/// the screens the operator saw.
struct Recorder {
    path: PathBuf,
    file: File,
}

impl Recorder {
    fn create(path: &Path, links: &[String], size: (u16, u16)) -> Result<Recorder, TuiError> {
        let err = |source| TuiError::Record {
            path: path.to_path_buf(),
            source,
        };
        // A FIFO would block the start, a device would take the keys: refused before opening.
        crate::fsio::check_plain_target(path).map_err(err)?;
        let mut file = File::create(path).map_err(err)?;
        let mut head = format!(
            "# mavterm {} recording: replay with mavterm --headless --input FILE\n",
            env!("CARGO_PKG_VERSION")
        );
        for l in links {
            head.push_str(&format!("# link {l}\n"));
        }
        head.push_str(&format!("# size {}x{}\n", size.0, size.1));
        file.write_all(head.as_bytes()).map_err(err)?;
        Ok(Recorder {
            path: path.to_path_buf(),
            file,
        })
    }

    /// One line, written at once, so a crash keeps everything typed before it.
    fn line(&mut self, line: &str) -> Result<(), TuiError> {
        writeln!(self.file, "{line}").map_err(|source| TuiError::Record {
            path: self.path.clone(),
            source,
        })
    }

    fn key(&mut self, t: Micros, key: Key) -> Result<(), TuiError> {
        self.line(&key_line(t, key))
    }

    fn release(&mut self, t: Micros, key: Key) -> Result<(), TuiError> {
        self.line(&format!("{} release {key}", format_secs(t)))
    }

    fn resize(&mut self, t: Micros, size: (u16, u16)) -> Result<(), TuiError> {
        self.line(&format!("{} resize {}x{}", format_secs(t), size.0, size.1))
    }

    /// The end: the last screen, then quit.
    fn finish(&mut self, t: Micros) -> Result<(), TuiError> {
        let t = format_secs(t);
        self.line(&format!("{t} snapshot final"))?;
        self.line(&format!("{t} quit"))
    }
}

/// The terminal as the driver's front end: keys and resizes from crossterm's event stream (no
/// polling), signals that end the session, and drawing at most `fps` times a second, only when
/// the core changed something.
struct TerminalFrontend<B: Backend, C: Clock> {
    terminal: Terminal<B>,
    /// The terminal's events, read by [`read_terminal`] (see there).
    events: tokio::sync::mpsc::Receiver<io::Result<ct::Event>>,
    signals: Signals,
    recorder: Option<Recorder>,
    /// A key pressed, written once the core has handled it: the key that quits is not written
    /// (the recording ends with `snapshot final` and `quit` instead, which a replay can go past).
    pending_key: Option<(Micros, Key)>,
    /// When the quit key was pressed (the recording's end).
    quit_at: Option<Micros>,
    guard: GuardHandle,
    theme: Theme,
    clock: C,
    period: Micros,
    last_draw: Option<Micros>,
    /// When the operator last pressed a key, pasted or resized (the start counts as one).
    last_input: Micros,
    /// Input came since the last draw: drawn at once, not at the frame-rate cap.
    input_pending: bool,
    /// A suspend held back: `u64::MAX` while a nudge's stop is still being sent, then when the
    /// process may stop.
    suspend_after: Option<Micros>,
}

/// The terminal's events, read by a task of their own and handed over a bounded channel. The
/// loop waits on the channel: crossterm's `EventStream` polled afresh each time the loop wakes
/// for something else (a frame) interrupts and restarts its reader thread each time (an eventfd
/// write, a futex wake and a lock taken by spinning), which was most of what an idle session cost.
fn read_terminal() -> (
    tokio::task::JoinHandle<()>,
    tokio::sync::mpsc::Receiver<io::Result<ct::Event>>,
) {
    use futures_util::StreamExt;
    let (tx, rx) = tokio::sync::mpsc::channel(256);
    let task = tokio::spawn(async move {
        let mut events = crossterm::event::EventStream::new();
        while let Some(ev) = events.next().await {
            if tx.send(ev).await.is_err() {
                return;
            }
        }
    });
    (task, rx)
}

/// No key for this long and no vehicle armed: the screen is only watched, and telemetry alone
/// redraws it at most every [`IDLE_PERIOD`].
pub const IDLE_AFTER: Micros = 10 * SECOND;

/// The time between redraws for telemetry alone on an idle screen (4 a second).
pub const IDLE_PERIOD: Micros = SECOND / 4;

/// The time between redraws for changes the core reports: `period` (the `--fps` cap) while the
/// operator is at the keys or any vehicle is armed, else at least [`IDLE_PERIOD`]. A key is
/// always drawn at once, whatever this says; the clock still turns every second.
pub fn draw_period(period: Micros, now: Micros, last_input: Micros, armed: bool) -> Micros {
    if armed || now.saturating_sub(last_input) < IDLE_AFTER {
        period
    } else {
        period.max(IDLE_PERIOD)
    }
}

/// After a nudge's last stop, the moment given to the link tasks to write it before the process
/// stops (as the wind-down's).
const SUSPEND_FLUSH: Micros = 50_000;

/// The signals that end a session with the terminal restored: SIGTERM, SIGHUP (the SSH
/// connection dropped), SIGQUIT and SIGINT (raw mode turns Ctrl-C into a key; a `kill -INT`
/// still arrives as a signal); and SIGTSTP (a `kill -TSTP`: suspend as Ctrl-Z does) and SIGCONT
/// (continued after a stop: take the terminal back and redraw).
struct Signals {
    #[cfg(unix)]
    end: Vec<tokio::signal::unix::Signal>,
    #[cfg(unix)]
    stop: tokio::signal::unix::Signal,
    #[cfg(unix)]
    cont: tokio::signal::unix::Signal,
}

/// Set by the panic hook when a thread other than the UI's panicked: the session winds down and
/// the program exits with 101.
static LINK_PANICKED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Wakes the front end when [`LINK_PANICKED`] is set.
fn link_panic() -> &'static tokio::sync::Notify {
    static N: std::sync::OnceLock<tokio::sync::Notify> = std::sync::OnceLock::new();
    N.get_or_init(tokio::sync::Notify::new)
}

/// What a signal asks of the session.
enum SignalAsk {
    End,
    Stop,
    Continued,
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
            let end = kinds.into_iter().map(signal).collect::<io::Result<_>>()?;
            let stop = signal(SignalKind::from_raw(libc::SIGTSTP))?;
            let cont = signal(SignalKind::from_raw(libc::SIGCONT))?;
            Ok(Signals { end, stop, cont })
        }
        #[cfg(not(unix))]
        Ok(Signals {})
    }

    /// Resolves when any of the signals arrives.
    async fn recv(&mut self) -> SignalAsk {
        #[cfg(unix)]
        {
            let futs = self.end.iter_mut().map(|s| Box::pin(s.recv()));
            tokio::select! {
                _ = futures_util::future::select_all(futs) => SignalAsk::End,
                _ = link_panic().notified() => SignalAsk::End,
                _ = self.stop.recv() => SignalAsk::Stop,
                _ = self.cont.recv() => SignalAsk::Continued,
            }
        }
        #[cfg(not(unix))]
        {
            let _ = tokio::signal::ctrl_c().await;
            SignalAsk::End
        }
    }
}

impl<B: Backend + Send, C: Clock + Send> TerminalFrontend<B, C>
where
    B::Error: Into<io::Error>,
{
    /// Forget what is on the screen (the guard cleared it when it took the terminal back): the
    /// next draw writes every cell. Not `Terminal::clear`, which asks the terminal for the cursor
    /// position and fails on terminals that do not answer: the buffer ratatui compares with is
    /// made blank instead (flushing a blank buffer, then swapping it in as the last frame).
    fn forget_screen(&mut self) -> io::Result<()> {
        self.terminal.current_buffer_mut().reset();
        self.terminal.flush().map_err(Into::into)?;
        self.terminal.swap_buffers();
        Ok(())
    }

    /// The terminal is now `size` (columns, rows). The viewport is fixed and changed only here,
    /// so a draw does not ask the terminal for its size (an open of /dev/tty and an ioctl each
    /// time).
    fn resize_to(&mut self, (w, h): (u16, u16)) -> io::Result<()> {
        self.terminal
            .resize(ratatui::layout::Rect::new(0, 0, w, h))
            .map_err(Into::into)
    }

    /// The time between redraws now: see [`draw_period`].
    fn draw_period(&self, app: &App) -> Micros {
        // Whether anything is armed is asked only once the keys have been idle.
        let idle = app.now.saturating_sub(self.last_input) >= IDLE_AFTER;
        draw_period(
            self.period,
            app.now,
            self.last_input,
            idle && app.any_armed(),
        )
    }

    /// The next event from the terminal or a signal (`None`: the session ends).
    async fn next_event(&mut self) -> io::Result<Option<Event>> {
        loop {
            let ev = tokio::select! {
                ev = self.events.recv() => ev,
                ask = self.signals.recv() => match ask {
                    SignalAsk::End => return Ok(None),
                    // Through the core, as Ctrl-Z: Fly mode ends in its stop before the
                    // process stops (see `after`).
                    SignalAsk::Stop => return Ok(Some(Event::Suspend)),
                    SignalAsk::Continued => {
                        self.guard.retake()?;
                        // The size may have changed while stopped.
                        if let Ok(size) = crossterm::terminal::size() {
                            self.resize_to(size)?;
                        }
                        self.forget_screen()?;
                        return Ok(Some(Event::Resize));
                    }
                },
            };
            match ev {
                Some(Ok(ct::Event::Key(k))) if k.kind == KeyEventKind::Release => {
                    let pressed = ct::KeyEvent::new(k.code, k.modifiers);
                    if let Some(key) = key_from_crossterm(pressed) {
                        self.record(|r, t| r.release(t, key))?;
                        return Ok(Some(Event::KeyRelease(key)));
                    }
                }
                Some(Ok(ct::Event::Key(k))) => {
                    if let Some(key) = key_from_crossterm(k) {
                        self.pending_key = Some((self.clock.now(), key));
                        // A repeat flies like a press but never answers a question.
                        if k.kind == KeyEventKind::Repeat {
                            return Ok(Some(Event::KeyRepeat(key)));
                        }
                        return Ok(Some(Event::Key(key)));
                    }
                }
                Some(Ok(ct::Event::Paste(text))) => return Ok(Some(Event::Paste(text))),
                Some(Ok(ct::Event::Resize(w, h))) => {
                    self.record(|r, t| r.resize(t, (w, h)))?;
                    self.resize_to((w, h))?;
                    return Ok(Some(Event::Resize));
                }
                Some(Ok(_)) => {}
                Some(Err(e)) => return Err(e),
                None => return Ok(None),
            }
        }
    }

    fn record(
        &mut self,
        f: impl FnOnce(&mut Recorder, Micros) -> Result<(), TuiError>,
    ) -> io::Result<()> {
        let now = self.clock.now();
        match self.recorder.as_mut() {
            Some(r) => f(r, now).map_err(io::Error::other),
            None => Ok(()),
        }
    }
}

impl<B: Backend + Send, C: Clock + Send> Frontend for TerminalFrontend<B, C>
where
    B::Error: Into<io::Error>,
{
    async fn next_input(&mut self) -> io::Result<Option<Event>> {
        let ev = self.next_event().await?;
        if matches!(
            ev,
            Some(
                Event::Key(_)
                    | Event::KeyRepeat(_)
                    | Event::KeyRelease(_)
                    | Event::Paste(_)
                    | Event::Resize
                    | Event::Suspend
            )
        ) {
            self.last_input = self.clock.now();
            self.input_pending = true;
        }
        Ok(ev)
    }

    fn wake_at(&self, app: &App) -> Option<Micros> {
        // A change held back by the frame-rate cap, and the clock on screen (whole seconds).
        let next_second = (app.now / SECOND + 1) * SECOND;
        let period = self.draw_period(app);
        let draw = match (app.is_dirty(), self.last_draw) {
            (true, _) if self.input_pending => app.now,
            (true, Some(t)) => (t + period).min(next_second),
            _ => next_second,
        };
        // A suspend held back for the nudge's last stop to be written.
        Some(match self.suspend_after {
            Some(t) if t != u64::MAX => draw.min(t),
            _ => draw,
        })
    }

    fn after(&mut self, app: &mut App, now: Micros) -> io::Result<()> {
        // The terminal was given back by a link task's panic: nothing more is drawn.
        if LINK_PANICKED.load(std::sync::atomic::Ordering::SeqCst) {
            return Ok(());
        }
        if let Some((t, key)) = self.pending_key.take() {
            if app.quit {
                self.quit_at = Some(t);
            } else if let Some(r) = self.recorder.as_mut() {
                r.key(t, key).map_err(io::Error::other)?;
            }
        }
        // A suspend waits for a nudge's stop to be sent in full (three copies, 100 ms apart),
        // then a moment for the link tasks to write the last one.
        if app.suspend && app.nudge.stopping() {
            self.suspend_after = Some(u64::MAX);
        } else if app.suspend && self.suspend_after == Some(u64::MAX) {
            self.suspend_after = Some(now + SUSPEND_FLUSH);
        }
        if app.suspend && self.suspend_after.is_none_or(|t| now >= t) {
            app.suspend = false;
            self.suspend_after = None;
            self.guard.suspend()?;
            self.forget_screen()?;
            self.terminal
                .draw(|f| ui::render_with(app, f, &self.theme))
                .map_err(Into::into)?;
            app.take_dirty();
            self.last_draw = Some(now);
            return Ok(());
        }
        let period = self.draw_period(app);
        if !self.input_pending && self.last_draw.is_some_and(|t| now < t + period) && app.is_dirty()
        {
            return Ok(()); // drawn moments ago: draw at wake_at
        }
        if draw_if_dirty(&mut self.terminal, app, &self.theme).map_err(Into::into)? {
            self.last_draw = Some(now);
            self.input_pending = false;
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
    let size = crossterm::terminal::size().unwrap_or((80, 24));
    let recorder = opts
        .record
        .as_deref()
        .map(|p| Recorder::create(p, &opts.links, size))
        .transpose()?;
    let guard = TerminalGuard::enter()?;
    // No `terminal.clear()`: it asks the terminal for the cursor position, which fails (times
    // out) on terminals that do not answer; the guard already cleared the alternate screen.
    // A fixed viewport, resized on the terminal's resize events (see `resize_to`).
    let terminal = Terminal::with_options(
        CrosstermBackend::new(io::stdout()),
        ratatui::TerminalOptions {
            viewport: ratatui::Viewport::Fixed(ratatui::layout::Rect::new(0, 0, size.0, size.1)),
        },
    )?;
    let reader = read_terminal();
    let mut front = TerminalFrontend {
        terminal,
        events: reader.1,
        signals: Signals::new()?,
        recorder,
        pending_key: None,
        quit_at: None,
        guard: guard.handle(),
        theme: opts.theme,
        clock: rt.clock(),
        period: SECOND / u64::from(opts.fps.clamp(1, 120)),
        last_draw: None,
        last_input: rt.clock().now(),
        input_pending: true,
        suspend_after: None,
    };
    let result = rt.run(None, &mut front).await;
    reader.0.abort();
    let end = front.quit_at.unwrap_or_else(|| front.clock.now());
    let recorded = match front.recorder.as_mut() {
        Some(r) => r.finish(end),
        None => Ok(()),
    };
    drop(front);
    let restored = guard.restore();
    // The telemetry log written out and flushed, whichever way the loop ended (an error too).
    rt.finish();
    if LINK_PANICKED.load(std::sync::atomic::Ordering::SeqCst) {
        // Wound down (the stop sent, logs flushed): the panic's exit code.
        std::process::exit(101);
    }
    restored?;
    result?;
    recorded?;
    Ok(rt.app)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_idle_screen_redraws_four_times_a_second_and_keys_or_armed_vehicles_keep_the_rate() {
        let fps10 = SECOND / 10;
        let t = 100 * SECOND;
        // At the keys lately: the --fps rate.
        assert_eq!(draw_period(fps10, t, t - 9 * SECOND, false), fps10);
        // Ten seconds without a key, nothing armed: 4 a second.
        assert_eq!(draw_period(fps10, t, t - IDLE_AFTER, false), SECOND / 4);
        // Armed: the full rate however long since a key.
        assert_eq!(draw_period(fps10, t, 0, true), fps10);
        // A cap slower than the idle rate is kept.
        assert_eq!(draw_period(SECOND / 2, t, 0, false), SECOND / 2);
    }

    #[test]
    fn recording_is_a_replayable_script() {
        use crate::headless::script::{Script, Step};
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("keys.txt");
        let links = vec![
            "sim://?seed=1".to_string(),
            "udpin:0.0.0.0:14550".to_string(),
        ];
        let mut r = Recorder::create(&path, &links, (100, 30)).unwrap();
        let keys = ["tab", "ctrl-p", "#", "space", "?", "backtab"];
        for (i, k) in keys.iter().enumerate() {
            r.key(520_000 + i as u64 * 1_000, k.parse().unwrap())
                .unwrap();
        }
        r.release(530_000, "up".parse().unwrap()).unwrap();
        r.resize(540_000, (80, 24)).unwrap();
        r.finish(2_500_000).unwrap();
        drop(r);
        let text = std::fs::read_to_string(&path).unwrap();
        let head: Vec<&str> = text.lines().take(4).collect();
        assert_eq!(
            head,
            [
                format!(
                    "# mavterm {} recording: replay with mavterm --headless --input FILE",
                    env!("CARGO_PKG_VERSION")
                )
                .as_str(),
                "# link sim://?seed=1",
                "# link udpin:0.0.0.0:14550",
                "# size 100x30"
            ]
        );
        assert!(text.contains("\n0.52 key tab\n"), "{text}");
        assert!(
            text.ends_with("\n0.53 release up\n0.54 resize 80x24\n2.5 snapshot final\n2.5 quit\n"),
            "{text}"
        );
        let script = Script::load(&path).unwrap();
        assert_eq!(script.size, Some((100, 30)));
        assert_eq!(
            script.links.iter().map(|l| l.1.clone()).collect::<Vec<_>>(),
            links
        );
        let back: Vec<(Micros, Step)> = script.steps.into_iter().map(|s| (s.t, s.step)).collect();
        let mut want: Vec<(Micros, Step)> = keys
            .iter()
            .enumerate()
            .map(|(i, k)| (520_000 + i as u64 * 1_000, Step::Key(k.parse().unwrap())))
            .collect();
        want.push((530_000, Step::Release("up".parse().unwrap())));
        want.push((540_000, Step::Resize(80, 24)));
        want.push((2_500_000, Step::Snapshot("final".into())));
        want.push((2_500_000, Step::Quit));
        assert_eq!(back, want);
        assert!(matches!(
            Recorder::create(&dir.path().join("no/such/dir.txt"), &[], (80, 24)),
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
