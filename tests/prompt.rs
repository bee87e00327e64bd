//! The `:` prompt and the input modes, end to end on the simulated vehicles (virtual clock):
//! keys type text in the prompt instead of acting, commands run with their outcome on the status
//! line, `link` opens a link at run time, history and completion work, help is per mode.

mod common;

use mavterm::app::AppConfig;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::keymap::Mode;
use mavterm::link::LinkSpec;
use mavterm::proto::vehicles::VehicleKey;

fn runner(query: &str) -> VirtualRunner {
    let spec: LinkSpec = format!("sim://?{query}").parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    r.advance_to(3_000_000);
    r
}

fn status_line(r: &VirtualRunner) -> String {
    common::screen(r, 80, 24)
        .lines()
        .last()
        .unwrap_or("")
        .to_string()
}

#[test]
fn keys_type_in_the_prompt_and_esc_leaves_it() {
    let mut r = runner("vehicles=2");
    common::keys(&mut r, &[":"]);
    assert_eq!(r.app.ui.mode, Mode::Prompt);
    // `q` is quit in normal mode; here it is a letter.
    common::typed(&mut r, "quq");
    assert!(!r.app.quit);
    assert_eq!(status_line(&r), ":quq");
    common::keys(&mut r, &["left", "backspace", "i"]);
    assert_eq!(r.app.ui.prompt.line.text, "qiq");
    common::keys(&mut r, &["esc"]);
    assert_eq!(r.app.ui.mode, Mode::Normal);
    assert!(!r.app.quit);
    assert!(status_line(&r).contains("q quit"), "{}", status_line(&r));
}

#[test]
fn target_command_and_its_errors_show_on_the_status_line() {
    let mut r = runner("vehicles=2");
    assert_eq!(r.app.target, Some(VehicleKey(1, 1)));
    common::keys(&mut r, &[":"]);
    common::typed(&mut r, "target 2");
    common::keys(&mut r, &["enter"]);
    assert_eq!(r.app.target, Some(VehicleKey(2, 1)));
    assert!(
        status_line(&r).ends_with("target 2:1"),
        "{}",
        status_line(&r)
    );
    common::keys(&mut r, &[":"]);
    common::typed(&mut r, "target 9");
    common::keys(&mut r, &["enter"]);
    assert_eq!(r.app.target, Some(VehicleKey(2, 1)));
    let s = status_line(&r);
    assert!(s.contains("no autopilot 9 heard"), "{s}");
    common::keys(&mut r, &[":"]);
    common::typed(&mut r, "jump");
    common::keys(&mut r, &["enter"]);
    assert!(status_line(&r).contains("unknown command `jump`"));
    // The next key clears the message.
    common::keys(&mut r, &["down"]);
    assert!(status_line(&r).contains("q quit"));
}

#[test]
fn history_and_completion() {
    let mut r = runner("vehicles=2");
    common::keys(&mut r, &[":"]);
    common::typed(&mut r, "tar");
    common::keys(&mut r, &["tab"]);
    assert_eq!(r.app.ui.prompt.line.text, "target ");
    common::keys(&mut r, &["tab"]);
    // Two autopilots: their common prefix, both shown.
    assert_eq!(r.app.ui.prompt.line.text, "target ");
    let s = status_line(&r);
    assert!(s.contains(":target "), "{s}");
    common::typed(&mut r, "2");
    common::keys(&mut r, &["tab", "enter"]);
    assert_eq!(r.app.target, Some(VehicleKey(2, 1)));
    common::keys(&mut r, &[":", "up"]);
    assert_eq!(r.app.ui.prompt.line.text, "target 2:1");
    common::keys(&mut r, &["esc"]);
}

#[test]
fn link_command_opens_a_link_at_run_time() {
    let mut r = runner("sysid=1");
    common::keys(&mut r, &[":"]);
    common::typed(&mut r, "link sim://?sysid=5");
    common::keys(&mut r, &["enter"]);
    assert_eq!(r.app.links.len(), 2);
    let t = r.now() + 3_000_000;
    r.advance_to(t);
    assert!(
        r.app.vehicles.get(VehicleKey(5, 1)).is_some(),
        "the new link's vehicle"
    );
    assert_eq!(r.app.vehicles.get(VehicleKey(5, 1)).unwrap().links.len(), 1);
    assert!(r
        .app
        .vehicles
        .get(VehicleKey(5, 1))
        .unwrap()
        .links
        .contains(&1));
    // A bad spec is refused with the parser's reason, nothing opened.
    common::keys(&mut r, &[":"]);
    common::typed(&mut r, "link udpin:::14550");
    common::keys(&mut r, &["enter"]);
    assert_eq!(r.app.links.len(), 2);
    let s = status_line(&r);
    assert!(s.contains("14550") || s.contains('['), "{s}");
}

#[test]
fn route_pins_the_target_to_a_link() {
    let mut r = runner("sysid=1");
    common::keys(&mut r, &[":"]);
    common::typed(&mut r, "route 3");
    common::keys(&mut r, &["enter"]);
    assert!(status_line(&r).contains("no link 3"), "{}", status_line(&r));
    common::keys(&mut r, &[":"]);
    common::typed(&mut r, "route 0");
    common::keys(&mut r, &["enter"]);
    assert_eq!(r.app.sessions[&VehicleKey(1, 1)].pinned, Some(0));
    assert_eq!(r.app.route(VehicleKey(1, 1)), Some(0));
}

#[test]
fn help_lists_the_keys_and_the_commands_and_q_closes_it() {
    let mut r = runner("sysid=1");
    common::keys(&mut r, &["?"]);
    assert_eq!(r.app.ui.mode, Mode::Help);
    let s = common::screen(&r, 100, 90);
    assert!(s.contains("open the : command line"), "{s}");
    assert!(s.contains(":target SYSID[:COMPID]"), "{s}");
    common::keys(&mut r, &["q"]);
    assert_eq!(r.app.ui.mode, Mode::Normal);
    assert!(!r.app.quit);
    // From the prompt too.
    common::keys(&mut r, &[":"]);
    common::typed(&mut r, "help");
    common::keys(&mut r, &["enter"]);
    assert_eq!(r.app.ui.mode, Mode::Help);
}

#[test]
fn screen_keys_switch_screens() {
    let mut r = runner("sysid=1");
    common::keys(&mut r, &["6"]);
    assert_eq!(r.app.ui.screen, "camera");
    common::keys(&mut r, &["5"]);
    assert_eq!(r.app.ui.screen, "mission");
    common::keys(&mut r, &["2"]);
    assert_eq!(r.app.ui.screen, "parameters");
    common::keys(&mut r, &["1"]);
    assert_eq!(r.app.ui.screen, "overview");
}

#[test]
fn ctrl_c_quits_from_every_mode() {
    for first in [None, Some(":"), Some("?")] {
        let mut r = runner("sysid=1");
        if let Some(k) = first {
            common::keys(&mut r, &[k]);
        }
        common::keys(&mut r, &["ctrl-c"]);
        assert!(r.app.quit, "{first:?}");
    }
}
