//! Key names and keymap files: round trips, layering, and errors that point at the problem.

use mavterm::keymap::{Action, Key, KeyCode, Keymap, KeymapError};

fn all_keys() -> Vec<Key> {
    use KeyCode::*;
    let mut codes = vec![
        Enter, Esc, Tab, BackTab, Backspace, Delete, Up, Down, Left, Right, PageUp, PageDown, Home,
        End,
    ];
    codes.extend((1..=12).map(F));
    codes.extend("aZ?#-+ 1/\\é".chars().map(Char));
    let mut keys = Vec::new();
    for code in codes {
        for (ctrl, alt) in [(false, false), (true, false), (false, true), (true, true)] {
            if ctrl && matches!(code, Char(c) if c.is_uppercase()) {
                continue; // ctrl- letters are normalised to lower case
            }
            keys.push(Key { code, ctrl, alt });
        }
    }
    keys
}

#[test]
fn every_key_round_trips_through_its_name() {
    for key in all_keys() {
        let name = key.to_string();
        assert_eq!(name.parse::<Key>(), Ok(key), "{name:?}");
    }
}

#[test]
fn key_names_and_aliases() {
    use KeyCode::*;
    let k = |s: &str| s.parse::<Key>().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(k("a"), Key::ch('a'));
    assert_eq!(k("?"), Key::ch('?'));
    assert_eq!(k("tab"), Key::plain(Tab));
    assert_eq!(k("shift-tab"), Key::plain(BackTab));
    assert_eq!(k("backtab"), Key::plain(BackTab));
    assert_eq!(k("Enter"), Key::plain(Enter));
    assert_eq!(k("space"), Key::ch(' '));
    assert_eq!(k("pageup"), Key::plain(PageUp));
    assert_eq!(k("f12"), Key::plain(F(12)));
    assert_eq!(k("ctrl-x"), Key::ctrl('x'));
    assert_eq!(k("ctrl-X"), Key::ctrl('x'));
    assert_eq!(k("shift-g"), Key::ch('G'));
    assert_eq!(k("ctrl--"), Key::ctrl('-'));
    assert_eq!(
        k("alt-x"),
        Key {
            code: Char('x'),
            ctrl: false,
            alt: true
        }
    );
    assert_eq!(k("BackTab").to_string(), "backtab");
    for bad in [
        "",
        "ctrl-",
        "tabby",
        "f0",
        "f99",
        "shift-up",
        "shift-?",
        "ctrl-shift-a",
        "xx",
    ] {
        let e = bad.parse::<Key>().unwrap_err();
        assert!(e.to_string().contains(&format!("`{bad}`")), "{e}");
    }
}

fn invalid(text: &str) -> (Vec<String>, Vec<String>, Vec<String>, String) {
    let e = Keymap::from_toml(text, "my.toml").unwrap_err();
    let msg = e.to_string();
    match e {
        KeymapError::Invalid {
            unknown_actions,
            unknown_keys,
            duplicate_keys,
            ..
        } => (unknown_actions, unknown_keys, duplicate_keys, msg),
        other => panic!("{other:?}"),
    }
}

#[test]
fn every_unknown_action_and_key_is_listed_by_name() {
    let (actions, keys, dups, msg) = invalid(
        "[bindings]\nquit = [\"q\", \"ctrl-qq\"]\nfly = [\"f\"]\nland = [\"l\"]\nhelp = [\"hyper-h\"]\n",
    );
    assert_eq!(actions, ["fly", "land"]);
    assert_eq!(keys, ["ctrl-qq", "hyper-h"]);
    assert!(dups.is_empty());
    // With where each one is.
    assert!(msg.starts_with("keymap my.toml: "), "{msg}");
    assert!(
        msg.contains("line 2, column 14: unknown key `ctrl-qq`"),
        "{msg}"
    );
    assert!(
        msg.contains("line 3, column 1: unknown action `fly`"),
        "{msg}"
    );
    assert!(
        msg.contains("line 4, column 1: unknown action `land`"),
        "{msg}"
    );
    assert!(
        msg.contains("line 5, column 9: unknown key `hyper-h`"),
        "{msg}"
    );
}

#[test]
fn one_key_for_two_actions_in_one_file_is_an_error() {
    let (_, _, dups, msg) = invalid("[bindings]\nquit = [\"q\"]\nhelp = [\"?\", \"q\"]\n");
    assert_eq!(dups, ["q (quit, help)"]);
    assert!(
        msg.contains("line 3, column 14: key `q` is already bound to `quit`"),
        "{msg}"
    );
    // The same key twice for one action is harmless.
    assert!(Keymap::from_toml("[bindings]\nquit = [\"q\", \"q\"]\n", "x").is_ok());
}

#[test]
fn malformed_files_report_file_line_and_column() {
    for (text, line, col, needle) in [
        ("[bindings]\nquit = [\"q\"\n", 2, 12, ""),
        ("[bindings]\nquit = \"q\"\n", 2, 8, "sequence"),
        (
            "[bindings]\nquit = [\"q\"]\n[colours]\nx = 1\n",
            3,
            2,
            "colours",
        ),
        ("bindings = 3\n", 1, 12, ""),
    ] {
        let e = Keymap::from_toml(text, "bad.toml").unwrap_err();
        let shown = e.to_string();
        let KeymapError::Syntax {
            origin,
            line: l,
            col: c,
            message,
        } = e
        else {
            panic!("{text:?}: {e:?}")
        };
        assert_eq!(origin, "bad.toml");
        assert_eq!((l, c), (line, col), "{text:?}: {shown}");
        assert!(message.contains(needle), "{text:?}: {message}");
        assert!(
            shown.starts_with(&format!("keymap bad.toml:{line}:{col}: ")),
            "{shown}"
        );
    }
}

#[test]
fn user_file_is_layered_on_the_default() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("keymap.toml");
    std::fs::write(
        &path,
        "[bindings]\nquit = [\"ctrl-q\"]\nhelp = []\nfocus_next = [\"n\"]\n",
    )
    .unwrap();
    let km = Keymap::load(&path).unwrap();
    // Listed actions replace their default keys...
    assert_eq!(km.keys_for(Action::Quit), vec![Key::ctrl('q')]);
    assert_eq!(km.lookup(&Key::ch('q')), None);
    assert!(km.keys_for(Action::Help).is_empty(), "`help = []` unbinds");
    // ...a key taken by the override leaves its old action...
    assert_eq!(km.lookup(&Key::ch('n')), Some(Action::FocusNext));
    assert!(km.keys_for(Action::NextVehicle).is_empty());
    // ...and the rest keep their defaults.
    assert_eq!(
        km.lookup(&Key::plain(KeyCode::Tab)),
        None,
        "focus_next was listed"
    );
    assert_eq!(km.lookup(&Key::plain(KeyCode::Up)), Some(Action::Up));
    assert_eq!(km.lookup(&Key::ch('p')), Some(Action::PrevVehicle));

    let missing = dir.path().join("nope.toml");
    let e = Keymap::load(&missing).unwrap_err();
    assert!(matches!(e, KeymapError::Io { .. }));
    assert!(e.to_string().contains("nope.toml"), "{e}");
    // An explicit --keymap file must exist; errors carry the path as origin.
    std::fs::write(&path, "[bindings]\nquit = [\"q\"\n").unwrap();
    let e = Keymap::load_user(Some(&path)).unwrap_err();
    assert!(
        e.to_string().contains(&format!("{}:2:", path.display())),
        "{e}"
    );
}

#[test]
fn shipped_vim_keymap_works_on_top_of_the_default() {
    let vim = Keymap::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/keymaps/vim.toml"
    )))
    .unwrap();
    assert_eq!(vim.lookup(&Key::ch('j')), Some(Action::Down));
    assert_eq!(vim.lookup(&Key::ch('G')), Some(Action::Bottom));
    assert_eq!(
        vim.lookup(&Key::ch('p')),
        None,
        "vim lists prev_vehicle, so p is gone"
    );
    assert_eq!(vim.keys_for(Action::Up)[0], Key::ch('k'));
}
