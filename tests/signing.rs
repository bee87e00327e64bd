//! MAVLink 2 signing in the core, with pymavlink as the reference both ways: what mavterm signs
//! verifies in pymavlink with the same key (and fails with another); what pymavlink signs is
//! taken; tampered bytes, a wrong key, replayed and stale timestamps and unsigned frames are
//! rejected and counted; a timestamp more than a minute ahead of the wall clock (2^48-1, or a
//! vehicle an hour ahead) is refused as `future` and moves no clock, and a state file poisoned
//! with one is repaired at start; the timestamp never goes back across restarts; `signing setup` and
//! `signing off` send the SETUP_SIGNING MAVProxy sends, only after a confirmation and only on a
//! `?secure=1` link; the Links pane shows the counts per source.

mod common;

use chrono::{DateTime, Utc};
use serde_json::{json, Value};

use mavterm::app::links::LinkState;
use mavterm::app::signing::SigningConfig;
use mavterm::app::{App, AppConfig, Effect, Event};
use mavterm::clock::{Micros, SECOND};
use mavterm::keymap::Key;
use mavterm::proto::vehicles::VehicleKey;
use mavterm::wire::signing::SecretKey;
use mavterm::wire::FrameParser;

const PASS: &str = "mavterm signing test";
const OTHER: &str = "another key";
/// 2024-05-01 12:00:00 UTC, in Unix seconds: the wall clock at core time 0.
const EPOCH_UNIX: i64 = 1_714_564_800;
/// 2015-01-01 00:00:00 UTC, the signing timestamp's epoch (MAVLink guide).
const SIGNING_EPOCH_UNIX: i64 = 1_420_070_400;

fn epoch(unix: i64) -> DateTime<Utc> {
    DateTime::from_timestamp(unix, 0).unwrap()
}

/// The signing timestamp of the wall clock at core time `t`, from the guide: 10 µs units since
/// 2015-01-01.
fn spec_ts(t: Micros) -> u64 {
    (((EPOCH_UNIX - SIGNING_EPOCH_UNIX) * 1_000_000) as u64 + t) / 10
}

fn signing(pass: &str, allow_hb: bool) -> SigningConfig {
    SigningConfig {
        key: SecretKey::from_passphrase(pass),
        allow_unsigned_heartbeat: allow_hb,
        state_path: None,
        saved_timestamp: 0,
        saved_at: None,
    }
}

fn app_with(links: &[&str], signing: Option<SigningConfig>, epoch_unix: i64) -> App {
    app_with_fx(links, signing, epoch_unix).0
}

/// [`app_with`], and what the core did when its links came up (its first update).
fn app_with_fx(
    links: &[&str],
    signing: Option<SigningConfig>,
    epoch_unix: i64,
) -> (App, Vec<Effect>) {
    let mut a = App::new(AppConfig {
        links: links.iter().map(|s| s.to_string()).collect(),
        epoch: epoch(epoch_unix),
        request_streams: false,
        fetch_params: false,
        signing,
        ..AppConfig::default()
    });
    let mut fx = Vec::new();
    for i in 0..links.len() {
        fx.extend(a.update(
            0,
            Event::LinkState {
                link: i,
                state: LinkState::Up,
            },
        ));
    }
    (a, fx)
}

fn app(links: &[&str], key: Option<&str>, allow_hb: bool) -> App {
    app_with(links, key.map(|k| signing(k, allow_hb)), EPOCH_UNIX)
}

/// Frames as a link delivers them; what the core does in answer.
fn feed(a: &mut App, t: Micros, link: usize, bytes: &[u8]) -> Vec<Effect> {
    let mut p = FrameParser::new();
    let frames = p.parse_all(bytes);
    assert_eq!(frames.len(), 1, "one whole frame");
    let stats = *p.stats();
    a.update(
        t,
        Event::Frames {
            link,
            frames,
            stats,
        },
    )
}

/// (link, bytes) of every frame sent.
fn sends(fx: &[Effect]) -> Vec<(usize, Vec<u8>)> {
    fx.iter()
        .filter_map(|e| match e {
            Effect::Send { link, frame, .. } => Some((*link, frame.clone())),
            _ => None,
        })
        .collect()
}

fn keys(a: &mut App, t: Micros, names: &[&str]) -> Vec<Effect> {
    let mut fx = Vec::new();
    for n in names {
        fx.extend(a.update(t, Event::Key(n.parse::<Key>().unwrap())));
    }
    fx
}

/// Type a prompt command and run it.
fn command(a: &mut App, t: Micros, line: &str) -> Vec<Effect> {
    let mut fx = keys(a, t, &[":"]);
    for c in line.chars() {
        fx.extend(a.update(t, Event::Key(Key::ch(c))));
    }
    fx.extend(keys(a, t, &["enter"]));
    fx
}

/// Run `tests/py/signing.py`.
fn py(args: &[&str], input: &[String]) -> Vec<String> {
    common::py_lines("signing.py", args, input)
}

fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

/// The key MAVProxy makes of a passphrase (hashlib.sha256 of its UTF-8 bytes), as hex; asked
/// once per passphrase.
fn mavproxy_key(pass: &str) -> String {
    use std::collections::HashMap;
    use std::sync::Mutex;
    static KEYS: Mutex<Option<HashMap<String, String>>> = Mutex::new(None);
    let mut keys = KEYS.lock().unwrap_or_else(|e| e.into_inner());
    keys.get_or_insert_with(HashMap::new)
        .entry(pass.to_string())
        .or_insert_with(|| py(&["passphrase", pass], &[]).remove(0))
        .clone()
}

/// pymavlink's reading of each frame with key `key` (hex, or "none"), and its counters.
fn verify(key: &str, frames: &[Vec<u8>]) -> (Vec<Value>, Value) {
    let lines: Vec<String> = frames.iter().map(|f| hex(f)).collect();
    let mut out: Vec<Value> = py(&["verify", key], &lines)
        .iter()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let summary = out.pop().unwrap()["summary"].clone();
    (out, summary)
}

/// Frames signed by pymavlink with key `key`, link id `link_id`, first timestamp `ts`.
fn sign(key: &str, link_id: u8, ts: u64, requests: &[Value]) -> Vec<Vec<u8>> {
    let lines: Vec<String> = requests.iter().map(|r| r.to_string()).collect();
    py(
        &["sign", key, &link_id.to_string(), &ts.to_string()],
        &lines,
    )
    .iter()
    .map(|h| {
        (0..h.len())
            .step_by(2)
            .map(|i| u8::from_str_radix(&h[i..i + 2], 16).unwrap())
            .collect()
    })
    .collect()
}

/// An ArduCopter HEARTBEAT request for pymavlink, from `sysid`:1.
fn copter_hb(sysid: u8, seq: u8, custom_mode: u32) -> Value {
    json!({
        "sysid": sysid, "compid": 1, "seq": seq, "msg": "HEARTBEAT",
        "fields": {"type": 2, "autopilot": 3, "base_mode": 1, "custom_mode": custom_mode,
                   "system_status": 3, "mavlink_version": 3}
    })
}

fn counts(a: &App, link: usize, key: (u8, u8)) -> Value {
    let r = a.report();
    r["links"][link]["sources"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["sysid"] == key.0 && s["compid"] == key.1)
        .map(|s| s["signing"].clone())
        .unwrap_or(Value::Null)
}

fn notices(a: &App) -> Vec<String> {
    a.notices.iter().map(|n| n.text.clone()).collect()
}

#[test]
fn mavterm_signs_and_pymavlink_verifies() {
    let key = mavproxy_key(PASS);
    let mut a = app(
        &["udpin:0.0.0.0:14550", "tcp:127.0.0.1:5760"],
        Some(PASS),
        false,
    );
    let mut sent = Vec::new();
    for s in 1..4 {
        sent.extend(sends(&a.update(s * SECOND, Event::Tick)));
    }
    // Our GCS heartbeat, once a second on each link.
    assert_eq!(sent.len(), 6, "{sent:?}");
    let frames: Vec<Vec<u8>> = sent.iter().map(|(_, f)| f.clone()).collect();
    let (got, summary) = verify(&key, &frames);
    for (i, ((link, _), g)) in sent.iter().zip(&got).enumerate() {
        assert_eq!(g["name"], "HEARTBEAT", "{g}");
        assert_eq!(
            (g["sysid"].as_u64(), g["compid"].as_u64()),
            (Some(255), Some(190))
        );
        assert_eq!(g["sig_ok"], true, "{g}");
        assert_eq!(g["link_id"], *link as u64, "link id = link number: {g}");
        // The wall clock's timestamp; the second link's frame in the same 10 µs gets one more.
        let second = (i / 2) as u64 + 1;
        assert_eq!(
            g["timestamp"],
            spec_ts(second * SECOND) + (i % 2) as u64,
            "{g}"
        );
    }
    assert_eq!(summary["goodsig_count"], 6, "{summary}");
    assert_eq!(summary["badsig_count"], 0);
    // Another key: pymavlink refuses every one.
    let (got, summary) = verify(&mavproxy_key(OTHER), &frames);
    assert!(
        got.iter().all(|g| g["error"] == "Invalid signature"),
        "{got:?}"
    );
    assert_eq!(summary["badsig_count"], 6, "{summary}");
}

#[test]
fn frames_pymavlink_signs_are_taken() {
    let key = mavproxy_key(PASS);
    let mut a = app(&["udpin:0.0.0.0:14550"], Some(PASS), false);
    let frames = sign(
        &key,
        3,
        spec_ts(0),
        &[copter_hb(1, 0, 4), copter_hb(1, 1, 4), copter_hb(1, 2, 4)],
    );
    for (i, f) in frames.iter().enumerate() {
        feed(&mut a, 100_000 * (i as u64 + 1), 0, f);
    }
    let v = a.vehicles.get(VehicleKey(1, 1)).expect("vehicle heard");
    assert_eq!(v.custom_mode, 4);
    assert_eq!(a.target, Some(VehicleKey(1, 1)));
    let c = counts(&a, 0, (1, 1));
    assert_eq!(c["signed"], 3, "{c}");
    assert_eq!(c["rejected"], 0, "{c}");
    assert_eq!(a.report()["links"][0]["signing_streams"], 1);
    // Our clock is at least the vehicle's from now on (the guide's rule).
    assert!(a.signing.clock.last() >= spec_ts(0) + 2);
}

#[test]
fn tampered_wrong_key_replayed_and_stale_frames_are_rejected_and_counted() {
    let key = mavproxy_key(PASS);
    let mut a = app(&["udpin:0.0.0.0:14550"], Some(PASS), false);
    let t0 = spec_ts(0);
    let good = sign(&key, 0, t0, &[copter_hb(1, 0, 4), copter_hb(1, 1, 4)]);
    feed(&mut a, 100_000, 0, &good[0]);
    feed(&mut a, 200_000, 0, &good[1]);
    // Mode 6 (RTL) in a frame changed on the way (its CRC made right again): not read.
    let mut tampered = copter_hb(1, 2, 6);
    tampered["tamper"] = json!(true);
    tampered["ts"] = json!(t0 + 100);
    let tampered = sign(&key, 0, t0 + 100, &[tampered]);
    feed(&mut a, 300_000, 0, &tampered[0]);
    // Signed with another key.
    let wrong = sign(&mavproxy_key(OTHER), 0, t0 + 200, &[copter_hb(1, 3, 6)]);
    feed(&mut a, 400_000, 0, &wrong[0]);
    // The first frame again: its timestamp is not after the stream's last.
    feed(&mut a, 500_000, 0, &good[0]);
    // A new stream (link id 9) two minutes behind our clock.
    let stale = sign(&key, 9, t0 - 2 * 6_000_000, &[copter_hb(1, 4, 6)]);
    feed(&mut a, 600_000, 0, &stale[0]);
    assert_eq!(
        a.vehicles.get(VehicleKey(1, 1)).unwrap().custom_mode,
        4,
        "no rejected frame was read"
    );
    let c = counts(&a, 0, (1, 1));
    assert_eq!(c["signed"], 2, "{c}");
    assert_eq!(c["bad_signature"], 2, "{c}");
    assert_eq!(c["replayed"], 1, "{c}");
    assert_eq!(c["too_old"], 1, "{c}");
    assert_eq!(c["rejected"], 4, "{c}");
    // Rejected frames are not in the loss counts either.
    let src = &a.report()["links"][0]["sources"][0];
    assert_eq!(
        (src["received"].as_u64(), src["lost"].as_u64()),
        (Some(2), Some(0))
    );
    // Told once per kind.
    let n = notices(&a);
    assert_eq!(
        n.iter().filter(|t| t.contains("bad signature")).count(),
        1,
        "{n:?}"
    );
    assert_eq!(
        n.iter().filter(|t| t.contains("replayed")).count(),
        1,
        "{n:?}"
    );
    // A good frame after all that is still taken.
    let next = sign(&key, 0, t0 + 300, &[copter_hb(1, 5, 5)]);
    feed(&mut a, 700_000, 0, &next[0]);
    assert_eq!(a.vehicles.get(VehicleKey(1, 1)).unwrap().custom_mode, 5);
}

#[test]
fn unsigned_frames_are_rejected_with_a_key_but_radio_status() {
    let radio_status = json!({"sysid": 51, "compid": 68, "seq": 0, "msg": "RADIO_STATUS",
        "fields": {"rssi": 100, "remrssi": 90, "txbuf": 80, "noise": 20, "remnoise": 25,
                   "rxerrors": 0, "fixed": 0}});
    let radio = json!({"sysid": 51, "compid": 68, "seq": 1, "msg": "RADIO",
        "fields": {"rssi": 100, "remrssi": 90, "txbuf": 80, "noise": 20, "remnoise": 25,
                   "rxerrors": 0, "fixed": 0}});
    let sys_status = json!({"sysid": 1, "compid": 1, "seq": 1, "msg": "SYS_STATUS",
        "fields": {"onboard_control_sensors_present": 0, "onboard_control_sensors_enabled": 0,
                   "onboard_control_sensors_health": 0, "load": 0, "voltage_battery": 12000,
                   "current_battery": 100, "battery_remaining": 50, "drop_rate_comm": 0,
                   "errors_comm": 0, "errors_count1": 0, "errors_count2": 0,
                   "errors_count3": 0, "errors_count4": 0}});
    let mut v1_hb = copter_hb(1, 2, 4);
    v1_hb["v1"] = json!(true);
    let unsigned =
        common::pymavlink_encode(&[copter_hb(1, 0, 4), radio_status, radio, sys_status, v1_hb]);

    let mut a = app(
        &["udpin:0.0.0.0:14550", "serial:/dev/ttyACM0?secure=1"],
        Some(PASS),
        false,
    );
    for (i, f) in unsigned.iter().enumerate() {
        feed(&mut a, (i as u64 + 1) * 100_000, 0, f);
    }
    assert!(
        a.vehicles.get(VehicleKey(1, 1)).is_none(),
        "unsigned heartbeats rejected"
    );
    let c = counts(&a, 0, (1, 1));
    assert_eq!(
        (c["unsigned"].as_u64(), c["rejected"].as_u64()),
        (Some(3), Some(3)),
        "{c}"
    );
    let radio = counts(&a, 0, (51, 68));
    assert_eq!(
        (radio["unsigned"].as_u64(), radio["rejected"].as_u64()),
        (Some(2), Some(0)),
        "SiK radios cannot sign: {radio}"
    );
    let n = notices(&a);
    assert!(
        n.iter()
            .any(|t| t.contains("1:1 sends unsigned frames on link 0: rejected")),
        "{n:?}"
    );
    // On the ?secure=1 link (a USB cable) unsigned frames are taken, and counted.
    feed(&mut a, SECOND, 1, &unsigned[0]);
    assert!(a.vehicles.get(VehicleKey(1, 1)).is_some());
    let c = counts(&a, 1, (1, 1));
    assert_eq!(
        (c["unsigned"].as_u64(), c["rejected"].as_u64()),
        (Some(1), Some(0)),
        "{c}"
    );

    // With the option, unsigned HEARTBEATs are taken; nothing else is.
    let mut a = app(&["udpin:0.0.0.0:14550"], Some(PASS), true);
    for (i, f) in unsigned.iter().enumerate() {
        feed(&mut a, (i as u64 + 1) * 100_000, 0, f);
    }
    assert!(
        a.vehicles.get(VehicleKey(1, 1)).is_some(),
        "heartbeat taken"
    );
    let c = counts(&a, 0, (1, 1));
    // Heartbeat (v2 and v1) taken, SYS_STATUS rejected.
    assert_eq!(
        (c["unsigned"].as_u64(), c["rejected"].as_u64()),
        (Some(3), Some(1)),
        "{c}"
    );
}

#[test]
fn without_a_key_everything_is_taken_and_a_signing_vehicle_is_warned_of() {
    let key = mavproxy_key(PASS);
    let mut a = app(&["udpin:0.0.0.0:14550"], None, false);
    let signed = sign(&key, 0, 1000, &[copter_hb(1, 0, 4), copter_hb(1, 1, 4)]);
    feed(&mut a, 100_000, 0, &signed[0]);
    feed(&mut a, 200_000, 0, &signed[1]);
    feed(&mut a, 300_000, 0, &common::copter_heartbeat(2, 0, 0));
    assert!(
        a.vehicles.get(VehicleKey(1, 1)).is_some() && a.vehicles.get(VehicleKey(2, 1)).is_some()
    );
    let c = counts(&a, 0, (1, 1));
    assert_eq!(
        (c["unchecked"].as_u64(), c["rejected"].as_u64()),
        (Some(2), Some(0)),
        "{c}"
    );
    assert_eq!(counts(&a, 0, (2, 1))["unsigned"], 1);
    let warned: Vec<String> = notices(&a)
        .into_iter()
        .filter(|t| t.contains("signs but we have no key"))
        .collect();
    assert_eq!(warned.len(), 1, "once: {warned:?}");
    assert!(warned[0].starts_with("1:1 "), "{warned:?}");
    // And we do not sign.
    let ours = sends(&a.update(2 * SECOND, Event::Tick));
    assert!(!ours.is_empty() && ours.iter().all(|(_, f)| f[2] & 1 == 0));
}

#[test]
fn timestamps_never_go_back_across_restarts() {
    use mavterm::signing_store::{load_state, signing_config};
    let key = mavproxy_key(PASS);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("signing.json");
    let state = |a: &App| a.signing.clock.last();

    // First run: two minutes of heartbeats; the state file written as the core asks.
    let cfg = signing_config(PASS, false, Some(path.clone())).unwrap();
    assert_eq!(cfg.saved_timestamp, 0);
    let mut a = app_with(&["udpin:0.0.0.0:14550"], Some(cfg), EPOCH_UNIX);
    let mut frames = Vec::new();
    let mut writes = 0;
    for s in 1..=120 {
        for e in a.update(s * SECOND, Event::Tick) {
            match e {
                Effect::Send { frame, .. } => frames.push(frame),
                Effect::WriteFile { path: p, contents } => {
                    assert_eq!(p, path);
                    std::fs::write(&p, &contents).unwrap();
                    writes += 1;
                    // The write is not told of (it is not the operator's file).
                    let before = a.notices.total;
                    a.update(
                        s * SECOND,
                        Event::FileWritten {
                            path: p,
                            error: None,
                        },
                    );
                    assert_eq!(a.notices.total, before);
                }
                _ => {}
            }
        }
    }
    // A reservation 30 s ahead, renewed every 15 s: a few writes, not one a frame.
    assert!((6..=9).contains(&writes), "{writes} writes");
    let (got, _) = verify(&key, &frames);
    let used: Vec<u64> = got
        .iter()
        .map(|g| g["timestamp"].as_u64().unwrap())
        .collect();
    assert!(used.windows(2).all(|w| w[0] < w[1]), "increasing");
    let last_a = *used.last().unwrap();
    assert_eq!(last_a, state(&a));
    // The run dies without its final save: what the file holds is still ahead of all it used.
    assert!(load_state(&path).unwrap() > last_a);

    // Second run, with the system clock an hour behind the one that wrote the file (its
    // modification time): still after every timestamp used, the file is not doubted.
    let file = std::fs::File::options().write(true).open(&path).unwrap();
    file.set_modified(
        std::time::SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(EPOCH_UNIX as u64 + 120),
    )
    .unwrap();
    drop(file);
    let cfg = signing_config(PASS, false, Some(path.clone())).unwrap();
    let mut b = app_with(&["udpin:0.0.0.0:14550"], Some(cfg), EPOCH_UNIX - 3600);
    let first_b: Vec<Vec<u8>> = sends(&b.update(SECOND, Event::Tick))
        .into_iter()
        .map(|(_, f)| f)
        .collect();
    let (got, _) = verify(&key, &first_b);
    let ts_b = got[0]["timestamp"].as_u64().unwrap();
    assert!(ts_b > last_a, "{ts_b} after {last_a}");
    assert_eq!(got[0]["sig_ok"], true);
    // A clean end keeps the exact last timestamp; the third run starts after it.
    let (p, contents) = b.signing.final_state().unwrap();
    std::fs::write(&p, contents).unwrap();
    assert_eq!(load_state(&path).unwrap(), ts_b);
    let cfg = signing_config(PASS, false, Some(path.clone())).unwrap();
    let mut c = app_with(&["udpin:0.0.0.0:14550"], Some(cfg), EPOCH_UNIX - 7200);
    let first_c: Vec<Vec<u8>> = sends(&c.update(SECOND, Event::Tick))
        .into_iter()
        .map(|(_, f)| f)
        .collect();
    let (got, _) = verify(&key, &first_c);
    assert!(got[0]["timestamp"].as_u64().unwrap() > ts_b);
    // A failed write is told once.
    for _ in 0..2 {
        c.update(
            2 * SECOND,
            Event::FileWritten {
                path: path.clone(),
                error: Some("disk full".into()),
            },
        );
    }
    let told: Vec<String> = notices(&c)
        .into_iter()
        .filter(|t| t.contains("signing timestamp"))
        .collect();
    assert_eq!(told.len(), 1, "{told:?}");
}

/// SETUP_SIGNING frames among `fx`, with their links.
fn setup_signing(fx: &[Effect]) -> Vec<(usize, Vec<u8>)> {
    fx.iter()
        .filter_map(|e| match e {
            Effect::Send {
                link,
                frame,
                msg: mavterm::dialect::MavMessage::SETUP_SIGNING(_),
            } => Some((*link, frame.clone())),
            _ => None,
        })
        .collect()
}

#[test]
fn signing_setup_and_off_go_only_confirmed_and_only_on_a_secure_link() {
    let key = mavproxy_key(PASS);
    let other = mavproxy_key(OTHER);
    let links = ["udpin:0.0.0.0:14550", "serial:/dev/ttyACM0?secure=1"];

    // No key: nothing to send.
    let mut a = app(&links, None, false);
    feed(&mut a, 100_000, 1, &common::copter_heartbeat(1, 0, 0));
    let fx = command(&mut a, 200_000, "signing setup");
    assert!(setup_signing(&fx).is_empty());
    let msg = a.ui.message.clone().unwrap().1;
    assert!(msg.contains("no signing key"), "{msg}");

    // The vehicle (already signing, with our key) heard on the radio link only: refused.
    let mut a = app(&links, Some(PASS), false);
    let radio = sign(&key, 0, spec_ts(0), &[copter_hb(1, 0, 0)]);
    feed(&mut a, 100_000, 0, &radio[0]);
    assert_eq!(a.target, Some(VehicleKey(1, 1)));
    let fx = command(&mut a, 200_000, "signing setup");
    assert!(setup_signing(&fx).is_empty() && a.ui.confirm.is_none());
    let msg = a.ui.message.clone().unwrap().1;
    assert!(
        msg.contains("not heard on a link marked ?secure=1"),
        "{msg}"
    );

    // Heard on the USB link too (it has another key there: taken on a trusted link).
    let usb = sign(&other, 0, spec_ts(0), &[copter_hb(1, 1, 0)]);
    feed(&mut a, 300_000, 1, &usb[0]);
    let fx = command(&mut a, 400_000, "signing setup");
    assert!(setup_signing(&fx).is_empty(), "asked first, nothing sent");
    let q = a.ui.confirm.clone().expect("a confirmation").text;
    assert!(
        q.contains("SEND SIGNING KEY") && q.contains("1:1") && q.contains("link 1"),
        "{q}"
    );
    let fx = keys(&mut a, 500_000, &["n"]);
    assert!(setup_signing(&fx).is_empty(), "cancelled: nothing sent");
    command(&mut a, 600_000, "signing setup");
    let t = 950_000; // a `y` counts 0.3 s after the question

    let fx = keys(&mut a, t, &["y"]);
    let sent = setup_signing(&fx);
    assert_eq!(sent.len(), 1, "{fx:?}");
    assert_eq!(sent[0].0, 1, "on the secure link only");
    let (got, _) = verify(&key, &[sent[0].1.clone()]);
    let g = &got[0];
    assert_eq!(g["name"], "SETUP_SIGNING", "{g}");
    assert_eq!(g["sig_ok"], true, "{g}");
    assert_eq!(
        (g["target_system"].as_u64(), g["target_component"].as_u64()),
        (Some(1), Some(1))
    );
    let secret: Vec<u8> = g["secret_key"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap() as u8)
        .collect();
    assert_eq!(
        hex(&secret),
        key,
        "the key MAVProxy makes of the passphrase"
    );
    let initial = g["initial_timestamp"].as_u64().unwrap();
    assert!(initial >= spec_ts(t), "{initial}");
    assert!(
        initial < g["timestamp"].as_u64().unwrap(),
        "ours come after it"
    );
    let msg = a.ui.message.clone().unwrap().1;
    assert!(msg.contains("sent to 1:1 on link 1"), "{msg}");
    // The vehicle answers signed with our key: told.
    let signed = sign(&key, 0, initial + 10, &[copter_hb(1, 2, 0)]);
    feed(&mut a, 800_000, 1, &signed[0]);
    assert!(
        notices(&a)
            .iter()
            .any(|n| n == "1:1 signs with our key: signing is on"),
        "{:?}",
        notices(&a)
    );

    // signing off: the all-zero key and timestamp 0, as MAVProxy's `signing remove`.
    command(&mut a, SECOND, "signing off");
    assert!(a.ui.confirm.is_some());
    let fx = keys(&mut a, SECOND + 400_000, &["y"]);
    let sent = setup_signing(&fx);
    assert_eq!(sent.len(), 1);
    assert_eq!(sent[0].0, 1);
    let (got, _) = verify(&key, &[sent[0].1.clone()]);
    let g = &got[0];
    assert_eq!(
        g["sig_ok"], true,
        "sent signed, with the key it still holds: {g}"
    );
    assert_eq!(g["initial_timestamp"], 0);
    assert!(
        g["secret_key"].as_array().unwrap().iter().all(|v| v == 0),
        "{g}"
    );
    // We no longer sign.
    let ours = sends(&a.update(2 * SECOND, Event::Tick));
    assert!(!ours.is_empty() && ours.iter().all(|(_, f)| f[2] & 1 == 0));
    // It still signs five seconds later: told it kept its key.
    let mut ts = initial + 100;
    for s in 2..8 {
        let f = sign(&key, 0, ts, &[copter_hb(1, s as u8 + 2, 0)]);
        feed(&mut a, s * SECOND + 500_000, 1, &f[0]);
        ts += 100_000;
    }
    let n = notices(&a);
    assert!(
        n.iter().any(|t| t.contains("1:1 still signs 5 s after")),
        "{n:?}"
    );
    assert!(
        !n.iter().any(|t| t.contains("signs but we have no key")),
        "the watch says it instead: {n:?}"
    );
}

// ---- Screens ----

use mavterm::ui::{self, buffer_to_text, Theme};
use ratatui::backend::TestBackend;
use ratatui::Terminal;

fn draw(
    app: &App,
    w: u16,
    h: u16,
    f: fn(&App, &mut ratatui::Frame, ratatui::layout::Rect, &Theme),
) -> String {
    let mut t = Terminal::new(TestBackend::new(w, h)).unwrap();
    t.draw(|frame| f(app, frame, frame.area(), &Theme::PLAIN))
        .unwrap();
    buffer_to_text(t.backend().buffer())
}

#[test]
fn links_pane_shows_signing_counts_per_source() {
    let key = mavproxy_key(PASS);
    let mut a = app(
        &["udpin:0.0.0.0:14550", "serial:/dev/ttyACM0?secure=1"],
        Some(PASS),
        false,
    );
    let t0 = spec_ts(0);
    let reqs: Vec<Value> = (0..10).map(|i| copter_hb(1, i, 4)).collect();
    let good = sign(&key, 0, t0, &reqs);
    for (i, f) in good.iter().enumerate() {
        feed(&mut a, 100_000 * (i as u64 + 1), 0, f);
    }
    feed(&mut a, 1_100_000, 0, &good[3]); // replayed
    let wrong = sign(
        &mavproxy_key(OTHER),
        0,
        t0 + 50,
        &[copter_hb(1, 10, 4), copter_hb(1, 11, 4)],
    );
    feed(&mut a, 1_200_000, 0, &wrong[0]);
    feed(&mut a, 1_300_000, 0, &wrong[1]);
    // Dated the end of time: from the future.
    let end = sign(&key, 0, (1 << 48) - 1, &[copter_hb(1, 12, 4)]);
    feed(&mut a, 1_350_000, 0, &end[0]);
    let unsigned = common::pymavlink_encode(&[
        json!({"sysid": 51, "compid": 68, "seq": 0, "msg": "RADIO_STATUS",
               "fields": {"rssi": 1, "remrssi": 2, "txbuf": 3, "noise": 4, "remnoise": 5,
                          "rxerrors": 0, "fixed": 0}}),
        copter_hb(2, 0, 0),
        copter_hb(2, 1, 0),
    ]);
    for (i, f) in unsigned.iter().enumerate() {
        feed(&mut a, 1_400_000 + i as u64 * 100_000, 0, f);
    }
    // The USB link: the vehicle unsigned there, taken.
    feed(&mut a, 1_800_000, 1, &common::copter_heartbeat(1, 0, 4));
    a.update(2 * SECOND, Event::Tick);
    for l in &mut a.links {
        l.expanded = true;
    }
    a.ui.focus = mavterm::app::Pane::Links;
    insta::assert_snapshot!("links_signing_80x24", draw(&a, 80, 24, ui::links::render));
    // Wider, the counts keep their `signing:` label.
    let wide = draw(&a, 100, 24, ui::links::render);
    assert!(
        wide.contains(
            "     signing: signed 10 · unsigned 0 · bad sig 2 · replayed 1 · future 1 · rejected 4"
        ),
        "{wide}"
    );
}

#[test]
fn a_vehicle_that_signs_while_we_have_no_key_is_a_notice() {
    let key = mavproxy_key(PASS);
    let mut a = app(&["udpin:0.0.0.0:14550"], None, false);
    let signed = sign(
        &key,
        0,
        spec_ts(0),
        &[copter_hb(1, 0, 4), copter_hb(1, 1, 4)],
    );
    feed(&mut a, 100_000, 0, &signed[0]);
    feed(&mut a, 1_100_000, 0, &signed[1]);
    a.update(2 * SECOND, Event::Tick);
    for l in &mut a.links {
        l.expanded = true;
    }
    insta::assert_snapshot!("links_no_key_80x24", draw(&a, 80, 12, ui::links::render));
    insta::assert_snapshot!(
        "notices_no_key_80x24",
        draw(&a, 80, 10, ui::messages::render)
    );
}

// ---- Timestamps from the future (one bad frame must not lock the link) ----

use mavterm::wire::signing::{FUTURE_MARGIN, MAX_TIMESTAMP};

/// One minute in timestamp units, from the guide (10 µs units).
const MINUTE: u64 = 6_000_000;

/// The timestamps of the frames among `fx` that pymavlink reads as signed with `key`.
fn sent_timestamps(key: &str, fx: &[Effect]) -> Vec<u64> {
    let frames: Vec<Vec<u8>> = sends(fx).into_iter().map(|(_, f)| f).collect();
    let (got, _) = verify(key, &frames);
    got.iter()
        .map(|g| {
            assert_eq!(g["sig_ok"], true, "{g}");
            g["timestamp"].as_u64().unwrap()
        })
        .collect()
}

#[test]
fn a_frame_dated_the_end_of_time_is_refused_and_the_link_goes_on() {
    assert_eq!(MAX_TIMESTAMP, (1u64 << 48) - 1);
    assert_eq!(FUTURE_MARGIN, MINUTE, "the margin chosen: a minute");
    let key = mavproxy_key(PASS);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("signing.json");
    let mut cfg = signing(PASS, false);
    cfg.state_path = Some(path.clone());
    let mut a = app_with(&["udpin:0.0.0.0:14550"], Some(cfg), EPOCH_UNIX);
    // Signed with the right key (by pymavlink), timestamp 2^48-1, then the vehicle's normal
    // frames on the same stream (link id 0), at the wall clock.
    let end = sign(&key, 0, MAX_TIMESTAMP, &[copter_hb(1, 0, 6)]);
    feed(&mut a, 100_000, 0, &end[0]);
    let reqs: Vec<Value> = (1..6).map(|i| copter_hb(1, i, 4)).collect();
    let normal = sign(&key, 0, spec_ts(200_000), &reqs);
    for (i, f) in normal.iter().enumerate() {
        feed(&mut a, 200_000 + i as u64 * 100_000, 0, f);
    }
    // The same end-of-time frame again later: counted, not told again.
    feed(&mut a, 800_000, 0, &end[0]);
    let c = counts(&a, 0, (1, 1));
    assert_eq!(c["future"], 2, "{c}");
    assert_eq!(c["signed"], 5, "{c}");
    assert_eq!(c["rejected"], 2, "{c}");
    let v = a
        .vehicles
        .get(VehicleKey(1, 1))
        .expect("the vehicle is heard");
    assert_eq!(v.custom_mode, 4, "the end-of-time frame (mode 6) not read");
    // Named once, with its stream and its date (2^48-1 x 10 µs after 2015-01-01 is
    // 2104-03-13 02:56:07 UTC).
    let told: Vec<String> = notices(&a)
        .into_iter()
        .filter(|t| t.contains("from the future"))
        .collect();
    assert_eq!(told.len(), 1, "{told:?}");
    assert!(
        told[0].starts_with("1:1: ")
            && told[0].contains("link 0 (its link id 0)")
            && told[0].contains("2104-03-13 02:56:07 UTC")
            && told[0].contains("rejected"),
        "{told:?}"
    );
    // Our clock stayed with the wall clock: what we sign next is read by pymavlink at the wall
    // clock's timestamp, and the state file never holds the end of time.
    let mut written = Vec::new();
    let mut ts = Vec::new();
    for s in 1..=40 {
        let fx = a.update(s * SECOND, Event::Tick);
        for e in &fx {
            if let Effect::WriteFile { path: p, contents } = e {
                assert_eq!(p, &path);
                written.push(mavterm::wire::signing::decode_state(contents).unwrap());
            }
        }
        for t in sent_timestamps(&key, &fx) {
            ts.push((s, t));
        }
    }
    for (s, t) in &ts {
        assert!(
            *t >= spec_ts(s * SECOND) && *t < spec_ts(s * SECOND) + 100,
            "at {s} s we signed {t}, the wall clock is {}",
            spec_ts(s * SECOND)
        );
    }
    assert!(!written.is_empty());
    for w in &written {
        // At most the 30 s reservation past the last used.
        assert!(*w <= spec_ts(40 * SECOND) + 100 + 3_000_000, "state {w}");
    }
    // A new stream of a vehicle whose clock is right is still taken.
    let other = sign(&key, 2, spec_ts(41 * SECOND), &[copter_hb(1, 9, 5)]);
    feed(&mut a, 41 * SECOND, 0, &other[0]);
    assert_eq!(a.vehicles.get(VehicleKey(1, 1)).unwrap().custom_mode, 5);
}

#[test]
fn a_frame_from_the_future_on_a_trusted_link_is_taken_but_moves_no_clock() {
    let key = mavproxy_key(PASS);
    let mut a = app(&["serial:/dev/ttyACM0?secure=1"], Some(PASS), false);
    let end = sign(&key, 0, MAX_TIMESTAMP, &[copter_hb(1, 0, 6)]);
    feed(&mut a, 100_000, 0, &end[0]);
    assert_eq!(
        a.vehicles.get(VehicleKey(1, 1)).unwrap().custom_mode,
        6,
        "taken"
    );
    let c = counts(&a, 0, (1, 1));
    assert_eq!(
        (c["future"].as_u64(), c["rejected"].as_u64()),
        (Some(1), Some(0))
    );
    let n = notices(&a);
    assert!(
        n.iter()
            .any(|t| t.contains("from the future") && t.contains("taken: the link is trusted")),
        "{n:?}"
    );
    let ts = sent_timestamps(&key, &a.update(SECOND, Event::Tick));
    assert!(ts[0] < spec_ts(SECOND) + 100, "{ts:?}");
}

/// Set `path`'s modification time to `EPOCH_UNIX`, as if the wall clock wrote it then.
fn modified_at_epoch(path: &std::path::Path) {
    let file = std::fs::File::options().write(true).open(path).unwrap();
    file.set_modified(
        std::time::SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(EPOCH_UNIX as u64),
    )
    .unwrap();
}

#[test]
fn a_poisoned_state_file_is_repaired_at_start() {
    use mavterm::signing_store::{load_state, signing_config};
    let key = mavproxy_key(PASS);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("signing.json");
    // What the probe left: the end of time, written by a clock that read "now".
    std::fs::write(&path, "{\"timestamp\": 281474976710655}").unwrap();
    modified_at_epoch(&path);
    let cfg = signing_config(PASS, false, Some(path.clone())).unwrap();
    assert_eq!(cfg.saved_timestamp, MAX_TIMESTAMP);
    let (mut a, fx) = app_with_fx(&["udpin:0.0.0.0:14550"], Some(cfg), EPOCH_UNIX);
    let told: Vec<String> = notices(&a)
        .into_iter()
        .filter(|t| t.contains("repaired"))
        .collect();
    assert_eq!(told.len(), 1, "{:?}", notices(&a));
    assert!(
        told[0].contains(&path.display().to_string())
            && told[0].contains("2104-03-13 02:56:07 UTC")
            && told[0].contains("signing setup"),
        "{told:?}"
    );
    assert_eq!(a.report()["signing"]["state_repaired_from"], MAX_TIMESTAMP);
    // The first thing done: our frames at the wall clock, and the file written again.
    let ts = sent_timestamps(&key, &fx);
    assert!(
        !ts.is_empty() && ts.iter().all(|t| *t >= spec_ts(0) && *t < spec_ts(0) + 100),
        "{ts:?}"
    );
    let w: Vec<&Vec<u8>> = fx
        .iter()
        .filter_map(|e| match e {
            Effect::WriteFile { contents, .. } => Some(contents),
            _ => None,
        })
        .collect();
    assert_eq!(w.len(), 1, "{fx:?}");
    std::fs::write(&path, w[0]).unwrap();
    let kept = load_state(&path).unwrap();
    // A reservation of 30 s (3,000,000 units) past the last used, as every run writes.
    assert!(
        kept > ts[0] && kept <= *ts.last().unwrap() + 3_000_000,
        "{kept}"
    );
    // A signed vehicle at the wall clock is taken.
    let hb = sign(&key, 0, spec_ts(2 * SECOND), &[copter_hb(1, 0, 4)]);
    feed(&mut a, 2 * SECOND, 0, &hb[0]);
    assert!(a.vehicles.get(VehicleKey(1, 1)).is_some());

    // Within the limit of the clock that wrote it (a reservation after a crash, 80 s ahead):
    // kept, and ours start after it, silently.
    let ahead = spec_ts(0) + 80 * 100_000;
    std::fs::write(&path, format!("{{\"timestamp\": {ahead}}}")).unwrap();
    modified_at_epoch(&path);
    let cfg = signing_config(PASS, false, Some(path.clone())).unwrap();
    let mut b = app_with(&["udpin:0.0.0.0:14550"], Some(cfg), EPOCH_UNIX);
    assert!(!notices(&b).iter().any(|t| t.contains("repaired")));
    let ts = sent_timestamps(&key, &b.update(SECOND, Event::Tick));
    assert!(ts[0] > ahead, "{ts:?}");
}

#[test]
fn a_vehicle_an_hour_ahead_is_refused_until_signing_setup_gives_it_our_clock() {
    let key = mavproxy_key(PASS);
    let links = ["udpin:0.0.0.0:14550", "serial:/dev/ttyACM0?secure=1"];
    let mut a = app(&links, Some(PASS), false);
    let hour = 60 * MINUTE;
    // Its clock an hour ahead: every frame refused on the radio link, the vehicle not taken.
    let reqs: Vec<Value> = (0..3).map(|i| copter_hb(1, i, 4)).collect();
    let ahead = sign(&key, 0, spec_ts(0) + hour, &reqs);
    for (i, f) in ahead.iter().enumerate() {
        feed(&mut a, 100_000 * (i as u64 + 1), 0, f);
    }
    assert!(a.vehicles.get(VehicleKey(1, 1)).is_none());
    let c = counts(&a, 0, (1, 1));
    assert_eq!(
        (c["future"].as_u64(), c["rejected"].as_u64()),
        (Some(3), Some(3))
    );
    let n = notices(&a);
    let told: Vec<&String> = n.iter().filter(|t| t.contains("from the future")).collect();
    assert_eq!(told.len(), 1, "{n:?}");
    assert!(
        told[0].contains("1 h 00 min ahead") && told[0].contains("signing setup"),
        "what the operator does is said: {told:?}"
    );
    // 50 s ahead (within the minute): taken, and our clock follows it (the guide's rule).
    let near = sign(
        &key,
        1,
        spec_ts(400_000) + 50 * 100_000,
        &[copter_hb(1, 3, 4)],
    );
    feed(&mut a, 400_000, 0, &near[0]);
    assert!(a.vehicles.get(VehicleKey(1, 1)).is_some());
    assert!(a.signing.clock.last() >= spec_ts(400_000) + 50 * 100_000);
    assert!(a.signing.clock.last() <= spec_ts(400_000) + FUTURE_MARGIN);

    // The operator's way out: on the USB link (trusted, so its frames are taken there) send
    // our key with our clock; ArduPilot sets its clock to SETUP_SIGNING's initial_timestamp.
    let usb = sign(&key, 0, spec_ts(0) + hour + 10, &[copter_hb(1, 4, 4)]);
    feed(&mut a, 500_000, 1, &usb[0]);
    command(&mut a, 600_000, "signing setup");
    // The y a little after the question (a key within 0.3 s of it does not answer).
    let fx = keys(&mut a, 1_000_000, &["y"]);
    let sent = setup_signing(&fx);
    assert_eq!(sent.len(), 1, "{fx:?}");
    let (got, _) = verify(&key, &[sent[0].1.clone()]);
    let initial = got[0]["initial_timestamp"].as_u64().unwrap();
    assert!(
        initial < spec_ts(1_000_000) + FUTURE_MARGIN,
        "our clock, not the vehicle's: {initial}"
    );
    // Its frames from that clock on are taken on the radio link too (a new stream: link id 2).
    let after = sign(&key, 2, initial + 1000, &[copter_hb(1, 5, 5)]);
    feed(&mut a, 1_100_000, 0, &after[0]);
    assert_eq!(a.vehicles.get(VehicleKey(1, 1)).unwrap().custom_mode, 5);
}
