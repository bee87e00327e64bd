//! Before flight, on the simulated ArduCopter fresh from the box (`sim://?uncal=1`, virtual
//! clock): the pre-arm reasons gathered from its `PreArm:` statements and shown on the Health
//! screen and the Overview, aged out when the vehicle stops stating them, asked again with
//! `c` (RUN_PREARM_CHECKS, given up when its ACK is lost); a refused arm's reasons on the
//! status bar; the Health screen at 80x24 and 200x60, and short; a PX4 vehicle's reasons kept
//! and ArduPilot's calibrations refused on it.

mod common;

use common::{command, keys, wait, yes};

use mavterm::app::AppConfig;
use mavterm::dialect::{self, MavMessage};
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::source::VirtualSource;
use mavterm::link::LinkSpec;
use mavterm::proto::health::{ASK_TIMEOUT, KEEP};
use mavterm::proto::vehicles::VehicleKey;
use mavterm::wire::frame::{encode, Header, Version};

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
    // The Health screen's summary on the Flight pane's title row.
    assert!(
        overview.contains("─ Flight 1:1 ─ 2 pre-arm reasons (screen 8) ─"),
        "{overview}"
    );
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
    // Both compasses done: their results, and the keys that apply (accept, cancel).
    let end = r.now() + 30 * SECOND;
    while r.app.sessions[&KEY].calibration.run.as_ref().unwrap().phase
        != mavterm::proto::calibration::Phase::Accept
        && r.now() < end
    {
        wait(&mut r, 0.5);
    }
    insta::assert_snapshot!("health_compass_accept_80x24", common::screen(&r, 80, 24));
    // The Overview says so too, on the Flight pane's title row.
    keys(&mut r, &["1"]);
    let overview = common::screen(&r, 80, 24);
    assert!(
        overview.contains("─ 2 pre-arm reasons, compass calibration to accept (screen 8) ─"),
        "{overview}"
    );
}

/// On a short terminal the calibration and its keys stay; what does not fit is left out whole,
/// and named.
#[test]
fn a_short_health_screen_keeps_the_calibration_and_its_keys() {
    let mut r = runner("uncal=1", 7.0);
    keys(&mut r, &["8"]);
    command(&mut r, "cal compass");
    yes(&mut r);
    wait(&mut r, 5.0);
    let s = common::screen(&r, 80, 18);
    for want in [
        "PreArm: Compass not calibrated",
        "CALIBRATE compass calibration",
        "mag 0 █",
        "mag 1 █",
        "x cancel",
        "not shown: EKF, vibration, radio (a taller terminal shows them)",
    ] {
        assert!(s.contains(want), "{want}: {s}");
    }
}

/// RUN_PREARM_CHECKS whose ACK is lost (`drop_ack`): the screen stops saying "asking…" and
/// says the ask got no answer; `c` asks again.
#[test]
fn an_ask_whose_ack_is_lost_is_given_up() {
    let mut r = runner("uncal=1&drop_ack=401:1", 7.0);
    keys(&mut r, &["8", "c"]);
    wait(&mut r, 1.0);
    let s = common::screen(&r, 80, 24);
    assert!(s.contains("(asking…)"), "{s}");
    wait(&mut r, ASK_TIMEOUT as f64 / SECOND as f64);
    let s = common::screen(&r, 80, 24);
    assert!(s.contains("(no answer: c asks again)"), "{s}");
    keys(&mut r, &["c"]);
    wait(&mut r, 1.0);
    let s = common::screen(&r, 80, 24);
    assert!(s.contains("(asked 1s ago)"), "{s}");
}

/// A PX4 vehicle (HEARTBEAT autopilot PX4) stating one failed check once, then its heartbeat.
#[derive(Default)]
struct Px4Vehicle {
    next: u64,
    seq: u8,
}

impl Px4Vehicle {
    fn frame(&mut self, msg: &MavMessage) -> Vec<u8> {
        let h = Header {
            sysid: 1,
            compid: 1,
            seq: self.seq,
        };
        self.seq = self.seq.wrapping_add(1);
        encode(Version::V2, h, msg)
    }
}

impl VirtualSource for Px4Vehicle {
    fn receive(&mut self, _: u64, _: &[u8]) {}
    fn poll(&mut self, now: u64) -> Vec<u8> {
        let mut out = Vec::new();
        while self.next <= now {
            let hb = MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
                custom_mode: 0,
                mavtype: dialect::MavType::MAV_TYPE_QUADROTOR,
                autopilot: dialect::MavAutopilot::MAV_AUTOPILOT_PX4,
                base_mode: dialect::MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                system_status: dialect::MavState::MAV_STATE_STANDBY,
                mavlink_version: 3,
            });
            out.extend(self.frame(&hb));
            if self.next == 2 * SECOND {
                let text = common::statustext(
                    dialect::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "Preflight Fail: Accel Sensor 0 missing",
                );
                out.extend(self.frame(&text));
            }
            self.next += SECOND;
        }
        out
    }
    fn next_deadline(&self) -> u64 {
        self.next
    }
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

/// PX4 does not repeat its reasons on ArduPilot's 30 s cadence: they are kept (not aged out
/// after KEEP). ArduPilot's accelerometer, compass and large-vehicle calibrations are refused
/// before anything is asked or sent; PREFLIGHT_CALIBRATION's gyro is asked as usual.
#[test]
fn on_px4_reasons_stay_and_ardupilot_calibrations_are_refused() {
    let cfg = AppConfig {
        links: vec!["px4".into()],
        epoch: mavterm::driver::virtual_time::virtual_epoch(),
        ..AppConfig::default()
    };
    let mut r = VirtualRunner::new(cfg, vec![Box::new(Px4Vehicle::default())]);
    r.advance_to(3 * SECOND);
    assert_eq!(reasons(&r), vec!["Preflight Fail: Accel Sensor 0 missing"]);
    r.advance_to(3 * SECOND + 2 * KEEP);
    assert_eq!(reasons(&r), vec!["Preflight Fail: Accel Sensor 0 missing"]);
    keys(&mut r, &["8"]);
    let s = common::screen(&r, 80, 24);
    assert!(s.contains("1 reason not to arm"), "{s}");
    for (word, what) in [
        (
            "accel",
            "accelerometer calibration is ArduPilot's (ACCELCAL_VEHICLE_POS)",
        ),
        (
            "compass",
            "compass calibration is ArduPilot's (DO_START_MAG_CAL)",
        ),
        (
            "compass-fixed 90",
            "large-vehicle compass calibration is ArduPilot's (FIXED_MAG_CAL_YAW)",
        ),
    ] {
        command(&mut r, &format!("cal {word}"));
        assert!(r.app.ui.confirm.is_none(), "{word}: not asked");
        let msg = r.app.ui.message.clone().unwrap().1;
        assert_eq!(msg, format!("1:1 runs PX4: the {what}, not sent"));
    }
    keys(&mut r, &["m"]);
    assert!(r.app.ui.confirm.is_none());
    command(&mut r, "cal gyro");
    assert!(r.app.ui.confirm.is_some(), "the gyros are PX4's too");
}

/// The EKF failsafe is judged against the vehicle's own `FS_EKF_THRESH` once its parameters are
/// in (ArduCopter's `ekf_over_threshold`): the sim's variances (velocity 0.02, position 0.01,
/// compass 0.02) are within the default 0.8, and over a threshold of 0.015 for compass and
/// velocity, two of three.
#[test]
fn the_ekf_failsafe_uses_the_vehicles_threshold() {
    let mut r = runner("", 8.0);
    common::keys(&mut r, &["8"]);
    let s = common::screen(&r, 200, 60);
    assert!(s.contains("FS_EKF_THRESH 0.8: within"), "{s}");
    common::command(&mut r, "param set FS_EKF_THRESH 0.015");
    common::wait(&mut r, 2.0);
    let s = common::screen(&r, 200, 60);
    assert!(s.contains("FS_EKF_THRESH 0.015: OVER"), "{s}");
    assert!(s.contains("EKF variance"), "{s}");
}
