//! `tlog:FILE?speed=N` as a link: a log written by pymavlink and the real capture replay with
//! pymavlink's counts, paced by their timestamps on the virtual clock (speed 1 = real time,
//! 0 = as fast as possible), to the end of the log (the link then says so), deterministic
//! screens, the replay keys (pause, step, seek, speed), a bounded seek index, and the same
//! replay in real time losing nothing.

mod common;

use std::collections::BTreeMap;
use std::path::PathBuf;

use mavterm::app::links::LinkState;
use mavterm::app::AppConfig;
use mavterm::clock::{Micros, SECOND};
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::keymap::Key;
use mavterm::link::replay::{ReplayCmd, ReplaySpeed};
use mavterm::link::source::{TlogSource, VirtualSource, SEEK_INDEX_MAX};
use mavterm::link::LinkSpec;
use serde_json::Value;

/// A log written and counted by pymavlink (tests/py/write_tlog.py): its path and pymavlink's
/// reading of it.
struct PyLog {
    _dir: tempfile::TempDir,
    path: PathBuf,
    info: Value,
}

impl PyLog {
    fn write(seconds: u32) -> Self {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("py.tlog");
        let out = std::process::Command::new(common::python())
            .arg(common::test_path("py/write_tlog.py"))
            .arg(&path)
            .arg(seconds.to_string())
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "write_tlog.py: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let info = serde_json::from_slice(&out.stdout).unwrap();
        Self {
            _dir: dir,
            path,
            info,
        }
    }

    fn first_us(&self) -> u64 {
        self.info["first_us"].as_u64().unwrap()
    }

    /// Log time of pymavlink's STATUSTEXT, since the first record.
    fn statustext_at(&self) -> Micros {
        self.info["statustext_us"].as_u64().unwrap() - self.first_us()
    }

    fn frames(&self) -> u64 {
        self.info["frames"].as_u64().unwrap()
    }

    fn types(&self) -> BTreeMap<String, u64> {
        counts(&self.info["types"])
    }

    fn spec(&self, query: &str) -> LinkSpec {
        format!("tlog:{}{query}", self.path.display())
            .parse()
            .unwrap()
    }
}

fn counts(v: &Value) -> BTreeMap<String, u64> {
    v.as_object()
        .unwrap()
        .iter()
        .map(|(k, v)| (k.clone(), v.as_u64().unwrap()))
        .collect()
}

fn data(name: &str) -> PathBuf {
    common::test_path(&format!("data/{name}"))
}

fn runner(spec: LinkSpec) -> VirtualRunner {
    VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap()
}

/// Messages per type the core handled from `sysid:compid` (the Inspector's counts).
fn core_types(r: &VirtualRunner, source: (u8, u8)) -> BTreeMap<String, u64> {
    let mut out = BTreeMap::new();
    for ((s, c, _), e) in r.app.inspector.iter() {
        if (s, c) == source {
            *out.entry(e.name.to_string()).or_default() += e.count;
        }
    }
    out
}

fn frames(r: &VirtualRunner) -> u64 {
    r.app.links[0].parser.frames
}

/// The core time the notice containing `text` was made at.
fn notice_at(r: &VirtualRunner, text: &str) -> Micros {
    r.app
        .notices
        .iter()
        .find(|n| n.text.contains(text))
        .unwrap_or_else(|| panic!("no notice `{text}`"))
        .t
}

#[test]
fn a_pymavlink_log_replays_with_pymavlink_counts_to_its_end() {
    let log = PyLog::write(60);
    let mut r = runner(log.spec(""));
    assert!(r.run_to_end_of_replays(u64::MAX));
    assert_eq!(core_types(&r, (1, 1)), log.types());
    let rep = r.app.report();
    let link = &rep["links"][0];
    assert_eq!(link["frames"], log.frames(), "{link}");
    assert_eq!(link["sources"][0]["received"], log.frames(), "{link}");
    assert_eq!(link["sources"][0]["lost"], 0, "{link}");
    // At speed 1 the last record (pymavlink's last timestamp) arrives at its own log time, and
    // the link then says the log ended.
    let last = log.info["last_us"].as_u64().unwrap() - log.first_us();
    assert_eq!(r.now(), last);
    assert_eq!(link["state"], "down", "{link}");
    assert_eq!(link["reason"], "end of log", "{link}");
    assert_eq!(link["replay"]["ended"], true, "{link}");
    assert_eq!(link["replay"]["position_s"], last as f64 / 1e6, "{link}");
    assert_eq!(link["replay"]["duration_s"], last as f64 / 1e6, "{link}");
    assert_eq!(
        r.app.links[0].state,
        LinkState::Down("end of log".to_string())
    );
    // The vehicle goes lost by the normal timeout after its last heartbeat.
    assert_eq!(rep["vehicles"][0]["lost"], false);
    r.advance_to(last + 6 * SECOND);
    assert_eq!(r.app.report()["vehicles"][0]["lost"], true);
}

#[test]
fn the_flight_capture_replays_with_pymavlink_counts_as_fast_as_possible() {
    let exp: Value =
        serde_json::from_str(&std::fs::read_to_string(data("expected.json")).unwrap()).unwrap();
    let e = &exp["copter-flight.vehicle.tlog"];
    let spec: LinkSpec = format!(
        "tlog:{}?speed=0",
        data("copter-flight.vehicle.tlog").display()
    )
    .parse()
    .unwrap();
    let mut r = runner(spec);
    assert!(r.run_to_end_of_replays(u64::MAX));
    assert_eq!(core_types(&r, (1, 1)), counts(&e["types"]));
    let link = &r.app.report()["links"][0];
    assert_eq!(link["frames"], e["frames"], "{link}");
    assert_eq!(
        link["sources"][0]["received"], e["sources"]["1:1"],
        "{link}"
    );
    assert_eq!(link["sources"][0]["lost"], e["sequence_gaps"], "{link}");
    assert_eq!(link["reason"], "end of log", "{link}");
    // 81.8 s of log went by without the virtual clock moving (a few µs of spin guard at most).
    assert!(r.now() < 1000, "virtual clock at {} µs", r.now());
}

#[test]
fn frames_arrive_at_their_log_time_divided_by_the_speed() {
    let log = PyLog::write(12);
    let at = log.statustext_at();
    assert_eq!(at, 5 * SECOND, "pymavlink stamped it at T0 + 5 s");
    for (query, want) in [
        ("", at),
        ("?speed=1", at),
        ("?speed=2", at / 2),
        ("?speed=0.5", at * 2),
        ("?speed=4", at / 4),
    ] {
        let mut r = runner(log.spec(query));
        r.advance_to(want - 1);
        assert!(
            !r.app
                .notices
                .iter()
                .any(|n| n.text.contains("five seconds")),
            "{query}: early"
        );
        r.advance_to(want + 20 * SECOND);
        assert_eq!(notice_at(&r, "five seconds in"), want, "{query}");
    }
    // As fast as possible: everything at virtual time 0, the clock not moved by the log's span.
    let mut r = runner(log.spec("?speed=0"));
    r.advance_to(0);
    assert_eq!(frames(&r), log.frames());
    assert!(notice_at(&r, "five seconds in") < 1000);
    assert!(r.now() < 1000);
}

/// Records of the pymavlink log at or before log time `t`: 16 a second (1 HEARTBEAT,
/// 1 SYS_STATUS, 10 ATTITUDE, 4 GLOBAL_POSITION_INT), at 25 ms ticks, plus the STATUSTEXT at 5 s.
fn records_by(t: Micros) -> u64 {
    let ticks = t / 25_000;
    let n = |every: u64| ticks / every + 1;
    2 * n(40) + n(4) + n(10) + u64::from(t >= 5 * SECOND)
}

#[test]
fn keys_pause_step_seek_and_change_speed_on_the_virtual_clock() {
    let log = PyLog::write(60);
    // The count by time agrees with pymavlink's count of the whole log.
    assert_eq!(records_by(59_975_000), log.frames());
    let mut r = runner(log.spec(""));
    r.advance_to(10 * SECOND);
    assert_eq!(frames(&r), records_by(10 * SECOND));

    // P pauses: nothing more arrives however long we wait.
    r.key(Key::ch('P'));
    r.advance_to(30 * SECOND);
    assert_eq!(frames(&r), records_by(10 * SECOND));
    let st = &r.app.links[0].replay.as_ref().unwrap().status;
    assert!(st.paused);
    assert_eq!(st.position, 10 * SECOND);

    // `.` hands on exactly the next record (ATTITUDE at 10.1 s), and stays paused.
    r.key(Key::ch('.'));
    r.advance_to(31 * SECOND);
    assert_eq!(frames(&r), records_by(10 * SECOND) + 1);
    let st = &r.app.links[0].replay.as_ref().unwrap().status;
    assert!(st.paused);
    assert_eq!(st.position, 10_100_000);

    // `]` seeks 10 s on, handing on nothing it passes over; P plays from there.
    r.key(Key::ch(']'));
    r.advance_to(32 * SECOND);
    assert_eq!(frames(&r), records_by(10 * SECOND) + 1);
    assert_eq!(
        r.app.links[0].replay.as_ref().unwrap().status.position,
        20_100_000
    );
    r.key(Key::ch('P'));
    r.advance_to(37 * SECOND);
    let skipped = records_by(20_099_999) - records_by(10_100_000);
    assert_eq!(frames(&r), records_by(25_100_000) - skipped);
    // What was skipped is not loss, nor a reboot.
    let rep = r.app.report();
    assert_eq!(rep["links"][0]["sources"][0]["lost"], 0, "{rep}");
    assert_eq!(rep["vehicles"][0]["reboots"], 0, "{rep}");

    // `[` seeks 10 s back: the records from 15.1 s come again.
    r.key(Key::ch('['));
    let before = frames(&r);
    r.advance_to(42 * SECOND);
    assert_eq!(
        frames(&r) - before,
        records_by(20_100_000) - records_by(15_099_999)
    );
    let rep = r.app.report();
    assert_eq!(rep["links"][0]["sources"][0]["lost"], 0, "{rep}");
    assert_eq!(rep["vehicles"][0]["reboots"], 0, "{rep}");

    // `+` doubles the speed: 5 s of core time play 10 s of log.
    r.key(Key::ch('+'));
    let before = frames(&r);
    r.advance_to(47 * SECOND);
    assert_eq!(
        frames(&r) - before,
        records_by(30_100_000) - records_by(20_100_000)
    );
    let st = &r.app.links[0].replay.as_ref().unwrap().status;
    assert_eq!(st.speed.get(), 2.0);
    // `-` twice: half speed, 4 s of core time play 2 s of log.
    r.key(Key::ch('-'));
    r.key(Key::ch('-'));
    let before = frames(&r);
    r.advance_to(51 * SECOND);
    assert_eq!(
        frames(&r) - before,
        records_by(32_100_000) - records_by(30_100_000)
    );
    assert_eq!(
        r.app.links[0].replay.as_ref().unwrap().status.speed.get(),
        0.5
    );
}

#[test]
fn the_replay_command_controls_every_replay_and_says_what_it_did() {
    let log = PyLog::write(20);
    let mut r = runner(log.spec(""));
    r.advance_to(2 * SECOND);
    for c in ":replay seek 0:12\n".chars() {
        r.key(if c == '\n' {
            Key::plain(mavterm::keymap::KeyCode::Enter)
        } else {
            Key::ch(c)
        });
    }
    assert_eq!(
        r.app.ui.message.as_ref().map(|m| m.1.as_str()),
        Some("replay: seek to 00:12")
    );
    r.advance_to(3 * SECOND);
    let view = r.app.links[0].replay.as_ref().unwrap();
    assert_eq!(view.position(r.now()), 13 * SECOND);
    assert_eq!(view.status.seeks, 1);
    // Keys on a run without a replay link say so.
    let sim: LinkSpec = "sim://".parse().unwrap();
    let mut s = runner(sim);
    s.advance_to(SECOND);
    s.key(Key::ch('P'));
    assert_eq!(
        s.app.ui.message.as_ref().map(|m| m.1.as_str()),
        Some("no replay link (tlog:FILE)")
    );
}

#[test]
fn the_status_bar_shows_where_the_replay_is() {
    let spec: LinkSpec = "tlog:tests/data/copter-flight.vehicle.tlog"
        .parse()
        .unwrap();
    let mut r = runner(spec);
    r.advance_to(20 * SECOND);
    r.key(Key::ch('+'));
    r.advance_to(25 * SECOND);
    r.key(Key::ch('P'));
    r.advance_to(30 * SECOND);
    let screen =
        mavterm::headless::replay::screen_text(&r.app, (80, 24), &mavterm::ui::Theme::PLAIN);
    let status = screen.lines().last().unwrap();
    // 20 s at ×1 and 5 s at ×2: 30 s into an 81.8 s log, paused.
    assert!(status.contains("replay 00:30/01:21 ×2 paused"), "{status}");
    insta::assert_snapshot!("replay_paused_80x24", screen);
}

/// Run the mavterm binary headless; its stdout.
fn mavterm(args: &[&str]) -> String {
    let out = std::process::Command::new(common::mavterm())
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "mavterm {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn a_headless_report_runs_to_the_end_of_the_log_unless_told_a_duration() {
    let link = "tlog:tests/data/copter-flight.vehicle.tlog";
    let full: Value = serde_json::from_str(&mavterm(&[
        "--headless",
        "--report",
        "json",
        "--link",
        link,
    ]))
    .unwrap();
    let l = &full["links"][0];
    assert_eq!(l["frames"], 11648, "{l}");
    assert_eq!(
        (&l["state"], &l["reason"]),
        (&"down".into(), &"end of log".into())
    );
    let short: Value = serde_json::from_str(&mavterm(&[
        "--headless",
        "--report",
        "json",
        "--duration",
        "10",
        "--link",
        link,
    ]))
    .unwrap();
    let l = &short["links"][0];
    assert!(l["frames"].as_u64().unwrap() < 11648, "{l}");
    assert_eq!(l["state"], "up", "{l}");
}

#[test]
fn a_headless_script_on_a_tlog_gives_the_same_screens_twice() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("keys.txt");
    std::fs::write(
        &script,
        "5 snapshot playing\n6 key P\n8 snapshot paused\n8.5 key .\n9 key ]\n\
         10 snapshot seeked\n11 key P\n11.5 key +\n15 snapshot faster\n16 key [\n\
         20 snapshot back\n",
    )
    .unwrap();
    let run = || {
        mavterm(&[
            "--headless",
            "--input",
            script.to_str().unwrap(),
            "--size",
            "80x24",
            "--link",
            "tlog:tests/data/copter-flight.vehicle.tlog",
        ])
    };
    let a = run();
    let b = run();
    assert_eq!(
        a, b,
        "the same script on the same log gives the same screens"
    );
    let snap = |name: &str| {
        let s = a.split(&format!("=== snapshot {name} ")).nth(1).unwrap();
        s.lines().nth(24).unwrap().to_string()
    };
    assert!(snap("playing").contains("replay 00:05/01:21 ×1 "), "{a}");
    assert!(
        snap("paused").contains("replay 00:06/01:21 ×1 paused"),
        "{a}"
    );
    assert!(snap("faster").contains("×2"), "{}", snap("faster"));
}

#[test]
fn seeking_a_long_log_keeps_memory_bounded_and_lands_where_asked() {
    use std::io::Write;
    const RECORDS: u64 = 200_000; // 5.5 hours at 10 Hz
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("long.tlog");
    let mut file = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
    let mut buf = Vec::new();
    for i in 0..RECORDS {
        buf.clear();
        mavterm::link::tlog::write_record(
            &mut buf,
            1_700_000_000_000_000 + i * 100_000,
            &common::copter_heartbeat(1, i as u8, 0),
        );
        file.write_all(&buf).unwrap();
    }
    file.into_inner().unwrap().sync_all().unwrap();
    let mut src = TlogSource::open(&path)
        .unwrap()
        .with_speed(ReplaySpeed::MAX);
    // Its duration, from the last record, without reading the log through.
    let st = src.replay_status().unwrap();
    assert_eq!(st.duration, Some((RECORDS - 1) * 100_000));
    // Play it all, then seek all over it: forward past what was read, back, to the start.
    let mut now = 0;
    while src.next_deadline() != u64::MAX {
        src.poll(now);
        now += 1;
    }
    assert_eq!(src.emitted(), RECORDS);
    assert!(src.index().len() <= SEEK_INDEX_MAX);
    for target_s in [5000u64, 100, 19_000, 0, 7777, 12_345, 3] {
        src.control(now, ReplayCmd::SeekTo(target_s * SECOND));
        src.control(now, ReplayCmd::Pause);
        src.control(now, ReplayCmd::Step(1));
        let bytes = src.poll(now);
        // The record at the target: heartbeat number target × 10.
        let i = target_s * 10;
        assert_eq!(
            bytes,
            common::copter_heartbeat(1, i as u8, 0),
            "at {target_s} s"
        );
        assert!(
            src.buffered_bytes() <= 256 * 1024,
            "{}",
            src.buffered_bytes()
        );
        assert!(src.buffered_records() <= 1);
        assert!(src.index().len() <= SEEK_INDEX_MAX);
        src.control(now, ReplayCmd::Resume);
        now += 1;
    }
    // A stream cannot seek back, and says so.
    let mut stream = TlogSource::from_reader(std::fs::File::open(&path).unwrap()).unwrap();
    stream.poll(0);
    stream.poll(10 * SECOND);
    stream.take_status(10 * SECOND);
    stream.control(10 * SECOND, ReplayCmd::Seek(-5 * SECOND as i64));
    let st = stream.take_status(10 * SECOND).unwrap();
    assert!(st.note.unwrap().contains("stream"));
    assert_eq!(st.duration, None);
}

#[test]
fn a_replay_in_real_time_as_fast_as_possible_loses_nothing_and_ends() {
    let log = PyLog::write(600); // 15,361 frames
    let spec = log.spec("?speed=0");
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let app = rt.block_on(async {
        let mut rt = mavterm::driver::real_time::RealTime::start(&[spec], AppConfig::default());
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
        loop {
            let until = rt.now() + 200_000;
            let _ = rt
                .run(Some(until), &mut mavterm::driver::real_time::NoFrontend)
                .await;
            let ended = rt.app.links[0]
                .replay
                .as_ref()
                .is_some_and(|v| v.status.ended);
            if ended || std::time::Instant::now() > deadline {
                break;
            }
        }
        rt.app
    });
    let link = &app.report()["links"][0];
    assert_eq!(link["frames"], log.frames(), "{link}");
    assert_eq!(link["dropped"], 0, "{link}");
    assert_eq!(link["reason"], "end of log", "{link}");
    let mut types = BTreeMap::new();
    for (_, e) in app.inspector.iter() {
        *types.entry(e.name.to_string()).or_default() += e.count;
    }
    assert_eq!(types, log.types());
}

#[test]
fn a_replay_in_real_time_pauses_and_seeks_on_the_keys() {
    let log = PyLog::write(60);
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        use mavterm::driver::real_time::{NoFrontend, RealTime};
        let mut rt = RealTime::start(&[log.spec("")], AppConfig::default());
        let t = rt.now() + 300_000;
        let _ = rt.run(Some(t), &mut NoFrontend).await;
        rt.step(mavterm::app::Event::Key(Key::ch('P')));
        // Once the link says it is paused, nothing more comes.
        let mut waited = 0;
        while !rt.app.links[0]
            .replay
            .as_ref()
            .is_some_and(|v| v.status.paused)
        {
            let t = rt.now() + 50_000;
            let _ = rt.run(Some(t), &mut NoFrontend).await;
            waited += 1;
            // 30 s: only against a hang.
            assert!(waited < 600, "no paused status");
        }
        let n = rt.app.links[0].parser.frames;
        assert!(n > 0);
        let t = rt.now() + 500_000;
        let _ = rt.run(Some(t), &mut NoFrontend).await;
        assert_eq!(rt.app.links[0].parser.frames, n);
        // Play again, and seek 5 s on while playing (80 frames: a gap the sequence numbers
        // would show as loss): what was passed over is not loss.
        rt.step(mavterm::app::Event::Key(Key::ch('P')));
        let t = rt.now() + 300_000;
        let _ = rt.run(Some(t), &mut NoFrontend).await;
        for c in ":replay seek +5\n".chars() {
            let k = match c {
                '\n' => Key::plain(mavterm::keymap::KeyCode::Enter),
                c => Key::ch(c),
            };
            rt.step(mavterm::app::Event::Key(k));
        }
        let t = rt.now() + 500_000;
        let _ = rt.run(Some(t), &mut NoFrontend).await;
        let rep = rt.app.report();
        let link = &rep["links"][0];
        assert!(link["frames"].as_u64().unwrap() > n, "{link}");
        assert_eq!(link["replay"]["paused"], false, "{link}");
        assert!(
            link["replay"]["position_s"].as_f64().unwrap() > 5.0,
            "{link}"
        );
        assert_eq!(link["sources"][0]["lost"], 0, "{link}");
        assert_eq!(rep["vehicles"][0]["reboots"], 0, "{rep}");
    });
}
