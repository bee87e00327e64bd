//! Mission, geofence and rally point transfers through the prompt against `sim://` (ArduCopter's
//! mission protocol) on the virtual clock, without loss and with 30 % loss both ways: a 50-item
//! mission, a fence and rally points loaded from WPL files, uploaded, downloaded again and saved;
//! what comes back is the file, item by item. And the mixed-frame confirmation.

mod common;

use mavterm::app::AppConfig;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::LinkSpec;
use mavterm::mission::{wpl, MissionType};
use mavterm::proto::vehicles::VehicleKey;

const SECOND: u64 = 1_000_000;

fn runner(query: &str) -> VirtualRunner {
    let spec: LinkSpec = format!("sim://?{query}").parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    // Home is set when the EKF uses GPS (5 s): item 0 of the mission reads as home.
    r.advance_to(6 * SECOND);
    r
}

fn command(r: &mut VirtualRunner, line: &str) {
    common::keys(r, &[":"]);
    common::typed(r, line);
    common::keys(r, &["enter"]);
    let t = r.now() + 1000;
    r.advance_to(t);
}

/// Run until the target's transfers are done (at most `limit` seconds).
fn settle(r: &mut VirtualRunner, limit: u64) {
    let end = r.now() + limit * SECOND;
    while r.now() < end {
        let t = r.now() + SECOND / 2;
        r.advance_to(t);
        let s = &r.app.sessions[&VehicleKey(1, 1)];
        if !s.mission.busy() && s.mission.queued().count() == 0 {
            return;
        }
    }
    panic!("transfers still running after {limit} s");
}

/// Home (the sim's), then 49 waypoints and loiters in a zigzag, with delays and speeds.
fn mission_file() -> String {
    let mut s =
        String::from("QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t-35.3632621\t149.1652374\t584\t1\n");
    for i in 1..50u32 {
        let lat = -35.3632621 + (i / 7) as f64 * 0.0002;
        let lon = 149.1652374 + (i % 7) as f64 * 0.0003;
        let (cmd, p1) = match i % 10 {
            5 => (178, 1.0), // DO_CHANGE_SPEED: airspeed type 1... (param2 speed below)
            9 => (19, 3.0),  // NAV_LOITER_TIME 3 s
            _ => (16, (i % 3) as f64),
        };
        if cmd == 178 {
            // ArduPilot gives commands without a position back in frame 0.
            s += &format!("{i}\t0\t0\t178\t1\t{}\t-1\t0\t0\t0\t0\t1\n", 4 + i % 3);
        } else {
            // A loiter's direction comes back as param3 = 1 (clockwise), as ArduPilot keeps it.
            let p3 = if cmd == 19 { 1 } else { 0 };
            s += &format!(
                "{i}\t0\t3\t{cmd}\t{p1}\t0\t{p3}\t0\t{lat:.7}\t{lon:.7}\t{}\t1\n",
                20.0 + (i % 5) as f64 * 2.5
            );
        }
    }
    s
}

/// An inclusion polygon of 4 vertices and an exclusion circle (autocontinue 0, as ArduPilot
/// gives fence and rally items back).
fn fence_file() -> String {
    let mut s = String::from("QGC WPL 110\n");
    let corners = [(0.0, 0.0), (0.002, 0.0), (0.002, 0.003), (0.0, 0.003)];
    for (i, (dn, de)) in corners.iter().enumerate() {
        s += &format!(
            "{i}\t0\t0\t5001\t4\t0\t0\t0\t{:.7}\t{:.7}\t0\t0\n",
            -35.3642621 + dn,
            149.1642374 + de
        );
    }
    s += "4\t0\t0\t5004\t30\t0\t0\t0\t-35.3622621\t149.1662374\t0\t0\n";
    s
}

fn rally_file() -> String {
    let mut s = String::from("QGC WPL 110\n");
    for i in 0..3 {
        s += &format!(
            "{i}\t0\t3\t5100\t0\t0\t0\t0\t{:.7}\t{:.7}\t{}\t0\n",
            -35.3632621 + i as f64 * 0.0005,
            149.1662374,
            30 + i * 5
        );
    }
    s
}

fn round_trip(query: &str) {
    let mut r = runner(query);
    let dir = tempfile::tempdir().unwrap();
    let lists = [
        (MissionType::Mission, "wp", mission_file()),
        (MissionType::Fence, "fence", fence_file()),
        (MissionType::Rally, "rally", rally_file()),
    ];
    for (t, word, text) in &lists {
        let path = dir.path().join(format!("{word}.waypoints"));
        std::fs::write(&path, text).unwrap();
        let want = wpl::parse(text, *t);
        assert!(want.ok(), "{:?}", want.errors);
        command(&mut r, &format!("{word} load {}", path.display()));
        assert!(
            r.app.ui.mission.files[t.index()].is_some(),
            "{word} not loaded"
        );
        command(&mut r, &format!("{word} upload"));
        assert!(r.app.ui.confirm.is_none(), "{:?}", r.app.ui.confirm);
        settle(&mut r, 120);
        // The vehicle's one MISSION_ACK can be lost too: mavterm then says it cannot tell and
        // that a download shows it, which the round trip below does.
        let unsure = r
            .app
            .notices
            .iter()
            .last()
            .is_some_and(|n| n.text.contains("may or may not have taken"));
        if !r.app.file_uploaded(*t) && !unsure {
            for n in r.app.notices.iter() {
                eprintln!("{:.2} {}", n.t as f64 / 1e6, n.text);
            }
            panic!("{word} upload failed");
        }
        command(&mut r, &format!("{word} download"));
        settle(&mut r, 120);
        let k = r.app.sessions[&VehicleKey(1, 1)].mission.known(*t).unwrap();
        assert!(k.downloaded);
        assert_eq!(k.items.len(), want.items.len(), "{word}");
        for (got, file) in k.items.iter().zip(&want.items) {
            // Home's `current` flag is the file's habit (Mission Planner writes 1); ArduPilot
            // sends 0 for every item.
            let file = mavterm::mission::MissionItem {
                current: got.current,
                ..*file
            };
            assert_eq!(*got, file, "{word} item {}", file.seq);
        }
        // Saved again, the file says the same.
        let saved = dir.path().join(format!("{word}-saved.waypoints"));
        command(&mut r, &format!("{word} save {}", saved.display()));
        let back = std::fs::read_to_string(&saved).unwrap();
        let k = r.app.sessions[&VehicleKey(1, 1)].mission.known(*t).unwrap();
        assert!(
            wpl::parse(&back, *t).items == k.items,
            "{word} saved: {back}"
        );
    }
}

#[test]
fn lists_round_trip_without_loss() {
    round_trip("seed=1");
}

#[test]
fn lists_round_trip_with_30_percent_loss() {
    round_trip("loss=0.3&seed=3");
}

#[test]
fn a_mixed_frame_file_asks_first_and_no_sends_nothing() {
    let mut r = runner("");
    command(
        &mut r,
        &format!(
            "wp load {}",
            common::test_path("data/missions/mixed-frames.waypoints").display()
        ),
    );
    command(&mut r, "wp upload");
    let c = r.app.ui.confirm.clone().expect("a confirmation");
    assert!(c.text.contains("altitudes in mixed frames"), "{}", c.text);
    assert!(
        c.text.contains("AMSL (item 3)") && c.text.contains("REL"),
        "{}",
        c.text
    );
    let s = common::screen(&r, 80, 24);
    assert!(s.contains("mixed frames"), "{s}");
    // `n`: nothing goes.
    let fx = r.app.update(
        r.now(),
        mavterm::app::Event::Key(mavterm::keymap::Key::ch('n')),
    );
    assert!(
        !fx.iter()
            .any(|e| matches!(e, mavterm::app::Effect::Send { msg, .. }
            if !matches!(msg, mavterm::dialect::MavMessage::HEARTBEAT(_)))),
        "{fx:?}"
    );
    settle(&mut r, 5);
    let s = &r.app.sessions[&VehicleKey(1, 1)];
    assert!(s.mission.known(MissionType::Mission).is_none());
    assert!(r.app.ui.message.as_ref().unwrap().1.contains("cancelled"));
}
