//! The core against senders that do not behave like ArduPilot: constant sequence numbers,
//! enum values newer than our dialect; and operator-facing rules (Ctrl-C, link-down notices).

mod common;

use mavterm::app::links::LinkState;
use mavterm::app::{App, AppConfig, Effect, Event};
use mavterm::clock::SECOND;
use mavterm::keymap::{Key, Keymap};
use mavterm::link::{FrameParser, ParserStats};
use mavterm::proto::vehicles::VehicleKey;
use mavterm::wire::frame::frame_crc;

fn app() -> App {
    App::new(AppConfig {
        links: vec!["test".into()],
        ..AppConfig::default()
    })
}

fn heartbeat(seq: u8, mode: u32) -> Vec<u8> {
    common::copter_heartbeat(1, seq, mode)
}

fn feed(app: &mut App, now: u64, bytes: &[u8]) {
    let frames = FrameParser::new().parse_all(bytes);
    app.update(
        now,
        Event::Frames {
            link: 0,
            frames,
            stats: ParserStats::default(),
        },
    );
}

#[test]
fn a_sender_with_a_constant_sequence_is_still_heard() {
    let mut a = app();
    for i in 0..10u64 {
        feed(&mut a, i * SECOND, &heartbeat(0, if i < 5 { 0 } else { 4 }));
    }
    a.update(10 * SECOND, Event::Tick);
    let v = a.vehicles.get(VehicleKey(1, 1)).unwrap();
    assert!(!v.lost);
    assert_eq!(v.heartbeats, 10);
    assert_eq!(v.mode_name(), "GUIDED");
    // The sequence statistics still say what happened.
    assert_eq!(a.links[0].sources[&VehicleKey(1, 1)].seq.duplicates, 9);
}

#[test]
fn a_true_duplicate_is_not_read_twice() {
    let mut a = app();
    let f = heartbeat(7, 0);
    let mut both = f.clone();
    both.extend(&f);
    feed(&mut a, 0, &both);
    assert_eq!(a.vehicles.get(VehicleKey(1, 1)).unwrap().heartbeats, 1);
}

#[test]
fn heartbeat_with_enum_values_newer_than_our_dialect_still_lists_the_component() {
    let mut f = heartbeat(0, 0);
    f[10 + 4] = 250; // MAV_TYPE unknown to the dialect
    let n = f.len();
    let crc = frame_crc(&f[1..n - 2], 50);
    f[n - 2..].copy_from_slice(&crc.to_le_bytes());
    let mut a = app();
    feed(&mut a, 0, &f);
    assert_eq!(a.links[0].sources[&VehicleKey(1, 1)].seq.received, 1);
    let v = a.vehicles.get(VehicleKey(1, 1)).expect("listed");
    assert_eq!(v.type_name(), "GENERIC");
    assert_eq!(v.autopilot_name(), "ARDUPILOTMEGA");
}

#[test]
fn ctrl_c_quits_whatever_the_keymap() {
    let mut a = app();
    a.keymap = Keymap::from_toml("[bindings]\nquit = [\"x\"]\n", "test").unwrap();
    let fx = a.update(0, Event::Key(Key::ctrl('c')));
    assert!(fx.contains(&Effect::Quit));
}

fn set_state(a: &mut App, now: u64, state: LinkState) {
    a.update(now, Event::LinkState { link: 0, state });
}

fn down_notices(a: &App) -> usize {
    a.notices
        .iter()
        .filter(|n| n.text.contains("down: refused"))
        .count()
}

#[test]
fn a_link_failing_the_same_way_is_reported_once() {
    let mut a = app();
    for i in 0..5 {
        set_state(&mut a, i, LinkState::Connecting);
        set_state(&mut a, i, LinkState::Down("refused".into()));
    }
    assert_eq!(down_notices(&a), 1);
    set_state(&mut a, 9, LinkState::Up);
    set_state(&mut a, 10, LinkState::Down("refused".into()));
    assert_eq!(down_notices(&a), 2);
}
