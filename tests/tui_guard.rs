//! The terminal guard puts the terminal back on drop, on error and on panic, and chains to the
//! previous panic hook. One test function: panic hooks are process-global.

use std::io::Write;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use mavterm::tui::TerminalGuard;

const ENTER_ALT: &str = "\x1b[?1049h";
const LEAVE_ALT: &str = "\x1b[?1049l";
const SHOW_CURSOR: &str = "\x1b[?25h";

#[derive(Clone, Default)]
struct Shared(Arc<Mutex<Vec<u8>>>);

impl Write for Shared {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(b);
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Shared {
    fn text(&self) -> String {
        String::from_utf8_lossy(&self.0.lock().unwrap()).into_owned()
    }
}

static PREV_HOOK_CALLS: AtomicUsize = AtomicUsize::new(0);

fn fails(_g: &TerminalGuard) -> Result<(), String> {
    Err("link manager died".into())
}

#[test]
fn guard_restores_on_drop_error_and_panic() {
    std::panic::set_hook(Box::new(|_| {
        PREV_HOOK_CALLS.fetch_add(1, Ordering::SeqCst);
    }));

    // Normal exit.
    let out = Shared::default();
    let guard = TerminalGuard::enter_with(Box::new(out.clone()), false).unwrap();
    assert!(out.text().contains(ENTER_ALT));
    assert!(!out.text().contains(LEAVE_ALT));
    drop(guard);
    assert!(
        out.text().ends_with(&format!("{LEAVE_ALT}{SHOW_CURSOR}")),
        "{:?}",
        out.text()
    );

    // After a normal drop the previous hook is back: a panic reaches it and writes nothing here.
    let before = out.text();
    assert!(std::panic::catch_unwind(|| panic!("after drop")).is_err());
    assert_eq!(PREV_HOOK_CALLS.load(Ordering::SeqCst), 1);
    assert_eq!(out.text(), before);

    // Error path: `?` out of a function holding the guard.
    let out = Shared::default();
    let run = || -> Result<(), String> {
        let guard = TerminalGuard::enter_with(Box::new(out.clone()), false).unwrap();
        fails(&guard)?;
        unreachable!()
    };
    assert!(run().is_err());
    assert_eq!(out.text().matches(LEAVE_ALT).count(), 1);

    // Panic: the hook restores before the previous hook (which prints the message) runs, and
    // the terminal is restored only once in all. The "previous hook" records what the screen
    // had received when it ran.
    let seen_by_prev_hook = Arc::new(Mutex::new(String::new()));
    let out = Shared::default();
    let probe_out = out.clone();
    let seen = Arc::clone(&seen_by_prev_hook);
    std::panic::set_hook(Box::new(move |_| {
        *seen.lock().unwrap() = probe_out.text();
        PREV_HOOK_CALLS.fetch_add(1, Ordering::SeqCst);
    }));
    let guard = TerminalGuard::enter_with(Box::new(out.clone()), false).unwrap();
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(move || {
        let _g = guard;
        panic!("boom");
    }));
    assert!(r.is_err());
    assert_eq!(
        PREV_HOOK_CALLS.load(Ordering::SeqCst),
        2,
        "previous hook chained"
    );
    let seen = seen_by_prev_hook.lock().unwrap().clone();
    assert!(
        seen.contains(LEAVE_ALT) && seen.contains(SHOW_CURSOR),
        "terminal restored before the panic message: {seen:?}"
    );
    assert_eq!(out.text().matches(LEAVE_ALT).count(), 1, "restored once");
}
