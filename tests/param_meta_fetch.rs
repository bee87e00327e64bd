//! `param meta fetch`: the target's parameter metadata downloaded from a (local) server, kept in
//! the cache directory and shown on the Parameters screen; a later run uses the cache with no
//! server at all; an unreachable server is told in plain words and leaves no cache file.

mod common;

use std::io::{Read, Write};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use mavterm::app::AppConfig;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::LinkSpec;

fn fixture() -> Vec<u8> {
    std::fs::read(common::test_path("data/param-meta/ArduCopter.apm.pdef.xml")).unwrap()
}

/// A tiny HTTP/1.1 server on 127.0.0.1: `/ArduCopter/apm.pdef.xml` is the fixture, anything else
/// 404. Returns its base URL and the paths asked for.
fn serve() -> (String, Arc<Mutex<Vec<String>>>) {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let base = format!("http://{}", listener.local_addr().unwrap());
    let asked = Arc::new(Mutex::new(Vec::new()));
    let log = asked.clone();
    let body = fixture();
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
            let (status, body): (&str, &[u8]) = if path == "/ArduCopter/apm.pdef.xml" {
                ("200 OK", &body)
            } else {
                ("404 Not Found", b"not here")
            };
            let head = format!(
                "HTTP/1.1 {status}\r\nContent-Type: application/xml\r\nContent-Length: {}\r\nConnection: close\r\n\r\n",
                body.len()
            );
            let _ = s.write_all(head.as_bytes());
            let _ = s.write_all(body);
        }
    });
    (base, asked)
}

/// A base URL nothing listens on.
fn nowhere() -> String {
    let l = TcpListener::bind("127.0.0.1:0").unwrap();
    let url = format!("http://{}", l.local_addr().unwrap());
    drop(l);
    url
}

fn runner(cache: &Path, url: &str) -> VirtualRunner {
    let spec: LinkSpec = "sim://".parse().unwrap();
    let cfg = AppConfig {
        param_meta_cache: Some(cache.to_path_buf()),
        param_meta_url: Some(url.to_string()),
        ..AppConfig::default()
    };
    let mut r = VirtualRunner::from_specs(&[spec], cfg).unwrap();
    // Heard, and its parameters downloaded.
    for _ in 0..120 {
        common::wait(&mut r, 0.5);
        if r.app.param_set().is_some_and(|s| s.complete()) {
            return r;
        }
    }
    panic!("the parameter download did not finish");
}

fn cache_file(cache: &Path) -> PathBuf {
    cache.join("param-meta").join("ArduCopter.apm.pdef.xml")
}

/// The Parameters screen with RTL_ALT selected.
fn rtl_alt_screen(r: &mut VirtualRunner) -> String {
    common::keys(r, &["2", "/", "ctrl-u"]);
    common::typed(r, "RTL_ALT");
    common::keys(r, &["enter"]);
    assert_eq!(r.app.param_selected().as_deref(), Some("RTL_ALT"));
    common::screen(r, 80, 24)
}

fn messages(r: &VirtualRunner) -> Vec<String> {
    r.app.notices.iter().map(|n| n.text.clone()).collect()
}

#[test]
fn fetched_cached_and_shown_then_used_from_the_cache_with_no_server() {
    let tmp = tempfile::tempdir().unwrap();
    let cache = tmp.path().join("mavterm");
    let (url, asked) = serve();

    let mut r = runner(&cache, &url);
    let before = rtl_alt_screen(&mut r);
    assert!(
        before.contains("no metadata: :param meta fetch, or --param-meta FILE"),
        "{before}"
    );
    assert!(!cache_file(&cache).exists());
    common::keys(&mut r, &["esc"]);
    common::command(&mut r, "param meta fetch");
    common::wait(&mut r, 0.5);
    // The sim reports a development build: the latest metadata, not a release's.
    assert_eq!(*asked.lock().unwrap(), ["/ArduCopter/apm.pdef.xml"]);
    assert_eq!(std::fs::read(cache_file(&cache)).unwrap(), fixture());
    let m = messages(&r);
    assert!(
        m.iter().any(|t| t
            == &format!(
                "param meta fetch: 3 parameters described, from {url}/ArduCopter/apm.pdef.xml"
            )),
        "{m:?}"
    );
    let s = rtl_alt_screen(&mut r);
    assert!(s.contains("RTL Altitude"), "{s}");
    assert!(s.contains("The minimum alt above home"), "{s}");
    assert!(s.contains("cm"), "{s}");

    // Another run, the server gone: the cache is read once the vehicle is heard.
    let mut r = runner(&cache, &nowhere());
    let s = rtl_alt_screen(&mut r);
    assert!(s.contains("RTL Altitude"), "{s}");
    let m = messages(&r);
    assert!(
        m.iter()
            .any(|t| t.starts_with("parameter metadata: 3 parameters, from ")
                && t.ends_with("ArduCopter.apm.pdef.xml")),
        "{m:?}"
    );
}

#[test]
fn an_unreachable_server_is_told_and_leaves_no_cache_file() {
    let tmp = tempfile::tempdir().unwrap();
    let cache = tmp.path().join("mavterm");
    let url = nowhere();
    let mut r = runner(&cache, &url);
    common::command(&mut r, "param meta fetch");
    common::wait(&mut r, 0.5);
    let want = format!("param meta fetch: cannot reach {url}/ArduCopter/apm.pdef.xml: ");
    let (_, status) = r.app.ui.message.clone().expect("a status message");
    assert!(status.starts_with(&want), "{status}");
    assert!(messages(&r).iter().any(|t| t.starts_with(&want)));
    assert!(!cache_file(&cache).exists());
    assert!(r.app.cfg.param_meta.is_none());
    // The screen still says how to get it.
    let s = rtl_alt_screen(&mut r);
    assert!(s.contains("no metadata: :param meta fetch"), "{s}");
}

#[test]
fn a_missing_file_on_the_server_is_its_http_status() {
    let tmp = tempfile::tempdir().unwrap();
    let cache = tmp.path().join("mavterm");
    let (url, _) = serve();
    let mut r = runner(&cache, &format!("{url}/elsewhere"));
    common::command(&mut r, "param meta fetch");
    common::wait(&mut r, 0.5);
    let (_, status) = r.app.ui.message.clone().unwrap();
    assert_eq!(
        status,
        format!(
            "param meta fetch: {url}/elsewhere/ArduCopter/apm.pdef.xml answered HTTP 404 Not Found"
        )
    );
    assert!(!cache_file(&cache).exists());
}

/// The binary: `XDG_CACHE_HOME` says where the cache goes, `MAVTERM_PARAM_META_URL` where the
/// metadata comes from.
#[test]
fn the_binary_caches_under_xdg_cache_home() {
    let tmp = tempfile::tempdir().unwrap();
    let (url, asked) = serve();
    let script = tmp.path().join("s.txt");
    std::fs::write(
        &script,
        "20 key :\n20 text \"param meta fetch\"\n20 key enter\n25 quit\n",
    )
    .unwrap();
    common::succeed(
        std::process::Command::new(common::mavterm())
            .args(["--link", "sim://", "--headless", "--input"])
            .arg(&script)
            .env("XDG_CACHE_HOME", tmp.path().join("cache"))
            .env("MAVTERM_PARAM_META_URL", &url),
    );
    assert_eq!(*asked.lock().unwrap(), ["/ArduCopter/apm.pdef.xml"]);
    let file = tmp
        .path()
        .join("cache/mavterm/param-meta/ArduCopter.apm.pdef.xml");
    assert_eq!(std::fs::read(file).unwrap(), fixture());
}

/// A HEARTBEAT of `autopilot` (a quadrotor) from 1:1, into a core on link "x"; then
/// `param meta fetch`: what it says, whether it asked for a download, and what it sent.
fn fetch_on(
    autopilot: mavterm::dialect::MavAutopilot,
    mavtype: mavterm::dialect::MavType,
) -> (String, bool, Vec<mavterm::dialect::MavMessage>) {
    use mavterm::app::{App, Effect, Event};
    use mavterm::dialect::{self, MavMessage};
    use mavterm::link::{FrameParser, ParserStats};
    use mavterm::wire::frame::{encode, Header, Version};
    let tmp = tempfile::tempdir().unwrap();
    let mut app = App::new(AppConfig {
        links: vec!["x".into()],
        request_streams: false,
        fetch_params: false,
        param_meta_cache: Some(tmp.path().to_path_buf()),
        ..AppConfig::default()
    });
    let hb = MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype,
        autopilot,
        base_mode: dialect::MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
        system_status: dialect::MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
    });
    let frame = encode(
        Version::V2,
        Header {
            sysid: 1,
            compid: 1,
            seq: 0,
        },
        &hb,
    );
    app.update(
        0,
        Event::Frames {
            link: 0,
            frames: FrameParser::new().parse_all(&frame),
            stats: ParserStats::default(),
        },
    );
    let mut fx = Vec::new();
    for k in std::iter::once(":".to_string())
        .chain("param meta fetch".chars().map(String::from))
        .chain(std::iter::once("enter".to_string()))
    {
        let key = if k.chars().count() == 1 && k != ":" {
            mavterm::keymap::Key::ch(k.chars().next().unwrap())
        } else {
            k.parse().unwrap()
        };
        fx.extend(app.update(1_000_000, Event::Key(key)));
    }
    let fetched = fx
        .iter()
        .any(|e| matches!(e, Effect::FetchParamMeta { .. }));
    let sent = common::sent_messages(&fx);
    (app.ui.message.clone().unwrap().1, fetched, sent)
}

#[test]
fn px4_is_asked_by_component_metadata_and_vehicles_without_published_metadata_are_told_so() {
    use mavterm::dialect::{MavAutopilot, MavCmd, MavMessage, MavType};
    // PX4 (and any autopilot but ArduPilot): the vehicle is asked where its metadata is
    // (tests/px4_meta_fetch.rs follows it to the end).
    for autopilot in [
        MavAutopilot::MAV_AUTOPILOT_PX4,
        MavAutopilot::MAV_AUTOPILOT_GENERIC,
    ] {
        let (m, fetched, sent) = fetch_on(autopilot, MavType::MAV_TYPE_QUADROTOR);
        assert!(!fetched);
        assert_eq!(
            m,
            "param meta fetch: asking 1:1 for its parameter metadata (component metadata protocol)"
        );
        let asks: Vec<_> = sent
            .iter()
            .filter_map(|m| match m {
                MavMessage::COMMAND_LONG(c) => Some(c),
                _ => None,
            })
            .collect();
        assert_eq!(asks.len(), 1, "{sent:?}");
        assert_eq!(asks[0].command, MavCmd::MAV_CMD_REQUEST_MESSAGE);
        assert_eq!(asks[0].param1, 397.0, "COMPONENT_METADATA");
        assert_eq!((asks[0].target_system, asks[0].target_component), (1, 1));
    }
    let (m, fetched, _) = fetch_on(
        MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        MavType::MAV_TYPE_FLAPPING_WING,
    );
    assert!(!fetched);
    assert!(m.contains("ArduPilot publishes no metadata for a"), "{m}");
    let (m, fetched, _) = fetch_on(
        MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        MavType::MAV_TYPE_FIXED_WING,
    );
    assert!(fetched, "{m}");
    assert_eq!(
        m,
        "param meta fetch: downloading https://autotest.ardupilot.org/Parameters/ArduPlane/apm.pdef.xml"
    );
}

/// A release's own file missing (a release the server has no tree for): the latest is used, and
/// named as the origin.
#[test]
fn a_missing_release_file_falls_back_to_the_latest() {
    use mavterm::app::param_meta::{metadata_urls, MetaOrigin};
    use mavterm::app::Event;
    let tmp = tempfile::tempdir().unwrap();
    let (url, asked) = serve();
    // ArduCopter 4.5.7, official (FIRMWARE_VERSION_TYPE_OFFICIAL = 255).
    let urls = metadata_urls(&url, ("ArduCopter", "Copter"), Some(0x0405_07FF));
    let cache = tmp.path().join("c/ArduCopter.apm.pdef.xml");
    match mavterm::driver::fetch::fetch_param_meta(urls, cache.clone()) {
        Event::ParamMeta {
            origin,
            cache_path,
            result,
        } => {
            assert_eq!(
                origin,
                MetaOrigin::Url(format!("{url}/ArduCopter/apm.pdef.xml"))
            );
            assert_eq!(cache_path, cache);
            assert_eq!(result.unwrap(), fixture());
            assert!(cache.parent().unwrap().is_dir(), "made for the write");
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(
        *asked.lock().unwrap(),
        [
            "/versioned/Copter/stable-4.5.7/apm.pdef.xml",
            "/ArduCopter/apm.pdef.xml"
        ]
    );
}
