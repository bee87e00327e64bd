//! Missions as each autopilot family holds them, against a pymavlink stand-in vehicle
//! (tests/py/fake_mission_vehicle.py) over TCP through the `mavterm` binary. Only ArduPilot
//! reserves mission item 0 for home (QGroundControl's APM plugin sends it a home item, its PX4
//! and generic ones do not); a vehicle of any other stack holds mission items from seq 0.
//! Expected items come from the WPL file and the stand-in's log, never from mavterm.

mod common;

use std::ffi::OsStr;
use std::path::Path;

/// The stand-in as `autopilot` with `extra` arguments; a download, the Mission screen, then the
/// square mission loaded and uploaded, and the file's row 2 (its second waypoint) made current
/// with `c`. Returns the screen after the download, the uploads the stand-in received and the
/// current items it was asked to fly.
fn run(autopilot: &str, extra: &[&str]) -> (String, Vec<Vec<Vec<f64>>>, Vec<u64>) {
    let dir = tempfile::tempdir().unwrap();
    let port = common::free_tcp_port();
    let log = dir.path().join("uploads.json");
    let current_log = dir.path().join("current.json");
    let mut a: Vec<std::ffi::OsString> = vec![
        "--port".into(),
        port.to_string().into(),
        "--autopilot".into(),
        autopilot.into(),
        "--log-out".into(),
        log.clone().into(),
        "--current-log".into(),
        current_log.clone().into(),
    ];
    a.extend(extra.iter().map(|s| s.into()));
    let _v = common::stand_in("fake_mission_vehicle.py", &a);
    let file = common::test_path("data/missions/square.waypoints");
    let script = format!(
        "2 text \":wp download\\n\"\n3.5 key 5\n4 snapshot downloaded\n\
         4.5 text \":wp load {}\\n\"\n5 text \":wp upload\\n\"\n\
         7 key down\n7.1 key down\n7.2 key c\n9 quit\n",
        file.display()
    );
    let path = dir.path().join("script.txt");
    std::fs::write(&path, script).unwrap();
    let screens = dir.path().join("screens");
    let size = ["--size", "120x30", "--screens"].map(OsStr::new);
    common::headless_tcp(port, &path, size.into_iter().chain([screens.as_os_str()]));
    let screen = std::fs::read_to_string(screens.join("downloaded.txt")).unwrap();
    if std::env::var("PEEK").is_ok() {
        eprintln!("{screen}");
    }
    let uploads = std::fs::read_to_string(&log)
        .map(|t| serde_json::from_str(&t).unwrap())
        .unwrap_or_default();
    let currents = std::fs::read_to_string(&current_log)
        .map(|t| serde_json::from_str(&t).unwrap())
        .unwrap_or_default();
    (screen, uploads, currents)
}

/// The square mission's lines (seq, command, frame, current, x, y, z) as the WPL file says.
fn wpl_items(path: &Path) -> Vec<Vec<f64>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let w: Vec<f64> = l.split('\t').map(|x| x.parse().unwrap()).collect();
            vec![
                w[0],
                w[3],
                w[2],
                w[1],
                (w[8] * 1e7).round(),
                (w[9] * 1e7).round(),
                w[10],
            ]
        })
        .collect()
}

#[test]
fn a_generic_vehicle_gets_no_home_item_and_its_item_0_is_no_home() {
    let (screen, uploads, currents) = run("generic", &["--current-total", "0"]);
    // The file's row 2 is the vehicle's item 1 (no home item before it).
    assert_eq!(currents, vec![1], "{screen}");
    // Its own first item is a waypoint at 10 m, not HOME.
    assert!(!screen.contains("HOME"), "{screen}");
    assert!(screen.contains("WAYPOINT"), "{screen}");
    // MISSION_CURRENT total 0 ("not supported"): the list's length.
    assert!(screen.contains("current 1 of 2"), "{screen}");
    // The file's home line stays behind: items 1..5 go as seq 0..4, the first current.
    let want: Vec<Vec<f64>> = wpl_items(&common::test_path("data/missions/square.waypoints"))
        .into_iter()
        .skip(1)
        .enumerate()
        .map(|(n, mut i)| {
            i[0] = n as f64;
            i
        })
        .collect();
    assert_eq!(uploads.len(), 1, "{uploads:?}");
    let got: Vec<Vec<f64>> = uploads[0]
        .iter()
        .map(|i| {
            let mut i = i.clone();
            i[3] = 0.0; // `current` is the GCS's to choose
            i
        })
        .collect();
    let want: Vec<Vec<f64>> = want
        .into_iter()
        .map(|mut i| {
            i[3] = 0.0;
            i
        })
        .collect();
    assert_eq!(got, want);
    assert!(
        uploads[0].iter().all(|i| i[6] != 584.0),
        "home went up: {uploads:?}"
    );
}

#[test]
fn an_ardupilot_vehicle_keeps_its_home_item() {
    let (screen, uploads, currents) = run("ardupilot", &["--current-total", "0"]);
    // ArduPilot numbers as the file does, home at 0.
    assert_eq!(currents, vec![2]);
    assert!(screen.contains("HOME"), "{screen}");
    // seq 1 of the two items after home.
    assert!(screen.contains("current 1 of 2"), "{screen}");
    let want = wpl_items(&common::test_path("data/missions/square.waypoints"));
    assert_eq!(uploads.len(), 1, "{uploads:?}");
    assert_eq!(uploads[0].len(), want.len());
    for (g, w) in uploads[0].iter().zip(&want) {
        assert_eq!(
            (g[0], g[1], g[2], g[4], g[5], g[6]),
            (w[0], w[1], w[2], w[4], w[5], w[6])
        );
    }
}
