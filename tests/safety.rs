//! Operator safety, read on the wire: keys go into the core (headless, virtual time) and the
//! frames that leave (or do not) are read back by pymavlink. Confirmations that a repeated or
//! typed-ahead key cannot give, questions that expire, one question at a time, a safe mode that
//! never waits, a DO_SET_MODE resend that a pilot's mode change cancels.

mod common;

use common::{command, sim, wait};

use mavterm::app::{App, AppConfig, Event};
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::keymap::Key;
use mavterm::link::{FrameParser, LinkSpec, ParserStats};
use mavterm::proto::vehicles::VehicleKey;
use serde_json::{json, Value};

const SECOND: u64 = 1_000_000;

/// Message ids of what an operator sends: COMMAND_INT, COMMAND_LONG, SET_MODE, PARAM_SET,
/// SET_POSITION_TARGET_LOCAL_NED.
const OPERATOR_IDS: [u32; 5] = [75, 76, 11, 23, 84];

/// The operator's frames among `frames`, as pymavlink reads them (automatic requests left out).
fn operator_frames(frames: &[Vec<u8>]) -> Vec<Value> {
    common::operator_messages(frames, &OPERATOR_IDS)
}

/// What the runner sent since the last call, read by pymavlink.
fn sent(r: &mut VirtualRunner) -> Vec<Value> {
    let frames: Vec<Vec<u8>> = r.take_sent().into_iter().map(|(_, _, f)| f).collect();
    operator_frames(&frames)
}

fn commands(v: &[Value], command: u64) -> Vec<Value> {
    v.iter()
        .filter(|m| {
            (m["name"] == "COMMAND_LONG" || m["name"] == "COMMAND_INT") && m["command"] == command
        })
        .cloned()
        .collect()
}

/// sim:// after its GPS fix (arming allowed), every frame sent from now on kept.
fn runner(query: &str) -> VirtualRunner {
    let spec: LinkSpec = format!("sim://?{query}").parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    r.advance_to(6 * SECOND);
    r.capture_sent();
    r
}

fn key(r: &mut VirtualRunner, name: &str) {
    r.key(name.parse().unwrap());
}

#[test]
fn key_repeat_double_press_and_typed_ahead_keys_do_not_arm() {
    let mut r = runner("");
    // `A` held: the terminal repeats it every 33 ms after half a second.
    key(&mut r, "A");
    assert!(r.app.ui.confirm.is_some());
    wait(&mut r, 0.5);
    for _ in 0..60 {
        key(&mut r, "A");
        wait(&mut r, 0.033);
    }
    // A double press, and `A` then `y` typed ahead in one burst.
    key(&mut r, "n");
    key(&mut r, "A");
    key(&mut r, "A");
    key(&mut r, "n");
    key(&mut r, "A");
    key(&mut r, "y");
    // A `y` held from before the question: its repeats never answer.
    for _ in 0..30 {
        wait(&mut r, 0.033);
        key(&mut r, "y");
    }
    // A terminal that reports repeats: a repeated `y` never answers, however late.
    wait(&mut r, 0.5);
    r.event(Event::KeyRepeat(Key::ch('y')));
    assert!(r.app.ui.confirm.is_some(), "still asking");
    key(&mut r, "n");
    wait(&mut r, 3.0);
    assert!(!sim(&r).vehicle(1).unwrap().armed());
    let out = sent(&mut r);
    assert!(commands(&out, 400).is_empty(), "{out:?}");
    // A `y` pressed on its own after reading the question arms, once.
    key(&mut r, "A");
    common::yes(&mut r);
    wait(&mut r, 2.0);
    let out = sent(&mut r);
    let arm = commands(&out, 400);
    assert_eq!(arm.len(), 1, "{out:?}");
    assert_eq!(arm[0]["param1"], 1.0);
    armed_at_1_1(&r, &arm);
}

/// The one ARM in `arm` went to 1:1, and the simulated vehicle is armed.
fn armed_at_1_1(r: &VirtualRunner, arm: &[Value]) {
    assert_eq!(
        (
            arm[0]["target_system"].as_u64(),
            arm[0]["target_component"].as_u64()
        ),
        (Some(1), Some(1))
    );
    assert!(sim(r).vehicle(1).unwrap().armed());
}

#[test]
fn d_d_never_disarms_in_flight() {
    let mut r = runner("");
    command(&mut r, "takeoff 10");
    common::yes(&mut r);
    wait(&mut r, 15.0);
    assert!(sim(&r).vehicle(1).unwrap().relative_alt_m() > 9.0);
    sent(&mut r);
    key(&mut r, "D");
    let q = r.app.ui.confirm.clone().expect("asked").text;
    assert!(
        q.contains("DISARM while flying") && q.contains("1:1"),
        "{q}"
    );
    key(&mut r, "D");
    wait(&mut r, 0.5);
    key(&mut r, "D"); // late, but not `y`: no
    wait(&mut r, 2.0);
    assert!(r.app.ui.confirm.is_none());
    let out = sent(&mut r);
    assert!(commands(&out, 400).is_empty(), "{out:?}");
    assert!(sim(&r).vehicle(1).unwrap().armed());
}

#[test]
fn a_stale_landed_state_is_not_trusted() {
    let hb = |seq: u64| {
        json!({"sysid": 1, "compid": 1, "seq": seq, "msg": "HEARTBEAT",
        "fields": {"type": 2, "autopilot": 3, "base_mode": 129, "custom_mode": 4,
        "system_status": 4, "mavlink_version": 3}})
    };
    let on_ground = |seq: u64| {
        json!({"sysid": 1, "compid": 1, "seq": seq, "msg": "EXTENDED_SYS_STATE",
        "fields": {"vtol_state": 0, "landed_state": 1}})
    };
    let at = |seq: u64, relative_alt: i64| {
        json!({"sysid": 1, "compid": 1, "seq": seq, "msg": "GLOBAL_POSITION_INT",
        "fields": {"time_boot_ms": 1000, "lat": -353632621, "lon": 1491652374,
        "alt": 584000 + relative_alt, "relative_alt": relative_alt,
        "vx": 0, "vy": 0, "vz": 0, "hdg": 0}})
    };
    // Fresh ON_GROUND, armed: `D` disarms without a question.
    let mut b = bench_in(4, true);
    b.raw(0.1, &[on_ground(20)]);
    let out = operator_frames(&b.keys(0.5, &["D"]));
    assert!(b.app.ui.confirm.is_none());
    assert_eq!(commands(&out, 400).len(), 1, "{out:?}");
    // ON_GROUND heard 8 s ago, then only the heartbeat and a position 50 m up: it asks.
    b.raw(8.0, &[hb(21), at(22, 50_000)]);
    let out = b.keys(8.1, &["D"]);
    asked_nothing_sent(&mut b, 8.1, out, 400, "stale ON_GROUND, 50 m up");
    // Only the heartbeat for 8 s (state and height both stale): unknown, so flying: it asks.
    b.raw(16.0, &[hb(23)]);
    let out = b.keys(16.1, &["D"]);
    asked_nothing_sent(&mut b, 16.1, out, 400, "nothing fresh");
    // A fresh position on the ground: the height rule lets it go.
    b.raw(17.0, &[hb(24), at(25, 0)]);
    let out = operator_frames(&b.keys(17.1, &["D"]));
    assert!(b.app.ui.confirm.is_none());
    assert_eq!(commands(&out, 400).len(), 1, "{out:?}");
}

/// A core on one link ("x") fed frames pymavlink encoded.
struct Bench {
    app: App,
    frames: Vec<Vec<u8>>,
    next: usize,
}

impl Bench {
    /// HEARTBEATs of ArduCopter `sysid`:1 in `modes` (custom_mode, armed), in order, with a
    /// GLOBAL_POSITION_INT after each.
    fn new(vehicles: &[(u8, &[(u32, bool)])]) -> (Bench, Vec<Vec<usize>>) {
        let mut reqs = Vec::new();
        let mut index = Vec::new();
        for (sysid, modes) in vehicles {
            let mut mine = Vec::new();
            for (i, (mode, armed)) in modes.iter().enumerate() {
                let base = if *armed { 129 } else { 1 };
                mine.push(reqs.len());
                reqs.push(
                    json!({"sysid": sysid, "compid": 1, "seq": 2 * i, "msg": "HEARTBEAT",
                    "fields": {"type": 2, "autopilot": 3, "base_mode": base, "custom_mode": mode,
                    "system_status": 4, "mavlink_version": 3}}),
                );
                reqs.push(json!({"sysid": sysid, "compid": 1, "seq": 2 * i + 1,
                    "msg": "GLOBAL_POSITION_INT", "fields": {"time_boot_ms": 1000 + i,
                    "lat": -353632621, "lon": 1491652374, "alt": 584000, "relative_alt": 0,
                    "vx": 0, "vy": 0, "vz": 0, "hdg": 0}}));
            }
            index.push(mine);
        }
        let app = App::new(AppConfig {
            links: vec!["x".into()],
            request_streams: false,
            fetch_params: false,
            ..AppConfig::default()
        });
        let frames = common::pymavlink_encode(&reqs);
        (
            Bench {
                app,
                frames,
                next: 0,
            },
            index,
        )
    }

    /// Feed request `i` (and the position after it) at `t` seconds: what left.
    fn feed(&mut self, t: f64, i: usize) -> Vec<Vec<u8>> {
        self.next = i;
        let mut out = Vec::new();
        for f in [&self.frames[i], &self.frames[i + 1]] {
            let fx = self.app.update(
                (t * 1e6) as u64,
                Event::Frames {
                    link: 0,
                    frames: FrameParser::new().parse_all(f),
                    stats: ParserStats::default(),
                },
            );
            out.extend(sends(&fx));
        }
        out
    }

    fn keys(&mut self, t: f64, names: &[&str]) -> Vec<Vec<u8>> {
        let mut out = Vec::new();
        for n in names {
            let k: Key = n.parse().unwrap();
            out.extend(sends(&self.app.update((t * 1e6) as u64, Event::Key(k))));
        }
        out
    }

    fn command(&mut self, t: f64, line: &str) -> Vec<Vec<u8>> {
        let mut out = self.keys(t, &[":"]);
        for c in line.chars() {
            out.extend(sends(
                &self.app.update((t * 1e6) as u64, Event::Key(Key::ch(c))),
            ));
        }
        out.extend(self.keys(t, &["enter"]));
        out
    }

    /// Time passing to `to` seconds, woken at each deadline: what left.
    fn tick_to(&mut self, to: f64) -> Vec<Vec<u8>> {
        let to = (to * 1e6) as u64;
        let mut out = Vec::new();
        loop {
            let d = self.app.next_deadline().max(self.app.now + 1);
            if d > to {
                break;
            }
            out.extend(sends(&self.app.update(d, Event::Tick)));
        }
        out.extend(sends(&self.app.update(to, Event::Tick)));
        out
    }
}

use common::sent_frames as sends;

#[test]
fn a_question_expires_after_10_s() {
    let mut r = runner("");
    key(&mut r, "A");
    wait(&mut r, 10.5);
    assert!(r.app.ui.confirm.is_none());
    let s = common::screen(&r, 80, 24);
    assert!(s.contains("question expired"), "{s}");
    key(&mut r, "y");
    wait(&mut r, 2.0);
    let out = sent(&mut r);
    assert!(commands(&out, 400).is_empty(), "{out:?}");
    assert!(!sim(&r).vehicle(1).unwrap().armed());
}

#[test]
fn a_question_expires_when_its_vehicle_is_lost() {
    let (mut b, ix) = Bench::new(&[(1, &[(0, false)])]);
    b.feed(0.0, ix[0][0]);
    b.keys(1.0, &["A"]);
    assert!(b.app.ui.confirm.is_some());
    // No heartbeat for 5 s: lost.
    let mut out = b.tick_to(6.0);
    assert!(b.app.ui.confirm.is_none(), "expired on the loss");
    assert!(b
        .app
        .notices
        .iter()
        .any(|n| n.text.contains("question expired") && n.text.contains("lost")));
    out.extend(b.keys(7.0, &["y"]));
    assert!(operator_frames(&out).is_empty());
}

#[test]
fn a_question_expires_when_the_target_or_the_vehicles_state_changes() {
    // Mode: asked in STABILIZE, the heartbeat then shows RTL (a failsafe).
    let (mut b, ix) = Bench::new(&[(1, &[(0, false), (6, false)])]);
    b.feed(0.0, ix[0][0]);
    b.keys(1.0, &["A"]);
    let mut out = b.feed(1.2, ix[0][1]);
    assert!(b.app.ui.confirm.is_none(), "expired on the mode change");
    out.extend(b.keys(1.5, &["y"]));
    assert!(operator_frames(&out).is_empty());

    // Target: asked for 1:1, the target is then 2:1 (however it changed).
    let (mut b, ix) = Bench::new(&[(1, &[(0, false)]), (2, &[(0, false)])]);
    b.feed(0.0, ix[0][0]);
    b.feed(0.0, ix[1][0]);
    assert_eq!(b.app.target, Some(VehicleKey(1, 1)));
    b.keys(1.0, &["A"]);
    b.app.target = Some(VehicleKey(2, 1));
    let mut out = b.tick_to(1.2);
    assert!(b.app.ui.confirm.is_none(), "expired on the retarget");
    out.extend(b.keys(1.5, &["y"]));
    assert!(
        operator_frames(&out).is_empty(),
        "nothing to either vehicle"
    );

    // Armed: a disarm asked in flight (no EXTENDED_SYS_STATE, 0 m: not flying, so force).
    let (mut b, ix) = Bench::new(&[(1, &[(4, true), (4, false)])]);
    b.feed(0.0, ix[0][0]);
    b.command(1.0, "disarm force");
    assert!(b.app.ui.confirm.is_some());
    let mut out = b.feed(1.2, ix[0][1]);
    assert!(b.app.ui.confirm.is_none(), "expired: disarmed meanwhile");
    out.extend(b.keys(1.6, &["y"]));
    assert!(operator_frames(&out).is_empty());
}

#[test]
fn a_queued_file_load_does_not_steal_a_y() {
    let mut r = runner("");
    for i in 0..60 {
        if r.app.sessions[&VehicleKey(1, 1)]
            .params
            .autopilot()
            .is_some_and(|p| p.complete())
        {
            break;
        }
        assert!(i < 59, "no parameter download");
        wait(&mut r, 0.5);
    }
    sent(&mut r);
    key(&mut r, "A");
    // A parameter file finishes loading while the arm question is open.
    r.event(Event::FileRead {
        path: "tune.parm".into(),
        purpose: mavterm::app::params::FileUse::Load,
        result: Ok(b"FLTMODE1 5\n".to_vec()),
    });
    let s = common::screen(&r, 80, 24);
    assert!(
        s.contains("ARM 1:1"),
        "the arm question stays on screen: {s}"
    );
    common::yes(&mut r);
    // Then the file's question, asked afresh (a `y` now is too soon to answer it).
    let q = r.app.ui.confirm.clone().expect("the file's turn").text;
    assert!(q.contains("FLTMODE1") && q.contains("1:1"), "{q}");
    key(&mut r, "y");
    wait(&mut r, 1.0);
    let out = sent(&mut r);
    assert_eq!(commands(&out, 400).len(), 1, "{out:?}");
    assert!(
        !out.iter().any(|m| m["name"] == "PARAM_SET"),
        "the y was the arm's: {out:?}"
    );
    // Asked while disarmed: the arm that followed ends it, or a no does.
    key(&mut r, "n");
    wait(&mut r, 2.0);
    let out = sent(&mut r);
    assert!(out.iter().all(|m| m["name"] != "PARAM_SET"), "{out:?}");
}

/// The DO_SET_MODEs among `out` asking for custom mode `mode` (ArduPilot: param2).
fn set_mode(out: &[Value], mode: f64) -> usize {
    commands(out, 176)
        .iter()
        .filter(|m| m["param2"] == mode)
        .count()
}

#[test]
fn mode_land_goes_out_at_once_behind_a_pending_mode_change() {
    // The first DO_SET_MODE is lost: LOITER waits for its resend.
    let mut r = runner("drop_cmd=176:1");
    command(&mut r, "mode loiter");
    assert_eq!(set_mode(&sent(&mut r), 5.0), 1);
    command(&mut r, "mode land");
    let out = sent(&mut r);
    assert_eq!(set_mode(&out, 9.0), 1, "LAND at once: {out:?}");
    wait(&mut r, 10.0);
    let out = sent(&mut r);
    assert_eq!(set_mode(&out, 5.0), 0, "LOITER is not resent: {out:?}");
    assert_eq!(sim(&r).vehicle(1).unwrap().custom_mode(), 9);
}

#[test]
fn mode_land_goes_out_at_once_during_a_takeoff_and_abandons_it() {
    // The arm of the take-off is lost: the sequence waits for its answer.
    let mut r = runner("drop_cmd=400:1");
    command(&mut r, "takeoff 10");
    common::yes(&mut r);
    // GUIDED first, then (once the heartbeat shows it) the arm, which gets no answer.
    let mut out = Vec::new();
    for _ in 0..100 {
        wait(&mut r, 0.05);
        out.extend(sent(&mut r));
        if !commands(&out, 400).is_empty() {
            break;
        }
    }
    assert_eq!(set_mode(&out, 4.0), 1, "GUIDED first: {out:?}");
    assert_eq!(commands(&out, 400).len(), 1, "then the arm: {out:?}");
    assert!(
        r.app.sessions[&VehicleKey(1, 1)].sequence.is_some(),
        "waiting for the arm"
    );
    command(&mut r, "mode land");
    let out = sent(&mut r);
    assert_eq!(set_mode(&out, 9.0), 1, "LAND at once: {out:?}");
    wait(&mut r, 15.0);
    let out = sent(&mut r);
    assert!(commands(&out, 22).is_empty(), "no take-off after: {out:?}");
    assert!(commands(&out, 400).is_empty(), "{out:?}");
    let texts: Vec<&str> = r.app.notices.iter().map(|n| n.text.as_str()).collect();
    assert!(
        texts.iter().any(|t| t.contains("abandoned for mode land")),
        "{texts:?}"
    );
}

#[test]
fn a_second_land_goes_out_at_once_behind_an_unanswered_first() {
    // The first NAV_LAND is lost: a second `L` is not refused for the first one's answer.
    let mut r = runner("drop_cmd=21:1");
    key(&mut r, "L");
    let out = sent(&mut r);
    assert_eq!(commands(&out, 21).len(), 1, "{out:?}");
    wait(&mut r, 0.2);
    key(&mut r, "L");
    let out = sent(&mut r);
    assert_eq!(
        commands(&out, 21).len(),
        1,
        "the second LAND at once: {out:?}"
    );
    // RTL behind it, and the first LAND is never resent on its own.
    key(&mut r, "R");
    let out = sent(&mut r);
    assert_eq!(commands(&out, 20).len(), 1, "RTL at once: {out:?}");
    wait(&mut r, 10.0);
    let out = sent(&mut r);
    assert!(commands(&out, 21).is_empty(), "no LAND resent: {out:?}");
}

/// Starts a take-off whose arm (dropped by the sim) gets no answer; returns once the arm left.
fn takeoff_waiting_for_the_arm(r: &mut VirtualRunner) {
    command(r, "takeoff 10");
    common::yes(r);
    let mut out = Vec::new();
    for _ in 0..100 {
        wait(r, 0.05);
        out.extend(sent(r));
        if !commands(&out, 400).is_empty() {
            break;
        }
    }
    assert_eq!(commands(&out, 400).len(), 1, "the arm: {out:?}");
    assert!(r.app.sessions[&VehicleKey(1, 1)].sequence.is_some());
}

#[test]
fn a_long_or_palette_land_during_a_takeoff_goes_out_and_abandons_it() {
    for (way, line) in [
        ("long", "long NAV_LAND"),
        ("long RTL", "long NAV_RETURN_TO_LAUNCH"),
        ("long DO_SET_MODE", "long DO_SET_MODE 1 9"),
    ] {
        let mut r = runner("drop_cmd=400:1");
        takeoff_waiting_for_the_arm(&mut r);
        command(&mut r, line);
        let out = sent(&mut r);
        let number = match way {
            "long" => 21,
            "long RTL" => 20,
            _ => 176,
        };
        assert_eq!(commands(&out, number).len(), 1, "{way} at once: {out:?}");
        assert!(
            r.app.sessions[&VehicleKey(1, 1)]
                .sequence
                .as_ref()
                .is_none_or(|s| s.finished()),
            "{way}: the take-off stopped"
        );
        wait(&mut r, 15.0);
        let out = sent(&mut r);
        assert!(commands(&out, 22).is_empty(), "{way}: no take-off: {out:?}");
        assert!(commands(&out, 400).is_empty(), "{way}: {out:?}");
    }
    // The palette's NAV_LAND, the same.
    let (mut b, ix) = Bench::new(&[(1, &[(0, false)])]);
    b.feed(0.0, ix[0][0]);
    b.command(0.5, "takeoff 10");
    b.keys(1.0, &["y"]);
    assert!(b.app.sessions[&VehicleKey(1, 1)].sequence.is_some());
    let out = operator_frames(&from_palette(&mut b, 1.2, 21, "NAV_LAND", [0.0, 0.0]));
    assert_eq!(commands(&out, 21).len(), 1, "palette: {out:?}");
    assert!(
        b.app.sessions[&VehicleKey(1, 1)]
            .sequence
            .as_ref()
            .is_none_or(|s| s.finished()),
        "palette: the take-off stopped"
    );
    let out = operator_frames(&b.tick_to(20.0));
    assert!(commands(&out, 22).is_empty(), "palette: {out:?}");
}

#[test]
fn a_mode_name_that_does_not_resolve_cancels_nothing() {
    let mut r = runner("drop_cmd=176:1");
    command(&mut r, "mode loiter");
    assert_eq!(set_mode(&sent(&mut r), 5.0), 1);
    command(&mut r, "mode lnad");
    assert!(sent(&mut r).is_empty());
    // The LOITER request still stands: resent since the first copy got no answer.
    wait(&mut r, 5.0);
    let out = sent(&mut r);
    assert!(set_mode(&out, 5.0) >= 1, "LOITER still pending: {out:?}");
    assert_eq!(sim(&r).vehicle(1).unwrap().custom_mode(), 5);
    // Nor does it abandon a take-off.
    let mut r = runner("drop_cmd=400:1");
    takeoff_waiting_for_the_arm(&mut r);
    command(&mut r, "mode lnad");
    assert!(r.app.sessions[&VehicleKey(1, 1)]
        .sequence
        .as_ref()
        .is_some_and(|s| !s.finished()));
    let texts: Vec<&str> = r.app.notices.iter().map(|n| n.text.as_str()).collect();
    assert!(!texts.iter().any(|t| t.contains("abandoned")), "{texts:?}");
}

#[test]
fn a_pilots_mode_change_stops_our_do_set_mode_resend() {
    // STABILIZE; we ask LOITER and hear no ACK; the heartbeat then shows RTL (a failsafe, the
    // pilot's switch, another GCS): our request is not sent again.
    let (mut b, ix) = Bench::new(&[(1, &[(0, false), (6, false)])]);
    b.feed(0.0, ix[0][0]);
    let out = operator_frames(&b.command(1.0, "mode loiter"));
    assert_eq!(set_mode(&out, 5.0), 1, "{out:?}");
    let mut later = b.feed(1.5, ix[0][1]);
    later.extend(b.tick_to(15.0));
    let later = operator_frames(&later);
    assert_eq!(set_mode(&later, 5.0), 0, "not resent over RTL: {later:?}");
    assert!(b
        .app
        .notices
        .iter()
        .any(|n| n.text.contains("changed mode on its own")));
    // Where nobody changed the mode, the same request is resent (the heartbeat still shows the
    // mode we left).
    let (mut b, ix) = Bench::new(&[(1, &[(0, false)])]);
    b.feed(0.0, ix[0][0]);
    let mut all = b.command(1.0, "mode loiter");
    all.extend(b.tick_to(4.5));
    assert!(set_mode(&operator_frames(&all), 5.0) >= 2);
}

#[test]
fn a_px4_long_do_set_mode_that_took_is_ours() {
    // PX4 1:1 in MANUAL (main mode 1); `long DO_SET_MODE 1 3` asks POSCTL (main mode 3), and
    // the heartbeat then shows it (custom_mode 3 << 16): no warning of a change of its own.
    let hb = |seq: u64, custom_mode: u64| {
        json!({"sysid": 1, "compid": 1, "seq": seq, "msg": "HEARTBEAT",
        "fields": {"type": 2, "autopilot": 12, "base_mode": 1, "custom_mode": custom_mode,
        "system_status": 3, "mavlink_version": 3}})
    };
    let (mut b, _) = Bench::new(&[(9, &[(0, false)])]);
    b.raw(0.0, &[hb(0, 1 << 16)]);
    let out = operator_frames(&b.command(1.0, "long DO_SET_MODE 1 3"));
    assert_eq!(commands(&out, 176).len(), 1, "{out:?}");
    b.raw(1.5, &[hb(1, 3 << 16)]);
    let texts: Vec<&str> = b.app.notices.iter().map(|n| n.text.as_str()).collect();
    assert!(
        !texts.iter().any(|t| t.contains("changed mode on its own")),
        "{texts:?}"
    );
}

/// The SET_POSITION_TARGET_LOCAL_NEDs among `frames`, read by pymavlink: (vx, vy, vz, yaw
/// rate, frame, mask) each.
fn velocity_targets(frames: &[Vec<u8>]) -> Vec<Value> {
    operator_frames(frames)
        .into_iter()
        .filter(|v| v["name"] == "SET_POSITION_TARGET_LOCAL_NED")
        .collect()
}

fn is_moving(v: &Value) -> bool {
    ["vx", "vy", "vz", "yaw_rate"].iter().any(|f| v[*f] != 0.0)
}

/// A way a session in Fly mode ends: what it does to the bench, and what left meanwhile.
type Ending = dyn Fn(&mut Bench, &[Vec<usize>]) -> Vec<Vec<u8>>;

#[test]
fn a_nudge_ends_in_three_stops_whichever_way_fly_mode_ends() {
    // Armed in GUIDED (4), then: LOITER (5) armed, GUIDED disarmed.
    let modes: &[(u32, bool)] = &[(4, true), (5, true), (4, false)];
    let ways: [(&str, &Ending); 11] = [
        ("a mode change away from GUIDED", &|b, ix| {
            b.feed(1.3, ix[0][1])
        }),
        ("esc", &|b, _| b.keys(1.3, &["esc"])),
        // Ctrl-Z and a `kill -TSTP`: Fly mode is left before the front end suspends.
        ("the suspend key", &|b, _| {
            let out = b.keys(1.3, &["ctrl-z"]);
            assert!(b.app.suspend, "suspend asked");
            out
        }),
        ("a kill -TSTP", &|b, _| {
            let out = sends(&b.app.update(1_300_000, Event::Suspend));
            assert!(b.app.suspend, "suspend asked");
            out
        }),
        ("a disarm", &|b, ix| b.feed(1.3, ix[0][2])),
        ("the prompt opening", &|b, _| b.keys(1.3, &[":"])),
        ("another screen", &|b, _| b.keys(1.3, &["4"])),
        ("the palette", &|b, _| b.keys(1.3, &["ctrl-p"])),
        ("quit", &|b, _| b.keys(1.3, &["q"])),
        ("the target changing", &|b, _| {
            b.app.target = None;
            b.tick_to(1.3)
        }),
        // No heartbeat for 5 s: lost (the deadman is longer, so it is not what stops it).
        ("the vehicle lost", &|b, _| b.tick_to(6.5)),
    ];
    for (way, end) in ways {
        let (mut b, ix) = Bench::new(&[(1, modes)]);
        b.app.nudge.deadman = 20 * SECOND;
        b.feed(0.0, ix[0][0]);
        let mut out = b.keys(1.0, &["F", "up"]);
        assert!(b.app.nudge.active(), "{way}");
        out.extend(b.tick_to(1.25));
        let flown = velocity_targets(&out);
        assert!(flown.iter().any(is_moving), "{way}: flew {flown:?}");
        let mut after = end(&mut b, &ix);
        assert!(!b.app.nudge.active(), "{way}: Fly mode left");
        // Keys keep coming (a terminal repeating `up`): nothing moves it any more.
        let t = b.app.now as f64 / 1e6;
        after.extend(b.keys(t + 0.05, &["up"]));
        after.extend(b.tick_to(t + 1.0));
        // What follows the last velocity (the loss takes 5 s to tell: the stream goes on
        // until then) is the stop, three times, and nothing moves after it.
        let v = velocity_targets(&after);
        let stops = &v[v.iter().rposition(is_moving).map_or(0, |i| i + 1)..];
        assert!(
            v.iter().skip_while(|s| is_moving(s)).all(|s| !is_moving(s)),
            "{way}"
        );
        assert_eq!(stops.len(), 3, "{way}: {stops:?}");
        for s in stops {
            assert_eq!(s["coordinate_frame"], flown[0]["coordinate_frame"], "{way}");
            assert_eq!(s["type_mask"], flown[0]["type_mask"], "{way}");
            assert_eq!(s["target_system"], 1, "{way}");
        }
        // 100 ms apart.
        let ms: Vec<u64> = stops
            .iter()
            .map(|s| s["time_boot_ms"].as_u64().unwrap())
            .collect();
        assert_eq!(ms[1] - ms[0], 100, "{way}: {ms:?}");
        assert_eq!(ms[2] - ms[1], 100, "{way}: {ms:?}");
    }
}

#[test]
fn the_stream_checks_armed_and_mode_before_every_send() {
    // A key held and repeating: the heartbeat shows LOITER between two sends; the next send
    // is a stop, not the velocity.
    let (mut b, ix) = Bench::new(&[(1, &[(4, true), (5, true)])]);
    b.feed(0.0, ix[0][0]);
    let mut out = b.keys(1.0, &["F", "up"]);
    out.extend(b.tick_to(1.15));
    assert!(velocity_targets(&out).iter().any(is_moving));
    // The mode change comes with no key pressed: only the stream's own check can see it.
    let mut after = b.feed(1.16, ix[0][1]);
    after.extend(b.tick_to(1.5));
    let v = velocity_targets(&after);
    assert!(!v.is_empty() && v.iter().all(|s| !is_moving(s)), "{v:?}");
}

impl Bench {
    /// Encode `reqs` with pymavlink and feed them at `t` seconds: what left.
    fn raw(&mut self, t: f64, reqs: &[Value]) -> Vec<Vec<u8>> {
        let mut out = Vec::new();
        for f in common::pymavlink_encode(reqs) {
            let fx = self.app.update(
                (t * 1e6) as u64,
                Event::Frames {
                    link: 0,
                    frames: FrameParser::new().parse_all(&f),
                    stats: ParserStats::default(),
                },
            );
            out.extend(sends(&fx));
        }
        out
    }
}

/// The list of dangerous commands, from the MAVLink spec's numbers: (name, number, params,
/// the vehicle flying).
const DANGEROUS: &[(&str, u64, [f64; 2], bool)] = &[
    ("COMPONENT_ARM_DISARM", 400, [1.0, 0.0], false), // arm
    ("COMPONENT_ARM_DISARM", 400, [0.0, 21196.0], false), // force-disarm
    ("COMPONENT_ARM_DISARM", 400, [0.0, 0.0], true),  // disarm in flight
    ("NAV_TAKEOFF", 22, [0.0, 0.0], false),
    ("NAV_VTOL_TAKEOFF", 84, [0.0, 0.0], false),
    ("PREFLIGHT_REBOOT_SHUTDOWN", 246, [1.0, 0.0], false),
    ("DO_MOTOR_TEST", 209, [1.0, 0.0], false),
    ("DO_FLIGHTTERMINATION", 185, [1.0, 0.0], false),
    ("PREFLIGHT_STORAGE", 245, [2.0, 0.0], false),
    ("DO_PARACHUTE", 208, [2.0, 0.0], false),
    ("MISSION_START", 300, [0.0, 0.0], false),
    ("DO_SET_SERVO", 183, [9.0, 1900.0], false),
    ("DO_REPEAT_SERVO", 184, [9.0, 1900.0], false),
    ("DO_AUX_FUNCTION", 218, [41.0, 2.0], false),
    ("DO_GRIPPER", 211, [1.0, 0.0], false),
    ("DO_WINCH", 42600, [1.0, 1.0], false),
    ("DO_SET_HOME", 179, [1.0, 0.0], false),
    ("STORAGE_FORMAT", 526, [1.0, 0.0], false),
    ("PREFLIGHT_CALIBRATION", 241, [1.0, 0.0], false),
    ("DO_START_MAG_CAL", 42424, [0.0, 0.0], false),
];

/// What asks only while the vehicle flies its mission (armed in AUTO): (name, number, params).
const DANGEROUS_IN_ITS_MISSION: &[(&str, u64, [f64; 2])] = &[
    ("DO_SET_MISSION_CURRENT", 224, [3.0, 0.0]), // a jump, as `wp set 3`
];

/// ArduCopter 1:1, on the ground disarmed, or armed and in the air (EXTENDED_SYS_STATE).
fn bench_for(flying: bool) -> Bench {
    bench_in(if flying { 4 } else { 0 }, flying)
}

/// ArduCopter 1:1 in `mode`: on the ground disarmed, or armed and in the air.
fn bench_in(mode: u32, flying: bool) -> Bench {
    let (mut b, ix) = Bench::new(&[(1, &[(mode, flying)])]);
    b.feed(0.0, ix[0][0]);
    if flying {
        b.raw(
            0.1,
            &[
                json!({"sysid": 1, "compid": 1, "seq": 9, "msg": "EXTENDED_SYS_STATE",
                "fields": {"vtol_state": 0, "landed_state": 2}}),
            ],
        );
    }
    b
}

/// `name` from the palette, with `params` typed into p1 and p2.
fn from_palette(b: &mut Bench, t: f64, number: u64, name: &str, params: [f64; 2]) -> Vec<Vec<u8>> {
    let mut out = b.keys(t, &["ctrl-p"]);
    for c in name.chars() {
        out.extend(sends(
            &b.app.update((t * 1e6) as u64, Event::Key(Key::ch(c))),
        ));
    }
    let p = b.app.ui.palette.as_ref().expect("the palette");
    let i = p
        .matches
        .iter()
        .position(|&n| n as u64 == number)
        .unwrap_or_else(|| panic!("{name} not in the palette"));
    for _ in 0..i {
        out.extend(b.keys(t, &["down"]));
    }
    out.extend(b.keys(t, &["enter"]));
    for (k, p) in params.iter().enumerate() {
        if k > 0 {
            out.extend(b.keys(t, &["tab"]));
        }
        out.extend(b.keys(t, &["ctrl-u"]));
        for c in format!("{p}").chars() {
            out.extend(sends(
                &b.app.update((t * 1e6) as u64, Event::Key(Key::ch(c))),
            ));
        }
    }
    out.extend(b.keys(t, &["enter"]));
    out
}

/// It asked, and nothing of `number` left; then `n` (after a reading's pause) sends nothing.
fn asked_nothing_sent(b: &mut Bench, t: f64, out: Vec<Vec<u8>>, number: u64, what: &str) {
    let q = b
        .app
        .ui
        .confirm
        .clone()
        .unwrap_or_else(|| panic!("{what}: not asked ({:?})", b.app.ui.message));
    assert!(
        q.text.contains("1:1"),
        "{what}: the vehicle is named: {}",
        q.text
    );
    let mut out = out;
    out.extend(b.keys(t + 0.5, &["n"]));
    let left = operator_frames(&out);
    assert!(
        commands(&left, number).is_empty() && left.iter().all(|m| m["command"] != number),
        "{what}: {left:?}"
    );
    assert!(b.app.ui.confirm.is_none(), "{what}");
}

#[test]
fn every_dangerous_command_asks_from_every_entry_point() {
    let table = DANGEROUS
        .iter()
        .map(|&(n, c, p, flying)| (n, c, p, if flying { 4 } else { 0 }, flying))
        .chain(
            DANGEROUS_IN_ITS_MISSION
                .iter()
                .map(|&(n, c, p)| (n, c, p, 3, true)),
        );
    for (name, number, [p1, p2], mode, flying) in table {
        let what = format!("{name} {p1} {p2}");
        // The prompt.
        let mut b = bench_in(mode, flying);
        let out = b.command(1.0, &format!("long {name} {p1} {p2}"));
        asked_nothing_sent(&mut b, 1.0, out, number, &format!("prompt: {what}"));
        // The palette.
        let out = from_palette(&mut b, 2.0, number, name, [p1, p2]);
        asked_nothing_sent(&mut b, 2.0, out, number, &format!("palette: {what}"));
        // The Commands screen's re-issue: sent once (asked, `y`), cancelled, then again.
        b.command(3.0, &format!("long {name} {p1} {p2}"));
        let first = operator_frames(&b.keys(3.5, &["y"]));
        assert_eq!(commands(&first, number).len(), 1, "{what}: {first:?}");
        b.keys(3.6, &["3", "x"]);
        let out = b.keys(3.7, &["enter"]);
        asked_nothing_sent(&mut b, 3.7, out, number, &format!("re-issue: {what}"));
    }
    // The keys: `A` arms, `D` disarms in flight.
    let mut b = bench_for(false);
    let out = b.keys(1.0, &["A"]);
    asked_nothing_sent(&mut b, 1.0, out, 400, "key A");
    let mut b = bench_for(true);
    let out = b.keys(1.0, &["D"]);
    asked_nothing_sent(&mut b, 1.0, out, 400, "key D in flight");
    // The Mission screen's start (DO_SET_MODE AUTO then MISSION_START), the Camera screen's
    // format (STORAGE_FORMAT to the camera).
    // Armed (disarmed, with no mission known, `wp start` is refused: tests/operator.rs).
    let mut b = bench_for(true);
    let out = b.command(1.0, "wp start");
    asked_nothing_sent(&mut b, 1.0, out, 300, "wp start");
    let mut b = bench_for(false);
    b.raw(
        0.5,
        &[
            json!({"sysid": 1, "compid": 100, "seq": 0, "msg": "HEARTBEAT", "fields": {
            "type": 30, "autopilot": 8, "base_mode": 0, "custom_mode": 0,
            "system_status": 4, "mavlink_version": 3}}),
        ],
    );
    let out = b.command(1.0, "camera format");
    asked_nothing_sent(&mut b, 1.0, out, 526, "camera format");
    // And a disarm on the ground, a mode change, LAND go without a question.
    let mut b = bench_for(false);
    let out = operator_frames(&b.command(1.0, "long COMPONENT_ARM_DISARM 0 0"));
    assert!(b.app.ui.confirm.is_none());
    assert_eq!(commands(&out, 400).len(), 1, "{out:?}");
    // A jump while the vehicle is not flying its mission (armed in GUIDED) goes as well.
    let mut b = bench_for(true);
    let out = operator_frames(&b.command(1.0, "long DO_SET_MISSION_CURRENT 3"));
    assert!(b.app.ui.confirm.is_none());
    assert_eq!(commands(&out, 224).len(), 1, "{out:?}");
}

/// A camera 1:100: its heartbeat with sequence `seq`, and (first) its CAMERA_INFORMATION
/// saying it captures images and video (CAMERA_CAP_FLAGS 1 | 2, no modes).
fn camera_hb(seq: u8) -> Vec<Value> {
    let hb = json!({"sysid": 1, "compid": 100, "seq": seq, "msg": "HEARTBEAT", "fields": {
        "type": 30, "autopilot": 8, "base_mode": 0, "custom_mode": 0,
        "system_status": 4, "mavlink_version": 3}});
    let name = vec![0u8; 32];
    let info = json!({"sysid": 1, "compid": 100, "seq": seq + 1, "msg": "CAMERA_INFORMATION",
        "fields": {"time_boot_ms": 1000, "vendor_name": name, "model_name": name,
        "firmware_version": 0, "focal_length": 0.0, "sensor_size_h": 0.0, "sensor_size_v": 0.0,
        "resolution_h": 0, "resolution_v": 0, "lens_id": 0, "flags": 3,
        "cam_definition_version": 0, "cam_definition_uri": ""}});
    vec![hb, info]
}

/// What left for `command` to (sysid, compid).
fn to(out: &[Value], command: u64) -> Vec<(u64, u64)> {
    commands(out, command)
        .iter()
        .map(|m| {
            (
                m["target_system"].as_u64().unwrap(),
                m["target_component"].as_u64().unwrap(),
            )
        })
        .collect()
}

#[test]
fn a_lost_camera_gets_nothing() {
    let modes = [(0u32, false); 10];
    let (mut b, ix) = Bench::new(&[(1, &modes)]);
    b.feed(0.0, ix[0][0]);
    b.raw(0.2, &camera_hb(0));
    let out = operator_frames(&b.command(1.0, "camera shoot"));
    assert_eq!(to(&out, 2000), vec![(1, 100)], "heard: sent");
    // The autopilot keeps its heartbeat, the camera is silent: lost after 5 s.
    let mut later = Vec::new();
    for (s, &i) in ix[0].iter().enumerate().take(8).skip(1) {
        later.extend(b.feed(s as f64, i));
    }
    assert!(b.app.vehicles.get(VehicleKey(1, 100)).unwrap().lost);
    later.extend(b.command(8.0, "camera shoot"));
    later.extend(b.command(8.1, "camera video start"));
    let later = operator_frames(&later);
    assert!(
        to(&later, 2000).is_empty() && to(&later, 2500).is_empty(),
        "{later:?}"
    );
    let msg = b.app.ui.message.clone().unwrap().1;
    assert!(msg.contains("1:100 is lost"), "{msg}");
}

#[test]
fn reissue_goes_to_the_entrys_camera_and_the_row_under_the_cursor() {
    let (mut b, ix) = Bench::new(&[(1, &[(0, false)])]);
    b.feed(0.0, ix[0][0]);
    b.raw(0.2, &camera_hb(0));
    b.command(1.0, "camera shoot");
    // On the Commands screen the shot is the newest row, under the cursor; it is cancelled.
    b.keys(1.2, &["3", "x"]);
    // A command arrives meanwhile (typed at the prompt): a new newest row.
    let out = operator_frames(&b.command(1.4, "long GET_HOME_POSITION"));
    assert_eq!(to(&out, 410), vec![(1, 1)]);
    b.tick_to(4.0); // its answer never comes
    let out = operator_frames(&b.keys(4.1, &["enter"]));
    assert_eq!(
        to(&out, 2000),
        vec![(1, 100)],
        "the shot, to its camera: {out:?}"
    );
    assert!(to(&out, 410).is_empty(), "{out:?}");
}

#[test]
fn armed_uploads_and_parameter_changes_ask_naming_the_vehicle() {
    let (mut b, ix) = Bench::new(&[(1, &[(4, true)])]);
    b.feed(0.0, ix[0][0]);
    // A parameter the vehicle reported.
    b.raw(
        0.1,
        &[
            json!({"sysid": 1, "compid": 1, "seq": 9, "msg": "PARAM_VALUE", "fields": {
            "param_id": "RTL_ALT", "param_value": 1500.0, "param_type": 4,
            "param_count": 1, "param_index": 0}}),
        ],
    );
    let out = b.command(1.0, "param set RTL_ALT 3000");
    let q = b.app.ui.confirm.clone().expect("asked while armed").text;
    assert!(
        q.contains("ARMED") && q.contains("1:1") && q.contains("RTL_ALT"),
        "{q}"
    );
    let mut out = out;
    out.extend(b.keys(1.5, &["n"]));
    assert!(operator_frames(&out)
        .iter()
        .all(|m| m["name"] != "PARAM_SET"));
    // The same value again is no change: sent without a question.
    let out = operator_frames(&b.command(2.0, "param set RTL_ALT 1500"));
    assert!(b.app.ui.confirm.is_none());
    assert_eq!(
        out.iter().filter(|m| m["name"] == "PARAM_SET").count(),
        1,
        "{out:?}"
    );
    // A mission file uploaded while armed.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.waypoints");
    std::fs::write(
        &path,
        "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t-35.3632621\t149.1652374\t584\t1\n\
         1\t0\t3\t16\t0\t0\t0\t0\t-35.36\t149.16\t20\t1\n",
    )
    .unwrap();
    b.app.update(
        2_500_000,
        Event::FileRead {
            path: path.clone(),
            purpose: mavterm::app::params::FileUse::Mission(mavterm::mission::MissionType::Mission),
            result: Ok(std::fs::read(&path).unwrap()),
        },
    );
    let out = b.command(3.0, "wp upload");
    let q = b.app.ui.confirm.clone().expect("asked while armed").text;
    assert!(
        q.contains("ARMED") && q.contains("1:1") && q.contains("replaces"),
        "{q}"
    );
    let mut out = out;
    out.extend(b.keys(3.5, &["n"]));
    // No MISSION_COUNT (44) left.
    assert!(out.iter().all(|f| common::frame_msgid(f) != 44));
}

/// The ARM commands among what the runner sent since the last call.
fn arms(r: &mut VirtualRunner) -> Vec<Value> {
    commands(&sent(r), 400)
        .into_iter()
        .filter(|c| c["param1"] == 1.0)
        .collect()
}

#[test]
fn enter_confirms_only_on_a_highlighted_yes_and_not_as_the_key_that_asked() {
    let mut r = runner("");
    // `arm` at the prompt: its `enter` asks, and an `enter` typed ahead (or bounced) right after
    // it does not answer; the highlight starts on No.
    key(&mut r, ":");
    common::typed(&mut r, "arm");
    key(&mut r, "enter");
    assert!(r.app.ui.confirm.is_some(), "asked");
    key(&mut r, "enter");
    assert!(
        r.app.ui.confirm.is_some(),
        "an enter hard on the asking one does not answer"
    );
    // `enter` after reading the question, on No: cancelled, nothing sent.
    wait(&mut r, 0.5);
    key(&mut r, "enter");
    assert!(r.app.ui.confirm.is_none(), "enter on No cancels");
    wait(&mut r, 2.0);
    assert!(arms(&mut r).is_empty());
    assert!(!sim(&r).vehicle(1).unwrap().armed());
    // Right moves the highlight to Yes, tab back to No, left to Yes again; each move sends
    // nothing and an `enter` hard on a move's heels (a held or typed-ahead key) does not answer.
    key(&mut r, "A");
    wait(&mut r, 0.5);
    key(&mut r, "right");
    assert_eq!(r.app.ui.confirm.as_ref().map(|c| c.yes), Some(true));
    key(&mut r, "tab");
    assert_eq!(r.app.ui.confirm.as_ref().map(|c| c.yes), Some(false));
    key(&mut r, "left");
    key(&mut r, "enter");
    assert!(
        r.app.ui.confirm.is_some(),
        "enter right after a move does not answer"
    );
    wait(&mut r, 1.0);
    assert!(arms(&mut r).is_empty());
    // A repeated `enter` (the terminal says so) never answers, however late.
    r.event(Event::KeyRepeat(Key::plain(
        mavterm::keymap::KeyCode::Enter,
    )));
    assert!(r.app.ui.confirm.is_some());
    // An `enter` on its own, on Yes: armed, once.
    wait(&mut r, 0.5);
    key(&mut r, "enter");
    wait(&mut r, 2.0);
    let arm = arms(&mut r);
    assert_eq!(arm.len(), 1, "{arm:?}");
    armed_at_1_1(&r, &arm);
}

#[test]
fn the_question_box_shows_its_choices_and_the_highlight() {
    let mut r = runner("");
    key(&mut r, "A");
    let s = common::screen(&r, 80, 24);
    assert!(s.contains("[ No ]   Yes"), "{s}");
    wait(&mut r, 0.5);
    key(&mut r, "right");
    let s = common::screen(&r, 80, 24);
    assert!(s.contains("  No   [ Yes ]"), "{s}");
    assert!(s.contains("ARM 1:1"), "{s}");
}
