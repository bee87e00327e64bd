//! One session per autopilot heard: its protocol machines and how to reach it.
//!
//! The session holds the protocol machines of one system (streams, telemetry, commands,
//! sequences, parameters, missions, cameras, gimbals). It is handed the messages of its system
//! that are for us (or broadcast) as one [`Incoming`], and the time; each machine it dispatches
//! to (by the table built from the machines' [`Machine::IDS`]) answers in [`Out`], and
//! [`Session::deliver`] turns those into [`SessionOut`] in one place, where the routing policy
//! lives (the operator's route, mavterm's own traffic spared on high-latency links, stream
//! requests per link) and where typed events go on to the machines that wait for them (a
//! finished command to the cameras, gimbals and the sequence). It says when it next needs
//! waking ([`Session::next_deadline`]).
//!
//! Adding a machine: its file under `src/proto` (named in `src/proto/mod.rs`) implements
//! [`Machine`] (its `IDS`, `on_message`, `poll`, `next_deadline`, answering in [`Out`]; and
//! `claims` when some message is its alone); here, a field of [`Session`] (built in
//! [`Session::new`]), a bit in [`Dispatch`] and a line in [`TABLE`], a call in
//! [`Session::on_message`] under its bit, one in [`Session::poll`], and its deadline in
//! [`Session::next_deadline`]. A machine whose commands go through the queue also implements
//! [`Requests`] and gets a line in `Session::offer_requests`. A new kind of event is a
//! [`MachineEvent`] variant, routed in [`Session::deliver`] (and, for the screens, a
//! [`SessionOut`] variant handled in `App::session_out`).

use std::collections::BTreeMap;

use crate::clock::Micros;
use crate::dialect::{MavAutopilot, MavCmd, MavMessage};
use crate::link::LinkId;
use crate::proto::calibration::Calibration;
use crate::proto::camera::{CameraAction, CameraSet};
use crate::proto::commands::{self, CmdOut, CommandQueue, CommandSpec, State};
use crate::proto::comp_meta::CompMeta;
use crate::proto::gimbal::GimbalSet;
use crate::proto::health::PrearmReasons;
use crate::proto::logs::LogMachine;
use crate::proto::machine::{Ids, Incoming, Machine, MachineEvent, Out, Requests, Route};
use crate::proto::mission::{MissionMachine, Request as MissionRequest};
use crate::proto::params::{ParamMachine, ParamOut};
use crate::proto::rates::StreamRates;
use crate::proto::sequence::{self, Sequence};
use crate::proto::streams::{LinkProfile, StreamMachine};
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
    /// The outcome of an edit of parameter `name` of component `comp`, and its notice.
    ParamSet {
        comp: u8,
        name: String,
        confirmed: bool,
        sev: crate::wire::Severity,
        text: String,
    },
    /// An operator's mission request ended (`done` or not), and its notice.
    MissionEnd {
        ask: crate::proto::mission::MissionAsk,
        done: bool,
        sev: crate::wire::Severity,
        text: String,
    },
    /// The running sequence ended (done, or stopped), and its notice.
    SequenceDone {
        sev: crate::wire::Severity,
        text: String,
    },
    /// The component metadata machine's news, for the core (`app::param_meta`).
    CompMeta(crate::proto::comp_meta::CompMetaEvent),
    /// Command `command` of the queue to `target` finished, and its notice.
    Command {
        id: u64,
        target: VehicleKey,
        command: u16,
        sev: crate::wire::Severity,
        text: String,
    },
}

/// The machines a message goes to: one bit each.
pub struct Dispatch;

impl Dispatch {
    pub const STREAMS: u16 = 1;
    pub const FLIGHT: u16 = 1 << 1;
    pub const PARAMS: u16 = 1 << 2;
    pub const MISSION: u16 = 1 << 3;
    pub const COMMANDS: u16 = 1 << 4;
    pub const SEQUENCE: u16 = 1 << 5;
    pub const CAMERAS: u16 = 1 << 6;
    pub const GIMBALS: u16 = 1 << 7;
    pub const COMP_META: u16 = 1 << 8;
    pub const LOGS: u16 = 1 << 9;
    pub const PREARM: u16 = 1 << 10;
    pub const CALIBRATION: u16 = 1 << 11;
}

/// Each machine's bit and the ids it reads.
pub const TABLE: &[(u16, Ids)] = &[
    (Dispatch::STREAMS, StreamMachine::IDS),
    (Dispatch::FLIGHT, FlightTelemetry::IDS),
    (Dispatch::PARAMS, ParamMachine::IDS),
    (Dispatch::MISSION, MissionMachine::IDS),
    (Dispatch::COMMANDS, CommandQueue::IDS),
    (Dispatch::SEQUENCE, Sequence::IDS),
    (Dispatch::CAMERAS, CameraSet::IDS),
    (Dispatch::GIMBALS, GimbalSet::IDS),
    (Dispatch::COMP_META, CompMeta::IDS),
    (Dispatch::LOGS, LogMachine::IDS),
    (Dispatch::PREARM, PrearmReasons::IDS),
    (Dispatch::CALIBRATION, Calibration::IDS),
];

/// Each machine's ids read decoded ([`Machine::DECODES`]), in [`TABLE`]'s order.
pub const DECODES: &[Ids] = &[
    StreamMachine::DECODES,
    FlightTelemetry::DECODES,
    ParamMachine::DECODES,
    MissionMachine::DECODES,
    CommandQueue::DECODES,
    Sequence::DECODES,
    CameraSet::DECODES,
    GimbalSet::DECODES,
    CompMeta::DECODES,
    LogMachine::DECODES,
    PrearmReasons::DECODES,
    Calibration::DECODES,
];

/// The machines that read message `id`, from [`TABLE`] (built once).
#[inline]
pub fn wants(id: u32) -> u16 {
    wants_in(table(), id)
}

/// Ids below this are looked up directly in [`Built::small`]; the rest by binary search.
const SMALL_IDS: usize = 512;

/// A dispatch table: the bits of the machines reading every message, (id, bits) by id, and the
/// bits of every id below [`SMALL_IDS`] (almost every message heard), read in one load.
struct Built {
    all: u16,
    by_id: Vec<(u32, u16)>,
    small: [u16; SMALL_IDS],
}

fn build(table: &[(u16, Ids)]) -> Built {
    let mut all = 0;
    let mut by_id: Vec<(u32, u16)> = Vec::new();
    for &(bit, ids) in table {
        match ids {
            Ids::All => all |= bit,
            Ids::Only(ids) => {
                for &id in ids {
                    match by_id.iter_mut().find(|(i, _)| *i == id) {
                        Some((_, b)) => *b |= bit,
                        None => by_id.push((id, bit)),
                    }
                }
            }
        }
    }
    by_id.sort_unstable();
    let mut small = [all; SMALL_IDS];
    for &(id, bits) in &by_id {
        if let Some(b) = small.get_mut(id as usize) {
            *b |= bits;
        }
    }
    Built { all, by_id, small }
}

fn table() -> &'static Built {
    static T: std::sync::OnceLock<Built> = std::sync::OnceLock::new();
    T.get_or_init(|| build(TABLE))
}

#[inline]
fn wants_in(t: &Built, id: u32) -> u16 {
    if let Some(&bits) = t.small.get(id as usize) {
        return bits;
    }
    match t.by_id.binary_search_by_key(&id, |(i, _)| *i) {
        Ok(i) => t.all | t.by_id[i].1,
        Err(_) => t.all,
    }
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
    /// Parameter metadata asked of the vehicle (component metadata protocol).
    pub comp_meta: CompMeta,
    /// The onboard logs: the list, the download and its queue.
    pub logs: LogMachine,
    /// The reasons the vehicle gives now for not arming (Health screen).
    pub prearm: PrearmReasons,
    /// The calibration running, or the last one and its result.
    pub calibration: Calibration,
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
            streams: StreamMachine::new(key, autopilot, request_streams, rates),
            commands: CommandQueue::default(),
            sequence: None,
            flight: FlightTelemetry::new(key, request_streams),
            params: ParamMachine::new(key, autopilot, fetch_params),
            mission: MissionMachine::new(key),
            cameras: CameraSet::default(),
            gimbals: GimbalSet::default(),
            comp_meta: CompMeta::new(
                key,
                fetch_params && crate::proto::profile::of(autopilot).component_metadata(),
            ),
            logs: LogMachine::new(key),
            // ArduPilot repeats its reasons every 30 s; others keep them until cleared.
            prearm: PrearmReasons::with_period(
                crate::proto::profile::of(autopilot).prearm_period(),
            ),
            calibration: Calibration::new(key),
            mode_seen: None,
            mode_asks: Vec::new(),
            quiet: std::collections::BTreeSet::new(),
            autopilot,
        };
        s.gimbals.autopilot = key.1;
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

    /// When this system was last heard on a link `ok` accepts (`None`: on none).
    pub fn last_heard_on(&self, ok: impl Fn(LinkId) -> bool) -> Option<Micros> {
        self.heard
            .iter()
            .filter(|(l, _)| ok(**l))
            .map(|(_, (t, _))| *t)
            .max()
    }

    /// Links this system has been heard on.
    pub fn links(&self) -> impl Iterator<Item = LinkId> + '_ {
        self.heard.keys().copied()
    }

    /// A message of this system, for us or broadcast: each machine reading its id is handed it
    /// (the autopilot's machines only what the autopilot sent; parameters, cameras, gimbals and
    /// the ACKs of commands from any component of the system).
    /// What comes of it is pushed on `out` (not returned: a Vec handed back through the stack
    /// for every frame is stored and read back in pieces, which the CPU waits for).
    pub fn on_message(&mut self, m: &Incoming, out: &mut Vec<SessionOut>) {
        let (now, from) = (m.now, m.from.1);
        match self.heard.get_mut(&m.link) {
            Some(h) => *h = (now, m.profile),
            None => {
                self.heard.insert(m.link, (now, m.profile));
                // Nothing starts on its own while the system is heard on high-latency links
                // only.
                let held = self.heard.values().all(|(_, p)| p.hl);
                self.params.hold_auto(held);
                self.comp_meta.hold_auto(held);
            }
        }
        let w = wants(m.id);
        // The queue's requests (cameras, gimbals) can only have become takeable when one of
        // those machines or the queue read this message, or something came out of it (a
        // command finished, a sequence's next step); otherwise the next poll offers them.
        let offers = Dispatch::CAMERAS
            | Dispatch::GIMBALS
            | Dispatch::COMMANDS
            | Dispatch::COMP_META
            | Dispatch::CALIBRATION;
        let mut buf = Vec::new();
        if w & Dispatch::PARAMS != 0 {
            Machine::on_message(&mut self.params, m, &mut buf);
            self.deliver(now, &mut buf, out);
        }
        // Cameras: no automatic discovery for components first heard in a heartbeat flood.
        if w & Dispatch::CAMERAS != 0 && !self.quiet.contains(&from) {
            Machine::on_message(&mut self.cameras, m, &mut buf);
            self.deliver(now, &mut buf, out);
        }
        if w & Dispatch::GIMBALS != 0 {
            Machine::on_message(&mut self.gimbals, m, &mut buf);
            self.deliver(now, &mut buf, out);
        }
        // The first message starts its automatic request; files may come from another
        // component.
        if w & Dispatch::COMP_META != 0 || self.comp_meta.waits_to_start() {
            Machine::on_message(&mut self.comp_meta, m, &mut buf);
            self.deliver(now, &mut buf, out);
        }
        if from != self.key.1 {
            // Another component of this system (a camera, a gimbal): the answers to commands
            // sent to it through this session's queue.
            if w & Dispatch::COMMANDS != 0 {
                Machine::on_message(&mut self.commands, m, &mut buf);
                self.deliver(now, &mut buf, out);
            }
            if w & offers != 0 || !out.is_empty() || self.sequence.is_some() {
                self.offer_requests(now, out);
                self.hold_streams();
            }
            return;
        }
        if w & Dispatch::MISSION != 0 {
            Machine::on_message(&mut self.mission, m, &mut buf);
            self.deliver(now, &mut buf, out);
        }
        if w & Dispatch::LOGS != 0 {
            Machine::on_message(&mut self.logs, m, &mut buf);
            self.deliver(now, &mut buf, out);
        }
        if w & Dispatch::PREARM != 0 {
            Machine::on_message(&mut self.prearm, m, &mut buf);
        }
        if w & Dispatch::CALIBRATION != 0 {
            Machine::on_message(&mut self.calibration, m, &mut buf);
            self.deliver(now, &mut buf, out);
        }
        // A SET_MESSAGE_INTERVAL's ACK is the stream machine's while one of its own waits,
        // else the command queue's. The messages it measures are counted here, the rest of it
        // (heartbeats, ACKs, a link's first message) is its `on_message`.
        let streams = w & Dispatch::STREAMS != 0 || self.streams.count(now, m.link, m.id).is_none();
        let claimed = streams && self.streams.claims(m);
        if streams {
            Machine::on_message(&mut self.streams, m, &mut buf);
        }
        if w & Dispatch::FLIGHT != 0 {
            Machine::on_message(&mut self.flight, m, &mut buf);
        }
        self.deliver(now, &mut buf, out);
        if w & Dispatch::COMMANDS != 0 && !claimed {
            Machine::on_message(&mut self.commands, m, &mut buf);
            self.deliver(now, &mut buf, out);
        }
        if let Some(hb) = m.heartbeat() {
            self.on_mode_seen(hb.custom_mode, out);
        }
        if let Some(seq) = self
            .sequence
            .as_mut()
            .filter(|_| w & Dispatch::SEQUENCE != 0)
        {
            Machine::on_message(seq, m, &mut buf);
            self.deliver(now, &mut buf, out);
        }
        // The command queue changed only if a command was answered, something came out, or
        // requests were offered: only then can an operator's rate request have opened or ended.
        if w & offers != 0 || !out.is_empty() || self.sequence.is_some() {
            self.offer_requests(now, out);
            self.hold_streams();
        }
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

    /// The waiting requests of the machines asking through the queue (cameras, then gimbals),
    /// each component's first, when the queue takes it (one command of a kind per target open
    /// at a time); a refused one is offered again after the next message or poll.
    fn offer_requests(&mut self, now: Micros, out: &mut Vec<SessionOut>) {
        self.drain_requests(now, |s| &mut s.cameras, out);
        self.drain_requests(now, |s| &mut s.gimbals, out);
        self.drain_requests(now, |s| &mut s.comp_meta, out);
        self.drain_requests(now, |s| &mut s.calibration, out);
    }

    /// One machine's requests offered to the queue; those taken go out as mavterm's own.
    fn drain_requests<M: Requests>(
        &mut self,
        now: Micros,
        machine: fn(&mut Session) -> &mut M,
        out: &mut Vec<SessionOut>,
    ) {
        for r in machine(self).requests() {
            let (compid, command, params) = r;
            let target = VehicleKey(self.key.0, compid);
            if self.commands.is_open(target, command) {
                continue;
            }
            let spec = CommandSpec {
                target: target.into(),
                command,
                params,
                form: crate::proto::commands::Form::Long,
            };
            let Ok((_, sends)) = self.commands.submit(now, spec) else {
                continue;
            };
            machine(self).taken(&r);
            let mut buf = Vec::new();
            commands::to_out(sends, Route::Auto, &mut buf);
            self.deliver(now, &mut buf, out);
        }
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
        self.prearm.on_text(now, text);
        self.calibration.on_text(now, text);
    }

    /// Start (or queue) a mission, fence or rally point transfer.
    pub fn mission_submit(
        &mut self,
        now: Micros,
        req: MissionRequest,
    ) -> Result<Vec<SessionOut>, String> {
        let mut o = self.mission.submit_out(now, req)?;
        let mut out = Vec::new();
        self.deliver(now, &mut o, &mut out);
        Ok(out)
    }

    /// Make `seq` the current mission item.
    pub fn mission_set_current(
        &mut self,
        now: Micros,
        seq: u16,
    ) -> Result<Vec<SessionOut>, String> {
        let mut o = self.mission.set_current_out(now, seq)?;
        let mut out = Vec::new();
        self.deliver(now, &mut o, &mut out);
        Ok(out)
    }

    /// Send a command through the queue.
    pub fn submit(
        &mut self,
        now: Micros,
        spec: CommandSpec,
    ) -> Result<(u64, Vec<SessionOut>), String> {
        let (id, o) = self.queue(now, spec)?;
        let mut out = Vec::new();
        self.drive(now, o, &mut out);
        self.hold_streams();
        Ok((id, out))
    }

    /// The queue's submit; a mode change remembers the mode it leaves.
    fn queue(&mut self, now: Micros, spec: CommandSpec) -> Result<(u64, Vec<CmdOut>), String> {
        let mode = spec.command == MavCmd::MAV_CMD_DO_SET_MODE as u16 && spec.key() == self.key;
        let (id, out) = self.commands.submit(now, spec)?;
        if mode {
            self.mode_asks.push((id, self.mode_seen));
        }
        Ok((id, out))
    }

    /// The heartbeat shows `mode`: a DO_SET_MODE sent from another mode is no longer resent.
    fn on_mode_seen(&mut self, mode: u32, out: &mut Vec<SessionOut>) {
        self.mode_seen = Some(mode);
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
            done.extend(self.commands.supersede(now, self.key, command as u16));
        }
        self.mode_asks.clear();
        self.drive(now, done, &mut out);
        self.hold_streams();
        out
    }

    /// Abort command `id` in progress.
    pub fn cancel(&mut self, now: Micros, id: u64) -> Result<Vec<SessionOut>, String> {
        let o = self.commands.cancel(now, id)?;
        let mut out = Vec::new();
        self.drive(now, o, &mut out);
        self.hold_streams();
        Ok(out)
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
        let mut out = Vec::new();
        self.seq_step(now, Vec::new(), &mut out);
        self.hold_streams();
        Ok(out)
    }

    /// Queue output, in the one contract, delivered.
    fn drive(&mut self, now: Micros, outs: Vec<CmdOut>, out: &mut Vec<SessionOut>) {
        let mut buf = Vec::new();
        commands::to_out(outs, Route::Vehicle, &mut buf);
        self.deliver(now, &mut buf, out);
    }

    /// Machine output turned into what the session wants done, in one place: the routing
    /// policy ([`Route`] to [`SessionOut`]), notices, typed outcomes for the UI, and finished
    /// commands handed on to the cameras, gimbals and the sequence (which then submits its next
    /// command when it is time). Drains `outs`.
    #[inline]
    pub fn deliver(&mut self, now: Micros, outs: &mut Vec<Out>, out: &mut Vec<SessionOut>) {
        if outs.is_empty() && self.sequence.is_none() {
            return;
        }
        self.deliver_all(now, outs, out);
    }

    fn deliver_all(&mut self, now: Micros, outs: &mut Vec<Out>, out: &mut Vec<SessionOut>) {
        let mut seq_events = Vec::new();
        for o in outs.drain(..) {
            match o {
                Out::Send { route, msg } => out.push(route_out(route, msg)),
                Out::Event(MachineEvent::Notice(sev, text))
                | Out::Event(MachineEvent::Text { sev, text, .. }) => {
                    out.push(SessionOut::Notice(sev, text))
                }
                Out::Event(MachineEvent::ParamSet {
                    comp,
                    name,
                    confirmed,
                    notice: (sev, text),
                }) => out.push(SessionOut::ParamSet {
                    comp,
                    name,
                    confirmed,
                    sev,
                    text,
                }),
                Out::Event(MachineEvent::SequenceDone {
                    notice: (sev, text),
                }) => out.push(SessionOut::SequenceDone { sev, text }),
                Out::Event(MachineEvent::CompMeta(e)) => out.push(SessionOut::CompMeta(e)),
                Out::Event(MachineEvent::MissionEnd {
                    ask,
                    done,
                    notice: (sev, text),
                }) => out.push(SessionOut::MissionEnd {
                    ask,
                    done,
                    sev,
                    text,
                }),
                Out::Event(MachineEvent::CommandDone { id, notice }) => {
                    if let (Some((sev, text)), Some(e)) = (notice, self.commands.get(id)) {
                        // The gimbal discovery asks every autopilot (most have no mount): its
                        // outcomes stay on the Commands screen instead of a notice each; the
                        // component metadata request tells its own outcome.
                        if !crate::proto::gimbal::is_discovery(e.spec.command, &e.spec.params)
                            && !crate::proto::comp_meta::is_request(e.spec.command, &e.spec.params)
                        {
                            out.push(SessionOut::Command {
                                id,
                                target: e.spec.key(),
                                command: e.spec.command,
                                sev,
                                text,
                            });
                        }
                    }
                    self.on_command_done(now, id, out, &mut seq_events);
                }
            }
        }
        self.seq_step(now, seq_events, out);
    }

    /// Command `id` finished: the gimbals, cameras and the sequence waiting on it are told.
    fn on_command_done(
        &mut self,
        now: Micros,
        id: u64,
        out: &mut Vec<SessionOut>,
        seq_events: &mut Vec<Out>,
    ) {
        let Some(e) = self.commands.get(id) else {
            return;
        };
        let (target, cmd, p) = (e.spec.target, e.spec.command, e.spec.params);
        let state = e.state.clone();
        let accepted = state == State::Done(0);
        let refused = matches!(state, State::Done(r) if r != 0);
        if target.0 == self.key.0 {
            self.gimbals.on_finished(now, target.1, cmd, &p);
        }
        let mut meta = Vec::new();
        self.comp_meta
            .on_finished(now, target, cmd, &p, state.clone(), &mut meta);
        for o in meta {
            if let Out::Event(MachineEvent::CompMeta(e)) = o {
                out.push(SessionOut::CompMeta(e));
            }
        }
        if self.cameras.cameras.contains_key(&target.1) && target.0 == self.key.0 {
            if accepted && cmd == MavCmd::MAV_CMD_STORAGE_FORMAT as u16 && p[2] == 1.0 {
                self.cameras.forget_images(target.1);
            }
            let mut notes = self.cameras.on_finished(now, target.1, cmd, &p, accepted);
            if refused {
                notes.extend(self.cameras.on_refused(target.1, cmd, &p));
            }
            out.extend(notes.into_iter().map(|(s, t)| SessionOut::Notice(s, t)));
        }
        if let (Some(seq), Some(e)) = (self.sequence.as_mut(), self.commands.get(id)) {
            let accepted = e.state == State::Done(0);
            let outcome = e.outcome_with_reason();
            sequence::to_out(seq.on_finished(now, id, accepted, &outcome), seq_events);
        }
    }

    /// The sequence's output, and its next command submitted when it is time.
    fn seq_step(&mut self, now: Micros, mut events: Vec<Out>, out: &mut Vec<SessionOut>) {
        for o in events.drain(..) {
            match o {
                Out::Send { route, msg } => out.push(route_out(route, msg)),
                Out::Event(MachineEvent::Notice(sev, text)) => {
                    out.push(SessionOut::Notice(sev, text))
                }
                Out::Event(MachineEvent::SequenceDone {
                    notice: (sev, text),
                }) => out.push(SessionOut::SequenceDone { sev, text }),
                Out::Event(_) => {}
            }
        }
        let next = self.sequence.as_ref().and_then(|s| s.next_command());
        if let Some(spec) = next {
            match self.queue(now, spec) {
                Ok((id, sends)) => {
                    if let Some(seq) = self.sequence.as_mut() {
                        seq.sent(id);
                    }
                    self.drive(now, sends, out);
                }
                Err(why) => {
                    let mut r = Vec::new();
                    if let Some(s) = self.sequence.as_mut() {
                        sequence::to_out(s.refused(&why), &mut r);
                    }
                    self.seq_step(now, r, out);
                }
            }
        }
        if self.sequence.as_ref().is_some_and(|s| s.finished()) {
            self.sequence = None;
        }
    }

    /// The stream machine holds its SET_MESSAGE_INTERVALs while one of the operator's is open.
    fn hold_streams(&mut self) {
        let interval = MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL as u16;
        let operators = self.commands.is_open(self.key, interval)
            || self.commands.is_open(VehicleKey(self.key.0, 0), interval);
        self.streams.hold_intervals(operators);
    }

    /// The vehicle rebooted: every machine starts over where it must.
    /// True while work is in flight: a command waiting for its answer, a sequence, a parameter
    /// download or edit, a mission transfer. Such a vehicle is never evicted.
    pub fn busy(&self) -> bool {
        self.sequence.is_some()
            || self.params.busy()
            || self.mission.busy()
            || self.logs.busy()
            || self.commands.entries().any(|e| e.open())
    }

    pub fn on_reboot(&mut self, now: Micros) -> Vec<SessionOut> {
        self.streams.on_reboot();
        self.mission.on_reboot();
        self.comp_meta.on_reboot();
        // A calibration running is forgotten; the reboot a compass calibration needed is done.
        let mut buf = Vec::new();
        self.calibration.on_reboot(now, &mut buf);
        let mut out = Vec::new();
        self.deliver(now, &mut buf, &mut out);
        out
    }

    /// Every open `command` to this vehicle is superseded (finished at once, never resent, its
    /// late ACK ignored): a newer request of the same command makes it stale.
    pub fn supersede(&mut self, now: Micros, command: u16) -> Vec<SessionOut> {
        let done = self.commands.supersede(now, self.key, command);
        let mut out = Vec::new();
        self.drive(now, done, &mut out);
        out
    }

    /// `link` came back after being down.
    pub fn on_link_reconnected(&mut self, link: LinkId) {
        self.streams.on_link_reconnected(link);
    }

    /// Whatever is due at `now`.
    pub fn poll(&mut self, now: Micros) -> Vec<SessionOut> {
        self.hold_streams();
        let mut out = Vec::new();
        let mut buf = Vec::new();
        Machine::poll(&mut self.streams, now, &mut buf);
        self.deliver(now, &mut buf, &mut out);
        Machine::poll(&mut self.commands, now, &mut buf);
        self.deliver(now, &mut buf, &mut out);
        if let Some(seq) = self.sequence.as_mut() {
            Machine::poll(seq, now, &mut buf);
        }
        self.deliver(now, &mut buf, &mut out);
        Machine::poll(&mut self.flight, now, &mut buf);
        Machine::poll(&mut self.params, now, &mut buf);
        self.deliver(now, &mut buf, &mut out);
        Machine::poll(&mut self.mission, now, &mut buf);
        self.deliver(now, &mut buf, &mut out);
        Machine::poll(&mut self.cameras, now, &mut buf);
        Machine::poll(&mut self.gimbals, now, &mut buf);
        self.deliver(now, &mut buf, &mut out);
        Machine::poll(&mut self.comp_meta, now, &mut buf);
        Machine::poll(&mut self.logs, now, &mut buf);
        Machine::poll(&mut self.prearm, now, &mut buf);
        Machine::poll(&mut self.calibration, now, &mut buf);
        self.deliver(now, &mut buf, &mut out);
        self.offer_requests(now, &mut out);
        self.hold_streams();
        out
    }

    /// An operator's action on the log machine, its output delivered.
    pub fn logs_do<T>(
        &mut self,
        now: Micros,
        f: impl FnOnce(&mut LogMachine, &mut Vec<Out>) -> T,
    ) -> (T, Vec<SessionOut>) {
        let mut buf = Vec::new();
        let r = f(&mut self.logs, &mut buf);
        let mut out = Vec::new();
        self.deliver(now, &mut buf, &mut out);
        (r, out)
    }

    /// The operator fetches the parameters of component `comp`.
    pub fn params_fetch(&mut self, now: Micros, comp: u8) -> Vec<SessionOut> {
        let o = self.params.fetch(now, comp);
        self.params_out(now, o)
    }

    /// The operator sets parameter `name` of component `comp` to `v`.
    pub fn params_set(
        &mut self,
        now: Micros,
        comp: u8,
        name: &str,
        v: f64,
    ) -> Result<Vec<SessionOut>, String> {
        let o = self.params.set(now, comp, name, v)?;
        Ok(self.params_out(now, o))
    }

    /// The parameter machine's output of an operator's fetch or edit, delivered.
    fn params_out(&mut self, now: Micros, o: Vec<ParamOut>) -> Vec<SessionOut> {
        let mut buf: Vec<Out> = o.into_iter().map(|o| self.params.out(o)).collect();
        let mut out = Vec::new();
        self.deliver(now, &mut buf, &mut out);
        out
    }

    /// When the session next needs a poll: the machines' deadlines (work not on a timer is
    /// due at the time it became due; the poll then does it).
    pub fn next_deadline(&self) -> Option<Micros> {
        [
            Machine::next_deadline(&self.streams),
            Machine::next_deadline(&self.commands),
            self.sequence.as_ref().and_then(Machine::next_deadline),
            Machine::next_deadline(&self.flight),
            Machine::next_deadline(&self.params),
            Machine::next_deadline(&self.mission),
            Machine::next_deadline(&self.cameras),
            Machine::next_deadline(&self.gimbals),
            Machine::next_deadline(&self.comp_meta),
            Machine::next_deadline(&self.logs),
            Machine::next_deadline(&self.prearm),
            Machine::next_deadline(&self.calibration),
        ]
        .into_iter()
        .flatten()
        .min()
    }
}

/// The routing policy: the operator's messages on the vehicle's route, mavterm's own spared on
/// high-latency links, stream requests on their link.
fn route_out(route: Route, msg: MavMessage) -> SessionOut {
    match route {
        Route::Vehicle => SessionOut::Send(msg),
        Route::Auto => SessionOut::SendAuto(msg),
        Route::Link(l) => SessionOut::SendOn(l, msg),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::app::{App, AppConfig};
    use crate::clock::SECOND;
    use crate::wire::Severity;
    use mavlink::MessageData;

    /// A machine made up for the test: it reads SYSTEM_TIME, and one second after each it
    /// tells the time it was sent (untimed work would be a deadline at the time it came).
    #[derive(Default)]
    struct Toy {
        heard: Vec<u32>,
        at: Option<Micros>,
    }

    impl Machine for Toy {
        const IDS: Ids = Ids::Only(&[crate::dialect::SYSTEM_TIME_DATA::ID]);

        fn on_message(&mut self, m: &Incoming, _: &mut Vec<Out>) {
            self.heard.push(m.id);
            self.at = Some(m.now + SECOND);
        }

        fn poll(&mut self, now: Micros, out: &mut Vec<Out>) {
            if self.at.is_some_and(|t| now >= t) {
                self.at = None;
                out.push(Out::notice(Severity::INFO, format!("toy at {now}")));
                out.push(Out::send(Route::Auto, App::gcs_heartbeat()));
            }
        }

        fn next_deadline(&self) -> Option<Micros> {
            self.at
        }
    }

    const TOY: u16 = 1 << 15;

    fn incoming(now: Micros, id: u32) -> Incoming<'static> {
        Incoming {
            now,
            from: (1, 1),
            link: 0,
            profile: LinkProfile {
                hl: false,
                baud: None,
            },
            id,
            payload: &[],
            msg: None,
            ack: None,
        }
    }

    #[test]
    fn a_new_machine_plugs_in_by_its_ids_and_its_deadline() {
        // Its bit and its ids in the table, next to the session's own machines.
        let mut table = TABLE.to_vec();
        table.push((TOY, Toy::IDS));
        let built = build(&table);
        let time = crate::dialect::SYSTEM_TIME_DATA::ID;
        let attitude = crate::dialect::ATTITUDE_DATA::ID;
        assert_ne!(wants_in(&built, time) & TOY, 0);
        assert_eq!(wants_in(&built, attitude) & TOY, 0);
        // The session's own bits are unchanged by the toy: the stream machine takes
        // heartbeats by the table (the messages it measures come by its own per-link check),
        // and the session's own table is untouched.
        let heartbeat = crate::dialect::HEARTBEAT_DATA::ID;
        assert_ne!(wants_in(&built, heartbeat) & Dispatch::STREAMS, 0);
        assert_eq!(wants_in(&built, attitude) & Dispatch::STREAMS, 0);
        assert_eq!(wants(time) & TOY, 0);
        assert_eq!(
            wants(crate::dialect::PARAM_VALUE_DATA::ID) & Dispatch::PARAMS,
            Dispatch::PARAMS
        );

        // Driven as the session drives its machines: messages by the table, a poll whenever
        // the deadline is reached, output through the one conversion.
        let mut toy = Toy::default();
        let mut buf = Vec::new();
        for (now, id) in [(0, attitude), (SECOND / 2, time), (SECOND, attitude)] {
            if wants_in(&built, id) & TOY != 0 {
                toy.on_message(&incoming(now, id), &mut buf);
            }
        }
        assert_eq!(toy.heard, vec![time]);
        assert_eq!(toy.next_deadline(), Some(SECOND + SECOND / 2));
        toy.poll(SECOND, &mut buf);
        assert!(buf.is_empty(), "not before its deadline");
        toy.poll(SECOND + SECOND / 2, &mut buf);
        assert_eq!(toy.next_deadline(), None, "the poll took the work");
        let out: Vec<SessionOut> = buf
            .drain(..)
            .map(|o| match o {
                Out::Send { route, msg } => route_out(route, msg),
                Out::Event(MachineEvent::Notice(s, t)) => SessionOut::Notice(s, t),
                o => panic!("{o:?}"),
            })
            .collect();
        assert_eq!(
            out,
            vec![
                SessionOut::Notice(crate::wire::Severity::INFO, "toy at 1500000".into()),
                SessionOut::SendAuto(App::gcs_heartbeat()),
            ]
        );
    }

    #[test]
    fn outcomes_reach_the_screens_as_events_not_as_text() {
        let mut app = App::new(AppConfig::default());
        let key = VehicleKey(1, 1);
        let mut fx = Vec::new();
        // A parameter edit awaited: a notice worded like its outcome is only a notice.
        let kind = crate::app::outcome::ActionKind::ParamWrite {
            key,
            waiting: vec![(1, "RTL_ALT".into())],
            total: 1,
            confirmed: 0,
        };
        app.start_action(Some(key), Vec::new(), kind, "RTL_ALT = 30: sent".into());
        app.session_out(
            key,
            vec![SessionOut::Notice(
                crate::wire::Severity::INFO,
                "RTL_ALT = 30 confirmed".into(),
            )],
            &mut fx,
        );
        assert!(app.ui.action.as_ref().is_some_and(|a| !a.done));
        // Another component's parameter of the same name is not it.
        let set = |comp| SessionOut::ParamSet {
            comp,
            name: "RTL_ALT".into(),
            confirmed: true,
            sev: crate::wire::Severity::INFO,
            text: "RTL_ALT = 30 confirmed".into(),
        };
        app.session_out(key, vec![set(2)], &mut fx);
        assert!(app.ui.action.as_ref().is_some_and(|a| !a.done));
        // The typed outcome settles it, whatever its wording.
        app.session_out(key, vec![set(1)], &mut fx);
        assert!(app.ui.action.as_ref().is_some_and(|a| a.done));
        assert_eq!(
            app.action_text(),
            Some((crate::wire::Severity::INFO, "RTL_ALT = 30 confirmed".into()))
        );

        // A command of the queue: its id, not a notice worded like its outcome.
        let kind = crate::app::outcome::ActionKind::Command;
        app.start_action(
            Some(key),
            vec![2],
            kind,
            "SET_MESSAGE_INTERVAL: sent".into(),
        );
        let text = "SET_MESSAGE_INTERVAL to 1:1: ACCEPTED".to_string();
        let notice = SessionOut::Notice(crate::wire::Severity::INFO, text.clone());
        app.session_out(key, vec![notice], &mut fx);
        assert!(app.ui.action.as_ref().is_some_and(|a| !a.done));
        let smi = MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL as u16;
        let other = SessionOut::Command {
            id: 1,
            target: VehicleKey(1, 1),
            command: smi,
            sev: crate::wire::Severity::INFO,
            text: text.clone(),
        };
        app.session_out(key, vec![other], &mut fx);
        assert!(app.ui.action.as_ref().is_some_and(|a| !a.done));
        let done = SessionOut::Command {
            id: 2,
            target: VehicleKey(1, 1),
            command: smi,
            sev: crate::wire::Severity::INFO,
            text: text.clone(),
        };
        app.session_out(key, vec![done], &mut fx);
        assert_eq!(app.action_text(), Some((crate::wire::Severity::INFO, text)));
    }
}
