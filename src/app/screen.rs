//! The full screens the core knows, switched by number keys (`screen_N` in keymaps): the core's
//! side of the one screen list ([`crate::screen_list`]).
//!
//! A screen's contract is its line there: name, number key, title, keys section, selection and
//! help note live in [`Screen`], its drawing in `ui/NAME.rs` (bound by `ui::screens`). The view
//! state a screen keeps (selection, scroll) lives in [`super::UiState`] so replays reproduce it.

use super::App;
use crate::keymap::{Action, Section};

/// One screen.
#[derive(Debug, Clone, Copy)]
pub struct Screen {
    /// Its name in keymaps (`[normal.NAME]`) and its file in `ui/`.
    pub name: &'static str,
    pub title: &'static str,
    /// Its number key: `screen_N` shows it.
    pub number: u8,
    /// Moves its own selection by a step (clamped at the ends); `None`: the arrow keys move in
    /// the focused pane.
    pub select: Option<fn(&mut App, isize)>,
    /// A note below its keys in the help.
    pub help_note: Option<&'static str>,
}

impl PartialEq for Screen {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
    }
}

impl Eq for Screen {}

impl Screen {
    /// The action of its number key.
    pub fn action(&self) -> Action {
        Action::Screen(self.number - 1)
    }

    /// Its keymap section, `[normal.NAME]` (by its place in the list: numbers may skip).
    pub fn section(&self) -> Section {
        let i = crate::keymap::SCREENS.iter().position(|n| *n == self.name);
        Section::Screen(i.unwrap_or(usize::from(self.number - 1)))
    }
}

/// The Parameters screen's marks, below its keys in the help.
pub const PARAM_MARKS: &str = "marks: * changed since the download, ≠ differs from the loaded \
file, … edit sent, ✓ confirmed by the vehicle, ✗ failed (why: in the detail pane)";

macro_rules! core_screens {
    (@select) => { None };
    (@select $sel:ident) => { Some(App::$sel as fn(&mut App, isize)) };
    (@note) => { None };
    (@note $note:ident) => { Some($note) };
    ($( $n:literal $name:ident $title:literal $what:literal
        $(select = $sel:ident)? $(note = $note:ident)? ;)*) => {
        /// The screens in this build, in number-key order, the first shown at start.
        pub const SCREENS: &[Screen] = &[$(Screen {
            name: stringify!($name),
            title: $title,
            number: $n,
            select: core_screens!(@select $($sel)?),
            help_note: core_screens!(@note $($note)?),
        }),*];
    };
}
crate::for_each_screen!(core_screens);

/// The screen called `name`, if this build has it.
pub fn by_name(name: &str) -> Option<&'static Screen> {
    SCREENS.iter().find(|s| s.name == name)
}

/// The screen number key `screen_{i+1}` shows, if this build has it.
pub fn by_action_index(i: usize) -> Option<&'static Screen> {
    SCREENS.iter().find(|s| usize::from(s.number) == i + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_list_is_in_number_key_order_and_names_the_keymap_sections() {
        for (i, s) in SCREENS.iter().enumerate() {
            // Number keys rise along the list (screens of other builds may leave gaps).
            assert!(i == 0 || SCREENS[i - 1].number < s.number, "{}", s.name);
            assert_eq!(crate::keymap::SCREENS[i], s.name);
            assert_eq!(s.section().to_string(), format!("[normal.{}]", s.name));
        }
        assert_eq!(crate::keymap::SCREENS.len(), SCREENS.len());
    }
}
