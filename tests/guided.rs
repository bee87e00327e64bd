//! Guided control on the simulated ArduCopter (virtual clock): Fly mode's velocity nudges move
//! the vehicle, a reported key release stops it at once, a silent key stops it within the
//! deadman time, a nudge outside GUIDED is refused; pymavlink's reading of our
//! SET_POSITION_TARGET_LOCAL_NED and DO_REPOSITION (COMMAND_INT) frames.

mod common;

use common::{command, sim, wait};

use mavterm::app::{AppConfig, Effect, Event};
use mavterm::driver::virtual_time::{Driver, VirtualRunner};
use mavterm::keymap::Key;
use mavterm::link::LinkSpec;

const SECOND: u64 = 1_000_000;
const MS: u64 = 1_000;

fn runner() -> VirtualRunner {
    let spec: LinkSpec = "sim://".parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    r.advance_to(6 * SECOND);
    r
}

/// Horizontal speed of the sim's GUIDED velocity target (m/s), 0 when it has none.
fn target_speed(r: &VirtualRunner) -> f64 {
    sim(r)
        .vehicle(1)
        .unwrap()
        .guided_velocity()
        .map_or(0.0, |(n, e, _)| (n * n + e * e).sqrt())
}

/// Flying in GUIDED at 10 m, in Fly mode.
fn flying() -> VirtualRunner {
    let mut r = runner();
    command(&mut r, "takeoff 10");
    common::yes(&mut r);
    wait(&mut r, 14.0);
    assert!((sim(&r).vehicle(1).unwrap().relative_alt_m() - 10.0).abs() < 0.5);
    common::keys(&mut r, &["F"]);
    assert!(r.app.nudge.active());
    r
}

/// Hold `key` for `secs` as a terminal repeats it (every 30 ms).
fn hold(r: &mut VirtualRunner, key: &str, secs: f64) {
    let end = r.now() + (secs * SECOND as f64) as u64;
    while r.now() < end {
        common::keys(r, &[key]);
        let t = r.now() + 30 * MS;
        r.advance_to(t);
    }
}

#[test]
fn a_nudge_moves_the_vehicle_and_a_release_stops_it_at_once() {
    let mut r = flying();
    let start = sim(&r).vehicle(1).unwrap().position_ne();
    hold(&mut r, "up", 3.0);
    // 2 m/s forward (the default speed), flown.
    assert!(
        (target_speed(&r) - 2.0).abs() < 1e-6,
        "{}",
        target_speed(&r)
    );
    let s = common::screen(&r, 80, 24);
    assert!(s.contains("FLY ↑2.0 m/s"), "{s}");
    let now = sim(&r).vehicle(1).unwrap().position_ne();
    let moved = ((now.0 - start.0).powi(2) + (now.1 - start.1).powi(2)).sqrt();
    assert!(moved > 3.0, "moved {moved} m");
    r.release("up".parse().unwrap());
    let t = r.now() + 5 * MS;
    r.advance_to(t);
    assert_eq!(target_speed(&r), 0.0);
    let s = common::screen(&r, 80, 24);
    assert!(s.contains("FLY 2.0 m/s"), "{s}");
    // The terminal reports releases: the status bar says they stop a nudge.
    assert!(s.contains("release keys"), "{s}");
    // esc leaves Fly mode; arrows scroll again.
    common::keys(&mut r, &["esc"]);
    assert!(!r.app.nudge.active());
}

#[test]
fn a_silent_key_stops_within_the_deadman_time() {
    let mut r = flying();
    common::keys(&mut r, &["3"]); // 5 m/s
    hold(&mut r, "right", 1.0);
    assert!((target_speed(&r) - 5.0).abs() < 1e-6);
    let last_key = r.now() - 30 * MS;
    // The key repeated: still flying 0.25 s after its last repeat; stopped by 0.3 s (the
    // default deadman) + 1 ms, not 0.8 s.
    r.advance_to(last_key + 250 * MS);
    assert!((target_speed(&r) - 5.0).abs() < 1e-6);
    r.advance_to(last_key + 301 * MS);
    assert_eq!(target_speed(&r), 0.0);
    let s = common::screen(&r, 80, 24);
    assert!(
        s.contains("deadman 0.3 s"),
        "the status bar says what stops it: {s}"
    );
}

#[test]
fn a_nudge_outside_guided_is_refused_and_nothing_is_sent() {
    let mut r = runner();
    command(&mut r, "mode stabilize");
    wait(&mut r, 2.0);
    common::keys(&mut r, &["F"]);
    let fx = r.app.update(
        r.now(),
        Event::Key(Key::plain(mavterm::keymap::KeyCode::Up)),
    );
    assert!(
        !fx.iter().any(|e| matches!(e, Effect::Send { msg, .. }
            if matches!(msg, mavterm::dialect::MavMessage::SET_POSITION_TARGET_LOCAL_NED(_)))),
        "{fx:?}"
    );
    let m = r.app.ui.message.clone().unwrap().1;
    assert!(
        m.contains("nudge refused") && m.contains("not armed"),
        "{m}"
    );
    // Armed in STABILIZE: refused too, saying why.
    common::keys(&mut r, &["esc"]);
    command(&mut r, "arm");
    common::yes(&mut r);
    wait(&mut r, 2.0);
    assert!(sim(&r).vehicle(1).unwrap().armed());
    common::keys(&mut r, &["F"]);
    let fx = r.app.update(
        r.now(),
        Event::Key(Key::plain(mavterm::keymap::KeyCode::Up)),
    );
    assert!(
        !fx.iter().any(|e| matches!(e, Effect::Send { .. })),
        "{fx:?}"
    );
    let m = r.app.ui.message.clone().unwrap().1;
    assert!(m.contains("STABILIZE, not GUIDED"), "{m}");
}

#[test]
fn a_replayed_nudge_and_release_fly_and_stop_the_sim() {
    use mavterm::headless::replay::{run_script, ReplayOptions};
    use mavterm::headless::script::Script;
    let script = Script::load(&common::test_path("data/replay/nudge.txt")).unwrap();
    let mut r =
        VirtualRunner::from_specs(&["sim://".parse().unwrap()], AppConfig::default()).unwrap();
    let mut out = Vec::new();
    let opts = ReplayOptions {
        size: (80, 24),
        ..ReplayOptions::default()
    };
    let outcome = run_script(&script, &mut r, &opts, &mut out).unwrap();
    assert!(outcome.completed);
    let text = String::from_utf8(out).unwrap();
    let (nudging, released) = text.split_once("=== snapshot released").unwrap();
    assert!(nudging.contains("FLY ↑2.0 m/s"), "{nudging}");
    assert!(released.contains("FLY 2.0 m/s"), "{released}");
    // The snapshot just after the release (23.11 s, before any deadman) shows no direction held;
    // the sim holds.
    assert_eq!(target_speed(&r), 0.0);
    let (n, e) = sim(&r).vehicle(1).unwrap().position_ne();
    assert!(n.hypot(e) > 0.5, "flew {n} {e}");
}

/// The frames of `fx` that pymavlink should read.
fn decoded(fx: &[Effect], name: &str) -> Vec<serde_json::Value> {
    let frames: Vec<Vec<u8>> = fx
        .iter()
        .filter_map(|e| match e {
            Effect::Send { frame, .. } => Some(frame.clone()),
            _ => None,
        })
        .collect();
    common::pymavlink_decode(&frames)
        .into_iter()
        .filter(|v| v["name"] == name)
        .collect()
}

#[test]
fn pymavlink_reads_our_nudge_and_reposition() {
    let mut r = flying();
    let now = r.now();
    let fx = r
        .app
        .update(now, Event::Key(Key::plain(mavterm::keymap::KeyCode::Up)));
    let d = decoded(&fx, "SET_POSITION_TARGET_LOCAL_NED");
    assert_eq!(d.len(), 1, "{fx:?}");
    let m = &d[0];
    // MAV_FRAME_BODY_OFFSET_NED; velocity and yaw rate used: X|Y|Z|AX|AY|AZ|YAW_IGNORE.
    assert_eq!(m["coordinate_frame"], 9);
    assert_eq!(m["type_mask"], 1 | 2 | 4 | 64 | 128 | 256 | 1024);
    assert_eq!(m["type_mask"], 0x05C7);
    assert_eq!((m["vx"].as_f64(), m["vy"].as_f64()), (Some(2.0), Some(0.0)));
    assert_eq!(
        (m["target_system"].as_u64(), m["target_component"].as_u64()),
        (Some(1), Some(1))
    );
    let fx = r
        .app
        .update(now, Event::Key(Key::plain(mavterm::keymap::KeyCode::Esc)));
    let stop = decoded(&fx, "SET_POSITION_TARGET_LOCAL_NED");
    assert_eq!(stop.len(), 1, "leaving Fly mode sends a stop");
    assert_eq!(stop[0]["vx"], 0.0);
    let mut fx = Vec::new();
    for k in ":goto -35.3621234 149.1663456 25".chars() {
        fx.extend(r.app.update(now, Event::Key(Key::ch(k))));
    }
    fx.extend(r.app.update(now, Event::Key("enter".parse().unwrap())));
    let d = decoded(&fx, "COMMAND_INT");
    assert_eq!(d.len(), 1, "{fx:?}");
    let c = &d[0];
    assert_eq!(c["command"], 192); // MAV_CMD_DO_REPOSITION
    assert_eq!(c["frame"], 3); // MAV_FRAME_GLOBAL_RELATIVE_ALT
    assert_eq!(c["x"], -353621234);
    assert_eq!(c["y"], 1491663456);
    assert_eq!(c["z"], 25.0);
    assert_eq!(c["param1"], -1.0);
    assert_eq!(c["param2"], 0.0);
    assert_eq!(c["param4"], "nan");
}

#[test]
fn goto_flies_there_in_guided() {
    let mut r = flying();
    common::keys(&mut r, &["esc"]);
    // 50 m north of home, at 15 m.
    let lat = -35.3632621 + 50.0 / 111_195.0;
    command(&mut r, &format!("goto {lat:.7} 149.1652374 15"));
    wait(&mut r, 30.0);
    let v = sim(&r).vehicle(1).unwrap();
    let (n, e) = v.position_ne();
    assert!((n - 50.0).abs() < 2.0 && e.abs() < 2.0, "{n} {e}");
    assert!((v.relative_alt_m() - 15.0).abs() < 0.5);
    assert!(r
        .app
        .notices
        .iter()
        .any(|n| n.text.contains("DO_REPOSITION") && n.text.contains("ACCEPTED")));
}
