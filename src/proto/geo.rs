//! Geodesy for the map and the traffic: great-circle distance and bearing on a sphere, and a
//! local tangent-plane projection around a centre (east and north metres).
//!
//! The projection is the azimuthal equidistant one: a point's distance from the centre is its
//! great-circle distance and its direction is the initial bearing to it, so it holds across the
//! antimeridian and near the poles (only the centre's antipode has no direction), and distances
//! between points near the centre stay within a fraction of a percent of the great circle's up
//! to tens of kilometres. Pure: no I/O, no clock.

/// The sphere's radius, in metres (the mean Earth radius, as
/// [`crate::proto::telemetry::EARTH_RADIUS_M`]).
pub const EARTH_RADIUS_M: f64 = 6_371_000.0;

/// A point in degrees.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LatLon {
    pub lat: f64,
    pub lon: f64,
}

impl LatLon {
    pub const fn new(lat: f64, lon: f64) -> LatLon {
        LatLon { lat, lon }
    }

    /// From MAVLink's degrees ×1e7.
    pub fn from_e7(lat: i32, lon: i32) -> LatLon {
        LatLon::new(lat as f64 / 1e7, lon as f64 / 1e7)
    }

    /// A real position: finite, latitude within ±90°, longitude within ±180°.
    pub fn is_valid(&self) -> bool {
        self.lat.is_finite()
            && self.lon.is_finite()
            && self.lat.abs() <= 90.0
            && self.lon.abs() <= 180.0
    }
}

/// `deg` in [-180, 180).
pub fn wrap_180(deg: f64) -> f64 {
    let d = (deg + 180.0).rem_euclid(360.0) - 180.0;
    if d.is_finite() {
        d
    } else {
        0.0
    }
}

/// `deg` in [0, 360).
pub fn wrap_360(deg: f64) -> f64 {
    let d = deg.rem_euclid(360.0);
    if d.is_finite() && d < 360.0 {
        d
    } else {
        0.0
    }
}

/// The great-circle distance from `a` to `b` in metres (haversine).
pub fn distance_m(a: LatLon, b: LatLon) -> f64 {
    let (p1, p2) = (a.lat.to_radians(), b.lat.to_radians());
    let dp = p2 - p1;
    let dl = wrap_180(b.lon - a.lon).to_radians();
    let h = (dp / 2.0).sin().powi(2) + p1.cos() * p2.cos() * (dl / 2.0).sin().powi(2);
    2.0 * EARTH_RADIUS_M * h.sqrt().min(1.0).asin()
}

/// The initial bearing from `a` to `b`, degrees from north, clockwise, in [0, 360).
pub fn bearing_deg(a: LatLon, b: LatLon) -> f64 {
    let (p1, p2) = (a.lat.to_radians(), b.lat.to_radians());
    let dl = wrap_180(b.lon - a.lon).to_radians();
    let y = dl.sin() * p2.cos();
    let x = p1.cos() * p2.sin() - p1.sin() * p2.cos() * dl.cos();
    wrap_360(y.atan2(x).to_degrees())
}

/// The point `dist` metres from `from` on the initial bearing `bearing` (degrees).
pub fn destination(from: LatLon, bearing: f64, dist: f64) -> LatLon {
    let d = dist / EARTH_RADIUS_M;
    let th = bearing.to_radians();
    let p1 = from.lat.to_radians();
    let l1 = from.lon.to_radians();
    let sp2 = (p1.sin() * d.cos() + p1.cos() * d.sin() * th.cos()).clamp(-1.0, 1.0);
    let p2 = sp2.asin();
    let l2 = l1 + (th.sin() * d.sin() * p1.cos()).atan2(d.cos() - p1.sin() * sp2);
    LatLon::new(p2.to_degrees(), wrap_180(l2.to_degrees()))
}

/// A local tangent plane around `centre`: points as (east, north) metres and back.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    pub centre: LatLon,
}

impl Plane {
    pub fn new(centre: LatLon) -> Plane {
        Plane { centre }
    }

    /// `p` as (east, north) metres from the centre.
    pub fn to_en(&self, p: LatLon) -> (f64, f64) {
        let d = distance_m(self.centre, p);
        if d < 1e-9 {
            return (0.0, 0.0);
        }
        let b = bearing_deg(self.centre, p).to_radians();
        (d * b.sin(), d * b.cos())
    }

    /// The point at (east, north) metres from the centre.
    pub fn from_en(&self, east: f64, north: f64) -> LatLon {
        let d = east.hypot(north);
        if d < 1e-9 {
            return self.centre;
        }
        destination(self.centre, wrap_360(east.atan2(north).to_degrees()), d)
    }
}

/// (east, north) rotated so that `up_deg` (a bearing) points up: the screen's (right, up).
pub fn rotate(east: f64, north: f64, up_deg: f64) -> (f64, f64) {
    if up_deg == 0.0 {
        return (east, north);
    }
    let (s, c) = up_deg.to_radians().sin_cos();
    (east * c - north * s, east * s + north * c)
}

/// The screen's (right, up) back to (east, north) for a view with `up_deg` up.
pub fn unrotate(right: f64, up: f64, up_deg: f64) -> (f64, f64) {
    rotate(right, up, -up_deg)
}

/// A distance as people read it: `850 m`, `1.2 km`, `12 km`.
pub fn distance_text(m: f64) -> String {
    if !m.is_finite() {
        "--".into()
    } else if m < 1000.0 {
        format!("{m:.0} m")
    } else if m < 10_000.0 {
        format!("{:.1} km", m / 1000.0)
    } else {
        format!("{:.0} km", m / 1000.0)
    }
}

/// The arrow pointing at `bearing` degrees on a screen whose top is north.
pub fn arrow(bearing: f64) -> char {
    const ARROWS: [char; 8] = ['↑', '↗', '→', '↘', '↓', '↙', '←', '↖'];
    ARROWS[((wrap_360(bearing) + 22.5) / 45.0) as usize % 8]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wraps() {
        assert_eq!(wrap_180(190.0), -170.0);
        assert_eq!(wrap_180(-180.0), -180.0);
        assert_eq!(wrap_360(-10.0), 350.0);
        assert_eq!(wrap_360(f64::NAN), 0.0);
    }

    #[test]
    fn the_plane_round_trips() {
        for c in [
            LatLon::new(-35.3632621, 149.1652374),
            LatLon::new(0.0, 179.999),
            LatLon::new(89.99, 10.0),
        ] {
            let pl = Plane::new(c);
            for (e, n) in [(100.0, 0.0), (-2500.0, 4000.0), (30_000.0, -40_000.0)] {
                let (e2, n2) = pl.to_en(pl.from_en(e, n));
                assert!(
                    (e - e2).abs() < 1e-3 && (n - n2).abs() < 1e-3,
                    "{c:?} {e} {n}"
                );
            }
        }
    }

    #[test]
    fn arrows() {
        assert_eq!(arrow(0.0), '↑');
        assert_eq!(arrow(359.0), '↑');
        assert_eq!(arrow(90.0), '→');
        assert_eq!(arrow(200.0), '↓');
        assert_eq!(arrow(-45.0), '↖');
    }

    #[test]
    fn rotation_puts_the_heading_up() {
        // Heading east: a point east of the centre is straight up.
        let (r, u) = rotate(100.0, 0.0, 90.0);
        assert!(r.abs() < 1e-9 && (u - 100.0).abs() < 1e-9);
        let (e, n) = unrotate(r, u, 90.0);
        assert!((e - 100.0).abs() < 1e-9 && n.abs() < 1e-9);
    }
}
