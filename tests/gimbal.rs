//! Gimbals (MAVLink Gimbal Protocol v2) on the simulated ArduCopter with its mount
//! (`sim://?camera=1&gimbal=1`, virtual clock): the autopilot asked for GIMBAL_MANAGER_INFORMATION
//! (as pymavlink reads it off the recorded wire), the gimbal shown on the Camera screen, pointed
//! from the keys within the manager's limits with the ACK shown, refused beyond them; zoom from
//! the keys; an autopilot without a mount asked three times, then left alone.

mod common;

use common::{command, sim, wait};
use serde_json::Value;

use mavterm::app::AppConfig;
use mavterm::driver::record::TlogTarget;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::LinkSpec;
use mavterm::proto::commands::State;
use mavterm::proto::vehicles::VehicleKey;

const SECOND: u64 = 1_000_000;
/// MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, MAV_CMD_REQUEST_MESSAGE, MAV_CMD_SET_CAMERA_ZOOM (common).
const PITCHYAW: u16 = 1000;
const REQUEST_MESSAGE: u16 = 512;
const SET_CAMERA_ZOOM: u16 = 531;
/// GIMBAL_MANAGER_FLAGS_ROLL_LOCK | PITCH_LOCK | YAW_IN_VEHICLE_FRAME (4 + 8 + 32).
const BODY_YAW_FLAGS: f64 = 44.0;

fn runner(query: &str, tlog: Option<&std::path::Path>) -> VirtualRunner {
    let spec: LinkSpec = format!("sim://?{query}").parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    if let Some(p) = tlog {
        r.record(&TlogTarget::File(p.to_path_buf()));
    }
    r.advance_to(6 * SECOND);
    r
}

/// Commands of the target session to (1, `compid`) with this command id, and their fate.
fn sent(r: &VirtualRunner, compid: u8, command: u16) -> Vec<(State, [f64; 7])> {
    r.app.sessions[&VehicleKey(1, 1)]
        .commands
        .entries()
        .filter(|e| e.spec.target == (1, compid) && e.spec.command == command)
        .map(|e| (e.state.clone(), e.spec.params))
        .collect()
}

/// The COMMAND_LONGs we sent, as pymavlink reads them from the recorded log.
fn wire_commands(tlog: &std::path::Path) -> Vec<Value> {
    let lines = common::py_lines("read_tlog.py", &[tlog.to_str().unwrap()], &[]);
    let frames: Vec<Vec<u8>> = lines
        .iter()
        .map(|l| serde_json::from_str::<Value>(l).unwrap())
        .filter(|m| m["type"] == "COMMAND_LONG" && m["sysid"] == 255)
        .map(|m| {
            let h = m["hex"].as_str().unwrap();
            (0..h.len())
                .step_by(2)
                .map(|i| u8::from_str_radix(&h[i..i + 2], 16).unwrap())
                .collect()
        })
        .collect();
    common::pymavlink_decode(&frames)
}

#[test]
fn the_mount_is_discovered_shown_and_pointed_from_the_keys() {
    let dir = tempfile::tempdir().unwrap();
    let tlog = dir.path().join("gimbal.tlog");
    let mut r = runner("camera=1&gimbal=1", Some(&tlog));
    let s = &r.app.sessions[&VehicleKey(1, 1)];
    // ArduPilot's AP_Mount: manager on the autopilot (1), device id instance + 1 = 1, and the
    // MNT1_ default limits (pitch -90..20°, yaw -180..180°).
    let g = &s.gimbals.gimbals[&(1, 1)];
    let info = g.info.expect("GIMBAL_MANAGER_INFORMATION read");
    assert!((info.pitch.0 + 90.0).abs() < 1e-3 && (info.pitch.1 - 20.0).abs() < 1e-3);
    assert!((info.yaw.0 + 180.0).abs() < 1e-3 && (info.yaw.1 - 180.0).abs() < 1e-3);
    assert_eq!(
        g.status.map(|s| s.primary),
        Some((0, 0)),
        "nobody in control"
    );
    assert!(g.attitude.is_some());
    let asked = sent(&r, 1, REQUEST_MESSAGE);
    assert_eq!(
        asked
            .iter()
            .filter(|(_, p)| p[0] == 280.0)
            .cloned()
            .collect::<Vec<_>>(),
        vec![(State::Done(0), [280.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])],
        "asked once, answered"
    );
    common::keys(&mut r, &["6"]);
    let screen = common::screen(&r, 80, 24);
    assert!(
        screen.contains("gimbal 1:1/1 pitch 0.0°")
            && screen.contains("pitch -90..20° yaw -180..180°"),
        "{screen}"
    );
    assert!(screen.contains("control nobody"), "{screen}");
    insta::assert_snapshot!("gimbal_discovered_80x24", screen);

    // Two steps up: 5° then 10° (pitch positive up), to the manager, device 1 in param7.
    common::keys(&mut r, &["alt-up"]);
    wait(&mut r, 0.5);
    common::keys(&mut r, &["alt-up"]);
    wait(&mut r, 1.0);
    let nan = |p: &[f64; 7]| p[2].is_nan() && p[3].is_nan();
    let points = sent(&r, 1, PITCHYAW);
    assert_eq!(points.len(), 2, "{points:?}");
    for ((state, p), pitch) in points.iter().zip([5.0, 10.0]) {
        assert_eq!(*state, State::Done(0));
        assert_eq!([p[0], p[1]], [pitch, 0.0]);
        assert!(nan(p), "{p:?}");
        assert_eq!([p[4], p[5], p[6]], [BODY_YAW_FLAGS, 0.0, 1.0]);
    }
    let m = sim(&r).vehicle(1).unwrap().mount().unwrap();
    assert_eq!((m.pitch, m.yaw), (10.0, 0.0), "the mount slewed there");
    wait(&mut r, 1.0);
    let screen = common::screen(&r, 80, 24);
    assert!(
        screen.contains("gimbal 1:1/1 pitch 10.0°") && screen.contains("asked 10°/0°"),
        "{screen}"
    );
    insta::assert_snapshot!("gimbal_pointed_80x24", screen);
    // The ACK is shown (Commands screen).
    common::keys(&mut r, &["3"]);
    let screen = common::screen(&r, 120, 30);
    assert!(
        screen.contains("DO_GIMBAL_MANAGER_PITCHYAW") && screen.contains("ACCEPTED"),
        "{screen}"
    );

    // Up to the limit (20°), then a step beyond it is refused and not sent.
    common::keys(&mut r, &["6", "alt-up"]);
    wait(&mut r, 0.5);
    common::keys(&mut r, &["alt-up"]);
    wait(&mut r, 0.5);
    assert_eq!(sent(&r, 1, PITCHYAW).len(), 4);
    common::keys(&mut r, &["alt-up"]);
    wait(&mut r, 0.5);
    assert_eq!(
        sent(&r, 1, PITCHYAW).len(),
        4,
        "25° is beyond 20°: not sent"
    );
    let msg = r.app.ui.message.clone().unwrap().1;
    assert!(msg.contains("beyond") && msg.contains("not sent"), "{msg}");
    command(&mut r, "gimbal -100 0");
    assert_eq!(sent(&r, 1, PITCHYAW).len(), 4);
    // Yaw right of the nose: positive, within -180..180.
    common::keys(&mut r, &["alt-right"]);
    wait(&mut r, 1.0);
    let last = sent(&r, 1, PITCHYAW).pop().unwrap();
    assert_eq!([last.1[0], last.1[1]], [20.0, 5.0]);
    let m = sim(&r).vehicle(1).unwrap().mount().unwrap();
    assert_eq!((m.pitch, m.yaw), (20.0, 5.0));

    // Zoom in one step from CAMERA_SETTINGS' 0 %: SET_CAMERA_ZOOM ZOOM_TYPE_RANGE (2), 10 %.
    common::keys(&mut r, &["z"]);
    wait(&mut r, 1.0);
    assert_eq!(
        sent(&r, 100, SET_CAMERA_ZOOM),
        vec![(State::Done(0), [2.0, 10.0, 0.0, 0.0, 0.0, 0.0, 0.0])]
    );
    assert_eq!(sim(&r).camera(1).unwrap().zoom, 10.0);

    // What pymavlink reads off the wire.
    r.finish_recording();
    let wire = wire_commands(&tlog);
    let ask: Vec<&Value> = wire
        .iter()
        .filter(|c| c["command"] == 512 && c["param1"] == 280.0)
        .collect();
    assert_eq!(ask.len(), 1, "{wire:?}");
    assert_eq!(
        (&ask[0]["target_system"], &ask[0]["target_component"]),
        (&Value::from(1), &Value::from(1))
    );
    for f in ["param2", "param3", "param4", "param5", "param6", "param7"] {
        assert_eq!(ask[0][f], 0.0, "{f}");
    }
    let points: Vec<&Value> = wire.iter().filter(|c| c["command"] == 1000).collect();
    assert_eq!(points.len(), 5);
    assert_eq!(points[1]["param1"], 10.0);
    assert_eq!(points[1]["param2"], 0.0);
    assert_eq!(points[1]["param3"], "nan");
    assert_eq!(points[1]["param4"], "nan");
    assert_eq!(points[1]["param5"], BODY_YAW_FLAGS);
    assert_eq!(points[1]["param7"], 1.0);
    assert_eq!(points[1]["target_component"], 1);
}

#[test]
fn without_a_mount_nothing_is_pointed_and_the_autopilot_is_asked_three_times() {
    let mut r = runner("", None);
    wait(&mut r, 20.0);
    let asked = |r: &VirtualRunner| -> Vec<(State, [f64; 7])> {
        sent(r, 1, REQUEST_MESSAGE)
            .into_iter()
            .filter(|(_, p)| p[0] == 280.0)
            .collect()
    };
    // No sign of a gimbal (no GIMBAL_DEVICE_ATTITUDE_STATUS in EXTRA3): not asked.
    assert!(asked(&r).is_empty());
    common::keys(&mut r, &["6", "alt-up"]);
    wait(&mut r, 1.0);
    assert!(sent(&r, 1, PITCHYAW).is_empty());
    let msg = r.app.ui.message.clone().unwrap().1;
    assert!(
        msg.contains("no gimbal manager discovered") && msg.contains("not sent"),
        "{msg}"
    );
    // The key made it ask the autopilot: ArduPilot without a mount answers ACCEPTED and sends
    // nothing; three tries, then left alone.
    wait(&mut r, 30.0);
    let a = asked(&r);
    assert_eq!(a.len(), 3, "{a:?}");
    assert!(a.iter().all(|(s, _)| *s == State::Done(0)));
    assert!(sent(&r, 1, PITCHYAW).is_empty());
}

#[test]
fn a_gimbal_without_a_camera_has_the_screen_to_itself() {
    let mut r = runner("gimbal=1", None);
    // One pointing command open at a time (the queue's rule): each key after the last ACK.
    for k in ["6", "alt-down", "alt-down", "alt-left"] {
        common::keys(&mut r, &[k]);
        wait(&mut r, 0.5);
    }
    wait(&mut r, 1.0);
    let m = sim(&r).vehicle(1).unwrap().mount().unwrap();
    assert_eq!((m.pitch, m.yaw), (-10.0, -5.0));
    let screen = common::screen(&r, 80, 24);
    assert!(
        screen.contains("gimbal 1:1/1 pitch -10.0°") && screen.contains("yaw -5.0° (nose)"),
        "{screen}"
    );
    insta::assert_snapshot!("gimbal_only_80x24", screen);
    insta::assert_snapshot!("gimbal_only_60x20", common::screen(&r, 60, 20));
    insta::assert_snapshot!("gimbal_only_200x60", common::screen(&r, 200, 60));
    // Taking control: MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE with our ids; the status says so.
    command(&mut r, "gimbal control");
    wait(&mut r, 1.0);
    let g = &r.app.sessions[&VehicleKey(1, 1)].gimbals.gimbals[&(1, 1)];
    assert_eq!(g.status.map(|s| s.primary), Some((255, 190)));
    let screen = common::screen(&r, 80, 24);
    assert!(screen.contains("control 255:190 (us)"), "{screen}");
}
