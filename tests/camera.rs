//! Cameras (MAVLink Camera Protocol v2) on the simulated vehicle with its camera component
//! (`sim://?camera=1`, virtual clock): discovery, the Camera screen, modes, images, video, a
//! capture refused for the mode, a lost CAMERA_IMAGE_CAPTURED asked for again.

mod common;

use common::{command, sim, wait};

use mavterm::app::AppConfig;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::LinkSpec;
use mavterm::proto::commands::State;
use mavterm::proto::vehicles::VehicleKey;

const SECOND: u64 = 1_000_000;

fn runner(query: &str) -> VirtualRunner {
    let spec: LinkSpec = format!("sim://?{query}").parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    r.advance_to(6 * SECOND);
    r
}

/// Commands sent to 1:100 with this command id, and what became of them.
fn sent(r: &VirtualRunner, command: u16) -> Vec<(State, [f64; 7])> {
    r.app.sessions[&VehicleKey(1, 1)]
        .commands
        .entries()
        .filter(|e| e.spec.target == (1, 100) && e.spec.command == command)
        .map(|e| (e.state.clone(), e.spec.params))
        .collect()
}

#[test]
fn discover_switch_shoot_three_record_video() {
    let mut r = runner("camera=1");
    let s = &r.app.sessions[&VehicleKey(1, 1)];
    let cam = &s.cameras.cameras[&100];
    let info = cam.info.as_ref().expect("CAMERA_INFORMATION read");
    assert_eq!(
        (info.vendor.as_str(), info.model.as_str()),
        ("Sony", "ILX-LR1")
    );
    assert_eq!(info.resolution, (9504, 6336));
    assert!(cam.settings.is_some() && cam.storage.is_some() && cam.status.is_some());
    assert_eq!(
        cam.streams.len(),
        1,
        "HAS_VIDEO_STREAM: VIDEO_STREAM_INFORMATION asked"
    );
    // Discovery asked by REQUEST_MESSAGE, 259 first.
    let asked: Vec<f64> = sent(&r, 512).iter().map(|(_, p)| p[0]).collect();
    assert_eq!(&asked[..], &[259.0, 260.0, 261.0, 262.0, 269.0]);
    common::keys(&mut r, &["6"]);
    let screen = common::screen(&r, 80, 24);
    assert!(
        screen.contains("Sony ILX-LR1") && screen.contains("9504x6336"),
        "{screen}"
    );
    assert!(
        screen.contains("CAPTURE_IMAGE") && screen.contains("HAS_MODES"),
        "{screen}"
    );
    assert!(screen.contains("mode image"), "{screen}");
    assert!(
        screen.contains("rtsp://192.168.144.25:8554/main.264"),
        "{screen}"
    );
    insta::assert_snapshot!("camera_discovered_80x24", screen);

    // Video needs video mode: not sent in image mode.
    command(&mut r, "camera video start");
    assert!(sent(&r, 2500).is_empty());
    let msg = r.app.ui.message.clone().unwrap().1;
    assert!(
        msg.contains("image mode") && msg.contains("camera mode video"),
        "{msg}"
    );

    command(&mut r, "camera mode video");
    wait(&mut r, 1.0);
    command(&mut r, "camera mode image");
    wait(&mut r, 1.0);
    assert_eq!(sim(&r).camera(1).unwrap().mode, 0);
    let modes: Vec<(State, f64)> = sent(&r, 530).into_iter().map(|(s, p)| (s, p[1])).collect();
    assert_eq!(modes, vec![(State::Done(0), 1.0), (State::Done(0), 0.0)]);

    command(&mut r, "camera shoot 3 1");
    wait(&mut r, 4.0);
    let starts = sent(&r, 2000);
    assert_eq!(starts.len(), 1);
    assert_eq!(starts[0].0, State::Done(0));
    // IMAGE_START_CAPTURE: id 0 (all), interval 1 s, 3 images, sequence 0 (not a single shot).
    assert_eq!(starts[0].1, [0.0, 1.0, 3.0, 0.0, 0.0, 0.0, 0.0]);
    let cam = &r.app.sessions[&VehicleKey(1, 1)].cameras.cameras[&100];
    assert_eq!(
        cam.images.keys().copied().collect::<Vec<_>>(),
        vec![0, 1, 2]
    );
    assert_eq!(sim(&r).camera(1).unwrap().images_taken(), 3);
    let screen = common::screen(&r, 80, 24);
    assert!(
        screen.contains("list 0 1 2") && screen.contains("last #2"),
        "{screen}"
    );
    insta::assert_snapshot!("camera_three_images_80x24", screen);

    command(&mut r, "camera mode video");
    wait(&mut r, 1.0);
    command(&mut r, "camera video start");
    wait(&mut r, 5.0);
    assert!(sim(&r).camera(1).unwrap().recording());
    let screen = common::screen(&r, 80, 24);
    assert!(screen.contains("RECORDING 00:0"), "{screen}");
    insta::assert_snapshot!("camera_recording_80x24", screen);
    command(&mut r, "camera video stop");
    wait(&mut r, 2.0);
    assert!(!sim(&r).camera(1).unwrap().recording());
    assert_eq!(sent(&r, 2500)[0].0, State::Done(0));
    assert_eq!(sent(&r, 2501)[0].0, State::Done(0));
    let cam = &r.app.sessions[&VehicleKey(1, 1)].cameras.cameras[&100];
    assert_eq!(cam.status.unwrap().video_status, 0);
    // The card filled: three images of 8 MiB and about 5 s of video at 12 MiB/s.
    let free = cam.status.unwrap().available_mib;
    let used = 30_528.0 - free;
    assert!((24.0 + 55.0..=24.0 + 80.0).contains(&used), "{used}");
}

#[test]
fn the_camera_refuses_a_capture_in_the_wrong_mode() {
    let mut r = runner("camera=1");
    command(&mut r, "camera mode video");
    wait(&mut r, 1.0);
    // Ours does not send it...
    command(&mut r, "camera shoot");
    assert!(sent(&r, 2000).is_empty());
    let msg = r.app.ui.message.clone().unwrap().1;
    assert!(
        msg.contains("video mode") && msg.contains("not sent"),
        "{msg}"
    );
    // The Camera screen shows the shot disabled, and why.
    common::keys(&mut r, &["6"]);
    let screen = common::screen(&r, 80, 24);
    assert!(
        screen.contains("(shoot)") && screen.contains("[video start]"),
        "{screen}"
    );
    assert!(screen.contains("is in video mode"), "{screen}");
    // The screen's keys: mode back to image, one shot (a single capture: count 1, sequence 1).
    common::keys(&mut r, &["m"]);
    wait(&mut r, 1.0);
    assert_eq!(sim(&r).camera(1).unwrap().mode, 0);
    common::keys(&mut r, &["s"]);
    wait(&mut r, 1.0);
    assert_eq!(sim(&r).camera(1).unwrap().images_taken(), 1);
    let shots = sent(&r, 2000);
    assert_eq!(
        shots,
        vec![(State::Done(0), [0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0])]
    );
    // The gimbal keys point the gimbal through the autopilot (its gimbal manager).
    common::keys(&mut r, &["alt-down"]);
    wait(&mut r, 1.0);
    let gimbal: Vec<_> = r.app.sessions[&VehicleKey(1, 1)]
        .commands
        .entries()
        .filter(|e| e.spec.command == 1000)
        .map(|e| (e.spec.target, e.spec.params[0], e.spec.params[1]))
        .collect();
    assert_eq!(gimbal, vec![((1, 1), -5.0, 0.0)]);
}

#[test]
fn a_lost_image_captured_is_asked_for_again() {
    let mut r = runner("camera=1&camera_drop=1");
    command(&mut r, "camera shoot 3 1");
    wait(&mut r, 5.0);
    let again: Vec<(State, [f64; 7])> = sent(&r, 512)
        .into_iter()
        .filter(|(_, p)| p[0] == 263.0)
        .collect();
    assert_eq!(again.len(), 1, "{again:?}");
    assert_eq!(again[0].1[1], 1.0, "param2 = the missing index");
    let cam = &r.app.sessions[&VehicleKey(1, 1)].cameras.cameras[&100];
    assert_eq!(
        cam.images.keys().copied().collect::<Vec<_>>(),
        vec![0, 1, 2]
    );
    assert!(cam.missing().is_empty());
}

#[test]
fn formatting_the_storage_asks_first() {
    // MAV_CMD_STORAGE_FORMAT (526), from the MAVLink common message set.
    const STORAGE_FORMAT: u16 = 526;
    let mut r = runner("camera=1");
    command(&mut r, "camera format");
    let screen = common::screen(&r, 80, 24);
    assert!(
        screen.contains("FORMAT the storage of camera 1:100"),
        "{screen}"
    );
    common::keys(&mut r, &["n"]);
    wait(&mut r, 1.0);
    assert!(sent(&r, STORAGE_FORMAT).is_empty(), "no: nothing sent");
    command(&mut r, "camera format");
    common::yes(&mut r);
    wait(&mut r, 2.0);
    let f = sent(&r, STORAGE_FORMAT);
    assert_eq!(f.len(), 1, "{f:?}");
    assert_eq!(f[0].0, State::Done(0), "{f:?}");
}
