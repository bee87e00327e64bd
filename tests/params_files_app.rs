//! `param save`, `param load` and `param diff` at the prompt against the simulated ArduCopter
//! (virtual clock): files written atomically in both formats, a file with bad lines reported by
//! line, its valid changes applied only after the confirmation, and nothing sent without it.

mod common;

use std::collections::BTreeMap;

use mavterm::app::AppConfig;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::LinkSpec;
use mavterm::proto::vehicles::VehicleKey;
use mavterm::sim::Sim;

const SECOND: u64 = 1_000_000;

fn downloaded() -> VirtualRunner {
    let spec: LinkSpec = "sim://".parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    for i in 1..120 {
        r.advance_to(i * SECOND / 2);
        if r.app.sessions[&VehicleKey(1, 1)]
            .params
            .autopilot()
            .is_some_and(|p| p.complete())
        {
            // As ArduCopter's, the sim's calibrations save new values in its first seconds
            // (announced by PARAM_VALUE): let them settle so the files compare with the sim.
            let settled = r.now().max(6 * SECOND);
            r.advance_to(settled);
            return r;
        }
    }
    panic!("no download");
}

fn run(r: &mut VirtualRunner, line: &str) {
    common::keys(r, &[":"]);
    common::typed(r, line);
    common::keys(r, &["enter"]);
    let t = r.now() + SECOND / 2;
    r.advance_to(t);
}

fn sim_param(r: &VirtualRunner, name: &str) -> f64 {
    let sim = r.source(0).unwrap().as_any().downcast_ref::<Sim>().unwrap();
    sim.vehicle(1).unwrap().param(name).unwrap()
}

#[test]
fn save_writes_both_formats_with_every_parameter() {
    let mut r = downloaded();
    let dir = tempfile::tempdir().unwrap();
    let parm = dir.path().join("a.parm");
    let qgc = dir.path().join("a.params");
    run(&mut r, &format!("param save {}", parm.display()));
    run(&mut r, &format!("param save {}", qgc.display()));
    // .parm: NAME VALUE, the sim's values (read from the sim, not from us).
    let text = std::fs::read_to_string(&parm).unwrap();
    let got: BTreeMap<&str, f64> = text
        .lines()
        .map(|l| {
            let mut w = l.split_whitespace();
            (w.next().unwrap(), w.next().unwrap().parse().unwrap())
        })
        .collect();
    assert_eq!(got.len(), 1354);
    for name in ["FLTMODE1", "RTL_ALT", "ATC_RAT_RLL_P", "INS_GYROFFS_X"] {
        assert_eq!(got[name] as f32, sim_param(&r, name) as f32, "{name}");
    }
    // .params: QGroundControl's tab-separated lines, sysid 1, component 1, type code.
    let text = std::fs::read_to_string(&qgc).unwrap();
    let data: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(data.len(), 1354);
    let fltmode = data.iter().find(|l| l.contains("\tFLTMODE1\t")).unwrap();
    assert_eq!(*fltmode, "1\t1\tFLTMODE1\t7\t2"); // INT8
                                                  // Atomic: no temp file left behind.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    assert!(r.app.notices.iter().any(|n| n.text.starts_with("saved ")));
}

#[test]
fn load_reports_bad_lines_and_applies_the_valid_changes_only_after_yes() {
    let mut r = downloaded();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("tune.parm");
    // Line 2 is bad (not a number), line 4 too (no value); RTL_ALT is unchanged.
    std::fs::write(
        &path,
        "FLTMODE1 5\nANGLE_MAX fast\nRTL_ALT 1500\nWPNAV_SPEED\nPILOT_TKOFF_ALT 250\n",
    )
    .unwrap();
    let before = sim_param(&r, "FLTMODE1");
    run(&mut r, &format!("param load {}", path.display()));
    let c = r.app.ui.confirm.as_ref().expect("a confirmation");
    assert!(c.text.contains("2 bad lines (line 2:"), "{}", c.text);
    assert!(c.text.contains("Apply 2 changes"), "{}", c.text);
    assert!(c.text.contains("FLTMODE1 7 → 5"), "{}", c.text);
    let warned: Vec<&str> = r
        .app
        .notices
        .iter()
        .map(|n| n.text.as_str())
        .filter(|t| t.contains("tune.parm: line"))
        .collect();
    assert_eq!(warned.len(), 2, "{warned:?}");
    assert!(warned[0].contains("line 2:") && warned[1].contains("line 4:"));
    // Nothing sent yet.
    assert_eq!(sim_param(&r, "FLTMODE1"), before);
    common::yes(&mut r);
    let t = r.now() + 2 * SECOND;
    r.advance_to(t);
    assert_eq!(sim_param(&r, "FLTMODE1"), 5.0);
    assert_eq!(sim_param(&r, "PILOT_TKOFF_ALT"), 250.0);
    let set = r.app.param_set().unwrap();
    for n in ["FLTMODE1", "PILOT_TKOFF_ALT"] {
        assert_eq!(
            set.get(n).unwrap().edit.as_ref().unwrap().state,
            mavterm::proto::params::EditState::Confirmed,
            "{n}"
        );
    }
}

#[test]
fn load_answered_no_sends_nothing() {
    let mut r = downloaded();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("q.params");
    std::fs::write(&path, "# QGC\n1\t1\tFLTMODE1\t3\t2\n").unwrap();
    run(&mut r, &format!("param load {}", path.display()));
    assert!(r.app.ui.confirm.is_some());
    common::keys(&mut r, &["n"]);
    let t = r.now() + 2 * SECOND;
    r.advance_to(t);
    assert_eq!(sim_param(&r, "FLTMODE1"), 7.0);
    assert!(r
        .app
        .param_set()
        .unwrap()
        .get("FLTMODE1")
        .unwrap()
        .edit
        .is_none());
}

#[test]
fn diff_counts_changed_only_on_vehicle_and_only_in_file() {
    let mut r = downloaded();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("d.parm");
    std::fs::write(&path, "FLTMODE1 5\nRTL_ALT 1500\nNOT_A_PARAM 1\n").unwrap();
    run(&mut r, &format!("param diff {}", path.display()));
    let f = r.app.param_file.as_ref().unwrap();
    assert_eq!(f.diff.changed.len(), 1);
    assert_eq!(f.diff.changed[0].name, "FLTMODE1");
    assert_eq!(f.diff.only_file, vec!["NOT_A_PARAM".to_string()]);
    assert_eq!(f.diff.only_vehicle.len(), 1354 - 2);
    assert!(r.app.ui.confirm.is_none());
}

#[test]
fn a_missing_file_is_an_error_not_a_crash() {
    let mut r = downloaded();
    run(&mut r, "param load /nonexistent/dir/x.parm");
    assert!(r
        .app
        .notices
        .iter()
        .any(|n| n.text.starts_with("could not read /nonexistent/dir/x.parm")));
}

#[test]
fn param_comp_switches_the_component_and_fetch_asks_it_by_the_list() {
    use mavterm::app::{App, Effect, Event};
    use mavterm::dialect::MavMessage;
    use mavterm::keymap::Key;
    let mut a = App::new(AppConfig {
        links: vec!["test".into()],
        request_streams: false,
        fetch_params: false,
        ..AppConfig::default()
    });
    let frames =
        mavterm::wire::parser::FrameParser::new().parse_all(&common::copter_heartbeat(1, 0, 0));
    a.update(
        0,
        Event::Frames {
            link: 0,
            frames,
            stats: Default::default(),
        },
    );
    let run = |a: &mut App, line: &str| {
        let mut fx = a.update(1, Event::Key(Key::ch(':')));
        for c in line.chars() {
            fx.extend(a.update(1, Event::Key(Key::ch(c))));
        }
        fx.extend(a.update(1, Event::Key("enter".parse().unwrap())));
        fx
    };
    let mut fx: Vec<Effect> = Vec::new();
    fx.extend(run(&mut a, "param comp 154"));
    // Not heard yet: nothing is asked of it.
    let refused = run(&mut a, "param fetch");
    assert!(!refused.iter().any(|e| matches!(
        e,
        Effect::Send {
            msg: MavMessage::PARAM_REQUEST_LIST(_),
            ..
        }
    )));
    let msg = a.ui.message.clone().unwrap().1;
    assert!(msg.contains("1:154 has not been heard"), "{msg}");
    // Its heartbeat (a camera), then the fetch goes.
    let hb = common::pymavlink_encode(&[serde_json::json!({"sysid": 1, "compid": 154,
        "seq": 0, "msg": "HEARTBEAT", "fields": {"type": 30, "autopilot": 8, "base_mode": 0,
        "custom_mode": 0, "system_status": 4, "mavlink_version": 3}})]);
    let frames = mavterm::wire::parser::FrameParser::new().parse_all(&hb[0]);
    a.update(
        1,
        Event::Frames {
            link: 0,
            frames,
            stats: Default::default(),
        },
    );
    fx.extend(run(&mut a, "param fetch"));
    let lists: Vec<(u8, u8)> = fx
        .iter()
        .filter_map(|e| match e {
            Effect::Send {
                msg: MavMessage::PARAM_REQUEST_LIST(m),
                ..
            } => Some((m.target_system, m.target_component)),
            _ => None,
        })
        .collect();
    // A camera (154) serves no param.pck: the parameter protocol, to it.
    assert_eq!(lists, vec![(1, 154)]);
    assert!(!fx.iter().any(|e| matches!(
        e,
        Effect::Send {
            msg: MavMessage::FILE_TRANSFER_PROTOCOL(_),
            ..
        }
    )));
    assert_eq!(a.ui.params.comp, Some(154));
}

#[test]
fn load_leaves_out_values_the_c_cast_float_cannot_carry_before_asking() {
    // ArduCopter takes INT32 values C-cast into the float: 2^24 + 1 would arrive as 2^24.
    let mut r = downloaded();
    let before = sim_param(&r, "COMPASS_DEV_ID");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.parm");
    std::fs::write(&path, "COMPASS_DEV_ID 16777217\nFLTMODE1 5\n").unwrap();
    run(&mut r, &format!("param load {}", path.display()));
    let c = r.app.ui.confirm.as_ref().expect("a confirmation");
    assert!(c.text.contains("FLTMODE1 7 → 5"), "{}", c.text);
    assert!(!c.text.contains("COMPASS_DEV_ID"), "{}", c.text);
    let told: Vec<&str> = r
        .app
        .notices
        .iter()
        .map(|n| n.text.as_str())
        .filter(|t| t.contains("COMPASS_DEV_ID") && t.contains("not sent"))
        .collect();
    assert_eq!(told.len(), 1, "{told:?}");
    assert!(told[0].contains("16777217"), "{told:?}");
    common::yes(&mut r);
    let t = r.now() + 2 * SECOND;
    r.advance_to(t);
    assert_eq!(sim_param(&r, "FLTMODE1"), 5.0);
    assert_eq!(sim_param(&r, "COMPASS_DEV_ID"), before, "never sent");
    assert!(r
        .app
        .param_set()
        .unwrap()
        .get("COMPASS_DEV_ID")
        .unwrap()
        .edit
        .is_none());
}
