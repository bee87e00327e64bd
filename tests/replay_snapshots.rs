//! Screens of every pane, made by headless replay of an input file (tests/data/replay/tour.txt)
//! on `sim://` with impairments, at 80x24 and 200x60, compared with reviewed insta snapshots;
//! and the binary's replay: byte-identical screens on a second run, exit status on early quit.

mod common;

use std::process::Command;

use mavterm::app::AppConfig;
use mavterm::headless::replay::{run_script_on_specs, ReplayOptions};
use mavterm::headless::script::Script;
use mavterm::link::LinkSpec;
use mavterm::proto::vehicles::VehicleKey;

const SIM: &str = "sim://?vehicles=2&loss=0.05&dup=0.01&reorder=0.02&corrupt=0.002&seed=7";

fn tour_screens(size: (u16, u16)) -> Vec<(String, String)> {
    let script = Script::load(&common::test_path("data/replay/tour.txt")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let opts = ReplayOptions {
        size,
        screens_dir: Some(dir.path().to_path_buf()),
        ..ReplayOptions::default()
    };
    let specs: Vec<LinkSpec> = vec![SIM.parse().unwrap()];
    let (outcome, _app) = run_script_on_specs(
        &script,
        &specs,
        AppConfig::default(),
        &opts,
        &mut Vec::new(),
    )
    .unwrap();
    assert!(outcome.completed);
    outcome
        .snapshots
        .iter()
        .map(|name| {
            let text = std::fs::read_to_string(dir.path().join(format!("{name}.txt"))).unwrap();
            (name.clone(), text)
        })
        .collect()
}

#[test]
fn tour_at_80x24() {
    let screens = tour_screens((80, 24));
    assert_eq!(screens.len(), 5);
    for (name, text) in screens {
        insta::assert_snapshot!(format!("tour_80x24_{name}"), text);
    }
}

#[test]
fn tour_at_200x60() {
    for (name, text) in tour_screens((200, 60)) {
        insta::assert_snapshot!(format!("tour_200x60_{name}"), text);
    }
}

fn run_binary(args: &[&str]) -> std::process::Output {
    Command::new(common::mavterm()).args(args).output().unwrap()
}

#[test]
fn binary_replay_is_deterministic() {
    let tour = common::test_path("data/replay/tour.txt");
    let dirs = [tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap()];
    for d in &dirs {
        let out = run_binary(&[
            "--link",
            SIM,
            "--headless",
            "--input",
            tour.to_str().unwrap(),
            "--size",
            "100x30",
            "--screens",
            d.path().to_str().unwrap(),
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let mut names: Vec<_> = std::fs::read_dir(dirs[0].path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    names.sort();
    assert_eq!(names.len(), 5);
    for n in names {
        let a = std::fs::read(dirs[0].path().join(&n)).unwrap();
        let b = std::fs::read(dirs[1].path().join(&n)).unwrap();
        assert_eq!(a, b, "{n:?} differs between runs");
        assert!(!a.is_empty());
    }
}

#[test]
fn binary_exit_status_says_whether_the_script_ran_to_the_end() {
    let dir = tempfile::tempdir().unwrap();
    let early = dir.path().join("early.txt");
    std::fs::write(&early, "1 key q\n2 snapshot never\n").unwrap();
    let out = run_binary(&["--headless", "--input", early.to_str().unwrap()]);
    assert!(!out.status.success());
    let bad = dir.path().join("bad.txt");
    std::fs::write(&bad, "1 key tab\nsoon key q\n").unwrap();
    let out = run_binary(&["--headless", "--input", bad.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("line 2"), "{err}");
    let good = dir.path().join("good.txt");
    std::fs::write(&good, "1 snapshot s\n2 quit\n").unwrap();
    let out = run_binary(&["--headless", "--input", good.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("=== snapshot s"));
}

#[test]
fn binary_replays_on_a_real_tcp_link_in_real_time() {
    let port = common::free_tcp_port();
    let _server = common::sim_server(port, "seed=4");
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("real.txt");
    std::fs::write(&script, "2.5 snapshot live\n3 quit\n").unwrap();
    let started = std::time::Instant::now();
    let out = run_binary(&[
        "--link",
        &format!("tcp:127.0.0.1:{port}"),
        "--headless",
        "--input",
        script.to_str().unwrap(),
        "--size",
        "80x24",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        started.elapsed() >= std::time::Duration::from_millis(2900),
        "ran in real time"
    );
    let screen = String::from_utf8_lossy(&out.stdout);
    assert!(screen.contains("=== snapshot live"), "{screen}");
    let words = screen.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(words.contains("1:1 QUADROTOR STABILIZE"), "{screen}");
    assert!(
        screen.contains(&format!("tcp:127.0.0.1:{port}")),
        "{screen}"
    );
}

#[test]
fn a_vehicle_that_falls_silent_is_shown_lost() {
    // The MAVFTP capture is 2.2 s of a real ArduCopter; after it ends the vehicle goes quiet.
    // A path relative to the package (cargo runs tests there), so the screen is the same in
    // any checkout.
    let specs: Vec<LinkSpec> = vec!["tlog:tests/data/copter-mavftp-params.vehicle.tlog"
        .parse()
        .unwrap()];
    let script = Script::parse("2 snapshot alive\n12 snapshot lost\n").unwrap();
    let mut out = Vec::new();
    let (outcome, app) = run_script_on_specs(
        &script,
        &specs,
        AppConfig::default(),
        &ReplayOptions {
            size: (80, 24),
            ..ReplayOptions::default()
        },
        &mut out,
    )
    .unwrap();
    assert!(outcome.completed);
    assert!(app.vehicles.get(VehicleKey(1, 1)).unwrap().lost);
    let text = String::from_utf8(out).unwrap();
    let lost = text.split("=== snapshot lost").nth(1).unwrap();
    assert!(lost.contains("vehicle 1:1 lost"), "{lost}");
    insta::assert_snapshot!("tlog_vehicle_lost_80x24", lost);
}
