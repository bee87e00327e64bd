//! The command palette (`ctrl-p`): searched, picked, filled in and sent on the simulated
//! ArduCopter (virtual clock), with the same checks and confirmation as the keys; and a command
//! to a camera component, reached through its vehicle's autopilot.

use mavterm::app::palette::TARGET;
use mavterm::app::{App, AppConfig, Effect, Event};
use mavterm::dialect::{self, MavCmd, MavMessage};
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::keymap::{Key, Mode};
use mavterm::link::{FrameParser, LinkSpec, ParserStats};
use mavterm::proto::commands::State;
use mavterm::proto::vehicles::VehicleKey;
use mavterm::sim::Sim;
use mavterm::ui::{buffer_to_text, render_to_buffer, Theme};
use mavterm::wire::{frame, Header, Version};

const SECOND: u64 = 1_000_000;

fn runner() -> VirtualRunner {
    let spec: LinkSpec = "sim://".parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    // The sim's EKF uses GPS from 5 s: arming is allowed after that.
    r.advance_to(6 * SECOND);
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

fn wait(r: &mut VirtualRunner, secs: f64) {
    let t = r.now() + (secs * SECOND as f64) as u64;
    r.advance_to(t);
}

fn sim(r: &VirtualRunner) -> &Sim {
    r.source(0).unwrap().as_any().downcast_ref::<Sim>().unwrap()
}

fn screen(r: &VirtualRunner) -> String {
    buffer_to_text(&render_to_buffer(&r.app, 80, 24, &Theme::PLAIN))
}

fn error(r: &VirtualRunner) -> String {
    r.app
        .ui
        .palette
        .as_ref()
        .unwrap()
        .error
        .clone()
        .unwrap_or_default()
}

#[test]
fn arm_from_the_palette_asks_first_then_arms_the_sim() {
    let mut r = runner();
    keys(&mut r, &["ctrl-p"]);
    assert_eq!(r.app.ui.mode, Mode::Edit);
    typed(&mut r, "arm");
    let p = r.app.ui.palette.as_ref().unwrap();
    let i = p.matches.iter().position(|&n| n == 400).unwrap();
    assert!(i < 3, "COMPONENT_ARM_DISARM at {i}");
    for _ in 0..i {
        keys(&mut r, &["down"]);
    }
    assert_eq!(r.app.ui.palette.as_ref().unwrap().selected(), Some(400));
    // up/down (and ctrl-n/ctrl-p) move the selection.
    keys(&mut r, &["down"]);
    assert_ne!(r.app.ui.palette.as_ref().unwrap().selected(), Some(400));
    keys(&mut r, &["ctrl-p"]);
    assert_eq!(r.app.ui.palette.as_ref().unwrap().selected(), Some(400));
    let s = screen(&r);
    assert!(
        s.contains("> arm") && s.contains("COMPONENT_ARM_DISARM"),
        "{s}"
    );
    insta::assert_snapshot!("palette_list_80x24", s);

    keys(&mut r, &["enter"]);
    typed(&mut r, "1");
    let s = screen(&r);
    for want in [
        "COMPONENT_ARM_DISARM (400)",
        "Arms / Disarms a component",
        "p1 Arm",
        "p2 Force",
        "[1:1",
        "COMMAND_LONG target 1:1 command 400 COMPONENT_ARM_DISARM confirmation 0",
        "p1=1 p2=0 p3=0 p4=0 p5=0 p6=0 p7=0",
    ] {
        assert!(s.contains(want), "{want}: {s}");
    }
    insta::assert_snapshot!("palette_form_80x24", s);

    // Dangerous: asked first, nothing sent yet.
    keys(&mut r, &["enter"]);
    assert!(r.app.ui.palette.is_none());
    assert_eq!(r.app.ui.mode, Mode::Normal);
    let c = r.app.ui.confirm.as_ref().expect("a confirmation");
    assert!(c.text.contains("COMPONENT_ARM_DISARM") && c.text.contains("1:1"));
    assert_eq!(
        r.app.sessions[&VehicleKey(1, 1)].commands.entries().len(),
        0
    );
    wait(&mut r, 0.5); // a `y` sooner than 0.3 s after the question does not count
    keys(&mut r, &["y"]);
    wait(&mut r, 2.0);
    assert!(sim(&r).vehicle(1).unwrap().armed());
    let e = r.app.sessions[&VehicleKey(1, 1)]
        .commands
        .entries()
        .next()
        .unwrap();
    assert_eq!((e.spec.target, e.spec.command), ((1, 1), 400));
    assert_eq!(e.spec.params, [1.0, 0., 0., 0., 0., 0., 0.]);
    assert_eq!(e.state, State::Done(0));
}

#[test]
fn a_wrong_field_or_target_keeps_the_palette_open_and_sends_nothing() {
    let mut r = runner();
    keys(&mut r, &["ctrl-p"]);
    typed(&mut r, "land");
    assert_eq!(r.app.ui.palette.as_ref().unwrap().selected(), Some(21));
    keys(&mut r, &["tab"]); // picks, like enter
    typed(&mut r, "x");
    keys(&mut r, &["enter"]);
    assert!(
        error(&r).contains("param1 (Abort Alt): `x` is not a number"),
        "{}",
        error(&r)
    );
    assert!(screen(&r).contains("`x` is not a number"));
    keys(&mut r, &["backspace"]);
    // Up from the first field is the target.
    keys(&mut r, &["up"]);
    assert_eq!(
        r.app
            .ui
            .palette
            .as_ref()
            .unwrap()
            .form
            .as_ref()
            .unwrap()
            .focus,
        TARGET
    );
    for (target, why) in [
        ("9:1", "9:1 has not been heard"),
        ("1:100", "1:100 has not been heard"),
        ("one", "SYSID:COMPID"),
    ] {
        keys(&mut r, &["ctrl-u"]);
        typed(&mut r, target);
        keys(&mut r, &["enter"]);
        assert!(error(&r).contains(why), "{target}: {}", error(&r));
    }
    assert_eq!(
        r.app.sessions[&VehicleKey(1, 1)].commands.entries().len(),
        0
    );
    // Esc: back to the list, then closed.
    keys(&mut r, &["esc"]);
    let p = r.app.ui.palette.as_ref().unwrap();
    assert!(p.form.is_none());
    assert_eq!(p.query.text, "land");
    keys(&mut r, &["esc"]);
    assert!(r.app.ui.palette.is_none());
    assert_eq!(r.app.ui.mode, Mode::Normal);
    // Not dangerous: sent at once (nan allowed), its outcome in the status bar.
    keys(&mut r, &["ctrl-p"]);
    typed(&mut r, "land");
    keys(&mut r, &["enter"]);
    for _ in 0..3 {
        keys(&mut r, &["tab"]);
    }
    typed(&mut r, "nan");
    keys(&mut r, &["enter"]);
    assert!(r.app.ui.palette.is_none() && r.app.ui.confirm.is_none());
    let (_, msg) = r.app.ui.message.clone().unwrap();
    assert_eq!(msg, "NAV_LAND: sent");
    let e = r.app.sessions[&VehicleKey(1, 1)]
        .commands
        .entries()
        .next()
        .unwrap();
    assert_eq!(e.spec.command, 21);
    assert!(e.spec.params[3].is_nan());
}

/// Frames from (sysid, compid) as the link would hand them to the core.
fn frames_from(key: (u8, u8), seq: u8, msg: &MavMessage) -> Event {
    let bytes = frame::encode(
        Version::V2,
        Header {
            sysid: key.0,
            compid: key.1,
            seq,
        },
        msg,
    );
    Event::Frames {
        link: 0,
        frames: FrameParser::new().parse_all(&bytes),
        stats: ParserStats::default(),
    }
}

fn heartbeat(mavtype: dialect::MavType, autopilot: dialect::MavAutopilot) -> MavMessage {
    MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype,
        autopilot,
        base_mode: dialect::MavModeFlag::empty(),
        system_status: dialect::MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
    })
}

#[test]
fn a_camera_is_reached_through_its_vehicle_and_its_ack_is_matched() {
    let mut a = App::new(AppConfig {
        links: vec!["x".into()],
        request_streams: false,
        fetch_params: false,
        ..AppConfig::default()
    });
    a.update(
        0,
        frames_from(
            (1, 1),
            0,
            &heartbeat(
                dialect::MavType::MAV_TYPE_QUADROTOR,
                dialect::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            ),
        ),
    );
    a.update(
        0,
        frames_from(
            (1, 100),
            0,
            &heartbeat(
                dialect::MavType::MAV_TYPE_CAMERA,
                dialect::MavAutopilot::MAV_AUTOPILOT_INVALID,
            ),
        ),
    );
    assert_eq!(a.target, Some(VehicleKey(1, 1)));
    let key = |a: &mut App, k: &str| a.update(1000, Event::Key(k.parse::<Key>().unwrap()));
    key(&mut a, "ctrl-p");
    for c in "image start".chars() {
        a.update(1000, Event::Key(Key::ch(c)));
    }
    assert_eq!(a.ui.palette.as_ref().unwrap().selected(), Some(2000));
    key(&mut a, "enter");
    key(&mut a, "tab");
    a.update(1000, Event::Key(Key::ch('2'))); // interval 2 s
    key(&mut a, "backtab");
    key(&mut a, "backtab");
    key(&mut a, "ctrl-u");
    for c in "1:100".chars() {
        a.update(1000, Event::Key(Key::ch(c)));
    }
    let form = a.ui.palette.as_ref().unwrap().form.as_ref().unwrap();
    assert_eq!(
        form.preview()[0],
        "COMMAND_LONG target 1:100 command 2000 IMAGE_START_CAPTURE confirmation 0"
    );
    let fx = key(&mut a, "enter");
    assert!(a.ui.palette.is_none(), "{:?}", a.ui.palette);
    let sent: Vec<&MavMessage> = fx
        .iter()
        .filter_map(|e| match e {
            Effect::Send { msg, .. } => Some(msg),
            _ => None,
        })
        .collect();
    let [MavMessage::COMMAND_LONG(c)] = sent.as_slice() else {
        panic!("{sent:?}")
    };
    assert_eq!((c.target_system, c.target_component), (1, 100));
    assert_eq!(c.command, MavCmd::MAV_CMD_IMAGE_START_CAPTURE);
    assert_eq!((c.param1, c.param2, c.confirmation), (0.0, 2.0, 0));
    // The camera's answer closes the command in its vehicle's queue.
    let ack = MavMessage::COMMAND_ACK(dialect::COMMAND_ACK_DATA {
        command: MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
        result: dialect::MavResult::MAV_RESULT_ACCEPTED,
        progress: 0,
        result_param2: 0,
        target_system: 255,
        target_component: 190,
    });
    a.update(200_000, frames_from((1, 100), 1, &ack));
    // (The camera's heartbeat also started its discovery: a REQUEST_MESSAGE of its own.)
    let e = a.sessions[&VehicleKey(1, 1)]
        .commands
        .entries()
        .find(|e| e.spec.command == MavCmd::MAV_CMD_IMAGE_START_CAPTURE as u16)
        .unwrap();
    assert_eq!(e.spec.target, (1, 100));
    assert_eq!(e.state, State::Done(0));
}

#[test]
fn the_takeoff_form_shows_units_and_the_command_long_to_be_sent() {
    let mut r = runner();
    keys(&mut r, &["ctrl-p"]);
    typed(&mut r, "takeoff");
    assert_eq!(r.app.ui.palette.as_ref().unwrap().selected(), Some(22));
    keys(&mut r, &["enter", "down", "down", "down"]);
    typed(&mut r, "nan");
    keys(&mut r, &["tab", "tab", "tab"]);
    typed(&mut r, "10");
    let s = screen(&r);
    for want in [
        "NAV_TAKEOFF (22)",
        "p1 Pitch",
        "p4 Yaw",
        "p7 Altitude",
        "] m ",
        "] deg ",
        "COMMAND_LONG target 1:1 command 22 NAV_TAKEOFF confirmation 0",
        "p1=0 p2=0 p3=0 p4=nan p5=0 p6=0 p7=10",
    ] {
        assert!(s.contains(want), "{want}: {s}");
    }
    insta::assert_snapshot!("palette_takeoff_form_80x24", s);
    keys(&mut r, &["esc", "esc"]);
    assert!(r.app.ui.palette.is_none());
    assert_eq!(
        r.app.sessions[&VehicleKey(1, 1)].commands.entries().len(),
        0
    );
}

/// The COMMAND_LONGs of `command` that left for the sim since the last call, as parsed from the
/// bytes on the wire.
fn sent_commands(r: &mut VirtualRunner, command: MavCmd) -> Vec<dialect::COMMAND_LONG_DATA> {
    r.take_sent()
        .into_iter()
        .flat_map(|(_, _, bytes)| FrameParser::new().parse_all(&bytes))
        .filter_map(|f| match f.message.as_deref() {
            Some(MavMessage::COMMAND_LONG(c)) if c.command == command => Some(c.clone()),
            _ => None,
        })
        .collect()
}

/// `ctrl-p`, the query typed, the first match picked (it must be `command`).
fn pick(r: &mut VirtualRunner, query: &str, command: MavCmd) {
    keys(r, &["ctrl-p"]);
    typed(r, query);
    assert_eq!(
        r.app.ui.palette.as_ref().unwrap().selected(),
        Some(command as u16),
        "{query}"
    );
    keys(r, &["enter"]);
}

#[test]
fn empty_fields_send_the_documented_defaults_on_the_wire() {
    let mut r = runner();
    r.capture_sent();
    // DO_CHANGE_SPEED, every field empty. common.xml: speed and throttle "-1 indicates no
    // change"; param4-7 reserved, default="0"; the speed type (SPEED_TYPE) has no default: 0.
    pick(&mut r, "change speed", MavCmd::MAV_CMD_DO_CHANGE_SPEED);
    let s = screen(&r);
    for want in [
        "DO_CHANGE_SPEED (178)",
        "Change speed and/or throttle set points.",
        "p2 Speed",
        "p3 Throttle",
        "[-1          ] m/s",
        "[-1          ] %",
        "p1=0 p2=-1 p3=-1 p4=0 p5=0 p6=0 p7=0",
        // The focused field's documentation: the enum's values.
        "SPEED_TYPE: 0 AIRSPEED, 1 GROUNDSPEED",
    ] {
        assert!(s.contains(want), "{want}\n{s}");
    }
    insta::assert_snapshot!("palette_change_speed_defaults_80x24", s);
    // On the throttle: its description, range and default from the XML.
    keys(&mut r, &["tab", "tab"]);
    let s = screen(&r);
    assert!(
        s.contains("p3 Throttle (%): Throttle (-1 indicates no change"),
        "{s}"
    );
    assert!(s.contains("min -2") && s.contains("empty sends -1"), "{s}");
    // A number typed replaces the default.
    keys(&mut r, &["backtab"]);
    typed(&mut r, "5");
    keys(&mut r, &["enter"]);
    assert!(r.app.ui.palette.is_none(), "{:?}", r.app.ui.palette);
    wait(&mut r, 0.5);
    let sent = sent_commands(&mut r, MavCmd::MAV_CMD_DO_CHANGE_SPEED);
    let [c] = sent.as_slice() else {
        panic!("{sent:?}")
    };
    assert_eq!((c.target_system, c.target_component), (1, 1));
    assert_eq!(
        [c.param1, c.param2, c.param3, c.param4, c.param5, c.param6, c.param7],
        [0.0, 5.0, -1.0, 0.0, 0.0, 0.0, 0.0]
    );

    // IMAGE_START_CAPTURE: param7 reserved with default="NaN" in common.xml.
    pick(&mut r, "image start", MavCmd::MAV_CMD_IMAGE_START_CAPTURE);
    assert!(screen(&r).contains("p7=nan"), "{}", screen(&r));
    keys(&mut r, &["enter"]);
    wait(&mut r, 0.5);
    let sent = sent_commands(&mut r, MavCmd::MAV_CMD_IMAGE_START_CAPTURE);
    let [c] = sent.as_slice() else {
        panic!("{sent:?}")
    };
    assert!(c.param7.is_nan(), "{c:?}");
    assert_eq!((c.param1, c.param5, c.param6), (0.0, 0.0, 0.0));
}

#[test]
fn a_command_never_described_by_hand_has_the_xmls_description_and_labels() {
    let mut r = runner();
    keys(&mut r, &["ctrl-p"]);
    typed(&mut r, "do_set_servo");
    assert_eq!(
        r.app.ui.palette.as_ref().unwrap().selected(),
        Some(MavCmd::MAV_CMD_DO_SET_SERVO as u16)
    );
    // In the list: common.xml's <description>.
    let s = screen(&r);
    assert!(s.contains("Set a servo to a desired PWM value."), "{s}");
    keys(&mut r, &["enter"]);
    let s = screen(&r);
    for want in [
        "DO_SET_SERVO (183)",
        "Set a servo to a desired PWM value.",
        "p1 Instance",
        "p2 PWM",
        "] us ",
        "p3 (unused)",
        "p1 Instance: Servo instance number. min 0, increment 1, empty sends 0.",
    ] {
        assert!(s.contains(want), "{want}\n{s}");
    }
    insta::assert_snapshot!("palette_set_servo_form_80x24", s);
}
