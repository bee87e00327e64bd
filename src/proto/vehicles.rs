//! The registry of systems and components heard, built from HEARTBEAT.
//!
//! Keyed by (sysid, compid). A component is *lost* after a timeout without a heartbeat and *back*
//! when heard again. Our own heartbeats echoed by a router never get here (the core recognises
//! them by the bytes we sent); another GCS on our own sysid:compid, a vehicle on our sysid, or two
//! different vehicles on one sysid:compid are flagged rather than merged. Another GCS on our
//! sysid with another compid (MAVProxy is 255:230) is normal.
//!
//! The table is bounded: past [`MAX_COMPONENTS`] the longest silent component is evicted and
//! counted, so a flood of spoofed ids costs a fixed amount of memory. What the core keeps (the
//! operator's target, a vehicle with work in flight: [`Registry::keep`]) is never evicted; a
//! newcomer that finds only kept components in a full table is refused and counted.
//!
//! More than [`FLOOD_FOUND`] components found within [`FLOOD_WINDOW`] is a *flood* (spoofed
//! heartbeats on an unsigned link): told once ([`VehicleEvent::Flood`]) and counted; components
//! found while it lasts are marked [`Vehicle::flood`] so the core tells nothing of each. It ends
//! after [`FLOOD_QUIET`] without a newly found component.

use std::collections::{BTreeMap, BTreeSet, VecDeque};

use crate::clock::{Micros, SECOND};
use crate::dialect::{MavAutopilot, MavModeFlag, MavState, MavType, HEARTBEAT_DATA};
use crate::link::{LinkId, Version};
use crate::proto::modes;

/// Default time without a heartbeat after which a component is lost.
pub const DEFAULT_LOST_TIMEOUT: Micros = 5 * SECOND;

/// Heartbeats closer together than this are copies of one (e.g. heard on two links).
pub const HEARTBEAT_COPY_WINDOW: Micros = 100_000;

/// The MAVLink address of one component: (sysid, compid), shown as `sysid:compid`.
///
/// One type for every address: a component heard by heartbeat, the target of a command or a
/// mission transfer, the source of a message, the ground station itself. MAVLink addresses them
/// all alike, so a separate "component key" would only convert back and forth.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct VehicleKey(pub u8, pub u8);

impl std::fmt::Display for VehicleKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}", self.0, self.1)
    }
}

impl From<(u8, u8)> for VehicleKey {
    fn from((sysid, compid): (u8, u8)) -> Self {
        VehicleKey(sysid, compid)
    }
}

impl From<VehicleKey> for (u8, u8) {
    fn from(k: VehicleKey) -> Self {
        (k.0, k.1)
    }
}

/// Components kept at most; a new one past this evicts the longest silent. Room for a swarm of
/// 250 vehicles with a companion component each, and still a fixed bound under a flood of
/// spoofed ids.
pub const MAX_COMPONENTS: usize = 512;

/// More components than this found within [`FLOOD_WINDOW`] is a flood.
pub const FLOOD_FOUND: usize = 16;
/// The window [`FLOOD_FOUND`] is counted over.
pub const FLOOD_WINDOW: Micros = 10 * SECOND;
/// A flood ends after this long without a newly found component.
pub const FLOOD_QUIET: Micros = 60 * SECOND;

/// Reboots of one vehicle closer together than this are one reboot seen twice (on two links, or
/// by two signs).
pub const REBOOT_DEBOUNCE: Micros = 10 * SECOND;

/// Name of an enum value without its MAVLink prefix: `MAV_TYPE_QUADROTOR` → `QUADROTOR`.
pub fn short_name<T: std::fmt::Debug>(v: &T, prefix: &str) -> String {
    let s = format!("{v:?}");
    s.strip_prefix(prefix).unwrap_or(&s).to_string()
}

/// One system/component heard by heartbeat.
#[derive(Debug, Clone)]
pub struct Vehicle {
    pub sysid: u8,
    pub compid: u8,
    pub mavtype: MavType,
    pub autopilot: MavAutopilot,
    pub base_mode: MavModeFlag,
    pub custom_mode: u32,
    pub system_status: MavState,
    pub mavlink_version: u8,
    /// MAVLink version of the frames its heartbeats came in.
    pub frame_version: Version,
    pub first_heard: Micros,
    pub last_heard: Micros,
    hb_times: VecDeque<Micros>,
    /// Links this component has been heard on.
    pub links: BTreeSet<LinkId>,
    pub lost: bool,
    pub heartbeats: u64,
    pub reboots: u32,
    last_boot_ms: Option<u32>,
    last_reboot: Option<Micros>,
    /// Set when a heartbeat from the same sysid:compid described a different vehicle.
    pub conflict: Option<String>,
    /// Set when a vehicle uses the ground station's own sysid, or another GCS our sysid:compid.
    pub uses_gcs_sysid: bool,
    /// First heard during a heartbeat flood: listed, but nothing told of it on its own.
    pub flood: bool,
}

impl Vehicle {
    /// Its address, `sysid:compid`.
    pub fn key(&self) -> VehicleKey {
        VehicleKey(self.sysid, self.compid)
    }

    pub fn armed(&self) -> bool {
        self.base_mode
            .contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED)
    }
    /// The profile of this vehicle's autopilot family.
    pub fn profile(&self) -> &'static dyn crate::proto::profile::Profile {
        crate::proto::profile::of(self.autopilot)
    }
    pub fn mode_name(&self) -> String {
        if self
            .base_mode
            .contains(MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED)
            || self.profile().custom_mode_always()
        {
            modes::mode_name(self.autopilot, self.mavtype, self.custom_mode)
        } else if self.mavtype == MavType::MAV_TYPE_GCS {
            "-".into()
        } else {
            format!("BASE({:#04x})", self.base_mode.bits())
        }
    }
    pub fn type_name(&self) -> String {
        short_name(&self.mavtype, "MAV_TYPE_")
    }
    pub fn autopilot_name(&self) -> String {
        short_name(&self.autopilot, "MAV_AUTOPILOT_")
    }
    pub fn status_name(&self) -> String {
        short_name(&self.system_status, "MAV_STATE_")
    }
    /// True for a camera or a gimbal: a payload, which may be alone on its system (no autopilot
    /// to reach it through).
    pub fn is_payload(&self) -> bool {
        matches!(
            self.mavtype,
            MavType::MAV_TYPE_CAMERA | MavType::MAV_TYPE_GIMBAL
        )
    }
    /// True for components that fly (or drive): what commands are sent to. Gimbals, cameras,
    /// companions and ground stations announce MAV_AUTOPILOT_INVALID.
    pub fn is_autopilot(&self) -> bool {
        self.autopilot != MavAutopilot::MAV_AUTOPILOT_INVALID
            && !matches!(
                self.mavtype,
                MavType::MAV_TYPE_GCS
                    | MavType::MAV_TYPE_GIMBAL
                    | MavType::MAV_TYPE_CAMERA
                    | MavType::MAV_TYPE_ONBOARD_CONTROLLER
                    | MavType::MAV_TYPE_ADSB
                    | MavType::MAV_TYPE_ANTENNA_TRACKER
            )
    }
    /// True for ground stations (other GCSs, MAVProxy, …).
    pub fn is_gcs(&self) -> bool {
        self.mavtype == MavType::MAV_TYPE_GCS
    }
    /// Heartbeat rate in Hz over the last few heartbeats (0 until two are heard).
    pub fn heartbeat_hz(&self) -> f64 {
        match (self.hb_times.front(), self.hb_times.back()) {
            (Some(a), Some(b)) if b > a => {
                (self.hb_times.len() - 1) as f64 * SECOND as f64 / (b - a) as f64
            }
            _ => 0.0,
        }
    }
    /// Seconds since the last heartbeat.
    pub fn age_secs(&self, now: Micros) -> f64 {
        now.saturating_sub(self.last_heard) as f64 / SECOND as f64
    }
}

/// What the registry noticed; the app turns these into operator notices.
#[derive(Debug, Clone, PartialEq)]
pub enum VehicleEvent {
    Found(VehicleKey),
    Lost(VehicleKey),
    Back(VehicleKey),
    Rebooted(VehicleKey, &'static str),
    Conflict(VehicleKey, String),
    UsesGcsSysid(VehicleKey),
    /// Dropped from a full table (the longest silent).
    Evicted(VehicleKey),
    /// A heartbeat flood began: this many components were found within [`FLOOD_WINDOW`].
    Flood(usize),
}

/// All components heard by heartbeat.
#[derive(Debug, Clone)]
pub struct Registry {
    vehicles: BTreeMap<VehicleKey, Vehicle>,
    pub lost_timeout: Micros,
    own: VehicleKey,
    /// Components evicted to keep the table within [`MAX_COMPONENTS`].
    pub evicted: u64,
    /// Links whose time runs slow or stands still (a replay played slowly or paused).
    paced: BTreeMap<LinkId, Pace>,
    /// What eviction must spare (the target, vehicles with work in flight): set by the core.
    kept: BTreeSet<VehicleKey>,
    /// Newcomers refused because every component in the full table is kept.
    pub refused: u64,
    /// When the last components were found (at most [`FLOOD_FOUND`] + 1 kept).
    found_times: VecDeque<Micros>,
    /// While a flood lasts: when the last component was found.
    flood_since: Option<Micros>,
    /// Floods begun.
    pub floods: u64,
    /// Components found during a flood.
    pub flood_found: u64,
}

/// How time runs on a link compared with ours (a replay's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Pace {
    /// Stopped at this time of ours (paused): components heard only there are not lost.
    Held(Micros),
    /// This many times slower (≥ 1): the lost timeout stretches as much.
    Slow(f64),
}

impl Registry {
    /// `own` is our (sysid, compid): anything else using it is flagged.
    pub fn new(own: VehicleKey, lost_timeout: Micros) -> Self {
        Self {
            vehicles: BTreeMap::new(),
            lost_timeout,
            own,
            evicted: 0,
            paced: BTreeMap::new(),
            kept: BTreeSet::new(),
            refused: 0,
            found_times: VecDeque::with_capacity(FLOOD_FOUND + 1),
            flood_since: None,
            floods: 0,
            flood_found: 0,
        }
    }

    /// Set what eviction must spare: the target and the vehicles with work in flight.
    pub fn keep(&mut self, keys: impl IntoIterator<Item = VehicleKey>) {
        self.kept.clear();
        self.kept.extend(keys);
    }

    /// True while a heartbeat flood lasts.
    pub fn flooding(&self) -> bool {
        self.flood_since.is_some()
    }

    /// True when a heartbeat from `key` would add a component to a full table (the core then
    /// says what to keep first).
    pub fn full_for(&self, key: VehicleKey) -> bool {
        self.vehicles.len() >= MAX_COMPONENTS && !self.vehicles.contains_key(&key)
    }

    /// Account a component found at `now` for flood detection; true while flooding.
    fn found_at(&mut self, now: Micros, events: &mut Vec<VehicleEvent>) -> bool {
        if self
            .flood_since
            .is_some_and(|t| now.saturating_sub(t) >= FLOOD_QUIET)
        {
            self.flood_since = None;
        }
        if self.found_times.len() > FLOOD_FOUND {
            self.found_times.pop_front();
        }
        self.found_times.push_back(now);
        if self.flood_since.is_none()
            && self.found_times.len() > FLOOD_FOUND
            && self
                .found_times
                .front()
                .is_some_and(|&t| now.saturating_sub(t) < FLOOD_WINDOW)
        {
            self.floods += 1;
            events.push(VehicleEvent::Flood(self.found_times.len()));
            self.flood_since = Some(now);
        }
        if self.flood_since.is_some() {
            self.flood_since = Some(now);
            self.flood_found += 1;
            true
        } else {
            false
        }
    }

    /// Set how time runs on `link` (`None`: as ours). When a held link runs again, the
    /// components heard only there are as old as when it stopped.
    pub fn set_pace(&mut self, link: LinkId, pace: Option<Pace>, now: Micros) {
        let old = self.paced.get(&link).copied();
        if let (Some(Pace::Held(since)), Some(Pace::Held(_))) = (old, pace) {
            // Still held since then.
            self.paced.insert(link, Pace::Held(since));
            return;
        }
        if let Some(Pace::Held(since)) = old {
            let stopped = now.saturating_sub(since);
            let held: Vec<VehicleKey> = self
                .vehicles
                .iter()
                .filter(|(_, v)| self.timeout_of(v).is_none())
                .map(|(k, _)| *k)
                .collect();
            for k in held {
                if let Some(v) = self.vehicles.get_mut(&k) {
                    v.last_heard = (v.last_heard + stopped).min(now);
                }
            }
        }
        match pace {
            Some(p) => self.paced.insert(link, p),
            None => self.paced.remove(&link),
        };
    }

    /// The lost timeout of `v`: stretched when every link it is heard on runs slow, none while
    /// they all stand still.
    fn timeout_of(&self, v: &Vehicle) -> Option<Micros> {
        if self.paced.is_empty() || v.links.is_empty() {
            return Some(self.lost_timeout);
        }
        let mut stretch: f64 = 1.0;
        let mut running = false;
        for l in &v.links {
            match self.paced.get(l) {
                None => return Some(self.lost_timeout),
                Some(Pace::Held(_)) => {}
                Some(Pace::Slow(f)) => {
                    running = true;
                    stretch = stretch.max(*f);
                }
            }
        }
        running.then_some((self.lost_timeout as f64 * stretch) as Micros)
    }

    pub fn get(&self, key: VehicleKey) -> Option<&Vehicle> {
        self.vehicles.get(&key)
    }
    pub fn iter(&self) -> impl Iterator<Item = &Vehicle> {
        self.vehicles.values()
    }
    pub fn len(&self) -> usize {
        self.vehicles.len()
    }
    pub fn is_empty(&self) -> bool {
        self.vehicles.is_empty()
    }

    /// Account a HEARTBEAT from `key` heard on `link` at `now`.
    pub fn on_heartbeat(
        &mut self,
        link: LinkId,
        key: VehicleKey,
        hb: &HEARTBEAT_DATA,
        version: Version,
        now: Micros,
    ) -> Vec<VehicleEvent> {
        let mut events = Vec::new();
        // A vehicle on our sysid, or another GCS on our very sysid:compid, confuses whoever
        // routes replies; another GCS on our sysid with its own compid (MAVProxy) is normal.
        let uses_gcs_sysid =
            key == self.own || (key.0 == self.own.0 && hb.mavtype != MavType::MAV_TYPE_GCS);
        match self.vehicles.get_mut(&key) {
            None => {
                if self.vehicles.len() >= MAX_COMPONENTS {
                    let oldest = self
                        .vehicles
                        .values()
                        .filter(|v| !self.kept.contains(&v.key()))
                        .min_by_key(|v| v.last_heard)
                        .map(|v| v.key());
                    match oldest {
                        Some(k) => {
                            self.vehicles.remove(&k);
                            self.evicted += 1;
                            events.push(VehicleEvent::Evicted(k));
                        }
                        None => {
                            // Everything here is kept: the newcomer waits outside.
                            self.refused += 1;
                            return events;
                        }
                    }
                }
                let flood = self.found_at(now, &mut events);
                let mut hb_times = VecDeque::with_capacity(8);
                hb_times.push_back(now);
                self.vehicles.insert(
                    key,
                    Vehicle {
                        sysid: key.0,
                        compid: key.1,
                        mavtype: hb.mavtype,
                        autopilot: hb.autopilot,
                        base_mode: hb.base_mode,
                        custom_mode: hb.custom_mode,
                        system_status: hb.system_status,
                        mavlink_version: hb.mavlink_version,
                        frame_version: version,
                        first_heard: now,
                        last_heard: now,
                        hb_times,
                        links: BTreeSet::from([link]),
                        lost: false,
                        heartbeats: 1,
                        reboots: 0,
                        last_boot_ms: None,
                        last_reboot: None,
                        conflict: None,
                        uses_gcs_sysid,
                        flood,
                    },
                );
                events.push(VehicleEvent::Found(key));
                if uses_gcs_sysid {
                    events.push(VehicleEvent::UsesGcsSysid(key));
                }
            }
            Some(v) => {
                if v.mavtype != hb.mavtype || v.autopilot != hb.autopilot {
                    let detail = format!(
                        "{key} heard as {}/{} and as {}/{}{}",
                        v.type_name(),
                        v.autopilot_name(),
                        short_name(&hb.mavtype, "MAV_TYPE_"),
                        short_name(&hb.autopilot, "MAV_AUTOPILOT_"),
                        if v.links.contains(&link) {
                            String::new()
                        } else {
                            format!(" (on link {link})")
                        }
                    );
                    if v.conflict.as_deref() != Some(detail.as_str()) {
                        events.push(VehicleEvent::Conflict(key, detail.clone()));
                    }
                    v.conflict = Some(detail);
                }
                if v.lost {
                    v.lost = false;
                    v.hb_times.clear();
                    events.push(VehicleEvent::Back(key));
                }
                v.mavtype = hb.mavtype;
                v.autopilot = hb.autopilot;
                v.base_mode = hb.base_mode;
                v.custom_mode = hb.custom_mode;
                v.system_status = hb.system_status;
                v.mavlink_version = hb.mavlink_version;
                v.frame_version = version;
                v.last_heard = now;
                v.heartbeats += 1;
                v.links.insert(link);
                // The same heartbeat heard again on a second link is not a second heartbeat.
                let copy = v
                    .hb_times
                    .back()
                    .is_some_and(|&t| now < t + HEARTBEAT_COPY_WINDOW);
                if !copy {
                    if v.hb_times.len() == 8 {
                        v.hb_times.pop_front();
                    }
                    v.hb_times.push_back(now);
                }
            }
        }
        events
    }

    /// SYSTEM_TIME from a component: `time_boot_ms` going backwards means it rebooted.
    pub fn on_system_time(
        &mut self,
        key: VehicleKey,
        time_boot_ms: u32,
        now: Micros,
    ) -> Vec<VehicleEvent> {
        let Some(v) = self.vehicles.get_mut(&key) else {
            return Vec::new();
        };
        let rebooted =
            matches!(v.last_boot_ms, Some(prev) if time_boot_ms < prev.saturating_sub(1000));
        v.last_boot_ms = Some(time_boot_ms);
        if rebooted {
            Self::reboot(v, key, now, "boot time went backwards")
        } else {
            Vec::new()
        }
    }

    /// Time jumped on `link` (a replay seeked): the boot times heard there no longer follow
    /// the ones before, so they are not taken for a reboot.
    pub fn on_time_jump(&mut self, link: LinkId) {
        for v in self.vehicles.values_mut() {
            if v.links.contains(&link) {
                v.last_boot_ms = None;
            }
        }
    }

    /// The component's sequence count restarted (see `loss`) on some link. Where SYSTEM_TIME
    /// arrives, it alone decides; otherwise this is the sign, taken once per reboot however many
    /// links show it.
    pub fn on_sequence_restart(&mut self, key: VehicleKey, now: Micros) -> Vec<VehicleEvent> {
        match self.vehicles.get_mut(&key) {
            Some(v) if v.last_boot_ms.is_none() => {
                Self::reboot(v, key, now, "sequence restarted after silence")
            }
            _ => Vec::new(),
        }
    }

    fn reboot(
        v: &mut Vehicle,
        key: VehicleKey,
        now: Micros,
        why: &'static str,
    ) -> Vec<VehicleEvent> {
        if v.last_reboot
            .is_some_and(|t| now.saturating_sub(t) < REBOOT_DEBOUNCE)
        {
            return Vec::new();
        }
        v.last_reboot = Some(now);
        v.reboots += 1;
        vec![VehicleEvent::Rebooted(key, why)]
    }

    /// When [`Registry::tick`] next has a component to mark lost.
    pub fn next_deadline(&self) -> Option<Micros> {
        self.vehicles
            .values()
            .filter(|v| !v.lost)
            .filter_map(|v| Some(v.last_heard + self.timeout_of(v)?))
            .min()
    }

    /// Mark components lost whose last heartbeat is older than the timeout.
    pub fn tick(&mut self, now: Micros) -> Vec<VehicleEvent> {
        let lost: Vec<VehicleKey> = self
            .vehicles
            .iter()
            .filter(|(_, v)| {
                !v.lost
                    && self
                        .timeout_of(v)
                        .is_some_and(|t| now.saturating_sub(v.last_heard) >= t)
            })
            .map(|(k, _)| *k)
            .collect();
        let mut events = Vec::with_capacity(lost.len());
        for key in lost {
            if let Some(v) = self.vehicles.get_mut(&key) {
                v.lost = true;
                events.push(VehicleEvent::Lost(key));
            }
        }
        events
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_key_shows_as_sysid_colon_compid_and_orders_by_sysid_first() {
        assert_eq!(VehicleKey(1, 1).to_string(), "1:1");
        assert_eq!(format!("target {}", VehicleKey(255, 190)), "target 255:190");
        assert_eq!(VehicleKey::from((7, 100)), VehicleKey(7, 100));
        assert!(VehicleKey(1, 200) < VehicleKey(2, 0));
    }

    fn hb(mavtype: MavType, autopilot: MavAutopilot, armed: bool, mode: u32) -> HEARTBEAT_DATA {
        let mut base_mode = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
        if armed {
            base_mode |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
        }
        HEARTBEAT_DATA {
            custom_mode: mode,
            mavtype,
            autopilot,
            base_mode,
            system_status: MavState::MAV_STATE_STANDBY,
            mavlink_version: 3,
        }
    }
    fn copter(armed: bool, mode: u32) -> HEARTBEAT_DATA {
        hb(
            MavType::MAV_TYPE_QUADROTOR,
            MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            armed,
            mode,
        )
    }

    #[test]
    fn found_then_lost_then_back() {
        let mut r = Registry::new(VehicleKey(255, 190), DEFAULT_LOST_TIMEOUT);
        let ev = r.on_heartbeat(0, VehicleKey(1, 1), &copter(false, 0), Version::V2, 0);
        assert_eq!(ev, vec![VehicleEvent::Found(VehicleKey(1, 1))]);
        for i in 1..4 {
            r.on_heartbeat(
                0,
                VehicleKey(1, 1),
                &copter(true, 4),
                Version::V2,
                i * SECOND,
            );
        }
        let v = r.get(VehicleKey(1, 1)).unwrap();
        assert!(v.armed());
        assert_eq!(v.mode_name(), "GUIDED");
        assert_eq!(v.type_name(), "QUADROTOR");
        assert_eq!(v.autopilot_name(), "ARDUPILOTMEGA");
        assert_eq!(v.status_name(), "STANDBY");
        assert!((v.heartbeat_hz() - 1.0).abs() < 1e-9);
        assert!(r.tick(7 * SECOND).is_empty());
        assert_eq!(
            r.tick(8 * SECOND),
            vec![VehicleEvent::Lost(VehicleKey(1, 1))]
        );
        assert!(r.tick(9 * SECOND).is_empty(), "lost only once");
        let ev = r.on_heartbeat(
            1,
            VehicleKey(1, 1),
            &copter(false, 0),
            Version::V2,
            10 * SECOND,
        );
        assert_eq!(ev, vec![VehicleEvent::Back(VehicleKey(1, 1))]);
        assert_eq!(
            r.get(VehicleKey(1, 1)).unwrap().links,
            BTreeSet::from([0, 1])
        );
    }

    #[test]
    fn other_gcss_are_listed_and_sysid_clashes_flagged() {
        let mut r = Registry::new(VehicleKey(255, 190), DEFAULT_LOST_TIMEOUT);
        let gcs = hb(
            MavType::MAV_TYPE_GCS,
            MavAutopilot::MAV_AUTOPILOT_INVALID,
            false,
            0,
        );
        // MAVProxy at 255:230: a GCS beside us, nothing wrong.
        let ev = r.on_heartbeat(0, VehicleKey(255, 230), &gcs, Version::V2, 0);
        assert_eq!(ev, vec![VehicleEvent::Found(VehicleKey(255, 230))]);
        assert!(r.get(VehicleKey(255, 230)).unwrap().is_gcs());
        assert!(!r.get(VehicleKey(255, 230)).unwrap().is_autopilot());
        // Another GCS on our very id (QGroundControl's default is ours too): listed, flagged.
        let ev = r.on_heartbeat(0, VehicleKey(255, 190), &gcs, Version::V2, 0);
        assert!(ev.contains(&VehicleEvent::UsesGcsSysid(VehicleKey(255, 190))));
        let ev = r.on_heartbeat(0, VehicleKey(255, 1), &copter(false, 0), Version::V2, 0);
        assert!(ev.contains(&VehicleEvent::UsesGcsSysid(VehicleKey(255, 1))));
        assert!(r.get(VehicleKey(255, 1)).unwrap().uses_gcs_sysid);
    }

    #[test]
    fn two_vehicles_on_one_sysid_are_flagged() {
        let mut r = Registry::new(VehicleKey(255, 190), DEFAULT_LOST_TIMEOUT);
        r.on_heartbeat(0, VehicleKey(1, 1), &copter(false, 0), Version::V2, 0);
        let plane = hb(
            MavType::MAV_TYPE_FIXED_WING,
            MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            false,
            0,
        );
        let ev = r.on_heartbeat(1, VehicleKey(1, 1), &plane, Version::V2, 1);
        assert!(
            matches!(&ev[0], VehicleEvent::Conflict(VehicleKey(1, 1), d) if d.contains("FIXED_WING"))
        );
        assert!(r.get(VehicleKey(1, 1)).unwrap().conflict.is_some());
    }

    #[test]
    fn heartbeat_rate_is_not_doubled_by_a_second_link() {
        let mut r = Registry::new(VehicleKey(255, 190), DEFAULT_LOST_TIMEOUT);
        for i in 0..5 {
            r.on_heartbeat(
                0,
                VehicleKey(1, 1),
                &copter(false, 0),
                Version::V2,
                i * SECOND,
            );
            r.on_heartbeat(
                1,
                VehicleKey(1, 1),
                &copter(false, 0),
                Version::V2,
                i * SECOND + 20_000,
            );
        }
        let v = r.get(VehicleKey(1, 1)).unwrap();
        assert!(
            (v.heartbeat_hz() - 1.0).abs() < 1e-9,
            "{}",
            v.heartbeat_hz()
        );
        assert_eq!(v.links.len(), 2);
    }

    #[test]
    fn boot_time_near_the_top_of_u32_does_not_overflow() {
        let mut r = Registry::new(VehicleKey(255, 190), DEFAULT_LOST_TIMEOUT);
        r.on_heartbeat(0, VehicleKey(1, 1), &copter(false, 0), Version::V2, 0);
        assert!(r
            .on_system_time(VehicleKey(1, 1), u32::MAX - 10, 0)
            .is_empty());
        assert!(r.on_system_time(VehicleKey(1, 1), u32::MAX, 0).is_empty());
    }

    #[test]
    fn reboot_from_boot_time() {
        let mut r = Registry::new(VehicleKey(255, 190), DEFAULT_LOST_TIMEOUT);
        r.on_heartbeat(0, VehicleKey(1, 1), &copter(false, 0), Version::V2, 0);
        assert!(r.on_system_time(VehicleKey(1, 1), 50_000, 0).is_empty());
        assert!(r
            .on_system_time(VehicleKey(1, 1), 50_900, SECOND)
            .is_empty());
        assert_eq!(r.on_system_time(VehicleKey(1, 1), 300, 2 * SECOND).len(), 1);
        assert_eq!(r.get(VehicleKey(1, 1)).unwrap().reboots, 1);
        // The same reboot seen again on a second link, or by its sequence count: not again.
        assert!(r
            .on_system_time(VehicleKey(1, 1), 200, 2 * SECOND)
            .is_empty());
        assert!(r
            .on_sequence_restart(VehicleKey(1, 1), 3 * SECOND)
            .is_empty());
        assert_eq!(r.get(VehicleKey(1, 1)).unwrap().reboots, 1);
    }

    #[test]
    fn sequence_restart_is_one_reboot_however_many_links_show_it() {
        let mut r = Registry::new(VehicleKey(255, 190), DEFAULT_LOST_TIMEOUT);
        r.on_heartbeat(0, VehicleKey(1, 1), &copter(false, 0), Version::V2, 0);
        assert_eq!(
            r.on_sequence_restart(VehicleKey(1, 1), 10 * SECOND).len(),
            1
        );
        assert!(r
            .on_sequence_restart(VehicleKey(1, 1), 10 * SECOND + 1)
            .is_empty());
        assert_eq!(
            r.on_sequence_restart(VehicleKey(1, 1), 60 * SECOND).len(),
            1
        );
        assert_eq!(r.get(VehicleKey(1, 1)).unwrap().reboots, 2);
    }

    #[test]
    fn a_held_link_keeps_its_components_and_a_slow_one_stretches_the_timeout() {
        let mut r = Registry::new(VehicleKey(255, 190), 5 * SECOND);
        r.on_heartbeat(0, VehicleKey(1, 1), &copter(false, 0), Version::V2, 0);
        r.on_heartbeat(1, VehicleKey(2, 1), &copter(false, 0), Version::V2, 0);
        // Link 0 held at 2 s: 1:1 is never lost meanwhile, 2:1 (link 1) is, after 5 s.
        r.set_pace(0, Some(Pace::Held(2 * SECOND)), 2 * SECOND);
        assert_eq!(r.next_deadline(), Some(5 * SECOND));
        r.tick(60 * SECOND);
        assert!(!r.get(VehicleKey(1, 1)).unwrap().lost);
        assert!(r.get(VehicleKey(2, 1)).unwrap().lost);
        assert_eq!(r.next_deadline(), None, "nothing to wake for while held");
        // Running again at 60 s, slowly (×4): it was 2 s old when held, so lost 18 s on.
        r.set_pace(0, Some(Pace::Slow(4.0)), 60 * SECOND);
        assert_eq!(r.next_deadline(), Some(78 * SECOND));
        r.tick(77 * SECOND);
        assert!(!r.get(VehicleKey(1, 1)).unwrap().lost);
        r.tick(78 * SECOND);
        assert!(r.get(VehicleKey(1, 1)).unwrap().lost);
    }

    #[test]
    fn a_flood_of_ids_is_bounded_and_counted() {
        let mut r = Registry::new(VehicleKey(255, 190), DEFAULT_LOST_TIMEOUT);
        for i in 0..10_000u32 {
            let key = VehicleKey((i % 250) as u8 + 1, (i / 250) as u8);
            r.on_heartbeat(0, key, &copter(false, 0), Version::V2, i as u64);
        }
        assert_eq!(r.len(), MAX_COMPONENTS);
        assert_eq!(r.evicted, 10_000 - MAX_COMPONENTS as u64);
        // The most recently heard are the ones kept.
        assert!(r.get(VehicleKey(250, 39)).is_some());
    }
}
