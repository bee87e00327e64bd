//! The JSON report says what the bounded tables and queues let go: frames dropped, our own frames
//! echoed back, sources evicted per link, and vehicles evicted.

mod common;

use mavterm::app::links::MAX_SOURCES;
use mavterm::app::{App, AppConfig, Effect, Event};
use mavterm::clock::SECOND;
use mavterm::dialect::MavMessage;
use mavterm::link::{FrameParser, LinkState, ParserStats};
use mavterm::proto::vehicles::MAX_COMPONENTS;

fn heartbeat(sysid: u8, compid: u8, seq: u8) -> Vec<u8> {
    common::copter_heartbeat_from(sysid, compid, seq, 0)
}

fn feed(app: &mut App, now: u64, bytes: &[u8]) -> Vec<Effect> {
    let frames = FrameParser::new().parse_all(bytes);
    assert!(!frames.is_empty());
    app.update(
        now,
        Event::Frames {
            link: 0,
            frames,
            stats: ParserStats::default(),
        },
    )
}

use common::sent_frames as sent;

#[test]
fn report_counts_drops_echoes_and_evictions() {
    // The limits the counts below are worked out from.
    assert_eq!(MAX_SOURCES, 256);
    assert_eq!(MAX_COMPONENTS, 512);
    let mut a = App::new(AppConfig {
        links: vec!["test".into()],
        request_streams: false,
        fetch_params: false,
        ..AppConfig::default()
    });
    let mut ours = sent(&a.update(
        0,
        Event::LinkState {
            link: 0,
            state: LinkState::Up,
        },
    ));
    ours.extend(sent(&a.update(0, Event::Tick)));

    // Nothing let go yet: every counter is there, at zero.
    let rep = a.report();
    for field in ["dropped", "echoes", "evicted_sources"] {
        assert_eq!(rep["links"][0][field], 0, "{field}: {rep}");
    }
    assert_eq!(rep["vehicles_evicted"], 0, "{rep}");

    // 600 components (sysid 1..=150, compid 1 to 4), one heartbeat each, 5 ms apart: a link
    // keeps 256 sources (344 evicted), the registry 512 components (88 evicted).
    let mut t = 0;
    for sysid in 1..=150u8 {
        for compid in 1..=4u8 {
            t += 5_000;
            ours.extend(sent(&feed(&mut a, t, &heartbeat(sysid, compid, 0))));
        }
    }
    // Our GCS heartbeats (1 Hz) from the first 3 s, and router echoes of them.
    for s in 1..=3 {
        ours.extend(sent(&a.update(s * SECOND + 500_000, Event::Tick)));
    }
    let gcs_heartbeats: Vec<&Vec<u8>> = ours
        .iter()
        .filter(|f| {
            let fr = FrameParser::new().parse_all(f);
            matches!(fr[0].message.as_deref(), Some(MavMessage::HEARTBEAT(_)))
        })
        .collect();
    assert!(gcs_heartbeats.len() >= 3, "{}", gcs_heartbeats.len());
    for f in &gcs_heartbeats[..3] {
        feed(&mut a, 4 * SECOND, f);
    }
    a.update(4 * SECOND, Event::Dropped { link: 0, frames: 5 });
    a.update(4 * SECOND, Event::Dropped { link: 0, frames: 2 });

    let rep = a.report();
    let link = &rep["links"][0];
    assert_eq!(link["dropped"], 7, "{link}");
    assert_eq!(link["echoes"], 3, "{link}");
    assert_eq!(link["evicted_sources"], 600 - 256, "{link}");
    assert_eq!(link["sources"].as_array().unwrap().len(), 256);
    assert_eq!(rep["vehicles_evicted"], 600 - 512, "{rep}");
    assert_eq!(rep["vehicles"].as_array().unwrap().len(), 512);
    // Echoes are not sources nor vehicles: our own 255:190 is in neither.
    assert!(!link["sources"]
        .as_array()
        .unwrap()
        .iter()
        .any(|s| s["sysid"] == 255));
}
