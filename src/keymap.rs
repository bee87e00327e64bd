//! Keys and the actions they are bound to.
//!
//! The core never sees terminal events: front ends turn them into [`Key`], the keymap turns a
//! key into an [`Action`], and the core matches on the action.

use std::collections::BTreeMap;
use std::fmt;

/// A key as the core sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Key {
    pub code: KeyCode,
    pub ctrl: bool,
    pub alt: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum KeyCode {
    Char(char),
    Enter,
    Esc,
    Tab,
    BackTab,
    Backspace,
    Delete,
    Up,
    Down,
    Left,
    Right,
    PageUp,
    PageDown,
    Home,
    End,
    F(u8),
}

impl Key {
    pub const fn plain(code: KeyCode) -> Self {
        Key {
            code,
            ctrl: false,
            alt: false,
        }
    }
    pub const fn ch(c: char) -> Self {
        Key::plain(KeyCode::Char(c))
    }
    pub const fn ctrl(c: char) -> Self {
        Key {
            code: KeyCode::Char(c),
            ctrl: true,
            alt: false,
        }
    }
}

impl fmt::Display for Key {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.ctrl {
            write!(f, "ctrl-")?;
        }
        if self.alt {
            write!(f, "alt-")?;
        }
        match self.code {
            KeyCode::Char(' ') => write!(f, "space"),
            KeyCode::Char(c) => write!(f, "{c}"),
            KeyCode::Enter => write!(f, "enter"),
            KeyCode::Esc => write!(f, "esc"),
            KeyCode::Tab => write!(f, "tab"),
            KeyCode::BackTab => write!(f, "backtab"),
            KeyCode::Backspace => write!(f, "backspace"),
            KeyCode::Delete => write!(f, "delete"),
            KeyCode::Up => write!(f, "up"),
            KeyCode::Down => write!(f, "down"),
            KeyCode::Left => write!(f, "left"),
            KeyCode::Right => write!(f, "right"),
            KeyCode::PageUp => write!(f, "pageup"),
            KeyCode::PageDown => write!(f, "pagedown"),
            KeyCode::Home => write!(f, "home"),
            KeyCode::End => write!(f, "end"),
            KeyCode::F(n) => write!(f, "f{n}"),
        }
    }
}

/// Everything a key can be bound to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Action {
    Quit,
    FocusNext,
    FocusPrev,
    Up,
    Down,
    PageUp,
    PageDown,
    /// Expand or collapse the selected link's per-source rows.
    ToggleExpand,
    NextVehicle,
    PrevVehicle,
    Help,
    Cancel,
}

impl Action {
    /// Every bindable action with its name in keymap files and a short description.
    pub const ALL: &'static [(Action, &'static str, &'static str)] = &[
        (Action::Quit, "quit", "quit mavterm"),
        (Action::FocusNext, "focus_next", "focus the next pane"),
        (Action::FocusPrev, "focus_prev", "focus the previous pane"),
        (Action::Up, "up", "move the selection up"),
        (Action::Down, "down", "move the selection down"),
        (Action::PageUp, "page_up", "scroll up a page"),
        (Action::PageDown, "page_down", "scroll down a page"),
        (
            Action::ToggleExpand,
            "toggle_expand",
            "expand/collapse the selected link",
        ),
        (
            Action::NextVehicle,
            "next_vehicle",
            "target the next vehicle",
        ),
        (
            Action::PrevVehicle,
            "prev_vehicle",
            "target the previous vehicle",
        ),
        (Action::Help, "help", "show/hide key help"),
        (Action::Cancel, "cancel", "close the open dialog"),
    ];

    pub fn name(self) -> &'static str {
        Action::ALL
            .iter()
            .find(|(a, _, _)| *a == self)
            .map(|(_, n, _)| *n)
            .unwrap_or("?")
    }
}

/// Key → action bindings.
#[derive(Debug, Clone)]
pub struct Keymap {
    pub bindings: BTreeMap<Key, Action>,
}

impl Default for Keymap {
    fn default() -> Self {
        use KeyCode::*;
        let b = [
            (Key::ch('q'), Action::Quit),
            (Key::ctrl('c'), Action::Quit),
            (Key::plain(Tab), Action::FocusNext),
            (Key::plain(BackTab), Action::FocusPrev),
            (Key::plain(Up), Action::Up),
            (Key::plain(Down), Action::Down),
            (Key::plain(PageUp), Action::PageUp),
            (Key::plain(PageDown), Action::PageDown),
            (Key::plain(Enter), Action::ToggleExpand),
            (Key::ch('n'), Action::NextVehicle),
            (Key::ch('p'), Action::PrevVehicle),
            (Key::ch('?'), Action::Help),
            (Key::plain(Esc), Action::Cancel),
        ];
        Keymap {
            bindings: b.into_iter().collect(),
        }
    }
}

impl Keymap {
    pub fn lookup(&self, key: &Key) -> Option<Action> {
        self.bindings.get(key).copied()
    }
    /// Keys bound to `action`, for hints and help.
    pub fn keys_for(&self, action: Action) -> Vec<Key> {
        self.bindings
            .iter()
            .filter(|(_, a)| **a == action)
            .map(|(k, _)| *k)
            .collect()
    }
}
