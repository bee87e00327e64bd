//! Onboard logs on the simulated vehicle (`sim://`, virtual clock): the list (completed when
//! LOG_ENTRY frames are lost), downloads at 0, 20 and 40 % loss byte-identical to the sim's
//! logs, resume from the partial on disk, cancel (LOG_REQUEST_END), erase (asked first), the
//! Logs screen, the high-latency link left alone, a partial of another log, the status bar,
//! LOG_REQUEST_END on quitting.

mod common;

use common::{command, keys, sim, wait};

use std::sync::{Arc, Mutex};

use mavterm::app::{AppConfig, Event};
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::source::VirtualSource;
use mavterm::link::{LinkSpec, LinkState};
use mavterm::proto::logs::State;
use mavterm::proto::vehicles::VehicleKey;
use mavterm::sim::logs::{catalogue, content};

const SECOND: u64 = 1_000_000;
const KEY: VehicleKey = VehicleKey(1, 1);

fn runner(query: &str, dir: &std::path::Path) -> VirtualRunner {
    let spec: LinkSpec = format!("sim://?{query}").parse().unwrap();
    // No parameter download alongside: the link is the log's (and the telemetry's).
    let cfg = AppConfig {
        logs_dir: Some(dir.to_path_buf()),
        fetch_params: false,
        ..AppConfig::default()
    };
    let mut r = VirtualRunner::from_specs(&[spec], cfg).unwrap();
    r.advance_to(3 * SECOND);
    r
}

fn logs(r: &VirtualRunner) -> &mavterm::proto::logs::LogMachine {
    &r.app.sessions[&KEY].logs
}

/// Run until the download ended (or `limit` s passed).
fn until_ended(r: &mut VirtualRunner, limit: f64) {
    let end = r.now() + (limit * 1e6) as u64;
    while r.now() < end {
        wait(r, 0.5);
        let t = logs(r).transfer.as_ref();
        if t.is_some_and(|t| !t.active()) && logs(r).queue.is_empty() {
            return;
        }
    }
}

fn list(r: &mut VirtualRunner) {
    command(r, "log list");
    for _ in 0..120 {
        wait(r, 0.5);
        if logs(r).list.complete() {
            return;
        }
    }
    panic!("list incomplete: {:?}", logs(r).list);
}

/// At 57600 baud in `dir`, the list in, `get` typed and 2 s of it run: the runner and the
/// sim's count of LOG_REQUEST_END so far (its logging paused by the download).
fn two_seconds_into(dir: &std::path::Path, get: &str) -> (VirtualRunner, u32) {
    let mut r = runner("baud=57600&log_size=30000", dir);
    list(&mut r);
    command(&mut r, get);
    wait(&mut r, 2.0);
    let ends = sim(&r).vehicle(1).unwrap().logs.ends;
    assert!(sim(&r).vehicle(1).unwrap().logs.logging_paused);
    (r, ends)
}

/// `mavterm --link LINK --headless --duration SECS --logs-out OUT`, run to its end.
fn headless_logs_out(link: &str, secs: &str, out: &std::path::Path) -> std::process::Output {
    std::process::Command::new(common::mavterm())
        .args([
            "--link",
            link,
            "--headless",
            "--duration",
            secs,
            "--logs-out",
        ])
        .arg(out)
        .output()
        .unwrap()
}

fn download(loss: f64, baud: u32) -> (f64, u32) {
    let dir = tempfile::tempdir().unwrap();
    let mut r = runner(
        &format!("loss={loss}&baud={baud}&log_size=30000&seed=5"),
        dir.path(),
    );
    list(&mut r);
    let entries = logs(&r).list.newest_first();
    let want = catalogue(3, 30_000);
    assert_eq!(entries.len(), 3);
    assert_eq!(entries[0].id, 3, "newest first");
    assert_eq!(entries[0].size, want[2].0);
    let t0 = r.now();
    command(&mut r, "log get latest");
    until_ended(&mut r, 300.0);
    let t = logs(&r).transfer.as_ref().unwrap();
    assert_eq!(t.state, State::Done, "{:?}", t.state);
    let bytes = std::fs::read(&t.path).unwrap();
    assert_eq!(bytes.len() as u32, want[2].0);
    assert!(bytes == content(3, want[2].0), "byte-identical");
    assert!(!mavterm::proto::logs::partial_of(&t.path).exists());
    // In its vehicle's directory, named by its time (log 3: BASE_TIME + 3 h, UTC).
    assert_eq!(
        t.path,
        dir.path().join("vehicle/1/2025-11-24_19-00-00_log3.bin")
    );
    // The vehicle stopped logging for it and was told the end.
    let s = sim(&r).vehicle(1).unwrap();
    assert!(s.logs.ends >= 1 && !s.logs.logging_paused);
    let secs = (t.finished.unwrap() - t0) as f64 / 1e6;
    eprintln!(
        "loss {loss} baud {baud}: {secs:.1} s, {} requests, {} retries, srtt {:?}, window {}",
        t.requests, t.retries, t.srtt, t.window
    );
    eprintln!("truth {:?}", sim(&r).truth().get(1));
    (want[2].0 as f64 / secs, t.retries)
}

#[test]
fn a_download_is_whole_at_0_20_and_40_percent_loss() {
    // 57600 baud carries 5760 bytes a second; LOG_DATA is 90 of 109 bytes on the wire, and
    // the telemetry streams share the link.
    let (rate0, retries0) = download(0.0, 57600);
    eprintln!("57600 baud, 0 %: {rate0:.0} B/s");
    assert!(rate0 > 2000.0, "clean link: {rate0:.0} B/s");
    assert_eq!(retries0, 0);
    let (rate20, retries20) = download(0.2, 57600);
    eprintln!("57600 baud, 20 %: {rate20:.0} B/s, {retries20} retries");
    assert!(retries20 > 0);
    assert!(rate20 > 1000.0, "20 % loss: {rate20:.0} B/s");
    let (rate40, retries40) = download(0.4, 57600);
    eprintln!("57600 baud, 40 %: {rate40:.0} B/s, {retries40} retries");
    assert!(rate40 > 400.0, "40 % loss: {rate40:.0} B/s");
}

#[test]
fn a_list_with_lost_entries_is_completed_by_asking_the_missing_ids() {
    let dir = tempfile::tempdir().unwrap();
    let mut r = runner("loss=0.4&logs=40&seed=3", dir.path());
    list(&mut r);
    let l = &logs(&r).list;
    assert_eq!(l.entries.len(), 40);
    assert_eq!(l.first, 1);
    assert_eq!(l.last, 40);
    assert!(l.retries > 0);
    let asked = &sim(&r).vehicle(1).unwrap().logs.list_requests;
    assert_eq!(asked[0], (0, 0xFFFF));
    // Asked again by range, never the whole list again while ids were known missing.
    assert!(
        asked[1..].iter().all(|&(a, b)| a >= 1 && b <= 40 && a <= b),
        "{asked:?}"
    );
    for (i, (size, time)) in catalogue(40, 60_000).into_iter().enumerate() {
        let e = l.entries[&(i as u16 + 1)];
        assert_eq!((e.size, e.time_utc), (size, time));
    }
}

#[test]
fn an_interrupted_download_resumes_from_what_is_on_disk() {
    let dir = tempfile::tempdir().unwrap();
    let query = "baud=57600&log_size=30000";
    let mut r = runner(query, dir.path());
    list(&mut r);
    command(&mut r, "log get 3");
    wait(&mut r, 3.0);
    let t = logs(&r).transfer.as_ref().unwrap();
    let had = t.written;
    assert!(had > 0 && had < t.entry.size, "{had}");
    let path = t.path.clone();
    let partial = mavterm::proto::logs::partial_of(&path);
    assert_eq!(std::fs::metadata(&partial).unwrap().len(), had as u64);
    drop(r); // mavterm quits (or the link is gone) mid-download
    let mut r = runner(query, dir.path());
    list(&mut r);
    command(&mut r, "log get 3");
    until_ended(&mut r, 120.0);
    let t = logs(&r).transfer.as_ref().unwrap();
    assert_eq!(t.state, State::Done);
    assert_eq!(t.resumed, had);
    let size = catalogue(3, 30_000)[2].0;
    assert!(std::fs::read(&path).unwrap() == content(3, size));
    // The first request of the second run starts where the disk ended.
    let asked = &sim(&r).vehicle(1).unwrap().logs.data_requests;
    assert_eq!(asked[0].1, had, "{asked:?}");
}

#[test]
fn cancel_sends_log_request_end_and_keeps_the_partial() {
    let dir = tempfile::tempdir().unwrap();
    let (mut r, ends) = two_seconds_into(dir.path(), "log get 2");
    command(&mut r, "log cancel");
    wait(&mut r, 1.0);
    let v = sim(&r).vehicle(1).unwrap();
    assert_eq!(v.logs.ends, ends + 1);
    assert!(!v.logs.logging_paused, "logging resumed after END");
    let t = logs(&r).transfer.as_ref().unwrap();
    assert_eq!(t.state, State::Cancelled);
    assert!(mavterm::proto::logs::partial_of(&t.path).exists());
    // Nothing more is asked.
    let n = v.logs.data_requests.len();
    wait(&mut r, 3.0);
    assert_eq!(sim(&r).vehicle(1).unwrap().logs.data_requests.len(), n);
}

#[test]
fn erase_asks_first_naming_the_vehicle() {
    let dir = tempfile::tempdir().unwrap();
    let mut r = runner("", dir.path());
    list(&mut r);
    keys(&mut r, &["7"]);
    keys(&mut r, &["E"]);
    let q = r.app.ui.confirm.as_ref().expect("asked").text.clone();
    assert!(q.contains("ERASE all 3 logs") && q.contains("1:1"), "{q}");
    // No: nothing sent.
    keys(&mut r, &["n"]);
    wait(&mut r, 1.0);
    assert_eq!(sim(&r).vehicle(1).unwrap().logs.erases, 0);
    keys(&mut r, &["E"]);
    common::yes(&mut r);
    wait(&mut r, 3.0);
    let v = sim(&r).vehicle(1).unwrap();
    assert_eq!(v.logs.erases, 1);
    assert!(v.logs.logs.is_empty());
    // Listed again: none left.
    assert_eq!(logs(&r).list.num_logs, Some(0));
}

#[test]
fn a_queue_downloads_one_after_another() {
    let dir = tempfile::tempdir().unwrap();
    let mut r = runner("log_size=20000", dir.path());
    keys(&mut r, &["7"]);
    wait(&mut r, 2.0);
    assert!(logs(&r).list.complete(), "the screen asked for the list");
    // Newest first: the first row is log 3; down, down: log 1.
    keys(&mut r, &["d", "down", "d", "down", "d"]);
    assert_eq!(logs(&r).queue.len(), 2);
    until_ended(&mut r, 60.0);
    let done: Vec<u16> = logs(&r)
        .history
        .iter()
        .filter(|(_, _, s)| *s == State::Done)
        .map(|(e, _, _)| e.id)
        .collect();
    assert_eq!(done, vec![3, 2, 1]);
    for (i, (size, _)) in catalogue(3, 20_000).into_iter().enumerate() {
        let (_, path, _) = &logs(&r).history[2 - i];
        assert!(std::fs::read(path).unwrap() == content(i as u16 + 1, size));
    }
}

#[test]
fn the_logs_screen_at_80x24() {
    let dir = tempfile::tempdir().unwrap();
    let mut r = runner("baud=57600&log_size=30000", dir.path());
    keys(&mut r, &["7"]);
    wait(&mut r, 2.0);
    keys(&mut r, &["d"]);
    wait(&mut r, 2.0);
    let screen = common::screen(&r, 80, 24);
    let screen = screen.replace(&dir.path().display().to_string(), "DIR");
    insta::assert_snapshot!(screen);
}

#[test]
fn headless_logs_out_exits_0_only_when_every_log_is_whole() {
    let dir = tempfile::tempdir().unwrap();
    let out = std::process::Command::new(common::mavterm())
        .args([
            "--link",
            "sim://?log_size=20000",
            "--headless",
            "--logs-out",
        ])
        .arg(dir.path())
        .args(["--log-ids", "1,3"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for (id, (size, _)) in [
        (1u16, catalogue(3, 20_000)[0]),
        (3, catalogue(3, 20_000)[2]),
    ] {
        let found: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| {
                p.to_string_lossy().ends_with(&format!("log{id}.bin"))
                    || p.to_string_lossy()
                        .ends_with(&format!("log{id}_no-time.bin"))
            })
            .collect();
        assert_eq!(found.len(), 1, "{found:?}");
        assert!(std::fs::read(&found[0]).unwrap() == content(id, size));
    }
    // A log the vehicle does not have: not 0.
    let out = std::process::Command::new(common::mavterm())
        .args(["--link", "sim://", "--headless", "--logs-out"])
        .arg(dir.path())
        .args(["--log-ids", "9"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("no log 9"));
    // Not whole in the time given: not 0, the partial kept.
    let slow = tempfile::tempdir().unwrap();
    let out = headless_logs_out("sim://?baud=57600&log_size=200000", "8", slow.path());
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("not complete"));
    let partials = std::fs::read_dir(slow.path())
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .path()
                .to_string_lossy()
                .ends_with(".partial")
        })
        .count();
    assert_eq!(partials, 1);
}

/// `--logs-out` against the pymavlink stand-in (tests/py/fake_log_vehicle.py) over TCP in real
/// time, at `loss` and with the link dropping for 3 s mid-log when `outage`: the file written
/// is the bytes the stand-in served, and every request it got was valid.
fn stand_in_download(loss: &str, outage: bool) {
    let dir = tempfile::tempdir().unwrap();
    let port = common::free_tcp_port();
    let served = dir.path().join("served.bin");
    let check = dir.path().join("check.json");
    let mut a: Vec<std::ffi::OsString> = vec![
        "--port".into(),
        port.to_string().into(),
        "--size".into(),
        "40000".into(),
        "--loss".into(),
        loss.into(),
        "--served-out".into(),
        served.clone().into(),
        "--check-out".into(),
        check.clone().into(),
    ];
    if outage {
        a.extend(["--outage-at".into(), "15000".into()]);
    }
    let mut fake = common::stand_in("fake_log_vehicle.py", &a);
    let out_dir = dir.path().join("logs");
    let out = headless_logs_out(&format!("tcp:127.0.0.1:{port}"), "45", &out_dir);
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "{stderr}");
    let _ = fake.0.wait();
    let path = out_dir.join("2025-11-24_16-00-00_log1.bin");
    assert!(
        std::fs::read(&path).unwrap() == std::fs::read(&served).unwrap(),
        "the file is what the stand-in served"
    );
    let c: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&check).unwrap()).unwrap();
    assert_eq!(c["errors"], serde_json::json!([]), "{c}");
    assert!(c["ends"].as_u64().unwrap() >= 1, "LOG_REQUEST_END sent");
    let reqs = c["requests"].as_array().unwrap();
    // The first asks from the start; every one within the log.
    assert_eq!(reqs[0][1], 0);
    for r in reqs {
        let (ofs, count) = (r[1].as_u64().unwrap(), r[2].as_u64().unwrap());
        assert!(ofs < 40_000 && count > 0 && ofs + count <= 40_000, "{r}");
    }
    if outage {
        assert!(reqs.len() > 2, "asked again after the drop: {reqs:?}");
    }
}

#[test]
fn a_pymavlink_vehicle_serves_a_log_and_checks_every_request() {
    stand_in_download("0", false);
    stand_in_download("0.2", false);
}

#[test]
fn a_download_goes_on_after_the_link_drops() {
    stand_in_download("0", true);
}

#[test]
fn nothing_goes_on_a_high_latency_link_unless_asked_there() {
    let dir = tempfile::tempdir().unwrap();
    let mut r = runner("", dir.path());
    r.app.links[0].profile.hl = true;
    keys(&mut r, &["7"]);
    command(&mut r, "log list");
    wait(&mut r, 2.0);
    assert!(
        sim(&r).vehicle(1).unwrap().logs.list_requests.is_empty(),
        "neither the screen nor `log list` asked"
    );
    let said = r.app.ui.message.clone().unwrap().1;
    assert!(said.contains("high-latency"), "{said}");
    command(&mut r, "log list --hl");
    wait(&mut r, 2.0);
    assert_eq!(sim(&r).vehicle(1).unwrap().logs.list_requests.len(), 1);
    command(&mut r, "log get 1");
    wait(&mut r, 1.0);
    assert!(sim(&r).vehicle(1).unwrap().logs.data_requests.is_empty());
    command(&mut r, "log get 1 --hl");
    wait(&mut r, 1.0);
    assert!(!sim(&r).vehicle(1).unwrap().logs.data_requests.is_empty());
}

#[test]
fn log_rate_caps_the_download() {
    let dir = tempfile::tempdir().unwrap();
    let spec: LinkSpec = "sim://?log_size=30000".parse().unwrap();
    let cfg = AppConfig {
        logs_dir: Some(dir.path().to_path_buf()),
        fetch_params: false,
        log_rate: Some(5000),
        ..AppConfig::default()
    };
    let mut r = VirtualRunner::from_specs(&[spec], cfg).unwrap();
    r.advance_to(3 * SECOND);
    list(&mut r);
    let t0 = r.now();
    command(&mut r, "log get 3");
    until_ended(&mut r, 60.0);
    let t = logs(&r).transfer.as_ref().unwrap();
    assert_eq!(t.state, State::Done);
    let secs = (t.finished.unwrap() - t0) as f64 / 1e6;
    let rate = t.entry.size as f64 / secs;
    // The network link carries far more; capped at 5000 B/s (one window's burst allowed).
    assert!(rate <= 5000.0 * 1.1 && rate > 3000.0, "{rate:.0} B/s");
}

/// One simulated vehicle heard over two radios (links 0 and 1): what it sends goes out on
/// both, what either sends reaches it; a radio that is cut passes nothing either way.
struct Radios {
    sim: Box<dyn VirtualSource>,
    out: [Vec<u8>; 2],
    cut: [bool; 2],
}

/// One radio of [`Radios`], as a link's source.
struct Radio {
    radios: Arc<Mutex<Radios>>,
    i: usize,
}

impl VirtualSource for Radio {
    fn receive(&mut self, now: u64, bytes: &[u8]) {
        let mut r = self.radios.lock().unwrap();
        if !r.cut[self.i] {
            r.sim.receive(now, bytes);
        }
    }
    fn poll(&mut self, now: u64) -> Vec<u8> {
        let mut r = self.radios.lock().unwrap();
        let bytes = r.sim.poll(now);
        for k in 0..2 {
            if !r.cut[k] {
                r.out[k].extend_from_slice(&bytes);
            }
        }
        std::mem::take(&mut r.out[self.i])
    }
    fn next_deadline(&self) -> u64 {
        let r = self.radios.lock().unwrap();
        if r.out[self.i].is_empty() {
            r.sim.next_deadline()
        } else {
            0
        }
    }
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

/// A runner over one sim (`query`) heard on two links, link 1 high-latency (`?hl=1`) when
/// `hl`; only link 0 when `two` is false.
fn radios(query: &str, dir: &std::path::Path, two: bool, hl: bool) -> VirtualRunner {
    let spec: LinkSpec = format!("sim://?{query}").parse().unwrap();
    let sim = mavterm::driver::local_source(&spec).unwrap();
    let shared = Arc::new(Mutex::new(Radios {
        sim,
        out: [Vec::new(), Vec::new()],
        cut: [false, !two],
    }));
    let n = if two { 2 } else { 1 };
    let sources: Vec<Box<dyn VirtualSource>> = (0..n)
        .map(|i| {
            Box::new(Radio {
                radios: shared.clone(),
                i,
            }) as Box<dyn VirtualSource>
        })
        .collect();
    let cfg = AppConfig {
        links: (0..n).map(|_| "sim://".to_string()).collect(),
        logs_dir: Some(dir.to_path_buf()),
        fetch_params: false,
        ..AppConfig::default()
    };
    let mut r = VirtualRunner::new(cfg, sources);
    if two && hl {
        r.app.links[1].profile.hl = true;
    }
    r.advance_to(3 * SECOND);
    r
}

fn radios_of(r: &VirtualRunner) -> Arc<Mutex<Radios>> {
    r.source(0)
        .unwrap()
        .as_any()
        .downcast_ref::<Radio>()
        .unwrap()
        .radios
        .clone()
}

/// Cut radio `i` (nothing passes) or bring it back.
fn cut(r: &mut VirtualRunner, i: usize, cut: bool) {
    radios_of(r).lock().unwrap().cut[i] = cut;
}

/// `f` of the simulated vehicle behind the radios.
fn vehicle_logs<T>(r: &VirtualRunner, f: impl FnOnce(&mavterm::sim::logs::SimLogs) -> T) -> T {
    let rs = radios_of(r);
    let g = rs.lock().unwrap();
    let sim = g.sim.as_any().downcast_ref::<mavterm::sim::Sim>().unwrap();
    f(&sim.vehicle(1).unwrap().logs)
}

/// The ids of the log protocol's requests among frames sent on `link`.
fn log_requests_on(sent: &[(u64, usize, Vec<u8>)], link: usize) -> Vec<u32> {
    // LOG_REQUEST_LIST, LOG_REQUEST_DATA, LOG_ERASE, LOG_REQUEST_END.
    sent.iter()
        .filter(|(_, l, _)| *l == link)
        .map(|(_, _, f)| common::frame_msgid(f))
        .filter(|id| [117, 119, 121, 122].contains(id))
        .collect()
}

#[test]
fn a_download_pauses_when_only_the_high_latency_link_is_left_and_goes_on_after() {
    let dir = tempfile::tempdir().unwrap();
    let mut r = radios("baud=57600&log_size=30000", dir.path(), true, true);
    r.capture_sent();
    list(&mut r);
    command(&mut r, "log get 3");
    wait(&mut r, 3.0);
    let had = logs(&r).transfer.as_ref().unwrap().written;
    assert!(had > 0, "under way");
    // The normal radio goes: its link is down, the satellite link is all that is left.
    cut(&mut r, 0, true);
    r.event(Event::LinkState {
        link: 0,
        state: LinkState::Down("gone".into()),
    });
    wait(&mut r, 20.0);
    let t = logs(&r).transfer.as_ref().unwrap();
    assert_eq!(t.state, State::Running);
    assert!(t.paused.is_some(), "paused");
    let bar = common::screen(&r, 120, 24);
    let bar = bar.lines().last().unwrap().to_string();
    assert!(bar.contains("paused (high-latency link only)"), "{bar}");
    assert!(r
        .app
        .notices
        .iter()
        .any(|n| n.text.contains("paused at") && n.text.contains("high-latency")));
    // 20 s paused: no give-up, nothing asked anywhere meanwhile.
    let sent = r.take_sent();
    assert_eq!(
        log_requests_on(&sent, 1),
        Vec::<u32>::new(),
        "nothing on the hl link"
    );
    let paused_at = sent
        .iter()
        .filter(|(t, _, _)| *t > 4 * SECOND + r.now() - 20 * SECOND);
    assert!(
        log_requests_on(&paused_at.cloned().collect::<Vec<_>>(), 0).is_empty(),
        "nothing asked while paused"
    );
    // The radio is back: it goes on (END first: the vehicle may still be sending into the
    // radio that went), and ends whole.
    let ends = vehicle_logs(&r, |l| l.ends);
    cut(&mut r, 0, false);
    r.event(Event::LinkState {
        link: 0,
        state: LinkState::Up,
    });
    until_ended(&mut r, 120.0);
    // END when it was whole: the vehicle logs again.
    let (ends_now, paused) = vehicle_logs(&r, |l| (l.ends, l.logging_paused));
    assert!(ends_now > ends);
    assert!(!paused);
    let t = logs(&r).transfer.as_ref().unwrap();
    assert_eq!(t.state, State::Done, "{:?}", t.state);
    let size = catalogue(3, 30_000)[2].0;
    assert!(std::fs::read(&t.path).unwrap() == content(3, size));
    let sent = r.take_sent();
    assert_eq!(
        log_requests_on(&sent, 1),
        Vec::<u32>::new(),
        "nothing on the hl link"
    );
    assert!(log_requests_on(&sent, 0).contains(&119));
}

#[test]
fn a_partial_of_another_log_with_the_same_id_is_started_over() {
    // Log 1 has no time: its file is `log1_no-time.bin`, the same name for a new log 1 after
    // an erase. A partial of the old one (other bytes, another size) must not be continued.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("vehicle/1/log1_no-time.bin");
    let partial = mavterm::proto::logs::partial_of(&path);
    std::fs::create_dir_all(partial.parent().unwrap()).unwrap();
    std::fs::write(&partial, vec![0xAA; 4000]).unwrap();
    let old = mavterm::proto::logs::LogEntry {
        id: 1,
        time_utc: 0,
        size: 9000,
    };
    std::fs::write(
        mavterm::proto::logs::info_of(&partial),
        mavterm::proto::logs::tag_of(KEY, &old),
    )
    .unwrap();
    let mut r = runner("log_size=30000", dir.path());
    list(&mut r);
    command(&mut r, "log get 1");
    until_ended(&mut r, 60.0);
    let t = logs(&r).transfer.as_ref().unwrap();
    assert_eq!(t.state, State::Done, "{:?}", t.state);
    assert_eq!(t.resumed, 0, "started over");
    assert_eq!(t.path, path);
    let size = catalogue(3, 30_000)[0].0;
    assert!(std::fs::read(&path).unwrap() == content(1, size));
    assert_eq!(sim(&r).vehicle(1).unwrap().logs.data_requests[0].1, 0);
    assert!(!mavterm::proto::logs::info_of(&partial).exists());
}

#[test]
fn a_download_that_failed_for_silence_goes_on_once_the_vehicle_is_heard_again() {
    let dir = tempfile::tempdir().unwrap();
    let mut r = radios("baud=57600&log_size=30000", dir.path(), false, false);
    list(&mut r);
    command(&mut r, "log get 3");
    wait(&mut r, 3.0);
    // Out of the radio's range: the link stays up, nothing passes.
    cut(&mut r, 0, true);
    wait(&mut r, 62.0);
    let m = logs(&r);
    let t = m.transfer.as_ref().unwrap();
    let had = t.written;
    match &t.state {
        State::Failed(why) => assert!(
            why.contains("not heard") && why.contains("once the vehicle is heard again"),
            "{why}"
        ),
        s => panic!("{s:?}"),
    }
    assert!(m.waiting_for_link.is_some());
    assert_eq!(m.queue.front().map(|q| q.id), Some(3));
    let bar = common::screen(&r, 120, 24);
    let bar = bar.lines().last().unwrap().to_string();
    assert!(
        bar.contains("log 3 waits for the vehicle to be heard"),
        "{bar}"
    );
    // Back in range: it goes on from the disk by itself.
    cut(&mut r, 0, false);
    wait(&mut r, 2.0);
    until_ended(&mut r, 120.0);
    let t = logs(&r).transfer.as_ref().unwrap();
    assert_eq!(t.state, State::Done, "{:?}", t.state);
    assert_eq!(t.resumed, had);
    let size = catalogue(3, 30_000)[2].0;
    assert!(std::fs::read(&t.path).unwrap() == content(3, size));
}

#[test]
fn the_status_bar_shows_bytes_rate_eta_and_retries_on_other_screens_and_a_stall() {
    let dir = tempfile::tempdir().unwrap();
    let mut r = radios(
        "baud=57600&log_size=30000&loss=0.2&seed=5",
        dir.path(),
        false,
        false,
    );
    list(&mut r);
    command(&mut r, "log get 3");
    keys(&mut r, &["2"]);
    wait(&mut r, 6.0);
    assert_ne!(r.app.ui.screen, "logs");
    let bar = |r: &VirtualRunner| {
        let s = common::screen(r, 120, 24);
        s.lines().last().unwrap().to_string()
    };
    let b = bar(&r);
    let t = logs(&r).transfer.as_ref().unwrap();
    assert!(t.retries > 0);
    assert!(
        b.contains("log 3 15.2 kB/30.0 kB 50% 2.6 kB/s ETA 6 s retries 11"),
        "{b}"
    );
    // Nothing comes: no rate or ETA frozen at what they were, the stall and its length.
    cut(&mut r, 0, true);
    wait(&mut r, 5.0);
    let b = bar(&r);
    assert!(b.contains("stalled 5 s"), "{b}");
    assert!(!b.contains("kB/s") && !b.contains("ETA"), "{b}");
}

#[test]
fn quitting_mid_download_sends_log_request_end() {
    let dir = tempfile::tempdir().unwrap();
    let (mut r, ends) = two_seconds_into(dir.path(), "log get 3");
    r.capture_sent();
    keys(&mut r, &["q"]);
    assert!(r.quit_requested());
    let sent = r.take_sent();
    assert_eq!(
        log_requests_on(&sent, 0),
        vec![122],
        "LOG_REQUEST_END on the wire"
    );
    let v = sim(&r).vehicle(1).unwrap();
    assert_eq!(v.logs.ends, ends + 1);
    assert!(!v.logs.logging_paused, "the vehicle logs again");
    let t = logs(&r).transfer.as_ref().unwrap();
    assert!(mavterm::proto::logs::partial_of(&t.path).exists(), "kept");
}

#[test]
fn a_headless_run_whose_time_is_up_sends_log_request_end() {
    // Real time over TCP against the pymavlink stand-in: the run ends at --duration with the
    // log not whole; the stand-in saw LOG_REQUEST_END.
    let dir = tempfile::tempdir().unwrap();
    let port = common::free_tcp_port();
    let served = dir.path().join("served.bin");
    let check = dir.path().join("check.json");
    let a: Vec<std::ffi::OsString> = vec![
        "--port".into(),
        port.to_string().into(),
        "--size".into(),
        "3000000".into(),
        "--duration".into(),
        "8".into(),
        "--served-out".into(),
        served.into(),
        "--check-out".into(),
        check.clone().into(),
    ];
    let mut fake = common::stand_in("fake_log_vehicle.py", &a);
    let out = headless_logs_out(
        &format!("tcp:127.0.0.1:{port}"),
        "3",
        &dir.path().join("logs"),
    );
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!out.status.success());
    assert!(stderr.contains("not complete"), "{stderr}");
    let _ = fake.0.wait();
    let c: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&check).unwrap()).unwrap();
    assert!(!c["requests"].as_array().unwrap().is_empty(), "{c}");
    assert_eq!(c["ends"], 1, "LOG_REQUEST_END at the end of the run: {c}");
    assert_eq!(c["errors"], serde_json::json!([]), "{c}");
}

/// The list's columns line up whatever the zone's label: with `+05:30` (six characters) a row
/// with a time and one without end their size at the same column, under the header's.
#[test]
fn the_list_lines_up_in_any_zone() {
    let dir = tempfile::tempdir().unwrap();
    let spec: LinkSpec = "sim://".parse().unwrap();
    let cfg = AppConfig {
        logs_dir: Some(dir.path().to_path_buf()),
        fetch_params: false,
        zone: mavterm::clock::DisplayZone::fixed(
            chrono::FixedOffset::east_opt(5 * 3600 + 1800).unwrap(),
        ),
        ..AppConfig::default()
    };
    let mut r = VirtualRunner::from_specs(&[spec], cfg).unwrap();
    r.advance_to(3 * SECOND);
    keys(&mut r, &["7"]);
    wait(&mut r, 2.0);
    let screen = common::screen(&r, 80, 24);
    let end_of = |needle: &str| {
        let line = screen
            .lines()
            .find(|l| l.contains(needle))
            .unwrap_or_else(|| panic!("{needle}: {screen}"));
        let at = line
            .find(" kB")
            .or_else(|| line.find("size").map(|i| i + 4 - 3));
        line[..at.unwrap()].chars().count()
    };
    // The sim's logs: 3 newest with a time (+05:30 shows 00:30 the next day), 1 without.
    assert!(screen.contains("2025-11-25 00:30:00 +05:30"), "{screen}");
    assert_eq!(
        end_of("2025-11-25 00:30:00 +05:30"),
        end_of("(no time)"),
        "{screen}"
    );
    assert_eq!(end_of("(no time)"), end_of("size"), "{screen}");
}
