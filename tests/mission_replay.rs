//! Headless replay on `sim://`: take off, upload a 4-waypoint mission from a WPL file, start it
//! (after a confirmation), watch it fly on the Mission screen (80x24 snapshots) and land at its
//! end (the sim's NAV_LAND disarms).

mod common;

use mavterm::app::AppConfig;
use mavterm::headless::replay::{run_script_on_specs, ReplayOptions};
use mavterm::headless::script::Script;
use mavterm::link::LinkSpec;
use mavterm::mission::MissionType;

#[test]
fn a_mission_from_a_file_flies_and_lands() {
    let script = Script::load(&common::test_path("data/replay/mission.txt")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let opts = ReplayOptions {
        size: (80, 24),
        screens_dir: Some(dir.path().to_path_buf()),
        ..ReplayOptions::default()
    };
    let specs: Vec<LinkSpec> = vec!["sim://?seed=3".parse().unwrap()];
    let (outcome, app) = run_script_on_specs(
        &script,
        &specs,
        AppConfig::default(),
        &opts,
        &mut Vec::new(),
    )
    .unwrap();
    assert!(outcome.completed);
    let key = app.target.expect("a target");
    let s = &app.sessions[&key];
    // What the vehicle holds is the file's list, item by item.
    let file =
        std::fs::read_to_string(common::test_path("data/missions/square.waypoints")).unwrap();
    let want = mavterm::mission::wpl::parse(&file, MissionType::Mission).items;
    assert_eq!(s.mission.known(MissionType::Mission).unwrap().items, want);
    // Every waypoint reached, and the vehicle landed and disarmed.
    let reached: Vec<u16> = s.mission.reached().map(|(_, q)| q).collect();
    for wp in 1..=4 {
        assert!(reached.contains(&wp), "{wp} not in {reached:?}");
    }
    assert!(!app.vehicles.get(key).unwrap().armed(), "still armed");
    for name in &outcome.snapshots {
        let text = std::fs::read_to_string(dir.path().join(format!("{name}.txt"))).unwrap();
        insta::assert_snapshot!(format!("mission_80x24_{name}"), text);
    }
}
