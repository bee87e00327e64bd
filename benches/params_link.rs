//! Parameter download over a simulated 57600-baud radio, on the virtual clock: simulated seconds
//! to a complete set, bytes we sent, requests and retries, by MAVFTP and by the parameter
//! protocol, at 0 % and 20 % loss of the vehicle's frames, each beside the floor the link allows.
//!
//! `cargo bench --bench params_link` prints the table (a measurement, not a criterion timing).
//!
//! Floors, for the sim's 1,354 ArduCopter parameters:
//! - link: the bytes that must come down at 5,760 bytes/s (10 bits a byte): param.pck is 15,024
//!   bytes in 63 FILE_TRANSFER_PROTOCOL frames of 266 bytes; the list is 1,354 PARAM_VALUE
//!   frames of 37 bytes.
//! - ArduPilot's pacing: a burst packet every 3000 × 266 / 5760 ms = 138 ms (GCS_FTP.cpp), and
//!   PARAM_VALUEs in 30 % of the link (GCS_Param.cpp `queued_param_send`).

use mavterm::app::AppConfig;
use mavterm::clock::SECOND;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::headless::params::{progress, Progress};
use mavterm::link::LinkSpec;

const LINK_BYTES_PER_S: f64 = 5760.0;

fn run(query: &str) -> (Progress, u64, u64) {
    let spec: LinkSpec = format!("sim://?{query}").parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    let mut t = 0;
    loop {
        t += SECOND / 10;
        r.advance_to(t);
        let p = progress(&r.app);
        if p.ended() || t > 600 * SECOND {
            let l = &r.app.links[0];
            return (p, l.sent_bytes, l.sent_frames);
        }
    }
}

fn main() {
    // `cargo test --benches` runs this too: only measure under `cargo bench`.
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    let ftp_link = 63.0 * 266.0 / LINK_BYTES_PER_S;
    let ftp_paced = 63.0 * 3.0 * 266.0 / LINK_BYTES_PER_S;
    let list_link = 1354.0 * 37.0 / LINK_BYTES_PER_S;
    let list_paced = list_link / 0.3;
    println!(
        "{:<26} {:>8} {:>10} {:>9} {:>8} {:>8} {:>11} {:>11}",
        "57600 baud",
        "seconds",
        "sent B",
        "frames",
        "requests",
        "retries",
        "link floor",
        "AP pacing"
    );
    for (name, q, floors) in [
        ("MAVFTP, 0 %", "baud=57600", (ftp_link, ftp_paced)),
        (
            "MAVFTP, 20 %",
            "baud=57600&loss=0.2&seed=3",
            (ftp_link, ftp_paced),
        ),
        (
            "param protocol, 0 %",
            "baud=57600&ftp=0",
            (list_link, list_paced),
        ),
        (
            "param protocol, 20 %",
            "baud=57600&ftp=0&loss=0.2&seed=3",
            (list_link, list_paced),
        ),
    ] {
        let (p, bytes, frames) = run(q);
        match p {
            Progress::Ended {
                missing: 0,
                secs,
                requests,
                retries,
                ..
            } => println!(
                "{name:<26} {secs:>8.1} {bytes:>10} {frames:>9} {requests:>8} {retries:>8} {:>10.1}s {:>10.1}s",
                floors.0, floors.1
            ),
            other => println!("{name:<26} incomplete: {}", other.line()),
        }
    }
}
