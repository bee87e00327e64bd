//! The one screen list (`src/screen_list.rs`) drives the keymap's screen sections, the number
//! keys, the help and the drawing: every screen on it gets all of them, and nothing else names
//! a screen.

use mavterm::app::screen::SCREENS;
use mavterm::app::{App, AppConfig, Event};
use mavterm::keymap::{Action, Key, Keymap, Mode, Section};
use mavterm::ui::help::help_groups;
use mavterm::ui::screens::REGISTRY;

/// The screens as the README's key table and the default keymap name them: number key, keymap
/// section, help title.
const EXPECTED: &[(char, &str, &str)] = &[
    ('1', "overview", "Overview"),
    ('2', "parameters", "Parameters"),
    ('3', "commands", "Commands"),
    ('4', "inspector", "MAVLink Inspector"),
    ('5', "mission", "Mission"),
    ('6', "camera", "Camera"),
    ('7', "logs", "Logs"),
    ('8', "health", "Health"),
    ('9', "map", "Map"),
];

#[test]
fn the_list_is_the_screens_the_keymap_and_the_renderers_know() {
    let listed: Vec<(char, &str, &str)> = SCREENS
        .iter()
        .map(|s| (char::from(b'0' + s.number), s.name, s.title))
        .collect();
    assert_eq!(listed, EXPECTED);
    let keymap: Vec<&str> = mavterm::keymap::SCREENS.to_vec();
    let drawn: Vec<&str> = REGISTRY.iter().map(|(n, _)| *n).collect();
    let names: Vec<&str> = EXPECTED.iter().map(|e| e.1).collect();
    assert_eq!(keymap, names);
    assert_eq!(drawn, names);
}

#[test]
fn every_listed_screen_has_its_keymap_section_and_no_other_name_does() {
    let f5: Key = "f5".parse().unwrap();
    for (_, name, _) in EXPECTED {
        let km = Keymap::from_toml(&format!("[normal.{name}]\nhelp = [\"f5\"]\n"), "t.toml")
            .unwrap_or_else(|e| panic!("[normal.{name}]: {e}"));
        for (_, other, _) in EXPECTED {
            let want = (other == name).then_some(Action::Help);
            assert_eq!(
                km.lookup(Mode::Normal, other, &f5),
                want,
                "{name} on {other}"
            );
        }
    }
    let e = Keymap::from_toml("[normal.nosuch]\nhelp = [\"f5\"]\n", "t.toml").unwrap_err();
    let text = e.to_string();
    for (_, name, _) in EXPECTED {
        assert!(text.contains(name), "{text}");
    }
}

#[test]
fn every_listed_screen_has_its_number_key_and_its_help() {
    for (i, (digit, name, title)) in EXPECTED.iter().enumerate() {
        let n = digit.to_digit(10).unwrap() as u8;
        let action = Action::from_name(&format!("screen_{n}")).expect("screen_N action");
        assert_eq!(action, Action::Screen(n - 1));
        let mut app = App::new(AppConfig::default());
        // From another screen, its number key shows it.
        let from = if *digit == '1' { '2' } else { '1' };
        app.update(0, Event::Key(Key::ch(from)));
        assert_ne!(app.ui.screen, *name);
        app.update(0, Event::Key(Key::ch(*digit)));
        assert_eq!(app.ui.screen, *name, "key {digit}");
        // The help lists every screen's number key everywhere, in list order, and is titled
        // by the screen shown where it has keys of its own.
        let groups = help_groups(&app);
        let everywhere = &groups[0];
        assert_eq!(everywhere.heading, "Everywhere");
        let keys: Vec<&str> = everywhere.rows[..EXPECTED.len()]
            .iter()
            .map(|r| r.0.as_str())
            .collect();
        let numbers: Vec<String> = EXPECTED.iter().map(|e| e.0.to_string()).collect();
        assert_eq!(keys, numbers, "on {name}");
        let own = !app.keymap.section(Section::Screen(i)).is_empty();
        let heading = format!("{title} screen");
        assert_eq!(
            groups.iter().any(|g| g.heading == heading),
            own,
            "{heading} on {name}"
        );
    }
}
