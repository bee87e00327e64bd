//! The `:` prompt and the input modes, end to end on the simulated vehicles (virtual clock):
//! keys type text in the prompt instead of acting, commands run with their outcome on the status
//! line, `link` opens a link at run time, history and completion work, help is per mode.

use mavterm::app::AppConfig;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::keymap::{Key, Mode};
use mavterm::link::LinkSpec;
use mavterm::ui::{buffer_to_text, render_to_buffer, Theme};

fn runner(query: &str) -> VirtualRunner {
    let spec: LinkSpec = format!("sim://?{query}").parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    r.advance_to(3_000_000);
    r
}

fn keys(r: &mut VirtualRunner, names: &[&str]) {
    for n in names {
        r.key(n.parse::<Key>().unwrap());
    }
}

fn typed(r: &mut VirtualRunner, text: &str) {
    for c in text.chars() {
        r.key(Key::ch(c));
    }
}

fn screen(r: &VirtualRunner, w: u16, h: u16) -> String {
    buffer_to_text(&render_to_buffer(&r.app, w, h, &Theme::PLAIN))
}

fn status_line(r: &VirtualRunner) -> String {
    screen(r, 80, 24).lines().last().unwrap_or("").to_string()
}

#[test]
fn keys_type_in_the_prompt_and_esc_leaves_it() {
    let mut r = runner("vehicles=2");
    keys(&mut r, &[":"]);
    assert_eq!(r.app.ui.mode, Mode::Prompt);
    // `q` is quit in normal mode; here it is a letter.
    typed(&mut r, "quq");
    assert!(!r.app.quit);
    assert_eq!(status_line(&r), ":quq");
    keys(&mut r, &["left", "backspace", "i"]);
    assert_eq!(r.app.ui.prompt.line.text, "qiq");
    keys(&mut r, &["esc"]);
    assert_eq!(r.app.ui.mode, Mode::Normal);
    assert!(!r.app.quit);
    assert!(status_line(&r).contains("q quit"), "{}", status_line(&r));
}

#[test]
fn target_command_and_its_errors_show_on_the_status_line() {
    let mut r = runner("vehicles=2");
    assert_eq!(r.app.target, Some((1, 1)));
    keys(&mut r, &[":"]);
    typed(&mut r, "target 2");
    keys(&mut r, &["enter"]);
    assert_eq!(r.app.target, Some((2, 1)));
    assert!(
        status_line(&r).ends_with("target 2:1"),
        "{}",
        status_line(&r)
    );
    keys(&mut r, &[":"]);
    typed(&mut r, "target 9");
    keys(&mut r, &["enter"]);
    assert_eq!(r.app.target, Some((2, 1)));
    let s = status_line(&r);
    assert!(s.contains("no autopilot 9 heard"), "{s}");
    keys(&mut r, &[":"]);
    typed(&mut r, "jump");
    keys(&mut r, &["enter"]);
    assert!(status_line(&r).contains("unknown command `jump`"));
    // The next key clears the message.
    keys(&mut r, &["down"]);
    assert!(status_line(&r).contains("q quit"));
}

#[test]
fn history_and_completion() {
    let mut r = runner("vehicles=2");
    keys(&mut r, &[":"]);
    typed(&mut r, "tar");
    keys(&mut r, &["tab"]);
    assert_eq!(r.app.ui.prompt.line.text, "target ");
    keys(&mut r, &["tab"]);
    // Two autopilots: their common prefix, both shown.
    assert_eq!(r.app.ui.prompt.line.text, "target ");
    let s = status_line(&r);
    assert!(s.contains(":target "), "{s}");
    typed(&mut r, "2");
    keys(&mut r, &["tab", "enter"]);
    assert_eq!(r.app.target, Some((2, 1)));
    keys(&mut r, &[":", "up"]);
    assert_eq!(r.app.ui.prompt.line.text, "target 2:1");
    keys(&mut r, &["esc"]);
}

#[test]
fn link_command_opens_a_link_at_run_time() {
    let mut r = runner("sysid=1");
    keys(&mut r, &[":"]);
    typed(&mut r, "link sim://?sysid=5");
    keys(&mut r, &["enter"]);
    assert_eq!(r.app.links.len(), 2);
    let t = r.now() + 3_000_000;
    r.advance_to(t);
    assert!(
        r.app.vehicles.get((5, 1)).is_some(),
        "the new link's vehicle"
    );
    assert_eq!(r.app.vehicles.get((5, 1)).unwrap().links.len(), 1);
    assert!(r.app.vehicles.get((5, 1)).unwrap().links.contains(&1));
    // A bad spec is refused with the parser's reason, nothing opened.
    keys(&mut r, &[":"]);
    typed(&mut r, "link udpin:::14550");
    keys(&mut r, &["enter"]);
    assert_eq!(r.app.links.len(), 2);
    let s = status_line(&r);
    assert!(s.contains("14550") || s.contains('['), "{s}");
}

#[test]
fn route_pins_the_target_to_a_link() {
    let mut r = runner("sysid=1");
    keys(&mut r, &[":"]);
    typed(&mut r, "route 3");
    keys(&mut r, &["enter"]);
    assert!(status_line(&r).contains("no link 3"), "{}", status_line(&r));
    keys(&mut r, &[":"]);
    typed(&mut r, "route 0");
    keys(&mut r, &["enter"]);
    assert_eq!(r.app.sessions[&(1, 1)].pinned, Some(0));
    assert_eq!(r.app.route((1, 1)), Some(0));
}

#[test]
fn help_lists_the_keys_and_the_commands_and_q_closes_it() {
    let mut r = runner("sysid=1");
    keys(&mut r, &["?"]);
    assert_eq!(r.app.ui.mode, Mode::Help);
    let s = screen(&r, 100, 50);
    assert!(s.contains("open the : command line"), "{s}");
    assert!(s.contains(":target SYSID[:COMPID]"), "{s}");
    keys(&mut r, &["q"]);
    assert_eq!(r.app.ui.mode, Mode::Normal);
    assert!(!r.app.quit);
    // From the prompt too.
    keys(&mut r, &[":"]);
    typed(&mut r, "help");
    keys(&mut r, &["enter"]);
    assert_eq!(r.app.ui.mode, Mode::Help);
}

#[test]
fn screen_keys_switch_only_to_screens_that_exist() {
    let mut r = runner("sysid=1");
    keys(&mut r, &["2"]);
    assert_eq!(r.app.ui.screen, "overview");
    assert!(status_line(&r).contains("no parameters screen"));
    keys(&mut r, &["1"]);
    assert_eq!(r.app.ui.screen, "overview");
}

#[test]
fn ctrl_c_quits_from_every_mode() {
    for first in [None, Some(":"), Some("?")] {
        let mut r = runner("sysid=1");
        if let Some(k) = first {
            keys(&mut r, &[k]);
        }
        keys(&mut r, &["ctrl-c"]);
        assert!(r.app.quit, "{first:?}");
    }
}
