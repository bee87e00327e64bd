//! Rendering cost: time per full frame at 200x60 (10 vehicles, 3 links), and the bytes the
//! terminal receives per second at 80x24 with one vehicle streaming at 10 Hz when redrawing only
//! on change at 10 fps (a measurement, printed, not asserted).

#[path = "../tests/ui_fixture/mod.rs"]
mod ui_fixture;

use criterion::{criterion_group, Criterion};
use mavterm::clock::SECOND;
use mavterm::tui::draw_if_dirty;
use mavterm::ui::{self, Theme};
use ratatui::backend::TestBackend;
use ratatui::Terminal;

fn render_frame(c: &mut Criterion) {
    let d = ui_fixture::many(10, 20);
    let mut term = Terminal::new(TestBackend::new(200, 60)).unwrap();
    let theme = Theme::default();
    c.bench_function("render 200x60, 10 vehicles, 3 links", |b| {
        b.iter(|| {
            term.draw(|f| ui::render_with(&d.app, f, &theme)).unwrap();
        })
    });
}

/// One copter at 10 Hz (1 Hz heartbeat) for 60 s of virtual time, drawn at most 10 times a
/// second and only when dirty, into a crossterm backend that counts bytes.
fn bytes_per_second() {
    const SECS: u64 = 60;
    let (mut term, out) = ui_fixture::counting_terminal(80, 24);
    let mut d = ui_fixture::Drive::new(&ui_fixture::LINKS[..1]);
    d.link_state(0, 0, mavterm::app::links::LinkState::Up);
    let theme = Theme::default();
    let (mut draws, mut first) = (0u64, 0u64);
    for k in 0..SECS * 10 {
        let t = k * SECOND / 10;
        // Telemetry lands between frames.
        if k % 10 == 0 {
            d.send(t + 37_000, 0, (1, 1), &ui_fixture::copter(false, 0));
        }
        d.send(t + 41_000, 0, (1, 1), &ui_fixture::attitude());
        // The frame tick at 10 fps.
        d.tick(t + 100_000);
        if draw_if_dirty(&mut term, &mut d.app, &theme).unwrap() {
            draws += 1;
        }
        if k == 0 {
            first = out.bytes();
        }
    }
    let total = out.bytes();
    println!(
        "terminal output at 80x24, 1 vehicle at 10 Hz, fps 10, {SECS} s: {total} bytes \
         ({:.0} bytes/s; first frame {first} bytes; {draws} redraws = {:.1}/s)",
        (total - first) as f64 / (SECS as f64 - 0.1),
        draws as f64 / SECS as f64
    );
}

/// The Map screen at 200x60: 10 vehicles with 3-minute tracks, a 100-item mission (the loaded
/// file's), 50 ADS-B aircraft around them.
fn map_scene() -> ui_fixture::Drive {
    use mavterm::dialect::{self, MavMessage};
    use mavterm::mission::{MissionItem, MissionType};
    use mavterm::proto::geo::{LatLon, Plane};
    let mut d = ui_fixture::Drive::new(&ui_fixture::LINKS[..1]);
    d.link_state(0, 0, mavterm::app::links::LinkState::Up);
    let home = Plane::new(LatLon::new(-35.3632621, 149.1652374));
    let secs = 180u64;
    for s in 0..=secs {
        let t = s * SECOND;
        for v in 1..=10u8 {
            d.send(t, 0, (v, 1), &ui_fixture::copter(true, 4));
            // Each on a circle of its own, a lap in 3 minutes.
            let a = s as f64 / secs as f64 * std::f64::consts::TAU + v as f64;
            let r = 100.0 + 40.0 * v as f64;
            let p = home.from_en(r * a.sin(), r * a.cos());
            let pos = MavMessage::GLOBAL_POSITION_INT(dialect::GLOBAL_POSITION_INT_DATA {
                time_boot_ms: (t / 1000) as u32,
                lat: (p.lat * 1e7) as i32,
                lon: (p.lon * 1e7) as i32,
                alt: 604_000,
                relative_alt: 20_000,
                vx: 0,
                vy: 0,
                vz: 0,
                hdg: ((a.to_degrees() + 90.0).rem_euclid(360.0) * 100.0) as u16,
            });
            d.send(t + v as u64 * 1000, 0, (v, 1), &pos);
        }
    }
    for i in 0..50u32 {
        let a = i as f64 * 0.7;
        let p = home.from_en(3000.0 * a.sin() * (i as f64 / 50.0), 3000.0 * a.cos());
        let msg = MavMessage::ADSB_VEHICLE(dialect::ADSB_VEHICLE_DATA {
            ICAO_address: 0x40_0000 + i,
            lat: (p.lat * 1e7) as i32,
            lon: (p.lon * 1e7) as i32,
            altitude: 900_000 + i as i32 * 10_000,
            heading: ((i * 720) % 36000) as u16,
            hor_velocity: 5000,
            ver_velocity: 0,
            flags: dialect::AdsbFlags::all(),
            squawk: 1200,
            altitude_type: dialect::AdsbAltitudeType::ADSB_ALTITUDE_TYPE_PRESSURE_QNH,
            callsign: format!("TST{i:03}").as_str().into(),
            emitter_type: dialect::AdsbEmitterType::ADSB_EMITTER_TYPE_LIGHT,
            tslc: 0,
        });
        d.send(secs * SECOND + 500_000, 0, (1, 1), &msg);
    }
    let mut items = vec![MissionItem::at(
        MissionType::Mission,
        0,
        0,
        16,
        -35.3632621,
        149.1652374,
        584.0,
    )];
    for i in 1..100u16 {
        let a = i as f64 * 0.4;
        let p = home.from_en(600.0 * a.sin(), 20.0 * i as f64 - 1000.0);
        items.push(MissionItem::at(
            MissionType::Mission,
            i,
            3,
            16,
            p.lat,
            p.lon,
            20.0,
        ));
    }
    d.app.ui.mission.files[0] = Some(mavterm::app::mission::LoadedList {
        path: "bench.waypoints".into(),
        items,
        errors: Vec::new(),
    });
    d.app.ui.mission.shown = mavterm::app::mission::Shown::File;
    d.key(secs * SECOND + 600_000, "9");
    d.key(secs * SECOND + 600_000, "f");
    d
}

fn render_map(c: &mut Criterion) {
    let d = map_scene();
    assert_eq!(d.app.air.traffic.len(), 50);
    // Ten vehicles, each with its 3 minutes of track (a point a second).
    let vehicles = d.app.map_vehicles();
    assert_eq!(vehicles.len(), 10);
    for v in &vehicles {
        let n = d.app.track(v.key).len();
        assert!((175..=181).contains(&n), "{}: {n} points", v.key);
    }
    assert_eq!(d.app.map_path().len(), 99);
    let mut term = Terminal::new(TestBackend::new(200, 60)).unwrap();
    let theme = Theme::default();
    c.bench_function(
        "render map 200x60, 10 vehicles, 3-min tracks, 100 items, 50 aircraft",
        |b| {
            b.iter(|| {
                term.draw(|f| ui::render_with(&d.app, f, &theme)).unwrap();
            })
        },
    );
}

criterion_group!(benches, render_frame, render_map);

fn main() {
    bytes_per_second();
    benches();
    Criterion::default().configure_from_args().final_summary();
}
