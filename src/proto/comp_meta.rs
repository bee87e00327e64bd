//! Parameter metadata from the vehicle itself, by the component metadata protocol
//! (<https://mavlink.io/en/services/component_metadata.html>), as PX4 serves it and
//! QGroundControl reads it (`RequestMetaDataTypeStateMachine`, `CompInfoGeneral`,
//! `CompInfoParam`):
//!
//! 1. **Ask**: MAV_CMD_REQUEST_MESSAGE(COMPONENT_METADATA, 397) to the autopilot, through the
//!    command queue. PX4 answers with the message and an ACK (`streams/COMPONENT_METADATA.hpp`:
//!    `uri` = `mftp://etc/extras/component_general.json.xz`, `file_crc` from the build). A
//!    refusal (an ACK other than ACCEPTED), or an accepted request whose message never comes, is
//!    asked once more as the deprecated COMPONENT_INFORMATION (395), which PX4 answered before
//!    COMPONENT_METADATA existed (QGroundControl's fallback too). No ACK at all, or no answer to
//!    either: the vehicle does not serve it, said once ([`CompMetaEvent::Failed`]); nothing is
//!    retried on its own.
//! 2. **Announced**: the general file's URI and CRC go up ([`CompMetaEvent::Announced`]): the
//!    CRC keys the cache, and the core either has the metadata already (nothing more is sent:
//!    [`CompMeta::finish`]) or asks for the download ([`CompMeta::download`]).
//! 3. **General file** over MAVLink FTP ([`crate::proto::ftp_file`]; `mftp://[;comp=N]path`, the
//!    component the autopilot unless named), xz-inflated when it is xz, and read for its
//!    `metadataTypes` entry of type 1 (COMP_METADATA_TYPE_PARAMETER): `uri`, `uriFallback`.
//! 4. **Parameter file**: an `mftp://` URI is read over FTP and handed up as it came
//!    ([`CompMetaEvent::ParamFile`]); an `https://` one (PX4 boards whose flash holds no
//!    `parameters.json.xz`) is handed up to be downloaded ([`CompMetaEvent::Fetch`]), and so is
//!    the fallback when the FTP read fails.
//!
//! Automatic at connect for the autopilots whose profile says so (PX4, as QGroundControl does
//! it), a second after the vehicle is first heard, once a session and never on a high-latency
//! link; `param meta fetch` starts it again at any time.

use crate::clock::{Micros, SECOND};
use crate::dialect::{self, MavCmd, MavMessage};
use crate::proto::commands::State;
use crate::proto::ftp_file::{FileOut, FileRead};
use crate::proto::machine::{Ids, Incoming, Machine, MachineEvent, Out, Request, Requests, Route};
use crate::proto::vehicles::VehicleKey;
use crate::wire::mavftp::{FtpPacket, PAYLOAD_LEN};
use crate::wire::payload::Payload;
use mavlink::MessageData;

/// COMPONENT_METADATA, and the deprecated COMPONENT_INFORMATION.
pub const COMPONENT_METADATA: u32 = 397;
pub const COMPONENT_INFORMATION: u32 = 395;
/// COMP_METADATA_TYPE_PARAMETER.
pub const TYPE_PARAMETER: u64 = 1;
/// The automatic request waits this long after the vehicle is first heard.
pub const AUTO_DELAY: Micros = SECOND;
/// After an accepted request, the message is waited for this long.
pub const MESSAGE_WAIT: Micros = 3 * SECOND;
/// The general file is small (PX4's is ~300 bytes compressed).
pub const MAX_GENERAL: usize = 256 * 1024;
/// The parameter file as it comes (PX4's `parameters.json.xz` is ~100 kB).
pub const MAX_PARAM_FILE: usize = crate::params::meta::MAX_JSON;

/// What the machine has to tell, for the core (defined with the machine contract, which carries
/// it).
pub use crate::proto::machine::CompMetaEvent;

#[derive(Debug, Clone)]
enum Step {
    Idle,
    /// The automatic request, due then.
    Due(Micros),
    /// REQUEST_MESSAGE for `msg`: waiting for the queue to take it (`until` None), then for the
    /// message (until then, once the ACK came).
    Ask {
        msg: u32,
        taken: bool,
        until: Option<Micros>,
    },
    Announced {
        crc: u32,
        uri: String,
    },
    General {
        crc: u32,
        comp: u8,
        read: Box<FileRead>,
    },
    Param {
        crc: u32,
        comp: u8,
        uri: String,
        fallback: Vec<String>,
        read: Box<FileRead>,
    },
}

/// The component metadata machine of one vehicle.
#[derive(Debug, Clone)]
pub struct CompMeta {
    key: VehicleKey,
    step: Step,
    auto: bool,
    auto_done: bool,
    held: bool,
    /// The operator asked (`param meta fetch`): outcomes are told on the status bar, the
    /// traffic goes on the operator's route.
    operator: bool,
    /// The next MAVFTP sequence number: reads go on from the last one's.
    ftp_seq: u16,
}

/// Is this (command, params) the request this machine sends (its outcome stays quiet)?
pub fn is_request(command: u16, params: &[f64; 7]) -> bool {
    command == MavCmd::MAV_CMD_REQUEST_MESSAGE as u16
        && (params[0] == COMPONENT_METADATA as f64 || params[0] == COMPONENT_INFORMATION as f64)
}

/// An `mftp://[;comp=N]path` URI: (component, path). `None` for another scheme.
pub fn parse_mftp(uri: &str, default_comp: u8) -> Option<Result<(u8, String), String>> {
    let rest = uri
        .get(..7)
        .filter(|s| s.eq_ignore_ascii_case("mftp://"))
        .map(|_| &uri[7..])?;
    let (comp, path) = match rest.strip_prefix("[;comp=") {
        Some(r) => {
            let Some((n, path)) = r.split_once(']') else {
                return Some(Err(format!("{uri}: unterminated [;comp=")));
            };
            match n.trim().parse::<u8>() {
                Ok(c) => (c, path),
                Err(_) => return Some(Err(format!("{uri}: component {n:?} is not 0-255"))),
            }
        }
        None => (default_comp, rest),
    };
    if path.is_empty() || path.len() > crate::wire::mavftp::DATA_LEN || path.contains('\0') {
        return Some(Err(format!("{uri}: no usable path")));
    }
    Some(Ok((comp, path.to_string())))
}

/// Whether `uri` is for HTTP(S).
pub fn is_web(uri: &str) -> bool {
    let l = uri.to_ascii_lowercase();
    l.starts_with("https://") || l.starts_with("http://")
}

/// The general file's entry of type `kind`: its URI and fallback URI (empty ones dropped).
pub fn general_entry(json: &[u8], kind: u64) -> Result<Option<(String, Option<String>)>, String> {
    let doc: serde_json::Value =
        serde_json::from_slice(json).map_err(|e| format!("general metadata is not JSON: {e}"))?;
    let types = doc
        .get("metadataTypes")
        .and_then(|t| t.as_array())
        .ok_or("general metadata has no \"metadataTypes\" list")?;
    for t in types {
        if t.get("type").and_then(|v| v.as_u64()) != Some(kind) {
            continue;
        }
        let text = |k: &str| {
            t.get(k)
                .and_then(|v| v.as_str())
                .map(str::trim)
                .filter(|s| !s.is_empty())
                .map(str::to_string)
        };
        let Some(uri) = text("uri") else {
            continue;
        };
        return Ok(Some((uri, text("uriFallback"))));
    }
    Ok(None)
}

impl CompMeta {
    /// Whether the next message heard starts the automatic request (the session hands this
    /// machine other ids only while it waits).
    pub fn waits_to_start(&self) -> bool {
        self.auto && !self.auto_done && matches!(self.step, Step::Idle)
    }

    /// `auto`: ask on its own once the vehicle is heard (the profile's choice, and the core's
    /// automatic traffic allowed).
    pub fn new(key: VehicleKey, auto: bool) -> CompMeta {
        CompMeta {
            key,
            step: Step::Idle,
            auto,
            auto_done: false,
            held: false,
            operator: false,
            ftp_seq: 0,
        }
    }

    /// The vehicle rebooted (maybe into other firmware): it is asked again on its own, as at
    /// connect.
    pub fn on_reboot(&mut self) {
        if self.auto && !self.busy() {
            self.auto_done = false;
            self.step = Step::Idle;
        }
    }

    /// Nothing starts on its own while the system is heard on high-latency links only.
    pub fn hold_auto(&mut self, held: bool) {
        self.held = held;
    }

    /// True while a request or a transfer runs (or the core decides on an announcement).
    pub fn busy(&self) -> bool {
        !matches!(self.step, Step::Idle | Step::Due(_))
    }

    /// The transfer under way, for the operator: (what, bytes so far, size).
    pub fn progress(&self) -> Option<(&str, usize, Option<u32>)> {
        match &self.step {
            Step::General { read, .. } | Step::Param { read, .. } => {
                let (n, size) = read.progress();
                Some((read.path(), n, size))
            }
            _ => None,
        }
    }

    /// The operator asks (`param meta fetch`): the request goes out again.
    pub fn start(&mut self, operator: bool) -> Result<(), String> {
        if self.busy() {
            return Err("the vehicle's component metadata is being read already".into());
        }
        self.operator = operator;
        self.auto_done = true;
        self.step = Step::Ask {
            msg: COMPONENT_METADATA,
            taken: false,
            until: None,
        };
        Ok(())
    }

    /// The core has the announced metadata already: nothing more to read.
    pub fn finish(&mut self) {
        if matches!(self.step, Step::Announced { .. }) {
            self.step = Step::Idle;
        }
    }

    /// The core has no copy of the announced metadata: read the general file.
    pub fn download(&mut self, now: Micros, out: &mut Vec<Out>) {
        let Step::Announced { crc, uri } = std::mem::replace(&mut self.step, Step::Idle) else {
            return;
        };
        match parse_mftp(&uri, self.key.1) {
            Some(Ok((comp, path))) => {
                let (read, o) = FileRead::start(now, &path, MAX_GENERAL, self.ftp_seq);
                self.ftp_seq = read.seq();
                self.step = Step::General {
                    crc,
                    comp,
                    read: Box::new(read),
                };
                self.ftp_out(now, comp, o, out);
            }
            Some(Err(e)) => self.failed(format!("general metadata: {e}"), out),
            None => self.failed(
                format!("the general metadata URI is not MAVLink FTP ({uri})"),
                out,
            ),
        }
    }

    fn route(&self) -> Route {
        if self.operator {
            Route::Vehicle
        } else {
            Route::Auto
        }
    }

    fn failed(&mut self, why: String, out: &mut Vec<Out>) {
        self.step = Step::Idle;
        out.push(Out::Event(MachineEvent::CompMeta(CompMetaEvent::Failed {
            why,
            operator: self.operator,
        })));
    }

    fn event(&self, e: CompMetaEvent, out: &mut Vec<Out>) {
        out.push(Out::Event(MachineEvent::CompMeta(e)));
    }

    /// FTP output: packets to `comp`, and what a finished read means.
    fn ftp_out(&mut self, now: Micros, comp: u8, o: Vec<FileOut>, out: &mut Vec<Out>) {
        let route = self.route();
        for r in o {
            match r {
                FileOut::Send(p) => out.push(Out::send(
                    route,
                    MavMessage::FILE_TRANSFER_PROTOCOL(dialect::FILE_TRANSFER_PROTOCOL_DATA {
                        target_network: 0,
                        target_system: self.key.0,
                        target_component: comp,
                        payload: p.to_payload(),
                    }),
                )),
                FileOut::Done(bytes) => self.read_done(now, bytes, out),
                FileOut::Failed(why) => self.read_failed(why, out),
            }
        }
    }

    fn read_done(&mut self, now: Micros, bytes: Vec<u8>, out: &mut Vec<Out>) {
        match std::mem::replace(&mut self.step, Step::Idle) {
            Step::General { crc, read, .. } => {
                let json = match crate::params::meta::inflate(read.path(), &bytes, MAX_GENERAL * 16)
                {
                    Ok(j) => j,
                    Err(e) => return self.failed(format!("general metadata: {e}"), out),
                };
                let (uri, fallback) = match general_entry(&json, TYPE_PARAMETER) {
                    Ok(Some(e)) => e,
                    Ok(None) => {
                        return self.failed(
                            "the vehicle's general metadata lists no parameter metadata".into(),
                            out,
                        )
                    }
                    Err(e) => return self.failed(e, out),
                };
                let fallback: Vec<String> = fallback.into_iter().filter(|u| is_web(u)).collect();
                match parse_mftp(&uri, self.key.1) {
                    Some(Ok((comp, path))) => {
                        let (read, o) = FileRead::start(now, &path, MAX_PARAM_FILE, self.ftp_seq);
                        self.ftp_seq = read.seq();
                        self.step = Step::Param {
                            crc,
                            comp,
                            uri,
                            fallback,
                            read: Box::new(read),
                        };
                        self.ftp_out(now, comp, o, out);
                    }
                    Some(Err(e)) => self.fetch_or_fail(crc, fallback, e, out),
                    None if is_web(&uri) => {
                        let mut urls = vec![uri];
                        urls.extend(fallback);
                        self.event(CompMetaEvent::Fetch { crc, urls }, out);
                    }
                    None => self.fetch_or_fail(
                        crc,
                        fallback,
                        format!("parameter metadata at {uri}: not MAVLink FTP nor HTTP(S)"),
                        out,
                    ),
                }
            }
            Step::Param { crc, uri, .. } => self.event(
                CompMetaEvent::ParamFile {
                    crc,
                    source: uri,
                    bytes,
                },
                out,
            ),
            other => self.step = other,
        }
    }

    fn fetch_or_fail(&mut self, crc: u32, fallback: Vec<String>, why: String, out: &mut Vec<Out>) {
        if fallback.is_empty() {
            self.failed(why, out);
        } else {
            self.step = Step::Idle;
            self.event(
                CompMetaEvent::Fetch {
                    crc,
                    urls: fallback,
                },
                out,
            );
        }
    }

    fn read_failed(&mut self, why: String, out: &mut Vec<Out>) {
        match std::mem::replace(&mut self.step, Step::Idle) {
            Step::General { .. } => self.failed(format!("general metadata: {why}"), out),
            Step::Param { crc, fallback, .. } => {
                self.fetch_or_fail(crc, fallback, format!("parameter metadata: {why}"), out)
            }
            other => self.step = other,
        }
    }

    /// The queue finished a command of this system: ours decides the next step.
    pub fn on_finished(
        &mut self,
        now: Micros,
        target: (u8, u8),
        command: u16,
        params: &[f64; 7],
        state: State,
        out: &mut Vec<Out>,
    ) {
        if target != (self.key.0, self.key.1) || !is_request(command, params) {
            return;
        }
        let Step::Ask {
            msg, taken: true, ..
        } = self.step
        else {
            return;
        };
        if params[0] != msg as f64 {
            return;
        }
        match state {
            State::Done(0) => {
                // Accepted: the message follows (PX4 sends it before the ACK, so it may be here
                // already).
                self.step = Step::Ask {
                    msg,
                    taken: true,
                    until: Some(now + MESSAGE_WAIT),
                };
            }
            State::Done(_) if msg == COMPONENT_METADATA => self.ask(COMPONENT_INFORMATION),
            State::Done(r) => self.failed(
                format!(
                    "{} serves no component metadata (REQUEST_MESSAGE {})",
                    self.key,
                    crate::proto::ack::result_name(r)
                ),
                out,
            ),
            State::NoAck => self.failed(
                format!(
                    "{} did not answer REQUEST_MESSAGE(COMPONENT_METADATA)",
                    self.key
                ),
                out,
            ),
            _ => self.failed("the component metadata request was cancelled".into(), out),
        }
    }

    fn ask(&mut self, msg: u32) {
        self.step = Step::Ask {
            msg,
            taken: false,
            until: None,
        };
    }

    fn announced(&mut self, crc: u32, uri: String, out: &mut Vec<Out>) {
        if uri.is_empty() {
            return self.failed(
                format!("{} announces no component metadata (empty URI)", self.key),
                out,
            );
        }
        self.step = Step::Announced {
            crc,
            uri: uri.clone(),
        };
        self.event(CompMetaEvent::Announced { crc, uri }, out);
    }
}

impl Machine for CompMeta {
    const IDS: Ids = Ids::Only(&[
        COMPONENT_METADATA,
        COMPONENT_INFORMATION,
        dialect::FILE_TRANSFER_PROTOCOL_DATA::ID,
    ]);
    /// All read from their payloads.
    const DECODES: Ids = Ids::Only(&[]);

    fn on_message(&mut self, m: &Incoming, out: &mut Vec<Out>) {
        if self.waits_to_start() {
            self.auto_done = true;
            self.step = Step::Due(m.now + AUTO_DELAY);
        }
        let from = m.from.1;
        let p = Payload(m.payload);
        match (m.id, &mut self.step) {
            (COMPONENT_METADATA, Step::Ask { .. }) if from == self.key.1 => {
                self.announced(p.u32(4), p.text(8, 100), out)
            }
            (COMPONENT_INFORMATION, Step::Ask { .. }) if from == self.key.1 => {
                self.announced(p.u32(4), p.text(12, 100), out)
            }
            (id, Step::General { comp, read, .. } | Step::Param { comp, read, .. })
                if id == dialect::FILE_TRANSFER_PROTOCOL_DATA::ID
                    && from == *comp
                    && m.payload.len() > 3 =>
            {
                let comp = *comp;
                let mut buf = [0u8; PAYLOAD_LEN];
                let body = &m.payload[3..];
                let n = body.len().min(PAYLOAD_LEN);
                buf[..n].copy_from_slice(&body[..n]);
                let o = read.on_packet(m.now, &FtpPacket::parse(&buf));
                self.ftp_seq = read.seq();
                self.ftp_out(m.now, comp, o, out);
            }
            _ => {}
        }
    }

    fn poll(&mut self, now: Micros, out: &mut Vec<Out>) {
        match &mut self.step {
            Step::Due(at) if now >= *at && !self.held => {
                self.operator = false;
                self.ask(COMPONENT_METADATA);
            }
            Step::Ask {
                msg,
                until: Some(t),
                ..
            } if now >= *t => {
                if *msg == COMPONENT_METADATA {
                    self.ask(COMPONENT_INFORMATION);
                } else {
                    self.failed(
                        format!(
                            "{} accepted the request but sent no COMPONENT_METADATA",
                            self.key
                        ),
                        out,
                    );
                }
            }
            Step::General { comp, read, .. } | Step::Param { comp, read, .. } => {
                let comp = *comp;
                let o = read.poll(now);
                self.ftp_seq = read.seq();
                self.ftp_out(now, comp, o, out);
            }
            _ => {}
        }
    }

    fn next_deadline(&self) -> Option<Micros> {
        match &self.step {
            Step::Due(at) if !self.held => Some(*at),
            Step::Ask { until, .. } => *until,
            Step::General { read, .. } | Step::Param { read, .. } => read.next_deadline(),
            _ => None,
        }
    }
}

impl Requests for CompMeta {
    fn requests(&self) -> Vec<Request> {
        match self.step {
            Step::Ask {
                msg, taken: false, ..
            } => vec![(
                self.key.1,
                MavCmd::MAV_CMD_REQUEST_MESSAGE as u16,
                [msg as f64, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            )],
            _ => Vec::new(),
        }
    }

    fn taken(&mut self, r: &Request) {
        if let Step::Ask { msg, taken, .. } = &mut self.step {
            if r.2[0] == *msg as f64 {
                *taken = true;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proto::streams::LinkProfile;

    #[test]
    fn mftp_uris_as_the_mavlink_ftp_url_scheme_writes_them() {
        assert_eq!(
            parse_mftp("mftp://etc/extras/component_general.json.xz", 1),
            Some(Ok((1, "etc/extras/component_general.json.xz".into())))
        );
        assert_eq!(
            parse_mftp("MFTP://[;comp=100]/fs/x.json", 1),
            Some(Ok((100, "/fs/x.json".into())))
        );
        assert!(parse_mftp("mftp://[;comp=256]x", 1).unwrap().is_err());
        assert!(parse_mftp("mftp://[;comp=1x", 1).unwrap().is_err());
        assert!(parse_mftp("mftp://", 1).unwrap().is_err());
        assert_eq!(parse_mftp("https://px4.io/p.json.xz", 1), None);
        assert!(is_web("HTTPS://a") && is_web("http://a") && !is_web("mftp://a"));
    }

    #[test]
    fn the_general_file_gives_the_parameter_entry() {
        // As PX4's generate_component_general.py writes it.
        let g = br#"{"version": 1, "metadataTypes": [{"type": 1, "uri": "mftp://etc/extras/parameters.json.xz", "fileCrc": 1, "uriFallback": "https://px4-travis.s3.amazonaws.com/Firmware/v1.15.0/px4_fmu-v6x_default/parameters.json.xz"}, {"type": 4, "uri": "mftp://etc/extras/all_events.json.xz", "fileCrc": 2, "uriFallback": ""}]}"#;
        assert_eq!(
            general_entry(g, TYPE_PARAMETER).unwrap(),
            Some((
                "mftp://etc/extras/parameters.json.xz".into(),
                Some("https://px4-travis.s3.amazonaws.com/Firmware/v1.15.0/px4_fmu-v6x_default/parameters.json.xz".into())
            ))
        );
        assert_eq!(
            general_entry(g, 4).unwrap(),
            Some(("mftp://etc/extras/all_events.json.xz".into(), None))
        );
        assert_eq!(general_entry(g, 5).unwrap(), None);
        assert!(general_entry(b"{}", 1).is_err());
        assert!(general_entry(b"xz?", 1).is_err());
    }

    fn incoming(now: Micros, id: u32, payload: &[u8]) -> Incoming<'_> {
        Incoming {
            now,
            from: (1, 1),
            link: 0,
            profile: LinkProfile::default(),
            id,
            payload,
            msg: None,
            ack: None,
        }
    }

    fn request() -> [f64; 7] {
        [COMPONENT_METADATA as f64, 0., 0., 0., 0., 0., 0.]
    }

    #[test]
    fn asked_once_at_connect_then_the_deprecated_message_then_given_up() {
        let key = VehicleKey(1, 1);
        let mut m = CompMeta::new(key, true);
        let mut out = Vec::new();
        // Heard: due a second later, not before.
        m.on_message(&incoming(10, 0, &[]), &mut out);
        assert_eq!(m.next_deadline(), Some(10 + AUTO_DELAY));
        assert!(m.requests().is_empty());
        m.poll(10 + AUTO_DELAY, &mut out);
        let r = m.requests();
        assert_eq!(r, vec![(1, 512, request())]);
        m.taken(&r[0]);
        assert!(m.requests().is_empty(), "asked once");
        // UNSUPPORTED: COMPONENT_INFORMATION next.
        m.on_finished(
            2 * SECOND,
            (1, 1),
            512,
            &request(),
            State::Done(3),
            &mut out,
        );
        let r = m.requests();
        assert_eq!(r[0].2[0], COMPONENT_INFORMATION as f64);
        m.taken(&r[0]);
        let mut p = request();
        p[0] = COMPONENT_INFORMATION as f64;
        m.on_finished(3 * SECOND, (1, 1), 512, &p, State::Done(3), &mut out);
        assert_eq!(
            out,
            vec![Out::Event(MachineEvent::CompMeta(CompMetaEvent::Failed {
                why: "1:1 serves no component metadata (REQUEST_MESSAGE UNSUPPORTED)".into(),
                operator: false
            }))]
        );
        // Nothing more on its own, however long.
        m.on_message(&incoming(4 * SECOND, 0, &[]), &mut out);
        assert_eq!(m.next_deadline(), None);
        assert!(m.requests().is_empty());
        assert!(!m.busy());
    }

    #[test]
    fn the_announcement_and_the_general_file_lead_to_the_parameter_file() {
        let key = VehicleKey(1, 1);
        let mut m = CompMeta::new(key, false);
        let mut out = Vec::new();
        m.start(true).unwrap();
        assert!(m.start(true).is_err(), "one at a time");
        let r = m.requests();
        m.taken(&r[0]);
        // COMPONENT_METADATA as PX4 sends it, before its ACK.
        let mut p = vec![0u8; 108];
        p[4..8].copy_from_slice(&0xDEAD_BEEFu32.to_le_bytes());
        let uri = b"mftp://etc/extras/component_general.json.xz";
        p[8..8 + uri.len()].copy_from_slice(uri);
        m.on_message(&incoming(SECOND, COMPONENT_METADATA, &p), &mut out);
        assert_eq!(
            out.pop(),
            Some(Out::Event(MachineEvent::CompMeta(
                CompMetaEvent::Announced {
                    crc: 0xDEAD_BEEF,
                    uri: String::from_utf8(uri.to_vec()).unwrap()
                }
            )))
        );
        // The late ACK changes nothing.
        m.on_finished(SECOND, (1, 1), 512, &request(), State::Done(0), &mut out);
        assert!(out.is_empty());
        // The core has no copy: the general file is opened over MAVFTP, on the operator's route.
        m.download(SECOND, &mut out);
        let sent: Vec<FtpPacket> = out
            .drain(..)
            .map(|o| match o {
                Out::Send {
                    route: Route::Vehicle,
                    msg: MavMessage::FILE_TRANSFER_PROTOCOL(f),
                } => {
                    assert_eq!((f.target_system, f.target_component), (1, 1));
                    FtpPacket::parse(&f.payload)
                }
                o => panic!("{o:?}"),
            })
            .collect();
        assert_eq!(sent[1].opcode, crate::wire::mavftp::op::OPEN_FILE_RO);
        assert_eq!(sent[1].data, b"etc/extras/component_general.json.xz");
        assert!(m.busy());
    }
}
