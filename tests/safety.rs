//! Operator safety, read on the wire: keys go into the core (headless, virtual time) and the
//! frames that leave (or do not) are read back by pymavlink. Confirmations that a repeated or
//! typed-ahead key cannot give, questions that expire, one question at a time, a safe mode that
//! never waits, a DO_SET_MODE resend that a pilot's mode change cancels.

mod common;

use common::{command, sim, wait};

use mavterm::app::{App, AppConfig, Effect, Event};
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::keymap::Key;
use mavterm::link::{FrameParser, LinkSpec, ParserStats};
use serde_json::{json, Value};

const SECOND: u64 = 1_000_000;

/// Message ids of what an operator sends: COMMAND_INT, COMMAND_LONG, SET_MODE, PARAM_SET,
/// SET_POSITION_TARGET_LOCAL_NED.
const OPERATOR_IDS: [u32; 5] = [75, 76, 11, 23, 84];

fn msgid(frame: &[u8]) -> u32 {
    match frame.first() {
        Some(0xFD) if frame.len() >= 10 => u32::from_le_bytes([frame[7], frame[8], frame[9], 0]),
        Some(0xFE) if frame.len() >= 6 => frame[5] as u32,
        _ => u32::MAX,
    }
}

/// The operator's frames among `frames`, as pymavlink reads them (automatic requests left out).
fn operator_frames(frames: &[Vec<u8>]) -> Vec<Value> {
    let mine: Vec<Vec<u8>> = frames
        .iter()
        .filter(|f| OPERATOR_IDS.contains(&msgid(f)))
        .cloned()
        .collect();
    if mine.is_empty() {
        return Vec::new();
    }
    common::pymavlink_decode(&mine)
        .into_iter()
        .inspect(|v| assert!(v.get("error").is_none(), "pymavlink: {v}"))
        .filter(|v| {
            // Automatic requests: SET_MESSAGE_INTERVAL, REQUEST_MESSAGE, capabilities, streams.
            let c = v["command"].as_u64().unwrap_or(0);
            !(v["name"] == "COMMAND_LONG" && matches!(c, 511 | 512 | 520 | 2504 | 2505 | 1000))
        })
        .collect()
}

/// What the runner sent since the last call, read by pymavlink.
fn sent(r: &mut VirtualRunner) -> Vec<Value> {
    let frames: Vec<Vec<u8>> = r.take_sent().into_iter().map(|(_, _, f)| f).collect();
    operator_frames(&frames)
}

fn commands(v: &[Value], command: u64) -> Vec<Value> {
    v.iter()
        .filter(|m| m["name"] == "COMMAND_LONG" && m["command"] == command)
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
    assert_eq!(
        (
            arm[0]["target_system"].as_u64(),
            arm[0]["target_component"].as_u64()
        ),
        (Some(1), Some(1))
    );
    assert!(sim(&r).vehicle(1).unwrap().armed());
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

fn sends(fx: &[Effect]) -> Vec<Vec<u8>> {
    fx.iter()
        .filter_map(|e| match e {
            Effect::Send { frame, .. } => Some(frame.clone()),
            _ => None,
        })
        .collect()
}

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
    assert_eq!(b.app.target, Some((1, 1)));
    b.keys(1.0, &["A"]);
    b.app.target = Some((2, 1));
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
        if r.app.sessions[&(1, 1)]
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
        r.app.sessions[&(1, 1)].sequence.is_some(),
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
    let ways: [(&str, &Ending); 8] = [
        ("a mode change away from GUIDED", &|b, ix| {
            b.feed(1.3, ix[0][1])
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
