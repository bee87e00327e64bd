//! The Map screen's core: where the view is (following the target, panned, zoomed, fitted), the
//! cursor and what it does (`g` go-to, `a` on the Mission screen's file list), the vehicles'
//! tracks, the ADS-B traffic ([`crate::proto::adsb::Traffic`]) and its proximity warning.
//!
//! The traffic is the core's, not one vehicle's: every ADSB_VEHICLE heard (from an autopilot
//! forwarding its receiver, or a receiver of its own) goes to one table. An aircraft within
//! `adsb_warn_distance` metres and `adsb_warn_height` metres of the target is told once on the
//! message log when it comes near, and stands on the status bar while it is near.
//!
//! Tracks: each session's position at most once a second for the last [`TRACK_SECS`] seconds
//! (at most [`TRACK_POINTS`] points a vehicle).

use std::cell::Cell;
use std::collections::{BTreeMap, BTreeSet, VecDeque};

use super::mission::{LoadedList, Shown};
use super::{App, Effect};
use crate::clock::{Micros, SECOND};
use crate::keymap::Action;
use crate::link::{Frame, LinkId};
use crate::mission::{self, cmd, MissionItem, MissionType};
use crate::proto::adsb::{self, Aircraft, Relative, Traffic};
use crate::proto::commands::State;
use crate::proto::geo::{self, LatLon, Plane};
use crate::proto::machine::{Incoming, Machine};
use crate::proto::vehicles::VehicleKey;
use crate::wire::Severity;

/// Seconds of track kept per vehicle.
pub const TRACK_SECS: u64 = 180;
/// Points of track kept per vehicle at most.
pub const TRACK_POINTS: usize = 400;
/// The view's half height at start, metres.
pub const DEFAULT_RADIUS_M: f64 = 250.0;
/// The closest and the farthest zoom: half heights in metres.
pub const MIN_RADIUS_M: f64 = 10.0;
pub const MAX_RADIUS_M: f64 = 2_000_000.0;
/// The width/height of the map in metres assumed before the map was first drawn (a terminal's
/// cells are about twice as tall as wide; the map pane is wider than tall).
pub const FIT_ASPECT: f64 = 1.6;

/// The map's settings (config file `adsb_timeout`, `adsb_warn_distance`, `adsb_warn_height`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapConfig {
    /// Traffic not heard for this long is dropped.
    pub adsb_timeout: Micros,
    /// The proximity warning: horizontal distance, metres.
    pub warn_distance: f64,
    /// The proximity warning: height difference, metres.
    pub warn_height: f64,
}

impl Default for MapConfig {
    fn default() -> Self {
        MapConfig {
            adsb_timeout: adsb::DEFAULT_TIMEOUT,
            warn_distance: adsb::DEFAULT_WARN_DISTANCE_M,
            warn_height: adsb::DEFAULT_WARN_HEIGHT_M,
        }
    }
}

/// The Map screen's view (in the core so replays reproduce it).
#[derive(Debug, Clone, PartialEq)]
pub struct MapView {
    /// The view stays on the target.
    pub follow: bool,
    /// The view's centre when not following.
    pub centre: Option<LatLon>,
    /// Half the map's height, metres.
    pub radius_m: f64,
    /// The target's heading up (else north up).
    pub heading_up: bool,
    /// The cursor, while shown.
    pub cursor: Option<LatLon>,
    /// After a fit: the half width and half height (metres) the view must hold.
    pub fit: Option<(f64, f64)>,
    /// The map pane's width over its height (metres on the map, as dots are square) when last
    /// drawn: what a fitted view shows, so zooming or panning out of it goes on from there.
    pub aspect: Cell<Option<f64>>,
}

impl MapView {
    /// Half the height shown (metres) on a pane `aspect` wide for 1 high: the fit's extent,
    /// else the zoom's.
    pub fn half_height(&self, aspect: f64) -> f64 {
        match self.fit {
            Some((fw, fh)) => fh.max(fw / aspect),
            None => self.radius_m,
        }
    }

    /// Half the height shown, on the pane as last drawn.
    pub fn shown_radius(&self) -> f64 {
        self.half_height(self.aspect.get().unwrap_or(FIT_ASPECT))
    }

    /// Out of a fit (if in one) into a plain view of the same scale.
    fn leave_fit(&mut self) {
        if self.fit.is_some() {
            self.radius_m = self.shown_radius().clamp(MIN_RADIUS_M, MAX_RADIUS_M);
            self.fit = None;
        }
    }
}

impl Default for MapView {
    fn default() -> Self {
        MapView {
            follow: true,
            centre: None,
            radius_m: DEFAULT_RADIUS_M,
            heading_up: false,
            cursor: None,
            fit: None,
            aspect: Cell::new(None),
        }
    }
}

/// What the map keeps of the sky: traffic, tracks, warnings.
#[derive(Debug, Clone, Default)]
pub struct Air {
    pub traffic: Traffic,
    pub cfg: MapConfig,
    /// Positions per vehicle, oldest first: (time, where).
    pub tracks: BTreeMap<VehicleKey, VecDeque<(Micros, LatLon)>>,
    /// Aircraft near the target now (told once as they came near).
    pub near: BTreeSet<u32>,
    /// The second proximity was last checked.
    checked_sec: Option<u64>,
}

impl Air {
    pub fn new(cfg: MapConfig) -> Air {
        Air {
            traffic: Traffic::new(cfg.adsb_timeout),
            cfg,
            ..Air::default()
        }
    }
}

/// A vehicle as the map draws it.
#[derive(Debug, Clone, PartialEq)]
pub struct MapVehicle {
    pub key: VehicleKey,
    pub pos: LatLon,
    /// Degrees, when known.
    pub heading: Option<f64>,
    pub home: Option<LatLon>,
    pub target: bool,
    pub lost: bool,
}

/// A fence shape.
#[derive(Debug, Clone, PartialEq)]
pub enum FenceShape {
    Polygon {
        inclusion: bool,
        points: Vec<LatLon>,
    },
    Circle {
        inclusion: bool,
        centre: LatLon,
        radius: f64,
    },
}

/// True for the frames whose x/y are a latitude and longitude.
fn is_global(frame: u8) -> bool {
    matches!(frame, 0 | 3 | 5 | 6 | 10 | 11)
}

/// The position of a positional item, if it has one (0,0 is "here" on a take-off or land).
pub fn item_pos(i: &MissionItem) -> Option<LatLon> {
    if !mission::command_has_position(i.command) || !is_global(i.frame) || (i.x == 0 && i.y == 0) {
        return None;
    }
    let p = LatLon::new(i.param5(), i.param6());
    p.is_valid().then_some(p)
}

/// True for the items the vehicle flies through (NAV commands with a position), the path's.
pub fn on_path(i: &MissionItem) -> bool {
    i.command < 176 && item_pos(i).is_some()
}

/// The fence list's shapes: polygons from runs of vertices (each `param1` long), circles.
pub fn fence_shapes(items: &[MissionItem]) -> Vec<FenceShape> {
    let mut out = Vec::new();
    let mut run: Option<(u16, usize, Vec<LatLon>)> = None;
    for i in items {
        let Some(p) = item_pos(i) else { continue };
        match i.command {
            cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION | cmd::NAV_FENCE_POLYGON_VERTEX_EXCLUSION => {
                let n = (i.params[0].max(0.0) as usize).max(1);
                let cont =
                    matches!(&run, Some((c, want, pts)) if *c == i.command && pts.len() < *want);
                if !cont {
                    if let Some((c, _, pts)) = run.take() {
                        out.push(polygon(c, pts));
                    }
                    run = Some((i.command, n, Vec::new()));
                }
                if let Some((_, _, pts)) = run.as_mut() {
                    pts.push(p);
                }
            }
            cmd::NAV_FENCE_CIRCLE_INCLUSION | cmd::NAV_FENCE_CIRCLE_EXCLUSION => {
                out.push(FenceShape::Circle {
                    inclusion: i.command == cmd::NAV_FENCE_CIRCLE_INCLUSION,
                    centre: p,
                    radius: i.params[0].max(0.0) as f64,
                });
            }
            _ => {}
        }
    }
    if let Some((c, _, pts)) = run {
        out.push(polygon(c, pts));
    }
    out
}

fn polygon(command: u16, points: Vec<LatLon>) -> FenceShape {
    FenceShape::Polygon {
        inclusion: command == cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION,
        points,
    }
}

impl App {
    /// An ADSB_VEHICLE from anyone: to the traffic table, then the proximity check.
    pub(super) fn on_adsb_frame(
        &mut self,
        link: LinkId,
        frame: &Frame,
        msg: Option<&crate::dialect::MavMessage>,
    ) {
        let incoming = Incoming {
            now: self.now,
            from: (frame.sysid, frame.compid),
            link,
            profile: self.links[link].profile,
            id: frame.msgid,
            payload: frame.payload(),
            msg,
            ack: None,
        };
        Machine::on_message(&mut self.air.traffic, &incoming, &mut Vec::new());
        self.check_traffic();
    }

    /// On every event: old traffic dropped when due (so its deadline never stays in the past),
    /// and once a second the proximity check (the target moves).
    pub(super) fn map_time(&mut self) {
        let mut check = false;
        if self.map_deadline().is_some_and(|d| d <= self.now) {
            let before = self.air.traffic.len();
            Machine::poll(&mut self.air.traffic, self.now, &mut Vec::new());
            if before != self.air.traffic.len() {
                self.dirty = true;
                check = true;
            }
        }
        let sec = self.now / SECOND;
        if self.air.checked_sec != Some(sec) {
            self.air.checked_sec = Some(sec);
            check = true;
        }
        if check {
            self.check_traffic();
        }
    }

    /// When the traffic table next drops an aircraft.
    pub(super) fn map_deadline(&self) -> Option<Micros> {
        Machine::next_deadline(&self.air.traffic)
    }

    /// Positions sampled into the tracks (after frames came).
    pub(super) fn sample_tracks(&mut self) {
        let now = self.now;
        let keep = TRACK_SECS * SECOND;
        for (key, s) in &self.sessions {
            let Some(p) = s.flight.position.as_ref().filter(|p| p.value.is_known()) else {
                continue;
            };
            let t = self.air.tracks.entry(*key).or_default();
            if t.back().is_some_and(|(at, _)| p.at < at + SECOND) {
                continue;
            }
            t.push_back((p.at, LatLon::new(p.value.lat(), p.value.lon())));
            while t.len() > TRACK_POINTS || t.front().is_some_and(|(at, _)| now > at + keep) {
                t.pop_front();
            }
        }
        let sessions = &self.sessions;
        self.air.tracks.retain(|k, _| sessions.contains_key(k));
    }

    /// The track of `key` within the last [`TRACK_SECS`], oldest first.
    pub fn track(&self, key: VehicleKey) -> Vec<LatLon> {
        let keep = TRACK_SECS * SECOND;
        self.air.tracks.get(&key).map_or_else(Vec::new, |t| {
            t.iter()
                .filter(|(at, _)| self.now <= at + keep)
                .map(|(_, p)| *p)
                .collect()
        })
    }

    /// Every vehicle with a position, the target first.
    pub fn map_vehicles(&self) -> Vec<MapVehicle> {
        let mut out: Vec<MapVehicle> = self
            .sessions
            .iter()
            .filter_map(|(key, s)| {
                let p = s.flight.position.as_ref()?.value;
                if !p.is_known() {
                    return None;
                }
                Some(MapVehicle {
                    key: *key,
                    pos: LatLon::new(p.lat(), p.lon()),
                    heading: s.flight.motion.as_ref().map(|m| m.value.heading as f64),
                    home: s
                        .flight
                        .home
                        .as_ref()
                        .map(|h| LatLon::from_e7(h.value.lat_e7, h.value.lon_e7)),
                    target: self.target == Some(*key),
                    lost: self.vehicles.get(*key).is_some_and(|v| v.lost),
                })
            })
            .collect();
        out.sort_by_key(|v| !v.target);
        out
    }

    /// The target's position, altitude AMSL (m) and velocity (east, north m/s).
    fn own(&self) -> Option<(LatLon, f64, (f64, f64))> {
        let s = self.sessions.get(&self.target?)?;
        let p = s.flight.position.as_ref()?.value;
        if !p.is_known() {
            return None;
        }
        let v = s.flight.motion.as_ref().map_or((0.0, 0.0), |m| {
            let (sin, cos) = (m.value.heading as f64).to_radians().sin_cos();
            let g = m.value.groundspeed as f64;
            (g * sin, g * cos)
        });
        Some((LatLon::new(p.lat(), p.lon()), p.alt_m(), v))
    }

    /// The target's position.
    pub fn target_pos(&self) -> Option<LatLon> {
        self.own().map(|o| o.0)
    }

    /// The target's heading, degrees.
    pub fn target_heading(&self) -> Option<f64> {
        let s = self.sessions.get(&self.target?)?;
        s.flight.motion.as_ref().map(|m| m.value.heading as f64)
    }

    /// List `t` of the target as the Mission screen chooses (the vehicle's, or the loaded
    /// file's).
    pub fn map_list(&self, t: MissionType) -> Vec<MissionItem> {
        match self.ui.mission.shown {
            Shown::File => self.ui.mission.files[t.index()]
                .as_ref()
                .map(|f| f.items.clone())
                .unwrap_or_default(),
            Shown::Vehicle => self
                .target
                .and_then(|k| self.sessions.get(&k))
                .and_then(|s| s.mission.known(t))
                .map(|k| k.items.clone())
                .unwrap_or_default(),
        }
    }

    /// The mission rows' sequence number of the item the target flies now.
    pub fn map_current_seq(&self) -> Option<u16> {
        let key = self.target?;
        let cur = self.sessions.get(&key)?.mission.current?.seq;
        let home_held = self.profile(key).mission_home_item();
        Some(match self.ui.mission.shown {
            Shown::File if !home_held => cur + 1,
            _ => cur,
        })
    }

    /// The waypoints on the path (home, item 0 of a list holding it, left out): (seq, where).
    pub fn map_path(&self) -> Vec<(u16, LatLon)> {
        let home_first = match self.ui.mission.shown {
            Shown::File => true,
            Shown::Vehicle => self
                .target
                .is_some_and(|k| self.profile(k).mission_home_item()),
        };
        self.map_list(MissionType::Mission)
            .iter()
            .filter(|i| !(home_first && i.seq == 0))
            .filter(|i| on_path(i))
            .filter_map(|i| Some((i.seq, item_pos(i)?)))
            .collect()
    }

    /// The waypoint flown now (the next with a position), else the first when the vehicle has
    /// said none: (seq, where).
    pub fn next_waypoint(&self) -> Option<(u16, LatLon)> {
        let path = self.map_path();
        match self.map_current_seq() {
            // Past the last one with a position (landing, RTL): none ahead.
            Some(c) => path.iter().find(|(s, _)| *s >= c).copied(),
            None => path.first().copied(),
        }
    }

    /// The target of the target's last go-to (DO_REPOSITION not refused): where it was sent.
    pub fn guided_target(&self) -> Option<LatLon> {
        let s = self.sessions.get(&self.target?)?;
        let e = s
            .commands
            .entries()
            .rev()
            .find(|e| e.spec.command == crate::dialect::MavCmd::MAV_CMD_DO_REPOSITION as u16)?;
        let ok = match e.state {
            State::Waiting | State::InProgress(_) => true,
            State::Done(r) => r == crate::dialect::MavResult::MAV_RESULT_ACCEPTED as u8,
            _ => false,
        };
        let p = LatLon::new(e.spec.params[4], e.spec.params[5]);
        (ok && p.is_valid()).then_some(p)
    }

    /// The traffic seen from the target, nearest first (unsorted by distance when the target
    /// has no position: by ICAO address, with no relative data).
    pub fn traffic_from_target(&self) -> Vec<(&Aircraft, Option<Relative>)> {
        let own = self.own();
        let mut v: Vec<(&Aircraft, Option<Relative>)> = self
            .air
            .traffic
            .aircraft()
            .map(|a| {
                (
                    a,
                    own.map(|(p, alt, vel)| adsb::relative(a, p, Some(alt), vel)),
                )
            })
            .collect();
        v.sort_by(|a, b| {
            let d = |x: &Option<Relative>| x.map_or(f64::MAX, |r| r.distance);
            d(&a.1).total_cmp(&d(&b.1))
        });
        v
    }

    /// The nearest aircraft within the warning's distance and height, as the status bar says it:
    /// `TRAFFIC ABC123 850 m +40 m`.
    pub fn traffic_alert(&self) -> Option<String> {
        let cfg = self.air.cfg;
        let (a, r) = self
            .traffic_from_target()
            .into_iter()
            .filter_map(|(a, r)| Some((a, r?)))
            .find(|(_, r)| adsb::is_near(r, cfg.warn_distance, cfg.warn_height))?;
        let more = self.air.near.len().saturating_sub(1);
        Some(format!(
            "TRAFFIC {} {} {}{}",
            a.name(),
            geo::distance_text(r.distance),
            r.height.map_or("alt ?".into(), |h| format!("{h:+.0} m")),
            if more > 0 {
                format!(" (+{more})")
            } else {
                String::new()
            }
        ))
    }

    /// Which aircraft are near the target; those that just came near are told.
    fn check_traffic(&mut self) {
        let cfg = self.air.cfg;
        let key = self.target;
        let near: Vec<(u32, String)> = self
            .traffic_from_target()
            .into_iter()
            .filter_map(|(a, r)| {
                let r = r?;
                adsb::is_near(&r, cfg.warn_distance, cfg.warn_height).then(|| {
                    (
                        a.icao,
                        format!(
                            "traffic {} {} from {} at {:03.0}°, {}",
                            a.name(),
                            geo::distance_text(r.distance),
                            key.map_or("the target".into(), |k| k.to_string()),
                            r.bearing,
                            r.height
                                .map_or("altitude unknown".into(), |h| format!("{h:+.0} m")),
                        ),
                    )
                })
            })
            .collect();
        let now_near: BTreeSet<u32> = near.iter().map(|(i, _)| *i).collect();
        for (icao, text) in near {
            if !self.air.near.contains(&icao) {
                self.notice(Severity::WARNING, None, text);
            }
        }
        if now_near != self.air.near {
            self.dirty = true;
        }
        self.air.near = now_near;
    }

    /// Where the map is centred now: the target (following), else the centre panned to; with
    /// no target position, its home, the first waypoint or any vehicle.
    pub fn map_centre(&self) -> Option<LatLon> {
        let v = &self.ui.map;
        if !v.follow {
            if let Some(c) = v.centre {
                return Some(c);
            }
        }
        self.target_pos()
            .or_else(|| {
                let s = self.sessions.get(&self.target?)?;
                let h = s.flight.home.as_ref()?.value;
                Some(LatLon::from_e7(h.lat_e7, h.lon_e7))
            })
            .or_else(|| self.map_path().first().map(|p| p.1))
            .or_else(|| self.map_vehicles().first().map(|v| v.pos))
    }

    /// The bearing that is up on the map.
    pub fn map_up(&self) -> f64 {
        if self.ui.map.heading_up {
            self.target_heading().unwrap_or(0.0)
        } else {
            0.0
        }
    }

    /// Everything `f` fits: the mission, fence and rally points, the homes and the vehicles.
    fn fit_points(&self) -> Vec<LatLon> {
        let mut pts: Vec<LatLon> = self.map_path().into_iter().map(|p| p.1).collect();
        for t in [MissionType::Fence, MissionType::Rally] {
            pts.extend(self.map_list(t).iter().filter_map(item_pos));
        }
        for v in self.map_vehicles() {
            pts.push(v.pos);
            pts.extend(v.home);
        }
        pts
    }

    /// Move the view (or the cursor, when it is shown) by a step of the screen: (right, up).
    fn map_move(&mut self, right: f64, up: f64) {
        let Some(centre) = self.map_centre() else {
            self.ui.message = Some((Severity::WARNING, "no position to move from yet".into()));
            return;
        };
        let radius = self.ui.map.shown_radius();
        let upd = self.map_up();
        if let Some(c) = self.ui.map.cursor {
            let (e, n) = geo::unrotate(right * radius / 10.0, up * radius / 10.0, upd);
            self.ui.map.cursor = Some(Plane::new(c).from_en(e, n));
            return;
        }
        let (e, n) = geo::unrotate(right * radius / 4.0, up * radius / 4.0, upd);
        // Moved away from what was fitted: a plain view at the same scale.
        self.ui.map.leave_fit();
        self.ui.map.follow = false;
        self.ui.map.centre = Some(Plane::new(centre).from_en(e, n));
    }

    /// Zoom by `factor` (2: in), from the extent shown if a fit is (on the pane as last drawn).
    fn map_zoom(&mut self, factor: f64) {
        let v = &mut self.ui.map;
        v.leave_fit();
        v.radius_m = (v.radius_m / factor).clamp(MIN_RADIUS_M, MAX_RADIUS_M);
    }

    /// The Map screen's selection step (the arrow keys up/down, page up/down): the view or the
    /// cursor north/south on the screen.
    pub(super) fn select_map(&mut self, step: isize) {
        let up = match step {
            -1 => 1.0,
            1 => -1.0,
            -10 => 4.0,
            10 => -4.0,
            _ => return,
        };
        self.map_move(0.0, up);
    }

    /// True when `+`/`-` zoom the map rather than change a replay's speed: on the Map screen,
    /// with no replay link open.
    pub(super) fn map_takes_speed_keys(&self) -> bool {
        self.ui.screen == "map" && self.replay_links().is_empty()
    }

    /// Keys of the Map screen (and `a` on the Mission screen).
    pub(super) fn on_map_action(&mut self, action: Action, fx: &mut Vec<Effect>) {
        let outcome: Result<Option<String>, String> = match action {
            Action::MapZoomIn | Action::ReplayFaster => {
                self.map_zoom(2.0);
                Ok(None)
            }
            Action::MapZoomOut | Action::ReplaySlower => {
                self.map_zoom(0.5);
                Ok(None)
            }
            Action::MapLeft => {
                self.map_move(-1.0, 0.0);
                Ok(None)
            }
            Action::MapRight => {
                self.map_move(1.0, 0.0);
                Ok(None)
            }
            Action::MapCentre => {
                let v = &mut self.ui.map;
                v.leave_fit();
                v.follow = true;
                v.centre = None;
                Ok(None)
            }
            Action::MapFit => self.map_fit(),
            Action::MapHeadingUp => {
                // A fit is north up: turned, it would no longer hold what it fitted.
                self.ui.map.leave_fit();
                self.ui.map.heading_up = !self.ui.map.heading_up;
                Ok(Some(
                    if self.ui.map.heading_up {
                        "map: heading up"
                    } else {
                        "map: north up"
                    }
                    .into(),
                ))
            }
            Action::MapCursor => {
                self.ui.map.cursor = match self.ui.map.cursor {
                    Some(_) => None,
                    None => self.map_centre(),
                };
                Ok(None)
            }
            Action::MapGoto => match self.ui.map.cursor {
                None => Err("no cursor: enter shows it, then the arrows move it".into()),
                Some(c) => self.goto(c.lat, c.lon, None, fx),
            },
            Action::MissionAddAtCursor => self.add_waypoint_at_cursor(),
            _ => Ok(None),
        };
        self.ui.message = match outcome {
            Ok(Some(t)) => Some((Severity::INFO, t)),
            Ok(None) => None,
            Err(e) => Some((Severity::ERROR, e)),
        };
    }

    /// `f`: the view holds the mission, fence, rally points, homes and vehicles.
    fn map_fit(&mut self) -> Result<Option<String>, String> {
        let pts = self.fit_points();
        let first = *pts
            .first()
            .ok_or("nothing to fit: no position, mission or home yet")?;
        let plane = Plane::new(first);
        let en: Vec<(f64, f64)> = pts.iter().map(|p| plane.to_en(*p)).collect();
        let (mut e0, mut e1, mut n0, mut n1) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for (e, n) in &en {
            e0 = e0.min(*e);
            e1 = e1.max(*e);
            n0 = n0.min(*n);
            n1 = n1.max(*n);
        }
        let centre = plane.from_en((e0 + e1) / 2.0, (n0 + n1) / 2.0);
        // A tenth more room, and never closer than the nearest zoom.
        let hw = ((e1 - e0) / 2.0 * 1.1).max(MIN_RADIUS_M);
        let hh = ((n1 - n0) / 2.0 * 1.1).max(MIN_RADIUS_M);
        let v = &mut self.ui.map;
        v.follow = false;
        v.heading_up = false;
        v.centre = Some(centre);
        v.fit = Some((hw, hh));
        v.radius_m = v.shown_radius().clamp(MIN_RADIUS_M, MAX_RADIUS_M);
        Ok(Some(format!("map: fitted {} points", pts.len())))
    }

    /// `a` on the Mission screen's file list: a waypoint at the map's cursor after the selected
    /// row (a new file list, home first, when none is loaded). Not uploaded.
    fn add_waypoint_at_cursor(&mut self) -> Result<Option<String>, String> {
        if self.ui.mission.shown != Shown::File || self.ui.mission.list != 0 {
            return Err("a adds to the mission file list: switch to it (tab, v)".into());
        }
        let c = self
            .ui
            .map
            .cursor
            .ok_or("no map cursor: on the Map (9), enter shows it and the arrows move it")?;
        let home = self.target.and_then(|k| {
            let h = self.sessions.get(&k)?.flight.home.as_ref()?.value;
            Some(LatLon::from_e7(h.lat_e7, h.lon_e7))
        });
        let file = self.ui.mission.files[0].get_or_insert_with(|| LoadedList {
            path: "new mission".into(),
            items: vec![MissionItem::at(
                MissionType::Mission,
                0,
                0,
                cmd::NAV_WAYPOINT,
                home.unwrap_or(c).lat,
                home.unwrap_or(c).lon,
                0.0,
            )],
            errors: Vec::new(),
        });
        // The altitude of the waypoint before it, else the take-off altitude.
        let at = (self.ui.mission.sel + 1).clamp(1, file.items.len().max(1));
        let alt = file.items[..at.min(file.items.len())]
            .iter()
            .rev()
            .find(|i| on_path(i) && i.seq != 0 && i.alt_ref() == mission::AltRef::Rel)
            .map_or(self.cfg.takeoff_alt as f32, |i| i.z);
        let wp = MissionItem::at(
            MissionType::Mission,
            at as u16,
            3, // MAV_FRAME_GLOBAL_RELATIVE_ALT
            cmd::NAV_WAYPOINT,
            c.lat,
            c.lon,
            alt,
        );
        file.items.insert(at.min(file.items.len()), wp);
        mission::renumber(&mut file.items);
        self.ui.mission.sel = at;
        Ok(Some(format!(
            "waypoint {at} at {:.7} {:.7}, {alt:.0} m: added to {} (not uploaded)",
            c.lat, c.lon, file.path
        )))
    }

    /// The cursor's text for the footer: where it is, and from the target.
    pub fn cursor_text(&self) -> Option<String> {
        let c = self.ui.map.cursor?;
        let from = match (self.target, self.target_pos()) {
            (Some(k), Some(p)) => format!(
                "  {} at {:03.0}° from {k}",
                geo::distance_text(geo::distance_m(p, c)),
                geo::bearing_deg(p, c)
            ),
            _ => String::new(),
        };
        Some(format!("cursor {:.6} {:.6}{from}", c.lat, c.lon))
    }
}
