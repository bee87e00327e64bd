//! The screens' drawing: the ui's side of the one screen list ([`crate::screen_list`]). Each
//! screen `NAME` is drawn by `ui::NAME::render`, bound here by expanding that list.

use ratatui::layout::Rect;
use ratatui::Frame;

use super::{overview, Theme};
use crate::app::App;

/// Draws a screen into the area above the status bar.
pub type RenderFn = fn(&App, &mut Frame, Rect, &Theme);

macro_rules! ui_screens {
    ($( $n:literal $name:ident $title:literal $what:literal
        $(select = $sel:ident)? $(note = $note:ident)? ;)*) => {
        /// (screen name, renderer), in number-key order.
        pub const REGISTRY: &[(&str, RenderFn)] = &[$((stringify!($name), super::$name::render)),*];
    };
}
crate::for_each_screen!(ui_screens);

/// Draw the screen the core says is shown.
pub fn render(app: &App, frame: &mut Frame, body: Rect, theme: &Theme) {
    let f = REGISTRY
        .iter()
        .find(|(name, _)| *name == app.ui.screen)
        .map_or(overview::render as RenderFn, |(_, f)| *f);
    f(app, frame, body, theme);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_screen_of_the_core_has_a_renderer_and_a_keymap_name() {
        for (i, s) in crate::app::screen::SCREENS.iter().enumerate() {
            assert_eq!(REGISTRY[i].0, s.name);
            assert_eq!(crate::keymap::SCREENS[i], s.name);
        }
        assert_eq!(REGISTRY.len(), crate::app::screen::SCREENS.len());
    }
}
