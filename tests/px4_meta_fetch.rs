//! PX4's parameter metadata by the component metadata protocol, against a pymavlink stand-in PX4
//! (tests/py/fake_px4_metadata.py: COMPONENT_METADATA, and a MAVFTP server that behaves as PX4's
//! mavlink_ftp.cpp and checks every request) over TCP, in real time, the core in process.
//! The metadata files are made by tests/py/make_px4_metadata.py with Python's json and lzma
//! modules; what the screen must show comes from that JSON, never from mavterm.

mod common;

use std::io::{Read, Write};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use mavterm::app::AppConfig;
use mavterm::driver::real_time::RealTimeRunner;
use mavterm::driver::virtual_time::Driver;
use mavterm::link::LinkSpec;

/// The metadata files in `dir`, with `extra` arguments; returns the general file's CRC.
fn make_files(dir: &Path, extra: &[&str]) -> u32 {
    let mut args = vec![dir.to_str().unwrap()];
    args.extend(extra);
    let out = common::py_lines("make_px4_metadata.py", &args, &[]);
    out[0].trim().parse().unwrap()
}

/// Start the stand-in; its log goes to `dir/log.json`.
fn fake(port: u16, files: &Path, dir: &Path, crc: u32, extra: &[&str]) -> common::ChildGuard {
    let mut a: Vec<std::ffi::OsString> = vec!["--port".into(), port.to_string().into()];
    a.extend([
        "--general".into(),
        files.join("component_general.json.xz").into(),
    ]);
    a.extend(["--params".into(), files.join("parameters.json.xz").into()]);
    a.extend(["--crc".into(), crc.to_string().into()]);
    a.extend(["--log-out".into(), dir.join("log.json").into()]);
    a.extend(extra.iter().map(|s| s.into()));
    common::stand_in("fake_px4_metadata.py", &a)
}

fn log(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("log.json")).unwrap()).unwrap()
}

/// The stand-in's log once `done` holds of it (at most 10 s): mavterm's last frames are on
/// their way over TCP when the core is done with a file, and the stand-in logs on receipt.
fn log_when(dir: &Path, done: impl Fn(&serde_json::Value) -> bool) -> serde_json::Value {
    let end = Instant::now() + Duration::from_secs(10);
    loop {
        let l = log(dir);
        if done(&l) || Instant::now() > end {
            return l;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

struct Run {
    r: RealTimeRunner,
    _rt: tokio::runtime::Runtime,
}

fn start(port: u16, cache: &Path) -> Run {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    let spec: LinkSpec = format!("tcp:127.0.0.1:{port}").parse().unwrap();
    let cfg = AppConfig {
        param_meta_cache: Some(cache.to_path_buf()),
        ..AppConfig::default()
    };
    let r = RealTimeRunner::start(rt.handle().clone(), &[spec], cfg);
    Run { r, _rt: rt }
}

impl Run {
    /// Run until `done` holds (at most `secs` seconds).
    fn until(&mut self, secs: f64, what: &str, done: impl Fn(&mavterm::app::App) -> bool) {
        let end = Instant::now() + Duration::from_secs_f64(secs);
        while Instant::now() < end {
            let t = self.r.now() + 200_000;
            self.r.advance_to(t);
            if done(self.r.app()) {
                return;
            }
        }
        panic!(
            "{what}: not within {secs} s; messages: {:?}",
            self.messages()
        );
    }

    fn keys(&mut self, names: &[&str]) {
        for n in names {
            self.r.key(n.parse::<mavterm::keymap::Key>().unwrap());
        }
    }

    fn typed(&mut self, text: &str) {
        for c in text.chars() {
            self.r.key(mavterm::keymap::Key::ch(c));
        }
    }

    fn command(&mut self, line: &str) {
        self.keys(&[":"]);
        self.typed(line);
        self.keys(&["enter"]);
    }

    fn messages(&self) -> Vec<String> {
        self.r
            .app()
            .notices
            .iter()
            .map(|n| n.text.clone())
            .collect()
    }

    /// The Parameters screen at 80x24 with `name` selected.
    fn parameter_screen(&mut self, name: &str) -> String {
        self.keys(&["2", "/", "ctrl-u"]);
        self.typed(name);
        self.keys(&["enter"]);
        assert_eq!(self.r.app().param_selected().as_deref(), Some(name));
        use mavterm::ui::{buffer_to_text, render_to_buffer, Theme};
        buffer_to_text(&render_to_buffer(self.r.app(), 80, 24, &Theme::PLAIN))
    }
}

fn loaded(app: &mavterm::app::App) -> bool {
    app.cfg.param_meta.is_some() && app.param_set().is_some_and(|s| s.complete())
}

/// The JSON Python wrote: the parameter `name`'s entry.
fn entry(files: &Path, name: &str) -> serde_json::Value {
    let doc: serde_json::Value =
        serde_json::from_slice(&std::fs::read(files.join("parameters.json")).unwrap()).unwrap();
    doc["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == name)
        .unwrap()
        .clone()
}

fn cache_file(cache: &Path, crc: u32) -> PathBuf {
    cache
        .join("param-meta")
        .join(format!("component-{crc:08x}.parameters.json"))
}

#[test]
fn px4_metadata_read_over_mavftp_at_connect_shown_and_cached() {
    let tmp = tempfile::tempdir().unwrap();
    let (files, cache) = (tmp.path().join("files"), tmp.path().join("cache"));
    std::fs::create_dir_all(&files).unwrap();
    // 150 more parameters: a parameter file of several of PX4's bursts (chunks of 500 bytes
    // here), the 3rd packet of each file's first burst lost.
    let crc = make_files(&files, &["--pad", "150"]);
    let xz_len = std::fs::metadata(files.join("parameters.json.xz"))
        .unwrap()
        .len();
    assert!(xz_len > 2000, "{xz_len}");
    let want = entry(&files, "MPC_XY_VEL_MAX");

    let port = common::free_tcp_port();
    let run1 = tmp.path().join("run1");
    std::fs::create_dir_all(&run1).unwrap();
    let _v = fake(port, &files, &run1, crc, &["--chunk", "500", "--drop", "3"]);
    let mut run = start(port, &cache);
    run.until(30.0, "metadata read at connect", loaded);

    // Both files read and the session closed after the second (TerminateSession, opcode 1).
    let l = log_when(&run1, |l| {
        let ops: Vec<u64> = l["ftp"]
            .as_array()
            .map(|a| a.iter().filter_map(|r| r[1].as_u64()).collect())
            .unwrap_or_default();
        ops.iter().filter(|o| **o == 4).count() == 2 && ops.last() == Some(&1)
    });
    assert_eq!(l["errors"], serde_json::json!([]), "{l}");
    assert_eq!(l["requests"], serde_json::json!([397]));
    assert_eq!(
        l["opens"],
        serde_json::json!([
            "etc/extras/component_general.json.xz",
            "etc/extras/parameters.json.xz"
        ])
    );
    let ftp = l["ftp"].as_array().unwrap();
    // Opcodes: TerminateSession, OpenFileRO, bursts (BurstReadFile 15), TerminateSession.
    let ops: Vec<u64> = ftp.iter().map(|r| r[1].as_u64().unwrap()).collect();
    assert_eq!(&ops[..3], &[1, 4, 15], "{ops:?}");
    assert_eq!(*ops.last().unwrap(), 1, "the session is closed: {ops:?}");
    let bursts = ops.iter().filter(|o| **o == 15).count();
    assert!(
        bursts as u64 > xz_len / 500,
        "{bursts} bursts for {xz_len} bytes"
    );

    // The inflated JSON is the cache, keyed by the CRC of the general file. The real-time
    // driver writes it on a blocking task (atomically), so it may land a moment after the
    // metadata is in use.
    let cached = cache_file(&cache, crc);
    run.until(10.0, "the metadata cache written", |_| cached.exists());
    assert_eq!(
        std::fs::read(cache_file(&cache, crc)).unwrap(),
        std::fs::read(files.join("parameters.json")).unwrap()
    );
    let m = run.messages();
    assert!(
        m.iter().any(|t| t
            == "parameter metadata: 155 parameters described, from 1:1's mftp://etc/extras/parameters.json.xz"),
        "{m:?}"
    );
    let s = run.parameter_screen("MPC_XY_VEL_MAX");
    assert!(s.contains(want["shortDesc"].as_str().unwrap()), "{s}");
    assert!(s.contains(want["units"].as_str().unwrap()), "{s}");
    assert!(s.contains(want["longDesc"].as_str().unwrap()), "{s}");
    drop(run);
    drop(_v);

    // Another run, the same firmware (CRC): the cache, nothing read over MAVFTP.
    let port = common::free_tcp_port();
    let run2 = tmp.path().join("run2");
    std::fs::create_dir_all(&run2).unwrap();
    let _v = fake(port, &files, &run2, crc, &[]);
    let mut run = start(port, &cache);
    run.until(30.0, "metadata from the cache", loaded);
    let l = log(&run2);
    assert_eq!(l["requests"], serde_json::json!([397]));
    assert_eq!(l["ftp"], serde_json::json!([]), "no MAVFTP at all: {l}");
    let m = run.messages();
    let path = cache_file(&cache, crc);
    assert!(
        m.iter().any(|t| *t
            == format!(
                "parameter metadata: 155 parameters, from {}",
                path.display()
            )),
        "{m:?}"
    );
    let s = run.parameter_screen("MPC_XY_VEL_MAX");
    assert!(s.contains(want["shortDesc"].as_str().unwrap()), "{s}");
    assert!(s.contains(want["units"].as_str().unwrap()), "{s}");
}

/// A local HTTP server of one file (`/px4/parameters.json.xz`, `body` as it is when asked):
/// returns its base URL and the paths asked for.
fn serve(body: Arc<Mutex<Vec<u8>>>) -> (String, Arc<Mutex<Vec<String>>>) {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let base = format!("http://{}", listener.local_addr().unwrap());
    let asked = Arc::new(Mutex::new(Vec::new()));
    let log = asked.clone();
    std::thread::spawn(move || {
        for stream in listener.incoming() {
            let Ok(mut s) = stream else { continue };
            let mut req = Vec::new();
            let mut buf = [0u8; 1024];
            while !req.windows(4).any(|w| w == b"\r\n\r\n") {
                match s.read(&mut buf) {
                    Ok(0) | Err(_) => break,
                    Ok(n) => req.extend_from_slice(&buf[..n]),
                }
            }
            let text = String::from_utf8_lossy(&req);
            let path = text.split_whitespace().nth(1).unwrap_or("").to_string();
            log.lock().unwrap().push(path.clone());
            let file = body.lock().unwrap().clone();
            let (status, body): (&str, &[u8]) = if path == "/px4/parameters.json.xz" {
                ("200 OK", &file)
            } else {
                ("404 Not Found", b"not here")
            };
            let head = format!(
                "HTTP/1.1 {status}\r\nContent-Length: {}\r\nConnection: close\r\n\r\n",
                body.len()
            );
            let _ = s.write_all(head.as_bytes());
            let _ = s.write_all(body);
        }
    });
    (base, asked)
}

/// A board whose flash holds no parameters.json.xz: the general file's `uriFallback` (HTTPS on
/// PX4's servers; a local HTTP server here) is downloaded instead, inflated and cached.
#[test]
fn a_missing_file_on_the_vehicle_falls_back_to_the_web() {
    let tmp = tempfile::tempdir().unwrap();
    let (files, cache) = (tmp.path().join("files"), tmp.path().join("cache"));
    std::fs::create_dir_all(&files).unwrap();
    // The server's URL goes into the general file: serve first, make the files after.
    let body = Arc::new(Mutex::new(Vec::new()));
    let (base, asked) = serve(body.clone());
    let fallback = format!("{base}/px4/parameters.json.xz");
    let crc = make_files(&files, &["--fallback", &fallback]);
    *body.lock().unwrap() = std::fs::read(files.join("parameters.json.xz")).unwrap();
    let port = common::free_tcp_port();
    let _v = fake(port, &files, tmp.path(), crc, &["--no-params"]);
    let mut run = start(port, &cache);
    run.until(30.0, "metadata from the fallback URL", loaded);
    let l = log(tmp.path());
    assert_eq!(l["errors"], serde_json::json!([]), "{l}");
    assert_eq!(
        l["opens"],
        serde_json::json!([
            "etc/extras/component_general.json.xz",
            "etc/extras/parameters.json.xz"
        ])
    );
    assert_eq!(*asked.lock().unwrap(), ["/px4/parameters.json.xz"]);
    // Written on a blocking task: it may land a moment after the metadata is in use.
    let cached = cache_file(&cache, crc);
    run.until(10.0, "the metadata cache written", |_| cached.exists());
    assert_eq!(
        std::fs::read(cache_file(&cache, crc)).unwrap(),
        std::fs::read(files.join("parameters.json")).unwrap()
    );
    let m = run.messages();
    assert!(
        m.iter()
            .any(|t| *t
                == format!("parameter metadata: 5 parameters described, from 1:1's {fallback}")),
        "{m:?}"
    );
    let want = entry(&files, "COM_RC_IN_MODE");
    let s = run.parameter_screen("COM_RC_IN_MODE");
    assert!(s.contains(want["shortDesc"].as_str().unwrap()), "{s}");
    // Its value 3 named from the JSON's values.
    assert!(s.contains("3 (RC or Joystick keep first)"), "{s}");
}

/// A vehicle that refuses COMPONENT_METADATA and COMPONENT_INFORMATION (UNSUPPORTED): told
/// once at connect, and on `param meta fetch` on the status bar; nothing asked again on its own.
#[test]
fn a_vehicle_without_component_metadata_is_told_plainly() {
    let tmp = tempfile::tempdir().unwrap();
    let files = tmp.path().join("files");
    std::fs::create_dir_all(&files).unwrap();
    let crc = make_files(&files, &[]);
    let port = common::free_tcp_port();
    let _v = fake(
        port,
        &files,
        tmp.path(),
        crc,
        &["--metadata", "unsupported"],
    );
    let mut run = start(port, &tmp.path().join("cache"));
    let auto = "parameter metadata from the vehicle: 1:1 serves no component metadata (REQUEST_MESSAGE UNSUPPORTED) (param meta fetch tries again)";
    run.until(20.0, "the automatic request told", |a| {
        a.notices.iter().any(|n| n.text == auto)
    });
    assert_eq!(log(tmp.path())["requests"], serde_json::json!([397, 395]));
    run.command("param meta fetch");
    let refused = "param meta fetch: 1:1 serves no component metadata (REQUEST_MESSAGE UNSUPPORTED); --param-meta FILE loads a file instead";
    run.until(20.0, "the operator's fetch told", |a| {
        a.ui.message.as_ref().is_some_and(|(_, t)| t == refused)
    });
    // Nothing more on its own.
    let t = run.r.now() + 3_000_000;
    run.r.advance_to(t);
    let l = log(tmp.path());
    assert_eq!(l["requests"], serde_json::json!([397, 395, 397, 395]));
    assert_eq!(l["ftp"], serde_json::json!([]));
    assert!(run.r.app().cfg.param_meta.is_none());
}

/// A vehicle that never answers REQUEST_MESSAGE: the queue's resends, then one plain message.
#[test]
fn a_silent_vehicle_is_given_up_once() {
    let tmp = tempfile::tempdir().unwrap();
    let files = tmp.path().join("files");
    std::fs::create_dir_all(&files).unwrap();
    let crc = make_files(&files, &[]);
    let port = common::free_tcp_port();
    let _v = fake(port, &files, tmp.path(), crc, &["--metadata", "silent"]);
    let mut run = start(port, &tmp.path().join("cache"));
    let told = "parameter metadata from the vehicle: 1:1 did not answer REQUEST_MESSAGE(COMPONENT_METADATA) (param meta fetch tries again)";
    run.until(30.0, "the silence told", |a| {
        a.notices.iter().any(|n| n.text == told)
    });
    let asked = log(tmp.path())["requests"].as_array().unwrap().len();
    assert_eq!(asked, 3, "the queue's three sends, no more");
    let t = run.r.now() + 5_000_000;
    run.r.advance_to(t);
    assert_eq!(log(tmp.path())["requests"].as_array().unwrap().len(), asked);
}
