//! The screen registry: each screen the core knows (`app::screen::SCREENS`) and the function in
//! its own file that draws it. A new screen is one file and one line here.

use ratatui::layout::Rect;
use ratatui::Frame;

use super::{camera, commands, inspector, mission, overview, parameters, Theme};
use crate::app::App;

/// Draws a screen into the area above the status bar.
pub type RenderFn = fn(&App, &mut Frame, Rect, &Theme);

/// (screen name, renderer).
pub const REGISTRY: &[(&str, RenderFn)] = &[
    ("overview", overview::render),
    ("parameters", parameters::render),
    ("commands", commands::render),
    ("inspector", inspector::render),
    ("mission", mission::render),
    ("camera", camera::render),
];

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
        for s in crate::app::screen::SCREENS {
            assert!(
                REGISTRY.iter().any(|(n, _)| *n == s.name),
                "{} is not registered",
                s.name
            );
            assert!(crate::keymap::SCREENS.contains(&s.name), "{}", s.name);
        }
    }
}
