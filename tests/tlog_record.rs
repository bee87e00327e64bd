//! The telemetry log mavterm records: pymavlink (as MAVExplorer and mavlogdump use it) reads back
//! every frame heard and sent, byte for byte, with the wall-clock time it was heard or sent;
//! SETUP_SIGNING (the secret key) is never in it; a log that cannot be written is told on screen
//! and the session goes on; the status bar shows the log's name and size, and the Links pane the
//! forwarding outputs.

mod common;

use std::path::Path;
use std::sync::{Arc, Mutex};

use mavterm::app::tap::OutputStatus;
use mavterm::app::{AppConfig, Event};
use mavterm::clock::{Micros, SECOND};
use mavterm::dialect::{self, MavMessage};
use mavterm::driver::record::TlogTarget;
use mavterm::driver::virtual_time::{virtual_epoch, VirtualRunner};
use mavterm::driver::SimSource;
use mavterm::link::source::VirtualSource;
use mavterm::link::{LinkSpec, LinkState};
use mavterm::sim::SimConfig;
use mavterm::wire::frame::{encode, Header, Version};
use serde_json::Value;

/// Bytes that went through a link at once, as the vehicle's side saw them: (time, from the
/// vehicle?, bytes).
type Chunk = (Micros, bool, Vec<u8>);

/// Everything that went through a link.
type Wire = Arc<Mutex<Vec<Chunk>>>;

/// The simulated vehicle, with every byte in and out noted; at 2 s it also sends a
/// SETUP_SIGNING (which is not noted: it must not be in the log).
struct Spy {
    sim: SimSource,
    wire: Wire,
    secret_sent: bool,
}

fn setup_signing() -> Vec<u8> {
    let msg = MavMessage::SETUP_SIGNING(dialect::SETUP_SIGNING_DATA {
        initial_timestamp: 123_456,
        target_system: 255,
        target_component: 190,
        secret_key: [0x5A; 32],
    });
    let h = Header {
        sysid: 1,
        compid: 1,
        seq: 0,
    };
    encode(Version::V2, h, &msg)
}

impl VirtualSource for Spy {
    fn receive(&mut self, now: Micros, bytes: &[u8]) {
        self.wire.lock().unwrap().push((now, false, bytes.to_vec()));
        self.sim.receive(now, bytes);
    }
    fn poll(&mut self, now: Micros) -> Vec<u8> {
        let mut bytes = self.sim.poll(now);
        if !bytes.is_empty() {
            self.wire.lock().unwrap().push((now, true, bytes.clone()));
        }
        if now >= 2 * SECOND && !self.secret_sent {
            self.secret_sent = true;
            bytes.extend(setup_signing());
        }
        bytes
    }
    fn next_deadline(&self) -> Micros {
        if self.secret_sent {
            self.sim.next_deadline()
        } else {
            self.sim.next_deadline().min(2 * SECOND)
        }
    }
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

/// pymavlink's reading of a log: one JSON object per message.
fn pymavlink_read(path: &Path) -> Vec<Value> {
    let out = std::process::Command::new(common::python())
        .arg(common::test_path("py/read_tlog.py"))
        .arg(path)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "read_tlog.py: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

#[test]
fn pymavlink_reads_every_frame_both_ways_with_its_time_and_no_secret() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("session.tlog");
    let wire: Wire = Arc::default();
    let spy = Spy {
        sim: SimSource::new(SimConfig::default()),
        wire: wire.clone(),
        secret_sent: false,
    };
    let cfg = AppConfig {
        links: vec!["sim://".into()],
        epoch: virtual_epoch(),
        ..AppConfig::default()
    };
    let mut r = VirtualRunner::new(cfg, vec![Box::new(spy)]);
    // Our first heartbeat went when the link came up, before the log was opened.
    let before = wire.lock().unwrap().len();
    r.record(&TlogTarget::File(path.clone()));
    r.advance_to(10 * SECOND);
    r.finish_recording();
    let epoch = virtual_epoch().timestamp_micros() as u64;

    let msgs = pymavlink_read(&path);
    assert!(msgs.len() > 500, "{} messages", msgs.len());
    // Walk the wire's chunks in order: each message pymavlink read is the next frame of the
    // chunk at hand, stamped with the chunk's time.
    let wire = wire.lock().unwrap();
    let mut chunks = wire[before..].iter().filter(|c| !c.2.is_empty());
    let mut cur: Option<(&Chunk, usize)> = None;
    let (mut from_vehicle, mut from_us) = (0, 0);
    for (i, m) in msgs.iter().enumerate() {
        assert_ne!(m["type"], "BAD_DATA", "message {i}: {m}");
        assert_ne!(
            m["type"], "SETUP_SIGNING",
            "message {i}: the key was logged"
        );
        if cur.is_none_or(|(c, at)| at == c.2.len()) {
            cur = Some((chunks.next().expect("more in the log than on the wire"), 0));
        }
        let (chunk, at) = cur.as_mut().unwrap();
        let frame = m["hex"].as_str().unwrap();
        let want = hex(&chunk.2[*at..(*at + frame.len() / 2).min(chunk.2.len())]);
        assert_eq!(
            frame, want,
            "message {i} ({m}) is not the next frame on the wire"
        );
        *at += frame.len() / 2;
        let t = m["t_us"].as_u64().unwrap();
        // pymavlink's timestamp is a float of seconds: good to a microsecond.
        assert!(
            t.abs_diff(epoch + chunk.0) <= 1,
            "message {i}: logged at {t}, on the wire at {}",
            epoch + chunk.0
        );
        if chunk.1 {
            from_vehicle += 1;
        } else {
            from_us += 1;
            assert_eq!(
                (&m["sysid"], &m["compid"]),
                (&Value::from(255), &Value::from(190))
            );
        }
    }
    assert!(
        cur.is_none_or(|(c, at)| at == c.2.len()) && chunks.next().is_none(),
        "frames on the wire missing from the log"
    );
    assert!(from_us >= 10, "our frames: {from_us}");
    // The core did get the SETUP_SIGNING: one frame more than the log holds from the vehicle.
    let report = r.app.report();
    assert_eq!(
        report["links"][0]["frames"],
        from_vehicle + 1,
        "{}",
        report["links"][0]
    );
    // The core was told the final size: the file's.
    let size = std::fs::metadata(&path).unwrap().len();
    assert_eq!(report["recording"]["bytes"], size);
    assert_eq!(report["recording"]["error"], Value::Null);
}

fn sim_runner() -> VirtualRunner {
    let spec: LinkSpec = "sim://".parse().unwrap();
    VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap()
}

#[test]
fn a_log_that_cannot_be_opened_is_told_on_screen_and_the_session_goes_on() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("plain-file");
    std::fs::write(&file, b"not a directory").unwrap();
    for target in [
        TlogTarget::File(file.join("x.tlog")),
        TlogTarget::NewIn(file.join("logs")),
    ] {
        let mut r = sim_runner();
        r.record(&target);
        r.advance_to(5 * SECOND);
        let screen = common::screen(&r, 200, 60);
        assert!(
            screen.contains("not recording:") && screen.contains("Not a directory"),
            "{screen}"
        );
        assert!(screen.contains("stopped"), "status bar: {screen}");
        // The vehicle is there and flying data keeps coming.
        assert!(
            screen.contains("1:1") && r.app.vehicles.iter().count() == 1,
            "{screen}"
        );
        let frames = r.app.links[0].parser.frames;
        r.advance_to(7 * SECOND);
        assert!(r.app.links[0].parser.frames > frames);
        assert!(!r.quit_requested());
    }
}

/// A device (or a FIFO) as the log is refused at the start with a notice, and nothing else
/// stops: a FIFO would block the start, a device would swallow the log. (It replaces the test
/// that recorded to /dev/full; the full disk is pinned by the recorder's own test and
/// tests/hardening.rs::a_full_disk_leaves_only_whole_records_in_the_tlog.)
#[cfg(target_os = "linux")]
#[test]
fn a_device_as_the_log_is_refused_with_a_notice_and_nothing_else() {
    let mut r = sim_runner();
    r.record(&TlogTarget::File("/dev/full".into()));
    r.advance_to(2 * SECOND);
    let screen = common::screen(&r, 200, 60);
    assert!(
        screen.contains("not recording: /dev/full: not a regular file"),
        "{screen}"
    );
    assert_eq!(
        r.app
            .notices
            .iter()
            .filter(|n| n.text.contains("not recording"))
            .count(),
        1,
        "told once"
    );
    let frames = r.app.links[0].parser.frames;
    r.advance_to(6 * SECOND);
    assert!(r.app.links[0].parser.frames > frames);
}

#[test]
fn status_bar_shows_the_log_and_the_links_pane_an_output() {
    let dir = tempfile::tempdir().unwrap();
    let mut r = sim_runner();
    r.record(&TlogTarget::File(dir.path().join("flight.tlog")));
    r.advance_to(10 * SECOND);
    // What the edge reports of an output (as the forwarding test sees them for real).
    r.event(Event::Output {
        out: 0,
        status: OutputStatus {
            spec: "udpout:127.0.0.1:14550".into(),
            state: LinkState::Up,
            sent: 1234,
            received: 56,
            dropped: 0,
        },
    });
    r.event(Event::Output {
        out: 1,
        status: OutputStatus {
            spec: "tcp:192.168.1.20:5760".into(),
            state: LinkState::Down("connect 192.168.1.20:5760: Connection refused".into()),
            sent: 0,
            received: 0,
            dropped: 1290,
        },
    });
    r.finish_recording();
    // The size shown is the file's.
    let size = std::fs::metadata(dir.path().join("flight.tlog"))
        .unwrap()
        .len();
    assert_eq!(r.app.recording.as_ref().unwrap().bytes, size);
    let shown = mavterm::ui::fmt::size(size);
    // The temporary directory's name changes every run: a fixed one in its place, as wide.
    let tmp = format!("{}/flight.tlog", dir.path().display());
    let fixed = format!("{:<w$}", "/tmp/t/flight.tlog", w = tmp.len());
    let wide = common::screen(&r, 200, 60).replace(&tmp, &fixed);
    assert!(wide.contains(&format!("log flight.tlog {shown}")), "{wide}");
    insta::assert_snapshot!("recording_and_outputs_200x60", wide);
    let narrow = common::screen(&r, 80, 24).replace(&tmp, &fixed);
    insta::assert_snapshot!("recording_and_outputs_80x24", narrow);
}

fn cli(args: &[&str]) -> Result<mavterm::cli::Cli, clap::Error> {
    use clap::Parser;
    mavterm::cli::Cli::try_parse_from(std::iter::once("mavterm").chain(args.iter().copied()))
}

#[test]
fn who_records_by_default() {
    let links = |c: &mavterm::cli::Cli| c.links(&Default::default());
    let target = |args: &[&str]| {
        let c = cli(args).unwrap();
        c.tlog_target(&links(&c)).unwrap()
    };
    // The terminal UI records into the data directory's logs, a new file each time.
    match target(&[]) {
        Some(TlogTarget::NewIn(dir)) => assert!(dir.ends_with("mavterm/logs"), "{dir:?}"),
        other => panic!("{other:?}"),
    }
    match target(&["--link", "udpin:0.0.0.0:14550", "--link", "tlog:x.tlog"]) {
        Some(TlogTarget::NewIn(_)) => {}
        other => panic!("{other:?}"),
    }
    // Not: headless runs, replays only, --no-tlog.
    assert_eq!(target(&["--headless", "--report", "json"]), None);
    assert_eq!(
        target(&["--link", "tlog:a.tlog", "--link", "tlog:b.tlog"]),
        None
    );
    assert_eq!(target(&["--no-tlog"]), None);
    // --tlog FILE: there, headless too.
    assert_eq!(
        target(&["--headless", "--tlog", "out.tlog"]),
        Some(TlogTarget::File("out.tlog".into()))
    );
    assert!(cli(&["--tlog", "a.tlog", "--no-tlog"]).is_err());
    // Outputs reach ground stations: not the sim nor a replay.
    assert!(cli(&["--out", "sim://"]).is_err());
    assert!(cli(&["--out", "tlog:x.tlog"]).is_err());
    let c = cli(&[
        "--out",
        "udpout:127.0.0.1:14550",
        "--out",
        "tcpin:0.0.0.0:5760",
    ])
    .unwrap();
    let outs: Vec<String> = c.outs.iter().map(|o| o.to_string()).collect();
    assert_eq!(outs, ["udpout:127.0.0.1:14550", "tcpin:0.0.0.0:5760"]);
}
