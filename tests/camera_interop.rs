//! Cameras and pymavlink: a camera whose every frame pymavlink packed (MAV_TYPE_CAMERA on
//! component 100, flag bits newer than our dialect, a capture_result of -1) is discovered and
//! operated, and what we send it pymavlink reads with the exact field values.

mod common;

use mavterm::app::{App, AppConfig, Effect, Event};
use mavterm::keymap::Key;
use mavterm::link::{FrameParser, ParserStats};
use mavterm::proto::vehicles::VehicleKey;
use serde_json::{json, Value};

struct Gcs {
    app: App,
    now: u64,
    seq: u8,
    /// The component whose COMMAND_LONGs are kept.
    to: u8,
}

impl Gcs {
    fn new() -> Gcs {
        Gcs {
            app: App::new(AppConfig {
                links: vec!["x".into()],
                ..AppConfig::default()
            }),
            now: 0,
            seq: 0,
            to: 100,
        }
    }

    /// Frames from 1:`compid`, packed by pymavlink; what we send back, read by pymavlink,
    /// keeping only COMMAND_LONGs to the camera.
    fn hear(&mut self, compid: u8, msgs: &[(&str, Value)]) -> Vec<Value> {
        let reqs: Vec<Value> = msgs
            .iter()
            .map(|(m, f)| {
                self.seq = self.seq.wrapping_add(1);
                json!({"sysid": 1, "compid": compid, "seq": self.seq, "msg": m, "fields": f})
            })
            .collect();
        let frames = common::pymavlink_encode(&reqs);
        let mut fx = Vec::new();
        for f in &frames {
            self.now += 10_000;
            fx.extend(self.app.update(
                self.now,
                Event::Frames {
                    link: 0,
                    frames: FrameParser::new().parse_all(f),
                    stats: ParserStats::default(),
                },
            ));
        }
        decoded(fx, self.to)
    }

    fn line(&mut self, text: &str) -> Vec<Value> {
        let mut fx = Vec::new();
        fx.extend(self.app.update(self.now, Event::Key(Key::ch(':'))));
        for c in text.chars() {
            fx.extend(self.app.update(self.now, Event::Key(Key::ch(c))));
        }
        fx.extend(
            self.app
                .update(self.now, Event::Key("enter".parse().unwrap())),
        );
        decoded(fx, self.to)
    }

    fn key(&mut self, name: &str) -> Vec<Value> {
        let fx = self.app.update(self.now, Event::Key(name.parse().unwrap()));
        decoded(fx, self.to)
    }
}

fn decoded(fx: Vec<Effect>, to: u8) -> Vec<Value> {
    let sent: Vec<Vec<u8>> = fx
        .iter()
        .filter_map(|e| match e {
            Effect::Send { frame, .. } => Some(frame.clone()),
            _ => None,
        })
        .collect();
    if sent.is_empty() {
        return Vec::new();
    }
    common::pymavlink_decode(&sent)
        .into_iter()
        .filter(|v| v["name"] == "COMMAND_LONG" && v["target_component"] == to)
        .collect()
}

fn ack(command: u64) -> (&'static str, Value) {
    (
        "COMMAND_ACK",
        json!({"command": command, "result": 0, "progress": 0, "result_param2": 0,
               "target_system": 255, "target_component": 190}),
    )
}

fn heartbeat(mavtype: u64, autopilot: u64) -> (&'static str, Value) {
    (
        "HEARTBEAT",
        json!({"type": mavtype, "autopilot": autopilot, "base_mode": 0, "custom_mode": 0,
               "system_status": 4, "mavlink_version": 3}),
    )
}

fn image(index: i64, result: i64) -> (&'static str, Value) {
    (
        "CAMERA_IMAGE_CAPTURED",
        json!({"time_boot_ms": 1000, "time_utc": 1_700_000_000_000_000u64, "camera_id": 1,
               "lat": -353632621, "lon": 1491652374, "alt": 600000, "relative_alt": 16000,
               "q": [1.0, 0.0, 0.0, 0.0], "image_index": index, "capture_result": result,
               "file_url": ""}),
    )
}

#[test]
fn a_pymavlink_camera_is_discovered_and_operated() {
    let mut g = Gcs::new();
    g.hear(1, &[heartbeat(2, 3)]);
    // The camera's heartbeat: asked for CAMERA_INFORMATION with REQUEST_MESSAGE.
    let sent = g.hear(100, &[heartbeat(30, 8)]);
    assert_eq!(sent.len(), 1, "{sent:?}");
    let c = &sent[0];
    assert_eq!(c["target_system"], 1);
    assert_eq!(c["command"], 512);
    assert_eq!(c["param1"], 259.0);
    assert_eq!(c["param2"], 0.0);
    assert_eq!(c["confirmation"], 0);
    // Flags: image, video, modes and a bit newer than our dialect (1 << 20).
    let flags = 1 | 2 | 4 | (1 << 20);
    let mut vendor = vec![0u8; 32];
    vendor[..6].copy_from_slice(b"Gremsy");
    let mut model = vec![0u8; 32];
    model[..4].copy_from_slice(b"ZIO2");
    let info = (
        "CAMERA_INFORMATION",
        json!({"time_boot_ms": 1000, "vendor_name": vendor, "model_name": model,
               "firmware_version": 0x0102_0304u32, "focal_length": 4.5, "sensor_size_h": 6.17,
               "sensor_size_v": 4.55, "resolution_h": 1920, "resolution_v": 1080, "lens_id": 2,
               "flags": flags, "cam_definition_version": 0, "cam_definition_uri": "",
               "gimbal_device_id": 0}),
    );
    let sent = g.hear(100, &[ack(512), info]);
    // The next request: CAMERA_SETTINGS.
    assert_eq!(sent.len(), 1, "{sent:?}");
    assert_eq!(
        (sent[0]["command"].clone(), sent[0]["param1"].clone()),
        (json!(512), json!(260.0))
    );
    let settings = (
        "CAMERA_SETTINGS",
        json!({"time_boot_ms": 1000, "mode_id": 0, "zoomLevel": 0.0, "focusLevel": 0.0}),
    );
    let sent = g.hear(100, &[ack(512), settings]);
    assert_eq!(sent[0]["param1"], 261.0, "{sent:?}");
    let cams = &g.app.sessions[&VehicleKey(1, 1)].cameras.cameras;
    let info = cams[&100].info.as_ref().unwrap();
    assert_eq!(
        (info.vendor.as_str(), info.model.as_str()),
        ("Gremsy", "ZIO2")
    );
    assert_eq!(info.flags, flags as u32);
    assert_eq!(info.resolution, (1920, 1080));
    assert_eq!(info.firmware, (4, 3, 2, 1));
    assert_eq!(cams[&100].settings.unwrap().mode, 0);

    // Operate: 2 images 0.5 s apart. pymavlink reads exactly what the protocol asks for.
    let sent = g.line("camera shoot 2 0.5");
    assert_eq!(sent.len(), 1, "{sent:?}");
    let c = &sent[0];
    assert_eq!(c["command"], 2000);
    assert_eq!(c["target_system"], 1);
    assert_eq!(
        [&c["param1"], &c["param2"], &c["param3"], &c["param4"]],
        [&json!(0.0), &json!(0.5), &json!(2.0), &json!(0.0)]
    );
    // Images 0 and 2 come (2 with capture_result -1, beyond MAV_BOOL); 1 is asked for again.
    g.hear(100, &[ack(2000)]);
    let sent = g.hear(100, &[image(0, 1), image(2, -1)]);
    let asked: Vec<(f64, f64)> = sent
        .iter()
        .filter(|c| c["command"] == 512)
        .map(|c| (c["param1"].as_f64().unwrap(), c["param2"].as_f64().unwrap()))
        .collect();
    // Storage was still being asked for; the capture status and the hole wait their turn.
    assert!(
        asked.is_empty() || asked[0].0 == 262.0 || asked[0] == (263.0, 1.0),
        "{asked:?}"
    );
    let cam = &g.app.sessions[&VehicleKey(1, 1)].cameras.cameras[&100];
    assert_eq!(cam.images[&2].result, -1);
    assert_eq!(cam.missing(), vec![1]);
    // Answer the open requests until the hole's request goes out.
    let mut hole = None;
    for _ in 0..6 {
        let sent = g.hear(100, &[ack(512)]);
        if let Some(c) = sent.iter().find(|c| c["param1"] == 263.0) {
            hole = Some(c["param2"].as_f64().unwrap());
            break;
        }
    }
    assert_eq!(
        hole,
        Some(1.0),
        "REQUEST_MESSAGE 263 with param2 = the missing index"
    );
    g.hear(100, &[image(1, 1)]);
    let cam = &g.app.sessions[&VehicleKey(1, 1)].cameras.cameras[&100];
    assert!(cam.missing().is_empty());
    assert_eq!(
        cam.images.keys().copied().collect::<Vec<_>>(),
        vec![0, 1, 2]
    );
}

/// A pymavlink camera over UDP (`tests/py/fake_camera.py`: an ArduCopter heartbeat on 1:1, a
/// MAV_TYPE_CAMERA on 1:100) and mavterm headless with a replay script: discovered, shown on the
/// Camera screen, and one image taken from the keyboard.
#[test]
fn a_pymavlink_camera_over_udp_is_discovered_and_shoots() {
    let dir = tempfile::tempdir().unwrap();
    let port = common::free_udp_port();
    let log = dir.path().join("camera.json");
    let script = dir.path().join("script.txt");
    std::fs::write(&script, "5 key 6\n5.2 key s\n7 snapshot camera\n7.5 quit\n").unwrap();
    let screens = dir.path().join("screens");
    // The camera first (its heartbeats go nowhere until mavterm listens), so that however slowly
    // Python starts on a busy machine, the script's times count from a camera already there.
    let _cam = common::stand_in(
        "fake_camera.py",
        &[
            "--port".into(),
            port.to_string().into(),
            "--log-out".into(),
            log.clone().into(),
            "--duration".into(),
            "20".into(),
        ],
    );
    let mut run = std::process::Command::new(common::mavterm())
        .args([
            "--link",
            &format!("udpin:127.0.0.1:{port}"),
            "--headless",
            "--input",
        ])
        .arg(&script)
        .arg("--screens")
        .arg(&screens)
        .args(["--size", "80x24"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let status = run.wait().unwrap();
    let mut err = String::new();
    use std::io::Read;
    run.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    assert!(status.success(), "{err}");
    // The camera writes its log after each command it answers: wait for the one `s` sent (it
    // may still be on its way to a busy camera when mavterm exits), not for a time.
    let start = std::time::Instant::now();
    let got: Vec<Vec<f64>> = loop {
        let got: Vec<Vec<f64>> = std::fs::read_to_string(&log)
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok())
            .unwrap_or_default();
        if got.iter().any(|c| c[0] == 2000.0)
            || start.elapsed() > std::time::Duration::from_secs(30)
        {
            break got;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    // REQUEST_MESSAGE 259 first, then the settings, storage and capture status.
    let first: Vec<(f64, f64)> = got.iter().take(4).map(|c| (c[0], c[1])).collect();
    assert_eq!(
        first,
        vec![
            (512.0, 259.0),
            (512.0, 260.0),
            (512.0, 261.0),
            (512.0, 262.0)
        ],
        "{got:?}"
    );
    // `s` on the Camera screen: one image, sequence number 1.
    let shot: Vec<&Vec<f64>> = got.iter().filter(|c| c[0] == 2000.0).collect();
    let screen = std::fs::read_to_string(screens.join("camera.txt")).unwrap_or_default();
    assert_eq!(shot.len(), 1, "{got:?}\n{screen}\n{err}");
    assert_eq!(&shot[0][1..5], &[0.0, 0.0, 1.0, 1.0]);
    let screen = std::fs::read_to_string(screens.join("camera.txt")).unwrap();
    assert!(
        screen.contains("Gremsy ZIO2") && screen.contains("1920x1080"),
        "{screen}"
    );
    assert!(
        screen.contains("BIT16") && screen.contains("last #0"),
        "{screen}"
    );
}

/// A gimbal manager whose every frame pymavlink packed (ardupilotmega dialect): an ArduCopter
/// on 1:1 with an AP_Mount-like gimbal (device 1). Our REQUEST_MESSAGE 280 and
/// DO_GIMBAL_MANAGER_PITCHYAW as pymavlink reads them, and the angles of a quaternion Python
/// computed shown on the Camera screen.
#[test]
fn a_pymavlink_gimbal_manager_is_discovered_shown_and_pointed() {
    let mut g = Gcs::new();
    g.to = 1;
    let sent = g.hear(1, &[heartbeat(2, 3)]);
    assert!(
        !sent
            .iter()
            .any(|c| c["command"] == 512 && c["param1"] == 280.0),
        "no sign of a gimbal yet: {sent:?}"
    );
    // Pitch -35°, yaw 20° right of the nose, as Python makes the quaternion.
    let q: Vec<f64> =
        serde_json::from_str(&common::py_lines("euler_to_q.py", &[], &["0 -35 20".to_string()])[0])
            .unwrap();
    let attitude = (
        "GIMBAL_DEVICE_ATTITUDE_STATUS",
        json!({"target_system": 0, "target_component": 0, "time_boot_ms": 1000,
               "flags": 4 | 8 | 32, "q": q, "angular_velocity_x": 0.0,
               "angular_velocity_y": 0.0, "angular_velocity_z": 0.0, "failure_flags": 0,
               "delta_yaw": 0.0, "delta_yaw_velocity": 0.0, "gimbal_device_id": 1}),
    );
    // The attitude of device 1 from the autopilot (ArduPilot's EXTRA3): its manager is asked.
    let sent = g.hear(1, &[attitude]);
    let ask: Vec<&Value> = sent
        .iter()
        .filter(|c| c["command"] == 512 && c["param1"] == 280.0)
        .collect();
    assert_eq!(ask.len(), 1, "{sent:?}");
    assert_eq!(ask[0]["target_system"], 1);
    for f in ["param2", "param3", "param4", "param5", "param6", "param7"] {
        assert_eq!(ask[0][f], 0.0, "{f}");
    }
    // Capability flags: pitch and yaw axes, and a bit newer than our dialect (1 << 20).
    let caps = 32 | 256 | (1 << 20);
    let rad = |d: f64| d.to_radians();
    let info = (
        "GIMBAL_MANAGER_INFORMATION",
        json!({"time_boot_ms": 1000, "cap_flags": caps, "gimbal_device_id": 1,
               "roll_min": rad(-30.0), "roll_max": rad(30.0), "pitch_min": rad(-90.0),
               "pitch_max": rad(20.0), "yaw_min": rad(-160.0), "yaw_max": rad(160.0)}),
    );
    let status = (
        "GIMBAL_MANAGER_STATUS",
        json!({"time_boot_ms": 1000, "flags": 12, "gimbal_device_id": 1,
               "primary_control_sysid": 0, "primary_control_compid": 0,
               "secondary_control_sysid": 0, "secondary_control_compid": 0}),
    );
    g.hear(1, &[ack(512), info, status]);
    let gim = &g.app.sessions[&VehicleKey(1, 1)].gimbals.gimbals[&(1, 1)];
    let a = gim.attitude.unwrap();
    assert!((a.pitch + 35.0).abs() < 0.01 && (a.yaw - 20.0).abs() < 0.01 && a.roll.abs() < 0.01);
    assert_eq!(gim.info.unwrap().cap_flags, caps as u32);
    g.key("6");
    let screen = mavterm::ui::buffer_to_text(&mavterm::ui::render_to_buffer(
        &g.app,
        80,
        24,
        &mavterm::ui::Theme::PLAIN,
    ));
    assert!(
        screen.contains("gimbal 1:1/1 pitch -35.0° roll 0.0° yaw 20.0° (nose)"),
        "{screen}"
    );
    assert!(
        screen.contains("pitch -90..20° yaw -160..160°  control nobody"),
        "{screen}"
    );
    assert!(
        screen.contains("HAS_PITCH_AXIS HAS_YAW_AXIS BIT20"),
        "{screen}"
    );
    // A key steps 5° up from the attitude heard; pymavlink reads exactly what the spec asks.
    let sent = g.key("alt-up");
    assert_eq!(sent.len(), 1, "{sent:?}");
    let c = &sent[0];
    assert_eq!(c["command"], 1000);
    assert_eq!(
        (&c["target_system"], &c["target_component"]),
        (&json!(1), &json!(1))
    );
    assert_eq!(c["param1"], -30.0);
    assert_eq!(c["param2"], 20.0);
    assert_eq!(c["param3"], "nan");
    assert_eq!(c["param4"], "nan");
    // GIMBAL_MANAGER_FLAGS_ROLL_LOCK | PITCH_LOCK | YAW_IN_VEHICLE_FRAME, device 1.
    assert_eq!(c["param5"], 44.0);
    assert_eq!(c["param6"], 0.0);
    assert_eq!(c["param7"], 1.0);
    assert_eq!(c["confirmation"], 0);
    // Beyond the manager's yaw limit (160°): not sent.
    g.hear(1, &[ack(1000)]);
    let sent = g.line("gimbal 0 170");
    assert!(sent.is_empty(), "{sent:?}");
}

/// `fake_camera.py` with `extra` arguments against mavterm headless running `script` (80x24);
/// returns the COMMAND_LONGs the camera received ([command, p1..p7]), the screens' folder and
/// the tempdir holding it.
fn camera_run(extra: &[&str], script: &str) -> (Vec<Vec<f64>>, tempfile::TempDir, String) {
    let dir = tempfile::tempdir().unwrap();
    let port = common::free_udp_port();
    let log = dir.path().join("camera.json");
    let script_path = dir.path().join("script.txt");
    std::fs::write(&script_path, script).unwrap();
    let screens = dir.path().join("screens");
    let mut a: Vec<std::ffi::OsString> = vec![
        "--port".into(),
        port.to_string().into(),
        "--log-out".into(),
        log.clone().into(),
        "--duration".into(),
        "20".into(),
    ];
    a.extend(extra.iter().map(|s| s.into()));
    let _cam = common::stand_in("fake_camera.py", &a);
    let run = std::process::Command::new(common::mavterm())
        .args([
            "--link",
            &format!("udpin:127.0.0.1:{port}"),
            "--headless",
            "--input",
        ])
        .arg(&script_path)
        .arg("--screens")
        .arg(&screens)
        .args(["--size", "100x30"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr).to_string();
    assert!(run.status.success(), "{err}");
    let got = serde_json::from_str(&std::fs::read_to_string(&log).unwrap()).unwrap();
    (got, dir, err)
}

fn screen(dir: &tempfile::TempDir, name: &str) -> String {
    std::fs::read_to_string(dir.path().join("screens").join(format!("{name}.txt")))
        .unwrap_or_default()
}

/// A camera of the older protocol: REQUEST_MESSAGE 260/261 denied, only
/// MAV_CMD_REQUEST_CAMERA_SETTINGS (522) and MAV_CMD_REQUEST_STORAGE_INFORMATION (525) served.
/// Both are asked (param1 = 1; param1 = 0 all storages, param2 = 1) and the storage is shown.
#[test]
fn a_camera_that_answers_only_522_and_525_shows_its_storage() {
    let (got, dir, err) = camera_run(&["--legacy"], "5 key 6\n8 snapshot camera\n8.5 quit\n");
    let s = screen(&dir, "camera");
    assert!(
        got.iter().any(|c| c[0] == 522.0 && c[1] == 1.0),
        "{got:?}\n{err}"
    );
    assert!(
        got.iter()
            .any(|c| c[0] == 525.0 && c[1] == 0.0 && c[2] == 1.0),
        "{got:?}"
    );
    assert!(s.contains("storage") && !s.contains("storage ?"), "{s}");
    assert!(s.contains("free of"), "{s}");
}

/// A camera whose image indices start at 1: after one shot (index 1, count 1) image 0 is asked
/// for once, denied, and never again; the numbering is said to be off, once.
#[test]
fn image_indices_from_1_are_not_asked_for_image_0_again() {
    let (got, dir, err) = camera_run(
        &["--first-index", "1"],
        "5 key 6\n5.2 key s\n13 snapshot camera\n13.2 key 1\n13.4 snapshot main\n13.6 quit\n",
    );
    let asks_0: Vec<&Vec<f64>> = got
        .iter()
        .filter(|c| c[0] == 512.0 && c[1] == 263.0 && c[2] == 0.0)
        .collect();
    assert_eq!(asks_0.len(), 1, "{got:?}\n{err}");
    let main = screen(&dir, "main");
    assert_eq!(main.matches("numbering starts at 1").count(), 1, "{main}");
}

/// A camera alone on system 2 (no autopilot there): it becomes the target, the Camera screen
/// shows it, and `s` shoots: IMAGE_START_CAPTURE reaches 2:100 as pymavlink reads it.
#[test]
fn a_camera_alone_on_sysid_2_is_selected_and_shot_from_screen_6() {
    let (got, dir, err) = camera_run(
        &["--sysid", "2", "--alone"],
        "5 key 6\n5.2 key s\n7 snapshot camera\n7.5 quit\n",
    );
    let s = screen(&dir, "camera");
    let shot: Vec<&Vec<f64>> = got.iter().filter(|c| c[0] == 2000.0).collect();
    assert_eq!(shot.len(), 1, "{got:?}\n{s}\n{err}");
    assert_eq!(&shot[0][1..5], &[0.0, 0.0, 1.0, 1.0]);
    assert!(s.contains("Gremsy ZIO2"), "{s}");
}
