//! Mission files: waypoint files (`QGC WPL 110`) as Mission Planner and MAVProxy write them, read
//! and written back; pymavlink's `mavwp` reading what we write and writing what we read;
//! QGroundControl `.plan` files with a mission, a geofence and rally points; files with errors;
//! the checks an upload asks the operator to confirm.

mod common;

use std::collections::BTreeMap;

use mavterm::mission::plan::{self, Plan};
use mavterm::mission::{upload_warnings, wpl, AltRef, MissionItem, MissionType};
use serde_json::Value;

fn data(name: &str) -> String {
    std::fs::read_to_string(common::test_path(&format!("data/missions/{name}"))).unwrap()
}

/// Run a Python snippet with pymavlink; its stdout as JSON.
fn python(script: &str, args: &[&str]) -> Value {
    let out = std::process::Command::new(common::python())
        .arg("-c")
        .arg(script)
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "python: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

const READ_WITH_MAVWP: &str = r#"
import json, sys
from pymavlink import mavwp
w = mavwp.MAVWPLoader()
w.load(sys.argv[1])
print(json.dumps([[p.seq, p.current, p.frame, p.command, p.param1, p.param2, p.param3,
    None if p.param4 != p.param4 else p.param4, p.x, p.y, p.z, p.autocontinue]
    for p in w.wpoints]))
"#;

#[test]
fn mission_planner_file_round_trips_byte_for_byte() {
    let text = data("mission-planner.waypoints");
    let f = wpl::parse(&text, MissionType::Mission);
    assert!(f.ok(), "{:?}", f.errors);
    assert_eq!(f.items.len(), 8);
    // Home, then take-off to 15 m above home, a waypoint, a speed change, a jump, RTL.
    let home = &f.items[0];
    assert_eq!((home.frame, home.alt_ref()), (0, AltRef::Amsl));
    assert_eq!(
        (home.x, home.y, home.z),
        (-353_632_610, 1_491_652_300, 584.0)
    );
    assert_eq!(f.items[1].altitude_text().unwrap(), "15.0 m REL");
    assert_eq!(f.items[4].y, 1_491_657_807);
    assert_eq!(f.items[6].params[..2], [2.0, 1.0], "DO_JUMP to 2, once");
    assert_eq!(
        f.items[3].altitude_text(),
        None,
        "a speed change has no altitude"
    );
    // Written back: the same text, line ends aside.
    assert_eq!(
        wpl::write(&f.items, &f.comments),
        text.replace("\r\n", "\n")
    );
}

#[test]
fn mavproxy_file_reads_and_pymavlink_reads_what_we_write() {
    let f = wpl::parse(&data("mavproxy.txt"), MissionType::Mission);
    assert!(f.ok(), "{:?}", f.errors);
    assert_eq!(f.comments.get(&1).map(String::as_str), Some("climb out"));
    assert_eq!(f.items[0].z, 584.09);
    assert!(f.items[2].params[3].is_nan());
    assert_eq!(f.items[3].alt_ref(), AltRef::Terr);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.waypoints");
    std::fs::write(&path, wpl::write(&f.items, &f.comments)).unwrap();
    let read = python(READ_WITH_MAVWP, &[path.to_str().unwrap()]);
    let rows = read.as_array().unwrap();
    assert_eq!(rows.len(), f.items.len());
    for (row, i) in rows.iter().zip(&f.items) {
        let r = row.as_array().unwrap();
        let n = |k: usize| r[k].as_f64().unwrap();
        assert_eq!(
            (n(0), n(1), n(2), n(3), n(11)),
            (
                i.seq as f64,
                i.current as u8 as f64,
                i.frame as f64,
                i.command as f64,
                i.autocontinue as u8 as f64
            ),
            "{row}"
        );
        assert_eq!(
            (n(4) as f32, n(5) as f32, n(6) as f32),
            (i.params[0], i.params[1], i.params[2])
        );
        assert_eq!(
            r[7].as_f64().map(|v| v as f32),
            Some(i.params[3]).filter(|v| !v.is_nan())
        );
        // pymavlink holds MISSION_ITEM's float32 x/y: within a float's step of ours.
        assert!((n(8) - i.param5()).abs() < 2e-6, "{row}");
        assert!((n(9) - i.param6()).abs() < 2e-6, "{row}");
        assert_eq!(n(10) as f32, i.z);
    }
}

#[test]
fn what_pymavlink_writes_we_read() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mavwp.txt");
    let script = r#"
import json, sys
from pymavlink import mavwp, mavutil
m = mavutil.mavlink
w = mavwp.MAVWPLoader()
rows = [
    (0, 1, 0, 16, 0, 0, 0, 0, -35.363261, 149.165230, 584.0, 1),
    (1, 0, 3, 22, 0, 0, 0, 0, 0, 0, 12.5, 1),
    (2, 0, 6, 16, 3, 0, 0, 0, 47.397742, 8.545594, 30.0, 1),
    (3, 0, 11, 82, 0, 0, 0, 0, 47.398, 8.546, 40.0, 0),
    (4, 0, 2, 177, 1, 3, 0, 0, 0, 0, 0, 1),
]
for r in rows:
    w.add(m.MAVLink_mission_item_message(1, 1, r[0], r[2], r[3], r[1], r[11], r[4], r[5], r[6], r[7], r[8], r[9], r[10]))
w.save(sys.argv[1])
print(json.dumps(rows))
"#;
    let rows = python(script, &[path.to_str().unwrap()]);
    let f = wpl::parse(
        &std::fs::read_to_string(&path).unwrap(),
        MissionType::Mission,
    );
    assert!(f.ok(), "{:?}", f.errors);
    for (row, i) in rows.as_array().unwrap().iter().zip(&f.items) {
        let r: Vec<f64> = row
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        assert_eq!(i.seq as f64, r[0]);
        assert_eq!(i.current, r[1] != 0.0);
        assert_eq!((i.frame as f64, i.command as f64), (r[2], r[3]));
        assert_eq!(i.params.map(|p| p as f64), [r[4], r[5], r[6], r[7]]);
        // pymavlink writes six decimals: the 1e-7° steps we keep are those six.
        assert!((i.param5() - r[8]).abs() < 1e-6 && (i.param6() - r[9]).abs() < 1e-6);
        assert_eq!(i.z as f64, r[10]);
        assert_eq!(i.autocontinue, r[11] != 0.0);
    }
    assert_eq!(f.items[3].alt_ref(), AltRef::Terr);
    assert_eq!(
        f.items[4].x, 0,
        "MAV_FRAME_MISSION: x is a number, not degrees"
    );
}

#[test]
fn a_file_with_a_bad_line_says_where_and_is_not_for_upload() {
    let f = wpl::parse(&data("bad-line.waypoints"), MissionType::Mission);
    assert!(!f.ok());
    let errors: Vec<String> = f.errors.iter().map(|e| e.to_string()).collect();
    assert_eq!(
        errors,
        [
            "line 4: 10 fields where 12 were expected",
            "line 5: z \"fifty\" is not a number",
            "line 6: sequence number 4 where 2 was expected",
        ]
    );
}

#[test]
fn mixed_frames_and_amsl_below_home_need_confirming() {
    let f = wpl::parse(&data("mixed-frames.waypoints"), MissionType::Mission);
    assert!(f.ok(), "{:?}", f.errors);
    let w = upload_warnings(&f.items, Some(584.0), true);
    assert_eq!(
        w,
        [
            "altitudes in mixed frames: AMSL (item 3), REL (items 1-2, 4)",
            "item 3: 30.0 m AMSL is 554.0 m below home (584.0 m AMSL)",
        ]
    );
    // The same mission all above home: nothing to confirm.
    let f = wpl::parse(&data("mission-planner.waypoints"), MissionType::Mission);
    assert!(upload_warnings(&f.items, Some(584.0), true).is_empty());
}

fn rel(items: &[MissionItem]) -> Vec<(u16, u8, f32)> {
    items.iter().map(|i| (i.command, i.frame, i.z)).collect()
}

#[test]
fn qgroundcontrol_plan_reads_all_three_lists() {
    let f = plan::parse(&data("copter.plan"));
    assert!(f.ok(), "{:?}", f.errors);
    let p = &f.plan;
    assert_eq!((p.firmware_type, p.vehicle_type), (3, Some(2)));
    // plannedHomePosition is item 0 (AMSL), the items follow from 1.
    assert_eq!(
        rel(&p.mission),
        [
            (16, 0, 584.0),
            (22, 3, 15.0),
            (16, 3, 20.0),
            (178, 2, 0.0),
            (16, 10, 25.0),
            (177, 2, 0.0),
            (20, 2, 0.0)
        ]
    );
    assert_eq!(
        (p.mission[0].x, p.mission[0].y),
        (-353_632_610, 1_491_652_300)
    );
    assert_eq!(
        p.mission[5].params[0], 2.0,
        "DO_JUMP to doJumpId 2 is item 2"
    );
    assert!(p.mission[1].params[3].is_nan(), "null is NaN");
    // Polygon vertices with their count, the exclusion circle with its radius, the return
    // point above home.
    let fence: Vec<(u16, f32, i32, i32)> = p
        .fence
        .iter()
        .map(|i| (i.command, i.params[0], i.x, i.y))
        .collect();
    assert_eq!(
        fence,
        [
            (5001, 4.0, -353_650_576, 1_491_630_269),
            (5001, 4.0, -353_605_660, 1_491_630_269),
            (5001, 4.0, -353_605_660, 1_491_685_346),
            (5001, 4.0, -353_650_576, 1_491_685_346),
            (5004, 30.0, -353_628_000, 1_491_650_000),
            (5000, 0.0, -353_632_000, 1_491_652_000),
        ]
    );
    assert_eq!(p.fence[5].alt_ref(), AltRef::Rel);
    assert!(p.fence.iter().all(|i| i.mission_type == MissionType::Fence));
    assert_eq!(rel(&p.rally), [(5100, 3, 15.0), (5100, 3, 20.0)]);
    assert_eq!((p.rally[0].x, p.rally[0].y), (-353_635_304, 1_491_654_503));
}

#[test]
fn plan_written_back_keeps_what_qgroundcontrol_wrote() {
    let f = plan::parse(&data("copter.plan"));
    let text = f.plan.to_json().unwrap();
    let again = plan::parse(&text);
    assert!(again.ok(), "{:?}", again.errors);
    assert_eq!(again.plan, f.plan);
    // QGroundControl's keys beside the items are still there, compared with the original.
    let orig: Value = serde_json::from_str(&data("copter.plan")).unwrap();
    let ours: Value = serde_json::from_str(&text).unwrap();
    for k in [
        "cruiseSpeed",
        "hoverSpeed",
        "globalPlanAltitudeMode",
        "firmwareType",
        "vehicleType",
    ] {
        assert_eq!(ours["mission"][k], orig["mission"][k], "{k}");
    }
    assert_eq!(ours["groundStation"], orig["groundStation"]);
    assert_eq!(ours["fileType"], "Plan");
    let items = ours["mission"]["items"].as_array().unwrap();
    let orig_items = orig["mission"]["items"].as_array().unwrap();
    assert_eq!(items.len(), orig_items.len());
    for (a, b) in items.iter().zip(orig_items) {
        for k in [
            "command",
            "frame",
            "autoContinue",
            "doJumpId",
            "type",
            "AltitudeMode",
        ] {
            assert_eq!(a.get(k), b.get(k), "{k} of {b}");
        }
        let pa: Vec<Option<f64>> = a["params"]
            .as_array()
            .unwrap()
            .iter()
            .map(Value::as_f64)
            .collect();
        let pb: Vec<Option<f64>> = b["params"]
            .as_array()
            .unwrap()
            .iter()
            .map(Value::as_f64)
            .collect();
        assert_eq!(pa, pb);
    }
    assert_eq!(ours["geoFence"], orig["geoFence"]);
    assert_eq!(ours["rallyPoints"], orig["rallyPoints"]);
    assert_eq!(
        ours["mission"]["plannedHomePosition"],
        orig["mission"]["plannedHomePosition"]
    );
}

#[test]
fn a_plan_with_a_survey_is_refused_with_where_and_why() {
    let f = plan::parse(&data("survey.plan"));
    assert_eq!(f.errors.len(), 1, "{:?}", f.errors);
    assert_eq!(f.errors[0].at, "mission.items[2]");
    assert!(f.errors[0]
        .why
        .contains("ComplexItem \"survey\" is not supported"));
}

#[test]
fn broken_json_and_wrong_files_say_where() {
    let f = plan::parse("{\n  \"fileType\": \"Plan\",\n  \"version\": 1\n  \"mission\": {}\n}");
    assert_eq!(f.errors.len(), 1);
    assert!(f.errors[0].at.starts_with("line 4"), "{:?}", f.errors);
    let f = plan::parse(r#"{"fileType": "GeoFence", "version": 1}"#);
    let at: Vec<&str> = f.errors.iter().map(|e| e.at.as_str()).collect();
    assert_eq!(at, ["fileType", "mission"]);
    let f = plan::parse(&data("copter.plan").replace("\"polygon\": [", "\"polygon\": [[1, 2], "));
    assert!(f.errors.is_empty(), "five vertices are a polygon too");
    let f = plan::parse(&data("copter.plan").replace("-35.3650576", "-135.3650576"));
    assert_eq!(f.errors[0].at, "geoFence.polygons[0].polygon[0]");
}

#[test]
fn a_plans_mission_saved_as_a_waypoint_file_reads_back_the_same() {
    let f = plan::parse(&data("copter.plan"));
    let text = wpl::write(&f.plan.mission, &BTreeMap::new());
    let back = wpl::parse(&text, MissionType::Mission);
    assert!(back.ok(), "{:?}", back.errors);
    assert_eq!(back.items, f.plan.mission);
    // And a downloaded list made into a plan, saved and read again.
    let p = Plan::new(
        back.items.clone(),
        f.plan.fence.clone(),
        f.plan.rally.clone(),
        3,
        None,
    );
    let again = plan::parse(&p.to_json().unwrap());
    assert!(again.ok(), "{:?}", again.errors);
    assert_eq!(again.plan.mission, back.items);
    assert_eq!(again.plan.fence, f.plan.fence);
}

#[test]
fn lists_a_plan_cannot_hold_are_refused_on_save() {
    let f = plan::parse(&data("copter.plan"));
    let mut rally = f.plan.rally.clone();
    rally[1].frame = 0;
    let p = Plan::new(f.plan.mission.clone(), vec![], rally, 3, None);
    let e = p.to_json().unwrap_err();
    assert!(e.contains("rally point 1 is AMSL"), "{e}");
    let mut fence = f.plan.fence.clone();
    fence.remove(2);
    let p = Plan::new(f.plan.mission.clone(), fence, vec![], 3, None);
    let e = p.to_json().unwrap_err();
    assert!(e.contains("cut short"), "{e}");
}

#[test]
fn a_plan_saved_with_no_vehicle_known_claims_no_firmware() {
    use mavterm::app::AppConfig;
    use mavterm::driver::virtual_time::VirtualRunner;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.plan");
    let mut r = VirtualRunner::from_specs(&[], AppConfig::default()).unwrap();
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/missions/square.waypoints");
    for (t, line) in [
        (1, format!("wp load {}", file.display())),
        (2, format!("wp save {}", out.display())),
    ] {
        r.advance_to(t * 1_000_000);
        r.key(":".parse().unwrap());
        for c in line.chars() {
            r.key(mavterm::keymap::Key::ch(c));
        }
        r.key("enter".parse().unwrap());
    }
    r.advance_to(3_000_000);
    let text =
        std::fs::read_to_string(&out).unwrap_or_else(|e| panic!("{e}: {:?}", r.app.ui.message));
    let v: Value = serde_json::from_str(&text).unwrap();
    // MAV_AUTOPILOT_GENERIC (0), not ArduPilot (3).
    assert_eq!(v["mission"]["firmwareType"], 0, "{text}");
}
