//! Forwarding (`--out`), end to end with the mavterm binary: a pymavlink ground station on an
//! output gets every frame mavterm's links heard, byte for byte (the tlog mavterm recorded of the
//! same run is the reference), and its command reaches the simulated vehicle (its mode changes);
//! SETUP_SIGNING goes neither way nor into the log; mavterm's own view is as without outputs. An
//! output nobody listens on, one that refuses, and one that never reads cost the links nothing.

mod common;

use std::io::{BufRead, BufReader, Read};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use mavterm::dialect::{self, MavMessage};
use mavterm::link::tlog::{read_tlog, write_record};
use mavterm::wire::frame::{encode, Header, Version};
use serde_json::Value;

fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

/// Message id of a frame (MAVLink 2 or 1).
fn msgid(f: &[u8]) -> u32 {
    if f[0] == 0xFD {
        u32::from_le_bytes([f[7], f[8], f[9], 0])
    } else {
        f[5] as u32
    }
}

/// Source system of a frame (MAVLink 2 or 1).
fn sysid(f: &[u8]) -> u8 {
    if f[0] == 0xFD {
        f[5]
    } else {
        f[3]
    }
}

/// A replayed vehicle, system 7: heartbeats every 0.5 s for 4 s, and a SETUP_SIGNING at 1 s.
fn vehicle_log(path: &Path) -> Vec<u8> {
    const T0: u64 = 1_700_000_000_000_000;
    let setup = encode(
        Version::V2,
        Header {
            sysid: 7,
            compid: 1,
            seq: 100,
        },
        &MavMessage::SETUP_SIGNING(dialect::SETUP_SIGNING_DATA {
            initial_timestamp: 99,
            target_system: 255,
            target_component: 190,
            secret_key: [0x77; 32],
        }),
    );
    let mut log = Vec::new();
    for i in 0..9u64 {
        write_record(
            &mut log,
            T0 + i * 500_000,
            &common::copter_heartbeat(7, i as u8, 0),
        );
        if i == 2 {
            write_record(&mut log, T0 + i * 500_000 + 1, &setup);
        }
    }
    std::fs::write(path, &log).unwrap();
    setup
}

fn run_mavterm(args: &[String]) -> std::process::Child {
    Command::new(common::mavterm())
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn report(child: std::process::Child) -> Value {
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "mavterm: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn a_ground_station_on_an_output_gets_every_frame_and_commands_the_vehicle() {
    let python = common::python();
    let dir = tempfile::tempdir().unwrap();
    let vehicle = dir.path().join("vehicle7.tlog");
    let vehicle_secret = vehicle_log(&vehicle);
    let tlog = dir.path().join("run.tlog");
    let port = common::free_udp_port();

    let mut gcs_child = common::ChildGuard(
        Command::new(python)
            .arg(common::test_path("py/fwd_gcs.py"))
            .arg(port.to_string())
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap(),
    );
    let mut gcs_out = BufReader::new(gcs_child.0.stdout.take().unwrap());
    let mut line = String::new();
    gcs_out.read_line(&mut line).unwrap();
    assert_eq!(line.trim(), "listening");

    let mavterm = run_mavterm(&[
        "--link".into(),
        "sim://".into(),
        "--link".into(),
        format!("tlog:{}", vehicle.display()),
        "--out".into(),
        format!("udpout:127.0.0.1:{port}"),
        "--tlog".into(),
        tlog.display().to_string(),
        "--headless".into(),
        "--duration".into(),
        "6".into(),
        "--report".into(),
        "json".into(),
    ]);
    let report = report(mavterm);
    // mavterm has exited: the ground station reads what is left and tells.
    {
        use std::io::Write;
        let mut stdin = gcs_child.0.stdin.take().unwrap();
        writeln!(stdin).unwrap();
    }
    let mut text = String::new();
    gcs_out.read_to_string(&mut text).unwrap();
    let gcs: Value = serde_json::from_str(text.trim()).unwrap();
    drop(gcs_child);

    // mavterm's view: the vehicles and links its links gave, the ground station on the output
    // neither a vehicle nor a link; the command's effect seen in the sim's heartbeat.
    let vehicles: Vec<(u64, u64)> = report["vehicles"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| (v["sysid"].as_u64().unwrap(), v["compid"].as_u64().unwrap()))
        .collect();
    assert_eq!(vehicles, [(1, 1), (7, 1)], "{}", report["vehicles"]);
    assert_eq!(report["links"].as_array().unwrap().len(), 2);
    let sim = &report["vehicles"][0];
    assert_eq!(sim["mode"], "GUIDED", "{sim}");
    for l in report["links"].as_array().unwrap() {
        let sources: Vec<u64> = l["sources"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s["sysid"].as_u64().unwrap())
            .collect();
        assert!(!sources.contains(&250), "the GCS counted as a source: {l}");
    }
    let out = &report["outputs"][0];
    assert_eq!(out["state"], "up", "{out}");
    assert_eq!(
        out["dropped"].as_u64(),
        Some(1),
        "its SETUP_SIGNING only: {out}"
    );

    // The ground station: its command acknowledged and obeyed.
    assert_eq!(gcs["bad"], 0, "{}", gcs["bad"]);
    assert!(
        gcs["guided_seen"].as_bool().unwrap(),
        "no GUIDED heartbeat after the command"
    );
    assert_eq!(
        gcs["ack"],
        serde_json::json!({"command": 176, "result": 0}),
        "DO_SET_MODE's ACK"
    );

    // What the ground station got is what mavterm's links heard, byte for byte, in order: the
    // log mavterm recorded holds the same frames (the last few may not have left before exit).
    // Loopback UDP may lose a datagram on a busy machine: what came is in the log in the same
    // order, none made up, none changed.
    let log = read_tlog(&std::fs::read(&tlog).unwrap()).unwrap();
    let heard: Vec<String> = log
        .iter()
        .filter(|r| matches!(sysid(&r.frame), 1 | 7))
        .map(|r| hex(&r.frame))
        .collect();
    let got: Vec<String> = gcs["received"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["hex"].as_str().unwrap().to_string())
        .collect();
    assert!(
        got.len() > 200,
        "{} frames reached the ground station",
        got.len()
    );
    assert!(
        got.len() <= heard.len(),
        "{} heard, {} forwarded",
        heard.len(),
        got.len()
    );
    let mut rest = heard.iter();
    for (i, g) in got.iter().enumerate() {
        assert!(
            rest.any(|h| h == g),
            "frame {i} the ground station got is not next in the log: {g}"
        );
    }
    assert_eq!(out["sent"].as_u64().unwrap(), heard.len() as u64);
    // Both vehicles' frames, and the replayed vehicle's key did not leave.
    assert!(gcs["received"]
        .as_array()
        .unwrap()
        .iter()
        .any(|f| f["sysid"] == 7));
    assert!(!got.contains(&hex(&vehicle_secret)));
    assert!(gcs["received"]
        .as_array()
        .unwrap()
        .iter()
        .all(|f| f["msgid"] != 256));

    // The log: the ground station's frames carried to the vehicles are in it (its command,
    // byte for byte), SETUP_SIGNING from either side is not.
    let logged: Vec<String> = log.iter().map(|r| hex(&r.frame)).collect();
    let command = gcs["sent"]["command"].as_str().unwrap();
    assert!(
        logged.iter().any(|f| f == command),
        "the GCS's command is not in the log"
    );
    assert!(
        log.iter().all(|r| msgid(&r.frame) != 256),
        "SETUP_SIGNING in the log"
    );
    assert!(log.iter().any(|r| sysid(&r.frame) == 250));
    assert_eq!(
        out["received"].as_u64().unwrap(),
        log.iter().filter(|r| sysid(&r.frame) == 250).count() as u64 + 1
    );
}

/// Connect to `port` until it listens, then never read.
fn idle_client(port: u16) -> std::thread::JoinHandle<Option<std::net::TcpStream>> {
    std::thread::spawn(move || {
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(30) {
            if let Ok(s) = std::net::TcpStream::connect(("127.0.0.1", port)) {
                return Some(s);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        None
    })
}

#[test]
fn dead_outputs_cost_the_links_nothing() {
    // Two sims served over TCP, one per run, so both runs are on the wall clock alike.
    let (pa, pb) = (common::free_tcp_port(), common::free_tcp_port());
    let _sa = common::sim_server(pa, "");
    let _sb = common::sim_server(pb, "");
    let dead_udp = common::free_udp_port();
    let refused = common::free_tcp_port();
    let listen = common::free_tcp_port();
    let base = |port: u16| {
        vec![
            "--link".to_string(),
            format!("tcp:127.0.0.1:{port}"),
            "--headless".into(),
            "--duration".into(),
            "4".into(),
            "--report".into(),
            "json".into(),
        ]
    };
    let a = run_mavterm(&base(pa));
    let mut args = base(pb);
    for o in [
        format!("udpout:127.0.0.1:{dead_udp}"),
        format!("tcp:127.0.0.1:{refused}"),
        format!("tcpin:127.0.0.1:{listen}"),
    ] {
        args.push("--out".into());
        args.push(o);
    }
    let b = run_mavterm(&args);
    let client = idle_client(listen);
    let (a, b) = (report(a), report(b));
    let _client = client
        .join()
        .unwrap()
        .expect("the tcpin output never listened");

    let frames = |r: &Value| r["links"][0]["frames"].as_u64().unwrap();
    let (fa, fb) = (frames(&a), frames(&b));
    assert!(fa > 100, "{fa}");
    // The rates the streams came at (from the spacing of their arrivals, so a run that started
    // a little later on a busy machine is not counted short), with dead outputs and without.
    let rate = |r: &Value| -> f64 {
        r["streams"][0]["links"][0]["messages"]
            .as_array()
            .unwrap()
            .iter()
            .map(|m| m["measured_hz"].as_f64().unwrap())
            .sum()
    };
    let (ra, rb) = (rate(&a), rate(&b));
    assert!(ra > 20.0, "{}", a["streams"]);
    assert!(
        rb >= ra * 0.9,
        "with dead outputs {rb:.1} frames/s of streams, without {ra:.1} ({fb} and {fa} frames)"
    );
    assert_eq!(b["links"][0]["dropped"], 0, "{}", b["links"][0]);
    // The same view.
    assert_eq!(
        a["vehicles"].as_array().unwrap().len(),
        b["vehicles"].as_array().unwrap().len()
    );
    assert_eq!(b["links"].as_array().unwrap().len(), 1);

    let outs = b["outputs"].as_array().unwrap();
    assert_eq!(outs.len(), 3, "{}", b["outputs"]);
    // Nobody listens: the datagrams go (and are lost); nothing waits.
    assert_eq!(outs[0]["state"], "up", "{}", outs[0]);
    assert!(
        outs[0]["sent"].as_u64().unwrap() >= fb * 9 / 10,
        "{}",
        outs[0]
    );
    // Refused: down, every frame dropped and counted (but those queued while it was trying).
    assert_eq!(outs[1]["state"], "down", "{}", outs[1]);
    assert!(
        outs[1]["dropped"].as_u64().unwrap() >= fb * 9 / 10,
        "{}",
        outs[1]
    );
    assert!(
        outs[1]["reason"].as_str().unwrap().contains("refused"),
        "{}",
        outs[1]
    );
    // Listening, its one client never reading: frames handed on (the socket's buffers take
    // these few seconds of them) or dropped, never waited for.
    assert_eq!(outs[2]["state"], "up", "{}", outs[2]);
    let (s2, d2) = (
        outs[2]["sent"].as_u64().unwrap(),
        outs[2]["dropped"].as_u64().unwrap(),
    );
    assert!(s2 + d2 >= fb * 9 / 10, "{}", outs[2]);
}
