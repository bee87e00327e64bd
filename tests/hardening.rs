//! Hostile links, vehicles and files (issue 30): each reproduction of the fault probe, bounded.

use mavlink::Message;
use mavterm::app::{App, AppConfig, Effect, Event};
use mavterm::clock::{Micros, SECOND};
use mavterm::dialect::{self, MavMessage};
use mavterm::link::{FrameParser, LinkState, ParserStats};
use mavterm::wire::frame::{encode, Header, Version};

fn heartbeat(sysid: u8, compid: u8, seq: u8) -> Vec<u8> {
    let msg = MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: dialect::MavType::MAV_TYPE_QUADROTOR,
        autopilot: dialect::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode: dialect::MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
        system_status: dialect::MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
    });
    encode(Version::V2, Header { sysid, compid, seq }, &msg)
}

fn feed(app: &mut App, now: Micros, link: usize, bytes: &[u8]) -> Vec<Effect> {
    let frames = FrameParser::new().parse_all(bytes);
    assert!(!frames.is_empty());
    app.update(
        now,
        Event::Frames {
            link,
            frames,
            stats: ParserStats::default(),
        },
    )
}

/// Every message the core sent in `fx`.
fn sent(fx: &[Effect]) -> Vec<MavMessage> {
    fx.iter()
        .filter_map(|e| match e {
            Effect::Send { msg, .. } => Some(msg.clone()),
            _ => None,
        })
        .collect()
}

/// Item 1: a second, unsigned link carrying heartbeats from spoofed ids never takes the
/// target away, never evicts the real vehicle (busy downloading its parameters), starts no
/// parameter download beyond the flood budget, and tells of the flood once.
#[test]
fn a_heartbeat_flood_keeps_the_target_and_the_real_vehicle() {
    let mut a = App::new(AppConfig {
        links: vec!["sim".into(), "udp".into()],
        ..AppConfig::default()
    });
    for link in 0..2 {
        a.update(
            0,
            Event::LinkState {
                link,
                state: LinkState::Up,
            },
        );
    }
    feed(&mut a, 0, 0, &heartbeat(1, 1, 0));
    assert_eq!(a.target, Some((1, 1)));
    let mut list_requests = Vec::new();
    let mut t: Micros = 0;
    let mut seq = 0u8;
    // 20,000 spoofed ids (sysid 2..=80 × compid 1..=255, the probe's flood cut short), 1,000 a
    // batch, 20 ms apart; the real vehicle's heartbeat every second.
    let mut batch = Vec::new();
    let mut n = 0usize;
    for sysid in 2..=80u8 {
        for compid in 1..=255u8 {
            batch.extend(heartbeat(sysid, compid, 0));
            n += 1;
            if n.is_multiple_of(1000) {
                t += 20_000;
                let fx = feed(&mut a, t, 1, &batch);
                batch.clear();
                if t % SECOND < 20_000 {
                    seq = seq.wrapping_add(1);
                    feed(&mut a, t, 0, &heartbeat(1, 1, seq));
                }
                let fx: Vec<Effect> = fx.into_iter().chain(a.update(t, Event::Tick)).collect();
                for m in sent(&fx) {
                    if let Some(s) = m.target_system_id() {
                        list_requests.push(s);
                    }
                }
                assert_eq!(a.target, Some((1, 1)), "target moved at {t} µs");
                assert!(
                    a.vehicles.get((1, 1)).is_some(),
                    "real vehicle evicted at {t}"
                );
            }
        }
    }
    let fakes: Vec<&u8> = list_requests.iter().filter(|s| **s != 1).collect();
    // The budget: the components found before the flood was recognised (16 at most).
    assert!(
        fakes.len() <= 16,
        "{} parameter downloads for spoofed ids",
        fakes.len()
    );
    let floods = a
        .notices
        .iter()
        .filter(|n| n.text.contains("heartbeat flood"))
        .count();
    assert_eq!(floods, 1, "the flood is told once");
    let found = a
        .notices
        .iter()
        .filter(|n| n.text.contains(" found ("))
        .count();
    assert!(found <= 17, "{found} found notices");
    let rep = a.report();
    assert_eq!(rep["heartbeat_floods"], 1, "{}", rep["heartbeat_floods"]);
    assert!(rep["flood_found"].as_u64().unwrap() > 19_000);
}
