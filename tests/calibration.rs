//! Calibrations on the simulated ArduCopter (`sim://`, virtual clock), from the operator's
//! question to the vehicle's result, at 0 and 20 % loss both ways, and with the start command
//! lost (`drop_cmd`): gyro, barometer, level, simple accelerometer, the six-position
//! accelerometer (enter at each position), the onboard compass calibration (progress per
//! compass, accept, reboot needed) and the large-vehicle one. Every COMMAND_LONG mavterm sends
//! for them is checked as pymavlink reads it: command, params and confirmation 0.

mod common;

use common::{command, keys, wait, yes};

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use mavterm::app::AppConfig;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::source::VirtualSource;
use mavterm::link::LinkSpec;
use mavterm::proto::calibration::{Phase, Run};
use mavterm::proto::vehicles::VehicleKey;
use mavterm::wire::Severity;

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

/// The Health screen (`8`), then `cal WORD` asked and confirmed.
fn start_on_health(r: &mut VirtualRunner, word: &str) {
    keys(r, &["8"]);
    start(r, word);
}

/// How an accelerometer calibration ends when ArduPilot says it went well.
fn accel_successful() -> Phase {
    Phase::Done {
        ok: true,
        text: "accelerometer calibration: successful".into(),
    }
}

/// Steps of `step` s until the calibration is at `want` (at most `limit` s), and it is.
fn until_phase(r: &mut VirtualRunner, want: Phase, limit: u64, step: f64) {
    let end = r.now() + limit * SECOND;
    while run(r).unwrap().phase != want && r.now() < end {
        wait(r, step);
    }
    assert_eq!(run(r).unwrap().phase, want);
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
/// RESEND_AFTER, still with confirmation 0, and the calibration ends well. Each calibration
/// whose result is its ACK: gyro, barometer, level, simple accelerometer, large vehicle.
#[test]
fn a_lost_start_is_sent_again() {
    let cases: [(&str, u32, [f64; 7]); 5] = [
        ("gyro", 241, [1., 0., 0., 0., 0., 0., 0.]),
        ("baro", 241, [0., 0., 1., 0., 0., 0., 0.]),
        ("level", 241, [0., 0., 0., 0., 2., 0., 0.]),
        ("simple-accel", 241, [0., 0., 0., 0., 4., 0., 0.]),
        ("compass-fixed 90", 42006, [90., 0., 0., 0., 0., 0., 0.]),
    ];
    for (word, id, want) in cases {
        let mut r = runner(&format!("drop_cmd={id}:1"));
        start(&mut r, word);
        until_done(&mut r, 30.0);
        assert!(
            matches!(run(&r).unwrap().phase, Phase::Done { ok: true, .. }),
            "{word}: {:?}",
            run(&r).unwrap().phase
        );
        assert_eq!(
            common::sim(&r).vehicles()[0].commands_dropped(),
            1,
            "{word}"
        );
        let f = frames(&mut r);
        let cmds = sent(&f, id);
        assert_eq!(cmds.len(), 2, "{word}: the first lost, the second answered");
        all_as(&cmds, want);
    }
}

/// The six-position and the onboard compass calibrations with their start command lost: sent
/// again, then run to their end (the compass accepted).
#[test]
fn a_lost_start_of_accel_or_compass_is_sent_again() {
    let mut r = runner("uncal=1&drop_cmd=241:1");
    start_on_health(&mut r, "accel");
    until_done(&mut r, 120.0);
    assert_eq!(run(&r).unwrap().phase, accel_successful());
    let f = frames(&mut r);
    let cmds = sent(&f, 241);
    assert_eq!(cmds.len(), 2);
    all_as(&cmds, [0., 0., 0., 0., 1., 0., 0.]);

    let mut r = runner("uncal=1&drop_cmd=42424:1");
    start_on_health(&mut r, "compass");
    until_phase(&mut r, Phase::Accept, 40, 0.2);
    command(&mut r, "cal accept");
    until_done(&mut r, 30.0);
    assert!(run(&r).unwrap().reboot_needed);
    let f = frames(&mut r);
    let cmds = sent(&f, 42424);
    assert_eq!(cmds.len(), 2);
    all_as(&cmds, [0., 1., 0., 0., 0., 0., 0.]);
}

/// The ACK of position 1 lost (`drop_ack`), the vehicle moves on to position 2 while that
/// answer still waits in the command queue: enter at position 2 sends at once, no error.
#[test]
fn a_lost_position_ack_does_not_hold_the_next_position_back() {
    // A slow link, so the queue still waits for the lost ACK when position 2 is asked.
    let mut r = runner("uncal=1&drop_ack=42429:1&latency_ms=300");
    start_on_health(&mut r, "accel");
    until_phase(&mut r, Phase::Position(1), 20, 0.05);
    keys(&mut r, &["enter"]);
    until_phase(&mut r, Phase::Position(2), 20, 0.05);
    assert!(
        r.app.sessions[&KEY].commands.is_open(KEY, 42429),
        "the answer to position 1 still waits for its ACK"
    );
    frames(&mut r);
    keys(&mut r, &["enter"]);
    let msg = r.app.ui.message.clone();
    assert!(
        msg.as_ref().is_some_and(|(sev, _)| *sev != Severity::ERROR),
        "{msg:?}"
    );
    assert_eq!(run(&r).unwrap().phase, Phase::Placed(2));
    wait(&mut r, 0.01);
    let pos: Vec<f64> = sent(&frames(&mut r), 42429)
        .iter()
        .map(|c| params(c)[0])
        .collect();
    assert_eq!(pos, vec![2.0], "sent at once");
    until_done(&mut r, 120.0);
    assert_eq!(run(&r).unwrap().phase, accel_successful());
}

/// `x` on the Health screen during a compass calibration: DO_CANCEL_MAG_CAL for every compass
/// (mask 0), confirmation 0; the vehicle stops and the screen says it was cancelled.
#[test]
fn a_compass_calibration_cancelled() {
    let mut r = runner("uncal=1");
    start_on_health(&mut r, "compass");
    until_phase(&mut r, Phase::Running, 10, 0.2);
    keys(&mut r, &["x"]);
    wait(&mut r, 2.0);
    assert_eq!(
        run(&r).unwrap().phase,
        Phase::Done {
            ok: false,
            text: "compass calibration cancelled".into()
        }
    );
    let screen = common::screen(&r, 80, 24);
    assert!(
        screen.contains("CALIBRATE compass calibration cancelled"),
        "{screen}"
    );
    assert_eq!(action(&r), "compass calibration cancelled");
    let f = frames(&mut r);
    let cmds = sent(&f, 42426);
    assert_eq!(cmds.len(), 1);
    all_as(&cmds, [0.; 7]);
    // The vehicle no longer calibrates: no MAG_CAL_PROGRESS or REPORT since.
    let ignored = r.app.sessions[&KEY].calibration.ignored;
    wait(&mut r, 3.0);
    assert_eq!(r.app.sessions[&KEY].calibration.ignored, ignored);
}

/// A source that goes silent (hears and says nothing) from a time the test sets: a vehicle
/// lost.
struct Silenced {
    inner: Box<dyn VirtualSource>,
    from: Arc<AtomicU64>,
}

impl VirtualSource for Silenced {
    fn receive(&mut self, now: u64, bytes: &[u8]) {
        if now < self.from.load(Ordering::Relaxed) {
            self.inner.receive(now, bytes);
        }
    }
    fn poll(&mut self, now: u64) -> Vec<u8> {
        let out = self.inner.poll(now);
        if now < self.from.load(Ordering::Relaxed) {
            out
        } else {
            Vec::new()
        }
    }
    fn next_deadline(&self) -> u64 {
        self.inner.next_deadline()
    }
    fn as_any(&self) -> &dyn std::any::Any {
        self.inner.as_any()
    }
}

/// A runner on `sim://?query` that can be silenced.
fn silenceable(query: &str) -> (VirtualRunner, Arc<AtomicU64>) {
    let spec: LinkSpec = format!("sim://?{query}").parse().unwrap();
    let from = Arc::new(AtomicU64::new(u64::MAX));
    let src = Silenced {
        inner: mavterm::driver::local_source(&spec).unwrap(),
        from: from.clone(),
    };
    let cfg = AppConfig {
        links: vec![spec.to_string()],
        epoch: mavterm::driver::virtual_time::virtual_epoch(),
        ..AppConfig::default()
    };
    let mut r = VirtualRunner::new(cfg, vec![Box::new(src)]);
    r.advance_to(7 * SECOND);
    (r, from)
}

/// The vehicle goes silent in the middle of an accelerometer or compass calibration: after
/// STALL_AFTER without its position requests or MAG_CAL_PROGRESS the calibration ends as
/// failed, with the reason on the status bar and the screen (not "running" for ever).
#[test]
fn a_calibration_whose_vehicle_goes_silent_ends_as_failed() {
    let (mut r, silence) = silenceable("uncal=1");
    start_on_health(&mut r, "accel");
    until_phase(&mut r, Phase::Position(1), 20, 0.1);
    silence.store(r.now(), Ordering::Relaxed);
    wait(&mut r, 14.0);
    assert!(
        run(&r).unwrap().phase == Phase::Position(1),
        "still waiting"
    );
    wait(&mut r, 1.5);
    let want = "accelerometer calibration FAILED: no word from the vehicle for 15 s (no position \
                request): is it still there? start again";
    assert_eq!(
        run(&r).unwrap().phase,
        Phase::Done {
            ok: false,
            text: want.into()
        }
    );
    assert_eq!(action(&r), want);
    let screen = common::screen(&r, 200, 60);
    assert!(screen.contains(want), "{screen}");

    let (mut r, silence) = silenceable("uncal=1");
    start_on_health(&mut r, "compass");
    until_phase(&mut r, Phase::Running, 10, 0.2);
    silence.store(r.now(), Ordering::Relaxed);
    wait(&mut r, 16.0);
    assert!(
        matches!(&run(&r).unwrap().phase, Phase::Done { ok: false, text }
            if text.contains("no word from the vehicle for 15 s (no MAG_CAL_PROGRESS or REPORT)")),
        "{:?}",
        run(&r).unwrap().phase
    );
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
        start_on_health(&mut r, "accel");
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
        assert_eq!(run.phase, accel_successful(), "{query}");
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
        start_on_health(&mut r, "compass");
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
/// of the calibrations (and reboots), and the `health` snapshot.
fn against_stand_in(extra: &[&str], script: &str) -> (Vec<Vec<f64>>, String) {
    let (got, _, last) = against_stand_in_all(extra, script);
    (got, last)
}

/// As [`against_stand_in`], with the `before` snapshot too.
fn against_stand_in_all(extra: &[&str], script: &str) -> (Vec<Vec<f64>>, String, String) {
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
    let cal = [241.0, 42429.0, 42424.0, 42425.0, 42426.0, 42006.0, 246.0];
    let got = got.into_iter().filter(|c| cal.contains(&c[0])).collect();
    let read = |name: &str| std::fs::read_to_string(screens.join(name)).unwrap_or_default();
    (got, read("before.txt"), read("health.txt"))
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

/// DO_CANCEL_MAG_CAL as pymavlink reads it: every compass (mask 0), confirmation 0; the
/// vehicle's ACCEPTED ends it as cancelled.
#[test]
fn stand_in_compass_cancelled() {
    let script = "1.5 key 8\n2 key :\n2.1 text \"cal compass\"\n2.2 key enter\n2.8 key y\n\
                  4 key x\n5 snapshot health\n5.5 quit\n";
    let (got, screen) = against_stand_in(&[], script);
    assert_eq!(
        got,
        vec![
            vec![42424.0, 0., 1., 0., 0., 0., 0., 0., 0.],
            vec![42426.0, 0., 0., 0., 0., 0., 0., 0., 0.],
        ],
        "{screen}"
    );
    assert!(screen.contains("compass calibration cancelled"), "{screen}");
}

/// Accepted, then rebooted from the prompt (`reboot`, asked first): the vehicle comes back
/// with its boot time from 0, and the reboot the calibration needed is done.
#[test]
fn stand_in_compass_accepted_then_rebooted() {
    let script = "1.5 key 8\n2 key :\n2.1 text \"cal compass\"\n2.2 key enter\n2.8 key y\n\
                  7 key S\n7.5 snapshot before\n8 key :\n8.1 text \"reboot\"\n8.2 key enter\n\
                  8.6 key y\n13 snapshot health\n13.5 quit\n";
    let dir_screens = against_stand_in_all(&[], script);
    let (got, first, last) = dir_screens;
    assert_eq!(
        got,
        vec![
            vec![42424.0, 0., 1., 0., 0., 0., 0., 0., 0.],
            vec![42425.0, 0., 0., 0., 0., 0., 0., 0., 0.],
            vec![246.0, 1., 0., 0., 0., 0., 0., 0., 0.],
        ],
        "{last}"
    );
    assert!(
        first.contains("compass calibration accepted: `reboot` the vehicle (asks first)"),
        "{first}"
    );
    assert!(
        last.contains("compass calibration: the vehicle rebooted, new offsets in use"),
        "{last}"
    );
}

/// Started from the prompt on another screen, the six-position calibration's line says what
/// answers there (`:cal next`), and `:cal next` does: `enter` is "placed" on screen 8 only.
#[test]
fn accelerometer_placement_from_another_screen_says_cal_next() {
    let mut r = runner("uncal=1");
    start(&mut r, "accel");
    until_phase(&mut r, Phase::Position(1), 20, 0.1);
    let bar = common::screen(&r, 200, 60);
    let bar = bar.lines().last().unwrap();
    assert!(
        bar.contains(
            "accel cal 1/6: place the vehicle level (bottom down), then :cal next (or enter on screen 8)"
        ),
        "{bar}"
    );
    command(&mut r, "cal next");
    until_phase(&mut r, Phase::Position(2), 10, 0.1);
}
