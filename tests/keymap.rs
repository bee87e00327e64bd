//! Key names and keymap files: round trips, layering, and errors that point at the problem.

use std::collections::BTreeMap;

use mavterm::keymap::{Action, Key, KeyCode, Keymap, KeymapError, Mode, Problem, SCREENS};

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
    // Modifiers may repeat; a very long name is still read in one pass.
    assert_eq!(k("ctrl-CTRL-x"), Key::ctrl('x'));
    assert_eq!(k(&format!("{}x", "ctrl-".repeat(200_000))), Key::ctrl('x'));
    assert!(format!("{}xx", "Alt-".repeat(200_000))
        .parse::<Key>()
        .is_err());
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

struct Invalid {
    actions: Vec<String>,
    keys: Vec<String>,
    dups: Vec<String>,
    problems: Vec<Problem>,
    more: usize,
    hints: Vec<String>,
    msg: String,
}

fn invalid(text: &str) -> Invalid {
    let e = Keymap::from_toml(text, "my.toml").unwrap_err();
    let msg = e.to_string();
    match e {
        KeymapError::Invalid(e) => Invalid {
            actions: e.unknown_actions,
            keys: e.unknown_keys,
            dups: e.duplicate_keys,
            problems: e.problems,
            more: e.more,
            hints: e.hints,
            msg,
        },
        other => panic!("{other:?}"),
    }
}

/// (line, column) of each problem.
fn places(problems: &[Problem]) -> Vec<(usize, usize)> {
    problems.iter().map(|p| (p.line, p.col)).collect()
}

fn k(s: &str) -> Key {
    s.parse().unwrap_or_else(|e| panic!("{e}"))
}

fn keys(names: &[&str]) -> Vec<Key> {
    names.iter().map(|s| k(s)).collect()
}

fn shipped(name: &str) -> String {
    std::fs::read_to_string(format!("{}/keymaps/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

#[test]
fn every_unknown_action_and_key_is_listed_by_name() {
    let e = invalid(
        "[bindings]\nquit = [\"q\", \"ctrl-qq\"]\ndive = [\"f\"]\nhover = [\"l\"]\nhelp = [\"hyper-h\"]\n",
    );
    assert_eq!(e.actions, ["dive", "hover"]);
    assert_eq!(e.keys, ["ctrl-qq", "hyper-h"]);
    assert!(e.dups.is_empty());
    assert_eq!(e.more, 0);
    assert_eq!(places(&e.problems), [(2, 14), (3, 1), (4, 1), (5, 9)]);
    // With where each one is, as FILE:LINE:COL, one per line.
    let msg = &e.msg;
    assert!(msg.starts_with("keymap my.toml: 4 problems:\n"), "{msg}");
    assert!(
        msg.contains("\n  my.toml:2:14: unknown key `ctrl-qq`"),
        "{msg}"
    );
    assert!(
        msg.contains("\n  my.toml:3:1: unknown action `dive`"),
        "{msg}"
    );
    assert!(
        msg.contains("\n  my.toml:4:1: unknown action `hover`"),
        "{msg}"
    );
    assert!(
        msg.contains("\n  my.toml:5:9: unknown key `hyper-h`"),
        "{msg}"
    );
}

#[test]
fn unknown_sections_screens_and_shapes_are_listed_all_at_once() {
    let text = "[colours]\nx = 1\n[normal.radar]\nquit = [\"q\"]\n[normal]\ndive = [\"f\"]\n\
                [normal.overview]\nhelp = [\"hyper-h\"]\n[edit]\nsubmit = \"enter\"\n\
                [prompt.more]\nsubmit = [\"enter\"]\n";
    let e = invalid(text);
    assert_eq!(
        places(&e.problems),
        [(1, 2), (3, 9), (6, 1), (8, 9), (10, 10), (11, 9)],
        "{}",
        e.msg
    );
    let m: Vec<&str> = e.problems.iter().map(|p| p.message.as_str()).collect();
    assert!(m[0].contains("unknown section `colours`"), "{}", m[0]);
    assert!(m[1].contains("unknown screen `radar`"), "{}", m[1]);
    assert!(m[1].contains("overview, parameters, commands"), "{}", m[1]);
    assert!(m[2].contains("unknown action `dive`"), "{}", m[2]);
    assert!(m[3].contains("unknown key `hyper-h`"), "{}", m[3]);
    assert!(m[4].contains("expected a list of key names"), "{}", m[4]);
    assert!(m[5].contains("[prompt] has no sub-sections"), "{}", m[5]);

    // Bindings outside any section, and a section that is not a table.
    let e = invalid("quit = [\"q\"]\n[normal]\nhelp = [\"?\"]\n");
    assert_eq!(places(&e.problems), [(1, 1)]);
    assert!(e.msg.starts_with("keymap my.toml:1:1: "), "{}", e.msg);
    assert!(e.msg.contains("put it under [normal]"), "{}", e.msg);
    let e = invalid("bindings = 3\n");
    assert_eq!(places(&e.problems), [(1, 12)]);
    let e = invalid("[normal]\nquit = [\"q\", 7]\n");
    assert_eq!(places(&e.problems), [(2, 14)]);
    assert!(e.msg.contains("key name in quotes"), "{}", e.msg);
}

#[test]
fn one_key_for_two_actions_in_one_file_is_an_error() {
    let e = invalid("[bindings]\nquit = [\"q\"]\nhelp = [\"?\", \"q\"]\n");
    assert_eq!(e.dups, ["q (quit, help)"]);
    assert_eq!(
        e.msg,
        "keymap my.toml:3:14: key `q` is already bound to `quit`"
    );
    // The same key twice for one action is harmless.
    assert!(Keymap::from_toml("[bindings]\nquit = [\"q\", \"q\"]\n", "x").is_ok());
    // The legacy [bindings] and [normal] are one section.
    let e = invalid("[bindings]\nquit = [\"x\"]\n[normal]\nhelp = [\"x\"]\n");
    assert_eq!(e.dups, ["x (quit, help)"]);
    assert_eq!(places(&e.problems), [(4, 9)]);
    // Two actions on one key within [prompt].
    let e = invalid("[prompt]\nsubmit = [\"enter\"]\ncancel = [\"enter\"]\n");
    assert_eq!(e.dups, ["enter (cancel, submit) in [prompt]"]);
}

#[test]
fn a_screen_section_may_not_rebind_a_key_of_normal() {
    // [normal] ∪ [normal.parameters] is what normal mode sees on the parameters screen.
    let e = invalid("[normal]\nquit = [\"q\"]\n[normal.parameters]\nhelp = [\"q\"]\n");
    assert_eq!(places(&e.problems), [(4, 9)]);
    assert_eq!(e.dups, ["q (quit, help) in [normal.parameters]"]);
    assert!(
        e.msg.contains(
            "key `q` is already bound to `quit` in [normal] (line 2, column 9); \
             on the parameters screen both apply"
        ),
        "{}",
        e.msg
    );
    // Reported where the second binding is, whichever section comes first.
    let e = invalid("[normal.overview]\nhelp = [\"x\"]\n[normal]\nquit = [\"x\"]\n");
    assert_eq!(places(&e.problems), [(4, 9)]);
    assert!(
        e.msg
            .contains("already bound to `help` in [normal.overview] (line 2, column 9)"),
        "{}",
        e.msg
    );
    // Fine: the same action in both, one key on two screens, and a key in another mode.
    let ok = "[normal]\nquit = [\"q\"]\nhelp = [\"?\"]\n[normal.overview]\nquit = [\"q\"]\n\
              toggle_expand = [\"enter\"]\n[normal.parameters]\nsubmit = [\"enter\"]\n\
              [prompt]\ncancel = [\"q\"]\n[help]\ncancel = [\"q\", \"?\"]\n";
    Keymap::from_toml(ok, "ok.toml").unwrap_or_else(|e| panic!("{e}"));
}

#[test]
fn lookup_follows_mode_and_screen() {
    let km = Keymap::from_toml(
        "[normal]\nquit = [\"q\"]\n[normal.overview]\ntoggle_expand = [\"enter\"]\n\
         [normal.parameters]\nsubmit = [\"enter\"]\n[prompt]\nsubmit = [\"enter\"]\n\
         cancel = [\"esc\"]\n[edit]\ncancel = [\"ctrl-g\"]\n[help]\ncancel = [\"q\"]\n",
        "t",
    )
    .unwrap();
    let enter = k("enter");
    assert_eq!(
        km.lookup(Mode::Normal, "overview", &enter),
        Some(Action::ToggleExpand)
    );
    assert_eq!(
        km.lookup(Mode::Normal, "parameters", &enter),
        Some(Action::Submit)
    );
    assert_eq!(km.lookup(Mode::Normal, "mission", &enter), None);
    // [normal] applies on every screen, also one we do not know.
    for screen in SCREENS.iter().chain(&["nowhere"]) {
        assert_eq!(
            km.lookup(Mode::Normal, screen, &k("q")),
            Some(Action::Quit),
            "{screen}"
        );
    }
    // The other modes see their own section only, whatever the screen.
    assert_eq!(
        km.lookup(Mode::Prompt, "overview", &enter),
        Some(Action::Submit)
    );
    assert_eq!(km.lookup(Mode::Prompt, "overview", &k("q")), None);
    assert_eq!(km.lookup(Mode::Edit, "parameters", &enter), None);
    assert_eq!(
        km.lookup(Mode::Edit, "parameters", &k("ctrl-g")),
        Some(Action::Cancel)
    );
    assert_eq!(
        km.lookup(Mode::Help, "overview", &k("q")),
        Some(Action::Cancel)
    );
    assert_eq!(km.lookup(Mode::Help, "overview", &enter), None);
}

#[test]
fn default_sections_and_keys() {
    let km = Keymap::default();
    let ov = |s: &str| km.lookup(Mode::Normal, "overview", &k(s));
    let params = |s: &str| km.lookup(Mode::Normal, "parameters", &k(s));
    // The original bindings.
    for (key, a) in [
        ("q", Action::Quit),
        ("ctrl-c", Action::Quit),
        ("tab", Action::FocusNext),
        ("backtab", Action::FocusPrev),
        ("up", Action::Up),
        ("down", Action::Down),
        ("pageup", Action::PageUp),
        ("pagedown", Action::PageDown),
        ("home", Action::Top),
        ("end", Action::Bottom),
        ("enter", Action::ToggleExpand),
        ("space", Action::ToggleExpand),
        ("n", Action::NextVehicle),
        ("p", Action::PrevVehicle),
        ("?", Action::Help),
        ("f1", Action::Help),
        ("esc", Action::Cancel),
    ] {
        assert_eq!(ov(key), Some(a), "{key}");
    }
    // New: the prompt and the screens, on every screen.
    for screen in SCREENS {
        let at = |s: &str| km.lookup(Mode::Normal, screen, &k(s));
        assert_eq!(at(":"), Some(Action::Prompt), "{screen}");
        for n in 0..6u8 {
            let key = (b'1' + n) as char;
            assert_eq!(at(&key.to_string()), Some(Action::Screen(n)), "{screen}");
        }
    }
    // Overview-only actions are free elsewhere; the parameters screen has its own.
    for key in ["tab", "backtab", "space"] {
        assert_eq!(params(key), None, "{key}");
    }
    for (key, a) in [
        ("/", Action::ParamFilter),
        ("enter", Action::ParamEdit),
        ("f", Action::ParamFetch),
        ("d", Action::ParamOnlyDiff),
    ] {
        assert_eq!(params(key), Some(a), "{key}");
        assert_ne!(ov(key), Some(a), "{key}");
    }
    assert_eq!(params("q"), Some(Action::Quit));
    // The text line.
    for mode in [Mode::Prompt, Mode::Edit] {
        for (key, a) in [
            ("enter", Action::Submit),
            ("esc", Action::Cancel),
            ("left", Action::CursorLeft),
            ("ctrl-b", Action::CursorLeft),
            ("right", Action::CursorRight),
            ("ctrl-f", Action::CursorRight),
            ("home", Action::LineStart),
            ("ctrl-a", Action::LineStart),
            ("end", Action::LineEnd),
            ("ctrl-e", Action::LineEnd),
            ("backspace", Action::DeleteBack),
            ("delete", Action::DeleteForward),
            ("ctrl-d", Action::DeleteForward),
            ("ctrl-w", Action::DeleteWord),
            ("ctrl-u", Action::ClearLine),
            ("up", Action::HistoryPrev),
            ("ctrl-p", Action::HistoryPrev),
            ("down", Action::HistoryNext),
            ("ctrl-n", Action::HistoryNext),
            ("tab", Action::Complete),
        ] {
            assert_eq!(
                km.lookup(mode, "overview", &k(key)),
                Some(a),
                "{mode:?} {key}"
            );
        }
        // Unbound printable keys are left for the core to type.
        for key in ["q", "1", ":", "?", "n", "space"] {
            assert_eq!(km.lookup(mode, "overview", &k(key)), None, "{mode:?} {key}");
        }
    }
    for (key, a) in [
        ("esc", Action::Cancel),
        ("q", Action::Cancel),
        ("?", Action::Help),
    ] {
        assert_eq!(km.lookup(Mode::Help, "overview", &k(key)), Some(a), "{key}");
    }
}

#[test]
fn keys_for_and_bindings_list_what_applies_in_file_order() {
    let km = Keymap::default();
    assert_eq!(
        km.keys_for(Mode::Normal, "overview", Action::ToggleExpand),
        keys(&["enter", "space"])
    );
    assert!(km
        .keys_for(Mode::Normal, "parameters", Action::ToggleExpand)
        .is_empty());
    assert_eq!(
        km.keys_for(Mode::Prompt, "overview", Action::LineStart),
        keys(&["home", "ctrl-a"])
    );
    assert_eq!(
        km.keys_for(Mode::Help, "overview", Action::Cancel),
        keys(&["esc", "q"])
    );
    let names = |b: Vec<(Action, Vec<Key>)>| -> Vec<(String, String)> {
        b.into_iter()
            .map(|(a, ks)| {
                let ks: Vec<String> = ks.iter().map(|k| k.to_string()).collect();
                (a.name().to_string(), ks.join(" "))
            })
            .collect()
    };
    let pairs = |v: &[(&str, &str)]| -> Vec<(String, String)> {
        v.iter()
            .map(|(a, k)| (a.to_string(), k.to_string()))
            .collect()
    };
    let common = [
        ("quit", "q ctrl-c"),
        ("suspend", "ctrl-z"),
        ("help", "? f1"),
        ("cancel", "esc"),
        ("prompt", ":"),
        ("screen_1", "1"),
        ("screen_2", "2"),
        ("screen_3", "3"),
        ("screen_4", "4"),
        ("screen_5", "5"),
        ("screen_6", "6"),
        ("screen_7", "7"),
        ("screen_8", "8"),
        ("screen_9", "9"),
        ("up", "up"),
        ("down", "down"),
        ("page_up", "pageup"),
        ("page_down", "pagedown"),
        ("top", "home"),
        ("bottom", "end"),
    ];
    let mut overview = common.to_vec();
    overview.extend([
        ("focus_next", "tab"),
        ("focus_prev", "backtab"),
        ("toggle_expand", "enter space"),
    ]);
    overview.extend([("next_vehicle", "n"), ("prev_vehicle", "p")]);
    overview.extend([
        ("arm", "A"),
        ("disarm", "D"),
        ("takeoff", "T"),
        ("land", "L"),
        ("rtl", "R"),
        ("mode", "M"),
        ("palette", "ctrl-p"),
        ("messages", "O"),
        ("fly", "F"),
    ]);
    let replay = [
        ("replay_pause", "P"),
        ("replay_step", "."),
        ("replay_back", "["),
        ("replay_forward", "]"),
        ("replay_slower", "-"),
        ("replay_faster", "+ ="),
    ];
    overview.extend(replay);
    overview.extend([
        ("msg_severity", "s"),
        ("msg_severity_back", "S"),
        ("msg_vehicle", "v"),
        ("msg_vehicle_back", "V"),
    ]);
    assert_eq!(
        names(km.bindings(Mode::Normal, "overview")),
        pairs(&overview)
    );
    // The Health screen's own keys, in file order after the keys of every screen.
    let health = names(km.bindings(Mode::Normal, "health"));
    let own: Vec<(String, String)> = health
        .iter()
        .filter(|(a, _)| a.starts_with("cal_") || a.starts_with("health_"))
        .cloned()
        .collect();
    assert_eq!(
        own,
        pairs(&[
            ("health_prearm", "c"),
            ("cal_next", "enter"),
            ("cal_gyro", "i"),
            ("cal_baro", "b"),
            ("cal_level", "l"),
            ("cal_accel", "a"),
            ("cal_simple_accel", "s"),
            ("cal_compass", "m"),
            ("cal_accept", "S"),
            ("cal_cancel", "x"),
        ])
    );
    let mut parameters = common.to_vec();
    parameters.extend([("next_vehicle", "n"), ("prev_vehicle", "p")]);
    parameters.extend([
        ("arm", "A"),
        ("disarm", "D"),
        ("takeoff", "T"),
        ("land", "L"),
        ("rtl", "R"),
        ("mode", "M"),
        ("palette", "ctrl-p"),
        ("messages", "O"),
        ("param_filter", "/"),
        ("param_edit", "enter"),
        ("param_fetch", "f"),
        ("param_only_diff", "d"),
        ("fly", "F"),
    ]);
    parameters.extend(replay);
    assert_eq!(
        names(km.bindings(Mode::Normal, "parameters")),
        pairs(&parameters)
    );
    assert_eq!(
        names(km.bindings(Mode::Help, "parameters")),
        pairs(&[
            ("help", "? f1"),
            ("cancel", "esc q"),
            ("up", "up"),
            ("down", "down"),
            ("page_up", "pageup"),
            ("page_down", "pagedown"),
            ("top", "home"),
            ("bottom", "end"),
        ])
    );
}

#[test]
fn malformed_files_report_file_line_and_column() {
    for (text, line, col, needle) in [
        ("[bindings]\nquit = [\"q\"\n", 2, 12, ""),
        ("[normal\nquit = [\"q\"]\n", 1, 8, ""),
        (
            "[normal]\nquit = [\"q\"]\nquit = [\"w\"]\n",
            3,
            1,
            "duplicate",
        ),
        ("[normal]\nquit = [\"q\"] x\n", 2, 14, ""),
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
fn many_problems_are_capped_and_counted() {
    // 50,000 unknown actions (once quadratic: 42 s).
    let n = 50_000;
    let mut text = String::from("[normal]\n");
    for i in 0..n {
        text.push_str(&format!("a{i} = [\"q\"]\n"));
    }
    let e = invalid(&text);
    assert_eq!(e.actions.len(), n);
    assert_eq!(e.actions[n - 1], format!("a{}", n - 1));
    assert_eq!(e.problems.len(), 50);
    assert_eq!(e.more, n - 50);
    assert_eq!(e.problems[0].line, 2);
    assert_eq!(e.problems[49].line, 51);
    assert_eq!(e.problems[49].message, "unknown action `a49` in [normal]");
    assert!(e.msg.starts_with("keymap my.toml: 50000 problems:\n"));
    // The problems, the count of the rest, then the actions of [normal] once.
    let (problems, hint) = e.msg.split_once("\n  … and 49950 more\n").unwrap();
    assert_eq!(problems.lines().count(), 1 + 50);
    assert!(
        hint.starts_with("the actions of [normal] and [normal.SCREEN]: arm, bottom,"),
        "{hint}"
    );
    assert_eq!(e.hints.len(), 1);

    // A large file (about 6 MB), two problems per line, still listed top to bottom.
    let lines = 200_000;
    let mut text = String::from("[normal]\n");
    for i in 0..lines {
        text.push_str(&format!("action{i:07} = [\"nokey{i:07}\"]\n"));
    }
    let e = invalid(&text);
    assert_eq!(e.actions.len(), lines);
    assert_eq!(e.keys.len(), lines);
    assert_eq!(e.problems.len() + e.more, 2 * lines);
    assert_eq!(places(&e.problems[..4]), [(2, 1), (2, 18), (3, 1), (3, 18)]);

    // Positions stay right far down a file.
    let mut text = "#\n".repeat(99_999);
    text.push_str("[normal]\nquit = [\"q\", \"nope\"]\n");
    let e = invalid(&text);
    assert_eq!(places(&e.problems), [(100_001, 14)]);
}

#[test]
fn user_file_is_layered_on_the_default() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("keymap.toml");
    // A legacy file: [bindings] means [normal]. `n` is the default's `next_vehicle` key: the
    // file moves that action to `N` before taking `n`.
    std::fs::write(
        &path,
        "[bindings]\nquit = [\"ctrl-q\"]\nhelp = []\nfocus_next = [\"n\"]\nnext_vehicle = [\"N\"]\n",
    )
    .unwrap();
    let km = Keymap::load(&path).unwrap();
    let ov = |s: &str| km.lookup(Mode::Normal, "overview", &k(s));
    assert_eq!(ov("N"), Some(Action::NextVehicle));
    // Listed actions replace their default keys...
    assert_eq!(
        km.keys_for(Mode::Normal, "overview", Action::Quit),
        keys(&["ctrl-q"])
    );
    assert_eq!(ov("q"), None);
    assert!(
        km.keys_for(Mode::Normal, "overview", Action::Help)
            .is_empty(),
        "`help = []` unbinds"
    );
    // ...a key the file gives another action leaves its old one...
    assert_eq!(ov("n"), Some(Action::FocusNext));
    assert_eq!(
        km.keys_for(Mode::Normal, "overview", Action::NextVehicle),
        keys(&["N"])
    );
    // ...also where the default bound the action in [normal.overview]...
    assert_eq!(ov("tab"), None, "focus_next was listed");
    // ...and the rest keep their defaults.
    assert_eq!(ov("up"), Some(Action::Up));
    assert_eq!(ov("p"), Some(Action::PrevVehicle));
    assert_eq!(ov("enter"), Some(Action::ToggleExpand));
    assert_eq!(
        km.lookup(Mode::Prompt, "overview", &k("enter")),
        Some(Action::Submit)
    );
    // Help mode has its own section, which the file did not touch.
    assert_eq!(
        km.lookup(Mode::Help, "overview", &k("?")),
        Some(Action::Help)
    );

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
fn overrides_work_section_by_section() {
    let user = Keymap::from_toml(
        "[normal.parameters]\nhelp = [\"n\"]\n[prompt]\ncomplete = [\"ctrl-i\"]\nsubmit = [\"tab\"]\n\
         [normal]\ntoggle_expand = [\"o\"]\nquit = [\"enter\"]\n",
        "user.toml",
    )
    .unwrap();
    let km = Keymap::default().with_overrides(&user);
    let at = |mode, screen, s: &str| km.lookup(mode, screen, &k(s));
    // A key bound in [normal.parameters] shadows [normal] there only.
    assert_eq!(at(Mode::Normal, "parameters", "n"), Some(Action::Help));
    assert_eq!(at(Mode::Normal, "overview", "n"), Some(Action::NextVehicle));
    assert!(km
        .keys_for(Mode::Normal, "parameters", Action::NextVehicle)
        .is_empty());
    assert_eq!(
        km.keys_for(Mode::Normal, "parameters", Action::Help),
        keys(&["n", "?", "f1"])
    );
    assert_eq!(
        km.keys_for(Mode::Normal, "overview", Action::Help),
        keys(&["?", "f1"])
    );
    // An action listed in [normal] loses its keys in [normal.SCREEN] too.
    assert_eq!(at(Mode::Normal, "overview", "space"), None);
    assert_eq!(
        km.keys_for(Mode::Normal, "overview", Action::ToggleExpand),
        keys(&["o"])
    );
    assert_eq!(at(Mode::Normal, "mission", "o"), Some(Action::ToggleExpand));
    // A key bound in [normal] is taken from the screen sections as well.
    assert_eq!(at(Mode::Normal, "overview", "enter"), Some(Action::Quit));
    assert_eq!(
        km.keys_for(Mode::Normal, "overview", Action::Quit),
        keys(&["enter"])
    );
    // [prompt] changes leave [edit] alone.
    assert_eq!(
        at(Mode::Prompt, "overview", "ctrl-i"),
        Some(Action::Complete)
    );
    assert_eq!(at(Mode::Prompt, "overview", "tab"), Some(Action::Submit));
    assert_eq!(
        km.keys_for(Mode::Prompt, "overview", Action::Submit),
        keys(&["tab"])
    );
    assert_eq!(at(Mode::Prompt, "overview", "enter"), None);
    assert_eq!(at(Mode::Edit, "overview", "tab"), Some(Action::Complete));
    assert_eq!(at(Mode::Edit, "overview", "enter"), Some(Action::Submit));
}

#[test]
fn shipped_vim_keymap_works_on_top_of_the_default() {
    let vim = Keymap::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/keymaps/vim.toml"
    )))
    .unwrap();
    let at = |mode, screen, s: &str| vim.lookup(mode, screen, &k(s));
    assert_eq!(at(Mode::Normal, "overview", "j"), Some(Action::Down));
    assert_eq!(at(Mode::Normal, "parameters", "G"), Some(Action::Bottom));
    assert_eq!(
        at(Mode::Normal, "overview", "p"),
        None,
        "vim lists prev_vehicle, so p is gone"
    );
    assert_eq!(at(Mode::Normal, "overview", "l"), Some(Action::FocusNext));
    assert_eq!(at(Mode::Normal, "parameters", "l"), None);
    assert_eq!(
        vim.keys_for(Mode::Normal, "overview", Action::Up)[0],
        k("k")
    );
    assert_eq!(at(Mode::Help, "overview", "j"), Some(Action::Down));
    // The results of the last actions on every screen, as in the default keymap.
    for screen in ["overview", "parameters", "commands", "mission", "camera"] {
        assert_eq!(at(Mode::Normal, screen, "O"), Some(Action::Outcomes));
    }
    assert_eq!(
        at(Mode::Prompt, "overview", "ctrl-b"),
        Some(Action::LineStart)
    );
    assert_eq!(
        at(Mode::Prompt, "overview", "ctrl-h"),
        Some(Action::DeleteBack)
    );
    assert_eq!(at(Mode::Prompt, "overview", "j"), None, "typed, not moved");
    assert_eq!(
        at(Mode::Edit, "overview", "ctrl-b"),
        Some(Action::LineStart)
    );
}

/// Action name → key names, as a file lists them.
type Section = Vec<(String, Vec<String>)>;

/// The shipped keymaps, read as plain TOML (not through the loader under test): within normal
/// mode on each screen and within each other mode, no key is bound to two actions.
#[test]
fn shipped_keymaps_have_no_collisions() {
    for file in ["default.toml", "vim.toml"] {
        let text = shipped(file);
        let doc: toml::Table = toml::from_str(&text).unwrap();
        let actions = |t: &toml::Table| -> Section {
            t.iter()
                .filter_map(|(name, v)| {
                    let list = v.as_array()?;
                    Some((
                        name.clone(),
                        list.iter()
                            .map(|k| k.as_str().unwrap().to_string())
                            .collect(),
                    ))
                })
                .collect()
        };
        let normal = doc["normal"].as_table().unwrap();
        let mut contexts: Vec<(String, Section)> = Vec::new();
        for screen in SCREENS {
            let mut set = actions(normal);
            if let Some(t) = normal.get(*screen).and_then(|v| v.as_table()) {
                set.extend(actions(t));
            }
            contexts.push((format!("normal.{screen}"), set));
        }
        for mode in ["help", "prompt", "edit"] {
            contexts.push((mode.into(), actions(doc[mode].as_table().unwrap())));
        }
        for (context, set) in contexts {
            let mut seen: BTreeMap<Key, String> = BTreeMap::new();
            for (action, names) in set {
                for name in names {
                    if let Some(prev) = seen.insert(k(&name), action.clone()) {
                        assert_eq!(prev, action, "{file} [{context}]: `{name}` bound twice");
                    }
                }
            }
        }
        // And the loader agrees.
        Keymap::from_toml(&text, file).unwrap_or_else(|e| panic!("{e}"));
    }
}

/// The error of layering the user file `text` over the default keymap.
fn layering_error(text: &str) -> Invalid {
    let user = Keymap::from_toml(text, "user.toml").unwrap_or_else(|e| panic!("{e}"));
    let e = Keymap::default().layered(&user, "user.toml").unwrap_err();
    let msg = e.to_string();
    let KeymapError::Invalid(e) = e else {
        panic!("{e:?}")
    };
    Invalid {
        actions: e.unknown_actions,
        keys: e.unknown_keys,
        dups: e.duplicate_keys,
        problems: e.problems,
        more: e.more,
        hints: e.hints,
        msg,
    }
}

#[test]
fn a_user_key_that_the_default_binds_to_another_action_is_an_error() {
    // The case: `n` is the default's next_vehicle key in [normal].
    let e = layering_error("[normal]\nquit = [\"q\", \"n\"]\n");
    assert_eq!(e.dups, ["n (quit, next_vehicle)"]);
    assert_eq!(places(&e.problems), [(2, 14)]);
    assert_eq!(
        e.msg,
        "keymap user.toml:2:14: key `n` is bound to `quit` here and to `next_vehicle` by the \
         default keymap in [normal]: on every screen both would apply; give `next_vehicle` other \
         keys (or none: `next_vehicle = []`) in [normal] of this file"
    );
    assert!(e.actions.is_empty() && e.keys.is_empty() && e.hints.is_empty());
    // A key of [normal] that a screen of the default binds: on that screen only.
    let e = layering_error("[normal]\nhelp = [\"g\", \"?\"]\n");
    assert_eq!(e.dups, ["g (help, mission_goto)", "g (help, map_goto)"]);
    assert!(
        e.msg.contains(
            "to `mission_goto` by the default keymap in [normal.mission]: on the mission screen"
        ),
        "{}",
        e.msg
    );
    // A screen section's key that the default binds in [normal]; and one in [prompt]; all at
    // once, top to bottom.
    let e = layering_error(
        "[normal.camera]\ncamera_shoot = [\"s\", \"A\"]\n[prompt]\nsubmit = [\"enter\", \"tab\"]\n",
    );
    assert_eq!(places(&e.problems), [(2, 22), (4, 20)], "{}", e.msg);
    assert!(
        e.msg.starts_with("keymap user.toml: 2 problems:\n"),
        "{}",
        e.msg
    );
    assert!(
        e.msg
            .contains("`A` is bound to `camera_shoot` here and to `arm`"),
        "{}",
        e.msg
    );
    assert!(e.msg.contains("on the camera screen"), "{}", e.msg);
    assert!(e.msg.contains("`tab` is bound to `submit` here and to `complete` by the default keymap in [prompt]: in [prompt] both"), "{}", e.msg);
    assert_eq!(
        e.dups,
        [
            "A (camera_shoot, arm) in [normal.camera]",
            "tab (submit, complete) in [prompt]"
        ]
    );

    // Fine: the other action moved or unbound in the same file; the same action again; a key
    // in another mode; a key the default binds on another screen only.
    for ok in [
        "[normal]\nquit = [\"n\"]\nnext_vehicle = [\"N\"]\n",
        "[normal]\nquit = [\"n\"]\nnext_vehicle = []\n",
        "[normal]\nnext_vehicle = [\"n\", \"j\"]\n",
        "[help]\ncancel = [\"n\"]\n",
        "[normal.overview]\ntoggle_expand = [\"g\"]\n",
        "[normal.mission]\nmission_goto = [\"o\"]\n[normal.map]\nmap_goto = [\"o\"]\n\
         [normal]\ntop = [\"g\"]\n",
    ] {
        let user = Keymap::from_toml(ok, "ok.toml").unwrap_or_else(|e| panic!("{e}"));
        let km = Keymap::default()
            .layered(&user, "ok.toml")
            .unwrap_or_else(|e| panic!("{ok:?}: {e}"));
        // What the file binds is what the key does.
        if ok.starts_with("[normal]\nquit") {
            assert_eq!(
                km.lookup(Mode::Normal, "overview", &k("n")),
                Some(Action::Quit)
            );
        }
    }
    // Through the loader, the error names the file.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("keymap.toml");
    std::fs::write(&path, "[normal]\nquit = [\"n\"]\n").unwrap();
    let e = Keymap::load(&path).unwrap_err().to_string();
    assert!(
        e.starts_with(&format!("keymap {}:2:9: key `n`", path.display())),
        "{e}"
    );
}

#[test]
fn unknown_actions_and_keys_list_the_valid_names() {
    let e = invalid(
        "[normal]\ndive = [\"f\"]\n[help]\nsubmit_it = [\"q\"]\n[edit]\nquit = [\"hyper-q\"]\n",
    );
    assert_eq!(e.hints.len(), 3, "{:?}", e.hints);
    // Each list once, after the problems, sorted, wrapped.
    let normal = &e.hints[0];
    assert!(
        normal
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ")
            .starts_with(
                "the actions of [normal] and [normal.SCREEN]: arm, bottom, cal_accel, \
                 cal_accept, cal_baro, cal_cancel, cal_compass, cal_gyro, cal_level, cal_next, \
                 cal_simple_accel, camera_"
            ),
        "{normal}"
    );
    for name in ["quit", "next_vehicle", "mission_goto", "screen_6", "cancel"] {
        assert!(
            normal.contains(&format!(" {name},")) || normal.ends_with(&format!(" {name}")),
            "{name}: {normal}"
        );
    }
    assert!(!normal.contains("cursor_left"), "{normal}");
    assert!(normal.lines().count() > 1, "wrapped: {normal}");
    assert!(normal.lines().all(|l| l.chars().count() <= 96), "{normal}");
    assert_eq!(
        e.hints[1],
        "the actions of [help]: bottom, cancel, down, help, page_down, page_up, top, up"
    );
    assert!(
        e.hints[2].starts_with("key names: a character (a, A, ?, 1), space, enter, esc, tab,"),
        "{}",
        e.hints[2]
    );
    assert!(
        e.hints[2].contains("f1 to f24") && e.hints[2].contains("ctrl-x, alt-x"),
        "{}",
        e.hints[2]
    );
    assert!(e.msg.ends_with(&e.hints.join("\n")), "{}", e.msg);
    // The text line's actions, for [prompt] and [edit] alike.
    let e = invalid("[prompt]\nsend = [\"enter\"]\n");
    assert!(
        e.hints[0].starts_with("the actions of [prompt] and [edit]: cancel, clear_line, complete,"),
        "{:?}",
        e.hints
    );
    // A key name alone (as a replay script's) says the names too.
    let e = "hyper-q".parse::<Key>().unwrap_err().to_string();
    assert!(
        e.contains("`hyper-q`") && e.contains("pagedown") && e.contains("f1 to f24"),
        "{e}"
    );
}
