//! Before flight, on the simulated ArduCopter fresh from the box (`sim://?uncal=1`, virtual
//! clock): the pre-arm reasons gathered from its `PreArm:` statements and shown on the Health
//! screen and the Overview, aged out when the vehicle stops stating them, asked again with
//! `c` (RUN_PREARM_CHECKS); a refused arm's reasons on the status bar; the Health screen at
//! 80x24 and 200x60.

mod common;

use common::{command, keys, wait, yes};

use mavterm::app::AppConfig;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::LinkSpec;
use mavterm::proto::health::KEEP;
use mavterm::proto::vehicles::VehicleKey;

const SECOND: u64 = 1_000_000;
const KEY: VehicleKey = VehicleKey(1, 1);

fn runner(query: &str, at: f64) -> VirtualRunner {
    let spec: LinkSpec = format!("sim://?{query}").parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    r.advance_to((at * SECOND as f64) as u64);
    r
}

fn reasons(r: &VirtualRunner) -> Vec<String> {
    r.app.sessions[&KEY]
        .prearm
        .reasons()
        .map(|x| x.line())
        .collect()
}

fn action(r: &VirtualRunner) -> String {
    r.app
        .ui
        .action
        .as_ref()
        .map(|a| a.text.clone())
        .unwrap_or_default()
}

/// ArduPilot states its failing checks 4 s after they start failing, then every 30 s: both
/// reasons are on the Health screen and counted on the Overview.
#[test]
fn prearm_reasons_are_shown_without_scrolling() {
    let mut r = runner("uncal=1", 7.0);
    assert_eq!(
        reasons(&r),
        vec![
            "PreArm: 3D Accel calibration needed",
            "PreArm: Compass not calibrated"
        ]
    );
    let overview = common::screen(&r, 80, 24);
    assert!(overview.contains("PRE FAIL (2, screen 8)"), "{overview}");
    keys(&mut r, &["8"]);
    let s = common::screen(&r, 80, 24);
    assert!(s.contains("2 reasons not to arm"), "{s}");
    assert!(s.contains("PreArm: 3D Accel calibration needed"), "{s}");
    assert!(s.contains("PreArm: Compass not calibrated"), "{s}");
    // The default simulated vehicle is calibrated: nothing stated, in 40 s.
    let mut r = runner("seed=1", 40.0);
    assert!(reasons(&r).is_empty());
    keys(&mut r, &["8"]);
    let s = common::screen(&r, 80, 24);
    assert!(s.contains("no reason stated"), "{s}");
}

/// A reason the vehicle stops stating (the compass calibrated) goes once it was not
/// repeated for KEEP; the one still stated every 30 s stays.
#[test]
fn a_reason_no_longer_stated_ages_out() {
    let mut r = runner("uncal=1", 7.0);
    command(&mut r, "cal compass-fixed 0");
    yes(&mut r);
    wait(&mut r, 2.0);
    assert!(
        action(&r).contains("large-vehicle compass calibration: done"),
        "{}",
        action(&r)
    );
    // Stated at about 4 s; the vehicle states only the accelerometer at 34 s and 64 s.
    r.advance_to(4 * SECOND + KEEP - SECOND);
    assert_eq!(reasons(&r).len(), 2, "{:?}", reasons(&r));
    r.advance_to(5 * SECOND + KEEP + SECOND);
    assert_eq!(reasons(&r), vec!["PreArm: 3D Accel calibration needed"]);
    keys(&mut r, &["8"]);
    let s = common::screen(&r, 80, 24);
    assert!(!s.contains("Compass not calibrated"), "{s}");
    assert!(s.contains("1 reason not to arm"), "{s}");
}

/// `c` asks at once (RUN_PREARM_CHECKS): the vehicle states what fails before its ACK, and a
/// reason it did not state again goes at once.
#[test]
fn asked_again_with_c() {
    let mut r = runner("uncal=1", 7.0);
    command(&mut r, "cal compass-fixed 0");
    yes(&mut r);
    wait(&mut r, 2.0);
    assert_eq!(reasons(&r).len(), 2);
    keys(&mut r, &["8", "c"]);
    wait(&mut r, 1.0);
    assert_eq!(reasons(&r), vec!["PreArm: 3D Accel calibration needed"]);
    assert_eq!(
        action(&r),
        "RUN_PREARM_CHECKS to 1:1: ACCEPTED: 1 failing: PreArm: 3D Accel calibration needed"
    );
    let s = common::screen(&r, 80, 24);
    assert!(s.contains("(asked 1s ago)"), "{s}");
}

/// A refused arm: the vehicle's own reason and the others it gives now, on the status bar.
#[test]
fn a_refused_arm_shows_its_reasons_on_the_status_bar() {
    let mut r = runner("uncal=1", 7.0);
    command(&mut r, "arm");
    yes(&mut r);
    wait(&mut r, 2.0);
    let a = action(&r);
    // The first text after the ACK is the refusal's reason; the other failing check follows.
    assert_eq!(
        a,
        "COMPONENT_ARM_DISARM to 1:1: FAILED (Arm: 3D Accel calibration needed); pre-arm: \
         Arm: Compass not calibrated (screen 8)"
    );
    let bar = common::screen(&r, 200, 60);
    assert!(
        bar.contains("pre-arm: Arm: Compass not calibrated (screen 8)"),
        "{bar}"
    );
    // A take-off from the ground stops at its arm step, with the same reasons.
    command(&mut r, "takeoff 5");
    yes(&mut r);
    wait(&mut r, 6.0);
    let a = action(&r);
    assert!(a.contains("3D Accel calibration needed"), "{a}");
    assert!(a.contains("Compass not calibrated"), "{a}");
}

#[test]
fn health_screen_snapshots() {
    let mut r = runner("uncal=1", 7.0);
    keys(&mut r, &["8"]);
    insta::assert_snapshot!("health_uncalibrated_80x24", common::screen(&r, 80, 24));
    command(&mut r, "cal compass");
    yes(&mut r);
    wait(&mut r, 5.0);
    insta::assert_snapshot!("health_compass_running_200x60", common::screen(&r, 200, 60));
    insta::assert_snapshot!("health_compass_running_80x24", common::screen(&r, 80, 24));
}
