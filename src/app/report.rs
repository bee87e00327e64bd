//! The headless JSON report (`--report json`): one object with links and vehicles.
//!
//! Field names and meanings are a contract with scripts: `links[].spec/state/frames/bytes/
//! crc_errors/unknown_ids/sources[].{sysid,compid,received,lost,duplicates,reordered,loss_pct}`,
//! `vehicles[].{sysid,compid,type,autopilot,mode,armed,system_status,lost}`. Extra fields may be
//! added, never renamed. Bounded tables and queues say what they let go: `links[].dropped` (frames
//! a queue dropped), `links[].echoes` (our own frames heard back), `links[].evicted_sources`, and
//! `vehicles_evicted` at the top (with `vehicles_refused`: newcomers turned away because every
//! component kept was the target or busy, and `heartbeat_floods` / `flood_found`: floods of new
//! ids and the components found during them). A tlog link's skipped bytes are in `links[].garbage_bytes`, and
//! where its replay is in `links[].replay.{position_s,duration_s,speed,paused,ended}` (speed 0 =
//! as fast as possible; `null` on other links).
//!
//! `streams[]`, per session (`sysid`, `compid`, `autopilot`), per link heard: `link`, `state`
//! (`due`, `asking`, `flowing`, `failed`, `high-latency`), `requests` (frames sent),
//! `expected_bytes_per_second`, `budget_bytes_per_second` (a serial link with a known baud),
//! and `messages[].{id,name,requested_hz,measured_hz,method,state}` (method:
//! `REQUEST_DATA_STREAM <GROUP>` or `SET_MESSAGE_INTERVAL`).
//!
//! MAVLink signing: `signing.{key,key_id,timestamp}` at the top (whether we sign, the key's
//! short id, never the key; our last timestamp), `links[].{secure,signing_streams,
//! signing_streams_evicted}`, and `links[].sources[].signing.{signed,unchecked,unsigned,
//! bad_signature,replayed,too_old,rejected}`.
//! `outputs[].{spec,state,reason,sent,received,dropped}`: the forwarding outputs (`--out`);
//! `recording.{path,bytes,dropped,error}` (null when not recording): the telemetry log.
//! `version` (mavterm's), `start` (RFC 3339: the wall-clock time the run started; a replay's is
//! its log's start, a `sim://` run on the virtual clock has a fixed one) and `duration_s` (how
//! long the run lasted, in seconds of its clock).

use serde::Serialize;
use serde_json::Value;

use super::links::{loss_pct, LinkState, LinkStatus};
use super::session::Session;
use super::App;
use crate::clock::Micros;
use crate::link::LinkId;
use crate::proto::vehicles::{Vehicle, VehicleKey};

/// The headless report: what [`App::report`] gives as JSON, field for field (the field order is
/// the JSON's).
#[derive(Debug, Serialize)]
pub struct Report<'a> {
    pub version: &'static str,
    /// RFC 3339, to the microsecond.
    pub start: String,
    pub duration_s: f64,
    pub links: Vec<LinkReport<'a>>,
    pub vehicles: Vec<VehicleReport<'a>>,
    pub params: Vec<SessionParams<'a>>,
    pub streams: Vec<SessionStreams>,
    pub vehicles_evicted: u64,
    pub vehicles_refused: u64,
    pub auto_held: u64,
    pub heartbeat_floods: u64,
    pub flood_found: u64,
    pub signing: SigningReport,
    pub outputs: Vec<OutputReport<'a>>,
    pub recording: Option<RecordingReport<'a>>,
}

/// `links[]`.
#[derive(Debug, Serialize)]
pub struct LinkReport<'a> {
    pub spec: &'a str,
    pub state: &'static str,
    pub reason: Option<String>,
    pub frames: u64,
    pub bytes: u64,
    pub crc_errors: u64,
    pub unknown_ids: u64,
    pub truncated: u64,
    pub decode_errors: u64,
    pub garbage_bytes: u64,
    pub signed_frames: u64,
    pub v1_frames: u64,
    pub v2_frames: u64,
    pub loss_pct: f64,
    pub dropped: u64,
    pub echoes: u64,
    pub sent_frames: u64,
    pub sent_bytes: u64,
    pub evicted_sources: u64,
    pub secure: bool,
    pub signing_streams: usize,
    pub signing_streams_evicted: u64,
    pub sources: Vec<SourceReport>,
    pub replay: Option<ReplayReport>,
}

/// `links[].sources[]`: one sender heard on the link.
#[derive(Debug, Serialize)]
pub struct SourceReport {
    pub sysid: u8,
    pub compid: u8,
    pub received: u64,
    pub lost: u64,
    pub duplicates: u64,
    pub reordered: u64,
    pub restarts: u64,
    pub frames: u64,
    pub loss_pct: f64,
    pub loss_pct_10s: f64,
    /// `links[].sources[].signing`.
    pub signing: super::signing::SigningCounts,
}

/// `links[].replay`: where a tlog link's replay is.
#[derive(Debug, Serialize)]
pub struct ReplayReport {
    pub position_s: f64,
    pub duration_s: Option<f64>,
    pub speed: f64,
    pub paused: bool,
    pub ended: bool,
}

/// `vehicles[]`.
#[derive(Debug, Serialize)]
pub struct VehicleReport<'a> {
    pub sysid: u8,
    pub compid: u8,
    #[serde(rename = "type")]
    pub kind: String,
    pub autopilot: String,
    pub mode: String,
    pub custom_mode: u32,
    pub armed: bool,
    pub system_status: String,
    pub lost: bool,
    pub heartbeats: u64,
    pub heartbeat_hz: f64,
    pub links: Vec<&'a LinkId>,
    pub reboots: u32,
    pub conflict: Option<&'a str>,
    pub uses_gcs_sysid: bool,
}

/// `params[]`: a session's parameters.
#[derive(Debug, Serialize)]
pub struct SessionParams<'a> {
    pub sysid: u8,
    pub compid: u8,
    pub components: Vec<ComponentParams<'a>>,
    pub download: Option<DownloadReport<'a>>,
    pub encoding: &'static str,
    pub encoding_by: &'static str,
    pub encoding_suspect: Option<&'a str>,
}

/// `params[].components[]`: how far a component's download got, and its edits.
#[derive(Debug, Serialize)]
pub struct ComponentParams<'a> {
    pub compid: u8,
    pub received: usize,
    pub count: Option<u16>,
    pub complete: bool,
    pub refused_names: u64,
    pub edits: Vec<EditReport<'a>>,
}

/// `params[].components[].edits[]`: an edit and its outcome.
#[derive(Debug, Serialize)]
pub struct EditReport<'a> {
    pub name: &'a str,
    pub value: f64,
    pub state: &'static str,
    pub reason: Option<&'a str>,
    pub vehicle_value: f64,
}

/// `params[].download`: the last download.
#[derive(Debug, Serialize)]
pub struct DownloadReport<'a> {
    pub method: &'static str,
    pub seconds: Option<f64>,
    pub requests: u32,
    pub retries: u32,
    pub fallback: Option<&'a str>,
}

/// `streams[]`: telemetry asked of a session's autopilot.
#[derive(Debug, Serialize)]
pub struct SessionStreams {
    pub sysid: u8,
    pub compid: u8,
    pub links: Vec<LinkStreams>,
}

/// `streams[].links[]`.
#[derive(Debug, Serialize)]
pub struct LinkStreams {
    pub link: LinkId,
    pub state: &'static str,
    pub requests: u32,
    pub expected_bytes_per_second: f64,
    pub budget_bytes_per_second: Option<f64>,
    pub messages: Vec<MessageRate>,
}

/// `streams[].links[].messages[]`.
#[derive(Debug, Serialize)]
pub struct MessageRate {
    pub id: u32,
    pub name: String,
    pub requested_hz: f64,
    pub measured_hz: f64,
    pub method: String,
    pub state: &'static str,
}

/// `signing`: whether we sign, the key's short id (never the key), our last timestamp.
#[derive(Debug, Serialize)]
pub struct SigningReport {
    pub key: bool,
    pub key_id: Option<String>,
    pub timestamp: u64,
    pub state_repaired_from: Option<u64>,
}

/// `outputs[]`: a forwarding output.
#[derive(Debug, Serialize)]
pub struct OutputReport<'a> {
    pub spec: &'a str,
    pub state: &'static str,
    pub reason: Option<String>,
    pub sent: u64,
    pub received: u64,
    pub dropped: u64,
}

/// `recording`: the telemetry log.
#[derive(Debug, Serialize)]
pub struct RecordingReport<'a> {
    pub path: &'a std::path::Path,
    pub bytes: u64,
    pub dropped: u64,
    pub error: Option<&'a str>,
}

/// A link's or output's state for the report: `up`, `connecting` or `down` with the reason.
fn state_reason(s: &LinkState) -> (&'static str, Option<String>) {
    match s {
        LinkState::Up => ("up", None),
        LinkState::Connecting => ("connecting", None),
        LinkState::Down(r) => ("down", Some(r.clone())),
    }
}

fn round2(v: f64) -> f64 {
    (v * 100.0).round() / 100.0
}

impl App {
    /// `all links stayed down: SPEC (REASON), ...` when no link has ever been up (nothing could
    /// be heard, whatever the report says): a headless report then ends in failure.
    pub fn all_links_stayed_down(&self) -> Option<String> {
        if self.links.is_empty() || self.links.iter().any(|l| l.was_up) {
            return None;
        }
        let each: Vec<String> = self
            .links
            .iter()
            .map(|l| match &l.state {
                LinkState::Down(why) => format!("{} ({why})", l.spec),
                LinkState::Connecting | LinkState::Up => format!("{} (never connected)", l.spec),
            })
            .collect();
        Some(format!("all links stayed down: {}", each.join(", ")))
    }

    /// The report as a JSON value (the fields of [`Report`]).
    pub fn report(&self) -> Value {
        // Nothing in it fails to serialise (no map has non-string keys); a path that is not
        // UTF-8 would, and the report then says null rather than stopping the run.
        serde_json::to_value(self.report_doc()).unwrap_or(Value::Null)
    }

    /// The report, borrowed from the app.
    pub fn report_doc(&self) -> Report<'_> {
        let now = self.now;
        Report {
            version: env!("CARGO_PKG_VERSION"),
            start: self
                .cfg
                .epoch
                .to_rfc3339_opts(chrono::SecondsFormat::Micros, true),
            duration_s: now as f64 / 1e6,
            links: self.links.iter().map(|l| link_report(l, now)).collect(),
            vehicles: self.vehicles.iter().map(vehicle_report).collect(),
            params: self
                .sessions
                .iter()
                .map(|(key, s)| params_report(*key, s))
                .collect(),
            streams: self
                .sessions
                .iter()
                .map(|(key, s)| streams_report(*key, s, now))
                .collect(),
            vehicles_evicted: self.vehicles.evicted,
            vehicles_refused: self.vehicles.refused,
            auto_held: self.auto_held,
            heartbeat_floods: self.vehicles.floods,
            flood_found: self.vehicles.flood_found,
            signing: SigningReport {
                key: self.signing.key.is_some(),
                key_id: self.signing.key.as_ref().map(|k| k.id()),
                timestamp: self.signing.clock.last(),
                state_repaired_from: self.signing.repaired_from,
            },
            outputs: self
                .outputs
                .list
                .iter()
                .map(|o| {
                    let (state, reason) = state_reason(&o.state);
                    OutputReport {
                        spec: &o.spec,
                        state,
                        reason,
                        sent: o.sent,
                        received: o.received,
                        dropped: o.dropped,
                    }
                })
                .collect(),
            recording: self.recording.as_ref().map(|r| RecordingReport {
                path: &r.path,
                bytes: r.bytes,
                dropped: r.dropped,
                error: r.error.as_deref(),
            }),
        }
    }
}

fn link_report(l: &LinkStatus, now: Micros) -> LinkReport<'_> {
    let (state, reason) = state_reason(&l.state);
    LinkReport {
        spec: &l.spec,
        state,
        reason,
        frames: l.parser.frames,
        bytes: l.parser.bytes,
        crc_errors: l.parser.crc_errors,
        unknown_ids: l.parser.unknown_ids,
        truncated: l.parser.truncated,
        decode_errors: l.parser.decode_errors,
        garbage_bytes: l.parser.garbage_bytes,
        signed_frames: l.parser.signed_frames,
        v1_frames: l.parser.v1_frames,
        v2_frames: l.parser.v2_frames,
        loss_pct: round2(loss_pct(l.totals())),
        dropped: l.dropped,
        echoes: l.echoes,
        sent_frames: l.sent_frames,
        sent_bytes: l.sent_bytes,
        evicted_sources: l.evicted_sources,
        secure: l.secure,
        signing_streams: l.signing_streams.len(),
        signing_streams_evicted: l.signing_streams.evicted,
        sources: l
            .sources
            .iter()
            .map(|(&VehicleKey(sysid, compid), s)| SourceReport {
                sysid,
                compid,
                received: s.seq.received,
                lost: s.seq.lost,
                duplicates: s.seq.duplicates,
                reordered: s.seq.reordered,
                restarts: s.seq.restarts,
                frames: s.frames,
                loss_pct: round2(s.seq.loss_pct()),
                loss_pct_10s: round2(s.seq.window_loss_pct(now)),
                signing: s.signing,
            })
            .collect(),
        replay: l.replay.as_ref().map(|v| ReplayReport {
            position_s: v.position(now) as f64 / 1e6,
            duration_s: v.status.duration.map(|d| d as f64 / 1e6),
            speed: v.status.speed.get(),
            paused: v.status.paused,
            ended: v.status.ended,
        }),
    }
}

fn vehicle_report(v: &Vehicle) -> VehicleReport<'_> {
    VehicleReport {
        sysid: v.sysid,
        compid: v.compid,
        kind: v.type_name(),
        autopilot: v.autopilot_name(),
        mode: v.mode_name(),
        custom_mode: v.custom_mode,
        armed: v.armed(),
        system_status: v.status_name(),
        lost: v.lost,
        heartbeats: v.heartbeats,
        heartbeat_hz: round2(v.heartbeat_hz()),
        links: v.links.iter().collect(),
        reboots: v.reboots,
        conflict: v.conflict.as_deref(),
        uses_gcs_sysid: v.uses_gcs_sysid,
    }
}

/// Parameters of a session: per component, how far the download got, and every edit with its
/// outcome.
fn params_report(key: VehicleKey, s: &Session) -> SessionParams<'_> {
    use crate::proto::params::EditState;
    let components = s
        .params
        .sets
        .iter()
        .map(|(comp, set)| {
            let (received, count) = set.progress();
            let edits = set
                .params
                .iter()
                .filter_map(|(name, p)| {
                    let e = p.edit.as_ref()?;
                    let (state, reason) = match &e.state {
                        EditState::Pending => ("pending", None),
                        EditState::Confirmed => ("confirmed", None),
                        EditState::Failed(w) => ("failed", Some(w.as_str())),
                    };
                    Some(EditReport {
                        name,
                        value: e.value,
                        state,
                        reason,
                        vehicle_value: p.value,
                    })
                })
                .collect();
            ComponentParams {
                compid: *comp,
                received,
                count,
                complete: set.complete(),
                refused_names: set.refused,
                edits,
            }
        })
        .collect();
    let download = s.params.last.as_ref().map(|d| DownloadReport {
        method: d.method.name(),
        seconds: d.finished.map(|f| (f - d.started) as f64 / 1e6),
        requests: d.requests,
        retries: d.retries,
        fallback: d.fallback.as_deref(),
    });
    SessionParams {
        sysid: key.0,
        compid: key.1,
        components,
        download,
        encoding: s.params.encoding.name(),
        encoding_by: s.params.encoding_by.name(),
        encoding_suspect: s.params.encoding_suspect.as_deref(),
    }
}

/// Telemetry asked of an autopilot, per link: asked and measured rates.
fn streams_report(key: VehicleKey, s: &Session, now: Micros) -> SessionStreams {
    let links = s
        .streams
        .link_states()
        .map(|(link, state)| {
            let messages = s
                .streams
                .report(now, link)
                .into_iter()
                .map(|m| MessageRate {
                    id: m.msgid,
                    name: crate::proto::streams::msg_name(m.msgid),
                    requested_hz: round2(m.requested_hz as f64),
                    measured_hz: round2(m.measured_hz),
                    method: m.method.name(),
                    state: m.state.name(),
                })
                .collect();
            let (bytes, budget) = s.streams.load(link).unwrap_or((0.0, None));
            LinkStreams {
                link,
                state: state.name(),
                requests: s.streams.requests_sent(link),
                expected_bytes_per_second: round2(bytes),
                budget_bytes_per_second: budget,
                messages,
            }
        })
        .collect();
    SessionStreams {
        sysid: key.0,
        compid: key.1,
        links,
    }
}
