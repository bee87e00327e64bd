//! ADS-B traffic: the aircraft ADSB_VEHICLE reports, by ICAO address, each with its age.
//!
//! A machine of the whole core (held by `App`, not by one vehicle's session): the sky is the
//! same whoever reports it, and a receiver may be a system of its own. Every ADSB_VEHICLE with
//! valid coordinates updates its aircraft (the newest report wins whichever vehicle forwards
//! it); an aircraft not heard for the timeout is dropped (counted), the report's own age
//! (`tslc`) included. At most [`MAX_AIRCRAFT`] are kept: beyond that the one heard longest ago
//! gives way (counted). Reports without valid coordinates, or with a position off the globe,
//! are counted and ignored.

use std::collections::BTreeMap;

use crate::clock::{Micros, SECOND};
use crate::dialect::{AdsbAltitudeType, AdsbFlags, MavMessage, ADSB_VEHICLE_DATA};
use crate::proto::geo::{self, LatLon};
use crate::proto::machine::{Ids, Incoming, Machine, Out};
use crate::proto::vehicles::VehicleKey;
use mavlink::MessageData;

/// Aircraft kept at most.
pub const MAX_AIRCRAFT: usize = 500;
/// Dropped when not heard for this long, by default (config `adsb_timeout`).
pub const DEFAULT_TIMEOUT: Micros = 30 * SECOND;
/// Shown dimmed once older than this.
pub const STALE_AFTER: Micros = 5 * SECOND;
/// The proximity warning's defaults: closer than this horizontally (config
/// `adsb_warn_distance`, metres) and this vertically (`adsb_warn_height`).
pub const DEFAULT_WARN_DISTANCE_M: f64 = 2000.0;
pub const DEFAULT_WARN_HEIGHT_M: f64 = 300.0;

/// One aircraft as last reported.
#[derive(Debug, Clone, PartialEq)]
pub struct Aircraft {
    pub icao: u32,
    /// The callsign, when the report says it is valid (trimmed).
    pub callsign: Option<String>,
    pub pos: LatLon,
    /// Altitude above mean sea level, metres, when valid.
    pub alt_m: Option<f64>,
    /// True when the altitude is barometric (QNH), false for GNSS.
    pub baro: bool,
    /// Course over ground, degrees, when valid.
    pub heading: Option<f64>,
    /// Horizontal speed, m/s, when valid.
    pub speed: Option<f64>,
    /// Climb rate, m/s (up positive), when valid.
    pub climb: Option<f64>,
    pub squawk: Option<u16>,
    pub emitter: u8,
    pub simulated: bool,
    /// When the report came, less the age it carried (`tslc`).
    pub seen: Micros,
    /// Who forwarded the last report.
    pub via: VehicleKey,
}

impl Aircraft {
    /// The callsign, else the ICAO address in hex.
    pub fn name(&self) -> String {
        self.callsign
            .clone()
            .unwrap_or_else(|| format!("{:06X}", self.icao))
    }

    /// How old its information is at `now`.
    pub fn age(&self, now: Micros) -> Micros {
        now.saturating_sub(self.seen)
    }

    pub fn is_stale(&self, now: Micros) -> bool {
        self.age(now) > STALE_AFTER
    }

    /// Its velocity as (east, north) m/s (zero when unknown).
    pub fn velocity_en(&self) -> (f64, f64) {
        match (self.heading, self.speed) {
            (Some(h), Some(s)) => {
                let (sin, cos) = h.to_radians().sin_cos();
                (s * sin, s * cos)
            }
            _ => (0.0, 0.0),
        }
    }
}

/// The traffic heard.
#[derive(Debug, Clone)]
pub struct Traffic {
    aircraft: BTreeMap<u32, Aircraft>,
    /// Dropped after this long without a report.
    pub timeout: Micros,
    /// Aircraft dropped for age.
    pub expired: u64,
    /// Aircraft that gave way to a newer one (the table was full).
    pub evicted: u64,
    /// Reports ignored: no valid coordinates, or a position off the globe.
    pub invalid: u64,
    /// Reports taken.
    pub reports: u64,
}

impl Default for Traffic {
    fn default() -> Self {
        Traffic::new(DEFAULT_TIMEOUT)
    }
}

impl Traffic {
    pub fn new(timeout: Micros) -> Traffic {
        Traffic {
            aircraft: BTreeMap::new(),
            timeout: timeout.max(SECOND),
            expired: 0,
            evicted: 0,
            invalid: 0,
            reports: 0,
        }
    }

    /// The aircraft heard, by ICAO address.
    pub fn aircraft(&self) -> impl Iterator<Item = &Aircraft> {
        self.aircraft.values()
    }

    pub fn len(&self) -> usize {
        self.aircraft.len()
    }

    pub fn is_empty(&self) -> bool {
        self.aircraft.is_empty()
    }

    pub fn get(&self, icao: u32) -> Option<&Aircraft> {
        self.aircraft.get(&icao)
    }

    /// A report from `via` at `now`.
    pub fn on_report(&mut self, now: Micros, via: VehicleKey, a: &ADSB_VEHICLE_DATA) {
        let f = a.flags;
        let pos = LatLon::from_e7(a.lat, a.lon);
        if !f.contains(AdsbFlags::ADSB_FLAGS_VALID_COORDS) || !pos.is_valid() {
            self.invalid += 1;
            return;
        }
        self.reports += 1;
        let seen = now.saturating_sub(a.tslc as Micros * SECOND);
        if let Some(old) = self.aircraft.get(&a.ICAO_address) {
            // An older report (another vehicle forwarding it late) does not go back in time.
            if old.seen > seen {
                return;
            }
        } else if self.aircraft.len() >= MAX_AIRCRAFT {
            if let Some(oldest) = self
                .aircraft
                .values()
                .min_by_key(|x| x.seen)
                .map(|x| x.icao)
            {
                self.aircraft.remove(&oldest);
                self.evicted += 1;
            }
        }
        let callsign = f
            .contains(AdsbFlags::ADSB_FLAGS_VALID_CALLSIGN)
            .then(|| {
                a.callsign
                    .to_str()
                    .unwrap_or("")
                    .chars()
                    .filter(|c| c.is_ascii_graphic())
                    .collect::<String>()
            })
            .filter(|s| !s.is_empty());
        let ac = Aircraft {
            icao: a.ICAO_address,
            callsign,
            pos,
            alt_m: f
                .contains(AdsbFlags::ADSB_FLAGS_VALID_ALTITUDE)
                .then(|| a.altitude as f64 / 1000.0),
            baro: a.altitude_type == AdsbAltitudeType::ADSB_ALTITUDE_TYPE_PRESSURE_QNH,
            heading: f
                .contains(AdsbFlags::ADSB_FLAGS_VALID_HEADING)
                .then(|| geo::wrap_360(a.heading as f64 / 100.0)),
            speed: f
                .contains(AdsbFlags::ADSB_FLAGS_VALID_VELOCITY)
                .then(|| a.hor_velocity as f64 / 100.0),
            climb: f
                .contains(AdsbFlags::ADSB_FLAGS_VERTICAL_VELOCITY_VALID)
                .then(|| a.ver_velocity as f64 / 100.0),
            squawk: f
                .contains(AdsbFlags::ADSB_FLAGS_VALID_SQUAWK)
                .then_some(a.squawk),
            emitter: a.emitter_type as u8,
            simulated: f.contains(AdsbFlags::ADSB_FLAGS_SIMULATED),
            seen,
            via,
        };
        self.aircraft.insert(a.ICAO_address, ac);
    }

    /// Drop the aircraft older than the timeout at `now`.
    pub fn expire(&mut self, now: Micros) {
        let timeout = self.timeout;
        let before = self.aircraft.len();
        self.aircraft.retain(|_, a| a.age(now) <= timeout);
        self.expired += (before - self.aircraft.len()) as u64;
    }
}

impl Machine for Traffic {
    const IDS: Ids = Ids::Only(&[ADSB_VEHICLE_DATA::ID]);

    fn on_message(&mut self, m: &Incoming, _out: &mut Vec<Out>) {
        if let Some(MavMessage::ADSB_VEHICLE(a)) = m.msg {
            self.on_report(m.now, VehicleKey(m.from.0, m.from.1), a);
        }
    }

    fn poll(&mut self, now: Micros, _out: &mut Vec<Out>) {
        self.expire(now);
    }

    /// When the oldest aircraft is dropped.
    fn next_deadline(&self) -> Option<Micros> {
        self.aircraft
            .values()
            .map(|a| a.seen.saturating_add(self.timeout).saturating_add(1))
            .min()
    }
}

/// Where one aircraft stands from a vehicle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Relative {
    /// Horizontal distance, metres.
    pub distance: f64,
    /// Bearing from the vehicle, degrees.
    pub bearing: f64,
    /// Its altitude less the vehicle's (AMSL), metres, when both are known.
    pub height: Option<f64>,
    /// How fast the horizontal distance shrinks, m/s (negative: opening).
    pub closing: f64,
}

/// `a` seen from a vehicle at `own` (AMSL `own_alt` metres, velocity `own_v` east/north m/s).
pub fn relative(a: &Aircraft, own: LatLon, own_alt: Option<f64>, own_v: (f64, f64)) -> Relative {
    let plane = geo::Plane::new(own);
    let (e, n) = plane.to_en(a.pos);
    let distance = e.hypot(n);
    let (ve, vn) = a.velocity_en();
    let (rve, rvn) = (ve - own_v.0, vn - own_v.1);
    let closing = if distance > 1e-6 {
        -(e * rve + n * rvn) / distance
    } else {
        0.0
    };
    Relative {
        distance,
        bearing: geo::bearing_deg(own, a.pos),
        height: a.alt_m.zip(own_alt).map(|(x, o)| x - o),
        closing,
    }
}

/// True when `r` is within `distance` metres horizontally and `height` metres vertically (an
/// unknown height difference counts as within).
pub fn is_near(r: &Relative, distance: f64, height: f64) -> bool {
    r.distance <= distance && r.height.is_none_or(|h| h.abs() <= height)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report(icao: u32, lat: f64, lon: f64, tslc: u8) -> ADSB_VEHICLE_DATA {
        ADSB_VEHICLE_DATA {
            ICAO_address: icao,
            lat: (lat * 1e7) as i32,
            lon: (lon * 1e7) as i32,
            altitude: 500_000,
            heading: 9000,
            hor_velocity: 5000,
            ver_velocity: -100,
            flags: AdsbFlags::ADSB_FLAGS_VALID_COORDS
                | AdsbFlags::ADSB_FLAGS_VALID_ALTITUDE
                | AdsbFlags::ADSB_FLAGS_VALID_HEADING
                | AdsbFlags::ADSB_FLAGS_VALID_VELOCITY
                | AdsbFlags::ADSB_FLAGS_VALID_CALLSIGN,
            squawk: 1200,
            altitude_type: AdsbAltitudeType::ADSB_ALTITUDE_TYPE_PRESSURE_QNH,
            callsign: "ABC123  ".into(),
            emitter_type: crate::dialect::AdsbEmitterType::ADSB_EMITTER_TYPE_LIGHT,
            tslc,
        }
    }

    #[test]
    fn reports_are_read_and_aged_and_dropped() {
        let mut t = Traffic::new(10 * SECOND);
        t.on_report(20 * SECOND, VehicleKey(1, 1), &report(7, -35.0, 149.0, 2));
        let a = t.get(7).unwrap();
        assert_eq!(a.callsign.as_deref(), Some("ABC123"));
        assert_eq!(a.alt_m, Some(500.0));
        assert_eq!(a.heading, Some(90.0));
        assert_eq!(a.speed, Some(50.0));
        assert_eq!(a.age(20 * SECOND), 2 * SECOND);
        assert_eq!(t.next_deadline(), Some(28 * SECOND + 1));
        t.expire(28 * SECOND);
        assert_eq!(t.len(), 1);
        t.expire(28 * SECOND + 1);
        assert_eq!((t.len(), t.expired), (0, 1));
    }

    #[test]
    fn bad_reports_are_counted_and_the_table_is_bounded() {
        let mut t = Traffic::default();
        let mut r = report(1, -35.0, 149.0, 0);
        r.flags = AdsbFlags::ADSB_FLAGS_VALID_ALTITUDE;
        t.on_report(0, VehicleKey(1, 1), &r);
        t.on_report(0, VehicleKey(1, 1), &report(2, 95.0, 149.0, 0));
        assert_eq!((t.len(), t.invalid), (0, 2));
        for i in 0..(MAX_AIRCRAFT as u32 + 5) {
            t.on_report(i as Micros, VehicleKey(1, 1), &report(i, -35.0, 149.0, 0));
        }
        assert_eq!((t.len(), t.evicted), (MAX_AIRCRAFT, 5));
        assert!(t.get(0).is_none() && t.get(MAX_AIRCRAFT as u32 + 4).is_some());
    }

    #[test]
    fn closing_speed_of_head_on_traffic() {
        let own = LatLon::new(0.0, 0.0);
        // 1 km east, flying west at 50 m/s, towards us flying east at 10 m/s.
        let mut r = report(1, 0.0, 1000.0 / 111_194.9, 0);
        r.heading = 27000;
        let mut t = Traffic::default();
        t.on_report(0, VehicleKey(1, 1), &r);
        let rel = relative(t.get(1).unwrap(), own, Some(450.0), (10.0, 0.0));
        assert!((rel.distance - 1000.0).abs() < 1.0, "{rel:?}");
        assert!((rel.closing - 60.0).abs() < 1e-6, "{rel:?}");
        assert_eq!(rel.height, Some(50.0));
        assert!(is_near(&rel, 1500.0, 100.0));
        assert!(!is_near(&rel, 1500.0, 40.0));
    }
}
