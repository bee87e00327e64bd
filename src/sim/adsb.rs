//! Simulated ADS-B traffic (`sim://?adsb=N`), as ArduPilot SITL's `SIM_ADSB_*`
//! (`libraries/SITL/SIM_ADSB.cpp`): N aircraft around home on straight, level tracks, each put
//! back on a new track when it leaves the radius (`adsb_radius`, SIM_ADSB_RADIUS, 10 km) at its
//! altitude above home (`adsb_alt`, SIM_ADSB_ALT, 1000 m). As there, the reports carry
//! ICAO addresses below 10000, callsigns `SIM<icao>`, altitude type QNH, squawk 1200, the
//! SIMULATED flag among the valid-data flags and `tslc` 1; speeds are 5 to 20 m/s inside 500 m
//! and three times that beyond. The autopilot forwards each aircraft once a second as
//! ADSB_VEHICLE from its own ids (AP_ADSB's stream to the GCS).
//!
//! Deterministic: the tracks come from the sim's seed.

use crate::clock::{Micros, SECOND};
use crate::dialect::{AdsbAltitudeType, AdsbEmitterType, AdsbFlags, MavMessage, ADSB_VEHICLE_DATA};
use crate::proto::geo::{self, LatLon, Plane};

use super::rng::Rng;
use super::vehicle::{HOME_ALT_M, HOME_LAT, HOME_LON};

/// The most aircraft `adsb=` takes.
pub const MAX: u8 = 50;
/// Each aircraft is reported this often.
pub const REPORT_EVERY: Micros = SECOND;
/// SIM_ADSB_RADIUS's default, metres.
pub const DEFAULT_RADIUS_M: f64 = 10_000.0;
/// SIM_ADSB_ALT's default, metres above home.
pub const DEFAULT_ALT_M: f64 = 1000.0;

/// One simulated aircraft: metres east and north of home, velocity in m/s.
#[derive(Debug, Clone, PartialEq)]
pub struct SimAircraft {
    pub icao: u32,
    pub east: f64,
    pub north: f64,
    pub alt_m: f64,
    pub ve: f64,
    pub vn: f64,
}

impl SimAircraft {
    pub fn pos(&self) -> LatLon {
        Plane::new(LatLon::new(HOME_LAT, HOME_LON)).from_en(self.east, self.north)
    }

    pub fn heading(&self) -> f64 {
        geo::wrap_360(self.ve.atan2(self.vn).to_degrees())
    }

    pub fn speed(&self) -> f64 {
        self.ve.hypot(self.vn)
    }

    /// The ADSB_VEHICLE report of it.
    pub fn report(&self) -> MavMessage {
        let p = self.pos();
        MavMessage::ADSB_VEHICLE(ADSB_VEHICLE_DATA {
            ICAO_address: self.icao,
            lat: (p.lat * 1e7).round() as i32,
            lon: (p.lon * 1e7).round() as i32,
            altitude: ((HOME_ALT_M + self.alt_m) * 1000.0).round() as i32,
            heading: (self.heading() * 100.0).round() as u16 % 36000,
            hor_velocity: (self.speed() * 100.0).round().min(65535.0) as u16,
            ver_velocity: 0,
            flags: AdsbFlags::ADSB_FLAGS_VALID_COORDS
                | AdsbFlags::ADSB_FLAGS_VALID_ALTITUDE
                | AdsbFlags::ADSB_FLAGS_VALID_HEADING
                | AdsbFlags::ADSB_FLAGS_VALID_VELOCITY
                | AdsbFlags::ADSB_FLAGS_VALID_CALLSIGN
                | AdsbFlags::ADSB_FLAGS_VALID_SQUAWK
                | AdsbFlags::ADSB_FLAGS_SIMULATED
                | AdsbFlags::ADSB_FLAGS_VERTICAL_VELOCITY_VALID
                | AdsbFlags::ADSB_FLAGS_BARO_VALID,
            squawk: 1200,
            altitude_type: AdsbAltitudeType::ADSB_ALTITUDE_TYPE_PRESSURE_QNH,
            callsign: format!("SIM{}", self.icao).as_str().into(),
            emitter_type: AdsbEmitterType::ADSB_EMITTER_TYPE_LIGHT,
            tslc: 1,
        })
    }
}

/// The traffic around the sim's home.
#[derive(Debug, Clone)]
pub struct SimAdsb {
    pub aircraft: Vec<SimAircraft>,
    radius: f64,
    alt: f64,
    rng: Rng,
    /// The time the tracks are at.
    at: Micros,
    /// The next report (all aircraft at once).
    next_report: Micros,
}

impl SimAdsb {
    pub fn new(count: u8, radius: f64, alt: f64, seed: u64) -> SimAdsb {
        let mut s = SimAdsb {
            aircraft: Vec::new(),
            radius: radius.max(100.0),
            alt,
            rng: Rng::derive(seed, 0xAD5B),
            at: 0,
            next_report: 0,
        };
        for i in 0..count.min(MAX) {
            let a = s.new_track(i);
            s.aircraft.push(a);
        }
        s
    }

    /// A new straight track: somewhere within the radius, heading anywhere.
    fn new_track(&mut self, i: u8) -> SimAircraft {
        let icao = 1000 + 100 * i as u32 + self.rng.below(100) as u32;
        let r = self.radius * self.rng.next_f64().sqrt() * 0.9;
        let th = self.rng.next_f64() * std::f64::consts::TAU;
        let (east, north) = (r * th.sin(), r * th.cos());
        let (lo, hi) = if r > 500.0 { (15.0, 60.0) } else { (5.0, 20.0) };
        let speed = lo + (hi - lo) * self.rng.next_f64();
        let course = self.rng.next_f64() * std::f64::consts::TAU;
        SimAircraft {
            icao,
            east,
            north,
            alt_m: self.alt + 30.0 * i as f64,
            ve: speed * course.sin(),
            vn: speed * course.cos(),
        }
    }

    /// Move every aircraft on to `now`; one that left the radius gets a new track.
    pub fn tick(&mut self, now: Micros) {
        if now <= self.at {
            return;
        }
        let dt = (now - self.at) as f64 / SECOND as f64;
        self.at = now;
        for i in 0..self.aircraft.len() {
            let a = &mut self.aircraft[i];
            a.east += a.ve * dt;
            a.north += a.vn * dt;
            if a.east.hypot(a.north) > self.radius {
                self.aircraft[i] = self.new_track(i as u8);
            }
        }
    }

    /// The reports due at `now`.
    pub fn due(&mut self, now: Micros) -> Vec<MavMessage> {
        if self.aircraft.is_empty() || now < self.next_report {
            return Vec::new();
        }
        self.next_report = now + REPORT_EVERY;
        self.aircraft.iter().map(SimAircraft::report).collect()
    }

    pub fn next_event(&self) -> Micros {
        if self.aircraft.is_empty() {
            Micros::MAX
        } else {
            self.next_report
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aircraft_fly_straight_and_stay_within_the_radius() {
        let mut s = SimAdsb::new(3, 2000.0, 100.0, 7);
        assert_eq!(s.aircraft.len(), 3);
        let a0 = s.aircraft[0].clone();
        s.tick(2 * SECOND);
        let a1 = &s.aircraft[0];
        if a1.icao == a0.icao {
            assert!((a1.east - (a0.east + 2.0 * a0.ve)).abs() < 1e-9);
            assert!((a1.north - (a0.north + 2.0 * a0.vn)).abs() < 1e-9);
        }
        for k in 3..2000 {
            s.tick(k * SECOND);
            assert!(s.aircraft.iter().all(|a| a.east.hypot(a.north) <= 2000.0));
        }
        assert_eq!(s.due(0).len(), 3);
        assert!(s.due(SECOND / 2).is_empty());
        assert_eq!(s.due(SECOND).len(), 3);
        // The same seed gives the same sky.
        let t = SimAdsb::new(3, 2000.0, 100.0, 7);
        assert_eq!(t.aircraft, SimAdsb::new(3, 2000.0, 100.0, 7).aircraft);
    }

    #[test]
    fn the_report_is_what_sitl_sends() {
        let s = SimAdsb::new(1, 2000.0, 100.0, 1);
        let MavMessage::ADSB_VEHICLE(r) = s.aircraft[0].report() else {
            panic!()
        };
        assert_eq!(
            r.callsign.to_str().unwrap(),
            format!("SIM{}", r.ICAO_address)
        );
        assert_eq!(r.squawk, 1200);
        assert_eq!(r.tslc, 1);
        assert_eq!(r.altitude, ((HOME_ALT_M + 100.0) * 1000.0) as i32);
        assert!(r.flags.contains(AdsbFlags::ADSB_FLAGS_SIMULATED));
    }
}
