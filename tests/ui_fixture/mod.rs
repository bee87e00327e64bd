//! Drives an `App` with real encoded frames, for pane tests and the render benchmark.
#![allow(dead_code)]

use std::collections::BTreeMap;

use mavterm::app::links::LinkState;
use mavterm::app::{App, AppConfig, Event};
use mavterm::clock::{Micros, SECOND};
use mavterm::dialect::{self, MavMessage};
use mavterm::link::LinkId;
use mavterm::wire::{frame, FrameParser, Header, Version};

/// 2024-05-01 12:00:00 UTC: a fixed wall clock so screens are reproducible.
pub fn epoch() -> chrono::DateTime<chrono::Utc> {
    chrono::DateTime::from_timestamp(1_714_564_800, 0).unwrap()
}

pub struct Drive {
    pub app: App,
    parsers: Vec<FrameParser>,
    seq: BTreeMap<(LinkId, u8, u8), u8>,
}

impl Drive {
    pub fn new(links: &[&str]) -> Self {
        let cfg = AppConfig {
            links: links.iter().map(|s| s.to_string()).collect(),
            epoch: epoch(),
            request_streams: false,
            fetch_params: false,
            ..AppConfig::default()
        };
        Drive {
            app: App::new(cfg),
            parsers: links.iter().map(|_| FrameParser::new()).collect(),
            seq: BTreeMap::new(),
        }
    }

    /// Feed raw bytes on a link, as a transport would.
    pub fn bytes(&mut self, t: Micros, link: LinkId, bytes: &[u8]) {
        let before = *self.parsers[link].stats();
        let frames = self.parsers[link].parse_all(bytes);
        let stats = self.parsers[link].stats().since(&before);
        self.app.update(
            t,
            Event::Frames {
                link,
                frames,
                stats,
            },
        );
    }

    /// Encode `msg` from `key` with the next sequence number (after skipping `skip`).
    pub fn encode(&mut self, link: LinkId, key: (u8, u8), msg: &MavMessage, skip: u8) -> Vec<u8> {
        let s = self.seq.entry((link, key.0, key.1)).or_insert(0);
        *s = s.wrapping_add(skip);
        let header = Header {
            sysid: key.0,
            compid: key.1,
            seq: *s,
        };
        *s = s.wrapping_add(1);
        frame::encode(Version::V2, header, msg)
    }

    pub fn send(&mut self, t: Micros, link: LinkId, key: (u8, u8), msg: &MavMessage) {
        let b = self.encode(link, key, msg, 0);
        self.bytes(t, link, &b);
    }

    /// Send after `skip` frames that never arrive (loss).
    pub fn send_after_loss(
        &mut self,
        t: Micros,
        link: LinkId,
        key: (u8, u8),
        msg: &MavMessage,
        skip: u8,
    ) {
        let b = self.encode(link, key, msg, skip);
        self.bytes(t, link, &b);
    }

    pub fn link_state(&mut self, t: Micros, link: LinkId, state: LinkState) {
        self.app.update(t, Event::LinkState { link, state });
    }

    pub fn tick(&mut self, t: Micros) {
        self.app.update(t, Event::Tick);
    }

    pub fn key(&mut self, t: Micros, key: &str) {
        self.app.update(t, Event::Key(key.parse().unwrap()));
    }
}

pub fn heartbeat(
    mavtype: dialect::MavType,
    autopilot: dialect::MavAutopilot,
    armed: bool,
    mode: u32,
) -> MavMessage {
    let mut base_mode = dialect::MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
    if armed {
        base_mode |= dialect::MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
    }
    MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
        custom_mode: mode,
        mavtype,
        autopilot,
        base_mode,
        system_status: if armed {
            dialect::MavState::MAV_STATE_ACTIVE
        } else {
            dialect::MavState::MAV_STATE_STANDBY
        },
        mavlink_version: 3,
    })
}

pub fn copter(armed: bool, mode: u32) -> MavMessage {
    heartbeat(
        dialect::MavType::MAV_TYPE_QUADROTOR,
        dialect::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        armed,
        mode,
    )
}

pub fn plane(armed: bool, mode: u32) -> MavMessage {
    heartbeat(
        dialect::MavType::MAV_TYPE_FIXED_WING,
        dialect::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        armed,
        mode,
    )
}

pub fn statustext(severity: dialect::MavSeverity, text: &str) -> MavMessage {
    MavMessage::STATUSTEXT(dialect::STATUSTEXT_DATA {
        severity,
        text: text.into(),
        id: 0,
        chunk_seq: 0,
    })
}

pub fn attitude() -> MavMessage {
    MavMessage::ATTITUDE(dialect::ATTITUDE_DATA::default())
}

pub const LINKS: [&str; 3] = [
    "udpin:0.0.0.0:14550",
    "tcp:127.0.0.1:5760",
    "serial:/dev/ttyUSB0:57600",
];

/// A busy, varied scene at t = 20.9 s: an armed copter (target) with loss on link 0 (expanded),
/// a plane lost at ~13 s, a sysid clash, a component on our GCS sysid, a gimbal, a dead serial
/// link, a CRC error and STATUSTEXT of several severities.
pub fn scene() -> Drive {
    use dialect::MavSeverity::*;
    let mut d = Drive::new(&LINKS);
    d.link_state(0, 0, LinkState::Up);
    d.link_state(0, 1, LinkState::Up);
    d.link_state(
        0,
        2,
        LinkState::Down("No such file or directory (os error 2)".into()),
    );
    let gimbal = heartbeat(
        dialect::MavType::MAV_TYPE_GIMBAL,
        dialect::MavAutopilot::MAV_AUTOPILOT_INVALID,
        false,
        0,
    );
    let texts = [
        (2, MAV_SEVERITY_CRITICAL, "PreArm: GPS not healthy"),
        (5, MAV_SEVERITY_INFO, "EKF3 IMU0 is using GPS"),
        (10, MAV_SEVERITY_INFO, "Arming motors"),
        (12, MAV_SEVERITY_WARNING, "Battery 1 is low 10.2V"),
        (18, MAV_SEVERITY_DEBUG, "Mission: 1 WP"),
        (19, MAV_SEVERITY_EMERGENCY, "Crash: Disarming"),
    ];
    // Everything in time order: the core's clock only moves forward.
    for s in 0..=20u64 {
        let t = s * SECOND;
        let armed = s >= 10;
        d.send(t, 0, (1, 1), &copter(armed, if armed { 4 } else { 0 }));
        d.send(t + 10_000, 0, (1, 154), &gimbal);
        if s <= 8 {
            d.send(t + 20_000, 1, (2, 1), &plane(false, 11));
        }
        d.send(t + 30_000, 1, (255, 1), &copter(false, 0));
        match s {
            // 3:1 is heard first as a copter, then as a plane.
            15 => d.send(t + 40_000, 1, (3, 1), &copter(false, 5)),
            16 => d.send(t + 40_000, 1, (3, 1), &plane(false, 0)),
            17 => {
                // A corrupted frame on link 1.
                let mut bad = d.encode(1, (2, 1), &attitude(), 0);
                let n = bad.len();
                bad[n - 3] ^= 0xFF;
                d.bytes(t + 50_000, 1, &bad);
            }
            _ => {}
        }
        // 4 Hz attitude; every 7th second one frame is lost.
        for i in 1..5u64 {
            let ti = t + i * SECOND / 5;
            if s % 7 == 3 && i == 2 {
                d.send_after_loss(ti, 0, (1, 1), &attitude(), 1);
            } else {
                d.send(ti, 0, (1, 1), &attitude());
            }
            if i == 2 {
                for (ts, sev, text) in texts {
                    if ts == s {
                        d.send(ti + 1000, 0, (1, 1), &statustext(sev, text));
                    }
                }
            }
        }
    }
    d.app.links[0].expanded = true;
    // Every line shown, DEBUG too (as after the severity keys went round once): the panes'
    // tests are about the scene's 17 lines; the default DEBUG floor is tested on its own.
    d.app.ui.msg_filter.hide_debug = false;
    d.tick(20 * SECOND + 900_000);
    d
}

/// `n` copters on 3 links (sysid 1..=n, link = sysid % 3), 1 Hz heartbeat + 10 Hz attitude for
/// `secs` seconds: the render benchmark's load.
pub fn many(n: u8, secs: u64) -> Drive {
    let mut d = Drive::new(&LINKS);
    for l in 0..3 {
        d.link_state(0, l, LinkState::Up);
    }
    for s in 0..secs {
        for k in 0..10u64 {
            let t = s * SECOND + k * SECOND / 10;
            for v in 1..=n {
                let link = v as usize % 3;
                if k == 0 {
                    d.send(t, link, (v, 1), &copter(v % 2 == 0, (v % 6) as u32));
                }
                d.send(t + v as u64, link, (v, 1), &attitude());
            }
        }
    }
    for l in 0..3 {
        d.app.links[l].expanded = true;
    }
    d.tick(secs * SECOND);
    d
}

/// A writer that only counts the bytes a terminal backend emits.
#[derive(Clone, Default)]
pub struct Counting(std::sync::Arc<std::sync::atomic::AtomicU64>);

impl Counting {
    pub fn bytes(&self) -> u64 {
        self.0.load(std::sync::atomic::Ordering::SeqCst)
    }
}

impl std::io::Write for Counting {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.0
            .fetch_add(b.len() as u64, std::sync::atomic::Ordering::SeqCst);
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// A `w`x`h` crossterm terminal writing into a byte counter.
pub fn counting_terminal(
    w: u16,
    h: u16,
) -> (
    ratatui::Terminal<ratatui::backend::CrosstermBackend<Counting>>,
    Counting,
) {
    let out = Counting::default();
    let term = ratatui::Terminal::with_options(
        ratatui::backend::CrosstermBackend::new(out.clone()),
        ratatui::TerminalOptions {
            viewport: ratatui::Viewport::Fixed(ratatui::layout::Rect::new(0, 0, w, h)),
        },
    )
    .unwrap();
    (term, out)
}

/// The links of [`first_contact`]: a listening UDP port, a TCP client to a closed port, two
/// simulators told apart only by their seed, and a serial port.
pub const FIRST_CONTACT_LINKS: [&str; 5] = [
    "udpin:0.0.0.0:14550",
    "tcp:127.0.0.1:5761",
    "sim://?vehicles=1&seed=1",
    "sim://?vehicles=1&seed=2",
    "serial:/dev/serial/by-id/usb-ArduPilot_fmuv3_1E0042-if00:115200",
];

/// What connecting to a closed TCP port says on Linux.
pub const REFUSED: &str = "Connection refused (os error 111) while connecting to 127.0.0.1:5761";

/// First contact at t = 10 s: twelve vehicles (more than an 80x24 Overview lists) on links 0, 2
/// and 3, a copter in STABILIZE, a down TCP link with a long reason, two `sim://` links that
/// differ only in their seed.
pub fn first_contact() -> Drive {
    let mut d = Drive::new(&FIRST_CONTACT_LINKS);
    d.link_state(0, 0, LinkState::Up);
    d.link_state(0, 1, LinkState::Down(REFUSED.into()));
    d.link_state(0, 2, LinkState::Up);
    d.link_state(0, 3, LinkState::Up);
    d.link_state(0, 4, LinkState::Connecting);
    for s in 0..=10u64 {
        let t = s * SECOND;
        for v in 1..=12u8 {
            let link = [0, 2, 3][v as usize % 3];
            let msg = if v % 4 == 0 {
                plane(false, 11)
            } else {
                // Mode 0 is STABILIZE on ArduCopter.
                copter(v == 1, if v == 1 { 4 } else { 0 })
            };
            d.send(t + v as u64 * 1000, link, (v, 1), &msg);
        }
    }
    d.tick(10 * SECOND + 500_000);
    d
}
