//! Cameras of one system (MAVLink Camera Protocol v2), sans-I/O.
//!
//! - Discovery: a component whose HEARTBEAT says MAV_TYPE_CAMERA, or an autopilot that sends
//!   CAMERA_INFORMATION itself (ArduPilot's camera library answers on the autopilot's id), is
//!   asked for CAMERA_INFORMATION with MAV_CMD_REQUEST_MESSAGE; if that is refused or goes
//!   unanswered the older MAV_CMD_REQUEST_CAMERA_INFORMATION (521, param1 = 1) is tried, as
//!   QGroundControl does. Then CAMERA_SETTINGS, STORAGE_INFORMATION, CAMERA_CAPTURE_STATUS and,
//!   with CAMERA_CAP_FLAGS_HAS_VIDEO_STREAM, VIDEO_STREAM_INFORMATION. CAMERA_SETTINGS and
//!   STORAGE_INFORMATION fall back the same way, to MAV_CMD_REQUEST_CAMERA_SETTINGS (522) and
//!   MAV_CMD_REQUEST_STORAGE_INFORMATION (525), for a camera that serves only those.
//! - The camera messages are read from their payloads (zeros MAVLink 2 cut restored), so a
//!   camera that sets flag bits or enum values newer than our dialect is still read.
//! - Images: every CAMERA_IMAGE_CAPTURED is kept by index; an index below the highest heard (or
//!   below CAMERA_CAPTURE_STATUS.image_count) that never came is asked for again
//!   (REQUEST_MESSAGE 263, param2 = index), up to [`HOLE_TRIES`] times, so the list has no holes.
//!   A request the camera refuses is not made again; a refused index below every one heard means
//!   the camera numbers from later (the spec says from 0; some start at 1): said once, and
//!   indices below its first are no longer looked for.
//! - Operating: [`CameraSet::action`] turns what the operator asks into a command for the camera,
//!   or says why the camera cannot do it (its flags, its mode).
//!
//! Requests go out through the vehicle's command queue (one REQUEST_MESSAGE open per target at
//! a time): the set holds them until [`CameraSet::next_request`] is taken.

// The older camera requests (521, 522, 525) are deliberately kept as the fallback.
#![allow(deprecated)]

use std::collections::{BTreeMap, VecDeque};

use crate::clock::{Micros, SECOND};
use crate::dialect::{self, MavCmd};
use crate::proto::machine::{Ids, Incoming, Machine, Out, Request, Requests};
use mavlink::MessageData;
use num_traits::FromPrimitive;

pub const CAMERA_INFORMATION: u32 = crate::dialect::CAMERA_INFORMATION_DATA::ID;
pub const CAMERA_SETTINGS: u32 = crate::dialect::CAMERA_SETTINGS_DATA::ID;
pub const STORAGE_INFORMATION: u32 = crate::dialect::STORAGE_INFORMATION_DATA::ID;
pub const CAMERA_CAPTURE_STATUS: u32 = crate::dialect::CAMERA_CAPTURE_STATUS_DATA::ID;
pub const CAMERA_IMAGE_CAPTURED: u32 = crate::dialect::CAMERA_IMAGE_CAPTURED_DATA::ID;
pub const VIDEO_STREAM_INFORMATION: u32 = crate::dialect::VIDEO_STREAM_INFORMATION_DATA::ID;

/// MAV_TYPE_CAMERA.
pub const MAV_TYPE_CAMERA: u8 = 30;

/// Times a missing image is asked for.
pub const HOLE_TRIES: u32 = 3;
/// The wait for a missing image before asking again.
pub const HOLE_RETRY: Micros = 3 * SECOND;
/// Missing images are looked for among the newest this many indices only (below the highest
/// known): a camera whose count runs far ahead costs a fixed amount per message.
pub const HOLE_SPAN: i32 = 256;
/// Requests for missing images waiting at once, at most (the newest first).
pub const HOLE_QUEUE: usize = 16;
/// After a CAMERA_INFORMATION request finished without the message, the wait before 521.
pub const FALLBACK_WAIT: Micros = SECOND;
/// VIDEO_STREAM_INFORMATION (all streams, param2 = 0) is asked this many times at most, this
/// long after a request that brought none.
pub const STREAM_TRIES: u32 = 3;
pub const STREAM_RETRY: Micros = 3 * SECOND;

/// CAMERA_CAP_FLAGS, bit by bit, as the common dialect names them.
pub const CAP_FLAGS: &[(u32, &str)] = &[
    (1, "CAPTURE_VIDEO"),
    (2, "CAPTURE_IMAGE"),
    (4, "HAS_MODES"),
    (8, "CAN_CAPTURE_IMAGE_IN_VIDEO_MODE"),
    (16, "CAN_CAPTURE_VIDEO_IN_IMAGE_MODE"),
    (32, "HAS_IMAGE_SURVEY_MODE"),
    (64, "HAS_BASIC_ZOOM"),
    (128, "HAS_BASIC_FOCUS"),
    (256, "HAS_VIDEO_STREAM"),
    (512, "HAS_TRACKING_POINT"),
    (1024, "HAS_TRACKING_RECTANGLE"),
    (2048, "HAS_TRACKING_GEO_STATUS"),
    (4096, "HAS_THERMAL_RANGE"),
    (8192, "HAS_MTI"),
];
pub const CAP_CAPTURE_VIDEO: u32 = 1;
pub const CAP_CAPTURE_IMAGE: u32 = 2;
pub const CAP_HAS_MODES: u32 = 4;
pub const CAP_IMAGE_IN_VIDEO_MODE: u32 = 8;
pub const CAP_VIDEO_IN_IMAGE_MODE: u32 = 16;
pub const CAP_SURVEY_MODE: u32 = 32;
pub const CAP_ZOOM: u32 = 64;
pub const CAP_FOCUS: u32 = 128;
pub const CAP_VIDEO_STREAM: u32 = 256;

/// The names of the bits set in `flags` (unknown bits as `BIT n`).
pub fn flag_names(flags: u32) -> Vec<String> {
    names(CAP_FLAGS, flags)
}

/// The names of the bits of `flags` in `table` (unknown bits as `BITn`).
pub fn names(table: &[(u32, &str)], flags: u32) -> Vec<String> {
    (0..32)
        .filter(|b| flags & (1 << b) != 0)
        .map(|b| {
            table
                .iter()
                .find(|(v, _)| *v == 1 << b)
                .map_or(format!("BIT{b}"), |(_, n)| n.to_string())
        })
        .collect()
}

/// CAMERA_MODE by number.
pub fn mode_name(mode: u8) -> &'static str {
    match mode {
        0 => "image",
        1 => "video",
        2 => "survey",
        _ => "unknown",
    }
}

/// Payloads are read with the one zero-extending reader.
pub(crate) use crate::wire::payload::Payload as P;

/// CAMERA_INFORMATION.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraInfo {
    pub vendor: String,
    pub model: String,
    /// (major, minor, revision, build), from `firmware_version` (build in the top byte).
    pub firmware: (u8, u8, u8, u8),
    pub focal_length_mm: f32,
    pub sensor_mm: (f32, f32),
    pub flags: u32,
    pub resolution: (u16, u16),
    pub lens_id: u8,
    pub definition_uri: String,
    pub gimbal_device_id: u8,
}

impl CameraInfo {
    pub fn read(payload: &[u8]) -> CameraInfo {
        let p = P(payload);
        let fw = p.u32(4);
        CameraInfo {
            firmware: (
                (fw & 0xff) as u8,
                (fw >> 8 & 0xff) as u8,
                (fw >> 16 & 0xff) as u8,
                (fw >> 24) as u8,
            ),
            focal_length_mm: p.f32(8),
            sensor_mm: (p.f32(12), p.f32(16)),
            flags: p.u32(20),
            resolution: (p.u16(24), p.u16(26)),
            vendor: p.text(30, 32),
            model: p.text(62, 32),
            lens_id: p.u8(94),
            definition_uri: p.text(95, 140),
            gimbal_device_id: p.u8(235),
        }
    }
    pub fn has(&self, flag: u32) -> bool {
        self.flags & flag != 0
    }
}

/// CAMERA_SETTINGS.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    pub mode: u8,
    pub zoom: f32,
    pub focus: f32,
}

/// STORAGE_INFORMATION (MiB).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Storage {
    pub total: f32,
    pub used: f32,
    pub available: f32,
    pub id: u8,
    pub count: u8,
    /// STORAGE_STATUS: 0 empty, 1 unformatted, 2 ready, 3 not supported.
    pub status: u8,
}

/// CAMERA_CAPTURE_STATUS.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CaptureStatus {
    pub image_interval: f32,
    pub recording_ms: u32,
    pub available_mib: f32,
    /// 0 idle, 1 capturing, 2 interval set but idle, 3 interval set and capturing.
    pub image_status: u8,
    /// 0 idle, 1 recording.
    pub video_status: u8,
    pub image_count: i32,
}

/// One CAMERA_IMAGE_CAPTURED.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    pub index: i32,
    pub time_utc_us: u64,
    pub lat_e7: i32,
    pub lon_e7: i32,
    pub alt_mm: i32,
    pub relative_alt_mm: i32,
    /// 1 success, 0 failure, -1 unknown.
    pub result: i8,
    pub url: String,
}

impl Image {
    pub fn read(payload: &[u8]) -> Image {
        let p = P(payload);
        Image {
            time_utc_us: p.u64(0),
            lat_e7: p.i32(12),
            lon_e7: p.i32(16),
            alt_mm: p.i32(20),
            relative_alt_mm: p.i32(24),
            index: p.i32(44),
            result: p.u8(49) as i8,
            url: p.text(50, 205),
        }
    }
}

/// VIDEO_STREAM_INFORMATION.
#[derive(Debug, Clone, PartialEq)]
pub struct Stream {
    pub id: u8,
    pub name: String,
    pub uri: String,
    pub resolution: (u16, u16),
    pub framerate: f32,
    /// VIDEO_STREAM_TYPE: 0 RTSP, 1 RTP/UDP, 2 TCP MPEG, 3 MPEG-TS.
    pub kind: u8,
}

/// Where asking for CAMERA_INFORMATION stands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Discovery {
    /// REQUEST_MESSAGE 259 asked (or waiting to be).
    Asking,
    /// Refused or unanswered: 521 from this time.
    FallbackAt(Micros),
    /// MAV_CMD_REQUEST_CAMERA_INFORMATION asked.
    Legacy,
    Found,
    /// Neither request brought CAMERA_INFORMATION.
    Failed,
}

/// One camera component.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    pub compid: u8,
    pub discovery: Discovery,
    pub info: Option<CameraInfo>,
    pub settings: Option<Settings>,
    pub storage: Option<Storage>,
    pub status: Option<CaptureStatus>,
    pub images: BTreeMap<i32, Image>,
    /// The index of the last CAMERA_IMAGE_CAPTURED heard (not a re-requested one).
    pub last_image: Option<i32>,
    pub streams: BTreeMap<u8, Stream>,
    /// Missing image indices asked for again: how often, and when last.
    asked: BTreeMap<i32, (u32, Micros)>,
    /// Requests waiting for the command queue: (command, params).
    pending: VecDeque<(u16, [f64; 7])>,
    /// Sequence number of the next single-image capture (IMAGE_START_CAPTURE param4).
    next_seq: u32,
    /// VIDEO_STREAM_INFORMATION requests so far, and when to ask again.
    stream_asks: u32,
    stream_next: Option<Micros>,
    /// CAMERA_SETTINGS / STORAGE_INFORMATION asked by REQUEST_MESSAGE without the message: the
    /// older command (522 / 525) from this time, if it still has not come.
    older: Vec<(Micros, u32)>,
    /// The camera's first image index when it is not 0 (learnt from a refused request).
    pub first_index: Option<i32>,
}

impl Camera {
    fn new(compid: u8) -> Camera {
        let mut c = Camera {
            compid,
            discovery: Discovery::Asking,
            info: None,
            settings: None,
            storage: None,
            status: None,
            images: BTreeMap::new(),
            last_image: None,
            streams: BTreeMap::new(),
            asked: BTreeMap::new(),
            pending: VecDeque::new(),
            next_seq: 1,
            stream_asks: 0,
            stream_next: None,
            older: Vec::new(),
            first_index: None,
        };
        c.request(CAMERA_INFORMATION, 0.0);
        c
    }

    fn request(&mut self, id: u32, p2: f64) {
        let r = (
            (MavCmd::MAV_CMD_REQUEST_MESSAGE as u16),
            [id as f64, p2, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        if !self.pending.contains(&r) {
            self.pending.push_back(r);
        }
    }

    pub fn has(&self, flag: u32) -> bool {
        self.info.as_ref().is_some_and(|i| i.has(flag))
    }

    pub fn recording(&self) -> bool {
        self.status.is_some_and(|s| s.video_status == 1)
    }

    /// The window holes are looked for in: the newest [`HOLE_SPAN`] indices below the highest
    /// known (an image heard, or the count CAMERA_CAPTURE_STATUS gives).
    fn hole_window(&self) -> std::ops::Range<i32> {
        let top = self
            .images
            .keys()
            .next_back()
            .map(|i| i.saturating_add(1))
            .unwrap_or(0)
            .max(self.status.map_or(0, |s| s.image_count));
        // A camera whose numbering starts above 0 (told once) has no holes below its first.
        top.saturating_sub(HOLE_SPAN)
            .max(self.first_index.unwrap_or(0))..top
    }

    /// Image indices in the hole window that never came, oldest first: the ranges between the
    /// images heard there (O(log n + HOLE_SPAN), however far the count ran).
    pub fn missing(&self) -> Vec<i32> {
        let w = self.hole_window();
        let mut out = Vec::new();
        let mut next = w.start;
        for &i in self.images.range(w.clone()).map(|(i, _)| i) {
            out.extend(next..i);
            next = i + 1;
        }
        out.extend(next..w.end);
        out
    }

    /// Image requests waiting in `pending`.
    fn hole_requests(&self) -> usize {
        self.pending
            .iter()
            .filter(|(cmd, p)| {
                *cmd == (MavCmd::MAV_CMD_REQUEST_MESSAGE as u16)
                    && p[0] == CAMERA_IMAGE_CAPTURED as f64
            })
            .count()
    }

    fn find_holes(&mut self, now: Micros) {
        let w = self.hole_window();
        // Holes that fell out of the window are forgotten, and their waiting requests dropped.
        while self
            .asked
            .first_key_value()
            .is_some_and(|(&i, _)| i < w.start)
        {
            self.asked.pop_first();
        }
        self.pending.retain(|(cmd, p)| {
            !(*cmd == (MavCmd::MAV_CMD_REQUEST_MESSAGE as u16)
                && p[0] == CAMERA_IMAGE_CAPTURED as f64
                && (p[1] as i32) < w.start)
        });
        let mut queued = self.hole_requests();
        // The newest first, a bounded number waiting at once.
        for i in self.missing().into_iter().rev() {
            if queued >= HOLE_QUEUE {
                break;
            }
            let (n, last) = self.asked.entry(i).or_insert((0, 0));
            if *n == 0 || (*n < HOLE_TRIES && now >= *last + HOLE_RETRY) {
                *n += 1;
                *last = now;
                let before = self.pending.len();
                self.request(CAMERA_IMAGE_CAPTURED, i as f64);
                queued += self.pending.len() - before;
            }
        }
    }

    /// When a missing image is next asked for again (the holes asked for are at most
    /// [`HOLE_SPAN`]).
    fn hole_deadline(&self) -> Option<Micros> {
        self.asked
            .iter()
            .filter(|(i, (n, _))| *n < HOLE_TRIES && !self.images.contains_key(i))
            .map(|(_, (_, last))| last + HOLE_RETRY)
            .min()
    }

    /// Missing-image bookkeeping held: (holes asked for, requests waiting).
    pub fn hole_tracking(&self) -> (usize, usize) {
        (self.asked.len(), self.pending.len())
    }

    /// The line the Camera screen heads with: `Sony ILX-LR1 (1:100)`.
    pub fn title(&self) -> String {
        match &self.info {
            Some(i) => format!("{} {}", i.vendor, i.model),
            None => "camera".into(),
        }
    }
}

/// What the operator asks of a camera.
#[derive(Debug, Clone, PartialEq)]
pub enum CameraAction {
    Mode(u8),
    /// Images: count (0 = until stopped), interval in seconds.
    Shoot {
        count: u32,
        interval: f64,
    },
    StopImages,
    VideoStart,
    VideoStop,
    Zoom(f64),
    Focus(f64),
    Format,
}

impl CameraAction {
    /// What the operator sees it as: `shoot 3 every 1 s`, `mode video`, …
    pub fn describe(&self) -> String {
        match self {
            CameraAction::Mode(m) => format!("mode {}", mode_name(*m)),
            CameraAction::Shoot { count: 1, .. } => "shoot".into(),
            CameraAction::Shoot { count: 0, interval } => {
                format!("shoot every {interval} s until stopped")
            }
            CameraAction::Shoot { count, interval } => format!("shoot {count} every {interval} s"),
            CameraAction::StopImages => "stop images".into(),
            CameraAction::VideoStart => "video start".into(),
            CameraAction::VideoStop => "video stop".into(),
            CameraAction::Zoom(z) => format!("zoom {z}%"),
            CameraAction::Focus(f) => format!("focus {f}%"),
            CameraAction::Format => "format storage".into(),
        }
    }
}

/// The cameras of one system, by component id.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CameraSet {
    pub cameras: BTreeMap<u8, Camera>,
    /// A request may wait for the queue since this time (a command to a camera finished): the
    /// next poll has it offered again.
    offer: Option<Micros>,
}

impl CameraSet {
    /// A message of component `from` of this system. `hb_type`: its HEARTBEAT's MAV_TYPE.
    /// Returns notices to show.
    pub fn on_message(
        &mut self,
        now: Micros,
        from: u8,
        id: u32,
        hb_type: Option<u8>,
        payload: &[u8],
    ) -> Vec<(crate::wire::Severity, String)> {
        let mut notes = Vec::new();
        if hb_type == Some(MAV_TYPE_CAMERA) && !self.cameras.contains_key(&from) {
            self.cameras.insert(from, Camera::new(from));
            return notes;
        }
        if id == CAMERA_INFORMATION && !self.cameras.contains_key(&from) {
            // An autopilot answering for its camera (ArduPilot).
            let mut c = Camera::new(from);
            c.pending.clear();
            self.cameras.insert(from, c);
        }
        let Some(c) = self.cameras.get_mut(&from) else {
            return notes;
        };
        match id {
            CAMERA_INFORMATION => {
                let info = CameraInfo::read(payload);
                let first = c.info.is_none();
                if first {
                    notes.push((
                        crate::wire::Severity::INFO,
                        format!(
                            "camera {from}: {} {} {}x{}",
                            info.vendor, info.model, info.resolution.0, info.resolution.1
                        ),
                    ));
                    c.request(CAMERA_SETTINGS, 0.0);
                    c.request(STORAGE_INFORMATION, 0.0);
                    c.request(CAMERA_CAPTURE_STATUS, 0.0);
                    if info.has(CAP_VIDEO_STREAM) {
                        c.request(VIDEO_STREAM_INFORMATION, 0.0);
                        c.stream_asks = 1;
                    }
                }
                c.discovery = Discovery::Found;
                c.info = Some(info);
            }
            CAMERA_SETTINGS => {
                let p = P(payload);
                c.settings = Some(Settings {
                    mode: p.u8(4),
                    zoom: p.f32(5),
                    focus: p.f32(9),
                });
            }
            STORAGE_INFORMATION => {
                let p = P(payload);
                c.storage = Some(Storage {
                    total: p.f32(4),
                    used: p.f32(8),
                    available: p.f32(12),
                    id: p.u8(24),
                    count: p.u8(25),
                    status: p.u8(26),
                });
            }
            CAMERA_CAPTURE_STATUS => {
                let p = P(payload);
                c.status = Some(CaptureStatus {
                    image_interval: p.f32(4),
                    recording_ms: p.u32(8),
                    available_mib: p.f32(12),
                    image_status: p.u8(16),
                    video_status: p.u8(17),
                    image_count: p.i32(18),
                });
                c.find_holes(now);
            }
            CAMERA_IMAGE_CAPTURED => {
                let img = Image::read(payload);
                if img.index >= 0 {
                    let again = c.asked.remove(&img.index).is_some();
                    if !again {
                        c.last_image = Some(img.index.max(c.last_image.unwrap_or(-1)));
                        // The count and the card's free space changed.
                        c.request(CAMERA_CAPTURE_STATUS, 0.0);
                    }
                    c.images.insert(img.index, img);
                    // Keep memory bounded: the newest 10 000 images.
                    while c.images.len() > 10_000 {
                        c.images.pop_first();
                    }
                    c.find_holes(now);
                }
            }
            VIDEO_STREAM_INFORMATION => {
                let p = P(payload);
                let s = Stream {
                    framerate: p.f32(0),
                    resolution: (p.u16(10), p.u16(12)),
                    id: p.u8(18),
                    kind: p.u8(20),
                    name: p.text(21, 32),
                    uri: p.text(53, 160),
                };
                if c.streams.len() < 16 || c.streams.contains_key(&s.id) {
                    c.streams.insert(s.id, s);
                }
            }
            _ => {}
        }
        notes
    }

    /// A command to camera `compid` finished: `accepted` or not. Drives the fallback and the
    /// refreshes after a change.
    pub fn on_finished(
        &mut self,
        now: Micros,
        compid: u8,
        command: u16,
        params: &[f64; 7],
        accepted: bool,
    ) -> Vec<(crate::wire::Severity, String)> {
        let mut notes = Vec::new();
        let Some(c) = self.cameras.get_mut(&compid) else {
            return notes;
        };
        self.offer = Some(self.offer.map_or(now, |t| t.min(now)));
        match MavCmd::from_u16(command) {
            Some(MavCmd::MAV_CMD_REQUEST_MESSAGE)
                if params[0] == CAMERA_INFORMATION as f64
                    && c.info.is_none()
                    && c.discovery == Discovery::Asking =>
            {
                c.discovery = Discovery::FallbackAt(now + FALLBACK_WAIT);
            }
            Some(MavCmd::MAV_CMD_REQUEST_CAMERA_INFORMATION) if c.info.is_none() && !accepted => {
                c.discovery = Discovery::Failed;
                notes.push((
                    crate::wire::Severity::WARNING,
                    format!(
                        "camera {compid}: no CAMERA_INFORMATION (REQUEST_MESSAGE and 521 unanswered)"
                    ),
                ));
            }
            Some(MavCmd::MAV_CMD_REQUEST_MESSAGE)
                if (params[0] == CAMERA_SETTINGS as f64 && c.settings.is_none())
                    || (params[0] == STORAGE_INFORMATION as f64 && c.storage.is_none()) =>
            {
                // Refused, unanswered, or accepted without the message: the older command soon
                // if the message still has not come (once).
                let id = params[0] as u32;
                if !c.older.iter().any(|(_, m)| *m == id) {
                    c.older.push((now + FALLBACK_WAIT, id));
                }
            }
            Some(MavCmd::MAV_CMD_REQUEST_MESSAGE)
                if params[0] == VIDEO_STREAM_INFORMATION as f64 && c.streams.is_empty() =>
            {
                // None came (lost, or refused): asked again, a bounded number of times.
                c.stream_next = (c.stream_asks < STREAM_TRIES).then_some(now + STREAM_RETRY);
            }
            Some(MavCmd::MAV_CMD_SET_CAMERA_MODE)
            | Some(MavCmd::MAV_CMD_SET_CAMERA_ZOOM)
            | Some(MavCmd::MAV_CMD_SET_CAMERA_FOCUS)
                if accepted =>
            {
                c.request(CAMERA_SETTINGS, 0.0);
            }
            Some(MavCmd::MAV_CMD_IMAGE_START_CAPTURE)
            | Some(MavCmd::MAV_CMD_IMAGE_STOP_CAPTURE)
            | Some(MavCmd::MAV_CMD_VIDEO_START_CAPTURE)
            | Some(MavCmd::MAV_CMD_VIDEO_STOP_CAPTURE) => {
                c.request(CAMERA_CAPTURE_STATUS, 0.0);
            }
            Some(MavCmd::MAV_CMD_STORAGE_FORMAT) if accepted => {
                c.request(STORAGE_INFORMATION, 0.0);
                c.request(CAMERA_CAPTURE_STATUS, 0.0);
            }
            _ => {}
        }
        notes
    }

    /// The camera refused a command (a COMMAND_ACK with a result other than ACCEPTED). A missing
    /// image it will not give is not asked for again; one below every index heard means the
    /// camera numbers its images from later than 0: said once.
    pub fn on_refused(
        &mut self,
        compid: u8,
        command: u16,
        params: &[f64; 7],
    ) -> Vec<(crate::wire::Severity, String)> {
        let mut notes = Vec::new();
        let Some(c) = self.cameras.get_mut(&compid) else {
            return notes;
        };
        if command != (MavCmd::MAV_CMD_REQUEST_MESSAGE as u16)
            || params[0] != CAMERA_IMAGE_CAPTURED as f64
        {
            return notes;
        }
        let index = params[1] as i32;
        c.asked.insert(index, (HOLE_TRIES, 0));
        let lowest = c.images.keys().next().copied();
        if c.first_index.is_none() && lowest.is_some_and(|l| index < l) {
            let l = lowest.unwrap_or(0);
            c.first_index = Some(l);
            notes.push((
                crate::wire::Severity::NOTICE,
                format!(
                    "camera {compid}: image {index} refused: its image numbering starts at {l}, not 0 as the camera protocol says; images before {l} are not asked for"
                ),
            ));
        }
        notes
    }

    /// Due work: the 521, 522 and 525 fallbacks.
    pub fn poll(&mut self, now: Micros) {
        for c in self.cameras.values_mut() {
            let due: Vec<u32> = c
                .older
                .iter()
                .filter(|(t, _)| *t != Micros::MAX && now >= *t)
                .map(|(_, m)| *m)
                .collect();
            for m in due {
                for o in c.older.iter_mut().filter(|(_, x)| *x == m) {
                    o.0 = Micros::MAX; // done: asked once
                }
                let (missing, cmd, p) = match m {
                    CAMERA_SETTINGS => (
                        c.settings.is_none(),
                        (MavCmd::MAV_CMD_REQUEST_CAMERA_SETTINGS as u16),
                        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                    ),
                    // param1 = storage id (0: all), param2 = 1: request.
                    _ => (
                        c.storage.is_none(),
                        (MavCmd::MAV_CMD_REQUEST_STORAGE_INFORMATION as u16),
                        [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                    ),
                };
                if missing {
                    c.pending.push_back((cmd, p));
                }
            }
            if c.hole_deadline().is_some_and(|t| now >= t) {
                c.find_holes(now);
            }
            if c.stream_next.is_some_and(|t| now >= t) {
                c.stream_next = None;
                if c.streams.is_empty() {
                    c.stream_asks += 1;
                    c.request(VIDEO_STREAM_INFORMATION, 0.0);
                }
            }
            if let Discovery::FallbackAt(t) = c.discovery {
                if now >= t && c.info.is_none() {
                    c.discovery = Discovery::Legacy;
                    c.pending.push_back((
                        (MavCmd::MAV_CMD_REQUEST_CAMERA_INFORMATION as u16),
                        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                    ));
                }
            }
        }
    }

    pub fn next_deadline(&self) -> Option<Micros> {
        self.cameras
            .values()
            .flat_map(|c| {
                let fallback = match c.discovery {
                    Discovery::FallbackAt(t) => Some(t),
                    _ => None,
                };
                let older = c
                    .older
                    .iter()
                    .map(|(t, _)| *t)
                    .filter(|t| *t != Micros::MAX)
                    .min();
                [fallback, c.hole_deadline(), c.stream_next, older]
            })
            .flatten()
            .min()
    }

    /// The requests waiting, by camera: (compid, command, params), the first of each camera.
    pub fn heads(&self) -> Vec<(u8, u16, [f64; 7])> {
        self.cameras
            .values()
            .filter_map(|c| c.pending.front().map(|(cmd, p)| (c.compid, *cmd, *p)))
            .collect()
    }

    /// The head request of `compid` went out.
    pub fn sent(&mut self, compid: u8) {
        if let Some(c) = self.cameras.get_mut(&compid) {
            c.pending.pop_front();
        }
    }

    /// The command for `action` on camera `compid`, or why the camera cannot do it.
    pub fn action(&self, compid: u8, action: &CameraAction) -> Result<(u16, [f64; 7]), String> {
        let c = self
            .cameras
            .get(&compid)
            .ok_or_else(|| format!("no camera {compid}"))?;
        let info = c
            .info
            .as_ref()
            .ok_or_else(|| format!("camera {compid}: CAMERA_INFORMATION not heard yet"))?;
        let has = |f: u32| info.has(f);
        let lacks = |what: &str, flag: &str| {
            format!("camera {compid} cannot {what} (no CAMERA_CAP_FLAGS_{flag})")
        };
        let mode = c.settings.map(|s| s.mode);
        let p = |a: f64, b: f64, cc: f64, d: f64| [a, b, cc, d, 0.0, 0.0, 0.0];
        match action {
            CameraAction::Mode(m) => {
                if !has(CAP_HAS_MODES) {
                    return Err(lacks("change modes", "HAS_MODES"));
                }
                if *m == 2 && !has(CAP_SURVEY_MODE) {
                    return Err(lacks("survey", "HAS_IMAGE_SURVEY_MODE"));
                }
                if c.recording() {
                    return Err(format!(
                        "camera {compid} is recording: `camera video stop` first"
                    ));
                }
                Ok((
                    (MavCmd::MAV_CMD_SET_CAMERA_MODE as u16),
                    p(0.0, *m as f64, 0.0, 0.0),
                ))
            }
            CameraAction::Shoot { count, interval } => {
                if !has(CAP_CAPTURE_IMAGE) {
                    return Err(lacks("take images", "CAPTURE_IMAGE"));
                }
                if has(CAP_HAS_MODES) && !has(CAP_IMAGE_IN_VIDEO_MODE) {
                    match mode {
                        None => return Err(format!("camera {compid}: mode unknown (CAMERA_SETTINGS not heard): not sent")),
                        Some(1) => return Err(format!("camera {compid} is in video mode: `camera mode image` first (not sent)")),
                        _ => {}
                    }
                }
                let seq = if *count == 1 { c.next_seq as f64 } else { 0.0 };
                Ok((
                    (MavCmd::MAV_CMD_IMAGE_START_CAPTURE as u16),
                    p(0.0, *interval, *count as f64, seq),
                ))
            }
            CameraAction::StopImages => Ok((
                (MavCmd::MAV_CMD_IMAGE_STOP_CAPTURE as u16),
                p(0.0, 0.0, 0.0, 0.0),
            )),
            CameraAction::VideoStart => {
                if !has(CAP_CAPTURE_VIDEO) {
                    return Err(lacks("record video", "CAPTURE_VIDEO"));
                }
                if has(CAP_HAS_MODES) && !has(CAP_VIDEO_IN_IMAGE_MODE) {
                    match mode {
                        None => {
                            return Err(format!(
                            "camera {compid}: mode unknown (CAMERA_SETTINGS not heard): not sent"
                        ))
                        }
                        Some(m) if m != 1 => {
                            return Err(format!(
                            "camera {compid} is in {} mode: `camera mode video` first (not sent)",
                            mode_name(m)
                        ))
                        }
                        _ => {}
                    }
                }
                // CAMERA_CAPTURE_STATUS at 1 Hz while recording (param2).
                Ok((
                    (MavCmd::MAV_CMD_VIDEO_START_CAPTURE as u16),
                    p(0.0, 1.0, 0.0, 0.0),
                ))
            }
            CameraAction::VideoStop => Ok((
                (MavCmd::MAV_CMD_VIDEO_STOP_CAPTURE as u16),
                p(0.0, 0.0, 0.0, 0.0),
            )),
            CameraAction::Zoom(z) => {
                if !has(CAP_ZOOM) {
                    return Err(lacks("zoom", "HAS_BASIC_ZOOM"));
                }
                // ZOOM_TYPE_RANGE (2): 0 to 100 % of the range.
                Ok((
                    (MavCmd::MAV_CMD_SET_CAMERA_ZOOM as u16),
                    p(2.0, *z, 0.0, 0.0),
                ))
            }
            CameraAction::Focus(f) => {
                if !has(CAP_FOCUS) {
                    return Err(lacks("focus", "HAS_BASIC_FOCUS"));
                }
                // FOCUS_TYPE_RANGE (2): 0 to 100 % of the range.
                Ok((
                    (MavCmd::MAV_CMD_SET_CAMERA_FOCUS as u16),
                    p(2.0, *f, 0.0, 0.0),
                ))
            }
            CameraAction::Format => {
                if c.storage.is_none() {
                    return Err(format!("camera {compid}: STORAGE_INFORMATION not heard"));
                }
                if c.recording() {
                    return Err(format!(
                        "camera {compid} is recording: `camera video stop` first"
                    ));
                }
                let id = c.storage.map_or(1, |s| s.id.max(1));
                // Storage id (1 = first), format, reset the image log.
                Ok((
                    (MavCmd::MAV_CMD_STORAGE_FORMAT as u16),
                    p(id as f64, 1.0, 1.0, 0.0),
                ))
            }
        }
    }

    /// A single capture went out: the next one carries the next sequence number.
    pub fn shot_sent(&mut self, compid: u8) {
        if let Some(c) = self.cameras.get_mut(&compid) {
            c.next_seq += 1;
        }
    }

    /// After a format that reset the image log: forget the images.
    pub fn forget_images(&mut self, compid: u8) {
        if let Some(c) = self.cameras.get_mut(&compid) {
            c.images.clear();
            c.asked.clear();
            c.last_image = None;
        }
    }
}

/// Notes in the one contract.
pub(crate) fn notes_out(notes: Vec<(crate::wire::Severity, String)>, out: &mut Vec<Out>) {
    out.extend(notes.into_iter().map(|(s, t)| Out::notice(s, t)));
}

impl Machine for CameraSet {
    /// Heartbeats (a camera announces itself) and the camera protocol's messages.
    const IDS: Ids = Ids::Only(&[
        dialect::HEARTBEAT_DATA::ID,
        dialect::CAMERA_INFORMATION_DATA::ID,
        dialect::CAMERA_SETTINGS_DATA::ID,
        dialect::STORAGE_INFORMATION_DATA::ID,
        dialect::CAMERA_CAPTURE_STATUS_DATA::ID,
        dialect::CAMERA_IMAGE_CAPTURED_DATA::ID,
        dialect::FLIGHT_INFORMATION_DATA::ID,
        dialect::MOUNT_ORIENTATION_DATA::ID,
        dialect::LOGGING_DATA_DATA::ID,
        dialect::LOGGING_DATA_ACKED_DATA::ID,
        dialect::LOGGING_ACK_DATA::ID,
        dialect::VIDEO_STREAM_INFORMATION_DATA::ID,
        dialect::GIMBAL_DEVICE_ATTITUDE_STATUS_DATA::ID,
    ]);
    /// Only the heartbeat is read decoded; the rest from their payloads.
    const DECODES: Ids = Ids::Only(&[dialect::HEARTBEAT_DATA::ID]);

    /// Any component of the system (ArduPilot answers for its camera itself).
    fn on_message(&mut self, m: &Incoming, out: &mut Vec<Out>) {
        let hb_type = m.heartbeat().map(|hb| hb.mavtype as u8);
        let notes = CameraSet::on_message(self, m.now, m.from.1, m.id, hb_type, m.payload);
        notes_out(notes, out);
    }

    fn poll(&mut self, now: Micros, _: &mut Vec<Out>) {
        self.offer = None;
        CameraSet::poll(self, now);
    }

    fn next_deadline(&self) -> Option<Micros> {
        CameraSet::next_deadline(self)
            .into_iter()
            .chain(self.offer)
            .min()
    }
}

impl Requests for CameraSet {
    fn requests(&self) -> Vec<Request> {
        self.heads()
    }

    fn taken(&mut self, r: &Request) {
        self.sent(r.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn info_payload(flags: u32) -> Vec<u8> {
        let mut p = vec![0u8; 237];
        p[20..24].copy_from_slice(&flags.to_le_bytes());
        p[24..26].copy_from_slice(&4000u16.to_le_bytes());
        p[30..34].copy_from_slice(b"Acme");
        p[62..65].copy_from_slice(b"X10");
        p
    }

    fn image(index: i32) -> Vec<u8> {
        let mut p = vec![0u8; 255];
        p[44..48].copy_from_slice(&index.to_le_bytes());
        p[49] = 1;
        p
    }

    #[test]
    fn discovery_falls_back_to_521_and_holes_are_asked_for() {
        let mut s = CameraSet::default();
        s.on_message(0, 100, 0, Some(MAV_TYPE_CAMERA), &[]);
        assert_eq!(
            s.heads(),
            vec![(100, 512, [259.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])]
        );
        s.sent(100);
        s.on_finished(
            SECOND,
            100,
            512,
            &[259.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            false,
        );
        s.poll(SECOND + FALLBACK_WAIT);
        assert_eq!(
            s.heads(),
            vec![(100, 521, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])]
        );
        s.sent(100);
        // New flag bits beyond the dialect are kept.
        s.on_message(3 * SECOND, 100, 259, None, &info_payload(2 | 4 | (1 << 20)));
        let c = &s.cameras[&100];
        assert_eq!(c.info.as_ref().unwrap().vendor, "Acme");
        assert_eq!(
            flag_names(c.info.as_ref().unwrap().flags),
            ["CAPTURE_IMAGE", "HAS_MODES", "BIT20"]
        );
        for _ in 0..3 {
            s.sent(100); // settings, storage, status
        }
        s.on_message(4 * SECOND, 100, 263, None, &image(0));
        s.on_message(4 * SECOND, 100, 263, None, &image(2));
        // A new image asks for the capture status (count, free space), then the hole.
        assert_eq!(
            s.heads(),
            vec![(100, 512, [262.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])]
        );
        s.sent(100);
        assert_eq!(
            s.heads(),
            vec![(100, 512, [263.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0])]
        );
        s.sent(100);
        // Not asked again while the answer may still come; asked again after HOLE_RETRY.
        s.poll(4 * SECOND + 1);
        assert!(s.heads().is_empty());
        s.poll(4 * SECOND + HOLE_RETRY);
        assert_eq!(
            s.heads(),
            vec![(100, 512, [263.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0])]
        );
        s.sent(100);
        s.on_message(5 * SECOND, 100, 263, None, &image(1));
        assert!(s.cameras[&100].missing().is_empty());
        assert_eq!(s.cameras[&100].last_image, Some(2));
    }

    #[test]
    fn a_capture_in_the_wrong_mode_is_not_sent() {
        let mut s = CameraSet::default();
        s.on_message(0, 100, 259, None, &info_payload(1 | 2 | 4));
        let e = s
            .action(
                100,
                &CameraAction::Shoot {
                    count: 1,
                    interval: 0.0,
                },
            )
            .unwrap_err();
        assert!(e.contains("mode unknown"), "{e}");
        let mut settings = vec![0u8; 14];
        settings[4] = 1; // video
        s.on_message(0, 100, 260, None, &settings);
        let e = s
            .action(
                100,
                &CameraAction::Shoot {
                    count: 1,
                    interval: 0.0,
                },
            )
            .unwrap_err();
        assert!(e.contains("video mode"), "{e}");
        assert!(s.action(100, &CameraAction::VideoStart).is_ok());
        let e = s.action(100, &CameraAction::Zoom(50.0)).unwrap_err();
        assert!(e.contains("HAS_BASIC_ZOOM"), "{e}");
    }

    #[test]
    fn video_streams_are_asked_again_when_none_came() {
        let mut s = CameraSet::default();
        s.on_message(0, 100, 259, None, &info_payload(CAP_VIDEO_STREAM));
        let ask = [269.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        for _ in 0..3 {
            s.sent(100); // settings, storage, status
        }
        assert_eq!(s.heads(), vec![(100, 512, ask)], "all streams: param2 = 0");
        let mut t = SECOND;
        for n in 1..=STREAM_TRIES {
            s.sent(100);
            s.on_finished(t, 100, 512, &ask, true);
            if n == STREAM_TRIES {
                break;
            }
            s.poll(t + STREAM_RETRY - 1);
            assert!(s.heads().is_empty());
            t += STREAM_RETRY;
            s.poll(t);
            assert_eq!(s.heads(), vec![(100, 512, ask)], "ask {}", n + 1);
        }
        assert_eq!(s.next_deadline(), None, "bounded");
        s.poll(t + 60 * SECOND);
        assert!(s.heads().is_empty());
    }
}
