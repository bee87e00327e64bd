//! One session per autopilot heard: its protocol machines and how to reach it.
//!
//! The session is where a protocol machine lives (streams, commands, parameters, missions; a
//! camera's later). It is handed the messages of its system that are for
//! us (or broadcast), the time, and the link each came on; it returns what to send and what to
//! tell the operator, and says when it next needs waking ([`Session::next_deadline`]).
//!
//! Adding a machine: give it `on_message(now, link, ...)`, `poll(now) -> Vec<Out>` and
//! `next_deadline() -> Option<Micros>`, hold it here, call it from the three methods below, and
//! map its output to [`SessionOut`].

use std::collections::BTreeMap;

use crate::clock::Micros;
use crate::dialect::{MavAutopilot, MavCmd, MavMessage};
use crate::link::LinkId;
use crate::proto::ack::CommandAck;
use crate::proto::camera::{CameraAction, CameraSet};
use crate::proto::commands::{CmdOut, CommandQueue, CommandSpec, State};
use crate::proto::gimbal::GimbalSet;
use crate::proto::mission::{MissionMachine, MissionMsg, MissionOut, Request as MissionRequest};
use crate::proto::params::{ParamMachine, ParamOut};
use crate::proto::rates::StreamRates;
use crate::proto::sequence::{SeqOut, Sequence};
use crate::proto::streams::{LinkProfile, StreamMachine, StreamOut};
use crate::proto::telemetry::FlightTelemetry;
use crate::proto::vehicles::VehicleKey;

/// What a session wants done.
#[derive(Debug, Clone, PartialEq)]
#[allow(clippy::large_enum_variant)] // short-lived; boxing every message buys nothing
pub enum SessionOut {
    /// Send to the vehicle on its route (the link it was heard on most recently, or the one the
    /// operator pinned).
    Send(MavMessage),
    /// Sent by mavterm on its own (a HOME_POSITION request, a parameter download it started):
    /// on the vehicle's route among the links that are not high-latency, or not at all
    /// ([`Session::route_auto`]).
    SendAuto(MavMessage),
    /// Send on this link (stream rates are per link).
    SendOn(LinkId, MavMessage),
    /// Tell the operator (severity, text).
    Notice(crate::wire::Severity, String),
}

/// The protocol machines for one autopilot.
#[derive(Debug, Clone)]
pub struct Session {
    pub key: VehicleKey,
    /// The link the operator chose for this vehicle (`link` at the prompt), if any.
    pub pinned: Option<LinkId>,
    /// When anything of this system was last heard on each link, and what the link is.
    heard: BTreeMap<LinkId, (Micros, LinkProfile)>,
    pub streams: StreamMachine,
    pub commands: CommandQueue,
    /// A mode change waiting for the heartbeat, or a take-off working through its steps.
    pub sequence: Option<Sequence>,
    /// What the autopilot tells of its flight (position, battery, GPS, home...).
    pub flight: FlightTelemetry,
    /// Parameters of the autopilot and the other components of its system.
    pub params: ParamMachine,
    /// Mission, fence and rally point transfers; the current item and items reached.
    pub mission: MissionMachine,
    /// The cameras of this system (camera components, or the autopilot answering for one).
    pub cameras: CameraSet,
    /// The gimbals of this system, by their managers (the autopilot, or a gimbal component).
    pub gimbals: GimbalSet,
    /// The custom mode of the autopilot's last heartbeat.
    mode_seen: Option<u32>,
    /// DO_SET_MODEs that may still be resent: (queue id, the mode the heartbeat showed when it
    /// was sent). The first heartbeat with another mode stops their resends: the vehicle
    /// changed mode (ours took, or the pilot, a failsafe or another GCS changed it).
    mode_asks: Vec<(u64, Option<u32>)>,
    /// Components of this system first heard during a heartbeat flood: no automatic camera
    /// discovery for them (at most 256).
    pub quiet: std::collections::BTreeSet<u8>,
    /// The autopilot family (its profile encodes DO_SET_MODE).
    autopilot: MavAutopilot,
}

impl Session {
    pub fn new(
        key: VehicleKey,
        autopilot: MavAutopilot,
        request_streams: bool,
        fetch_params: bool,
        rates: StreamRates,
    ) -> Self {
        let mut s = Self {
            key,
            pinned: None,
            heard: BTreeMap::new(),
            streams: StreamMachine::new(key.into(), autopilot, request_streams, rates),
            commands: CommandQueue::default(),
            sequence: None,
            flight: FlightTelemetry::new(key.into(), request_streams),
            params: ParamMachine::new(key, autopilot, fetch_params),
            mission: MissionMachine::new(key),
            cameras: CameraSet::default(),
            gimbals: GimbalSet::default(),
            mode_seen: None,
            mode_asks: Vec::new(),
            quiet: std::collections::BTreeSet::new(),
            autopilot,
        };
        let profile = crate::proto::profile::of(autopilot);
        s.mission.set_int_items(profile.mission_int());
        s.flight.set_vfr_hud_expected(profile.vfr_hud_motion());
        s
    }

    /// The link this system was heard on most recently among those `up_only` or not, and
    /// high-latency ones too when `hl`.
    fn newest(&self, is_up: &impl Fn(LinkId) -> bool, up_only: bool, hl: bool) -> Option<LinkId> {
        self.heard
            .iter()
            .filter(|(l, (_, p))| (!up_only || is_up(**l)) && (hl || !p.hl))
            .max_by_key(|(l, (t, _))| (*t, std::cmp::Reverse(**l)))
            .map(|(l, _)| *l)
    }

    /// Where to send: the pinned link if it is up, else the link this system was heard on most
    /// recently among those up (a link that is not high-latency first), else the most recent of
    /// any.
    pub fn route(&self, is_up: impl Fn(LinkId) -> bool) -> Option<LinkId> {
        if let Some(p) = self.pinned.filter(|&p| is_up(p)) {
            return Some(p);
        }
        self.newest(&is_up, true, false)
            .or_else(|| self.newest(&is_up, true, true))
            .or_else(|| self.newest(&is_up, false, false))
            .or_else(|| self.newest(&is_up, false, true))
    }

    /// Where what mavterm sends on its own goes: as [`Session::route`], among the links that are
    /// not high-latency only. `None` when the system is heard on high-latency links only.
    pub fn route_auto(&self, is_up: impl Fn(LinkId) -> bool) -> Option<LinkId> {
        if let Some(p) = self.pinned.filter(|&p| is_up(p) && !self.is_hl(p)) {
            return Some(p);
        }
        self.newest(&is_up, true, false)
            .or_else(|| self.newest(&is_up, false, false))
    }

    fn is_hl(&self, link: LinkId) -> bool {
        self.heard.get(&link).is_some_and(|(_, p)| p.hl)
    }

    /// Links this system has been heard on.
    pub fn links(&self) -> impl Iterator<Item = LinkId> + '_ {
        self.heard.keys().copied()
    }

    /// A frame of this system, for us or broadcast, heard on `link` (of kind `profile`): its
    /// source component, its message id, and the message when the dialect could read it (or
    /// read it by hand), and its payload as sent (for fields of messages the dialect could not
    /// read).
    #[allow(clippy::too_many_arguments)]
    pub fn on_message(
        &mut self,
        now: Micros,
        link: LinkId,
        profile: LinkProfile,
        (from, id): (u8, u32),
        msg: Option<&MavMessage>,
        ack: Option<&CommandAck>,
        payload: &[u8],
    ) -> Vec<SessionOut> {
        if self.heard.insert(link, (now, profile)).is_none() {
            // Nothing starts on its own while the system is heard on high-latency links only.
            let held = self.heard.values().all(|(_, p)| p.hl);
            self.params.hold_auto(held);
        }
        let mut out = Vec::new();
        // Parameters are kept per component of the system.
        match id {
            22 => out.extend(
                self.params
                    .on_param_value(now, from, payload)
                    .into_iter()
                    .map(|o| self.pmap(o)),
            ),
            // FILE_TRANSFER_PROTOCOL: target_network, target_system, target_component, then
            // the FTP payload.
            110 if payload.len() > 3 => out.extend(
                self.params
                    .on_ftp(now, from, &payload[3..])
                    .into_iter()
                    .map(|o| self.pmap(o)),
            ),
            // AUTOPILOT_VERSION: capabilities u64 first (MAVLink 2 may have cut its zeros).
            148 if from == self.key.1 => {
                let mut caps = [0u8; 8];
                let n = payload.len().min(8);
                caps[..n].copy_from_slice(&payload[..n]);
                let caps = u64::from_le_bytes(caps);
                self.mission.on_capabilities(caps);
                out.extend(
                    self.params
                        .on_autopilot_version(now, caps)
                        .into_iter()
                        .map(|o| self.pmap(o)),
                );
            }
            _ => {}
        }
        // The COMMAND_ACK of our AUTOPILOT_VERSION request: a first round trip.
        if let Some(a) = ack.filter(|a| {
            from == self.key.1
                && a.command == crate::dialect::MavCmd::MAV_CMD_REQUEST_MESSAGE as u16
        }) {
            let _ = a;
            self.params.on_version_answer(now);
        }
        // Cameras: any component of the system (ArduPilot answers for its camera itself).
        let hb_type = match msg {
            Some(MavMessage::HEARTBEAT(hb)) => Some(hb.mavtype as u8),
            _ => None,
        };
        if (hb_type.is_some() || (259..=269).contains(&id) || id == 285)
            && !self.quiet.contains(&from)
        {
            let notes = self.cameras.on_message(now, from, id, hb_type, payload);
            out.extend(notes.into_iter().map(|(s, t)| SessionOut::Notice(s, t)));
        }
        // Gimbals: the autopilot and any gimbal component may be a gimbal manager.
        if hb_type.is_some() || (280..=285).contains(&id) {
            let ap = self.key.1;
            let notes = self.gimbals.on_message(now, from, id, hb_type, ap, payload);
            self.gimbals.poll(now);
            out.extend(notes.into_iter().map(|(s, t)| SessionOut::Notice(s, t)));
        }
        if from != self.key.1 {
            // Another component of this system (a camera, a gimbal): the answers to commands
            // sent to it through this session's queue.
            if let Some(a) = ack {
                let done = self.commands.on_ack(now, (self.key.0, from), a);
                out.extend(self.drive(now, done));
            }
            out.extend(self.camera_requests(now));
            return out;
        }
        if let Some(m) = MissionMsg::read(id, payload) {
            let o = self.mission.on_message(now, &m);
            out.extend(self.mission_out(o));
        }
        let hb = match msg {
            Some(MavMessage::HEARTBEAT(hb)) => Some(hb),
            _ => None,
        };
        self.streams.on_message(now, link, profile, id, hb);
        self.flight.on_message(now, id, msg, payload);
        if let Some(a) = ack {
            // A SET_MESSAGE_INTERVAL's ACK is the stream machine's while one of its own waits
            // (it went before any of the operator's: the machine sends none while one of those
            // is open), else the command queue's.
            match self.streams.on_ack(now, a.command, a.result) {
                Some(o) => out.extend(o.into_iter().map(map)),
                None => {
                    let done = self.commands.on_ack(now, (self.key.0, from), a);
                    out.extend(self.drive(now, done));
                }
            }
        }
        if let Some(hb) = hb {
            out.extend(self.on_mode_seen(hb.custom_mode));
        }
        if let (Some(hb), Some(seq)) = (hb, self.sequence.as_mut()) {
            let armed = hb
                .base_mode
                .contains(crate::dialect::MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED);
            let r = seq.on_heartbeat(hb.custom_mode, armed);
            out.extend(self.seq_out(now, r));
        }
        out.extend(self.camera_requests(now));
        out
    }

    /// Operate camera `compid` of this system: the command goes through the queue, or the
    /// reason the camera cannot do it comes back.
    pub fn camera_action(
        &mut self,
        now: Micros,
        compid: u8,
        action: &CameraAction,
    ) -> Result<(u64, Vec<SessionOut>), String> {
        let (command, params) = self.cameras.action(compid, action)?;
        let spec = CommandSpec {
            target: (self.key.0, compid),
            command,
            params,
            form: crate::proto::commands::Form::Long,
        };
        let r = self.submit(now, spec)?;
        if matches!(action, CameraAction::Shoot { count: 1, .. }) {
            self.cameras.shot_sent(compid);
        }
        Ok(r)
    }

    /// Point gimbal `sel` (MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW to its manager's component):
    /// pitch and yaw in degrees, yaw relative to the vehicle; `us` is our (sysid, compid).
    /// Refused (nothing sent) with the reason when no manager is known, an angle is beyond its
    /// limits, or another controller holds it.
    pub fn gimbal_point(
        &mut self,
        now: Micros,
        sel: usize,
        pitch: f64,
        yaw: f64,
        us: (u8, u8),
    ) -> Result<(u64, Vec<SessionOut>), String> {
        let (compid, command, params) = match self.gimbals.point(sel, pitch, yaw, us) {
            Ok(c) => c,
            Err(why) if self.gimbals.usable().is_empty() => {
                // None known: ask the autopilot, the usual manager (not the pointing itself).
                self.gimbals.ask_autopilot(now, self.key.1);
                return Err(format!(
                    "{why}; asking the autopilot for GIMBAL_MANAGER_INFORMATION"
                ));
            }
            Err(why) => return Err(why),
        };
        let spec = CommandSpec {
            target: (self.key.0, compid),
            command,
            params,
            form: crate::proto::commands::Form::Long,
        };
        let r = self.submit(now, spec)?;
        self.gimbals.pointed(compid, params[6] as u8, pitch, yaw);
        Ok(r)
    }

    /// Take (`take`) or give up primary control of gimbal `sel`
    /// (MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE).
    pub fn gimbal_configure(
        &mut self,
        now: Micros,
        sel: usize,
        take: bool,
        us: (u8, u8),
    ) -> Result<(u64, Vec<SessionOut>), String> {
        let (compid, command, params) = self.gimbals.configure(sel, take, us)?;
        let spec = CommandSpec {
            target: (self.key.0, compid),
            command,
            params,
            form: crate::proto::commands::Form::Long,
        };
        self.submit(now, spec)
    }

    /// The cameras' and gimbals' waiting requests, each component's first, when the queue takes
    /// it (one command of a kind per target open at a time).
    fn camera_requests(&mut self, now: Micros) -> Vec<SessionOut> {
        let mut out = Vec::new();
        let heads: Vec<(bool, Request)> = self
            .cameras
            .heads()
            .into_iter()
            .map(|h| (true, h))
            .chain(self.gimbals.heads().into_iter().map(|h| (false, h)))
            .collect();
        for (camera, head) in heads {
            let (compid, command, params) = head;
            let target = (self.key.0, compid);
            if self.commands.is_open(target, command) {
                continue;
            }
            let spec = CommandSpec {
                target,
                command,
                params,
                form: crate::proto::commands::Form::Long,
            };
            match self.commands.submit(now, spec) {
                Ok((_, sends)) => {
                    if camera {
                        self.cameras.sent(compid);
                    } else {
                        self.gimbals.sent(&head);
                    }
                    // Asked on our own: not over a high-latency link.
                    out.extend(self.drive(now, sends).into_iter().map(|o| match o {
                        SessionOut::Send(m) => SessionOut::SendAuto(m),
                        o => o,
                    }));
                }
                Err(_) => continue,
            }
        }
        out
    }

    /// Home's altitude above mean sea level in metres, for PX4's take-off altitude: from
    /// HOME_POSITION, else from GLOBAL_POSITION_INT (alt minus relative_alt).
    pub fn home_amsl(&self) -> Option<f64> {
        if let Some(h) = &self.flight.home {
            return Some(h.value.alt_mm as f64 / 1000.0);
        }
        let p = &self.flight.position.as_ref()?.value;
        Some((p.alt_mm as f64 - p.relative_alt_mm as f64) / 1000.0)
    }

    /// A text the vehicle said (joined STATUSTEXT): it may explain a refusal.
    pub fn on_text(&mut self, now: Micros, text: &str) {
        self.commands.on_statustext(now, self.key.0, text);
        self.mission.on_text(now, text);
    }

    /// Start (or queue) a mission, fence or rally point transfer.
    pub fn mission_submit(
        &mut self,
        now: Micros,
        req: MissionRequest,
    ) -> Result<Vec<SessionOut>, String> {
        let out = self.mission.submit(now, req)?;
        Ok(self.mission_out(out))
    }

    /// Make `seq` the current mission item.
    pub fn mission_set_current(
        &mut self,
        now: Micros,
        seq: u16,
    ) -> Result<Vec<SessionOut>, String> {
        let out = self.mission.set_current(now, seq)?;
        Ok(self.mission_out(out))
    }

    /// Mission machine output: its messages go to the vehicle on its route (the operator asked
    /// for every transfer), its events worth telling become notices.
    fn mission_out(&self, outs: Vec<MissionOut>) -> Vec<SessionOut> {
        outs.into_iter()
            .filter_map(|o| match o {
                MissionOut::Send(m) => Some(SessionOut::Send(m)),
                MissionOut::Event(e) => e
                    .notice(self.key)
                    .map(|(sev, text)| SessionOut::Notice(sev, text)),
            })
            .collect()
    }

    /// Send a command through the queue.
    pub fn submit(
        &mut self,
        now: Micros,
        spec: CommandSpec,
    ) -> Result<(u64, Vec<SessionOut>), String> {
        let (id, out) = self.queue(now, spec)?;
        Ok((id, self.drive(now, out)))
    }

    /// The queue's submit; a mode change remembers the mode it leaves.
    fn queue(&mut self, now: Micros, spec: CommandSpec) -> Result<(u64, Vec<CmdOut>), String> {
        let mode =
            spec.command == MavCmd::MAV_CMD_DO_SET_MODE as u16 && spec.target == self.key.into();
        let (id, out) = self.commands.submit(now, spec)?;
        if mode {
            self.mode_asks.push((id, self.mode_seen));
        }
        Ok((id, out))
    }

    /// The heartbeat shows `mode`: a DO_SET_MODE sent from another mode is no longer resent.
    fn on_mode_seen(&mut self, mode: u32) -> Vec<SessionOut> {
        self.mode_seen = Some(mode);
        let mut out = Vec::new();
        let asks = std::mem::take(&mut self.mode_asks);
        for (id, left) in asks {
            let Some(e) = self.commands.get(id).filter(|e| e.open()) else {
                continue;
            };
            if left == Some(mode) {
                self.mode_asks.push((id, left));
                continue;
            }
            // Ours when the request carries the mode shown, as the profile encodes it (PX4:
            // main mode in param2, sub mode in param3).
            let want = crate::proto::profile::of(self.autopilot).set_mode_params(mode);
            let ours = e.spec.params[1..3] == want[1..3]
                || self
                    .sequence
                    .as_ref()
                    .and_then(|s| s.current())
                    .map(|s| s.until)
                    == Some(crate::proto::sequence::Until::Mode(mode));
            self.commands.hold_resends(id);
            if !ours {
                out.push(SessionOut::Notice(
                    crate::wire::Severity::WARNING,
                    format!(
                        "{} changed mode on its own meanwhile: our DO_SET_MODE is not resent",
                        self.key
                    ),
                ));
            }
        }
        out
    }

    /// A new mode request (a mode, LAND, RTL): the take-off or mode change still running is
    /// abandoned, and a DO_SET_MODE, NAV_LAND or NAV_RETURN_TO_LAUNCH still waiting is superseded
    /// (not waited for, never resent).
    pub fn supersede_mode(&mut self, now: Micros, by: &str) -> Vec<SessionOut> {
        let mut out = Vec::new();
        if let Some(seq) = self.sequence.take().filter(|s| !s.finished()) {
            out.push(SessionOut::Notice(
                crate::wire::Severity::WARNING,
                format!("{}: abandoned for {by}", seq.name),
            ));
        }
        // Every mode request still open (DO_SET_MODE, NAV_LAND, NAV_RETURN_TO_LAUNCH) to this
        // vehicle: a safe mode never waits behind one that got no answer.
        let mut done = Vec::new();
        for command in [
            MavCmd::MAV_CMD_DO_SET_MODE,
            MavCmd::MAV_CMD_NAV_LAND,
            MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH,
        ] {
            done.extend(
                self.commands
                    .supersede(now, self.key.into(), command as u16),
            );
        }
        self.mode_asks.clear();
        out.extend(self.drive(now, done));
        out
    }

    /// Abort command `id` in progress.
    pub fn cancel(&mut self, now: Micros, id: u64) -> Result<Vec<SessionOut>, String> {
        let out = self.commands.cancel(now, id)?;
        Ok(self.drive(now, out))
    }

    /// Start a sequence (one at a time).
    pub fn start_sequence(
        &mut self,
        now: Micros,
        seq: Sequence,
    ) -> Result<Vec<SessionOut>, String> {
        if let Some(s) = self.sequence.as_ref().filter(|s| !s.finished()) {
            return Err(format!("{} is still running", s.name));
        }
        self.sequence = Some(seq);
        Ok(self.seq_out(now, Vec::new()))
    }

    /// Queue output: sends and notices out; finished commands move a sequence on.
    fn drive(&mut self, now: Micros, outs: Vec<CmdOut>) -> Vec<SessionOut> {
        let mut out = Vec::new();
        let mut seq_events = Vec::new();
        // The gimbal discovery asks every autopilot (most have no mount): their outcomes stay on
        // the Commands screen instead of a notice each.
        let quiet: Vec<bool> = outs
            .iter()
            .enumerate()
            .map(|(i, o)| match (o, outs.get(i + 1)) {
                (CmdOut::Notice(..), Some(CmdOut::Finished(id))) => {
                    self.commands.get(*id).is_some_and(|e| {
                        crate::proto::gimbal::is_discovery(e.spec.command, &e.spec.params)
                    })
                }
                _ => false,
            })
            .collect();
        for (o, quiet) in outs.into_iter().zip(quiet) {
            match o {
                CmdOut::Send(m) => out.push(SessionOut::Send(m)),
                CmdOut::Notice(..) if quiet => {}
                CmdOut::Notice(s, t) => out.push(SessionOut::Notice(s, t)),
                CmdOut::Finished(id) => {
                    if let Some(e) = self.commands.get(id) {
                        if e.spec.target.0 == self.key.0 {
                            let (c, cmd, p) = (e.spec.target.1, e.spec.command, e.spec.params);
                            self.gimbals.on_finished(now, c, cmd, &p);
                        }
                    }
                    if let Some(e) = self.commands.get(id) {
                        if self.cameras.cameras.contains_key(&e.spec.target.1)
                            && e.spec.target.0 == self.key.0
                        {
                            let accepted = e.state == State::Done(0);
                            let (c, cmd, p) = (e.spec.target.1, e.spec.command, e.spec.params);
                            if accepted
                                && cmd == crate::proto::camera::CMD_STORAGE_FORMAT
                                && p[2] == 1.0
                            {
                                self.cameras.forget_images(c);
                            }
                            let mut notes = self.cameras.on_finished(now, c, cmd, &p, accepted);
                            if matches!(e.state, State::Done(r) if r != 0) {
                                notes.extend(self.cameras.on_refused(c, cmd, &p));
                            }
                            out.extend(notes.into_iter().map(|(s, t)| SessionOut::Notice(s, t)));
                        }
                    }
                    if let (Some(seq), Some(e)) = (self.sequence.as_mut(), self.commands.get(id)) {
                        let accepted = e.state == State::Done(0);
                        let outcome = match &e.reason {
                            Some(r) => format!("{} ({r})", e.outcome()),
                            None => e.outcome(),
                        };
                        seq_events.extend(seq.on_finished(now, id, accepted, &outcome));
                    }
                }
            }
        }
        out.extend(self.seq_out(now, seq_events));
        out
    }

    /// Sequence output, and its next command submitted when it is time.
    fn seq_out(&mut self, now: Micros, events: Vec<SeqOut>) -> Vec<SessionOut> {
        let mut out = Vec::new();
        for e in events {
            match e {
                SeqOut::Notice(s, t) => out.push(SessionOut::Notice(s, t)),
                SeqOut::Send(m) => out.push(SessionOut::Send(m)),
                SeqOut::Done => {}
            }
        }
        let next = self.sequence.as_ref().and_then(|s| s.next_command());
        if let Some(spec) = next {
            match self.queue(now, spec) {
                Ok((id, sends)) => {
                    if let Some(seq) = self.sequence.as_mut() {
                        seq.sent(id);
                    }
                    out.extend(self.drive(now, sends));
                }
                Err(why) => {
                    let r = self
                        .sequence
                        .as_mut()
                        .map(|s| s.refused(&why))
                        .unwrap_or_default();
                    out.extend(self.seq_out(now, r));
                }
            }
        }
        if self.sequence.as_ref().is_some_and(|s| s.finished()) {
            self.sequence = None;
        }
        out
    }

    /// The vehicle rebooted: every machine starts over where it must.
    /// True while work is in flight: a command waiting for its answer, a sequence, a parameter
    /// download or edit, a mission transfer. Such a vehicle is never evicted.
    pub fn busy(&self) -> bool {
        self.sequence.is_some()
            || self.params.busy()
            || self.mission.busy()
            || self.commands.entries().any(|e| e.open())
    }

    pub fn on_reboot(&mut self) {
        self.streams.on_reboot();
        self.mission.on_reboot();
    }

    /// `link` came back after being down.
    pub fn on_link_reconnected(&mut self, link: LinkId) {
        self.streams.on_link_reconnected(link);
    }

    /// Whatever is due at `now`.
    pub fn poll(&mut self, now: Micros) -> Vec<SessionOut> {
        let interval = MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL as u16;
        let operators = self.commands.is_open(self.key.into(), interval)
            || self.commands.is_open((self.key.0, 0), interval);
        self.streams.hold_intervals(operators);
        let mut out: Vec<SessionOut> = self.streams.poll(now).into_iter().map(map).collect();
        let done = self.commands.poll(now);
        out.extend(self.drive(now, done));
        let r = self
            .sequence
            .as_mut()
            .map(|s| s.poll(now))
            .unwrap_or_default();
        out.extend(self.seq_out(now, r));
        out.extend(self.flight.poll(now).into_iter().map(SessionOut::SendAuto));
        let p = self.params.poll(now);
        out.extend(p.into_iter().map(|o| self.pmap(o)));
        let m = self.mission.poll(now);
        out.extend(self.mission_out(m));
        self.cameras.poll(now);
        self.gimbals.poll(now);
        out.extend(self.camera_requests(now));
        out
    }

    /// Parameter machine output: what belongs to a download it started on its own is automatic
    /// traffic; an edit (PARAM_SET) is always the operator's.
    pub(crate) fn pmap(&self, o: ParamOut) -> SessionOut {
        match o {
            ParamOut::Send(m @ MavMessage::PARAM_SET(_)) => SessionOut::Send(m),
            ParamOut::Send(m) if self.params.auto_download() => SessionOut::SendAuto(m),
            ParamOut::Send(m) => SessionOut::Send(m),
            ParamOut::Notice(s, t) => SessionOut::Notice(s, t),
        }
    }

    /// True when a poll now would do something (a machine has work that is not on a timer).
    pub fn due(&self) -> bool {
        self.streams.due()
            || self.flight.due()
            || self.params.due()
            || self.mission.due()
            || self
                .cameras
                .heads()
                .iter()
                .chain(self.gimbals.heads().iter())
                .any(|(c, cmd, _)| !self.commands.is_open((self.key.0, *c), *cmd))
    }

    /// When the session next needs a poll.
    pub fn next_deadline(&self) -> Option<Micros> {
        [
            self.streams.next_deadline(),
            self.commands.next_deadline(),
            self.sequence.as_ref().and_then(|s| s.next_deadline()),
            self.flight.next_deadline(),
            self.params.next_deadline(),
            self.mission.next_deadline(),
            self.cameras.next_deadline(),
            self.gimbals.next_deadline(),
        ]
        .into_iter()
        .flatten()
        .min()
    }
}

/// A component's request waiting for the queue: (component, command, params).
type Request = (u8, u16, [f64; 7]);

fn map(o: StreamOut) -> SessionOut {
    match o {
        StreamOut::SendOn(l, m) => SessionOut::SendOn(l, m),
        StreamOut::Notice(s, t) => SessionOut::Notice(s, t),
    }
}
