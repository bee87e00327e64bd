//! `tlog:` links stream the log from disk: garbage in a damaged log is skipped and counted on the
//! link (as garbage bytes, in the Links pane and the report), every real frame still arrives, and
//! memory does not grow with the log's length.

use std::io::Write;

use mavterm::app::AppConfig;
use mavterm::dialect::{self as apm, MavMessage};
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::source::{TlogSource, VirtualSource};
use mavterm::link::tlog::write_record;
use mavterm::link::LinkSpec;
use mavterm::wire::frame::{encode, Header, Version};

/// 2023-11-14T22:13:20Z, in µs since the Unix epoch.
const T0: u64 = 1_700_000_000_000_000;

fn heartbeat(seq: u8) -> Vec<u8> {
    let msg = MavMessage::HEARTBEAT(apm::HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: apm::MavType::MAV_TYPE_QUADROTOR,
        autopilot: apm::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode: apm::MavModeFlag::empty(),
        system_status: apm::MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
    });
    let h = Header {
        sysid: 1,
        compid: 1,
        seq,
    };
    encode(Version::V2, h, &msg)
}

/// Record `i` of the generated logs: a heartbeat every 100 ms from T0.
fn record(buf: &mut Vec<u8>, i: u64) {
    write_record(buf, T0 + i * 100_000, &heartbeat(i as u8));
}

/// Junk with magic bytes and lengths that fit, but no frame whose CRC checks out.
fn junk(n: usize) -> Vec<u8> {
    (0..n)
        .map(|i| [0xFD, 0xFE, 3, 0, 9, 0xFD, 0x01][i % 7])
        .collect()
}

#[test]
fn garbage_in_a_tlog_is_counted_on_the_link_and_every_frame_arrives() {
    const RECORDS: u64 = 300;
    let mut log = Vec::new();
    let mut inserted = 0;
    for i in 0..RECORDS {
        record(&mut log, i);
        if i == 99 {
            // A bad block: no magic byte in it.
            log.extend([0x42u8; 77]);
            inserted += 77;
        }
        if i == 199 {
            let j = junk(123);
            inserted += j.len() as u64;
            log.extend(j);
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("damaged.tlog");
    std::fs::write(&path, &log).unwrap();
    let spec: LinkSpec = format!("tlog:{}", path.display()).parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    // The replay's epoch is the first record's time.
    assert_eq!(r.app.cfg.epoch.timestamp_micros() as u64, T0);
    // The last record is at 29.9 s.
    r.advance_to(31_000_000);

    assert_eq!(r.source(0).unwrap().skipped(), 200);
    assert_eq!(inserted, 200);
    let report = r.app.report();
    let link = &report["links"][0];
    assert_eq!(link["garbage_bytes"], inserted, "{link}");
    assert_eq!(link["frames"], RECORDS, "{link}");
    assert_eq!(link["crc_errors"], 0, "{link}");
    // The parser saw only the frames: the skipped bytes never reached it.
    assert_eq!(link["bytes"], RECORDS * heartbeat(0).len() as u64, "{link}");
    let src = &link["sources"][0];
    assert_eq!(
        (src["sysid"].as_u64(), src["compid"].as_u64()),
        (Some(1), Some(1))
    );
    assert_eq!(src["received"], RECORDS, "{src}");
    assert_eq!(src["lost"], 0, "{src}");
    assert_eq!(r.app.links[0].parser.garbage_bytes, 200);
}

#[test]
fn a_clean_tlog_counts_no_garbage() {
    let mut log = Vec::new();
    for i in 0..20 {
        record(&mut log, i);
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("clean.tlog");
    std::fs::write(&path, &log).unwrap();
    let spec: LinkSpec = format!("tlog:{}", path.display()).parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    r.advance_to(3_000_000);
    let report = r.app.report();
    assert_eq!(report["links"][0]["garbage_bytes"], 0);
    assert_eq!(report["links"][0]["frames"], 20);
}

#[test]
fn garbage_is_counted_on_a_tlog_link_in_real_time_too() {
    // 10 records over 0.9 s, 55 bytes of garbage between the 5th and 6th, 9 at the end.
    let mut log = Vec::new();
    for i in 0..10 {
        record(&mut log, i);
        if i == 4 {
            log.extend(junk(55));
        }
    }
    log.extend([0x11u8; 9]);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("damaged.tlog");
    std::fs::write(&path, &log).unwrap();
    let spec: LinkSpec = format!("tlog:{}", path.display()).parse().unwrap();
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    // Played in real time to its end (0.9 s of records): waited for, not timed.
    let app = rt.block_on(async {
        use mavterm::driver::real_time::{NoFrontend, RealTime};
        let mut rt = RealTime::start(&[spec], AppConfig::default());
        let hang = rt.now() + 30 * mavterm::clock::SECOND;
        while !matches!(&rt.app.links[0].state, mavterm::app::links::LinkState::Down(r) if r == "end of log")
        {
            assert!(rt.now() < hang, "{:?}", rt.app.links[0].state);
            let t = rt.now() + 50_000;
            let _ = rt.run(Some(t), &mut NoFrontend).await;
        }
        rt.app
    });
    let link = &app.report()["links"][0];
    assert_eq!(link["garbage_bytes"], 55 + 9, "{link}");
    assert_eq!(link["frames"], 10, "{link}");
}

#[test]
fn a_long_tlog_streams_in_constant_memory() {
    const RECORDS: u64 = 200_000; // 5.5 hours at 10 Hz
    const MAX_BUFFERED_BYTES: usize = 256 * 1024;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("long.tlog");
    let mut file = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
    let mut buf = Vec::new();
    for i in 0..RECORDS {
        buf.clear();
        record(&mut buf, i);
        file.write_all(&buf).unwrap();
    }
    file.into_inner().unwrap().sync_all().unwrap();
    let size = std::fs::metadata(&path).unwrap().len();
    assert_eq!(size, RECORDS * (8 + heartbeat(0).len() as u64));
    // The log is many times what may be held.
    assert!(size > 20 * MAX_BUFFERED_BYTES as u64);

    let mut src = TlogSource::open(&path).unwrap();
    assert_eq!(src.buffered_records(), 1);
    let mut frames_bytes = 0u64;
    let mut now = 0;
    while src.next_deadline() != u64::MAX {
        now += 60_000_000;
        frames_bytes += src.poll(now).len() as u64;
        assert!(src.buffered_records() <= 1, "at {now}");
        assert!(
            src.buffered_bytes() <= MAX_BUFFERED_BYTES,
            "{} bytes buffered at {now}",
            src.buffered_bytes()
        );
    }
    assert_eq!(src.emitted(), RECORDS);
    assert_eq!(src.buffered_records(), 0);
    assert_eq!(frames_bytes, RECORDS * heartbeat(0).len() as u64);
    assert_eq!(src.skipped(), 0);
}

/// Not a tlog: its link is down from the start, saying why, and the run goes on to its report
/// (the README's promise: when no link ever came up the report is still printed).
#[test]
fn a_file_without_records_is_a_link_down_saying_why() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("not.tlog");
    std::fs::write(&path, [0x42u8; 1000]).unwrap();
    let spec: LinkSpec = format!("tlog:{}", path.display()).parse().unwrap();
    let r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    let why = r.app.all_links_stayed_down().expect("down");
    assert!(why.contains("no MAVLink records in 1000 bytes"), "{why}");
}
