//! Parameters against pymavlink stand-in vehicles (tests/py/fake_param_vehicle.py) over TCP, in
//! real time, through the `mavterm` binary: `--headless --params-out` for downloads, a replay
//! script for edits. Expected values come from the stand-in's own table (what pymavlink sent),
//! never from mavterm.

mod common;

use std::collections::BTreeMap;
use std::ffi::OsStr;
use std::path::Path;
use std::process::{Command, Output};

use common::ChildGuard;

/// Start the stand-in with `args`; returns it once it listens.
fn fake(port: u16, dir: &Path, args: &[&str]) -> ChildGuard {
    let mut a: Vec<std::ffi::OsString> = vec!["--port".into(), port.to_string().into()];
    a.extend(["--table-out".into(), dir.join("table.json").into()]);
    a.extend(["--log-out".into(), dir.join("sets.json").into()]);
    a.extend(args.iter().map(|s| s.into()));
    common::stand_in("fake_param_vehicle.py", &a)
}

/// Download headless from the stand-in on `port` into `out` with `--params-out`, for `duration`
/// seconds at most.
fn params_out(port: u16, duration: &str, out: &Path) -> Output {
    Command::new(common::mavterm())
        .args([
            "--link",
            &format!("tcp:127.0.0.1:{port}"),
            "--headless",
            "--duration",
            duration,
        ])
        .arg("--params-out")
        .arg(out)
        .output()
        .unwrap()
}

/// Write `script` to `dir/script.txt`, replay it headless against the stand-in on `port` with
/// `--report json` and then `extra`; it must succeed. Returns the JSON report.
fn run_script(dir: &Path, port: u16, script: &str, extra: &[&OsStr]) -> serde_json::Value {
    let path = dir.join("script.txt");
    std::fs::write(&path, script).unwrap();
    let report = [OsStr::new("--report"), OsStr::new("json")];
    let run = common::headless_tcp(port, &path, report.iter().chain(extra));
    serde_json::from_slice(&run.stdout).unwrap()
}

/// The stand-in's table: name -> (value, MAV_PARAM_TYPE).
fn table(dir: &Path) -> BTreeMap<String, (f64, u8)> {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("table.json")).unwrap()).unwrap();
    v.as_object()
        .unwrap()
        .iter()
        .map(|(k, v)| {
            (
                k.clone(),
                (v[0].as_f64().unwrap(), v[1].as_u64().unwrap() as u8),
            )
        })
        .collect()
}

/// A `.parm` file: name -> value text.
fn parm(path: &Path) -> BTreeMap<String, String> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let mut w = l.split_whitespace();
            (w.next().unwrap().to_string(), w.next().unwrap().to_string())
        })
        .collect()
}

/// Download with `--params-out` from a stand-in started with `args`; every value must be the
/// stand-in's, integers exact, reals as the f32 it sent.
fn download_matches(args: &[&str]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let port = common::free_tcp_port();
    let _v = fake(port, dir.path(), args);
    let out = dir.path().join("got.parm");
    let run = params_out(port, "40", &out);
    let stderr = String::from_utf8_lossy(&run.stderr).to_string();
    assert!(run.status.success(), "{args:?}: {stderr}");
    let want = table(dir.path());
    let got = parm(&out);
    assert_eq!(
        got.keys().collect::<Vec<_>>(),
        want.keys().collect::<Vec<_>>(),
        "{args:?}: names"
    );
    for (name, (v, t)) in &want {
        let text = &got[name];
        if *t == 9 {
            let g: f32 = text.parse().unwrap();
            assert_eq!(g, *v as f32, "{name}: {text} vs {v}");
        } else {
            // Integers print without a fraction and exactly.
            assert_eq!(text, &format!("{}", *v as i64), "{name}");
        }
    }
    stderr
}

#[test]
fn ardupilot_list_with_loss_duplicates_and_a_change_by_another_gcs() {
    let err = download_matches(&[
        "--caps",
        "8192", // MAVLINK2 only: no FTP, no encoding bit
        "--loss",
        "0.2",
        "--dup",
        "10",
        "--change",
        "AP_I16_001=1234",
    ]);
    assert!(err.contains("parameter protocol"), "{err}");
}

#[test]
fn a_param_count_that_grows_mid_download_is_followed() {
    let err = download_matches(&["--caps", "8192", "--count-change", "7"]);
    assert!(err.contains("parameters 207/207"), "{err}");
}

#[test]
fn px4_bytewise_int32_by_heartbeat() {
    // No AUTOPILOT_VERSION: the HEARTBEAT's autopilot (PX4) decides. PX4 serves no
    // `@PARAM/param.pck` (ArduPilot's), so its profile goes straight to the parameter protocol:
    // the stand-in's NAK is never asked for.
    let err = download_matches(&["--autopilot", "px4", "--ftp", "nak"]);
    assert!(!err.contains("file not found"), "{err}");
    assert!(err.contains("parameter protocol"), "{err}");
}

#[test]
fn autopilot_version_bytewise_bit_overrides_an_ardupilot_heartbeat() {
    // An ArduPilot heartbeat whose AUTOPILOT_VERSION announces PARAM_ENCODE_BYTEWISE (16): the
    // values come bytewise, and mavterm must read them so.
    download_matches(&[
        "--autopilot",
        "px4",
        "--heartbeat",
        "ardupilot",
        "--caps",
        "16",
    ]);
}

#[test]
fn autopilot_version_c_cast_bit_overrides_a_px4_heartbeat() {
    // A PX4 heartbeat whose AUTOPILOT_VERSION announces PARAM_ENCODE_C_CAST (131072).
    download_matches(&["--heartbeat", "px4", "--caps", "131072"]);
}

/// Run a replay script against a stand-in started with `args`; returns the JSON report and the
/// PARAM_SETs the stand-in received (name -> count).
fn replay(args: &[&str], script: &str) -> (serde_json::Value, BTreeMap<String, u64>) {
    let dir = tempfile::tempdir().unwrap();
    let port = common::free_tcp_port();
    let _v = fake(port, dir.path(), args);
    let report = run_script(
        dir.path(),
        port,
        script,
        &[OsStr::new("--screens"), dir.path().as_os_str()],
    );
    let sets = std::fs::read_to_string(dir.path().join("sets.json"))
        .map(|t| serde_json::from_str::<BTreeMap<String, u64>>(&t).unwrap())
        .unwrap_or_default();
    (report, sets)
}

/// The report's edit of `name` on the autopilot.
fn edit<'a>(report: &'a serde_json::Value, name: &str) -> &'a serde_json::Value {
    report["params"][0]["components"][0]["edits"]
        .as_array()
        .unwrap()
        .iter()
        .find(|e| e["name"] == name)
        .unwrap_or_else(|| panic!("no edit of {name}: {report}"))
}

const SET_SCRIPT: &str = "3 text \":param set AP_I16_001 77\\n\"\n9 quit\n";

#[test]
fn param_set_echoed_is_confirmed() {
    let (r, sets) = replay(&["--caps", "8192"], SET_SCRIPT);
    let e = edit(&r, "AP_I16_001");
    assert_eq!(e["state"], "confirmed", "{e}");
    assert_eq!(e["vehicle_value"], 77.0);
    assert_eq!(sets["AP_I16_001"], 1);
}

#[test]
fn param_set_whose_echo_is_lost_is_sent_again() {
    let (r, sets) = replay(&["--caps", "8192", "--set", "lose-first"], SET_SCRIPT);
    assert_eq!(edit(&r, "AP_I16_001")["state"], "confirmed");
    assert_eq!(sets["AP_I16_001"], 2);
}

#[test]
fn param_set_refused_shows_failed_after_one_resend() {
    // The vehicle echoes its old value (-300): resent once (it may have been stale), then failed.
    let (r, sets) = replay(&["--caps", "8192", "--set", "refuse"], SET_SCRIPT);
    let e = edit(&r, "AP_I16_001");
    assert_eq!(e["state"], "failed", "{e}");
    assert_eq!(e["reason"], "refused: the vehicle kept -300");
    assert_eq!(e["vehicle_value"], -300.0);
    assert_eq!(sets["AP_I16_001"], 2);
}

#[test]
fn param_set_never_answered_fails_after_three_resends() {
    let (r, sets) = replay(&["--caps", "8192", "--set", "silent"], SET_SCRIPT);
    let e = edit(&r, "AP_I16_001");
    assert_eq!(e["state"], "failed", "{e}");
    assert_eq!(sets["AP_I16_001"], 4);
}

#[test]
fn params_out_exits_non_zero_with_the_missing_count() {
    // Every PARAM_VALUE lost: the set never completes, and the exit says so.
    let dir = tempfile::tempdir().unwrap();
    let port = common::free_tcp_port();
    let _v = fake(port, dir.path(), &["--caps", "8192", "--loss", "1.0"]);
    let out = dir.path().join("got.parm");
    let run = params_out(port, "15", &out);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success(), "{stderr}");
    assert!(!out.exists());
    assert!(
        stderr.contains("no parameter came from the vehicle"),
        "{stderr}"
    );
}

/// A vehicle of another stack (HEARTBEAT autopilot GENERIC, no AUTOPILOT_VERSION, so no
/// PARAM_ENCODE_* bit): the parameter protocol's default, bytewise. Its INT32 values −1,
/// 2^24+1, INT32_MAX and INT32_MIN (NaN, a tiny fraction, NaN and −0 as C-cast floats) read
/// exactly, and no MAVFTP parameter file is asked of it (only ArduPilot serves one).
#[test]
fn a_generic_vehicle_s_bytewise_int32_values_read_exactly() {
    let err = download_matches(&["--autopilot", "generic"]);
    assert!(!err.contains("looks wrong"), "{err}");
    assert!(!err.contains("MAVFTP"), "{err}");
}

/// Replay `script` against a generic (bytewise) stand-in; each `(name, value)` of `want` must
/// arrive exactly in the stand-in's table and its edit be confirmed with that vehicle value.
/// Returns the JSON report.
fn write_generic(script: &str, want: &[(&str, f64)]) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    let port = common::free_tcp_port();
    let _v = fake(port, dir.path(), &["--autopilot", "generic"]);
    let report = run_script(dir.path(), port, script, &[]);
    let held = table(dir.path());
    for &(name, v) in want {
        assert_eq!(
            held[name].0, v,
            "{name}: the vehicle holds {}",
            held[name].0
        );
        let e = edit(&report, name);
        assert_eq!(e["state"], "confirmed", "{e}");
        assert_eq!(e["vehicle_value"], v, "{e}");
    }
    report
}

/// Written to the generic vehicle: each value arrives exact (the stand-in decodes bytewise, as
/// the protocol says) and its echo is confirmed.
#[test]
fn a_generic_vehicle_s_int32_values_are_written_exactly() {
    let script = "3 text \":param set INT_BIG 16777219\\n\"\n\
                  3.2 text \":param set INT_NEG_BIG -2147483647\\n\"\n\
                  3.4 text \":param set INT_MAX 2147483646\\n\"\n\
                  3.6 text \":param set INT_ONE 5\\n\"\n\
                  3.8 text \":param set INT_MINUS1 -2\\n\"\n\
                  8 quit\n";
    let want = [
        ("INT_BIG", 16_777_219.0),
        ("INT_NEG_BIG", -2_147_483_647.0),
        ("INT_MAX", 2_147_483_646.0),
        ("INT_ONE", 5.0),
        ("INT_MINUS1", -2.0),
    ];
    let report = write_generic(script, &want);
    assert_eq!(report["params"][0]["encoding"], "bytewise");
}

/// The exact INT32 values written to the generic vehicle (bytewise), each onto a
/// parameter that holds another value: −1, 2^24 + 1, INT32_MAX and INT32_MIN arrive exactly in
/// the stand-in's own table, and each echo is confirmed.
#[test]
fn a_generic_vehicle_takes_minus_one_2_24_plus_1_and_the_int32_limits_exactly() {
    let script = "3 text \":param set INT_ONE -1\\n\"\n\
                  3.2 text \":param set INT_MINUS1 16777217\\n\"\n\
                  3.4 text \":param set INT_BIG 2147483647\\n\"\n\
                  3.6 text \":param set INT_MAX -2147483648\\n\"\n\
                  8 quit\n";
    let want = [
        ("INT_ONE", -1.0),
        ("INT_MINUS1", 16_777_217.0),
        ("INT_BIG", 2_147_483_647.0),
        ("INT_MAX", -2_147_483_648.0),
    ];
    write_generic(script, &want);
}

/// Run `script` with screens saved to `dir/screens` at 160 columns; returns the report.
fn replay_screens(dir: &Path, port: u16, script: &str) -> serde_json::Value {
    let screens = dir.join("screens");
    let extra = ["--size", "160x30", "--screens"].map(OsStr::new);
    run_script(
        dir,
        port,
        script,
        &[extra[0], extra[1], extra[2], screens.as_os_str()],
    )
}

/// C-cast (ArduPilot) carries whole numbers exactly only up to 2^24: 2^24+1 is refused before
/// anything is sent, with the reason, and never blamed on the vehicle.
#[test]
fn c_cast_refuses_two_to_the_24_plus_one_before_sending() {
    let dir = tempfile::tempdir().unwrap();
    let port = common::free_tcp_port();
    let _v = fake(port, dir.path(), &["--caps", "8192"]);
    let r = replay_screens(
        dir.path(),
        port,
        "3 text \":param set AP_I32_002 16777217\\n\"\n3.5 snapshot refused\n4 quit\n",
    );
    let sets = std::fs::read_to_string(dir.path().join("sets.json")).unwrap_or_default();
    assert!(!sets.contains("AP_I32_002"), "sent anyway: {sets}");
    let screen = std::fs::read_to_string(dir.path().join("screens/refused.txt")).unwrap();
    assert!(
        screen.contains("16777217 cannot be sent exactly"),
        "{screen}"
    );
    assert_eq!(r["params"][0]["encoding"], "C-cast");
    assert_eq!(table(dir.path())["AP_I32_002"].0, 16_777_216.0);
}

/// An echo whose float is one bit off the one sent decodes to the same integer C-cast, yet it is
/// not what was sent: not confirmed (resent once, as any other mismatch, then failed).
#[test]
fn an_echo_whose_raw_bits_differ_is_not_confirmed() {
    let (r, sets) = replay(&["--caps", "8192", "--set", "nudge"], SET_SCRIPT);
    let e = edit(&r, "AP_I16_001");
    assert_eq!(e["state"], "failed", "{e}");
    assert!(
        e["reason"].as_str().unwrap().contains("not confirmed"),
        "{e}"
    );
    assert_eq!(sets["AP_I16_001"], 2);
}

/// The stand-in's arguments for a PX4 (bytewise) vehicle whose HEARTBEAT says ArduPilot, with no
/// MAVFTP parameter file.
const BYTEWISE_AS_ARDUPILOT: [&str; 6] = [
    "--autopilot",
    "px4",
    "--heartbeat",
    "ardupilot",
    "--ftp",
    "nak",
];

/// A vehicle announcing ArduPilot whose values come bytewise, with no AUTOPILOT_VERSION to say
/// so: the first impossible C-cast float is told once as "encoding looks wrong", and `param
/// encoding bytewise` at the prompt reads every value right.
#[test]
fn encoding_that_looks_wrong_is_told_and_switched_at_the_prompt() {
    let dir = tempfile::tempdir().unwrap();
    let port = common::free_tcp_port();
    let _v = fake(port, dir.path(), &BYTEWISE_AS_ARDUPILOT);
    let r = replay_screens(dir.path(), port, "5 quit\n");
    let suspect = r["params"][0]["encoding_suspect"].as_str().unwrap_or("");
    assert!(suspect.contains("bytewise it would be"), "{r}");
    assert_eq!(r["params"][0]["encoding"], "C-cast");
    drop(_v);
    // Again, switched at the prompt: every INT32 as the vehicle holds it.
    let port = common::free_tcp_port();
    let _v = fake(port, dir.path(), &BYTEWISE_AS_ARDUPILOT);
    let out = dir.path().join("after.parm");
    let script = format!(
        "5 text \":param encoding bytewise\\n\"\n5.5 text \":param save {}\\n\"\n6.5 quit\n",
        out.display()
    );
    let r = replay_screens(dir.path(), port, &script);
    assert_eq!(r["params"][0]["encoding"], "bytewise");
    assert_eq!(r["params"][0]["encoding_by"], "the operator");
    let got = parm(&out);
    for (name, (v, t)) in table(dir.path()) {
        if t == 6 {
            assert_eq!(got[&name], format!("{}", v as i64), "{name}");
        }
    }
}

/// MAVFTP given up (AUTOPILOT_VERSION says no FTP while the open is unanswered), and then the
/// vehicle ACKs the open after all with session 3: mavterm closes it with TerminateSession
/// (opcode 1) of session 3, as pymavlink reads the request, so no session is left open.
#[test]
fn a_session_opened_after_the_fallback_is_terminated() {
    let dir = tempfile::tempdir().unwrap();
    let port = common::free_tcp_port();
    let log = dir.path().join("ftp.json");
    let log_arg = log.display().to_string();
    let _v = fake(
        port,
        dir.path(),
        &["--caps", "8192", "--ftp", "late-ack", "--ftp-log", &log_arg],
    );
    let r = replay_screens(dir.path(), port, "4 quit\n");
    assert_eq!(
        r["params"][0]["download"]["method"], "parameter protocol",
        "{r}"
    );
    let got: Vec<Vec<u64>> = serde_json::from_str(&std::fs::read_to_string(&log).unwrap()).unwrap();
    // [seq, session, opcode]: the open (4), then after the late ACK a TerminateSession (1) of
    // session 3.
    let open = got.iter().position(|p| p[2] == 4).expect("an OpenFileRO");
    assert!(
        got[open..].iter().any(|p| p[2] == 1 && p[1] == 3),
        "{got:?}"
    );
}
