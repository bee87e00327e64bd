//! The Map screen (`9`): the projection against an independent great-circle truth
//! (`tests/py/geo_truth.py`, textbook haversine) and known distances across the antimeridian
//! and near the poles; the screen on a simulated flight with a mission, fence, rally points and
//! two ADS-B aircraft (snapshots at 80x24 and 200x60, and 60x16); following, panning, zooming and
//! fitting; a go-to from the cursor, read back by pymavlink; a waypoint added at the cursor;
//! stale traffic dimmed and dropped; the proximity warning; the sim's traffic as the core sees it.

mod common;

use common::{command, hear, keys, screen, sim, wait};
use mavterm::app::mission::{LoadedList, Shown};
use mavterm::app::{App, AppConfig, Effect, Event};
use mavterm::dialect::{self, MavMessage};
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::keymap::Key;
use mavterm::mission::{MissionItem, MissionType};
use mavterm::proto::geo::{LatLon, Plane};
use mavterm::proto::vehicles::VehicleKey;
use mavterm::ui::{buffer_to_text, render_to_buffer, Theme};
use ratatui::buffer::Buffer;
use ratatui::style::{Color, Modifier};

const SECOND: u64 = 1_000_000;
/// One degree of a great circle on the 6371 km sphere, metres (π·R/180).
const DEG_M: f64 = 111_194.926_644_558_7;

fn runner(q: &str) -> VirtualRunner {
    let spec = format!("sim://{q}").parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    // Home is set when the EKF uses GPS (5 s).
    r.advance_to(6 * SECOND);
    r
}

/// The truth for pairs of points: (distance m, bearing °) each.
fn truth(pairs: &[(LatLon, LatLon)]) -> Vec<(f64, f64)> {
    let lines: Vec<String> = pairs
        .iter()
        .map(|(a, b)| serde_json::json!({"a": [a.lat, a.lon], "b": [b.lat, b.lon]}).to_string())
        .collect();
    common::py_lines("geo_truth.py", &[], &lines)
        .iter()
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).unwrap();
            (v["d"].as_f64().unwrap(), v["b"].as_f64().unwrap())
        })
        .collect()
}

#[test]
fn projected_distances_are_the_great_circle_within_half_a_percent_up_to_50_km() {
    // Centres at mid latitudes, on the equator, by the antimeridian and near both poles; points
    // around each up to 25 km from it, so pairs up to 50 km apart.
    let centres = [
        LatLon::new(-35.3632621, 149.1652374),
        LatLon::new(51.5, -0.12),
        LatLon::new(0.0, 0.0),
        LatLon::new(10.0, 179.95),
        LatLon::new(-60.0, -179.99),
        LatLon::new(85.0, 45.0),
        LatLon::new(-88.0, 120.0),
    ];
    let mut pairs = Vec::new();
    let mut projected = Vec::new();
    for c in centres {
        let plane = Plane::new(c);
        // Points at known offsets (a fan of bearings and ranges), placed on the sphere by the
        // plane itself, then measured both ways.
        let pts: Vec<LatLon> = (0..8)
            .flat_map(|k| {
                let b = (k as f64 * 47.0 + 3.0).to_radians();
                [500.0, 5_000.0, 25_000.0].map(|r| plane.from_en(r * b.sin(), r * b.cos()))
            })
            .collect();
        for (i, a) in pts.iter().enumerate() {
            for b in pts.iter().skip(i + 1) {
                let (ea, na) = plane.to_en(*a);
                let (eb, nb) = plane.to_en(*b);
                pairs.push((*a, *b));
                projected.push((eb - ea).hypot(nb - na));
            }
            // From the centre: the projection's own distance and bearing.
            let (e, n) = plane.to_en(*a);
            pairs.push((c, *a));
            projected.push(e.hypot(n));
        }
    }
    let t = truth(&pairs);
    let mut worst = 0.0f64;
    for ((got, (want, _)), (a, b)) in projected.iter().zip(&t).zip(&pairs) {
        assert!(*want <= 50_001.0, "{a:?} {b:?} {want}");
        let err = (got - want).abs() / want;
        worst = worst.max(err);
        assert!(err < 0.005, "{a:?} → {b:?}: {got} m, truth {want} m");
    }
    assert!(worst > 0.0, "the pairs must not all be trivial");
    // The bearings from the centre are the truth's.
    for (((c, p), (_, want)), _) in pairs.iter().zip(&t).zip(&projected) {
        let (e, n) = Plane::new(*c).to_en(*p);
        if e.hypot(n) < 1.0 || !centres.contains(c) {
            continue;
        }
        let got = e.atan2(n).to_degrees().rem_euclid(360.0);
        let d = ((got - want + 540.0) % 360.0 - 180.0).abs();
        assert!(d < 1e-6, "{c:?} → {p:?}: {got}° vs {want}°");
    }
}

#[test]
fn known_distances_across_the_antimeridian_and_over_the_poles() {
    // 0.2° of longitude on the equator across ±180°: 0.2 × π·R/180, east–west.
    let plane = Plane::new(LatLon::new(0.0, 180.0));
    let (e1, n1) = plane.to_en(LatLon::new(0.0, 179.9));
    let (e2, n2) = plane.to_en(LatLon::new(0.0, -179.9));
    assert!(
        (e1 + 0.1 * DEG_M).abs() < 0.01 && n1.abs() < 0.01,
        "{e1} {n1}"
    );
    assert!(
        (e2 - 0.1 * DEG_M).abs() < 0.01 && n2.abs() < 0.01,
        "{e2} {n2}"
    );
    // Across the north pole: 89.95° N on opposite meridians are 0.1° of latitude apart, the far
    // one straight north of the centre.
    let plane = Plane::new(LatLon::new(89.95, 0.0));
    let (e, n) = plane.to_en(LatLon::new(89.95, 180.0));
    assert!(e.abs() < 0.01 && (n - 0.1 * DEG_M).abs() < 0.01, "{e} {n}");
    // And the south pole itself, 0.5° south of a centre at 89.5° S.
    let plane = Plane::new(LatLon::new(-89.5, 30.0));
    let (e, n) = plane.to_en(LatLon::new(-90.0, 0.0));
    assert!(e.abs() < 0.01 && (n + 0.5 * DEG_M).abs() < 0.01, "{e} {n}");
    // Back from the plane across the antimeridian: 1 km east of 179.999° E is in the west.
    let p = Plane::new(LatLon::new(0.0, 179.999)).from_en(1000.0, 0.0);
    assert!(p.lon < -179.99 && p.lon > -180.0, "{p:?}");
    let want = truth(&[(LatLon::new(0.0, 179.999), p)]);
    assert!((want[0].0 - 1000.0).abs() < 0.01 && (want[0].1 - 90.0).abs() < 1e-6);
}

/// Home, then six waypoints in a loop ~200 m across, a speed change between them (not on the
/// path), and an RTL.
fn mission_file() -> String {
    let mut s =
        String::from("QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t-35.3632621\t149.1652374\t584\t1\n");
    s += "1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t20\t1\n";
    let pts = [
        (0.0009, 0.0),
        (0.0009, 0.0016),
        (0.0, 0.0022),
        (-0.0009, 0.0016),
        (-0.0009, 0.0),
    ];
    for (i, (dn, de)) in pts.iter().enumerate() {
        let seq = i + 2;
        s += &format!(
            "{seq}\t0\t3\t16\t0\t0\t0\t0\t{:.7}\t{:.7}\t20\t1\n",
            -35.3632621 + dn,
            149.1652374 + de
        );
    }
    s += "7\t0\t0\t178\t1\t5\t-1\t0\t0\t0\t0\t1\n";
    s += "8\t0\t3\t16\t0\t0\t0\t0\t-35.3630000\t149.1640000\t20\t1\n";
    s += "9\t0\t0\t20\t0\t0\t0\t0\t0\t0\t0\t1\n";
    s
}

/// An inclusion polygon around it all, and an exclusion circle of 40 m.
fn fence_file() -> String {
    let mut s = String::from("QGC WPL 110\n");
    let corners = [
        (-0.0016, -0.0025),
        (0.0016, -0.0025),
        (0.0016, 0.0035),
        (-0.0016, 0.0035),
    ];
    for (i, (dn, de)) in corners.iter().enumerate() {
        s += &format!(
            "{i}\t0\t0\t5001\t4\t0\t0\t0\t{:.7}\t{:.7}\t0\t0\n",
            -35.3632621 + dn,
            149.1652374 + de
        );
    }
    s += "4\t0\t0\t5004\t40\t0\t0\t0\t-35.3626621\t149.1666374\t0\t0\n";
    s
}

fn rally_file() -> String {
    "QGC WPL 110\n\
     0\t0\t3\t5100\t0\t0\t0\t0\t-35.3645000\t149.1645000\t30\t0\n\
     1\t0\t3\t5100\t0\t0\t0\t0\t-35.3620000\t149.1675000\t30\t0\n"
        .to_string()
}

/// Settle the target's transfers.
fn settle(r: &mut VirtualRunner) {
    for _ in 0..120 {
        wait(r, 0.5);
        let s = &r.app.sessions[&VehicleKey(1, 1)];
        if !s.mission.busy() && s.mission.queued().count() == 0 {
            return;
        }
    }
    panic!("transfers still running");
}

/// The sim with the lists uploaded, flying its mission for 25 s, then two aircraft heard near it
/// (the sim's own traffic, `adsb=`, flies tracks kilometres long: it would be off this map).
fn flight() -> (VirtualRunner, tempfile::TempDir) {
    let mut r = runner("?seed=4");
    let dir = tempfile::tempdir().unwrap();
    for (word, text) in [
        ("wp", mission_file()),
        ("fence", fence_file()),
        ("rally", rally_file()),
    ] {
        let path = dir.path().join(format!("{word}.waypoints"));
        std::fs::write(&path, text).unwrap();
        command(&mut r, &format!("{word} load {}", path.display()));
        wait(&mut r, 0.1);
        command(&mut r, &format!("{word} upload"));
        settle(&mut r);
        assert!(r.app.ui.confirm.is_none(), "{:?}", r.app.ui.confirm);
    }
    command(&mut r, "wp start");
    common::yes(&mut r);
    wait(&mut r, 25.0);
    keys(&mut r, &["9"]);
    // Two aircraft on the map around the vehicle (604 m AMSL): one 100 m above (near: the
    // status bar warns), one 400 m above.
    let own = r.app.target_pos().unwrap();
    let plane = Plane::new(own);
    let now = r.now();
    for (icao, name, (e, n), alt, hdg, speed) in TRAFFIC {
        let msg = aircraft_on(icao, name, plane.from_en(e, n), alt, 0, hdg, speed);
        hear(&mut r.app, now, &msg);
    }
    (r, dir)
}

/// An aircraft heard: ICAO, callsign, (east, north) of the vehicle, altitude, heading and speed.
type Heard = (u32, &'static str, (f64, f64), f64, f64, f64);

/// The flight's aircraft.
const TRAFFIC: [Heard; 2] = [
    (0x7C6B2D, "MEDIC", (-180.0, 120.0), 704.0, 135.0, 30.0),
    (0x7C4F1A, "GLIDE", (150.0, -150.0), 1004.0, 290.0, 60.0),
];

/// The Map's canvas in a whole screen: inside the border, above the footer, left of the traffic
/// list when there is one: (left, top, right, bottom), the ends excluded.
fn canvas(buf: &Buffer) -> (u16, u16, u16, u16) {
    let (w, h) = (buf.area.width, buf.area.height);
    let word: Vec<&str> = "Traffic ".split("").filter(|c| !c.is_empty()).collect();
    let side = (1..w).find(|x| {
        word.iter()
            .enumerate()
            .all(|(i, c)| x + (i as u16) < w && buf[(x + i as u16, 2)].symbol() == *c)
    });
    (1, 2, side.map_or(w - 1, |s| s - 1), h - 3)
}

/// The canvas cells holding `symbol`, (column, row).
fn on_canvas(buf: &Buffer, symbol: &str) -> Vec<(u16, u16)> {
    let (x0, y0, x1, y1) = canvas(buf);
    let mut out = Vec::new();
    for y in y0..y1 {
        for x in x0..x1 {
            if buf[(x, y)].symbol() == symbol {
                out.push((x, y));
            }
        }
    }
    out
}

/// The cell of the target's arrow: reverse video, on the canvas.
fn target_cell(buf: &Buffer) -> (u16, u16) {
    let (x0, y0, x1, y1) = canvas(buf);
    let arrows = ["↑", "↗", "→", "↘", "↓", "↙", "←", "↖", "●"];
    let found: Vec<(u16, u16)> = (y0..y1)
        .flat_map(|y| (x0..x1).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            let c = &buf[(x, y)];
            arrows.contains(&c.symbol()) && c.modifier.contains(Modifier::REVERSED)
        })
        .collect();
    assert_eq!(found.len(), 1, "{found:?}\n{}", buffer_to_text(buf));
    found[0]
}

/// The compass rose's three rows (five cells each) at the canvas's top right.
fn rose(buf: &Buffer) -> [String; 3] {
    let (_, y0, x1, _) = canvas(buf);
    [0, 1, 2].map(|dy| {
        (x1 - 5..x1)
            .map(|x| buf[(x, y0 + dy)].symbol())
            .collect::<String>()
    })
}

/// One flight (it takes a while on the virtual clock) for the screens and the moves.
#[test]
fn a_flight_with_a_mission_fence_rally_and_traffic() {
    let (mut r, _dir) = flight();
    let s = &r.app.sessions[&VehicleKey(1, 1)];
    assert!(s.mission.current.is_some(), "flying the mission");
    assert_eq!(r.app.air.traffic.len(), 2);
    for (w, h) in [(80, 24), (200, 60)] {
        let buf = render_to_buffer(&r.app, w, h, &Theme::PLAIN);
        let text = buffer_to_text(&buf);
        assert!(text.contains("Map: following 1:1, north up"), "{text}");
        assert!(text.contains("Traffic 2"), "{text}");
        assert!(text.contains("next wp "), "{text}");
        assert!(
            text.contains("TRAFFIC MEDIC"),
            "the near one on the status bar: {text}"
        );
        // Both aircraft on the map itself (not only in the list beside it), each with its
        // callsign, where they are from the vehicle: up left, and down right.
        let planes = on_canvas(&buf, "✈");
        assert_eq!(planes.len(), 2, "{text}");
        let (vx, vy) = target_cell(&buf);
        for (_, name, (e, n), ..) in TRAFFIC {
            let &(x, y) = planes
                .iter()
                .find(|(x, y)| {
                    (1..=5).all(|i| buf[(x + i, *y)].symbol() == &name[i as usize - 1..i as usize])
                })
                .unwrap_or_else(|| panic!("{name} not on the map: {text}"));
            assert_eq!((x < vx, y < vy), (e < 0.0, n > 0.0), "{name}: {text}");
        }
        // North up: the rose as on a paper map.
        assert_eq!(rose(&buf), ["  N  ", "W · E", "  S  "], "{text}");
        insta::assert_snapshot!(format!("map_flight_{w}x{h}"), text);
    }
    without_colour_everything_is_a_symbol(&r);
    the_current_waypoint_is_marked(&r);
    keys(&mut r, &["f"]);
    insta::assert_snapshot!("map_flight_fitted_200x60", screen(&r, 200, 60));
    keys(&mut r, &["c"]);
    let radius = r.app.ui.map.radius_m;
    a_small_terminal_still_shows_the_vehicle_and_the_next_waypoint(&mut r);
    r.app.ui.map.radius_m = radius;
    follow_pan_zoom_centre_and_fit(r);
}

fn a_small_terminal_still_shows_the_vehicle_and_the_next_waypoint(r: &mut VirtualRunner) {
    // Zoomed right in, the next waypoint is off the map: pointed at from the edge, and named in
    // the footer with its distance.
    for _ in 0..4 {
        keys(r, &["z"]);
    }
    let text = screen(r, 60, 16);
    let seq = r.app.next_waypoint().unwrap().0;
    assert!(text.contains(&format!("next wp {seq}: ")), "{text}");
    let arrows = ['↑', '↗', '→', '↘', '↓', '↙', '←', '↖'];
    assert!(
        text.lines()
            .any(|l| arrows.iter().any(|a| l.contains(&format!("{a}{seq}")))),
        "no pointer to wp {seq}: {text}"
    );
    assert!(
        text.lines()
            .skip(2)
            .any(|l| l.chars().any(|c| arrows.contains(&c))),
        "{text}"
    );
    insta::assert_snapshot!("map_small_60x16", text);
}

fn without_colour_everything_is_a_symbol(r: &VirtualRunner) {
    let buf = render_to_buffer(&r.app, 120, 40, &Theme::PLAIN);
    for c in buf.content() {
        assert_eq!(c.fg, ratatui::style::Color::Reset, "{c:?}");
    }
    let text = buffer_to_text(&buf);
    // On the map: the traffic, the home, and the exclusion circle's centre marked.
    assert_eq!(on_canvas(&buf, "✈").len(), 2, "{text}");
    assert_eq!(on_canvas(&buf, "H").len(), 1, "{text}");
    assert_eq!(on_canvas(&buf, "×").len(), 1, "{text}");
}

/// The waypoint flown to now stands out (reverse video, bold) from the others, in colour and
/// without.
fn the_current_waypoint_is_marked(r: &VirtualRunner) {
    let current = r.app.map_current_seq().unwrap();
    let path = r.app.map_path();
    assert!(path.iter().any(|(s, _)| *s == current) && path.len() > 3);
    for theme in [Theme::default(), Theme::PLAIN] {
        let buf = render_to_buffer(&r.app, 200, 60, &theme);
        let (_, _, _, bottom) = canvas(&buf);
        for (seq, _) in &path {
            // Its label on the canvas (the scale bar's digits, on the last row, left out).
            let cells: Vec<&ratatui::buffer::Cell> = on_canvas(&buf, &seq.to_string())
                .into_iter()
                .filter(|(_, y)| *y + 1 < bottom)
                .map(|c| &buf[c])
                .collect();
            assert_eq!(cells.len(), 1, "wp {seq}: {}", buffer_to_text(&buf));
            let marked = cells[0]
                .modifier
                .contains(Modifier::REVERSED | Modifier::BOLD);
            assert_eq!(marked, *seq == current, "wp {seq}: {:?}", cells[0]);
            if theme.color && *seq != current {
                assert_eq!(cells[0].fg, Color::Yellow);
            }
        }
    }
}

#[test]
fn no_position_yet_says_so() {
    let mut app = App::new(AppConfig {
        links: vec!["x".into()],
        request_streams: false,
        fetch_params: false,
        ..AppConfig::default()
    });
    app.update(0, Event::Key(Key::ch('9')));
    let text = buffer_to_text(&render_to_buffer(&app, 80, 24, &Theme::PLAIN));
    assert!(text.contains("no vehicle heard yet"), "{text}");
    hear(&mut app, 0, &heartbeat());
    let text = buffer_to_text(&render_to_buffer(&app, 80, 24, &Theme::PLAIN));
    assert!(
        text.contains("no position yet: waiting for 1:1's GLOBAL_POSITION_INT"),
        "{text}"
    );
}

/// Metres north and east from `a` to `b`, by the textbook's flat-earth approximation (close
/// enough over a few hundred metres).
fn ne(a: LatLon, b: LatLon) -> (f64, f64) {
    (
        (b.lat - a.lat) * DEG_M,
        (b.lon - a.lon) * DEG_M * a.lat.to_radians().cos(),
    )
}

fn follow_pan_zoom_centre_and_fit(mut r: VirtualRunner) {
    let own = r.app.target_pos().unwrap();
    assert_eq!(r.app.map_centre(), Some(own), "follows the target");
    let radius = r.app.ui.map.radius_m;
    // Up: a quarter of the half height north; right: as far east. Following stops.
    keys(&mut r, &["up", "right"]);
    assert!(!r.app.ui.map.follow);
    let c = r.app.map_centre().unwrap();
    let (n, e) = ne(own, c);
    assert!(
        (n - radius / 4.0).abs() < 0.5 && (e - radius / 4.0).abs() < 0.5,
        "{n} {e}"
    );
    // The view stays there while the vehicle flies on.
    wait(&mut r, 5.0);
    assert_eq!(r.app.map_centre(), Some(c));
    assert_ne!(r.app.target_pos(), Some(own));
    // z / Z halve and double the scale; so do + and - without a replay.
    keys(&mut r, &["z"]);
    assert_eq!(r.app.ui.map.radius_m, radius / 2.0);
    keys(&mut r, &["Z", "Z"]);
    assert_eq!(r.app.ui.map.radius_m, radius * 2.0);
    keys(&mut r, &["+"]);
    assert_eq!(r.app.ui.map.radius_m, radius);
    keys(&mut r, &["-"]);
    assert_eq!(r.app.ui.map.radius_m, radius * 2.0);
    let text = screen(&r, 80, 24);
    assert!(text.contains("Map: panned"), "{text}");
    // c: following again.
    keys(&mut r, &["c"]);
    assert!(r.app.ui.map.follow);
    assert_eq!(r.app.map_centre(), r.app.target_pos());
    // f: the view's centre is the middle of what it fits, and it holds every waypoint.
    for _ in 0..5 {
        keys(&mut r, &["z"]);
    }
    keys(&mut r, &["f"]);
    let text = screen(&r, 200, 60);
    assert!(text.contains("Map: fitted"), "{text}");
    // Every waypoint, rally point, fence corner and the home lie within the fitted extent
    // around the centre, and the extent is no more than a tenth wider than they need.
    let c = r.app.map_centre().unwrap();
    let (hw, hh) = r.app.ui.map.fit.unwrap();
    let mut pts: Vec<LatLon> = r.app.map_path().iter().map(|p| p.1).collect();
    for t in [MissionType::Fence, MissionType::Rally] {
        pts.extend(
            r.app
                .map_list(t)
                .iter()
                .filter_map(mavterm::app::map::item_pos),
        );
    }
    pts.push(r.app.target_pos().unwrap());
    let (mut me, mut mn) = (0.0f64, 0.0f64);
    for p in &pts {
        let (n, e) = ne(c, *p);
        assert!(
            e.abs() <= hw + 0.5 && n.abs() <= hh + 0.5,
            "{p:?}: {e} {n} in {hw} {hh}"
        );
        me = me.max(e.abs());
        mn = mn.max(n.abs());
    }
    assert!(
        hw <= me * 1.11 + 1.0 && hh <= mn * 1.11 + 1.0,
        "{hw} {hh} for {me} {mn}"
    );
    // Zooming out of a fit goes on from the scale shown (on the pane as drawn): exactly half
    // of it, and the scale bar says so.
    let shown = r.app.ui.map.shown_radius();
    let fitted = metres_per_cell(&text);
    keys(&mut r, &["z"]);
    assert_eq!(r.app.ui.map.fit, None);
    assert_eq!(r.app.ui.map.radius_m, shown / 2.0);
    let text = screen(&r, 200, 60);
    assert!(text.contains("Map: panned, north up"), "{text}");
    let ratio = metres_per_cell(&text) / fitted;
    assert!((ratio - 0.5).abs() < 0.03, "{ratio}: {text}");
    // Panning out of a fit: no longer fitted, at the fit's scale, a quarter of it east.
    keys(&mut r, &["f"]);
    let text = screen(&r, 200, 60);
    assert!(text.contains("Map: fitted"), "{text}");
    let (shown, fitted) = (r.app.ui.map.shown_radius(), metres_per_cell(&text));
    let c = r.app.map_centre().unwrap();
    keys(&mut r, &["right"]);
    assert_eq!(r.app.ui.map.fit, None);
    assert_eq!(r.app.ui.map.radius_m, shown);
    let (n, e) = ne(c, r.app.map_centre().unwrap());
    assert!(n.abs() < 0.5 && (e - shown / 4.0).abs() < 0.5, "{n} {e}");
    let text = screen(&r, 200, 60);
    assert!(text.contains("Map: panned, north up"), "{text}");
    let ratio = metres_per_cell(&text) / fitted;
    assert!((ratio - 1.0).abs() < 0.03, "{ratio}: {text}");
    // h: heading up, said in the title (and drawn: `heading_up_turns_the_map_and_the_rose`).
    keys(&mut r, &["c", "h"]);
    let text = screen(&r, 80, 24);
    assert!(text.contains("heading up"), "{text}");
}

/// The scale bar's metres per cell: `├──┤ 100 m`.
fn metres_per_cell(text: &str) -> f64 {
    let line = text.lines().find(|l| l.contains('├')).expect("a scale bar");
    let bar = &line[line.find('├').unwrap()..];
    let end = bar.find('┤').unwrap();
    let cells = bar[..end].chars().count() + 1;
    let words: Vec<&str> = bar[end + '┤'.len_utf8()..].split_whitespace().collect();
    let v: f64 = words[0].parse().unwrap();
    let m = match words[1] {
        "m" => v,
        "km" => v * 1000.0,
        u => panic!("{u}"),
    };
    m / cells as f64
}

/// Flying in GUIDED at 10 m.
fn guided() -> VirtualRunner {
    let mut r = runner("");
    command(&mut r, "takeoff 10");
    common::yes(&mut r);
    wait(&mut r, 14.0);
    assert!((sim(&r).vehicle(1).unwrap().relative_alt_m() - 10.0).abs() < 0.5);
    r
}

#[test]
fn go_to_from_the_cursor_sends_do_reposition_there() {
    let mut r = guided();
    keys(&mut r, &["9", "g"]);
    assert!(
        r.app.ui.message.as_ref().unwrap().1.contains("no cursor"),
        "{:?}",
        r.app.ui.message
    );
    keys(&mut r, &["enter"]);
    let own = r.app.target_pos().unwrap();
    assert_eq!(r.app.ui.map.cursor, Some(own));
    // Each arrow moves the cursor a tenth of the half height: 3 up, 2 right = 75 m N, 50 m E.
    let step = r.app.ui.map.radius_m / 10.0;
    keys(&mut r, &["up", "up", "up", "right", "right"]);
    let c = r.app.ui.map.cursor.unwrap();
    let (n, e) = ne(own, c);
    assert!(
        (n - 3.0 * step).abs() < 0.3 && (e - 2.0 * step).abs() < 0.3,
        "{n} {e}"
    );
    // The footer: where it is, and its distance and bearing from the vehicle.
    let text = screen(&r, 100, 30);
    let d = (3.0 * step).hypot(2.0 * step);
    let b = (2.0f64).atan2(3.0).to_degrees();
    let want = format!(
        "cursor {:.6} {:.6}  {:.0} m at {:03.0}° from 1:1",
        c.lat, c.lon, d, b
    );
    assert!(text.contains(&want), "{want}\n{text}");
    let buf = render_to_buffer(&r.app, 100, 30, &Theme::PLAIN);
    let cursor_at = on_canvas(&buf, "X");
    assert_eq!(cursor_at.len(), 1, "{}", buffer_to_text(&buf));
    let now = r.now();
    let fx = r.app.update(now, Event::Key(Key::ch('g')));
    let frames: Vec<Vec<u8>> = fx
        .iter()
        .filter_map(|e| match e {
            Effect::Send { frame, .. } => Some(frame.clone()),
            _ => None,
        })
        .collect();
    let d: Vec<serde_json::Value> = common::pymavlink_decode(&frames)
        .into_iter()
        .filter(|v| v["name"] == "COMMAND_INT")
        .collect();
    assert_eq!(d.len(), 1, "{fx:?}");
    let m = &d[0];
    assert_eq!(m["command"], 192); // MAV_CMD_DO_REPOSITION
    assert_eq!(m["frame"], 3); // MAV_FRAME_GLOBAL_RELATIVE_ALT
    assert_eq!(m["x"], (c.lat * 1e7).round() as i64);
    assert_eq!(m["y"], (c.lon * 1e7).round() as i64);
    assert!((m["z"].as_f64().unwrap() - 10.0).abs() < 0.5, "{m}");
    assert_eq!(
        (m["target_system"].as_u64(), m["target_component"].as_u64()),
        (Some(1), Some(1))
    );
    // The map marks the go-to's target: `G` where the cursor was (hidden now).
    let g = r.app.guided_target().unwrap();
    assert!(mavterm::proto::geo::distance_m(g, c) < 0.05, "{g:?} {c:?}");
    keys(&mut r, &["enter"]);
    assert_eq!(r.app.ui.map.cursor, None);
    let buf = render_to_buffer(&r.app, 100, 30, &Theme::PLAIN);
    assert_eq!(on_canvas(&buf, "G"), cursor_at, "{}", buffer_to_text(&buf));
}

#[test]
fn go_to_from_the_cursor_has_the_checks_of_goto() {
    // Disarmed: refused as `goto` is, and nothing is sent.
    let mut r = runner("");
    keys(&mut r, &["9", "enter"]);
    let now = r.now();
    let fx = r.app.update(now, Event::Key(Key::ch('g')));
    assert!(!fx.iter().any(|e| matches!(
        e,
        Effect::Send {
            msg: MavMessage::COMMAND_INT(_),
            ..
        }
    )));
    let m = r.app.ui.message.clone().unwrap().1;
    assert!(m.contains("goto refused") && m.contains("not armed"), "{m}");
}

#[test]
fn a_waypoint_is_added_at_the_cursor_on_the_mission_file_list() {
    let mut r = runner("");
    keys(&mut r, &["9", "enter", "up", "up"]);
    let c = r.app.ui.map.cursor.unwrap();
    // On the vehicle's list `a` says where it works.
    keys(&mut r, &["5", "a"]);
    assert!(r.app.ui.message.as_ref().unwrap().1.contains("file list"));
    keys(&mut r, &["v", "a"]);
    let f = r.app.ui.mission.files[0].as_ref().unwrap();
    assert_eq!(f.items.len(), 2, "home, then the waypoint");
    let wp = &f.items[1];
    assert_eq!((wp.seq, wp.command, wp.frame), (1, 16, 3));
    assert_eq!(wp.x, (c.lat * 1e7).round() as i32);
    assert_eq!(wp.y, (c.lon * 1e7).round() as i32);
    assert_eq!(wp.z, 10.0, "the take-off altitude");
    let text = screen(&r, 100, 30);
    assert!(text.contains("not uploaded"), "{text}");
}

fn heartbeat() -> MavMessage {
    MavMessage::HEARTBEAT(dialect::HEARTBEAT_DATA {
        mavtype: dialect::MavType::MAV_TYPE_QUADROTOR,
        autopilot: dialect::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode: dialect::MavModeFlag::from_bits_truncate(1),
        system_status: dialect::MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
        custom_mode: 0,
    })
}

fn position(lat: f64, lon: f64, alt_m: f64) -> MavMessage {
    position_hdg(lat, lon, alt_m, 0.0)
}

/// A position with the vehicle heading `hdg` degrees.
fn position_hdg(lat: f64, lon: f64, alt_m: f64, hdg: f64) -> MavMessage {
    MavMessage::GLOBAL_POSITION_INT(dialect::GLOBAL_POSITION_INT_DATA {
        time_boot_ms: 0,
        lat: (lat * 1e7) as i32,
        lon: (lon * 1e7) as i32,
        alt: (alt_m * 1000.0) as i32,
        relative_alt: 10_000,
        vx: 0,
        vy: 0,
        vz: 0,
        hdg: (hdg * 100.0).round() as u16,
    })
}

/// `msg` from `sysid`:1 on link 0, at `now`.
fn hear_from(app: &mut App, sysid: u8, now: u64, msg: &MavMessage) {
    use mavterm::wire::frame::{decode_one, encode, Header, Version};
    let h = Header {
        sysid,
        compid: 1,
        seq: 0,
    };
    let frame = decode_one(&encode(Version::V2, h, msg)).unwrap();
    app.update(
        now,
        Event::Frames {
            link: 0,
            frames: vec![frame],
            stats: mavterm::link::ParserStats::default(),
        },
    );
}

fn aircraft(icao: u32, callsign: &str, p: LatLon, alt_m: f64, tslc: u8) -> MavMessage {
    aircraft_on(icao, callsign, p, alt_m, tslc, 270.0, 40.0)
}

/// An ADSB_VEHICLE report: heading in degrees, speed in m/s.
fn aircraft_on(
    icao: u32,
    callsign: &str,
    p: LatLon,
    alt_m: f64,
    tslc: u8,
    heading: f64,
    speed: f64,
) -> MavMessage {
    use dialect::AdsbFlags as F;
    MavMessage::ADSB_VEHICLE(dialect::ADSB_VEHICLE_DATA {
        ICAO_address: icao,
        lat: (p.lat * 1e7).round() as i32,
        lon: (p.lon * 1e7).round() as i32,
        altitude: (alt_m * 1000.0) as i32,
        heading: (heading * 100.0).round() as u16,
        hor_velocity: (speed * 100.0).round() as u16,
        ver_velocity: 0,
        flags: F::ADSB_FLAGS_VALID_COORDS
            | F::ADSB_FLAGS_VALID_ALTITUDE
            | F::ADSB_FLAGS_VALID_HEADING
            | F::ADSB_FLAGS_VALID_VELOCITY
            | F::ADSB_FLAGS_VALID_CALLSIGN,
        squawk: 0,
        altitude_type: dialect::AdsbAltitudeType::ADSB_ALTITUDE_TYPE_GEOMETRIC,
        callsign: callsign.into(),
        emitter_type: dialect::AdsbEmitterType::ADSB_EMITTER_TYPE_LIGHT,
        tslc,
    })
}

/// A core that has heard 1:1 at (-35, 149), 600 m AMSL, with `cfg`'s map settings.
fn app_with(map: mavterm::app::map::MapConfig) -> App {
    let mut app = App::new(AppConfig {
        links: vec!["x".into()],
        request_streams: false,
        fetch_params: false,
        map,
        ..AppConfig::default()
    });
    hear(&mut app, 0, &heartbeat());
    hear(&mut app, 0, &position(-35.0, 149.0, 600.0));
    app.update(0, Event::Key(Key::ch('9')));
    app
}

fn text(app: &App) -> String {
    buffer_to_text(&render_to_buffer(app, 120, 30, &Theme::PLAIN))
}

#[test]
fn stale_traffic_is_dimmed_then_dropped() {
    let mut app = app_with(mavterm::app::map::MapConfig {
        adsb_timeout: 20 * SECOND,
        ..Default::default()
    });
    let own = LatLon::new(-35.0, 149.0);
    // On the map: 150 m north, 400 m above (not near).
    let there = Plane::new(own).from_en(0.0, 150.0);
    // Heard at 1 s, its report one second old.
    hear(
        &mut app,
        SECOND,
        &aircraft(0xABC123, "QFA12", there, 1000.0, 1),
    );
    let a = app.air.traffic.get(0xABC123).unwrap();
    assert!(!a.is_stale(SECOND));
    let t = text(&app);
    assert!(t.contains("✈ QFA12") && t.contains("+400 m"), "{t}");
    assert!(t.contains("150 m 000°"), "{t}");
    // Fresh: in the traffic's colour on the map, plain in the list.
    let buf = render_to_buffer(&app, 120, 30, &Theme::default());
    let on_map = on_canvas(&buf, "✈");
    assert_eq!(on_map.len(), 1, "{}", buffer_to_text(&buf));
    assert_eq!(buf[on_map[0]].fg, Color::Magenta);
    // Older than 5 s: dimmed, on the map and in the list (still there).
    app.update(7 * SECOND, Event::Tick);
    assert!(app.air.traffic.get(0xABC123).unwrap().is_stale(app.now));
    let buf = render_to_buffer(&app, 120, 30, &Theme::default());
    let all: Vec<(u16, u16)> = buf
        .content()
        .iter()
        .enumerate()
        .filter(|(_, c)| c.symbol() == "✈")
        .map(|(i, _)| buf.pos_of(i))
        .collect();
    let on_map = on_canvas(&buf, "✈");
    assert_eq!(
        (all.len(), on_map.len()),
        (2, 1),
        "the map's and the list's"
    );
    for at in all {
        assert_eq!(
            buf[at].fg,
            Color::DarkGray,
            "stale traffic is drawn dim: {at:?}"
        );
    }
    // Without colour: dim.
    let buf = render_to_buffer(&app, 120, 30, &Theme::PLAIN);
    assert!(buf[on_canvas(&buf, "✈")[0]]
        .modifier
        .contains(Modifier::DIM));
    // 20 s after the information's time (0 s): still there at 20 s, gone after it.
    app.update(20 * SECOND, Event::Tick);
    assert_eq!(app.air.traffic.len(), 1);
    assert!(app.next_deadline() <= 20 * SECOND + 1);
    app.update(21 * SECOND, Event::Tick);
    assert_eq!(app.air.traffic.len(), 0);
    assert_eq!(app.air.traffic.expired, 1);
    let t = text(&app);
    assert!(
        !t.contains("QFA12") && t.contains("no ADS-B traffic heard"),
        "{t}"
    );
    assert!(on_canvas(&render_to_buffer(&app, 120, 30, &Theme::PLAIN), "✈").is_empty());
}

#[test]
fn traffic_near_the_target_warns_once_and_stays_on_the_status_bar() {
    let mut app = app_with(mavterm::app::map::MapConfig {
        warn_distance: 1000.0,
        warn_height: 150.0,
        ..Default::default()
    });
    let own = LatLon::new(-35.0, 149.0);
    let plane = Plane::new(own);
    // 3 km away: no warning. 800 m away but 400 m above: none either.
    hear(
        &mut app,
        SECOND,
        &aircraft(1, "FAR1", plane.from_en(3000.0, 0.0), 650.0, 0),
    );
    hear(
        &mut app,
        SECOND,
        &aircraft(2, "HIGH2", plane.from_en(800.0, 0.0), 1000.0, 0),
    );
    assert!(app.traffic_alert().is_none());
    let warnings = |app: &App| {
        app.notices
            .iter()
            .filter(|n| n.text.starts_with("traffic "))
            .count()
    };
    assert_eq!(warnings(&app), 0);
    // 800 m east, 100 m above: near.
    hear(
        &mut app,
        2 * SECOND,
        &aircraft(3, "NEAR3", plane.from_en(800.0, 0.0), 700.0, 0),
    );
    let alert = app.traffic_alert().unwrap();
    assert_eq!(alert, "TRAFFIC NEAR3 800 m +100 m");
    let t = text(&app);
    let status = t.lines().last().unwrap();
    assert!(status.contains("TRAFFIC NEAR3 800 m +100 m"), "{status}");
    let n: Vec<&str> = app
        .notices
        .iter()
        .filter(|n| n.text.starts_with("traffic "))
        .map(|n| n.text.as_str())
        .collect();
    assert_eq!(n, ["traffic NEAR3 800 m from 1:1 at 090°, +100 m"]);
    // Heard again while near: told once only.
    hear(
        &mut app,
        3 * SECOND,
        &aircraft(3, "NEAR3", plane.from_en(700.0, 0.0), 700.0, 0),
    );
    app.update(4 * SECOND, Event::Tick);
    assert_eq!(warnings(&app), 1);
    // Gone away: the warning leaves the status bar.
    hear(
        &mut app,
        5 * SECOND,
        &aircraft(3, "NEAR3", plane.from_en(4000.0, 0.0), 700.0, 0),
    );
    assert!(app.traffic_alert().is_none());
    let t = text(&app);
    assert!(!t.lines().last().unwrap().contains("TRAFFIC"), "{t}");
}

#[test]
fn the_sims_traffic_is_what_the_map_shows() {
    let mut r = runner("?adsb=3&adsb_radius=4000&adsb_alt=200");
    wait(&mut r, 2.0);
    let truth: Vec<_> = sim(&r).adsb().unwrap().aircraft.clone();
    assert_eq!(r.app.air.traffic.len(), 3);
    for a in &truth {
        let seen = r.app.air.traffic.get(a.icao).expect("every aircraft");
        assert_eq!(
            seen.callsign.as_deref(),
            Some(format!("SIM{}", a.icao).as_str())
        );
        assert_eq!(seen.squawk, Some(1200));
        assert!(seen.simulated);
        // Reported within the last second at its speed: no farther than that from the truth.
        let moved = mavterm::proto::geo::distance_m(seen.pos, a.pos());
        assert!(moved <= a.speed() * 1.05 + 0.5, "{moved} m");
        assert!((seen.alt_m.unwrap() - (584.0 + a.alt_m)).abs() < 0.01);
        assert!((seen.speed.unwrap() - a.speed()).abs() < 0.01);
    }
    keys(&mut r, &["9"]);
    let t = screen(&r, 120, 40);
    assert!(t.contains("Traffic 3"), "{t}");
}

#[test]
fn the_traffic_settings_come_from_the_config_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("config.toml");
    std::fs::write(
        &path,
        "adsb_timeout = 12\nadsb_warn_distance = 750.5\nadsb_warn_height = 90\n",
    )
    .unwrap();
    let f = mavterm::config::read(&path).unwrap();
    let mut cfg = AppConfig::default();
    f.apply(&mut cfg);
    assert_eq!(cfg.map.adsb_timeout, 12 * SECOND);
    assert_eq!((cfg.map.warn_distance, cfg.map.warn_height), (750.5, 90.0));
    let app = App::new(cfg);
    assert_eq!(app.air.traffic.timeout, 12 * SECOND);
    // Out of range: refused, each where it stands.
    std::fs::write(
        &path,
        "adsb_timeout = 0\nadsb_warn_distance = -1\nadsb_warn_height = \"high\"\n",
    )
    .unwrap();
    let e = mavterm::config::read(&path).unwrap_err().to_string();
    let lines: Vec<&str> = e.lines().collect();
    assert_eq!(lines.len(), 3, "{e}");
    assert!(
        lines[0].ends_with(":1:16: adsb_timeout: expected seconds from 1 to 3600, found 0"),
        "{e}"
    );
    assert!(
        lines[1].contains(":2:22: adsb_warn_distance: expected metres from 0 to 100000"),
        "{e}"
    );
    assert!(
        lines[2].contains(":3:20: adsb_warn_height: expected metres from 0 to 10000"),
        "{e}"
    );
}

#[test]
fn the_traffic_deadline_never_stays_in_the_past() {
    let mut app = app_with(mavterm::app::map::MapConfig {
        adsb_timeout: 10 * SECOND,
        ..Default::default()
    });
    let p = Plane::new(LatLon::new(-35.0, 149.0)).from_en(0.0, 9000.0);
    hear(
        &mut app,
        SECOND + 300_000,
        &aircraft(9, "LATE9", p, 900.0, 0),
    );
    // Due just after 11.3 s: woken then, it is gone, and the next deadline is not in the past.
    let due = app.next_deadline();
    assert!(due <= 11 * SECOND + 300_001, "{due}");
    app.update(11 * SECOND + 300_001, Event::Tick);
    assert!(app.air.traffic.is_empty());
    assert!(app.next_deadline() > 11 * SECOND + 300_001);
}

/// The file lists `kind`: `items` as a loaded file's, shown on the map.
fn load(app: &mut App, kind: MissionType, items: Vec<MissionItem>) {
    app.ui.mission.files[kind.index()] = Some(LoadedList {
        path: format!("{kind}.waypoints"),
        items,
        errors: Vec::new(),
    });
    app.ui.mission.shown = Shown::File;
}

#[test]
fn heading_up_turns_the_map_and_the_rose() {
    let mut app = app_with(Default::default());
    let own = LatLon::new(-35.0, 149.0);
    // Heading east, with waypoint 1 150 m north.
    hear(
        &mut app,
        SECOND,
        &position_hdg(own.lat, own.lon, 600.0, 90.0),
    );
    let wp = Plane::new(own).from_en(0.0, 150.0);
    let m = MissionType::Mission;
    load(
        &mut app,
        m,
        vec![
            MissionItem::at(m, 0, 0, 16, own.lat, own.lon, 600.0),
            MissionItem::at(m, 1, 3, 16, wp.lat, wp.lon, 20.0),
        ],
    );
    // The vehicle's arrow, waypoint 1's label and the rose.
    let look = |app: &App| {
        let buf = render_to_buffer(app, 120, 30, &Theme::PLAIN);
        let (vx, vy) = target_cell(&buf);
        let (_, _, _, bottom) = canvas(&buf);
        let wp: Vec<(u16, u16)> = on_canvas(&buf, "1")
            .into_iter()
            .filter(|(_, y)| y + 1 < bottom)
            .collect();
        assert_eq!(wp.len(), 1, "{}", buffer_to_text(&buf));
        let arrow = buf[(vx, vy)].symbol().to_string();
        (arrow, (vx, vy), wp[0], rose(&buf), buffer_to_text(&buf))
    };
    // North up: the arrow points east, the waypoint straight above.
    let (arrow, (vx, vy), (wx, wy), r, text) = look(&app);
    assert_eq!(arrow, "→", "{text}");
    assert!(wx.abs_diff(vx) <= 1 && wy + 5 < vy, "{text}");
    assert_eq!(r, ["  N  ", "W · E", "  S  "], "{text}");
    // Heading up: the arrow points up, the waypoint (north) to the left on the same row, the
    // rose turned a quarter left.
    app.update(2 * SECOND, Event::Key(Key::ch('h')));
    let (arrow, (vx, vy), (wx, wy), r, text) = look(&app);
    assert!(
        text.contains("Map: following 1:1, heading up 090°"),
        "{text}"
    );
    assert_eq!(arrow, "↑", "{text}");
    assert!(wy.abs_diff(vy) <= 1 && wx + 10 < vx, "{text}");
    assert_eq!(r, ["  E  ", "N · S", "  W  "], "{text}");
    // Heading north-east: north is up left, the waypoint too.
    hear(
        &mut app,
        3 * SECOND,
        &position_hdg(own.lat, own.lon, 600.0, 45.0),
    );
    let (arrow, (vx, vy), (wx, wy), r, text) = look(&app);
    assert_eq!(arrow, "↑", "{text}");
    assert!(wx + 5 < vx && wy + 3 < vy, "{text}");
    assert_eq!(r, ["N   E", "  ·  ", "W   S"], "{text}");
    // Heading south: upside down.
    hear(
        &mut app,
        4 * SECOND,
        &position_hdg(own.lat, own.lon, 600.0, 180.0),
    );
    let (_, (vx, vy), (wx, wy), r, text) = look(&app);
    assert!(wx.abs_diff(vx) <= 1 && wy > vy + 5, "{text}");
    assert_eq!(r, ["  S  ", "E · W", "  N  "], "{text}");
}

#[test]
fn every_vehicle_heard_is_drawn() {
    let mut app = app_with(Default::default());
    // 2:1 120 m east of the target, heading south.
    let p = Plane::new(LatLon::new(-35.0, 149.0)).from_en(120.0, 0.0);
    hear_from(&mut app, 2, SECOND, &heartbeat());
    hear_from(
        &mut app,
        2,
        SECOND,
        &position_hdg(p.lat, p.lon, 600.0, 180.0),
    );
    assert_eq!(app.map_vehicles().len(), 2);
    let buf = render_to_buffer(&app, 120, 30, &Theme::PLAIN);
    let text = buffer_to_text(&buf);
    assert!(text.contains("Map: following 1:1"), "{text}");
    // The target: its arrow in reverse video; the other: its arrow and system id, to the right
    // on the same row.
    let (vx, vy) = target_cell(&buf);
    assert_eq!(buf[(vx, vy)].symbol(), "↑");
    let other = on_canvas(&buf, "↓");
    assert_eq!(other.len(), 1, "{text}");
    let (x, y) = other[0];
    assert!(y == vy && x > vx + 8, "{text}");
    assert_eq!(buf[(x + 1, y)].symbol(), "2", "{text}");
    assert!(!buf[(x, y)].modifier.contains(Modifier::REVERSED));
}

#[test]
fn without_colour_inclusion_and_exclusion_fences_look_different() {
    // The same square and circle, once as inclusion and once as exclusion fences.
    let draw = |inclusion: bool| {
        let mut app = app_with(Default::default());
        let plane = Plane::new(LatLon::new(-35.0, 149.0));
        let f = MissionType::Fence;
        let (vertex, circle) = if inclusion {
            (5001, 5003)
        } else {
            (5002, 5004)
        };
        let mut items: Vec<MissionItem> = [
            (-200.0, -150.0),
            (200.0, -150.0),
            (200.0, 150.0),
            (-200.0, 150.0),
        ]
        .iter()
        .enumerate()
        .map(|(i, (e, n))| {
            let p = plane.from_en(*e, *n);
            let mut it = MissionItem::at(f, i as u16, 0, vertex, p.lat, p.lon, 0.0);
            it.params[0] = 4.0;
            it
        })
        .collect();
        let c = plane.from_en(-80.0, 40.0);
        let mut it = MissionItem::at(f, 4, 0, circle, c.lat, c.lon, 0.0);
        it.params[0] = 50.0;
        items.push(it);
        load(&mut app, f, items);
        let buf = render_to_buffer(&app, 120, 30, &Theme::PLAIN);
        for cell in buf.content() {
            assert_eq!(cell.fg, Color::Reset);
        }
        buf
    };
    let (inc, exc) = (draw(true), draw(false));
    let canvas_text = |buf: &Buffer| {
        let (x0, y0, x1, y1) = canvas(buf);
        (y0..y1)
            .map(|y| (x0..x1).map(|x| buf[(x, y)].symbol()).collect::<String>())
            .collect::<Vec<String>>()
    };
    let (ti, te) = (canvas_text(&inc), canvas_text(&exc));
    // Exclusion: its corners and the circle's centre marked; inclusion: none.
    assert_eq!(on_canvas(&inc, "×").len(), 0, "{}", ti.join("\n"));
    assert_eq!(on_canvas(&exc, "×").len(), 5, "{}", te.join("\n"));
    // And the lines themselves differ (dashed against dotted), the marks aside: on the square's
    // top edge, the row of its two top corners.
    let top = on_canvas(&exc, "×").iter().map(|(_, y)| *y).min().unwrap();
    let row = |t: &Vec<String>| t[(top - 2) as usize].clone();
    assert_ne!(row(&ti), row(&te), "\n{}\n{}", ti.join("\n"), te.join("\n"));
    let dots = |s: &str| {
        s.chars()
            .filter(|c| ('\u{2801}'..='\u{28ff}').contains(c))
            .count()
    };
    assert!(
        dots(&row(&ti)) > 10 && dots(&row(&te)) > 10,
        "both drawn:\n{}\n{}",
        ti.join("\n"),
        te.join("\n")
    );
}

#[test]
fn tracks_keep_three_minutes_at_a_point_a_second() {
    use mavterm::app::map::{TRACK_POINTS, TRACK_SECS};
    let mut r = guided();
    // Flying about for five minutes of the virtual clock.
    for k in 0..10 {
        let to = ["-35.3622 149.1652", "-35.3642 149.1662"][k % 2];
        command(&mut r, &format!("goto {to} 20"));
        if r.app.ui.confirm.is_some() {
            common::yes(&mut r);
        }
        wait(&mut r, 30.0);
    }
    let now = r.now();
    let key = VehicleKey(1, 1);
    let t = &r.app.air.tracks[&key];
    assert!(t.len() <= TRACK_POINTS);
    // A point a second over the last three minutes.
    assert!(
        (TRACK_SECS as usize - 3..=TRACK_SECS as usize + 1).contains(&t.len()),
        "{}",
        t.len()
    );
    // Kept: none older than three minutes when the last point came (within the second since).
    let (oldest, newest) = (t.front().unwrap().0, t.back().unwrap().0);
    assert!(now - newest < SECOND && oldest + TRACK_SECS * SECOND >= newest);
    for (a, b) in t.iter().zip(t.iter().skip(1)) {
        let dt = b.0 - a.0;
        assert!((SECOND..2 * SECOND).contains(&dt), "{dt}");
    }
    // Drawn: the last three minutes now.
    let drawn = r.app.track(key);
    let recent = t
        .iter()
        .filter(|(at, _)| at + TRACK_SECS * SECOND >= now)
        .count();
    assert_eq!(drawn.len(), recent);
    assert!(recent + 1 >= t.len());
    // It flew: most points differ from the one before.
    let moved = drawn.windows(2).filter(|w| w[0] != w[1]).count();
    assert!(moved > drawn.len() / 2, "{moved} of {}", drawn.len());
}
