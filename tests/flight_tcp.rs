//! Flying over a real TCP link in real time: the `mavterm` binary, headless, replays typed
//! commands against `mavterm sim --listen` (a separate process): GUIDED, arm, take off to 10 m.

mod common;

use std::ffi::OsStr;

#[test]
fn guided_arm_takeoff_over_tcp_in_real_time() {
    let port = common::free_tcp_port();
    let _sim = common::sim_server(port, "");
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("fly.txt");
    // The sim's EKF uses GPS 5 s after boot; the sim booted a moment before us. The climb to
    // 10 m takes the sim 6.7 s: looked at 14 s after the takeoff, so a busy machine's delays in
    // the commands do not decide what is seen.
    std::fs::write(
        &script,
        "6 text \":mode guided\\n\"\n\
         8 text \":arm\\n\"\n\
         8.5 key y\n\
         10 text \":takeoff 10\\n\"\n\
         10.5 key y\n\
         24 snapshot overview\n\
         24.1 key 3\n\
         24.2 snapshot commands\n\
         24.3 quit\n",
    )
    .unwrap();
    let screens = dir.path().join("screens");
    let size = ["--size", "100x30", "--screens"].map(OsStr::new);
    common::headless_tcp(port, &script, size.into_iter().chain([screens.as_os_str()]));
    let overview = std::fs::read_to_string(screens.join("overview.txt")).unwrap();
    assert!(
        overview.contains("GUIDED") && overview.contains("ARMED"),
        "{overview}"
    );
    let alt = common::shown_altitude(&overview).unwrap_or_else(|| panic!("{overview}"));
    assert!((alt - 10.0).abs() <= 0.5, "{alt}: {overview}");
    let commands = std::fs::read_to_string(screens.join("commands.txt")).unwrap();
    for want in ["DO_SET_MODE", "COMPONENT_ARM_DISARM", "NAV_TAKEOFF"] {
        let line = commands
            .lines()
            .find(|l| l.contains(want))
            .unwrap_or_else(|| panic!("{want}: {commands}"));
        assert!(line.contains("ACCEPTED"), "{line}");
    }
}
