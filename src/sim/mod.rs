//! The simulated vehicle(s) behind `sim://`: a pure, deterministic state machine.
//!
//! Bytes from the GCS go in with [`Sim::receive`]; [`Sim::poll`] advances simulated time and
//! returns what the vehicles emit after the link impairments. Time is always handed in, so the
//! same config, seed and inputs at the same times give byte-identical output; a virtual clock
//! can jump straight to [`Sim::next_deadline`]. `server` puts the same machine on a real socket.
//!
//! Modules: `config` (query string), `rng` (seeded PRNG), `vehicle` (state and flight model),
//! `handlers` (GCS messages and commands), `telemetry` (messages out), `streams` (rates),
//! `params` + `param_pck` (parameter table, packed file), `param_send` (PARAM_VALUE pacing),
//! `mavftp` (FTP server), `impair` (link), `mission` (mission, fence and rally stores and their
//! protocol), `auto` (AUTO flying the mission), `guided` (SET_POSITION_TARGET_* in GUIDED).

/// The ArduCopter version the sim's parameter set (`assets/sim/copter-params.parm`) and its
/// behaviour come from: the real captures in tests/data were made with ArduCopter V4.7.0-dev
/// (its parameters say `MAV_SYSID`, the name that replaced `SYSID_THISMAV`). One place for it:
/// the boot banner STATUSTEXT, AUTOPILOT_VERSION and `mavterm sim`'s first line use it.
macro_rules! arducopter_version {
    () => {
        "4.7.0-dev"
    };
}

/// [`arducopter_version!`] as a constant: "4.7.0-dev".
pub const ARDUCOPTER_VERSION: &str = arducopter_version!();

pub mod adsb;
pub mod auto;
pub mod calibration;
pub mod camera;
pub mod config;
pub mod gimbal;
pub mod guided;
pub mod handlers;
pub mod impair;
pub mod logs;
pub mod mavftp;
pub mod mission;
pub mod param_send;
pub mod params;
pub mod rng;
pub mod server;
pub mod streams;
pub mod telemetry;
pub mod vehicle;

pub use config::{SimConfig, SimError};
pub use impair::{LinkTruth, SimTruth};
pub use server::serve;
pub use vehicle::SimVehicle;

use crate::clock::Micros;
use crate::dialect::{MavResult, COMMAND_ACK_DATA, COMMAND_INT_DATA, COMMAND_LONG_DATA};
use crate::wire::frame::{crc_extra, encode, frame_crc, Header, Version, MAGIC_V2};
use crate::wire::parser::FrameParser;
use impair::{ImpairConfig, Impairer};
use mavlink::MessageData;
use params::ParamTable;
use rng::Rng;
use std::path::PathBuf;
use vehicle::{Out, TICK};

/// Message id of COMMAND_LONG and COMMAND_ACK.
const COMMAND_LONG_ID: u32 = COMMAND_LONG_DATA::ID;
const COMMAND_INT_ID: u32 = COMMAND_INT_DATA::ID;
const COMMAND_ACK_ID: u32 = COMMAND_ACK_DATA::ID;

/// One or more simulated vehicles on one simulated link.
#[derive(Debug)]
pub struct Sim {
    cfg: SimConfig,
    vehicles: Vec<SimVehicle>,
    seqs: Vec<u8>,
    /// The camera of each vehicle (`camera=1`), and its sequence numbers.
    cameras: Vec<(camera::SimCamera, u8)>,
    /// ADS-B traffic (`adsb=N`), forwarded by the first vehicle.
    adsb: Option<adsb::SimAdsb>,
    parser: FrameParser,
    impair: Impairer,
    in_rng: Rng,
    /// The next tick to run; every tick before it has run.
    next_tick: Micros,
    /// Latest time seen (poll or receive): time never goes back.
    clock: Micros,
}

/// The state file of vehicle `index`: the configured path for the first, `PATH.<sysid>` for
/// the others, so each vehicle keeps its own parameters.
fn state_path(base: &Option<PathBuf>, index: usize, sysid: u8) -> Option<PathBuf> {
    let base = base.as_ref()?;
    if index == 0 {
        return Some(base.clone());
    }
    let mut s = base.as_os_str().to_owned();
    s.push(format!(".{sysid}"));
    Some(PathBuf::from(s))
}

/// The simulator with its parameter state read from its state files (`state=FILE`): the edge
/// that reads; [`Sim::new_with_state`] itself touches no file.
pub fn open(cfg: SimConfig) -> Sim {
    Sim::new_with_state(cfg, |p| {
        match crate::fsio::read_text(p, crate::fsio::MAX_READ) {
            Ok(text) => Some(text),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(e) => {
                tracing::warn!("sim: cannot read parameter state {}: {e}", p.display());
                None
            }
        }
    })
}

/// Write the state files the simulator has waiting, atomically ([`crate::fsio::write_atomic`]:
/// a temporary of a unique name, fsync, rename; a special file is refused).
pub fn save_pending(sim: &mut Sim) {
    for (path, contents) in sim.take_writes() {
        if let Err(e) = crate::fsio::write_atomic(&path, &contents) {
            tracing::warn!("sim: cannot save parameters to {}: {e}", path.display());
        }
    }
}

impl Sim {
    /// A simulator with default parameters (no state file is read).
    pub fn new(cfg: SimConfig) -> Sim {
        Sim::new_with_state(cfg, |_| None)
    }

    /// A simulator whose vehicles start from the parameter text `state` gives for their state
    /// file path (`None`: defaults).
    pub fn new_with_state(
        cfg: SimConfig,
        state: impl Fn(&std::path::Path) -> Option<String>,
    ) -> Sim {
        let table = ParamTable::copter(cfg.params);
        let mut vehicles = Vec::with_capacity(cfg.vehicles as usize);
        for i in 0..cfg.vehicles.max(1) as usize {
            let sysid = cfg.sysid.saturating_add(i as u8).min(254);
            let path = state_path(&cfg.state, i, sysid);
            let mut params = table.clone();
            if let Some(text) = path.as_deref().and_then(&state) {
                params.load_parm_text(&text);
            }
            let mut v = SimVehicle::new(sysid, i, cfg.seed, params, path);
            v.drop_left = cfg.drop_cmd.clone();
            v.drop_acks = cfg.drop_ack.clone();
            v.set_link(cfg.baud, cfg.ftp);
            v.logs = logs::SimLogs::new(cfg.logs, cfg.log_size);
            v.mission.ready_at = cfg.mission_boot_ms.saturating_mul(1000);
            if cfg.gimbal.unwrap_or(cfg.camera) {
                v.mount = Some(gimbal::SimMount::default());
            }
            if cfg.uncal {
                v.cal = calibration::SimCal::uncalibrated();
            }
            if cfg.sr > 0 {
                v.streams.request_stream(0, 0, cfg.sr, true);
            }
            vehicles.push(v);
        }
        let impair = Impairer::new(
            ImpairConfig {
                loss: cfg.loss,
                dup: cfg.dup,
                reorder: cfg.reorder,
                corrupt: cfg.corrupt,
                latency: cfg.latency_ms.saturating_mul(1000),
                baud: cfg.baud,
            },
            Rng::derive(cfg.seed, 0x11A7),
        );
        let cameras = if cfg.camera {
            vehicles
                .iter()
                .map(|v| (camera::SimCamera::new(v.sysid, cfg.camera_drop), 0u8))
                .collect()
        } else {
            Vec::new()
        };
        let adsb = (cfg.adsb > 0)
            .then(|| adsb::SimAdsb::new(cfg.adsb, cfg.adsb_radius, cfg.adsb_alt, cfg.seed));
        Sim {
            seqs: vec![0; vehicles.len()],
            cameras,
            adsb,
            vehicles,
            parser: FrameParser::new(),
            impair,
            in_rng: Rng::derive(cfg.seed, 0x1A),
            next_tick: 0,
            clock: 0,
            cfg,
        }
    }

    pub fn config(&self) -> &SimConfig {
        &self.cfg
    }

    /// State files waiting to be written (path, contents): the edge writes them.
    pub fn take_writes(&mut self) -> Vec<(PathBuf, Vec<u8>)> {
        self.vehicles
            .iter_mut()
            .filter_map(|v| v.pending_write.take())
            .collect()
    }

    /// Bytes from the GCS (any chunking). Messages addressed to a vehicle's sysid (or 0 =
    /// broadcast) are handled at `now`, after the simulation has advanced to `now`.
    pub fn receive(&mut self, now: Micros, bytes: &[u8]) {
        let now = self.advance(now);
        let mut frames = Vec::new();
        self.parser.push(bytes, |f| frames.push(f));
        for f in frames {
            // Our own vehicles' frames echoed back (a UDP broadcast loop) are not commands.
            if self.vehicles.iter().any(|v| v.sysid == f.sysid) {
                continue;
            }
            if self.cfg.impair_in
                && (self.in_rng.chance(self.cfg.loss) || self.in_rng.chance(self.cfg.corrupt))
            {
                for v in &self.vehicles {
                    self.impair
                        .truth_mut()
                        .per_sysid
                        .entry(v.sysid)
                        .or_default()
                        .inbound_dropped += 1;
                }
                continue;
            }
            let from = (f.sysid, f.compid);
            if mission::is_protocol_message(f.msgid) {
                // Read from the payload, so ids the dialect lacks still get an answer.
                for i in 0..self.vehicles.len() {
                    self.vehicles[i].handle_raw(now, from, f.msgid, f.payload());
                    self.flush(i, now);
                }
                continue;
            }
            match &f.message {
                Some(msg) => {
                    for i in 0..self.vehicles.len() {
                        self.vehicles[i].handle(now, from, msg);
                        self.flush(i, now);
                    }
                    for i in 0..self.cameras.len() {
                        self.cameras[i].0.handle(now, from, msg);
                        self.flush_camera(i, now);
                    }
                }
                None if f.msgid == COMMAND_LONG_ID || f.msgid == COMMAND_INT_ID => {
                    self.unknown_command(now, from, f.payload())
                }
                None => {}
            }
        }
    }

    /// A COMMAND_LONG or COMMAND_INT whose command id the dialect does not know did not decode;
    /// ArduPilot answers such commands with MAV_RESULT_UNSUPPORTED, so build that ACK by hand.
    fn unknown_command(&mut self, now: Micros, from: (u8, u8), payload: &[u8]) {
        // Wire layout, the same in both: 28 bytes of params (COMMAND_INT: 4 floats, x, y, z),
        // command u16, target_system u8, target_component u8.
        let p = crate::wire::payload::Payload(payload);
        let command = p.u16(28);
        for i in 0..self.vehicles.len() {
            if !self.vehicles[i].for_me(p.u8(30), p.u8(31)) || self.vehicles[i].take_drop(command) {
                continue;
            }
            // COMMAND_ACK: command u16, result u8, progress u8, result_param2 i32,
            // target_system u8, target_component u8.
            let mut ack = Vec::with_capacity(10);
            ack.extend_from_slice(&command.to_le_bytes());
            ack.push(MavResult::MAV_RESULT_UNSUPPORTED as u8);
            ack.extend_from_slice(&[0, 0, 0, 0, 0, from.0, from.1]);
            let sysid = self.vehicles[i].sysid;
            let compid = self.vehicles[i].compid;
            let seq = self.next_seq(i);
            let frame = encode_raw(Header { sysid, compid, seq }, COMMAND_ACK_ID, &ack);
            self.impair.push(now, sysid, frame);
        }
    }

    /// Advance the simulation to `now` and return the bytes due by `now` (after impairments and
    /// the byte-rate queue).
    pub fn poll(&mut self, now: Micros) -> Vec<u8> {
        let now = self.advance(now);
        self.impair.take_due(now)
    }

    /// The earliest time something will next be emitted or change; never before the latest time
    /// the sim has seen.
    pub fn next_deadline(&self) -> Micros {
        let mut t = self
            .vehicles
            .iter()
            .map(|v| v.next_event(self.next_tick))
            .min()
            .unwrap_or(self.next_tick);
        for (c, _) in &self.cameras {
            t = t.min(c.next_event().max(self.next_tick));
        }
        if let Some(a) = &self.adsb {
            t = t.min(a.next_event().max(self.next_tick));
        }
        if let Some(d) = self.impair.next_due() {
            t = t.min(d);
        }
        t.max(self.clock)
    }

    /// Ground truth of the impairments, per vehicle sysid.
    pub fn truth(&self) -> SimTruth {
        self.impair.truth().clone()
    }

    pub fn vehicle(&self, sysid: u8) -> Option<&SimVehicle> {
        self.vehicles.iter().find(|v| v.sysid == sysid)
    }

    pub fn vehicles(&self) -> &[SimVehicle] {
        &self.vehicles
    }

    /// Run every tick up to `now`; returns the effective time (never earlier than before).
    fn advance(&mut self, now: Micros) -> Micros {
        let now = now.max(self.clock);
        self.clock = now;
        while self.next_tick <= now {
            let t = self.next_tick;
            for i in 0..self.vehicles.len() {
                // The UART's room: its buffer less what the radio still has to send.
                self.vehicles[i].txspace = match self.cfg.baud {
                    Some(b) => {
                        let backlog = self.impair.busy_until().saturating_sub(t);
                        let bytes = backlog * (b as u64 / 10) / 1_000_000;
                        logs::UART_TXBUF.saturating_sub(bytes)
                    }
                    None => param_send::TXSPACE_CAP,
                };
                self.vehicles[i].tick(t);
                self.flush(i, t);
            }
            for i in 0..self.cameras.len() {
                let v = &self.vehicles[i];
                let (lat, lon) = v.lat_lon();
                let rel = v.relative_alt_m();
                self.cameras[i].0.position = (
                    (lat * 1e7) as i32,
                    (lon * 1e7) as i32,
                    ((vehicle::HOME_ALT_M + rel) * 1000.0) as i32,
                    (rel * 1000.0) as i32,
                );
                self.cameras[i].0.tick(t);
                self.flush_camera(i, t);
            }
            self.flush_adsb(t);
            self.next_tick += TICK;
        }
        now
    }

    /// The camera of vehicle `sysid` (`camera=1`).
    pub fn camera(&self, sysid: u8) -> Option<&camera::SimCamera> {
        self.cameras
            .iter()
            .map(|(c, _)| c)
            .find(|c| c.sysid == sysid)
    }

    fn flush_camera(&mut self, i: usize, t: Micros) {
        let (cam, seq) = &mut self.cameras[i];
        let msgs = cam.drain();
        let (sysid, compid) = (cam.sysid, cam.compid);
        for m in msgs {
            let h = Header {
                sysid,
                compid,
                seq: *seq,
            };
            *seq = seq.wrapping_add(1);
            let frame = match m {
                Out::Msg(m) => encode(Version::V2, h, &m),
                Out::Raw { msgid, payload } => encode_raw(h, msgid, &payload),
            };
            self.impair.push(t, sysid, frame);
        }
    }

    /// The simulated traffic, if any.
    pub fn adsb(&self) -> Option<&adsb::SimAdsb> {
        self.adsb.as_ref()
    }

    /// The traffic moved on to `t`, and its reports due, from the first vehicle's autopilot.
    fn flush_adsb(&mut self, t: Micros) {
        let Some(a) = self.adsb.as_mut() else {
            return;
        };
        a.tick(t);
        let msgs = a.due(t);
        let (sysid, compid) = (self.vehicles[0].sysid, self.vehicles[0].compid);
        for m in msgs {
            let seq = self.next_seq(0);
            let frame = encode(Version::V2, Header { sysid, compid, seq }, &m);
            self.impair.push(t, sysid, frame);
        }
    }

    fn next_seq(&mut self, i: usize) -> u8 {
        let s = self.seqs[i];
        self.seqs[i] = s.wrapping_add(1);
        s
    }

    /// Encode vehicle `i`'s pending messages (own sequence counter) into the link.
    fn flush(&mut self, i: usize, t: Micros) {
        let msgs: Vec<Out> = self.vehicles[i].drain();
        let sysid = self.vehicles[i].sysid;
        let compid = self.vehicles[i].compid;
        for m in msgs {
            let seq = self.next_seq(i);
            let h = Header { sysid, compid, seq };
            let frame = match m {
                Out::Msg(m) => encode(Version::V2, h, &m),
                Out::Raw { msgid, payload } => encode_raw(h, msgid, &payload),
            };
            self.impair.push(t, sysid, frame);
        }
    }
}

/// Frame a raw payload as MAVLink 2 (trailing zeros trimmed), for messages the dialect types
/// cannot express.
fn encode_raw(h: Header, msgid: u32, payload: &[u8]) -> Vec<u8> {
    let mut len = payload.len();
    while len > 1 && payload[len - 1] == 0 {
        len -= 1;
    }
    let id = msgid.to_le_bytes();
    let mut out = vec![
        MAGIC_V2, len as u8, 0, 0, h.seq, h.sysid, h.compid, id[0], id[1], id[2],
    ];
    out.extend_from_slice(&payload[..len]);
    let crc = frame_crc(&out[1..], crc_extra(msgid).unwrap_or(0));
    out.extend_from_slice(&crc.to_le_bytes());
    out
}

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_mission;
