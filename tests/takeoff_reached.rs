//! "Take-off done" when the altitude is reached, not at NAV_TAKEOFF's ACK: the status bar goes
//! from *started* to the ACK (`NAV_TAKEOFF to 1:1: ACCEPTED; climbing: 4.3 m of 10.0 m`) to
//! `take-off: 10.0 m reached` only once the vehicle's height above home (GLOBAL_POSITION_INT
//! `relative_alt`) is within 5 % (at least 0.5 m) of it; a disarm, a mode change or a climb
//! that takes too long ends the wait with a clear line, and nothing is ever resent. `wp start`
//! on a disarmed ArduCopter switches to AUTO only once the take-off's altitude is reached
//! (ArduCopter refuses AUTO on the ground, armed, without a NAV_TAKEOFF first:
//! `Auto: Missing Takeoff Cmd`).
//!
//! On `sim://` (ArduCopter; it climbs at 1.5 m/s in GUIDED) on the virtual clock, and on the
//! core fed by hand where the vehicle must misbehave.

mod common;

use common::{command, hear, sim, wait, yes};

use mavterm::app::{App, AppConfig, Event};
use mavterm::dialect::{self, MavMessage};
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::keymap::Key;
use mavterm::link::LinkSpec;
use mavterm::ui::{buffer_to_text, render_to_buffer, Theme};

const SECOND: u64 = 1_000_000;
const REACHED: &str = "take-off: 10.0 m reached";

/// The status bar's part after the separator, on a `w`-column screen.
fn tail_of(app: &App, w: u16) -> String {
    let s = buffer_to_text(&render_to_buffer(app, w, 30, &Theme::PLAIN));
    let s = s.lines().last().unwrap_or("").trim_end().to_string();
    s.split_once('│')
        .map_or(s.clone(), |(_, t)| t.trim().to_string())
}

fn tail(r: &VirtualRunner) -> String {
    tail_of(&r.app, 200)
}

/// sim:// 10 s in: GPS fix and home (6 s) known, disarmed in STABILIZE.
fn runner() -> VirtualRunner {
    let spec: LinkSpec = "sim://?sysid=1".parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    r.advance_to(10 * SECOND);
    r
}

/// What one step of the virtual clock showed.
#[derive(Debug)]
struct Sample {
    t: u64,
    tail: String,
    /// The sim's own height above home.
    sim_alt: f64,
    /// The take-off's end told so far (notice or outcome).
    said: bool,
}

fn said(r: &VirtualRunner, text: &str) -> bool {
    r.app.notices.iter().any(|n| n.text == text) || r.app.ui.outcomes.iter().any(|o| o.text == text)
}

/// Step the clock by 50 ms until `done` or `secs` pass, sampling the screen and the sim.
fn sample(r: &mut VirtualRunner, secs: f64, done: impl Fn(&Sample) -> bool) -> Vec<Sample> {
    let mut out = Vec::new();
    for _ in 0..(secs * 20.0) as usize {
        wait(r, 0.05);
        let s = Sample {
            t: r.now(),
            tail: tail(r),
            sim_alt: sim(r).vehicle(1).unwrap().relative_alt_m(),
            said: said(r, REACHED),
        };
        let stop = done(&s);
        out.push(s);
        if stop {
            break;
        }
    }
    out
}

/// `4.3` from `…; climbing: 4.3 m of 10.0 m`.
fn climbing_at(tail: &str) -> Option<f64> {
    let rest = tail.split_once("; climbing: ")?.1;
    rest.split_once(" m of ")?.0.parse().ok()
}

#[test]
fn on_the_sim_the_take_off_is_done_when_the_sim_is_there_not_at_the_ack() {
    let mut r = runner();
    command(&mut r, "takeoff 10");
    yes(&mut r);
    assert_eq!(tail(&r), "takeoff to 10 m: started");
    let samples = sample(&mut r, 30.0, |s| s.tail == REACHED);
    let tails: Vec<&str> = samples.iter().map(|s| s.tail.as_str()).collect();
    let ack = samples
        .iter()
        .position(|s| s.tail.starts_with("NAV_TAKEOFF to 1:1: ACCEPTED"))
        .unwrap_or_else(|| panic!("no ACK on the status bar: {tails:?}"));
    let done = samples
        .iter()
        .position(|s| s.tail == REACHED)
        .unwrap_or_else(|| panic!("never reached: {tails:?}"));
    // At the ACK the vehicle is still on the ground, and nothing says the take-off is done.
    assert!(samples[ack].sim_alt < 1.0, "{:?}", samples[ack]);
    assert!(ack < done);
    for s in &samples[..done] {
        assert!(!s.said, "said before the altitude: {s:?}");
    }
    // Meanwhile the line keeps the ACK and says how high the vehicle is (what we heard of it,
    // never more than the sim's own height and below the line of 9.5 m).
    let mut heard = Vec::new();
    for s in &samples[ack..done] {
        assert!(
            s.tail.starts_with("NAV_TAKEOFF to 1:1: ACCEPTED; climbing"),
            "{s:?}"
        );
        if let Some(h) = climbing_at(&s.tail) {
            assert!(h < 9.5 && h <= s.sim_alt + 0.05, "{s:?}");
            heard.push(h);
        }
    }
    assert!(heard.windows(2).all(|w| w[0] <= w[1]), "{heard:?}");
    assert!(heard.iter().any(|h| *h > 5.0), "{heard:?}");
    // Reached once the sim is within 0.5 m of 10 m; at the sim's 1.5 m/s that is > 6 s after
    // the ACK.
    let at = &samples[done];
    assert!(at.sim_alt >= 9.5 && at.sim_alt <= 10.0, "{at:?}");
    assert!(at.t - samples[ack].t >= 6 * SECOND, "{at:?}");
    assert!(said(&r, REACHED));
    assert!(
        !r.app
            .notices
            .iter()
            .any(|n| n.text.contains("takeoff 10 m: done")
                || (n.text.contains("confirmed") && n.text.contains("take"))),
        "the old end at the ACK is gone"
    );
    // It stays, and `:messages` has it last.
    wait(&mut r, 5.0);
    assert_eq!(tail(&r), REACHED);
    assert_eq!(
        r.app.ui.outcomes.back().map(|o| o.text.as_str()),
        Some(REACHED)
    );
    command(&mut r, "messages");
    let s = buffer_to_text(&render_to_buffer(&r.app, 160, 30, &Theme::PLAIN));
    assert!(s.contains(" Outcomes ") && s.contains(REACHED), "{s}");
}

#[test]
fn on_the_sim_a_disarm_mid_climb_ends_the_wait_and_nothing_is_resent() {
    let mut r = runner();
    command(&mut r, "takeoff 10");
    yes(&mut r);
    let samples = sample(&mut r, 20.0, |s| s.sim_alt > 3.0);
    assert!(samples.last().unwrap().sim_alt > 3.0, "{samples:?}");
    // The operator force-disarms (asked first): the vehicle falls, its heartbeat says disarmed.
    command(&mut r, "disarm force");
    r.capture_sent();
    yes(&mut r);
    wait(&mut r, 3.0);
    assert!(!sim(&r).vehicle(1).unwrap().armed());
    let stop = r
        .app
        .notices
        .iter()
        .find(|n| n.text.starts_with("take-off to 10.0 m: disarmed at "))
        .unwrap_or_else(|| panic!("{:?}", r.app.notices));
    assert!(stop.text.ends_with(" m; stopped"), "{}", stop.text);
    // The last action is the disarm: its answer is the line.
    assert_eq!(tail(&r), "COMPONENT_ARM_DISARM to 1:1: ACCEPTED");
    wait(&mut r, 30.0);
    assert!(!said(&r, REACHED));
    // After the disarm only that command went: no take-off resent, nothing else.
    let frames: Vec<Vec<u8>> = r.take_sent().into_iter().map(|(_, _, f)| f).collect();
    let ops = common::operator_messages(&frames, &[75, 76, 11]);
    let cmds: Vec<u64> = ops.iter().filter_map(|m| m["command"].as_u64()).collect();
    assert_eq!(cmds, vec![400], "{ops:?}");
    assert_eq!(ops[0]["param2"].as_f64(), Some(21196.0), "forced: {ops:?}");
}

/// Home, a take-off to 20 m (relative frame 3) and two waypoints at 25 m.
const MISSION: &str = "QGC WPL 110\n\
0\t1\t0\t16\t0\t0\t0\t0\t-35.3632621\t149.1652374\t584\t1\n\
1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t20\t1\n\
2\t0\t3\t16\t0\t0\t0\t0\t-35.3622621\t149.1652374\t25\t1\n\
3\t0\t3\t16\t0\t0\t0\t0\t-35.3622621\t149.1662374\t25\t1\n";

#[test]
fn on_the_sim_wp_start_disarmed_switches_to_auto_only_at_the_take_offs_altitude() {
    let mut r = runner();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.waypoints");
    std::fs::write(&path, MISSION).unwrap();
    command(&mut r, &format!("wp load {}", path.display()));
    command(&mut r, "wp upload");
    wait(&mut r, 3.0);
    command(&mut r, "wp start");
    assert!(r.app.ui.confirm.is_some(), "{:?}", r.app.ui.message);
    r.capture_sent();
    yes(&mut r);
    assert_eq!(
        tail(&r),
        "mission start: GUIDED, arm, take off to 20 m, AUTO, start mission: started"
    );
    // Each COMMAND_LONG with the time it went and the sim's height then.
    let mut sent: Vec<(u64, f64, Vec<u8>)> = Vec::new();
    let mut tails: Vec<(f64, String)> = Vec::new();
    for _ in 0..(40 * 20) {
        wait(&mut r, 0.05);
        let alt = sim(&r).vehicle(1).unwrap().relative_alt_m();
        for (t, _, f) in r.take_sent() {
            if common::frame_msgid(&f) == 76 {
                sent.push((t, alt, f));
            }
        }
        let t = tail(&r);
        if tails.last().is_none_or(|(_, l)| *l != t) {
            tails.push((alt, t.clone()));
        }
        if t == "mission start: done" {
            break;
        }
    }
    let frames: Vec<Vec<u8>> = sent.iter().map(|s| s.2.clone()).collect();
    let decoded = common::pymavlink_decode(&frames);
    // DO_SET_MODE 176 with param2 3 is AUTO (ArduCopter); MISSION_START 300.
    let auto = decoded
        .iter()
        .position(|m| m["command"] == 176 && m["param2"].as_f64() == Some(3.0))
        .unwrap_or_else(|| panic!("no AUTO: {decoded:?} {tails:?}"));
    let takeoff = decoded
        .iter()
        .position(|m| m["command"] == 22)
        .unwrap_or_else(|| panic!("no NAV_TAKEOFF: {decoded:?}"));
    assert!(takeoff < auto);
    // 20 m less 5 % is 19 m: AUTO only once the sim was there (its height when AUTO went).
    assert!(
        sent[auto].1 >= 19.0,
        "AUTO at {} m: {tails:?}",
        sent[auto].1
    );
    assert!(sent[takeoff].1 < 1.0, "{tails:?}");
    assert!(
        decoded[auto + 1..].iter().any(|m| m["command"] == 300),
        "{decoded:?}"
    );
    // The status bar showed the climb, and ends with the sequence's end; the take-off's end
    // was told (in the messages) before AUTO went.
    assert!(
        tails
            .iter()
            .any(|(_, t)| t.starts_with("NAV_TAKEOFF to 1:1: ACCEPTED; climbing: ")),
        "{tails:?}"
    );
    assert_eq!(
        tails.last().map(|t| t.1.as_str()),
        Some("mission start: done")
    );
    let told = r
        .app
        .notices
        .iter()
        .find(|n| n.text == "take-off: 20.0 m reached")
        .unwrap_or_else(|| panic!("{:?}", r.app.notices));
    assert!(told.t <= sent[auto].0, "{} {}", told.t, sent[auto].0);
    assert_eq!(
        r.app.ui.outcomes.back().map(|o| o.text.as_str()),
        Some("mission start: done")
    );
    assert_eq!(sim(&r).vehicle(1).unwrap().custom_mode(), 3, "flying AUTO");
}

// The core, fed by hand: a vehicle that misbehaves while climbing.

const ARMED: u8 = 128 | 1; // MAV_MODE_FLAG_SAFETY_ARMED | CUSTOM_MODE_ENABLED

/// ArduCopter 1:1's HEARTBEAT in `mode`, armed or not.
fn heartbeat(mode: u32, armed: bool) -> MavMessage {
    MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
        mavtype: dialect::MavType::MAV_TYPE_QUADROTOR,
        autopilot: dialect::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode: dialect::MavModeFlag::from_bits_truncate(if armed { ARMED } else { 1 }),
        system_status: dialect::MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
        custom_mode: mode,
    })
}

fn position(relative_alt_mm: i32) -> MavMessage {
    MavMessage::GLOBAL_POSITION_INT(dialect::GLOBAL_POSITION_INT_DATA {
        lat: -353_632_621,
        lon: 1_491_652_374,
        alt: 584_000 + relative_alt_mm,
        relative_alt: relative_alt_mm,
        ..Default::default()
    })
}

fn takeoff_ack() -> MavMessage {
    MavMessage::COMMAND_ACK(dialect::COMMAND_ACK_DATA {
        command: dialect::MavCmd::MAV_CMD_NAV_TAKEOFF,
        result: dialect::MavResult::MAV_RESULT_ACCEPTED,
        ..Default::default()
    })
}

const GUIDED: u32 = 4;

/// An app that has heard 1:1 armed in GUIDED at 0 s and sent `takeoff 10` (one step: it is in
/// GUIDED and armed), its ACK heard at 2 s. The commands sent (ids 75, 76, 11) after the ACK
/// are checked by the caller.
fn climbing_app() -> App {
    let mut app = App::new(AppConfig {
        links: vec!["x".into()],
        request_streams: false,
        fetch_params: false,
        ..AppConfig::default()
    });
    hear(&mut app, 0, &heartbeat(GUIDED, true));
    let key = |app: &mut App, t: u64, k: &str| app.update(t, Event::Key(k.parse().unwrap()));
    key(&mut app, SECOND, ":");
    for c in "takeoff 10".chars() {
        app.update(SECOND, Event::Key(Key::ch(c)));
    }
    key(&mut app, SECOND, "enter");
    key(&mut app, SECOND + SECOND / 2, "y");
    assert_eq!(tail_of(&app, 200), "takeoff to 10 m: started");
    hear(&mut app, 2 * SECOND, &takeoff_ack());
    assert_eq!(
        tail_of(&app, 200),
        "NAV_TAKEOFF to 1:1: ACCEPTED; climbing to 10.0 m"
    );
    app
}

/// The operator's commands among what the core sent (COMMAND_INT, COMMAND_LONG, SET_MODE).
fn commands(fx: &[mavterm::app::Effect]) -> usize {
    common::sent_frames(fx)
        .iter()
        .filter(|f| [75, 76, 11].contains(&common::frame_msgid(f)))
        .count()
}

#[test]
fn a_vehicle_that_disarms_while_climbing_ends_the_take_off_on_the_status_bar() {
    let mut app = climbing_app();
    let mut n = commands(&hear(&mut app, 2_200_000, &position(1_800)));
    n += commands(&hear(&mut app, 3 * SECOND, &heartbeat(GUIDED, true)));
    n += commands(&hear(&mut app, 3_200_000, &position(4_000)));
    assert_eq!(
        tail_of(&app, 200),
        "NAV_TAKEOFF to 1:1: ACCEPTED; climbing: 4.0 m of 10.0 m"
    );
    n += commands(&hear(&mut app, 4 * SECOND, &heartbeat(GUIDED, false)));
    let stop = "take-off to 10.0 m: disarmed at 4.0 m; stopped";
    assert_eq!(tail_of(&app, 200), stop);
    // Heights after that change nothing.
    n += commands(&hear(&mut app, 5 * SECOND, &position(10_000)));
    assert_eq!(tail_of(&app, 200), stop);
    assert_eq!(app.ui.outcomes.back().map(|o| o.text.as_str()), Some(stop));
    assert_eq!(n, 0, "nothing sent after the ACK");
}

#[test]
fn a_vehicle_that_leaves_guided_while_climbing_ends_the_take_off() {
    let mut app = climbing_app();
    hear(&mut app, 2_500_000, &position(2_500));
    // LAND (9), switched to by the vehicle (a failsafe, the pilot's switch).
    let n = commands(&hear(&mut app, 3 * SECOND, &heartbeat(9, true)));
    assert_eq!(
        tail_of(&app, 200),
        "take-off to 10.0 m: mode changed to LAND at 2.5 m; stopped"
    );
    assert_eq!(n, 0);
}

#[test]
fn a_climb_that_never_gets_there_is_no_longer_waited_for_and_nothing_is_resent() {
    let mut app = climbing_app();
    let mut n = 0;
    // Stuck at 6 m (a payload too heavy, a wrong altitude source), in view for 40 s.
    for i in 0..80u64 {
        let t = 2 * SECOND + i * SECOND / 2;
        n += commands(&hear(&mut app, t, &position(6_000)));
        if i % 2 == 0 {
            n += commands(&hear(&mut app, t, &heartbeat(GUIDED, true)));
        }
        n += commands(&app.update(t + SECOND / 4, Event::Tick));
        // 10 s and 2 s a metre: 30 s after the ACK at 2 s.
        if t + SECOND / 4 < 32 * SECOND {
            assert_eq!(
                tail_of(&app, 200),
                "NAV_TAKEOFF to 1:1: ACCEPTED; climbing: 6.0 m of 10.0 m",
                "at {t}"
            );
        }
    }
    let end = "take-off to 10.0 m: not reached after 30 s (at 6.0 m); no longer waited for, \
               nothing resent (watch the vehicle)";
    assert_eq!(tail_of(&app, 200), end);
    assert_eq!(app.ui.outcomes.back().map(|o| o.text.as_str()), Some(end));
    assert_eq!(n, 0, "nothing resent");
}
