//! MAVLink 2 signing in the core: what we sign, what we accept, and the `signing` command.
//!
//! Policy (the MAVLink guide's rules; the codec is [`crate::wire::signing`]):
//! - Without a key, every frame is taken; signed ones are counted as *unchecked*, and a source
//!   that signs is warned about once: its autopilot ignores our unsigned commands.
//! - With a key, every frame we send is signed (MAVLink 2; link id = the link's number, one
//!   timestamp clock for all links that never goes backwards, kept across runs by the edge).
//!   Incoming signed frames are checked: a bad signature, a timestamp not after the last of its
//!   stream (link id, sysid, compid), a new stream more than a minute behind ours, or a timestamp
//!   more than [`codec::FUTURE_MARGIN`] (a minute) ahead of the wall clock is rejected. Only a
//!   frame taken raises our clock, so no frame from the future carries it away; nor does one
//!   on a trusted link, where everything is taken.
//! - Our clock is kept within that margin of the wall clock, and so is the state file (plus the
//!   reservation, [`RESERVE`]): a file further ahead of the clock that wrote it (an older run
//!   that took a frame from the future) is repaired at start, with a notice.
//!   Unsigned frames are rejected, except RADIO_STATUS and RADIO (SiK radios cannot sign, as
//!   ArduPilot and MAVProxy accept them) and, with `--signing-allow-unsigned-heartbeat`,
//!   HEARTBEAT.
//! - On a trusted link (`?secure=1`: a USB cable or a wire, as ArduPilot trusts its USB port; and
//!   the in-process `sim://` and `tlog:`) nothing is rejected, but everything is still checked
//!   and counted, so the operator sees whether a vehicle signs with our key.
//! - A rejected frame is counted on its source (link, sysid:compid) and read no further: it is
//!   not a heartbeat, not telemetry, and not in the loss statistics (its sequence number is not
//!   one we trust).
//!
//! `signing setup` sends our key to the target in SETUP_SIGNING (after a confirmation, and only
//! on a `?secure=1` link: the key travels in clear); `signing off` sends the all-zero key with
//! timestamp 0, as MAVProxy's `signing remove`, and stops our own signing. SETUP_SIGNING has no
//! ACK: what the vehicle's frames do next tells, and is told.

use std::path::PathBuf;

pub use super::confirm::SigningAction;
use super::confirm::{Ask, Confirmed};
use super::{App, Effect};
use crate::clock::{Micros, SECOND};
use crate::dialect::{self, MavMessage};
use crate::link::{Frame, LinkId};
use crate::proto::vehicles::VehicleKey;
use crate::wire::signing::{self as codec, Clock, SecretKey, Verdict};
use crate::wire::tx::Sign;
use crate::wire::Severity;

/// RADIO_STATUS: SiK radios send it unsigned.
pub const MSG_RADIO_STATUS: u32 = <dialect::RADIO_STATUS_DATA as mavlink::MessageData>::ID;
/// RADIO (ardupilotmega): the older form, accepted unsigned as ArduPilot and MAVProxy do.
#[allow(deprecated)] // superseded by RADIO_STATUS, still sent by older radios
pub const MSG_RADIO: u32 = <dialect::RADIO_DATA as mavlink::MessageData>::ID;
/// How long after `signing setup`/`signing off` the vehicle's frames are watched for the change.
pub const WATCH: Micros = 5 * SECOND;
/// How far ahead of our clock the state file is written (30 s, in timestamp units), renewed when
/// the clock is within half of it: a write every 15 s while we sign. After a crash the next run
/// starts at most this far ahead of the last timestamp used: never behind it, and well within
/// the minute a vehicle's new stream may be behind ours.
pub const RESERVE: u64 = 3_000_000;
/// How far ahead of the wall clock that wrote it the state file may be: our clock is at most
/// [`codec::FUTURE_MARGIN`] ahead (it only takes timestamps within it), the reservation
/// [`RESERVE`] more. A file beyond this is repaired at start.
pub const STATE_LIMIT: u64 = codec::FUTURE_MARGIN + RESERVE;

/// Signing settings the core starts with: made at the edge from `--signing-key` and the state
/// file.
#[derive(Debug, Clone)]
pub struct SigningConfig {
    pub key: SecretKey,
    /// Accept unsigned HEARTBEATs (components that cannot sign stay listed).
    pub allow_unsigned_heartbeat: bool,
    /// Where the timestamp is kept between runs; `None`: not kept.
    pub state_path: Option<PathBuf>,
    /// The timestamp the last run kept: ours start after it.
    pub saved_timestamp: u64,
    /// The wall timestamp at which it was written (the file's modification time), when known:
    /// a system clock that went back since then is no reason to doubt the file.
    pub saved_at: Option<u64>,
}

/// How a frame stood with signing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SigKind {
    /// Signed, checked and good.
    Signed,
    /// Signed, not checked (we have no key).
    Unchecked,
    Unsigned,
    BadSignature,
    /// A timestamp not after the last of its stream.
    Replayed,
    /// A new stream more than a minute behind our timestamp.
    TooOld,
    /// A timestamp more than a minute ahead of the wall clock.
    Future,
}

/// A frame's signing verdict: what it was, and whether it is used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Checked {
    pub kind: SigKind,
    pub accepted: bool,
    /// For [`SigKind::Future`]: what to tell of it.
    pub future: Option<FutureStamp>,
}

/// A timestamp from the future, as heard.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FutureStamp {
    pub timestamp: u64,
    /// The wall timestamp it was held against.
    pub wall: u64,
    pub link_id: u8,
    /// The first such frame of its stream.
    pub first: bool,
}

impl Checked {
    /// True when this frame is told of, `first` being whether it is the first of its kind from
    /// its source: a timestamp from the future is told once per stream, the rest once per kind.
    fn is_told(&self, first: bool) -> bool {
        match self.future {
            Some(f) => f.first,
            None => first,
        }
    }
}

/// Signing counts of one source on one link (the report's `links[].sources[].signing`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct SigningCounts {
    /// Signed frames checked and good.
    pub signed: u64,
    /// Signed frames taken unchecked (no key).
    pub unchecked: u64,
    pub unsigned: u64,
    pub bad_signature: u64,
    pub replayed: u64,
    /// New streams more than a minute old (counted with the replays on screen).
    pub too_old: u64,
    /// Timestamps more than a minute ahead of the wall clock.
    pub future: u64,
    /// Frames rejected (of any kind above).
    pub rejected: u64,
}

impl SigningCounts {
    /// Count a frame; true when it is the first of its kind from this source (to tell of once).
    pub fn count(&mut self, c: Checked) -> bool {
        let n = match c.kind {
            SigKind::Signed => &mut self.signed,
            SigKind::Unchecked => &mut self.unchecked,
            SigKind::Unsigned => &mut self.unsigned,
            SigKind::BadSignature => &mut self.bad_signature,
            SigKind::Replayed => &mut self.replayed,
            SigKind::TooOld => &mut self.too_old,
            SigKind::Future => &mut self.future,
        };
        *n += 1;
        if !c.accepted {
            self.rejected += 1;
        }
        *n == 1
    }

    /// True when there is something about signing to show for this source.
    pub fn any_signing(&self) -> bool {
        self.signed
            + self.unchecked
            + self.bad_signature
            + self.replayed
            + self.too_old
            + self.future
            > 0
            || self.rejected > 0
    }
}

/// What was sent to a vehicle and is being watched for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WatchFor {
    /// `signing setup`: its first frame signed with our key.
    Setup,
    /// `signing off`: its frames no longer signed.
    Off,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Watch {
    pub vehicle: VehicleKey,
    pub what: WatchFor,
    pub until: Micros,
    /// The vehicle's last frame was signed.
    pub signed: bool,
}

/// The `signing` prompt command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SigningCmd {
    Status,
    Setup,
    Off,
}

/// The core's signing state.
#[derive(Debug, Clone, Default)]
pub struct SigningState {
    /// The key in use: `None` without `--signing-key`, or after `signing off`.
    pub key: Option<SecretKey>,
    /// The key given at start (what `signing setup` sends), kept after `signing off`.
    configured: Option<SecretKey>,
    pub allow_unsigned_heartbeat: bool,
    /// Our outgoing timestamp.
    pub clock: Clock,
    state_path: Option<PathBuf>,
    /// The timestamp the run started after.
    loaded: u64,
    /// The timestamp last written to the state file: a reservation [`RESERVE`] ahead of the
    /// clock, so a crash between writes never lets the next run reuse a timestamp.
    reserved: u64,
    save_failure_told: bool,
    /// The state file was repaired at start: written at the first chance.
    repair_due: bool,
    /// What the state file held when it was repaired (for the notice at start).
    pub repaired_from: Option<u64>,
    saved_at: Option<u64>,
    pub watch: Option<Watch>,
}

impl SigningState {
    pub fn new(cfg: Option<&SigningConfig>) -> Self {
        let Some(cfg) = cfg else {
            return Self::default();
        };
        Self {
            key: Some(cfg.key.clone()),
            configured: Some(cfg.key.clone()),
            allow_unsigned_heartbeat: cfg.allow_unsigned_heartbeat,
            clock: Clock::after(cfg.saved_timestamp),
            state_path: cfg.state_path.clone(),
            loaded: cfg.saved_timestamp,
            reserved: cfg.saved_timestamp,
            save_failure_told: false,
            repair_due: false,
            repaired_from: None,
            saved_at: cfg.saved_at,
            watch: None,
        }
    }

    /// At start, at wall timestamp `wall`: a saved timestamp further ahead than [`STATE_LIMIT`]
    /// of the clock that wrote it (or of ours now, when later) was not written by a run that
    /// kept the rules: ours start from `wall` instead, and the file is written again. Returns
    /// what it held then.
    fn repair(&mut self, wall: u64) -> Option<u64> {
        self.key.as_ref()?;
        let reference = wall.max(self.saved_at.unwrap_or(0));
        if self.loaded <= reference.saturating_add(STATE_LIMIT) {
            return None;
        }
        let bad = self.loaded;
        self.clock = Clock::after(wall);
        self.loaded = wall;
        self.reserved = wall;
        self.repair_due = true;
        self.repaired_from = Some(bad);
        Some(bad)
    }

    /// The signature for the next frame on `link`, when we sign.
    pub fn next_sign(&mut self, link: LinkId, wall: u64) -> Option<Sign<'_>> {
        let Self { key, clock, .. } = self;
        let key = key.as_ref()?;
        Some(Sign {
            key,
            link_id: link_id(link),
            timestamp: clock.next(wall),
        })
    }

    /// The state file write due now, if any: when the clock comes within half of [`RESERVE`]
    /// of what was last reserved, it is reserved again.
    fn save_due(&mut self) -> Option<Effect> {
        let path = self.state_path.as_ref()?;
        let last = self.clock.last();
        let repair = std::mem::take(&mut self.repair_due);
        if !repair && (last <= self.loaded || last + RESERVE / 2 <= self.reserved) {
            return None;
        }
        self.reserved = last + RESERVE;
        Some(Effect::WriteFile {
            path: path.clone(),
            contents: codec::encode_state(self.reserved),
        })
    }

    /// The state file and what to write in it when the run ends: the last timestamp used.
    pub fn final_state(&self) -> Option<(PathBuf, Vec<u8>)> {
        let path = self.state_path.as_ref()?;
        (self.clock.last() > self.loaded)
            .then(|| (path.clone(), codec::encode_state(self.clock.last())))
    }

    /// True for the state file (its writes are not told of).
    pub fn is_state_file(&self, path: &std::path::Path) -> bool {
        self.state_path.as_deref() == Some(path)
    }
}

/// A signing timestamp as a UTC date: `2104-03-13 02:56:07 UTC`.
fn date_text(timestamp: u64) -> String {
    chrono::DateTime::from_timestamp_micros(codec::unix_micros_of(timestamp))
        .map(|d| d.format("%Y-%m-%d %H:%M:%S UTC").to_string())
        .unwrap_or_else(|| format!("timestamp {timestamp}"))
}

/// The link id we sign with on link `link`: its number (links past 255 share the last ids).
pub fn link_id(link: LinkId) -> u8 {
    link.min(255) as u8
}

/// Unsigned messages taken even with a key (SiK radios cannot sign).
fn unsigned_allowed(msgid: u32, heartbeat_too: bool) -> bool {
    msgid == MSG_RADIO_STATUS
        || msgid == MSG_RADIO
        || (heartbeat_too && msgid == <dialect::HEARTBEAT_DATA as mavlink::MessageData>::ID)
}

impl App {
    /// The signing timestamp of the wall clock now.
    pub(super) fn signing_wall(&self) -> u64 {
        codec::timestamp_from_unix_micros(
            self.cfg
                .epoch
                .timestamp_micros()
                .saturating_add(self.now as i64),
        )
    }

    /// A frame from `link` against the signing policy (nothing counted yet).
    pub(super) fn check_signing(&mut self, link: LinkId, frame: &Frame) -> Checked {
        let signed = frame.is_signed();
        let wall = match (&self.signing.key, signed) {
            (Some(_), true) => self.signing_wall(),
            _ => 0,
        };
        let Self { signing, links, .. } = self;
        let trusted = links[link].trusted;
        let mut future = None;
        let (kind, accepted) = match (signing.key.as_ref(), signed) {
            (None, true) => (SigKind::Unchecked, true),
            (None, false) => (SigKind::Unsigned, true),
            (Some(_), false) => (
                SigKind::Unsigned,
                trusted || unsigned_allowed(frame.msgid, signing.allow_unsigned_heartbeat),
            ),
            (Some(key), true) => {
                let current = signing.clock.current(wall);
                let verdict = links[link].signing_streams.check(
                    key,
                    &frame.raw,
                    frame.sysid,
                    frame.compid,
                    current,
                    wall,
                );
                match verdict {
                    Verdict::Good(ts) => {
                        signing.clock.observe(ts);
                        (SigKind::Signed, true)
                    }
                    Verdict::BadSignature => (SigKind::BadSignature, trusted),
                    Verdict::Replayed => (SigKind::Replayed, trusted),
                    Verdict::TooOld => (SigKind::TooOld, trusted),
                    // Taken on a trusted link, but our clock stays where it is.
                    Verdict::Future {
                        timestamp,
                        link_id,
                        first,
                    } => {
                        future = Some(FutureStamp {
                            timestamp,
                            wall,
                            link_id,
                            first,
                        });
                        (SigKind::Future, trusted)
                    }
                }
            }
        };
        Checked {
            kind,
            accepted,
            future,
        }
    }

    /// At start: a state file beyond [`STATE_LIMIT`] is repaired, and told.
    pub(super) fn signing_start(&mut self) {
        let wall = self.signing_wall();
        let Some(bad) = self.signing.repair(wall) else {
            return;
        };
        let file = match &self.signing.state_path {
            Some(p) => format!("signing state {}", p.display()),
            None => "the signing timestamp given".to_string(),
        };
        let reference = wall.max(self.signing.saved_at.unwrap_or(0));
        self.notice(
            Severity::WARNING,
            None,
            format!(
                "{file} held {}, {} ahead of the clock: repaired, we sign from the system \
                 clock (an older run took a frame from the future?). A vehicle that took those \
                 timestamps refuses ours until `signing setup` over ?secure=1 and a reboot",
                date_text(bad),
                codec::span_text(bad - reference)
            ),
        );
    }

    /// A rejected frame: counted on its source, told of once per kind.
    #[cold]
    pub(super) fn signing_rejected(&mut self, link: LinkId, frame: &Frame, c: Checked) {
        let key = VehicleKey(frame.sysid, frame.compid);
        let first = self.links[link].source(key).signing.count(c);
        self.dirty = true;
        if c.is_told(first) {
            self.tell_signing(link, key, c);
        }
    }

    /// After an accepted frame was counted (`first`: the first of its kind from its source on
    /// this link): what there is to tell, and the watch after `signing setup`/`off`.
    pub(super) fn signing_accepted(
        &mut self,
        link: LinkId,
        key: VehicleKey,
        c: Checked,
        first: bool,
    ) {
        if let Some(w) = self.signing.watch.as_mut().filter(|w| w.vehicle == key) {
            w.signed = matches!(c.kind, SigKind::Signed | SigKind::Unchecked);
            if w.what == WatchFor::Setup && c.kind == SigKind::Signed {
                self.signing.watch = None;
                self.notice(
                    Severity::NOTICE,
                    Some(key),
                    format!("{key} signs with our key: signing is on"),
                );
                return;
            }
            if w.what == WatchFor::Off {
                // Frames still on their way are signed: judged when the watch ends.
                return;
            }
        }
        if c.is_told(first) && c.kind != SigKind::Signed && c.kind != SigKind::Unsigned {
            self.tell_signing(link, key, c);
        }
    }

    /// The notice for the first frame of a kind from a source.
    fn tell_signing(&mut self, link: LinkId, key: VehicleKey, c: Checked) {
        let who = key.to_string();
        let fate = if c.accepted {
            "taken: the link is trusted"
        } else {
            "rejected"
        };
        let (sev, text) = match c.kind {
            SigKind::Signed => return,
            SigKind::Unsigned => (
                Severity::WARNING,
                format!(
                    "{who} sends unsigned frames on link {link}: {fate} (we sign; `signing \
                     setup` gives it our key over a ?secure=1 link)"
                ),
            ),
            // A recording or our own sim is not commanded.
            SigKind::Unchecked if !self.links[link].secure && self.links[link].trusted => return,
            SigKind::Unchecked => (
                Severity::WARNING,
                format!(
                    "{who} signs but we have no key: it ignores our commands (start with \
                     --signing-key)"
                ),
            ),
            SigKind::BadSignature => (
                Severity::ERROR,
                format!(
                    "{who}: frames with a bad signature on link {link} (another key, or changed \
                     on the way): {fate}"
                ),
            ),
            SigKind::Replayed => (
                Severity::ERROR,
                format!(
                    "{who}: replayed frames on link {link} (signing timestamps not newer than \
                     before): {fate}"
                ),
            ),
            SigKind::TooOld => (
                Severity::ERROR,
                format!(
                    "{who}: signed frames over a minute behind our clock on link {link} (an old \
                     recording played back?): {fate}"
                ),
            ),
            SigKind::Future => {
                let Some(f) = c.future else { return };
                (
                    Severity::ERROR,
                    format!(
                        "{who}: signed frames from the future, {} ahead of our clock (dated {}), \
                         on link {link} (its link id {}): {fate}, our clock kept. Ours wrong? set \
                         it (`date -u`). Its? `signing setup` over a ?secure=1 link gives it ours",
                        codec::span_text(f.timestamp.saturating_sub(f.wall)),
                        date_text(f.timestamp),
                        f.link_id,
                    ),
                )
            }
        };
        self.notice(sev, Some(key), text);
    }

    /// Timers of signing: the end of a watch, the state file's reservation.
    pub(super) fn signing_time(&mut self, fx: &mut Vec<Effect>) {
        if let Some(w) = self.signing.watch.filter(|w| self.now >= w.until) {
            self.signing.watch = None;
            let who = w.vehicle.to_string();
            let secs = WATCH / SECOND;
            match (w.what, w.signed) {
                (WatchFor::Setup, _) => self.notice(
                    Severity::WARNING,
                    Some(w.vehicle),
                    format!(
                        "{who} sent no frame signed with our key in {secs} s since SETUP_SIGNING: \
                         it may not have taken the key"
                    ),
                ),
                (WatchFor::Off, true) => self.notice(
                    Severity::WARNING,
                    Some(w.vehicle),
                    format!("{who} still signs {secs} s after `signing off`: it kept its key"),
                ),
                (WatchFor::Off, false) => self.notice(
                    Severity::NOTICE,
                    Some(w.vehicle),
                    format!("{who} no longer signs: signing is off"),
                ),
            }
        }
        if let Some(e) = self.signing.save_due() {
            fx.push(e);
        }
    }

    /// When the signing watch ends, if one runs.
    pub(super) fn signing_deadline(&self) -> Option<Micros> {
        self.signing.watch.map(|w| w.until)
    }

    /// A state file write came back: silent when it worked, told once when it did not.
    pub(super) fn signing_file_written(&mut self, error: Option<String>) {
        if let Some(e) = error {
            if !std::mem::replace(&mut self.signing.save_failure_told, true) {
                self.notice(
                    Severity::WARNING,
                    None,
                    format!(
                        "could not keep the signing timestamp: {e} (signing goes on; after a \
                         restart the clock alone sets it)"
                    ),
                );
            }
        }
    }

    /// `signing`, `signing setup`, `signing off`.
    /// (Setup and off only ask here; [`App::carry_out_signing`] sends once confirmed.)
    pub(super) fn run_signing(&mut self, cmd: SigningCmd) -> Result<Option<String>, String> {
        match cmd {
            SigningCmd::Status => Ok(Some(self.signing_status())),
            SigningCmd::Setup => {
                let key = self.signing.configured.clone().ok_or(
                    "signing setup: no signing key (start mavterm with --signing-key)".to_string(),
                )?;
                let target = self.commandable()?;
                let link = self.secure_link_to(target, "signing setup")?;
                self.ask(Ask {
                    text: format!(
                        "SEND SIGNING KEY {} to {} over link {link} ({})? It will then require \
                         signed frames. y = yes, any other key = no",
                        key.id(),
                        self.who(target),
                        self.links[link].spec
                    ),
                    action: Confirmed::Signing(SigningAction::Setup { link }),
                    target,
                });
                Ok(None)
            }
            SigningCmd::Off => {
                let target = self.commandable()?;
                let link = self.secure_link_to(target, "signing off")?;
                self.ask(Ask {
                    text: format!(
                        "TURN SIGNING OFF on {} over link {link} ({})? Anyone on its links could \
                         then command it. y = yes, any other key = no",
                        self.who(target),
                        self.links[link].spec
                    ),
                    action: Confirmed::Signing(SigningAction::Off { link }),
                    target,
                });
                Ok(None)
            }
        }
    }

    /// `1:1 (ArduPilot QUADROTOR)`.
    fn who(&self, key: VehicleKey) -> String {
        match self.vehicles.get(key) {
            Some(v) => format!("{key} ({} {})", v.autopilot_name(), v.type_name()),
            None => key.to_string(),
        }
    }

    /// The link marked `?secure=1`, up, on which `target` is heard.
    fn secure_link_to(&self, target: VehicleKey, what: &str) -> Result<LinkId, String> {
        let heard = self
            .vehicles
            .get(target)
            .map(|v| v.links.clone())
            .unwrap_or_default();
        heard
            .into_iter()
            .find(|&l| self.links.get(l).is_some_and(|s| s.secure) && self.link_up(l))
            .ok_or_else(|| {
                format!(
                    "{what}: {target} is not heard on a link marked ?secure=1 (a USB cable): \
                     refused, SETUP_SIGNING would carry the key in clear"
                )
            })
    }

    /// Send what a confirmed `signing` command means.
    pub(super) fn carry_out_signing(
        &mut self,
        target: VehicleKey,
        action: SigningAction,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let (SigningAction::Setup { link } | SigningAction::Off { link }) = action;
        if !(self.links.get(link).is_some_and(|l| l.secure) && self.link_up(link)) {
            return Err(format!("link {link} is no longer up: nothing sent"));
        }
        let who = target.to_string();
        let (secret, initial_timestamp, what, text) = match action {
            SigningAction::Setup { .. } => {
                let key = self.signing.configured.clone().ok_or("no signing key")?;
                // A timestamp of its own: the frame carrying it is signed after it.
                let ts = self.signing.clock.next(self.signing_wall());
                let text = format!(
                    "signing setup: key {} sent to {who} on link {link}; it will require signed \
                     frames (no ACK: watching its frames)",
                    key.id()
                );
                // Ours is on from now: the vehicle answers signed.
                self.signing.key = Some(key.clone());
                (*key.as_bytes(), ts, WatchFor::Setup, text)
            }
            SigningAction::Off { .. } => (
                [0u8; 32],
                0,
                WatchFor::Off,
                format!(
                    "signing off: sent to {who} on link {link}; we no longer sign nor check \
                     signatures (no ACK: watching its frames)"
                ),
            ),
        };
        let msg = MavMessage::SETUP_SIGNING(dialect::SETUP_SIGNING_DATA {
            initial_timestamp,
            target_system: target.0,
            target_component: target.1,
            secret_key: secret,
        });
        self.send(link, msg, fx);
        if what == WatchFor::Off {
            // Sent signed with the key it held; from now on nothing is.
            self.signing.key = None;
        }
        self.signing.watch = Some(Watch {
            vehicle: target,
            what,
            until: self.now + WATCH,
            signed: what == WatchFor::Off,
        });
        self.notice(Severity::NOTICE, Some(target), text.clone());
        Ok(Some(text))
    }

    /// What `signing` alone says.
    fn signing_status(&self) -> String {
        match &self.signing.key {
            Some(k) => format!(
                "signing on (key {}): we sign on every link, link id = link number; unsigned \
                 frames rejected but RADIO_STATUS{}, and on ?secure=1 links",
                k.id(),
                if self.signing.allow_unsigned_heartbeat {
                    ", HEARTBEAT"
                } else {
                    ""
                }
            ),
            None if self.signing.configured.is_some() => {
                "signing off (`signing off` sent): `signing setup` turns it on again".into()
            }
            None => "signing off: no key (start with --signing-key); signed frames are taken \
                     unchecked"
                .into(),
        }
    }
}
