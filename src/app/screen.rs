//! The full screens the core knows, switched by number keys (`screen_N` in keymaps).
//!
//! A screen is its state here (selection, scroll) and one file in `ui/` that draws it, registered
//! in `ui::screens`. Adding one: a line below, a `[normal.NAME]` keymap section for its own keys
//! (the name must be one of `keymap::SCREENS`, which fixes its number key), and its ui file.

/// One screen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Screen {
    /// Its name in keymaps and in `ui::screens`.
    pub name: &'static str,
    pub title: &'static str,
}

/// The screens in this build, the first shown at start.
pub const SCREENS: &[Screen] = &[
    Screen {
        name: "overview",
        title: "Overview",
    },
    Screen {
        name: "parameters",
        title: "Parameters",
    },
    Screen {
        name: "commands",
        title: "Commands",
    },
    Screen {
        name: "inspector",
        title: "MAVLink Inspector",
    },
    Screen {
        name: "mission",
        title: "Mission",
    },
    Screen {
        name: "camera",
        title: "Camera",
    },
];

/// The screen called `name`, if this build has it.
pub fn by_name(name: &str) -> Option<&'static Screen> {
    SCREENS.iter().find(|s| s.name == name)
}
