//! The one list of full screens, in number-key order: the only place a screen is named.
//!
//! Each line is a screen's contract: its number key (`screen_N`, bound to `N` in the default
//! keymap), its name (its `[normal.NAME]` keymap section and its file `ui/NAME.rs`, whose
//! `pub fn render` draws it), its title (help, status), what its number key does (the help's
//! description of `screen_N`), and optionally the core's selection for it (`select =` an
//! `App` method taking the step; without one the arrow keys move in the focused pane) and a
//! note below its keys in the help (`note =` a constant of `app::screen`).
//!
//! Every layer expands this list with [`for_each_screen!`]: `keymap` (the section names and
//! the `screen_N` actions), `app::screen` (the core's `SCREENS`, number
//! keys and selection), `ui` (the screens' modules) and `ui::screens` (the renderers). Adding a
//! screen: its file `ui/NAME.rs` with `pub fn render`, one line here, and its number key
//! (`screen_N = ["N"]`) in `keymaps/default.toml`.

/// Calls the macro `$then` with the list of screens (see the module doc for the fields).
#[macro_export]
macro_rules! for_each_screen {
    ($then:ident) => {
        $then! {
            1 overview "Overview" "show the overview screen";
            2 parameters "Parameters" "show the parameters screen"
                select = select_parameters note = PARAM_MARKS;
            3 commands "Commands" "show the commands screen" select = select_commands;
            4 inspector "MAVLink Inspector" "show the message inspector"
                select = select_inspector;
            5 mission "Mission" "show the mission screen" select = select_mission;
            6 camera "Camera" "show the camera screen";
            7 logs "Logs" "show the onboard logs screen" select = select_logs;
            8 health "Health" "show the health screen: pre-arm, sensors, calibrations";
            9 map "Map" "show the map" select = select_map;
        }
    };
}
