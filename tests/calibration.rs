//! Calibrations on the simulated ArduCopter (`sim://`, virtual clock), from the operator's
//! question to the vehicle's result, at 0 and 20 % loss both ways, and with the start command
//! lost (`drop_cmd`): gyro, barometer, level, simple accelerometer, the six-position
//! accelerometer (enter at each position), the onboard compass calibration (progress per
//! compass, accept, reboot needed) and the large-vehicle one. Every COMMAND_LONG mavterm sends
//! for them is checked as pymavlink reads it: command, params and confirmation 0.

mod common;

use common::{command, keys, wait, yes};

use mavterm::app::AppConfig;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::LinkSpec;
use mavterm::proto::calibration::{Phase, Run};
use mavterm::proto::vehicles::VehicleKey;

const SECOND: u64 = 1_000_000;
const KEY: VehicleKey = VehicleKey(1, 1);

fn runner(query: &str) -> VirtualRunner {
    let spec: LinkSpec = format!("sim://?{query}").parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    r.capture_sent();
    r.advance_to(7 * SECOND);
    r
}

fn run(r: &VirtualRunner) -> Option<&Run> {
    r.app.sessions[&KEY].calibration.run.as_ref()
}

/// The status bar's action line.
fn action(r: &VirtualRunner) -> String {
    r.app
        .ui
        .action
        .as_ref()
        .map(|a| a.text.clone())
        .unwrap_or_default()
}

/// Steps of 0.1 s until the calibration is over (or `limit` seconds); at an accelerometer
/// position the operator presses enter on the Health screen.
fn until_done(r: &mut VirtualRunner, limit: f64) {
    let end = r.now() + (limit * SECOND as f64) as u64;
    while r.now() < end {
        match run(r).map(|x| &x.phase) {
            Some(Phase::Done { .. }) => return,
            Some(Phase::Position(_)) => {
                // The operator reads where to put it, puts it there, presses enter.
                wait(r, 0.5);
                keys(r, &["enter"]);
            }
            _ => wait(r, 0.1),
        }
    }
}

/// The COMMAND_LONGs sent with this command id, as pymavlink reads them.
fn sent(frames: &[Vec<u8>], command: u32) -> Vec<serde_json::Value> {
    let longs: Vec<Vec<u8>> = frames
        .iter()
        .filter(|f| common::frame_msgid(f) == 76)
        .cloned()
        .collect();
    if longs.is_empty() {
        return Vec::new();
    }
    common::pymavlink_decode(&longs)
        .into_iter()
        .filter(|v| v["command"].as_u64() == Some(command as u64))
        .collect()
}

fn frames(r: &mut VirtualRunner) -> Vec<Vec<u8>> {
    r.take_sent().into_iter().map(|(_, _, f)| f).collect()
}

fn params(v: &serde_json::Value) -> [f64; 7] {
    std::array::from_fn(|i| v[format!("param{}", i + 1)].as_f64().unwrap())
}

/// Each command sent once or more, always with these params and confirmation 0, to 1:1.
fn all_as(cmds: &[serde_json::Value], want: [f64; 7]) {
    assert!(!cmds.is_empty());
    for c in cmds {
        assert_eq!(params(c), want, "{c}");
        assert_eq!(c["confirmation"], 0, "{c}");
        assert_eq!(
            (c["target_system"].as_u64(), c["target_component"].as_u64()),
            (Some(1), Some(1))
        );
    }
}

/// `cal WORD`, asked and confirmed.
fn start(r: &mut VirtualRunner, word: &str) {
    command(r, &format!("cal {word}"));
    let q = r
        .app
        .ui
        .confirm
        .as_ref()
        .expect("the calibration asks first");
    assert!(q.text.contains("CALIBRATION"), "{}", q.text);
    yes(r);
}

/// The synchronous calibrations: sent as ArduPilot's PREFLIGHT_CALIBRATION wants them, the
/// vehicle's ACK is the result, on the status bar.
#[test]
fn gyro_baro_level_and_simple_accel_from_start_to_result_at_0_and_20_percent_loss() {
    let cases: [(&str, [f64; 7]); 4] = [
        ("gyro", [1., 0., 0., 0., 0., 0., 0.]),
        ("baro", [0., 0., 1., 0., 0., 0., 0.]),
        ("level", [0., 0., 0., 0., 2., 0., 0.]),
        ("simple-accel", [0., 0., 0., 0., 4., 0., 0.]),
    ];
    for query in [
        "seed=3",
        "loss=0.2&impair_in=1&seed=5",
        "loss=0.2&impair_in=1&seed=11",
    ] {
        let mut r = runner(query);
        for (word, want) in cases {
            start(&mut r, word);
            until_done(&mut r, 30.0);
            let run = run(&r).unwrap();
            assert_eq!(
                run.phase,
                Phase::Done {
                    ok: true,
                    text: format!("{}: done", run.kind.name())
                },
                "{query} {word}"
            );
            assert!(action(&r).ends_with(": done"), "{query}: {}", action(&r));
            let f = frames(&mut r);
            all_as(&sent(&f, 241), want);
        }
    }
}

/// The start command lost (the vehicle never hears the first copy): sent again after
/// RESEND_AFTER, still with confirmation 0, and the calibration ends well.
#[test]
fn a_lost_start_is_sent_again() {
    let mut r = runner("drop_cmd=241:1");
    start(&mut r, "gyro");
    until_done(&mut r, 30.0);
    assert!(matches!(
        run(&r).unwrap().phase,
        Phase::Done { ok: true, .. }
    ));
    let f = frames(&mut r);
    let cmds = sent(&f, 241);
    assert_eq!(cmds.len(), 2, "the first lost, the second answered");
    all_as(&cmds, [1., 0., 0., 0., 0., 0., 0.]);
}

/// Six positions, each asked by the vehicle (COMMAND_LONG ACCELCAL_VEHICLE_POS) and shown with
/// its face down; enter answers each with the position asked; the vehicle's SUCCESS ends it;
/// its pre-arm failure about the accelerometers goes.
#[test]
fn accelerometer_six_positions_at_0_and_20_percent_loss() {
    for query in [
        "uncal=1",
        "uncal=1&loss=0.2&impair_in=1&seed=2",
        "uncal=1&loss=0.2&impair_in=1&seed=9",
    ] {
        let mut r = runner(query);
        keys(&mut r, &["8"]);
        start(&mut r, "accel");
        // The first position on screen, as the vehicle asked it.
        let end = r.now() + 20 * SECOND;
        while !matches!(run(&r).unwrap().phase, Phase::Position(_)) && r.now() < end {
            wait(&mut r, 0.1);
        }
        assert_eq!(run(&r).unwrap().phase, Phase::Position(1), "{query}");
        let screen = common::screen(&r, 120, 40);
        assert!(
            screen.contains("accel cal 1/6: place the vehicle level (bottom down), then enter"),
            "{screen}"
        );
        until_done(&mut r, 120.0);
        let run = run(&r).unwrap();
        assert_eq!(
            run.phase,
            Phase::Done {
                ok: true,
                text: "accelerometer calibration: successful".into()
            },
            "{query}"
        );
        assert!(run.asked >= 6);
        let f = frames(&mut r);
        all_as(&sent(&f, 241), [0., 0., 0., 0., 1., 0., 0.]);
        // Each position answered with itself, in order (a resend repeats the last).
        let pos: Vec<f64> = sent(&f, 42429).iter().map(|c| params(c)[0]).collect();
        let mut uniq = pos.clone();
        uniq.dedup();
        assert_eq!(uniq, vec![1., 2., 3., 4., 5., 6.], "{query}: {pos:?}");
        for c in sent(&f, 42429) {
            assert_eq!(c["confirmation"], 0);
            assert_eq!(&params(&c)[1..], &[0.; 6]);
        }
        // The vehicle no longer says it needs an accelerometer calibration.
        command(&mut r, "prearm");
        wait(&mut r, 3.0);
        let reasons: Vec<String> = r.app.sessions[&KEY]
            .prearm
            .reasons()
            .map(|x| x.line())
            .collect();
        assert!(
            !reasons.iter().any(|x| x.contains("3D Accel")),
            "{query}: {reasons:?}"
        );
    }
}

/// Onboard compass calibration: progress per compass, both reports, accept, and the reboot it
/// needs (the vehicle's pre-arm check says so).
#[test]
fn compass_progress_reports_accept_and_reboot_at_0_and_20_percent_loss() {
    for query in [
        "uncal=1",
        "uncal=1&loss=0.2&impair_in=1&seed=4",
        "uncal=1&loss=0.2&impair_in=1&seed=8",
    ] {
        let mut r = runner(query);
        keys(&mut r, &["8"]);
        start(&mut r, "compass");
        // Running from its ACK, or from the first progress when the ACK is lost; both
        // compasses once each has sent its progress.
        let end = r.now() + 10 * SECOND;
        wait(&mut r, 1.0);
        while (run(&r).unwrap().phase != Phase::Running || run(&r).unwrap().compasses.len() < 2)
            && r.now() < end
        {
            wait(&mut r, 0.2);
        }
        let run1 = run(&r).unwrap();
        assert_eq!(run1.phase, Phase::Running, "{query}");
        assert_eq!(
            run1.compasses.keys().copied().collect::<Vec<_>>(),
            vec![0, 1]
        );
        let screen = common::screen(&r, 120, 40);
        assert!(screen.contains("mag 0 █"), "{screen}");
        let end = r.now() + 40 * SECOND;
        while run(&r).unwrap().phase != Phase::Accept && r.now() < end {
            wait(&mut r, 0.2);
        }
        let run2 = run(&r).unwrap();
        assert_eq!(run2.phase, Phase::Accept, "{query}");
        assert_eq!(run2.reports[&0].status, 4);
        assert!((run2.reports[&0].fitness - 6.5).abs() < 1e-3);
        assert_eq!(run2.reports[&1].offsets, [15.0, -12.0, 53.0]);
        assert!(
            action(&r).contains("`cal accept` saves it"),
            "{}",
            action(&r)
        );
        command(&mut r, "cal accept");
        until_done(&mut r, 30.0);
        let run3 = run(&r).unwrap();
        assert!(
            matches!(&run3.phase, Phase::Done { ok: true, text } if text.contains("reboot")),
            "{query}: {:?}",
            run3.phase
        );
        assert!(run3.reboot_needed);
        let f = frames(&mut r);
        all_as(&sent(&f, 42424), [0., 1., 0., 0., 0., 0., 0.]);
        all_as(&sent(&f, 42425), [0.; 7]);
        // Asked until heard (at 20 % loss the ask, its texts or its ACK may be lost: the operator
        // asks again).
        let reasons = |r: &VirtualRunner| -> Vec<String> {
            r.app.sessions[&KEY]
                .prearm
                .reasons()
                .map(|x| x.text.clone())
                .collect()
        };
        for _ in 0..8 {
            let asked = r.now();
            command(&mut r, "prearm");
            wait(&mut r, 3.0);
            let answered = r.app.sessions[&KEY]
                .prearm
                .answered
                .is_some_and(|t| t > asked);
            if answered && reasons(&r).contains(&"Compass calibrated requires reboot".to_string()) {
                break;
            }
        }
        assert!(
            reasons(&r).contains(&"Compass calibrated requires reboot".to_string()),
            "{query}: {:?}",
            reasons(&r)
        );
        // "Compass not calibrated" was stated before the calibration, not since: the answered
        // ask dropped it.
        assert!(!reasons(&r).contains(&"Compass not calibrated".to_string()));
    }
}

#[test]
fn large_vehicle_compass_calibration_with_a_heading() {
    for query in ["seed=1", "loss=0.2&impair_in=1&seed=6"] {
        let mut r = runner(query);
        start(&mut r, "compass-fixed 271.5");
        until_done(&mut r, 30.0);
        assert!(
            matches!(run(&r).unwrap().phase, Phase::Done { ok: true, .. }),
            "{query}"
        );
        let f = frames(&mut r);
        all_as(&sent(&f, 42006), [271.5, 0., 0., 0., 0., 0., 0.]);
    }
}

/// Refused while armed, before anything is asked or sent.
#[test]
fn no_calibration_while_armed() {
    let mut r = runner("seed=1");
    command(&mut r, "arm");
    yes(&mut r);
    wait(&mut r, 2.0);
    assert!(r.app.vehicles.get(KEY).unwrap().armed());
    frames(&mut r);
    command(&mut r, "cal gyro");
    assert!(r.app.ui.confirm.is_none());
    let msg = r.app.ui.message.clone().unwrap().1;
    assert_eq!(msg, "1:1 is armed: no gyro calibration (disarm first)");
    wait(&mut r, 1.0);
    assert!(sent(&frames(&mut r), 241).is_empty());
}

/// `fake_calibration_vehicle.py` with `extra` arguments against mavterm headless running
/// `script` (100x30): the COMMAND_LONGs the vehicle received ([command, p1..p7, confirmation])
/// of the calibrations, and the `health` snapshot.
fn against_stand_in(extra: &[&str], script: &str) -> (Vec<Vec<f64>>, String) {
    let dir = tempfile::tempdir().unwrap();
    let port = common::free_udp_port();
    let log = dir.path().join("commands.json");
    let script_path = dir.path().join("script.txt");
    std::fs::write(&script_path, script).unwrap();
    let screens = dir.path().join("screens");
    let mut a: Vec<std::ffi::OsString> = vec![
        "--port".into(),
        port.to_string().into(),
        "--log-out".into(),
        log.clone().into(),
        "--duration".into(),
        "30".into(),
    ];
    a.extend(extra.iter().map(|s| s.into()));
    let _v = common::stand_in("fake_calibration_vehicle.py", &a);
    let out = common::succeed(
        std::process::Command::new(common::mavterm())
            .args([
                "--link",
                &format!("udpin:127.0.0.1:{port}"),
                "--headless",
                "--input",
            ])
            .arg(&script_path)
            .arg("--screens")
            .arg(&screens)
            .args(["--size", "100x30"]),
    );
    let _ = out;
    let got: Vec<Vec<f64>> = std::fs::read_to_string(&log)
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .unwrap_or_default();
    let cal = [241.0, 42429.0, 42424.0, 42425.0, 42426.0, 42006.0];
    let got = got.into_iter().filter(|c| cal.contains(&c[0])).collect();
    let screen = std::fs::read_to_string(screens.join("health.txt")).unwrap_or_default();
    (got, screen)
}

/// ArduPilot's six-position sequence from pymavlink, its start ACK lost: the first position
/// request shows it started; each position answered once with itself, confirmation 0.
#[test]
fn stand_in_accel_cal_with_its_start_ack_lost() {
    let mut script =
        String::from("1.5 key 8\n2 key :\n2.1 text \"cal accel\"\n2.2 key enter\n2.8 key y\n");
    for i in 0..7 {
        script.push_str(&format!("{} key enter\n", 4.0 + 1.5 * i as f64));
    }
    script.push_str("14.5 snapshot health\n15 quit\n");
    let (got, screen) = against_stand_in(&["--lose-start-ack"], &script);
    let mut want = vec![vec![241.0, 0., 0., 0., 0., 1., 0., 0., 0.]];
    for p in 1..=6 {
        want.push(vec![42429.0, p as f64, 0., 0., 0., 0., 0., 0., 0.]);
    }
    assert_eq!(got, want, "{screen}");
    assert!(
        screen.contains("accelerometer calibration: successful"),
        "{screen}"
    );
}

/// Refusals as ArduPilot gives them: DO_START_MAG_CAL FAILED with its reason after the ACK;
/// a compass that ends in BAD_RADIUS.
#[test]
fn stand_in_compass_refused_and_bad_radius() {
    let script = "1.5 key 8\n2 key :\n2.1 text \"cal compass\"\n2.2 key enter\n2.8 key y\n\
                  5 snapshot health\n5.5 quit\n";
    let (got, screen) = against_stand_in(&["--refuse-mag"], script);
    assert_eq!(got, vec![vec![42424.0, 0., 1., 0., 0., 0., 0., 0., 0.]]);
    assert!(
        screen.contains("compass calibration refused: FAILED (Compass cal requires GPS lock)"),
        "{screen}"
    );
    let script = "1.5 key 8\n2 key :\n2.1 text \"cal compass\"\n2.2 key enter\n2.8 key y\n\
                  8 snapshot health\n8.5 quit\n";
    let (got, screen) = against_stand_in(&["--mag-bad-radius", "--lose-start-ack"], script);
    assert_eq!(got, vec![vec![42424.0, 0., 1., 0., 0., 0., 0., 0., 0.]]);
    assert!(
        screen.contains("compass calibration FAILED: mag 0 BAD_RADIUS fitness 45.2"),
        "{screen}"
    );
}
