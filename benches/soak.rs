//! Soak: simulated vehicles with impairments through the whole core (links, framing, loss
//! counting, registry, sessions, notices) on the virtual clock, the Overview drawn into a buffer
//! once per simulated second as the terminal would, for a set number of simulated minutes. Prints
//! per simulated minute: frames processed, the CPU time that minute took (and what share of one
//! core that is if it ran in real time), and the resident set size. A measurement, printed, not
//! asserted.
//!
//!     cargo bench --bench soak -- --vehicles 5 --minutes 10 [--size 200x60] [--spec SPEC]
//!
//! or `MAVTERM_SOAK_VEHICLES`, `MAVTERM_SOAK_MINUTES`, `MAVTERM_SOAK_SPEC`. Impairments default to
//! `loss=0.1&dup=0.01&reorder=0.02&corrupt=0.001`. Run as a test (`cargo test --benches`, no
//! `--bench` argument) it does one minute, as a smoke test.

use std::time::{Duration, Instant};

use mavterm::app::AppConfig;
use mavterm::clock::SECOND;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::LinkSpec;
use mavterm::ui::{self, Theme};

const IMPAIRMENTS: &str = "loss=0.1&dup=0.01&reorder=0.02&corrupt=0.001";

struct Options {
    spec: String,
    minutes: u64,
    size: (u16, u16),
}

fn options() -> Options {
    let env = |k: &str| std::env::var(k).ok();
    let mut vehicles: u32 =
        env("MAVTERM_SOAK_VEHICLES").map_or(5, |v| v.parse().expect("vehicles"));
    let mut minutes: u64 = env("MAVTERM_SOAK_MINUTES").map_or(10, |v| v.parse().expect("minutes"));
    let mut spec = env("MAVTERM_SOAK_SPEC");
    let mut size = (200, 60);
    let mut bench = false;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = || args.next().unwrap_or_else(|| panic!("{a} needs a value"));
        match a.as_str() {
            "--vehicles" => vehicles = value().parse().expect("--vehicles N"),
            "--minutes" => minutes = value().parse().expect("--minutes N"),
            "--spec" => spec = Some(value()),
            "--size" => {
                let v = value();
                let (w, h) = v.split_once('x').expect("--size WxH");
                size = (w.parse().expect("width"), h.parse().expect("height"));
            }
            "--bench" => bench = true,
            _ => {} // cargo's and libtest's own flags
        }
    }
    if !bench {
        minutes = 1;
    }
    Options {
        spec: spec.unwrap_or_else(|| format!("sim://?vehicles={vehicles}&{IMPAIRMENTS}")),
        minutes,
        size,
    }
}

/// CPU time this thread has used (the run is single-threaded): /proc/self/schedstat's first
/// field, in ns; `None` where there is no such file.
fn cpu_time() -> Option<Duration> {
    let s = std::fs::read_to_string("/proc/self/schedstat").ok()?;
    let ns: u64 = s.split_whitespace().next()?.parse().ok()?;
    Some(Duration::from_nanos(ns))
}

/// Resident set size in KiB (VmRSS in /proc/self/status).
fn rss_kib() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmRSS:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

fn frames(r: &VirtualRunner) -> u64 {
    r.app.links.iter().map(|l| l.parser.frames).sum()
}

fn main() {
    let o = options();
    let spec: LinkSpec = o.spec.parse().expect("link spec");
    let theme = Theme::default();
    let (w, h) = o.size;
    println!(
        "soak: {spec}, {} simulated minutes, Overview drawn at {w}x{h} once per simulated second",
        o.minutes
    );
    println!("RSS at start: {} KiB", rss_kib().unwrap_or(0));
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).expect("runner");
    println!(
        "{:>6} {:>9} {:>8} {:>8} {:>8} {:>10} {:>9} {:>8}",
        "minute", "frames", "frames/s", "wall_ms", "cpu_ms", "core%(rt)", "rss_kib", "vehicles"
    );
    let (wall0, cpu0) = (Instant::now(), cpu_time());
    let mut draws = 0u64;
    let mut last_frames = 0;
    for minute in 1..=o.minutes {
        let (wall, cpu) = (Instant::now(), cpu_time());
        let start = (minute - 1) * 60;
        for s in start + 1..=start + 60 {
            r.advance_to(s * SECOND);
            if r.app.take_dirty() {
                std::hint::black_box(ui::render_to_buffer(&r.app, w, h, &theme));
                draws += 1;
            }
        }
        let wall = wall.elapsed();
        let cpu = match (cpu_time(), cpu) {
            (Some(b), Some(a)) => b - a,
            _ => wall,
        };
        let total = frames(&r);
        let n = total - last_frames;
        last_frames = total;
        println!(
            "{minute:>6} {n:>9} {:>8.1} {:>8.1} {:>8.1} {:>9.3}% {:>9} {:>8}",
            n as f64 / 60.0,
            wall.as_secs_f64() * 1e3,
            cpu.as_secs_f64() * 1e3,
            cpu.as_secs_f64() / 60.0 * 100.0,
            rss_kib().unwrap_or(0),
            r.app.vehicles.len(),
        );
    }
    let wall = wall0.elapsed();
    let cpu = match (cpu_time(), cpu0) {
        (Some(b), Some(a)) => b - a,
        _ => wall,
    };
    let secs = (o.minutes * 60) as f64;
    let rep = r.app.report();
    let link = &rep["links"][0];
    println!(
        "total: {last_frames} frames in {} simulated s ({:.1} frames/s), {draws} draws, \
         {:.0} ms CPU ({:.3}% of a core in real time, {:.0} frames per CPU-second), \
         RSS {} KiB at the end",
        secs,
        last_frames as f64 / secs,
        cpu.as_secs_f64() * 1e3,
        cpu.as_secs_f64() / secs * 100.0,
        last_frames as f64 / cpu.as_secs_f64().max(1e-9),
        rss_kib().unwrap_or(0),
    );
    println!(
        "link: loss {}%, crc_errors {}, garbage_bytes {}, dropped {}; {} sources, {} vehicles",
        link["loss_pct"],
        link["crc_errors"],
        link["garbage_bytes"],
        link["dropped"],
        link["sources"].as_array().map_or(0, Vec::len),
        rep["vehicles"].as_array().map_or(0, Vec::len),
    );
}
