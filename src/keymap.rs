//! Keys and the actions they are bound to.
//!
//! The core never sees terminal events: front ends turn them into [`Key`], the keymap turns a
//! key into an [`Action`], and the core matches on the action.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

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
    /// Jump to the first row (oldest message).
    Top,
    /// Jump to the last row (newest message).
    Bottom,
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
            "expand/collapse the selected link, or target the selected vehicle",
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
        (Action::Top, "top", "jump to the first row"),
        (Action::Bottom, "bottom", "jump to the last row"),
    ];

    pub fn name(self) -> &'static str {
        Action::ALL
            .iter()
            .find(|(a, _, _)| *a == self)
            .map(|(_, n, _)| *n)
            .unwrap_or("?")
    }

    /// The action called `name` in keymap files.
    pub fn from_name(name: &str) -> Option<Action> {
        Action::ALL
            .iter()
            .find(|(_, n, _)| *n == name)
            .map(|(a, _, _)| *a)
    }

    /// One-line description for the help popup.
    pub fn description(self) -> &'static str {
        Action::ALL
            .iter()
            .find(|(a, _, _)| *a == self)
            .map(|(_, _, d)| *d)
            .unwrap_or("")
    }
}

/// A key name that means nothing to us.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown key `{0}` (try a, ?, tab, backtab, enter, esc, space, up, pageup, home, f1, ctrl-x, alt-x)")]
pub struct KeyParseError(pub String);

impl FromStr for Key {
    type Err = KeyParseError;

    /// Parses the names [`Key`]'s `Display` writes, plus a few aliases (`shift-tab`, `return`,
    /// `escape`, `del`, `pgup`, `pgdn`). Single characters are case-sensitive; names are not.
    /// `ctrl-` with a letter is normalised to lower case: terminals cannot tell them apart.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let err = || KeyParseError(s.to_string());
        let (mut ctrl, mut alt, mut shift) = (false, false, false);
        let mut rest = s;
        loop {
            let lower = rest.to_ascii_lowercase();
            let strip = |p: &str| lower.starts_with(p) && rest.len() > p.len();
            if strip("ctrl-") {
                ctrl = true;
                rest = &rest[5..];
            } else if strip("alt-") {
                alt = true;
                rest = &rest[4..];
            } else if strip("shift-") {
                shift = true;
                rest = &rest[6..];
            } else {
                break;
            }
        }
        let mut chars = rest.chars();
        let code = match (chars.next(), chars.next()) {
            (None, _) => return Err(err()),
            (Some(c), None) => {
                let c = if ctrl { c.to_ascii_lowercase() } else { c };
                if shift {
                    if !c.is_alphabetic() || ctrl {
                        return Err(err());
                    }
                    shift = false;
                    KeyCode::Char(c.to_uppercase().next().unwrap_or(c))
                } else {
                    KeyCode::Char(c)
                }
            }
            _ => {
                let name = rest.to_ascii_lowercase();
                match name.as_str() {
                    "tab" if shift => {
                        shift = false;
                        KeyCode::BackTab
                    }
                    "tab" => KeyCode::Tab,
                    "backtab" => KeyCode::BackTab,
                    "enter" | "return" => KeyCode::Enter,
                    "esc" | "escape" => KeyCode::Esc,
                    "space" => KeyCode::Char(' '),
                    "backspace" => KeyCode::Backspace,
                    "delete" | "del" => KeyCode::Delete,
                    "up" => KeyCode::Up,
                    "down" => KeyCode::Down,
                    "left" => KeyCode::Left,
                    "right" => KeyCode::Right,
                    "pageup" | "pgup" => KeyCode::PageUp,
                    "pagedown" | "pgdn" => KeyCode::PageDown,
                    "home" => KeyCode::Home,
                    "end" => KeyCode::End,
                    f if f.starts_with('f') => match f[1..].parse::<u8>() {
                        Ok(n @ 1..=24) => KeyCode::F(n),
                        _ => return Err(err()),
                    },
                    _ => return Err(err()),
                }
            }
        };
        if shift {
            return Err(err()); // shift only combines with letters and tab
        }
        Ok(Key { code, ctrl, alt })
    }
}

/// The built-in keymap, in the same format users write.
pub const DEFAULT_KEYMAP: &str = include_str!("../keymaps/default.toml");

/// Why a keymap file was refused. Every message names the file.
#[derive(Debug, thiserror::Error)]
pub enum KeymapError {
    #[error("keymap {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// The file is not valid TOML or not in the keymap format.
    #[error("keymap {origin}:{line}:{col}: {message}")]
    Syntax {
        origin: String,
        line: usize,
        col: usize,
        message: String,
    },
    /// Well-formed, but naming things that do not exist or binding one key twice. Lists every
    /// problem, not just the first, so one edit fixes the file.
    #[error("keymap {origin}: {}", problems.join("; "))]
    Invalid {
        origin: String,
        unknown_actions: Vec<String>,
        unknown_keys: Vec<String>,
        /// Keys bound to more than one action, as `key (action, action)`.
        duplicate_keys: Vec<String>,
        /// Each problem with its line and column.
        problems: Vec<String>,
    },
}

/// The file format: `[bindings]` table of action name → key names.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct KeymapFile {
    #[serde(default)]
    bindings: BTreeMap<toml::Spanned<String>, Vec<toml::Spanned<String>>>,
}

/// 1-based line and column of a byte offset.
fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

/// Key → action bindings.
#[derive(Debug, Clone)]
pub struct Keymap {
    pub bindings: BTreeMap<Key, Action>,
    /// Actions the source file listed (even with no keys): when layered on top of another keymap
    /// these replace that keymap's keys for the action, so `help = []` unbinds.
    listed: BTreeSet<Action>,
    /// Keys in the order the files listed them: the first key of an action is its hint.
    order: Vec<Key>,
}

impl Default for Keymap {
    fn default() -> Self {
        // A unit test parses the shipped file, so this cannot fail in a released binary.
        Keymap::from_toml(DEFAULT_KEYMAP, "<built-in default>").expect("built-in keymap is valid")
    }
}

impl Keymap {
    /// Parse a keymap file. `origin` names it in errors (usually the path).
    pub fn from_toml(text: &str, origin: &str) -> Result<Keymap, KeymapError> {
        let file: KeymapFile = toml::from_str(text).map_err(|e| {
            let (line, col) = line_col(text, e.span().map_or(0, |s| s.start));
            KeymapError::Syntax {
                origin: origin.to_string(),
                line,
                col,
                message: e.message().trim().to_string(),
            }
        })?;
        let at = |span: std::ops::Range<usize>| {
            let (l, c) = line_col(text, span.start);
            format!("line {l}, column {c}")
        };
        let mut unknown_actions = Vec::new();
        let mut unknown_keys = Vec::new();
        let mut problems = Vec::new();
        let mut bindings: BTreeMap<Key, Action> = BTreeMap::new();
        let mut clashes: BTreeMap<Key, BTreeSet<Action>> = BTreeMap::new();
        let mut listed = BTreeSet::new();
        let mut order = Vec::new();
        // In file order, so problems are listed top to bottom.
        let mut entries: Vec<_> = file.bindings.iter().collect();
        entries.sort_by_key(|(name, _)| name.span().start);
        for (name, keys) in entries {
            let action = Action::from_name(name.get_ref());
            match action {
                Some(a) => {
                    listed.insert(a);
                }
                None => {
                    unknown_actions.push(name.get_ref().clone());
                    problems.push(format!(
                        "{}: unknown action `{}`",
                        at(name.span()),
                        name.get_ref()
                    ));
                }
            }
            for k in keys {
                match k.get_ref().parse::<Key>() {
                    Err(_) => {
                        unknown_keys.push(k.get_ref().clone());
                        problems.push(format!("{}: unknown key `{}`", at(k.span()), k.get_ref()));
                    }
                    Ok(key) => {
                        let Some(action) = action else { continue };
                        order.push(key);
                        match bindings.insert(key, action) {
                            Some(prev) if prev != action => {
                                let set = clashes.entry(key).or_default();
                                set.insert(prev);
                                set.insert(action);
                                problems.push(format!(
                                    "{}: key `{key}` is already bound to `{}`",
                                    at(k.span()),
                                    prev.name()
                                ));
                            }
                            _ => {}
                        }
                    }
                }
            }
        }
        let duplicate_keys: Vec<String> = clashes
            .iter()
            .map(|(k, acts)| {
                let names: Vec<&str> = acts.iter().map(|a| a.name()).collect();
                format!("{k} ({})", names.join(", "))
            })
            .collect();
        if !problems.is_empty() {
            return Err(KeymapError::Invalid {
                origin: origin.to_string(),
                unknown_actions,
                unknown_keys,
                duplicate_keys,
                problems,
            });
        }
        Ok(Keymap {
            bindings,
            listed,
            order,
        })
    }

    /// Read a keymap file (no layering).
    pub fn from_file(path: &Path) -> Result<Keymap, KeymapError> {
        let text = std::fs::read_to_string(path).map_err(|source| KeymapError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Keymap::from_toml(&text, &path.display().to_string())
    }

    /// The default keymap with the user's file at `path` layered on top.
    pub fn load(path: &Path) -> Result<Keymap, KeymapError> {
        Ok(Keymap::default().with_overrides(&Keymap::from_file(path)?))
    }

    /// The keymap to run with: `explicit` (`--keymap FILE`, must exist) or else the user's
    /// `$XDG_CONFIG_HOME/mavterm/keymap.toml` / `~/.config/mavterm/keymap.toml` if present,
    /// layered on the default.
    pub fn load_user(explicit: Option<&Path>) -> Result<Keymap, KeymapError> {
        if let Some(p) = explicit {
            return Keymap::load(p);
        }
        match Keymap::user_path() {
            Some(p) if p.is_file() => Keymap::load(&p),
            _ => Ok(Keymap::default()),
        }
    }

    /// Where the user's keymap lives by default.
    pub fn user_path() -> Option<PathBuf> {
        let base = std::env::var_os("XDG_CONFIG_HOME")
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
            .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".config")))?;
        Some(base.join("mavterm").join("keymap.toml"))
    }

    /// `self` with `over` on top: each action `over` lists loses its keys here and gets
    /// `over`'s; a key `over` binds is taken from whatever action had it.
    pub fn with_overrides(mut self, over: &Keymap) -> Keymap {
        self.bindings
            .retain(|k, a| !over.listed.contains(a) && !over.bindings.contains_key(k));
        self.bindings
            .extend(over.bindings.iter().map(|(k, a)| (*k, *a)));
        self.listed.extend(over.listed.iter().copied());
        let mut order = over.order.clone();
        order.extend(self.order.iter().filter(|k| !over.order.contains(k)));
        self.order = order;
        self
    }

    pub fn lookup(&self, key: &Key) -> Option<Action> {
        self.bindings.get(key).copied()
    }

    /// Keys bound to `action`, in the order the keymap file lists them (the first makes the
    /// hint); keys added to `bindings` by hand come last.
    pub fn keys_for(&self, action: Action) -> Vec<Key> {
        let bound = |k: &Key| self.bindings.get(k) == Some(&action);
        let mut keys: Vec<Key> = Vec::new();
        for k in self.order.iter().chain(self.bindings.keys()) {
            if bound(k) && !keys.contains(k) {
                keys.push(*k);
            }
        }
        keys
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_keymaps_parse_and_bind_every_action() {
        for (name, text) in [
            ("default.toml", DEFAULT_KEYMAP),
            ("vim.toml", include_str!("../keymaps/vim.toml")),
        ] {
            let km = Keymap::from_toml(text, name).unwrap_or_else(|e| panic!("{e}"));
            for (action, aname, _) in Action::ALL {
                assert!(
                    !km.keys_for(*action).is_empty(),
                    "{name}: `{aname}` unbound"
                );
            }
        }
    }

    #[test]
    fn default_keeps_the_original_bindings() {
        let km = Keymap::default();
        for (k, a) in [
            (Key::ch('q'), Action::Quit),
            (Key::ctrl('c'), Action::Quit),
            (Key::plain(KeyCode::Tab), Action::FocusNext),
            (Key::plain(KeyCode::BackTab), Action::FocusPrev),
            (Key::plain(KeyCode::Enter), Action::ToggleExpand),
            (Key::ch('n'), Action::NextVehicle),
            (Key::ch('p'), Action::PrevVehicle),
            (Key::ch('?'), Action::Help),
            (Key::plain(KeyCode::Esc), Action::Cancel),
        ] {
            assert_eq!(km.lookup(&k), Some(a), "{k}");
        }
        assert_eq!(
            km.keys_for(Action::Quit),
            vec![Key::ch('q'), Key::ctrl('c')]
        );
    }

    #[test]
    fn line_col_counts_from_one() {
        assert_eq!(line_col("ab\ncd", 0), (1, 1));
        assert_eq!(line_col("ab\ncd", 4), (2, 2));
    }
}
