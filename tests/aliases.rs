//! MAVProxy's spellings at the prompt: each sends exactly what mavterm's own command (or key)
//! sends, read back off the wire on the simulated ArduCopter (virtual time), and asks first
//! where that one asks. Expected values are MAVLink's: COMPONENT_ARM_DISARM is MAV_CMD 400
//! (param1 1 arm, 0 disarm), DO_SET_MODE 176 (param1 MAV_MODE_FLAG_CUSTOM_MODE_ENABLED = 1,
//! param2 the custom mode; ArduCopter's GUIDED is 4), NAV_RETURN_TO_LAUNCH 20, NAV_LAND 21,
//! NAV_TAKEOFF 22 (param7 the altitude), MISSION_REQUEST_LIST id 43.

mod common;

use common::{command, keys, wait, yes};

use mavterm::app::AppConfig;
use mavterm::dialect::MavMessage;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::{FrameParser, LinkSpec};

/// The simulated copter after its GPS fix, every frame sent from now on kept.
fn runner() -> VirtualRunner {
    let spec: LinkSpec = "sim://".parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    r.advance_to(6_000_000);
    r.capture_sent();
    r
}

/// What the operator sent since the last call: commands (the automatic requests for messages,
/// streams and capabilities left out), SET_MODE, PARAM_SET, MISSION_REQUEST_LIST.
#[allow(deprecated)] // SET_MODE: kept, so that one sent instead of DO_SET_MODE shows
fn sent(r: &mut VirtualRunner) -> Vec<MavMessage> {
    let mut out = Vec::new();
    for (_, _, bytes) in r.take_sent() {
        for f in FrameParser::new().parse_all(&bytes) {
            let Some(m) = f.message else { continue };
            let keep = match &*m {
                MavMessage::COMMAND_LONG(c) => {
                    !matches!(c.command as u16, 511 | 512 | 520 | 2504 | 2505 | 1000)
                }
                MavMessage::COMMAND_INT(_)
                | MavMessage::SET_MODE(_)
                | MavMessage::PARAM_SET(_)
                | MavMessage::MISSION_REQUEST_LIST(_) => true,
                _ => false,
            };
            if keep {
                out.push(*m);
            }
        }
    }
    out
}

/// A fresh vehicle; `act` runs on it; what went out in the next 3 s.
fn after(act: impl FnOnce(&mut VirtualRunner)) -> (VirtualRunner, Vec<MavMessage>) {
    let mut r = runner();
    act(&mut r);
    wait(&mut r, 3.0);
    let out = sent(&mut r);
    (r, out)
}

/// COMMAND_LONGs of `command`: (param1..param7, target system, target component).
fn longs(out: &[MavMessage], command: u16) -> Vec<([f32; 7], u8, u8)> {
    out.iter()
        .filter_map(|m| match m {
            MavMessage::COMMAND_LONG(c) if c.command as u16 == command => Some((
                [
                    c.param1, c.param2, c.param3, c.param4, c.param5, c.param6, c.param7,
                ],
                c.target_system,
                c.target_component,
            )),
            _ => None,
        })
        .collect()
}

fn custom_mode(r: &VirtualRunner) -> u32 {
    let v = r
        .app
        .vehicles
        .iter()
        .find(|v| (v.sysid, v.compid) == (1, 1));
    v.unwrap().custom_mode
}

#[test]
fn arm_throttle_asks_then_sends_what_arm_and_a_send() {
    // Asked first: nothing leaves before the `y`.
    let (_, out) = after(|r| command(r, "arm throttle"));
    assert!(longs(&out, 400).is_empty(), "{out:?}");

    let (r, alias) = after(|r| {
        command(r, "arm throttle");
        assert!(r.app.ui.confirm.is_some(), "asks first");
        yes(r);
    });
    assert_eq!(
        longs(&alias, 400),
        [([1.0, 0., 0., 0., 0., 0., 0.], 1, 1)],
        "{alias:?}"
    );
    assert!(common::sim(&r).vehicle(1).unwrap().armed());
    let (_, arm) = after(|r| {
        command(r, "arm");
        yes(r);
    });
    let (_, key) = after(|r| {
        keys(r, &["A"]);
        yes(r);
    });
    assert_eq!(alias, arm);
    assert_eq!(alias, key);
    let (r, _) = after(|r| command(r, "arm now"));
    let (_, e) = r.app.ui.message.clone().unwrap();
    assert_eq!(e, "usage: arm, or arm throttle");
}

/// Answer the question, if one is asked.
fn answer(r: &mut VirtualRunner) {
    if r.app.ui.confirm.is_some() {
        yes(r);
    }
}

#[test]
fn disarm_sends_what_d_sends() {
    let arm = |r: &mut VirtualRunner| {
        command(r, "arm throttle");
        yes(r);
        wait(r, 2.0);
        sent(r);
    };
    let (r, alias) = after(|r| {
        arm(r);
        command(r, "disarm");
        answer(r);
    });
    let (_, key) = after(|r| {
        arm(r);
        keys(r, &["D"]);
        answer(r);
    });
    let disarms = longs(&alias, 400);
    assert_eq!(disarms.len(), 1, "{alias:?}");
    assert_eq!(disarms[0].0[0], 0.0);
    assert_eq!((disarms[0].1, disarms[0].2), (1, 1));
    assert!(!common::sim(&r).vehicle(1).unwrap().armed());
    assert_eq!(alias, key);
}

#[test]
fn mode_4_on_arducopter_is_mode_guided() {
    let (r, number) = after(|r| command(r, "mode 4"));
    let set = longs(&number, 176);
    assert_eq!(set.len(), 1, "{number:?}");
    assert_eq!((set[0].0[0], set[0].0[1]), (1.0, 4.0));
    assert_eq!((set[0].1, set[0].2), (1, 1));
    assert_eq!(custom_mode(&r), 4, "the vehicle is in GUIDED");
    let (_, name) = after(|r| command(r, "mode guided"));
    assert_eq!(number, name);

    // A number not in ArduCopter's table (8 is unused): refused, nothing sent.
    let (r, out) = after(|r| command(r, "mode 8"));
    assert!(out.is_empty(), "{out:?}");
    let (_, e) = r.app.ui.message.clone().unwrap();
    assert!(e.starts_with("no mode number 8 on this vehicle"), "{e}");
}

#[test]
fn wp_list_downloads_the_mission_as_wp_download() {
    let (_, alias) = after(|r| command(r, "wp list"));
    let lists: Vec<_> = alias
        .iter()
        .filter_map(|m| match m {
            MavMessage::MISSION_REQUEST_LIST(l) => Some(l.clone()),
            _ => None,
        })
        .collect();
    assert!(!lists.is_empty(), "{alias:?}");
    assert_eq!((lists[0].target_system, lists[0].target_component), (1, 1));
    assert_eq!(lists[0].mission_type as u8, 0, "MAV_MISSION_TYPE_MISSION");
    let (_, own) = after(|r| command(r, "wp download"));
    assert_eq!(alias, own);
}

#[test]
fn rtl_land_and_takeoff_send_their_commands() {
    let (_, rtl) = after(|r| command(r, "rtl"));
    assert_eq!(longs(&rtl, 20), [([0.0; 7], 1, 1)], "{rtl:?}");
    let (_, land) = after(|r| command(r, "land"));
    let l = longs(&land, 21);
    assert_eq!(l.len(), 1, "{land:?}");
    assert_eq!((l[0].1, l[0].2), (1, 1));
    let (_, up) = after(|r| {
        command(r, "takeoff 15");
        answer(r);
        wait(r, 5.0);
    });
    let t = longs(&up, 22);
    assert_eq!(t.len(), 1, "{up:?}");
    assert_eq!(t[0].0[6], 15.0, "param7: metres above home (ArduPilot)");
}

/// Run until the parameters are in.
fn with_params() -> VirtualRunner {
    let mut r = runner();
    for _ in 0..120 {
        wait(&mut r, 0.5);
        if r.app.param_set().is_some_and(|s| s.complete()) {
            sent(&mut r);
            return r;
        }
    }
    panic!("the parameter download did not finish");
}

fn sim_param(r: &VirtualRunner, name: &str) -> f64 {
    common::sim(r).vehicle(1).unwrap().param(name).unwrap()
}

/// A value as PARAM_VALUE carries it: a float.
fn shown(v: f64) -> String {
    format!("{}", v as f32)
}

#[test]
fn param_show_and_param_set() {
    let mut r = with_params();
    let rtl_alt = sim_param(&r, "RTL_ALT");
    command(&mut r, "param show rtl_alt");
    let (_, m) = r.app.ui.message.clone().unwrap();
    assert_eq!(m, format!("RTL_ALT = {}", shown(rtl_alt)));
    assert!(r.app.notices.iter().any(|n| n.text == m));

    // A pattern: every match in the message log.
    command(&mut r, "param show ACRO_*");
    let acro: Vec<String> = r
        .app
        .param_set()
        .unwrap()
        .params
        .keys()
        .filter(|n| n.starts_with("ACRO_"))
        .map(|n| n.to_string())
        .collect();
    assert!(acro.len() >= 2, "{acro:?}");
    for n in &acro {
        let want = format!("{n} = {}", shown(sim_param(&r, n)));
        assert!(r.app.notices.iter().any(|x| x.text == want), "{want}");
    }
    command(&mut r, "param show NO_SUCH_*");
    let (_, e) = r.app.ui.message.clone().unwrap();
    assert_eq!(e, "no parameter matches `NO_SUCH_*`");
    assert!(sent(&mut r).is_empty(), "param show sends nothing");

    command(&mut r, "param set RTL_ALT 2000");
    wait(&mut r, 2.0);
    let out = sent(&mut r);
    let sets: Vec<_> = out
        .iter()
        .filter_map(|m| match m {
            MavMessage::PARAM_SET(p) => Some(p.clone()),
            _ => None,
        })
        .collect();
    assert_eq!(sets.len(), 1, "{out:?}");
    let id: String = sets[0]
        .param_id
        .iter()
        .take_while(|c| **c != 0)
        .map(|c| *c as char)
        .collect();
    assert_eq!(id, "RTL_ALT");
    assert_eq!(sets[0].param_value, 2000.0);
    assert_eq!((sets[0].target_system, sets[0].target_component), (1, 1));
    assert_eq!(sim_param(&r, "RTL_ALT"), 2000.0);
}

#[test]
fn tab_completes_the_aliases_and_parameter_names() {
    let mut r = with_params();
    let line = |r: &VirtualRunner| r.app.ui.prompt.line.text.clone();
    keys(&mut r, &[":"]);
    common::typed(&mut r, "arm t");
    keys(&mut r, &["tab"]);
    assert_eq!(line(&r), "arm throttle ");
    keys(&mut r, &["ctrl-u"]);
    common::typed(&mut r, "param sh");
    keys(&mut r, &["tab"]);
    assert_eq!(line(&r), "param show ");
    common::typed(&mut r, "RTL_AL");
    keys(&mut r, &["tab"]);
    // RTL_ALT, RTL_ALT_FINAL, …: their common prefix.
    assert_eq!(line(&r), "param show RTL_ALT");
    common::typed(&mut r, "_FI");
    keys(&mut r, &["tab"]);
    assert_eq!(line(&r), "param show RTL_ALT_FINAL ");
    keys(&mut r, &["ctrl-u"]);
    common::typed(&mut r, "param meta");
    keys(&mut r, &["tab"]);
    assert_eq!(line(&r), "param meta fetch ");
    keys(&mut r, &["ctrl-u"]);
    common::typed(&mut r, "wp l");
    keys(&mut r, &["tab"]);
    assert_eq!(line(&r), "wp l", "load and list");
    keys(&mut r, &["esc"]);
}
