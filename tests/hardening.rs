//! Hostile links, vehicles and files (issue 30): each reproduction of the fault probe, bounded.

mod common;

use mavlink::Message;
use mavterm::app::{App, AppConfig, Effect, Event};
use mavterm::clock::{Micros, SECOND};
use mavterm::dialect::{self, MavMessage};
use mavterm::link::{FrameParser, LinkState, ParserStats};
use mavterm::proto::vehicles::VehicleKey;
use mavterm::wire::frame::{encode, Header, Version};

fn heartbeat(sysid: u8, compid: u8, seq: u8) -> Vec<u8> {
    common::copter_heartbeat_from(sysid, compid, seq, 0)
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

use common::sent_messages as sent;

/// Item 1: a second, unsigned link carrying heartbeats from spoofed ids never takes the
/// target away, never evicts the real vehicle (busy downloading its parameters), starts no
/// parameter download beyond the flood budget, and tells of the flood once.
#[test]
fn a_heartbeat_flood_keeps_the_target_and_the_real_vehicle() {
    let mut a = two_links();
    feed(&mut a, 0, 0, &heartbeat(1, 1, 0));
    assert_eq!(a.target, Some(VehicleKey(1, 1)));
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
                assert_eq!(a.target, Some(VehicleKey(1, 1)), "target moved at {t} µs");
                assert!(
                    a.vehicles.get(VehicleKey(1, 1)).is_some(),
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

fn param_value(name: &[u8], value: f32, count: u16, index: u16) -> Vec<u8> {
    let mut id = [0u8; 16];
    id[..name.len()].copy_from_slice(name);
    let msg = MavMessage::PARAM_VALUE(dialect::PARAM_VALUE_DATA {
        param_value: value,
        param_count: count,
        param_index: index,
        param_id: id.into(),
        param_type: dialect::MavParamType::MAV_PARAM_TYPE_REAL32,
    });
    encode(
        Version::V2,
        Header {
            sysid: 1,
            compid: 1,
            seq: index as u8,
        },
        &msg,
    )
}

fn press(a: &mut App, now: Micros, keys: &[&str]) -> Vec<Effect> {
    let mut fx = Vec::new();
    for k in keys {
        fx.extend(a.update(now, Event::Key(k.parse().unwrap())));
    }
    fx
}

fn command(a: &mut App, now: Micros, line: &str) -> Vec<Effect> {
    let mut fx = press(a, now, &[":"]);
    for c in line.chars() {
        fx.extend(a.update(now, Event::Key(mavterm::keymap::Key::ch(c))));
    }
    fx.extend(press(a, now, &["enter"]));
    fx
}

/// Item 4: names that are not 1–16 printable ASCII characters without spaces (a newline that
/// would inject a line, an escape sequence, a tab, `#`, a space, bytes that are not UTF-8) are
/// refused, counted and shown escaped; the download completes without them and the saved
/// `.parm` holds only real names.
#[test]
fn hostile_parameter_names_are_refused_and_never_reach_a_file() {
    let mut a = App::new(AppConfig {
        links: vec!["test".into()],
        request_streams: false,
        ..AppConfig::default()
    });
    a.update(
        0,
        Event::LinkState {
            link: 0,
            state: LinkState::Up,
        },
    );
    feed(&mut a, 0, 0, &heartbeat(1, 1, 0));
    a.update(SECOND, Event::Tick);
    let names: [&[u8]; 8] = [
        b"RTL_ALT",
        b"X\nRTL_ALT 1",
        b"\x1b[2JCLEAR",
        b"TAB\tX",
        b"HASH#X",
        b"SPACE X",
        b"\xff\xfe",
        b"WPNAV_SPEED",
    ];
    let count = names.len() as u16;
    for (i, n) in names.iter().enumerate() {
        feed(
            &mut a,
            2 * SECOND,
            0,
            &param_value(n, 1500.0 + i as f32, count, i as u16),
        );
    }
    a.update(3 * SECOND, Event::Tick);
    let set = a.sessions[&VehicleKey(1, 1)].params.autopilot().unwrap();
    let kept: Vec<&str> = set.params.keys().map(|k| k.as_str()).collect();
    assert_eq!(kept, ["RTL_ALT", "WPNAV_SPEED"]);
    assert_eq!(set.refused, 6);
    a.ui.screen = "parameters";
    let text = mavterm::headless::replay::screen_text(&a, (80, 24), &Default::default());
    assert!(text.contains("6 names refused"), "{text}");
    let rep = a.report();
    assert_eq!(
        rep["params"][0]["components"][0]["refused_names"], 6,
        "{}",
        rep["params"]
    );
    // Not stalled: every index is accounted for.
    assert!(set.complete(), "{:?}", set.progress());
    let told: Vec<&str> = a
        .notices
        .iter()
        .map(|n| n.text.as_str())
        .filter(|t| t.contains("parameter name refused"))
        .collect();
    assert_eq!(told.len(), 3, "{told:?}");
    assert!(told[0].ends_with(r#""X\nRTL_ALT 1""#), "{}", told[0]);
    assert!(told[1].contains(r#""\x1b[2JCLEAR""#), "{}", told[1]);
    for t in &told {
        assert!(!t.chars().any(|c| c.is_control()), "{t:?}");
    }
    let fx = command(&mut a, 4 * SECOND, "param save keep.parm");
    let text = fx
        .iter()
        .find_map(|e| match e {
            Effect::WriteFile { contents, .. } => {
                Some(String::from_utf8(contents.clone()).unwrap())
            }
            _ => None,
        })
        .expect("a file written");
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 2, "{text}");
    assert!(lines[0].starts_with("RTL_ALT ") && lines[1].starts_with("WPNAV_SPEED "));
    assert!(!text.contains("RTL_ALT 1\n"), "{text}");
}

/// Item 8: a save replaces a regular file only, keeps its mode, follows a symlink (the link
/// stays, the file it points to is replaced), refuses a FIFO or a device, and never touches a
/// user's file named like a temporary.
#[cfg(unix)]
#[test]
fn atomic_saves_keep_links_modes_special_files_and_other_files() {
    use mavterm::driver::write_atomic;
    use std::os::unix::fs::{FileTypeExt, PermissionsExt};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A user's own file with the name the old temporary had.
    std::fs::write(d.join("keep.tmp~"), "mine").unwrap();
    write_atomic(&d.join("keep.parm"), b"A 1\n").unwrap();
    write_atomic(&d.join("keep.waypoints"), b"QGC WPL 110\n").unwrap();
    assert_eq!(
        std::fs::read_to_string(d.join("keep.tmp~")).unwrap(),
        "mine"
    );
    assert_eq!(
        std::fs::read_to_string(d.join("keep.parm")).unwrap(),
        "A 1\n"
    );

    // Mode 600 stays 600.
    let private = d.join("private.parm");
    std::fs::write(&private, "old").unwrap();
    std::fs::set_permissions(&private, std::fs::Permissions::from_mode(0o600)).unwrap();
    write_atomic(&private, b"new").unwrap();
    let mode = std::fs::metadata(&private).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, 0o600);

    // A symlink is followed: the link stays, its file holds the new text.
    std::fs::write(d.join("real.parm"), "old").unwrap();
    std::os::unix::fs::symlink(d.join("real.parm"), d.join("link.parm")).unwrap();
    write_atomic(&d.join("link.parm"), b"new").unwrap();
    assert!(std::fs::symlink_metadata(d.join("link.parm"))
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(std::fs::read_to_string(d.join("real.parm")).unwrap(), "new");

    // A link to a device is refused, and the link is not replaced by a file.
    std::os::unix::fs::symlink("/dev/null", d.join("null.parm")).unwrap();
    assert!(write_atomic(&d.join("null.parm"), b"x").is_err());
    assert!(std::fs::symlink_metadata(d.join("null.parm"))
        .unwrap()
        .file_type()
        .is_symlink());

    // A FIFO is refused (without blocking) and stays a FIFO.
    let fifo = d.join("fifo.parm");
    common::mkfifo(&fifo);
    assert!(write_atomic(&fifo, b"x").is_err());
    assert!(std::fs::symlink_metadata(&fifo)
        .unwrap()
        .file_type()
        .is_fifo());

    // Nothing left behind: exactly the files made above.
    let mut names: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "fifo.parm",
            "keep.parm",
            "keep.tmp~",
            "keep.waypoints",
            "link.parm",
            "null.parm",
            "private.parm",
            "real.parm"
        ]
    );
}

/// Item 7: the `:` line holds at most 4,096 characters however many are typed (100,000 here:
/// the probe's quadratic case, now O(1) a key), a paste is one event typed into the line (its
/// newline runs nothing), and `esc` after it still closes the prompt.
#[test]
fn the_prompt_line_is_bounded_and_a_paste_is_one_event() {
    use mavterm::app::input::MAX_LINE;
    use mavterm::keymap::{Key, Mode};
    assert_eq!(MAX_LINE, 4096);
    let mut a = App::new(AppConfig {
        links: vec!["test".into()],
        ..AppConfig::default()
    });
    press(&mut a, 0, &[":"]);
    for i in 0..100_000u32 {
        a.update(0, Event::Key(Key::ch(char::from(b'a' + (i % 26) as u8))));
    }
    assert_eq!(a.ui.prompt.line.text.chars().count(), MAX_LINE);
    assert!(a
        .ui
        .prompt
        .line
        .text
        .starts_with("abcdefghijklmnopqrstuvwxyzab"));
    press(&mut a, 0, &["esc"]);
    assert_eq!(a.ui.mode, Mode::Normal);

    // A paste: one event; the newline inside it does not run `quit`.
    press(&mut a, 0, &[":"]);
    let fx = a.update(0, Event::Paste("wp lo\nquit\r\x1bx".into()));
    assert!(!fx.iter().any(|e| matches!(e, Effect::Quit)));
    assert_eq!(a.ui.mode, Mode::Prompt);
    assert_eq!(a.ui.prompt.line.text, "wp lo quit x");
    // ~1 kB more, then keys still work.
    a.update(0, Event::Paste("y".repeat(1100)));
    assert_eq!(a.ui.prompt.line.text.len(), 12 + 1100);
    press(&mut a, 0, &["esc"]);
    assert_eq!(a.ui.mode, Mode::Normal);
    press(&mut a, 0, &["q"]);
    assert!(a.quit);
}

/// Item 6: `param load` (and `wp load`) of a FIFO is refused before it is opened: the run goes
/// on, the operator is told why. (On today's code the open blocks for ever: the guard below
/// turns that hang into a failure.)
#[cfg(unix)]
#[test]
fn loading_a_fifo_is_refused_without_blocking() {
    use mavterm::driver::virtual_time::VirtualRunner;
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("x.parm");
    common::mkfifo(&fifo);
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let spec = "sim://".parse().unwrap();
        let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
        r.advance_to(SECOND);
        for line in [
            format!("param load {}", fifo.display()),
            format!("wp load {}", fifo.display()),
        ] {
            r.key(":".parse().unwrap());
            for c in line.chars() {
                r.key(mavterm::keymap::Key::ch(c));
            }
            r.key("enter".parse().unwrap());
            let t = r.now() + SECOND;
            r.advance_to(t);
        }
        let told: Vec<String> = r
            .app
            .notices
            .iter()
            .map(|n| n.text.clone())
            .filter(|t| t.contains("not a regular file"))
            .collect();
        let _ = tx.send(told);
    });
    let told = rx
        .recv_timeout(std::time::Duration::from_secs(60))
        .expect("the load of a FIFO hung");
    assert_eq!(told.len(), 2, "{told:?}");
}

/// Item 5: one flipped bit in a record's timestamp (a jump of ~3 days forward, and back) is
/// skipped, not waited for: the whole capture replays, every frame counted; `tlog:/dev/zero` is
/// refused at once and a file with no MAVLink records still gives a report, its link down and
/// why. (The guard turns today's stall into a failure.)
#[test]
fn a_timestamp_jump_in_a_tlog_is_skipped_and_bad_files_still_report() {
    use mavterm::driver::virtual_time::VirtualRunner;
    use mavterm::link::tlog::read_tlog;
    let bytes = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/copter-mavftp-params.vehicle.tlog"
    ))
    .unwrap();
    let records = read_tlog(&bytes).unwrap();
    let total = records.len();
    assert!(total > 50, "{total}");
    let at: usize = records[..10].iter().map(|r| 8 + r.frame.len()).sum();
    let mut flipped = bytes.clone();
    flipped[at + 3] ^= 0x40; // bit 38 of the big-endian µs: 2^38 µs ≈ 3.2 days
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("flipped.tlog");
    std::fs::write(&path, &flipped).unwrap();
    let junk = dir.path().join("junk.tlog");
    std::fs::write(&junk, [0x42u8; 1000]).unwrap();

    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        // At the default speed (real time, on the virtual clock), so the log's time counts: a
        // jump waited for would be days of virtual time.
        let spec = format!("tlog:{}", path.display()).parse().unwrap();
        let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
        r.run_to_end_of_replays(u64::MAX);
        let played = r.app.report();
        let specs = [
            "tlog:/dev/zero".parse().unwrap(),
            format!("tlog:{}", junk.display()).parse().unwrap(),
        ];
        let mut bad = VirtualRunner::from_specs(&specs, AppConfig::default()).unwrap();
        bad.advance_to(10 * SECOND);
        let _ = tx.send((played, bad.app.report(), bad.app.all_links_stayed_down()));
    });
    let (played, bad, down) = rx
        .recv_timeout(std::time::Duration::from_secs(60))
        .expect("the replay stalled");
    let frames = played["links"][0]["frames"].as_u64().unwrap();
    assert_eq!(frames, total as u64, "{}", played["links"][0]);
    assert_eq!(played["links"][0]["replay"]["ended"], true);
    // The log's own span of virtual time went by (not days): the jump was skipped.
    let span = (records[total - 1].time_us - records[0].time_us) as f64 / 1e6;
    let took = played["duration_s"].as_f64().unwrap();
    assert!(
        took >= span * 0.5 && took <= span + 10.0,
        "{took} s for a {span} s log"
    );
    assert_eq!(bad["links"][0]["state"], "down");
    let state = |i: usize| bad["links"][i]["reason"].as_str().unwrap().to_string();
    assert!(state(0).contains("not a regular file"), "{}", state(0));
    assert!(
        state(1).contains("no MAVLink records in 1000 bytes"),
        "{}",
        state(1)
    );
    assert!(down.is_some_and(|d| d.contains("all links stayed down")));
}

/// What a hostile MAVFTP vehicle streams after acknowledging the open of a 2,000-byte file.
fn hostile_burst(offset_of: impl Fn(u32) -> u32) -> (Option<String>, u64, Option<u32>, Micros) {
    use mavterm::proto::param_ftp::{FtpOut, FtpRead};
    use mavterm::wire::mavftp::{op, FtpPacket};
    let ack = |req: u8, offset: u32, data: Vec<u8>| FtpPacket {
        seq: 0,
        session: 1,
        opcode: op::ACK,
        size: data.len() as u8,
        req_opcode: req,
        burst_complete: 0,
        offset,
        data,
    };
    let (mut r, _) = FtpRead::start(0, "@PARAM/param.pck");
    let mut out = r.on_packet(
        10_000,
        &ack(op::OPEN_FILE_RO, 0, 2000u32.to_le_bytes().to_vec()),
    );
    let mut failed = None;
    // 20 Hz for two minutes of virtual time, whatever mavterm asks.
    for i in 0..2400u32 {
        let now = 20_000 + i as Micros * 50_000;
        out.extend(r.poll(now));
        out.extend(r.on_packet(
            now,
            &ack(op::BURST_READ_FILE, offset_of(i), vec![0x55; 239]),
        ));
        if let Some(why) = out.iter().find_map(|o| match o {
            FtpOut::Failed(w) => Some(w.clone()),
            _ => None,
        }) {
            failed = Some(why);
            let (bytes, size) = r.progress();
            return (failed, bytes, size, now);
        }
        out.clear();
    }
    let (bytes, size) = r.progress();
    (failed, bytes, size, 0)
}

/// Item 3: a burst that never ends (offsets beyond the file, unaligned, or the same in-range
/// block over and over, `burst_complete` never set) is not progress: with nothing new for
/// 10 s the read fails, so the download falls back to the parameter protocol; the bytes counted
/// never exceed the file's size.
#[test]
fn a_mavftp_burst_without_useful_progress_falls_back() {
    for (what, f) in [
        (
            "beyond the file",
            Box::new(|i: u32| 239 * (100 + i)) as Box<dyn Fn(u32) -> u32>,
        ),
        ("unaligned", Box::new(|i: u32| 17 + i)),
        ("in range, repeated", Box::new(|_| 0)),
    ] {
        let (failed, bytes, size, at) = hostile_burst(f);
        let why = failed.unwrap_or_else(|| panic!("{what}: never fell back"));
        assert!(
            at <= 20 * SECOND,
            "{what}: fell back only at {at} µs ({why})"
        );
        assert!(
            bytes <= size.unwrap_or(0) as u64,
            "{what}: {bytes} of {size:?}"
        );
    }
}

/// CAMERA_CAPTURE_STATUS (262) saying `image_count` images were taken.
fn capture_status(image_count: i32) -> Vec<u8> {
    let mut p = vec![0u8; 22];
    p[18..22].copy_from_slice(&image_count.to_le_bytes());
    p
}

/// Item 2: a camera whose `image_count` rises by 1,000 at 20 Hz (no image ever sent) keeps the
/// missing-image bookkeeping bounded: the newest 256 indices looked at, at most 16 requests
/// waiting, the holes asked for never more than the window.
#[test]
fn a_runaway_image_count_keeps_hole_tracking_bounded() {
    use mavterm::proto::camera::{CameraSet, HOLE_QUEUE, HOLE_SPAN};
    let mut s = CameraSet::default();
    s.on_message(0, 100, 0, Some(30), &[]);
    let mut most = (0, 0);
    for i in 1..=1200i32 {
        let now = i as Micros * 50_000;
        s.on_message(now, 100, 262, None, &capture_status(i * 1000));
        s.poll(now);
        let _ = s.next_deadline();
        // The command queue takes one request a message.
        if !s.heads().is_empty() {
            s.sent(100);
        }
        let c = &s.cameras[&100];
        let (asked, pending) = c.hole_tracking();
        most = (most.0.max(asked), most.1.max(pending));
        assert!(c.missing().len() <= HOLE_SPAN as usize);
    }
    assert!(most.0 <= HOLE_SPAN as usize, "{most:?}");
    assert!(most.1 <= HOLE_QUEUE + 8, "{most:?}");
    // The newest holes are the ones asked for.
    let c = &s.cameras[&100];
    assert!(c.missing().contains(&(1_200_000 - 1)));
    let asked_newest = s
        .heads()
        .iter()
        .any(|(_, cmd, p)| *cmd == 512 && p[0] == 263.0 && p[1] as i32 >= 1_200_000 - HOLE_SPAN);
    assert!(asked_newest, "{:?}", s.heads());
}

/// Item 9: `--report json` with `--params-out` prints the report as well as writing the file.
#[test]
fn params_out_with_report_json_prints_the_report() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.parm");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_mavterm"))
        .args(["--headless", "--link", "sim://", "--report", "json"])
        .arg("--params-out")
        .arg(&out)
        .env("HOME", dir.path())
        .env("XDG_CONFIG_HOME", dir.path())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(out.exists(), "{err}");
    let stdout = String::from_utf8(o.stdout).unwrap();
    let rep: serde_json::Value = serde_json::from_str(stdout.trim()).expect("a JSON report");
    assert_eq!(
        rep["params"][0]["components"][0]["complete"], true,
        "{}",
        rep["params"]
    );
}

/// Item 9: a disk that fills mid-record (a file-size limit here, its signal ignored, so the
/// write fails with EFBIG as with ENOSPC) leaves only whole records in the tlog.
#[cfg(unix)]
#[test]
fn a_full_disk_leaves_only_whole_records_in_the_tlog() {
    use mavterm::link::tlog::read_tlog_counted;
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("x.tlog");
    let o = std::process::Command::new("sh")
        .arg("-c")
        .arg(r#"trap '' XFSZ; ulimit -f 8; exec "$0" --headless --link sim:// --tlog "$1" --duration 120 --report json"#)
        .arg(env!("CARGO_BIN_EXE_mavterm"))
        .arg(&log)
        .env("HOME", dir.path())
        .env("XDG_CONFIG_HOME", dir.path())
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    let rep: serde_json::Value = serde_json::from_str(out.trim()).expect("a report");
    assert!(
        rep["recording"]["error"].is_string(),
        "{}",
        rep["recording"]
    );
    let bytes = std::fs::read(&log).unwrap();
    assert!(bytes.len() <= 4096 && !bytes.is_empty(), "{}", bytes.len());
    let (records, skipped) = read_tlog_counted(&bytes).unwrap();
    assert!(!records.is_empty());
    assert_eq!(skipped.bytes, 0, "a partial record at the end");
}

/// Item 9: a client flooding a `tcpin` forwarding output while the core does not keep up: at
/// most [`OUTPUT_QUEUE`] reports (each one read's frames) wait, the rest is dropped and counted,
/// so memory stays bounded (the outputs' manager is started with this queue).
#[test]
fn a_flooded_output_queues_a_bounded_number_of_reports() {
    use mavterm::link::manager::{LinkManager, OUTPUT_QUEUE};
    use mavterm::link::transport::LinkEvent;
    use std::io::Write;
    let port = {
        let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        l.local_addr().unwrap().port()
    };
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .unwrap();
    let spec = format!("tcpin:127.0.0.1:{port}").parse().unwrap();
    let mut m = rt.block_on(async {
        LinkManager::start_queued(&[spec], mavterm::driver::local_sources(), OUTPUT_QUEUE)
    });
    let mut client = loop {
        if let Ok(c) = std::net::TcpStream::connect(("127.0.0.1", port)) {
            break c;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    // 4 MB of heartbeats, nobody draining the queue.
    let blob: Vec<u8> = (0..10_000).flat_map(|i| heartbeat(9, 1, i as u8)).collect();
    for _ in 0..20 {
        client.write_all(&blob).unwrap();
    }
    std::thread::sleep(std::time::Duration::from_millis(500));
    let (mut reports, mut dropped) = (0usize, 0u64);
    rt.block_on(async {
        while let Ok(Some((_, ev))) =
            tokio::time::timeout(std::time::Duration::from_millis(300), m.next_event()).await
        {
            match ev {
                LinkEvent::Frames { .. } => reports += 1,
                LinkEvent::Dropped(n) => dropped += n,
                _ => {}
            }
            if reports > 10 * OUTPUT_QUEUE {
                break;
            }
        }
    });
    // All 4 MB were read (write_all returned) but only the queue's worth waited; what did not
    // fit is counted with the next report.
    let _ = dropped;
    assert!(
        reports <= OUTPUT_QUEUE + 2,
        "{reports} reports were waiting"
    );
}

fn heartbeat_of(
    sysid: u8,
    compid: u8,
    mavtype: dialect::MavType,
    autopilot: dialect::MavAutopilot,
) -> Vec<u8> {
    let msg = MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype,
        autopilot,
        base_mode: dialect::MavModeFlag::empty(),
        system_status: dialect::MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
    });
    encode(
        Version::V2,
        Header {
            sysid,
            compid,
            seq: 0,
        },
        &msg,
    )
}

fn two_links() -> App {
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
    a
}

/// Item 1 (round two): a camera alone on its system is the target; a (spoofed) autopilot
/// heartbeat on its sysid neither takes the target away nor drops the camera's session.
#[test]
fn the_target_stays_on_a_payload_when_an_autopilot_appears_on_its_sysid() {
    let mut a = two_links();
    feed(
        &mut a,
        0,
        0,
        &heartbeat_of(
            5,
            100,
            dialect::MavType::MAV_TYPE_CAMERA,
            dialect::MavAutopilot::MAV_AUTOPILOT_INVALID,
        ),
    );
    assert_eq!(a.target, Some(VehicleKey(5, 100)));
    feed(&mut a, SECOND, 1, &heartbeat(5, 1, 0));
    assert_eq!(a.target, Some(VehicleKey(5, 100)), "the target moved");
    assert!(
        a.sessions.contains_key(&VehicleKey(5, 100)),
        "the target's session was dropped"
    );
    // Later vehicles take no target either.
    feed(&mut a, 2 * SECOND, 1, &heartbeat(6, 1, 0));
    assert_eq!(a.target, Some(VehicleKey(5, 100)));
}

/// Item 1 (round two): new autopilots arriving below the flood threshold (one every 2 s, 40 of
/// them) get automatic starts for the first AUTO_FREE (8) and then at most AUTO_BUDGET (4) a
/// minute.
#[test]
fn a_trickle_of_new_autopilots_starts_at_most_the_budget() {
    let mut a = two_links();
    let mut asked = std::collections::BTreeSet::new();
    let mut t: Micros = 0;
    for sysid in 10..50u8 {
        t += 2 * SECOND;
        let fx = feed(&mut a, t, 1, &heartbeat(sysid, 1, 0));
        let fx: Vec<Effect> = fx.into_iter().chain(a.update(t, Event::Tick)).collect();
        for m in sent(&fx) {
            if let Some(s) = m.target_system_id() {
                asked.insert(s);
            }
        }
    }
    assert_eq!(a.report()["heartbeat_floods"], 0, "no flood was seen");
    // 80 s: 8 free, then 4 in each of two minutes.
    assert!(
        asked.len() <= 8 + 2 * 4,
        "{} autopilots got requests",
        asked.len()
    );
    assert!(asked.len() >= 8, "the first autopilots got their requests");
}

/// Item 1 (round two): a vehicle that is not the target but has work in flight (its
/// parameters downloading) survives a flood that fills the table.
#[test]
fn a_busy_non_target_vehicle_survives_a_flood() {
    let mut a = two_links();
    feed(&mut a, 0, 0, &heartbeat(1, 1, 0));
    feed(&mut a, 0, 0, &heartbeat(2, 1, 0));
    a.update(0, Event::Tick);
    assert_eq!(a.target, Some(VehicleKey(1, 1)));
    assert!(a.sessions[&VehicleKey(2, 1)].params.downloading().is_some());
    let mut t: Micros = 0;
    let mut batch = Vec::new();
    for sysid in 100..=110u8 {
        for compid in 1..=255u8 {
            batch.extend(heartbeat(sysid, compid, 0));
        }
        t += 20_000;
        feed(&mut a, t, 1, &batch);
        batch.clear();
        a.update(t, Event::Tick);
        assert!(
            a.vehicles.get(VehicleKey(2, 1)).is_some(),
            "busy vehicle evicted at {t}"
        );
    }
    assert_eq!(a.target, Some(VehicleKey(1, 1)));
}

/// Item 6 (round two): a FIFO given as `--input`, `--keymap` or `--config` is refused at once,
/// the error naming the path (the guard turns a hang on the FIFO's open into a failure).
#[cfg(unix)]
#[test]
fn a_fifo_as_input_keymap_or_config_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe");
    common::mkfifo(&fifo);
    let script = dir.path().join("empty.txt");
    std::fs::write(&script, "").unwrap();
    let f = fifo.to_str().unwrap();
    let s = script.to_str().unwrap();
    let cases: [Vec<&str>; 3] = [
        vec!["--headless", "--link", "sim://", "--input", f],
        vec![
            "--headless",
            "--link",
            "sim://",
            "--input",
            s,
            "--keymap",
            f,
        ],
        vec![
            "--headless",
            "--link",
            "sim://",
            "--report",
            "json",
            "--config",
            f,
        ],
    ];
    for args in cases {
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_mavterm"))
            .args(&args)
            .env("HOME", dir.path())
            .env("XDG_CONFIG_HOME", dir.path())
            .stdin(std::process::Stdio::null())
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let mut status = None;
        for _ in 0..600 {
            if let Some(st) = child.try_wait().unwrap() {
                status = Some(st);
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(100));
        }
        let Some(status) = status else {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{args:?}: hung on the FIFO");
        };
        let mut err = String::new();
        use std::io::Read;
        child
            .stderr
            .take()
            .unwrap()
            .read_to_string(&mut err)
            .unwrap();
        assert!(!status.success(), "{args:?}: {err}");
        assert!(err.contains(f), "{args:?}: the error names the path: {err}");
        assert!(err.contains("not a regular file"), "{args:?}: {err}");
    }
}

/// Item 7 (round two): a bracketed paste goes into the palette's search and the parameter
/// search, not only into the `:` line.
#[test]
fn a_paste_reaches_the_palette_and_the_parameter_search() {
    use mavterm::keymap::Mode;
    let mut a = App::new(AppConfig {
        links: vec!["test".into()],
        ..AppConfig::default()
    });
    press(&mut a, 0, &["ctrl-p"]);
    assert!(a.ui.palette.is_some());
    a.update(0, Event::Paste("takeoff".into()));
    let p = a.ui.palette.as_ref().unwrap();
    assert_eq!(p.query.text, "takeoff");
    assert!(!p.matches.is_empty());
    press(&mut a, 0, &["esc"]);
    a.ui.palette = None;
    a.ui.mode = Mode::Normal;
    a.ui.screen = "parameters";
    press(&mut a, 0, &["/"]);
    assert_eq!(a.ui.mode, Mode::Edit);
    a.update(0, Event::Paste("RTL_".into()));
    assert_eq!(a.ui.params.filter, "RTL_");
}

/// Item 5 (round two): a file whose first MiBs hold no record is refused at open, not read
/// whole: here 6 MiB of garbage before a real record (which a full scan would find).
#[test]
fn a_tlog_starting_with_mibs_of_garbage_is_refused_at_open() {
    use mavterm::link::source::{TlogSource, OPEN_GIVE_UP};
    let log = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/copter-mavftp-params.vehicle.tlog"
    ))
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("junk.tlog");
    let mut bytes = vec![0x55u8; 6 * 1024 * 1024];
    bytes.extend_from_slice(&log[..4096]);
    std::fs::write(&path, &bytes).unwrap();
    let Err(e) = TlogSource::open(&path) else {
        panic!("a file of garbage opened");
    };
    let text = e.to_string();
    assert!(text.contains("no MAVLink records"), "{text}");
    // The real log still opens.
    let ok = dir.path().join("ok.tlog");
    std::fs::write(&ok, &log).unwrap();
    assert!(TlogSource::open(&ok).is_ok());
    const { assert!(OPEN_GIVE_UP < 6 * 1024 * 1024) };
}
